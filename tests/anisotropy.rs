//! The direction-weighted (anisotropic) law: each spring's dispersion lever `lambda = w L`
//! replaces its rest length in the pools, the normalisers and the dispersed force
//! (`hooke_core::transverse`). These are the isotropic law's own checks, repeated with levers:
//! levers equal to the rest lengths change no bit; forces are minus the energy gradient; the
//! tangent is their Jacobian; momentum is conserved; every kernel matches the reference law;
//! and the damaged stiffness stays positive semidefinite for any (even signed) weights.

use hooke_core::anisotropy::{tensor_component, Transverse};
use hooke_core::kernel::Kernel;
use hooke_core::Designs;
use hooke_core::{law, Body, Coords, Lattice, LatticeKind, Real, State, Vector};
use hooke_tests::{
    assert_force_is_minus_energy_gradient, assert_tangent_is_force_jacobian, dense_tangent,
    kernel_forces, kill_random, random_displacement, small_body, Rng,
};

/// A carbon-fibre-like material (E_t / E_p = 2.5, nu_tp above nu_p), the fibre along `fibre`.
fn carbon(fibre: [Real; 3]) -> Transverse {
    Transverse {
        youngs_plane: 10e9,
        youngs_fibre: 25e9,
        poisson_plane: 0.35,
        poisson_fibre: 0.28,
        shear_fibre: 4e9,
        density: 1500.0,
        fibre,
    }
}

/// [`carbon`] on a small Ladd box.
fn fibre_body(n: [usize; 3], fibre: [Real; 3]) -> Body {
    Body::transverse(Lattice::cubic_box(n, 1e-3).unwrap(), &carbon(fibre)).unwrap()
}

/// Random signed weights on a body of any lattice: levers `w L` with w in (-1.5, 1.5).
fn random_levers(mut body: Body, seed: u64) -> Body {
    let mut rng = Rng::new(seed);
    body.lever = Some(
        body.lattice
            .rest_lengths()
            .iter()
            .map(|&l| rng.sym(1.5) * l)
            .collect(),
    );
    body
}

/// The bodies every check below runs on: the fibre body along each axis, and random signed
/// levers on every lattice kind, at q < 0 and q > 0.
fn bodies() -> Vec<(String, Body)> {
    let mut out = vec![
        (
            "cubic fibre z".into(),
            fibre_body([4, 4, 4], [0.0, 0.0, 1.0]),
        ),
        (
            "cubic fibre x".into(),
            fibre_body([4, 4, 4], [-1.0, 0.0, 0.0]),
        ),
    ];
    for (kind, q, seed) in [
        (LatticeKind::Cubic, -0.4, 1),
        (LatticeKind::Cubic, 2.0, 2),
        (LatticeKind::Hex, 0.8, 3),
        (LatticeKind::Random3d, -0.45, 4),
        (LatticeKind::Random2d, 1.5, 5),
    ] {
        out.push((
            format!("{kind:?} q={q} random levers"),
            random_levers(small_body(kind, q, 4), seed),
        ));
    }
    out
}

fn energy(body: &Body, state: &State, u: &Coords) -> Real {
    law::energy(body, u, state.springs(body), state.norm()).total()
}

#[test]
fn levers_equal_to_the_rest_lengths_change_no_bit() {
    for kind in [LatticeKind::Random3d, LatticeKind::Hex] {
        let plain = small_body(kind, 0.7, 5);
        let mut weighted = plain.clone();
        weighted.lever = Some(plain.lattice.rest_lengths().into_owned());
        let mut rng = Rng::new(9);
        let mut state = State::new(&plain);
        kill_random(&plain, &mut state, &mut rng, 0.2);
        state.u = random_displacement(&plain, &mut rng, 0.05);
        let kernel = Kernel::Csr { plain: false };
        let (a, b) = (
            kernel_forces(&kernel, &plain, &state),
            kernel_forces(&kernel, &weighted, &state),
        );
        for i in 0..plain.nodes() {
            assert_eq!(a.get(i), b.get(i), "{kind:?} node {i}");
        }
        assert_eq!(
            energy(&plain, &state, &state.u),
            energy(&weighted, &state, &state.u)
        );
    }
}

#[test]
fn weighted_force_is_minus_the_energy_gradient_and_the_tangent_its_jacobian() {
    for (name, body) in bodies() {
        let mut rng = Rng::new(21);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.2);
        let a = body.lattice.spacing;
        state.u = random_displacement(&body, &mut rng, 0.05 * a);
        law::update_forces(&body, &mut state);
        let h = 1e-6 * a;
        assert_force_is_minus_energy_gradient(&body, &state, h, 1e-6, &name);
        let v = random_displacement(&body, &mut rng, 1.0);
        assert_tangent_is_force_jacobian(&body, &state, &v, h, 1e-6, &name);
    }
}

