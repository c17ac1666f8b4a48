//! Masonry generators: an arch of voussoirs, a wall of bricks in running bond, a dome of
//! voussoir blocks in courses, an octagonal cloister vault (the dome of Florence in outline)
//! with optional corner ribs. Each returns an [`Assembly`]: one [`Mesh`] per block, with
//! named face/node sets and the block's course, index and springer flag.
//!
//! Neighbouring blocks share their faces exactly: the same nodes (computed by the same
//! formulas) and the same triangles (see `structured`: prism cuts are ordered by position,
//! Kuhn cuts are the same in every cell), so `sim.insert_joints(#{ between: blocks })` finds
//! every contact face and glues it with a mortar joint.

use super::generators::box_mesh;
use super::solids::{need_positive, need_reasonable, product};
use super::structured::{add_all_elements, add_face_set, add_face_set_by_ids, cells, lerp, Tri2};
use super::Mesh;
use crate::math::{Real, Vec3};
use std::f64::consts::PI;

/// One block of an assembly.
#[derive(Clone, Debug)]
pub struct Block {
    pub mesh: Mesh,
    /// Course (row) of the block, 0 at the bottom (the arch has one course).
    pub course: usize,
    /// Index of the block within its course.
    pub index: usize,
    /// Whether the block rests on a support (arch springers, the dome's base course, the
    /// wall's bottom course).
    pub springer: bool,
}

/// Blocks of a masonry structure, with what generated them.
#[derive(Clone, Debug)]
pub struct Assembly {
    /// "arch", "wall", "dome" or "cloister_vault".
    pub kind: &'static str,
    pub blocks: Vec<Block>,
    pub courses: usize,
}

impl Assembly {
    /// Total volume of the blocks [m³].
    pub fn volume(&self) -> Real {
        self.blocks.iter().map(|b| b.mesh.volume()).sum()
    }
    pub fn n_tets(&self) -> usize {
        self.blocks.iter().map(|b| b.mesh.tets.len()).sum()
    }
    /// Quality over all blocks: worst of each measure, mean aspect ratio over all tets; the
    /// worst tets are numbered through the blocks in order (block 0's tets first).
    pub fn quality(&self) -> Option<super::Quality> {
        let mut out: Option<super::Quality> = None;
        let (mut offset, mut sum_ar) = (0usize, 0.0);
        for b in &self.blocks {
            let Some(q) = b.mesh.quality() else { continue };
            sum_ar += q.mean_aspect_ratio * b.mesh.tets.len() as Real;
            let o = out.get_or_insert(super::Quality {
                worst_dihedral_tet: offset + q.worst_dihedral_tet,
                worst_aspect_tet: offset + q.worst_aspect_tet,
                ..q
            });
            if q.min_dihedral_deg < o.min_dihedral_deg {
                o.min_dihedral_deg = q.min_dihedral_deg;
                o.worst_dihedral_tet = offset + q.worst_dihedral_tet;
            }
            if q.max_aspect_ratio > o.max_aspect_ratio {
                o.max_aspect_ratio = q.max_aspect_ratio;
                o.worst_aspect_tet = offset + q.worst_aspect_tet;
            }
            o.max_dihedral_deg = o.max_dihedral_deg.max(q.max_dihedral_deg);
            offset += b.mesh.tets.len();
        }
        if let Some(o) = out.as_mut() {
            o.mean_aspect_ratio = sum_ar / offset.max(1) as Real;
        }
        out
    }
}

/// The largest block or course count of a generator (a typo guard: products of counts are
/// estimated in floating point before anything is built).
pub const MAX_COUNT: usize = 1_000_000;

fn need_count(key: &str, v: usize, min: usize) -> Result<(), String> {
    if v < min {
        Err(format!("'{key}' must be ≥ {min}, got {v}"))
    } else if v > MAX_COUNT {
        Err(format!("'{key}' must be ≤ {MAX_COUNT}, got {v}"))
    } else {
        Ok(())
    }
}

// ─── Arch ────────────────────────────────────────────────────────────────────────

/// A circular arch in the x–z plane, centre of the intrados circle at the origin, depth along
/// y on `[−depth/2, depth/2]`, symmetric about the z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arch {
    /// Intrados radius R [m].
    pub radius: Real,
    /// Radial thickness t [m].
    pub thickness: Real,
    /// Out-of-plane width [m].
    pub depth: Real,
    /// Number of voussoirs (≥ 3).
    pub voussoirs: usize,
    /// Angle subtended by the arch [degrees]: 180 for a semicircle, less for a segmental arch.
    pub span_angle: Real,
}

