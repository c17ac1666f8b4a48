//! Stage 2 — bond between reinforcing bars and their host: each bar node is tied to the host
//! tetrahedron that contains it through its barycentric coordinates w (fixed in the
//! reference configuration), and the bond law turns their relative displacement into forces.
//! When the host cracks, a bar node follows the fragment its tetrahedron belongs to.
//!
//! Kinematics at bar node b with host point x_h = Σ w_a x_a (a = the host's 4 nodes):
//!
//! ```text
//! δ = (x_b − x_h) − (X_b − X_h)          relative displacement [m]
//! t = (x_next − x_prev)/|x_next − x_prev|  bar axis at the node (neighbouring bar nodes)
//! s = δ·t,  δ⊥ = δ − s t                  slip along the bar and its transverse part
//! F_b = −A_b (τ(s) t + k⊥ δ⊥),  F_a = −w_a F_b     A_b = π d L_b (perimeter × tributary length)
//! g = A_b (τ − k⊥ s) δ⊥ / |x_next − x_prev|,  F_prev = +g,  F_next = −g
//! ```
//!
//! These are −∂W/∂x of W = A_b[ψ(s) + ½k⊥(|δ|² − s²)] (ψ' = τ), the axis t turning with the
//! bar included: without the g terms the bond force would be a follower load, and the lateral
//! modes of a slipping bar gain energy until they blow up. The forces sum to zero. The slip law is elastic–plastic with the bond law's envelope
//! τ_env (built-in: fib Model Code 2010, §6.1.1, eq. 6.1-1 and Table 6.1-1; or a Rhai
//! function of the slip): an elastic trial τ = k (s − s_p) with the unloading stiffness k,
//! bounded by ±τ_env(s_max), s_max the largest |s| so far (cyclic loading follows the
//! monotone envelope's strength, which softens past s₂); the bounded part moves the plastic
//! slip s_p. Energy: ½A_b(τ²/k + k⊥|δ⊥|²) is recoverable, A_b∫|τ| |ds_p| (trapezoid per step)
//! is dissipated.
//!
//! Guarantees: deterministic for any thread count (bond points in parallel into a per-point
//! force, added to the nodes in point order).

use crate::compiled;
use crate::math::{Real, Vec3};
use crate::params::{value, value_of, DefaultValue, Given, Param, Range};
use crate::state::{Nodes, Tets};
use rayon::prelude::*;

compiled::law_signature! {
    /// Input of a bond law written in Rhai: the slip s ≥ 0 [m] (the envelope is symmetric)
    /// and the bar diameter d [m].
    pub struct BondLawInputs { slip, diameter }
    /// A bond law: `fn law(b, p)` returning the envelope bond stress τ_env(s) [Pa] ≥ 0.
    pub const BOND_LAW = "bond law" -> ["stress"];
}

/// k⊥ of the fib2010 law: by default the bearing stiffness of concrete under a bar.
const TRANSVERSE_STIFFNESS: Param = Param::float(
    "transverse_stiffness",
    "Pa/m",
    DefaultValue::Text("K_f/π: Soroushian et al. 1987, K_f = 127·0.8·√f_cm/d^(2/3) N/mm³ (f_cm in MPa, d in mm)"),
    Range::POSITIVE,
    "k⊥: stiffness of the host against the bar's transverse displacement, per unit of bond area πd·L (the foundation of a bar in dowel action: K_f·d = πd·k⊥ per unit length).",
);

/// k⊥ of a script bond law (no concrete strength to take the bearing stiffness from).
const SCRIPT_TRANSVERSE_STIFFNESS: Param = Param::float(
    "transverse_stiffness",
    "Pa/m",
    DefaultValue::Text("E of the host / d"),
    Range::POSITIVE,
    "k⊥: stiffness of the host against the bar's transverse displacement, per unit of bond area.",
);

/// The bearing (dowel) stiffness of concrete under a bar as k⊥ per unit of bond area [Pa/m]:
/// Soroushian, Obaseki & Rojas (1987, ACI Materials Journal 84(3)) measured the foundation
/// modulus K_f = 127·c₁·√f_c / d^(2/3) [N/mm³; f_c in MPa, d in mm] with c₁ = 0.6 (bars
/// 25 mm apart) to 1.0 (far apart); c₁ = 0.8 here. Per unit length the bar rests on K_f·d,
/// which the bond points spread over the perimeter πd: k⊥ = K_f/π.
pub fn dowel_transverse_stiffness(fcm: Real, diameter: Real) -> Real {
    let kf_n_per_mm3 = 127.0 * 0.8 * (fcm / 1e6).sqrt() / (diameter * 1e3).powf(2.0 / 3.0);
    kf_n_per_mm3 * 1e9 / std::f64::consts::PI
}

