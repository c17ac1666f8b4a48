//! The `fdem` command line: `run`, `check`, `plot`, `doc`, `bench`.

use crate::material::{Formulation, Material};
use crate::math::Vec3;
use crate::mesh::box_mesh;
use crate::pipeline::{Simulation, Stage};
use crate::script::{self, numbers::sig, types::SimHandle, RunOptions};
use crate::state::Layout;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "fdem",
    version,
    about = "Combined finite-discrete element method (FEM/DEM), driven by Rhai model scripts"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a model script.
    Run {
        script: PathBuf,
        /// Override a script parameter: --set name=value (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Output directory (overrides the script's out_dir).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores). Results are identical for any count.
        #[arg(long)]
        threads: Option<usize>,
        /// No progress bar and no end-of-run summary.
        #[arg(long)]
        quiet: bool,
        /// Replace the output of an earlier run (each simulation's frames, energy.csv,
        /// cracks.csv and monitor CSVs in its directory); without it that output is an error.
        #[arg(long)]
        overwrite: bool,
        /// Stop the script after N Rhai operations without a time step (a runaway loop);
        /// 0: no limit. Default 200000000 (about 10 s).
        #[arg(long, value_name = "N")]
        max_operations: Option<u64>,
        /// Continue from a checkpoint (`sim.checkpoint()`, or the one Ctrl-C writes): the
        /// script runs again with the same --set values and its simulation goes on from the
        /// checkpoint, bit for bit, writing on in the same output directory.
        #[arg(long, value_name = "FILE")]
        restart: Option<PathBuf>,
        #[command(flatten)]
        geo: GeoArgs,
    },
    /// Parse a script, build its model up to the first run() and validate it (nothing is
    /// stepped); or, with --mesh, validate a mesh file alone and print its summary.
    Check {
        #[arg(required_unless_present = "mesh", conflicts_with = "mesh")]
        script: Option<PathBuf>,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// A mesh file to check (.msh; .geo when gmsh is installed).
        #[arg(long, value_name = "FILE")]
        mesh: Option<PathBuf>,
        #[command(flatten)]
        geo: GeoArgs,
    },
    /// Plot a finished run's histories as PNG and SVG beside its CSV files: the energy
    /// account (each term against time, and the balance error), broken joints against time,
    /// and one figure per other CSV (each monitor against time). With --y, one figure of
    /// the chosen columns instead.
    Plot {
        /// The run's output directory (the one holding energy.csv and the monitors' CSVs).
        dir: PathBuf,
        /// Column for the x axis of the --y figure (default: time). Columns of different
        /// CSV files are matched on their `step`.
        #[arg(long, value_name = "COLUMN", requires = "y")]
        x: Option<String>,
        /// Columns to plot against --x, comma-separated (any CSV of the directory; a name
        /// that several files have is the monitor's own file's, else say FILE:COLUMN).
        #[arg(long, value_name = "COLUMN[,COLUMN]", value_delimiter = ',')]
        y: Vec<String>,
        /// File name of the --y figure, without extension (default: <first y>_vs_<x>).
        #[arg(long, requires = "y")]
        name: Option<String>,
        /// Title of the --y figure (of the standard figures: a prefix).
        #[arg(long)]
        title: Option<String>,
        /// png, svg or both.
        #[arg(long, default_value = "both")]
        format: String,
        /// Width of a figure in pixels.
        #[arg(long, default_value_t = 1000)]
        width: u32,
        /// Height of a figure in pixels (the energy account is 4/3 of it: two panels).
        #[arg(long, default_value_t = 600)]
        height: u32,
    },
    /// Print the script API reference (Markdown).
    Doc,
    /// Run a standard benchmark and print its timings.
    Bench {
        /// Benchmark case: elastic; joints (a fully jointed box: joints on every internal
        /// face); detection (NBS on --elements boxes, against sort-and-sweep and parry3d's
        /// BVH); fragmented (a box cut into loose blocks settling under gravity, with contact);
        /// rebars (the elastic box with a grid of embedded bars, timed against the same box
        /// without them); rigid (one step of a spinning rigid box against the same box
        /// deformable).
        #[arg(long, default_value = "elastic")]
        case: String,
        /// Number of surface elements of the detection case.
        #[arg(long, default_value_t = 100_000)]
        elements: usize,
        /// Approximate number of tetrahedra.
        #[arg(long, default_value_t = 200_000)]
        tets: usize,
        /// Number of time steps.
        #[arg(long, default_value_t = 200)]
        steps: u64,
        /// Elastic law of the tetrahedra.
        #[arg(long, default_value = "elastic/munjiza")]
        material: String,
        /// Joint law of the joints case: builtin (cohesive/munjiza) or script (the same law
        /// written in Rhai, stdlib/joint_laws.rhai, compiled to native code).
        #[arg(long, default_value = "builtin")]
        law: String,
        /// Body layout: jointed or continuous.
        #[arg(long, default_value = "jointed")]
        layout: String,
        #[arg(long)]
        threads: Option<usize>,
        /// Print one JSON line instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// How `.geo` files are run through gmsh (`run` and `check`).
#[derive(clap::Args, Clone, Debug)]
struct GeoArgs {
    /// Let .geo files run programs (gmsh's SystemCall, Shell, OnelabRun); refused without
    /// it. Only for files you trust.
    #[arg(long)]
    allow_geo_commands: bool,
    /// Stop gmsh after this many seconds (default 600).
    #[arg(long, value_name = "SECONDS")]
    gmsh_timeout: Option<f64>,
}

impl GeoArgs {
    fn policy(&self) -> Result<crate::mesh::gmsh::GeoPolicy, String> {
        let mut p = crate::mesh::gmsh::GeoPolicy {
            allow_commands: self.allow_geo_commands,
            ..Default::default()
        };
        if let Some(t) = self.gmsh_timeout {
            if !(t > 0.0 && t <= 1e7) {
                return Err(format!(
                    "--gmsh-timeout {t}: give a number of seconds in (0, 1e7]"
                ));
            }
            p.timeout = std::time::Duration::from_secs_f64(t);
        }
        Ok(p)
    }
}

/// The number of processes an MPI launcher started this one among (Open MPI's
/// `OMPI_COMM_WORLD_SIZE`, MPICH's and Intel MPI's `PMI_SIZE`), if any.
fn launched_ranks() -> Option<usize> {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE"]
        .iter()
        .find_map(|v| std::env::var(v).ok()?.trim().parse().ok())
}

/// The threads a rank takes when an MPI launcher started several on this machine (Open MPI's
/// `OMPI_COMM_WORLD_LOCAL_SIZE`, MPICH's `MPI_LOCALNRANKS`): the cores divided among them,
/// at least one. None when not started so.
fn ranks_share_of_cores() -> Option<usize> {
    let local = ["OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .find_map(|v| std::env::var(v).ok()?.trim().parse().ok());
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    share_of_cores(local, cores)
}

/// `cores` shared among `local` ranks on one machine: at least one thread each; None for
/// a single rank (rayon's default, one thread per core).
fn share_of_cores(local: Option<usize>, cores: usize) -> Option<usize> {
    let local = local.filter(|&l| l > 1)?;
    Some((cores / local).max(1))
}

/// Started by `mpirun` as one of several ranks: initialise MPI and make its world this
/// process's (scripts' models are then decomposed over it). The universe returned must live
/// until the run ends.
#[cfg(feature = "mpi")]
fn start_ranks() -> Result<Option<mpi::environment::Universe>, String> {
    if launched_ranks().unwrap_or(1) <= 1 {
        return Ok(None);
    }
    let universe = mpi::initialize().ok_or("MPI was initialised twice")?;
    let world = crate::parallel::comm::MpiComm::world(&universe);
    crate::parallel::set_world(std::sync::Arc::new(world));
    Ok(Some(universe))
}

/// Without the `mpi` feature a launch by `mpirun` on several ranks is refused: each process
/// would run the whole model and write the same files.
#[cfg(not(feature = "mpi"))]
fn start_ranks() -> Result<Option<()>, String> {
    match launched_ranks() {
        Some(n) if n > 1 => Err(format!(
            "this process is one of {n} started by an MPI launcher, but this fdem was built without MPI, so each would run the whole model and write the same files; build it with `cargo build --release --features mpi` (docs/cluster.md), or run one process"
        )),
        _ => Ok(None),
    }
}

/// The `fdem` command: parse the arguments, run the subcommand and exit with its code.
pub fn main() {
    let cli = Cli::parse();
    std::process::exit(execute(cli));
}

/// The `fdem` command in-process: `args` as the command line (the program name first).
/// Returns the exit code instead of exiting; clap's messages (usage errors, `--help`,
/// `--version`) are printed, without colour, to stderr or stdout as `fdem` prints them.
/// The command-line tests and tests/fuzz.rs call it.
pub fn run_args<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    match Cli::try_parse_from(args) {
        Ok(cli) => execute(cli),
        Err(e) => {
            let text = e.render().to_string();
            if e.use_stderr() {
                eprint!("{text}");
            } else {
                print!("{text}");
            }
            e.exit_code()
        }
    }
}

/// Run the parsed command; returns the exit code.
fn execute(cli: Cli) -> i32 {
    match cli.command {
        Command::Run {
            script,
            set,
            out,
            threads,
            quiet,
            overwrite,
            max_operations,
            restart,
            geo,
        } => {
            // Several ranks on one machine share its cores: without --threads each takes its
            // share (rayon would start one thread per core in every rank).
            let threads = threads.or_else(ranks_share_of_cores);
            if let Err(e) = set_threads(threads) {
                return fail(&e);
            }
            let geo = match geo.policy() {
                Ok(g) => g,
                Err(e) => return fail(&e),
            };
            // Under `mpirun`: MPI lives until this run returns (dropping it finalises).
            let ranks = match start_ranks() {
                Ok(r) => r,
                Err(e) => return fail(&e),
            };
            // Rank 0 of a decomposed run prints and writes; the others work quietly.
            let quiet = quiet || !crate::parallel::is_root();
            let options = RunOptions {
                out_dir: out,
                quiet,
                check_only: false,
                progress: !quiet,
                overwrite,
                max_operations,
                geo,
                restart,
                ..Default::default()
            };
            leave_if_failed(run_script(&script, &set, options), ranks)
        }
        Command::Check {
            mesh: Some(mesh),
            geo,
            ..
        } => match geo
            .policy()
            .and_then(|g| check_mesh_file_with(&mesh, &g).map_err(|e| e.trim_end().to_string()))
        {
            Ok(report) => {
                print!("{report}");
                0
            }
            // Errors on stderr, like every other command's.
            Err(report) => fail(&report),
        },
        Command::Check {
            script: None,
            mesh: None,
            ..
        } => fail("fdem check: give a script or --mesh FILE"),
        Command::Check {
            script: Some(script),
            set,
            geo,
            ..
        } => match geo.policy() {
            Ok(g) => check_script(&script, &set, g),
            Err(e) => fail(&e),
        },
        Command::Plot {
            dir,
            x,
            y,
            name,
            title,
            format,
            width,
            height,
        } => plot(&dir, x, y, name, title, &format, width, height),
        Command::Doc => {
            print!("{}", script::api::markdown());
            0
        }
        Command::Bench {
            case,
            elements,
            tets,
            steps,
            material,
            law,
            layout,
            threads,
            json,
        } => {
            if let Err(e) = set_threads(threads) {
                return fail(&e);
            }
            if let Err(e) = check_bench_size(&case, tets, elements, &layout) {
                return fail(&e);
            }
            let result = match case.as_str() {
                "rigid" => bench_rigid(tets, steps, &material),
                "detection" => bench_detection(elements),
                "fragmented" => bench_fragmented(tets, steps),
                "rebars" => bench_rebars(tets, steps),
                _ => bench(&case, tets, steps, &material, &law, &layout),
            };
            print_bench(result, json)
        }
    }
}

/// `fdem run`: run `script` (summaries printed unless `quiet`); returns the exit code.
fn run_script(script: &Path, set: &[String], mut options: RunOptions) -> i32 {
    options.overrides = match parse_sets(set) {
        Err(e) => return fail(&e),
        Ok(overrides) => overrides,
    };
    let quiet = options.quiet;
    crate::limits::interrupt::install();
    // The summaries (timing, energy account) are printed whether the script succeeded or
    // not: a failed self-check is when they are needed most.
    let (report, result) = script::run_file_with_report(script, options);
    if !quiet {
        for s in report.summaries() {
            print!("{s}");
        }
    }
    match result {
        Ok(()) => 0,
        Err(e) => {
            // Every rank of a decomposed run runs the same script and meets the same errors:
            // rank 0 prints them. Another rank prints only its own (a piece it could not
            // write), which name it.
            let msg = e.to_string();
            if crate::parallel::is_root() || crate::parallel::names_this_rank(&msg) {
                fail(&msg);
            }
            // 128 + the signal number when SIGINT or SIGTERM stopped the run, as shells do.
            crate::limits::interrupt::requested().map_or(1, |sig| 128 + sig)
        }
    }
}

/// The exit code of a run, after which `ranks` (MPI, under `mpirun`) is finalised. A rank
/// that stops with an error leaves at once instead, without MPI's finalisation, which waits
/// for every rank: a rank whose error the others did not meet (rank 0's check of earlier
/// output, a piece of a frame it could not write) would wait there for ever, and the others
/// in their next exchange. The launcher sees the exit and stops the others. A rank other
/// than 0 waits a moment first: when every rank meets the error, rank 0 prints it, and a
/// launcher stopping rank 0 because another left first could lose that line (seen once in
/// tests/mpi.rs under load).
fn leave_if_failed<R>(code: i32, ranks: Option<R>) -> i32 {
    if code != 0 && ranks.is_some() {
        if !crate::parallel::is_root() {
            std::thread::sleep(std::time::Duration::from_millis(500));
        }
        std::mem::forget(ranks);
        std::process::exit(code);
    }
    drop(ranks);
    code
}

/// `fdem plot DIR`: write the figures, one line per file; the exit code.
#[allow(clippy::too_many_arguments)]
fn plot(
    dir: &Path,
    x: Option<String>,
    y: Vec<String>,
    name: Option<String>,
    title: Option<String>,
    format: &str,
    width: u32,
    height: u32,
) -> i32 {
    use crate::io::plot::{plot_dir, Format, PlotOptions};
    let format = match Format::parse(format) {
        Ok(f) => f,
        Err(e) => return fail(&format!("fdem plot: --{e}")),
    };
    let y: Vec<String> = y
        .into_iter()
        .map(|c| c.trim().to_string())
        .filter(|c| !c.is_empty())
        .collect();
    let options = PlotOptions {
        x,
        y,
        name,
        title,
        format,
        width,
        height,
    };
    match plot_dir(dir, &options) {
        Ok((written, notes)) => {
            for n in notes {
                eprintln!("note: {n}");
            }
            for p in written {
                println!("wrote {}", p.display());
            }
            0
        }
        Err(e) => fail(&format!("fdem plot: {e}")),
    }
}

/// `fdem check SCRIPT`: build the models up to their first run, one line each; the exit code.
fn check_script(script: &Path, set: &[String], geo: crate::mesh::gmsh::GeoPolicy) -> i32 {
    let overrides = match parse_sets(set) {
        Err(e) => return fail(&e),
        Ok(overrides) => overrides,
    };
    let options = RunOptions {
        overrides,
        check_only: true,
        quiet: true,
        geo,
        ..Default::default()
    };
    match script::run_file(script, options) {
        Ok(report) => {
            for s in &report.sims {
                if let Err(code) = print_checked_model(script, s) {
                    return code;
                }
            }
            if report.sims.is_empty() {
                println!(
                    "ok: {} parses and runs its setup; it creates no simulation",
                    script.display()
                );
            }
            0
        }
        Err(e) => fail(&e.to_string()),
    }
}

/// Print one model's `fdem check` lines (mass in kg, dt in s); Err(exit code 1), with the
/// reason printed, if it cannot be prepared.
fn print_checked_model(script: &Path, s: &SimHandle) -> Result<(), i32> {
    let mut st = s.0.borrow_mut();
    let ready = st.sim.prepare();
    let sim = &st.sim;
    println!(
        "ok: model '{}': {} bodies, {} tets, {} nodes, mass {} kg",
        st.name,
        sim.bodies.len(),
        sim.tets.len(),
        sim.nodes.len(),
        sig(sim.total_mass(), 6)
    );
    match (ready, &sim.dt_info) {
        (Err(e), _) => return Err(fail(&format!("{}: {e}", script.display()))),
        (Ok(()), Some(i)) => {
            println!("    {i}");
            if let Some(line) = dt_cost_line(sim) {
                println!("    {line}");
            }
        }
        _ => {}
    }
    Ok(())
}

/// What the worst tetrahedron costs: its own critical step against the median tet's, and the
/// number of steps the model takes for it (a sliver from a mesher can cut the step tenfold).
/// None without deformable tets.
fn dt_cost_line(sim: &Simulation) -> Option<String> {
    use crate::elements::tet4::tet_critical_dt;
    let mut dts: Vec<(f64, usize)> = (0..sim.tets.len())
        .filter(|&e| !sim.tets.rigid.get(e).copied().unwrap_or(false))
        .map(|e| {
            let m = &sim.materials[sim.tets.material[e] as usize];
            (tet_critical_dt(&sim.tets.dm_inv[e], m), e)
        })
        .collect();
    if dts.is_empty() {
        return None;
    }
    dts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let (worst, e) = dts[0];
    let median = dts[dts.len() / 2].0;
    let at = crate::math::fmt_place(&sim.current_centroid(e));
    let body = &sim.bodies[sim.tets.body[e] as usize].name;
    let ratio = median / worst;
    let note = if ratio >= 3.0 {
        "  <-- WARNING: a poorly shaped or tiny element sets the step; remesh (docs/meshing.md, avoiding slivers)"
    } else {
        ""
    };
    Some(format!(
        "worst tet {e} of body '{body}' at {at} allows {} s; the median tet allows {} s: {}× the steps the median would need{note}",
        sig(worst, 4),
        sig(median, 4),
        sig(ratio, 3)
    ))
}

/// Print a benchmark's JSON record (one line if `json`, else pretty); returns the exit code.
fn print_bench(result: Result<serde_json::Value, String>, json: bool) -> i32 {
    match result {
        Ok(r) => {
            if json {
                println!("{}", r);
            } else {
                println!("{}", serde_json::to_string_pretty(&r).unwrap());
            }
            0
        }
        Err(e) => fail(&e),
    }
}

/// `fdem check --mesh FILE`: import and check a mesh file; the summary (Ok) or the summary
/// with the problems (Err), as printed.
pub fn check_mesh_file(path: &std::path::Path) -> Result<String, String> {
    check_mesh_file_with(path, &Default::default())
}

/// [`check_mesh_file`] with `.geo` files run under `policy`.
pub fn check_mesh_file_with(
    path: &std::path::Path,
    policy: &crate::mesh::gmsh::GeoPolicy,
) -> Result<String, String> {
    use crate::mesh::{checks::fmt_point, gmsh};
    use std::fmt::Write;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let t = Instant::now();
    let imported = match ext.as_str() {
        "msh" => gmsh::read_msh(path).map_err(|e| format!("error: {e}\n"))?,
        "geo" => gmsh::mesh_geo_cached(path, None, policy)
            .map(|c| c.imported)
            .map_err(|e| format!("error: {e}\n"))?,
        _ => {
            return Err(format!(
                "error: {}: expected a .msh or .geo file\n",
                path.display()
            ))
        }
    };
    let seconds = t.elapsed().as_secs_f64();
    let m = &imported.mesh;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "mesh {} ({}, read in {seconds:.3} s)",
        path.display(),
        imported.format
    );
    let _ = writeln!(out, "  nodes         {}", m.nodes.len());
    let _ = writeln!(out, "  tetrahedra    {}", m.tets.len());
    let _ = writeln!(out, "  volume        {:.9e} m³", m.volume());
    let (lo, hi) = m.bounds();
    let _ = writeln!(
        out,
        "  bounding box  {} – {}",
        fmt_point(&lo),
        fmt_point(&hi)
    );
    let summary = m.sets.summary();
    if summary.is_empty() {
        let _ = writeln!(out, "  groups        none");
    } else {
        let _ = writeln!(out, "  groups");
        let w = summary.iter().map(|(n, _, _)| n.len()).max().unwrap_or(0);
        for (name, kind, size) in &summary {
            let _ = writeln!(out, "    {name:<w$}  {kind:<8} {size}");
        }
    }
    if let Some(q) = m.quality() {
        let _ = writeln!(
            out,
            "  quality       min dihedral angle {:.2}° (tet {}), max {:.2}°; worst aspect ratio {:.3} (tet {} at {}), mean {:.3}",
            q.min_dihedral_deg,
            q.worst_dihedral_tet,
            q.max_dihedral_deg,
            q.max_aspect_ratio,
            q.worst_aspect_tet,
            fmt_point(&m.tet_centroid(q.worst_aspect_tet)),
            q.mean_aspect_ratio
        );
    }
    for w in &imported.warnings {
        let _ = writeln!(out, "  warning: {w}");
    }
    let problems = m.problems();
    if problems.is_empty() {
        let _ = writeln!(out, "ok: no problems found");
        Ok(out)
    } else {
        let _ = writeln!(out, "  problems      {}", problems.len());
        for p in problems.iter().take(20) {
            let _ = writeln!(out, "    error: {p}");
        }
        if problems.len() > 20 {
            let _ = writeln!(out, "    … and {} more", problems.len() - 20);
        }
        let _ = writeln!(out, "error: the mesh has {} problem(s)", problems.len());
        Err(out)
    }
}

