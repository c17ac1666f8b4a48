//! Script bindings of stages 2–3: joint laws, joint insertion, break events, fragments.

use super::api::keys_of;
use super::opts::{err, vec3_to_array, Opts, RhaiResult};
use super::types::{BodyHandle, JointLawValue, SimHandle};
use super::ScriptContext;
use crate::joints::law::{given_penalties, Calibration, Cohesive, RateEffects, Softening};
use crate::joints::JointLaw;
use crate::math::Real;
use rhai::{Array, Dynamic, Engine, FnPtr, Map};
use std::rc::Rc;

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<JointLawValue>("JointLaw");
    engine.register_fn("to_string", |l: &mut JointLawValue| {
        format!("JointLaw({})", l.name)
    });
    engine.register_fn("insert_joints", |s: &mut SimHandle, m: Map| -> RhaiResult<i64> {
        let o = Opts::new("insert_joints", m, keys_of("sim.insert_joints"))?;
        let law = o.typed::<JointLawValue>("law", "a joint_law(..)")?.map_or_else(|| err("insert_joints(): missing required key 'law'"), Ok)?;
        let bodies_of = |key: &str| -> RhaiResult<Option<Vec<BodyHandle>>> {
            let Some(d) = o.get(key) else { return Ok(None) };
            if let Some(b) = d.clone().try_cast::<BodyHandle>() {
                return Ok(Some(vec![b]));
            }
            let Some(a) = d.clone().try_cast::<Array>() else {
                return err(format!("insert_joints(): '{key}' must be a body or an array of bodies, got {}", d.type_name()));
            };
            a.into_iter()
                .map(|x| x.try_cast::<BodyHandle>().ok_or_else(|| format!("insert_joints(): '{key}' must hold bodies").into()))
                .collect::<RhaiResult<Vec<_>>>()
                .map(Some)
        };
        let (within, between) = (bodies_of("within")?, bodies_of("between")?);
        for b in within.iter().chain(&between).flatten() {
            s.body_of(b, "insert_joints()")?;
        }
        if within.is_some() == between.is_some() {
            return err("insert_joints(): give exactly one of 'within' (internal faces of jointed bodies) or 'between' (coincident faces of different bodies)");
        }
        let region = o.typed::<super::types::Shape>("region", "a shape")?;
        let mut st = s.0.borrow_mut();
        if st.sim.step > 0 {
            return err("insert_joints(): joints must be inserted before the first step");
        }
        let tol = st.sim.length_tolerance();
        // Penalties default to 10 × the Young's modulus of the (softest) body involved.
        let resolve = |young: f64| {
            let (pn, pt) = crate::joints::law::penalties_or_default(law.penalties, young);
            match (&law.cohesive, &law.script) {
                (Some(c), _) => {
                    let rate = match c.rate {
                        RateEffects::Fib2010 { .. } => RateEffects::Fib2010 { young },
                        r => r,
                    };
                    JointLaw::Cohesive(Cohesive { normal_penalty: pn, tangential_penalty: pt, rate, ..c.clone() })
                }
                (None, Some(l)) => JointLaw::Script { law: l.clone(), normal_penalty: pn, tangential_penalty: pt },
                (None, None) => JointLaw::Tied { normal_penalty: pn, tangential_penalty: pt },
            }
        };
        let mut total = 0;
        if let Some(bodies) = within {
            for b in bodies {
                let body = st.sim.bodies[b.id].clone();
                let young = st.sim.materials[body.material as usize].young;
                let id = st.sim.joints.add_law(resolve(young));
                let (tets, x0) = (st.sim.tets.nodes.clone(), st.sim.nodes.x0.clone());
                total += st
                    .sim
                    .joints
                    .insert_in_body(&body, &tets, &x0, id, |c| region.as_ref().is_none_or(|r| r.0.contains(c, tol)))
                    .map_err(|e| format!("insert_joints(): {e}"))?;
            }
        } else if let Some(bodies) = between {
            if region.is_some() {
                return err("insert_joints(): 'region' applies to 'within'");
            }
            let gap = o.positive("gap_tolerance")?.unwrap_or(tol);
            let list: Vec<crate::state::Body> = bodies.iter().map(|b| st.sim.bodies[b.id].clone()).collect();
            if let Some(b) = list.iter().find(|b| b.layout == crate::state::Layout::Rigid) {
                return err(format!("insert_joints(): body '{}' is rigid: it cannot be glued by joints (they need faces that move apart); let contact hold it, or make it \"continuous\"", b.name));
            }
            let young = list.iter().map(|b| st.sim.materials[b.material as usize].young).fold(f64::INFINITY, f64::min);
            let id = st.sim.joints.add_law(resolve(young));
            let x0 = st.sim.nodes.x0.clone();
            let refs: Vec<&crate::state::Body> = list.iter().collect();
            total = st.sim.joints.insert_between(&refs, &x0, id, gap);
            if total == 0 {
                return err(format!("insert_joints(): no coincident faces between the bodies within gap_tolerance = {gap:e} m (faces must match vertex for vertex)"));
            }
        }
        st.sim.invalidate();
        Ok(total as i64)
    });

    engine.register_fn("on_joint_broken", |s: &mut SimHandle, f: FnPtr| {
        s.0.borrow_mut().on_joint_broken = Some(f);
    });
    engine.register_get("n_joints", |s: &mut SimHandle| {
        s.0.borrow().sim.joints.len() as i64
    });
    engine.register_fn("broken_joints", |s: &mut SimHandle| {
        s.0.borrow().sim.break_events.len() as i64
    });
    engine.register_fn("damaged_joints", damaged_joints);
    engine.register_fn("fragments", |s: &mut SimHandle| -> RhaiResult<Map> {
        let mut st = s.0.borrow_mut();
        st.sim.prepare().map_err(|e| e.to_string())?;
        let sim = &st.sim;
        let (_, vol, mass) = crate::fracture::fragment_sizes(
            &sim.tets,
            &sim.materials,
            &sim.joints,
            sim.nodes.len(),
        );
        let count = vol.len();
        let mut m = Map::new();
        m.insert("count".into(), (count as i64).into());
        m.insert(
            "volumes".into(),
            Dynamic::from_array(vol.into_iter().map(Dynamic::from).collect()),
        );
        m.insert(
            "masses".into(),
            Dynamic::from_array(mass.into_iter().map(Dynamic::from).collect()),
        );
        Ok(m)
    });
}

