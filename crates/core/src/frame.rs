//! What an output frame shows of the lattice, computed in as few passes as the law allows: the
//! pools, forces and strain energy of [`law::update_forces`](hooke_model::law::update_forces) and [`law::energy`](hooke_model::law::energy), bit for bit,
//! with the per-node energy density and virial stress ([`law::node_virial`](hooke_model::law::node_virial)). Derived fields
//! are computed only here, for output, never in the step.
//!
//! A run shared by several processes computes a frame by parts ([`FramePart`], one rank's
//! nodes of the whole body; [`PieceFrame`], a rank's piece), with the same bits at every value.

use rayon::prelude::*;

use crate::body::Body;
use crate::law::{
    pool_ratio, spring_geometry, spring_geometry_rest, Energy, GridLaw, MIN_NODES_PER_TASK,
};
use crate::math::{Coords, Real};
use crate::state::{Springs, State};
use crate::team::{Piece, Team};

/// Everything an output frame shows of the lattice, from a pass over the springs and two over
/// the rows instead of a set of passes per field: the pools, forces and strain energy of
/// [`update_forces`](hooke_model::law::update_forces) and [`energy`](hooke_model::law::energy), and the per-node energy density and virial stress. The
/// pools, forces and energies are those of the separate functions, bit for bit (the same
/// operations in the same order); the stress is [`node_virial`](hooke_model::law::node_virial)'s to round-off (it is
/// accumulated by its six distinct entries and scaled by `1/V_n`).
#[derive(Clone, Debug)]
pub struct FrameFields {
    /// Pool ratios `p_n` (as [`compute_pools`](hooke_model::law::compute_pools)).
    pub pool: Vec<Real>,
    /// Internal forces (as [`compute_forces`](hooke_model::law::compute_forces)).
    pub force: Coords,
    /// Strain energy (as [`energy`](hooke_model::law::energy)).
    pub strain: Energy,
    /// Strain energy density (J/m^3): half of each intact spring's direct energy plus the
    /// node's dispersive energy, over the node's volume.
    pub energy_density: Vec<Real>,
    /// Virial stress `1/(2 V_n) sum_t T_t l_t e_t (x) e_t` (Pa), row-major 3x3.
    pub stress: Vec<[Real; 9]>,
}

/// See [`FrameFields`]. Parallel over nodes and springs (each writes its own entries) and
/// bit-identical for any thread count.
///
/// Each spring's geometry is computed once, from its first end, into per-spring arrays
/// ([`FrameScratch`]), with its direct energy summed per chunk; the row passes read them. Seen
/// from the other end the vector is the exact negation (every rounded difference negates) and
/// the length and extension are the same bits, so both ends read what they would compute. The
/// force pass forms each spring's `T/l` at both ends (the same bits: `p_i + p_j` commutes): a
/// division more per spring, where a pass over the springs that stored it cost more (1.2 ms of
/// a 9 ms frame on the glass plate).
pub fn frame_fields(body: &Body, u: &Coords, sp: Springs<'_>, norm: &[Real]) -> FrameFields {
    frame_fields_in(body, u, sp, norm, &mut FrameScratch::default())
}

/// The per-spring arrays of [`frame_fields_in`] (64 bytes a spring; of a rank's springs only,
/// [`FramePart`]), kept by a caller that writes frame after frame: a frame then allocates and
/// fills no fresh memory for them (in a run on the glass plate, collecting them afresh made the
/// first pass take 3.4 to 6.9 ms).
#[derive(Clone, Debug, Default)]
pub struct FrameScratch {
    geo: Vec<[Real; 4]>,
    ext: Vec<[Real; 2]>,
    terms: Vec<[Real; 2]>,
}

impl FrameScratch {
    /// Heap bytes held.
    pub fn bytes(&self) -> usize {
        use crate::memory::bytes;
        bytes(&self.geo) + bytes(&self.ext) + bytes(&self.terms)
    }
}

/// [`frame_fields`] with the per-spring arrays in `scratch` (sized here; its contents are
/// overwritten).
pub fn frame_fields_in(
    body: &Body,
    u: &Coords,
    sp: Springs<'_>,
    norm: &[Real],
    scratch: &mut FrameScratch,
) -> FrameFields {
    frame_fields_part(body, u, sp, norm, scratch, None)
}

/// One rank's part of a frame of a run shared by a team ([`crate::team`]): the rank computes
/// the fields of its own nodes (`share.mine()`), from the springs of their rows, and its part of
/// the strain energy's partial sums; the pools are all-gathered between the passes (a spring's
/// tension reads the pools at both ends). Every rank needs the whole displacement field
/// (gathered before a frame).
#[derive(Clone, Copy)]
pub struct FramePart<'a> {
    pub team: &'a dyn crate::team::Team,
    pub share: &'a crate::team::Share,
}

