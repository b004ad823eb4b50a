//! Softening (cohesive) springs: quasi-brittle materials with a process zone.
//!
//! # The law
//!
//! A softening spring carries its elastic force up to a peak stretch `s_p`, then loses
//! stiffness as it is stretched further, and carries nothing past a final stretch `s_f`. Its
//! state is a damage weight `w` in `[0, 1]`: it acts with stiffness `w k` everywhere, in its own
//! force and in the dispersion (its pool share `w k L dL`, its nodes' normalisers
//! `S_n = sum_t w_t k_t L_t^2`; [`hooke_core::state::Springs`]). With `kappa` the largest stretch
//! the spring has seen, the envelope of its direct force per `k L` is `s_p g(kappa)`, and
//!
//! ```text
//! w(kappa) = 1                          kappa <= s_p
//! w(kappa) = s_p g(kappa) / kappa       s_p < kappa < s_f
//! w(kappa) = 0                          kappa >= s_f   (the spring is broken)
//!
//! linear:    g = (s_f - kappa) / (s_f - s_p)
//! bilinear:  g falls linearly from 1 at s_p to 1/3 at s_k = s_p + 2/9 (s_f - s_p), then to 0 at
//!            s_f (Petersson's concrete curve: the knee at f_t/3, 0.8 G_f/f_t of an opening of
//!            3.6 G_f/f_t)
//! ```
//!
//! Damage is irreversible (`w` only falls), so unloading goes back to the origin on the damaged
//! stiffness `w k`, and at `w = 0` the spring is removed exactly as a broken one
//! ([`hooke_core::State::soften`]): a fully softened spring *is* a broken spring.
//!
//! # Energy
//!
//! For fixed weights the law is the gradient of `U = 1/2 sum w k dL^2 + q/2 sum Pi^2/S` with
//! the weighted pools and normalisers, so between damage events energy is conserved as in the
//! intact material. A damage event at fixed displacements lowers U; [`crate::Fracture`] books
//! that drop, `U(w) - U(w')` over the touched springs and nodes, as released energy, exactly,
//! the way it books a break. A spring taken from 0 to `s_f` under its own stretch dissipates its
//! direct work
//!
//! ```text
//! E_s = k L^2 (s_p^2 / 2 + c s_p (s_f - s_p)),      c = 1/2 (linear), 5/18 (bilinear)
//! ```
//!
//! # Stability for any damage state
//!
//! The stiffness at weights `w` is `K(w) = K_direct(w) + K_disp(w)`. By Cauchy-Schwarz,
//! `Pi_n^2 = (sum w k L dL)^2 <= (sum w k L^2)(sum w k dL^2) = S_n sum_t w k dL^2`, so
//! `q/2 sum_n Pi_n^2/S_n <= q sum_s w_s k_s dL_s^2` (each spring has two ends) and, for `q >= 0`,
//! `U(w) <= (1 + 2q) U_plain(w) <= (1 + 2q) U_plain(1)`: every weight lowers the plain energy,
//! a sum of non-negative terms. For `q < 0`, `U(w) <= U_plain(w) <= U_plain(1)`. The largest
//! eigenvalue of `M^-1 K(w)` is therefore bounded by `(1 + 2 max(q, 0)) lambda_plain` of the
//! undamaged body, the bound the damage-proof stable step already uses for broken springs
//! ([`hooke_core::stability`]): a softening run is stable in every damage state with the step it
//! starts with (tested with eigenvalues in `tests/softening.rs`).
//!
//! # Calibration from G_f and f_t
//!
//! The peak stretch is the uniaxial strain at the tensile strength, `s_p = f_t / E` (an axial
//! spring of a uniaxially stressed body stretches by exactly `sigma / E`). The final stretch
//! comes from the fracture energy: a crack that opens a unit area takes the springs across it
//! through their whole curve, and the lattice's measured toughness per spring energy
//! ([`crate::stretch`]: `G = Gamma k s^2` for a brittle spring that takes `1/2 k L^2 s^2` with it)
//! is applied to the softening spring's `E_s`, that is to the equivalent stretch
//! `s_eq^2 = s_p^2 + 2 c s_p (s_f - s_p)`:
//!
//! ```text
//! s_eq = CriticalStretch::stretch_for(G_f),     s_f = s_p + (s_eq^2 - s_p^2) / (2 c s_p)
//! ```
//!
//! A strength too high for the toughness at this lattice spacing (`s_p >= s_eq`: the spring
//! would have to snap back) is refused with the fix: a lower f_t, a higher G_f or a finer
//! lattice (the characteristic length `l_ch = E G_f / f_t^2` must be resolved by the spacing).

