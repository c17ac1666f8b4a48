//! Measurements of where bodies are and how they move: bounding boxes (reference or current),
//! linear and angular momentum, mass-weighted means over node sets, and placing one body
//! against another. Read-only except [`Simulation::place_against`], which moves a body before
//! the first step as `translate_body` does.

use super::{SimError, Simulation};
use crate::math::{Real, Vec3};

/// Which configuration a geometric query reads: the reference positions X (as built, before
/// any step) or the current positions x.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Configuration {
    #[default]
    Reference,
    Current,
}

impl Configuration {
    /// "reference" or "current"; anything else is an error naming both.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "reference" => Ok(Configuration::Reference),
            "current" => Ok(Configuration::Current),
            _ => Err(format!("at \"{s}\" is not \"reference\" or \"current\"")),
        }
    }
}

/// An axis-aligned bounding box [m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    /// The box of `points`; None for no points.
    pub fn of<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Option<Bounds> {
        let mut it = points.into_iter();
        let first = *it.next()?;
        let mut b = Bounds {
            min: first,
            max: first,
        };
        for p in it {
            b.min = b.min.inf(p);
            b.max = b.max.sup(p);
        }
        Some(b)
    }
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }
}

/// Axis index of "x", "y", "z".
pub fn axis_index(s: &str) -> Option<usize> {
    match s {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    }
}

impl Simulation {
    /// Positions of `at`.
    pub fn positions(&self, at: Configuration) -> &[Vec3] {
        match at {
            Configuration::Reference => &self.nodes.x0,
            Configuration::Current => &self.nodes.x,
        }
    }

    /// Bounding box of body `body`'s nodes in configuration `at` [m].
    pub fn body_bounds(&self, body: usize, at: Configuration) -> Bounds {
        let x = self.positions(at);
        Bounds::of(&x[self.bodies[body].nodes.clone()]).expect("a body has nodes")
    }

    /// Linear momentum of body `body` [kg·m/s]: M·V (a rigid body's, or Σ m_n v_n of a
    /// deformable one with the lumped masses ρV/4 of its tets), at the last half step.
    pub fn body_momentum(&self, body: usize) -> Vec3 {
        self.body_velocity(body) * self.body_mass(body)
    }

    /// Angular momentum of body `body` about `about` (default: its centre of mass now)
    /// [kg·m²/s]. Rigid: L_c + M (c − p) × V with the exact inertia. Deformable:
    /// Σ m_n (x_n − p) × v_n with the lumped masses ρV/4 of its tets, x at t and v at
    /// t − dt/2: the pairing the central difference conserves exactly when no external
    /// moment acts.
    pub fn body_angular_momentum(&self, body: usize, about: Option<Vec3>) -> Vec3 {
        let p = about.unwrap_or_else(|| self.center_of_mass(body));
        if let Some(rb) = self.rigid.of_body(body) {
            return rb.angular_momentum + (rb.center - p).cross(&rb.velocity) * rb.mass;
        }
        let density = self.materials[self.bodies[body].material as usize].density;
        let mut l = Vec3::zeros();
        for e in self.bodies[body].tets.clone() {
            let m = density * self.tets.vol0[e] / 4.0;
            for &n in &self.tets.nodes[e] {
                let n = n as usize;
                l += (self.nodes.x[n] - p).cross(&self.nodes.v[n]) * m;
            }
        }
        l
    }

    /// Σ m_n f_n / Σ m_n over `nodes` with the lumped nodal masses (valid after `prepare`);
    /// None for an empty set or zero mass.
    fn mass_mean_of(&self, nodes: &[u32], field: &[Vec3]) -> Option<Vec3> {
        let (mut m, mut s) = (0.0, Vec3::zeros());
        for &n in nodes {
            let n = n as usize;
            m += self.nodes.m[n];
            s += field[n] * self.nodes.m[n];
        }
        (m > 0.0).then(|| s / m)
    }

    /// Mass-weighted mean current position of `nodes` (their centre of mass) [m].
    pub fn mass_mean_position(&self, nodes: &[u32]) -> Option<Vec3> {
        self.mass_mean_of(nodes, &self.nodes.x)
    }

    /// Mass-weighted mean velocity of `nodes` at the last half step (their momentum over
    /// their mass) [m/s].
    pub fn mass_mean_velocity(&self, nodes: &[u32]) -> Option<Vec3> {
        self.mass_mean_of(nodes, &self.nodes.v)
    }

    /// Move body `body` along `axis` (0, 1, 2) so that its bounding box faces the box of
    /// body `other` across a gap `gap` [m] (0: touching): on the side of `other` where
    /// `body`'s centre lies (`side` None), or on its + (`Some(true)`) or − side. The body
    /// moves only along `axis`. Returns the translation [m]. Before the first step only.
    pub fn place_against(
        &mut self,
        body: usize,
        other: usize,
        axis: usize,
        gap: Real,
        side: Option<bool>,
    ) -> Result<Vec3, SimError> {
        if body == other {
            return Err(SimError::Invalid(format!(
                "body '{}' cannot be placed against itself",
                self.bodies[body].name
            )));
        }
        let a = self.body_bounds(body, Configuration::Reference);
        let b = self.body_bounds(other, Configuration::Reference);
        let plus = side.unwrap_or(a.center()[axis] >= b.center()[axis]);
        let shift = if plus {
            b.max[axis] + gap - a.min[axis]
        } else {
            b.min[axis] - gap - a.max[axis]
        };
        let mut d = Vec3::zeros();
        d[axis] = shift;
        self.translate_body(body, d)?;
        Ok(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_of_points() {
        let p = [Vec3::new(1.0, -2.0, 0.5), Vec3::new(-1.0, 3.0, 0.0)];
        let b = Bounds::of(&p).unwrap();
        assert_eq!(b.min, Vec3::new(-1.0, -2.0, 0.0));
        assert_eq!(b.max, Vec3::new(1.0, 3.0, 0.5));
        assert_eq!(b.center(), Vec3::new(0.0, 0.5, 0.25));
        assert!(Bounds::of(&[]).is_none());
        assert!(Configuration::parse("deformed")
            .unwrap_err()
            .contains("\"reference\" or \"current\""));
    }
}
