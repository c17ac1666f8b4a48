//! Measurements a modeller needs in every test (issue 16): bounds, momentum, mass-weighted
//! means, selections by reference position, reaction signs and monitor post-processing,
//! contact measures, damping relative to bodies, gravity ramps and the bring-to-rest stage.
//! Each is checked against a reference it cannot fake (a hand calculation, a generator's
//! parameters, an analytical static or quasi-static solution); every script prints what it
//! measured (`cargo test --test measurements -- --nocapture`).

mod common;

use fdem::script::{run_source, RunOptions};
use std::path::Path;

/// Run script text in-process (as `dir/name.rhai`); the script's own `expect_*` are the
/// assertions. Returns the error text on failure.
fn run(name: &str, text: &str) -> Result<(), String> {
    let dir = common::temp_dir(name);
    let path = dir.join(format!("{name}.rhai"));
    let opts = RunOptions {
        out_dir: Some(dir.join("out")),
        quiet: true,
        ..Default::default()
    };
    run_source(&path, text, opts)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

fn ok(name: &str, text: &str) {
    if let Err(e) = run(name, text) {
        panic!("{name}: {e}");
    }
}

fn fails(name: &str, text: &str) -> String {
    match run(name, text) {
        Ok(()) => panic!("{name}: expected an error"),
        Err(e) => e,
    }
}

/// Bounds of generated meshes against their parameters. Reference: the generators' own
/// geometry (box corners; disc poles on the circle since the cells per quarter are even,
/// also for the size that gave n = 11 and a flat at 0.99745 R before). Tolerance 1e-12 R:
/// the vertices are computed, not approximated.
#[test]
fn bounds_of_generated_meshes_match_their_parameters() {
    ok(
        "bounds",
        r#"
let b = box(#{ min: [0.1, -0.2, 0.3], max: [1.1, 0.4, 0.5] }).mesh(#{ size: 0.1 }).bounds();
expect_near("box min x", b.min[0], 0.1, 1e-12); expect_near("box max y", b.max[1], 0.4, 1e-12);
expect_near("box centre z", b.center[2], 0.4, 1e-12); expect_near("box size x", b.size[0], 1.0, 1e-12);
// size R/7 gave 11 cells per quarter before: flats at the poles, 0.99745 R.
for h in [0.025 / 5.0, 0.025 / 7.0, 0.025 / 3.3] {
    let d = disc(#{ radius: 0.025, thickness: 0.01, size: h }).bounds();
    print(`disc size ${fmt(h * 1e3, 3, "mm")}: max ${fmt(d.max, 15)}, min ${fmt(d.min, 15)}`);
    expect_near("disc +x pole", d.max[0], 0.025, 1e-12);
    expect_near("disc +y pole", d.max[1], 0.025, 1e-12);
    expect_near("disc -y pole", d.min[1], -0.025, 1e-12);
    expect_near("disc half thickness", d.max[2], 0.005, 1e-12);
}
// A disc about y (a Brazilian disc loaded along z): poles on ±z.
let dz = disc(#{ radius: 0.05, thickness: 0.02, axis: [0.0, 1.0, 0.0], size: 0.05 / 7.0 }).bounds();
expect_near("disc about y: top pole", dz.max[2], 0.05, 1e-12);
expect_near("disc about y: bottom pole", dz.min[2], -0.05, 1e-12);
let s = sphere(#{ center: [0.0, 0.0, 0.0], radius: 0.3 }).mesh(#{ size: 0.07 }).bounds();
expect_near("sphere pole", s.max[2], 0.3, 1e-12);
"#,
    );
}

/// `place_against` puts a platen on a Brazilian disc so that they touch, and the run shows a
/// load at once. Reference: the disc's pole at R (bounds) and contact: a platen driven into
/// the disc must see a contact force and a positive overlap after a few steps, and the platen's
/// bottom must sit at the pole to 1e-12 R before the run.
#[test]
fn place_against_makes_a_platen_touch_a_disc() {
    ok(
        "place",
        r#"
let sim = simulation(#{ name: "place" });
let rock = material("elastic/small_strain", #{ density: 2600.0, young: 1.0e9, poisson: 0.2 });
let steel = material("elastic/small_strain", #{ density: 7800.0, young: 2.0e10, poisson: 0.3 });
let d = sim.add_body("disc", disc(#{ radius: 0.025, thickness: 0.01, axis: [0.0, 1.0, 0.0], size: 0.025 / 7.0 }), rock);
let top = sim.add_body("platen", box(#{ min: [-0.01, -0.006, 0.0], max: [0.01, 0.006, 0.004] }).mesh(#{ size: 0.004 }), steel, #{ layout: "rigid" });
let base = sim.add_body("base", box(#{ min: [-0.01, -0.006, 0.0], max: [0.01, 0.006, 0.004] }).mesh(#{ size: 0.004 }), steel, #{ layout: "rigid" });
let moved = top.place_against(d, "+z");
base.place_against(d, "-z", 0.0);
expect_near("platen bottom at the pole", top.bounds().min[2], 0.025, 1e-12);
expect_near("base top at the pole", base.bounds().max[2], -0.025, 1e-12);
expect_near("platen moved up by R", moved[2], 0.025, 1e-12);
sim.contact_law("potential", #{});
base.fix();
top.prescribe_velocity(#{ x: 0.0, y: 0.0, z: -0.05, rotation: "fixed" });
let f = sim.monitor("platen_contact", #{ every: 1 }, |s| s.contact_force(top)[2]);
sim.run(#{ steps: 40 });
let c = sim.contact();
print(`after 40 steps: contact force on the platen ${fmt(f.last(), 4, "N")}, ${c.active} touching pairs, max overlap ${fmt(c.max_overlap, 3, "m")}, area ${fmt(c.area, 3, "m²")}`);
expect_within("platen pushed back up (N)", f.last(), 1e-6, 1e9);
expect_within("touching pairs", c.active, 1, 1000);
expect_within("overlap (m)", c.max_overlap, 1e-12, 1e-4);
// a bad axis is refused with the allowed ones
"#,
    );
    let e = fails(
        "place_bad",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1.0, young: 1.0, poisson: 0.0 });
let a = sim.add_body("a", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ size: 1.0 }), m);
let b = sim.add_body("b", box(#{ min: [2.0, 0.0, 0.0], max: [3.0, 1.0, 1.0] }).mesh(#{ size: 1.0 }), m);
a.place_against(b, "w");
"#,
    );
    assert!(
        e.contains("axis \"w\" is not one of") && e.contains(":6:"),
        "{e}"
    );
}

/// Momentum and angular momentum of a spinning rigid cube against M·V and I·ω by hand
/// (I = M a²/6 for a cube of side a, exact for the rigid layout's inertia), about the centre
/// and about another point (L_p = L_c + M (c − p) × V). Tolerance 1e-12 relative (exact
/// formulas, round-off only).
#[test]
fn momentum_of_a_spinning_rigid_cube_is_m_v_and_i_omega() {
    ok(
        "momentum_rigid",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 2000.0, young: 1.0e9, poisson: 0.25 });
let a = 0.2;
let cube = sim.add_body("cube", box(#{ min: [0.0, 0.0, 0.0], max: [a, a, a] }).mesh(#{ size: 0.05 }), m, #{ layout: "rigid" });
cube.set_velocity([1.0, -2.0, 0.5]);
cube.set_spin([0.0, 0.0, 3.0]);
let M = 2000.0 * a * a * a;
let p = cube.momentum();
let l = cube.angular_momentum();
print(`rigid cube: p = ${fmt(p, 6, "kg·m/s")}, L = ${fmt(l, 6, "kg·m²/s")}, M a²ω/6 = ${fmt(M * a * a * 3.0 / 6.0, 6)}`);
expect_near("p_x = M·1", p[0], M * 1.0, 1e-12);
expect_near("p_y = M·(-2)", p[1], -2.0 * M, 1e-12);
expect_near("L_z = M a²/6 · ω", l[2], M * a * a / 6.0 * 3.0, 1e-12);
expect_within("L_x", l[0], -1e-15, 1e-15);
// about the origin: + M (c − 0) × V, c = (a/2, a/2, a/2), V = (1, −2, 0.5)
let lo = cube.angular_momentum([0.0, 0.0, 0.0]);
let c = a / 2.0;
expect_near("L_origin x", lo[0], M * (c * 0.5 - c * (-2.0)), 1e-12);
expect_near("L_origin z", lo[2], M * a * a / 6.0 * 3.0 + M * (c * (-2.0) - c * 1.0), 1e-12);
"#,
    );
}

/// A deformable cube spinning freely: its angular momentum, Σ m (x − c) × v with the lumped
/// masses, is I_lumped·ω with I_lumped = M(a² + 2h²)/6 (the P1 interpolant of x² + y² that
/// lumping integrates: each Kuhn tet adds V·h²/6 per axis; 12.5 % above M a²/6 at h = a/4),
/// to 1e-12, and stays constant to
/// round-off (1e-9 relative) over 300 steps: the central difference conserves it exactly for
/// internal forces. Its momentum M·V stays too, and the mass-weighted node mean of all nodes
/// is the body's centre of mass.
#[test]
fn angular_momentum_of_a_free_deformable_body_is_conserved() {
    ok(
        "momentum_deformable",
        r#"
let sim = simulation(#{});
let m = material("elastic/munjiza", #{ density: 2000.0, young: 1.0e8, poisson: 0.25 });
let a = 0.2;
let cube = sim.add_body("cube", box(#{ min: [0.0, 0.0, 0.0], max: [a, a, a] }).mesh(#{ size: 0.05 }), m);
cube.set_velocity([0.3, 0.0, 0.0]);
cube.set_spin([0.0, 0.0, 20.0]);
let M = 2000.0 * a * a * a;
let l0 = cube.angular_momentum();
let p0 = cube.momentum();
let h = 0.05;
print(`deformable cube: L_z = ${fmt(l0[2], 8, "kg·m²/s")} vs M(a² + 2h²)ω/6 = ${fmt(M * (a * a + 2.0 * h * h) / 6.0 * 20.0, 8)} (continuum M a²ω/6 = ${fmt(M * a * a / 6.0 * 20.0, 8)})`);
expect_near("L_z = lumped inertia × ω", l0[2], M * (a * a + 2.0 * h * h) / 6.0 * 20.0, 1e-12);
let all = cube.nodes();
expect_near("mass_position = centre of mass (x)", sim.mass_position(all)[0], cube.center_of_mass()[0], 1e-12);
sim.run(#{ steps: 300 });
let l1 = cube.angular_momentum();
print(`after 300 steps: L_z = ${fmt(l1[2], 12)} (change ${fmt((l1[2] - l0[2]) / l0[2], 3)}), p_x = ${fmt(cube.momentum()[0], 12)}`);
expect_near("L_z conserved", l1[2], l0[2], 1e-9);
expect_near("p_x conserved", cube.momentum()[0], p0[0], 1e-9);
expect_near("mass_velocity = body velocity", sim.mass_velocity(all)[0], cube.velocity()[0], 1e-12);
"#,
    );
}

/// Centre of mass against node means, by hand. Two tets sharing a face: A = (0, 0, 0),
/// (1, 0, 0), (0, 1, 0), (0, 0, 1) of volume 1/6 and B = (1, 0, 0), (0, 1, 0), (0, 0, 1),
/// (0.7, 0.7, 0.7) of volume 1.1/6; centroids 0.25 and 0.425 on every axis, so the centre of
/// mass is (0.25 + 1.1·0.425)/2.1 = 0.341667 (exact for linear tets; `s.mass_position` of the
/// five nodes with their lumped masses V/4 gives the same), while the plain node mean
/// `s.position` is (1 + 0.7)/5 = 0.34. A rigid body moving at V keeps c(t) = c₀ + V·t, and so
/// does a free deformable one (momentum conserved). Tolerance 1e-12 (round-off), 1e-9 after
/// 200 steps.
#[test]
fn centre_of_mass_is_the_volume_weighted_centroid_not_the_node_mean() {
    ok(
        "centre_of_mass",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.7, 0.7, 0.7]];
let b = sim.add_body("two", tet_mesh(#{ nodes: pts, tets: [[0, 1, 2, 3], [1, 2, 3, 4]] }), m);
let c = b.center_of_mass();
let by_hand = (0.25 + 1.1 * 0.425) / 2.1;
print(`two tets: centre of mass ${fmt(c, 7)} (by hand ${fmt(by_hand, 7)}); mass_position ${fmt(sim.mass_position(b.nodes()), 7)}; node mean ${fmt(sim.position(b.nodes()), 7)}`);
for k in 0..3 {
    expect_near("centre of mass", c[k], by_hand, 1e-12);
    expect_near("mass-weighted node mean", sim.mass_position(b.nodes())[k], by_hand, 1e-12);
    expect_near("plain node mean", sim.position(b.nodes())[k], 0.34, 1e-12);
}
expect_near("mass = ρ·2.1/6", b.mass, 1000.0 * 2.1 / 6.0, 1e-12);
b.set_velocity([0.5, -0.25, 1.0]);
let r = sim.add_body("rigid", box(#{ min: [3.0, 0.0, 0.0], max: [3.2, 0.1, 0.4] }).mesh(#{ size: 0.1 }), m, #{ layout: "rigid" });
r.set_velocity([0.0, 2.0, 0.0]);
expect_near("rigid centre of mass = box centre (z)", r.center_of_mass()[2], 0.2, 1e-12);
sim.run(#{ steps: 200 });
let t = sim.time;
print(`after ${fmt(t * 1e3, 4, "ms")}: ${fmt(b.center_of_mass(), 10)}, rigid ${fmt(r.center_of_mass(), 10)}`);
expect_near("deformable c(t) = c0 + V·t (x)", b.center_of_mass()[0], by_hand + 0.5 * t, 1e-9);
expect_near("deformable c(t) = c0 + V·t (z)", b.center_of_mass()[2], by_hand + 1.0 * t, 1e-9);
expect_near("rigid c(t) = c0 + V·t (y)", r.center_of_mass()[1], 0.05 + 2.0 * t, 1e-9);
"#,
    );
}

/// The bar in compression between a fixed base and a platen (its top nodes) driven down at
/// v = −0.01 m/s after a 10 ms ramp: E = 10 MPa, ρ = 1000 kg/m³, ν = 0 (uniaxial: the
/// constant-strain tets are exact), L = 1 m, A = 0.01 m², 10 cells along the bar, damped at
/// α = 2ω₁ (ω₁ = πc/L, fixed–fixed) so the start-up transient is gone (e^{−αt/2} < e^{−15})
/// by the measurements.
///
/// Reaction sign: the platen's reaction is negative (it pushes down), so `peak()` of the
/// signed history is the 0 at t = 0, the trap of the issue; `peak_abs()` is the load.
///
/// Damping under prescribed motion, analytical quasi-static solution of the bar (equilibrium
/// dσ/dz = α ρ (v(z) − v_frame) with v(z) = v z/L and ∫σ/E dz = u): the platen reads
/// E A u/L + α ρ |v| L A/3 with damping relative to the ground and E A u/L + α ρ |v| L A/12
/// relative to the body's mean velocity v/2: 20.9 N and 5.24 N on top of ≈ 95 N, less the
/// damping of the platen's own half cell (prescribed nodes are not damped): 17.8 N and 3.67 N
/// (measured 17.9 N and 3.77 N, the reaction taken at x(t − dt)). The slope of
/// the load, E A |v|/L = 1000 N/s, is the same in both (least-squares fit over 40–100 ms).
/// Tolerances: 5 % on the damping excess (10 elements: the lumped damping forces are the
/// trapezoid rule of the distributed load, O(h²); measured 0.6 % and 3 %, the body frame
/// damps the first mode less, its mean velocity not being damped, so some transient is left),
/// 0.5 % on the slope.
#[test]
fn compression_reaction_sign_peaks_and_damping_frames() {
    ok(
        "compression",
        r#"
fn compress(frame) {
    let sim = simulation(#{ name: "bar_" + frame });
    let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.0 });
    let bar = sim.add_body("bar", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 1.0] }).mesh(#{ size: 0.1 }), m);
    let base = bar.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] }));
    let top = bar.nodes(half_space(#{ point: [0.0, 0.0, 1.0], normal: [0.0, 0.0, 1.0] }));
    sim.fix(base);
    sim.prescribe_velocity(top, #{ z: table([[0.0, 0.0], [0.01, -0.01]]) });
    let omega = PI() / 1.0 * 100.0;
    sim.damping(#{ mass_proportional: 2.0 * omega, frame: frame });
    let platen = sim.monitor("platen", #{ every: 5 }, |s| s.reaction(top)[2]);
    let support = sim.monitor("support", #{ every: 5 }, |s| s.reaction(base)[2]);
    sim.run(#{ max_time: 0.1 });
    [platen, support, sim.dt]
}
let E = 1.0e7; let A = 0.01; let L = 1.0; let v = 0.01; let rho = 1000.0;
let alpha = 2.0 * PI() * 100.0;
for frame in ["ground", "body"] {
    let r = compress(frame);
    let platen = r[0]; let support = r[1];
    let t = platen.times()[platen.len() - 1];
    // The reaction recorded at t is the last step's, computed at x(t − dt).
    let u = v * (t - r[2] - 0.005);
    let elastic = E * A * u / L;
    let excess = -platen.last() - elastic;
    // The platen's own nodes (half a cell, ρAh/2) are prescribed, so their damping force is
    // not part of the reaction: take it off the continuum result.
    let m_top = rho * A * 0.1 / 2.0;
    let predicted = if frame == "ground" { alpha * rho * v * L * A / 3.0 - alpha * m_top * v } else { alpha * rho * v * L * A / 12.0 - alpha * m_top * v / 2.0 };
    print(`${frame}: platen ${fmt(platen.last(), 5, "N")}, support ${fmt(support.last(), 5, "N")}, E·A·u/L = ${fmt(elastic, 5, "N")}, damping excess ${fmt(excess, 4, "N")} vs ${fmt(predicted, 4, "N")}; peak() ${fmt(platen.peak(), 3, "N")}, peak_abs() ${fmt(platen.peak_abs(), 5, "N")} at ${fmt(platen.argmax_abs() * 1e3, 4, "ms")}`);
    expect_within("platen reaction is negative (pushes down)", platen.last(), -1e9, -1.0);
    expect_within("support reaction is positive", support.last(), 1.0, 1e9);
    expect_within("peak() of the signed history is the zero at t = 0", platen.peak(), 0.0, 0.0);
    expect_near("peak_abs() = -min()", platen.peak_abs(), -platen.min(), 1e-15);
    expect_near("argmax_abs() = argmin()", platen.argmax_abs(), platen.argmin(), 1e-15);
    expect_near("the load peaks at the end", platen.argmax_abs(), t, 1e-12);
    expect_near(`${frame}: damping excess / analytical`, excess, predicted, 0.05);
    let k = platen.fit(0.04, 0.1);
    expect_near("slope of the load = -E·A·v/L", k.slope, -E * A * v / L, 0.005);
    expect_within("fit is a line", k.r2, 0.9995, 1.0);
    expect_near("slope() = fit().slope", platen.slope(0.04, 0.1), k.slope, 1e-15);
    // value at a time and first crossing, against the steady line
    let dt = r[2];
    let line = |t| E * A * v * (t - dt - 0.005) / L + predicted;
    expect_near("at(80 ms)", -platen.at(0.08), line.call(0.08), 0.005);
    let t50 = platen.first_crossing(-50.0, "down");
    let t50_line = 0.005 + r[2] + (50.0 - predicted) * L / (E * A * v);
    print(`  load reaches 50 N at ${fmt(t50 * 1e3, 5, "ms")} (steady line ${fmt(t50_line * 1e3, 5, "ms")})`);
    expect_near("first crossing of 50 N", t50, t50_line, 0.01);
    expect_within("never reaches 1 kN", if platen.first_crossing(-1000.0) == () { 0 } else { 1 }, 0, 0);
}
"#,
    );
    let e = fails(
        "monitor_at_outside",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.0 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.1 }), m);
let k = sim.monitor("ke", #{}, |s| s.kinetic_energy());
sim.run(#{ steps: 3 });
print(k.at(1.0));
"#,
    );
    assert!(
        e.contains("at(): monitor 'ke': t = 1 s lies outside the recorded times")
            && e.contains(":7:"),
        "{e}"
    );
    let e = fails(
        "damping_frame_bad",
        r#"
let sim = simulation(#{});
sim.damping(#{ mass_proportional: 1.0, frame: "bodies" });
"#,
    );
    assert!(
        e.contains("frame \"bodies\" is not \"ground\" or \"body\""),
        "{e}"
    );
}

/// Selections by reference position: a block that slid 0.3 m (free flight at 1 m/s) is still
/// selected by the region it was built in; `at: "current"` selects by where it is now. Before
/// this change the first selection was empty. Reference: node counts of the 2 × 2 × 2-cell
/// box (9 nodes on a face, 27 in all), exact.
#[test]
fn selections_use_reference_positions_unless_asked() {
    ok(
        "select_reference",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
b.set_velocity([1.0, 0.0, 0.0]);
let left = half_space(#{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] });
let where_built = box(#{ min: [-0.01, -0.01, -0.01], max: [0.11, 0.11, 0.11] });
let n_face = b.nodes(left).len();
let moved = sim.monitor("in_old_place_now", #{ every: 10 }, |s| s.nodes(where_built, #{ at: "current" }).len());
sim.run(#{ max_time: 0.3 });
print(`after sliding ${fmt(b.center_of_mass()[0] - 0.05, 4, "m")}: reference face ${b.nodes(left).len()} nodes, current ${b.nodes(left, #{ at: "current" }).len()}; body nodes in the old place now ${moved.last()}`);
expect_within("face nodes by reference", b.nodes(left).len(), 9, 9);
expect_within("same as before the run", n_face, 9, 9);
expect_within("face by current position: gone", b.nodes(left, #{ at: "current" }).len(), 0, 0);
expect_within("elements by reference", b.elements(where_built).len(), 48, 48);
expect_within("elements by current position", b.elements(where_built, #{ at: "current" }).len(), 0, 0);
let now = b.bounds();
expect_near("current bounds moved with the body", now.min[0], 1.0 * sim.time, 1e-9);
expect_near("reference bounds did not", b.bounds(#{ at: "reference" }).min[0], 0.0, 1e-15);
"#,
    );
    let e = fails(
        "select_bad",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
let n = b.nodes(sphere(#{ center: [0.0, 0.0, 0.0], radius: 0.01 }), #{ at: "deformed" });
"#,
    );
    assert!(
        e.contains("at \"deformed\" is not \"reference\" or \"current\""),
        "{e}"
    );
    let e = fails(
        "select_bad_key",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
let n = b.nodes(sphere(#{ center: [0.0, 0.0, 0.0], radius: 0.01 }), #{ where: "current" });
"#,
    );
    assert!(
        e.contains("unknown key 'where'") && e.contains("allowed keys: at"),
        "{e}"
    );
}

/// A column under its own weight (fixed base, H = 1 m, E = 10 MPa, ρ = 1000 kg/m³, ν = 0:
/// uniaxial; lumped = consistent loads for linear elements make the 1D nodal solution exact,
/// and the Kuhn tets' uneven nodal masses within a cross-section add 1.1e-4): static
/// settlement of the top u_s = ρgH²/2E = 0.4905 mm.
///
/// Sudden gravity overshoots to ≈ 2 u_s. Gravity ramped over 10.25 periods of the first mode
/// (ω₁ = πc/2H) stays below u_s (1 + 2/(ω₁T)) + 1 % for higher modes, the quasi-static
/// response of a linear ramp. `bring_to_rest` then settles it to u_s: the adaptive damping
/// converges to a kinetic energy below 1e-10 of the work, which leaves |u − u_s| ~ 1e-5 u_s
/// (tolerance 1e-3).
#[test]
fn gravity_ramp_and_bring_to_rest_against_the_static_column() {
    ok(
        "gravity_rest",
        r#"
fn column(mode) {
    let sim = simulation(#{ name: "column_" + mode });
    let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.0 });
    let col = sim.add_body("col", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 1.0] }).mesh(#{ size: 0.1 }), m);
    sim.fix(col.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] })));
    let top = col.nodes(half_space(#{ point: [0.0, 0.0, 1.0], normal: [0.0, 0.0, 1.0] }));
    let settle = sim.monitor("settlement", #{ every: 2 }, |s| -s.displacement(top)[2]);
    let period = 4.0 * 1.0 / 100.0;
    if mode == "sudden" { sim.gravity([0.0, 0.0, -9.81]); }
    if mode == "ramp" { sim.gravity([0.0, 0.0, -9.81], #{ ramp: 10.25 * period }); }
    if mode == "table" { sim.gravity([0.0, 0.0, -9.81], table([[0.0, 0.0], [10.25 * period, 1.0]])); }
    sim.run(#{ duration: 13.0 * period });
    let r = sim.bring_to_rest(#{ ratio: 1.0e-10 });
    #{ max: settle.max(), last: -sim.displacement(top)[2], rest: r, balance: sim.energy().relative_error }
}
let us = 1000.0 * 9.81 / (2.0 * 1.0e7);
let omega = PI() * 100.0 / 2.0;
let bound = us * (1.0 + 2.0 / (omega * 10.25 * 0.04)) * 1.01;
let sudden = column("sudden");
let ramp = column("ramp");
let tab = column("table");
print(`static u_s = ${fmt(us * 1e3, 5, "mm")}; sudden max ${fmt(sudden.max * 1e3, 5, "mm")}; ramped max ${fmt(ramp.max * 1e3, 5, "mm")} (bound ${fmt(bound * 1e3, 5, "mm")})`);
print(`at rest: ${fmt(ramp.last * 1e3, 7, "mm")} after ${ramp.rest.steps} steps (α = ${fmt(ramp.rest.damping, 4, "1/s")}, KE/W = ${fmt(ramp.rest.ratio, 3)}); sudden then rest: ${fmt(sudden.last * 1e3, 7, "mm")} after ${sudden.rest.steps} steps; balance ${fmt(ramp.balance, 3)}`);
expect_within("sudden gravity overshoots", sudden.max / us, 1.8, 2.1);
expect_within("ramped gravity does not", ramp.max / us, 0.99, bound / us);
expect_near("a table does what the ramp does", tab.max, ramp.max, 1e-12);
expect_near("ramp then rest = static", ramp.last, us, 1e-3);
expect_near("sudden then rest = static", sudden.last, us, 1e-3);
expect_within("converged", if ramp.rest.converged && sudden.rest.converged { 1 } else { 0 }, 1, 1);
expect_within("energy balance of the ramp", ramp.balance, 0.0, 1e-3);
"#,
    );
    // A model that cannot come to rest (a prescribed velocity) says so and returns
    // converged = false after max_steps.
    ok(
        "rest_never",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.0 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
sim.prescribe_velocity(b.nodes(), [0.0, 0.0, 1.0]);
let r = sim.bring_to_rest(#{ max_steps: 200, damping: 10.0 });
expect_within("not converged", if r.converged { 1 } else { 0 }, 0, 0);
expect_within("stopped at the cap", r.steps, 200, 200);
"#,
    );
    let e = fails(
        "gravity_bad",
        r#"
let sim = simulation(#{});
sim.gravity([0.0, 0.0, -9.81], #{ rmp: 0.1 });
"#,
    );
    assert!(
        e.contains("unknown key 'rmp' (did you mean 'ramp'?)"),
        "{e}"
    );
}

/// Contact you can measure: a deformable block pressed on a fixed base by a traction p.
/// Once at rest: the contact force on the block = p·A up, the contact area = the block's face
/// A = 0.01 m² (each touching pair contributes the area of its thin overlap), the largest
/// mean pressure of a pair = p, and the deepest overlap = σH/(8p_pen) with σ = p,
/// p_pen = 10·E and H = 0.05 m, the height over the contact face of the Kuhn tets on it
/// (docs/theory/contact.md, Overlap). Tolerance 1 % each (measured 2e-5, 1.1e-4, 2.1e-4,
/// 1.3e-4). The touching-pair count depends on how the two meshes cross, so it is only
/// required to be positive.
#[test]
fn contact_area_force_and_overlap_of_a_pressed_block() {
    ok(
        "contact_measures",
        r#"
let sim = simulation(#{});
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e8, poisson: 0.0 });
let base = sim.add_body("base", box(#{ min: [-0.02, -0.02, -0.05], max: [0.12, 0.12, 0.0] }).mesh(#{ size: 0.05 }), m);
let blk = sim.add_body("block", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
sim.fix(base.nodes());
sim.contact_law("potential", #{});
let p = 1.0e5;
sim.traction(blk.boundary(#{ normal: [0.0, 0.0, 1.0] }), [0.0, 0.0, -p]);
let f = sim.monitor("contact_on_block", #{ every: 10 }, |s| s.contact_force(blk)[2]);
let r = sim.bring_to_rest(#{ ratio: 1.0e-8 });
let c = sim.contact();
let d_thin = p * 0.05 / (8.0 * 10.0 * 1.0e8);
print(`pressed block: contact force ${fmt(f.last(), 5, "N")} (p·A = ${fmt(p * 0.01, 5, "N")}), area ${fmt(c.area, 4, "m²")}, ${c.active} touching pairs, max overlap ${fmt(c.max_overlap * 1e6, 4, "µm")} (σH/8p = ${fmt(d_thin * 1e6, 4, "µm")}), max pressure ${fmt(c.max_pressure, 4, "Pa")}, rest after ${r.steps} steps`);
expect_near("contact force = p·A", f.last(), p * 0.01, 0.01);
expect_near("contact area = block face", c.area, 0.01, 0.01);
expect_near("max pressure = p", c.max_pressure, p, 0.01);
expect_near("deepest overlap = σH/(8p_pen)", c.max_overlap, d_thin, 0.01);
expect_within("touching pairs", c.active, 1, 10000);
"#,
    );
}

/// Joints in a band only: cohesive joints on the faces whose centroid lies in a slab around
/// the cross-section x = L/2 of a jointed bar of 10 × 2 × 2 cells, `"tied"` joints on every
/// other internal face (the second `insert_joints` skips faces that already carry one).
/// Reference, exact counts of the structured mesh: the slab is ±h/6 thick and an internal
/// face of a Kuhn cell has its centroid at x_k + {0, 1/3, 2/3, 1}·h, so it holds exactly the
/// 2·2·2 = 8 triangles of that section; the bar has (4·240 − 2·2·(20 + 4 + 20))/2 = 392
/// internal faces, so 384 are tied. Pulled slowly (the speed ramped as in
/// `scripts/tension_bar.rhai`, to 2 f_t/E over t_load = k·L/c, k = 100), it breaks at that
/// section only: all 8 band joints, every broken joint's centroid (current position, 6e-5 m
/// past L/2 by then) inside the band, 2 fragments of half the volume each (1e-9). The load
/// read at the pulled end peaks at f_t·A plus what the end gains while the unloading wave
/// runs from the band to it, (L/2c)·dF/dt = f_t·A/k: measured 1.0076 f_t·A at k = 100
/// (1.019 at k = 40); accepted in [0.995, 1 + 1/k].
#[test]
fn joints_in_a_band_break_there_and_nowhere_else() {
    ok(
        "joint_band",
        r#"
let L = 1.0; let a = 0.1; let E = 1.0e10; let f_t = 1.0e6; let h = L / 10.0;
let sim = simulation(#{ name: "band" });
let rock = material("elastic/munjiza", #{ density: 2500.0, young: E, poisson: 0.0 });
let bar = sim.add_body("bar", box(#{ min: [0.0, 0.0, 0.0], max: [L, a, a] }).mesh(#{ divisions: [10, 2, 2] }), rock, #{ layout: "jointed" });
let band = box(#{ min: [L / 2.0 - h / 6.0, -1.0, -1.0], max: [L / 2.0 + h / 6.0, 1.0, 1.0] });
let weak = joint_law("cohesive/munjiza", #{ tensile_strength: f_t, cohesion: 3.0 * f_t, friction_angle: 30.0, g_i: 50.0, g_ii: 200.0 });
let n_band = sim.insert_joints(#{ within: bar, law: weak, region: band });
let n_tied = sim.insert_joints(#{ within: bar, law: joint_law("tied", #{}) });
print(`band: ${n_band} cohesive joints, ${n_tied} tied`);
expect_within("cohesive joints in the band", n_band, 8, 8);
expect_within("tied joints elsewhere", n_tied, 384, 384);
let cracks = [];
sim.on_joint_broken(|s, j| cracks.push(j.centroid[0]));
let c = sqrt(E / 2500.0);
let k = 100.0;
let t_load = k * L / c;
let v = 2.0 * f_t / E * L / t_load;
let held = bar.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] }));
let pulled = bar.nodes(half_space(#{ point: [L, 0.0, 0.0], normal: [1.0, 0.0, 0.0] }));
sim.prescribe_velocity(held, #{ x: 0.0 });
sim.prescribe_velocity(pulled, #{ x: table([[0.0, 0.0], [5.0 * L / c, v]]) });
let load = sim.monitor("load", #{ every: 10 }, |s| s.reaction(pulled)[0]);
sim.run(#{ max_time: 1.5 * t_load, stop_when: |s| s.broken_joints() > 0 && load.last() < 0.01 * load.max(), check_every: 50 });
let frags = sim.fragments();
print(`${cracks.len()} joints broke, at x = ${fmt(cracks, 6)}; ${frags.count} fragments of ${fmt(frags.volumes, 6, "m³")}; peak ${fmt(load.max(), 5, "N")} vs f_t·A = ${fmt(f_t * a * a, 5, "N")}`);
expect_within("the band broke whole", cracks.len(), 8, 8);
for x in cracks { expect_within("a crack in the band", x, L / 2.0 - h / 6.0, L / 2.0 + h / 6.0); }
expect_within("two fragments", frags.count, 2, 2);
for vol in frags.volumes { expect_near("half the bar each", vol, L * a * a / 2.0, 1e-9); }
expect_within("peak load / f_t·A", load.max() / (f_t * a * a), 0.995, 1.0 + 1.0 / k);
"#,
    );
}

/// `fdem check` warns when the worst tetrahedron costs 3× or more of the median one's steps.
/// Reference: the critical step of a tet scales with its size (ω_max ∝ 1/size for the same
/// shape), so of two bodies with one tet each, the second the first shrunk 4× (2×), the worst
/// allows 1/4 (1/2) of the median's step: "4×" with the warning, "2×" without.
#[test]
fn check_warns_when_one_small_tet_sets_the_time_step() {
    let dir = common::temp_dir("check_sliver");
    for (k, warned) in [(4.0, true), (2.0, false)] {
        let path = dir.join(format!("small_{k}.rhai"));
        std::fs::write(
            &path,
            format!(
                r#"let sim = simulation(#{{ name: "s" }});
let m = material("elastic/small_strain", #{{ density: 1000.0, young: 1.0e7, poisson: 0.2 }});
let tet = |s, x| tet_mesh(#{{ nodes: [[x, 0.0, 0.0], [x + s, 0.0, 0.0], [x, s, 0.0], [x, 0.0, s]], tets: [[0, 1, 2, 3]] }});
sim.add_body("big", tet.call(1.0, 0.0), m);
sim.add_body("small", tet.call(1.0 / {k:.1}, 5.0), m);
sim.run(#{{ steps: 1 }});
"#
            ),
        )
        .unwrap();
        let out = common::fdem().arg("check").arg(&path).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{text}");
        let line = text
            .lines()
            .find(|l| l.contains("worst tet"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(
            line.contains("of body 'small'")
                && line.contains(&format!(": {k}× the steps the median would need")),
            "{line}"
        );
        assert_eq!(line.contains("<-- WARNING"), warned, "{line}");
    }
}

/// `fdem check` shows the script's own prints (up to its first run) and names the worst
/// element with what it costs in steps. Reference: the cantilever-like box has one tet shape,
/// so the worst tet allows exactly the median's step (1×).
#[test]
fn check_shows_prints_and_the_worst_element() {
    let dir = common::temp_dir("check_prints");
    let path = dir.join("c.rhai");
    std::fs::write(
        &path,
        r#"
let sim = simulation(#{ name: "c" });
let m = material("elastic/small_strain", #{ density: 1000.0, young: 1.0e7, poisson: 0.2 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.2, 0.1, 0.1] }).mesh(#{ size: 0.05 }), m);
print(`the block weighs ${fmt(b.mass, 3, "kg")}`);
sim.run(#{ steps: 1 });
print("not reached by check");
"#,
    )
    .unwrap();
    let out = common::fdem().arg("check").arg(&path).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("the block weighs 2 kg"), "{text}");
    assert!(!text.contains("not reached"), "{text}");
    assert!(
        text.contains("worst tet") && text.contains(": 1× the steps the median would need"),
        "{text}"
    );
}

/// A `.geo` mesh is made once and reused: check and run see the same mesh (gmsh's HXT is not
/// deterministic), the message names the file, and a changed `size` makes a new one.
#[test]
#[ignore = "needs gmsh"]
fn geo_meshes_are_cached_by_content() {
    let dir = common::temp_dir("geo_cache");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/meshes/box_hole.geo"),
        dir.join("box_hole.geo"),
    )
    .unwrap();
    let script = |size: f64| {
        format!(
            "let m = gmsh(\"box_hole.geo\", #{{ size: {size} }});\nprint(`tets ${{m.n_tets}}`);\n"
        )
    };
    std::fs::write(dir.join("a.rhai"), script(0.3)).unwrap();
    std::fs::write(dir.join("b.rhai"), script(0.25)).unwrap();
    let first = common::fdem()
        .arg("check")
        .arg(dir.join("a.rhai"))
        .output()
        .unwrap();
    let first = String::from_utf8_lossy(&first.stdout).to_string();
    assert!(
        first.contains("meshed by gmsh into") && first.contains(".fdem-cache"),
        "{first}"
    );
    let again = common::fdem()
        .arg("run")
        .arg("--quiet")
        .arg(dir.join("a.rhai"))
        .output()
        .unwrap();
    let again = String::from_utf8_lossy(&again.stdout).to_string();
    assert!(again.contains("using the cached mesh"), "{again}");
    let tets = |t: &str| {
        t.lines()
            .find(|l| l.starts_with("tets "))
            .unwrap()
            .to_string()
    };
    assert_eq!(tets(&first), tets(&again));
    let other = common::fdem()
        .arg("check")
        .arg(dir.join("b.rhai"))
        .output()
        .unwrap();
    let other = String::from_utf8_lossy(&other.stdout).to_string();
    assert!(other.contains("meshed by gmsh into"), "{other}");
    let cached = std::fs::read_dir(dir.join(".fdem-cache")).unwrap().count();
    assert_eq!(cached, 2);
    // A script named by a relative path, its .geo in a subdirectory: gmsh runs in the .geo's
    // directory, so the cache file it writes must be given as an absolute path (a relative one
    // was taken from there, and gmsh failed with "Unable to open file").
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::copy(dir.join("box_hole.geo"), dir.join("sub/box_hole.geo")).unwrap();
    std::fs::write(
        dir.join("c.rhai"),
        "let m = gmsh(\"sub/box_hole.geo\", #{ size: 0.3 });\nprint(`tets ${m.n_tets}`);\n",
    )
    .unwrap();
    let sub = common::fdem()
        .current_dir(&dir)
        .arg("check")
        .arg("c.rhai")
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&sub.stdout).to_string();
    assert!(
        sub.status.success() && out.contains("meshed by gmsh into"),
        "{out}{}",
        String::from_utf8_lossy(&sub.stderr)
    );
    assert!(dir.join("sub/.fdem-cache").is_dir());
}
