//! `sim.run(..)`: the time loop as seen from a script — steps, periodic hooks, monitors,
//! `stop_when`, progress on a terminal, histories streamed as they are sampled, and a stop
//! at the end of a step on SIGINT/SIGTERM.

use super::checkpoint::{self, RunAction};
use super::numbers::sig;
use super::opts::{Opts, RhaiResult};
use super::types::{MonitorHandle, SimHandle, SimState};
use super::ScriptContext;
use crate::contact_interaction::{DeepestOverlap, PENETRATION_WARNING};
use crate::io::{frame::encode_frame, CsvStream};
use crate::limits::interrupt;
use crate::pipeline::{Energy, SimError, Simulation, Stage};
use rhai::{Dynamic, FnPtr, NativeCallContext};
use std::cell::Cell;
use std::io::{IsTerminal, Write};
use std::rc::Rc;
use std::time::Instant;

/// Token with which `fdem check` ends a script at its first `run`.
pub const CHECK_DONE: &str = "fdem-check: model validated";

/// Run the simulation until one of the limits in `o` is reached.
pub fn run(nc: &NativeCallContext, ctx: &ScriptContext, s: &SimHandle, o: Opts) -> RhaiResult<()> {
    let max_time = o.float("max_time")?;
    let duration = o.positive("duration")?;
    let steps = o.positive_int("steps")?;
    let stop_when = o.fn_ptr("stop_when")?;
    let check_every = o.positive_int("check_every")?.unwrap_or(1);
    if max_time.is_none() && duration.is_none() && steps.is_none() {
        return super::opts::err(
            "run(): give a limit: max_time, duration or steps (stop_when alone could run forever)",
        );
    }
    prepare_run(ctx, s)?;
    if ctx.options.check_only {
        // `fdem check` validates the model as built up to the first run, then stops the script.
        return Err(
            rhai::EvalAltResult::ErrorTerminated(CHECK_DONE.into(), rhai::Position::NONE).into(),
        );
    }
    let start = match checkpoint::at_run(ctx, s).map_err(|e| format!("run(): {e}"))? {
        RunAction::Skip => return Ok(()),
        RunAction::Resumed(start) => start,
        RunAction::Step => None,
    };
    let limits = Limits::new(s, start, max_time, duration, steps, stop_when, check_every);
    run_within(nc, ctx, s, limits)
}

/// A stop rule evaluated natively on the model (`sim.bring_to_rest`).
pub type NativeStop = Box<dyn FnMut(&mut Simulation) -> bool>;

/// Run `steps` steps at most, asking `stop` every `check_every` steps: a run as `run` does it
/// (monitors, hooks, output), ended by a rule in Rust. Returns whether `stop` ended it, or
/// None when a restart skipped the run (the checkpoint is past it).
pub fn run_native(
    nc: &NativeCallContext,
    ctx: &ScriptContext,
    s: &SimHandle,
    steps: u64,
    check_every: u64,
    stop: NativeStop,
) -> RhaiResult<Option<bool>> {
    prepare_run(ctx, s)?;
    if ctx.options.check_only {
        return Err(
            rhai::EvalAltResult::ErrorTerminated(CHECK_DONE.into(), rhai::Position::NONE).into(),
        );
    }
    // Checkpoints are never taken inside a native run, so a restore is never into one.
    if let RunAction::Skip = checkpoint::at_run(ctx, s).map_err(|e| format!("run(): {e}"))? {
        return Ok(None);
    }
    s.0.borrow_mut().native_run = true;
    let mut limits = Limits::new(s, None, None, None, Some(steps), None, check_every);
    let stopped = Rc::new(Cell::new(false));
    let flag = stopped.clone();
    let mut stop = stop;
    limits.native_stop = Some(Box::new(move |sim: &mut Simulation| {
        let done = stop(sim);
        flag.set(done);
        done
    }));
    let r = run_within(nc, ctx, s, limits);
    s.0.borrow_mut().native_run = false;
    r?;
    Ok(Some(stopped.get()))
}

/// The run itself: first monitor values, the time loop, the run's bookkeeping and output.
fn run_within(
    nc: &NativeCallContext,
    ctx: &ScriptContext,
    s: &SimHandle,
    mut limits: Limits,
) -> RhaiResult<()> {
    limits.check_length(s)?;
    check_hook_periods(s)?;
    open_histories(s)?;
    let mut progress = Progress::new(ctx.options.progress && std::io::stderr().is_terminal());
    // Monitors get a first value when the model has not moved yet.
    let monitors: Vec<MonitorHandle> = s.0.borrow().monitors.clone();
    for m in &monitors {
        if m.0.borrow().values.is_empty() {
            record(nc, s, m)?;
        }
    }
    let wall = Instant::now();
    ctx.in_run.set(true);
    s.0.borrow_mut().run_start = Some((limits.t_start, limits.step_start));
    let result = step_until_done(nc, ctx, s, &mut limits, &monitors, &mut progress);
    ctx.in_run.set(false);
    progress.finish();
    {
        let mut st = s.0.borrow_mut();
        st.wall += wall.elapsed().as_secs_f64();
        let done = st.sim.step - limits.step_start;
        st.steps_in_runs += done;
        st.runs += 1;
        st.run_start = None;
    }
    // Every rank's timings for the summary's load balance (a collective: every rank of a
    // decomposed model ends a run at the same step, and errors that stop a run are agreed).
    if result.is_ok() {
        s.0.borrow_mut().sim.gather_rank_timings();
    }
    // Output is finished whether the run ended normally or not.
    let written = finish_run_output(s);
    result?;
    written.map_err(|e| format!("run(): {e}"))?;
    // A checkpoint asked for in the run's last step (or in a native run) is taken now,
    // between runs.
    if std::mem::take(&mut s.0.borrow_mut().checkpoint_requested) {
        write_checkpoint(ctx, s, "run()")?;
    }
    Ok(())
}

