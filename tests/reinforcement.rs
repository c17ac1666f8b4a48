//! Reinforcement: steel bars (stage 1, bar2) embedded in a host through bond points (stage 2).
//! Each test names its reference and why its tolerance.

mod common;

use common::{box_sim, material};
use fdem::elements::bar2::steel::{Steel, SteelLaw};
use fdem::joints::bond::{BondLaw, Envelope, Fib2010};
use fdem::loads::TimeFunction;
use fdem::material::Formulation;
use fdem::math::{Real, Vec3};
use fdem::pipeline::RebarSpec;
use fdem::{Layout, Simulation};

const E_S: Real = 200e9;
const FY: Real = 464e6;

fn steel(hardening: Real, rupture: Real) -> Steel {
    Steel {
        density: 7850.0,
        young: E_S,
        yield_stress: FY,
        hardening,
        rupture_strain: rupture,
        rate: None,
        law: SteelLaw::Bilinear,
    }
}

/// A concrete-like block [0, 0.3] × [0, 0.1] × [0, 0.1] m with one straight bar along x at
/// mid-section, from `x0` to `x1`, in `pieces` bars.
fn block_with_bar(
    steel: Steel,
    bond: BondLaw,
    x0: Real,
    x1: Real,
    pieces: usize,
    d: Real,
) -> (Simulation, std::ops::Range<usize>) {
    let mut sim = box_sim(
        Vec3::zeros(),
        Vec3::new(0.3, 0.1, 0.1),
        [12, 4, 4],
        material(Formulation::NeoHookean, 2400.0, 30e9, 0.2),
        Layout::Continuous,
    );
    let s = sim.add_steel(steel);
    let b = sim.add_bond_law(bond);
    let spec = RebarSpec {
        name: "bar".into(),
        host: 0,
        points: vec![Vec3::new(x0, 0.05, 0.05), Vec3::new(x1, 0.05, 0.05)],
        diameter: d,
        area: None,
        steel: s,
        bond_law: b,
        segment: Some((x1 - x0) / pieces as Real * 1.000001),
        bending: true,
    };
    let r = sim.add_rebar(&spec).unwrap();
    let nodes = sim.rebars[r].nodes.clone();
    (sim, nodes)
}

/// A bond that carries (almost) nothing along the bar: τ_max = 1 Pa.
fn no_bond() -> BondLaw {
    BondLaw {
        envelope: Envelope::Fib2010(Fib2010 {
            tau_max: 1.0,
            s1: 1e-3,
            s2: 2e-3,
            s3: 3e-3,
            alpha: 0.4,
            tau_f: 0.0,
        }),
        stiffness: 1e3,
        transverse_stiffness: Some(1e3),
    }
}

