//! The stable time step of the explicit integrator.
//!
//! Velocity Verlet (leapfrog) is stable for `dt < 2 / sqrt(lambda_max)`, `lambda_max` the
//! largest eigenvalue of `M^-1 K`. We estimate it with a Lanczos iteration on the symmetric
//! `M^-1/2 K M^-1/2`. The product `K v` is the forward difference of the run's own force kernel,
//! `K v = -(f(u + eps v) - f(u)) / eps` with `eps |v|_max = 1e-7 a`, `f(u)` evaluated once. Its
//! error is the force's curvature times `eps`, about 1e-7 relative (a spring's force is smooth on
//! the scale of its length `a`), and its rounding about 1e-9 (the force's rounding, 1e-16 k a,
//! over `eps`): far below the 1e-3 to which the iteration converges. A central difference would
//! cancel the curvature term but costs two sweeps per iteration where this costs one (the
//! estimate is the largest part of a large body's set-up). It sees the body's current state
//! (geometric stiffness, broken springs) and cannot disagree with the forces actually
//! integrated. The largest Ritz value converges from
//! below: on small bodies to 1e-6 of a dense eigensolver; on large ones the top of the spectrum
//! is nearly continuous and the estimate after the 40 iterations we allow is about 0.5 % low
//! (10^6 nodes, plain lattice), which the safety factor covers. For the plain Ladd lattice
//! `lambda_max = 12 k/m` (MODEL.md).
//!
//! **Damage-proof step.** Removing springs only lowers the plain quadratic form
//! `sum_s k_s delta_s^2`, and Cauchy-Schwarz bounds the dispersive part by `2 max(q, 0)` times it,
//! so for every pattern of broken springs `lambda_max <= (1 + 2 max(q, 0)) lambda_plain`, with
//! `lambda_plain` the largest eigenvalue of the plain law on the current body (MODEL.md gives
//! `12 (1 + 2q) k/m` for the Ladd lattice). [`crate::dynamics::IntegratorOptions::damage_proof`]
//! uses it, estimating `lambda_plain` with the same Lanczos iteration on the kernel's plain copy.
//!
//! **Shared by a team.** Processes that share a run ([`crate::team`]) share the estimate as
//! they share a step ([`Split`]): each evaluates the forces of its own nodes and forms the
//! vector passes there, the ghosts' displacements and pools are traded between the sweeps, and
//! the per-chunk partial sums of `alpha`, `beta^2` (and the maxima behind the difference step)
//! are all-gathered and added in chunk order: the same `lambda_max`, bit for bit, as one
//! process finds.
//!
//! We also give a cruder bound that needs no iteration: with `delta_s` the extension rate
//! of spring s, Cauchy-Schwarz gives `(sum_t k_t L_t delta_t)^2 <= S_n sum_t k_t delta_t^2`, so
//! the material stiffness satisfies `v.K.v <= (1 + 2 max(q, 0)) sum_s k_s delta_s^2
//! <= (1 + 2 max(q,0)) sum_n 2 (sum_t k_t) |v_n|^2`, hence
//! `lambda_max <= (1 + 2 max(q,0)) max_n 2 sum_t k_t / m_n`. It is loose (36 k/m against the
//! true 12 k/m for the intact Ladd lattice) and serves as a check.

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::body::Body;
use crate::kernel::{Kernel, StepParams, CHUNK};
use crate::math::{Coords, Real};
use crate::state::State;
use crate::team::{Share, Team};

/// Nodes per parallel task of the estimate's element-wise passes.
const BLOCK: usize = 1 << 14;

/// Default safety factor on the critical step.
///
/// 0.8: the Lanczos estimate is accurate to far better than 1 %, so the margin is for what
/// changes during a run: the geometric stiffness of tensioned springs and the stiffening of
/// nodes at new free surfaces when springs break with q > 0 (MODEL.md). It also keeps the
/// highest mode's energy oscillation, of relative size (omega dt)^2/8, below 0.32.
pub const DEFAULT_SAFETY: Real = 0.8;

/// The result of the stable-step estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StableStep {
    /// Estimate of lambda_max(M^-1 K) (1/s^2).
    pub lambda_max: Real,
    /// `2 / sqrt(lambda_max)` (s).
    pub dt_critical: Real,
    /// The damage-proof upper bound on lambda_max (1/s^2).
    pub lambda_bound: Real,
}

