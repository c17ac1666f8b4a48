//! Script bindings of body motion (section "Bodies and selections"): initial velocity and
//! spin, fixing and prescribing a body's motion, and the rigid bodies' state and forces. The
//! core is `Simulation::set_body_velocity`, `set_body_spin`, `fix_body`,
//! `prescribe_body_velocity`, `center_of_mass`, `body_velocity` and `rigid_body`
//! (`pipeline/rigid.rs`, dynamics in `integration/rigid.rs`).

use super::api::keys_of;
use super::bindings_loads::time_fn;
use super::opts::{err, vec3_arg, vec3_to_array, Opts, RhaiResult};
use super::types::BodyHandle;
use crate::integration::rigid::RigidBody;
use crate::loads::TimeFunction;
use crate::math::{Mat3, Real};
use rhai::{Array, Dynamic, Engine, Map};

pub fn register(engine: &mut Engine) {
    engine.register_fn(
        "set_velocity",
        |b: &mut BodyHandle, v: Array| -> RhaiResult<()> {
            let v = vec3_arg(&v, "set_velocity()")?;
            // (The body's motion from its nodes' current places.)
            drop(b.sim.current_body(b.id));
            b.sim.0.borrow_mut().sim.set_body_velocity(b.id, v);
            Ok(())
        },
    );
    engine.register_fn("set_spin", |b: &mut BodyHandle, w: Array| spin(b, w, None));
    engine.register_fn(
        "set_spin",
        |b: &mut BodyHandle, w: Array, c: Array| -> RhaiResult<()> {
            let c = vec3_arg(&c, "set_spin() centre")?;
            spin(b, w, Some(c))
        },
    );
    engine.register_fn("fix", |b: &mut BodyHandle| {
        drop(b.sim.current_body(b.id));
        b.sim.0.borrow_mut().sim.fix_body(b.id)
    });
    engine.register_fn("prescribe_velocity", prescribe);
    engine.register_fn("center_of_mass", |b: &mut BodyHandle| {
        vec3_to_array(b.sim.current_body(b.id).sim.center_of_mass(b.id))
    });
    engine.register_fn("velocity", |b: &mut BodyHandle| {
        vec3_to_array(b.sim.current_body(b.id).sim.body_velocity(b.id))
    });
    register_rigid_queries(engine);
}

/// Queries of a rigid body's state; each an error naming the body when it is not rigid.
fn register_rigid_queries(engine: &mut Engine) {
    type Get = fn(&RigidBody) -> Array;
    let queries: [(&str, Get); 7] = [
        ("angular_velocity", |r| vec3_to_array(r.angular_velocity())),
        ("force", |r| vec3_to_array(r.force)),
        ("torque", |r| vec3_to_array(r.torque)),
        ("reaction", |r| vec3_to_array(r.reaction)),
        ("reaction_torque", |r| vec3_to_array(r.reaction_torque)),
        ("acceleration", |r| vec3_to_array(r.acceleration)),
        ("mass_acceleration", |r| {
            vec3_to_array(r.acceleration * r.mass)
        }),
    ];
    for (name, get) in queries {
        engine.register_fn(name, move |b: &mut BodyHandle| -> RhaiResult<Array> {
            let st = b.sim.0.borrow();
            let rb = st
                .sim
                .rigid_body(b.id)
                .map_err(|e| format!("{name}(): {e}"))?;
            Ok(get(rb))
        });
    }
    engine.register_fn("inertia", |b: &mut BodyHandle| -> RhaiResult<Array> {
        let st = b.sim.0.borrow();
        let rb = st
            .sim
            .rigid_body(b.id)
            .map_err(|e| format!("inertia(): {e}"))?;
        Ok(matrix(&rb.inertia()))
    });
}

fn matrix(m: &Mat3) -> Array {
    (0..3)
        .map(|i| {
            let row: Array = (0..3).map(|j| Dynamic::from(m[(i, j)] as Real)).collect();
            Dynamic::from_array(row)
        })
        .collect()
}

fn spin(b: &mut BodyHandle, w: Array, centre: Option<crate::math::Vec3>) -> RhaiResult<()> {
    let w = vec3_arg(&w, "set_spin()")?;
    drop(b.sim.current_body(b.id));
    b.sim.0.borrow_mut().sim.set_body_spin(b.id, w, centre);
    Ok(())
}

/// `body.prescribe_velocity(#{ x, y, z, rotation })` on a rigid body.
fn prescribe(b: &mut BodyHandle, m: Map) -> RhaiResult<()> {
    let o = Opts::new("prescribe_velocity", m, keys_of("body.prescribe_velocity"))?;
    let mut c: [Option<TimeFunction>; 3] = Default::default();
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        if let Some(d) = o.get(name) {
            c[k] = Some(time_fn(d, "prescribe_velocity()")?);
        }
    }
    let rotation = o.choice("rotation", &[("fixed", true), ("free", false)])?;
    if c.iter().all(|c| c.is_none()) && rotation.is_none() {
        return err("prescribe_velocity(): give at least one of x, y, z, rotation");
    }
    drop(b.sim.current_body(b.id));
    b.sim
        .0
        .borrow_mut()
        .sim
        .prescribe_body_velocity(b.id, c, rotation)
        .map_err(|e| format!("prescribe_velocity(): {e}").into())
}