fn fail(msg: &str) -> i32 {
    eprintln!("{msg}");
    1
}

/// The most worker threads `--threads` may ask for (results are the same for any count;
/// more threads than cores only cost memory and time).
const MAX_THREADS: usize = 1024;

/// `--threads N`: the size of the worker pool, 1 ..= [`MAX_THREADS`].
fn set_threads(threads: Option<usize>) -> Result<(), String> {
    let Some(n) = threads else {
        return Ok(());
    };
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    if n == 0 || n > MAX_THREADS {
        return Err(format!(
            "--threads {n}: give 1 to {MAX_THREADS} (this machine has {cores} cores; results are the same for any count)"
        ));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| format!("--threads {n}: cannot start the worker threads: {e}"))
}

/// Memory of the detection benchmark per element [B]: the boxes, NBS's workspace, the
/// pairs, and parry3d's tree of the same boxes.
const DETECTION_BYTES_PER_ELEMENT: f64 = 400.0;

/// Error unless the benchmark's model fits in the memory available (`--tets 1e19` was a
/// capacity-overflow panic, `--tets 1e11` an allocation abort): `--elements` for the
/// detection case, `--tets` for the others (jointed bodies cost more).
fn check_bench_size(case: &str, tets: usize, elements: usize, layout: &str) -> Result<(), String> {
    use crate::limits::{
        check_memory, CONTINUOUS_BYTES_PER_TET, JOINTED_BYTES_PER_TET, MESH_BYTES_PER_TET,
    };
    let r = if case == "detection" {
        check_memory(
            &format!("--elements {elements}"),
            elements as f64 * DETECTION_BYTES_PER_ELEMENT,
        )
    } else {
        let jointed = layout == "jointed" && (case == "elastic" || case == "joints");
        let body = if jointed {
            JOINTED_BYTES_PER_TET
        } else {
            CONTINUOUS_BYTES_PER_TET
        };
        check_memory(
            &format!("--tets {tets}"),
            tets as f64 * (MESH_BYTES_PER_TET + body),
        )
    };
    r.map_err(|e| format!("bench: {e}"))
}

