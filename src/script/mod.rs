//! The scripting layer: one function builds every Rhai engine (CLI, tests, docs), with strict
//! variables, errors on invalid map properties, explicit limits and the `stdlib/` modules.
//! A script is the model: it builds geometry, materials, loads, hooks, and runs stages.

pub mod api;
mod bindings_bodies;
mod bindings_contact;
mod bindings_generators;
mod bindings_geometry;
mod bindings_ground_motion;
mod bindings_hooks;
mod bindings_joints;
mod bindings_loads;
mod bindings_materials;
mod bindings_measurements;
mod bindings_mesh_io;
mod bindings_params;
mod bindings_plot;
mod bindings_queries;
mod bindings_reinforcement;
mod bindings_rigid;
mod bindings_simulation;
pub mod checkpoint;
pub mod numbers;
pub mod opts;
pub mod postprocess;
mod rest;
mod runner;
pub mod types;

use rhai::module_resolvers::{FileModuleResolver, ModuleResolversCollection, StaticModuleResolver};
use rhai::{Engine, EvalAltResult, Module, NativeCallContext, ParseError, Position, Scope};
use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use types::SimHandle;

/// How a script is run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// `--set name=value` overrides of `params(..)`.
    pub overrides: Vec<(String, String)>,
    /// `--out DIR`: output directory for every simulation of the script.
    pub out_dir: Option<PathBuf>,
    /// No timing/energy summary (script prints still appear).
    pub quiet: bool,
    /// `fdem check`: build the model up to the first `run`, validate it, and stop there.
    pub check_only: bool,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// `--overwrite`: replace the output of an earlier run in the same directory (without
    /// it, a simulation whose files are already there is an error naming them).
    pub overwrite: bool,
    /// `--max-operations N`: stop a script that runs more than N Rhai operations without a
    /// time step (a runaway loop); None: [`DEFAULT_MAX_OPERATIONS`]; Some(0): no limit.
    pub max_operations: Option<u64>,
    /// How `.geo` files are run through gmsh (commands refused unless allowed, time limit).
    pub geo: crate::mesh::gmsh::GeoPolicy,
    /// `--restart FILE`: continue the simulation of this checkpoint.
    pub restart: Option<PathBuf>,
}

/// Rhai operations a script may run between two time steps (about 10 s on one core of the
/// reference machine) before it is stopped as a runaway loop; `--max-operations` changes it.
pub const DEFAULT_MAX_OPERATIONS: u64 = 200_000_000;

/// State shared by the bindings of one script run.
pub struct ScriptContext {
    pub options: RunOptions,
    pub script_path: PathBuf,
    pub params_called: Cell<bool>,
    pub sims: RefCell<Vec<SimHandle>>,
    /// The running script's AST (joint laws written in it are compiled from here).
    pub ast: RefCell<Option<rhai::AST>>,
    /// Output directories claimed by the simulations of this script (directory, name).
    pub out_dirs: RefCell<Vec<(PathBuf, String)>>,
    /// Rhai's operation count when the last time step was taken (the runaway-loop limit
    /// counts from there).
    pub ops_at_step: Cell<u64>,
    /// A time step was taken since the progress callback last looked.
    pub stepped: Cell<bool>,
    /// Inside a run's time loop: an interrupt is handled by the runner at the end of the
    /// step, not by the progress callback.
    pub in_run: Cell<bool>,
    /// `--restart`: the checkpoint, until its simulation's run restores it.
    pub restart: RefCell<Option<checkpoint::PendingRestart>>,
}

impl ScriptContext {
    /// The context of a script at `script_path` run with `options`, before it runs.
    pub fn new(options: RunOptions, script_path: PathBuf) -> Self {
        ScriptContext {
            options,
            script_path,
            params_called: Cell::new(false),
            sims: RefCell::new(Vec::new()),
            ast: RefCell::new(None),
            out_dirs: RefCell::new(Vec::new()),
            ops_at_step: Cell::new(0),
            stepped: Cell::new(false),
            in_run: Cell::new(false),
            restart: RefCell::new(None),
        }
    }

    /// Print a line of script output (silent under `fdem check`, and while a restart replays
    /// the script up to its checkpoint).
    pub fn say(&self, msg: &str) {
        // On a decomposed run rank 0 speaks for all.
        if !self.options.check_only && !self.replaying() && crate::parallel::is_root() {
            println!("{msg}");
        }
    }

    /// `--restart` is replaying the script up to its checkpoint: what the script prints and
    /// checks there belongs to the run that wrote the checkpoint (it got past those checks),
    /// and is computed from a model that has not been stepped.
    pub fn replaying(&self) -> bool {
        self.restart.borrow().is_some()
    }
    pub fn script_stem(&self) -> String {
        self.script_path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into())
    }
}

