//! A spatially correlated random field of Young's modulus: the material's stiffness scattered
//! from place to place (concrete's mortar, rock, a ceramic of varying porosity).
//!
//! **The field.** A Gaussian field `g(x)` of mean 0, variance 1 and correlation
//!
//! ```text
//! rho(r) = E[g(x) g(x + r)] = exp(-|r|^2 / (2 l^2)),     l the correlation length,
//! ```
//!
//! is built from `M` random Fourier modes, `g(x) = sqrt(2 / M) sum_m cos(k_m . x + phi_m)` with
//! the wave vectors `k_m` drawn from the field's spectral density (each component normal, of
//! standard deviation `1 / l`) and the phases `phi_m` uniform: then `E[cos(k . r)] = rho(r)`
//! exactly, and the sum of many modes is close to Gaussian. Young's modulus is lognormal,
//!
//! ```text
//! E(x) = E_0 exp(s g(x) - s^2 / 2),     s^2 = ln(1 + c^2),
//! ```
//!
//! of mean `E_0` (the material's) and coefficient of variation `c`.
//!
//! **On the lattice.** Poisson's ratio is the material's everywhere, so each node keeps its `q`
//! and a spring scales with `E` at its two halves: `k_s = k_s^0 series(f_i, f_j)`, `f_n =
//! E(x_n) / E_0`, the two halves in series as between two phases ([`hooke_core::phases`]).
//! Masses are unchanged.
//!
//! **Reproducible.** The modes come from one stream of the seed, and each node's factor from
//! its position alone: every process, thread count and set-up from parts gives the same field.

use hooke_core::{Real, Vector};

use crate::inclusions::Stream;

/// Fourier modes of a field.
pub const MODES: usize = 1024;

/// A lognormal field of Young's modulus: coefficient of variation, correlation length (m),
/// seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffnessField {
    pub cov: Real,
    pub correlation_length: Real,
    pub seed: u64,
}

/// The modes of one field, drawn from its seed.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Wave vectors (1/m) and phases.
    k: Vec<([Real; 3], Real)>,
    sigma: Real,
    dim: usize,
}

impl StiffnessField {
    /// Refused where the coefficient of variation is not in (0, 2] or the length not positive.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if !(self.cov > 0.0 && self.cov <= 2.0) {
            return Err((
                "cov",
                format!(
                    "{}: give a coefficient of variation of Young's modulus above 0 and at most 2",
                    self.cov
                ),
            ));
        }
        if !(self.correlation_length.is_finite() && self.correlation_length > 0.0) {
            return Err((
                "correlation_length",
                format!(
                    "{}: give a positive correlation length in m",
                    self.correlation_length
                ),
            ));
        }
        Ok(())
    }

    /// The field's modes in `dim` dimensions.
    pub fn modes(&self, dim: usize) -> Modes {
        let mut s = Stream(self.seed);
        let inv = 1.0 / self.correlation_length;
        let k = (0..MODES)
            .map(|_| {
                let mut k = [0.0; 3];
                for c in k.iter_mut().take(dim) {
                    *c = s.normal() * inv;
                }
                (k, 2.0 * std::f64::consts::PI * s.next())
            })
            .collect();
        Modes {
            k,
            sigma: (1.0 + self.cov * self.cov).ln().sqrt(),
            dim,
        }
    }
}

impl Modes {
    /// `g(x)`: the Gaussian field at `p`.
    pub fn gaussian(&self, p: Vector) -> Real {
        let z = if self.dim == 3 { p.z } else { 0.0 };
        let sum: Real = self
            .k
            .iter()
            .map(|&(k, phi)| (k[0] * p.x + k[1] * p.y + k[2] * z + phi).cos())
            .sum();
        (2.0 / self.k.len() as Real).sqrt() * sum
    }

    /// `E(p) / E_0`.
    pub fn factor(&self, p: Vector) -> Real {
        let s = self.sigma;
        (s * self.gaussian(p) - 0.5 * s * s).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The issue's check: the empirical correlation of `g` at one and two correlation lengths
    /// is its target `exp(-1/2)` and `exp(-2)` within 10 % (2D and 3D; 250 pairs of points in
    /// each of 160 fields), and `E` has the mean and coefficient of variation asked for.
    #[test]
    fn the_field_has_its_correlation_mean_and_spread() {
        for dim in [2, 3] {
            let l = 2e-3;
            let mut s = Stream(99);
            for (r, want) in [(l, (-0.5 as Real).exp()), (2.0 * l, (-2.0 as Real).exp())] {
                let (mut sum, mut n) = (0.0, 0);
                let (mut e_sum, mut e2_sum) = (0.0, 0.0);
                for seed in 0..160 {
                    let f = StiffnessField {
                        cov: 0.3,
                        correlation_length: l,
                        seed,
                    };
                    let m = f.modes(dim);
                    for _ in 0..250 {
                        let p = Vector::new(
                            0.1 * s.next(),
                            0.1 * s.next(),
                            if dim == 3 { 0.1 * s.next() } else { 0.0 },
                        );
                        // A random direction.
                        let d = loop {
                            let d = Vector::new(
                                s.normal(),
                                s.normal(),
                                if dim == 3 { s.normal() } else { 0.0 },
                            );
                            if d.norm() > 1e-3 {
                                break d / d.norm();
                            }
                        };
                        sum += m.gaussian(p) * m.gaussian(p + d * r);
                        n += 1;
                        let e = m.factor(p);
                        e_sum += e;
                        e2_sum += e * e;
                    }
                }
                let rho = sum / n as Real;
                assert!(
                    (rho / want - 1.0).abs() < 0.10,
                    "{dim}D, r = {r}: correlation {rho:.4}, target {want:.4}"
                );
                let mean = e_sum / n as Real;
                let cov = (e2_sum / n as Real - mean * mean).sqrt() / mean;
                assert!((mean - 1.0).abs() < 0.02, "{dim}D: mean factor {mean}");
                assert!(
                    (cov / 0.3 - 1.0).abs() < 0.1,
                    "{dim}D: coefficient of variation {cov}"
                );
            }
        }
    }

    #[test]
    fn a_field_follows_its_seed_and_position_only() {
        let f = StiffnessField {
            cov: 0.2,
            correlation_length: 1e-3,
            seed: 4,
        };
        let p = Vector::new(1e-3, 2e-3, 0.0);
        assert_eq!(
            f.modes(2).factor(p).to_bits(),
            f.modes(2).factor(p).to_bits()
        );
        let other = StiffnessField { seed: 5, ..f };
        assert_ne!(f.modes(2).factor(p), other.modes(2).factor(p));
        assert!(StiffnessField { cov: 0.0, ..f }.check().is_err());
        assert!(StiffnessField {
            correlation_length: -1.0,
            ..f
        }
        .check()
        .is_err());
    }
}
