//! The tet4 element family (4-node constant-strain tetrahedron): everything fdem needs of
//! it in one place — reference data, the stage 1 force kernel, the lumped mass and the
//! critical time step ([`stable_dt`]). Its face numbering is [`FACES`] (the mesh layer's
//! [`crate::mesh::TET_FACES`]: meshes, generators and Gmsh import are tet4 meshes).
//!
//! Kernel (Munjiza 2004, §4.7):
//!
//! ```text
//! F   = [x1−x0, x2−x0, x3−x0] · [X1−X0, X2−X0, X3−X0]⁻¹      (uniform in the tet)
//! Ḟ   = [v1−v0, v2−v0, v3−v0] · [X1−X0, X2−X0, X3−X0]⁻¹
//! P   = P_elastic(F) + P_viscous(F, Ḟ)                     (first Piola–Kirchhoff, Pa)
//! H   = −V₀ · P · D_m⁻ᵀ ;  f_a = H e_a (a = 1..3),  f_0 = −(f_1 + f_2 + f_3)
//! ```
//!
//! Lumped mass: ρV₀/4 at each corner.

pub mod stable_dt;

pub use stable_dt::{tet_critical_dt, tet_max_frequency};

use super::ElementSums;
use crate::material::{munjiza_cauchy, Formulation, Material};
use crate::math::{Mat3, Real, Vec3};
use crate::state::{Nodes, Tets};

/// Nodes of the element.
pub const NODES: usize = 4;

/// Local corner numbers of face k (the face opposite corner k), ordered so that the normal
/// (c1 − c0) × (c2 − c0) points out of a positively oriented tet.
pub const FACES: [[usize; 3]; 4] = crate::mesh::TET_FACES;

/// Reference data of a tet with corners `p`: (D_m⁻¹ [1/m], V₀ [m³]), or None when it is
/// degenerate. D_m = [X1−X0, X2−X0, X3−X0], V₀ = det(D_m)/6 (negative when inverted).
pub fn reference(p: &[Vec3; 4]) -> Option<(Mat3, Real)> {
    let dm = crate::math::edge_matrix(&p[0], &p[1], &p[2], &p[3]);
    Some((dm.try_inverse()?, dm.determinant() / 6.0))
}

/// Nodal forces of one tetrahedron and, optionally, its energy terms.
#[derive(Clone, Copy, Debug, Default)]
pub struct TetResult {
    pub forces: [Vec3; 4],
    /// V₀·ψ(F) [J] (only when energies are requested).
    pub strain_energy: Real,
    /// Viscous power V₀·P_v:Ḟ [W] (≥ 0; always computed when the material is viscous).
    pub viscous_power: Real,
    /// det F ≤ 0 (or NaN): the element is inverted. Checked on every step (one 3×3
    /// determinant beside the stress), so a run stops in the step after the one that inverted
    /// an element, before a frame or a callback sees it.
    pub inverted: bool,
}

/// The tet4 force kernel: F, P, and f = −V₀·P·D_m⁻ᵀ.
#[inline(always)]
pub fn internal_force_tet4(
    xs: &[Vec3; 4],
    vs: &[Vec3; 4],
    dm_inv: &Mat3,
    vol0: Real,
    mat: &Material,
    want_energy: bool,
) -> TetResult {
    let ds = Mat3::from_columns(&[xs[1] - xs[0], xs[2] - xs[0], xs[3] - xs[0]]);
    let f = ds * dm_inv;
    let j = f.determinant();
    let mut viscous_power = 0.0;
    let mut h = if mat.formulation == Formulation::Munjiza {
        // Cauchy-stress law: V₀·P·D_m⁻ᵀ = V₀·J·σ·D_s⁻ᵀ = σ·cof(D_s)/6, since
        // cof(D_s) = det(D_s)·D_s⁻ᵀ and det(D_s) = 6·V₀·J. No inverse, no division.
        let sigma = munjiza_cauchy(&f, j, mat.mu, mat.bulk());
        -(sigma * cofactor(&ds)) / 6.0
    } else {
        -vol0 * mat.pk1(&f) * dm_inv.transpose()
    };
    if mat.viscosity > 0.0 {
        let dv = Mat3::from_columns(&[vs[1] - vs[0], vs[2] - vs[0], vs[3] - vs[0]]);
        let f_dot = dv * dm_inv;
        let pv = mat.pk1_viscous(&f, &f_dot);
        viscous_power = vol0 * pv.dot(&f_dot);
        h -= vol0 * pv * dm_inv.transpose();
    }
    let f1 = h.column(0).into_owned();
    let f2 = h.column(1).into_owned();
    let f3 = h.column(2).into_owned();
    let mut r = TetResult {
        forces: [-(f1 + f2 + f3), f1, f2, f3],
        viscous_power,
        strain_energy: 0.0,
        // NaN counts as inverted.
        inverted: j.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater),
    };
    if want_energy {
        r.strain_energy = vol0 * mat.energy_density(&f);
    }
    r
}