/// The `stdlib/` modules, embedded so scripts run from any directory.
pub const STDLIB: &[(&str, &str)] = &[
    ("stdlib/units", include_str!("../../stdlib/units.rhai")),
    (
        "stdlib/joint_laws",
        include_str!("../../stdlib/joint_laws.rhai"),
    ),
    (
        "stdlib/friction_laws",
        include_str!("../../stdlib/friction_laws.rhai"),
    ),
];

/// Build the Rhai engine used for every script.
pub fn build_engine(ctx: Rc<ScriptContext>) -> Engine {
    let mut engine = Engine::new();
    engine
        .set_strict_variables(true)
        .set_fail_on_invalid_map_property(true)
        .set_max_expr_depths(128, 64)
        .set_max_call_levels(64)
        // Unlimited in total (a long run's hooks add up); the progress callback below stops a
        // script that runs too long between two time steps.
        .set_max_operations(0)
        .set_max_modules(64)
        .set_max_string_size(16 << 20)
        .set_max_array_size(50_000_000)
        .set_max_map_size(100_000);
    // The script's own output shows under `fdem check` too (up to its first run).
    let c = ctx.clone();
    engine.on_print(move |s| {
        if !c.replaying() && crate::parallel::is_root() {
            println!("{s}");
        }
    });
    engine.on_debug(|s, src, pos| eprintln!("{}:{}: {s}", src.unwrap_or("script"), pos));
    // One `register` per section of the API (api.rs), each in its own bindings_*.rs file.
    // A binding converts Rhai values, calls the core (Simulation, mesh, loads) and turns its
    // errors into script errors; it computes nothing itself.
    types::register(&mut engine);
    bindings_params::register(&mut engine, ctx.clone());
    bindings_geometry::register(&mut engine);
    bindings_simulation::register(&mut engine, ctx.clone());
    bindings_materials::register(&mut engine);
    bindings_bodies::register(&mut engine);
    bindings_rigid::register(&mut engine);
    bindings_measurements::register(&mut engine);
    bindings_loads::register(&mut engine);
    bindings_ground_motion::register(&mut engine);
    bindings_queries::register(&mut engine);
    bindings_hooks::register(&mut engine);
    bindings_plot::register(&mut engine);
    bindings_joints::register(&mut engine);
    bindings_contact::register(&mut engine, ctx.clone());
    bindings_generators::register(&mut engine);
    bindings_joints::register_script_laws(&mut engine, ctx.clone());
    bindings_reinforcement::register(&mut engine);
    bindings_reinforcement::register_script_laws(&mut engine, ctx.clone());
    bindings_mesh_io::register(&mut engine, ctx.clone());
    rest::register(&mut engine, ctx.clone());
    numbers::register(&mut engine);
    // stdlib modules are compiled by this engine (they may call host functions).
    let mut stdlib = StaticModuleResolver::new();
    for (name, src) in STDLIB {
        let mut ast = engine
            .compile(*src)
            .unwrap_or_else(|e| panic!("{name}.rhai does not compile: {e}"));
        ast.set_source(format!("{name}.rhai"));
        let module = Module::eval_ast_as_new(Scope::new(), &ast, &engine)
            .unwrap_or_else(|e| panic!("{name}.rhai: {e}"));
        stdlib.insert(*name, module);
    }
    // The operation limit and interrupts watch the script from here on: the stdlib modules
    // above are fdem's, and a small `--max-operations` stopping their setup was a panic.
    let c = ctx.clone();
    engine.on_progress(move |ops| progress(&c, ops));
    let mut resolvers = ModuleResolversCollection::new();
    resolvers.push(stdlib);
    let base = ctx
        .script_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    resolvers.push(FileModuleResolver::new_with_path(base));
    engine.set_module_resolver(resolvers);
    engine
}

/// The progress callback: stop a runaway script (too many operations since the last time
/// step) and a script interrupted by SIGINT/SIGTERM outside a run's time loop.
fn progress(c: &ScriptContext, ops: u64) -> Option<rhai::Dynamic> {
    if c.stepped.get() {
        c.stepped.set(false);
        c.ops_at_step.set(ops);
    }
    if ops < c.ops_at_step.get() {
        c.ops_at_step.set(0);
    }
    let limit = c.options.max_operations.unwrap_or(DEFAULT_MAX_OPERATIONS);
    if limit > 0 && ops - c.ops_at_step.get() > limit {
        return Some(
            format!(
                "the script ran {limit} operations without a time step (a runaway loop?); if it really needs more, raise the limit with fdem run --max-operations N (0: no limit)"
            )
            .into(),
        );
    }
    if !c.in_run.get() {
        if let Some(sig) = crate::limits::interrupt::requested() {
            return Some(
                format!(
                    "interrupted by {}",
                    crate::limits::interrupt::signal_name(sig)
                )
                .into(),
            );
        }
    }
    None
}

