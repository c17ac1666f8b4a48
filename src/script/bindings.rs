//! Registration of every script function on the Rhai engine. Each binding validates its
//! options against `api.rs` and turns engine errors into script errors at the call site.

use super::api::{self, keys_of};
use super::opts::{err, to_float, to_vec3, vec3_arg, vec3_to_array, Opts, RhaiResult};
use super::runner;
use super::types::*;
use super::ScriptContext;
use crate::io::VtkSeries;
use crate::loads::{NodalForces, PrescribedVelocity, TimeFunction};
use crate::material::{Formulation, Material, StressMeasure};
use crate::math::{rotation_matrix, von_mises, Mat3, Real, Vec3};
use crate::mesh::{box_mesh, divisions_for, Mesh, Region};
use crate::pipeline::Simulation;
use crate::state::Layout;
use rhai::{Array, Dynamic, Engine, FnPtr, Map, NativeCallContext};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};

static MATERIAL_UID: AtomicU64 = AtomicU64::new(1);

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    register_types(engine);
    register_params(engine, ctx.clone());
    register_geometry(engine);
    register_simulation(engine, ctx.clone());
    register_bodies(engine);
    register_loads(engine);
    register_queries(engine);
    register_hooks(engine, ctx.clone());
    super::bindings_joints::register(engine);
    super::bindings_contact::register(engine, ctx);
    super::bindings_generators::register(engine);
}

fn register_types(engine: &mut Engine) {
    engine
        .register_type_with_name::<SimHandle>("Simulation")
        .register_type_with_name::<BodyHandle>("Body")
        .register_type_with_name::<NodeSet>("Nodes")
        .register_type_with_name::<ElementSet>("Elements")
        .register_type_with_name::<FaceSet>("Faces")
        .register_type_with_name::<Shape>("Shape")
        .register_type_with_name::<MeshValue>("Mesh")
        .register_type_with_name::<MaterialValue>("Material")
        .register_type_with_name::<Table>("Table")
        .register_type_with_name::<MonitorHandle>("Monitor");
    engine.register_fn("to_string", |b: &mut BodyHandle| {
        format!("Body '{}'", b.sim.0.borrow().sim.bodies[b.id].name)
    });
    engine.register_fn("to_string", |n: &mut NodeSet| {
        format!("Nodes({})", n.0.len())
    });
    engine.register_fn("to_string", |n: &mut ElementSet| {
        format!("Elements({})", n.0.len())
    });
    engine.register_fn("to_string", |f: &mut FaceSet| {
        format!("Faces({}, area {:e} m²)", f.faces.len(), f.area)
    });
    engine.register_fn("to_string", |m: &mut MeshValue| {
        format!("Mesh({} nodes, {} tets)", m.0.nodes.len(), m.0.tets.len())
    });
    engine.register_fn("to_string", |m: &mut MaterialValue| {
        format!("Material({})", m.material.formulation.name())
    });
    engine.register_fn("to_string", |s: &mut Shape| {
        format!("Shape({})", s.0.kind())
    });
    engine.register_fn("to_string", |s: &mut SimHandle| {
        format!("Simulation '{}'", s.0.borrow().name)
    });
    engine.register_fn("to_string", |m: &mut MonitorHandle| {
        format!("Monitor '{}'", m.0.borrow().name)
    });
}

// ─── Parameters and checks ───────────────────────────────────────────────────────

fn register_params(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("params", move |defaults: Map| -> RhaiResult<Map> {
        if c.params_called.replace(true) {
            return err("params() may be called only once per script");
        }
        let mut out = defaults.clone();
        for (k, raw) in &c.options.overrides {
            let Some(default) = defaults.get(k.as_str()) else {
                let mut names: Vec<&str> = defaults.keys().map(|k| k.as_str()).collect();
                names.sort_unstable();
                let hint = super::opts::suggest(k, &names).map(|s| format!(" (did you mean '{s}'?)")).unwrap_or_default();
                return err(format!("--set {k}={raw}: the script has no parameter '{k}'{hint}; its parameters are: {}", names.join(", ")));
            };
            let value: Dynamic = if default.is_bool() {
                match raw.as_str() {
                    "true" => true.into(),
                    "false" => false.into(),
                    _ => return err(format!("--set {k}={raw}: '{k}' is a bool (default {default}); use true or false")),
                }
            } else if default.is_int() {
                match raw.parse::<i64>() {
                    Ok(i) => i.into(),
                    Err(_) => return err(format!("--set {k}={raw}: '{k}' is an integer (default {default})")),
                }
            } else if default.is_float() {
                match raw.parse::<f64>() {
                    Ok(x) => x.into(),
                    Err(_) => return err(format!("--set {k}={raw}: '{k}' is a number (default {default})")),
                }
            } else if default.is_string() {
                raw.clone().into()
            } else {
                return err(format!("--set {k}={raw}: parameter '{k}' has type {} which --set cannot override", default.type_name()));
            };
            out.insert(k.as_str().into(), value);
        }
        Ok(out)
    });
    let c = ctx.clone();
    engine.register_fn(
        "expect_within",
        move |label: &str, value: Dynamic, lo: Dynamic, hi: Dynamic| -> RhaiResult<()> {
            if c.options.check_only {
                return Ok(());
            }
            let (v, lo, hi) = (num(&value, label)?, num(&lo, "low")?, num(&hi, "high")?);
            if v >= lo && v <= hi {
                c.say(&format!(
                    "check ok: {label} = {v:.6e} in [{lo:.6e}, {hi:.6e}]"
                ));
                Ok(())
            } else {
                err(format!(
                    "self-check failed: {label} = {v:.6e}, expected within [{lo:.6e}, {hi:.6e}]"
                ))
            }
        },
    );
    let c = ctx;
    engine.register_fn("expect_near", move |label: &str, value: Dynamic, reference: Dynamic, tol: Dynamic| -> RhaiResult<()> {
        if c.options.check_only {
            return Ok(());
        }
        let (v, r, tol) = (num(&value, label)?, num(&reference, "reference")?, num(&tol, "rel_tol")?);
        let rel = (v - r).abs() / r.abs().max(Real::MIN_POSITIVE);
        if rel <= tol {
            c.say(&format!("check ok: {label} = {v:.6e} vs {r:.6e} (rel. error {rel:.2e} ≤ {tol:.1e})"));
            Ok(())
        } else {
            err(format!("self-check failed: {label} = {v:.6e}, reference {r:.6e}: relative error {rel:.3e} > {tol:.1e}"))
        }
    });
}

