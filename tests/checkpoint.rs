//! Checkpoint and restart (issue 15): a run stopped and continued with `fdem run --restart`
//! must write exactly what the run that never stopped writes — every frame, every CSV row,
//! byte for byte — whatever the thread counts of the two runs. The oracle is the
//! uninterrupted run itself, so the tolerance is zero: any state a checkpoint forgets
//! (a joint's history, a contact pair's friction spring, a bar's plastic strain, a rigid
//! body's spin, a hook's clock, the frame numbering) shows up as a differing byte.
//!
//! The model exercises every kind of state at once: a jointed, reinforced concrete beam
//! (cohesive joints that soften and break, a bar with fib2010 bond) on a fixed rigid base,
//! struck by a rigid block, with contact and a compiled (Rhai) friction law, gravity, two runs
//! with a damping change and a self-check between them (skipped by the replay), monitors and
//! periodic frames.

mod common;

use std::path::{Path, PathBuf};

/// The model; `CRASH` is replaced by a statement run in the checkpoint hook (nothing for the
/// reference run, a `throw` for the run that "crashes").
const MODEL: &str = r#"
let p = params(#{ steps: 1500 });
let sim = simulation(#{ name: "ck", energy_every: 10 });
let concrete = material("elastic/neo_hookean", #{ density: 2400.0, young: 3.0e9, poisson: 0.2 });
let steel_m = material("elastic/small_strain", #{ density: 7800.0, young: 2.0e11, poisson: 0.3 });
let base = sim.add_body("base", box(#{ min: [-0.05, -0.05, -0.04], max: [0.35, 0.15, 0.0] }).mesh(#{ divisions: [4, 2, 1] }), steel_m, #{ layout: "rigid" });
base.fix();
let beam = sim.add_body("beam", box(#{ min: [0.0, 0.0, 0.0], max: [0.3, 0.1, 0.1] }).mesh(#{ divisions: [6, 2, 2] }), concrete, #{ layout: "jointed" });
sim.insert_joints(#{ within: beam, law: joint_law("cohesive/munjiza", #{
    tensile_strength: 0.05e6, cohesion: 0.1e6, friction_angle: 30.0, g_i: 0.5, g_ii: 2.5 }) });
let bar = sim.rebar(beam, #{ points: straight_bar(beam, #{ axis: "x", at: [0.05, 0.02], cover: 0.01 }),
    diameter: 0.008, steel: steel(#{ yield_stress: 400.0e6, ultimate_stress: 500.0e6, ultimate_strain: 0.1 }),
    bond: bond_law("fib2010", #{ fcm: 30.0e6, confinement: "unconfined" }) });
let hammer = sim.add_body("hammer", box(#{ min: [0.12, 0.02, 0.101], max: [0.18, 0.08, 0.14] }).mesh(#{ divisions: [1, 1, 1] }), steel_m, #{ layout: "rigid" });
hammer.set_velocity([0.0, 0.0, -8.0]);
hammer.set_spin([0.0, 20.0, 0.0]);
sim.contact_law("potential", #{ friction: 0.5, friction_law: #{ source: "stdlib/friction_laws",
    function: "slip_weakening", params: #{ mu_s: 0.6, mu_d: 0.4, d_c: 1.0e-4 } } });
sim.gravity([0.0, 0.0, -9.81]);
let ke = sim.monitor("ke", #{ every: 10 }, |s| s.kinetic_energy());
let hz = sim.monitor("hammer_z", #{ every: 7 }, |s| s.displacement(hammer.nodes())[2]);
sim.every(#{ steps: 40 }, |s| s.write_vtk());
sim.run(#{ steps: 100 });
// Skipped while a restart replays the script (on the unstepped model it would fail).
expect_within("steps after the first run", sim.step, 100, 100);
sim.damping(#{ mass_proportional: 20.0 });
sim.checkpoint();
sim.every(#{ steps: 60 }, |s| { s.checkpoint(); CRASH });
sim.run(#{ duration: p.steps * sim.dt });
print(`broken ${sim.energy().fracture} J, ${sim.step} steps`);
"#;

/// Write the model with `crash` as `dir/model.rhai` (the file name a checkpoint records).
fn write_model(dir: &Path, crash: &str) -> PathBuf {
    write_script(dir, MODEL, crash)
}

/// Write `model` with `CRASH` replaced by `crash` as `dir/model.rhai`.
fn write_script(dir: &Path, model: &str, crash: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let path = dir.join("model.rhai");
    std::fs::write(&path, model.replace("CRASH", crash)).unwrap();
    path
}

/// `fdem run` with `args`; (success, stderr).
fn fdem_run(args: &[&std::ffi::OsStr]) -> (bool, String) {
    let out = common::fdem().arg("run").args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn os(s: &str) -> &std::ffi::OsStr {
    s.as_ref()
}

/// The reference: the model run without stopping, on `threads` threads, into `dir/out`.
fn reference(dir: &Path, threads: &str, extra: &[&str]) -> PathBuf {
    let script = write_model(dir, "");
    let out = dir.join("out");
    let mut args = vec![script.as_os_str(), os("--out"), out.as_os_str()];
    args.extend([
        os("--quiet"),
        os("--overwrite"),
        os("--threads"),
        os(threads),
    ]);
    args.extend(extra.iter().map(|a| os(a)));
    let (ok, err) = fdem_run(&args);
    assert!(ok, "{err}");
    out
}

/// Every file of `want` is in `got` with the same bytes (the checkpoint file aside: it holds
/// wall-clock timings); `got` has no other file the `.pvd`s list.
fn assert_same_output(want: &Path, got: &Path) {
    let mut compared = 0;
    for e in std::fs::read_dir(want).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        if name.ends_with(".fdemck") {
            continue;
        }
        let a = std::fs::read(want.join(&name)).unwrap();
        let b = std::fs::read(got.join(&name)).unwrap_or_else(|_| panic!("{name} is missing"));
        assert!(a == b, "{name} differs from the uninterrupted run's");
        compared += 1;
    }
    // 3 .pvd, energy.csv, cracks.csv, 2 monitors, and at least 13 body and 13 bar frames.
    assert!(compared >= 3 + 4 + 2 * 13, "only {compared} files compared");
}

/// Run the model with `crash` in its checkpoint hook into `dir/b/out` (it must fail), then
/// restart it from its checkpoint with the reference script on `threads` threads; `set` is
/// given to both. Returns the output directory.
fn crash_and_restart(dir: &Path, crash: &str, set: &[&str], threads: &str) -> PathBuf {
    let b = dir.join("b");
    let crashed = write_model(&b, crash);
    let out = b.join("out");
    let mut args = vec![
        crashed.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ];
    args.extend(set.iter().map(|a| os(a)));
    let (ok, err) = fdem_run(&args);
    assert!(!ok && err.contains("crash"), "{err}");
    // Restart with the reference script (the crash was in the script, not the model).
    let script = write_model(&dir.join("c"), "");
    let ck = out.join("checkpoint.fdemck");
    let mut args = vec![
        script.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ];
    args.extend([
        os("--restart"),
        ck.as_os_str(),
        os("--threads"),
        os(threads),
    ]);
    args.extend(set.iter().map(|a| os(a)));
    let (ok, err) = fdem_run(&args);
    assert!(ok, "{err}");
    out
}

/// A run that fails after its checkpoint at step 960 (the hook throws at 1020: the checkpoint
/// it asks for there is never written), restarted on 1 thread, equals the 2-thread
/// uninterrupted run in every file.
#[test]
fn a_run_restarted_after_a_crash_writes_what_the_uninterrupted_run_writes() {
    let dir = common::temp_dir("crash");
    let want = reference(&dir.join("a"), "2", &[]);
    let out = crash_and_restart(&dir, "if s.step >= 1000 { throw \"crash\" }", &[], "1");
    assert_same_output(&want, &out);
}

/// A checkpoint taken between two runs (`sim.checkpoint()` after the first, at step 100)
/// restarts at the second run's start; a crash at its first hook leaves only that one.
#[test]
fn a_checkpoint_between_runs_restarts_at_the_next_run() {
    let dir = common::temp_dir("between");
    let set = ["--set", "steps=700"];
    let want = reference(&dir.join("a"), "1", &set);
    let out = crash_and_restart(&dir, "throw \"crash\"", &set, "2");
    assert_same_output(&want, &out);
}

/// SIGTERM in the middle of the second run writes a checkpoint and prints the command that
/// continues it; that command finishes the run with the uninterrupted run's output.
#[test]
fn a_run_stopped_by_sigterm_continues_with_the_printed_command() {
    let dir = common::temp_dir("sigterm");
    let steps = "steps=6000";
    let want = reference(&dir.join("a"), "2", &["--set", steps]);
    let b = dir.join("b");
    let script = write_model(&b, "");
    let out = b.join("out");
    let child = common::fdem()
        .arg("run")
        .arg(&script)
        .arg("--out")
        .arg(&out)
        .args(["--quiet", "--set", steps])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Past the first run (100 steps) and the checkpoint after it: 150 rows of `ke` (every 10
    // steps) is step 1490 of 6100.
    let t = std::time::Instant::now();
    while std::fs::read_to_string(out.join("ke.csv")).map_or(0, |s| s.lines().count()) < 150 {
        assert!(t.elapsed().as_secs() < 120, "the run never got going");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    // SAFETY: kill(2) with the pid of a child this test spawned and has not reaped.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) },
        0
    );
    let done = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(143), "{err}");
    let ck = out.join("checkpoint.fdemck");
    let cmd = format!("--restart {}", ck.display());
    assert!(
        err.contains("continue with: fdem run") && err.contains(&cmd) && err.contains(steps),
        "{err}"
    );
    let (ok, err) = fdem_run(&[
        script.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
        os("--set"),
        os(steps),
        os("--restart"),
        ck.as_os_str(),
        os("--threads"),
        os("1"),
    ]);
    assert!(ok, "{err}");
    assert_same_output(&want, &out);
}

/// A checkpoint of the reference model after its first run, for the refusal tests.
fn a_checkpoint(dir: &Path) -> (PathBuf, PathBuf) {
    let out = reference(dir, "2", &["--set", "steps=60"]);
    (dir.join("model.rhai"), out.join("checkpoint.fdemck"))
}

/// `bytes` with the build id in its head replaced by zeros and the checksum made right: a
/// whole, valid file of another build.
fn other_build(bytes: &[u8]) -> Vec<u8> {
    let id = fdem::io::checkpoint::BUILD_ID.as_bytes();
    let mut b = bytes.to_vec();
    let at = b
        .windows(id.len())
        .position(|w| w == id)
        .expect("the build id is in the head");
    b[at..at + id.len()].fill(b'0');
    let crc = crc32fast::hash(&b[24..]);
    b[20..24].copy_from_slice(&crc.to_le_bytes());
    b
}

/// `fdem run script --restart ck extra…` into `out`; its error text (it must fail).
fn refused(script: &Path, ck: &Path, extra: &[&str]) -> String {
    let out = ck.parent().unwrap();
    let mut args = vec![
        script.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
        os("--restart"),
        ck.as_os_str(),
    ];
    args.extend(extra.iter().map(|a| os(a)));
    let (ok, err) = fdem_run(&args);
    assert!(!ok, "restarted when it should not have");
    err
}

/// A damaged, truncated, foreign or other-version file, other --set values, another script
/// and another model are each refused with the reason, before anything is written.
#[test]
fn checkpoints_of_other_models_or_damaged_files_are_refused_with_the_reason() {
    let dir = common::temp_dir("refused");
    let (script, ck) = a_checkpoint(&dir);
    let good = std::fs::read(&ck).unwrap();
    let variant = |name: &str, bytes: Vec<u8>| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let mut flipped = good.clone();
    let k = good.len() - 100;
    flipped[k] ^= 0x40;
    let cases: Vec<(PathBuf, &[&str], &str)> = vec![
        (
            variant("flipped.fdemck", flipped),
            &["--set", "steps=60"],
            "checksum",
        ),
        (
            variant("short.fdemck", good[..good.len() / 2].to_vec()),
            &["--set", "steps=60"],
            "truncated",
        ),
        (
            variant(
                "foreign.fdemck",
                b"<VTKFile>not a checkpoint</VTKFile>".to_vec(),
            ),
            &["--set", "steps=60"],
            "not an fdem checkpoint",
        ),
        (
            variant("v99.fdemck", {
                let mut b = good.clone();
                b[8] = 99;
                b
            }),
            &["--set", "steps=60"],
            "format version 99",
        ),
        (
            variant("other_build.fdemck", other_build(&good)),
            &["--set", "steps=60"],
            "another build of fdem",
        ),
        (ck.clone(), &["--set", "steps=61"], "--set steps=60"),
        (ck.clone(), &[], "no --set"),
    ];
    for (file, extra, why) in cases {
        let err = refused(&script, &file, extra);
        assert!(
            err.contains("--restart") && err.contains(why),
            "{why}:\n{err}"
        );
    }
    // Another script file name.
    let other = dir.join("other.rhai");
    std::fs::copy(&script, &other).unwrap();
    let err = refused(&other, &ck, &["--set", "steps=60"]);
    assert!(err.contains("made by script 'model.rhai'"), "{err}");
    // The same script name, another mesh: the model differs.
    let changed = dir.join("changed");
    std::fs::create_dir_all(&changed).unwrap();
    let text = std::fs::read_to_string(&script)
        .unwrap()
        .replace("divisions: [6, 2, 2]", "divisions: [5, 2, 2]");
    std::fs::write(changed.join("model.rhai"), text).unwrap();
    let err = refused(&changed.join("model.rhai"), &ck, &["--set", "steps=60"]);
    assert!(
        err.contains("another model than the checkpoint's") && err.contains("tetrahedra"),
        "{err}"
    );
    // A script that never reaches the checkpoint's run.
    let short = dir.join("short");
    std::fs::create_dir_all(&short).unwrap();
    let text = std::fs::read_to_string(&script).unwrap();
    let cut = text.find("sim.run(#{ duration").unwrap();
    std::fs::write(short.join("model.rhai"), &text[..cut]).unwrap();
    let err = refused(&short.join("model.rhai"), &ck, &["--set", "steps=60"]);
    assert!(
        err.contains("ended without reaching the checkpoint"),
        "{err}"
    );
}

/// A cantilever sagging under gravity, brought to rest, then run on with a checkpoint in the
/// second run; `CRASH` as in [`MODEL`]. The last line prints what `bring_to_rest` returned
/// and checks it: on a restart that call is skipped (the checkpoint is past it).
const REST_MODEL: &str = r#"
let sim = simulation(#{ name: "rest" });
let steel = material("elastic/munjiza", #{ density: 7850.0, young: 2.0e9, poisson: 0.2 });
let beam = sim.add_body("beam", box(#{ min: [0.0, 0.0, 0.0], max: [0.5, 0.05, 0.05] }).mesh(#{ divisions: [10, 1, 1] }), steel);
sim.fix(beam.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] })));
sim.gravity([0.0, 0.0, -9.81]);
let rest = sim.bring_to_rest(#{ ratio: 1e-4, max_steps: 20000 });
sim.every(#{ steps: 50 }, |s| { s.checkpoint(); CRASH });
sim.run(#{ steps: 120 });
print(`rest ${rest.converged} ${rest.steps} ${rest.time} ${rest.kinetic} ${rest.work} ${rest.ratio} ${rest.damping}`);
expect_within("bring_to_rest's steps", rest.steps, 1, 20000);
"#;

/// `sim.bring_to_rest`'s result, returned by a call a restart skips, is the one the
/// interrupted run got (kept in the checkpoint), not a skipped call's zeros: a script's
/// checks after the restart see the real values (before, `steps` came back 0 and `ratio` 0,
/// and a check `ratio ≤ 1e-4` passed on them). Oracle: the uninterrupted run's printed line.
#[test]
fn a_restart_returns_what_the_skipped_bring_to_rest_returned() {
    let dir = common::temp_dir("ck-rest");
    let write = |sub: &str, crash: &str| write_script(&dir.join(sub), REST_MODEL, crash);
    let line = |stdout: &[u8]| {
        String::from_utf8_lossy(stdout)
            .lines()
            .find(|l| l.starts_with("rest "))
            .map(str::to_string)
    };
    let reference = write("a", "");
    let out = common::fdem()
        .arg("run")
        .arg(&reference)
        .arg("--out")
        .arg(dir.join("a/out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let want = line(&out.stdout).expect("the reference prints its rest line");
    assert!(!want.starts_with("rest true 0 "), "{want}");
    // Crash in the second run, 100 steps in (its checkpoints every 50 steps before that are
    // written; the one asked for in the throwing step is not), then restart.
    let crashed = write("b", "if s.step >= rest.steps + 100 { throw \"crash\" }");
    let out_b = dir.join("b/out");
    let run = common::fdem()
        .arg("run")
        .arg(&crashed)
        .arg("--out")
        .arg(&out_b)
        .output()
        .unwrap();
    assert!(!run.status.success(), "the crash run must fail");
    let again = common::fdem()
        .arg("run")
        .arg(write("c", ""))
        .arg("--out")
        .arg(&out_b)
        .arg("--restart")
        .arg(out_b.join("checkpoint.fdemck"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success(), "{err}");
    let got = line(&again.stdout).expect("the restart prints its rest line");
    assert_eq!(got, want);
}