/// `sim.checkpoint()`: written now between runs; inside a run, at the end of the step.
pub fn checkpoint(ctx: &ScriptContext, s: &SimHandle) -> RhaiResult<()> {
    {
        let mut st = s.0.borrow_mut();
        if st.dry || st.restore_pending {
            // `fdem check` writes nothing; a restart replaying up to its checkpoint has it.
            return Ok(());
        }
        if ctx.in_run.get() {
            st.checkpoint_requested = true;
            return Ok(());
        }
    }
    write_checkpoint(ctx, s, "checkpoint()")
}

/// Write the checkpoint of `s` now (at the end of a step, or between runs).
fn write_checkpoint(ctx: &ScriptContext, s: &SimHandle, func: &str) -> RhaiResult<()> {
    let mut st = s.0.borrow_mut();
    let start = st.run_start;
    checkpoint::write(ctx, &mut st, start).map_err(|e| format!("{func}: {e}"))?;
    Ok(())
}

/// Open `energy.csv` (and `cracks.csv` with joints) at the first run, header first.
fn open_histories(s: &SimHandle) -> RhaiResult<()> {
    let mut st = s.0.borrow_mut();
    if st.dry {
        return Ok(());
    }
    if st.energy_csv.is_none() {
        let path = st.out_dir.join("energy.csv");
        st.energy_csv =
            Some(CsvStream::create(&path, &ENERGY_HEADER).map_err(|e| format!("run(): {e}"))?);
    }
    if st.cracks_csv.is_none() && !st.sim.joints.is_empty() {
        let path = st.out_dir.join("cracks.csv");
        st.cracks_csv =
            Some(CsvStream::create(&path, &CRACKS_HEADER).map_err(|e| format!("run(): {e}"))?);
    }
    append_histories(&mut st).map_err(|e| format!("run(): {e}").into())
}

/// Columns of `energy.csv`.
pub(super) const ENERGY_HEADER: [&str; 18] = [
    "step",
    "time",
    "kinetic",
    "strain",
    "gravity_work",
    "force_work",
    "reaction_work",
    "ground_work",
    "mass_damping",
    "viscous_damping",
    "joint",
    "fracture",
    "contact",
    "friction",
    "plastic",
    "bond",
    "bond_slip",
    "balance_error",
];

/// One row of `energy.csv` (the columns of [`ENERGY_HEADER`]).
pub(super) fn energy_row(e: &crate::pipeline::EnergySample) -> [f64; 18] {
    let en = &e.energy;
    [
        e.step as f64,
        e.time,
        en.kinetic,
        en.strain,
        en.gravity_work,
        en.force_work,
        en.reaction_work,
        en.ground_work,
        en.mass_damping,
        en.viscous_damping,
        en.joint,
        en.fracture,
        en.contact,
        en.friction,
        en.plastic,
        en.bond,
        en.bond_slip,
        en.balance_error(),
    ]
}

/// Columns of `cracks.csv` (mode: 1 = I, 2 = II, 3 = mixed; body: body id).
const CRACKS_HEADER: [&str; 7] = ["joint", "time", "x", "y", "z", "mode", "body"];

/// Append the energy samples and break events not yet in their files (every step; no
/// allocation: rows are arrays, the line buffer is reused).
fn append_histories(st: &mut SimState) -> Result<(), String> {
    let st = &mut *st;
    if let Some(csv) = st.energy_csv.as_mut() {
        for e in &st.sim.energy_history[st.energy_rows..] {
            csv.row(&energy_row(e))?;
        }
        st.energy_rows = st.sim.energy_history.len();
    }
    if let Some(csv) = st.cracks_csv.as_mut() {
        for e in &st.sim.break_events[st.crack_rows..] {
            csv.row(&[
                e.joint as f64,
                e.time,
                e.centroid.x,
                e.centroid.y,
                e.centroid.z,
                e.mode.code() as f64,
                e.body as f64,
            ])?;
        }
        st.crack_rows = st.sim.break_events.len();
    }
    Ok(())
}

/// A periodic hook by time shorter than the time step would run every step: refused, saying
/// so (a period of 1e-300 s also could not advance the hook's clock).
fn check_hook_periods(s: &SimHandle) -> RhaiResult<()> {
    let st = s.0.borrow();
    let dt = st.sim.dt;
    for h in &st.hooks {
        if let Some(t) = h.every_time {
            if t < dt * (1.0 - 1e-9) {
                return super::opts::err(format!(
                    "run(): every(#{{ time: {} }}) is shorter than the time step dt = {} s: the hook would run on every step; use every(#{{ steps: 1 }}) for that, or a longer time",
                    sig(t, 6),
                    sig(dt, 6)
                ));
            }
        }
    }
    Ok(())
}

/// Prepare the model (first run: overlaps, unjointed bodies) and print a changed dt line.
fn prepare_run(ctx: &ScriptContext, s: &SimHandle) -> RhaiResult<()> {
    let mut st = s.0.borrow_mut();
    st.sim.prepare().map_err(|e| format!("run(): {e}"))?;
    if st.runs == 0 {
        st.sim
            .check_body_overlaps()
            .map_err(|e| format!("run(): {e}"))?;
        warn_jointless_bodies(ctx, &st);
        if let Some(split) = st.sim.split_summary() {
            ctx.say(&format!("[{}] {split}", st.name));
        }
    }
    // Printed again when the step or what sets it changes, not when the element that sets
    // it has only moved (its place is where it is now).
    let (line, key) = st
        .sim
        .dt_info
        .as_ref()
        .map(|i| {
            let unplaced = crate::pipeline::TimeStepInfo {
                centroid: Default::default(),
                ..i.clone()
            };
            (i.to_string(), unplaced.to_string())
        })
        .unwrap_or_default();
    if st.printed_dt.as_deref() != Some(key.as_str()) {
        ctx.say(&format!("[{}] {line}", st.name));
        st.printed_dt = Some(key);
    }
    Ok(())
}

