//! Contact (stages 4–5): collisions, friction, stacking, fragments, against physics that
//! cannot be faked: conservation of momentum and energy, 1D wave theory, Coulomb's law on an
//! incline.

mod common;

use common::material;
use fdem::contact_interaction::ContactRule;
use fdem::material::Formulation;
use fdem::math::{Real, Vec3};
use fdem::mesh::box_mesh;
use fdem::pipeline::{Layout, Simulation};

fn body_momentum(sim: &Simulation, b: usize) -> (Vec3, Real) {
    let r = sim.bodies[b].nodes.clone();
    let m: Real = sim.nodes.m[r.clone()].iter().sum();
    let p: Vec3 = r.map(|n| sim.nodes.v[n] * sim.nodes.m[n]).sum();
    (p, m)
}

fn total_momentum(sim: &Simulation) -> Vec3 {
    (0..sim.nodes.len())
        .map(|n| sim.nodes.v[n] * sim.nodes.m[n])
        .sum()
}

fn set_velocity(sim: &mut Simulation, b: usize, v: Vec3) {
    for n in sim.bodies[b].nodes.clone() {
        sim.nodes.v[n] = v;
    }
}

/// Two elastic cubes (edge 0.1 m, 4³ cells, continuous, offset sideways so the faces overlap
/// partly and the meshes do not match) approach head-on at ±0.05 m/s, no damping, no
/// friction. Momentum: contact forces are equal and opposite pair by pair, so the total
/// momentum stays at its initial value to rounding (1e-10 of one cube's momentum). Energy:
/// the potential force is conservative. The penalty (1e3 Pa against E = 1e6 Pa) makes the
/// contact much softer than the cubes, so the impact is quasi-static (contact ≈ 60 ms, the
/// cubes' fundamental period ≈ 6 ms) and little energy is left in vibration: after
/// separation the kinetic energy (translation and the rotation the offset induces) must be
/// ≥ 98 % of the initial.
#[test]
fn cubes_head_on_conserve_momentum_and_energy() {
    let mat = material(Formulation::StVenantKirchhoff, 1000.0, 1.0e6, 0.25);
    const PENALTY: Real = 1.0e3;
    const V: Real = 0.05;
    const T_END: Real = 0.15;
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let a = box_mesh(Vec3::zeros(), Vec3::repeat(0.1), [4, 4, 4]);
    let mut b = a.clone();
    b.translate(Vec3::new(0.105, 0.02, 0.01));
    sim.add_body("a", &a, m, Layout::Continuous).unwrap();
    sim.add_body("b", &b, m, Layout::Continuous).unwrap();
    sim.contact.rules.push(ContactRule {
        penalty: Some(PENALTY),
        friction: 0.0,
        ..Default::default()
    });
    set_velocity(&mut sim, 0, Vec3::new(V, 0.0, 0.0));
    set_velocity(&mut sim, 1, Vec3::new(-V, 0.0, 0.0));
    sim.prepare().unwrap();
    let p0 = total_momentum(&sim);
    let (pa0, ma) = body_momentum(&sim, 0);
    let ke0 = sim.kinetic_energy_now();
    let mut touched = false;
    let mut steps = 0;
    // Approach (5 mm gap at 2 m/s), contact (~2L/c ≈ 6 ms), separation.
    while sim.time < T_END {
        sim.step().unwrap();
        steps += 1;
        touched |= sim.contact.last.active > 0;
        let p = total_momentum(&sim);
        assert!(
            (p - p0).norm() < 1e-10 * pa0.norm(),
            "step {steps}: momentum drift {:?}",
            p - p0
        );
    }
    assert!(touched, "the cubes never touched");
    assert_eq!(sim.contact.last.active, 0, "still touching at the end");
    let (pa, _) = body_momentum(&sim, 0);
    let (pb, _) = body_momentum(&sim, 1);
    let ke = sim.kinetic_energy_now();
    println!(
        "steps {steps}, dt {:.3e}, KE after/before = {:.6}, velocity of a {:?}, balance error {:.3e} J, detections {}",
        sim.dt,
        ke / ke0,
        pa / ma,
        sim.energy.balance_error(),
        sim.contact.detector.detections
    );
    assert!(pa.x < 0.0 && pb.x > 0.0, "the cubes must bounce back");
    assert!(ke >= 0.98 * ke0, "kinetic energy recovered {:.4}", ke / ke0);
    assert!(sim.energy.balance_error().abs() < 1e-3 * ke0);
}

/// Two identical bars (1 m × 0.05 m × 0.05 m, ν = 0 so waves are 1D at c = √(E/ρ)) collide
/// end on, one at rest. 1D wave theory (equal impedances): the striker stops, the target
/// leaves at the striker's speed, and the contact lasts 2L/c (first to last step with a
/// touching pair: the discrete interface may chatter within it). Tolerance 5 % on the
/// duration (the penalty adds a small compliance), 3 % on the velocities.
#[test]
fn bars_end_on_exchange_velocities() {
    let (rho, e) = (1000.0, 1.0e7);
    let c = (e / rho as Real).sqrt();
    let mat = material(Formulation::StVenantKirchhoff, rho, e, 0.0);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let a = box_mesh(Vec3::zeros(), Vec3::new(1.0, 0.05, 0.05), [40, 2, 2]);
    let mut b = a.clone();
    b.translate(Vec3::new(1.001, 0.0, 0.0));
    sim.add_body("striker", &a, m, Layout::Continuous).unwrap();
    sim.add_body("target", &b, m, Layout::Continuous).unwrap();
    sim.contact.rules.push(ContactRule {
        penalty: Some(10.0 * e),
        ..Default::default()
    });
    let v = 1.0;
    set_velocity(&mut sim, 0, Vec3::new(v, 0.0, 0.0));
    sim.prepare().unwrap();
    let (mut start, mut end) = (None, None);
    while sim.time < 0.001 / v + 4.0 / c {
        sim.step().unwrap();
        let active = sim.contact.last.active > 0;
        if active && start.is_none() {
            start = Some(sim.time);
        }
        if active {
            end = Some(sim.time);
        }
    }
    let duration = end.unwrap() - start.unwrap();
    let (pa, ma) = body_momentum(&sim, 0);
    let (pb, mb) = body_momentum(&sim, 1);
    println!(
        "duration {duration:.5e} s vs 2L/c {:.5e} s; striker {:.4} m/s, target {:.4} m/s; dt {:.3e}",
        2.0 / c,
        pa.x / ma,
        pb.x / mb,
        sim.dt
    );
    assert!((duration - 2.0 / c).abs() < 0.05 * 2.0 / c);
    assert!((pa.x / ma).abs() < 0.03 * v, "striker keeps {}", pa.x / ma);
    assert!(
        (pb.x / mb - v).abs() < 0.03 * v,
        "target leaves at {}",
        pb.x / mb
    );
}