fn num(d: &Dynamic, what: &str) -> RhaiResult<Real> {
    to_float(d).map_or_else(
        || {
            err(format!(
                "{what}: expected a number, got {} ({d})",
                d.type_name()
            ))
        },
        Ok,
    )
}

// ─── Geometry ────────────────────────────────────────────────────────────────────

fn register_geometry(engine: &mut Engine) {
    engine.register_fn("box", |m: Map| -> RhaiResult<Shape> {
        let o = Opts::new("box", m, keys_of("box"))?;
        let (min, max) = (o.req_vec3("min")?, o.req_vec3("max")?);
        if (0..3).any(|i| max[i] <= min[i]) {
            return err(
                format!("box(): max {max:?} must exceed min {min:?} in every coordinate")
                    .replace('\n', ""),
            );
        }
        Ok(Shape(Region::Box { min, max }))
    });
    engine.register_fn("sphere", |m: Map| -> RhaiResult<Shape> {
        let o = Opts::new("sphere", m, keys_of("sphere"))?;
        let radius = o
            .positive("radius")?
            .map_or_else(|| err("sphere(): missing required key 'radius'"), Ok)?;
        Ok(Shape(Region::Sphere {
            center: o.req_vec3("center")?,
            radius,
        }))
    });
    engine.register_fn("cylinder", |m: Map| -> RhaiResult<Shape> {
        let o = Opts::new("cylinder", m, keys_of("cylinder"))?;
        let axis = o.req_vec3("axis")?;
        if axis.norm() == 0.0 {
            return err("cylinder(): axis must not be zero");
        }
        let radius = o
            .positive("radius")?
            .map_or_else(|| err("cylinder(): missing required key 'radius'"), Ok)?;
        let length = o
            .positive("length")?
            .map_or_else(|| err("cylinder(): missing required key 'length'"), Ok)?;
        Ok(Shape(Region::Cylinder {
            base: o.req_vec3("base")?,
            axis: axis.normalize(),
            radius,
            length,
        }))
    });
    engine.register_fn("half_space", |m: Map| -> RhaiResult<Shape> {
        let o = Opts::new("half_space", m, keys_of("half_space"))?;
        let normal = o.req_vec3("normal")?;
        if normal.norm() == 0.0 {
            return err("half_space(): normal must not be zero");
        }
        Ok(Shape(Region::HalfSpace {
            point: o.req_vec3("point")?,
            normal: normal.normalize(),
        }))
    });
    engine.register_fn("mesh", |s: &mut Shape, m: Map| -> RhaiResult<MeshValue> {
        let o = Opts::new("mesh", m, keys_of("shape.mesh"))?;
        let Region::Box { min, max } = s.0 else {
            return super::bindings_generators::mesh_region(&s.0, &o);
        };
        let divisions = match (o.positive("size")?, o.get("divisions")) {
            (Some(_), Some(_)) => {
                return err("mesh(): give either 'size' or 'divisions', not both")
            }
            (Some(h), None) => divisions_for(max - min, h),
            (None, Some(d)) => {
                let a = d.read_lock::<Array>().map(|a| {
                    a.iter()
                        .map(|v| v.as_int().unwrap_or(0))
                        .collect::<Vec<_>>()
                });
                match a.as_deref() {
                    Some([x, y, z]) if *x > 0 && *y > 0 && *z > 0 => {
                        [*x as usize, *y as usize, *z as usize]
                    }
                    _ => {
                        return err(format!(
                            "mesh(): 'divisions' must be 3 positive integers [nx, ny, nz], got {d}"
                        ))
                    }
                }
            }
            (None, None) => return err("mesh(): missing required key 'size' (or 'divisions')"),
        };
        let cells = divisions.iter().product::<usize>();
        if cells > 50_000_000 {
            return err(format!(
                "mesh(): {cells} cells ({} tets) is too many; use a larger size",
                6 * cells
            ));
        }
        Ok(MeshValue(Rc::new(box_mesh(min, max, divisions))))
    });
    engine.register_fn("tet_mesh", |m: Map| -> RhaiResult<MeshValue> {
        let o = Opts::new("tet_mesh", m, keys_of("tet_mesh"))?;
        let nodes_d = o
            .typed::<Array>("nodes", "an array of [x, y, z]")?
            .map_or_else(|| err("tet_mesh(): missing required key 'nodes'"), Ok)?;
        let tets_d = o
            .typed::<Array>("tets", "an array of [a, b, c, d]")?
            .map_or_else(|| err("tet_mesh(): missing required key 'tets'"), Ok)?;
        let mut nodes = Vec::with_capacity(nodes_d.len());
        for (i, n) in nodes_d.iter().enumerate() {
            nodes.push(to_vec3(n).map_or_else(
                || err(format!("tet_mesh(): node {i} must be [x, y, z], got {n}")),
                Ok,
            )?);
        }
        let mut tets = Vec::with_capacity(tets_d.len());
        for (e, t) in tets_d.iter().enumerate() {
            let ids: Option<Vec<i64>> = t
                .read_lock::<Array>()
                .and_then(|a| a.iter().map(|v| v.as_int().ok()).collect());
            match ids.as_deref() {
                Some(&[a, b, c, d])
                    if [a, b, c, d]
                        .iter()
                        .all(|&i| i >= 0 && (i as usize) < nodes.len()) =>
                {
                    tets.push([a as u32, b as u32, c as u32, d as u32])
                }
                _ => {
                    return err(format!(
                        "tet_mesh(): tet {e} must be 4 node ids in 0..{}, got {t}",
                        nodes.len()
                    ))
                }
            }
        }
        Ok(MeshValue(Rc::new(Mesh::new(nodes, tets))))
    });
    engine.register_fn(
        "translate",
        |m: &mut MeshValue, d: Array| -> RhaiResult<MeshValue> {
            let d = vec3_arg(&d, "translate()")?;
            Rc::make_mut(&mut m.0).translate(d);
            Ok(m.clone())
        },
    );
    engine.register_fn(
        "rotate",
        |m: &mut MeshValue, o: Map| -> RhaiResult<MeshValue> {
            let (axis, angle, center) = rotation_opts(o)?;
            Rc::make_mut(&mut m.0).rotate(axis, angle, center);
            Ok(m.clone())
        },
    );
    engine.register_fn("copy", |m: &mut MeshValue| {
        MeshValue(Rc::new((*m.0).clone()))
    });
    engine.register_get("n_nodes", |m: &mut MeshValue| m.0.nodes.len() as i64);
    engine.register_get("n_tets", |m: &mut MeshValue| m.0.tets.len() as i64);
    engine.register_get("volume", |m: &mut MeshValue| m.0.volume());
}

