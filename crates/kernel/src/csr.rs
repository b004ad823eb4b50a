//! The CSR kernel, for any lattice.
//!
//! Sweep 1 runs over the springs (in parallel over fixed chunks of springs; each spring is
//! written by its own task). For each intact spring `s` from its lower end `i` to its upper
//! end `j` it forms the current vector `d_s`, length `l_s` and extension `dL_s` once
//! ([`hooke_model::law::spring_geometry`]'s cancellation-free form), and stores what the two ends
//! need:
//!
//! ```text
//! record_s = [ k_s dL_s,  q k_s L_s,  d_s / l_s ]      (the force on i is  (r0 + r1 (p_i + p_j)) r2..)
//! pi_s     = k_s L_s dL_s                               (its share of both ends' pools)
//! ```
//!
//! (For a direction-weighted material the `L_s` of `r1` and `pi_s` is the spring's dispersion
//! lever, [`Body::levers`]; for an isotropic one the lever slice *is* the rest lengths, so the
//! extra read hits the same cache lines.)
//!
//! A broken spring's record and share are zeros, so neither later sweep tests `alive`: a zero
//! adds nothing to a sum, bit for bit. Then each node's pool `p_n = sum_t pi_t / S_n` (a gather
//! over its row). Sweep 2 gathers each node's force over its row,
//! `f_i = sum_t +-(r0_t + r1_t (p_i + p_j)) r2_t` (plus for the lower end, minus for the upper
//! end, since `d` points from the lower end to the upper), and kicks and drifts it. A spring
//! costs one square root and two divisions in all, and the force sweep reads no position at all:
//! only the records, the neighbours' pools and the row.
//!
//! Against the reference law ([`hooke_model::law::node_force`], which divides `T_s` by `l_s` at each
//! end) the forces agree to round-off (tested to 1e-12 of the largest force, with broken
//! springs, on every lattice kind). Both ends of a spring read the same record and the same sum
//! `p_i + p_j`, so the two forces are exact opposites and momentum is conserved to round-off.
//!
//! The loops are specialised at compile time for plates (`D = 2`: z is neither read nor stored;
//! a plate's springs lie in the plane) and for periodic lattices (the minimum-image wrap is only
//! compiled into the periodic variant).

use rayon::prelude::*;

use super::{sweep_chunks, StepParams, SweepSums, BLOCK, CHUNK};
use crate::share::Share;
use hooke_model::body::Body;
use hooke_model::lattice::{reference_vector, Lattice};
use hooke_model::math::{Coords, Real};
use hooke_model::state::State;

/// Reals per spring record: `k dL`, `q k L`, and the unit vector's `D` components.
pub(crate) const fn stride(dim: usize) -> usize {
    2 + dim
}

/// Sweep 1: the spring records and pool shares, then the pools (zero for the plain law, `q =
/// 0`). With a finite `screen` s, it also flags each block of `BLOCK` springs holding an
/// intact spring with `dL > s L` in `state.hot` (the fracture check then looks at those blocks
/// only); pass infinity for no screen.
///
/// With a `share` (a rank's part of a distributed run, `hooke_core::team`), only the records of
/// its springs and the pools of its nodes are computed, and the screen flags of all other
/// blocks are cleared (the ranks then combine them).
pub fn pools(body: &Body, state: &mut State, plain: bool, screen: Real, share: Option<&Share>) {
    let lat = &body.lattice;
    let q = if plain { 0.0 } else { body.q };
    match (lat.dim(), lat.is_periodic()) {
        (2, false) => pools_impl::<2, false>(body, state, q, screen, share),
        (2, true) => pools_impl::<2, true>(body, state, q, screen, share),
        (_, false) => pools_impl::<3, false>(body, state, q, screen, share),
        (_, true) => pools_impl::<3, true>(body, state, q, screen, share),
    }
}