/// Voussoirs of an arch, meshed at target edge length `h`. Voussoir i spans the polar angles
/// θ ∈ [θ₀ + iΔ, θ₀ + (i+1)Δ] (θ from +x towards +z, θ₀ = 90° − span_angle/2), so block 0 is
/// the springer at +x. Each is a structured (r, θ, y) grid of prisms cut into 3 tetrahedra.
///
/// Sets of each block (faces + nodes): `intrados` (r = R), `extrados` (r = R + t),
/// `joint_right` (its face at the smaller θ, towards +x), `joint_left` (larger θ, towards −x),
/// `front` (y = −depth/2), `back` (y = +depth/2); springers also `springing` (the face on
/// the support). Blocks 0 and N−1 are springers.
pub fn arch(a: &Arch, h: Real) -> Result<Assembly, String> {
    need_positive("radius", a.radius)?;
    need_positive("thickness", a.thickness)?;
    need_positive("depth", a.depth)?;
    need_positive("size", h)?;
    need_count("voussoirs", a.voussoirs, 3)?;
    if !(a.span_angle > 0.0 && a.span_angle < 360.0) {
        return Err(format!(
            "'span_angle' must lie in (0, 360) degrees, got {}",
            a.span_angle
        ));
    }
    let (r0, r1) = (a.radius, a.radius + a.thickness);
    let n = a.voussoirs;
    let span = a.span_angle.to_radians();
    let (t0, t1) = (PI / 2.0 - span / 2.0, PI / 2.0 + span / 2.0);
    let nr = cells(a.thickness, h, 1);
    let nt = cells(0.5 * (r0 + r1) * span / n as Real, h, 1);
    let ny = cells(a.depth, h, 1);
    need_reasonable(product(&[n, nr, nt, ny, 6]))?;
    let tol = 1e-9 * r1.max(a.depth);
    let mut blocks = Vec::with_capacity(n);
    for i in 0..n {
        let (ta, tb) = (lerp(t0, t1, i, n), lerp(t0, t1, i + 1, n));
        let mut tri = Tri2::new(tol);
        tri.quad_grid(
            nr,
            nt,
            |ir, it| {
                let r = lerp(r0, r1, ir, nr);
                let t = lerp(ta, tb, it, nt);
                [r * t.cos(), r * t.sin()]
            },
            |p| Vec3::new(p[0], 0.0, p[1]),
        );
        let mut mesh = tri.extrude(ny, |p, k| {
            Vec3::new(p[0], lerp(-0.5 * a.depth, 0.5 * a.depth, k, ny), p[1])
        });
        let rad = |p: &Vec3| p.x.hypot(p.z);
        // On the ray at angle t (in the x–z plane): perpendicular distance ~0, ahead of the origin.
        let on_ray = move |p: &Vec3, t: Real| {
            (p.z * t.cos() - p.x * t.sin()).abs() <= tol && p.x * t.cos() + p.z * t.sin() > 0.0
        };
        add_face_set(&mut mesh, "intrados", |p| (rad(p) - r0).abs() <= tol);
        add_face_set(&mut mesh, "extrados", |p| (rad(p) - r1).abs() <= tol);
        add_face_set(&mut mesh, "joint_right", |p| on_ray(p, ta));
        add_face_set(&mut mesh, "joint_left", |p| on_ray(p, tb));
        add_face_set(&mut mesh, "front", |p| (p.y + 0.5 * a.depth).abs() <= tol);
        add_face_set(&mut mesh, "back", |p| (p.y - 0.5 * a.depth).abs() <= tol);
        let springer = i == 0 || i == n - 1;
        if springer {
            let t = if i == 0 { ta } else { tb };
            add_face_set(&mut mesh, "springing", |p| on_ray(p, t));
        }
        add_all_elements(&mut mesh);
        blocks.push(Block {
            mesh,
            course: 0,
            index: i,
            springer,
        });
    }
    Ok(Assembly {
        kind: "arch",
        blocks,
        courses: 1,
    })
}

// ─── Wall ────────────────────────────────────────────────────────────────────────

/// A wall of bricks in running bond, on `[0, L] × [0, w] × [0, H]` (length along x, courses
/// stacked along z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    pub courses: usize,
    /// Full bricks in the even courses (0, 2, …); odd courses have a half brick at each end
    /// and one full brick fewer, so both ends of the wall are straight.
    pub bricks_per_course: usize,
    /// Brick length (x), height (z), width (y) [m].
    pub brick: [Real; 3],
    /// Gap between bricks of a course (head joints) [m]; 0: coincident faces.
    pub head_gap: Real,
    /// Gap between courses (bed joints) [m]; 0: coincident faces.
    pub bed_gap: Real,
}

/// Bricks of a running-bond wall, meshed with Kuhn boxes at target edge length `h` (a full
/// brick has an even number of cells along its length, a half brick half as many, so with
/// zero gaps the bed faces of neighbouring courses match triangle for triangle).
///
/// Sets of each brick (faces + nodes): `top`, `bottom`, `left` (x min), `right` (x max),
/// `front` (y = 0), `back` (y = width). Bricks of course 0 are flagged `springer`.
pub fn wall(w: &Wall, h: Real) -> Result<Assembly, String> {
    need_count("courses", w.courses, 1)?;
    need_count("bricks_per_course", w.bricks_per_course, 1)?;
    let [bl, bh, bw] = w.brick;
    need_positive("brick length", bl)?;
    need_positive("brick height", bh)?;
    need_positive("brick width", bw)?;
    need_positive("size", h)?;
    if !(w.head_gap >= 0.0 && w.head_gap < bl) {
        return Err(format!(
            "'head_gap' must lie in [0, brick length = {bl}), got {}",
            w.head_gap
        ));
    }
    if !(w.bed_gap >= 0.0 && w.bed_gap.is_finite()) {
        return Err(format!("'bed_gap' must be ≥ 0, got {}", w.bed_gap));
    }
    let m = cells(0.5 * bl, h, 1); // cells per half brick
    let (ny, nz) = (cells(bw, h, 1), cells(bh, h, 1));
    need_reasonable(product(&[w.courses, w.bricks_per_course, 2, m, ny, nz, 6]))?;
    let g = w.head_gap;
    let mut blocks = Vec::new();
    for c in 0..w.courses {
        let z0 = c as Real * (bh + w.bed_gap);
        let pieces: Vec<(Real, usize)> = if c % 2 == 0 {
            vec![(bl, 2 * m); w.bricks_per_course]
        } else {
            let half = (0.5 * (bl - g), m);
            let mut v = vec![half];
            v.extend(std::iter::repeat_n((bl, 2 * m), w.bricks_per_course - 1));
            v.push(half);
            v
        };
        let mut x = 0.0;
        for (index, &(len, nx)) in pieces.iter().enumerate() {
            let (lo, hi) = (Vec3::new(x, 0.0, z0), Vec3::new(x + len, bw, z0 + bh));
            let mut mesh = box_mesh(lo, hi, [nx, ny, nz]);
            let tol = 1e-9 * (hi - lo).norm();
            add_face_set(&mut mesh, "top", |p| (p.z - hi.z).abs() <= tol);
            add_face_set(&mut mesh, "bottom", |p| (p.z - lo.z).abs() <= tol);
            add_face_set(&mut mesh, "left", |p| (p.x - lo.x).abs() <= tol);
            add_face_set(&mut mesh, "right", |p| (p.x - hi.x).abs() <= tol);
            add_face_set(&mut mesh, "front", |p| (p.y - lo.y).abs() <= tol);
            add_face_set(&mut mesh, "back", |p| (p.y - hi.y).abs() <= tol);
            add_all_elements(&mut mesh);
            blocks.push(Block {
                mesh,
                course: c,
                index,
                springer: c == 0,
            });
            x += len + g;
        }
    }
    Ok(Assembly {
        kind: "wall",
        blocks,
        courses: w.courses,
    })
}

// ─── Dome ────────────────────────────────────────────────────────────────────────

