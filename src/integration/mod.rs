//! Stage 7 — integration: explicit central difference with lumped mass.
//!
//! Reads the force accumulator `f` (internal + external), masses and constraints; writes
//! velocities and positions, the reactions of constrained components, and clears `f` for the
//! next step. With mass-proportional damping α [1/s] (damping force −α·m·v):
//!
//! ```text
//! v(t+dt/2) = [ (1 − α·dt̄/2)·v(t−dt/2) + dt̄·(f/m + g) ] / (1 + α·dt̄/2),  dt̄ = (dt_prev + dt)/2
//! x(t+dt)   = x(t) + dt·v(t+dt/2)
//! ```
//!
//! On the first step dt_prev = 0, so v(dt/2) = v(0) + (dt/2)·a(0), which makes the free fall
//! x(t) = x₀ + v₀t + gt²/2 exact. Gravity enters as an acceleration here (stage 6 chooses g),
//! and so does the body acceleration b = −a_g(t) of a relative-frame ground motion; the
//! constrained components take the prescribed velocity and report the reaction
//! R = m·(v_new − v_old)/dt̄ − f − m·(g + b). Under a base motion, damping acts on the velocity
//! relative to the ground v_f (the damping force is −α·m·(v − v_f)), so the rigid shaking of
//! a structure is not damped, only its motion relative to its base.
//!
//! Energy terms are summed over fixed-size chunks in a fixed order, so they are identical
//! for any thread count. Nodes of rigid bodies are skipped here: [`rigid`] moves them with
//! their body's six degrees of freedom.

pub mod rigid;

use crate::math::{Real, Vec3};
use crate::state::{Nodes, RIGID_NODE};
use rayon::prelude::*;

/// Nodes per parallel work item (fixed for deterministic partial sums).
pub const CHUNK: usize = 2048;

/// Sums over nodes produced by one integration step.
///
/// Work terms are split into the two trapezoid halves around t: `before` is the share of the
/// interval [t − dt, t] (½·F(t)·(x(t) − x(t−dt))) and `after` the share of [t, t + dt]
/// (½·F(t)·(x(t+dt) − x(t))). With the kinetic energy measured as ½m·v(t−dt/2)·v(t+dt/2),
/// the energy the central difference conserves exactly for linear systems, the account at t
/// is then exact up to the integrator's own O(dt²) error.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct IntegrationSums {
    /// Σ ½m·v(t−dt/2)·v(t+dt/2) [J] (when sampled). On the first step v(−dt/2) is the
    /// virtual 2v(0) − v(dt/2) for free components and v(0) for constrained ones.
    pub kinetic: Real,
    /// Σ m g·(x(t) − X): work done by gravity since the start [J] (when sampled).
    pub gravity_work: Real,
    /// Work of the reactions: share of [t − dt, t] and of [t, t + dt] [J].
    pub reaction_work_before: Real,
    pub reaction_work_after: Real,
    /// Energy removed by mass-proportional damping, shares as above [J].
    pub damping_before: Real,
    pub damping_after: Real,
    /// Chunks holding a non-finite position or velocity (checked every step).
    pub non_finite: usize,
    /// Σ m·v(t + dt/2) over all nodes (every step) [kg·m/s]: dt times it is the change of
    /// Σ m·x, with which the work of a uniform body acceleration is booked.
    pub momentum: Vec3,
}

impl IntegrationSums {
    /// The chunks' sums: exact sums, rounded once (the same bits for any thread or rank
    /// count, [`crate::math::ExactSum`]).
    pub fn total(partials: &[IntegrationSums]) -> IntegrationSums {
        crate::math::exact_total(partials)
    }
}

