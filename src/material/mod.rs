//! Elastic laws of the constant-strain tetrahedron (stage 1 reads them), with viscous damping.
//!
//! Every law maps the deformation gradient F (uniform in a tet4) to the first Piola–Kirchhoff
//! stress P, from which nodal forces follow as f = −V₀·P·∇N₀ (see [`crate::elements`]).
//! Lamé constants from Young's modulus E and Poisson's ratio ν:
//! λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)), bulk modulus K = λ + 2μ/3.
//!
//! | name | strain | stress | hyperelastic |
//! |---|---|---|---|
//! | `elastic/small_strain` | ε = sym(F) − I | σ = λ tr ε I + 2μ ε, P = σ | yes (not objective: a rigid rotation gives stress) |
//! | `elastic/st_venant_kirchhoff` | E = ½(FᵀF − I) | S = λ tr E I + 2μ E, P = F S | yes |
//! | `elastic/munjiza` | Ẽ_d = ½(B/J^{2/3} − I), Ẽ_s = ½(J^{2/3} − 1) I, B = FFᵀ | σ = (2μ Ẽ_d + 3K Ẽ_s)/J^{2/3} | no (Cauchy-elastic) |
//! | `elastic/neo_hookean` | C = FᵀF, J = det F | P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ | yes |
//!
//! `elastic/munjiza` is Munjiza (2004), *The Combined Finite-Discrete Element Method*, eqs.
//! 4.215–4.220: the left Cauchy–Green tensor split into a shape-changing and a volume-changing
//! part. It is not derived from a strain-energy function, so its "strain energy" (reported for
//! the energy balance) is the quadratic form ψ = μ Ẽ_d:Ẽ_d + (9K/2) ẽ_s², exact to second order
//! in the strain; under finite strain the balance carries an error of third order.
//!
//! Viscous damping (all laws): σ_v = η·D with D = sym(Ḟ F⁻¹) the rate of deformation and η
//! [Pa·s] the `viscosity` (Munjiza's 2μ_v); P_v = J σ_v F⁻ᵀ (small strain: P_v = η sym(Ḟ)).

use crate::math::{Mat3, Real};
use crate::params::{value_of, DefaultValue, Given, Param, Range};

/// Parameters of every elastic law (`material(law, #{ … })`).
pub const MATERIAL_PARAMS: &[Param] = &[
    Param::float(
        "density",
        "kg/m³",
        DefaultValue::Required,
        Range::POSITIVE,
        "Mass density ρ.",
    ),
    Param::float(
        "young",
        "Pa",
        DefaultValue::Required,
        Range::POSITIVE,
        "Young's modulus E.",
    ),
    Param::float(
        "poisson",
        "-",
        DefaultValue::Required,
        Range::new(-1.0, 0.5, true, true),
        "Poisson's ratio ν.",
    ),
    Param::float(
        "viscosity",
        "Pa·s",
        DefaultValue::Value(0.0),
        Range::NON_NEGATIVE,
        "Viscous damping η: σ_v = η·D, D the rate of deformation.",
    ),
];

/// The strain/stress formulation of an elastic material.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Formulation {
    SmallStrain,
    StVenantKirchhoff,
    Munjiza,
    NeoHookean,
}

impl Formulation {
    pub const ALL: [Formulation; 4] = [
        Formulation::SmallStrain,
        Formulation::StVenantKirchhoff,
        Formulation::Munjiza,
        Formulation::NeoHookean,
    ];

    /// Registry name used in scripts.
    pub fn name(self) -> &'static str {
        match self {
            Formulation::SmallStrain => "elastic/small_strain",
            Formulation::StVenantKirchhoff => "elastic/st_venant_kirchhoff",
            Formulation::Munjiza => "elastic/munjiza",
            Formulation::NeoHookean => "elastic/neo_hookean",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// True where the law is derived from a strain-energy function (force = −∂U/∂x exactly).
    pub fn is_hyperelastic(self) -> bool {
        !matches!(self, Formulation::Munjiza)
    }
}

/// Stress measure for output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StressMeasure {
    /// σ, force per current area (symmetric).
    Cauchy,
    /// P, force per reference area (not symmetric).
    Pk1,
    /// S = F⁻¹P, pulled back (symmetric).
    Pk2,
}

impl StressMeasure {
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "cauchy" => Some(Self::Cauchy),
            "pk1" => Some(Self::Pk1),
            "pk2" => Some(Self::Pk2),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Self::Cauchy => "cauchy",
            Self::Pk1 => "pk1",
            Self::Pk2 => "pk2",
        }
    }
}

/// An isotropic elastic material with viscous damping.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub formulation: Formulation,
    /// ρ [kg/m³]
    pub density: Real,
    /// E [Pa]
    pub young: Real,
    /// ν [-]
    pub poisson: Real,
    /// η [Pa·s]
    pub viscosity: Real,
    /// λ [Pa]
    pub lambda: Real,
    /// μ [Pa]
    pub mu: Real,
}

