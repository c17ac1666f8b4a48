//! Masonry generators: an arch of voussoirs, a wall of bricks in running bond, a dome of
//! voussoir blocks in courses. Each returns an [`Assembly`]: one [`Mesh`] per block, with
//! named face/node sets and the block's course, index and springer flag.
//!
//! Neighbouring blocks share their faces exactly: the same nodes (computed by the same
//! formulas) and the same triangles (see `structured`: prism cuts are ordered by position,
//! Kuhn cuts are the same in every cell), so `sim.insert_joints(#{ between: blocks })` finds
//! every contact face and glues it with a mortar joint.

use super::generators::box_mesh;
use super::solids::{need_positive, need_reasonable};
use super::structured::{add_all_elements, add_face_set, cells, lerp, Tri2};
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
    /// "arch", "wall" or "dome".
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

fn need_count(key: &str, v: usize, min: usize) -> Result<(), String> {
    if v >= min {
        Ok(())
    } else {
        Err(format!("'{key}' must be ≥ {min}, got {v}"))
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
    need_reasonable((n * nr * nt * ny * 6) as Real)?;
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
    need_reasonable((w.courses * w.bricks_per_course * 2 * m * ny * nz * 6) as Real)?;
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
    let m = 2 * ((rm * s_ref * dphi / (2.0 * h)).ceil() as usize).max(1);
    let nphi = nb * m; // φ cells around the whole dome
    let nr = cells(d.thickness, h, 1);
    let tol = 1e-9 * r1;
    let theta_edge = |c: usize| lerp(a1, a0, c, d.courses); // polar angle of bed c (0 = base)
    let mut estimate = 0usize;
    let n_theta: Vec<usize> = (0..d.courses)
        .map(|c| {
            let (tlo, thi) = (theta_edge(c + 1), theta_edge(c));
            let width = rm * (0.5 * (tlo + thi)).sin() * dphi / m as Real;
            let n = cells(rm * (thi - tlo), (h * width).sqrt(), 1);
            estimate += nb * n * m * nr * 6;
            n
        })
        .collect();
    need_reasonable(estimate as Real)?;
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
}
