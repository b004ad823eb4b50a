//! The row kernel's vector path on AVX2, for processors without AVX-512.
//!
//! The rows keep their layout (groups of 8 lanes, slot by slot); AVX2 holds 4 doubles to a
//! vector, so each group is walked as two halves of 4 lanes, side by side in the same slot
//! loop (two independent chains of square roots and divisions for the processor to overlap).
//! A record is two 32-byte halves, `[X, Y, Z, u_x]` and `[u_y, u_z, p, 0]`: 4 records are 8
//! aligned loads and a 4 x 4 transpose of each half (8 shuffles). Every operation is the
//! AVX-512 path's (and so the scalar path's) lane by lane, with no fused multiply-adds: the
//! same bits.

use std::arch::x86_64::*;

use super::super::{StepParams, SweepSums};
use super::avx::{group_nodes, prefetch, Window};
use super::{RowKernel, Src, WINDOW};
use hooke_model::math::{Coords, Real};

/// Components 0..4 of four rows `a`, transposed: vector c holds component c of each row.
///
/// # Safety
/// The processor has AVX.
#[inline(always)]
unsafe fn transpose(a: [__m256d; 4]) -> [__m256d; 4] {
    // SAFETY: by the caller's contract, AVX.
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

/// The records of the 4 nodes `js`, transposed (the padding component left out).
///
/// # Safety
/// The processor has the function's target feature; `base` points to the records and every
/// index in `js` names one of them (a 64-byte aligned record of 8 reals).
#[inline(always)]
unsafe fn records(base: *const Real, js: &[u32]) -> [__m256d; 7] {
    // SAFETY: by the caller's contract, every js[l] indexes a record (64-byte aligned, 8 reals).
    unsafe {
        // Written out: a closure or `array::map` here is not inlined, and its loads become
        // calls (the helper has no target features of its own).
        let (a, b, c, d) = (
            base.wrapping_add(8 * js[0] as usize),
            base.wrapping_add(8 * js[1] as usize),
            base.wrapping_add(8 * js[2] as usize),
            base.wrapping_add(8 * js[3] as usize),
        );
        let lo = transpose([
            _mm256_load_pd(a),
            _mm256_load_pd(b),
            _mm256_load_pd(c),
            _mm256_load_pd(d),
        ]);
        let hi = transpose([
            _mm256_load_pd(a.add(4)),
            _mm256_load_pd(b.add(4)),
            _mm256_load_pd(c.add(4)),
            _mm256_load_pd(d.add(4)),
        ]);
        [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2]]
    }
}

/// One slot's values for 4 lanes (see the AVX-512 path's `Slot`); `dummy` is all ones in the
/// lanes whose entry is padding or a broken spring.
struct Slot {
    d: [__m256d; 3],
    d2: __m256d,
    num: __m256d,
    k: __m256d,
    rest: __m256d,
    lever: __m256d,
    dummy: __m256d,
    nb: [__m256d; 7],
}

/// The operations of the 4 entries from `e` (a slot's first or second half).
///
/// # Safety
/// AVX2; the 4 entries are in bounds of every slot array; `me` the lanes' own records.
#[inline(always)]
unsafe fn slot_at<const D: usize, const LEVER: bool, const STORED: bool>(
    rk: &RowKernel,
    base: *const Real,
    me: &[__m256d; 7],
    e: usize,
) -> Slot {
    let s = &rk.slots;
    // SAFETY: by the caller's contract, as stated.
    unsafe {
        let js = &s.j[e..e + 4];
        let jv = _mm_loadu_si128(s.j.as_ptr().add(e) as *const __m128i);
        let eq = _mm_cmpeq_epi32(jv, _mm_set1_epi32(rk.dummy() as i32));
        let dummy = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(eq));
        let nb = records(base, js);
        let z = _mm256_setzero_pd();
        let mut big = [z; 3];
        let mut w = [z; 3];
        for c in 0..D {
            big[c] = _mm256_sub_pd(nb[c], me[c]);
            w[c] = _mm256_sub_pd(nb[3 + c], me[3 + c]);
        }
        let d = [0, 1, 2].map(|c| _mm256_add_pd(big[c], w[c]));
        let sq = |a: [__m256d; 3], b: [__m256d; 3]| {
            let s = _mm256_add_pd(_mm256_mul_pd(a[0], b[0]), _mm256_mul_pd(a[1], b[1]));
            if D == 3 {
                _mm256_add_pd(s, _mm256_mul_pd(a[2], b[2]))
            } else {
                s
            }
        };
        let d2 = sq(d, d);
        let num = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(2.0), sq(big, w)), sq(w, w));
        let k = _mm256_loadu_pd(s.k.as_ptr().add(e));
        let rest = if STORED {
            _mm256_loadu_pd(s.rest.as_ptr().add(e))
        } else {
            _mm256_sqrt_pd(sq(big, big))
        };
        let lever = if LEVER {
            _mm256_loadu_pd(s.lever.as_ptr().add(e))
        } else {
            rest
        };
        Slot {
            d,
            d2,
            num,
            k,
            rest,
            lever,
            dummy,
            nb,
        }
    }
}