fn rotation_opts(m: Map) -> RhaiResult<(Vec3, Real, Vec3)> {
    let o = Opts::new("rotate", m, keys_of("mesh.rotate"))?;
    let axis = o.req_vec3("axis")?;
    if axis.norm() == 0.0 {
        return err("rotate(): axis must not be zero");
    }
    Ok((
        axis,
        o.req_float("degrees")?.to_radians(),
        o.vec3("center")?.unwrap_or_default(),
    ))
}

// ─── Simulation, materials, integration ─────────────────────────────────────────

fn register_simulation(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("simulation", move |m: Map| -> RhaiResult<SimHandle> {
        let o = Opts::new("simulation", m, keys_of("simulation"))?;
        let name = o.string("name")?.unwrap_or_else(|| c.script_stem());
        if name.is_empty() || name.contains(['/', '\\']) {
            return err(format!("simulation(): name '{name}' must be non-empty and contain no path separators"));
        }
        let out_dir = match (&c.options.out_dir, o.string("out_dir")?) {
            (Some(cli), _) => cli.clone(),
            (None, Some(d)) => d.into(),
            (None, None) => std::path::PathBuf::from("out").join(&name),
        };
        let mut sim = Simulation::new();
        if let Some(n) = o.positive_int("energy_every")? {
            sim.settings.energy_every = n;
        }
        let stress_output = match o.string("stress_output")? {
            None => StressMeasure::Cauchy,
            Some(s) => StressMeasure::from_name(&s).map_or_else(
                || err(format!("simulation(): stress_output '{s}' is not one of \"cauchy\", \"pk1\", \"pk2\"")),
                Ok,
            )?,
        };
        let vtk_encoding = match o.string("vtk_encoding")?.as_deref() {
            None | Some("raw") => crate::io::vtu::Encoding::Raw,
            Some("base64") => crate::io::vtu::Encoding::Base64,
            Some(x) => return err(format!("simulation(): vtk_encoding '{x}' is not \"raw\" or \"base64\"")),
        };
        let handle = SimHandle(Rc::new(RefCell::new(SimState {
            sim,
            vtk_encoding,
            vtk: VtkSeries::new(out_dir.clone(), name.clone()),
            cracks_vtk: VtkSeries::new(out_dir.clone(), format!("{name}_cracks")),
            name,
            out_dir,
            stress_output,
            hooks: Vec::new(),
            monitors: Vec::new(),
            material_ids: HashMap::new(),
            runs: 0,
            printed_dt: None,
            wall: 0.0,
            steps_in_runs: 0,
            on_joint_broken: None,
            events_dispatched: 0,
            on_new_contact_pair: None,
        })));
        c.sims.borrow_mut().push(handle.clone());
        Ok(handle)
    });
    engine.register_fn(
        "material",
        |law: &str, m: Map| -> RhaiResult<MaterialValue> {
            let Some(formulation) = Formulation::from_name(law) else {
                let names: Vec<&str> = Formulation::ALL.iter().map(|f| f.name()).collect();
                return err(format!(
                    "material(): unknown law \"{law}\"; available: {}",
                    names.join(", ")
                ));
            };
            let o = Opts::new("material", m, keys_of("material"))?;
            let material = Material::new(
                formulation,
                o.req_float("density")?,
                o.req_float("young")?,
                o.req_float("poisson")?,
                o.float("viscosity")?.unwrap_or(0.0),
            )
            .map_err(|e| format!("material(): {e}"))?;
            Ok(MaterialValue {
                uid: MATERIAL_UID.fetch_add(1, Ordering::Relaxed),
                material,
            })
        },
    );
    engine.register_get("young", |m: &mut MaterialValue| m.material.young);
    engine.register_get("poisson", |m: &mut MaterialValue| m.material.poisson);
    engine.register_get("density", |m: &mut MaterialValue| m.material.density);
    engine.register_get("viscosity", |m: &mut MaterialValue| m.material.viscosity);
    engine.register_get("law", |m: &mut MaterialValue| {
        m.material.formulation.name().to_string()
    });

    engine.register_fn(
        "integrator",
        |s: &mut SimHandle, kind: &str, m: Map| -> RhaiResult<()> {
            if kind != "central_difference" {
                return err(format!(
                    "integrator(): unknown integrator \"{kind}\"; available: central_difference"
                ));
            }
            let o = Opts::new("integrator", m, keys_of("sim.integrator"))?;
            let mut st = s.0.borrow_mut();
            if let Some(safety) = o.float("safety")? {
                if !(safety > 0.0 && safety <= 1.0) {
                    return err(format!(
                        "integrator(): safety must lie in (0, 1], got {safety}"
                    ));
                }
                st.sim.settings.safety = safety;
            }
            if let Some(dt) = o.positive("dt")? {
                st.sim.settings.dt = Some(dt);
            }
            st.sim.invalidate();
            Ok(())
        },
    );
    engine.register_fn("damping", |s: &mut SimHandle, m: Map| -> RhaiResult<()> {
        let o = Opts::new("damping", m, keys_of("sim.damping"))?;
        if let Some(a) = o.float("mass_proportional")? {
            if a < 0.0 {
                return err(format!("damping(): mass_proportional must be ≥ 0, got {a}"));
            }
            s.0.borrow_mut().sim.settings.mass_damping = a;
        }
        Ok(())
    });
    let c = ctx;
    engine.register_fn(
        "run",
        move |nc: NativeCallContext, s: &mut SimHandle, m: Map| -> RhaiResult<()> {
            let o = Opts::new("run", m, keys_of("sim.run"))?;
            runner::run(&nc, &c, s, o)
        },
    );
    engine.register_fn("write_vtk", |s: &mut SimHandle| -> RhaiResult<()> {
        runner::write_vtk(s)
    });
}

