//! One source for the two vector paths: [`Wide`] is a vector of f64 lanes, 8 on AVX-512
//! ([`W8`]) and 4 on AVX2 ([`W4`]), and the kernels' vector code ([`crate::stencil::vector`],
//! the cubic and hexagonal stencils', the row kernel's) is written once over it.
//!
//! **The same bits on both.** Every operation here is one IEEE operation lane by lane (add,
//! subtract, multiply, divide, square root; never a fused multiply-add), so a kernel written
//! over `Wide` performs the portable path's operations in each lane, whatever the width. What
//! differs between the widths is only how lanes are chosen: AVX-512 has mask registers (a
//! masked add keeps the unchosen lanes), AVX2 has all-ones lanes (a blend keeps them); both
//! leave an unchosen lane's bits as they were.
//!
//! **Safety.** A vector ([`V8`], [`V4`]) and a lane mask can only be made through a width's
//! token, and a token only by `unsafe fn new`, whose contract is that the processor has the
//! width's instructions. So a vector's existence proves the instructions are there, and the
//! arithmetic on it is safe. What reads or writes memory through a pointer stays `unsafe`.
//! Every function is `#[inline(always)]`: a kernel's entry (`#[target_feature]`) inlines the
//! generic code, and the intrinsics inside it then inline into that entry. Closures and
//! `array::map` are avoided in generic code for the same reason (they would not inherit the
//! entry's target features, and each operation would become a call).

use std::arch::x86_64::*;
use std::ops::{Add, BitOr, Div, Mul, Sub};

use crate::stencil::CLASSES;
use hooke_model::math::Real;

/// A width of vector lanes: its token is proof that the processor has the instructions.
pub(crate) trait Wide: Copy {
    /// Lanes per vector.
    const N: usize;
    /// N doubles.
    type F: Copy
        + Add<Output = Self::F>
        + Sub<Output = Self::F>
        + Mul<Output = Self::F>
        + Div<Output = Self::F>;
    /// A choice of lanes.
    type M: Copy + BitOr<Output = Self::M>;
    /// N 64-bit integers (a stencil's mask words, one per lane).
    type I: Copy;

    /// `x` in every lane.
    fn splat(self, x: Real) -> Self::F;
    /// +0 in every lane.
    fn zero(self) -> Self::F;
    /// The square root, lane by lane.
    fn sqrt(self, x: Self::F) -> Self::F;
    /// `acc + x` in the lanes `m`, `acc` (its bits) in the others.
    fn add_where(self, acc: Self::F, m: Self::M, x: Self::F) -> Self::F;
    /// The lanes of `m` where `a > b` (ordered: a NaN is never greater).
    fn gt_where(self, m: Self::M, a: Self::F, b: Self::F) -> Self::M;
    /// `a / b` where `b` is not zero, +0 where it is.
    fn div_where_nonzero(self, a: Self::F, b: Self::F) -> Self::F;
    /// No lane.
    fn no_lanes(self) -> Self::M;
    /// Whether `m` holds a lane.
    fn any(self, m: Self::M) -> bool;
    /// The lanes whose word has bit `d` set.
    fn bit(self, words: Self::I, d: usize) -> Self::M;
    /// The words shifted right by `shift` (a stencil node's weight class), if one is not zero.
    fn classes(self, words: Self::I, shift: u32) -> Option<Self::I>;
    /// `row[c]` for each lane's class `c`.
    ///
    /// Each class is below [`CLASSES`] (the stencils' set-up puts at most that many in the
    /// spare bits of their mask words), which keeps the lookup inside `row`.
    fn factors(self, row: &[Real; CLASSES], c: Self::I) -> Self::F;
    /// The lanes, in the first N entries.
    fn lanes(self, v: Self::F) -> [Real; 8];

