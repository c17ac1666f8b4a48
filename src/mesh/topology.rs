//! Face topology: boundary faces of a tet mesh, and selections of faces (by normal and
//! region) with their nodes and area.

use super::region::Region;
use super::Mesh;
use crate::math::{Real, Vec3};
use std::collections::HashMap;

/// Local node ids of the face opposite local node k, ordered so that the face normal
/// (b−a)×(c−a) points out of a positively oriented tetrahedron.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// A face on the boundary of a mesh: the tet it belongs to, which local face, and its
/// global nodes ordered with an outward normal.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
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

    /// Centroid of the face at positions `x` [m].
    pub fn centroid(&self, x: &[Vec3]) -> Vec3 {
        self.nodes.iter().map(|&n| x[n as usize]).sum::<Vec3>() / 3.0
    }
}

/// Which boundary faces to keep: those whose outward normal lies within `tolerance` of
/// `normal`, and whose centroid lies in `within` (each test only when given).
/// The default keeps every face (and has the script's 1° tolerance).
#[derive(Clone, Debug, PartialEq)]
pub struct FaceFilter {
    /// Wanted outward normal direction (any length; normalised when tested). A zero vector
    /// matches no face.
    pub normal: Option<Vec3>,
    /// Largest angle between a face's outward normal and `normal` [rad].
    pub tolerance: Real,
    /// Region that must hold the face centroid (surface included, see [`Region::contains`]).
    pub within: Option<Region>,
}

impl Default for FaceFilter {
    fn default() -> Self {
        FaceFilter {
            normal: None,
            tolerance: 1.0_f64.to_radians(),
            within: None,
        }
    }
}

impl FaceFilter {
    /// Whether `face` passes, at positions `x` [m], with containment tolerance `length_tol` [m].
    /// The angle test is cos θ ≥ cos(tolerance) − 1e-12, so a face exactly at the tolerance
    /// angle is kept despite rounding.
    pub fn accepts(&self, face: &BoundaryFace, x: &[Vec3], length_tol: Real) -> bool {
        let ok_n = self.normal.is_none_or(|n| {
            face.area_normal(x).normalize().dot(&n.normalize()) >= self.tolerance.cos() - 1e-12
        });
        let ok_r = self
            .within
            .as_ref()
            .is_none_or(|r| r.contains(&face.centroid(x), length_tol));
        ok_n && ok_r
    }
}

/// The nodes of `faces`, each once, in id order.
pub fn face_nodes(faces: &[BoundaryFace]) -> Vec<u32> {
    let mut v: Vec<u32> = faces.iter().flat_map(|f| f.nodes).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Total area of `faces` at positions `x` [m²] (summed in the given order).
pub fn faces_area(faces: &[BoundaryFace], x: &[Vec3]) -> Real {
    let mut area = 0.0;
    for f in faces {
        area += f.area_normal(x).norm();
    }
    area
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
