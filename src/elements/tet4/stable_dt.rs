//! Critical time step of the central difference method for tet4 elements with lumped mass.
//!
//! For each tet the largest eigenfrequency ω of K_e φ = ω² M_e φ is computed exactly:
//! with M_e = (ρV/4)·I₁₂ and K_e = V·GᵀCG (G the 6×12 strain–displacement matrix, C the
//! 6×6 Voigt elasticity matrix), the nonzero eigenvalues of M_e⁻¹K_e are those of the
//! symmetric 6×6 matrix (4/ρ)·Lᵀ(GGᵀ)L with C = LLᵀ. By the element eigenvalue inequality
//! (Irons & Treharne 1971; Hughes 1987, ch. 9) the global ω_max never exceeds the largest
//! element ω, so dt_crit = min_e 2/ω_e is safe for both body layouts. With viscous damping
//! η the critical step of the damped top mode is dt = (2/ω)(√(1+ξ²) − ξ) (Belytschko et al.
//! 2000, §6.2), ξ its damping ratio from the element's damping matrix.

use crate::material::Material;
use crate::math::{Mat3, Real};
use nalgebra::{SMatrix, SVector};

type M6 = SMatrix<Real, 6, 6>;
type M6x12 = SMatrix<Real, 6, 12>;

/// Strain–displacement matrix (Voigt: xx, yy, zz, yz, zx, xy with engineering shear).
fn strain_displacement(dm_inv: &Mat3) -> M6x12 {
    let mut grads = [nalgebra::Vector3::zeros(); 4];
    for (a, g) in grads.iter_mut().enumerate().skip(1) {
        *g = dm_inv.row(a - 1).transpose();
    }
    grads[0] = -(grads[1] + grads[2] + grads[3]);
    let mut g = M6x12::zeros();
    for (a, d) in grads.iter().enumerate() {
        let c = 3 * a;
        g[(0, c)] = d.x;
        g[(1, c + 1)] = d.y;
        g[(2, c + 2)] = d.z;
        g[(3, c + 1)] = d.z;
        g[(3, c + 2)] = d.y;
        g[(4, c)] = d.z;
        g[(4, c + 2)] = d.x;
        g[(5, c)] = d.y;
        g[(5, c + 1)] = d.x;
    }
    g
}

fn voigt_elasticity(m: &Material) -> M6 {
    let (l, mu) = (m.lambda, m.mu);
    let mut c = M6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            c[(i, j)] = l;
        }
        c[(i, i)] = l + 2.0 * mu;
        c[(i + 3, i + 3)] = mu;
    }
    c
}

/// (ω_max, ξ) of one tetrahedron with reference inverse edge matrix `dm_inv`.
pub fn tet_max_frequency(dm_inv: &Mat3, m: &Material) -> (Real, Real) {
    let g = strain_displacement(dm_inv);
    let c = voigt_elasticity(m);
    let l = c
        .cholesky()
        .expect("elasticity matrix is positive definite for -1 < ν < 0.5")
        .l();
    let a = l.transpose() * (g * g.transpose()) * l;
    let eig = a.symmetric_eigen();
    let (imax, lmax) =
        eig.eigenvalues.iter().enumerate().fold(
            (0, 0.0),
            |acc, (i, &v)| if v > acc.1 { (i, v) } else { acc },
        );
    let omega = (4.0 * lmax / m.density).sqrt();
    let mut xi = 0.0;
    if m.viscosity > 0.0 {
        let psi: SVector<Real, 6> = eig.eigenvectors.column(imax).into_owned();
        let eps = l.transpose().try_inverse().unwrap() * psi;
        let phi = g.transpose() * (c * eps);
        let gphi = g * phi;
        let eta = SVector::<Real, 6>::from([1.0, 1.0, 1.0, 0.5, 0.5, 0.5]) * m.viscosity;
        let damping: Real = (0..6).map(|i| gphi[i] * eta[i] * gphi[i]).sum();
        xi = 4.0 * damping / (2.0 * omega * m.density * phi.norm_squared());
    }
    (omega, xi)
}

/// Critical time step of one tetrahedron [s].
pub fn tet_critical_dt(dm_inv: &Mat3, m: &Material) -> Real {
    let (omega, xi) = tet_max_frequency(dm_inv, m);
    2.0 / omega * ((1.0 + xi * xi).sqrt() - xi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Formulation;
    use crate::math::Vec3;

    /// The bound must agree with a brute-force 12×12 eigen solve of M⁻¹K for one tet.
    #[test]
    fn matches_full_eigenproblem() {
        let m = Material::new(Formulation::SmallStrain, 2000.0, 1e9, 0.3, 0.0).unwrap();
        let p = [
            Vec3::zeros(),
            Vec3::new(1.0, 0.1, 0.0),
            Vec3::new(0.2, 0.9, 0.1),
            Vec3::new(0.1, 0.3, 1.2),
        ];
        let dm = Mat3::from_columns(&[p[1] - p[0], p[2] - p[0], p[3] - p[0]]);
        let dm_inv = dm.try_inverse().unwrap();
        let vol = dm.determinant() / 6.0;
        let g = strain_displacement(&dm_inv);
        let k = g.transpose() * voigt_elasticity(&m) * g * vol;
        let mk = k * (4.0 / (m.density * vol));
        let sym = (mk + mk.transpose()) * 0.5; // M ∝ I, so M⁻¹K is symmetric
        let lmax = sym.symmetric_eigen().eigenvalues.max();
        let (omega, _) = tet_max_frequency(&dm_inv, &m);
        assert!((omega * omega - lmax).abs() < 1e-9 * lmax);
    }
}