/// One bar element pulled at both ends (prescribed velocities, no bond): the axial force
/// from the end reaction against the bilinear law (Simo & Hughes §1.4; exact for one
/// uniform element, so 1e-6), elastic unloading with slope E, rupture at ε_u, and the
/// booked plastic work against the area under the measured force–elongation curve less the
/// elastic energy left (1 %, the issue's tolerance; the trapezoid over ~4000 steps is far
/// finer).
#[test]
fn steel_bar_in_tension_yields_hardens_unloads_elastically_and_ruptures() {
    let (h, eu) = (1.5e9, 0.12);
    let (mut sim, bar) = block_with_bar(steel(h, eu), no_bond(), 0.05, 0.25, 1, 0.02);
    let (a, l0) = (sim.bars.area[0], 0.2);
    let v = 1.0; // m/s at each end: ε̇ = 10 /s (rate-free law)
    let (t_unload, t_reload) = (0.003, 0.0035);
    let vel = |sign: Real| {
        TimeFunction::table(vec![
            (0.0, sign * v),
            (t_unload, sign * v),
            (t_unload + 1e-9, -sign * v),
            (t_reload, -sign * v),
            (t_reload + 1e-9, sign * v),
        ])
        .unwrap()
    };
    let (n0, n1) = (bar.start as u32, bar.start as u32 + 1);
    sim.prescribe_velocity(
        &[n0],
        [
            Some(vel(-1.0)),
            Some(TimeFunction::Constant(0.0)),
            Some(TimeFunction::Constant(0.0)),
        ],
    );
    sim.prescribe_velocity(
        &[n1],
        [
            Some(vel(1.0)),
            Some(TimeFunction::Constant(0.0)),
            Some(TimeFunction::Constant(0.0)),
        ],
    );
    // (time, ε, σ, end reaction N, plastic work booked, α) per step until rupture.
    let mut hist: Vec<(Real, Real, Real, Real, Real, Real)> = Vec::new();
    let mut ruptured_at = None;
    sim.set_velocity(&[n0], Vec3::new(-v, 0.0, 0.0)).unwrap();
    sim.set_velocity(&[n1], Vec3::new(v, 0.0, 0.0)).unwrap();
    while sim.time < 0.02 {
        sim.step().unwrap();
        let eps = sim.bars.strain[0];
        if !sim.bars.ruptured_at[0].is_nan() {
            ruptured_at = Some(eps);
            break;
        }
        let n = sim.nodes.reaction_sum(&[n1]).x;
        let (sigma, alpha) = (sim.bars.stress[0], sim.bars.history[0]);
        // The force the constraint exerts on the pulled end is the bar's axial force (but in
        // the steps where the end's velocity reverses: there it also stops the end's mass).
        let reversing = [t_unload, t_reload]
            .iter()
            .any(|t| (sim.time - t).abs() < 2.0 * sim.dt);
        if !reversing {
            assert!(
                (n - sigma * a).abs() < 1e-6 * FY * a,
                "reaction {n} vs N {}",
                sigma * a
            );
        }
        if sim.time < t_unload {
            let expected = if alpha > 0.0 {
                FY + h * alpha
            } else {
                E_S * eps
            };
            assert!(
                (sigma - expected).abs() < 1e-6 * FY,
                "σ = {sigma} vs {expected}"
            );
        }
        hist.push((
            sim.time,
            eps,
            sigma,
            sigma * a,
            sim.bars.dissipated[0],
            alpha,
        ));
    }
    let first_yield = hist.iter().find(|h| h.5 > 0.0).expect("the bar yields");
    let de = 2.0 * v / l0 * sim.dt;
    assert!(
        (first_yield.1 - FY / E_S).abs() < 2.0 * de,
        "yield at ε = {}",
        first_yield.1
    );
    let unloading: Vec<_> = hist
        .iter()
        .filter(|h| h.0 > t_unload + 2e-5 && h.0 < t_reload - 2e-5)
        .collect();
    let (u0, u1) = (unloading[0], unloading[unloading.len() - 1]);
    let slope = (u1.2 - u0.2) / (u1.1 - u0.1);
    assert!((slope / E_S - 1.0).abs() < 1e-6, "unloading slope {slope}");
    assert_eq!(u0.5, u1.5, "no plastic flow while unloading");
    let eps_u = ruptured_at.expect("the bar ruptures");
    assert!(eps_u >= eu && eps_u < eu + 2.0 * de, "rupture at {eps_u}");
    // The work of the axial force along the strain path, ∫N dl (trapezoid), against the elastic energy
    // left plus the plastic work booked, at the last step before rupture.
    let work: Real = hist
        .windows(2)
        .map(|w| 0.5 * (w[0].3 + w[1].3) * (w[1].1 - w[0].1) * l0)
        .sum::<Real>()
        + 0.5 * hist[0].3 * hist[0].1 * l0;
    let last = hist.last().unwrap();
    let booked = last.4 + 0.5 * last.2 * last.2 / E_S * a * l0;
    assert!(
        (booked / work - 1.0).abs() < 0.01,
        "booked {booked} J vs measured {work} J"
    );
    assert!(
        sim.bars.dissipated[0] > last.4,
        "the elastic energy lost at rupture is booked"
    );
    assert_eq!(sim.bars.stress[0], 0.0);
    println!(
        "yield at ε = {:.6} (f_y/E = {:.6}), unloading slope {slope:.5e} Pa, rupture at ε = {eps_u:.5}, work: booked {booked:.3} J vs measured {work:.3} J ({:+.2e})",
        first_yield.1,
        FY / E_S,
        booked / work - 1.0
    );
}

