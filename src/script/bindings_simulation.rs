//! Script bindings of the section "Simulation": creating a model, its integration and
//! damping options, and running it in stages (the run loop is in `runner.rs`).

use super::api::keys_of;
use super::opts::{err, Opts, RhaiResult};
use super::runner;
use super::types::{SimHandle, SimState};
use super::ScriptContext;
use crate::io::VtkSeries;
use crate::material::StressMeasure;
use crate::pipeline::Simulation;
use rhai::{Engine, Map, NativeCallContext};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("simulation", move |m: Map| simulation(&c, m));
    engine.register_fn(
        "integrator",
        |s: &mut SimHandle, kind: &str, m: Map| -> RhaiResult<()> {
            if kind != "central_difference" {
                return err(format!(
                    "integrator(): unknown integrator \"{kind}\"; available: central_difference"
                ));
            }
            let o = Opts::new("integrator", m, keys_of("sim.integrator"))?;
            let mut st = s.0.borrow_mut();
            if let Some(safety) = o.float("safety")? {
                if !(1e-6..=1.0).contains(&safety) {
                    return err(format!(
                        "integrator(): safety must lie in [1e-6, 1], got {safety} (below 1e-6 the time step would be a millionth of the stable one and the run would not finish)"
                    ));
                }
                st.sim.settings.safety = safety;
            }
            if let Some(dt) = o.positive("dt")? {
                st.sim.settings.dt = Some(dt);
            }
            st.sim.invalidate();
            Ok(())
        },
    );
    engine.register_fn("damping", |s: &mut SimHandle, m: Map| -> RhaiResult<()> {
        let o = Opts::new("damping", m, keys_of("sim.damping"))?;
        if let Some(a) = o.float("mass_proportional")? {
            if a < 0.0 {
                return err(format!("damping(): mass_proportional must be ≥ 0, got {a}"));
            }
            s.0.borrow_mut().sim.settings.mass_damping = a;
        }
        if let Some(body) = o.choice("frame", &[("ground", false), ("body", true)])? {
            s.0.borrow_mut().sim.settings.damping_relative_to_body = body;
        }
        Ok(())
    });
    let c = ctx.clone();
    engine.register_fn("checkpoint", move |s: &mut SimHandle| -> RhaiResult<()> {
        runner::checkpoint(&c, s)
    });
    let c = ctx.clone();
    engine.register_fn("repartition", move |s: &mut SimHandle| -> RhaiResult<f64> {
        repartition(&c, s, Map::new())
    });
    let c = ctx.clone();
    engine.register_fn(
        "repartition",
        move |s: &mut SimHandle, m: Map| -> RhaiResult<f64> { repartition(&c, s, m) },
    );
    let c = ctx;
    engine.register_fn(
        "run",
        move |nc: NativeCallContext, s: &mut SimHandle, m: Map| -> RhaiResult<()> {
            let o = Opts::new("run", m, keys_of("sim.run"))?;
            runner::run(&nc, &c, s, o)
        },
    );
}

