//! Point location in a tet4 mesh: which tetrahedron holds a point, and the point's
//! barycentric coordinates in it (used to embed reinforcing bars in their host).
//!
//! A uniform grid of cells about one mean element size holds every tet whose bounding box
//! meets the cell; a query tests the tets of the point's cell. Cost: O(tets) to build,
//! O(tets per cell) a query. A point on a face or edge shared by several tets gets the
//! lowest tet id (deterministic).

use super::Mesh;
use crate::math::{Real, Vec3};

/// Barycentric coordinates of `p` in the tet with corners `c` (w₀ + w₁ + w₂ + w₃ = 1,
/// p = Σ wₐ cₐ); None for a degenerate tet.
pub fn barycentric(c: &[Vec3; 4], p: &Vec3) -> Option<[Real; 4]> {
    let m = crate::math::edge_matrix(&c[0], &c[1], &c[2], &c[3]);
    let w = m.try_inverse()? * (p - c[0]);
    Some([1.0 - w.x - w.y - w.z, w.x, w.y, w.z])
}

/// Where each of `points` lies in `mesh`: (tet, barycentric coordinates), None when no tet
/// holds it. A point counts as inside when every coordinate is ≥ −`tol` (relative: 1e-9 is a
/// good value; it admits points on faces).
pub fn locate_points(mesh: &Mesh, points: &[Vec3], tol: Real) -> Vec<Option<(usize, [Real; 4])>> {
    if mesh.tets.is_empty() {
        return vec![None; points.len()];
    }
    let (lo, hi) = mesh.bounds();
    let size = (mesh.volume().abs() / mesh.tets.len() as Real)
        .cbrt()
        .max(1e-300);
    let pad = 1e-9 * (hi - lo).norm();
    let dims: [usize; 3] =
        std::array::from_fn(|k| (((hi[k] - lo[k]) / size).ceil() as usize).clamp(1, 512));
    let cell_of = |p: &Vec3| -> [usize; 3] {
        std::array::from_fn(|k| {
            let f = (p[k] - lo[k]) / (hi[k] - lo[k]).max(1e-300) * dims[k] as Real;
            (f.floor().max(0.0) as usize).min(dims[k] - 1)
        })
    };
    let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
    for e in 0..mesh.tets.len() {
        let c = mesh.tet_points(e);
        let (mut a, mut b) = (c[0], c[0]);
        for q in &c[1..] {
            a = a.inf(q);
            b = b.sup(q);
        }
        let (ca, cb) = (
            cell_of(&(a - Vec3::repeat(pad))),
            cell_of(&(b + Vec3::repeat(pad))),
        );
        for z in ca[2]..=cb[2] {
            for y in ca[1]..=cb[1] {
                for x in ca[0]..=cb[0] {
                    cells[index([x, y, z])].push(e as u32);
                }
            }
        }
    }
    points
        .iter()
        .map(|p| {
            if (0..3).any(|k| p[k] < lo[k] - pad || p[k] > hi[k] + pad) {
                return None;
            }
            cells[index(cell_of(p))].iter().find_map(|&e| {
                let w = barycentric(&mesh.tet_points(e as usize), p)?;
                w.iter().all(|&wa| wa >= -tol).then_some((e as usize, w))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_found_in_their_tets_and_outside_points_are_not() {
        let mesh = crate::mesh::box_mesh(Vec3::zeros(), Vec3::new(1.0, 0.5, 0.3), [5, 3, 2]);
        let pts = [
            Vec3::new(0.31, 0.22, 0.11),
            Vec3::new(0.2, 0.1, 0.15),
            Vec3::new(1.0, 0.5, 0.3),
            Vec3::new(1.2, 0.2, 0.1),
        ];
        let found = locate_points(&mesh, &pts, 1e-9);
        for (p, f) in pts.iter().zip(&found).take(3) {
            let (e, w) = f.expect("inside");
            let c = mesh.tet_points(e);
            let back: Vec3 = (0..4).map(|a| c[a] * w[a]).sum();
            assert!((back - p).norm() < 1e-12);
        }
        assert!(found[3].is_none());
    }
}
