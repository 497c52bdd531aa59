//! Four `f64` lanes on AVX2, for the rod and integration kernels.
//!
//! The rod passes are bound by the latency of a chain of square root, division and a
//! polynomial per node; four nodes in the lanes of one register run four chains at once.
//! Every lane does exactly the operations the scalar code does, in the same order (Rust never
//! contracts to fused multiply–adds), and IEEE arithmetic rounds each lane as it rounds a
//! scalar: the lanes give the scalar code's bits, which the kernels' tests check.
//!
//! Everything here needs AVX2 in its caller (`#[target_feature(enable = "avx2")]`); a kernel
//! takes the lanes only when [`available`] says the processor has it.

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
    pub fn splat(value: f64) -> Self {
        Self(_mm256_set1_pd(value))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn new(values: [f64; 4]) -> Self {
        Self(_mm256_setr_pd(values[0], values[1], values[2], values[3]))
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
    pub fn and(self, other: Self) -> Self {
        Self(_mm256_and_pd(self.0, other.0))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn or(self, other: Self) -> Self {
        Self(_mm256_or_pd(self.0, other.0))
    }

    /// True when every lane is true.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn all(self) -> bool {
        _mm256_movemask_pd(self.0) == 0b1111
    }
}

/// Four 3-vectors, one per lane, component by component.
#[derive(Clone, Copy)]
pub struct V4 {
    pub x: F4,
    pub y: F4,
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
        let [m0, m1, m2] = unsafe { [_mm256_loadu_pd(values), _mm256_loadu_pd(values.add(4)), _mm256_loadu_pd(values.add(8))] };
        // m0 = x0 y0 z0 x1, m1 = y1 z1 x2 y2, m2 = z2 x3 y3 z3
        let a = _mm256_blend_pd::<0b1100>(m0, m1); // x0 y0 x2 y2
        let b = _mm256_permute2f128_pd::<0x21>(m0, m2); // z0 x1 z2 x3
        let c = _mm256_blend_pd::<0b1100>(m1, m2); // y1 z1 y3 z3
        Self { x: F4(_mm256_blend_pd::<0b1010>(a, b)), y: F4(_mm256_shuffle_pd::<0b0101>(a, c)), z: F4(_mm256_blend_pd::<0b1010>(b, c)) }
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
    pub fn add(self, other: Self) -> Self {
        Self { x: self.x.add(other.x), y: self.y.add(other.y), z: self.z.add(other.z) }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
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

    /// nalgebra's cross product, component for component.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn cross(self, other: Self) -> Self {
        Self { x: self.y.mul(other.z).sub(self.z.mul(other.y)), y: self.z.mul(other.x).sub(self.x.mul(other.z)), z: self.x.mul(other.y).sub(self.y.mul(other.x)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_round_as_the_scalar_code() {
        if !available() {
            return;
        }
        let a = [Vec3::new(0.3, -1.7, 2.9), Vec3::new(1e-9, 3.3, -0.1), Vec3::new(-4.0, 0.25, 7.5), Vec3::new(0.1, 0.2, 0.3)];
        let b = [Vec3::new(-2.2, 0.6, 1.1), Vec3::new(5.0, -1e-7, 0.7), Vec3::new(0.9, 0.8, -0.7), Vec3::new(0.3, 0.2, 0.1)];
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
}
