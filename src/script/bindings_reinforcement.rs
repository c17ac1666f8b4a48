//! Script bindings of the section "Reinforcement": steels, bond laws, rebars laid in a host
//! body, layout helpers (straight bars with cover, closed stirrups) and rebar queries.

use super::api::keys_of;
use super::bindings_joints::compile_from;
use super::opts::{err, to_vec3, vec3_to_array, Opts, RhaiResult};
use super::types::{BodyHandle, NodeSet, Shape, SimHandle};
use super::ScriptContext;
use crate::elements::bar2::steel::{Steel, STEEL_LAW};
use crate::joints::bond::{BondLaw, Envelope, BOND_LAW, SCRIPT_BOND_PARAMS};
use crate::math::{Real, Vec3};
use crate::params::value;
use crate::pipeline::RebarSpec;
use rhai::{Array, Dynamic, Engine, Map};
use std::rc::Rc;

/// A steel from `steel(..)`.
#[derive(Clone, Debug)]
pub struct SteelValue(pub Steel);

/// A bond law from `bond_law(..)`: resolved per rebar (its defaults depend on the bar
/// diameter and the host's stiffness).
#[derive(Clone, Debug)]
pub struct BondLawValue {
    pub kind: String,
    /// fib2010: the options as given (validated).
    pub options: Map,
    /// script: the compiled envelope and its stiffnesses.
    pub script: Option<BondLaw>,
}

/// A rebar in a simulation.
#[derive(Clone)]
pub struct RebarHandle {
    pub sim: SimHandle,
    pub id: usize,
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<SteelValue>("Steel");
    engine.register_type_with_name::<BondLawValue>("BondLaw");
    engine.register_type_with_name::<RebarHandle>("Rebar");
    engine.register_fn("to_string", |s: &mut SteelValue| {
        format!(
            "Steel(f_y = {:e} Pa, H = {:e} Pa)",
            s.0.yield_stress, s.0.hardening
        )
    });
    engine.register_fn("to_string", |b: &mut BondLawValue| {
        format!("BondLaw({})", b.kind)
    });
    engine.register_fn("to_string", |r: &mut RebarHandle| {
        format!("Rebar({})", r.sim.0.borrow().sim.rebars[r.id].name)
    });
    engine.register_fn("steel", |m: Map| -> RhaiResult<SteelValue> {
        let o = Opts::for_law("steel", "steel", "bilinear", m)?;
        Ok(SteelValue(
            Steel::from_params(&|p| o.given(p)).map_err(|e| o.error(e))?,
        ))
    });
    engine.register_fn("rebar", rebar);
    engine.register_fn("straight_bar", straight_bar);
    engine.register_fn("stirrup", stirrup);
    register_queries(engine);
}

/// `steel("script", …)` and `bond_law(..)` need the running script (their laws are compiled
/// from its AST).
pub fn register_script_laws(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn(
        "steel",
        move |kind: &str, m: Map| -> RhaiResult<SteelValue> {
            let o = Opts::for_law("steel", "steel", kind, m)?;
            if kind == "bilinear" {
                return Ok(SteelValue(
                    Steel::from_params(&|p| o.given(p)).map_err(|e| o.error(e))?,
                ));
            }
            let (function, params) = script_function(&o, "steel(\"script\")")?;
            let law = compile_from(&c, &o, &function, &params, STEEL_LAW)
                .map_err(|e| format!("steel(\"script\"): {e}"))?;
            Ok(SteelValue(
                Steel::script(std::sync::Arc::new(law), &|p| o.given(p)).map_err(|e| o.error(e))?,
            ))
        },
    );
    engine.register_fn(
        "bond_law",
        move |kind: &str, m: Map| -> RhaiResult<BondLawValue> {
            let o = Opts::for_law("bond_law", "bond_law", kind, m.clone())?;
            if kind == "fib2010" {
                // Validate now (with a 1 m diameter: only c_clear's default depends on it).
                fib2010(&o, 1.0)?;
                return Ok(BondLawValue {
                    kind: kind.into(),
                    options: m,
                    script: None,
                });
            }
            let (function, params) = script_function(&o, "bond_law(\"script\")")?;
            let law = compile_from(&ctx, &o, &function, &params, BOND_LAW)
                .map_err(|e| format!("bond_law(\"script\"): {e}"))?;
            let given = |p: &crate::params::Param| o.given(p);
            let stiffness = value(SCRIPT_BOND_PARAMS, "stiffness", &given, Real::NAN)
                .map_err(|e| o.error(e))?
                .expect("required");
            let transverse_stiffness = value(
                SCRIPT_BOND_PARAMS,
                "transverse_stiffness",
                &given,
                Real::NAN,
            )
            .map_err(|e| o.error(e))?;
            Ok(BondLawValue {
                kind: kind.into(),
                options: Map::new(),
                script: Some(BondLaw {
                    envelope: Envelope::Script(std::sync::Arc::new(law)),
                    stiffness,
                    transverse_stiffness,
                }),
            })
        },
    );
}