impl FramePart<'_> {
    /// Every rank's chunks of springs (of [`crate::kernel::CHUNK`]) for the direct energy's
    /// partial sums: chunk c goes to the rank that owns its first spring's lower end (springs
    /// are sorted by it), so the parts are contiguous and cover every chunk.
    fn spring_chunk_parts(&self, body: &Body) -> Vec<std::ops::Range<usize>> {
        let ends = &body.lattice.bonds.ends;
        let chunks = ends.len().div_ceil(crate::kernel::CHUNK);
        // The first chunk whose first spring's lower end is at or past `node` (a binary
        // search: those ends ascend).
        let first = |node: usize| {
            let (mut lo, mut hi) = (0, chunks);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if (ends[mid * crate::kernel::CHUNK][0] as usize) < node {
                    lo = mid + 1;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        let nodes = &self.share.nodes;
        (0..nodes.len())
            .map(|r| {
                let lo = first(nodes[r].start);
                let hi = match nodes.get(r + 1) {
                    Some(next) => first(next.start),
                    None => chunks,
                };
                lo..hi.max(lo)
            })
            .collect()
    }
}

/// [`frame_fields_in`], or with `part` one rank's part of it ([`FramePart`]): then the pools
/// are whole and the energies every rank's, while the forces, energy densities and stresses
/// hold this rank's nodes only (zeros elsewhere). The same bits as the whole computation at
/// every value it gives.
pub fn frame_fields_part(
    body: &Body,
    u: &Coords,
    sp: Springs<'_>,
    norm: &[Real],
    scratch: &mut FrameScratch,
    part: Option<FramePart<'_>>,
) -> FrameFields {
    let n = body.nodes();
    let ns = body.springs();
    let lat = &body.lattice;
    let bonds = &*lat.bonds;
    let chunk = crate::kernel::CHUNK;
    let chunks = ns.div_ceil(chunk);
    // What this rank computes: its nodes; the springs of their rows, as whole chunks of the
    // springs whose lower end is one of them (widened to this rank's chunks of the energy
    // sum) and one by one those whose lower end is another rank's.
    let parts = part.map(|p| p.spring_chunk_parts(body));
    let (nodes, springs, foreign) = match (part, &parts) {
        (Some(p), Some(parts)) => {
            let own = p.share.mine();
            let ends = &bonds.ends;
            let s0 = ends.partition_point(|e| (e[0] as usize) < own.start);
            let s1 = ends.partition_point(|e| (e[0] as usize) < own.end);
            let mine = &parts[p.share.rank];
            let lo = (s0 / chunk).min(mine.start) * chunk;
            let hi = (s1.div_ceil(chunk).max(mine.end) * chunk).min(ns);
            let mut foreign: Vec<u32> = own
                .clone()
                .flat_map(|i| bonds.row(i))
                .map(|e| bonds.bond[e])
                .filter(|&b| (b as usize) < lo)
                .collect();
            foreign.sort_unstable();
            foreign.dedup();
            (own, lo..hi.max(lo), foreign)
        }
        _ => (0..n, 0..ns, Vec::new()),
    };
    // Pass 1, over the springs: the vector `d` from the first end and the length `l` (`geo`),
    // `k dL` and `q k L` (what the tension needs besides the pools; the lever `L` is computed
    // once, here, where the lattice shed the rest lengths), and the two terms the pool pass
    // adds, `k L dL` and `k dL^2 / 4` (a quarter of the spring's direct energy at each end).
    // The per-spring arrays hold this rank's springs only: the range (every spring, in one
    // process), then the foreign ones.
    let FrameScratch { geo, ext, terms } = scratch;
    let levers = sp.lever.stored();
    let (lo, width) = (springs.start, springs.len());
    let slots = width + foreign.len();
    let slot = |b: usize| -> usize {
        if b >= lo {
            b - lo
        } else {
            width
                + foreign
                    .binary_search(&(b as u32))
                    .expect("a foreign spring of the rows")
        }
    };
    geo.resize(slots, [0.0; 4]);
    ext.resize(slots, [0.0; 2]);
    terms.resize(slots, [0.0; 2]);
    let one = |b: usize| frame_spring(body, u, sp, levers, b);
    // The direct energy is summed per chunk here, in the order of [`energy`](hooke_model::law::energy).
    let first = springs.start;
    let mut partial = vec![0.0; chunks];
    geo[..width]
        .par_chunks_mut(chunk)
        .zip(ext[..width].par_chunks_mut(chunk))
        .zip(terms[..width].par_chunks_mut(chunk))
        .zip(partial[first / chunk..springs.end.div_ceil(chunk)].par_iter_mut())
        .enumerate()
        .for_each(|(c, (((g, x), t), out))| {
            let b0 = first + c * chunk;
            *out = g
                .iter_mut()
                .zip(x)
                .zip(t)
                .enumerate()
                .map(|(o, ((g, x), t))| {
                    let energy;
                    (*g, *x, *t, energy) = one(b0 + o);
                    energy
                })
                .sum::<Real>();
        });
    for (k, &b) in foreign.iter().enumerate() {
        (geo[width + k], ext[width + k], terms[width + k], _) = one(b as usize);
    }
    // Pass 2, over the nodes: the pool Pi_n, its ratio p_n, and a quarter of the springs'
    // direct energy.
    let [pi, quarter, mut pool] = frame_pools(body, sp, terms, slot, norm, nodes.clone());
    if let Some(p) = part {
        p.team.gather(&mut pool, &p.share.nodes);
    }
    if let (Some(p), Some(parts)) = (part, &parts) {
        p.team.gather(&mut partial, parts);
    }
    let direct = partial.iter().sum();
    // Pass 3, over the nodes: forces, energy densities and virial stresses.
    let (force, energy_density, stress) = frame_forces(
        body,
        sp,
        (&geo[..], &ext[..]),
        slot,
        (&pool, &pi, &quarter, norm),
        nodes.clone(),
    );
    FrameFields {
        pool,
        force,
        strain: Energy {
            direct,
            dispersive: dispersive_sum(body, &pi, norm, nodes, part),
        },
        energy_density,
        stress,
    }
}

/// A rank's piece of a frame ([`crate::team::Piece`], what [`frame_fields_piece`] computes on):
/// the team, the piece and the share of the whole body the piece was cut by.
#[derive(Clone, Copy)]
pub struct PieceFrame<'a> {
    pub team: &'a dyn crate::team::Team,
    pub piece: &'a crate::team::Piece,
    pub share: &'a crate::team::Share,
}

