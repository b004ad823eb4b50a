//! Stencil kernel for a box of Ladd's cubic lattice with one spring stiffness.
//!
//! A node's 18 neighbours sit at fixed index offsets `dx + nx (dy + ny dz)`, so no neighbour
//! index is stored: a node costs one 18-bit mask (which of its springs exist and are intact)
//! plus its `1/S_n`. Spring vectors are `D_d + (u_j - u_n)` with `D_d` the constant reference
//! vector of direction `d`.
//!
//! On processors with AVX-512F, blocks of 8 consecutive nodes are processed in one vector: the
//! neighbour rows are unaligned loads at the block index plus the direction's offset. Lengths
//! use the vector square root and one division per spring and pass: measured on this project's
//! 2-core AMD machine, that was as fast as the 14-bit reciprocal square root with the two Newton
//! steps double precision needs (one step leaves a relative error of 4e-9, too much for
//! `dL = l - L` at small strain), and it is exact. A block runs on the vector path
//! when all its neighbour indices are inside the arrays; which path a node takes depends only on
//! its index, never on how the nodes were split between threads, so results stay bit-identical
//! for any thread count. The portable scalar path computes the same formulas with `sqrt` and
//! division.

use rayon::prelude::*;

use super::{kick_drift, sweep_chunks, ChunkOut, StepParams, SweepSums, CHUNK};
use crate::body::Body;
use crate::lattice::LatticeKind;
use crate::math::{Coords, Real};
use crate::state::State;

/// Nodes per flag of the break screen (divides [`CHUNK`]).
pub const SCREEN: usize = 64;

/// The 18 directions of the Ladd star, in opposite pairs: `opposite(d) = d ^ 1`.
pub const DIRS: [[i32; 3]; 18] = [
    [1, 0, 0],
    [-1, 0, 0],
    [0, 1, 0],
    [0, -1, 0],
    [0, 0, 1],
    [0, 0, -1],
    [1, 1, 0],
    [-1, -1, 0],
    [1, -1, 0],
    [-1, 1, 0],
    [1, 0, 1],
    [-1, 0, -1],
    [1, 0, -1],
    [-1, 0, 1],
    [0, 1, 1],
    [0, -1, -1],
    [0, 1, -1],
    [0, -1, 1],
];

/// Precomputed stencil of a cubic box.
#[derive(Clone, Debug)]
pub struct CubicStencil {
    n: usize,
    /// Index offset of each direction.
    off: [isize; 18],
    /// Reference vector of each direction (m).
    dvec: [[Real; 3]; 18],
    /// Rest length of each direction (m).
    rest: [Real; 18],
    k: Real,
    q: Real,
    /// Bit d set: the spring in direction d exists and is intact.
    mask: Vec<u32>,
    /// `1 / S_n`, 0 for a node with no intact spring.
    inv_norm: Vec<Real>,
    /// Largest |offset|: blocks whose neighbours all lie within the arrays run vectorised.
    reach: usize,
    simd: bool,
}

