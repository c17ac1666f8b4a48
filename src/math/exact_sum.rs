//! Exact sums of f64 values: the same bits for any order and any grouping of the terms.
//!
//! A sum of floating-point numbers rounds after every addition, so its last bits depend on
//! the order of the terms. Totals a decomposed run must reproduce bit for bit (stage 5's
//! energies and forces summed over the contact pairs, whichever rank or thread computed
//! each) are therefore kept as [`ExactSum`]s: a fixed-point integer wide enough for every
//! finite f64 (2 098 bits, from 2⁻¹⁰⁷⁴ to 2¹⁰²⁴, in 32-bit digits with 32 bits of headroom
//! each), to which each term is added exactly, and which is rounded to the nearest f64
//! (ties to even) once, when read. Two ranks' sums combine by adding their digits, as f64
//! integers below 2⁵³ ([`ExactSum::digits`]): any reduction order gives the same digits.
//! (The idea is Kulisch's long accumulator; see also Demmel & Nguyen, "Parallel
//! reproducible summation", IEEE Trans. Comput. 64, 2015.)
//!
//! Cost: an addition is ~15 integer operations on three digits; reading is ~70 digit
//! carries. Non-finite terms are summed apart (±∞ and NaN combine the same in any order).

use super::Real;

/// Digits of 32 bits: the least significant has weight 2⁻¹⁰⁷⁴ (the smallest subnormal).
const DIGIT_BITS: u32 = 32;
/// 2⁻¹⁰⁷⁴ … 2¹⁰²⁴ is 2 098 bits, 66 digits; a term spans at most three (53 bits shifted by
/// up to 31), and one more digit takes the carries of 2³¹ terms at the top.
pub const DIGITS: usize = 68;
/// Terms added between carry passes: each digit then stays below 2³¹·2³² < 2⁶³.
const CARRY_EVERY: u32 = 1 << 30;
/// Bit position of the least significant digit: 2⁻¹⁰⁷⁴.
const LOWEST_EXP: i32 = -1074;

/// An exact sum of f64 terms (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ExactSum {
    /// Digit k has weight 2^(32k − 1074); between carry passes a digit may exceed 32 bits
    /// or be negative (the value is Σ digit_k·2^(32k − 1074) either way).
    digits: [i64; DIGITS],
    /// Sum of the non-finite terms (0 when there are none).
    special: Real,
    /// Terms added since the last carry pass.
    pending: u32,
}

impl Default for ExactSum {
    fn default() -> Self {
        ExactSum {
            digits: [0; DIGITS],
            special: 0.0,
            pending: 0,
        }
    }
}

impl ExactSum {
    /// Add one term exactly.
    #[inline]
    pub fn add(&mut self, x: Real) {
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i32;
        let fraction = bits & ((1 << 52) - 1);
        if biased == 0x7ff {
            self.special += x;
            return;
        }
        if x == 0.0 {
            return;
        }
        // x = ±m·2^e with m < 2⁵³ an integer.
        let (m, e) = if biased == 0 {
            (fraction, LOWEST_EXP)
        } else {
            (fraction | (1 << 52), biased - 1075)
        };
        let p = (e - LOWEST_EXP) as u32;
        let (k, s) = ((p / DIGIT_BITS) as usize, p % DIGIT_BITS);
        let wide = (m as u128) << s; // < 2⁸⁵: three digits
        let mask = (1u128 << DIGIT_BITS) - 1;
        let d = [
            (wide & mask) as i64,
            ((wide >> DIGIT_BITS) & mask) as i64,
            (wide >> (2 * DIGIT_BITS)) as i64,
        ];
        if bits >> 63 == 0 {
            self.digits[k] += d[0];
            self.digits[k + 1] += d[1];
            self.digits[k + 2] += d[2];
        } else {
            self.digits[k] -= d[0];
            self.digits[k + 1] -= d[1];
            self.digits[k + 2] -= d[2];
        }
        self.pending += 1;
        if self.pending >= CARRY_EVERY {
            self.carry();
        }
    }

