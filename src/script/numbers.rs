//! Numbers for people: one formatter, [`sig`], for what the CLI prints (the run summary and
//! progress line, `fdem check`'s model line) and for scripts through `fmt(x, digits [, unit])`.
//! Files (CSV, VTK) are not written with it: they keep every digit.

use rhai::{Array, Dynamic, Engine, EvalAltResult, Position};

/// `x` with `digits` significant digits (at least 1), trailing zeros dropped:
/// fixed notation when the rounded value lies in 1e-3 ≤ |x| < 1e6 (`157`, `0.0010013`,
/// `123500`), scientific outside (`1.5e-7`, `2.4e12`); `0`, `NaN`, `inf`, `-inf`.
/// Rounded once, to nearest (an exact tie to even), by Rust's `{:e}` formatting.
pub fn sig(x: f64, digits: usize) -> String {
    if x.is_nan() {
        return "NaN".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let digits = digits.clamp(1, 17);
    // Rounding to `digits` places happens once, here; the rest only moves the decimal point.
    let sci = format!("{:.*e}", digits - 1, x.abs());
    let (mantissa, exp) = sci.split_once('e').expect("Rust's {:e} has an exponent");
    let exp: i32 = exp.parse().expect("integer exponent");
    let d: String = mantissa.chars().filter(|c| *c != '.').collect();
    let sign = if x < 0.0 { "-" } else { "" };
    if !(-3..6).contains(&exp) {
        // Only the mantissa is trimmed: "3.50e-10" is 3.5e-10, not 3.5e-1.
        return format!("{sign}{}e{exp}", trim_zeros(mantissa));
    }
    let body = {
        let n = d.len() as i32;
        if exp < 0 {
            format!("0.{}{d}", "0".repeat((-exp - 1) as usize))
        } else if exp >= n - 1 {
            format!("{d}{}", "0".repeat((exp - (n - 1)) as usize))
        } else {
            let (int, frac) = d.split_at(exp as usize + 1);
            format!("{int}.{frac}")
        }
    };
    format!("{sign}{}", trim_zeros(&body))
}

/// Drop trailing zeros after a decimal point (and the point itself if nothing is left).
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

fn digits_of(digits: i64) -> Result<usize, Box<EvalAltResult>> {
    if (1..=17).contains(&digits) {
        Ok(digits as usize)
    } else {
        Err(EvalAltResult::ErrorRuntime(
            format!("fmt(): digits must be 1 to 17, got {digits}").into(),
            Position::NONE,
        )
        .into())
    }
}

/// A number (float or int) or an array of numbers, formatted.
fn fmt_dynamic(x: &Dynamic, digits: usize) -> Result<String, Box<EvalAltResult>> {
    if let Ok(f) = x.as_float() {
        Ok(sig(f, digits))
    } else if let Ok(i) = x.as_int() {
        Ok(sig(i as f64, digits))
    } else if x.is_array() {
        let a = x.clone().cast::<Array>();
        let parts: Result<Vec<String>, _> = a.iter().map(|v| fmt_dynamic(v, digits)).collect();
        Ok(format!("[{}]", parts?.join(", ")))
    } else {
        Err(EvalAltResult::ErrorRuntime(
            format!(
                "fmt(): expected a number or an array of numbers, got {} ({x})",
                x.type_name()
            )
            .into(),
            Position::NONE,
        )
        .into())
    }
}

fn with_unit(s: String, unit: &str) -> String {
    if unit.is_empty() {
        s
    } else {
        format!("{s} {unit}")
    }
}

/// Register `fmt(x, digits)` and `fmt(x, digits, unit)` (x a float, an int or an array of them).
pub fn register(engine: &mut Engine) {
    engine.register_fn(
        "fmt",
        |x: Dynamic, digits: i64| -> Result<String, Box<EvalAltResult>> {
            fmt_dynamic(&x, digits_of(digits)?)
        },
    );
    engine.register_fn(
        "fmt",
        |x: Dynamic, digits: i64, unit: &str| -> Result<String, Box<EvalAltResult>> {
            Ok(with_unit(fmt_dynamic(&x, digits_of(digits)?)?, unit))
        },
    );
}

#[cfg(test)]
mod tests {
    use super::sig;

    #[test]
    fn significant_digits_for_people() {
        let cases: &[(f64, usize, &str)] = &[
            (0.0, 4, "0"),
            (-0.0, 4, "0"),
            (157.00000000001262, 4, "157"),
            (157.00000000001262, 6, "157"),
            (156.96, 4, "157"),
            (156.94, 4, "156.9"),
            (1.0013e-3, 5, "0.0010013"),
            (1.0013e-3 * 1e3, 5, "1.0013"),
            (0.8489137679457158, 4, "0.8489"),
            (-0.8489137679457158, 4, "-0.8489"),
            (-4.688569061739284, 4, "-4.689"),
            (0.009000000000000001, 4, "0.009"),
            (0.0009999999999999998, 4, "0.001"),
            (0.000999, 3, "9.99e-4"),
            (1e-12, 4, "1e-12"),
            // The exponent keeps its zeros (it used to lose them: 3.86e-10 printed 3.86e-1).
            (3.86e-10, 3, "3.86e-10"),
            (-5.0e-20, 3, "-5e-20"),
            (2.5e10, 3, "2.5e10"),
            (-2.195451e-6, 5, "-2.1955e-6"),
            (1e12, 4, "1e12"),
            (2.4343e12, 3, "2.43e12"),
            (999_999.4, 4, "1e6"),
            (999_999.4, 7, "999999.4"),
            (123_456.7, 4, "123500"),
            (3535.5339059327375, 5, "3535.5"),
            (40.0, 4, "40"),
            (10.011982328539627, 4, "10.01"),
            (1.0, 1, "1"),
            (0.95, 1, "0.9"), // 0.95 is 0.9499999… in binary
            (9.6, 1, "10"),
            (f64::NAN, 4, "NaN"),
            (f64::INFINITY, 4, "inf"),
            (f64::NEG_INFINITY, 4, "-inf"),
            (f64::MAX, 3, "1.8e308"),
            (f64::MIN_POSITIVE, 3, "2.23e-308"),
            (5e-324, 3, "4.94e-324"),
            (0.1 + 0.2, 17, "0.30000000000000004"),
            (2.5, 0, "2"), // digits below 1 count as 1; an exact tie rounds to even
            (0.125, 2, "0.12"),
            (0.375, 2, "0.38"),
        ];
        for &(x, n, want) in cases {
            assert_eq!(sig(x, n), want, "sig({x:e}, {n})");
        }
    }

    #[test]
    fn never_a_long_run_of_digits() {
        // Whatever the value, at most `n` digits are printed (plus zeros that place the point).
        let mut x = 1.234_567_890_123e-9_f64;
        while x < 1e9 {
            for v in [x, -x, x * 7.77, 1.0 / x] {
                let s = sig(v, 5);
                let digits = s
                    .split('e')
                    .next()
                    .unwrap()
                    .trim_start_matches(['-', '0', '.'])
                    .chars()
                    .filter(char::is_ascii_digit)
                    .count();
                assert!(digits <= 6, "sig({v:e}, 5) = {s}");
                assert!(s.len() <= 12, "sig({v:e}, 5) = {s}");
            }
            x *= 3.3;
        }
    }
}