/// `simulation(#{ … })`: an empty model with its output settings, kept in the script context
/// so that its output is finished even after an error.
fn simulation(c: &ScriptContext, m: Map) -> RhaiResult<SimHandle> {
    let o = Opts::new("simulation", m, keys_of("simulation"))?;
    let name = o.string("name")?.unwrap_or_else(|| c.script_stem());
    super::types::check_file_name("simulation()", "name", &name)?;
    let out_dir = match (&c.options.out_dir, o.string("out_dir")?) {
        (Some(cli), _) => cli.clone(),
        (None, Some(d)) => d.into(),
        (None, None) => std::path::PathBuf::from("out").join(&name),
    };
    let out_dir = claim_out_dir(c, &name, out_dir)?;
    // A restart continues the output of the simulation it restores.
    let continues = super::checkpoint::continues(c, &name);
    if !c.options.check_only && !continues && crate::parallel::is_root() {
        clear_earlier_output(&out_dir, &name, c.options.overwrite)?;
    }
    let mut sim = Simulation::new();
    // Started as one of several ranks (`mpirun`): the model is split between them.
    if let Some(world) = crate::parallel::world() {
        sim.decompose(world);
    }
    if let Some(n) = o.positive_int("energy_every")? {
        sim.settings.energy_every = n;
    }
    let stress_output = match o.string("stress_output")? {
        None => StressMeasure::Cauchy,
        Some(s) => StressMeasure::from_name(&s).map_or_else(
            || {
                err(format!(
                    "simulation(): stress_output '{s}' is not one of \"cauchy\", \"pk1\", \"pk2\""
                ))
            },
            Ok,
        )?,
    };
    let vtk_encoding = o
        .choice(
            "vtk_encoding",
            &[
                ("raw", crate::io::vtu::Encoding::Raw),
                ("base64", crate::io::vtu::Encoding::Base64),
            ],
        )?
        .unwrap_or(crate::io::vtu::Encoding::Raw);
    let vtk_pieces = o
        .choice("vtk_pieces", &[("one", false), ("per_rank", true)])?
        .unwrap_or(false);
    let handle = SimHandle(Rc::new(RefCell::new(SimState {
        sim,
        owner: super::types::Owner::new(&name),
        vtk_encoding,
        vtk_pieces,
        vtk: VtkSeries::new(out_dir.clone(), name.clone()),
        cracks_vtk: VtkSeries::new(out_dir.clone(), format!("{name}_cracks")),
        bars_vtk: VtkSeries::new(out_dir.clone(), format!("{name}_bars")),
        name,
        out_dir,
        stress_output,
        hooks: Vec::new(),
        monitors: Vec::new(),
        material_ids: HashMap::new(),
        runs: 0,
        printed_dt: None,
        wall: 0.0,
        steps_in_runs: 0,
        on_joint_broken: None,
        events_dispatched: 0,
        on_new_contact_pair: None,
        balance_warned: false,
        penetration_warned: false,
        energy_csv: None,
        energy_rows: 0,
        cracks_csv: None,
        crack_rows: 0,
        dry: c.options.check_only,
        // A restart rewrites its own output from the checkpoint on.
        overwrite: c.options.overwrite || continues,
        restore_pending: continues && !c.options.check_only,
        checkpoint_requested: false,
        run_start: None,
        native_run: false,
        rest_results: Vec::new(),
    })));
    c.sims.borrow_mut().push(handle.clone());
    Ok(handle)
}

/// `dir` without `.` components, for comparing directories as given.
fn lexical(dir: &Path) -> PathBuf {
    dir.components()
        .filter(|c| !matches!(c, std::path::Component::CurDir))
        .collect()
}

/// One output directory per simulation: `dir`, or `dir/<name>` when another simulation of
/// the script already writes to `dir` (two simulations under one `--out DIR`). A note says
/// where the output goes; a second simulation of the same name there is an error.
fn claim_out_dir(c: &ScriptContext, name: &str, dir: PathBuf) -> RhaiResult<PathBuf> {
    let mut claimed = c.out_dirs.borrow_mut();
    let owner_of = |d: &Path| {
        claimed
            .iter()
            .find(|(p, _)| lexical(p) == lexical(d))
            .map(|(_, n)| n.clone())
    };
    let dir = match owner_of(&dir) {
        None => dir,
        Some(other) => {
            let sub = dir.join(name);
            if let Some(o) = owner_of(&sub) {
                return err(format!(
                    "simulation(): '{name}' would write to {}, where simulation '{o}' writes; give each simulation its own name or out_dir",
                    sub.display()
                ));
            }
            c.say(&format!(
                "[{name}] output in {} ({} holds the output of simulation '{other}')",
                sub.display(),
                dir.display()
            ));
            sub
        }
    };
    claimed.push((dir.clone(), name.to_string()));
    Ok(dir)
}

