//! Script bindings of the section "Hooks, monitors and output": periodic callbacks, monitored
//! quantities (written as CSV by `runner.rs`) and ParaView frames.

use super::api::keys_of;
use super::opts::{err, Opts, RhaiResult};
use super::runner;
use super::types::{Hook, MonitorData, MonitorHandle, SimHandle};
use crate::math::Real;
use rhai::{Array, Dynamic, Engine, FnPtr, Map};
use std::cell::RefCell;
use std::rc::Rc;

pub fn register(engine: &mut Engine) {
    engine.register_fn(
        "every",
        |s: &mut SimHandle, m: Map, f: FnPtr| -> RhaiResult<()> {
            let o = Opts::new("every", m, keys_of("sim.every"))?;
            let steps = o.positive_int("steps")?;
            let time = o.positive("time")?;
            if steps.is_some() == time.is_some() {
                return err("every(): give exactly one of 'steps' or 'time'");
            }
            let mut st = s.0.borrow_mut();
            // Refused here when the step is known (else at run()): a period shorter than dt.
            if let (Some(t), true) = (time, st.sim.step > 0) {
                if t < st.sim.dt * (1.0 - 1e-9) {
                    return err(format!(
                        "every(): time {t:e} s is shorter than the time step dt = {:e} s: the hook would run on every step; use #{{ steps: 1 }} for that, or a longer time",
                        st.sim.dt
                    ));
                }
            }
            let next_time = time
                .map(|t| ((st.sim.time / t).floor() + 1.0) * t)
                .unwrap_or(0.0);
            st.hooks.push(Hook {
                every_steps: steps,
                every_time: time,
                next_time,
                f,
            });
            Ok(())
        },
    );
    engine.register_fn(
        "monitor",
        |s: &mut SimHandle, name: &str, m: Map, f: FnPtr| -> RhaiResult<MonitorHandle> {
            let o = Opts::new("monitor", m, keys_of("sim.monitor"))?;
            let every = o.positive_int("every")?.unwrap_or(1);
            super::types::check_file_name("monitor()", "name", name)?;
            if ["energy", "cracks"].contains(&name) {
                return err(format!(
                    "monitor(): the name '{name}' is taken by the simulation's own {name}.csv; choose another"
                ));
            }
            let mut st = s.0.borrow_mut();
            if st.monitors.iter().any(|m| m.0.borrow().name == name) {
                return err(format!(
                    "monitor(): a monitor named '{name}' already exists"
                ));
            }
            let path = st.out_dir.join(format!("{name}.csv"));
            if !st.dry && !st.overwrite && path.exists() {
                return err(format!(
                    "monitor(): {} is already there (an earlier run?); nothing is overwritten: run with --overwrite to replace it, or give another --out (or out_dir)",
                    path.display()
                ));
            }
            let h = MonitorHandle(Rc::new(RefCell::new(MonitorData {
                name: name.to_string(),
                every,
                f,
                times: Vec::new(),
                steps: Vec::new(),
                values: Vec::new(),
                path,
                csv: None,
                dry: st.dry,
            })));
            st.monitors.push(h.clone());
            Ok(h)
        },
    );
    engine.register_fn("last", |m: &mut MonitorHandle| {
        m.0.borrow().values.last().copied().unwrap_or(0.0)
    });
    engine.register_fn("peak", |m: &mut MonitorHandle| {
        m.0.borrow().values.iter().copied().fold(0.0_f64, Real::max)
    });
    engine.register_fn("max", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .copied()
            .fold(Real::NEG_INFINITY, Real::max)
    });
    engine.register_fn("min", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .copied()
            .fold(Real::INFINITY, Real::min)
    });
    engine.register_fn("len", |m: &mut MonitorHandle| {
        m.0.borrow().values.len() as i64
    });
    engine.register_fn("values", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .map(|&v| Dynamic::from(v))
            .collect::<Array>()
    });
    engine.register_fn("times", |m: &mut MonitorHandle| {
        m.0.borrow()
            .times
            .iter()
            .map(|&v| Dynamic::from(v))
            .collect::<Array>()
    });
    engine.register_fn("write_csv", |m: &mut MonitorHandle| -> RhaiResult<()> {
        runner::write_monitor(m).map_err(|e| e.into())
    });
    engine.register_fn("write_vtk", |s: &mut SimHandle| -> RhaiResult<()> {
        runner::write_vtk(s)
    });
}
