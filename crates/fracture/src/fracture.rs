//! Deciding and committing breaks.

use rayon::prelude::*;

use hooke_core::dynamics::{Breaker, Integrator, Interaction};
use hooke_core::kernel::CHUNK;
use hooke_core::law::spring_geometry;
use hooke_core::{Body, Real, State};

use crate::criterion::{Criterion, SpringState};
use crate::error::FractureError;
use crate::precrack::{springs_crossing, Crack};

/// What one check did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BreakReport {
    /// Springs broken.
    pub broken: usize,
    /// Springs softened without breaking (a softening criterion: their damage weight fell).
    pub softened: usize,
    /// Energy released, `U(before) - U(after)` (J). Usually positive; it can be negative with a
    /// large q when neighbouring springs are in opposite states.
    pub released: Real,
}

/// Bond breaking for one body.
#[derive(Debug)]
pub struct Fracture {
    criterion: Box<dyn Criterion>,
    /// Nodes whose springs never break (near loading boundaries).
    no_fail: Vec<bool>,
    /// Springs each node had at set-up (for damage).
    initial: Vec<u32>,
    /// Per-chunk lists of springs that fail or soften, with their new damage weight (0:
    /// broken), reused between checks.
    found: Vec<Vec<(u32, Real)>>,
    /// Scratch: nodes touched by a commit.
    touched: Vec<u32>,
    /// Scratch: the nodes a commit's energies read (the touched ones and their neighbours).
    reads: Vec<u32>,
    /// Scratch: the springs sweep 1's screen flagged.
    hot: Vec<u32>,
    /// What the last screened decision broke.
    last: BreakReport,
    /// On a rank's piece: its decisions, `(spring, new weight, ends)` in the body's indices,
    /// then every rank's ([`Integrator::gather_decisions`]).
    decided: Vec<(u32, Real, [u32; 2])>,
    /// Total springs broken by checks (pre-cracks not counted).
    pub broken_total: usize,
    /// Total softening events (a spring's weight lowered without breaking it).
    pub softened_total: usize,
    /// Total energy released by checks (J).
    pub released_total: Real,
}

impl Fracture {
    /// Breaking with `criterion` on `body`.
    pub fn new(body: &Body, criterion: Box<dyn Criterion>) -> Self {
        let bonds = &*body.lattice.bonds;
        Fracture {
            criterion,
            no_fail: vec![false; body.nodes()],
            initial: (0..body.nodes())
                .map(|n| bonds.row(n).len() as u32)
                .collect(),
            found: vec![Vec::new(); body.nodes().div_ceil(CHUNK)],
            touched: Vec::new(),
            reads: Vec::new(),
            hot: Vec::new(),
            last: BreakReport::default(),
            decided: Vec::new(),
            broken_total: 0,
            softened_total: 0,
            released_total: 0.0,
        }
    }

    /// The criterion in use.
    pub fn criterion(&self) -> &dyn Criterion {
        self.criterion.as_ref()
    }

    /// Follow a shared integrator onto its rank's piece ([`Integrator::cut`]; `piece_body` the
    /// body it returned): the per-node flags and counts in the piece's numbering. From here on
    /// the rank decides the springs whose lower end it owns, the ranks gather their decisions,
    /// and each commits those of its piece's springs; the released energy's terms are each
    /// computed by an owner and summed on every rank in one process's order.
    pub fn cut(&mut self, piece: &hooke_core::team::Piece, piece_body: &Body) {
        use hooke_core::team::PAD;
        self.no_fail = piece
            .global
            .iter()
            .map(|&g| g != PAD && self.no_fail[g as usize])
            .collect();
        // A piece holds its own nodes' rows whole (the ghosts' partly: their damage is their
        // owners' to write).
        let bonds = &*piece_body.lattice.bonds;
        self.initial = (0..piece_body.nodes())
            .map(|n| bonds.row(n).len() as u32)
            .collect();
        self.found = vec![Vec::new(); piece_body.nodes().div_ceil(CHUNK)];
    }

    /// Springs with an end in `nodes` never break.
    pub fn set_no_fail(&mut self, nodes: &[u32]) {
        for &n in nodes {
            self.no_fail[n as usize] = true;
        }
    }