#[test]
fn weighted_forces_conserve_momentum_and_every_kernel_matches_the_reference_law() {
    for (name, body) in bodies() {
        let mut rng = Rng::new(33);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.25);
        state.u = random_displacement(&body, &mut rng, 0.08 * body.lattice.spacing);
        let mut reference = state.clone();
        law::update_forces(&body, &mut reference);
        let (mut sum, mut torque, mut fmax) = (Vector::zeros(), Vector::zeros(), 0.0 as Real);
        for i in 0..body.nodes() {
            let f = reference.f.get(i);
            sum += f;
            torque += reference.position(&body, i).cross(&f);
            fmax = fmax.max(f.norm());
        }
        let n = body.nodes() as Real;
        let size = body.lattice.spacing * n.cbrt();
        assert!(sum.norm() < 1e-13 * fmax * n, "{name}: net force {sum:?}");
        assert!(
            torque.norm() < 1e-12 * fmax * size * n,
            "{name}: net torque {torque:?}"
        );
        // A weighted body runs on a general kernel (CSR, or its row form on AVX-512): the
        // stencil declines it.
        let kernel = Kernel::for_body(&body, &state);
        assert!(!kernel.is_stencil(), "{name}: {}", kernel.name());
        let f = kernel_forces(&kernel, &body, &state);
        for i in 0..body.nodes() {
            let (a, b) = (f.get(i), reference.f.get(i));
            assert!(
                (a - b).norm() <= 1e-12 * fmax,
                "{name}: node {i}: {a:?} vs {b:?}"
            );
        }
    }
}

/// Half the springs removed at random: no negative eigenvalue, whatever the signs of the
/// weights (Cauchy-Schwarz holds for signed levers).
#[test]
fn weighted_damaged_stiffness_stays_positive_semidefinite() {
    for (name, body) in bodies() {
        for seed in 0..2 {
            let mut rng = Rng::new(200 + seed);
            let mut state = State::new(&body);
            kill_random(&body, &mut state, &mut rng, 0.5);
            law::update_forces(&body, &mut state);
            let k = dense_tangent(&body, &state, false);
            let asym = (&k - k.transpose()).abs().max();
            let kmax = k.abs().max();
            assert!(asym < 1e-12 * kmax, "{name}: tangent not symmetric: {asym}");
            let eig = k.symmetric_eigen().eigenvalues;
            assert!(
                eig.min() > -1e-12 * eig.max(),
                "{name} seed {seed}: eigenvalue {} (max {})",
                eig.min(),
                eig.max()
            );
        }
    }
}

