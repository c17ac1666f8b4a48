#!/usr/bin/env python3
"""Figures of docs/applications/notched_beam.md from runs of scripts/notched_beam.rhai.

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/notched_beam.rhai --out out/notched_beam
    python3 scripts/plot/notched_beam.py out/notched_beam docs/applications/img
    python3 scripts/plot/notched_beam.py --compare docs/applications/img/notched_beam_mesh.png \
        "out/nb_h25:structured 25 mm" "out/nb_h12:structured 12.5 mm" ...

The first form reads one run's histories (load.csv, load_top.csv, deflection.csv, energy.csv)
and its last frame (notched_beam_*.vtu), and writes three PNGs: the load–deflection curve
against Petersson's measured band of peaks (0.75–0.8 kN); the energy account against the
deflection, with G_F times the ligament area; the cracked state (the front face of the beam
around mid-span, displacements magnified, coloured by joint damage). The second form overlays
the load–deflection curves of several runs ("directory:label") in one figure.
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
from matplotlib.collections import PolyCollection  # noqa: E402

BAND = (0.75, 0.80)  # Petersson's measured peaks [kN]
G_F_A = 124.0 * 0.1 * 0.05  # G_F × ligament area [J]


def read_csv(path):
    """Columns by name; a header `name [unit]` (a monitor with a unit) is read as `name`."""
    with open(path) as f:
        rows = list(csv.reader(f))
    head, body = rows[0], np.array(rows[1:], dtype=float)
    return {re.sub(r" \[[^\[\]]+\]$", "", h): body[:, i] for i, h in enumerate(head)}


def curve(run):
    load = read_csv(os.path.join(run, "load.csv"))
    defl = read_csv(os.path.join(run, "deflection.csv"))
    n = min(len(load["load"]), len(defl["deflection"]))
    return defl["deflection"][:n] * 1e3, load["load"][:n] / 1e3


def band(ax):
    ax.axhspan(*BAND, color="C2", alpha=0.2, lw=0)
    ax.text(0.55, BAND[1], " Petersson (1981): measured peaks 0.75–0.8 kN", color="C2",
            fontsize=8, va="bottom", transform=ax.get_yaxis_transform())


def single(run, out):
    os.makedirs(out, exist_ok=True)
    prefix = os.path.join(out, "notched_beam")
    d, P = curve(run)
    top = read_csv(os.path.join(run, "load_top.csv"))["load_top"][: len(P)] / 1e3
    i = int(np.argmax(P))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    band(ax)
    ax.plot(d, P, label="support reactions (the load P)")
    ax.plot(d, top, "--", lw=0.8, label="reaction at the load line")
    # After the crack snaps through, the beam rings at its first bending mode (about 70 Hz with
    # the heavier band); a running mean over 15 ms shows the load it carries.
    t = read_csv(os.path.join(run, "load.csv"))["time"][: len(P)]
    k = max(1, int(round(0.015 / max(t[1] - t[0], 1e-12))))
    if len(P) > 2 * k:
        mean = np.convolve(P, np.ones(k) / k, mode="valid")
        dm = d[k // 2: k // 2 + len(mean)]
        after = dm > d[i]
        ax.plot(dm[after], mean[after], color="k", lw=1.0, label="P, running mean over 15 ms")
    ax.plot(d[i], P[i], "ko")
    ax.annotate(f"peak {P[i]:.3f} kN at {d[i]:.2f} mm", (d[i], P[i]), textcoords="offset points",
                xytext=(10, 8), fontsize=9)
    ax.set_xlabel("mid-span deflection [mm]")
    ax.set_ylabel("load P [kN]")
    ax.set_ylim(bottom=min(0.0, P.min()))
    ax.grid(alpha=0.3)
    ax.legend(loc="center right", fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + "_load.png", dpi=120)
    plt.close(fig)

    # Energy account against the deflection (energy.csv has its own sample times).
    e = read_csv(os.path.join(run, "energy.csv"))
    defl = read_csv(os.path.join(run, "deflection.csv"))
    de = np.interp(e["time"], defl["time"], defl["deflection"]) * 1e3
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(de, e["reaction_work"], label="work of the supports and load line")
    ax.plot(de, e["fracture"], label="dissipated by the joints (fracture)")
    ax.plot(de, e["strain"] + e["joint"], label="elastic: tetrahedra + joints")
    ax.plot(de, e["kinetic"], label="kinetic")
    ax.plot(de, e["balance_error"], ":", color="0.3", label="balance error")
    ax.axhline(G_F_A, color="C3", lw=0.8, ls="--")
    ax.text(de[0], G_F_A, " G_F × ligament area = 0.62 J", color="C3", fontsize=8, va="bottom")
    ax.set_xlabel("mid-span deflection [mm]")
    ax.set_ylabel("energy [J]")
    ax.grid(alpha=0.3)
    ax.legend(loc="center right", fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + "_energy.png", dpi=120)
    plt.close(fig)

    # Cracked state: front-face triangles (y = 0) of the tetrahedra near mid-span, deformed.
    frames = sorted(f for f in glob.glob(os.path.join(run, "notched_beam_*.vtu")) if "cracks" not in f)
    m = meshio.read(frames[-1])
    u = m.point_data["displacement"]
    x0 = m.points - u  # the frames hold the current positions
    tets = m.cells_dict["tetra"]
    dmg = m.cell_data_dict["damage"]["tetra"]
    # Displacements relative to the load line's (mid-span, top), magnified.
    ref = np.mean(u[(np.abs(x0[:, 0]) < 1e-7) & (np.abs(x0[:, 2] - x0[:, 2].max()) < 1e-7)], axis=0)
    u = u - ref
    scale = 50.0
    polys, vals = [], []
    for t, dv in zip(tets, dmg):
        on = [n for n in t if abs(x0[n, 1]) < 1e-7]
        if len(on) != 3 or abs(x0[on, 0]).max() > 0.21:
            continue
        p = x0[on] + scale * u[on]
        polys.append(p[:, [0, 2]] * 1e3)
        vals.append(dv)
    fig, ax = plt.subplots(figsize=(8, 4.2))
    pc = PolyCollection(polys, array=np.array(vals), cmap="inferno_r", edgecolors="0.6", linewidths=0.2)
    pc.set_clim(0.0, 1.0)
    ax.add_collection(pc)
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm] (mid-span at 0)")
    ax.set_ylabel("z [mm]")
    ax.set_title(f"front face at {d[-1]:.2f} mm deflection, displacements relative to the load line × {scale:g}", fontsize=9)
    fig.colorbar(pc, ax=ax, label="damage of the tetrahedron's joints", shrink=0.8)
    fig.tight_layout()
    fig.savefig(prefix + "_cracks.png", dpi=120)
    plt.close(fig)


def compare(png, runs):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    band(ax)
    for r in runs:
        run, label = r.split(":", 1)
        d, P = curve(run)
        ax.plot(d, P, lw=1.0, label=f"{label}: peak {P.max():.3f} kN")
    ax.set_xlabel("mid-span deflection [mm]")
    ax.set_ylabel("load P [kN]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3:])
    elif len(sys.argv) == 3:
        single(sys.argv[1], sys.argv[2])
    else:
        sys.exit(__doc__)
