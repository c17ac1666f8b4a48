//! Script bindings of the mesh generators: meshing cylinders and spheres, discs, hollow
//! cylinders, notched beams, and the masonry assemblies (arch, wall, dome, cloister vault) that
//! `sim.add_blocks` turns into one body per block.

use super::api::keys_of;
use super::opts::{err, Opts, RhaiResult};
use super::types::{BodyHandle, MaterialValue, MeshValue, SimHandle};
use crate::math::{Real, Vec3};
use crate::mesh::masonry::{self, Assembly};
use crate::mesh::solids::{self, NotchedBeam};
use crate::mesh::{cells, packing};
use crate::mesh::{Mesh, Quality, Region};
use crate::state::Layout;
use rhai::{Array, Dynamic, Engine, Map};
use std::f64::consts::PI;
use std::rc::Rc;

/// Blocks from `arch(..)`, `wall(..)`, `dome(..)` or `cloister_vault(..)`.
#[derive(Clone, Debug)]
pub struct AssemblyValue(pub Rc<Assembly>);

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<AssemblyValue>("Assembly");
    engine.register_fn("to_string", |a: &mut AssemblyValue| {
        format!(
            "Assembly({}, {} blocks in {} courses, {} tets)",
            a.0.kind,
            a.0.blocks.len(),
            a.0.courses,
            a.0.n_tets()
        )
    });
    engine.register_fn("disc", disc);
    engine.register_fn("hollow_cylinder", hollow_cylinder);
    engine.register_fn("notched_beam", notched_beam);
    engine.register_fn("biconcave_cell", biconcave_cell);
    engine.register_fn("random_packing", random_packing);
    engine.register_fn("arch", arch);
    engine.register_fn("wall", wall);
    engine.register_fn("dome", dome);
    engine.register_fn("cloister_vault", cloister_vault);
    engine.register_fn("len", |a: &mut AssemblyValue| a.0.blocks.len() as i64);
    engine.register_get("n_blocks", |a: &mut AssemblyValue| a.0.blocks.len() as i64);
    engine.register_get("n_courses", |a: &mut AssemblyValue| a.0.courses as i64);
    engine.register_get("n_tets", |a: &mut AssemblyValue| a.0.n_tets() as i64);
    engine.register_get("volume", |a: &mut AssemblyValue| a.0.volume());
    engine.register_get("kind", |a: &mut AssemblyValue| a.0.kind.to_string());
    engine.register_fn(
        "block",
        |a: &mut AssemblyValue, i: i64| -> RhaiResult<Map> {
            let b = block_at(a, i)?;
            let mut m = Map::new();
            m.insert("index".into(), (b.index as i64).into());
            m.insert("course".into(), (b.course as i64).into());
            m.insert("springer".into(), b.springer.into());
            m.insert(
                "mesh".into(),
                Dynamic::from(MeshValue(Rc::new(b.mesh.clone()))),
            );
            Ok(m)
        },
    );
    engine.register_fn(
        "mesh",
        |a: &mut AssemblyValue, i: i64| -> RhaiResult<MeshValue> {
            Ok(MeshValue(Rc::new(block_at(a, i)?.mesh.clone())))
        },
    );
    engine.register_fn("quality", |a: &mut AssemblyValue| {
        a.0.quality().map(quality_map).unwrap_or_default()
    });
    engine.register_fn("quality", |m: &mut MeshValue| {
        m.0.quality().map(quality_map).unwrap_or_default()
    });
    engine.register_fn(
        "add_blocks",
        |s: &mut SimHandle, a: AssemblyValue, mat: MaterialValue| add_blocks(s, a, mat, None),
    );
    engine.register_fn(
        "add_blocks",
        |s: &mut SimHandle, a: AssemblyValue, mat: MaterialValue, o: Map| {
            add_blocks(s, a, mat, Some(o))
        },
    );
}

fn block_at(a: &AssemblyValue, i: i64) -> RhaiResult<&masonry::Block> {
    let n = a.0.blocks.len();
    if i < 0 || i as usize >= n {
        return err(format!(
            "block(): index {i} is out of range; the {} has {n} blocks (0..{})",
            a.0.kind,
            n.saturating_sub(1)
        ));
    }
    Ok(&a.0.blocks[i as usize])
}

