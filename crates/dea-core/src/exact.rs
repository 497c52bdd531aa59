//! Exact, order-independent summation of f64 values.
//!
//! A diagnostic summed over nodes (an energy, say) must come out with the same bits on any
//! number of ranks, yet each rank sums a different subset and the partial sums meet in an
//! order the partition decides. [`ExactSum`] holds the exact value of the sum in fixed point
//! (a Kulisch accumulator: 32-bit limbs in i64 words covering the whole f64 range), so adding
//! in any order, and merging partial sums with integer addition (an MPI sum of i64 words),
//! gives one exact value, rounded once at the end.

/// Bits of significance per limb; the rest of each i64 word is headroom for carries.
const LIMB_BITS: u32 = 32;
const LIMB_MASK: i64 = (1 << LIMB_BITS) - 1;
/// Limbs covering 2^-1074 … 2^1024 plus two limbs of headroom.
pub const LIMBS: usize = 68;
/// Additions between carry normalisations: each adds < 2^32 to a limb, so 2^30 of them keep
/// every word far from overflow.
const ADDS_PER_NORMALISATION: u32 = 1 << 30;

/// The exact sum of the f64 values added so far.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactSum {
    limbs: [i64; LIMBS],
    adds: u32,
    /// infinities and NaNs, summed as floats (their sum is order-independent)
    special_bits: u64,
    has_special: bool,
}

impl Default for ExactSum {
    fn default() -> Self {
        Self { limbs: [0; LIMBS], adds: 0, special_bits: 0, has_special: false }
    }
}

impl ExactSum {
    /// An empty sum: zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `x` exactly.
    #[inline]
    pub fn add(&mut self, x: f64) {
        if x == 0.0 {
            return;
        }
        if !x.is_finite() {
            let special = if self.has_special { f64::from_bits(self.special_bits) + x } else { x };
            self.special_bits = special.to_bits();
            self.has_special = true;
            return;
        }
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i64;
        let fraction = (bits & ((1 << 52) - 1)) as i128;
        // x = mantissa * 2^(position - 1074), position >= 0
        let (mantissa, position) = if biased == 0 { (fraction, 0) } else { (fraction | (1 << 52), biased - 1) };
        let (index, shift) = ((position / LIMB_BITS as i64) as usize, (position % LIMB_BITS as i64) as u32);
        let mut value = mantissa << shift;
        if x < 0.0 {
            value = -value;
        }
        // value = high 2^64 + middle 2^32 + low with 0 <= low, middle < 2^32 (arithmetic shifts)
        self.limbs[index] += (value as i64) & LIMB_MASK;
        self.limbs[index + 1] += ((value >> LIMB_BITS) as i64) & LIMB_MASK;
        self.limbs[index + 2] += (value >> (2 * LIMB_BITS)) as i64;
        self.adds += 1;
        if self.adds == ADDS_PER_NORMALISATION {
            self.normalise();
        }
    }

    /// Propagates carries: every limb but the top one ends in [0, 2^32).
    fn normalise(&mut self) {
        for k in 0..LIMBS - 1 {
            let carry = self.limbs[k] >> LIMB_BITS;
            self.limbs[k] -= carry << LIMB_BITS;
            self.limbs[k + 1] += carry;
        }
        self.adds = 0;
    }

    /// Adds another exact sum (the merge of two partial sums).
    pub fn merge(&mut self, other: &ExactSum) {
        let mut other = other.clone();
        other.normalise();
        self.normalise();
        for (a, b) in self.limbs.iter_mut().zip(other.limbs) {
            *a += b;
        }
        if other.has_special {
            self.add(f64::from_bits(other.special_bits));
        }
    }

    /// The state as words for an integer sum across ranks: after [`Self::to_words`] on every
    /// rank, an element-wise i64 sum of the words followed by [`Self::from_words`] equals the
    /// merge of all the sums. The last two words carry the special values.
    pub fn to_words(&self) -> [i64; LIMBS + 2] {
        let mut normal = self.clone();
        normal.normalise();
        let mut words = [0; LIMBS + 2];
        words[..LIMBS].copy_from_slice(&normal.limbs);
        // specials cannot be summed as integers: count infinities of each sign and NaNs
        if self.has_special {
            let s = f64::from_bits(self.special_bits);
            words[LIMBS] = if s.is_nan() { 1 << 40 } else if s > 0.0 { 1 } else { 0 };
            words[LIMBS + 1] = if s.is_nan() { 0 } else if s < 0.0 { 1 } else { 0 };
        }
        words
    }

    /// Inverse of [`Self::to_words`] after the words of several sums were added.
    pub fn from_words(words: &[i64]) -> Self {
        let mut sum = Self::default();
        sum.limbs.copy_from_slice(&words[..LIMBS]);
        let (positive_or_nan, negative) = (words[LIMBS], words[LIMBS + 1]);
        let special = if positive_or_nan >= 1 << 40 || (positive_or_nan > 0 && negative > 0) {
            Some(f64::NAN)
        } else if positive_or_nan > 0 {
            Some(f64::INFINITY)
        } else if negative > 0 {
            Some(f64::NEG_INFINITY)
        } else {
            None
        };
        if let Some(s) = special {
            sum.special_bits = s.to_bits();
            sum.has_special = true;
        }
        sum
    }

