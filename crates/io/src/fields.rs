//! Derived per-node fields, computed only for output (never on the hot path).

use hooke_core::law::{self, spring_geometry};
use hooke_core::{Body, Matrix, Real, State};

/// Fields derived from a state.
#[derive(Clone, Debug)]
pub struct Derived {
    /// Pool ratio `p_n = Pi_n / S_n`: under uniform strain it equals `tr(eps)/d`, a local
    /// dilatation.
    pub pool: Vec<Real>,
    /// Strain energy density (J/m^3): half of each intact spring's direct energy plus the node's
    /// dispersive energy, over the node's volume. Summed times the volume it gives U exactly.
    pub energy_density: Vec<Real>,
    /// Virial stress `1/(2V_n) sum_t T_t l_t e_t e_t` (Pa), row-major 3x3, V_n the node's volume.
    pub stress: Vec<[Real; 9]>,
}

/// Compute the derived fields of `state`.
pub fn derived(body: &Body, state: &State) -> Derived {
    let n = body.nodes();
    let mut pool = vec![0.0; n];
    law::compute_pools(body, &state.u, &state.alive(), &state.norm(), &mut pool);
    let bonds = &body.lattice.bonds;
    let lat = &body.lattice;
    let t = law::spring_tensions(body, &state.u, &state.alive(), &pool);
    let mut energy_density = vec![0.0; n];
    let mut stress = vec![[0.0; 9]; n];
    for i in 0..n {
        let mut direct = 0.0;
        let mut pi = 0.0;
        for e in bonds.row(i) {
            let b = bonds.bond[e] as usize;
            if state.alive()[b] {
                let rest = bonds.rest[b];
                let dl = spring_geometry(lat, &state.u, i, bonds.nbr[e] as usize, rest).dl;
                direct += 0.25 * body.k[b] * dl * dl;
                pi += body.k[b] * rest * dl;
            }
        }
        let disp = if state.norm()[i] > 0.0 {
            0.5 * body.q * pi * pi / state.norm()[i]
        } else {
            0.0
        };
        // Each node's own volume (on random lattices they differ): summed times it, U exactly.
        energy_density[i] = (direct + disp) / lat.node_volume(i);
        let s: Matrix = law::node_virial(body, &state.u, &t, i);
        for r in 0..3 {
            for c in 0..3 {
                stress[i][3 * r + c] = s[(r, c)];
            }
        }
    }
    Derived {
        pool,
        energy_density,
        stress,
    }
}