/// Plane waves on a periodic Ladd box of the fibre material run at the speeds of the
/// Christoffel equation `det(C_ijkl n_j n_l - rho c^2 delta_ik) = 0`: along the fibre, across
/// it, and at 45 degrees to it (where the quasi-longitudinal and quasi-shear waves couple through
/// C13), within 1 % for every polarisation. Each wave is set up as the Christoffel eigenvector
/// `p` times `sin(k.x)` at rest (amplitude 1e-7 of the spacing: linear), integrated with
/// leapfrog steps of the full (nonlinear) law, and its frequency read from the zero crossings of
/// its projection over three periods. The wavelength is 24 spacings: the lattice's own dispersion
/// is about (ka)^2/24 = 0.3 %.
#[test]
fn wave_speeds_along_and_across_the_fibre_match_christoffel() {
    let t = carbon([0.0, 0.0, 1.0]);
    let c = t.stiffness().unwrap();
    let a = 1e-3;
    let n = 24;
    for (dir, size) in [
        ([1.0, 0.0, 0.0], [n, 3, 3]),
        ([0.0, 0.0, 1.0], [3, 3, n]),
        ([1.0, 0.0, 1.0], [n, 3, n]),
    ] {
        let lattice = Lattice::cubic_box_periodic(size, a, [true; 3]).unwrap();
        let body = Body::transverse(lattice, &t).unwrap();
        let len = |v: [Real; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let nd = [dir[0] / len(dir), dir[1] / len(dir), dir[2] / len(dir)];
        // One wavelength over each periodic side the wave crosses.
        let kv: [Real; 3] = std::array::from_fn(|c| {
            if dir[c] != 0.0 {
                2.0 * std::f64::consts::PI / (size[c] as Real * a)
            } else {
                0.0
            }
        });
        let gamma = nalgebra::Matrix3::from_fn(|i, k| {
            let mut g = 0.0;
            for j in 0..3 {
                for l in 0..3 {
                    g += tensor_component(&c, i, j, k, l) * nd[j] * nd[l];
                }
            }
            g
        });
        let eig = gamma.symmetric_eigen();
        for m in 0..3 {
            let p = eig.eigenvectors.column(m);
            let c_theory = (eig.eigenvalues[m] / t.density).sqrt();
            let amp = 1e-7 * a;
            let mut state = State::new(&body);
            let phase: Vec<Real> = (0..body.nodes())
                .map(|i| {
                    let x = body.lattice.pos.get(i);
                    (kv[0] * x.x + kv[1] * x.y + kv[2] * x.z).sin()
                })
                .collect();
            for (i, s) in phase.iter().enumerate() {
                state.u.set(i, Vector::new(p[0], p[1], p[2]) * (amp * s));
            }
            let norm: Real = phase.iter().map(|s| s * s).sum();
            let project = |u: &Coords| -> Real {
                (0..body.nodes())
                    .map(|i| u.get(i).dot(&Vector::new(p[0], p[1], p[2])) * phase[i])
                    .sum::<Real>()
                    / (amp * norm)
            };
            let k = len(kv);
            let period = 2.0 * std::f64::consts::PI / (c_theory * k);
            let dt = period / 400.0;
            // Leapfrog: v(1/2) = dt/2 f(0)/m, then drift-kick.
            let mut u = state.u.clone();
            let accel = |u: &Coords| {
                state.u.clone_from(u);
                law::update_forces(&body, &mut state);
                let mut a = Coords::zeros(body.nodes());
                for i in 0..body.nodes() {
                    a.set(i, state.f.get(i) / body.mass[i]);
                }
                a
            };
            let (crossings, _) = zero_crossings(&mut u, dt, 4000, accel, project);
            assert_eq!(crossings.len(), 7, "dir {dir:?} mode {m}: no oscillation");
            let omega = std::f64::consts::PI * 6.0 / (crossings[6] - crossings[0]);
            let c_measured = omega / k;
            let err = c_measured / c_theory - 1.0;
            eprintln!(
                "dir {dir:?} polarisation {:.3?}: c = {c_measured:.2} m/s, Christoffel {c_theory:.2} m/s, {:+.3} %",
                [p[0], p[1], p[2]],
                100.0 * err
            );
            assert!(
                err.abs() < 0.01,
                "dir {dir:?} polarisation {p:?}: {c_measured} m/s against {c_theory} m/s"
            );
        }
    }
}

/// On a random3d lattice the calibration's fixed point converges: the mean-field design is far
/// off (the network's fabric scatter and non-affine relaxation), each correction takes most of
/// the rest. Small cubes, so it runs in the default suite.
#[test]
fn random_lattice_calibration_converges() {
    use hooke_core::random::anisotropic::{calibrate, CalibrationOptions, Symmetry};
    let t = carbon([0.0, 0.0, 1.0]);
    // Two cubes of 12 spacings scatter by about 4 % per entry between node sets, so the
    // held-out check cannot tell 2 % here: the convergence is what this test holds.
    let opts = CalibrationOptions {
        size: 12.0,
        samples: 2,
        iterations: 3,
        reach: 0.05,
        ..Default::default()
    };
    let cal = calibrate(
        &t.local_stiffness(),
        t.frame().unwrap(),
        Symmetry::Transverse,
        &opts,
    )
    .unwrap();
    assert_converged(&cal);
}

/// A plate too anisotropic for its network (E_t = 4 E_p: the springs at 45 degrees to the
/// fibre would be nearly free) is refused with the calibration's figures, not built some
/// percent off: its fit to its own squares does not carry over to other squares.
#[test]
fn a_plate_beyond_the_networks_reach_is_refused() {
    use hooke_core::material::PlaneModel;
    use hooke_core::random::anisotropic::CalibrationOptions;
    let mut t = carbon([1.0, 0.0, 0.0]);
    t.youngs_fibre = 40e9;
    let opts = CalibrationOptions {
        size: 40.0,
        samples: 4,
        ..CalibrationOptions::plane()
    };
    let e = hooke_core::Anisotropic::Transverse(t)
        .random_design_plane_with(&opts, PlaneModel::Stress)
        .unwrap_err()
        .to_string();
    eprintln!("{e}");
    assert!(
        e.contains("out of reach of the random2d lattice") && e.contains("on others"),
        "{e}"
    );
}

/// A random3d fibre four times as stiff as the plane (E_t = 40 GPa against E_p = 10) fits its
/// own cubes to 1.6 % but misses others by 3.3 % per entry, more than the 2 % a random lattice
/// promises: it is refused with the figures. Measured (`hooke moduli --bulk --lattice random3d
/// --transverse 10e9,E_t,0.35,0.28,4e9`): held-out 1.4 % at E_t = 25 GPa (built), 2.2 % at 30
/// (refused), 3.3 % at 40 (refused).
#[test]
#[ignore = "slow: a calibration of cubes of 20 spacings, about half a minute"]
fn a_fibre_beyond_the_random3d_reach_is_refused() {
    let mut t = carbon([0.0, 0.0, 1.0]);
    t.youngs_fibre = 40e9;
    let e = hooke_core::Anisotropic::Transverse(t)
        .random_design(hooke_core::random::Sampler::Poisson)
        .unwrap_err()
        .to_string();
    eprintln!("{e}");
    assert!(
        e.contains("out of reach of the random3d lattice") && e.contains("2 % is the most"),
        "{e}"
    );
}

/// The mean-field design far off (more than 5 %), the last correction within 1 % and a tenth
/// of that.
fn assert_converged(cal: &hooke_core::random::anisotropic::Calibrated) {
    let r = &cal.residuals;
    eprintln!(
        "residuals {r:?} in {:.1} s; on other node sets {:.4}",
        cal.seconds, cal.held_out
    );
    assert!(r[0] > 0.05, "the mean field alone is {:.3} off", r[0]);
    assert!(
        *r.last().unwrap() < 0.1 * r[0] && *r.last().unwrap() < 0.01,
        "residuals {r:?}"
    );
}

/// The calibrated design on node sets it has not seen (seeds 1-3, cubes of 32 spacings where
/// it was calibrated on 20): every orthotropic entry of the ensemble's mean within 2 % of the
/// target, the fibre along [1, 2, 0.5] (a random lattice has no axes to lay along it) and the
/// tensor turned back to the material axes. Measured: within 1.1 % (C23 +1.06 %, the rest
/// within 0.6 %), the node sets' spread 0.2-0.8 % per entry; with the fibre along z, within
/// 1.3 %.
#[test]
#[ignore = "slow: about 2 minutes of relaxed cubes"]
fn random_lattice_design_meets_the_target_on_unseen_node_sets() {
    let t = carbon([1.0, 2.0, 0.5]);
    unseen_node_sets_within(
        hooke_core::Anisotropic::Transverse(t),
        &t.frame().unwrap(),
        &t.local_stiffness(),
        0.02,
    );
}

/// Calibrate `m`'s random3d design, measure it on 3 unseen node sets (seeds 1-3, cubes of 32
/// spacings) and hold each orthotropic entry in the material axes `frame` to `tol` of `target`.
fn unseen_node_sets_within(
    m: hooke_core::Anisotropic,
    frame: &[[Real; 3]; 3],
    target: &[[Real; 6]; 6],
    tol: Real,
) {
    let cal = m
        .random_design(hooke_core::random::Sampler::Poisson)
        .unwrap();
    design_within(&cal, 3, (32.0, 3), frame, target, tol);
}

/// Measure `cal`'s design on `samples` unseen node sets (seeds 1 on) in cubes (`dim` 3) or
/// squares (2) of `side` spacings and hold each orthotropic entry in the material axes `frame`
/// to `tol` of `target` (every entry printed first, with the node sets' spread).
fn design_within(
    cal: &hooke_core::random::anisotropic::Calibrated,
    dim: usize,
    (side, samples): (Real, usize),
    frame: &[[Real; 3]; 3],
    target: &[[Real; 6]; 6],
    tol: Real,
) {
    use hooke_core::random::anisotropic::{
        boxes, mean, measure, orthotropic_entries, spread, to_material,
    };
    eprintln!(
        "calibration residuals {:?} in {:.1} s, design {:?}",
        cal.residuals, cal.seconds, cal.design
    );
    let runs = measure(
        &cal.design,
        &boxes(dim, side, samples, 1, hooke_core::random::Sampler::Poisson).unwrap(),
        side,
        &Default::default(),
    )
    .unwrap();
    let local: Vec<_> = runs.iter().map(|c| to_material(c, frame)).collect();
    let mean_local = mean(&local);
    let sds = spread(&local, &mean_local);
    let entries = orthotropic_entries(dim);
    let rels: Vec<Real> = entries
        .iter()
        .map(|&(i, j)| {
            let rel = mean_local[i][j] / target[i][j] - 1.0;
            eprintln!(
                "C{}{}: {:+.4} (spread {:.4})",
                i + 1,
                j + 1,
                rel,
                sds[i][j] / target[i][j]
            );
            rel
        })
        .collect();
    for (&(i, j), rel) in entries.iter().zip(rels) {
        assert!(rel.abs() < tol, "C{}{} off by {rel:+.4}", i + 1, j + 1);
    }
}

/// [`unseen_node_sets_within`] for an orthotropic material: each entry in its own axes within
/// 2 % of its stiffness.
fn orthotropic_within_2_percent_on_unseen_node_sets(o: hooke_core::anisotropy::Orthotropic) {
    unseen_node_sets_within(
        hooke_core::Anisotropic::Orthotropic(o),
        &o.axes,
        &o.local_stiffness().unwrap(),
        0.02,
    );
}

/// The same for an orthotropic material (three moduli 20, 15 and 10 GPa, a negative q) whose
/// axes are turned against the body's (x along [1, 1, 0], y along [-1, 1, 1]): the calibrated
/// design on node sets it was not calibrated on (seeds 1-3, cubes of 32 spacings), each
/// orthotropic entry in the material axes within 2 % of the target. Measured: within 0.8 %
/// (C12 +0.8 %), spread 0.2-1.0 %; calibration 0.220 -> 0.0016 in 5 measurements.
#[test]
#[ignore = "slow: about 2 minutes of relaxed cubes"]
fn random_lattice_orthotropic_design_meets_the_target_on_unseen_node_sets() {
    use hooke_core::anisotropy::Orthotropic;
    let o = Orthotropic {
        youngs: [20e9, 15e9, 10e9],
        poisson: [0.2, 0.25, 0.3],
        shear: [4e9, 5e9, 6e9],
        density: 1500.0,
        axes: Orthotropic::axes_from([1.0, 1.0, 0.0], [-1.0, 1.0, 1.0]).unwrap(),
    };
    orthotropic_within_2_percent_on_unseen_node_sets(o);
}

/// A second orthotropic material, its stiffest axis the middle one and its q positive (E 6, 12
/// and 9 GPa; nu_xy 0.2, nu_xz 0.3, nu_yz 0.25; G_yz 3.5, G_xz 2.5, G_xy 3 GPa), axes turned
/// about y (x along [1, 0, 1]): the same check on unseen node sets, each orthotropic entry in
/// the material axes within 2 %. Measured: q = 0.224, calibration 0.124 -> 0.0017 in 3 rounds,
/// the cubes of 32 within 0.84 % per entry (C66 -0.84 %, C12 -0.56 %, the rest within 0.4 %),
/// spread 0.1-0.7 %; `hooke moduli --bulk --lattice random3d --orthotropic
/// 6e9,12e9,9e9,0.2,0.3,0.25,3.5e9,2.5e9,3e9 --samples 2 --size 25` (body axes): held-out
/// 0.92 %, cubes of 25 within 0.94 %.
#[test]
#[ignore = "slow: a calibration and three relaxed cubes, about 25 seconds"]
fn random_lattice_second_orthotropic_design_meets_the_target_on_unseen_node_sets() {
    use hooke_core::anisotropy::Orthotropic;
    let o = Orthotropic {
        youngs: [6e9, 12e9, 9e9],
        poisson: [0.2, 0.3, 0.25],
        shear: [3.5e9, 2.5e9, 3e9],
        density: 1200.0,
        axes: Orthotropic::axes_from([1.0, 0.0, 1.0], [0.0, 1.0, 0.0]).unwrap(),
    };
    orthotropic_within_2_percent_on_unseen_node_sets(o);
}

/// Block tests (the paper's 71 x 16 x 16-node block, free faces, sliding ends) of the calibrated
/// random3d design along the fibre and across it: E from the middle third's strain and both
/// lateral ratios against the engineering constants. The design is calibrated in the bulk, so
/// the block carries a free-surface bias. Measured (seed 1): along the fibre E +1.8 % (+2.3 %
/// from the ends' travel), nu_tp 0.2852 and 0.2812 (0.28); across it E +2.5 % (+3.2 %), nu_p
/// 0.3510 (0.35), nu_pt 0.1198 (0.112). Held to E within 3.5 % and each ratio within 0.01.
#[test]
#[ignore = "slow: two random blocks of 18 000 nodes, about a minute and a half"]
fn random_lattice_blocks_along_and_across_the_fibre_give_the_engineering_constants() {
    use hooke_core::moduli::{block_test, BlockTest};
    for fibre in [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]] {
        let mut t = BlockTest::paper(LatticeKind::Random3d, Real::NAN);
        t.spacing = 1e-3;
        t.anisotropic = Some(hooke_core::Anisotropic::Transverse(carbon(fibre)));
        let r = block_test(&t).unwrap();
        let e = r.e_measured_middle.unwrap() / r.e_target - 1.0;
        let (lm, lt) = (r.lateral_measured.unwrap(), r.lateral_target.unwrap());
        eprintln!(
            "fibre {fibre:?}: E {e:+.4} (ends' travel {:+.4}), lateral {lm:.4?} against {lt:.4?}",
            r.e_measured / r.e_target - 1.0
        );
        assert!(e.abs() < 0.035, "fibre {fibre:?}: E off by {e:+.4}");
        for c in 0..2 {
            assert!(
                (lm[c] - lt[c]).abs() < 0.01,
                "fibre {fibre:?}: lateral {c} {} against {}",
                lm[c],
                lt[c]
            );
        }
    }
}

