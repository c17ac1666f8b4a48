//! Script bindings of the section "Hooks, monitors and output": periodic callbacks, monitored
//! quantities (written as CSV by `runner.rs`) and ParaView frames.

use super::api::keys_of;
use super::opts::{err, num, Opts, RhaiResult};
use super::postprocess as pp;
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
            let unit = o.string("unit")?;
            if let Some(u) = &unit {
                crate::io::check_unit(u).map_err(|e| o.error(e))?;
            }
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
                unit,
                every,
                f,
                times: Vec::new(),
                steps: Vec::new(),
                values: Vec::new(),
                path,
                csv: None,
                // Replaying up to a restart's checkpoint: nothing written.
                dry: st.dry || st.restore_pending,
            })));
            st.monitors.push(h.clone());
            Ok(h)
        },
    );
    engine.register_fn("last", |m: &mut MonitorHandle| {
        m.0.borrow().values.last().copied().unwrap_or(0.0)
    });
    register_post_processing(engine);
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

/// The monitor's history through `postprocess`: extremes and their times, value at a time,
/// crossings and straight-line fits. Empty histories give 0 for the extremes (as `last()`)
/// and errors where a time is asked for.
fn register_post_processing(engine: &mut Engine) {
    type Pick = fn(&[f64]) -> Option<usize>;
    // Extremes: the value (0 for an empty monitor).
    let extremes: [(&str, Pick, bool); 4] = [
        ("peak", pp::argmax, false),
        ("max", pp::argmax, false),
        ("min", pp::argmin, false),
        ("peak_abs", pp::argmax_abs, true),
    ];
    for (name, pick, abs) in extremes {
        engine.register_fn(name, move |m: &mut MonitorHandle| -> Real {
            let d = m.0.borrow();
            match pick(&d.values) {
                Some(i) if abs => d.values[i].abs(),
                Some(i) => d.values[i],
                None => 0.0,
            }
        });
    }
    // When they happen [s].
    let times: [(&str, Pick); 3] = [
        ("argmax", pp::argmax),
        ("argmin", pp::argmin),
        ("argmax_abs", pp::argmax_abs),
    ];
    for (name, pick) in times {
        engine.register_fn(name, move |m: &mut MonitorHandle| -> RhaiResult<Real> {
            let d = m.0.borrow();
            match pick(&d.values) {
                Some(i) => Ok(d.times[i]),
                None => err(format!(
                    "{name}(): monitor '{}' has no finite value recorded yet",
                    d.name
                )),
            }
        });
    }
    engine.register_fn(
        "at",
        |m: &mut MonitorHandle, t: Dynamic| -> RhaiResult<Real> {
            let t = num(&t, "at()")?;
            let d = m.0.borrow();
            pp::value_at(&d.times, &d.values, t)
                .map_err(|e| format!("at(): monitor '{}': {e}", d.name).into())
        },
    );
    let crossing =
        |m: &mut MonitorHandle, level: Dynamic, dir: &str| -> RhaiResult<Dynamic> {
            let level = num(&level, "first_crossing()")?;
            let dir = pp::Direction::parse(dir).map_err(|e| format!("first_crossing(): {e}"))?;
            let d = m.0.borrow();
            Ok(pp::first_crossing(&d.times, &d.values, level, dir)
                .map_or(Dynamic::UNIT, Dynamic::from))
        };
    engine.register_fn(
        "first_crossing",
        move |m: &mut MonitorHandle, level: Dynamic| crossing(m, level, "any"),
    );
    engine.register_fn("first_crossing", crossing);
    engine.register_fn(
        "fit",
        |m: &mut MonitorHandle, t0: Dynamic, t1: Dynamic| -> RhaiResult<Map> {
            let f = fit(m, t0, t1, "fit()")?;
            let mut out = Map::new();
            out.insert("slope".into(), f.slope.into());
            out.insert("intercept".into(), f.intercept.into());
            out.insert("r2".into(), f.r2.into());
            out.insert("n".into(), (f.n as i64).into());
            Ok(out)
        },
    );
    engine.register_fn(
        "slope",
        |m: &mut MonitorHandle, t0: Dynamic, t1: Dynamic| -> RhaiResult<Real> {
            Ok(fit(m, t0, t1, "slope()")?.slope)
        },
    );
}

fn fit(m: &MonitorHandle, t0: Dynamic, t1: Dynamic, what: &str) -> RhaiResult<pp::LineFit> {
    let (t0, t1) = (num(&t0, what)?, num(&t1, what)?);
    let d = m.0.borrow();
    pp::fit_line(&d.times, &d.values, t0, t1)
        .map_err(|e| format!("{what}: monitor '{}': {e}", d.name).into())
}
