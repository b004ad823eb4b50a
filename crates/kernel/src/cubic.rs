//! Stencil kernel for a box of Ladd's cubic lattice with one spring stiffness (or one bulk
//! stiffness and the cell weights of its faces and edges, [`Body::with_cell_weights`]).
//!
//! A node's 18 neighbours sit at fixed index offsets `dx + nx (dy + ny dz)`, so no neighbour
//! index is stored: a node costs one 18-bit mask (which of its springs exist and are intact),
//! its weight class in bits `CLASS_SHIFT`.. of the same word (`Factors`), plus its `1/S_n`. Spring vectors are `D_d + (u_j - u_n)` with `D_d` the constant reference
//! vector of direction `d`.
//!
//! On processors with AVX-512F, blocks of 8 consecutive nodes are processed in one vector (with
//! AVX2 only, in two vectors of 4, blends standing in for masked adds): the
//! neighbour rows are unaligned loads at the block index plus the direction's offset. Lengths
//! use the vector square root and one division per spring and pass: measured on this project's
//! 2-core AMD machine, that was as fast as the 14-bit reciprocal square root with the two Newton
//! steps double precision needs (one step leaves a relative error of 4e-9, too much for
//! `dL = l - L` at small strain), and it is exact. A block runs on the vector path when all its
//! neighbour indices are inside the arrays. The vector path performs the portable scalar path's
//! IEEE operations in the same order, lane by lane (no fused multiply-adds; a masked lane skips a
//! spring as the scalar loop does), so the two give the same bits: results depend neither on
//! which nodes took which path nor on the thread count or the processor.

use std::sync::{Arc, Mutex};

use super::stencil::{simd_lanes, Factors, Lanes, Src, Stencil};
use super::{StepParams, SweepSums};
use rayon::prelude::*;

use hooke_model::body::{Body, GridStiffness};
use hooke_model::lattice::LatticeKind;
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// Nodes per flag of the break screen.
pub const SCREEN: usize = super::stencil::SCREEN;

/// First bit of a node's weight class in its mask word (the directions take bits 0..18).
const CLASS_SHIFT: u32 = 24;

/// `1/S_n` of a node whose intact springs are the directions set in `mask` (`S_n = sum k_t
/// L^2` in direction order, `k_t = k w`), or 0 for a node without springs.
fn inv_norm(mask: u32, k: Real, rest: &[Real; 18], w: &Factors<18>) -> Real {
    let c = (mask >> CLASS_SHIFT) as usize;
    let s: Real = (0..18)
        .filter(|d| mask & (1 << d) != 0)
        .map(|d| k * rest[d] * rest[d] * w.get(d, c))
        .sum();
    if s > 0.0 {
        1.0 / s
    } else {
        0.0
    }
}

/// The direction from node `i` to its neighbour `j` on the box's grid, from the index step
/// `j - i` alone (the 18 steps `off` are distinct with at least 3 nodes along x and y): reading
/// positions at random and rounding them was most of a large block's stencil set-up.
fn direction(off: &[isize; 18], i: usize, j: usize) -> usize {
    let step = j as isize - i as isize;
    off.iter()
        .position(|&o| o == step)
        .expect("a cubic-lattice spring has one of the 18 directions")
}

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
    /// Bulk stiffness (N/m); a spring's is `k w` ([`Factors`]).
    k: Real,
    q: Real,
    /// Bit d set: the spring in direction d exists and is intact; bits [`CLASS_SHIFT`]..: the
    /// node's weight class.
    mask: Vec<u32>,
    /// Spring factors by direction and class (every factor 1 unless cell-weighted).
    factors: Factors<18>,
    /// `1 / S_n`, 0 for a node with no intact spring.
    inv_norm: Vec<Real>,
    /// Largest |offset|: blocks whose neighbours all lie within the arrays run vectorised.
    reach: usize,
    /// The vector path's instructions (`None`: the portable path).
    simd: Option<Lanes>,
    /// Node slots per ring row (`R`, see [`wave`]).
    ring_len: usize,
    /// One ring per part of a wavefront sweep.
    rings: Arc<Vec<Mutex<wave::Ring>>>,
    /// Whether the rows are long enough for the wavefront sweeps (at least 9 nodes), and they
    /// are not switched off ([`CubicStencil::set_wave`]).
    wave_ok: bool,
}

