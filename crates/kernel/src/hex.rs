//! Stencil kernel for a box of the hexagonal lattice with one spring stiffness (or one bulk
//! stiffness and the cell weights of its edges, [`Body::with_cell_weights`]).
//!
//! Node `c + nx r` sits in row `r` (odd rows shifted by `a/2`), and its six neighbours are at
//! index offsets that depend only on the row's parity:
//!
//! ```text
//!             E     W     NE        SW        NW        SE
//! even row   +1    -1    +nx      -nx - 1   +nx - 1    -nx
//! odd row    +1    -1    +nx + 1  -nx       +nx       -nx + 1
//! ```
//!
//! so no neighbour index is stored: a node costs a 6-bit mask (which of its springs exist and are
//! intact) with its weight class in bits `CLASS_SHIFT`.. of the same word (`Factors`), and
//! its `1/S_n`. A spring's current vector is `D_d + w` with `D_d` the direction's
//! constant reference vector and `w = u_j - u_n`; its extension is the cancellation-free
//! `dL = (2 D_d.w + w.w) / (l + L)` of the reference law ([`hooke_model::law::spring_geometry`]), so
//! a body at rest has exactly zero force and small strains keep their digits.
//!
//! On processors with AVX-512F, blocks of 8 consecutive nodes of one row are processed in one
//! vector (unaligned loads at the block index plus the direction's offset). The vector path
//! performs exactly the scalar path's IEEE operations in the same order (no fused
//! multiply-adds; masked lanes skip a spring as the scalar loop does), so both give the same
//! bits: results do not depend on which nodes took which path, on the thread count, or on
//! whether the processor has AVX-512 at all.

use super::stencil::{simd_lanes, Factors, Lanes, Src, Stencil};
use super::{StepParams, SweepSums};
use hooke_model::body::Body;
use hooke_model::lattice::LatticeKind;
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// Nodes per flag of the break screen (the cubic stencil's blocks, so
/// [`super::Kernel::hot_springs`] reads both alike).
pub const SCREEN: usize = super::stencil::SCREEN;

/// Number of directions; opposite pairs are `d` and `d ^ 1`.
const DIRS: usize = 6;

/// First bit of a node's weight class in its mask word (the directions take bits 0..6).
const CLASS_SHIFT: u32 = 8;

/// Precomputed stencil of a hexagonal box.
#[derive(Clone, Debug)]
pub struct HexStencil {
    n: usize,
    nx: usize,
    /// Index offset of each direction, for even and odd rows.
    off: [[isize; DIRS]; 2],
    /// Reference vector of each direction (m).
    dvec: [[Real; 2]; DIRS],
    /// Rest length `a` (m).
    rest: Real,
    /// Bulk stiffness (N/m); a spring's is `k w` ([`Factors`]).
    k: Real,
    q: Real,
    /// Bit d set: the spring in direction d exists and is intact; bits [`CLASS_SHIFT`]..: the
    /// node's weight class.
    mask: Vec<u16>,
    /// Spring factors by direction and class (every factor 1 unless cell-weighted).
    factors: Factors<DIRS>,
    /// `1 / S_n`, 0 for a node with no intact spring.
    inv_norm: Vec<Real>,
    /// Largest |offset|: blocks whose neighbours all lie within the arrays may run vectorised.
    reach: usize,
    /// The vector path's instructions (`None`: the portable path).
    simd: Option<Lanes>,
}

impl HexStencil {
    /// Heap memory by part (see [`hooke_model::memory::Footprint`]).
    pub fn footprint(&self) -> hooke_model::memory::Footprint {
        use hooke_model::memory::bytes;
        vec![(
            "stencil masks and normalisers",
            bytes(&self.mask) + bytes(&self.inv_norm),
        )]
    }

