//! The simulation state and the time step: the seven stages of Munjiza's FEM/DEM in order,
//! each a free function of exactly the arrays it reads and writes, each timed.
//!
//! Building the model is here (`add_material`, `add_body`, selections); edits between runs
//! (moving bodies, constraints, loads) are in `edit.rs`, read-only queries of the state
//! (energies, means over node sets, stresses, body masses, boundary faces) in `queries.rs`.

mod edit;
mod measurements;
mod queries;
mod reinforcement;

pub use measurements::{axis_index, Bounds, Configuration};
pub use reinforcement::RebarSpec;
mod rigid;

use crate::contact_detection::{self, ContactDetection};
use crate::contact_interaction::{self, ContactInteraction};
use crate::elements::{self, ElementsWorkspace};
use crate::integration::{self, IntegrationSums, StepParams};
use crate::loads::{self, Loads};
use crate::material::{Formulation, Material};
use crate::math::{Real, Vec3};
use crate::mesh::{boundary_faces, BoundaryFace, Mesh, Region};
use crate::state::{Bars, Body, Layout, MaterialId, Nodes, Rebar, Tets};
use rayon::prelude::*;
use std::time::Instant;

/// The seven stages of a time step (Munjiza 2004), in execution order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    Elements,
    Joints,
    Fracture,
    ContactDetection,
    ContactInteraction,
    ExternalLoads,
    Integration,
}

impl Stage {
    pub const ALL: [Stage; 7] = [
        Stage::Elements,
        Stage::Joints,
        Stage::Fracture,
        Stage::ContactDetection,
        Stage::ContactInteraction,
        Stage::ExternalLoads,
        Stage::Integration,
    ];
    /// Module name of the stage (also its key in timing tables and `fdem bench` JSON).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Elements => "elements",
            Stage::Joints => "joints",
            Stage::Fracture => "fracture",
            Stage::ContactDetection => "contact_detection",
            Stage::ContactInteraction => "contact_interaction",
            Stage::ExternalLoads => "external_loads",
            Stage::Integration => "integration",
        }
    }
}

/// Accumulated wall time per stage.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct StageTimers {
    pub seconds: [f64; 7],
}

impl StageTimers {
    pub fn get(&self, s: Stage) -> f64 {
        self.seconds[s as usize]
    }
    pub fn total(&self) -> f64 {
        self.seconds.iter().sum()
    }
}

/// Running energy account [J]. Balance: kinetic + strain + dissipated = initial + external work.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    pub kinetic: Real,
    pub strain: Real,
    /// Work of gravity Σ m g·(x − X).
    pub gravity_work: Real,
    /// Work of nodal forces and tractions.
    pub force_work: Real,
    /// Work of the constraints (fixed and prescribed-velocity nodes, base motions).
    pub reaction_work: Real,
    /// Work of the relative-frame ground-motion body force −m·a_g(t) (the earthquake's
    /// input in the relative frame; under a base motion that input is reaction work).
    pub ground_work: Real,
    /// Dissipated by mass-proportional damping.
    pub mass_damping: Real,
    /// Dissipated by viscous (η·D) element damping.
    pub viscous_damping: Real,
    /// Recoverable energy of the joints.
    pub joint: Real,
    /// Dissipated by joint damage and friction on broken joints (fracture).
    pub fracture: Real,
    /// Recoverable contact energy: penalty energy p∫(φ_c + φ_t) and friction springs.
    pub contact: Real,
    /// Dissipated by contact friction.
    pub friction: Real,
    /// Dissipated by steel: plastic work of the bars and the elastic energy of ruptured bars.
    pub plastic: Real,
    /// Recoverable energy of the bond between bars and their host.
    pub bond: Real,
    /// Dissipated by bond slip.
    pub bond_slip: Real,
    /// Kinetic + strain energy at the first step.
    pub initial: Real,
    /// The least scale of the relative balance error: the elastic energy of the whole model at
    /// a strain of [`Energy::FLOOR_STRAIN`] ([`Energy::floor_of`]). Not a term of the balance.
    pub floor: Real,
}

impl Energy {
    /// A relative balance error beyond this (1 % of the largest term) is reported: `fdem run`
    /// warns when a sample first passes it and repeats the warning in the end-of-run
    /// summary. Sound runs close to 1e-4 or better (docs/validation.md); 1 % means some
    /// energy is created or lost that no term books.
    pub const WARNING_THRESHOLD: Real = 0.01;

    /// The strain of [`Energy::floor_of`]: 1e-7, far below any strain a model is run for,
    /// far above the roundoff of positions (1e-16 relative) a model at rest is left with.
    pub const FLOOR_STRAIN: Real = 1e-7;

    /// The floor of the relative balance error's scale, ½·Σ E·V₀·ε² with ε =
    /// [`Energy::FLOOR_STRAIN`]: the elastic energy of the whole model at a uniform strain of
    /// 1e-7, from `young_volume` = Σ E·V₀ over its deformable elements [N·m]. A model at rest
    /// (or at its first samples) holds energies of roundoff size, and its balance error over
    /// them is noise of order 1: against this floor it reads as the tiny number it is.
    pub fn floor_of(young_volume: Real) -> Real {
        0.5 * young_volume * Self::FLOOR_STRAIN * Self::FLOOR_STRAIN
    }

    /// The relative balance error passes [`Energy::WARNING_THRESHOLD`].
    pub fn balance_is_off(&self) -> bool {
        self.relative_balance_error().abs() > Self::WARNING_THRESHOLD
    }

    pub fn external_work(&self) -> Real {
        self.gravity_work + self.force_work + self.reaction_work + self.ground_work
    }
    pub fn dissipated(&self) -> Real {
        self.mass_damping
            + self.viscous_damping
            + self.fracture
            + self.friction
            + self.plastic
            + self.bond_slip
    }
    /// (kinetic + strain + joint + contact + bond + dissipated) − (initial + external work) [J].
    pub fn balance_error(&self) -> Real {
        self.kinetic + self.strain + self.joint + self.contact + self.bond + self.dissipated()
            - (self.initial + self.external_work())
    }
    /// The scale of the relative balance error: the largest energy in the account, or the
    /// floor ([`Energy::floor_of`]) when that is larger.
    pub fn balance_scale(&self) -> Real {
        [
            self.kinetic,
            self.strain,
            self.joint,
            self.contact,
            self.bond,
            self.initial,
            self.gravity_work.abs(),
            self.force_work.abs(),
            self.reaction_work.abs(),
            self.ground_work.abs(),
            self.dissipated(),
            self.floor,
        ]
        .into_iter()
        .fold(0.0, Real::max)
    }

    /// What [`Energy::balance_scale`] is, for messages: "the largest term", or the floor when
    /// every term is smaller.
    pub fn scale_name(&self) -> &'static str {
        if self.floor > 0.0 && self.balance_scale() == self.floor {
            "the floor, the model's elastic energy at a strain of 1e-7"
        } else {
            "the largest term"
        }
    }

    /// Balance error relative to [`Energy::balance_scale`] (the largest energy in the account,
    /// at least the floor); 0 when every term is 0.
    pub fn relative_balance_error(&self) -> Real {
        let scale = self.balance_scale();
        if scale > 0.0 {
            self.balance_error() / scale
        } else {
            0.0
        }
    }
}

/// One row of the energy history.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct EnergySample {
    pub step: u64,
    pub time: Real,
    pub energy: Energy,
}

/// How the time step was chosen.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct TimeStepInfo {
    pub dt: Real,
    pub critical: Real,
    pub safety: Real,
    /// Element that sets the critical step, its body and its centroid where it is when the
    /// step is chosen (current positions).
    pub tet: usize,
    pub body: String,
    pub centroid: Vec3,
    /// True when the user fixed dt.
    pub fixed: bool,
    /// With joints: the node whose joint springs are stiffest and the critical step of the
    /// tetrahedra alone.
    pub joints: Option<(usize, Real)>,
    /// The contact penalty lowered the critical step.
    pub contact: bool,
    /// Where the contact bound comes from, when contact lowered the step.
    #[serde(default)]
    pub contact_by: Option<ContactLimit>,
}

/// The tet whose contact springs bound the step, as the run's time-step line names it: a
/// light body given a stiff penalty against a material it may never meet shows here.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct ContactLimit {
    pub tet: usize,
    pub body: String,
    /// A body of the partner material (the first in body order).
    pub partner_body: String,
    /// The penalty of the tet's material against it [Pa].
    pub penalty: Real,
    /// The critical step without the contact springs [s].
    pub without: Real,
}

impl std::fmt::Display for TimeStepInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let at = crate::math::fmt_place(&self.centroid);
        let how = if self.fixed {
            "fixed by the script".to_string()
        } else {
            format!("{} × critical", self.safety)
        };
        match self.joints {
            None => write!(
                f,
                "dt = {:.4e} s ({how}); critical {:.4e} s set by tet {} of body '{}' at {at}",
                self.dt, self.critical, self.tet, self.body
            )?,
            Some((node, alone)) => {
                let by = match (node == usize::MAX, self.contact) {
                    (true, _) => "the contact penalty".to_string(),
                    (false, false) => format!("the joint penalties (stiffest at node {node})"),
                    (false, true) => {
                        format!("the joint (stiffest at node {node}) and contact penalties")
                    }
                };
                write!(
                    f,
                    "dt = {:.4e} s ({how}); critical {:.4e} s: tetrahedra alone {alone:.4e} s (tet {} of body '{}' at {at}), lowered by {by}",
                    self.dt, self.critical, self.tet, self.body
                )?
            }
        }
        if let Some(c) = &self.contact_by {
            write!(
                f,
                "; without contact {:.4e} s, the contact bound from tet {} of body '{}' (penalty {:.3e} Pa against the material of body '{}')",
                c.without, c.tet, c.body, c.penalty, c.partner_body
            )?;
        }
        Ok(())
    }
}

