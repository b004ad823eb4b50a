//! Energy criterion: a spring breaks when the energy it carries (direct plus its share of its
//! nodes' dispersive energy, [`crate::SpringState::energy`]) exceeds `w_c`, and it is in tension.
//! Unlike the stretch criterion it sees the dispersive coupling: a spring in a node that is being
//! dilated carries more energy, and breaks earlier, than one at the same stretch whose
//! neighbours are relaxed.
//!
//! For a spring of length L at a uniform stretch s, `w = 1/2 k s^2 L^2 (1 + 2q)`: setting
//! `w_c(L) = 1/2 k s_c^2 L^2 (1 + 2q)` makes the two criteria agree in that state, which is how
//! [`SpringEnergy::matching`] derives `w_c` per spring length from a critical stretch.
//!
//! # w_c from the fracture energy G_c
//!
//! At a crack tip the state is far from uniform, so a crack under the matched energy criterion
//! does not dissipate what one under the stretch criterion does: the tip spring's nodes are
//! dilated, their pools add to its energy when q > 0 and take from it when q < 0. The strip
//! experiment ([`crate::toughness`], `hooke toughness --criterion energy`) measures the ratio
//! `F_E(nu) = G_energy / G_stretch` at the same `s_c`; it runs from 0.10 (hex, nu_2D = -0.9)
//! and 0.23 (cubic, nu = -0.5) to 1.20 (hex, 0.5) and 4.3 (cubic, 0.45). Since the load at which a spring reaches `w_c` grows as `sqrt(w_c)`
//! and G as the load squared, G is proportional to `w_c`, and
//!
//! ```text
//! w_c = 1/2 k s_c^2 a^2 (1 + 2q) / F_E(nu),    s_c from G_c as in crate::stretch
//! ```
//!
//! gives a crack that dissipates G_c ([`SpringEnergy::from_fracture_energy`]). `F_E` is measured
//! on the regular lattices only: on random lattices the spring stiffnesses differ from spring to
//! spring and one `w_c (L / L_ref)^2` cannot stand for all of them, so they take the stretch
//! criterion.

use hooke_core::material::nu_from_q;
use hooke_core::{LatticeKind, Real};

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

    /// The criterion whose cracks dissipate `g_c` (J/m^2) on a regular lattice of stiffness `k`,
    /// spacing `a`, dispersion ratio `q` and (2D) plate thickness `h` (see the module docs).
    pub fn from_fracture_energy(
        kind: LatticeKind,
        k: Real,
        a: Real,
        q: Real,
        h: Real,
        g_c: Real,
    ) -> Result<Self, FractureError> {
        if kind.is_random() {
            return Err(FractureError::BadParameter {
                what: "energy criterion on a random lattice (its springs differ in stiffness)",
                value: g_c,
                fix: "use the stretch criterion on random lattices",
            });
        }
        let s_c = crate::CriticalStretch::from_fracture_energy(kind, k, a, q, h, g_c)?.s_c;
        let mut c = Self::matching(s_c, k, q, a)?;
        c.w_c /= energy_toughness_factor(kind, nu_from_q(kind, q));
        Ok(c)
    }
}

/// `F_E = G_energy / G_stretch` at the same critical stretch, measured with `hooke toughness
/// --lattice hex --criterion energy --table` (strips 40 rows high, as the stretch table). The
/// crack stays on its plane at every nu here.
const HEX_ENERGY_FACTOR: &[(Real, Real)] = &[
    (-0.9, 0.1012),
    (-0.7, 0.2552),
    (-0.5, 0.3875),
    (-0.3, 0.5143),
    (-0.1, 0.6457),
    (0.0, 0.7160),
    (0.1, 0.7913),
    (0.2, 0.8737),
    (0.25, 0.9184),
    (0.3, 0.9661),
    (0.35, 1.0176),
    (0.4, 1.0735),
    (0.45, 1.1348),
    (0.5, 1.2030),
];

/// As [`HEX_ENERGY_FACTOR`], cubic lattice (`--lattice cubic`, strips 20 planes high). At
/// nu = -0.5 and -0.3 (and 0.45) about a third (a sixth) of the broken springs lie off the
/// crack plane: the energy crack roughens there, and G_c is matched only roughly. At q = 0
/// (nu = 0.25) the two criteria are the same.
const CUBIC_ENERGY_FACTOR: &[(Real, Real)] = &[
    (-0.5, 0.2255),
    (-0.3, 0.3929),
    (-0.1, 0.4458),
    (0.0, 0.5482),
    (0.1, 0.6817),
    (0.2, 0.8696),
    (0.25, 1.0000),
    (0.3, 1.1749),
    (0.35, 1.4306),
    (0.4, 2.0728),
    (0.45, 4.3456),
];

/// Whether the energy criterion's G_c calibration holds at this nu with a crack that stays on
/// its plane: hex nu_2D in [-0.9, 0.5], cubic nu in [-0.1, 0.4].
pub fn energy_calibrated(kind: LatticeKind, nu: Real) -> bool {
    match kind {
        LatticeKind::Hex => (-0.9 - 1e-9..=0.5 + 1e-9).contains(&nu),
        LatticeKind::Cubic => (-0.1 - 1e-9..=0.4 + 1e-9).contains(&nu),
        _ => false,
    }
}

/// `F_E` at the lattice's nu, interpolated linearly and held at the table's ends (1 on random
/// lattices, where the energy criterion is not calibrated).
pub fn energy_toughness_factor(kind: LatticeKind, nu: Real) -> Real {
    match kind {
        LatticeKind::Hex => crate::stretch::interpolate(HEX_ENERGY_FACTOR, nu),
        LatticeKind::Cubic => crate::stretch::interpolate(CUBIC_ENERGY_FACTOR, nu),
        _ => 1.0,
    }
}

impl Criterion for SpringEnergy {
    fn name(&self) -> &'static str {
        "spring-energy"
    }

    fn is_energy(&self) -> bool {
        true
    }

    fn breaks(&self, s: &SpringState) -> bool {
        let r = s.rest / self.l_ref * s.strength;
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
                lever: rest,
                dir: [1.0, 0.0, 0.0],
                dl: s * rest,
                pool: [s, s],
                q,
                strength: 1.0,
            };
            assert_eq!(c.breaks(&st), s > s_c, "L={rest} s={s}");
        }
    }
}