fn pools_impl<const D: usize, const P: bool>(
    body: &Body,
    state: &mut State,
    q: Real,
    screen: Real,
    share: Option<&Share>,
) {
    let bonds = &*body.lattice.bonds;
    let springs = bonds.len();
    let w = stride(D);
    if state.spring.len() != w * springs || state.spring_pi.len() != springs {
        // Sized once per state (the first step), not per step.
        state.spring = vec![0.0; w * springs];
        state.spring_pi = vec![0.0; springs];
    }
    if state.hot.len() != springs.div_ceil(BLOCK) {
        state.hot = vec![false; springs.div_ceil(BLOCK)];
    }
    let (u, alive) = (&state.u, &state.alive);
    // The current stiffnesses: the body's, or those a softening material left.
    let kk = hooke_model::state::Springs::of(body, alive, &state.k_eff).k;
    let levers = body.levers();
    let lat = &body.lattice;
    let wide = wide_available();
    // This rank's springs (all of them in one process); `first` is a multiple of BLOCK.
    let mine = share.map_or(0..springs, |s| s.springs.clone());
    let first = mine.start;
    if share.is_some() {
        state.hot.fill(false);
    }
    state.spring[w * mine.start..w * mine.end]
        .par_chunks_mut(w * CHUNK)
        .zip(state.spring_pi[mine.clone()].par_chunks_mut(CHUNK))
        .zip(state.hot[first / BLOCK..mine.end.div_ceil(BLOCK)].par_chunks_mut(CHUNK / BLOCK))
        .enumerate()
        .for_each(|(c, ((rec, pis), hot))| {
            let start = first + c * CHUNK;
            let n = pis.len();
            let springs = Springs {
                ends: &bonds.ends[start..start + n],
                k: &kk[start..start + n],
                rest: bonds.stored_rest().map(|r| &r[start..start + n]),
                lever: levers.stored().map(|l| &l[start..start + n]),
                alive: &alive[start..start + n],
            };
            #[cfg(target_arch = "x86_64")]
            if wide {
                // SAFETY: `wide_available` checked that the processor has AVX.
                unsafe { spring_chunk_avx::<D, P>(lat, u, q, screen, &springs, rec, pis, hot) };
                return;
            }
            let _ = wide;
            spring_chunk::<D, P>(lat, u, q, screen, &springs, rec, pis, hot);
        });
    if let Some(s) = share {
        for &b in &s.foreign {
            let b = b as usize;
            let (rec, pi) = (&mut state.spring[w * b..w * b + w], &mut state.spring_pi[b]);
            spring_one::<D, P>(lat, u, q, kk[b], bonds, levers, alive[b], b, rec, pi);
        }
    }
    if q == 0.0 {
        state.pool.fill(0.0);
        return;
    }
    let nodes = share.map_or(0..body.nodes(), |s| s.mine());
    let (norm, pis) = (&state.norm, &state.spring_pi);
    let start = nodes.start;
    state.pool[nodes]
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, pool)| {
            let first = start + c * CHUNK;
            for (k, p) in pool.iter_mut().enumerate() {
                *p = node_pool(body, norm, pis, first + k);
            }
        });
}

/// One spring's record and pool share, by the operations [`spring_chunk`] applies to it (a
/// broken spring goes through them with zero stiffness and a zero vector, as there), so the
/// bits are the same: what a rank uses for the springs of its rows that another rank's range
/// holds.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn spring_one<const D: usize, const P: bool>(
    lat: &Lattice,
    u: &Coords,
    q: Real,
    k: Real,
    bonds: &hooke_model::lattice::Bonds,
    lev: hooke_model::body::Levers,
    alive: bool,
    b: usize,
    rec: &mut [Real],
    pi: &mut Real,
) {
    let rest = lat.rest(b);
    let lever = lev.get(b);
    let (k, l2, num) = if alive {
        let [i, j] = bonds.ends[b].map(|v| v as usize);
        let (d, d2, nm) = vector::<D, P>(lat, u, i, j);
        rec[2..].copy_from_slice(&d[..D]);
        (k, d2, nm)
    } else {
        rec[2..].fill(0.0);
        (0.0, 1.0, 0.0)
    };
    let l = l2.sqrt();
    let inv = 1.0 / l;
    let dl = num / (l + rest);
    rec[0] = k * dl;
    rec[1] = q * k * lever;
    for c in 0..D {
        rec[2 + c] *= inv;
    }
    *pi = k * lever * dl;
}

