//! The mutable state of a body: positions, velocities, forces, which springs are intact, and
//! each node's dispersion normaliser.

use rayon::prelude::*;

use crate::body::Body;
use crate::math::{Coords, Real, Vector};

/// A field of [`State`] that every crate reads and only this one changes: the spring masks,
/// damage weights and normalisers, which [`State`]'s methods keep consistent with each other.
/// It reads as the value it holds (`Deref`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Kept<T>(T);

impl<T> std::ops::Deref for Kept<T> {
    type Target = T;
    #[inline]
    fn deref(&self) -> &T {
        &self.0
    }
}

/// One node's record of the row kernel (`hooke_kernel::rows`): reference position,
/// displacement, pool, padding (a cache line).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Record(pub [Real; 8]);

/// Everything that changes during a run.
///
/// Which springs are intact and the normalisers that follow from them are kept consistent by
/// this type (read them with [`State::alive`] and [`State::norm`]; change them with
/// [`State::kill_bond`] or [`State::set_alive`]), and an integrator notices any change through
/// [`State::breaks`], so its kernel never runs on stale spring masks.
#[derive(Debug)]
pub struct State {
    /// Node displacements from the reference positions (m). Stored instead of positions so that
    /// spring extensions keep full precision at small strain: a spring's vector is formed as
    /// `(X_j - X_i) + (u_j - u_i)`, never as the difference of two large coordinates.
    pub u: Coords,
    /// Node velocities (m/s).
    pub v: Coords,
    /// Internal forces of the last evaluation (N).
    pub f: Coords,
    /// Whether each spring is intact.
    pub alive: Kept<Vec<bool>>,
    /// Damage weight `w_t` in (0, 1] of each intact spring of a softening material: the spring
    /// acts with stiffness `w_t k_t` everywhere (its force, its pool share, its node's
    /// normaliser). Empty while no spring has softened (every weight 1), so brittle runs keep
    /// neither this nor `k_eff`.
    pub weight: Kept<Vec<Real>>,
    /// `w_t k_t` per spring (N/m), kept with `weight` (empty with it): what the kernels read.
    pub k_eff: Kept<Vec<Real>>,
    /// Normaliser `S_n = sum_t k_t L_t^2` over node n's intact springs (N m). Kept in step with
    /// `alive` by [`State::kill_bond`].
    pub norm: Kept<Vec<Real>>,
    /// Pool ratio `p_n = Pi_n / S_n` of the last evaluation (dimensionless strain-like measure:
    /// `tr(eps)/d` under uniform strain).
    pub pool: Vec<Real>,
    /// Simulated time (s).
    pub time: Real,
    /// Steps taken.
    pub step: u64,
    /// Changes to `alive` so far (see [`State::breaks`]).
    breaks: u64,
    /// Scratch of the CSR kernel (`kernel::csr`): each spring's record and pool share, computed
    /// once per spring in its first sweep and read by both of its ends (not state: not compared,
    /// not checkpointed).
    pub spring: Vec<Real>,
    pub spring_pi: Vec<Real>,
    /// Break screen of the last screened sweep 1 (`hooke_kernel::Kernel::pools_screened`):
    /// one flag per block of springs (CSR) or nodes (stencil) holding a spring stretched past
    /// the screen. Scratch like `spring`.
    pub hot: Vec<bool>,
    /// Scratch of the row kernel (`kernel::rows`): each node's reference position,
    /// displacement and pool in one cache line, refreshed before each sweep.
    pub rec: Vec<Record>,
}

impl Clone for State {
    fn clone(&self) -> Self {
        let mut s = State {
            u: Coords::default(),
            v: Coords::default(),
            f: Coords::default(),
            alive: Kept(Vec::new()),
            weight: Kept(Vec::new()),
            k_eff: Kept(Vec::new()),
            norm: Kept(Vec::new()),
            pool: Vec::new(),
            time: 0.0,
            step: 0,
            breaks: 0,
            spring: Vec::new(),
            spring_pi: Vec::new(),
            hot: Vec::new(),
            rec: Vec::new(),
        };
        s.clone_from(self);
        s
    }

