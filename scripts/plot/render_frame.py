#!/usr/bin/env python3
"""A picture of one ParaView frame of any fdem run, drawn headless (no display, no ParaView):
the outer surface of the tetrahedra in their deformed place, coloured by a cell field and
shaded, and with --cracks the crack surface (the broken joints, coloured by when they broke)
inside a faint outline of the bodies.

    python3 -m pip install -r requirements-dev.txt      # meshio, numpy, matplotlib
    python3 scripts/plot/render_frame.py OUT_DIR [--frame N] [--field von_mises]
            [--cracks] [--view iso|xz|xy|yz] [--scale 1] [--out FILE.png] [--title TEXT]
            [--hide-bodies 216-220,3]

OUT_DIR is a run's output directory (it holds <name>_000000.vtu …, and once a joint broke
<name>_cracks_000000.vtu …). --frame is the frame number (default: the last; negative counts
from the end). --hide-bodies leaves out the tetrahedra of the bodies listed by id (the
`body` cell field; ids and ranges a-b, comma separated), e.g. a container's walls. --field is a cell field of the frame: von_mises, damage, fragment, body,
material, contact_pressure (default: fragment when the model has joints, else von_mises).
--view looks along an axis (xz: from -y, the side; xy: from +z, the top; yz: from +x) or
from an oblique corner (iso). --scale magnifies the displacement. Writes OUT_DIR/<name>_frame
(NNNNNN).png unless --out says where.

How it draws: the outer faces are the triangular faces of the tetrahedra that no other
tetrahedron shares in the reference configuration (jointed bodies give every tetrahedron its
own nodes, so faces are matched by position, not by node number); each is drawn at its
current place, projected onto the view plane, back to front (painter's algorithm), with
Lambert shading from a light behind the viewer. The result is a plain PNG from matplotlib's
Agg backend: the same frame gives the same picture on any machine.
"""

import argparse
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

# Faces of a tetrahedron (node positions in the cell), outward for a positive volume.
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])

# View directions (from the eye into the scene) and the screen's "up".
VIEWS = {
    "xz": (np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])),
    "xy": (np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0])),
    "yz": (np.array([-1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])),
    "iso": (np.array([-1.0, 1.6, -0.9]), np.array([0.0, 0.0, 1.0])),
}

UNITS = {"von_mises": "Pa", "contact_pressure": "Pa", "damage": "-"}


def frames(out_dir, pattern):
    """Frame files of one series, in order (names end in _NNNNNN.vtu)."""
    files = sorted(glob.glob(os.path.join(out_dir, "*.vtu")))
    return [f for f in files if re.fullmatch(pattern, os.path.basename(f))]


def series_name(out_dir):
    """The simulation's name: the .pvd that is not a crack or bar series."""
    pvds = sorted(glob.glob(os.path.join(out_dir, "*.pvd")))
    names = [
        os.path.basename(p)[:-4]
        for p in pvds
        if not p.endswith("_cracks.pvd") and not p.endswith("_bars.pvd")
    ]
    if not names:
        sys.exit(f"render_frame: {out_dir} has no .pvd series (was sim.write_vtk() called?)")
    return names[0]


def series_times(out_dir, pvd_name):
    """(time [s], file) of each frame of a .pvd series, in order ([] without the file)."""
    try:
        with open(os.path.join(out_dir, pvd_name), encoding="utf-8") as f:
            pvd = f.read()
    except OSError:
        return []
    out = []
    for ds in re.findall(r"<DataSet[^>]*>", pvd):
        ts = re.search(r'timestep="([^"]+)"', ds)
        fl = re.search(r'file="([^"]+)"', ds)
        if ts and fl:
            out.append((float(ts.group(1)), fl.group(1)))
    return out


def frame_time(out_dir, name, file):
    """The frame's simulated time [s] from the .pvd series (None if it is not listed)."""
    return next((t for t, f in series_times(out_dir, name + ".pvd") if f == file), None)


def crack_frame(out_dir, name, t):
    """The crack surface at time t: the last crack frame written at or before t (the crack
    series starts with the first broken joint, so its numbers are not the body frames')."""
    best = None
    for tc, f in series_times(out_dir, name + "_cracks.pvd"):
        if t is None or tc <= t * (1 + 1e-12) + 1e-300:
            best = f
    return os.path.join(out_dir, best) if best else None


