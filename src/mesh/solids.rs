//! Solid generators: cylinder (disc), sphere, hollow cylinder and the notched beam of the
//! three-point-bending test, meshed into positively oriented tetrahedra at a target edge
//! length `h`, conforming, with named face and node sets.
//!
//! Curved boundaries carry their nodes exactly on the surface, so the volume error is that of
//! the inscribed polyhedron, O(h²). Measured quality and volume errors: `docs/generators.md`.
//!
//! - **Cylinder**: an O-grid cross-section (a square core and four blocks mapped onto the
//!   circle) cut into triangles and extruded along the axis; each prism is 3 tetrahedra.
//! - **Sphere**: one cube grid mapped onto the ball (each cube shell blended towards a sphere,
//!   the outer one exactly onto it), cells split into 6 Kuhn tetrahedra mirrored per octant so
//!   the cut diagonals point outwards.
//! - **Hollow cylinder**: a periodic annular (r, θ) grid extruded along the axis.
//! - **Notched beam**: a tensor grid of boxes without the notch cells, refined towards the
//!   notch, Kuhn tetrahedra mirrored about mid-span (the mesh is symmetric).

use super::structured::{
    add_all_elements, add_face_set, add_node_set, cells, grid_1d, hex_grid, lerp, union_node_sets,
    Tri2,
};
use super::Mesh;
use crate::math::{rotation_matrix, Real, Vec3};
use std::f64::consts::PI;

/// Error unless `v > 0` (and finite).
pub(crate) fn need_positive(key: &str, v: Real) -> Result<(), String> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(format!("'{key}' must be > 0, got {v}"))
    }
}

/// Refuse meshes that would be absurdly large (a typo in `size`): more than 2·10⁷
/// tetrahedra, or more than the machine's memory could simulate. Callers compute `estimate`
/// in floating point (products of cell counts, none of which may overflow).
pub(crate) fn need_reasonable(estimate: Real) -> Result<(), String> {
    if estimate.is_nan() || estimate > 2.0e7 {
        let n = if estimate.is_finite() {
            format!("about {estimate:.3e}")
        } else {
            "a number beyond any machine's memory of".into()
        };
        return Err(format!(
            "{n} tetrahedra is too many (the generators stop at 2e7); use a larger 'size'"
        ));
    }
    crate::limits::check_tets(estimate)
}

/// A product of cell counts in floating point (no overflow, whatever the counts).
pub(crate) fn product(counts: &[usize]) -> Real {
    counts.iter().map(|&n| n as Real).product()
}

fn rel_tol(scale: Real) -> Real {
    1e-9 * scale
}

/// A solid cylinder of `radius` and `length` along +z, base centred at the origin, meshed at
/// target edge length `h`. Sets (faces + nodes): `bottom` (z = 0), `top` (z = length),
/// `side` (r = radius); element set `all`.
pub fn cylinder(radius: Real, length: Real, h: Real) -> Result<Mesh, String> {
    need_positive("radius", radius)?;
    need_positive("length", length)?;
    need_positive("size", h)?;
    // Cells per quarter of the circle, even, so that a vertex lies at each pole (±x, ±y of
    // the section): the extremes of the polygon are then ±radius exactly, and a platen set at
    // the radius touches the disc.
    // Saturating: a `size` of 1e-300 gives usize::MAX cells, which the check below refuses
    // (doubled by wrapping it became 0 or an overflow panic).
    let n = cells(PI * radius / 4.0, h, 1).saturating_mul(2);
    let a = 0.55 * radius; // half-side of the square core
    let m = cells(radius - a, h, 1); // radial cells of the ring blocks
    let nz = cells(length, h, 1);
    need_reasonable((product(&[n, n]) + product(&[4, n, m])) * product(&[2, 3, nz]))?;
    let tri = disc_section(radius, a, n, m);
    let mut mesh = tri.extrude(nz, |p, k| Vec3::new(p[0], p[1], lerp(0.0, length, k, nz)));
    let tol = rel_tol(radius.max(length));
    add_face_set(&mut mesh, "bottom", |p| p.z.abs() <= tol);
    add_face_set(&mut mesh, "top", |p| (p.z - length).abs() <= tol);
    add_face_set(&mut mesh, "side", |p| {
        (p.x.hypot(p.y) - radius).abs() <= tol
    });
    add_all_elements(&mut mesh);
    Ok(mesh)
}

