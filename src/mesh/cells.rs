//! Solids of revolution symmetric about their mid-plane — lenses, oblate discs and the
//! biconcave red blood cell — meshed into positively oriented tetrahedra.
//!
//! A body of radius R whose faces are z = ±t(r) (t > 0 on [0, R), t(R) = 0) is the image of
//! the unit ball under the map
//!
//! (x, y, z) ↦ (R x, R y, z · t(Rρ) / √(1 − ρ²)),   ρ² = x² + y².
//!
//! The ball's surface z = ±√(1 − ρ²) lands exactly on z = ±t(r), so every surface node of the
//! ball mesh ([`super::solids::sphere`]) lies exactly on the body's surface and the volume error
//! is that of the inscribed polyhedron, O(h²). The map's Jacobian is lower triangular with
//! diagonal (R, R, t/√(1 − ρ²)) > 0, so it keeps orientation; for a mesh fine enough to follow
//! the map, every tet stays positive (checked by [`Mesh::check`] before returning). The ball
//! grid has as many layers through the thickness as cells across the diameter, so where the
//! body is thin its tets are flat: a red blood cell's centre (0.81 µm thick, 7.82 µm across)
//! gives tets about ten times wider than high, and the stable time step follows their height.
//!
//! **Evans–Fung shape** (Evans & Fung 1972, *Microvascular Research* 4:335–347): the thickness
//! of a human red blood cell at r = ρR₀ is
//!
//! D(r) = √(1 − ρ²) (C₀ + C₁ρ² + C₂ρ⁴),   t = D/2,
//!
//! with R₀ = 3.91 µm, C₀ = 0.81 µm, C₁ = 7.83 µm, C₂ = −4.39 µm. Its volume, integrated in
//! closed form (u = ρ², ∫₀¹ uⁿ√(1 − u) du = 2/3, 4/15, 16/105 for n = 0, 1, 2), is
//!
//! V = π R₀² (2C₀/3 + 4C₁/15 + 16C₂/105) = 94.1 µm³.

use super::solids::{need_positive, sphere};
use super::structured::{add_all_elements, add_face_set};
use super::Mesh;
use crate::math::Real;
use std::f64::consts::PI;

/// The Evans–Fung biconcave disc: radius R₀ and the thickness coefficients C₀, C₁, C₂ [m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvansFung {
    pub radius: Real,
    pub c0: Real,
    pub c1: Real,
    pub c2: Real,
}

impl EvansFung {
    /// The human red blood cell of Evans & Fung (1972), in metres.
    pub const HUMAN: EvansFung = EvansFung {
        radius: 3.91e-6,
        c0: 0.81e-6,
        c1: 7.83e-6,
        c2: -4.39e-6,
    };

    /// Half the thickness at radius r [m] (zero at and beyond R₀).
    pub fn half_thickness(&self, r: Real) -> Real {
        let u = (r / self.radius).powi(2);
        if u >= 1.0 {
            return 0.0;
        }
        0.5 * (1.0 - u).sqrt() * (self.c0 + self.c1 * u + self.c2 * u * u)
    }

    /// The closed-form volume π R₀² (2C₀/3 + 4C₁/15 + 16C₂/105) [m³].
    pub fn volume(&self) -> Real {
        PI * self.radius
            * self.radius
            * (2.0 * self.c0 / 3.0 + 4.0 * self.c1 / 15.0 + 16.0 * self.c2 / 105.0)
    }

    /// Error unless the shape is a solid: R₀ > 0 and a positive thickness on [0, R₀), i.e.
    /// C₀ + C₁u + C₂u² > 0 for u ∈ [0, 1] (a quadratic: check both ends and its vertex).
    pub fn validate(&self) -> Result<(), String> {
        need_positive("radius", self.radius)?;
        for (k, v) in [("c0", self.c0), ("c1", self.c1), ("c2", self.c2)] {
            if !v.is_finite() {
                return Err(format!("'{k}' must be finite, got {v}"));
            }
        }
        let g = |u: Real| self.c0 + self.c1 * u + self.c2 * u * u;
        let mut worst = g(0.0).min(g(1.0));
        if self.c2 != 0.0 {
            let u = -self.c1 / (2.0 * self.c2);
            if (0.0..=1.0).contains(&u) {
                worst = worst.min(g(u));
            }
        }
        if worst <= 0.0 {
            return Err(format!(
                "the thickness C0 + C1·ρ² + C2·ρ⁴ must be > 0 for 0 ≤ ρ ≤ 1 (its smallest value \
                 is {worst:e} m): the faces would cross"
            ));
        }
        Ok(())
    }
}