fn parse_sets(set: &[String]) -> Result<Vec<(String, String)>, String> {
    set.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => {
                Ok((k.trim().to_string(), v.trim().to_string()))
            }
            _ => Err(format!("--set {s}: expected NAME=VALUE")),
        })
        .collect()
}

/// A box of about `tets` tetrahedra with a smooth initial velocity field, stepped `steps`
/// times; returns the JSON record (seconds per stage keyed by stage module name).
pub fn bench(
    case: &str,
    tets: usize,
    steps: u64,
    material: &str,
    joint_law: &str,
    layout: &str,
) -> Result<serde_json::Value, String> {
    if case != "elastic" && case != "joints" {
        return Err(format!(
            "bench: unknown case '{case}'; available: elastic, joints, detection, fragmented, rebars, rigid"
        ));
    }
    let formulation = Formulation::from_name(material)
        .ok_or_else(|| format!("bench: unknown material law '{material}'"))?;
    let layout = match layout {
        "jointed" => Layout::Jointed,
        "continuous" => Layout::Continuous,
        _ => {
            return Err(format!(
                "bench: layout '{layout}' is not jointed or continuous"
            ))
        }
    };
    let (sim, setup) = {
        let t = Instant::now();
        let mut sim = bench_model(tets, formulation, layout);
        if case == "joints" {
            if layout != Layout::Jointed {
                return Err("bench: the joints case needs --layout jointed".into());
            }
            let cohesive = crate::joints::law::Cohesive {
                softening: crate::joints::law::Softening::Munjiza,
                calibration: crate::joints::law::Calibration::Exact,
                tensile_strength: 5e6,
                cohesion: 10e6,
                tan_friction: 0.6,
                g_i: 50.0,
                g_ii: 200.0,
                normal_penalty: 3e11,
                tangential_penalty: 3e11,
                residual_friction: 0.6,
                rate: crate::joints::law::RateEffects::None,
                dilatancy: crate::joints::law::Dilatancy::NONE,
            };
            let joint = match joint_law {
                "builtin" => crate::joints::JointLaw::Cohesive(cohesive),
                "script" => {
                    let mut p = rhai::Map::new();
                    for (k, v) in [
                        ("tensile_strength", cohesive.tensile_strength),
                        ("cohesion", cohesive.cohesion),
                        ("tan_friction", cohesive.tan_friction),
                        ("g_i", cohesive.g_i),
                        ("g_ii", cohesive.g_ii),
                        ("normal_penalty", cohesive.normal_penalty),
                        ("tangential_penalty", cohesive.tangential_penalty),
                        ("k_soft", 1.0 / crate::joints::law::Z_INTEGRAL),
                    ] {
                        p.insert(k.into(), v.into());
                    }
                    let src = script::STDLIB
                        .iter()
                        .find(|(n, _)| *n == "stdlib/joint_laws")
                        .unwrap()
                        .1;
                    let ast = rhai::Engine::new_raw()
                        .compile(src)
                        .map_err(|e| e.to_string())?;
                    crate::joints::JointLaw::Script {
                        law: std::sync::Arc::new(crate::compiled::compile_with(
                            &ast,
                            "munjiza",
                            &p,
                            crate::joints::JOINT_LAW,
                        )?),
                        normal_penalty: cohesive.normal_penalty,
                        tangential_penalty: cohesive.tangential_penalty,
                    }
                }
                other => {
                    return Err(format!(
                        "bench: joint law '{other}' is not builtin or script"
                    ))
                }
            };
            let law = sim.joints.add_law(joint);
            let (body, tet_nodes, x0) = (
                sim.bodies[0].clone(),
                sim.tets.nodes.clone(),
                sim.nodes.x0.clone(),
            );
            sim.joints
                .insert_in_body(&body, &tet_nodes, &x0, law, |_| true)?;
        }
        (sim, t.elapsed().as_secs_f64())
    };
    let mut sim = sim;
    let (seconds, stages) = time_steps(&mut sim, steps)?;
    let n = sim.tets.len();
    Ok(serde_json::json!({
        "case": case,
        "material": material,
        "joint_law": if case == "joints" { joint_law } else { "none" },
        "layout": layout.name(),
        "tets": n,
        "nodes": sim.nodes.len(),
        "joints": sim.joints.len(),
        "damaged_joints": sim.joints.state.iter().filter(|s| s.iter().any(|p| p.damage > 0.0)).count(),
        "broken_joints": sim.break_events.len(),
        "joint_steps_per_s": if sim.joints.is_empty() { 0.0 } else { sim.joints.len() as f64 * steps as f64 / sim.timers.get(Stage::Joints).max(1e-12) },
        "steps": steps,
        "threads": rayon::current_num_threads(),
        "seconds": seconds,
        "setup_seconds": setup,
        "tet_steps_per_s": n as f64 * steps as f64 / seconds,
        "stages": stages,
    }))
}