/// What a finished script leaves behind (used by tests and the CLI summary).
pub struct ScriptReport {
    pub sims: Vec<SimHandle>,
}

/// A script error, formatted as `file:line:col: error: message` with the source line.
#[derive(Debug, Clone)]
pub struct ScriptError(pub String);

impl std::fmt::Display for ScriptError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ScriptError {}

/// Resolve a data path named in a script: as given if it exists, else next to the script.
pub fn resolve_path(nc: &NativeCallContext, path: &str) -> PathBuf {
    let p = PathBuf::from(path);
    if p.exists() || p.is_absolute() {
        return p;
    }
    if let Some(src) = nc.call_source() {
        if let Some(dir) = Path::new(src).parent() {
            let q = dir.join(path);
            if q.exists() {
                return q;
            }
        }
    }
    p
}

/// Run a script file.
pub fn run_file(path: &Path, options: RunOptions) -> Result<ScriptReport, ScriptError> {
    let (report, result) = run_file_with_report(path, options);
    result.map(|()| report)
}

/// Run a script file; the simulations it made come back even when it fails (a failed
/// self-check, a script error, an unstable run), so their summaries can still be printed.
pub fn run_file_with_report(
    path: &Path,
    options: RunOptions,
) -> (ScriptReport, Result<(), ScriptError>) {
    match crate::limits::read_text_bounded(path, crate::limits::MAX_TEXT_INPUT) {
        Ok(source) => run_source_with_report(path, &source, options),
        Err(e) => (
            ScriptReport { sims: Vec::new() },
            Err(ScriptError(format!(
                "{}: cannot read the script: {e}",
                path.display()
            ))),
        ),
    }
}

/// Run script text as if it were the file `path`.
pub fn run_source(
    path: &Path,
    source: &str,
    options: RunOptions,
) -> Result<ScriptReport, ScriptError> {
    let (report, result) = run_source_with_report(path, source, options);
    result.map(|()| report)
}

/// [`run_source`], keeping the simulations when the script fails.
pub fn run_source_with_report(
    path: &Path,
    source: &str,
    options: RunOptions,
) -> (ScriptReport, Result<(), ScriptError>) {
    let ctx = Rc::new(ScriptContext::new(options, path.to_path_buf()));
    let result = run_in(&ctx, path, source);
    let sims = ctx.sims.borrow().clone();
    (ScriptReport { sims }, result)
}

/// Compile and run the script in `ctx`.
fn run_in(ctx: &Rc<ScriptContext>, path: &Path, source: &str) -> Result<(), ScriptError> {
    let engine = build_engine(ctx.clone());
    let label = path.display().to_string();
    let mut ast = engine
        .compile(source)
        .map_err(|e| ScriptError(format_parse_error(&label, source, &e)))?;
    ast.set_source(label.clone());
    if !ctx.options.overrides.is_empty() && !may_call_params(&ast) {
        return Err(set_without_params(
            &label,
            &ctx.options.overrides,
            " (nothing was run)",
        ));
    }
    if let Some(p) = &ctx.options.restart {
        let pending = checkpoint::load(p, path, &ctx.options.overrides).map_err(ScriptError)?;
        *ctx.restart.borrow_mut() = Some(pending);
    }
    *ctx.ast.borrow_mut() = Some(ast.clone());
    let result = engine.run_ast(&ast);
    // Finish output of every simulation, even after an error.
    for s in ctx.sims.borrow().iter() {
        let mut st = s.0.borrow_mut();
        let _ = st.vtk.flush();
        let _ = st.cracks_vtk.flush();
        let _ = st.bars_vtk.flush();
    }
    match result {
        Err(e) if matches!(&*e, EvalAltResult::ErrorTerminated(t, _) if t.to_string() == runner::CHECK_DONE) =>
            {}
        r => r.map_err(|e| ScriptError(format_eval_error(&label, source, &e)))?,
    }
    if !ctx.options.overrides.is_empty() && !ctx.params_called.get() {
        return Err(set_without_params(&label, &ctx.options.overrides, ""));
    }
    if !ctx.options.check_only {
        checkpoint::check_used(ctx).map_err(ScriptError)?;
    }
    Ok(())
}

/// Whether the script calls `params(..)` anywhere or imports a module (which might): a
/// `--set` on a script that cannot declare parameters is refused before it runs.
fn may_call_params(ast: &rhai::AST) -> bool {
    use rhai::{ASTNode, Expr, Stmt};
    let mut found = false;
    ast.walk(&mut |path: &[ASTNode]| {
        found = match path.last() {
            Some(ASTNode::Expr(Expr::FnCall(f, _))) => f.name == "params",
            Some(ASTNode::Stmt(Stmt::Import(..))) => true,
            _ => false,
        };
        !found
    });
    found
}

