//! Contact laws of stage 5 (registry name ↔ type, as [`crate::joints::JointLaw`]): the rules a
//! script gives, and the parameters they resolve to for every pair of materials.
//!
//! `"potential"` ([`ContactLaw::Potential`]): Munjiza's potential contact force (normal
//! penalty p, [`super::potential`]) with Coulomb friction on an elastic tangential spring
//! (p_t, μ or a compiled friction law, [`super::friction`]) and an optional normal dashpot ζ.

use crate::compiled::CompiledLaw;
use crate::math::Real;
use crate::params::{find, value_of, DefaultValue, Given, LawParams, Param, Range};
use std::sync::Arc;

/// Default normal penalty of the potential law: this factor × the larger Young's modulus of
/// the two materials [-] (docs/theory/contact.md: overlaps stay below ~1 % of the element
/// height at impact speeds of a few m/s).
pub const DEFAULT_PENALTY_FACTOR: Real = 10.0;

/// Parameters of the `"potential"` law.
pub const POTENTIAL_PARAMS: &[Param] = &[
    Param::float(
        "penalty",
        "Pa",
        DefaultValue::Scaled {
            factor: DEFAULT_PENALTY_FACTOR,
            of: "Young's modulus E of the stiffer material",
        },
        Range::POSITIVE,
        "Normal penalty p: contact energy p∫(φ_c + φ_t) dV over the overlap. Overlap depth ≈ H·σ/(8p) under contact pressure σ (H the element height); the critical time step falls as p grows.",
    ),
    Param::float(
        "tangential_penalty",
        "Pa",
        DefaultValue::Text("= penalty"),
        Range::POSITIVE,
        "Friction spring: stiffness (4/3)·p_t·A·(1/h_c + 1/h_t) per pair (A contact area, h element heights).",
    ),
    Param::float(
        "friction",
        "-",
        DefaultValue::Value(0.0),
        Range::NON_NEGATIVE,
        "Coulomb coefficient μ (static = kinetic). With `friction_law`: the law's input `c.mu`.",
    ),
    Param::other(
        "friction_law",
        "map",
        "",
        "none (μ = friction)",
        "μ as a Rhai function of each pair's slip rate, slip, pressure, …, compiled to native code: `#{ function, params, source }` (below; docs/theory/contact.md).",
    ),
    Param::float(
        "damping",
        "-",
        DefaultValue::Value(0.0),
        Range::new(0.0, 1.0, false, false),
        "Normal damping ratio ζ: a dashpot 2ζ√(k_n·m*) on the normal approach speed (for settling; dissipation is booked with friction).",
    ),
];

/// The contact laws by registry name, with their parameters.
pub const CONTACT_LAWS: &[LawParams] = &[LawParams {
    name: "potential",
    summary: "Munjiza's potential contact force with Coulomb friction.",
    params: POTENTIAL_PARAMS,
}];

/// A contact law with its parameters.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub enum ContactLaw {
    /// `"potential"`: potential contact force with Coulomb friction.
    Potential(PotentialContact),
}

impl ContactLaw {
    pub fn name(&self) -> &'static str {
        match self {
            ContactLaw::Potential(_) => "potential",
        }
    }
}

impl Default for ContactLaw {
    fn default() -> Self {
        ContactLaw::Potential(PotentialContact::default())
    }
}

/// Parameters of the `"potential"` contact law as the script gave them.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct PotentialContact {
    /// Normal penalty p [Pa]; None: [`DEFAULT_PENALTY_FACTOR`] × the larger Young's modulus
    /// of the pair.
    pub penalty: Option<Real>,
    /// Tangential penalty p_t [Pa]; None: equal to the normal penalty.
    pub tangential_penalty: Option<Real>,
    /// Coulomb friction coefficient μ [-] (with a friction law: its input `mu`).
    pub friction: Real,
    /// Normal damping ratio ζ [-].
    pub damping: Real,
    /// μ as a compiled function of the pair's kinematics (signature
    /// [`super::FRICTION_LAW`]); None: the constant `friction`.
    pub friction_law: Option<Arc<CompiledLaw>>,
}

impl PotentialContact {
    /// The law from the values of [`POTENTIAL_PARAMS`] (checked, with their defaults) and
    /// its friction law, if any.
    pub fn from_params(
        given: Given,
        friction_law: Option<Arc<CompiledLaw>>,
    ) -> Result<Self, String> {
        let checked = |name: &str| -> Result<Option<Real>, String> {
            let p = find(POTENTIAL_PARAMS, name).expect("a potential-law key");
            given(p)?.map(|x| p.check(x)).transpose()
        };
        Ok(PotentialContact {
            penalty: checked("penalty")?,
            tangential_penalty: checked("tangential_penalty")?,
            friction: value_of(POTENTIAL_PARAMS, "friction", given)?,
            damping: value_of(POTENTIAL_PARAMS, "damping", given)?,
            friction_law,
        })
    }
}

