//! The cubic stencil's wavefront sweeps (AVX-512): each spring's length, and in sweep 2 its
//! force factor, computed once instead of once from each end.
//!
//! The gather form of the sweeps ([`super::super::stencil`]) has every node evaluate all 18 of
//! its springs, so each spring's square root (and in sweep 2 its division) is done twice. Here
//! a sweep walks its nodes in index order, 8 to a vector block, and keeps what a node computes
//! for its 9 *forward* springs (those to a higher index, `off_d > 0`) in a ring: sweep 1 keeps
//! the extension `dL = l - L`, sweep 2 the factor `s = T / l` of the force `s x` with tension
//! `T = k dL + q k L (p_i + p_j)` (times the spring's cell weight). A *backward* spring of node
//! `n` (`off_d < 0`) is the forward spring `d^1` of node `m = n + off_d < n`, which the sweep
//! has passed: its value is read from the ring, and node `n` still adds its own term `s x_n`
//! to its own force (the sweeps stay gathers: each node writes only its own entries).
//!
//! **The same bits as the gather sweeps.** Seen from `n`, the spring's vector is
//! `x_n = D_d + (u_m - u_n)`, the exact negation of `x_m = D_{d^1} + (u_n - u_m)` (`D_{d^1} =
//! -D_d` exactly, and every rounded difference negates), so `|x|^2`, `l`, `dL` are the same
//! numbers at both ends; `p_m + p_n = p_n + p_m` in IEEE arithmetic, `L_d = L_{d^1}`, and a
//! cell weight belongs to the spring, so `T` and `s = T / l` are too. Each node then adds its
//! 18 terms in direction order as the gather sweep does, and a node off the vector path takes
//! that sweep's scalar code: the two sweeps give the same bits on every node (tested against
//! the portable path, with broken springs and cell weights).
//!
//! **The ring** holds, per forward direction, one value per node slot `m mod R`, `R >= reach +
//! 8` (a multiple of 8): a block at `i` (a multiple of 8) reads nodes `i + off_d >= i - reach`
//! and writes nodes `i..i + 8`, all in distinct slots. Slots `R..R + 8` mirror `0..8`, so an
//! unaligned read of 8 slots never wraps. A read of the block's own nodes (`off_d = -1`) comes
//! after the forward direction that wrote them (`d^1 = d - 1`); the other backward directions
//! whose partner comes later in the order (`[1, -1, 0]`, `[1, 0, -1]`, `[0, 1, -1]`) reach at
//! least 8 nodes back once rows hold 9 nodes or more, which the path requires. On a block of
//! `10^6` nodes the ring is 0.7 MB per part, resident in the core's L2 cache.
//!
//! **Parts.** A sweep splits its chunks into a few contiguous parts (one per worker thread of
//! the pool the stencil was built in), each with its own ring; a part's first vector block
//! first fills the ring with the forward values of the `reach` nodes before it. Which part
//! computes a node changes none of its bits, so results do not depend on the thread count;
//! the partial sums are still formed per fixed chunk, in node order.

use std::ops::Range;
use std::sync::Mutex;

use rayon::prelude::*;

use super::CubicStencil;
use crate::stencil::{pools_span, SCREEN};
use crate::{sweep_parts, ChunkOut, StepParams, SweepSums, CHUNK};
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// One part's ring (see the module docs): 9 rows of `R + 8` values, and the node up to which
/// it holds the forward values of every node the sweep passed (`usize::MAX`: none yet).
#[derive(Debug)]
pub(crate) struct Ring {
    buf: Vec<Real>,
    next: usize,
}

/// `parts` empty rings for a stencil whose largest index offset is `reach`; their length `R`.
pub(super) fn rings(reach: usize, parts: usize) -> (Vec<Mutex<Ring>>, usize) {
    let r = (reach + 8).next_multiple_of(8);
    let rings = (0..parts.max(1))
        .map(|_| {
            Mutex::new(Ring {
                buf: vec![0.0; 9 * (r + 8)],
                next: usize::MAX,
            })
        })
        .collect();
    (rings, r)
}

