//! Contact (stages 4–5): collisions, friction, stacking, fragments, against physics that
//! cannot be faked: conservation of momentum and energy, 1D wave theory, Coulomb's law on an
//! incline.

mod common;

use common::material;
use fdem::compiled::{compile_with, CompiledLaw};
use fdem::contact_interaction::{ContactRule, PotentialContact, FRICTION_LAW};
use fdem::material::Formulation;
use fdem::math::{Real, Vec3};
use fdem::mesh::box_mesh;
use fdem::{Layout, Simulation};
use std::sync::Arc;

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
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            penalty: Some(PENALTY),
            friction: 0.0,
            ..Default::default()
        }));
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
        sim.contact_detection.detector.detections
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
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            penalty: Some(10.0 * e),
            ..Default::default()
        }));
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

/// A block (0.1 m × 0.1 m × `height`, cells of 0.05 m) resting on a fixed base, gravity
/// tilted by θ (the same as an incline of angle θ), contact by `rule`, the block pushed down
/// the slope at `v0`.
fn incline_model(theta_deg: Real, height: Real, rule: ContactRule, v0: Real) -> Simulation {
    let mat = material(Formulation::StVenantKirchhoff, 2500.0, 1.0e8, 0.25);
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    let base = box_mesh(
        Vec3::new(-0.1, -0.1, -0.05),
        Vec3::new(1.0, 0.2, 0.0),
        [22, 6, 1],
    );
    let nz = (height / 0.05).round() as usize;
    let block = box_mesh(Vec3::zeros(), Vec3::new(0.1, 0.1, height), [2, 2, nz]);
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
    sim.contact.laws.rules.push(rule);
    set_velocity(&mut sim, 1, Vec3::new(v0, 0.0, 0.0));
    sim.prepare().unwrap();
    sim
}

/// Step to `t_end`; every step (t, mean x-displacement of the block, its x-velocity).
fn run_incline(sim: &mut Simulation, t_end: Real) -> Vec<(Real, Real, Real)> {
    let mut hist = Vec::new();
    while sim.time < t_end {
        sim.step().unwrap();
        let (p, mb) = body_momentum(sim, 1);
        let r = sim.bodies[1].nodes.clone();
        let x: Real = r
            .clone()
            .map(|n| sim.nodes.x[n].x - sim.nodes.x0[n].x)
            .sum::<Real>()
            / r.len() as Real;
        hist.push((sim.time, x, p.x / mb));
    }
    hist
}

/// The incline with Coulomb friction μ and contact damping ζ = 1 (the block is dropped onto
/// its contact springs at t = 0 and would otherwise ring). Coulomb: below the friction angle
/// it sticks; above, it slides with a = g(sinθ − μcosθ).
fn incline(theta_deg: Real, mu: Real, t_end: Real) -> (Vec<(Real, Real, Real)>, Simulation) {
    let rule = ContactRule::from(PotentialContact {
        friction: mu,
        damping: 1.0,
        ..Default::default()
    });
    let mut sim = incline_model(theta_deg, 0.1, rule, 0.0);
    (run_incline(&mut sim, t_end), sim)
}

/// Least-squares slope of y(t) over the points with t ≥ t0.
fn slope_after(
    hist: &[(Real, Real, Real)],
    t0: Real,
    y: impl Fn(&(Real, Real, Real)) -> Real,
) -> Real {
    let pts: Vec<_> = hist.iter().filter(|h| h.0 >= t0).collect();
    let n = pts.len() as Real;
    let (st, sy) = pts.iter().fold((0.0, 0.0), |a, h| (a.0 + h.0, a.1 + y(h)));
    let (mt, my) = (st / n, sy / n);
    let (num, den) = pts.iter().fold((0.0, 0.0), |a, h| {
        (a.0 + (h.0 - mt) * (y(h) - my), a.1 + (h.0 - mt).powi(2))
    });
    num / den
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
    let a = slope_after(&hist, 0.1, |h| h.2);
    let e = sim.energy;
    println!("a = {a:.5} m/s² vs {a_exact:.5}; friction dissipated {:.4e} J, gravity work {:.4e} J, KE {:.4e} J, balance error {:.3e} J; dt {:.3e}", e.friction, e.gravity_work, e.kinetic, e.balance_error(), sim.dt);
    assert!((a - a_exact).abs() < 0.02 * a_exact);
}

/// The friction law `name` of Rhai source `src`, compiled as stage 5 uses it.
fn friction_law(src: &str, name: &str, params: &[(&str, Real)]) -> Arc<CompiledLaw> {
    let ast = rhai::Engine::new_raw().compile(src).unwrap();
    let mut p = rhai::Map::new();
    for (k, v) in params {
        p.insert((*k).into(), (*v).into());
    }
    Arc::new(compile_with(&ast, name, &p, FRICTION_LAW).unwrap())
}

/// The rule of the incline tests (contact damping ζ = 1) with a friction law.
fn law_rule(friction: Real, law: Arc<CompiledLaw>) -> ContactRule {
    ContactRule::from(law_params(friction, law))
}

fn law_params(friction: Real, law: Arc<CompiledLaw>) -> PotentialContact {
    PotentialContact {
        friction,
        damping: 1.0,
        friction_law: Some(law),
        ..Default::default()
    }
}

/// A compiled law that returns the constant μ takes the same path through stage 5 as the
/// built-in Coulomb friction: the block sliding down 40° with μ = 0.5 has bit-identical
/// positions, velocities and energies after 0.1 s (6400 steps, settling and sliding), whether μ
/// comes from the rule, from a law parameter (`p.mu`, the rule's friction 0) or from the
/// law's input `c.mu` (returned as a bare number).
#[test]
fn friction_law_returning_a_constant_is_bit_identical_to_builtin_coulomb() {
    let t_end = 0.1;
    let (_, builtin) = incline(40.0, 0.5, t_end);
    let from_param = friction_law("fn mu(c, p) { #{ friction: p.mu } }", "mu", &[("mu", 0.5)]);
    let from_input = friction_law("fn mu(c, p) { c.mu }", "mu", &[]);
    for (friction, law) in [(0.0, from_param), (0.5, from_input)] {
        let mut sim = incline_model(40.0, 0.1, law_rule(friction, law), 0.0);
        let hist = run_incline(&mut sim, t_end);
        assert!(hist.last().unwrap().1 > 1e-3, "the block slides");
        assert_eq!(sim.step, builtin.step);
        assert_eq!(sim.nodes.x, builtin.nodes.x);
        assert_eq!(sim.nodes.v, builtin.nodes.v);
        assert_eq!(sim.energy_history, builtin.energy_history);
    }
}

