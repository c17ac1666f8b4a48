//! Scalar and small-matrix aliases used everywhere (SI units throughout: m, kg, s, N, Pa).

pub mod exact_sum;
mod lists;

pub use exact_sum::{exact_total, ExactSum, Partial};
pub use lists::Lists;

pub type Real = f64;
pub type Vec3 = nalgebra::Vector3<Real>;
pub type Mat3 = nalgebra::Matrix3<Real>;

/// Edge matrix `[p1−p0, p2−p0, p3−p0]` (columns) of a tetrahedron.
#[inline(always)]
pub fn edge_matrix(p0: &Vec3, p1: &Vec3, p2: &Vec3, p3: &Vec3) -> Mat3 {
    Mat3::from_columns(&[p1 - p0, p2 - p0, p3 - p0])
}

/// Signed volume of a tetrahedron: det(edge matrix)/6, positive when (p1−p0, p2−p0, p3−p0)
/// is right-handed.
#[inline(always)]
pub fn tet_volume(p0: &Vec3, p1: &Vec3, p2: &Vec3, p3: &Vec3) -> Real {
    (p1 - p0).cross(&(p2 - p0)).dot(&(p3 - p0)) / 6.0
}

/// Von Mises equivalent stress of a (symmetric) stress tensor [Pa].
pub fn von_mises(s: &Mat3) -> Real {
    let (sxx, syy, szz) = (s[(0, 0)], s[(1, 1)], s[(2, 2)]);
    let (sxy, syz, szx) = (s[(0, 1)], s[(1, 2)], s[(2, 0)]);
    (0.5 * ((sxx - syy).powi(2) + (syy - szz).powi(2) + (szz - sxx).powi(2))
        + 3.0 * (sxy * sxy + syz * syz + szx * szx))
        .sqrt()
}

/// A place for messages, `(x, y, z)` [m]: each coordinate with 4 decimals, or with 4
/// significant digits in scientific notation below 0.01 m in magnitude (so the places of a
/// micro-scale model, a red blood cell of 8 µm, do not all print as `0.0000`); zero, and a
/// coordinate 1e-12 or less of the largest one (roundoff: −1.4e-17 beside 0.1), as `0`.
pub fn fmt_place(p: &Vec3) -> String {
    let largest = p
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0, |m: Real, v| m.max(v.abs()));
    let c = |v: Real| {
        if v.abs() <= 1e-12 * largest {
            "0".to_string()
        } else if v.abs() < 0.01 {
            format!("{v:.3e}")
        } else {
            format!("{v:.4}")
        }
    };
    format!("({}, {}, {})", c(p.x), c(p.y), c(p.z))
}

/// Rotation matrix about a unit `axis` by `angle` radians (Rodrigues).
pub fn rotation_matrix(axis: &Vec3, angle: Real) -> Mat3 {
    let a = axis.normalize();
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(a), angle).into_inner()
}

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, well-mixed, reproducible generator, the
/// one stream behind every seeded draw (random packings, fuzz and property inputs).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> Real {
        (self.next_u64() >> 11) as Real * (1.0 / (1u64 << 53) as Real)
    }
}

/// A raw pointer into an array that parallel workers write at disjoint entries (stage 1's
/// body runs, stage 2's colour blocks). Each use states why its writes never alias.
pub(crate) struct SyncPtr<T>(pub(crate) *mut T);
impl<T> Clone for SyncPtr<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for SyncPtr<T> {}
// SAFETY: only the pointer is shared; every dereference is justified at its use.
unsafe impl<T> Send for SyncPtr<T> {}
unsafe impl<T> Sync for SyncPtr<T> {}
impl<T> SyncPtr<T> {
    #[inline(always)]
    pub(crate) fn get(self) -> *mut T {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Places in messages: 4 decimals from 0.01 m up, 4 significant digits in scientific
    /// notation below (a micro-scale model's places are not 0.0000), zero as 0.
    #[test]
    fn places_read_at_every_scale() {
        assert_eq!(
            fmt_place(&Vec3::new(0.5125, 0.0125, 1.155)),
            "(0.5125, 0.0125, 1.1550)"
        );
        assert_eq!(
            fmt_place(&Vec3::new(3.91e-6, -1.2344e-7, 0.0)),
            "(3.910e-6, -1.234e-7, 0)"
        );
        assert_eq!(
            fmt_place(&Vec3::new(0.00625, 0.01, -12.0)),
            "(6.250e-3, 0.0100, -12.0000)"
        );
        assert_eq!(
            fmt_place(&Vec3::new(Real::NAN, 1e5, 0.0)),
            "(NaN, 100000.0000, 0)"
        );
        // Roundoff beside the other coordinates is 0; a small coordinate of a small place is not.
        assert_eq!(
            fmt_place(&Vec3::new(0.1, 0.05, -1.4e-17)),
            "(0.1000, 0.0500, 0)"
        );
        assert_eq!(
            fmt_place(&Vec3::new(2e-6, 1e-19, 1e-9)),
            "(2.000e-6, 0, 1.000e-9)"
        );
    }
}
