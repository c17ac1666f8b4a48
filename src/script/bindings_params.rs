//! Script bindings of the section "Parameters and checks": `params` (with the `--set`
//! overrides of the command line) and the self-checks `expect_within`, `expect_near`.

use super::numbers::sig;
use super::opts::{err, num, suggest, RhaiResult};
use super::ScriptContext;
use crate::math::Real;
use rhai::{Dynamic, Engine, Map};
use std::rc::Rc;

pub fn register(engine: &mut Engine, ctx: Rc<ScriptContext>) {
    let c = ctx.clone();
    engine.register_fn("params", move |defaults: Map| params(&c, defaults));
    let c = ctx.clone();
    engine.register_fn(
        "expect_within",
        move |label: &str, value: Dynamic, lo: Dynamic, hi: Dynamic| -> RhaiResult<()> {
            // Under `fdem check`, and while a restart replays the script up to its
            // checkpoint (the run that wrote it got past this check).
            if c.options.check_only || c.replaying() {
                return Ok(());
            }
            let (v, lo, hi) = (num(&value, label)?, num(&lo, "low")?, num(&hi, "high")?);
            if v >= lo && v <= hi {
                c.say(&format!(
                    "check ok: {label} = {} in [{}, {}]",
                    sig(v, 7),
                    sig(lo, 7),
                    sig(hi, 7)
                ));
                Ok(())
            } else {
                err(format!(
                    "self-check failed: {label} = {}, expected within [{}, {}]",
                    sig(v, 7),
                    sig(lo, 7),
                    sig(hi, 7)
                ))
            }
        },
    );
    let c = ctx;
    engine.register_fn(
        "expect_near",
        move |label: &str, value: Dynamic, reference: Dynamic, tol: Dynamic| -> RhaiResult<()> {
            // Under `fdem check`, and while a restart replays the script up to its
            // checkpoint (the run that wrote it got past this check).
            if c.options.check_only || c.replaying() {
                return Ok(());
            }
            let (v, r, tol) = (
                num(&value, label)?,
                num(&reference, "reference")?,
                num(&tol, "rel_tol")?,
            );
            let rel = (v - r).abs() / r.abs().max(Real::MIN_POSITIVE);
            if rel <= tol {
                c.say(&format!(
                    "check ok: {label} = {} vs {} (rel. error {} ≤ {})",
                    sig(v, 7),
                    sig(r, 7),
                    sig(rel, 3),
                    sig(tol, 2)
                ));
                Ok(())
            } else {
                err(format!(
                    "self-check failed: {label} = {}, reference {}: relative error {} > {}",
                    sig(v, 7),
                    sig(r, 7),
                    sig(rel, 4),
                    sig(tol, 2)
                ))
            }
        },
    );
}

/// `params(#{ … })`: the defaults with every `--set name=value` applied.
fn params(c: &ScriptContext, defaults: Map) -> RhaiResult<Map> {
    if c.params_called.replace(true) {
        return err("params() may be called only once per script");
    }
    let mut out = defaults.clone();
    for (k, raw) in &c.options.overrides {
        let Some(default) = defaults.get(k.as_str()) else {
            let mut names: Vec<&str> = defaults.keys().map(|k| k.as_str()).collect();
            names.sort_unstable();
            let hint = suggest(k, &names)
                .map(|s| format!(" (did you mean '{s}'?)"))
                .unwrap_or_default();
            return err(format!(
                "--set {k}={raw}: the script has no parameter '{k}'{hint}; its parameters are: {}",
                names.join(", ")
            ));
        };
        out.insert(k.as_str().into(), override_value(k, raw, default)?);
    }
    Ok(out)
}

/// The text `raw` of `--set k=raw` parsed with the type of the parameter's default.
fn override_value(k: &str, raw: &str, default: &Dynamic) -> RhaiResult<Dynamic> {
    Ok(if default.is_bool() {
        match raw {
            "true" => true.into(),
            "false" => false.into(),
            _ => {
                return err(format!(
                    "--set {k}={raw}: '{k}' is a bool (default {default}); use true or false"
                ))
            }
        }
    } else if default.is_int() {
        match raw.parse::<i64>() {
            Ok(i) => i.into(),
            Err(_) => {
                return err(format!(
                    "--set {k}={raw}: '{k}' is an integer (default {default})"
                ))
            }
        }
    } else if default.is_float() {
        match raw.parse::<f64>() {
            Ok(x) => x.into(),
            Err(_) => {
                return err(format!(
                    "--set {k}={raw}: '{k}' is a number (default {default})"
                ))
            }
        }
    } else if default.is_string() {
        raw.to_string().into()
    } else {
        return err(format!(
            "--set {k}={raw}: parameter '{k}' has type {} which --set cannot override",
            default.type_name()
        ));
    })
}
