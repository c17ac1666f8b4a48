//! Script bindings of the section "Materials": `material(law, #{ … })` and its properties.

use super::opts::{err, Opts, RhaiResult};
use super::types::MaterialValue;
use crate::material::{Formulation, Material};
use rhai::{Engine, Map};
use std::sync::atomic::{AtomicU64, Ordering};

/// Identity of a script material value: a simulation adds each material once, however many
/// bodies use it (`SimState::material_ids`).
static MATERIAL_UID: AtomicU64 = AtomicU64::new(1);

pub fn register(engine: &mut Engine) {
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
            let o = Opts::for_law("material", "material", law, m)?;
            let material =
                Material::from_params(formulation, &|p| o.given(p)).map_err(|e| o.error(e))?;
            Ok(MaterialValue {
                uid: MATERIAL_UID.fetch_add(1, Ordering::Relaxed),
                material,
            })
        },
    );
    engine.register_get("young", |m: &mut MaterialValue| m.material.young);
    engine.register_get("poisson", |m: &mut MaterialValue| m.material.poisson);
    engine.register_get("c10", |m: &mut MaterialValue| m.material.c10());
    engine.register_get("c01", |m: &mut MaterialValue| m.material.c01);
    engine.register_get("bulk", |m: &mut MaterialValue| m.material.bulk());
    engine.register_get("density", |m: &mut MaterialValue| m.material.density);
    engine.register_get("viscosity", |m: &mut MaterialValue| m.material.viscosity);
    engine.register_get("law", |m: &mut MaterialValue| {
        m.material.formulation.name().to_string()
    });
}