/// Estimate the stable step of `body` in `state` with the force kernel of the run: at most
/// `iterations` Lanczos steps, stopping once the estimate changes by less than `tolerance`
/// (relative) from one step to the next. Works on a copy of `state`; see [`estimate_in`] for
/// the same estimate without the copy.
pub fn estimate(
    body: &Body,
    state: &State,
    kernel: &Kernel,
    iterations: usize,
    tolerance: Real,
) -> StableStep {
    estimate_in(body, &mut state.clone(), kernel, iterations, tolerance)
}

/// [`estimate`], with the force evaluations run in `state` itself (a copy of a large body's
/// state was a third of its peak memory at set-up): its displacements and velocities are given
/// back exactly, while its pools, forces and kernel scratch are left as the last evaluation made
/// them, for the caller to recompute.
pub fn estimate_in(
    body: &Body,
    state: &mut State,
    kernel: &Kernel,
    iterations: usize,
    tolerance: Real,
) -> StableStep {
    let mut u_next = drift_scratch(body, kernel);
    let mut ones = Vec::new();
    estimate_using(
        body,
        state,
        kernel,
        iterations,
        tolerance,
        &mut u_next,
        &mut ones,
        None,
    )
}

/// One rank's part of an estimate shared by a team ([`crate::team`]): the force sweeps and
/// the vector passes run on the rank's own nodes, the ghosts' displacements and pools are
/// traded as in a step, and the per-chunk partial sums (and the maxima) are all-gathered and
/// added in chunk order, so that every rank gets the estimate of one process, bit for bit.
pub struct Split<'a> {
    team: &'a dyn Team,
    share: &'a Share,
    out: Vec<Vec<Real>>,
    inp: Vec<Vec<Real>>,
    /// On a piece ([`Split::for_piece`]): where its chunks and nodes sit in the body.
    piece: Option<PieceMap<'a>>,
}

/// Where a piece's chunks and nodes sit in the body, for an estimate on the piece.
struct PieceMap<'a> {
    /// Every rank's chunks of the body (the all-gather's parts).
    parts: Vec<std::ops::Range<usize>>,
    /// The piece's first own chunk and the body's chunk it is.
    local: usize,
    global: usize,
    /// The body's index of each of the piece's nodes (`team::PAD` for its dummies).
    nodes: &'a [u32],
    /// Nodes of the body.
    total: usize,
    /// Every chunk's partial sum, in the body's chunks.
    sums: Vec<Real>,
}

impl<'a> Split<'a> {
    /// Rank `share.rank` of `team`, which every rank calls with the same body.
    pub fn new(team: &'a dyn Team, share: &'a Share) -> Self {
        let size = team.size();
        Split {
            team,
            share,
            out: vec![Vec::new(); size],
            inp: vec![Vec::new(); size],
            piece: None,
        }
    }

    /// Rank `team.rank()`'s part of an estimate on its piece ([`crate::team::Piece`]):
    /// `sweeps` is the piece's own share (its own nodes as one rank's, in the piece's
    /// numbering) carrying the piece's halo, `body_share` the ranks' nodes in the body, and
    /// `global` the body's index of each of the piece's nodes. The same estimate, bit for bit,
    /// as one process finds.
    pub fn for_piece(
        team: &'a dyn Team,
        sweeps: &'a Share,
        body_share: &Share,
        global: &'a [u32],
        first: usize,
        total: usize,
    ) -> Self {
        let mut split = Split::new(team, sweeps);
        split.piece = Some(PieceMap {
            parts: body_share.chunk_parts(1),
            local: sweeps.mine().start / CHUNK,
            global: first / CHUNK,
            nodes: global,
            total,
            sums: vec![0.0; total.div_ceil(CHUNK)],
        });
        split
    }

    fn trade(&mut self, fields: &mut [&mut [Real]]) {
        crate::team::trade_halo(
            self.team,
            &self.share.halo,
            &mut self.out,
            &mut self.inp,
            fields,
        );
    }