/// The contact penalty of the rate- and slip-dependent incline tests: E/10 instead of the
/// default 10·E. Under the default the block's contact overlap (σH/8p ≈ 7 nm) is far smaller
/// than the elastic deformation of the block under its weight (ρgh²/2E ≈ 0.3 µm), and the
/// sliding contact chatters: the normal force fluctuates with a standard deviation of about
/// 2/3 of its mean (measured). Coulomb's constant μ averages that exactly, a μ(v) does not
/// (the terminal speed came out 2.4 % fast); at E/10 the overlap is 0.7 µm and the normal
/// force is steady to 1e-4.
const SMOOTH_PENALTY: Real = 1.0e7;

/// Velocity strengthening μ(v) = μ0 + k·v (stdlib `linear_rate`, μ0 = 0.3, k = 2.5 s/m) on
/// 25° (tan 25° = 0.466 > μ0), a flat block (0.1 × 0.1 × 0.05 m, so that the friction moment
/// cannot lift its rear edge): it accelerates until sinθ = μ(v)·cosθ, the terminal slip
/// speed v* = (tanθ − μ0)/k = 0.06652 m/s. Linearised, v approaches v* with the time constant
/// 1/(g·k·cosθ) = 0.045 s, so the mean velocity over 0.3–0.35 s (6.7 time constants: 0.1 %
/// left) must be v* within 2 %.
#[test]
fn velocity_strengthening_friction_reaches_the_terminal_slip_speed() {
    let (theta, mu0, k): (Real, Real, Real) = (25.0, 0.3, 2.5);
    let law = friction_law(
        include_str!("../stdlib/friction_laws.rhai"),
        "linear_rate",
        &[("mu0", mu0), ("k", k)],
    );
    let rule = ContactRule::from(PotentialContact {
        penalty: Some(SMOOTH_PENALTY),
        ..law_params(0.0, law)
    });
    let mut sim = incline_model(theta, 0.05, rule, 0.0);
    let hist = run_incline(&mut sim, 0.35);
    let v_star = (theta.to_radians().tan() - mu0) / k;
    let late: Vec<Real> = hist.iter().filter(|h| h.0 >= 0.3).map(|h| h.2).collect();
    let v = late.iter().sum::<Real>() / late.len() as Real;
    let spread = late.iter().fold(0.0, |m: Real, x| m.max((x - v).abs()));
    println!(
        "terminal slip speed {v:.6} m/s (±{spread:.1e} over 0.3–0.35 s) vs v* = {v_star:.6} m/s ({:+.3} %); v at 0.1 s {:.5}; {} steps, dt {:.3e}",
        100.0 * (v / v_star - 1.0),
        hist.iter().find(|h| h.0 >= 0.1).unwrap().2,
        sim.step,
        sim.dt
    );
    assert!((v - v_star).abs() < 0.02 * v_star);
}

/// Linear slip weakening μ = μ_d + (μ_s − μ_d)·max(0, 1 − slip/D_c) (stdlib
/// `slip_weakening`, μ_s = 0.5, μ_d = 0.25, D_c = 1 mm) on 20°, the flat block: tan 20° =
/// 0.364 lies between them. Pushed down the slope at 0.05 m/s, a block with the constant
/// μ_s stops (checked: |v| < 1e-4 m/s at 0.3 s), but with slip weakening it slides through
/// D_c, weakens its contacts and keeps sliding with a = g(sinθ − μ_d·cosθ) = 1.0506 m/s²
/// (rigid block, uniform contact). Fitted over 0.1–0.3 s (by 0.1 s it has slid 8 mm, 8·D_c):
/// within 2 %.
#[test]
fn slip_weakening_friction_keeps_a_pushed_block_sliding_at_the_dynamic_acceleration() {
    let (theta, mu_s, mu_d, d_c): (Real, Real, Real, Real) = (20.0, 0.5, 0.25, 1e-3);
    let v0 = 0.05;
    let law = friction_law(
        include_str!("../stdlib/friction_laws.rhai"),
        "slip_weakening",
        &[("mu_s", mu_s), ("mu_d", mu_d), ("d_c", d_c)],
    );
    let rule = ContactRule::from(PotentialContact {
        penalty: Some(SMOOTH_PENALTY),
        ..law_params(0.0, law)
    });
    let mut sim = incline_model(theta, 0.05, rule, v0);
    let hist = run_incline(&mut sim, 0.3);
    let a_exact = 9.81 * (theta.to_radians().sin() - mu_d * theta.to_radians().cos());
    let a = slope_after(&hist, 0.1, |h| h.2);
    let at_01 = hist.iter().find(|h| h.0 >= 0.1).unwrap();
    let last = hist.last().unwrap();
    let min_slip = sim
        .contact
        .pair_states()
        .filter(|s| s.touching)
        .map(|s| s.slip)
        .fold(Real::INFINITY, Real::min);
    let static_rule = ContactRule::from(PotentialContact {
        penalty: Some(SMOOTH_PENALTY),
        friction: mu_s,
        damping: 1.0,
        ..Default::default()
    });
    let mut stuck = incline_model(theta, 0.05, static_rule, v0);
    let stuck_hist = run_incline(&mut stuck, 0.3);
    let stuck_last = stuck_hist.last().unwrap();
    println!(
        "a = {a:.5} m/s² vs g(sinθ − μ_d cosθ) = {a_exact:.5} ({:+.3} %); slid {:.4} m by 0.1 s, {:.4} m by 0.3 s (v {:.4} m/s); smallest slip of a touching pair {min_slip:.2e} m; with constant μ_s: slid {:.3e} m, v {:.1e} m/s; dt {:.3e}",
        100.0 * (a / a_exact - 1.0),
        at_01.1,
        last.1,
        last.2,
        stuck_last.1,
        stuck_last.2,
        sim.dt
    );
    assert!(
        stuck_last.2.abs() < 1e-4,
        "constant μ_s: v = {}",
        stuck_last.2
    );
    assert!(at_01.1 > 5.0 * d_c, "slid only {} m by 0.1 s", at_01.1);
    assert!((a - a_exact).abs() < 0.02 * a_exact);
}

