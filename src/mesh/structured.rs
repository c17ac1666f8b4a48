//! Building blocks of the solid and masonry generators: graded 1-D grids, planar (or
//! parametric) triangulations with merged nodes, their extrusion into prisms split into 3
//! tetrahedra, tensor-product hexahedral grids split into 6 Kuhn tetrahedra, and named face
//! sets found geometrically on the boundary.
//!
//! **Conformity across meshes.** A prism `(a, b, c) × [k, k+1]` is split into
//! `(a₀ b₀ c₀ c₁), (a₀ b₀ b₁ c₁), (a₀ a₁ b₁ c₁)` with its vertices sorted `a < b < c`, which
//! cuts every side quad `(u, v)` (u < v) along the diagonal `u₀–v₁`. The order is a fixed
//! comparison of the vertices' 3-D positions (not their ids), so two meshes built separately
//! cut a common side face the same way whenever they place the same nodes on it: neighbouring
//! blocks of an arch or a dome then have coincident faces, triangle for triangle, which is what
//! `Joints::insert_between` needs to glue them.

use super::{boundary_faces, Mesh, TET_FACES};
use crate::math::{tet_volume, Real, Vec3};
use std::cmp::Ordering;
use std::collections::HashMap;

/// `a + (b − a)·i/n`, exact at both ends (so blocks sharing an end compute the same value).
pub(crate) fn lerp(a: Real, b: Real, i: usize, n: usize) -> Real {
    if i == 0 {
        a
    } else if i == n {
        b
    } else {
        a + (b - a) * i as Real / n as Real
    }
}

/// Cells for a length `len` at target size `h`: round(len/h), at least `min`.
pub(crate) fn cells(len: Real, h: Real, min: usize) -> usize {
    ((len / h).round() as usize).max(min)
}

/// Points `x0 = p₀ < p₁ < … < p_n = x1` whose spacing follows the size function `target(s)`
/// (s = distance from x0): n = round(∫ ds/target) ≥ 1 and the points split that integral
/// evenly. Ends are exact.
pub(crate) fn grid_1d(x0: Real, x1: Real, target: impl Fn(Real) -> Real) -> Vec<Real> {
    let len = x1 - x0;
    const SAMPLES: usize = 2000;
    let ds = len / SAMPLES as Real;
    // Cumulative ∫ 1/target by the midpoint rule.
    let mut cum = vec![0.0; SAMPLES + 1];
    for i in 0..SAMPLES {
        cum[i + 1] = cum[i] + ds / target((i as Real + 0.5) * ds);
    }
    let total = cum[SAMPLES];
    let n = (total.round() as usize).max(1);
    let mut out = Vec::with_capacity(n + 1);
    out.push(x0);
    let mut j = 0;
    for k in 1..n {
        let want = total * k as Real / n as Real;
        while cum[j + 1] < want {
            j += 1;
        }
        let f = (want - cum[j]) / (cum[j + 1] - cum[j]);
        out.push(x0 + (j as Real + f) * ds);
    }
    out.push(x1);
    out
}

/// Compare two points lexicographically by (x, y, z), coordinates within `tol` counting as
/// equal. Used to order prism vertices the same way in every mesh that holds them.
pub(crate) fn position_order(a: &Vec3, b: &Vec3, tol: Real) -> Ordering {
    for i in 0..3 {
        let d = a[i] - b[i];
        if d < -tol {
            return Ordering::Less;
        }
        if d > tol {
            return Ordering::Greater;
        }
    }
    Ordering::Equal
}

/// A triangulation of a planar or parametric 2-D domain; nodes closer than `tol` are merged,
/// so structured patches glued edge to edge (an O-grid, a periodic annulus) share nodes.
pub(crate) struct Tri2 {
    pub pts: Vec<[Real; 2]>,
    pub tris: Vec<[u32; 3]>,
    tol: Real,
    grid: HashMap<[i64; 2], Vec<u32>>,
}