    /// Every rank's per-chunk partials (`partial`, one per chunk, valid on this rank's chunks)
    /// gathered, then added in chunk order.
    fn sum(&mut self, partial: &mut [Real]) -> Real {
        if let Some(p) = &mut self.piece {
            // The piece's own chunks are the body's chunks from `p.global` on.
            for c in self.share.chunks() {
                p.sums[c - p.local + p.global] = partial[c];
            }
            self.team.gather(&mut p.sums, &p.parts);
            return in_order(&p.sums);
        }
        self.team.gather(partial, &self.share.chunk_parts(1));
        in_order(partial)
    }

    /// The largest of every rank's `x`.
    fn max(&self, x: Real) -> Real {
        let size = self.team.size();
        let mut all = vec![0.0; size];
        all[self.team.rank()] = x;
        let parts: Vec<_> = (0..size).map(|r| r..r + 1).collect();
        self.team.gather(&mut all, &parts);
        all.into_iter().fold(0.0, Real::max)
    }
}

/// The drift's scratch for an estimate with `kernel`: none for a kernel that drifts in place
/// ([`Kernel::drifts_in_place`]), whose drifted displacements land in the state's, which each
/// evaluation forms afresh and the estimate gives back; otherwise an array as long as the body.
pub(crate) fn drift_scratch(body: &Body, kernel: &Kernel) -> Coords {
    if kernel.drifts_in_place() {
        Coords::default()
    } else {
        Coords::zeros(body.nodes())
    }
}

/// The nodes and node chunks a pass of the estimate covers: a rank's own, or all.
fn own(split: &Option<&mut Split>, n: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
    match split {
        Some(s) => (s.share.mine(), s.share.chunks()),
        None => (0..n, 0..n.div_ceil(CHUNK)),
    }
}

