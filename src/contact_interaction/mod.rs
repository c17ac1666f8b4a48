//! Stage 5: contact interaction — the narrow phase. Reads stage 4's candidate pairs (and its
//! old→new remap, to carry the per-pair history), node positions and velocities; adds the
//! potential contact forces with Coulomb friction to `nodes.f` and owns the pair history
//! (friction springs, slip paths, separating-axis witnesses, arming).
//!
//! **Normal force**: [`potential::tet_tet`], the exact gradient of E = p∫(φ_c + φ_t) dV.
//!
//! **Friction** (per pair, with history; [`friction`]): the contact normal n is the direction
//! of the normal force on the contactor, the contact point x_p the centroid of the clipped
//! facets. Each step the relative displacement of the two elements at x_p over the last step,
//! Δu = Σ N_i^c(x_p)·Δx_i^c − Σ N_j^t(x_p)·Δx_j^t, is projected on the tangent plane and the
//! tangential force is updated incrementally, then returned to the Coulomb cone
//! |f_t| ≤ μ|F_n| (sliding). The work μ|F_n|·(|f_trial| − μ|F_n|)/k_t of each slip is
//! dissipated and ½|f_t|²/k_t is stored. The spring stiffness follows the normal one of one
//! face node for a thin overlap, k_t = (4/3)·p_t·A·(1/h_c + 1/h_t), with A the contact area
//! and h the smallest height of each element (the spring acts at one point, so one node may
//! carry all of it): static friction holds with an elastic offset |f_t|/k_t, kinetic
//! friction slides at μ|F_n|.
//!
//! **Friction laws**: μ is the rule's constant `friction`, or, when the rule has a
//! `friction_law`, the value of a Rhai function compiled to native code (signature
//! [`FRICTION_LAW`]) of the pair's slip rate, slip path (history [`PairState::slip`]),
//! pressure, normal force, area, time and the constant, evaluated once per touching pair and
//! step just before the return to the cone. A result that is not finite and ≥ 0 stops the
//! run ([`ContactSums::law_failure`]).
//!
//! **Normal damping** (optional, ratio ζ): a dashpot on the normal relative velocity at x_p,
//! f_d = −2ζ·√(k·m*)·(v_rel·n)·n with k = (4/3)·p·A·(1/h_c + 1/h_t) and m* the reduced mass
//! of one node of each tetrahedron (ζ is the damping ratio of one face node on its contact
//! spring), never pulling harder than the contact pushes. Its work is dissipated (booked with
//! friction).
//!
//! **Laws**: [`law`] (`"potential"`, with its defaults). **Time step**: the contact springs'
//! share of the critical step is [`contact_nodal_stiffness`].
//!
//! **Determinism**: pairs are evaluated in parallel and their forces added to the nodes in
//! pair order on one thread.

pub mod friction;
pub mod law;
pub mod oracle;
pub mod potential;

pub use friction::{FrictionInputs, FrictionLawFailure, FRICTION_LAW, FRICTION_LAW_PARAMS};
pub use law::{
    ContactLaw, ContactLaws, ContactProps, ContactRule, PotentialContact, CONTACT_LAWS,
    DEFAULT_PENALTY_FACTOR, NO_FRICTION_LAW,
};

use crate::compiled::Frame;
use crate::contact_detection::{Aabb, ContactDetection, PairOrigin};
use crate::material::Material;
use crate::math::{ExactSum, Mat3, Real, Vec3};
use crate::state::held::Held;
use crate::state::{Nodes, Tets};
use potential::{overlapping_tet_tet, separating_axis, TetGeom, OVERLAPPED};
use rayon::prelude::*;

/// Stage 5's share of the time-step limit ([`ContactInteraction::max_omega2`]) and where it
/// comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactStepBound {
    /// max 2·k/m over the tets' nodes [1/s²].
    pub omega2: Real,
    /// The tet that has it (`usize::MAX` without tets).
    pub tet: usize,
    /// The material whose pairs with the tet's material have the largest penalty.
    pub partner: u32,
    /// That penalty [Pa].
    pub penalty: Real,
}

/// A pair that came into contact (for `on_new_contact_pair`).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    pub time: Real,
    /// Simulation tet ids (contactor, target).
    pub tets: [u32; 2],
    pub point: Vec3,
}

/// What every candidate pair keeps between steps: 4 bytes. Most candidates never touch;
/// their only state is the separating-axis witness. A pair that touches or is not yet armed
/// also has a [`PairState`] in its chunk's history list (`hist`, chunk-local).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct PairSlot {
    /// Index of the pair's history in its chunk's list, [`NO_HISTORY`] if none (the pair
    /// is armed and not touching: every field of its history would be the default).
    pub hist: u16,
    /// The axis that last separated the pair (see [`potential::separating_axis`]).
    pub witness: u8,
}

/// [`PairSlot::hist`] of a pair without history.
pub const NO_HISTORY: u16 = u16::MAX;

impl Default for PairSlot {
    fn default() -> Self {
        PairSlot {
            hist: NO_HISTORY,
            witness: 0,
        }
    }
}

/// A rank's designated pairs as the ranks share them ([`ContactInteraction::designated_states`]):
/// every pair's [`pair_key`] and witness, ascending, and apart the histories of those that
/// have one, with their place in `keys`. Apart, so that the pairs without a history (most
/// candidates) cost 9 bytes, not a whole [`PairState`], in every rank's copy of the list.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct DesignatedStates {
    pub keys: Vec<(u64, u8)>,
    pub histories: Vec<(u32, PairState)>,
}

/// History of one candidate pair that touches or is not yet armed (the others have the
/// default history, which is not stored).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
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
    /// The pair's witness axis while it is being evaluated (kept in [`PairSlot`]).
    pub witness: u8,
    /// Slip path while touching [m]: Σ|Δu_t| of the relative tangential displacement at the
    /// contact point, summed every step the pair's friction acts; back to 0 when the pair
    /// releases. The `slip` input of friction laws.
    pub slip: Real,
    /// The pair's forces in the last step it touched (read for the steps it is listed in
    /// the chunk's outputs).
    out: PairOut,
}

impl PairState {
    /// The history of a pair stage 4 found for the first time: former neighbours start
    /// unarmed (see [`PairState::armed`]), with the broken joint between them.
    pub fn new_pair(neighbours: bool, joint: u32) -> Self {
        let mut s = PairState::default();
        if neighbours {
            s.armed = false;
            s.joint = joint;
        }
        s
    }

    /// Whether the broken joint between the two elements still holds their faces (a dilatant
    /// joint within its asperities' reach: `keeps` is stage 2's
    /// [`crate::joints::Joints::keeps_faces`]); the pair does not arm until it lets go.
    #[inline]
    fn joint_keeps_faces(&self, keeps: &[bool]) -> bool {
        self.joint != u32::MAX && keeps.get(self.joint as usize).copied().unwrap_or(false)
    }

    /// The elements do not overlap: release the friction spring and arm the pair (a broken
    /// joint between the two is handed over to contact), unless that joint still holds the
    /// faces (`held`).
    #[inline]
    fn apart(&mut self, sums: &mut ContactSums, handover: &mut Vec<u32>, held: bool) {
        self.release(sums);
        if !self.armed && !held {
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

    /// The history differs from the default one and must be stored: the pair touches (its
    /// friction spring, slip path, last forces) or is not armed yet (its broken joint).
    /// Released, armed pairs have every field at its default (the joint id is not read
    /// once armed).
    #[inline(always)]
    fn needs_history(&self) -> bool {
        self.touching || !self.armed
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
            out: PairOut::default(),
        }
    }
}

/// Per-step totals of stage 5.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
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
    /// Σ A over touching pairs: the contact area (each pair's A is half the area of its
    /// clipped facets, the area of a thin overlap) [m²].
    pub area: Real,
    /// The first pair (in pair order) whose friction law gave a μ that is not finite and
    /// ≥ 0 in this step: the run must stop (the pair got μ = 0).
    pub law_failure: Option<FrictionLawFailure>,
}