/// Block tests of the calibrated plate (random2d, plane stress, sliding ends, four node sets
/// each) along the fibre and across it: E from the middle third's strain and the in-plane
/// lateral ratio against the plate's engineering constants (E_t, nu_tp; E_p, nu_pt). The design
/// is calibrated in the bulk, and the free edges' springs, laid along the edge, make a stiffer
/// layer: along the fibre E reads +6.7 % on the paper's 71 x 16 strip and +3.65 % on a strip
/// twice as wide (141 x 32), so the excess goes as a / W and the bulk value extrapolates to
/// +0.6 %; across the fibre +5.3 % at 16 rows. The ratios: nu_tp 0.2795 (0.28), nu_pt 0.1192
/// (0.112). Held: the excess falls by at least a third when the width doubles, the
/// extrapolation within 2 %, each ratio within 0.01.
#[test]
#[ignore = "slow: a calibration and twelve random strips, about two minutes"]
fn random_plate_blocks_along_and_across_the_fibre_give_the_engineering_constants() {
    use hooke_core::moduli::{block_test, BlockTest};
    let strips = |fibre: [Real; 3], size: [usize; 3]| {
        let (mut e, mut nu) = (0.0, 0.0);
        let mut targets = (0.0, 0.0);
        for seed in 1..=4 {
            let mut t = BlockTest::paper(LatticeKind::Random2d, Real::NAN);
            t.spacing = 1e-3;
            t.size = size;
            t.random.seed = seed;
            t.anisotropic = Some(hooke_core::Anisotropic::Transverse(carbon(fibre)));
            let r = block_test(&t).unwrap();
            e += 0.25 * (r.e_measured_middle.unwrap() / r.e_target - 1.0);
            nu += 0.25 * r.nu_measured;
            targets = (r.e_target, r.nu_target);
        }
        eprintln!(
            "fibre {fibre:?}, {size:?}: E {e:+.4} of {:.3e}, nu {nu:.4} against {:.4}",
            targets.0, targets.1
        );
        (e, nu, targets.1)
    };
    let (narrow, nu_along, nu_tp) = strips([1.0, 0.0, 0.0], [71, 16, 1]);
    let (wide, ..) = strips([1.0, 0.0, 0.0], [141, 32, 1]);
    let bulk = 2.0 * wide - narrow;
    eprintln!("along the fibre, extrapolated in 1 / W: E {bulk:+.4}");
    assert!(
        wide < narrow * (2.0 / 3.0),
        "E excess {narrow:+.4} -> {wide:+.4}"
    );
    assert!(bulk.abs() < 0.02, "extrapolated E {bulk:+.4}");
    assert!(
        (nu_along - nu_tp).abs() < 0.01,
        "nu_tp {nu_along} against {nu_tp}"
    );
    let (across, nu_across, nu_pt) = strips([0.0, 1.0, 0.0], [71, 16, 1]);
    assert!(across.abs() < 0.08, "across the fibre E {across:+.4}");
    assert!(
        (nu_across - nu_pt).abs() < 0.01,
        "nu_pt {nu_across} against {nu_pt}"
    );
}

