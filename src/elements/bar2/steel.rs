//! Uniaxial steel of the bar elements (stage 1, [`crate::elements::bar2`]):
//! elastic–plastic with linear isotropic hardening, rupture at the ultimate strain, and an
//! optional Cowper–Symonds strain-rate factor.
//!
//! Strain ε = l/l₀ − 1 (engineering strain of the bar's chord: zero under any rigid motion),
//! nominal stress σ = N/A₀. With the plastic strain ε_p and the equivalent plastic strain
//! α = ∫|dε_p|, the elastic predictor and return map of one step are (Simo & Hughes 1998,
//! *Computational Inelasticity*, §1.4):
//!
//! σ_trial = E (ε − ε_p),  f = |σ_trial| − k·σ_y(α),  σ_y(α) = f_y + H α,
//! if f > 0: Δγ = f / (E + k·H),  ε_p += Δγ·sign σ_trial,  α += Δγ,  σ = σ_trial − E Δγ sign σ_trial,
//!
//! where k = 1 + (|ε̇|/C)^{1/p} is the Cowper–Symonds factor (k = 1 without it). With f_u at
//! ε_u given instead of H, H = (f_u − f_y)/(ε_u − f_u/E): the hardening line reaches f_u at the
//! total strain ε_u. The bar ruptures (carries nothing from then on) when ε ≥ ε_u.
//!
//! Energy: the elastic energy ½ σ²/E per unit volume is recoverable; the plastic work
//! ∫σ dε_p is dissipated. For linear hardening σ is linear in α on the yield line, so the
//! trapezoid ½(σ_old + σ_new)·Δγ of a step is that integral exactly (rate-free).

use crate::compiled;
use crate::math::Real;
use crate::params::{value, value_of, DefaultValue, Given, Param, Range};

/// Parameters of `steel(#{ … })`.
pub const STEEL_PARAMS: &[Param] = &[
    Param::float(
        "density",
        "kg/m³",
        DefaultValue::Value(7850.0),
        Range::POSITIVE,
        "Mass density ρ.",
    ),
    Param::float(
        "young",
        "Pa",
        DefaultValue::Value(200e9),
        Range::POSITIVE,
        "Young's modulus E.",
    ),
    Param::float(
        "yield_stress",
        "Pa",
        DefaultValue::Required,
        Range::POSITIVE,
        "Yield stress f_y.",
    ),
    Param::float(
        "hardening",
        "Pa",
        DefaultValue::Text("from ultimate_stress and ultimate_strain, else 0"),
        Range::NON_NEGATIVE,
        "Plastic hardening modulus H: σ_y = f_y + H·α, α the accumulated plastic strain. Give it or ultimate_stress, not both.",
    ),
    Param::float(
        "ultimate_stress",
        "Pa",
        DefaultValue::Text("none"),
        Range::POSITIVE,
        "Tensile strength f_u, reached at ultimate_strain (then H = (f_u − f_y)/(ε_u − f_u/E)); must be ≥ yield_stress.",
    ),
    Param::float(
        "ultimate_strain",
        "-",
        DefaultValue::Text("none: the bar never ruptures"),
        Range::POSITIVE,
        "Strain ε_u at which the bar ruptures (and at which ultimate_stress is reached).",
    ),
    Param::float(
        "rate_c",
        "1/s",
        DefaultValue::Text("none: no rate effect"),
        Range::POSITIVE,
        "Cowper–Symonds C: σ_y × (1 + (|ε̇|/C)^{1/p}) (mild steel: C = 40.4 /s, p = 5).",
    ),
    Param::float(
        "rate_p",
        "-",
        DefaultValue::Value(5.0),
        Range::POSITIVE,
        "Cowper–Symonds exponent p (used with rate_c).",
    ),
];

/// Parameters of `steel("script", #{ … })`.
pub const SCRIPT_STEEL_PARAMS: &[Param] = &[
    Param::other("function", "string", "", "required", "Name of the Rhai function `fn name(b, p)` returning `#{ stress, plastic_strain, history }` from `b.strain`, `b.strain_rate`, `b.plastic_strain`, `b.history` (last step's) and `b.young`; compiled to native code."),
    crate::compiled::PARAMS_KEY,
    crate::compiled::SOURCE_KEY,
    STEEL_PARAMS[0],
    STEEL_PARAMS[1],
    STEEL_PARAMS[5],
];

