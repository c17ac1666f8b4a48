//! Stage 5: contact interaction — potential contact forces with Coulomb friction between the
//! candidate pairs found by stage 4.
//!
//! **Normal force**: [`potential::tet_tet`], the exact gradient of E = p∫(φ_c + φ_t) dV.
//!
//! **Friction** (per pair, with history): the contact normal n is the direction of the
//! normal force on the contactor, the contact point x_p the centroid of the clipped facets.
//! Each step the relative displacement of the two elements at x_p over the last step,
//! Δu = Σ N_i^c(x_p)·Δx_i^c − Σ N_j^t(x_p)·Δx_j^t, is projected on the tangent plane and the
//! tangential force is updated incrementally, f_t ← P_n(f_t) − k_t·Δu_t (P_n re-projects the
//! stored force on the current tangent plane, keeping its magnitude), then returned to the
//! Coulomb cone |f_t| ≤ μ|F_n| (sliding). The work μ|F_n|·(|f_trial| − μ|F_n|)/k_t of each
//! slip is dissipated and ½|f_t|²/k_t is stored. The spring stiffness follows the normal one
//! of one face node for a thin overlap, k_t = (4/3)·p_t·A·(1/h_c + 1/h_t), with A the contact
//! area and h the smallest height of each element (the spring acts at one point, so one node
//! may carry all of it): static friction holds with an elastic offset |f_t|/k_t,
//! kinetic friction slides at μ|F_n|. Storing the force rather than the spring extension
//! keeps the force continuous when A (hence k_t) changes.
//!
//! **Friction laws**: μ is the rule's constant `friction`, or, when the rule has a
//! `friction_law`, the value of a Rhai function compiled to native code
//! ([`crate::compiled`], signature [`FRICTION_LAW`]) of the pair's slip rate, slip
//! path (history [`PairState::slip`]), pressure, normal force, area, time and the constant,
//! evaluated once per touching pair and step just before the return to the cone. A result
//! that is not finite and ≥ 0 stops the run ([`ContactSums::law_failure`]).
//!
//! **Normal damping** (optional, ratio ζ): a dashpot on the normal relative velocity at x_p,
//! f_d = −2ζ·√(k·m*)·(v_rel·n)·n with k = (4/3)·p·A·(1/h_c + 1/h_t) and m* the reduced mass
//! of one node of each tetrahedron (ζ is the damping ratio of one face node on its contact
//! spring), never pulling harder than the contact pushes. Its work is
//! dissipated (booked with friction).
//!
//! **Determinism**: pairs are evaluated in parallel and their forces added to the nodes in
//! pair order on one thread.

pub mod potential;

use crate::compiled::{CompiledLaw, Frame};
use crate::contact_detection::{Aabb, Detector};
use crate::math::{Real, Vec3};
use crate::state::Nodes;
use potential::{overlapping_tet_tet, separating_axis, TetGeom, OVERLAPPED};
use rayon::prelude::*;
use std::sync::Arc;

crate::compiled::law_signature! {
    /// Inputs of a contact friction law, per touching pair and step: tangential relative
    /// speed at the contact point [m/s], slip path accumulated while touching [m], mean
    /// normal pressure |F_n|/A [Pa], normal force |F_n| [N], contact area A [m²], time [s],
    /// and the rule's static `friction` value [-].
    pub struct FrictionInputs { slip_rate, slip, pressure, normal_force, area, time, mu }
    /// A contact friction law: `fn law(c, p)` returning `#{ friction: μ }` (or μ alone).
    pub const FRICTION_LAW = "friction law" -> ["friction"];
}

/// [`ContactProps::friction_law`] of a rule without a friction law (μ is `friction`).
pub const NO_FRICTION_LAW: u32 = u32::MAX;

/// Contact parameters of one pair of materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactProps {
    /// Normal penalty p [Pa] (energy per overlap volume at φ = 1).
    pub penalty: Real,
    /// Tangential penalty p_t [Pa] (spring k_t = 4·p_t·A·(1/h_c + 1/h_t)).
    pub tangential_penalty: Real,
    /// Coulomb friction coefficient μ [-] (with a friction law: its input `mu`).
    pub friction: Real,
    /// Normal damping ratio ζ [-].
    pub damping: Real,
    /// Index into [`Contact::friction_laws`], or [`NO_FRICTION_LAW`].
    pub friction_law: u32,
}

