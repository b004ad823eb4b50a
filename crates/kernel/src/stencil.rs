//! What the stencil kernels ([`super::cubic`], [`super::hex`]) share: the sweeps' scaffolding
//! over fixed node chunks, the break screen's flags, the repair after breaks, and the choice
//! between a block of 8 nodes on the vector path and one node on the portable path.
//!
//! A stencil says, per node and per block, how to form its pool and its force
//! ([`Stencil`]); everything else here is the same for both lattices. Which path a node takes
//! depends only on its index and on where its chunk begins (chunks are fixed, never the thread
//! count's), so results are bit-identical for any thread count.

use rayon::prelude::*;

use super::{sweep_chunks, StepParams, SweepSums, CHUNK};
use hooke_model::body::Body;
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// What a sweep reads of the state: the displacements (through `Deref`, as a [`Coords`]), and
/// for the row kernel the nodes' records and normalisers.
pub(crate) struct Src<'a> {
    pub u: &'a Coords,
    pub rec: &'a [super::rows::Record],
    pub norm: &'a [Real],
    /// Sweep 2 drifts in place: the output slices hold the old displacements (`u` is then
    /// empty; only the row kernel, which reads its neighbours from its records, does this).
    pub in_place: bool,
}

impl Src<'_> {
    /// The displacements the drift starts from, or `None` where it drifts in place.
    #[inline(always)]
    pub fn old_u(&self) -> Option<&Coords> {
        (!self.in_place).then_some(self.u)
    }
}

impl std::ops::Deref for Src<'_> {
    type Target = Coords;
    fn deref(&self) -> &Coords {
        self.u
    }
}

/// Nodes per flag of the break screen (divides [`CHUNK`]).
pub const SCREEN: usize = 64;

/// The per-node and per-block operations of a stencil kernel.
pub(crate) trait Stencil: Sync {
    /// Number of nodes.
    fn nodes(&self) -> usize;
    /// Dispersion ratio q (0: the plain law, no pools).
    fn q(&self) -> Real;
    /// Dimension of the body (2: a plate, whose z components may be left alone).
    fn dim(&self) -> usize;
    /// Nodes in a block of the vector path: 8 (one vector of lanes), or a multiple of 8 that
    /// divides [`SCREEN`] for a kernel that deals a block's nodes to its lanes in another order.
    fn block_len(&self) -> usize {
        8
    }
    /// Whether the block of [`Stencil::block_len`] nodes from `i` runs on the vector path (it
    /// is on, the processor has it, and the block and its neighbours lie inside the arrays).
    fn vector_block(&self, i: usize) -> bool;
    /// Node i's pool and whether one of its intact springs has `dL > screen L`.
    fn pool_one(&self, u: &Src, i: usize, screen: Real) -> (Real, bool);
    /// Node i's force.
    fn force_one(&self, u: &Src, pool: &[Real], i: usize) -> [Real; 3];
    /// Pools of the block's nodes from `i` into `out`, and whether one of their springs is past
    /// the screen.
    ///
    /// # Safety
    /// Only when [`Stencil::vector_block`] holds for `i`.
    #[cfg(target_arch = "x86_64")]
    unsafe fn pool_block(&self, u: &Src, i: usize, out: &mut [Real], screen: Real) -> bool;
    /// Force, kick and drift of the block's nodes from `i` (`v` and `un` hold their entries),
    /// their shares of the sums added to `sums` node by node.
    ///
    /// # Safety
    /// Only when [`Stencil::vector_block`] holds for `i`.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn force_kick_drift_block(
        &self,
        u: &Src,
        pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    );
}

/// Largest number of weight classes a stencil body may have (one `zmm` of factors per
/// direction, indexed by the class in the vector path).
pub(crate) const CLASSES: usize = 8;

