//! Random lattices (the paper's "random MSM"): the Delaunay network fills its box exactly, is
//! reproducible from its seed, and its ensemble-mean moduli match the requested E and nu
//! (block test over seeded samples), along every axis.
//!
//! Tolerances: the issue's, 0.02 on the mean nu and 5 % on the mean E (3D); the same in 2D. The
//! calibration (`hooke_core::random::calibration`) was measured on the paper's 70a x 15a x 15a
//! block; these tests run smaller blocks (40a x 10a x 10a), so they also check that the
//! calibration does not depend on the block size.

use hooke_core::moduli::{block_test, BlockTest};
use hooke_core::random::{RandomSpec, Sampler};
use hooke_core::{Lattice, LatticeKind, Real};

fn ensemble(
    kind: LatticeKind,
    nu: Real,
    size: [usize; 3],
    axis: usize,
    samples: u64,
    seed0: u64,
) -> (Vec<Real>, Vec<Real>, Real) {
    let mut nus = Vec::new();
    let mut es = Vec::new();
    let mut target = 0.0;
    for s in 0..samples {
        let mut t = BlockTest::paper(kind, nu);
        t.size = size;
        t.axis = axis;
        t.random.seed = seed0 + s;
        let r = block_test(&t).unwrap();
        assert!(r.solve.residual < 1e-8);
        nus.push(r.nu_measured);
        es.push(r.e_measured);
        target = r.e_target;
    }
    (nus, es, target)
}

fn mean_sd(v: &[Real]) -> (Real, Real) {
    let n = v.len() as Real;
    let m = v.iter().sum::<Real>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<Real>() / (n - 1.0).max(1.0);
    (m, var.sqrt())
}

#[test]
fn random3d_ensemble_moduli_match_the_targets() {
    for nu in [-0.5, 0.0, 0.25, 0.45] {
        let (nus, es, e_t) = ensemble(LatticeKind::Random3d, nu, [41, 11, 11], 0, 3, 1);
        let (nu_m, nu_sd) = mean_sd(&nus);
        let (e_m, e_sd) = mean_sd(&es);
        println!(
            "random3d nu {nu:+.2}: nu {nu_m:.4} (sd {nu_sd:.4}), E/E_target {:.4} (sd {:.4})",
            e_m / e_t,
            e_sd / e_t
        );
        assert!((nu_m - nu).abs() <= 0.02, "nu {nu}: measured {nu_m}");
        assert!(
            (e_m / e_t - 1.0).abs() <= 0.05,
            "nu {nu}: E ratio {}",
            e_m / e_t
        );
    }
}

#[test]
fn random2d_ensemble_moduli_match_the_targets() {
    for nu in [-0.5, 0.0, 1.0 / 3.0, 0.7] {
        let (nus, es, e_t) = ensemble(LatticeKind::Random2d, nu, [81, 21, 1], 0, 6, 11);
        let (nu_m, nu_sd) = mean_sd(&nus);
        let (e_m, e_sd) = mean_sd(&es);
        println!(
            "random2d nu {nu:+.2}: nu {nu_m:.4} (sd {nu_sd:.4}), E/E_target {:.4} (sd {:.4})",
            e_m / e_t,
            e_sd / e_t
        );
        assert!((nu_m - nu).abs() <= 0.02, "nu {nu}: measured {nu_m}");
        assert!(
            (e_m / e_t - 1.0).abs() <= 0.05,
            "nu {nu}: E ratio {}",
            e_m / e_t
        );
    }
}

/// The jittered grid has its own calibration (its Delaunay network is stiffer and has a lower
/// plain Poisson's ratio than blue noise): the same tolerances hold with it.
#[test]
fn jittered_grids_meet_the_targets_with_their_own_calibration() {
    for (kind, nu, size) in [
        (LatticeKind::Random3d, 0.0, [41, 11, 11]),
        (LatticeKind::Random3d, 0.4, [41, 11, 11]),
        (LatticeKind::Random2d, 0.2, [81, 21, 1]),
        (LatticeKind::Random2d, 0.7, [81, 21, 1]),
    ] {
        let mut nus = Vec::new();
        let mut es = Vec::new();
        let mut e_t = 0.0;
        for s in 0..3 {
            let mut t = BlockTest::paper(kind, nu);
            t.size = size;
            t.random = RandomSpec {
                sampler: Sampler::Jitter { amplitude: 0.6 },
                seed: 50 + s,
            };
            let r = block_test(&t).unwrap();
            nus.push(r.nu_measured);
            es.push(r.e_measured);
            e_t = r.e_target;
        }
        let (nu_m, _) = mean_sd(&nus);
        let (e_m, _) = mean_sd(&es);
        println!(
            "jitter {kind:?} nu {nu}: nu {nu_m:.4}, E/E_target {:.4}",
            e_m / e_t
        );
        assert!((nu_m - nu).abs() <= 0.02, "{kind:?} nu {nu}: {nu_m}");
        assert!(
            (e_m / e_t - 1.0).abs() <= 0.05,
            "{kind:?} nu {nu}: E {}",
            e_m / e_t
        );
    }
}

