//! Sharing a run's work between processes (MPI ranks) with results bit-identical to one process.
//!
//! Every rank holds the whole body and state and runs the same control flow: loads, boundary
//! conditions, contact, the fracture decisions, the energy ledger and the output all see the
//! same data on every rank, so they give the same bits on every rank and as in one process.
//! What is split are the two sweeps of a step, which are nearly all of its cost (and the same
//! sweeps in the stable-step estimate at set-up, [`crate::stability::Split`]): rank r owns
//! a contiguous range of whole node chunks ([`crate::kernel::CHUNK`] nodes each) and
//!
//! - sweep 1: computes the records of the springs in its nodes' rows and its nodes' pools
//!   `p_n`, and sends the pools its neighbours' sweeps read (its [`Halo`]);
//! - sweep 2: forces, kick and drift of its own nodes, after which it sends the new
//!   displacements through the same halo; the per-chunk partial sums (damping, body-force
//!   work) and the loaded and prescribed nodes' velocities and forces are all-gathered.
//!
//! Between steps a rank's copy of the other ranks' nodes is therefore current only on its
//! ghost nodes (the far ends of its springs, and the loaded and prescribed nodes, which every
//! rank's bookkeeping reads). Whatever reads the whole state (output, checkpoints, the
//! blow-up check, contact, the fracture criteria's decisions) first makes every node current
//! with all-gathers (`Integrator::gather_state`), so every rank still sees one state there.
//!
//! Each value is computed by exactly the operations one process would use, and the partial
//! sums are added in chunk order on every rank, so any number of ranks gives the bits of one.
//! A spring that crosses two ranks is computed by both from the same displacements, and its
//! fate (broken or not) is decided by the same replicated criterion: identically on both.
//!
//! The memory per rank shrinks with the number of ranks only in the kernel: a rank's row
//! kernel holds its own nodes' rows, and records of its own nodes and ghosts only
//! ([`crate::kernel::Kernel::keep_rows`]); every rank holds the whole body and state. What a step moves shrinks too: a rank receives its ghosts' `1 + dim`
//! values, the nodes along its cuts, not every node (`docs/mpi.md`, `docs/scaling.md`). The
//! transport is behind [`Team`]: MPI in the `hooke` binary (feature `mpi`), threads in the
//! tests.

use std::ops::Range;

use crate::math::Real;

pub use hooke_kernel::share::{Halo, Share};

pub mod parts;
mod piece;
pub use piece::{Piece, PAD};

/// The processes sharing a run, and the two collective operations a step needs.
///
/// Every rank calls the operations in the same order with the same `parts`.
pub trait Team: Send + Sync + std::fmt::Debug {
    /// This process's rank, `0..size`.
    fn rank(&self) -> usize;
    /// Number of processes.
    fn size(&self) -> usize;
    /// All-gather in place: on entry, rank r's values of `data[parts[r].clone()]` are valid on
    /// rank r; on return every rank holds every rank's values there. `parts` are ascending,
    /// disjoint and the same on every rank (one per rank, possibly empty).
    fn gather(&self, data: &mut [Real], parts: &[Range<usize>]);
    /// Logical or of `flags` over the ranks, in place.
    fn any(&self, flags: &mut [bool]);
    /// Point to point: send `out[s]` to each rank s whose `out[s]` is not empty, and fill each
    /// non-empty `inp[s]` with what rank s sends. Each rank's lengths must match its peers'
    /// (a [`Halo`] computed alike on every rank guarantees it); `out[rank]` and `inp[rank]` are
    /// empty.
    fn trade(&self, out: &[Vec<Real>], inp: &mut [Vec<Real>]);
}

/// Every rank's run of a list (this rank's is `values`), concatenated in rank order into
/// `all`: two all-gathers (the lengths, then the values; `parts` their scratch, kept by the
/// caller so that a step allocates nothing once they have grown). Collective.
pub fn gather_runs(
    team: &dyn Team,
    values: &[Real],
    all: &mut Vec<Real>,
    parts: &mut Vec<Range<usize>>,
) {
    let (size, rank) = (team.size(), team.rank());
    parts.clear();
    parts.extend((0..size).map(|r| r..r + 1));
    all.clear();
    all.resize(size, 0.0);
    all[rank] = values.len() as Real;
    team.gather(all, parts);
    let mut at = 0;
    for (r, p) in parts.iter_mut().enumerate() {
        let l = all[r] as usize;
        *p = at..at + l;
        at += l;
    }
    all.clear();
    all.resize(at, 0.0);
    all[parts[rank].clone()].copy_from_slice(values);
    team.gather(all, parts);
}