fn quality_map(q: Quality) -> Map {
    let mut m = Map::new();
    m.insert("min_dihedral".into(), q.min_dihedral_deg.into());
    m.insert("max_dihedral".into(), q.max_dihedral_deg.into());
    m.insert("max_aspect_ratio".into(), q.max_aspect_ratio.into());
    m.insert("mean_aspect_ratio".into(), q.mean_aspect_ratio.into());
    m
}

/// `func(): message` for generator errors.
fn gen<T>(func: &str, r: Result<T, String>) -> RhaiResult<T> {
    r.map_err(|e| format!("{func}(): {e}").into())
}

fn req_positive(o: &Opts, k: &str) -> RhaiResult<Real> {
    o.positive(k)?.map_or_else(
        || err(format!("{}(): missing required key '{k}'", o.func)),
        Ok,
    )
}

fn axis_of(o: &Opts) -> RhaiResult<Vec3> {
    let axis = o.vec3("axis")?.unwrap_or_else(Vec3::z);
    if axis.norm() == 0.0 {
        return err(format!("{}(): 'axis' must not be zero", o.func));
    }
    Ok(axis.normalize())
}

fn count(o: &Opts, k: &str, min: i64) -> RhaiResult<usize> {
    match o.int(k)? {
        None => err(format!("{}(): missing required key '{k}'", o.func)),
        Some(v) if v < min => err(format!("{}(): key '{k}' must be ≥ {min}, got {v}", o.func)),
        Some(v) if v as u64 > masonry::MAX_COUNT as u64 => err(format!(
            "{}(): key '{k}' must be ≤ {}, got {v}",
            o.func,
            masonry::MAX_COUNT
        )),
        Some(v) => Ok(v as usize),
    }
}

/// Mesh a cylinder or sphere region (`shape.mesh(#{ size })`).
pub fn mesh_region(region: &Region, o: &Opts) -> RhaiResult<MeshValue> {
    for k in ["divisions", "pattern"] {
        if o.has(k) {
            return err(format!(
                "mesh(): '{k}' applies to boxes; a {} takes 'size'",
                region.kind()
            ));
        }
    }
    let mesh = match region {
        Region::Cylinder {
            base,
            axis,
            radius,
            length,
        } => {
            let h = o.positive("size")?.unwrap_or(radius / 5.0);
            let mut m = gen("mesh", solids::cylinder(*radius, *length, h))?;
            solids::place_on_axis(&mut m, *base, *axis);
            m
        }
        Region::Sphere { center, radius } => {
            let h = o.positive("size")?.unwrap_or(radius / 8.0);
            let mut m = gen("mesh", solids::sphere(*radius, h))?;
            m.translate(*center);
            m
        }
        other => {
            return err(format!(
                "mesh(): a {} is a selection region only; meshable shapes are box, cylinder and sphere (and the generators disc, hollow_cylinder, notched_beam, arch, wall, dome, cloister_vault)",
                other.kind()
            ))
        }
    };
    Ok(MeshValue(Rc::new(mesh)))
}

fn disc(m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("disc", m, keys_of("disc"))?;
    let radius = req_positive(&o, "radius")?;
    let thickness = req_positive(&o, "thickness")?;
    let h = o.positive("size")?.unwrap_or(radius / 5.0);
    let axis = axis_of(&o)?;
    let center = o.vec3("center")?.unwrap_or_default();
    let mut mesh = gen("disc", solids::cylinder(radius, thickness, h))?;
    solids::place_on_axis(&mut mesh, center - 0.5 * thickness * axis, axis);
    Ok(MeshValue(Rc::new(mesh)))
}

fn biconcave_cell(m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("biconcave_cell", m, keys_of("biconcave_cell"))?;
    let d = cells::EvansFung::HUMAN;
    let shape = cells::EvansFung {
        radius: o.positive("radius")?.unwrap_or(d.radius),
        c0: o.float("c0")?.unwrap_or(d.c0),
        c1: o.float("c1")?.unwrap_or(d.c1),
        c2: o.float("c2")?.unwrap_or(d.c2),
    };
    let h = o.positive("size")?.unwrap_or(shape.radius / 3.0);
    let axis = axis_of(&o)?;
    let mut mesh = gen("biconcave_cell", cells::biconcave_cell(&shape, h))?;
    solids::place_on_axis(&mut mesh, o.vec3("center")?.unwrap_or_default(), axis);
    Ok(MeshValue(Rc::new(mesh)))
}

