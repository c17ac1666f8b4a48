//! Script bindings of stages 4–5: contact laws, detection options, contact queries and the
//! new-contact-pair event.

use super::api::keys_of;
use super::opts::{err, vec3_to_array, Opts, RhaiResult};
use super::types::{BodyHandle, MaterialValue, SimHandle};
use super::ScriptContext;
use crate::contact_interaction::{ContactLaw, ContactRule, PotentialContact, FRICTION_LAW};
use crate::math::Vec3;
use rhai::{Array, Dynamic, Engine, FnPtr, Map};
use std::rc::Rc;

/// `friction_law: #{ function, params, source }` of `contact_law`: compile the function.
fn friction_law(
    ctx: &ScriptContext,
    d: &Dynamic,
) -> RhaiResult<std::sync::Arc<crate::compiled::CompiledLaw>> {
    let Some(m) = d.clone().try_cast::<Map>() else {
        return err(format!(
            "contact_law(): 'friction_law' must be a map #{{ function, params, source }}, got {}",
            d.type_name()
        ));
    };
    let o = Opts::nested("contact_law", "friction_law", m, keys_of("friction_law"))?;
    let function = o.string("function")?.map_or_else(
        || err("contact_law(): friction_law: missing required key 'function'"),
        Ok,
    )?;
    let params = o
        .typed::<Map>("params", "a map of numbers")?
        .unwrap_or_default();
    let law = super::bindings_joints::compile_from(ctx, &o, &function, &params, FRICTION_LAW)
        .map_err(|e| format!("contact_law(): {e}"))?;
    Ok(std::sync::Arc::new(law))
}

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    engine.register_fn(
        "contact_law",
        move |s: &mut SimHandle, law: &str, m: Map| -> RhaiResult<()> {
            let o = Opts::for_law("contact_law", "sim.contact_law", law, m)?;
            let compiled = match o.get("friction_law") {
                None => None,
                Some(d) => Some(friction_law(&ctx, d)?),
            };
            let potential = PotentialContact::from_params(&|p| o.given(p), compiled)
                .map_err(|e| o.error(e))?;
            let mut st = s.0.borrow_mut();
            if st.sim.step > 0 {
                return err("contact_law(): contact must be set before the first step");
            }
            let materials = match o.get("between") {
                None => None,
                Some(d) => {
                    let Some(a) = d.clone().try_cast::<Array>() else {
                        return err("contact_law(): 'between' must be [material_a, material_b]");
                    };
                    if a.len() != 2 {
                        return err(format!(
                            "contact_law(): 'between' must hold 2 materials, got {}",
                            a.len()
                        ));
                    }
                    let mut ids = [0u32; 2];
                    for (k, x) in a.into_iter().enumerate() {
                        let Some(mv) = x.clone().try_cast::<MaterialValue>() else {
                            return err(format!(
                                "contact_law(): 'between' must hold materials from material(..), got {}",
                                x.type_name()
                            ));
                        };
                        ids[k] = match st.material_ids.get(&mv.uid) {
                            Some(&id) => id,
                            None => {
                                let id = st.sim.add_material(mv.material.clone());
                                st.material_ids.insert(mv.uid, id);
                                id
                            }
                        };
                    }
                    Some((ids[0], ids[1]))
                }
            };
            st.sim.contact.laws.rules.push(ContactRule {
                materials,
                law: ContactLaw::Potential(potential),
            });
            st.sim.invalidate();
            Ok(())
        },
    );
    engine.register_fn(
        "contact_detection",
        |s: &mut SimHandle, m: Map| -> RhaiResult<()> {
            let o = Opts::new("contact_detection", m, keys_of("sim.contact_detection"))?;
            let mut st = s.0.borrow_mut();
            if let Some(skin) = o.positive("skin")? {
                st.sim.contact_detection.skin = Some(skin);
            }
            st.sim.invalidate();
            Ok(())
        },
    );
    engine.register_fn("on_new_contact_pair", |s: &mut SimHandle, f: FnPtr| {
        let mut st = s.0.borrow_mut();
        st.on_new_contact_pair = Some(f);
        st.sim.contact.record_events = true;
    });
    engine.register_fn("contact", |s: &mut SimHandle| -> Map {
        let st = s.0.borrow();
        let (c, cd) = (&st.sim.contact, &st.sim.contact_detection);
        let mut m = Map::new();
        m.insert("pairs".into(), (cd.candidate_pairs() as i64).into());
        m.insert("active".into(), (c.last.active as i64).into());
        m.insert("surface_elements".into(), (cd.surface.len() as i64).into());
        m.insert("normal_force".into(), c.last.normal_force.into());
        m.insert("friction_force".into(), c.last.friction_force.into());
        m.insert("energy".into(), c.last.energy.into());
        m.insert("max_overlap".into(), c.last.max_overlap.into());
        m.insert("max_overlap_ratio".into(), c.last.max_overlap_ratio.into());
        m.insert("max_pressure".into(), c.last.max_pressure.into());
        m.insert("area".into(), c.last.area.into());
        m.insert("detections".into(), (cd.detector.detections as i64).into());
        m.insert(
            "incremental_detections".into(),
            (cd.detector.incremental as i64).into(),
        );
        m
    });
    engine.register_fn(
        "contact_force",
        |s: &mut SimHandle, b: BodyHandle| -> RhaiResult<Array> {
            let id = s.body_of(&b, "contact_force()")?;
            // (A decomposed model: each rank's share of the sum.)
            let f: Vec3 = s.0.borrow_mut().sim.contact_force_on(id);
            Ok(vec3_to_array(f))
        },
    );
}

/// The map a script's `on_new_contact_pair` callback receives.
pub fn event_map(
    sim: &crate::pipeline::Simulation,
    e: &crate::contact_interaction::ContactEvent,
) -> Map {
    let mut m = Map::new();
    m.insert("time".into(), e.time.into());
    m.insert("point".into(), Dynamic::from_array(vec3_to_array(e.point)));
    let bodies: Array = e
        .tets
        .iter()
        .map(|&t| {
            sim.bodies[sim.tets.body[t as usize] as usize]
                .name
                .clone()
                .into()
        })
        .collect();
    m.insert("bodies".into(), bodies.into());
    let tets: Array = e.tets.iter().map(|&t| (t as i64).into()).collect();
    m.insert("elements".into(), tets.into());
    m
}
