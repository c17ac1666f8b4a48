//! The scripts users run, and what users see when a script is wrong: every `scripts/*.rhai`
//! runs in its quick mode (its self-checks are assertions), and bad input fails with
//! file:line:col and a message that names the problem.

mod common;

use common::{fdem, run_script, temp_dir};
use std::path::{Path, PathBuf};

/// Run `fdem run` on script text; returns (success, stdout, stderr).
fn run_text(name: &str, text: &str, extra: &[&str]) -> (bool, String, String) {
    run_script(&temp_dir(name), name, text, extra)
}

/// [`run_text`] without `--quiet`: the end-of-run summaries are printed.
fn run_text_with_summary(name: &str, text: &str) -> (bool, String, String) {
    common::run_script_with(&temp_dir(name), name, text, &[])
}

#[test]
fn every_bundled_script_runs_in_quick_mode_and_passes_its_self_checks() {
    let scripts: Vec<PathBuf> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "rhai"))
            .collect();
    assert!(scripts.len() >= 3);
    for s in scripts {
        let name = s.file_stem().unwrap().to_string_lossy().into_owned();
        let out_dir = temp_dir(&format!("script-{name}"));
        let out = fdem()
            .arg("run")
            .arg(&s)
            .args(["--set", "quick=true", "--quiet", "--out"])
            .arg(&out_dir)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{name} failed:\n{stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.contains("check ok:"), "{name} has no self-check");
        assert!(!stdout.contains("check failed"));
        // What the script prints is for people (`fmt(..)`, not 17-digit floats).
        for line in stdout.lines() {
            assert!(!has_long_decimals(line), "{name} prints: {line}");
        }
        assert!(
            out_dir.join("energy.csv").exists(),
            "{name} wrote no energy.csv"
        );
        // Every script says what it models, how to run it and its quick mode.
        let text = std::fs::read_to_string(&s).unwrap();
        for needle in ["//! ", "Run:", "Quick:", "--set quick=true", "Output:"] {
            assert!(text.contains(needle), "{name}: header lacks '{needle}'");
        }
        // `fdem check` validates without running.
        let check = fdem().arg("check").arg(&s).output().unwrap();
        assert!(
            check.status.success(),
            "fdem check {name}: {}",
            String::from_utf8_lossy(&check.stderr)
        );
        assert!(String::from_utf8_lossy(&check.stdout).contains("ok: model"));
    }
}

/// A run of 10 or more digits after a decimal point (`157.00000000001262`).
fn has_long_decimals(line: &str) -> bool {
    line.split('.')
        .skip(1)
        .any(|after| after.chars().take_while(char::is_ascii_digit).count() >= 10)
}

/// Numbers are printed for people: `fmt(x, digits [, unit])` in scripts, the run summary and
/// `fdem check` show a few significant digits, never a float's full round-trip form.
#[test]
fn printed_numbers_are_for_people() {
    let dir = temp_dir("numbers");
    let path = dir.join("numbers.rhai");
    let text = r#"let sim = simulation(#{});
let steel = material("elastic/munjiza", #{ density: 7850.0, young: 200.0e9, poisson: 0.3 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.05 }), steel);
sim.fix(b.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] })));
sim.gravity([0.0, 0.0, -9.81]);
print(`raw ${157.00000000001262} ${0.1 + 0.2}`);
print(`mass ${fmt(b.mass, 4, "kg")}`);
print(`fmt: ${fmt(157.00000000001262, 4)} | ${fmt(1.0013e-3, 5, "m")} | ${fmt(-1.0e-12, 3)} | ${fmt(1.0e12, 3)} | ${fmt(0.0, 3)} | ${fmt(42, 3, "joints")} | ${fmt([0.009000000000000001, 0.0009999999999999998], 3, "m³")}`);
sim.run(#{ steps: 20 });
"#;
    let (ok, stdout, stderr) = common::run_script_with(&dir, "numbers", text, &[]);
    assert!(ok, "{stdout}\n{stderr}");
    // The detector works: Rhai's own float interpolation is what `fmt` replaces.
    assert!(
        stdout.contains("raw 157.00000000001262 0.30000000000000004"),
        "{stdout}"
    );
    assert!(stdout.contains("mass 7.85 kg\n"), "{stdout}");
    assert!(
        stdout.contains(
            "fmt: 157 | 0.0010013 m | -1e-12 | 1e12 | 0 | 42 joints | [0.009, 0.001] m³\n"
        ),
        "{stdout}"
    );
    let summary = &stdout[stdout
        .find("── numbers: 20 steps to t = ")
        .expect("a run summary")..];
    for line in summary.lines() {
        assert!(!has_long_decimals(line), "summary line: {line}");
    }
    for label in ["kinetic", "strain", "external work", "balance error"] {
        let line = summary
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap_or_else(|| panic!("no '{label}' in\n{summary}"));
        assert!(!line.contains("e0"), "{line}");
    }
    // The energy column stays aligned: every value ends in the same column.
    let ends: Vec<usize> = [
        "kinetic",
        "strain",
        "external work",
        "dissipated",
        "balance error",
    ]
    .iter()
    .map(|label| {
        let line = summary
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap();
        line.split("   (").next().unwrap().chars().count()
    })
    .collect();
    assert!(ends.windows(2).all(|w| w[0] == w[1]), "{ends:?}\n{summary}");
    // `fdem check` reports the mass the same way.
    let check = fdem().arg("check").arg(&path).output().unwrap();
    let check = String::from_utf8_lossy(&check.stdout);
    assert!(check.contains(", mass 7.85 kg\n"), "{check}");
    // Bad digits and non-numbers are errors that say what fmt takes.
    for (call, expected) in [
        ("fmt(1.5, 0)", "fmt(): digits must be 1 to 17, got 0"),
        (
            "fmt(1.5, 18, \"m\")",
            "fmt(): digits must be 1 to 17, got 18",
        ),
        (
            "fmt(\"a\", 3)",
            "fmt(): expected a number or an array of numbers, got string (a)",
        ),
        (
            "fmt([1.0, \"a\"], 3)",
            "fmt(): expected a number or an array of numbers, got string (a)",
        ),
    ] {
        let (ok, _, err) = run_script(&dir, "bad_fmt", &format!("print({call});\n"), &[]);
        assert!(!ok, "{call}");
        assert!(
            err.contains("bad_fmt.rhai:1:7: error: ") && err.contains(expected),
            "{call}: {err}"
        );
    }
}

#[test]
fn syntax_error_names_file_line_and_column() {
    let (ok, _, err) = run_text(
        "syntax",
        "let p = params(#{ h: 0.1 });\nlet x = (1 + ;\n",
        &[],
    );
    assert!(!ok);
    assert!(err.contains("syntax.rhai:2:14: error:"), "{err}");
    assert!(
        err.contains("let x = (1 + ;"),
        "the source line is shown: {err}"
    );
}

