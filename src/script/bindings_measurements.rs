//! Script bindings of the measurements of where bodies are and how they move (sections
//! "Bodies and selections" and "Queries"): bounding boxes of meshes and bodies, momentum and
//! angular momentum, mass-weighted means over node sets, placing a body against another, and
//! selections in an explicit configuration (`#{ at: "reference" | "current" }`). The numbers
//! come from `pipeline/measurements.rs`.

use super::api::keys_of;
use super::opts::{err, vec3_arg, vec3_to_array, Opts, RhaiResult};
use super::types::{BodyHandle, ElementSet, MeshValue, NodeSet, Shape, SimHandle};
use crate::math::Vec3;
use crate::pipeline::{axis_index, Bounds, Configuration};
use rhai::{Array, Dynamic, Engine, Map};
use std::rc::Rc;

/// `#{ min, max, center, size }` of a box [m].
fn bounds_map(b: Bounds) -> Map {
    let mut m = Map::new();
    m.insert("min".into(), Dynamic::from_array(vec3_to_array(b.min)));
    m.insert("max".into(), Dynamic::from_array(vec3_to_array(b.max)));
    m.insert(
        "center".into(),
        Dynamic::from_array(vec3_to_array(b.center())),
    );
    m.insert("size".into(), Dynamic::from_array(vec3_to_array(b.size())));
    m
}

/// The `at` option of `func` (documented as `doc`), with `default`.
fn configuration(
    func: &'static str,
    doc: &str,
    m: Map,
    default: Configuration,
) -> RhaiResult<Configuration> {
    let o = Opts::new(func, m, keys_of(doc))?;
    match o.string("at")? {
        None => Ok(default),
        Some(s) => Configuration::parse(&s).map_err(|e| format!("{func}(): {e}").into()),
    }
}

pub fn register(engine: &mut Engine) {
    engine.register_fn("bounds", |m: &mut MeshValue| -> RhaiResult<Map> {
        match Bounds::of(&m.0.nodes) {
            Some(b) => Ok(bounds_map(b)),
            None => err("bounds(): the mesh has no nodes"),
        }
    });
    engine.register_fn("bounds", |b: &mut BodyHandle| {
        bounds_map(
            b.sim
                .current_body(b.id)
                .sim
                .body_bounds(b.id, Configuration::Current),
        )
    });
    engine.register_fn("bounds", |b: &mut BodyHandle, m: Map| -> RhaiResult<Map> {
        let at = configuration("bounds", "body.bounds", m, Configuration::Current)?;
        Ok(bounds_map(
            b.sim.current_body(b.id).sim.body_bounds(b.id, at),
        ))
    });
    engine.register_fn("momentum", |b: &mut BodyHandle| {
        vec3_to_array(b.sim.current_body(b.id).sim.body_momentum(b.id))
    });
    engine.register_fn("angular_momentum", |b: &mut BodyHandle| {
        vec3_to_array(
            b.sim
                .current_body(b.id)
                .sim
                .body_angular_momentum(b.id, None),
        )
    });
    engine.register_fn(
        "angular_momentum",
        |b: &mut BodyHandle, p: Array| -> RhaiResult<Array> {
            let p = vec3_arg(&p, "angular_momentum() point")?;
            Ok(vec3_to_array(
                b.sim
                    .current_body(b.id)
                    .sim
                    .body_angular_momentum(b.id, Some(p)),
            ))
        },
    );
    engine.register_fn(
        "place_against",
        |a: &mut BodyHandle, b: BodyHandle, axis: &str| place(a, b, axis, 0.0),
    );
    engine.register_fn(
        "place_against",
        |a: &mut BodyHandle, b: BodyHandle, axis: &str, gap: Dynamic| -> RhaiResult<Array> {
            let gap = super::opts::num(&gap, "place_against() gap")?;
            place(a, b, axis, gap)
        },
    );
    engine.register_fn(
        "mass_position",
        |s: &mut SimHandle, n: NodeSet| -> RhaiResult<Array> {
            mass_mean(s, &n, "mass_position", |sim, n| sim.mass_mean_position(n))
        },
    );
    engine.register_fn(
        "mass_velocity",
        |s: &mut SimHandle, n: NodeSet| -> RhaiResult<Array> {
            mass_mean(s, &n, "mass_velocity", |sim, n| sim.mass_mean_velocity(n))
        },
    );
    engine.register_fn("volume_in_box", volume_in_box);
    register_selections(engine);
}

