//! Script bindings of the section "Geometry and meshes": shapes (which are also selection
//! regions), meshing a box, explicit tet meshes, and moving meshes. Meshing the other shapes
//! is in `bindings_generators.rs`, importing and transforming meshes in `bindings_mesh_io.rs`.

use super::api::keys_of;
use super::opts::{err, to_vec3, vec3_arg, Opts, RhaiResult};
use super::types::{MeshValue, Shape};
use crate::math::{Real, Vec3};
use crate::mesh::{box_mesh_with, divisions_for, BoxPattern, Mesh, Region};
use rhai::{Array, Engine, Map};
use std::rc::Rc;

pub fn register(engine: &mut Engine) {
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
    engine.register_fn("mesh", mesh_shape);
    engine.register_fn("tet_mesh", tet_mesh);
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

/// `shape.mesh(#{ … })`: a structured box mesh by `size` or `divisions`; other shapes are
/// meshed by the generators.
fn mesh_shape(s: &mut Shape, m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("mesh", m, keys_of("shape.mesh"))?;
    let Region::Box { min, max } = s.0 else {
        return super::bindings_generators::mesh_region(&s.0, &o);
    };
    let divisions = match (o.positive("size")?, o.get("divisions")) {
        (Some(_), Some(_)) => return err("mesh(): give either 'size' or 'divisions', not both"),
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
    // In floating point: 4 194 304³ cells must not wrap around to a small number.
    let cells: f64 = divisions.iter().map(|&n| n as f64).product();
    if cells > 50.0e6 {
        return err(format!(
            "mesh(): {cells:.4e} cells ({:.4e} tets) is too many (the limit is 5e7 cells); use a larger size",
            6.0 * cells
        ));
    }
    crate::limits::check_tets(6.0 * cells).map_err(|e| format!("mesh(): {e}"))?;
    let pattern = o
        .choice(
            "pattern",
            &[
                ("kuhn", BoxPattern::Kuhn),
                ("alternating", BoxPattern::Alternating),
            ],
        )?
        .unwrap_or(BoxPattern::Kuhn);
    Ok(MeshValue(Rc::new(box_mesh_with(
        min, max, divisions, pattern,
    ))))
}

/// `tet_mesh(#{ nodes, tets })`: a mesh from explicit nodes and tetrahedra.
fn tet_mesh(m: Map) -> RhaiResult<MeshValue> {
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
}

/// The options of `mesh.rotate` and `body.rotate`: (axis, angle [rad], center [m]).
pub(super) fn rotation_opts(m: Map) -> RhaiResult<(Vec3, Real, Vec3)> {
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