    /// Add another exact sum (the combined sum is exact too).
    pub fn merge(&mut self, o: &ExactSum) {
        self.carry();
        let mut o = o.clone();
        o.carry();
        for (a, b) in self.digits.iter_mut().zip(o.digits) {
            *a += b;
        }
        self.special += o.special;
        self.pending = 1;
        self.carry();
    }

    /// Carry every digit into [0, 2³²) but the top one, which keeps the sign: the value
    /// is unchanged.
    fn carry(&mut self) {
        carry(&mut self.digits);
        self.pending = 0;
    }

    /// The sum rounded to the nearest f64, ties to even (±∞ beyond the largest finite
    /// f64; NaN or ±∞ when such a term was added).
    pub fn value(&self) -> Real {
        if self.special != 0.0 {
            return self.special;
        }
        let mut d = self.digits;
        carry(&mut d);
        let negative = d[DIGITS - 1] < 0;
        if negative {
            for x in d.iter_mut() {
                *x = -*x;
            }
            carry(&mut d);
        }
        let Some(top) = d.iter().rposition(|&x| x != 0) else {
            return 0.0;
        };
        // The leading 96 bits (three digits) and whether anything below them is set.
        let lead = |k: usize| if k <= top { d[k] as u128 } else { 0 };
        let low = top.saturating_sub(2);
        let mut m: u128 = (lead(low + 2) << 64) | (lead(low + 1) << 32) | lead(low);
        let sticky = d[..low].iter().any(|&x| x != 0);
        // m·2^e, e the weight of digit `low`.
        let mut e = (low as i32) * DIGIT_BITS as i32 + LOWEST_EXP;
        let len = 128 - m.leading_zeros() as i32;
        // The result's precision: 53 bits, fewer where it is subnormal (its top bit below
        // 2⁻¹⁰²²).
        let top_exp = e + len - 1;
        let keep = if top_exp >= -1022 {
            53
        } else {
            53 - (-1022 - top_exp)
        };
        let drop = len - keep;
        if drop > 0 {
            let dropped = m & ((1u128 << drop) - 1);
            let half = 1u128 << (drop - 1);
            m >>= drop;
            e += drop;
            if dropped > half || (dropped == half && (sticky || m & 1 == 1)) {
                m += 1; // may reach 2^keep: still exact in f64
            }
        }
        // m < 2⁵⁴ and m·2^e is representable (or overflows to ∞): scale by exact powers.
        let v = scale(m as f64, e);
        if negative {
            -v
        } else {
            v
        }
    }

    /// The digits as f64 integers after a carry pass: each in [0, 2³²) but the top one
    /// (|top| < 2³²). Summing the arrays of up to 2²⁰ ranks element by element in f64 is
    /// exact in any order (every partial sum is an integer below 2⁵³), and
    /// [`ExactSum::from_digits`] of that sum is the exact sum of the ranks' sums.
    pub fn digits(&self, out: &mut [f64]) {
        let mut d = self.clone();
        d.carry();
        for (o, x) in out.iter_mut().zip(d.digits) {
            *o = x as f64;
        }
        out[DIGITS] = d.special;
    }

    /// Values [`ExactSum::digits`] writes: the digits and the non-finite part.
    pub const LEN: usize = DIGITS + 1;

    /// The sum whose digits (summed over ranks) are `from`.
    pub fn from_digits(from: &[f64]) -> Self {
        let mut s = ExactSum::default();
        for (d, &x) in s.digits.iter_mut().zip(from) {
            *d = x as i64;
        }
        s.special = from[DIGITS];
        s.carry();
        s
    }
}

/// A stage's per-unit sums as a fixed number of f64 (at most [`MAX_FIELDS`]; counts are
/// exact in f64 below 2⁵³).
pub trait Partial: Sized {
    const LEN: usize;
    fn write(&self, out: &mut [f64]);
    fn read(from: &[f64]) -> Self;
}