// ─── Bodies and selections ───────────────────────────────────────────────────────

fn register_bodies(engine: &mut Engine) {
    fn add_body(
        s: &mut SimHandle,
        name: &str,
        mesh: MeshValue,
        mat: MaterialValue,
        o: Option<Map>,
    ) -> RhaiResult<BodyHandle> {
        let layout = match o {
            None => Layout::Continuous,
            Some(m) => {
                let o = Opts::new("add_body", m, keys_of("sim.add_body"))?;
                match o.string("layout")?.as_deref() {
                    None | Some("continuous") => Layout::Continuous,
                    Some("jointed") => Layout::Jointed,
                    Some(x) => {
                        return err(format!(
                            "add_body(): layout \"{x}\" is not \"continuous\" or \"jointed\""
                        ))
                    }
                }
            }
        };
        let mut st = s.0.borrow_mut();
        if st.sim.step > 0 {
            return err("add_body(): bodies must be added before the first step");
        }
        let mid = match st.material_ids.get(&mat.uid) {
            Some(&id) => id,
            None => {
                let id = st.sim.add_material(mat.material.clone());
                st.material_ids.insert(mat.uid, id);
                id
            }
        };
        let id = st
            .sim
            .add_body(name, &mesh.0, mid, layout)
            .map_err(|e| format!("add_body(): {e}"))?;
        drop(st);
        Ok(BodyHandle { sim: s.clone(), id })
    }
    engine.register_fn(
        "add_body",
        |s: &mut SimHandle, name: &str, mesh: MeshValue, mat: MaterialValue| {
            add_body(s, name, mesh, mat, None)
        },
    );
    engine.register_fn(
        "add_body",
        |s: &mut SimHandle, name: &str, mesh: MeshValue, mat: MaterialValue, o: Map| {
            add_body(s, name, mesh, mat, Some(o))
        },
    );
    engine.register_fn(
        "copy",
        |b: &mut BodyHandle, name: &str| -> RhaiResult<BodyHandle> {
            let (mesh, mat_uid_material, layout) = {
                let st = b.sim.0.borrow();
                let body = &st.sim.bodies[b.id];
                let m = st.sim.materials[body.material as usize].clone();
                let uid = st
                    .material_ids
                    .iter()
                    .find(|(_, &v)| v == body.material)
                    .map(|(k, _)| *k)
                    .unwrap_or(0);
                (
                    st.sim.bodies[b.id].mesh.clone(),
                    MaterialValue { uid, material: m },
                    body.layout,
                )
            };
            let layout =
                Map::from_iter([("layout".into(), Dynamic::from(layout.name().to_string()))]);
            add_body(
                &mut b.sim.clone(),
                name,
                MeshValue(Rc::new(mesh)),
                mat_uid_material,
                Some(layout),
            )
        },
    );
    engine.register_fn(
        "translate",
        |b: &mut BodyHandle, d: Array| -> RhaiResult<()> {
            let d = vec3_arg(&d, "translate()")?;
            move_body(b, |p| p + d)
        },
    );
    engine.register_fn("rotate", |b: &mut BodyHandle, o: Map| -> RhaiResult<()> {
        let (axis, angle, center) = rotation_opts(o)?;
        let r = rotation_matrix(&axis, angle);
        move_body(b, |p| center + r * (p - center))
    });
    engine.register_get("name", |b: &mut BodyHandle| {
        b.sim.0.borrow().sim.bodies[b.id].name.clone()
    });
    engine.register_get("layout", |b: &mut BodyHandle| {
        b.sim.0.borrow().sim.bodies[b.id].layout.name().to_string()
    });
    engine.register_get("n_tets", |b: &mut BodyHandle| {
        b.sim.0.borrow().sim.bodies[b.id].tets.len() as i64
    });
    engine.register_get("n_nodes", |b: &mut BodyHandle| {
        b.sim.0.borrow().sim.bodies[b.id].nodes.len() as i64
    });
    engine.register_get("volume", |b: &mut BodyHandle| {
        let st = b.sim.0.borrow();
        st.sim.bodies[b.id]
            .tets
            .clone()
            .map(|e| st.sim.tets.vol0[e])
            .sum::<Real>()
    });
    engine.register_get("mass", |b: &mut BodyHandle| {
        let st = b.sim.0.borrow();
        let body = &st.sim.bodies[b.id];
        body.tets.clone().map(|e| st.sim.tets.vol0[e]).sum::<Real>()
            * st.sim.materials[body.material as usize].density
    });
    engine.register_fn("nodes", |b: &mut BodyHandle| {
        NodeSet(Rc::new(
            b.sim.0.borrow().sim.bodies[b.id]
                .nodes
                .clone()
                .map(|n| n as u32)
                .collect(),
        ))
    });
    engine.register_fn("nodes", |b: &mut BodyHandle, r: Shape| {
        NodeSet(Rc::new(b.sim.0.borrow().sim.nodes_in(&r.0, Some(b.id))))
    });
    engine.register_fn("nodes", |s: &mut SimHandle, r: Shape| {
        NodeSet(Rc::new(s.0.borrow().sim.nodes_in(&r.0, None)))
    });
    engine.register_fn("elements", |b: &mut BodyHandle| {
        ElementSet(Rc::new(
            b.sim.0.borrow().sim.bodies[b.id]
                .tets
                .clone()
                .map(|e| e as u32)
                .collect(),
        ))
    });
    engine.register_fn("elements", |b: &mut BodyHandle, r: Shape| {
        ElementSet(Rc::new(b.sim.0.borrow().sim.tets_in(&r.0, Some(b.id))))
    });
    engine.register_fn("boundary", |b: &mut BodyHandle| boundary(b, Map::new()));
    engine.register_fn("boundary", boundary);
    engine.register_fn("nodes", |f: &mut FaceSet| {
        let mut v: Vec<u32> = f.faces.iter().flat_map(|f| f.nodes).collect();
        v.sort_unstable();
        v.dedup();
        NodeSet(Rc::new(v))
    });
    engine.register_get("area", |f: &mut FaceSet| f.area);
    engine.register_fn("len", |f: &mut FaceSet| f.faces.len() as i64);
    engine.register_fn("len", |n: &mut NodeSet| n.0.len() as i64);
    engine.register_fn("len", |n: &mut ElementSet| n.0.len() as i64);
    engine.register_fn("+", |a: NodeSet, b: NodeSet| {
        NodeSet(Rc::new(union(&a.0, &b.0)))
    });
    engine.register_fn("+", |a: ElementSet, b: ElementSet| {
        ElementSet(Rc::new(union(&a.0, &b.0)))
    });
}