/// [`frame_fields_part`] on a rank's piece (`body`, `u`, `sp` and `norm` the piece's): the
/// pools at its own nodes and ghosts, the forces, energy densities and stresses at its own
/// nodes, and both strain energies, each the bits of the whole body's frame.
///
/// The pools at the ghosts come through the piece's halo. The direct energy is the whole
/// body's sum in spring order, per chunk of [`crate::kernel::CHUNK`] springs, the chunks added
/// in order ([`energy`](hooke_model::law::energy)): chunk c is summed by the rank owning the lower end of its first
/// spring, and the springs of that chunk whose lower ends the next ranks own are sent to it
/// (one trade; every rank's range of springs is all-gathered first, so each knows what to send
/// and to expect). The dispersive energy's chunks are the body's chunks of nodes, whole on
/// their owners. Collective.
pub fn frame_fields_piece(
    body: &Body,
    u: &Coords,
    sp: Springs<'_>,
    norm: &[Real],
    scratch: &mut FrameScratch,
    pf: PieceFrame<'_>,
) -> FrameFields {
    let (ns, chunk) = (body.springs(), crate::kernel::CHUNK);
    let bonds = &*body.lattice.bonds;
    let (team, piece) = (pf.team, pf.piece);
    let size = team.size();
    let own = piece.own.clone();
    let levers = sp.lever.stored();
    // Pass 1 over every spring of the piece (each has an end among the owned nodes).
    let FrameScratch { geo, ext, terms } = scratch;
    geo.resize(ns, [0.0; 4]);
    ext.resize(ns, [0.0; 2]);
    terms.resize(ns, [0.0; 2]);
    let mut direct_of = vec![0.0; ns];
    geo.par_iter_mut()
        .zip(ext.par_iter_mut())
        .zip(terms.par_iter_mut())
        .zip(direct_of.par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(b, (((g, x), t), e))| {
            (*g, *x, *t, *e) = frame_spring(body, u, sp, levers, b);
        });
    let direct = direct_on_pieces(team, piece, &bonds.ends, &direct_of);
    // Pass 2 over the owned nodes; the ghosts' pools from their owners.
    let q = body.q;
    let [pi, quarter, mut pool] = frame_pools(body, sp, terms, |b| b, norm, own.clone());
    let (mut out, mut inp) = (vec![Vec::new(); size], vec![Vec::new(); size]);
    crate::team::trade_halo(team, &piece.halo, &mut out, &mut inp, &mut [&mut pool[..]]);
    // The dispersive energy per chunk of the body's nodes, as `dispersive_sum` forms it.
    let dispersive = if q == 0.0 {
        0.0
    } else {
        let disp = |i: usize| {
            if norm[i] != 0.0 {
                0.5 * q * pi[i] * pi[i] / norm[i]
            } else {
                0.0
            }
        };
        let mut partial = vec![0.0; piece.total.div_ceil(chunk)];
        for c in (own.start / chunk)..own.end.div_ceil(chunk) {
            partial[piece.global_chunk(c)] =
                (c * chunk..((c + 1) * chunk).min(own.end)).map(disp).sum();
        }
        team.gather(&mut partial, &pf.share.chunk_parts(1));
        partial.iter().sum()
    };
    // Pass 3 over the owned nodes.
    let (force, energy_density, stress) = frame_forces(
        body,
        sp,
        (&geo[..], &ext[..]),
        |b| b,
        (&pool, &pi, &quarter, norm),
        own.clone(),
    );
    FrameFields {
        pool,
        force,
        strain: Energy { direct, dispersive },
        energy_density,
        stress,
    }
}