/// `p_n = sum_t pi_t / S_n` over node n's row (broken springs' shares are zeros).
#[inline(always)]
fn node_pool(body: &Body, norm: &[Real], pis: &[Real], n: usize) -> Real {
    let bonds = &*body.lattice.bonds;
    let s = norm[n];
    // Negative at a node of negative q_n (Body::q_node); 0 only without springs.
    if s != 0.0 {
        let mut sum = 0.0;
        for &b in &bonds.bond[bonds.row(n)] {
            sum += pis[b as usize];
        }
        sum / s
    } else {
        0.0
    }
}

/// After springs `changed` broke or softened between sweep 1 and sweep 2: zero the broken
/// ones' records and shares, recompute the softened ones' with their new stiffness, and
/// recompute their ends' pools, exactly as sweep 1 would have with the springs already changed
/// (the same operations on the same values), so changing them mid-step gives the bits of
/// changing them before it.
pub(crate) fn repair(body: &Body, state: &mut State, plain: bool, changed: &[u32]) {
    let lat = &body.lattice;
    let w = stride(lat.dim());
    if state.spring_pi.len() != body.springs() {
        return;
    }
    let q = if plain { 0.0 } else { body.q };
    let (u, alive) = (&state.u, &state.alive);
    let kk = hooke_model::state::Springs::of(body, alive, &state.k_eff).k;
    let levers = body.levers();
    let bonds = &*lat.bonds;
    for &b in changed {
        let b = b as usize;
        let (rec, pi) = (&mut state.spring[w * b..w * b + w], &mut state.spring_pi[b]);
        if !alive[b] {
            rec.fill(0.0);
            *pi = 0.0;
            continue;
        }
        match (lat.dim(), lat.is_periodic()) {
            (2, false) => spring_one::<2, false>(lat, u, q, kk[b], bonds, levers, true, b, rec, pi),
            (2, true) => spring_one::<2, true>(lat, u, q, kk[b], bonds, levers, true, b, rec, pi),
            (_, false) => spring_one::<3, false>(lat, u, q, kk[b], bonds, levers, true, b, rec, pi),
            (_, true) => spring_one::<3, true>(lat, u, q, kk[b], bonds, levers, true, b, rec, pi),
        }
    }
    if q == 0.0 {
        return;
    }
    for &b in changed {
        for n in body.lattice.bonds.ends[b as usize] {
            let n = n as usize;
            state.pool[n] = node_pool(body, &state.norm, &state.spring_pi, n);
        }
    }
}

/// Springs of the blocks sweep 1 flagged (ascending; broken ones included), appended to `out`.
pub(crate) fn hot_springs(state: &State, springs: usize, out: &mut Vec<u32>) {
    for (blk, _) in state.hot.iter().enumerate().filter(|(_, &h)| h) {
        out.extend((blk * BLOCK..((blk + 1) * BLOCK).min(springs)).map(|b| b as u32));
    }
}

/// The per-spring inputs of one chunk of sweep 1. Rest lengths that the lattice shed
/// ([`Lattice::rest`]) are recomputed from the reference positions, and levers that are the
/// rest lengths are read from them (`None`).
struct Springs<'a> {
    ends: &'a [[u32; 2]],
    k: &'a [Real],
    rest: Option<&'a [Real]>,
    lever: Option<&'a [Real]>,
    alive: &'a [bool],
}

/// True when sweep 1 may use AVX (x86-64 processors since 2011), unless the portable paths are
/// forced ([`super::Simd::Portable`]). Either way the results are the same bits: the vector
/// loop performs the same IEEE operations (Rust never fuses a multiply and an add on its own).
pub(crate) fn wide_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    let avx = std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    let avx = false;
    super::simd_allowed() && avx
}

/// [`spring_chunk`] compiled for AVX.
///
/// # Safety
/// The processor must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[allow(clippy::too_many_arguments)]
unsafe fn spring_chunk_avx<const D: usize, const P: bool>(
    lat: &Lattice,
    u: &Coords,
    q: Real,
    screen: Real,
    sp: &Springs,
    rec: &mut [Real],
    pis: &mut [Real],
    hot: &mut [bool],
) {
    spring_chunk::<D, P>(lat, u, q, screen, sp, rec, pis, hot)
}

