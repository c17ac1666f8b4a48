//! Stage 3 — fracture: joints whose every integration point is fully damaged (D = 1) break.
//! A broken joint keeps its compression penalty and friction (so the two faces do not
//! interpenetrate before contact takes over); its faces become free surfaces. Each break is
//! recorded as an event (time, centroid, mode, body).
//!
//! Fragments are the connected components of tetrahedra over intact joints and shared nodes.

mod fragments;

pub use fragments::{same_partition, FragmentTracker};

use crate::joints::{joint_kinematics, Joints};
use crate::math::{ExactSum, Real, Vec3};

/// How a joint broke, from the direction of its total opening and slip at failure.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BreakMode {
    /// Opening dominated (slip share below tan 15°).
    I,
    /// Slip dominated (opening share below tan 15°).
    II,
    Mixed,
}

impl BreakMode {
    pub fn name(self) -> &'static str {
        match self {
            BreakMode::I => "I",
            BreakMode::II => "II",
            BreakMode::Mixed => "mixed",
        }
    }

    /// Numeric code for CSV and VTK output: 1 = I, 2 = II, 3 = mixed.
    pub fn code(self) -> i32 {
        match self {
            BreakMode::I => 1,
            BreakMode::II => 2,
            BreakMode::Mixed => 3,
        }
    }
}

/// A joint that broke.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct BreakEvent {
    pub joint: usize,
    pub time: Real,
    pub centroid: Vec3,
    pub mode: BreakMode,
    /// Body of the tetrahedron on side A.
    pub body: u32,
}

/// When a user fracture criterion is consulted.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CriterionWhen {
    /// For fully damaged joints (all points at D = 1): the joint breaks only when the
    /// criterion also says so; until then it stays pending and is asked again every step.
    Damaged,
    /// Every `every` steps for every intact joint: the joint breaks when the criterion says
    /// so, or when it is fully damaged.
    Always { every: u64 },
}

crate::compiled::law_signature! {
    /// Inputs of a fracture criterion, per joint: largest damage [-], mean opening and slip
    /// [m], largest opening and slip so far [m], centroid x, y, z [m], size [m], time [s].
    pub struct CriterionInputs {
        damage, opening, slip, max_opening, max_slip, x, y, z, size, time
    }
    /// A fracture criterion: `fn criterion(j, p)` returning true (break) or false.
    pub const CRITERION = "fracture criterion" -> ["broken"];
}

/// Keys of `sim.fracture_criterion(#{ … })`.
pub const CRITERION_PARAMS: &[crate::params::Param] = &[
    crate::params::Param::other("function", "string", "", "required", "Name of the Rhai function `fn name(j, p)` returning true to break (compiled to native code). Inputs j.damage (largest over the joint's points), j.opening, j.slip (means), j.max_opening, j.max_slip (largest so far), j.x, j.y, j.z (centroid), j.size, j.time."),
    crate::compiled::PARAMS_KEY,
    crate::compiled::SOURCE_KEY,
    crate::params::Param::other("when", "string", "", "\"damaged\"", "\"damaged\": asked only for fully damaged joints, which break when it agrees (e.g. an extra opening needed); \"always\": asked for every intact joint every `every` steps, which break when it says so (or at D = 1)."),
    crate::params::Param::other("every", "int", "steps", "1", "With when: \"always\": how often the criterion is evaluated (it costs one compiled call per joint)."),
];

/// A fracture criterion written in Rhai and compiled ([`CRITERION`]).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct FractureCriterion {
    pub function: std::sync::Arc<crate::compiled::CompiledLaw>,
    pub when: CriterionWhen,
    /// Fully damaged joints the criterion has not let break yet.
    pending: Vec<usize>,
}

impl FractureCriterion {
    pub fn new(
        function: std::sync::Arc<crate::compiled::CompiledLaw>,
        when: CriterionWhen,
    ) -> Self {
        FractureCriterion {
            function,
            when,
            pending: Vec::new(),
        }
    }

