//! Parameters as laws declare them: name, unit, default, allowed range, meaning.
//!
//! Every material, joint, contact and friction law lists its parameters once, beside the law
//! (`material::MATERIAL_PARAMS`, `joints::law::COHESIVE_PARAMS`, …). The script layer
//! validates option maps against these lists, `fdem doc` and `docs/script-reference.md` print
//! them, and a Rust user reads the same defaults and ranges: a documented default cannot
//! drift from the one the code uses, because the code takes it from here.

use crate::math::Real;

/// What a parameter is when it is not given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DefaultValue {
    /// It must be given.
    Required,
    /// This value.
    Value(Real),
    /// `factor` × a quantity of the model, named by `of` ("10 × Young's modulus E of the
    /// stiffer material").
    Scaled { factor: Real, of: &'static str },
    /// Described in words (derived from other parameters or from the model).
    Text(&'static str),
}

/// Allowed values of a numeric parameter: `lo`/`hi` bounds, each closed or open; infinite
/// bounds for none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub lo: Real,
    pub hi: Real,
    pub lo_open: bool,
    pub hi_open: bool,
}

impl Range {
    /// Any finite number.
    pub const ANY: Range = Range::new(Real::NEG_INFINITY, Real::INFINITY, true, true);
    /// x > 0.
    pub const POSITIVE: Range = Range::new(0.0, Real::INFINITY, true, true);
    /// x ≥ 0.
    pub const NON_NEGATIVE: Range = Range::new(0.0, Real::INFINITY, false, true);

    pub const fn new(lo: Real, hi: Real, lo_open: bool, hi_open: bool) -> Range {
        Range {
            lo,
            hi,
            lo_open,
            hi_open,
        }
    }

    /// `x` is finite and within the range.
    pub fn contains(&self, x: Real) -> bool {
        x.is_finite()
            && (if self.lo_open {
                x > self.lo
            } else {
                x >= self.lo
            })
            && (if self.hi_open {
                x < self.hi
            } else {
                x <= self.hi
            })
    }

    /// "> 0", "≥ 0", "[0, 90)", "(-1, 0.5)", or "" for any number.
    pub fn text(&self) -> String {
        match (self.lo.is_finite(), self.hi.is_finite()) {
            (false, false) => String::new(),
            (true, false) => format!("{} {}", if self.lo_open { ">" } else { "≥" }, self.lo),
            (false, true) => format!("{} {}", if self.hi_open { "<" } else { "≤" }, self.hi),
            (true, true) => format!(
                "{}{}, {}{}",
                if self.lo_open { "(" } else { "[" },
                self.lo,
                self.hi,
                if self.hi_open { ")" } else { "]" }
            ),
        }
    }
}

/// One parameter (a key of a script options map).
#[derive(Clone, Copy, Debug)]
pub struct Param {
    pub name: &'static str,
    /// Value type in scripts: "float", "int", "bool", "string", "vec3", "map", "table|float",
    /// "closure", "shape", …
    pub kind: &'static str,
    /// SI unit ("-" for a ratio, "" for none).
    pub unit: &'static str,
    pub default: DefaultValue,
    /// Allowed values (numbers only).
    pub range: Range,
    /// Meaning.
    pub doc: &'static str,
}

impl Param {
    /// A number.
    pub const fn float(
        name: &'static str,
        unit: &'static str,
        default: DefaultValue,
        range: Range,
        doc: &'static str,
    ) -> Param {
        Param {
            name,
            kind: "float",
            unit,
            default,
            range,
            doc,
        }
    }

    /// A key of another kind, with its default in words.
    pub const fn other(
        name: &'static str,
        kind: &'static str,
        unit: &'static str,
        default: &'static str,
        doc: &'static str,
    ) -> Param {
        Param {
            name,
            kind,
            unit,
            default: DefaultValue::Text(default),
            range: Range::ANY,
            doc,
        }
    }

    /// `x` if it lies in the range, else the error "`name` must be > 0 Pa, got -1".
    pub fn check(&self, x: Real) -> Result<Real, String> {
        if self.range.contains(x) {
            return Ok(x);
        }
        let unit = match self.unit {
            "" | "-" => String::new(),
            u => format!(" {u}"),
        };
        let r = &self.range;
        let what = if r.lo.is_finite() && r.hi.is_finite() {
            format!("lie in {}{unit}", r.text())
        } else if r.lo.is_finite() || r.hi.is_finite() {
            format!("be {}{unit}", r.text())
        } else {
            "be a finite number".to_string()
        };
        Err(format!("{} must {what}, got {x}", self.name))
    }

