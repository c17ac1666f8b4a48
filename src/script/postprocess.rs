//! Post-processing of a sampled history (t, y): the measurements every validation script
//! otherwise writes by hand — extremes and when they happen, the value at a time, the first
//! time a level is crossed, and least-squares straight lines over a time window. Pure
//! functions over slices (the monitor bindings in `bindings_hooks.rs` call them), so they are
//! tested here without a simulation.
//!
//! Conventions: `t` increases (monitors record in time order; equal times are allowed);
//! between samples a history is linear; NaN values are skipped by the extremes.

/// Index of the sample that maximises `key(y)` (the first one on ties); None when there is
/// no finite value.
fn arg_best(y: &[f64], key: impl Fn(f64) -> f64) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (i, &v) in y.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        let k = key(v);
        if best.is_none_or(|(_, b)| k > b) {
            best = Some((i, k));
        }
    }
    best.map(|(i, _)| i)
}

/// Index of the largest value (first on ties).
pub fn argmax(y: &[f64]) -> Option<usize> {
    arg_best(y, |v| v)
}

/// Index of the smallest value (first on ties).
pub fn argmin(y: &[f64]) -> Option<usize> {
    arg_best(y, |v| -v)
}

/// Index of the value of largest magnitude |y| (first on ties).
pub fn argmax_abs(y: &[f64]) -> Option<usize> {
    arg_best(y, f64::abs)
}

/// The history's value at time `at`, linear between samples. Outside [t₀, t_last] (or for an
/// empty history) an error that says the recorded range.
pub fn value_at(t: &[f64], y: &[f64], at: f64) -> Result<f64, String> {
    let (Some(&first), Some(&last)) = (t.first(), t.last()) else {
        return Err("the history is empty (nothing recorded yet)".into());
    };
    let slack = 1e-12 * (last - first).abs().max(last.abs());
    if !(at >= first - slack && at <= last + slack) {
        return Err(format!(
            "t = {at} s lies outside the recorded times [{first}, {last}] s"
        ));
    }
    // First sample at or after `at`.
    let j = t.partition_point(|&ti| ti < at);
    if j == 0 {
        return Ok(y[0]);
    }
    if j >= t.len() {
        return Ok(y[t.len() - 1]);
    }
    let (t0, t1) = (t[j - 1], t[j]);
    if t1 == t0 {
        return Ok(y[j]);
    }
    let w = (at - t0) / (t1 - t0);
    Ok(y[j - 1] + w * (y[j] - y[j - 1]))
}

/// Which way a crossing must go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// From below the level to at or above it.
    Up,
    /// From above the level to at or below it.
    Down,
    /// Either.
    Any,
}

impl Direction {
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "up" => Ok(Direction::Up),
            "down" => Ok(Direction::Down),
            "any" => Ok(Direction::Any),
            _ => Err(format!(
                "direction \"{s}\" is not \"up\", \"down\" or \"any\""
            )),
        }
    }
}

/// The first time the history reaches `level` going in `dir`, interpolated linearly between
/// the two samples that straddle it. A history that starts exactly at the level crosses it at
/// t₀ for `Any`; `Up` and `Down` need a sample on the other side first. None when it never
/// does.
pub fn first_crossing(t: &[f64], y: &[f64], level: f64, dir: Direction) -> Option<f64> {
    if y.first().is_some_and(|&v| v == level) && dir == Direction::Any {
        return Some(t[0]);
    }
    for i in 1..y.len() {
        let (a, b) = (y[i - 1], y[i]);
        let up = a < level && b >= level;
        let down = a > level && b <= level;
        let hit = match dir {
            Direction::Up => up,
            Direction::Down => down,
            Direction::Any => up || down,
        };
        if hit {
            let w = (level - a) / (b - a);
            return Some(t[i - 1] + w * (t[i] - t[i - 1]));
        }
    }
    None
}

/// A least-squares straight line y ≈ intercept + slope·t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFit {
    pub slope: f64,
    pub intercept: f64,
    /// Coefficient of determination R² (1 for points on a line; 1 also when y is constant).
    pub r2: f64,
    /// Samples used.
    pub n: usize,
}