impl Tri2 {
    pub fn new(tol: Real) -> Self {
        Tri2 {
            pts: Vec::new(),
            tris: Vec::new(),
            tol,
            grid: HashMap::new(),
        }
    }

    fn key(&self, p: [Real; 2]) -> [i64; 2] {
        let c = 4.0 * self.tol;
        [(p[0] / c).floor() as i64, (p[1] / c).floor() as i64]
    }

    /// The id of the node at `p` (an existing one within `tol`, or a new one).
    pub fn node(&mut self, p: [Real; 2]) -> u32 {
        let k = self.key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(ids) = self.grid.get(&[k[0] + dx, k[1] + dy]) {
                    for &i in ids {
                        let q = self.pts[i as usize];
                        if (q[0] - p[0]).abs() <= self.tol && (q[1] - p[1]).abs() <= self.tol {
                            return i;
                        }
                    }
                }
            }
        }
        let id = self.pts.len() as u32;
        self.pts.push(p);
        self.grid.entry(k).or_default().push(id);
        id
    }

    /// Add an `ni × nj` patch of quadrilaterals with corners `f(i, j)`, each cut into two
    /// triangles along its shorter diagonal as measured by `embed` (the 3-D image of a 2-D point).
    pub fn quad_grid(
        &mut self,
        ni: usize,
        nj: usize,
        f: impl Fn(usize, usize) -> [Real; 2],
        embed: impl Fn([Real; 2]) -> Vec3,
    ) {
        let mut id = vec![0u32; (ni + 1) * (nj + 1)];
        for j in 0..=nj {
            for i in 0..=ni {
                id[i + (ni + 1) * j] = self.node(f(i, j));
            }
        }
        for j in 0..nj {
            for i in 0..ni {
                let [a, b, c, d] = [
                    id[i + (ni + 1) * j],
                    id[i + 1 + (ni + 1) * j],
                    id[i + 1 + (ni + 1) * (j + 1)],
                    id[i + (ni + 1) * (j + 1)],
                ];
                let e = |n: u32| embed(self.pts[n as usize]);
                if (e(a) - e(c)).norm() <= (e(b) - e(d)).norm() {
                    self.tris.push([a, b, c]);
                    self.tris.push([a, c, d]);
                } else {
                    self.tris.push([a, b, d]);
                    self.tris.push([b, c, d]);
                }
            }
        }
    }

    /// Extrude through `layers` layers: node `(p, k)` (k = 0..=layers) is placed at
    /// `map(p, k)`. Each prism is split into 3 positively oriented tetrahedra, cut as described
    /// in the module docs (vertex order by position, tolerance `tol`).
    pub fn extrude(&self, layers: usize, map: impl Fn([Real; 2], usize) -> Vec3) -> Mesh {
        let n2 = self.pts.len();
        let mut nodes = Vec::with_capacity(n2 * (layers + 1));
        for k in 0..=layers {
            for p in &self.pts {
                nodes.push(map(*p, k));
            }
        }
        let tol = size_tolerance(&nodes);
        let mut tets = Vec::with_capacity(3 * self.tris.len() * layers);
        for t in &self.tris {
            let mut v = *t;
            v.sort_by(|&a, &b| position_order(&nodes[a as usize], &nodes[b as usize], tol));
            for k in 0..layers {
                let lo = |n: u32| n + (k * n2) as u32;
                let hi = |n: u32| n + ((k + 1) * n2) as u32;
                let [a, b, c] = v;
                for tet in [
                    [lo(a), lo(b), lo(c), hi(c)],
                    [lo(a), lo(b), hi(b), hi(c)],
                    [lo(a), hi(a), hi(b), hi(c)],
                ] {
                    tets.push(oriented(tet, &nodes));
                }
            }
        }
        Mesh::new(nodes, tets)
    }
}

