//! Face topology: boundary faces of a tet mesh.

use super::Mesh;
use crate::math::Vec3;
use std::collections::HashMap;

/// Local node ids of the face opposite local node k, ordered so that the face normal
/// (b−a)×(c−a) points out of a positively oriented tetrahedron.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// A face on the boundary of a mesh: the tet it belongs to, which local face, and its
/// global nodes ordered with an outward normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoundaryFace {
    pub tet: u32,
    pub local: u8,
    pub nodes: [u32; 3],
}

impl BoundaryFace {
    /// Outward normal scaled by the face area (|n| = area) [m²].
    pub fn area_normal(&self, x: &[Vec3]) -> Vec3 {
        let [a, b, c] = self.nodes.map(|n| x[n as usize]);
        0.5 * (b - a).cross(&(c - a))
    }
}

/// Faces that belong to exactly one tetrahedron, in (tet, local face) order.
pub fn boundary_faces(mesh: &Mesh) -> Vec<BoundaryFace> {
    let mut count: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.tets.len() * 2);
    let key = |t: &[u32; 4], f: &[usize; 3]| {
        let mut k = [t[f[0]], t[f[1]], t[f[2]]];
        k.sort_unstable();
        k
    };
    for t in &mesh.tets {
        for f in &TET_FACES {
            *count.entry(key(t, f)).or_insert(0) += 1;
        }
    }
    let mut faces = Vec::new();
    for (e, t) in mesh.tets.iter().enumerate() {
        for (l, f) in TET_FACES.iter().enumerate() {
            if count[&key(t, f)] == 1 {
                faces.push(BoundaryFace {
                    tet: e as u32,
                    local: l as u8,
                    nodes: [t[f[0]], t[f[1]], t[f[2]]],
                });
            }
        }
    }
    faces
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Real;

    #[test]
    fn normals_point_out_and_close() {
        // A closed surface: Σ area·n = 0 and Σ (centroid·n)·area/3 = volume (divergence theorem).
        let m = super::super::box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 3.0), [2, 3, 2]);
        let b = boundary_faces(&m);
        let mut sum = Vec3::zeros();
        let mut vol: Real = 0.0;
        for f in &b {
            let an = f.area_normal(&m.nodes);
            let c = f.nodes.iter().map(|&n| m.nodes[n as usize]).sum::<Vec3>() / 3.0;
            sum += an;
            vol += c.dot(&an) / 3.0;
        }
        assert!(sum.norm() < 1e-12);
        assert!((vol - 6.0).abs() < 1e-12);
    }
}
