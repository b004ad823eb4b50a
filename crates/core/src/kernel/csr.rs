//! The CSR kernel, for any lattice.
//!
//! Sweep 1 computes every intact spring's current length `l_s` and extension `dL_s` once (in
//! parallel over fixed chunks of springs, each spring written by its own task), then each node's
//! pool `p_n = sum_t k_t L_t dL_t / S_n` from them. Sweep 2 gathers each node's force
//! `sum_t (T_t / l_t) d_t` over its row with `T_t = k_t dL_t + q k_t L_t (p_n + p_j)` and kicks
//! and drifts it. The reference law ([`crate::law::node_force`]) forms the same quantities
//! from each end of a spring in turn: the spring's vector from the other end is the exact
//! negative (every term is a difference negated), so `l` and `dL` are the same bits, and this
//! kernel gives the reference law's forces bit for bit with one square root and one division
//! per spring instead of four and six.

use rayon::prelude::*;

use super::{kick_drift, sweep_chunks, ChunkOut, StepParams, SweepSums, CHUNK};
use crate::body::Body;
use crate::law::{spring_geometry, spring_vector, tension};
use crate::math::{Coords, Real};
use crate::state::State;

/// Sweep 1: lengths and extensions of the intact springs, then the pools (zero for the plain
/// law, `q = 0`).
pub fn pools(body: &Body, state: &mut State, plain: bool) {
    let bonds = &body.lattice.bonds;
    let springs = bonds.len();
    if state.spring_len.len() != springs {
        // Sized once per state (the first step), not per step.
        state.spring_len = vec![0.0; springs];
        state.spring_dl = vec![0.0; springs];
    }
    let (u, alive) = (&state.u, &state.alive);
    let lat = &body.lattice;
    state
        .spring_len
        .par_chunks_mut(CHUNK)
        .zip(state.spring_dl.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (len, dl))| {
            let start = c * CHUNK;
            for (k, (l, d)) in len.iter_mut().zip(dl.iter_mut()).enumerate() {
                let b = start + k;
                if alive[b] {
                    let [i, j] = bonds.ends[b].map(|v| v as usize);
                    let g = spring_geometry(lat, u, i, j, bonds.rest[b]);
                    *l = g.l;
                    *d = g.dl;
                }
            }
        });
    if plain || body.q == 0.0 {
        state.pool.fill(0.0);
        return;
    }
    let (alive, norm, dls) = (&state.alive, &state.norm, &state.spring_dl);
    state
        .pool
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, pool)| {
            for (k, p) in pool.iter_mut().enumerate() {
                let n = c * CHUNK + k;
                let s = norm[n];
                *p = if s > 0.0 {
                    let mut pi = 0.0;
                    for e in bonds.row(n) {
                        let b = bonds.bond[e] as usize;
                        if alive[b] {
                            pi += body.k[b] * bonds.rest[b] * dls[b];
                        }
                    }
                    pi / s
                } else {
                    0.0
                };
            }
        });
}

/// Sweep 2 over CSR rows.
pub fn force_kick_drift(
    body: &Body,
    state: &mut State,
    inv_mass: &[Real],
    p: &StepParams,
    u_next: &mut Coords,
    partials: &mut [SweepSums],
    q: Real,
) -> SweepSums {
    let (u, alive, pool) = (&state.u, &state.alive, &state.pool);
    let (len, dls) = (&state.spring_len, &state.spring_dl);
    let bonds = &body.lattice.bonds;
    let lat = &body.lattice;
    sweep_chunks(body.nodes(), &mut state.v, u_next, partials, |r, o| {
        let ChunkOut {
            v: [vx, vy, vz],
            u_next: [nx, ny, nz],
        } = o;
        let mut sums = SweepSums::default();
        for (k, i) in r.enumerate() {
            let mut f = [0.0; 3];
            for e in bonds.row(i) {
                let b = bonds.bond[e] as usize;
                if !alive[b] {
                    continue;
                }
                let j = bonds.nbr[e] as usize;
                let s = tension(body.k[b], bonds.rest[b], dls[b], q, pool[i], pool[j]) / len[b];
                let (dx, dy, dz) = spring_vector(lat, u, i, j);
                f[0] += s * dx;
                f[1] += s * dy;
                f[2] += s * dz;
            }
            let (d, w) = kick_drift(
                f,
                inv_mass[i],
                p,
                [&mut vx[k], &mut vy[k], &mut vz[k]],
                [u.x[i], u.y[i], u.z[i]],
                [&mut nx[k], &mut ny[k], &mut nz[k]],
            );
            sums.dissipated += d;
            sums.body_work += w;
        }
        sums
    })
}
