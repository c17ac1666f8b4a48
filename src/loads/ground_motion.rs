//! Earthquake ground-motion records: readers (PEER NGA `.AT2`, two-column `t, a`, one-column
//! with a given dt), processing (integration, baseline correction, resampling) and intensity
//! measures (PGA/PGV/PGD, Arias intensity, significant duration, elastic response spectrum).
//! Theory and measured agreement: docs/theory/ground_motion.md.
//!
//! The record is the piecewise-linear acceleration through (k·dt, a_k), k = 0..N−1, and
//! (N·dt, 0); it is zero after t = N·dt (the duration), and the ground is at rest at t = 0.

use crate::math::Real;
use std::path::Path;

/// Standard gravity [m/s²] (the `g` unit of records).
pub const G: Real = 9.80665;

/// File formats of a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// PEER NGA: 4 header lines, the 4th with `NPTS=` and `DT=`; then values, any number a line.
    At2,
    /// Lines of `t, a` (commas or white space); the time step must be uniform.
    TwoColumn,
    /// One value (or several) a line, at a given dt.
    OneColumn,
}

impl Format {
    /// `"at2"`, `"two_column"` (also `"csv"`), `"one_column"`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "at2" => Ok(Format::At2),
            "two_column" | "csv" => Ok(Format::TwoColumn),
            "one_column" => Ok(Format::OneColumn),
            _ => Err(format!(
                "unknown format \"{s}\"; use \"at2\", \"two_column\" (or \"csv\") or \"one_column\""
            )),
        }
    }
}

/// Acceleration units of a file: the factor to m/s².
pub fn units_factor(s: &str) -> Result<Real, String> {
    match s {
        "g" => Ok(G),
        "m/s2" => Ok(1.0),
        "cm/s2" => Ok(0.01),
        _ => Err(format!(
            "unknown units \"{s}\"; use \"g\", \"m/s2\" or \"cm/s2\""
        )),
    }
}

/// How to read and prepare a record. Applied in this order: units, window, baseline, scale.
#[derive(Clone, Debug)]
pub struct ReadOptions {
    /// None: `.AT2` files (any case) are AT2, others two-column, or one-column if `dt` is given.
    pub format: Option<Format>,
    /// Factor from the file's unit to m/s² (see [`units_factor`]).
    pub units: Real,
    /// Time step of one-column files [s].
    pub dt: Option<Real>,
    /// Multiply the acceleration by this factor (not with `pga`).
    pub scale: Option<Real>,
    /// Scale so that the peak |a| is this value [m/s²] (not with `scale`).
    pub pga: Option<Real>,
    /// Keep only samples with start ≤ t ≤ end [s]; the kept part starts again at t = 0.
    pub start: Option<Real>,
    pub end: Option<Real>,
    /// Apply [`GroundMotion::baseline_corrected`].
    pub baseline: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            format: None,
            units: G,
            dt: None,
            scale: None,
            pga: None,
            start: None,
            end: None,
            baseline: false,
        }
    }
}

/// An acceleration record.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct GroundMotion {
    /// Name (file name).
    pub name: String,
    /// Where it came from: the file path and its header lines.
    pub source: String,
    /// Time step [s].
    pub dt: Real,
    /// Ground acceleration a_k at t = k·dt [m/s²].
    pub acc: Vec<Real>,
}

/// A peak of a history: value (with sign), sample index and time [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    pub value: Real,
    pub index: usize,
    pub time: Real,
}

/// Tokens of a line: split at white space and commas.
fn tokens(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
}

/// A number, or an error naming the file, the line (from 1) and the token.
fn number(tok: &str, file: &str, line: usize) -> Result<Real, String> {
    match tok.parse::<Real>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{file}:{line}: '{tok}' is not a number")),
    }
}

/// The value after `key` (e.g. `NPTS=`) on a header line.
fn header_value<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let upper = line.to_ascii_uppercase();
    let i = upper.find(key)? + key.len();
    let rest = line[i..].trim_start_matches([' ', '=']);
    let end = rest
        .find(|c: char| c == ',' || c.is_whitespace())
        .unwrap_or(rest.len());
    Some(&rest[..end])
}

/// A positive time step, or an error naming its line.
fn check_dt(dt: Real, file: &str, line: usize) -> Result<Real, String> {
    if dt > 0.0 {
        Ok(dt)
    } else {
        Err(format!(
            "{file}:{line}: the time step must be positive, got DT = {dt}"
        ))
    }
}