impl ContactProps {
    /// Friction acts (a positive constant μ, or a law that may make it so).
    #[inline]
    pub fn has_friction(&self) -> bool {
        self.friction > 0.0 || self.friction_law != NO_FRICTION_LAW
    }
}

/// A contact rule from the script: defaults apply to every pair of materials, rules with
/// `materials` to one pair (later rules override earlier ones).
#[derive(Clone, Debug, Default)]
pub struct ContactRule {
    pub materials: Option<(u32, u32)>,
    /// None: 10 × the larger Young's modulus of the pair.
    pub penalty: Option<Real>,
    /// None: equal to the normal penalty.
    pub tangential_penalty: Option<Real>,
    pub friction: Real,
    pub damping: Real,
    /// μ as a compiled function of the pair's kinematics (signature [`FRICTION_LAW`]); None:
    /// the constant `friction`.
    pub friction_law: Option<Arc<CompiledLaw>>,
}

/// A pair that came into contact (for `on_new_contact_pair`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    pub time: Real,
    /// Simulation tet ids (contactor, target).
    pub tets: [u32; 2],
    pub point: Vec3,
}

/// History of one candidate pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairState {
    /// Tangential friction force on the contactor [N].
    pub spring: Vec3,
    pub touching: bool,
    /// The pair exerts forces only once armed. Pairs of elements that were neighbours in the
    /// reference configuration (they may overlap from the deformation they underwent while
    /// connected) are armed when they first do not overlap, so contact never releases energy
    /// stored in an overlap it did not make.
    pub armed: bool,
    /// The broken joint between the two elements (u32::MAX if none): it keeps acting until
    /// the pair is armed, then hands its faces over to contact.
    pub joint: u32,
    /// Friction + damping force on the contactor in the last step [N], and the energy then
    /// stored in the friction spring [J] (for the dissipation account).
    pub f_prev: Vec3,
    pub e_prev: Real,
    /// The axis that last separated the pair (see [`potential::separating_axis`]), tried
    /// first.
    pub witness: u8,
    /// Slip path while touching [m]: Σ|Δu_t| of the relative tangential displacement at the
    /// contact point, summed every step the pair's friction acts; back to 0 when the pair
    /// releases. The `slip` input of friction laws.
    pub slip: Real,
}

impl PairState {
    /// The elements do not overlap: release the friction spring and arm the pair (a broken
    /// joint between the two is handed over to contact).
    #[inline]
    fn apart(&mut self, sums: &mut ContactSums, handover: &mut Vec<u32>) {
        self.release(sums);
        if !self.armed {
            self.armed = true;
            if self.joint != u32::MAX {
                handover.push(self.joint);
            }
        }
    }

    /// The pair stopped touching: its friction spring is released (booked as dissipated).
    #[inline]
    fn release(&mut self, sums: &mut ContactSums) {
        // Released already (every field below is zero): no store, so the many candidate
        // pairs that stay apart are only read each step.
        if !self.touching {
            return;
        }
        sums.dissipated += self.e_prev;
        self.e_prev = 0.0;
        self.f_prev = Vec3::zeros();
        self.spring = Vec3::zeros();
        self.touching = false;
        self.slip = 0.0;
    }
}

impl Default for PairState {
    fn default() -> Self {
        PairState {
            spring: Vec3::zeros(),
            touching: false,
            armed: true,
            joint: u32::MAX,
            f_prev: Vec3::zeros(),
            e_prev: 0.0,
            witness: 0,
            slip: 0.0,
        }
    }
}