/// Leapfrog from rest at `u` (`v(1/2) = dt/2 a(0)`, then drift-kick) until `project(u)` has
/// crossed zero seven times (three periods) or `limit` steps have passed: the crossing times,
/// each interpolated linearly within its step, and the steps taken.
fn zero_crossings(
    u: &mut Coords,
    dt: Real,
    limit: usize,
    mut accel: impl FnMut(&Coords) -> Coords,
    project: impl Fn(&Coords) -> Real,
) -> (Vec<Real>, usize) {
    let mut v = Coords::zeros(u.len());
    v.axpy(0.5 * dt, &accel(u));
    let (mut crossings, mut prev, mut step) = (Vec::new(), project(u), 0);
    while crossings.len() < 7 && step < limit {
        u.axpy(dt, &v);
        step += 1;
        let now = project(u);
        if prev.signum() != now.signum() {
            crossings.push(dt * (step as Real - now / (now - prev)));
        }
        prev = now;
        v.axpy(dt, &accel(u));
    }
    (crossings, step)
}

/// Which standing mode a ringing bar runs: both ends held and `u = p sin(pi x_d / L)`, or both
/// ends free and `u = p cos(pi x_d / L)` (less its mass-weighted mean, so no rigid motion).
/// Both have `omega = pi c / L` in the continuum. The held mode strains the bar most at its
/// ends, where the ends' layer of springs (standing for less material than bulk ones) sits;
/// the free mode strains it least there (not at all in the continuum: the free ends' traction
/// vanishes), so that layer enters only at second order.
#[derive(Clone, Copy)]
enum Ends {
    Held,
    Free,
}

