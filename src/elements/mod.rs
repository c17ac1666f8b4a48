//! Stage 1 — elements: stress in every element from its deformation, and the nodal internal
//! forces. Reads positions `x`, half-step velocities `v`, reference data and materials; adds
//! to the nodal force accumulator `f`.
//!
//! **The element seam.** Each element family is one module with everything fdem needs of it:
//! reference data, force kernel, lumped mass and critical time step — today [`tet4`]
//! (4-node constant-strain tetrahedron). The stage-level functions here
//! ([`add_internal_forces`], [`lumped_masses`], [`critical_time_step`]) dispatch to the
//! families; a new family (2-node bars, 3-node triangles) is its own module plus a line in
//! each of them and its arrays in [`crate::state`] (docs/architecture.md lists the files).
//!
//! The tet4 force is f = −∂U/∂x for a hyperelastic law (tested by finite differences) and sums
//! to zero (no net force, no net moment from a symmetric Cauchy stress).
//!
//! Guarantees: deterministic for any thread count. Bodies whose tets own their nodes (jointed
//! layout) write forces straight into their nodes; bodies that share nodes write each tet's 4
//! forces into a slot buffer that is then gathered per node in a fixed order (no atomics).

pub mod bar2;
pub mod tet4;

pub use tet4::{cofactor, deformation_gradient, internal_force_tet4, tet_result, TetResult};

use crate::material::Material;
use crate::math::{Real, SyncPtr, Vec3};
use crate::state::{Body, Layout, Nodes, Tets};
use rayon::prelude::*;
use tet4::accumulate;

/// Tets per parallel work item; fixed, so partial sums are the same for any thread count.
pub const CHUNK: usize = 512;

/// Per-step sums over all elements.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementSums {
    pub strain_energy: Real,
    pub viscous_power: Real,
    pub inverted: usize,
}

/// Scratch owned by the elements stage, sized once at setup (no allocation per step).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct ElementsWorkspace {
    /// Per-body gather data for bodies that share nodes.
    pub shared: Vec<Option<SharedGather>>,
    /// The sums of the stage's work units (their total is an exact sum, [`ElementsWorkspace::total`]): one per run of small bodies, then
    /// one per chunk of each large body (see [`ElementsWorkspace::units`]).
    pub unit_partials: Vec<ElementSums>,
    /// Which units this process computes (empty: all). A rank of a decomposed model computes
    /// only the units with an element at one of its nodes (crate::parallel).
    pub compute: Vec<bool>,
    /// Bodies with at least `BIG_BODY` tets, each split into parallel chunks.
    big: Vec<usize>,
    /// Runs of consecutive smaller bodies (≈ `GROUP_TETS` tets each), one thread per run.
    groups: Vec<std::ops::Range<usize>>,
}

/// A body this large is split into parallel chunks of its own.
const BIG_BODY: usize = 8 * CHUNK;
/// Smaller bodies are grouped into runs of about this many tets, the runs in parallel
/// (a masonry wall or a fragmented stack has thousands of bodies of ~100 tets).
const GROUP_TETS: usize = 2 * CHUNK;