/// The steel laws by registry name, with their parameters.
pub const STEEL_LAWS: &[crate::params::LawParams] = &[
    crate::params::LawParams { name: "bilinear", summary: "Elastic–plastic with linear isotropic hardening, rupture at ε_u, optional Cowper–Symonds rate factor (`steel(#{ … })` is this law).", params: STEEL_PARAMS },
    crate::params::LawParams { name: "script", summary: "Stress from strain, strain rate and history, written in Rhai and compiled once to native code.", params: SCRIPT_STEEL_PARAMS },
];

compiled::law_signature! {
    /// Inputs of a steel law written in Rhai, per bar: strain ε and its rate ε̇ [1/s], the
    /// plastic strain ε_p and the history variable α returned last step, Young's modulus E.
    pub struct SteelLawInputs { strain, strain_rate, plastic_strain, history, young }
    /// A steel law: `fn law(b, p)` returning `#{ stress, plastic_strain, history }` (σ [Pa],
    /// ε_p [-], α: any history variable the law keeps, e.g. the accumulated plastic strain).
    pub const STEEL_LAW = "steel law" -> ["stress", "plastic_strain", "history"];
}

/// How the stress follows from the strain.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub enum SteelLaw {
    /// Built-in linear isotropic hardening (module docs).
    Bilinear,
    /// A Rhai function compiled to native code ([`STEEL_LAW`]).
    Script(std::sync::Arc<compiled::CompiledLaw>),
}

/// A uniaxial steel.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Steel {
    /// ρ [kg/m³]
    pub density: Real,
    /// E [Pa]
    pub young: Real,
    /// f_y [Pa]
    pub yield_stress: Real,
    /// H [Pa]
    pub hardening: Real,
    /// ε_u [-] (∞: no rupture)
    pub rupture_strain: Real,
    /// Cowper–Symonds (C [1/s], p), if any.
    pub rate: Option<(Real, Real)>,
    pub law: SteelLaw,
}

/// History of one bar's steel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SteelState {
    /// ε_p [-]
    pub plastic_strain: Real,
    /// α [-]: accumulated plastic strain (built-in law) or the script law's history variable.
    pub history: Real,
}

impl Steel {
    /// A steel from the values of [`STEEL_PARAMS`] (checked, with their defaults).
    pub fn from_params(given: Given) -> Result<Self, String> {
        let v = |name| value_of(STEEL_PARAMS, name, given);
        let opt = |name| value(STEEL_PARAMS, name, given, Real::NAN);
        let (density, young, fy) = (v("density")?, v("young")?, v("yield_stress")?);
        let eu = opt("ultimate_strain")?;
        let hardening = match (opt("hardening")?, opt("ultimate_stress")?) {
            (Some(_), Some(_)) => {
                return Err("give hardening or ultimate_stress, not both".into());
            }
            (Some(h), None) => h,
            (None, None) => 0.0,
            (None, Some(fu)) => {
                if fu < fy {
                    return Err(format!(
                        "ultimate_stress f_u = {fu} Pa is below yield_stress f_y = {fy} Pa"
                    ));
                }
                let eu = eu.ok_or("ultimate_stress needs ultimate_strain (the strain at f_u)")?;
                let eu_plastic = eu - fu / young;
                if eu_plastic <= 0.0 {
                    return Err(format!(
                        "ultimate_strain ε_u = {eu} must exceed the strain at f_u, f_u/E = {:.4e}",
                        fu / young
                    ));
                }
                (fu - fy) / eu_plastic
            }
        };
        let rate = match opt("rate_c")? {
            Some(c) => Some((c, v("rate_p")?)),
            None => None,
        };
        Ok(Steel {
            density,
            young,
            yield_stress: fy,
            hardening,
            rupture_strain: eu.unwrap_or(Real::INFINITY),
            rate,
            law: SteelLaw::Bilinear,
        })
    }

    /// A steel whose stress is the compiled script law `law`, from the values of
    /// [`SCRIPT_STEEL_PARAMS`] (density, young, ultimate_strain).
    pub fn script(
        law: std::sync::Arc<compiled::CompiledLaw>,
        given: Given,
    ) -> Result<Self, String> {
        let v = |name| value_of(STEEL_PARAMS, name, given);
        Ok(Steel {
            density: v("density")?,
            young: v("young")?,
            yield_stress: Real::NAN,
            hardening: 0.0,
            rupture_strain: value(STEEL_PARAMS, "ultimate_strain", given, Real::NAN)?
                .unwrap_or(Real::INFINITY),
            rate: None,
            law: SteelLaw::Script(law),
        })
    }