/// A PEER NGA `.AT2` text: (dt [s], values in the file's unit, header lines). Four header
/// lines; the 4th gives `NPTS=` and `DT=`; then whitespace-separated values.
pub fn parse_at2(text: &str, file: &str) -> Result<(Real, Vec<Real>, Vec<String>), String> {
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() < 4 {
        return Err(format!(
            "{file}:{}: an AT2 file needs 4 header lines, the file has {}",
            lines.len().max(1),
            lines.len()
        ));
    }
    let h = lines[3];
    let npts = header_value(h, "NPTS").ok_or_else(|| {
        format!("{file}:4: no NPTS in the 4th header line (expected e.g. 'NPTS=  4000, DT= .01000 SEC'), got '{}'", h.trim())
    })?;
    let npts: usize = npts
        .parse()
        .map_err(|_| format!("{file}:4: NPTS '{npts}' is not a whole number"))?;
    let dt = header_value(h, "DT").ok_or_else(|| {
        format!(
            "{file}:4: no DT in the 4th header line (expected e.g. 'NPTS=  4000, DT= .01000 SEC'), got '{}'",
            h.trim()
        )
    })?;
    let dt = check_dt(number(dt, file, 4)?, file, 4)?;
    // Not more than the text can hold (a value and a separator take two bytes): a corrupt
    // NPTS must not reserve gigabytes before the count is found wrong.
    let mut values = Vec::with_capacity(npts.min(text.len() / 2 + 1));
    let mut last = 4;
    for (k, line) in lines.iter().enumerate().skip(4) {
        for tok in tokens(line) {
            values.push(number(tok, file, k + 1)?);
            last = k + 1;
        }
    }
    if values.len() != npts {
        return Err(format!(
            "{file}:{last}: the header (line 4) says NPTS = {npts}, but the file has {} values (last at line {last})",
            values.len()
        ));
    }
    let header = lines[..4].iter().map(|l| l.trim().to_string()).collect();
    Ok((dt, values, header))
}

/// A two-column `t, a` text: (dt [s], values). Lines starting with `#` and a non-numeric
/// header before the first data line are skipped. The time step must be uniform (within
/// 0.1 % of the first step, so that times printed with few digits are accepted).
pub fn parse_two_column(text: &str, file: &str) -> Result<(Real, Vec<Real>), String> {
    let mut t = Vec::new();
    let mut a = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let toks: Vec<&str> = tokens(line).collect();
        if t.is_empty() && toks.iter().any(|s| s.parse::<Real>().is_err()) {
            continue; // header
        }
        if toks.len() != 2 {
            return Err(format!(
                "{file}:{}: expected two numbers 't, a', got '{line}'",
                k + 1
            ));
        }
        let (ti, ai) = (number(toks[0], file, k + 1)?, number(toks[1], file, k + 1)?);
        if let Some(&prev) = t.last() {
            let step: Real = ti - prev;
            let dt = if t.len() >= 2 { t[1] - t[0] } else { step };
            if t.len() == 1 {
                check_dt(step, file, k + 1)?;
            } else if (step - dt).abs() > 1e-3 * dt {
                return Err(format!(
                    "{file}:{}: uneven time step: {step} s from the line before, the record's step is {dt} s",
                    k + 1
                ));
            }
        }
        t.push(ti);
        a.push(ai);
    }
    if t.len() < 2 {
        return Err(format!(
            "{file}: a two-column record needs at least two lines"
        ));
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as Real;
    Ok((dt, a))
}

/// A one-column text at time step `dt`: every number after an optional non-numeric header
/// (`#` lines skipped).
pub fn parse_one_column(text: &str, file: &str, dt: Real) -> Result<Vec<Real>, String> {
    if dt <= 0.0 {
        return Err(format!(
            "{file}: the time step must be positive, got dt = {dt}"
        ));
    }
    let mut a = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.starts_with('#') {
            continue;
        }
        if a.is_empty() && tokens(line).any(|s| s.parse::<Real>().is_err()) {
            continue; // header
        }
        for tok in tokens(line) {
            a.push(number(tok, file, k + 1)?);
        }
    }
    if a.is_empty() {
        return Err(format!("{file}: no values"));
    }
    Ok(a)
}

