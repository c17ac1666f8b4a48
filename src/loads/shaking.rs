//! Stage 6 — ground shaking: earthquake records (x, y, z components) driving a model, in
//! one of two ways (theory: docs/theory/ground_motion.md, section "Shaking a model"):
//!
//! - **Base motion** ([`ShakingKind::Base`]): a node set (a base body, a foundation) follows
//!   the ground; its velocity is prescribed each step and the structure is moved through
//!   the joints, the elements or contact and friction it has with the base.
//! - **Relative frame** ([`ShakingKind::Relative`]): the model is described relative to the
//!   ground; every node carries the body force −m·a_g(t) (the d'Alembert force of the
//!   accelerating frame), and the base is fixed by the script.
//!
//! Both move the ground with the velocity of the record, V(τ) = ∫₀^τ a_g, integrated exactly
//! for the piecewise-linear record (the trapezoidal velocity at its samples, a quadratic in
//! between; τ = t − start), sampled at the half steps of the simulation:
//!
//! ```text
//! v_g(t + dt/2) = V(t + dt/2 − start),   u_g(t + dt) = u_g(t) + dt·v_g(t + dt/2),
//! a_g(t) = (v_g(t + dt/2) − v_g(t − dt/2)) / dt̄,   dt̄ = (dt_prev + dt)/2,
//! ```
//!
//! from rest at the start time. a_g(t) is the mean of the record over the step's dual cell,
//! exactly the acceleration the central difference needs to give the nodes the ground's
//! velocities; the relative frame applies −m·a_g(t) with this same a_g, so a structure moves
//! relative to its base identically (to round-off) in the two ways. The ground's velocity is
//! exact at every half step, so a record whose velocity ends at zero (`baseline: true`) leaves
//! the ground at rest: no drift after the shaking, at any dt. The displacement is the
//! midpoint rule on V: within dt²·max|a|/12 of the record's exact double integral. A start
//! between steps, or a record starting with a₀ ≠ 0, needs no special case: V(τ < 0) = 0.
//! After the record the ground keeps V's final value (zero with baseline correction).
//! Per step: one evaluation of V per component.

use super::ground_motion::GroundMotion;
use crate::math::{Real, Vec3};
use std::sync::Arc;

/// How a record drives the model.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum ShakingKind {
    /// These nodes follow the ground in all three components.
    Base(Vec<u32>),
    /// Body force −m·a_g(t) on every node.
    Relative,
}

/// A record with its velocity at the samples, V(k·dt) (trapezoidal from rest, k = 0..N; the
/// record closes with a_N = 0 at N·dt).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct GroundRecord {
    pub record: GroundMotion,
    velocity: Vec<Real>,
}

impl GroundRecord {
    pub fn new(record: GroundMotion) -> Self {
        let velocity = record.velocity();
        GroundRecord { record, velocity }
    }

    /// V(τ) = ∫₀^τ a_g [m/s], exact for the piecewise-linear record: 0 before τ = 0, the
    /// final velocity after the record. O(1).
    pub fn velocity_at(&self, tau: Real) -> Real {
        if tau.is_nan() || tau <= 0.0 {
            return 0.0;
        }
        let (dt, acc) = (self.record.dt, &self.record.acc);
        let k = (tau / dt).floor();
        if k >= acc.len() as Real {
            return self.velocity[acc.len()];
        }
        let k = k as usize;
        let s = tau - k as Real * dt;
        let (a0, a1) = (acc[k], acc.get(k + 1).copied().unwrap_or(0.0));
        self.velocity[k] + a0 * s + (a1 - a0) * s * s / (2.0 * dt)
    }
}

/// One ground motion applied to the model, with the ground's state.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Shaking {
    /// Records of the x, y and z ground acceleration (None: no motion in that direction).
    pub records: [Option<Arc<GroundRecord>>; 3],
    /// Simulation time at which the records' t = 0 falls [s].
    pub start: Real,
    pub kind: ShakingKind,
    /// Ground acceleration applied on the last step, a_g(t_n) [m/s²].
    pub acceleration: Vec3,
    /// Ground velocity v_g(t_n − dt/2) before the last step and v_g(t_n + dt/2) after [m/s].
    pub velocity_before: Vec3,
    pub velocity: Vec3,
    /// Ground displacement u_g at the end of the last step [m].
    pub displacement: Vec3,
}

impl Shaking {
    pub fn new(records: [Option<Arc<GroundRecord>>; 3], start: Real, kind: ShakingKind) -> Self {
        Shaking {
            records,
            start,
            kind,
            acceleration: Vec3::zeros(),
            velocity_before: Vec3::zeros(),
            velocity: Vec3::zeros(),
            displacement: Vec3::zeros(),
        }
    }