    /// Remove every spring a pre-crack cuts (at set-up, before the integrator is built; no
    /// energy is booked: the body must still be undeformed). Returns the number removed.
    pub fn precrack(
        &mut self,
        body: &Body,
        state: &mut State,
        cracks: &[Crack],
    ) -> Result<usize, FractureError> {
        self.precrack_where(body, state, cracks, &|cut| !cut)
    }

    /// [`Fracture::precrack`] on a process's piece of a body: `cuts_nothing(cut)`, given
    /// whether a crack cuts a spring of this piece, says whether it cuts none of the body's
    /// (a collective answer, so that every process refuses it alike).
    pub fn precrack_where(
        &mut self,
        body: &Body,
        state: &mut State,
        cracks: &[Crack],
        cuts_nothing: &dyn Fn(bool) -> bool,
    ) -> Result<usize, FractureError> {
        let mut n = 0;
        for (k, c) in cracks.iter().enumerate() {
            let cut = springs_crossing(body, c, k)?;
            if cuts_nothing(!cut.is_empty()) {
                return Err(crate::precrack::no_spring(k));
            }
            for s in cut {
                if state.kill_bond(body, s) {
                    n += 1;
                }
            }
        }
        Ok(n)
    }

    /// One step of `integrator` with breaking. With a criterion that has a screen (the
    /// critical stretch), the check runs inside the step: sweep 1 flags the blocks holding a
    /// spring past the screen, the criterion looks at those springs only, and the breaks are
    /// committed before the forces, at the step's start state. That is the state, the decisions
    /// and the bits of [`Fracture::check`] after the previous step, without its pass over every
    /// spring. Other criteria: the step, then [`Fracture::check`]. Returns what broke.
    pub fn step(
        &mut self,
        body: &Body,
        state: &mut State,
        integrator: &mut Integrator,
        interaction: Option<&mut dyn Interaction>,
    ) -> BreakReport {
        if self.criterion.screen().is_some() {
            self.last = BreakReport::default();
            integrator.step_breaking(body, state, interaction, self);
            self.last
        } else {
            integrator.step_with(body, state, interaction);
            self.check(body, state, integrator)
        }
    }

    /// With a screened criterion, commit now the breaks that the next [`Fracture::step`] would
    /// make at its start (before a frame or a checkpoint shows the state). Deciding is
    /// idempotent, so this never changes a run. Without a screen there is nothing pending.
    pub fn settle(
        &mut self,
        body: &Body,
        state: &mut State,
        integrator: &mut Integrator,
    ) -> BreakReport {
        if self.criterion.screen().is_none() {
            return BreakReport::default();
        }
        self.last = BreakReport::default();
        integrator.settle(body, state, self);
        self.last
    }

    /// Decide which intact springs fail in the current state and commit them: they leave the
    /// state and the kernel's copy, and the energy ledger is told what they released. Call after
    /// each step (or every few steps). The pool ratios the criterion sees are those of the
    /// step's force evaluation. In a shared run each rank decides its own nodes' springs, so
    /// call it where a step (or a whole-state gather) has left every rank's nodes and ghosts
    /// current: after a step, as [`Fracture::step`] does.
    pub fn check(
        &mut self,
        body: &Body,
        state: &mut State,
        integrator: &mut Integrator,
    ) -> BreakReport {
        if let Some(own) = integrator.piece().map(|p| p.own.clone()) {
            // After a step a piece's own nodes and ghosts hold the new displacements and the
            // step's pools: its own nodes' springs are decided as one process decides them.
            self.decide_at(body, state, own);
            let piece = integrator.piece().expect("a piece");
            let bonds = &*body.lattice.bonds;
            self.decided.clear();
            for list in &mut self.found {
                for (b, w) in list.drain(..) {
                    let ends = bonds.ends[b as usize].map(|n| piece.global[n as usize]);
                    self.decided.push((piece.springs[b as usize], w, ends));
                }
            }
            let report = self.commit_piece(body, state, integrator);
            integrator.add_released(report.released);
            return report;
        }
        match integrator.share().map(|s| s.mine()) {
            // A shared run: after a step, this rank's nodes and its ghosts hold the new
            // displacements and the step's pools, which is all that deciding its own nodes'
            // springs (each from its lower end) reads. The ranks then trade their lists, so
            // every rank commits the lone run's decisions in the lone run's order.
            Some(mine) => {
                self.decide_at(body, state, mine);
                integrator.gather_chunk_lists(&mut self.found);
            }
            None => self.decide(body, state),
        }
        let report = self.commit(body, state, Some(&mut *integrator));
        integrator.add_released(report.released);
        report
    }

