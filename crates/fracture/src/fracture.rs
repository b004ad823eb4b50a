//! Deciding and committing breaks.

use rayon::prelude::*;

use hooke_core::dynamics::{commit_alone, Breaker, Candidates, Integrator, Interaction};
use hooke_core::kernel::CHUNK;
use hooke_core::law::spring_geometry;
use hooke_core::{Body, Real, State};

pub use hooke_core::dynamics::{node_dispersive_energy, BreakReport};

use crate::criterion::{Criterion, SpringState};
use crate::error::FractureError;
use crate::precrack::{springs_crossing, Crack};

/// Bond breaking for one body.
#[derive(Debug)]
pub struct Fracture {
    criterion: Box<dyn Criterion>,
    /// Nodes whose springs never break (near loading boundaries).
    no_fail: Vec<bool>,
    /// Springs each node had at set-up (for damage).
    initial: Vec<u32>,
    /// Each spring's strength factor ([`Fracture::with_strength`]), and the least of them;
    /// `None`: every spring's is 1.
    strength: Option<(Vec<Real>, Real)>,
    /// Per-chunk lists of springs that fail or soften, with their new damage weight (0:
    /// broken), reused between checks.
    found: Vec<Vec<(u32, Real)>>,
    /// Scratch: the decisions of a static solver's round, and the nodes they touch.
    decided: Vec<(u32, Real)>,
    touched: Vec<u32>,
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
            strength: None,
            decided: Vec::new(),
            touched: Vec::new(),
            broken_total: 0,
            softened_total: 0,
            released_total: 0.0,
        }
    }

    /// Give each spring `s` its own strength factor `f_s` ([`SpringState::strength`]: the
    /// stretches at which the criterion acts are `f_s` times its own for that spring): a
    /// material's or an interface's strength against the criterion's, or a random draw
    /// (Weibull). Refused where the count is not the body's springs or a factor is not
    /// positive and finite. The screened step then flags a block where a spring passes the
    /// criterion's screen times the least factor, so the decisions stay those of a check of
    /// every spring.
    pub fn with_strength(mut self, body: &Body, factor: Vec<Real>) -> Result<Self, FractureError> {
        if factor.len() != body.lattice.bonds.len() {
            return Err(FractureError::BadParameter {
                what: "the springs' strength factors (one per spring)",
                value: factor.len() as Real,
                fix: "give one factor per spring of the body",
            });
        }
        if let Some(&f) = factor.iter().find(|&&f| !(f.is_finite() && f > 0.0)) {
            return Err(FractureError::BadParameter {
                what: "a spring's strength factor",
                value: f,
                fix: "give positive, finite factors",
            });
        }
        let least = factor.iter().fold(Real::INFINITY, |m, &f| m.min(f));
        self.strength = Some((factor, least));
        Ok(self)
    }

    /// Each spring's strength factor, if the springs have their own ([`Fracture::with_strength`]).
    pub fn strength(&self) -> Option<&[Real]> {
        self.strength.as_ref().map(|(f, _)| &f[..])
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
        // The piece's springs are the body's `piece.springs`, in the body's order.
        if let Some((f, least)) = self.strength.take() {
            let mine: Vec<Real> = piece.springs.iter().map(|&b| f[b as usize]).collect();
            self.strength = Some((mine, least));
        }
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
    /// critical stretch), the decisions are taken inside the step: sweep 1 flags the blocks
    /// holding a spring past the screen, the criterion looks at those springs only, and the
    /// integrator commits the breaks before the forces, at the step's start state. That is the
    /// state, the decisions and the bits of [`Fracture::check`] after the previous step, without
    /// its pass over every spring. Other criteria: the step, then [`Fracture::check`]. Returns
    /// what broke.
    pub fn step(
        &mut self,
        body: &Body,
        state: &mut State,
        integrator: &mut Integrator,
        interaction: Option<&mut dyn Interaction>,
    ) -> BreakReport {
        if self.criterion.screen().is_some() {
            let report = integrator.step_breaking(body, state, interaction, self);
            self.count(report)
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
        let report = integrator.settle(body, state, self);
        self.count(report)
    }

    /// Decide which intact springs fail in the current state, and have `integrator` commit
    /// them: they leave the state and the kernel's copy, and the energy ledger is told what
    /// they released ([`Integrator::break_now`]). Call after each step (or every few steps).
    /// The pool ratios the criterion sees are those of the step's force evaluation. In a
    /// shared run each rank decides its own nodes' springs, so call it where a step has left
    /// every rank's nodes and ghosts current: after a step, as [`Fracture::step`] does.
    pub fn check(
        &mut self,
        body: &Body,
        state: &mut State,
        integrator: &mut Integrator,
    ) -> BreakReport {
        let report = integrator.break_now(body, state, self);
        self.count(report)
    }

    /// Decide and commit breaks in a state that no integrator steps (a static solver's
    /// breaking rounds): the released energy is the exact `R(u)` at the current displacements
    /// ([`hooke_core::dynamics::commit_alone`]).
    pub fn break_alone(&mut self, body: &Body, state: &mut State) -> BreakReport {
        let mut decided = std::mem::take(&mut self.decided);
        decided.clear();
        self.decide(body, state, Candidates::Rows, 0..body.nodes(), &mut decided);
        let report = commit_alone(body, state, &decided, &mut self.touched);
        self.decided = decided;
        self.count(report)
    }

    /// Add a round's report to the totals, and return it.
    fn count(&mut self, report: BreakReport) -> BreakReport {
        self.broken_total += report.broken;
        self.softened_total += report.softened;
        self.released_total += report.released;
        report
    }

    /// The springs whose lower end is in `nodes` (whole chunks) that the criterion changes, in
    /// the per-chunk lists (no state changes; parallel, each chunk's list in row order).
    fn decide_rows(&mut self, body: &Body, state: &State, nodes: std::ops::Range<usize>) {
        let bonds = &*body.lattice.bonds;
        let (crit, no_fail) = (&*self.criterion, &self.no_fail);
        let strength = self.strength.as_ref().map(|(f, _)| &f[..]);
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
                    if let Some(w) = new_weight(crit, strength, body, state, b, i, j) {
                        list.push((b as u32, w));
                    }
                }
            }
        });
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
    strength: Option<&[Real]>,
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
            strength: strength.map_or(1.0, |f| f[b]),
        },
        w,
    );
    (next < w).then_some(next.max(0.0))
}