/// Parameters of `bond_law("fib2010", #{ … })`.
pub const FIB2010_PARAMS: &[Param] = &[
    Param::float(
        "fcm",
        "Pa",
        DefaultValue::Required,
        Range::POSITIVE,
        "Mean cylinder compressive strength of the concrete f_cm.",
    ),
    Param::other(
        "confinement",
        "string",
        "",
        "\"confined\"",
        "\"confined\" (pull-out failure: well-confined concrete), \"stirrups\" (splitting failure, concrete confined by stirrups) or \"unconfined\" (splitting failure, no stirrups): Table 6.1-1's columns.",
    ),
    Param::other(
        "bond",
        "string",
        "",
        "\"good\"",
        "Bond conditions: \"good\" or \"other\" (§6.1.3.2).",
    ),
    Param::float(
        "clear_rib_spacing",
        "m",
        DefaultValue::Text("0.6 × the bar diameter"),
        Range::POSITIVE,
        "Clear distance between the ribs c_clear: the slip s₃ where the residual stress is reached (confined: s₃ = c_clear; stirrups: 0.5 c_clear).",
    ),
    Param::float(
        "stiffness",
        "Pa/m",
        DefaultValue::Text("the secant of the envelope at s₁/100"),
        Range::POSITIVE,
        "Unloading stiffness k: the elastic slope before the envelope is reached and of every unloading.",
    ),
    TRANSVERSE_STIFFNESS,
];

/// Parameters of `bond_law("script", #{ … })`.
pub const SCRIPT_BOND_PARAMS: &[Param] = &[
    Param::other("function", "string", "", "required", "Name of the Rhai function `fn name(b, p)` returning the envelope bond stress τ_env [Pa] at slip `b.slip` [m] (bar diameter `b.diameter` [m]); compiled to native code."),
    crate::compiled::PARAMS_KEY,
    crate::compiled::SOURCE_KEY,
    Param::float(
        "stiffness",
        "Pa/m",
        DefaultValue::Required,
        Range::POSITIVE,
        "Unloading stiffness k (the elastic slope before the envelope is reached).",
    ),
    SCRIPT_TRANSVERSE_STIFFNESS,
];

/// The bond laws by registry name, with their parameters.
pub const BOND_LAWS: &[crate::params::LawParams] = &[
    crate::params::LawParams { name: "fib2010", summary: "fib Model Code 2010 bond stress–slip (eq. 6.1-1, Table 6.1-1): τ_max(s/s₁)^0.4 to s₁, flat to s₂, linear to τ_bf at s₃; unloading elastic with the stiffness k.", params: FIB2010_PARAMS },
    crate::params::LawParams { name: "script", summary: "An envelope τ_env(s) written in Rhai, compiled once to native code; unloading as fib2010.", params: SCRIPT_BOND_PARAMS },
];

/// The monotone bond stress–slip envelope of fib Model Code 2010, eq. 6.1-1:
/// τ = τ_max (s/s₁)^α for s ≤ s₁; τ_max to s₂; linear to τ_bf at s₃; τ_bf beyond.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Fib2010 {
    pub tau_max: Real,
    pub s1: Real,
    pub s2: Real,
    pub s3: Real,
    pub alpha: Real,
    pub tau_f: Real,
}