    /// The decision pass: fills the per-chunk lists (no state changes).
    pub fn decide(&mut self, body: &Body, state: &State) {
        self.decide_at(body, state, 0..body.nodes());
    }

    /// [`Fracture::decide`] for the springs whose lower end is in `nodes` (whole chunks): the
    /// other chunks' lists are left empty.
    fn decide_at(&mut self, body: &Body, state: &State, nodes: std::ops::Range<usize>) {
        let bonds = &*body.lattice.bonds;
        let (crit, no_fail) = (&*self.criterion, &self.no_fail);
        self.found.par_iter_mut().enumerate().for_each(|(c, list)| {
            list.clear();
            for i in (c * CHUNK).max(nodes.start)..((c + 1) * CHUNK).min(nodes.end) {
                if no_fail[i] {
                    continue;
                }
                for e in bonds.row(i) {
                    let j = bonds.neighbour(i, e);
                    let b = bonds.bond[e] as usize;
                    // Each spring once, from its lower end; rows are sorted, so the lists come
                    // out in a fixed order.
                    if j < i || !state.alive()[b] || no_fail[j] {
                        continue;
                    }
                    if let Some(w) = new_weight(crit, body, state, b, i, j) {
                        list.push((b as u32, w));
                    }
                }
            }
        });
    }

    /// Commit the decided breaks and softenings, in chunk (so node, then spring) order.
    ///
    /// The energy released, `R(u) = U_before(u) - U_after(u)`, is exact at the current
    /// displacements: a broken spring takes its direct energy and changes its nodes' pools, a
    /// softened one (weight `w -> w'`) gives up `1/2 (w - w') k dL^2` of its direct energy and
    /// changes its nodes' pools and normalisers; both are counted over the touched springs and
    /// nodes. In a run, the springs change between two steps, and leapfrog's discrete energy
    /// identity then charges the mean of R at the two positions that share the step, `u(t)` and
    /// `u(t - dt) = u(t) - dt v(t - dt/2)`; booking R(u(t)) alone would leave an O(dt) error per
    /// event in the energy balance. With an integrator we book that mean; without one, R(u).
    pub fn commit(
        &mut self,
        body: &Body,
        state: &mut State,
        mut integrator: Option<&mut Integrator>,
    ) -> BreakReport {
        let count: usize = self.found.iter().map(|l| l.len()).sum();
        if count == 0 {
            return BreakReport::default();
        }
        let bonds = &*body.lattice.bonds;
        let back = integrator.as_deref().map(|it| it.dt);
        self.touched.clear();
        for list in &self.found {
            for &(b, _) in list {
                self.touched.extend(bonds.ends[b as usize]);
            }
        }
        self.touched.sort_unstable();
        self.touched.dedup();
        if let Some(it) = integrator.as_deref_mut().filter(|it| it.share().is_some()) {
            // The released energy reads the touched nodes and their neighbours, displacements
            // and velocities (a shared run keeps only its own and its ghosts' state current
            // between outputs): those are taken from their owners, not the whole state.
            self.reads.clear();
            for &n in &self.touched {
                let n = n as usize;
                self.reads.push(n as u32);
                self.reads
                    .extend(bonds.row(n).map(|e| bonds.neighbour(n, e) as u32));
            }
            self.reads.sort_unstable();
            self.reads.dedup();
            it.gather_state_at(state, &self.reads);
        }
        // R at u (shift 0) and, in a run, at u - dt v.
        let shifts: &[Real] = if back.is_some() { &[0.0, 1.0] } else { &[0.0] };
        let energy = |state: &State, touched: &[u32], found: &[Vec<(u32, Real)>], h: Real| {
            let k = state.springs(body).k;
            let mut e = 0.0;
            for list in found {
                for &(b, _) in list {
                    let b = b as usize;
                    if state.alive()[b] {
                        let [i, j] = bonds.ends[b].map(|v| v as usize);
                        let dl = shifted_extension(body, state, h, i, j, body.lattice.rest(b));
                        e += 0.5 * k[b] * dl * dl;
                    }
                }
            }
            e + touched
                .iter()
                .map(|&n| shifted_dispersive_energy(body, state, h, n as usize))
                .sum::<Real>()
        };
        let mut before = [0.0; 2];
        for (k, &s) in shifts.iter().enumerate() {
            before[k] = energy(state, &self.touched, &self.found, s * back.unwrap_or(0.0));
        }
        let (mut broken, mut softened) = (0, 0);
        for list in &self.found {
            for &(b, w) in list {
                let b = b as usize;
                let changed = match integrator.as_deref_mut() {
                    Some(it) => it.soften_spring(body, state, b, w),
                    None => state.soften(body, b, w),
                };
                if changed && !state.alive()[b] {
                    broken += 1;
                } else if changed {
                    softened += 1;
                }
            }
        }
        let mut released = 0.0;
        for (k, &s) in shifts.iter().enumerate() {
            let after = energy(state, &self.touched, &self.found, s * back.unwrap_or(0.0));
            released += (before[k] - after) / shifts.len() as Real;
        }
        self.broken_total += broken;
        self.softened_total += softened;
        self.released_total += released;
        BreakReport {
            broken,
            softened,
            released,
        }
    }

