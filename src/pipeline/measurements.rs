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

/// Volume of the part of tetrahedron `p` inside the axis-aligned box [lo, hi] [m³], exact
/// (to rounding). By the divergence theorem with the field (x − lo_x, 0, 0), whose divergence
/// is 1, the volume of the clipped solid is the sum over its boundary of ∫ (x − lo_x) n_x dA.
/// That boundary is the tet's faces clipped to the box (Sutherland–Hodgman against the six
/// planes), plus pieces of the box's faces inside the tet; of those only the face x = hi_x
/// contributes (n_x = 0 on the y and z faces, x − lo_x = 0 on x = lo_x), with
/// (hi_x − lo_x) × the area of the tet's section at x = hi_x clipped to the box's y–z rectangle.
pub fn tet_volume_in_box(p: &[Vec3; 4], lo: &Vec3, hi: &Vec3) -> Real {
    let (mut plo, mut phi) = (p[0], p[0]);
    for q in &p[1..] {
        plo = plo.inf(q);
        phi = phi.sup(q);
    }
    let volume = ((p[1] - p[0]).cross(&(p[2] - p[0])))
        .dot(&(p[3] - p[0]))
        .abs()
        / 6.0;
    if (0..3).all(|k| plo[k] >= lo[k] && phi[k] <= hi[k]) {
        return volume;
    }
    if (0..3).any(|k| phi[k] <= lo[k] || plo[k] >= hi[k]) {
        return 0.0;
    }
    // Clip a polygon to the half-space s·x[k] ≤ s·c (s = ±1).
    fn clip(poly: &[Vec3], k: usize, c: Real, upper: bool) -> Vec<Vec3> {
        let inside = |q: &Vec3| if upper { q[k] <= c } else { q[k] >= c };
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (ia, ib) = (inside(&a), inside(&b));
            if ia {
                out.push(a);
            }
            if ia != ib {
                let t = (c - a[k]) / (b[k] - a[k]);
                let mut q = a + (b - a) * t;
                q[k] = c;
                out.push(q);
            }
        }
        out
    }
    let clip_box = |mut poly: Vec<Vec3>, axes: &[usize]| -> Vec<Vec3> {
        for &k in axes {
            for (c, upper) in [(lo[k], false), (hi[k], true)] {
                if poly.len() < 3 {
                    return Vec::new();
                }
                poly = clip(&poly, k, c, upper);
            }
        }
        poly
    };
    let centroid = (p[0] + p[1] + p[2] + p[3]) / 4.0;
    let mut total = 0.0;
    for f in [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]] {
        let mut tri = vec![p[f[0]], p[f[1]], p[f[2]]];
        // Outward: away from the opposite vertex (any input orientation).
        let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
        if n.dot(&(tri[0] - centroid)) < 0.0 {
            tri.swap(1, 2);
        }
        let poly = clip_box(tri, &[0, 1, 2]);
        for i in 1..poly.len().saturating_sub(1) {
            let (a, b, c) = (poly[0], poly[i], poly[i + 1]);
            let area_x = 0.5 * (b - a).cross(&(c - a)).x;
            total += area_x * ((a.x + b.x + c.x) / 3.0 - lo.x);
        }
    }
    // The section at x = hi_x: where the edges cross it, ordered around their mean.
    let c = hi.x;
    let mut section: Vec<Vec3> = Vec::with_capacity(4);
    for (i, j) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
        let (a, b) = (p[i], p[j]);
        if (a.x < c) != (b.x < c) {
            let t = (c - a.x) / (b.x - a.x);
            let mut q = a + (b - a) * t;
            q.x = c;
            section.push(q);
        }
    }
    if section.len() >= 3 {
        let m = section.iter().sum::<Vec3>() / section.len() as Real;
        section.sort_by(|a, b| {
            let ta = (a.z - m.z).atan2(a.y - m.y);
            let tb = (b.z - m.z).atan2(b.y - m.y);
            ta.total_cmp(&tb)
        });
        let poly = clip_box(section, &[1, 2]);
        let mut area = 0.0;
        for i in 1..poly.len().saturating_sub(1) {
            let (a, b, q) = (poly[0], poly[i], poly[i + 1]);
            area += 0.5 * ((b.y - a.y) * (q.z - a.z) - (b.z - a.z) * (q.y - a.y));
        }
        total += (hi.x - lo.x) * area.abs();
    }
    total.clamp(0.0, volume)
}