/// Warn about each jointed body that has no joints (its tetrahedra move independently).
fn warn_jointless_bodies(ctx: &ScriptContext, st: &SimState) {
    let sim = &st.sim;
    let with_joints: std::collections::HashSet<u32> = sim
        .joints
        .tets
        .iter()
        .map(|t| sim.tets.body[t[0] as usize])
        .collect();
    for (id, b) in sim.bodies.iter().enumerate() {
        if b.layout == crate::state::Layout::Jointed && !with_joints.contains(&(id as u32)) {
            ctx.say(&format!(
                "[{}] WARNING: body '{}' is jointed but has no joints: its tetrahedra are not connected and will move independently (sim.insert_joints(..) adds them)",
                st.name, b.name
            ));
        }
    }
}

/// Where a run ends: the first limit reached, or `stop_when` returning true.
struct Limits {
    /// Simulated time at the start of the run [s].
    t_start: f64,
    /// Step count at the start of the run.
    step_start: u64,
    /// Time step [s].
    dt: f64,
    /// Time at which the run ends [s] (infinite without `max_time` and `duration`).
    t_end: f64,
    /// Step count at which the run ends (`u64::MAX` without `steps`).
    step_end: u64,
    /// The script's `stop_when` closure.
    stop_when: Option<FnPtr>,
    /// `stop_when` is asked every `check_every` steps.
    check_every: u64,
    /// A rule in Rust asked as `stop_when` is (`run_native`).
    native_stop: Option<NativeStop>,
}

impl Limits {
    /// Limits of a run starting now: `max_time` [s], `duration` [s], `steps`, first reached.
    /// `start`: where the run started when it is resumed from a checkpoint (time [s], step);
    /// None: now.
    fn new(
        s: &SimHandle,
        start: Option<(f64, u64)>,
        max_time: Option<f64>,
        duration: Option<f64>,
        steps: Option<u64>,
        stop_when: Option<FnPtr>,
        check_every: u64,
    ) -> Self {
        let (t_start, step_start, dt) = {
            let st = s.0.borrow();
            let (t, n) = start.unwrap_or((st.sim.time, st.sim.step));
            (t, n, st.sim.dt)
        };
        let t_end = match (max_time, duration) {
            (Some(a), Some(b)) => a.min(t_start + b),
            (Some(a), None) => a,
            (None, Some(b)) => t_start + b,
            (None, None) => f64::INFINITY,
        };
        let step_end = steps.map(|n| step_start + n).unwrap_or(u64::MAX);
        Limits {
            t_start,
            step_start,
            dt,
            t_end,
            step_end,
            stop_when,
            check_every,
            native_stop: None,
        }
    }

    /// The most steps one run may take: more is a time step or a duration out of scale
    /// (`dt: 1e-300`), which would never finish.
    const MAX_STEPS: f64 = 1.0e10;

    /// Error when the run would take more than [`Self::MAX_STEPS`] steps.
    fn check_length(&self, s: &SimHandle) -> RhaiResult<()> {
        let by_time = (self.t_end - self.t_start) / self.dt;
        let by_steps = (self.step_end - self.step_start) as f64;
        let steps = by_time.min(by_steps);
        if steps > Self::MAX_STEPS {
            let st = s.0.borrow();
            return super::opts::err(format!(
                "run(): reaching t = {} s with dt = {} s takes {:.3e} steps (more than {:.0e}): the run would not finish; check the time step (integrator dt, safety) and the run's length",
                sig(self.t_end, 6),
                sig(st.sim.dt, 6),
                steps,
                Self::MAX_STEPS
            ));
        }
        Ok(())
    }

    /// Fraction of the run done at `time` [s] and `step` (the larger of the two fractions).
    fn fraction_done(&self, time: f64, step: u64) -> f64 {
        let frac_t = if self.t_end.is_finite() {
            (time - self.t_start) / (self.t_end - self.t_start)
        } else {
            0.0
        };
        let frac_s = if self.step_end < u64::MAX {
            (step - self.step_start) as f64 / (self.step_end - self.step_start) as f64
        } else {
            0.0
        };
        frac_t.max(frac_s)
    }
}