/// Stage 5's totals while the pairs' contributions are being added: exact sums
/// ([`ExactSum`]), counts, maxima and the law failure of the lowest pair, so the totals have
/// the same bits whichever thread or rank adds which pairs, in any order. (Until 2026-12-07
/// the sums were f64 added chunk by chunk in pair order, and a decomposed model gathered a
/// record of every chunk, or of every pair in a chunk two ranks shared, to add them in that
/// order: 0.25 of the 0.42 MB a rank received per step on the 55k-tet impact.)
#[derive(Clone, Debug, Default)]
pub struct ContactTally {
    energy: ExactSum,
    dissipated: ExactSum,
    normal_force: ExactSum,
    friction_force: ExactSum,
    area: ExactSum,
    active: usize,
    max_overlap: Real,
    max_overlap_ratio: Real,
    max_pressure: Real,
    /// (pair, failure) of the lowest pair whose friction law failed (the pair by its
    /// [`pair_key`]).
    law_failure: Option<(u64, FrictionLawFailure)>,
}

impl ContactTally {
    /// Exact sums, each [`ExactSum::LEN`] values of [`ContactTally::write_sums`].
    const SUMS: usize = 5;
    /// Values [`ContactTally::write_sums`] writes: the exact sums and the count.
    pub const SUM_LEN: usize = Self::SUMS * ExactSum::LEN + 1;

    /// Add what pair `pair` ([`pair_key`]) contributed (its own contributions, summed first).
    #[inline]
    fn add_pair(&mut self, pair: u64, s: &ContactSums) {
        self.energy.add(s.energy);
        self.dissipated.add(s.dissipated);
        self.normal_force.add(s.normal_force);
        self.friction_force.add(s.friction_force);
        self.area.add(s.area);
        self.active += s.active;
        self.max_overlap = self.max_overlap.max(s.max_overlap);
        self.max_overlap_ratio = self.max_overlap_ratio.max(s.max_overlap_ratio);
        self.max_pressure = self.max_pressure.max(s.max_pressure);
        if let Some(f) = s.law_failure {
            if self.law_failure.is_none_or(|(p, _)| pair < p) {
                self.law_failure = Some((pair, f));
            }
        }
    }

    /// Add another tally (of other pairs).
    fn merge(&mut self, o: &ContactTally) {
        self.energy.merge(&o.energy);
        self.dissipated.merge(&o.dissipated);
        self.normal_force.merge(&o.normal_force);
        self.friction_force.merge(&o.friction_force);
        self.area.merge(&o.area);
        self.active += o.active;
        self.max_overlap = self.max_overlap.max(o.max_overlap);
        self.max_overlap_ratio = self.max_overlap_ratio.max(o.max_overlap_ratio);
        self.max_pressure = self.max_pressure.max(o.max_pressure);
        if let Some((p, f)) = o.law_failure {
            if self.law_failure.is_none_or(|(q, _)| p < q) {
                self.law_failure = Some((p, f));
            }
        }
    }

    /// The totals, each sum rounded once.
    pub fn sums(&self) -> ContactSums {
        ContactSums {
            energy: self.energy.value(),
            dissipated: self.dissipated.value(),
            active: self.active,
            normal_force: self.normal_force.value(),
            friction_force: self.friction_force.value(),
            max_overlap: self.max_overlap,
            max_overlap_ratio: self.max_overlap_ratio,
            max_pressure: self.max_pressure,
            area: self.area.value(),
            law_failure: self.law_failure.map(|(_, f)| f),
        }
    }

    /// The sums and the count as f64 integers for a sum over ranks ([`ExactSum::digits`]):
    /// adding the arrays of every rank in any order and reading them back
    /// ([`ContactTally::read_sums`]) gives the tally of all ranks' pairs.
    pub fn write_sums(&self, out: &mut [f64]) {
        let sums = [
            &self.energy,
            &self.dissipated,
            &self.normal_force,
            &self.friction_force,
            &self.area,
        ];
        for (s, o) in sums.iter().zip(out.chunks_exact_mut(ExactSum::LEN)) {
            s.digits(o);
        }
        out[Self::SUMS * ExactSum::LEN] = self.active as f64;
    }

    /// The maxima, for a largest-over-ranks reduction.
    pub fn maxima(&self) -> [Real; 3] {
        [self.max_overlap, self.max_overlap_ratio, self.max_pressure]
    }

    /// The tally of every rank: the summed [`ContactTally::write_sums`] arrays, the largest
    /// [`ContactTally::maxima`], and the law failure of the lowest pair over the ranks.
    pub fn read_sums(
        summed: &[f64],
        maxima: [Real; 3],
        law_failure: Option<(u64, FrictionLawFailure)>,
    ) -> Self {
        let part = |i: usize| ExactSum::from_digits(&summed[i * ExactSum::LEN..]);
        ContactTally {
            energy: part(0),
            dissipated: part(1),
            normal_force: part(2),
            friction_force: part(3),
            area: part(4),
            active: summed[Self::SUMS * ExactSum::LEN] as usize,
            max_overlap: maxima[0],
            max_overlap_ratio: maxima[1],
            max_pressure: maxima[2],
            law_failure,
        }
    }
}

/// Overlap, relative to the smaller element height of the pair, above which a run warns
/// (once) and its summary says so: the potential's thin-layer stiffness and energy assume
/// d ≪ h (docs/theory/contact.md, Overlap), and a pair that keeps approaching can pass through.
/// For scale: 3 % was measured in a 5 m/s impact at the default penalty 10·E.
pub const PENETRATION_WARNING: Real = 0.1;

/// The step with the deepest penetration so far (largest [`ContactSums::max_overlap_ratio`]
/// since the model was built).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct DeepestOverlap {
    /// Largest d/h of a touching pair [-] (h the smaller height of its two elements).
    pub ratio: Real,
    /// Deepest overlap d of that step [m].
    pub depth: Real,
    /// Time at the start of that step [s].
    pub time: Real,
}

/// Output of one touching pair (kept in its history).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct PairOut {
    /// Simulation ids of the contactor and the target.
    tets: [u32; 2],
    /// Their nodes (contactor's 4, then the target's) and the forces on them [N].
    nodes: [u32; 8],
    f: [Vec3; 8],
    point: Vec3,
    /// Mean normal contact pressure |F_n|/A [Pa].
    pressure: Real,
}

impl PairOut {
    /// Numbers in one message of f64 ([`PairOut::write`]).
    pub const LEN: usize = 38;

    /// The nodes the pair's forces act on: the contactor's four, then the target's.
    pub fn nodes(&self) -> &[u32; 8] {
        &self.nodes
    }

    /// Append the output to `out` as [`PairOut::LEN`] numbers (ids are exact in f64).
    pub fn write(&self, out: &mut Vec<f64>) {
        out.extend(self.tets.iter().chain(&self.nodes).map(|&i| i as f64));
        for f in &self.f {
            out.extend_from_slice(f.as_slice());
        }
        out.extend_from_slice(self.point.as_slice());
        out.push(self.pressure);
    }

    /// The output [`PairOut::write`] wrote as `v`.
    pub fn read(v: &[f64]) -> Self {
        let id = |k: usize| v[k] as u32;
        let vec = |k: usize| Vec3::new(v[k], v[k + 1], v[k + 2]);
        PairOut {
            tets: [id(0), id(1)],
            nodes: std::array::from_fn(|k| id(2 + k)),
            f: std::array::from_fn(|k| vec(10 + 3 * k)),
            point: vec(34),
            pressure: v[37],
        }
    }
}

/// Marks a pair that started touching in this step (top bit of its output entry).
const NEW_FLAG: u32 = 1 << 31;

/// Pairs per parallel task.
const CHUNK: usize = 1024;