/// Lanczos's start vector, of unit norm: a deterministic, non-special hash of the body's node
/// index, so that dt is reproducible; on a piece, its own and ghost nodes' entries of the whole
/// body's vector.
fn start_vector(n: usize, dims: usize, on_piece: Option<&PieceMap>) -> Coords {
    let start = |i: usize, c: usize| {
        let h = (i as u64 * 3 + c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
        (h as Real / (1u64 << 53) as Real) - 0.5
    };
    let mut q = Coords::zeros(n);
    for c in 0..dims {
        q.comp_mut(c)
            .par_iter_mut()
            .with_min_len(BLOCK)
            .enumerate()
            .for_each(|(i, x)| {
                *x = match on_piece {
                    Some(p) if p.nodes[i] == crate::team::PAD => 0.0,
                    Some(p) => start(p.nodes[i] as usize, c),
                    None => start(i, c),
                };
            });
    }
    let qn = match on_piece {
        // The norm of the whole body's start vector, from its formula, in `Coords::dot`'s
        // order: three hashes per node of the body, and no array.
        Some(p) => {
            let mut s = 0.0;
            for c in 0..3 {
                s += (0..p.total)
                    .map(|i| {
                        let x = if c < dims { start(i, c) } else { 0.0 };
                        x * x
                    })
                    .sum::<Real>();
            }
            s.sqrt()
        }
        None => q.norm(),
    };
    scale(&mut q, 1.0 / qn);
    q
}

/// `w -= alpha q + beta q_prev` (no `q_prev` in the first iteration: +0 everywhere), and
/// `|w|^2` summed by chunk in chunk order (over the team's chunks when split).
fn orthogonalise(
    w: &mut Coords,
    q: &Coords,
    q_prev: Option<&Coords>,
    (a, b_last): (Real, Real),
    (partial, chunks): (&mut [Real], &std::ops::Range<usize>),
    mut split: Option<&mut Split>,
) -> Real {
    let mut b2 = 0.0;
    for c in 0..3 {
        let (x, p) = (q.comp(c), q_prev.map(|p| p.comp(c)));
        w.comp_mut(c)
            .par_chunks_mut(CHUNK)
            .zip(partial.par_iter_mut())
            .enumerate()
            .filter(|(k, _)| chunks.contains(k))
            .for_each(|(k, (y, out))| {
                let r = k * CHUNK..k * CHUNK + y.len();
                let mut part = 0.0;
                match p {
                    Some(p) => {
                        for ((y, x), p) in y.iter_mut().zip(&x[r.clone()]).zip(&p[r]) {
                            *y += -a * x + -b_last * p;
                            part += *y * *y;
                        }
                    }
                    // The first q_prev: +0 everywhere.
                    None => {
                        for (y, x) in y.iter_mut().zip(&x[r]) {
                            *y += -a * x + -b_last * 0.0;
                            part += *y * *y;
                        }
                    }
                }
                *out = part;
            });
        b2 += match split.as_deref_mut() {
            Some(sp) => sp.sum(partial),
            None => in_order(partial),
        };
    }
    b2
}

/// [`estimate_in`] with the drift's scratch `u_next` ([`drift_scratch`]) and a vector
/// `ones` from the caller, who may keep them: an integrator's own drift scratch, which it
/// clears afterwards, and its inverse masses, which the estimate leaves holding 1 per node (the
/// unit masses of its force evaluations). Large bodies' set-up is dominated by first touches
/// of fresh memory, so the estimate allocates as little as it can: with `state.f` at +0 (a
/// fresh state) the force at the base point is kept there, and `state.f` is given back at +0.
///
/// Its sums (the Lanczos coefficients) are formed per chunk of [`crate::kernel::CHUNK`] nodes
/// and added in chunk order, in parallel and the same for any thread count, and with `split`
/// for any number of ranks sharing it (see [`Split`]; the state's displacements, velocities
/// and forces are given back whole on every rank, its pools current on the rank's nodes).
#[allow(clippy::too_many_arguments)]
pub(crate) fn estimate_using(
    body: &Body,
    state: &mut State,
    kernel: &Kernel,
    iterations: usize,
    tolerance: Real,
    u_next: &mut Coords,
    ones: &mut Vec<Real>,
    mut split: Option<&mut Split>,
) -> StableStep {
    let n = body.nodes();
    let (nodes, chunks) = own(&split, n);
    let inv_sqrt_m: Vec<Real> = body
        .mass
        .par_iter()
        .with_min_len(BLOCK)
        .map(|m| 1.0 / m.sqrt())
        .collect();
    let dims = body.lattice.dim();
    let mut op = KernelJacobian::new(body, state, u_next, ones);
    let on_piece = split.as_deref().and_then(|s| s.piece.as_ref());
    let mut q = start_vector(n, dims, on_piece);
    // The previous Lanczos vector; none is read in the first iteration (its beta is 0), so the
    // buffer is found after it: the state's force array when the estimate does not need it.
    let mut q_prev = Coords::default();
    let mut lent = false;
    let mut w = Coords::zeros(n);
    // max |M^-1/2 q|, for the difference step; later ones come with each new q. The maximum
    // is exact in any order.
    let mut vmax = 0.0;
    // Over every node, or on a piece over its own (the others' are their owners'), and then
    // over the ranks.
    let first = if on_piece.is_some() {
        nodes.clone()
    } else {
        0..n
    };
    for c in 0..3 {
        let top = q.comp(c)[first.clone()]
            .par_iter()
            .with_min_len(BLOCK)
            .zip(&inv_sqrt_m[first.clone()])
            .map(|(x, s)| (x * s).abs())
            .reduce(|| 0.0, Real::max);
        vmax = Real::max(vmax, top);
    }
    if on_piece.is_some() {
        vmax = split.as_deref().expect("a piece").max(vmax);
    }
    let mut partial = vec![0.0; n.div_ceil(CHUNK)];
    let mut alpha = Vec::new();
    let mut beta: Vec<Real> = Vec::new();
    let mut last = 0.0;
    for it in 0..iterations.max(2) {
        // w = M^-1/2 K M^-1/2 q and alpha = w.q (the vector passes are fused, and M^-1/2 q is
        // formed where it is read rather than stored: on a large body they cost as much as
        // the force sweeps, and each array a large body allocates is also first touched).
        let a = op.apply(
            body,
            kernel,
            &q,
            &inv_sqrt_m,
            vmax,
            &mut w,
            split.as_deref_mut(),
        );
        alpha.push(a);
        // w -= alpha q + beta q_prev, and beta' = |w|.
        let b_last = beta.last().copied().unwrap_or(0.0);
        let b2 = orthogonalise(
            &mut w,
            &q,
            (it > 0).then_some(&q_prev),
            (a, b_last),
            (&mut partial, &chunks),
            split.as_deref_mut(),
        );
        let b = b2.sqrt();
        let top = largest_ritz(&alpha, &beta);
        if b <= 1e-14 * a.abs() || (it > 5 && (top - last).abs() <= tolerance * top) {
            last = top;
            break;
        }
        last = top;
        beta.push(b);
        if it == 0 {
            match op.lend_force_array() {
                Some(f) => (q_prev, lent) = (f, true),
                None => q_prev = Coords::zeros(n),
            }
        }
        std::mem::swap(&mut q_prev, &mut q);
        let inv = 1.0 / b;
        // The maximum is exact in any order, so this pass runs in parallel.
        vmax = 0.0;
        for c in 0..3 {
            let top = q.comp_mut(c)[nodes.clone()]
                .par_iter_mut()
                .with_min_len(BLOCK)
                .zip(&w.comp(c)[nodes.clone()])
                .zip(&inv_sqrt_m[nodes.clone()])
                .map(|((x, y), s)| {
                    *x = y * inv;
                    (*x * s).abs()
                })
                .reduce(|| 0.0, Real::max);
            vmax = Real::max(vmax, top);
        }
        if let Some(sp) = split.as_deref() {
            vmax = sp.max(vmax);
        }
    }
    let lambda_max = last;
    if lent {
        // Either Lanczos buffer will do: both are as long as the body.
        op.scratch.f = q_prev;
    }
    if op.f_free {
        op.scratch.f.fill_zero();
    }
    match &op.base {
        Some(u) => op.scratch.u.clone_from(u),
        None => op.scratch.u.fill_zero(),
    }
    match &op.saved_v {
        Some(v) => op.scratch.v.clone_from(v),
        None if op.v_zero => {}
        None => op.scratch.v.fill_zero(),
    }
    StableStep {
        lambda_max,
        dt_critical: 2.0 / lambda_max.sqrt(),
        lambda_bound: damage_bound(body),
    }
}

/// `K v` as the forward difference of a force kernel (see the module docs).
struct KernelJacobian<'a> {
    /// The displacements to linearise about and give back; `None` for +0 everywhere (a body at
    /// rest, the usual set-up: no copy of a large array).
    base: Option<Coords>,
    /// The velocities to give back; `None` for +0 everywhere.
    saved_v: Option<Coords>,
    scratch: &'a mut State,
    u_next: &'a mut Coords,
    unit_inv_mass: &'a [Real],
    spacing: Real,
    partials: Vec<crate::kernel::SweepSums>,
    /// Per-chunk partial sums of a product's dot product.
    partial: Vec<Real>,
    /// The force at `u`, once the first product has evaluated it.
    base_force: BaseForce,
    /// Whether `scratch.f` was +0 everywhere (a fresh state's): then it may hold the base force
    /// or serve as a Lanczos vector, and is given back at +0.
    f_free: bool,
    /// Whether `scratch.v` is +0 everywhere (an evaluation's kick adds the force to it).
    v_zero: bool,
}