/// The time loop: step, with hooks, callbacks and monitors, until `lim` ends the run.
fn step_until_done(
    nc: &NativeCallContext,
    ctx: &ScriptContext,
    s: &SimHandle,
    lim: &mut Limits,
    monitors: &[MonitorHandle],
    progress: &mut Progress,
) -> RhaiResult<()> {
    loop {
        let (time, step) = {
            let st = s.0.borrow();
            (st.sim.time, st.sim.step)
        };
        if step >= lim.step_end || time >= lim.t_end - 1e-9 * lim.dt {
            return check_configuration(s);
        }
        // (On a decomposed model every rank stops at the same step, if any rank got it.)
        let signal = s.0.borrow_mut().sim.agree_on_signal(interrupt::requested());
        if let Some(sig) = signal {
            return Err(interrupted(ctx, s, sig));
        }
        {
            let mut st = s.0.borrow_mut();
            // The last step of a run with a known end is an energy sample.
            if step + 1 >= lim.step_end || time + lim.dt >= lim.t_end - 1e-9 * lim.dt {
                st.sim.sample_next = true;
            }
            let samples = st.sim.energy_history.len();
            let stepped = st.sim.step();
            ctx.stepped.set(true);
            // The samples up to a failed step are written before its error is returned.
            append_histories(&mut st).map_err(|e| format!("run(): {e}"))?;
            stepped.map_err(|e| sim_error(&e))?;
            if st.sim.energy_history.len() > samples {
                warn_balance(ctx, &mut st);
            }
            warn_penetration(ctx, &mut st);
            // A frame that failed to write (on the background thread) stops the run now.
            st.vtk.check().map_err(|e| format!("run(): {e}"))?;
            st.cracks_vtk.check().map_err(|e| format!("run(): {e}"))?;
            st.bars_vtk.check().map_err(|e| format!("run(): {e}"))?;
        }
        call_hooks(nc, s)?;
        dispatch_break_events(nc, s)?;
        dispatch_contact_events(nc, s)?;
        let step = step + 1;
        for m in monitors {
            let every = m.0.borrow().every;
            if step % every == 0 {
                record(nc, s, m)?;
            }
        }
        if stop_requested(nc, s, lim, step)? {
            return check_configuration(s);
        }
        // A checkpoint asked for during this step, now that the step is complete (its
        // hooks, events and monitors done) and the run goes on.
        let due = {
            let st = s.0.borrow();
            st.checkpoint_requested && !st.native_run
        };
        if due {
            s.0.borrow_mut().checkpoint_requested = false;
            write_checkpoint(ctx, s, "checkpoint()")?;
        }
        if progress.enabled {
            progress.update(lim.fraction_done(time, step), step - lim.step_start, time);
        }
    }
}

/// Print once per simulation when a sample's balance error passes
/// [`Energy::WARNING_THRESHOLD`].
fn warn_balance(ctx: &ScriptContext, st: &mut SimState) {
    let e = &st.sim.energy;
    if st.balance_warned || !e.balance_is_off() {
        return;
    }
    st.balance_warned = true;
    ctx.say(&format!(
        "[{}] WARNING: energy balance error {} J at t = {} s is {} of {} (over {} %): energy is created or lost that no term books. Check it before trusting the results: a time step near its limit (lower the integrator's safety), a friction or joint law out of its range, or a known limit (docs/theory/contact.md, Energy account)",
        st.name,
        sig(e.balance_error(), 4),
        sig(st.sim.time, 6),
        sig(e.relative_balance_error(), 3),
        e.scale_name(),
        sig(100.0 * Energy::WARNING_THRESHOLD, 2)
    ));
}

/// Print once per simulation when a contact overlap first passes
/// [`PENETRATION_WARNING`] of the smaller element height of its pair.
fn warn_penetration(ctx: &ScriptContext, st: &mut SimState) {
    let d = st.sim.contact.deepest;
    if st.penetration_warned || d.ratio <= PENETRATION_WARNING {
        return;
    }
    st.penetration_warned = true;
    ctx.say(&format!(
        "[{}] WARNING: contact penetration {} m at t = {} s is {} % of the element height (limit {} %): the contact potential is meant for overlaps much thinner than the elements, and a pair that keeps approaching can pass through. Raise the contact `penalty` (default 10·E), lower the impact speed, or use larger elements at the contact (docs/theory/contact.md, Overlap)",
        st.name,
        sig(d.depth, 3),
        sig(d.time, 6),
        sig(100.0 * d.ratio, 3),
        sig(100.0 * PENETRATION_WARNING, 2)
    ));
}

/// Whether `stop_when` (asked every `check_every` steps of the run) ends the run at `step`.
fn stop_requested(
    nc: &NativeCallContext,
    s: &SimHandle,
    lim: &mut Limits,
    step: u64,
) -> RhaiResult<bool> {
    // `check_every` ≥ 1 (`positive_int`).
    if !(step - lim.step_start).is_multiple_of(lim.check_every) {
        return Ok(false);
    }
    if let Some(stop) = &mut lim.native_stop {
        if stop(&mut s.0.borrow_mut().sim) {
            return Ok(true);
        }
    }
    let Some(f) = &lim.stop_when else {
        return Ok(false);
    };
    let r: Dynamic = f.call_within_context(nc, (s.clone(),))?;
    match r.as_bool() {
        Ok(stop) => Ok(stop),
        Err(t) => super::opts::err(format!(
            "run(): stop_when must return true or false, got {t}"
        )),
    }
}

/// The end-of-run check for inverted elements, as a script error.
fn check_configuration(s: &SimHandle) -> RhaiResult<()> {
    // The run ends: every node current on every rank, for the check and for what the
    // script does between runs. Joint and pair histories are shared only when something
    // reads them (a frame gathers what it shows to rank 0; checkpoints, queries and a new
    // split share what they need); before 2026-12-07 every run's end shared them all.
    s.0.borrow_mut().sim.synchronize_nodes();
    s.0.borrow()
        .sim
        .check_configuration()
        .map_err(|e| sim_error(&e))
}

fn sim_error(e: &SimError) -> Box<rhai::EvalAltResult> {
    format!("run(): {e}").into()
}

fn call_hooks(nc: &NativeCallContext, s: &SimHandle) -> RhaiResult<()> {
    let n = s.0.borrow().hooks.len();
    for i in 0..n {
        let due: Option<FnPtr> = {
            let mut st = s.0.borrow_mut();
            let (time, step) = (st.sim.time, st.sim.step);
            let h = &mut st.hooks[i];
            let due = match (h.every_steps, h.every_time) {
                (Some(k), _) => step % k == 0,
                (None, Some(t)) if time >= h.next_time * (1.0 - 1e-12) => {
                    // Bounded: a period far below dt (a hook added inside a run, which
                    // `check_hook_periods` has not seen) jumps instead of looping.
                    let mut n = 0;
                    while h.next_time <= time * (1.0 + 1e-12) {
                        h.next_time += t;
                        n += 1;
                        if n > 1000 {
                            h.next_time = time + t.max(time * 1e-12);
                            break;
                        }
                    }
                    true
                }
                _ => false,
            };
            due.then(|| h.f.clone())
        };
        if let Some(f) = due {
            let _: Dynamic = f.call_within_context(nc, (s.clone(),))?;
        }
    }
    Ok(())
}

