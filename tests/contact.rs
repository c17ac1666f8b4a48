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

/// A block (0.1 m cube, 2 cells) resting on a fixed base, gravity tilted by θ (the same as an
/// incline of angle θ), contact damping ζ = 1 (the block is dropped onto its contact springs
/// at t = 0 and would otherwise ring). Coulomb: below the friction angle it sticks; above,
/// it slides with a = g(sinθ − μcosθ).
fn incline(theta_deg: Real, mu: Real, t_end: Real) -> (Vec<(Real, Real, Real)>, Simulation) {
    let mat = material(Formulation::StVenantKirchhoff, 2500.0, 1.0e8, 0.25);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let base = box_mesh(
        Vec3::new(-0.1, -0.1, -0.05),
        Vec3::new(1.0, 0.2, 0.0),
        [22, 6, 1],
    );
    let block = box_mesh(Vec3::zeros(), Vec3::new(0.1, 0.1, 0.1), [2, 2, 2]);
    sim.add_body("base", &base, m, Layout::Continuous).unwrap();
    sim.add_body("block", &block, m, Layout::Continuous)
        .unwrap();
    let base_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: base_nodes,
        components: [(); 3].map(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    let th = theta_deg.to_radians();
    sim.loads.gravity = Vec3::new(th.sin(), 0.0, -th.cos()) * 9.81;
    sim.contact.rules.push(ContactRule {
        friction: mu,
        damping: 1.0,
        ..Default::default()
    });
    sim.prepare().unwrap();
    let mut hist = Vec::new();
    while sim.time < t_end {
        sim.step().unwrap();
        let (p, mb) = body_momentum(&sim, 1);
        let r = sim.bodies[1].nodes.clone();
        let x: Real = r
            .clone()
            .map(|n| sim.nodes.x[n].x - sim.nodes.x0[n].x)
            .sum::<Real>()
            / r.len() as Real;
        hist.push((sim.time, x, p.x / mb));
    }
    (hist, sim)
}

/// θ = 15° with μ = 0.7 (friction angle 35°): the block sticks; over 1 s it creeps less than
/// 1e-4 of its size (the elastic offset of the friction springs is ~1e-9 m).
#[test]
fn block_on_incline_sticks_below_the_friction_angle() {
    let (hist, sim) = incline(15.0, 0.7, 1.0);
    let last = hist.last().unwrap();
    println!(
        "x after 1 s: {:.3e} m, v {:.3e} m/s, dt {:.3e}, energy error {:.3e}",
        last.1,
        last.2,
        sim.dt,
        sim.energy.relative_balance_error()
    );
    assert!(last.1.abs() < 1e-5, "crept {:.3e} m", last.1);
}

/// θ = 40° with μ = 0.5: a = g(sin40° − 0.5·cos40°) = 2.551 m/s², within 2 %. The slope of
/// v(t) is fitted by least squares over 0.1–0.4 s (after the block has settled onto the
/// base).
#[test]
fn block_on_incline_slides_at_coulomb_acceleration() {
    let (theta, mu): (Real, Real) = (40.0, 0.5);
    let (hist, sim) = incline(theta, mu, 0.4);
    let a_exact = 9.81 * (theta.to_radians().sin() - mu * theta.to_radians().cos());
    let pts: Vec<_> = hist.iter().filter(|h| h.0 >= 0.1).collect();
    let n = pts.len() as Real;
    let (st, sv) = pts.iter().fold((0.0, 0.0), |a, h| (a.0 + h.0, a.1 + h.2));
    let (mt, mv) = (st / n, sv / n);
    let (num, den) = pts.iter().fold((0.0, 0.0), |a, h| {
        (a.0 + (h.0 - mt) * (h.2 - mv), a.1 + (h.0 - mt).powi(2))
    });
    let a = num / den;
    let e = sim.energy;
    println!("a = {a:.5} m/s² vs {a_exact:.5}; friction dissipated {:.4e} J, gravity work {:.4e} J, KE {:.4e} J, balance error {:.3e} J; dt {:.3e}", e.friction, e.gravity_work, e.kinetic, e.balance_error(), sim.dt);
    assert!((a - a_exact).abs() < 0.02 * a_exact);
}

/// Four blocks (0.1 m cubes, staggered by 1–2 cm) stacked on a fixed base under gravity, μ =
/// 0.5, contact damping ζ = 0.3. They settle (with mass damping α = 60/s for the first
/// 0.3 s, the usual quasi-static device), then, with mass damping off, stay at rest: between
/// 0.35 s and 0.65 s no block's centre of mass moves more than 1e-6 m (no drift; 1e-5 of the block size;
/// the blocks' own elastic ringing, undamped, moves nodes by a few µm) and the kinetic
/// energy stays below 1e-4 of the potential energy released (no explosion), and the contact
/// force on the base carries the weight of the stack (1 %).
#[test]
fn stack_of_blocks_settles_and_stays_at_rest() {
    let mat = material(Formulation::StVenantKirchhoff, 2500.0, 1.0e7, 0.25);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let base = box_mesh(
        Vec3::new(-0.1, -0.1, -0.05),
        Vec3::new(0.2, 0.2, 0.0),
        [6, 6, 1],
    );
    sim.add_body("base", &base, m, Layout::Continuous).unwrap();
    for k in 0..4 {
        let mut b = box_mesh(Vec3::zeros(), Vec3::repeat(0.1), [2, 2, 2]);
        let s = if k % 2 == 0 { 0.01 } else { -0.02 };
        b.translate(Vec3::new(s, 0.5 * s, 0.1 * k as Real));
        sim.add_body(&format!("block{k}"), &b, m, Layout::Continuous)
            .unwrap();
    }
    let base_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: base_nodes.clone(),
        components: [(); 3].map(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.contact.rules.push(ContactRule {
        friction: 0.5,
        damping: 0.3,
        ..Default::default()
    });
    sim.settings.mass_damping = 60.0;
    sim.prepare().unwrap();
    let weight: Real = (1..5).map(|b| body_momentum(&sim, b).1).sum::<Real>() * 9.81;
    while sim.time < 0.3 {
        sim.step().unwrap();
    }
    sim.settings.mass_damping = 0.0;
    while sim.time < 0.35 {
        sim.step().unwrap();
    }
    let centres = |sim: &Simulation| -> Vec<Vec3> {
        (1..5)
            .map(|b| {
                let r = sim.bodies[b].nodes.clone();
                let m: Real = sim.nodes.m[r.clone()].iter().sum();
                r.map(|n| sim.nodes.x[n] * sim.nodes.m[n]).sum::<Vec3>() / m
            })
            .collect()
    };
    let before = centres(&sim);
    let mut max_ke: Real = 0.0;
    while sim.time < 0.65 {
        sim.step().unwrap();
        max_ke = max_ke.max(sim.kinetic_energy_now());
    }
    let drift = centres(&sim)
        .iter()
        .zip(&before)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    let released = sim.energy.gravity_work;
    let node_force = sim.contact.node_forces(sim.nodes.len());
    let on_base: Vec3 = base_nodes.iter().map(|&n| node_force[n as usize]).sum();
    println!(
        "drift {drift:.3e} m, max KE {max_ke:.3e} J (gravity work {released:.3e} J), contact force on the base {:.4} N vs weight {weight:.4} N, detections {}, dt {:.3e}",
        -on_base.z, sim.contact.detector.detections, sim.dt
    );
    assert!(drift < 1e-6, "drift {drift:.3e} m");
    assert!(max_ke < 1e-4 * released, "max KE {max_ke:.3e} J");
    assert!((-on_base.z - weight).abs() < 0.01 * weight);
}

/// The impact model: a fully jointed block at 5 m/s above a fixed plate, contact on.
fn impact_model() -> (Simulation, usize) {
    use fdem::joints::law::{Calibration, Cohesive, Softening};
    use fdem::joints::JointLaw;
    let (rho, e) = (2500.0, 1.0e8);
    let mat = material(Formulation::StVenantKirchhoff, rho, e, 0.2);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let plate = box_mesh(
        Vec3::new(-0.1, -0.1, -0.05),
        Vec3::new(0.2, 0.2, 0.0),
        [6, 6, 1],
    );
    let mut block = box_mesh(Vec3::zeros(), Vec3::repeat(0.1), [3, 3, 3]);
    block.translate(Vec3::new(0.0, 0.0, 0.002));
    sim.add_body("plate", &plate, m, Layout::Continuous)
        .unwrap();
    let b = sim.add_body("block", &block, m, Layout::Jointed).unwrap();
    let law = sim.joints.add_law(JointLaw::Cohesive(Cohesive {
        softening: Softening::Munjiza,
        calibration: Calibration::Exact,
        tensile_strength: 0.3e6,
        cohesion: 0.6e6,
        tan_friction: 0.6,
        g_i: 2.0,
        g_ii: 8.0,
        normal_penalty: 10.0 * e,
        tangential_penalty: 10.0 * e,
        residual_friction: 0.5,
    }));
    let body = sim.bodies[b].clone();
    let (tn, x0) = (sim.tets.nodes.clone(), sim.nodes.x0.clone());
    let joints = sim
        .joints
        .insert_in_body(&body, &tn, &x0, law, |_| true)
        .unwrap();
    let plate_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: plate_nodes,
        components: [(); 3].map(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    sim.contact.rules.push(ContactRule {
        friction: 0.3,
        ..Default::default()
    });
    set_velocity(&mut sim, b, Vec3::new(0.0, 0.0, -5.0));
    (sim, joints)
}

/// A fully jointed block (0.1 m cube, 3³ cells, Munjiza joints with f_t = 0.3 MPa) hits a
/// fixed plate at 5 m/s and breaks into dozens of fragments. Contact acts between fragments
/// and on the plate; broken joints hand their faces to contact once these have separated.
/// Checked: the total energy balance (kinetic + strain + joint + contact + fracture +
/// friction = initial) within 2 % of the impact energy, the block really fragments, and
/// the deepest penetration of any pair stays below 5 % of an element height (documented in
/// docs/theory/contact.md: ≈ 0.6 % of h per m/s of impact speed at p = 10E).
#[test]
fn jointed_block_fractures_on_impact_without_interpenetration() {
    let (mut sim, joints) = impact_model();
    sim.prepare().unwrap();
    let ke0 = sim.kinetic_energy_now();
    let mut max_ratio: Real = 0.0;
    while sim.time < 3e-3 {
        sim.step().unwrap();
        max_ratio = max_ratio.max(sim.contact.last.max_overlap_ratio);
    }
    sim.sample_next = true;
    sim.step().unwrap();
    let en = sim.energy;
    let (frag, _, _) =
        fdem::fracture::fragment_sizes(&sim.tets, &sim.materials, &sim.joints, sim.nodes.len());
    let fragments = frag.iter().max().unwrap() + 1;
    println!(
        "{joints} joints, {} broken, {fragments} fragments (with the plate); energy: initial KE {ke0:.3} J, KE {:.3}, strain {:.3}, joint {:.3}, contact {:.4}, fracture {:.3}, friction {:.3}, balance error {:.3e} J ({:.2} %); deepest penetration {:.4} h; dt {:.3e}",
        sim.break_events.len(),
        en.kinetic,
        en.strain,
        en.joint,
        en.contact,
        en.fracture,
        en.friction,
        en.balance_error(),
        100.0 * en.balance_error() / ke0,
        max_ratio,
        sim.dt
    );
    assert!(fragments >= 10, "the block should break up");
    assert!(en.balance_error().abs() < 0.02 * ke0);
    assert!(max_ratio < 0.05, "penetration {max_ratio:.4} h");
}

mod detection {
    use fdem::contact_detection::{brute_force_pairs, nbs_pairs, Aabb, NbsWorkspace};
    use fdem::math::{Real, Vec3};
    use proptest::prelude::*;

    /// Boxes from (centre, size) with a spread of sizes, densities and, optionally, a second
    /// cluster very far away.
    fn boxes(raw: &[(f64, f64, f64, f64)], spread: Real, far: bool) -> Vec<Aabb> {
        raw.iter()
            .enumerate()
            .map(|(i, &(x, y, z, s))| {
                let mut c = Vec3::new(x, y, z) * spread;
                if far && i % 2 == 1 {
                    c.x += 1.0e7;
                }
                let h = Vec3::new(s, 0.5 * s + 0.01, 0.8 * s);
                Aabb {
                    lo: c - h,
                    hi: c + h,
                }
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The NBS pair set equals brute force on random configurations: mixed sizes (factor
        /// 100), sparse and dense packings, bodies 1e7 m apart.
        #[test]
        fn nbs_equals_brute_force(
            raw in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64, 0.001..0.1f64), 2..400),
            spread in prop::sample::select(vec![0.5, 2.0, 20.0]),
            far in any::<bool>(),
        ) {
            let b = boxes(&raw, spread, far);
            let mut ws = NbsWorkspace::default();
            let mut out = Vec::new();
            nbs_pairs(&b, &mut ws, &|_, _| true, &mut out);
            out.sort_unstable();
            prop_assert_eq!(out, brute_force_pairs(&b, |_, _| true));
        }
    }
}

/// Crown drops [m] of a dry-stone semicircular arch (R = 1 m, 15 voussoirs, no mortar:
/// blocks touch through contact, μ = 0.7, contact damping ζ = 0.3) under self-weight with
/// fixed springings, at t_end/2 and t_end.
fn dry_arch_crown_drop(t_over_r: Real, t_end: Real) -> (Real, Real) {
    use fdem::mesh::masonry::{arch, Arch};
    let r = 1.0;
    let ring = arch(
        &Arch {
            radius: r,
            thickness: t_over_r * r,
            depth: 0.2,
            voussoirs: 15,
            span_angle: 180.0,
        },
        0.1,
    )
    .unwrap();
    // Stiff against the self-weight stress ρgR ≈ 2.4e4 Pa (strain ~5e-4): rigid-block-like.
    let mat = material(Formulation::StVenantKirchhoff, 2400.0, 5.0e7, 0.2);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let mut fixed = Vec::new();
    let mut crown = Vec::new();
    for (i, b) in ring.blocks.iter().enumerate() {
        let id = sim
            .add_body(&format!("v{i}"), &b.mesh, m, Layout::Continuous)
            .unwrap();
        let start = sim.bodies[id].nodes.start as u32;
        if b.springer {
            fixed.extend(b.mesh.sets.nodes["springing"].iter().map(|n| n + start));
        }
        if i == ring.blocks.len() / 2 {
            crown.extend(sim.bodies[id].nodes.clone().map(|n| n as u32));
        }
    }
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: fixed,
        components: [(); 3].map(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.contact.rules.push(ContactRule {
        friction: 0.7,
        damping: 0.3,
        ..Default::default()
    });
    sim.prepare().unwrap();
    let crown_z = |sim: &Simulation| {
        crown
            .iter()
            .map(|&n| sim.nodes.x[n as usize].z)
            .sum::<Real>()
            / crown.len() as Real
    };
    let z0 = crown_z(&sim);
    while sim.time < 0.5 * t_end {
        sim.step().unwrap();
    }
    let half = z0 - crown_z(&sim);
    while sim.time < t_end {
        sim.step().unwrap();
    }
    let end = z0 - crown_z(&sim);
    println!(
        "t/R = {t_over_r}: crown drop {half:.4e} m at {:.2} s, {end:.4e} m at {t_end} s ({} steps, dt {:.2e})",
        0.5 * t_end,
        sim.step,
        sim.dt
    );
    (half, end)
}

/// Heyman's minimum thickness of a semicircular arch is t/R ≈ 0.1075 (Heyman 1969; with
/// friction, Ochsendorf 2002). A dry-stone arch of t/R = 0.15 stands under self-weight: its
/// crown settles by the contact and elastic compliance and rocks about 1–3 mm below its start
/// (a 1.2 s run shows no growth), so it stays within 1 % of R at 0.2 s and 0.4 s. One of
/// t/R = 0.06 collapses: its crown falls more than 5 % of R within 0.4 s, accelerating.
#[test]
fn dry_stone_arch_stands_when_thick_and_collapses_when_thin() {
    let (half, end) = dry_arch_crown_drop(0.15, 0.4);
    assert!(
        half.abs() < 1e-2 && end.abs() < 1e-2,
        "thick arch crown moved {half:.3e}, {end:.3e} m"
    );
    let (half, thin) = dry_arch_crown_drop(0.06, 0.4);
    assert!(
        thin > 0.05 && thin > 2.0 * half,
        "thin arch crown dropped only {half:.3e}, {thin:.3e} m"
    );
}

/// Contact, fracture and friction give bit-identical positions, velocities and energies on
/// 1 and 2 threads (pairs are evaluated in parallel, added to the nodes in pair order).
#[test]
fn contact_results_are_bit_identical_for_1_and_2_threads() {
    let run = |threads: usize| {
        common::on_threads(threads, || {
            let (mut sim, _) = impact_model();
            sim.settings.energy_every = 9;
            for _ in 0..600 {
                sim.step().unwrap();
            }
            sim
        })
    };
    let (a, b) = (run(1), run(2));
    assert!(a.contact.last.active > 0 && !a.break_events.is_empty());
    assert_eq!(a.nodes.x, b.nodes.x);
    assert_eq!(a.nodes.v, b.nodes.v);
    assert_eq!(a.energy_history, b.energy_history);
    assert_eq!(a.contact.pairs, b.contact.pairs);
}