/// Sweep 1 over one chunk of springs: records, pool shares and the blocks' screen flags.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spring_chunk<const D: usize, const P: bool>(
    lat: &Lattice,
    u: &Coords,
    q: Real,
    screen: Real,
    sp: &Springs,
    rec: &mut [Real],
    pis: &mut [Real],
    hot: &mut [bool],
) {
    let w = stride(D);
    let n = pis.len();
    let p = &lat.pos;
    let pos = [p.x(), p.y(), p.z()];
    let disp = [u.x(), u.y(), u.z()];
    let mut b0 = 0;
    while b0 < n {
        let m = BLOCK.min(n - b0);
        // Gather: the current vector (straight into the record), |d|^2, the numerator of dL,
        // and the stiffness, zero for a broken spring (whose record is then all zeros: `l2 =
        // 1` keeps its square root finite).
        let (mut l2, mut num, mut k, mut rest, mut lever) = (
            [1.0; BLOCK],
            [0.0; BLOCK],
            [0.0; BLOCK],
            [0.0; BLOCK],
            [0.0; BLOCK],
        );
        // The block's slices, cut once so that the loop below indexes them without
        // re-checking their lengths.
        let ends = &sp.ends[b0..b0 + m];
        let (brest, blever, balive, bk) = (
            sp.rest.map(|r| &r[b0..b0 + m]),
            sp.lever.map(|l| &l[b0..b0 + m]),
            &sp.alive[b0..b0 + m],
            &sp.k[b0..b0 + m],
        );
        let brec = &mut rec[w * b0..w * (b0 + m)];
        for s in 0..m {
            let r = &mut brec[w * s..w * s + w];
            rest[s] = match brest {
                Some(l) => l[s],
                // Shed only where nothing is periodic (`Lattice::shed_setup`).
                None => {
                    let [i, j] = ends[s].map(|v| v as usize);
                    hooke_model::lattice::reference_length([0, 1, 2].map(|c| pos[c][j] - pos[c][i]))
                }
            };
            lever[s] = blever.map_or(rest[s], |l| l[s]);
            if !balive[s] {
                r[2..].fill(0.0);
                continue;
            }
            k[s] = bk[s];
            let [i, j] = ends[s].map(|v| v as usize);
            let (d, d2, nm) = if P {
                vector::<D, P>(lat, u, i, j)
            } else {
                vector_open::<D>(&pos, &disp, i, j)
            };
            r[2..].copy_from_slice(&d[..D]);
            l2[s] = d2;
            num[s] = nm;
        }
        // Square roots and divisions over contiguous arrays (vectorised).
        let (mut inv, mut dl) = ([0.0; BLOCK], [0.0; BLOCK]);
        for s in 0..BLOCK {
            let l = l2[s].sqrt();
            inv[s] = 1.0 / l;
            dl[s] = num[s] / (l + rest[s]);
        }
        // The break screen (no branch: a compare per spring). Broken springs and the unused
        // tail have dL = 0, and rest 0 makes the product NaN, which compares false.
        let mut h = false;
        for s in 0..BLOCK {
            h |= dl[s] > screen * rest[s];
        }
        hot[b0 / BLOCK] = h;
        let bpis = &mut pis[b0..b0 + m];
        for (s, (r, pi)) in brec.chunks_exact_mut(w).zip(bpis.iter_mut()).enumerate() {
            r[0] = k[s] * dl[s];
            r[1] = q * k[s] * lever[s];
            for c in 0..D {
                r[2 + c] *= inv[s];
            }
            *pi = k[s] * lever[s] * dl[s];
        }
        b0 += m;
    }
}

/// [`vector`] of a lattice without periodic axes, from the component slices of the reference
/// positions and the displacements (cut once per chunk): the same operations in the same order.
#[inline(always)]
fn vector_open<const D: usize>(
    pos: &[&[Real]; 3],
    disp: &[&[Real]; 3],
    i: usize,
    j: usize,
) -> ([Real; 3], Real, Real) {
    let mut big = [0.0; 3];
    let mut w = [0.0; 3];
    for c in 0..D {
        big[c] = pos[c][j] - pos[c][i];
        w[c] = disp[c][j] - disp[c][i];
    }
    geometry::<D>(big, w)
}