/// The benchmark model: a unit-aspect box of ≈`tets` tets of rock, all free, with a smooth
/// velocity field v = 0.1·(sin 2πy, sin 2πz, sin 2πx) m/s so every element deforms.
pub fn bench_model(tets: usize, formulation: Formulation, layout: Layout) -> Simulation {
    let n = ((tets as f64 / 6.0).cbrt().round() as usize).max(1);
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [n, n, n]);
    let mut sim = Simulation::new();
    let m = sim.add_material(Material::new(formulation, 2500.0, 30e9, 0.25, 0.0).unwrap());
    sim.add_body("box", &mesh, m, layout).unwrap();
    let tau = std::f64::consts::TAU;
    for i in 0..sim.nodes.len() {
        let p = sim.nodes.x0[i];
        sim.nodes.v[i] = 0.1 * Vec3::new((tau * p.y).sin(), (tau * p.z).sin(), (tau * p.x).sin());
    }
    sim
}

/// Rebar benchmark: the elastic box of [`bench_model`] (continuous) stepped without and then
/// with a square grid of straight bars along x (n/2 × n/2 bars for n cells a side, about one
/// bar per 30 tets, fib2010 bond). Reports the extra seconds of stage 1 (bars) and stage 2
/// (bond) per bar-step and per bond-point-step.
pub fn bench_rebars(tets: usize, steps: u64) -> Result<serde_json::Value, String> {
    use crate::elements::bar2::steel::{Steel, SteelLaw};
    use crate::joints::bond::BondLaw;
    let mut plain = bench_model(tets, Formulation::SmallStrain, Layout::Continuous);
    let (plain_seconds, plain_stages) = time_steps(&mut plain, steps)?;
    let mut sim = bench_model(tets, Formulation::SmallStrain, Layout::Continuous);
    let n = ((tets as f64 / 6.0).cbrt().round() as usize).max(1);
    let k = (n / 2).max(1);
    let steel = sim.add_steel(Steel {
        density: 7850.0,
        young: 200e9,
        yield_stress: 500e6,
        hardening: 1e9,
        rupture_strain: 0.1,
        rate: None,
        law: SteelLaw::Bilinear,
    });
    let given = |p: &crate::params::Param| -> Result<Option<f64>, String> {
        Ok((p.name == "fcm").then_some(40e6))
    };
    let bond = sim.add_bond_law(BondLaw::fib2010(&given, "confined", "good", 0.02)?);
    for i in 0..k {
        for j in 0..k {
            let (y, z) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
            sim.add_rebar(&crate::pipeline::RebarSpec {
                name: format!("bar{i}_{j}"),
                host: 0,
                points: vec![Vec3::new(0.01, y, z), Vec3::new(0.99, y, z)],
                diameter: 0.02,
                area: None,
                steel,
                bond_law: bond,
                segment: None,
                bending: true,
            })?;
        }
    }
    let (seconds, stages) = time_steps(&mut sim, steps)?;
    let stage = |m: &serde_json::Map<String, serde_json::Value>, s: Stage| {
        m[s.name()].as_f64().unwrap_or(0.0)
    };
    let bars_extra = stage(&stages, Stage::Elements) - stage(&plain_stages, Stage::Elements);
    let bond_extra = stage(&stages, Stage::Joints) - stage(&plain_stages, Stage::Joints);
    let per = |extra: f64, count: usize| extra / (count as f64 * steps as f64) * 1e9;
    Ok(serde_json::json!({
        "case": "rebars",
        "tets": sim.tets.len(),
        "bars": sim.bars.len(),
        "bond_points": sim.bonds.len(),
        "steps": steps,
        "threads": rayon::current_num_threads(),
        "seconds_without_rebars": plain_seconds,
        "seconds": seconds,
        "bar_ns_per_bar_step": per(bars_extra, sim.bars.len()),
        "bond_ns_per_point_step": per(bond_extra, sim.bonds.len()),
        "bar_steps_per_s": sim.bars.len() as f64 * steps as f64 / bars_extra.max(1e-12),
        "dt_without_rebars": plain.dt,
        "dt": sim.dt,
        "stages_without_rebars": plain_stages,
        "stages": stages,
    }))
}