/// The direct strain energy of a body whose ranks hold pieces, as one process sums it
/// ([`energy`](hooke_model::law::energy)): per chunk of the body's springs in spring order,
/// the chunks added in order. `direct_of` holds the piece's springs' direct energies; chunk c
/// is summed by the rank owning the lower end of its first spring, and the springs of that
/// chunk whose lower ends the next ranks own are sent to it (one trade, after every rank's
/// range of springs is all-gathered). Collective.
fn direct_on_pieces(team: &dyn Team, piece: &Piece, ends: &[[u32; 2]], direct_of: &[Real]) -> Real {
    let (size, rank, chunk) = (team.size(), team.rank(), crate::kernel::CHUNK);
    let own = piece.own.clone();
    // The springs whose lower end is owned here: a range of the piece's, and of the body's.
    let l0 = ends.partition_point(|e| (e[0] as usize) < own.start);
    let l1 = ends.partition_point(|e| (e[0] as usize) < own.end);
    let mut ranges = vec![-1.0; 2 * size];
    if l0 < l1 {
        ranges[2 * rank] = piece.springs[l0] as Real;
        ranges[2 * rank + 1] = (piece.springs[l1 - 1] + 1) as Real;
    }
    let pairs: Vec<_> = (0..size).map(|r| 2 * r..2 * r + 2).collect();
    team.gather(&mut ranges, &pairs);
    let range = |r: usize| -> std::ops::Range<usize> {
        if ranges[2 * r] < 0.0 {
            0..0
        } else {
            ranges[2 * r] as usize..ranges[2 * r + 1] as usize
        }
    };
    let total = (0..size).map(|r| range(r).end).max().unwrap_or(0);
    // Rank r sums the chunks whose first spring is in its range.
    let mut parts = Vec::with_capacity(size);
    let mut next = 0;
    for r in 0..size {
        let g = range(r);
        if !g.is_empty() {
            next = g.start.div_ceil(chunk);
            parts.push(next..g.end.div_ceil(chunk));
            next = g.end.div_ceil(chunk);
        } else {
            parts.push(next..next);
        }
    }
    // Whose chunk the head of rank s's range falls in, when it does not start a chunk.
    let owner_of_head = |s: usize| -> Option<usize> {
        let g = range(s);
        (!g.is_empty() && g.start % chunk != 0)
            .then(|| parts.iter().position(|p| p.contains(&(g.start / chunk))))
            .flatten()
    };
    let head = |s: usize| -> usize {
        let g = range(s);
        g.len().min((g.start / chunk + 1) * chunk - g.start)
    };
    let mut out = vec![Vec::new(); size];
    let mut inp = vec![Vec::new(); size];
    if let Some(to) = owner_of_head(rank) {
        out[to].extend_from_slice(&direct_of[l0..l0 + head(rank)]);
    }
    for s in (0..size).filter(|&s| s != rank) {
        if owner_of_head(s) == Some(rank) {
            inp[s].resize(head(s), 0.0);
        }
    }
    team.trade(&out, &mut inp);
    let mut partial = vec![0.0; total.div_ceil(chunk)];
    let mine = range(rank);
    for c in parts[rank].clone() {
        let b0 = c * chunk;
        let b1 = ((c + 1) * chunk).min(total);
        let here = b1.min(mine.end);
        let local = l0 + (b0 - mine.start)..l0 + (here - mine.start);
        // In spring order: this rank's springs, then the heads of the next ranks' ranges
        // (ranks ascend with their springs), one fold as the whole body's chunk sum.
        let heads = if b1 > mine.end { &inp[..] } else { &[] };
        debug_assert_eq!(heads.iter().map(Vec::len).sum::<usize>(), b1 - here);
        partial[c] = direct_of[local]
            .iter()
            .chain(heads.iter().flatten())
            .copied()
            .sum::<Real>();
    }
    team.gather(&mut partial, &parts);
    partial.iter().sum()
}

