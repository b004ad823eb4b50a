//! The partition of a run between processes: the one seam where MPI (or any [`Team`]) meets
//! the explicit step.
//!
//! An integrator runs alone, or shares its steps with a team ([`Integrator::distribute`]): each
//! rank sweeps its share of the nodes and trades what its neighbours read (the halo), and the
//! partial sums travel in chunk order, so every rank computes one process's bits. A rank may
//! also hold only its piece of the body ([`Integrator::cut`], [`Integrator::on_piece`]).
//! Everything that knows about ranks lives here; the step ([`Integrator::step`], in the parent
//! module) calls the operations below, each of which does nothing alone:
//!
//! - [`Integrator::pools_everywhere`] and [`Integrator::sweep_everywhere`]: the two sweeps on
//!   this process's share, with the halo trades and the partial sums' all-gather;
//! - [`Integrator::contact_reads_current`] and [`Integrator::swept_velocities_current`]: the
//!   few nodes' state that contact and the bookkeeping read, from their owners;
//! - [`Integrator::gather_state`] and friends: the whole state, or some nodes', for readers
//!   of the whole (output, checks, breaking).

use rayon::prelude::*;

use crate::body::Body;
use crate::error::{Error, Result};
use crate::kernel::{Kernel, StepParams};
use crate::law;
use crate::loading::Loading;
use crate::math::{Coords, Real};
use crate::stability::{self, StableStep};
use crate::state::State;
use crate::team::{Piece, Share, Team};

use super::{chunk_node_sums, EnergyBalance, Interaction, Reads};
use super::{estimate, new_displacements, step_size, Integrator, IntegratorOptions, UNSTABLE_HINT};

/// Which pools a gather from their owners takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pools {
    No,
    /// Those the integrator has marked stale (after a sweep's trade).
    IfStale,
    /// Always: a repair after breaks changed them on their owners only.
    Repaired,
}

/// How an integrator's work is split between processes. Running alone is the trivial case:
/// every operation of this module then does nothing, and the step reads as one process's.
#[derive(Debug, Default)]
pub(super) enum Partition {
    /// One process does all.
    #[default]
    Alone,
    /// A team shares the sweeps ([`Integrator::distribute`]); this process's share, and its
    /// piece where it holds only that ([`Integrator::cut`]).
    Shared(Box<Shared>),
}

impl Partition {
    /// The team's state, where a team shares the run.
    pub(super) fn shared(&self) -> Option<&Shared> {
        match self {
            Partition::Alone => None,
            Partition::Shared(t) => Some(t),
        }
    }

    pub(super) fn shared_mut(&mut self) -> Option<&mut Shared> {
        match self {
            Partition::Alone => None,
            Partition::Shared(t) => Some(t),
        }
    }

    pub(super) fn is_shared(&self) -> bool {
        matches!(self, Partition::Shared(_))
    }

    /// Whether this process holds only its piece of the body.
    pub(super) fn is_pieced(&self) -> bool {
        self.pieced().is_some()
    }

    /// The team and the piece, where this process holds only its piece.
    pub(super) fn pieced(&self) -> Option<(&Shared, &Pieced)> {
        self.shared()
            .and_then(|t| t.piece.as_deref().map(|p| (t, p)))
    }

    /// The nodes this process's kernel sweeps, in what it holds (`None`: every node).
    pub(super) fn swept(&self) -> Option<std::ops::Range<usize>> {
        self.shared().map(|t| t.sweeps().mine())
    }

    /// The nodes this process owns, in what it holds: its piece's own nodes, its share of the
    /// body, or all `n` alone.
    pub(super) fn own(&self, n: usize) -> std::ops::Range<usize> {
        match (self.shared(), self.pieced()) {
            (_, Some((_, p))) => p.piece.own.clone(),
            (Some(t), None) => t.share.mine(),
            (None, None) => 0..n,
        }
    }

    /// One rank's part of a frame of the whole body (`None` alone, or on a piece, whose frame
    /// is [`Integrator::piece_fields`]).
    pub(super) fn frame_part(&self) -> Option<law::FramePart<'_>> {
        self.shared().map(|t| law::FramePart {
            team: &*t.team,
            share: &t.share,
        })
    }
}

/// The split an integrator is set up on, before it exists: alone, or this member's share of a
/// team's, found once. The set-up reads it where the split matters (the kernel's rows, the
/// stable-step estimate's shared sweeps) and ends by turning it into the [`Partition`].
pub(super) enum Plan {
    Alone,
    Shared {
        team: std::sync::Arc<dyn Team>,
        share: Share,
    },
}

impl Plan {
    /// Alone without a team or with a team of one; else this member's share of `body` (the
    /// loaded and prescribed nodes of `loading`, which the steps' bookkeeping reads, traded
    /// with the halo).
    pub(super) fn new(
        body: &Body,
        loading: &Loading,
        team: Option<std::sync::Arc<dyn Team>>,
    ) -> Plan {
        match team.filter(|t| t.size() > 1) {
            None => Plan::Alone,
            Some(team) => {
                let share = Share::new(body, team.size(), team.rank(), &special_nodes(loading));
                Plan::Shared { team, share }
            }
        }
    }

    /// The nodes this member's kernel sweeps (`None`: every node).
    pub(super) fn swept(&self) -> Option<std::ops::Range<usize>> {
        match self {
            Plan::Alone => None,
            Plan::Shared { share, .. } => Some(share.mine()),
        }
    }

    /// The stable-step estimate's split of its sweeps (`None` alone).
    pub(super) fn split(&self) -> Option<stability::Split<'_>> {
        match self {
            Plan::Alone => None,
            Plan::Shared { team, share } => Some(stability::Split::new(&**team, share)),
        }
    }

    /// Distribute `it` as planned (alone, nothing).
    pub(super) fn distribute(self, it: &mut Integrator, body: &Body) {
        if let Plan::Shared { team, share } = self {
            it.distribute_with(body, team, Some(share));
        }
    }
}