impl Fib2010 {
    /// Table 6.1-1 for f_cm [Pa], the confinement and bond conditions, and c_clear [m].
    pub fn new(fcm: Real, confinement: &str, good: bool, c_clear: Real) -> Result<Self, String> {
        let mpa = fcm / 1e6;
        // Pull-out (confined): τ_max = 2.5√f_cm (good) or 1.25√f_cm, s₁ = 1.0 / 1.8 mm.
        let (po_tau, po_s1, po_s2) = if good {
            (2.5 * mpa.sqrt(), 1.0e-3, 2.0e-3)
        } else {
            (1.25 * mpa.sqrt(), 1.8e-3, 3.6e-3)
        };
        let alpha = 0.4;
        let splitting = |tau_max_mpa: Real| po_s1 * (tau_max_mpa / po_tau).powf(1.0 / alpha);
        let (tau, s1, s2, s3, tau_f) = match confinement {
            "confined" => (po_tau, po_s1, po_s2, c_clear, 0.4 * po_tau),
            "stirrups" => {
                let t = if good { 8.0 } else { 5.5 } * (mpa / 20.0).powf(0.25);
                let s1 = splitting(t);
                (t, s1, s1, s1.max(0.5 * c_clear), 0.4 * t)
            }
            "unconfined" => {
                let t = if good { 7.0 } else { 5.0 } * (mpa / 20.0).powf(0.25);
                let s1 = splitting(t);
                (t, s1, s1, 1.2 * s1, 0.0)
            }
            x => {
                return Err(format!(
                    "confinement \"{x}\" is not \"confined\", \"stirrups\" or \"unconfined\""
                ))
            }
        };
        Ok(Fib2010 {
            tau_max: tau * 1e6,
            s1,
            s2,
            s3: s3.max(s2),
            alpha,
            tau_f: tau_f * 1e6,
        })
    }

    /// τ_env(s) [Pa] for s ≥ 0.
    #[inline]
    pub fn envelope(&self, s: Real) -> Real {
        if s <= self.s1 {
            self.tau_max * (s / self.s1).powf(self.alpha)
        } else if s <= self.s2 {
            self.tau_max
        } else if s <= self.s3 {
            self.tau_max - (self.tau_max - self.tau_f) * (s - self.s2) / (self.s3 - self.s2)
        } else {
            self.tau_f
        }
    }
}

/// The envelope of a bond law.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub enum Envelope {
    Fib2010(Fib2010),
    Script(std::sync::Arc<compiled::CompiledLaw>),
}

/// A bond law: envelope, unloading stiffness k and transverse stiffness k⊥ [Pa/m].
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct BondLaw {
    pub envelope: Envelope,
    pub stiffness: Real,
    /// None: E of the host / d, set when the bar is embedded.
    pub transverse_stiffness: Option<Real>,
}

impl BondLaw {
    /// `bond_law("fib2010", …)` from [`FIB2010_PARAMS`]; the strings come separately.
    /// `diameter` [m] sets the defaults that depend on the bar (c_clear = 0.6 d).
    pub fn fib2010(
        given: Given,
        confinement: &str,
        bond: &str,
        diameter: Real,
    ) -> Result<Self, String> {
        let good = match bond {
            "good" => true,
            "other" => false,
            x => return Err(format!("bond \"{x}\" is not \"good\" or \"other\"")),
        };
        let c_clear =
            value(FIB2010_PARAMS, "clear_rib_spacing", given, Real::NAN)?.unwrap_or(0.6 * diameter);
        let fcm = value_of(FIB2010_PARAMS, "fcm", given)?;
        let fib = Fib2010::new(fcm, confinement, good, c_clear)?;
        let s_lin = fib.s1 / 100.0;
        let stiffness = value(FIB2010_PARAMS, "stiffness", given, Real::NAN)?
            .unwrap_or(fib.envelope(s_lin) / s_lin);
        Ok(BondLaw {
            envelope: Envelope::Fib2010(fib),
            stiffness,
            transverse_stiffness: Some(
                value(FIB2010_PARAMS, "transverse_stiffness", given, Real::NAN)?
                    .unwrap_or_else(|| dowel_transverse_stiffness(fcm, diameter)),
            ),
        })
    }

    /// τ_env(s) [Pa] for the bar diameter d; a script law's negative or non-finite value is
    /// returned as NaN (the run stops on it).
    #[inline]
    pub fn envelope(&self, s: Real, diameter: Real) -> Real {
        match &self.envelope {
            Envelope::Fib2010(f) => f.envelope(s),
            Envelope::Script(law) => {
                let [t] = law.evaluate::<1>(&[s, diameter]);
                if t >= 0.0 && t.is_finite() {
                    t
                } else {
                    Real::NAN
                }
            }
        }
    }