/// Stage 5 state: the laws, the pair history (aligned with stage 4's pair list) and the
/// outputs of the last step.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct ContactInteraction {
    pub laws: ContactLaws,
    /// Witness and history slot of every candidate pair, `slots[k]` for stage 4's
    /// `pairs[k]`.
    pub slots: Vec<PairSlot>,
    /// Per chunk of [`CHUNK`] pairs: the histories of its pairs that have one. An entry
    /// stays with its pair while the pair needs it; freed entries are listed in `free` and
    /// reused (in pair order: deterministic).
    pub hist: Vec<Vec<PairState>>,
    free: Vec<Vec<u16>>,
    /// Record `events` for new touching pairs.
    pub record_events: bool,
    pub events: Vec<ContactEvent>,
    /// Totals of the last step.
    pub last: ContactSums,
    /// The deepest penetration of all steps so far (for the run's warning and summary).
    pub deepest: DeepestOverlap,
    /// Mass ρV₀ of every tet [kg] (for the normal damping).
    pub tet_mass: Vec<Real>,
    /// Broken joints whose faces contact took over in the last step (stage 2 drops them).
    pub handover: Vec<u32>,
    /// Per surface tet: current geometry, box (the cheap first test of every pair) and
    /// 1/(smallest height), computed at the start of each step (not in checkpoints). A rank
    /// of a decomposed model holds those of the surface tets of its pairs only
    /// ([`PairMask::surface`], the list `geom_for`): 416 B a surface tet.
    #[serde(skip)]
    geom: Held<Option<TetGeom>>,
    #[serde(skip)]
    current_boxes: Held<Aabb>,
    #[serde(skip)]
    inv_h: Held<Real>,
    #[serde(skip)]
    geom_for: Vec<u32>,
    /// Per chunk of pairs: the history entries of the pairs that touched in the last step,
    /// in pair order ([`NEW_FLAG`] set for those that started touching), and handovers.
    chunk_out: Vec<Vec<u32>>,
    chunk_handover: Vec<Vec<u32>>,
    /// On a decomposed model: the pairs this rank computes, and those designated to it
    /// (`crate::parallel`); empty on one rank (every pair).
    #[serde(skip)]
    pub mask: PairMask,
    /// Per chunk, on a decomposed model: the designated pairs' events, handovers and law
    /// failures (merged over ranks by [`ContactInteraction::apply_records`]).
    #[serde(skip)]
    chunk_records: Vec<Vec<PairRecord>>,
    /// On a decomposed model: this rank's tally of its designated pairs in the last step.
    #[serde(skip)]
    tally: ContactTally,
}

/// Which candidate pairs one rank of a decomposed model computes (those with a node of the
/// rank: their forces on its nodes are then the one-rank sums; a rank's list holds only
/// those) and which it reports (each pair to one rank: the lowest owning a node of it).
/// Indexed like stage 4's pairs.
#[derive(Clone, Debug, Default)]
pub struct PairMask {
    /// Made for a rank of a decomposed model (the default mask, on one process, computes
    /// and designates every pair).
    pub decomposed: bool,
    pub designated: Vec<bool>,
    /// The surface tets in a pair this rank computes, ascending (the others' geometry is not
    /// updated: stage 5's per-step work on a rank follows its pairs, not the whole surface).
    pub surface: Vec<u32>,
}

/// A candidate pair (surface indices, lower first) as one number that sorts like the list:
/// the lists of all ranks are sorted the same way, so keys order pairs across ranks.
#[inline]
pub fn pair_key(p: [u32; 2]) -> u64 {
    ((p[0] as u64) << 32) | p[1] as u64
}

/// What one pair did in a step that every rank must see in pair order: the joint it handed
/// over, the contact event it started, its friction law's failure. A decomposed model
/// gathers these (few: most steps none) from the pairs' designated ranks; the totals go by
/// a sum of [`ContactTally`]s.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct PairRecord {
    /// The pair's [`pair_key`]: its place in the whole list, whichever ranks hold it.
    pub pair: u64,
    pub handover: Option<u32>,
    pub event: Option<ContactEvent>,
    pub law_failure: Option<FrictionLawFailure>,
}

impl PairMask {
    /// A decomposed model's mask for a list of `n` pairs (a rank may hold none).
    pub fn is_for(&self, n: usize) -> bool {
        self.decomposed && self.designated.len() == n
    }
}

impl ContactInteraction {
    /// Contact is on once a rule is given.
    pub fn is_enabled(&self) -> bool {
        self.laws.is_enabled()
    }

    /// Before the first step after the model changed: resolve the laws for every pair of
    /// materials and the tet masses the dashpot uses.
    pub fn prepare(&mut self, materials: &[Material], tets: &Tets) {
        let young: Vec<Real> = materials.iter().map(|m| m.young).collect();
        self.laws.resolve(&young);
        self.tet_mass = (0..tets.len())
            .map(|e| materials[tets.material[e] as usize].density * tets.vol0[e])
            .collect();
    }

    /// Stage 4 detected: carry the history over to the new pair list (`origins`, one per new
    /// pair: stage 4's remap) and size the per-chunk buffers (stage 5 sizes the per-surface
    /// ones).
    pub fn carry_history(&mut self, origins: Vec<PairOrigin>) {
        let old_slots = std::mem::take(&mut self.slots);
        let old_hist = std::mem::take(&mut self.hist);
        let n_chunks = origins.len().div_ceil(CHUNK);
        // Chunk by chunk in parallel: a chunk's slots and history list depend only on its
        // own pairs' origins (the same lists for any thread count).
        let mut slots = vec![PairSlot::default(); origins.len()];
        let hist: Vec<Vec<PairState>> = (slots.par_chunks_mut(CHUNK))
            .zip(origins.par_chunks(CHUNK))
            .map(|(slots, origins)| {
                let mut h = Vec::new();
                for (slot, o) in slots.iter_mut().zip(origins) {
                    let state = match *o {
                        PairOrigin::Kept(k) => {
                            let s = old_slots[k as usize];
                            slot.witness = s.witness;
                            (s.hist != NO_HISTORY)
                                .then(|| old_hist[k as usize / CHUNK][s.hist as usize])
                        }
                        PairOrigin::New { neighbours, joint } => {
                            let s = PairState::new_pair(neighbours, joint);
                            s.needs_history().then_some(s)
                        }
                    };
                    if let Some(s) = state {
                        slot.hist = h.len() as u16;
                        h.push(s);
                    }
                }
                h.shrink_to_fit();
                h
            })
            .collect();
        self.slots = slots;
        self.hist = hist;
        self.free = vec![Vec::new(); n_chunks];
        // The outputs point into the old histories.
        self.chunk_out.iter_mut().for_each(Vec::clear);
        self.chunk_out.resize_with(n_chunks, Vec::new);
        self.chunk_handover.resize_with(n_chunks, Vec::new);
        self.chunk_records.resize_with(n_chunks, Vec::new);
        self.chunk_records.iter_mut().for_each(Vec::clear);
        // The pairs changed: a decomposed model makes its mask again.
        self.mask = PairMask::default();
    }

