//! Functions of time for loads and prescribed motion.

use crate::math::Real;

/// A scalar function of time: a constant or a piecewise-linear table (held constant beyond
/// its ends).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum TimeFunction {
    Constant(Real),
    Table { t: Vec<Real>, value: Vec<Real> },
}

impl TimeFunction {
    /// A table from (t, value) pairs; times must be strictly increasing.
    pub fn table(points: Vec<(Real, Real)>) -> Result<Self, String> {
        if points.is_empty() {
            return Err("a time table needs at least one (t, value) point".into());
        }
        for (i, w) in points.windows(2).enumerate() {
            if w[1].0 <= w[0].0 {
                return Err(format!(
                    "time table times must increase strictly: point {} has t = {} after t = {}",
                    i + 1,
                    w[1].0,
                    w[0].0
                ));
            }
        }
        if let Some((i, _)) = points
            .iter()
            .enumerate()
            .find(|(_, p)| !(p.0.is_finite() && p.1.is_finite()))
        {
            return Err(format!("time table point {i} is not finite"));
        }
        let (t, value) = points.into_iter().unzip();
        Ok(TimeFunction::Table { t, value })
    }

    /// The value at `time`; a table is held constant beyond its ends, and gives NaN at a NaN
    /// time (no point of the table is nearer than another).
    #[inline]
    pub fn eval(&self, time: Real) -> Real {
        match self {
            TimeFunction::Constant(c) => *c,
            TimeFunction::Table { t, value } => {
                if time.is_nan() {
                    return Real::NAN;
                }
                if time <= t[0] {
                    return value[0];
                }
                let last = t.len() - 1;
                if time >= t[last] {
                    return value[last];
                }
                let i = t.partition_point(|&ti| ti <= time) - 1;
                let s = (time - t[i]) / (t[i + 1] - t[i]);
                value[i] + s * (value[i + 1] - value[i])
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_interpolates_and_holds() {
        let f = TimeFunction::table(vec![(0.0, 0.0), (1.0, 2.0), (3.0, 2.0)]).unwrap();
        assert_eq!(f.eval(-1.0), 0.0);
        assert_eq!(f.eval(0.5), 1.0);
        assert_eq!(f.eval(2.0), 2.0);
        assert_eq!(f.eval(10.0), 2.0);
        assert!(TimeFunction::table(vec![(0.0, 0.0), (0.0, 1.0)]).is_err());
    }
}
