//! Mesh checks beyond single elements: duplicate elements, non-manifold faces, tetrahedra
//! that fold over a neighbour, unreferenced nodes; the orientation fix; and node-order flips
//! that keep face sets consistent.
//!
//! A *fold*: two tetrahedra sharing a face must lie on opposite sides of it. If both opposite
//! vertices are on the same side, the mesh overlaps itself there. This test does not depend on
//! the node order of either tetrahedron, which is what makes the orientation fix safe: a
//! left-handed tetrahedron that folds over nothing is only listed in the wrong order, while
//! one that folds is geometrically wrong and reordering cannot repair it.

use super::{Mesh, MeshErrorKind, TET_FACES};
use crate::math::{Real, Vec3};
use std::collections::HashMap;

/// What is wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    BadNodeIndex,
    Inverted,
    Degenerate,
    /// Two tetrahedra with the same four nodes.
    DuplicateElement,
    /// A face shared by more than two tetrahedra.
    NonManifoldFace,
    /// Two tetrahedra on the same side of their shared face.
    Folded,
    /// A node no tetrahedron uses (it would have no mass).
    UnreferencedNode,
}

/// A problem in a mesh, naming its elements (mesh tet ids) and place.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshProblem {
    pub kind: ProblemKind,
    /// Tetrahedra involved (mesh ids).
    pub elements: Vec<usize>,
    /// Nodes involved (mesh ids).
    pub nodes: Vec<u32>,
    /// Where (centroid of the element or face, or the node).
    pub at: Vec3,
    pub message: String,
}

impl std::fmt::Display for MeshProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub(crate) fn fmt_point(p: &Vec3) -> String {
    format!("({:.6}, {:.6}, {:.6})", p.x, p.y, p.z)
}

/// Six times the signed volume of (a, b, c, d).
fn orient(a: &Vec3, b: &Vec3, c: &Vec3, d: &Vec3) -> Real {
    (b - a).dot(&(c - a).cross(&(d - a)))
}

/// Every face of the tets not skipped, as (sorted face nodes, tet, local face), sorted so that
/// the tets sharing a face are adjacent (a sort is several times faster than a hash map of
/// lists on large meshes).
pub(crate) fn sorted_faces(mesh: &Mesh, skip: &[bool]) -> Vec<([u32; 3], u32, u8)> {
    let mut v: Vec<([u32; 3], u32, u8)> = Vec::with_capacity(mesh.tets.len() * 4);
    for (e, t) in mesh.tets.iter().enumerate() {
        if skip.get(e).copied().unwrap_or(false) {
            continue;
        }
        for (l, f) in TET_FACES.iter().enumerate() {
            let mut k = [t[f[0]], t[f[1]], t[f[2]]];
            k.sort_unstable();
            v.push((k, e as u32, l as u8));
        }
    }
    v.sort_unstable();
    v
}

/// Groups of tets sharing a face: (face nodes, [(tet, local face)]).
fn face_groups(
    faces: &[([u32; 3], u32, u8)],
) -> impl Iterator<Item = ([u32; 3], Vec<(u32, u8)>)> + '_ {
    faces
        .chunk_by(|a, b| a.0 == b.0)
        .map(|g| (g[0].0, g.iter().map(|&(_, t, l)| (t, l)).collect()))
}

impl Mesh {
    /// Volumes below this are degenerate: 1e-12 × the mean |volume|.
    fn degenerate_threshold(&self) -> Real {
        let n = self.nodes.len();
        let (sum, count) = self
            .tets
            .iter()
            .enumerate()
            .filter(|(_, t)| t.iter().all(|&i| (i as usize) < n))
            .fold((0.0, 0usize), |(s, c), (e, _)| {
                (s + self.tet_volume(e).abs(), c + 1)
            });
        1e-12 * sum / count.max(1) as Real
    }

