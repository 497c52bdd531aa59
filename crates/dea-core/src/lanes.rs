//! Four `f64` lanes on AVX2, for the rod and integration kernels and the contact search.
//!
//! The rod passes are bound by the latency of a chain of square root, division and a
//! polynomial per node; four nodes in the lanes of one register run four chains at once.
//! The contact search tests four candidates at a time ([`U4`] for their places on the chain)
//! and packs the hits without a branch per candidate ([`pack_counting`]).
//! Every lane does exactly the operations the scalar code does, in the same order (Rust never
//! contracts to fused multiply–adds), and IEEE arithmetic rounds each lane as it rounds a
//! scalar: the lanes give the scalar code's bits, which the kernels' tests check.
//!
//! Everything here needs AVX2 in its caller (`#[target_feature(enable = "avx2")]`); a kernel
//! is entered through [`crate::in_avx2_lanes`], which calls it only when [`available`] says the
//! processor has it.

use std::arch::x86_64::*;

use crate::Vec3;

// `V4` reads and writes 3-vectors as consecutive f64 triples
const _: () = assert!(std::mem::size_of::<Vec3>() == 3 * std::mem::size_of::<f64>());

/// True when this processor runs AVX2 (checked once; the answer is cached by `std`).
#[inline]
pub fn available() -> bool {
    is_x86_feature_detected!("avx2")
}

/// A lane-by-lane arithmetic operation of [`F4`] by its intrinsic.
macro_rules! binary {
    ($name:ident, $intrinsic:ident) => {
        #[target_feature(enable = "avx2")]
        #[inline]
        /// Lane by lane.
        pub fn $name(self, other: Self) -> Self {
            Self($intrinsic(self.0, other.0))
        }
    };
}

/// Four `f64` values.
#[derive(Clone, Copy)]
pub struct F4(__m256d);

/// Four lane conditions (all bits set where true).
#[derive(Clone, Copy)]
pub struct Mask(__m256d);

impl F4 {
    #[target_feature(enable = "avx2")]
    #[inline]
    /// `value` in every lane.
    pub fn splat(value: f64) -> Self {
        Self(_mm256_set1_pd(value))
    }

    /// `value(k)` for the four indices `k` from `start` on (a per-node quantity not stored
    /// per node, such as a section's).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn gather(start: usize, value: impl Fn(usize) -> f64) -> Self {
        Self(_mm256_setr_pd(value(start), value(start + 1), value(start + 2), value(start + 3)))
    }

    /// The four values of `values` from index `start` on.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn load(values: &[f64], start: usize) -> Self {
        let four = &values[start..start + 4];
        // SAFETY: `four` holds four f64 values, and the load accepts any alignment
        Self(unsafe { _mm256_loadu_pd(four.as_ptr()) })
    }

    /// Writes the four values to `values` from index `start` on.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn store(self, values: &mut [f64], start: usize) {
        let four = &mut values[start..start + 4];
        // SAFETY: `four` holds four f64 values, and the store accepts any alignment
        unsafe { _mm256_storeu_pd(four.as_mut_ptr(), self.0) }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    /// The four lanes, lowest first.
    pub fn to_array(self) -> [f64; 4] {
        let mut values = [0.0; 4];
        self.store(&mut values, 0);
        values
    }

    binary!(add, _mm256_add_pd);
    binary!(sub, _mm256_sub_pd);
    binary!(mul, _mm256_mul_pd);
    binary!(div, _mm256_div_pd);

    #[target_feature(enable = "avx2")]
    #[inline]
    /// The square root of each lane.
    pub fn sqrt(self) -> Self {
        Self(_mm256_sqrt_pd(self.0))
    }

    /// `self.max(other)` in each lane where `self` is not NaN; `other` where it is (as the
    /// scalar `other.max(self)` does).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn max_with(self, other: Self) -> Self {
        Self(_mm256_max_pd(self.0, other.0))
    }

    /// `self < other` in each lane (false on NaN, as the scalar comparison).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn lt(self, other: Self) -> Mask {
        Mask(_mm256_cmp_pd::<_CMP_LT_OQ>(self.0, other.0))
    }

    /// `self >= other` in each lane (false on NaN).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn ge(self, other: Self) -> Mask {
        Mask(_mm256_cmp_pd::<_CMP_GE_OQ>(self.0, other.0))
    }

    /// `self == other` in each lane (false on NaN).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn eq(self, other: Self) -> Mask {
        Mask(_mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, other.0))
    }

    /// `if mask { if_true } else { if_false }` in each lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn select(mask: Mask, if_true: Self, if_false: Self) -> Self {
        Self(_mm256_blendv_pd(if_false.0, if_true.0, mask.0))
    }
}

impl Mask {
    #[target_feature(enable = "avx2")]
    #[inline]
    /// Set in the lanes set in both.
    pub fn and(self, other: Self) -> Self {
        Self(_mm256_and_pd(self.0, other.0))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    /// Set in the lanes set in either.
    pub fn or(self, other: Self) -> Self {
        Self(_mm256_or_pd(self.0, other.0))
    }

    /// The lanes as bits, lane 0 lowest (set where true).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn bits(self) -> u32 {
        _mm256_movemask_pd(self.0) as u32
    }

