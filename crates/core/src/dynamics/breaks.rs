//! Decide, then commit: how springs break inside a run.
//!
//! A [`Breaker`] (fracture, `hooke-fracture`) gets a narrow, read-only view: the state and the
//! springs worth a look. It returns its decisions, `(spring, new damage weight)` pairs with
//! weight 0 for a break, and changes nothing. The integrator commits them: it trades the
//! decisions between the ranks of a shared run, changes the springs in the state and the
//! kernel, repairs sweep 1's pools and books the energy the changes release in the ledger.
//! The breaker never sees the integrator, the team or a piece; the integrator never sees a
//! criterion.
//!
//! The released energy `R(u) = U_before(u) - U_after(u)` is exact at the current displacements
//! (paper eq. 9 with the intact springs' `k_s`, the pools `Pi_n` and normalisers `S_n` before
//! and after): a broken spring gives up its direct energy `k dL^2 / 2` and changes its nodes'
//! pools; a softened one (weight `w -> w'`) gives up `(w - w') k dL^2 / 2` and changes its
//! nodes' pools and normalisers. Only the decided springs and their ends' dispersive terms
//! change, so R is summed over those. In a run the springs change between two steps, and
//! leapfrog's discrete energy identity charges the mean of R at the two positions that share
//! the step, `u(t)` and `u(t - dt) = u(t) - dt v(t - dt/2)`: booking `R(u(t))` alone would
//! leave an O(dt) error per event in the balance. Without an integrator (a static solver's
//! breaking rounds, [`commit_alone`]) R(u) is booked.

use std::ops::Range;

use crate::body::Body;
use crate::law::spring_geometry;
use crate::math::Real;
use crate::state::State;

use super::partition::Shared;
use super::{Integrator, Pools};

/// What one round of decisions did.
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

/// Which springs a [`Breaker`] looks at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Candidates<'a> {
    /// Those sweep 1's screen flagged as possibly past it (ascending, each once; broken ones
    /// included).
    Hot(&'a [u32]),
    /// Every spring, each from its lower end's row.
    Rows,
}

/// Decides which springs break or soften (fracture, `hooke-fracture`).
///
/// A step with a breaker ([`Integrator::step_breaking`]) runs sweep 1 with the breaker's screen,
/// asks the breaker for its decisions at the step's start state, commits them, brings sweep 1's
/// results in line, then computes the forces. That is the same state and the same bits as
/// deciding after the previous step and then stepping, without a pass of its own over all
/// springs: the screen costs a compare per spring inside sweep 1, which has each extension at
/// hand. A breaker without a screen is asked after the step ([`Integrator::break_now`]).
pub trait Breaker {
    /// Screen stretch s: the breaker never breaks a spring with `dL <= s L` (the integrator
    /// widens it by a margin far above round-off before the kernel compares). Infinity: no
    /// screen.
    fn screen(&self) -> Real;
    /// Decide, changing nothing, which of the `candidates` whose lower end is in `nodes` change
    /// now: push `(spring, new damage weight)` to `out` (0: the spring breaks), ascending by
    /// lower end and within a lower end in row order, so that every process that decides a
    /// range of nodes lists its part of one process's list. Intact springs only. Deciding
    /// again at the same state must add nothing (the integrator settles before output).
    fn decide(
        &mut self,
        body: &Body,
        state: &State,
        candidates: Candidates<'_>,
        nodes: Range<usize>,
        out: &mut Vec<(u32, Real)>,
    );
}

/// What committing breaks keeps between rounds (no allocation once grown).
#[derive(Debug, Default)]
pub(super) struct BreakScratch {
    /// The springs sweep 1's screen flagged.
    hot: Vec<u32>,
    /// The breaker's decisions (this process's, then every rank's).
    decided: Vec<(u32, Real)>,
    /// The decided springs' ends.
    touched: Vec<u32>,
    /// The nodes the released energy reads (the touched ones and their neighbours).
    reads: Vec<u32>,
    /// On a piece: the decisions in the body's numbering, `(spring, weight, ends)`.
    global: Vec<(u32, Real, [u32; 2])>,
}

impl Integrator {
    /// One step that breaks springs at its start ([`Breaker`]), with an optional interaction.
    /// Returns what broke.
    pub fn step_breaking(
        &mut self,
        body: &Body,
        state: &mut State,
        interaction: Option<&mut dyn super::Interaction>,
        breaker: &mut dyn Breaker,
    ) -> BreakReport {
        self.step_full(body, state, interaction, Some(breaker))
    }