    /// Pairs of tetrahedra that fold over each other (same side of their shared face), among
    /// tets not skipped; with the face nodes.
    fn folds(&self, skip: &[bool]) -> Vec<(usize, usize, [u32; 3])> {
        let mut out = Vec::new();
        let faces = sorted_faces(self, skip);
        for (k, owners) in face_groups(&faces) {
            if owners.len() != 2 {
                continue;
            }
            let [a, b, c] = k.map(|i| self.nodes[i as usize]);
            let side = |&(t, l): &(u32, u8)| {
                let d = self.nodes[self.tets[t as usize][l as usize] as usize];
                orient(&a, &b, &c, &d)
            };
            if side(&owners[0]) * side(&owners[1]) > 0.0 {
                let (e1, e2) = (owners[0].0 as usize, owners[1].0 as usize);
                out.push((e1.min(e2), e1.max(e2), k));
            }
        }
        out.sort_unstable();
        out
    }

    /// Every problem of the mesh, each naming its elements and place: bad node indices,
    /// inverted and degenerate tetrahedra, duplicate elements, non-manifold faces, folds and
    /// unreferenced nodes. Empty for a valid mesh.
    pub fn problems(&self) -> Vec<MeshProblem> {
        let mut out: Vec<MeshProblem> = self
            .check()
            .into_iter()
            .map(|p| MeshProblem {
                kind: match p.kind {
                    MeshErrorKind::BadNodeIndex => ProblemKind::BadNodeIndex,
                    MeshErrorKind::Inverted => ProblemKind::Inverted,
                    MeshErrorKind::Degenerate => ProblemKind::Degenerate,
                },
                elements: vec![p.tet],
                nodes: Vec::new(),
                at: p.centroid,
                message: p.to_string(),
            })
            .collect();
        if out.iter().any(|p| p.kind == ProblemKind::BadNodeIndex) {
            return out;
        }
        let degenerate: Vec<bool> = {
            let mut d = vec![false; self.tets.len()];
            for p in &out {
                if p.kind == ProblemKind::Degenerate {
                    d[p.elements[0]] = true;
                }
            }
            d
        };
        // Duplicates: later copies are left out of the face analysis.
        let mut skip = degenerate.clone();
        let mut first: HashMap<[u32; 4], usize> = HashMap::with_capacity(self.tets.len());
        for (e, t) in self.tets.iter().enumerate() {
            let mut k = *t;
            k.sort_unstable();
            if let Some(&f) = first.get(&k) {
                skip[e] = true;
                let c = self.tet_centroid(e);
                out.push(MeshProblem {
                    kind: ProblemKind::DuplicateElement,
                    elements: vec![f, e],
                    nodes: k.to_vec(),
                    at: c,
                    message: format!(
                        "tets {f} and {e} are duplicates (same nodes {}, {}, {}, {}) at {}",
                        k[0],
                        k[1],
                        k[2],
                        k[3],
                        fmt_point(&c)
                    ),
                });
            } else {
                first.insert(k, e);
            }
        }
        let faces = sorted_faces(self, &skip);
        for (k, o) in face_groups(&faces).filter(|(_, o)| o.len() > 2) {
            let c = k.iter().map(|&i| self.nodes[i as usize]).sum::<Vec3>() / 3.0;
            let ids: Vec<usize> = o.iter().map(|&(t, _)| t as usize).collect();
            let list: Vec<String> = ids.iter().map(|e| e.to_string()).collect();
            out.push(MeshProblem {
                kind: ProblemKind::NonManifoldFace,
                elements: ids.clone(),
                nodes: k.to_vec(),
                at: c,
                message: format!(
                    "non-manifold face (nodes {}, {}, {}) at {}: shared by {} tetrahedra (tets {}); a face can belong to at most 2",
                    k[0], k[1], k[2], fmt_point(&c), ids.len(), list.join(", ")
                ),
            });
        }
        for (e1, e2, k) in self.folds(&skip) {
            let c = k.iter().map(|&i| self.nodes[i as usize]).sum::<Vec3>() / 3.0;
            out.push(MeshProblem {
                kind: ProblemKind::Folded,
                elements: vec![e1, e2],
                nodes: k.to_vec(),
                at: c,
                message: format!(
                    "tets {e1} and {e2} fold over each other: they lie on the same side of their shared face (nodes {}, {}, {}) at {} (centroids {} and {}); the mesh overlaps itself there",
                    k[0], k[1], k[2], fmt_point(&c),
                    fmt_point(&self.tet_centroid(e1)), fmt_point(&self.tet_centroid(e2))
                ),
            });
        }
        let mut used = vec![false; self.nodes.len()];
        for t in &self.tets {
            for &n in t {
                used[n as usize] = true;
            }
        }
        for (n, _) in used.iter().enumerate().filter(|(_, &u)| !u) {
            let p = self.nodes[n];
            out.push(MeshProblem {
                kind: ProblemKind::UnreferencedNode,
                elements: Vec::new(),
                nodes: vec![n as u32],
                at: p,
                message: format!(
                    "node {n} at {} is used by no tetrahedron (it would have no mass); remove it",
                    fmt_point(&p)
                ),
            });
        }
        out
    }