/// Errors that stop a run.
#[derive(Clone, Debug, PartialEq)]
pub enum SimError {
    /// The model is not valid (bad mesh, dt too large, nothing to simulate, …).
    Invalid(String),
    /// The solution blew up: non-finite values or inverted elements.
    Unstable(String),
    /// A law written in the script returned a value it must not (a negative or NaN μ).
    Law(String),
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::Invalid(m) => write!(f, "{m}"),
            SimError::Unstable(m) => write!(f, "unstable run: {m}"),
            SimError::Law(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for SimError {}

/// Time-integration settings.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Settings {
    /// dt = safety × critical step.
    pub safety: Real,
    /// A fixed dt [s] instead of the automatic one (must not exceed the critical step).
    pub dt: Option<Real>,
    /// Mass-proportional damping α [1/s].
    pub mass_damping: Real,
    /// Mass damping acts on velocities relative to each body's centre-of-mass velocity
    /// (`sim.damping(#{ frame: "body" })`) instead of the ground's.
    pub damping_relative_to_body: bool,
    /// Sample the energy account every this many steps.
    pub energy_every: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            safety: 0.8,
            dt: None,
            mass_damping: 0.0,
            damping_relative_to_body: false,
            energy_every: 50,
        }
    }
}

/// The whole state of a FEM/DEM model.
#[derive(serde::Serialize, serde::Deserialize, Debug, Default)]
pub struct Simulation {
    pub nodes: Nodes,
    pub tets: Tets,
    pub bodies: Vec<Body>,
    pub materials: Vec<Material>,
    pub loads: Loads,
    /// Rigid bodies (stage 7): their six degrees of freedom, constraints and results.
    pub rigid: integration::rigid::RigidBodies,
    /// Joint elements (stage 2) and their laws.
    pub joints: crate::joints::Joints,
    /// Joints broken so far (stage 3), in the order they broke.
    pub break_events: Vec<crate::fracture::BreakEvent>,
    /// A user fracture criterion (stage 3), if any.
    pub fracture_criterion: Option<crate::fracture::FractureCriterion>,
    /// Contact detection (stage 4): surface, candidate pairs.
    pub contact_detection: ContactDetection,
    /// Contact interaction (stage 5): laws, pair history; off until a contact law is set.
    pub contact: ContactInteraction,
    /// Bar elements (stage 1) of the rebars, their steels, and the rebars.
    pub bars: Bars,
    pub steels: Vec<crate::elements::bar2::steel::Steel>,
    pub rebars: Vec<Rebar>,
    /// Bond points between bar nodes and their hosts (stage 2).
    pub bonds: crate::joints::bond::Bonds,
    bar_force: Vec<Vec3>,
    pub settings: Settings,
    pub time: Real,
    pub step: u64,
    pub dt: Real,
    dt_prev: Real,
    pub dt_info: Option<TimeStepInfo>,
    pub timers: StageTimers,
    /// The energy account at the last sample (all terms at the same time level).
    pub energy: Energy,
    /// Running sums of the path-dependent terms (work of constraints, dissipation).
    accumulated: Energy,
    pub energy_history: Vec<EnergySample>,
    /// Sample energies on the next step regardless of `energy_every`.
    pub sample_next: bool,
    ready: bool,
    /// Scratch (not in checkpoints; see [`Simulation::restore`]).
    #[serde(skip)]
    elements_ws: ElementsWorkspace,
    #[serde(skip)]
    integration_partials: Vec<IntegrationSums>,
    /// Each body's mass-weighted velocity, for damping relative to bodies [m/s].
    body_frame: Vec<Vec3>,
    contact_energy: Real,
    contact_dissipated: Real,
    /// Gravity of the last step (None before the first): a change (a ramp, a body force
    /// standing for ground acceleration) shifts the gravity work's state function, see
    /// [`Simulation::gravity_changed`].
    gravity_applied: Option<Vec3>,
    /// Σ m·v(t − dt/2) of the last step, for the relative-frame body force's work.
    momentum_before: Vec3,
    /// This rank's part of a model decomposed over several ranks ([`Simulation::decompose`]).
    #[serde(skip)]
    parallel: Option<crate::parallel::Parallel>,
}

/// What one rank of a decomposed model exchanged with the others so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Exchanged {
    /// Wall time spent exchanging [s].
    pub seconds: Real,
    /// Bytes received.
    pub bytes: u64,
    /// Of `bytes`, those in the halo after each step.
    pub halo: u64,
    /// Of `bytes`, those of the nodes within reach of this rank's, before full detections.
    pub near: u64,
    /// Of `bytes`, those of the whole model's state (every node, every joint's or pair's
    /// history, every node's position at the last detection: for output, checkpoints and
    /// whole-model queries; not every step).
    pub whole: u64,
}

impl Simulation {
    /// Continue from `saved`, a checkpoint of this model (the caller has compared their
    /// [`crate::io::checkpoint::Fingerprint`]s): every state variable is taken from `saved`;
    /// only the per-step scratch buffers, which checkpoints leave out, are kept from `self`.
    pub fn restore(&mut self, mut saved: Simulation) {
        std::mem::swap(&mut saved.elements_ws, &mut self.elements_ws);
        std::mem::swap(
            &mut saved.integration_partials,
            &mut self.integration_partials,
        );
        std::mem::swap(
            &mut saved.contact_detection.detector.workspace,
            &mut self.contact_detection.detector.workspace,
        );
        saved.joints.take_scratch(&mut self.joints);
        // A decomposed model stays decomposed (over this run's ranks, whatever the count
        // that wrote the checkpoint): the split is made again before the next step.
        let parallel = self.parallel.take();
        *self = saved;
        if let Some(mut par) = parallel {
            par.nodes_shared_at = None;
            par.joints_shared_at = None;
            par.contact_shared_at = None;
            self.parallel = Some(par);
            self.ready = false;
        }
    }

    pub fn new() -> Self {
        Self::default()
    }

    /// Run this model as one rank of `comm` (every rank builds the same model and calls
    /// this; see [`crate::parallel`]). The split is made before the next step. One rank is
    /// the plain single-process run.
    pub fn decompose(&mut self, comm: std::sync::Arc<dyn crate::parallel::Comm>) {
        self.parallel = (comm.size() > 1).then(|| crate::parallel::Parallel::pending(comm));
        self.ready = false;
    }

    /// On a decomposed model, bring this rank's copy of the whole state up to date (each rank
    /// keeps current only what it computes): [`Simulation::synchronize_nodes`] and
    /// [`Simulation::synchronize_joints`]. Collectives: every rank calls them at the same point
    /// of the script (a new split does; the script layer the nodes alone when a run
    /// returns, and in the queries that read them, only theirs for a node or element set; a
    /// whole frame gathers what it shows to rank 0 alone,
    /// [`Simulation::gather_frame_to_root`], a frame in pieces exchanges what crosses
    /// pieces, [`Simulation::piece_frame_reads`], and a checkpoint gathers the whole state
    /// to rank 0 alone, [`Simulation::with_whole_state_on_root`]). While stepping, ranks
    /// share only break events and the nodes other ranks read (`Parallel::halo`).
    pub fn synchronize(&mut self) {
        self.synchronize_nodes();
        self.synchronize_joints();
        self.synchronize_contact();
        self.synchronize_detection();
    }

    /// What a whole frame reads beyond the mesh, for rank 0 to write it: on a decomposed
    /// model rank 0 gathers the nodes' positions and velocities from their owners, the
    /// damaged joints' damage and the touching pairs' outputs from the ranks they are
    /// designated to (a collective; None on the other ranks, whose copies are left as they
    /// are, and no rank counts anything as shared). Before 2026-12-07 every rank received
    /// the whole model's nodes and every joint's and pair's history for each frame. On one
    /// process (or when every rank holds the whole model), from the state itself.
    pub fn gather_frame_to_root(&mut self) -> Option<FrameReads> {
        let step = self.step;
        let Some(par) = self.parallel.as_mut().filter(|p| p.partition.is_split()) else {
            return Some(FrameReads::of(self));
        };
        if par.nodes_shared_at != Some(step) {
            par.gather_nodes_to_root(&mut self.nodes, false);
        }
        let joint_damage = if par.joints_shared_at == Some(step) || self.joints.is_empty() {
            None
        } else {
            par.gather_joint_damage_to_root(&self.joints)
        };
        let masked = self.contact.is_masked();
        let outputs = if par.contact_shared_at == Some(step) || !masked {
            None
        } else {
            let mine = self
                .contact
                .designated_outputs(&self.contact_detection.pairs);
            par.gather_pair_outputs_to_root(mine)
        };
        if par.rank() != 0 {
            return None;
        }
        let joint_damage = joint_damage.unwrap_or_else(|| FrameReads::joint_damage(self));
        let (contact_force, contact_pressure) = match outputs {
            Some(o) => FrameReads::contact_from(&o, self),
            None => FrameReads::contact(self),
        };
        Some(FrameReads {
            joint_damage,
            contact_force,
            contact_pressure,
        })
    }

    /// What this rank's piece of a frame written in pieces reads ([`FrameReads`], right for
    /// the tets whose first node this rank owns, [`crate::parallel::Parallel::piece_of_tet`],
    /// and their nodes). The rank computes those tets, so their nodes are current here; the
    /// damage of their joints and the outputs of the touching pairs at their nodes come
    /// from the ranks those are designated to, a neighbour exchange (a collective). Before
    /// 2026-12-07 every rank received the whole model's state for its piece. On one
    /// process, from the state itself.
    pub fn piece_frame_reads(&mut self) -> FrameReads {
        let step = self.step;
        let Some(par) = self.parallel.as_ref().filter(|p| p.partition.is_split()) else {
            return FrameReads::of(self);
        };
        let joints_whole = par.joints_shared_at == Some(step) || self.joints.is_empty();
        let masked = self.contact.is_masked();
        let contact_whole = par.contact_shared_at == Some(step) || !masked;
        let joint_damage = match (&mut self.parallel, joints_whole) {
            (Some(par), false) => par.joint_damage_for_piece(&self.joints, &self.tets),
            _ => FrameReads::joint_damage(self),
        };
        let par = self.parallel.as_mut().expect("decomposed");
        let (contact_force, contact_pressure) = if contact_whole {
            FrameReads::contact(self)
        } else {
            let ranks = par.piece_ranks(&self.tets, self.nodes.len());
            let mine = self
                .contact
                .designated_outputs(&self.contact_detection.pairs);
            let outputs = par.pair_outputs_for_piece(mine, &ranks);
            FrameReads::contact_from(&outputs, self)
        };
        FrameReads {
            joint_damage,
            contact_force,
            contact_pressure,
        }
    }