impl CubicStencil {
    /// The stencil for `body` if it is a non-periodic box of the cubic lattice (at least 3 nodes
    /// per axis) with a single stiffness; `None` otherwise.
    pub fn new(body: &Body, state: &State) -> Option<Self> {
        let lat = &body.lattice;
        let g = lat.grid?;
        if lat.kind != LatticeKind::Cubic || g.iter().any(|&v| v < 3) || lat.is_periodic() {
            return None;
        }
        let k = *body.k.first()?;
        // Damaged (softened) springs have stiffnesses of their own: the general kernel runs
        // them.
        // Direction-weighted (anisotropic) materials have levers of their own: also general.
        if body.k.iter().any(|&v| v != k) || state.is_softened() || body.lever.is_some() {
            return None;
        }
        let (sy, sz) = (g[0] as isize, (g[0] * g[1]) as isize);
        let a = lat.spacing;
        let mut off = [0isize; 18];
        let mut dvec = [[0.0; 3]; 18];
        let mut rest = [0.0; 18];
        for (d, dir) in DIRS.iter().enumerate() {
            off[d] = dir[0] as isize + sy * dir[1] as isize + sz * dir[2] as isize;
            dvec[d] = [dir[0] as Real * a, dir[1] as Real * a, dir[2] as Real * a];
            rest[d] = a * ((dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]) as Real).sqrt();
        }
        let reach = off.iter().map(|o| o.unsigned_abs()).max().unwrap_or(0);
        let mut s = CubicStencil {
            n: lat.len(),
            off,
            dvec,
            rest,
            k,
            q: body.q,
            mask: vec![0; lat.len()],
            inv_norm: vec![0.0; lat.len()],
            reach,
            simd: simd_available(),
        };
        for b in 0..lat.bonds.len() {
            if state.alive[b] {
                let (i, d) = s.direction_of(body, b);
                let j = (i as isize + s.off[d]) as usize;
                s.mask[i] |= 1 << d;
                s.mask[j] |= 1 << (d ^ 1);
            }
        }
        for i in 0..s.n {
            s.refresh_norm(i);
        }
        Some(s)
    }

    /// Use (or not) the vector path, e.g. to measure the portable one. Ignored where the
    /// processor lacks AVX-512F.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = on && simd_available();
    }

    /// Whether the vector path is on.
    pub fn simd(&self) -> bool {
        self.simd
    }

    /// A copy with another dispersion ratio (q = 0: the plain law).
    pub fn with_q(&self, q: Real) -> Self {
        CubicStencil { q, ..self.clone() }
    }

    /// Kernel name for reports.
    pub fn name(&self) -> &'static str {
        if self.simd {
            "cubic-stencil-avx512"
        } else {
            "cubic-stencil-portable"
        }
    }

    /// Start node and direction of spring `b`.
    fn direction_of(&self, body: &Body, b: usize) -> (usize, usize) {
        let lat = &body.lattice;
        let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
        let dx = lat.pos.get(j) - lat.pos.get(i);
        let r = |v: Real| (v / lat.spacing).round() as i32;
        let dir = [r(dx.x), r(dx.y), r(dx.z)];
        let d = DIRS
            .iter()
            .position(|&e| e == dir)
            .expect("a cubic-lattice spring has one of the 18 directions");
        (i, d)
    }

    fn refresh_norm(&mut self, i: usize) {
        let m = self.mask[i];
        let s: Real = (0..18)
            .filter(|d| m & (1 << d) != 0)
            .map(|d| self.k * self.rest[d] * self.rest[d])
            .sum();
        self.inv_norm[i] = if s > 0.0 { 1.0 / s } else { 0.0 };
    }

    /// Clear spring `b` from the masks and refresh both ends' `1/S_n`.
    pub fn bond_killed(&mut self, body: &Body, b: usize) {
        let (i, d) = self.direction_of(body, b);
        let j = (i as isize + self.off[d]) as usize;
        self.mask[i] &= !(1 << d);
        self.mask[j] &= !(1 << (d ^ 1));
        self.refresh_norm(i);
        self.refresh_norm(j);
    }

    /// True when node block starting at `i` (8 nodes) can use the vector path.
    #[inline]
    fn block_inside(&self, i: usize) -> bool {
        i >= self.reach && i + 8 + self.reach <= self.n
    }

    #[inline(always)]
    fn spring(&self, u: &Coords, i: usize, d: usize) -> (usize, [Real; 3], Real, Real) {
        let j = (i as isize + self.off[d]) as usize;
        let dv = self.dvec[d];
        let x = [
            dv[0] + (u.x()[j] - u.x()[i]),
            dv[1] + (u.y()[j] - u.y()[i]),
            dv[2] + (u.z()[j] - u.z()[i]),
        ];
        let l = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
        (j, x, l, l - self.rest[d])
    }

    /// Node i's pool and whether one of its intact springs has `dL > screen L`.
    fn pool_scalar(&self, u: &Coords, i: usize, screen: Real) -> (Real, bool) {
        let m = self.mask[i];
        let mut pi = 0.0;
        let mut hot = false;
        for d in 0..18 {
            if m & (1 << d) != 0 {
                let (_, _, _, dl) = self.spring(u, i, d);
                pi += self.k * self.rest[d] * dl;
                hot |= dl > screen * self.rest[d];
            }
        }
        (pi * self.inv_norm[i], hot)
    }

    fn force_scalar(&self, u: &Coords, pool: &[Real], i: usize) -> [Real; 3] {
        let m = self.mask[i];
        let mut f = [0.0; 3];
        for d in 0..18 {
            if m & (1 << d) != 0 {
                let (j, x, l, dl) = self.spring(u, i, d);
                let t = self.k * dl + self.q * self.k * self.rest[d] * (pool[i] + pool[j]);
                let s = t / l;
                f[0] += s * x[0];
                f[1] += s * x[1];
                f[2] += s * x[2];
            }
        }
        f
    }

    /// Sweep 1, and with a finite `screen` s the break screen: `state.hot` flags each block of
    /// [`SCREEN`] nodes with an intact spring of `dL > s L` (seen from either end: both ends
    /// compute the same length).
    ///
    /// With `chunks` (one rank's share of a distributed run), only those node chunks, and every
    /// other screen flag cleared.
    pub fn pools(
        &self,
        _body: &Body,
        state: &mut State,
        screen: Real,
        chunks: Option<std::ops::Range<usize>>,
    ) {
        if self.q == 0.0 && !screen.is_finite() {
            state.pool.fill(0.0);
            return;
        }
        let blocks = self.n.div_ceil(SCREEN);
        if state.hot.len() != blocks {
            state.hot = vec![false; blocks];
        }
        let all = 0..self.n.div_ceil(CHUNK);
        let shared = chunks.is_some();
        let chunks = chunks.unwrap_or(all);
        if shared {
            state.hot.fill(false);
        }
        let u = &state.u;
        let (first, per) = (chunks.start, CHUNK / SCREEN);
        let nodes = (first * CHUNK).min(self.n)..(chunks.end * CHUNK).min(self.n);
        let flags = (first * per).min(blocks)..(chunks.end * per).min(blocks);
        state.pool[nodes]
            .par_chunks_mut(CHUNK)
            .zip(state.hot[flags].par_chunks_mut(per))
            .enumerate()
            .for_each(|(c, (out, hot))| self.pool_chunk(u, first + c, out, hot, screen));
    }

    /// Sweep 1 over chunk `c` (its pools `out` and screen flags `hot`).
    fn pool_chunk(&self, u: &Coords, c: usize, out: &mut [Real], hot: &mut [bool], screen: Real) {
        hot.fill(false);
        let start = c * CHUNK;
        let mut k = 0;
        while k < out.len() {
            let i = start + k;
            if self.simd && k + 8 <= out.len() && self.block_inside(i) {
                // SAFETY: AVX-512F was detected; the block and its neighbours are in bounds.
                #[cfg(target_arch = "x86_64")]
                {
                    let h = unsafe { avx512::pools8(self, u, i, &mut out[k..k + 8], screen) };
                    // A block of 8 may straddle two screen blocks (scalar steps shift it).
                    hot[k / SCREEN] |= h;
                    hot[(k + 7) / SCREEN] |= h;
                }
                k += 8;
            } else {
                let (p, h) = self.pool_scalar(u, i, screen);
                out[k] = p;
                hot[k / SCREEN] |= h;
                k += 1;
            }
        }
        if self.q == 0.0 {
            out.fill(0.0);
        }
    }

    /// After springs broke between sweep 1 and sweep 2 (`bond_killed` already applied):
    /// recompute the pools of the chunks holding their ends with the same code as sweep 1, so
    /// the bits are those of breaking before the step.
    pub fn repair(&self, body: &Body, state: &mut State, killed: &[u32]) {
        if self.q == 0.0 {
            return;
        }
        let mut chunks: Vec<usize> = killed
            .iter()
            .flat_map(|&b| body.lattice.bonds.ends[b as usize])
            .map(|n| n as usize / CHUNK)
            .collect();
        chunks.sort_unstable();
        chunks.dedup();
        let mut scratch = [false; CHUNK / SCREEN];
        for c in chunks {
            let r = c * CHUNK..((c + 1) * CHUNK).min(self.n);
            let blocks = r.len().div_ceil(SCREEN);
            self.pool_chunk(
                &state.u,
                c,
                &mut state.pool[r],
                &mut scratch[..blocks],
                Real::INFINITY,
            );
        }
    }

    /// Sweep 2 over the node chunks `chunks`.
    #[allow(clippy::too_many_arguments)]
    pub fn force_kick_drift(
        &self,
        _body: &Body,
        state: &mut State,
        inv_mass: &[Real],
        p: &StepParams,
        u_next: &mut Coords,
        partials: &mut [SweepSums],
        chunks: std::ops::Range<usize>,
    ) -> SweepSums {
        let (u, pool) = (&state.u, &state.pool);
        sweep_chunks(self.n, chunks, &mut state.v, u_next, partials, |r, o| {
            let ChunkOut {
                v: [vx, vy, vz],
                u_next: [nx, ny, nz],
            } = o;
            let mut sums = SweepSums::default();
            let len = r.len();
            let mut k = 0;
            while k < len {
                let i = r.start + k;
                if self.simd && k + 8 <= len && self.block_inside(i) {
                    #[cfg(target_arch = "x86_64")]
                    {
                        // SAFETY: AVX-512F was detected; the block and its neighbours are in
                        // bounds; the output slices hold the block's 8 nodes.
                        let s = unsafe {
                            avx512::force_kick_drift8(
                                self,
                                u,
                                pool,
                                inv_mass,
                                p,
                                i,
                                [&mut vx[k..k + 8], &mut vy[k..k + 8], &mut vz[k..k + 8]],
                                [&mut nx[k..k + 8], &mut ny[k..k + 8], &mut nz[k..k + 8]],
                            )
                        };
                        sums += s;
                    }
                    k += 8;
                } else {
                    let f = self.force_scalar(u, pool, i);
                    let (d, w) = kick_drift(
                        f,
                        inv_mass[i],
                        p,
                        [&mut vx[k], &mut vy[k], &mut vz[k]],
                        [u.x()[i], u.y()[i], u.z()[i]],
                        [&mut nx[k], &mut ny[k], &mut nz[k]],
                    );
                    sums.dissipated += d;
                    sums.body_work += w;
                    k += 1;
                }
            }
            sums
        })
    }
}