    /// True when every lane is true.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn all(self) -> bool {
        self.bits() == 0b1111
    }
}

/// Four `u64` values.
#[derive(Clone, Copy)]
pub struct U4(__m256i);

impl U4 {
    #[target_feature(enable = "avx2")]
    #[inline]
    /// `value` in every lane.
    pub fn splat(value: u64) -> Self {
        Self(_mm256_set1_epi64x(value as i64))
    }

    /// The four values of `values` from index `start` on.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn load(values: &[u64], start: usize) -> Self {
        let four = &values[start..start + 4];
        // SAFETY: `four` holds four u64 values, and the load accepts any alignment
        Self(unsafe { _mm256_loadu_si256(four.as_ptr().cast()) })
    }

    /// `(self - other) as i64` (wrapping) within `-limit..=limit` in each lane (`limit` below
    /// 2^63).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn distance_within(self, other: Self, limit: Self) -> Mask {
        let difference = _mm256_sub_epi64(self.0, other.0);
        let negative_limit = _mm256_sub_epi64(_mm256_setzero_si256(), limit.0);
        let outside =
            _mm256_or_si256(_mm256_cmpgt_epi64(difference, limit.0), _mm256_cmpgt_epi64(negative_limit, difference));
        Mask(_mm256_castsi256_pd(_mm256_andnot_si256(outside, _mm256_set1_epi64x(-1))))
    }
}

/// Four 3-vectors, one per lane, component by component.
#[derive(Clone, Copy)]
pub struct V4 {
    /// x components
    pub x: F4,
    /// y components
    pub y: F4,
    /// z components
    pub z: F4,
}

impl V4 {
    /// The four vectors of `vectors` from index `start` on: three loads and a transpose.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn load(vectors: &[Vec3], start: usize) -> Self {
        let four = &vectors[start..start + 4];
        let values = four.as_ptr().cast::<f64>();
        // SAFETY: four 3-vectors of f64 are twelve consecutive f64 values (size checked below)
        let [m0, m1, m2] =
            unsafe { [_mm256_loadu_pd(values), _mm256_loadu_pd(values.add(4)), _mm256_loadu_pd(values.add(8))] };
        // m0 = x0 y0 z0 x1, m1 = y1 z1 x2 y2, m2 = z2 x3 y3 z3
        let a = _mm256_blend_pd::<0b1100>(m0, m1); // x0 y0 x2 y2
        let b = _mm256_permute2f128_pd::<0x21>(m0, m2); // z0 x1 z2 x3
        let c = _mm256_blend_pd::<0b1100>(m1, m2); // y1 z1 y3 z3
        Self {
            x: F4(_mm256_blend_pd::<0b1010>(a, b)),
            y: F4(_mm256_shuffle_pd::<0b0101>(a, c)),
            z: F4(_mm256_blend_pd::<0b1010>(b, c)),
        }
    }

    /// Writes the four vectors to `vectors` from index `start` on: a transpose and three
    /// stores.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn store(self, vectors: &mut [Vec3], start: usize) {
        let (x, y, z) = (self.x.0, self.y.0, self.z.0);
        let a = _mm256_shuffle_pd::<0b0000>(x, y); // x0 y0 x2 y2
        let b = _mm256_blend_pd::<0b1010>(z, x); // z0 x1 z2 x3
        let c = _mm256_shuffle_pd::<0b1111>(y, z); // y1 z1 y3 z3
        let four = &mut vectors[start..start + 4];
        let values = four.as_mut_ptr().cast::<f64>();
        // SAFETY: as in `load`
        unsafe {
            _mm256_storeu_pd(values, _mm256_permute2f128_pd::<0x20>(a, b));
            _mm256_storeu_pd(values.add(4), _mm256_permute2f128_pd::<0x30>(c, a));
            _mm256_storeu_pd(values.add(8), _mm256_permute2f128_pd::<0x31>(b, c));
        }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    /// The lanes' vector sums.
    pub fn add(self, other: Self) -> Self {
        Self { x: self.x.add(other.x), y: self.y.add(other.y), z: self.z.add(other.z) }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    /// The lanes' vector differences.
    pub fn sub(self, other: Self) -> Self {
        Self { x: self.x.sub(other.x), y: self.y.sub(other.y), z: self.z.sub(other.z) }
    }

    /// Each lane's vector times its lane of `factor`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn scale(self, factor: F4) -> Self {
        Self { x: self.x.mul(factor), y: self.y.mul(factor), z: self.z.mul(factor) }
    }

    /// `(x x' + y y') + z z'`, nalgebra's order for three components.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn dot(self, other: Self) -> F4 {
        self.x.mul(other.x).add(self.y.mul(other.y)).add(self.z.mul(other.z))
    }

    /// `if mask { if_true } else { if_false }` in each lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn select(mask: Mask, if_true: Self, if_false: Self) -> Self {
        Self {
            x: F4::select(mask, if_true.x, if_false.x),
            y: F4::select(mask, if_true.y, if_false.y),
            z: F4::select(mask, if_true.z, if_false.z),
        }
    }

    /// nalgebra's cross product, component for component.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn cross(self, other: Self) -> Self {
        Self {
            x: self.y.mul(other.z).sub(self.z.mul(other.y)),
            y: self.z.mul(other.x).sub(self.x.mul(other.z)),
            z: self.x.mul(other.y).sub(self.y.mul(other.x)),
        }
    }
}

