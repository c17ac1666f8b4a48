//! Random non-overlapping placement of copies of one mesh in a box: the loose initial state of
//! a packing (particles, grains, cells) that gravity then pours into a container.
//!
//! Random sequential addition: each copy gets a uniformly random orientation (Shoemake's
//! uniform unit quaternion, so orientations are uniform on SO(3)) and a uniformly random
//! position at which its rotated bounding box lies inside the box; it is kept unless it comes
//! closer than `gap` to a copy already placed, and otherwise drawn again. Closeness is decided
//! exactly on the meshes, not on bounding spheres, so flat or concave shapes (discs, biconcave
//! cells) pack as densely as their shape allows: candidate copies whose bounding spheres are
//! within reach are tested tet against tet with the separating-axis test of
//! [`super::overlap`], widened by `gap` (a pair is apart only if some axis separates it by at
//! least `gap`, which is conservative). Copies whose centres are closer than twice the
//! radius of a ball about the centre that lies inside the mesh overlap for certain and are
//! redrawn without the tet test (for round particles that is most rejections). Draws come from a SplitMix64 stream seeded by `seed`:
//! the same inputs give the same packing on every machine and thread count.

use super::masonry::{Assembly, Block};
use super::overlap::meshes_overlap;
use super::solids::need_reasonable;
use super::Mesh;
use crate::math::{Real, SplitMix64, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};
use std::collections::HashMap;
use std::f64::consts::PI;

/// What `random_packing` places and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Number of copies.
    pub count: usize,
    /// Box corners [m]: every copy lies inside.
    pub min: Vec3,
    pub max: Vec3,
    /// Smallest distance kept between copies [m] (≥ 0).
    pub gap: Real,
    /// Random orientations (otherwise every copy keeps the mesh's orientation).
    pub rotate: bool,
    pub seed: u64,
    /// Draws allowed in total before giving up.
    pub max_attempts: usize,
}

/// A uniformly distributed rotation (Shoemake 1992, *Graphics Gems III*: uniform random
/// rotations from three uniform numbers).
fn random_rotation(rng: &mut SplitMix64) -> UnitQuaternion<Real> {
    let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (t2, t3) = (2.0 * PI * u2, 2.0 * PI * u3);
    UnitQuaternion::from_quaternion(Quaternion::new(
        b * t3.cos(),
        a * t2.sin(),
        a * t2.cos(),
        b * t3.sin(),
    ))
}

/// Copies of `mesh` placed at random in the box without overlap, as an assembly (kind
/// `"random_packing"`, one block per copy, in the order placed). Each copy keeps the mesh's
/// sets. Fails, saying how far it got, if `count` copies do not fit in `max_attempts` draws.
pub fn random_packing(mesh: &Mesh, p: &Placement) -> Result<Assembly, String> {
    let (placed, attempts) = place(mesh, p)?;
    if placed.len() < p.count {
        let fraction = placed.len() as Real * mesh.volume() / (p.max - p.min).product();
        return Err(format!(
            "placed {} of {} copies in {} attempts (solid fraction {:.3} of the box): \
             enlarge the box, lower 'count' or raise 'attempts'",
            placed.len(),
            p.count,
            attempts,
            fraction
        ));
    }
    Ok(Assembly {
        kind: "random_packing",
        blocks: placed
            .into_iter()
            .enumerate()
            .map(|(index, (_, mesh))| Block {
                mesh,
                course: 0,
                index,
                springer: false,
            })
            .collect(),
        courses: 1,
    })
}

/// The copies placed (centre, mesh) and the draws used; fewer than `count` copies if the
/// draws ran out.
type Placed = (Vec<(Vec3, Mesh)>, usize);