/// 1e-9 of the bounding-box diagonal (at least 1e-15).
pub(crate) fn size_tolerance(nodes: &[Vec3]) -> Real {
    let mut lo = Vec3::repeat(Real::INFINITY);
    let mut hi = Vec3::repeat(Real::NEG_INFINITY);
    for p in nodes {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (1e-9 * (hi - lo).norm()).max(1e-15)
}

/// The tet with nodes swapped if needed so that its signed volume is positive.
pub(crate) fn oriented(mut t: [u32; 4], nodes: &[Vec3]) -> [u32; 4] {
    let p = |n: u32| nodes[n as usize];
    if tet_volume(&p(t[0]), &p(t[1]), &p(t[2]), &p(t[3])) < 0.0 {
        t.swap(1, 2);
    }
    t
}

/// The 6 Kuhn tetrahedra of a cell with corners `i + 2j + 4k` (see `generators::box_mesh`).
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// A tensor-product grid of `(nx, ny, nz)` cells whose node `(i, j, k)` sits at `map(i, j, k)`,
/// keeping the cells where `keep(i, j, k)` holds, each split into 6 Kuhn tetrahedra along the
/// diagonal chosen by `mirror(i, j, k)` (per axis: false = from the low to the high corner,
/// true = reflected). Mirroring per octant of the index box keeps the mesh conforming (the two
/// cells on either side of a face agree on its diagonal as long as the mirror flags of the two
/// other axes agree, which holds when the flag of each axis depends only on that axis' index).
/// Unused nodes are dropped; returns the mesh and, for each kept node, its (i, j, k).
pub(crate) fn hex_grid(
    n: [usize; 3],
    map: impl Fn(usize, usize, usize) -> Vec3,
    keep: impl Fn(usize, usize, usize) -> bool,
    mirror: impl Fn(usize, usize, usize) -> [bool; 3],
) -> (Mesh, Vec<[usize; 3]>) {
    let [nx, ny, nz] = n;
    let full = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let mut used = vec![u32::MAX; (nx + 1) * (ny + 1) * (nz + 1)];
    let mut nodes = Vec::new();
    let mut ijk = Vec::new();
    let mut tets = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if !keep(i, j, k) {
                    continue;
                }
                let m = mirror(i, j, k);
                let mut corner = [0u32; 8];
                for (c, slot) in corner.iter_mut().enumerate() {
                    let b = [c & 1, (c >> 1) & 1, (c >> 2) & 1];
                    let d = [0, 1, 2].map(|a| if m[a] { 1 - b[a] } else { b[a] });
                    let (ci, cj, ck) = (i + d[0], j + d[1], k + d[2]);
                    let g = full(ci, cj, ck);
                    if used[g] == u32::MAX {
                        used[g] = nodes.len() as u32;
                        nodes.push(map(ci, cj, ck));
                        ijk.push([ci, cj, ck]);
                    }
                    *slot = used[g];
                }
                for t in KUHN {
                    tets.push(oriented(t.map(|c| corner[c]), &nodes));
                }
            }
        }
    }
    (Mesh::new(nodes, tets), ijk)
}

/// Add the boundary faces whose three vertices all satisfy `on` as face set `name`, and
/// their nodes as node set `name`. Returns the number of faces.
pub(crate) fn add_face_set(mesh: &mut Mesh, name: &str, on: impl Fn(&Vec3) -> bool) -> usize {
    let set = face_set(mesh, |f| f.iter().all(|&n| on(&mesh.nodes[n as usize])));
    insert_face_set(mesh, name, set)
}

/// Add the boundary faces for which `on` holds (given the face's three node ids) as face set
/// `name`, and their nodes as node set `name`: for generators that know each node's grid
/// indices, so their sets need no geometric tolerance. Returns the number of faces.
pub(crate) fn add_face_set_by_ids(
    mesh: &mut Mesh,
    name: &str,
    on: impl Fn(&[u32; 3]) -> bool,
) -> usize {
    let set = face_set(mesh, on);
    insert_face_set(mesh, name, set)
}

