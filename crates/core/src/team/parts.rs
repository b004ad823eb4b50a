//! A rank's piece of a random body set up from its part alone ([`crate::random::part`]): no
//! rank builds, or holds, the whole body.
//!
//! [`assemble`] gives each rank the [`Piece`] and the piece's lattice that [`Piece::cut`]
//! would cut out of the whole body for a share that owns the same nodes, by four collective
//! steps:
//!
//! 1. **Counts.** Each rank samples (without triangulating) the nodes of an even split of the
//!    Morton keys and counts them; the counts, all-gathered, number the body's nodes (the
//!    body's order is the keys' order).
//! 2. **Whole chunks.** A piece owns whole chunks of [`CHUNK`] nodes, as a share does (its
//!    kernels' windows and per-chunk partial sums then fall as they fall in the body). The
//!    boundaries are moved to the nearest multiple of [`CHUNK`], the keys found there are
//!    all-gathered, and each rank builds the part of its key range, once.
//! 3. **Ghosts.** Each rank asks the owners of its ghosts (by key range) for their index in
//!    the body, volume and boundary share, naming them by grid index; the questions are its
//!    halo's receives, the answers' order its peers' sends.
//! 4. **Springs.** A spring's index in the body is its place among the springs ordered by
//!    their ends: the springs whose lower end a rank owns are numbered from the all-gathered
//!    counts, and those whose lower end is a ghost are asked of its owner.
//!
//! The body's cell volume (its volume over its nodes) is summed per chunk, chunks in order,
//! as [`crate::Lattice::random`] sums it. Memory: a rank holds its part (and, in step 1, the
//! keys of its share), never the body.

use std::ops::Range;

use super::{Halo, Piece, Share, Team, PAD};
use crate::error::{Error, Result};
use crate::kernel::CHUNK;
use crate::lattice::{Bonds, Cells, Lattice, LatticeKind, Topology};
use crate::math::{Coords, Real};
use crate::random::part::{Sampling, KEY_END};

/// Rank `team.rank()`'s piece of the random body `body`, built from its part ([`Sampling::part`]
/// with `margin`: four spacings suffice) (every rank passes the same body; see the module docs),
/// with its lattice, and every rank's nodes in the body's numbering (a share's `nodes`).
/// Collective: a failure on any rank stops every rank, each with that rank's reason.
pub fn assemble(team: &dyn Team, body: &Sampling, margin: Real) -> Result<(Piece, Lattice, Share)> {
    let (rank, size) = (team.rank(), team.size());
    let even = |r: usize| ((KEY_END as u128 * r as u128) / size as u128) as u64;
    let trial = all_ok(team, body.own_keys(even(rank)..even(rank + 1)))?;
    // 1. Counts and the body's numbering.
    let mut counts = vec![0.0; size];
    counts[rank] = trial.len() as Real;
    team.gather(&mut counts, &singles(size));
    let counts: Vec<usize> = counts.iter().map(|&c| c as usize).collect();
    let offsets: Vec<usize> = prefix(&counts);
    let total = offsets[size];
    if total > u32::MAX as usize {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: format!("{total} nodes: more than a u32 index holds"),
        });
    }
    // 2. Boundaries on whole chunks, and their keys.
    let (split, keys) = split_keys(team, &trial, &offsets);
    drop(trial);
    let part = all_ok(team, body.part(keys[rank]..keys[rank + 1], margin))?;
    let want = split[rank + 1] - split[rank];
    let mut wrong = [part.own.len() != want];
    team.any(&mut wrong);
    if wrong[0] {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: "two nodes share a Morton key where the body is split between processes; \
                  change the seed or the spacing slightly"
                .into(),
        });
    }
    // 3. Ghosts: asked of their owners by grid index.
    let owner = |k: u64| keys[1..size].partition_point(|&s| s <= k);
    let (ghosts, ghost_info, sends) = ask_ghosts(team, &part, split[rank], &owner)?;
    // 4. Springs: numbered by the owners of their lower ends.
    let global = |i: usize| -> usize {
        if part.own.contains(&i) {
            split[rank] + i - part.own.start
        } else {
            let g = ghosts.binary_search(&i).expect("a ghost");
            ghost_info[g].0
        }
    };
    let (springs, spring_first) = number_springs(team, &part, &global, &owner)?;
    // The piece: dummies, ghosts below, own nodes, ghosts above (the part's order).
    let below = part.own.start;
    let pad = below.next_multiple_of(CHUNK) - below;
    let n = pad + part.pos.len();
    let mut global_ids = vec![PAD; pad];
    global_ids.extend((0..part.pos.len()).map(|i| global(i) as u32));
    let own = pad + part.own.start..pad + part.own.end;
    let ghost_local: Vec<usize> = ghosts.iter().map(|&i| pad + i).collect();
    let mut recv = vec![Vec::new(); size];
    for (k, &i) in ghosts.iter().enumerate() {
        recv[owner(part.key[i])].push(ghost_local[k] as u32);
    }
    let send = sends
        .into_iter()
        .map(|s| s.into_iter().map(|at| (own.start + at) as u32).collect())
        .collect();
    let pick = |c: usize| -> Vec<Real> {
        let mut v = vec![0.0; pad];
        v.extend(part.pos.iter().map(|p| p[c]));
        v
    };
    let pos = Coords::from_components(&pick(0), &pick(1), &pick(2));
    let pairs: Vec<[u32; 2]> = part
        .springs
        .iter()
        .map(|(e, _)| e.map(|i| (pad + i as usize) as u32))
        .collect();
    let bonds = Bonds::from_pairs(n, pairs, &pos, [0.0; 3])?;
    let mut node = vec![0.0; n];
    let mut surface = vec![[0.0; 3]; n];
    for (k, &i) in ghosts.iter().enumerate() {
        node[pad + i] = ghost_info[k].1;
        surface[pad + i] = ghost_info[k].2;
    }
    node[own.clone()].copy_from_slice(&part.volume);
    surface[own.clone()].copy_from_slice(&part.surface);
    let (nodes, volume) = body_volume(team, &part.volume, &split);
    let cell_volume = volume / total as Real;
    // A dummy stands for no material, but a body built from the cells gives every node its
    // volume's mass, and a node needs a positive one: the mean.
    node[..pad].fill(cell_volume);
    let lattice = part_lattice(body, &part, pos, bonds, cell_volume, (node, surface));
    // The share's halo in the body's numbering (the piece trades its own, in its numbering):
    // what the figures of a share's traffic count.
    let to_global = |list: &Vec<u32>| list.iter().map(|&i| global_ids[i as usize]).collect();
    let halo = Halo { send, recv };
    let share = Share {
        nodes,
        rank,
        springs: spring_first[rank]..spring_first[rank + 1],
        foreign: Vec::new(),
        halo: Halo {
            send: halo.send.iter().map(to_global).collect(),
            recv: halo.recv.iter().map(to_global).collect(),
        },
    };
    let piece = Piece {
        global: global_ids,
        own,
        first: split[rank],
        total,
        springs,
        halo,
    };
    Ok((piece, lattice, share))
}