fn dispatch_contact_events(nc: &NativeCallContext, s: &SimHandle) -> RhaiResult<()> {
    let (f, events) = {
        let mut st = s.0.borrow_mut();
        let Some(f) = st.on_new_contact_pair.clone() else {
            return Ok(());
        };
        let ev = std::mem::take(&mut st.sim.contact.events);
        let maps: Vec<rhai::Map> = ev
            .iter()
            .map(|e| super::bindings_contact::event_map(&st.sim, e))
            .collect();
        (f, maps)
    };
    for m in events {
        let _: Dynamic = f.call_within_context(nc, (s.clone(), m))?;
    }
    Ok(())
}

fn dispatch_break_events(nc: &NativeCallContext, s: &SimHandle) -> RhaiResult<()> {
    loop {
        let (f, event) = {
            let mut st = s.0.borrow_mut();
            let Some(f) = st.on_joint_broken.clone() else {
                return Ok(());
            };
            let k = st.events_dispatched;
            let Some(e) = st.sim.break_events.get(k) else {
                return Ok(());
            };
            let m = super::bindings_joints::event_map(&st.sim, e);
            st.events_dispatched += 1;
            (f, m)
        };
        let _: Dynamic = f.call_within_context(nc, (s.clone(), event))?;
    }
}

fn record(nc: &NativeCallContext, s: &SimHandle, m: &MonitorHandle) -> RhaiResult<()> {
    let f = m.0.borrow().f.clone();
    let v: Dynamic = f.call_within_context(nc, (s.clone(),))?;
    let value = super::opts::to_float(&v).ok_or_else(|| {
        format!(
            "monitor '{}': the closure must return a number, got {} ({v})",
            m.0.borrow().name,
            v.type_name()
        )
    })?;
    let (t, step) = {
        let st = s.0.borrow();
        (st.sim.time, st.sim.step)
    };
    let mut d = m.0.borrow_mut();
    d.times.push(t);
    d.steps.push(step);
    d.values.push(value);
    open_monitor(&mut d).map_err(|e| format!("monitor '{}': {e}", d.name))?;
    if let Some(csv) = d.csv.as_mut() {
        csv.row(&[step as f64, t, value])
            .map_err(|e| format!("monitor '{}': {e}", d.name))?;
    }
    Ok(())
}

/// Create a monitor's CSV file (header `step,time,<name>`, or `step,time,<name> [<unit>]`
/// with a unit) unless it is open (or under `fdem check`, which writes nothing).
fn open_monitor(d: &mut super::types::MonitorData) -> Result<(), String> {
    if d.csv.is_none() && !d.dry {
        let value = crate::io::column_header(&d.name, d.unit.as_deref());
        d.csv = Some(CsvStream::create(&d.path, &["step", "time", &value])?);
    }
    Ok(())
}

/// `monitor.write_csv()`: the file is streamed as values are recorded; this makes sure it
/// exists (a header alone when nothing was recorded yet).
pub fn write_monitor(m: &MonitorHandle) -> Result<(), String> {
    let mut d = m.0.borrow_mut();
    open_monitor(&mut d).map_err(|e| format!("write_csv(): {e}"))
}

/// Stop a run on SIGINT/SIGTERM at the end of a step: a final frame is written (the
/// histories are up to date), and the error says where the output is.
fn interrupted(ctx: &ScriptContext, s: &SimHandle, sig: i32) -> Box<rhai::EvalAltResult> {
    // The checkpoint first: a restarted run numbers its frames as the uninterrupted run
    // would (the final frame's number is the next periodic frame's).
    let restart = interrupt_checkpoint(ctx, s);
    let frame = write_vtk(s)
        .err()
        .map(|e| format!(" (the final frame failed: {e})"));
    let st = s.0.borrow();
    format!(
        "run(): interrupted by {} at step {}, t = {} s; the histories and a final frame are in {}{}; {restart}",
        interrupt::signal_name(sig),
        st.sim.step,
        sig_fmt(st.sim.time),
        st.out_dir.display(),
        frame.unwrap_or_default()
    )
    .into()
}

/// The checkpoint of an interrupted run, and how to continue from it (or why not).
fn interrupt_checkpoint(ctx: &ScriptContext, s: &SimHandle) -> String {
    // (Every rank of a decomposed model stops at the same step; the checkpoint gathers the
    // whole state to rank 0, as for any checkpoint.)
    let mut st = s.0.borrow_mut();
    if st.dry || st.restore_pending {
        return "no checkpoint was written".into();
    }
    if st.native_run {
        return "no checkpoint was written (a bring_to_rest stage cannot be resumed in its middle)"
            .into();
    }
    let start = st.run_start;
    match checkpoint::write(ctx, &mut st, start) {
        Ok(p) => {
            let mut cmd = format!("fdem run {}", ctx.script_path.display());
            for (k, v) in &ctx.options.overrides {
                cmd.push_str(&format!(" --set {k}={v}"));
            }
            if let Some(d) = &ctx.options.out_dir {
                cmd.push_str(&format!(" --out {}", d.display()));
            }
            format!("continue with: {cmd} --restart {}", p.display())
        }
        Err(e) => format!("the checkpoint failed: {e}"),
    }
}

fn sig_fmt(x: f64) -> String {
    sig(x, 6)
}