pub(crate) mod wave;

impl CubicStencil {
    /// Heap memory by part (see [`hooke_model::memory::Footprint`]).
    pub fn footprint(&self) -> hooke_model::memory::Footprint {
        use hooke_model::memory::bytes;
        vec![
            (
                "stencil masks and normalisers",
                bytes(&self.mask) + bytes(&self.inv_norm),
            ),
            (
                "stencil wavefront rings",
                self.rings.len() * 9 * (self.ring_len + 8) * std::mem::size_of::<Real>(),
            ),
        ]
    }

    /// Whether the sweeps take the wavefront path (`wave`: AVX-512, rows of at least 9
    /// nodes), which gives the gather sweeps' bits computing each spring once.
    pub fn wave(&self) -> bool {
        self.wave_ok && self.simd == Some(Lanes::Avx512)
    }

    /// Split the wavefront sweeps into `parts` parts (by default one per worker thread of the
    /// pool the stencil was built in); the results do not depend on it.
    pub fn set_parts(&mut self, parts: usize) {
        self.rings = Arc::new(wave::rings(self.reach, parts).0);
    }

    /// Allow (the default) or forbid the wavefront sweeps, e.g. to compare them with the
    /// gather sweeps; they still need AVX-512 and rows of at least 9 nodes.
    pub fn set_wave(&mut self, on: bool) {
        self.wave_ok = on && Self::wave_fits(&self.off);
    }

    /// Whether a box with index offsets `off` can take the wavefront sweeps: rows of at least 9
    /// nodes, and the forward directions those the sweeps take for forward.
    fn wave_fits(off: &[isize; 18]) -> bool {
        off[2] >= 9 && (0..18).all(|d| (off[d] > 0) == wave::is_forward(d))
    }