/// Step parameters.
#[derive(Clone, Copy, Debug)]
pub struct StepParams {
    pub dt: Real,
    pub dt_prev: Real,
    pub gravity: Vec3,
    /// Body acceleration besides gravity (a relative-frame ground motion) [m/s²]; its work
    /// is booked by the caller from [`IntegrationSums::momentum`].
    pub body_acceleration: Vec3,
    pub mass_damping: Real,
    /// Velocity that mass damping measures against (the ground's under a base motion) [m/s].
    pub frame_velocity: Vec3,
    pub sample: bool,
}

/// The coefficients of one central-difference step that nodes and rigid bodies share:
/// dt̄ = (dt_prev + dt)/2, the mass-damping factors (1 − c) and 1/(1 + c) with c = α·dt̄/2,
/// the two half steps, and the uniform acceleration g + b.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StepCoefficients {
    pub dt_bar: Real,
    pub c_old: Real,
    pub c_inv: Real,
    /// The first step (dt_prev = 0): v(−dt/2) is v(0).
    pub first: bool,
    pub half_before: Real,
    pub half_after: Real,
    pub body: Vec3,
}

impl StepParams {
    pub(crate) fn coefficients(&self) -> StepCoefficients {
        let dt_bar = 0.5 * (self.dt_prev + self.dt);
        let c = 0.5 * self.mass_damping * dt_bar;
        StepCoefficients {
            dt_bar,
            c_old: 1.0 - c,
            c_inv: 1.0 / (1.0 + c),
            first: self.dt_prev == 0.0,
            half_before: 0.5 * self.dt_prev,
            half_after: 0.5 * self.dt,
            body: self.gravity + self.body_acceleration,
        }
    }
}