/// Where the body is split: rank r's nodes start at `split[r]` (whole chunks, near the trial
/// counts' `offsets`), and the Morton keys there, each found by the rank whose trial range
/// (`trial`, its sorted keys) holds the boundary (collective).
fn split_keys(team: &dyn Team, trial: &[u64], offsets: &[usize]) -> (Vec<usize>, Vec<u64>) {
    let (rank, size) = (team.rank(), team.size());
    let total = offsets[size];
    let mut split = vec![0usize; size + 1];
    split[size] = total;
    for r in 1..size {
        let at = (offsets[r] + CHUNK / 2) / CHUNK * CHUNK;
        split[r] = at.min(total).max(split[r - 1]);
    }
    let mut keys = vec![0.0; size + 1];
    keys[size] = Real::from_bits(KEY_END);
    // The boundary keys rank q finds: those of the boundaries inside its trial range.
    let finder = |s: usize| (0..size).find(|&q| offsets[q] <= s && s < offsets[q + 1]);
    let mut parts = vec![0..0; size];
    for r in 1..size {
        match finder(split[r]) {
            Some(q) => {
                if parts[q].is_empty() {
                    parts[q] = r..r + 1;
                } else {
                    parts[q].end = r + 1;
                }
            }
            None => keys[r] = Real::from_bits(KEY_END),
        }
    }
    for r in parts[rank].clone() {
        keys[r] = Real::from_bits(trial[split[r] - offsets[rank]]);
    }
    fill_gaps(&mut parts);
    team.gather(&mut keys, &parts);
    let keys: Vec<u64> = keys.iter().map(|k| k.to_bits()).collect();
    (split, keys)
}

/// Every rank's nodes of the body split at `split`, and the body's volume: per-chunk sums of
/// each rank's own chunks (`volume`, its nodes' volumes), added in chunk order (collective).
fn body_volume(team: &dyn Team, volume: &[Real], split: &[usize]) -> (Vec<Range<usize>>, Real) {
    let (rank, size) = (team.rank(), team.size());
    let total = split[size];
    let chunks = total.div_ceil(CHUNK);
    let mut partial = vec![0.0; chunks];
    for (k, c) in volume.chunks(CHUNK).enumerate() {
        partial[split[rank] / CHUNK + k] = c.iter().sum();
    }
    let nodes: Vec<Range<usize>> = (0..size).map(|r| split[r]..split[r + 1]).collect();
    let chunk_parts: Vec<Range<usize>> = nodes.iter().map(crate::kernel::chunks_of).collect();
    team.gather(&mut partial, &chunk_parts);
    (nodes, partial.iter().sum())
}

