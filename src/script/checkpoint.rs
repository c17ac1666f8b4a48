//! `sim.checkpoint()` and `fdem run SCRIPT --restart FILE`: the script side of checkpoints
//! (the file itself: [`crate::io::checkpoint`]).
//!
//! A restarted script runs again from its first line and builds the same model (materials,
//! compiled laws, hooks and monitors are code, not data: they come from the script). The
//! simulation the checkpoint names then fast-forwards: its `run` calls before the one the
//! checkpoint was taken in return at once, and its frames and histories are not rewritten;
//! at that run the state is restored — the simulation, monitors, hook clocks, output series
//! and history files (cut back to their length at the checkpoint) — and the run goes on to the
//! end it had. From there the script runs as it did the first time.
//!
//! What is not restored: values the script itself computed from the model before the
//! restored run (they see the model as built, not as stepped), and variables a closure
//! changes. Keep such values in monitors, or compute them after the last run. What a skipped
//! `bring_to_rest` returns is restored: the checkpoint keeps each call's result
//! ([`RestRecord`]).

use super::types::{MonitorHandle, SimHandle, SimState};
use super::ScriptContext;
use crate::io::checkpoint::{self, Fingerprint, Head, Loaded, RunPoint};
use crate::io::CsvStream;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The file name of a simulation's checkpoint in its output directory.
pub const FILE_NAME: &str = "checkpoint.fdemck";

/// A monitor's recorded values and the length of its CSV file.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct MonitorState {
    pub name: String,
    pub times: Vec<f64>,
    pub steps: Vec<u64>,
    pub values: Vec<f64>,
    pub csv_bytes: Option<u64>,
}

/// The script layer's part of a checkpoint.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct ScriptState {
    pub runs: usize,
    pub wall: f64,
    pub steps_in_runs: u64,
    pub events_dispatched: usize,
    pub balance_warned: bool,
    pub penetration_warned: bool,
    pub printed_dt: Option<String>,
    pub energy_rows: usize,
    pub crack_rows: usize,
    pub energy_csv_bytes: Option<u64>,
    pub cracks_csv_bytes: Option<u64>,
    pub monitors: Vec<MonitorState>,
    /// Each periodic hook's next firing time [s], in registration order.
    pub hook_times: Vec<f64>,
    /// Frames of the body, crack and bar series: (time, file name).
    pub frames: [Vec<(f64, String)>; 3],
    /// What the completed `bring_to_rest` calls returned.
    pub rest_results: Vec<RestRecord>,
}

/// What one `sim.bring_to_rest` returned (its map's entries), and after which completed run
/// (`runs`, counting it): a restart returns it again from the call it skips, so a script's
/// checks of it see the values of the run that wrote the checkpoint, not a skipped call's.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct RestRecord {
    pub runs: usize,
    pub converged: bool,
    pub steps: u64,
    pub time: f64,
    pub kinetic: f64,
    pub work: f64,
    pub ratio: f64,
    pub damping: f64,
}

/// The record of the `bring_to_rest` a restart is skipping (the `runs`-th run), from the
/// pending checkpoint; None when not replaying or not recorded.
pub fn recorded_rest(ctx: &ScriptContext, runs: usize) -> Option<RestRecord> {
    let pending = ctx.restart.borrow();
    let ss = &pending.as_ref()?.loaded.head.script_state;
    ss.rest_results.iter().find(|r| r.runs == runs).cloned()
}

/// A checkpoint given with `--restart`, waiting for its simulation's run.
pub struct PendingRestart {
    pub path: PathBuf,
    pub loaded: Loaded<ScriptState>,
}

