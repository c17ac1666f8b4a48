//! Shaking a model with earthquake records (issue 11): the two ways of `Simulation::shake`
//! (prescribed base motion, relative frame) against each other and against oracles they
//! cannot fake: the SDOF response of the same period and damping, Newmark's rigid-plastic
//! sliding block, and the ground's own double integral.

mod common;

use common::material;
use fdem::contact_interaction::{ContactRule, PotentialContact};
use fdem::joints::JointLaw;
use fdem::loads::ground_motion::{sdof_peak, Method, ReadOptions};
use fdem::loads::{GroundMotion, GroundRecord, ShakingKind};
use fdem::material::Formulation;
use fdem::math::{Real, Vec3};
use fdem::mesh::{box_mesh, Mesh};
use fdem::{Layout, Simulation};
use std::sync::Arc;

const G: Real = 9.80665;

fn data(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/ground_motion")
        .join(name)
}

/// El Centro 1940 N–S (IELC180) in m/s² between `start` and `end` [s] of the record,
/// baseline-corrected (the ground ends at rest), scaled by `scale`.
fn el_centro(start: Real, end: Real, scale: Real) -> Arc<GroundRecord> {
    let gm = GroundMotion::read(
        &data("IELC180.AT2"),
        &ReadOptions {
            start: Some(start),
            end: Some(end),
            baseline: true,
            scale: Some(scale),
            ..Default::default()
        },
    )
    .unwrap();
    Arc::new(GroundRecord::new(gm))
}

/// The tets of a box grid whose centroid passes `keep`, with the unused nodes dropped.
fn carve(full: &Mesh, keep: impl Fn(Vec3) -> bool) -> Mesh {
    let tets: Vec<[u32; 4]> = (0..full.tets.len())
        .filter(|&e| keep(full.tet_centroid(e)))
        .map(|e| full.tets[e])
        .collect();
    let mut new_id = vec![u32::MAX; full.nodes.len()];
    let mut nodes = Vec::new();
    let tets = tets
        .iter()
        .map(|t| {
            t.map(|n| {
                if new_id[n as usize] == u32::MAX {
                    new_id[n as usize] = nodes.len() as u32;
                    nodes.push(full.nodes[n as usize]);
                }
                new_id[n as usize]
            })
        })
        .collect();
    Mesh::new(nodes, tets)
}

/// A mass on a slender column: a light 0.1 × 0.1 × 1 m column (ρ = 200 kg/m³, 2 kg) under
/// a dense 0.3 × 0.3 × 0.2 m head (ρ = 2000 kg/m³, 36 kg), small-strain elastic, E = 1.2e8
/// Pa, glued by tied joints (penalty 10·E, the default), 168 tets: the head carries 95 % of the mass,
/// so the first sway mode (near 0.4 s) is the SDOF of the head on the column's bending
/// stiffness, well apart from the next (the head's rocking, the column's second bending
/// mode). `plane`: every node is held in y, a plane frame (the one-cell column's Kuhn tets
/// make its x and y sway couple and beat in 3-D). Returns the model, its base nodes
/// (z = 0) and its head nodes.
fn mass_on_column(plane: bool) -> (Simulation, Vec<u32>, Vec<u32>) {
    let full = box_mesh(
        Vec3::new(-0.15, -0.15, 0.0),
        Vec3::new(0.15, 0.15, 1.0),
        [3, 3, 10],
    );
    let column = carve(&full, |c| c.x.abs() < 0.05 && c.y.abs() < 0.05);
    let head = box_mesh(
        Vec3::new(-0.15, -0.15, 1.0),
        Vec3::new(0.15, 0.15, 1.2),
        [3, 3, 2],
    );
    let e = 1.2e8;
    let mut sim = Simulation::new();
    let light = sim.add_material(material(Formulation::SmallStrain, 200.0, e, 0.25));
    let dense = sim.add_material(material(Formulation::SmallStrain, 2000.0, e, 0.25));
    sim.add_body("column", &column, light, Layout::Continuous)
        .unwrap();
    sim.add_body("head", &head, dense, Layout::Continuous)
        .unwrap();
    let tied = sim.joints.add_law(JointLaw::Tied {
        normal_penalty: 10.0 * e,
        tangential_penalty: 10.0 * e,
    });
    let (b0, b1, x0) = (
        sim.bodies[0].clone(),
        sim.bodies[1].clone(),
        sim.nodes.x0.clone(),
    );
    assert_eq!(sim.joints.insert_between(&[&b0, &b1], &x0, tied, 1e-9), 2);
    let base: Vec<u32> = (0..sim.nodes.len() as u32)
        .filter(|&n| sim.nodes.x0[n as usize].z < 1e-9)
        .collect();
    let head: Vec<u32> = sim.bodies[1].nodes.clone().map(|n| n as u32).collect();
    if plane {
        let all: Vec<u32> = (0..sim.nodes.len() as u32).collect();
        sim.fix(&all, [false, true, false]);
    }
    (sim, base, head)
}