    /// The value to use when the parameter is not given: `Value(v)` gives v, `Scaled` gives
    /// factor × `scale_of` (the quantity it names); None for `Required` and `Text`.
    pub fn default_value(&self, scale_of: Real) -> Option<Real> {
        match self.default {
            DefaultValue::Value(v) => Some(v),
            DefaultValue::Scaled { factor, .. } => Some(factor * scale_of),
            DefaultValue::Required | DefaultValue::Text(_) => None,
        }
    }

    /// The default as the reference shows it.
    pub fn default_text(&self) -> String {
        match self.default {
            DefaultValue::Required => "required".into(),
            DefaultValue::Value(v) => format!("{v}"),
            DefaultValue::Scaled { factor, of } => format!("{factor} × {of}"),
            DefaultValue::Text(t) => t.into(),
        }
    }
}

/// A law in a registry: its name in scripts, what it is, and its parameters.
#[derive(Clone, Copy, Debug)]
pub struct LawParams {
    pub name: &'static str,
    pub summary: &'static str,
    pub params: &'static [Param],
}

/// The values a law is built from: for each declared parameter, the number given (None:
/// not given). The script layer reads them from an options map; a Rust user passes a closure.
pub type Given<'a> = &'a dyn Fn(&Param) -> Result<Option<Real>, String>;

/// Parameter `name` of the list `params` from `given`: checked against its range, with its
/// default (`Value`, or `Scaled` by `scale_of`) when not given; None when not given and the
/// default is in words (the law derives it); an error when it is required.
pub fn value(
    params: &'static [Param],
    name: &str,
    given: Given,
    scale_of: Real,
) -> Result<Option<Real>, String> {
    let p = find(params, name).unwrap_or_else(|| panic!("'{name}' is not a declared parameter"));
    match given(p)? {
        Some(x) => p.check(x).map(Some),
        None => match p.default {
            DefaultValue::Required => Err(format!("missing required key '{}'", p.name)),
            _ => Ok(p.default_value(scale_of)),
        },
    }
}

/// [`value`] for a parameter that always has a value (required, or a numeric default).
pub fn value_of(params: &'static [Param], name: &str, given: Given) -> Result<Real, String> {
    value(params, name, given, Real::NAN)?.ok_or_else(|| format!("'{name}' has no numeric default"))
}

/// The parameter `name` of `params` (a law's list).
pub fn find(params: &'static [Param], name: &str) -> Option<&'static Param> {
    params.iter().find(|p| p.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_check_and_describe_themselves() {
        let p = Param::float("young", "Pa", DefaultValue::Required, Range::POSITIVE, "");
        assert_eq!(p.check(2.0), Ok(2.0));
        assert_eq!(p.check(0.0).unwrap_err(), "young must be > 0 Pa, got 0");
        assert!(p.check(Real::NAN).is_err() && p.check(Real::INFINITY).is_err());
        let nu = Param::float(
            "poisson",
            "-",
            DefaultValue::Required,
            Range::new(-1.0, 0.5, true, true),
            "",
        );
        assert_eq!(
            nu.check(0.5).unwrap_err(),
            "poisson must lie in (-1, 0.5), got 0.5"
        );
        assert_eq!(nu.check(-0.99), Ok(-0.99));
        let phi = Param::float(
            "friction_angle",
            "°",
            DefaultValue::Value(30.0),
            Range::new(0.0, 90.0, false, true),
            "",
        );
        assert_eq!(phi.check(0.0), Ok(0.0));
        assert_eq!(
            phi.check(90.0).unwrap_err(),
            "friction_angle must lie in [0, 90) °, got 90"
        );
        assert_eq!(phi.default_value(1.0), Some(30.0));
        let pen = Param::float(
            "penalty",
            "Pa",
            DefaultValue::Scaled {
                factor: 10.0,
                of: "E",
            },
            Range::POSITIVE,
            "",
        );
        assert_eq!(pen.default_value(2e9), Some(2e10));
        assert_eq!(pen.default_text(), "10 × E");
        assert_eq!(Range::NON_NEGATIVE.text(), "≥ 0");
        assert_eq!(Range::ANY.text(), "");
    }
}
