//! The row kernel: the general (CSR) kernel's sweeps node by node, eight nodes to a vector.
//!
//! Random lattices have no stencil: a node's neighbours are arbitrary nodes. The CSR kernel
//! ([`super::csr`]) computes each spring once into a record that both ends read; that costs
//! about a hundred scalar instructions per spring, since the records' inputs are gathered one
//! value at a time. This kernel computes each spring from both ends instead, with AVX-512 lanes
//! for nodes: a group of 8 nodes walks its rows side by side, slot by slot (the rows padded to
//! the group's longest, *sliced ELLPACK*), so that each lane adds its node's springs in the
//! order of its CSR row, exactly as the CSR kernel sums the records of that row. The groups of
//! a window of 64 consecutive nodes take its nodes longest row first, so that a group's rows
//! are about as long as each other (padding 4 % of the slots instead of 20 %; see `deal`).
//! What a slot needs of the 8 neighbours comes from one 64-byte record per node,
//!
//! ```text
//! record_n = [ X_n, Y_n, Z_n, u_x, u_y, u_z, p_n, 0 ]     (one cache line)
//! ```
//!
//! loaded whole and transposed in registers (8 loads and 23 shuffles instead of 7 gathers of 8
//! scattered values). The records are refreshed from `u` before sweep 1 and from the pools
//! before sweep 2 (two streaming passes; the state stays the truth).
//!
//! **The bits are those of the CSR kernel.** Seen from its upper end a spring's vector is the
//! exact negation of the vector seen from its lower end (`(X_i - X_j) + (u_i - u_j)` negates
//! every rounded difference), so `|d|^2`, the extension `dL = (2 D.w + w.w)/(l + L)`, `1/l`
//! and the tension `T = k dL + q k L (p_i + p_j)` are the same numbers at both ends, and the
//! force term `T (d / l)` is the CSR record's term with its sign. Each node adds its terms in
//! its row's order, as the CSR sweep does; a padding slot or a broken spring points at a far
//! dummy record with zero stiffness and adds a signed zero, which leaves a sum that started at
//! +0 unchanged. The rest length `L` is recomputed as `|X_j - X_i|` in the operations that
//! built it (checked for every spring at set-up; otherwise it is streamed). The scalar path (the
//! last, incomplete group of 8; the whole body after `set_simd(false)`) performs the same
//! operations one lane at a time. Without AVX-512, the AVX2 path (the same source, `mod vector`) walks each
//! group as two halves of 4 lanes; without either, `Kernel::for_body` takes the CSR kernel
//! itself. Tested bit for bit against the CSR kernel, with broken and softened springs,
//! dispersion levers and stored or recomputed rest lengths, in 2D and 3D.
//!
//! Periodic lattices keep the CSR kernel (their minimum-image wrap is not needed on the fast
//! path of any shipped case).

use std::sync::Arc;

use rayon::prelude::*;

use super::csr::geometry;
use super::stencil::{simd_lanes, Lanes, Src, Stencil};
use super::{StepParams, SweepSums, CHUNK};
use crate::share::Share;
use hooke_model::body::Body;
use hooke_model::math::Real;
use hooke_model::state::State;

/// Nodes in a block of the vector path: a window whose nodes are dealt to 8 groups of lanes
/// (see [`deal`]).
const WINDOW: usize = 64;

/// One node's record: reference position, displacement, pool, padding (a cache line). It is
/// part of the state's scratch, so the model defines it.
pub use hooke_model::state::Record;

/// The rows of a body in slot-major groups of 8 nodes, with each slot's spring constants.
#[derive(Clone, Debug)]
struct Slots {
    /// First slot of each group of 8 nodes (`groups + 1` entries); a slot is 8 entries, one
    /// per lane.
    start: Vec<u32>,
    /// Which node each lane holds: lane position `p` (group `p / 8`, lane `p % 8`) holds node
    /// `64 (p / 64) + lanes[p]`. A window of 64 nodes deals its nodes to its 8 groups by row
    /// length (see [`deal`]); a position past the last node holds none.
    lanes: Vec<u8>,
    /// Node i's lane position within its window (the inverse of `lanes`).
    at: Vec<u8>,
    /// Neighbour of each entry, or the dummy node `n` (padding, broken spring).
    j: Vec<u32>,
    /// Current stiffness (N/m): the body's, or what softening left; 0 at the dummy.
    k: Vec<Real>,
    /// Rest length (m); 1 at the dummy. Empty when every rest length is `|X_j - X_i|` to the
    /// bit (every lattice that is not periodic, unless its lengths were set otherwise): the
    /// kernel then recomputes it from the records, a square root instead of 8 streamed bytes
    /// per entry and sweep (the sweeps are bound by memory traffic, not by arithmetic).
    rest: Vec<Real>,
    /// Dispersion lever of direction-weighted materials (empty: the rest length).
    lever: Vec<Real>,
}

/// The row kernel of a body (see the module docs).
#[derive(Clone, Debug)]
pub struct RowKernel {
    n: usize,
    /// The nodes whose rows the kernel holds: `0..n`, or one rank's share
    /// ([`RowKernel::keep_rows`]).
    own: std::ops::Range<usize>,
    /// The other nodes that the rows reach (a share's ghosts, ascending; none for `0..n`).
    /// A node's index in the slots and records is its own for `own`, `own.end + k` for
    /// `ghosts[k]`, and the dummy's is `own.end + ghosts.len()` (`n` for the whole body): a
    /// share's records hold its own nodes, its ghosts and the dummy, not the whole body.
    ghosts: Arc<Vec<u32>>,
    /// `own.end + ghosts.len()`, the dummy's index (a field: the lanes' loops compare every
    /// slot's neighbour with it).
    dummy: usize,
    dim: usize,
    q: Real,
    slots: Arc<Slots>,
    /// The dummy record's position: far from every node, so that its (ignored) spring has a
    /// finite, non-zero length.
    far: [Real; 3],
    /// The vector path's instructions (`None`: the scalar path).
    simd: Option<Lanes>,
}

impl RowKernel {
    /// Heap memory by part (see [`hooke_model::memory::Footprint`]).
    pub fn footprint(&self) -> hooke_model::memory::Footprint {
        use hooke_model::memory::bytes;
        let s = &self.slots;
        vec![
            ("row slots: neighbours", bytes(&s.j)),
            ("row slots: stiffnesses", bytes(&s.k)),
            (
                "row slots: rest lengths, levers",
                bytes(&s.rest) + bytes(&s.lever),
            ),
            (
                "row slots: lanes",
                bytes(&s.start) + bytes(&s.lanes) + bytes(&s.at),
            ),
        ]
    }

    /// The row kernel of `body` in `state` (its intact springs and current stiffnesses); `None`
    /// for a periodic lattice.
    pub fn new(body: &Body, state: &State) -> Option<Self> {
        Self::build(body, state, true, None)
    }

    /// [`RowKernel::new`] holding only the rows of the nodes `own` (whole windows), as
    /// [`RowKernel::keep_rows`] leaves it, without first building the others.
    pub fn new_for(body: &Body, state: &State, own: std::ops::Range<usize>) -> Option<Self> {
        Self::build(body, state, true, Some(own))
    }

    /// The same kernel with each group holding 8 consecutive nodes, as before windows dealt
    /// them by row length (the same bits; for measuring what [`deal`] gains).
    #[doc(hidden)]
    pub fn undealt(body: &Body, state: &State) -> Option<Self> {
        Self::build(body, state, false, None)
    }