/// Pull-out of a short bar (embedment 2.5 d, d = 20 mm) from a block held at its far face:
/// the pull-out force against π d L τ(s̄) of the fib Model Code 2010 envelope at the mean slip
/// (f_cm = 30 MPa, confined, good bond; eq. 6.1-1). Short embedment makes the slip nearly
/// uniform (the bar's own stretch at τ_max is ~2 % of s₁), so 3 % — the issue's tolerance —
/// holds on the rising branch, the plateau and the descent (measured within 0.2 %).
#[test]
fn pull_out_force_follows_the_bond_law_integrated_over_the_bond_length() {
    let d = 0.02;
    let fib = Fib2010::new(30e6, "confined", true, 10e-3).unwrap();
    let s_lin = fib.s1 / 100.0;
    let bond = BondLaw {
        envelope: Envelope::Fib2010(fib),
        stiffness: fib.envelope(s_lin) / s_lin,
        transverse_stiffness: None,
    };
    let l = 2.5 * d;
    let (mut sim, bar) = block_with_bar(steel(0.0, Real::INFINITY), bond, 0.0, l, 4, d);
    let far = common::plane_x(&sim, 0.3, 1.0);
    sim.fix(&far, [true, true, true]);
    let end = bar.start as u32;
    // Ramp to 0.2 m/s over 2 ms, then constant: quasi-static (the block's first period is
    // ~0.2 ms), to 4 mm of slip.
    let v = TimeFunction::table(vec![(0.0, 0.0), (2e-3, -0.2)]).unwrap();
    sim.prescribe_velocity(
        &[end],
        [
            Some(v),
            Some(TimeFunction::Constant(0.0)),
            Some(TimeFunction::Constant(0.0)),
        ],
    );
    let mut checked = Vec::new();
    let targets = [0.1e-3, 0.3e-3, 0.6e-3, 1.5e-3, 3.0e-3, 4.0e-3];
    let area = std::f64::consts::PI * d * l;
    let mut next = 0;
    while next < targets.len() {
        sim.step().unwrap();
        let b = &sim.bonds;
        let weight: Real = b.area.iter().sum();
        let mean_slip = -(0..b.len()).map(|p| b.slip[p] * b.area[p]).sum::<Real>() / weight;
        if mean_slip >= targets[next] {
            let force = sim.nodes.reaction_sum(&[end]).x.abs();
            let expected = area * fib.envelope(mean_slip);
            checked.push((mean_slip, force, expected));
            next += 1;
        }
    }
    for &(s, f, e) in &checked {
        println!(
            "s̄ = {:.3} mm: F = {:.4} kN, π d L τ(s̄) = {:.4} kN ({:+.2} %)",
            s * 1e3,
            f / 1e3,
            e / 1e3,
            (f / e - 1.0) * 100.0
        );
    }
    for &(s, f, e) in &checked {
        assert!((f / e - 1.0).abs() < 0.03, "at s̄ = {s}: F = {f} N vs {e} N");
    }
    // The bond's slip dissipation is booked and the account closes: the bond forces are
    // −∂W/∂x of the bond potential, the axis turning with the bar included (measured 3.3e-12;
    // 1e-6 leaves room for round-off over longer runs, while a follower-load bond force, the
    // first version's, had passed 1e-2 at 2.5 mm of slip and blew up near 3 mm).
    let en = sim.energy;
    assert!(en.bond_slip > 0.0);
    println!("balance error {:.2e}", en.relative_balance_error());
    assert!(
        en.relative_balance_error().abs() < 1e-6,
        "balance {:e}",
        en.relative_balance_error()
    );
}

