//! # hooke-kernel
//!
//! The explicit step's kernels: the two sweeps of a leapfrog (velocity Verlet) step over a
//! body ([`hooke_model`]), and every `unsafe` block of hooke's physics (the SIMD paths and the
//! disjoint writes of parallel sweeps; each with its SAFETY comment).
//!
//! Sweep 1 ([`Kernel::pools`]): `p_n = Pi_n / S_n` from the displacements `u`.
//! Sweep 2 ([`Kernel::force_kick_drift`]): for each node, its force `f_n` from `u` and the pools,
//! then at once the kick and the drift,
//!
//! ```text
//! v_n <- ((1 - c dt/2) v_n + dt (f_n / m_n + g)) / (1 + c dt/2)      (v at t + dt/2)
//! u'_n = u_n + dt v_n                                                 (u at t + dt)
//! ```
//!
//! written into a second displacement buffer `u'`, so that every other node's force still sees
//! the old `u`. Each node writes only its own entries; sums that span nodes (damping dissipation,
//! body-force work) are formed per fixed chunk of [`CHUNK`] nodes and added in chunk order, so
//! every result is bit-identical for any thread count.
//!
//! [`Kernel::Csr`] works on any lattice through its CSR rows. [`Kernel::Cubic`] and
//! [`Kernel::Hex`] are stencil kernels for box-shaped Ladd and hexagonal lattices: no neighbour
//! indices at all, x/y/z in separate arrays, AVX-512 where the processor has it.

//!
//! Modules: [`csr`] (any lattice, through its CSR rows), [`rows`] (the row kernel: slot-major
//! groups of 8 nodes, AVX-512 or AVX2), [`cubic`] and [`hex`] (stencils of box-shaped Ladd and
//! hexagonal lattices), `stencil` (what the stencils share), `wide` (the lane widths, AVX-512
//! and AVX2, that the vector paths are written over once), [`share`] (the part of a body one
//! process's sweeps cover when several share a run).

// Checks are written `!(x > 0.0)` on purpose: a NaN fails them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod csr;
pub mod cubic;
pub mod hex;
pub mod rows;
pub mod share;
mod stencil;
#[cfg(target_arch = "x86_64")]
mod wide;

use std::ops::Range;

use hooke_model::body::Body;
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// Nodes per parallel task and per partial sum ([`hooke_lattice::CHUNK`]).
pub use hooke_lattice::CHUNK;

/// Springs per block of the CSR kernel's sweep 1 (a share's springs are whole blocks): a block's geometry is gathered first (scalar: the ends are
/// arbitrary nodes), then its square roots and divisions run as one loop over contiguous
/// arrays, which the compiler turns into vector instructions (two or four springs at once).
/// Those two operations are most of a spring's cost, and they are not pipelined: one spring
/// at a time they would wait on each other.
pub(crate) const BLOCK: usize = 32;

/// Length of the scratch that [`Kernel::force_kick_drift`] needs for `n` nodes (one partial sum
/// per chunk; the caller owns it, so that a step allocates nothing).
pub fn partials_len(n: usize) -> usize {
    n.div_ceil(CHUNK)
}

/// The node chunks that hold the nodes `nodes`: a share of whole chunks (the body's last chunk
/// may be short), or an empty share, which holds none wherever it starts.
///
/// An empty share that comes after the body's last, short chunk starts at `n`, which is no
/// chunk boundary: `n / CHUNK..n.div_ceil(CHUNK)` would be that last chunk, so a rank owning
/// nothing swept another rank's nodes and gave overlapping parts to the all-gathers (a row
/// kernel holding no rows then read records below its own, issue "A failed rank never hangs a
/// job"). Every chunk range of a share is taken here.
pub fn chunks_of(nodes: &Range<usize>) -> Range<usize> {
    if nodes.is_empty() {
        let c = nodes.start.div_ceil(CHUNK);
        c..c
    } else {
        nodes.start / CHUNK..nodes.end.div_ceil(CHUNK)
    }
}

