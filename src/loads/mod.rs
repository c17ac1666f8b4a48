//! Stage 6 — external loads: gravity, nodal forces and surface tractions (each optionally
//! scaled by a time function), prescribed velocities of node sets (fixed nodes are a
//! prescribed velocity of zero), and ground shaking by earthquake records ([`shaking`]).
//!
//! Reads the time and positions; adds nodal forces to `f`, writes the prescribed velocity of
//! constrained components at t + dt/2 into `v_prescribed` (stage 7 imposes it) and keeps the
//! work of the applied forces, integrated with the trapezoidal rule in displacement:
//! W += ½(F(t) + F(t−dt))·(x(t) − x(t−dt)) (exact for constant loads).

pub mod ground_motion;
pub mod shaking;
mod table;
mod time_function;

pub use ground_motion::GroundMotion;
pub use shaking::{GroundRecord, Shaking, ShakingKind};
pub use table::{parse_table, read_table, BadLine, TableError};
pub use time_function::TimeFunction;

use crate::math::{Real, Vec3};
use crate::state::Nodes;

/// A set of nodal forces: node i gets `force[i]·scale(t)` [N].
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct NodalForces {
    pub nodes: Vec<u32>,
    pub force: Vec<Vec3>,
    pub scale: TimeFunction,
    prev_x: Vec<Vec3>,
    prev_scale: Real,
    started: bool,
}

impl NodalForces {
    pub fn new(nodes: Vec<u32>, force: Vec<Vec3>, scale: TimeFunction) -> Self {
        assert_eq!(nodes.len(), force.len());
        NodalForces {
            nodes,
            force,
            scale,
            prev_x: Vec::new(),
            prev_scale: 0.0,
            started: false,
        }
    }
    /// A surface traction `t` [Pa] on the reference area of `faces` (a dead load), lumped as
    /// area/3 to each face node; nodes appear once, in id order.
    pub fn traction(
        faces: &[crate::mesh::BoundaryFace],
        x0: &[Vec3],
        t: Vec3,
        scale: TimeFunction,
    ) -> Self {
        let mut per_node: std::collections::BTreeMap<u32, Vec3> = Default::default();
        for f in faces {
            let area = f.area_normal(x0).norm();
            for &n in &f.nodes {
                *per_node.entry(n).or_default() += t * (area / 3.0);
            }
        }
        let (nodes, force) = per_node.into_iter().unzip();
        Self::new(nodes, force, scale)
    }

    /// Total force at time t [N].
    pub fn total(&self, t: Real) -> Vec3 {
        self.force.iter().sum::<Vec3>() * self.scale.eval(t)
    }
}

/// Velocity prescribed on components of a node set; each component an optional function of time.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct PrescribedVelocity {
    pub nodes: Vec<u32>,
    pub components: [Option<TimeFunction>; 3],
}

impl PrescribedVelocity {
    pub fn mask(&self) -> u8 {
        (0..3)
            .filter(|&k| self.components[k].is_some())
            .fold(0, |m, k| m | (1 << k))
    }
}

/// Displacement components named by letters ("z", "xz", "xyz") as a mask [x, y, z]. An
/// error for any other letter, or for no letter at all.
pub fn parse_components(spec: &str) -> Result<[bool; 3], String> {
    let mut c = [false; 3];
    for ch in spec.chars() {
        match ch {
            'x' => c[0] = true,
            'y' => c[1] = true,
            'z' => c[2] = true,
            _ => {
                return Err(format!(
                    "components \"{spec}\" must use only the letters x, y, z"
                ))
            }
        }
    }
    if c == [false; 3] {
        return Err("no component given; use e.g. \"xyz\" or \"z\"".into());
    }
    Ok(c)
}

