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
//! | `elastic/mooney_rivlin` | Ī₁ = J^{-2/3} I₁, Ī₂ = J^{-4/3} I₂ | P = ∂W/∂F below | yes |
//!
//! `elastic/mooney_rivlin` is the compressible Mooney–Rivlin solid in the decoupled form of
//! Holzapfel (2000), *Nonlinear Solid Mechanics*, §6.5 (the form of Abaqus' `MOONEY-RIVLIN`
//! with D₁ = 2/K): W = C₁₀(Ī₁ − 3) + C₀₁(Ī₂ − 3) + (K/2)(J − 1)², with I₁ = tr C,
//! I₂ = ½(I₁² − tr C²), C = FᵀF. Its parameters are `c10`, `c01` (both ≥ 0, which makes W
//! polyconvex, Ball 1977) and the bulk modulus `bulk`; at small strain it is Hooke's law with
//! μ = 2(C₁₀ + C₀₁) and K, so λ = K − 2μ/3, E = 9Kμ/(3K + μ) and ν = (3K − 2μ)/(2(3K + μ))
//! are derived from them (the critical time step uses the p-wave modulus K + 4μ/3). With
//! ∂I₁/∂F = 2F, ∂I₂/∂F = 2(I₁F − FC), ∂J/∂F = J F⁻ᵀ:
//! P = C₁₀ J^{-2/3}(2F − ⅔ I₁ F⁻ᵀ) + C₀₁ J^{-4/3}(2(I₁F − FC) − ⁴⁄₃ I₂ F⁻ᵀ) + K(J − 1) J F⁻ᵀ.
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
use crate::params::{value_of, DefaultValue, Given, LawParams, Param, Range};

/// Parameters of the laws given by Young's modulus and Poisson's ratio, with the common ones
/// ([`MATERIAL_COMMON_PARAMS`]); [`Material::new`] checks its arguments against them.
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

/// Keys every law of `material(law, #{ … })` takes.
pub const MATERIAL_COMMON_PARAMS: &[Param] = &[MATERIAL_PARAMS[0], MATERIAL_PARAMS[3]];

/// The elastic constants of the laws given by E and ν.
pub const ELASTIC_PARAMS: &[Param] = &[MATERIAL_PARAMS[1], MATERIAL_PARAMS[2]];

/// The constants of `elastic/mooney_rivlin`.
pub const MOONEY_RIVLIN_PARAMS: &[Param] = &[
    Param::float(
        "c10",
        "Pa",
        DefaultValue::Required,
        Range::NON_NEGATIVE,
        "C₁₀, the coefficient of Ī₁ − 3; small-strain shear modulus μ = 2(C₁₀ + C₀₁) > 0.",
    ),
    Param::float(
        "c01",
        "Pa",
        DefaultValue::Required,
        Range::NON_NEGATIVE,
        "C₀₁, the coefficient of Ī₂ − 3 (0 gives a neo-Hookean solid in Ī₁).",
    ),
    Param::float(
        "bulk",
        "Pa",
        DefaultValue::Required,
        Range::POSITIVE,
        "Bulk modulus K of the volumetric energy (K/2)(J − 1)².",
    ),
];

/// The laws of `material(law, #{ … })` and their own keys (besides [`MATERIAL_COMMON_PARAMS`]).
pub const MATERIAL_LAWS: &[LawParams] = &[
    LawParams { name: "elastic/small_strain", summary: "Hooke's law on the linear strain sym(F) − I (not objective).", params: ELASTIC_PARAMS },
    LawParams { name: "elastic/st_venant_kirchhoff", summary: "Hooke's law between the Green–Lagrange strain and the PK2 stress.", params: ELASTIC_PARAMS },
    LawParams { name: "elastic/munjiza", summary: "Left Cauchy–Green split into shape and volume change, Cauchy stress (Munjiza 2004 eq. 4.220).", params: ELASTIC_PARAMS },
    LawParams { name: "elastic/neo_hookean", summary: "Compressible neo-Hookean, W = μ/2(I₁ − 3) − μ ln J + λ/2 ln²J.", params: ELASTIC_PARAMS },
    LawParams { name: "elastic/mooney_rivlin", summary: "Compressible Mooney–Rivlin, W = C₁₀(Ī₁ − 3) + C₀₁(Ī₂ − 3) + K/2 (J − 1)² (Holzapfel 2000 §6.5), for rubber-like solids.", params: MOONEY_RIVLIN_PARAMS },
];

/// The strain/stress formulation of an elastic material.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Formulation {
    SmallStrain,
    StVenantKirchhoff,
    Munjiza,
    NeoHookean,
    MooneyRivlin,
}