    /// On a decomposed model whose frames are written in pieces: the positions the crack and
    /// bar frames (written whole by rank 0) read, to rank 0: the broken joints' faces, and
    /// every node from the first rebar's on (a collective; nothing when every node is
    /// current this step or on one process).
    pub fn gather_whole_series_nodes_to_root(&mut self) {
        let step = self.step;
        let Some(par) = self.parallel.as_mut() else {
            return;
        };
        if par.nodes_shared_at == Some(step) || !par.partition.is_split() {
            return;
        }
        if self.break_events.is_empty() && self.bars.is_empty() {
            return;
        }
        let bar_points = (self.rebars.first().map(|r| r.nodes.start))
            .filter(|_| !self.bars.is_empty())
            .map_or(0..0, |first| first as u32..self.nodes.len() as u32);
        let mut which: Vec<u32> = (self.break_events.iter())
            .flat_map(|e| self.joints.faces[e.joint][0])
            .chain(bar_points)
            .collect();
        which.sort_unstable();
        which.dedup();
        par.gather_listed_nodes_to_root(&mut self.nodes, &which);
    }

    /// Call `write` with the whole model's state on rank 0 (what a checkpoint serializes);
    /// Some(its result) there, None on the other ranks. On a decomposed model rank 0 gathers
    /// every node's position, velocity and reaction, every joint's and pair's history and
    /// every position at the last detection (a collective); the other ranks send their part
    /// and are left as they were. Rank 0's own contact lists are put back after `write`, so
    /// every rank steps on from the state it had: before 2026-12-07 every rank received the
    /// whole model for a checkpoint. On one process, `write(self)`.
    pub fn with_whole_state_on_root<R>(
        &mut self,
        write: impl FnOnce(&Simulation) -> R,
    ) -> Option<R> {
        let step = self.step;
        let Some(par) = self.parallel.as_mut().filter(|p| p.partition.is_split()) else {
            return Some(write(self));
        };
        let root = par.rank() == 0;
        if par.nodes_shared_at != Some(step) {
            par.gather_nodes_to_root(&mut self.nodes, true);
        }
        let par_joints_gathered = par.joints_shared_at != Some(step);
        if par_joints_gathered {
            par.gather_joint_histories_to_root(&mut self.joints);
        }
        let masked = self.contact.is_masked();
        let contact = par.contact_shared_at != Some(step) && masked;
        let detection = !self.contact_detection.detector.current.is_empty();
        // (Rank 0's lists as they are, to be put back: only the checkpoint sees the whole.)
        let kept = (root && (contact || detection))
            .then(|| (self.contact_detection.clone(), self.contact.clone()));
        let cd = &mut self.contact_detection;
        if contact {
            par.gather_contact_histories_to_root(cd, &mut self.contact);
        }
        if detection {
            par.gather_positions_at_detection_to_root(&mut cd.detector.x_at_detection);
            if root {
                cd.positions_at_detection_shared();
            }
        }
        if !root {
            return None;
        }
        let written = write(self);
        if let Some((cd, ci)) = kept {
            self.contact_detection = cd;
            self.contact = ci;
        }
        if par_joints_gathered {
            self.joints.hold_computed();
        }
        Some(written)
    }

    /// On a decomposed model, every node's position at the last full contact detection from
    /// its owner (a rank records only those within reach of its own nodes): what a new split
    /// needs (a collective, once per detection; a checkpoint gathers them to rank 0 alone).
    pub fn synchronize_detection(&mut self) {
        if let Some(par) = &mut self.parallel {
            let cd = &mut self.contact_detection;
            if par.partition.is_split() && !cd.detector.current.is_empty() {
                par.share_positions_at_detection(&mut cd.detector.x_at_detection);
                cd.positions_at_detection_shared();
            }
        }
    }

    /// Every node's position, velocity and reaction from the rank that owns it (once per
    /// step).
    pub fn synchronize_nodes(&mut self) {
        let step = self.step;
        if let Some(par) = &mut self.parallel {
            if par.nodes_shared_at != Some(step) && par.partition.is_split() {
                par.share_nodes(&mut self.nodes);
                par.nodes_shared_at = Some(step);
            }
        }
    }

    /// The nodes `which` (position, velocity, reaction) from the ranks that own them: on a
    /// decomposed model a collective, every rank passing the same list (the script's
    /// queries of node and element sets; nothing when every node is current this step).
    pub fn synchronize_some_nodes(&mut self, which: &[u32]) {
        let step = self.step;
        if let Some(par) = &mut self.parallel {
            if par.nodes_shared_at != Some(step) && par.partition.is_split() {
                par.share_listed_nodes(&mut self.nodes, which, true);
            }
        }
    }

    /// Joints with D > 0 somewhere. On a decomposed model (a collective) each rank counts
    /// the joints designated to it, whose histories it holds current, and the counts are
    /// added: one number per rank instead of every joint's history.
    pub fn damaged_joints(&mut self) -> usize {
        let step = self.step;
        match &mut self.parallel {
            Some(par) if par.partition.is_split() && par.joints_shared_at != Some(step) => {
                let mine = (0..self.joints.len())
                    .filter(|&j| par.joints.designates(j) && self.joints.is_damaged(j))
                    .count();
                par.sum_in_rank_order(mine as Real) as usize
            }
            _ => self.joints.damaged(),
        }
    }

    /// The contact force on body `body`'s nodes in the last step [N]. On a decomposed model
    /// (a collective) the ranks add their exact sums over the pairs designated to them
    /// (3 × 69 numbers each) instead of sharing every pair's history; the same bits as one
    /// process.
    pub fn contact_force_on(&mut self, body: usize) -> Vec3 {
        let range = self.bodies[body].nodes.clone();
        let step = self.step;
        let masked = self.contact.is_masked();
        match &mut self.parallel {
            Some(par)
                if par.partition.is_split() && par.contact_shared_at != Some(step) && masked =>
            {
                let t = std::time::Instant::now();
                let mut digits = vec![0.0; 3 * crate::math::ExactSum::LEN];
                self.contact.force_share(range, &mut digits);
                par.sum_exact_digits(&mut digits);
                par.seconds += t.elapsed().as_secs_f64();
                contact_interaction::ContactInteraction::force_from_shares(&digits)
            }
            _ => self.contact.force_on(range),
        }
    }

    /// On a decomposed model whose joint histories were shared since the split (a query
    /// or frame read them whole), hold again only those of this rank's units: they are
    /// current nowhere else once it steps.
    fn hold_own_joint_histories(&mut self) {
        if let Some(par) = &mut self.parallel {
            if par.joints_shared_at.is_some() && par.partition.is_split() {
                self.joints.hold_computed();
                par.joints_shared_at = None;
            }
        }
    }

    /// Every joint's history from the rank it is designated to (once per step).
    pub fn synchronize_joints(&mut self) {
        let step = self.step;
        if let Some(par) = &mut self.parallel {
            if par.joints_shared_at != Some(step) && par.partition.is_split() {
                par.share_joint_histories(&mut self.joints);
                par.joints_shared_at = Some(step);
            }
        }
    }

    /// Every contact pair's history and last forces from the rank it is designated to (once
    /// per step).
    pub fn synchronize_contact(&mut self) {
        let step = self.step;
        if let Some(par) = &mut self.parallel {
            if par.contact_shared_at != Some(step)
                && par.partition.is_split()
                && self.contact.is_masked()
            {
                par.share_contact_histories(&mut self.contact_detection, &mut self.contact);
                par.contact_shared_at = Some(step);
            }
        }
    }

    /// On a decomposed model, split nodes and work between the ranks again from where the
    /// nodes are now (ownership by place, [`crate::parallel::Partition`]): bodies and
    /// fragments that moved go to the ranks of their new place. Every rank's copy of the
    /// whole state is brought up to date first ([`Simulation::synchronize`]), so a rank can
    /// take over any node, joint or pair. The results do not change, bit for bit: which
    /// rank computes what never decides the order of a sum. A collective (every rank calls
    /// it at the same step); nothing on one process. With `if_imbalance` > 0, only when the
    /// ranks' stage work since the last call was at least that unbalanced (the slowest
    /// rank's over the mean: one number per rank gathered); with `if_moved` > 0, only when
    /// at least that fraction of the nodes would change rank (decided from the chunks'
    /// centres alone, a small collective); given both, both must hold. The partition then
    /// depends on measured times, the results do not.
    pub fn repartition(
        &mut self,
        if_moved: Real,
        if_imbalance: Real,
        by_work: bool,
    ) -> Result<Repartitioned, SimError> {
        let stage_seconds: f64 = self.timers.seconds.iter().sum();
        if !self
            .parallel
            .as_ref()
            .is_some_and(|p| p.partition.is_split())
        {
            return Ok(Repartitioned::default());
        }
        // (Every joint's and pair's state current on every rank first: the same weights.)
        let work = if by_work {
            self.synchronize_joints();
            self.synchronize_contact();
            self.modelled_work()
        } else {
            Vec::new()
        };
        let par = self.parallel.as_mut().expect("decomposed");
        let before = par.partition.chunk_owner.clone();
        let t = std::time::Instant::now();
        let mut done = Repartitioned::default();
        let mut declined = false;
        if if_imbalance > 0.0 {
            let imbalance = par.imbalance_since_last_check(stage_seconds);
            done.imbalance = Some(imbalance);
            declined = imbalance < if_imbalance;
        }
        if if_moved > 0.0 && !declined {
            let now = par.owners_by_place_now(&self.nodes.x, &self.tets, &self.bodies, &work);
            let n = self.nodes.len();
            declined = (nodes_changing_rank(&now, &before, n) as Real) < if_moved * n as Real;
        }
        if declined {
            done.seconds = t.elapsed().as_secs_f64();
            par.seconds += done.seconds;
            return Ok(done);
        }
        self.synchronize();
        self.split_between_ranks(&work)?;
        done.seconds = t.elapsed().as_secs_f64();
        let n = self.nodes.len();
        let par = self.parallel.as_mut().expect("decomposed");
        par.seconds += done.seconds;
        done.moved_nodes = nodes_changing_rank(&par.partition.chunk_owner, &before, n);
        Ok(done)
    }

