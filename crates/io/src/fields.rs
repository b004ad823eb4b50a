//! Derived per-node fields, computed only for output (never on the hot path).

use hooke_core::law;
use hooke_core::{Body, Real, State};

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

/// Compute the derived fields of `state` ([`law::frame_fields`]).
pub fn derived(body: &Body, state: &State) -> Derived {
    law::frame_fields(body, &state.u, state.springs(body), state.norm()).into()
}

impl From<law::FrameFields> for Derived {
    fn from(f: law::FrameFields) -> Self {
        Derived {
            pool: f.pool,
            energy_density: f.energy_density,
            stress: f.stress,
        }
    }
}
