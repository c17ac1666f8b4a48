//! Option maps: validated against the documented keys of `api.rs`, converted with errors that
//! name the function, the key and what was expected.

use super::api::Key;
use crate::math::{Real, Vec3};
use crate::params::Param;
use rhai::{Array, Dynamic, EvalAltResult, FnPtr, Map};

pub type RhaiResult<T> = Result<T, Box<EvalAltResult>>;

/// A runtime error for the script (Rhai adds the call site's line and column).
pub fn err<T>(msg: impl Into<String>) -> RhaiResult<T> {
    Err(msg.into().into())
}

/// A float from an int or float value.
pub fn to_float(d: &Dynamic) -> Option<Real> {
    d.as_float()
        .ok()
        .or_else(|| d.as_int().ok().map(|i| i as Real))
}

/// A finite number (int or float) argument; the error names it by `what`. NaN and ±∞ are
/// refused here, at the call that takes them, not found later as a blown-up run.
pub fn num(d: &Dynamic, what: &str) -> RhaiResult<Real> {
    match to_float(d) {
        Some(x) if x.is_finite() => Ok(x),
        Some(x) => err(format!("{what}: expected a finite number, got {x}")),
        None => err(format!(
            "{what}: expected a number, got {} ({d})",
            d.type_name()
        )),
    }
}

/// Three finite numbers `[x, y, z]` (None for anything else, NaN and ±∞ included).
pub fn to_vec3(d: &Dynamic) -> Option<Vec3> {
    let a = d.read_lock::<Array>()?;
    if a.len() != 3 {
        return None;
    }
    let v = Vec3::new(to_float(&a[0])?, to_float(&a[1])?, to_float(&a[2])?);
    v.iter().all(|c| c.is_finite()).then_some(v)
}

/// What a value that is not a finite vector should have been, for messages.
fn vec3_expected(d: &Dynamic) -> &'static str {
    let non_finite = d.read_lock::<Array>().is_some_and(|a| {
        a.iter()
            .any(|c| to_float(c).is_some_and(|x| !x.is_finite()))
    });
    if non_finite {
        "an array of 3 finite numbers [x, y, z] (NaN and infinity are not allowed)"
    } else {
        "an array of 3 numbers [x, y, z]"
    }
}

pub fn vec3_arg(d: &Array, what: &str) -> RhaiResult<Vec3> {
    let dy = Dynamic::from_array(d.clone());
    to_vec3(&dy).map_or_else(
        || {
            err(format!(
                "{what}: expected {}, got {d:?}",
                vec3_expected(&dy)
            ))
        },
        Ok,
    )
}

pub fn vec3_to_array(v: Vec3) -> Array {
    vec![v.x.into(), v.y.into(), v.z.into()]
}

/// A validated options map of one function.
pub struct Opts {
    pub func: &'static str,
    /// For a map that is the value of a key of `func`'s options: that key (named in messages).
    pub within: Option<&'static str>,
    map: Map,
}

impl Opts {
    /// Check every key of `map` against `keys`; an unknown key is an error naming the allowed ones.
    pub fn new(func: &'static str, map: Map, keys: &[Key]) -> RhaiResult<Self> {
        Self::build(func, None, map, keys)
    }

    /// The options map given as key `within` of `func`'s options (messages say
    /// "func(): within: …").
    pub fn nested(
        func: &'static str,
        within: &'static str,
        map: Map,
        keys: &[Key],
    ) -> RhaiResult<Self> {
        Self::build(func, Some(within), map, keys)
    }

    fn build(
        func: &'static str,
        within: Option<&'static str>,
        map: Map,
        keys: &[Key],
    ) -> RhaiResult<Self> {
        let at = Self::place(func, within);
        for k in map.keys() {
            if !keys.iter().any(|key| key.name == k.as_str()) {
                let allowed: Vec<&str> = keys.iter().map(|k| k.name).collect();
                let hint = suggest(k, &allowed)
                    .map(|s| format!(" (did you mean '{s}'?)"))
                    .unwrap_or_default();
                return err(format!(
                    "{at}: unknown key '{k}'{hint}; allowed keys: {}",
                    allowed.join(", ")
                ));
            }
        }
        Ok(Opts { func, within, map })
    }

    /// The options of `func(law, #{ … })`: the keys of that law (and the function's common
    /// ones). A key of another law of the function says which laws take it.
    /// `doc` is the function's name in `api.rs` (`sim.contact_law`), `func` as messages say it.
    pub fn for_law(func: &'static str, doc: &str, law: &str, map: Map) -> RhaiResult<Self> {
        let keys = super::api::law_keys(doc, law).map_err(|e| format!("{func}(): {e}"))?;
        for k in map.keys() {
            if keys.iter().any(|key| key.name == k.as_str()) {
                continue;
            }
            let others = super::api::laws_taking(doc, k);
            if !others.is_empty() {
                let allowed: Vec<&str> = keys.iter().map(|k| k.name).collect();
                return err(format!(
                    "{func}(\"{law}\"): key '{k}' belongs to {}; \"{law}\" takes {}",
                    others
                        .iter()
                        .map(|o| format!("\"{o}\""))
                        .collect::<Vec<_>>()
                        .join(", "),
                    allowed.join(", ")
                ));
            }
        }
        Self::build(func, None, map, &keys)
    }