/// A spherical dome centred at the origin, pole on +z, between the polar angles `oculus`
/// (the opening at the crown) and `base` (90° for a hemisphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dome {
    /// Intrados radius R [m].
    pub radius: Real,
    /// Radial thickness t [m].
    pub thickness: Real,
    pub courses: usize,
    /// Blocks in every course (≥ 3); odd courses are offset by half a block (running bond).
    pub blocks_per_course: usize,
    /// Polar half-angle of the crown opening [degrees], > 0. (A closed crown would need a
    /// keystone block at the pole; this version requires an oculus.)
    pub oculus: Real,
    /// Polar angle of the base [degrees], in (oculus, 180).
    pub base: Real,
}

/// Voussoir blocks of a dome, meshed at target edge length `h`. Course c (0 at the base)
/// spans equal steps of polar angle; each block is a spherical-shell patch meshed as a
/// structured (θ, φ) grid extruded through the thickness (prisms cut into 3 tetrahedra). All
/// blocks share one φ grid (an even number of cells per block, so the half-block offset of
/// odd courses falls on it; sized where sin θ is the geometric mean of its extremes); the θ cells of each course are sized by the geometric mean of
/// `h` and the local φ cell width, so blocks near the crown are not too flat.
///
/// Sets of each block (faces + nodes): `intrados` (r = R), `extrados` (r = R + t),
/// `bed_lower` (towards the base), `bed_upper` (towards the crown), `head_left` (at its
/// smaller longitude φ), `head_right` (larger φ). Base-course blocks are springers and also
/// have `base` (= their `bed_lower`).
pub fn dome(d: &Dome, h: Real) -> Result<Assembly, String> {
    need_positive("radius", d.radius)?;
    need_positive("thickness", d.thickness)?;
    need_positive("size", h)?;
    need_count("courses", d.courses, 1)?;
    need_count("blocks_per_course", d.blocks_per_course, 3)?;
    if !(d.base > 0.0 && d.base < 180.0) {
        return Err(format!(
            "'base' must lie in (0, 180) degrees, got {}",
            d.base
        ));
    }
    if !(d.oculus > 0.0 && d.oculus < d.base) {
        return Err(format!(
            "'oculus' must lie in (0, base = {}) degrees, got {} (a dome closed at the crown needs a keystone, not generated in this version)",
            d.base, d.oculus
        ));
    }
    let (r0, r1) = (d.radius, d.radius + d.thickness);
    let rm = 0.5 * (r0 + r1);
    let (a0, a1) = (d.oculus.to_radians(), d.base.to_radians());
    let nb = d.blocks_per_course;
    let dphi = 2.0 * PI / nb as Real;
    // φ cells per block (even), sized where sin θ is the geometric mean of its extremes over
    // the dome, so the φ cells are as much too narrow at the crown as too wide at the base.
    let (s0, s1) = (a0.sin(), a1.sin());
    let s_max = if a1 >= PI / 2.0 { 1.0 } else { s0.max(s1) };
    let s_ref = (s0.min(s1) * s_max).sqrt();
    let m_half = (rm * s_ref * dphi / (2.0 * h)).ceil().max(1.0);
    let nr = cells(d.thickness, h, 1);
    // A lower bound (one θ cell per course) before any count is multiplied in integers.
    need_reasonable(product(&[nb, d.courses, nr, 6]) * 2.0 * m_half)?;
    let m = 2 * m_half as usize;
    let nphi = nb * m; // φ cells around the whole dome
    let tol = 1e-9 * r1;
    let theta_edge = |c: usize| lerp(a1, a0, c, d.courses); // polar angle of bed c (0 = base)
    let mut estimate = 0.0;
    let n_theta: Vec<usize> = (0..d.courses)
        .map(|c| {
            let (tlo, thi) = (theta_edge(c + 1), theta_edge(c));
            let width = rm * (0.5 * (tlo + thi)).sin() * dphi / m as Real;
            let n = cells(rm * (thi - tlo), (h * width).sqrt(), 1);
            estimate += product(&[nb, n, m, nr, 6]);
            n
        })
        .collect();
    need_reasonable(estimate)?;
    let phi_of = |q: usize| 2.0 * PI * (q % nphi) as Real / nphi as Real;
    let sph = |r: Real, t: Real, f: Real| {
        Vec3::new(r * t.sin() * f.cos(), r * t.sin() * f.sin(), r * t.cos())
    };
    let mut blocks = Vec::new();
    for (c, &nt) in n_theta.iter().enumerate() {
        let (t_low, t_up) = (theta_edge(c), theta_edge(c + 1)); // lower bed, upper bed
        let offset = if c % 2 == 1 { m / 2 } else { 0 };
        for j in 0..nb {
            let q0 = j * m + offset;
            let mut tri = Tri2::new(1e-12);
            tri.quad_grid(
                nt,
                m,
                |it, ip| [lerp(t_low, t_up, it, nt), phi_of(q0 + ip)],
                |p| sph(r0, p[0], p[1]),
            );
            let mut mesh = tri.extrude(nr, |p, k| sph(lerp(r0, r1, k, nr), p[0], p[1]));
            let (f_left, f_right) = (phi_of(q0), phi_of(q0 + m));
            let polar = |p: &Vec3| (p.z / p.norm()).clamp(-1.0, 1.0).acos();
            let on_meridian = move |p: &Vec3, f: Real| {
                (p.y * f.cos() - p.x * f.sin()).abs() <= tol && p.x * f.cos() + p.y * f.sin() > 0.0
            };
            add_face_set(&mut mesh, "intrados", |p| (p.norm() - r0).abs() <= tol);
            add_face_set(&mut mesh, "extrados", |p| (p.norm() - r1).abs() <= tol);
            add_face_set(&mut mesh, "bed_lower", |p| {
                (polar(p) - t_low).abs() * p.norm() <= 10.0 * tol
            });
            add_face_set(&mut mesh, "bed_upper", |p| {
                (polar(p) - t_up).abs() * p.norm() <= 10.0 * tol
            });
            add_face_set(&mut mesh, "head_left", |p| on_meridian(p, f_left));
            add_face_set(&mut mesh, "head_right", |p| on_meridian(p, f_right));
            if c == 0 {
                let faces = mesh.sets.faces["bed_lower"].clone();
                let nodes = mesh.sets.nodes["bed_lower"].clone();
                mesh.sets.faces.insert("base".into(), faces);
                mesh.sets.nodes.insert("base".into(), nodes);
            }
            add_all_elements(&mut mesh);
            blocks.push(Block {
                mesh,
                course: c,
                index: j,
                springer: c == 0,
            });
        }
    }
    Ok(Assembly {
        kind: "dome",
        blocks,
        courses: d.courses,
    })
}