/// Per-step totals of stage 5.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactSums {
    /// Recoverable contact energy: penalty energy + friction springs [J].
    pub energy: Real,
    /// Dissipated by friction and normal damping this step [J].
    pub dissipated: Real,
    /// Pairs that overlap.
    pub active: usize,
    /// Σ |normal force| over active pairs [N].
    pub normal_force: Real,
    /// Σ |friction force| [N].
    pub friction_force: Real,
    /// Largest penetration depth over touching pairs [m] (see `PairForces::depth`).
    pub max_overlap: Real,
    /// Largest d/h (h the smaller height of the pair's two elements) [-].
    pub max_overlap_ratio: Real,
    /// Largest mean pressure |F_n|/A over touching pairs [Pa].
    pub max_pressure: Real,
    /// The first pair (in pair order) whose friction law gave a μ that is not finite and
    /// ≥ 0 in this step: the run must stop (the pair got μ = 0).
    pub law_failure: Option<FrictionLawFailure>,
}

/// A friction law that returned an invalid μ, with what it was given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionLawFailure {
    /// Index into [`Contact::friction_laws`].
    pub law: u32,
    /// Simulation tet ids (contactor, target).
    pub tets: [u32; 2],
    /// Contact point [m].
    pub point: Vec3,
    /// What the law was given.
    pub inputs: FrictionInputs,
    /// What the law returned.
    pub friction: Real,
}

/// Output of one touching pair.
#[derive(Clone, Copy, Debug)]
struct PairOut {
    pair: u32,
    /// Simulation ids of the contactor and the target.
    tets: [u32; 2],
    /// Their nodes (contactor's 4, then the target's) and the forces on them [N].
    nodes: [u32; 8],
    f: [Vec3; 8],
    point: Vec3,
    /// Mean normal contact pressure |F_n|/A [Pa].
    pressure: Real,
}

/// Contact state of a simulation (stages 4 and 5).
#[derive(Clone, Debug, Default)]
pub struct Contact {
    /// Rules as given by the script.
    pub rules: Vec<ContactRule>,
    /// Resolved parameters, `props[a * n_materials + b]`.
    pub props: Vec<ContactProps>,
    /// The distinct friction laws of the rules (filled by `resolve`).
    pub friction_laws: Vec<Arc<CompiledLaw>>,
    pub n_materials: usize,
    pub detector: Detector,
    /// Skin given by the script [m] (None: a quarter of the mean surface element size).
    pub skin: Option<Real>,
    /// Surface tets (a free face: outer boundary or broken joint), simulation ids.
    pub surface: Vec<u32>,
    /// Nodes of surface tets, sorted.
    pub surface_nodes: Vec<u32>,
    /// Fragment of each tet at the last detection.
    pub fragment: Vec<u32>,
    /// Fragment of each tet when contact started: only tets that were once connected can
    /// carry an overlap contact did not make (see [`PairState::armed`]).
    pub fragment0: Vec<u32>,
    /// Tet pairs (lower id first) across a broken joint, sorted, with the joint id.
    pub broken_faces: Vec<([u32; 2], u32)>,
    /// Candidate pairs (indices into `surface`), from stage 4.
    pub pairs: Vec<[u32; 2]>,
    pub state: Vec<PairState>,
    /// Surface lists must be rebuilt (joints broke, model changed).
    pub surface_stale: bool,
    pub boxes: Vec<Aabb>,
    geom: Vec<Option<TetGeom>>,
    /// Current (uninflated) boxes of the surface tets: the cheap first test of every pair.
    current_boxes: Vec<Aabb>,
    inv_h: Vec<Real>,
    chunk_out: Vec<Vec<PairOut>>,
    chunk_sums: Vec<ContactSums>,
    /// Record `events` for new touching pairs.
    pub record_events: bool,
    pub events: Vec<ContactEvent>,
    /// Totals of the last step.
    pub last: ContactSums,
    /// Mass ρV₀ of every tet [kg] (for the normal damping).
    pub tet_mass: Vec<Real>,
    /// Broken joints whose faces contact took over in the last step (stage 2 drops them).
    pub handover: Vec<u32>,
    chunk_handover: Vec<Vec<u32>>,
}

const CHUNK: usize = 1024;

impl Contact {
    pub fn is_enabled(&self) -> bool {
        !self.rules.is_empty()
    }