    /// [`Fracture::commit`] on a rank's piece: the ranks' decisions (`self.decided`, this
    /// rank's) gathered, and each rank's piece's springs among them changed. The released
    /// energy has one process's terms and order: a spring's direct energy is computed by the
    /// owner of its lower end, a touched node's dispersive energy by its owner (both read the
    /// velocities of the node's neighbours, traded first), the terms are all-gathered and
    /// every rank adds them as [`Fracture::commit`] does. Collective.
    fn commit_piece(&mut self, body: &Body, state: &mut State, it: &mut Integrator) -> BreakReport {
        let mut decided = std::mem::take(&mut self.decided);
        it.gather_decisions(&mut decided);
        if decided.is_empty() {
            self.decided = decided;
            return BreakReport::default();
        }
        it.trade_velocities(state);
        let dt = it.dt;
        let share = it.share().expect("shared").nodes.clone();
        let piece = it.piece().expect("a piece");
        let own = piece.first..piece.first + piece.own.len();
        let mut touched: Vec<u32> = decided.iter().flat_map(|d| d.2).collect();
        touched.sort_unstable();
        touched.dedup();
        // Each rank's entries and touched nodes are runs of the lists (both ascending by the
        // lower end, or the node, in the body): its slots are laid out in rank order.
        let runs = |r: &std::ops::Range<usize>| {
            let e = decided.partition_point(|d| (d.2[0] as usize) < r.start)
                ..decided.partition_point(|d| (d.2[0] as usize) < r.end);
            let n = touched.partition_point(|&n| (n as usize) < r.start)
                ..touched.partition_point(|&n| (n as usize) < r.end);
            (e, n)
        };
        // Where each entry's and each touched node's terms are (four each: before and after
        // the change, at the two positions of the step), in list order.
        let mut parts = Vec::with_capacity(share.len());
        let (mut spring_at, mut node_at) = (Vec::new(), Vec::new());
        let mut at = 0;
        for r in &share {
            let (e, n) = runs(r);
            spring_at.extend((0..e.len()).map(|x| 4 * (at + x)));
            node_at.extend((0..n.len()).map(|x| 4 * (at + e.len() + x)));
            parts.push(4 * at..4 * (at + e.len() + n.len()));
            at += e.len() + n.len();
        }
        let (mine_e, mine_n) = runs(&own);
        let springs: Vec<usize> = decided[mine_e.clone()]
            .iter()
            .map(|d| piece.springs.binary_search(&d.0).expect("an owned spring"))
            .collect();
        let nodes: Vec<usize> = touched[mine_n.clone()]
            .iter()
            .map(|&n| piece.local(n as usize).expect("an owned node"))
            .collect();
        // Every rank changes the decided springs its piece holds.
        let changes: Vec<(usize, Real)> = decided
            .iter()
            .filter_map(|d| piece.springs.binary_search(&d.0).ok().map(|b| (b, d.1)))
            .collect();
        let slot = parts[it.team().expect("shared").rank()].start;
        let bonds = &*body.lattice.bonds;
        let terms = |state: &State, out: &mut [Real], after: bool| {
            let k = state.springs(body).k;
            let at = if after { 2 } else { 0 };
            for (s, h) in [0.0, dt].into_iter().enumerate() {
                for (x, &b) in springs.iter().enumerate() {
                    out[4 * x + at + s] = if state.alive()[b] {
                        let [i, j] = bonds.ends[b].map(|v| v as usize);
                        let dl = shifted_extension(body, state, h, i, j, body.lattice.rest(b));
                        0.5 * k[b] * dl * dl
                    } else {
                        0.0
                    };
                }
                for (x, &n) in nodes.iter().enumerate() {
                    out[4 * (springs.len() + x) + at + s] =
                        shifted_dispersive_energy(body, state, h, n);
                }
            }
        };
        let mut values = vec![0.0; 4 * at];
        let mine = slot..slot + 4 * (springs.len() + nodes.len());
        terms(state, &mut values[mine.clone()], false);
        for &(b, w) in &changes {
            it.soften_spring(body, state, b, w);
        }
        terms(state, &mut values[mine], true);
        it.team().expect("shared").gather(&mut values, &parts);
        // The sums of `commit`: the springs' terms in spring order, then the nodes' in node
        // order, rank after rank being both orders.
        let mut released = 0.0;
        for s in 0..2 {
            let sum = |at: usize| {
                let mut e = 0.0;
                for &i in &spring_at {
                    e += values[i + at + s];
                }
                e + node_at.iter().map(|&i| values[i + at + s]).sum::<Real>()
            };
            released += (sum(0) - sum(2)) / 2.0;
        }
        let broken = decided.iter().filter(|d| d.1 <= 0.0).count();
        let softened = decided.len() - broken;
        self.broken_total += broken;
        self.softened_total += softened;
        self.released_total += released;
        self.decided = decided;
        BreakReport {
            broken,
            softened,
            released,
        }
    }

