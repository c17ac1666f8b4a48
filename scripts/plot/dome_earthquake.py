#!/usr/bin/env python3
"""Figures of docs/applications/dome_earthquake.md from a run of scripts/dome_earthquake.rhai.

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/dome_earthquake.rhai --out out/dome_earthquake
    python3 scripts/plot/dome_earthquake.py out/dome_earthquake docs/applications/img

Reads the run's CSV histories (ground.csv, crown.csv, broken.csv, energy.csv) and its last
ParaView frames (dome_*.vtu, dome_cracks_*.vtu), and writes PNGs with the given prefix:
record and response histories, the 5 %-damped response spectrum of the applied motion
(computed here from ground.csv, Newmark average acceleration — an independent check of the
record the model received), the energy account, and a picture of the vault with its cracks.
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
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

G = 9.80665


def read_csv(path):
    """Columns by name; a header `name [unit]` (a monitor with a unit) is read as `name`."""
    with open(path) as f:
        rows = list(csv.reader(f))
    head, body = rows[0], np.array(rows[1:], dtype=float)
    return {re.sub(r" \[[^\[\]]+\]$", "", h): body[:, i] for i, h in enumerate(head)}


def spectrum(t, a, periods, zeta=0.05):
    """Pseudo-acceleration Sa(T) [m/s²] of u'' + 2ζωu' + ω²u = −a, Newmark average
    acceleration on the samples (uniform step)."""
    dt = np.mean(np.diff(t))
    out = []
    for T in periods:
        w = 2 * np.pi / T
        k = w * w
        c = 2 * zeta * w
        kh = k + 2 * c / dt + 4 / dt**2
        u = v = 0.0
        acc = -a[0]
        peak = 0.0
        for ai in a[1:]:
            p = -ai + (4 / dt**2 + 2 * c / dt) * u + (4 / dt + c) * v + acc
            un = p / kh
            vn = 2 * (un - u) / dt - v
            acc = 4 * (un - u) / dt**2 - 4 * v / dt - acc
            u, v = un, vn
            peak = max(peak, abs(u))
        out.append(k * peak)
    return np.array(out)


def boundary_triangles(cells):
    """Faces of tetrahedra that belong to one tetrahedron only."""
    faces = np.concatenate(
        [cells[:, [0, 1, 2]], cells[:, [0, 1, 3]], cells[:, [0, 2, 3]], cells[:, [1, 2, 3]]]
    )
    key = np.sort(faces, axis=1)
    _, idx, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[idx[counts == 1]]


def main(run, out):
    os.makedirs(out, exist_ok=True)
    prefix = os.path.join(out, "dome_earthquake")
    ground = read_csv(os.path.join(run, "ground.csv"))
    crown = read_csv(os.path.join(run, "crown.csv"))
    broken = read_csv(os.path.join(run, "broken.csv"))
    energy = read_csv(os.path.join(run, "energy.csv"))
    t0 = ground["time"][0]

    # Record and response histories.
    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    ax[0].plot(ground["time"] - t0, ground["ground"] / G, lw=0.7)
    ax[0].set_ylabel("ground acc. [g]")
    ax[0].set_title("El Centro 1940 N–S on the drum top (as applied)")
    ax[1].plot(crown["time"] - t0, crown["crown"] * 1e3, lw=0.8, color="C1")
    ax[1].set_ylabel("oculus ring drift [mm]")
    ax[2].plot(broken["time"] - t0, broken["broken"], color="C3")
    ax[2].set_ylabel("broken joints")
    ax[2].set_xlabel("time from the start of shaking [s]")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "_histories.png", dpi=120)
    plt.close(fig)

    # Response spectrum of the applied motion.
    periods = np.linspace(0.05, 3.0, 120)
    sa = spectrum(ground["time"], ground["ground"], periods)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(periods, sa / G)
    ax.set_xlabel("period T [s]")
    ax.set_ylabel("Sa [g], 5 % damping")
    ax.set_title("Response spectrum of the applied record")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "_spectrum.png", dpi=120)
    plt.close(fig)

    # Energy account.
    fig, ax = plt.subplots(figsize=(8, 4.5))
    t = energy["time"]
    for name in ["kinetic", "strain", "joint", "mass_damping", "fracture", "friction"]:
        ax.plot(t, energy[name] / 1e3, label=name)
    ext = energy["gravity_work"] + energy["reaction_work"] + energy["ground_work"]
    ax.plot(t, ext / 1e3, "k--", label="external work")
    ax.plot(t, energy["balance_error"] / 1e3, "k:", label="balance error")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [kJ]")
    ax.legend(ncol=2, fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "_energy.png", dpi=120)
    plt.close(fig)

    # The vault and its cracks at the end of the run.
    frame = sorted(glob.glob(os.path.join(run, "dome_[0-9]*.vtu")))[-1]
    m = meshio.read(frame)
    pts = m.points  # fdem writes the points at their current place
    tris = boundary_triangles(m.cells_dict["tetra"])
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(
        Poly3DCollection(pts[tris], facecolor=(0.85, 0.8, 0.72, 0.25), edgecolor=(0.5, 0.5, 0.5, 0.08), lw=0.2)
    )
    cracks = sorted(glob.glob(os.path.join(run, "dome_cracks_[0-9]*.vtu")))
    n_cracks = 0
    if cracks:
        c = meshio.read(cracks[-1])
        cp = c.points + c.point_data.get("displacement", np.zeros_like(c.points))
        ct = c.cells_dict["triangle"]
        n_cracks = len(ct)
        ax.add_collection3d(Poly3DCollection(cp[ct], facecolor="crimson", edgecolor="darkred", lw=0.3))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    mid, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(mid[0] - r, mid[0] + r)
    ax.set_ylim(mid[1] - r, mid[1] + r)
    ax.set_zlim(lo[2], lo[2] + 2 * r)
    ax.view_init(elev=22, azim=-60)
    ax.set_xlabel("x (N–S) [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"Crack surfaces at the end ({n_cracks} broken joints, red)")
    fig.tight_layout()
    fig.savefig(prefix + "_cracks.png", dpi=120)
    plt.close(fig)
    print("wrote", ", ".join(sorted(glob.glob(prefix + "_*.png"))))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