/// Where the estimate keeps the force at its base point.
enum BaseForce {
    /// Not evaluated yet.
    Unknown,
    /// Zero everywhere (a body at rest and unstrained: every extension is exactly 0): no array.
    Zero,
    /// In the state's force array (free, see `KernelJacobian::f_free`).
    InF,
    /// In an array of its own.
    Apart(Coords),
}

impl<'a> KernelJacobian<'a> {
    fn new(
        body: &Body,
        state: &'a mut State,
        u_next: &'a mut Coords,
        ones: &'a mut Vec<Real>,
    ) -> Self {
        // Only +0 itself may stand for a zero array: `0.0 + x` and `-0.0 + x` differ for x = -0.
        let zero = |v: &Coords| v.as_flat().par_iter().all(|x| x.to_bits() == 0);
        let copy = |v: &Coords| (!zero(v)).then(|| v.clone());
        let n = body.nodes();
        ones.clear();
        ones.par_extend(rayon::iter::repeat_n(1.0, n));
        let v_zero = zero(&state.v);
        KernelJacobian {
            base: copy(&state.u),
            saved_v: (!v_zero).then(|| state.v.clone()),
            v_zero,
            base_force: BaseForce::Unknown,
            f_free: zero(&state.f),
            scratch: state,
            u_next,
            unit_inv_mass: ones,
            spacing: body.lattice.spacing,
            partials: vec![Default::default(); crate::kernel::partials_len(n)],
            partial: vec![0.0; n.div_ceil(CHUNK)],
        }
    }

