//! `sim.bring_to_rest(#{ … })`: a dynamic-relaxation stage. The model runs with
//! mass-proportional damping until its kinetic energy stays below a fraction of the work
//! done on it, or a step cap is reached (then a warning says so and how far it got). Without
//! a given damping α the stage estimates the lowest mode from the Rayleigh quotient of the
//! current displacement, ω² ≈ 2U / Σ m|u|², and damps it critically, α = 2ω, updating the
//! estimate at every check (Underwood's adaptive dynamic relaxation in its simplest form).

use super::api::keys_of;
use super::checkpoint::{self, RestRecord};
use super::numbers::sig;
use super::opts::{err, Opts, RhaiResult};
use super::runner;
use super::types::SimHandle;
use super::ScriptContext;
use crate::math::Real;
use crate::pipeline::Simulation;
use crate::state::Layout;
use rhai::{Engine, Map, NativeCallContext};
use std::cell::Cell;
use std::rc::Rc;

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    engine.register_fn(
        "bring_to_rest",
        move |nc: NativeCallContext, s: &mut SimHandle, m: Map| -> RhaiResult<Map> {
            bring_to_rest(&nc, &ctx, s, m)
        },
    );
}

/// The Rayleigh-quotient estimate ω² ≈ 2U/Σ m|x − X|² of the lowest mode from the
/// displacement of the deformable nodes; None before anything moved.
pub fn rayleigh_omega(sim: &Simulation) -> Option<Real> {
    let u = sim.strain_energy_now();
    let mut mu2 = 0.0;
    for n in 0..sim.nodes.len() {
        if sim.bodies[sim.nodes.body[n] as usize].layout == Layout::Rigid {
            continue;
        }
        mu2 += sim.nodes.m[n] * (sim.nodes.x[n] - sim.nodes.x0[n]).norm_squared();
    }
    (u > 0.0 && mu2 > 0.0).then(|| (2.0 * u / mu2).sqrt())
}

/// What the stop rule measures at a check: kinetic energy [J] and the work it is compared
/// with [J]: the larger of |external work| (last energy sample) and the strain energy now.
fn measure(sim: &Simulation) -> (Real, Real) {
    let ke = sim.kinetic_energy_now();
    let w = sim
        .energy
        .external_work()
        .abs()
        .max(sim.strain_energy_now());
    (ke, w)
}

fn bring_to_rest(
    nc: &NativeCallContext,
    ctx: &ScriptContext,
    s: &mut SimHandle,
    m: Map,
) -> RhaiResult<Map> {
    let o = Opts::new("bring_to_rest", m, keys_of("sim.bring_to_rest"))?;
    let ratio = o.positive("ratio")?.unwrap_or(1e-6);
    let max_steps = o.positive_int("max_steps")?.unwrap_or(200_000);
    let check_every = o.positive_int("check_every")?.unwrap_or(50);
    let fixed = o.float("damping")?;
    if let Some(a) = fixed {
        if a <= 0.0 {
            return err(format!("bring_to_rest(): damping must be > 0, got {a}"));
        }
    }
    let (before, start_step, name) = {
        drop(s.current());
        let mut st = s.0.borrow_mut();
        st.sim
            .prepare()
            .map_err(|e| format!("bring_to_rest(): {e}"))?;
        let before = st.sim.settings.mass_damping;
        // Start with the given α, or the estimate from the displacement so far (if any), or
        // the damping the model already had.
        st.sim.settings.mass_damping = fixed
            .or_else(|| rayleigh_omega(&st.sim).map(|w| 2.0 * w))
            .unwrap_or(before);
        (before, st.sim.step, st.name.clone())
    };
    let last = Rc::new(Cell::new((0.0, 0.0)));
    let seen = last.clone();
    let mut below = 0;
    let stop = Box::new(move |sim: &mut Simulation| {
        // (Every rank checks at the same steps: a collective on a decomposed model.)
        sim.synchronize_nodes();
        let (ke, w) = measure(sim);
        seen.set((ke, w));
        if fixed.is_none() {
            if let Some(w) = rayleigh_omega(sim) {
                sim.settings.mass_damping = 2.0 * w;
            }
        }
        // Twice in a row: a turning point of an oscillation has zero kinetic energy too.
        below = if ke <= ratio * w { below + 1 } else { 0 };
        below >= 2
    });
    let result = runner::run_native(nc, ctx, s, max_steps, check_every, stop);
    let mut st = s.0.borrow_mut();
    let alpha = st.sim.settings.mass_damping;
    st.sim.settings.mass_damping = before;
    let Some(converged) = result? else {
        // A restart skipped this call: return what it returned in the run that wrote the
        // checkpoint (nothing is printed while the script replays).
        let r = checkpoint::recorded_rest(ctx, st.runs).unwrap_or(RestRecord {
            runs: st.runs,
            converged: true,
            steps: 0,
            time: st.sim.time,
            kinetic: 0.0,
            work: 0.0,
            ratio: 0.0,
            damping: alpha,
        });
        return Ok(rest_map(&r));
    };
    let (ke, w) = last.get();
    let achieved = if w > 0.0 { ke / w } else { 0.0 };
    let steps = st.sim.step - start_step;
    if converged {
        ctx.say(&format!(
            "[{name}] at rest after {steps} steps (t = {} s): kinetic energy {} J = {} of the work {} J (α = {} 1/s)",
            sig(st.sim.time, 6),
            sig(ke, 3),
            sig(achieved, 3),
            sig(w, 4),
            sig(alpha, 4)
        ));
    } else {
        ctx.say(&format!(
            "[{name}] WARNING: not at rest after {steps} steps (t = {} s): kinetic energy {} J is {} of the work {} J, above the ratio {} asked (α = {} 1/s). Raise max_steps, give a damping α ≈ 2ω₁, or check for motion that never stops (a prescribed velocity, a body sliding or falling freely)",
            sig(st.sim.time, 6),
            sig(ke, 3),
            sig(achieved, 3),
            sig(w, 4),
            sig(ratio, 3),
            sig(alpha, 4)
        ));
    }
    let record = RestRecord {
        runs: st.runs,
        converged,
        steps,
        time: st.sim.time,
        kinetic: ke,
        work: w,
        ratio: achieved,
        damping: alpha,
    };
    st.rest_results.push(record.clone());
    Ok(rest_map(&record))
}

/// `bring_to_rest`'s result as the script sees it.
fn rest_map(r: &RestRecord) -> Map {
    let mut out = Map::new();
    out.insert("converged".into(), r.converged.into());
    out.insert("steps".into(), (r.steps as i64).into());
    out.insert("time".into(), r.time.into());
    out.insert("kinetic".into(), r.kinetic.into());
    out.insert("work".into(), r.work.into());
    out.insert("ratio".into(), r.ratio.into());
    out.insert("damping".into(), r.damping.into());
    out
}