    /// Reorder left-handed tetrahedra (negative volume) that are not degenerate and fold over
    /// no neighbour, by swapping their last two nodes; returns how many were fixed. Those that
    /// fold stay as they are (which of the two is wrong is ambiguous) and [`Mesh::problems`]
    /// reports them.
    pub fn fix_orientation(&mut self) -> usize {
        let n = self.nodes.len();
        if self.tets.iter().any(|t| t.iter().any(|&i| i as usize >= n)) {
            return 0;
        }
        let eps = self.degenerate_threshold();
        let vol: Vec<Real> = (0..self.tets.len()).map(|e| self.tet_volume(e)).collect();
        let degenerate: Vec<bool> = vol.iter().map(|v| v.abs() <= eps).collect();
        if !vol.iter().zip(&degenerate).any(|(v, d)| *v < 0.0 && !d) {
            return 0;
        }
        let mut folded = vec![false; self.tets.len()];
        for (a, b, _) in self.folds(&degenerate) {
            folded[a] = true;
            folded[b] = true;
        }
        let flip: Vec<usize> = (0..self.tets.len())
            .filter(|&e| vol[e] < 0.0 && !degenerate[e] && !folded[e])
            .collect();
        self.flip_tets(&flip);
        flip.len()
    }

    /// Swap nodes 2 and 3 of the given tetrahedra (reversing their orientation), keeping face
    /// sets on the same geometric faces.
    pub fn flip_tets(&mut self, which: &[usize]) {
        if which.is_empty() {
            return;
        }
        let mut flipped = vec![false; self.tets.len()];
        for &e in which {
            self.tets[e].swap(2, 3);
            flipped[e] = true;
        }
        // The face opposite node 2 is now the face opposite node 3 and vice versa.
        for faces in self.sets.faces.values_mut() {
            for (t, l) in faces.iter_mut() {
                if flipped[*t as usize] && *l >= 2 {
                    *l = 5 - *l;
                }
            }
            faces.sort_unstable();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::box_mesh;

    fn unit_tet() -> Mesh {
        Mesh::new(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            vec![[0, 1, 2, 3]],
        )
    }

    #[test]
    fn box_mesh_has_no_problems() {
        let m = box_mesh(Vec3::zeros(), Vec3::new(1.0, 2.0, 3.0), [3, 2, 4]);
        assert!(m.problems().is_empty(), "{:?}", m.problems());
    }

    #[test]
    fn all_left_handed_mesh_is_fixed_and_face_sets_follow() {
        let mut m = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [2, 2, 2]);
        let faces = crate::mesh::boundary_faces(&m);
        m.sets.faces.insert(
            "all".into(),
            faces.iter().map(|f| (f.tet, f.local)).collect(),
        );
        let before: Vec<[u32; 3]> = faces
            .iter()
            .map(|f| {
                let mut k = f.nodes;
                k.sort_unstable();
                k
            })
            .collect();
        let all: Vec<usize> = (0..m.tets.len()).collect();
        m.flip_tets(&all);
        let p = m.problems();
        assert_eq!(p.len(), m.tets.len());
        assert!(p.iter().all(|p| p.kind == ProblemKind::Inverted));
        let fixed = m.fix_orientation();
        assert_eq!(fixed, m.tets.len());
        assert!(m.problems().is_empty());
        assert!((m.volume() - 1.0).abs() < 1e-12);
        // The face set still names the same faces (same node triples).
        let mut after: Vec<[u32; 3]> = m.sets.faces["all"]
            .iter()
            .map(|&(t, l)| {
                let f = TET_FACES[l as usize];
                let mut k = f.map(|c| m.tets[t as usize][c]);
                k.sort_unstable();
                k
            })
            .collect();
        let mut b = before.clone();
        b.sort_unstable();
        after.sort_unstable();
        assert_eq!(after, b);
    }

    #[test]
    fn duplicate_nonmanifold_unreferenced_and_fold_are_named() {
        // Two tets glued on face (1, 2, 3): fine. Add a duplicate, a third tet on the same
        // face (non-manifold), and an unused node.
        let mut m = unit_tet();
        m.nodes.push(Vec3::new(1.0, 1.0, 1.0)); // 4
        m.tets.push([1, 2, 3, 4]);
        assert!(m.problems().is_empty(), "{:?}", m.problems());
        m.tets.push([0, 1, 2, 3]);
        m.nodes.push(Vec3::new(0.6, 0.6, 0.6)); // 5: third tet on face (1,2,3)
        m.tets.push([1, 2, 3, 5]);
        m.nodes.push(Vec3::new(9.0, 9.0, 9.0)); // 6: unused
        let p = m.problems();
        let kinds: Vec<ProblemKind> = p.iter().map(|p| p.kind).collect();
        assert!(kinds.contains(&ProblemKind::DuplicateElement), "{p:?}");
        assert!(kinds.contains(&ProblemKind::NonManifoldFace), "{p:?}");
        assert!(kinds.contains(&ProblemKind::UnreferencedNode), "{p:?}");
        let dup = p
            .iter()
            .find(|p| p.kind == ProblemKind::DuplicateElement)
            .unwrap();
        assert!(dup.message.contains("tets 0 and 2 are duplicates"), "{dup}");
        let nm = p
            .iter()
            .find(|p| p.kind == ProblemKind::NonManifoldFace)
            .unwrap();
        assert!(
            nm.message.contains("tets 0, 1, 3") && nm.message.contains("nodes 1, 2, 3"),
            "{nm}"
        );
        let un = p
            .iter()
            .find(|p| p.kind == ProblemKind::UnreferencedNode)
            .unwrap();
        assert!(
            un.message
                .contains("node 6 at (9.000000, 9.000000, 9.000000)"),
            "{un}"
        );
    }

    #[test]
    fn fold_is_found_and_not_fixed() {
        // Second tet on the same side of face (1, 2, 3) as the first: a fold.
        let mut m = unit_tet();
        m.nodes.push(Vec3::new(0.1, 0.1, 0.1));
        m.tets.push([1, 2, 3, 4]); // left-handed: its vertex is on tet 0's side
        assert_eq!(m.fix_orientation(), 0);
        let p = m.problems();
        let f = p
            .iter()
            .find(|p| p.kind == ProblemKind::Folded)
            .expect("fold");
        assert!(
            f.message.contains("tets 0 and 1 fold over each other"),
            "{f}"
        );
        assert!(f.message.contains("nodes 1, 2, 3"), "{f}");
    }
}