    /// N doubles from `p` (any alignment).
    ///
    /// # Safety
    /// `p..p + N` is readable.
    unsafe fn load(self, p: *const Real) -> Self::F;
    /// The lanes of `v` into `p..p + N` (any alignment).
    ///
    /// # Safety
    /// `p..p + N` is writable.
    unsafe fn store(self, p: *mut Real, v: Self::F);
    /// N 32-bit mask words from `p`, one per lane.
    ///
    /// # Safety
    /// `p..p + N` is readable.
    unsafe fn words32(self, p: *const u32) -> Self::I;
    /// N 16-bit mask words from `p`, one per lane.
    ///
    /// # Safety
    /// `p..p + N` is readable (the AVX-512 load reads 8 words, N of them).
    unsafe fn words16(self, p: *const u16) -> Self::I;
    /// The row kernel's records of the N nodes `js[..N]`, transposed: component c of each
    /// lane's record in vector c (the padding component left out).
    ///
    /// # Safety
    /// `base` points to the records, each 64-byte aligned and 8 reals, and `js[..N]` (`js` has
    /// at least N entries) name records.
    unsafe fn records(self, base: *const Real, js: &[u32]) -> [Self::F; 7];
    /// The lanes whose entry of `js..js + N` is not `dummy`.
    ///
    /// # Safety
    /// `js..js + N` is readable.
    unsafe fn real(self, js: *const u32, dummy: u32) -> Self::M;
}

/// AVX-512: 8 lanes, masks in mask registers.
#[derive(Clone, Copy)]
pub(crate) struct W8(());

/// AVX2: 4 lanes, masks as all-ones lanes.
#[derive(Clone, Copy)]
pub(crate) struct W4(());

impl W8 {
    /// The token.
    ///
    /// # Safety
    /// The processor has AVX-512F and AVX-512VL.
    #[inline(always)]
    pub(crate) unsafe fn new() -> W8 {
        W8(())
    }
}

impl W4 {
    /// The token.
    ///
    /// # Safety
    /// The processor has AVX2.
    #[inline(always)]
    pub(crate) unsafe fn new() -> W4 {
        W4(())
    }
}

/// 8 doubles (made only through a [`W8`]).
#[derive(Clone, Copy)]
pub(crate) struct V8(__m512d);

/// 8 lanes' choice (made only through a [`W8`]).
#[derive(Clone, Copy)]
pub(crate) struct M8(__mmask8);

/// 8 64-bit integers (made only through a [`W8`]).
#[derive(Clone, Copy)]
pub(crate) struct I8(__m512i);

/// 4 doubles (made only through a [`W4`]).
#[derive(Clone, Copy)]
pub(crate) struct V4(__m256d);

/// 4 lanes' choice, all ones in the chosen lanes (made only through a [`W4`]).
#[derive(Clone, Copy)]
pub(crate) struct M4(__m256d);

/// 4 64-bit integers (made only through a [`W4`]).
#[derive(Clone, Copy)]
pub(crate) struct I4(__m256i);

/// The four arithmetic operators of a vector type, each one intrinsic.
macro_rules! arithmetic {
    ($v:ident, $($op:ident $method:ident $intrinsic:ident),*) => { $(
        impl $op for $v {
            type Output = $v;
            #[inline(always)]
            fn $method(self, o: $v) -> $v {
                // SAFETY: a value of this type is made only through its width's token, whose
                // constructor's contract is that the processor has the instructions.
                $v(unsafe { $intrinsic(self.0, o.0) })
            }
        }
    )* };
}

arithmetic!(V8, Add add _mm512_add_pd, Sub sub _mm512_sub_pd, Mul mul _mm512_mul_pd,
    Div div _mm512_div_pd);
arithmetic!(V4, Add add _mm256_add_pd, Sub sub _mm256_sub_pd, Mul mul _mm256_mul_pd,
    Div div _mm256_div_pd);

impl BitOr for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitor(self, o: M8) -> M8 {
        M8(self.0 | o.0)
    }
}

impl BitOr for M4 {
    type Output = M4;
    #[inline(always)]
    fn bitor(self, o: M4) -> M4 {
        // SAFETY: an M4 is made only through a W4, so the processor has AVX2.
        M4(unsafe { _mm256_or_pd(self.0, o.0) })
    }
}

// In both impls below, every `unsafe` block that holds no pointer access is safe because
// `self` is the width's token: it exists only where the processor has the instructions.
impl Wide for W8 {
    const N: usize = 8;
    type F = V8;
    type M = M8;
    type I = I8;

