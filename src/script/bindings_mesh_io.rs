//! Script bindings for mesh files and named sets: `gmsh(..)`, `mesh.sets()`, the
//! transformations `mesh.scale`, `mesh.mirror` and `array(mesh, ..)`, and `body.set(name)` with
//! its kind-specific variants.

use super::api::keys_of;
use super::opts::{err, to_float, to_vec3, Opts, RhaiResult};
use super::types::*;
use super::ScriptContext;
use crate::math::{Real, Vec3};
use crate::mesh::gmsh;
use crate::mesh::{BoundaryFace, Mesh, TET_FACES};
use rhai::{Array, Dynamic, Engine, Map, NativeCallContext};
use std::path::{Path, PathBuf};
use std::rc::Rc;

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn(
        "gmsh",
        move |nc: NativeCallContext, path: &str| -> RhaiResult<MeshValue> {
            load(&nc, &c, path, Map::new())
        },
    );
    let c = ctx;
    engine.register_fn(
        "gmsh",
        move |nc: NativeCallContext, path: &str, m: Map| -> RhaiResult<MeshValue> {
            load(&nc, &c, path, m)
        },
    );
    engine.register_fn("sets", |m: &mut MeshValue| names_array(&m.0));
    engine.register_fn(
        "scale",
        |m: &mut MeshValue, f: Dynamic| -> RhaiResult<MeshValue> { scale(m, &f, Vec3::zeros()) },
    );
    engine.register_fn(
        "scale",
        |m: &mut MeshValue, f: Dynamic, center: Array| -> RhaiResult<MeshValue> {
            let c = super::opts::vec3_arg(&center, "scale() center")?;
            scale(m, &f, c)
        },
    );
    engine.register_fn(
        "mirror",
        |m: &mut MeshValue, o: Map| -> RhaiResult<MeshValue> {
            let o = Opts::new("mirror", o, keys_of("mesh.mirror"))?;
            let point = o.req_vec3("point")?;
            let normal = o.req_vec3("normal")?;
            if normal.norm() == 0.0 || !normal.iter().all(|c| c.is_finite()) {
                return err("mirror(): normal must not be zero");
            }
            Rc::make_mut(&mut m.0).mirror(point, normal);
            Ok(m.clone())
        },
    );
    engine.register_fn("array", array);
    engine.register_fn("sets", |b: &mut BodyHandle| {
        names_array(&b.sim.0.borrow().sim.bodies[b.id].mesh)
    });
    engine.register_fn("set", |b: &mut BodyHandle, name: &str| {
        body_set(b, name, None)
    });
    engine.register_fn("node_set", |b: &mut BodyHandle, name: &str| {
        body_set(b, name, Some(Kind::Nodes))
    });
    engine.register_fn("element_set", |b: &mut BodyHandle, name: &str| {
        body_set(b, name, Some(Kind::Elements))
    });
    engine.register_fn("face_set", |b: &mut BodyHandle, name: &str| {
        body_set(b, name, Some(Kind::Faces))
    });
}

/// A path named in a script: relative to the script's directory (or the calling module's),
/// else as given (relative to the working directory).
fn script_relative(nc: &NativeCallContext, ctx: &ScriptContext, path: &str) -> PathBuf {
    let p = PathBuf::from(path);
    if p.is_absolute() {
        return p;
    }
    let dirs = [
        nc.call_source()
            .and_then(|s| Path::new(s).parent().map(Path::to_path_buf)),
        ctx.script_path.parent().map(Path::to_path_buf),
    ];
    for d in dirs.into_iter().flatten() {
        let q = d.join(&p);
        if q.exists() {
            return q;
        }
    }
    p
}