/// Read `path` for `--restart` and compare what can be compared before the script runs.
pub fn load(
    path: &Path,
    script: &Path,
    overrides: &[(String, String)],
) -> Result<PendingRestart, String> {
    let loaded: Loaded<ScriptState> = checkpoint::read(path)?;
    let head = &loaded.head;
    if head.overrides != overrides {
        let show = |o: &[(String, String)]| {
            if o.is_empty() {
                "no --set".to_string()
            } else {
                o.iter()
                    .map(|(k, v)| format!("--set {k}={v}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            }
        };
        return Err(format!(
            "--restart {}: the checkpoint was made with {}, this run has {}: a restart continues the same model, so give the same --set values",
            path.display(),
            show(&head.overrides),
            show(overrides)
        ));
    }
    let name = script.file_name().map(|n| n.to_string_lossy().into_owned());
    if name.as_deref() != Some(head.script.as_str()) {
        return Err(format!(
            "--restart {}: the checkpoint was made by script '{}', not '{}'",
            path.display(),
            head.script,
            name.unwrap_or_default()
        ));
    }
    Ok(PendingRestart {
        path: path.to_path_buf(),
        loaded,
    })
}

/// Write the checkpoint of `st` (taken between runs, or inside a run started at
/// `run_start`), replacing the previous one; returns its path.
pub fn write(
    ctx: &ScriptContext,
    st: &mut SimState,
    run_start: Option<(f64, u64)>,
) -> Result<PathBuf, String> {
    let path = st.out_dir.join(FILE_NAME);
    // What may fail on rank 0 alone (it writes the files) is only reported after the
    // ranks' collective below, which every rank must reach.
    let script_state = script_state(st);
    let (simulation, runs_completed) = (st.name.clone(), st.runs);
    // Rank 0 encodes and writes the whole model, which it gathers (a collective); the other
    // ranks send their part and go on from the state they had.
    let written = st.sim.with_whole_state_on_root(|sim| {
        let head = Head {
            fdem_version: env!("CARGO_PKG_VERSION").to_string(),
            build: checkpoint::BUILD_ID.to_string(),
            simulation,
            script: ctx
                .script_path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            overrides: ctx.options.overrides.clone(),
            point: RunPoint {
                runs_completed,
                run_start,
            },
            time: sim.time,
            step: sim.step,
            fingerprint: Fingerprint::of(sim),
            script_state: script_state?,
        };
        checkpoint::write(&path, &head, sim)
    });
    written.transpose()?;
    Ok(path)
}

/// The script layer's state for a checkpoint, after putting every queued frame on disk (the
/// frames a checkpoint lists must be on disk when it is).
fn script_state(st: &mut SimState) -> Result<ScriptState, String> {
    st.vtk.flush()?;
    st.cracks_vtk.flush()?;
    st.bars_vtk.flush()?;
    let monitors = st
        .monitors
        .iter()
        .map(monitor_state)
        .collect::<Result<Vec<_>, String>>()?;
    Ok(ScriptState {
        runs: st.runs,
        wall: st.wall,
        steps_in_runs: st.steps_in_runs,
        events_dispatched: st.events_dispatched,
        balance_warned: st.balance_warned,
        penetration_warned: st.penetration_warned,
        printed_dt: st.printed_dt.clone(),
        energy_rows: st.energy_rows,
        crack_rows: st.crack_rows,
        energy_csv_bytes: st.energy_csv.as_ref().map(|c| c.bytes()).transpose()?,
        cracks_csv_bytes: st.cracks_csv.as_ref().map(|c| c.bytes()).transpose()?,
        monitors,
        hook_times: st.hooks.iter().map(|h| h.next_time).collect(),
        frames: [
            st.vtk.entries.clone(),
            st.cracks_vtk.entries.clone(),
            st.bars_vtk.entries.clone(),
        ],
        rest_results: st.rest_results.clone(),
    })
}

fn monitor_state(m: &MonitorHandle) -> Result<MonitorState, String> {
    let d = m.0.borrow();
    Ok(MonitorState {
        name: d.name.clone(),
        times: d.times.clone(),
        steps: d.steps.clone(),
        values: d.values.clone(),
        csv_bytes: d.csv.as_ref().map(|c| c.bytes()).transpose()?,
    })
}

/// Whether the simulation named `name` is the one `--restart` continues (it then does not
/// clear its earlier output: the restart continues it).
pub fn continues(ctx: &ScriptContext, name: &str) -> bool {
    ctx.restart
        .borrow()
        .as_ref()
        .is_some_and(|r| r.loaded.head.simulation == name)
}

/// What a `run` call of a simulation does under `--restart`.
pub enum RunAction {
    /// Step as usual.
    Step,
    /// A run the checkpoint is past: return at once.
    Skip,
    /// The state was restored; the run goes on, started at this (time, step) when the
    /// checkpoint was taken inside it.
    Resumed(Option<(f64, u64)>),
}

/// Decide what this `run` does, restoring the checkpoint when this is its run.
pub fn at_run(ctx: &ScriptContext, s: &SimHandle) -> Result<RunAction, String> {
    let mut st = s.0.borrow_mut();
    if !st.restore_pending {
        return Ok(RunAction::Step);
    }
    let pending = ctx
        .restart
        .borrow_mut()
        .take()
        .ok_or("--restart: the checkpoint was already used")?;
    let head = &pending.loaded.head;
    if st.runs < head.point.runs_completed {
        st.runs += 1;
        *ctx.restart.borrow_mut() = Some(pending);
        return Ok(RunAction::Skip);
    }
    let where_ = format!("--restart {}", pending.path.display());
    if let Some(d) = head.fingerprint.difference(&Fingerprint::of(&st.sim)) {
        return Err(format!(
            "{where_}: the script built another model than the checkpoint's ({d}); was the script or a mesh changed?"
        ));
    }
    let saved = pending
        .loaded
        .simulation()
        .map_err(|e| format!("{where_}: {e}"))?;
    st.sim.restore(saved);
    apply_script_state(&mut st, &head.script_state).map_err(|e| format!("{where_}: {e}"))?;
    st.restore_pending = false;
    // The replay is over: from here on the script prints and checks again.
    ctx.say(&format!(
        "[{}] restarted from {} at step {}, t = {} s: the model, its monitors and output are restored; the script's output and self-checks before this point were skipped (they belong to the run that wrote the checkpoint), and values it computed there or that its callbacks collected are not restored",
        st.name,
        pending.path.display(),
        st.sim.step,
        super::numbers::sig(st.sim.time, 6)
    ));
    Ok(RunAction::Resumed(head.point.run_start))
}

/// Put the script layer back as it was at the checkpoint; history files continue from
/// their length then.
fn apply_script_state(st: &mut SimState, ss: &ScriptState) -> Result<(), String> {
    // The script may have added monitors and hooks after a checkpoint taken between runs:
    // the checkpoint's are the first ones.
    if st.monitors.len() < ss.monitors.len() || st.hooks.len() < ss.hook_times.len() {
        return Err(format!(
            "the checkpoint has {} monitors and {} periodic hooks, the script made only {} and {} by this run",
            ss.monitors.len(),
            ss.hook_times.len(),
            st.monitors.len(),
            st.hooks.len()
        ));
    }
    for (m, saved) in st.monitors.iter().zip(&ss.monitors) {
        let mut d = m.0.borrow_mut();
        if d.name != saved.name {
            return Err(format!(
                "the checkpoint's monitor '{}' is '{}' in the script",
                saved.name, d.name
            ));
        }
        d.times = saved.times.clone();
        d.steps = saved.steps.clone();
        d.values = saved.values.clone();
        d.dry = st.dry;
        d.csv = match saved.csv_bytes {
            Some(n) if !st.dry => Some(CsvStream::resume(&d.path, n)?),
            _ => None,
        };
    }
    for m in &st.monitors[ss.monitors.len()..] {
        m.0.borrow_mut().dry = st.dry;
    }
    let time = st.sim.time;
    for (i, h) in st.hooks.iter_mut().enumerate() {
        h.next_time = match (ss.hook_times.get(i), h.every_time) {
            (Some(&t), _) => t,
            // Added after the checkpoint: its clock starts at the restored time, as `every`
            // starts it.
            (None, Some(period)) => ((time / period).floor() + 1.0) * period,
            (None, None) => h.next_time,
        };
    }
    st.runs = ss.runs;
    st.rest_results = ss.rest_results.clone();
    st.wall = ss.wall;
    st.steps_in_runs = ss.steps_in_runs;
    st.events_dispatched = ss.events_dispatched;
    st.balance_warned = ss.balance_warned;
    st.penetration_warned = ss.penetration_warned;
    st.printed_dt = ss.printed_dt.clone();
    st.energy_rows = ss.energy_rows;
    st.crack_rows = ss.crack_rows;
    if !st.dry {
        st.energy_csv = ss
            .energy_csv_bytes
            .map(|n| CsvStream::resume(&st.out_dir.join("energy.csv"), n))
            .transpose()?;
        st.cracks_csv = ss
            .cracks_csv_bytes
            .map(|n| CsvStream::resume(&st.out_dir.join("cracks.csv"), n))
            .transpose()?;
    }
    st.vtk.entries = ss.frames[0].clone();
    st.cracks_vtk.entries = ss.frames[1].clone();
    st.bars_vtk.entries = ss.frames[2].clone();
    Ok(())
}

/// After the script: a checkpoint whose run was never reached is an error.
pub fn check_used(ctx: &ScriptContext) -> Result<(), String> {
    let Some(p) = ctx.restart.borrow_mut().take() else {
        return Ok(());
    };
    let h = &p.loaded.head;
    Err(format!(
        "--restart {}: the script ended without reaching the checkpoint (simulation '{}', taken after {} completed run(s) at step {}). Either the script changed, or a loop or `if` between runs reads the model's state: while a restart replays the script up to its checkpoint, runs return at once and the model is the one the script built (the checkpoint's state is restored at its run), so such a condition can take another branch and call `run` fewer times. A checkpoint taken before such a loop, or in a script whose runs do not depend on the state, restarts",
        p.path.display(),
        h.simulation,
        h.point.runs_completed,
        h.step
    ))
}
