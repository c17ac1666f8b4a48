//! The spatial order a body's mesh is stored in: tetrahedra layer by layer across the body's
//! longest extent (layers one element size thick), along a Morton (Z-order) curve of their
//! centroids' other two coordinates within each layer; nodes in the order the tetrahedra
//! first use them.
//!
//! **Why.** Every stage splits its work into runs of consecutive indices: stage 1 chunks of
//! tets, stage 2 blocks of joints (inserted face by face in tet order), stage 7 chunks of
//! `integration::CHUNK` nodes, and a decomposed model gives those chunks to ranks by place
//! (`parallel::Partition`). A run of consecutive indices along a Z-order curve is a compact
//! piece of the body, whatever order the mesher wrote: a structured box written row by row
//! would give runs that are thin slabs the length of the body, so a rank's share of a long
//! bar would be a layer along its whole length, touching every other rank's.
//!
//! **Why layers first.** Stage 2 runs its joints in blocks of 1/16 of them (or 1/32, 1/64)
//! coloured so that blocks of a colour share no node, and takes such large blocks only when
//! 3 colours do (`Joints::prepare`). Blocks along one 3D Z-order curve are compact blobs
//! with neighbours on every side: the 200k-tet jointed box then needed 6 colours of
//! 1024-joint blocks, and stage 2 took 30–40 % longer; 16 slabs each along its own 3D curve
//! still needed 3 (a curve crosses its slab's thickness at every step, so a block's end
//! touches the slab before). Layers one after another touch only the next and the previous,
//! as in a mesh written row by row, and a run of 512 tets is a patch of one or two layers.
//!
//! **Guarantees.** The result is the same mesh (the same tetrahedra with the same corner
//! order, so the same orientation and faces; the same nodes) with its sets carried over; the
//! order depends on the mesh alone, so every rank of a decomposed model and every run of a
//! script builds the same model. Ties (equal keys) keep the mesher's order.

use super::{Mesh, MeshSets};
use crate::math::{Real, Vec3};

/// Bits per axis of the 2D Morton key.
const BITS: u32 = 31;

/// `mesh` with its tetrahedra sorted by layer across its longest extent (layers of the
/// element size (6V/N)^⅓, the edge of a cube of six tetrahedra of the mean volume), then
/// along the Z-order curve of their centroids' other two coordinates, and its nodes numbered in the order the sorted tetrahedra first use them (nodes of no
/// tetrahedron last, in their old order); sets are renumbered to match.
pub fn spatially_ordered(mesh: &Mesh) -> Mesh {
    let (lo, hi) = mesh.bounds();
    let extent = hi - lo;
    let axis = extent.imax();
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let cross = extent[a].max(extent[b]).max(Real::MIN_POSITIVE);
    let scale = ((1u64 << BITS) - 1) as Real / cross;
    let size = (6.0 * mesh.volume().abs() / mesh.tets.len().max(1) as Real).cbrt();
    let layer = size.max(extent[axis] * 1e-9).max(Real::MIN_POSITIVE);
    let keys: Vec<(u32, u64)> = (0..mesh.tets.len())
        .map(|e| {
            let c = mesh.tet_centroid(e) - lo;
            let along = (c[axis] / layer).clamp(0.0, u32::MAX as Real) as u32;
            (along, morton_key(c[a] * scale, c[b] * scale))
        })
        .collect();
    let mut new_to_old: Vec<u32> = (0..mesh.tets.len() as u32).collect();
    new_to_old.sort_by_key(|&e| (keys[e as usize], e));
    let mut old_to_new_tet = vec![0u32; mesh.tets.len()];
    for (new, &old) in new_to_old.iter().enumerate() {
        old_to_new_tet[old as usize] = new as u32;
    }
    let mut old_to_new_node = vec![u32::MAX; mesh.nodes.len()];
    let mut nodes = Vec::with_capacity(mesh.nodes.len());
    let mut number = |n: u32, nodes: &mut Vec<Vec3>| {
        let slot = &mut old_to_new_node[n as usize];
        if *slot == u32::MAX {
            *slot = nodes.len() as u32;
            nodes.push(mesh.nodes[n as usize]);
        }
        *slot
    };
    let tets: Vec<[u32; 4]> = new_to_old
        .iter()
        .map(|&e| mesh.tets[e as usize].map(|n| number(n, &mut nodes)))
        .collect();
    for n in 0..mesh.nodes.len() as u32 {
        number(n, &mut nodes);
    }
    let sets = &mesh.sets;
    let renumber = |ids: &Vec<u32>, map: &[u32]| {
        let mut v: Vec<u32> = ids.iter().map(|&i| map[i as usize]).collect();
        v.sort_unstable();
        v
    };
    Mesh {
        nodes,
        tets,
        sets: MeshSets {
            elements: sets
                .elements
                .iter()
                .map(|(k, v)| (k.clone(), renumber(v, &old_to_new_tet)))
                .collect(),
            nodes: sets
                .nodes
                .iter()
                .map(|(k, v)| (k.clone(), renumber(v, &old_to_new_node)))
                .collect(),
            faces: sets
                .faces
                .iter()
                .map(|(k, v)| {
                    let mut f: Vec<(u32, u8)> = v
                        .iter()
                        .map(|&(t, l)| (old_to_new_tet[t as usize], l))
                        .collect();
                    f.sort_unstable();
                    (k.clone(), f)
                })
                .collect(),
        },
    }
}