/// Constants of one step.
#[derive(Clone, Copy, Debug)]
pub struct StepParams {
    /// Time step (s).
    pub dt: Real,
    /// Mass-proportional damping coefficient c (1/s): damping force `-c m v`.
    pub damping: Real,
    /// Body acceleration g (m/s^2).
    pub accel: [Real; 3],
    /// The body is a plate whose z components stay exact zeros (nothing acts along z: see
    /// `hooke_core::dynamics::Integrator`): sweep 2 then neither reads nor writes the z components
    /// of v and u', which would only ever hold the zeros they hold. A third less memory
    /// traffic; the same bits (the z lanes of a plate compute +0 from +0). Ignored in 3D.
    pub plane: bool,
}

impl StepParams {
    /// Components sweep 2 updates for a body of dimension `dim`.
    #[inline(always)]
    pub fn dims(&self, dim: usize) -> usize {
        if dim == 2 && self.plane {
            2
        } else {
            3
        }
    }
}

/// Sums over all nodes gathered during sweep 2 (two reals, in this order: ranks exchange them
/// as such).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct SweepSums {
    /// Energy removed by damping over the step: `sum c m |v_mid|^2 dt` with `v_mid` the mean of
    /// the half-step velocities before and after (J).
    pub dissipated: Real,
    /// Work of the body force over the step, `sum m g . v_mid dt` (J): the midpoint form that
    /// matches leapfrog's discrete energy identity.
    pub body_work: Real,
}

impl SweepSums {
    /// The sums as the flat reals the ranks exchange (two per entry, in field order).
    pub fn as_flat_mut(sums: &mut [SweepSums]) -> &mut [Real] {
        // SAFETY: `SweepSums` is `repr(C)` with two `Real` fields and no padding, so `sums` is
        // `2 sums.len()` initialised reals; the view borrows `sums` mutably for its lifetime.
        unsafe { std::slice::from_raw_parts_mut(sums.as_mut_ptr() as *mut Real, 2 * sums.len()) }
    }
}

impl std::ops::AddAssign for SweepSums {
    fn add_assign(&mut self, o: SweepSums) {
        self.dissipated += o.dissipated;
        self.body_work += o.body_work;
    }
}

/// The force kernel a run uses.
// One per integrator, read at every sweep: the stencil's tables inline (under a kilobyte)
// rather than behind a pointer.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Kernel {
    /// Any lattice: gathers over CSR rows. `plain` drops the dispersion (q = 0), for the
    /// damage-proof stable step.
    Csr { plain: bool },
    /// Box-shaped Ladd lattice with uniform spring constants: stencil kernel.
    Cubic(cubic::CubicStencil),
    /// Box-shaped hexagonal lattice with uniform spring constants: stencil kernel.
    Hex(hex::HexStencil),
    /// Any other non-periodic lattice on a processor with AVX-512: the CSR kernel's sweeps
    /// node by node, 8 nodes to a vector, with the CSR kernel's bits (see [`rows`]).
    Rows(rows::RowKernel),
}

impl Kernel {
    /// The fastest kernel that can run `body`: a stencil for a box-shaped Ladd or hexagonal
    /// lattice with one stiffness, CSR otherwise.
    pub fn for_body(body: &Body, state: &State) -> Kernel {
        Self::for_body_in(body, state, None)
    }

    /// [`Kernel::for_body`] for a rank that sweeps only the nodes `own` (whole chunks; `None`:
    /// every node): a row kernel then holds only their rows ([`Kernel::keep_rows`]).
    pub fn for_body_in(body: &Body, state: &State, own: Option<std::ops::Range<usize>>) -> Kernel {
        // A stencil keeps one normaliser rule for the whole box; a body of several materials
        // (its normalisers `S_n / q_n`, `Body::q_node`) takes the row or CSR kernel, which read
        // the state's.
        if body.q_node.is_none() {
            if let Some(s) = cubic::CubicStencil::new(body, state) {
                return Kernel::Cubic(s);
            }
            if let Some(s) = hex::HexStencil::new(body, state) {
                return Kernel::Hex(s);
            }
        }
        // Without vector instructions (AVX-512 or AVX2) the row kernel's scalar path would be
        // slower than the CSR kernel, which gives the same bits.
        let rows = match own {
            Some(own) => rows::RowKernel::new_for(body, state, own),
            None => rows::RowKernel::new(body, state),
        };
        match rows.filter(|r| r.simd()) {
            Some(r) => Kernel::Rows(r),
            None => Kernel::Csr { plain: false },
        }
    }