/// A reinforced block spinning through 3 rad while it vibrates (free flight, elastic host,
/// elastic bar, bond below its elastic limit): energy is conserved, the account closing to
/// 1e-6 (the central difference conserves a shadow energy; measured 1.5e-7), and
/// angular momentum about the centre of mass to 1e-9 (all forces are internal and pairwise
/// balanced). The bar's force stays at the level of the vibration, not of the rotation: a
/// formulation that were not objective would see strains of order the rotation angle (with
/// the host in `elastic/small_strain`, which is not objective, the bar reached 316 MPa).
#[test]
fn a_reinforced_block_spinning_and_vibrating_conserves_energy_and_angular_momentum() {
    let fib = Fib2010::new(30e6, "confined", true, 10e-3).unwrap();
    let bond = BondLaw {
        envelope: Envelope::Fib2010(fib),
        stiffness: fib.envelope(fib.s1 / 100.0) / (fib.s1 / 100.0),
        transverse_stiffness: None,
    };
    let (mut sim, _) = block_with_bar(steel(0.0, Real::INFINITY), bond, 0.02, 0.28, 8, 0.016);
    let c = Vec3::new(0.15, 0.05, 0.05);
    let omega = Vec3::new(10.0, 40.0, 25.0); // |ω| = 48 rad/s
    for n in 0..sim.nodes.len() {
        let r = sim.nodes.x0[n] - c;
        sim.nodes.v[n] = omega.cross(&r) + Vec3::new(2.0 * r.x, 0.0, 0.0);
    }
    let angular = |sim: &Simulation| -> Vec3 {
        let m: Real = sim.nodes.m.iter().sum();
        let com: Vec3 = (0..sim.nodes.len())
            .map(|n| sim.nodes.x[n] * sim.nodes.m[n])
            .sum::<Vec3>()
            / m;
        (0..sim.nodes.len())
            .map(|n| (sim.nodes.x[n] - com).cross(&sim.nodes.v[n]) * sim.nodes.m[n])
            .sum()
    };
    sim.prepare().unwrap();
    let l0 = angular(&sim);
    let mut max_stress: Real = 0.0;
    while sim.time < 3.0 / omega.norm() {
        sim.step().unwrap();
        max_stress = max_stress.max(sim.bars.stress.iter().fold(0.0, |a, s| a.max(s.abs())));
    }
    sim.sample_next = true;
    sim.step().unwrap();
    let l1 = angular(&sim);
    let e = sim.energy;
    println!(
        "balance {:.2e}, |ΔL|/|L| = {:.2e}, largest bar stress {:.3} MPa, bond slip dissipated {:.2e} J of kinetic {:.3} J",
        e.relative_balance_error(),
        (l1 - l0).norm() / l0.norm(),
        max_stress / 1e6,
        e.bond_slip,
        e.kinetic
    );
    assert!(e.relative_balance_error().abs() < 1e-6);
    // Measured 1e-14: the central difference conserves Σ m x(t) × v(t − dt/2) exactly for
    // pairwise central forces, and every force here comes in balanced sets.
    assert!((l1 - l0).norm() < 1e-9 * l0.norm(), "{l0} → {l1}");
    assert_eq!(e.bond_slip, 0.0, "the bond stays elastic");
    assert!(max_stress < 20e6, "bar stress {max_stress} Pa");
}