/// Slot buffer and CSR node→slots map of a body that shares nodes.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
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
                if owns_nodes_in_order(b, tets) || b.layout == Layout::Rigid {
                    return None;
                }
                let (first, nn) = (b.nodes.start, b.nodes.len());
                let corners = b.tets.clone().enumerate().flat_map(|(le, e)| {
                    (tets.nodes[e].iter().enumerate())
                        .map(move |(c, &n)| ((n as usize - first) as u32, (4 * le + c) as u32))
                });
                let lists = crate::math::Lists::from_pairs(nn, corners);
                let (offsets, slot_ids) = (lists.start, lists.items);
                Some(SharedGather {
                    slots: vec![[Vec3::zeros(); 4]; b.tets.len()],
                    offsets,
                    slot_ids,
                })
            })
            .collect();
        let (mut big, mut groups) = (Vec::new(), Vec::new());
        let mut run = 0..0;
        let mut run_tets = 0;
        for (i, b) in bodies.iter().enumerate() {
            // Node ranges follow body order (groups hand out disjoint node slices).
            debug_assert!(i == 0 || bodies[i - 1].nodes.end <= b.nodes.start);
            if b.layout == Layout::Rigid {
                continue; // no element forces: the body moves rigidly (integration::rigid)
            }
            if b.tets.len() >= BIG_BODY {
                big.push(i);
                continue;
            }
            if run.is_empty() {
                run = i..i;
            }
            run.end = i + 1;
            run_tets += b.tets.len();
            if run_tets >= GROUP_TETS {
                groups.push(std::mem::replace(&mut run, 0..0));
                run_tets = 0;
            }
        }
        if !run.is_empty() {
            groups.push(run);
        }
        let n_units = groups.len()
            + big
                .iter()
                .map(|&b| bodies[b].tets.len().div_ceil(CHUNK))
                .sum::<usize>();
        ElementsWorkspace {
            shared,
            unit_partials: vec![ElementSums::default(); n_units],
            compute: Vec::new(),
            big,
            groups,
        }
    }

    /// The tets of each work unit, in unit order (the order of `unit_partials`): the runs of
    /// small bodies (tets of rigid bodies among them included, though not computed), then the
    /// chunks of `CHUNK` tets of each large body.
    pub fn units(&self, bodies: &[Body]) -> Vec<std::ops::Range<usize>> {
        let mut units: Vec<_> = self
            .groups
            .iter()
            .map(|run| bodies[run.start].tets.start..bodies[run.end - 1].tets.end)
            .collect();
        for &bi in &self.big {
            let t = bodies[bi].tets.clone();
            units.extend(
                (t.start..t.end)
                    .step_by(CHUNK)
                    .map(|s| s..(s + CHUNK).min(t.end)),
            );
        }
        units
    }

    /// The stage's sums: the exact sums of the units' partial sums, rounded once (the same
    /// bits for any thread or rank count, [`crate::math::ExactSum`]).
    pub fn total(&self) -> ElementSums {
        crate::math::exact_total(&self.unit_partials)
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

/// Lumped masses of every element at its nodes [kg] (`nodes.m` is set, not added to).
pub fn lumped_masses(nodes: &mut Nodes, tets: &Tets, materials: &[Material]) {
    tet4::lumped_masses(nodes, tets, materials);
}

/// This stage's share of the time-step limit: the smallest critical step of the central
/// difference over all elements [s], and the element that sets it. Tets of rigid bodies do
/// not deform and do not count; when every tet is rigid the answer is (∞, 0).
pub fn critical_time_step(tets: &Tets, materials: &[Material]) -> (Real, usize) {
    match tet4::critical_time_step(tets, materials) {
        (dt, usize::MAX) => (dt, 0),
        found => found,
    }
}

/// Stage 1: add the internal (elastic + viscous) forces of every tetrahedron to `nodes.f`.
/// Always returns the viscous power and the count of inverted elements (det F ≤ 0 or NaN);
/// with `want_energy` also the strain energy (otherwise zero).
pub fn add_internal_forces(
    nodes: &mut Nodes,
    tets: &Tets,
    bodies: &[Body],
    materials: &[Material],
    ws: &mut ElementsWorkspace,
    want_energy: bool,
) -> ElementSums {
    let k = Kernel {
        tets,
        materials,
        x: &nodes.x,
        v: &nodes.v,
        want_energy,
    };
    let n_runs = ws.groups.len();
    let n_units = n_runs
        + ws.big
            .iter()
            .map(|&b| bodies[b].tets.len().div_ceil(CHUNK))
            .sum::<usize>();
    // (Sized at setup; only a caller that regrouped the bodies changes it.)
    ws.unit_partials.resize(n_units, ElementSums::default());
    small_body_runs(&k, bodies, &mut nodes.f, ws);
    let ElementsWorkspace {
        shared,
        unit_partials,
        compute,
        big,
        ..
    } = ws;
    let mut first = n_runs;
    for &bi in big.iter() {
        let b = &bodies[bi];
        let n = b.tets.len().div_ceil(CHUNK);
        let unit = first..first + n;
        large_body(
            &k,
            b,
            &mut nodes.f[b.nodes.clone()],
            &mut shared[bi],
            &mut unit_partials[unit.clone()],
            compute.get(unit).unwrap_or(&[]),
        );
        first += n;
    }
    ws.total()
}

/// What every element of one stage 1 pass reads.
struct Kernel<'a> {
    tets: &'a Tets,
    materials: &'a [Material],
    x: &'a [Vec3],
    v: &'a [Vec3],
    want_energy: bool,
}