/// The laws of stdlib/friction_laws.rhai compile and give their formulas (to 1e-15) at a
/// few points: inputs in the order slip_rate, slip, pressure, normal_force, area, time, mu.
#[test]
fn stdlib_friction_laws_give_their_formulas() {
    let src = include_str!("../stdlib/friction_laws.rhai");
    let at = |v: Real, slip: Real| [v, slip, 1e5, 10.0, 1e-4, 0.5, 0.6];
    let linear = friction_law(src, "linear_rate", &[("mu0", 0.3), ("k", 2.0)]);
    let expo = friction_law(
        src,
        "exponential_rate",
        &[("mu_s", 0.6), ("mu_d", 0.2), ("v_c", 0.1)],
    );
    let sw = friction_law(
        src,
        "slip_weakening",
        &[("mu_s", 0.6), ("mu_d", 0.2), ("d_c", 1e-3)],
    );
    let cases: [(&CompiledLaw, [Real; 7], Real); 8] = [
        (&linear, at(0.0, 0.0), 0.3),
        (&linear, at(0.25, 0.0), 0.3 + 2.0 * 0.25),
        (&expo, at(0.0, 0.0), 0.6),
        (&expo, at(0.1, 0.0), 0.2 + 0.4 * (-1.0 as Real).exp()),
        (&sw, at(0.0, 0.0), 0.6),
        (&sw, at(0.0, 0.25e-3), 0.2 + 0.4 * 0.75),
        (&sw, at(0.0, 1e-3), 0.2),
        (&sw, at(0.0, 5e-3), 0.2),
    ];
    for (law, inputs, expected) in cases {
        let [mu] = law.evaluate(&inputs);
        assert!(
            (mu - expected).abs() < 1e-15,
            "{}: {mu} vs {expected}",
            law.name
        );
    }
}

/// A law's μ must be finite and ≥ 0: a negative value (μ = 0.1 − 10·v turns negative once
/// the block slides faster than 1 cm/s) and a NaN (ln of a negative number) stop the run
/// with the function, the value, the pair and every input named.
#[test]
fn negative_or_nan_friction_from_a_law_stops_the_run_with_its_inputs() {
    for (src, value) in [
        (
            "fn mu(c, p) { p.mu0 - p.k * c.slip_rate }",
            "returned friction = -",
        ),
        (
            "fn mu(c, p) { ln(c.slip_rate - 1.0) }",
            "returned friction = NaN",
        ),
    ] {
        let law = friction_law(src, "mu", &[("mu0", 0.1), ("k", 10.0)]);
        let mut sim = incline_model(40.0, 0.1, law_rule(0.5, law), 0.0);
        let err = (0..100_000)
            .find_map(|_| sim.step().err())
            .expect("the run must stop");
        let msg = err.to_string();
        println!("{msg}");
        assert!(matches!(err, fdem::pipeline::SimError::Law(_)));
        assert!(
            msg.starts_with("friction law 'mu' ") && msg.contains(value),
            "{msg}"
        );
        assert!(
            msg.contains("(body 'block')") && msg.contains("(body 'base')"),
            "{msg}"
        );
        for input in fdem::contact_interaction::FrictionInputs::NAMES {
            assert!(msg.contains(&format!("c.{input} = ")), "{msg}");
        }
    }
}