    fn build(
        body: &Body,
        state: &State,
        dealt: bool,
        own: Option<std::ops::Range<usize>>,
    ) -> Option<Self> {
        let lat = &body.lattice;
        if lat.is_periodic() {
            return None;
        }
        let n = body.nodes();
        let bonds = &*lat.bonds;
        let springs = state.springs(body);
        let lever = body.lever.is_some();
        let pos = &lat.pos;
        // Shed rest lengths are `|X_j - X_i|` already (`Lattice::shed_setup`).
        let stored = bonds.stored_rest().is_some_and(|rest| {
            bonds.ends.iter().zip(rest).any(|(&[i, j], &l)| {
                let big = [0, 1, 2].map(|c| pos.comp(c)[j as usize] - pos.comp(c)[i as usize]);
                rest_of::<3>(big).to_bits() != l.to_bits()
            })
        });
        let groups = n.div_ceil(8);
        let (lanes, at) = if dealt {
            deal(n, |i| bonds.row(i).len())
        } else {
            deal(n, |_| 0)
        };
        let node = |p: usize| WINDOW * (p / WINDOW) + lanes[p] as usize;
        let own = own.unwrap_or(0..n);
        assert!(whole_windows(&own, n), "a share of whole windows");
        // A group's nodes are all in its window, so a share of whole windows holds whole groups.
        let mine = |g: usize| own.contains(&(8 * g / WINDOW * WINDOW));
        let width = |g: usize| {
            if !mine(g) {
                return 0;
            }
            (8 * g..8 * g + 8)
                .map(node)
                .filter(|&i| i < n)
                .map(|i| bonds.row(i).len())
                .max()
                .unwrap_or(0)
        };
        let total: usize = (0..groups).map(width).sum();
        let mut start = Vec::with_capacity(groups + 1);
        let mut j = Vec::with_capacity(8 * total);
        let mut k = Vec::with_capacity(8 * total);
        let mut rest = Vec::with_capacity(if stored { 8 * total } else { 0 });
        let mut levers = Vec::with_capacity(if lever { 8 * total } else { 0 });
        start.push(0);
        for g in 0..groups {
            let width = width(g);
            for slot in 0..width {
                for l in 0..8 {
                    let i = node(8 * g + l);
                    let e = (i < n)
                        .then(|| bonds.row(i))
                        .and_then(|r| r.clone().nth(slot));
                    let b = e.map(|e| bonds.bond[e] as usize);
                    match (e, b) {
                        (Some(e), Some(b)) if springs.alive[b] => {
                            j.push(bonds.neighbour(i, e) as u32);
                            k.push(springs.k[b]);
                            if stored {
                                rest.push(lat.rest(b));
                            }
                            if lever {
                                levers.push(springs.lever.get(b));
                            }
                        }
                        _ => {
                            j.push(n as u32);
                            k.push(0.0);
                            if stored {
                                rest.push(1.0);
                            }
                            if lever {
                                levers.push(1.0);
                            }
                        }
                    }
                }
            }
            start.push(start[g] + width as u32);
        }
        let s = Slots {
            start,
            lanes,
            at,
            j,
            k,
            rest,
            lever: levers,
        };
        // Far outside the body's box (in every axis the body uses), at a finite distance.
        let mut far = [0.0; 3];
        for (c, f) in far.iter_mut().enumerate().take(lat.dim()) {
            let big = lat
                .pos
                .comp(c)
                .iter()
                .fold(0.0 as Real, |m, &x| m.max(x.abs()));
            *f = 4.0 * big + 1e3 * lat.spacing.max(1e-300);
        }
        let mut rk = RowKernel {
            n,
            own: 0..n,
            ghosts: Arc::new(Vec::new()),
            dummy: n,
            dim: lat.dim(),
            q: body.q,
            slots: Arc::new(s),
            far,
            simd: simd_lanes(),
        };
        if own != (0..n) {
            rk.localise(own);
        }
        Some(rk)
    }

    pub fn name(&self) -> &'static str {
        match self.simd {
            Some(Lanes::Avx512) => "rows-avx512",
            Some(Lanes::Avx2) => "rows-avx2",
            None => "rows",
        }
    }

    pub fn simd(&self) -> bool {
        self.simd.is_some()
    }

    pub fn set_simd(&mut self, on: bool) {
        self.simd = if on { simd_lanes() } else { None };
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

    /// The same kernel with ratio `q` (0: the plain law).
    pub fn with_q(&self, q: Real) -> Self {
        RowKernel { q, ..self.clone() }
    }

    /// The entries of intact spring `b`, one in each end's lane: the entry that points at the
    /// other end (two nodes share at most one spring; a broken spring's entries point at the
    /// dummy).
    fn entries_of(&self, body: &Body, b: usize) -> [Option<usize>; 2] {
        let [i, j] = body.lattice.bonds.ends[b].map(|v| v as usize);
        let s = &self.slots;
        [(i, j), (j, i)].map(|(me, other)| {
            let other = self.index_of(other)?;
            self.lane(me).find(|&e| s.j[e] as usize == other)
        })
    }

    /// Keep only the rows of the nodes `own` (whole windows of 64 nodes; one rank's share of
    /// a distributed run, `hooke_core::team`): every other row becomes empty. A rank sweeps its
    /// own nodes only, so the other ranks' rows, three quarters of a random3d body's kernel
    /// memory on four ranks, would never be read. Entries keep their order and values, so
    /// the kept rows give the same bits. Afterwards only nodes in `own` may be swept, and a
    /// spring with no end in `own` has no entries ([`RowKernel::bond_killed`] and
    /// [`RowKernel::bond_softened`] then change nothing).
    pub fn keep_rows(&mut self, own: std::ops::Range<usize>) {
        assert!(whole_windows(&own, self.n), "a share of whole windows");
        let s = &self.slots;
        let groups = s.start.len() - 1;
        // An empty share holds no group (one after a short last window starts inside it).
        let (g0, g1) = if own.is_empty() {
            (groups, groups)
        } else {
            (own.start / 8, own.end.div_ceil(8).min(groups))
        };
        let (e0, e1) = (8 * s.start[g0] as usize, 8 * s.start[g1] as usize);
        if e0 == 0 && e1 == s.j.len() {
            return; // Nothing else held (built for `own`, or one rank).
        }
        // The slots as they are within `own`, none before it: `start` shifted down by the
        // slots of the groups before `own`, flat after it.
        let first = s.start[g0];
        let start = s
            .start
            .iter()
            .map(|&x| x.clamp(first, s.start[g1]) - first)
            .collect();
        let copy = |v: &Vec<Real>| {
            if v.is_empty() {
                Vec::new()
            } else {
                v[e0..e1].to_vec()
            }
        };
        let kept = Slots {
            start,
            lanes: s.lanes.clone(),
            at: s.at.clone(),
            j: s.j[e0..e1].to_vec(),
            k: s.k[e0..e1].to_vec(),
            rest: copy(&s.rest),
            lever: copy(&s.lever),
        };
        // The full slots are freed here (unless a clone of this kernel still holds them).
        self.slots = Arc::new(kept);
        self.localise(own);
    }

    /// Renumber the held rows' neighbours for records of `own`'s nodes, their ghosts and the
    /// dummy (see [`RowKernel::ghosts`]); the slots hold only `own`'s rows, still numbered by
    /// node.
    fn localise(&mut self, own: std::ops::Range<usize>) {
        let n = self.n as u32;
        let s = Arc::make_mut(&mut self.slots);
        let mut ghosts: Vec<u32> =
            s.j.iter()
                .copied()
                .filter(|&j| j != n && !own.contains(&(j as usize)))
                .collect();
        ghosts.sort_unstable();
        ghosts.dedup();
        let dummy = (own.end + ghosts.len()) as u32;
        for j in s.j.iter_mut() {
            *j = if *j == n {
                dummy
            } else if own.contains(&(*j as usize)) {
                *j
            } else {
                own.end as u32 + ghosts.binary_search(j).expect("listed") as u32
            };
        }
        self.dummy = own.end + ghosts.len();
        self.own = own;
        self.ghosts = Arc::new(ghosts);
    }

    /// Index of the dummy node in the slots and records.
    #[inline(always)]
    fn dummy(&self) -> usize {
        self.dummy
    }

    /// Node of slot index `j` (not the dummy).
    #[inline(always)]
    fn node_of(&self, j: usize) -> usize {
        if j < self.own.end {
            j
        } else {
            self.ghosts[j - self.own.end] as usize
        }
    }

    /// Slot index of node `i`, if the held rows reach it.
    fn index_of(&self, i: usize) -> Option<usize> {
        if self.own.contains(&i) {
            Some(i)
        } else {
            let k = self.ghosts.binary_search(&(i as u32)).ok()?;
            Some(self.own.end + k)
        }
    }

    /// Whether the kernel holds every row (not a share's).
    fn whole(&self) -> bool {
        self.own == (0..self.n)
    }

    /// The node chunks whose rows a share's kernel holds (`None`: every chunk): the only
    /// ones it may sweep.
    pub(crate) fn own_chunks(&self) -> Option<std::ops::Range<usize>> {
        (!self.whole()).then(|| super::chunks_of(&self.own))
    }

    /// The records' base, so that slot index `j`'s record starts at `base + 8 j` (the records
    /// begin with node `own.start`). Offset with wrapping arithmetic: only in-bounds addresses
    /// are ever read.
    #[inline(always)]
    fn base(&self, rec: &[Record]) -> *const Real {
        (rec.as_ptr() as *const Real).wrapping_sub(8 * self.own.start)
    }

    /// Spring `b` broke: both its entries become dummies.
    pub fn bond_killed(&mut self, body: &Body, b: usize) {
        let entries = self.entries_of(body, b);
        let dummy = self.dummy() as u32;
        let s = Arc::make_mut(&mut self.slots);
        for e in entries.into_iter().flatten() {
            s.j[e] = dummy;
            s.k[e] = 0.0;
            if !s.rest.is_empty() {
                s.rest[e] = 1.0;
            }
            if !s.lever.is_empty() {
                s.lever[e] = 1.0;
            }
        }
    }

    /// Spring `b` softened: both its entries take its current stiffness.
    pub fn bond_softened(&mut self, body: &Body, state: &State, b: usize) {
        let k = state.springs(body).k[b];
        let entries = self.entries_of(body, b);
        let dummy = self.dummy() as u32;
        let s = Arc::make_mut(&mut self.slots);
        for e in entries.into_iter().flatten() {
            if s.j[e] != dummy {
                s.k[e] = k;
            }
        }
    }
}