    /// This stage's share of the time-step limit: the stiffest contact spring a node can
    /// feel over its mass, max over tets and their nodes of 2·k/m with k from
    /// [`contact_nodal_stiffness`] at the largest penalty of the tet's material against any
    /// material of the model [1/s²]. Added to the elements' ω² like the joint springs. (Until
    /// 2026-11-30 every tet took the model's largest penalty: a soft pad beside rock, whose
    /// pad–rock penalty is 50 times below the rock–rock one, cut dt 3.2× for nothing.)
    /// Also returns where the bound comes from ([`ContactStepBound`]): the tet (the lowest
    /// index among equal bounds, so any thread count finds the same), the partner material
    /// and the penalty, for the run's time-step line.
    pub fn max_omega2(&self, tets: &Tets, mass: &[Real]) -> ContactStepBound {
        let mut present = vec![false; self.laws.n_materials];
        for &m in &tets.material {
            if let Some(p) = present.get_mut(m as usize) {
                *p = true;
            }
        }
        let penalty = self.laws.max_penalty_by_material(&present);
        let (omega2, tet) = (0..tets.len())
            .into_par_iter()
            .map(|e| {
                let p = penalty
                    .get(tets.material[e] as usize)
                    .map_or(0.0, |&(p, _)| p);
                let k = contact_nodal_stiffness(&tets.dm_inv[e], tets.vol0[e], p);
                let w2 = tets.nodes[e]
                    .iter()
                    .map(|&n| 2.0 * k / mass[n as usize])
                    .fold(0.0, Real::max);
                (w2, e)
            })
            .reduce(
                || (0.0, usize::MAX),
                |a, b| {
                    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                        b
                    } else {
                        a
                    }
                },
            );
        let (penalty, partner) = tets
            .material
            .get(tet)
            .and_then(|&m| penalty.get(m as usize).copied())
            .unwrap_or((0.0, u32::MAX));
        ContactStepBound {
            omega2,
            tet,
            partner,
            penalty,
        }
    }

    /// The outputs of the pairs that touched in the last step, in pair order.
    fn outputs(&self) -> impl Iterator<Item = &PairOut> {
        self.chunk_out.iter().enumerate().flat_map(move |(c, out)| {
            out.iter()
                .map(move |&i| &self.hist[c][(i & !NEW_FLAG) as usize].out)
        })
    }

    /// Contact force on each of `n_nodes` nodes in the last step [N] (zero where none), summed
    /// in pair order. Built on demand (output, queries): stage 5 only adds to `nodes.f`.
    pub fn node_forces(&self, n_nodes: usize) -> Vec<Vec3> {
        node_forces_of(self.outputs(), n_nodes)
    }

    /// Total contact force in the last step on the nodes `range` (a body's nodes) [N]: an
    /// exact sum over the touching pairs ([`ExactSum`]), so a decomposed model gets its
    /// bits from the ranks' sums of their designated pairs
    /// ([`ContactInteraction::force_share`]).
    pub fn force_on(&self, range: std::ops::Range<usize>) -> Vec3 {
        let mut sum: [ExactSum; 3] = Default::default();
        for (out, hist) in self.chunk_out.iter().zip(&self.hist) {
            for &i in out {
                add_force(
                    &mut sum,
                    pair_force_on(&hist[(i & !NEW_FLAG) as usize].out, &range),
                );
            }
        }
        Vec3::from_fn(|k, _| sum[k].value())
    }

    /// A decomposed model's share of [`ContactInteraction::force_on`]: the exact sums over
    /// the touching pairs designated to this rank, as digits (3 × [`ExactSum::LEN`] values)
    /// to be summed over the ranks and read by [`ContactInteraction::force_from_shares`].
    pub fn force_share(&self, range: std::ops::Range<usize>, out_digits: &mut [f64]) {
        let designated = &self.mask.designated;
        let mut sum: [ExactSum; 3] = Default::default();
        for (c, (out, hist)) in self.chunk_out.iter().zip(&self.hist).enumerate() {
            if out.is_empty() {
                continue;
            }
            let pairs = self.chunk_pairs(c);
            if designated[pairs.clone()].iter().all(|&d| d) {
                for &i in out {
                    add_force(
                        &mut sum,
                        pair_force_on(&hist[(i & !NEW_FLAG) as usize].out, &range),
                    );
                }
                continue;
            }
            // The touching pairs designated here, found through their history slots.
            let mut touching = vec![false; hist.len()];
            for &i in out {
                touching[(i & !NEW_FLAG) as usize] = true;
            }
            for k in pairs.filter(|&k| designated[k]) {
                let slot = self.slots[k];
                if slot.hist != NO_HISTORY && touching[slot.hist as usize] {
                    add_force(
                        &mut sum,
                        pair_force_on(&hist[slot.hist as usize].out, &range),
                    );
                }
            }
        }
        for (s, o) in sum.iter().zip(out_digits.chunks_exact_mut(ExactSum::LEN)) {
            s.digits(o);
        }
    }

    /// The candidate pairs of chunk `c` of stage 5.
    fn chunk_pairs(&self, c: usize) -> std::ops::Range<usize> {
        c * CHUNK..((c + 1) * CHUNK).min(self.slots.len())
    }

    /// [`ContactInteraction::force_on`] from the sum over ranks of their
    /// [`ContactInteraction::force_share`]s.
    pub fn force_from_shares(summed: &[f64]) -> Vec3 {
        Vec3::from_fn(|k, _| ExactSum::from_digits(&summed[k * ExactSum::LEN..]).value())
    }

    /// Largest mean contact pressure on each of `n_tets` tets in the last step [Pa] (zero
    /// where none).
    pub fn tet_pressures(&self, n_tets: usize) -> Vec<Real> {
        tet_pressures_of(self.outputs(), n_tets)
    }

    /// Contact is on and the mask is made for the pair list held (on a decomposed model: the
    /// rank holds only its own pairs, not the whole list shared). The same on every rank,
    /// so it may decide a collective.
    pub fn is_masked(&self) -> bool {
        self.is_enabled() && self.mask.is_for(self.slots.len())
    }

    /// The outputs of the last step's touching pairs designated to this rank (all of them
    /// on one process), each with its pair's key ([`pair_key`] of `pairs`, stage 4's list),
    /// in pair order: what rank 0 needs of this rank's pairs for a whole frame, put
    /// together there by key ([`node_forces_of`], [`tet_pressures_of`]).
    pub fn designated_outputs(&self, pairs: &[[u32; 2]]) -> Vec<(u64, PairOut)> {
        let designated = |k: usize| self.mask.designated.get(k).copied().unwrap_or(true);
        let mut mine = Vec::new();
        for (c, (out, hist)) in self.chunk_out.iter().zip(&self.hist).enumerate() {
            let mut touching = vec![false; hist.len()];
            for &i in out {
                touching[(i & !NEW_FLAG) as usize] = true;
            }
            for k in self.chunk_pairs(c).filter(|&k| designated(k)) {
                let slot = self.slots[k];
                if slot.hist != NO_HISTORY && touching[slot.hist as usize] {
                    mine.push((pair_key(pairs[k]), hist[slot.hist as usize].out));
                }
            }
        }
        mine
    }

    /// The history of candidate pair `k` (the default one when none is stored).
    pub fn pair_state(&self, k: usize) -> PairState {
        let s = self.slots[k];
        let mut st = if s.hist == NO_HISTORY {
            PairState::default()
        } else {
            self.hist[k / CHUNK][s.hist as usize]
        };
        st.witness = s.witness;
        st
    }

    /// The history of every candidate pair, in pair order.
    pub fn pair_states(&self) -> impl Iterator<Item = PairState> + '_ {
        (0..self.slots.len()).map(|k| self.pair_state(k))
    }

    /// The pairs that touched in the last step, with their geometry as of the last step and
    /// their penalty (for the bench's kernel figures).
    fn touching_pairs(
        &self,
        detection: &ContactDetection,
        tet_material: &[u32],
    ) -> Vec<(TetGeom, TetGeom, Real)> {
        let surface = &detection.surface;
        detection
            .pairs
            .iter()
            .enumerate()
            .filter(|&(k, _)| self.pair_state(k).touching)
            .filter_map(|(_, &[a, b])| {
                let (ea, eb) = (surface[a as usize], surface[b as usize]);
                let p = self
                    .laws
                    .props_of(tet_material[ea as usize], tet_material[eb as usize]);
                let geom = |s: u32| *self.geom.get(s as usize)?;
                Some((geom(a)?, geom(b)?, p.penalty))
            })
            .collect()
    }

    /// Single-thread cost of the stage 5 kernel on the pairs that touched in the last step
    /// (their geometry as of the last step), in ns per pair: the best of `repeats` passes,
    /// so it is a stable figure on a noisy machine. (touching pairs, ns per pair)
    pub fn kernel_ns_per_touching_pair(
        &self,
        detection: &ContactDetection,
        tet_material: &[u32],
        repeats: usize,
    ) -> (usize, f64) {
        let touching = self.touching_pairs(detection, tet_material);
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

    /// How far the kernel is from the test oracle ([`oracle`], the kernel before issue
    /// 14's speed work) on the pairs that touched in the last step: the largest, over the
    /// pairs, of max_i |F_i − F_i^oracle| / max_i |F_i^oracle| over the pair's 8 nodes; and
    /// Σ|E − E^oracle| / Σ|E^oracle| over the pairs (single pairs that barely touch differ
    /// more: both kernels' energy is accurate to ≈ ulp(H)·H/d² of itself for an overlap of
    /// depth d, and at rest under gravity d/H ≈ 1e-8 that is the energy's size).
    /// (force deviation, energy deviation)
    pub fn kernel_oracle_deviation(
        &self,
        detection: &ContactDetection,
        tet_material: &[u32],
    ) -> (f64, f64) {
        let (df, de, e) = self
            .touching_pairs(detection, tet_material)
            .iter()
            .map(|(c, t, p)| potential::deviation(c, t, *p))
            .fold((0.0 as Real, 0.0, 0.0), |a, b| {
                (a.0.max(b.0), a.1 + b.1, a.2 + b.2.abs())
            });
        (df, if de == 0.0 { 0.0 } else { de / e })
    }

    /// How far the kernel's result on each pair that touched in the last step moves when
    /// contactor and target swap roles (E and the forces are symmetric in them; the
    /// clipping and the cones are not, so this sees what the oracle, which shares them,
    /// cannot): (the largest over the pairs of max_i |F_i − F_i^swapped|, over the largest
    /// nodal force of all the pairs; Σ|E − E^swapped| / Σ|E|; the number of pairs with
    /// E < 0, which the exact energy never is; the most negative E over the largest |E|). (Over the model's largest force, not each
    /// pair's own: pairs that overlap by a rounding error, 1e-14 m, have forces of 1e-9 N
    /// that differ by 1e-4 of themselves.)
    pub fn kernel_swap_deviation(
        &self,
        detection: &ContactDetection,
        tet_material: &[u32],
    ) -> (f64, f64, usize, f64) {
        let (df, scale, de, e, negative, lowest, highest) = self
            .touching_pairs(detection, tet_material)
            .iter()
            .map(|(c, t, p)| potential::swap_deviation(c, t, *p))
            .fold(
                (
                    0.0 as Real,
                    0.0 as Real,
                    0.0,
                    0.0,
                    0,
                    0.0 as Real,
                    0.0 as Real,
                ),
                |a, b| {
                    (
                        a.0.max(b.0),
                        a.1.max(b.1),
                        a.2 + b.2,
                        a.3 + b.3.abs(),
                        a.4 + usize::from(b.3 < 0.0),
                        a.5.min(b.3),
                        a.6.max(b.3),
                    )
                },
            );
        (
            if df == 0.0 { 0.0 } else { df / scale },
            if de == 0.0 { 0.0 } else { de / e },
            negative,
            if lowest == 0.0 {
                0.0
            } else {
                lowest / highest.max(-lowest)
            },
        )
    }

    /// Bytes held by each stage 5 buffer (capacity), by name (for the bench).
    pub fn bytes_by_buffer(&self) -> serde_json::Value {
        use std::mem::size_of;
        let hist = |h: &Vec<Vec<PairState>>| {
            h.iter()
                .map(|h| h.capacity() * size_of::<PairState>())
                .sum::<usize>()
        };
        serde_json::json!({
            "slots": self.slots.capacity() * size_of::<PairSlot>(),
            "history": hist(&self.hist)
                + self.free.iter().map(|f| f.capacity() * 2).sum::<usize>(),
            "geometry": self.geom.capacity() * size_of::<Option<TetGeom>>()
                + self.current_boxes.capacity() * size_of::<Aabb>()
                + self.inv_h.capacity() * size_of::<Real>(),
            "outputs": self
                .chunk_out
                .iter()
                .map(|c| c.capacity() * 4)
                .sum::<usize>(),
        })
    }

    /// Bytes held by the stage 5 buffers (capacity).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.slots.capacity() * size_of::<PairSlot>()
            + self
                .hist
                .iter()
                .map(|h| h.capacity() * size_of::<PairState>())
                .sum::<usize>()
            + self.free.iter().map(|f| f.capacity() * 2).sum::<usize>()
            + self.geom.capacity() * size_of::<Option<TetGeom>>()
            + self.current_boxes.capacity() * size_of::<Aabb>()
            + self.inv_h.capacity() * size_of::<Real>()
            + self
                .chunk_out
                .iter()
                .map(|c| c.capacity() * 4)
                .sum::<usize>()
    }
}