/// The part's ghosts (its nodes that other ranks own, ascending), what their owners answer for
/// each (its index in the body, volume and boundary share), and the own nodes this rank sends
/// to each rank from then on. `first` is the body's index of the part's first own node, `owner`
/// gives a key's rank. Collective.
#[allow(clippy::type_complexity)]
fn ask_ghosts(
    team: &dyn Team,
    part: &crate::random::part::Part,
    first: usize,
    owner: &dyn Fn(u64) -> usize,
) -> Result<(Vec<usize>, Vec<(usize, Real, [Real; 3])>, Vec<Vec<usize>>)> {
    let size = team.size();
    let ghosts: Vec<usize> = (0..part.pos.len())
        .filter(|i| !part.own.contains(i))
        .collect();
    let mut asks = vec![Vec::new(); size];
    for &i in &ghosts {
        let q = owner(part.key[i]);
        asks[q].push(Real::from_bits(part.key[i]));
        asks[q].push(Real::from_bits(part.grid[i]));
    }
    let own_ids: Vec<(u64, u64)> = part
        .own
        .clone()
        .map(|i| (part.key[i], part.grid[i]))
        .collect();
    let mut sends = vec![Vec::new(); size];
    let answers = ask(team, &asks, 2, 5, &mut |from, q| {
        let id = (q[0].to_bits(), q[1].to_bits());
        let at = own_ids.binary_search(&id).ok()?;
        sends[from].push(at);
        let s = part.surface[at];
        Some(vec![
            (first + at) as Real,
            part.volume[at],
            s[0],
            s[1],
            s[2],
        ])
    })?;
    // The ghosts' answers, in the part's order (owners ascend with the keys).
    let mut ghost_info = Vec::with_capacity(ghosts.len());
    for a in &answers {
        ghost_info.extend(
            a.chunks(5)
                .map(|x| (x[0] as usize, x[1], [x[2], x[3], x[4]])),
        );
    }
    Ok((ghosts, ghost_info, sends))
}

/// The part's springs in the body's numbering: the springs whose lower end a rank owns are
/// numbered by that rank, in order after the lower ranks' (`spring_first`, one entry per rank
/// and the total); the others are asked of their lower end's owner. `global` numbers a node of
/// the part in the body, `owner` gives a key's rank. Collective.
fn number_springs(
    team: &dyn Team,
    part: &crate::random::part::Part,
    global: &dyn Fn(usize) -> usize,
    owner: &dyn Fn(u64) -> usize,
) -> Result<(Vec<u32>, Vec<usize>)> {
    let (rank, size) = (team.rank(), team.size());
    let lower_own: Vec<(usize, usize)> = part
        .springs
        .iter()
        .filter(|(e, _)| part.own.contains(&(e[0] as usize)))
        .map(|(e, _)| (global(e[0] as usize), global(e[1] as usize)))
        .collect();
    let mut spring_counts = vec![0.0; size];
    spring_counts[rank] = lower_own.len() as Real;
    team.gather(&mut spring_counts, &singles(size));
    let spring_first = prefix(
        &spring_counts
            .iter()
            .map(|&c| c as usize)
            .collect::<Vec<_>>(),
    );
    let mut asks = vec![Vec::new(); size];
    for (e, _) in &part.springs {
        let lo = e[0] as usize;
        if !part.own.contains(&lo) {
            let q = owner(part.key[lo]);
            asks[q].push(global(lo) as Real);
            asks[q].push(global(e[1] as usize) as Real);
        }
    }
    let answers = ask(team, &asks, 2, 1, &mut |_, q| {
        let at = lower_own
            .binary_search(&(q[0] as usize, q[1] as usize))
            .ok()?;
        Some(vec![(spring_first[rank] + at) as Real])
    })?;
    let mut foreign = answers.iter().flatten().map(|&x| x as u32);
    let mut next_own = spring_first[rank] as u32;
    let springs: Vec<u32> = part
        .springs
        .iter()
        .map(|(e, _)| {
            if part.own.contains(&(e[0] as usize)) {
                next_own += 1;
                next_own - 1
            } else {
                foreign.next().expect("an answer per foreign spring")
            }
        })
        .collect();
    Ok((springs, spring_first))
}

/// The piece's lattice: its positions and springs, the nodes' and springs' volumes and boundary
/// shares, the body's mean cell volume.
fn part_lattice(
    body: &Sampling,
    part: &crate::random::part::Part,
    pos: Coords,
    bonds: Bonds,
    cell_volume: Real,
    (node, surface): (Vec<Real>, Vec<[Real; 3]>),
) -> Lattice {
    Lattice {
        kind: if body.dim == 2 {
            LatticeKind::Random2d
        } else {
            LatticeKind::Random3d
        },
        spacing: body.a,
        pos,
        cell_volume,
        thickness: if body.dim == 2 { body.h } else { 1.0 },
        period: [0.0; 3],
        grid: None,
        bonds: Topology::from(bonds),
        cells: Some(Cells {
            node,
            spring: part.springs.iter().map(|(_, v)| *v).collect(),
            surface,
            sampler: body.spec.sampler,
        }),
    }
}