/// Period of the first sway mode [s]: the head is released from a lateral push (a short
/// base pulse) and swings freely, undamped; the mean of the zero-crossing intervals of its
/// x displacement over 6 half periods.
fn sway_period() -> Real {
    let (mut sim, base, head) = mass_on_column(true);
    sim.fix(&base, [true; 3]);
    // A push of the head: mostly the first mode.
    for &n in &head {
        sim.nodes.v[n as usize].x = 0.01;
    }
    let mut crossings = Vec::new();
    let mut prev = 0.0;
    while crossings.len() < 8 && sim.time < 5.0 {
        sim.step().unwrap();
        let d = sim.mean_displacement(&head).unwrap().x;
        if sim.step > 10 && prev * d < 0.0 {
            // Linear interpolation of the crossing time.
            crossings.push(sim.time - sim.dt * d / (d - prev));
        }
        prev = d;
    }
    assert!(crossings.len() == 8, "no free sway");
    (crossings[7] - crossings[1]) / 3.0
}

/// The head's x displacement relative to the ground at every step of `duration` [s] under
/// `records` (x, y, z), shaken either way, with mass damping α [1/s] and gravity on or off.
fn shaken_head(
    records: [Option<Arc<GroundRecord>>; 3],
    relative: bool,
    alpha: Real,
    gravity: bool,
    plane: bool,
    duration: Real,
) -> (Vec<Vec3>, Simulation) {
    let (mut sim, base, head) = mass_on_column(plane);
    sim.settings.mass_damping = alpha;
    if gravity {
        sim.loads.gravity = Vec3::new(0.0, 0.0, -G);
    }
    if relative {
        sim.fix(&base, [true; 3]);
        sim.shake(records, None, ShakingKind::Relative).unwrap();
    } else {
        sim.shake(records, None, ShakingKind::Base(base.clone()))
            .unwrap();
    }
    let mut out = Vec::new();
    while sim.time < duration {
        sim.step().unwrap();
        let ground = if relative {
            Vec3::zeros()
        } else {
            sim.loads.shaking[0].displacement
        };
        out.push(sim.mean_displacement(&head).unwrap() - ground);
    }
    (out, sim)
}