/// A frame's pass 2 over `nodes` ([`frame_node_pool`]): each node's pool `Pi_n`, a quarter of
/// its springs' direct energy and its pool ratio `p_n` (zero at the other nodes).
fn frame_pools(
    body: &Body,
    sp: Springs<'_>,
    terms: &[[Real; 2]],
    slot: impl Fn(usize) -> usize + Sync + Copy,
    norm: &[Real],
    nodes: std::ops::Range<usize>,
) -> [Vec<Real>; 3] {
    let n = body.nodes();
    let q = body.q;
    let mut pi = vec![0.0; n];
    let mut quarter = vec![0.0; n];
    let mut pool = vec![0.0; n];
    pi[nodes.clone()]
        .par_iter_mut()
        .zip(quarter[nodes.clone()].par_iter_mut())
        .zip(pool[nodes.clone()].par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(k, ((p, e4), ratio))| {
            let i = nodes.start + k;
            let (s, d) = frame_node_pool(body, sp, terms, slot, i);
            (*p, *e4) = (s, d);
            *ratio = pool_ratio(q, norm[i], || s);
        });
    [pi, quarter, pool]
}

/// A frame's pass 3 over `nodes` ([`frame_node_force`], [`node_density_stress`]): forces,
/// energy densities and virial stresses (zero at the other nodes).
fn frame_forces(
    body: &Body,
    sp: Springs<'_>,
    spring: (&[[Real; 4]], &[[Real; 2]]),
    slot: impl Fn(usize) -> usize + Sync + Copy,
    (pool, pi, quarter, norm): (&[Real], &[Real], &[Real], &[Real]),
    nodes: std::ops::Range<usize>,
) -> (Coords, Vec<Real>, Vec<[Real; 9]>) {
    let n = body.nodes();
    let mut force = Coords::zeros(n);
    let mut energy_density = vec![0.0; n];
    let mut stress = vec![[0.0; 9]; n];
    let [fx, fy, fz] = force.xyz_mut();
    fx[nodes.clone()]
        .par_iter_mut()
        .zip(fy[nodes.clone()].par_iter_mut())
        .zip(fz[nodes.clone()].par_iter_mut())
        .zip(energy_density[nodes.clone()].par_iter_mut())
        .zip(stress[nodes.clone()].par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(k, ((((fx, fy), fz), ed), st))| {
            let i = nodes.start + k;
            let (f, m) = frame_node_force(body, sp, spring, slot, pool, i);
            [*fx, *fy, *fz] = f;
            (*ed, *st) = node_density_stress(body, pi, quarter, norm, i, m);
        });
    (force, energy_density, stress)
}

/// What a frame's pass 1 keeps of spring `b` (its vector from the first end and length, `k dL`
/// and `q k L`, `k L dL` and `k dL^2 / 4`), and its direct energy `k dL^2 / 2`.
#[inline]
fn frame_spring(
    body: &Body,
    u: &Coords,
    sp: Springs<'_>,
    levers: Option<&[Real]>,
    b: usize,
) -> ([Real; 4], [Real; 2], [Real; 2], Real) {
    if !sp.alive[b] {
        // A broken spring's extension is +0: its direct energy adds +0.
        return ([0.0; 4], [0.0; 2], [0.0; 2], 0.0);
    }
    let [i, j] = body.lattice.bonds.ends[b].map(|v| v as usize);
    let (s, rest) = spring_geometry_rest(&body.lattice, u, b, i, j);
    let lever = levers.map_or(rest, |l| l[b]);
    let k = sp.k[b];
    let q = body.q;
    // `k dL` and `q k L` round as in `tension`'s `k * dl + q * k * lever * (p_i + p_j)`.
    (
        [s.d[0], s.d[1], s.d[2], s.l],
        [k * s.dl, q * k * lever],
        [k * lever * s.dl, 0.25 * k * s.dl * s.dl],
        0.5 * k * s.dl * s.dl,
    )
}

/// A frame's pass 2 at node `i`: its pool `Pi_i` and a quarter of its springs' direct energy,
/// from pass 1's `terms` (at `slot(b)` for spring `b`).
#[inline]
fn frame_node_pool(
    body: &Body,
    sp: Springs<'_>,
    terms: &[[Real; 2]],
    slot: impl Fn(usize) -> usize,
    i: usize,
) -> (Real, Real) {
    let bonds = &*body.lattice.bonds;
    let (mut s, mut d) = (0.0, 0.0);
    for e in bonds.row(i) {
        let b = bonds.bond[e] as usize;
        if sp.alive[b] {
            let [kl, e] = terms[slot(b)];
            d += e;
            s += kl;
        }
    }
    (s, d)
}