impl Formulation {
    pub const ALL: [Formulation; 5] = [
        Formulation::SmallStrain,
        Formulation::StVenantKirchhoff,
        Formulation::Munjiza,
        Formulation::NeoHookean,
        Formulation::MooneyRivlin,
    ];

    /// Registry name used in scripts.
    pub fn name(self) -> &'static str {
        match self {
            Formulation::SmallStrain => "elastic/small_strain",
            Formulation::StVenantKirchhoff => "elastic/st_venant_kirchhoff",
            Formulation::Munjiza => "elastic/munjiza",
            Formulation::NeoHookean => "elastic/neo_hookean",
            Formulation::MooneyRivlin => "elastic/mooney_rivlin",
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
    /// μ [Pa] (Mooney–Rivlin: 2(C₁₀ + C₀₁))
    pub mu: Real,
    /// C₀₁ [Pa] of `elastic/mooney_rivlin` (C₁₀ = μ/2 − C₀₁); 0 for the other laws.
    #[serde(default)]
    pub c01: Real,
}

impl Material {
    /// A material of `formulation` from the values of its law's parameters
    /// ([`MATERIAL_LAWS`] and [`MATERIAL_COMMON_PARAMS`]; checked, with their defaults).
    pub fn from_params(formulation: Formulation, given: Given) -> Result<Self, String> {
        let v = |name| value_of(MATERIAL_PARAMS, name, given);
        if formulation == Formulation::MooneyRivlin {
            let mr = |name| value_of(MOONEY_RIVLIN_PARAMS, name, given);
            return Material::mooney_rivlin(
                v("density")?,
                mr("c10")?,
                mr("c01")?,
                mr("bulk")?,
                v("viscosity")?,
            );
        }
        Material::new(
            formulation,
            v("density")?,
            v("young")?,
            v("poisson")?,
            v("viscosity")?,
        )
    }