/// Lane `l` of `v` into `out[js[l] - i]`.
///
/// # Safety
/// The processor has the function's target feature, and every `js[l] - i` is below
/// `WINDOW` (the rows' neighbours lie in the window).
#[inline(always)]
unsafe fn scatter(v: __m256d, js: &[u32], i: usize, out: &mut [Real; WINDOW]) {
    let mut lane = [0.0; 4];
    // SAFETY: by the caller's contract, AVX.
    unsafe { _mm256_storeu_pd(lane.as_mut_ptr(), v) };
    for l in 0..4 {
        out[js[l] as usize - i] = lane[l];
    }
}

/// Pools of the window of nodes i..i+64 into `out`; whether a real spring is past the
/// screen.
///
/// # Safety
/// AVX2; i a multiple of 64 with i + 64 <= n; records refreshed.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn pools<const D: usize, const LEVER: bool, const STORED: bool>(
    rk: &RowKernel,
    src: &Src,
    i: usize,
    out: &mut [Real],
    screen: Real,
) -> bool {
    let base = rk.base(src.rec);
    let s = &rk.slots;
    let sv = _mm256_set1_pd(screen);
    let mut sums = Window([[0.0; WINDOW]; 3]);
    let mut hot = _mm256_setzero_pd();
    // SAFETY: by the caller's contract, in bounds as stated.
    unsafe {
        for g in i / 8..(i + WINDOW) / 8 {
            prefetch(rk, base, g + 2);
            let js = group_nodes(rk, g);
            let me = [records(base, &js[..4]), records(base, &js[4..])];
            let mut acc = [_mm256_setzero_pd(); 2];
            for slot in s.start[g] as usize..s.start[g + 1] as usize {
                for h in 0..2 {
                    let t = slot_at::<D, LEVER, STORED>(rk, base, &me[h], 8 * slot + 4 * h);
                    let l = _mm256_sqrt_pd(t.d2);
                    let dl = _mm256_div_pd(t.num, _mm256_add_pd(l, t.rest));
                    let past = _mm256_cmp_pd::<_CMP_GT_OQ>(dl, _mm256_mul_pd(sv, t.rest));
                    hot = _mm256_or_pd(hot, _mm256_andnot_pd(t.dummy, past));
                    acc[h] = _mm256_add_pd(acc[h], _mm256_mul_pd(_mm256_mul_pd(t.k, t.lever), dl));
                }
            }
            scatter(acc[0], &js[..4], i, &mut sums.0[0]);
            scatter(acc[1], &js[4..], i, &mut sums.0[0]);
        }
        let z = _mm256_setzero_pd();
        for b in 0..WINDOW / 4 {
            let acc = _mm256_load_pd(sums.0[0].as_ptr().add(4 * b));
            let sn = _mm256_loadu_pd(src.norm.as_ptr().add(i + 4 * b));
            // sum / sn where sn > 0, else +0 (the quotient's other lanes are masked away).
            let pos = _mm256_cmp_pd::<_CMP_GT_OQ>(sn, z);
            _mm256_storeu_pd(
                out.as_mut_ptr().add(4 * b),
                _mm256_and_pd(pos, _mm256_div_pd(acc, sn)),
            );
        }
        _mm256_movemask_pd(hot) != 0
    }
}

