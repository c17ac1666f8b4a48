//! The script API and its documentation agree: every function the engine registers is
//! documented in `src/script/api.rs` and every documented one is registered; every name a
//! binding asks the table for exists; every parameter a law declares changes the law it
//! builds (a documented key the law ignored would fail here). The reference page itself is
//! checked against `fdem doc` in tests/scripts.rs, and every documented key is exercised by
//! a script there (`every_documented_key_is_accepted`).

use fdem::params::{Given, Param};
use fdem::script::api::API;
use std::collections::BTreeSet;
use std::rc::Rc;

/// Functions the engine registers: names from Rhai's signatures, without operators, property
/// getters and setters, indexers and the generic `to_string`.
fn registered() -> BTreeSet<String> {
    let ctx = Rc::new(fdem::script::ScriptContext::new(
        Default::default(),
        "api_test.rhai".into(),
    ));
    let engine = fdem::script::build_engine(ctx);
    engine
        .gen_fn_signatures(false)
        .into_iter()
        .filter_map(|sig| {
            let name = sig.split('(').next()?.trim().to_string();
            let name = name.rsplit(' ').next()?.to_string();
            let plain = name.chars().all(|c| c.is_alphanumeric() || c == '_');
            (plain && !name.starts_with("get$") && !name.starts_with("set$") && name != "to_string")
                .then_some(name)
        })
        .collect()
}

/// The function names a documentation entry covers: the last segment of its name
/// (`sim.run` → `run`) and every `word(` of its signature and summary (entries that document
/// several functions, such as a monitor's methods, name them there).
fn documented() -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for f in API {
        out.insert(f.name.rsplit('.').next().unwrap().to_string());
        let sig = format!("{} {}", f.signature, f.summary);
        for (i, _) in sig.match_indices('(') {
            let word: String = sig[..i]
                .chars()
                .rev()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect::<String>()
                .chars()
                .rev()
                .collect();
            if !word.is_empty() {
                out.insert(word);
            }
        }
    }
    out
}

#[test]
fn every_registered_function_is_documented() {
    let reg = registered();
    let doc = documented();
    let missing: Vec<&String> = reg.iter().filter(|n| !doc.contains(*n)).collect();
    assert!(
        missing.is_empty(),
        "registered script functions with no entry in src/script/api.rs: {missing:?}"
    );
}

#[test]
fn every_documented_function_is_registered() {
    let reg = registered();
    // Entries that are not functions of their own: operators, properties and map keys.
    let not_functions = ["set + set", "s.time", "friction_law"];
    let missing: Vec<&str> = API
        .iter()
        .filter(|f| !not_functions.contains(&f.name))
        .map(|f| f.name)
        .filter(|n| !reg.contains(n.rsplit('.').next().unwrap()))
        .collect();
    assert!(
        missing.is_empty(),
        "documented in src/script/api.rs but not registered: {missing:?}"
    );
}

/// Every `keys_of("…")`, `doc_of("…")` and `for_law(…, "…", …)` name in the script layer is
/// an entry of the table (a miss would panic at run time).
#[test]
fn every_name_the_bindings_ask_for_is_documented() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/script");
    let mut asked = Vec::new();
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "rs") || p.ends_with("api.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        for pat in ["keys_of(\"", "doc_of(\""] {
            for (i, _) in text.match_indices(pat) {
                let rest = &text[i + pat.len()..];
                asked.push(rest[..rest.find('"').unwrap()].to_string());
            }
        }
        for (i, _) in text.match_indices("Opts::for_law(") {
            // for_law(label, doc, …): the second string is the table's name.
            let args: Vec<&str> = text[i..].split('"').collect();
            asked.push(args[3].to_string());
        }
    }
    assert!(asked.len() > 20, "found only {asked:?}");
    for name in &asked {
        assert!(
            API.iter().any(|f| f.name == name),
            "a binding asks for '{name}', which src/script/api.rs does not document"
        );
    }
}

/// Values for a law's parameters: `base` for each, except `name` which gets `other`.
fn given_with<'a>(
    base: &'a dyn Fn(&Param) -> f64,
    name: Option<&'a str>,
    other: f64,
) -> impl Fn(&Param) -> Result<Option<f64>, String> + 'a {
    move |p: &Param| Ok(Some(if Some(p.name) == name { other } else { base(p) }))
}

/// A value inside the parameter's range, and a second, different one.
fn two_values(p: &Param) -> (f64, f64) {
    let r = p.range;
    let (lo, hi) = (r.lo.max(-1e3), r.hi.min(1e3));
    if lo.is_finite() && hi.is_finite() && hi - lo < 10.0 {
        (lo + 0.25 * (hi - lo), lo + 0.5 * (hi - lo))
    } else if lo.is_finite() {
        (lo + 2.0, lo + 3.0)
    } else {
        (2.0, 3.0)
    }
}

