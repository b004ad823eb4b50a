//! Penalty contact between lattice nodes and rigid bodies, and between lattice nodes that are
//! not joined by an intact spring (crack faces, fragments).
//!
//! # Rigid bodies
//!
//! Every node carries a contact radius `r` (default `a/2`, the half-spacing its cell reaches).
//! With `d` the signed distance from the node to the body's surface and `n` the outward normal,
//! the gap is `g = d - r`; when `g < 0` the node feels `F = k_i (-g) n` and the body the
//! opposite. The potential `1/2 k_i g^2` makes the frictionless contact conservative.
//!
//! The stiffness comes from the time step: `k_i = c m_i / dt^2` (`c` = `stiffness_factor`,
//! default 0.1). A node in contact then oscillates at `omega dt = sqrt(c) = 0.32`, well inside
//! leapfrog's limit of 2 even on top of the lattice's own stiffness (whose step already has a
//! safety factor), so contact never makes a stable run unstable; and `m/dt^2` is about five
//! spring stiffnesses of the lattice (`lambda_max <= 12 (1 + 2q) k/m` in `docs/model.md`), so
//! `c = 0.1` makes a contact about half a spring stiff. The penetration under a force `F` is
//! `F / k_i`; `ContactOptions::max_penetration` states the bound the tests check.
//!
//! Coulomb friction (coefficient `mu` per body) acts against the tangential velocity of the node
//! relative to the body, `|F_t| = min(mu |F_n|, m_i |v_t| / dt)`: it never reverses the sliding
//! direction within a step (the regularised Coulomb law of explicit codes).
//!
//! # Fragments
//!
//! Two nodes not joined by an intact spring repel when closer than
//! `d_ij = min(d_f, |X_i - X_j|)` (reference positions: nodes never start in contact) with
//! `F = k_ij (d_ij - r) e`, `k_ij = c 2 m_i m_j / ((m_i + m_j) dt^2)`, the short-range force of
//! peridynamics codes. `d_f` defaults to 0.8 of the shortest spring, so a spring that breaks in
//! tension leaves its two nodes outside the search range. Candidate pairs come from a cell list
//! with a skin (Verlet list), rebuilt only when the nodes or bodies have moved more than the skin
//! since the last build. Only pairs with a damaged end (a node that lost a spring) are searched:
//! an intact lattice has none, so the cost of a run without fragments is one pass over the
//! displacements per step.
//!
//! Forces are gathered per node in a fixed order, so results are bit-identical for any thread
//! count.

use hooke_core::dynamics::{Interaction, Reads};
use hooke_core::team::{Team, PAD};
use hooke_core::{Body, Coords, Real, State};
use rayon::prelude::*;

use crate::rigid::RigidBody;

/// Settings of the contact model.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactOptions {
    /// `c` in `k = c m / dt^2`.
    pub stiffness_factor: Real,
    /// Contact radius of a node (m).
    pub radius: Real,
    /// Fragment contact distance `d_f` (m); `None` turns fragment contact off.
    pub fragment_distance: Option<Real>,
}

impl ContactOptions {
    /// Defaults for a body: `c = 0.1`, radius `a/2`, fragment contact at 0.8 of the shortest
    /// spring.
    pub fn for_body(body: &Body) -> Self {
        Self::for_lattice(body.lattice.spacing, body.lattice.shortest())
    }

    /// [`ContactOptions::for_body`] for a lattice of spacing `a` whose shortest spring is
    /// `shortest` (m): what a process holding a piece of the body knows once the processes
    /// have found the body's shortest spring.
    pub fn for_lattice(a: Real, shortest: Real) -> Self {
        ContactOptions {
            stiffness_factor: 0.1,
            radius: 0.5 * a,
            fragment_distance: Some(0.8 * shortest.min(a)),
        }
    }
}

/// One step of a body's history, all at `time`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub time: Real,
    pub body: usize,
    /// Force of the lattice on the body (N).
    pub reaction: [Real; 3],
    /// Position of the body's reference point (m).
    pub position: [Real; 3],
    /// Full-step velocity: the mean of the half-step velocities around `time` (m/s).
    pub velocity: [Real; 3],
    /// Full-step angular velocity, the mean of the half steps' (rad/s, world frame).
    pub spin: [Real; 3],
    /// Orientation at `time` (unit quaternion w, x, y, z; body frame to world).
    pub orientation: [Real; 4],
    /// Torque of the lattice on the body about its centre of mass (N m).
    pub torque: [Real; 3],
}

/// Contact of one lattice with rigid bodies and with itself.
#[derive(Debug)]
pub struct Contact {
    pub bodies: Vec<RigidBody>,
    pub opts: ContactOptions,
    dim: usize,
    skin: Real,
    /// Nodes near each body at the last build.
    candidates: Vec<Vec<u32>>,
    /// Fragment candidate pairs: CSR over nodes.
    frag_offsets: Vec<u32>,
    frag_nbr: Vec<u32>,
    frag_nodes: Vec<u32>,
    frag_force: Vec<[Real; 3]>,
    u_build: Coords,
    x_build: Vec<[Real; 3]>,
    /// Each body's orientation at the last build, and the radius of a ball about its
    /// reference point that holds it (for the turned distance).
    q_build: Vec<[Real; 4]>,
    reach: Vec<Real>,
    built: bool,
    /// Per-node accumulator and the nodes it touched this step.
    acc: Vec<[Real; 3]>,
    touched: Vec<u32>,
    mark: Vec<bool>,
    /// Contact potential energy at the last evaluation (J).
    pub potential: Real,
    /// Number of candidate-list builds so far.
    pub rebuilds: usize,
    /// Deepest penetration past the contact radius seen so far (m).
    pub max_penetration: Real,
    pub history: Vec<Record>,
    /// Record every `record_every` steps (1: every step).
    pub record_every: u64,
    steps: u64,
    /// Processes sharing the evaluation of the candidates (see [`Contact::distribute`]).
    team: Option<std::sync::Arc<dyn Team>>,
    /// Per candidate of one body: the force on the node and its potential energy, and its
    /// penetration (NaN when not in contact); and the ranks' parts of the candidates.
    hits: Vec<Real>,
    parts: Vec<std::ops::Range<usize>>,
    /// Each process's largest move since the rebuild, and the one-value parts to gather them
    /// by (see [`Contact::lists_valid`]; sized by [`Contact::distribute`]).
    moves: Vec<Real>,
    one_each: Vec<std::ops::Range<usize>>,
    /// Every node the forces read while the lists hold (the candidates, the fragment nodes and
    /// their neighbours), ascending: what a shared run makes current (see
    /// [`Interaction::reads`]).
    read_nodes: Vec<u32>,
    /// Whether the lists hold, as [`Interaction::reads`] found before this step's forces.
    checked: Option<bool>,
    /// Every process's nodes, as [`Interaction::reads`] was last told (empty: not known): a
    /// rebuild then passes over this process's nodes only and gathers the lists.
    node_parts: Vec<std::ops::Range<usize>>,
    /// On a rank's piece ([`Contact::cut`]): where its nodes are in the body. The candidate
    /// and fragment lists then hold its own nodes only, in the piece's numbering.
    piece: Option<PieceNodes>,
    /// On a piece: the other ends of its fragment pairs, every rank's, each once, by their
    /// index in the body (ascending: each owner's are a run), their reference positions and
    /// masses, and their displacements, gathered from their owners each step (`frag_nbr`
    /// indexes these).
    wanted: Vec<u32>,
    wanted_ref: Vec<[Real; 3]>,
    wanted_mass: Vec<Real>,
    wanted_u: Vec<Real>,
    /// Each fragment node's contact energy at the last evaluation.
    frag_energy: Vec<Real>,
    /// Scratch of the gathers of a piece's fragment contact.
    scratch: Vec<Real>,
    scratch_parts: Vec<std::ops::Range<usize>>,
    /// On a piece, per body: every rank's count of candidates (all-gathered at each rebuild).
    counts: Vec<Real>,
}