    /// Whether [`Kernel::for_body`] could ever give the CSR kernel to bodies of a lattice with
    /// periods `period` (0: not periodic): on a periodic lattice, or where the vector paths are
    /// unavailable (neither AVX-512 nor AVX2, or [`Simd::Portable`]), since a stencil body that softens moves to
    /// a general kernel. Only then is the rows' neighbour array built
    /// ([`hooke_model::lattice::Bonds::keep_neighbours`]; the CSR kernel also runs without it, with
    /// one more indirection per row entry).
    pub fn csr_may_run(period: [Real; 3]) -> bool {
        hooke_model::lattice::csr_may_run(period)
    }

    /// The kernel's heap memory by part (see [`hooke_model::memory::Footprint`]).
    pub fn footprint(&self) -> hooke_model::memory::Footprint {
        match self {
            Kernel::Csr { .. } => Vec::new(),
            Kernel::Cubic(s) => s.footprint(),
            Kernel::Hex(s) => s.footprint(),
            Kernel::Rows(r) => r.footprint(),
        }
    }

    /// Name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Kernel::Csr { .. } => "csr",
            Kernel::Cubic(s) => s.name(),
            Kernel::Hex(s) => s.name(),
            Kernel::Rows(r) => r.name(),
        }
    }

    /// Whether a stencil kernel uses its vector path (false for the CSR kernel, whose vector
    /// loops are chosen per process).
    pub fn simd(&self) -> bool {
        match self {
            Kernel::Csr { .. } => false,
            Kernel::Cubic(s) => s.simd(),
            Kernel::Hex(s) => s.simd(),
            Kernel::Rows(r) => r.simd(),
        }
    }

    /// Switch a stencil kernel's vector path on or off (e.g. to measure the portable one);
    /// nothing for the CSR kernel.
    pub fn set_simd(&mut self, on: bool) {
        match self {
            Kernel::Csr { .. } => {}
            Kernel::Cubic(s) => s.set_simd(on),
            Kernel::Hex(s) => s.set_simd(on),
            Kernel::Rows(r) => r.set_simd(on),
        }
    }

    /// Take the AVX2 vector path where the processor has it, even if it has AVX-512 too (to
    /// test and measure that path on such a machine); false (nothing changed) for the CSR
    /// kernel or without AVX2.
    pub fn use_avx2(&mut self) -> bool {
        match self {
            Kernel::Csr { .. } => false,
            Kernel::Cubic(s) => s.use_avx2(),
            Kernel::Hex(s) => s.use_avx2(),
            Kernel::Rows(r) => r.use_avx2(),
        }
    }

    /// Whether this is one of the stencil kernels.
    pub fn is_stencil(&self) -> bool {
        matches!(self, Kernel::Cubic(_) | Kernel::Hex(_))
    }

    /// Whether the kernel keeps its own copy of the springs' states (the stencils' masks, the
    /// row kernel's slots), which a change behind the integrator's back makes stale.
    pub fn holds_springs(&self) -> bool {
        !matches!(self, Kernel::Csr { .. })
    }

    /// Sweep 1: `state.pool` from `state.u` (and the CSR kernel's per-spring scratch, which
    /// sweep 2 reads: call it before every [`Kernel::force_kick_drift`]).
    pub fn pools(&self, body: &Body, state: &mut State) {
        self.pools_screened(body, state, Real::INFINITY);
    }

    /// Sweep 1 with the break screen: besides the pools, flag the blocks of springs (CSR) or
    /// nodes (stencil) where an intact spring has `dL > screen L`. The test costs a compare per
    /// spring inside the sweep, which has `dL` at hand; [`Kernel::hot_springs`] then lists the
    /// springs a stretch-type criterion has to look at, instead of a separate pass over all of
    /// them. Infinity: no screen.
    pub fn pools_screened(&self, body: &Body, state: &mut State, screen: Real) {
        self.pools_shared(body, state, screen, None);
    }

    /// Sweep 1 of one rank's share of a distributed run (`hooke_core::team`): the pools of its
    /// nodes (and the CSR records of its springs); every other screen flag cleared. `None`:
    /// the whole body.
    pub fn pools_shared(
        &self,
        body: &Body,
        state: &mut State,
        screen: Real,
        share: Option<&crate::share::Share>,
    ) {
        match self {
            Kernel::Csr { plain } => csr::pools(body, state, *plain, screen, share),
            Kernel::Cubic(s) if s.wave() => {
                cubic::wave::pools(s, state, screen, self.chunks_for(share))
            }
            Kernel::Cubic(s) => stencil::pools(s, state, screen, self.chunks_for(share)),
            Kernel::Hex(s) => stencil::pools(s, state, screen, self.chunks_for(share)),
            Kernel::Rows(r) => {
                rows::refresh_displacements(r, body, state, share);
                stencil::pools(r, state, screen, self.chunks_for(share))
            }
        }
    }

    /// The springs of the blocks the last [`Kernel::pools_screened`] flagged, ascending and
    /// each once (a superset of the springs past the screen; broken ones included), into `out`
    /// (cleared first; it keeps its capacity, so steady state allocates nothing).
    pub fn hot_springs(&self, body: &Body, state: &State, out: &mut Vec<u32>) {
        out.clear();
        match self {
            Kernel::Csr { .. } => csr::hot_springs(state, body.springs(), out),
            Kernel::Cubic(_) | Kernel::Hex(_) | Kernel::Rows(_) => {
                let bonds = &*body.lattice.bonds;
                let n = body.nodes();
                for (blk, _) in state.hot.iter().enumerate().filter(|(_, &h)| h) {
                    for i in blk * stencil::SCREEN..((blk + 1) * stencil::SCREEN).min(n) {
                        out.extend(bonds.row(i).map(|e| bonds.bond[e]));
                    }
                }
                out.sort_unstable();
                out.dedup();
            }
        }
    }

    /// Keep what only the sweeps of the nodes `own` read (one rank's share of a distributed
    /// run): the row kernel drops the other ranks' rows ([`rows::RowKernel::keep_rows`]); the
    /// stencils and the CSR kernel hold no per-row data to drop.
    pub fn keep_rows(&mut self, own: std::ops::Range<usize>) {
        if let Kernel::Rows(r) = self {
            r.keep_rows(own);
        }
    }

    /// Make sweep 1's results (pools, CSR records) those of a sweep with the springs `killed`
    /// already broken (after they broke between the sweeps, the kernel's masks updated).
    pub fn repair(&self, body: &Body, state: &mut State, killed: &[u32]) {
        self.repair_shared(body, state, killed, None);
    }

    /// [`Kernel::repair`] on one rank's share (`None`: the whole body): the pools of the
    /// changed springs' ends that this rank owns are right afterwards; the others are left
    /// to their owners (a stencil kernel recomputes none of them, the CSR kernel from what
    /// this rank holds).
    pub fn repair_shared(
        &self,
        body: &Body,
        state: &mut State,
        killed: &[u32],
        share: Option<&crate::share::Share>,
    ) {
        if killed.is_empty() {
            return;
        }
        let chunks = self
            .chunks_for(share)
            .unwrap_or(0..body.nodes().div_ceil(CHUNK));
        match self {
            Kernel::Csr { plain } => csr::repair(body, state, *plain, killed),
            Kernel::Cubic(s) => stencil::repair(s, body, state, killed, chunks),
            Kernel::Hex(s) => stencil::repair(s, body, state, killed, chunks),
            Kernel::Rows(r) => stencil::repair(r, body, state, killed, chunks),
        }
    }

    /// Sweep 2: force, kick and drift; writes `u_next`, updates `state.v` in place.
    pub fn force_kick_drift(
        &self,
        body: &Body,
        state: &mut State,
        inv_mass: &[Real],
        p: &StepParams,
        u_next: &mut Coords,
        partials: &mut [SweepSums],
    ) -> SweepSums {
        self.force_kick_drift_shared(body, state, inv_mass, p, Some(u_next), partials, None)
    }

    /// Sweep 2 over one rank's share of a distributed run (`hooke_core::team`; `None`: the whole
    /// body): its nodes' velocities, next displacements and partial sums; returns the sum of
    /// those partials. The next displacements go into `u_next`, or with `None` into
    /// `state.u` in place, which only a kernel that [`Kernel::drifts_in_place`] allows.
    #[allow(clippy::too_many_arguments)]
    pub fn force_kick_drift_shared(
        &self,
        body: &Body,
        state: &mut State,
        inv_mass: &[Real],
        p: &StepParams,
        u_next: Option<&mut Coords>,
        partials: &mut [SweepSums],
        share: Option<&crate::share::Share>,
    ) -> SweepSums {
        let chunks = self
            .chunks_for(share)
            .unwrap_or(0..body.nodes().div_ceil(CHUNK));
        const OUT: &str = "a kernel that reads displacements from state.u drifts out of place";
        match self {
            Kernel::Csr { .. } => {
                let u_next = u_next.expect(OUT);
                csr::force_kick_drift(body, state, inv_mass, p, u_next, partials, chunks)
            }
            Kernel::Cubic(s) if s.wave() => {
                let u_next = u_next.expect(OUT);
                cubic::wave::force_kick_drift(s, state, inv_mass, p, u_next, partials, chunks)
            }
            Kernel::Cubic(s) => {
                assert!(u_next.is_some(), "{OUT}");
                stencil::force_kick_drift(s, state, inv_mass, p, u_next, partials, chunks)
            }
            Kernel::Hex(s) => {
                assert!(u_next.is_some(), "{OUT}");
                stencil::force_kick_drift(s, state, inv_mass, p, u_next, partials, chunks)
            }
            Kernel::Rows(r) => {
                rows::refresh_pools(r, state, share);
                stencil::force_kick_drift(r, state, inv_mass, p, u_next, partials, chunks)
            }
        }
    }

    /// The node chunks a sweep covers: a rank's share, or for a row kernel that holds one
    /// share's rows those chunks even when called without the share (it may sweep no other);
    /// `None`: every chunk.
    fn chunks_for(&self, share: Option<&crate::share::Share>) -> Option<std::ops::Range<usize>> {
        share.map(|s| s.chunks()).or_else(|| match self {
            Kernel::Rows(r) => r.own_chunks(),
            _ => None,
        })
    }

    /// Whether sweep 2 may write the new displacements over `state.u` (the row kernel: its
    /// force sweep reads the displacements from its records, refreshed by sweep 1), so that
    /// the integrator keeps no second displacement array.
    pub fn drifts_in_place(&self) -> bool {
        matches!(self, Kernel::Rows(_))
    }

    /// The same kernel for the plain law (q = 0): what the damage-proof stable step is
    /// estimated with.
    pub fn plain(&self) -> Kernel {
        match self {
            Kernel::Csr { .. } => Kernel::Csr { plain: true },
            Kernel::Cubic(s) => Kernel::Cubic(s.with_q(0.0)),
            Kernel::Hex(s) => Kernel::Hex(s.with_q(0.0)),
            Kernel::Rows(r) => Kernel::Rows(r.with_q(0.0)),
        }
    }

    /// Keep the kernel's own copy of the spring states in step after `state.kill_bond(b)`.
    pub fn bond_killed(&mut self, body: &Body, b: usize) {
        match self {
            Kernel::Csr { .. } => {}
            Kernel::Cubic(s) => s.bond_killed(body, b),
            Kernel::Hex(s) => s.bond_killed(body, b),
            Kernel::Rows(r) => r.bond_killed(body, b),
        }
    }

    /// Keep the kernel's own copy of the spring stiffnesses in step after `state.soften(b, ..)`
    /// (the row kernel; the stencils cannot hold softened springs and are replaced instead).
    pub fn bond_softened(&mut self, body: &Body, state: &State, b: usize) {
        if let Kernel::Rows(r) = self {
            r.bond_softened(body, state, b);
        }
    }
}