/// Friction laws are refused at setup, with the place: an unknown function (the defined ones
/// listed), an unknown input (the inputs listed), constructs outside the compiled subset
/// (with their line).
#[test]
fn bad_friction_laws_are_refused_with_the_function_and_line() {
    let compile = |src: &str, name: &str| {
        let ast = rhai::Engine::new_raw().compile(src).unwrap();
        compile_with(&ast, name, &rhai::Map::new(), FRICTION_LAW).unwrap_err()
    };
    let cases = [
        ("fn mu(c, p) { c.mu }", "my_mu", "friction law: no function 'my_mu' in the script; functions defined: mu"),
        ("fn mu(c, p) {\n    c.velocity\n}", "mu", "friction law 'mu': line 2: c.velocity is not an input; inputs: slip_rate, slip, pressure, normal_force, area, time, mu"),
        ("fn mu(c, p) {\n    let m = 0.0;\n    while m < 1.0 { m += 0.1; }\n    m\n}", "mu", "friction law 'mu': line 3: a loop is not supported"),
        ("fn mu(c, p) {\n    let s = `${c.mu}`;\n    0.5\n}", "mu", "friction law 'mu': line 2: a string is not supported"),
        ("fn mu(c, p) {\n    #{ mu: 0.5 }\n}", "mu", "line 2: the result map has key 'mu'; allowed keys: friction"),
        ("fn mu(c) { 0.5 }", "mu", "must take two parameters"),
    ];
    for (src, name, expected) in cases {
        let e = compile(src, name);
        assert!(e.contains(expected), "{e}");
    }
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
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            friction: 0.5,
            damping: 0.3,
            ..Default::default()
        }));
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
        -on_base.z, sim.contact_detection.detector.detections, sim.dt
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
        rate: fdem::joints::law::RateEffects::None,
        dilatancy: fdem::joints::law::Dilatancy::NONE,
    }));
    let joints = joint_every_face(&mut sim, b, law);
    let plate_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: plate_nodes,
        components: [(); 3].map(|_| Some(fdem::loads::TimeFunction::Constant(0.0))),
    });
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            friction: 0.3,
            ..Default::default()
        }));
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
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            friction: 0.7,
            damping: 0.3,
            ..Default::default()
        }));
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
/// 1 and 2 threads (pairs are evaluated in parallel, added to the nodes in pair order): the
/// impact run up to 100 steps after its first broken joint is in contact.
#[test]
fn contact_results_are_bit_identical_for_1_and_2_threads() {
    let run = |threads: usize| {
        common::on_threads(threads, || {
            let (mut sim, _) = impact_model();
            sim.settings.energy_every = 9;
            // Until the first joints have broken and their faces are in contact.
            while sim.step < 3000 && (sim.break_events.is_empty() || sim.contact.last.active == 0) {
                sim.step().unwrap();
            }
            for _ in 0..100 {
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
    assert_eq!(a.contact_detection.pairs, b.contact_detection.pairs);
}

/// How the incline is made: gravity tilted by θ on level bodies, or the bodies rotated by θ
/// about y under vertical gravity.
#[derive(Clone, Copy, Debug)]
enum Tilt {
    Gravity,
    Geometry,
}

/// One incline of the defaults matrix: a block 0.1 m wide and `height` tall meshed with
/// `cells` cells per 0.1 m, on a base meshed at 0.05 m, offset by (13, 7) mm so that no node
/// or face of the block lines up with the base (non-matching meshes, any mesh ratio). Every
/// contact setting is the default (penalty 10·E, tangential penalty = penalty, no damping),
/// only μ is given. Gravity grows from 0 to g over `RAMP` (25 periods of the block's
/// bouncing mode, ~2 ms): the block is placed, not dropped.
struct DefaultsIncline {
    sim: Simulation,
    /// Unit vector down the slope.
    slope: Vec3,
    theta: Real,
    tilt: Tilt,
}

const RAMP: Real = 0.05;

impl DefaultsIncline {
    fn new(theta_deg: Real, mu: Real, cells: usize, height: Real, tilt: Tilt) -> Self {
        let mat = material(Formulation::StVenantKirchhoff, 2500.0, 1.0e8, 0.25);
        let mut sim = Simulation::new();
        let m = sim.add_material(mat);
        let base = box_mesh(
            Vec3::new(-0.1, -0.1, -0.05),
            Vec3::new(0.9, 0.2, 0.0),
            [20, 6, 1],
        );
        let o = Vec3::new(0.013, 0.007, 0.0);
        let nz = ((cells as Real) * height / 0.1).ceil() as usize;
        let block = box_mesh(o, o + Vec3::new(0.1, 0.1, height), [cells, cells, nz]);
        sim.add_body("base", &base, m, Layout::Continuous).unwrap();
        sim.add_body("block", &block, m, Layout::Continuous)
            .unwrap();
        let base_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
        sim.fix(&base_nodes, [true; 3]);
        let th = theta_deg.to_radians();
        let slope = match tilt {
            Tilt::Gravity => Vec3::x(),
            Tilt::Geometry => {
                for b in 0..2 {
                    sim.rotate_body(b, Vec3::y(), th, Vec3::zeros()).unwrap();
                }
                Vec3::new(th.cos(), 0.0, -th.sin())
            }
        };
        sim.contact
            .laws
            .rules
            .push(ContactRule::from(PotentialContact {
                friction: mu,
                ..Default::default()
            }));
        sim.prepare().unwrap();
        DefaultsIncline {
            sim,
            slope,
            theta: th,
            tilt,
        }
    }

    /// Step to `t_end` with the gravity ramp; every 1 ms: (t, block displacement and
    /// velocity down the slope).
    fn run(&mut self, t_end: Real) -> Vec<(Real, Real, Real)> {
        let block: Vec<u32> = self.sim.bodies[1].nodes.clone().map(|n| n as u32).collect();
        let g = match self.tilt {
            Tilt::Gravity => Vec3::new(self.theta.sin(), 0.0, -self.theta.cos()) * 9.81,
            Tilt::Geometry => Vec3::new(0.0, 0.0, -9.81),
        };
        let mut hist = Vec::new();
        let mut next = 0.0;
        while self.sim.time < t_end {
            self.sim.loads.gravity = g * (self.sim.time / RAMP).min(1.0);
            self.sim.step().unwrap();
            if self.sim.time >= next {
                let d = self.sim.mean_displacement(&block).unwrap();
                let v = self.sim.mean_velocity(&block).unwrap();
                hist.push((self.sim.time, d.dot(&self.slope), v.dot(&self.slope)));
                next += 1e-3;
            }
        }
        hist
    }
}

/// Stick at the defaults across the space a user meshes in: block meshes coarser than, equal
/// to, 1.5× and 2× finer than the base, none lined up with it; slopes at 88–90 % of the
/// friction angle's tangent (tan θ/μ = 0.89, 0.88, 0.88, 0.89); μ from 0.2 to 0.8; tilted
/// gravity and tilted geometry. Coulomb: the block does not slide. After the placement ramp
/// it may move by the elastic offset of its friction springs (µm), then must stay: over the
/// last 75 ms it moves less than 0.1 µm (1e-6 of its size; a creep of 1 mm/s, what the
/// issue measured before the kernel fix, would be 75 µm). The energy account closes to 1 %.
#[test]
fn blocks_stick_below_the_friction_angle_at_the_defaults() {
    let cases = [
        (24.0, 0.5, 1, 0.1, Tilt::Gravity),
        (24.0, 0.5, 2, 0.1, Tilt::Geometry),
        (35.0, 0.8, 3, 0.1, Tilt::Gravity),
        (10.0, 0.2, 4, 0.05, Tilt::Geometry),
    ];
    for (theta, mu, cells, height, tilt) in cases {
        let mut inc = DefaultsIncline::new(theta, mu, cells, height, tilt);
        let hist = inc.run(0.15);
        let at = |t: Real| hist.iter().find(|h| h.0 >= t).unwrap().1;
        let offset = at(0.075);
        let creep = hist.last().unwrap().1 - offset;
        let err = inc.sim.energy.relative_balance_error();
        println!(
            "θ {theta}°, μ {mu}, {cells} cells, {tilt:?}: offset {offset:.3e} m, creep over 75 ms {creep:.3e} m, balance error {err:.2e}"
        );
        assert!(offset.abs() < 1e-4, "slid {offset:.3e} m during placement");
        assert!(creep.abs() < 1e-7, "crept {creep:.3e} m");
        assert!(err.abs() < 0.01, "balance error {err:.3e}");
    }
}

/// Slip at the defaults across the same space: a = g(sin θ − μ cos θ) (μ = 0: g sin θ),
/// fitted by least squares to v(t) over 0.07–0.15 s, after the ramp. Tolerance 1 %: the
/// contact compliance and the chattering of a sliding interface average out over the fit
/// (measured within 0.5 %); the balance error within 1 %.
#[test]
fn blocks_slide_at_the_coulomb_acceleration_at_the_defaults() {
    let cases = [
        (25.0, 0.3, 1, 0.1, Tilt::Geometry),
        (40.0, 0.5, 3, 0.1, Tilt::Gravity),
        (30.0, 0.2, 4, 0.05, Tilt::Geometry),
        (15.0, 0.0, 2, 0.1, Tilt::Gravity),
    ];
    for (theta, mu, cells, height, tilt) in cases {
        let mut inc = DefaultsIncline::new(theta, mu, cells, height, tilt);
        let hist = inc.run(0.15);
        let th: Real = Real::to_radians(theta);
        let a_exact = 9.81 * (th.sin() - mu * th.cos());
        let a = slope_after(&hist, 0.07, |h| h.2);
        let err = inc.sim.energy.relative_balance_error();
        println!(
            "θ {theta}°, μ {mu}, {cells} cells, {tilt:?}: a = {a:.5} m/s² vs {a_exact:.5} ({:+.3} %), balance error {err:.2e}",
            100.0 * (a / a_exact - 1.0)
        );
        assert!((a - a_exact).abs() < 0.01 * a_exact);
        assert!(err.abs() < 0.01, "balance error {err:.3e}");
    }
}

/// Stage 4 after fracture: when joints break, the candidate list grows incrementally (the
/// pairs of tets that joined the surface, and the two sides of each broken joint, found at
/// the positions of the last full detection). Oracle: a full detection (NBS over every
/// surface tet) with the same topology at those positions — the lists must be equal as sets
/// of tet pairs, after each of 40 rounds of random breaks in a jointed 6³-cell block whose
/// nodes were moved (less than half the skin) since the last full detection (the mutation
/// "boxes from the current positions" fails it). Rounds that
/// split off a fragment, or bring too many tets to the surface, take the full path, and so
/// does a node moved past half the skin; both paths must be taken. The boxes the incremental
/// path carries over must equal the full detection's.
#[test]
fn incremental_detection_after_fracture_equals_a_full_detection() {
    use fdem::contact_detection::{update_pairs, ContactDetection};
    use fdem::joints::law::{Calibration, Cohesive, Softening};
    use fdem::joints::JointLaw;
    let mut sim = Simulation::new();
    let m = sim.add_material(material(Formulation::StVenantKirchhoff, 2500.0, 1e8, 0.2));
    let block = box_mesh(Vec3::zeros(), Vec3::repeat(0.6), [6, 6, 6]);
    let b = sim.add_body("block", &block, m, Layout::Jointed).unwrap();
    let law = sim.joints.add_law(JointLaw::Cohesive(Cohesive {
        softening: Softening::Munjiza,
        calibration: Calibration::Exact,
        tensile_strength: 0.3e6,
        cohesion: 0.6e6,
        tan_friction: 0.6,
        g_i: 2.0,
        g_ii: 8.0,
        normal_penalty: 1e9,
        tangential_penalty: 1e9,
        residual_friction: 0.5,
        rate: fdem::joints::law::RateEffects::None,
        dilatancy: fdem::joints::law::Dilatancy::NONE,
    }));
    let n_joints = joint_every_face(&mut sim, b, law);
    // A skin of 1.5 cells: tets a cell or two apart (not neighbours) are candidates or not
    // by where their nodes are, so detections at different positions differ.
    let mut cd = ContactDetection::default();
    cd.skin = Some(0.15);
    cd.prepare();
    assert!(update_pairs(
        &mut cd,
        &mut sim.nodes,
        &sim.tets,
        &sim.bodies,
        &sim.joints,
        None
    ));
    let skin = cd.detector.skin;
    let as_tets = |cd: &ContactDetection| {
        let mut v: Vec<[u32; 2]> = (cd.pairs.iter())
            .map(|p| {
                let (a, b) = (cd.surface[p[0] as usize], cd.surface[p[1] as usize]);
                [a.min(b), a.max(b)]
            })
            .collect();
        v.sort_unstable();
        v
    };
    let mut rng = fdem::math::SplitMix64(7);
    let offsets: Vec<Vec3> = (0..sim.nodes.len())
        .map(|_| {
            let v = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3::repeat(0.5);
            v * (0.45 * skin * rng.uniform() / v.norm().max(1e-3))
        })
        .collect();
    let (mut incremental, mut full) = (0, 0);
    for round in 0..40 {
        // Every node is either at its reference place or moved by its own random offset
        // (less than 0.45 × skin), by the round's parity: the positions now and at the last
        // full detection differ by up to 0.9 × skin between neighbours, within half a skin
        // for each node; in round 30 one node goes past half the skin.
        for ((x, x0), r) in sim.nodes.x.iter_mut().zip(&sim.nodes.x0).zip(&offsets) {
            *x = if round % 2 == 1 { x0 + r } else { *x0 };
        }
        if round == 30 {
            sim.nodes.x[0].x += skin;
        }
        // A few random joints, and in round 20 a whole plane of them (a fragment splits
        // off) and in round 25 a third of all joints (too many tets join the surface).
        let breaks = match round {
            25 => n_joints / 3,
            _ => 1 + (rng.next_u64() % 6) as usize,
        };
        let mut now = Vec::new();
        for _ in 0..breaks {
            now.push((rng.next_u64() % n_joints as u64) as u32);
        }
        if round == 20 {
            for j in 0..n_joints {
                let f = sim.joints.faces[j][0];
                if f.iter()
                    .all(|&n| (sim.nodes.x0[n as usize].z - 0.3).abs() < 1e-9)
                {
                    now.push(j as u32);
                }
            }
        }
        // (The joints broken before are not broken again, as in a run.)
        now.retain(|&j| !sim.joints.broken[j as usize]);
        now.iter()
            .for_each(|&j| sim.joints.broken[j as usize] = true);
        let (inc0, full0) = (cd.detector.incremental, cd.detector.detections);
        let surface_before = cd.surface.clone();
        // A rank's skin test over its own surface nodes (here those not divisible by 3),
        // asked every step: its list is kept and, after a refresh from breaks, the nodes
        // that joined are merged into it.
        let owned = |n: u32| !n.is_multiple_of(3);
        fdem::contact_detection::surface_moved_here(&mut cd, &sim.nodes.x, owned);
        cd.broken_since_refresh(now);
        assert!(update_pairs(
            &mut cd,
            &mut sim.nodes,
            &sim.tets,
            &sim.bodies,
            &sim.joints,
            None
        ));
        incremental += cd.detector.incremental - inc0;
        full += cd.detector.detections - full0;
        fdem::contact_detection::surface_moved_here(&mut cd, &sim.nodes.x, owned);
        let own: Vec<u32> = (cd.surface_nodes.iter().copied())
            .filter(|&n| owned(n))
            .collect();
        assert!(
            cd.own_surface_nodes.as_ref() == Some(&own),
            "round {round}: the rank's own surface nodes differ from a listing anew"
        );
        // The oracle: a full detection at the positions of the last full one.
        let mut at_detection = sim.nodes.clone();
        at_detection.x = cd.detector.x_at_detection.clone();
        // (A refresh from scratch keeps the order of the tets that stay on the surface and
        // puts the newcomers after them: given the surface before this round, it must list
        // the surface in the order the refresh from the breaks made.)
        let mut fresh = ContactDetection::default();
        fresh.skin = Some(skin);
        fresh.surface = surface_before;
        fresh.prepare();
        update_pairs(
            &mut fresh,
            &mut at_detection,
            &sim.tets,
            &sim.bodies,
            &sim.joints,
            None,
        );
        // The surface lists made from the breaks alone are those made from scratch (the
        // surface nodes in any order: the skin test only asks whether one moved).
        assert_eq!(fresh.surface, cd.surface, "round {round}: surfaces differ");
        let by_node = |cd: &ContactDetection| {
            let mut v: Vec<(u32, [u64; 3])> = (cd.surface_nodes.iter().copied())
                .zip(
                    cd.detector
                        .surface_positions()
                        .iter()
                        .map(|x| x.map(f64::to_bits).into()),
                )
                .collect();
            v.sort_unstable();
            v
        };
        let mut nodes = (fresh.surface_nodes.clone(), cd.surface_nodes.clone());
        nodes.0.sort_unstable();
        nodes.1.sort_unstable();
        assert_eq!(nodes.0, nodes.1, "round {round}");
        assert_eq!(fresh.broken_seen, cd.broken_seen, "round {round}");
        assert!(
            by_node(&fresh) == by_node(&cd),
            "round {round}: the skin test's positions differ"
        );
        assert!(
            fdem::fracture::same_partition(&fresh.fragment, &cd.fragment),
            "round {round}: the fragments differ"
        );
        let (got, want) = (as_tets(&cd), as_tets(&fresh));
        assert!(
            got == want,
            "round {round}: {} pairs incrementally, {} by a full detection",
            got.len(),
            want.len()
        );
        assert_eq!(cd.origins.len(), cd.pairs.len());
        // The two sides of every broken joint share a face, so they are a candidate pair
        // (an oracle that does not go through the detection's own lookup of broken joints).
        for j in (0..n_joints).filter(|&j| sim.joints.broken[j]) {
            let [a, b] = sim.joints.tets[j];
            assert!(
                got.binary_search(&[a.min(b), a.max(b)]).is_ok(),
                "round {round}: the sides of broken joint {j} are no pair"
            );
        }
        // The incremental path keeps the boxes of the tets that stayed on the surface and
        // computes the joined tets' only: bit for bit the boxes of a full detection.
        assert!(cd.boxes == fresh.boxes, "round {round}: boxes differ");
    }
    println!(
        "{incremental} incremental, {full} full detections; {} pairs, {} surface tets at the end",
        cd.pairs.len(),
        cd.surface.len()
    );
    assert!(incremental >= 30, "the incremental path must be taken");
    assert_eq!(
        cd.refreshes_from_breaks, 40,
        "every refresh from the breaks alone"
    );
    assert!(full >= 3, "rounds 20, 25 and 30 must detect in full");
}

/// One rank holding the whole model, whose step answered the skin test at its first
/// meeting (as a decomposed step does, before stage 4 refreshes the surface).
struct AnsweredSkinTest {
    computes: Vec<bool>,
    owned: Vec<bool>,
    answer: bool,
}

impl fdem::contact_detection::PairExchange for AnsweredSkinTest {
    fn computes(&self) -> &[bool] {
        &self.computes
    }
    fn make_every_node_current(&mut self, _: &mut fdem::state::Nodes) {}
    fn make_near_current(&mut self, nodes: &mut fdem::state::Nodes, _: Real) -> Vec<bool> {
        vec![true; nodes.len()]
    }
    fn largest(&mut self, value: Real) -> Real {
        value
    }
    fn designates(&self, _: usize) -> bool {
        true
    }
    fn sum_over_ranks(&mut self, _: &mut fdem::math::ExactSum) {}
    fn any_rank(&mut self, mine: bool) -> bool {
        mine
    }
    fn skin_test_answered(&self) -> Option<bool> {
        Some(self.answer)
    }
    fn owned_chunks(&self) -> (&[bool], usize) {
        (&self.owned, 1)
    }
}

/// A tet joins the surface when a joint breaks; its nodes were inside the body and were not
/// skin-tested. If one moved more than half the skin since the last detection, the joined
/// tet's box at that detection no longer holds it, so the incremental detection must give
/// way to a full one. One process tests the joined nodes with the refreshed surface; a rank
/// answered the skin test at the step's first meeting, before the refresh, so it must test
/// them apart. Both must detect in full, with the same pairs (found in review: ranks did
/// the incremental detection).
#[test]
fn a_joined_tet_that_moved_past_the_skin_forces_a_full_detection_on_ranks_too() {
    use fdem::contact_detection::{update_pairs, ContactDetection};
    let mut sim = Simulation::new();
    let m = sim.add_material(material(Formulation::StVenantKirchhoff, 2500.0, 1e8, 0.2));
    let b = sim
        .add_body(
            "block",
            &box_mesh(Vec3::zeros(), Vec3::repeat(0.4), [4, 4, 4]),
            m,
            Layout::Jointed,
        )
        .unwrap();
    let law = sim.joints.add_law(fdem::joints::JointLaw::Tied {
        normal_penalty: 1e9,
        tangential_penalty: 1e9,
    });
    joint_every_face(&mut sim, b, law);
    let mut runs = Vec::new();
    for on_ranks in [false, true] {
        let mut nodes = sim.nodes.clone();
        let mut joints = sim.joints.clone();
        let mut cd = ContactDetection::default();
        cd.skin = Some(0.02);
        cd.prepare();
        update_pairs(&mut cd, &mut nodes, &sim.tets, &sim.bodies, &joints, None);
        // An interior tet (no free face) and one of its joints.
        let inner = (0..sim.tets.len() as u32)
            .find(|e| !cd.surface.contains(e))
            .unwrap();
        let j = (0..joints.len())
            .find(|&j| joints.tets[j].contains(&inner))
            .unwrap();
        // Its node moves 0.6 skin; no surface node moves.
        let n = sim.tets.nodes[inner as usize][0] as usize;
        assert!(!cd.surface_nodes.contains(&(n as u32)));
        nodes.x[n].x += 0.6 * 0.02;
        joints.broken[j] = true;
        cd.broken_since_refresh([j as u32]);
        let full = cd.detector.detections;
        let mut rank = AnsweredSkinTest {
            computes: vec![true; sim.tets.len()],
            owned: vec![true; nodes.len()],
            answer: false,
        };
        let ranks: Option<&mut dyn fdem::contact_detection::PairExchange> =
            if on_ranks { Some(&mut rank) } else { None };
        assert!(update_pairs(
            &mut cd,
            &mut nodes,
            &sim.tets,
            &sim.bodies,
            &joints,
            ranks
        ));
        assert!(cd.surface.contains(&inner), "the tet joined the surface");
        assert_eq!(cd.detector.detections, full + 1, "on ranks: {on_ranks}");
        runs.push(cd.pairs.clone());
    }
    assert_eq!(runs[0], runs[1]);
}

/// Issue 14: the kernel agrees with its oracle (the kernel before the speed work,
/// `contact_interaction::oracle`) to 1e-12 of each pair's largest force on every pair that
/// touches in the settled fragmented stack of `fdem bench` (non-matching blocks at rest under
/// gravity: the thin overlaps of resting contact), and the bench reports the figures the
/// issue names. Both kernels integrate the same clipped polygons and differ in rounding only
/// (≈ 4e-15 measured), so 1e-12 leaves room for a different machine's libm, not for a
/// different integration. Their energies differ by the rounding of the cones' heights (a
/// facet's height over its apex from a vertex there, from the centroid in the oracle), about
/// ulp(H)/d of the energy for overlaps d ≈ 1e-9 m deep under elements of H = 0.1 m: 4e-9
/// measured, bound 1e-7.
///
/// The oracle shares the clipping and the cones, so the pairs are also evaluated with
/// contactor and target swapped, which the exact forces and energy do not see: the forces
/// agree within 1e-7 of the largest pair force (4e-9 measured; 0.27 when all regions shared
/// one apex, docs/theory/contact.md), the energies within 1e-6 of their sum (1e-8 measured;
/// 1349 before), and no more than one pair in a thousand has E < 0 (the exact energy never
/// is; a pair overlapping by a rounding error, 1e-14 m, can be: 2 of 4 087 measured, 595 of
/// 4 123 before), none by more than 1e-12 of the largest pair energy (rounding: at 20 000
/// tets, 41 of 35 065 pairs, the lowest at −1.9e-23 of the largest).
#[test]
fn the_kernel_agrees_with_its_oracle_on_a_settled_stack() {
    let out = common::fdem()
        .args([
            "bench",
            "--case",
            "fragmented",
            "--tets",
            "3000",
            "--steps",
            "5",
            "--threads",
            "1",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let number = |key: &str| {
        json[key]
            .as_f64()
            .unwrap_or_else(|| panic!("the bench reports no {key}: {json}"))
    };
    let pairs = number("kernel_pairs");
    let deviation = number("kernel_oracle_deviation");
    let energy = number("kernel_oracle_energy_deviation");
    println!("{pairs} touching pairs: forces within {deviation:e}, energies {energy:e}");
    assert!(pairs > 500.0, "too few touching pairs to check: {pairs}");
    assert!(deviation <= 1e-12, "forces differ by {deviation:e}");
    assert!(energy <= 1e-7, "energies differ by {energy:e} of their sum");
    let swap = number("kernel_swap_deviation");
    let swap_energy = number("kernel_swap_energy_deviation");
    let negative = number("kernel_negative_energy_pairs");
    println!("swapped: forces within {swap:e}, energies {swap_energy:e}; {negative} pairs E < 0");
    assert!(
        swap <= 1e-7,
        "swapping contactor and target moves forces by {swap:e}"
    );
    assert!(
        swap_energy <= 1e-6,
        "swapping contactor and target moves energies by {swap_energy:e} of their sum"
    );
    assert!(
        negative <= pairs / 1000.0,
        "{negative} of {pairs} pairs have a negative energy"
    );
    let lowest = number("kernel_lowest_energy_ratio");
    assert!(
        lowest >= -1e-12,
        "a pair's energy is {lowest:e} of the largest pair's: more than rounding"
    );
    for key in [
        "kernel_ns_per_pair",
        "contact_over_elements",
        "touching_pairs",
        "contact_bytes_per_candidate_pair",
    ] {
        assert!(number(key) > 0.0, "{key}");
    }
}

/// A prepared model for the time-step tests below: `rock` (a 0.1 m cube, E = 50 GPa) and/or
/// `pad` (40 × 40 × 2 mm, elements 1 mm thick, E = 1 GPa), far apart; contact laws: rock–rock
/// 500 GPa (the default rule), pad–pad `pad_pad`, pad–rock `pad_rock`.
fn rock_and_pad(with_rock: bool, with_pad: bool, pad_pad: Real, pad_rock: Real) -> Simulation {
    use fdem::contact_interaction::ContactLaw;
    let rule = |materials: Option<(u32, u32)>, p: Real| ContactRule {
        materials,
        law: ContactLaw::Potential(PotentialContact {
            penalty: Some(p),
            ..Default::default()
        }),
    };
    let mut sim = Simulation::new();
    let r = sim.add_material(material(Formulation::NeoHookean, 2650.0, 50.0e9, 0.25));
    let s = sim.add_material(material(Formulation::NeoHookean, 1000.0, 1.0e9, 0.3));
    if with_rock {
        let m = box_mesh(Vec3::zeros(), Vec3::new(0.1, 0.1, 0.1), [5, 5, 5]);
        sim.add_body("rock", &m, r, Layout::Continuous).unwrap();
    }
    if with_pad {
        let m = box_mesh(
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.54, 0.04, 0.002),
            [5, 5, 2],
        );
        sim.add_body("pad", &m, s, Layout::Continuous).unwrap();
    }
    sim.contact.laws.rules.push(rule(None, 500.0e9));
    sim.contact.laws.rules.push(rule(Some((s, s)), pad_pad));
    sim.contact.laws.rules.push(rule(Some((r, s)), pad_rock));
    sim.prepare().unwrap();
    sim
}

/// The critical step's contact bound follows the penalty each tet can meet: a soft pad
/// (E = 1 GPa, penalty 10·E against everything) beside rock (E = 50 GPa, penalty 10·E rock on
/// rock) must not take the rock's penalty into its own bound. Reference: the bound is
/// per tet, 2·k/m with k ∝ p (`contact_nodal_stiffness`), so
/// - the rock and the pad together have the smaller of the two bodies' steps, each alone
///   with the penalty of its own pairs (to 1e-12: the same arithmetic);
/// - with the pad–rock penalty raised to the rock's, the pad's nodes do feel 500 GPa and the
///   step must fall to that of the pad alone at 500 GPa (50× stiffer: ~√50 shorter).
///
/// Until 2026-11-30 every tet took the model's largest penalty, so the first case gave the
/// last case's step (3.2× too short for the Brazilian disc with pads).
#[test]
fn the_contact_time_step_follows_each_materials_penalty() {
    let critical = |with_rock: bool, with_pad: bool, pad_pad: Real, pad_rock: Real| {
        rock_and_pad(with_rock, with_pad, pad_pad, pad_rock)
            .stable_time_step()
            .unwrap()
            .critical
    };
    let rock_alone = critical(true, false, 10.0e9, 10.0e9);
    let pad_alone = critical(false, true, 10.0e9, 10.0e9);
    let both = critical(true, true, 10.0e9, 10.0e9);
    assert!(
        (both - rock_alone.min(pad_alone)).abs() <= 1e-12 * both,
        "rock {rock_alone:e}, pad {pad_alone:e}, both {both:e}"
    );
    let pad_stiff = critical(false, true, 500.0e9, 500.0e9);
    let both_stiff = critical(true, true, 10.0e9, 500.0e9);
    assert!(
        (both_stiff - rock_alone.min(pad_stiff)).abs() <= 1e-12 * both_stiff,
        "rock {rock_alone:e}, stiff pad {pad_stiff:e}, both {both_stiff:e}"
    );
    assert!(
        both > 2.0 * both_stiff,
        "the pad's own penalty must lengthen the step: {both:e} against {both_stiff:e}"
    );
}

/// The time-step line names where the contact bound comes from: a thin, light pad (1 mm
/// elements) beside a rock cube bounds the step, at the pad–rock penalty when that is the
/// larger (500 GPa), at its own 10 GPa otherwise, and the line says so (body, partner
/// material, penalty, and the step without contact).
#[test]
fn the_time_step_line_names_the_tet_and_material_pair_of_the_contact_bound() {
    let info = |pad_rock: Real| {
        rock_and_pad(true, true, 10.0e9, pad_rock)
            .stable_time_step()
            .unwrap()
    };
    let stiff = info(500.0e9);
    let by = stiff.contact_by.clone().expect("contact lowers the step");
    assert_eq!(
        (by.body.as_str(), by.partner_body.as_str()),
        ("pad", "rock"),
        "{stiff}"
    );
    assert_eq!(by.penalty, 500.0e9);
    assert!(by.without > stiff.critical, "{stiff}");
    let line = stiff.to_string();
    assert!(
        line.contains("of body 'pad' (penalty 5.000e11 Pa against the material of body 'rock')"),
        "{line}"
    );
    // With its own 10 GPa against everything the thin, light pad still bounds the step, now
    // at 10 GPa (pad–pad and pad–rock tie: the first material in order, the rock's, is named).
    let soft = info(10.0e9);
    let by = soft.contact_by.clone().expect("contact lowers the step");
    assert_eq!(
        (by.body.as_str(), by.partner_body.as_str()),
        ("pad", "rock"),
        "{soft}"
    );
    assert_eq!(by.penalty, 10.0e9);
    assert!(soft.critical > 2.0 * stiff.critical, "{soft} / {stiff}");
}

/// Joints of law `law` on every internal face of body `b` (jointed); returns how many.
fn joint_every_face(sim: &mut Simulation, b: usize, law: u32) -> usize {
    let body = sim.bodies[b].clone();
    let (tn, x0) = (sim.tets.nodes.clone(), sim.nodes.x0.clone());
    sim.joints
        .insert_in_body(&body, &tn, &x0, law, |_| true)
        .unwrap()
}