impl GroundMotion {
    /// Read a record file (see [`ReadOptions`]); errors name the file and the line.
    pub fn read(path: &Path, opts: &ReadOptions) -> Result<Self, String> {
        let text = crate::limits::read_text_bounded(path, crate::limits::MAX_TEXT_INPUT)
            .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
        let is_at2 = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("at2"));
        let format = opts.format.unwrap_or(if is_at2 {
            Format::At2
        } else if opts.dt.is_some() {
            Format::OneColumn
        } else {
            Format::TwoColumn
        });
        let name = path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Self::from_text(&text, &path.display().to_string(), &name, format, opts)
    }

    /// A record from the text of a file named `file` (in messages).
    pub fn from_text(
        text: &str,
        file: &str,
        name: &str,
        format: Format,
        opts: &ReadOptions,
    ) -> Result<Self, String> {
        let (dt, raw, header) = match format {
            Format::At2 => parse_at2(text, file)?,
            Format::TwoColumn => {
                let (dt, a) = parse_two_column(text, file)?;
                (dt, a, Vec::new())
            }
            Format::OneColumn => {
                let dt = opts.dt.ok_or_else(|| {
                    format!("{file}: a one-column record needs its time step 'dt'")
                })?;
                (dt, parse_one_column(text, file, dt)?, Vec::new())
            }
        };
        let mut source = file.to_string();
        for h in header {
            source.push('\n');
            source.push_str(&h);
        }
        let gm = GroundMotion {
            name: name.to_string(),
            source,
            dt,
            acc: raw.iter().map(|a| a * opts.units).collect(),
        };
        gm.prepared(opts).map_err(|e| format!("{file}: {e}"))
    }

    /// Window, baseline correction and scaling of [`ReadOptions`] (units already applied).
    pub fn prepared(mut self, opts: &ReadOptions) -> Result<Self, String> {
        if opts.scale.is_some() && opts.pga.is_some() {
            return Err("give 'scale' or 'pga', not both".into());
        }
        if opts.start.is_some() || opts.end.is_some() {
            self = self.window(
                opts.start.unwrap_or(0.0),
                opts.end.unwrap_or(Real::INFINITY),
            )?;
        }
        if opts.baseline {
            self = self.baseline_corrected();
        }
        if let Some(s) = opts.scale {
            self.acc.iter_mut().for_each(|a| *a *= s);
        }
        if let Some(target) = opts.pga {
            if target <= 0.0 {
                return Err(format!("'pga' must be positive, got {target}"));
            }
            let p = self.pga().value.abs();
            if p == 0.0 {
                return Err("the record is all zeros; it cannot be scaled to a PGA".into());
            }
            self.acc.iter_mut().for_each(|a| *a *= target / p);
        }
        Ok(self)
    }

    /// The samples with start ≤ t ≤ end [s] (to 1e-9·dt), re-timed to start at t = 0.
    pub fn window(mut self, start: Real, end: Real) -> Result<Self, String> {
        if !(start >= 0.0 && end > start) {
            return Err(format!(
                "the time window [{start}, {end}] s must have 0 ≤ start < end"
            ));
        }
        let eps = 1e-9 * self.dt;
        let first = ((start - eps) / self.dt).ceil().max(0.0) as usize;
        let last = ((end + eps) / self.dt)
            .floor()
            .min(self.acc.len() as Real - 1.0);
        if last < first as Real {
            return Err(format!(
                "the time window [{start}, {end}] s holds no sample of the record (duration {} s)",
                self.duration()
            ));
        }
        self.acc = self.acc[first..=last as usize].to_vec();
        Ok(self)
    }

    /// Duration N·dt [s] (the acceleration returns to zero at this time).
    pub fn duration(&self) -> Real {
        self.acc.len() as Real * self.dt
    }

    /// Samples a_0..a_{N−1} followed by the closing zero a_N = 0 [m/s²].
    fn closed(&self) -> Vec<Real> {
        let mut a = self.acc.clone();
        a.push(0.0);
        a
    }

    /// Ground acceleration at time t [m/s²]: linear between samples, zero before 0 and
    /// from the duration N·dt on (it reaches zero linearly over the last step).
    /// O(1), no allocation: this is what a shaken model evaluates once a step.
    pub fn at(&self, t: Real) -> Real {
        if t.is_nan() || t < 0.0 {
            return 0.0;
        }
        let s = t / self.dt;
        let k = s.floor();
        if k >= self.acc.len() as Real {
            return 0.0;
        }
        let k = k as usize;
        let next = self.acc.get(k + 1).copied().unwrap_or(0.0); // the closing a_N = 0
        let f = s - k as Real;
        self.acc[k] * (1.0 - f) + next * f
    }

    /// Ground velocity at the samples t = k·dt, k = 0..N [m/s], from rest. See
    /// [`kinematics`] for the scheme.
    pub fn velocity(&self) -> Vec<Real> {
        kinematics(&self.closed(), self.dt).0
    }

    /// Ground displacement at the samples t = k·dt, k = 0..N [m]. See [`kinematics`].
    pub fn displacement(&self) -> Vec<Real> {
        kinematics(&self.closed(), self.dt).1
    }

    /// The velocity and displacement samples, for repeated interpolation.
    pub fn kinematics(&self) -> Kinematics {
        let (v, u) = kinematics(&self.closed(), self.dt);
        Kinematics { dt: self.dt, v, u }
    }

    /// See [`Kinematics::velocity_at`] (this integrates the record on every call).
    pub fn velocity_at(&self, t: Real) -> Real {
        self.kinematics().velocity_at(t)
    }

    /// See [`Kinematics::displacement_at`] (this integrates the record on every call).
    pub fn displacement_at(&self, t: Real) -> Real {
        self.kinematics().displacement_at(t)
    }

    /// The record resampled at time step `dt` [s] by linear interpolation of [`Self::at`];
    /// it keeps the samples with k·dt < the duration.
    pub fn resampled(&self, dt: Real) -> Result<Self, String> {
        if dt <= 0.0 {
            return Err(format!("resampling step must be positive, got {dt}"));
        }
        let n = (self.duration() / dt - 1e-9).ceil().max(1.0) as usize;
        let closed = self.closed();
        let acc = (0..n)
            .map(|k| interpolate(&closed, self.dt, k as Real * dt, None))
            .collect();
        Ok(GroundMotion {
            acc,
            dt,
            ..self.clone()
        })
    }

    /// Peak ground acceleration: the sample of largest |a| (first if tied) [m/s²].
    pub fn pga(&self) -> Peak {
        peak(&self.acc, self.dt)
    }

    /// Peak ground velocity (trapezoidal, from rest) [m/s].
    pub fn pgv(&self) -> Peak {
        peak(&self.velocity(), self.dt)
    }

    /// Peak ground displacement [m].
    pub fn pgd(&self) -> Peak {
        peak(&self.displacement(), self.dt)
    }

    /// Cumulative Arias intensity at t = k·dt, k = 0..N [m/s]:
    /// I_a(t) = π/(2g)·∫₀ᵗ a² dt, by the trapezoidal rule on the samples,
    /// ∫ over a step ≈ dt/2·(a_k² + a_{k+1}²) (the usual definition on a sampled record and the
    /// data README's; the exact integral of the piecewise-linear a² is lower by
    /// dt/6·Σ(a_{k+1} − a_k)², 1.4 % for IELC180 and 4.3 % for the 0.02 s Peknold record).
    pub fn arias_history(&self) -> Vec<Real> {
        let a = self.closed();
        let c = std::f64::consts::PI / (2.0 * G) * self.dt / 2.0;
        let mut out = Vec::with_capacity(a.len());
        let mut sum = 0.0;
        out.push(0.0);
        for w in a.windows(2) {
            sum += c * (w[0] * w[0] + w[1] * w[1]);
            out.push(sum);
        }
        out
    }

    /// Arias intensity I_a = π/(2g)·∫a² dt [m/s] (Arias 1970).
    pub fn arias(&self) -> Real {
        *self.arias_history().last().unwrap_or(&0.0)
    }

    /// Significant duration D5-95 [s]: the time between 5 % and 95 % of the Arias intensity
    /// (times found by linear interpolation of the cumulative intensity).
    pub fn significant_duration(&self) -> Real {
        let h = self.arias_history();
        let total = h[h.len() - 1];
        if total == 0.0 {
            return 0.0;
        }
        let time_of = |level: Real| {
            let k = h.iter().position(|&x| x >= level).unwrap_or(h.len() - 1);
            if k == 0 {
                return 0.0;
            }
            let f = (level - h[k - 1]) / (h[k] - h[k - 1]);
            (k as Real - 1.0 + f) * self.dt
        };
        time_of(0.95 * total) - time_of(0.05 * total)
    }

    /// Baseline correction: a_c(t) = a(t) − (c₀ + c₁·t/T), T = N·dt, with c₀, c₁ the unique
    /// pair for which the corrected record, integrated by [`kinematics`], ends at rest where it
    /// started: v(T) = 0 and u(T) = 0 (a 2×2 linear system on the discrete scheme, so both hold
    /// to round-off). After the record the ground then stays at rest: no drift.
    pub fn baseline_corrected(&self) -> Self {
        let n = self.acc.len();
        let t_end = self.duration();
        let basis = |j: usize| -> Vec<Real> {
            let mut b: Vec<Real> = (0..n)
                .map(|k| (k as Real * self.dt / t_end).powi(j as i32))
                .collect();
            b.push(0.0);
            b
        };
        let end_state = |a: &[Real]| {
            let (v, u) = kinematics(a, self.dt);
            (v[v.len() - 1], u[u.len() - 1])
        };
        let (v0, u0) = end_state(&self.closed());
        let (p, q) = (end_state(&basis(0)), end_state(&basis(1)));
        // [p.0 q.0; p.1 q.1]·[c0; c1] = [v0; u0]
        let det = p.0 * q.1 - q.0 * p.1;
        let c0 = (v0 * q.1 - q.0 * u0) / det;
        let c1 = (p.0 * u0 - v0 * p.1) / det;
        let mut out = self.clone();
        for (k, a) in out.acc.iter_mut().enumerate() {
            *a -= c0 + c1 * k as Real * self.dt / t_end;
        }
        out
    }

    /// Pseudo-acceleration spectrum Sa(T) = ω²·max|u| [m/s²] of a linear SDOF with damping
    /// ratio `damping`, ü + 2ζωu̇ + ω²u = −a_g(t), from rest, integrated exactly for the
    /// piecewise-linear record (Nigam & Jennings 1969; see [`sdof_peak`]). The peak is taken
    /// at the samples, over the record and a free-vibration tail of one period after it; a
    /// peak between samples is missed by up to about (ω·dt)²/8 relative (resample the record
    /// finer with [`Self::resampled`] for short periods: it keeps the same piecewise-linear
    /// record).
    ///
    /// Each period costs N + T/dt + 1 steps: check the periods with
    /// [`Self::check_spectrum_periods`] first (the script's `record.spectrum` does).
    pub fn spectrum(&self, periods: &[Real], damping: Real) -> Vec<Real> {
        periods
            .iter()
            .map(|&t| {
                let w = 2.0 * std::f64::consts::PI / t;
                w * w * sdof_peak(&self.acc, self.dt, t, damping, Method::Exact)
            })
            .collect()
    }

    /// Positive periods [s] whose spectrum takes at most [`MAX_SPECTRUM_STEPS`] steps in all
    /// (each costs N + T/dt + 1), or an error naming the first that is not positive or the
    /// total: a period of 1e6 s on a 0.01 s record would take 1e8 steps, and a thousand of
    /// them minutes.
    pub fn check_spectrum_periods(&self, periods: &[Real]) -> Result<(), String> {
        let mut total = 0.0;
        for (i, &t) in periods.iter().enumerate() {
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!("period {i} must be a positive number [s], got {t}"));
            }
            total += sdof_steps(self.acc.len(), self.dt, t);
        }
        if total > MAX_SPECTRUM_STEPS {
            return Err(format!(
                "the periods need {total:.3e} steps of the record's time step (dt = {} s) in all, more than {MAX_SPECTRUM_STEPS:.0e}: each period T costs N + T/dt + 1 steps (N = {} samples); give fewer or shorter periods",
                self.dt,
                self.acc.len()
            ));
        }
        Ok(())
    }

    /// As [`Self::spectrum`], integrated with Newmark's average-acceleration method
    /// (γ = 1/2, β = 1/4; Newmark 1959), the method of the data README's reference values.
    pub fn spectrum_newmark(&self, periods: &[Real], damping: Real) -> Vec<Real> {
        periods
            .iter()
            .map(|&t| {
                let w = 2.0 * std::f64::consts::PI / t;
                w * w * sdof_peak(&self.acc, self.dt, t, damping, Method::AverageAcceleration)
            })
            .collect()
    }
}

