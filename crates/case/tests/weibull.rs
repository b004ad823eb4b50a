//! Weakest link: bars whose springs' critical stretches scatter by Weibull (modulus m) are
//! weaker the larger they are, their mean strength going as `V^(-1/m)`.
//!
//! The strength here is the stress at which the first spring of a bar under a uniform
//! uniaxial stress breaks (brittle, flaw-controlled failure: the weakest link). Under the
//! stress `sigma` along x (plane stress, strain `sigma / E` along x and `-nu sigma / E` across)
//! a spring of direction `n` stretches by `(n_x^2 - nu n_y^2) sigma / E` and breaks past its
//! critical stretch `f_s s_c`: the bar's strength is `E min_s f_s s_c / (n_x^2 - nu n_y^2)`
//! over the springs that stretch. The factors `f_s` are the ones the case's fracture set-up
//! draws ([`hooke_fracture::Fracture::strength`]), from the bars' own springs.

use std::path::Path;

use hooke_core::Real;

fn bar(lx: Real, ly: Real, m: Real, seed: u64) -> String {
    format!(
        r#"
[lattice]
kind = "hex"
spacing = 1e-3
thickness = 1e-3
[material]
youngs = 70e9
poisson = 0.25
density = 2500
critical_stretch = 1e-3
weibull = {{ modulus = {m}, seed = {seed} }}
[geometry]
box = {{ min = [0.0, 0.0], max = [{lx}, {ly}] }}
[solver]
end_time = 1e-6
"#
    )
}

/// The strength of one bar (see the module docs), Pa.
fn strength(lx: Real, ly: Real, m: Real, seed: u64) -> (Real, usize) {
    let sim = hooke_case::load_str(Path::new("bar.toml"), &bar(lx, ly, m, seed), 1.0).unwrap();
    let f = sim.fracture.as_ref().unwrap();
    let s_c = f.criterion().screen().unwrap();
    let factor = f.strength().unwrap();
    let lat = &sim.body.lattice;
    let mut least = Real::INFINITY;
    for (b, &[i, j]) in lat.bonds.ends.iter().enumerate() {
        let d = lat.reference_vector(i as usize, j as usize);
        let l2 = d[0] * d[0] + d[1] * d[1];
        let stretch = (d[0] * d[0] - 0.25 * d[1] * d[1]) / l2;
        if stretch > 0.0 {
            least = least.min(factor[b] * s_c / stretch);
        }
    }
    (70e9 * least, lat.bonds.len())
}

/// Bars of 40 x 10 and 113 x 28.3 spacings (8.0 times the area, geometrically similar), 120
/// bars of each size for m = 5 and m = 10: the ratio of their mean strengths is `8^(-1/m)`
/// within 10 % (measured: see the assertion's message), with the sample means' standard
/// errors (2 to 3 % at m = 5, half that at m = 10) well inside it.
#[test]
fn mean_strength_follows_the_volume_to_the_minus_one_over_m() {
    let samples = 120;
    for m in [5.0, 10.0] {
        let mean = |lx: Real, ly: Real| {
            let s: Vec<Real> = (0..samples)
                .map(|seed| strength(lx, ly, m, 1000 + seed).0)
                .collect();
            let mu = s.iter().sum::<Real>() / samples as Real;
            let sd =
                (s.iter().map(|x| (x - mu).powi(2)).sum::<Real>() / (samples - 1) as Real).sqrt();
            (mu, sd / (samples as Real).sqrt())
        };
        let (small, se_small) = mean(40e-3, 10e-3);
        let (large, se_large) = mean(113.1e-3, 28.3e-3);
        let (n_small, n_large) = (
            strength(40e-3, 10e-3, m, 0).1,
            strength(113.1e-3, 28.3e-3, m, 0).1,
        );
        let v = n_large as Real / n_small as Real;
        let want = v.powf(-1.0 / m);
        let got = large / small;
        assert!(
            (got / want - 1.0).abs() < 0.10 && se_small / small < 0.04 && se_large / large < 0.04,
            "m = {m}: strength ratio {got:.4} for {v:.2} times the springs, V^(-1/m) = {want:.4}; \
             means {small:.4e} +- {se_small:.1e} and {large:.4e} +- {se_large:.1e} Pa"
        );
        eprintln!(
            "m = {m}: ratio {got:.4}, V^(-1/m) = {want:.4} ({v:.2} x springs); means {small:.4e} +- {se_small:.1e}, {large:.4e} +- {se_large:.1e} Pa"
        );
    }
}