    /// The stencil for `body` if it is a non-periodic box of the cubic lattice (at least 3 nodes
    /// per axis) with a single stiffness, or one bulk stiffness with factors of at most
    /// `stencil::CLASSES` kinds of node (cell weights); `None` otherwise.
    pub fn new(body: &Body, state: &State) -> Option<Self> {
        let lat = &body.lattice;
        let g = lat.grid?;
        if lat.kind != LatticeKind::Cubic || g.iter().any(|&v| v < 3) || lat.is_periodic() {
            return None;
        }
        // Damaged (softened) springs have stiffnesses of their own: the general kernel runs
        // them.
        // Direction-weighted (anisotropic) materials have levers of their own: also general.
        if state.is_softened() || body.lever.is_some() {
            return None;
        }
        // The bulk stiffness: the largest (cell weights only lower a spring's).
        let k = match body.k.rule() {
            Some(GridStiffness::One(k)) => k,
            // A box at least 3 nodes along each axis has springs in four cubes (a share of 1).
            Some(GridStiffness::Cubes(k, _)) => k,
            None => body.k.par_iter().cloned().reduce(|| 0.0, Real::max),
        };
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
        let (rings, ring_len) = wave::rings(reach, rayon::current_num_threads());
        let mut s = CubicStencil {
            n: lat.len(),
            off,
            dvec,
            rest,
            k,
            q: body.q,
            mask: vec![0; lat.len()],
            factors: Factors {
                w: [[1.0; super::stencil::CLASSES]; 18],
                on: false,
            },
            inv_norm: vec![0.0; lat.len()],
            reach,
            simd: simd_lanes(),
            ring_len,
            rings: Arc::new(rings),
            wave_ok: Self::wave_fits(&off),
        };
        // Each node's mask from its own row (a gather, in parallel: on a large block this is
        // mostly first writes to fresh memory), then its 1/S_n.
        let off = s.off;
        // One stiffness (the common case): every node is of class 0, nothing to classify.
        let rule = body.k.rule();
        let uniform = match rule {
            Some(GridStiffness::One(_)) => true,
            Some(GridStiffness::Cubes(..)) => false,
            None => body.k.par_iter().all(|&v| v == k),
        };
        let class = if uniform {
            Vec::new()
        } else {
            let (class, factors) = match (rule, lat.bonds.grid()) {
                // Cell weights without a list: each link's stiffness from the rule.
                (Some(rule), Some(g)) => {
                    let star = g.star();
                    Factors::classify(lat.len(), k, |i| {
                        let mut f = [None; 18];
                        g.links(&star, i, |j, _| {
                            f[direction(&off, i, j)] = Some(rule.between(i, j));
                        });
                        f
                    })?
                }
                _ => {
                    let bonds = &*lat.bonds;
                    Factors::classify(lat.len(), k, |i| {
                        let mut f = [None; 18];
                        for e in bonds.row(i) {
                            let d = direction(&off, i, bonds.neighbour(i, e));
                            f[d] = Some(body.k[bonds.bond[e] as usize]);
                        }
                        f
                    })?
                }
            };
            s.factors = factors;
            class
        };
        let grid = lat
            .bonds
            .grid()
            .filter(|_| state.alive.par_iter().all(|&a| a));
        let star = grid.map(|g| g.star());
        s.mask
            .par_iter_mut()
            .with_min_len(1 << 12)
            .enumerate()
            .for_each(|(i, m)| {
                *m = class.get(i).map_or(0, |&c| (c as u32) << CLASS_SHIFT);
                match grid {
                    // Every spring intact: the directions that stay in the box, without rows.
                    Some(g) => g.links(star.as_ref().expect("with the grid"), i, |j, _| {
                        *m |= 1 << direction(&off, i, j)
                    }),
                    None => {
                        let bonds = &*lat.bonds;
                        for e in bonds.row(i) {
                            if state.alive[bonds.bond[e] as usize] {
                                *m |= 1 << direction(&off, i, bonds.neighbour(i, e));
                            }
                        }
                    }
                }
            });
        let (mask, k, rest, w) = (&s.mask, s.k, s.rest, &s.factors);
        s.inv_norm
            .par_iter_mut()
            .with_min_len(1 << 12)
            .enumerate()
            .for_each(|(i, v)| *v = inv_norm(mask[i], k, &rest, w));
        Some(s)
    }

    /// Use (or not) the vector path, e.g. to measure the portable one. Ignored where the
    /// processor lacks AVX-512F.
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
        CubicStencil { q, ..self.clone() }
    }

    /// Kernel name for reports.
    pub fn name(&self) -> &'static str {
        match self.simd {
            Some(Lanes::Avx512) => "cubic-stencil-avx512",
            Some(Lanes::Avx2) => "cubic-stencil-avx2",
            None => "cubic-stencil-portable",
        }
    }

    /// Start node and direction of spring `b`.
    fn direction_of(&self, body: &Body, b: usize) -> (usize, usize) {
        let lat = &body.lattice;
        let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
        let d = direction(&self.off, i, j);
        debug_assert_eq!(
            {
                let dx = lat.pos.get(j) - lat.pos.get(i);
                let r = |v: Real| (v / lat.spacing).round() as i32;
                [r(dx.x), r(dx.y), r(dx.z)]
            },
            DIRS[d]
        );
        (i, d)
    }

    fn refresh_norm(&mut self, i: usize) {
        self.inv_norm[i] = inv_norm(self.mask[i], self.k, &self.rest, &self.factors);
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
        let c = (m >> CLASS_SHIFT) as usize;
        let mut pi = 0.0;
        let mut hot = false;
        for d in 0..18 {
            if m & (1 << d) != 0 {
                let (_, _, _, dl) = self.spring(u, i, d);
                pi += self.k * self.rest[d] * dl * self.factors.get(d, c);
                hot |= dl > screen * self.rest[d];
            }
        }
        (pi * self.inv_norm[i], hot)
    }

    fn force_scalar(&self, u: &Coords, pool: &[Real], i: usize) -> [Real; 3] {
        let m = self.mask[i];
        let c = (m >> CLASS_SHIFT) as usize;
        let mut f = [0.0; 3];
        for d in 0..18 {
            if m & (1 << d) != 0 {
                let (j, x, l, dl) = self.spring(u, i, d);
                let t = (self.k * dl + self.q * self.k * self.rest[d] * (pool[i] + pool[j]))
                    * self.factors.get(d, c);
                let s = t / l;
                f[0] += s * x[0];
                f[1] += s * x[1];
                f[2] += s * x[2];
            }
        }
        f
    }
}