def body_ids(spec):
    """Body ids from "3,216-220" (ids and inclusive ranges)."""
    ids = []
    for part in spec.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            ids.extend(range(int(lo), int(hi or lo) + 1))
        except ValueError:
            sys.exit(f"render_frame: --hide-bodies {spec}: expected ids and ranges like 3,216-220")
    return ids


def outer_faces(x0, tets):
    """Faces of the tetrahedra that no other tetrahedron shares (matched by reference
    position, rounded to a millionth of the model's size): (tet index, 3 node ids) each."""
    size = float(np.ptp(x0, axis=0).max()) or 1.0
    keys = np.round(x0 / (size * 1e-6)).astype(np.int64)
    faces = tets[:, TET_FACES].reshape(-1, 3)
    owner = np.repeat(np.arange(len(tets)), 4)
    k = keys[faces]  # (nf, 3, 3)
    # A face's key: its three vertex keys in sorted order.
    order = np.lexsort((k[:, :, 2], k[:, :, 1], k[:, :, 0]), axis=1)
    ks = np.take_along_axis(k, order[:, :, None], axis=1).reshape(len(faces), 9)
    _, inverse, counts = np.unique(ks, axis=0, return_inverse=True, return_counts=True)
    single = counts[inverse.ravel()] == 1
    return owner[single], faces[single]


def camera(view):
    d, up = VIEWS[view]
    d = d / np.linalg.norm(d)
    right = np.cross(d, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, d)
    return d, right, up


def project(points, view):
    """Screen coordinates (right, up) and depth (along the view) of points."""
    d, right, up = camera(view)
    return np.stack([points @ right, points @ up], axis=1), points @ d


def shade(tri, view):
    """Lambert factor of triangles (n, 3, 3) lit from the eye, in [0.35, 1]."""
    d, _, _ = camera(view)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    norm[norm == 0] = 1.0
    lam = np.abs((n / norm[:, None]) @ d)
    return 0.35 + 0.65 * lam


