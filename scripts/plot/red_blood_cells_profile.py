#!/usr/bin/env python3
"""Height profiles of a red-blood-cell bed (docs/applications/red_blood_cells.md).

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/red_blood_cells.rhai --threads 2 --set cells=1000 --set width=60e-6 ...
    python3 scripts/plot/red_blood_cells_profile.py out/red_blood_cells 60e-6 [--slab 4e-6] [--frame N] [--quadrants ZTOP]

Arguments: the run's output directory and the tray's width [m]. Reads the last frame
(red_blood_cells_*.vtu, or frame N) and prints two Markdown tables over height z (the floor
at z = 0): the cells' solid fraction in horizontal slabs of the core column (one cell
diameter D = 7.82 µm in from the walls, as the script's core), and the cells' mean vertical
velocity in slabs twice as thick (each cell counted once, at its centroid, with the mean
velocity of its nodes), which tells a bed at rest from cells still sinking.

With `--quadrants ZTOP` (the core's top [m], as the script prints it: the core runs from
z = D to ZTOP) it also prints the solid fraction of the core's four quarters in x and y, a
measure of the packing's spread within one run.

The solid fraction bins each tetrahedron's volume by its centroid: exact for the whole core,
within about a tet's height (~1 µm at the default cell size) at the slab boundaries. The
script's own core figure (`core ... solid fraction`) clips exactly and is the one to quote.
"""

import argparse
import glob
import os
import re

import meshio
import numpy as np

D = 2.0 * 3.91e-6  # cell diameter [m]
WALLS = 5  # floor and four walls: the last five bodies


def last_frame(out, frame):
    frames = sorted(glob.glob(os.path.join(out, "red_blood_cells_[0-9]*.vtu")))
    if not frames:
        raise SystemExit(f"no red_blood_cells_*.vtu in {out}")
    if frame is None:
        return frames[-1]
    by_number = {int(re.search(r"_(\d+)\.vtu$", f).group(1)): f for f in frames}
    if frame not in by_number:
        raise SystemExit(f"no frame {frame} in {out} (frames {min(by_number)}–{max(by_number)})")
    return by_number[frame]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("width", type=float)
    ap.add_argument("--slab", type=float, default=4e-6, help="slab height for the solid fraction [m]")
    ap.add_argument("--frame", type=int, default=None)
    ap.add_argument("--quadrants", type=float, default=None, metavar="ZTOP", help="core top [m]: print the core's quarters")
    a = ap.parse_args()

    path = last_frame(a.out, a.frame)
    m = meshio.read(path)
    tets = m.get_cells_type("tetra")
    body = np.asarray(m.cell_data_dict["body"]["tetra"]).astype(int)
    cells = body < body.max() - (WALLS - 1)
    x = m.points  # fdem writes the current positions
    v = np.asarray(m.point_data["velocity"])
    p = x[tets[cells]]  # (n, 4, 3)
    vol = np.abs(np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))) / 6.0
    c = p.mean(axis=1)

    lo, hi = D, a.width - D
    if hi - lo < 2 * D:
        raise SystemExit(f"a {a.width * 1e6:.1f} µm tray has no core two cells wide one diameter from the walls")
    core = (c[:, 0] > lo) & (c[:, 0] < hi) & (c[:, 1] > lo) & (c[:, 1] < hi)
    top = c[:, 2].max()
    edges = np.arange(0.0, top + a.slab, a.slab)
    area = (hi - lo) ** 2
    phi, _ = np.histogram(c[core, 2], bins=edges, weights=vol[core])
    phi /= area * a.slab

    # Per cell: centroid (volume-weighted) and the mean velocity of its nodes.
    ids = body[cells]
    n_cells = ids.max() + 1
    cvol = np.bincount(ids, weights=vol, minlength=n_cells)
    cz = np.bincount(ids, weights=vol * c[:, 2], minlength=n_cells) / np.maximum(cvol, 1e-300)
    node_vz = v[tets[cells]][:, :, 2].mean(axis=1)
    cvz = np.bincount(ids, weights=vol * node_vz, minlength=n_cells) / np.maximum(cvol, 1e-300)
    vedges = np.arange(0.0, top + 2 * a.slab, 2 * a.slab)
    counts, _ = np.histogram(cz, bins=vedges)
    vsum, _ = np.histogram(cz, bins=vedges, weights=cvz)
    mean_vz = np.where(counts > 0, vsum / np.maximum(counts, 1), np.nan)

    print(f"frame {os.path.basename(path)}; core {lo * 1e6:.1f}–{hi * 1e6:.1f} µm in x and y")
    print()
    print("| height [µm] | " + " | ".join(f"{edges[i] * 1e6:.0f}–{edges[i + 1] * 1e6:.0f}" for i in range(len(phi))) + " |")
    print("|---|" + "---|" * len(phi))
    print("| core solid fraction | " + " | ".join(f"{f:.3f}" for f in phi) + " |")
    print()
    print("| height [µm] | " + " | ".join(f"{vedges[i] * 1e6:.0f}–{vedges[i + 1] * 1e6:.0f}" for i in range(len(mean_vz))) + " |")
    print("|---|" + "---|" * len(mean_vz))
    print("| cells | " + " | ".join(f"{n}" for n in counts) + " |")
    print("| mean v_z [mm/s] | " + " | ".join("—" if np.isnan(u) else f"{u * 1e3:+.3f}" for u in mean_vz) + " |")

    if a.quadrants is not None:
        mid = 0.5 * (lo + hi)
        height = a.quadrants - D
        inz = core & (c[:, 2] > D) & (c[:, 2] < a.quadrants)
        whole = vol[inz].sum() / (area * height)
        cols = []
        for qx, qy in ((0, 0), (1, 0), (0, 1), (1, 1)):
            sel = inz & ((c[:, 0] > mid) == bool(qx)) & ((c[:, 1] > mid) == bool(qy))
            cols.append(vol[sel].sum() / (0.25 * area * height))
        print()
        print(f"| core, z {D * 1e6:.1f}–{a.quadrants * 1e6:.1f} µm | whole | x−y− | x+y− | x−y+ | x+y+ | spread (std) |")
        print("|---|---|---|---|---|---|---|")
        print(f"| solid fraction | {whole:.4f} | " + " | ".join(f"{f:.4f}" for f in cols) + f" | {np.std(cols, ddof=1):.4f} |")


if __name__ == "__main__":
    main()