// ─── Cloister vault ──────────────────────────────────────────────────────────────

/// Half the angle that a side of the octagon subtends at the axis: π/8 = 22.5°.
const HALF_SIDE: Real = PI / 8.0;

/// Corner ribs of a [`CloisterVault`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ribs {
    /// Width of a rib across its corner [m], measured along the intrados at the springing
    /// (half on each side of the corner); in (0, 2a·tan 22.5°), the side length there. It is
    /// rounded to an even number of cells of the around-grid. `None`: one block width.
    pub width: Option<Real>,
    /// How far a rib projects beyond the web extrados [m], > 0, measured as
    /// [`CloisterVault::thickness`] is (along the radius of the profile circle in the section
    /// that carries it).
    pub depth: Real,
}

/// Which vertical section of a [`CloisterVault`] carries the circle of radius
/// r = profile_ratio · D_c (the other sections follow from it, the webs being cylinders with
/// horizontal axes parallel to their sides).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ProfileOn {
    /// The eight corner ribs (the vertical planes through the axis and a corner; q the
    /// horizontal distance from the axis in such a plane, R_c = D_c/2 the circumradius of the
    /// intrados octagon at the springing): the intrados corner line is
    ///
    /// (q − q_c)² + z² = r²,  q_c = R_c − r,
    ///
    /// through the springing corner (q = R_c, z = 0) with a vertical tangent. A web's mid-line
    /// is that circle compressed horizontally by cos 22.5° (s = q cos 22.5°): an ellipse with
    /// semi-axes r cos 22.5° (horizontal) and r (vertical). Florence as usually described
    /// (Museo Galileo: the ribs of the inner shell have a pointed-fifth curvature whose radius
    /// is 4/5 of the diagonal of the base octagon). Needs profile_ratio ≥ 1/2. The default.
    #[default]
    Corners,
    /// Each web's mid-line (the vertical plane through the axis along its normal, s the
    /// horizontal distance from the axis, a = span/2):
    ///
    /// (s − s_c)² + z² = r²,  s_c = a − r,
    ///
    /// through the springing line (s = a, z = 0) with a vertical tangent. A corner section is
    /// that circle stretched horizontally by 1/cos 22.5° (q = s / cos 22.5°): an ellipse with
    /// semi-axes r / cos 22.5° (horizontal) and r (vertical). Needs profile_ratio ≥
    /// cos(22.5°)/2.
    Webs,
}

impl ProfileOn {
    /// The script name: "corners" or "webs".
    pub fn name(self) -> &'static str {
        match self {
            ProfileOn::Corners => "corners",
            ProfileOn::Webs => "webs",
        }
    }

    /// The profile of a script name, or `None`.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "corners" => Some(ProfileOn::Corners),
            "webs" => Some(ProfileOn::Webs),
            _ => None,
        }
    }
}

/// An octagonal cloister vault (a domical vault of eight cylindrical webs) on a regular
/// octagon, axis on +z through the origin, springing at z = 0: the dome of Santa Maria del
/// Fiore in Florence in outline (one shell, no void between an inner and an outer shell).
/// The octagon has a corner on +x; corner k is at the angle k·45°, web k lies between corners
/// k and k + 1 and faces the outward normal at k·45° + 22.5°.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloisterVault {
    /// Inner span across flats at the springing, 2a [m] (a: apothem of the intrados octagon).
    pub span: Real,
    /// Shell thickness t [m], measured along the radius of the profile circle in the section
    /// that carries it ([`ProfileOn`]): the extrados is the coaxial circle of radius r + t
    /// there. With [`ProfileOn::Webs`] that is the web normal; with [`ProfileOn::Corners`] it
    /// is in the corner plane, and the web is thinner: t cos 22.5° across it at the
    /// springing, rising towards t as the web turns horizontal (see [`cloister_vault`]).
    pub thickness: Real,
    /// Courses (≥ 1): equal steps of the arc angle ψ from the springing to the top bed.
    pub courses: usize,
    /// Blocks across each web in every course (≥ 1); with ribs, the web blocks between two
    /// ribs (in the even courses).
    pub blocks_per_web: usize,
    /// Radius of the profile circle over the span across corners, r / D_c; 4/5 is
    /// Brunelleschi's "quinto acuto". At least 1/2 with [`ProfileOn::Corners`] (r = R_c,
    /// round crown), cos(22.5°)/2 ≈ 0.462 with [`ProfileOn::Webs`] (r = a).
    pub profile_ratio: Real,
    /// Which section carries the profile circle: the corner ribs (default) or each web's
    /// mid-line.
    pub profile: ProfileOn,
    /// Inner opening across flats at the top bed [m], in (0, span): the intrados of every
    /// web's mid-line ends at s = oculus/2 from the axis.
    pub oculus: Real,
    /// Corner ribs, or none.
    pub ribs: Option<Ribs>,
}

/// The profile of a [`CloisterVault`], derived from its parameters (lengths in m, angles in
/// radians). ψ is the angle on the profile circle (0 at the springing), ρ the radius on it
/// (r at the intrados, r + t at the extrados); s is the horizontal distance from the axis in
/// a web's mid-plane, q = s / cos 22.5° that in a corner plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VaultProfile {
    /// Which section carries the circle.
    pub on: ProfileOn,
    /// Apothem a = span/2 of the intrados octagon at the springing.
    pub apothem: Real,
    /// Span across corners at the springing, D_c = 2a / cos 22.5° (circumradius R_c = D_c/2).
    pub corner_span: Real,
    /// Intrados radius of the profile circle, r = profile_ratio · D_c.
    pub radius: Real,
    /// Distance from the axis of the circle's centre in the section that carries it, ≤ 0 (on
    /// the springing plane, beyond the axis): s_c = a − r on the webs, q_c = R_c − r on the
    /// corners.
    pub centre: Real,
    /// ψ of the top bed, where the intrados mid-line reaches s = oculus/2:
    /// cos ψ_top = (oculus/2 − s_c)/r on the webs, (oculus/(2 cos 22.5°) − q_c)/r on the
    /// corners.
    pub psi_top: Real,
    /// ψ where the intrados reaches the axis (the pointed crown, cut off by the oculus):
    /// cos ψ_crown = −centre/r.
    pub psi_crown: Real,
    /// Height of that crown above the springing, r sin ψ_crown: √(2ra − a²) on the webs,
    /// √(2rR_c − R_c²) = D_c √(p − 1/4) on the corners (p = profile_ratio).
    pub crown_height: Real,
    /// Height of the intrados at the top bed, r sin ψ_top.
    pub oculus_height: Real,
}

