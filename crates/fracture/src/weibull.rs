//! Random strength: each spring's critical stretch drawn from a Weibull distribution.
//!
//! A spring's critical stretch is `s_c = s_0 X`, where `s_0` is its material's (the scale) and
//! `X` has the distribution
//!
//! ```text
//! P(X <= x) = 1 - exp(-x^m),    mean Gamma(1 + 1/m),
//! ```
//!
//! of Weibull modulus `m`. `X` is drawn by inversion, `X = (-ln U)^(1/m)` with `U` uniform in
//! (0, 1), and `U` comes from a hash of the seed and the spring's two end nodes in the body's
//! numbering (the lower one first). A spring's draw therefore depends on nothing but the seed and
//! which nodes it joins: not on thread counts, on how processes split the body, or on the order
//! in which springs are visited. The factor enters the criteria as the spring's strength
//! ([`crate::SpringState::strength`]).
//!
//! Weakest link: a bar in tension whose springs scatter independently fails at the load its
//! weakest cross-section holds, so its mean strength falls with its volume as `V^(-1/m)` (the
//! classical Weibull size effect); the validation lives in the `weibull` tests.

use hooke_core::Real;

use crate::error::FractureError;

/// A Weibull scatter of the springs' critical stretches: modulus `m` and seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weibull {
    /// The Weibull modulus `m` (the larger, the narrower the scatter).
    pub modulus: Real,
    /// The seed of the draws.
    pub seed: u64,
}

/// The moduli taken: below 1 the scatter spans many decades (a few springs nearly without
/// strength), above 100 it is narrower than the lattice's own scatter of stretches.
pub const MODULI: (Real, Real) = (1.0, 100.0);

impl Weibull {
    /// A scatter of modulus `modulus` in [`MODULI`], refused with the range otherwise.
    pub fn new(modulus: Real, seed: u64) -> Result<Self, FractureError> {
        if !(modulus >= MODULI.0 && modulus <= MODULI.1) {
            return Err(FractureError::BadParameter {
                what: "the Weibull modulus m",
                value: modulus,
                fix: "give a modulus from 1 to 100 (glass and ceramics: 5 to 20)",
            });
        }
        Ok(Weibull { modulus, seed })
    }

    /// The factor `X = s_c / s_0` of the spring between the body's nodes `a` and `b` (in
    /// either order): see the module docs.
    pub fn factor(&self, a: u64, b: u64) -> Real {
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let h = mix(mix(mix(self.seed) ^ lo) ^ hi.rotate_left(32));
        // 53 random bits, centred in their interval: U in (0, 1), never 0 or 1.
        let u = ((h >> 11) as Real + 0.5) * (1.0 / (1u64 << 53) as Real);
        (-u.ln()).powf(1.0 / self.modulus)
    }

    /// The mean of the factor, `Gamma(1 + 1/m)`.
    pub fn mean(&self) -> Real {
        gamma(1.0 + 1.0 / self.modulus)
    }
}

/// SplitMix64's step from the state `z`: the golden-ratio increment, then its finaliser (a
/// bijection of 64-bit words whose every output bit depends on every input bit). The set-up's
/// other seeded generators draw from it too.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// `Gamma(x)` for `x` in [1, 2] and beyond, by the Lanczos approximation (g = 7, nine terms;
/// relative error below 1e-13 there).
pub fn gamma(x: Real) -> Real {
    const G: Real = 7.0;
    const C: [Real; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as Real);
    }
    (2.0 * std::f64::consts::PI).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_at_known_points() {
        for (x, want) in [
            (1.0, 1.0),
            (2.0, 1.0),
            (1.5, 0.886_226_925_452_758),
            (1.2, 0.918_168_742_399_761),
            (1.1, 0.951_350_769_866_873),
            (5.0, 24.0),
        ] {
            assert!(
                (gamma(x) - want).abs() < 1e-12 * want,
                "Gamma({x}) = {}",
                gamma(x)
            );
        }
    }

    /// The draws follow the distribution: a Kolmogorov-Smirnov test on 20,000 springs of a
    /// chain of nodes (the 1 % critical value of the statistic is 1.63 / sqrt(n) = 0.0115),
    /// and the sample mean within 4 standard errors of Gamma(1 + 1/m).
    #[test]
    fn draws_follow_the_weibull_distribution() {
        for m in [1.0, 5.0, 10.0, 30.0] {
            let w = Weibull::new(m, 2024).unwrap();
            let n = 20_000;
            let mut x: Vec<Real> = (0..n as u64).map(|i| w.factor(i, i + 1)).collect();
            let mean = x.iter().sum::<Real>() / n as Real;
            let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<Real>() / n as Real;
            let se = (var / n as Real).sqrt();
            assert!(
                (mean - w.mean()).abs() < 4.0 * se,
                "m {m}: mean {mean}, want {}",
                w.mean()
            );
            x.sort_by(|a, b| a.total_cmp(b));
            let d = x
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    let f = 1.0 - (-v.powf(m)).exp();
                    (f - i as Real / n as Real)
                        .abs()
                        .max((f - (i + 1) as Real / n as Real).abs())
                })
                .fold(0.0, Real::max);
            assert!(d < 1.63 / (n as Real).sqrt(), "m {m}: KS statistic {d}");
        }
    }

    #[test]
    fn a_draw_depends_on_the_spring_and_the_seed_only() {
        let w = Weibull::new(5.0, 7).unwrap();
        assert_eq!(w.factor(3, 9).to_bits(), w.factor(9, 3).to_bits());
        assert_ne!(w.factor(3, 9), w.factor(3, 10));
        assert_ne!(w.factor(3, 9), Weibull::new(5.0, 8).unwrap().factor(3, 9));
        assert!(w.factor(0, 0).is_finite() && w.factor(u64::MAX, 0) > 0.0);
    }

    #[test]
    fn moduli_out_of_range_are_refused() {
        for m in [0.5, 0.0, -2.0, 101.0, Real::NAN, Real::INFINITY] {
            let e = Weibull::new(m, 1).unwrap_err().to_string();
            assert!(e.contains("from 1 to 100"), "{e}");
        }
    }
}