/// A frame's pass 3 at node `i`: its force and its springs' `T l e (x) e / 2` by distinct
/// entries (xx, yy, zz, xy, yz, xz), from pass 1's `geo` and `ext` and the pools.
#[inline]
fn frame_node_force(
    body: &Body,
    sp: Springs<'_>,
    (geo, ext): (&[[Real; 4]], &[[Real; 2]]),
    slot: impl Fn(usize) -> usize,
    pool: &[Real],
    i: usize,
) -> ([Real; 3], [Real; 6]) {
    let bonds = &*body.lattice.bonds;
    let mut f = [0.0; 3];
    // xx, yy, zz, xy, yz, xz: `e (x) e` is symmetric, and `-d` gives the same terms.
    let mut m = [0.0; 6];
    for e in bonds.row(i) {
        let b = bonds.bond[e] as usize;
        if !sp.alive[b] {
            continue;
        }
        let at = slot(b);
        let [dx, dy, dz, l] = geo[at];
        let [kdl, qkl] = ext[at];
        let j = bonds.neighbour(i, e);
        // `T/l`: `tension(k, L, dL, q, p_i, p_j) / l` with its `k dL` and `q k L` from
        // pass 1 (the sum of the two pools is the same number from either end). Each
        // spring's from both ends: a division each time, cheaper than a pass that
        // stores it.
        let s = (kdl + qkl * (pool[i] + pool[j])) / l;
        // A spring's first end is its lower node (`Bonds::from_pairs`).
        let d = if i < j { [dx, dy, dz] } else { [-dx, -dy, -dz] };
        for c in 0..3 {
            f[c] += s * d[c];
        }
        let h = 0.5 * s;
        let hd = [h * dx, h * dy, h * dz];
        m[0] += hd[0] * dx;
        m[1] += hd[1] * dy;
        m[2] += hd[2] * dz;
        m[3] += hd[0] * dy;
        m[4] += hd[1] * dz;
        m[5] += hd[0] * dz;
    }
    (f, m)
}

/// Node `i`'s energy density and virial stress from its sums: the pool `Pi_i`, a quarter of
/// its springs' direct energy and `m`, its springs' `T l e (x) e / 2` by distinct entries
/// (xx, yy, zz, xy, yz, xz).
#[inline]
fn node_density_stress(
    body: &Body,
    pi: &[Real],
    quarter: &[Real],
    norm: &[Real],
    i: usize,
    m: [Real; 6],
) -> (Real, [Real; 9]) {
    let disp = if norm[i] != 0.0 {
        0.5 * body.q * pi[i] * pi[i] / norm[i]
    } else {
        0.0
    };
    // Each node's own volume (on random lattices they differ): summed times it, U.
    let v = body.lattice.node_volume(i);
    let w = 1.0 / v;
    let [xx, yy, zz, xy, yz, xz] = m.map(|x| x * w);
    (
        (quarter[i] + disp) / v,
        [xx, xy, xz, xy, yy, yz, xz, yz, zz],
    )
}

/// The dispersive energy `sum_n q Pi_n^2 / (2 S_n)` as [`ordered_sum`](hooke_model::law::ordered_sum) forms it (per chunk of
/// nodes, the chunks added in order), of the pools `pi` of `nodes` (with `part`, this rank's:
/// the chunks' partial sums are all-gathered).
fn dispersive_sum(
    body: &Body,
    pi: &[Real],
    norm: &[Real],
    nodes: std::ops::Range<usize>,
    part: Option<FramePart<'_>>,
) -> Real {
    let (q, n, chunk) = (body.q, pi.len(), crate::kernel::CHUNK);
    if q == 0.0 {
        return 0.0;
    }
    let disp = |i: usize| {
        if norm[i] != 0.0 {
            0.5 * q * pi[i] * pi[i] / norm[i]
        } else {
            0.0
        }
    };
    let mut partial = vec![0.0; n.div_ceil(chunk)];
    let mine = nodes.start / chunk..nodes.end.div_ceil(chunk);
    partial[mine.clone()]
        .par_iter_mut()
        .enumerate()
        .for_each(|(k, out)| {
            let c = mine.start + k;
            *out = (c * chunk..((c + 1) * chunk).min(n)).map(disp).sum();
        });
    if let Some(p) = part {
        p.team.gather(&mut partial, &p.share.chunk_parts(1));
    }
    partial.iter().sum()
}