/// `--set` given to a script without `params(..)`.
fn set_without_params(label: &str, overrides: &[(String, String)], note: &str) -> ScriptError {
    let keys: Vec<&str> = overrides.iter().map(|(k, _)| k.as_str()).collect();
    ScriptError(format!(
        "{label}: error: --set {} given, but the script declares no params(#{{..}}) to override{note}",
        keys.join(", ")
    ))
}

impl ScriptReport {
    /// Timing and energy summaries of every simulation that ran.
    pub fn summaries(&self) -> Vec<String> {
        self.sims
            .iter()
            .filter_map(|s| {
                let st = s.0.borrow();
                (st.runs > 0).then(|| {
                    runner::summary(
                        &st.name,
                        &st.sim,
                        st.wall,
                        st.steps_in_runs,
                        st.vtk.entries.len(),
                        &st.out_dir,
                    )
                })
            })
            .collect()
    }
}

fn snippet(source: &str, pos: Position) -> String {
    match (
        pos.line(),
        source
            .lines()
            .nth(pos.line().unwrap_or(1).saturating_sub(1)),
    ) {
        (Some(l), Some(text)) => {
            let col = pos.position().unwrap_or(1).max(1);
            format!("\n{l:>5} | {text}\n      | {}^", " ".repeat(col - 1))
        }
        _ => String::new(),
    }
}

fn loc(label: &str, pos: Position) -> String {
    match (pos.line(), pos.position()) {
        (Some(l), Some(c)) => format!("{label}:{l}:{c}"),
        (Some(l), None) => format!("{label}:{l}"),
        _ => label.to_string(),
    }
}

fn format_parse_error(label: &str, source: &str, e: &ParseError) -> String {
    let pos = e.position();
    format!(
        "{}: error: {}{}",
        loc(label, pos),
        e.err_type(),
        snippet(source, pos)
    )
}

/// The file of an imported module named `src` in Rhai's errors (`helpers` for `import
/// "helpers"`): `<script dir>/helpers.rhai` when that file exists, else `src` as it is (the
/// embedded stdlib modules are named `stdlib/….rhai` already).
fn module_file(label: &str, src: &str) -> String {
    let p = Path::new(src);
    if p.is_file() || src.starts_with("stdlib/") {
        return src.to_string();
    }
    let dir = Path::new(label).parent().unwrap_or(Path::new(""));
    let with_ext = if p.extension().is_some() {
        p.to_path_buf()
    } else {
        p.with_extension("rhai")
    };
    let q = dir.join(with_ext);
    if q.is_file() {
        q.display().to_string()
    } else {
        src.to_string()
    }
}

/// Unwrap nested function-call errors down to the innermost one, keeping the call chain.
fn format_eval_error(label: &str, source: &str, e: &EvalAltResult) -> String {
    let mut chain = Vec::new();
    let mut cur = e;
    let mut src_label = label.to_string();
    loop {
        match cur {
            EvalAltResult::ErrorInFunctionCall(name, src, inner, pos) => {
                let shown = if name.starts_with("anon$") {
                    "closure".to_string()
                } else {
                    format!("function '{name}'")
                };
                chain.push(format!("  in {shown} called at {}", loc(&src_label, *pos)));
                if name == "eval" {
                    // Positions inside are lines of the evaluated string, not of the file.
                    src_label = "eval string".to_string();
                } else if !src.is_empty() {
                    src_label = module_file(label, src);
                }
                cur = inner;
            }
            EvalAltResult::ErrorInModule(path, inner, pos) => {
                chain.push(format!(
                    "  in module '{path}' imported at {}",
                    loc(&src_label, *pos)
                ));
                cur = inner;
            }
            _ => break,
        }
    }
    let pos = cur.position();
    let msg = match cur {
        EvalAltResult::ErrorRuntime(d, _) => d.to_string(),
        EvalAltResult::ErrorTerminated(d, _) => d.to_string(),
        other => {
            let s = other.to_string();
            // Rhai appends " (line l, position c)"; the location is printed in front already.
            match s.rfind(" (line ") {
                Some(i) => s[..i].to_string(),
                None => s,
            }
        }
    };
    let snip = if src_label == label {
        snippet(source, pos)
    } else {
        // An imported module's own file, when it can be read.
        crate::limits::read_text_bounded(Path::new(&src_label), 1 << 20)
            .map(|text| snippet(&text, pos))
            .unwrap_or_default()
    };
    let mut out = format!("{}: error: {msg}{snip}", loc(&src_label, pos));
    for c in chain.iter().rev() {
        out.push('\n');
        out.push_str(c);
    }
    out
}