    /// The exact sum rounded to the nearest f64 (ties to even; one rounding, so the result
    /// depends on the set of values added, not on their order).
    pub fn value(&self) -> f64 {
        if self.has_special {
            return f64::from_bits(self.special_bits);
        }
        let mut limbs = self.clone();
        limbs.normalise();
        let negative = limbs.limbs[LIMBS - 1] < 0;
        if negative {
            for l in limbs.limbs.iter_mut() {
                *l = -*l;
            }
            limbs.normalise();
        }
        let Some(top) = limbs.limbs.iter().rposition(|&l| l != 0) else { return 0.0 };
        // the top four limbs hold at least 97 significant bits; anything below only decides
        // ties, so it becomes a sticky bit far under the rounding position
        let mut head: u128 = 0;
        for k in 0..4 {
            head <<= LIMB_BITS;
            if top >= k {
                head |= limbs.limbs[top - k] as u128;
            }
        }
        if top >= 4 && limbs.limbs[..top - 3].iter().any(|&l| l != 0) {
            head |= 1;
        }
        let exponent = LIMB_BITS as i32 * (top as i32 - 3) - 1074;
        let magnitude = scale_by_power_of_two(head as f64, exponent);
        if negative {
            -magnitude
        } else {
            magnitude
        }
    }
}

/// `x 2^e` by exact power-of-two factors (no intermediate overflow).
fn scale_by_power_of_two(mut x: f64, mut e: i32) -> f64 {
    let step = |k: i32| f64::from_bits(((k + 1023) as u64) << 52);
    while e > 1000 {
        x *= step(1000);
        e -= 1000;
    }
    while e < -1000 {
        x *= step(-1000);
        e += 1000;
    }
    x * step(e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};

    fn sum(values: &[f64]) -> f64 {
        let mut s = ExactSum::new();
        values.iter().for_each(|&v| s.add(v));
        s.value()
    }

    #[test]
    fn cancellation_is_exact() {
        assert_eq!(sum(&[1e16, 1.0, -1e16]), 1.0);
        assert_eq!(sum(&[1e300, 1e-300, -1e300]), 1e-300);
        // the doubles nearest 0.1, 0.2, 0.3 sum to exactly 2^-55; naive summation gives 2^-54
        assert_eq!(sum(&[0.1, 0.2, -0.3]), 2f64.powi(-55));
        assert_eq!(sum(&[f64::MIN_POSITIVE / 8.0, f64::MIN_POSITIVE / 8.0]), f64::MIN_POSITIVE / 4.0);
        assert_eq!(sum(&[-2.5, 1.0]), -1.5);
        assert_eq!(sum(&[]), 0.0);
    }

    #[test]
    fn integers_sum_exactly_and_round_once() {
        // 2^53 + 1 is not a double: the exact sum rounds to even, 2^53
        assert_eq!(sum(&[9007199254740992.0, 1.0]), 9007199254740992.0);
        // 2^53 + 1 + 1 is exact
        assert_eq!(sum(&[9007199254740992.0, 1.0, 1.0]), 9007199254740994.0);
        // a tie decided by a far smaller term (the sticky bit)
        assert_eq!(sum(&[9007199254740992.0, 1.0, 1e-30]), 9007199254740994.0);
    }

    #[test]
    fn order_and_grouping_do_not_change_the_bits() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut values: Vec<f64> = (0..5000).map(|_| rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-20..20))).collect();
        let reference = sum(&values);
        // the naive sum in the same order generally differs in the last bits
        for _ in 0..5 {
            values.shuffle(&mut rng);
            assert_eq!(sum(&values).to_bits(), reference.to_bits());
            // split into uneven parts, merged directly and through integer words
            let cut = rng.random_range(0..values.len());
            let (mut a, mut b) = (ExactSum::new(), ExactSum::new());
            values[..cut].iter().for_each(|&v| a.add(v));
            values[cut..].iter().for_each(|&v| b.add(v));
            let mut merged = a.clone();
            merged.merge(&b);
            assert_eq!(merged.value().to_bits(), reference.to_bits());
            let (wa, wb) = (a.to_words(), b.to_words());
            let words: Vec<i64> = wa.iter().zip(wb.iter()).map(|(x, y)| x + y).collect();
            assert_eq!(ExactSum::from_words(&words).value().to_bits(), reference.to_bits());
        }
        // and the exact result is within one rounding of a compensated reference
        let mut sorted = values.clone();
        sorted.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
        let approx: f64 = sorted.iter().sum();
        assert!((approx - reference).abs() <= 1e-12 * values.iter().map(|v| v.abs()).sum::<f64>());
    }

    #[test]
    fn specials_propagate_through_words() {
        let mut a = ExactSum::new();
        a.add(1.0);
        a.add(f64::INFINITY);
        let mut b = ExactSum::new();
        b.add(f64::NEG_INFINITY);
        let words: Vec<i64> = a.to_words().iter().zip(b.to_words().iter()).map(|(x, y)| x + y).collect();
        assert!(ExactSum::from_words(&words).value().is_nan());
        assert_eq!(ExactSum::from_words(&a.to_words()).value(), f64::INFINITY);
    }
}