fn simd_available() -> bool {
    super::simd_allowed() && {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx512f")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    use super::{CubicStencil, StepParams, SweepSums};
    use crate::math::{Coords, Real};

    /// Current vectors of the springs in direction `d` of the block at `i`, and their squared
    /// lengths.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn vector8(
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        d: usize,
        ui: [__m512d; 3],
    ) -> ([__m512d; 3], __m512d) {
        let j = (i as isize + s.off[d]) as usize;
        let dv = s.dvec[d];
        let comp = |c: &[Real], k: usize| {
            // SAFETY (caller): j..j+8 is in bounds because the block is inside.
            unsafe {
                _mm512_add_pd(
                    _mm512_set1_pd(dv[k]),
                    _mm512_sub_pd(_mm512_loadu_pd(c.as_ptr().add(j)), ui[k]),
                )
            }
        };
        let (x, y, z) = (comp(u.x(), 0), comp(u.y(), 1), comp(u.z(), 2));
        (
            [x, y, z],
            _mm512_fmadd_pd(x, x, _mm512_fmadd_pd(y, y, _mm512_mul_pd(z, z))),
        )
    }

    /// Spring vectors, 1/l and extension of direction `d` for the block at `i`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn spring8(
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        d: usize,
        ui: [__m512d; 3],
    ) -> ([__m512d; 3], __m512d, __m512d) {
        let (x, ss) = unsafe { vector8(s, u, i, d, ui) };
        let l = _mm512_sqrt_pd(ss);
        let r = _mm512_div_pd(_mm512_set1_pd(1.0), l);
        let dl = _mm512_sub_pd(l, _mm512_set1_pd(s.rest[d]));
        (x, r, dl)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load_block(s: &CubicStencil, u: &Coords, i: usize) -> ([__m512d; 3], __m256i) {
        // SAFETY (caller): i..i+8 is in bounds.
        unsafe {
            (
                [
                    _mm512_loadu_pd(u.x().as_ptr().add(i)),
                    _mm512_loadu_pd(u.y().as_ptr().add(i)),
                    _mm512_loadu_pd(u.z().as_ptr().add(i)),
                ],
                _mm256_loadu_si256(s.mask.as_ptr().add(i) as *const __m256i),
            )
        }
    }

    /// Lanes whose spring in direction `d` is intact.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn lanes(mask: __m256i, d: usize) -> __mmask8 {
        let bits = _mm512_cvtepu32_epi64(mask);
        _mm512_test_epi64_mask(bits, _mm512_set1_epi64(1 << d))
    }

    /// Sweep 1 for the 8 nodes at `i`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn pools8(
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        let (ui, mask) = unsafe { load_block(s, u, i) };
        let mut acc = _mm512_setzero_pd();
        let mut hot: __mmask8 = 0;
        for d in 0..18 {
            let m = unsafe { lanes(mask, d) };
            if m == 0 {
                continue;
            }
            // The pool needs only the length, not its inverse: one square root.
            let (_, ss) = unsafe { vector8(s, u, i, d, ui) };
            let l = _mm512_sqrt_pd(ss);
            let dl = _mm512_sub_pd(l, _mm512_set1_pd(s.rest[d]));
            acc = _mm512_mask3_fmadd_pd(_mm512_set1_pd(s.k * s.rest[d]), dl, acc, m);
            hot |= _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(m, dl, _mm512_set1_pd(screen * s.rest[d]));
        }
        // SAFETY: out has 8 entries; inv_norm[i..i+8] is in bounds.
        unsafe {
            let inv = _mm512_loadu_pd(s.inv_norm.as_ptr().add(i));
            _mm512_storeu_pd(out.as_mut_ptr(), _mm512_mul_pd(acc, inv));
        }
        hot != 0
    }

    /// Sweep 2 for the 8 nodes at `i`: force, kick, drift.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn force_kick_drift8(
        s: &CubicStencil,
        u: &Coords,
        pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
    ) -> SweepSums {
        let (ui, mask) = unsafe { load_block(s, u, i) };
        let pi = unsafe { _mm512_loadu_pd(pool.as_ptr().add(i)) };
        let kv = _mm512_set1_pd(s.k);
        let mut f = [_mm512_setzero_pd(); 3];
        for d in 0..18 {
            let m = unsafe { lanes(mask, d) };
            if m == 0 {
                continue;
            }
            let j = (i as isize + s.off[d]) as usize;
            let (x, r, dl) = unsafe { spring8(s, u, i, d, ui) };
            let pj = unsafe { _mm512_loadu_pd(pool.as_ptr().add(j)) };
            let t = _mm512_fmadd_pd(
                kv,
                dl,
                _mm512_mul_pd(_mm512_set1_pd(s.q * s.k * s.rest[d]), _mm512_add_pd(pi, pj)),
            );
            // Broken or missing springs: zero their share (their lanes may hold anything).
            let sc = _mm512_maskz_mov_pd(m, _mm512_mul_pd(t, r));
            for c in 0..3 {
                f[c] = _mm512_fmadd_pd(sc, x[c], f[c]);
            }
        }
        let h = 0.5 * p.damping * p.dt;
        let shrink = _mm512_set1_pd(1.0 - h);
        let grow = _mm512_set1_pd(1.0 / (1.0 + h));
        let dt = _mm512_set1_pd(p.dt);
        let half = _mm512_set1_pd(0.5);
        let im = unsafe { _mm512_loadu_pd(inv_mass.as_ptr().add(i)) };
        let mut v2 = _mm512_setzero_pd();
        let mut gw = _mm512_setzero_pd();
        let [vx, vy, vz] = v;
        let [nx, ny, nz] = un;
        for (c, (vs, ns)) in [(vx, nx), (vy, ny), (vz, nz)].into_iter().enumerate() {
            // SAFETY: each slice holds the block's 8 entries.
            unsafe {
                let old = _mm512_loadu_pd(vs.as_ptr());
                let acc = _mm512_fmadd_pd(f[c], im, _mm512_set1_pd(p.accel[c]));
                let new = _mm512_mul_pd(_mm512_fmadd_pd(dt, acc, _mm512_mul_pd(shrink, old)), grow);
                _mm512_storeu_pd(vs.as_mut_ptr(), new);
                _mm512_storeu_pd(ns.as_mut_ptr(), _mm512_fmadd_pd(dt, new, ui[c]));
                let mid = _mm512_mul_pd(half, _mm512_add_pd(old, new));
                v2 = _mm512_fmadd_pd(mid, mid, v2);
                gw = _mm512_fmadd_pd(_mm512_set1_pd(p.accel[c]), mid, gw);
            }
        }
        if p.damping == 0.0 && p.accel == [0.0; 3] {
            return SweepSums::default();
        }
        // Per-lane masses (1/inv_mass), summed lane by lane in a fixed order.
        let mut lane_v2 = [0.0; 8];
        let mut lane_gw = [0.0; 8];
        let mut lane_im = [0.0; 8];
        unsafe {
            _mm512_storeu_pd(lane_v2.as_mut_ptr(), v2);
            _mm512_storeu_pd(lane_gw.as_mut_ptr(), gw);
            _mm512_storeu_pd(lane_im.as_mut_ptr(), im);
        }
        let mut sums = SweepSums::default();
        for l in 0..8 {
            let m = if lane_im[l] > 0.0 {
                1.0 / lane_im[l]
            } else {
                0.0
            };
            sums.dissipated += p.damping * m * lane_v2[l] * p.dt;
            sums.body_work += m * lane_gw[l] * p.dt;
        }
        sums
    }
}