/// Least-squares line through the samples with t0 ≤ t ≤ t1. Needs at least two samples at
/// different times in the window; otherwise an error saying how many there were.
pub fn fit_line(t: &[f64], y: &[f64], t0: f64, t1: f64) -> Result<LineFit, String> {
    if t1 < t0 {
        return Err(format!("the window [{t0}, {t1}] s is empty (t1 < t0)"));
    }
    let pts: Vec<(f64, f64)> = t
        .iter()
        .zip(y)
        .filter(|(&ti, &yi)| ti >= t0 && ti <= t1 && yi.is_finite())
        .map(|(&ti, &yi)| (ti, yi))
        .collect();
    let n = pts.len();
    if n < 2 {
        return Err(format!(
            "{n} sample(s) in the window [{t0}, {t1}] s; a straight line needs at least 2 (record more often with `every`, or widen the window)"
        ));
    }
    // Centred sums (stable for times far from zero).
    let tm = pts.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let ym = pts.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let (mut stt, mut sty, mut syy) = (0.0, 0.0, 0.0);
    for &(ti, yi) in &pts {
        let (dt, dy) = (ti - tm, yi - ym);
        stt += dt * dt;
        sty += dt * dy;
        syy += dy * dy;
    }
    if stt == 0.0 {
        return Err(format!(
            "the {n} samples in the window [{t0}, {t1}] s all have the same time"
        ));
    }
    let slope = sty / stt;
    let intercept = ym - slope * tm;
    let r2 = if syy == 0.0 {
        1.0
    } else {
        (sty * sty / (stt * syy)).clamp(0.0, 1.0)
    };
    Ok(LineFit {
        slope,
        intercept,
        r2,
        n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extremes_of_a_compression_history() {
        // A platen pushing in: the reaction is negative, its magnitude peaks at t = 2.
        let y = [0.0, -1.0, -3.0, -2.0, 0.5];
        assert_eq!(argmax(&y), Some(4));
        assert_eq!(argmin(&y), Some(2));
        assert_eq!(argmax_abs(&y), Some(2));
        assert_eq!(argmax(&[]), None);
        assert_eq!(argmax(&[f64::NAN, 1.0]), Some(1));
        // Ties: the first.
        assert_eq!(argmax(&[1.0, 2.0, 2.0]), Some(1));
    }

    #[test]
    fn value_at_interpolates_and_refuses_outside() {
        let t = [0.0, 1.0, 2.0];
        let y = [0.0, 10.0, 30.0];
        assert_eq!(value_at(&t, &y, 0.5).unwrap(), 5.0);
        assert_eq!(value_at(&t, &y, 1.5).unwrap(), 20.0);
        assert_eq!(value_at(&t, &y, 2.0).unwrap(), 30.0);
        assert_eq!(value_at(&t, &y, 0.0).unwrap(), 0.0);
        let e = value_at(&t, &y, 2.5).unwrap_err();
        assert!(e.contains("outside the recorded times [0, 2]"), "{e}");
        assert!(value_at(&[], &[], 0.0).unwrap_err().contains("empty"));
    }

    #[test]
    fn crossings_are_interpolated_and_directed() {
        // sin-like history sampled coarsely.
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [0.0, 1.0, 0.0, -1.0, 0.0];
        assert_eq!(first_crossing(&t, &y, 0.5, Direction::Up), Some(0.5));
        assert_eq!(first_crossing(&t, &y, 0.5, Direction::Down), Some(1.5));
        assert_eq!(first_crossing(&t, &y, -0.5, Direction::Any), Some(2.5));
        assert_eq!(first_crossing(&t, &y, 2.0, Direction::Any), None);
        // A history starting at the level: `any` says t₀, `up` waits for a real crossing.
        assert_eq!(first_crossing(&t, &y, 0.0, Direction::Any), Some(0.0));
        assert_eq!(first_crossing(&t, &y, 0.0, Direction::Up), Some(4.0));
    }

    #[test]
    fn line_fit_recovers_a_line_and_ignores_samples_outside_the_window() {
        // y = 3 + 2t on [1, 5], garbage outside.
        let t: Vec<f64> = (0..=10).map(|i| i as f64).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (1.0..=5.0).contains(&x) {
                    3.0 + 2.0 * x
                } else {
                    1e6
                }
            })
            .collect();
        let f = fit_line(&t, &y, 1.0, 5.0).unwrap();
        assert!((f.slope - 2.0).abs() < 1e-12);
        assert!((f.intercept - 3.0).abs() < 1e-12);
        assert!((f.r2 - 1.0).abs() < 1e-12);
        assert_eq!(f.n, 5);
        // Far from zero in time (a stage late in a run): centred sums stay exact.
        let t2: Vec<f64> = (0..5).map(|i| 1.0e6 + 1e-3 * i as f64).collect();
        let y2: Vec<f64> = t2.iter().map(|&x| 7.0 * (x - 1.0e6)).collect();
        let f2 = fit_line(&t2, &y2, 0.0, 2.0e6).unwrap();
        assert!((f2.slope - 7.0).abs() < 1e-6, "{}", f2.slope);
        // Noise lowers R².
        let f3 = fit_line(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 0.0, 1.0], 0.0, 3.0).unwrap();
        assert!(f3.r2 < 0.5);
        let e = fit_line(&t, &y, 1.5, 1.9).unwrap_err();
        assert!(e.contains("0 sample(s)"), "{e}");
    }
}
