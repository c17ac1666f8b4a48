//! Script bindings of plots (section "Hooks, monitors and output"): `sim.plot(#{ … })` draws
//! monitors, `sim.plot_energy(#{ … })` the energy account, as PNG and SVG in the
//! simulation's output directory (drawn by `io::plot`), from what is recorded at the call.

use super::api::keys_of;
use super::opts::{err, Opts, RhaiResult};
use super::types::{MonitorHandle, SimHandle};
use crate::io::plot::{self, Axis, Figure, Format, Panel, Series, Table, Unit};
use rhai::{Array, Dynamic, Engine, Map};
use std::path::PathBuf;

pub fn register(engine: &mut Engine) {
    engine.register_fn("plot", |s: &mut SimHandle, m: Map| -> RhaiResult<Array> {
        plot_monitors(s, m)
    });
    engine.register_fn(
        "plot_energy",
        |s: &mut SimHandle, m: Map| -> RhaiResult<Array> { plot_energy(s, m) },
    );
    engine.register_fn("plot_energy", |s: &mut SimHandle| -> RhaiResult<Array> {
        plot_energy(s, Map::new())
    });
}

/// Format, width and height of a plot's options (defaults: both, `w` × `h`).
fn common(o: &Opts, w: u32, h: u32) -> RhaiResult<(Format, u32, u32)> {
    let format = match o.string("format")? {
        None => Format::Both,
        Some(f) => Format::parse(&f).map_err(|e| o.error(e))?,
    };
    let size = |k: &str, d: u32| -> RhaiResult<u32> {
        Ok(o.int(k)?.map_or(d, |v| v.clamp(0, u32::MAX as i64) as u32))
    };
    let (w, h) = (size("width", w)?, size("height", h)?);
    plot::check_size(w, h).map_err(|e| o.error(e))?;
    Ok((format, w, h))
}

/// The figure written to `<out_dir>/<file>.{png,svg}` unless the run writes nothing
/// (`fdem check`, or a restart replaying up to its checkpoint); the paths written.
fn write(s: &SimHandle, o: &Opts, file: &str, fig: &Figure, format: Format) -> RhaiResult<Array> {
    super::types::check_file_name(&format!("{}()", o.func), "file", file)?;
    let st = s.0.borrow();
    if st.dry || st.restore_pending {
        return Ok(Array::new());
    }
    let stem: PathBuf = st.out_dir.join(file);
    let written = plot::write(fig, &stem, format).map_err(|e| o.error(e))?;
    Ok(written
        .iter()
        .map(|p| Dynamic::from(p.display().to_string()))
        .collect())
}

/// A monitor named by a string or given as the monitor itself.
fn monitor_of(s: &SimHandle, o: &Opts, key: &str, v: &Dynamic) -> RhaiResult<MonitorHandle> {
    if let Some(m) = v.clone().try_cast::<MonitorHandle>() {
        return Ok(m);
    }
    let Ok(name) = v.clone().into_string() else {
        return err(format!(
            "{}: key '{key}' must name monitors (strings or the monitors themselves), got {} ({v})",
            o.at(),
            v.type_name()
        ));
    };
    let st = s.0.borrow();
    let found = st.monitors.iter().find(|m| m.0.borrow().name == name);
    match found {
        Some(m) => Ok(m.clone()),
        None => {
            let names: Vec<String> = st
                .monitors
                .iter()
                .map(|m| format!("\"{}\"", m.0.borrow().name))
                .collect();
            err(format!(
                "{}: {key}: no monitor named \"{name}\"; {}",
                o.at(),
                if names.is_empty() {
                    "this simulation has no monitors yet".to_string()
                } else {
                    format!("its monitors are {}", names.join(", "))
                }
            ))
        }
    }
}