    /// The joints it keeps from breaking, from the joints' state: those `relevant` (every
    /// joint on one process; a rank's own after a split), fully damaged and not broken, in
    /// joint order. A decomposed model calls it at each split, when every joint's history
    /// is whole: the list before was the old split's (or, after a restart, the process's
    /// that wrote the checkpoint), and a joint it names may no longer be this rank's.
    pub fn pending_again(&mut self, joints: &Joints, relevant: impl Fn(usize) -> bool) {
        if matches!(self.when, CriterionWhen::Always { .. }) {
            // (Such a criterion keeps none: it breaks every fully damaged joint at once.)
            self.pending.clear();
            return;
        }
        self.pending = (0..joints.len())
            .filter(|&j| relevant(j) && failed_unbroken(joints, j))
            .collect();
    }

    /// Ask the criterion about joint `j`.
    fn says_break(&self, joints: &Joints, j: usize, x: &[Vec3], time: Real) -> bool {
        let (_, _, pts) = joint_kinematics(&joints.faces[j], x);
        let st = &joints.state[j];
        let c = joints.faces[j]
            .iter()
            .flatten()
            .map(|&n| x[n as usize])
            .sum::<Vec3>()
            / 6.0;
        let inputs = CriterionInputs {
            damage: st.iter().map(|p| p.damage).fold(0.0, Real::max),
            opening: pts.iter().map(|p| p.0).sum::<Real>() / 3.0,
            slip: pts.iter().map(|p| p.1).sum::<Real>() / 3.0,
            max_opening: st
                .iter()
                .map(|p| p.max_opening)
                .fold(Real::NEG_INFINITY, Real::max),
            max_slip: st.iter().map(|p| p.max_slip).fold(0.0, Real::max),
            x: c.x,
            y: c.y,
            z: c.z,
            size: joints.size[j],
            time,
        };
        let [b] = self.function.evaluate(&inputs.to_slots());
        b != 0.0 && !b.is_nan()
    }
}

/// The joints a rank of a decomposed model works on (crate::parallel): `relevant`, those at
/// one of its nodes (their state is current on this rank); `designated`, those whose sums it
/// reports (each joint on exactly one rank).
#[derive(Clone, Debug, Default)]
pub struct JointMask {
    pub relevant: Vec<bool>,
    pub designated: Vec<bool>,
}

impl JointMask {
    /// Joint `j` is designated to this rank: false for a joint added since the split (the
    /// model edited between steps: it is the same on every rank until the next split).
    pub fn designates(&self, j: usize) -> bool {
        self.designated.get(j).copied().unwrap_or(false)
    }
}

/// Joint `j` is fully damaged (D = 1 at every point) and not broken yet.
fn failed_unbroken(joints: &Joints, j: usize) -> bool {
    !joints.broken[j] && joints.state[j].iter().all(|p| p.damage >= 1.0)
}