/// `joint_law("script", #{ function, params, source })`: compile a Rhai function to a law.
fn script_law(ctx: &ScriptContext, o: &Opts) -> RhaiResult<JointLawValue> {
    let function = o.string("function")?.map_or_else(
        || err("joint_law(\"script\"): missing required key 'function'"),
        Ok,
    )?;
    let params = o
        .typed::<Map>("params", "a map of numbers")?
        .unwrap_or_default();
    let law = compile_from(ctx, o, &function, &params, crate::joints::JOINT_LAW)
        .map_err(|e| format!("joint_law(\"script\"): {e}"))?;
    Ok(JointLawValue {
        name: format!("script:{function}"),
        cohesive: None,
        script: Some(std::sync::Arc::new(law)),
        penalties: penalties(o)?,
    })
}

/// The penalties a joint law was given (None: the default, resolved per body).
fn penalties(o: &Opts) -> RhaiResult<(Option<Real>, Option<Real>)> {
    given_penalties(&|p| o.given(p)).map_err(|e| o.error(e))
}

/// `joint_law(kind, #{ … })`: the keys are the law's own ([`crate::joints::law::JOINT_LAWS`]).
fn joint_law(ctx: &ScriptContext, kind: &str, m: Map) -> RhaiResult<JointLawValue> {
    let o = Opts::for_law("joint_law", "joint_law", kind, m)?;
    let softening = match kind {
        "cohesive/munjiza" => Softening::Munjiza,
        "cohesive/linear" => Softening::Linear,
        "script" => return script_law(ctx, &o),
        _ => {
            return Ok(JointLawValue {
                name: "tied".into(),
                cohesive: None,
                script: None,
                penalties: penalties(&o)?,
            })
        }
    };
    let calibration = o
        .choice(
            "calibration",
            &[
                ("exact", Calibration::Exact),
                ("y_compatible", Calibration::YCompatible),
            ],
        )?
        .unwrap_or(Calibration::Exact);
    let mut cohesive =
        Cohesive::from_params(softening, calibration, &|p| o.given(p)).map_err(|e| o.error(e))?;
    cohesive.rate = o
        .choice(
            "rate_effects",
            // Young's modulus is the body's, set by insert_joints.
            &[
                ("none", RateEffects::None),
                ("fib2010", RateEffects::Fib2010 { young: Real::NAN }),
            ],
        )?
        .unwrap_or(RateEffects::None);
    Ok(JointLawValue {
        name: kind.into(),
        cohesive: Some(cohesive),
        script: None,
        penalties: penalties(&o)?,
    })
}