use hooke_core::Real;

use crate::criterion::{Criterion, SpringState};
use crate::error::FractureError;

/// Shape of the softening branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SofteningShape {
    Linear,
    Bilinear,
}

impl SofteningShape {
    /// Area of the softening branch over `s_p (s_f - s_p)`: the `c` of the module docs.
    pub fn area_factor(self) -> Real {
        match self {
            SofteningShape::Linear => 0.5,
            SofteningShape::Bilinear => 5.0 / 18.0,
        }
    }

    /// Name used in case files.
    pub fn name(self) -> &'static str {
        match self {
            SofteningShape::Linear => "linear",
            SofteningShape::Bilinear => "bilinear",
        }
    }
}

/// Where the bilinear curve's knee lies along the softening branch, and its height.
const KNEE_AT: Real = 2.0 / 9.0;
const KNEE_HEIGHT: Real = 1.0 / 3.0;

/// A softening spring law (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softening {
    /// Peak stretch `s_p`: the spring is elastic below it.
    pub peak: Real,
    /// Final stretch `s_f`: the spring is broken at it.
    pub last: Real,
    pub shape: SofteningShape,
}

impl Softening {
    /// The law for given peak and final stretches (`0 < s_p < s_f`).
    pub fn new(peak: Real, last: Real, shape: SofteningShape) -> Result<Self, FractureError> {
        if !(peak.is_finite() && peak > 0.0) {
            return Err(FractureError::BadParameter {
                what: "peak stretch s_p",
                value: peak,
                fix: "give a positive number, e.g. 1e-4",
            });
        }
        if !(last.is_finite() && last > peak) {
            return Err(FractureError::BadParameter {
                what: "final stretch s_f",
                value: last,
                fix: "the final stretch must exceed the peak stretch (a spring cannot snap back)",
            });
        }
        Ok(Softening { peak, last, shape })
    }

    /// The law for a tensile strength `f_t` (Pa) and fracture energy `g_f` (J/m^2) on a material
    /// of Young's modulus `e` whose brittle springs would break at `s_eq` for the same `g_f`
    /// ([`crate::CriticalStretch::stretch_for`]).
    pub fn from_strength(
        e: Real,
        f_t: Real,
        s_eq: Real,
        shape: SofteningShape,
    ) -> Result<Self, FractureError> {
        if !(f_t.is_finite() && f_t > 0.0) {
            return Err(FractureError::BadParameter {
                what: "tensile strength f_t (Pa)",
                value: f_t,
                fix: "give a positive number",
            });
        }
        let peak = f_t / e;
        if s_eq.is_nan() || s_eq <= peak {
            return Err(FractureError::BadParameter {
                what: "tensile strength f_t (Pa)",
                value: f_t,
                fix: "it is too high for the fracture energy at this lattice spacing (the \
                      springs would snap back: the peak stretch f_t/E reaches the stretch that \
                      alone dissipates G_f); lower f_t, raise G_f, or refine the lattice until \
                      the spacing is well below the characteristic length E G_f / f_t^2",
            });
        }
        let c = shape.area_factor();
        let last = peak + (s_eq * s_eq - peak * peak) / (2.0 * c * peak);
        Self::new(peak, last, shape)
    }

    /// The envelope `g(kappa)` of the module docs (1 at the peak, 0 at the end).
    fn envelope(&self, kappa: Real) -> Real {
        let (p, f) = (self.peak, self.last);
        match self.shape {
            SofteningShape::Linear => (f - kappa) / (f - p),
            SofteningShape::Bilinear => {
                let knee = p + KNEE_AT * (f - p);
                if kappa <= knee {
                    1.0 - (1.0 - KNEE_HEIGHT) * (kappa - p) / (knee - p)
                } else {
                    KNEE_HEIGHT * (f - kappa) / (f - knee)
                }
            }
        }
    }