/// The spring factors of a stencil body whose stiffnesses are one bulk stiffness `k` times a
/// factor per spring: a cell-weighted body ([`Body::with_cell_weights`]), whose springs on free
/// faces and edges stand for a half or a quarter of a bulk spring's material. The factor of a
/// spring depends only on which faces its ends lie on, so the nodes fall into a few classes,
/// each with one factor per direction; a node's class rides in spare bits of its mask and the
/// sweeps multiply each spring's pool share and tension by `w[d][class]`. Where every factor is
/// 1 (`on` false) nothing is multiplied: the unweighted sweeps are unchanged.
///
/// With factors that are powers of two (the cubic and hexagonal cells give 1, 1/2, 1/4), the
/// products `(k L dL) w` and `(k dL + q k L (p_i + p_j)) w` are exactly the reference law's
/// `(k w) L dL` and `(k w) dL + q (k w) L (p_i + p_j)`.
#[derive(Clone, Debug)]
pub(crate) struct Factors<const D: usize> {
    /// `w[d][c]`: the factor of the spring in direction d of a class-c node (class 0: all 1).
    pub w: [[Real; CLASSES]; D],
    /// Whether some node has a factor other than 1.
    pub on: bool,
}

impl<const D: usize> Factors<D> {
    /// The factor of node class `c`'s spring in direction `d`.
    #[inline(always)]
    pub fn get(&self, d: usize, c: usize) -> Real {
        self.w[d][c]
    }

    /// Classes of the `n` nodes from each node's springs' stiffnesses by direction (`None`: no
    /// spring that way), against the bulk stiffness `k`: `None` when a stiffness is not `k`
    /// times a factor in (0, 1] exactly, or when the nodes need more than [`CLASSES`] classes
    /// (the general kernels then run the body). A node's missing directions match any factor,
    /// so the faces of a box share their classes with the opposite faces.
    pub fn classify(
        n: usize,
        k: Real,
        row: impl Fn(usize) -> [Option<Real>; D] + Sync,
    ) -> Option<(Vec<u8>, Self)> {
        let factor = |kb: Real| {
            let w = kb / k;
            (w > 0.0 && w <= 1.0 && k * w == kb).then_some(w)
        };
        // Most nodes are bulk nodes (class 0): found in parallel, the rest one by one.
        let bulk: Vec<Option<bool>> = (0..n)
            .into_par_iter()
            .with_min_len(1 << 12)
            .map(|i| {
                let mut ones = true;
                for kb in row(i).into_iter().flatten() {
                    ones &= factor(kb)? == 1.0;
                }
                Some(ones)
            })
            .collect();
        let mut class = vec![0u8; n];
        // Per class: each direction's factor, or None while no member has that spring.
        let mut table: Vec<[Option<Real>; D]> = vec![[Some(1.0); D]];
        for i in 0..n {
            if bulk[i]? {
                continue;
            }
            let f = row(i).map(|kb| kb.and_then(factor));
            let fits = |t: &[Option<Real>; D]| {
                (0..D).all(|d| match (f[d], t[d]) {
                    (Some(a), Some(b)) => a == b,
                    _ => true,
                })
            };
            let c = match table.iter().position(fits) {
                Some(c) => c,
                None if table.len() < CLASSES => {
                    table.push([None; D]);
                    table.len() - 1
                }
                None => return None,
            };
            for d in 0..D {
                if f[d].is_some() {
                    table[c][d] = f[d];
                }
            }
            class[i] = c as u8;
        }
        let mut w = [[1.0; CLASSES]; D];
        for (c, t) in table.iter().enumerate() {
            for d in 0..D {
                w[d][c] = t[d].unwrap_or(1.0);
            }
        }
        let on = table.len() > 1;
        Some((class, Factors { w, on }))
    }
}

pub use hooke_sys::simd::Lanes;
pub(crate) use hooke_sys::simd::{avx2_lanes, lanes as simd_lanes};