/// From the reference vector `big` and the displacement difference `w`: the current vector `d`,
/// `|d|^2` and the numerator `2 D.w + w.w` of the extension ([`hooke_model::law::spring_geometry`]'s
/// operations in its order; in 2D its z terms are exact zeros and are left out).
#[inline(always)]
pub(crate) fn geometry<const D: usize>(big: [Real; 3], w: [Real; 3]) -> ([Real; 3], Real, Real) {
    let d = [big[0] + w[0], big[1] + w[1], big[2] + w[2]];
    if D == 3 {
        (
            d,
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2],
            2.0 * (big[0] * w[0] + big[1] * w[1] + big[2] * w[2])
                + (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]),
        )
    } else {
        (
            d,
            d[0] * d[0] + d[1] * d[1],
            2.0 * (big[0] * w[0] + big[1] * w[1]) + (w[0] * w[0] + w[1] * w[1]),
        )
    }
}

/// The current vector `d` from `i` to `j`, `|d|^2` and the numerator `2 D.w + w.w` of the
/// extension, `D` dimensions, `P` with the periodic wrap: [`hooke_model::law::spring_geometry`] (the
/// same operations in the same order; in 2D its z terms are exact zeros and are left out).
#[inline(always)]
fn vector<const D: usize, const P: bool>(
    lat: &Lattice,
    u: &Coords,
    i: usize,
    j: usize,
) -> ([Real; 3], Real, Real) {
    let p = &lat.pos;
    let disp = [u.x(), u.y(), u.z()];
    if !P {
        return vector_open::<D>(&[p.x(), p.y(), p.z()], &disp, i, j);
    }
    let big = reference_vector(p, lat.period, i, j);
    let mut w = [0.0; 3];
    for c in 0..D {
        w[c] = disp[c][j] - disp[c][i];
    }
    geometry::<D>(big, w)
}

/// Sweep 2 over CSR rows.
pub fn force_kick_drift(
    body: &Body,
    state: &mut State,
    inv_mass: &[Real],
    p: &StepParams,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    chunks: std::ops::Range<usize>,
) -> SweepSums {
    if body.lattice.dim() == 2 {
        fkd::<2, 4>(body, state, inv_mass, p, u_next, partials, chunks)
    } else {
        fkd::<3, 5>(body, state, inv_mass, p, u_next, partials, chunks)
    }
}

