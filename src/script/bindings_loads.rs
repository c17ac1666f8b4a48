//! Script bindings of the section "Loads and constraints": gravity, fixed and
//! prescribed-velocity nodes, nodal forces, tractions, initial velocities, and time tables.
//! The model edits are `Simulation::fix`, `prescribe_velocity`, `add_nodal_force`,
//! `add_traction`, `set_velocity`; tables are `loads::TimeFunction` (files: `loads::read_table`).

use super::api::keys_of;
use super::opts::{err, num, to_float, vec3_arg, Opts, RhaiResult};
use super::types::{FaceSet, NodeSet, SimHandle, Table};
use crate::loads::{parse_components, read_table, TimeFunction};
use crate::math::Real;
use rhai::{Array, Dynamic, Engine, Map, NativeCallContext};

pub fn register(engine: &mut Engine) {
    engine.register_fn("gravity", |s: &mut SimHandle, g: Array| -> RhaiResult<()> {
        let mut st = s.0.borrow_mut();
        st.sim.loads.gravity = vec3_arg(&g, "gravity()")?;
        st.sim.loads.gravity_ramp = None;
        Ok(())
    });
    engine.register_fn(
        "gravity",
        |s: &mut SimHandle, g: Array, t: Table| -> RhaiResult<()> {
            let g = vec3_arg(&g, "gravity()")?;
            let mut st = s.0.borrow_mut();
            st.sim.loads.gravity = g * t.0.eval(st.sim.time);
            st.sim.loads.gravity_ramp = Some((g, t.0));
            Ok(())
        },
    );
    engine.register_fn(
        "gravity",
        |s: &mut SimHandle, g: Array, m: Map| -> RhaiResult<()> {
            let g = vec3_arg(&g, "gravity()")?;
            let o = Opts::new("gravity", m, keys_of("sim.gravity"))?;
            let Some(ramp) = o.positive("ramp")? else {
                return err("gravity(): missing required key 'ramp'");
            };
            let mut st = s.0.borrow_mut();
            let start = o.float("start")?.unwrap_or(st.sim.time);
            let table = TimeFunction::table(vec![(start, 0.0), (start + ramp, 1.0)])
                .map_err(|e| format!("gravity(): {e}"))?;
            st.sim.loads.gravity = g * table.eval(st.sim.time);
            st.sim.loads.gravity_ramp = Some((g, table));
            Ok(())
        },
    );
    engine.register_fn("fix", |s: &mut SimHandle, n: NodeSet| -> RhaiResult<()> {
        let ids = s.nodes_of(&n, "fix()")?;
        s.0.borrow_mut().sim.fix(ids, [true; 3]);
        Ok(())
    });
    engine.register_fn(
        "fix",
        |s: &mut SimHandle, n: NodeSet, c: &str| -> RhaiResult<()> {
            let components = parse_components(c).map_err(|e| format!("fix(): {e}"))?;
            let ids = s.nodes_of(&n, "fix()")?;
            s.0.borrow_mut().sim.fix(ids, components);
            Ok(())
        },
    );
    engine.register_fn("prescribe_velocity", prescribe_array);
    engine.register_fn("prescribe_velocity", prescribe_map);
    engine.register_fn("nodal_force", |s: &mut SimHandle, n: NodeSet, f: Array| {
        nodal_force(s, n, f, TimeFunction::Constant(1.0))
    });
    engine.register_fn(
        "nodal_force",
        |s: &mut SimHandle, n: NodeSet, f: Array, t: Table| nodal_force(s, n, f, t.0),
    );
    engine.register_fn("traction", |s: &mut SimHandle, f: FaceSet, t: Array| {
        traction(s, f, t, TimeFunction::Constant(1.0))
    });
    engine.register_fn(
        "traction",
        |s: &mut SimHandle, f: FaceSet, t: Array, tab: Table| traction(s, f, t, tab.0),
    );
    engine.register_fn(
        "initial_velocity",
        |s: &mut SimHandle, n: NodeSet, v: Array| -> RhaiResult<()> {
            let v = vec3_arg(&v, "initial_velocity()")?;
            let ids = s.nodes_of(&n, "initial_velocity()")?;
            s.0.borrow_mut()
                .sim
                .set_velocity(ids, v)
                .map_err(|e| format!("initial_velocity(): {e}").into())
        },
    );
    register_tables(engine);
}