/// Isotropy: the same test with the bar along x, y and z (independent samples each: the sampler
/// and the triangulation treat the axes in a fixed order, so each axis sees a different network)
/// gives the same E and nu within the sampling error.
#[test]
fn random3d_moduli_agree_along_x_y_and_z() {
    let nu = 0.3;
    let runs: Vec<_> = (0..3)
        .map(|ax| {
            ensemble(
                LatticeKind::Random3d,
                nu,
                [41, 11, 11],
                ax,
                3,
                20 + 10 * ax as u64,
            )
        })
        .collect();
    for a in 0..3 {
        for b in a + 1..3 {
            let (na, sa) = mean_sd(&runs[a].0);
            let (nb, sb) = mean_sd(&runs[b].0);
            let (ea, ta) = mean_sd(&runs[a].1);
            let (eb, tb) = mean_sd(&runs[b].1);
            // Standard error of the difference of two means of 3 samples.
            let se_nu = ((sa * sa + sb * sb) / 3.0).sqrt();
            let se_e = ((ta * ta + tb * tb) / 3.0).sqrt();
            println!(
                "axes {a}/{b}: nu {na:.4} / {nb:.4} (se {se_nu:.4}), E {ea:.5} / {eb:.5} (se {se_e:.5})"
            );
            assert!(
                (na - nb).abs() <= 3.0 * se_nu + 0.003,
                "nu along {a} and {b}"
            );
            assert!(
                (ea - eb).abs() <= 3.0 * se_e + 0.005 * ea,
                "E along {a} and {b}"
            );
        }
    }
}

/// The triangulation covers the box exactly (its faces carry nodes of their own) and the node
/// and spring volumes each add up to it, so masses and stiffnesses account for all material.
#[test]
fn random_lattices_fill_their_box_and_repeat_with_their_seed() {
    for sampler in [Sampler::Poisson, Sampler::Jitter { amplitude: 0.6 }] {
        let spec = RandomSpec { sampler, seed: 4 };
        let l3 = Lattice::random(3, [0.0; 3], [9.0, 6.0, 5.0], 1.0, 1.0, spec, &|_| true).unwrap();
        let l2 = Lattice::random(2, [0.0; 3], [12.0, 7.0, 0.0], 1.0, 0.5, spec, &|_| true).unwrap();
        for (l, vol) in [(&l3, 270.0), (&l2, 84.0 * 0.5)] {
            let c = l.cells.as_ref().unwrap();
            let nodes: Real = c.node.iter().sum();
            let springs: Real = c.spring.iter().sum();
            assert!(
                (nodes / vol - 1.0).abs() < 1e-9,
                "{sampler:?}: node volume {nodes} of {vol}"
            );
            assert!(
                (springs / vol - 1.0).abs() < 1e-9,
                "{sampler:?}: spring volume {springs}"
            );
            // The boundary shares add up to the surface, and to zero as vectors (closed).
            let area: Real = c
                .surface
                .iter()
                .map(|s| s[0].abs() + s[1].abs() + s[2].abs())
                .sum();
            let net: [Real; 3] = [0, 1, 2].map(|k| c.surface.iter().map(|s| s[k]).sum::<Real>());
            let expect = if l.dim() == 3 {
                2.0 * (54.0 + 45.0 + 30.0)
            } else {
                2.0 * (12.0 + 7.0) * 0.5
            };
            assert!(
                (area / expect - 1.0).abs() < 1e-9,
                "{sampler:?}: surface {area} of {expect}"
            );
            assert!(net.iter().all(|v| v.abs() < 1e-9), "{net:?}");
            let mean_degree = 2.0 * l.bonds.len() as Real / l.len() as Real;
            println!(
                "{:?} {sampler:?}: {} nodes, mean degree {mean_degree:.2}",
                l.kind,
                l.len()
            );
        }
        let again =
            Lattice::random(3, [0.0; 3], [9.0, 6.0, 5.0], 1.0, 1.0, spec, &|_| true).unwrap();
        assert_eq!(again.pos, l3.pos);
        assert_eq!(again.bonds.ends, l3.bonds.ends);
        let other = RandomSpec { seed: 5, ..spec };
        let l = Lattice::random(3, [0.0; 3], [9.0, 6.0, 5.0], 1.0, 1.0, other, &|_| true).unwrap();
        assert_ne!(l.pos, l3.pos);
    }
}