/// Everything stage 6 applies.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Loads {
    /// Gravitational acceleration g [m/s²], applied to every node by stage 7.
    pub gravity: Vec3,
    /// Gravity that varies in time: g(t) = g₀·s(t), set into `gravity` by stage 6 at the
    /// start of every step (None: `gravity` is constant).
    pub gravity_ramp: Option<(Vec3, TimeFunction)>,
    pub forces: Vec<NodalForces>,
    pub prescribed: Vec<PrescribedVelocity>,
    /// Ground motions driving the model (base motion or relative frame).
    pub shaking: Vec<Shaking>,
    /// Work done by nodal forces and tractions so far [J].
    pub force_work: Real,
    /// Set by stage 6 for stage 7: the relative-frame body acceleration −Σa_g(t) [m/s²].
    pub body_acceleration: Vec3,
    /// Set by stage 6 for stage 7: the ground velocity at t that mass damping measures
    /// velocities against (the first base motion's; zero without one) [m/s].
    pub frame_velocity: Vec3,
}

impl Loads {
    /// Rebuild the per-node constraint masks from the prescriptions (later ones win per
    /// component; nodes following a base motion are constrained in all three), and the list
    /// of constrained nodes ([`Nodes::index_constrained`]).
    pub fn apply_constraint_masks(&self, nodes: &mut Nodes) {
        nodes.constraint.iter_mut().for_each(|c| *c = 0);
        for p in &self.prescribed {
            let mask = p.mask();
            for &n in &p.nodes {
                nodes.constraint[n as usize] |= mask;
            }
        }
        for s in &self.shaking {
            if let ShakingKind::Base(base) = &s.kind {
                for &n in base {
                    nodes.constraint[n as usize] = 0b111;
                }
            }
        }
        nodes.index_constrained();
    }
}

/// Stage 6: add the applied forces at time `t`, set prescribed velocities for t + dt/2, and
/// advance the ground of each shaking over the step (`dt_prev`: the previous step, 0 on the
/// first). Base motions win over other prescriptions of their nodes.
pub fn add_external_forces(loads: &mut Loads, nodes: &mut Nodes, t: Real, dt_prev: Real, dt: Real) {
    if let Some((g0, s)) = &loads.gravity_ramp {
        loads.gravity = g0 * s.eval(t);
    }
    let mut work = 0.0;
    for set in &mut loads.forces {
        let s = set.scale.eval(t);
        if !set.started {
            set.prev_x = set.nodes.iter().map(|&n| nodes.x[n as usize]).collect();
            set.prev_scale = s;
            set.started = true;
        }
        for (i, &n) in set.nodes.iter().enumerate() {
            let n = n as usize;
            nodes.f[n] += set.force[i] * s;
            work += 0.5 * (s + set.prev_scale) * set.force[i].dot(&(nodes.x[n] - set.prev_x[i]));
            set.prev_x[i] = nodes.x[n];
        }
        set.prev_scale = s;
    }
    loads.force_work += work;
    let t_half = t + 0.5 * dt;
    let constrained = &mut nodes.constrained;
    for p in &loads.prescribed {
        let value = p
            .components
            .each_ref()
            .map(|c| c.as_ref().map(|tf| tf.eval(t_half)));
        for &n in &p.nodes {
            let Some(s) = constrained.slot(n) else {
                continue; // (listed at prepare: a prescription added since applies from then)
            };
            for k in 0..3 {
                if let Some(value) = value[k] {
                    constrained.v_prescribed[s][k] = value;
                }
            }
        }
    }
    loads.body_acceleration = Vec3::zeros();
    loads.frame_velocity = Vec3::zeros();
    let mut frame_set = false;
    for s in &mut loads.shaking {
        let a = s.advance(t, dt_prev, dt);
        match &s.kind {
            ShakingKind::Relative => loads.body_acceleration -= a,
            ShakingKind::Base(base) => {
                for &n in base {
                    if let Some(slot) = constrained.slot(n) {
                        constrained.v_prescribed[slot] = s.velocity;
                    }
                }
                if !frame_set {
                    loads.frame_velocity = s.velocity_at_step();
                    frame_set = true;
                }
            }
        }
    }
}