def draw_triangles(ax, tri, values, view, cmap, clim, alpha=1.0, edge=None):
    """Triangles (n, 3, 3) back to front, coloured by values and shaded."""
    xy, depth = project(tri.reshape(-1, 3), view)
    xy = xy.reshape(-1, 3, 2)
    depth = depth.reshape(-1, 3).mean(axis=1)
    order = np.argsort(-depth, kind="stable")  # far first
    norm = matplotlib.colors.Normalize(*clim)
    rgba = matplotlib.colormaps[cmap](norm(values[order]))
    rgba[:, :3] *= shade(tri[order], view)[:, None]
    rgba[:, 3] = alpha
    pc = PolyCollection(
        xy[order],
        facecolors=rgba,
        edgecolors=edge if edge else rgba,
        linewidths=0.15 if edge else 0.3,
    )
    ax.add_collection(pc)
    return xy


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--frame", type=int, default=-1)
    ap.add_argument("--field", default=None)
    ap.add_argument("--cracks", action="store_true")
    ap.add_argument("--view", default="iso", choices=sorted(VIEWS))
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--out", default=None)
    ap.add_argument("--title", default=None)
    ap.add_argument("--hide-bodies", default=None)
    a = ap.parse_args(argv)

    name = series_name(a.out_dir)
    body_frames = frames(a.out_dir, re.escape(name) + r"_[0-9]{6}\.vtu")
    if not body_frames:
        sys.exit(f"render_frame: no frames {name}_NNNNNN.vtu in {a.out_dir}")
    try:
        path = body_frames[a.frame]
    except IndexError:
        sys.exit(f"render_frame: --frame {a.frame}: {a.out_dir} has {len(body_frames)} frames")
    number = os.path.basename(path)[-10:-4]
    m = meshio.read(path)
    if "tetra" not in m.cells_dict:
        sys.exit(f"render_frame: {path} has no tetrahedra")
    tets = m.cells_dict["tetra"]
    fields = {k: np.asarray(v[0]) for k, v in m.cell_data.items()}
    if a.hide_bodies:
        if "body" not in fields:
            sys.exit(f"render_frame: --hide-bodies: {path} has no body field")
        keep = ~np.isin(fields["body"], body_ids(a.hide_bodies))
        if not keep.any():
            sys.exit(f"render_frame: --hide-bodies {a.hide_bodies} hides every tetrahedron")
        tets = tets[keep]
        fields = {k: v[keep] for k, v in fields.items()}
    field = a.field or ("fragment" if "fragment" in fields else "von_mises")
    if field not in fields or fields[field].ndim != 1:
        scalars = sorted(k for k, v in fields.items() if v.ndim == 1)
        sys.exit(f"render_frame: --field {field}: {path} has the cell fields {', '.join(scalars)}")
    # fdem writes points at their current place; the reference place is points - displacement.
    u = np.asarray(m.point_data["displacement"], dtype=float)
    x0 = np.asarray(m.points, dtype=float) - u
    x = x0 + a.scale * u

    owner, faces = outer_faces(x0, tets)
    values = fields[field][owner].astype(float)
    categorical = field in ("fragment", "body", "material")
    if categorical:
        cmap, clim, values = "tab20", (0, 19), values % 20
    else:
        cmap, clim = "viridis", (float(values.min()), float(values.max()) or 1.0)
        if clim[0] == clim[1]:
            clim = (clim[0] - 1.0, clim[1] + 1.0)

    t = frame_time(a.out_dir, name, os.path.basename(path))
    crack_path = crack_frame(a.out_dir, name, t) if a.cracks else None

    panels = 2 if a.cracks else 1
    fig, axes = plt.subplots(1, panels, figsize=(6.5 * panels, 5.5), squeeze=False)
    ax = axes[0][0]
    xy = draw_triangles(ax, x[faces], values, a.view, cmap, clim)
    lo, hi = xy.reshape(-1, 2).min(axis=0), xy.reshape(-1, 2).max(axis=0)
    pad = 0.05 * (hi - lo).max()
    sm = plt.cm.ScalarMappable(norm=matplotlib.colors.Normalize(*clim), cmap=cmap)
    if categorical:
        label = f"{field} (colour = {field} mod 20)"
    else:
        label = f"{field} [{UNITS.get(field, 'unit not recorded')}]"
    fig.colorbar(sm, ax=ax, label=label, shrink=0.8)
    ax.set_title(f"{field}, {a.view} view")
    n_cracks = 0
    if a.cracks:
        ax2 = axes[0][1]
        # The bodies as a faint outline, the crack surface over it.
        grey = np.zeros(len(faces))
        draw_triangles(ax2, x[faces], grey, a.view, "Greys", (-1, 4), alpha=0.12)
        if crack_path:
            cm = meshio.read(crack_path)
            tri = cm.cells_dict.get("triangle")
            if tri is not None and len(tri):
                n_cracks = len(tri)
                tb = np.asarray(cm.cell_data["time"][0], dtype=float)
                ct = np.asarray(cm.points, dtype=float)[tri]
                lo_t, hi_t = float(tb.min()), float(tb.max())
                tl = (lo_t, hi_t if hi_t > lo_t else lo_t + 1e-9)
                draw_triangles(ax2, ct, tb, a.view, "plasma", tl, edge="k")
                sm2 = plt.cm.ScalarMappable(norm=matplotlib.colors.Normalize(*tl), cmap="plasma")
                fig.colorbar(sm2, ax=ax2, label="time of breaking [s]", shrink=0.8)
        ax2.set_title(f"crack surface: {n_cracks} broken joints")
    for axis in axes[0]:
        axis.set_xlim(lo[0] - pad, hi[0] + pad)
        axis.set_ylim(lo[1] - pad, hi[1] + pad)
        axis.set_aspect("equal")
        axis.set_axis_off()
    fig.suptitle(a.title or f"{name}, frame {number}" + (f", t = {t:.6g} s" if t is not None else ""))
    out = a.out or os.path.join(a.out_dir, f"{name}_frame{number}.png")
    fig.savefig(out, dpi=100, bbox_inches="tight")
    cracks = f", {n_cracks} broken joints" if a.cracks else ""
    print(f"wrote {out} ({len(faces)} outer faces, field {field}{cracks})")


if __name__ == "__main__":
    main()
