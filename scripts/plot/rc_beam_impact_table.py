#!/usr/bin/env python3
"""The seven-test table of docs/applications/rc_beam_impact.md from runs of scripts/rc_beam_impact.rhai.

    fdem run scripts/rc_beam_impact.rhai --set series=SS2 --set mass=600 --out runs/SS2b/out \\
        > runs/SS2b/run.log 2>&1
    ...
    python3 scripts/plot/rc_beam_impact_table.py SS2b=runs/SS2b SS3b=runs/SS3b ...

Each argument is TEST=DIR: DIR holds the run's console output (run.log) and its output
directory (out/). Prints one Markdown row per test, in the order given: the measured peak and
residual mid-span displacement (Saatci 2007), fdem's (from the log) with the relative error,
when the beam stopped the weight (its first upward speed before the damped phase, whose start
is read from energy.csv's mass-damping column), the impact force over 0.1 ms, the largest
support reaction, joints broken, fragments, the longitudinal bars' largest plastic strain, the
energy balance error and the run's wall time. Needs numpy.
"""

import csv
import os
import re
import sys

import numpy as np

# Measured (Saatci 2007): peak / residual mid-span displacement [mm], stirrup spacing, mass.
MEASURED = {
    "SS0b": (None, None, "none", "600 kg"), "SS1b": (39.5, 17.7, "300 mm", "600 kg"),
    "SS2b": (37.9, 18.5, "200 mm", "600 kg"), "SS3b": (35.3, 17.7, "100 mm", "600 kg"),
    "SS0a": (9.3, 1.6, "none", "211 kg"), "SS1a": (12.1, 0.9, "300 mm", "211 kg"),
    "SS2a": (10.0, 0.5, "200 mm", "211 kg"), "SS3a": (None, None, "100 mm", "211 kg"),
}
SS3A_FORCE_KN = 1421.0


def column(path, name):
    with open(path) as f:
        rows = list(csv.reader(f))
    i = rows[0].index(name)
    return np.array([float(r[i]) for r in rows[1:]])


def row(test, run):
    peak_m, resid_m, stirrups, mass = MEASURED[test]
    log = open(os.path.join(run, "run.log")).read()

    def num(pattern):
        m = re.search(pattern, log)
        return float(m.group(1)) if m else float("nan")

    def rel(x, ref):
        return f" ({(x - ref) / ref * 100:+.0f} %)" if ref else ""

    peak, resid = num(r"peak ([\d.]+) mm, at the end"), num(r"at the end ([\d.]+) mm;")
    force = num(r"peak impact force: ([\d.]+) kN")
    out = os.path.join(run, "out")
    t = column(os.path.join(out, "weight_velocity.csv"), "time")
    v = column(os.path.join(out, "weight_velocity.csv"), "weight_velocity [m/s]")
    te, damping = column(os.path.join(out, "energy.csv"), "time"), column(os.path.join(out, "energy.csv"), "mass_damping")
    damped_from = te[np.argmax(damping > 0)] if (damping > 0).any() else np.inf
    up = np.nonzero((v >= 0) & (t < damped_from))[0]
    stopped = f"at {t[up[0]] * 1e3:.1f} ms" if len(up) else "no"
    # The weight's displacement (the beam's top under the plate), integrated from its velocity.
    z = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))
    weight_peak = -z.min() * 1e3
    measured = "failed: shear plug" if test == "SS0b" else (
        f"— (force {SS3A_FORCE_KN:.0f} kN)" if test == "SS3a" else f"{peak_m} / {resid_m}")
    reaction, broken = num(r"largest support reaction ([\d.]+) kN"), num(r"(\d+) joints broken;")
    fragments, strain = num(r"fragments\s+(\d+)"), num(r"plastic strain ([\d.e-]+)")
    balance, wall = num(r"balance (-?[\d.e-]+)\n"), num(r"([\d.]+) s wall")
    ref_force = SS3A_FORCE_KN if test == "SS3a" else None
    cells = [
        test, stirrups, mass, measured, f"{peak:.1f}{rel(peak, peak_m)}", f"{resid:.1f}{rel(resid, resid_m)}",
        f"{weight_peak:.1f}",
        stopped, f"{force:.0f}{rel(force, ref_force)}", f"{reaction:.0f}", f"{broken:.0f}",
        f"{fragments:.0f}", f"{strain:.3g}", f"{balance:.1e}", f"{wall / 60:.0f} min",
    ]
    return "| " + " | ".join(cells) + " |"


if __name__ == "__main__":
    print("| test | stirrups | mass | measured peak / residual [mm] | fdem peak [mm] | fdem at rest [mm] "
          "| weight's peak [mm] | weight stopped (test: all but SS0b) | force, 0.1 ms [kN] | largest support reaction [kN] "
          "| joints broken | fragments | bars ε_p | balance | wall |")
    print("|" + "---|" * 15)
    for arg in sys.argv[1:]:
        test, run = arg.split("=", 1)
        print(row(test, run))