/// O-grid triangulation of the disc of `radius`: a square core of half-side `a` with `n × n`
/// cells, four blocks of `n × m` cells from the square's sides to the circle.
fn disc_section(radius: Real, a: Real, n: usize, m: usize) -> Tri2 {
    let mut tri = Tri2::new(rel_tol(radius));
    let flat = |p: [Real; 2]| Vec3::new(p[0], p[1], 0.0);
    tri.quad_grid(n, n, |i, j| [lerp(-a, a, i, n), lerp(-a, a, j, n)], flat);
    for side in 0..4 {
        let (c, s) = match side {
            0 => (1.0, 0.0),
            1 => (0.0, 1.0),
            2 => (-1.0, 0.0),
            _ => (0.0, -1.0),
        };
        let rot = |x: Real, y: Real| [c * x - s * y, s * x + c * y];
        tri.quad_grid(
            n,
            m,
            |i, j| {
                let t = lerp(-1.0, 1.0, i, n);
                let u = lerp(0.0, 1.0, j, m);
                let sq = [a, a * t];
                let phi = PI / 4.0 * t;
                let ci = [radius * phi.cos(), radius * phi.sin()];
                let p = if j == m {
                    ci
                } else {
                    [(1.0 - u) * sq[0] + u * ci[0], (1.0 - u) * sq[1] + u * ci[1]]
                };
                rot(p[0], p[1])
            },
            flat,
        );
    }
    // Outer nodes exactly on the circle (the rotation by quarter turns is exact for c, s ∈
    // {0, ±1}, but re-project to remove any doubt).
    for p in &mut tri.pts {
        let r = p[0].hypot(p[1]);
        if (r - radius).abs() <= 1e-9 * radius {
            p[0] *= radius / r;
            p[1] *= radius / r;
        }
    }
    tri
}

/// A solid sphere of `radius` centred at the origin, target edge length `h`. Sets:
/// `surface` (faces + nodes); element set `all`.
pub fn sphere(radius: Real, h: Real) -> Result<Mesh, String> {
    need_positive("radius", radius)?;
    need_positive("size", h)?;
    // A cube face maps onto a quarter great circle along its middle: n cells across it.
    let n = cells(PI * radius / 4.0, h, 1).saturating_mul(2); // as in `cylinder`
    need_reasonable(product(&[6, n, n, n]))?;
    let half = n / 2;
    let (mut mesh, _) = hex_grid(
        [n, n, n],
        |i, j, k| {
            let p = Vec3::new(
                lerp(-1.0, 1.0, i, n),
                lerp(-1.0, 1.0, j, n),
                lerp(-1.0, 1.0, k, n),
            );
            let s = p.amax();
            if s == 0.0 {
                return Vec3::zeros();
            }
            // Blend the cube shell of half-side s towards the sphere of radius s; the outer
            // shell (s = 1) lands exactly on the sphere.
            let w = s;
            let d = p.norm();
            radius * p * ((1.0 - w) + w * s / d)
        },
        |_, _, _| true,
        |i, j, k| [i < half, j < half, k < half],
    );
    let tol = rel_tol(radius);
    add_face_set(&mut mesh, "surface", |p| (p.norm() - radius).abs() <= tol);
    add_all_elements(&mut mesh);
    Ok(mesh)
}

/// A hollow cylinder (tube) of `inner_radius` < `outer_radius` and `length` along +z, base
/// centred at the origin, target edge length `h`. Sets (faces + nodes): `inner`, `outer`,
/// `bottom`, `top`; element set `all`.
pub fn hollow_cylinder(
    inner_radius: Real,
    outer_radius: Real,
    length: Real,
    h: Real,
) -> Result<Mesh, String> {
    need_positive("inner_radius", inner_radius)?;
    need_positive("length", length)?;
    need_positive("size", h)?;
    if !(outer_radius > inner_radius && outer_radius.is_finite()) {
        return Err(format!(
            "'outer_radius' must exceed inner_radius = {inner_radius}, got {outer_radius}"
        ));
    }
    let nr = cells(outer_radius - inner_radius, h, 1);
    let nt = cells(PI * (inner_radius + outer_radius), h, 12);
    let nz = cells(length, h, 1);
    need_reasonable(product(&[nr, nt, nz, 6]))?;
    let mut tri = Tri2::new(rel_tol(outer_radius));
    tri.quad_grid(
        nr,
        nt,
        |i, j| {
            let r = lerp(inner_radius, outer_radius, i, nr);
            // j = nt is the same node as j = 0: computed identically, so merged exactly.
            let t = 2.0 * PI * (j % nt) as Real / nt as Real;
            [r * t.cos(), r * t.sin()]
        },
        |p| Vec3::new(p[0], p[1], 0.0),
    );
    let mut mesh = tri.extrude(nz, |p, k| Vec3::new(p[0], p[1], lerp(0.0, length, k, nz)));
    let tol = rel_tol(outer_radius.max(length));
    add_face_set(&mut mesh, "bottom", |p| p.z.abs() <= tol);
    add_face_set(&mut mesh, "top", |p| (p.z - length).abs() <= tol);
    add_face_set(&mut mesh, "inner", |p| {
        (p.x.hypot(p.y) - inner_radius).abs() <= tol
    });
    add_face_set(&mut mesh, "outer", |p| {
        (p.x.hypot(p.y) - outer_radius).abs() <= tol
    });
    add_all_elements(&mut mesh);
    Ok(mesh)
}