/// Reference: the linear SDOF oscillator ü + 2ζωu̇ + ω²u = −a_g(t) of the structure's own
/// first-mode period (measured by free vibration of the same mesh) and damping ratio ζ = 5 %
/// (mass-proportional damping α = 2ζω gives exactly ζ in that mode), integrated exactly for
/// the piecewise-linear record (Nigam–Jennings, `sdof_peak`). The head's peak displacement
/// relative to the shaken base must equal it within 5 % (the issue's tolerance): what the
/// SDOF leaves out is the other modes' share (the head's rocking and the column's second
/// mode, whose periods are several times shorter and whose participation at the head is
/// small), the column's 5 % of the mass and the head's rotation: together −1.5 % measured
/// (T₁ = 0.377 s).
#[test]
fn a_mass_on_a_column_peaks_as_its_sdof_oracle() {
    let period = sway_period();
    let zeta = 0.05;
    let alpha = 2.0 * zeta * 2.0 * std::f64::consts::PI / period;
    let eq = el_centro(1.0, 7.0, 1.0);
    let (hist, sim) = shaken_head(
        [Some(eq.clone()), None, None],
        false,
        alpha,
        false,
        true,
        7.0,
    );
    let peak_fe = hist.iter().map(|d| d.x.abs()).fold(0.0, Real::max);
    let peak_sdof = sdof_peak(&eq.record.acc, eq.record.dt, period, zeta, Method::Exact);
    let err = peak_fe / peak_sdof - 1.0;
    let balance = sim.energy.relative_balance_error();
    println!(
        "T₁ = {period:.4} s, dt = {:.3e} s: FE peak {peak_fe:.4e} m, SDOF {peak_sdof:.4e} m ({:+.2} %), balance {balance:.1e}",
        sim.dt,
        100.0 * err
    );
    assert!(
        (0.3..0.6).contains(&period),
        "period {period} s off the design"
    );
    assert!(err.abs() < 0.05, "FE {peak_fe:.4e} vs SDOF {peak_sdof:.4e}");
    assert!(balance.abs() < 1e-3, "balance error {balance:.2e}");
}

/// Reference: the two ways are the same equations. Under a base motion every node's
/// absolute motion is the ground's plus its motion relative to the base; the elastic
/// forces depend only on the relative one, and mass damping acts on velocities relative
/// to the ground; the ground is integrated with the same step as the nodes. So the
/// relative response is the same as the relative frame's with −m·a_g, step by step, up
/// to round-off (the absolute positions carry the ground's metres beside the response's
/// millimetres). Checked with all three components (El Centro along x, the same record
/// reversed and scaled along y, and scaled along z), gravity on and 5 % damping; the
/// issue's tolerance is 1 %; measured 6e-13 of the peak, asserted at 1e-6.
#[test]
fn base_motion_and_relative_frame_give_the_same_relative_response() {
    let x = el_centro(1.0, 4.0, 1.0);
    let y = el_centro(3.0, 6.0, -0.7);
    let z = el_centro(1.5, 4.5, 0.4);
    let records = [Some(x), Some(y), Some(z)];
    let alpha = 1.2;
    let (a, sim_a) = shaken_head(records.clone(), false, alpha, true, false, 3.0);
    let (b, sim_b) = shaken_head(records, true, alpha, true, false, 3.0);
    assert_eq!(a.len(), b.len());
    let peak = b.iter().map(|d| d.norm()).fold(0.0, Real::max);
    let diff = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, Real::max);
    let (ea, eb) = (&sim_a.energy, &sim_b.energy);
    println!(
        "peak relative head displacement {peak:.4e} m; largest difference {diff:.3e} m ({:.1e} of the peak); balance: base motion {:.1e} (reaction work {:.4e} J), relative frame {:.1e} (ground work {:.4e} J)",
        diff / peak,
        ea.relative_balance_error(),
        ea.reaction_work,
        eb.relative_balance_error(),
        eb.ground_work
    );
    assert!(peak > 1e-3, "the head barely moved: {peak:.3e} m");
    assert!(diff < 1e-6 * peak, "ways differ by {diff:.3e} m");
    assert!(eb.ground_work != 0.0 && ea.ground_work == 0.0);
    for e in [ea, eb] {
        assert!(
            e.relative_balance_error().abs() < 1e-3,
            "balance error {:.2e}",
            e.relative_balance_error()
        );
    }
}