impl Kernel<'_> {
    #[inline(always)]
    fn tet(&self, e: usize) -> TetResult {
        tet_result(
            self.tets,
            self.materials,
            self.x,
            self.v,
            e,
            self.want_energy,
        )
    }
}

/// Runs of small bodies, one thread per run; their sums in `ws.unit_partials` (one per run). Per
/// node the arithmetic is the same as [`large_body`]'s (a body's forces, then its gather in
/// slot order), so results do not depend on how bodies are scheduled.
fn small_body_runs(k: &Kernel, bodies: &[Body], f: &mut [Vec3], ws: &mut ElementsWorkspace) {
    let f_ptr = SyncPtr(f.as_mut_ptr());
    let g_ptr = SyncPtr(ws.shared.as_mut_ptr());
    let compute = &ws.compute;
    let n_runs = ws.groups.len();
    ws.groups
        .par_iter()
        .zip(ws.unit_partials[..n_runs].par_iter_mut())
        .enumerate()
        .for_each(|(u, (run, partial))| {
            let mut s = ElementSums::default();
            if !compute.get(u).unwrap_or(&true) {
                *partial = s;
                return;
            }
            for bi in run.clone() {
                let b = &bodies[bi];
                if b.layout == Layout::Rigid {
                    continue;
                }
                // SAFETY: runs are disjoint ranges of bodies, whose node ranges are disjoint
                // (checked when the runs are built), and each body's gather data belongs to
                // it alone; `f` and `ws.shared` outlive this parallel section.
                let (f_body, shared) = unsafe {
                    (
                        std::slice::from_raw_parts_mut(
                            f_ptr.get().add(b.nodes.start),
                            b.nodes.len(),
                        ),
                        &mut *g_ptr.get().add(bi),
                    )
                };
                let e0 = b.tets.start;
                match shared {
                    None => {
                        for (i, f4) in f_body.chunks_exact_mut(4).enumerate() {
                            let r = k.tet(e0 + i);
                            for (f, rf) in f4.iter_mut().zip(r.forces) {
                                *f += rf;
                            }
                            accumulate(&mut s, &r);
                        }
                    }
                    Some(g) => {
                        for (i, slot) in g.slots.iter_mut().enumerate() {
                            let r = k.tet(e0 + i);
                            *slot = r.forces;
                            accumulate(&mut s, &r);
                        }
                        for (i, f) in f_body.iter_mut().enumerate() {
                            for &k in &g.slot_ids[g.offsets[i] as usize..g.offsets[i + 1] as usize]
                            {
                                *f += g.slots[k as usize / 4][k as usize % 4];
                            }
                        }
                    }
                }
            }
            *partial = s;
        });
}