/// What a shared integrator keeps besides its share (see [`Integrator::distribute`]).
#[derive(Debug)]
pub(super) struct Shared {
    pub(super) team: std::sync::Arc<dyn Team>,
    pub(super) share: Share,
    /// Nodes whose velocities and forces the sparse bookkeeping reads (loaded and prescribed
    /// ones), ascending, so grouped by owner; `parts3` indexes their forces' three components
    /// per rank.
    pub(super) special: Vec<u32>,
    pub(super) parts3: Vec<std::ops::Range<usize>>,
    /// Index in `special` of each prescribed DOF's node.
    pub(super) dof_slot: Vec<usize>,
    /// The special nodes' forces at u(t), three components each.
    pub(super) forces: Vec<Real>,
    /// Messages of a halo trade, per rank (kept: a step allocates nothing).
    pub(super) out: Vec<Vec<Real>>,
    pub(super) inp: Vec<Vec<Real>>,
    /// Values and parts of an all-gather at listed nodes ([`Integrator::current_at`]) or of a
    /// list's runs (a breaker's decisions), and the nodes whose velocities a step's
    /// bookkeeping reads.
    pub(super) listed: Vec<Real>,
    pub(super) listed_parts: Vec<std::ops::Range<usize>>,
    pub(super) ends: Vec<u32>,
    /// Whether `state.u`, `state.pool` and `state.v` hold stale values at other ranks' nodes.
    /// A step makes current only what the next step reads: displacements and pools on this
    /// rank's nodes and its ghosts, velocities on its nodes and the special ones. Whatever
    /// reads the whole state first gathers the rest ([`Integrator::gather_state`]).
    pub(super) stale_u: bool,
    pub(super) stale_pool: bool,
    pub(super) v_partial: bool,
    /// Set once the rank holds only its piece of the body ([`Integrator::cut`]).
    pub(super) piece: Option<Box<Pieced>>,
    /// On pieces: a breaker's gathered decisions changed springs somewhere, so the repaired
    /// pools are traded; and this rank's decisions as they travel.
    pub(super) broke: bool,
    pub(super) springs_flat: Vec<Real>,
}

/// What an integrator that steps a rank's piece keeps (see [`Integrator::cut`]). Its `Shared`
/// keeps the share in the body's numbering: which rank owns which nodes and chunks.
#[derive(Debug)]
pub(super) struct Pieced {
    pub(super) piece: Piece,
    /// The piece's own share, in its numbering: what its kernel sweeps.
    pub(super) sweeps: Share,
    /// The partial sums of every chunk of the body, for their all-gather.
    pub(super) partials: Vec<crate::kernel::SweepSums>,
}

/// The checks of a piece's inputs (body, loading, damping), on every rank before the first
/// collective, refused on all alike: a rank returning alone would leave the others waiting.
fn refuse_together(
    body: &Body,
    loading: &Loading,
    opts: &IntegratorOptions,
    team: &dyn Team,
) -> Result<()> {
    let checked = body
        .validate()
        .and_then(|_| loading.validate(body.nodes()))
        .and_then(|_| {
            if opts.damping.is_finite() && opts.damping >= 0.0 {
                Ok(())
            } else {
                Err(Error::OutOfRange {
                    what: "damping coefficient c (1/s)",
                    value: opts.damping,
                    why: "it must be zero or positive".into(),
                })
            }
        });
    let mut failed = [checked.is_err()];
    team.any(&mut failed);
    checked?;
    if failed[0] {
        return Err(Error::InvalidInput {
            what: "a piece set up from parts",
            why: "another process refused its piece (its message says why)".into(),
        });
    }
    Ok(())
}

/// The damage-proof step's bound over every rank's piece (collective).
fn damage_bound_over(body: &Body, q_bound: Real, team: &dyn Team) -> Real {
    // Ghosts' rows are partial and dummies have none, so their ratios are no larger than
    // their owners': the ranks' maxima's maximum is the body's.
    max_over(stability::damage_bound_with(body, q_bound), team)
}

/// The largest of every rank's `x` (collective; each rank's value gathered, the maximum the
/// same on all).
fn max_over(x: Real, team: &dyn Team) -> Real {
    let size = team.size();
    let mut all = vec![0.0; size];
    all[team.rank()] = x;
    let singles: Vec<_> = (0..size).map(|r| r..r + 1).collect();
    team.gather(&mut all, &singles);
    all.into_iter().fold(Real::NEG_INFINITY, Real::max)
}

/// The loaded and prescribed nodes of `loading`, ascending, each once: a shared run's
/// bookkeeping reads them on every rank.
pub(crate) fn special_nodes(loading: &Loading) -> Vec<usize> {
    let loaded = loading.loads.iter().flat_map(|l| &l.nodes);
    let prescribed = loading.prescribed.iter().flat_map(|p| &p.nodes);
    let mut special: Vec<usize> = loaded.chain(prescribed).map(|&i| i as usize).collect();
    special.sort_unstable();
    special.dedup();
    special
}

impl Shared {
    /// Send this rank's values of `fields` at the nodes its peers read and take theirs at its
    /// ghosts (one message per peer, a node's fields side by side).
    pub(super) fn trade(&mut self, fields: &mut [&mut [Real]]) {
        let halo = match &self.piece {
            Some(p) => &p.piece.halo,
            None => &self.share.halo,
        };
        crate::team::trade_halo(&*self.team, halo, &mut self.out, &mut self.inp, fields);
    }

    /// The share the kernel sweeps: the rank's in the body, or its piece's own.
    pub(super) fn sweeps(&self) -> &Share {
        match &self.piece {
            Some(p) => &p.sweeps,
            None => &self.share,
        }
    }

    /// The body's index of node `i` of what this rank holds.
    pub(super) fn global(&self, i: u32) -> usize {
        match &self.piece {
            Some(p) => p.piece.global[i as usize] as usize,
            None => i as usize,
        }
    }