/// The Morton key of a point with coordinates in [0, 2^BITS): the bits of u and v
/// interleaved (u lowest).
fn morton_key(u: Real, v: Real) -> u64 {
    let q = |w: Real| (w.max(0.0) as u64).min((1 << BITS) - 1);
    spread(q(u)) | spread(q(v)) << 1
}

/// The low 32 bits of `v` spread to every second bit.
fn spread(v: u64) -> u64 {
    let mut v = v & 0xffff_ffff;
    v = (v | v << 16) & 0x0000_ffff_0000_ffff;
    v = (v | v << 8) & 0x00ff_00ff_00ff_00ff;
    v = (v | v << 4) & 0x0f0f_0f0f_0f0f_0f0f;
    v = (v | v << 2) & 0x3333_3333_3333_3333;
    v = (v | v << 1) & 0x5555_5555_5555_5555;
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit interleaving against its definition.
    #[test]
    fn the_key_interleaves_the_bits() {
        for (u, v) in [(1u64, 0u64), (0, 1), (5, 3), (0x7fff_ffff, 0x5555_5555)] {
            let mut want = 0u64;
            for b in 0..BITS {
                want |= ((u >> b) & 1) << (2 * b);
                want |= ((v >> b) & 1) << (2 * b + 1);
            }
            assert_eq!(morton_key(u as Real, v as Real), want, "({u}, {v})");
        }
    }

    /// The ordered mesh is the same mesh: every tetrahedron, with its corners in the same
    /// order at the same places, the same nodes and the same sets (as places), and runs of
    /// consecutive tets are compact: in a long bar meshed row by row (the x rows the length
    /// of the bar), the first 512 tets of the row-by-row order span the whole bar, the
    /// ordered ones two layers of cells at its end; and the layers come in order along the
    /// bar.
    #[test]
    fn the_ordered_mesh_is_the_same_mesh_in_compact_runs() {
        let mut mesh = crate::mesh::box_mesh(Vec3::zeros(), Vec3::new(8.0, 1.0, 1.0), [64, 8, 8]);
        let end: Vec<u32> = (0..mesh.tets.len() as u32)
            .filter(|&e| mesh.tet_centroid(e as usize).x > 7.9)
            .collect();
        mesh.sets.elements.insert("end".into(), end);
        let top: Vec<u32> = (0..mesh.nodes.len() as u32)
            .filter(|&n| mesh.nodes[n as usize].z > 0.99)
            .collect();
        mesh.sets.nodes.insert("top".into(), top);
        let ordered = spatially_ordered(&mesh);
        assert_eq!(ordered.nodes.len(), mesh.nodes.len());
        assert_eq!(ordered.tets.len(), mesh.tets.len());
        // The same tets, as lists of corner places.
        let places = |m: &Mesh| {
            let mut v: Vec<[[u64; 3]; 4]> = (0..m.tets.len())
                .map(|e| {
                    m.tet_points(e)
                        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                })
                .collect();
            v.sort_unstable();
            v
        };
        assert_eq!(places(&ordered), places(&mesh));
        // The same sets, as places.
        let set_places = |m: &Mesh| {
            let mut e: Vec<u64> = m.sets.elements["end"]
                .iter()
                .map(|&t| m.tet_centroid(t as usize).x.to_bits())
                .collect();
            let mut n: Vec<[u64; 3]> = m.sets.nodes["top"]
                .iter()
                .map(|&i| {
                    let p = m.nodes[i as usize];
                    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
                })
                .collect();
            e.sort_unstable();
            n.sort_unstable();
            (e, n)
        };
        assert_eq!(set_places(&ordered), set_places(&mesh));
        // Compact runs.
        let span = |m: &Mesh| {
            let xs: Vec<Real> = (0..512).map(|e| m.tet_centroid(e).x).collect();
            xs.iter().cloned().fold(Real::NEG_INFINITY, Real::max)
                - xs.iter().cloned().fold(Real::INFINITY, Real::min)
        };
        assert!(span(&mesh) > 7.0, "row by row: {}", span(&mesh));
        assert!(span(&ordered) < 0.25, "ordered: {}", span(&ordered));
        let xs: Vec<Real> = (0..ordered.tets.len())
            .map(|e| ordered.tet_centroid(e).x)
            .collect();
        let cell = |x: Real| (x / 0.125).floor();
        assert!(
            xs.windows(2).all(|w| cell(w[0]) <= cell(w[1])),
            "layers out of order"
        );
    }
}