/// One large body in parallel chunks of `CHUNK` tets (`f_body` its nodes' forces); the
/// chunks' sums in `partials`, only the chunks marked in `compute` (empty: all) computed. A
/// body that owns its nodes adds each tet's forces directly; one that shares nodes writes
/// slots, then gathers them per node in slot order (a node's slots are all in computed
/// chunks when the node is this rank's; the other nodes' forces are not used).
fn large_body(
    k: &Kernel,
    b: &Body,
    f_body: &mut [Vec3],
    shared: &mut Option<SharedGather>,
    partials: &mut [ElementSums],
    compute: &[bool],
) {
    let e0 = b.tets.start;
    let skip = |c: usize| !compute.get(c).unwrap_or(&true);
    match shared {
        None => {
            f_body
                .par_chunks_mut(4 * CHUNK)
                .zip(partials.par_iter_mut())
                .enumerate()
                .for_each(|(c, (fs, partial))| {
                    let mut s = ElementSums::default();
                    if skip(c) {
                        *partial = s;
                        return;
                    }
                    for (i, f4) in fs.chunks_exact_mut(4).enumerate() {
                        let r = k.tet(e0 + c * CHUNK + i);
                        for (f, rf) in f4.iter_mut().zip(r.forces) {
                            *f += rf;
                        }
                        accumulate(&mut s, &r);
                    }
                    *partial = s;
                });
        }
        Some(g) => {
            g.slots
                .par_chunks_mut(CHUNK)
                .zip(partials.par_iter_mut())
                .enumerate()
                .for_each(|(c, (slots, partial))| {
                    let mut s = ElementSums::default();
                    if skip(c) {
                        *partial = s;
                        return;
                    }
                    for (i, slot) in slots.iter_mut().enumerate() {
                        let r = k.tet(e0 + c * CHUNK + i);
                        *slot = r.forces;
                        accumulate(&mut s, &r);
                    }
                    *partial = s;
                });
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Formulation;
    use crate::mesh::box_mesh;
    use crate::pipeline::Simulation;

    /// Runs of small bodies (one thread per run) give the same nodal forces, bit for bit,
    /// as every body in its own parallel chunks: per node the arithmetic is the same. Forty
    /// deformed bodies, continuous and jointed, and one large one.
    #[test]
    fn body_runs_equal_per_body_chunks() {
        let mut sim = Simulation::new();
        let m = sim
            .add_material(Material::new(Formulation::NeoHookean, 1000.0, 1e7, 0.3, 1e3).unwrap());
        for k in 0..40 {
            let b = box_mesh(
                Vec3::new(k as Real, 0.0, 0.0),
                Vec3::new(k as Real + 0.5, 0.5, 0.5),
                [2, 2, 2 + k % 3],
            );
            let layout = if k % 2 == 0 {
                Layout::Continuous
            } else {
                Layout::Jointed
            };
            sim.add_body(&format!("b{k}"), &b, m, layout).unwrap();
        }
        let big = box_mesh(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(4.0, 3.0, 1.0),
            [16, 8, 8],
        );
        sim.add_body("big", &big, m, Layout::Continuous).unwrap();
        // A smooth deformation and velocity, so every tet has forces.
        for (i, x) in sim.nodes.x.iter_mut().enumerate() {
            *x += Vec3::new(0.01 * x.y * x.z, -0.02 * x.x, 0.003 * (i % 7) as Real);
        }
        for (i, v) in sim.nodes.v.iter_mut().enumerate() {
            *v = Vec3::new(0.1, -0.2 * (i % 3) as Real, 0.05);
        }
        let run = |ws: &mut ElementsWorkspace, sim: &mut Simulation| {
            for f in sim.nodes.f.iter_mut() {
                *f = Vec3::zeros();
            }
            add_internal_forces(
                &mut sim.nodes,
                &sim.tets,
                &sim.bodies,
                &sim.materials,
                ws,
                true,
            );
            sim.nodes.f.clone()
        };
        let mut grouped = ElementsWorkspace::new(&sim.bodies, &sim.tets);
        assert!(grouped.groups.len() >= 2 && grouped.big.len() == 1);
        let mut chunked = ElementsWorkspace::new(&sim.bodies, &sim.tets);
        chunked.big = (0..sim.bodies.len()).collect();
        chunked.groups.clear();
        let a = run(&mut grouped, &mut sim);
        let b = run(&mut chunked, &mut sim);
        assert!(a.iter().any(|f| f.norm() > 0.0));
        assert_eq!(a, b);
    }
}