/// Forces on the window of nodes i..i+64 into `f`, in node order.
///
/// # Safety
/// As [`pools`], with the pools in the records.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn forces<const D: usize, const LEVER: bool, const STORED: bool>(
    rk: &RowKernel,
    src: &Src,
    i: usize,
    f: &mut Window,
) {
    let base = rk.base(src.rec);
    let s = &rk.slots;
    let q = _mm256_set1_pd(rk.q);
    let one = _mm256_set1_pd(1.0);
    let plain = rk.q == 0.0;
    // SAFETY: by the caller's contract, in bounds as stated.
    unsafe {
        for g in i / 8..(i + WINDOW) / 8 {
            prefetch(rk, base, g + 2);
            let js = group_nodes(rk, g);
            let me = [records(base, &js[..4]), records(base, &js[4..])];
            let z = _mm256_setzero_pd();
            // The plain law reads no pools (the records may hold another law's).
            let pi = if plain { [z; 2] } else { [me[0][6], me[1][6]] };
            let mut acc = [[z; 3]; 2];
            for slot in s.start[g] as usize..s.start[g + 1] as usize {
                for h in 0..2 {
                    let t = slot_at::<D, LEVER, STORED>(rk, base, &me[h], 8 * slot + 4 * h);
                    let l = _mm256_sqrt_pd(t.d2);
                    let inv = _mm256_div_pd(one, l);
                    let dl = _mm256_div_pd(t.num, _mm256_add_pd(l, t.rest));
                    let r1 = _mm256_mul_pd(_mm256_mul_pd(q, t.k), t.lever);
                    let pj = if plain { z } else { t.nb[6] };
                    let tt = _mm256_add_pd(
                        _mm256_mul_pd(t.k, dl),
                        _mm256_mul_pd(r1, _mm256_add_pd(pi[h], pj)),
                    );
                    for c in 0..D {
                        acc[h][c] =
                            _mm256_add_pd(acc[h][c], _mm256_mul_pd(tt, _mm256_mul_pd(t.d[c], inv)));
                    }
                }
            }
            for c in 0..D {
                scatter(acc[0][c], &js[..4], i, &mut f.0[c]);
                scatter(acc[1][c], &js[4..], i, &mut f.0[c]);
            }
        }
    }
}

/// Kick and drift of the window of nodes i..i+64 with forces `f` (node order), 4 nodes at a
/// time in node order (the sums' order).
///
/// # Safety
/// AVX2; `u` and `inv_mass` hold the window's nodes, `v` and `un` its 64 entries.
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn kick_drift(
    dims: usize,
    f: &Window,
    u: Option<&Coords>,
    inv_mass: &[Real],
    p: &StepParams,
    i: usize,
    v: [&mut [Real]; 3],
    un: [&mut [Real]; 3],
    sums: &mut SweepSums,
) {
    let [vx, vy, vz] = v;
    let [nx, ny, nz] = un;
    for b in 0..WINDOW / 4 {
        let r = 4 * b..4 * b + 4;
        // SAFETY: by the caller's contract, in bounds as stated.
        unsafe {
            let fb = [
                _mm256_load_pd(f.0[0][r.start..].as_ptr()),
                _mm256_load_pd(f.0[1][r.start..].as_ptr()),
                _mm256_load_pd(f.0[2][r.start..].as_ptr()),
            ];
            super::super::stencil::avx2::kick_drift4(
                dims,
                fb,
                u,
                inv_mass,
                p,
                i + 4 * b,
                [&mut vx[r.clone()], &mut vy[r.clone()], &mut vz[r.clone()]],
                [&mut nx[r.clone()], &mut ny[r.clone()], &mut nz[r.clone()]],
                sums,
            )
        };
    }
}
