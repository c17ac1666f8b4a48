//! Script bindings of the section "Bodies and selections": adding, copying and placing
//! bodies, their properties, and node, element and face selections (named mesh sets are in
//! `bindings_mesh_io.rs`). The geometry is computed by the core (`Simulation::translate_body`,
//! `rotate_body`, `body_volume`, `body_mass`, `select_boundary`, `mesh::FaceFilter`).

use super::api::keys_of;
use super::bindings_geometry::rotation_opts;
use super::opts::{err, vec3_arg, Opts, RhaiResult};
use super::types::*;
use crate::mesh::{face_nodes, faces_area, FaceFilter};
use crate::state::Layout;
use rhai::{Array, Dynamic, Engine, Map};
use std::rc::Rc;

/// The values of a body's `layout` key.
pub const LAYOUTS: &[(&str, Layout)] = &[
    ("continuous", Layout::Continuous),
    ("jointed", Layout::Jointed),
    ("rigid", Layout::Rigid),
];

pub fn register(engine: &mut Engine) {
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
    engine.register_fn("copy", copy_body);
    engine.register_fn(
        "translate",
        |b: &mut BodyHandle, d: Array| -> RhaiResult<()> {
            let d = vec3_arg(&d, "translate()")?;
            let mut st = b.sim.0.borrow_mut();
            st.sim
                .translate_body(b.id, d)
                .map_err(|e| e.to_string().into())
        },
    );
    engine.register_fn("rotate", |b: &mut BodyHandle, o: Map| -> RhaiResult<()> {
        let (axis, angle, center) = rotation_opts(o)?;
        drop(b.sim.current());
        let mut st = b.sim.0.borrow_mut();
        st.sim
            .rotate_body(b.id, axis, angle, center)
            .map_err(|e| e.to_string().into())
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
        b.sim.0.borrow().sim.body_volume(b.id)
    });
    engine.register_get("mass", |b: &mut BodyHandle| {
        b.sim.0.borrow().sim.body_mass(b.id)
    });
    register_selections(engine);
}

/// Node, element and face selections, and their unions.
fn register_selections(engine: &mut Engine) {
    engine.register_fn("nodes", |b: &mut BodyHandle| {
        let st = b.sim.0.borrow();
        let ids = st.sim.bodies[b.id].nodes.clone().map(|n| n as u32);
        NodeSet(Rc::new(ids.collect()), st.owner.clone())
    });
    engine.register_fn("nodes", |b: &mut BodyHandle, r: Shape| {
        let st = b.sim.0.borrow();
        NodeSet(Rc::new(st.sim.nodes_in(&r.0, Some(b.id))), st.owner.clone())
    });
    engine.register_fn("nodes", |s: &mut SimHandle, r: Shape| {
        let st = s.0.borrow();
        NodeSet(Rc::new(st.sim.nodes_in(&r.0, None)), st.owner.clone())
    });
    engine.register_fn("elements", |b: &mut BodyHandle| {
        let st = b.sim.0.borrow();
        let ids = st.sim.bodies[b.id].tets.clone().map(|e| e as u32);
        ElementSet(Rc::new(ids.collect()), st.owner.clone())
    });
    engine.register_fn("elements", |b: &mut BodyHandle, r: Shape| {
        let st = b.sim.0.borrow();
        ElementSet(Rc::new(st.sim.tets_in(&r.0, Some(b.id))), st.owner.clone())
    });
    engine.register_fn("boundary", |b: &mut BodyHandle| boundary(b, Map::new()));
    engine.register_fn("boundary", boundary);
    engine.register_fn("nodes", |f: &mut FaceSet| {
        NodeSet(Rc::new(face_nodes(&f.faces)), f.owner.clone())
    });
    engine.register_get("area", |f: &mut FaceSet| f.area);
    engine.register_fn("len", |f: &mut FaceSet| f.faces.len() as i64);
    engine.register_fn("len", |n: &mut NodeSet| n.0.len() as i64);
    engine.register_fn("len", |n: &mut ElementSet| n.0.len() as i64);
    engine.register_fn("+", |a: NodeSet, b: NodeSet| -> RhaiResult<NodeSet> {
        b.1.check(&a.1, "nodes + nodes", "the right-hand nodes")?;
        Ok(NodeSet(Rc::new(union(&a.0, &b.0)), a.1))
    });
    engine.register_fn(
        "+",
        |a: ElementSet, b: ElementSet| -> RhaiResult<ElementSet> {
            b.1.check(&a.1, "elements + elements", "the right-hand elements")?;
            Ok(ElementSet(Rc::new(union(&a.0, &b.0)), a.1))
        },
    );
}

/// `sim.add_body(name, mesh, material [, #{ layout }])`; the material is added to the
/// simulation on its first use.
fn add_body(
    s: &mut SimHandle,
    name: &str,
    mesh: MeshValue,
    mat: MaterialValue,
    o: Option<Map>,
) -> RhaiResult<BodyHandle> {
    let layout = match o {
        None => Layout::Continuous,
        Some(m) => Opts::new("add_body", m, keys_of("sim.add_body"))?
            .choice("layout", LAYOUTS)?
            .unwrap_or(Layout::Continuous),
    };
    let per_tet = match layout {
        Layout::Jointed => crate::limits::JOINTED_BYTES_PER_TET,
        _ => crate::limits::CONTINUOUS_BYTES_PER_TET,
    };
    let n = mesh.0.tets.len() as f64;
    crate::limits::check_memory(
        &format!("body '{name}' ({n} tets, {})", layout.name()),
        n * per_tet,
    )
    .map_err(|e| format!("add_body(): {e}"))?;
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

/// `body.copy(name)`: a new body with the same mesh (at its current reference placement),
/// material and layout.
fn copy_body(b: &mut BodyHandle, name: &str) -> RhaiResult<BodyHandle> {
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
    let layout = Map::from_iter([("layout".into(), Dynamic::from(layout.name().to_string()))]);
    add_body(
        &mut b.sim.clone(),
        name,
        MeshValue(Rc::new(mesh)),
        mat_uid_material,
        Some(layout),
    )
}

/// `body.boundary([#{ normal, tolerance, within }])`: the body's outer faces that pass the
/// filter, with their reference area.
fn boundary(b: &mut BodyHandle, m: Map) -> RhaiResult<FaceSet> {
    let o = Opts::new("boundary", m, keys_of("body.boundary"))?;
    let filter = FaceFilter {
        normal: o.vec3("normal")?,
        tolerance: o.float("tolerance")?.unwrap_or(1.0).to_radians(),
        within: o.typed::<Shape>("within", "a shape")?.map(|s| s.0),
    };
    let st = b.sim.0.borrow();
    let faces = st.sim.select_boundary(b.id, &filter);
    let area = faces_area(&faces, &st.sim.nodes.x0);
    Ok(FaceSet {
        faces: Rc::new(faces),
        area,
        owner: st.owner.clone(),
    })
}