    /// The stencil for `body` if it is a non-periodic box of the hexagonal lattice (at least 2
    /// nodes per row and 2 rows) with a single stiffness, or one bulk stiffness with factors of
    /// at most `stencil::CLASSES` kinds of node (cell weights), and the isotropic law;
    /// `None` otherwise.
    pub fn new(body: &Body, state: &State) -> Option<Self> {
        let lat = &body.lattice;
        let g = lat.grid?;
        if lat.kind != LatticeKind::Hex || g[0] < 2 || g[1] < 2 || lat.is_periodic() {
            return None;
        }
        if lat.len() != g[0] * g[1] {
            return None;
        }
        if state.is_softened() || body.lever.is_some() {
            return None;
        }
        // The bulk stiffness: the largest (cell weights only lower a spring's).
        let k = match body.k.uniform_value() {
            Some(k) => k,
            None => body.k.iter().cloned().fold(0.0, Real::max),
        };
        let nx = g[0] as isize;
        let a = lat.spacing;
        let h = a * (3.0 as Real).sqrt() / 2.0;
        let off = [
            [1, -1, nx, -nx - 1, nx - 1, -nx],
            [1, -1, nx + 1, -nx, nx, -nx + 1],
        ];
        let dvec = [
            [a, 0.0],
            [-a, 0.0],
            [0.5 * a, h],
            [-0.5 * a, -h],
            [-0.5 * a, h],
            [0.5 * a, -h],
        ];
        let mut s = HexStencil {
            n: lat.len(),
            nx: g[0],
            off,
            dvec,
            rest: a,
            k,
            q: body.q,
            mask: vec![0; lat.len()],
            factors: Factors {
                w: [[1.0; super::stencil::CLASSES]; DIRS],
                on: false,
            },
            inv_norm: vec![0.0; lat.len()],
            reach: (nx + 1) as usize,
            simd: simd_lanes(),
        };
        let uniform = body.k.uniform_value().is_some() || body.k.iter().all(|&v| v == k);
        if let Some(g) = lat.bonds.grid() {
            if uniform && state.alive.iter().all(|&a| a) {
                // One stiffness, every spring intact: each node's directions that stay in the
                // box, without the rows.
                let star = g.star();
                for i in 0..s.n {
                    let mut m = 0;
                    g.links(&star, i, |j, _| {
                        let step = j as isize - i as isize;
                        let d = (0..DIRS).find(|&d| s.offset(i, d) == step);
                        m |= 1 << d.expect("a grid link is a star direction");
                    });
                    s.mask[i] = m;
                    s.refresh_norm(i);
                }
                return Some(s);
            }
        }
        // Each node's springs' stiffnesses by direction, for the weight classes.
        let mut stiff = vec![[None; DIRS]; if uniform { 0 } else { s.n }];
        for b in 0..lat.bonds.len() {
            let (i, d) = s.direction_of(body, b)?;
            let j = lat.bonds.ends[b][1] as usize;
            if (i as isize + s.offset(i, d)) as usize != j {
                return None;
            }
            if let Ok([si, sj]) = stiff.get_disjoint_mut([i, j]) {
                si[d] = Some(body.k[b]);
                sj[d ^ 1] = Some(body.k[b]);
            }
            if state.alive[b] {
                let j = (i as isize + s.offset(i, d)) as usize;
                s.mask[i] |= 1 << d;
                s.mask[j] |= 1 << (d ^ 1);
            }
        }
        if !stiff.is_empty() {
            let (class, factors) = Factors::classify(s.n, k, |i| stiff[i])?;
            s.factors = factors;
            for (m, c) in s.mask.iter_mut().zip(class) {
                *m |= (c as u16) << CLASS_SHIFT;
            }
        }
        for i in 0..s.n {
            s.refresh_norm(i);
        }
        Some(s)
    }