/// The decisions, taken inside a step for a screened criterion (see [`Fracture::step`]), after
/// it for the others ([`Fracture::check`]).
impl Breaker for Fracture {
    fn screen(&self) -> Real {
        // (Times 1 is exact: without factors the screen keeps its bits.)
        let least = self.strength.as_ref().map_or(1.0, |&(_, least)| least);
        self.criterion
            .screen()
            .map_or(Real::INFINITY, |s| s * least)
    }

    fn decide(
        &mut self,
        body: &Body,
        state: &State,
        candidates: Candidates<'_>,
        nodes: std::ops::Range<usize>,
        out: &mut Vec<(u32, Real)>,
    ) {
        let Candidates::Hot(hot) = candidates else {
            self.decide_rows(body, state, nodes);
            for list in &self.found {
                out.extend_from_slice(list);
            }
            return;
        };
        let bonds = &*body.lattice.bonds;
        let (crit, no_fail) = (&*self.criterion, &self.no_fail);
        let strength = self.strength.as_ref().map(|(f, _)| &f[..]);
        // Ascending spring order is (lower end, upper end) order: the order of the rows.
        for &b in hot {
            let b = b as usize;
            let [i, j] = bonds.ends[b].map(|v| v as usize);
            if !nodes.contains(&i) || !state.alive()[b] || no_fail[i] || no_fail[j] {
                continue;
            }
            if let Some(w) = new_weight(crit, strength, body, state, b, i, j) {
                out.push((b as u32, w));
            }
        }
    }
}