/// Ground velocity and displacement at t = k·dt, k = 0..N (see [`kinematics`]).
#[derive(Clone, Debug)]
pub struct Kinematics {
    pub dt: Real,
    /// [m/s]
    pub v: Vec<Real>,
    /// [m]
    pub u: Vec<Real>,
}

impl Kinematics {
    /// Ground velocity at time t [m/s]: linear between samples, 0 before the record; after
    /// it the final velocity is held (the acceleration is zero).
    pub fn velocity_at(&self, t: Real) -> Real {
        interpolate(&self.v, self.dt, t, Some(0.0))
    }

    /// Ground displacement at time t [m]: linear between samples, 0 before the record;
    /// after it the ground moves on at the final velocity (zero after
    /// [`GroundMotion::baseline_corrected`], so the displacement stays put).
    pub fn displacement_at(&self, t: Real) -> Real {
        interpolate(&self.u, self.dt, t, Some(self.v[self.v.len() - 1]))
    }
}

/// Integration of a response spectrum's SDOF.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Exact for a piecewise-linear ground acceleration (Nigam & Jennings 1969).
    Exact,
    /// Newmark average acceleration (unconditionally stable, period elongation
    /// ≈ (ωdt)²/12 relative).
    AverageAcceleration,
}

/// Linear interpolation of samples `y` at t = k·dt; before 0 the value is 0, after the last
/// sample it is y_last + slope·(t − t_last) with `slope` given, else 0.
fn interpolate(y: &[Real], dt: Real, t: Real, slope: Option<Real>) -> Real {
    if t <= 0.0 || y.is_empty() {
        return if t == 0.0 {
            y.first().copied().unwrap_or(0.0)
        } else {
            0.0
        };
    }
    let s = t / dt;
    // Compared as floats: a time far beyond the record (1e300 s) must not become an index.
    if s.is_nan() || s >= (y.len() - 1) as Real {
        let t_last = (y.len() - 1) as Real * dt;
        return match slope {
            // A zero slope holds the value exactly, also at t = ∞.
            Some(v) if v != 0.0 => y[y.len() - 1] + v * (t - t_last),
            Some(_) => y[y.len() - 1],
            None => 0.0,
        };
    }
    let k = s.floor() as usize;
    let f = s - k as Real;
    y[k] * (1.0 - f) + y[k + 1] * f
}