    /// Three values at each loaded or prescribed node into `buf` (three per node, in
    /// `special`'s order), each from the node's owner, which gives it as `value(node)`: one
    /// all-gather.
    pub(super) fn gather_special(&self, buf: &mut Vec<Real>, value: impl Fn(usize) -> [Real; 3]) {
        buf.clear();
        buf.resize(3 * self.special.len(), 0.0);
        let mine = self.parts3[self.share.rank].clone();
        for k in mine.start / 3..mine.end / 3 {
            buf[3 * k..3 * k + 3].copy_from_slice(&value(self.special[k] as usize));
        }
        self.team.gather(buf, &self.parts3);
    }

    /// Take the loaded and prescribed nodes' forces in `state.f` from their owners (each
    /// rank's own are current): one all-gather, `buf` its scratch.
    pub(super) fn special_forces(&self, state: &mut State, buf: &mut Vec<Real>) {
        let f = &state.f;
        self.gather_special(buf, |i| [f.x()[i], f.y()[i], f.z()[i]]);
        for (k, &i) in self.special.iter().enumerate() {
            for c in 0..3 {
                state.f.comp_mut(c)[i as usize] = buf[3 * k + c];
            }
        }
    }

    /// A rank that steps its piece holds no whole state: what would read it (output,
    /// checkpoints, breaking, contact) is not supported on pieces yet, only the steps are.
    /// Reaching it is a caller's error ([`Integrator::cut`] says so).
    pub(super) fn whole(&self, what: &str) {
        assert!(
            self.piece.is_none(),
            "{what} reads the whole state, which a rank stepping its piece does not hold"
        );
    }
}

impl Integrator {
    /// Share the sweeps of every following step with the other members of `team` (each
    /// process then holds and runs the same simulation; see [`crate::team`]). Every member
    /// calls it, with the same body; a team of one changes nothing. Results stay the bits of
    /// one process.
    pub fn distribute(&mut self, body: &Body, team: std::sync::Arc<dyn Team>) {
        self.distribute_with(body, team, None);
    }

    /// [`Integrator::distribute`] with this rank's share if already found (for the same
    /// team, body and loading).
    pub(super) fn distribute_with(
        &mut self,
        body: &Body,
        team: std::sync::Arc<dyn Team>,
        share: Option<Share>,
    ) {
        self.partition = if team.size() > 1 {
            let special = special_nodes(&self.loading);
            let share =
                share.unwrap_or_else(|| Share::new(body, team.size(), team.rank(), &special));
            Partition::Shared(Box::new(self.shared(team, share, special)))
        } else {
            Partition::Alone
        };
        // From here on this rank sweeps its own nodes only.
        if let Some(t) = self.partition.shared() {
            self.kernel.keep_rows(t.share.mine());
        }
    }

    /// The team's state of a shared run over `share`, whose loaded and prescribed nodes are
    /// `special` (in the body's numbering).
    pub(super) fn shared(
        &self,
        team: std::sync::Arc<dyn Team>,
        share: Share,
        special: Vec<usize>,
    ) -> Shared {
        let parts3 = share
            .nodes
            .iter()
            .map(|r| {
                3 * special.partition_point(|&i| i < r.start)
                    ..3 * special.partition_point(|&i| i < r.end)
            })
            .collect();
        let dof_slot = self
            .dofs
            .iter()
            .map(|d| special.partition_point(|&i| i < d.node))
            .collect();
        let special: Vec<u32> = special.into_iter().map(|i| i as u32).collect();
        let size = team.size();
        Shared {
            team,
            share,
            forces: vec![0.0; 3 * special.len()],
            special,
            parts3,
            dof_slot,
            out: vec![Vec::new(); size],
            inp: vec![Vec::new(); size],
            listed: Vec::new(),
            listed_parts: Vec::new(),
            ends: Vec::new(),
            stale_u: false,
            stale_pool: false,
            v_partial: false,
            piece: None,
            broke: false,
            springs_flat: Vec::new(),
        }
    }

    /// Cut this rank's piece out of `body` and `state` ([`crate::team::Piece`]: its own nodes
    /// and its ghosts, renumbered in the body's order) and step only that from here on: the
    /// caller drops the whole body and state and passes the returned piece body and state to
    /// every following step. The steps keep the bits of one process at the rank's own nodes,
    /// and the energy ledger's sums are every rank's alike.
    ///
    /// This is the first part of a distributed-memory run, and only the steps and the blow-up
    /// check ([`Integrator::check_shared`], which names the bad node by its index in the body)
    /// are supported on pieces: breaking, contact, output frames and checkpoints read the whole
    /// state, and panic on a piece. Node indices in the returned body are the piece's
    /// ([`Integrator::piece`] maps them to the body's). The body must be one that its kernel
    /// sweeps by rows (a random lattice; not a box of a regular lattice, whose stencil kernel
    /// needs the whole box), the integrator distributed, and `state` current.
    pub fn cut(&mut self, body: &Body, state: &State) -> Result<(Body, State)> {
        let Some(t) = self.partition.shared_mut() else {
            return Err(Error::InvalidInput {
                what: "a piece of the body",
                why: "the integrator is not shared between processes: there is nothing to cut"
                    .into(),
            });
        };
        if t.piece.is_some() || t.stale_u || t.stale_pool || t.v_partial {
            return Err(Error::InvalidInput {
                what: "a piece of the body",
                why: "cut the body once, before the first step".into(),
            });
        }
        if matches!(self.kernel, Kernel::Cubic(_) | Kernel::Hex(_)) {
            return Err(Error::InvalidInput {
                what: "a piece of the body",
                why: format!(
                    "the {} kernel sweeps the whole box; pieces are cut from bodies swept by rows \
                     (random lattices)",
                    self.kernel.name()
                ),
            });
        }
        let (piece, piece_body) = Piece::cut(body, &t.share)?;
        let mut piece_state = piece.state(&piece_body, state);
        let local = |i: usize| {
            piece
                .local(i)
                .expect("every loaded or prescribed node is a ghost")
        };
        for l in &mut self.loading.loads {
            l.nodes
                .iter_mut()
                .for_each(|i| *i = local(*i as usize) as u32);
        }
        for p in &mut self.loading.prescribed {
            p.nodes
                .iter_mut()
                .for_each(|i| *i = local(*i as usize) as u32);
        }
        self.dofs.iter_mut().for_each(|d| d.node = local(d.node));
        self.loaded.iter_mut().for_each(|l| l.0 = local(l.0));
        t.special
            .iter_mut()
            .for_each(|i| *i = local(*i as usize) as u32);
        let sweeps = piece.share(&piece_body);
        self.attach(piece, &piece_body, &mut piece_state, sweeps, false);
        Ok((piece_body, piece_state))
    }