/// Write `u` (and at the first call the reference positions and the dummy) into the records:
/// every record, or with `share` (one rank's part of a distributed run) those its rows read.
/// A kernel holding one share's rows keeps records of that share's nodes and ghosts only.
pub(crate) fn refresh_displacements(
    rk: &RowKernel,
    body: &Body,
    state: &mut State,
    share: Option<&Share>,
) {
    let pos = &body.lattice.pos;
    let at = |i: usize| [pos.x()[i], pos.y()[i], pos.z()[i]];
    let (o0, len) = (rk.own.start, rk.own.len());
    let count = len + rk.ghosts.len();
    // Built once per state (the first sweep), not per step; rebuilt if the state was last swept
    // with another body or share (a cheap check of the dummy and three nodes' positions).
    let same = |i: usize| state.rec[i - o0].0[..3] == at(i);
    let built = state.rec.len() == count + 1
        && state.rec[count].0[..3] == rk.far
        && (len == 0 || (same(o0) && same(o0 + len / 2) && same(rk.own.end - 1)));
    if !built {
        // The nodes, then the dummy, collected at their exact length (a push after the
        // collect doubled the capacity).
        let far = Record([rk.far[0], rk.far[1], rk.far[2], 0.0, 0.0, 0.0, 0.0, 0.0]);
        state.rec = rk
            .own
            .clone()
            .chain(rk.ghosts.iter().map(|&g| g as usize))
            .map(|i| {
                let [x, y, z] = at(i);
                Record([x, y, z, 0.0, 0.0, 0.0, 0.0, 0.0])
            })
            .chain(std::iter::once(far))
            .collect();
    }
    let u = &state.u;
    each_record(rk, &mut state.rec[..count], share, |i, r| {
        r[3] = u.x()[i];
        r[4] = u.y()[i];
        r[5] = u.z()[i];
    });
    // A share's ghosts may differ from those its records were built with (a kernel rebuilt
    // after springs softened reaches fewer nodes): their positions are written every time.
    if !rk.whole() {
        for (r, &g) in state.rec[len..count].iter_mut().zip(rk.ghosts.iter()) {
            r.0[..3].copy_from_slice(&at(g as usize));
        }
    }
}

/// Write the pools into the records (before sweep 2, after any repair): every record, or with
/// `share` those one rank's rows read. None for the plain law, whose pools are all +0 and
/// whose sweep 2 reads none from the records.
pub(crate) fn refresh_pools(rk: &RowKernel, state: &mut State, share: Option<&Share>) {
    if rk.q == 0.0 {
        return;
    }
    let pool = &state.pool;
    let count = rk.own.len() + rk.ghosts.len();
    each_record(rk, &mut state.rec[..count], share, |i, r| r[6] = pool[i]);
}

/// `f(node, its record)` for every record, in parallel over fixed chunks; with `share` only
/// for the rank's own nodes and its ghosts, which are all that its rows read (the far ends of
/// its springs that cross ranks are ghosts). A rank refreshing every record spent a tenth of
/// its step on it at two ranks, and refreshing the chunks its rows touch still a fifth of the
/// records more than it owns on a Morton-ordered random lattice. A kernel holding one share's
/// rows has records of exactly those nodes (`recs`: its own, then its ghosts).
fn each_record(
    rk: &RowKernel,
    recs: &mut [Record],
    share: Option<&Share>,
    f: impl Fn(usize, &mut [Real; 8]) + Sync,
) {
    let whole = rk.whole();
    let own = if whole {
        share.map_or(0..recs.len(), |s| s.mine())
    } else {
        rk.own.clone()
    };
    let at = if whole { own.clone() } else { 0..own.len() };
    recs[at.clone()]
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, recs)| {
            for (k, r) in recs.iter_mut().enumerate() {
                f(own.start + c * CHUNK + k, &mut r.0);
            }
        });
    if whole {
        for &g in share.iter().flat_map(|s| s.halo.recv.iter().flatten()) {
            f(g as usize, &mut recs[g as usize].0);
        }
    } else {
        for (r, &g) in recs[at.end..].iter_mut().zip(rk.ghosts.iter()) {
            f(g as usize, &mut r.0);
        }
    }
}

/// Whether `own` is empty or made of whole windows of the nodes `0..n` (the last may be short).
fn whole_windows(own: &std::ops::Range<usize>, n: usize) -> bool {
    own.is_empty()
        || (own.start.is_multiple_of(WINDOW) && (own.end.is_multiple_of(WINDOW) || own.end == n))
}

