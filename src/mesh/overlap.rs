//! Overlap of meshes placed in one model: tetrahedra of different bodies that intersect.
//!
//! Broad phase: only tets inside the intersection of the two bodies' bounding boxes, hashed
//! into a uniform grid (cell = twice the mean tet extent). Narrow phase: the separating axis
//! test for two convex polyhedra — 4 + 4 face normals and the 6 × 6 edge cross products. Two
//! tets whose projections on some axis overlap by no more than a tolerance are separated, so
//! touching faces, edges and vertices do not count.

use super::Mesh;
use crate::math::{Real, Vec3};
use std::collections::HashMap;

const EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

fn project(p: &[Vec3; 4], a: &Vec3) -> (Real, Real) {
    let mut lo = Real::INFINITY;
    let mut hi = Real::NEG_INFINITY;
    for q in p {
        let s = q.dot(a);
        lo = lo.min(s);
        hi = hi.max(s);
    }
    (lo, hi)
}

/// True if the interiors of two tetrahedra intersect by more than `tol` (a length) along
/// every separating axis. Touching (within `tol`) is not an intersection.
pub fn tets_intersect(p: &[Vec3; 4], q: &[Vec3; 4], tol: Real) -> bool {
    let separated_on = |a: Vec3| -> bool {
        let n = a.norm();
        if n <= Real::MIN_POSITIVE {
            return false;
        }
        let a = a / n;
        let (p0, p1) = project(p, &a);
        let (q0, q1) = project(q, &a);
        p1 <= q0 + tol || q1 <= p0 + tol
    };
    for t in [p, q] {
        for f in &FACES {
            if separated_on((t[f[1]] - t[f[0]]).cross(&(t[f[2]] - t[f[0]]))) {
                return false;
            }
        }
    }
    // Edge–edge axes; skip near-parallel pairs (their cross product is noise and a face axis
    // already covers them).
    for ep in &EDGES {
        let a = p[ep[1]] - p[ep[0]];
        for eq in &EDGES {
            let b = q[eq[1]] - q[eq[0]];
            let c = a.cross(&b);
            if c.norm() > 1e-9 * a.norm() * b.norm() && separated_on(c) {
                return false;
            }
        }
    }
    true
}

fn tet_box(p: &[Vec3; 4]) -> (Vec3, Vec3) {
    let mut lo = p[0];
    let mut hi = p[0];
    for q in &p[1..] {
        lo = lo.inf(q);
        hi = hi.sup(q);
    }
    (lo, hi)
}

/// Pairs (tet of `a`, tet of `b`) whose interiors intersect, in order, and how many there are
/// in all (the list stops at `limit`). `tol` is a length: overlaps up to it are touching.
pub fn overlapping_tets(
    a: &Mesh,
    b: &Mesh,
    tol: Real,
    limit: usize,
) -> (usize, Vec<(usize, usize)>) {
    let mut pairs = Vec::new();
    let count = visit_overlaps(a, b, tol, |ea, eb| {
        if pairs.len() < limit {
            pairs.push((ea, eb));
        }
        true
    });
    pairs.sort_unstable();
    (count, pairs)
}

/// True if some tetrahedron of `a` intersects one of `b` by more than `tol`: the test of
/// [`overlapping_tets`], stopping at the first overlapping pair (a random packing's
/// rejections, most of which overlap in many pairs).
pub fn meshes_overlap(a: &Mesh, b: &Mesh, tol: Real) -> bool {
    visit_overlaps(a, b, tol, |_, _| false) > 0
}