    /// An integrator for rank `team.rank()`'s piece of a body that no rank holds whole, as
    /// [`crate::team::parts::assemble`] sets it up (`share` its nodes per rank, in the body's
    /// numbering): the steps of [`Integrator::new`] followed by [`Integrator::cut`], bit for
    /// bit. `body` and `state` are the piece's (its dummies need a positive mass, as every
    /// node does: a body from the lattice's cells gives them the body's mean node volume's),
    /// `loading` in the piece's numbering; its loaded and prescribed nodes must be in every
    /// rank's piece ([`crate::team::parts::everyone`]).
    ///
    /// The body starts undeformed (every displacement zero, and every prescribed one at the
    /// start time), where pools, forces and strain energy are zero exactly; it may move
    /// (`state.v`, an initial velocity).
    ///
    /// The stable step is estimated on the pieces as one process estimates it on the body
    /// ([`stability::Split::for_piece`]: the same Lanczos iteration, bit for bit), so
    /// `TimeStep::Auto` gives one process's step.
    pub fn on_piece(
        body: &Body,
        state: &mut State,
        loading: Loading,
        piece: Piece,
        share: Share,
        team: std::sync::Arc<dyn Team>,
        opts: &IntegratorOptions,
    ) -> Result<Self> {
        refuse_together(body, &loading, opts, &*team)?;
        let deformed = |state: &State| {
            let mut d = [state.u.as_flat().iter().any(|&x| x != 0.0)];
            team.any(&mut d);
            d[0]
        };
        if deformed(state) {
            return Err(Error::InvalidInput {
                what: "a piece set up from parts",
                why: "it must start undeformed (displacements zero)".into(),
            });
        }
        let mut kernel = if opts.force_csr {
            Kernel::Csr { plain: false }
        } else {
            Kernel::for_body_in(body, state, Some(piece.own.clone()))
        };
        opts.choose_lanes(&mut kernel);
        // A piece holds some of the body's materials only: the bounds take the whole body's.
        let q_bound = max_over(body.q_bound(), &*team);
        let bound = damage_bound_over(body, q_bound, &*team);
        // The estimate on the piece, as `new_shared` makes it on the body: the piece's own
        // sweeps, its halo traded, the partial sums gathered in the body's chunks.
        let mut sweeps = piece.share(body);
        sweeps.halo = piece.halo.clone();
        let mut u_next = stability::drift_scratch(body, &kernel);
        let mut ones = Vec::new();
        let stable = {
            let mut split = stability::Split::for_piece(
                &*team,
                &sweeps,
                &share,
                &piece.global,
                piece.first,
                piece.total,
            );
            let s = estimate(
                body,
                state,
                &kernel,
                opts,
                (&mut u_next, &mut ones),
                (Some(&mut split), q_bound),
            );
            StableStep {
                lambda_bound: bound,
                ..s
            }
        };
        // The estimate's unit masses become the inverse masses, as in `new_shared`; the
        // sweeps trade the piece's halo, not the share's.
        ones.par_iter_mut()
            .with_min_len(1 << 14)
            .zip(&body.mass)
            .for_each(|(x, &m)| *x = 1.0 / m);
        let inv_mass = ones;
        sweeps.halo = crate::team::Halo::default();
        u_next.fill_zero();
        let dt = step_size(opts, &stable)?;
        let mut it = Self::assemble(body, loading, opts, kernel, dt, stable, (u_next, inv_mass));
        it.synced = state.breaks();
        let mut curved = [!Self::flat(state)];
        team.any(&mut curved);
        it.plane &= !curved[0];
        // Prescribed positions and velocities at the start, as `new_shared` sets them (every
        // rank holds every prescribed node).
        it.prescribe_start(state);
        if deformed(state) {
            return Err(Error::InvalidInput {
                what: "a piece set up from parts",
                why: "a prescribed displacement is not zero at the start: the body must start \
                      undeformed"
                    .into(),
            });
        }
        // Undeformed: pools, forces and strain energy are zero exactly.
        state.f.fill_zero();
        state.pool.fill(0.0);
        // The team's bookkeeping in the body's numbering, then the piece's.
        let special: Vec<usize> = special_nodes(&it.loading)
            .into_iter()
            .map(|i| piece.global[i] as usize)
            .collect();
        for d in &mut it.dofs {
            d.node = piece.global[d.node] as usize;
        }
        let mut shared = it.shared(team, share, special);
        for d in &mut it.dofs {
            d.node = piece.local(d.node).expect("a prescribed node of the piece");
        }
        for s in &mut shared.special {
            *s = piece
                .local(*s as usize)
                .expect("a special node of the piece") as u32;
        }
        it.partition = Partition::Shared(Box::new(shared));
        it.attach(piece, body, state, sweeps, true);
        // The energy at the start and the power there, summed as one process sums them.
        let v0 = state.v.clone();
        it.initial = it.node_sums(body, &v0)[0];
        it.initial_power = it.power(body, state, &v0);
        it.back_half_step(body, state);
        Ok(it)
    }