fn place(mesh: &Mesh, p: &Placement) -> Result<Placed, String> {
    if mesh.tets.is_empty() {
        return Err("the mesh has no tetrahedra".into());
    }
    need_reasonable(p.count as Real * mesh.tets.len() as Real)?;
    if !(p.gap >= 0.0 && p.gap.is_finite()) {
        return Err(format!("'gap' must be ≥ 0, got {}", p.gap));
    }
    if (0..3).any(|k| !(p.min[k].is_finite() && p.max[k].is_finite() && p.max[k] > p.min[k])) {
        return Err(format!(
            "'max' must be above 'min' on every axis, got min {:?} and max {:?}",
            p.min.as_slice(),
            p.max.as_slice()
        ));
    }
    // Centre the mesh on its bounding-box centre; its bounding sphere about that point.
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let local: Vec<Vec3> = mesh.nodes.iter().map(|q| q - centre).collect();
    let radius = local.iter().map(|q| q.norm()).fold(0.0, Real::max);
    let reach = 2.0 * radius + p.gap;
    // Copies closer than this overlap for certain (two inscribed balls intersect).
    let sure_overlap = 2.0 * inscribed_radius(mesh, &centre);

    let mut rng = SplitMix64(p.seed);
    let mut placed: Vec<(Vec3, Mesh)> = Vec::with_capacity(p.count.min(1 << 20));
    // Centres hashed in cells of `reach`: a copy can only touch copies in the 27 cells around.
    let cell_of = |c: &Vec3| -> [i64; 3] {
        [0, 1, 2].map(|k| ((c[k] - p.min[k]) / reach).floor().clamp(-1e9, 1e9) as i64)
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut attempts = 0usize;
    while placed.len() < p.count {
        if attempts >= p.max_attempts {
            break;
        }
        attempts += 1;
        let rotation = if p.rotate {
            random_rotation(&mut rng)
        } else {
            UnitQuaternion::identity()
        };
        let rotated: Vec<Vec3> = local.iter().map(|q| rotation * q).collect();
        let (mut rlo, mut rhi) = (Vec3::repeat(Real::INFINITY), Vec3::repeat(-Real::INFINITY));
        for q in &rotated {
            rlo = rlo.inf(q);
            rhi = rhi.sup(q);
        }
        // The centre's range keeps the rotated copy inside the box; draw all three numbers
        // even if an axis has no room, so the stream does not depend on the outcome.
        let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let from = p.min - rlo;
        let to = p.max - rhi;
        if (0..3).any(|k| to[k] < from[k]) {
            if placed.is_empty() && attempts >= 64 && !p.rotate {
                return Err(format!(
                    "the mesh ({:?} m across) does not fit in the box",
                    (hi - lo).as_slice()
                ));
            }
            continue;
        }
        let c = from + (to - from).component_mul(&u);
        let mut copy = mesh.clone();
        for (node, q) in copy.nodes.iter_mut().zip(&rotated) {
            *node = c + q;
        }
        let key = cell_of(&c);
        let mut clear = true;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = grid.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) else {
                        continue;
                    };
                    for &j in list {
                        let (cj, other) = &placed[j as usize];
                        let d = (cj - c).norm();
                        if d >= reach {
                            continue;
                        }
                        if d < sure_overlap {
                            clear = false;
                            break 'search;
                        }
                        if meshes_overlap(&copy, other, -p.gap) {
                            clear = false;
                            break 'search;
                        }
                    }
                }
            }
        }
        if clear {
            grid.entry(key).or_default().push(placed.len() as u32);
            placed.push((c, copy));
        }
    }
    Ok((placed, attempts))
}