/// The fundamental standing mode of a random bar of the fibre material `t` (`dim` 3), or of a
/// strip of a random2d plate of it in plane stress (`dim` 2; its target the plate's in-plane
/// stiffness per unit thickness, so its density is the material's), `side` spacings across and
/// `long` along axis `d`, polarised along axis `p` (node set `seed`), its ends as `ends` says:
/// its speed `omega L / pi`, the Christoffel speed `sqrt(C_pdpd / rho)`, the nodes and the
/// steps taken.
///
/// On a side face of normal `m` only what the continuum's traction needs is held: the normal
/// component under a longitudinal wave (`C_mmdd` pushes on it), the wave direction's component
/// on the faces normal to a shear wave's polarisation (`C_dpdp`); every other traction of the
/// mode, `C_kmpd`, vanishes for an orthotropic material in its axes, so the mode is exact in
/// the continuum. Leapfrog steps of half the estimated critical step with the run's kernel; the
/// frequency from the zero crossings of the mode's mass-weighted projection over three periods.
/// At 96 spacings per wavelength or more the lattice's own dispersion, `(ka)^2 / 24`, is below
/// 0.01 %.
fn ringing_bar_in(
    dim: usize,
    t: &Transverse,
    (d, p): (usize, usize),
    [side, long]: [Real; 2],
    ends: Ends,
    seed: u64,
) -> (Real, Real, usize, usize) {
    use hooke_core::random::{RandomSpec, Sampler};
    let a = 1e-3;
    let mut hi = [side * a; 3];
    if dim == 2 {
        hi[2] = 0.0;
    }
    hi[d] = long * a;
    let spec = RandomSpec {
        sampler: Sampler::Poisson,
        seed,
    };
    let lattice = Lattice::random(dim, [0.0; 3], hi, a, a, spec, &|_| true).unwrap();
    let body = hooke_core::Anisotropic::Transverse(*t)
        .body(lattice)
        .unwrap();
    let n = body.nodes();
    let len = hi[d];
    let at = |i: usize| {
        let x = body.lattice.pos.get(i);
        [x.x, x.y, x.z]
    };
    let on = |x: Real, edge: Real| x == 0.0 || x == edge;
    // Which components each node keeps free.
    let free: Vec<[bool; 3]> = (0..n)
        .map(|i| {
            let x = at(i);
            let mut keep = [matches!(ends, Ends::Free) || !on(x[d], hi[d]); 3];
            for m in (0..dim).filter(|&m| m != d && on(x[m], hi[m])) {
                if p == d {
                    keep[m] = false;
                } else if m == p {
                    keep[d] = false;
                }
            }
            keep
        })
        .collect();
    let mut phase: Vec<Real> = (0..n)
        .map(|i| {
            let arg = std::f64::consts::PI * at(i)[d] / len;
            match ends {
                Ends::Held => arg.sin(),
                Ends::Free => arg.cos(),
            }
        })
        .collect();
    if let Ends::Free = ends {
        let mean =
            (0..n).map(|i| body.mass[i] * phase[i]).sum::<Real>() / body.mass.iter().sum::<Real>();
        phase.iter_mut().for_each(|s| *s -= mean);
    }
    let voigt = |i: usize, j: usize| if i == j { i } else { 6 - i - j };
    let c = if dim == 3 {
        t.stiffness().unwrap()
    } else {
        hooke_core::Anisotropic::Transverse(*t)
            .plane_stiffness(hooke_core::material::PlaneModel::Stress)
            .unwrap()
    };
    let c_theory = (c[voigt(p, d)][voigt(p, d)] / t.density).sqrt();
    let mut state = State::new(&body);
    let kernel = Kernel::for_body(&body, &state);
    let dt = 0.5 * hooke_core::stability::estimate(&body, &state, &kernel, 60, 1e-4).dt_critical;
    let amp = 1e-7 * a;
    for (i, s) in phase.iter().enumerate() {
        let mut u = Vector::zeros();
        u[p] = amp * s;
        state.u.set(i, u);
    }
    let norm: Real = (0..n).map(|i| body.mass[i] * phase[i] * phase[i]).sum();
    let project = |u: &Coords| -> Real {
        (0..n)
            .map(|i| body.mass[i] * u.get(i)[p] * phase[i])
            .sum::<Real>()
            / (amp * norm)
    };
    let mut u = state.u.clone();
    let accel = |u: &Coords| -> Coords {
        state.u.clone_from(u);
        let f = kernel_forces(&kernel, &body, &state);
        let mut acc = Coords::zeros(n);
        for i in 0..n {
            let mut g = f.get(i) / body.mass[i];
            for k in 0..3 {
                if !free[i][k] {
                    g[k] = 0.0;
                }
            }
            acc.set(i, g);
        }
        acc
    };
    let limit = (10.0 * len / c_theory / dt) as usize;
    let (crossings, step) = zero_crossings(&mut u, dt, limit, accel, project);
    assert_eq!(
        crossings.len(),
        7,
        "d {d} p {p} side {side}: no oscillation"
    );
    let omega = std::f64::consts::PI * 6.0 / (crossings[6] - crossings[0]);
    (omega * len / std::f64::consts::PI, c_theory, n, step)
}