/// The most fields a [`Partial`] has.
pub const MAX_FIELDS: usize = 10;

/// Field by field, the exact sums of the partials `include`d (by index): the stage's totals
/// as every thread count and rank count gets them.
pub fn exact_fields<P: Partial>(
    partials: &[P],
    include: impl Fn(usize) -> bool,
) -> [ExactSum; MAX_FIELDS] {
    assert!(P::LEN <= MAX_FIELDS);
    let mut sums: [ExactSum; MAX_FIELDS] = Default::default();
    let mut values = [0.0; MAX_FIELDS];
    for (i, p) in partials.iter().enumerate() {
        if include(i) {
            p.write(&mut values[..P::LEN]);
            for (s, &v) in sums.iter_mut().zip(&values[..P::LEN]) {
                s.add(v);
            }
        }
    }
    sums
}

/// The total of the partials: each field's exact sum, rounded once.
pub fn exact_total<P: Partial>(partials: &[P]) -> P {
    let sums = exact_fields(partials, |_| true);
    read_rounded(&sums)
}

/// A [`Partial`] of the rounded values of exact sums.
pub fn read_rounded<P: Partial>(sums: &[ExactSum; MAX_FIELDS]) -> P {
    let mut values = [0.0; MAX_FIELDS];
    for (v, s) in values.iter_mut().zip(sums) {
        *v = s.value();
    }
    P::read(&values[..P::LEN])
}

/// Carry every digit but the top one into [0, 2³²); the value is unchanged.
fn carry(d: &mut [i64; DIGITS]) {
    for k in 0..DIGITS - 1 {
        let c = d[k] >> DIGIT_BITS; // floor division by 2³²
        d[k] -= c << DIGIT_BITS;
        d[k + 1] += c;
    }
}