/// `sim.volume_in_box(bodies, #{ min, max, at })`: the bodies' volume inside a box [m³].
fn volume_in_box(s: &mut SimHandle, bodies: Array, m: Map) -> RhaiResult<f64> {
    let o = Opts::new("volume_in_box", m, keys_of("sim.volume_in_box"))?;
    let (lo, hi) = (o.req_vec3("min")?, o.req_vec3("max")?);
    if (0..3).any(|k| hi[k].partial_cmp(&lo[k]) != Some(std::cmp::Ordering::Greater)) {
        return err("volume_in_box(): 'max' must be above 'min' on every axis");
    }
    let at = match o.string("at")? {
        None => Configuration::Current,
        Some(x) => Configuration::parse(&x).map_err(|e| format!("volume_in_box(): {e}"))?,
    };
    let mut ids = Vec::with_capacity(bodies.len());
    for b in bodies {
        let Some(b) = b.try_cast::<BodyHandle>() else {
            return err("volume_in_box(): the first argument must be an array of bodies");
        };
        s.body_of(&b, "volume_in_box()")?;
        ids.push(b.id);
    }
    Ok(s.current().sim.volume_in_box(&ids, &lo, &hi, at))
}

/// `a.place_against(b, axis [, gap])`: axis "x", "y", "z" (the side where a's centre lies)
/// or "+x", "-y", … (a goes on that side of b).
fn place(a: &mut BodyHandle, b: BodyHandle, axis: &str, gap: f64) -> RhaiResult<Array> {
    let (side, name) = match axis.as_bytes().first() {
        Some(b'+') => (Some(true), &axis[1..]),
        Some(b'-') => (Some(false), &axis[1..]),
        _ => (None, axis),
    };
    let Some(k) = axis_index(name) else {
        return err(format!(
            "place_against(): axis \"{axis}\" is not one of \"x\", \"y\", \"z\", \"+x\", \"-x\", \"+y\", \"-y\", \"+z\", \"-z\""
        ));
    };
    // A body of another simulation is an error naming both simulations.
    a.sim.body_of(&b, "place_against()")?;
    drop(a.sim.current());
    let d: Vec3 = a
        .sim
        .0
        .borrow_mut()
        .sim
        .place_against(a.id, b.id, k, gap, side)
        .map_err(|e| format!("place_against(): {e}"))?;
    Ok(vec3_to_array(d))
}

fn mass_mean(
    s: &mut SimHandle,
    n: &NodeSet,
    what: &str,
    f: impl Fn(&crate::pipeline::Simulation, &[u32]) -> Option<Vec3>,
) -> RhaiResult<Array> {
    // A set selected in another simulation is an error naming both (ids into other arrays).
    let ids = s.nodes_of(n, &format!("{what}()"))?;
    s.0.borrow_mut()
        .sim
        .prepare()
        .map_err(|e| format!("{what}(): {e}"))?;
    match f(&s.current_nodes(ids).sim, ids) {
        Some(v) => Ok(vec3_to_array(v)),
        None => err(format!("{what}(): the node set is empty")),
    }
}

/// `body.nodes(shape, #{ at })`, `body.elements(shape, #{ at })`, `sim.nodes(shape, #{ at })`.
fn register_selections(engine: &mut Engine) {
    engine.register_fn(
        "nodes",
        |b: &mut BodyHandle, r: Shape, m: Map| -> RhaiResult<NodeSet> {
            let at = configuration("nodes", "body.nodes", m, Configuration::Reference)?;
            let st = b.sim.current();
            let ids = st.sim.nodes_in_at(&r.0, Some(b.id), at);
            Ok(NodeSet(Rc::new(ids), st.owner.clone()))
        },
    );
    engine.register_fn(
        "nodes",
        |s: &mut SimHandle, r: Shape, m: Map| -> RhaiResult<NodeSet> {
            let at = configuration("nodes", "sim.nodes", m, Configuration::Reference)?;
            let st = s.current();
            let ids = st.sim.nodes_in_at(&r.0, None, at);
            Ok(NodeSet(Rc::new(ids), st.owner.clone()))
        },
    );
    engine.register_fn(
        "elements",
        |b: &mut BodyHandle, r: Shape, m: Map| -> RhaiResult<ElementSet> {
            let at = configuration("elements", "body.elements", m, Configuration::Reference)?;
            let st = b.sim.current();
            let ids = st.sim.tets_in_at(&r.0, Some(b.id), at);
            Ok(ElementSet(Rc::new(ids), st.owner.clone()))
        },
    );
}