    /// One slip update: the bond stress τ [Pa] at slip s, advancing the plastic slip s_p, the
    /// largest slip s_max and the strength τ_env(s_max) (NaN: not evaluated yet; the envelope
    /// is evaluated only when s_max grows); also the plastic slip increment |Δs_p| [m].
    #[inline]
    pub fn update(
        &self,
        s: Real,
        diameter: Real,
        plastic_slip: &mut Real,
        max_slip: &mut Real,
        strength: &mut Real,
    ) -> (Real, Real) {
        if s.abs() > *max_slip || strength.is_nan() {
            *max_slip = max_slip.max(s.abs());
            *strength = self.envelope(*max_slip, diameter);
        }
        let bound = *strength;
        let trial = self.stiffness * (s - *plastic_slip);
        if trial.abs() <= bound {
            return (trial, 0.0);
        }
        let tau = bound * trial.signum();
        let sp = s - tau / self.stiffness;
        let dsp = (sp - *plastic_slip).abs();
        *plastic_slip = sp;
        (tau, dsp)
    }
}

/// Bond points (one per embedded bar node), structure of arrays indexed by point id.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Bonds {
    pub laws: Vec<BondLaw>,
    /// The bar node.
    pub node: Vec<u32>,
    /// Neighbouring bar nodes along the bar (the node itself at an end): the axis t.
    pub along: Vec<[u32; 2]>,
    /// Host tetrahedron and the node's barycentric coordinates in it.
    pub tet: Vec<u32>,
    pub weights: Vec<[Real; 4]>,
    /// X_b − X_h at the reference (round-off of the embedding) [m].
    pub offset0: Vec<Vec3>,
    /// Bond area A_b = π d L_b [m²].
    pub area: Vec<Real>,
    pub diameter: Vec<Real>,
    /// k⊥ [Pa/m].
    pub transverse_stiffness: Vec<Real>,
    pub law: Vec<u32>,
    /// History: plastic slip s_p and largest slip s_max [m].
    pub plastic_slip: Vec<Real>,
    pub max_slip: Vec<Real>,
    /// τ_env(s_max) [Pa] (NaN until first evaluated).
    pub strength: Vec<Real>,
    /// Slip s [m] and bond stress τ [Pa] of the last step.
    pub slip: Vec<Real>,
    pub stress: Vec<Real>,
    /// Energy dissipated by slip so far [J].
    pub dissipated: Vec<Real>,
    /// Force on the bar node in the last step [N] (the stage's scratch as well).
    pub force: Vec<Vec3>,
    /// ∂W/∂(x_next − x_prev) of the last step [N]: the axis turns with the bar, so the bond
    /// potential also acts on the neighbouring bar nodes (scratch).
    pub axis_force: Vec<Vec3>,
}

/// One bond point to add.
#[derive(Clone, Copy, Debug)]
pub struct BondPoint {
    pub node: u32,
    pub along: [u32; 2],
    pub tet: u32,
    pub weights: [Real; 4],
    pub offset0: Vec3,
    pub area: Real,
    pub diameter: Real,
    pub transverse_stiffness: Real,
    pub law: u32,
}

/// Sums over the bond points of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BondSums {
    /// Recoverable energy ½A_b(τ²/k + k⊥|δ⊥|²) [J] (only when energies are requested).
    pub energy: Real,
}

impl Bonds {
    pub fn len(&self) -> usize {
        self.node.len()
    }
    pub fn is_empty(&self) -> bool {
        self.node.is_empty()
    }
    pub fn add_law(&mut self, law: BondLaw) -> u32 {
        self.laws.push(law);
        (self.laws.len() - 1) as u32
    }
    pub fn push(&mut self, p: BondPoint) {
        self.node.push(p.node);
        self.along.push(p.along);
        self.tet.push(p.tet);
        self.weights.push(p.weights);
        self.offset0.push(p.offset0);
        self.area.push(p.area);
        self.diameter.push(p.diameter);
        self.transverse_stiffness.push(p.transverse_stiffness);
        self.law.push(p.law);
        self.plastic_slip.push(0.0);
        self.max_slip.push(0.0);
        self.strength.push(Real::NAN);
        self.slip.push(0.0);
        self.stress.push(0.0);
        self.dissipated.push(0.0);
        self.force.push(Vec3::zeros());
        self.axis_force.push(Vec3::zeros());
    }