/// The lanes of the nodes `0..n` with rows of `len(i)` entries: `(lanes, at)` of [`Slots`].
///
/// A group's lanes walk their rows side by side, so each group costs the longest of its 8
/// rows: with 8 consecutive nodes in a group, a fifth of the slots were padding on random
/// lattices (rows of 4 to 9 springs in 2D, 7 to 22 in 3D). Each whole window of 64 nodes
/// instead deals its nodes to its 8 groups longest row first (ties in node order), which
/// leaves about 4 % padding. The lanes' order changes no bit: every node still adds its own
/// row's terms in its row's order, whichever lane it has. A last, partial window keeps its
/// nodes in order (it runs on the scalar path).
fn deal(n: usize, len: impl Fn(usize) -> usize) -> (Vec<u8>, Vec<u8>) {
    let positions = 8 * n.div_ceil(8);
    let mut lanes: Vec<u8> = (0..positions).map(|p| (p % WINDOW) as u8).collect();
    let mut at: Vec<u8> = (0..n).map(|i| (i % WINDOW) as u8).collect();
    for w in 0..n / WINDOW {
        let base = WINDOW * w;
        let mut order: [u8; WINDOW] = std::array::from_fn(|o| o as u8);
        order.sort_by_key(|&o| std::cmp::Reverse(len(base + o as usize)));
        for (p, &o) in order.iter().enumerate() {
            lanes[base + p] = o;
            at[base + o as usize] = p as u8;
        }
    }
    (lanes, at)
}

/// The rest length from the reference vector, in [`hooke_model::lattice::Bonds::from_pairs`]'s
/// operations (in 2D the z term is an exact zero and is left out).
#[inline(always)]
fn rest_of<const D: usize>(big: [Real; 3]) -> Real {
    if D == 3 {
        hooke_model::lattice::reference_length(big)
    } else {
        (big[0] * big[0] + big[1] * big[1]).sqrt()
    }
}

impl RowKernel {
    /// The entries of node i's row, in order (its lane of its group's slots).
    #[inline(always)]
    fn lane(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let s = &self.slots;
        let p = WINDOW * (i / WINDOW) + s.at[i] as usize;
        let (g, l) = (p / 8, p % 8);
        (s.start[g] as usize..s.start[g + 1] as usize).map(move |slot| 8 * slot + l)
    }

    #[inline(always)]
    fn lever_at(&self, e: usize, rest: Real) -> Real {
        let s = &self.slots;
        if s.lever.is_empty() {
            rest
        } else {
            s.lever[e]
        }
    }

    /// Node i's springs one by one: `(entry, neighbour, d, |d|^2, numerator of dL, L)`.
    #[inline(always)]
    fn each<const D: usize>(
        &self,
        rec: &[Record],
        i: usize,
        mut f: impl FnMut(usize, usize, [Real; 3], Real, Real, Real),
    ) {
        // Records start at node `own.start` (see `RowKernel::ghosts`).
        let o0 = self.own.start;
        let me = &rec[i - o0].0;
        let s = &self.slots;
        let dummy = self.dummy();
        for e in self.lane(i) {
            let j = s.j[e] as usize;
            if j == dummy {
                continue;
            }
            let o = &rec[j - o0].0;
            let big = [o[0] - me[0], o[1] - me[1], o[2] - me[2]];
            let w = [o[3] - me[3], o[4] - me[4], o[5] - me[5]];
            let (d, d2, num) = geometry::<D>(big, w);
            let rest = if s.rest.is_empty() {
                rest_of::<D>(big)
            } else {
                s.rest[e]
            };
            f(e, j, d, d2, num, rest);
        }
    }

    fn pool_scalar<const D: usize>(&self, src: &Src, i: usize, screen: Real) -> (Real, bool) {
        let s = &self.slots;
        let (mut sum, mut hot) = (0.0, false);
        self.each::<D>(src.rec, i, |e, _, _, d2, num, rest| {
            let dl = num / (d2.sqrt() + rest);
            hot |= dl > screen * rest;
            sum += s.k[e] * self.lever_at(e, rest) * dl;
        });
        let sn = src.norm[i];
        // Negative at a node of negative q_n (Body::q_node); 0 only without springs.
        (if sn != 0.0 { sum / sn } else { 0.0 }, hot)
    }

    fn force_scalar<const D: usize>(&self, src: &Src, pool: &[Real], i: usize) -> [Real; 3] {
        let s = &self.slots;
        let mut f = [0.0; 3];
        let pi = pool[i];
        self.each::<D>(src.rec, i, |e, j, d, d2, num, rest| {
            let l = d2.sqrt();
            let inv = 1.0 / l;
            let dl = num / (l + rest);
            let k = s.k[e];
            let t = k * dl + self.q * k * self.lever_at(e, rest) * (pi + pool[self.node_of(j)]);
            for c in 0..D {
                f[c] += t * (d[c] * inv);
            }
        });
        f
    }
}

/// `$m::$f::<D, LEVER, STORED>(args)` for the kernel's dimension, whether its springs carry
/// levers of their own and whether it streams its rest lengths: one monomorphised sweep per
/// shape, so the lanes' loop holds no branch on them.
macro_rules! by_shape {
    ($rk:expr, $m:ident :: $f:ident, $($arg:expr),*) => {{
        let s = &$rk.slots;
        match ($rk.dim, !s.lever.is_empty(), !s.rest.is_empty()) {
            (2, false, false) => $m::$f::<2, false, false>($($arg),*),
            (2, false, true) => $m::$f::<2, false, true>($($arg),*),
            (2, true, false) => $m::$f::<2, true, false>($($arg),*),
            (2, true, true) => $m::$f::<2, true, true>($($arg),*),
            (_, false, false) => $m::$f::<3, false, false>($($arg),*),
            (_, false, true) => $m::$f::<3, false, true>($($arg),*),
            (_, true, false) => $m::$f::<3, true, false>($($arg),*),
            (_, true, true) => $m::$f::<3, true, true>($($arg),*),
        }
    }};
}

impl Stencil for RowKernel {
    fn nodes(&self) -> usize {
        self.n
    }

    fn q(&self) -> Real {
        self.q
    }

    fn dim(&self) -> usize {
        self.dim
    }

    fn block_len(&self) -> usize {
        WINDOW
    }

    fn vector_block(&self, i: usize) -> bool {
        self.simd.is_some() && i.is_multiple_of(WINDOW) && i + WINDOW <= self.n
    }

    fn pool_one(&self, u: &Src, i: usize, screen: Real) -> (Real, bool) {
        if self.dim == 2 {
            self.pool_scalar::<2>(u, i, screen)
        } else {
            self.pool_scalar::<3>(u, i, screen)
        }
    }

    fn force_one(&self, u: &Src, pool: &[Real], i: usize) -> [Real; 3] {
        if self.dim == 2 {
            self.force_scalar::<2>(u, pool, i)
        } else {
            self.force_scalar::<3>(u, pool, i)
        }
    }

    /// # Safety
    /// As the trait's: only when [`Stencil::vector_block`] holds for `i` (the vector path
    /// is on, the processor has its instructions, and the block and its neighbours are nodes).
    #[cfg(target_arch = "x86_64")]
    unsafe fn pool_block(&self, u: &Src, i: usize, out: &mut [Real], screen: Real) -> bool {
        // SAFETY: by the caller's contract, `vector_block(i)`, so the path's instructions are there and
        // i..i+64 are nodes.
        unsafe {
            if self.simd == Some(Lanes::Avx2) {
                return by_shape!(self, vector::pools256, self, u, i, out, screen);
            }
            by_shape!(self, vector::pools512, self, u, i, out, screen)
        }
    }

    /// # Safety
    /// As the trait's: only when [`Stencil::vector_block`] holds for `i` (the vector path
    /// is on, the processor has its instructions, and the block and its neighbours are nodes).
    #[cfg(target_arch = "x86_64")]
    unsafe fn force_kick_drift_block(
        &self,
        u: &Src,
        _pool: &[Real],
        inv_mass: &[Real],
        p: &StepParams,
        i: usize,
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        let consts = (inv_mass, p, p.dims(self.dim));
        // SAFETY: by the caller's contract, as for `pool_block`.
        unsafe {
            if self.simd == Some(Lanes::Avx2) {
                by_shape!(self, vector::step256, self, u, i, consts, v, un, sums)
            } else {
                by_shape!(self, vector::step512, self, u, i, consts, v, un, sums)
            }
        }
    }
}

