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

/// How the cells of a structured box mesh are split into tetrahedra.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxPattern {
    /// Every cell split alike, along its diagonal from (min x, min y, min z) to
    /// (max x, max y, max z): the faces inside the mesh lean one way only, so a crack can run
    /// straight along an inclined plane in one family of directions and not in the mirrored
    /// one (in the x–z plane: along (1, 0, 1), not along (1, 0, −1)).
    Kuhn,
    /// Cell (i, j, k) is the Kuhn cell mirrored in x when i is odd, in y when j is odd, in z
    /// when k is odd. Mirroring a cell in the plane of a face keeps that face's diagonal, so
    /// the mesh stays conforming; the cells with i + k even carry one diagonal family in the
    /// x–z plane and those with i + k odd the other, so inclined planes of both directions
    /// run through the mesh, and with even divisions it is its own mirror image in each axis.
    Alternating,
}

/// A structured tet mesh of the box `[min, max]` with `divisions = [nx, ny, nz]` cells, each
/// split into 6 Kuhn tetrahedra (all of volume `cell/6`).
pub fn box_mesh(min: Vec3, max: Vec3, divisions: [usize; 3]) -> Mesh {
    box_mesh_with(min, max, divisions, BoxPattern::Kuhn)
}

/// [`box_mesh`] with the cells split by `pattern`.
pub fn box_mesh_with(min: Vec3, max: Vec3, divisions: [usize; 3], pattern: BoxPattern) -> Mesh {
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
                // Mirroring the cell in an axis swaps its corners' bit for that axis.
                let flip = match pattern {
                    BoxPattern::Kuhn => 0,
                    BoxPattern::Alternating => (i & 1) | ((j & 1) << 1) | ((k & 1) << 2),
                };
                let corner = |c: usize| {
                    let c = c ^ flip;
                    id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))
                };
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

    /// The tets of `m` as sorted lists of node coordinates, rounded to 1e-9.
    fn tet_set(m: &Mesh, map: impl Fn(Vec3) -> Vec3) -> Vec<Vec<[i64; 3]>> {
        let key = |x: Vec3| [x.x, x.y, x.z].map(|c| (c * 1e9).round() as i64);
        let mut set: Vec<Vec<[i64; 3]>> = m
            .tets
            .iter()
            .map(|t| {
                let mut v: Vec<[i64; 3]> =
                    t.iter().map(|&n| key(map(m.nodes[n as usize]))).collect();
                v.sort();
                v
            })
            .collect();
        set.sort();
        set
    }

    #[test]
    fn alternating_box_is_conforming_positive_and_its_own_mirror_image() {
        // Conforming (boundary faces exactly cover the box surface, as above), every tet of
        // positive volume and the box's volume, for odd and even divisions.
        for div in [[3, 4, 5], [4, 2, 6]] {
            let m = box_mesh_with(
                Vec3::zeros(),
                Vec3::new(1.0, 1.0, 1.0),
                div,
                BoxPattern::Alternating,
            );
            assert!(m.check().is_empty());
            assert!((m.volume() - 1.0).abs() < 1e-12);
            let [x, y, z] = div;
            let b = super::super::boundary_faces(&m);
            assert_eq!(b.len(), 4 * (x * y + y * z + z * x));
        }
        // With even divisions, mirroring the box in any axis gives back the same tets; the
        // Kuhn box mirrored in x is a different mesh (its diagonals lean the other way).
        let (lo, hi) = (Vec3::zeros(), Vec3::new(2.0, 1.0, 1.5));
        let alt = box_mesh_with(lo, hi, [4, 2, 6], BoxPattern::Alternating);
        let kuhn = box_mesh(lo, hi, [4, 2, 6]);
        for axis in 0..3 {
            let mirror = |mut p: Vec3| {
                p[axis] = hi[axis] - p[axis];
                p
            };
            assert_eq!(tet_set(&alt, mirror), tet_set(&alt, |p| p), "axis {axis}");
        }
        let mirror_x = |p: Vec3| Vec3::new(hi.x - p.x, p.y, p.z);
        assert_ne!(tet_set(&kuhn, mirror_x), tet_set(&kuhn, |p| p));
    }

    #[test]
    fn alternating_box_has_inclined_faces_of_both_directions() {
        // In a slab one cell thick in y, the x–z diagonal of each cell's y = 0 face is an
        // edge of the mesh. Kuhn cells all carry (0,0)–(1,1); alternating cells carry
        // (0,0)–(1,1) where i + k is even and (1,0)–(0,1) where it is odd.
        let has_edge = |m: &Mesh, a: Vec3, b: Vec3| {
            let close = |p: Vec3, q: Vec3| (p - q).norm() < 1e-12;
            m.tets.iter().any(|t| {
                let x = t.map(|n| m.nodes[n as usize]);
                x.iter().any(|&p| close(p, a)) && x.iter().any(|&p| close(p, b))
            })
        };
        let (lo, hi) = (Vec3::zeros(), Vec3::new(4.0, 1.0, 4.0));
        let kuhn = box_mesh(lo, hi, [4, 1, 4]);
        let alt = box_mesh_with(lo, hi, [4, 1, 4], BoxPattern::Alternating);
        for i in 0..4 {
            for k in 0..4 {
                let (x, z) = (i as Real, k as Real);
                let rising = has_edge(&alt, Vec3::new(x, 0.0, z), Vec3::new(x + 1.0, 0.0, z + 1.0));
                let falling =
                    has_edge(&alt, Vec3::new(x + 1.0, 0.0, z), Vec3::new(x, 0.0, z + 1.0));
                assert_eq!(
                    (rising, falling),
                    ((i + k) % 2 == 0, (i + k) % 2 == 1),
                    "cell {i} {k}"
                );
                assert!(has_edge(
                    &kuhn,
                    Vec3::new(x, 0.0, z),
                    Vec3::new(x + 1.0, 0.0, z + 1.0)
                ));
                assert!(!has_edge(
                    &kuhn,
                    Vec3::new(x + 1.0, 0.0, z),
                    Vec3::new(x, 0.0, z + 1.0)
                ));
            }
        }
    }
}