impl Stencil for CubicStencil {
    fn nodes(&self) -> usize {
        self.n
    }

    fn q(&self) -> Real {
        self.q
    }

    fn dim(&self) -> usize {
        3
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
/// of 8 as two halves) through [`crate::wide`]: the scalar path's operations lane by lane.
#[cfg(target_arch = "x86_64")]
mod vector {
    use super::{CubicStencil, StepParams, SweepSums, CLASS_SHIFT};
    use crate::stencil::vector::{kick_drift, Lanewise};
    use crate::wide::Wide;
    use hooke_model::math::{Coords, Real};

    /// The N nodes' displacements from `i` and their mask words (one 64-bit lane per node).
    ///
    /// # Safety
    /// The block's nodes from `i` are in bounds of `u` and of the stencil's mask words.
    #[inline(always)]
    pub(super) unsafe fn load_block<W: Wide>(
        w: W,
        s: &CubicStencil,
        u: &Coords,
        i: usize,
    ) -> ([W::F; 3], W::I) {
        // SAFETY: by the caller's contract, i..i+N is in bounds.
        unsafe {
            (
                [
                    w.load(u.x().as_ptr().add(i)),
                    w.load(u.y().as_ptr().add(i)),
                    w.load(u.z().as_ptr().add(i)),
                ],
                w.words32(s.mask.as_ptr().add(i)),
            )
        }
    }

    /// The block's weight classes (one 64-bit lane per node), if one of its nodes has factors
    /// other than 1: then each direction's factors are the classes' entries of that direction's
    /// row of [`super::Factors`] (multiplying by 1 is exact, so the other blocks skip it).
    #[inline(always)]
    pub(super) fn classes<W: Wide>(w: W, s: &CubicStencil, mask: W::I) -> Option<W::I> {
        if !s.factors.on {
            return None;
        }
        w.classes(mask, CLASS_SHIFT)
    }

    /// Current vectors of the springs in direction `d` of the block at `i`, and their squared
    /// lengths.
    ///
    /// # Safety
    /// The block at `i` is inside the body's box, so that its neighbours in direction `d` are
    /// nodes (`vector_block`).
    #[inline(always)]
    pub(super) unsafe fn vector<W: Wide>(
        w: W,
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        d: usize,
        ui: [W::F; 3],
    ) -> ([W::F; 3], W::F) {
        let j = (i as isize + s.off[d]) as usize;
        let dv = s.dvec[d];
        // SAFETY: by the caller's contract, j..j+N is in bounds because the block is inside.
        let (x, y, z) = unsafe {
            (
                w.splat(dv[0]) + (w.load(u.x().as_ptr().add(j)) - ui[0]),
                w.splat(dv[1]) + (w.load(u.y().as_ptr().add(j)) - ui[1]),
                w.splat(dv[2]) + (w.load(u.z().as_ptr().add(j)) - ui[2]),
            )
        };
        // ((x x + y y) + z z), as the scalar path adds them.
        ([x, y, z], (x * x + y * y) + z * z)
    }

    /// `dL = l - L` of the block at `i`'s springs in direction `d`: one square root.
    ///
    /// # Safety
    /// As [`vector`].
    #[inline(always)]
    pub(super) unsafe fn extension<W: Wide>(
        w: W,
        s: &CubicStencil,
        u: &Coords,
        i: usize,
        d: usize,
        ui: [W::F; 3],
    ) -> W::F {
        // SAFETY: by the caller's contract, the block is inside.
        let (_, ss) = unsafe { vector(w, s, u, i, d, ui) };
        w.sqrt(ss) - w.splat(s.rest[d])
    }

    /// The vectors `x` of the block at `i`'s springs in direction `d` and their force factors
    /// `s = T / l`, `T = (k dL + q k L (p_i + p_j)) w` (the force on node i is `s x`).
    ///
    /// # Safety
    /// As [`vector`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn factor<W: Wide>(
        w: W,
        s: &CubicStencil,
        u: &Coords,
        pool: &[Real],
        i: usize,
        d: usize,
        ui: [W::F; 3],
        pi: W::F,
        cls: Option<W::I>,
    ) -> ([W::F; 3], W::F) {
        let j = (i as isize + s.off[d]) as usize;
        // SAFETY: by the caller's contract, the block is inside, so j..j+N is in bounds.
        let ((x, ss), pj) = unsafe { (vector(w, s, u, i, d, ui), w.load(pool.as_ptr().add(j))) };
        let l = w.sqrt(ss);
        let dl = l - w.splat(s.rest[d]);
        let mut t = w.splat(s.k) * dl + w.splat(s.q * s.k * s.rest[d]) * (pi + pj);
        if let Some(c) = cls {
            t = t * w.factors(&s.factors.w[d], c);
        }
        (x, t / l)
    }

    /// Add the terms `s x` of the lanes `m` to the forces `f`.
    #[inline(always)]
    pub(super) fn add_terms<W: Wide>(w: W, f: &mut [W::F; 3], m: W::M, sc: W::F, x: [W::F; 3]) {
        for c in 0..3 {
            f[c] = w.add_where(f[c], m, sc * x[c]);
        }
    }

    /// Add the pool shares `k L dL w` of the lanes `m` to `acc`, and flag those past the screen.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn add_share<W: Wide>(
        w: W,
        s: &CubicStencil,
        d: usize,
        m: W::M,
        dl: W::F,
        cls: Option<W::I>,
        screen: Real,
        acc: &mut W::F,
        hot: &mut W::M,
    ) {
        let mut share = w.splat(s.k * s.rest[d]) * dl;
        if let Some(c) = cls {
            share = share * w.factors(&s.factors.w[d], c);
        }
        *acc = w.add_where(*acc, m, share);
        *hot = *hot | w.gt_where(m, dl, w.splat(screen * s.rest[d]));
    }