/// Contact stiffness at a node of a tet for the critical step: (8/3)·p·max_k(A_k/H_k) [N/m],
/// the stiffest face of the tet in a thin overlap with an equal partner (a thin overlap under
/// face k is a spring k_n = 4pA_k(1/H_c + 1/H_t) ≤ 8pA_k/H_k for equal heights, a third per
/// face node). With ∇λ_k = g_k, H_k = 1/|g_k| and A_k = 3V|g_k|, so A_k/H_k = 3V|g_k|².
pub fn contact_nodal_stiffness(dm_inv: &Mat3, vol0: Real, p: Real) -> Real {
    let g1 = dm_inv.row(0).transpose();
    let g2 = dm_inv.row(1).transpose();
    let g3 = dm_inv.row(2).transpose();
    let g0 = -(g1 + g2 + g3);
    let g2max = [g0, g1, g2, g3]
        .iter()
        .map(|g| g.norm_squared())
        .fold(0.0, Real::max);
    8.0 / 3.0 * p * 3.0 * vol0.abs() * g2max
}

/// What every pair of one step reads.
struct StepInputs<'a> {
    surface: &'a [u32],
    pairs: &'a [[u32; 2]],
    geom: &'a Held<Option<TetGeom>>,
    boxes: &'a Held<Aabb>,
    inv_h: &'a Held<Real>,
    laws: &'a ContactLaws,
    tet_mass: &'a [Real],
    tet_nodes: &'a [[u32; 4]],
    tet_material: &'a [u32],
    v: &'a [Vec3],
    /// Stage 2's broken joints that still hold their faces (indexed by joint).
    joint_keeps: &'a [bool],
    dt_prev: Real,
    time: Real,
}

/// Stage 5: add the contact and friction forces of every touching candidate pair of stage 4
/// to `nodes.f`. `dt_prev` is the last step (Δx = v·dt_prev for the friction springs).
/// `joint_keeps`: the broken joints that still hold their faces
/// ([`crate::joints::Joints::keeps_faces`]; their pairs do not arm).
pub fn add_contact_forces(
    ci: &mut ContactInteraction,
    detection: &ContactDetection,
    nodes: &mut Nodes,
    tets: &Tets,
    joint_keeps: &[bool],
    dt_prev: Real,
    time: Real,
) -> ContactSums {
    let needed = std::mem::take(&mut ci.mask.surface);
    let decomposed = ci.mask.decomposed;
    size_surface_geometry(
        ci,
        decomposed.then_some(&needed[..]),
        detection.surface.len(),
    );
    update_surface_geometry(
        ci,
        decomposed.then_some(&needed[..]),
        &detection.surface,
        &tets.nodes,
        &nodes.x,
    );
    ci.mask.surface = needed;
    // Checkpoints leave the records out: one list per chunk again after a restart.
    let n_chunks = ci.hist.len();
    ci.chunk_records.resize_with(n_chunks, Vec::new);
    let ContactInteraction {
        laws,
        slots,
        hist,
        free,
        record_events,
        tet_mass,
        geom,
        current_boxes,
        inv_h,
        chunk_out,
        chunk_handover,
        chunk_records,
        mask,
        ..
    } = ci;
    let inputs = StepInputs {
        surface: &detection.surface,
        pairs: &detection.pairs,
        geom,
        boxes: current_boxes,
        inv_h,
        laws,
        tet_mass,
        tet_nodes: &tets.nodes,
        tet_material: &tets.material,
        v: &nodes.v,
        joint_keeps,
        dt_prev,
        time,
    };
    let record_events = *record_events;
    let masked = mask.decomposed;
    // The tallies are exact sums: any split of the chunks among threads gives their bits.
    let tally = slots
        .par_chunks_mut(CHUNK)
        .zip(hist.par_iter_mut())
        .zip(free.par_iter_mut())
        .zip(chunk_out.par_iter_mut())
        .zip(chunk_handover.par_iter_mut())
        .zip(chunk_records.par_iter_mut())
        .enumerate()
        .fold(
            ContactTally::default,
            |mut tally, (c, (((((slots, hist), free), out), handover), records))| {
                let chunk = Chunk {
                    slots,
                    hist,
                    free,
                    out,
                    tally: &mut tally,
                    handover,
                    records,
                };
                evaluate_chunk(&inputs, c, chunk, mask, record_events);
                tally
            },
        )
        .reduce(ContactTally::default, |mut a, b| {
            a.merge(&b);
            a
        });
    if masked {
        // Forces only: the totals, events and handovers come from every rank's tallies
        // and records.
        scatter_forces(ci, nodes);
        ci.tally = tally;
        return ContactSums::default();
    }
    scatter_in_pair_order(ci, nodes, &tally, time)
}

/// Contact force on each of `n_nodes` nodes [N] from the touching pairs' `outputs`, summed
/// in the order given (pair order, for the same bits as one process).
pub fn node_forces_of<'a>(outputs: impl Iterator<Item = &'a PairOut>, n_nodes: usize) -> Vec<Vec3> {
    let mut f = vec![Vec3::zeros(); n_nodes];
    for po in outputs {
        for (k, &n) in po.nodes.iter().enumerate() {
            if let Some(x) = f.get_mut(n as usize) {
                *x += po.f[k];
            }
        }
    }
    f
}