/// x·2^e for an integer x < 2⁵⁴ whose product is representable (or beyond the largest
/// f64): exact, or ±∞. Each step multiplies by a normal power of two and keeps the partial
/// product normal (x ≥ 1 and e ≥ −1074), so only the last can round, and it has nothing
/// to round.
fn scale(mut x: f64, mut e: i32) -> f64 {
    let pow = |k: i32| f64::from_bits(((k + 1023) as u64) << 52);
    while e > 1000 {
        x *= pow(1000);
        e -= 1000;
    }
    while e < -1000 {
        x *= pow(-1000);
        e += 1000;
    }
    x * pow(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(terms: &[f64]) -> f64 {
        let mut s = ExactSum::default();
        terms.iter().for_each(|&t| s.add(t));
        s.value()
    }

    /// A deterministic stream of f64 with wide exponents (xorshift).
    fn stream(seed: u64, n: usize, exp_range: i32) -> Vec<f64> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let m = (x >> 11) as f64 / (1u64 << 53) as f64 + 0.5;
                let e = ((x >> 3) % (2 * exp_range as u64 + 1)) as i32 - exp_range;
                let s = if x & 1 == 0 { 1.0 } else { -1.0 };
                s * m * 2f64.powi(e)
            })
            .collect()
    }

    /// Reference: terms that are integer multiples of 2⁻⁶⁰ below 2⁶⁰ sum exactly in i128;
    /// i128 → f64 rounds to nearest, ties to even (Rust's `as`), and scaling by 2⁻⁶⁰ is exact.
    #[test]
    fn sums_equal_the_correctly_rounded_integer_sum() {
        for seed in 1..200u64 {
            let terms: Vec<f64> = stream(seed, 300, 50)
                .into_iter()
                .map(|t| (t * 2f64.powi(60)).round() * 2f64.powi(-60))
                .collect();
            let int: i128 = terms.iter().map(|&t| (t * 2f64.powi(60)) as i128).sum();
            let reference = int as f64 * 2f64.powi(-60);
            assert_eq!(exact(&terms).to_bits(), reference.to_bits(), "seed {seed}");
        }
    }

    #[test]
    fn order_and_grouping_do_not_change_the_bits() {
        let terms = stream(7, 5000, 300);
        let forward = exact(&terms);
        let mut reversed = terms.clone();
        reversed.reverse();
        assert_eq!(forward.to_bits(), exact(&reversed).to_bits());
        // Grouped as three "ranks", their digits summed as f64 in two different orders.
        let parts: Vec<ExactSum> = terms
            .chunks(1700)
            .map(|c| {
                let mut s = ExactSum::default();
                c.iter().for_each(|&t| s.add(t));
                s
            })
            .collect();
        let digits: Vec<Vec<f64>> = parts
            .iter()
            .map(|p| {
                let mut d = vec![0.0; ExactSum::LEN];
                p.digits(&mut d);
                d
            })
            .collect();
        let mut a = vec![0.0; ExactSum::LEN];
        let mut b = vec![0.0; ExactSum::LEN];
        for d in &digits {
            a.iter_mut().zip(d).for_each(|(x, y)| *x += y);
        }
        for d in digits.iter().rev() {
            b.iter_mut().zip(d).for_each(|(x, y)| *x += y);
        }
        assert_eq!(
            ExactSum::from_digits(&a).value().to_bits(),
            forward.to_bits()
        );
        assert_eq!(
            ExactSum::from_digits(&b).value().to_bits(),
            forward.to_bits()
        );
        let mut merged = ExactSum::default();
        parts.iter().rev().for_each(|p| merged.merge(p));
        assert_eq!(merged.value().to_bits(), forward.to_bits());
        // And the naive sum is within the usual bound of it: n·ε·Σ|t|.
        let naive: f64 = terms.iter().sum();
        let bound = terms.len() as f64 * f64::EPSILON * terms.iter().map(|t| t.abs()).sum::<f64>();
        assert!((naive - forward).abs() <= bound);
    }

    #[test]
    fn cancellation_subnormals_and_extremes_are_exact() {
        assert_eq!(exact(&[1e300, 1.0, -1e300]), 1.0);
        assert_eq!(exact(&[f64::MAX, f64::MAX, -f64::MAX]), f64::MAX);
        assert_eq!(exact(&[f64::MAX, f64::MAX]), f64::INFINITY);
        assert_eq!(exact(&[-f64::MAX, -f64::MAX]), f64::NEG_INFINITY);
        let tiny = f64::from_bits(1); // 2⁻¹⁰⁷⁴
        assert_eq!(exact(&[tiny, tiny, tiny]).to_bits(), 3);
        assert_eq!(
            exact(&[f64::MIN_POSITIVE, -tiny]).to_bits(),
            f64::MIN_POSITIVE.to_bits() - 1
        );
        assert_eq!(exact(&[1.0, 1e-300, -1.0]), 1e-300);
        assert_eq!(exact(&[0.1, 0.2]), 0.1 + 0.2); // one rounding, as f64 addition
        assert_eq!(exact(&[]), 0.0);
        assert_eq!(exact(&[2.5, -2.5]), 0.0);
        // Ties to even: 1 + 2⁻⁵³ is a tie, rounds to 1; 1 + 2⁻⁵³ + 2⁻¹⁰⁰ rounds up.
        assert_eq!(exact(&[1.0, 2f64.powi(-53)]), 1.0);
        assert_eq!(
            exact(&[1.0, 2f64.powi(-53), 2f64.powi(-100)]),
            1.0 + f64::EPSILON
        );
        assert_eq!(
            exact(&[-1.0, -(2f64.powi(-53)), -(2f64.powi(-100))]),
            -1.0 - f64::EPSILON
        );
        assert!(exact(&[1.0, f64::NAN]).is_nan());
        assert_eq!(exact(&[1.0, f64::INFINITY]), f64::INFINITY);
        assert!(exact(&[f64::INFINITY, f64::NEG_INFINITY]).is_nan());
    }
}