fn move_body(b: &mut BodyHandle, f: impl Fn(Vec3) -> Vec3) -> RhaiResult<()> {
    let mut st = b.sim.0.borrow_mut();
    if st.sim.step > 0 {
        return err("bodies can be moved only before the first step (their reference configuration would change)");
    }
    let range = st.sim.bodies[b.id].nodes.clone();
    for n in range {
        let p = f(st.sim.nodes.x0[n]);
        st.sim.nodes.x0[n] = p;
        st.sim.nodes.x[n] = p;
    }
    for p in &mut st.sim.bodies[b.id].mesh.nodes {
        *p = f(*p);
    }
    // dm_inv changes under rotation: rebuild the tets' reference data.
    let tets = st.sim.bodies[b.id].tets.clone();
    for e in tets {
        let p = st.sim.tets.nodes[e].map(|n| st.sim.nodes.x0[n as usize]);
        let dm = crate::math::edge_matrix(&p[0], &p[1], &p[2], &p[3]);
        st.sim.tets.dm_inv[e] = dm
            .try_inverse()
            .expect("rigid motion keeps tets non-degenerate");
    }
    st.sim.invalidate();
    Ok(())
}

fn boundary(b: &mut BodyHandle, m: Map) -> RhaiResult<FaceSet> {
    let o = Opts::new("boundary", m, keys_of("body.boundary"))?;
    let normal = o.vec3("normal")?.map(|n| n.normalize());
    let tol = o.float("tolerance")?.unwrap_or(1.0).to_radians();
    let within = o.typed::<Shape>("within", "a shape")?;
    let st = b.sim.0.borrow();
    let x0 = &st.sim.nodes.x0;
    let ltol = st.sim.length_tolerance();
    let mut area = 0.0;
    let faces: Vec<_> = st.sim.bodies[b.id]
        .boundary
        .iter()
        .filter(|f| {
            let an = f.area_normal(x0);
            let ok_n = normal.is_none_or(|n| an.normalize().dot(&n) >= tol.cos() - 1e-12);
            let c = f.nodes.iter().map(|&n| x0[n as usize]).sum::<Vec3>() / 3.0;
            let ok_r = within.as_ref().is_none_or(|s| s.0.contains(&c, ltol));
            ok_n && ok_r
        })
        .copied()
        .inspect(|f| area += f.area_normal(x0).norm())
        .collect();
    Ok(FaceSet {
        faces: Rc::new(faces),
        area,
    })
}