/// A solid of revolution about z, symmetric about z = 0, of `radius` R and half-thickness
/// `half_thickness(r)` (> 0 on [0, R), → 0 at R), meshed at target edge length `h` across the
/// diameter. Sets: `surface` (faces + nodes), `top` and `bottom` (the faces with z > 0 and
/// z < 0); element set `all`.
pub fn solid_of_revolution(
    radius: Real,
    half_thickness: &dyn Fn(Real) -> Real,
    h: Real,
) -> Result<Mesh, String> {
    need_positive("radius", radius)?;
    need_positive("size", h)?;
    let mut mesh = sphere(1.0, h / radius)?;
    for p in &mut mesh.nodes {
        let rho2 = (p.x * p.x + p.y * p.y).min(1.0);
        let r = radius * rho2.sqrt();
        let cap = (1.0 - rho2).sqrt();
        let t = half_thickness(r);
        if !(t.is_finite() && (t > 0.0 || cap == 0.0)) {
            return Err(format!(
                "the half-thickness at r = {r:e} m is {t:e}: it must be > 0 inside the radius"
            ));
        }
        let z = if cap > 0.0 { p.z * t / cap } else { 0.0 };
        *p = crate::math::Vec3::new(radius * p.x, radius * p.y, z);
    }
    if let Some(bad) = mesh.check().first() {
        return Err(format!(
            "tet {} at ({:.3e}, {:.3e}, {:.3e}) came out {:?} (volume {:e}): the profile \
             changes too fast for size {h:e}; use a smaller 'size'",
            bad.tet, bad.centroid.x, bad.centroid.y, bad.centroid.z, bad.kind, bad.volume
        ));
    }
    // Surface sets: rebuild from the boundary (the ball's "surface" set is still valid as
    // faces, since the map moves nodes only; split it by the sign of z at the face centre).
    mesh.sets.faces.remove("surface");
    mesh.sets.nodes.remove("surface");
    add_face_set(&mut mesh, "surface", |_| true);
    add_face_set(&mut mesh, "top", |p| p.z >= 0.0);
    add_face_set(&mut mesh, "bottom", |p| p.z <= 0.0);
    mesh.sets.elements.clear();
    add_all_elements(&mut mesh);
    Ok(mesh)
}

/// The Evans–Fung biconcave cell, mid-plane z = 0, axis z, centred at the origin.
pub fn biconcave_cell(shape: &EvansFung, h: Real) -> Result<Mesh, String> {
    shape.validate()?;
    solid_of_revolution(shape.radius, &|r| shape.half_thickness(r), h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mesh's volume converges to the closed form at second order (the inscribed
    /// polyhedron of a smooth surface): the error must fall ≥ 3× when h halves.
    #[test]
    fn cell_volume_converges_to_the_closed_form() {
        let s = EvansFung::HUMAN;
        let exact = s.volume();
        assert!((exact - 94.1e-18).abs() < 0.1e-18, "{exact}");
        let err = |h: Real| {
            let m = biconcave_cell(&s, h).unwrap();
            assert!(m.check().is_empty());
            (m.volume() - exact).abs() / exact
        };
        let (e1, e2) = (err(1.0e-6), err(0.5e-6));
        assert!(e2 < 0.05 && e1 / e2 > 3.0, "{e1} {e2}");
    }

    /// Every boundary node lies on z = ±t(r) to 1e-7 R₀ (rounding: near the rim t(r) has an
    /// infinite slope, so a few-ulp rounding of ρ² moves t by ~3e-8 of its scale), every
    /// interior node strictly inside, and the cell is as wide and
    /// as thick as the Evans–Fung formula says.
    #[test]
    fn surface_nodes_lie_on_the_profile() {
        let s = EvansFung::HUMAN;
        let m = biconcave_cell(&s, 0.8e-6).unwrap();
        let nodes = &m.sets.nodes["surface"];
        assert!(!nodes.is_empty());
        for &n in nodes {
            let p = m.nodes[n as usize];
            let r = (p.x * p.x + p.y * p.y).sqrt();
            assert!(
                (p.z.abs() - s.half_thickness(r)).abs() < 1e-7 * s.radius,
                "{p:?}"
            );
        }
        for (n, p) in m.nodes.iter().enumerate() {
            if nodes.binary_search(&(n as u32)).is_err() {
                let r = (p.x * p.x + p.y * p.y).sqrt();
                assert!(p.z.abs() < s.half_thickness(r), "{p:?}");
            }
        }
        let (lo, hi) = m.bounds();
        assert!((hi.x - lo.x - 2.0 * s.radius).abs() < 1e-15);
        // Top and bottom split the surface at the equator (rim nodes in both).
        assert!(!m.sets.faces["top"].is_empty() && !m.sets.faces["bottom"].is_empty());
    }

    #[test]
    fn crossing_faces_are_refused() {
        let s = EvansFung {
            c0: -0.1e-6,
            ..EvansFung::HUMAN
        };
        assert!(biconcave_cell(&s, 1e-6).unwrap_err().contains("C0 + C1"));
        // A quadratic negative only between its ends.
        let s = EvansFung {
            radius: 1.0,
            c0: 1.0,
            c1: -4.0,
            c2: 4.0,
        };
        assert!(s.validate().is_err());
    }

    /// A sphere is the solid of revolution with t = √(R² − r²).
    #[test]
    fn sphere_profile_gives_the_ball() {
        let m = solid_of_revolution(1.0, &|r| (1.0 - r * r).max(0.0).sqrt(), 0.25).unwrap();
        let b = sphere(1.0, 0.25).unwrap();
        assert!((m.volume() - b.volume()).abs() < 1e-12);
    }
}
