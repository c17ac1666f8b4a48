//! Script bindings of the section "Earthquake records": `ground_motion(path, #{ … })` reads a
//! record with `loads::ground_motion::GroundMotion::read` and returns it with its properties
//! (PGA, PGV, Arias, …) and methods (`at`, `velocity_at`, `displacement_at`, `spectrum`).

use super::api::keys_of;
use super::opts::{err, num, to_float, Opts, RhaiResult};
use super::types::Record;
use crate::loads::ground_motion::{units_factor, Format, GroundMotion, ReadOptions};
use crate::math::Real;
use rhai::{Array, Dynamic, Engine, Map, NativeCallContext};
use std::rc::Rc;

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