/// Where a rank's piece's nodes are in the body (see [`Contact::cut`]).
#[derive(Debug)]
struct PieceNodes {
    /// Its own nodes, in its numbering, and the body's index of the first.
    own: std::ops::Range<usize>,
    first: usize,
    /// The body's index of each of its nodes (`hooke_core::team::PAD` for its padding).
    global: Vec<u32>,
}

/// A node as a fragment-contact rebuild lists it: its index in the body, position, reference
/// position and mass.
#[derive(Clone, Copy, Debug)]
struct Near {
    id: u32,
    x: [Real; 3],
    x0: [Real; 3],
    mass: Real,
}

/// The box of the current positions of the nodes `mine`, and over the team's processes when
/// shared (minima and maxima are exact in any grouping).
fn current_bounds(
    body: &Body,
    u: &Coords,
    mine: &std::ops::Range<usize>,
    team: Option<&dyn Team>,
) -> ([Real; 3], [Real; 3]) {
    let (mut lo, mut hi) = mine
        .clone()
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let p = Contact::position(body, u, i);
            (p, p)
        })
        .reduce(
            || ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]),
            |(a, b), (c, d)| {
                (
                    [0, 1, 2].map(|k| a[k].min(c[k])),
                    [0, 1, 2].map(|k| b[k].max(d[k])),
                )
            },
        );
    if let Some(t) = team {
        let mut lists = vec![lo.iter().chain(&hi).copied().collect()];
        gather_lists(t, &mut lists);
        for b in lists[0].chunks(6) {
            for c in 0..3 {
                lo[c] = lo[c].min(b[c]);
                hi[c] = hi[c].max(b[3 + c]);
            }
        }
    }
    (lo, hi)
}

/// Every pair (i, j) of a damaged node i and a listed node j in its or the next cells (`order`:
/// the listed nodes sorted by cell, `cell` the cell of a position), closer than `h`, not
/// coincident in the reference configuration and joined by no intact spring (`bonded`: `None`
/// when this process holds neither end's row), in both directions.
fn search_pairs<C, B>(
    damaged: &[Near],
    order: &[([i64; 3], &Near)],
    cell: &C,
    h: Real,
    bonded: &B,
) -> Vec<(u32, u32)>
where
    C: Fn(&[Real; 3]) -> [i64; 3] + Sync,
    B: Fn(u32, u32) -> Option<bool> + Sync,
{
    damaged
        .par_iter()
        .with_min_len(64)
        .flat_map_iter(|di| {
            let mut pairs = Vec::new();
            let ci = cell(&di.x);
            for dz in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        let key = [ci[0] + dx, ci[1] + dy, ci[2] + dz];
                        let start = order.partition_point(|e| e.0 < key);
                        for &(k, dj) in &order[start..] {
                            if k != key {
                                break;
                            }
                            if dj.id == di.id {
                                continue;
                            }
                            let d2: Real = (0..3).map(|c| (di.x[c] - dj.x[c]).powi(2)).sum();
                            if d2 >= h * h {
                                continue;
                            }
                            if di.rest(dj) < 1e-12 * h || bonded(di.id, dj.id).is_none_or(|b| b) {
                                continue;
                            }
                            pairs.push((di.id, dj.id));
                            pairs.push((dj.id, di.id));
                        }
                    }
                }
            }
            pairs
        })
        .collect()
}

/// A bitmap over the body's grid of cells (`dims` cells a side) marking the cells next to a
/// damaged node's, or `None` when the grid is too large for one (every node is then listed).
fn near_cells(
    damaged: &[Near],
    dims: [i64; 3],
    cell: &dyn Fn(&[Real; 3]) -> [i64; 3],
    index: &dyn Fn([i64; 3]) -> usize,
) -> Option<Vec<u64>> {
    let cells = dims
        .iter()
        .try_fold(1u64, |t, &d| t.checked_mul(d.max(1) as u64));
    cells.filter(|&t| t <= 1 << 28).map(|t| {
        let mut bits = vec![0u64; (t as usize).div_ceil(64)];
        for d in damaged {
            let ci = cell(&d.x);
            for dx in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dz in -1..=1i64 {
                        let k = [ci[0] + dx, ci[1] + dy, ci[2] + dz];
                        if (0..3).all(|c| k[c] >= 0 && k[c] < dims[c]) {
                            let at = index(k);
                            bits[at >> 6] |= 1 << (at & 63);
                        }
                    }
                }
            }
        }
        bits
    })
}

impl Near {
    /// The distance between two nodes in the reference configuration (m).
    fn rest(&self, o: &Near) -> Real {
        ((self.x0[0] - o.x0[0]).powi(2)
            + (self.x0[1] - o.x0[1]).powi(2)
            + (self.x0[2] - o.x0[2]).powi(2))
        .sqrt()
    }