/// Stage 7: advance velocities and positions by one central-difference step. With
/// `body_frame` (the body of every node and each body's velocity), mass damping acts on the
/// velocity relative to the node's body, −α·m·(v − V_body), instead of relative to
/// `p.frame_velocity`: a body's translation is then not damped, only its deformation and
/// rotation. `owned_chunks` (a rank of a decomposed model): the chunks of `CHUNK` nodes this
/// process advances; the other chunks' forces are only cleared (`None`: all).
/// Kept whole: one pass over every node, its body the central difference and the energy terms
/// it books; split, its parts would pass a dozen arrays and coefficients each.
pub fn central_difference(
    nodes: &mut Nodes,
    p: StepParams,
    body_frame: Option<(&[u32], &[Vec3])>,
    owned_chunks: Option<&[bool]>,
    partials: &mut Vec<IntegrationSums>,
) -> IntegrationSums {
    let StepCoefficients {
        dt_bar,
        c_old,
        c_inv,
        first,
        half_before,
        half_after,
        body,
    } = p.coefficients();
    // Damping towards the frame velocity: (1 + c)·v_new = (1 − c)·v_old + dt̄·(a + α·v_f).
    let frame_push = p.frame_velocity * p.mass_damping;
    let Nodes {
        x0,
        x,
        v,
        f,
        m,
        constraint,
        constrained,
        ..
    } = nodes;
    let (x0, m, constraint) = (&*x0, &*m, &*constraint);
    // The reactions first (read by the nodes' loop for their work).
    constraint_reactions(
        constrained,
        (v, f, m, constraint),
        dt_bar,
        body,
        owned_chunks,
    );
    let c = &*constrained;
    x.par_chunks_mut(CHUNK)
        .zip(v.par_chunks_mut(CHUNK))
        .zip(f.par_chunks_mut(CHUNK))
        .enumerate()
        .map(|(chunk, ((xs, vs), fs))| {
            let base = chunk * CHUNK;
            let mut s = IntegrationSums::default();
            if owned_chunks.is_some_and(|o| !o[chunk]) {
                fs.fill(Vec3::zeros());
                return s;
            }
            let mut finite_probe = 0.0;
            // The chunk's constrained nodes, met in node order.
            let mut slot = c.node.partition_point(|&c| (c as usize) < base);
            for i in 0..xs.len() {
                let n = base + i;
                let mask = constraint[n];
                if mask & RIGID_NODE != 0 {
                    continue; // moved by its rigid body (rigid::advance)
                }
                let mass = m[n];
                let v_old = vs[i];
                let acc = fs[i] / mass + body;
                let (frame_v, push) = match body_frame {
                    None => (p.frame_velocity, frame_push),
                    Some((of, vb)) => {
                        let vb = vb[of[n] as usize];
                        (vb, vb * p.mass_damping)
                    }
                };
                let mut v_new = (v_old * c_old + (acc + push) * dt_bar) * c_inv;
                if mask != 0 {
                    debug_assert_eq!(c.node[slot] as usize, n);
                    let r = c.reaction[slot];
                    for k in 0..3 {
                        if mask & (1 << k) != 0 {
                            v_new[k] = c.v_prescribed[slot][k];
                        }
                    }
                    slot += 1;
                    s.reaction_work_before += r.dot(&v_old) * half_before;
                    // A constraint may start with a velocity jump: its impulse works at the
                    // mean of the velocities before and after the jump.
                    let v_after = if first { (v_old + v_new) * 0.5 } else { v_new };
                    s.reaction_work_after += r.dot(&v_after) * half_after;
                }
                if p.mass_damping > 0.0 {
                    // The damping force −α·m·((v_old + v_new)/2 − v_f), free components only.
                    let mut fd = ((v_old + v_new) * 0.5 - frame_v) * (p.mass_damping * mass);
                    for k in 0..3 {
                        if mask & (1 << k) != 0 {
                            fd[k] = 0.0;
                        }
                    }
                    s.damping_before += fd.dot(&v_old) * half_before;
                    s.damping_after += fd.dot(&v_new) * half_after;
                }
                if p.sample {
                    // First step: the virtual v(−dt/2) = 2v(0) − v(dt/2) for free components; a
                    // constrained component may start with a velocity jump, so it keeps v(0).
                    let mut v_minus = v_old;
                    if first {
                        for k in 0..3 {
                            if mask & (1 << k) == 0 {
                                v_minus[k] = 2.0 * v_old[k] - v_new[k];
                            }
                        }
                    }
                    s.kinetic += 0.5 * mass * v_minus.dot(&v_new);
                    s.gravity_work += mass * p.gravity.dot(&(xs[i] - x0[n]));
                }
                xs[i] += v_new * p.dt;
                s.momentum += v_new * mass;
                vs[i] = v_new;
                fs[i] = Vec3::zeros();
                // NaN and ±∞ propagate through sums: one finiteness test per chunk.
                finite_probe += xs[i].sum() + v_new.sum();
            }
            s.non_finite = usize::from(!finite_probe.is_finite());
            s
        })
        .collect_into_vec(partials);
    IntegrationSums::total(partials)
}

/// The reactions of the constrained nodes (listed apart, [`crate::state::Constrained`]) this
/// process advances, from the forces and velocities before the step:
/// R = m·((v_p − v_old)/dt̄ − g − b) − f on each constrained component, zero on the others.
fn constraint_reactions(
    constrained: &mut crate::state::Constrained,
    (v, f, m, constraint): (&[Vec3], &[Vec3], &[Real], &[u8]),
    dt_bar: Real,
    body: Vec3,
    owned_chunks: Option<&[bool]>,
) {
    let crate::state::Constrained {
        node: listed,
        v_prescribed,
        reaction,
    } = constrained;
    (listed.par_iter())
        .zip(&*v_prescribed)
        .zip(&mut *reaction)
        .with_min_len(CHUNK)
        .for_each(|((&n, v_p), r)| {
            let n = n as usize;
            if owned_chunks.is_some_and(|o| !o[n / CHUNK]) {
                return;
            }
            let (mask, mass, v_old) = (constraint[n], m[n], v[n]);
            *r = Vec3::zeros();
            for k in 0..3 {
                if mask & (1 << k) != 0 {
                    r[k] = mass * ((v_p[k] - v_old[k]) / dt_bar - body[k]) - f[n][k];
                }
            }
        });
}