/// Shuffles for [`pack_counting`]: for each four-bit mask, the bytes of the set lanes' 32-bit
/// values, lowest lane first.
const PACK_SHUFFLES: [[u8; 16]; 16] = {
    let mut table = [[0x80u8; 16]; 16];
    let mut mask = 0;
    while mask < 16 {
        let (mut lane, mut packed) = (0, 0);
        while lane < 4 {
            if mask & (1 << lane) != 0 {
                let mut byte = 0;
                while byte < 4 {
                    table[mask][4 * packed + byte] = (4 * lane + byte) as u8;
                    byte += 1;
                }
                packed += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

/// Writes to the front of `to` those of `start..start + 4` whose bit is set in `bits` (lane 0
/// lowest), in order, and returns how many: a left-pack without branches.
#[target_feature(enable = "avx2")]
#[inline]
pub fn pack_counting(start: u32, bits: u32, to: &mut [u32]) -> usize {
    let to = &mut to[..4];
    let bits = bits as usize & 0b1111;
    let values = _mm_add_epi32(_mm_set1_epi32(start as i32), _mm_setr_epi32(0, 1, 2, 3));
    // SAFETY: `to` holds four u32 values, the table row sixteen bytes, and the load and
    // store accept any alignment
    unsafe {
        let shuffle = _mm_loadu_si128(PACK_SHUFFLES[bits].as_ptr().cast());
        _mm_storeu_si128(to.as_mut_ptr().cast(), _mm_shuffle_epi8(values, shuffle));
    }
    bits.count_ones() as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_round_as_the_scalar_code() {
        if !available() {
            return;
        }
        let a = [
            Vec3::new(0.3, -1.7, 2.9),
            Vec3::new(1e-9, 3.3, -0.1),
            Vec3::new(-4.0, 0.25, 7.5),
            Vec3::new(0.1, 0.2, 0.3),
        ];
        let b = [
            Vec3::new(-2.2, 0.6, 1.1),
            Vec3::new(5.0, -1e-7, 0.7),
            Vec3::new(0.9, 0.8, -0.7),
            Vec3::new(0.3, 0.2, 0.1),
        ];
        // SAFETY: AVX2 is present (checked above)
        let (cross, dot, norm) = unsafe { check(&a, &b) };
        for k in 0..4 {
            assert_eq!(cross[k], a[k].cross(&b[k]));
            assert_eq!(dot[k].to_bits(), a[k].dot(&b[k]).to_bits());
            assert_eq!(norm[k].to_bits(), (1.0 / a[k].norm()).to_bits());
        }

        #[target_feature(enable = "avx2")]
        fn check(a: &[Vec3], b: &[Vec3]) -> (Vec<Vec3>, [f64; 4], [f64; 4]) {
            let (a, b) = (V4::load(a, 0), V4::load(b, 0));
            let mut cross = vec![Vec3::zeros(); 6];
            a.cross(b).store(&mut cross, 1);
            assert_eq!((cross[0], cross[5]), (Vec3::zeros(), Vec3::zeros()), "the store stays within its four vectors");
            cross.remove(0);
            (cross, a.dot(b).to_array(), F4::splat(1.0).div(a.dot(a).sqrt()).to_array())
        }
    }

    #[test]
    fn packing_keeps_the_set_lanes_in_order() {
        if !available() {
            return;
        }
        for bits in 0..16u32 {
            let mut to = [u32::MAX; 5];
            // SAFETY: AVX2 is present (checked above)
            let count = unsafe { pack_counting(40, bits | 0b110000, &mut to) };
            let expected: Vec<u32> = (0..4).filter(|lane| bits & (1 << lane) != 0).map(|lane| 40 + lane).collect();
            assert_eq!(count, expected.len(), "bits {bits:04b}: the bits above the four lanes are ignored");
            assert_eq!(&to[..count], &expected[..], "bits {bits:04b}");
            assert_eq!(to[4], u32::MAX, "the store stays within its four values");
        }
    }

    #[test]
    fn distance_within_wraps_as_the_scalar_difference() {
        if !available() {
            return;
        }
        let place = 7u64 << 32 | 100;
        let others = [place + 3, place - 4, (8u64 << 32) | 100, place.wrapping_sub(1 << 32) + 2];
        // SAFETY: AVX2 is present (checked above)
        let bits = unsafe { U4::load(&others, 0).distance_within(U4::splat(place), U4::splat(3)).bits() };
        assert_eq!(bits, 0b0001, "within 3 below and above, not 4 away, not on another fibre");
    }
}
