#!/usr/bin/env python3
"""Figures of docs/applications/rc_beam_impact.md from a run of scripts/rc_beam_impact.rhai.

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/rc_beam_impact.rhai --set series=SS2 --set mass=600 --out out/SS2b
    python3 scripts/plot/rc_beam_impact.py out/SS2b docs/applications/img SS2b 600 37.9 18.5

Arguments: the run's directory, the image directory, the test's name, the drop mass [kg] and
the measured peak and residual mid-span displacements [mm] (0 when not measured). Reads the
run's histories (displacement.csv, weight_velocity.csv, support_reaction.csv, energy.csv) and
its last frames (rc_beam_impact_*.vtu, *_cracks_*.vtu, *_bars_*.vtu), and writes
<image dir>/rc_beam_impact_<test>_histories.png (mid-span displacement, impact force as the
weight's mass × deceleration over 0.1 ms windows, support reaction, against time) and
<image dir>/rc_beam_impact_<test>_cracks.png (a side view of the half beam: crack faces, and
the bars coloured by axial force).
"""

import csv
import glob
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402


def read_csv(path):
    """Columns by name; a header `name [unit]` (a monitor with a unit) is read as `name`."""
    with open(path) as f:
        rows = list(csv.reader(f))
    head, body = rows[0], np.array(rows[1:], dtype=float)
    return {re.sub(r" \[[^\[\]]+\]$", "", h): body[:, i] for i, h in enumerate(head)}


def windowed_force(t, v, mass, window=1e-4):
    """mass × mean deceleration over consecutive windows of `window` seconds."""
    out_t, out_f = [], []
    k0 = 0
    for k in range(1, len(t)):
        if t[k] - t[k0] >= window:
            out_t.append(0.5 * (t[k] + t[k0]))
            out_f.append(mass * (v[k] - v[k0]) / (t[k] - t[k0]))
            k0 = k
    return np.array(out_t), np.array(out_f)


def main(run, out, test, mass, peak, residual):
    os.makedirs(out, exist_ok=True)
    prefix = os.path.join(out, f"rc_beam_impact_{test}")
    d = read_csv(os.path.join(run, "displacement.csv"))
    w = read_csv(os.path.join(run, "weight_velocity.csv"))
    r = read_csv(os.path.join(run, "support_reaction.csv"))
    tf, f = windowed_force(w["time"], w["weight_velocity"], mass)
    fig, ax = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    ax[0].plot(d["time"] * 1e3, d["displacement"] * 1e3, color="navy", label="fdem")
    if peak > 0:
        ax[0].axhline(peak, color="crimson", ls="--", lw=1, label=f"measured peak {peak} mm")
    if residual > 0:
        ax[0].axhline(residual, color="darkorange", ls=":", lw=1.2, label=f"measured residual {residual} mm")
    ax[0].set_ylabel("mid-span displacement [mm]")
    ax[0].legend(loc="lower right")
    ax[1].plot(tf * 1e3, f / 1e3, color="darkgreen")
    ax[1].set_ylabel("impact force [kN]\n(m·a, 0.1 ms windows)")
    ax[2].plot(r["time"] * 1e3, r["support_reaction"] / 1e3, color="purple", lw=0.8)
    ax[2].set_ylabel("support reaction [kN]")
    ax[2].set_xlabel("time [ms]")
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle(f"{test}: {mass:g} kg at 8 m/s (fdem, half beam by symmetry)")
    fig.tight_layout()
    fig.savefig(prefix + "_histories.png", dpi=120)

    frames = sorted(glob.glob(os.path.join(run, "rc_beam_impact_[0-9]*.vtu")))
    cracks = sorted(glob.glob(os.path.join(run, "rc_beam_impact_cracks_[0-9]*.vtu")))
    bars = sorted(glob.glob(os.path.join(run, "rc_beam_impact_bars_[0-9]*.vtu")))
    fig, ax = plt.subplots(figsize=(11, 4.4))
    m = meshio.read(frames[-1])
    pts = m.points
    scale = 1.0
    if cracks:
        c = meshio.read(cracks[-1])
        tri = c.cells_dict.get("triangle", np.zeros((0, 3), int))
        polys = c.points[tri][:, :, [0, 2]]
        ax.add_collection(PolyCollection(polys, facecolor=(0.8, 0.1, 0.1, 0.25), edgecolor=(0.6, 0.0, 0.0, 0.5), lw=0.3))
    if bars:
        b = meshio.read(bars[-1])
        lines = b.cells_dict["line"]
        force = b.cell_data["axial_force"][0] / 1e3
        segs = b.points[lines][:, :, [0, 2]]
        lc = LineCollection(segs, array=force, cmap="coolwarm", lw=1.6)
        lim = max(1.0, np.abs(force).max())
        lc.set_clim(-lim, lim)
        ax.add_collection(lc)
        fig.colorbar(lc, ax=ax, label="bar axial force [kN]", fraction=0.03)
    ax.plot(pts[:, 0] * scale, pts[:, 2] * scale, ",", color=(0.4, 0.4, 0.4, 0.3))
    # The beam, the plate and the weight; spalled debris far below the soffit is left out.
    ax.set_xlim(-0.05, pts[:, 0].max() + 0.05)
    ax.set_ylim(-0.15, min(pts[:, 2].max(), 0.8) + 0.05)
    ax.set_aspect("equal")
    ax.set_xlabel("x from mid-span [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(f"{test}: cracks (red, broken joints) and bar forces at the end of the run")
    fig.tight_layout()
    fig.savefig(prefix + "_cracks.png", dpi=120)


if __name__ == "__main__":
    if len(sys.argv) != 7:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6]))