    /// Modelled work per node besides its tets, in quarters of a tet corner (a tet corner is
    /// about 30 ns a step), for a split weighed by the work (`sim.repartition(#{ weigh:
    /// "work" })`). A joint adds to each of its six face nodes 1 while undamaged (an intact
    /// joint costs about 45 ns a step), 4 once damaged (the law's general path), nothing once
    /// broken; a candidate contact pair adds 1 to each of its eight nodes (the rejection
    /// test), 30 while touching (the exact kernel, about 1.8 µs a pair). Reads every joint's
    /// and pair's state: on a decomposed model, synchronise them first.
    pub fn modelled_work(&self) -> Vec<u32> {
        let mut work = vec![0u32; self.nodes.len()];
        for (j, faces) in self.joints.faces.iter().enumerate() {
            if self.joints.broken[j] {
                continue;
            }
            let damaged = self.joints.is_damaged(j);
            for &n in faces.iter().flatten() {
                work[n as usize] += if damaged { 4 } else { 1 };
            }
        }
        if self.contact.is_enabled() {
            let cd = &self.contact_detection;
            for (k, &[a, b]) in cd.pairs.iter().enumerate() {
                let w = if self.contact.pair_state(k).touching {
                    30
                } else {
                    1
                };
                for s in [a, b] {
                    for n in self.tets.nodes[cd.surface[s as usize] as usize] {
                        work[n as usize] += w;
                    }
                }
            }
        }
        work
    }

    /// On a decomposed model, every rank's stage and exchange times and peak memory to every
    /// rank ([`crate::parallel::Parallel::rank_seconds`], for the summary's load balance). A
    /// collective: the script layer calls it when a run returns normally, on every rank.
    pub fn gather_rank_timings(&mut self) {
        if let Some(par) = &mut self.parallel {
            if par.partition.is_split() {
                let peak = crate::limits::peak_resident_memory().unwrap_or(0.0);
                par.gather_timings(&self.timers.seconds, peak);
            }
        }
    }

    /// Every rank's stage and exchange times as of the last run ([`Simulation::gather_rank_timings`]);
    /// empty unless decomposed.
    pub fn rank_seconds(&self) -> &[crate::parallel::RankSeconds] {
        self.parallel.as_ref().map_or(&[], |p| &p.rank_seconds)
    }

    /// What this rank exchanged with the others ([`Exchanged`]); zeros unless decomposed.
    pub fn exchanged(&self) -> Exchanged {
        self.parallel
            .as_ref()
            .map_or(Exchanged::default(), |p| Exchanged {
                seconds: p.seconds,
                bytes: p.bytes,
                halo: p.halo_bytes,
                near: p.near_bytes,
                whole: p.whole_bytes,
            })
    }

    /// A stop signal (SIGINT, SIGTERM) as every rank of a decomposed model sees it: the
    /// largest signal number any rank received, so that all stop at the same step (mpirun
    /// forwards a Ctrl-C to every rank, which may get it a step apart). A collective on a
    /// decomposed model; `signal` itself otherwise.
    pub fn agree_on_signal(&mut self, signal: Option<i32>) -> Option<i32> {
        let Some(par) = &mut self.parallel else {
            return signal;
        };
        let largest = par.largest_over_ranks(signal.map_or(0.0, f64::from));
        (largest > 0.0).then_some(largest as i32)
    }

    /// How a decomposed model is split, for the console: ranks, nodes per rank, and the
    /// nodes each step exchanges (None unless decomposed).
    pub fn split_summary(&self) -> Option<String> {
        let par = self.parallel.as_ref()?;
        let per_rank = &par.partition.nodes_per_rank;
        let nodes: Vec<String> = per_rank.iter().map(|n| n.to_string()).collect();
        let exported = par.shared_nodes();
        let when = if self.contact.is_enabled() {
            "in the first step (then the nodes of work and contact pairs shared between ranks, and before a full contact detection those within reach of each rank's own)"
        } else {
            "every step"
        };
        Some(format!(
            "split over {} ranks: nodes per rank [{}]; {} nodes ({:.1} %) exchanged {when}",
            per_rank.len(),
            nodes.join(", "),
            exported,
            100.0 * exported as f64 / self.nodes.len().max(1) as f64
        ))
    }

    /// Nodes owned by each rank (None unless decomposed).
    pub fn nodes_per_rank(&self) -> Option<&[usize]> {
        self.parallel
            .as_ref()
            .map(|p| p.partition.nodes_per_rank.as_slice())
    }

    /// This process's rank and the number of ranks ((0, 1) unless decomposed).
    pub fn rank_and_size(&self) -> (usize, usize) {
        self.parallel
            .as_ref()
            .map_or((0, 1), |p| (p.rank(), p.comm.size()))
    }

    /// The rank owning node `n` (0 unless decomposed).
    pub fn node_owner(&self, n: usize) -> usize {
        match &self.parallel {
            Some(p) if p.comm.size() > 1 => p.partition.owner(n),
            _ => 0,
        }
    }

    pub fn add_material(&mut self, m: Material) -> MaterialId {
        self.ready = false;
        self.materials.push(m);
        (self.materials.len() - 1) as MaterialId
    }

    /// Add a body meshed by `mesh` (shared-node topology) with `layout`. Returns its id.
    pub fn add_body(
        &mut self,
        name: &str,
        mesh: &Mesh,
        material: MaterialId,
        layout: Layout,
    ) -> Result<usize, String> {
        if self.bodies.iter().any(|b| b.name == name) {
            return Err(format!("a body named '{name}' already exists"));
        }
        if mesh.tets.is_empty() {
            return Err(format!("body '{name}': the mesh has no tetrahedra"));
        }
        if material as usize >= self.materials.len() {
            return Err(format!("body '{name}': unknown material id {material}"));
        }
        let problems = mesh.problems();
        if !problems.is_empty() {
            let list: Vec<String> = problems.iter().take(5).map(|p| format!("  {p}")).collect();
            let more = if problems.len() > 5 {
                format!("\n  … and {} more", problems.len() - 5)
            } else {
                String::new()
            };
            return Err(format!(
                "body '{name}': invalid mesh, {} problem(s) (tet and node ids are the mesh's):\n{}{more}",
                problems.len(),
                list.join("\n")
            ));
        }
        self.ready = false;
        // A body larger than one of stage 7's chunks is stored in spatial order (its tets
        // layer by layer, a Z-order curve within each layer, `mesh::order`): every stage's runs of consecutive tets, joints and nodes,
        // and a rank's chunks on a decomposed model, are then compact pieces of it. (Smaller
        // bodies fit one chunk and keep the mesher's order.)
        let layout_nodes = match layout {
            Layout::Jointed => 4 * mesh.tets.len(),
            Layout::Continuous | Layout::Rigid => mesh.nodes.len(),
        };
        let ordered;
        let mesh = if layout_nodes > integration::CHUNK {
            ordered = crate::mesh::order::spatially_ordered(mesh);
            &ordered
        } else {
            mesh
        };
        let id = self.bodies.len();
        let node_start = self.nodes.len();
        let tet_start = self.tets.len();
        // Simulation node ids of each tet's corners.
        let tet_nodes: Vec<[u32; 4]> = match layout {
            Layout::Continuous | Layout::Rigid => {
                for p in &mesh.nodes {
                    self.nodes.push(*p, id as u32);
                }
                mesh.tets
                    .iter()
                    .map(|t| t.map(|n| n + node_start as u32))
                    .collect()
            }
            Layout::Jointed => {
                let mut out = Vec::with_capacity(mesh.tets.len());
                for t in &mesh.tets {
                    let base = self.nodes.len() as u32;
                    for &n in t {
                        self.nodes.push(mesh.nodes[n as usize], id as u32);
                    }
                    out.push([base, base + 1, base + 2, base + 3]);
                }
                out
            }
        };
        for (e, t) in tet_nodes.iter().enumerate() {
            let (dm_inv, vol0) =
                elements::tet4::reference(&mesh.tet_points(e)).expect("checked non-degenerate");
            self.tets.nodes.push(*t);
            self.tets.dm_inv.push(dm_inv);
            self.tets.vol0.push(vol0);
            self.tets.material.push(material);
            self.tets.body.push(id as u32);
            self.tets.rigid.push(layout == Layout::Rigid);
        }
        let boundary = boundary_faces(mesh)
            .into_iter()
            .map(|f| {
                let t = tet_nodes[f.tet as usize];
                let local = crate::mesh::TET_FACES[f.local as usize];
                BoundaryFace {
                    tet: f.tet + tet_start as u32,
                    local: f.local,
                    nodes: local.map(|c| t[c]),
                }
            })
            .collect();
        self.bodies.push(Body {
            name: name.to_string(),
            layout,
            material,
            tets: tet_start..self.tets.len(),
            nodes: node_start..self.nodes.len(),
            boundary,
            mesh: mesh.clone(),
        });
        if layout == Layout::Rigid {
            self.add_rigid(id);
        }
        Ok(id)
    }