/// Add the nodes every rank reads each step to every rank's piece (the loaded and prescribed
/// nodes: a shared run's bookkeeping gathers their velocities and forces, so each rank holds
/// them, as [`Share::new`]'s `everyone` puts them in every rank's halo). `mine` are the
/// body's indices of this rank's own such nodes, ascending; the pieces, lattices and shares
/// come from [`assemble`]. The new ghosts' positions, volumes and boundary shares are asked of
/// their owners, and each owner sends its such nodes to every other rank from then on.
/// Collective.
///
/// Returns the piece, its lattice and share with those ghosts added, in the body's order, and
/// the body's index of every such node of every rank, ascending.
pub fn everyone(
    team: &dyn Team,
    piece: Piece,
    lattice: Lattice,
    share: Share,
    mine: &[u32],
) -> Result<(Piece, Lattice, Share, Vec<u32>)> {
    let (rank, size) = (team.rank(), team.size());
    let first = piece.first;
    let own_g = first..first + piece.own.len();
    check_mine(team, mine, &own_g)?;
    let all = gather_ids(team, mine);
    let owner_of = |g: u32| share.nodes.partition_point(|r| r.end <= g as usize);
    // The ones this piece lacks: not its own, not a ghost already.
    let held = |g: u32| piece.local(g as usize).is_some();
    let new: Vec<u32> = all.iter().copied().filter(|&g| !held(g)).collect();
    let mut asks = vec![Vec::new(); size];
    for &g in &new {
        asks[owner_of(g)].push(g as Real);
    }
    let cells = lattice.cells.as_ref().ok_or_else(|| Error::InvalidInput {
        what: "nodes every process reads",
        why: "the piece's lattice has no cells (not set up from parts)".into(),
    })?;
    let answers = ask(team, &asks, 1, 7, &mut |_, q| {
        let g = q[0] as usize;
        if !own_g.contains(&g) {
            return None;
        }
        let i = piece.own.start + (g - first);
        let p = lattice.pos.get(i);
        let s = cells.surface[i];
        Some(vec![p.x, p.y, p.z, cells.node[i], s[0], s[1], s[2]])
    })?;
    // The answers in `new`'s order (owners ascend with the nodes).
    let info: Vec<&[Real]> = answers.iter().flat_map(|a| a.chunks(7)).collect();
    // The piece again: old and new nodes merged in the body's order, dummies recounted.
    let real: Vec<u32> = piece.global.iter().copied().filter(|&g| g != PAD).collect();
    let merged = merge_ascending(&real, &new);
    let below = merged.partition_point(|&(g, _)| (g as usize) < first);
    let pad = below.next_multiple_of(CHUNK) - below;
    let n = pad + merged.len();
    let old_pad = piece.global.partition_point(|&g| g == PAD);
    // Old local index -> new local index.
    let mut to_new = vec![u32::MAX; piece.global.len()];
    let mut global = vec![PAD; pad];
    let mut old = old_pad;
    for (k, &(g, fresh)) in merged.iter().enumerate() {
        global.push(g);
        if fresh.is_none() {
            to_new[old] = (pad + k) as u32;
            old += 1;
        }
    }
    let own = pad + below..pad + below + piece.own.len();
    let mut x = vec![vec![0.0; n]; 3];
    let mut node = vec![lattice.cell_volume; n];
    let mut surface = vec![[0.0; 3]; n];
    for (k, &(_, fresh)) in merged.iter().enumerate() {
        if let Some(b) = fresh {
            let (i, a) = (pad + k, info[b]);
            for c in 0..3 {
                x[c][i] = a[c];
            }
            node[i] = a[3];
            surface[i] = [a[4], a[5], a[6]];
        }
    }
    for (o, &nw) in to_new.iter().enumerate().skip(old_pad) {
        let nw = nw as usize;
        let p = lattice.pos.get(o);
        x[0][nw] = p.x;
        x[1][nw] = p.y;
        x[2][nw] = p.z;
        node[nw] = cells.node[o];
        surface[nw] = cells.surface[o];
    }
    let pos = Coords::from_components(&x[0], &x[1], &x[2]);
    let bonds = &*lattice.bonds;
    let pairs: Vec<[u32; 2]> = bonds
        .ends
        .iter()
        .map(|e| e.map(|i| to_new[i as usize]))
        .collect();
    let new_bonds = Bonds::from_pairs(n, pairs, &pos, lattice.period)?;
    // Each rank's such nodes go to every other rank; this rank receives the others' from
    // their owners.
    let remap = |l: &Vec<u32>| -> Vec<u32> { l.iter().map(|&i| to_new[i as usize]).collect() };
    let mut send: Vec<Vec<u32>> = piece.halo.send.iter().map(remap).collect();
    let mut recv: Vec<Vec<u32>> = piece.halo.recv.iter().map(remap).collect();
    let local_of = |g: u32| -> u32 {
        let at = merged.binary_search_by_key(&g, |&(x, _)| x).expect("held");
        (pad + at) as u32
    };
    for (r, list) in send.iter_mut().enumerate() {
        if r != rank {
            list.extend(mine.iter().map(|&g| local_of(g)));
        }
    }
    for &g in &all {
        let q = owner_of(g);
        if q != rank {
            recv[q].push(local_of(g));
        }
    }
    for l in send.iter_mut().chain(recv.iter_mut()) {
        l.sort_unstable();
        l.dedup();
    }
    let to_global = |list: &Vec<u32>| list.iter().map(|&i| global[i as usize]).collect();
    let halo = Halo { send, recv };
    let share = Share {
        halo: Halo {
            send: halo.send.iter().map(to_global).collect(),
            recv: halo.recv.iter().map(to_global).collect(),
        },
        ..share
    };
    let lattice = Lattice {
        pos,
        bonds: Topology::from(new_bonds),
        cells: Some(Cells {
            node,
            spring: cells.spring.clone(),
            surface,
            sampler: cells.sampler,
        }),
        ..lattice
    };
    let piece = Piece {
        global,
        own,
        halo,
        ..piece
    };
    Ok((piece, lattice, share, all))
}

