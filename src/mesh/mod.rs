//! Tet4 meshes: geometry of constant-strain tetrahedra, structured generators, regions used
//! for selections, and boundary-face topology.
//!
//! A [`Mesh`] is always stored with shared nodes (the continuous topology). Whether a body
//! keeps them shared or gives every tetrahedron its own 4 nodes (node multiplicity, Munjiza's
//! layout for fracture) is decided when the body is added to a simulation.

pub mod cells;
pub mod checks;
mod generators;
pub mod gmsh;
pub mod locate;
pub mod masonry;
pub mod order;
pub mod overlap;
pub mod packing;
pub mod quality;
mod region;
pub mod solids;
mod structured;
mod topology;

pub use checks::{MeshProblem, ProblemKind};
pub use generators::{box_mesh, box_mesh_with, divisions_for, BoxPattern};
pub use quality::Quality;
pub use region::Region;
pub use topology::{boundary_faces, face_nodes, faces_area, BoundaryFace, FaceFilter, TET_FACES};

use crate::math::{rotation_matrix, tet_volume, Mat3, Real, Vec3};
use std::collections::BTreeMap;

/// A tetrahedral mesh with shared nodes. Tet node order is right-handed: the signed volume
/// `(p1−p0)·((p2−p0)×(p3−p0))/6` is positive.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Mesh {
    pub nodes: Vec<Vec3>,
    pub tets: Vec<[u32; 4]>,
    /// Named sets (Gmsh physical groups, generator sets such as `top` or `intrados`).
    pub sets: MeshSets,
}

/// Named subsets of a mesh, by index into the mesh's own nodes and tets. They move with the
/// mesh (translate, rotate, copy) and follow it into a body.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default, PartialEq)]
pub struct MeshSets {
    /// Element sets: sorted, unique tet indices.
    pub elements: BTreeMap<String, Vec<u32>>,
    /// Node sets: sorted, unique node indices.
    pub nodes: BTreeMap<String, Vec<u32>>,
    /// Face sets: (tet, local face 0..4 as in [`TET_FACES`]), sorted and unique.
    pub faces: BTreeMap<String, Vec<(u32, u8)>>,
}

impl MeshSets {
    pub fn is_empty(&self) -> bool {
        self.elements.is_empty() && self.nodes.is_empty() && self.faces.is_empty()
    }

    /// Every set name with its kind ("elements", "nodes", "faces") and size, sorted by name.
    pub fn summary(&self) -> Vec<(String, &'static str, usize)> {
        let mut out: Vec<(String, &'static str, usize)> = Vec::new();
        out.extend(
            self.elements
                .iter()
                .map(|(k, v)| (k.clone(), "elements", v.len())),
        );
        out.extend(
            self.nodes
                .iter()
                .map(|(k, v)| (k.clone(), "nodes", v.len())),
        );
        out.extend(
            self.faces
                .iter()
                .map(|(k, v)| (k.clone(), "faces", v.len())),
        );
        out.sort();
        out
    }

    /// All names, sorted and deduplicated (for "unknown set; the mesh has …" errors).
    pub fn names(&self) -> Vec<String> {
        let mut n: Vec<String> = self
            .elements
            .keys()
            .chain(self.nodes.keys())
            .chain(self.faces.keys())
            .cloned()
            .collect();
        n.sort();
        n.dedup();
        n
    }
}

/// A problem found in a mesh, with the element and its place.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshError {
    pub tet: usize,
    pub centroid: Vec3,
    pub volume: Real,
    pub kind: MeshErrorKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshErrorKind {
    /// Negative signed volume: nodes are ordered left-handed or the element is folded.
    Inverted,
    /// Volume below 1e-12 of the mean: the element has collapsed onto a plane, line or point.
    Degenerate,
    /// A node index is out of range.
    BadNodeIndex,
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = self.centroid;
        match self.kind {
            MeshErrorKind::Inverted => write!(
                f,
                "tet {} is inverted (signed volume {:.3e} m³) at ({:.6}, {:.6}, {:.6}); its nodes must be ordered so that (p1−p0)·((p2−p0)×(p3−p0)) > 0",
                self.tet, self.volume, c.x, c.y, c.z
            ),
            MeshErrorKind::Degenerate => write!(
                f,
                "tet {} is degenerate (volume {:.3e} m³, flat or collapsed) at ({:.6}, {:.6}, {:.6})",
                self.tet, self.volume, c.x, c.y, c.z
            ),
            MeshErrorKind::BadNodeIndex => {
                write!(f, "tet {} refers to a node index that does not exist", self.tet)
            }
        }
    }
}