/// At the end of every run: histories up to date (they are streamed; this catches the last
/// samples) and every queued frame on disk. Errors name the file.
fn finish_run_output(s: &SimHandle) -> Result<(), String> {
    let monitors = s.0.borrow().monitors.clone();
    for m in &monitors {
        let mut d = m.0.borrow_mut();
        open_monitor(&mut d)?;
    }
    let mut st = s.0.borrow_mut();
    append_histories(&mut st)?;
    // Frames in pieces are written by every rank: a failure is that rank's own.
    st.vtk.flush().map_err(|e| {
        if st.vtk_pieces {
            crate::parallel::on_this_rank(e)
        } else {
            e
        }
    })?;
    st.cracks_vtk.flush()?;
    st.bars_vtk.flush()
}

/// `sim.write_vtk()`: encode a frame now and queue it for the background writer.
pub fn write_vtk(s: &SimHandle) -> RhaiResult<()> {
    let mut st = s.0.borrow_mut();
    st.sim.prepare().map_err(|e| format!("write_vtk(): {e}"))?;
    // `fdem check` writes nothing; a restart replaying up to its checkpoint has these frames
    // on disk already.
    if st.dry || st.restore_pending {
        return Ok(());
    }
    // No frame shows inverted elements: the last step's motion is checked before it is
    // written (stage 1 of the next step would find them, but a frame may come first). Each
    // rank checks its piece, the tets current on it, and every rank learns the count.
    if st.sim.step > 0 {
        st.sim
            .check_configuration_by_pieces()
            .map_err(|e| format!("write_vtk(): {e}"))?;
    }
    // Rank 0 writes whole frames, cracks and bars, from what it gathers (the other ranks
    // send their part and are done); with pieces every rank writes its piece, from its own
    // state and what its neighbours send of the joints and pairs at its piece, and rank 0
    // the crack and bar frames, whole, from the nodes they read (gathered first: a piece
    // may fail on one rank alone).
    let reads = if st.vtk_pieces {
        let reads = st.sim.piece_frame_reads();
        st.sim.gather_whole_series_nodes_to_root();
        reads
    } else {
        match st.sim.gather_frame_to_root() {
            Some(reads) => reads,
            None => return Ok(()),
        }
    };
    let t = st.sim.time;
    if st.vtk_pieces {
        write_vtk_piece(&mut st, &reads)?;
    } else {
        let bytes = encode_frame(&st.sim, &reads, st.stress_output, st.vtk_encoding)
            .map_err(|e| format!("write_vtk(): {e}"))?;
        st.vtk
            .push(t, bytes)
            .map_err(|e| format!("write_vtk(): {e}"))?;
    }
    if !crate::parallel::is_root() {
        return Ok(());
    }
    // Crack frames start with the first crack (some readers, meshio among them, cannot read a
    // frame without cells).
    if !st.sim.break_events.is_empty() {
        let cracks = crate::io::frame::encode_cracks(&st.sim, st.vtk_encoding)
            .map_err(|e| format!("write_vtk(): {e}"))?;
        st.cracks_vtk
            .push(t, cracks)
            .map_err(|e| format!("write_vtk(): {e}"))?;
    }
    if !st.sim.bars.is_empty() {
        let bars = crate::io::frame::encode_bars(&st.sim, st.vtk_encoding)
            .map_err(|e| format!("write_vtk(): {e}"))?;
        st.bars_vtk
            .push(t, bars)
            .map_err(|e| format!("write_vtk(): {e}"))?;
    }
    Ok(())
}

/// This rank's piece of a frame written in pieces (`vtk_pieces: "per_rank"`): the tets whose
/// first node it owns (every tet on one process), and on rank 0 the `.pvtu` naming every
/// rank's piece. The crack and bar series stay whole, from rank 0.
fn write_vtk_piece(st: &mut SimState, reads: &crate::pipeline::FrameReads) -> RhaiResult<()> {
    let (rank, size) = st.sim.rank_and_size();
    let sources = st.vtk.piece_names(size);
    let sim = &st.sim;
    let owner = |e: usize| sim.node_owner(sim.tets.nodes[e][0] as usize);
    let (piece, pvtu) = crate::io::frame::encode_frame_piece(
        sim,
        reads,
        st.stress_output,
        st.vtk_encoding,
        |e| owner(e) == rank,
        &sources,
    )
    .map_err(|e| format!("write_vtk(): {e}"))?;
    let t = st.sim.time;
    st.vtk
        .push_piece(t, rank, piece, (rank == 0).then_some(pvtu))
        .map_err(|e| crate::parallel::on_this_rank(format!("write_vtk(): {e}")))?;
    Ok(())
}

/// The summary line of the rebars (empty without them): bond energy, bars yielded and broken,
/// bending hinges that reached their plastic moment.
fn reinforcement_line(sim: &Simulation) -> String {
    if sim.bars.is_empty() {
        return String::new();
    }
    let ruptured = sim.bars.ruptured_at.iter().filter(|t| !t.is_nan()).count();
    let yielded = sim.bars.history.iter().filter(|&&a| a > 0.0).count();
    let hinges = &sim.bars.hinges;
    let bending = if hinges.is_empty() {
        String::new()
    } else {
        let kinked = hinges.plastic_angle.iter().filter(|&&a| a != 0.0).count();
        format!("; {} hinges: {kinked} kinked past M_p", hinges.len())
    };
    format!(
        "   {:<20} {:>12}   ({} rebars, {} bars: {yielded} yielded, {ruptured} ruptured{bending}; {} bond points)\n",
        "bond (elastic)",
        sig(sim.energy.bond, 5),
        sim.rebars.len(),
        sim.bars.len(),
        sim.bonds.len()
    )
}