/// Stage 3: break the joints whose points all reached D = 1 (subject to a user criterion, if
/// any) and record the events. Returns the energy released by joints a criterion broke before
/// they were fully damaged [J] (their stored energy, counted as fracture dissipation), as an
/// exact sum ([`ExactSum`]: ranks add theirs to the one-process bits). With `mask`, only the
/// relevant joints are looked at, and only the designated ones' energy is returned.
#[allow(clippy::too_many_arguments)]
pub fn break_joints(
    joints: &mut Joints,
    x: &[Vec3],
    tet_body: &[u32],
    time: Real,
    step: u64,
    newly_failed: usize,
    criterion: Option<&mut FractureCriterion>,
    events: &mut Vec<BreakEvent>,
    mask: Option<&JointMask>,
) -> ExactSum {
    let relevant = |j: usize| mask.is_none_or(|m| m.relevant[j]);
    let failed = |joints: &Joints, j: usize| relevant(j) && failed_unbroken(joints, j);
    let mut released = ExactSum::default();
    let first_event = events.len();
    // The joints that failed this step, in joint order, from the units that counted them
    // (not a look at every joint: on a rank of a large model that was a pass over the whole
    // model's joint states at every step where one broke).
    let failed_now = |joints: &mut Joints| -> Vec<usize> {
        if newly_failed == 0 {
            return Vec::new();
        }
        let units = joints.units_with_new_failures().to_vec();
        units
            .into_iter()
            .flatten()
            .filter(|&j| failed(joints, j))
            .collect()
    };
    match criterion {
        None => {
            for j in failed_now(joints) {
                record(joints, j, x, tet_body, time, events);
            }
        }
        Some(c) => {
            for j in failed_now(joints) {
                if !c.pending.contains(&j) {
                    c.pending.push(j);
                }
            }
            // Fully damaged joints break when the criterion agrees (Damaged) or at once (Always).
            let mut still = Vec::new();
            for j in std::mem::take(&mut c.pending) {
                if joints.broken[j] {
                    continue;
                }
                if matches!(c.when, CriterionWhen::Always { .. })
                    || c.says_break(joints, j, x, time)
                {
                    record(joints, j, x, tet_body, time, events);
                } else {
                    still.push(j);
                }
            }
            c.pending = still;
            if let CriterionWhen::Always { every } = c.when {
                if step.is_multiple_of(every.max(1)) {
                    for j in 0..joints.len() {
                        if relevant(j) && !joints.broken[j] && c.says_break(joints, j, x, time) {
                            if mask.is_none_or(|m| m.designated[j]) {
                                released.add(joints.stored_energy(j, x));
                            }
                            // Fully damaged now; the friction springs start unstretched
                            // and hold nothing (a softening point's last energy was its
                            // cohesive ψ₀: left in place, the next opening would release it
                            // as friction work no force did).
                            let (_, _, pts) = crate::joints::joint_kinematics(&joints.faces[j], x);
                            for (p, (_, ds, dir)) in pts.into_iter().enumerate() {
                                joints.state[j][p].damage = 1.0;
                                joints.set_anchor_global(j, p, x, dir * ds);
                                joints.last_energy[j][p] = 0.0;
                                joints.slid[j][p] = 0.0;
                                joints.offset[j][p] = Vec3::zeros();
                            }
                            record(joints, j, x, tet_body, time, events);
                        }
                    }
                }
            }
        }
    }
    // A step's events in joint order, whoever broke them and in whatever order (a
    // criterion's waiting joints, its `always` checks, the failed joints): the order a
    // decomposed model's ranks merge them in.
    events[first_event..].sort_by_key(|e| e.joint);
    released
}

fn record(
    joints: &mut Joints,
    j: usize,
    x: &[Vec3],
    tet_body: &[u32],
    time: Real,
    events: &mut Vec<BreakEvent>,
) {
    joints.broken[j] = true;
    let (_, _, pts) = joint_kinematics(&joints.faces[j], x);
    let (open, slip) = pts
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0.max(0.0), a.1 + p.1));
    let angle = Real::atan2(slip, open).to_degrees();
    let mode = if angle < 15.0 {
        BreakMode::I
    } else if angle > 75.0 {
        BreakMode::II
    } else {
        BreakMode::Mixed
    };
    let c = joints.faces[j][0]
        .iter()
        .chain(&joints.faces[j][1])
        .map(|&n| x[n as usize])
        .sum::<Vec3>()
        / 6.0;
    events.push(BreakEvent {
        joint: j,
        time,
        centroid: c,
        mode,
        body: tet_body[joints.tets[j][0] as usize],
    });
}

/// Fragments with their volumes [m³] and masses [kg]: (fragment id per tet, volumes, masses).
pub fn fragment_sizes(
    tets: &crate::state::Tets,
    materials: &[crate::material::Material],
    joints: &Joints,
    n_nodes: usize,
) -> (Vec<u32>, Vec<Real>, Vec<Real>) {
    let id = fragments(&tets.nodes, joints, n_nodes);
    let count = id.iter().max().map_or(0, |m| *m as usize + 1);
    let (mut volume, mut mass) = (vec![0.0; count], vec![0.0; count]);
    for (e, &f) in id.iter().enumerate() {
        volume[f as usize] += tets.vol0[e];
        mass[f as usize] += tets.vol0[e] * materials[tets.material[e] as usize].density;
    }
    (id, volume, mass)
}

/// Connected components of tetrahedra over shared nodes and intact joints: a fragment id per
/// tet, numbered 0.. in order of first tet.
pub fn fragments(tet_nodes: &[[u32; 4]], joints: &Joints, n_nodes: usize) -> Vec<u32> {
    FragmentTracker::build(tet_nodes, &joints.tets, &joints.broken, n_nodes).labels()
}