/// Whether `file` is output of the simulation `name` (its frames, crack and bar series, the
/// energy and crack histories).
fn is_output_of(file: &str, name: &str) -> bool {
    if file == "energy.csv" || file == "cracks.csv" {
        return true;
    }
    let Some(rest) = file.strip_prefix(name) else {
        return false;
    };
    let rest = rest
        .strip_prefix("_cracks")
        .or_else(|| rest.strip_prefix("_bars"))
        .unwrap_or(rest);
    let number = |n: &str| n.len() == 6 && n.bytes().all(|b| b.is_ascii_digit());
    // NAME_NNNNNN.vtu, or in pieces NAME_NNNNNN.pvtu and NAME_NNNNNN_pR.vtu.
    let frame = rest.strip_prefix('_').is_some_and(|r| {
        r.strip_suffix(".pvtu").is_some_and(number)
            || r.strip_suffix(".vtu").is_some_and(|r| {
                number(r)
                    || r.split_once("_p").is_some_and(|(n, p)| {
                        number(n) && !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit())
                    })
            })
    });
    rest == ".pvd" || frame
}

/// Earlier output of simulation `name` in `dir`: an error listing it, or removed with
/// `--overwrite` (so no stale frame of a longer earlier run is left beside the new ones).
fn clear_earlier_output(dir: &Path, name: &str, overwrite: bool) -> RhaiResult<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let mut found: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|f| is_output_of(f, name))
        .collect();
    if found.is_empty() {
        return Ok(());
    }
    found.sort();
    if !overwrite {
        let shown: Vec<&str> = found.iter().take(4).map(String::as_str).collect();
        return err(format!(
            "simulation(): {} already holds output of simulation '{name}' ({}{}); nothing is overwritten: run with --overwrite to replace it, or give another --out (or out_dir)",
            dir.display(),
            shown.join(", "),
            if found.len() > 4 {
                format!(" and {} more", found.len() - 4)
            } else {
                String::new()
            }
        ));
    }
    for f in &found {
        let p = dir.join(f);
        std::fs::remove_file(&p)
            .map_err(|e| format!("simulation(): removing {} (--overwrite): {e}", p.display()))?;
    }
    Ok(())
}

/// `sim.repartition([#{ if_moved, if_imbalance, weigh }])`: split nodes and work between the ranks
/// again ([`crate::pipeline::Simulation::repartition`]); rank 0 reports the nodes that moved.
fn repartition(c: &ScriptContext, s: &mut SimHandle, m: Map) -> RhaiResult<f64> {
    let o = Opts::new("repartition", m, keys_of("sim.repartition"))?;
    let if_moved = o.float("if_moved")?.unwrap_or(0.0);
    if !(0.0..=1.0).contains(&if_moved) {
        return Err(o.error(format!(
            "if_moved must be a fraction in [0, 1], got {if_moved}"
        )));
    }
    let if_imbalance = o.float("if_imbalance")?.unwrap_or(0.0);
    if !(if_imbalance == 0.0 || if_imbalance >= 1.0) || !if_imbalance.is_finite() {
        return Err(o.error(format!(
            "if_imbalance must be 0 (not checked) or at least 1 (the slowest rank's work over the mean), got {if_imbalance}"
        )));
    }
    let by_work = o
        .choice("weigh", &[("corners", false), ("work", true)])?
        .unwrap_or(false);
    let mut st = s.0.borrow_mut();
    let done = st
        .sim
        .repartition(if_moved, if_imbalance, by_work)
        .map_err(|e| format!("repartition(): {e}"))?;
    if let Some(per_rank) = st.sim.nodes_per_rank().filter(|_| done.moved_nodes > 0) {
        let per_rank: Vec<String> = per_rank.iter().map(|n| n.to_string()).collect();
        let imbalance = done
            .imbalance
            .map_or(String::new(), |i| format!(" at imbalance {i:.3}"));
        c.say(&format!(
            "[{}] step {}: repartitioned{imbalance}, {} nodes changed rank ({:.3} s); nodes per rank [{}]",
            st.name,
            st.sim.step,
            done.moved_nodes,
            done.seconds,
            per_rank.join(", ")
        ));
    }
    Ok(done.seconds)
}