/// Rigid-body benchmark: the elastic case's box (≈`tets` tets, continuous) against the same
/// mesh as one rigid body spinning at (1, 2, 3) rad/s, both at the deformable model's dt.
/// Reports the seconds per step of each and their ratio (target < 0.1: a rigid body costs a
/// force gather and a node update, no element forces).
pub fn bench_rigid(tets: usize, steps: u64, material: &str) -> Result<serde_json::Value, String> {
    let formulation = Formulation::from_name(material)
        .ok_or_else(|| format!("bench: unknown material law '{material}'"))?;
    let mut soft = bench_model(tets, formulation, Layout::Continuous);
    let (soft_s, soft_stages) = time_steps(&mut soft, steps)?;
    let mut rigid = bench_model(tets, formulation, Layout::Rigid);
    rigid.settings.dt = Some(soft.dt);
    rigid.set_body_spin(0, Vec3::new(1.0, 2.0, 3.0), None);
    let (rigid_s, rigid_stages) = time_steps(&mut rigid, steps)?;
    let per_step = |s: f64| s / steps as f64;
    Ok(serde_json::json!({
        "case": "rigid",
        "material": material,
        "tets": soft.tets.len(),
        "nodes": soft.nodes.len(),
        "steps": steps,
        "threads": rayon::current_num_threads(),
        "deformable_seconds_per_step": per_step(soft_s),
        "rigid_seconds_per_step": per_step(rigid_s),
        "rigid_over_deformable": rigid_s / soft_s,
        "deformable_stages": soft_stages,
        "rigid_stages": rigid_stages,
    }))
}

