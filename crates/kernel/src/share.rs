//! A share of a body's sweeps: which nodes, springs and ghost nodes one process's sweeps cover
//! when several share a run ([`Share`], with its [`Halo`]). The kernels sweep a share; how
//! the processes trade what the halo names is the solver's (`hooke_core::team`).

use std::ops::Range;

use hooke_model::body::Body;
use hooke_model::CHUNK;

/// The nodes a rank trades with each other rank every step: those whose values the other
/// rank's sweeps and bookkeeping read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Halo {
    /// Per rank s: this rank's nodes that s reads, ascending (empty for this rank).
    pub send: Vec<Vec<u32>>,
    /// Per rank s: rank s's nodes that this rank reads (its ghosts there), ascending.
    pub recv: Vec<Vec<u32>>,
}

impl Halo {
    /// Ghost nodes in all.
    pub fn ghosts(&self) -> usize {
        self.recv.iter().map(Vec::len).sum()
    }

    /// Messages this rank sends per trade.
    pub fn messages(&self) -> usize {
        self.send.iter().filter(|s| !s.is_empty()).count()
    }
}

/// One process's share of the sweeps of a body (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Share {
    /// Every rank's nodes: whole chunks, ascending, covering `0..n`.
    pub nodes: Vec<Range<usize>>,
    /// This rank.
    pub rank: usize,
    /// Springs whose lower end is one of this rank's nodes, widened to whole blocks of the CSR
    /// kernel's sweep 1 (so that a block's break-screen flag is computed whole).
    pub springs: Range<usize>,
    /// Springs of this rank's rows outside `springs` (upper end here, lower end on a rank
    /// before): their records are computed one by one. Ascending.
    pub foreign: Vec<u32>,
    /// What this rank trades with the others each step.
    pub halo: Halo,
}

impl Share {
    /// Split the node chunks of `body` into `size` contiguous ranges of about equal spring
    /// count (each spring counted from both ends), and describe rank `rank`'s share. `everyone`
    /// are nodes that every rank reads each step (loaded and prescribed ones): they are in
    /// every rank's halo.
    pub fn new(body: &Body, size: usize, rank: usize, everyone: &[usize]) -> Share {
        let n = body.nodes();
        let bonds = &*body.lattice.bonds;
        let chunks = n.div_ceil(CHUNK);
        // Work of a chunk: its row entries plus one per node (the kick and drift).
        let work: Vec<usize> = (0..chunks)
            .map(|c| {
                let r = c * CHUNK..((c + 1) * CHUNK).min(n);
                bonds.offsets[r.end] as usize - bonds.offsets[r.start] as usize + r.len()
            })
            .collect();
        let total: usize = work.iter().sum();
        let mut nodes = Vec::with_capacity(size);
        let (mut c, mut done) = (0, 0usize);
        for r in 0..size {
            let first = c;
            // Take chunks while the running total stays at or below rank r's fair end.
            let goal = (total as u128 * (r as u128 + 1) / size.max(1) as u128) as usize;
            while c < chunks && (r + 1 == size || done + work[c] / 2 < goal) {
                done += work[c];
                c += 1;
            }
            nodes.push((first * CHUNK).min(n)..(c * CHUNK).min(n));
        }
        let rank = rank.min(size - 1);
        let halo = halo(body, &nodes, rank, everyone);
        Share {
            halo,
            ..Share::without_halo(body, nodes, rank)
        }
    }

    /// Rank `rank`'s share of its sweeps when the ranks own `nodes` (whole chunks, ascending,
    /// covering the body's nodes), with no halo: what a piece's kernel sweeps
    /// (`hooke_core::team::Piece::share`, whose trades go through the piece's own halo).
    pub fn without_halo(body: &Body, nodes: Vec<Range<usize>>, rank: usize) -> Share {
        let bonds = &*body.lattice.bonds;
        let mine = nodes[rank].clone();
        let block = crate::BLOCK;
        let m = bonds.len();
        // Springs are sorted by (lower end, upper end): those with the lower end here are one
        // range.
        let first = bonds.ends.partition_point(|e| (e[0] as usize) < mine.start);
        let last = bonds.ends.partition_point(|e| (e[0] as usize) < mine.end);
        let springs = if first < last {
            (first / block * block)..(last.div_ceil(block) * block).min(m)
        } else {
            0..0
        };
        let mut foreign: Vec<u32> = mine
            .clone()
            .flat_map(|i| bonds.row(i).map(|e| bonds.bond[e]))
            .filter(|&b| !springs.contains(&(b as usize)))
            .collect();
        foreign.sort_unstable();
        foreign.dedup();
        let halo = Halo {
            send: vec![Vec::new(); nodes.len()],
            recv: vec![Vec::new(); nodes.len()],
        };
        Share {
            nodes,
            rank,
            springs,
            foreign,
            halo,
        }
    }