    fn place(func: &str, within: Option<&str>) -> String {
        match within {
            None => format!("{func}()"),
            Some(w) => format!("{func}(): {w}"),
        }
    }

    /// Where messages say an error is: "func()" or "func(): key".
    pub fn at(&self) -> String {
        Self::place(self.func, self.within)
    }

    pub fn has(&self, k: &str) -> bool {
        self.map.contains_key(k)
    }

    pub fn get(&self, k: &str) -> Option<&Dynamic> {
        self.map.get(k)
    }

    fn type_err<T>(&self, k: &str, expected: &str, v: &Dynamic) -> RhaiResult<T> {
        err(format!(
            "{}: key '{k}' must be {expected}, got {} ({v})",
            self.at(),
            v.type_name()
        ))
    }

    fn missing<T>(&self, k: &str) -> RhaiResult<T> {
        err(format!("{}: missing required key '{k}'", self.at()))
    }

    pub fn float(&self, k: &str) -> RhaiResult<Option<Real>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) => match to_float(v) {
                Some(x) if x.is_finite() => Ok(Some(x)),
                _ => self.type_err(k, "a finite number", v),
            },
        }
    }
    pub fn req_float(&self, k: &str) -> RhaiResult<Real> {
        self.float(k)?.map_or_else(|| self.missing(k), Ok)
    }
    pub fn positive(&self, k: &str) -> RhaiResult<Option<Real>> {
        match self.float(k)? {
            Some(x) if x <= 0.0 => err(format!("{}: key '{k}' must be > 0, got {x}", self.at())),
            o => Ok(o),
        }
    }
    /// The number given for a law's parameter (unchecked: the law checks it), for
    /// [`crate::params::Given`].
    pub fn given(&self, p: &Param) -> Result<Option<Real>, String> {
        self.float(p.name).map_err(|e| e.to_string())
    }
    /// A law's error, placed: "func(): message".
    pub fn error(&self, msg: String) -> Box<EvalAltResult> {
        format!("{}: {msg}", self.at()).into()
    }
    pub fn int(&self, k: &str) -> RhaiResult<Option<i64>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) => v
                .as_int()
                .map(Some)
                .or_else(|_| self.type_err(k, "an integer", v)),
        }
    }
    pub fn positive_int(&self, k: &str) -> RhaiResult<Option<u64>> {
        match self.int(k)? {
            Some(i) if i < 1 => err(format!("{}: key '{k}' must be ≥ 1, got {i}", self.at())),
            o => Ok(o.map(|i| i as u64)),
        }
    }
    pub fn string(&self, k: &str) -> RhaiResult<Option<String>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) if v.is_string() => Ok(Some(v.clone().into_string().unwrap())),
            Some(v) => self.type_err(k, "a string", v),
        }
    }
    /// The value of a key that names one of `options` (name, value); None when the key is
    /// absent. Any other string is an error listing the names:
    /// `func(): key "x" is not "a", "b" or "c"`.
    pub fn choice<T: Clone>(&self, k: &str, options: &[(&str, T)]) -> RhaiResult<Option<T>> {
        let Some(given) = self.string(k)? else {
            return Ok(None);
        };
        if let Some((_, v)) = options.iter().find(|(name, _)| *name == given) {
            return Ok(Some(v.clone()));
        }
        let names: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        let list = match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        };
        err(format!("{}: {k} \"{given}\" is not {list}", self.at()))
    }
    pub fn vec3(&self, k: &str) -> RhaiResult<Option<Vec3>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) => to_vec3(v)
                .map(Some)
                .map_or_else(|| self.type_err(k, vec3_expected(v), v), Ok),
        }
    }
    pub fn req_vec3(&self, k: &str) -> RhaiResult<Vec3> {
        self.vec3(k)?.map_or_else(|| self.missing(k), Ok)
    }
    pub fn fn_ptr(&self, k: &str) -> RhaiResult<Option<FnPtr>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) => v
                .clone()
                .try_cast::<FnPtr>()
                .map(Some)
                .map_or_else(|| self.type_err(k, "a closure |s| …", v), Ok),
        }
    }
    pub fn typed<T: Clone + 'static>(&self, k: &str, what: &str) -> RhaiResult<Option<T>> {
        match self.map.get(k) {
            None => Ok(None),
            Some(v) => v
                .clone()
                .try_cast::<T>()
                .map(Some)
                .map_or_else(|| self.type_err(k, what, v), Ok),
        }
    }
}

/// The allowed key closest to a misspelled one (edit distance ≤ 2).
pub fn suggest<'a>(k: &str, allowed: &[&'a str]) -> Option<&'a str> {
    allowed
        .iter()
        .map(|a| (edit_distance(k, a), *a))
        .filter(|(d, _)| *d <= 2)
        .min_by_key(|(d, _)| *d)
        .map(|(_, a)| a)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut cur = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            cur[j] = (prev[j] + 1)
                .min(cur[j - 1] + 1)
                .min(prev[j - 1] + usize::from(a[i - 1] != b[j - 1]));
        }
        prev = cur;
    }
    prev[b.len()]
}
