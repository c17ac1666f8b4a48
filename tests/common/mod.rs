//! Helpers shared by the physics tests.
#![allow(dead_code)]

use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::{box_mesh, Region};
use fdem::{Layout, Simulation};

/// A simulation holding one box body meshed with `div` cells.
pub fn box_sim(min: Vec3, max: Vec3, div: [usize; 3], mat: Material, layout: Layout) -> Simulation {
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    sim.add_body("box", &box_mesh(min, max, div), m, layout)
        .unwrap();
    sim
}

pub fn material(f: Formulation, rho: Real, e: Real, nu: Real) -> Material {
    Material::new(f, rho, e, nu, 0.0).unwrap()
}

/// Nodes on the plane x = value (within 1e-9).
pub fn plane_x(sim: &Simulation, value: Real, outward: Real) -> Vec<u32> {
    sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::new(value, 0.0, 0.0),
            normal: Vec3::new(outward, 0.0, 0.0),
        },
        None,
    )
}

/// The `fdem` binary of this build.
pub fn fdem() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_fdem"))
}

/// A fresh, empty directory for one test (named by test crate, process and `name`), removed
/// when the value is dropped unless the test is panicking (a failed test leaves its files to
/// look at). Derefs to its path.
pub fn temp_dir(name: &str) -> TestDir {
    let d = std::env::temp_dir().join(format!(
        "fdem-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TestDir(d)
}

/// See [`temp_dir`].
pub struct TestDir(std::path::PathBuf);

impl std::ops::Deref for TestDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for TestDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for TestDir {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Write `text` as `dir/name.rhai` and `fdem run` it quietly with `extra` arguments;
/// returns (success, stdout, stderr).
pub fn run_script(
    dir: &std::path::Path,
    name: &str,
    text: &str,
    extra: &[&str],
) -> (bool, String, String) {
    let mut args = vec!["--quiet"];
    args.extend_from_slice(extra);
    run_script_with(dir, name, text, &args)
}

/// [`run_script`] with exactly the arguments `args` (without `--quiet`, the end-of-run
/// summaries are printed), and `--overwrite`: tests run several scripts into one `dir/out`
/// (tests/robustness.rs checks the refusal without it).
pub fn run_script_with(
    dir: &std::path::Path,
    name: &str,
    text: &str,
    args: &[&str],
) -> (bool, String, String) {
    let path = dir.join(format!("{name}.rhai"));
    std::fs::write(&path, text).unwrap();
    let out = fdem()
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(dir.join("out"))
        .arg("--overwrite")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Run `f` on a rayon pool of `threads` threads (determinism tests).
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// `fdem::script::run_source` with its output in a fresh temporary directory (not the working
/// directory's out/, which the no-overwrite policy would refuse on a second run), removed
/// afterwards. `prefix` names the directories; a counter keeps parallel tests apart.
pub fn run_source_in_temp(
    prefix: &str,
    script: &std::path::Path,
    text: &str,
) -> Result<fdem::script::ScriptReport, fdem::script::ScriptError> {
    static RUN: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let dir = temp_dir(&format!(
        "{prefix}{}",
        RUN.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let options = fdem::script::RunOptions {
        out_dir: Some(dir.to_path_buf()),
        ..Default::default()
    };
    fdem::script::run_source(script, text, options)
}
