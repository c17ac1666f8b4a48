//! Stage 1 — elements: stress in every constant-strain tetrahedron from its deformation, and
//! the nodal internal forces.
//!
//! Reads positions `x`, half-step velocities `v`, reference data and materials; adds to the
//! nodal force accumulator `f`. Per tetrahedron (Munjiza 2004, §4.7):
//!
//! ```text
//! F   = [x1−x0, x2−x0, x3−x0] · [X1−X0, X2−X0, X3−X0]⁻¹      (uniform in the tet)
//! Ḟ   = [v1−v0, v2−v0, v3−v0] · [X1−X0, X2−X0, X3−X0]⁻¹
//! P   = P_elastic(F) + P_viscous(F, Ḟ)                     (first Piola–Kirchhoff, Pa)
//! H   = −V₀ · P · D_m⁻ᵀ ;  f_a = H e_a (a = 1..3),  f_0 = −(f_1 + f_2 + f_3)
//! ```
//!
//! which is f = −∂U/∂x for a hyperelastic law (tested by finite differences) and sums to zero
//! (no net force, no net moment from a symmetric Cauchy stress).
//!
//! Guarantees: deterministic for any thread count. Bodies whose tets own their nodes (jointed
//! layout) write forces straight into their nodes; bodies that share nodes write each tet's 4
//! forces into a slot buffer that is then gathered per node in a fixed order (no atomics).

use crate::material::{munjiza_cauchy, Formulation, Material};
use crate::math::{Mat3, Real, Vec3};
use crate::pipeline::state::{Body, Layout, Nodes, Tets};
use rayon::prelude::*;

/// Tets per parallel work item; fixed, so partial sums are the same for any thread count.
pub const CHUNK: usize = 512;

/// Nodal forces of one tetrahedron and, optionally, its energy terms.
#[derive(Clone, Copy, Debug, Default)]
pub struct TetResult {
    pub forces: [Vec3; 4],
    /// V₀·ψ(F) [J] (only when energies are requested).
    pub strain_energy: Real,
    /// Viscous power V₀·P_v:Ḟ [W] (≥ 0; always computed when the material is viscous).
    pub viscous_power: Real,
    /// det F ≤ 0: the element is inverted.
    pub inverted: bool,
}

/// Per-step sums over all elements.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementSums {
    pub strain_energy: Real,
    pub viscous_power: Real,
    pub inverted: usize,
}

/// The tet4 force kernel: F, P, and f = −V₀·P·D_m⁻ᵀ.
#[inline(always)]
pub fn internal_force_tet4(
    xs: &[Vec3; 4],
    vs: &[Vec3; 4],
    dm_inv: &Mat3,
    vol0: Real,
    mat: &Material,
    want_energy: bool,
) -> TetResult {
    let ds = Mat3::from_columns(&[xs[1] - xs[0], xs[2] - xs[0], xs[3] - xs[0]]);
    let f = ds * dm_inv;
    let mut viscous_power = 0.0;
    let mut h = if mat.formulation == Formulation::Munjiza {
        // Cauchy-stress law: V₀·P·D_m⁻ᵀ = V₀·J·σ·D_s⁻ᵀ = σ·cof(D_s)/6, since
        // cof(D_s) = det(D_s)·D_s⁻ᵀ and det(D_s) = 6·V₀·J. No inverse, no division.
        let sigma = munjiza_cauchy(&f, f.determinant(), mat.mu, mat.bulk());
        -(sigma * cofactor(&ds)) / 6.0
    } else {
        -vol0 * mat.pk1(&f) * dm_inv.transpose()
    };
    if mat.viscosity > 0.0 {
        let dv = Mat3::from_columns(&[vs[1] - vs[0], vs[2] - vs[0], vs[3] - vs[0]]);
        let f_dot = dv * dm_inv;
        let pv = mat.pk1_viscous(&f, &f_dot);
        viscous_power = vol0 * pv.dot(&f_dot);
        h -= vol0 * pv * dm_inv.transpose();
    }
    let f1 = h.column(0).into_owned();
    let f2 = h.column(1).into_owned();
    let f3 = h.column(2).into_owned();
    let mut r = TetResult {
        forces: [-(f1 + f2 + f3), f1, f2, f3],
        viscous_power,
        strain_energy: 0.0,
        inverted: false,
    };
    if want_energy {
        r.strain_energy = vol0 * mat.energy_density(&f);
        // NaN counts as inverted.
        r.inverted = f.determinant().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater);
    }
    r
}

/// Cofactor matrix cof(A) = det(A)·A⁻ᵀ (defined for singular A too).
#[inline(always)]
pub fn cofactor(a: &Mat3) -> Mat3 {
    let (c0, c1, c2) = (a.column(0), a.column(1), a.column(2));
    Mat3::from_columns(&[c1.cross(&c2), c2.cross(&c0), c0.cross(&c1)])
}

/// Run the kernel on tet `e`, reading its nodes' x and v.
#[inline(always)]
pub fn tet_result(
    tets: &Tets,
    mats: &[Material],
    x: &[Vec3],
    v: &[Vec3],
    e: usize,
    want_energy: bool,
) -> TetResult {
    let n = tets.nodes[e];
    let xs = n.map(|i| x[i as usize]);
    let vs = n.map(|i| v[i as usize]);
    internal_force_tet4(
        &xs,
        &vs,
        &tets.dm_inv[e],
        tets.vol0[e],
        &mats[tets.material[e] as usize],
        want_energy,
    )
}