    /// Every process's `mine`, concatenated in rank order (indices exact as reals).
    fn gather(team: &dyn Team, mine: &[Near]) -> Vec<Near> {
        let mut lists = vec![mine
            .iter()
            .flat_map(|e| {
                [
                    e.id as Real,
                    e.x[0],
                    e.x[1],
                    e.x[2],
                    e.x0[0],
                    e.x0[1],
                    e.x0[2],
                    e.mass,
                ]
            })
            .collect()];
        gather_lists(team, &mut lists);
        lists[0]
            .chunks_exact(8)
            .map(|e| Near {
                id: e[0] as u32,
                x: [e[1], e[2], e[3]],
                x0: [e[4], e[5], e[6]],
                mass: e[7],
            })
            .collect()
    }
}

/// Reals per candidate in `Contact::hits`: the force, the potential energy, the penetration
/// and the torque of the reaction about the body's centre.
const HIT: usize = 8;

/// Each of `lists` (this process's part on entry) becomes every process's part of it,
/// concatenated in rank order: two all-gathers, the lengths and then the values, whatever the
/// number of lists.
fn gather_lists(team: &dyn Team, lists: &mut [Vec<Real>]) {
    let (size, rank, l) = (team.size(), team.rank(), lists.len());
    let mut lens = vec![0.0; size * l];
    for (k, list) in lists.iter().enumerate() {
        lens[rank * l + k] = list.len() as Real;
    }
    let each: Vec<std::ops::Range<usize>> = (0..size).map(|r| r * l..(r + 1) * l).collect();
    team.gather(&mut lens, &each);
    let len = |r: usize, k: usize| lens[r * l + k] as usize;
    let mut parts = Vec::with_capacity(size);
    let mut at = 0;
    for r in 0..size {
        let n: usize = (0..l).map(|k| len(r, k)).sum();
        parts.push(at..at + n);
        at += n;
    }
    let mut all = vec![0.0; at];
    let mut w = parts[rank].start;
    for list in lists.iter() {
        all[w..w + list.len()].copy_from_slice(list);
        w += list.len();
    }
    team.gather(&mut all, &parts);
    for list in lists.iter_mut() {
        list.clear();
    }
    for (r, part) in parts.iter().enumerate() {
        let mut at = part.start;
        for (k, list) in lists.iter_mut().enumerate() {
            list.extend_from_slice(&all[at..at + len(r, k)]);
            at += len(r, k);
        }
    }
}

impl Contact {
    /// Share the evaluation of the rigid bodies' candidate nodes with the other members of
    /// `team` (each process holds the same contact, see `hooke_core::team`): each evaluates a
    /// contiguous part of every body's candidates and the results are gathered, then every
    /// process sums them in candidate order, so the forces, reactions and energies are the bits
    /// of one process. Needs the displacements and velocities of the nodes its lists hold
    /// current on every process, and of every node when it rebuilds them: a shared integrator
    /// gathers what [`Interaction::reads`] asks for before each step's forces.
    pub fn distribute(&mut self, team: std::sync::Arc<dyn Team>) {
        self.moves = vec![0.0; team.size()];
        self.one_each = (0..team.size()).map(|r| r..r + 1).collect();
        self.team = (team.size() > 1).then_some(team);
    }

    /// Follow a shared integrator onto its rank's piece (`Integrator::cut`). From here on each
    /// rank evaluates the rigid bodies' candidates among its own nodes, and the forces,
    /// energies and the bodies' reactions and torques are gathered in candidate order and
    /// summed on every rank as one process sums them. Fragment contact pairs the rank's own
    /// damaged nodes (and own nodes near damage) with nodes anywhere: a rebuild finds the
    /// pairs from the listed nodes every rank sends (the lists one process makes), each rank
    /// keeps those with an own first node, and the displacements of their other ends, every
    /// rank's list of them, are all-gathered each step.
    pub fn cut(&mut self, piece: &hooke_core::team::Piece) -> Result<(), String> {
        let team = self.team.as_ref().ok_or("the contact is not shared")?;
        let nodes = piece.len();
        self.counts = vec![0.0; team.size() * self.bodies.len()];
        self.u_build = Coords::zeros(nodes);
        self.acc = vec![[0.0; 3]; nodes];
        self.mark = vec![false; nodes];
        self.frag_offsets = vec![0; nodes + 1];
        self.touched.clear();
        self.built = false;
        self.piece = Some(PieceNodes {
            own: piece.own.clone(),
            first: piece.first,
            global: piece.global.clone(),
        });
        Ok(())
    }

    pub fn new(body: &Body, bodies: Vec<RigidBody>, opts: ContactOptions) -> Self {
        Self::with_shortest(body, bodies, opts, body.lattice.shortest())
    }

    /// [`Contact::new`] where the body's shortest spring is `shortest` (m): a process holding
    /// a piece of the body passes the body's, found across the processes.
    pub fn with_shortest(
        body: &Body,
        bodies: Vec<RigidBody>,
        opts: ContactOptions,
        shortest: Real,
    ) -> Self {
        let n = body.nodes();
        let shortest = shortest.min(body.lattice.spacing);
        let nb = bodies.len();
        // How far a body reaches from its reference point (bounded shapes).
        let reach = bodies
            .iter()
            .map(|b| {
                let (lo, hi) = b.geometry.bounds([0.0; 3]);
                let r: Real = (0..3)
                    .map(|c| {
                        let m = lo[c].abs().max(hi[c].abs());
                        if m.is_finite() {
                            m * m
                        } else {
                            0.0
                        }
                    })
                    .sum();
                r.sqrt()
            })
            .collect();
        Contact {
            bodies,
            dim: body.lattice.dim(),
            // Broken springs stay out of range: d_f + skin < shortest spring (d_f <= 0.8 of it by
            // default; a user value is held below 0.95 of it and the skin shrinks to fit).
            skin: (0.15 * shortest)
                .min(0.95 * shortest - opts.fragment_distance.unwrap_or(0.0))
                .max(0.01 * shortest),
            opts,
            candidates: vec![Vec::new(); nb],
            frag_offsets: vec![0; n + 1],
            frag_nbr: Vec::new(),
            frag_nodes: Vec::new(),
            frag_force: Vec::new(),
            u_build: Coords::zeros(n),
            x_build: vec![[0.0; 3]; nb],
            q_build: vec![crate::rigid::IDENTITY; nb],
            reach,
            built: false,
            acc: vec![[0.0; 3]; n],
            touched: Vec::new(),
            mark: vec![false; n],
            potential: 0.0,
            rebuilds: 0,
            max_penetration: 0.0,
            history: Vec::new(),
            record_every: 1,
            team: None,
            read_nodes: Vec::new(),
            node_parts: Vec::new(),
            piece: None,
            wanted: Vec::new(),
            wanted_ref: Vec::new(),
            wanted_mass: Vec::new(),
            wanted_u: Vec::new(),
            frag_energy: Vec::new(),
            scratch: Vec::new(),
            scratch_parts: Vec::new(),
            counts: Vec::new(),
            checked: None,
            hits: Vec::new(),
            parts: Vec::new(),
            moves: Vec::new(),
            one_each: Vec::new(),
            steps: 0,
        }
    }