/// Reference: the base follows the record's double integral. A base shaken by El Centro
/// (2 s of it, baseline-corrected, resampled at the simulation step so that the samples
/// fall on steps) is where the exact double integral of the piecewise-linear record puts
/// the ground (integrated here independently, a cubic per sample step) at every step,
/// within the midpoint rule's dt²·max|a|/12; after the record it stays (no drift: the
/// ground's velocity is exact at the half steps, and zero after a baseline-corrected
/// record), to 1e-12 m.
#[test]
fn a_base_follows_the_double_integral_of_its_record() {
    let (mut sim, base, _) = mass_on_column(false);
    sim.prepare().unwrap();
    let eq = el_centro(1.0, 3.0, 1.0);
    let at_step = eq.record.resampled(sim.dt).unwrap().baseline_corrected();
    let (dt, a) = (at_step.dt, &at_step.acc);
    let (mut u, mut v, mut u_exact) = (0.0, 0.0, vec![0.0]);
    for k in 0..a.len() {
        let a1 = a.get(k + 1).copied().unwrap_or(0.0);
        u += v * dt + (a[k] / 3.0 + a1 / 6.0) * dt * dt;
        v += 0.5 * (a[k] + a1) * dt;
        u_exact.push(u);
    }
    let bound = dt * dt * a.iter().fold(0.0, |m: Real, x| m.max(x.abs())) / 12.0 + 1e-12;
    let record = Arc::new(GroundRecord::new(at_step.clone()));
    sim.shake(
        [None, Some(record), None],
        None,
        ShakingKind::Base(base.clone()),
    )
    .unwrap();
    let mut worst: Real = 0.0;
    let mut after = Vec::new();
    for u_k in &u_exact[1..] {
        sim.step().unwrap();
        let u = sim.mean_displacement(&base).unwrap();
        assert!(u.x == 0.0 && u.z == 0.0);
        worst = worst.max((u.y - u_k).abs());
    }
    for _ in 0..2000 {
        sim.step().unwrap();
        after.push(sim.mean_displacement(&base).unwrap().y);
    }
    let pgd = at_step.pgd().value.abs();
    let drift = after.last().unwrap() - after[0];
    println!("PGD {pgd:.4e} m; largest difference {worst:.2e} m (bound {bound:.2e}); drift over 2000 steps after the record {drift:.2e} m");
    assert!(worst <= bound, "{worst:.3e} > {bound:.3e}");
    assert!(drift.abs() < 1e-12, "drift {drift:.3e} m");
}

/// Newmark (1965): a rigid block on a horizontal base with friction μ, under ground
/// acceleration a_g(t), slides relative to the base with ü = −a_g − μg·sign(u̇) and sticks
/// when u̇ returns to zero while |a_g| ≤ μg. Integrated here independently (explicit, 1e-5 s
/// steps on the piecewise-linear record).
fn newmark_slip(eq: &GroundMotion, mu: Real, dt: Real, every: Real) -> (Real, Vec<(Real, Real)>) {
    let (mut u, mut v) = (0.0, 0.0);
    let n = (eq.duration() / dt).ceil() as usize + 1;
    let stride = (every / dt).round() as usize;
    let mut hist = Vec::new();
    let fr = mu * G;
    for k in 0..n {
        let ag = eq.at(k as Real * dt);
        if v == 0.0 {
            // Stuck until the ground's pull passes friction; then it slides opposite to a_g.
            if ag.abs() > fr {
                v = (-ag + fr * ag.signum()) * dt;
            }
        } else {
            let v_new = v + (-ag - fr * v.signum()) * dt;
            // Friction stops the slip; it cannot reverse it within a step.
            v = if v_new * v <= 0.0 { 0.0 } else { v_new };
        }
        u += v * dt;
        if (k + 1) % stride == 0 {
            hist.push(((k + 1) as Real * dt, u));
        }
    }
    (u, hist)
}

/// A block on a base slab, both elastic (ρ = 2000 kg/m³, ν = 0.25), touching with Coulomb
/// friction μ at the contact defaults, settled under gravity (ramped over 50 ms, damped α,
/// until `settle`); damping off. Returns the model, the block's nodes and its mean
/// displacement after settling.
struct BlockOnSlab {
    e: Real,
    mu: Real,
    slab: (Vec3, Vec3, [usize; 3]),
    block: (Vec3, Vec3, [usize; 3]),
    alpha: Real,
    settle: Real,
}