// ─── Loads ───────────────────────────────────────────────────────────────────────

fn parse_components(spec: &str) -> RhaiResult<[bool; 3]> {
    let mut c = [false; 3];
    for ch in spec.chars() {
        match ch {
            'x' => c[0] = true,
            'y' => c[1] = true,
            'z' => c[2] = true,
            _ => {
                return err(format!(
                    "fix(): components \"{spec}\" must use only the letters x, y, z"
                ))
            }
        }
    }
    if c == [false; 3] {
        return err("fix(): no component given; use e.g. \"xyz\" or \"z\"");
    }
    Ok(c)
}

fn time_fn(d: &Dynamic, what: &str) -> RhaiResult<TimeFunction> {
    if let Some(t) = d.clone().try_cast::<Table>() {
        return Ok(t.0);
    }
    to_float(d).map(TimeFunction::Constant).map_or_else(
        || {
            err(format!(
                "{what}: expected a number or a table, got {} ({d})",
                d.type_name()
            ))
        },
        Ok,
    )
}

fn register_loads(engine: &mut Engine) {
    engine.register_fn("gravity", |s: &mut SimHandle, g: Array| -> RhaiResult<()> {
        s.0.borrow_mut().sim.loads.gravity = vec3_arg(&g, "gravity()")?;
        Ok(())
    });
    fn fix(s: &mut SimHandle, n: NodeSet, comps: [bool; 3]) {
        let components = comps.map(|c| c.then_some(TimeFunction::Constant(0.0)));
        let mut st = s.0.borrow_mut();
        st.sim.loads.prescribed.push(PrescribedVelocity {
            nodes: (*n.0).clone(),
            components,
        });
        for &i in n.0.iter() {
            for (k, _) in comps.iter().enumerate().filter(|(_, &c)| c) {
                st.sim.nodes.v[i as usize][k] = 0.0;
            }
        }
        st.sim.invalidate();
    }
    engine.register_fn("fix", |s: &mut SimHandle, n: NodeSet| fix(s, n, [true; 3]));
    engine.register_fn(
        "fix",
        |s: &mut SimHandle, n: NodeSet, c: &str| -> RhaiResult<()> {
            fix(s, n, parse_components(c)?);
            Ok(())
        },
    );
    fn prescribe(s: &mut SimHandle, n: NodeSet, components: [Option<TimeFunction>; 3]) {
        let mut st = s.0.borrow_mut();
        st.sim.loads.prescribed.push(PrescribedVelocity {
            nodes: (*n.0).clone(),
            components,
        });
        st.sim.invalidate();
    }
    engine.register_fn(
        "prescribe_velocity",
        |s: &mut SimHandle, n: NodeSet, v: Array| -> RhaiResult<()> {
            if v.len() != 3 {
                return err("prescribe_velocity(): expected [vx, vy, vz] or a map #{ x: …, z: … }");
            }
            let mut c: [Option<TimeFunction>; 3] = Default::default();
            for k in 0..3 {
                c[k] = Some(time_fn(&v[k], "prescribe_velocity()")?);
            }
            prescribe(s, n, c);
            Ok(())
        },
    );
    engine.register_fn(
        "prescribe_velocity",
        |s: &mut SimHandle, n: NodeSet, m: Map| -> RhaiResult<()> {
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
            prescribe(s, n, c);
            Ok(())
        },
    );
    fn nodal_force(s: &mut SimHandle, n: NodeSet, f: Array, scale: TimeFunction) -> RhaiResult<()> {
        let f = vec3_arg(&f, "nodal_force()")?;
        let mut st = s.0.borrow_mut();
        st.sim
            .loads
            .forces
            .push(NodalForces::new((*n.0).clone(), vec![f; n.0.len()], scale));
        Ok(())
    }
    engine.register_fn("nodal_force", |s: &mut SimHandle, n: NodeSet, f: Array| {
        nodal_force(s, n, f, TimeFunction::Constant(1.0))
    });
    engine.register_fn(
        "nodal_force",
        |s: &mut SimHandle, n: NodeSet, f: Array, t: Table| nodal_force(s, n, f, t.0),
    );
    fn traction(
        s: &mut SimHandle,
        faces: FaceSet,
        t: Array,
        scale: TimeFunction,
    ) -> RhaiResult<()> {
        let t = vec3_arg(&t, "traction()")?;
        let mut st = s.0.borrow_mut();
        let forces = NodalForces::traction(&faces.faces, &st.sim.nodes.x0, t, scale);
        st.sim.loads.forces.push(forces);
        Ok(())
    }
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
            let mut st = s.0.borrow_mut();
            for &i in n.0.iter() {
                st.sim.nodes.v[i as usize] = v;
            }
            Ok(())
        },
    );
    engine.register_fn("table", |points: Array| -> RhaiResult<Table> {
        let mut pts = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let pair: Option<(Real, Real)> =
                p.read_lock::<Array>().and_then(|a| match a.as_slice() {
                    [t, v] => Some((to_float(t)?, to_float(v)?)),
                    _ => None,
                });
            pts.push(pair.map_or_else(
                || err(format!("table(): point {i} must be [t, value], got {p}")),
                Ok,
            )?);
        }
        Ok(Table(
            TimeFunction::table(pts).map_err(|e| format!("table(): {e}"))?,
        ))
    });
    fn read_table(nc: &NativeCallContext, path: &str, scale: Real) -> RhaiResult<Table> {
        let resolved = super::resolve_path(nc, path);
        let text = std::fs::read_to_string(&resolved)
            .map_err(|e| format!("read_table(): cannot read '{}': {e}", resolved.display()))?;
        let mut pts = Vec::new();
        for (ln, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let cols: Vec<&str> = line
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|s| !s.is_empty())
                .collect();
            let parsed: Option<Vec<f64>> = cols.iter().map(|c| c.parse().ok()).collect();
            match parsed.as_deref() {
                Some([t, v, ..]) => pts.push((*t, *v * scale)),
                _ if pts.is_empty() => continue, // header
                _ => {
                    return err(format!(
                        "read_table(): {}:{}: expected two numbers, got '{line}'",
                        resolved.display(),
                        ln + 1
                    ))
                }
            }
        }
        Ok(Table(TimeFunction::table(pts).map_err(|e| {
            format!("read_table(): {}: {e}", resolved.display())
        })?))
    }
    engine.register_fn("read_table", |nc: NativeCallContext, path: &str| {
        read_table(&nc, path, 1.0)
    });
    engine.register_fn(
        "read_table",
        |nc: NativeCallContext, path: &str, scale: Dynamic| -> RhaiResult<Table> {
            read_table(&nc, path, num(&scale, "read_table() scale")?)
        },
    );
    engine.register_fn("eval", |t: &mut Table, time: Dynamic| -> RhaiResult<Real> {
        Ok(t.0.eval(num(&time, "eval()")?))
    });
}

