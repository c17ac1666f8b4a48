#!/usr/bin/env python3
"""Figures of docs/applications/laminated_glass.md from a run of scripts/laminated_glass.rhai.

    python3 -m pip install -r requirements-docs.txt
    fdem run scripts/laminated_glass.rhai --out out/laminated_glass
    python3 scripts/plot/laminated_glass.py out/laminated_glass docs/applications/img [tag]

Reads the run's histories (deceleration.csv, ball_velocity.csv, deflection.csv, broken.csv,
energy.csv), its last crack surface (laminated_glass_cracks_*.vtu) and last frame, and writes three PNGs
(names prefixed `laminated_glass[_tag]`): the histories (the ball's deceleration in g, raw
every 5 steps and averaged over 0.1 ms, its velocity, the deflection under it and the broken
joints, and the energy account), and the crack pattern seen from above (the broken glass
faces of each ply, mirrored from the quarter model to the whole 300 × 300 mm plate, coloured
by the time they broke; delaminated interface faces in grey), and a section of the last frame
along the symmetry plane y = 0 (deflected plies, damage, the ball).
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


def moving_average(t, y, window):
    """Mean of y over the samples within ±window/2 of each time (a box filter)."""
    out = np.empty_like(y)
    lo = hi = 0
    c = np.concatenate([[0.0], np.cumsum(y)])
    for i, ti in enumerate(t):
        while t[lo] < ti - window / 2:
            lo += 1
        while hi < len(t) and t[hi] <= ti + window / 2:
            hi += 1
        out[i] = (c[hi] - c[lo]) / (hi - lo)
    return out


def histories(run, prefix):
    dec = read_csv(os.path.join(run, "deceleration.csv"))
    vel = read_csv(os.path.join(run, "ball_velocity.csv"))
    defl = read_csv(os.path.join(run, "deflection.csv"))
    broken = read_csv(os.path.join(run, "broken.csv"))
    energy = read_csv(os.path.join(run, "energy.csv"))
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    t = dec["time"] * 1e3
    a = ax[0, 0]
    a.plot(t, dec["deceleration"], lw=0.4, color="0.7", label="every 5 steps")
    smooth = moving_average(dec["time"], dec["deceleration"], 1e-4)
    a.plot(t, smooth, lw=1.5, color="C3", label="mean over 0.1 ms")
    a.set_xlabel("time [ms]")
    a.set_ylabel("ball deceleration [g]")
    a.set_title("ball deceleration")
    a.legend()
    a.set_ylim(min(-50.0, 1.1 * smooth.min()), 1.3 * max(smooth.max(), 1.0))
    a = ax[0, 1]
    a.plot(vel["time"] * 1e3, -vel["ball_velocity"], color="C0", label="ball speed (down +) [m/s]")
    a.plot(defl["time"] * 1e3, defl["deflection"] * 1e3, color="C2", label="deflection under the ball [mm]")
    a.set_xlabel("time [ms]")
    a.set_title("ball speed and plate deflection")
    a.axhline(0.0, color="k", lw=0.5)
    a.legend()
    a = ax[1, 0]
    a.plot(broken["time"] * 1e3, broken["broken"], color="C1")
    a.set_xlabel("time [ms]")
    a.set_ylabel("broken joints (quarter model)")
    a.set_title("fracture")
    a = ax[1, 1]
    te = energy["time"] * 1e3
    for key, label in [
        ("kinetic", "kinetic"),
        ("strain", "strain (glass + PVB)"),
        ("joint", "joints (elastic)"),
        ("fracture", "fracture"),
        ("contact", "contact (elastic)"),
        ("friction", "friction"),
    ]:
        a.plot(te, energy[key], label=label)
    a.plot(te, energy["balance_error"], "k--", label="balance error")
    a.set_xlabel("time [ms]")
    a.set_ylabel("energy, quarter model [J]")
    a.set_title("energy account")
    a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + "_histories.png", dpi=110)
    plt.close(fig)
    i = int(np.argmax(smooth))
    print(
        f"peak deceleration {dec['deceleration'].max():.0f} g (raw), {smooth[i]:.0f} g "
        f"(0.1 ms mean) at {t[i]:.3f} ms; max deflection {defl['deflection'].max() * 1e3:.2f} mm; "
        f"final ball velocity {vel['ball_velocity'][-1]:.2f} m/s"
    )


def crack_pattern(run, prefix, half=0.15):
    files = sorted(glob.glob(os.path.join(run, "laminated_glass_cracks_*.vtu")))
    if not files:
        print("no crack surface written (no joint broke)")
        return
    m = meshio.read(files[-1])
    tri = m.cells_dict["triangle"]
    pts = m.points
    time = m.cell_data["time"][0] * 1e3
    # The body of each triangle from cracks.csv (one row per broken joint, in the order the
    # crack surface lists them): the .vtu's integer arrays `body` and `joint` read back
    # swapped through meshio (noticed here, left for the output's owner).
    events = read_csv(os.path.join(run, "cracks.csv"))
    body = events["body"][: len(tri)].astype(int)
    assert np.allclose(events["time"][: len(tri)] * 1e3, time), "cracks.csv and the .vtu differ"
    body = np.where(np.isclose(events["time"][: len(tri)] * 1e3, time), body, -1)
    # Body ids in the order the script adds them: 0 glass_lower, 1 pvb, 2 glass_upper, 3 ball.
    # A face is drawn when it stands across the ply (its projection has area): the crack
    # triangles of a through-thickness face project to slivers, so draw each face as its
    # edge-on segment, widened a little, by projecting the triangle.
    fig, axes = plt.subplots(1, 2, figsize=(12, 6))
    # Interface joints have side A on the glass (`between: [glass, pvb]`), so they are drawn
    # with their ply.
    for a, ply, name in [(axes[0], 2, "upper ply (struck face)"), (axes[1], 0, "lower ply")]:
        polys, colors, greys = [], [], []
        for k, t in enumerate(tri):
            xy = pts[t][:, :2]
            if body[k] != ply:
                continue
            q = pts[t]
            n = np.cross(q[1] - q[0], q[2] - q[0])
            delam = abs(n[2]) > 0.9 * np.linalg.norm(n)  # a horizontal face: the interface
            for sx in (1, -1):
                for sy in (1, -1):
                    p = xy * np.array([sx, sy]) * 1e3
                    if delam:
                        greys.append(p)
                    else:
                        polys.append(p)
                        colors.append(time[k])
        if greys:
            a.add_collection(PolyCollection(greys, facecolor="0.85", edgecolor="0.6", lw=0.3))
        if polys:
            pc = PolyCollection(polys, array=np.array(colors), cmap="viridis", edgecolor="face", lw=1.2)
            a.add_collection(pc)
            fig.colorbar(pc, ax=a, shrink=0.8, label="time of breaking [ms]")
        h = half * 1e3
        a.plot([-h, h, h, -h, -h], [-h, -h, h, h, -h], "k-", lw=1)
        a.axhline(0, color="0.5", lw=0.4, ls=":")
        a.axvline(0, color="0.5", lw=0.4, ls=":")
        a.set_xlim(-h * 1.02, h * 1.02)
        a.set_ylim(-h * 1.02, h * 1.02)
        a.set_aspect("equal")
        a.set_xlabel("x [mm]")
        a.set_ylabel("y [mm]")
        a.set_title(f"{name}: {len(polys) // 4} broken faces")
    fig.suptitle("broken joints seen from above (quarter model mirrored to the whole plate; grey: delaminated)")
    fig.tight_layout()
    fig.savefig(prefix + "_cracks.png", dpi=110)
    plt.close(fig)


def section(run, prefix, strip=0.004):
    """The last frame cut near the symmetry plane y = 0: the tetrahedra with a node within
    `strip` of it, drawn as their x–z outlines (glass coloured by damage, PVB blue), the ball's
    outline, mirrored about x = 0."""
    files = sorted(glob.glob(os.path.join(run, "laminated_glass_[0-9]*.vtu")))
    m = meshio.read(files[-1])
    tets = m.cells_dict["tetra"]
    x = m.points
    body = m.cell_data["body"][0]
    damage = m.cell_data["damage"][0]
    keep = [(k, t) for k, t in enumerate(tets) if body[k] != 3 and x[t][:, 1].min() < strip]
    fig, a = plt.subplots(figsize=(12, 4.5))
    polys, vals, pvb = [], [], []
    for k, t in keep:
        faces = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
        for sx in (1, -1):
            for f in faces:
                p = x[t][f][:, [0, 2]] * np.array([sx, 1.0]) * 1e3
                if body[k] == 1:
                    pvb.append(p)
                else:
                    polys.append(p)
                    vals.append(damage[k])
    pc = PolyCollection(polys, array=np.array(vals), cmap="inferno_r", clim=(0, 1), edgecolor="0.3", lw=0.2)
    a.add_collection(pc)
    a.add_collection(PolyCollection(pvb, facecolor="C0", edgecolor="C0", lw=0.2, alpha=0.6))
    fig.colorbar(pc, ax=a, label="largest joint damage on the tetrahedron's faces")
    ball = [k for k in range(len(tets)) if body[k] == 3]
    zc = x[np.unique(tets[ball])][:, 2]
    r = (zc.max() - zc.min()) / 2
    th = np.linspace(0, 2 * np.pi, 200)
    a.plot(r * np.cos(th) * 1e3, (zc.min() + r + r * np.sin(th)) * 1e3, "k-", lw=1)
    a.set_xlim(-160, 160)
    a.set_ylim(min(-10, x[:, 2].min() * 1e3 - 5), 60)
    a.set_aspect("equal")
    a.set_xlabel("x [mm]")
    a.set_ylabel("z [mm]")
    t = os.path.basename(files[-1])
    a.set_title(f"section y ≈ 0 of the last frame ({t}; mirrored about x = 0; blue: PVB; circle: the ball)")
    fig.tight_layout()
    fig.savefig(prefix + "_section.png", dpi=110)
    plt.close(fig)


def main(run, out, tag=""):
    os.makedirs(out, exist_ok=True)
    prefix = os.path.join(out, "laminated_glass" + (f"_{tag}" if tag else ""))
    histories(run, prefix)
    crack_pattern(run, prefix)
    section(run, prefix)


if __name__ == "__main__":
    main(*sys.argv[1:])