    /// The time after which every record is over [s] (`start` plus the longest duration).
    pub fn end(&self) -> Real {
        self.start
            + self
                .records
                .iter()
                .flatten()
                .map(|r| r.record.duration())
                .fold(0.0, Real::max)
    }

    /// The ground's velocity at simulation time t [m/s].
    pub fn velocity_at(&self, t: Real) -> Vec3 {
        let mut v = Vec3::zeros();
        for (k, r) in self.records.iter().enumerate() {
            if let Some(r) = r {
                v[k] = r.velocity_at(t - self.start);
            }
        }
        v
    }

    /// Advance the ground over the step from t to t + dt (`dt_prev`: the step before, 0 on
    /// the first): returns a_g(t).
    pub fn advance(&mut self, t: Real, dt_prev: Real, dt: Real) -> Vec3 {
        let v_new = self.velocity_at(t + 0.5 * dt);
        let dt_bar = 0.5 * (dt_prev + dt);
        self.acceleration = (v_new - self.velocity) / dt_bar;
        self.velocity_before = self.velocity;
        self.velocity = v_new;
        self.displacement += v_new * dt;
        self.acceleration
    }

    /// Ground velocity at t_n, the mean of the half steps around it (what mass damping
    /// measures node velocities against; the integrator's v at t_n is the same mean).
    pub fn velocity_at_step(&self) -> Vec3 {
        (self.velocity_before + self.velocity) * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(acc: Vec<Real>, dt: Real) -> Arc<GroundRecord> {
        Arc::new(GroundRecord::new(GroundMotion {
            name: "test".into(),
            source: String::new(),
            dt,
            acc,
        }))
    }

    /// A constant acceleration a from rest: V = a·τ exactly, so u = a·t²/2 at the steps
    /// (the midpoint rule is exact for a linear V) and a_g = a.
    #[test]
    fn constant_acceleration_is_integrated_exactly() {
        let a = 2.0;
        let r = record(vec![a; 1000], 0.01);
        let mut s = Shaking::new([Some(r), None, None], 0.0, ShakingKind::Relative);
        let dt = 0.003;
        let mut t = 0.0;
        let mut dt_prev = 0.0;
        for _ in 0..1000 {
            let ag = s.advance(t, dt_prev, dt);
            assert!((ag.x - a).abs() < 1e-9, "{ag}");
            t += dt;
            dt_prev = dt;
        }
        assert!((s.displacement.x - 0.5 * a * t * t).abs() < 1e-12 * t * t);
        assert_eq!(s.displacement.y, 0.0);
    }

    /// Started mid-run with a jump at the start (a step straddles it): the first step's
    /// a_g is the mean over its dual cell, ½a₀, and u = a·(t − start)²/2 again.
    #[test]
    fn a_start_between_runs_needs_no_special_case() {
        let a = -3.0;
        let r = record(vec![a; 1000], 0.01);
        let start = 0.5;
        let mut s = Shaking::new([None, None, Some(r)], start, ShakingKind::Base(vec![]));
        let dt = 0.01;
        let mut t = 0.0;
        for n in 0..300 {
            let ag = s.advance(t, if n == 0 { 0.0 } else { dt }, dt);
            if n == 50 {
                assert!((ag.z - 0.5 * a).abs() < 1e-9, "{ag}");
            }
            t += dt;
        }
        let tau = t - start;
        assert!((s.displacement.z - 0.5 * a * tau * tau).abs() < 1e-9);
        assert!(s.end() > 10.0);
    }

    /// V between samples is the exact integral of the linear piece: against a fine
    /// trapezoidal sum.
    #[test]
    fn velocity_is_the_exact_integral_of_the_record() {
        let r = record(vec![0.0, 1.0, -2.0, 0.5], 0.1);
        for tau in [0.03, 0.1, 0.17, 0.25, 0.38, 0.45] {
            let n = 100_000;
            let h = tau / n as Real;
            let fine: Real = (0..n)
                .map(|i| 0.5 * (r.record.at(i as Real * h) + r.record.at((i + 1) as Real * h)) * h)
                .sum();
            assert!((r.velocity_at(tau) - fine).abs() < 1e-9, "τ = {tau}");
        }
        assert_eq!(r.velocity_at(-1.0), 0.0);
        assert_eq!(r.velocity_at(5.0), r.velocity_at(0.4));
    }
}