    /// Build from E, ν, ρ; checks 0 < E, −1 < ν < 0.5, ρ > 0, η ≥ 0. For
    /// `elastic/mooney_rivlin` E and ν set the small-strain constants: C₀₁ = 0 (use
    /// [`Material::mooney_rivlin`] for both constants).
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
            c01: 0.0,
        })
    }

    /// `elastic/mooney_rivlin` from C₁₀, C₀₁ ≥ 0 (not both 0), the bulk modulus K > 0, ρ > 0
    /// and η ≥ 0. Its small-strain constants are μ = 2(C₁₀ + C₀₁) and K, which must give
    /// ν = (3K − 2μ)/(2(3K + μ)) > −1 (always) and < 0.5 (always for finite K).
    pub fn mooney_rivlin(
        density: Real,
        c10: Real,
        c01: Real,
        bulk: Real,
        viscosity: Real,
    ) -> Result<Self, String> {
        for (p, x) in MOONEY_RIVLIN_PARAMS.iter().zip([c10, c01, bulk]) {
            p.check(x)?;
        }
        for (p, x) in MATERIAL_COMMON_PARAMS.iter().zip([density, viscosity]) {
            p.check(x)?;
        }
        let mu = 2.0 * (c10 + c01);
        if mu <= 0.0 {
            return Err(format!(
                "c10 + c01 must be > 0 Pa (the shear modulus is 2(c10 + c01)), got {c10} + {c01}"
            ));
        }
        let young = 9.0 * bulk * mu / (3.0 * bulk + mu);
        let poisson = (3.0 * bulk - 2.0 * mu) / (2.0 * (3.0 * bulk + mu));
        Ok(Material {
            name: Formulation::MooneyRivlin.name().to_string(),
            formulation: Formulation::MooneyRivlin,
            density,
            young,
            poisson,
            viscosity,
            lambda: bulk - 2.0 * mu / 3.0,
            mu,
            c01,
        })
    }

    /// C₁₀ of `elastic/mooney_rivlin` [Pa] (μ/2 for the others, which have no C₀₁).
    pub fn c10(&self) -> Real {
        0.5 * self.mu - self.c01
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
            Formulation::MooneyRivlin => {
                let j = f.determinant();
                let f_inv_t = f.try_inverse().unwrap_or(Mat3::zeros()).transpose();
                let c = f.transpose() * f;
                let i1 = c.trace();
                let i2 = 0.5 * (i1 * i1 - (c * c).trace());
                let y = inv_cbrt(j.abs()); // J^{-1/3}
                let (jm23, jm43) = (y * y, y * y * y * y);
                let (c10, c01) = (self.c10(), self.c01);
                (f * 2.0 - f_inv_t * (2.0 / 3.0 * i1)) * (c10 * jm23)
                    + ((f * i1 - f * c) * 2.0 - f_inv_t * (4.0 / 3.0 * i2)) * (c01 * jm43)
                    + f_inv_t * (self.bulk() * (j - 1.0) * j)
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
            Formulation::MooneyRivlin => {
                let j = f.determinant();
                let c = f.transpose() * f;
                let i1 = c.trace();
                let i2 = 0.5 * (i1 * i1 - (c * c).trace());
                let y = inv_cbrt(j.abs());
                self.c10() * (i1 * y * y - 3.0)
                    + self.c01 * (i2 * y * y * y * y - 3.0)
                    + 0.5 * self.bulk() * (j - 1.0) * (j - 1.0)
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

    /// A rubber-like Mooney–Rivlin solid with both constants non-zero (C₀₁/C₁₀ = 0.25, a
    /// typical ratio of fits to rubber; K/μ = 50, nearly incompressible).
    fn rubber() -> Material {
        Material::mooney_rivlin(1100.0, 0.4e6, 0.1e6, 50e6, 0.0).unwrap()
    }

    /// A general large deformation (stretches up to ~40 %, shear, J ≈ 1.06).
    fn big_f() -> Mat3 {
        Mat3::new(1.3, 0.25, -0.1, 0.05, 0.85, 0.3, -0.15, 0.1, 1.1)
    }

    /// Reference: P = ∂W/∂F, checked by central differences of W. h = 1e-6 on entries of
    /// order 1: truncation O(h²) ≈ 1e-12 relative, rounding ε·|W|/h ≈ 1e-10·|W|; 1e-6
    /// relative to |P| leaves margin and catches any wrong term (a missing ⅔ or ⁴⁄₃ factor
    /// is an O(1) error).
    #[test]
    fn mooney_rivlin_pk1_is_energy_derivative() {
        let m = rubber();
        for f in [big_f(), Mat3::identity() * 0.97 + big_f() * 0.02] {
            let p = m.pk1(&f);
            let h = 1e-6;
            for i in 0..3 {
                for j in 0..3 {
                    let (mut fp, mut fm) = (f, f);
                    fp[(i, j)] += h;
                    fm[(i, j)] -= h;
                    let d = (m.energy_density(&fp) - m.energy_density(&fm)) / (2.0 * h);
                    assert!(
                        (d - p[(i, j)]).abs() < 1e-6 * p.norm(),
                        "({i},{j}): fd {d:e} vs P {:e}",
                        p[(i, j)]
                    );
                }
            }
        }
    }

    /// Reference: linearised elasticity. At F = I + g, |g| = 1e-6, Mooney–Rivlin is Hooke's
    /// law with μ = 2(C₁₀ + C₀₁) and bulk modulus K (λ = K − 2μ/3) up to O(|g|) relative;
    /// 1e-5 relative as for the other laws. Also W(I) = 0, P(I) = 0 and the p-wave modulus
    /// (used by the critical time step) is K + 4μ/3.
    #[test]
    fn mooney_rivlin_is_hooke_at_small_strain() {
        let m = rubber();
        let (mu, k) = (2.0 * (0.4e6 + 0.1e6), 50e6);
        assert!((m.mu - mu).abs() < 1e-9 * mu && (m.bulk() - k).abs() < 1e-9 * k);
        assert!((m.p_wave_modulus() - (k + 4.0 * mu / 3.0)).abs() < 1e-9 * k);
        assert!((m.young - 9.0 * k * mu / (3.0 * k + mu)).abs() < 1e-9 * m.young);
        assert_eq!(m.energy_density(&Mat3::identity()), 0.0);
        assert!(m.pk1(&Mat3::identity()).norm() < 1e-9 * mu);
        let g = Mat3::new(1.0, 0.3, -0.2, 0.1, -0.5, 0.4, 0.7, 0.2, 0.6) * 1e-6;
        let eps = 0.5 * (g + g.transpose());
        let lambda = k - 2.0 * mu / 3.0;
        let hooke = Mat3::identity() * (lambda * eps.trace()) + eps * (2.0 * mu);
        for measure in [
            StressMeasure::Cauchy,
            StressMeasure::Pk1,
            StressMeasure::Pk2,
        ] {
            let s = m.stress(&(Mat3::identity() + g), measure);
            assert!(
                (s - hooke).norm() < 1e-5 * hooke.norm(),
                "{measure:?}: {s} vs {hooke}"
            );
        }
    }

    /// Reference: Rivlin's exact results for the incompressible Mooney–Rivlin solid
    /// (σ = −pI + 2C₁₀B − 2C₀₁B⁻¹; Holzapfel 2000 §7.2, Ogden 1984 §5.3). For an isochoric
    /// F (J = 1 exactly) the compressible law's volumetric term vanishes and its deviatoric
    /// part equals the incompressible one up to the pressure, so stress *differences* are
    /// exact: uniaxial F = diag(λ, λ^{-1/2}, λ^{-1/2}):
    /// σ₁₁ − σ₂₂ = 2(λ² − 1/λ)(C₁₀ + C₀₁/λ); simple shear F = I + γ e₁⊗e₂: σ₁₂ = 2(C₁₀ + C₀₁)γ,
    /// σ₁₁ − σ₃₃ = 2C₁₀γ², σ₂₂ − σ₃₃ = −2C₀₁γ². Only rounding separates them: 1e-10 relative.
    #[test]
    fn mooney_rivlin_matches_rivlin_uniaxial_and_simple_shear() {
        let m = rubber();
        let (c10, c01) = (0.4e6, 0.1e6);
        let close = |a: Real, b: Real, what: &str| {
            assert!(
                (a - b).abs() <= 1e-10 * b.abs().max(c10),
                "{what}: {a:e} vs {b:e}"
            );
        };
        for lam in [0.5, 0.8, 1.5, 2.0, 3.0] {
            let s = 1.0 / Real::sqrt(lam);
            let f = Mat3::from_diagonal(&crate::math::Vec3::new(lam, s, s));
            let sig = m.stress(&f, StressMeasure::Cauchy);
            let exact = 2.0 * (lam * lam - 1.0 / lam) * (c10 + c01 / lam);
            close(
                sig[(0, 0)] - sig[(1, 1)],
                exact,
                &format!("uniaxial λ = {lam}"),
            );
            close(sig[(1, 1)], sig[(2, 2)], "lateral symmetry");
            assert!(sig[(0, 1)].abs() < 1e-9 * c10);
        }
        for gamma in [0.1, 0.5, 1.0, 2.0] {
            let mut f = Mat3::identity();
            f[(0, 1)] = gamma;
            let sig = m.stress(&f, StressMeasure::Cauchy);
            close(sig[(0, 1)], 2.0 * (c10 + c01) * gamma, "shear stress");
            close(
                sig[(0, 0)] - sig[(2, 2)],
                2.0 * c10 * gamma * gamma,
                "σ11 − σ33",
            );
            close(
                sig[(1, 1)] - sig[(2, 2)],
                -2.0 * c01 * gamma * gamma,
                "σ22 − σ33",
            );
        }
    }

    /// Reference: material frame indifference. For any rotation Q, W(QF) = W(F) and
    /// P(QF) = Q·P(F) (Holzapfel 2000 §6.2). Rounding only: 1e-12 relative.
    #[test]
    fn mooney_rivlin_is_objective() {
        let m = rubber();
        let f = big_f();
        let q = nalgebra::Rotation3::from_scaled_axis(crate::math::Vec3::new(0.7, -1.1, 0.4))
            .into_inner();
        let (w, wq) = (m.energy_density(&f), m.energy_density(&(q * f)));
        assert!((w - wq).abs() < 1e-12 * w.abs(), "{w} vs {wq}");
        let (p, pq) = (m.pk1(&f), m.pk1(&(q * f)));
        assert!((q * p - pq).norm() < 1e-12 * p.norm());
        // The Cauchy stress is symmetric (balance of angular momentum).
        let s = m.stress(&f, StressMeasure::Cauchy);
        assert!((s - s.transpose()).norm() < 1e-12 * s.norm());
    }

    /// Parameter checks: negative constants, μ = 0 and a non-positive bulk modulus are
    /// refused with the parameter named.
    #[test]
    fn mooney_rivlin_refuses_bad_constants() {
        let e = Material::mooney_rivlin(1100.0, -1.0, 0.1e6, 50e6, 0.0).unwrap_err();
        assert!(e.contains("c10 must be ≥ 0"), "{e}");
        let e = Material::mooney_rivlin(1100.0, 0.0, 0.0, 50e6, 0.0).unwrap_err();
        assert!(e.contains("c10 + c01 must be > 0"), "{e}");
        let e = Material::mooney_rivlin(1100.0, 1e6, 0.0, 0.0, 0.0).unwrap_err();
        assert!(e.contains("bulk must be > 0"), "{e}");
    }
}