    /// Force at `base + eps M^-1/2 q` into `scratch.v` (one pool sweep and one force sweep:
    /// with unit inverse masses, zero velocity and dt = 1 the kick leaves exactly the force in
    /// the velocity). With `split`, on the rank's own nodes, its ghosts' displacements and
    /// pools traded between the sweeps as a step trades them.
    fn force(
        &mut self,
        body: &Body,
        kernel: &Kernel,
        (q, inv_sqrt_m): (&Coords, &[Real]),
        eps: Real,
        mut split: Option<&mut Split>,
    ) {
        let (nodes, _) = own(&split, body.nodes());
        // Element by element, so in parallel (the reductions elsewhere stay in node order).
        for c in 0..3 {
            let u = self.scratch.u.comp_mut(c)[nodes.clone()]
                .par_iter_mut()
                .with_min_len(BLOCK);
            let xs = q.comp(c)[nodes.clone()]
                .par_iter()
                .zip(&inv_sqrt_m[nodes.clone()]);
            match &self.base {
                Some(base) => {
                    u.zip(&base.comp(c)[nodes.clone()])
                        .zip(xs)
                        .for_each(|((u, b), (x, s))| {
                            *u = b + eps * (x * s);
                        })
                }
                None => u.zip(xs).for_each(|(u, (x, s))| {
                    *u = 0.0 + eps * (x * s);
                }),
            }
        }
        if !self.v_zero {
            for v in self.scratch.v.xyz_mut() {
                v.par_iter_mut().with_min_len(BLOCK).for_each(|v| *v = 0.0);
            }
        }
        self.v_zero = false;
        let share = split.as_deref().map(|s| s.share);
        if let Some(sp) = split.as_deref_mut() {
            // A plate's z displacements are the base's on every rank already.
            let dims = body.lattice.dim();
            sp.trade(&mut self.scratch.u.xyz_mut()[..dims]);
        }
        kernel.pools_shared(body, self.scratch, Real::INFINITY, share);
        if let Some(sp) = split {
            sp.trade(&mut [&mut self.scratch.pool[..]]);
        }
        let p = StepParams {
            dt: 1.0,
            damping: 0.0,
            accel: [0.0; 3],
            plane: false,
        };
        // A kernel that drifts in place writes over the displacements just formed, which the
        // next evaluation forms again (and the estimate gives back at its end).
        let u_next = (!kernel.drifts_in_place()).then_some(&mut *self.u_next);
        kernel.force_kick_drift_shared(
            body,
            self.scratch,
            self.unit_inv_mass,
            &p,
            u_next,
            &mut self.partials,
            share,
        );
    }

    /// The state's force array (+0 everywhere), for the caller to use and give back, when the
    /// base point's force needs no array; call after the first product.
    fn lend_force_array(&mut self) -> Option<Coords> {
        (matches!(self.base_force, BaseForce::Zero) && self.f_free)
            .then(|| std::mem::take(&mut self.scratch.f))
    }

