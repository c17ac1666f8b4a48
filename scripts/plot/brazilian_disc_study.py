#!/usr/bin/env python3
"""The mesh and speed study table of docs/applications/brazilian_disc.md, from the runs' logs.

    fdem run scripts/brazilian_disc.rhai --set size=0.008 --set speed=0.4 --out study/s8_v0.4 \
        > study/s8_v0.4.log 2>&1          # one run per row; any directory names
    python3 scripts/plot/brazilian_disc_study.py study/*.log

Each LOG is the console output of one run (its output directory is LOG without `.log`, for
cracks.csv). Prints one Markdown row per run, with the script's own printed figures: mesh,
target and mean element size, platen speed, failure load P, σ_t/f_t, the held platen's load
over P at the peak and the rms of the two platens' difference over the rise from P/2 to the
peak (from load.csv and load_bottom.csv, as the script's check), the first broken joint (place, mode), the primary crack's share on the
loaded diameter and its span, the energy balance error and the wall time (`/usr/bin/time -f
"%e s wall"` lines, if present). No third-party packages needed.
"""

import csv
import os
import re
import sys

MODES = {"1": "I", "2": "II", "3": "mixed"}


def grab(pattern, text, cast=float, default=None):
    m = re.search(pattern, text)
    return cast(m.group(1)) if m else default


def rise_rms(run):
    """rms of (top − bottom)/P over the rise from P/2 to the peak (the script's check)."""
    try:
        with open(os.path.join(run, "load.csv"), newline="") as f:
            top = [float(r[2]) for r in list(csv.reader(f))[1:]]
        with open(os.path.join(run, "load_bottom.csv"), newline="") as f:
            bottom = [float(r[2]) for r in list(csv.reader(f))[1:]]
    except (OSError, IndexError, ValueError):
        return None
    if not top:
        return None
    i_peak = max(range(len(top)), key=lambda k: top[k])
    P = top[i_peak]
    d = [(top[k] - bottom[k]) / P for k in range(min(i_peak + 1, len(bottom))) if top[k] >= 0.5 * P]
    return (sum(x * x for x in d) / len(d)) ** 0.5 if d else None


def row(log):
    text = open(log, encoding="utf-8").read()
    mesh = grab(r"disc: .*?, (\w+) mesh at size", text, str, "?")
    size = grab(r"mesh at size ([\d.]+) mm", text)
    tets = grab(r": (\d+) tetrahedra", text, int)
    mean = grab(r"mean element size ([\d.]+) mm", text)
    P = grab(r"peak load P = ([\d.]+) kN", text)
    ratio = grab(r"σ_t/f_t = ([\d.]+)", text)
    bottom = grab(r"bottom platen then ([\d.]+) kN", text)
    split = re.search(r"primary crack: (\d+) of its (\d+) joints", text)
    span = grab(r"spans ([\d.]+) % of D", text)
    balance = grab(r"balance error (-?[\d.e+-]+)\n", text)
    wall = grab(r"([\d.]+) s wall", text)
    speed = grab(r"--set speed=([\d.]+)", text)
    if speed is None:  # the script does not print it: from a name like s8_v0.4.log
        speed = grab(r"_v([\d.]+)\.log$", log)
    first = "–"
    run = log[: -len(".log")] if log.endswith(".log") else log
    rms = rise_rms(run)
    cracks = os.path.join(run, "cracks.csv")
    if os.path.exists(cracks):
        with open(cracks, newline="") as f:
            rows = list(csv.DictReader(f))
        if rows:
            r = min(rows, key=lambda r: float(r["time"]))
            first = "({:.1f}, {:.1f}), {}".format(
                1e3 * float(r["x"]), 1e3 * float(r["z"]), MODES.get(r["mode"], r["mode"])
            )
    name = os.path.basename(log)

    def f(x, fmt):
        return "?" if x is None else fmt.format(x)

    return "| {} | {} | {} | {} | {} | {} | {} | **{}** | {} | {} | {} | {} | {} | {} | {} |".format(
        name,
        mesh,
        f(size, "{:g}"),
        f(tets, "{}"),
        f(mean, "{:g}"),
        f(speed, "{:g}"),
        f(P, "{:.2f}"),
        f(ratio, "{:.3f}"),
        "?" if (bottom is None or P is None) else "{:.2f}".format(bottom / P),
        f(rms, "{:.3f}"),
        first,
        "{}/{}".format(split.group(1), split.group(2)) if split else "–",
        f(span / 100 if span is not None else None, "{:.2f}"),
        f(balance, "{:.2g}"),
        f(wall, "{:.0f}"),
    )


def main(logs):
    print(
        "| run | mesh | size [mm] | tets | mean size [mm] | speed [m/s] | P [kN] | σ_t/f_t |"
        " bottom/top at P | platens rms over the rise | first break: (x, z) [mm], mode | split | span |"
        " balance error / largest term | wall [s] |"
    )
    print("|" + "---|" * 15)
    for log in logs:
        print(row(log))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