/// Sweep 2 for `D` dimensions, whose records hold `W = 2 + D` reals: as fixed-size arrays the
/// records are read without a length check per row entry.
fn fkd<const D: usize, const W: usize>(
    body: &Body,
    state: &mut State,
    inv_mass: &[Real],
    p: &StepParams,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    chunks: std::ops::Range<usize>,
) -> SweepSums {
    let (u, pool, rec) = (&state.u, &state.pool, &state.spring);
    let bonds = &*body.lattice.bonds;
    debug_assert_eq!(W, stride(D));
    let (rec, rest) = rec.as_chunks::<W>();
    debug_assert!(rest.is_empty());
    let dims = p.dims(D);
    sweep_chunks(
        body.nodes(),
        chunks,
        &mut state.v,
        u_next,
        partials,
        |r, mut o| {
            let mut sums = SweepSums::default();
            for (k, i) in r.enumerate() {
                let mut f = [0.0; 3];
                let pi = pool[i];
                let mut add = |j: usize, b: usize| {
                    let r = &rec[b];
                    let t = r[0] + r[1] * (pi + pool[j]);
                    // The record's vector points from the lower end to the upper end.
                    let t = if j > i { t } else { -t };
                    for c in 0..D {
                        f[c] += t * r[2 + c];
                    }
                };
                let row = bonds.row(i);
                match bonds.neighbours() {
                    Some(nbr) => {
                        for (&j, &b) in nbr[row.clone()].iter().zip(&bonds.bond[row]) {
                            add(j as usize, b as usize);
                        }
                    }
                    // A body that was not meant for this kernel (see `csr_may_run`).
                    None => bonds.links(i).for_each(|(j, b)| add(j, b)),
                }
                let u_old = [u.x()[i], u.y()[i], u.z()[i]];
                o.kick_drift(k, dims, f, inv_mass[i], p, u_old, &mut sums);
            }
            sums
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use hooke_model::random::RandomSpec;

    /// The AVX build of sweep 1 and the portable one give the same bits (the portable one is what
    /// runs where AVX is missing or the portable paths are forced), on plates and solids with broken
    /// springs and a displacement.
    #[test]
    fn wide_and_portable_sweeps_agree_bit_for_bit() {
        let spec = RandomSpec::default();
        for lat in [
            Lattice::random(2, [0.0; 3], [9.0, 7.0, 0.0], 1.0, 1.0, spec, &|_| true).unwrap(),
            Lattice::random(3, [0.0; 3], [5.0, 4.0, 4.0], 1.0, 1.0, spec, &|_| true).unwrap(),
        ] {
            let dim = lat.dim();
            let body = Body::uniform(lat, 1.0, 0.3, 1.0);
            let mut state = State::new(&body);
            state.set_alive(&body, (0..body.springs()).map(|b| b % 5 != 3).collect());
            for i in 0..body.nodes() {
                let x = body.lattice.pos.get(i);
                state.u.x_mut()[i] = 0.01 * (1.3 * x.y).sin();
                state.u.y_mut()[i] = 0.02 * (0.7 * x.x + 0.2 * x.z).cos();
                if dim == 3 {
                    state.u.z_mut()[i] = 0.015 * (0.9 * x.x).sin();
                }
            }
            let n = body.springs();
            let sp = Springs {
                ends: &body.lattice.bonds.ends,
                k: &body.k,
                rest: body.lattice.bonds.stored_rest(),
                lever: body.levers().stored(),
                alive: &state.alive,
            };
            let dl: Vec<Real> = (0..n)
                .map(|b| {
                    let [i, j] = body.lattice.bonds.ends[b].map(|v| v as usize);
                    let rest = body.lattice.rest(b);
                    hooke_model::law::spring_geometry(&body.lattice, &state.u, i, j, rest).dl
                })
                .collect();
            // A screen that only the most stretched springs pass.
            let screen = 0.9
                * (0..n)
                    .filter(|&b| state.alive[b])
                    .map(|b| dl[b] / body.lattice.rest(b))
                    .fold(0.0, Real::max);
            let w = stride(dim);
            let run = |wide: bool| {
                let (mut rec, mut pis) = (vec![0.0; w * n], vec![0.0; n]);
                let mut hot = vec![false; n.div_ceil(BLOCK)];
                let lat = &body.lattice;
                match (dim, wide) {
                    (2, false) => spring_chunk::<2, false>(
                        lat, &state.u, 0.3, screen, &sp, &mut rec, &mut pis, &mut hot,
                    ),
                    (3, false) => spring_chunk::<3, false>(
                        lat, &state.u, 0.3, screen, &sp, &mut rec, &mut pis, &mut hot,
                    ),
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: the test runs the wide path only where the processor has AVX
                    // (checked below), on buffers sized for the whole chunk.
                    (2, true) => unsafe {
                        spring_chunk_avx::<2, false>(
                            lat, &state.u, 0.3, screen, &sp, &mut rec, &mut pis, &mut hot,
                        )
                    },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: the test runs the wide path only where the processor has AVX
                    // (checked below), on buffers sized for the whole chunk.
                    (3, true) => unsafe {
                        spring_chunk_avx::<3, false>(
                            lat, &state.u, 0.3, screen, &sp, &mut rec, &mut pis, &mut hot,
                        )
                    },
                    _ => unreachable!(),
                }
                (rec, pis, hot)
            };
            let portable = run(false);
            assert!(portable.0.iter().any(|&r| r != 0.0));
            // The screen flags exactly the blocks with a spring past it.
            let expect: Vec<bool> = (0..n.div_ceil(BLOCK))
                .map(|blk| {
                    (blk * BLOCK..((blk + 1) * BLOCK).min(n))
                        .any(|b| state.alive[b] && dl[b] > screen * body.lattice.rest(b))
                })
                .collect();
            assert_eq!(portable.2, expect);
            assert!(expect.iter().any(|&h| h) && expect.iter().any(|&h| !h));
            if cfg!(target_arch = "x86_64") && std::arch::is_x86_feature_detected!("avx") {
                let wide = run(true);
                let same = |a: &[Real], b: &[Real]| {
                    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
                };
                assert!(same(&portable.0, &wide.0) && same(&portable.1, &wide.1));
                assert_eq!(portable.2, wide.2);
            }
        }
    }
}