    /// Step `piece` from here on (the end of [`Integrator::cut`] and
    /// [`Integrator::on_piece`]): the piece's masses, kernel, scratch and partial sums.
    ///
    /// `sweeps` is the piece's own share ([`Piece::share`]); `built` says that the kernel, the
    /// masses and the drift scratch were made for the piece already (an integrator set up on
    /// it), not for the whole body.
    pub(super) fn attach(
        &mut self,
        piece: Piece,
        piece_body: &Body,
        piece_state: &mut State,
        sweeps: Share,
        built: bool,
    ) {
        if !built {
            self.inv_mass = piece_body.mass.iter().map(|&m| 1.0 / m).collect();
            if !self.u_next.is_empty() {
                self.u_next = Coords::zeros(piece_body.nodes());
            }
            let simd = self.kernel.simd();
            self.kernel = match self.kernel {
                Kernel::Csr { plain } => Kernel::Csr { plain },
                _ => Kernel::for_body_in(piece_body, piece_state, Some(sweeps.mine())),
            };
            self.kernel.set_simd(simd);
        }
        // Size the kernel's scratch now, so that no step allocates; the pools it computes at
        // the ghosts come from their partial rows, so the state's are kept.
        let pools = piece_state.pool.clone();
        self.kernel
            .pools_shared(piece_body, piece_state, Real::INFINITY, Some(&sweeps));
        piece_state.pool = pools;
        self.partials = vec![Default::default(); piece_body.nodes().div_ceil(crate::kernel::CHUNK)];
        self.synced = piece_state.breaks();
        let chunks = piece.total.div_ceil(crate::kernel::CHUNK);
        let t = self.partition.shared_mut().expect("a shared integrator");
        t.piece = Some(Box::new(Pieced {
            piece,
            sweeps,
            partials: vec![Default::default(); chunks],
        }));
    }

    /// A digest of every node's displacement and velocity, in the body's node order: the same
    /// for one process and for any team, with or without pieces, exactly when those bits are
    /// the same (FNV-1a over each chunk's values, the chunks' digests folded in chunk order;
    /// each rank digests its own chunks, which are current, and the digests are all-gathered).
    /// Collective. What `hooke bench --json` prints as `state_digest`, so that runs on
    /// different numbers of ranks can be compared without writing their states.
    pub fn state_digest(&mut self, state: &State) -> u64 {
        let chunk = crate::kernel::CHUNK;
        let (own, first, total) = match self.partition.shared() {
            None => (0..state.u.len(), 0, state.u.len()),
            Some(t) => match &t.piece {
                Some(p) => (p.piece.own.clone(), p.piece.first, p.piece.total),
                None => {
                    let mine = t.share.mine();
                    let total = t.share.nodes.last().map_or(0, |r| r.end);
                    (mine.clone(), mine.start, total)
                }
            },
        };
        let fnv = |h: u64, x: u64| (h ^ x).wrapping_mul(0x0000_0100_0000_01b3);
        let basis = 0xcbf2_9ce4_8422_2325_u64;
        let mut digests = vec![0.0; total.div_ceil(chunk)];
        for (k, c) in own.clone().step_by(chunk).enumerate() {
            let mut h = basis;
            for i in c..(c + chunk).min(own.end) {
                for x in (0..3)
                    .map(|d| state.u.comp(d)[i])
                    .chain((0..3).map(|d| state.v.comp(d)[i]))
                {
                    h = fnv(h, x.to_bits());
                }
            }
            // Carried as a real's bits: the all-gather copies bytes.
            digests[first / chunk + k] = Real::from_bits(h);
        }
        if let Some(t) = self.partition.shared() {
            t.team.gather(&mut digests, &t.share.chunk_parts(1));
        }
        digests.iter().fold(basis, |h, d| fnv(h, d.to_bits()))
    }

    /// Panics on a piece ([`Integrator::cut`]): `what` reads the whole state.
    pub(super) fn whole(&self, what: &str) {
        if let Some(t) = self.partition.shared() {
            t.whole(what);
        }
    }

    /// The piece this rank steps, if it was cut ([`Integrator::cut`]).
    pub fn piece(&self) -> Option<&Piece> {
        self.partition.shared()?.piece.as_ref().map(|p| &p.piece)
    }

    /// The team this integrator shares its steps with, if any.
    pub fn team(&self) -> Option<&dyn Team> {
        self.partition.shared().map(|t| &*t.team)
    }

    /// Collective operations per step of a shared run without contact and without springs
    /// near breaking: the all-gathers of the partial sums, of the loaded and prescribed nodes'
    /// velocities (if any) and of the prescribed nodes' forces (if any); a screened fracture
    /// criterion adds a logical or of the screen flags. Zero alone.
    pub fn collectives_per_step(&self) -> usize {
        self.partition.shared().map_or(0, |t| {
            1 + usize::from(!t.special.is_empty()) + usize::from(!self.dofs.is_empty())
        })
    }

    /// This process's share of the steps, if shared.
    pub fn share(&self) -> Option<&Share> {
        self.partition.shared().map(|t| &t.share)
    }

    /// Make every node's displacement, pool and velocity current on this process (a shared
    /// integrator's steps keep current only what its next step reads: see [`crate::team`]).
    /// Whatever reads the state as a whole calls it first: output, checkpoints, checks,
    /// breaking. Collective: every member calls it at the same point. Alone, or when current,
    /// it does nothing, as on a piece ([`Integrator::cut`]), which holds its own nodes and
    /// ghosts only: their displacements and pools are current after a step, and the
    /// velocities of its own nodes and of the loaded and prescribed ones.
    pub fn gather_state(&mut self, state: &mut State) {
        self.current(state, true, true, true);
    }

    /// [`Integrator::gather_state`] at `nodes` only (ascending, each once): one all-gather of
    /// what their owners hold, for a reader of a few nodes (a commit of breaks reads the
    /// broken springs' ends and their neighbours). Collective, with the same `nodes` on every
    /// member; alone it does nothing.
    pub fn gather_state_at(&mut self, state: &mut State, nodes: &[u32]) {
        self.current_at(state, nodes, true, Pools::IfStale, true);
    }