    #[inline(always)]
    fn splat(self, x: Real) -> V8 {
        // SAFETY: the token (see above).
        V8(unsafe { _mm512_set1_pd(x) })
    }
    #[inline(always)]
    fn zero(self) -> V8 {
        // SAFETY: the token.
        V8(unsafe { _mm512_setzero_pd() })
    }
    #[inline(always)]
    fn sqrt(self, x: V8) -> V8 {
        // SAFETY: the token.
        V8(unsafe { _mm512_sqrt_pd(x.0) })
    }
    #[inline(always)]
    fn add_where(self, acc: V8, m: M8, x: V8) -> V8 {
        // SAFETY: the token.
        V8(unsafe { _mm512_mask_add_pd(acc.0, m.0, acc.0, x.0) })
    }
    #[inline(always)]
    fn gt_where(self, m: M8, a: V8, b: V8) -> M8 {
        // SAFETY: the token.
        M8(unsafe { _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(m.0, a.0, b.0) })
    }
    #[inline(always)]
    fn div_where_nonzero(self, a: V8, b: V8) -> V8 {
        // SAFETY: the token.
        V8(unsafe {
            let some = _mm512_cmp_pd_mask::<_CMP_NEQ_OQ>(b.0, _mm512_setzero_pd());
            _mm512_maskz_div_pd(some, a.0, b.0)
        })
    }
    #[inline(always)]
    fn no_lanes(self) -> M8 {
        M8(0)
    }
    #[inline(always)]
    fn any(self, m: M8) -> bool {
        m.0 != 0
    }
    #[inline(always)]
    fn bit(self, words: I8, d: usize) -> M8 {
        // SAFETY: the token.
        M8(unsafe { _mm512_test_epi64_mask(words.0, _mm512_set1_epi64(1 << d)) })
    }
    #[inline(always)]
    fn classes(self, words: I8, shift: u32) -> Option<I8> {
        // SAFETY: the token.
        unsafe {
            let c = _mm512_srl_epi64(words.0, _mm_cvtsi64_si128(shift as i64));
            (_mm512_test_epi64_mask(c, c) != 0).then_some(I8(c))
        }
    }
    #[inline(always)]
    fn factors(self, row: &[Real; CLASSES], c: I8) -> V8 {
        // SAFETY: the token; a row is CLASSES = 8 doubles, the load's width, and the
        // permutation picks lanes of that one vector.
        V8(unsafe { _mm512_permutexvar_pd(c.0, _mm512_loadu_pd(row.as_ptr())) })
    }
    #[inline(always)]
    fn lanes(self, v: V8) -> [Real; 8] {
        let mut out = [0.0; 8];
        // SAFETY: the token; `out` holds 8 doubles, the store's width.
        unsafe { _mm512_storeu_pd(out.as_mut_ptr(), v.0) };
        out
    }