pub(crate) use hooke_sys::simd::simd_allowed;
pub use hooke_sys::simd::{set_simd, simd, Simd};

/// A mutable slice shared by parallel tasks that each write a disjoint range of it.
#[derive(Clone, Copy)]
pub(crate) struct Disjoint<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: tasks only obtain disjoint ranges through `range`, whose contract requires it.
unsafe impl<T: Send> Send for Disjoint<T> {}
// SAFETY: as for Send: shared between tasks, it hands each one only its own disjoint range.
unsafe impl<T: Send> Sync for Disjoint<T> {}

impl<T> Disjoint<T> {
    pub(crate) fn new(s: &mut [T]) -> Self {
        Disjoint {
            ptr: s.as_mut_ptr(),
            len: s.len(),
        }
    }

    /// # Safety
    /// No two live results of `range` may overlap, and the source slice must outlive them.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn range(&self, r: std::ops::Range<usize>) -> &mut [T] {
        assert!(r.start <= r.end && r.end <= self.len);
        // SAFETY: in bounds (checked above); disjointness is the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(r.start), r.end - r.start) }
    }
}

/// The outputs of sweep 2 for the nodes of one chunk: their velocities (updated in place) and
/// next displacements, each as x, y, z slices indexed from the chunk's first node.
pub(crate) struct ChunkOut<'a> {
    pub v: [&'a mut [Real]; 3],
    pub u_next: [&'a mut [Real]; 3],
}

impl<'a> ChunkOut<'a> {
    /// The entries of nodes `r` of the shared outputs `v` and `u_next`.
    ///
    /// # Safety
    /// As [`Disjoint::range`]: no two live results may overlap.
    unsafe fn of(
        v: &'a [Disjoint<Real>; 3],
        u_next: &'a [Disjoint<Real>; 3],
        r: Range<usize>,
    ) -> Self {
        // SAFETY: the caller's contract.
        unsafe {
            ChunkOut {
                v: v.each_ref().map(|d| d.range(r.clone())),
                u_next: u_next.each_ref().map(|d| d.range(r.clone())),
            }
        }
    }

    /// The velocities and next displacements of the chunk's nodes `r` (counted from its first).
    pub(crate) fn block(&mut self, r: Range<usize>) -> ([&mut [Real]; 3], [&mut [Real]; 3]) {
        let [vx, vy, vz] = &mut self.v;
        let [nx, ny, nz] = &mut self.u_next;
        (
            [&mut vx[r.clone()], &mut vy[r.clone()], &mut vz[r.clone()]],
            [&mut nx[r.clone()], &mut ny[r.clone()], &mut nz[r]],
        )
    }

    /// [`kick_drift`] of the chunk's node `k` (inverse mass `inv_m`, force `f`, displacements
    /// `u_old` before the step), its shares added to `sums`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn kick_drift(
        &mut self,
        k: usize,
        dims: usize,
        f: [Real; 3],
        inv_m: Real,
        p: &StepParams,
        u_old: [Real; 3],
        sums: &mut SweepSums,
    ) {
        let [vx, vy, vz] = &mut self.v;
        let [nx, ny, nz] = &mut self.u_next;
        let (d, w) = kick_drift(
            dims,
            f,
            inv_m,
            p,
            [&mut vx[k], &mut vy[k], &mut vz[k]],
            u_old,
            [&mut nx[k], &mut ny[k], &mut nz[k]],
        );
        sums.dissipated += d;
        sums.body_work += w;
    }
}