    pub fn body_id(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Nodes whose reference position lies inside `region` (optionally of one body), in id
    /// order. Selections are made on the model as built, whatever it has done since.
    pub fn nodes_in(&self, region: &Region, body: Option<usize>) -> Vec<u32> {
        self.nodes_in_at(region, body, Configuration::Reference)
    }

    /// Nodes inside `region` (optionally of one body) in configuration `at`: the reference
    /// positions X (what [`Self::nodes_in`] uses) or the current positions x.
    pub fn nodes_in_at(&self, region: &Region, body: Option<usize>, at: Configuration) -> Vec<u32> {
        let range = body
            .map(|b| self.bodies[b].nodes.clone())
            .unwrap_or(0..self.nodes.len());
        let tol = self.length_tolerance();
        let x = self.positions(at);
        range
            .filter(|&n| region.contains(&x[n], tol))
            .map(|n| n as u32)
            .collect()
    }

    /// Tets whose reference centroid lies inside `region` (optionally of one body).
    pub fn tets_in(&self, region: &Region, body: Option<usize>) -> Vec<u32> {
        self.tets_in_at(region, body, Configuration::Reference)
    }

    /// Tets whose centroid in configuration `at` lies inside `region`.
    pub fn tets_in_at(&self, region: &Region, body: Option<usize>, at: Configuration) -> Vec<u32> {
        let range = body
            .map(|b| self.bodies[b].tets.clone())
            .unwrap_or(0..self.tets.len());
        let tol = self.length_tolerance();
        let x = self.positions(at);
        range
            .filter(|&e| {
                let c = self.tets.nodes[e]
                    .iter()
                    .map(|&n| x[n as usize])
                    .sum::<Vec3>()
                    / 4.0;
                region.contains(&c, tol)
            })
            .map(|e| e as u32)
            .collect()
    }

    /// 1e-9 × the diagonal of the model's bounding box at its reference placement [m]
    /// (the reference, not the current places: the same on every rank of a decomposed model,
    /// whose ranks keep current only the nodes they compute).
    pub fn length_tolerance(&self) -> Real {
        let mut lo = Vec3::repeat(Real::INFINITY);
        let mut hi = Vec3::repeat(Real::NEG_INFINITY);
        for p in &self.nodes.x0 {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        if self.nodes.is_empty() {
            1e-12
        } else {
            1e-9 * (hi - lo).norm().max(1e-3)
        }
    }

    /// Bodies whose tetrahedra intersect at their reference placement (touching faces are
    /// fine): an error naming both bodies, the first element pairs (body-local tet ids, as in
    /// the bodies' meshes) and their places. Checked when the first run starts.
    pub fn check_body_overlaps(&self) -> Result<(), SimError> {
        if self.bodies.len() < 2 {
            return Ok(());
        }
        let tol = self.length_tolerance();
        let boxes: Vec<(Vec3, Vec3)> = self.bodies.iter().map(|b| b.mesh.bounds()).collect();
        let mut found = Vec::new();
        for i in 0..self.bodies.len() {
            for j in i + 1..self.bodies.len() {
                let ((al, ah), (bl, bh)) = (boxes[i], boxes[j]);
                if (0..3).any(|k| ah[k] <= bl[k] + tol || bh[k] <= al[k] + tol) {
                    continue;
                }
                let (a, b) = (&self.bodies[i], &self.bodies[j]);
                let (n, pairs) = crate::mesh::overlap::overlapping_tets(&a.mesh, &b.mesh, tol, 3);
                if n == 0 {
                    continue;
                }
                let fp = crate::mesh::checks::fmt_point;
                let list: Vec<String> = pairs
                    .iter()
                    .map(|&(ea, eb)| {
                        format!(
                            "  tet {ea} of '{}' (centroid {}) intersects tet {eb} of '{}' (centroid {})",
                            a.name,
                            fp(&a.mesh.tet_centroid(ea)),
                            b.name,
                            fp(&b.mesh.tet_centroid(eb))
                        )
                    })
                    .collect();
                found.push(format!(
                    "bodies '{}' and '{}' overlap at the start: {n} pair(s) of intersecting tetrahedra{}\n{}",
                    a.name,
                    b.name,
                    if n > pairs.len() { ", the first:" } else { ":" },
                    list.join("\n")
                ));
            }
        }
        if found.is_empty() {
            Ok(())
        } else {
            Err(SimError::Invalid(format!(
                "{}\nmove the bodies apart (touching faces are fine; tet ids are the bodies' own)",
                found.join("\n")
            )))
        }
    }

    /// Mark the model changed (masses, constraints, dt are recomputed before the next step).
    pub fn invalidate(&mut self) {
        self.ready = false;
    }

    /// Masses, gather maps, constraint masks and the stable time step. Called by `step`.
    pub fn prepare(&mut self) -> Result<(), SimError> {
        if self.ready {
            return Ok(());
        }
        // (A decomposed model edited between steps: from every node's current state, and
        // every joint's and pair's history, which the new split shares out again.)
        self.synchronize();
        if self.tets.is_empty() {
            return Err(SimError::Invalid(
                "the model has no bodies: add one with sim.add_body(..)".into(),
            ));
        }
        // The arrays were built by pushing: give back what doubling reserved (a no-op once
        // they are tight, as after the first prepare).
        self.nodes.shrink_to_fit();
        self.tets.shrink_to_fit();
        elements::lumped_masses(&mut self.nodes, &self.tets, &self.materials);
        elements::bar2::lumped_masses(&mut self.nodes, &self.bars, &self.steels);
        self.elements_ws = ElementsWorkspace::new(&self.bodies, &self.tets);
        self.integration_partials =
            Vec::with_capacity(self.nodes.len().div_ceil(integration::CHUNK));
        self.loads.apply_constraint_masks(&mut self.nodes);
        self.prepare_rigid()?;
        self.joints.prepare(self.nodes.len());
        if self.contact.is_enabled() {
            self.contact.prepare(&self.materials, &self.tets);
            self.contact_detection.prepare();
        }
        self.split_between_ranks(&[])?;
        let info = self.stable_time_step()?;
        self.dt = info.dt;
        self.dt_info = Some(info);
        self.ready = true;
        Ok(())
    }

    /// A decomposed model: split nodes and work for this rank, and hand stages 1 and 2 the
    /// units it computes. Rebars (bars, hinges, bond points) are few beside the host's
    /// tets: every rank computes all of them, so their nodes and their hosts' are read by
    /// every rank. Rigid bodies are advanced by every rank from their owner's loads.
    /// (`work`: modelled work per node for a split weighed by it, or empty: tet corners.)
    fn split_between_ranks(&mut self, work: &[u32]) -> Result<(), SimError> {
        let Some(par) = &mut self.parallel else {
            return Ok(());
        };
        let units = self.elements_ws.units(&self.bodies);
        let rebar_nodes = self.rebars.iter().flat_map(|r| r.nodes.clone());
        let hosts = self
            .bonds
            .tet
            .iter()
            .flat_map(|&t| self.tets.nodes[t as usize].map(|n| n as usize));
        let loaded: Vec<u32> = self
            .loads
            .forces
            .iter()
            .flat_map(|f| f.nodes.iter().copied())
            .chain(rebar_nodes.chain(hosts).map(|n| n as u32))
            .collect();
        par.split(crate::parallel::ModelToSplit {
            x: &self.nodes.x,
            tets: &self.tets,
            bodies: &self.bodies,
            element_units: &units,
            joints: &self.joints,
            loaded: &loaded,
            contact: self.contact.is_enabled(),
            work,
        });
        // Stage 5's mask is made for the pairs of the next step, and the skin test's list
        // of this rank's surface nodes anew.
        self.contact.mask = Default::default();
        self.contact_detection.own_surface_nodes = None;
        self.elements_ws.compute = par.elements.compute.clone();
        self.joints.compute = par.joint_blocks.compute.clone();
        // The joints a fracture criterion keeps pending, this rank's of them (while every
        // history is still whole here).
        if let Some(c) = &mut self.fracture_criterion {
            c.pending_again(&self.joints, |j| par.joints.relevant[j]);
        }
        // Each rank holds the joint histories of its own units from here on: a later
        // whole-model read gathers them.
        self.joints.hold_computed();
        par.joints_shared_at = None;
        Ok(())
    }

    /// Critical time step over all tets and the dt to use.
    pub fn stable_time_step(&self) -> Result<TimeStepInfo, SimError> {
        let (critical_tets, tet) = elements::critical_time_step(&self.tets, &self.materials);
        // Bars act on their own nodes: the elements' step is the smaller of the two families'.
        let (critical_bars, _) =
            elements::bar2::critical_time_step(&self.bars, &self.steels, &self.nodes.m);
        let critical_tets = critical_tets.min(critical_bars);
        // Joint springs add stiffness at their nodes: by Weyl's inequality and a Gershgorin
        // bound on the joint part, ω² ≤ ω_tets² + max_n 2·Σk_joint/m_n (bond springs alike).
        let mut critical = critical_tets;
        let mut joints_note = None;
        let mut contact_lowered = false;
        let mut contact_by = None;
        if !self.joints.is_empty() || !self.bonds.is_empty() {
            let (mut w2, mut node) = self.joints.max_omega2(&self.nodes.m);
            let (w2_bond, bond_node) = self.bonds.max_omega2(&self.tets, &self.nodes.m);
            if w2_bond > w2 {
                node = bond_node;
            }
            w2 += w2_bond;
            let w_tets = 2.0 / critical_tets;
            critical = 2.0 / (w_tets * w_tets + w2).sqrt();
            joints_note = Some((node, critical_tets));
        }
        // Contact springs likewise (stage 5's bound).
        if self.contact.is_enabled() {
            let mass = self.rigid.contact_masses(&self.nodes.m);
            let bound = self.contact.max_omega2(&self.tets, mass);
            let w = 2.0 / critical;
            let without = critical;
            critical = 2.0 / (w * w + bound.omega2).sqrt();
            if joints_note.is_none() {
                joints_note = Some((usize::MAX, critical_tets));
            }
            contact_lowered = true;
            if let Some(&b) = self.tets.body.get(bound.tet) {
                let partner_body = self
                    .bodies
                    .iter()
                    .find(|body| body.material == bound.partner)
                    .map_or_else(|| "?".to_string(), |body| body.name.clone());
                contact_by = Some(ContactLimit {
                    tet: bound.tet,
                    body: self.bodies[b as usize].name.clone(),
                    partner_body,
                    penalty: bound.penalty,
                    without,
                });
            }
        }
        if !critical.is_finite() && self.settings.dt.is_none() {
            return Err(SimError::Invalid("every body is rigid and contact is off: nothing limits the time step; set it with sim.integrator(\"central_difference\", #{ dt })".into()));
        }
        let body = &self.bodies[self.tets.body[tet] as usize];
        let centroid = self.current_centroid(tet);
        let mut info = TimeStepInfo {
            dt: self.settings.safety * critical,
            critical,
            safety: self.settings.safety,
            tet,
            body: body.name.clone(),
            centroid,
            fixed: false,
            joints: joints_note,
            contact: contact_lowered,
            contact_by,
        };
        if let Some(dt) = self.settings.dt {
            if dt > critical {
                return Err(SimError::Invalid(format!(
                    "dt = {dt:.4e} s is larger than the critical time step {critical:.4e} s set by tet {tet} of body '{}' at {}; use dt ≤ {:.4e} s or leave dt unset for the automatic step",
                    body.name, crate::math::fmt_place(&centroid), critical
                )));
            }
            info.dt = dt;
            info.fixed = true;
        }
        Ok(info)
    }

    /// Advance one time step through the seven stages, each timed; then the energy account.
    pub fn step(&mut self) -> Result<(), SimError> {
        self.prepare()?;
        self.hold_own_joint_histories();
        self.check_mass_damping()?;
        let sample = self.step == 0
            || self.sample_next
            || self.step.is_multiple_of(self.settings.energy_every.max(1))
            || crate::joints::audit::on();
        self.sample_next = false;
        let (dt, time) = (self.dt, self.time);
        // On a decomposed model the ranks meet twice a step: after stage 3 (stages 1–3's
        // totals, break events, the skin test) and after stage 7 (stages 5 and 7's totals,
        // then the halo). A stage's totals are read only after its meeting.
        let mut el = timed(&mut self.timers, Stage::Elements, || {
            elements::add_internal_forces(
                &mut self.nodes,
                &self.tets,
                &self.bodies,
                &self.materials,
                &mut self.elements_ws,
                sample,
            )
        });
        let bs = timed(&mut self.timers, Stage::Elements, || {
            elements::bar2::add_bar_forces(
                &mut self.nodes,
                &mut self.bars,
                &self.steels,
                &mut self.bar_force,
                time,
                sample,
            )
        });
        let (mut js, bond) = timed(&mut self.timers, Stage::Joints, || {
            (
                crate::joints::add_joint_forces(&mut self.joints, &mut self.nodes, time, sample),
                crate::joints::bond::add_bond_forces(
                    &mut self.bonds,
                    &mut self.nodes,
                    &self.tets,
                    sample,
                ),
            )
        });
        if crate::joints::audit::on() {
            crate::joints::audit::close_step(&self.joints.faces, &self.nodes.x, time);
        }
        // (This rank's count on a decomposed model: it scans the joints it computes.)
        (el, js) = self.fracture_stage(el, js);
        // An element inverted by the last step's motion stops the run here, before stages
        // 4–7 act on it (a neo-Hookean stress is NaN there, and would make the nodes
        // non-finite, hiding the cause). Stages 2 and 3 do not read stage 1's forces.
        if el.inverted > 0 {
            return Err(self.unstable(el.inverted));
        }
        if self.contact.is_enabled() {
            self.contact_stages(); // 4. contact detection, 5. contact interaction
        }
        if let Some(par) = &mut self.parallel {
            // This step's skin test is answered; a test outside a step asks again.
            par.take_skin_moved();
        }
        timed(&mut self.timers, Stage::ExternalLoads, || {
            loads::add_external_forces(&mut self.loads, &mut self.nodes, time, self.dt_prev, dt)
        });
        self.gravity_changed();
        let params = StepParams {
            dt,
            dt_prev: self.dt_prev,
            gravity: self.loads.gravity,
            body_acceleration: self.loads.body_acceleration,
            mass_damping: self.settings.mass_damping,
            frame_velocity: self.loads.frame_velocity,
            sample,
        };
        let body_frame = self.settings.damping_relative_to_body && params.mass_damping > 0.0;
        if body_frame {
            self.update_body_frame();
        }
        let is = self.integration_stage(params, body_frame);
        if let Some(failure) = &self.contact.last.law_failure {
            return Err(SimError::Law(self.describe_friction_failure(failure)));
        }
        self.account(sample, &el, &js, &is, (&bs, &bond))?;
        self.dt_prev = dt;
        self.time += dt;
        self.step += 1;
        Ok(())
    }

    /// Stage 3, and on a decomposed model the step's first meeting (stages 1–3's totals,
    /// the break events, the skin test: [`crate::parallel::Parallel::close_joint_stages`]).
    /// Takes this rank's stage 1 and 2 totals, returns every rank's.
    fn fracture_stage(
        &mut self,
        el: elements::ElementSums,
        js: crate::joints::JointSums,
    ) -> (elements::ElementSums, crate::joints::JointSums) {
        let (time, step) = (self.time, self.step);
        let events_before = self.break_events.len();
        let released = timed(&mut self.timers, Stage::Fracture, || {
            crate::fracture::break_joints(
                &mut self.joints,
                &self.nodes.x,
                &self.tets.body,
                time,
                step,
                js.newly_failed,
                self.fracture_criterion.as_mut(),
                &mut self.break_events,
                self.parallel.as_ref().map(|p| &p.joints),
            )
        });
        let Some(par) = &mut self.parallel else {
            self.accumulated.fracture += released.value();
            return (el, js);
        };
        // Stage 4's skin test for this rank's nodes, answered at the meeting (the nodes do
        // not move before stage 7).
        let moved_here = self.contact.is_enabled() && {
            let (owned, chunk) = (&par.owned_chunks[..], crate::integration::CHUNK);
            contact_detection::surface_moved_here(&mut self.contact_detection, &self.nodes.x, |n| {
                owned[n as usize / chunk]
            })
        };
        let (el, js, released) = par.close_joint_stages(
            &self.elements_ws.unit_partials,
            &released,
            &mut self.break_events,
            events_before,
            &mut self.joints,
            moved_here,
        );
        self.accumulated.fracture += released;
        (el, js)
    }

    /// Stage 7 (and the rigid bodies'); on a decomposed model, the exchange of the chunks'
    /// sums and of the nodes each rank advanced.
    fn integration_stage(&mut self, params: StepParams, body_frame: bool) -> IntegrationSums {
        let time = self.time;
        // Stage 7 writes the nodes and reads their body ids: lent out for the step.
        let node_body = std::mem::take(&mut self.nodes.body);
        let mut is = timed(&mut self.timers, Stage::Integration, || {
            let frame = body_frame.then_some((&node_body[..], &self.body_frame[..]));
            let is = integration::central_difference(
                &mut self.nodes,
                params,
                frame,
                self.parallel.as_ref().map(|p| &p.owned_chunks[..]),
                &mut self.integration_partials,
            );
            integration::rigid::gather_loads(&mut self.rigid, &mut self.nodes);
            is
        });
        self.nodes.body = node_body;
        let contact = self.contact.is_enabled();
        if let Some(par) = &mut self.parallel {
            let (sums, cs) = par.close_contact_and_integration(
                &self.integration_partials,
                &mut self.contact,
                contact,
                time,
            );
            is = sums;
            // The rank owning a rigid body's nodes has all their forces.
            par.share_rigid_loads(&mut self.rigid);
            if contact {
                self.close_contact_step(&cs);
            }
        }
        // Every rank advances every rigid body, after the nodes' sums: the same bits.
        timed(&mut self.timers, Stage::Integration, || {
            // A rigid body's motion is all rigid: relative to itself, nothing to damp.
            let rigid_params = StepParams {
                mass_damping: if body_frame { 0.0 } else { params.mass_damping },
                ..params
            };
            integration::rigid::advance(
                &mut self.rigid,
                &mut self.nodes,
                rigid_params,
                time,
                &mut is,
            );
        });
        if let Some(par) = &mut self.parallel {
            par.share_exports(&mut self.nodes);
        }
        is
    }

    /// Each body's mass-weighted mean velocity Σm·v/Σm over its nodes (v at t − dt/2), for
    /// mass damping relative to bodies. One pass over the nodes, in node order.
    fn update_body_frame(&mut self) {
        // Every node's velocity, not only the exported ones' (a decomposed model).
        self.synchronize_nodes();
        let nb = self.bodies.len();
        self.body_frame.clear();
        self.body_frame.resize(nb, Vec3::zeros());
        for (b, body) in self.bodies.iter().enumerate() {
            let (mut m, mut p) = (0.0, Vec3::zeros());
            for n in body.nodes.clone() {
                m += self.nodes.m[n];
                p += self.nodes.v[n] * self.nodes.m[n];
            }
            if m > 0.0 {
                self.body_frame[b] = p / m;
            }
        }
    }

    /// The gravity work is sampled as the state function W = Σ m·g·(x − X), exact while g is
    /// constant. When the script changes g between steps (from g_old to g), W would jump by
    /// (g − g_old)·Σ m(x − X) without any work done: that jump is taken out of the running
    /// sum (`accumulated.gravity_work`), so W grows by g·Δx from then on. The change is
    /// booked at the mid-step position x_n − dt_prev·v_{n−1/2}/2 (trapezoid in g), so a
    /// gravity ramp keeps the balance to O(dt²).
    fn gravity_changed(&mut self) {
        let g = self.loads.gravity;
        if let Some(g_old) = self.gravity_applied {
            if g_old != g {
                // Every node's position, not only the exported ones' (a decomposed model).
                self.synchronize_nodes();
                // Fixed chunks summed in order: the same for any thread count.
                const CHUNK: usize = 4096;
                let nodes = &self.nodes;
                // Booked at the middle of the last step, x_n − dt_prev·v(t − dt/2)/2: the
                // work of g is then the trapezoid ½(g_old + g)·ΔΣmx over that step, and a
                // ramp of g keeps the balance to O(dt²) instead of O(dt).
                let back = 0.5 * self.dt_prev;
                let partial: Vec<Vec3> = (0..nodes.len().div_ceil(CHUNK))
                    .into_par_iter()
                    .map(|c| {
                        (c * CHUNK..((c + 1) * CHUNK).min(nodes.len()))
                            .map(|n| (nodes.x[n] - nodes.v[n] * back - nodes.x0[n]) * nodes.m[n])
                            .sum::<Vec3>()
                    })
                    .collect();
                let moment: Vec3 = partial.iter().sum();
                self.accumulated.gravity_work -= (g - g_old).dot(&moment);
            }
        }
        self.gravity_applied = Some(g);
    }

    /// Stages 4 and 5: stage 4 refreshes the candidate pairs and hands stage 5 the remap of
    /// its pair history; stage 5 adds the contact forces, and the joints whose faces contact
    /// took over stop acting (on a decomposed model after the step's second meeting). A
    /// friction law's invalid result stops the run after stage 7 (`step`).
    fn contact_stages(&mut self) {
        self.contact_detection.joints_broke(&self.break_events);
        // On a decomposed model: whether stage 4 detects this step (None: not asked). The
        // answer is the same on every rank (each tests its own nodes; combined).
        let mut detects = None;
        if let Some(par) = &mut self.parallel {
            detects = Some(contact_detection::must_detect(
                &self.contact_detection,
                &self.nodes.x,
                Some(par as &mut dyn contact_detection::PairExchange),
            ));
        }
        // Each rank searches and keeps the pairs it computes, after making current the
        // positions the search reads: exchange time, not stage 4's (taken out below).
        let exchange_before = self.parallel.as_ref().map_or(0.0, |p| p.seconds);
        timed(&mut self.timers, Stage::ContactDetection, || {
            if let Some(par) = &self.parallel {
                // The whole list was shared (output, a checkpoint, a new split): this
                // rank's pairs again.
                let computes = &par.partition.tet_relevant;
                if contact_detection::keep_this_ranks_pairs(&mut self.contact_detection, computes) {
                    let remap = self.contact_detection.take_remap();
                    self.contact.carry_history(remap);
                }
            }
            let incremental_before = self.contact_detection.detector.incremental;
            // (A quiet step answered above need not run the skin test again.)
            if detects != Some(false)
                && contact_detection::update_pairs(
                    &mut self.contact_detection,
                    &mut self.nodes,
                    &self.tets,
                    &self.bodies,
                    &self.joints,
                    self.parallel
                        .as_mut()
                        .map(|p| p as &mut dyn contact_detection::PairExchange),
                )
            {
                if let Some(par) = &mut self.parallel {
                    // (Before the remap goes to stage 5: it marks the added pairs.)
                    let cd = &self.contact_detection;
                    let generation = (cd.detector.detections, cd.detector.incremental);
                    par.follow_pairs(&self.tets, &cd.surface, &cd.pairs, &cd.origins, generation);
                    if cd.detector.incremental != incremental_before {
                        // Stage 5 reads the added pairs' nodes on every rank computing them.
                        par.share_added_pairs_nodes(&mut self.nodes);
                    }
                }
                let remap = self.contact_detection.take_remap();
                self.contact.carry_history(remap);
            }
            if let Some(par) = &mut self.parallel {
                let cd = &mut self.contact_detection;
                if !self.contact.mask.is_for(cd.pairs.len()) {
                    self.contact.mask = par.contact_mask(&cd.surface, &cd.pairs);
                    // The whole model's count, for the summary and the script's queries.
                    let designated = self.contact.mask.designated.iter().filter(|&&d| d);
                    cd.all_ranks_pairs = par.sum_in_rank_order(designated.count() as Real) as usize;
                    par.pairs_held = par.pairs_held.max(cd.pairs.len());
                }
                // (After a split without a detection: from this rank's list, taken from the
                // whole one above.)
                let generation = (cd.detector.detections, cd.detector.incremental);
                par.follow_pairs(&self.tets, &cd.surface, &cd.pairs, &[], generation);
            }
        });
        if let Some(par) = &self.parallel {
            self.timers.seconds[Stage::ContactDetection as usize] -= par.seconds - exchange_before;
        }
        let cs = timed(&mut self.timers, Stage::ContactInteraction, || {
            contact_interaction::add_contact_forces(
                &mut self.contact,
                &self.contact_detection,
                &mut self.nodes,
                &self.tets,
                &self.joints.keeps_faces,
                self.dt_prev,
                self.time,
            )
        });
        if self.parallel.is_none() {
            // (A decomposed model's totals come at the step's second meeting.)
            self.close_contact_step(&cs);
        }
    }

    /// What stage 5's totals change after it: the joints contact took over, the contact
    /// energies of the account. (A friction law's failure stops the run after stage 7,
    /// from `contact.last`.)
    fn close_contact_step(&mut self, cs: &contact_interaction::ContactSums) {
        self.joints.hand_over(&self.contact.handover);
        self.contact_energy = cs.energy;
        self.contact_dissipated = cs.dissipated;
    }

    /// The energy account at t_n: path-dependent terms summed up to t_n with the trapezoidal
    /// rule (this step's "before" share is the last piece); kinetic energy in the form the
    /// central difference conserves; gravity work a state function of x_n; force work a
    /// trapezoid in displacement up to x_n. The viscous power is evaluated once per step (with
    /// v(t − dt/2)) and split evenly between the two halves. On samples, inverted elements or
    /// a non-finite kinetic energy stop the run; non-finite positions or velocities always do.
    fn account(
        &mut self,
        sample: bool,
        el: &elements::ElementSums,
        js: &crate::joints::JointSums,
        is: &IntegrationSums,
        (bars, bond): (&elements::bar2::BarSums, &crate::joints::bond::BondSums),
    ) -> Result<(), SimError> {
        let dt = self.dt;
        let viscous = el.viscous_power * 0.5 * (self.dt_prev + dt);
        // The body force m·b at t works over both half steps around t (as the reactions):
        // b·Σm·Δx, with Σm·Δx = dt·Σm·v of each half step.
        let b = self.loads.body_acceleration;
        let ground_before = 0.5 * b.dot(&self.momentum_before) * self.dt_prev;
        let ground_after = 0.5 * b.dot(&is.momentum) * dt;
        self.momentum_before = is.momentum;
        if sample {
            let a = &self.accumulated;
            self.energy = Energy {
                kinetic: is.kinetic,
                strain: el.strain_energy + bars.strain_energy,
                gravity_work: is.gravity_work + a.gravity_work,
                force_work: self.loads.force_work,
                reaction_work: a.reaction_work + is.reaction_work_before,
                ground_work: a.ground_work + ground_before,
                mass_damping: a.mass_damping + is.damping_before,
                viscous_damping: a.viscous_damping + 0.5 * viscous,
                joint: js.energy,
                fracture: a.fracture + js.dissipated,
                contact: self.contact_energy,
                friction: a.friction + self.contact_dissipated,
                // Per-bar and per-point running sums, added in id order.
                plastic: self.bars.dissipated.iter().sum::<Real>()
                    + self.bars.hinges.dissipated.iter().sum::<Real>(),
                bond: bond.energy,
                bond_slip: self.bonds.dissipated.iter().sum(),
                initial: if self.step == 0 {
                    is.kinetic + el.strain_energy + bars.strain_energy + bond.energy
                } else {
                    self.energy.initial
                },
                floor: self.energy_floor(),
            };
            self.energy_history.push(EnergySample {
                step: self.step,
                time: self.time,
                energy: self.energy,
            });
            if !self.energy.kinetic.is_finite() {
                return Err(self.unstable(el.inverted));
            }
        }
        // Every step: stage 7 counted the nodes it made non-finite.
        if is.non_finite > 0 {
            return Err(self.unstable(el.inverted));
        }
        self.accumulated.viscous_damping += viscous;
        self.accumulated.fracture += js.dissipated;
        self.accumulated.friction += self.contact_dissipated;
        self.accumulated.mass_damping += is.damping_before + is.damping_after;
        self.accumulated.reaction_work += is.reaction_work_before + is.reaction_work_after;
        self.accumulated.ground_work += ground_before + ground_after;
        Ok(())
    }

    /// What stopped the run, where, in which stage, and the likely cause: the first node
    /// made non-finite by stage 7 (integration), or the first element found inverted by
    /// stage 1 (elements) from the positions the previous step produced.
    /// The error that stops an unstable run, described from the whole model's state (a
    /// decomposed model is synchronised first: a collective every rank reaches alike).
    fn unstable(&mut self, inverted: usize) -> SimError {
        self.synchronize();
        SimError::Unstable(self.describe_instability(inverted))
    }

    fn describe_instability(&self, inverted: usize) -> String {
        self.describe_instability_found_by(
            inverted,
            &format!("stage 1 (elements) of step {}", self.step),
        )
    }

    /// [`Self::describe_instability`], the inverted elements found by `found_by`.
    fn describe_instability_found_by(&self, inverted: usize, found_by: &str) -> String {
        let (step, t, dt) = (self.step, self.time, self.dt);
        if let Some(n) = (0..self.nodes.len()).find(|&n| !self.node_is_finite(n)) {
            let owner = match self.rebars.iter().find(|r| r.nodes.contains(&n)) {
                Some(r) => format!("rebar '{}'", r.name),
                None => format!("body '{}'", self.bodies[self.nodes.body[n] as usize].name),
            };
            let p = self.nodes.x0[n];
            return format!(
                "{} node(s) got a non-finite position or velocity in step {step} (stage 7, integration; t = {t:.6e} → {:.6e} s, dt = {dt:.4e} s); first: node {n} of {owner}, reference position {}. Likely cause: a non-finite force (a law or a table returned NaN or ∞), or a stiffness far above the one the time step was chosen for (a contact or joint penalty, a stiffening material); check the loads and laws acting there",
                (0..self.nodes.len()).filter(|&i| !self.node_is_finite(i)).count(),
                t + dt,
                crate::math::fmt_place(&p)
            );
        }
        if let Some(e) = (0..self.tets.len()).find(|&e| self.tet_is_inverted(e)) {
            let b = &self.bodies[self.tets.body[e] as usize].name;
            let c = self.current_centroid(e);
            let j = elements::deformation_gradient(&self.tets, &self.nodes.x, e).determinant();
            return format!(
                "{inverted} element(s) inverted (det F ≤ 0) in step {} (by its motion, t = {:.6e} → {t:.6e} s, dt = {dt:.4e} s), found by {found_by}; first: tet {e} of body '{b}' at {} with det F = {j:.3e}. Likely cause: {}",
                step.saturating_sub(1),
                t - self.dt_prev,
                crate::math::fmt_place(&c),
                self.inversion_cause(e)
            );
        }
        format!(
            "non-finite energy in step {step} (t = {t:.6e} s, dt = {dt:.4e} s); likely cause: a law returned NaN or ∞"
        )
    }

    /// The likeliest reason why tet `e` inverted, from its nodes' speed against the material's
    /// wave speed, its elastic law, and whether contact is on.
    fn inversion_cause(&self, e: usize) -> String {
        let m = &self.materials[self.tets.material[e] as usize];
        let c = (m.young / m.density).sqrt();
        let v = self.tets.nodes[e]
            .iter()
            .map(|&n| self.nodes.v[n as usize].norm())
            .fold(0.0, Real::max);
        let mut causes = Vec::new();
        if let Some(info) = self
            .dt_info
            .as_ref()
            .filter(|i| self.dt > i.critical * (1.0 + 1e-9))
        {
            causes.push(format!(
                "the time step {:.4e} s is above the critical step {:.4e} s (lower it)",
                self.dt, info.critical
            ));
        }
        if v > 0.1 * c {
            causes.push(format!(
                "its nodes move at {v:.4e} m/s, {:.2} of the material's wave speed √(E/ρ) = {c:.4e} m/s: the impact or prescribed velocity crushes the elements faster than they can resist (lower the loading rate, or refine the mesh there)",
                v / c
            ));
        }
        if m.formulation == Formulation::SmallStrain {
            causes.push(format!(
                "material '{}' is elastic/small_strain, which offers no resistance to large compression or rotation (use elastic/neo_hookean or elastic/munjiza for large deformation)",
                m.name
            ));
        }
        if causes.is_empty() && self.contact.is_enabled() {
            causes.push("a load or a contact crushed it: a contact penalty too low for the impact (bodies pass through each other), a load concentrated on a few nodes, or a material far softer than intended (check the contact penalty, the loads and E)".into());
        }
        if causes.is_empty() {
            causes.push("the loads crushed it: a force concentrated on a few nodes, prescribed motions that squeeze it, or a material far softer than intended (check the loads and E)".into());
        }
        causes.join("; or ")
    }

    /// Mass-proportional damping beyond the central difference's limit is an error. With
    /// c = α·dt̄/2 the step multiplies the velocity of a free node by (1 − c)/(1 + c): for
    /// α·dt̄ > 2 that factor is negative, so every velocity reverses each step (the scheme stays
    /// bounded, since |(1 − c)/(1 + c)| < 1, and its critical step ω·dt ≤ 2 does not change
    /// with α: for m·ẍ + α·m·ẋ + k·x = 0 the step's characteristic polynomial
    /// (1 + c)λ² − (2 − ω²dt²)λ + (1 − c) has |λ| ≤ 1 for any c ≥ 0 when ω·dt ≤ 2). So the
    /// limit is α·dt ≤ 2, where the velocity is reset to zero every step; physical damping
    /// (critical damping of the lowest mode, 2ω₁) is usually orders of magnitude below it.
    pub fn check_mass_damping(&self) -> Result<(), SimError> {
        let alpha = self.settings.mass_damping;
        let dt = self.dt.max(self.dt_prev);
        if alpha * dt > 2.0 {
            return Err(SimError::Invalid(format!(
                "mass-proportional damping α = {alpha:.4e} 1/s with dt = {dt:.4e} s gives α·dt = {:.4e}, above the central difference's limit 2: each step would multiply velocities by (1 − α·dt/2)/(1 + α·dt/2) = {:.3}, reversing them; use α ≤ 2/dt = {:.4e} 1/s (critical damping of the lowest mode is 2ω₁, usually far less)",
                alpha * dt,
                (1.0 - 0.5 * alpha * dt) / (1.0 + 0.5 * alpha * dt),
                2.0 / dt
            )));
        }
        Ok(())
    }

    /// What a friction law returned, where, and what it was given.
    fn describe_friction_failure(
        &self,
        f: &crate::contact_interaction::FrictionLawFailure,
    ) -> String {
        let law = &self.contact.laws.friction_laws[f.law as usize];
        let body = |t: u32| &self.bodies[self.tets.body[t as usize] as usize].name;
        let inputs: Vec<String> = crate::contact_interaction::FrictionInputs::NAMES
            .iter()
            .zip(f.inputs.to_slots())
            .map(|(name, v)| format!("c.{name} = {v:.6e}"))
            .collect();
        format!(
            "friction law '{}' returned friction = {} (μ must be finite and ≥ 0) in step {} (t = {:.6e} s) for the pair of tet {} (body '{}') and tet {} (body '{}') at {}; its inputs: {}",
            law.name,
            f.friction,
            self.step,
            self.time,
            f.tets[0],
            body(f.tets[0]),
            f.tets[1],
            body(f.tets[1]),
            crate::math::fmt_place(&f.point),
            inputs.join(", ")
        )
    }

    /// det F ≤ 0 (or NaN) at the current positions.
    fn tet_is_inverted(&self, e: usize) -> bool {
        let j = elements::deformation_gradient(&self.tets, &self.nodes.x, e).determinant();
        j.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
    }

    fn node_is_finite(&self, n: usize) -> bool {
        self.nodes.x[n]
            .iter()
            .chain(self.nodes.v[n].iter())
            .all(|c| c.is_finite())
    }

    /// [`Simulation::check_configuration`] on a decomposed model whose nodes are current only
    /// where each rank computes: each rank checks the tets of its piece (the tets whose
    /// first node it owns, every tet on one rank) and the counts are added (a collective).
    /// When some tet is inverted, every rank shares the whole state and reports it as one
    /// process would.
    pub fn check_configuration_by_pieces(&mut self) -> Result<(), SimError> {
        let Some(par) = self.parallel.as_ref().filter(|p| p.partition.is_split()) else {
            return self.check_configuration();
        };
        let me = par.rank();
        let mine = (0..self.tets.len())
            .into_par_iter()
            .filter(|&e| par.piece_of_tet(&self.tets, e) == me && self.tet_is_inverted(e))
            .count();
        let par = self.parallel.as_mut().expect("decomposed");
        if par.sum_in_rank_order(mine as Real) == 0.0 {
            return Ok(());
        }
        self.synchronize();
        self.check_configuration()
    }

    /// Check the current configuration for inverted elements (stage 1 checks only on energy
    /// samples); called at the end of every run so that no run ends silently broken.
    pub fn check_configuration(&self) -> Result<(), SimError> {
        let inverted = (0..self.tets.len())
            .into_par_iter()
            .filter(|&e| self.tet_is_inverted(e))
            .count();
        if inverted > 0 {
            return Err(SimError::Unstable(self.describe_instability_found_by(
                inverted,
                &format!(
                    "the check of the configuration after step {}",
                    self.step.saturating_sub(1)
                ),
            )));
        }
        Ok(())
    }
}

/// Run one stage and add its wall time to the stage's timer.
#[inline(always)]
fn timed<R>(timers: &mut StageTimers, stage: Stage, f: impl FnOnce() -> R) -> R {
    let t = Instant::now();
    let r = f();
    timers.seconds[stage as usize] += t.elapsed().as_secs_f64();
    r
}

/// What a frame of the model reads besides the nodes and the mesh: each joint's largest
/// damage (empty without joints), and with contact the contact force on each node and the
/// largest mean contact pressure on each tet in the last step ([`crate::io::frame`]).
#[derive(Clone, Debug, Default)]
pub struct FrameReads {
    pub joint_damage: Vec<Real>,
    pub contact_force: Vec<Vec3>,
    pub contact_pressure: Vec<Real>,
}

impl FrameReads {
    /// From this process's copy of the state (one process, or a decomposed model's after
    /// [`Simulation::synchronize`]).
    pub fn of(sim: &Simulation) -> Self {
        let (contact_force, contact_pressure) = Self::contact(sim);
        FrameReads {
            joint_damage: Self::joint_damage(sim),
            contact_force,
            contact_pressure,
        }
    }

    fn joint_damage(sim: &Simulation) -> Vec<Real> {
        (0..sim.joints.len())
            .map(|j| sim.joints.largest_damage(j))
            .collect()
    }

    /// The contact force per node and pressure per tet from touching pairs' `outputs` in
    /// pair order (what a decomposed model's ranks gathered or exchanged).
    fn contact_from(
        outputs: &[contact_interaction::PairOut],
        sim: &Simulation,
    ) -> (Vec<Vec3>, Vec<Real>) {
        (
            contact_interaction::node_forces_of(outputs.iter(), sim.nodes.len()),
            contact_interaction::tet_pressures_of(outputs.iter(), sim.tets.len()),
        )
    }

    fn contact(sim: &Simulation) -> (Vec<Vec3>, Vec<Real>) {
        if !sim.contact.is_enabled() {
            return (Vec::new(), Vec::new());
        }
        (
            sim.contact.node_forces(sim.nodes.len()),
            sim.contact.tet_pressures(sim.tets.len()),
        )
    }
}

/// What [`Simulation::repartition`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Repartitioned {
    /// Wall time it took [s] (the checks alone when it declined).
    pub seconds: f64,
    /// Nodes that changed rank (0 when it declined or nothing moved).
    pub moved_nodes: usize,
    /// The imbalance it measured, when asked to (`if_imbalance`).
    pub imbalance: Option<Real>,
}

/// The nodes (of `n_nodes`) in the chunks whose owner differs between `now` and `before`.
fn nodes_changing_rank(now: &[u32], before: &[u32], n_nodes: usize) -> usize {
    let chunk = integration::CHUNK;
    (now.iter().zip(before).enumerate())
        .filter(|(_, (now, was))| now != was)
        .map(|(c, _)| n_nodes.min((c + 1) * chunk) - c * chunk)
        .sum()
}
