//! Stage 1 physics: patch test, rigid rotation, and force = −∂U/∂x.

mod common;

use common::*;
use fdem::elements::{add_internal_forces, internal_force_tet4, ElementsWorkspace};
use fdem::material::{Formulation, Material, StressMeasure};
use fdem::math::{rotation_matrix, Mat3, Real, Vec3};
use fdem::mesh::Region;
use fdem::{Layout, Simulation};
use proptest::prelude::*;

/// Perturb interior nodes of a box mesh so the patch is irregular (a patch test on a
/// perfectly regular mesh can pass by symmetry).
fn irregular_patch(f: Formulation) -> (Simulation, Vec<bool>) {
    let mut sim = box_sim(
        Vec3::zeros(),
        Vec3::new(1.0, 1.0, 1.0),
        [3, 3, 3],
        material(f, 2000.0, 1e9, 0.3),
        Layout::Continuous,
    );
    let tol = 1e-12;
    let mut interior = vec![false; sim.nodes.len()];
    for (i, p) in sim.nodes.x0.clone().iter().enumerate() {
        let on_boundary = (0..3).any(|k| p[k].abs() < tol || (p[k] - 1.0).abs() < tol);
        if !on_boundary {
            interior[i] = true;
            let d = Vec3::new((7.0 * p.y).sin(), (5.0 * p.z).cos(), (3.0 * p.x).sin()) * 0.08;
            sim.nodes.x0[i] += d;
        }
    }
    // Rebuild reference data from the perturbed coordinates.
    let mesh = fdem::mesh::Mesh::new(sim.nodes.x0.clone(), sim.tets.nodes.clone());
    let mut s2 = Simulation::new();
    let m = s2.add_material(sim.materials[0].clone());
    s2.add_body("patch", &mesh, m, Layout::Continuous).unwrap();
    (s2, interior)
}

/// Patch test (Irons): with every node on the affine field x = F·X, the element stress is the
/// stress of F everywhere and the internal forces at interior nodes vanish. Exact in exact
/// arithmetic for any consistent element; 1e-10 relative allows for rounding only.
#[test]
fn patch_test_uniform_strain_is_exact() {
    let f_applied = Mat3::new(
        1.002, 0.0007, -0.0011, 0.0004, 0.9985, 0.0009, -0.0006, 0.0012, 1.0013,
    );
    for form in Formulation::ALL {
        let (mut sim, interior) = irregular_patch(form);
        sim.prepare().unwrap();
        for i in 0..sim.nodes.len() {
            sim.nodes.x[i] = f_applied * sim.nodes.x0[i];
        }
        let mat = sim.materials[0].clone();
        let expected = mat.stress(&f_applied, StressMeasure::Cauchy);
        for e in 0..sim.tets.len() {
            let f = fdem::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e);
            let s = mat.stress(&f, StressMeasure::Cauchy);
            assert!(
                (s - expected).norm() <= 1e-10 * expected.norm(),
                "{form:?}: tet {e} stress off"
            );
        }
        let mut ws = ElementsWorkspace::new(&sim.bodies, &sim.tets);
        let (tets, bodies, mats) = (sim.tets.clone(), sim.bodies.clone(), sim.materials.clone());
        add_internal_forces(&mut sim.nodes, &tets, &bodies, &mats, &mut ws, false);
        // Scale: the force one element face carries, |σ|·(h²/2) with h = 1/3.
        let scale = expected.norm() * (1.0 / 9.0) / 2.0;
        let worst = (0..sim.nodes.len())
            .filter(|&i| interior[i])
            .map(|i| sim.nodes.f[i].norm())
            .fold(0.0, Real::max);
        assert!(
            worst <= 1e-10 * scale,
            "{form:?}: interior residual {worst:e} vs scale {scale:e}"
        );
    }
}

