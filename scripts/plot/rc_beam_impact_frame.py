#!/usr/bin/env python3
"""Side view of one frame of scripts/rc_beam_impact.rhai: the front layer of the half beam's
tetrahedra in their deformed place, coloured by fragment, the weight, plate and bearings in
grey, and the bars coloured by axial force (figures of docs/applications/rc_beam_impact.md).

    python3 -m pip install -r requirements-docs.txt
    python3 scripts/plot/rc_beam_impact_frame.py RUN_DIR OUT.png FRAME [DEPTH] [TITLE]

FRAME is the frame number (every 2 ms), DEPTH the thickness of the front layer shown [m]
(default 0.05: tetrahedra whose reference centroid has y < DEPTH).
"""

import glob
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402


def places(m):
    """Current and reference positions of a frame's nodes: fdem writes the points at their
    current place, so the reference place is points − displacement (adding the displacement
    to the points, as this script once did, drew the concrete displaced twice, away from the
    bars, which are drawn where they are)."""
    x = m.points
    return x, x - m.point_data["displacement"]


def main(run, out, k, depth, title):
    f = sorted(glob.glob(run + "/rc_beam_impact_[0-9]*.vtu"))[k]
    fb = sorted(glob.glob(run + "/rc_beam_impact_bars_[0-9]*.vtu"))[k]
    m, b = meshio.read(f), meshio.read(fb)
    x, x0 = places(m)
    tets = m.cells_dict["tetra"]
    body = m.cell_data["body"][0]
    fragment = m.cell_data["fragment"][0]
    centroid0 = x0[tets].mean(axis=1)
    front = (centroid0[:, 1] < depth) & (body == 0) & (centroid0[:, 0] < 1.6)
    fig, ax = plt.subplots(figsize=(14, 5))
    ax.add_collection(
        PolyCollection(
            [x[t][:, [0, 2]] for t in tets[front]],
            array=(fragment[front] % 20).astype(float),
            cmap="tab20",
            edgecolors="k",
            linewidths=0.1,
        )
    )
    ax.add_collection(
        PolyCollection([x[t][:, [0, 2]] for t in tets[body != 0]], facecolors="grey", alpha=0.3)
    )
    bars = LineCollection(
        [b.points[line][:, [0, 2]] for line in b.cells_dict["line"]],
        array=b.cell_data["axial_force"][0] / 1e3,
        cmap="coolwarm",
        clim=(-300, 300),
        linewidths=2,
    )
    ax.add_collection(bars)
    fig.colorbar(bars, label="bar axial force [kN]")
    ax.set_xlim(-0.05, 1.6)
    ax.set_ylim(-0.15, 0.8)
    ax.set_aspect("equal")
    ax.set_xlabel("x from mid-span [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(title or f"{f.split('/')[-1]} (front layer y < {depth} m)")
    fig.savefig(out, dpi=70, bbox_inches="tight")


if __name__ == "__main__":
    a = sys.argv
    main(a[1], a[2], int(a[3]), float(a[4]) if len(a) > 4 else 0.05, a[5] if len(a) > 5 else "")