/// Largest mean contact pressure on each of `n_tets` tets [Pa] over the touching pairs'
/// `outputs` (zero where none).
pub fn tet_pressures_of<'a>(
    outputs: impl Iterator<Item = &'a PairOut>,
    n_tets: usize,
) -> Vec<Real> {
    let mut p: Vec<Real> = vec![0.0; n_tets];
    for po in outputs {
        for &e in &po.tets {
            if let Some(x) = p.get_mut(e as usize) {
                *x = Real::max(*x, po.pressure);
            }
        }
    }
    p
}

/// Add a force's components to exact sums.
#[inline]
fn add_force(sum: &mut [ExactSum; 3], f: Vec3) {
    for k in 0..3 {
        sum[k].add(f[k]);
    }
}

/// A touching pair's force on the nodes in `range`, its nodes in order.
fn pair_force_on(po: &PairOut, range: &std::ops::Range<usize>) -> Vec3 {
    let mut f = Vec3::zeros();
    for (k, &n) in po.nodes.iter().enumerate() {
        if range.contains(&(n as usize)) {
            f += po.f[k];
        }
    }
    f
}

/// One chunk of stage 5's pairs and its per-step outputs.
struct Chunk<'a> {
    slots: &'a mut [PairSlot],
    hist: &'a mut Vec<PairState>,
    free: &'a mut Vec<u16>,
    out: &'a mut Vec<u32>,
    /// The pairs' totals (on a decomposed model, of the pairs designated to this rank).
    tally: &'a mut ContactTally,
    handover: &'a mut Vec<u32>,
    records: &'a mut Vec<PairRecord>,
}

/// Evaluate the pairs of chunk `c` (those `mask` gives this rank, all on one rank): forces
/// into their histories and the chunk's outputs, handovers and (for designated pairs of a
/// decomposed model) records; their totals into the tally.
fn evaluate_chunk(
    inputs: &StepInputs,
    c: usize,
    chunk: Chunk,
    mask: &PairMask,
    record_events: bool,
) {
    let Chunk {
        slots: sl,
        hist,
        free,
        out,
        tally,
        handover,
        records,
    } = chunk;
    let masked = mask.decomposed;
    out.clear();
    handover.clear();
    records.clear();
    // Slots of the compiled friction laws (on the stack, reused by every pair).
    let mut frame = Frame::new();
    for (k, slot) in sl.iter_mut().enumerate() {
        let pi = c * CHUNK + k;
        if slot.hist == NO_HISTORY {
            // No history: armed and not touching. Rejected pairs (most candidates,
            // most steps) only update their witness.
            match reject(inputs, pi, slot.witness) {
                Rejection::Apart(axis) => {
                    if slot.witness != axis {
                        slot.witness = axis;
                    }
                    continue;
                }
                Rejection::Degenerate => continue,
                Rejection::Maybe => {}
            }
        }
        let mut ps = if slot.hist == NO_HISTORY {
            PairState::default()
        } else {
            hist[slot.hist as usize]
        };
        ps.witness = slot.witness;
        let mut flag = 0;
        // The pair's own contributions first (the same bits on any rank that computes
        // it), then added exactly to the tally.
        let mut pair_sums = ContactSums::default();
        let handed = handover.len();
        let touches =
            if let Some(po) = interact(inputs, pi, &mut ps, &mut pair_sums, handover, &mut frame) {
                if !ps.touching && record_events {
                    // Reported in pair order below.
                    flag = NEW_FLAG;
                }
                ps.touching = true;
                ps.out = po;
                true
            } else {
                false
            };
        let designated = !masked || mask.designated[pi];
        if designated && pair_sums != ContactSums::default() {
            tally.add_pair(pair_key(inputs.pairs[pi]), &pair_sums);
        }
        if masked && designated {
            let record = PairRecord {
                pair: pair_key(inputs.pairs[pi]),
                handover: handover.get(handed).copied(),
                event: (flag != 0).then_some(ContactEvent {
                    time: inputs.time,
                    tets: ps.out.tets,
                    point: ps.out.point,
                }),
                law_failure: pair_sums.law_failure,
            };
            if record.handover.is_some() || record.event.is_some() || record.law_failure.is_some() {
                records.push(record);
            }
        }
        slot.witness = ps.witness;
        if ps.needs_history() {
            if slot.hist == NO_HISTORY {
                slot.hist = match free.pop() {
                    Some(h) => h,
                    None => {
                        // Grow by an eighth, not double: the histories are most
                        // of stage 5's memory.
                        if hist.len() == hist.capacity() {
                            hist.reserve_exact(hist.len() / 8 + 8);
                        }
                        hist.push(ps);
                        (hist.len() - 1) as u16
                    }
                };
            }
            hist[slot.hist as usize] = ps;
            if touches {
                out.push(slot.hist as u32 | flag);
            }
        } else if slot.hist != NO_HISTORY {
            free.push(slot.hist);
            slot.hist = NO_HISTORY;
        }
    }
}

/// Add the touching pairs' forces to the nodes in pair order (deterministic for any thread
/// count), record new-contact events, collect the handed-over joints and the step's sums.
fn scatter_in_pair_order(
    ci: &mut ContactInteraction,
    nodes: &mut Nodes,
    tally: &ContactTally,
    time: Real,
) -> ContactSums {
    scatter_forces(ci, nodes);
    for (out, hist) in ci.chunk_out.iter().zip(ci.hist.iter()) {
        for &i in out {
            if i & NEW_FLAG != 0 {
                let po = &hist[(i & !NEW_FLAG) as usize].out;
                ci.events.push(ContactEvent {
                    time,
                    tets: po.tets,
                    point: po.point,
                });
            }
        }
    }
    ci.handover.clear();
    for h in ci.chunk_handover.iter() {
        ci.handover.extend_from_slice(h);
    }
    ci.close_step(tally.sums(), time)
}

/// Add the forces of the pairs that touched in this step to their nodes, in pair order.
fn scatter_forces(ci: &ContactInteraction, nodes: &mut Nodes) {
    for (out, hist) in ci.chunk_out.iter().zip(ci.hist.iter()) {
        for &i in out {
            let po = &hist[(i & !NEW_FLAG) as usize].out;
            for k in 0..8 {
                nodes.f[po.nodes[k] as usize] += po.f[k];
            }
        }
    }
}

impl ContactInteraction {
    /// The step's totals are `total`: keep them and the deepest penetration so far.
    fn close_step(&mut self, total: ContactSums, time: Real) -> ContactSums {
        self.last = total;
        if total.max_overlap_ratio > self.deepest.ratio {
            self.deepest = DeepestOverlap {
                ratio: total.max_overlap_ratio,
                depth: total.max_overlap,
                time,
            };
        }
        total
    }

    /// The records this rank sends to close a decomposed step, in pair order (every rank
    /// then applies all ranks', [`ContactInteraction::apply_records`]).
    pub fn records_to_send(&self) -> Vec<PairRecord> {
        self.chunk_records.iter().flatten().copied().collect()
    }

    /// This rank's tally of its designated pairs in the last step (a decomposed model).
    pub fn rank_tally(&self) -> &ContactTally {
        &self.tally
    }

    /// A decomposed model's step, closed from the tally of every rank's pairs and the
    /// records of every pair (`records`, from all ranks, in pair order): events and
    /// handovers in pair order, what one rank gets.
    pub fn apply_records(
        &mut self,
        tally: &ContactTally,
        records: &[PairRecord],
        time: Real,
    ) -> ContactSums {
        self.handover.clear();
        for r in records {
            self.handover.extend(r.handover);
            self.events.extend(r.event);
        }
        self.close_step(tally.sums(), time)
    }

    /// On a decomposed model, the witness and history of every pair designated to this
    /// rank, as it holds them, from stage 4's list `pairs` ([`DesignatedStates`]).
    pub fn designated_states(&self, pairs: &[[u32; 2]]) -> DesignatedStates {
        let mut out = DesignatedStates::default();
        let designated = |k: &usize| self.mask.designated.get(*k).copied().unwrap_or(true);
        for k in (0..self.slots.len()).filter(designated) {
            let s = self.slots[k];
            if s.hist != NO_HISTORY {
                let place = out.keys.len() as u32;
                out.histories
                    .push((place, self.hist[k / CHUNK][s.hist as usize]));
            }
            out.keys.push((pair_key(pairs[k]), s.witness));
        }
        out
    }