    /// Resolve the rules for every pair of materials (by Young's moduli for defaults).
    pub fn resolve(&mut self, young: &[Real]) {
        let n = young.len();
        self.n_materials = n;
        self.props.clear();
        self.friction_laws.clear();
        for r in &self.rules {
            if let Some(l) = &r.friction_law {
                if !self.friction_laws.iter().any(|k| Arc::ptr_eq(k, l)) {
                    self.friction_laws.push(l.clone());
                }
            }
        }
        for a in 0..n {
            for b in 0..n {
                let mut p = ContactProps {
                    penalty: 10.0 * young[a].max(young[b]),
                    tangential_penalty: 0.0,
                    friction: 0.0,
                    damping: 0.0,
                    friction_law: NO_FRICTION_LAW,
                };
                let mut pt = None;
                for r in &self.rules {
                    let applies = match r.materials {
                        None => true,
                        Some((x, y)) => {
                            (x as usize == a && y as usize == b)
                                || (x as usize == b && y as usize == a)
                        }
                    };
                    if applies {
                        if let Some(v) = r.penalty {
                            p.penalty = v;
                        }
                        pt = r.tangential_penalty.or(pt);
                        p.friction = r.friction;
                        p.damping = r.damping;
                        p.friction_law = r.friction_law.as_ref().map_or(NO_FRICTION_LAW, |l| {
                            self.friction_laws
                                .iter()
                                .position(|k| Arc::ptr_eq(k, l))
                                .unwrap() as u32
                        });
                    }
                }
                p.tangential_penalty = pt.unwrap_or(p.penalty);
                self.props.push(p);
            }
        }
    }

    #[inline]
    pub fn props_of(&self, ma: u32, mb: u32) -> ContactProps {
        self.props[ma as usize * self.n_materials + mb as usize]
    }

    /// Largest penalty over material pairs [Pa] (for the critical time step).
    pub fn max_penalty(&self) -> Real {
        self.props
            .iter()
            .map(|p| p.penalty.max(p.tangential_penalty))
            .fold(0.0, Real::max)
    }

    /// Contact force on each of `n_nodes` nodes in the last step [N] (zero where none), summed
    /// in pair order. Built on demand (output, queries): stage 5 only adds to `nodes.f`.
    pub fn node_forces(&self, n_nodes: usize) -> Vec<Vec3> {
        let mut f = vec![Vec3::zeros(); n_nodes];
        for po in self.chunk_out.iter().flatten() {
            for (k, &n) in po.nodes.iter().enumerate() {
                if let Some(x) = f.get_mut(n as usize) {
                    *x += po.f[k];
                }
            }
        }
        f
    }

    /// Total contact force in the last step on the nodes `range` (a body's nodes) [N].
    pub fn force_on(&self, range: std::ops::Range<usize>) -> Vec3 {
        let mut f = Vec3::zeros();
        for po in self.chunk_out.iter().flatten() {
            for (k, &n) in po.nodes.iter().enumerate() {
                if range.contains(&(n as usize)) {
                    f += po.f[k];
                }
            }
        }
        f
    }

    /// Largest mean contact pressure on each of `n_tets` tets in the last step [Pa] (zero
    /// where none).
    pub fn tet_pressures(&self, n_tets: usize) -> Vec<Real> {
        let mut p: Vec<Real> = vec![0.0; n_tets];
        for po in self.chunk_out.iter().flatten() {
            for &e in &po.tets {
                if let Some(x) = p.get_mut(e as usize) {
                    *x = Real::max(*x, po.pressure);
                }
            }
        }
        p
    }

    /// Single-thread cost of the stage 5 kernel on the pairs that touched in the last step
    /// (their geometry as of the last step), in ns per pair: the best of `repeats` passes,
    /// so it is a stable figure on a noisy machine. (touching pairs, ns per pair)
    pub fn kernel_ns_per_touching_pair(
        &self,
        tet_material: &[u32],
        repeats: usize,
    ) -> (usize, f64) {
        let touching: Vec<(TetGeom, TetGeom, Real)> = self
            .pairs
            .iter()
            .zip(&self.state)
            .filter(|(_, s)| s.touching)
            .filter_map(|(&[a, b], _)| {
                let (ea, eb) = (self.surface[a as usize], self.surface[b as usize]);
                let p = self.props_of(tet_material[ea as usize], tet_material[eb as usize]);
                Some((self.geom[a as usize]?, self.geom[b as usize]?, p.penalty))
            })
            .collect();
        let mut best = f64::INFINITY;
        for _ in 0..repeats.max(1) {
            let t = std::time::Instant::now();
            let mut e = 0.0;
            for (c, g, p) in &touching {
                e += overlapping_tet_tet(c, g, *p).energy;
            }
            std::hint::black_box(e);
            best = best.min(t.elapsed().as_secs_f64());
        }
        (touching.len(), best * 1e9 / touching.len().max(1) as f64)
    }