/// Send this rank's values of `fields` at the nodes its peers read (`halo.send`) and take
/// theirs at its ghosts (`halo.recv`): one message per peer, a node's fields side by side.
/// `out` and `inp` (one per rank) are the messages' buffers, kept by the caller so that a
/// step allocates nothing.
pub fn trade_halo(
    team: &dyn Team,
    halo: &Halo,
    out: &mut [Vec<Real>],
    inp: &mut [Vec<Real>],
    fields: &mut [&mut [Real]],
) {
    let k = fields.len();
    for (o, nodes) in out.iter_mut().zip(&halo.send) {
        o.clear();
        for &i in nodes {
            o.extend(fields.iter().map(|f| f[i as usize]));
        }
    }
    for (i, nodes) in inp.iter_mut().zip(&halo.recv) {
        i.resize(k * nodes.len(), 0.0);
    }
    team.trade(out, inp);
    for (inp, nodes) in inp.iter().zip(&halo.recv) {
        for (vals, &i) in inp.chunks_exact(k).zip(nodes) {
            for (f, &v) in fields.iter_mut().zip(vals) {
                f[i as usize] = v;
            }
        }
    }
}

/// Whether `parts` fit [`Team::gather`]'s contract over `len` values: one per rank of a team of
/// `size`, ascending and disjoint, inside `0..len`. Overlapping parts are an error in MPI's
/// all-gather (and their result depends on the order the messages land), so both transports
/// refuse them: a split that produced them once went unseen for a long time.
pub fn parts_fit(parts: &[Range<usize>], size: usize, len: usize) -> bool {
    parts.len() == size
        && parts.iter().all(|p| p.start <= p.end && p.end <= len)
        && parts.windows(2).all(|w| w[0].end <= w[1].start)
}

/// A team of one: the default (no exchange).
#[derive(Debug, Default)]
pub struct Alone;

impl Team for Alone {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn gather(&self, _data: &mut [Real], _parts: &[Range<usize>]) {}
    fn any(&self, _flags: &mut [bool]) {}
    fn trade(&self, _out: &[Vec<Real>], _inp: &mut [Vec<Real>]) {}
}

/// Ranks as threads of one process, for tests: each rank is a thread with its own body and
/// state, and the collectives go through shared buffers and a barrier.
#[derive(Debug)]
pub struct Threads {
    rank: usize,
    shared: std::sync::Arc<ThreadsShared>,
}

#[derive(Debug)]
struct ThreadsShared {
    size: usize,
    barrier: std::sync::Barrier,
    reals: std::sync::Mutex<Vec<Real>>,
    flags: std::sync::Mutex<Vec<bool>>,
    /// Messages of a trade: `size x size` slots, the one from rank a to rank b at `a size + b`.
    mail: std::sync::Mutex<Vec<Vec<Real>>>,
}

impl Threads {
    /// `size` team members, one per thread, rank i at index i.
    pub fn team(size: usize) -> Vec<Threads> {
        let shared = std::sync::Arc::new(ThreadsShared {
            size,
            barrier: std::sync::Barrier::new(size),
            reals: Default::default(),
            flags: Default::default(),
            mail: std::sync::Mutex::new(vec![Vec::new(); size * size]),
        });
        (0..size)
            .map(|rank| Threads {
                rank,
                shared: shared.clone(),
            })
            .collect()
    }
}

