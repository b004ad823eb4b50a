//! Energy criterion: a spring breaks when the energy it carries (direct plus its share of its
//! nodes' dispersive energy, [`crate::SpringState::energy`]) exceeds `w_c`, and it is in tension.
//! Unlike the stretch criterion it sees the dispersive coupling: a spring in a node that is being
//! dilated carries more energy, and breaks earlier, than one at the same stretch whose
//! neighbours are relaxed.
//!
//! For a spring of length L at a uniform stretch s, `w = 1/2 k s^2 L^2 (1 + 2q)`: setting
//! `w_c(L) = 1/2 k s_c^2 L^2 (1 + 2q)` makes the two criteria agree in that state, which is how
//! [`SpringEnergy::matching`] derives `w_c` per spring length from a critical stretch (and so
//! from G_c, with the same calibration).

use hooke_core::Real;

use crate::criterion::{Criterion, SpringState};
use crate::error::FractureError;

/// Break when the spring's energy exceeds `w_c * (L / L_ref)^2` and it is in tension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringEnergy {
    /// Critical energy of a spring of length `l_ref` (J).
    pub w_c: Real,
    /// Reference length (m); springs of other lengths scale with `L^2`.
    pub l_ref: Real,
}

impl SpringEnergy {
    /// The criterion that agrees with the critical stretch `s_c` under uniform stretch, for
    /// springs of stiffness `k` and the material's `q`.
    pub fn matching(s_c: Real, k: Real, q: Real, l_ref: Real) -> Result<Self, FractureError> {
        let w_c = 0.5 * k * s_c * s_c * l_ref * l_ref * (1.0 + 2.0 * q);
        if !(w_c.is_finite() && w_c > 0.0 && l_ref > 0.0) {
            return Err(FractureError::BadParameter {
                what: "critical spring energy w_c (J)",
                value: w_c,
                fix: "give a positive critical stretch, stiffness and length",
            });
        }
        Ok(SpringEnergy { w_c, l_ref })
    }
}

impl Criterion for SpringEnergy {
    fn name(&self) -> &'static str {
        "spring-energy"
    }

    fn breaks(&self, s: &SpringState) -> bool {
        let r = s.rest / self.l_ref;
        s.dl > 0.0 && s.energy() > self.w_c * r * r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agrees_with_the_stretch_criterion_under_uniform_stretch() {
        let (k, q, s_c) = (2.0, 0.6, 1e-3);
        let c = SpringEnergy::matching(s_c, k, q, 1.0).unwrap();
        for (rest, s) in [
            (1.0, 0.99e-3),
            (1.0, 1.01e-3),
            (2f64.sqrt(), 0.99e-3),
            (2f64.sqrt(), 1.01e-3),
        ] {
            // Uniform stretch s: the pool ratio of every node is s.
            let st = SpringState {
                k,
                rest,
                dl: s * rest,
                pool: [s, s],
                q,
            };
            assert_eq!(c.breaks(&st), s > s_c, "L={rest} s={s}");
        }
    }
}