    /// Field by field into the existing buffers: a state of the same body is overwritten without
    /// reallocating, so views of its arrays (numpy) stay valid.
    fn clone_from(&mut self, o: &Self) {
        self.u.clone_from(&o.u);
        self.v.clone_from(&o.v);
        self.f.clone_from(&o.f);
        self.alive.0.clone_from(&o.alive.0);
        self.weight.0.clone_from(&o.weight.0);
        self.k_eff.0.clone_from(&o.k_eff.0);
        self.norm.0.clone_from(&o.norm.0);
        self.pool.clone_from(&o.pool);
        self.time = o.time;
        self.step = o.step;
        self.breaks = o.breaks;
        self.spring.clone_from(&o.spring);
        self.spring_pi.clone_from(&o.spring_pi);
        self.hot.clone_from(&o.hot);
        self.rec.clone_from(&o.rec);
    }
}

/// Equal states: the same displacements, velocities, forces, springs, pools, time and step (how
/// many changes led to the springs is not part of the state).
impl PartialEq for State {
    fn eq(&self, o: &Self) -> bool {
        self.u == o.u
            && self.v == o.v
            && self.f == o.f
            && self.alive == o.alive
            && self.weights_equal(o)
            && self.norm == o.norm
            && self.pool == o.pool
            && self.time == o.time
            && self.step == o.step
    }
}

impl State {
    /// The state's heap memory by part, scratch included (see [`crate::memory::Footprint`]).
    pub fn footprint(&self) -> crate::memory::Footprint {
        use crate::memory::bytes;
        vec![
            ("displacements", self.u.heap_bytes()),
            ("velocities", self.v.heap_bytes()),
            ("forces", self.f.heap_bytes()),
            ("intact flags", bytes(&self.alive)),
            (
                "damage (weights, stiffnesses)",
                bytes(&self.weight) + bytes(&self.k_eff),
            ),
            ("normalisers", bytes(&self.norm)),
            ("pools", bytes(&self.pool)),
            (
                "spring records (csr)",
                bytes(&self.spring) + bytes(&self.spring_pi) + bytes(&self.hot),
            ),
            ("node records (rows)", bytes(&self.rec)),
        ]
    }

    /// The body at rest in its reference configuration, every spring intact.
    pub fn new(body: &Body) -> Self {
        let n = body.nodes();
        let mut s = State {
            u: Coords::zeros(n),
            v: Coords::zeros(n),
            f: Coords::zeros(n),
            alive: Kept(vec![true; body.springs()]),
            weight: Kept(Vec::new()),
            k_eff: Kept(Vec::new()),
            norm: Kept(vec![0.0; n]),
            pool: vec![0.0; n],
            time: 0.0,
            step: 0,
            breaks: 0,
            spring: Vec::new(),
            spring_pi: Vec::new(),
            hot: Vec::new(),
            rec: Vec::new(),
        };
        // Each node's sum is its own: in parallel (a large body's set-up), the same bits.
        let grid = body.lattice.bonds.grid();
        if let (Some(g), Some(k), None) = (grid, body.k.rule(), &body.lever) {
            // A box whose stiffnesses follow a rule: the rows' values in their order, without
            // the rows.
            let star = g.star();
            s.norm
                .0
                .par_iter_mut()
                .with_min_len(1 << 12)
                .enumerate()
                .for_each(|(i, x)| {
                    let mut sum = 0.0;
                    g.links(&star, i, |j, l| sum += k.between(i, j) * l * l);
                    *x = sum;
                });
            return s;
        }
        let springs = Springs::of(body, &s.alive, &s.k_eff);
        s.norm
            .0
            .par_iter_mut()
            .with_min_len(1 << 12)
            .enumerate()
            .for_each(|(i, x)| *x = node_norm(body, springs, i));
        s
    }

    /// The springs as the force law sees them: which are intact and their current stiffness.
    #[inline]
    pub fn springs<'a>(&'a self, body: &'a Body) -> Springs<'a> {
        Springs::of(body, &self.alive, &self.k_eff)
    }

    /// Damage weight `w_t` of every spring (1 intact and undamaged, 0 broken): allocated.
    pub fn weights(&self) -> Vec<Real> {
        (0..self.alive.len()).map(|b| self.weight_of(b)).collect()
    }

    /// Damage weight of spring `b` (see [`State::weights`]).
    #[inline]
    pub fn weight_of(&self, b: usize) -> Real {
        if !self.alive[b] {
            0.0
        } else if self.weight.is_empty() {
            1.0
        } else {
            self.weight[b]
        }
    }