    /// Use (or not) the vector path. Ignored where the processor lacks AVX-512F. Either way
    /// the results are the same bits.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = if on { simd_lanes() } else { None };
    }

    /// Whether the vector path is on.
    pub fn simd(&self) -> bool {
        self.simd.is_some()
    }

    /// Take the AVX2 path where the processor has it, even if it has AVX-512 too (for tests
    /// and measurements of that path); false (and nothing changed) without AVX2.
    pub fn use_avx2(&mut self) -> bool {
        let lanes = super::stencil::avx2_lanes();
        if lanes.is_some() {
            self.simd = lanes;
        }
        lanes.is_some()
    }

    /// A copy with another dispersion ratio (q = 0: the plain law).
    pub fn with_q(&self, q: Real) -> Self {
        HexStencil { q, ..self.clone() }
    }

    /// Kernel name for reports.
    pub fn name(&self) -> &'static str {
        match self.simd {
            Some(Lanes::Avx512) => "hex-stencil-avx512",
            Some(Lanes::Avx2) => "hex-stencil-avx2",
            None => "hex-stencil-portable",
        }
    }

    #[inline(always)]
    fn offset(&self, i: usize, d: usize) -> isize {
        self.off[(i / self.nx) & 1][d]
    }

    /// Lower end and direction of spring `b` (`None` if it is not one of the six).
    fn direction_of(&self, body: &Body, b: usize) -> Option<(usize, usize)> {
        let lat = &body.lattice;
        let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
        let dx = lat.pos.get(j) - lat.pos.get(i);
        let (x, y) = (dx.x / lat.spacing, dx.y / lat.spacing);
        let d = if y.abs() < 0.25 {
            if x > 0.0 {
                0
            } else {
                1
            }
        } else if y > 0.0 {
            if x > 0.0 {
                2
            } else {
                4
            }
        } else if x > 0.0 {
            5
        } else {
            3
        };
        Some((i, d))
    }

    fn refresh_norm(&mut self, i: usize) {
        let m = self.mask[i];
        let c = (m >> CLASS_SHIFT) as usize;
        let mut s = 0.0;
        for d in 0..DIRS {
            if m & (1 << d) != 0 {
                s += self.k * self.rest * self.rest * self.factors.get(d, c);
            }
        }
        self.inv_norm[i] = if s > 0.0 { 1.0 / s } else { 0.0 };
    }

    /// Clear spring `b` from the masks and refresh both ends' `1/S_n`.
    pub fn bond_killed(&mut self, body: &Body, b: usize) {
        if let Some((i, d)) = self.direction_of(body, b) {
            let j = (i as isize + self.offset(i, d)) as usize;
            self.mask[i] &= !(1 << d);
            self.mask[j] &= !(1 << (d ^ 1));
            self.refresh_norm(i);
            self.refresh_norm(j);
        }
    }

    /// True when the 8 nodes from `i` lie in one row and all their neighbour indices inside the
    /// arrays: the vector path may run them.
    #[inline]
    fn block_inside(&self, i: usize) -> bool {
        i >= self.reach && i + 8 + self.reach <= self.n && i % self.nx + 8 <= self.nx
    }

    /// Current vector, squared length and the numerator `2 D.w + w.w` of the extension of
    /// node i's spring in direction d (the reference law's operations, in its order).
    #[inline(always)]
    fn spring(&self, u: &Coords, i: usize, d: usize) -> (usize, [Real; 2], Real, Real) {
        let j = (i as isize + self.offset(i, d)) as usize;
        let big = self.dvec[d];
        let w = [u.x()[j] - u.x()[i], u.y()[j] - u.y()[i]];
        let x = [big[0] + w[0], big[1] + w[1]];
        let d2 = x[0] * x[0] + x[1] * x[1];
        let num = 2.0 * (big[0] * w[0] + big[1] * w[1]) + (w[0] * w[0] + w[1] * w[1]);
        (j, x, d2, num)
    }

    /// Node i's pool and whether one of its intact springs has `dL > screen L`.
    fn pool_scalar(&self, u: &Coords, i: usize, screen: Real) -> (Real, bool) {
        let m = self.mask[i];
        let c = (m >> CLASS_SHIFT) as usize;
        let (kl, lim) = (self.k * self.rest, screen * self.rest);
        let mut pi = 0.0;
        let mut hot = false;
        for d in 0..DIRS {
            if m & (1 << d) != 0 {
                let (_, _, d2, num) = self.spring(u, i, d);
                let dl = num / (d2.sqrt() + self.rest);
                pi += kl * dl * self.factors.get(d, c);
                hot |= dl > lim;
            }
        }
        (pi * self.inv_norm[i], hot)
    }

    fn force_scalar(&self, u: &Coords, pool: &[Real], i: usize) -> [Real; 3] {
        let m = self.mask[i];
        let c = (m >> CLASS_SHIFT) as usize;
        let qkl = self.q * self.k * self.rest;
        let mut f = [0.0; 2];
        for d in 0..DIRS {
            if m & (1 << d) != 0 {
                let (j, x, d2, num) = self.spring(u, i, d);
                let l = d2.sqrt();
                let dl = num / (l + self.rest);
                let t = (self.k * dl + qkl * (pool[i] + pool[j])) * self.factors.get(d, c);
                let s = t / l;
                f[0] += s * x[0];
                f[1] += s * x[1];
            }
        }
        [f[0], f[1], 0.0]
    }
}