/// Refuse `mine` unless it is this rank's own nodes, ascending, each once: on every rank alike
/// (a rank returning alone would leave the others waiting). Collective.
fn check_mine(team: &dyn Team, mine: &[u32], own_g: &Range<usize>) -> Result<()> {
    let bad = mine.windows(2).any(|w| w[0] >= w[1])
        || mine.iter().any(|&g| !own_g.contains(&(g as usize)));
    all_ok(
        team,
        if bad {
            Err(Error::InvalidInput {
                what: "nodes every process reads",
                why: "give this process's own nodes, ascending, each once".into(),
            })
        } else {
            Ok(())
        },
    )
}

/// Two ascending lists of body indices merged in order: each entry with `None` when it comes
/// from `old`, or its index in `new`.
fn merge_ascending(old: &[u32], new: &[u32]) -> Vec<(u32, Option<usize>)> {
    let mut merged = Vec::with_capacity(old.len() + new.len());
    let (mut a, mut b) = (0, 0);
    while a < old.len() || b < new.len() {
        if b == new.len() || (a < old.len() && old[a] < new[b]) {
            merged.push((old[a], None));
            a += 1;
        } else {
            merged.push((new[b], Some(b)));
            b += 1;
        }
    }
    merged
}

/// Every rank's `mine` (node or spring indices), concatenated in rank order: ascending when
/// each rank's are ascending and the ranks own ascending ranges. Collective.
pub fn gather_ids(team: &dyn Team, mine: &[u32]) -> Vec<u32> {
    let (rank, size) = (team.rank(), team.size());
    let mut counts = vec![0.0; size];
    counts[rank] = mine.len() as Real;
    team.gather(&mut counts, &singles(size));
    let offsets = prefix(&counts.iter().map(|&c| c as usize).collect::<Vec<_>>());
    let mut all = vec![0.0; offsets[size]];
    for (k, &g) in mine.iter().enumerate() {
        all[offsets[rank] + k] = g as Real;
    }
    let parts: Vec<Range<usize>> = (0..size).map(|r| offsets[r]..offsets[r + 1]).collect();
    team.gather(&mut all, &parts);
    all.iter().map(|&g| g as u32).collect()
}

/// The sum over the ranks of a count of each (exact: counts below 2^53). Collective.
pub fn sum_counts(team: &dyn Team, mine: usize) -> usize {
    let size = team.size();
    let mut counts = vec![0.0; size];
    counts[team.rank()] = mine as Real;
    team.gather(&mut counts, &singles(size));
    counts.iter().map(|&c| c as usize).sum()
}

/// `result` on this rank if every rank's is `Ok`; otherwise the same error on every rank: the
/// first failing rank's message, naming that rank (each rank's message is all-gathered, so
/// whichever rank prints says why).
fn all_ok<T>(team: &dyn Team, result: Result<T>) -> Result<T> {
    let mut failed = [result.is_err()];
    team.any(&mut failed);
    if !failed[0] {
        return result;
    }
    let (rank, size) = (team.rank(), team.size());
    let mine = result
        .as_ref()
        .err()
        .map_or_else(String::new, |e| e.to_string());
    // The messages' bytes, carried as reals.
    let mut lengths = vec![0.0; size];
    lengths[rank] = mine.len() as Real;
    team.gather(&mut lengths, &singles(size));
    let offsets = prefix(&lengths.iter().map(|&l| l as usize).collect::<Vec<_>>());
    let mut bytes = vec![0.0; offsets[size]];
    for (k, b) in mine.bytes().enumerate() {
        bytes[offsets[rank] + k] = b as Real;
    }
    let parts: Vec<Range<usize>> = (0..size).map(|r| offsets[r]..offsets[r + 1]).collect();
    team.gather(&mut bytes, &parts);
    let first = (0..size)
        .find(|&r| !parts[r].is_empty())
        .expect("a failing rank has a message");
    let text: Vec<u8> = bytes[parts[first].clone()]
        .iter()
        .map(|&b| b as u8)
        .collect();
    Err(Error::InvalidInput {
        what: "random lattice",
        why: format!(
            "process {first} of {size} could not build its part of the body: {}",
            String::from_utf8_lossy(&text)
        ),
    })
}