    /// What a checkpoint keeps to continue bit for bit: each body's position, half-step velocity,
    /// last reaction, orientation, spin, angular momentum and torque, the step counter (the history's cadence), the list builds and the
    /// deepest penetration. The candidate lists are not kept: the forces do not depend on when
    /// they were built (every list holds every pair in range, and forces are summed in node
    /// order), so a resumed run rebuilds them.
    pub fn snapshot(&self) -> Vec<Real> {
        let mut v = vec![self.bodies.len() as Real];
        for b in &self.bodies {
            v.extend(b.position);
            v.extend(b.velocity);
            v.extend(b.reaction);
            v.extend(b.orientation);
            v.extend(b.spin);
            v.extend(b.angular_momentum);
            v.extend(b.torque);
        }
        v.extend([
            self.steps as Real,
            self.rebuilds as Real,
            self.max_penetration,
        ]);
        v
    }

    /// Restore what [`Contact::snapshot`] kept; refuses a snapshot of another set of bodies.
    pub fn restore(&mut self, v: &[Real]) -> Result<(), String> {
        let nb = self.bodies.len();
        // 22 values per body; checkpoints from before rotation hold 9 (no turn).
        let per = if v.len() == 1 + 9 * nb + 3 { 9 } else { 22 };
        if v.len() != 1 + per * nb + 3 || v.first() != Some(&(nb as Real)) {
            return Err(format!(
                "the checkpoint holds {} values for the rigid bodies and contact, this case has {nb} bodies ({} values)",
                v.len(),
                1 + 22 * nb + 3
            ));
        }
        for (k, b) in self.bodies.iter_mut().enumerate() {
            let s = &v[1 + per * k..1 + per * (k + 1)];
            b.position = [s[0], s[1], s[2]];
            b.velocity = [s[3], s[4], s[5]];
            b.reaction = [s[6], s[7], s[8]];
            if per == 22 {
                b.orientation = [s[9], s[10], s[11], s[12]];
                b.spin = [s[13], s[14], s[15]];
                b.angular_momentum = [s[16], s[17], s[18]];
                b.torque = [s[19], s[20], s[21]];
            }
        }
        let t = &v[1 + per * nb..];
        self.steps = t[0] as u64;
        self.rebuilds = t[1] as usize;
        self.max_penetration = t[2];
        self.built = false;
        self.history.clear();
        Ok(())
    }

    /// Force a rebuild of the candidate lists at the next step (e.g. after springs broke).
    pub fn invalidate(&mut self) {
        self.built = false;
    }

    /// Total momentum of the dynamic bodies (kg m/s).
    pub fn momentum(&self) -> [Real; 3] {
        let mut p = [0.0; 3];
        for b in &self.bodies {
            let m = b.momentum();
            for c in 0..3 {
                p[c] += m[c];
            }
        }
        p
    }

    /// Total angular momentum of the dynamic bodies about the world origin (kg m^2/s).
    pub fn angular_momentum(&self) -> [Real; 3] {
        let mut l = [0.0; 3];
        for b in &self.bodies {
            let m = b.angular_momentum_about_origin();
            for c in 0..3 {
                l[c] += m[c];
            }
        }
        l
    }

    /// Kinetic energy of the dynamic bodies (J, half-step velocities).
    pub fn kinetic(&self) -> Real {
        self.bodies.iter().map(|b| b.kinetic()).sum()
    }

    fn position(body: &Body, u: &Coords, i: usize) -> [Real; 3] {
        let p = &body.lattice.pos;
        [
            p.x()[i] + u.x()[i],
            p.y()[i] + u.y()[i],
            p.z()[i] + u.z()[i],
        ]
    }