impl BlockOnSlab {
    fn build(&self) -> (Simulation, Vec<u32>, Vec3) {
        let mat = material(Formulation::StVenantKirchhoff, 2000.0, self.e, 0.25);
        let mut sim = Simulation::new();
        let m = sim.add_material(mat);
        let (a, b, d) = self.slab;
        sim.add_body("slab", &box_mesh(a, b, d), m, Layout::Continuous)
            .unwrap();
        let (a, b, d) = self.block;
        sim.add_body("block", &box_mesh(a, b, d), m, Layout::Continuous)
            .unwrap();
        let slab_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
        let block_nodes: Vec<u32> = sim.bodies[1].nodes.clone().map(|n| n as u32).collect();
        sim.fix(&slab_nodes, [true; 3]);
        sim.contact
            .laws
            .rules
            .push(ContactRule::from(PotentialContact {
                friction: self.mu,
                ..Default::default()
            }));
        sim.settings.mass_damping = self.alpha;
        while sim.time < self.settle {
            sim.loads.gravity = Vec3::new(0.0, 0.0, -G) * (sim.time / 0.05).min(1.0);
            sim.step().unwrap();
        }
        sim.settings.mass_damping = 0.0;
        let settled = sim.mean_displacement(&block_nodes).unwrap();
        (sim, block_nodes, settled)
    }
}

/// A block of 0.4 × 0.4 × 0.2 m (E = 2e6 Pa) on a slab, settled for 0.2 s.
fn block_on_slab(mu: Real) -> (Simulation, Vec<u32>, Vec3) {
    BlockOnSlab {
        e: 2.0e6,
        mu,
        slab: (
            Vec3::new(-0.6, -0.3, -0.1),
            Vec3::new(0.6, 0.3, 0.0),
            [6, 3, 1],
        ),
        block: (
            Vec3::new(-0.2, -0.2, 0.0),
            Vec3::new(0.2, 0.2, 0.2),
            [2, 2, 1],
        ),
        alpha: 200.0,
        settle: 0.2,
    }
    .build()
}

/// Reference: Newmark's rigid-plastic sliding block above, under the first 8.5 s of El
/// Centro N–S (PGA 0.313 g; the strong shaking, ending while the block sticks) with
/// μ = 0.05 (PGA/μg = 6.3, the issue's ≥ 3; a μ where the permanent slip, 6 cm, is not a
/// small difference of slips back and forth). The block (0.4 × 0.4 × 0.2 m, elastic) rests
/// on a shaken base slab through contact and Coulomb friction alone, at the contact
/// defaults. Its permanent slip must equal Newmark's within 10 % (the issue's tolerance),
/// and its slip history must follow Newmark's within 5 % of the largest slip: the block is
/// not rigid (its shear mode, ~25 Hz, is inside the record's band and shifts when slips
/// start and stop: with E 10× and 40× stiffer the error falls from 20 % to 15 % and 14 % on a
/// 12 s window that ends in a large slip), and the penalty contact lets friction build up
/// over the friction springs' elastic offset (µm). Measured: −3.1 % permanent, history
/// within 3.5 % of the largest slip (8.7 cm).
#[test]
fn a_block_on_a_shaken_base_slides_as_newmarks_block() {
    let mu = 0.05;
    let eq = el_centro(0.0, 8.5, 1.0);
    let (reference, nm_hist) = newmark_slip(&eq.record, mu, 1e-5, 0.01);
    let (mut sim, block_nodes, settled) = block_on_slab(mu);
    let slab_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.shake(
        [Some(eq.clone()), None, None],
        None,
        ShakingKind::Base(slab_nodes),
    )
    .unwrap();
    let t0 = sim.time;
    let slip_now = |sim: &Simulation| {
        sim.mean_displacement(&block_nodes).unwrap().x
            - settled.x
            - sim.loads.shaking[0].displacement.x
    };
    let (mut worst, mut largest): (Real, Real) = (0.0, 0.0);
    for &(t, u) in &nm_hist {
        while sim.time - t0 < t {
            sim.step().unwrap();
        }
        worst = worst.max((slip_now(&sim) - u).abs());
        largest = largest.max(u.abs());
    }
    while sim.time - t0 < eq.record.duration() + 1.0 {
        sim.step().unwrap();
    }
    let slip = slip_now(&sim);
    let err = slip / reference - 1.0;
    println!(
        "slip {slip:.4e} m, Newmark {reference:.4e} m ({:+.1} %); history: largest slip {largest:.3e} m, largest difference {worst:.3e} m ({:.1} %); {} steps, balance {:.1e}",
        100.0 * err,
        100.0 * worst / largest,
        sim.step,
        sim.energy.relative_balance_error()
    );
    assert!(reference.abs() > 0.03, "the reference barely slides");
    assert!(err.abs() < 0.10, "slip {slip:.4e} vs {reference:.4e}");
    assert!(worst < 0.05 * largest, "history off by {worst:.3e} m");
    assert!(sim.energy.relative_balance_error().abs() < 1e-3);
}

