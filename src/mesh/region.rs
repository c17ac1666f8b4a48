//! Regions for node and element selections: box, sphere, cylinder, half-space.

use crate::math::{Real, Vec3};

/// A closed region of space. Containment is tested with a tolerance so that nodes lying
/// exactly on a region's surface (a clamped end at x = 0) are selected.
#[derive(Clone, Debug, PartialEq)]
pub enum Region {
    Box {
        min: Vec3,
        max: Vec3,
    },
    Sphere {
        center: Vec3,
        radius: Real,
    },
    /// Finite cylinder: axis from `base` along unit `axis` for `length`, radius `radius`.
    Cylinder {
        base: Vec3,
        axis: Vec3,
        radius: Real,
        length: Real,
    },
    /// Points on the side of the plane that `normal` points to: (x − point)·n ≥ 0.
    HalfSpace {
        point: Vec3,
        normal: Vec3,
    },
}

impl Region {
    /// Whether `p` lies in the region, with absolute tolerance `tol` [m].
    pub fn contains(&self, p: &Vec3, tol: Real) -> bool {
        match self {
            Region::Box { min, max } => {
                (0..3).all(|i| p[i] >= min[i] - tol && p[i] <= max[i] + tol)
            }
            Region::Sphere { center, radius } => (p - center).norm() <= radius + tol,
            Region::Cylinder {
                base,
                axis,
                radius,
                length,
            } => {
                let d = p - base;
                let s = d.dot(axis);
                s >= -tol && s <= length + tol && (d - axis * s).norm() <= radius + tol
            }
            Region::HalfSpace { point, normal } => (p - point).dot(normal) >= -tol,
        }
    }

    pub fn kind(&self) -> &'static str {
        match self {
            Region::Box { .. } => "box",
            Region::Sphere { .. } => "sphere",
            Region::Cylinder { .. } => "cylinder",
            Region::HalfSpace { .. } => "half_space",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containment() {
        let b = Region::Box {
            min: Vec3::zeros(),
            max: Vec3::new(1.0, 1.0, 1.0),
        };
        assert!(b.contains(&Vec3::new(0.0, 0.5, 1.0), 1e-12));
        assert!(!b.contains(&Vec3::new(-1e-6, 0.5, 0.5), 1e-12));
        let s = Region::Sphere {
            center: Vec3::zeros(),
            radius: 2.0,
        };
        assert!(s.contains(&Vec3::new(2.0, 0.0, 0.0), 1e-12));
        assert!(!s.contains(&Vec3::new(1.5, 1.5, 0.0), 1e-12));
        let c = Region::Cylinder {
            base: Vec3::zeros(),
            axis: Vec3::z(),
            radius: 1.0,
            length: 2.0,
        };
        assert!(c.contains(&Vec3::new(0.7, 0.7, 2.0), 1e-12));
        assert!(!c.contains(&Vec3::new(0.0, 0.0, 2.1), 1e-12));
        assert!(!c.contains(&Vec3::new(0.8, 0.8, 1.0), 1e-12));
        let h = Region::HalfSpace {
            point: Vec3::new(0.0, 0.0, 1.0),
            normal: Vec3::z(),
        };
        assert!(h.contains(&Vec3::new(5.0, 5.0, 1.0), 1e-12));
        assert!(!h.contains(&Vec3::new(0.0, 0.0, 0.99), 1e-12));
    }
}