/// Sweep 1, and with a finite `screen` s the break screen: `state.hot` flags each block of
/// [`SCREEN`] nodes with an intact spring of `dL > s L` (seen from either end: both ends
/// compute the same length). With `chunks` (one rank's share of a distributed run), only those
/// node chunks, and every other screen flag cleared.
pub(crate) fn pools<S: Stencil>(
    s: &S,
    state: &mut State,
    screen: Real,
    chunks: Option<std::ops::Range<usize>>,
) {
    let Some(span) = pools_span(s.nodes(), s.q(), state, screen, chunks) else {
        return;
    };
    let u = Src {
        u: &state.u,
        rec: &state.rec,
        norm: &state.norm,
        in_place: false,
    };
    let first = span.chunks.start;
    state.pool[span.nodes]
        .par_chunks_mut(CHUNK)
        .zip(state.hot[span.flags].par_chunks_mut(CHUNK / SCREEN))
        .enumerate()
        .for_each(|(c, (out, hot))| pool_chunk(s, &u, first + c, out, hot, screen));
}

/// What a sweep 1 of `n` nodes covers: its node chunks, and the pools and screen flags they
/// hold.
pub(crate) struct PoolSpan {
    pub chunks: std::ops::Range<usize>,
    pub nodes: std::ops::Range<usize>,
    pub flags: std::ops::Range<usize>,
}

/// The preparation every stencil's sweep 1 shares: with the plain law and no screen the pools
/// are +0 and there is nothing to sweep (`None`); otherwise the screen flags are sized (and for
/// one rank's `chunks`, cleared), and the span of `chunks` (every chunk: `None`) is returned.
pub(crate) fn pools_span(
    n: usize,
    q: Real,
    state: &mut State,
    screen: Real,
    chunks: Option<std::ops::Range<usize>>,
) -> Option<PoolSpan> {
    if q == 0.0 && !screen.is_finite() {
        state.pool.fill(0.0);
        return None;
    }
    let blocks = n.div_ceil(SCREEN);
    if state.hot.len() != blocks {
        state.hot = vec![false; blocks];
    }
    if chunks.is_some() {
        state.hot.fill(false);
    }
    let chunks = chunks.unwrap_or(0..n.div_ceil(CHUNK));
    let chunks = chunks.start..chunks.end.min(n.div_ceil(CHUNK));
    let per = CHUNK / SCREEN;
    Some(PoolSpan {
        nodes: (chunks.start * CHUNK).min(n)..(chunks.end * CHUNK).min(n),
        flags: (chunks.start * per).min(blocks)..(chunks.end * per).min(blocks),
        chunks,
    })
}

/// Sweep 1 over chunk `c` (its pools `out` and screen flags `hot`).
fn pool_chunk<S: Stencil>(
    s: &S,
    u: &Src,
    c: usize,
    out: &mut [Real],
    hot: &mut [bool],
    screen: Real,
) {
    hot.fill(false);
    let start = c * CHUNK;
    let b = s.block_len();
    let mut k = 0;
    while k < out.len() {
        let i = start + k;
        #[cfg(target_arch = "x86_64")]
        if k + b <= out.len() && s.vector_block(i) {
            // SAFETY: `vector_block` holds for i.
            let h = unsafe { s.pool_block(u, i, &mut out[k..k + b], screen) };
            // A block may straddle two screen blocks (scalar steps shift it).
            hot[k / SCREEN] |= h;
            hot[(k + b - 1) / SCREEN] |= h;
            k += b;
            continue;
        }
        let (p, h) = s.pool_one(u, i, screen);
        out[k] = p;
        hot[k / SCREEN] |= h;
        k += 1;
    }
    if s.q() == 0.0 {
        out.fill(0.0);
    }
}