/// Reference: the Rust API above. The script functions shake a model the same way (the base
/// ends where the record's double integral puts it, the relative frame books its work as
/// `ground_work`), and bad calls are refused naming what is wrong.
#[test]
fn script_functions_shake_and_refuse_bad_calls() {
    let script = data("shake_test.rhai"); // not written: run_source runs text as if it were there
    let text = r#"
let eq = ground_motion("IELC180.AT2", #{ start: 2.0, end: 2.5, baseline: true });
let sim = simulation(#{ name: "shake" });
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.3] }).mesh(#{ divisions: [1, 1, 3] }), m);
let base = b.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] }));
sim.shake_base(base, #{ x: eq });
sim.run(#{ max_time: 0.6 });
let g = sim.ground();
expect_near("base follows the ground", sim.displacement(base)[0], g.displacement[0], 1e-9);
// The record's own integration (at its dt) and the model's (at its dt) of the same
// piecewise-linear record differ by dt_rec²·(a₀ − a_N)/6 in displacement, not in velocity.
let offset = eq.dt * eq.dt * abs(eq.at(0.0)) / 6.0;
expect_within("record's double integral", abs(g.displacement[0] - eq.displacement_at(0.6)), 0.0, 1.01 * offset);
expect_within("at rest after the record", abs(g.velocity[0]), 0.0, 1e-12);
expect_near("end", g.end, eq.duration, 1e-9);
let sim2 = simulation(#{ name: "shake2" });
let b2 = sim2.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.3] }).mesh(#{ divisions: [1, 1, 3] }), m);
sim2.fix(b2.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] })));
sim2.shake_relative(#{ y: eq, start: 0.1 });
sim2.run(#{ max_time: 0.6 });
let e = sim2.energy();
expect_within("ground work booked", abs(e.ground_work), 1e-12, 1.0e9);
expect_within("balance", abs(e.relative_error), 0.0, 1e-6);
"#;
    common::run_source_in_temp("shaking_script", &script, text).unwrap();
    let head = r#"
let eq = ground_motion("IELC180.AT2");
let sim = simulation(#{ name: "bad" });
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.3] }).mesh(#{ divisions: [1, 1, 3] }), m);
"#;
    for (call, expect) in [
        ("sim.shake_relative(#{ x: eq, w: eq });", "unknown key 'w'"),
        (
            "sim.shake_relative(#{ start: 1.0 });",
            "at least one record",
        ),
        (
            "sim.shake_relative(#{ x: 1.0 });",
            "key 'x' must be a record",
        ),
        (
            "sim.shake_base(b.nodes(), #{ z: eq, start: -1.0 });",
            "before the current time",
        ),
        ("sim.ground();", "not shaken"),
    ] {
        let e = common::run_source_in_temp("shaking_script", &script, &format!("{head}{call}"))
            .err()
            .unwrap_or_else(|| panic!("{call} was accepted"))
            .to_string();
        assert!(e.contains(expect), "{call}: {e}");
        assert!(e.contains(":6:"), "{call}: no line in {e}");
    }
}