impl Stencil for HexStencil {
    fn nodes(&self) -> usize {
        self.n
    }

    fn q(&self) -> Real {
        self.q
    }

    fn dim(&self) -> usize {
        2
    }

    #[inline]
    fn vector_block(&self, i: usize) -> bool {
        self.simd.is_some() && self.block_inside(i)
    }

    fn pool_one(&self, u: &Src, i: usize, screen: Real) -> (Real, bool) {
        self.pool_scalar(u, i, screen)
    }

    fn force_one(&self, u: &Src, pool: &[Real], i: usize) -> [Real; 3] {
        self.force_scalar(u, pool, i)
    }

    /// # Safety
    /// As the trait's: only when [`Stencil::vector_block`] holds for `i` (the vector path
    /// is on, the processor has its instructions, and the block and its neighbours are nodes).
    #[cfg(target_arch = "x86_64")]
    unsafe fn pool_block(&self, u: &Src, i: usize, out: &mut [Real], screen: Real) -> bool {
        // SAFETY: by the caller's contract, the vector path is on (so the processor has its instructions) and
        // the block and its neighbours are in bounds.
        unsafe {
            let avx2 = self.simd == Some(Lanes::Avx2);
            crate::stencil::vector::pools8(self, avx2, u, i, out, screen)
        }
    }

    /// # Safety
    /// As the trait's: only when [`Stencil::vector_block`] holds for `i` (the vector path
    /// is on, the processor has its instructions, and the block and its neighbours are nodes).
    #[cfg(target_arch = "x86_64")]
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
    ) {
        // SAFETY: by the caller's contract, as for `pool_block`.
        unsafe {
            let avx2 = self.simd == Some(Lanes::Avx2);
            crate::stencil::vector::force_kick_drift8(
                self, avx2, u, pool, inv_mass, p, i, v, un, sums,
            )
        }
    }
}

/// The vector path, one source for AVX-512 (8 nodes to a vector) and AVX2 (4 nodes, a block
/// of 8, one row, as two halves) through [`crate::wide`]: the scalar path's operations lane by
/// lane.
#[cfg(target_arch = "x86_64")]
mod vector {
    use super::{HexStencil, StepParams, SweepSums, CLASS_SHIFT, DIRS};
    use crate::stencil::vector::{kick_drift, Lanewise};
    use crate::wide::Wide;
    use hooke_model::math::{Coords, Real};

    /// The N nodes' displacements from `i` and their mask words (one 64-bit lane per node).
    ///
    /// # Safety
    /// The block's nodes from `i` are in bounds of `u` and of the stencil's mask words.
    #[inline(always)]
    unsafe fn load_block<W: Wide>(w: W, s: &HexStencil, u: &Coords, i: usize) -> ([W::F; 2], W::I) {
        // SAFETY: by the caller's contract, i..i+N is in bounds.
        unsafe {
            (
                [w.load(u.x().as_ptr().add(i)), w.load(u.y().as_ptr().add(i))],
                w.words16(s.mask.as_ptr().add(i)),
            )
        }
    }

    /// The block's weight classes, if one of its nodes has factors other than 1 (as the cubic
    /// stencil's).
    #[inline(always)]
    fn classes<W: Wide>(w: W, s: &HexStencil, mask: W::I) -> Option<W::I> {
        if !s.factors.on {
            return None;
        }
        w.classes(mask, CLASS_SHIFT)
    }