/// Cofactor matrix cof(A) = det(A)·A⁻ᵀ (defined for singular A too).
#[inline(always)]
pub fn cofactor(a: &Mat3) -> Mat3 {
    let (c0, c1, c2) = (a.column(0), a.column(1), a.column(2));
    Mat3::from_columns(&[c1.cross(&c2), c2.cross(&c0), c0.cross(&c1)])
}

/// Run the kernel on tet `e`, reading its nodes' x and v.
#[inline(always)]
pub fn tet_result(
    tets: &Tets,
    mats: &[Material],
    x: &[Vec3],
    v: &[Vec3],
    e: usize,
    want_energy: bool,
) -> TetResult {
    let n = tets.nodes[e];
    let xs = n.map(|i| x[i as usize]);
    let vs = n.map(|i| v[i as usize]);
    internal_force_tet4(
        &xs,
        &vs,
        &tets.dm_inv[e],
        tets.vol0[e],
        &mats[tets.material[e] as usize],
        want_energy,
    )
}

/// Deformation gradient of tet `e` at the current positions.
pub fn deformation_gradient(tets: &Tets, x: &[Vec3], e: usize) -> Mat3 {
    let n = tets.nodes[e].map(|i| x[i as usize]);
    Mat3::from_columns(&[n[1] - n[0], n[2] - n[0], n[3] - n[0]]) * tets.dm_inv[e]
}

/// Lumped masses: ρV₀/4 of every tet at each of its corners [kg] (`nodes.m` is set, not
/// added to).
pub fn lumped_masses(nodes: &mut Nodes, tets: &Tets, materials: &[Material]) {
    nodes.m.iter_mut().for_each(|m| *m = 0.0);
    for e in 0..tets.len() {
        let mq = materials[tets.material[e] as usize].density * tets.vol0[e] / 4.0;
        for &n in &tets.nodes[e] {
            nodes.m[n as usize] += mq;
        }
    }
}

/// The smallest critical time step over all tets [s] and the tet that sets it (the lowest id
/// among equals, so the answer does not depend on threads). Tets of rigid bodies are left
/// out; with none left, (∞, usize::MAX).
pub fn critical_time_step(tets: &Tets, materials: &[Material]) -> (Real, usize) {
    use rayon::prelude::*;
    (0..tets.len())
        .into_par_iter()
        .filter(|&e| tets.rigid.get(e) != Some(&true))
        .map(|e| {
            (
                tet_critical_dt(&tets.dm_inv[e], &materials[tets.material[e] as usize]),
                e,
            )
        })
        .reduce(
            || (Real::INFINITY, usize::MAX),
            |a, b| {
                if b.0 < a.0 || (b.0 == a.0 && b.1 < a.1) {
                    b
                } else {
                    a
                }
            },
        )
}

/// Sum a tet's result into the stage totals.
#[inline(always)]
pub(super) fn accumulate(s: &mut ElementSums, r: &TetResult) {
    s.strain_energy += r.strain_energy;
    s.viscous_power += r.viscous_power;
    s.inverted += r.inverted as usize;
}