/// A shape with a hole: no node inside the hole and no spring across it.
#[test]
fn random_lattice_respects_holes_and_notches() {
    let inside = |p: [Real; 3]| {
        let hole = (p[0] - 5.0).powi(2) + (p[1] - 4.0).powi(2) < 2.0f64.powi(2);
        let notch = p[0] < 4.0 && (p[1] - 1.0).abs() < 0.6;
        !hole && !notch
    };
    let l = Lattice::random(
        2,
        [0.0; 3],
        [10.0, 8.0, 0.0],
        0.5,
        1.0,
        RandomSpec::default(),
        &inside,
    )
    .unwrap();
    for i in 0..l.len() {
        assert!(inside([l.pos.x()[i], l.pos.y()[i], 0.0]));
    }
    for &[i, j] in &l.bonds.ends {
        let (i, j) = (i as usize, j as usize);
        for t in 1..10 {
            let t = t as Real / 10.0;
            let p = [
                l.pos.x()[i] + t * (l.pos.x()[j] - l.pos.x()[i]),
                l.pos.y()[i] + t * (l.pos.y()[j] - l.pos.y()[i]),
                0.0,
            ];
            let in_hole = (p[0] - 5.0).powi(2) + (p[1] - 4.0).powi(2) < 1.9f64.powi(2);
            let in_notch = p[0] < 3.9 && (p[1] - 1.0).abs() < 0.5;
            assert!(
                !in_hole && !in_notch,
                "spring {i}-{j} crosses the gap at {p:?}"
            );
        }
    }
}

/// Slow verification at the paper's block size (70a x 15a x 15a), 4 samples per nu, for both
/// samplers (each with its own calibration table), on seeds the tables were not measured with.
/// `cargo test --release -p hooke-tests --test random -- --ignored --nocapture` (about 3 min).
#[test]
#[ignore]
fn random3d_paper_block_over_nu_and_samplers() {
    for sampler in [Sampler::Poisson, Sampler::Jitter { amplitude: 0.6 }] {
        for nu in [-0.9, -0.5, 0.0, 0.25, 0.45] {
            let mut nus = Vec::new();
            let mut es = Vec::new();
            let mut e_t = 0.0;
            for s in 0..4 {
                let mut t = BlockTest::paper(LatticeKind::Random3d, nu);
                t.random = RandomSpec {
                    sampler,
                    seed: 100 + s,
                };
                let r = block_test(&t).unwrap();
                nus.push(r.nu_measured);
                es.push(r.e_measured);
                e_t = r.e_target;
            }
            let (nu_m, nu_sd) = mean_sd(&nus);
            let (e_m, e_sd) = mean_sd(&es);
            println!(
                "{sampler:?} nu {nu:+.2}: nu {nu_m:.4} (sd {nu_sd:.4}), E/E_target {:.4} (sd {:.4})",
                e_m / e_t,
                e_sd / e_t
            );
            assert!((nu_m - nu).abs() <= 0.02 && (e_m / e_t - 1.0).abs() <= 0.05);
        }
    }
}