    /// `w = M^-1/2 K M^-1/2 q`, returning `w.q`; `vmax` is `max |M^-1/2 q|`. With `split`,
    /// `w` on the rank's own nodes and `w.q` over all of them.
    #[allow(clippy::too_many_arguments)]
    fn apply(
        &mut self,
        body: &Body,
        kernel: &Kernel,
        q: &Coords,
        inv_sqrt_m: &[Real],
        vmax: Real,
        w: &mut Coords,
        mut split: Option<&mut Split>,
    ) -> Real {
        if vmax == 0.0 {
            w.fill_zero();
            return 0.0;
        }
        let (_, chunks) = own(&split, body.nodes());
        let eps = 1e-7 * self.spacing / vmax;
        if let BaseForce::Unknown = self.base_force {
            self.force(body, kernel, (q, inv_sqrt_m), 0.0, split.as_deref_mut());
            let v = &mut self.scratch.v;
            // Another rank's nodes hold +0 here (the sweeps wrote this rank's only), so each
            // rank sees its own force and every rank decides alike on all of them.
            let mut moved = [v.as_flat().par_iter().any(|&x| x != 0.0)];
            if let Some(sp) = split.as_deref() {
                sp.team.any(&mut moved);
            }
            self.base_force = if self.base.is_none() && !moved[0] {
                // Then `u = 0 + eps M^-1/2 q` wherever the force is read, so a zero's sign
                // cannot reach a displacement, nor a sum: +0 stands for it.
                for c in v.xyz_mut() {
                    c.par_iter_mut().with_min_len(BLOCK).for_each(|x| *x = 0.0);
                }
                self.v_zero = true;
                BaseForce::Zero
            } else if self.f_free {
                // `f` is +0 everywhere: the swap keeps the force and clears the velocities.
                std::mem::swap(&mut self.scratch.f, &mut self.scratch.v);
                self.v_zero = true;
                BaseForce::InF
            } else {
                BaseForce::Apart(v.clone())
            };
        }
        self.force(body, kernel, (q, inv_sqrt_m), eps, split.as_deref_mut());
        // K v = -(f(u + eps v) - f(u)) / eps, scaled by M^-1/2 and dotted with q, summed per
        // component by chunks in chunk order.
        // The velocities (the force) are cleared as they are read, for the next evaluation.
        let State { f: base_f, v, .. } = &mut *self.scratch;
        let base = match &self.base_force {
            BaseForce::Zero => None,
            BaseForce::Apart(b) => Some(b),
            BaseForce::InF | BaseForce::Unknown => Some(&*base_f),
        };
        let mut a = 0.0;
        for c in 0..3 {
            let (b, x) = (base.map(|b| b.comp(c)), q.comp(c));
            w.comp_mut(c)
                .par_chunks_mut(CHUNK)
                .zip(v.comp_mut(c).par_chunks_mut(CHUNK))
                .zip(self.partial.par_iter_mut())
                .enumerate()
                .filter(|(k, _)| chunks.contains(k))
                .for_each(|(k, ((y, f), out))| {
                    let r = k * CHUNK..k * CHUNK + y.len();
                    let mut part = 0.0;
                    let b = b.map(|b| &b[r.clone()]);
                    for (i, ((y, f), x)) in y
                        .iter_mut()
                        .zip(f.iter_mut())
                        .zip(&x[r.clone()])
                        .enumerate()
                    {
                        let b = b.map_or(0.0, |b| b[i]);
                        *y = (b - *f) / eps * inv_sqrt_m[r.start + i];
                        *f = 0.0;
                        part += *y * x;
                    }
                    *out = part;
                });
            a += match split.as_deref_mut() {
                Some(sp) => sp.sum(&mut self.partial),
                None => in_order(&self.partial),
            };
        }
        self.v_zero = true;
        a
    }
}

/// The sum of per-chunk partial sums, first to last (fixed, so the same for any thread count).
fn in_order(partial: &[Real]) -> Real {
    partial.iter().fold(0.0, |s, &p| s + p)
}

fn scale(v: &mut Coords, s: Real) {
    for c in 0..3 {
        v.comp_mut(c).iter_mut().for_each(|x| *x *= s);
    }
}

fn largest_ritz(alpha: &[Real], beta: &[Real]) -> Real {
    let m = alpha.len();
    let mut t = DMatrix::zeros(m, m);
    for i in 0..m {
        t[(i, i)] = alpha[i];
        if i + 1 < m {
            t[(i, i + 1)] = beta[i];
            t[(i + 1, i)] = beta[i];
        }
    }
    t.symmetric_eigen().eigenvalues.max()
}

/// `(1 + 2 max(q,0)) max_n 2 sum_t k_t / m_n`: holds for any pattern of broken springs (in a
/// body of several materials, `max(q_n, 0)` over its nodes, `Body::q_bound`).
pub fn damage_bound(body: &Body) -> Real {
    damage_bound_with(body, body.q_bound())
}