fn load(nc: &NativeCallContext, ctx: &ScriptContext, path: &str, m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("gmsh", m, keys_of("gmsh"))?;
    let size = o.positive("size")?;
    let file = script_relative(nc, ctx, path);
    let ext = file
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let imported = match ext.as_str() {
        "msh" => {
            if size.is_some() {
                return err(format!(
                    "gmsh(\"{path}\"): 'size' applies to .geo files (a .msh file is already meshed)"
                ));
            }
            gmsh::read_msh(&file).map_err(|e| format!("gmsh(): {e}"))?
        }
        "geo" => {
            let c = gmsh::mesh_geo_cached(&file, size, &ctx.options.geo)
                .map_err(|e| format!("gmsh(): {e}"))?;
            // Said under `fdem check` too: which mesh the model is built on.
            println!(
                "gmsh(\"{path}\"): {} {} ({} tets, {} nodes){}",
                if c.reused {
                    "using the cached mesh"
                } else {
                    "meshed by gmsh into"
                },
                c.msh.display(),
                c.imported.mesh.tets.len(),
                c.imported.mesh.nodes.len(),
                if c.reused {
                    "; delete it to re-mesh"
                } else {
                    "; reused while the .geo text, size and gmsh version are unchanged"
                }
            );
            c.imported
        }
        _ => return err(format!("gmsh(\"{path}\"): expected a .msh or .geo file")),
    };
    for w in &imported.warnings {
        ctx.say(&format!("warning: gmsh(\"{path}\"): {w}"));
    }
    let problems = imported.mesh.problems();
    if !problems.is_empty() {
        let list: Vec<String> = problems.iter().take(10).map(|p| format!("  {p}")).collect();
        return err(format!(
            "gmsh(): {}: the mesh has {} problem(s) (tet and node ids count from 0 in file order of the tetrahedra and their nodes):\n{}{}",
            file.display(),
            problems.len(),
            list.join("\n"),
            if problems.len() > 10 { "\n  …" } else { "" }
        ));
    }
    Ok(MeshValue(Rc::new(imported.mesh)))
}

fn names_array(m: &Mesh) -> Array {
    m.sets.names().into_iter().map(Dynamic::from).collect()
}

fn scale(m: &mut MeshValue, f: &Dynamic, center: Vec3) -> RhaiResult<MeshValue> {
    let factors = match (to_float(f), to_vec3(f)) {
        (Some(s), _) => Vec3::repeat(s),
        (None, Some(v)) => v,
        _ => {
            return err(format!(
                "scale(): expected a number or [sx, sy, sz], got {f}"
            ))
        }
    };
    if factors.iter().any(|s| *s == 0.0 || !s.is_finite()) {
        return err(format!(
            "scale(): factors must be finite and non-zero, got [{}, {}, {}]",
            factors.x, factors.y, factors.z
        ));
    }
    Rc::make_mut(&mut m.0).scale(factors, center);
    Ok(m.clone())
}

/// `array(mesh, #{ count, spacing })`: copies of the mesh on a regular grid, the first at the
/// mesh's own place, x varying fastest.
fn array(m: MeshValue, o: Map) -> RhaiResult<Array> {
    let o = Opts::new("array", o, keys_of("array"))?;
    let count: Vec<i64> = match o.get("count") {
        None => return err("array(): missing required key 'count'"),
        Some(d) => d
            .read_lock::<Array>()
            .and_then(|a| {
                a.iter()
                    .map(|v| v.as_int().ok())
                    .collect::<Option<Vec<_>>>()
            })
            .filter(|v| v.len() == 3 && v.iter().all(|&n| n >= 1))
            .map_or_else(
                || {
                    err(format!(
                        "array(): 'count' must be 3 integers ≥ 1 [nx, ny, nz], got {d}"
                    ))
                },
                Ok,
            )?,
    };
    let spacing = o.req_vec3("spacing")?;
    // In floating point: counts of 2³¹ each must not wrap around to a small product.
    let total_f: f64 = count.iter().map(|&n| n as f64).product();
    if total_f > 100_000.0 {
        return err(format!(
            "array(): {total_f:.4e} copies is too many (the limit is 100 000)"
        ));
    }
    let total = total_f as i64;
    crate::limits::check_tets(total_f * m.0.tets.len() as f64)
        .map_err(|e| format!("array(): {e}"))?;
    let mut out = Array::with_capacity(total as usize);
    for k in 0..count[2] {
        for j in 0..count[1] {
            for i in 0..count[0] {
                let mut copy = (*m.0).clone();
                copy.translate(Vec3::new(
                    i as Real * spacing.x,
                    j as Real * spacing.y,
                    k as Real * spacing.z,
                ));
                out.push(Dynamic::from(MeshValue(Rc::new(copy))));
            }
        }
    }
    Ok(out)
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    Nodes,
    Elements,
    Faces,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Nodes => "node set",
            Kind::Elements => "element set",
            Kind::Faces => "face set",
        }
    }
}

