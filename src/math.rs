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