/// The per-stage timing table and the energy summary printed at the end of `fdem run`.
/// Times have 6 significant digits, dt and energies 5, relative errors 3 ([`sig`]).
pub fn summary(
    name: &str,
    sim: &Simulation,
    wall: f64,
    steps: u64,
    frames: usize,
    out_dir: &std::path::Path,
) -> String {
    let mut s = String::new();
    let rate = if wall > 0.0 {
        steps as f64 * sim.tets.len() as f64 / wall
    } else {
        0.0
    };
    s.push_str(&format!(
        "── {name}: {steps} steps to t = {} s (dt = {} s), {} tets, {} nodes; {:.2} s wall, {:.2} M tet-steps/s\n",
        sig(sim.time, 6),
        sig(sim.dt, 5),
        sim.tets.len(),
        sim.nodes.len(),
        wall,
        rate / 1e6
    ));
    s.push_str(&stage_table(sim));
    let e = &sim.energy;
    let joules = |x: f64| sig(x, 5);
    let at = sim.energy_history.last().map(|h| h.time).unwrap_or(0.0);
    s.push_str(&format!(
        "   energy [J] at t = {} s (last sample)\n",
        sig(at, 6)
    ));
    s.push_str(&format!("   {:<20} {:>12}\n", "kinetic", joules(e.kinetic)));
    s.push_str(&format!("   {:<20} {:>12}\n", "strain", joules(e.strain)));
    let ground = if e.ground_work != 0.0 {
        format!(", ground motion {}", joules(e.ground_work))
    } else {
        String::new()
    };
    s.push_str(&format!(
        "   {:<20} {:>12}   (gravity {}, forces {}, constraints {}{ground})\n",
        "external work",
        joules(e.external_work()),
        joules(e.gravity_work),
        joules(e.force_work),
        joules(e.reaction_work)
    ));
    s.push_str(&format!(
        "   {:<20} {:>12}   (mass damping {}, viscous {}, fracture {}, friction {}{})\n",
        "dissipated",
        joules(e.dissipated()),
        joules(e.mass_damping),
        joules(e.viscous_damping),
        joules(e.fracture),
        joules(e.friction),
        if sim.bars.is_empty() {
            String::new()
        } else {
            format!(
                ", steel {}, bond slip {}",
                joules(e.plastic),
                joules(e.bond_slip)
            )
        }
    ));
    s.push_str(&reinforcement_line(sim));
    if sim.contact.is_enabled() {
        let (c, cd) = (&sim.contact, &sim.contact_detection);
        s.push_str(&format!(
            "   {:<20} {:>12}   ({} surface tets, {} candidate pairs, {} touching, {} detections, {} incremental after fracture)\n",
            "contact (elastic)",
            joules(e.contact),
            cd.surface.len(),
            cd.candidate_pairs(),
            c.last.active,
            cd.detector.detections,
            cd.detector.incremental
        ));
        s.push_str(&penetration_lines(&c.deepest));
    }
    if !sim.joints.is_empty() {
        s.push_str(&format!(
            "   {:<20} {:>12}   ({} of {} joints broken)\n",
            "joints (elastic)",
            joules(e.joint),
            sim.break_events.len(),
            sim.joints.len()
        ));
        let (_, mut volume, _) = crate::fracture::fragment_sizes(
            &sim.tets,
            &sim.materials,
            &sim.joints,
            sim.nodes.len(),
        );
        let count = volume.len();
        volume.sort_by(|a, b| b.total_cmp(a));
        let shown: Vec<String> = volume.iter().take(5).map(|v| sig(*v, 4)).collect();
        let more = if count > 5 { ", …" } else { "" };
        s.push_str(&format!(
            "   fragments            {count} (volumes [m³], largest first: {}{more})\n",
            shown.join(", ")
        ));
    }
    s.push_str(&balance_lines(sim));
    s.push_str(&format!(
        "   output: {} ({frames} VTK frames, energy.csv, monitors{})\n",
        out_dir.display(),
        if sim.joints.is_empty() {
            ""
        } else {
            ", cracks.csv"
        }
    ));
    s
}

/// The deepest contact penetration of the simulation, with a warning above
/// [`PENETRATION_WARNING`] of the element height; nothing before any contact.
fn penetration_lines(d: &DeepestOverlap) -> String {
    if d.ratio == 0.0 {
        return String::new();
    }
    let mut s = format!(
        "   deepest penetration  {} m at t = {} s ({} % of the element height)\n",
        sig(d.depth, 3),
        sig(d.time, 6),
        sig(100.0 * d.ratio, 3)
    );
    if d.ratio > PENETRATION_WARNING {
        s.push_str(&format!(
            "   WARNING: contact penetration passed {} % of the element height; contact forces there are not to be trusted (raise the contact penalty)\n",
            sig(100.0 * PENETRATION_WARNING, 2)
        ));
    }
    s
}

/// The per-stage timing table of the summary.
fn stage_table(sim: &Simulation) -> String {
    let mut s = String::new();
    let total = sim.timers.total();
    s.push_str("   stage                 time [s]    share\n");
    for stage in Stage::ALL {
        let t = sim.timers.get(stage);
        let share = if total > 0.0 { 100.0 * t / total } else { 0.0 };
        s.push_str(&format!(
            "   {:<20} {:>9.3} {:>7.1} %\n",
            stage.name(),
            t,
            share
        ));
    }
    s.push_str(&format!("   {:<20} {:>9.3}\n", "total", total));
    let (rank, ranks) = sim.rank_and_size();
    if ranks > 1 {
        let e = sim.exchanged();
        let per_step = |b: u64| sig(b as f64 / sim.step.max(1) as f64 / 1e6, 3);
        s.push_str(&format!(
            "   {:<20} {:>9.3}            (rank {rank} of {ranks}, besides the stages; received {} MB per step: {} the halo, {} the nodes near its own before detections, {} the whole model's state for output and queries, {} the rest)\n",
            "exchange",
            e.seconds,
            per_step(e.bytes),
            per_step(e.halo),
            per_step(e.near),
            per_step(e.whole),
            per_step(e.bytes.saturating_sub(e.halo + e.near + e.whole)),
        ));
        s.push_str(&rank_table(sim.rank_seconds()));
    }
    s
}