fn available(m: &Mesh) -> String {
    if m.sets.is_empty() {
        return "the body's mesh has no named sets (they come from Gmsh physical groups)".into();
    }
    let mut parts = Vec::new();
    for name in m.sets.names() {
        let mut kinds = Vec::new();
        if m.sets.faces.contains_key(&name) {
            kinds.push("faces");
        }
        if m.sets.elements.contains_key(&name) {
            kinds.push("elements");
        }
        if m.sets.nodes.contains_key(&name) {
            kinds.push("nodes");
        }
        parts.push(format!("{name} ({})", kinds.join(", ")));
    }
    format!("its sets are: {}", parts.join("; "))
}

/// A named set of a body as a selection in simulation ids. Without a kind: a face set if there
/// is one (surface groups also give a node set of the same name), else the one set of that
/// name; a name that is both an element set and a node set must be asked for by kind.
fn body_set(b: &mut BodyHandle, name: &str, kind: Option<Kind>) -> RhaiResult<Dynamic> {
    let st = b.sim.0.borrow();
    let sim = &st.sim;
    let body = &sim.bodies[b.id];
    let sets = &body.mesh.sets;
    let has = |k: Kind| match k {
        Kind::Nodes => sets.nodes.contains_key(name),
        Kind::Elements => sets.elements.contains_key(name),
        Kind::Faces => sets.faces.contains_key(name),
    };
    let func = match kind {
        None => "set",
        Some(Kind::Nodes) => "node_set",
        Some(Kind::Elements) => "element_set",
        Some(Kind::Faces) => "face_set",
    };
    let kind = match kind {
        Some(k) if has(k) => k,
        Some(k) => {
            let other: Vec<&str> = [Kind::Faces, Kind::Elements, Kind::Nodes]
                .into_iter()
                .filter(|&o| has(o))
                .map(Kind::name)
                .collect();
            let also = if other.is_empty() {
                String::new()
            } else {
                format!(" ('{name}' is a {})", other.join(" and a "))
            };
            return err(format!(
                "{func}(): body '{}' has no {} named '{name}'{also}; {}",
                body.name,
                k.name(),
                available(&body.mesh)
            ));
        }
        None => {
            let (f, e, n) = (has(Kind::Faces), has(Kind::Elements), has(Kind::Nodes));
            match (f, e, n) {
                (true, false, _) => Kind::Faces,
                (false, true, false) => Kind::Elements,
                (false, false, true) => Kind::Nodes,
                (false, false, false) => {
                    return err(format!(
                        "set(): body '{}' has no set named '{name}'; {}",
                        body.name,
                        available(&body.mesh)
                    ))
                }
                _ => {
                    return err(format!(
                        "set(): '{name}' names sets of several kinds in body '{}'; say which with body.face_set(\"{name}\"), body.element_set(\"{name}\") or body.node_set(\"{name}\")",
                        body.name
                    ))
                }
            }
        }
    };
    let t0 = body.tets.start;
    Ok(match kind {
        Kind::Elements => Dynamic::from(ElementSet(
            Rc::new(
                sets.elements[name]
                    .iter()
                    .map(|&e| (t0 + e as usize) as u32)
                    .collect(),
            ),
            st.owner.clone(),
        )),
        Kind::Nodes => {
            // Every simulation node that is a copy of a mesh node of the set (one per mesh node
            // in continuous bodies, one per tet corner in jointed ones).
            let mut member = vec![false; body.mesh.nodes.len()];
            for &n in &sets.nodes[name] {
                member[n as usize] = true;
            }
            let mut ids: Vec<u32> = Vec::new();
            for (e, t) in body.mesh.tets.iter().enumerate() {
                for (k, &n) in t.iter().enumerate() {
                    if member[n as usize] {
                        ids.push(sim.tets.nodes[t0 + e][k]);
                    }
                }
            }
            ids.sort_unstable();
            ids.dedup();
            Dynamic::from(NodeSet(Rc::new(ids), st.owner.clone()))
        }
        Kind::Faces => {
            let x0 = &sim.nodes.x0;
            let mut area = 0.0;
            let faces: Vec<BoundaryFace> = sets.faces[name]
                .iter()
                .map(|&(t, l)| {
                    let tn = sim.tets.nodes[t0 + t as usize];
                    let f = BoundaryFace {
                        tet: (t0 + t as usize) as u32,
                        local: l,
                        nodes: TET_FACES[l as usize].map(|c| tn[c]),
                    };
                    area += f.area_normal(x0).norm();
                    f
                })
                .collect();
            Dynamic::from(FaceSet {
                faces: Rc::new(faces),
                area,
                owner: st.owner.clone(),
            })
        }
    })
}