/// The sample of largest |y| (first if tied), with its time k·dt.
fn peak(y: &[Real], dt: Real) -> Peak {
    let mut best = Peak {
        value: 0.0,
        index: 0,
        time: 0.0,
    };
    for (k, &v) in y.iter().enumerate() {
        if v.abs() > best.value.abs() {
            best = Peak {
                value: v,
                index: k,
                time: k as Real * dt,
            };
        }
    }
    best
}

/// Velocity and displacement at t = k·dt of a ground starting from rest, integrated as the
/// engine's central-difference step would move a node with this acceleration:
///
/// v_{k+1/2} = v_{k−1/2} + a_k·dt,   u_{k+1} = u_k + v_{k+1/2}·dt,
///
/// started with v_{−1/2} = −a_0·dt/2 so that v(0) = 0 and u_0 = 0. The velocity at the
/// samples is the mean of its half steps, v_k = ½(v_{k−1/2} + v_{k+1/2}), which makes it
/// exactly the trapezoidal integral v_{k+1} = v_k + ½(a_k + a_{k+1})·dt. So the displacement
/// is the one a base node driven by the record gets in the explicit step, and the velocity is
/// the trapezoidal one the data README's PGV uses.
pub fn kinematics(a: &[Real], dt: Real) -> (Vec<Real>, Vec<Real>) {
    let mut v = Vec::with_capacity(a.len());
    let mut u = Vec::with_capacity(a.len());
    let mut v_half = -0.5 * a.first().copied().unwrap_or(0.0) * dt; // v_{-1/2}
    let mut disp = 0.0;
    for &ak in a {
        let next = v_half + ak * dt; // v_{k+1/2}
        v.push(0.5 * (v_half + next));
        u.push(disp);
        disp += next * dt;
        v_half = next;
    }
    (v, u)
}