    /// Whether some intact spring has a weight below 1 (a softening material has damaged it).
    pub fn is_softened(&self) -> bool {
        !self.weight.is_empty()
    }

    fn weights_equal(&self, o: &Self) -> bool {
        (0..self.alive.len()).all(|b| self.weight_of(b) == o.weight_of(b))
    }

    /// Soften spring `b` to weight `w` (irreversible damage: `w` must not exceed its present
    /// weight). `w = 0` removes it exactly as [`State::kill_bond`] does, so a fully softened
    /// spring is a broken one. Both nodes' normalisers follow. Returns false if nothing changed.
    pub fn soften(&mut self, body: &Body, b: usize, w: Real) -> bool {
        if !self.alive[b] || w.is_nan() || w >= self.weight_of(b) {
            return false;
        }
        if w <= 0.0 {
            return self.kill_bond(body, b);
        }
        if self.weight.is_empty() {
            self.weight.0 = vec![1.0; self.alive.len()];
            self.k_eff.0 = body.k.to_vec();
        }
        self.weight.0[b] = w;
        self.k_eff.0[b] = w * body.k[b];
        self.breaks += 1;
        for n in body.lattice.bonds.ends[b] {
            let n = n as usize;
            self.norm.0[n] = node_norm(body, self.springs(body), n);
        }
        true
    }

    /// Set every spring's weight (e.g. from a checkpoint; 0 is broken) and recompute every
    /// normaliser. All ones leaves the state without weights.
    pub fn set_weights(&mut self, body: &Body, weights: &[Real]) {
        assert_eq!(weights.len(), body.springs(), "one weight per spring");
        self.alive.0 = weights.iter().map(|&w| w > 0.0).collect();
        if weights.iter().all(|&w| w == 0.0 || w == 1.0) {
            self.weight.0.clear();
            self.k_eff.0.clear();
        } else {
            self.weight.0 = weights
                .iter()
                .map(|&w| if w > 0.0 { w } else { 1.0 })
                .collect();
            self.k_eff.0 = self
                .weight
                .iter()
                .zip(body.k.iter())
                .map(|(w, k)| w * k)
                .collect();
        }
        for n in 0..body.nodes() {
            self.norm.0[n] = node_norm(body, self.springs(body), n);
        }
        self.breaks += 1;
    }

    /// Current position of node `i`.
    pub fn position(&self, body: &Body, i: usize) -> Vector {
        body.lattice.pos.get(i) + self.u.get(i)
    }

    /// Current positions of all nodes (for output).
    pub fn positions(&self, body: &Body) -> Coords {
        let mut x = body.lattice.pos.clone();
        x.axpy(1.0, &self.u);
        x
    }

    /// Remove spring `b`: it stops carrying direct and dispersed force, leaves its two nodes'
    /// pools, and both nodes' normalisers `S_n` are recomputed over their remaining springs
    /// (`docs/model.md`, bond removal). Returns false if it was already broken.
    pub fn kill_bond(&mut self, body: &Body, b: usize) -> bool {
        if !self.alive[b] {
            return false;
        }
        self.alive.0[b] = false;
        self.breaks += 1;
        for n in body.lattice.bonds.ends[b] {
            let n = n as usize;
            // Recomputed from scratch rather than decremented: the sum then does not depend on
            // the order in which springs broke, which keeps runs bit-reproducible.
            self.norm.0[n] = node_norm(body, self.springs(body), n);
        }
        true
    }

    /// Whether no spring was ever removed, restored or weakened: every spring is intact, of
    /// its body's stiffness, as [`State::new`] made it (a state passed through
    /// [`State::set_alive`] or [`State::set_weights`] is not, whatever they set).
    pub fn is_pristine(&self) -> bool {
        self.breaks == 0 && self.k_eff.is_empty()
    }

    /// Whether each spring is intact.
    pub fn alive(&self) -> &[bool] {
        &self.alive
    }

    /// Normaliser `S_n` of every node over its intact springs.
    pub fn norm(&self) -> &[Real] {
        &self.norm
    }

    /// A counter that changes whenever a spring is removed or restored: integrators compare it
    /// with the value their kernel was synchronised at.
    pub fn breaks(&self) -> u64 {
        self.breaks
    }