impl Material {
    /// Build from E, ν, ρ; checks 0 < E, −1 < ν < 0.5, ρ > 0, η ≥ 0.
    /// A material of `formulation` from the values of [`MATERIAL_PARAMS`] (checked, with
    /// their defaults).
    pub fn from_params(formulation: Formulation, given: Given) -> Result<Self, String> {
        let v = |name| value_of(MATERIAL_PARAMS, name, given);
        Material::new(
            formulation,
            v("density")?,
            v("young")?,
            v("poisson")?,
            v("viscosity")?,
        )
    }

    pub fn new(
        formulation: Formulation,
        density: Real,
        young: Real,
        poisson: Real,
        viscosity: Real,
    ) -> Result<Self, String> {
        for (p, x) in MATERIAL_PARAMS
            .iter()
            .zip([density, young, poisson, viscosity])
        {
            p.check(x)?;
        }
        let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
        let mu = young / (2.0 * (1.0 + poisson));
        Ok(Material {
            name: formulation.name().to_string(),
            formulation,
            density,
            young,
            poisson,
            viscosity,
            lambda,
            mu,
        })
    }

    /// Bulk modulus K = λ + 2μ/3 [Pa].
    pub fn bulk(&self) -> Real {
        self.lambda + 2.0 * self.mu / 3.0
    }

    /// P-wave modulus λ + 2μ [Pa]; the dilatational wave speed is √((λ+2μ)/ρ).
    pub fn p_wave_modulus(&self) -> Real {
        self.lambda + 2.0 * self.mu
    }

    /// First Piola–Kirchhoff stress P(F) of the elastic part [Pa].
    #[inline(always)]
    pub fn pk1(&self, f: &Mat3) -> Mat3 {
        let (lambda, mu) = (self.lambda, self.mu);
        let id = Mat3::identity();
        match self.formulation {
            Formulation::SmallStrain => {
                let eps = 0.5 * (f + f.transpose()) - id;
                id * (lambda * eps.trace()) + eps * (2.0 * mu)
            }
            Formulation::StVenantKirchhoff => {
                let e = 0.5 * (f.transpose() * f - id);
                f * (id * (lambda * e.trace()) + e * (2.0 * mu))
            }
            Formulation::Munjiza => {
                let j = f.determinant();
                let sigma = munjiza_cauchy(f, j, mu, self.bulk());
                let f_inv_t = f.try_inverse().unwrap_or(Mat3::zeros()).transpose();
                sigma * f_inv_t * j
            }
            Formulation::NeoHookean => {
                let j = f.determinant();
                let f_inv_t = f.try_inverse().unwrap_or(Mat3::zeros()).transpose();
                (f - f_inv_t) * mu + f_inv_t * (lambda * j.ln())
            }
        }
    }

    /// Strain energy per unit reference volume ψ(F) [J/m³] (for `elastic/munjiza` the
    /// second-order quadratic form documented in the module docs).
    pub fn energy_density(&self, f: &Mat3) -> Real {
        let (lambda, mu) = (self.lambda, self.mu);
        let id = Mat3::identity();
        match self.formulation {
            Formulation::SmallStrain => {
                let eps = 0.5 * (f + f.transpose()) - id;
                0.5 * lambda * eps.trace().powi(2) + mu * eps.norm_squared()
            }
            Formulation::StVenantKirchhoff => {
                let e = 0.5 * (f.transpose() * f - id);
                0.5 * lambda * e.trace().powi(2) + mu * e.norm_squared()
            }
            Formulation::Munjiza => {
                let j = f.determinant();
                let j23 = j.abs().cbrt().powi(2);
                let ed = 0.5 * (f * f.transpose() / j23 - id);
                let es = 0.5 * (j23 - 1.0);
                mu * ed.norm_squared() + 4.5 * self.bulk() * es * es
            }
            Formulation::NeoHookean => {
                let j = f.determinant();
                let lnj = j.ln();
                0.5 * mu * ((f.transpose() * f).trace() - 3.0) - mu * lnj + 0.5 * lambda * lnj * lnj
            }
        }
    }

    /// Viscous first Piola–Kirchhoff stress from F and its rate Ḟ [Pa].
    #[inline(always)]
    pub fn pk1_viscous(&self, f: &Mat3, f_dot: &Mat3) -> Mat3 {
        let eta = self.viscosity;
        match self.formulation {
            Formulation::SmallStrain => 0.5 * eta * (f_dot + f_dot.transpose()),
            _ => {
                let f_inv = f.try_inverse().unwrap_or(Mat3::zeros());
                let l = f_dot * f_inv;
                let d = 0.5 * (l + l.transpose());
                d * (eta * f.determinant()) * f_inv.transpose()
            }
        }
    }