    /// Commit now the decisions a screened breaker would take at the start of the next step,
    /// without stepping (before writing a frame or a checkpoint, so that they show the springs
    /// the next step would break at its start). Deciding is idempotent, so settling never
    /// changes a run.
    pub fn settle(
        &mut self,
        body: &Body,
        state: &mut State,
        breaker: &mut dyn Breaker,
    ) -> BreakReport {
        self.sync(body, state);
        self.killed.clear();
        self.break_at_start(body, state, breaker).1
    }

    /// Ask `breaker` to decide over every spring at the current state, and commit its decisions
    /// (a breaker without a screen, after each step or every few). In a shared run each rank
    /// decides the springs of its own nodes, which a step has left current with their ghosts,
    /// and the ranks trade the decisions: every rank commits one process's decisions in its
    /// order. Collective.
    pub fn break_now(
        &mut self,
        body: &Body,
        state: &mut State,
        breaker: &mut dyn Breaker,
    ) -> BreakReport {
        let nodes = self.partition.own(body.nodes());
        let mut decided = std::mem::take(&mut self.breaks.decided);
        decided.clear();
        breaker.decide(body, state, Candidates::Rows, nodes, &mut decided);
        let report = self.commit(body, state, &mut decided, false);
        self.breaks.decided = decided;
        report
    }

    /// Screened sweep 1, the breaker's decisions committed, and sweep 1's results repaired for
    /// them. Returns false (first) if the pools still have to be computed (springs changed
    /// behind the integrator's back), and what broke.
    pub(super) fn break_at_start(
        &mut self,
        body: &Body,
        state: &mut State,
        b: &mut dyn Breaker,
    ) -> (bool, BreakReport) {
        let s = b.screen();
        let screen = if s.is_finite() {
            s - 1e-9 * s.abs() - 1e-12
        } else {
            s
        };
        self.pools_everywhere(body, state, screen);
        let pieced = self.piece().is_some();
        let mut hot = std::mem::take(&mut self.breaks.hot);
        self.kernel.hot_springs(body, state, &mut hot);
        if self.partition.is_shared() && !pieced && state.hot.iter().any(|&h| h) {
            // Every rank decides every flagged spring, and reads both of its ends, wherever
            // they are.
            self.current_at_ends(body, state, &hot, true, Pools::IfStale);
        }
        // On a piece the springs of its own rows are decided (every spring past the screen
        // is flagged in its lower end's row), each rank those whose lower end it owns.
        let nodes = match self.piece() {
            Some(p) => p.own.clone(),
            None => 0..body.nodes(),
        };
        let mut decided = std::mem::take(&mut self.breaks.decided);
        decided.clear();
        b.decide(body, state, Candidates::Hot(&hot), nodes, &mut decided);
        self.breaks.hot = hot;
        let report = self.commit(body, state, &mut decided, true);
        self.breaks.decided = decided;
        if self.synced != state.breaks() {
            self.sync(body, state);
            return (false, report);
        }
        let killed = std::mem::take(&mut self.killed);
        self.kernel.repair_shared(
            body,
            state,
            &killed,
            self.partition.shared().map(Shared::sweeps),
        );
        if pieced {
            // On pieces the owners' repaired pools reach the ghosts through the halo, on
            // every rank alike when any rank's springs changed.
            let t = self.partition.shared_mut().expect("shared");
            if std::mem::take(&mut t.broke) {
                t.trade(&mut [&mut state.pool[..]]);
            }
        } else if !killed.is_empty() {
            // Only a broken spring's ends change their pools, and only their owners hold
            // what those pools read: every rank takes them from the owners (the rest of its
            // pools, its ghosts' from this step's trade, stand).
            self.current_at_ends(body, state, &killed, false, Pools::Repaired);
        }
        self.killed = killed;
        (true, report)
    }

    /// Commit a breaker's decisions (`everyone`: every rank holds every rank's already; else
    /// each holds its own, which are traded first) and book the released energy. Collective.
    fn commit(
        &mut self,
        body: &Body,
        state: &mut State,
        decided: &mut Vec<(u32, Real)>,
        everyone: bool,
    ) -> BreakReport {
        let report = if self.piece().is_some() {
            self.commit_piece(body, state, decided)
        } else {
            if !everyone {
                self.gather_pairs(decided);
            }
            self.commit_whole(body, state, decided)
        };
        self.ledger.released += report.released;
        report
    }