/// `sim.plot(#{ … })`: monitors against time, step or another monitor.
fn plot_monitors(s: &SimHandle, m: Map) -> RhaiResult<Array> {
    let o = Opts::new("plot", m, keys_of("sim.plot"))?;
    let Some(file) = o.string("file")? else {
        return err("plot(): missing required key 'file' (the name of the figure's files)");
    };
    let ys: Vec<Dynamic> = match o.get("y") {
        None => return err("plot(): missing required key 'y' (the monitors to plot)"),
        Some(v) => match v.read_lock::<Array>() {
            Some(a) => a.iter().cloned().collect(),
            None => vec![v.clone()],
        },
    };
    if ys.is_empty() {
        return err("plot(): key 'y' is empty: name at least one monitor");
    }
    let (format, width, height) = common(&o, 1000, 600)?;
    // x: "time", "step" or a monitor.
    enum X {
        Time,
        Step,
        Monitor(MonitorHandle),
    }
    let x = match o.get("x") {
        None => X::Time,
        Some(v) if v.clone().into_string().is_ok_and(|s| s == "time") => X::Time,
        Some(v) if v.clone().into_string().is_ok_and(|s| s == "step") => X::Step,
        Some(v) => X::Monitor(
            monitor_of(s, &o, "x", v).map_err(|e| format!("{e} (or \"time\", \"step\")"))?,
        ),
    };
    let mut series = Vec::new();
    let mut names = Vec::new();
    let mut axes = Vec::new();
    for v in &ys {
        let mh = monitor_of(s, &o, "y", v)?;
        let d = mh.0.borrow();
        let (xv, yv): (Vec<f64>, Vec<f64>) = match &x {
            X::Time => (d.times.clone(), d.values.clone()),
            X::Step => (
                d.steps.iter().map(|&k| k as f64).collect(),
                d.values.clone(),
            ),
            X::Monitor(xm) if std::rc::Rc::ptr_eq(&xm.0, &mh.0) => {
                (d.values.clone(), d.values.clone())
            }
            X::Monitor(xm) => {
                // Samples recorded at the same step (the last one of a step counts).
                let xd = xm.0.borrow();
                let by_step: std::collections::BTreeMap<u64, f64> = xd
                    .steps
                    .iter()
                    .copied()
                    .zip(xd.values.iter().copied())
                    .collect();
                d.steps
                    .iter()
                    .zip(&d.values)
                    .filter_map(|(k, &y)| by_step.get(k).map(|&x| (x, y)))
                    .unzip()
            }
        };
        if xv.is_empty() {
            let why = match &x {
                X::Monitor(xm) => format!(
                    "monitors \"{}\" and \"{}\" have no sample at the same step (give them the same `every`), or nothing is recorded yet",
                    xm.0.borrow().name,
                    d.name
                ),
                _ => format!("monitor \"{}\" has recorded nothing yet (plot after a run)", d.name),
            };
            return err(format!("plot(): {why}"));
        }
        names.push(d.name.clone());
        axes.push(plot::column_axis("", &d.name, d.unit.as_deref()));
        series.push(Series {
            label: d.name.clone(),
            x: xv,
            y: yv,
        });
    }
    let (x_name, x_unit) = match &x {
        X::Time => ("time".to_string(), None),
        X::Step => ("step".to_string(), None),
        X::Monitor(m) => {
            let d = m.0.borrow();
            (d.name.clone(), d.unit.clone())
        }
    };
    let x_axis = match o.string("x_label")? {
        Some(l) => Axis::new(&l, Unit::Given),
        None => plot::column_axis("", &x_name, x_unit.as_deref()),
    };
    let y_axis = match o.string("y_label")? {
        Some(l) => Axis::new(&l, Unit::Given),
        None if names.len() == 1 => axes[0].clone(),
        None => plot::shared_axis(&names.join(", "), &axes),
    };
    for (s, a) in series.iter_mut().zip(&axes) {
        s.label = plot::legend_label(a, &y_axis);
    }
    let fig = Figure {
        title: o
            .string("title")?
            .unwrap_or_else(|| format!("{} against {x_name}", names.join(", "))),
        x: x_axis,
        panels: vec![Panel { y: y_axis, series }],
        width,
        height,
    };
    write(s, &o, &file, &fig, format)
}

/// `sim.plot_energy(#{ … })`: the energy account so far, as `fdem plot` draws energy.csv.
fn plot_energy(s: &SimHandle, m: Map) -> RhaiResult<Array> {
    let o = Opts::new("plot_energy", m, keys_of("sim.plot_energy"))?;
    let file = o.string("file")?.unwrap_or_else(|| "energy".to_string());
    let (format, width, height) = common(&o, 1000, 800)?;
    let table = {
        let st = s.0.borrow();
        Table {
            path: PathBuf::from("energy.csv"),
            columns: super::runner::ENERGY_HEADER
                .iter()
                .map(|c| c.to_string())
                .collect(),
            units: vec![None; super::runner::ENERGY_HEADER.len()],
            rows: st
                .sim
                .energy_history
                .iter()
                .map(|e| super::runner::energy_row(e).to_vec())
                .collect(),
        }
    };
    let Some(mut fig) = plot::energy_figure(&table, width, height) else {
        return err("plot_energy(): the energy account has no sample yet (plot after a run)");
    };
    if let Some(t) = o.string("title")? {
        fig.title = t;
    }
    write(s, &o, &file, &fig, format)
}