    /// Replace every pair's witness and history (`states`: one per candidate pair of a list
    /// of `n` pairs, in pair order) and lay the histories out afresh in pair order; the
    /// outputs of the last step are those of the touching pairs. The forces a later step
    /// computes do not depend on the layout. The list's mask goes (a decomposed model makes
    /// it again for the pairs of the next step).
    pub fn set_states(&mut self, n: usize, states: impl Iterator<Item = (u8, Option<PairState>)>) {
        self.slots.clear();
        self.slots.resize(n, PairSlot::default());
        self.mask = PairMask::default();
        let n_chunks = self.slots.len().div_ceil(CHUNK);
        self.hist.iter_mut().for_each(Vec::clear);
        self.free.iter_mut().for_each(Vec::clear);
        self.chunk_out.iter_mut().for_each(Vec::clear);
        self.hist.resize_with(n_chunks, Vec::new);
        self.free.resize_with(n_chunks, Vec::new);
        self.chunk_out.resize_with(n_chunks, Vec::new);
        for (k, (witness, state)) in states.enumerate() {
            let slot = &mut self.slots[k];
            slot.witness = witness;
            slot.hist = NO_HISTORY;
            if let Some(s) = state {
                let h = &mut self.hist[k / CHUNK];
                slot.hist = h.len() as u16;
                if s.touching {
                    self.chunk_out[k / CHUNK].push(slot.hist as u32);
                }
                h.push(s);
            }
        }
    }
}

/// The per-surface-tet geometry arrays for `n_surface` surface tets: every one's, or only
/// those `needed` (a decomposed model's rank; packed again when its list changed).
fn size_surface_geometry(ci: &mut ContactInteraction, needed: Option<&[u32]>, n_surface: usize) {
    let no_box = Aabb::of_points(&[Vec3::zeros()]);
    match needed {
        Some(needed) => {
            if ci.geom.is_whole() || ci.geom_for != needed {
                ci.geom = Held::of_ids(n_surface, needed, None);
                ci.current_boxes = Held::of_ids(n_surface, needed, no_box);
                ci.inv_h = Held::of_ids(n_surface, needed, 0.0);
                ci.geom_for = needed.to_vec();
            }
        }
        None => {
            if !ci.geom.is_whole() {
                (ci.geom, ci.current_boxes, ci.inv_h) = Default::default();
                ci.geom_for = Vec::new();
            }
            ci.geom.resize(n_surface, None);
            ci.current_boxes.resize(n_surface, no_box);
            ci.inv_h.resize(n_surface, 0.0);
        }
    }
}

/// Current geometry, box and 1/(smallest height) of the surface tets (only those `needed`,
/// when given: a decomposed model's rank reads only the tets of its pairs), in one pass.
fn update_surface_geometry(
    ci: &mut ContactInteraction,
    needed: Option<&[u32]>,
    surface: &[u32],
    tet_nodes: &[[u32; 4]],
    x: &[Vec3],
) {
    let of = |e: u32| {
        let xs = tet_nodes[e as usize].map(|n| x[n as usize]);
        let g = TetGeom::new(xs);
        let ih = g.as_ref().map_or(0.0, |g| {
            g.height
                .iter()
                .fold(Real::INFINITY, |a, &h| a.min(h))
                .recip()
        });
        (Aabb::of_points(&xs), g, ih)
    };
    if let Some(needed) = needed {
        let fresh: Vec<(Aabb, Option<TetGeom>, Real)> = needed
            .par_iter()
            .with_min_len(256)
            .map(|&s| of(surface[s as usize]))
            .collect();
        for (&s, (bx, g, ih)) in needed.iter().zip(fresh) {
            let s = s as usize;
            (ci.current_boxes[s], ci.geom[s], ci.inv_h[s]) = (bx, g, ih);
        }
        return;
    }
    ci.geom
        .as_mut_slice()
        .par_iter_mut()
        .zip(ci.current_boxes.as_mut_slice().par_iter_mut())
        .zip(ci.inv_h.as_mut_slice().par_iter_mut())
        .zip(surface.par_iter())
        .enumerate()
        .with_min_len(256)
        .for_each(|(s, (((g, bx), ih), &e))| {
            // The surface tets of a large body are scattered through the node arrays (its
            // spatial order, `mesh::order`): fetch the nodes of the tet 8 ahead meanwhile.
            #[cfg(target_arch = "x86_64")]
            if let Some(&ahead) = surface.get(s + 8) {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                for n in tet_nodes[ahead as usize] {
                    // SAFETY: a prefetch is a hint and never faults (`wrapping_add`: no in-bounds claim).
                    unsafe {
                        _mm_prefetch::<_MM_HINT_T0>(
                            x.as_ptr().wrapping_add(n as usize).cast::<i8>(),
                        )
                    };
                }
            }
            (*bx, *g, *ih) = of(e);
        });
}

/// A touching pair as the tangential forces see it.
struct Overlap<'a> {
    r: &'a potential::PairForces,
    gc: &'a TetGeom,
    gt: &'a TetGeom,
    /// Nodes of the contactor and of the target.
    nodes: ([u32; 4], [u32; 4]),
    tets: [u32; 2],
    /// 1/(smallest height) of the contactor and of the target [1/m].
    inv_h: (Real, Real),
    /// Normal force on the contactor [N] and its magnitude.
    f_normal: Vec3,
    fn_mag: Real,
}

/// The normal dashpot and Coulomb friction of a touching pair at its contact point: adds
/// their forces to `f` (contactor's 4 nodes, then the target's), books their dissipation in
/// `sums` and returns the energy stored in the friction spring [J].
#[inline(always)]
fn friction_and_damping(
    inp: &StepInputs,
    pr: &ContactProps,
    o: &Overlap,
    ps: &mut PairState,
    sums: &mut ContactSums,
    frame: &mut Frame,
    f: &mut [Vec3; 8],
) -> Real {
    let (r, (na, nb), [ea, eb]) = (o.r, o.nodes, o.tets);
    let n = o.f_normal / o.fn_mag;
    let nc = o.gc.bary(&r.point);
    let nt = o.gt.bary(&r.point);
    let mut dv = Vec3::zeros();
    for i in 0..4 {
        dv += inp.v[na[i] as usize] * nc[i] - inp.v[nb[i] as usize] * nt[i];
    }
    // k_n/3 per unit penalty: the thin-overlap stiffness of one face node. The friction spring
    // and the dashpot act at one point, so one node can feel all of them; sized per node they
    // stay within the critical time step.
    let stiff = 4.0 / 3.0 * r.area * (o.inv_h.0 + o.inv_h.1);
    let mut fx = Vec3::zeros();
    // Normal dashpot first: Coulomb acts on the whole normal force.
    let mut normal = o.fn_mag;
    if pr.damping > 0.0 {
        let masses = (inp.tet_mass[ea as usize], inp.tet_mass[eb as usize]);
        let fd = friction::normal_dashpot(pr, stiff, masses, &n, &dv, o.fn_mag);
        fx += n * fd;
        normal += fd;
    }
    let du = dv * inp.dt_prev;
    let mut e_spring = 0.0;
    if pr.has_friction() {
        let touch = friction::Touch {
            n,
            dv,
            du,
            normal,
            stiff,
            area: r.area,
            point: r.point,
            tets: [ea, eb],
            time: inp.time,
            laws: &inp.laws.friction_laws,
        };
        let ft = friction::coulomb_friction(pr, ps, &touch, frame, sums);
        e_spring = 0.5 * ft.norm_squared() / (pr.tangential_penalty * stiff);
        sums.friction_force += ft.norm();
        fx += ft;
    } else {
        ps.spring = Vec3::zeros();
    }
    // Dissipated = −(work of these forces) − (change of the spring energy), the work in the
    // central difference's trapezoid form ½(f_{n−1} + f_n)·Δu_n.
    sums.dissipated += -0.5 * (ps.f_prev + fx).dot(&du) - (e_spring - ps.e_prev);
    ps.f_prev = fx;
    ps.e_prev = e_spring;
    for i in 0..4 {
        f[i] += fx * nc[i];
        f[4 + i] -= fx * nt[i];
    }
    e_spring
}

/// The cheap tests of a candidate pair, in order: current boxes, degenerate geometry, the
/// separating axes starting with the witness.
enum Rejection {
    /// The elements do not overlap; the separating axis found (the old witness when the
    /// boxes were apart).
    Apart(u8),
    /// A degenerate element: no contact.
    Degenerate,
    /// Possibly overlapping: the kernel decides.
    Maybe,
}

