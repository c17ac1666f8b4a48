//! Script bindings of the section "Earthquake records": `ground_motion(path, #{ … })` reads a
//! record with `loads::ground_motion::GroundMotion::read` and returns it with its properties
//! (PGA, PGV, Arias, …) and methods (`at`, `velocity_at`, `displacement_at`, `spectrum`);
//! `sim.shake_base(nodes, #{ x, y, z })` and `sim.shake_relative(#{ x, y, z })` shake a model
//! with records (`Simulation::shake`), and `s.ground()` reports the ground's motion.

use super::api::keys_of;
use super::opts::vec3_to_array;
use super::opts::{err, num, to_float, Opts, RhaiResult};
use super::types::{NodeSet, Record, SimHandle};
use crate::loads::ground_motion::{units_factor, Format, GroundMotion, ReadOptions};
use crate::loads::{GroundRecord, ShakingKind};
use crate::math::Real;
use rhai::{Array, Dynamic, Engine, Map, NativeCallContext};
use std::rc::Rc;
use std::sync::Arc;

/// A numeric property of a record.
type Property = fn(&GroundMotion) -> Real;

pub fn register(engine: &mut Engine) {
    engine.register_fn("ground_motion", |nc: NativeCallContext, path: &str| {
        read(&nc, path, Map::new())
    });
    engine.register_fn(
        "ground_motion",
        |nc: NativeCallContext, path: &str, m: Map| read(&nc, path, m),
    );
    let props: [(&str, Property); 8] = [
        ("dt", |g| g.dt),
        ("duration", |g| g.duration()),
        ("pga", |g| g.pga().value),
        ("pga_time", |g| g.pga().time),
        ("pgv", |g| g.pgv().value),
        ("pgd", |g| g.pgd().value),
        ("arias", |g| g.arias()),
        ("significant_duration", |g| g.significant_duration()),
    ];
    for (name, f) in props {
        engine.register_get(name, move |r: &mut Record| f(&r.0 .0));
    }
    engine.register_fn("at", |r: &mut Record, t: Dynamic| -> RhaiResult<Real> {
        Ok(r.0 .0.at(num(&t, "at()")?))
    });
    engine.register_fn(
        "velocity_at",
        |r: &mut Record, t: Dynamic| -> RhaiResult<Real> {
            Ok(r.0 .1.velocity_at(num(&t, "velocity_at()")?))
        },
    );
    engine.register_fn(
        "displacement_at",
        |r: &mut Record, t: Dynamic| -> RhaiResult<Real> {
            Ok(r.0 .1.displacement_at(num(&t, "displacement_at()")?))
        },
    );
    engine.register_fn("spectrum", spectrum);
    engine.register_fn(
        "shake_base",
        |s: &mut SimHandle, n: NodeSet, m: Map| -> RhaiResult<()> {
            let ids = s.nodes_of(&n, "shake_base()")?.to_vec();
            shake(s, m, "sim.shake_base", ShakingKind::Base(ids))
        },
    );
    engine.register_fn(
        "shake_relative",
        |s: &mut SimHandle, m: Map| -> RhaiResult<()> {
            shake(s, m, "sim.shake_relative", ShakingKind::Relative)
        },
    );
    engine.register_fn("ground", ground);
}

/// `sim.shake_base(nodes, #{ x, y, z, start })`, `sim.shake_relative(#{ … })`.
fn shake(s: &mut SimHandle, m: Map, name: &'static str, kind: ShakingKind) -> RhaiResult<()> {
    let o = Opts::new(name, m, keys_of(name))?;
    let mut records: [Option<Arc<GroundRecord>>; 3] = Default::default();
    for (k, c) in ["x", "y", "z"].iter().enumerate() {
        records[k] = o
            .typed::<Record>(c, "a record from ground_motion(..)")?
            .map(|r| Arc::new(GroundRecord::new(r.0 .0.clone())));
    }
    let start = o.float("start")?;
    s.0.borrow_mut()
        .sim
        .shake(records, start, kind)
        .map_err(|e| format!("{name}(): {e}").into())
}

/// `s.ground()`: the first shaking's ground motion at the current time.
fn ground(s: &mut SimHandle) -> RhaiResult<Map> {
    let st = s.0.borrow();
    let Some(g) = st.sim.loads.shaking.first() else {
        return err(
            "ground(): the model is not shaken; use sim.shake_base(..) or sim.shake_relative(..)",
        );
    };
    let mut m = Map::new();
    m.insert("acceleration".into(), vec3_to_array(g.acceleration).into());
    m.insert("velocity".into(), vec3_to_array(g.velocity).into());
    m.insert("displacement".into(), vec3_to_array(g.displacement).into());
    m.insert("start".into(), g.start.into());
    m.insert("end".into(), g.end().into());
    Ok(m)
}

/// `record.spectrum(periods, damping)`: Sa [m/s²] per period.
fn spectrum(r: &mut Record, periods: Array, damping: Dynamic) -> RhaiResult<Array> {
    let z = num(&damping, "spectrum() damping")?;
    if !(0.0..1.0).contains(&z) {
        return err(format!(
            "spectrum(): damping must be a ratio in [0, 1), got {z}"
        ));
    }
    let mut ts = Vec::with_capacity(periods.len());
    for (i, p) in periods.iter().enumerate() {
        match to_float(p) {
            Some(t) if t > 0.0 => ts.push(t),
            _ => {
                return err(format!(
                    "spectrum(): period {i} must be a positive number [s], got {p}"
                ))
            }
        }
    }
    r.0 .0
        .check_spectrum_periods(&ts)
        .map_err(|e| format!("spectrum(): {e}"))?;
    Ok(r.0
         .0
        .spectrum(&ts, z)
        .into_iter()
        .map(Dynamic::from)
        .collect())
}

/// `ground_motion(path, #{ … })`: `path` as given, or next to the script.
fn read(nc: &NativeCallContext, path: &str, m: Map) -> RhaiResult<Record> {
    let o = Opts::new("ground_motion", m, keys_of("ground_motion"))?;
    let at = |e: String| format!("ground_motion(): {e}");
    let format = match o.string("format")? {
        Some(f) => Some(Format::parse(&f).map_err(at)?),
        None => None,
    };
    let units = units_factor(&o.string("units")?.unwrap_or_else(|| "g".into())).map_err(at)?;
    let opts = ReadOptions {
        format,
        units,
        dt: o.positive("dt")?,
        scale: o.float("scale")?,
        pga: o.positive("pga")?.map(|p| p * units),
        start: o.float("start")?,
        end: o.float("end")?,
        baseline: o
            .typed::<bool>("baseline", "true or false")?
            .unwrap_or(false),
    };
    let resolved = super::resolve_path(nc, path);
    let gm = GroundMotion::read(&resolved, &opts).map_err(at)?;
    let k = gm.kinematics();
    Ok(Record(Rc::new((gm, k))))
}