/// Geometry of a notched beam for three-point bending.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotchedBeam {
    /// Length along x [m].
    pub length: Real,
    /// Height along z [m].
    pub height: Real,
    /// Width (thickness) along y [m].
    pub width: Real,
    /// Depth of the notch from the bottom face, 0 < a < height [m].
    pub notch_depth: Real,
    /// Width of the notch along x, centred at mid-span [m].
    pub notch_width: Real,
    /// Distance between the two supports, centred at mid-span [m].
    pub span: Real,
}

/// A notched beam on `[0, length] × [0, width] × [0, height]`, notch at x = length/2 from the
/// bottom, meshed at target edge length `h` (refined towards the notch down to half the notch
/// width, growing by ≤ 35 % per cell). `h` may not exceed 2.5 × notch_width (the notch cells
/// would be slivers: minimum dihedral angle 26.6° at h = notch_width, 11.3° at 2.5 ×). The mid-span line x = length/2 and the support lines
/// x = length/2 ± span/2 are grid lines.
///
/// Sets: faces + nodes `top`, `bottom`, `notch` (its two walls and tip), `left_end` (x = 0),
/// `right_end` (x = length), `front` (y = 0), `back` (y = width); nodes `load_line`
/// (top, x = length/2), `support_left`, `support_right` (bottom, x = length/2 ∓ span/2) and
/// `supports` (both); element set `all`.
pub fn notched_beam(b: &NotchedBeam, h: Real) -> Result<Mesh, String> {
    for (k, v) in [
        ("length", b.length),
        ("height", b.height),
        ("width", b.width),
        ("notch_depth", b.notch_depth),
        ("notch_width", b.notch_width),
        ("span", b.span),
        ("size", h),
    ] {
        need_positive(k, v)?;
    }
    if b.notch_depth >= b.height {
        return Err(format!(
            "'notch_depth' must lie in (0, height = {}), got {}",
            b.height, b.notch_depth
        ));
    }
    if b.span > b.length {
        return Err(format!(
            "'span' must lie in (0, length = {}], got {}",
            b.length, b.span
        ));
    }
    if b.notch_width >= b.span {
        return Err(format!(
            "'notch_width' must be smaller than span = {}, got {}",
            b.span, b.notch_width
        ));
    }
    if h > 2.5 * b.notch_width * (1.0 + 1e-9) {
        return Err(format!(
            "'size' = {h} is above 2.5 × notch_width = {}: the cells at the notch (half its width across, 'size' along y and z) would be slivers (minimum dihedral angle below 10°); use size ≤ 2.5 × notch_width",
            2.5 * b.notch_width
        ));
    }
    let xc = 0.5 * b.length;
    let (xn1, xn2) = (xc - 0.5 * b.notch_width, xc + 0.5 * b.notch_width);
    let (xs1, xs2) = (xc - 0.5 * b.span, xc + 0.5 * b.span);
    // Size function: the notch half-width (capped at h) at the notch, growing by 35 %.
    let hn = h.min(0.5 * b.notch_width);
    let target = |x: Real| {
        let d = if x < xn1 {
            xn1 - x
        } else if x > xn2 {
            x - xn2
        } else {
            0.0
        };
        h.min(hn + 0.35 * d)
    };
    // Before any grid is built: an upper bound of the cells along x (the notch at hn, the
    // growth ∫ dx/(hn + 0.35 d) on each side, the rest at h), and z and y at h.
    let nx_bound =
        b.notch_width / hn + 2.0 * (1.0 + 0.35 * b.length / hn).ln() / 0.35 + b.length / h;
    need_reasonable(6.0 * nx_bound * (b.height / h + 2.0) * (b.width / h + 1.0))?;
    let mut xs: Vec<Real> = Vec::new();
    let mut breaks = vec![0.0, xs1, xn1, xc, xn2, xs2, b.length];
    breaks.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs().max(1.0));
    for w in breaks.windows(2) {
        let g = grid_1d(w[0], w[1], |s| target(w[0] + s));
        if xs.is_empty() {
            xs.extend(g);
        } else {
            xs.extend(&g[1..]);
        }
    }
    let mut zs = grid_1d(0.0, b.notch_depth, |_| h);
    zs.extend(&grid_1d(b.notch_depth, b.height, |_| h)[1..]);
    let ny = cells(b.width, h, 1);
    let (nx, nz) = (xs.len() - 1, zs.len() - 1);
    need_reasonable(product(&[6, nx, ny, nz]))?;
    let ic = xs
        .iter()
        .position(|&x| x == xc)
        .expect("mid-span is a grid line");
    let (mut mesh, _) = hex_grid(
        [nx, ny, nz],
        |i, j, k| Vec3::new(xs[i], lerp(0.0, b.width, j, ny), zs[k]),
        |i, _, k| {
            let (x, z) = (0.5 * (xs[i] + xs[i + 1]), 0.5 * (zs[k] + zs[k + 1]));
            !(x > xn1 && x < xn2 && z < b.notch_depth)
        },
        |i, _, _| [i < ic, false, false],
    );
    let tol = rel_tol(b.length.max(b.height).max(b.width));
    let eq = |a: Real, v: Real| (a - v).abs() <= tol;
    add_face_set(&mut mesh, "top", |p| eq(p.z, b.height));
    add_face_set(&mut mesh, "bottom", |p| eq(p.z, 0.0));
    add_face_set(&mut mesh, "left_end", |p| eq(p.x, 0.0));
    add_face_set(&mut mesh, "right_end", |p| eq(p.x, b.length));
    add_face_set(&mut mesh, "front", |p| eq(p.y, 0.0));
    add_face_set(&mut mesh, "back", |p| eq(p.y, b.width));
    add_face_set(&mut mesh, "notch", |p| {
        p.x >= xn1 - tol && p.x <= xn2 + tol && p.z <= b.notch_depth + tol
    });
    add_node_set(&mut mesh, "load_line", |p| eq(p.z, b.height) && eq(p.x, xc));
    add_node_set(&mut mesh, "support_left", |p| eq(p.z, 0.0) && eq(p.x, xs1));
    add_node_set(&mut mesh, "support_right", |p| eq(p.z, 0.0) && eq(p.x, xs2));
    union_node_sets(&mut mesh, "supports", &["support_left", "support_right"]);
    add_all_elements(&mut mesh);
    Ok(mesh)
}