#[inline(always)]
fn reject(inp: &StepInputs, pi: usize, witness: u8) -> Rejection {
    let [a, b] = inp.pairs[pi];
    if !inp.boxes[a as usize].overlaps(&inp.boxes[b as usize]) {
        return Rejection::Apart(witness);
    }
    let (Some(gc), Some(gt)) = (&inp.geom[a as usize], &inp.geom[b as usize]) else {
        return Rejection::Degenerate;
    };
    match separating_axis(gc, gt, witness) {
        Some(axis) => Rejection::Apart(axis),
        None => Rejection::Maybe,
    }
}

/// One candidate pair `pi` in one step: rejection (boxes, then the witness axis), arming,
/// the potential force, friction and damping. Returns the forces of a touching pair; updates
/// its history, `sums` and `handover`.
#[inline(always)]
fn interact(
    inp: &StepInputs,
    pi: usize,
    ps: &mut PairState,
    sums: &mut ContactSums,
    handover: &mut Vec<u32>,
    frame: &mut Frame,
) -> Option<PairOut> {
    let [a, b] = inp.pairs[pi];
    // Separated (most candidates, most steps): one plane test on the witness axis.
    match reject(inp, pi, ps.witness) {
        Rejection::Apart(axis) => {
            ps.witness = axis;
            let held = !ps.armed && ps.joint_keeps_faces(inp.joint_keeps);
            ps.apart(sums, handover, held);
            return None;
        }
        Rejection::Degenerate => {
            ps.release(sums);
            return None;
        }
        Rejection::Maybe => {}
    }
    let (Some(gc), Some(gt)) = (&inp.geom[a as usize], &inp.geom[b as usize]) else {
        return None; // (reject() answered Degenerate for these)
    };
    let (ea, eb) = (inp.surface[a as usize], inp.surface[b as usize]);
    let pr = inp
        .laws
        .props_of(inp.tet_material[ea as usize], inp.tet_material[eb as usize]);
    let r = overlapping_tet_tet(gc, gt, pr.penalty);
    // Not overlapping after all (an edge–edge separation): all axes next step.
    ps.witness = if r.touching { OVERLAPPED } else { 0 };
    if !ps.armed {
        // Armed once there is no overlap energy to release (exactly touching faces, e.g.
        // blocks that start face to face, arm at once).
        let scale = pr.penalty * gc.volume.abs().min(gt.volume.abs());
        if (!r.touching || r.energy <= 1e-12 * scale) && !ps.joint_keeps_faces(inp.joint_keeps) {
            ps.armed = true;
            if ps.joint != u32::MAX {
                handover.push(ps.joint);
            }
        }
        if !ps.armed {
            return None;
        }
    }
    if !r.touching {
        ps.release(sums);
        return None;
    }
    let (inv_ha, inv_hb) = (inp.inv_h[a as usize], inp.inv_h[b as usize]);
    sums.max_overlap = sums.max_overlap.max(r.depth);
    sums.max_overlap_ratio = sums.max_overlap_ratio.max(r.depth * inv_ha.max(inv_hb));
    let mut f = [Vec3::zeros(); 8];
    f[..4].copy_from_slice(&r.fc);
    f[4..].copy_from_slice(&r.ft);
    let f_normal: Vec3 = r.fc.iter().sum();
    let fn_mag = f_normal.norm();
    let mut energy = r.energy;
    let (na, nb) = (inp.tet_nodes[ea as usize], inp.tet_nodes[eb as usize]);
    if (pr.has_friction() || pr.damping > 0.0) && fn_mag > 0.0 {
        let touch = Overlap {
            r: &r,
            gc,
            gt,
            nodes: (na, nb),
            tets: [ea, eb],
            inv_h: (inv_ha, inv_hb),
            f_normal,
            fn_mag,
        };
        let e_spring = friction_and_damping(inp, &pr, &touch, ps, sums, frame, &mut f);
        if pr.has_friction() {
            energy += e_spring;
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
    sums.area += r.area;
    Some(PairOut {
        tets: [ea, eb],
        nodes: [na[0], na[1], na[2], na[3], nb[0], nb[1], nb[2], nb[3]],
        f,
        point: r.point,
        pressure: fn_mag / r.area,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One candidate pair from stage 4 and stage 5's state for it.
    struct Fixture {
        cd: ContactDetection,
        ci: ContactInteraction,
        nodes: Nodes,
        tets: Tets,
    }

    /// A target tet with its face z = 0 on top and a contactor whose bottom face sinks 1 mm
    /// into it, friction μ = 0.5 (nodes 0–3 target, 4–7 contactor).
    fn two_tets() -> Fixture {
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
        let mut ci = ContactInteraction::default();
        ci.laws.rules.push(ContactRule::from(PotentialContact {
            penalty: Some(1e6),
            friction: 0.5,
            ..Default::default()
        }));
        ci.laws.resolve(&[1e5]);
        ci.tet_mass = vec![1.0, 1.0];
        let mut cd = ContactDetection::default();
        cd.surface = vec![0, 1];
        cd.pairs = vec![[1, 0]];
        let new = PairOrigin::New {
            neighbours: false,
            joint: u32::MAX,
        };
        ci.carry_history(vec![new]);
        let tets = Tets {
            nodes: vec![[0, 1, 2, 3], [4, 5, 6, 7]],
            material: vec![0, 0],
            ..Default::default()
        };
        Fixture {
            cd,
            ci,
            nodes,
            tets,
        }
    }

    /// Move the contactor by `d` per step for `steps` steps (velocity d/dt, as the central
    /// difference gives it to stage 5).
    fn slide(fx: &mut Fixture, d: Vec3, steps: usize) {
        let dt = 1e-3;
        for _ in 0..steps {
            for n in 4..8 {
                fx.nodes.x[n] += d;
                fx.nodes.v[n] = d / dt;
            }
            add_contact_forces(&mut fx.ci, &fx.cd, &mut fx.nodes, &fx.tets, &[], dt, 0.0);
            fx.nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
        }
    }

    /// `slip` is the path length of the tangential relative motion, not the net displacement:
    /// 10 steps of +0.1 mm and 10 of −0.1 mm along x give 2 mm (to 1e-9: the overlap is
    /// planar, so the contact normal is z and every step is tangential), with the contactor back
    /// where it started; a normal motion adds nothing; the slip is 0 once the pair releases.
    #[test]
    fn slip_accumulates_the_path_length_and_resets_on_release() {
        let mut fx = two_tets();
        let dx = Vec3::new(1e-4, 0.0, 0.0);
        slide(&mut fx, dx, 10);
        let forth = fx.ci.pair_state(0).slip;
        slide(&mut fx, -dx, 10);
        let back = fx.ci.pair_state(0).slip;
        println!("slip after 10 steps forth {forth:e} m, and back {back:e} m");
        assert!(fx.ci.pair_state(0).touching);
        assert!((forth - 1e-3).abs() < 1e-9 * 1e-3, "{forth:e}");
        assert!((back - 2e-3).abs() < 1e-9 * 2e-3, "{back:e}");
        assert!((fx.nodes.x[4] - fx.nodes.x0[4]).norm() < 1e-15);
        slide(&mut fx, Vec3::new(0.0, 0.0, -1e-5), 5);
        assert!(
            (fx.ci.pair_state(0).slip - back).abs() < 1e-9 * back,
            "normal motion is no slip"
        );
        // Lift the contactor off: the pair releases and its slip path starts again from 0.
        slide(&mut fx, Vec3::new(0.0, 0.0, 1e-2), 1);
        assert!(!fx.ci.pair_state(0).touching);
        assert_eq!(fx.ci.pair_state(0).slip, 0.0);
        // Released and armed: no history is stored; the freed entry is reused when the pair
        // touches again.
        assert_eq!(fx.ci.slots[0].hist, NO_HISTORY);
        assert_eq!(fx.ci.free[0], vec![0]);
        slide(&mut fx, Vec3::new(0.0, 0.0, -1e-2), 1);
        assert!(fx.ci.pair_state(0).touching);
        assert_eq!((fx.ci.slots[0].hist, fx.ci.hist[0].len()), (0, 1));
        assert!(fx.ci.free[0].is_empty());
    }
}
