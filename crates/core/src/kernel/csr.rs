//! The CSR kernel: sweep 2 for any lattice (sweep 1 is [`crate::law::compute_pools`]).

use super::{kick_drift, sweep_chunks, ChunkOut, StepParams, SweepSums};
use crate::body::Body;
use crate::law::node_force;
use crate::math::{Coords, Real};
use crate::state::State;

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
    sweep_chunks(body.nodes(), &mut state.v, u_next, partials, |r, o| {
        let ChunkOut {
            v: [vx, vy, vz],
            u_next: [nx, ny, nz],
        } = o;
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
        sums
    })
}