/// `table(..)`, `read_table(..)` and `table.at(t)`.
fn register_tables(engine: &mut Engine) {
    engine.register_fn("table", |points: Array| -> RhaiResult<Table> {
        let mut pts = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let pair: Option<(Real, Real)> =
                p.read_lock::<Array>().and_then(|a| match a.as_slice() {
                    [t, v] => Some((to_float(t)?, to_float(v)?))
                        .filter(|(t, v)| t.is_finite() && v.is_finite()),
                    _ => None,
                });
            pts.push(pair.map_or_else(
                || {
                    err(format!(
                        "table(): point {i} must be [t, value] with finite numbers, got {p}"
                    ))
                },
                Ok,
            )?);
        }
        Ok(Table(
            TimeFunction::table(pts).map_err(|e| format!("table(): {e}"))?,
        ))
    });
    engine.register_fn("read_table", |nc: NativeCallContext, path: &str| {
        read_table_file(&nc, path, 1.0)
    });
    engine.register_fn(
        "read_table",
        |nc: NativeCallContext, path: &str, scale: Dynamic| -> RhaiResult<Table> {
            read_table_file(&nc, path, num(&scale, "read_table() scale")?)
        },
    );
    // `at`, as for records and monitors: Rhai reserves `eval`, so `table.eval(t)` could not
    // be called from any script.
    engine.register_fn("at", |t: &mut Table, time: Dynamic| -> RhaiResult<Real> {
        Ok(t.0.eval(num(&time, "at()")?))
    });
}

/// A number or a `Table` as a function of time.
pub(super) fn time_fn(d: &Dynamic, what: &str) -> RhaiResult<TimeFunction> {
    if let Some(t) = d.clone().try_cast::<Table>() {
        return Ok(t.0);
    }
    match to_float(d) {
        Some(x) if x.is_finite() => Ok(TimeFunction::Constant(x)),
        Some(x) => err(format!(
            "{what}: expected a finite number or a table, got {x}"
        )),
        None => err(format!(
            "{what}: expected a number or a table, got {} ({d})",
            d.type_name()
        )),
    }
}

/// `sim.prescribe_velocity(nodes, [vx, vy, vz])`.
fn prescribe_array(s: &mut SimHandle, n: NodeSet, v: Array) -> RhaiResult<()> {
    if v.len() != 3 {
        return err("prescribe_velocity(): expected [vx, vy, vz] or a map #{ x: …, z: … }");
    }
    let mut c: [Option<TimeFunction>; 3] = Default::default();
    for k in 0..3 {
        c[k] = Some(time_fn(&v[k], "prescribe_velocity()")?);
    }
    let ids = s.nodes_of(&n, "prescribe_velocity()")?;
    s.0.borrow_mut().sim.prescribe_velocity(ids, c);
    Ok(())
}

/// `sim.prescribe_velocity(nodes, #{ x, y, z })`: only the components given.
fn prescribe_map(s: &mut SimHandle, n: NodeSet, m: Map) -> RhaiResult<()> {
    let o = Opts::new("prescribe_velocity", m, keys_of("sim.prescribe_velocity"))?;
    let mut c: [Option<TimeFunction>; 3] = Default::default();
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        if let Some(d) = o.get(name) {
            c[k] = Some(time_fn(d, "prescribe_velocity()")?);
        }
    }
    if c.iter().all(|c| c.is_none()) {
        return err("prescribe_velocity(): give at least one of x, y, z");
    }
    let ids = s.nodes_of(&n, "prescribe_velocity()")?;
    s.0.borrow_mut().sim.prescribe_velocity(ids, c);
    Ok(())
}

fn nodal_force(s: &mut SimHandle, n: NodeSet, f: Array, scale: TimeFunction) -> RhaiResult<()> {
    let f = vec3_arg(&f, "nodal_force()")?;
    let ids = s.nodes_of(&n, "nodal_force()")?;
    s.0.borrow_mut().sim.add_nodal_force(ids, f, scale);
    Ok(())
}

fn traction(s: &mut SimHandle, faces: FaceSet, t: Array, scale: TimeFunction) -> RhaiResult<()> {
    let t = vec3_arg(&t, "traction()")?;
    let faces = s.faces_of(&faces, "traction()")?;
    s.0.borrow_mut().sim.add_traction(faces, t, scale);
    Ok(())
}

/// `read_table(path [, scale])`: `path` as given, or next to the script.
fn read_table_file(nc: &NativeCallContext, path: &str, scale: Real) -> RhaiResult<Table> {
    let resolved = super::resolve_path(nc, path);
    let f = read_table(&resolved, scale).map_err(|e| format!("read_table(): {e}"))?;
    Ok(Table(f))
}
