//! Script bindings of the section "Simulation": creating a model, its integration and
//! damping options, and running it in stages (the run loop is in `runner.rs`).

use super::api::keys_of;
use super::opts::{err, Opts, RhaiResult};
use super::runner;
use super::types::{SimHandle, SimState};
use super::ScriptContext;
use crate::io::VtkSeries;
use crate::material::StressMeasure;
use crate::pipeline::Simulation;
use rhai::{Engine, Map, NativeCallContext};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("simulation", move |m: Map| simulation(&c, m));
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
}

/// `simulation(#{ … })`: an empty model with its output settings, kept in the script context
/// so that its output is finished even after an error.
fn simulation(c: &ScriptContext, m: Map) -> RhaiResult<SimHandle> {
    let o = Opts::new("simulation", m, keys_of("simulation"))?;
    let name = o.string("name")?.unwrap_or_else(|| c.script_stem());
    if name.is_empty() || name.contains(['/', '\\']) {
        return err(format!(
            "simulation(): name '{name}' must be non-empty and contain no path separators"
        ));
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
            || {
                err(format!(
                    "simulation(): stress_output '{s}' is not one of \"cauchy\", \"pk1\", \"pk2\""
                ))
            },
            Ok,
        )?,
    };
    let vtk_encoding = match o.string("vtk_encoding")?.as_deref() {
        None | Some("raw") => crate::io::vtu::Encoding::Raw,
        Some("base64") => crate::io::vtu::Encoding::Base64,
        Some(x) => {
            return err(format!(
                "simulation(): vtk_encoding '{x}' is not \"raw\" or \"base64\""
            ))
        }
    };
    let handle = SimHandle(Rc::new(RefCell::new(SimState {
        sim,
        owner: super::types::Owner::new(&name),
        vtk_encoding,
        vtk: VtkSeries::new(out_dir.clone(), name.clone()),
        cracks_vtk: VtkSeries::new(out_dir.clone(), format!("{name}_cracks")),
        bars_vtk: VtkSeries::new(out_dir.clone(), format!("{name}_bars")),
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
        balance_warned: false,
    })));
    c.sims.borrow_mut().push(handle.clone());
    Ok(handle)
}