/// Reference: the statics of a rigid block on a shaken base (Housner 1963): a block of half
/// width b whose centre of mass is h above its base tips about its edge when the ground
/// accelerates it by more than g·b/h; below, with friction enough not to slide (μ = 1 >
/// a/g), it stays seated. A 0.1 × 0.1 × 0.5 m block (b/h = 0.2) rests on a slab by contact and
/// friction alone; the slab follows a ground acceleration ramped over 0.1 s to a constant
/// value and held to 0.4 s. At 0.16 g (80 % of the threshold) its heel must stay down
/// (uplift below 0.1 mm: the contact's and the block's elastic give as the pressure moves to
/// the toe; measured 0.03 mm at 75 %, 0.1 mm at 90 %) and not slide (1 mm); at 0.24 g
/// (120 %) it must rock up: the excess overturning moment tips it about its toe (measured
/// 8.6 mm in 0.3 s; 20 mm at 150 %); asserted > 1 mm.
#[test]
fn a_slender_block_rocks_only_above_the_tipping_acceleration() {
    let uplift_and_slide = |a_g: Real| -> (Real, Real) {
        let (mut sim, block_nodes, _) = BlockOnSlab {
            e: 5.0e7,
            mu: 1.0,
            slab: (
                Vec3::new(-0.3, -0.2, -0.05),
                Vec3::new(0.3, 0.2, 0.0),
                [6, 4, 1],
            ),
            block: (
                Vec3::new(-0.05, -0.05, 0.0),
                Vec3::new(0.05, 0.05, 0.5),
                [2, 2, 10],
            ),
            alpha: 100.0,
            settle: 0.15,
        }
        .build();
        let slab_nodes: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
        // The heel: the block's base nodes on the side away from the push (the ground
        // accelerates +x, the block leans to −x and lifts its +x edge).
        let heel: Vec<u32> = block_nodes
            .iter()
            .copied()
            .filter(|&n| {
                let p = sim.nodes.x0[n as usize];
                p.z < 1e-9 && p.x > 0.05 - 1e-9
            })
            .collect();
        let z0 = sim.mean_displacement(&heel).unwrap().z;
        let rec = Arc::new(GroundRecord::new(GroundMotion {
            name: "step".into(),
            source: String::new(),
            dt: 0.01,
            // Ramped on over 0.1 s (~10 periods of the block's sway): a step would make the
            // elastic block overshoot to twice the static overturning moment.
            acc: (0..40)
                .map(|k| a_g * G * (k as Real / 10.0).min(1.0))
                .collect(),
        }));
        sim.shake([Some(rec), None, None], None, ShakingKind::Base(slab_nodes))
            .unwrap();
        let t0 = sim.time;
        let mut uplift: Real = 0.0;
        while sim.time < t0 + 0.4 {
            sim.step().unwrap();
            uplift = uplift.max(sim.mean_displacement(&heel).unwrap().z - z0);
        }
        let ground = sim.loads.shaking[0].displacement.x;
        let heel_x = sim.mean_displacement(&heel).unwrap().x - ground;
        (uplift, heel_x)
    };
    let (below, slide_below) = uplift_and_slide(0.16);
    let (above, slide_above) = uplift_and_slide(0.24);
    println!(
        "heel uplift at 0.16 g: {below:.3e} m (heel moved {slide_below:.2e} m); at 0.24 g: {above:.3e} m (heel moved {slide_above:.2e} m)"
    );
    assert!(below < 1e-4, "seated block lifted {below:.3e} m");
    assert!(
        slide_below.abs() < 1e-3,
        "seated block slid {slide_below:.3e} m"
    );
    assert!(above > 1e-3, "block did not rock: {above:.3e} m");
}