impl VaultProfile {
    /// Distance from the axis in the section that carries the circle, of the point (ρ, ψ).
    fn section(&self, rho: Real, psi: Real) -> Real {
        self.centre + rho * psi.cos()
    }

    /// s: distance from the axis of the point (ρ, ψ) on a web's mid-line.
    pub fn mid_line(&self, rho: Real, psi: Real) -> Real {
        match self.on {
            ProfileOn::Webs => self.section(rho, psi),
            ProfileOn::Corners => self.section(rho, psi) * HALF_SIDE.cos(),
        }
    }

    /// q: distance from the axis of the point (ρ, ψ) on a corner line.
    pub fn corner(&self, rho: Real, psi: Real) -> Real {
        match self.on {
            ProfileOn::Webs => self.section(rho, psi) / HALF_SIDE.cos(),
            ProfileOn::Corners => self.section(rho, psi),
        }
    }

    /// κ = ds/d(section distance): 1 on the webs, cos 22.5° on the corners.
    fn kappa(&self) -> Real {
        match self.on {
            ProfileOn::Webs => 1.0,
            ProfileOn::Corners => HALF_SIDE.cos(),
        }
    }
}

impl CloisterVault {
    /// The profile, checking `span`, `profile_ratio` and `oculus`.
    pub fn profile(&self) -> Result<VaultProfile, String> {
        need_positive("span", self.span)?;
        let c = HALF_SIDE.cos();
        let a = 0.5 * self.span;
        let corner_span = 2.0 * a / c;
        // The circle must reach the axis before its top: r ≥ the springing's distance from
        // the axis in its section (a on the webs, R_c on the corners).
        let (p_min, what) = match self.profile {
            ProfileOn::Webs => (0.5 * c, "cos(22.5°)/2"),
            ProfileOn::Corners => (0.5, "1/2"),
        };
        if !(self.profile_ratio >= p_min && self.profile_ratio.is_finite()) {
            return Err(format!(
                "'profile_ratio' must be ≥ {what} = {p_min:.6} with profile \"{}\" (with a smaller radius the arc would pass its top and come down before it reached the axis), got {}",
                self.profile.name(),
                self.profile_ratio
            ));
        }
        if !(self.oculus > 0.0 && self.oculus < self.span) {
            return Err(format!(
                "'oculus' must lie in (0, span = {}) m, got {} (a vault closed at the crown is not generated)",
                self.span, self.oculus
            ));
        }
        let r = self.profile_ratio * corner_span;
        let (centre, top) = match self.profile {
            ProfileOn::Webs => (a - r, 0.5 * self.oculus),
            ProfileOn::Corners => (0.5 * corner_span - r, 0.5 * self.oculus / c),
        };
        let psi_crown = (-centre / r).clamp(-1.0, 1.0).acos();
        let psi_top = ((top - centre) / r).clamp(-1.0, 1.0).acos();
        Ok(VaultProfile {
            on: self.profile,
            apothem: a,
            corner_span,
            radius: r,
            centre,
            psi_top,
            psi_crown,
            crown_height: r * psi_crown.sin(),
            oculus_height: r * psi_top.sin(),
        })
    }

    /// Exact volume of the eight webs, ribs left out [m³]. A web is the image of
    /// (ψ, ρ, ξ) ∈ [0, ψ_top] × [r, r + t] × [−1, 1] under s = κ (c + ρ cos ψ), z = ρ sin ψ,
    /// offset ξ s tan 22.5° along the side, with c the circle's centre ([`VaultProfile::centre`])
    /// and κ = 1 on the webs, cos 22.5° on the corners. The mid-plane area element is
    /// κ ρ dρ dψ and the width 2 s tan 22.5°, so
    ///
    /// V = 16 tan 22.5° κ² · [c ψ_top (R₁² − R₀²)/2 + sin ψ_top (R₁³ − R₀³)/3],
    ///
    /// R₀ = r, R₁ = r + t; on the corners 16 tan 22.5° cos² 22.5° = 8 sin 45° = 4√2.
    pub fn web_volume(&self) -> Result<Real, String> {
        let p = self.profile()?;
        let (r0, r1) = (p.radius, p.radius + self.thickness);
        let k = p.kappa();
        Ok(16.0
            * HALF_SIDE.tan()
            * k
            * k
            * (p.centre * p.psi_top * (r1 * r1 - r0 * r0) / 2.0
                + p.psi_top.sin() * (r1.powi(3) - r0.powi(3)) / 3.0))
    }
}