fn script_function(o: &Opts, what: &str) -> RhaiResult<(String, Map)> {
    let function = o.string("function")?.map_or_else(
        || err(format!("{what}: missing required key 'function'")),
        Ok,
    )?;
    let params = o
        .typed::<Map>("params", "a map of numbers")?
        .unwrap_or_default();
    Ok((function, params))
}

/// The fib2010 law of `o` for a bar of diameter `d` [m].
fn fib2010(o: &Opts, d: Real) -> RhaiResult<BondLaw> {
    let confinement = o
        .string("confinement")?
        .unwrap_or_else(|| "confined".into());
    let bond = o.string("bond")?.unwrap_or_else(|| "good".into());
    BondLaw::fib2010(&|p| o.given(p), &confinement, &bond, d).map_err(|e| o.error(e))
}

/// `sim.rebar(host, #{ points, diameter, area, steel, bond, segment, bending, name })`.
fn rebar(s: &mut SimHandle, host: BodyHandle, m: Map) -> RhaiResult<RebarHandle> {
    let o = Opts::new("rebar", m, keys_of("sim.rebar"))?;
    s.body_of(&host, "rebar()")?;
    let diameter = o.req_float("diameter")?;
    let steel = o
        .typed::<SteelValue>("steel", "a steel(..)")?
        .map_or_else(|| err("rebar(): missing required key 'steel'"), Ok)?;
    let bond = o
        .typed::<BondLawValue>("bond", "a bond_law(..)")?
        .map_or_else(|| err("rebar(): missing required key 'bond'"), Ok)?;
    let points: Vec<Vec3> = match o.typed::<Array>("points", "an array of [x, y, z]")? {
        None => return err("rebar(): missing required key 'points'"),
        Some(a) => a
            .iter()
            .enumerate()
            .map(|(k, p)| {
                to_vec3(p).ok_or_else(|| format!("rebar(): points[{k}] is not [x, y, z]").into())
            })
            .collect::<RhaiResult<_>>()?,
    };
    if !Rc::ptr_eq(&s.0, &host.sim.0) {
        return err("rebar(): the host body belongs to another simulation");
    }
    let law = match &bond.script {
        Some(l) => l.clone(),
        None => {
            let bo = Opts::for_law("bond_law", "bond_law", "fib2010", bond.options.clone())?;
            fib2010(&bo, diameter)?
        }
    };
    let mut st = s.0.borrow_mut();
    let name = o
        .string("name")?
        .unwrap_or_else(|| format!("rebar{}", st.sim.rebars.len()));
    let steel_id = st.sim.add_steel(steel.0);
    let bond_id = st.sim.add_bond_law(law);
    let spec = RebarSpec {
        name,
        host: host.id,
        points,
        diameter,
        area: o.float("area")?,
        steel: steel_id,
        bond_law: bond_id,
        segment: o.float("segment")?,
        bending: o.typed::<bool>("bending", "true or false")?.unwrap_or(true),
    };
    let id = st
        .sim
        .add_rebar(&spec)
        .map_err(|e| format!("rebar(): {e}"))?;
    Ok(RebarHandle { sim: s.clone(), id })
}

/// Axis index of "x", "y" or "z".
fn axis_of(o: &Opts) -> RhaiResult<usize> {
    o.choice("axis", &[("x", 0), ("y", 1), ("z", 2)])?
        .map_or_else(
            || err(format!("{}: missing required key 'axis'", o.at())),
            Ok,
        )
}

/// `straight_bar(host, #{ axis, at, cover })`: the end points of a straight bar along `axis`
/// through the section point `at` (the other two coordinates), stopping `cover` short of the
/// host's ends.
fn straight_bar(host: BodyHandle, m: Map) -> RhaiResult<Array> {
    let o = Opts::new("straight_bar", m, keys_of("straight_bar"))?;
    let k = axis_of(&o)?;
    let at = o
        .typed::<Array>("at", "[a, b]")?
        .map_or_else(|| err("straight_bar(): missing required key 'at'"), Ok)?;
    if at.len() != 2 {
        return err("straight_bar(): 'at' must be [a, b], the two section coordinates in axis order (y, z for axis \"x\")");
    }
    let cover = o.float("cover")?.unwrap_or(0.0);
    let (lo, hi) = host.sim.0.borrow().sim.bodies[host.id].mesh.bounds();
    let mut a = Vec3::zeros();
    for (i, c) in (0..3).filter(|&i| i != k).enumerate() {
        a[c] = super::opts::num(&at[i], "straight_bar(): at")?;
    }
    let (mut p, mut q) = (a, a);
    p[k] = lo[k] + cover;
    q[k] = hi[k] - cover;
    if p[k] >= q[k] {
        return err(format!(
            "straight_bar(): cover {cover} m leaves no bar in a host {} m long",
            hi[k] - lo[k]
        ));
    }
    Ok(vec![vec3_to_array(p).into(), vec3_to_array(q).into()])
}