fn random_packing(mesh: MeshValue, m: Map) -> RhaiResult<AssemblyValue> {
    let o = Opts::new("random_packing", m, keys_of("random_packing"))?;
    let count = count(&o, "count", 1)?;
    let seed = o.int("seed")?.unwrap_or(1);
    let attempts = match o.int("attempts")? {
        None => count.saturating_mul(100),
        Some(a) if a >= 1 => a as usize,
        Some(a) => {
            return err(format!(
                "random_packing(): key 'attempts' must be ≥ 1, got {a}"
            ))
        }
    };
    let p = packing::Placement {
        count,
        min: o.req_vec3("min")?,
        max: o.req_vec3("max")?,
        gap: o.float("gap")?.unwrap_or(0.0),
        rotate: o.typed::<bool>("rotate", "true or false")?.unwrap_or(true),
        seed: seed as u64,
        max_attempts: attempts,
    };
    Ok(AssemblyValue(Rc::new(gen(
        "random_packing",
        packing::random_packing(&mesh.0, &p),
    )?)))
}

fn hollow_cylinder(m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("hollow_cylinder", m, keys_of("hollow_cylinder"))?;
    let ri = req_positive(&o, "inner_radius")?;
    let ro = req_positive(&o, "outer_radius")?;
    let length = req_positive(&o, "length")?;
    let h = o
        .positive("size")?
        .unwrap_or(((ro - ri).abs() / 3.0).min(PI * (ri + ro) / 32.0));
    let axis = axis_of(&o)?;
    let mut mesh = gen(
        "hollow_cylinder",
        solids::hollow_cylinder(ri, ro, length, h),
    )?;
    solids::place_on_axis(&mut mesh, o.vec3("base")?.unwrap_or_default(), axis);
    Ok(MeshValue(Rc::new(mesh)))
}

fn notched_beam(m: Map) -> RhaiResult<MeshValue> {
    let o = Opts::new("notched_beam", m, keys_of("notched_beam"))?;
    let length = req_positive(&o, "length")?;
    let height = req_positive(&o, "height")?;
    let b = NotchedBeam {
        length,
        height,
        width: req_positive(&o, "width")?,
        notch_depth: req_positive(&o, "notch_depth")?,
        notch_width: req_positive(&o, "notch_width")?,
        span: o.positive("span")?.unwrap_or(0.8 * length),
    };
    let h = o
        .positive("size")?
        .unwrap_or((height / 10.0).min(2.5 * b.notch_width));
    let mut mesh = gen("notched_beam", solids::notched_beam(&b, h))?;
    mesh.translate(o.vec3("origin")?.unwrap_or_default());
    Ok(MeshValue(Rc::new(mesh)))
}

fn finish(a: Assembly, shift: Option<Vec3>) -> AssemblyValue {
    let mut a = a;
    if let Some(d) = shift {
        for b in &mut a.blocks {
            b.mesh.translate(d);
        }
    }
    AssemblyValue(Rc::new(a))
}

fn arch(m: Map) -> RhaiResult<AssemblyValue> {
    let o = Opts::new("arch", m, keys_of("arch"))?;
    let a = masonry::Arch {
        radius: req_positive(&o, "radius")?,
        thickness: req_positive(&o, "thickness")?,
        depth: req_positive(&o, "depth")?,
        voussoirs: count(&o, "voussoirs", 3)?,
        span_angle: o.float("span_angle")?.unwrap_or(180.0),
    };
    let h = o.positive("size")?.unwrap_or(a.thickness / 3.0);
    Ok(finish(
        gen("arch", masonry::arch(&a, h))?,
        o.vec3("center")?,
    ))
}

fn wall(m: Map) -> RhaiResult<AssemblyValue> {
    let o = Opts::new("wall", m, keys_of("wall"))?;
    let brick = o.vec3("brick")?.map_or_else(
        || err("wall(): missing required key 'brick' ([length, height, width])"),
        Ok,
    )?;
    let w = masonry::Wall {
        courses: count(&o, "courses", 1)?,
        bricks_per_course: count(&o, "bricks_per_course", 1)?,
        brick: [brick.x, brick.y, brick.z],
        head_gap: o.float("head_gap")?.unwrap_or(0.0),
        bed_gap: o.float("bed_gap")?.unwrap_or(0.0),
    };
    let h = o.positive("size")?.unwrap_or(0.5 * brick.min());
    Ok(finish(
        gen("wall", masonry::wall(&w, h))?,
        o.vec3("origin")?,
    ))
}