/// Reference: the Rust API tested above. The script functions lay straight bars with cover
/// and closed stirrups where the geometry says (a stirrup's centreline cover + d/2 inside the
/// section), the bars carry load from the first step, the VTK frame of the bars is written,
/// and bad input is refused naming the key, the bar or the point, with its line.
#[test]
fn script_functions_lay_bars_and_stirrups_and_refuse_bad_input() {
    let dir = common::temp_dir("rebar_script");
    let script = dir.join("rebar.rhai");
    let text = r#"
let sim = simulation(#{ name: "rc", out_dir: "OUT" });
let concrete = material("elastic/neo_hookean", #{ density: 2400.0, young: 30.0e9, poisson: 0.2 });
let beam = sim.add_body("beam", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 0.2, 0.3] }).mesh(#{ divisions: [20, 4, 6] }), concrete);
let s = steel(#{ yield_stress: 464.0e6, ultimate_stress: 630.0e6, ultimate_strain: 0.15 });
let b = bond_law("fib2010", #{ fcm: 47.0e6, confinement: "stirrups" });
let line = straight_bar(beam, #{ axis: "x", at: [0.05, 0.05], cover: 0.03 });
expect_near("bar start", line[0][0], 0.03, 1e-12);
expect_near("bar end", line[1][0], 0.97, 1e-12);
let r = sim.rebar(beam, #{ points: line, diameter: 0.02, area: 300.0e-6, steel: s, bond: b, name: "bottom" });
let hoop = stirrup(beam, #{ axis: "x", at: 0.5, cover: 0.02, diameter: 0.006 });
expect_within("stirrup corners", hoop.len(), 5, 5);
expect_near("stirrup inset", hoop[0][1], 0.023, 1e-12);
expect_near("closed", hoop[4][2], hoop[0][2], 0.0);
let st = sim.rebar(beam, #{ points: hoop, diameter: 0.006, steel: s, bond: b });
expect_within("bars laid", r.bars, 15, 40);
sim.fix(beam.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] })));
sim.gravity([0.0, 0.0, -9.81]);
sim.run(#{ steps: 200 });
sim.write_vtk();
let e = sim.energy();
expect_within("balance", abs(e.relative_error), 0.0, 1e-3);
expect_within("bond energy booked", e.bond, 1e-12, 1.0e9);
expect_within("stressed", r.max_stress(), 1.0, 464.0e6);
expect_within("no rupture", r.ruptured(), 0, 0);
// The cantilevered beam sags: its bar bends at its nodes, far below M_p = f_y d³/6 = 619 N·m.
expect_within("bar bends", r.max_bending_moment(), 1e-6, 619.0);
"#
    .replace("OUT", &dir.join("out").display().to_string().replace('\\', "/"));
    fdem::script::run_source(&script, &text, Default::default()).unwrap();
    let bars = dir.join("out/rc_bars_000000.vtu");
    let vtu = std::fs::read(&bars).unwrap_or_else(|e| panic!("{}: {e}", bars.display()));
    let vtu = String::from_utf8_lossy(&vtu);
    assert!(
        vtu.contains("axial_force")
            && vtu.contains("bond_stress")
            && vtu.contains("bending_moment")
            && vtu.contains("UInt8")
    );
    let head = r#"
let sim = simulation(#{ name: "bad" });
let concrete = material("elastic/neo_hookean", #{ density: 2400.0, young: 30.0e9, poisson: 0.2 });
let beam = sim.add_body("beam", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 0.2, 0.3] }).mesh(#{ divisions: [10, 2, 3] }), concrete);
let s = steel(#{ yield_stress: 464.0e6 });
let b = bond_law("fib2010", #{ fcm: 47.0e6 });
"#;
    for (call, expect) in [
        (
            "sim.rebar(beam, #{ points: [[0.1, 0.1, 0.1], [1.2, 0.1, 0.1]], diameter: 0.02, steel: s, bond: b, name: \"long\" });",
            "rebar 'long': point",
        ),
        ("sim.rebar(beam, #{ points: [[0.1, 0.1, 0.1], [0.9, 0.1, 0.1]], diameter: 0.0, steel: s, bond: b });", "diameter must be > 0"),
        ("steel(#{ yield_stress: 464.0e6, ultimate_stress: 400.0e6, ultimate_strain: 0.1 });", "below yield_stress"),
        ("steel(#{ fy: 464.0e6 });", "unknown key 'fy'"),
        ("bond_law(\"fib2010\", #{ fcm: 47.0e6, confinement: \"loose\" });", "confinement \"loose\""),
        ("bond_law(\"fib2010\", #{ confinement: \"confined\" });", "'fcm'"),
        ("sim.rebar(beam, #{ points: [[0.1, 0.1, 0.1]], diameter: 0.02, steel: s, bond: b });", "at least 2 points"),
        (
            "let plate = sim.add_body(\"plate\", box(#{ min: [0.0, 0.0, 0.4], max: [0.2, 0.2, 0.5] }).mesh(#{ divisions: [1, 1, 1] }), concrete, #{ layout: \"rigid\" }); sim.rebar(plate, #{ points: [[0.05, 0.1, 0.45], [0.15, 0.1, 0.45]], diameter: 0.02, steel: s, bond: b, name: \"in_plate\" });",
            "rebar 'in_plate': the host body 'plate' is rigid",
        ),
    ] {
        let e = common::run_source_in_temp("reinforcement_script", &script, &format!("{head}{call}"))
            .err()
            .unwrap_or_else(|| panic!("{call} was accepted"))
            .to_string();
        assert!(e.contains(expect), "{call}: {e}");
        assert!(e.contains(":7:"), "{call}: no line in {e}");
    }
}

/// The bars and bond points are computed in parallel into per-element slots and added to the
/// nodes in order: a slipping pull-out gives bit-identical positions on 1 and 2 threads.
#[test]
fn reinforced_runs_are_bit_identical_for_1_and_2_threads() {
    let run = || {
        let fib = Fib2010::new(30e6, "confined", true, 10e-3).unwrap();
        let bond = BondLaw {
            envelope: Envelope::Fib2010(fib),
            stiffness: fib.envelope(fib.s1 / 100.0) / (fib.s1 / 100.0),
            transverse_stiffness: None,
        };
        let (mut sim, bar) = block_with_bar(steel(1e9, 0.2), bond, 0.0, 0.2, 8, 0.02);
        let far = common::plane_x(&sim, 0.3, 1.0);
        sim.fix(&far, [true, true, true]);
        let v = TimeFunction::table(vec![(0.0, 0.0), (1e-3, -2.0)]).unwrap();
        let end = bar.start as u32;
        sim.prescribe_velocity(&[end], [Some(v), Some(TimeFunction::Constant(0.1)), None]);
        for _ in 0..1500 {
            sim.step().unwrap();
        }
        assert!(
            sim.bonds.max_slip.iter().any(|&s| s > fib.s1),
            "the bar slips"
        );
        sim.nodes.x.clone()
    };
    let (a, b) = (common::on_threads(1, run), common::on_threads(2, run));
    assert!(a == b, "positions differ between 1 and 2 threads");
}

/// A bar on an elastic foundation loaded at its free end: the bar bends at its nodes
/// (hinges k = EI/L̄) and the host's transverse bond springs are a Winkler foundation of
/// modulus k_f = π d k⊥ [N/m²]. Hetényi (1946, *Beams on Elastic Foundation*, §II.9): a
/// semi-infinite beam with an end load P deflects y₀ = 2Pβ/k_f and turns θ₀ = 2Pβ²/k_f at
/// the end, β = (k_f/4EI)^{1/4}. Here β = 25 /m over 0.28 m of bar (βL = 7: the far end
/// changes y₀ by ~e^{−7}) in 56 bars (βℓ = 0.125: the chain's discretisation error is
/// O((βℓ)²) ≈ 1 %), so 3 % on y₀ and 5 % on θ₀ (a difference quotient over the end bar).
/// Measured: y₀ −0.39 %, θ₀ −0.78 %, largest moment 12.80 N·m against P/β·e^{−π/4}·sin(π/4)
/// = 12.90. A chain of pins (bending off) would deflect P/(k_f ℓ/2) at its end node: 8× more.
/// The host is held fixed; the static state is reached by mass damping at 2ω₁.
#[test]
fn a_bar_on_an_elastic_foundation_bends_as_hetenyi_says() {
    let d: Real = 0.016;
    let ei = E_S * std::f64::consts::PI * d.powi(4) / 64.0;
    let beta: Real = 25.0;
    let k_f = 4.0 * ei * beta.powi(4);
    let fib = Fib2010::new(30e6, "confined", true, d).unwrap();
    let bond = BondLaw {
        envelope: Envelope::Fib2010(fib),
        stiffness: fib.envelope(fib.s1 / 100.0) / (fib.s1 / 100.0),
        transverse_stiffness: Some(k_f / (std::f64::consts::PI * d)),
    };
    let (x0, x1) = (0.01, 0.29);
    let (mut sim, nodes) = block_with_bar(steel(0.0, Real::INFINITY), bond, x0, x1, 56, d);
    let host: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(fdem::loads::PrescribedVelocity {
        nodes: host,
        components: [(); 3].map(|_| Some(TimeFunction::Constant(0.0))),
    });
    let p = 1000.0;
    // The free end is the bar's last node (x = x1), loaded across the bar (y).
    let tip = (nodes.end - 1) as u32;
    let before = (nodes.end - 2) as u32;
    sim.loads.forces.push(fdem::loads::NodalForces::new(
        vec![tip],
        vec![Vec3::new(0.0, p, 0.0)],
        TimeFunction::Constant(1.0),
    ));
    let rho_a = 7850.0 * std::f64::consts::PI * d * d / 4.0;
    let omega1 = (k_f / rho_a).sqrt();
    sim.settings.mass_damping = 2.0 * omega1;
    sim.prepare().unwrap();
    assert_eq!(sim.bars.hinges.len(), 55, "a hinge at every interior node");
    while sim.time < 20.0 / omega1 {
        sim.step().unwrap();
    }
    let y = |n: u32| sim.nodes.x[n as usize].y - sim.nodes.x0[n as usize].y;
    let (y0, y1) = (y(tip), y(before));
    let l = (x1 - x0) / 56.0;
    let theta0 = (y0 - y1) / l;
    let (y_ref, theta_ref) = (2.0 * p * beta / k_f, 2.0 * p * beta * beta / k_f);
    println!(
        "end deflection {y0:.4e} m (Hetényi {y_ref:.4e}), end rotation {theta0:.4e} (Hetényi {theta_ref:.4e}), largest moment {:.3} N·m",
        sim.bars.hinges.moment.iter().fold(0.0, |a: Real, m| a.max(m.abs()))
    );
    assert!((y0 / y_ref - 1.0).abs() < 0.03, "y₀ {y0} against {y_ref}");
    assert!(
        (theta0 / theta_ref - 1.0).abs() < 0.05,
        "θ₀ {theta0} against {theta_ref}"
    );
}