impl Simulation {
    /// Volume of `bodies` inside the box [lo, hi] in configuration `at` [m³]: the exact
    /// clipped volume of each of their tets ([`tet_volume_in_box`]), summed. Overlaps between
    /// bodies (contact penetration) are counted twice.
    pub fn volume_in_box(&self, bodies: &[usize], lo: &Vec3, hi: &Vec3, at: Configuration) -> Real {
        let x = self.positions(at);
        bodies
            .iter()
            .flat_map(|&b| self.bodies[b].tets.clone())
            .map(|e| {
                let n = self.tets.nodes[e];
                let p = n.map(|i| x[i as usize]);
                tet_volume_in_box(&p, lo, hi)
            })
            .sum()
    }
}

#[cfg(test)]
mod volume_in_box_tests {
    use super::*;

    /// Additivity, the one property an exact clipper must have and a wrong one hardly ever
    /// has by chance: a box cut in two along each axis at a random place gives two volumes
    /// that sum to the whole (1e-12 relative), and a box holding the tet gives its volume.
    #[test]
    fn clipped_volumes_add_up() {
        let mut s = crate::math::SplitMix64(5);
        for _ in 0..2000 {
            let p = [0; 4].map(|_| Vec3::new(s.uniform(), s.uniform(), s.uniform()));
            let v = ((p[1] - p[0]).cross(&(p[2] - p[0])))
                .dot(&(p[3] - p[0]))
                .abs()
                / 6.0;
            let lo = Vec3::new(s.uniform(), s.uniform(), s.uniform()) * 0.6 - Vec3::repeat(0.1);
            let hi = lo + Vec3::new(s.uniform(), s.uniform(), s.uniform()) * 0.8;
            let whole = tet_volume_in_box(&p, &lo, &hi);
            for k in 0..3 {
                let cut = lo[k] + (hi[k] - lo[k]) * s.uniform();
                let (mut hi1, mut lo2) = (hi, lo);
                hi1[k] = cut;
                lo2[k] = cut;
                let sum = tet_volume_in_box(&p, &lo, &hi1) + tet_volume_in_box(&p, &lo2, &hi);
                assert!(
                    (sum - whole).abs() <= 1e-12 * v.max(1e-300),
                    "{sum} {whole}"
                );
            }
            let all = tet_volume_in_box(&p, &Vec3::repeat(-1.0), &Vec3::repeat(2.0));
            assert!((all - v).abs() <= 1e-14 * v);
        }
    }

    /// The unit corner tet (volume 1/6) cut by x ≤ a keeps 1/6 − (1 − a)³/6 (what lies beyond
    /// is a similar tet of scale 1 − a).
    #[test]
    fn corner_tet_against_the_closed_form() {
        let p = [Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()];
        for a in [0.1, 0.25, 0.5, 0.9] {
            let got = tet_volume_in_box(&p, &Vec3::repeat(-1.0), &Vec3::new(a, 2.0, 2.0));
            let want = (1.0 - (1.0 - a).powi(3)) / 6.0;
            assert!((got - want).abs() < 1e-15, "{a}: {got} {want}");
            let got = tet_volume_in_box(&p, &Vec3::new(-1.0, a, -1.0), &Vec3::repeat(2.0));
            assert!((got - (1.0 - a).powi(3) / 6.0).abs() < 1e-15, "{a}: {got}");
        }
    }
}