/// Whether direction `d` is forward (`off_d > 0`) in every box the wavefront runs: the sign of
/// its last non-zero step along z, y, x, since `off = dx + sy dy + sz dz` with `sz > sy + 1 > 2`
/// (checked against the offsets where the stencil is built). A constant in the unrolled sweeps.
pub(super) const fn is_forward(d: usize) -> bool {
    let [dx, dy, dz] = super::DIRS[d];
    dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)))
}

/// The forward directions, in direction order.
const FORWARD: [usize; 9] = {
    let mut f = [0; 9];
    let (mut d, mut k) = (0, 0);
    while d < 18 {
        if is_forward(d) {
            f[k] = d;
            k += 1;
        }
        d += 1;
    }
    f
};

/// Each direction's row of the rings: its own place in [`FORWARD`], or its opposite's.
const ROW: [usize; 18] = {
    let mut row = [0; 18];
    let mut k = 0;
    while k < 9 {
        row[FORWARD[k]] = k;
        row[FORWARD[k] ^ 1] = k;
        k += 1;
    }
    row
};

/// Whether the node block at `i` runs on the wavefront's vector path.
#[inline]
fn vector_block(s: &CubicStencil, i: usize, k: usize, len: usize) -> bool {
    i.is_multiple_of(8) && k + 8 <= len && s.block_inside(i)
}

/// First nodes of the blocks whose forward values a part's first vector block at `i` reads.
fn lead_in(s: &CubicStencil, i: usize) -> impl Iterator<Item = usize> {
    // `block_inside(i)` gives i >= reach.
    ((i - s.reach) / 8 * 8..i).step_by(8)
}

/// Sweep 1 ([`crate::stencil::pools`]) on the wavefront path: the same pools and
/// screen flags.
pub(crate) fn pools(
    s: &CubicStencil,
    state: &mut State,
    screen: Real,
    chunks: Option<Range<usize>>,
) {
    let Some(span) = pools_span(s.n, s.q, state, screen, chunks) else {
        return;
    };
    let chunks = span.chunks;
    if chunks.is_empty() {
        return;
    }
    let per = chunks.len().div_ceil(s.rings.len().min(chunks.len()));
    let first = chunks.start * CHUNK;
    let u = &state.u;
    state.pool[span.nodes]
        .par_chunks_mut(per * CHUNK)
        .zip(state.hot[span.flags].par_chunks_mut(per * (CHUNK / SCREEN)))
        .zip(s.rings.par_iter())
        .enumerate()
        .for_each(|(k, ((out, hot), ring))| {
            let mut ring = ring.lock().unwrap_or_else(|e| e.into_inner());
            pool_part(s, u, first + k * per * CHUNK, out, hot, screen, &mut ring);
        });
}

/// Sweep 1 over the nodes from `start` (a chunk's first) whose pools are `out`.
fn pool_part(
    s: &CubicStencil,
    u: &Coords,
    start: usize,
    out: &mut [Real],
    hot: &mut [bool],
    screen: Real,
    ring: &mut Ring,
) {
    hot.fill(false);
    ring.next = usize::MAX;
    let mut k = 0;
    while k < out.len() {
        let i = start + k;
        #[cfg(target_arch = "x86_64")]
        if vector_block(s, i, k, out.len()) {
            // SAFETY: the wavefront path is on only with AVX-512F; the block and its
            // neighbours are inside the arrays, as are those of the lead-in blocks before it.
            let h = unsafe {
                if ring.next != i {
                    for m in lead_in(s, i) {
                        avx512::forward_lengths8(s, u, m, ring);
                    }
                }
                avx512::pools8(s, u, i, &mut out[k..k + 8], screen, ring)
            };
            ring.next = i + 8;
            // An aligned block lies within one screen block.
            hot[k / SCREEN] |= h;
            k += 8;
            continue;
        }
        let (p, h) = s.pool_scalar(u, i, screen);
        out[k] = p;
        hot[k / SCREEN] |= h;
        k += 1;
    }
    if s.q == 0.0 {
        out.fill(0.0);
    }
}