/// The relaxed bulk test's identities on one node set (random3d, 12-spacing cube):
/// * its tensor is symmetric (the relaxed response is the Hessian of an energy), to the
///   solver's tolerance;
/// * the affine tensor bounds it from above in energy (Hill: relaxation only lowers the energy
///   of a given boundary strain), so `C_affine - C_measured` is positive semi-definite;
/// * the relaxation is real: C11 relaxes by more than 3 % (the network is about 7 % softer
///   than its affine estimate, `calibration`);
/// * regular lattices and cubes too small to have inner nodes are refused.
#[test]
fn relaxed_bulk_tensor_is_symmetric_and_below_the_affine_one() {
    use hooke_core::moduli::{relaxed_bulk_stiffness, RelaxedBulk};
    let t = RelaxedBulk {
        kind: LatticeKind::Random3d,
        nu: 0.3,
        size: 12.0,
        spacing: 1e-3,
        stiffness: 2e9,
        random: RandomSpec {
            sampler: Sampler::Poisson,
            seed: 3,
        },
        solver: Default::default(),
    };
    let r = relaxed_bulk_stiffness(&t).unwrap();
    let c = nalgebra::Matrix6::from_fn(|i, j| r.c_measured[i][j]);
    let a = nalgebra::Matrix6::from_fn(|i, j| r.c_affine[i][j]);
    let c11 = c[(0, 0)];
    assert!(r.boundary_nodes > 0 && r.boundary_nodes < r.nodes);
    assert!(
        (c - c.transpose()).amax() < 1e-6 * c11,
        "asymmetry {:e} of C11",
        (c - c.transpose()).amax() / c11
    );
    let gap = (a - c).symmetric_eigenvalues().min();
    assert!(gap > -1e-6 * c11, "C_affine - C has eigenvalue {gap:e}");
    assert!(
        c11 < 0.97 * a[(0, 0)],
        "C11 {c11:e} against affine {:e}",
        a[(0, 0)]
    );
    // And it is a stiffness near the target: every entry within 5 % of C11 on one small cube.
    for i in 0..6 {
        for j in 0..6 {
            assert!((c[(i, j)] - r.c_target[i][j]).abs() < 0.05 * c11);
        }
    }
    let mut bad = t.clone();
    bad.kind = LatticeKind::Cubic;
    assert!(relaxed_bulk_stiffness(&bad).is_err());
    let mut bad = t.clone();
    bad.size = 2.0;
    assert!(relaxed_bulk_stiffness(&bad).is_err());
}

/// The relaxed bulk tensor's ensemble means against the calibrated isotropic targets, per entry
/// (the entry's own value, or C11 where the target's entry is zero), on the default cubes
/// (32 spacings in 3D, 64 in 2D), 4 node sets each. The calibration came from block tests with
/// free faces; this is an independent check. Measured: 3D within 1.3 % for nu in
/// [-0.9, 0.45] (C11 0.7-0.9 % high: the faces' boundary layer, which shrinks like a/L);
/// 2D within 1.5 % for nu_2D in [-0.9, 0.45]. At 3D nu = -0.9 the entries scale like
/// 1/(1 + nu): with the calibration's first row at q = -0.49 they were 5 % off.
#[test]
#[ignore]
fn relaxed_bulk_ensembles_match_the_calibrated_targets() {
    use hooke_core::moduli::{relaxed_bulk_stiffness, RelaxedBulk};
    let cases: &[(LatticeKind, Real, Real, Real)] = &[
        (LatticeKind::Random3d, -0.5, 32.0, 0.02),
        (LatticeKind::Random3d, 0.0, 32.0, 0.02),
        (LatticeKind::Random3d, 0.25, 32.0, 0.02),
        (LatticeKind::Random3d, 0.45, 32.0, 0.02),
        (LatticeKind::Random3d, -0.9, 32.0, 0.02),
        (LatticeKind::Random2d, -0.9, 64.0, 0.02),
        (LatticeKind::Random2d, -0.5, 64.0, 0.02),
        (LatticeKind::Random2d, 0.0, 64.0, 0.02),
        (LatticeKind::Random2d, 0.25, 64.0, 0.02),
        (LatticeKind::Random2d, 0.45, 64.0, 0.02),
    ];
    for &(kind, nu, size, tol) in cases {
        let mut mean = [[0.0; 6]; 6];
        let mut target = [[0.0; 6]; 6];
        let samples = 4;
        for seed in 1..=samples {
            let r = relaxed_bulk_stiffness(&RelaxedBulk {
                kind,
                nu,
                size,
                spacing: 1.0,
                stiffness: 1.0,
                random: RandomSpec {
                    sampler: Sampler::Poisson,
                    seed,
                },
                solver: Default::default(),
            })
            .unwrap();
            for i in 0..6 {
                for j in 0..6 {
                    mean[i][j] += r.c_measured[i][j] / samples as Real;
                }
            }
            target = r.c_target;
        }
        let scale = target[0][0];
        let mut worst: Real = 0.0;
        for i in 0..6 {
            for j in 0..6 {
                let t = target[i][j];
                let d = mean[i][j] - t;
                worst = worst.max(
                    if t.abs() > 1e-12 * scale {
                        d / t
                    } else {
                        d / scale
                    }
                    .abs(),
                );
            }
        }
        println!(
            "{} nu {nu}: largest entry difference {:.4}",
            kind.name(),
            worst
        );
        assert!(worst < tol, "{} nu {nu}: {worst}", kind.name());
    }
}
