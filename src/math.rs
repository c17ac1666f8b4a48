//! Scalar and small-matrix aliases used everywhere (SI units throughout: m, kg, s, N, Pa).

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

/// Rotation matrix about a unit `axis` by `angle` radians (Rodrigues).
pub fn rotation_matrix(axis: &Vec3, angle: Real) -> Mat3 {
    let a = axis.normalize();
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(a), angle).into_inner()
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