/// The vector path, one source for AVX-512 and AVX2 ([`crate::wide`]): the 8 nodes of a group
/// in the lanes, their rows slot by slot. AVX2 holds 4 doubles to a vector, so it walks each
/// group as two halves of 4 lanes side by side in the same slot loop (two independent chains
/// of square roots and divisions for the processor to overlap). Every operation is the scalar
/// path's lane by lane, with no fused multiply-adds: the same bits.
#[cfg(target_arch = "x86_64")]
mod vector {
    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};

    use super::{RowKernel, Src, StepParams, SweepSums, WINDOW};
    use crate::stencil::vector::kick_drift;
    use crate::wide::{Wide, W4, W8};
    use hooke_model::math::{Coords, Real};

    /// What sweep 1 and sweep 2 share for one slot of N lanes: the current vector, `|d|^2`,
    /// the numerator of dL (the scalar path's operations lane by lane), the records of the
    /// neighbours, the slot's stiffness, rest length and lever, and the real lanes.
    struct Slot<W: Wide> {
        d: [W::F; 3],
        d2: W::F,
        num: W::F,
        k: W::F,
        rest: W::F,
        lever: W::F,
        real: W::M,
        nb: [W::F; 7],
    }

    /// `a . b` over the first `D` components, added as the scalar path adds them.
    #[inline(always)]
    fn dot<W: Wide, const D: usize>(a: [W::F; 3], b: [W::F; 3]) -> W::F {
        let s = a[0] * b[0] + a[1] * b[1];
        if D == 3 {
            s + a[2] * b[2]
        } else {
            s
        }
    }

    /// The operations of the N entries from `e` (a slot's, or a half of one).
    ///
    /// # Safety
    /// The N entries are in bounds of every slot array; `me` the lanes' own records
    /// transposed; `base` points to the records.
    #[inline(always)]
    unsafe fn slot_at<W: Wide, const D: usize, const LEVER: bool, const STORED: bool>(
        w: W,
        rk: &RowKernel,
        base: *const Real,
        me: &[W::F; 7],
        e: usize,
    ) -> Slot<W> {
        let s = &rk.slots;
        // SAFETY: by the caller's contract, the N entries are in bounds of every slot array,
        // and each names a record (a neighbour's or the dummy's).
        unsafe {
            let js = std::slice::from_raw_parts(s.j.as_ptr().add(e), W::N);
            let real = w.real(js.as_ptr(), rk.dummy() as u32);
            let nb = w.records(base, js);
            let z = w.zero();
            let mut big = [z; 3];
            let mut wv = [z; 3];
            for c in 0..D {
                big[c] = nb[c] - me[c];
                wv[c] = nb[3 + c] - me[3 + c];
            }
            let d = [big[0] + wv[0], big[1] + wv[1], big[2] + wv[2]];
            let d2 = dot::<W, D>(d, d);
            let num = w.splat(2.0) * dot::<W, D>(big, wv) + dot::<W, D>(wv, wv);
            let k = w.load(s.k.as_ptr().add(e));
            let rest = if STORED {
                w.load(s.rest.as_ptr().add(e))
            } else {
                w.sqrt(dot::<W, D>(big, big))
            };
            let lever = if LEVER {
                w.load(s.lever.as_ptr().add(e))
            } else {
                rest
            };
            Slot {
                d,
                d2,
                num,
                k,
                rest,
                lever,
                real,
                nb,
            }
        }
    }

    /// Next group's neighbours into the cache: the records are scattered, the slot arrays
    /// stream (the hardware fetches those itself).
    ///
    /// # Safety
    /// `base` points to the records and group `g` is one of the kernel's (a prefetch of an
    /// address outside them would be harmless, but the index arithmetic assumes it).
    #[inline(always)]
    unsafe fn prefetch(rk: &RowKernel, base: *const Real, g: usize) {
        let s = &rk.slots;
        if g + 1 < s.start.len() {
            for e in 8 * s.start[g] as usize..8 * s.start[g + 1] as usize {
                // SAFETY: e is an entry; its neighbour (or the dummy) has a record.
                unsafe {
                    let j = *s.j.get_unchecked(e) as usize;
                    _mm_prefetch::<_MM_HINT_T0>(base.wrapping_add(8 * j) as *const i8);
                }
            }
        }
    }

    /// A window's values in node order, one array per component (aligned for vector loads).
    #[repr(C, align(64))]
    pub(super) struct Window(pub [[Real; WINDOW]; 3]);

    /// Lane `l` of `v` into `out[js[l] - i]`: N lanes of a group into its window's node
    /// order. Every `js[l] - i` is below `WINDOW` (the rows' nodes lie in the window).
    #[inline(always)]
    fn scatter<W: Wide>(w: W, v: W::F, js: &[u32], i: usize, out: &mut [Real; WINDOW]) {
        let lane = w.lanes(v);
        for l in 0..W::N {
            out[js[l] as usize - i] = lane[l];
        }
    }

    /// The nodes of group `g`'s lanes.
    #[inline(always)]
    fn group_nodes(rk: &RowKernel, g: usize) -> [u32; 8] {
        let lanes = &rk.slots.lanes[8 * g..8 * g + 8];
        std::array::from_fn(|l| (WINDOW * (8 * g / WINDOW) + lanes[l] as usize) as u32)
    }

    /// The records of group `g`'s lanes `js`, transposed: one vector set per N lanes (the
    /// second unused on AVX-512).
    ///
    /// # Safety
    /// `base` points to the records, which `js` name.
    #[inline(always)]
    unsafe fn own_records<W: Wide>(w: W, base: *const Real, js: &[u32; 8]) -> [[W::F; 7]; 2] {
        let mut me = [[w.zero(); 7]; 2];
        for h in 0..8 / W::N {
            // SAFETY: by the caller's contract.
            me[h] = unsafe { w.records(base, &js[h * W::N..]) };
        }
        me
    }

    /// Pools of the window of nodes i..i+64 into `out`; whether a real spring is past the
    /// screen.
    ///
    /// # Safety
    /// i a multiple of 64 with i + 64 <= n; records refreshed.
    #[inline(always)]
    unsafe fn pools<W: Wide, const D: usize, const LEVER: bool, const STORED: bool>(
        w: W,
        rk: &RowKernel,
        src: &Src,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        let base = rk.base(src.rec);
        let s = &rk.slots;
        let sv = w.splat(screen);
        // The sums in node order.
        let mut sums = Window([[0.0; WINDOW]; 3]);
        let mut hot = w.no_lanes();
        // SAFETY: by the caller's contract, in bounds as stated.
        unsafe {
            for g in i / 8..(i + WINDOW) / 8 {
                prefetch(rk, base, g + 2);
                let js = group_nodes(rk, g);
                let me = own_records(w, base, &js);
                let mut acc = [w.zero(); 2];
                for slot in s.start[g] as usize..s.start[g + 1] as usize {
                    for h in 0..8 / W::N {
                        let e = 8 * slot + W::N * h;
                        let t = slot_at::<W, D, LEVER, STORED>(w, rk, base, &me[h], e);
                        let l = w.sqrt(t.d2);
                        let dl = t.num / (l + t.rest);
                        hot = hot | w.gt_where(t.real, dl, sv * t.rest);
                        acc[h] = acc[h] + (t.k * t.lever) * dl;
                    }
                }
                for h in 0..8 / W::N {
                    scatter(w, acc[h], &js[h * W::N..], i, &mut sums.0[0]);
                }
            }
            for b in 0..WINDOW / W::N {
                let acc = w.load(sums.0[0].as_ptr().add(W::N * b));
                let sn = w.load(src.norm.as_ptr().add(i + W::N * b));
                w.store(out.as_mut_ptr().add(W::N * b), w.div_where_nonzero(acc, sn));
            }
        }
        w.any(hot)
    }

    /// Forces on the window of nodes i..i+64 into `f`, in node order.
    ///
    /// # Safety
    /// As [`pools`], with the pools in the records.
    #[inline(always)]
    unsafe fn forces<W: Wide, const D: usize, const LEVER: bool, const STORED: bool>(
        w: W,
        rk: &RowKernel,
        src: &Src,
        i: usize,
        f: &mut Window,
    ) {
        let base = rk.base(src.rec);
        let s = &rk.slots;
        let q = w.splat(rk.q);
        let one = w.splat(1.0);
        let plain = rk.q == 0.0;
        let z = w.zero();
        // SAFETY: by the caller's contract, in bounds as stated.
        unsafe {
            for g in i / 8..(i + WINDOW) / 8 {
                prefetch(rk, base, g + 2);
                let js = group_nodes(rk, g);
                let me = own_records(w, base, &js);
                // The plain law's pools are all +0: it reads none (the records may hold
                // another law's, and need no refresh).
                let pi = if plain { [z; 2] } else { [me[0][6], me[1][6]] };
                let mut acc = [[z; 3]; 2];
                for slot in s.start[g] as usize..s.start[g + 1] as usize {
                    for h in 0..8 / W::N {
                        let e = 8 * slot + W::N * h;
                        let t = slot_at::<W, D, LEVER, STORED>(w, rk, base, &me[h], e);
                        let l = w.sqrt(t.d2);
                        let inv = one / l;
                        let dl = t.num / (l + t.rest);
                        let r1 = (q * t.k) * t.lever;
                        let pj = if plain { z } else { t.nb[6] };
                        let tt = t.k * dl + r1 * (pi[h] + pj);
                        for c in 0..D {
                            acc[h][c] = acc[h][c] + tt * (t.d[c] * inv);
                        }
                    }
                }
                for c in 0..D {
                    for h in 0..8 / W::N {
                        scatter(w, acc[h][c], &js[h * W::N..], i, &mut f.0[c]);
                    }
                }
            }
        }
    }

    /// Forces on the window of nodes i..i+64, then its kick and drift N nodes at a time in
    /// node order (the sums' order).
    ///
    /// # Safety
    /// As [`forces`]; `u` and `inv_mass` hold the window's nodes, `v` and `un` its 64
    /// entries.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn step<W: Wide, const D: usize, const LEVER: bool, const STORED: bool>(
        w: W,
        rk: &RowKernel,
        src: &Src,
        i: usize,
        (inv_mass, p, dims): (&[Real], &StepParams, usize),
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // The window's forces in node order (its groups hold its nodes in another order).
        let mut f = Window([[0.0; WINDOW]; 3]);
        // SAFETY: by the caller's contract.
        unsafe { forces::<W, D, LEVER, STORED>(w, rk, src, i, &mut f) };
        let u: Option<&Coords> = src.old_u();
        let [vx, vy, vz] = v;
        let [nx, ny, nz] = un;
        for b in 0..WINDOW / W::N {
            let r = W::N * b..W::N * (b + 1);
            // SAFETY: by the caller's contract, in bounds as stated.
            unsafe {
                let fb = [
                    w.load(f.0[0][r.start..].as_ptr()),
                    w.load(f.0[1][r.start..].as_ptr()),
                    w.load(f.0[2][r.start..].as_ptr()),
                ];
                kick_drift(
                    w,
                    dims,
                    fb,
                    u,
                    inv_mass,
                    p,
                    i + r.start,
                    [&mut vx[r.clone()], &mut vy[r.clone()], &mut vz[r.clone()]],
                    [&mut nx[r.clone()], &mut ny[r.clone()], &mut nz[r.clone()]],
                    sums,
                )
            };
        }
    }

    /// [`pools`] on AVX-512.
    ///
    /// # Safety
    /// AVX-512F and AVX-512VL; as [`pools`].
    #[target_feature(enable = "avx512f,avx512vl")]
    pub(super) unsafe fn pools512<const D: usize, const LEVER: bool, const STORED: bool>(
        rk: &RowKernel,
        src: &Src,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        // SAFETY: the processor has the instructions, and the rest is this fn's contract.
        unsafe { pools::<W8, D, LEVER, STORED>(W8::new(), rk, src, i, out, screen) }
    }

    /// [`pools`] on AVX2.
    ///
    /// # Safety
    /// AVX2; as [`pools`].
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pools256<const D: usize, const LEVER: bool, const STORED: bool>(
        rk: &RowKernel,
        src: &Src,
        i: usize,
        out: &mut [Real],
        screen: Real,
    ) -> bool {
        // SAFETY: the processor has the instructions, and the rest is this fn's contract.
        unsafe { pools::<W4, D, LEVER, STORED>(W4::new(), rk, src, i, out, screen) }
    }

    /// [`step`] on AVX-512.
    ///
    /// # Safety
    /// AVX-512F and AVX-512VL; as [`step`].
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx512f,avx512vl")]
    pub(super) unsafe fn step512<const D: usize, const LEVER: bool, const STORED: bool>(
        rk: &RowKernel,
        src: &Src,
        i: usize,
        consts: (&[Real], &StepParams, usize),
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // SAFETY: the processor has the instructions, and the rest is this fn's contract.
        unsafe { step::<W8, D, LEVER, STORED>(W8::new(), rk, src, i, consts, v, un, sums) }
    }

    /// [`step`] on AVX2.
    ///
    /// # Safety
    /// AVX2; as [`step`].
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn step256<const D: usize, const LEVER: bool, const STORED: bool>(
        rk: &RowKernel,
        src: &Src,
        i: usize,
        consts: (&[Real], &StepParams, usize),
        v: [&mut [Real]; 3],
        un: [&mut [Real]; 3],
        sums: &mut SweepSums,
    ) {
        // SAFETY: the processor has the instructions, and the rest is this fn's contract.
        unsafe { step::<W4, D, LEVER, STORED>(W4::new(), rk, src, i, consts, v, un, sums) }
    }
}