    /// Whether the lists built at the last rebuild still hold every pair that can be in range.
    /// Shared between processes, each looks at `own` nodes (by default a slice of its own).
    fn lists_valid(
        &mut self,
        body: &Body,
        u: &Coords,
        own: Option<std::ops::Range<usize>>,
    ) -> bool {
        if !self.built {
            return false;
        }
        // The largest move since the rebuild: a pass over every node, each step. Shared between
        // the processes of a run (each its part of the nodes, then the parts' maxima gathered):
        // a maximum is exact in any grouping, so every process gets the one-process value.
        let n = body.nodes();
        let (size, rank) = self.team.as_ref().map_or((1, 0), |t| (t.size(), t.rank()));
        let plane = self.dim == 2;
        let largest = |nodes: std::ops::Range<usize>| {
            nodes
                .into_par_iter()
                .with_min_len(4096)
                .map(|i| {
                    let d = [
                        u.x()[i] - self.u_build.x()[i],
                        u.y()[i] - self.u_build.y()[i],
                    ];
                    // A plate's z components stay exact zeros (as the integrator's exchange
                    // between ranks also relies on), which add +0 to the sum: not read, a
                    // third of this per-step pass's memory traffic, the same bits.
                    let dz = if plane {
                        0.0
                    } else {
                        u.z()[i] - self.u_build.z()[i]
                    };
                    d[0] * d[0] + d[1] * d[1] + dz * dz
                })
                .reduce(|| 0.0, Real::max)
        };
        let moved = match &self.team {
            None => largest(0..n),
            Some(t) => {
                // The nodes the last rebuild kept the displacements of (see `rebuild_lists`).
                let own = self
                    .piece
                    .as_ref()
                    .map(|p| p.own.clone())
                    .or(own)
                    .or_else(|| {
                        (self.node_parts.len() == size).then(|| self.node_parts[rank].clone())
                    });
                let mine = largest(own.unwrap_or(n * rank / size..n * (rank + 1) / size));
                self.moves[rank] = mine;
                t.gather(&mut self.moves, &self.one_each);
                self.moves.iter().fold(0.0 as Real, |m, &x| m.max(x))
            }
        }
        .sqrt();
        let body_moved = self
            .bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                let x = self.x_build[k];
                let d = [0, 1, 2].map(|c| b.position[c] - x[c]);
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                    + b.turned_since(self.q_build[k], self.reach[k])
            })
            .fold(0.0, Real::max);
        // Two nodes approach by at most twice the largest move; a node and a body by the sum.
        2.0 * moved < self.skin && moved + body_moved < self.skin
    }

    fn rebuild(&mut self, body: &Body, state: &State) {
        self.rebuild_lists(body, state);
        let mut r = std::mem::take(&mut self.read_nodes);
        r.clear();
        for c in &self.candidates {
            r.extend_from_slice(c);
        }
        if self.piece.is_none() {
            r.extend_from_slice(&self.frag_nodes);
            r.extend_from_slice(&self.frag_nbr);
        }
        r.sort_unstable();
        r.dedup();
        self.read_nodes = r;
    }

    fn rebuild_lists(&mut self, body: &Body, state: &State) {
        self.rebuilds += 1;
        self.built = true;
        let n = body.nodes();
        for (k, b) in self.bodies.iter().enumerate() {
            self.x_build[k] = b.position;
            self.q_build[k] = b.orientation;
        }
        // The passes over every node run in parallel; each list comes out in node order, as
        // a serial pass makes it, and the sorts have unique keys, so nothing depends on the
        // thread count.
        let reach = self.opts.radius + self.skin;
        let dim = self.dim;
        // Shared between processes, each passes over its own nodes and the lists are gathered
        // in rank order, which is node order: the lists of one process (the rebuild was a
        // tenth of each rank's step at two ranks when every rank passed over every node).
        let team = self
            .team
            .clone()
            .filter(|t| self.piece.is_some() || self.node_parts.len() == t.size());
        let mine = match (&self.piece, &team) {
            (Some(p), _) => p.own.clone(),
            (None, Some(t)) => self.node_parts[t.rank()].clone(),
            (None, None) => 0..n,
        };
        let ids = |r: &std::ops::Range<usize>| r.start as u32..r.end as u32;
        // The largest move since the rebuild is taken over each process's own nodes (the
        // maxima gathered), so each keeps only their displacements.
        if team.is_some() {
            for c in 0..3 {
                self.u_build.comp_mut(c)[mine.clone()]
                    .copy_from_slice(&state.u.comp(c)[mine.clone()]);
            }
        } else {
            self.u_build.clone_from(&state.u);
        }
        for (k, b) in self.bodies.iter().enumerate() {
            let (lo, hi) = b.bounds();
            let list = &mut self.candidates[k];
            list.clear();
            list.par_extend(ids(&mine).into_par_iter().with_min_len(4096).filter(|&i| {
                let x = Self::position(body, &state.u, i as usize);
                (0..dim).all(|c| x[c] >= lo[c] - reach && x[c] <= hi[c] + reach)
            }));
        }
        if let (Some(t), Some(_)) = (&team, &self.piece) {
            // On a piece each rank keeps its own candidates; the counts give every rank's part.
            let nb = self.candidates.len();
            self.counts.iter_mut().for_each(|c| *c = 0.0);
            for (k, c) in self.candidates.iter().enumerate() {
                self.counts[t.rank() * nb + k] = c.len() as Real;
            }
            let each: Vec<_> = (0..t.size()).map(|r| r * nb..(r + 1) * nb).collect();
            t.gather(&mut self.counts, &each);
        } else if let Some(t) = &team {
            let mut lists: Vec<Vec<Real>> = self
                .candidates
                .iter()
                .map(|c| c.iter().map(|&i| i as Real).collect())
                .collect();
            gather_lists(t.as_ref(), &mut lists);
            for (c, l) in self.candidates.iter_mut().zip(&lists) {
                c.clear();
                c.extend(l.iter().map(|&i| i as u32));
            }
        }
        self.rebuild_fragments(body, state, team, mine);
    }

    /// The fragment lists (see the module docs): pairs of nodes within the fragment distance
    /// of which one is damaged and which no intact spring joins, found through a cell list over
    /// the nodes near a damaged one. Each process passes over its own nodes `mine`.
    fn rebuild_fragments(
        &mut self,
        body: &Body,
        state: &State,
        team: Option<std::sync::Arc<dyn Team>>,
        mine: std::ops::Range<usize>,
    ) {
        let n = body.nodes();
        self.frag_nbr.clear();
        self.frag_nodes.clear();
        self.frag_offsets.iter_mut().for_each(|o| *o = 0);
        let Some(df) = self.opts.fragment_distance else {
            return;
        };
        // Only pairs with a damaged end (a node that lost a spring) can be crack faces or
        // fragments: an intact lattice has none and skips the search.
        let bonds = &*body.lattice.bonds;
        // From the broken springs' ends (a contiguous scan of the flags, then the few broken
        // ones) rather than from every node's row (an indirect read per row entry): the same
        // list, in node order. (A piece's ghosts hold partial rows: only its own nodes' flags
        // are read.)
        let mut flags = vec![false; n];
        for (b, _) in state.alive().iter().enumerate().filter(|(_, &a)| !a) {
            let [i, j] = bonds.ends[b];
            flags[i as usize] = true;
            flags[j as usize] = true;
        }
        let pos = &body.lattice.pos;
        // Nodes travel with their index in the body, position, reference position and mass
        // (what a pair's force reads of its other end, which on a piece may be another
        // rank's), computed by their owners: a process holds current displacements at its own
        // nodes only, and gathering every node's for a rebuild cost a whole-state all-gather
        // each time.
        let offset = self.piece.as_ref().map_or(0, |p| p.first - p.own.start);
        let node = |i: usize| Near {
            id: (i + offset) as u32,
            x: Self::position(body, &state.u, i),
            x0: [pos.x()[i], pos.y()[i], pos.z()[i]],
            mass: body.mass[i],
        };
        let mut damaged: Vec<Near> = mine
            .clone()
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&i| flags[i])
            .map(node)
            .collect();
        if let Some(t) = &team {
            damaged = Near::gather(t.as_ref(), &damaged);
        }
        if damaged.is_empty() {
            self.frag_force.clear();
            self.wanted.clear();
            return;
        }
        let (lo, hi) = current_bounds(body, &state.u, &mine, team.as_deref());
        // Cell list: cells of side df + skin, nodes sorted by cell.
        let h = df + self.skin;
        let cell = |p: &[Real; 3]| [0, 1, 2].map(|c| ((p[c] - lo[c]) / h).floor() as i64);
        // Only nodes in the cells next to a damaged node's can pair with one: mark those cells
        // in a bitmap over the body's grid of cells and sort just their nodes (sorting every
        // node by cell at each rebuild was a sixth of a running crack's step). The pairs are a
        // set, so which nodes are listed changes nothing but the time.
        let dims = [0, 1, 2].map(|c| ((hi[c] - lo[c]) / h).floor() as i64 + 1);
        let index = |k: [i64; 3]| ((k[0] * dims[1] + k[1]) * dims[2] + k[2]) as usize;
        let near = near_cells(&damaged, dims, &cell, &index);
        // Each listed node with its cell.
        let listed: Vec<Near> = mine
            .clone()
            .into_par_iter()
            .with_min_len(4096)
            .filter_map(|i| {
                let p = Self::position(body, &state.u, i);
                let listed = near.as_ref().is_none_or(|bits| {
                    let at = index(cell(&p));
                    bits[at >> 6] & (1 << (at & 63)) != 0
                });
                listed.then(|| node(i))
            })
            .collect();
        let listed = match &team {
            Some(t) => Near::gather(t.as_ref(), &listed),
            None => listed,
        };
        let mut order: Vec<([i64; 3], &Near)> = listed.iter().map(|e| (cell(&e.x), e)).collect();
        // (Cell and node: unique keys.)
        order.par_sort_unstable_by_key(|e| (e.0, e.1.id));
        // Whether the intact spring joins body nodes `i` and `j`: read from the row of an end
        // this process holds whole (on a piece, an own node; its neighbours are all in the
        // piece, so an end outside it is no neighbour). `None`: neither end is held.
        // Held aside while the pairs are stored (their closures read it).
        let held = self.piece.take();
        let piece = held.as_ref();
        let local = |g: u32| -> Option<usize> {
            match piece {
                None => Some(g as usize),
                Some(p) => {
                    let at = p.global.partition_point(|&x| x == PAD || x < g);
                    (p.global.get(at) == Some(&g)).then_some(at)
                }
            }
        };
        let own = |g: u32| -> bool {
            piece.is_none_or(|p| (g as usize).wrapping_sub(p.first) < p.own.len())
        };
        let bonded = |i: u32, j: u32| -> Option<bool> {
            let (a, b) = if own(i) {
                (i, j)
            } else if own(j) {
                (j, i)
            } else {
                return None;
            };
            let a = local(a).expect("an own node");
            Some(local(b).is_some_and(|b| {
                bonds
                    .entry(a, b)
                    .is_some_and(|e| state.alive()[bonds.bond[e] as usize])
            }))
        };
        // Pairs (i, j) from every damaged i, then both directions, sorted: a CSR by node.
        let mut pairs = search_pairs(&damaged, &order, &cell, h, &bonded);
        // On a piece only the pairs with an own first node are this rank's.
        pairs.retain(|p| own(p.0));
        pairs.par_sort_unstable();
        pairs.dedup();
        self.store_pairs(
            &pairs,
            &local,
            (team.as_deref(), piece.is_some()),
            &listed,
            n,
        );
        self.piece = held;
    }

    /// The fragment pairs (first node own, both directions, sorted) as a CSR by node in this
    /// process's numbering (`local`); on a piece, the other ends wherever they are, each once in
    /// node order, with what the forces read of them (`listed`).
    fn store_pairs(
        &mut self,
        pairs: &[(u32, u32)],
        local: &dyn Fn(u32) -> Option<usize>,
        (team, on_piece): (Option<&dyn Team>, bool),
        listed: &[Near],
        n: usize,
    ) {
        // Their first nodes, in this process's numbering.
        let firsts: Vec<u32> = pairs
            .iter()
            .map(|p| local(p.0).expect("own") as u32)
            .collect();
        for &i in &firsts {
            self.frag_offsets[i as usize + 1] += 1;
        }
        for i in 0..n {
            self.frag_offsets[i + 1] += self.frag_offsets[i];
        }
        self.frag_nodes.extend(
            (0..n as u32)
                .filter(|&i| self.frag_offsets[i as usize + 1] > self.frag_offsets[i as usize]),
        );
        self.frag_force.resize(self.frag_nodes.len(), [0.0; 3]);
        match team {
            Some(t) if on_piece => {
                // The other ends, wherever they are: every rank's list of them, each once, in
                // node order (so each owner's run is contiguous), with what the forces read
                // of them; their displacements are gathered each step.
                let mut wanted: Vec<Real> = pairs.iter().map(|p| p.1 as Real).collect();
                wanted.sort_unstable_by(Real::total_cmp);
                wanted.dedup();
                let mut all = Vec::new();
                let mut parts = Vec::new();
                hooke_core::team::gather_runs(t, &wanted, &mut all, &mut parts);
                let mut ids: Vec<u32> = all.iter().map(|&x| x as u32).collect();
                ids.sort_unstable();
                ids.dedup();
                let by_id = |g: u32| {
                    listed
                        .binary_search_by_key(&g, |e| e.id)
                        .map(|k| &listed[k])
                        .expect("every pair's end is listed")
                };
                self.wanted_ref = ids.iter().map(|&g| by_id(g).x0).collect();
                self.wanted_mass = ids.iter().map(|&g| by_id(g).mass).collect();
                self.frag_nbr.extend(
                    pairs
                        .iter()
                        .map(|p| ids.binary_search(&p.1).expect("wanted") as u32),
                );
                self.wanted = ids;
            }
            _ => self.frag_nbr.extend(pairs.iter().map(|p| p.1)),
        }
    }

    /// The rigid bodies' contact forces on the nodes (into `acc`, the nodes marked `touched`),
    /// in body order, each body's reaction and torque summed in node order; their penalty
    /// energy is added to `potential`.
    fn rigid_forces(&mut self, body: &Body, state: &State, dt: Real, potential: &mut Real) {
        let t = state.time;
        let dim = self.dim;
        for k in 0..self.bodies.len() {
            let mut reaction = [0.0; 3];
            let mut torque = [0.0; 3];
            let (friction, xc, rotates) = {
                let b = &self.bodies[k];
                (b.friction, b.center(), b.inertia.is_some())
            };
            // What each candidate feels (the costly part: a distance query per node), shared
            // between the processes of a run; then the sums in candidate order, alike on every
            // process and as in one.
            let size = self.team.as_ref().map_or(1, |t| t.size());
            let rank = self.team.as_ref().map_or(0, |t| t.rank());
            self.parts.clear();
            let nc = if self.piece.is_some() {
                // On a piece, each rank its own candidates, in rank order: node order.
                let nb = self.bodies.len();
                let mut at = 0;
                for r in 0..size {
                    let c = self.counts[r * nb + k] as usize;
                    self.parts.push(HIT * at..HIT * (at + c));
                    at += c;
                }
                at
            } else {
                let nc = self.candidates[k].len();
                self.parts
                    .extend((0..size).map(|r| HIT * (nc * r / size)..HIT * (nc * (r + 1) / size)));
                nc
            };
            if self.hits.len() < HIT * nc {
                self.hits.resize(HIT * nc, 0.0);
            }
            let mine = self.parts[rank].start / HIT..self.parts[rank].end / HIT;
            // The node of candidate `idx`: on a piece, only this rank's own are held.
            let pieced = self.piece.is_some();
            let node = |c: &[u32], idx: usize| -> Option<usize> {
                if pieced {
                    mine.contains(&idx).then(|| c[idx - mine.start] as usize)
                } else {
                    Some(c[idx] as usize)
                }
            };
            for idx in mine.clone() {
                let i = node(&self.candidates[k], idx).expect("own");
                self.hits[HIT * idx + 4] = Real::NAN;
                let x = Self::position(body, &state.u, i);
                let Some((d, nrm)) = self.bodies[k].signed_distance(x) else {
                    continue;
                };
                let gap = d - self.opts.radius;
                if gap >= 0.0 {
                    continue;
                }
                let m = body.mass[i];
                let kc = self.stiffness(m, dt);
                let fn_mag = -kc * gap;
                let mut f = [0.0; 3];
                for c in 0..dim {
                    f[c] = fn_mag * nrm[c];
                }
                if friction > 0.0 {
                    let vi = [state.v.x()[i], state.v.y()[i], state.v.z()[i]];
                    // The body's material point under the node moves with V + w x r.
                    let vb = self.bodies[k].velocity_at(x);
                    let rel = [0, 1, 2].map(|c| vi[c] - vb[c]);
                    let vn: Real = (0..3).map(|c| rel[c] * nrm[c]).sum();
                    let vt = [0, 1, 2].map(|c| rel[c] - vn * nrm[c]);
                    let speed = vt.iter().map(|v| v * v).sum::<Real>().sqrt();
                    if speed > 0.0 {
                        let ft = (friction * fn_mag).min(m * speed / dt);
                        for c in 0..dim {
                            f[c] -= ft * vt[c] / speed;
                        }
                    }
                }
                let hit = &mut self.hits[HIT * idx..HIT * idx + HIT];
                hit[..3].copy_from_slice(&f);
                hit[3] = 0.5 * kc * gap * gap;
                hit[4] = -gap;
                if rotates {
                    // The reaction acts where the node is, on the force's own line.
                    let arm = [0, 1, 2].map(|c| x[c] - xc[c]);
                    hit[5..8].copy_from_slice(&crate::rigid::cross(arm, f));
                }
            }
            if let Some(t) = &self.team {
                t.gather(&mut self.hits[..HIT * nc], &self.parts);
            }
            for idx in 0..nc {
                let hit = &self.hits[HIT * idx..HIT * idx + HIT];
                if hit[4].is_nan() {
                    continue;
                }
                let i = node(&self.candidates[k], idx);
                let f = [hit[0], hit[1], hit[2]];
                self.max_penetration = self.max_penetration.max(hit[4]);
                *potential += hit[3];
                for c in 0..dim {
                    if let Some(i) = i {
                        self.acc[i][c] += f[c];
                    }
                    reaction[c] -= f[c];
                }
                if rotates {
                    for c in 0..3 {
                        torque[c] -= hit[5 + c];
                    }
                }
                if let Some(i) = i.filter(|&i| !self.mark[i]) {
                    self.mark[i] = true;
                    self.touched.push(i as u32);
                }
            }
            let (x0, v0) = (self.bodies[k].position, self.bodies[k].velocity);
            let (q0, w0) = (self.bodies[k].orientation, self.bodies[k].spin);
            self.bodies[k].advance(reaction, torque, t, dt, dim);
            if self.steps.is_multiple_of(self.record_every.max(1)) {
                // At time t: the reaction, the position and the full-step velocity (the mean of
                // the half steps around t), the pair a load-displacement curve needs.
                let (v1, w1) = (self.bodies[k].velocity, self.bodies[k].spin);
                self.history.push(Record {
                    time: t,
                    body: k,
                    reaction,
                    position: x0,
                    velocity: [0, 1, 2].map(|c| 0.5 * (v0[c] + v1[c])),
                    spin: [0, 1, 2].map(|c| 0.5 * (w0[c] + w1[c])),
                    orientation: q0,
                    torque,
                });
            }
        }
    }

    /// Fragment contact: forces gathered per node (each pair seen from both ends, exactly
    /// opposite) into `acc`, and their penalty energy (summed in node order, every rank's on a
    /// piece); `None` when no pair is listed anywhere. On a piece the other ends' displacements
    /// come from their owners first (every rank calls this gather while any rank has pairs).
    fn fragment_forces(&mut self, body: &Body, state: &State, dt: Real) -> Option<Real> {
        let dim = self.dim;
        if let (Some(p), Some(t)) = (&self.piece, &self.team) {
            if !self.wanted.is_empty() {
                let own = p.first..p.first + p.own.len();
                let (lo, hi) = (
                    self.wanted.partition_point(|&g| (g as usize) < own.start),
                    self.wanted.partition_point(|&g| (g as usize) < own.end),
                );
                let u = &state.u;
                let mut mine = std::mem::take(&mut self.wanted_u);
                mine.clear();
                for &g in &self.wanted[lo..hi] {
                    let i = p.own.start + (g as usize - p.first);
                    mine.extend([u.x()[i], u.y()[i], u.z()[i]]);
                }
                hooke_core::team::gather_runs(
                    t.as_ref(),
                    &mine,
                    &mut self.scratch,
                    &mut self.scratch_parts,
                );
                std::mem::swap(&mut mine, &mut self.scratch);
                self.wanted_u = mine;
            }
        }
        if self.frag_nodes.is_empty() && self.wanted.is_empty() {
            return None;
        }
        {
            let c_pen = self.opts.stiffness_factor;
            let df = self.opts.fragment_distance.unwrap_or(0.0);
            let (offs, nbr, nodes) = (&self.frag_offsets, &self.frag_nbr, &self.frag_nodes);
            let pos = &body.lattice.pos;
            let u = &state.u;
            let mass = &body.mass;
            // The other end `j` of a pair: its reference position, displacement and mass.
            let (pieced, wref, wu, wm) = (
                self.piece.is_some(),
                &self.wanted_ref,
                &self.wanted_u,
                &self.wanted_mass,
            );
            let other = |j: usize| -> ([Real; 3], [Real; 3], Real) {
                if pieced {
                    (wref[j], [wu[3 * j], wu[3 * j + 1], wu[3 * j + 2]], wm[j])
                } else {
                    (
                        [pos.x()[j], pos.y()[j], pos.z()[j]],
                        [u.x()[j], u.y()[j], u.z()[j]],
                        mass[j],
                    )
                }
            };
            let energy;
            let mut energies = std::mem::take(&mut self.frag_energy);
            energies.resize(nodes.len(), 0.0);
            self.frag_force
                .par_iter_mut()
                .zip(energies.par_iter_mut())
                .zip(nodes.par_iter())
                .with_min_len(256)
                .for_each(|((f, e), &i)| {
                    let i = i as usize;
                    let xi = [
                        pos.x()[i] + u.x()[i],
                        pos.y()[i] + u.y()[i],
                        pos.z()[i] + u.z()[i],
                    ];
                    *f = [0.0; 3];
                    *e = 0.0;
                    for &j in &nbr[offs[i] as usize..offs[i + 1] as usize] {
                        let (x0j, uj, mj) = other(j as usize);
                        let xj = [x0j[0] + uj[0], x0j[1] + uj[1], x0j[2] + uj[2]];
                        let d = [xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]];
                        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        let r0 = ((pos.x()[i] - x0j[0]).powi(2)
                            + (pos.y()[i] - x0j[1]).powi(2)
                            + (pos.z()[i] - x0j[2]).powi(2))
                        .sqrt();
                        let dij = df.min(r0);
                        if r >= dij || r == 0.0 {
                            continue;
                        }
                        let mi = mass[i];
                        let k = c_pen * 2.0 * mi * mj / ((mi + mj) * dt * dt);
                        let s = k * (dij - r) / r;
                        for c in 0..3 {
                            f[c] += s * d[c];
                        }
                        *e += 0.25 * k * (dij - r) * (dij - r); // half of each pair's energy
                    }
                });
            // Summed in node order (every rank's, on a piece), whatever the threads.
            if let (Some(_), Some(t)) = (&self.piece, &self.team) {
                hooke_core::team::gather_runs(
                    t.as_ref(),
                    &energies,
                    &mut self.scratch,
                    &mut self.scratch_parts,
                );
                energy = self.scratch.iter().sum::<Real>();
            } else {
                energy = energies.iter().sum::<Real>();
            }
            self.frag_energy = energies;
            for (idx, &i) in self.frag_nodes.iter().enumerate() {
                let i = i as usize;
                let f = self.frag_force[idx];
                if f == [0.0; 3] {
                    continue;
                }
                for c in 0..dim {
                    self.acc[i][c] += f[c];
                }
                if !self.mark[i] {
                    self.mark[i] = true;
                    self.touched.push(i as u32);
                }
            }
            Some(energy)
        }
    }

    fn stiffness(&self, m: Real, dt: Real) -> Real {
        self.opts.stiffness_factor * m / (dt * dt)
    }
}