    #[inline(always)]
    unsafe fn load(self, p: *const Real) -> V8 {
        // SAFETY: the token, and `p..p + 8` readable by the caller's contract.
        V8(unsafe { _mm512_loadu_pd(p) })
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut Real, v: V8) {
        // SAFETY: the token, and `p..p + 8` writable by the caller's contract.
        unsafe { _mm512_storeu_pd(p, v.0) }
    }
    #[inline(always)]
    unsafe fn words32(self, p: *const u32) -> I8 {
        // SAFETY: the token, and 8 words readable by the caller's contract.
        I8(unsafe { _mm512_cvtepu32_epi64(_mm256_loadu_si256(p as *const __m256i)) })
    }
    #[inline(always)]
    unsafe fn words16(self, p: *const u16) -> I8 {
        // SAFETY: the token, and 8 words readable by the caller's contract.
        I8(unsafe { _mm512_cvtepu16_epi64(_mm_loadu_si128(p as *const __m128i)) })
    }
    #[inline(always)]
    unsafe fn records(self, base: *const Real, js: &[u32]) -> [V8; 7] {
        // SAFETY: the token; by the caller's contract, every js[l] indexes a record (64-byte
        // aligned, 8 reals).
        unsafe {
            // Written out: a closure or `array::map` here might not be inlined.
            let r = [
                _mm512_load_pd(base.wrapping_add(8 * js[0] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[1] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[2] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[3] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[4] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[5] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[6] as usize)),
                _mm512_load_pd(base.wrapping_add(8 * js[7] as usize)),
            ];
            let a = [
                _mm512_unpacklo_pd(r[0], r[1]),
                _mm512_unpackhi_pd(r[0], r[1]),
                _mm512_unpacklo_pd(r[2], r[3]),
                _mm512_unpackhi_pd(r[2], r[3]),
                _mm512_unpacklo_pd(r[4], r[5]),
                _mm512_unpackhi_pd(r[4], r[5]),
                _mm512_unpacklo_pd(r[6], r[7]),
                _mm512_unpackhi_pd(r[6], r[7]),
            ];
            // Components c and c + 4 of four lanes at a time, then the two halves joined.
            let lo = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
            let hi = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
            let b0 = _mm512_permutex2var_pd(a[0], lo, a[2]);
            let b2 = _mm512_permutex2var_pd(a[0], hi, a[2]);
            let b1 = _mm512_permutex2var_pd(a[1], lo, a[3]);
            let b3 = _mm512_permutex2var_pd(a[1], hi, a[3]);
            let b4 = _mm512_permutex2var_pd(a[4], lo, a[6]);
            let b6 = _mm512_permutex2var_pd(a[4], hi, a[6]);
            let b5 = _mm512_permutex2var_pd(a[5], lo, a[7]);
            let b7 = _mm512_permutex2var_pd(a[5], hi, a[7]);
            let l2 = _mm512_set_epi64(11, 10, 9, 8, 3, 2, 1, 0);
            let h2 = _mm512_set_epi64(15, 14, 13, 12, 7, 6, 5, 4);
            [
                V8(_mm512_permutex2var_pd(b0, l2, b4)),
                V8(_mm512_permutex2var_pd(b1, l2, b5)),
                V8(_mm512_permutex2var_pd(b2, l2, b6)),
                V8(_mm512_permutex2var_pd(b3, l2, b7)),
                V8(_mm512_permutex2var_pd(b0, h2, b4)),
                V8(_mm512_permutex2var_pd(b1, h2, b5)),
                V8(_mm512_permutex2var_pd(b2, h2, b6)),
            ]
        }
    }
    #[inline(always)]
    unsafe fn real(self, js: *const u32, dummy: u32) -> M8 {
        // SAFETY: the token (AVX-512VL too), and 8 words readable by the caller's contract.
        M8(unsafe {
            let jv = _mm256_loadu_si256(js as *const __m256i);
            _mm256_cmpneq_epu32_mask(jv, _mm256_set1_epi32(dummy as i32))
        })
    }
}

/// Components 0..4 of four rows `a`, transposed: vector c holds component c of each row.
#[inline(always)]
fn transpose(_: W4, a: [__m256d; 4]) -> [__m256d; 4] {
    // SAFETY: the token (AVX2).
    unsafe {
        let t0 = _mm256_unpacklo_pd(a[0], a[1]);
        let t1 = _mm256_unpackhi_pd(a[0], a[1]);
        let t2 = _mm256_unpacklo_pd(a[2], a[3]);
        let t3 = _mm256_unpackhi_pd(a[2], a[3]);
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }
}

impl Wide for W4 {
    const N: usize = 4;
    type F = V4;
    type M = M4;
    type I = I4;