#[cfg(test)]
mod tests {
    use hooke_model::body::Body;
    // The integrator keeps the kernel in step with broken and softened springs: these tests
    // step through it (hooke-core, a dev-dependency only).
    use hooke_core::dynamics::{Integrator, IntegratorOptions, TimeStep};
    use hooke_model::lattice::Lattice;
    use hooke_model::loading::Loading;
    use hooke_model::math::Real;
    use hooke_model::random::RandomSpec;
    use hooke_model::state::State;

    #[derive(Clone, Copy, PartialEq, Debug)]
    enum Path {
        Csr,
        /// The processor's widest vector path.
        Vector,
        /// The AVX2 path (where AVX-512 is there too).
        Avx2,
        Scalar,
    }

    /// With `stored`, one rest length is not `|X_j - X_i|` to the bit, so the kernel streams
    /// the rest lengths instead of recomputing them.
    fn body_with(dim: usize, q: Real, levers: bool, stored: bool) -> Body {
        let spec = RandomSpec::default();
        let hi = if dim == 3 {
            [7.0, 6.0, 5.0]
        } else {
            [23.0, 17.0, 0.0]
        };
        let mut lat = Lattice::random(dim, [0.0; 3], hi, 1.0, 1.0, spec, &|_| true).unwrap();
        if stored {
            lat.rest_lengths_mut()[3] *= 1.0 + 4.0 * Real::EPSILON;
        }
        let mut body = Body::uniform(lat, 1.0, q, 1.0);
        for (b, k) in body.k.iter_mut().enumerate() {
            *k = 0.7 + 0.6 * ((b * 7919) % 101) as Real / 101.0;
        }
        if levers {
            // Signed levers, as direction-weighted dispersion may give.
            let rest = body.lattice.rest_lengths();
            body.lever = Some(
                rest.iter()
                    .enumerate()
                    .map(|(b, l)| l * (1.3 - 0.9 * ((b * 31) % 17) as Real / 17.0))
                    .collect(),
            );
        }
        body
    }