/// Build a law from values for every numeric parameter, then once more with each parameter
/// changed: the law must change (compared through its Debug form). A declared parameter the
/// law never reads fails here.
fn every_parameter_changes<T: std::fmt::Debug>(
    law: &str,
    params: &[Param],
    build: impl Fn(Given) -> Result<T, String>,
) {
    let base = |p: &Param| two_values(p).0;
    let reference = format!("{:?}", build(&given_with(&base, None, 0.0)).unwrap());
    let mut checked = 0;
    for p in params.iter().filter(|p| p.kind == "float") {
        let changed = build(&given_with(&base, Some(p.name), two_values(p).1))
            .unwrap_or_else(|e| panic!("{law}: {e}"));
        assert_ne!(
            format!("{changed:?}"),
            reference,
            "{law}: parameter '{}' is declared but does not change the law",
            p.name
        );
        checked += 1;
    }
    assert!(checked > 0, "{law}: no numeric parameter");
}

#[test]
fn every_declared_law_parameter_changes_its_law() {
    use fdem::joints::law::{given_penalties, Calibration, Cohesive, Softening};
    use fdem::material::{Formulation, Material, MATERIAL_PARAMS};
    every_parameter_changes("material", MATERIAL_PARAMS, |g| {
        Material::from_params(Formulation::NeoHookean, g)
    });
    every_parameter_changes(
        "elastic/mooney_rivlin",
        fdem::material::MOONEY_RIVLIN_PARAMS,
        |g| Material::from_params(Formulation::MooneyRivlin, g),
    );
    for law in fdem::joints::law::JOINT_LAWS {
        every_parameter_changes(law.name, law.params, |g| {
            let pen = given_penalties(g)?;
            let coh = match law.name {
                "cohesive/munjiza" | "cohesive/linear" => Some(Cohesive::from_params(
                    Softening::Munjiza,
                    Calibration::Exact,
                    g,
                )?),
                _ => None,
            };
            Ok((coh, pen))
        });
    }
    for law in fdem::contact_interaction::CONTACT_LAWS {
        every_parameter_changes(law.name, law.params, |g| {
            fdem::contact_interaction::PotentialContact::from_params(g, None)
        });
    }
}

/// Out-of-range values are refused by the law with the parameter, its range and unit.
#[test]
fn laws_refuse_values_outside_their_declared_ranges() {
    use fdem::material::{Formulation, Material};
    let g = |p: &Param| -> Result<Option<f64>, String> {
        Ok(Some(match p.name {
            "poisson" => 0.5,
            "viscosity" => 0.0,
            _ => 1.0,
        }))
    };
    let e = Material::from_params(Formulation::SmallStrain, &g).unwrap_err();
    assert_eq!(e, "poisson must lie in (-1, 0.5), got 0.5");
    let g = |p: &Param| -> Result<Option<f64>, String> {
        Ok(Some(if p.name == "damping" { 1.5 } else { 1.0 }))
    };
    let e = fdem::contact_interaction::PotentialContact::from_params(&g, None).unwrap_err();
    assert_eq!(e, "damping must lie in [0, 1], got 1.5");
    let none = |_: &Param| -> Result<Option<f64>, String> { Ok(None) };
    let e = fdem::joints::law::Cohesive::from_params(
        fdem::joints::law::Softening::Linear,
        fdem::joints::law::Calibration::Exact,
        &none,
    )
    .unwrap_err();
    assert_eq!(e, "missing required key 'tensile_strength'");
}

/// The documented contact-penalty default is the one the code uses (it is generated from the
/// same constant): 10 × E of the stiffer material.
#[test]
fn documented_penalty_defaults_are_the_code_defaults() {
    use fdem::contact_interaction::{ContactLaws, ContactRule, PotentialContact};
    let reference = fdem::script::api::markdown();
    assert!(reference
        .contains("| `penalty` | float | Pa | 10 × Young's modulus E of the stiffer material |"));
    let mut laws = ContactLaws::default();
    laws.rules
        .push(ContactRule::from(PotentialContact::default()));
    laws.resolve(&[1.0e9, 3.0e9]);
    assert_eq!(laws.props_of(0, 1).penalty, 10.0 * 3.0e9);
    let (pn, pt) = fdem::joints::law::penalties_or_default((None, None), 2.0e9);
    assert_eq!((pn, pt), (2.0e10, 2.0e10));
    assert!(reference
        .contains("| `normal_penalty` | float | Pa | 10 × Young's modulus E of the body |"));
}