fn dome(m: Map) -> RhaiResult<AssemblyValue> {
    let o = Opts::new("dome", m, keys_of("dome"))?;
    let d = masonry::Dome {
        radius: req_positive(&o, "radius")?,
        thickness: req_positive(&o, "thickness")?,
        courses: count(&o, "courses", 1)?,
        blocks_per_course: count(&o, "blocks_per_course", 3)?,
        oculus: o.float("oculus")?.unwrap_or(10.0),
        base: o.float("base")?.unwrap_or(90.0),
    };
    let h = o.positive("size")?.unwrap_or(d.thickness / 2.0);
    Ok(finish(
        gen("dome", masonry::dome(&d, h))?,
        o.vec3("center")?,
    ))
}

fn cloister_vault(m: Map) -> RhaiResult<AssemblyValue> {
    let o = Opts::new("cloister_vault", m, keys_of("cloister_vault"))?;
    let span = req_positive(&o, "span")?;
    let thickness = req_positive(&o, "thickness")?;
    let ribs = if o.typed::<bool>("ribs", "true or false")?.unwrap_or(false) {
        Some(masonry::Ribs {
            width: o.positive("rib_width")?,
            depth: o.positive("rib_depth")?.unwrap_or(thickness),
        })
    } else {
        if let Some(k) = ["rib_width", "rib_depth"].into_iter().find(|k| o.has(k)) {
            return err(format!(
                "cloister_vault(): key '{k}' applies only with 'ribs: true'"
            ));
        }
        None
    };
    let profile = match o.string("profile")?.as_deref() {
        None => masonry::ProfileOn::default(),
        Some(x) => masonry::ProfileOn::from_name(x).map_or_else(
            || {
                err(format!(
                    "cloister_vault(): profile \"{x}\" is not \"corners\" or \"webs\""
                ))
            },
            Ok,
        )?,
    };
    let v = masonry::CloisterVault {
        span,
        thickness,
        courses: count(&o, "courses", 1)?,
        blocks_per_web: count(&o, "blocks_per_web", 1)?,
        profile_ratio: o.float("profile_ratio")?.unwrap_or(0.8),
        profile,
        oculus: o.float("oculus")?.unwrap_or(span / 8.0),
        ribs,
    };
    let h = o.positive("size")?.unwrap_or(thickness / 2.0);
    Ok(finish(
        gen("cloister_vault", masonry::cloister_vault(&v, h))?,
        o.vec3("center")?,
    ))
}

fn add_blocks(
    s: &mut SimHandle,
    a: AssemblyValue,
    mat: MaterialValue,
    o: Option<Map>,
) -> RhaiResult<Array> {
    let o = Opts::new(
        "add_blocks",
        o.unwrap_or_default(),
        keys_of("sim.add_blocks"),
    )?;
    let layout = o
        .choice("layout", super::bindings_bodies::LAYOUTS)?
        .unwrap_or(Layout::Continuous);
    let prefix = o.string("prefix")?.unwrap_or_else(|| "block".into());
    let mut st = s.0.borrow_mut();
    if st.sim.step > 0 {
        return err("add_blocks(): bodies must be added before the first step");
    }
    let mid = match st.material_ids.get(&mat.uid) {
        Some(&id) => id,
        None => {
            let id = st.sim.add_material(mat.material.clone());
            st.material_ids.insert(mat.uid, id);
            id
        }
    };
    let mut ids = Vec::with_capacity(a.0.blocks.len());
    for (i, b) in a.0.blocks.iter().enumerate() {
        let mesh: &Mesh = &b.mesh;
        ids.push(
            st.sim
                .add_body(&format!("{prefix}_{i}"), mesh, mid, layout)
                .map_err(|e| format!("add_blocks(): {e}"))?,
        );
    }
    drop(st);
    Ok(ids
        .into_iter()
        .map(|id| Dynamic::from(BodyHandle { sim: s.clone(), id }))
        .collect())
}