/// The boundary faces for which `on` holds, and their nodes (sorted).
fn face_set(mesh: &Mesh, on: impl Fn(&[u32; 3]) -> bool) -> (Vec<(u32, u8)>, Vec<u32>) {
    let faces: Vec<(u32, u8)> = boundary_faces(mesh)
        .into_iter()
        .filter(|f| on(&f.nodes))
        .map(|f| (f.tet, f.local))
        .collect();
    let mut nodes: Vec<u32> = faces
        .iter()
        .flat_map(|&(t, l)| TET_FACES[l as usize].map(|c| mesh.tets[t as usize][c]))
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    (faces, nodes)
}

fn insert_face_set(mesh: &mut Mesh, name: &str, set: (Vec<(u32, u8)>, Vec<u32>)) -> usize {
    let (faces, nodes) = set;
    let count = faces.len();
    mesh.sets.faces.insert(name.to_string(), faces);
    mesh.sets.nodes.insert(name.to_string(), nodes);
    count
}

/// Add the nodes satisfying `on` as node set `name`. Returns how many.
pub(crate) fn add_node_set(mesh: &mut Mesh, name: &str, on: impl Fn(&Vec3) -> bool) -> usize {
    let nodes: Vec<u32> = (0..mesh.nodes.len() as u32)
        .filter(|&n| on(&mesh.nodes[n as usize]))
        .collect();
    let count = nodes.len();
    mesh.sets.nodes.insert(name.to_string(), nodes);
    count
}

/// Union of existing node sets under a new name.
pub(crate) fn union_node_sets(mesh: &mut Mesh, name: &str, parts: &[&str]) {
    let mut all: Vec<u32> = parts
        .iter()
        .filter_map(|p| mesh.sets.nodes.get(*p))
        .flatten()
        .copied()
        .collect();
    all.sort_unstable();
    all.dedup();
    mesh.sets.nodes.insert(name.to_string(), all);
}

/// Put every tet in the element set `all` (each generated mesh has it).
pub(crate) fn add_all_elements(mesh: &mut Mesh) {
    let all = (0..mesh.tets.len() as u32).collect();
    mesh.sets.elements.insert("all".to_string(), all);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_1d_follows_the_size_function() {
        let g = grid_1d(0.0, 1.0, |_| 0.1);
        assert_eq!(g.len(), 11);
        assert!((g[3] - 0.3).abs() < 1e-9);
        assert_eq!(*g.last().unwrap(), 1.0);
        // Graded: fine at 0, coarse at 1.
        let g = grid_1d(0.0, 1.0, |s| 0.02 + 0.3 * s);
        assert!(g[1] - g[0] < 0.5 * (g[g.len() - 1] - g[g.len() - 2]));
    }

    #[test]
    fn extruded_square_is_conforming_and_positive() {
        let mut t = Tri2::new(1e-12);
        t.quad_grid(
            3,
            2,
            |i, j| [i as Real / 3.0, j as Real / 2.0],
            |p| Vec3::new(p[0], p[1], 0.0),
        );
        let m = t.extrude(4, |p, k| Vec3::new(p[0], p[1], k as Real * 0.25));
        assert!(m.check().is_empty());
        assert!((m.volume() - 1.0).abs() < 1e-12);
        // Boundary triangles: 2 per quad of the box surface (3·2 + 3·4 + 2·4)·2 = 52.
        assert_eq!(
            boundary_faces(&m).len(),
            2 * (2 * 3 * 2 + 2 * 3 * 4 + 2 * 2 * 4)
        );
    }

    #[test]
    fn mirrored_kuhn_grid_is_conforming() {
        let (m, _) = hex_grid(
            [4, 4, 4],
            |i, j, k| Vec3::new(i as Real, j as Real, k as Real),
            |_, _, _| true,
            |i, j, k| [i < 2, j < 2, k < 2],
        );
        assert!(m.check().is_empty());
        assert!((m.volume() - 64.0).abs() < 1e-9);
        assert_eq!(boundary_faces(&m).len(), 6 * 16 * 2);
    }
}
