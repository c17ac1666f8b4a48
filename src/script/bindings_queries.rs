//! Script bindings of the section "Queries": time, sizes, energies, means over node sets,
//! reactions and stresses. The numbers come from `Simulation` (`pipeline/queries.rs`); here
//! they are only converted to Rhai values.

use super::opts::{err, vec3_to_array, RhaiResult};
use super::types::{ElementSet, NodeSet, SimHandle};
use crate::math::{Real, Vec3};
use rhai::{Array, Dynamic, Engine, Map};

pub fn register(engine: &mut Engine) {
    engine.register_get("time", |s: &mut SimHandle| s.0.borrow().sim.time);
    engine.register_get("step", |s: &mut SimHandle| s.0.borrow().sim.step as i64);
    engine.register_get("dt", |s: &mut SimHandle| -> RhaiResult<Real> {
        let mut st = s.0.borrow_mut();
        st.sim.prepare().map_err(|e| e.to_string())?;
        Ok(st.sim.dt)
    });
    engine.register_get("n_nodes", |s: &mut SimHandle| {
        s.0.borrow().sim.nodes.len() as i64
    });
    engine.register_get("n_tets", |s: &mut SimHandle| {
        s.0.borrow().sim.tets.len() as i64
    });
    engine.register_get("name", |s: &mut SimHandle| s.0.borrow().name.clone());
    engine.register_fn("kinetic_energy", |s: &mut SimHandle| -> RhaiResult<Real> {
        s.0.borrow_mut().sim.prepare().map_err(|e| e.to_string())?;
        Ok(s.current().sim.kinetic_energy_now())
    });
    engine.register_fn("strain_energy", |s: &mut SimHandle| {
        s.current().sim.strain_energy_now()
    });
    engine.register_fn("energy", energy);
    engine.register_fn("displacement", |s: &mut SimHandle, n: NodeSet| {
        let ids = s.nodes_of(&n, "displacement()")?;
        node_mean(
            s.current_nodes(ids).sim.mean_displacement(ids),
            "displacement",
        )
    });
    engine.register_fn("position", |s: &mut SimHandle, n: NodeSet| {
        let ids = s.nodes_of(&n, "position()")?;
        node_mean(s.current_nodes(ids).sim.mean_position(ids), "position")
    });
    engine.register_fn("velocity", |s: &mut SimHandle, n: NodeSet| {
        let ids = s.nodes_of(&n, "velocity()")?;
        node_mean(s.current_nodes(ids).sim.mean_velocity(ids), "velocity")
    });
    engine.register_fn(
        "reaction",
        |s: &mut SimHandle, n: NodeSet| -> RhaiResult<Array> {
            let ids = s.nodes_of(&n, "reaction()")?;
            Ok(vec3_to_array(s.current_nodes(ids).sim.reaction_sum(ids)))
        },
    );
    engine.register_fn(
        "mean_stress",
        |s: &mut SimHandle, el: ElementSet| -> RhaiResult<Array> {
            let ids = s.elements_of(&el, "mean_stress()")?;
            let Some(m) = s.current_tets(ids).sim.mean_stress(ids) else {
                return err("mean_stress(): the element set is empty");
            };
            Ok((0..3)
                .map(|i| {
                    Dynamic::from_array(vec![m[(i, 0)].into(), m[(i, 1)].into(), m[(i, 2)].into()])
                })
                .collect())
        },
    );
    engine.register_fn(
        "max_von_mises",
        |s: &mut SimHandle, el: ElementSet| -> RhaiResult<Real> {
            let ids = s.elements_of(&el, "max_von_mises()")?;
            Ok(s.current_tets(ids).sim.max_von_mises(ids))
        },
    );
}

/// A mean over a node set as `[x, y, z]`; None (an empty set) is an error of `what()`.
fn node_mean(mean: Option<Vec3>, what: &str) -> RhaiResult<Array> {
    match mean {
        Some(v) => Ok(vec3_to_array(v)),
        None => err(format!("{what}(): the node set is empty")),
    }
}

/// `s.energy()`: the energy account at the last sample as a map [J].
fn energy(s: &mut SimHandle) -> Map {
    let e = s.0.borrow().sim.energy;
    let mut m = Map::new();
    for (k, v) in [
        ("kinetic", e.kinetic),
        ("strain", e.strain),
        ("external_work", e.external_work()),
        ("gravity_work", e.gravity_work),
        ("force_work", e.force_work),
        ("reaction_work", e.reaction_work),
        ("ground_work", e.ground_work),
        ("damping", e.mass_damping + e.viscous_damping),
        ("joint", e.joint),
        ("fracture", e.fracture),
        ("contact", e.contact),
        ("friction", e.friction),
        ("plastic", e.plastic),
        ("bond", e.bond),
        ("bond_slip", e.bond_slip),
        ("initial", e.initial),
        ("balance_error", e.balance_error()),
        ("relative_error", e.relative_balance_error()),
        ("floor", e.floor),
    ] {
        m.insert(k.into(), v.into());
    }
    m
}