/// Blocks of an octagonal cloister vault ([`CloisterVault`]), meshed at target edge length `h`.
///
/// **Profile.** One vertical section carries the circle of radius r = profile_ratio · D_c,
/// centred on the springing plane beyond the axis, leaving the springing with a vertical
/// tangent ([`ProfileOn`]):
///
/// - `Corners` (default): in each corner plane (q the distance from the axis),
///   (q − q_c)² + z² = r², q_c = R_c − r; the crown, where the corner lines meet on the
///   axis, is at ψ_crown (cos ψ_crown = (r − R_c)/r) and the height √(2rR_c − R_c²) =
///   D_c √(p − 1/4) (0.742 D_c for p = 4/5). Valid for p ≥ 1/2.
/// - `Webs`: in each web's mid-plane (s the distance from the axis), (s − s_c)² + z² = r²,
///   s_c = a − r; crown height √(2ra − a²) (0.725 D_c for 4/5). Valid for p ≥ cos 22.5°/2.
///
/// The extrados is the coaxial circle of radius r + t in the same section.
///
/// **Webs.** Each web is bounded by cylinders with horizontal axes parallel to its side: every
/// horizontal line of web k is parallel to its side, so s (mid-plane) and q (corner plane) of
/// one horizontal line are related by s = q cos 22.5°. With ψ the angle on the circle (0 at
/// the springing), ρ ∈ [r, r + t] and ξ ∈ [−1, 1] across the web, a point of web k is
///
/// z = ρ sin ψ,  s = s_c + ρ cos ψ (`Webs`) or s = (q_c + ρ cos ψ) cos 22.5° (`Corners`),
/// offset along the side = ξ · s · tan 22.5°,
///
/// so ξ = ±1 lies on the corner planes (at q = s / cos 22.5°), and two neighbouring webs give
/// the same point there for the same (ψ, ρ): the meshes conform across the corners exactly.
/// The section without the circle is an ellipse: on `Corners` the mid-lines have semi-axes
/// r cos 22.5° (horizontal) and r; on `Webs` the corners have r / cos 22.5° and r. The
/// thickness measured along the circle's radius is t; in the other section, along the same
/// ray of constant ψ, it is t √(cos² 22.5° cos² ψ + sin² ψ) on the mid-line (`Corners`) or
/// t √(cos² ψ / cos² 22.5° + sin² ψ) on the corner line (`Webs`). On `Corners` the web's
/// thickness along its own normal is therefore t cos 22.5° at the springing (exactly, the
/// web being vertical there) and rises towards t with ψ (t / √(cos² ψ / cos² 22.5° + sin² ψ)
/// to first order in t/r).
///
/// **Sources.** The usual description of Florence (e.g. Museo Galileo, "Brunelleschi and the
/// dome of Florence Cathedral": the vertical ribs of the inner shell have a pointed-fifth
/// curvature whose radius is 4/5 of the diagonal of the base octagon) puts the circle on the
/// eight corner ribs, hence the default. `Webs` keeps the other reading (circular webs,
/// elliptical corners); profile_ratio = (p − 1/4 + cos² 22.5°/4) / cos 22.5° (0.826 for 4/5)
/// gives it the crown height of `Corners` with ratio p, but the surfaces differ between
/// springing and crown. See docs/generators.md.
///
/// **Oculus.** The webs end at the top bed ψ_top, where the intrados mid-line reaches
/// s = oculus/2 (height r sin ψ_top; on `Corners` cos ψ_top = (oculus/(2 cos 22.5°) − q_c)/r,
/// on `Webs` (oculus/2 − s_c)/r); the opening there is a regular octagon `oculus` across
/// flats. **Courses** are equal steps of ψ; bed joints are the planes through each web's
/// cylinder axis along the ray of constant ψ (radial to the circle in the section that
/// carries it; horizontal only at the springing). Head joints are vertical planes through the
/// vault's axis.
///
/// **Blocks and mesh.** One around-grid serves every course: N cells per side (an even
/// number per block, so the mid-line, the half-block offset and the corners are grid lines),
/// sized where s is the geometric mean of its extremes over the mid-surface (as the dome's
/// φ grid). Course c has `blocks_per_web` blocks across each web; odd courses are offset by
/// half a block (running bond), so in them one block straddles each corner: one mesh, bent
/// across the corner plane (each tetrahedron lies in one web). With ribs, every course has a
/// rib block straddling each corner (so the running bond stops at the corners), `width`
/// wide at the springing intrados and reaching from r to r + t + depth: its radial layers
/// include the web's, so its faces shared with the web blocks match node for node, and the
/// part beyond the web is free surface. Between two ribs the even courses have
/// `blocks_per_web` blocks, the odd ones a half block at each end and one full block fewer.
/// The ψ cells of a course are sized by the geometric mean of `h` and the around-cell width
/// (as the dome's θ cells), their length along the circle (ρ Δψ at mid-thickness), the
/// thickness by `h`. Each block is a structured (ψ, around) quad grid cut into triangles,
/// extruded through ρ into prisms of 3 tetrahedra (as `dome`). Head and bed faces are planar
/// and every cell is a hexahedron with planar faces, so the mesh is exact except for the
/// chords of the intrados and extrados arcs in ψ: its volume is low by O(Δψ²) (the extrados
/// chords cut off more than the intrados chords add, being longer and farther from the
/// axis).
///
/// **Numbering.** Blocks are numbered course by course from the springing (course 0, flagged
/// springers) and, within a course, counter-clockwise seen from above, starting with the
/// first block whose clockwise edge is at or after corner 0 (+x): the block straddling
/// corner 0 (odd courses, and every rib at corner 0) is the last of its course.
///
/// Sets of each block (faces + nodes): `intrados` (ρ = r), `extrados` (ρ = r + t; a rib's
/// outer face at r + t + depth), `bed_lower` (towards the springing), `bed_upper` (towards
/// the oculus), `head_left` (its clockwise edge, seen from above), `head_right`
/// (counter-clockwise), `base` (= `bed_lower`, course 0), `oculus` (= `bed_upper`, top
/// course), and on rib blocks `rib`: the free faces beyond the web extrados (the outer face
/// and the two flanks).
pub fn cloister_vault(v: &CloisterVault, h: Real) -> Result<Assembly, String> {
    let pr = v.profile()?;
    need_positive("thickness", v.thickness)?;
    need_positive("size", h)?;
    need_count("courses", v.courses, 1)?;
    need_count("blocks_per_web", v.blocks_per_web, 1)?;
    let tan = HALF_SIDE.tan();
    let side0 = 2.0 * pr.apothem * tan; // intrados side length at the springing
    if let Some(rb) = v.ribs {
        need_positive("rib_depth", rb.depth)?;
        if let Some(w) = rb.width {
            if !(w > 0.0 && w < side0) {
                return Err(format!(
                    "'rib_width' must lie in (0, side length at the springing = {side0:.6}) m, got {w}"
                ));
            }
        }
    }
    let (r0, r1) = (pr.radius, pr.radius + v.thickness);
    let r2 = r1 + v.ribs.map_or(0.0, |rb| rb.depth);
    let psi_t = pr.psi_top;
    let rm = 0.5 * (r0 + r1);
    let nb = v.blocks_per_web;
    // Around-grid: n_side cells from corner to corner, m (even) per block, w (even) per rib,
    // sized where s is the geometric mean of its extremes on the mid-surface.
    let s_ref = (pr.mid_line(rm, 0.0) * pr.mid_line(rm, psi_t)).sqrt();
    let rib_fraction = v.ribs.map(|rb| rb.width.map(|w| w / side0));
    let free = 1.0 - rib_fraction.flatten().unwrap_or(0.0);
    let block_width = 2.0 * s_ref * tan * free / nb as Real;
    let m_half = (block_width / (2.0 * h)).ceil();
    need_reasonable(8.0 * nb as Real * 2.0 * m_half * 6.0)?;
    let m = 2 * (m_half as usize).max(1);
    let w = match rib_fraction {
        None => 0,
        Some(None) => m,
        Some(Some(f)) => 2 * ((0.5 * f * (nb * m) as Real / free).round() as usize).max(1),
    };
    let n_side = nb * m + w;
    let n_around = 8 * n_side;
    let nr = cells(v.thickness, h, 1);
    let nd = v.ribs.map_or(0, |rb| cells(rb.depth, h, 1));
    let psi_edge = |c: usize| lerp(0.0, psi_t, c, v.courses);
    let mut estimate = 0.0;
    let n_psi: Vec<usize> = (0..v.courses)
        .map(|c| {
            let (lo, hi) = (psi_edge(c), psi_edge(c + 1));
            let width = 2.0 * pr.mid_line(rm, 0.5 * (lo + hi)) * tan / n_side as Real;
            let n = cells(rm * (hi - lo), (h * width).sqrt(), 1);
            let prisms = n_around as Real * nr as Real + 8.0 * w as Real * nd as Real;
            estimate += 6.0 * n as Real * prisms;
            n
        })
        .collect();
    need_reasonable(estimate)?;
    let rho: Vec<Real> = (0..=nr)
        .map(|k| lerp(r0, r1, k, nr))
        .chain((1..=nd).map(|k| lerp(r1, r2, k, nd)))
        .collect();
    let corners: [[Real; 2]; 8] = std::array::from_fn(|k| {
        let t = k as Real * PI / 4.0;
        [t.cos(), t.sin()]
    });
    // The point at radius ρ, arc angle ψ and around-grid line q (any integer; wrapped): on
    // side k = q div n_side at the fraction f of the way from corner k to corner k + 1, the
    // horizontal position is d·((1 − f)·c_k + f·c_{k+1}) with d the corner-plane distance
    // (q_c + ρ cos ψ on `Corners`, (s_c + ρ cos ψ)/cos 22.5° on `Webs`), i.e. s = d cos 22.5°
    // along the web normal and ξ·s·tan 22.5° along the side with ξ = 2f − 1. Grid line q is
    // computed the same way in every block (exactly c_k at a corner), so shared nodes are
    // equal.
    let point = |rho: Real, psi: Real, q: Real| -> Vec3 {
        let q = (q.round() as i64).rem_euclid(n_around as i64) as usize;
        let (k, j) = (q / n_side, q % n_side);
        let f = j as Real / n_side as Real;
        let (c0, c1) = (corners[k], corners[(k + 1) % 8]);
        let d = pr.corner(rho, psi);
        Vec3::new(
            d * ((1.0 - f) * c0[0] + f * c1[0]),
            d * ((1.0 - f) * c0[1] + f * c1[1]),
            rho * psi.sin(),
        )
    };
    let mut blocks = Vec::new();
    for (c, &nt) in n_psi.iter().enumerate() {
        let odd = c % 2 == 1;
        let pieces = course_pieces(odd, nb, m, w);
        let (psi_lo, psi_hi) = (psi_edge(c), psi_edge(c + 1));
        for (index, &(q0, nq, rib)) in pieces.iter().enumerate() {
            let mut tri = Tri2::new(1e-12);
            tri.quad_grid(
                nt,
                nq,
                |it, iq| [lerp(psi_lo, psi_hi, it, nt), (q0 + iq) as Real],
                |p| point(r0, p[0], p[1]),
            );
            let layers = if rib { nr + nd } else { nr };
            let mut mesh = tri.extrude(layers, |p, k| point(rho[k], p[0], p[1]));
            let grid = BlockGrid {
                psi: [psi_lo, psi_hi],
                q: [q0 as Real, (q0 + nq) as Real],
                layers,
                web_layers: nr,
                rib,
            };
            add_vault_block_sets(&mut mesh, &tri.pts, &grid, c == 0, c + 1 == v.courses);
            blocks.push(Block {
                mesh,
                course: c,
                index,
                springer: c == 0,
            });
        }
    }
    Ok(Assembly {
        kind: "cloister_vault",
        blocks,
        courses: v.courses,
    })
}