impl Mesh {
    pub fn new(nodes: Vec<Vec3>, tets: Vec<[u32; 4]>) -> Self {
        Mesh {
            nodes,
            tets,
            sets: MeshSets::default(),
        }
    }

    pub fn tet_points(&self, e: usize) -> [Vec3; 4] {
        let t = self.tets[e];
        [
            self.nodes[t[0] as usize],
            self.nodes[t[1] as usize],
            self.nodes[t[2] as usize],
            self.nodes[t[3] as usize],
        ]
    }

    pub fn tet_volume(&self, e: usize) -> Real {
        let p = self.tet_points(e);
        tet_volume(&p[0], &p[1], &p[2], &p[3])
    }

    pub fn tet_centroid(&self, e: usize) -> Vec3 {
        let p = self.tet_points(e);
        (p[0] + p[1] + p[2] + p[3]) / 4.0
    }

    /// Sum of signed tet volumes [m³].
    pub fn volume(&self) -> Real {
        (0..self.tets.len()).map(|e| self.tet_volume(e)).sum()
    }

    /// Axis-aligned bounding box (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::repeat(Real::INFINITY);
        let mut hi = Vec3::repeat(Real::NEG_INFINITY);
        for p in &self.nodes {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }

    /// Every inverted, degenerate or badly indexed tetrahedron, in element order.
    pub fn check(&self) -> Vec<MeshError> {
        let n = self.nodes.len();
        let mut errors = Vec::new();
        let mean = self.tets.iter().enumerate().fold(0.0, |acc, (e, t)| {
            if t.iter().all(|&i| (i as usize) < n) {
                acc + self.tet_volume(e).abs()
            } else {
                acc
            }
        }) / self.tets.len().max(1) as Real;
        for (e, t) in self.tets.iter().enumerate() {
            if t.iter().any(|&i| (i as usize) >= n) {
                errors.push(MeshError {
                    tet: e,
                    centroid: Vec3::zeros(),
                    volume: 0.0,
                    kind: MeshErrorKind::BadNodeIndex,
                });
                continue;
            }
            let v = self.tet_volume(e);
            let kind = if v.abs() <= 1e-12 * mean {
                MeshErrorKind::Degenerate
            } else if v < 0.0 {
                MeshErrorKind::Inverted
            } else {
                continue;
            };
            errors.push(MeshError {
                tet: e,
                centroid: self.tet_centroid(e),
                volume: v,
                kind,
            });
        }
        errors
    }

    pub fn translate(&mut self, d: Vec3) {
        for p in &mut self.nodes {
            *p += d;
        }
    }

    /// Rotate about `axis` through `center` by `angle` radians (right-hand rule).
    pub fn rotate(&mut self, axis: Vec3, angle: Real, center: Vec3) {
        let r: Mat3 = rotation_matrix(&axis, angle);
        for p in &mut self.nodes {
            *p = center + r * (*p - center);
        }
    }

    /// Scale about `center` by factors along x, y, z (none zero). A negative product mirrors
    /// the mesh; node order is then reversed so volumes stay positive (face sets follow).
    pub fn scale(&mut self, factors: Vec3, center: Vec3) {
        for p in &mut self.nodes {
            *p = center + (*p - center).component_mul(&factors);
        }
        if factors.x * factors.y * factors.z < 0.0 {
            let all: Vec<usize> = (0..self.tets.len()).collect();
            self.flip_tets(&all);
        }
    }

    /// Mirror across the plane through `point` with normal `normal` (not zero). Node order is
    /// reversed so volumes stay positive; face sets name the mirrored faces.
    pub fn mirror(&mut self, point: Vec3, normal: Vec3) {
        let n = normal.normalize();
        for p in &mut self.nodes {
            *p -= 2.0 * (*p - point).dot(&n) * n;
        }
        let all: Vec<usize> = (0..self.tets.len()).collect();
        self.flip_tets(&all);
    }
}