/// Detection benchmark: `n` boxes on a jittered lattice (spacing 1, half-sizes 0.3–0.6, so
/// each overlaps a few neighbours, as surface elements of packed fragments do). Times NBS
/// (median of 5), sort-and-sweep and parry3d-f64's BVH (build + self-traversal) on the same
/// boxes, checks they find the same number of pairs, and reports NBS memory.
pub fn bench_detection(n: usize) -> Result<serde_json::Value, String> {
    use crate::contact_detection::{nbs_pairs, sweep_pairs, Aabb, NbsWorkspace};
    if n < 2 {
        return Err("bench: --elements must be at least 2".into());
    }
    let side = (n as f64).cbrt().ceil() as usize;
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let boxes: Vec<Aabb> = (0..n)
        .map(|i| {
            let (x, y, z) = (i % side, (i / side) % side, i / (side * side));
            let c = Vec3::new(x as f64, y as f64, z as f64)
                + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.5;
            let h = Vec3::new(0.3 + 0.3 * rnd(), 0.3 + 0.3 * rnd(), 0.3 + 0.3 * rnd());
            Aabb {
                lo: c - h,
                hi: c + h,
            }
        })
        .collect();
    let mut ws = NbsWorkspace::default();
    let mut pairs = Vec::new();
    let mut times = Vec::new();
    for _ in 0..5 {
        let t = Instant::now();
        nbs_pairs(&boxes, &mut ws, &|_, _| true, &mut pairs);
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(|a, b| a.total_cmp(b));
    let nbs_ms = times[2];
    let bytes = ws.bytes() + boxes.len() * std::mem::size_of::<Aabb>() + pairs.capacity() * 8;
    // Sort and sweep degrades badly on a 3D cloud (its 1D sweep finds ~N^(2/3) boxes per
    // box): run it up to 2e5 boxes only.
    let (sweep, sweep_ms) = if n <= 200_000 {
        let t = Instant::now();
        let s = sweep_pairs(&boxes);
        (Some(s.len()), Some(t.elapsed().as_secs_f64() * 1e3))
    } else {
        (None, None)
    };
    // parry3d-f64's BVH: build from the same boxes, then traverse the tree against itself.
    use parry3d_f64::bounding_volume::Aabb as PAabb;
    use parry3d_f64::math::Vector as PV;
    use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
    let t = Instant::now();
    let leaves: Vec<PAabb> = boxes
        .iter()
        .map(|b| {
            PAabb::new(
                PV::new(b.lo.x, b.lo.y, b.lo.z),
                PV::new(b.hi.x, b.hi.y, b.hi.z),
            )
        })
        .collect();
    let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
    let mut bws = BvhWorkspace::default();
    let mut bvh_pairs = 0usize;
    bvh.traverse_bvtt_single_tree::<false>(&mut bws, &mut |_, _| bvh_pairs += 1);
    let bvh_ms = t.elapsed().as_secs_f64() * 1e3;
    if sweep.is_some_and(|s| s != pairs.len()) || bvh_pairs != pairs.len() {
        return Err(format!(
            "bench: pair counts differ: NBS {}, sweep {sweep:?}, BVH {bvh_pairs}",
            pairs.len()
        ));
    }
    Ok(serde_json::json!({
        "case": "detection",
        "elements": n,
        "pairs": pairs.len(),
        "threads": rayon::current_num_threads(),
        "ms": nbs_ms,
        "bytes": bytes,
        "sweep_ms": sweep_ms,
        "bvh_ms": bvh_ms,
    }))
}

/// Fragmented benchmark: a box cut into loose cubic blocks (3×3×2 cells, 108 tets each,
/// continuous), stacked on a fixed base plate, settling under gravity with contact (μ = 0.5,
/// ζ = 0.2). `tets` sets the number of blocks (≈ tets/108, at least 1000 for the default).
pub fn bench_fragmented(tets: usize, steps: u64) -> Result<serde_json::Value, String> {
    let blocks_per_side = ((tets as f64 / 108.0).cbrt().round() as usize).max(1);
    let size = 0.1;
    let t = Instant::now();
    let mut sim = Simulation::new();
    let m = sim.add_material(
        Material::new(Formulation::StVenantKirchhoff, 2500.0, 1e9, 0.25, 0.0).unwrap(),
    );
    let extent = size * blocks_per_side as f64;
    let plate = box_mesh(
        Vec3::new(-size, -size, -size),
        Vec3::new(extent + size, extent + size, 0.0),
        [blocks_per_side + 2, blocks_per_side + 2, 1],
    );
    sim.add_body("base", &plate, m, Layout::Continuous)?;
    let block = box_mesh(Vec3::zeros(), Vec3::repeat(size), [3, 3, 2]);
    for k in 0..blocks_per_side {
        for j in 0..blocks_per_side {
            for i in 0..blocks_per_side {
                let mut b = block.clone();
                b.translate(Vec3::new(i as f64, j as f64, k as f64) * size);
                sim.add_body(&format!("block_{i}_{j}_{k}"), &b, m, Layout::Continuous)?;
            }
        }
    }
    let base: Vec<u32> = sim.bodies[0].nodes.clone().map(|n| n as u32).collect();
    sim.loads.prescribed.push(crate::loads::PrescribedVelocity {
        nodes: base,
        components: [(); 3].map(|_| Some(crate::loads::TimeFunction::Constant(0.0))),
    });
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.contact
        .laws
        .rules
        .push(crate::contact_interaction::ContactRule::from(
            crate::contact_interaction::PotentialContact {
                friction: 0.5,
                damping: 0.2,
                ..Default::default()
            },
        ));
    let setup = t.elapsed().as_secs_f64();
    let (seconds, stages) = time_steps(&mut sim, steps)?;
    let contact =
        sim.timers.get(Stage::ContactDetection) + sim.timers.get(Stage::ContactInteraction);
    let n = sim.tets.len();
    let (kernel_pairs, kernel_ns) =
        sim.contact
            .kernel_ns_per_touching_pair(&sim.contact_detection, &sim.tets.material, 5);
    let (oracle_force, oracle_energy) = sim
        .contact
        .kernel_oracle_deviation(&sim.contact_detection, &sim.tets.material);
    let (swap_force, swap_energy, negative_energy, lowest_energy) = sim
        .contact
        .kernel_swap_deviation(&sim.contact_detection, &sim.tets.material);
    let contact_bytes = sim.contact.bytes() + sim.contact_detection.bytes();
    Ok(serde_json::json!({
        "case": "fragmented",
        "kernel_pairs": kernel_pairs,
        "kernel_ns_per_pair": kernel_ns,
        "kernel_oracle_deviation": oracle_force,
        "kernel_oracle_energy_deviation": oracle_energy,
        "kernel_swap_deviation": swap_force,
        "kernel_swap_energy_deviation": swap_energy,
        "kernel_negative_energy_pairs": negative_energy,
        "kernel_lowest_energy_ratio": lowest_energy,
        "tets": n,
        "blocks": sim.bodies.len() - 1,
        "surface_elements": sim.contact_detection.surface.len(),
        "candidate_pairs": sim.contact_detection.pairs.len(),
        "touching_pairs": sim.contact.last.active,
        "detections": sim.contact_detection.detector.detections,
        "incremental_detections": sim.contact_detection.detector.incremental,
        "steps": steps,
        "threads": rayon::current_num_threads(),
        "seconds": seconds,
        "setup_seconds": setup,
        "tet_steps_per_s": n as f64 * steps as f64 / seconds,
        "contact_over_elements": contact / sim.timers.get(Stage::Elements).max(1e-12),
        "contact_bytes": contact_bytes,
        "contact_bytes_detection": sim.contact_detection.bytes(),
        "contact_bytes_interaction": sim.contact.bytes_by_buffer(),
        "contact_bytes_per_candidate_pair": contact_bytes as f64 / sim.contact_detection.pairs.len().max(1) as f64,
        "stages": stages,
    }))
}

/// Prepare, take one untimed warm-up step (page faults, thread pool start), then time `steps`
/// steps: (seconds, seconds per stage keyed by stage module name).
fn time_steps(
    sim: &mut Simulation,
    steps: u64,
) -> Result<(f64, serde_json::Map<String, serde_json::Value>), String> {
    sim.prepare().map_err(|e| e.to_string())?;
    sim.step().map_err(|e| e.to_string())?;
    sim.timers = Default::default();
    let t = Instant::now();
    for _ in 0..steps {
        sim.step().map_err(|e| e.to_string())?;
    }
    let seconds = t.elapsed().as_secs_f64();
    let mut stages = serde_json::Map::new();
    for s in Stage::ALL {
        stages.insert(s.name().into(), sim.timers.get(s).into());
    }
    Ok((seconds, stages))
}

#[cfg(test)]
mod tests {
    /// Ranks on one machine split its cores (an 8-core node: 2 ranks take 4 threads each, 3
    /// take 2, 16 take 1); one rank, or none known, keeps rayon's default.
    #[test]
    fn ranks_share_the_cores_of_their_machine() {
        use super::share_of_cores;
        assert_eq!(share_of_cores(Some(2), 8), Some(4));
        assert_eq!(share_of_cores(Some(3), 8), Some(2));
        assert_eq!(share_of_cores(Some(16), 8), Some(1));
        assert_eq!(share_of_cores(Some(1), 8), None);
        assert_eq!(share_of_cores(None, 8), None);
    }
}