    #[inline(always)]
    fn splat(self, x: Real) -> V4 {
        // SAFETY: the token.
        V4(unsafe { _mm256_set1_pd(x) })
    }
    #[inline(always)]
    fn zero(self) -> V4 {
        // SAFETY: the token.
        V4(unsafe { _mm256_setzero_pd() })
    }
    #[inline(always)]
    fn sqrt(self, x: V4) -> V4 {
        // SAFETY: the token.
        V4(unsafe { _mm256_sqrt_pd(x.0) })
    }
    #[inline(always)]
    fn add_where(self, acc: V4, m: M4, x: V4) -> V4 {
        // SAFETY: the token.
        V4(unsafe { _mm256_blendv_pd(acc.0, _mm256_add_pd(acc.0, x.0), m.0) })
    }
    #[inline(always)]
    fn gt_where(self, m: M4, a: V4, b: V4) -> M4 {
        // SAFETY: the token.
        M4(unsafe { _mm256_and_pd(m.0, _mm256_cmp_pd::<_CMP_GT_OQ>(a.0, b.0)) })
    }
    #[inline(always)]
    fn div_where_nonzero(self, a: V4, b: V4) -> V4 {
        // SAFETY: the token. The quotient's other lanes are masked away to +0.
        V4(unsafe {
            let some = _mm256_cmp_pd::<_CMP_NEQ_OQ>(b.0, _mm256_setzero_pd());
            _mm256_and_pd(some, _mm256_div_pd(a.0, b.0))
        })
    }
    #[inline(always)]
    fn no_lanes(self) -> M4 {
        // SAFETY: the token.
        M4(unsafe { _mm256_setzero_pd() })
    }
    #[inline(always)]
    fn any(self, m: M4) -> bool {
        // SAFETY: the token.
        unsafe { _mm256_movemask_pd(m.0) != 0 }
    }
    #[inline(always)]
    fn bit(self, words: I4, d: usize) -> M4 {
        // SAFETY: the token.
        M4(unsafe {
            let bit = _mm256_set1_epi64x(1 << d);
            _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(words.0, bit), bit))
        })
    }
    #[inline(always)]
    fn classes(self, words: I4, shift: u32) -> Option<I4> {
        // SAFETY: the token.
        unsafe {
            let c = _mm256_srl_epi64(words.0, _mm_cvtsi64_si128(shift as i64));
            (_mm256_testz_si256(c, c) == 0).then_some(I4(c))
        }
    }
    #[inline(always)]
    fn factors(self, row: &[Real; CLASSES], c: I4) -> V4 {
        // SAFETY: the token; each class is below CLASSES (the trait's contract on the stencils'
        // set-up), so the gather stays in `row`.
        V4(unsafe { _mm256_i64gather_pd::<8>(row.as_ptr(), c.0) })
    }
    #[inline(always)]
    fn lanes(self, v: V4) -> [Real; 8] {
        let mut out = [0.0; 8];
        // SAFETY: the token; `out` holds 8 doubles, more than the store's 4.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v.0) };
        out
    }

    #[inline(always)]
    unsafe fn load(self, p: *const Real) -> V4 {
        // SAFETY: the token, and `p..p + 4` readable by the caller's contract.
        V4(unsafe { _mm256_loadu_pd(p) })
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut Real, v: V4) {
        // SAFETY: the token, and `p..p + 4` writable by the caller's contract.
        unsafe { _mm256_storeu_pd(p, v.0) }
    }
    #[inline(always)]
    unsafe fn words32(self, p: *const u32) -> I4 {
        // SAFETY: the token, and 4 words readable by the caller's contract.
        I4(unsafe { _mm256_cvtepu32_epi64(_mm_loadu_si128(p as *const __m128i)) })
    }
    #[inline(always)]
    unsafe fn words16(self, p: *const u16) -> I4 {
        // SAFETY: the token, and 4 words readable by the caller's contract.
        I4(unsafe { _mm256_cvtepu16_epi64(_mm_loadl_epi64(p as *const __m128i)) })
    }
    #[inline(always)]
    unsafe fn records(self, base: *const Real, js: &[u32]) -> [V4; 7] {
        // SAFETY: the token; by the caller's contract, js[..4] index records (64-byte
        // aligned, 8 reals: two aligned halves).
        unsafe {
            // Written out: a closure or `array::map` here would not be inlined.
            let (a, b, c, d) = (
                base.wrapping_add(8 * js[0] as usize),
                base.wrapping_add(8 * js[1] as usize),
                base.wrapping_add(8 * js[2] as usize),
                base.wrapping_add(8 * js[3] as usize),
            );
            let lo = transpose(
                self,
                [
                    _mm256_load_pd(a),
                    _mm256_load_pd(b),
                    _mm256_load_pd(c),
                    _mm256_load_pd(d),
                ],
            );
            let hi = transpose(
                self,
                [
                    _mm256_load_pd(a.add(4)),
                    _mm256_load_pd(b.add(4)),
                    _mm256_load_pd(c.add(4)),
                    _mm256_load_pd(d.add(4)),
                ],
            );
            [
                V4(lo[0]),
                V4(lo[1]),
                V4(lo[2]),
                V4(lo[3]),
                V4(hi[0]),
                V4(hi[1]),
                V4(hi[2]),
            ]
        }
    }
    #[inline(always)]
    unsafe fn real(self, js: *const u32, dummy: u32) -> M4 {
        // SAFETY: the token, and 4 words readable by the caller's contract.
        M4(unsafe {
            let jv = _mm_loadu_si128(js as *const __m128i);
            let eq = _mm_cmpeq_epi32(jv, _mm_set1_epi32(dummy as i32));
            let dummy = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(eq));
            // Not the dummy: the comparison's complement.
            _mm256_xor_pd(dummy, _mm256_castsi256_pd(_mm256_set1_epi64x(-1)))
        })
    }
}