/// Calls `found(tet of a, tet of b)` for each intersecting pair, in an order fixed by the
/// meshes, until it returns false; the number of pairs found.
fn visit_overlaps(
    a: &Mesh,
    b: &Mesh,
    tol: Real,
    mut found: impl FnMut(usize, usize) -> bool,
) -> usize {
    let (alo, ahi) = a.bounds();
    let (blo, bhi) = b.bounds();
    let lo = alo.sup(&blo);
    let hi = ahi.inf(&bhi);
    if (0..3).any(|k| hi[k] - lo[k] <= tol) {
        return 0;
    }
    // Tets of each mesh whose box reaches into the common box.
    let near = |m: &Mesh| -> Vec<(usize, [Vec3; 4], Vec3, Vec3)> {
        (0..m.tets.len())
            .filter_map(|e| {
                let p = m.tet_points(e);
                let (l, h) = tet_box(&p);
                ((0..3).all(|k| h[k] > lo[k] + tol && l[k] < hi[k] - tol)).then_some((e, p, l, h))
            })
            .collect()
    };
    let na = near(a);
    let nb = near(b);
    if na.is_empty() || nb.is_empty() {
        return 0;
    }
    let mean_extent = nb.iter().map(|(_, _, l, h)| (h - l).max()).sum::<Real>() / nb.len() as Real;
    let cell = (2.0 * mean_extent).max(1e-300);
    let key = |p: &Vec3| -> [i64; 3] {
        [0, 1, 2].map(|k| ((p[k] - lo[k]) / cell).floor().clamp(-1e9, 1e9) as i64)
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, (_, _, l, h)) in nb.iter().enumerate() {
        let (k0, k1) = (key(l), key(h));
        for x in k0[0]..=k1[0] {
            for y in k0[1]..=k1[1] {
                for z in k0[2]..=k1[2] {
                    grid.entry([x, y, z]).or_default().push(i as u32);
                }
            }
        }
    }
    let mut stamp = vec![usize::MAX; nb.len()];
    let mut count = 0;
    for (ia, (ea, pa, la, ha)) in na.iter().enumerate() {
        let (k0, k1) = (key(la), key(ha));
        for x in k0[0]..=k1[0] {
            for y in k0[1]..=k1[1] {
                for z in k0[2]..=k1[2] {
                    let Some(list) = grid.get(&[x, y, z]) else {
                        continue;
                    };
                    for &ib in list {
                        let ib = ib as usize;
                        if stamp[ib] == ia {
                            continue;
                        }
                        stamp[ib] = ia;
                        let (eb, pb, lb, hb) = &nb[ib];
                        if (0..3).any(|k| ha[k] <= lb[k] + tol || hb[k] <= la[k] + tol) {
                            continue;
                        }
                        if tets_intersect(pa, pb, tol) {
                            count += 1;
                            if !found(*ea, *eb) {
                                return count;
                            }
                        }
                    }
                }
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::box_mesh;

    fn tet(o: Vec3, s: Real) -> [Vec3; 4] {
        [
            o,
            o + Vec3::new(s, 0.0, 0.0),
            o + Vec3::new(0.0, s, 0.0),
            o + Vec3::new(0.0, 0.0, s),
        ]
    }

    #[test]
    fn separating_axes() {
        let a = tet(Vec3::zeros(), 1.0);
        // Overlapping corner.
        assert!(tets_intersect(
            &a,
            &tet(Vec3::new(0.2, 0.2, 0.2), 1.0),
            1e-12
        ));
        // Beyond the slanted face x + y + z = 1 but inside the bounding box: separated.
        assert!(!tets_intersect(
            &a,
            &tet(Vec3::new(0.4, 0.4, 0.4), 1.0),
            1e-12
        ));
        // Touching face to face: the mirror image across the plane x = 0.
        let m = a.map(|p| Vec3::new(-p.x, p.y, p.z));
        assert!(!tets_intersect(&a, &m, 1e-12));
        // Edge–edge case: two slender tets crossing like an X, separated only by an edge axis.
        let p = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.1, -0.1),
            Vec3::new(0.0, -0.1, -0.1),
        ];
        let q = [
            Vec3::new(0.0, -1.0, 0.01),
            Vec3::new(0.0, 1.0, 0.01),
            Vec3::new(0.1, 0.0, 0.11),
            Vec3::new(-0.1, 0.0, 0.11),
        ];
        assert!(!tets_intersect(&p, &q, 1e-12));
        let q_low = q.map(|v| v - Vec3::new(0.0, 0.0, 0.05));
        assert!(tets_intersect(&p, &q_low, 1e-12));
    }

    #[test]
    fn touching_boxes_do_not_overlap_and_interpenetrating_ones_do() {
        let a = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [3, 3, 3]);
        let b = box_mesh(
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 1.0),
            [2, 4, 3],
        );
        assert_eq!(overlapping_tets(&a, &b, 1e-9, 10).0, 0);
        let c = box_mesh(
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 1.0),
            [2, 4, 3],
        );
        let (n, pairs) = overlapping_tets(&a, &c, 1e-9, 3);
        assert!(n > 0 && pairs.len() == 3);
        for (ea, _) in pairs {
            assert!(a.tet_points(ea).iter().any(|p| p.x > 0.9));
        }
    }
}