/// (first around-grid line, cells, rib) of each block of a vault course, counter-clockwise
/// from corner 0: `nb` blocks of `m` cells a web (odd courses offset by m/2, so one block
/// straddles each corner), or with ribs of `w` cells, a rib at each corner and the web blocks
/// between (odd courses: a half block at each end).
fn course_pieces(odd: bool, nb: usize, m: usize, w: usize) -> Vec<(usize, usize, bool)> {
    let n_side = nb * m + w;
    let mut pieces = Vec::new();
    if w == 0 {
        let offset = if odd { m / 2 } else { 0 };
        pieces.extend((0..8 * nb).map(|j| (j * m + offset, m, false)));
        return pieces;
    }
    for k in 0..8 {
        let mut q = k * n_side + w / 2;
        let mut widths = Vec::with_capacity(nb + 1);
        if odd {
            widths.push(m / 2);
            widths.extend(std::iter::repeat_n(m, nb - 1));
            widths.push(m / 2);
        } else {
            widths.extend(std::iter::repeat_n(m, nb));
        }
        for cw in widths {
            pieces.push((q, cw, false));
            q += cw;
        }
        pieces.push((q, w, true));
    }
    pieces
}

/// The grid extent of one vault block: ψ of its beds, around-grid lines of its heads, radial
/// layers (the web's, and beyond them the rib's).
struct BlockGrid {
    psi: [Real; 2],
    q: [Real; 2],
    layers: usize,
    web_layers: usize,
    rib: bool,
}