impl Interaction for Contact {
    fn reads(&mut self, body: &Body, state: &State, nodes: &[std::ops::Range<usize>]) -> Reads<'_> {
        // Each process checks the nodes it owns, whose displacements it holds current.
        let own = self.team.as_ref().map(|t| nodes[t.rank()].clone());
        if self.piece.is_some() {
            // A piece: the lists hold its own nodes, which are current (the fragment pairs'
            // other ends are gathered by the forces).
            if self.node_parts.as_slice() != nodes {
                self.node_parts = nodes.to_vec();
            }
            if !self.lists_valid(body, &state.u, None) {
                self.rebuild(body, state);
            }
            self.checked = Some(true);
            return Reads::Nodes(&[]);
        }
        if own.is_some() && self.node_parts.as_slice() != nodes {
            self.node_parts = nodes.to_vec();
        }
        let valid = self.lists_valid(body, &state.u, own);
        if !valid && self.team.is_some() {
            // A rebuild reads only this process's own nodes and what the others send of
            // theirs, so it runs here, and the step then gathers the state of the nodes the
            // new lists hold, not of every node.
            self.rebuild(body, state);
        }
        // In a team the lists are current either way (rebuilt just above).
        let current = valid || self.team.is_some();
        self.checked = Some(current);
        if current {
            Reads::Nodes(&self.read_nodes)
        } else {
            Reads::All
        }
    }

    fn forces(&mut self, body: &Body, state: &State, dt: Real, out: &mut Vec<(u32, [Real; 3])>) {
        let valid = match self.checked.take() {
            Some(v) => v,
            None => self.lists_valid(body, &state.u, None),
        };
        if !valid {
            self.rebuild(body, state);
        }
        for &i in &self.touched {
            self.acc[i as usize] = [0.0; 3];
            self.mark[i as usize] = false;
        }
        self.touched.clear();
        let mut potential = 0.0;
        self.rigid_forces(body, state, dt, &mut potential);
        if let Some(e) = self.fragment_forces(body, state, dt) {
            potential += e;
        }
        self.potential = potential;
        self.touched.sort_unstable();
        for &i in &self.touched {
            out.push((i, self.acc[i as usize]));
        }
        self.steps += 1;
    }
}