/// Sweep 2 ([`crate::stencil::force_kick_drift`]) on the wavefront path over the node
/// chunks `chunks`, the new displacements into `u_next`: the same bits, the same partial sums.
pub(crate) fn force_kick_drift(
    s: &CubicStencil,
    state: &mut State,
    inv_mass: &[Real],
    p: &StepParams,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    chunks: Range<usize>,
) -> SweepSums {
    let State { u, v, pool, .. } = state;
    let (u, pool): (&Coords, &[Real]) = (u, pool);
    let dims = p.dims(3);
    sweep_parts(
        s.n,
        chunks,
        &s.rings,
        v,
        u_next,
        partials,
        |ring, first, r, o| {
            if first {
                // The ring holds nothing of this sweep yet: the part fills it from its lead-in.
                ring.next = usize::MAX;
            }
            force_chunk(s, u, pool, inv_mass, p, dims, r, o, ring)
        },
    )
}

/// Sweep 2 over the nodes `r` of one chunk, continuing its part's ring.
#[allow(clippy::too_many_arguments)]
fn force_chunk(
    s: &CubicStencil,
    u: &Coords,
    pool: &[Real],
    inv_mass: &[Real],
    p: &StepParams,
    dims: usize,
    r: Range<usize>,
    o: ChunkOut<'_>,
    ring: &mut Ring,
) -> SweepSums {
    let mut o = o;
    let mut sums = SweepSums::default();
    let len = r.len();
    let mut k = 0;
    while k < len {
        let i = r.start + k;
        #[cfg(target_arch = "x86_64")]
        if vector_block(s, i, k, len) {
            let (v, un) = o.block(k..k + 8);
            // SAFETY: as in `pool_part`; the output slices hold the block's nodes.
            unsafe {
                if ring.next != i {
                    for m in lead_in(s, i) {
                        avx512::forward_factors8(s, u, pool, m, ring);
                    }
                }
                let f = avx512::forces8(s, u, pool, i, ring);
                crate::stencil::vector::kick_drift8(
                    3,
                    f,
                    Some(u),
                    inv_mass,
                    p,
                    i,
                    v,
                    un,
                    &mut sums,
                );
            }
            ring.next = i + 8;
            k += 8;
            continue;
        }
        // The gather sweep's scalar step (crate::stencil::force_kick_drift).
        let f = s.force_scalar(u, pool, i);
        let u_old = [u.x()[i], u.y()[i], u.z()[i]];
        o.kick_drift(k, dims, f, inv_mass[i], p, u_old, &mut sums);
        k += 1;
    }
    sums
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::super::vector::{
        add_share, add_terms, classes, extension, factor, load_block, vector,
    };
    use super::{CubicStencil, Ring, FORWARD, ROW};
    use crate::wide::{Wide, W8};
    use hooke_model::math::{Coords, Real};

    type V = <W8 as Wide>::F;
    type M = <W8 as Wide>::M;
    type I = <W8 as Wide>::I;

    /// Store a forward direction's 8 values of the block in slots `at..at + 8` of its ring
    /// row `row` (and in the mirror slots when `at` is 0).
    ///
    /// # Safety
    /// The processor has AVX-512F, `row` is a ring row and `at + 8` is at most the ring's
    /// length (a block's slot: a multiple of 8).
    #[inline(always)]
    unsafe fn keep(w: W8, s: &CubicStencil, ring: &mut Ring, row: usize, at: usize, x: V) {
        let r = s.ring_len;
        // SAFETY: by the caller's contract, `at + 8 <= r` (a block's slot is a multiple of 8), within the row.
        unsafe {
            let base = ring.buf.as_mut_ptr().add(row * (r + 8));
            w.store(base.add(at), x);
            if at == 0 {
                w.store(base.add(r), x);
            }
        }
    }

    /// The 8 values of ring row `row` for the nodes `off` (< 0, at least `-reach`) from the
    /// block whose slot is `at`.
    ///
    /// # Safety
    /// The processor has AVX-512F, `row` is a ring row, and `at + off` lies within the
    /// row's reach (`-reach <= off < 0`), its 8 values kept by an earlier `keep`.
    #[inline(always)]
    unsafe fn recall(w: W8, s: &CubicStencil, ring: &Ring, row: usize, at: usize, off: isize) -> V {
        let r = s.ring_len;
        // The slot of node `i + off`, `(at + off) mod r`, without a division.
        let back = at as isize + off;
        let slot = if back < 0 { back + r as isize } else { back } as usize;
        // SAFETY: `slot + 8 <= r + 8`, within the row and its mirror.
        unsafe { w.load(ring.buf.as_ptr().add(row * (r + 8) + slot)) }
    }

    /// Fill the ring with the forward springs' `dL` of the block at `m` (a lead-in block).
    ///
    /// # Safety
    /// The processor has the function's target feature; the block at the given node is inside
    /// the body's box (`vector_block`), and `out`, `v`, `un` and the ring (where taken) hold
    /// its entries.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn forward_lengths8(s: &CubicStencil, u: &Coords, m: usize, ring: &mut Ring) {
        // SAFETY: the processor has the feature and the block at this index is in bounds (this fn's contract).
        let (w, (ui, mask)) = unsafe { (W8::new(), load_block(W8::new(), s, u, m)) };
        for d in FORWARD {
            if w.any(w.bit(mask, d)) {
                // SAFETY: the block at m is inside (this fn's contract), so its neighbours and its ring slot (m is a multiple of 8) are in bounds.
                unsafe {
                    keep(
                        w,
                        s,
                        ring,
                        ROW[d],
                        m % s.ring_len,
                        extension(w, s, u, m, d, ui),
                    )
                };
            }
        }
    }

    /// Direction `D`'s term of sweep 1 for the block at `i` (slot `at`).
    ///
    /// # Safety
    /// The block at the given node is inside the body's box (`vector_block`), and the ring
    /// holds its lead-in.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn pool_term<const D: usize>(
        w: W8,
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        (ui, mask, cls): ([V; 3], I, Option<I>),
        screen: Real,
        ring: &mut Ring,
        at: usize,
        acc: &mut V,
        hot: &mut M,
    ) {
        // SAFETY: by the caller's contract, the block is inside and the ring holds its lead-in.
        unsafe {
            let m = w.bit(mask, D);
            if !w.any(m) {
                return;
            }
            let dl = if const { super::is_forward(D) } {
                let dl = extension(w, s, u, i, D, ui);
                keep(w, s, ring, ROW[D], at, dl);
                dl
            } else {
                recall(w, s, ring, ROW[D], at, s.off[D])
            };
            add_share(w, s, D, m, dl, cls, screen, acc, hot);
        }
    }

    /// Sweep 1 for the 8 nodes at `i`: the gather sweep's sums, with each backward spring's
    /// `dL` recalled from the ring.
    ///
    /// # Safety
    /// The processor has the function's target feature; the block at the given node is inside
    /// the body's box (`vector_block`), and `out` and the ring hold its entries.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn pools8(
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        out: &mut [Real],
        screen: Real,
        ring: &mut Ring,
    ) -> bool {
        // SAFETY: the processor has the feature and the block at this index is in bounds (this fn's contract).
        let (w, (ui, mask)) = unsafe { (W8::new(), load_block(W8::new(), s, u, i)) };
        let block = (ui, mask, classes(w, s, mask));
        let at = i % s.ring_len;
        let mut acc = w.zero();
        let mut hot = w.no_lanes();
        // Each direction's term, the loop unrolled (a tenth off the sweep: the directions'
        // constants become immediate offsets and the branches go).
        macro_rules! directions { ($($d:literal)*) => { $(
            // SAFETY: the block is inside (this fn's contract), so its neighbours in every
            // direction are nodes, and `at` is its ring slot.
            unsafe {
            pool_term::<$d>(w, s, u, i, block, screen, ring, at, &mut acc, &mut hot)
        }; )* } }
        directions!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17);
        // SAFETY: out has 8 entries; inv_norm[i..i+8] is in bounds.
        unsafe {
            let inv = w.load(s.inv_norm.as_ptr().add(i));
            w.store(out.as_mut_ptr(), acc * inv);
        }
        w.any(hot)
    }

    /// Fill the ring with the forward springs' force factors of the block at `m` (a lead-in
    /// block).
    ///
    /// # Safety
    /// The processor has the function's target feature; the block at the given node is inside
    /// the body's box (`vector_block`), and the ring holds its entries.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn forward_factors8(
        s: &CubicStencil,
        u: &Coords,
        pool: &[Real],
        m: usize,
        ring: &mut Ring,
    ) {
        // SAFETY: the processor has the feature and the block at this index is in bounds (this fn's contract).
        let (w, (ui, mask)) = unsafe { (W8::new(), load_block(W8::new(), s, u, m)) };
        let cls = classes(w, s, mask);
        // SAFETY: the block's nodes are in bounds of the pools (this fn's contract).
        let pi = unsafe { w.load(pool.as_ptr().add(m)) };
        for d in FORWARD {
            if w.any(w.bit(mask, d)) {
                // SAFETY: the block is inside (this fn's contract), so its neighbours in direction d are nodes.
                let (_, sc) = unsafe { factor(w, s, u, pool, m, d, ui, pi, cls) };
                // SAFETY: m is a block start, a multiple of 8, so its slot lies within the ring row.
                unsafe { keep(w, s, ring, ROW[d], m % s.ring_len, sc) };
            }
        }
    }

    /// Sweep 2's forces on the 8 nodes at `i`: the gather sweep's sums, with each backward
    /// spring's factor recalled from the ring.
    ///
    /// # Safety
    /// The processor has the function's target feature; the block at the given node is inside
    /// the body's box (`vector_block`), and the ring holds its entries.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn forces8(
        s: &CubicStencil,
        u: &Coords,
        pool: &[Real],
        i: usize,
        ring: &mut Ring,
    ) -> [V; 3] {
        // SAFETY: the processor has the feature and the block at this index is in bounds (this fn's contract).
        let (w, (ui, mask)) = unsafe { (W8::new(), load_block(W8::new(), s, u, i)) };
        let block = (ui, mask, classes(w, s, mask));
        // SAFETY: the block's nodes are in bounds of the pools (this fn's contract).
        let pi = unsafe { w.load(pool.as_ptr().add(i)) };
        let at = i % s.ring_len;
        let mut f = [w.zero(); 3];
        macro_rules! directions { ($($d:literal)*) => { $(
            // SAFETY: the block is inside (this fn's contract), so its neighbours in every
            // direction are nodes, and `at` is its ring slot.
            unsafe {
            force_term::<$d>(w, s, u, pool, i, block, pi, ring, at, &mut f)
        }; )* } }
        directions!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17);
        f
    }

    /// Direction `D`'s term of the forces on the block at `i` (slot `at`).
    ///
    /// # Safety
    /// The block at the given node is inside the body's box (`vector_block`), and the ring
    /// holds its lead-in.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn force_term<const D: usize>(
        w: W8,
        s: &CubicStencil,
        u: &Coords,
        pool: &[Real],
        i: usize,
        (ui, mask, cls): ([V; 3], I, Option<I>),
        pi: V,
        ring: &mut Ring,
        at: usize,
        f: &mut [V; 3],
    ) {
        // SAFETY: by the caller's contract, the block is inside and the ring holds its lead-in.
        unsafe {
            let m = w.bit(mask, D);
            if !w.any(m) {
                return;
            }
            let (x, sc) = if const { super::is_forward(D) } {
                let (x, sc) = factor(w, s, u, pool, i, D, ui, pi, cls);
                keep(w, s, ring, ROW[D], at, sc);
                (x, sc)
            } else {
                // The square length is left unused (and not computed).
                let (x, _) = vector(w, s, u, i, D, ui);
                (x, recall(w, s, ring, ROW[D], at, s.off[D]))
            };
            add_terms(w, f, m, sc, x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Kernel;
    use hooke_model::body::Body;
    use hooke_model::lattice::Lattice;

    /// Pools, screen flags, velocities, next displacements and partial sums of one step.
    type Step = (Vec<Real>, Vec<bool>, Coords, Coords, Vec<(Real, Real)>);

    fn step(kernel: &Kernel, body: &Body, state: &State) -> Step {
        let mut s = state.clone();
        let n = body.nodes();
        let inv: Vec<Real> = (0..n).map(|i| 1.0 / (1.0 + (i % 7) as Real)).collect();
        let p = StepParams {
            dt: 0.1,
            damping: 0.3,
            accel: [0.0, 0.0, -1e-3],
            plane: false,
        };
        let mut u_next = Coords::zeros(n);
        let mut partials = vec![SweepSums::default(); crate::partials_len(n)];
        kernel.pools_screened(body, &mut s, 2e-3);
        kernel.force_kick_drift(body, &mut s, &inv, &p, &mut u_next, &mut partials);
        let sums = partials
            .iter()
            .map(|x| (x.dissipated, x.body_work))
            .collect();
        (s.pool, s.hot, s.v, u_next, sums)
    }

    /// The wavefront sweeps give the gather sweeps' bits (vector and portable) on a damaged,
    /// deformed, cell-weighted block, however the chunks are split into parts (each part fills
    /// its ring from its own lead-in), with screen flags set and rows of 11 nodes (the path
    /// needs 9).
    #[test]
    fn the_wavefront_gives_the_gather_bits_for_any_split() {
        let lat = Lattice::cubic_box([11, 13, 60], 1.0).unwrap();
        let body = Body::uniform(lat, 1.0, 0.2, 1.0)
            .with_cell_weights()
            .unwrap();
        let mut state = State::new(&body);
        let hash =
            |k: u64| (k.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11) as Real / (1u64 << 53) as Real;
        let alive = (0..body.springs()).map(|b| hash(b as u64) > 0.1).collect();
        state.set_alive(&body, alive);
        for c in 0..3 {
            for (i, x) in state.u.comp_mut(c).iter_mut().enumerate() {
                // Strains past the screen near nodes 4000..4100 only.
                let size = if (4000..4100).contains(&i) {
                    1e-2
                } else {
                    1e-4
                };
                *x = size * (hash((3 * i + c) as u64 + 7) - 0.5);
            }
        }
        let Kernel::Cubic(stencil) = Kernel::for_body(&body, &state) else {
            panic!("a cubic box has its stencil");
        };
        if !stencil.wave() {
            // No AVX-512 here (or the portable paths forced): nothing to compare.
            return;
        }
        let mut gather = stencil.clone();
        gather.set_wave(false);
        let mut portable = stencil.clone();
        portable.set_simd(false);
        let reference = step(&Kernel::Cubic(portable), &body, &state);
        assert!(reference.1.iter().any(|&h| h) && !reference.1.iter().all(|&h| h));
        assert_eq!(step(&Kernel::Cubic(gather), &body, &state), reference);
        for parts in [1, 2, 3] {
            let mut wave = stencil.clone();
            wave.set_parts(parts);
            assert!(wave.wave());
            let got = step(&Kernel::Cubic(wave), &body, &state);
            assert!(
                got == reference,
                "{parts} parts: not the gather sweeps' bits"
            );
        }
    }
}
