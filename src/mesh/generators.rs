//! Structured mesh generators.

use super::Mesh;
use crate::math::{Real, Vec3};

/// The 6 tetrahedra of Kuhn's (Freudenthal's) subdivision of the unit cube, as corner ids
/// `i + 2j + 4k` of corner (i, j, k). Every tet runs from corner 0 to corner 7 along one
/// monotone path, so neighbouring cubes split their shared face along the same diagonal and
/// the mesh is conforming. Orders are chosen so that every tet has positive volume.
const KUHN_TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7], // x, y, z
    [0, 1, 5, 7], // x, z, y  (odd permutation: swapped below)
    [0, 2, 3, 7], // y, x, z
    [0, 2, 6, 7], // y, z, x
    [0, 4, 5, 7], // z, x, y
    [0, 4, 6, 7], // z, y, x
];

/// A structured tet mesh of the box `[min, max]` with `divisions = [nx, ny, nz]` cells, each
/// split into 6 Kuhn tetrahedra (all of volume `cell/6`).
pub fn box_mesh(min: Vec3, max: Vec3, divisions: [usize; 3]) -> Mesh {
    let [nx, ny, nz] = divisions;
    let h = Vec3::new(
        (max.x - min.x) / nx as Real,
        (max.y - min.y) / ny as Real,
        (max.z - min.z) / nz as Real,
    );
    let id = |i: usize, j: usize, k: usize| (i + (nx + 1) * (j + (ny + 1) * k)) as u32;
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                // Exact end coordinates (no accumulated rounding on the far faces).
                let c = |n: usize, m: usize, lo: Real, hi: Real, d: Real| {
                    if n == m {
                        hi
                    } else {
                        lo + n as Real * d
                    }
                };
                nodes.push(Vec3::new(
                    c(i, nx, min.x, max.x, h.x),
                    c(j, ny, min.y, max.y, h.y),
                    c(k, nz, min.z, max.z, h.z),
                ));
            }
        }
    }
    let mut tets = Vec::with_capacity(6 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let corner = |c: usize| id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                for t in KUHN_TETS {
                    let mut tet = [corner(t[0]), corner(t[1]), corner(t[2]), corner(t[3])];
                    let p = |n: u32| nodes[n as usize];
                    if crate::math::tet_volume(&p(tet[0]), &p(tet[1]), &p(tet[2]), &p(tet[3])) < 0.0
                    {
                        tet.swap(1, 2);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    Mesh::new(nodes, tets)
}

/// Cell counts for a box of extent `size_xyz` meshed with target edge `h`: round(L/h), ≥ 1.
pub fn divisions_for(extent: Vec3, h: Real) -> [usize; 3] {
    let n = |l: Real| ((l / h).round() as usize).max(1);
    [n(extent.x), n(extent.y), n(extent.z)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_volume_and_orientation() {
        let m = box_mesh(
            Vec3::new(-1.0, 0.0, 2.0),
            Vec3::new(2.0, 0.5, 3.0),
            [3, 2, 4],
        );
        assert_eq!(m.tets.len(), 6 * 3 * 2 * 4);
        assert_eq!(m.nodes.len(), 4 * 3 * 5);
        assert!(m.check().is_empty());
        assert!((m.volume() - 1.5).abs() < 1e-12);
    }

    #[test]
    fn box_is_conforming() {
        // Conforming ⇔ every interior face is shared by exactly two tets, so boundary faces
        // cover exactly the box surface: 2·(nx·ny + ny·nz + nz·nx) cells × 2 triangles.
        let m = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [3, 4, 5]);
        let b = super::super::boundary_faces(&m);
        assert_eq!(b.len(), 4 * (3 * 4 + 4 * 5 + 5 * 3));
    }
}