    /// The commit of a lone or shared (uncut) run: every rank changes the same springs in the
    /// same order and computes the same released energy.
    fn commit_whole(
        &mut self,
        body: &Body,
        state: &mut State,
        decided: &[(u32, Real)],
    ) -> BreakReport {
        if decided.is_empty() {
            return BreakReport::default();
        }
        let bonds = &*body.lattice.bonds;
        let mut touched = std::mem::take(&mut self.breaks.touched);
        touched_nodes(body, decided, &mut touched);
        if self.partition.is_shared() {
            // The released energy reads the touched nodes and their neighbours, displacements
            // and velocities (a shared run keeps only its own and its ghosts' state current
            // between outputs): those are taken from their owners, not the whole state.
            let mut reads = std::mem::take(&mut self.breaks.reads);
            reads.clear();
            for &n in &touched {
                let n = n as usize;
                reads.push(n as u32);
                reads.extend(bonds.row(n).map(|e| bonds.neighbour(n, e) as u32));
            }
            reads.sort_unstable();
            reads.dedup();
            self.current_at(state, &reads, true, Pools::IfStale, true);
            self.breaks.reads = reads;
        }
        let shifts = [0.0, self.dt];
        let report = apply(
            body,
            state,
            decided,
            &touched,
            &shifts,
            &mut |state, b, w| self.soften_spring(body, state, b, w),
        );
        self.breaks.touched = touched;
        report
    }

    /// The commit on a rank's piece: the ranks' decisions gathered, and each rank's piece's
    /// springs among them changed. The released energy has one process's terms and order: a
    /// spring's direct energy is computed by the owner of its lower end, a touched node's
    /// dispersive energy by its owner (both read the velocities of the node's neighbours,
    /// traded first), the terms are all-gathered and every rank adds them as
    /// [`Integrator::commit_whole`] does. Collective.
    fn commit_piece(
        &mut self,
        body: &Body,
        state: &mut State,
        decided: &[(u32, Real)],
    ) -> BreakReport {
        let mut global = std::mem::take(&mut self.breaks.global);
        global.clear();
        {
            let piece = self.piece().expect("a piece");
            let bonds = &*body.lattice.bonds;
            global.extend(decided.iter().map(|&(b, w)| {
                let ends = bonds.ends[b as usize].map(|n| piece.global[n as usize]);
                (piece.springs[b as usize], w, ends)
            }));
        }
        self.gather_decisions(&mut global);
        let report = if global.is_empty() {
            BreakReport::default()
        } else {
            self.trade_velocities(state);
            self.commit_gathered(body, state, &global)
        };
        self.breaks.global = global;
        report
    }

    /// [`Integrator::commit_piece`] once every rank holds every rank's decisions (`decided`,
    /// in the body's numbering, ascending).
    fn commit_gathered(
        &mut self,
        body: &Body,
        state: &mut State,
        decided: &[(u32, Real, [u32; 2])],
    ) -> BreakReport {
        let dt = self.dt;
        let share = self.share().expect("shared").nodes.clone();
        let piece = self.piece().expect("a piece");
        let own = piece.first..piece.first + piece.own.len();
        let mut touched: Vec<u32> = decided.iter().flat_map(|d| d.2).collect();
        touched.sort_unstable();
        touched.dedup();
        // Each rank's entries and touched nodes are runs of the lists (both ascending by the
        // lower end, or the node, in the body): its slots are laid out in rank order.
        let runs = |r: &Range<usize>| {
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
        let springs: Vec<usize> = decided[mine_e]
            .iter()
            .map(|d| piece.springs.binary_search(&d.0).expect("an owned spring"))
            .collect();
        let nodes: Vec<usize> = touched[mine_n]
            .iter()
            .map(|&n| piece.local(n as usize).expect("an owned node"))
            .collect();
        // Every rank changes the decided springs its piece holds.
        let changes: Vec<(usize, Real)> = decided
            .iter()
            .filter_map(|d| piece.springs.binary_search(&d.0).ok().map(|b| (b, d.1)))
            .collect();
        let slot = parts[self.team().expect("shared").rank()].start;
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
            self.soften_spring(body, state, b, w);
        }
        terms(state, &mut values[mine], true);
        self.team().expect("shared").gather(&mut values, &parts);
        // The sums of `commit_whole`: the springs' terms in spring order, then the nodes' in
        // node order, rank after rank being both orders.
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
        BreakReport {
            broken,
            softened: decided.len() - broken,
            released,
        }
    }

    /// All-gather a shared (uncut) run's decisions, each rank's for the springs whose lower end
    /// it owns: on return every rank holds every rank's, in rank order, which is one process's
    /// order. Two all-gathers (the count, then the pairs; a spring index is exact as a `Real`).
    fn gather_pairs(&mut self, decided: &mut Vec<(u32, Real)>) {
        let Some(t) = self.partition.shared_mut() else {
            return;
        };
        let mut mine = std::mem::take(&mut t.springs_flat);
        mine.clear();
        mine.extend(decided.iter().flat_map(|&(b, w)| [b as Real, w]));
        crate::team::gather_runs(&*t.team, &mine, &mut t.listed, &mut t.listed_parts);
        t.springs_flat = mine;
        decided.clear();
        decided.extend(t.listed.chunks_exact(2).map(|p| (p[0] as u32, p[1])));
    }