    /// Bytes held by the contact buffers (capacity).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.detector.workspace.bytes()
            + self.pairs.capacity() * 8
            + self.state.capacity() * size_of::<PairState>()
            + self.boxes.capacity() * size_of::<Aabb>()
            + self.geom.capacity() * size_of::<Option<TetGeom>>()
            + self.surface.capacity() * 4
            + self.surface_nodes.capacity() * 4
            + self.detector.x_at_detection.capacity() * size_of::<Vec3>()
            + self
                .chunk_out
                .iter()
                .map(|c| c.capacity() * size_of::<PairOut>())
                .sum::<usize>()
    }
}

/// Stage 5: add the contact and friction forces of every touching candidate pair to
/// `nodes.f`. `tet_nodes` and `tet_material` are the simulation's tet arrays; `dt_prev` is
/// the last step (Δx = v·dt_prev for the friction springs).
pub fn add_contact_forces(
    contact: &mut Contact,
    nodes: &mut Nodes,
    tet_nodes: &[[u32; 4]],
    tet_material: &[u32],
    dt_prev: Real,
    time: Real,
) -> ContactSums {
    let Contact {
        surface,
        pairs,
        state,
        geom,
        current_boxes,
        inv_h,
        chunk_out,
        chunk_sums,
        chunk_handover,
        record_events,
        events,
        ..
    } = contact;
    let x = &nodes.x;
    let v = &nodes.v;
    // Current geometry, box and 1/(smallest height) of the surface tets, in one pass.
    let n_surface = surface.len();
    geom.resize(n_surface, None);
    current_boxes.resize(n_surface, Aabb::of_points(&[Vec3::zeros()]));
    inv_h.resize(n_surface, 0.0);
    geom.par_iter_mut()
        .zip(current_boxes.par_iter_mut())
        .zip(inv_h.par_iter_mut())
        .zip(surface.par_iter())
        .with_min_len(256)
        .for_each(|(((g, bx), ih), &e)| {
            let xs = tet_nodes[e as usize].map(|n| x[n as usize]);
            *bx = Aabb::of_points(&xs);
            *g = TetGeom::new(xs);
            *ih = g.as_ref().map_or(0.0, |g| {
                g.height
                    .iter()
                    .fold(Real::INFINITY, |a, &h| a.min(h))
                    .recip()
            });
        });
    let n_chunks = pairs.len().div_ceil(CHUNK);
    chunk_out.resize_with(n_chunks, Vec::new);
    chunk_sums.resize(n_chunks, ContactSums::default());
    chunk_handover.resize_with(n_chunks, Vec::new);
    let props = &contact.props;
    let laws = &contact.friction_laws;
    let tet_mass = &contact.tet_mass;
    let n_mat = contact.n_materials;
    let (geom, inv_h, boxes) = (&*geom, &*inv_h, &*current_boxes);
    let pairs_ref = &*pairs;
    let surface_ref = &*surface;
    state
        .par_chunks_mut(CHUNK)
        .zip(chunk_out.par_iter_mut())
        .zip(chunk_sums.par_iter_mut())
        .zip(chunk_handover.par_iter_mut())
        .enumerate()
        .for_each(|(ci, (((st, out), sums), handover))| {
            out.clear();
            handover.clear();
            *sums = ContactSums::default();
            // Slots of the compiled friction laws (on the stack, reused by every pair).
            let mut frame = Frame::new();
            for (k, ps) in st.iter_mut().enumerate() {
                let pi = ci * CHUNK + k;
                let [a, b] = pairs_ref[pi];
                // Cheap rejection on current boxes.
                if !boxes[a as usize].overlaps(&boxes[b as usize]) {
                    ps.apart(sums, handover);
                    continue;
                }
                let (Some(gc), Some(gt)) = (&geom[a as usize], &geom[b as usize]) else {
                    ps.release(sums);
                    continue;
                };
                // Separated (most candidates, most steps): one plane test on the witness axis,
                // and nothing written unless the pair changes.
                if let Some(axis) = separating_axis(gc, gt, ps.witness) {
                    if ps.witness != axis {
                        ps.witness = axis;
                    }
                    ps.apart(sums, handover);
                    continue;
                }
                let (ea, eb) = (surface_ref[a as usize], surface_ref[b as usize]);
                let pr = props[tet_material[ea as usize] as usize * n_mat
                    + tet_material[eb as usize] as usize];
                let r = overlapping_tet_tet(gc, gt, pr.penalty);
                // Not overlapping after all (an edge–edge separation): all axes next step.
                ps.witness = if r.touching { OVERLAPPED } else { 0 };
                if !ps.armed {
                    // Armed once there is no overlap energy to release (exactly touching
                    // faces, e.g. blocks that start face to face, arm at once).
                    let scale = pr.penalty * gc.volume.abs().min(gt.volume.abs());
                    if !r.touching || r.energy <= 1e-12 * scale {
                        ps.armed = true;
                        if ps.joint != u32::MAX {
                            handover.push(ps.joint);
                        }
                    }
                    if !ps.armed {
                        continue;
                    }
                }
                if !r.touching {
                    ps.release(sums);
                    continue;
                }
                sums.max_overlap = sums.max_overlap.max(r.depth);
                sums.max_overlap_ratio = sums
                    .max_overlap_ratio
                    .max(r.depth * inv_h[a as usize].max(inv_h[b as usize]));
                let mut f = [Vec3::zeros(); 8];
                f[..4].copy_from_slice(&r.fc);
                f[4..].copy_from_slice(&r.ft);
                let f_normal: Vec3 = r.fc.iter().sum();
                let fn_mag = f_normal.norm();
                let mut energy = r.energy;
                if (pr.has_friction() || pr.damping > 0.0) && fn_mag > 0.0 {
                    let n = f_normal / fn_mag;
                    let nc = gc.bary(&r.point);
                    let nt = gt.bary(&r.point);
                    let (na, nb) = (tet_nodes[ea as usize], tet_nodes[eb as usize]);
                    let mut dv = Vec3::zeros();
                    for i in 0..4 {
                        dv += v[na[i] as usize] * nc[i] - v[nb[i] as usize] * nt[i];
                    }
                    // k_n/3 per unit penalty: the thin-overlap stiffness of one face node. The
                    // friction spring and the dashpot act at one point, so one node can feel
                    // all of them; sized per node they stay within the critical time step.
                    let stiff = 4.0 / 3.0 * r.area * (inv_h[a as usize] + inv_h[b as usize]);
                    let mut fx = Vec3::zeros();
                    // Normal dashpot first: Coulomb acts on the whole normal force.
                    let mut normal = fn_mag;
                    if pr.damping > 0.0 {
                        let kn = pr.penalty * stiff;
                        let (mc, mt) = (tet_mass[ea as usize], tet_mass[eb as usize]);
                        // Reduced mass of one node of each tet.
                        let m_red = 0.25 * mc * mt / (mc + mt);
                        let c = 2.0 * pr.damping * (kn * m_red).sqrt();
                        let vn = n.dot(&dv);
                        // Never pull harder than the contact pushes.
                        let fd = (-c * vn).max(-fn_mag);
                        fx += n * fd;
                        normal += fd;
                    }
                    let du = dv * dt_prev;
                    let mut e_spring = 0.0;
                    if pr.has_friction() {
                        let du_t = du - n * n.dot(&du);
                        ps.slip += du_t.norm();
                        // μ: the rule's constant, or its compiled law of this pair's state.
                        let mu = if pr.friction_law == NO_FRICTION_LAW {
                            pr.friction
                        } else {
                            let dv_t = dv - n * n.dot(&dv);
                            let inputs = FrictionInputs {
                                slip_rate: dv_t.norm(),
                                slip: ps.slip,
                                pressure: normal / r.area,
                                normal_force: normal,
                                area: r.area,
                                time,
                                mu: pr.friction,
                            };
                            let [mu] = laws[pr.friction_law as usize]
                                .evaluate_in(&mut frame, &inputs.to_slots());
                            if mu.is_finite() && mu >= 0.0 {
                                mu
                            } else {
                                sums.law_failure.get_or_insert(FrictionLawFailure {
                                    law: pr.friction_law,
                                    tets: [ea, eb],
                                    point: r.point,
                                    inputs,
                                    friction: mu,
                                });
                                0.0
                            }
                        };
                        let kt = pr.tangential_penalty * stiff;
                        // Keep the stored force's magnitude on the new tangent plane.
                        let old = ps.spring;
                        let mut ft = old - n * n.dot(&old);
                        let m_old = old.norm();
                        let m_new = ft.norm();
                        if m_new > 0.0 {
                            ft *= m_old / m_new;
                        }
                        ft -= du_t * kt;
                        let limit = mu * normal;
                        let mag = ft.norm();
                        if mag > limit {
                            ft *= limit / mag;
                        }
                        ps.spring = ft;
                        e_spring = 0.5 * ft.norm_squared() / kt;
                        energy += e_spring;
                        sums.friction_force += ft.norm();
                        fx += ft;
                    } else {
                        ps.spring = Vec3::zeros();
                    }
                    // Dissipated = −(work of these forces) − (change of the spring energy), the
                    // work in the central difference's trapezoid form ½(f_{n−1} + f_n)·Δu_n.
                    sums.dissipated += -0.5 * (ps.f_prev + fx).dot(&du) - (e_spring - ps.e_prev);
                    ps.f_prev = fx;
                    ps.e_prev = e_spring;
                    for i in 0..4 {
                        f[i] += fx * nc[i];
                        f[4 + i] -= fx * nt[i];
                    }
                } else {
                    // Still touching: keep the touching flag and the slip path.
                    let (was, slip) = (ps.touching, ps.slip);
                    ps.release(sums);
                    ps.touching = was;
                    ps.slip = slip;
                }
                sums.energy += energy;
                sums.active += 1;
                sums.normal_force += fn_mag;
                sums.max_pressure = sums.max_pressure.max(fn_mag / r.area);
                if !ps.touching && *record_events {
                    // Reported in pair order below.
                    ps.touching = true;
                    out.push(PairOut {
                        pair: pi as u32 | NEW_FLAG,
                        tets: [ea, eb],
                        nodes: pair_nodes(tet_nodes, ea, eb),
                        f,
                        point: r.point,
                        pressure: fn_mag / r.area,
                    });
                } else {
                    ps.touching = true;
                    out.push(PairOut {
                        pair: pi as u32,
                        tets: [ea, eb],
                        nodes: pair_nodes(tet_nodes, ea, eb),
                        f,
                        point: r.point,
                        pressure: fn_mag / r.area,
                    });
                }
            }
        });
    // Add to the nodes in pair order (deterministic).
    let mut total = ContactSums::default();
    for (out, s) in chunk_out.iter().zip(chunk_sums.iter()) {
        total.energy += s.energy;
        total.dissipated += s.dissipated;
        total.active += s.active;
        total.normal_force += s.normal_force;
        total.friction_force += s.friction_force;
        total.max_overlap = total.max_overlap.max(s.max_overlap);
        total.max_overlap_ratio = total.max_overlap_ratio.max(s.max_overlap_ratio);
        total.max_pressure = total.max_pressure.max(s.max_pressure);
        if total.law_failure.is_none() {
            total.law_failure = s.law_failure;
        }
        for po in out {
            for k in 0..8 {
                nodes.f[po.nodes[k] as usize] += po.f[k];
            }
            if po.pair & NEW_FLAG != 0 {
                events.push(ContactEvent {
                    time,
                    tets: po.tets,
                    point: po.point,
                });
            }
        }
    }
    for h in chunk_handover.iter() {
        contact.handover.extend_from_slice(h);
    }
    contact.last = total;
    total
}