/// After springs broke between sweep 1 and sweep 2 (the stencil's masks already updated):
/// recompute the pools of the chunks holding their ends with the same code as sweep 1, so the
/// bits are those of breaking before the step.
pub(crate) fn repair<S: Stencil>(
    s: &S,
    body: &Body,
    state: &mut State,
    killed: &[u32],
    mine: std::ops::Range<usize>,
) {
    if s.q() == 0.0 {
        return;
    }
    let n = s.nodes();
    // A chunk of another rank's nodes would be recomputed from records this rank does not
    // keep current.
    let mut chunks: Vec<usize> = killed
        .iter()
        .flat_map(|&b| body.lattice.bonds.ends[b as usize])
        .map(|n| n as usize / CHUNK)
        .filter(|c| mine.contains(c))
        .collect();
    chunks.sort_unstable();
    chunks.dedup();
    let mut scratch = [false; CHUNK / SCREEN];
    for c in chunks {
        let r = c * CHUNK..((c + 1) * CHUNK).min(n);
        let blocks = r.len().div_ceil(SCREEN);
        pool_chunk(
            s,
            &Src {
                u: &state.u,
                rec: &state.rec,
                norm: &state.norm,
                in_place: false,
            },
            c,
            &mut state.pool[r],
            &mut scratch[..blocks],
            Real::INFINITY,
        );
    }
}

/// Sweep 2 over the node chunks `chunks`: the new displacements into `u_next`, or with `None`
/// into `state.u` in place (a kernel whose force sweep reads no displacement from `state.u`:
/// the row kernel, which reads its records; each node's drift reads only its own old value,
/// just before it writes the new one).
pub(crate) fn force_kick_drift<S: Stencil>(
    s: &S,
    state: &mut State,
    inv_mass: &[Real],
    p: &StepParams,
    u_next: Option<&mut Coords>,
    partials: &mut [SweepSums],
    chunks: std::ops::Range<usize>,
) -> SweepSums {
    let empty = Coords::default();
    let State {
        u,
        v,
        rec,
        norm,
        pool,
        ..
    } = state;
    let in_place = u_next.is_none();
    let (old, out): (&Coords, &mut Coords) = match u_next {
        Some(n) => (u, n),
        None => (&empty, u),
    };
    let u = &Src {
        u: old,
        rec,
        norm,
        in_place,
    };
    let pool: &[Real] = pool;
    let dims = p.dims(s.dim());
    sweep_chunks(s.nodes(), chunks, v, out, partials, |r, mut o| {
        let mut sums = SweepSums::default();
        let len = r.len();
        let b = s.block_len();
        let mut k = 0;
        while k < len {
            let i = r.start + k;
            #[cfg(target_arch = "x86_64")]
            if k + b <= len && s.vector_block(i) {
                let (v, un) = o.block(k..k + b);
                // SAFETY: `vector_block` holds for i; the output slices hold the block's
                // nodes.
                unsafe { s.force_kick_drift_block(u, pool, inv_mass, p, i, v, un, &mut sums) };
                k += b;
                continue;
            }
            let f = s.force_one(u, pool, i);
            let u_old = if in_place {
                o.u_next.each_ref().map(|c| c[k])
            } else {
                [u.x()[i], u.y()[i], u.z()[i]]
            };
            o.kick_drift(k, dims, f, inv_mass[i], p, u_old, &mut sums);
            k += 1;
        }
        sums
    })
}

/// The vector paths' kick and drift, one source for both widths ([`crate::wide`]).
#[cfg(target_arch = "x86_64")]
pub(crate) mod vector {
    use super::{StepParams, SweepSums};
    use crate::wide::{Wide, W4, W8};
    use hooke_model::math::{Coords, Real};