/// One slot per rank.
fn singles(size: usize) -> Vec<Range<usize>> {
    (0..size).map(|r| r..r + 1).collect()
}

/// Running sums: `out[r]` the sum of `x[..r]`, `out[len]` the total.
fn prefix(x: &[usize]) -> Vec<usize> {
    let mut out = vec![0; x.len() + 1];
    for (r, &c) in x.iter().enumerate() {
        out[r + 1] = out[r] + c;
    }
    out
}

/// Make empty ranges sit where the ranges around them meet (a gather's parts ascend).
fn fill_gaps(parts: &mut [Range<usize>]) {
    let mut at = 1;
    for p in parts.iter_mut() {
        if p.start >= p.end {
            *p = at..at;
        } else {
            at = p.end;
        }
    }
}

/// Answers a question (reals) from a rank, or `None` when it cannot.
type Answer<'a> = dyn FnMut(usize, &[Real]) -> Option<Vec<Real>> + 'a;

/// Ask each rank `q` the questions `asks[q]` (`width` reals each) and return its answers
/// (`reply` reals per question), in order. `answer(from, question)` answers a question from
/// rank `from`, `None` for one this rank cannot answer (an error on every rank). Two
/// all-gathers and two trades; collective.
fn ask(
    team: &dyn Team,
    asks: &[Vec<Real>],
    width: usize,
    reply: usize,
    answer: &mut Answer,
) -> Result<Vec<Vec<Real>>> {
    let (rank, size) = (team.rank(), team.size());
    // How many questions each rank asks each other rank.
    let mut matrix = vec![0.0; size * size];
    for q in 0..size {
        matrix[rank * size + q] = (asks[q].len() / width) as Real;
    }
    let rows: Vec<Range<usize>> = (0..size).map(|r| r * size..(r + 1) * size).collect();
    team.gather(&mut matrix, &rows);
    let asked = |from: usize, to: usize| matrix[from * size + to] as usize;
    let mut inp: Vec<Vec<Real>> = (0..size)
        .map(|r| vec![0.0; if r == rank { 0 } else { width * asked(r, rank) }])
        .collect();
    let mut out = asks.to_vec();
    out[rank].clear();
    team.trade(&out, &mut inp);
    let mut failed = [false];
    let mut replies: Vec<Vec<Real>> = vec![Vec::new(); size];
    for (from, questions) in inp.iter().enumerate() {
        for q in questions.chunks(width) {
            match answer(from, q) {
                Some(a) => replies[from].extend(a),
                None => {
                    failed[0] = true;
                    replies[from].extend(std::iter::repeat_n(0.0, reply));
                }
            }
        }
    }
    team.any(&mut failed);
    if failed[0] {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: "the processes' parts of the body disagree on a node or spring they share \
                  (please report the case)"
                .into(),
        });
    }
    let mut got: Vec<Vec<Real>> = (0..size)
        .map(|q| vec![0.0; if q == rank { 0 } else { reply * asked(rank, q) }])
        .collect();
    team.trade(&replies, &mut got);
    Ok(got)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Body;
    use crate::dynamics::{Integrator, IntegratorOptions, TimeStep};
    use crate::loading::Loading;
    use crate::random::{RandomSpec, Sampler};
    use crate::state::State;
    use crate::team::tests::assert_own_state;
    use crate::team::Threads;

    /// A block `[0, hi]` of spacing `a` to build in parts.
    fn sampling<'a>(
        hi: [Real; 3],
        a: Real,
        spec: RandomSpec,
        inside: &'a (dyn Fn([Real; 3]) -> bool + Sync),
    ) -> Sampling<'a> {
        Sampling {
            dim: 3,
            lo: [0.0; 3],
            hi,
            a,
            h: 1.0,
            spec,
            inside,
        }
    }

    /// A smooth velocity field, so that the springs do real work.
    fn swing(state: &mut State, pos: &Coords, skip: &dyn Fn(usize) -> bool) {
        for i in 0..pos.len() {
            if skip(i) {
                continue;
            }
            let p = pos.get(i);
            state.v.x_mut()[i] = 1e-2 * (0.3 * p.y).sin();
            state.v.y_mut()[i] = 1e-2 * (0.23 * p.z + 0.17 * p.x).cos();
            state.v.z_mut()[i] = -1e-2 * (0.11 * p.x).sin();
        }
    }

    /// Teams of 2 and 3 set up a notched random block from their parts alone and step it with
    /// one process's bits: the time step (estimated, damage-proof or given), every own node's
    /// displacement and velocity after the steps, the state's digest, and the body's cell
    /// volume.
    #[test]
    fn pieces_set_up_from_parts_step_with_the_bits_of_one_process() {
        let (hi, a) = ([24.0, 23.0, 21.0], 1.0);
        let spec = RandomSpec {
            sampler: Sampler::Jitter { amplitude: 0.6 },
            seed: 3,
        };
        let notch = |p: [Real; 3]| !(p[0] < 9.0 && (p[1] - 11.5).abs() < 0.7);
        let lattice = Lattice::random(3, [0.0; 3], hi, a, 1.0, spec, &notch).unwrap();
        let cell_volume = lattice.cell_volume;
        let body = Body::from_cells(lattice, 1.0, 0.3, 1.0);
        assert!(body.nodes() > 3 * CHUNK, "{} nodes", body.nodes());
        // The step estimated (by pieces as by one process), the damage-proof step, and a
        // given one.
        for opts in [
            IntegratorOptions::default(),
            IntegratorOptions {
                damage_proof: true,
                ..Default::default()
            },
            IntegratorOptions {
                time_step: TimeStep::Fixed {
                    dt: 0.1,
                    force: true,
                },
                ..Default::default()
            },
        ] {
            parts_step_as_one_process(&body, cell_volume, spec, hi, a, &notch, &opts);
        }
    }

    fn parts_step_as_one_process(
        body: &Body,
        cell_volume: Real,
        spec: RandomSpec,
        hi: [Real; 3],
        a: Real,
        notch: &(dyn Fn([Real; 3]) -> bool + Sync),
        opts: &IntegratorOptions,
    ) {
        let steps = 25;
        let mut alone = State::new(body);
        let mut it = Integrator::new(body, &mut alone, Loading::default(), opts).unwrap();
        let dt = it.dt();
        swing(&mut alone, &body.lattice.pos, &|_| false);
        for _ in 0..steps {
            it.step(body, &mut alone);
        }
        let digest = it.state_digest(&alone);
        for size in [2, 3] {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let alone = &alone;
                    scope.spawn(move || {
                        let team: std::sync::Arc<dyn Team> = std::sync::Arc::new(team);
                        let at = format!("{size} ranks, rank {}", team.rank());
                        let (piece, lat, share) =
                            assemble(&*team, &sampling(hi, a, spec, notch), 4.0 * a).unwrap();
                        assert!(piece.halo.ghosts() > 0 && !piece.own.is_empty(), "{at}");
                        assert_eq!(lat.cell_volume.to_bits(), cell_volume.to_bits(), "{at}");
                        let pb = Body::from_cells(lat, 1.0, 0.3, 1.0);
                        let mut ps = State::new(&pb);
                        let global = piece.global.clone();
                        let own = piece.own.clone();
                        let mut it = Integrator::on_piece(
                            &pb,
                            &mut ps,
                            Loading::default(),
                            piece,
                            share,
                            team,
                            opts,
                        )
                        .unwrap();
                        assert_eq!(it.dt().to_bits(), dt.to_bits(), "dt, {at}");
                        swing(&mut ps, &pb.lattice.pos, &|i| global[i] == PAD);
                        for _ in 0..steps {
                            it.step(&pb, &mut ps);
                        }
                        assert_own_state(&global, own, &ps, alone, &at);
                        assert_eq!(it.state_digest(&ps), digest, "{at}");
                    });
                }
            });
        }
    }

    /// A loaded block set up from parts: its grips (fixed, moved at a constant velocity)
    /// and loaded nodes added to every rank's piece by [`everyone`], a body force, damping
    /// and an initial velocity. Teams of 2 and 3 step it with one process's bits: the step,
    /// every own node's displacement and velocity, the digest and the energy balance.
    #[test]
    fn loaded_pieces_from_parts_step_with_the_bits_of_one_process() {
        use crate::loading::{Load, Motion, Prescribed, TimeFunction};
        use crate::math::Vector;
        let (hi, a) = ([22.0, 21.0, 20.0], 1.0);
        let spec = RandomSpec {
            sampler: Sampler::Jitter { amplitude: 0.6 },
            seed: 5,
        };
        let lattice = Lattice::random(3, [0.0; 3], hi, a, 1.0, spec, &|_| true).unwrap();
        let body = Body::from_cells(lattice, 1.0, 0.25, 1.0);
        // The loading, from node positions: what a case's regions select.
        let at = |p: Vector| -> [bool; 3] { [p.x == 0.0, p.x == hi[0], p.y == hi[1]] };
        let loading_of = |pos: &Coords, keep: &dyn Fn(usize) -> bool| {
            let mut sets = [Vec::new(), Vec::new(), Vec::new()];
            for i in (0..pos.len()).filter(|&i| keep(i)) {
                for (k, &b) in at(pos.get(i)).iter().enumerate() {
                    if b {
                        sets[k].push(i as u32);
                    }
                }
            }
            let [left, right, top] = sets;
            assert!(!left.is_empty() || !keep(0), "no node on a face");
            Loading {
                prescribed: vec![
                    Prescribed {
                        nodes: left,
                        axis: 0,
                        motion: Motion::Fixed,
                    },
                    Prescribed {
                        nodes: right,
                        axis: 0,
                        motion: Motion::Velocity(TimeFunction::Ramp {
                            t0: 0.0,
                            t1: 2.0,
                            from: 0.0,
                            to: 1e-2,
                        }),
                    },
                ],
                loads: vec![Load {
                    nodes: top,
                    force: Vector::new(0.0, 2e-3, 1e-3),
                    scale: TimeFunction::Constant(1.0),
                }],
                body_acceleration: Vector::new(0.0, 0.0, -1e-4),
            }
        };
        let opts = IntegratorOptions {
            damping: 0.01,
            damage_proof: true,
            ..Default::default()
        };
        let kick = |state: &mut State, pos: &Coords, keep: &dyn Fn(usize) -> bool| {
            for i in (0..pos.len()).filter(|&i| keep(i)) {
                let p = pos.get(i);
                state.v.y_mut()[i] = 1e-2 * (0.2 * p.x).sin();
            }
        };
        let steps = 30;
        let mut alone = State::new(&body);
        kick(&mut alone, &body.lattice.pos, &|_| true);
        let loading = loading_of(&body.lattice.pos, &|_| true);
        let mut it = Integrator::new(&body, &mut alone, loading, &opts).unwrap();
        for _ in 0..steps {
            it.step(&body, &mut alone);
        }
        let digest = it.state_digest(&alone);
        let balance = it.energy(&body, &mut alone);
        for size in [2, 3] {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let (alone, dt, opts) = (&alone, it.dt(), &opts);
                    scope.spawn(move || {
                        let team: std::sync::Arc<dyn Team> = std::sync::Arc::new(team);
                        let at_rank = format!("{size} ranks, rank {}", team.rank());
                        let body = sampling(hi, a, spec, &|_| true);
                        let (piece, lat, share) = assemble(&*team, &body, 4.0 * a).unwrap();
                        let own = piece.own.clone();
                        let mine: Vec<u32> = own
                            .clone()
                            .filter(|&i| at(lat.pos.get(i)).iter().any(|&b| b))
                            .map(|i| piece.global[i])
                            .collect();
                        let (piece, lat, share, all) =
                            everyone(&*team, piece, lat, share, &mine).unwrap();
                        let pb = Body::from_cells(lat, 1.0, 0.25, 1.0);
                        let global = piece.global.clone();
                        let real = |i: usize| global[i] != PAD;
                        let loading = loading_of(&pb.lattice.pos, &real);
                        // Every rank holds every loaded and prescribed node.
                        let held: Vec<u32> = crate::dynamics::special_nodes(&loading)
                            .into_iter()
                            .map(|i| global[i])
                            .collect();
                        assert_eq!(held, all, "{at_rank}");
                        let mut ps = State::new(&pb);
                        kick(&mut ps, &pb.lattice.pos, &real);
                        let own = piece.own.clone();
                        let mut it =
                            Integrator::on_piece(&pb, &mut ps, loading, piece, share, team, opts)
                                .unwrap();
                        assert_eq!(it.dt().to_bits(), dt.to_bits(), "dt, {at_rank}");
                        for _ in 0..steps {
                            it.step(&pb, &mut ps);
                        }
                        assert_own_state(&global, own, &ps, alone, &at_rank);
                        assert_eq!(it.state_digest(&ps), digest, "{at_rank}");
                        let b = it.energy(&pb, &mut ps);
                        assert_eq!(b.kinetic.to_bits(), balance.kinetic.to_bits(), "{at_rank}");
                        assert_eq!(b.error.to_bits(), balance.error.to_bits(), "{at_rank}");
                        assert_eq!(
                            b.ledger.boundary_work.to_bits(),
                            balance.ledger.boundary_work.to_bits(),
                            "{at_rank}"
                        );
                    });
                }
            });
        }
    }

    /// A part that cannot be built on one rank stops every rank, each with that rank's
    /// reason.
    #[test]
    fn a_part_that_fails_on_one_rank_stops_every_rank() {
        let spec = RandomSpec {
            sampler: Sampler::Jitter { amplitude: 0.6 },
            seed: 3,
        };
        std::thread::scope(|scope| {
            for team in Threads::team(3) {
                scope.spawn(move || {
                    let rank = team.rank();
                    // Rank 1 samples too narrow a margin.
                    let margin = if rank == 1 { 0.05 } else { 4.0 };
                    // Every rank gives rank 1's reason.
                    let body = sampling([24.0; 3], 1.0, spec, &|_| true);
                    let e = assemble(&team, &body, margin).unwrap_err().to_string();
                    assert!(e.contains("too narrow"), "rank {rank}: {e}");
                    assert!(e.contains("process 1 of 3"), "rank {rank}: {e}");
                });
            }
        });
    }
}