    /// A damaged, softened, moving body stepped 40 times on `path`, with springs broken and
    /// softened between steps; returns the state and the kernel's name.
    fn run(body: &Body, path: Path) -> (State, &'static str) {
        let mut state = State::new(body);
        for b in 0..body.springs() {
            if b % 7 == 3 {
                state.kill_bond(body, b);
            } else if b % 11 == 5 {
                state.soften(body, b, 0.55);
            }
        }
        let dim = body.lattice.dim();
        for i in 0..body.nodes() {
            let x = body.lattice.pos.get(i);
            state.u.x_mut()[i] = 0.01 * (1.3 * x.y).sin();
            state.u.y_mut()[i] = 0.02 * (0.7 * x.x + 0.2 * x.z).cos();
            state.v.x_mut()[i] = 0.05 * (0.4 * x.x).cos();
            if dim == 3 {
                state.u.z_mut()[i] = 0.015 * (0.9 * x.x).sin();
                state.v.z_mut()[i] = 0.03 * (0.3 * x.y).sin();
            }
        }
        let opts = IntegratorOptions {
            time_step: TimeStep::Fixed {
                dt: 0.05,
                force: true,
            },
            damping: 0.2,
            portable: path == Path::Scalar,
            force_csr: path == Path::Csr,
            avx2: path == Path::Avx2,
            damage_proof: false,
        };
        let it = Integrator::new(body, &mut state, Loading::default(), &opts).unwrap();
        if path == Path::Avx2 {
            assert_eq!(it.kernel().name(), "rows-avx2");
        }
        let mut it = it;
        for step in 0..40 {
            it.step(body, &mut state);
            if step % 9 == 4 {
                for b in (step..body.springs()).step_by(97) {
                    if step % 2 == 0 {
                        it.break_spring(body, &mut state, b);
                    } else {
                        it.soften_spring(body, &mut state, b, 0.3);
                    }
                }
            }
        }
        (state, it.kernel().name())
    }

    fn bits(s: &State) -> Vec<u64> {
        s.u.as_flat()
            .iter()
            .chain(s.v.as_flat())
            .chain(&s.pool)
            .map(|x| x.to_bits())
            .collect()
    }

    /// Each whole window deals every one of its nodes to exactly one lane, `at` inverts
    /// `lanes`, a partial last window keeps its order, and the dealt groups store at most 6 %
    /// more entries than the rows hold (groups of consecutive nodes: about 20 % more).
    #[test]
    fn windows_deal_their_nodes_once_and_cut_the_padding() {
        for dim in [2, 3] {
            let spec = RandomSpec::default();
            let hi = if dim == 3 {
                [24.0, 22.0, 20.0]
            } else {
                [140.0, 120.0, 0.0]
            };
            let lat = Lattice::random(dim, [0.0; 3], hi, 1.0, 1.0, spec, &|_| true).unwrap();
            let body = Body::uniform(lat, 1.0, 0.2, 1.0);
            let n = body.nodes();
            assert!(
                !n.is_multiple_of(super::WINDOW),
                "a partial last window is part of the test"
            );
            let len = |i: usize| body.lattice.bonds.row(i).len();
            let (lanes, at) = super::deal(n, len);
            for i in 0..n {
                let p = super::WINDOW * (i / super::WINDOW) + at[i] as usize;
                assert_eq!(super::WINDOW * (p / super::WINDOW) + lanes[p] as usize, i);
            }
            for i in super::WINDOW * (n / super::WINDOW)..n {
                assert_eq!(
                    at[i] as usize,
                    i % super::WINDOW,
                    "the partial window keeps its order"
                );
            }
            let stored = |lanes: &[u8]| -> usize {
                (0..lanes.len() / 8)
                    .map(|g| {
                        let w = (0..8)
                            .map(|l| super::WINDOW * (g / 8) + lanes[8 * g + l] as usize)
                            .filter(|&i| i < n)
                            .map(len)
                            .max()
                            .unwrap_or(0);
                        8 * w
                    })
                    .sum()
            };
            let real: usize = (0..n).map(len).sum();
            let (dealt, consecutive) = (stored(&lanes), stored(&super::deal(n, |_| 0).0));
            let (dealt, consecutive) = (
                dealt as Real / real as Real,
                consecutive as Real / real as Real,
            );
            assert!(
                dealt < 1.06 && consecutive > 1.15,
                "dim {dim}: {dealt} {consecutive}"
            );
            // The kernel on the dealt rows gives the CSR kernel's bits (the test below, on
            // smaller bodies); here the same for a body of several hundred windows.
            let (rows, csr) = (run(&body, Path::Vector).0, run(&body, Path::Csr).0);
            assert!(bits(&rows) == bits(&csr), "dim {dim}");
        }
    }