    /// Damage weight after the largest stretch `kappa` (1 below the peak, 0 at the end).
    pub fn weight_at(&self, kappa: Real) -> Real {
        if kappa <= self.peak {
            1.0
        } else if kappa >= self.last {
            0.0
        } else {
            (self.peak * self.envelope(kappa) / kappa).clamp(0.0, 1.0)
        }
    }

    /// Direct work to take one spring of stiffness `k` and rest length `l` to its end (J).
    pub fn spring_energy(&self, k: Real, l: Real) -> Real {
        k * l
            * l
            * (0.5 * self.peak * self.peak
                + self.shape.area_factor() * self.peak * (self.last - self.peak))
    }

    /// The brittle stretch that dissipates what this law does per spring: `s_eq` of the module
    /// docs.
    pub fn equivalent_stretch(&self) -> Real {
        (self.peak * self.peak
            + 2.0 * self.shape.area_factor() * self.peak * (self.last - self.peak))
            .sqrt()
    }
}

impl Criterion for Softening {
    fn name(&self) -> &'static str {
        "softening"
    }

    fn breaks(&self, s: &SpringState) -> bool {
        s.stretch() >= self.last
    }

    fn screen(&self) -> Option<Real> {
        Some(self.peak)
    }

    fn weight(&self, s: &SpringState, w: Real) -> Real {
        w.min(self.weight_at(s.stretch()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curves_have_the_stated_areas_and_are_monotone() {
        for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
            let s = Softening::new(1e-4, 1e-3, shape).unwrap();
            // Integrate the force envelope w(e) e by the trapezoid rule.
            let n = 200_000;
            let h = 1.2e-3 / n as Real;
            let mut area = 0.0;
            let mut last_w = 1.0;
            for i in 0..n {
                let (a, b) = (i as Real * h, (i + 1) as Real * h);
                area += 0.5 * h * (s.weight_at(a) * a + s.weight_at(b) * b);
                let w = s.weight_at(b);
                assert!(w <= last_w, "weight rises at {b}");
                last_w = w;
            }
            let exact = s.spring_energy(1.0, 1.0);
            assert!(
                (area - exact).abs() < 1e-6 * exact,
                "{shape:?}: {area} vs {exact}"
            );
            // The force is continuous at the peak and zero at the end.
            assert!((s.weight_at(1e-4 * (1.0 + 1e-12)) - 1.0).abs() < 1e-9);
            assert_eq!(s.weight_at(1e-3), 0.0);
        }
        let b = Softening::new(1e-4, 1e-3, SofteningShape::Bilinear).unwrap();
        let knee = 1e-4 + KNEE_AT * 9e-4;
        assert!((b.weight_at(knee) * knee / 1e-4 - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn calibration_keeps_the_equivalent_energy_and_refuses_snap_back() {
        let e = 30e9;
        for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
            let s = Softening::from_strength(e, 3e6, 5e-4, shape).unwrap();
            assert!((s.peak - 1e-4).abs() < 1e-18);
            assert!((s.equivalent_stretch() - 5e-4).abs() < 1e-15);
        }
        let err = Softening::from_strength(e, 3e7, 5e-4, SofteningShape::Linear).unwrap_err();
        assert!(err.to_string().contains("snap back"), "{err}");
        assert!(Softening::new(2e-4, 1e-4, SofteningShape::Linear).is_err());
        assert!(Softening::new(0.0, 1e-4, SofteningShape::Linear).is_err());
    }

    #[test]
    fn damage_is_irreversible() {
        let s = Softening::new(1e-4, 1e-3, SofteningShape::Linear).unwrap();
        let at = |stretch: Real| SpringState {
            k: 1.0,
            rest: 1.0,
            dl: stretch,
            pool: [0.0; 2],
            q: 0.0,
        };
        let w1 = s.weight(&at(4e-4), 1.0);
        assert!(w1 < 1.0 && w1 > 0.0);
        // Unloading keeps the weight; reloading past the old maximum lowers it further.
        assert_eq!(s.weight(&at(1e-4), w1), w1);
        assert_eq!(s.weight(&at(-1e-3), w1), w1);
        assert!(s.weight(&at(5e-4), w1) < w1);
        assert_eq!(s.weight(&at(2e-3), w1), 0.0);
    }
}