/// The patch test driven through the time loop: boundary nodes held on the affine field
/// (prescribed zero velocity), interior nodes free. They must not move (1e-10 relative to the
/// imposed displacement).
#[test]
fn patch_test_through_the_time_loop() {
    let f_applied = Mat3::new(1.001, 0.0005, 0.0, 0.0, 0.999, 0.0003, 0.0002, 0.0, 1.0004);
    let (mut sim, interior) = irregular_patch(Formulation::StVenantKirchhoff);
    let boundary: Vec<u32> = (0..sim.nodes.len() as u32)
        .filter(|&i| !interior[i as usize])
        .collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: boundary,
        components: std::array::from_fn(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    for i in 0..sim.nodes.len() {
        sim.nodes.x[i] = f_applied * sim.nodes.x0[i];
    }
    let start = sim.nodes.x.clone();
    for _ in 0..200 {
        sim.step().unwrap();
    }
    let u_scale = (f_applied - Mat3::identity()).norm();
    for (i, (x, x_start)) in sim.nodes.x.iter().zip(&start).enumerate() {
        assert!((x - x_start).norm() <= 1e-10 * u_scale, "node {i} moved");
    }
}

/// Rigid rotation of 90° applied in 30 increments about a skew axis: every finite-strain law
/// (objective by construction) gives zero stress up to rounding, < 1e-8·E. The small-strain law
/// is not objective: ε = sym(R) − I is of order 1 at 90°, so its spurious stress must be ~E.
#[test]
fn rigid_rotation_gives_no_stress_except_small_strain() {
    let e_mod = 1e9;
    let axis = Vec3::new(1.0, 2.0, 0.5).normalize();
    for form in Formulation::ALL {
        let mut sim = box_sim(
            Vec3::zeros(),
            Vec3::new(1.0, 0.5, 0.3),
            [4, 2, 2],
            material(form, 1000.0, e_mod, 0.3),
            Layout::Jointed,
        );
        let mut worst: Real = 0.0;
        for k in 1..=30 {
            let r = rotation_matrix(&axis, (90.0_f64 * k as Real / 30.0).to_radians());
            for i in 0..sim.nodes.len() {
                sim.nodes.x[i] = r * sim.nodes.x0[i] + Vec3::new(0.3, -0.2, 1.0);
            }
            for e in 0..sim.tets.len() {
                let f = fdem::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e);
                for m in [
                    StressMeasure::Cauchy,
                    StressMeasure::Pk1,
                    StressMeasure::Pk2,
                ] {
                    worst = worst.max(sim.materials[0].stress(&f, m).norm());
                }
            }
        }
        if form == Formulation::SmallStrain {
            assert!(
                worst > 0.1 * e_mod,
                "small strain should show spurious rotation stress, got {worst:e}"
            );
        } else {
            assert!(worst < 1e-8 * e_mod, "{form:?}: rotation stress {worst:e}");
        }
    }
}

/// Random well-shaped tetrahedron: a regular tet of edge ~1 with vertices jittered by up to
/// 20 % (keeps the shape far from degenerate).
fn tet_strategy() -> impl Strategy<Value = [Vec3; 4]> {
    prop::array::uniform12(-0.2..0.2f64).prop_map(|j| {
        let base = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.5, 0.866, 0.0),
            Vec3::new(0.5, 0.289, 0.816),
        ];
        std::array::from_fn(|a| base[a] + Vec3::new(j[3 * a], j[3 * a + 1], j[3 * a + 2]))
    })
}