    /// Damage of every node: the fraction of the springs it had at set-up that are broken
    /// (pre-cracks included), a softened spring counting by its lost weight `1 - w`.
    pub fn damage(&self, body: &Body, state: &State) -> Vec<Real> {
        let bonds = &*body.lattice.bonds;
        let (alive, softened) = (state.alive(), state.is_softened());
        // Each node's value from its own row: parallel, the same bits for any thread count.
        (0..body.nodes())
            .into_par_iter()
            .with_min_len(4096)
            .map(|n| {
                let left: Real = if softened {
                    bonds
                        .row(n)
                        .map(|e| state.weight_of(bonds.bond[e] as usize))
                        .sum()
                } else {
                    bonds
                        .row(n)
                        .filter(|&e| alive[bonds.bond[e] as usize])
                        .count() as Real
                };
                if self.initial[n] == 0 {
                    0.0
                } else {
                    1.0 - left / self.initial[n] as Real
                }
            })
            .collect()
    }
}

/// The new damage weight of intact spring `b` from `i` to `j` if the criterion lowers it now
/// (0: it breaks); `None` if it stays as it is.
#[inline]
fn new_weight(
    crit: &dyn Criterion,
    body: &Body,
    state: &State,
    b: usize,
    i: usize,
    j: usize,
) -> Option<Real> {
    let rest = body.lattice.rest(b);
    let g = spring_geometry(&body.lattice, &state.u, i, j, rest);
    let w = state.weight_of(b);
    let next = crit.weight(
        &SpringState {
            k: state.springs(body).k[b],
            rest,
            lever: body.levers().get(b),
            dir: crate::criterion::reference_direction(body, i, j),
            dl: g.dl,
            pool: [state.pool[i], state.pool[j]],
            q: body.q,
        },
        w,
    );
    (next < w).then_some(next.max(0.0))
}