impl Team for Threads {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.shared.size
    }
    fn gather(&self, data: &mut [Real], parts: &[Range<usize>]) {
        let s = &self.shared;
        assert!(
            parts_fit(parts, s.size, data.len()),
            "rank {}: all-gather parts {parts:?} over {} values are not one per rank, ascending and disjoint",
            self.rank,
            data.len()
        );
        {
            let mut buf = s.reals.lock().unwrap();
            if buf.len() < data.len() {
                buf.resize(data.len(), 0.0);
            }
            let mine = parts[self.rank].clone();
            buf[mine.clone()].copy_from_slice(&data[mine]);
        }
        s.barrier.wait();
        {
            let buf = s.reals.lock().unwrap();
            for (r, p) in parts.iter().enumerate() {
                if r != self.rank {
                    data[p.clone()].copy_from_slice(&buf[p.clone()]);
                }
            }
        }
        s.barrier.wait();
    }
    fn any(&self, flags: &mut [bool]) {
        let s = &self.shared;
        if self.rank == 0 {
            let mut buf = s.flags.lock().unwrap();
            buf.clear();
            buf.resize(flags.len(), false);
        }
        s.barrier.wait();
        {
            let mut buf = s.flags.lock().unwrap();
            for (b, &f) in buf.iter_mut().zip(flags.iter()) {
                *b |= f;
            }
        }
        s.barrier.wait();
        flags.copy_from_slice(&s.flags.lock().unwrap());
        s.barrier.wait();
    }
    fn trade(&self, out: &[Vec<Real>], inp: &mut [Vec<Real>]) {
        let s = &self.shared;
        let (me, size) = (self.rank, s.size);
        {
            let mut mail = s.mail.lock().unwrap();
            for (to, o) in out.iter().enumerate() {
                let slot = &mut mail[me * size + to];
                slot.clear();
                slot.extend_from_slice(o);
            }
        }
        s.barrier.wait();
        {
            let mail = s.mail.lock().unwrap();
            for (from, i) in inp.iter_mut().enumerate() {
                let m = &mail[from * size + me];
                assert_eq!(
                    m.len(),
                    i.len(),
                    "trade from rank {from} to {me}: lengths differ"
                );
                i.copy_from_slice(m);
            }
        }
        s.barrier.wait();
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::body::Body;
    use crate::kernel::CHUNK;
    use crate::random::RandomSpec;
    use crate::Lattice;

    /// A random3d block of unit spacing and box `hi` with nu = 0.3 and more than three chunks
    /// of nodes (what a share of three ranks needs).
    pub(crate) fn block(hi: [Real; 3]) -> Body {
        let lat =
            Lattice::random(3, [0.0; 3], hi, 1.0, 1.0, RandomSpec::default(), &|_| true).unwrap();
        let body = Body::uniform(lat, 1.0, 0.3, 1.0);
        assert!(body.nodes() > 3 * CHUNK, "{} nodes", body.nodes());
        body
    }

    /// Every own node's displacement and velocity on a piece (`global`: the body's index of
    /// each of the piece's nodes) against one process's, bit for bit.
    pub(crate) fn assert_own_state(
        global: &[u32],
        own: Range<usize>,
        piece: &crate::State,
        alone: &crate::State,
        at: &str,
    ) {
        for i in own {
            let g = global[i] as usize;
            for c in 0..3 {
                assert_eq!(
                    piece.u.comp(c)[i].to_bits(),
                    alone.u.comp(c)[g].to_bits(),
                    "u of node {g}, {at}"
                );
                assert_eq!(
                    piece.v.comp(c)[i].to_bits(),
                    alone.v.comp(c)[g].to_bits(),
                    "v of node {g}, {at}"
                );
            }
        }
    }

    /// `body` strained by a smooth displacement field, with every `every`-th spring broken.
    pub(crate) fn strained(body: &Body, every: usize) -> crate::State {
        let mut state = crate::State::new(body);
        for b in (0..body.springs()).step_by(every) {
            state.kill_bond(body, b);
        }
        for i in 0..body.nodes() {
            let x = body.lattice.pos.get(i);
            state.u.x_mut()[i] = 0.01 * (1.3 * x.y).sin();
            state.u.y_mut()[i] = 0.02 * (0.7 * x.x + 0.2 * x.z).cos();
            state.u.z_mut()[i] = 0.015 * (0.9 * x.x).sin();
        }
        state
    }

    /// The shares cover every node once, in whole chunks, and every spring of a rank's rows
    /// is in its range or in its foreign list; each rank receives from every other what that
    /// one sends it, and that covers every node its sweeps read.
    #[test]
    fn shares_cover_nodes_and_rows() {
        let body = block([40.0, 20.0, 20.0]);
        let n = body.nodes();
        for size in 1..=4 {
            let everyone = [5, n / 2, n - 1];
            let shares: Vec<Share> = (0..size)
                .map(|r| Share::new(&body, size, r, &everyone))
                .collect();
            let mut next = 0;
            for s in &shares {
                assert_eq!(s.nodes, shares[0].nodes);
                let m = s.mine();
                assert_eq!(m.start, next);
                assert!(m.start % CHUNK == 0);
                next = m.end;
                let bonds = &*body.lattice.bonds;
                let mut reads: std::collections::BTreeSet<u32> =
                    everyone.iter().map(|&i| i as u32).collect();
                for i in m.clone() {
                    for e in bonds.row(i) {
                        let b = bonds.bond[e];
                        assert!(s.springs.contains(&(b as usize)) || s.foreign.contains(&b));
                    }
                }
                for b in s
                    .springs
                    .clone()
                    .chain(s.foreign.iter().map(|&b| b as usize))
                {
                    reads.extend(bonds.ends[b]);
                }
                let ghosts: std::collections::BTreeSet<u32> =
                    s.halo.recv.iter().flatten().copied().collect();
                let outside: Vec<u32> = reads
                    .into_iter()
                    .filter(|&i| !m.contains(&(i as usize)))
                    .collect();
                assert!(outside.iter().all(|i| ghosts.contains(i)));
                assert_eq!(ghosts.len(), outside.len(), "no ghost more than needed");
                for (r, t) in shares.iter().enumerate() {
                    assert_eq!(s.halo.recv[r], t.halo.send[s.rank]);
                    assert!(s.halo.recv[r]
                        .iter()
                        .all(|&i| t.mine().contains(&(i as usize))));
                }
            }
            assert_eq!(next, n);
            if size == 2 {
                // The cut is a surface: a few percent of the nodes, not half of them.
                let g = shares[0].halo.ghosts();
                assert!(g > 0 && g < n / 8, "{g} ghosts of {n} nodes");
            }
        }
    }

    /// A frame computed in parts by 1 to 4 ranks ([`crate::law::FramePart`]) gives the whole
    /// computation's bits: the pools and both energies on every rank, the forces, energy
    /// densities and stresses at each rank's own nodes; with broken springs and shed rest
    /// lengths.
    #[test]
    fn a_frame_in_parts_gives_the_bits_of_the_whole() {
        use crate::law::{frame_fields_in, frame_fields_part, FramePart, FrameScratch};
        let mut body = block([32.0, 28.0, 26.0]);
        body.lattice.shed_rest();
        let state = strained(&body, 13);
        let sp = state.springs(&body);
        let whole = frame_fields_in(
            &body,
            &state.u,
            sp,
            state.norm(),
            &mut FrameScratch::default(),
        );
        let bits = |x: &[Real]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for size in 1..=4 {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let (body, state, whole) = (&body, &state, &whole);
                    scope.spawn(move || {
                        let share = Share::new(body, size, team.rank(), &[]);
                        let part = FramePart {
                            team: &team,
                            share: &share,
                        };
                        let f = frame_fields_part(
                            body,
                            &state.u,
                            state.springs(body),
                            state.norm(),
                            &mut FrameScratch::default(),
                            Some(part),
                        );
                        let at = format!("{size} ranks, rank {}", team.rank());
                        assert_eq!(bits(&f.pool), bits(&whole.pool), "{at}");
                        assert_eq!(
                            f.strain.direct.to_bits(),
                            whole.strain.direct.to_bits(),
                            "{at}"
                        );
                        assert_eq!(
                            f.strain.dispersive.to_bits(),
                            whole.strain.dispersive.to_bits(),
                            "{at}"
                        );
                        let m = share.mine();
                        for c in 0..3 {
                            let (a, b) = (f.force.comp(c), whole.force.comp(c));
                            assert_eq!(bits(&a[m.clone()]), bits(&b[m.clone()]), "{at}");
                        }
                        let ed = (
                            &f.energy_density[m.clone()],
                            &whole.energy_density[m.clone()],
                        );
                        assert_eq!(bits(ed.0), bits(ed.1), "{at}");
                        let st = |s: &[[Real; 9]]| bits(s.as_flattened());
                        assert_eq!(
                            st(&f.stress[m.clone()]),
                            st(&whole.stress[m.clone()]),
                            "{at}"
                        );
                    });
                }
            });
        }
    }
}