    /// The vector path's sweeps, each direction's term unrolled (a tenth off the sweep: the
    /// directions' constants become immediate offsets, and the loop's branches go).
    impl Lanewise for CubicStencil {
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
            let mut acc = w.zero();
            let mut hot = w.no_lanes();
            macro_rules! directions { ($($d:literal)*) => { $( {
                let m = w.bit(mask, $d);
                if w.any(m) {
                    // SAFETY: the block is inside (this fn's contract), so its neighbours in direction d are nodes.
                    let dl = unsafe { extension(w, s, u, i, $d, ui) };
                    add_share(w, s, $d, m, dl, cls, screen, &mut acc, &mut hot);
                }
            } )* } }
            directions!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17);
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
            let mut f = [w.zero(); 3];
            macro_rules! directions { ($($d:literal)*) => { $( {
                let m = w.bit(mask, $d);
                if w.any(m) {
                    // SAFETY: the block is inside (this fn's contract), so its neighbours in direction d are nodes.
                    let (x, sc) = unsafe { factor(w, s, u, pool, i, $d, ui, pi, cls) };
                    add_terms(w, &mut f, m, sc, x);
                }
            } )* } }
            directions!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17);
            // SAFETY: by the caller's contract, the block is in bounds.
            unsafe { kick_drift(w, 3, f, Some(u), inv_mass, p, i, v, un, sums) }
        }
    }
}