    /// Gather what is stale of the displacements, pools and velocities (as asked) from their
    /// owners. A plate's z components are exact zeros on every rank and are not gathered.
    pub(super) fn current(&mut self, state: &mut State, u: bool, pool: bool, v: bool) {
        let dims = if self.plane { 2 } else { 3 };
        // A piece holds no other ranks' nodes but its ghosts, whose displacements and pools
        // each step keeps current: there is nothing to gather.
        let Some(t) = self.partition.shared_mut().filter(|t| t.piece.is_none()) else {
            return;
        };
        if u && t.stale_u {
            for c in state.u.xyz_mut().into_iter().take(dims) {
                t.team.gather(c, &t.share.nodes);
            }
            t.stale_u = false;
        }
        if pool && t.stale_pool {
            t.team.gather(&mut state.pool, &t.share.nodes);
            t.stale_pool = false;
        }
        if v && t.v_partial {
            for c in state.v.xyz_mut().into_iter().take(dims) {
                t.team.gather(c, &t.share.nodes);
            }
            t.v_partial = false;
        }
    }

    /// Make the displacements, pools and velocities (as asked) current at `nodes` only
    /// (ascending, each once): one all-gather of what their owners hold.
    pub(super) fn current_at(
        &mut self,
        state: &mut State,
        nodes: &[u32],
        u: bool,
        pool: Pools,
        v: bool,
    ) {
        let dims = if self.plane { 2 } else { 3 };
        let Some(t) = self.partition.shared_mut() else {
            return;
        };
        let pool = match pool {
            Pools::No => false,
            Pools::IfStale => t.stale_pool,
            Pools::Repaired => true,
        };
        let (u, v) = (u && t.stale_u, v && t.v_partial);
        let k = if u { dims } else { 0 } + usize::from(pool) + if v { dims } else { 0 };
        // Every rank holds the same list: all skip alike.
        if k == 0 || nodes.is_empty() {
            return;
        }
        // A piece's numbering keeps the body's order: the owners' runs of `nodes` are where
        // their body indices fall.
        t.listed_parts.clear();
        for r in &t.share.nodes {
            let at = |end: usize| k * nodes.partition_point(|&i| t.global(i) < end);
            let part = at(r.start)..at(r.end);
            t.listed_parts.push(part);
        }
        t.listed.resize(k * nodes.len(), 0.0);
        let mine = t.listed_parts[t.share.rank].clone();
        let (first, last) = (mine.start / k, mine.end / k);
        let pack = |i: usize, out: &mut [Real]| {
            let mut c = 0;
            if u {
                for d in 0..dims {
                    out[c] = state.u.comp(d)[i];
                    c += 1;
                }
            }
            if pool {
                out[c] = state.pool[i];
                c += 1;
            }
            if v {
                for d in 0..dims {
                    out[c] = state.v.comp(d)[i];
                    c += 1;
                }
            }
        };
        for (vals, &i) in t.listed[mine].chunks_exact_mut(k).zip(&nodes[first..last]) {
            pack(i as usize, vals);
        }
        t.team.gather(&mut t.listed, &t.listed_parts);
        for (vals, &i) in t.listed.chunks_exact(k).zip(nodes) {
            let (i, mut c) = (i as usize, 0);
            if u {
                for d in 0..dims {
                    state.u.comp_mut(d)[i] = vals[c];
                    c += 1;
                }
            }
            if pool {
                state.pool[i] = vals[c];
                c += 1;
            }
            if v {
                for d in 0..dims {
                    state.v.comp_mut(d)[i] = vals[c];
                    c += 1;
                }
            }
        }
    }

    /// Make the state at the ends of `springs` current from their owners (displacements if
    /// `u`, pools as `pool` says); alone it does nothing.
    pub(super) fn current_at_ends(
        &mut self,
        body: &Body,
        state: &mut State,
        springs: &[u32],
        u: bool,
        pool: Pools,
    ) {
        let Some(t) = self.partition.shared_mut() else {
            return;
        };
        let mut ends = std::mem::take(&mut t.ends);
        ends.clear();
        ends.extend(
            springs
                .iter()
                .flat_map(|&b| body.lattice.bonds.ends[b as usize]),
        );
        ends.sort_unstable();
        ends.dedup();
        self.current_at(state, &ends, u, pool, false);
        self.partition.shared_mut().expect("shared").ends = ends;
    }

    /// Sweep 1 on this process's share, then the pools its peers read traded (and with a
    /// screen, the screen flags or-ed everywhere).
    pub(super) fn pools_everywhere(&mut self, body: &Body, state: &mut State, screen: Real) {
        match self.partition.shared_mut() {
            None => self.kernel.pools_screened(body, state, screen),
            Some(t) => {
                self.kernel
                    .pools_shared(body, state, screen, Some(t.sweeps()));
                t.trade(&mut [&mut state.pool[..]]);
                t.stale_pool = true;
                // A piece's flags are its own blocks' (each rank decides the springs of its
                // own nodes: a breaker gathers the decisions, see `Integrator::cut`); a whole
                // body's are the body's blocks, or-ed so that every rank looks at them all.
                if screen.is_finite() && t.piece.is_none() {
                    t.team.any(&mut state.hot);
                }
            }
        }
    }

    /// Sweep 2 on this process's share, then the new displacements its peers read and the
    /// partial sums everywhere; the total in chunk order (the bits of one process).
    pub(super) fn sweep_everywhere(
        &mut self,
        body: &Body,
        state: &mut State,
        params: &StepParams,
    ) -> crate::kernel::SweepSums {
        let in_place = self.kernel.drifts_in_place();
        if !in_place && self.u_next.len() != body.nodes() {
            // A kernel that drifts out of place after one that drifted in place (no shipped
            // path switches that way; a body's kernel changes only when springs soften).
            self.u_next = Coords::zeros(body.nodes());
        }
        let own = self.kernel.force_kick_drift_shared(
            body,
            state,
            &self.inv_mass,
            params,
            (!in_place).then_some(&mut self.u_next),
            &mut self.partials,
            self.partition.shared().map(Shared::sweeps),
        );
        let Some(t) = self.partition.shared_mut() else {
            return own;
        };
        if let Some(pc) = &mut t.piece {
            // The piece's chunks of owned nodes are the body's chunks from `first`.
            for c in pc.sweeps.chunks() {
                pc.partials[pc.piece.global_chunk(c)] = self.partials[c];
            }
        }
        // A plate's z components stay exact zeros on every rank (no force, load or
        // acceleration acts along z), so they need no exchange.
        let dims = params.dims(body.lattice.dim());
        let mut u = new_displacements(&mut self.u_next, &mut state.u, in_place).xyz_mut();
        t.trade(&mut u[..dims]);
        t.stale_u = true;
        t.v_partial = true;
        let (team, share) = (&t.team, &t.share);
        let parts = share.chunk_parts(2);
        let p = match &mut t.piece {
            Some(pc) => &mut pc.partials,
            None => &mut self.partials,
        };
        team.gather(crate::kernel::SweepSums::as_flat_mut(p), &parts);
        let mut total = crate::kernel::SweepSums::default();
        let chunks = share
            .nodes
            .last()
            .map_or(0, |r| r.end)
            .div_ceil(crate::kernel::CHUNK);
        for &s in &p[..chunks] {
            total += s;
        }
        total
    }