// ─── Queries ─────────────────────────────────────────────────────────────────────

fn mean_of(
    s: &SimHandle,
    n: &NodeSet,
    what: &str,
    f: impl Fn(&Simulation, usize) -> Vec3,
) -> RhaiResult<Array> {
    if n.0.is_empty() {
        return err(format!("{what}(): the node set is empty"));
    }
    let st = s.0.borrow();
    let sum: Vec3 = n.0.iter().map(|&i| f(&st.sim, i as usize)).sum();
    Ok(vec3_to_array(sum / n.0.len() as Real))
}

fn register_queries(engine: &mut Engine) {
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
        let mut st = s.0.borrow_mut();
        st.sim.prepare().map_err(|e| e.to_string())?;
        Ok(st.sim.kinetic_energy_now())
    });
    engine.register_fn("strain_energy", |s: &mut SimHandle| {
        s.0.borrow().sim.strain_energy_now()
    });
    engine.register_fn("energy", |s: &mut SimHandle| {
        let e = s.0.borrow().sim.energy;
        let mut m = Map::new();
        for (k, v) in [
            ("kinetic", e.kinetic),
            ("strain", e.strain),
            ("external_work", e.external_work()),
            ("gravity_work", e.gravity_work),
            ("force_work", e.force_work),
            ("reaction_work", e.reaction_work),
            ("damping", e.mass_damping + e.viscous_damping),
            ("joint", e.joint),
            ("fracture", e.fracture),
            ("contact", e.contact),
            ("friction", e.friction),
            ("initial", e.initial),
            ("balance_error", e.balance_error()),
            ("relative_error", e.relative_balance_error()),
        ] {
            m.insert(k.into(), v.into());
        }
        m
    });
    engine.register_fn("displacement", |s: &mut SimHandle, n: NodeSet| {
        mean_of(s, &n, "displacement", |sim, i| {
            sim.nodes.x[i] - sim.nodes.x0[i]
        })
    });
    engine.register_fn("position", |s: &mut SimHandle, n: NodeSet| {
        mean_of(s, &n, "position", |sim, i| sim.nodes.x[i])
    });
    engine.register_fn("velocity", |s: &mut SimHandle, n: NodeSet| {
        mean_of(s, &n, "velocity", |sim, i| sim.nodes.v[i])
    });
    engine.register_fn("reaction", |s: &mut SimHandle, n: NodeSet| {
        let st = s.0.borrow();
        vec3_to_array(n.0.iter().map(|&i| st.sim.nodes.reaction[i as usize]).sum())
    });
    engine.register_fn(
        "mean_stress",
        |s: &mut SimHandle, el: ElementSet| -> RhaiResult<Array> {
            if el.0.is_empty() {
                return err("mean_stress(): the element set is empty");
            }
            let st = s.0.borrow();
            let sim = &st.sim;
            let (mut sum, mut vol) = (Mat3::zeros(), 0.0);
            for &e in el.0.iter() {
                let e = e as usize;
                let f = crate::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e);
                let sigma =
                    sim.materials[sim.tets.material[e] as usize].stress(&f, StressMeasure::Cauchy);
                sum += sigma * sim.tets.vol0[e];
                vol += sim.tets.vol0[e];
            }
            let m = sum / vol;
            Ok((0..3)
                .map(|i| {
                    Dynamic::from_array(vec![m[(i, 0)].into(), m[(i, 1)].into(), m[(i, 2)].into()])
                })
                .collect())
        },
    );
    engine.register_fn("max_von_mises", |s: &mut SimHandle, el: ElementSet| {
        let st = s.0.borrow();
        let sim = &st.sim;
        el.0.iter()
            .map(|&e| {
                let f = crate::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e as usize);
                von_mises(
                    &sim.materials[sim.tets.material[e as usize] as usize]
                        .stress(&f, StressMeasure::Cauchy),
                )
            })
            .fold(0.0, Real::max)
    });
}