    /// On a piece: all-gather the decisions, `(spring, new weight, [lower end, upper end])`
    /// with the body's indices, each rank's for the springs whose lower end it owns, ascending.
    /// On return every rank holds every rank's, in rank order, which is ascending spring order:
    /// one process's decisions in its order. Two all-gathers (the counts, then the entries;
    /// indices are exact as reals). Collective.
    fn gather_decisions(&mut self, list: &mut Vec<(u32, Real, [u32; 2])>) {
        let Some(t) = self.partition.shared_mut().filter(|t| t.piece.is_some()) else {
            return;
        };
        let mut mine = std::mem::take(&mut t.springs_flat);
        mine.clear();
        mine.extend(
            list.iter()
                .flat_map(|&(b, w, [i, j])| [b as Real, w, i as Real, j as Real]),
        );
        crate::team::gather_runs(&*t.team, &mine, &mut t.listed, &mut t.listed_parts);
        t.springs_flat = mine;
        t.broke = !t.listed.is_empty();
        list.clear();
        list.extend(
            t.listed
                .chunks_exact(4)
                .map(|e| (e[0] as u32, e[1], [e[2] as u32, e[3] as u32])),
        );
    }

    /// On a piece: the ghosts' velocities from their owners, through the halo (what the
    /// released energy of breaks reads at a touched node's neighbours). Collective.
    fn trade_velocities(&mut self, state: &mut State) {
        let dims = if self.plane { 2 } else { 3 };
        if let Some(t) = self.partition.shared_mut().filter(|t| t.piece.is_some()) {
            let mut v = state.v.xyz_mut();
            t.trade(&mut v[..dims]);
        }
    }
}

/// Commit `decided` (`(spring, new weight)`, 0: broken) in a state with no integrator (a static
/// solver's breaking rounds), returning what changed with the exact `R(u)` (see the module's
/// docs). `touched` is scratch.
pub fn commit_alone(
    body: &Body,
    state: &mut State,
    decided: &[(u32, Real)],
    touched: &mut Vec<u32>,
) -> BreakReport {
    if decided.is_empty() {
        return BreakReport::default();
    }
    touched_nodes(body, decided, touched);
    apply(body, state, decided, touched, &[0.0], &mut |state, b, w| {
        state.soften(body, b, w)
    })
}

/// The decided springs' ends, ascending, each once, into `out`.
fn touched_nodes(body: &Body, decided: &[(u32, Real)], out: &mut Vec<u32>) {
    let bonds = &*body.lattice.bonds;
    out.clear();
    out.extend(decided.iter().flat_map(|&(b, _)| bonds.ends[b as usize]));
    out.sort_unstable();
    out.dedup();
}

/// Change the decided springs through `change` (in list order; true if the spring changed),
/// with the released energy the mean of `R(u - h v)` over `shifts` h.
fn apply(
    body: &Body,
    state: &mut State,
    decided: &[(u32, Real)],
    touched: &[u32],
    shifts: &[Real],
    change: &mut dyn FnMut(&mut State, usize, Real) -> bool,
) -> BreakReport {
    let bonds = &*body.lattice.bonds;
    let energy = |state: &State, h: Real| {
        let k = state.springs(body).k;
        let mut e = 0.0;
        for &(b, _) in decided {
            let b = b as usize;
            if state.alive()[b] {
                let [i, j] = bonds.ends[b].map(|v| v as usize);
                let dl = shifted_extension(body, state, h, i, j, body.lattice.rest(b));
                e += 0.5 * k[b] * dl * dl;
            }
        }
        e + touched
            .iter()
            .map(|&n| shifted_dispersive_energy(body, state, h, n as usize))
            .sum::<Real>()
    };
    let mut before = [0.0; 2];
    for (k, &h) in shifts.iter().enumerate() {
        before[k] = energy(state, h);
    }
    let (mut broken, mut softened) = (0, 0);
    for &(b, w) in decided {
        let b = b as usize;
        let changed = change(state, b, w);
        if changed && !state.alive()[b] {
            broken += 1;
        } else if changed {
            softened += 1;
        }
    }
    let mut released = 0.0;
    for (k, &h) in shifts.iter().enumerate() {
        let after = energy(state, h);
        released += (before[k] - after) / shifts.len() as Real;
    }
    BreakReport {
        broken,
        softened,
        released,
    }
}

/// `q/2 Pi_n^2 / S_n` of node n over its intact springs (J): its term of eq. 9.
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
    if body.q == 0.0 || s == 0.0 {
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
