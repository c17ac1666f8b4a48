#!/usr/bin/env python3
"""Figures of docs/applications/brazilian_disc.md from a run of scripts/brazilian_disc.rhai.

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/brazilian_disc.rhai --out out/brazilian_disc
    python3 scripts/plot/brazilian_disc.py out/brazilian_disc docs/applications/img [D t f_t]

Reads the run's histories (load.csv, load_bottom.csv, displacement.csv, broken.csv,
energy.csv) and its last crack surface (brazilian_disc_cracks_*.vtu), and writes
three PNGs: load against platen travel (with the level σ_t = f_t, the peak's σ_t/f_t and the broken joints); the
cracks seen along the disc's axis (crack triangles projected on the x–z plane, coloured by the
time they broke, over the disc's outline and the loaded diameter); the energy account.
D [m], t [m] and f_t [Pa] default to the script's 0.1, 0.02 and 8.12e6.
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


def read_csv(path):
    """Columns by name; a header `name [unit]` (a monitor with a unit) is read as `name`."""
    with open(path) as f:
        rows = list(csv.reader(f))
    head, body = rows[0], np.array(rows[1:], dtype=float)
    return {re.sub(r" \[[^\[\]]+\]$", "", h): body[:, i] for i, h in enumerate(head)}


def main(run, out, D=0.1, t=0.02, f_t=8.12e6):
    os.makedirs(out, exist_ok=True)
    prefix = os.path.join(out, "brazilian_disc")
    load = read_csv(os.path.join(run, "load.csv"))
    bottom = read_csv(os.path.join(run, "load_bottom.csv"))
    travel = read_csv(os.path.join(run, "displacement.csv"))
    broken = read_csv(os.path.join(run, "broken.csv"))
    energy = read_csv(os.path.join(run, "energy.csv"))
    to_ratio = 2.0 / (np.pi * D * t) / f_t  # P [N] → σ_t/f_t

    # Load against platen travel (the monitors share their sample times).
    u = travel["displacement"] * 1e3
    P = load["load"] / 1e3
    i = int(np.argmax(P))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(u, P, label="top platen (moving)")
    ax.plot(u, bottom["load_bottom"] / 1e3, "--", lw=0.9, label="bottom platen (held)")
    ax.plot(u[i], P[i], "ko")
    ax.annotate(
        f"P = {P[i]:.1f} kN, σ_t/f_t = {P[i] * 1e3 * to_ratio:.3f}",
        (u[i], P[i]),
        textcoords="offset points",
        xytext=(-200, 12),
        fontsize=9,
    )
    ax.axhline(f_t * np.pi * D * t / 2 / 1e3, color="0.5", lw=0.8, ls=":")
    ax.text(u[0], f_t * np.pi * D * t / 2 / 1e3, " P for σ_t = f_t", ha="left", va="bottom", color="0.4", fontsize=8)
    ax.set_xlabel("platen travel [mm]")
    ax.set_ylabel("load P [kN]")
    ax.grid(alpha=0.3)
    right = ax.twinx()
    right.plot(u, broken["broken"], color="C3", lw=0.8, label="broken joints")
    right.set_ylabel("broken joints", color="C3")
    lines = ax.get_legend_handles_labels()
    more = right.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], loc="center left", fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + "_load.png", dpi=120)
    plt.close(fig)

    # Cracks seen along the axis (y): triangles on the x–z plane, coloured by time.
    R = D / 2
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    th = np.linspace(0, 2 * np.pi, 200)
    ax.plot(R * 1e3 * np.cos(th), R * 1e3 * np.sin(th), color="0.3", lw=1)
    ax.axvline(0.0, color="0.6", lw=0.6, ls="--")
    cracks = sorted(glob.glob(os.path.join(run, "brazilian_disc_cracks_[0-9]*.vtu")))
    n = 0
    if cracks:
        c = meshio.read(cracks[-1])
        tri = c.cells_dict["triangle"]
        n = len(tri)
        xz = c.points[:, [0, 2]][tri] * 1e3
        when = c.cell_data["time"][0] * 1e3
        pc = PolyCollection(xz, array=when, cmap="viridis", edgecolors="face", linewidths=0.6)
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, shrink=0.8, label="time of breaking [ms]")
    t_peak = load["time"][i] * 1e3
    ax.set_title(f"{n} broken joints seen along the axis\n(peak load at {t_peak:.3f} ms)", fontsize=10)
    ax.set_xlim(-R * 1.1e3, R * 1.1e3)
    ax.set_ylim(-R * 1.1e3, R * 1.1e3)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm] (load along z)")
    ax.set_ylabel("z [mm]")
    fig.tight_layout()
    fig.savefig(prefix + "_cracks.png", dpi=120)
    plt.close(fig)

    # Energy account.
    fig, ax = plt.subplots(figsize=(7, 4.5))
    tt = energy["time"] * 1e3
    for name in ["kinetic", "strain", "joint", "contact", "fracture", "friction"]:
        ax.plot(tt, energy[name], label=name)
    ax.plot(tt, energy["reaction_work"], "k--", label="platen work")
    ax.plot(tt, energy["balance_error"], "k:", label="balance error")
    ax.axvline(t_peak, color="0.6", lw=0.6)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("energy [J]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "_energy.png", dpi=120)
    plt.close(fig)
    print("wrote", ", ".join(sorted(glob.glob(prefix + "_*.png"))))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 6):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], *map(float, sys.argv[3:]))