    /// [`Integrator::check`] in a shared run, between outputs: each member checks the nodes it
    /// owns, whose state it holds current, and only if one fails is the whole state gathered,
    /// so that every member finds the same first node and reports it alike (before, every
    /// member gathered and checked the whole body). Collective. Alone: [`Integrator::check`].
    pub fn check_shared(&mut self, body: &Body, state: &mut State) -> Result<()> {
        if let Some(t) = self.partition.shared().filter(|t| t.piece.is_some()) {
            return Self::check_piece(t, body, state);
        }
        if let Some(t) = self.partition.shared() {
            let mine = t.share.nodes[t.share.rank].clone();
            let mut failed = [Self::check_nodes(body, state, mine).is_err()];
            t.team.any(&mut failed);
            if !failed[0] {
                return Ok(());
            }
            self.gather_state(state);
        }
        self.check(body, state)
    }

    /// [`Integrator::check_shared`] on pieces: each rank checks its own nodes, and the first
    /// failure of the lowest failing rank (whose nodes come first in the body) is every
    /// rank's error, named by the node's index in the body.
    pub(super) fn check_piece(t: &Shared, body: &Body, state: &State) -> Result<()> {
        let pc = t.piece.as_ref().expect("a piece");
        let size = t.team.size();
        let parts: Vec<_> = (0..size).map(|r| 3 * r..3 * r + 3).collect();
        let mut found = vec![-1.0; 3 * size];
        let total = pc.piece.total;
        if let Err(Error::Unstable { node, .. }) =
            Self::check_nodes_of(body, state, pc.sweeps.mine(), total)
        {
            let u = state.u.get(node);
            let r = t.team.rank();
            found[3 * r] = pc.piece.global[node] as Real;
            found[3 * r + 1] = Real::from(u8::from(
                u.iter().chain(&state.v.get(node)).all(|x| x.is_finite()),
            ));
            found[3 * r + 2] = u.norm();
        }
        t.team.gather(&mut found, &parts);
        match found.chunks_exact(3).find(|f| f[0] >= 0.0) {
            None => Ok(()),
            Some(f) => Err(Error::Unstable {
                step: state.step,
                time: state.time,
                node: f[0] as usize,
                reason: Self::unstable_reason(f[1] == 1.0, f[2]),
                hint: UNSTABLE_HINT,
            }),
        }
    }

    /// On a piece: a frame's fields ([`law::frame_fields_piece`]), with `state.pool` (own
    /// nodes and ghosts) and `state.f` (own nodes, and the loaded and prescribed ones from
    /// their owners) refreshed from them. `None` off a piece. Collective.
    pub(super) fn piece_fields(
        &self,
        body: &Body,
        state: &mut State,
        scratch: &mut law::FrameScratch,
    ) -> Option<law::FrameFields> {
        let t = self.partition.shared()?;
        let pc = t.piece.as_ref()?;
        let fields = law::frame_fields_piece(
            body,
            &state.u,
            state.springs(body),
            &state.norm,
            scratch,
            law::PieceFrame {
                team: &*t.team,
                piece: &pc.piece,
                share: &t.share,
            },
        );
        state.pool.copy_from_slice(&fields.pool);
        state.f.clone_from(&fields.force);
        t.special_forces(state, &mut Vec::new());
        Some(fields)
    }
    /// Before contact's forces: the displacements and velocities of whichever nodes contact
    /// reads, from their owners: those its lists hold, or all when it rebuilds them (on a
    /// piece, its own nodes, which are current: it asks for none). Alone: nothing.
    pub(super) fn contact_reads_current(
        &mut self,
        body: &Body,
        state: &mut State,
        interaction: &mut dyn Interaction,
    ) {
        let Some(t) = self.partition.shared() else {
            return;
        };
        match interaction.reads(body, state, &t.share.nodes) {
            Reads::All => self.current(state, true, false, true),
            Reads::Nodes(list) => {
                self.current_at(state, list, true, Pools::No, true);
            }
        }
    }

    /// After sweep 2: the velocities the step's bookkeeping reads (the loaded and prescribed
    /// nodes' and those contact pushed), whichever rank swept them. Alone: nothing.
    pub(super) fn swept_velocities_current(&mut self, state: &mut State) {
        let Some(t) = self.partition.shared_mut() else {
            return;
        };
        let mut nodes = std::mem::take(&mut t.ends);
        nodes.clear();
        nodes.extend_from_slice(&t.special);
        // On a piece contact pushes its own nodes only, whose velocities are current.
        if t.piece.is_none() {
            nodes.extend(self.contact.iter().map(|c| c.0));
        }
        nodes.sort_unstable();
        nodes.dedup();
        self.current_at(state, &nodes, false, Pools::No, true);
        self.partition.shared_mut().expect("shared").ends = nodes;
    }
    /// The internal force at u(t) on every prescribed node, into `f_before` (their reactions'
    /// work): alone computed here; in a team each rank has current neighbours for its own
    /// nodes only, so owners compute the forces and everyone gathers them.
    pub(super) fn prescribed_forces_everywhere(&mut self, force: &dyn Fn(usize) -> [Real; 3]) {
        match self.partition.shared_mut() {
            None => self
                .f_before
                .extend(self.dofs.iter().map(|d| force(d.node))),
            Some(t) if !self.dofs.is_empty() => {
                let mut forces = std::mem::take(&mut t.forces);
                t.gather_special(&mut forces, force);
                t.forces = forces;
                for &k in &t.dof_slot {
                    let f = &t.forces[3 * k..3 * k + 3];
                    self.f_before.push([f[0], f[1], f[2]]);
                }
            }
            Some(_) => {}
        }
    }