/// `joint_law` needs the running script (laws written in it are compiled from its AST).
pub fn register_script_laws(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("joint_law", move |kind: &str, m: Map| {
        joint_law(&c, kind, m)
    });
    engine.register_fn("fracture_criterion", move |s: &mut SimHandle, m: Map| -> RhaiResult<()> {
        let o = Opts::new("fracture_criterion", m, keys_of("sim.fracture_criterion"))?;
        let function = o.string("function")?.map_or_else(|| err("fracture_criterion(): missing required key 'function'"), Ok)?;
        let params = o.typed::<Map>("params", "a map of numbers")?.unwrap_or_default();
        let compiled = compile_from(&ctx, &o, &function, &params, crate::fracture::CRITERION)
            .map_err(|e| format!("fracture_criterion(): {e}"))?;
        let when = match o.string("when")?.as_deref() {
            None | Some("damaged") => {
                if o.has("every") {
                    return err("fracture_criterion(): 'every' applies to when: \"always\"");
                }
                crate::fracture::CriterionWhen::Damaged
            }
            Some("always") => crate::fracture::CriterionWhen::Always { every: o.positive_int("every")?.unwrap_or(1) },
            Some(x) => return err(format!("fracture_criterion(): when \"{x}\" is not \"damaged\" or \"always\"")),
        };
        let mut st = s.0.borrow_mut();
        if st.sim.joints.is_empty() {
            return err("fracture_criterion(): the model has no joints (insert them first with sim.insert_joints(..))");
        }
        st.sim.fracture_criterion = Some(crate::fracture::FractureCriterion::new(std::sync::Arc::new(compiled), when));
        Ok(())
    });
}

/// Compile `function` from the running script or from the stdlib module named by `source`.
pub(super) fn compile_from(
    ctx: &ScriptContext,
    o: &Opts,
    function: &str,
    params: &Map,
    sig: crate::compiled::Signature,
) -> Result<crate::compiled::CompiledLaw, String> {
    match o.string("source").map_err(|e| e.to_string())? {
        None => {
            let ast = ctx.ast.borrow();
            let ast = ast.as_ref().ok_or("no script is running")?;
            crate::compiled::compile_with(ast, function, params, sig)
        }
        Some(src) => {
            let Some((_, text)) = super::STDLIB.iter().find(|(n, _)| *n == src) else {
                let names: Vec<&str> = super::STDLIB.iter().map(|(n, _)| *n).collect();
                return Err(format!(
                    "unknown source '{src}'; available: {}",
                    names.join(", ")
                ));
            };
            let ast = rhai::Engine::new_raw()
                .compile(*text)
                .map_err(|e| format!("{src}: {e}"))?;
            crate::compiled::compile_with(&ast, function, params, sig)
        }
    }
}

/// The map a script's `on_joint_broken` callback receives.
/// `s.damaged_joints()`: joints with D > 0 somewhere (a decomposed model's ranks count
/// their designated joints).
fn damaged_joints(s: &mut SimHandle) -> i64 {
    s.0.borrow_mut().sim.damaged_joints() as i64
}

pub fn event_map(sim: &crate::pipeline::Simulation, e: &crate::fracture::BreakEvent) -> Map {
    let mut m = Map::new();
    m.insert("id".into(), (e.joint as i64).into());
    m.insert("time".into(), e.time.into());
    m.insert(
        "centroid".into(),
        Dynamic::from_array(vec3_to_array(e.centroid)),
    );
    m.insert("mode".into(), e.mode.name().into());
    m.insert(
        "body".into(),
        sim.bodies[e.body as usize].name.clone().into(),
    );
    let tets = sim.joints.tets[e.joint];
    let ids: Array = tets
        .iter()
        .map(|&t| Dynamic::from(sim.tets.body[t as usize] as i64))
        .collect();
    m.insert("bodies".into(), ids.into());
    // Unit normal of face A in the reference configuration, pointing from side A to side B.
    let f = sim.joints.faces[e.joint][0].map(|n| sim.nodes.x0[n as usize]);
    let mut n = (f[1] - f[0]).cross(&(f[2] - f[0]));
    let towards_b =
        sim.reference_centroid(tets[1] as usize) - sim.reference_centroid(tets[0] as usize);
    if n.dot(&towards_b) < 0.0 {
        n = -n;
    }
    m.insert(
        "normal".into(),
        Dynamic::from_array(vec3_to_array(n.normalize())),
    );
    m
}