#[inline(always)]
fn pair_nodes(tet_nodes: &[[u32; 4]], ea: u32, eb: u32) -> [u32; 8] {
    let (a, b) = (tet_nodes[ea as usize], tet_nodes[eb as usize]);
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
}

/// Marks a pair that started touching in this step (top bit of the pair index).
const NEW_FLAG: u32 = 1 << 31;

#[cfg(test)]
mod tests {
    use super::*;

    /// A target tet with its face z = 0 on top and a contactor whose bottom face sinks 1 mm
    /// into it, friction μ = 0.5 (nodes 0–3 target, 4–7 contactor).
    fn two_tets() -> (Contact, Nodes, Vec<[u32; 4]>, Vec<u32>) {
        let mut nodes = Nodes::default();
        let pts = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.2, 0.2, -1e-3),
            Vec3::new(1.0, 0.2, -1e-3),
            Vec3::new(0.2, 1.0, -1e-3),
            Vec3::new(0.2, 0.2, 1.0),
        ];
        for (i, p) in pts.into_iter().enumerate() {
            nodes.push(p, (i / 4) as u32);
            nodes.m[i] = 1.0;
        }
        let mut contact = Contact::default();
        contact.rules.push(ContactRule {
            penalty: Some(1e6),
            friction: 0.5,
            ..Default::default()
        });
        contact.resolve(&[1e5]);
        contact.surface = vec![0, 1];
        contact.pairs = vec![[1, 0]];
        contact.state = vec![PairState::default()];
        contact.tet_mass = vec![1.0, 1.0];
        (contact, nodes, vec![[0, 1, 2, 3], [4, 5, 6, 7]], vec![0, 0])
    }

    /// Move the contactor by `d` per step for `steps` steps (velocity d/dt, as the central
    /// difference gives it to stage 5).
    fn slide(
        c: &mut Contact,
        nodes: &mut Nodes,
        tets: &[[u32; 4]],
        mat: &[u32],
        d: Vec3,
        steps: usize,
    ) {
        let dt = 1e-3;
        for _ in 0..steps {
            for n in 4..8 {
                nodes.x[n] += d;
                nodes.v[n] = d / dt;
            }
            add_contact_forces(c, nodes, tets, mat, dt, 0.0);
            nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
        }
    }

    /// `slip` is the path length of the tangential relative motion, not the net displacement:
    /// 10 steps of +0.1 mm and 10 of −0.1 mm along x give 2 mm (to 1e-9: the overlap is
    /// planar, so the contact normal is z and every step is tangential), with the contactor back
    /// where it started; a normal motion adds nothing; the slip is 0 once the pair releases.
    #[test]
    fn slip_accumulates_the_path_length_and_resets_on_release() {
        let (mut c, mut nodes, tets, mat) = two_tets();
        let dx = Vec3::new(1e-4, 0.0, 0.0);
        slide(&mut c, &mut nodes, &tets, &mat, dx, 10);
        let forth = c.state[0].slip;
        slide(&mut c, &mut nodes, &tets, &mat, -dx, 10);
        let back = c.state[0].slip;
        println!("slip after 10 steps forth {forth:e} m, and back {back:e} m");
        assert!(c.state[0].touching);
        assert!((forth - 1e-3).abs() < 1e-9 * 1e-3, "{forth:e}");
        assert!((back - 2e-3).abs() < 1e-9 * 2e-3, "{back:e}");
        assert!((nodes.x[4] - nodes.x0[4]).norm() < 1e-15);
        slide(
            &mut c,
            &mut nodes,
            &tets,
            &mat,
            Vec3::new(0.0, 0.0, -1e-5),
            5,
        );
        assert!(
            (c.state[0].slip - back).abs() < 1e-9 * back,
            "normal motion is no slip"
        );
        // Lift the contactor off: the pair releases and its slip path starts again from 0.
        slide(
            &mut c,
            &mut nodes,
            &tets,
            &mat,
            Vec3::new(0.0, 0.0, 1e-2),
            1,
        );
        assert!(!c.state[0].touching);
        assert_eq!(c.state[0].slip, 0.0);
    }
}