    /// Kick and drift of the N nodes from `i` with forces `f` (the first `dims` components):
    /// the scalar [`super::super::kick_drift`]'s operations lane by lane (no fused
    /// multiply-adds), each node's shares of the sums added to `sums` in index order, so the
    /// bits are those of the portable path.
    ///
    /// # Safety
    /// `u` and `inv_mass` hold nodes `i..i + N`; `v` and `un` hold the block's N entries per
    /// component.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn kick_drift<W: Wide>(
        w: W,
        dims: usize,
        f: [W::F; 3],
        u: Option<&Coords>,
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        let h = 0.5 * p.damping * p.dt;
        let shrink = w.splat(1.0 - h);
        let grow = w.splat(1.0 / (1.0 + h));
        let dt = w.splat(p.dt);
        let half = w.splat(0.5);
        // SAFETY: by the caller's contract, i..i+N is in bounds of every array read or written here.
        let im = unsafe { w.load(inv_mass.as_ptr().add(i)) };
        let mut v2 = w.zero();
        let mut gw = w.zero();
        let [vx, vy, vz] = v;
        let [nx, ny, nz] = un;
        // In place (`u` None), `un` holds the old displacements until it is written.
        let comps = [
            (vx, nx, u.map(|u| u.x())),
            (vy, ny, u.map(|u| u.y())),
            (vz, nz, u.map(|u| u.z())),
        ];
        for (c, (vs, ns, uc)) in comps.into_iter().enumerate().take(dims) {
            let g = w.splat(p.accel[c]);
            // SAFETY: by this fn's contract, the block's entries of `v`, `un` and `u` are in bounds of the loads and stores.
            unsafe {
                let old = w.load(vs.as_ptr());
                let acc = f[c] * im + g;
                let new = (shrink * old + dt * acc) * grow;
                w.store(vs.as_mut_ptr(), new);
                let ui = w.load(match uc {
                    Some(uc) => uc.as_ptr().add(i),
                    None => ns.as_ptr(),
                });
                w.store(ns.as_mut_ptr(), ui + dt * new);
                let mid = half * (old + new);
                v2 = v2 + mid * mid;
                gw = gw + g * mid;
            }
        }
        if p.damping == 0.0 && p.accel == [0.0; 3] {
            // Every node's shares are +0, which would leave the sums' bits as they are.
            return;
        }
        let (lane_v2, lane_gw, lane_im) = (w.lanes(v2), w.lanes(gw), w.lanes(im));
        for l in 0..W::N {
            let m = if lane_im[l] > 0.0 {
                1.0 / lane_im[l]
            } else {
                0.0
            };
            sums.dissipated += p.damping * m * lane_v2[l] * p.dt;
            sums.body_work += m * lane_gw[l] * p.dt;
        }
    }

    /// A stencil's block operations, written once over the width.
    pub(crate) trait Lanewise: Sync {
        /// Sweep 1 for the N nodes at `i`: their pools into `out`, and whether one of their
        /// springs is past the screen.
        ///
        /// # Safety
        /// The block at `i` is inside the body's box (`vector_block`), and `out` holds its N
        /// entries.
        unsafe fn pools<W: Wide>(
            &self,
            w: W,
            u: &Coords,
            i: usize,
            out: &mut [Real],
            screen: Real,
        ) -> bool;

        /// Sweep 2 for the N nodes at `i`: force, kick, drift.
        ///
        /// # Safety
        /// The block at `i` is inside the body's box (`vector_block`), and `v` and `un` hold
        /// its N entries.
        #[allow(clippy::too_many_arguments)]
        unsafe fn force_kick_drift<W: Wide>(
            &self,
            w: W,
            u: &Coords,
            pool: &[Real],
            inv_mass: &[Real],
            p: &StepParams,
            i: usize,
            v: [&mut [Real]; 3],
            un: [&mut [Real]; 3],
            sums: &mut SweepSums,
        );
    }

    /// Sweep 1 for the 8 nodes at `i`: AVX-512 (`avx2` false) or AVX2 (two halves of 4).
    ///
    /// # Safety
    /// The processor has the instructions of the path taken; otherwise as
    /// [`Lanewise::pools`] for 8 nodes.
    #[inline(always)]
    pub(crate) unsafe fn pools8<S: Lanewise>(
        s: &S,
        avx2: bool,
        u: &Coords,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        // SAFETY: the caller's contract.
        unsafe {
            if avx2 {
                pools_avx2(s, u, i, out, screen)
            } else {
                pools_avx512(s, u, i, out, screen)
            }
        }
    }

    /// # Safety
    /// AVX-512F; as [`Lanewise::pools`] for 8 nodes.
    #[target_feature(enable = "avx512f")]
    unsafe fn pools_avx512<S: Lanewise>(
        s: &S,
        u: &Coords,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        // SAFETY: the processor has AVX-512F, and the rest is this fn's contract.
        unsafe { s.pools(W8::new(), u, i, out, screen) }
    }

    /// # Safety
    /// AVX2; as [`Lanewise::pools`] for 8 nodes.
    #[target_feature(enable = "avx2")]
    unsafe fn pools_avx2<S: Lanewise>(
        s: &S,
        u: &Coords,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        let (a, b) = out.split_at_mut(4);
        // SAFETY: the processor has AVX2, and the rest is this fn's contract.
        unsafe {
            let w = W4::new();
            let hot = s.pools(w, u, i, a, screen);
            s.pools(w, u, i + 4, b, screen) | hot
        }
    }

    /// Sweep 2 for the 8 nodes at `i`: AVX-512 (`avx2` false) or AVX2 (two halves of 4, in
    /// node order).
    ///
    /// # Safety
    /// The processor has the instructions of the path taken; otherwise as
    /// [`Lanewise::force_kick_drift`] for 8 nodes.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn force_kick_drift8<S: Lanewise>(
        s: &S,
        avx2: bool,
        u: &Coords,
        pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // SAFETY: the caller's contract.
        unsafe {
            if avx2 {
                force_kick_drift_avx2(s, u, pool, inv_mass, p, i, v, un, sums)
            } else {
                force_kick_drift_avx512(s, u, pool, inv_mass, p, i, v, un, sums)
            }
        }
    }

    /// # Safety
    /// AVX-512F; as [`Lanewise::force_kick_drift`] for 8 nodes.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f")]
    unsafe fn force_kick_drift_avx512<S: Lanewise>(
        s: &S,
        u: &Coords,
        pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // SAFETY: the processor has AVX-512F, and the rest is this fn's contract.
        unsafe { s.force_kick_drift(W8::new(), u, pool, inv_mass, p, i, v, un, sums) }
    }

    /// # Safety
    /// AVX2; as [`Lanewise::force_kick_drift`] for 8 nodes.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2")]
    unsafe fn force_kick_drift_avx2<S: Lanewise>(
        s: &S,
        u: &Coords,
        pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        let [vx, vy, vz] = v;
        let [nx, ny, nz] = un;
        let ([vx0, vx1], [vy0, vy1], [vz0, vz1]) = (halves(vx), halves(vy), halves(vz));
        let ([nx0, nx1], [ny0, ny1], [nz0, nz1]) = (halves(nx), halves(ny), halves(nz));
        // SAFETY: the processor has AVX2, and the rest is this fn's contract.
        unsafe {
            let w = W4::new();
            let (v0, n0) = ([vx0, vy0, vz0], [nx0, ny0, nz0]);
            s.force_kick_drift(w, u, pool, inv_mass, p, i, v0, n0, sums);
            let (v1, n1) = ([vx1, vy1, vz1], [nx1, ny1, nz1]);
            s.force_kick_drift(w, u, pool, inv_mass, p, i + 4, v1, n1, sums);
        }
    }

    /// The two halves of a block's 8 entries.
    #[inline(always)]
    fn halves(x: &mut [Real]) -> [&mut [Real]; 2] {
        let (a, b) = x.split_at_mut(4);
        [a, &mut b[..4]]
    }

    /// [`kick_drift`] of 8 nodes on AVX-512, for callers outside a vector entry.
    ///
    /// # Safety
    /// The processor has AVX-512F; otherwise as [`kick_drift`].
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn kick_drift8(
        dims: usize,
        f: [<W8 as Wide>::F; 3],
        u: Option<&Coords>,
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // SAFETY: the processor has AVX-512F, and the rest is the caller's contract.
        unsafe { kick_drift(W8::new(), dims, f, u, inv_mass, p, i, v, un, sums) }
    }
}