// ─── Hooks and monitors ──────────────────────────────────────────────────────────

fn register_hooks(engine: &mut Engine, _ctx: Rc<ScriptContext>) {
    engine.register_fn(
        "every",
        |s: &mut SimHandle, m: Map, f: FnPtr| -> RhaiResult<()> {
            let o = Opts::new("every", m, keys_of("sim.every"))?;
            let steps = o.positive_int("steps")?;
            let time = o.positive("time")?;
            if steps.is_some() == time.is_some() {
                return err("every(): give exactly one of 'steps' or 'time'");
            }
            let mut st = s.0.borrow_mut();
            let next_time = time
                .map(|t| ((st.sim.time / t).floor() + 1.0) * t)
                .unwrap_or(0.0);
            st.hooks.push(Hook {
                every_steps: steps,
                every_time: time,
                next_time,
                f,
            });
            Ok(())
        },
    );
    engine.register_fn(
        "monitor",
        |s: &mut SimHandle, name: &str, m: Map, f: FnPtr| -> RhaiResult<MonitorHandle> {
            let o = Opts::new("monitor", m, keys_of("sim.monitor"))?;
            let every = o.positive_int("every")?.unwrap_or(1);
            if name.is_empty() || name.contains(['/', '\\']) {
                return err(format!(
                    "monitor(): name '{name}' must be non-empty and contain no path separators"
                ));
            }
            let mut st = s.0.borrow_mut();
            if st.monitors.iter().any(|m| m.0.borrow().name == name) {
                return err(format!(
                    "monitor(): a monitor named '{name}' already exists"
                ));
            }
            let path = st.out_dir.join(format!("{name}.csv"));
            let h = MonitorHandle(Rc::new(RefCell::new(MonitorData {
                name: name.to_string(),
                every,
                f,
                times: Vec::new(),
                steps: Vec::new(),
                values: Vec::new(),
                path,
            })));
            st.monitors.push(h.clone());
            Ok(h)
        },
    );
    engine.register_fn("last", |m: &mut MonitorHandle| {
        m.0.borrow().values.last().copied().unwrap_or(0.0)
    });
    engine.register_fn("peak", |m: &mut MonitorHandle| {
        m.0.borrow().values.iter().copied().fold(0.0_f64, Real::max)
    });
    engine.register_fn("max", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .copied()
            .fold(Real::NEG_INFINITY, Real::max)
    });
    engine.register_fn("min", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .copied()
            .fold(Real::INFINITY, Real::min)
    });
    engine.register_fn("len", |m: &mut MonitorHandle| {
        m.0.borrow().values.len() as i64
    });
    engine.register_fn("values", |m: &mut MonitorHandle| {
        m.0.borrow()
            .values
            .iter()
            .map(|&v| Dynamic::from(v))
            .collect::<Array>()
    });
    engine.register_fn("times", |m: &mut MonitorHandle| {
        m.0.borrow()
            .times
            .iter()
            .map(|&v| Dynamic::from(v))
            .collect::<Array>()
    });
    engine.register_fn("write_csv", |m: &mut MonitorHandle| -> RhaiResult<()> {
        runner::write_monitor(m).map_err(|e| e.into())
    });
    let _ = api::API;
}