/// Peak |u| [m] of the SDOF ü + 2ζωu̇ + ω²u = −a_g(t) (ω = 2π/period, ζ = damping), from
/// rest, under the piecewise-linear record `acc` [m/s²] followed by one period of free
/// vibration.
///
/// [`Method::Exact`] (Nigam & Jennings 1969): over a step the load p(τ) = −a_g is linear,
/// p = p_k + s·τ, s = (p_{k+1} − p_k)/dt; the particular solution is
/// u_p(τ) = (p_k + s·τ)/ω² − 2ζs/ω³ and the homogeneous one
/// u_h = e^{−ζωτ}(A cos ω_d τ + B sin ω_d τ), ω_d = ω√(1−ζ²), with A = u_k − u_p(0),
/// B = (v_k − s/ω² + ζωA)/ω_d. Evaluated at τ = dt this is exact (to round-off) for ζ < 1.
///
/// [`Method::AverageAcceleration`]: Newmark (1959) with γ = 1/2, β = 1/4.
pub fn sdof_peak(acc: &[Real], dt: Real, period: Real, damping: Real, method: Method) -> Real {
    let mut peak: Real = 0.0;
    sdof_walk(acc, dt, period, damping, method, |u| {
        peak = peak.max(u.abs())
    });
    peak
}