/// The sum of the chunks' partial sums, in chunk order.
fn in_chunk_order(partials: &[SweepSums]) -> SweepSums {
    let mut total = SweepSums::default();
    for &s in partials {
        total += s;
    }
    total
}

/// Run sweep 2 over the fixed chunks `chunks` of `n` nodes in parallel: `chunk(range, out)`
/// handles the nodes of one chunk and returns their sums, which are stored per chunk in
/// `partials` (one entry per chunk, owned by the caller so that nothing is allocated) and
/// added in chunk order into the total.
pub(crate) fn sweep_chunks<F>(
    n: usize,
    chunks: Range<usize>,
    v: &mut Coords,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    chunk: F,
) -> SweepSums
where
    F: Fn(Range<usize>, ChunkOut<'_>) -> SweepSums + Sync,
{
    use rayon::prelude::*;
    let chunks = chunks.start..chunks.end.min(n.div_ceil(CHUNK));
    let vs = v.xyz_mut().map(Disjoint::new);
    let us = u_next.xyz_mut().map(Disjoint::new);
    let first = chunks.start;
    partials[chunks.clone()]
        .par_iter_mut()
        .enumerate()
        .for_each(|(c, out)| {
            let c = first + c;
            let r = c * CHUNK..((c + 1) * CHUNK).min(n);
            // SAFETY: chunk ranges are disjoint, each task takes only its own, and the slices do
            // not outlive this call, during which `v` and `u_next` are borrowed mutably.
            let o = unsafe { ChunkOut::of(&vs, &us, r.clone()) };
            *out = chunk(r, o);
        });
    in_chunk_order(&partials[chunks])
}

/// [`sweep_chunks`] for a sweep that carries scratch from one chunk to the next (the cubic
/// stencil's wavefront rings): the chunks are split into at most `parts.len()` contiguous
/// parts, each run in chunk order by one task holding its part's scratch (locked for the whole
/// part; `chunk` is told which chunk is a part's first). The partial sums are still formed per
/// chunk and added in chunk order, so the split changes no bit.
pub(crate) fn sweep_parts<T: Send, F>(
    n: usize,
    chunks: Range<usize>,
    parts: &[std::sync::Mutex<T>],
    v: &mut Coords,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    chunk: F,
) -> SweepSums
where
    F: Fn(&mut T, bool, Range<usize>, ChunkOut<'_>) -> SweepSums + Sync,
{
    use rayon::prelude::*;
    let chunks = chunks.start..chunks.end.min(n.div_ceil(CHUNK));
    if !chunks.is_empty() {
        let vs = v.xyz_mut().map(Disjoint::new);
        let us = u_next.xyz_mut().map(Disjoint::new);
        let per = chunks.len().div_ceil(parts.len().clamp(1, chunks.len()));
        let first = chunks.start;
        partials[chunks.clone()]
            .par_chunks_mut(per)
            .zip(parts)
            .enumerate()
            .for_each(|(k, (outs, part))| {
                let mut part = part.lock().unwrap_or_else(|e| e.into_inner());
                for (c, out) in outs.iter_mut().enumerate() {
                    let c = first + k * per + c;
                    let r = c * CHUNK..((c + 1) * CHUNK).min(n);
                    // SAFETY: as in `sweep_chunks`; each part takes only its own chunks.
                    let o = unsafe { ChunkOut::of(&vs, &us, r.clone()) };
                    *out = chunk(&mut part, c == first + k * per, r, o);
                }
            });
    }
    in_chunk_order(&partials[chunks])
}

/// The kick-drift of one node's first `dims` components (every kernel shares it, so they
/// integrate identically). Returns the node's contributions to [`SweepSums`].
#[inline(always)]
pub(crate) fn kick_drift(
    dims: usize,
    f: [Real; 3],
    inv_m: Real,
    p: &StepParams,
    v: [&mut Real; 3],
    u: [Real; 3],
    u_next: [&mut Real; 3],
) -> (Real, Real) {
    let h = 0.5 * p.damping * p.dt;
    let (shrink, grow) = (1.0 - h, 1.0 / (1.0 + h));
    let m = if inv_m > 0.0 { 1.0 / inv_m } else { 0.0 };
    let mut v2 = 0.0;
    let mut gw = 0.0;
    let [vx, vy, vz] = v;
    let [ux, uy, uz] = u_next;
    for (c, (vc, unc)) in [(vx, ux), (vy, uy), (vz, uz)]
        .into_iter()
        .enumerate()
        .take(dims)
    {
        let old = *vc;
        let new = (shrink * old + p.dt * (f[c] * inv_m + p.accel[c])) * grow;
        *vc = new;
        *unc = u[c] + p.dt * new;
        let mid = 0.5 * (old + new);
        v2 += mid * mid;
        gw += p.accel[c] * mid;
    }
    (p.damping * m * v2 * p.dt, m * gw * p.dt)
}