    /// A state swept with one body and then with another of as many nodes (here the same
    /// lattice stretched by half) gets its records rebuilt: the forces are the CSR kernel's.
    #[test]
    fn records_follow_the_body() {
        use crate::{partials_len, Kernel, StepParams};
        use hooke_model::lattice::Bonds;
        use hooke_model::math::Coords;
        let a = body_with(3, 0.3, false, false);
        let mut b = a.clone();
        let mut pos = b.lattice.pos.clone();
        for c in pos.xyz_mut() {
            c.iter_mut().for_each(|x| *x *= 1.5);
        }
        let ends = b.lattice.bonds.ends.clone();
        b.lattice.bonds = Bonds::from_pairs(b.nodes(), ends, &pos, [0.0; 3])
            .unwrap()
            .into();
        b.lattice.pos = pos;
        let mut state = State::new(&a);
        for i in 0..a.nodes() {
            state.u.x_mut()[i] = 0.01 * (1.3 * a.lattice.pos.y()[i]).sin();
        }
        let p = StepParams {
            dt: 0.01,
            damping: 0.0,
            accel: [0.0; 3],
            plane: false,
        };
        let n = a.nodes();
        let step = |body: &Body, kernel: &Kernel, state: &mut State| {
            let (mut un, mut parts) = (Coords::zeros(n), vec![Default::default(); partials_len(n)]);
            kernel.pools(body, state);
            kernel.force_kick_drift(body, state, &vec![1.0; n], &p, &mut un, &mut parts);
            un
        };
        let rows_a = Kernel::for_body(&a, &state);
        step(&a, &rows_a, &mut state);
        let mut again = state.clone();
        let (rows_b, csr) = (Kernel::for_body(&b, &state), Kernel::Csr { plain: false });
        let via_rows = step(&b, &rows_b, &mut state);
        let via_csr = step(&b, &csr, &mut again);
        assert!(via_rows
            .as_flat()
            .iter()
            .zip(via_csr.as_flat())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
        assert_ne!(via_rows, step(&a, &csr, &mut again));
    }

    /// The row kernel, vector and scalar, gives the CSR kernel's bits: 2D and 3D, with broken
    /// and softened springs (before the run and between steps), signed dispersion levers, the
    /// plain law and damping.
    #[test]
    fn rows_give_the_bits_of_the_csr_kernel() {
        use super::super::stencil::{simd_lanes, Lanes};
        let lanes = simd_lanes();
        let mut paths = vec![Path::Vector, Path::Scalar];
        #[cfg(target_arch = "x86_64")]
        if lanes == Some(Lanes::Avx512) && std::arch::is_x86_feature_detected!("avx2") {
            paths.push(Path::Avx2);
        }
        for dim in [2, 3] {
            for (q, levers, stored) in [
                (0.3, false, false),
                (-0.2, true, false),
                (0.0, false, false),
                (0.3, false, true),
                (-0.2, true, true),
            ] {
                let body = body_with(dim, q, levers, stored);
                let k = super::RowKernel::new(&body, &State::new(&body)).unwrap();
                assert_eq!(k.slots.rest.is_empty(), !stored, "rest lengths recomputed");
                let (csr, name) = run(&body, Path::Csr);
                assert_eq!(name, "csr");
                assert!(csr.u.as_flat().iter().any(|&x| x != 0.0));
                for &path in &paths {
                    let (s, name) = run(&body, path);
                    let want = match (path, lanes) {
                        (Path::Vector, Some(Lanes::Avx512)) => "rows-avx512",
                        (Path::Vector, Some(Lanes::Avx2)) | (Path::Avx2, _) => "rows-avx2",
                        _ => "rows",
                    };
                    if lanes.is_some() {
                        assert_eq!(name, want);
                    }
                    assert!(
                        bits(&s) == bits(&csr) && s.alive == csr.alive,
                        "dim {dim} q {q} levers {levers} stored {stored} {path:?}: states differ"
                    );
                }
                // A lattice that shed its rest lengths (`Lattice::shed_rest`) gives the same
                // bits on every path, the CSR kernel's (which then recomputes them) included;
                // one whose lengths are not `|X_j - X_i|` keeps them.
                let mut shed = body.clone();
                assert_eq!(shed.lattice.shed_rest(), !stored);
                assert_eq!(shed.lattice.bonds.stored_rest().is_none(), !stored);
                for &path in paths.iter().chain(&[Path::Csr]) {
                    let s = run(&shed, path).0;
                    assert!(
                        bits(&s) == bits(&csr) && s.alive == csr.alive,
                        "dim {dim} q {q} levers {levers} shed {path:?}: states differ"
                    );
                }
            }
        }
    }

    /// A rank's kernel keeps only its own rows ([`RowKernel::keep_rows`]): its sweeps of its
    /// share give the whole kernel's bits there, with a fraction of the slots.
    #[test]
    fn a_share_keeps_its_own_rows_only() {
        use crate::share::Share;
        use crate::{partials_len, Kernel, StepParams};
        use hooke_model::math::Coords;
        // A random3d block of more than three chunks of nodes (a share of three ranks).
        let lat = Lattice::random(
            3,
            [0.0; 3],
            [32.0, 28.0, 26.0],
            1.0,
            1.0,
            RandomSpec::default(),
            &|_| true,
        )
        .unwrap();
        let body = Body::uniform(lat, 1.0, 0.3, 1.0);
        assert!(body.nodes() > 3 * crate::CHUNK);
        let n = body.nodes();
        let mut state = State::new(&body);
        for i in 0..n {
            state.u.x_mut()[i] = 0.01 * (1.3 * body.lattice.pos.y()[i]).sin();
            state.u.z_mut()[i] = 0.02 * (0.7 * body.lattice.pos.x()[i]).cos();
        }
        let p = StepParams {
            dt: 0.01,
            damping: 0.0,
            accel: [0.0; 3],
            plane: false,
        };
        let step = |kernel: &Kernel, share: &Share, state: &State| {
            let mut st = state.clone();
            let (mut un, mut parts) = (Coords::zeros(n), vec![Default::default(); partials_len(n)]);
            kernel.pools_shared(&body, &mut st, Real::INFINITY, Some(share));
            kernel.force_kick_drift_shared(
                &body,
                &mut st,
                &vec![1.0; n],
                &p,
                Some(&mut un),
                &mut parts,
                Some(share),
            );
            (st, un)
        };
        let whole = Kernel::for_body(&body, &state);
        let Kernel::Rows(rk) = &whole else {
            return; // No vector instructions: random bodies run on the CSR kernel.
        };
        let all = rk.slots.j.len();
        let mut kept_in_all = 0;
        for rank in 0..3 {
            let share = Share::new(&body, 3, rank, &[]);
            let own = share.mine();
            let mut mine = whole.clone();
            mine.keep_rows(own.clone());
            let Kernel::Rows(kept) = &mine else {
                unreachable!()
            };
            // The ranks' slots partition the whole kernel's.
            let slots = kept.slots.j.len();
            assert!(kept.slots.k.len() == slots && slots < all);
            // Built for the share from the start: the same slots.
            let built = super::RowKernel::new_for(&body, &state, own.clone()).unwrap();
            assert!(built.slots.start == kept.slots.start && built.slots.j == kept.slots.j);
            let kb = |k: &[Real]| k.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(kb(&built.slots.k) == kb(&kept.slots.k));
            kept_in_all += slots;
            // Springs broken after the split: the kernels' entries go as the state's do,
            // among them springs that cross to the next rank.
            let ends = &body.lattice.bonds.ends;
            let cut: Vec<usize> = (0..body.springs())
                .filter(|&b| {
                    let [i, j] = ends[b].map(|v| v as usize);
                    own.contains(&i) != own.contains(&j)
                })
                .step_by(7)
                .chain((0..body.springs()).step_by(53))
                .collect();
            assert!(cut.len() > 20);
            let mut broken = state.clone();
            let (mut whole, mut mine) = (whole.clone(), mine.clone());
            for &b in &cut {
                broken.kill_bond(&body, b);
                whole.bond_killed(&body, b);
                mine.bond_killed(&body, b);
            }
            // The widest vector path, the scalar path and (where the processor has AVX-512)
            // the AVX2 path.
            for path in 0..3 {
                let (mut w, mut m) = (whole.clone(), mine.clone());
                match path {
                    1 => {
                        w.set_simd(false);
                        m.set_simd(false);
                    }
                    2 if w.name() == "rows-avx512" => {
                        assert!(w.use_avx2() && m.use_avx2());
                    }
                    2 => continue,
                    _ => {}
                }
                let a = step(&w, &share, &broken);
                let b = step(&m, &share, &broken);
                let same = |x: &[Real], y: &[Real]| {
                    x[own.clone()]
                        .iter()
                        .zip(&y[own.clone()])
                        .all(|(x, y)| x.to_bits() == y.to_bits())
                };
                let at = format!("rank {rank}, path {path} ({})", m.name());
                for c in 0..3 {
                    assert!(same(a.1.comp(c), b.1.comp(c)), "{at}: displacements");
                    assert!(same(a.0.v.comp(c), b.0.v.comp(c)), "{at}: velocities");
                }
                assert!(same(&a.0.pool, &b.0.pool), "{at}: pools");
                // Records of its own nodes, its ghosts and the dummy only.
                let ghosts = kept.ghosts.len();
                assert!(
                    ghosts > 0 && ghosts < own.len() / 2,
                    "{at}: {ghosts} ghosts"
                );
                assert_eq!(b.0.rec.len(), own.len() + ghosts + 1);
                assert_eq!(a.0.rec.len(), n + 1);
                assert!(a.1.comp(0)[own.clone()].iter().any(|&x| x != 0.0));
            }
        }
        assert_eq!(kept_in_all, all);
    }
}