fn energy(mat: &Material, x: &[Vec3; 4], dm_inv: &Mat3, vol0: Real) -> Real {
    let ds = Mat3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
    vol0 * mat.energy_density(&(ds * dm_inv))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// f = −∂U/∂x by central differences (h = 1e-6 on O(1) coordinates: truncation ~1e-12,
    /// rounding ~1e-10 of the force scale), for every hyperelastic law at strains up to ~15 %.
    /// Munjiza's law is Cauchy-elastic: its reported energy is second-order accurate, so at
    /// strain 1e-4 the forces agree with −∂U/∂x to O(strain) = 1e-3 relative.
    #[test]
    fn internal_force_is_minus_energy_gradient(p in tet_strategy(), g in prop::array::uniform9(-0.1..0.1f64)) {
        let dm = Mat3::from_columns(&[p[1] - p[0], p[2] - p[0], p[3] - p[0]]);
        prop_assume!(dm.determinant() > 0.1);
        let dm_inv = dm.try_inverse().unwrap();
        let vol0 = dm.determinant() / 6.0;
        for form in Formulation::ALL {
            let mat = Material::new(form, 1000.0, 1e6, 0.3, 0.0).unwrap();
            let strain = if form.is_hyperelastic() { 1.0 } else { 1e-3 };
            let def = Mat3::identity() + Mat3::from_row_slice(&g) * strain;
            let x: [Vec3; 4] = p.map(|q| def * q);
            let r = internal_force_tet4(&x, &[Vec3::zeros(); 4], &dm_inv, vol0, &mat, false);
            let scale = r.forces.iter().map(|f| f.norm()).fold(0.0, Real::max);
            let tol = if form.is_hyperelastic() { 1e-6 } else { 1e-3 };
            let h = 1e-6;
            for a in 0..4 {
                for k in 0..3 {
                    let (mut xp, mut xm) = (x, x);
                    xp[a][k] += h;
                    xm[a][k] -= h;
                    let d = (energy(&mat, &xp, &dm_inv, vol0) - energy(&mat, &xm, &dm_inv, vol0)) / (2.0 * h);
                    prop_assert!((r.forces[a][k] + d).abs() <= tol * scale,
                        "{:?} node {} comp {}: f = {:e}, -dU/dx = {:e}", form, a, k, r.forces[a][k], -d);
                }
            }
            // Equilibrium of the element: Σf = 0.
            let sum: Vec3 = r.forces.iter().sum();
            prop_assert!(sum.norm() <= 1e-12 * scale);
        }
    }
}

/// The two layouts run through the same kernel: a body deformed by the same affine field has
/// the same total strain energy and the same sum of forces per reference node, jointed or
/// continuous.
#[test]
fn jointed_and_continuous_layouts_agree() {
    let f_applied = Mat3::new(1.01, 0.002, 0.0, 0.001, 0.995, 0.0, 0.0, 0.003, 1.004);
    let mut energies = Vec::new();
    for layout in [Layout::Jointed, Layout::Continuous] {
        let mut sim = box_sim(
            Vec3::zeros(),
            Vec3::new(1.0, 1.0, 1.0),
            [2, 2, 2],
            material(Formulation::NeoHookean, 1000.0, 1e6, 0.3),
            layout,
        );
        sim.prepare().unwrap();
        for i in 0..sim.nodes.len() {
            sim.nodes.x[i] = f_applied * sim.nodes.x0[i];
        }
        let mut ws = ElementsWorkspace::new(&sim.bodies, &sim.tets);
        let (tets, bodies, mats) = (sim.tets.clone(), sim.bodies.clone(), sim.materials.clone());
        let sums = add_internal_forces(&mut sim.nodes, &tets, &bodies, &mats, &mut ws, true);
        // Sum the forces of all nodes at the corner (0,0,0).
        let corner = sim.nodes_in(
            &Region::Sphere {
                center: Vec3::zeros(),
                radius: 1e-6,
            },
            None,
        );
        let f: Vec3 = corner.iter().map(|&n| sim.nodes.f[n as usize]).sum();
        energies.push((sums.strain_energy, f));
    }
    let (a, b) = (energies[0], energies[1]);
    assert!((a.0 - b.0).abs() <= 1e-12 * a.0.abs());
    assert!((a.1 - b.1).norm() <= 1e-12 * a.1.norm());
}