    /// On pieces: every rank's contact pushes' work terms (`terms`, three per push and axis,
    /// this rank's), gathered and booked in rank order, which is one process's node order;
    /// and, when any rank pushed, the pushed nodes' new displacements to their ghosts (the
    /// pushes moved own nodes after the sweep's trade: a second trade, on steps with contact
    /// forces).
    pub(super) fn book_contact_pieces(
        &mut self,
        body: &Body,
        state: &mut State,
        params: &StepParams,
        terms: &[Real],
        in_place: bool,
    ) {
        let t = self.partition.shared_mut().expect("shared");
        let mut all = std::mem::take(&mut t.listed);
        crate::team::gather_runs(&*t.team, terms, &mut all, &mut t.listed_parts);
        for term in all.chunks_exact(3) {
            super::book_contact(&mut self.ledger, [term[0], term[1], term[2]]);
        }
        let pushed = !all.is_empty();
        let t = self.partition.shared_mut().expect("shared");
        t.listed = all;
        if pushed {
            let dims = params.dims(body.lattice.dim());
            let mut u = new_displacements(&mut self.u_next, &mut state.u, in_place).xyz_mut();
            t.trade(&mut u[..dims]);
        }
    }

    /// A piece's frame ([`Integrator::frame_view`]): its own nodes' fields (a VTK piece), the
    /// velocity and the energy balance; `None` where this process holds the whole body.
    pub(super) fn frame_on_piece(
        &mut self,
        body: &Body,
        state: &mut State,
        whole: bool,
    ) -> Option<(Coords, EnergyBalance, law::FrameFields)> {
        self.partition.pieced()?;
        // Whole frames are written from a whole state.
        assert!(
            !whole,
            "a whole frame reads the whole state, which a rank stepping its piece does not hold"
        );
        let mut scratch = std::mem::take(&mut self.frame_scratch);
        let fields = self
            .piece_fields(body, state, &mut scratch)
            .expect("a piece");
        if scratch.bytes() <= hooke_sys::alloc::KEPT_BLOCK {
            self.frame_scratch = scratch;
        }
        let v = self.velocity_from_forces(body, state);
        let b = self.balance(body, state, &v, fields.strain);
        Some((v, b, fields))
    }

    /// After each rank computed the frame of its own nodes ([`Partition::frame_part`]): the
    /// forces gathered whole on every rank (the velocity, the reactions and a checkpoint read
    /// them), and with `whole` the energy densities and stresses too. Nothing alone.
    pub(super) fn frame_gathered(&self, fields: &mut law::FrameFields, whole: bool) {
        let Some(p) = self.partition.frame_part() else {
            return;
        };
        let nodes = &p.share.nodes;
        let dims = if self.plane { 2 } else { 3 };
        for c in fields.force.xyz_mut().into_iter().take(dims) {
            p.team.gather(c, nodes);
        }
        if whole {
            p.team.gather(&mut fields.energy_density, nodes);
            let nine: Vec<_> = nodes.iter().map(|r| 9 * r.start..9 * r.end).collect();
            p.team.gather(fields.stress.as_flattened_mut(), &nine);
        }
    }

    /// [`Integrator::node_sums`] on a piece: each rank sums the chunks it holds, and the
    /// chunks' sums are all-gathered and added in chunk order (collective); `None` where this
    /// process holds the whole body.
    pub(super) fn node_sums_on_piece(&self, body: &Body, v: &Coords) -> Option<[Real; 2]> {
        let (t, pc) = self.partition.pieced()?;
        let (g, c) = (self.loading.body_acceleration, self.damping);
        let piece = &pc.piece;
        let mut sums = vec![0.0; 2 * piece.total.div_ceil(crate::kernel::CHUNK)];
        let at = 2 * (piece.first / crate::kernel::CHUNK);
        for (k, x) in chunk_node_sums(body, v, g, c, piece.own.clone())
            .into_iter()
            .enumerate()
        {
            sums[at + 2 * k..at + 2 * k + 2].copy_from_slice(&x);
        }
        t.team.gather(&mut sums, &t.share.chunk_parts(2));
        Some(
            sums.chunks_exact(2)
                .fold([0.0; 2], |s, x| [s[0] + x[0], s[1] + x[1]]),
        )
    }

    /// The forces at `nodes` (prescribed ones, ascending) on a piece: each owner computes its
    /// nodes' forces from its own nodes' pools and its ghosts' traded (a halo trade and an
    /// all-gather: collective); `None` where this process holds the whole body.
    pub(super) fn forces_on_piece(
        &self,
        body: &Body,
        state: &State,
        nodes: &[usize],
    ) -> Option<Vec<[Real; 3]>> {
        let (t, pc) = self.partition.pieced()?;
        let piece = &pc.piece;
        let mut pool = state.pool.clone();
        let sp = state.springs(body);
        law::pools_in(
            body,
            &state.u,
            sp,
            &state.norm,
            piece.own.clone(),
            &mut pool,
        );
        let size = t.team.size();
        let (mut out, mut inp) = (vec![Vec::new(); size], vec![Vec::new(); size]);
        crate::team::trade_halo(
            &*t.team,
            &piece.halo,
            &mut out,
            &mut inp,
            &mut [&mut pool[..]],
        );
        let mut f = Vec::new();
        t.gather_special(&mut f, |i| {
            law::node_force(body, body.q, &state.u, sp, &pool, i)
        });
        Some(
            nodes
                .iter()
                .map(|&i| {
                    let k = t.special.partition_point(|&s| (s as usize) < i);
                    [f[3 * k], f[3 * k + 1], f[3 * k + 2]]
                })
                .collect(),
        )
    }
}