/// The screened check inside a step (see [`Fracture::step`]).
impl Breaker for Fracture {
    fn screen(&self) -> Real {
        self.criterion.screen().unwrap_or(Real::INFINITY)
    }

    fn break_in_step(&mut self, body: &Body, state: &mut State, it: &mut Integrator) {
        let mut hot = std::mem::take(&mut self.hot);
        it.hot_springs(body, state, &mut hot);
        if let Some(piece) = it.piece() {
            // The springs of the rank's own rows that the screen flagged, those whose lower
            // end it owns decided here (every spring past the screen is flagged in its lower
            // end's row).
            let bonds = &*body.lattice.bonds;
            let (crit, no_fail) = (&*self.criterion, &self.no_fail);
            self.decided.clear();
            for &b in &hot {
                let b = b as usize;
                let [i, j] = bonds.ends[b].map(|v| v as usize);
                if !piece.own.contains(&i) || !state.alive()[b] || no_fail[i] || no_fail[j] {
                    continue;
                }
                if let Some(w) = new_weight(crit, body, state, b, i, j) {
                    let ends = [i, j].map(|n| piece.global[n]);
                    self.decided.push((piece.springs[b], w, ends));
                }
            }
            self.hot = hot;
            let report = self.commit_piece(body, state, it);
            it.add_released(report.released);
            self.last = report;
            return;
        }
        for l in &mut self.found {
            l.clear();
        }
        let bonds = &*body.lattice.bonds;
        let (crit, no_fail) = (&*self.criterion, &self.no_fail);
        if let Some(list) = self.found.first_mut() {
            // Ascending spring order is (lower end, upper end) order: the order of `decide`.
            for &b in &hot {
                let b = b as usize;
                let [i, j] = bonds.ends[b].map(|v| v as usize);
                if !state.alive()[b] || no_fail[i] || no_fail[j] {
                    continue;
                }
                if let Some(w) = new_weight(crit, body, state, b, i, j) {
                    list.push((b as u32, w));
                }
            }
        }
        self.hot = hot;
        let report = self.commit(body, state, Some(&mut *it));
        it.add_released(report.released);
        self.last = report;
    }
}

/// `q/2 Pi_n^2 / S_n` of node n over its intact springs (J).
pub fn node_dispersive_energy(body: &Body, state: &State, n: usize) -> Real {
    shifted_dispersive_energy(body, state, 0.0, n)
}

/// Extension of spring (i, j) at the displacements `u - h v`.
fn shifted_extension(body: &Body, state: &State, h: Real, i: usize, j: usize, rest: Real) -> Real {
    if h == 0.0 {
        return spring_geometry(&body.lattice, &state.u, i, j, rest).dl;
    }
    let d = body.lattice.reference_vector(i, j);
    let (u, v) = (&state.u, &state.v);
    let w = [
        (u.x()[j] - h * v.x()[j]) - (u.x()[i] - h * v.x()[i]),
        (u.y()[j] - h * v.y()[j]) - (u.y()[i] - h * v.y()[i]),
        (u.z()[j] - h * v.z()[j]) - (u.z()[i] - h * v.z()[i]),
    ];
    let x = [d[0] + w[0], d[1] + w[1], d[2] + w[2]];
    let l = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    (2.0 * (d[0] * w[0] + d[1] * w[1] + d[2] * w[2]) + (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]))
        / (l + rest)
}

/// `q/2 Pi_n^2 / S_n` of node n at the displacements `u - h v`.
fn shifted_dispersive_energy(body: &Body, state: &State, h: Real, n: usize) -> Real {
    let s = state.norm()[n];
    if body.q == 0.0 || s <= 0.0 {
        return 0.0;
    }
    let bonds = &*body.lattice.bonds;
    let (k, lever) = (state.springs(body).k, body.levers());
    let mut pi = 0.0;
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        if state.alive()[b] {
            let rest = body.lattice.rest(b);
            pi += k[b]
                * lever.get(b)
                * shifted_extension(body, state, h, n, bonds.neighbour(n, e), rest);
        }
    }
    0.5 * body.q * pi * pi / s
}