    /// Spring vector, squared length and extension numerator of direction `d` for the block at
    /// `i` (the scalar path's operations, lane by lane).
    ///
    /// # Safety
    /// The block at `i` is inside the body's box, so that its neighbours in direction `d` are
    /// nodes (`vector_block`).
    #[inline(always)]
    unsafe fn spring<W: Wide>(
        w: W,
        s: &HexStencil,
        u: &Coords,
        i: usize,
        d: usize,
        ui: [W::F; 2],
    ) -> (usize, [W::F; 2], W::F, W::F) {
        let j = (i as isize + s.offset(i, d)) as usize;
        let big = s.dvec[d];
        // SAFETY: by the caller's contract, j..j+N is in bounds because the block is inside.
        let (wx, wy) = unsafe {
            (
                w.load(u.x().as_ptr().add(j)) - ui[0],
                w.load(u.y().as_ptr().add(j)) - ui[1],
            )
        };
        let (bx, by) = (w.splat(big[0]), w.splat(big[1]));
        let x = [bx + wx, by + wy];
        let d2 = x[0] * x[0] + x[1] * x[1];
        let bw = bx * wx + by * wy;
        let ww = wx * wx + wy * wy;
        let num = w.splat(2.0) * bw + ww;
        (j, x, d2, num)
    }

    impl Lanewise for HexStencil {
        #[inline(always)]
        unsafe fn pools<W: Wide>(
            &self,
            w: W,
            u: &Coords,
            i: usize,
            out: &mut [Real],
            screen: Real,
        ) -> bool {
            let s = self;
            // SAFETY: the block at this index is in bounds (this fn's contract).
            let (ui, mask) = unsafe { load_block(w, s, u, i) };
            let cls = classes(w, s, mask);
            let kl = w.splat(s.k * s.rest);
            let rest = w.splat(s.rest);
            let lim = w.splat(screen * s.rest);
            let mut acc = w.zero();
            let mut hot = w.no_lanes();
            for d in 0..DIRS {
                let m = w.bit(mask, d);
                if !w.any(m) {
                    continue;
                }
                // SAFETY: the block is inside (this fn's contract), so its neighbours in direction d are nodes.
                let (_, _, d2, num) = unsafe { spring(w, s, u, i, d, ui) };
                let dl = num / (w.sqrt(d2) + rest);
                let mut share = kl * dl;
                if let Some(c) = cls {
                    share = share * w.factors(&s.factors.w[d], c);
                }
                acc = w.add_where(acc, m, share);
                hot = hot | w.gt_where(m, dl, lim);
            }
            // SAFETY: out has N entries; inv_norm[i..i+N] is in bounds.
            unsafe {
                let inv = w.load(s.inv_norm.as_ptr().add(i));
                w.store(out.as_mut_ptr(), acc * inv);
            }
            w.any(hot)
        }

        #[inline(always)]
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
        ) {
            let s = self;
            // SAFETY: the block at this index is in bounds (this fn's contract).
            let ((ui, mask), pi) =
                unsafe { (load_block(w, s, u, i), w.load(pool.as_ptr().add(i))) };
            let cls = classes(w, s, mask);
            let (kv, qkl, rest) = (w.splat(s.k), w.splat(s.q * s.k * s.rest), w.splat(s.rest));
            let mut f = [w.zero(); 2];
            for d in 0..DIRS {
                let m = w.bit(mask, d);
                if !w.any(m) {
                    continue;
                }
                // SAFETY: the block is inside (this fn's contract), so its neighbours in direction d are nodes.
                let (j, x, d2, num) = unsafe { spring(w, s, u, i, d, ui) };
                let l = w.sqrt(d2);
                let dl = num / (l + rest);
                // SAFETY: j.. is the block's neighbours in direction d: nodes, as the block is inside (this fn's contract).
                let pj = unsafe { w.load(pool.as_ptr().add(j)) };
                let mut t = kv * dl + qkl * (pi + pj);
                if let Some(c) = cls {
                    t = t * w.factors(&s.factors.w[d], c);
                }
                let sc = t / l;
                for c in 0..2 {
                    f[c] = w.add_where(f[c], m, sc * x[c]);
                }
            }
            let f = [f[0], f[1], w.zero()];
            // SAFETY: by the caller's contract, the block is in bounds.
            unsafe { kick_drift(w, p.dims(2), f, Some(u), inv_mass, p, i, v, un, sums) }
        }
    }
}