/// Plane waves on the random3d lattice of the fibre material (fibre along z) run at the
/// Christoffel speeds along and across the fibre, within 1 %. A random lattice has no periodic
/// form, so each wave is the standing mode of bars ([`ringing_bar_in`]). Their faces add a layer
/// about a spacing thick (+4.1 % at 8 spacings across, +2.2 % at 16, for the longitudinal wave
/// across the fibre), so the bulk speed is the bars' mean over three node sets at 16 and 24
/// spacings across, extrapolated linearly in 1 / side: `c = 3 c_24 - 2 c_16`. Measured: the
/// longitudinal waves across (C11) and along (C33) the fibre +0.28 % and -0.60 %, the shear wave
/// across it (C66) +0.10 %, the two shear waves of C55 -0.57 % and +0.07 %.
///
/// The two shear waves of C55 (along x polarised z, along z polarised x) need the wider bars:
/// their faces (free ones normal to y, held ones normal to the polarisation) follow 1 / side
/// only from about 12 spacings across. Mean of the three node sets at 8, 12, 16 and 24 across:
/// -0.81, -1.33, -1.06, -0.90 % and -2.75, -1.50, -0.67, -0.43 %; from 8 and 16 they
/// extrapolated to -1.31 % and +1.40 % (held to 2 % then), from 16 and 24 to -0.57 % and +0.07 %
/// (a least-squares line over 12 to 24: -0.45 % and +0.75 %).
#[test]
#[ignore = "slow: a calibration and thirty ringing bars, about two minutes"]
fn random_lattice_wave_speeds_match_christoffel() {
    let t = carbon([0.0, 0.0, 1.0]);
    let seeds = [7, 8, 9];
    // (wave direction, polarisation, tolerance) along the material axes.
    for (d, p, tol) in [
        (0, 0, 0.01),
        (0, 1, 0.01),
        (2, 2, 0.01),
        (0, 2, 0.01),
        (2, 0, 0.01),
    ] {
        let mut mean = [0.0; 2];
        let mut theory = 0.0;
        for (k, side) in [16.0, 24.0].into_iter().enumerate() {
            for &seed in &seeds {
                let (c, ct, n, steps) =
                    ringing_bar_in(3, &t, (d, p), [side, 48.0], Ends::Held, seed);
                eprintln!(
                    "along {d}, polarised {p}, {side} across, node set {seed}: {c:.2} m/s ({:+.3} %), {n} nodes, {steps} steps",
                    100.0 * (c / ct - 1.0)
                );
                mean[k] += c / seeds.len() as Real;
                theory = ct;
            }
        }
        let bulk = 3.0 * mean[1] - 2.0 * mean[0];
        let err = bulk / theory - 1.0;
        eprintln!(
            "along {d}, polarised {p}: 16 across {:+.3} %, 24 across {:+.3} %, extrapolated {bulk:.2} m/s against Christoffel {theory:.2} m/s: {:+.3} %",
            100.0 * (mean[0] / theory - 1.0),
            100.0 * (mean[1] / theory - 1.0),
            100.0 * err
        );
        assert!(
            err.abs() < tol,
            "along {d}, polarised {p}: the bulk speed is {:+.2} % off",
            100.0 * err
        );
    }
}

/// The plate's (random2d) calibration converges as the cubes' does: small squares, so it runs
/// in the default suite.
#[test]
fn random_plate_calibration_converges() {
    use hooke_core::material::PlaneModel;
    use hooke_core::random::anisotropic::CalibrationOptions;
    let m = hooke_core::Anisotropic::Transverse(carbon([1.0, 0.0, 0.0]));
    // Small squares scatter by several percent per entry: the convergence is what this test
    // holds, not the 2 % reach.
    let opts = CalibrationOptions {
        size: 30.0,
        samples: 3,
        iterations: 3,
        reach: 0.05,
        ..CalibrationOptions::plane()
    };
    let cal = m
        .random_design_plane_with(&opts, PlaneModel::Stress)
        .unwrap();
    assert_converged(&cal);
}