/// Rotate a mesh built along +z so that +z becomes `axis`, then move its origin to `base`.
pub fn place_on_axis(mesh: &mut Mesh, base: Vec3, axis: Vec3) {
    let a = axis.normalize();
    let z = Vec3::z();
    let c = z.cross(&a);
    if c.norm() > 1e-12 {
        let angle = z.dot(&a).clamp(-1.0, 1.0).acos();
        let r = rotation_matrix(&c, angle);
        for p in &mut mesh.nodes {
            *p = r * *p;
        }
    } else if z.dot(&a) < 0.0 {
        // Half turn about x keeps tets positive (a rotation, not a reflection).
        let r = rotation_matrix(&Vec3::x(), PI);
        for p in &mut mesh.nodes {
            *p = r * *p;
        }
    }
    mesh.translate(base);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_volume_sets_orientation() {
        let m = cylinder(1.0, 0.5, 0.2).unwrap();
        assert!(m.check().is_empty());
        let exact = PI * 0.5;
        assert!((m.volume() - exact).abs() / exact < 0.01, "{}", m.volume());
        for s in ["top", "bottom", "side"] {
            assert!(!m.sets.faces[s].is_empty(), "{s}");
        }
    }

    #[test]
    fn sphere_and_tube_are_valid() {
        let s = sphere(1.0, 0.2).unwrap();
        assert!(s.check().is_empty());
        let t = hollow_cylinder(0.5, 1.0, 1.0, 0.2).unwrap();
        assert!(t.check().is_empty());
    }

    #[test]
    fn bad_parameters_name_the_key() {
        assert!(cylinder(0.0, 1.0, 0.1).unwrap_err().contains("'radius'"));
        assert!(hollow_cylinder(1.0, 0.5, 1.0, 0.1)
            .unwrap_err()
            .contains("'outer_radius'"));
        let b = NotchedBeam {
            length: 1.0,
            height: 0.2,
            width: 0.1,
            notch_depth: 0.3,
            notch_width: 0.01,
            span: 0.9,
        };
        assert!(notched_beam(&b, 0.02)
            .unwrap_err()
            .contains("'notch_depth'"));
    }

    #[test]
    fn axis_placement_keeps_orientation() {
        let mut m = cylinder(0.5, 1.0, 0.25).unwrap();
        place_on_axis(&mut m, Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(m.check().is_empty());
        let mut m = cylinder(0.5, 1.0, 0.25).unwrap();
        place_on_axis(&mut m, Vec3::zeros(), Vec3::new(1.0, 1.0, 0.0));
        assert!(m.check().is_empty());
        let (lo, hi) = m.bounds();
        assert!(hi.x - lo.x > 0.7 && hi.z - lo.z < 1.0 + 1e-9);
    }
}