#[test]
fn unknown_key_is_named_with_the_allowed_keys() {
    let text = "let sim = simulation(#{});\nlet rock = material(\"elastic/munjiza\",\n    #{ densty: 2500.0, young: 1e9, poisson: 0.2 });\n";
    let (ok, _, err) = run_text("key", text, &[]);
    assert!(!ok);
    assert!(
        err.contains("key.rhai:2:12: error: material(): unknown key 'densty'"),
        "{err}"
    );
    assert!(err.contains("did you mean 'density'?"), "{err}");
    assert!(
        err.contains("allowed keys: young, poisson, density, viscosity"),
        "{err}"
    );
}

/// A key that names one of a few values (`Opts::choice`) refuses any other with the key,
/// the value given and every allowed one, at the call's line.
#[test]
fn a_value_not_among_a_keys_choices_is_named_with_the_allowed_ones() {
    let head = "let sim = simulation(#{});\nlet m = material(\"elastic/neo_hookean\", #{ density: 2500.0, young: 1e9, poisson: 0.2 });\nlet mesh = box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ divisions: [2, 2, 2] });\n";
    for (call, expect) in [
        ("sim.add_body(\"b\", mesh, m, #{ layout: \"solid\" });", "add_body(): layout \"solid\" is not \"continuous\", \"jointed\" or \"rigid\""),
        ("box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ divisions: [2, 2, 2], pattern: \"zigzag\" });", "mesh(): pattern \"zigzag\" is not \"kuhn\" or \"alternating\""),
        ("joint_law(\"cohesive/munjiza\", #{ tensile_strength: 1e6, cohesion: 2e6, friction_angle: 30.0, g_i: 10.0, g_ii: 50.0, calibration: \"y\" });", "calibration \"y\" is not \"exact\" or \"y_compatible\""),
        ("simulation(#{ vtk_encoding: \"ascii\" });", "simulation(): vtk_encoding \"ascii\" is not \"raw\" or \"base64\""),
        ("simulation(#{ vtk_pieces: \"per_node\" });", "simulation(): vtk_pieces \"per_node\" is not \"one\" or \"per_rank\""),
        ("let b = sim.add_body(\"b\", mesh, m); straight_bar(b, #{ axis: \"w\", at: [0.5, 0.5] });", "straight_bar(): axis \"w\" is not \"x\", \"y\" or \"z\""),
    ] {
        let (ok, _, err) = run_text("choice", &format!("{head}{call}\n"), &[]);
        assert!(!ok, "{call} was accepted");
        assert!(err.contains(expect) && err.contains("choice.rhai:4:"), "{call}: {err}");
    }
}

/// `elastic/mooney_rivlin` from a script: its constants read back (μ = 2(C₁₀ + C₀₁) = 1 MPa,
/// K = 50 MPa give E = 9Kμ/(3K + μ) = 2.980 MPa), and a key of the other laws is refused
/// with the laws that take it and the keys this one takes.
#[test]
fn mooney_rivlin_material_from_a_script() {
    let text = "let m = material(\"elastic/mooney_rivlin\", #{ density: 1100.0, c10: 0.4e6, c01: 0.1e6, bulk: 50.0e6 });\nexpect_near(\"c10\", m.c10, 0.4e6, 1e-12);\nexpect_near(\"c01\", m.c01, 0.1e6, 1e-12);\nexpect_near(\"bulk\", m.bulk, 50.0e6, 1e-12);\nexpect_near(\"young\", m.young, 9.0 * 50.0e6 * 1.0e6 / (150.0e6 + 1.0e6), 1e-12);\nprint(m.law);\n";
    let (ok, out, err) = run_text("mooney", text, &[]);
    assert!(ok, "{err}");
    assert!(out.contains("elastic/mooney_rivlin"), "{out}");
    let text = "let m = material(\"elastic/mooney_rivlin\",\n    #{ density: 1100.0, young: 1e6, c10: 0.4e6, c01: 0.1e6, bulk: 50.0e6 });\n";
    let (ok, _, err) = run_text("mooney_key", text, &[]);
    assert!(!ok);
    assert!(
        err.contains("mooney_key.rhai:1:9: error: material(\"elastic/mooney_rivlin\"): key 'young' belongs to \"elastic/small_strain\""),
        "{err}"
    );
    assert!(
        err.contains("takes c10, c01, bulk, density, viscosity"),
        "{err}"
    );
    let text = "let m = material(\"elastic/mooney_rivlin\", #{ density: 1100.0, c10: 0.4e6, c01: 0.1e6 });\n";
    let (ok, _, err) = run_text("mooney_missing", text, &[]);
    assert!(!ok);
    assert!(err.contains("bulk"), "{err}");
}

#[test]
fn misspelled_variable_is_a_compile_error_with_its_place() {
    let text = "let size = 0.1;\nlet b = box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ size: sise });\n";
    let (ok, _, err) = run_text("var", text, &[]);
    assert!(!ok);
    assert!(
        err.contains("var.rhai:2:") && err.contains("Undefined variable: sise"),
        "{err}"
    );
}

#[test]
fn inverted_tet_is_named_with_its_place() {
    let text = r#"let sim = simulation(#{});
let m = material("elastic/munjiza", #{ density: 1.0, young: 1.0, poisson: 0.2 });
let mesh = tet_mesh(#{ nodes: [[0.0,0.0,0.0],[1.0,0.0,0.0],[0.0,1.0,0.0],[0.0,0.0,1.0],[1.0,1.0,1.0]],
                       tets: [[0,1,2,3],[1,2,3,4],[0,2,1,3]] });
sim.add_body("b", mesh, m);
"#;
    let (ok, _, err) = run_text("inverted", text, &[]);
    assert!(!ok);
    assert!(
        err.contains("inverted.rhai:5:5: error: add_body(): body 'b'"),
        "{err}"
    );
    assert!(
        err.contains("tet 2 is inverted") && err.contains("(0.250000, 0.250000, 0.250000)"),
        "{err}"
    );
}

#[test]
fn unknown_set_parameter_lists_the_parameters() {
    let (ok, _, err) = run_text(
        "set",
        "let p = params(#{ size: 0.1, quick: false });\n",
        &["--set", "sise=0.2"],
    );
    assert!(!ok);
    assert!(err.contains("--set sise=0.2: the script has no parameter 'sise' (did you mean 'size'?); its parameters are: quick, size"), "{err}");
    let (ok, _, err) = run_text(
        "settype",
        "let p = params(#{ quick: false });\n",
        &["--set", "quick=yes"],
    );
    assert!(!ok && err.contains("'quick' is a bool"), "{err}");
}