/// A contact rule from the script: rules without `materials` apply to every pair of
/// materials, rules with `materials` to one pair (later rules override earlier ones).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct ContactRule {
    pub materials: Option<(u32, u32)>,
    pub law: ContactLaw,
}

impl From<PotentialContact> for ContactRule {
    /// The potential law between every pair of materials.
    fn from(p: PotentialContact) -> Self {
        ContactRule {
            materials: None,
            law: ContactLaw::Potential(p),
        }
    }
}

/// [`ContactProps::friction_law`] of a rule without a friction law (μ is `friction`).
pub const NO_FRICTION_LAW: u32 = u32::MAX;

/// Resolved contact parameters of one pair of materials.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct ContactProps {
    /// Normal penalty p [Pa] (energy per overlap volume at φ = 1).
    pub penalty: Real,
    /// Tangential penalty p_t [Pa] (spring k_t = (4/3)·p_t·A·(1/h_c + 1/h_t)).
    pub tangential_penalty: Real,
    /// Coulomb friction coefficient μ [-] (with a friction law: its input `mu`).
    pub friction: Real,
    /// Normal damping ratio ζ [-].
    pub damping: Real,
    /// Index into [`ContactLaws::friction_laws`], or [`NO_FRICTION_LAW`].
    pub friction_law: u32,
}

impl ContactProps {
    /// Friction acts (a positive constant μ, or a law that may make it so).
    #[inline]
    pub fn has_friction(&self) -> bool {
        self.friction > 0.0 || self.friction_law != NO_FRICTION_LAW
    }
}

/// The rules of a simulation and what they resolve to (filled by [`ContactLaws::resolve`]
/// when the model is prepared).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct ContactLaws {
    /// Rules as given by the script.
    pub rules: Vec<ContactRule>,
    /// Resolved parameters, `props[a * n_materials + b]`.
    pub props: Vec<ContactProps>,
    /// The distinct friction laws of the rules.
    pub friction_laws: Vec<Arc<CompiledLaw>>,
    pub n_materials: usize,
}

impl ContactLaws {
    /// Contact is on once a rule is given.
    pub fn is_enabled(&self) -> bool {
        !self.rules.is_empty()
    }

    /// Resolve the rules for every pair of materials (defaults from their Young's moduli).
    pub fn resolve(&mut self, young: &[Real]) {
        let n = young.len();
        self.n_materials = n;
        self.props.clear();
        self.friction_laws.clear();
        for r in &self.rules {
            let ContactLaw::Potential(pc) = &r.law;
            if let Some(l) = &pc.friction_law {
                if !self.friction_laws.iter().any(|k| Arc::ptr_eq(k, l)) {
                    self.friction_laws.push(l.clone());
                }
            }
        }
        for a in 0..n {
            for b in 0..n {
                let mut p = ContactProps {
                    penalty: DEFAULT_PENALTY_FACTOR * young[a].max(young[b]),
                    tangential_penalty: 0.0,
                    friction: 0.0,
                    damping: 0.0,
                    friction_law: NO_FRICTION_LAW,
                };
                let mut pt = None;
                for r in &self.rules {
                    let applies = match r.materials {
                        None => true,
                        Some((x, y)) => {
                            (x as usize == a && y as usize == b)
                                || (x as usize == b && y as usize == a)
                        }
                    };
                    if !applies {
                        continue;
                    }
                    let ContactLaw::Potential(pc) = &r.law;
                    if let Some(v) = pc.penalty {
                        p.penalty = v;
                    }
                    pt = pc.tangential_penalty.or(pt);
                    p.friction = pc.friction;
                    p.damping = pc.damping;
                    p.friction_law = pc.friction_law.as_ref().map_or(NO_FRICTION_LAW, |l| {
                        self.friction_laws
                            .iter()
                            .position(|k| Arc::ptr_eq(k, l))
                            .unwrap() as u32
                    });
                }
                p.tangential_penalty = pt.unwrap_or(p.penalty);
                self.props.push(p);
            }
        }
    }

    /// Parameters between materials `ma` and `mb`.
    #[inline]
    pub fn props_of(&self, ma: u32, mb: u32) -> ContactProps {
        self.props[ma as usize * self.n_materials + mb as usize]
    }

    /// For each material, the largest penalty (normal or tangential) [Pa] of its pairs with
    /// the materials `present` (for the critical time step: a tet of material m meets only
    /// partners of a present material, so its contact springs are at most this stiff), and
    /// the partner material that has it (the first in material order; `u32::MAX` when no
    /// material is present).
    pub fn max_penalty_by_material(&self, present: &[bool]) -> Vec<(Real, u32)> {
        let n = self.n_materials;
        (0..n)
            .map(|a| {
                (0..n)
                    .filter(|&b| present.get(b).copied().unwrap_or(false))
                    .map(|b| {
                        let p = self.props[a * n + b];
                        (p.penalty.max(p.tangential_penalty), b as u32)
                    })
                    .fold(
                        (0.0, u32::MAX),
                        |best, x| if x.0 > best.0 { x } else { best },
                    )
            })
            .collect()
    }
}
