//! Element quality: dihedral angles and aspect ratio of tetrahedra.
//!
//! Aspect ratio is the longest edge over the inradius, normalised so that the regular
//! tetrahedron scores 1: `AR = l_max / (2√6 · r)`, `r = 3V / ΣA_faces`. Dihedral angles are
//! the interior angles between the two faces meeting at each of the 6 edges (regular tet:
//! arccos(1/3) = 70.53°). Both are computed on the reference configuration.

use super::{Mesh, TET_FACES};
use crate::math::{Real, Vec3};

/// Quality summary of a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// Smallest interior dihedral angle over all tets [degrees].
    pub min_dihedral_deg: Real,
    /// Largest interior dihedral angle over all tets [degrees].
    pub max_dihedral_deg: Real,
    /// Worst (largest) aspect ratio; 1 for the regular tetrahedron.
    pub max_aspect_ratio: Real,
    /// Mean aspect ratio.
    pub mean_aspect_ratio: Real,
    /// Tet with the smallest dihedral angle.
    pub worst_dihedral_tet: usize,
    /// Tet with the largest aspect ratio.
    pub worst_aspect_tet: usize,
}

/// The 6 interior dihedral angles of a tetrahedron [radians], one per edge.
pub fn dihedral_angles(p: &[Vec3; 4]) -> [Real; 6] {
    // Outward face normals (sign-independent: the angle uses both faces of the same tet,
    // so a left-handed tet flips both normals and leaves the angle unchanged).
    let n: [Vec3; 4] = TET_FACES.map(|f| {
        let (a, b, c) = (p[f[0]], p[f[1]], p[f[2]]);
        (b - a).cross(&(c - a))
    });
    // Edge (i, j) is shared by the faces opposite the two other nodes k, l.
    const EDGES: [[usize; 2]; 6] = [[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]];
    EDGES.map(|[k, l]| {
        let (a, b) = (n[k], n[l]);
        let c = a.dot(&b) / (a.norm() * b.norm()).max(Real::MIN_POSITIVE);
        std::f64::consts::PI - c.clamp(-1.0, 1.0).acos()
    })
}

/// Aspect ratio `l_max / (2√6 · r)` (1 for a regular tet, ∞ for a flat one).
pub fn aspect_ratio(p: &[Vec3; 4]) -> Real {
    let mut l_max: Real = 0.0;
    for i in 0..4 {
        for j in i + 1..4 {
            l_max = l_max.max((p[j] - p[i]).norm());
        }
    }
    let area: Real = TET_FACES
        .iter()
        .map(|f| 0.5 * (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]])).norm())
        .sum();
    let v = crate::math::tet_volume(&p[0], &p[1], &p[2], &p[3]).abs();
    if v <= 0.0 || area <= 0.0 {
        return Real::INFINITY;
    }
    let r = 3.0 * v / area;
    l_max / (2.0 * (6.0 as Real).sqrt() * r)
}

impl Mesh {
    /// Dihedral angles and aspect ratios over all tets (None for an empty mesh).
    pub fn quality(&self) -> Option<Quality> {
        if self.tets.is_empty() {
            return None;
        }
        let mut q = Quality {
            min_dihedral_deg: Real::INFINITY,
            max_dihedral_deg: 0.0,
            max_aspect_ratio: 0.0,
            mean_aspect_ratio: 0.0,
            worst_dihedral_tet: 0,
            worst_aspect_tet: 0,
        };
        let n = self.nodes.len();
        let mut counted = 0usize;
        for (e, t) in self.tets.iter().enumerate() {
            if t.iter().any(|&i| i as usize >= n) {
                continue;
            }
            let p = self.tet_points(e);
            for a in dihedral_angles(&p) {
                let deg = a.to_degrees();
                if deg < q.min_dihedral_deg {
                    q.min_dihedral_deg = deg;
                    q.worst_dihedral_tet = e;
                }
                q.max_dihedral_deg = q.max_dihedral_deg.max(deg);
            }
            let ar = aspect_ratio(&p);
            if ar > q.max_aspect_ratio {
                q.max_aspect_ratio = ar;
                q.worst_aspect_tet = e;
            }
            q.mean_aspect_ratio += ar;
            counted += 1;
        }
        q.mean_aspect_ratio /= counted.max(1) as Real;
        Some(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regular tetrahedron: every dihedral angle is arccos(1/3) = 70.528779°, AR = 1.
    #[test]
    fn regular_tet_scores_one() {
        let s = (8.0f64 / 9.0).sqrt();
        let p = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(s, 0.0, -1.0 / 3.0),
            Vec3::new(-s / 2.0, (2.0f64 / 3.0).sqrt(), -1.0 / 3.0),
            Vec3::new(-s / 2.0, -(2.0f64 / 3.0).sqrt(), -1.0 / 3.0),
        ];
        for a in dihedral_angles(&p) {
            assert!((a.to_degrees() - 70.528779365509).abs() < 1e-9);
        }
        assert!((aspect_ratio(&p) - 1.0).abs() < 1e-12);
    }

    /// Kuhn tets of a unit cube (path tets) have dihedral angles 45°, 60° and 90°;
    /// edges √3 (longest), inradius 3V/A with V = 1/6, A = 1 + √2 + ... computed directly.
    #[test]
    fn kuhn_tet_angles() {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let mut deg: Vec<f64> = dihedral_angles(&p).iter().map(|a| a.to_degrees()).collect();
        deg.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let expect = [45.0, 45.0, 60.0, 90.0, 90.0, 90.0];
        for (d, e) in deg.iter().zip(expect) {
            assert!((d - e).abs() < 1e-9, "{deg:?}");
        }
        // Faces: two right triangles with legs 1,1 (area 1/2) and two with legs 1,√2 (√2/2).
        let area = 1.0 + 2.0f64.sqrt();
        let r = 3.0 * (1.0 / 6.0) / area;
        let ar = 3.0f64.sqrt() / (2.0 * 6.0f64.sqrt() * r);
        assert!((aspect_ratio(&p) - ar).abs() < 1e-12);
    }
}