/// Most SDOF steps [`GroundMotion::check_spectrum_periods`] lets one spectrum take (about a
/// second).
pub const MAX_SPECTRUM_STEPS: Real = 1e8;

/// Steps of [`sdof_response`] for `n` samples at `dt` and `period`: N + ⌈T/dt⌉ + 1 (+ the
/// first), as a float (it may not fit an integer).
pub fn sdof_steps(n: usize, dt: Real, period: Real) -> Real {
    n as Real + (period / dt).ceil() + 2.0
}

/// The relative displacement u at t = k·dt [m], k = 0 .. N + one period, of the SDOF of
/// [`sdof_peak`] (same equations), from rest: u_0 = 0.
pub fn sdof_response(
    acc: &[Real],
    dt: Real,
    period: Real,
    damping: Real,
    method: Method,
) -> Vec<Real> {
    let mut out = Vec::with_capacity(sdof_steps(acc.len(), dt, period).min(1e7) as usize);
    sdof_walk(acc, dt, period, damping, method, |u| out.push(u));
    out
}

/// The SDOF of [`sdof_peak`] stepped through the record and one period after it; `out`
/// gets u at every sample, from u_0 = 0.
fn sdof_walk(
    acc: &[Real],
    dt: Real,
    period: Real,
    damping: Real,
    method: Method,
    mut out: impl FnMut(Real),
) {
    let w = 2.0 * std::f64::consts::PI / period;
    let z = damping;
    // Saturating: a period beyond the integers gives the largest count, not a wrapped one.
    let tail = ((period / dt).ceil() as usize).saturating_add(1);
    let steps = acc.len().saturating_add(tail);
    let p = |k: usize| -acc.get(k).copied().unwrap_or(0.0);
    let (mut u, mut v) = (0.0, 0.0);
    out(0.0);
    match method {
        Method::Exact => {
            let wd = w * (1.0 - z * z).sqrt();
            let e = (-z * w * dt).exp();
            let (sn, cs) = (wd * dt).sin_cos();
            for k in 0..steps {
                let s = (p(k + 1) - p(k)) / dt;
                let up0 = p(k) / (w * w) - 2.0 * z * s / (w * w * w);
                let a = u - up0;
                let b = (v - s / (w * w) + z * w * a) / wd;
                let (h, hd) = (
                    e * (a * cs + b * sn),
                    e * ((-z * w * a + wd * b) * cs + (-z * w * b - wd * a) * sn),
                );
                u = h + up0 + s * dt / (w * w);
                v = hd + s / (w * w);
                out(u);
            }
        }
        Method::AverageAcceleration => {
            // Newmark γ = 1/2, β = 1/4 on ü = p − 2ζωu̇ − ω²u.
            let mut acc_rel = p(0);
            let k_eff = w * w + 2.0 * z * w * 2.0 / dt + 4.0 / (dt * dt);
            for k in 0..steps {
                let rhs = p(k + 1)
                    + (4.0 / (dt * dt)) * u
                    + (4.0 / dt) * v
                    + acc_rel
                    + 2.0 * z * w * (2.0 / dt * u + v);
                let un = rhs / k_eff;
                let vn = 2.0 / dt * (un - u) - v;
                acc_rel = 4.0 / (dt * dt) * (un - u) - 4.0 / dt * v - acc_rel;
                u = un;
                v = vn;
                out(u);
            }
        }
    }
}