#[test]
fn time_step_above_critical_is_refused_with_the_element() {
    let text = r#"let sim = simulation(#{});
let m = material("elastic/munjiza", #{ density: 1000.0, young: 1e6, poisson: 0.2 });
sim.add_body("b", box(#{ min: [0.0,0.0,0.0], max: [1.0,1.0,1.0] }).mesh(#{ size: 0.5 }), m);
sim.integrator("central_difference", #{ dt: 1.0 });
sim.run(#{ steps: 10 });
"#;
    let (ok, _, err) = run_text("dt", text, &[]);
    assert!(!ok);
    assert!(
        err.contains(
            "dt.rhai:5:5: error: run(): dt = 1.0000e0 s is larger than the critical time step"
        ),
        "{err}"
    );
    assert!(
        err.contains("set by tet") && err.contains("of body 'b' at ("),
        "{err}"
    );
}

#[test]
fn errors_inside_functions_show_the_call_chain() {
    let text = r#"fn advance(sim) { sim.run(#{ stepz: 3 }) }
let sim = simulation(#{});
let m = material("elastic/munjiza", #{ density: 1000.0, young: 1e6, poisson: 0.2 });
sim.add_body("b", box(#{ min: [0.0,0.0,0.0], max: [1.0,1.0,1.0] }).mesh(#{ size: 0.5 }), m);
advance(sim);
"#;
    let (ok, _, err) = run_text("chain", text, &[]);
    assert!(!ok);
    assert!(
        err.contains("chain.rhai:1:23: error: run(): unknown key 'stepz' (did you mean 'steps'?)"),
        "{err}"
    );
    assert!(
        err.contains("in function 'advance' called at") && err.contains("chain.rhai:5:1"),
        "{err}"
    );
}

#[test]
fn failed_self_check_fails_the_run() {
    let (ok, _, err) = run_text(
        "selfcheck",
        "expect_within(\"answer\", 41.0, 42.0, 43.0);\n",
        &[],
    );
    assert!(!ok);
    assert!(
        err.contains("selfcheck.rhai:1:1: error: self-check failed: answer"),
        "{err}"
    );
}

/// A run whose self-check fails still prints its end-of-run summary (timing and energy):
/// that is when the user needs it most.
#[test]
fn summary_is_printed_when_a_self_check_fails() {
    let (ok, out, err) = run_text_with_summary(
        "failing_model",
        r#"let sim = simulation(#{ name: "failing" });
let m = material("elastic/st_venant_kirchhoff", #{ density: 1000.0, young: 1e6, poisson: 0.3 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ divisions: [1, 1, 1] }), m, #{ layout: "continuous" });
sim.run(#{ steps: 10 });
expect_within("answer", 41.0, 42.0, 43.0);
"#,
    );
    assert!(!ok);
    assert!(err.contains("self-check failed: answer"), "{err}");
    assert!(out.contains("── failing: 10 steps"), "{out}");
    assert!(out.contains("balance error"), "{out}");
}

/// Contact penetration beyond 10 % of the element height (`PENETRATION_WARNING`) is warned
/// once during the run, naming the depth, the time and the percentage, and again in the
/// summary, which always gives the deepest penetration; a jointed body without joints is
/// warned about at the first run. A 0.1 m block (E = 10 MPa, ρ = 1000 kg/m³, Kuhn tets of
/// size 0.05 m: smallest height h = 0.035 m) hits a fixed one at v = 2 m/s. References: at
/// the default penalty p = 10·E the overlap is bounded by about one step's approach,
/// v·dt = 4.3e-4 m = 1.2 % of h (the static thin-layer depth σH/(8p) with σ = ρcv is
/// 1.3e-5 m): measured 0.73 %, no warning. At p = E/1000 the contact spring must absorb the
/// block's kinetic energy, ½ρLv² = 2p·d²·(2/H) per unit area gives d = 16 mm = 45 % of h
/// (an upper estimate: the block deforms too): measured 8.8 mm, 25 %, warned.
#[test]
fn deep_contact_penetration_and_jointless_bodies_are_warned() {
    let model = |penalty: &str| {
        format!(
            r#"let sim = simulation(#{{ name: "drop" }});
let m = material("elastic/small_strain", #{{ density: 1000.0, young: 1.0e7, poisson: 0.0 }});
let base = sim.add_body("base", box(#{{ min: [0.0, 0.0, -0.1], max: [0.1, 0.1, 0.0] }}).mesh(#{{ size: 0.05 }}), m);
let blk = sim.add_body("block", box(#{{ min: [0.0, 0.0, 0.001], max: [0.1, 0.1, 0.101] }}).mesh(#{{ size: 0.05 }}), m);
let loose = sim.add_body("loose", box(#{{ min: [1.0, 0.0, 0.0], max: [1.1, 0.1, 0.1] }}).mesh(#{{ size: 0.05 }}), m, #{{ layout: "jointed" }});
sim.fix(base.nodes());
sim.fix(loose.nodes());
sim.contact_law("potential", #{{ {penalty} }});
sim.initial_velocity(blk.nodes(), [0.0, 0.0, -2.0]);
sim.run(#{{ max_time: 0.01 }});
print(`deepest ${{sim.contact().max_overlap_ratio}}`);
"#
        )
    };
    let (ok, out, err) = run_text_with_summary("drop_soft", &model("penalty: 1.0e4"));
    assert!(ok, "{err}");
    let warned: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("[drop] WARNING: contact penetration"))
        .collect();
    assert_eq!(warned.len(), 1, "warned once: {out}");
    assert!(
        warned[0].contains("% of the element height (limit 10 %)")
            && warned[0].contains(" m at t = "),
        "{}",
        warned[0]
    );
    assert!(
        out.contains("WARNING: contact penetration passed 10 % of the element height"),
        "{out}"
    );
    assert!(out.contains("   deepest penetration  "), "{out}");
    assert!(
        out.contains("[drop] WARNING: body 'loose' is jointed but has no joints"),
        "{out}"
    );
    let (ok, out, err) = run_text_with_summary("drop_default", &model(""));
    assert!(ok, "{err}");
    assert!(!out.contains("WARNING: contact penetration"), "{out}");
    assert!(out.contains("   deepest penetration  "), "{out}");
}

/// An energy account that stops closing is reported on the console when a sample first
/// passes 1 % of the largest term, and again in the summary. Here a second
/// `initial_velocity` kicks the block to 10× its speed between runs (work no term books).
#[test]
fn balance_error_beyond_one_percent_is_warned_during_the_run_and_in_the_summary() {
    let model = |kick: &str| {
        format!(
            r#"let sim = simulation(#{{ name: "kick", energy_every: 5 }});
let m = material("elastic/st_venant_kirchhoff", #{{ density: 1000.0, young: 1e6, poisson: 0.3 }});
let b = sim.add_body("b", box(#{{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }}).mesh(#{{ divisions: [1, 1, 1] }}), m, #{{ layout: "continuous" }});
sim.initial_velocity(b.nodes(), [0.1, 0.0, 0.0]);
sim.run(#{{ steps: 20 }});
{kick}
sim.run(#{{ steps: 20 }});
"#
        )
    };
    let (ok, out, err) = run_text_with_summary(
        "kick",
        &model("sim.initial_velocity(b.nodes(), [1.0, 0.0, 0.0]);"),
    );
    assert!(ok, "{err}");
    let warnings = balance_warnings(&out);
    assert_eq!(warnings.len(), 1, "warned once: {out}");
    assert!(warnings[0].starts_with("[kick] WARNING"), "{}", warnings[0]);
    assert!(
        out.contains("WARNING: the balance error passed 1 %"),
        "{out}"
    );
    // The same model without the kick closes its account: no warning.
    let (ok, out, err) = run_text_with_summary("no_kick", &model(""));
    assert!(ok, "{err}");
    assert!(
        !out.contains("energy balance error") && !out.contains("WARNING"),
        "{out}"
    );
}

/// The relative balance error has a floor: its scale is at least ½·Σ E·V₀·(1e-7)², the
/// model's elastic energy at a strain of 1e-7. Reference: two blocks at rest, the upper
/// meshed finer than the lower, touching, contact on, no load: roundoff leaves energies of
/// ~1e-23 J with an unbooked error of the same size, which read as 1.6 of the largest term
/// and warned before the floor (measured on main). Against the floor (1e-8 J here:
/// ½·1e9 Pa·0.002 m³·1e-14) it must be below 1e-12. The same model kicked between runs to
/// ½·m·v² = 3.1e-9 J (below the floor, 0.31 of it: work no term books) must still warn,
/// with the error over the floor (0.31 ± 5 %: the kick's energy over the floor).
#[test]
fn balance_error_has_a_floor_so_a_model_at_rest_does_not_warn() {
    let model = |kick: &str| {
        format!(
            r#"let sim = simulation(#{{ name: "rest" }});
let m = material("elastic/munjiza", #{{ density: 2500.0, young: 1.0e9, poisson: 0.2 }});
let a = sim.add_body("a", box(#{{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }}).mesh(#{{ divisions: [2, 2, 2] }}), m);
let b = sim.add_body("b", box(#{{ min: [0.0, 0.0, 0.1], max: [0.1, 0.1, 0.2] }}).mesh(#{{ divisions: [3, 3, 3] }}), m);
sim.fix(a.nodes(half_space(#{{ point: [0.0, 0.0, 0.001], normal: [0.0, 0.0, -1.0] }})));
sim.contact_law("potential", #{{ friction: 0.5 }});
sim.run(#{{ steps: 1500 }});
{kick}
sim.run(#{{ steps: 1500 }});
let e = sim.energy();
print(`floor ${{e.floor}} relative ${{e.relative_error}} largest ${{[e.kinetic, e.strain, e.contact].reduce(|m, v| if v > m {{ v }} else {{ m }}, 0.0)}}`);
"#
        )
    };
    let number = |out: &str, key: &str| -> f64 {
        let line = out.lines().find(|l| l.starts_with("floor ")).unwrap();
        let words: Vec<&str> = line.split_whitespace().collect();
        let i = words.iter().position(|w| *w == key).unwrap();
        words[i + 1].parse().unwrap()
    };
    let (ok, out, err) = run_text_with_summary("rest", &model(""));
    assert!(ok, "{err}");
    let floor = number(&out, "floor");
    // ½·E·V·ε² over both blocks, to rounding.
    assert!((floor / 1e-8 - 1.0).abs() < 1e-12, "floor {floor}");
    // Roundoff-level energies: all terms far below the floor, so the floor is the scale.
    assert!(number(&out, "largest") < 1e-6 * floor, "{out}");
    assert!(number(&out, "relative").abs() < 1e-12, "{out}");
    assert!(!out.contains("WARNING"), "a model at rest warned:\n{out}");
    assert!(
        out.contains("of the floor, the model's elastic energy at a strain of 1e-7"),
        "{out}"
    );
    // A real imbalance above 1 % of the floor still warns.
    let (ok, out, err) = run_text_with_summary(
        "rest_kicked",
        &model("sim.initial_velocity(b.nodes(), [5.0e-5, 0.0, 0.0]);"),
    );
    assert!(ok, "{err}");
    let warnings = balance_warnings(&out);
    assert_eq!(warnings.len(), 1, "warned once: {out}");
    assert!(warnings[0].contains("of the floor"), "{}", warnings[0]);
    let rel = number(&out, "relative");
    assert!((rel / 0.3125 - 1.0).abs() < 0.05, "relative error {rel}");
}

/// The place of the element that sets dt is where it is now, written so that a micro-scale
/// model reads (the red blood cell's places printed as 0.0000). Reference: a 8 × 8 × 2 µm
/// block moving at 0.1 m/s; after the first run it is d = 0.1·t away from where it was
/// built (t printed by the script), so the element's x lies in [d, d + 8 µm] (tolerance:
/// the printed 4 significant digits), and every coordinate prints in scientific notation.
#[test]
fn dt_messages_give_the_current_place_readably() {
    let text = r#"let sim = simulation(#{ name: "micro" });
let m = material("elastic/neo_hookean", #{ density: 1100.0, young: 1.0e4, poisson: 0.3 });
let b = sim.add_body("cell", box(#{ min: [0.0, 0.0, 0.0], max: [8.0e-6, 8.0e-6, 2.0e-6] }).mesh(#{ divisions: [2, 2, 1] }), m, #{ layout: "continuous" });
sim.initial_velocity(b.nodes(), [0.1, 0.0, 0.0]);
sim.run(#{ steps: 2000 });
print(`moved at t = ${sim.time}`);
sim.integrator("central_difference", #{ safety: 0.5 });
sim.run(#{ steps: 1 });
sim.integrator("central_difference", #{ dt: 1.0 });
sim.run(#{ steps: 1 });
"#;
    let (ok, out, err) = run_text_with_summary("micro", text);
    assert!(!ok, "dt = 1 s is too large: {out}");
    let t: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("moved at t = "))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let d = 0.1 * t;
    assert!(d > 3.0 * 8e-6, "moved farther than its size: {d}");
    // "(x, y, z)" after "at ": each coordinate in scientific notation, x where it is now.
    let place = |s: &str| -> Vec<String> {
        let p = s.split("of body 'cell' at (").nth(1).unwrap();
        p[..p.find(')').unwrap()]
            .split(", ")
            .map(str::to_string)
            .collect()
    };
    let lines: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("[micro] dt ="))
        .collect();
    assert_eq!(
        lines.len(),
        2,
        "the first run's line and the new safety's:\n{out}"
    );
    let msg = err
        .lines()
        .find(|l| l.contains("is larger than the critical"))
        .unwrap();
    for s in [lines[0], lines[1], msg] {
        let c = place(s);
        assert!(
            c.iter().all(|v| v.contains('e')),
            "scientific notation: {s}"
        );
        let x: f64 = c[0].parse().unwrap();
        let first = std::ptr::eq(s, lines[0]);
        let (lo, hi) = if first { (0.0, 8e-6) } else { (d, d + 8e-6) };
        assert!(
            x >= lo * (1.0 - 1e-3) && x <= hi * (1.0 + 1e-3),
            "x = {x} not in [{lo}, {hi}]: {s}"
        );
    }
}

#[test]
fn doc_command_matches_the_script_reference_page() {
    let out = fdem().arg("doc").output().unwrap();
    assert!(out.status.success());
    let page = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/script-reference.md"),
    )
    .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        page,
        "docs/script-reference.md is stale: regenerate with `fdem doc > docs/script-reference.md`"
    );
}

/// Every documented function is registered: calling it with its documented name must not be
/// "function not found" (checked through `fdem doc`'s table against the engine).
#[test]
fn every_documented_key_is_accepted() {
    // A model that uses every option map with every documented key.
    let text = r#"fn spring(j, p) { #{ normal: p.k * j.opening, shear: p.k * j.slip, damage: 0.0 } }
fn gate(j, p) { j.opening > p.limit || j.damage >= 1.0 }
let p = params(#{ n: 2 });
let sim = simulation(#{ name: "all", out_dir: "ignored", energy_every: 3, stress_output: "pk2", vtk_encoding: "base64", vtk_pieces: "per_rank" });
let m = material("elastic/neo_hookean", #{ density: 1000.0, young: 1e6, poisson: 0.3, viscosity: 1.0 });
let mr = material("elastic/mooney_rivlin", #{ density: 1000.0, c10: 3e5, c01: 5e4, bulk: 1e7, viscosity: 1.0 });
let mesh = box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 0.5, 0.5] }).mesh(#{ divisions: [2, 1, 1], pattern: "alternating" });
mesh.rotate(#{ axis: [0.0, 0.0, 1.0], degrees: 0.0, center: [0.0, 0.0, 0.0] });
let b = sim.add_body("b", mesh, m, #{ layout: "continuous" });
let j = sim.add_body("j", box(#{ min: [0.0, 0.0, 5.0], max: [1.0, 0.5, 5.5] }).mesh(#{ size: 0.5 }), m, #{ layout: "jointed" });
let glue = joint_law("cohesive/munjiza", #{ tensile_strength: 1e5, cohesion: 2e5, friction_angle: 30.0, g_i: 10.0, g_ii: 40.0,
    normal_penalty: 1e7, tangential_penalty: 1e7, residual_friction: 0.5, calibration: "y_compatible", rate_effects: "fib2010",
    dilatancy_angle: 30.0, dilatancy_opening: 1e-3 });
expect_within("joints", sim.insert_joints(#{ within: [j], law: glue, region: box(#{ min: [-1.0, -1.0, 4.0], max: [9.0, 9.0, 6.0] }) }), 1, 100);
// A joint law written in this script, and one from the stdlib, both compiled to native code.
let own = joint_law("script", #{ function: "spring", params: #{ k: 1.0e6 }, normal_penalty: 1e7, tangential_penalty: 1e7 });
let j2 = sim.add_body("j2", box(#{ min: [0.0, 0.0, 7.0], max: [1.0, 0.5, 7.5] }).mesh(#{ size: 0.5 }), m, #{ layout: "jointed" });
expect_within("script joints", sim.insert_joints(#{ within: j2, law: own }), 1, 100);
let std_law = joint_law("script", #{ source: "stdlib/joint_laws", function: "munjiza", params: #{ tensile_strength: 1e5,
    cohesion: 2e5, tan_friction: 0.5, g_i: 10.0, g_ii: 40.0, normal_penalty: 1e7, tangential_penalty: 1e7, k_soft: 3.0 } });
let j3 = sim.add_body("j3", box(#{ min: [0.0, 0.0, 9.0], max: [1.0, 0.5, 9.5] }).mesh(#{ size: 0.5 }), m, #{ layout: "jointed" });
expect_within("stdlib joints", sim.insert_joints(#{ within: j3, law: std_law }), 1, 100);
sim.fracture_criterion(#{ function: "gate", params: #{ limit: 1.0e-3 }, when: "always", every: 10 });
let slab = sim.add_body("slab", box(#{ min: [0.0, 0.0, -0.5], max: [1.0, 0.5, 0.0] }).mesh(#{ divisions: [2, 1, 1] }), m);
expect_within("glue", sim.insert_joints(#{ between: [slab, b], law: glue, gap_tolerance: 1.0e-6 }), 1, 100);
let t = sim.add_body("t", tet_mesh(#{ nodes: [[0.0, 0.0, 11.0], [1.0, 0.0, 11.0], [0.0, 1.0, 11.0], [0.0, 0.0, 12.0]], tets: [[0, 1, 2, 3]] }), m);
let bricks = array(mesh.copy().mirror(#{ point: [0.0, 0.0, 20.0], normal: [0.0, 0.0, 1.0] }), #{ count: [2, 1, 1], spacing: [1.0, 0.0, 0.0] });
let br = sim.add_body("brick", bricks[1], m);
let cell = biconcave_cell(#{ radius: 3.91e-6, c0: 0.81e-6, c1: 7.83e-6, c2: -4.39e-6, center: [0.0, 0.0, 50.0], axis: [1.0, 0.0, 0.0], size: 2.0e-6 });
expect_within("packed cells", random_packing(cell, #{ count: 2, min: [0.0, 0.0, 0.0], max: [3.0e-5, 3.0e-5, 3.0e-5], gap: 1.0e-7, rotate: true, seed: 3, attempts: 1000 }).n_blocks, 2, 2);
expect_within("volume in a box", sim.volume_in_box([b], #{ min: [0.0, 0.0, 0.0], max: [0.5, 0.5, 0.5], at: "reference" }), 0.1249999, 0.1250001);
fn elastic_steel(b, p) { #{ stress: b.young * (b.strain - b.plastic_strain), plastic_strain: b.plastic_strain, history: b.history } }
fn flat_bond(b, p) { p.tau }
let st1 = steel(#{ density: 7800.0, young: 2e11, yield_stress: 4e8, hardening: 1e9, ultimate_strain: 0.2, rate_c: 40.4, rate_p: 5.0 });
let st2 = steel("bilinear", #{ yield_stress: 4e8, ultimate_stress: 5e8, ultimate_strain: 0.2 });
let st3 = steel("script", #{ function: "elastic_steel", params: #{ k: 1.0 }, density: 7800.0, young: 2e11, ultimate_strain: 0.2 });
let bl1 = bond_law("fib2010", #{ fcm: 3e7, confinement: "stirrups", bond: "other", clear_rib_spacing: 0.01, stiffness: 1e10, transverse_stiffness: 1e11 });
let bl2 = bond_law("script", #{ function: "flat_bond", params: #{ tau: 1e6 }, stiffness: 1e10, transverse_stiffness: 1e11 });
let rb = sim.rebar(b, #{ points: straight_bar(b, #{ axis: "x", at: [0.25, 0.25], cover: 0.05 }), diameter: 0.01, area: 8e-5, steel: st1, bond: bl1, segment: 0.3, name: "rb" });
sim.rebar(b, #{ points: stirrup(b, #{ axis: "x", at: 0.5, cover: 0.05, diameter: 0.01 }), diameter: 0.01, steel: st2, bond: bl2 });
sim.rebar(b, #{ points: straight_bar(b, #{ axis: "x", at: [0.1, 0.1] }), diameter: 0.01, steel: st3, bond: bl1, bending: false });
let rg = sim.add_body("rg", box(#{ min: [0.0, 0.0, 30.0], max: [1.0, 0.5, 30.5] }).mesh(#{ divisions: [2, 1, 1] }), m, #{ layout: "rigid" });
rg.prescribe_velocity(#{ x: 0.0, y: table([[0.0, 0.0], [1.0, 1.0]]), z: 0.0, rotation: "fixed" });
let c = b.copy("c");
c.translate([0.0, 0.0, 2.0]);
let faces = b.boundary(#{ normal: [1.0, 0.0, 0.0], tolerance: 1.0, within: half_space(#{ point: [0.9, 0.0, 0.0], normal: [1.0, 0.0, 0.0] }) });
let s = sphere(#{ center: [0.0, 0.0, 0.0], radius: 1.0 });
let cyl = cylinder(#{ base: [0.0, 0.0, 0.0], axis: [1.0, 0.0, 0.0], radius: 1.0, length: 0.1 });
sim.fix(b.nodes(cyl));
sim.prescribe_velocity(c.nodes(s), #{ x: 0.0, y: table([[0.0, 0.0], [1.0, 1.0]]), z: 0.0 });
sim.traction(faces, [0.0, 0.0, -1.0]);
let g1 = disc(#{ radius: 0.1, thickness: 0.05, center: [5.0, 5.0, 5.0], axis: [0.0, 0.0, 1.0], size: 0.05 });
let g2 = hollow_cylinder(#{ inner_radius: 0.1, outer_radius: 0.2, length: 0.1, base: [5.0, 5.0, 5.0], axis: [0.0, 1.0, 0.0], size: 0.05 });
let g3 = notched_beam(#{ length: 1.0, height: 0.2, width: 0.1, notch_depth: 0.05, notch_width: 0.05, span: 0.8, origin: [5.0, 5.0, 5.0], size: 0.1 });
let g4 = arch(#{ radius: 1.0, thickness: 0.2, depth: 0.2, voussoirs: 3, span_angle: 180.0, center: [5.0, 5.0, 5.0], size: 0.2 });
let g5 = wall(#{ courses: 2, bricks_per_course: 2, brick: [0.2, 0.1, 0.1], head_gap: 0.0, bed_gap: 0.0, origin: [5.0, 5.0, 5.0], size: 0.1 });
let g6 = dome(#{ radius: 1.0, thickness: 0.2, courses: 2, blocks_per_course: 4, oculus: 20.0, base: 90.0, center: [5.0, 5.0, 5.0], size: 0.2 });
let g7 = cloister_vault(#{ span: 4.0, thickness: 0.3, courses: 1, blocks_per_web: 1, profile_ratio: 0.8, profile: "webs", oculus: 1.0, ribs: true, rib_width: 0.5, rib_depth: 0.2, center: [5.0, 5.0, 5.0], size: 0.3 });
let voussoirs = sim.add_blocks(g4, m, #{ layout: "continuous", prefix: "voussoir" });
sim.contact_law("potential", #{ penalty: 1e7, tangential_penalty: 1e7, friction: 0.5, damping: 0.1 });
sim.contact_law("potential", #{ between: [m, m], friction: 0.3 });
fn mu(c, p) { p.mu0 + p.k * c.slip_rate }
sim.contact_law("potential", #{ between: [m, m], friction: 0.3, friction_law: #{ function: "mu", params: #{ mu0: 0.3, k: 0.1 } } });
sim.contact_law("potential", #{ between: [m, m], friction_law: #{ source: "stdlib/friction_laws", function: "slip_weakening", params: #{ mu_s: 0.6, mu_d: 0.3, d_c: 1e-3 } } });
sim.contact_detection(#{ skin: 0.01 });
sim.on_new_contact_pair(|s, pair| ());
sim.integrator("central_difference", #{ safety: 0.5, dt: 1e-5 });
sim.damping(#{ mass_proportional: 1.0, frame: "body" });
sim.gravity([0.0, 0.0, -9.81], #{ ramp: 1e-4, start: 0.0 });
let sel = b.nodes(cyl, #{ at: "reference" });
let bb = b.bounds(#{ at: "current" });
sim.every(#{ steps: 2 }, |s| s.write_vtk());
sim.every(#{ steps: 3 }, |s| s.repartition(#{ if_moved: 0.2, if_imbalance: 1.1, weigh: "work" }));
sim.every(#{ time: 1e-5 }, |s| ());
let mon = sim.monitor("m", #{ every: 1, unit: "s" }, |s| s.time);
sim.run(#{ max_time: 1.0, duration: 1e-4, steps: 5, stop_when: |s| false, check_every: 1 });
expect_within("steps", sim.step, 5, 5);
sim.plot(#{ file: "p", y: [mon], x: "time", x_label: "t [s]", y_label: "time again [s]", title: "T", format: "svg", width: 300, height: 200 });
sim.plot_energy(#{ file: "e", title: "E", format: "png", width: 300, height: 300 });
let rest = sim.bring_to_rest(#{ ratio: 1e-3, max_steps: 3, check_every: 1, damping: 1.0 });
expect_within("rest stage steps", rest.steps, 1, 3);
let eq = ground_motion("@GM@", #{ format: "at2", units: "g", scale: 0.5, start: 1.0, end: 10.0, baseline: true });
let eq2 = ground_motion("@GM@", #{ units: "m/s2", pga: 1.0, dt: 0.01 });
expect_within("records", eq.duration + eq2.duration, 49.0, 50.0);
"#
    .replace(
        "@GM@",
        &format!("{}/data/ground_motion/IELC180.AT2", env!("CARGO_MANIFEST_DIR")),
    );
    let text = text.as_str();
    let (ok, out, err) = run_text("allkeys", text, &[]);
    assert!(ok, "{out}\n{err}");
    // The run covered every option map of the API table.
    for f in fdem::script::api::API.iter() {
        let law_keys = f.laws.iter().flat_map(|l| l.params.iter());
        for k in f.keys.iter().chain(law_keys) {
            assert!(
                text.contains(&format!("{}:", k.name)),
                "key '{}' of {} is not exercised",
                k.name,
                f.name
            );
        }
    }
}

/// An unstable run stops with what went wrong and where, not with garbage output.
#[test]
fn blow_up_is_reported_with_step_and_place() {
    use fdem::material::{Formulation, Material};
    let mut sim = fdem::Simulation::new();
    let m =
        sim.add_material(Material::new(Formulation::NeoHookean, 1000.0, 1e6, 0.3, 0.0).unwrap());
    let mesh = fdem::mesh::box_mesh(
        fdem::math::Vec3::zeros(),
        fdem::math::Vec3::new(1.0, 1.0, 1.0),
        [2, 2, 2],
    );
    sim.add_body("cube", &mesh, m, fdem::Layout::Continuous)
        .unwrap();
    sim.nodes.v[0] = fdem::math::Vec3::new(1.0, 0.0, 0.0);
    sim.prepare().unwrap();
    sim.dt *= 20.0; // far beyond the critical step
    sim.settings.energy_every = 1;
    let err = (0..10_000)
        .find_map(|_| sim.step().err())
        .expect("the run must blow up");
    let msg = err.to_string();
    assert!(msg.starts_with("unstable run:"), "{msg}");
    assert!(
        msg.contains("body 'cube'") && msg.contains("in step"),
        "{msg}"
    );
}

/// The README's example script runs as printed.
#[test]
fn readme_example_runs() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let start = readme.find("```rhai\n").expect("README has a rhai example") + 8;
    let end = start + readme[start..].find("```").unwrap();
    let text = &readme[start..end];
    assert!(
        text.lines().count() <= 16,
        "the README example should stay short"
    );
    let (ok, out, err) = run_text("readme", text, &["--set", "quick=true"]);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("tip deflection"));
}

/// Regression: a block crushed far beyond what the mesh can take, for fewer steps than
/// `energy_every`, used to end "successfully" with NaN positions. The run must fail and say
/// what broke and where.
#[test]
fn blow_up_between_energy_samples_fails_the_run() {
    let text = r#"let sim = simulation(#{ energy_every: 1000 });
let rubber = material("elastic/neo_hookean", #{ density: 1100.0, young: 1.0e6, poisson: 0.45 });
let b = sim.add_body("block", box(#{ min: [0.0, 0.0, 0.0], max: [0.1, 0.1, 0.1] }).mesh(#{ size: 0.025 }), rubber);
sim.fix(b.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] })));
sim.prescribe_velocity(b.nodes(half_space(#{ point: [0.0, 0.0, 0.1], normal: [0.0, 0.0, 1.0] })), #{ z: -200.0 });
sim.run(#{ steps: 38 });
print("finished");
"#;
    let (ok, out, err) = run_text("crush", text, &[]);
    assert!(!ok, "the run must fail: {out}");
    assert!(!out.contains("finished"));
    assert!(
        err.contains("crush.rhai:6:5: error: run(): unstable run:"),
        "{err}"
    );
    assert!(err.contains("body 'block'"), "{err}");
}

/// A friction law in a script: the example of docs/theory/contact.md ("Custom friction laws")
/// runs as printed there and passes its self-check (terminal slip speed within 2 %), and bad
/// laws fail with the script's line and a message naming the problem: an unknown function
/// (the defined ones listed, closures left out), a misspelled key of `friction_law` (the
/// allowed ones listed), a construct outside the compiled subset (its line in the function),
/// and a negative μ at run time (the function, value and inputs).
#[test]
fn friction_law_example_runs_and_bad_laws_are_named() {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/theory/contact.md"),
    )
    .unwrap();
    let section = &doc[doc.find("## Custom friction laws").expect("section")..];
    let start = section.find("```rhai\n").expect("a rhai example") + 8;
    let text = &section[start..start + section[start..].find("```").unwrap()];
    let (ok, out, err) = run_text("friction_law", text, &[]);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("check ok: terminal slip speed"), "{out}");
    // The output shown under the example is this run's.
    let shown = &section[start + section[start..].find("```text\n").unwrap() + 8..];
    let shown = &shown[..shown.find("```").unwrap()];
    for line in shown
        .lines()
        .filter(|l| l.starts_with("slip speed") || l.starts_with("check ok"))
    {
        assert!(
            out.contains(line),
            "docs show '{line}', the run printed:\n{out}"
        );
    }
    let cases = [
        (
            text.replace("function: \"mu\"", "function: \"my_mu\""),
            "error: contact_law(): friction law: no function 'my_mu' in the script; functions defined: mu\n",
        ),
        (
            text.replace("function: \"mu\"", "funtion: \"mu\""),
            "error: contact_law(): friction_law: unknown key 'funtion' (did you mean 'function'?); allowed keys: function, params, source",
        ),
        (
            text.replace("p.mu0 + p.k * c.slip_rate", "let m = 0.0;\n    while m < p.mu0 { m += 0.1; }\n    m"),
            "error: contact_law(): friction law 'mu': line 4: a loop is not supported in compiled functions",
        ),
        (
            text.replace("p.mu0 + p.k * c.slip_rate", "p.mu0 - 10.0 * p.k * c.slip_rate"),
            "error: run(): friction law 'mu' returned friction = -",
        ),
    ];
    for (bad, expected) in cases {
        let (ok, out, err) = run_text("bad_friction_law", &bad, &[]);
        assert!(!ok, "{out}");
        assert!(err.contains(expected), "expected '{expected}' in:\n{err}");
        assert!(err.contains("bad_friction_law.rhai:"), "{err}");
    }
}

/// Reference: the geometry of the model. Two boxes stacked on z = 0.5 and glued, the upper
/// one pulled up: every broken joint reports the two bodies (0 below, 1 above, in the
/// order added) and the unit normal of its face from side A to side B (±z, pointing from
/// the body of side A to the other).
#[test]
fn broken_joint_events_name_both_bodies_and_the_normal() {
    let text = r#"
let sim = simulation(#{ name: "events" });
let m = material("elastic/munjiza", #{ density: 2000.0, young: 1.0e9, poisson: 0.2 });
let a = sim.add_body("a", box(#{ min: [0.0, 0.0, 0.0], max: [0.2, 0.2, 0.5] }).mesh(#{ divisions: [1, 1, 2] }), m);
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.5], max: [0.2, 0.2, 1.0] }).mesh(#{ divisions: [1, 1, 2] }), m);
let glue = joint_law("cohesive/munjiza", #{ tensile_strength: 1.0e5, cohesion: 2.0e5, g_i: 1.0, g_ii: 5.0 });
sim.insert_joints(#{ between: [a, b], law: glue });
sim.fix(a.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, -1.0] })));
sim.prescribe_velocity(b.nodes(half_space(#{ point: [0.0, 0.0, 1.0], normal: [0.0, 0.0, 1.0] })), [0.0, 0.0, 0.5]);
let events = [];
sim.on_joint_broken(|s, j| events.push(j));
sim.run(#{ max_time: 0.01 });
expect_within("joints broken", events.len(), 1, 100);
for j in events {
    let ids = j.bodies;
    expect_within("two different bodies", abs(ids[0] - ids[1]), 1, 1);
    let up = if ids[0] == 0 { 1.0 } else { -1.0 };
    expect_near("normal z", j.normal[2], up, 1e-12);
    expect_within("normal x", abs(j.normal[0]), 0.0, 1e-12);
}
"#;
    let (ok, out, err) = run_text("events", text, &[]);
    assert!(ok, "{out}\n{err}");
}

/// The notched beam's two gmsh bands (scripts/meshes/notched_beam_band*.geo) mesh and match the
/// structured halves face for face: the script throws unless the band's sides carry exactly
/// 4·ny·nz glue joints (two triangles per cell on each side), so a .geo whose side faces drift
/// from the box generator's diagonals fails here. Both sizes of the page's mesh study.
#[test]
#[ignore = "needs gmsh"]
fn notched_beam_gmsh_bands_match_the_structured_halves() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/notched_beam.rhai");
    for mesh in ["gmsh", "gmsh_plane"] {
        for size in ["0.025", "0.016666666666666666"] {
            let out = fdem()
                .arg("check")
                .arg(&script)
                .args([
                    "--set",
                    &format!("mesh={mesh}"),
                    "--set",
                    &format!("size={size}"),
                ])
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success() && stdout.contains("ok: model"),
                "mesh={mesh} size={size}:\n{stdout}\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            assert!(stdout.contains(&format!("{mesh} band")), "{stdout}");
        }
    }
}

/// The red-blood-cell script's sphere check (issue 13: check the pipeline with rigid spheres
/// first) runs in quick mode with its self-checks, as rigid bodies meshed by the same generator
/// (the printed volume is the 384-tet polyhedron's, 0.93 of the sphere's 250.4 µm³: the
/// generator's sphere, not a cell of 94 µm³); an unknown shape is refused naming the two.
#[test]
fn red_blood_cells_sphere_check_runs_and_unknown_shapes_are_refused() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/red_blood_cells.rhai");
    let run = |shape: &str| {
        let out = fdem()
            .arg("run")
            .arg(&script)
            .args(["--set", "quick=true", "--set"])
            .arg(format!("shape={shape}"))
            .args(["--quiet", "--out"])
            .arg(temp_dir(&format!("rbc-{shape}")))
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, out, err) = run("sphere");
    assert!(ok && !out.contains("check failed"), "{out}\n{err}");
    let volume: f64 = out
        .lines()
        .find_map(|l| l.split("tets, ").nth(1)?.split(" µm³").next()?.parse().ok())
        .unwrap_or_else(|| panic!("no volume line:\n{out}"));
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 3.91f64.powi(3);
    assert!(
        (volume / sphere - 0.93).abs() < 0.02,
        "{volume} µm³ vs sphere {sphere}"
    );
    let (ok, out, err) = run("cube");
    assert!(
        !ok && err.contains("\"cube\" is not \"cell\" or \"sphere\""),
        "{out}\n{err}"
    );
}

/// The run-time energy-balance warnings a run printed.
fn balance_warnings(out: &str) -> Vec<&str> {
    out.lines()
        .filter(|l| l.contains("WARNING: energy balance error"))
        .collect()
}

/// The Brazilian disc's optional pads (`cushion`): the quick disc with 2 mm pads of 1 GPa
/// between platens and disc passes the script's own checks (σ_t/f_t in 0.85–1.10, the split on
/// the loaded diameter, quasi-static platens, energy balance), and the pads, whose contact
/// rules give them 50 GPa against 500 GPa rock on rock, lower the time step by their own
/// springs only: within 10 % of the padless disc's (measured 6 %: 3.73e-8 against 3.98e-8 s).
/// Before 2026-11-30 stage 5 bounded every tet at the model's largest penalty and the pads
/// cut dt 3.2-fold (docs/applications/brazilian_disc.md).
#[test]
fn brazilian_disc_with_pads_splits_and_keeps_the_time_step() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/brazilian_disc.rhai");
    let run = |extra: &[&str]| {
        let out_dir = temp_dir(&format!("pads-{}", extra.len()));
        let out = fdem()
            .arg("run")
            .arg(&script)
            .args(["--set", "quick=true", "--out"])
            .arg(&out_dir)
            .args(extra)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{extra:?}:\n{stdout}\n{stderr}");
        let dt = format!("{stdout}{stderr}")
            .lines()
            .find_map(|l| {
                l.split("dt = ")
                    .nth(1)
                    .map(|r| r.split(' ').next().unwrap().to_string())
            })
            .expect("a dt line");
        (stdout, dt)
    };
    let (_, dt_bare) = run(&[]);
    let (padded, dt_pads) = run(&["--set", "cushion=2", "--set", "cushion_E=1"]);
    assert!(padded.contains("check ok: σ_t / f_t"), "{padded}");
    assert!(!padded.contains("check failed"), "{padded}");
    let (bare, pads): (f64, f64) = (dt_bare.parse().unwrap(), dt_pads.parse().unwrap());
    assert!(
        pads > 0.9 * bare && pads <= bare,
        "dt {pads:e} with pads against {bare:e} without"
    );
}

/// The quick reinforced beam (`scripts/rc_beam_impact.rhai`, 600 kg at 8 m/s, 4 ms) with
/// `extra` settings, on one thread: its console output, after its own checks passed.
fn rc_beam_quick(extra: &[&str], name: &str) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/rc_beam_impact.rhai");
    let out = fdem()
        .arg("run")
        .arg(&script)
        .args(["--set", "quick=true"])
        .args(extra)
        .args(["--quiet", "--threads", "1", "--out"])
        .arg(temp_dir(name))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success() && !text.contains("check failed"),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The number printed between `after` and `before` on the first line that has them.
fn number_between(text: &str, after: &str, before: &str) -> f64 {
    text.lines()
        .find_map(|l| {
            l.split(after)
                .nth(1)?
                .split(before)
                .next()?
                .trim()
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no '{after}' … '{before}' in:\n{text}"))
}

/// The reinforced beam's pad under the weight (`pad_E`, a diagnosis of the first contact,
/// docs/applications/rc_beam_impact.md): a mass m landing at v on a spring k against a
/// rigid base peaks at F = v·√(k·m). The quick beam (600 kg at 8 m/s) with a 20 mm pad of
/// 48 MPa under the weight's 0.06 m² face (k = E·A/t = 1.44e8 N/m): 2.35 MN. 10 %: the
/// beam under the plate is not rigid, and the pad is squeezed by half its thickness, where
/// the neo-Hookean law is stiffer than E. Without the pad the rigid plate's plane wave
/// gives more than twice the pad's force over 0.1 ms.
#[test]
fn the_rc_beam_pad_peaks_at_the_spring_mass_force() {
    let bare = rc_beam_quick(&[], "rc-pad-none");
    let pad = rc_beam_quick(&["--set", "pad_E=48e6"], "rc-pad-48");
    let bare_100us = number_between(&bare, "peak impact force:", " kN");
    let pad_100us = number_between(&pad, "peak impact force:", " kN");
    let pad_peak = number_between(&pad, "step by step", " kN");
    let k = 48.0e6 * 0.06 / 0.02;
    let reference = 8.0 * (k * 600.0f64).sqrt() / 1e3;
    assert!(
        (pad_peak / reference - 1.0).abs() < 0.1,
        "pad peak {pad_peak} kN, spring–mass {reference} kN"
    );
    assert!(
        bare_100us > 2.0 * pad_100us,
        "no pad {bare_100us} kN, pad {pad_100us} kN over 0.1 ms"
    );
}

/// The reinforced beam's hold-down knobs (diagnoses of the 211 kg beams' depth, the page's
/// SS0a table): a loose bearing above takes no hold-down force at all, and the hold-down
/// as a spring (`hold_down_stiffness`) takes less the softer it is, below the rigid one's
/// (quick beam, 4 ms: rigid 477 kN, 2.4e9 N/m 279 kN, 2.4e8 N/m 52 kN). A spring that
/// were not in the load path would take nothing, one that were ignored the rigid force.
#[test]
fn the_rc_beam_hold_down_takes_less_the_softer_it_is() {
    let hold = |extra: &[&str], name: &str| {
        number_between(&rc_beam_quick(extra, name), "(hold-down", " kN)")
    };
    let rigid = hold(&[], "rc-hold-rigid");
    let stiff = hold(&["--set", "hold_down_stiffness=2.4e9"], "rc-hold-stiff");
    let soft = hold(&["--set", "hold_down_stiffness=2.4e8"], "rc-hold-soft");
    let loose = hold(&["--set", "hold_down=false"], "rc-hold-loose");
    assert!(
        rigid > stiff && stiff > soft && soft > 0.05 * rigid && loose == 0.0,
        "hold-down [kN]: rigid {rigid}, 2.4e9 N/m {stiff}, 2.4e8 N/m {soft}, loose {loose}"
    );
}
