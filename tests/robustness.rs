//! Robustness (issue 15): every input a script, a mesh, a record or the command line can give
//! ends in a clear, placed error, never a panic, an abort, a hang or a silently wrong result.
//! Each test names the input and the words the error must contain.

mod common;

use fdem::script::{run_source, RunOptions};
use std::path::Path;

/// Run `text` as `dir/name.rhai` in-process (output under `dir/out`); the error text if any.
fn run_in(dir: &Path, name: &str, text: &str) -> Result<(), String> {
    let path = dir.join(format!("{name}.rhai"));
    std::fs::write(&path, text).unwrap();
    let options = RunOptions {
        out_dir: Some(dir.join("out")),
        quiet: true,
        ..Default::default()
    };
    run_source(&path, text, options)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// The error of a script that must fail, run in a fresh directory named `name`.
fn error_of(name: &str, text: &str) -> String {
    let dir = common::temp_dir(name);
    match run_in(&dir, name, text) {
        Ok(()) => panic!("script '{name}' should have failed:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts that `msg` contains every one of `words`.
fn assert_has(msg: &str, words: &[&str]) {
    for w in words {
        assert!(msg.contains(w), "expected '{w}' in the error:\n{msg}");
    }
}

/// Two simulations: `sim` (a 1×1×1 box, 8 nodes) and `sim2` (a 2×2×2 box, bigger), with a body
/// `b` in `sim` and `b2` in `sim2`.
const TWO_SIMS: &str = r#"
let rock = material("elastic/small_strain", #{ density: 2000.0, young: 1e7, poisson: 0.25 });
let sim = simulation(#{ name: "first" });
let b = sim.add_body("small", box(#{ min: [0, 0, 0], max: [1, 1, 1] }).mesh(#{ divisions: [1, 1, 1] }), rock);
let sim2 = simulation(#{ name: "second" });
let b2 = sim2.add_body("big", box(#{ min: [0, 0, 0], max: [2, 2, 2] }).mesh(#{ divisions: [4, 4, 4] }), rock);
"#;

/// Every function that takes a node, element or face set or a body, called on `sim2` with a
/// handle made from `sim`: an error naming both simulations and the function, with the line.
#[test]
fn handles_from_another_simulation_are_refused_by_every_function() {
    let calls = [
        ("fix", "sim2.fix(b.nodes());"),
        ("fix", "sim2.fix(b.nodes(), \"z\");"),
        (
            "initial_velocity",
            "sim2.initial_velocity(b.nodes(), [1, 0, 0]);",
        ),
        (
            "prescribe_velocity",
            "sim2.prescribe_velocity(b.nodes(), [0, 0, 1]);",
        ),
        (
            "prescribe_velocity",
            "sim2.prescribe_velocity(b.nodes(), #{ z: 1.0 });",
        ),
        ("nodal_force", "sim2.nodal_force(b.nodes(), [0, 0, 1]);"),
        (
            "nodal_force",
            "sim2.nodal_force(b.nodes(), [0, 0, 1], table([[0, 0], [1, 1]]));",
        ),
        ("traction", "sim2.traction(b.boundary(), [0, 0, 1]);"),
        (
            "traction",
            "sim2.traction(b.boundary(), [0, 0, 1], table([[0, 0], [1, 1]]));",
        ),
        ("displacement", "sim2.displacement(b.nodes());"),
        ("position", "sim2.position(b.nodes());"),
        ("velocity", "sim2.velocity(b.nodes());"),
        ("reaction", "sim2.reaction(b.nodes());"),
        ("mean_stress", "sim2.mean_stress(b.elements());"),
        ("max_von_mises", "sim2.max_von_mises(b.elements());"),
        ("contact_force", "sim2.contact_force(b);"),
        ("shake_base", "sim2.shake_base(b.nodes(), #{});"),
        (
            "insert_joints",
            "sim2.insert_joints(#{ within: b, law: joint_law(\"tied\", #{}) });",
        ),
        (
            "insert_joints",
            "sim2.insert_joints(#{ between: [b, b2], law: joint_law(\"tied\", #{}) });",
        ),
        ("nodes + nodes", "let u = b2.nodes() + b.nodes();"),
        (
            "elements + elements",
            "let u = b2.elements() + b.elements();",
        ),
        (
            "rebar",
            "sim2.rebar(b, #{ points: [[0.1, 0.5, 0.5], [0.9, 0.5, 0.5]], diameter: 0.01 });",
        ),
        ("displacement", "sim2.displacement(b.boundary().nodes());"),
    ];
    for (i, (func, call)) in calls.iter().enumerate() {
        let text = format!("{TWO_SIMS}{call}\n");
        let line = text.lines().count();
        let e = error_of(&format!("handles_{i}"), &text);
        assert_has(
            &e,
            &[func, "simulation 'first'", "'second'", &format!(":{line}:")],
        );
    }
}

/// `sim2.fix(b.nodes())` with `b` from `sim` used to fix the first nodes of `sim2`, silently.
/// Now refused, and `sim2`'s nodes stay free.
#[test]
fn fixing_nodes_of_another_simulation_does_not_fix_other_nodes() {
    let text = format!("{TWO_SIMS}\nsim2.fix(b.nodes());\n");
    let e = error_of("fix_other", &text);
    assert_has(
        &e,
        &["fix()", "these nodes", "simulation 'first'", "'second'"],
    );
}

/// Two simulations of one name: the message still tells them apart.
#[test]
fn handles_from_a_simulation_of_the_same_name_are_refused() {
    let text = TWO_SIMS.replace("\"second\"", "\"first\"") + "\nsim2.fix(b.nodes());\n";
    let e = error_of("same_name", &text);
    assert_has(&e, &["fix()", "another simulation named 'first'"]);
}

/// A handle used with its own simulation still works (no false alarm), also from a named set
/// and a union.
#[test]
fn handles_of_the_same_simulation_work() {
    let dir = common::temp_dir("same_sim");
    let text = format!(
        "{TWO_SIMS}\nsim.fix(b.nodes() + b.nodes());\nsim2.fix(b2.nodes(box(#{{ min: [0, 0, 0], max: [2, 2, 0] }})));\nsim2.traction(b2.boundary(), [0, 0, 1]);\nlet d = sim2.displacement(b2.nodes());\nsim2.insert_joints(#{{ between: [b2], law: joint_law(\"tied\", #{{}}), gap_tolerance: 1e-6 }});\n"
    );
    let r = run_in(&dir, "same", &text);
    // insert_joints between one body finds no faces: that error is about faces, not handles.
    if let Err(e) = r {
        assert!(!e.contains("cannot be used with"), "{e}");
    }
}

// ─── Size guards, memory estimates, bounded reads ─────────────────────────────────────────

/// Sizes whose integer products used to overflow (an abort or a panic), or that allocated
/// gigabytes before their own check: each a placed error naming the key or the estimate.
#[test]
fn oversized_meshes_are_refused_before_anything_is_allocated() {
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "divisions",
            "let m = box(#{ min: [0, 0, 0], max: [1, 1, 1] }).mesh(#{ divisions: [4194304, 4194304, 4194304] });",
            &["mesh()", "too many", ":1:"],
        ),
        (
            "size",
            "let m = box(#{ min: [0, 0, 0], max: [1, 1, 1] }).mesh(#{ size: 2.4e-7 });",
            &["mesh()", "too many"],
        ),
        (
            "memory",
            "let m = box(#{ min: [0, 0, 0], max: [1, 1, 1] }).mesh(#{ divisions: [7000, 7000, 1] });",
            &["mesh()", "would need about", "of memory"],
        ),
        (
            "voussoirs",
            "let a = arch(#{ radius: 1.0, thickness: 0.2, depth: 0.3, voussoirs: 4600000000000000000 });",
            &["arch()", "'voussoirs' must be ≤ 1000000"],
        ),
        (
            "wall",
            "let w = wall(#{ courses: 1000000, bricks_per_course: 1000000, brick: [0.2, 0.1, 0.1] });",
            &["wall()", "too many"],
        ),
        (
            "dome",
            "let d = dome(#{ radius: 5.0, thickness: 0.5, courses: 1000000, blocks_per_course: 1000000 });",
            &["dome()", "too many"],
        ),
        (
            "dome_size",
            "let d = dome(#{ radius: 5.0, thickness: 0.5, courses: 10, blocks_per_course: 12, size: 1e-300 });",
            &["dome()", "too many"],
        ),
        (
            "array",
            "let m = box(#{ min: [0, 0, 0], max: [1, 1, 1] }).mesh(#{ divisions: [1, 1, 1] });\nlet a = array(m, #{ count: [2147483648, 2147483648, 4], spacing: [1, 1, 1] });",
            &["array()", "too many", ":2:"],
        ),
        (
            "notch",
            "let m = notched_beam(#{ length: 0.5, height: 0.1, width: 0.05, notch_depth: 0.03, notch_width: 1e-9 });",
            &["notched_beam()", "too many"],
        ),
    ];
    for (name, text, words) in cases {
        let t = std::time::Instant::now();
        let e = error_of(&format!("size_{name}"), text);
        assert_has(&e, words);
        assert!(
            t.elapsed().as_secs_f64() < 5.0,
            "{name} took {:?}",
            t.elapsed()
        );
    }
}

/// `read_table("/dev/zero")` read without bound; a ground-motion record likewise. Now both
/// stop at the limit with the path in the message.
#[test]
fn endless_input_files_are_read_up_to_a_limit() {
    let e = error_of("dev_zero_table", "let t = read_table(\"/dev/zero\");");
    assert_has(&e, &["read_table()", "/dev/zero", "larger than"]);
    let e = error_of(
        "dev_zero_record",
        "let g = ground_motion(\"/dev/zero\", #{ dt: 0.01 });",
    );
    assert_has(&e, &["/dev/zero", "larger than"]);
    let dir = common::temp_dir("dev_zero_mesh");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.msh")).unwrap();
    let e = run_in(&dir, "z", "let m = gmsh(\"zero.msh\");").unwrap_err();
    assert_has(&e, &["zero.msh", "larger than"]);
}