    /// The state of a piece cut out of this one (`piece` the piece's body; `hooke_core`'s
    /// `team::Piece::state`): the piece's node `p` takes this state's node `nodes[p]` (none
    /// where that is `pad`), its spring `t` this state's spring `springs[t]`. The normalisers
    /// are copied, not recomputed, so that they keep their bits; the counter of changes is
    /// carried over.
    pub fn cut(&self, piece: &Body, nodes: &[u32], pad: u32, springs: &[u32]) -> State {
        let mut s = State::new(piece);
        let pick = |dst: &mut [Real], src: &[Real]| {
            for (d, &g) in dst.iter_mut().zip(nodes) {
                if g != pad {
                    *d = src[g as usize];
                }
            }
        };
        for (a, b) in [
            (&mut s.u, &self.u),
            (&mut s.v, &self.v),
            (&mut s.f, &self.f),
        ] {
            for (c, dst) in a.xyz_mut().into_iter().enumerate() {
                pick(dst, b.comp(c));
            }
        }
        pick(&mut s.pool, &self.pool);
        pick(&mut s.norm.0, &self.norm);
        s.alive.0 = springs.iter().map(|&b| self.alive[b as usize]).collect();
        if !self.weight.is_empty() {
            s.weight.0 = springs.iter().map(|&b| self.weight[b as usize]).collect();
            s.k_eff.0 = springs.iter().map(|&b| self.k_eff[b as usize]).collect();
        }
        s.time = self.time;
        s.step = self.step;
        s.breaks = self.breaks;
        s
    }

    /// Set which springs are intact (e.g. from a checkpoint) and recompute every normaliser.
    pub fn set_alive(&mut self, body: &Body, alive: Vec<bool>) {
        assert_eq!(alive.len(), body.springs(), "one flag per spring");
        self.alive.0 = alive;
        for n in 0..body.nodes() {
            self.norm.0[n] = node_norm(body, self.springs(body), n);
        }
        self.breaks += 1;
    }

    /// Number of intact springs.
    pub fn intact(&self) -> usize {
        self.alive.iter().filter(|&&a| a).count()
    }
}

/// `S_n` of node `n` over its intact springs, each with its current stiffness (`S_n / q_n` in
/// a body of several materials, [`Body::q_node`]).
pub fn node_norm(body: &Body, springs: Springs<'_>, n: usize) -> Real {
    let bonds = &*body.lattice.bonds;
    let mut s = 0.0;
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        if springs.alive[b] {
            // Once: a lattice that shed its rest lengths computes each (a square root).
            let l = springs.lever.get(b);
            s += springs.k[b] * l * l;
        }
    }
    // A node of a body of several materials keeps `S_n / q_n` (Body::q_node): its pool is then
    // `q_n p_n`, and the law reads as one material's with q = 1. A ratio of 0 gives an infinite
    // normaliser, whose pool is 0; a negative one a negative normaliser.
    match &body.q_node {
        Some(q) if s != 0.0 => s / q[n],
        _ => s,
    }
}

/// The springs as the force law reads them: which are intact, and each one's current stiffness
/// `w_t k_t` (the body's `k_t` unless a softening material damaged some,
/// [`State::soften`]). A damaged spring enters everything with `w_t k_t`: its force, its pool
/// share `w_t k_t L_t dL_t` and its nodes' normalisers `S_n = sum_t w_t k_t L_t^2`, so the law
/// stays the gradient of `U = 1/2 sum w k dL^2 + q/2 sum Pi^2/S` and a spring at `w = 0` is a
/// broken one.
#[derive(Clone, Copy, Debug)]
pub struct Springs<'a> {
    pub alive: &'a [bool],
    pub k: &'a [Real],
    /// Each spring's dispersion lever ([`Body::levers`]): its rest length for an isotropic
    /// material.
    pub lever: crate::body::Levers<'a>,
}

impl<'a> Springs<'a> {
    /// Intact flags with the body's own stiffnesses (no damage weights).
    pub fn intact(body: &'a Body, alive: &'a [bool]) -> Self {
        Springs {
            alive,
            k: &body.k,
            lever: body.levers(),
        }
    }

    /// From a state's fields (for borrows that keep the state's other fields free).
    #[inline]
    pub fn of(body: &'a Body, alive: &'a [bool], k_eff: &'a [Real]) -> Self {
        Springs {
            alive,
            k: if k_eff.is_empty() { &body.k } else { k_eff },
            lever: body.levers(),
        }
    }
}