/// The load balance of a decomposed run: each rank's time per stage, all stages and
/// exchange, and the imbalance (the slowest rank's stages over the mean: a step waits for
/// the slowest rank, and the others spend the difference in the exchange).
fn rank_table(ranks: &[crate::parallel::RankSeconds]) -> String {
    if ranks.len() < 2 {
        return String::new();
    }
    let mut s = String::from("   per rank [s]        ");
    for r in 0..ranks.len() {
        s.push_str(&format!(" {:>9}", format!("rank {r}")));
    }
    s.push('\n');
    let row = |label: &str, value: &dyn Fn(&crate::parallel::RankSeconds) -> f64| {
        let mut line = format!("   {label:<20}");
        for r in ranks {
            line.push_str(&format!(" {:>9.3}", value(r)));
        }
        line.push('\n');
        line
    };
    for (i, stage) in Stage::ALL.iter().enumerate() {
        if ranks.iter().any(|r| r.stages[i] > 0.0005) {
            s.push_str(&row(stage.name(), &|r| r.stages[i]));
        }
    }
    let total = |r: &crate::parallel::RankSeconds| r.stages.iter().sum::<f64>();
    s.push_str(&row("all stages", &total));
    s.push_str(&row("exchange", &|r| r.exchange));
    if ranks.iter().any(|r| r.pairs_held > 0.0) {
        let mut line = format!("   {:<20}", "pairs held (most)");
        for r in ranks {
            line.push_str(&format!(" {:>9}", r.pairs_held));
        }
        s.push_str(&line);
        s.push_str("   (candidate contact pairs: each rank holds those it computes)\n");
    }
    if ranks.iter().all(|r| r.peak_memory > 0.0) {
        let mut line = format!("   {:<20}", "peak memory [MB]");
        for r in ranks {
            line.push_str(&format!(" {:>9.1}", r.peak_memory / 1e6));
        }
        s.push_str(&line);
        s.push_str("   (resident, each rank's most so far: what a node must hold for its ranks)\n");
    }
    let slowest = ranks.iter().map(total).fold(0.0, f64::max);
    let mean = ranks.iter().map(total).sum::<f64>() / ranks.len() as f64;
    if mean > 0.0 {
        s.push_str(&format!(
            "   {:<20} {:>9.3}   (the slowest rank's stages over the mean; the others wait in the exchange)\n",
            "imbalance",
            slowest / mean
        ));
    }
    s
}

/// The initial energy and balance lines of the summary, with a warning when some sample's
/// balance error passed [`Energy::WARNING_THRESHOLD`].
fn balance_lines(sim: &Simulation) -> String {
    let e = &sim.energy;
    let mut s = format!(
        "   {:<20} {:>12}\n   {:<20} {:>12}   ({} of {})\n",
        "initial (kin+strain)",
        sig(e.initial, 5),
        "balance error",
        sig(e.balance_error(), 5),
        sig(e.relative_balance_error(), 3),
        e.scale_name()
    );
    if let Some(first) = sim
        .energy_history
        .iter()
        .find(|h| h.energy.balance_is_off())
    {
        s.push_str(&format!(
            "   WARNING: the balance error passed {} % of {} (first at t = {} s); the energy account does not close\n",
            sig(100.0 * Energy::WARNING_THRESHOLD, 2),
            first.energy.scale_name(),
            sig(first.time, 6)
        ));
    }
    s
}

/// A one-line progress bar on stderr: shown after the first second, redrawn 5 times a second.
struct Progress {
    enabled: bool,
    start: Instant,
    last: Instant,
    drawn: bool,
}

impl Progress {
    fn new(enabled: bool) -> Self {
        let now = Instant::now();
        Progress {
            enabled,
            start: now,
            last: now,
            drawn: false,
        }
    }

    fn update(&mut self, frac: f64, steps: u64, t: f64) {
        let now = Instant::now();
        let elapsed = now.duration_since(self.start).as_secs_f64();
        if elapsed < 1.0 || now.duration_since(self.last).as_secs_f64() < 0.2 {
            return;
        }
        self.last = now;
        let frac = frac.clamp(0.0, 1.0);
        let width = 30;
        let filled = (frac * width as f64) as usize;
        let rate = steps as f64 / elapsed;
        let eta = if frac > 0.0 {
            format!("ETA {}", fmt_secs(elapsed * (1.0 - frac) / frac))
        } else {
            String::from("ETA ?")
        };
        let bar = format!("{}{}", "█".repeat(filled), "░".repeat(width - filled));
        eprint!(
            "\r{bar} {:>5.1} %  step {steps}  t = {} s  {:.0} steps/s  {eta}   ",
            100.0 * frac,
            sig(t, 4),
            rate
        );
        let _ = std::io::stderr().flush();
        self.drawn = true;
    }

    fn finish(&mut self) {
        if self.drawn {
            eprint!("\r{}\r", " ".repeat(100));
            let _ = std::io::stderr().flush();
        }
    }
}

fn fmt_secs(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.0} s")
    } else if s < 3600.0 {
        format!("{}m{:02.0}s", (s / 60.0) as u64, s % 60.0)
    } else {
        format!(
            "{}h{:02}m",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        )
    }
}