/// A plate (random2d) of the carbon-like material with its fibre in the plane at 30 degrees to
/// x, in plane stress and in plane strain: the design calibrated on its default squares (8 of
/// 64 spacings, seeds 1001-1008), measured on 8 unseen squares of 64 spacings (seeds 1-8), each
/// entry of the in-plane stiffness in the material axes within 2 % of the target. Measured:
/// stress within 1.05 % (C12 +1.05 %, C11 -0.58 %), strain within 0.76 % (C11 -0.76 %); the
/// squares scatter by 0.7 % (C66) to 2.3 % (C11) each.
#[test]
#[ignore = "slow: two calibrations, about a minute"]
fn random_plate_design_meets_the_target_on_unseen_node_sets() {
    use hooke_core::material::PlaneModel;
    let t = 30f64.to_radians();
    let m = hooke_core::Anisotropic::Transverse(carbon([t.cos(), t.sin(), 0.0]));
    for plane in [PlaneModel::Stress, PlaneModel::Strain] {
        eprintln!("plane {plane:?}");
        let cal = m
            .random_design_plane(hooke_core::random::Sampler::Poisson, plane)
            .unwrap();
        let (axes, _) = m.plane_axes().unwrap();
        let target = m.plane_local_stiffness(plane).unwrap();
        design_within(&cal, 2, (64.0, 8), &axes, &target, 0.02);
    }
}

/// Plane waves on a random2d plate of the fibre material (fibre along x, plane stress) run at
/// the plate's in-plane Christoffel speeds `sqrt(Q_pdpd / rho)` within 1 %: the free-ended
/// standing modes ([`Ends::Free`]) of strips 192 spacings long and 128 wide, the mean of four
/// node sets. Measured: longitudinal along the fibre +0.52 %, across it +0.23 %; shear along x
/// -0.55 %, along y -0.52 % (one strip scatters by 0.2-0.5 %). The design itself, on 8 unseen
/// squares of 64 spacings, is 0.53-0.84 % soft per entry (Q66 -0.65 %, so -0.33 % in speed).
///
/// Smaller strips do not show 1 %. Held ends (the 3D bars' mode), 48 long and 32 wide, six node
/// sets: +1.03, +0.79, -1.19, -1.98 % (in the order above); 48 long, free ends, 64 wide: -0.90,
/// -0.27, -0.48, -0.89 % with strips scattering by 0.3-0.9 %; 96 long and 128 wide: free ends
/// +0.25, +0.06, -0.79, -0.30 %, held ends -0.15, +0.19, -0.29, -0.88 % (the two shear waves
/// swap with the ends: the ends' layer, not the bulk). At 192 long the two shear waves agree.
#[test]
#[ignore = "slow: a plate calibration and 16 ringing strips of 28 000 nodes, about two minutes"]
fn random_plate_wave_speeds_match_christoffel() {
    plate_waves_within(carbon([1.0, 0.0, 0.0]), 0.01);
}

/// The plate's four plane waves with the fibre out of its plane, at 45 degrees in the x-z plane
/// (the plate orthotropic in x and y: E_x = E(45 degrees) = 10.9 GPa, E_y = E_p): free-ended
/// strips as [`random_plate_wave_speeds_match_christoffel`]'s, against the Christoffel speeds of
/// the plate's in-plane stiffness (plane stress), within 1 %. Measured: longitudinal along x
/// +0.19 %, along y -0.03 %; shear along x +0.07 %, along y +0.16 %.
#[test]
#[ignore = "slow: a plate calibration and 16 ringing strips of 28 000 nodes, about two minutes"]
fn random_plate_waves_with_a_fibre_out_of_the_plane_match_christoffel() {
    plate_waves_within(carbon([1.0, 0.0, 1.0]), 0.01);
}

/// The mean of four node sets' free-ended strips (192 long, 128 wide) of a random2d plate of
/// `t` in plane stress, along x and y and polarised along each, within `tol` of the Christoffel
/// speeds of the plate's in-plane stiffness.
fn plate_waves_within(t: Transverse, tol: Real) {
    let seeds = [7, 8, 9, 10];
    for (d, p) in [(0, 0), (1, 1), (0, 1), (1, 0)] {
        let (mut mean, mut theory) = (0.0, 0.0);
        for &seed in &seeds {
            let (c, ct, n, steps) = ringing_bar_in(2, &t, (d, p), [128.0, 192.0], Ends::Free, seed);
            eprintln!(
                "plate, along {d}, polarised {p}, node set {seed}: {c:.2} m/s ({:+.3} %), {n} nodes, {steps} steps",
                100.0 * (c / ct - 1.0)
            );
            mean += c / seeds.len() as Real;
            theory = ct;
        }
        let err = mean / theory - 1.0;
        eprintln!(
            "plate, along {d}, polarised {p}: {mean:.2} m/s against {theory:.2} m/s: {:+.3} %",
            100.0 * err
        );
        assert!(
            err.abs() < tol,
            "along {d}, polarised {p}: {:+.2} %",
            100.0 * err
        );
    }
}