    /// This rank's nodes.
    pub fn mine(&self) -> Range<usize> {
        self.nodes[self.rank].clone()
    }

    /// This rank's node chunks.
    pub fn chunks(&self) -> Range<usize> {
        crate::chunks_of(&self.mine())
    }

    /// Bytes this rank receives per step of the explicit integrator without contact: its
    /// ghosts' pools and `dim` displacement components (`1 + dim` values per ghost) and 2
    /// partial sums per chunk of the other ranks. The loaded and prescribed nodes' velocities
    /// and forces and the all-gathers that contact, breaking, output and checks add are not
    /// counted.
    pub fn received_per_step(&self, dim: usize) -> usize {
        let n = self.nodes.last().map_or(0, |r| r.end);
        let chunks = n.div_ceil(CHUNK);
        8 * ((1 + dim) * self.halo.ghosts() + 2 * (chunks - self.chunks().len()))
    }

    /// Messages this rank sends per step without contact: two trades (pools, displacements)
    /// with each rank in its halo.
    pub fn messages_per_step(&self) -> usize {
        2 * self.halo.messages()
    }

    /// Every rank's node chunks, in units of `per` values per chunk (the partial sums).
    pub fn chunk_parts(&self, per: usize) -> Vec<Range<usize>> {
        self.nodes
            .iter()
            .map(|r| {
                let c = crate::chunks_of(r);
                per * c.start..per * c.end
            })
            .collect()
    }
}

/// Rank `rank`'s halo when the ranks own `nodes` (see [`Halo`]): the far ends of every spring
/// that crosses two ranks, the ends of the springs that a rank's sweep 1 computes beyond its
/// own rows (its spring range is widened to whole blocks), and the `everyone` nodes.
fn halo(body: &Body, nodes: &[Range<usize>], rank: usize, everyone: &[usize]) -> Halo {
    let size = nodes.len();
    let bonds = &*body.lattice.bonds;
    let n = body.nodes();
    let owner = |i: usize| nodes.partition_point(|r| r.end <= i);
    let mut send: Vec<Vec<u32>> = vec![Vec::new(); size];
    let mut recv: Vec<Vec<u32>> = vec![Vec::new(); size];
    let mut note = |needs: usize, i: usize| {
        let has = owner(i);
        if has == needs {
            return;
        }
        if needs == rank {
            recv[has].push(i as u32);
        } else if has == rank {
            send[needs].push(i as u32);
        }
    };
    // Springs are sorted by lower end, so the ranks' rows are consecutive ranges of them.
    let block = crate::BLOCK;
    let m = bonds.len();
    for (r, own) in nodes.iter().enumerate() {
        let first = bonds.ends.partition_point(|e| (e[0] as usize) < own.start);
        let last = bonds.ends.partition_point(|e| (e[0] as usize) < own.end);
        if first < last {
            let wide = (first / block * block)..(last.div_ceil(block) * block).min(m);
            for b in (wide.start..first).chain(last..wide.end) {
                for e in bonds.ends[b] {
                    note(r, e as usize);
                }
            }
        }
    }
    let mine = nodes[rank].clone();
    for e in &bonds.ends {
        let [i, j] = e.map(|v| v as usize);
        let (oi, oj) = (owner(i), owner(j));
        if oi != oj && (oi == rank || oj == rank) {
            note(oi, j);
            note(oj, i);
        }
    }
    for &i in everyone.iter().filter(|&&i| i < n) {
        if mine.contains(&i) {
            (0..size).for_each(|r| note(r, i));
        } else {
            note(rank, i);
        }
    }
    for l in send.iter_mut().chain(recv.iter_mut()) {
        l.sort_unstable();
        l.dedup();
    }
    Halo { send, recv }
}