/// Named sets of a vault block, from the grid indices of its nodes (no geometric tolerance):
/// node n is 2-D point n mod n2 of layer n div n2, and the 2-D points `pts` hold (ψ, q)
/// exactly as the grid computed them. `first`/`last` course: also `base`/`oculus`.
fn add_vault_block_sets(
    mesh: &mut Mesh,
    pts: &[[Real; 2]],
    g: &BlockGrid,
    first: bool,
    last: bool,
) {
    let n2 = pts.len() as u32;
    let layer = |n: u32| (n / n2) as usize;
    let psi = |n: u32| pts[(n % n2) as usize][0];
    let q = |n: u32| pts[(n % n2) as usize][1];
    let all = |f: &[u32; 3], t: &dyn Fn(u32) -> bool| f.iter().all(|&n| t(n));
    let (top, web) = (g.layers, g.web_layers);
    add_face_set_by_ids(mesh, "intrados", |f| all(f, &|n| layer(n) == 0));
    add_face_set_by_ids(mesh, "extrados", |f| all(f, &|n| layer(n) == top));
    add_face_set_by_ids(mesh, "bed_lower", |f| all(f, &|n| psi(n) == g.psi[0]));
    add_face_set_by_ids(mesh, "bed_upper", |f| all(f, &|n| psi(n) == g.psi[1]));
    add_face_set_by_ids(mesh, "head_left", |f| all(f, &|n| q(n) == g.q[0]));
    add_face_set_by_ids(mesh, "head_right", |f| all(f, &|n| q(n) == g.q[1]));
    if g.rib {
        add_face_set_by_ids(mesh, "rib", |f| {
            all(f, &|n| layer(n) == top)
                || all(f, &|n| layer(n) >= web && q(n) == g.q[0])
                || all(f, &|n| layer(n) >= web && q(n) == g.q[1])
        });
    }
    for (is, from, to) in [(first, "bed_lower", "base"), (last, "bed_upper", "oculus")] {
        if is {
            let faces = mesh.sets.faces[from].clone();
            let nodes = mesh.sets.nodes[from].clone();
            mesh.sets.faces.insert(to.into(), faces);
            mesh.sets.nodes.insert(to.into(), nodes);
        }
    }
    add_all_elements(mesh);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arch_blocks_are_valid() {
        let a = arch(
            &Arch {
                radius: 1.0,
                thickness: 0.2,
                depth: 0.3,
                voussoirs: 9,
                span_angle: 180.0,
            },
            0.1,
        )
        .unwrap();
        assert_eq!(a.blocks.len(), 9);
        assert!(a.blocks.iter().all(|b| b.mesh.check().is_empty()));
        assert_eq!(a.blocks.iter().filter(|b| b.springer).count(), 2);
        // Assembly quality: the worst over blocks; the worst tet numbered through the blocks.
        let q = a.quality().unwrap();
        let per: Vec<_> = a.blocks.iter().map(|b| b.mesh.quality().unwrap()).collect();
        let min = per
            .iter()
            .map(|q| q.min_dihedral_deg)
            .fold(Real::MAX, Real::min);
        assert_eq!(q.min_dihedral_deg, min);
        let nt = a.blocks[0].mesh.tets.len();
        let (blk, local) = (q.worst_dihedral_tet / nt, q.worst_dihedral_tet % nt);
        assert_eq!(per[blk].min_dihedral_deg, min);
        assert_eq!(per[blk].worst_dihedral_tet, local);
        assert!(q.mean_aspect_ratio >= 1.0 && q.mean_aspect_ratio <= q.max_aspect_ratio);
    }

    #[test]
    fn bad_counts_name_the_key() {
        let e = dome(
            &Dome {
                radius: 1.0,
                thickness: 0.1,
                courses: 3,
                blocks_per_course: 2,
                oculus: 10.0,
                base: 90.0,
            },
            0.1,
        )
        .unwrap_err();
        assert!(e.contains("'blocks_per_course' must be ≥ 3, got 2"), "{e}");
        let e = arch(
            &Arch {
                radius: 1.0,
                thickness: 0.0,
                depth: 0.3,
                voussoirs: 9,
                span_angle: 180.0,
            },
            0.1,
        )
        .unwrap_err();
        assert!(e.contains("'thickness' must be > 0"), "{e}");
    }

    #[test]
    fn cloister_vault_courses_ribs_and_top_bed() {
        let v = CloisterVault {
            span: 6.0,
            thickness: 0.4,
            courses: 3,
            blocks_per_web: 2,
            profile_ratio: 0.8,
            profile: ProfileOn::default(),
            oculus: 1.0,
            ribs: Some(Ribs {
                width: None,
                depth: 0.2,
            }),
        };
        assert_eq!(v.profile, ProfileOn::Corners);
        for on in [ProfileOn::Corners, ProfileOn::Webs] {
            let v = CloisterVault { profile: on, ..v };
            let a = cloister_vault(&v, 0.4).unwrap();
            // Per course 8 ribs + 8 × 2 web blocks (even) or 8 × 3 (odd: two halves + one).
            assert_eq!(a.blocks.len(), 24 + 32 + 24);
            assert!(a.blocks.iter().all(|b| b.mesh.check().is_empty()));
            assert_eq!(a.blocks.iter().filter(|b| b.springer).count(), 24);
            // The oculus set of a web block of the top course (from the rib at corner 0 to
            // the mid-line of web 0): its intrados edge is at the documented height
            // r sin ψ_top, and nearest the axis (on the mid-line) at oculus/2.
            let p = v.profile().unwrap();
            let top = &a.blocks[24 + 32].mesh;
            let edge: Vec<Vec3> = top.sets.nodes["oculus"]
                .iter()
                .map(|&n| top.nodes[n as usize])
                .filter(|x| (x.z - p.oculus_height).abs() < 1e-12 * v.span)
                .collect();
            assert!(!edge.is_empty(), "{}", on.name());
            let near = edge
                .iter()
                .map(|x| x.x.hypot(x.y))
                .fold(Real::INFINITY, Real::min);
            assert!((near - 0.5 * v.oculus).abs() < 1e-12 * v.span, "{near}");
            // And the ribs carry `rib`.
            assert_eq!(
                a.blocks
                    .iter()
                    .filter(|b| b.mesh.sets.faces.contains_key("rib"))
                    .count(),
                24
            );
        }
        // A rib as wide as the side would leave no web between the ribs.
        let e = cloister_vault(
            &CloisterVault {
                ribs: Some(Ribs {
                    width: Some(6.0 * (PI / 8.0).tan()),
                    depth: 0.2,
                }),
                ..v
            },
            0.4,
        )
        .unwrap_err();
        assert!(e.contains("'rib_width' must lie in (0, side length"), "{e}");
    }
}