/// The frame of `state` ([`frame_fields`]), by [`frame_fields_grid`] where it applies, so that
/// a box's frame leaves its rows and stiffnesses unbuilt.
pub fn frame_fields_of(body: &Body, state: &State) -> FrameFields {
    frame_fields_grid(body, state)
        .unwrap_or_else(|| frame_fields(body, &state.u, state.springs(body), &state.norm))
}

/// [`frame_fields`] of a box read through its [`GridLaw`], bit for bit, or `None` where that
/// does not apply. The direct energy's chunk sums, over the springs in their order (each from
/// its lower end), find their first spring through each node's count of forward links. No
/// per-spring memory: a case's box on a stencil kernel stays without its rows after its
/// frames.
pub fn frame_fields_grid(body: &Body, state: &State) -> Option<FrameFields> {
    let law = GridLaw::of(body, state)?;
    let (u, norm, q) = (&state.u, &state.norm[..], body.q);
    let n = body.nodes();
    // Pools and a quarter of the direct energy, as pass 2 of `frame_fields_part`.
    let mut pi = vec![0.0; n];
    let mut quarter = vec![0.0; n];
    let mut pool = vec![0.0; n];
    pi.par_iter_mut()
        .zip(quarter.par_iter_mut())
        .zip(pool.par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(i, ((p, e4), ratio))| {
            let (mut s, mut d) = (0.0, 0.0);
            law.links(u, i, |_, k, rest, geo| {
                d += 0.25 * k * geo.dl * geo.dl;
                s += k * rest * geo.dl;
            });
            (*p, *e4) = (s, d);
            *ratio = pool_ratio(q, norm[i], || s);
        });
    // Forces, energy densities and stresses, as pass 3 of `frame_fields_part`.
    let mut force = Coords::zeros(n);
    let mut energy_density = vec![0.0; n];
    let mut stress = vec![[0.0; 9]; n];
    let [fx, fy, fz] = force.xyz_mut();
    fx.par_iter_mut()
        .zip(fy.par_iter_mut())
        .zip(fz.par_iter_mut())
        .zip(energy_density.par_iter_mut())
        .zip(stress.par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(i, ((((fx, fy), fz), ed), st))| {
            let mut f = [0.0; 3];
            let mut m = [0.0; 6];
            law.links(u, i, |j, k, rest, geo| {
                // `tension(k, L, dL, q, p_i, p_j) / l`, its `q k L` rounded as pass 1's.
                let qkl = q * k * rest;
                let s = (k * geo.dl + qkl * (pool[i.min(j)] + pool[i.max(j)])) / geo.l;
                let d = geo.d;
                for c in 0..3 {
                    f[c] += s * d[c];
                }
                let h = 0.5 * s;
                let hd = [h * d[0], h * d[1], h * d[2]];
                m[0] += hd[0] * d[0];
                m[1] += hd[1] * d[1];
                m[2] += hd[2] * d[2];
                m[3] += hd[0] * d[1];
                m[4] += hd[1] * d[2];
                m[5] += hd[0] * d[2];
            });
            [*fx, *fy, *fz] = f;
            (*ed, *st) = node_density_stress(body, &pi, &quarter, norm, i, m);
        });
    // The direct energy by chunks of springs in their order: spring `b` is forward link
    // `b - first[i]` of node `i`, `first` the running count of forward links.
    let mut first = Vec::with_capacity(n + 1);
    first.push(0usize);
    let counts: Vec<u32> = (0..n)
        .into_par_iter()
        .with_min_len(MIN_NODES_PER_TASK)
        .map(|i| {
            let mut c = 0;
            law.grid()
                .links(law.star(), i, |j, _| c += u32::from(j > i));
            c
        })
        .collect();
    for c in counts {
        first.push(first.last().unwrap() + c as usize);
    }
    let ns = first[n];
    debug_assert_eq!(ns, law.grid().springs());
    let chunk = crate::kernel::CHUNK;
    let partial: Vec<Real> = (0..ns.div_ceil(chunk))
        .into_par_iter()
        .map(|c| {
            let (b0, b1) = (c * chunk, ((c + 1) * chunk).min(ns));
            // The last node whose forward links start at or before `b0` holds it (nodes with
            // none share their offset with the next).
            let mut i = first.partition_point(|&o| o <= b0) - 1;
            let mut skip = b0 - first[i];
            let mut half = Vec::with_capacity(b1 - b0);
            while half.len() < b1 - b0 {
                let inner = law.is_inner(i);
                law.grid().links(law.star(), i, |j, rest| {
                    if j <= i || half.len() == b1 - b0 {
                    } else if skip > 0 {
                        skip -= 1;
                    } else {
                        let k = law.stiffness(inner, i, j);
                        let dl = spring_geometry(law.lattice(), u, i, j, rest).dl;
                        half.push(0.5 * k * dl * dl);
                    }
                });
                i += 1;
            }
            half.iter().sum::<Real>()
        })
        .collect();
    let direct = partial.iter().sum();
    Some(FrameFields {
        pool,
        force,
        strain: Energy {
            direct,
            dispersive: dispersive_sum(body, &pi, norm, 0..n, None),
        },
        energy_density,
        stress,
    })
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice::Lattice;
    use crate::law::{compute_forces, compute_pools, update_forces};

    /// A box's frame, pools and forces from its grid and stiffness rule are those from its rows
    /// and stiffness list, bit for bit, and build neither: Ladd boxes of one stiffness and weighted by their
    /// cubes (one of several chunks of springs), a box moved off the origin, a hexagonal plate
    /// without dispersion. With a spring broken it leaves the frame to the rows.
    #[test]
    fn a_box_frame_from_its_grid_is_its_rows_frame() {
        let moved = || {
            let mut l = Lattice::cubic_box([6, 7, 5], 0.1).unwrap();
            for c in 0..3 {
                l.pos.comp_mut(c).iter_mut().for_each(|x| *x += 0.0347);
            }
            l.shed_rest();
            l
        };
        let cubic = |n| Lattice::cubic_box(n, 0.1).unwrap();
        let bodies = [
            Body::uniform(cubic([7, 6, 9]), 3.0, 0.3, 2.0),
            Body::uniform(cubic([40, 31, 4]), 3.0, 0.3, 2.0)
                .with_cell_weights()
                .unwrap(),
            Body::uniform(moved(), 3.0, -0.2, 2.0),
            Body::uniform(Lattice::hex_box(23, 17, 0.1, 0.2).unwrap(), 3.0, 0.0, 2.0),
        ];
        let bits = |a: &[Real]| a.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for body in bodies {
            let mut state = State::new(&body);
            let pos = body.lattice.pos.clone();
            let dims = body.lattice.dim();
            for c in 0..dims {
                for (i, u) in state.u.comp_mut(c).iter_mut().enumerate() {
                    let (x, y, z) = (pos.x()[i], pos.y()[i], pos.z()[i]);
                    *u = 1e-3 * (7.0 * x + 3.0 * c as Real).sin() * (5.0 * y).cos()
                        + 2e-4 * z * (c + 1) as Real;
                }
            }
            let grid = frame_fields_grid(&body, &state).expect("a box of a rule");
            let mut lean = state.clone();
            update_forces(&body, &mut lean);
            assert!(!body.lattice.bonds.is_built() && body.k.bytes() == 0);
            let (mut pool, mut force) = (vec![0.0; body.nodes()], Coords::zeros(body.nodes()));
            compute_pools(
                &body,
                &state.u,
                state.springs(&body),
                &state.norm,
                &mut pool,
            );
            compute_forces(&body, &state.u, state.springs(&body), &pool, &mut force);
            assert_eq!(bits(&lean.pool), bits(&pool));
            assert_eq!(bits(lean.f.as_flat()), bits(force.as_flat()));
            assert!(
                body.lattice.bonds.len() > 2 * crate::kernel::CHUNK
                    || body.lattice.bonds.len() < crate::kernel::CHUNK
            );
            let rows = frame_fields(&body, &state.u, state.springs(&body), &state.norm);
            let what = format!("{:?} of {} nodes", body.lattice.kind, body.nodes());
            assert_eq!(bits(&grid.pool), bits(&rows.pool), "{what}: pools");
            assert_eq!(
                bits(grid.force.as_flat()),
                bits(rows.force.as_flat()),
                "{what}: forces"
            );
            assert_eq!(
                bits(&grid.energy_density),
                bits(&rows.energy_density),
                "{what}: energy densities"
            );
            assert_eq!(
                bits(grid.stress.as_flattened()),
                bits(rows.stress.as_flattened()),
                "{what}: stresses"
            );
            assert_eq!(grid.strain.direct.to_bits(), rows.strain.direct.to_bits());
            assert_eq!(
                grid.strain.dispersive.to_bits(),
                rows.strain.dispersive.to_bits()
            );
            assert!(grid.strain.direct > 0.0 && grid.force.as_flat().iter().any(|&f| f != 0.0));
            assert_eq!(body.q != 0.0, grid.strain.dispersive != 0.0, "{what}");
            state.kill_bond(&body, 3);
            assert!(
                frame_fields_grid(&body, &state).is_none() && GridLaw::of(&body, &state).is_none()
            );
        }
    }
}