/// Scratch owned by the elements stage, sized once at setup (no allocation per step).
#[derive(Clone, Debug, Default)]
pub struct ElementsWorkspace {
    /// Per-body gather data for bodies that share nodes.
    pub shared: Vec<Option<SharedGather>>,
    partials: Vec<ElementSums>,
}

/// Slot buffer and CSR node→slots map of a body that shares nodes.
#[derive(Clone, Debug, Default)]
pub struct SharedGather {
    pub slots: Vec<[Vec3; 4]>,
    /// For body-local node i, slots `slot_ids[offsets[i]..offsets[i+1]]` (slot = 4·local_tet + corner).
    pub offsets: Vec<u32>,
    pub slot_ids: Vec<u32>,
}

impl ElementsWorkspace {
    /// Prepare gather maps. A body takes the direct path when its tets own their nodes in
    /// order (node = first + 4·local tet + corner), which is how jointed bodies are built.
    pub fn new(bodies: &[Body], tets: &Tets) -> Self {
        let shared = bodies
            .iter()
            .map(|b| {
                if owns_nodes_in_order(b, tets) {
                    return None;
                }
                let nn = b.nodes.len();
                let mut count = vec![0u32; nn + 1];
                for e in b.tets.clone() {
                    for &n in &tets.nodes[e] {
                        count[n as usize - b.nodes.start + 1] += 1;
                    }
                }
                for i in 0..nn {
                    count[i + 1] += count[i];
                }
                let offsets = count.clone();
                let mut fill = count;
                let mut slot_ids = vec![0u32; offsets[nn] as usize];
                for (le, e) in b.tets.clone().enumerate() {
                    for (c, &n) in tets.nodes[e].iter().enumerate() {
                        let i = n as usize - b.nodes.start;
                        slot_ids[fill[i] as usize] = (4 * le + c) as u32;
                        fill[i] += 1;
                    }
                }
                Some(SharedGather {
                    slots: vec![[Vec3::zeros(); 4]; b.tets.len()],
                    offsets,
                    slot_ids,
                })
            })
            .collect();
        let max_chunks = bodies
            .iter()
            .map(|b| b.tets.len().div_ceil(CHUNK))
            .max()
            .unwrap_or(0);
        ElementsWorkspace {
            shared,
            partials: Vec::with_capacity(max_chunks),
        }
    }
}

fn owns_nodes_in_order(b: &Body, tets: &Tets) -> bool {
    b.layout == Layout::Jointed
        && b.nodes.len() == 4 * b.tets.len()
        && b.tets
            .clone()
            .enumerate()
            .all(|(le, e)| (0..4).all(|c| tets.nodes[e][c] as usize == b.nodes.start + 4 * le + c))
}

/// Stage 1: add the internal (elastic + viscous) forces of every tetrahedron to `nodes.f`.
/// Always returns the viscous power; with `want_energy` also the strain energy and the count
/// of inverted elements (otherwise zero).
pub fn add_internal_forces(
    nodes: &mut Nodes,
    tets: &Tets,
    bodies: &[Body],
    materials: &[Material],
    ws: &mut ElementsWorkspace,
    want_energy: bool,
) -> ElementSums {
    let mut total = ElementSums::default();
    let x = &nodes.x;
    let v = &nodes.v;
    for (b, shared) in bodies.iter().zip(ws.shared.iter_mut()) {
        let e0 = b.tets.start;
        let f_body = &mut nodes.f[b.nodes.clone()];
        match shared {
            None => {
                f_body
                    .par_chunks_mut(4 * CHUNK)
                    .enumerate()
                    .map(|(c, fs)| {
                        let mut s = ElementSums::default();
                        for (i, f4) in fs.chunks_exact_mut(4).enumerate() {
                            let r =
                                tet_result(tets, materials, x, v, e0 + c * CHUNK + i, want_energy);
                            for (f, rf) in f4.iter_mut().zip(r.forces) {
                                *f += rf;
                            }
                            accumulate(&mut s, &r);
                        }
                        s
                    })
                    .collect_into_vec(&mut ws.partials);
            }
            Some(g) => {
                g.slots
                    .par_chunks_mut(CHUNK)
                    .enumerate()
                    .map(|(c, slots)| {
                        let mut s = ElementSums::default();
                        for (i, slot) in slots.iter_mut().enumerate() {
                            let r =
                                tet_result(tets, materials, x, v, e0 + c * CHUNK + i, want_energy);
                            *slot = r.forces;
                            accumulate(&mut s, &r);
                        }
                        s
                    })
                    .collect_into_vec(&mut ws.partials);
                let (offsets, slot_ids, slots) = (&g.offsets, &g.slot_ids, &g.slots);
                f_body
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(4 * CHUNK)
                    .for_each(|(i, f)| {
                        for &s in &slot_ids[offsets[i] as usize..offsets[i + 1] as usize] {
                            *f += slots[s as usize / 4][s as usize % 4];
                        }
                    });
            }
        }
        for p in &ws.partials {
            total.strain_energy += p.strain_energy;
            total.viscous_power += p.viscous_power;
            total.inverted += p.inverted;
        }
    }
    total
}

#[inline(always)]
fn accumulate(s: &mut ElementSums, r: &TetResult) {
    s.strain_energy += r.strain_energy;
    s.viscous_power += r.viscous_power;
    s.inverted += r.inverted as usize;
}

/// Deformation gradient of tet `e` at the current positions.
pub fn deformation_gradient(tets: &Tets, x: &[Vec3], e: usize) -> Mat3 {
    let n = tets.nodes[e].map(|i| x[i as usize]);
    Mat3::from_columns(&[n[1] - n[0], n[2] - n[0], n[3] - n[0]]) * tets.dm_inv[e]
}