/// `stirrup(host, #{ axis, at, cover, diameter })`: a closed rectangular stirrup in the
/// section normal to `axis` at coordinate `at`, its centreline `cover + diameter/2` inside the
/// host's bounds (the last point repeats the first).
fn stirrup(host: BodyHandle, m: Map) -> RhaiResult<Array> {
    let o = Opts::new("stirrup", m, keys_of("stirrup"))?;
    let k = axis_of(&o)?;
    let at = o.req_float("at")?;
    let inset = o.float("cover")?.unwrap_or(0.0) + 0.5 * o.float("diameter")?.unwrap_or(0.0);
    let (lo, hi) = host.sim.0.borrow().sim.bodies[host.id].mesh.bounds();
    let (u, v) = ((k + 1) % 3, (k + 2) % 3);
    let (u0, u1, v0, v1) = (lo[u] + inset, hi[u] - inset, lo[v] + inset, hi[v] - inset);
    if u0 >= u1 || v0 >= v1 {
        return err("stirrup(): the cover leaves no room for a stirrup in the host's section");
    }
    let corner = |a: Real, b: Real| {
        let mut p = Vec3::zeros();
        (p[k], p[u], p[v]) = (at, a, b);
        Dynamic::from(vec3_to_array(p))
    };
    Ok(vec![
        corner(u0, v0),
        corner(u1, v0),
        corner(u1, v1),
        corner(u0, v1),
        corner(u0, v0),
    ])
}

fn register_queries(engine: &mut Engine) {
    let bars_of = |r: &RebarHandle| r.sim.0.borrow().sim.rebars[r.id].bars.clone();
    engine.register_get("name", |r: &mut RebarHandle| {
        r.sim.0.borrow().sim.rebars[r.id].name.clone()
    });
    engine.register_get("bars", move |r: &mut RebarHandle| bars_of(r).len() as i64);
    engine.register_fn("nodes", |r: &mut RebarHandle| {
        let st = r.sim.0.borrow();
        let nodes = st.sim.rebars[r.id].nodes.clone();
        NodeSet(Rc::new(nodes.map(|n| n as u32).collect()), st.owner.clone())
    });
    engine.register_fn("nodes", |r: &mut RebarHandle, shape: Shape| {
        let st = r.sim.current();
        let tol = st.sim.length_tolerance();
        let nodes = st.sim.rebars[r.id].nodes.clone();
        NodeSet(
            Rc::new(
                nodes
                    .filter(|&n| shape.0.contains(&st.sim.nodes.x[n], tol))
                    .map(|n| n as u32)
                    .collect(),
            ),
            st.owner.clone(),
        )
    });
    engine.register_fn("axial_forces", move |r: &mut RebarHandle| -> Array {
        let st = r.sim.0.borrow();
        bars_of(r)
            .map(|b| Dynamic::from(st.sim.bars.axial_force(b)))
            .collect()
    });
    engine.register_fn("max_force", move |r: &mut RebarHandle| -> Real {
        let st = r.sim.0.borrow();
        bars_of(r)
            .map(|b| st.sim.bars.axial_force(b))
            .fold(Real::NEG_INFINITY, Real::max)
    });
    engine.register_fn("max_stress", move |r: &mut RebarHandle| -> Real {
        let st = r.sim.0.borrow();
        bars_of(r)
            .map(|b| st.sim.bars.stress[b].abs())
            .fold(0.0, Real::max)
    });
    engine.register_fn("max_plastic_strain", move |r: &mut RebarHandle| -> Real {
        let st = r.sim.0.borrow();
        bars_of(r)
            .map(|b| st.sim.bars.plastic_strain[b].abs())
            .fold(0.0, Real::max)
    });
    engine.register_fn("max_bending_moment", |r: &mut RebarHandle| -> Real {
        let st = r.sim.0.borrow();
        let nodes = st.sim.rebars[r.id].nodes.clone();
        let h = &st.sim.bars.hinges;
        (0..h.len())
            .filter(|&k| nodes.contains(&(h.nodes[k][1] as usize)))
            .map(|k| h.moment[k].abs())
            .fold(0.0, Real::max)
    });
    engine.register_fn("ruptured", move |r: &mut RebarHandle| -> i64 {
        let st = r.sim.0.borrow();
        bars_of(r)
            .filter(|&b| !st.sim.bars.ruptured_at[b].is_nan())
            .count() as i64
    });
    engine.register_fn("max_slip", |r: &mut RebarHandle| -> Real {
        let st = r.sim.0.borrow();
        let nodes = st.sim.rebars[r.id].nodes.clone();
        let b = &st.sim.bonds;
        (0..b.len())
            .filter(|&p| nodes.contains(&(b.node[p] as usize)))
            .map(|p| b.slip[p].abs())
            .fold(0.0, Real::max)
    });
}
