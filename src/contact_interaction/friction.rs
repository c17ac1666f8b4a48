//! Stage 5's tangential and damping forces of one touching pair: the normal dashpot and
//! Coulomb friction on an elastic spring, with μ constant or from a friction law written in
//! Rhai ([`FRICTION_LAW`], compiled by [`crate::compiled`]).
//!
//! The friction force is updated incrementally, f_t ← P_n(f_t) − k_t·Δu_t (P_n re-projects
//! the stored force on the current tangent plane, keeping its magnitude), then returned to
//! the Coulomb cone |f_t| ≤ μ|F_n|. Storing the force rather than the spring extension keeps
//! the force continuous when the contact area (hence k_t) changes.

use super::{ContactProps, ContactSums, PairState};
use crate::compiled::{CompiledLaw, Frame};
use crate::math::{Real, Vec3};
use std::sync::Arc;

crate::compiled::law_signature! {
    /// Inputs of a contact friction law, per touching pair and step: tangential relative
    /// speed at the contact point [m/s], slip path accumulated while touching [m], mean
    /// normal pressure |F_n|/A [Pa], normal force |F_n| [N], contact area A [m²], time [s],
    /// and the rule's static `friction` value [-].
    #[derive(serde::Serialize, serde::Deserialize)]
    pub struct FrictionInputs { slip_rate, slip, pressure, normal_force, area, time, mu }
    /// A contact friction law: `fn law(c, p)` returning `#{ friction: μ }` (or μ alone).
    pub const FRICTION_LAW = "friction law" -> ["friction"];
}

/// Keys of `friction_law: #{ … }`.
pub const FRICTION_LAW_PARAMS: &[crate::params::Param] = &[
    crate::params::Param::other("function", "string", "", "required", "Name of the Rhai function `fn name(c, p)` returning μ ≥ 0 (`#{ friction: μ }` or the number). Inputs, per touching pair and step: c.slip_rate (tangential relative speed at the contact point) [m/s], c.slip (slip path since the pair started touching) [m], c.pressure (|F_n|/A) [Pa], c.normal_force [N], c.area [m²], c.time [s], c.mu (the rule's `friction`) [-]."),
    crate::compiled::PARAMS_KEY,
    crate::compiled::SOURCE_KEY,
];

/// A friction law that returned an invalid μ, with what it was given.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct FrictionLawFailure {
    /// Index into [`super::ContactLaws::friction_laws`].
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

/// Normal dashpot on the normal relative velocity at the contact point:
/// f_d = −2ζ·√(k·m*)·(v_rel·n), k = p·`stiff` (a face node's thin-overlap spring), m* the
/// reduced mass of one node of each tet (`tet_mass` = ρV₀ of each); never pulls harder than
/// the contact pushes (f_d ≥ −|F_n|). Returns f_d [N] along n.
#[inline(always)]
pub(super) fn normal_dashpot(
    pr: &ContactProps,
    stiff: Real,
    tet_mass: (Real, Real),
    n: &Vec3,
    dv: &Vec3,
    fn_mag: Real,
) -> Real {
    let kn = pr.penalty * stiff;
    let (mc, mt) = tet_mass;
    // Reduced mass of one node of each tet.
    let m_red = 0.25 * mc * mt / (mc + mt);
    let c = 2.0 * pr.damping * (kn * m_red).sqrt();
    let vn = n.dot(dv);
    (-c * vn).max(-fn_mag)
}

/// One touching pair as friction sees it.
pub(super) struct Touch<'a> {
    /// Contact normal (unit, along the normal force on the contactor).
    pub n: Vec3,
    /// Relative velocity of the contactor at the contact point [m/s].
    pub dv: Vec3,
    /// Relative displacement over the last step [m].
    pub du: Vec3,
    /// Normal force including the dashpot [N].
    pub normal: Real,
    /// (4/3)·A·(1/h_c + 1/h_t): the spring per unit penalty [m].
    pub stiff: Real,
    pub area: Real,
    pub point: Vec3,
    pub tets: [u32; 2],
    pub time: Real,
    pub laws: &'a [Arc<CompiledLaw>],
}

/// Coulomb friction of a touching pair: updates its spring and slip path, records an invalid
/// friction-law result in `sums`, and returns the friction force on the contactor [N].
#[inline(always)]
pub(super) fn coulomb_friction(
    pr: &ContactProps,
    ps: &mut PairState,
    t: &Touch,
    frame: &mut Frame,
    sums: &mut ContactSums,
) -> Vec3 {
    let n = t.n;
    let du_t = t.du - n * n.dot(&t.du);
    ps.slip += du_t.norm();
    // μ: the rule's constant, or its compiled law of this pair's state.
    let mu = if pr.friction_law == super::NO_FRICTION_LAW {
        pr.friction
    } else {
        let dv_t = t.dv - n * n.dot(&t.dv);
        let inputs = FrictionInputs {
            slip_rate: dv_t.norm(),
            slip: ps.slip,
            pressure: t.normal / t.area,
            normal_force: t.normal,
            area: t.area,
            time: t.time,
            mu: pr.friction,
        };
        let [mu] = t.laws[pr.friction_law as usize].evaluate_in(frame, &inputs.to_slots());
        if mu.is_finite() && mu >= 0.0 {
            mu
        } else {
            sums.law_failure.get_or_insert(FrictionLawFailure {
                law: pr.friction_law,
                tets: t.tets,
                point: t.point,
                inputs,
                friction: mu,
            });
            0.0
        }
    };
    let kt = pr.tangential_penalty * t.stiff;
    // Keep the stored force's magnitude on the new tangent plane.
    let old = ps.spring;
    let mut ft = old - n * n.dot(&old);
    let m_old = old.norm();
    let m_new = ft.norm();
    if m_new > 0.0 {
        ft *= m_old / m_new;
    }
    ft -= du_t * kt;
    let limit = mu * t.normal;
    let mag = ft.norm();
    if mag > limit {
        ft *= limit / mag;
    }
    ps.spring = ft;
    ft
}
