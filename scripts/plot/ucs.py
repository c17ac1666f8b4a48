#!/usr/bin/env python3
"""Figures of docs/applications/ucs.md from runs of scripts/ucs.rhai.

    python3 -m pip install -r requirements-docs.txt
    python3 scripts/plot/ucs.py STUDY_DIR docs/applications/img

STUDY_DIR holds one output directory per run, named as the study in docs/applications/ucs.md
runs them: v<speed> (12.5 mm cells at that platen speed), s<size> (structured, 0.25 m/s) and
g<size> (gmsh, 0.25 m/s); the structured 12.5 mm run at 0.25 m/s is v0.25. Each directory has
stress.csv, strain.csv and the ucs_cracks_*.vtu frames. Writes ucs_stress_strain.png (the
mesh study's curves against σ_c), ucs_speed.png (peak stress against platen speed) and
ucs_cracks.png (the broken joints of the finest structured and unstructured runs).
"""

import csv
import glob
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

# The script's defaults: c = 20 MPa, φ = 30°.
SIGMA_C = 2 * 20.0 * math.cos(math.radians(30)) / (1 - math.sin(math.radians(30)))


def column(path, name):
    """The column `name` of a CSV history; its header may carry a unit (`name [unit]`)."""
    with open(path) as f:
        rows = list(csv.reader(f))
    i = [re.sub(r" \[[^\[\]]+\]$", "", h) for h in rows[0]].index(name)
    return np.array([float(r[i]) for r in rows[1:]])


def curve(run):
    s = column(os.path.join(run, "stress.csv"), "stress")
    e = column(os.path.join(run, "strain.csv"), "strain")
    n = min(len(s), len(e))
    return e[:n] * 1000.0, s[:n]


def runs(study, prefix):
    """(value, directory) of the runs named prefix<value>, sorted by value."""
    out = []
    for d in glob.glob(os.path.join(study, prefix + "[0-9]*")):
        if os.path.isdir(d):
            out.append((float(os.path.basename(d)[len(prefix):]), d))
    return sorted(out)


def main(study, img):
    os.makedirs(img, exist_ok=True)
    # Stress–strain curves of the mesh study.
    fig, ax = plt.subplots(figsize=(7, 4.5))
    sized = [(0.0125, os.path.join(study, "v0.25"))] + runs(study, "s")
    for size, d in sized:
        e, s = curve(d)
        ax.plot(e, s, lw=1.2, label=f"structured, {size * 1000:.3g} mm")
    for size, d in runs(study, "g"):
        e, s = curve(d)
        ax.plot(e, s, lw=1.2, ls="--", label=f"gmsh, {size * 1000:.3g} mm")
    ax.axhline(SIGMA_C, color="k", lw=0.8, ls=":")
    ax.text(0.05, SIGMA_C + 1.0, "σ_c = 2c cos φ/(1 − sin φ)", fontsize=8)
    ax.set_xlabel("axial strain [‰]")
    ax.set_ylabel("axial stress [MPa]")
    ax.set_title("UCS of a jointed prism: mesh study (platen 0.25 m/s)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "ucs_stress_strain.png"), dpi=120)

    # Peak stress against platen speed.
    speeds = runs(study, "v")
    if speeds:
        fig, ax = plt.subplots(figsize=(6, 3.8))
        v = [x for x, _ in speeds]
        peaks = [curve(d)[1].max() / SIGMA_C for _, d in speeds]
        ax.semilogx(v, peaks, "o-")
        ax.set_xlabel("platen speed [m/s]")
        ax.set_ylabel("peak stress / σ_c")
        ax.set_title("Rate effect of loading speed (12.5 mm cells)")
        ax.grid(alpha=0.3, which="both")
        fig.tight_layout()
        fig.savefig(os.path.join(img, "ucs_speed.png"), dpi=120)

    # Broken joints of the finest runs.
    finest = runs(study, "s")[:1] + runs(study, "g")[:1]
    if finest:
        fig = plt.figure(figsize=(4.2 * len(finest), 5))
        for k, (size, d) in enumerate(finest):
            ax = fig.add_subplot(1, len(finest), k + 1, projection="3d")
            frames = sorted(glob.glob(os.path.join(d, "ucs_cracks_[0-9]*.vtu")))
            n = 0
            if frames:
                c = meshio.read(frames[-1])
                tris = np.vstack([b.data for b in c.cells if b.type == "triangle"])
                n = len(tris)
                ax.add_collection3d(
                    Poly3DCollection(c.points[tris], facecolor="crimson", edgecolor="darkred", lw=0.2)
                )
            ax.set_xlim(0, 0.05)
            ax.set_ylim(0, 0.05)
            ax.set_zlim(0, 0.1)
            ax.set_box_aspect((1, 1, 2))
            ax.view_init(elev=15, azim=-60)
            kind = "structured" if os.path.basename(d).startswith("s") else "gmsh"
            ax.set_title(f"{kind}, {size * 1000:.3g} mm: {n} broken joints", fontsize=9)
        fig.tight_layout()
        fig.savefig(os.path.join(img, "ucs_cracks.png"), dpi=120)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