    /// Stress in the requested measure from F (elastic part).
    pub fn stress(&self, f: &Mat3, measure: StressMeasure) -> Mat3 {
        let p = self.pk1(f);
        match measure {
            StressMeasure::Pk1 => p,
            StressMeasure::Cauchy => match self.formulation {
                // Small strain: σ is the stress itself (no distinction of configurations).
                Formulation::SmallStrain => p,
                _ => p * f.transpose() / f.determinant(),
            },
            StressMeasure::Pk2 => match self.formulation {
                Formulation::SmallStrain => p,
                _ => f.try_inverse().unwrap_or(Mat3::zeros()) * p,
            },
        }
    }
}

/// Munjiza (2004) eq. 4.220 without the viscous term: σ = (2μ Ẽ_d + 3K Ẽ_s)/J^{2/3}.
#[inline(always)]
pub fn munjiza_cauchy(f: &Mat3, j: Real, mu: Real, bulk: Real) -> Mat3 {
    let id = Mat3::identity();
    let y = inv_cbrt(j.abs()); // J^{-1/3}
    let inv_j23 = y * y;
    let j23 = j.abs() * y;
    let ed = 0.5 * (f * f.transpose() * inv_j23 - id);
    let es = 0.5 * (j23 - 1.0);
    (ed * (2.0 * mu) + id * (3.0 * bulk * es)) * inv_j23
}

/// x^{-1/3} for x > 0. Near 1 (|x − 1| ≤ 0.1, every element short of large volume change)
/// three Newton steps y ← y(4 − x·y³)/3 from the second-order guess 1 − δ/3 + 2δ²/9 reach
/// full double precision (error 1.7e-4 → 6e-8 → 7e-15 → rounding) without a division or a
/// libm call; elsewhere `cbrt`.
#[inline(always)]
pub fn inv_cbrt(x: Real) -> Real {
    let d = x - 1.0;
    if d.abs() <= 0.1 {
        let mut y = 1.0 - d * (1.0 / 3.0) + d * d * (2.0 / 9.0);
        for _ in 0..3 {
            y *= (4.0 - x * y * y * y) * (1.0 / 3.0);
        }
        y
    } else {
        1.0 / x.cbrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Newton inverse cube root agrees with libm's cbrt to 2 ulp over its branch and at
    /// the switch points.
    #[test]
    fn inv_cbrt_matches_libm() {
        for i in 0..=20_000 {
            let x = 0.85 + 0.3 * i as Real / 20_000.0;
            let exact = 1.0 / x.cbrt();
            assert!(
                (inv_cbrt(x) - exact).abs() <= 4.0 * Real::EPSILON * exact,
                "x = {x}"
            );
        }
    }

    fn rock(f: Formulation) -> Material {
        Material::new(f, 2500.0, 30e9, 0.25, 0.0).unwrap()
    }

    /// Reference: every law reduces to Hooke's law for an infinitesimal strain; at ε = 1e-6
    /// the nonlinear terms are O(ε²) relative, so 1e-5 relative is a strict but fair bound.
    #[test]
    fn all_laws_agree_with_hooke_at_small_strain() {
        let g = Mat3::new(1.0, 0.3, -0.2, 0.1, -0.5, 0.4, 0.7, 0.2, 0.6) * 1e-6;
        let f = Mat3::identity() + g;
        let eps = 0.5 * (g + g.transpose());
        for form in Formulation::ALL {
            let m = rock(form);
            let hooke = Mat3::identity() * (m.lambda * eps.trace()) + eps * (2.0 * m.mu);
            let s = m.stress(&f, StressMeasure::Cauchy);
            assert!((s - hooke).norm() < 1e-5 * hooke.norm(), "{form:?}");
        }
    }

    /// P = ∂ψ/∂F by central differences for the hyperelastic laws (h = 1e-6: truncation
    /// O(h²) ≈ 1e-12, rounding ≈ 1e-16/1e-6 relative; 1e-6 relative leaves margin).
    #[test]
    fn pk1_is_energy_derivative() {
        let f = Mat3::new(1.1, 0.2, -0.1, 0.05, 0.95, 0.15, -0.08, 0.1, 1.05);
        for form in Formulation::ALL.into_iter().filter(|f| f.is_hyperelastic()) {
            let m = rock(form);
            let p = m.pk1(&f);
            let h = 1e-6;
            for i in 0..3 {
                for j in 0..3 {
                    let mut fp = f;
                    let mut fm = f;
                    fp[(i, j)] += h;
                    fm[(i, j)] -= h;
                    let d = (m.energy_density(&fp) - m.energy_density(&fm)) / (2.0 * h);
                    assert!(
                        (d - p[(i, j)]).abs() < 1e-6 * p.norm(),
                        "{form:?} ({i},{j})"
                    );
                }
            }
        }
    }
}