/// Radius of a ball about `centre` that lies inside the mesh [m]: the smallest distance from
/// `centre` to the plane of a boundary face (a lower bound of the distance to the boundary),
/// or 0 when `centre` is in no tetrahedron (a ring, a biconcave cell's dimple).
fn inscribed_radius(mesh: &Mesh, centre: &Vec3) -> Real {
    if super::locate::locate_points(mesh, &[*centre], 0.0)[0].is_none() {
        return 0.0;
    }
    super::topology::boundary_faces(mesh)
        .iter()
        .map(|f| {
            let [a, b, c] = f.nodes.map(|n| mesh.nodes[n as usize]);
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if len > 0.0 {
                (centre - a).dot(&n).abs() / len
            } else {
                0.0
            }
        })
        .fold(Real::INFINITY, Real::min)
        .min(Real::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::cells::{biconcave_cell, EvansFung};
    use crate::mesh::overlap::overlapping_tets;
    use crate::mesh::solids::sphere;

    fn placement(count: usize, side: Real, seed: u64) -> Placement {
        Placement {
            count,
            min: Vec3::zeros(),
            max: Vec3::repeat(side),
            gap: 0.0,
            rotate: true,
            seed,
            max_attempts: 100_000,
        }
    }

    /// No two copies intersect (checked on every pair, not only the hashed neighbours), each
    /// lies inside the box, and the same seed gives the same packing.
    #[test]
    fn copies_do_not_overlap_and_stay_in_the_box() {
        let cell = biconcave_cell(&EvansFung::HUMAN, 1.2e-6).unwrap();
        let p = Placement {
            gap: 0.05e-6,
            ..placement(15, 20e-6, 7)
        };
        let a = random_packing(&cell, &p).unwrap();
        assert_eq!(a.blocks.len(), 15);
        for (i, bi) in a.blocks.iter().enumerate() {
            assert!(bi.mesh.check().is_empty());
            let (lo, hi) = bi.mesh.bounds();
            assert!((0..3).all(|k| lo[k] >= -1e-18 && hi[k] <= 20e-6 + 1e-18));
            for bj in &a.blocks[i + 1..] {
                assert_eq!(overlapping_tets(&bi.mesh, &bj.mesh, 0.0, 1).0, 0);
            }
        }
        let b = random_packing(&cell, &p).unwrap();
        assert!(a
            .blocks
            .iter()
            .zip(&b.blocks)
            .all(|(x, y)| x.mesh.nodes == y.mesh.nodes));
        let c = random_packing(&cell, &Placement { seed: 8, ..p }).unwrap();
        assert!(a.blocks[0].mesh.nodes != c.blocks[0].mesh.nodes);
    }

    /// Orientations are uniform on SO(3): a rotated unit vector has ⟨n⟩ = 0 and
    /// ⟨n_z²⟩ = 1/3. With 20 000 samples the standard errors are 0.004 and 0.002; the
    /// tolerances are about five of them.
    #[test]
    fn orientations_are_uniform() {
        let mut rng = SplitMix64(3);
        let n = 20_000;
        let (mut mean, mut zz) = (Vec3::zeros(), 0.0);
        for _ in 0..n {
            let v = random_rotation(&mut rng) * Vec3::z();
            mean += v;
            zz += v.z * v.z;
        }
        mean /= n as Real;
        zz /= n as Real;
        assert!(mean.norm() < 0.02, "{mean:?}");
        assert!((zz - 1.0 / 3.0).abs() < 0.01, "{zz}");
    }

    /// A box too small for the count is an error that says how far it got.
    #[test]
    fn an_overfull_box_is_refused() {
        let ball = sphere(1.0, 0.5).unwrap();
        let e = random_packing(
            &ball,
            &Placement {
                max_attempts: 2000,
                ..placement(50, 4.0, 1)
            },
        )
        .unwrap_err();
        assert!(
            e.contains("of 50 copies") && e.contains("solid fraction"),
            "{e}"
        );
        let e = random_packing(
            &ball,
            &Placement {
                rotate: false,
                ..placement(1, 1.0, 1)
            },
        )
        .unwrap_err();
        assert!(e.contains("does not fit"), "{e}");
    }

    /// Random sequential addition of equal spheres saturates near a solid fraction of 0.38
    /// (the jamming limit of RSA in 3D, Talbot, Tarjus & Schaaf 1991 give 0.3841); with
    /// walls and a finite number of draws this packing must land below it but well above
    /// half of it — a check that the exact-overlap test does not reject too much.
    #[test]
    fn sequential_addition_of_spheres_reaches_a_plausible_density() {
        let ball = sphere(0.5, 0.4).unwrap();
        let side = 5.0;
        let mut p = placement(10_000, side, 11);
        p.max_attempts = 6_000;
        let (placed, _) = place(&ball, &p).unwrap();
        let fraction = placed.len() as Real * ball.volume() / side.powi(3);
        assert!(fraction > 0.2 && fraction < 0.3841, "{fraction}");
    }

    /// The shortcut that redraws copies without the tet test: the inscribed radius about the
    /// centre is a lower bound of the distance to the surface (sphere: between 0.9·R and R for
    /// this mesh; the cell: at most half its 0.81 µm centre thickness), and copies closer than
    /// twice it overlap on the exact test, in every one of 100 random orientations and
    /// distances. Reference: the exact tet–tet test of `overlap`, which the shortcut must
    /// never contradict.
    #[test]
    fn the_inscribed_ball_shortcut_only_rejects_copies_that_overlap() {
        let ball = sphere(0.5, 0.2).unwrap();
        let cell = biconcave_cell(&EvansFung::HUMAN, 1.2e-6).unwrap();
        for (mesh, lo, hi) in [(&ball, 0.45, 0.5), (&cell, 0.1e-6, 0.405e-6)] {
            let (l, h) = mesh.bounds();
            let centre = 0.5 * (l + h);
            let r = inscribed_radius(mesh, &centre);
            assert!(r > lo && r <= hi, "inscribed radius {r}");
            let mut rng = SplitMix64(5);
            for _ in 0..100 {
                let place_copy = |rng: &mut SplitMix64, at: Vec3| {
                    let q = random_rotation(rng);
                    let mut m = mesh.clone();
                    for x in &mut m.nodes {
                        *x = at + q * (*x - centre);
                    }
                    m
                };
                let dir = Vec3::new(
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                )
                .normalize();
                let d = 2.0 * r * rng.uniform();
                let a = place_copy(&mut rng, Vec3::zeros());
                let b = place_copy(&mut rng, dir * d);
                assert!(
                    overlapping_tets(&a, &b, 0.0, 1).0 > 0,
                    "d = {d} < 2r = {}",
                    2.0 * r
                );
            }
        }
    }
}
