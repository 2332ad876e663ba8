//! Lanes of the sweeps: four (glam's `Vec4`, SSE) or eight (`F8`, AVX2: two wide
//! constraints of one colour side by side). The sweeps are written once over [`Lanes`];
//! each operation of `F8` is the AVX form of the SSE instruction `Vec4` uses, lane for
//! lane the same IEEE operation with the same operand order, so eight lanes give the
//! bits four give.

use glam::Vec4;
use std::ops::{Add, Mul, Neg, Sub};

/// The arithmetic the sweeps use, lane by lane.
pub(super) trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    type Mask: Copy;
    fn splat(x: f32) -> Self;
    /// min(self, o): `o` where either is NaN, as `minps`.
    fn min(self, o: Self) -> Self;
    /// max(self, o): `o` where either is NaN, as `maxps`.
    fn max(self, o: Self) -> Self;
    fn abs(self) -> Self;
    /// self > o (false where either is NaN)
    fn gt(self, o: Self) -> Self::Mask;
    /// `a` where the mask is set, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
}

impl Lanes for Vec4 {
    type Mask = glam::BVec4A;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Vec4::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Vec4::max(self, o)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        self.cmpgt(o)
    }
    #[inline(always)]
    fn select(m: Self::Mask, a: Self, b: Self) -> Self {
        Vec4::select(m, a, b)
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::F8;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Lanes;
    use glam::Vec4;
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    /// Eight f32 lanes in an AVX register: lanes 0..4 one wide constraint's, 4..8 the
    /// next one's. Only built inside the sweeps' AVX2 functions: every method is inlined
    /// into them, so its AVX instructions run only where the CPU has AVX2 (checked before
    /// those functions are called).
    #[derive(Clone, Copy)]
    pub(in crate::solver) struct F8(__m256);

    // SAFETY (every `unsafe` below): the intrinsics need AVX, and these methods are
    // only reached from functions compiled with `target_feature(enable = "avx2")`, which
    // are only called after AVX2 was detected at run time (see the type's docs).
    impl F8 {
        /// Lanes 0..4 from `lo`, 4..8 from `hi`.
        #[inline(always)]
        pub(in crate::solver) fn join(lo: Vec4, hi: Vec4) -> F8 {
            F8(unsafe { _mm256_set_m128(hi.into(), lo.into()) })
        }
        /// The register.
        #[inline(always)]
        pub(in crate::solver) fn raw(self) -> __m256 {
            self.0
        }
        /// From a register.
        #[inline(always)]
        pub(in crate::solver) fn from_raw(v: __m256) -> F8 {
            F8(v)
        }
        /// (lanes 0..4, lanes 4..8)
        #[inline(always)]
        pub(in crate::solver) fn split(self) -> (Vec4, Vec4) {
            unsafe {
                (
                    _mm256_castps256_ps128(self.0).into(),
                    _mm256_extractf128_ps::<1>(self.0).into(),
                )
            }
        }
    }

    impl Add for F8 {
        type Output = F8;
        #[inline(always)]
        fn add(self, o: F8) -> F8 {
            F8(unsafe { _mm256_add_ps(self.0, o.0) })
        }
    }
    impl Sub for F8 {
        type Output = F8;
        #[inline(always)]
        fn sub(self, o: F8) -> F8 {
            F8(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
    }
    impl Mul for F8 {
        type Output = F8;
        #[inline(always)]
        fn mul(self, o: F8) -> F8 {
            F8(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
    }
    impl Neg for F8 {
        type Output = F8;
        /// The sign bit flipped, as glam's `Vec4` does it.
        #[inline(always)]
        fn neg(self) -> F8 {
            F8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
        }
    }

    impl Lanes for F8 {
        type Mask = F8;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            F8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            F8(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            F8(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        /// The sign bit cleared, as glam's `Vec4` does it.
        #[inline(always)]
        fn abs(self) -> Self {
            F8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self::Mask {
            // ordered, signalling: `cmpltps` with the operands swapped, as SSE's cmpgt
            F8(unsafe { _mm256_cmp_ps::<_CMP_GT_OS>(self.0, o.0) })
        }
        #[inline(always)]
        fn select(m: Self::Mask, a: Self, b: Self) -> Self {
            // the mask's lanes are all ones or all zeros: a blend picks as and/or do
            F8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
        }
    }
}