/// [`damage_bound`] with `max(q_n, 0)` given (a process that holds a piece of a body of several
/// materials takes the whole body's, so that every process finds the one-process bound).
pub fn damage_bound_with(body: &Body, q_bound: Real) -> Real {
    // Each node's sum in row order; the maximum is exact in any order.
    let star = body.lattice.bonds.grid().map(|g| g.star());
    let sum_k = |n: usize| -> Real {
        match (body.lattice.bonds.grid(), body.k.rule(), &star) {
            // A box whose stiffnesses follow a rule: the row's terms in its order, without the
            // rows.
            (Some(g), Some(k), Some(star)) => {
                let (mut terms, mut count) = ([0.0; 18], 0);
                g.links(star, n, |j, _| {
                    terms[count] = k.between(n, j);
                    count += 1;
                });
                terms[..count].iter().sum()
            }
            _ => {
                let bonds = &*body.lattice.bonds;
                bonds.row(n).map(|e| body.k[bonds.bond[e] as usize]).sum()
            }
        }
    };
    let worst = (0..body.nodes())
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|n| 2.0 * sum_k(n) / body.mass[n])
        .reduce(|| 0.0, Real::max);
    (1.0 + 2.0 * q_bound) * worst
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use crate::dynamics::{Integrator, IntegratorOptions};
    use crate::loading::Loading;
    use crate::material::{Elastic, PlaneModel};
    use crate::random::RandomSpec;
    use crate::team::{Team, Threads};
    use crate::{Body, Lattice, State};

    /// A team's members find the stable step of one process, bit for bit: on every kernel
    /// (the row kernel, the CSR kernel, both stencils), 2D and 3D, at rest and deformed and
    /// moving, with the damage-proof bound too, for teams of 2 and 3. (A wrong sum or a
    /// missing trade changes the step's last bits, or its members' steps disagree.)
    #[test]
    fn a_team_finds_the_stable_step_of_one_process() {
        let m = Elastic {
            youngs: 70e9,
            poisson: 0.3,
            density: 2500.0,
        };
        let a = 1e-3;
        let random = |dim: usize, hi: [f64; 3]| {
            Lattice::random(dim, [0.0; 3], hi, a, 2e-3, RandomSpec::default(), &|_| true).unwrap()
        };
        let bodies = [
            ("random3d", random(3, [45e-3, 30e-3, 12e-3]), false),
            ("random3d, CSR", random(3, [45e-3, 30e-3, 12e-3]), true),
            ("random2d", random(2, [150e-3, 100e-3, 0.0]), false),
            ("hex", Lattice::hex_box(150, 100, a, 2e-3).unwrap(), false),
            ("cubic", Lattice::cubic_box([30, 20, 24], a).unwrap(), false),
        ];
        for (name, lattice, csr) in bodies {
            let body = Body::new(lattice, &m, PlaneModel::Stress).unwrap();
            assert!(
                body.nodes() >= 3 * crate::kernel::CHUNK,
                "{name}: {} nodes",
                body.nodes()
            );
            for (moving, damage_proof) in [(false, false), (true, false), (true, true)] {
                let mut state = State::new(&body);
                if moving {
                    let x = &body.lattice.pos;
                    for i in 0..body.nodes() {
                        state.u.x_mut()[i] = 1e-6 * (x.y()[i] * 300.0).sin();
                        state.u.y_mut()[i] = 2e-6 * (x.x()[i] * 200.0).cos();
                        state.v.x_mut()[i] = 0.1 * (x.x()[i] * 100.0).sin();
                    }
                }
                let opts = IntegratorOptions {
                    force_csr: csr,
                    damage_proof,
                    ..Default::default()
                };
                let alone = Integrator::new(&body, &mut state.clone(), Loading::default(), &opts)
                    .unwrap()
                    .stable()
                    .to_owned();
                for size in [2, 3] {
                    let found: Vec<(f64, f64)> = std::thread::scope(|s| {
                        let handles: Vec<_> = Threads::team(size)
                            .into_iter()
                            .map(|t| {
                                let (body, opts, mut state) = (&body, &opts, state.clone());
                                s.spawn(move || {
                                    let team: Arc<dyn Team> = Arc::new(t);
                                    let it = Integrator::new_shared(
                                        body,
                                        &mut state,
                                        Loading::default(),
                                        opts,
                                        Some(team),
                                    )
                                    .unwrap();
                                    (it.stable().lambda_max, it.stable().dt_critical)
                                })
                            })
                            .collect();
                        handles.into_iter().map(|h| h.join().unwrap()).collect()
                    });
                    for (r, &(lambda, dt)) in found.iter().enumerate() {
                        assert!(
                            lambda.to_bits() == alone.lambda_max.to_bits()
                                && dt.to_bits() == alone.dt_critical.to_bits(),
                            "{name}, moving {moving}, damage-proof {damage_proof}: member {r} \
                             of {size} found lambda {lambda:e}, one process {:e}",
                            alone.lambda_max
                        );
                    }
                }
            }
        }
    }
}