    /// Largest ω² the bond springs add at a node, by Gershgorin on M⁻¹K_bond: for each node
    /// 2Σ k_max A_b w/m (the bar node with weight 1), k_max = max(k, k⊥). Returns (ω², node).
    pub fn max_omega2(&self, tets: &Tets, mass: &[Real]) -> (Real, usize) {
        let mut stiff = std::collections::BTreeMap::<u32, Real>::new();
        for p in 0..self.len() {
            let k = self.laws[self.law[p] as usize]
                .stiffness
                .max(self.transverse_stiffness[p])
                * self.area[p];
            *stiff.entry(self.node[p]).or_default() += k;
            for (a, &n) in tets.nodes[self.tet[p] as usize].iter().enumerate() {
                *stiff.entry(n).or_default() += k * self.weights[p][a].abs();
            }
        }
        stiff
            .into_iter()
            .map(|(n, k)| (2.0 * k / mass[n as usize], n as usize))
            .fold((0.0, 0), |a, c| if c.0 > a.0 { c } else { a })
    }

    /// Relative displacement δ = (x_b − x_h) − (X_b − X_h) of point p, the bar axis t and the
    /// length |x_next − x_prev| it is taken over.
    #[inline]
    fn kinematics(&self, p: usize, x: &[Vec3], tets: &Tets) -> (Vec3, Vec3, Real) {
        let host = &tets.nodes[self.tet[p] as usize];
        let w = &self.weights[p];
        let xh: Vec3 = (0..4).map(|a| x[host[a] as usize] * w[a]).sum();
        let delta = x[self.node[p] as usize] - xh - self.offset0[p];
        let [prev, next] = self.along[p];
        let axis = x[next as usize] - x[prev as usize];
        let len = axis.norm();
        (delta, axis / len, len)
    }
}

