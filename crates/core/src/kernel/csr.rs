//! The CSR kernel: sweep 2 for any lattice (sweep 1 is [`crate::law::compute_pools`]).

use rayon::prelude::*;

use super::{kick_drift, Disjoint, StepParams, SweepSums, CHUNK};
use crate::body::Body;
use crate::law::{spring_geometry, tension};
use crate::math::{Coords, Real};
use crate::state::State;

/// Force of node `n` from the state's displacements and pools, with dispersion ratio `q`.
#[inline]
pub fn node_force(
    body: &Body,
    q: Real,
    u: &Coords,
    alive: &[bool],
    pool: &[Real],
    n: usize,
) -> [Real; 3] {
    let bonds = &body.lattice.bonds;
    let lat = &body.lattice;
    let mut f = [0.0; 3];
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        if !alive[b] {
            continue;
        }
        let j = bonds.nbr[e] as usize;
        let rest = bonds.rest[b];
        let g = spring_geometry(lat, u, n, j, rest);
        let s = tension(body.k[b], rest, g.dl, q, pool[n], pool[j]) / g.l;
        f[0] += s * g.d[0];
        f[1] += s * g.d[1];
        f[2] += s * g.d[2];
    }
    f
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
    let n = body.nodes();
    let chunks = n.div_ceil(CHUNK);
    let (vx, vy, vz) = (
        Disjoint::new(&mut state.v.x),
        Disjoint::new(&mut state.v.y),
        Disjoint::new(&mut state.v.z),
    );
    let (nx, ny, nz) = (
        Disjoint::new(&mut u_next.x),
        Disjoint::new(&mut u_next.y),
        Disjoint::new(&mut u_next.z),
    );
    let (u, alive, pool) = (&state.u, &state.alive, &state.pool);
    partials[..chunks]
        .par_iter_mut()
        .enumerate()
        .for_each(|(c, out)| {
            let r = c * CHUNK..((c + 1) * CHUNK).min(n);
            // SAFETY: chunk ranges are disjoint and each task touches only its own.
            let (vx, vy, vz, nx, ny, nz) = unsafe {
                (
                    vx.range(r.clone()),
                    vy.range(r.clone()),
                    vz.range(r.clone()),
                    nx.range(r.clone()),
                    ny.range(r.clone()),
                    nz.range(r.clone()),
                )
            };
            let mut sums = SweepSums::default();
            for (k, i) in r.enumerate() {
                let f = node_force(body, q, u, alive, pool, i);
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
            *out = sums;
        });
    let mut total = SweepSums::default();
    for &s in &partials[..chunks] {
        total += s;
    }
    total
}