    /// Cowper–Symonds factor 1 + (|ε̇|/C)^{1/p} (1 without a rate law).
    #[inline]
    pub fn rate_factor(&self, strain_rate: Real) -> Real {
        match self.rate {
            Some((c, p)) => 1.0 + (strain_rate.abs() / c).powf(1.0 / p),
            None => 1.0,
        }
    }

    /// Stress σ [Pa] at strain `strain` and rate `strain_rate` [1/s], advancing `state`; also
    /// returns the plastic work per unit volume of this update [J/m³]. A script law that
    /// returns a non-finite value gives NaN (the run stops on it as unstable).
    #[inline]
    pub fn stress(&self, strain: Real, strain_rate: Real, state: &mut SteelState) -> (Real, Real) {
        match &self.law {
            SteelLaw::Bilinear => self.return_map(strain, strain_rate, state),
            SteelLaw::Script(law) => {
                let inputs = SteelLawInputs {
                    strain,
                    strain_rate,
                    plastic_strain: state.plastic_strain,
                    history: state.history,
                    young: self.young,
                };
                let [sigma, ep, h] = law.evaluate::<3>(&inputs.to_slots());
                let sigma_old = self.young * (strain - state.plastic_strain);
                let work = 0.5 * (sigma + sigma_old) * (ep - state.plastic_strain);
                *state = SteelState {
                    plastic_strain: ep,
                    history: h,
                };
                (sigma, work)
            }
        }
    }

    /// The built-in law's return map (module docs).
    #[inline]
    fn return_map(&self, strain: Real, strain_rate: Real, s: &mut SteelState) -> (Real, Real) {
        let e = self.young;
        let trial = e * (strain - s.plastic_strain);
        let k = self.rate_factor(strain_rate);
        let yield_now = k * (self.yield_stress + self.hardening * s.history);
        let f = trial.abs() - yield_now;
        if f <= 0.0 {
            return (trial, 0.0);
        }
        let dgamma = f / (e + k * self.hardening);
        let sign = trial.signum();
        s.plastic_strain += dgamma * sign;
        s.history += dgamma;
        let sigma = trial - e * dgamma * sign;
        (sigma, 0.5 * (yield_now + sigma.abs()) * dgamma)
    }

    /// Elastic strain energy per unit volume ½σ²/E [J/m³].
    #[inline]
    pub fn elastic_energy_density(&self, stress: Real) -> Real {
        0.5 * stress * stress / self.young
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel(h: Real) -> Steel {
        Steel {
            density: 7850.0,
            young: 200e9,
            yield_stress: 400e6,
            hardening: h,
            rupture_strain: Real::INFINITY,
            rate: None,
            law: SteelLaw::Bilinear,
        }
    }

    /// Monotone loading in small increments: σ follows f_y + H'ε beyond yield with the
    /// elasto-plastic tangent H' = EH/(E + H) (exact for a linear law), and the summed plastic
    /// work equals ∫σ dε_p = (f_y + ½Hα)α (exact: the trapezoid is exact on a line).
    #[test]
    fn return_map_follows_the_bilinear_curve_and_books_the_plastic_work() {
        let s = steel(2e9);
        let mut st = SteelState::default();
        let mut work = 0.0;
        let mut sigma = 0.0;
        let n = 1000;
        for i in 1..=n {
            let eps = 0.02 * i as Real / n as Real;
            let (sg, w) = s.stress(eps, 0.0, &mut st);
            sigma = sg;
            work += w;
        }
        let alpha = st.history;
        assert!((alpha - (0.02 - sigma / 200e9)).abs() < 1e-15);
        assert!((sigma - (400e6 + 2e9 * alpha)).abs() < 1e-6 * sigma);
        let exact = (400e6 + 0.5 * 2e9 * alpha) * alpha;
        assert!((work - exact).abs() < 1e-12 * exact, "{work} vs {exact}");
    }

    #[test]
    fn ultimate_stress_sets_the_hardening_and_bad_values_are_named() {
        let given = |fu: Real, eu: Real| {
            move |p: &Param| -> Result<Option<Real>, String> {
                Ok(match p.name {
                    "yield_stress" => Some(464e6),
                    "ultimate_stress" => Some(fu),
                    "ultimate_strain" => Some(eu),
                    _ => None,
                })
            }
        };
        let s = Steel::from_params(&given(630e6, 0.15)).unwrap();
        let at_eu = 464e6 + s.hardening * (0.15 - 630e6 / 200e9);
        assert!((at_eu - 630e6).abs() < 1e-3);
        let e = Steel::from_params(&given(400e6, 0.15)).unwrap_err();
        assert!(
            e.contains("ultimate_stress") && e.contains("yield_stress"),
            "{e}"
        );
    }
}