/// Stage 2 for bonds: the bond forces of every point added to its bar node and the host's
/// nodes; histories advanced.
pub fn add_bond_forces(
    bonds: &mut Bonds,
    nodes: &mut Nodes,
    tets: &Tets,
    want_energy: bool,
) -> BondSums {
    if bonds.is_empty() {
        return BondSums::default();
    }
    let x = &nodes.x;
    let mut force = std::mem::take(&mut bonds.force);
    let mut axis_force = std::mem::take(&mut bonds.axis_force);
    let mut slip = std::mem::take(&mut bonds.slip);
    let mut stress = std::mem::take(&mut bonds.stress);
    let mut plastic = std::mem::take(&mut bonds.plastic_slip);
    let mut max_slip = std::mem::take(&mut bonds.max_slip);
    let mut strength = std::mem::take(&mut bonds.strength);
    let mut dissipated = std::mem::take(&mut bonds.dissipated);
    let b = &*bonds;
    (
        force.par_iter_mut(),
        axis_force.par_iter_mut(),
        slip.par_iter_mut(),
        stress.par_iter_mut(),
        plastic.par_iter_mut(),
        max_slip.par_iter_mut(),
        strength.par_iter_mut(),
        dissipated.par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(p, (f, g, s, tau, sp, smax, strong, diss))| {
            let (delta, t, len) = b.kinematics(p, x, tets);
            *s = delta.dot(&t);
            let perp = delta - t * *s;
            let law = &b.laws[b.law[p] as usize];
            let tau_old = *tau;
            let (tau_new, dsp) = law.update(*s, b.diameter[p], sp, smax, strong);
            *tau = tau_new;
            let (area, kt) = (b.area[p], b.transverse_stiffness[p]);
            *diss += 0.5 * (tau_old.abs() + tau_new.abs()) * dsp * area;
            *f = -(t * tau_new + perp * kt) * area;
            // W = A[ψ(s) + ½k⊥(|δ|² − s²)] with s = δ·t(a): ∂W/∂a = A(τ − k⊥s)·δ⊥/|a|.
            *g = perp * ((tau_new - kt * *s) * area / len);
        });
    // On samples, in point order (the same sum for any thread count).
    let energy = if want_energy {
        (0..b.len())
            .map(|p| {
                let (delta, t, _) = b.kinematics(p, x, tets);
                let perp = delta - t * delta.dot(&t);
                let k = b.laws[b.law[p] as usize].stiffness;
                0.5 * b.area[p]
                    * (stress[p] * stress[p] / k + b.transverse_stiffness[p] * perp.norm_squared())
            })
            .sum()
    } else {
        0.0
    };
    for p in 0..b.len() {
        let host = &tets.nodes[b.tet[p] as usize];
        nodes.f[b.node[p] as usize] += force[p];
        let [prev, next] = b.along[p];
        nodes.f[prev as usize] += axis_force[p];
        nodes.f[next as usize] -= axis_force[p];
        for (&n, &w) in host.iter().zip(&b.weights[p]) {
            nodes.f[n as usize] -= force[p] * w;
        }
    }
    bonds.force = force;
    bonds.axis_force = axis_force;
    bonds.slip = slip;
    bonds.stress = stress;
    bonds.plastic_slip = plastic;
    bonds.max_slip = max_slip;
    bonds.strength = strength;
    bonds.dissipated = dissipated;
    BondSums { energy }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table 6.1-1, pull-out, good bond, f_cm = 47 MPa: τ_max = 2.5√47 = 17.14 MPa at
    /// s₁ = 1 mm, flat to 2 mm, down to 0.4 τ_max at c_clear.
    #[test]
    fn fib2010_envelope_has_the_code_values() {
        let f = Fib2010::new(47e6, "confined", true, 10e-3).unwrap();
        assert!((f.tau_max - 2.5 * 47f64.sqrt() * 1e6).abs() < 1.0);
        assert!((f.envelope(1e-3) - f.tau_max).abs() < 1e-6);
        assert!((f.envelope(0.5e-3) / f.tau_max - 0.5f64.powf(0.4)).abs() < 1e-12);
        assert!((f.envelope(6e-3) - 0.7 * f.tau_max).abs() < 1e-6 * f.tau_max);
        assert!((f.envelope(20e-3) - 0.4 * f.tau_max).abs() < 1e-6);
        let u = Fib2010::new(47e6, "unconfined", true, 10e-3).unwrap();
        assert!((u.tau_max - 7.0 * (47.0f64 / 20.0).powf(0.25) * 1e6).abs() < 1.0);
        assert_eq!(u.envelope(1.3 * u.s1), 0.0);
        assert!(Fib2010::new(47e6, "loose", true, 1e-2).is_err());
    }

    /// Soroushian et al. (1987) for f_c = 30 MPa and a 20 mm bar: K_f = 127·0.8·√30/20^(2/3)
    /// = 75.53 N/mm³ (by hand), so k⊥ = K_f/π = 2.404e10 Pa/m; and fib2010 takes it as its
    /// default k⊥ for the rebar's diameter unless one is given.
    #[test]
    fn the_default_transverse_stiffness_is_the_dowel_bearing_stiffness() {
        let k = dowel_transverse_stiffness(30e6, 0.020);
        assert!((k / 2.404e10 - 1.0).abs() < 1e-3, "{k}");
        let given =
            |p: &Param| -> Result<Option<Real>, String> { Ok((p.name == "fcm").then_some(30e6)) };
        let law = BondLaw::fib2010(&given, "confined", "good", 0.020).unwrap();
        assert_eq!(law.transverse_stiffness, Some(k));
        let given = |p: &Param| -> Result<Option<Real>, String> {
            Ok(match p.name {
                "fcm" => Some(30e6),
                "transverse_stiffness" => Some(1e9),
                _ => None,
            })
        };
        let law = BondLaw::fib2010(&given, "confined", "good", 0.020).unwrap();
        assert_eq!(law.transverse_stiffness, Some(1e9));
    }

    /// Unloading is elastic with slope k and reloading returns to the envelope.
    #[test]
    fn slip_unloads_elastically_and_dissipates_only_on_the_envelope() {
        let law = BondLaw {
            envelope: Envelope::Fib2010(Fib2010::new(30e6, "confined", true, 10e-3).unwrap()),
            stiffness: 1e11,
            transverse_stiffness: Some(1e12),
        };
        let (mut sp, mut smax, mut strength) = (0.0, 0.0, Real::NAN);
        let (t, d) = law.update(1e-5, 0.02, &mut sp, &mut smax, &mut strength);
        assert!((t - 1e6).abs() < 1e-6 && d == 0.0, "{t} {d}");
        let (t, _) = law.update(1.5e-3, 0.02, &mut sp, &mut smax, &mut strength);
        assert!((t - 2.5 * 30f64.sqrt() * 1e6).abs() < 1.0);
        let (t2, d2) = law.update(1.4e-3, 0.02, &mut sp, &mut smax, &mut strength);
        assert!((t - t2 - 1e11 * 1e-4).abs() < 1e-3 && d2 == 0.0);
    }
}
