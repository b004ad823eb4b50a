//! Softening (cohesive) springs: a damaged spring is a spring of lower stiffness in every part of
//! the dispersive law, a fully softened one is exactly a broken one, every kernel agrees with
//! the reference law, the damage-proof step bounds every damage state, the ledger books what
//! softening dissipates, and runs are bit-identical for any thread count and through a
//! checkpoint.

use hooke_core::dynamics::{Integrator, IntegratorOptions, TimeStep};
use hooke_core::kernel::Kernel;
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::{law, Body, LatticeKind, Real, State};
use hooke_fracture::{Fracture, Softening, SofteningShape};
use hooke_tests::{dense_tangent, kernel_forces, pull_ends, random_displacement, small_body, Rng};

const KINDS: [(LatticeKind, Real); 6] = [
    (LatticeKind::Cubic, -0.8),
    (LatticeKind::Cubic, 0.45),
    (LatticeKind::Hex, 0.9),
    (LatticeKind::Hex, -0.5),
    (LatticeKind::Random3d, 0.3),
    (LatticeKind::Random2d, -0.6),
];

/// Soften a third of the springs to random weights and break a tenth; returns the weights.
fn damage_randomly(body: &Body, state: &mut State, rng: &mut Rng) -> Vec<Real> {
    for b in 0..body.springs() {
        let r = rng.uniform();
        if r < 0.1 {
            state.soften(body, b, 0.0);
        } else if r < 0.43 {
            let w = 0.05 + 0.9 * rng.uniform();
            assert!(state.soften(body, b, w));
        }
    }
    state.weights()
}

/// The law on a damaged state is the law of the body whose springs have stiffness `w k`: pools,
/// normalisers, forces and energy, bit for bit.
#[test]
fn a_softened_spring_is_a_spring_of_the_lower_stiffness() {
    for (seed, &(kind, nu)) in KINDS.iter().enumerate() {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 5);
        let mut rng = Rng::new(40 + seed as u64);
        let mut state = State::new(&body);
        let w = damage_randomly(&body, &mut state, &mut rng);
        assert!(state.is_softened());
        state.u = random_displacement(&body, &mut rng, 0.05);
        law::update_forces(&body, &mut state);

        let mut weaker = body.clone();
        for (k, &w) in weaker.k.iter_mut().zip(&w) {
            if w > 0.0 {
                *k *= w;
            }
        }
        let mut plain = State::new(&weaker);
        for (b, &w) in w.iter().enumerate() {
            if w == 0.0 {
                plain.kill_bond(&weaker, b);
            }
        }
        plain.u = state.u.clone();
        law::update_forces(&weaker, &mut plain);
        assert_eq!(state.norm(), plain.norm(), "{kind:?}: normalisers");
        assert_eq!(state.pool, plain.pool, "{kind:?}: pools");
        assert!(state.f == plain.f, "{kind:?}: forces");
        let e1 = law::energy(&body, &state.u, state.springs(&body), state.norm());
        let e2 = law::energy(&weaker, &plain.u, plain.springs(&weaker), plain.norm());
        assert_eq!(e1, e2, "{kind:?}: energy");
    }
}

/// Softening a spring to weight 0 is breaking it: the same state, bit for bit; a plane of
/// fully softened springs decouples the two halves exactly.
#[test]
fn a_fully_softened_spring_is_a_broken_one() {
    for &(kind, nu) in &KINDS {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 6);
        let mut rng = Rng::new(7);
        let (mut a, mut b) = (State::new(&body), State::new(&body));
        damage_randomly(&body, &mut a, &mut rng);
        b.clone_from(&a);
        let mid = 2.5;
        let x = body.lattice.pos.x();
        let crossing: Vec<usize> = (0..body.springs())
            .filter(|&s| {
                let [i, j] = body.lattice.bonds.ends[s].map(|v| v as usize);
                (x[i] < mid) != (x[j] < mid)
            })
            .collect();
        for &s in &crossing {
            a.soften(&body, s, 0.0);
            b.kill_bond(&body, s);
        }
        assert!(a == b, "{kind:?}: softened to 0 differs from broken");
        // Move the right half: no force on the left half changes.
        a.u = random_displacement(&body, &mut rng, 0.05);
        law::update_forces(&body, &mut a);
        let left_before: Vec<[Real; 3]> = (0..body.nodes())
            .filter(|&i| x[i] < mid)
            .map(|i| [a.f.x()[i], a.f.y()[i], a.f.z()[i]])
            .collect();
        let extra = random_displacement(&body, &mut rng, 0.05);
        for i in (0..body.nodes()).filter(|&i| x[i] >= mid) {
            for c in 0..body.lattice.dim() {
                a.u.comp_mut(c)[i] += extra.comp(c)[i];
            }
        }
        law::update_forces(&body, &mut a);
        let left_after: Vec<[Real; 3]> = (0..body.nodes())
            .filter(|&i| x[i] < mid)
            .map(|i| [a.f.x()[i], a.f.y()[i], a.f.z()[i]])
            .collect();
        assert_eq!(left_before, left_after, "{kind:?}: the halves are coupled");
    }
}

/// The general kernel (the stencil hands softened bodies to it) against the reference law, with
/// softened and broken springs, to 1e-12 of the largest force; and the stencil gives the body
/// up at its first softened spring.
#[test]
fn kernel_forces_match_the_reference_law_with_softened_springs() {
    for &(kind, nu) in &KINDS {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 6);
        let mut rng = Rng::new(11);
        let mut state = State::new(&body);
        damage_randomly(&body, &mut state, &mut rng);
        state.u = random_displacement(&body, &mut rng, 0.05);
        // A general kernel: CSR, or its row form on AVX-512.
        let general = Kernel::for_body(&body, &state);
        assert!(!general.is_stencil(), "{kind:?}: {}", general.name());
        let mut reference = state.clone();
        law::update_forces(&body, &mut reference);
        let fmax = (0..body.nodes())
            .map(|i| reference.f.get(i).norm())
            .fold(0.0, Real::max);
        for kernel in [Kernel::Csr { plain: false }, general] {
            let f = kernel_forces(&kernel, &body, &state);
            for i in 0..body.nodes() {
                let (a, b) = (f.get(i), reference.f.get(i));
                assert!(
                    (a - b).norm() <= 1e-12 * fmax,
                    "{kind:?} {}: node {i}: {a:?} vs {b:?}",
                    kernel.name()
                );
            }
        }
    }
}

/// For any damage state the stiffness stays positive semidefinite and its largest eigenvalue
/// (over the masses) stays below `(1 + 2 max(q, 0)) lambda_plain` of the undamaged body, the
/// damage-proof bound the stable step uses (`hooke_fracture::softening`, proof in its docs).
#[test]
fn every_damage_state_respects_the_damage_proof_bound() {
    for &(kind, nu) in &KINDS {
        let q = q_from_nu(kind, nu).unwrap();
        let body = small_body(kind, q, 4);
        let mut plain_body = body.clone();
        plain_body.q = 0.0;
        let intact = State::new(&plain_body);
        let lambda_plain = dense_tangent(&plain_body, &intact, true)
            .symmetric_eigen()
            .eigenvalues
            .max();
        let bound = (1.0 + 2.0 * q.max(0.0)) * lambda_plain;
        for seed in 0..3 {
            let mut rng = Rng::new(70 + seed);
            let mut state = State::new(&body);
            damage_randomly(&body, &mut state, &mut rng);
            law::update_forces(&body, &mut state);
            let eig = dense_tangent(&body, &state, true)
                .symmetric_eigen()
                .eigenvalues;
            let (lmin, lmax) = (eig.min(), eig.max());
            assert!(lmin > -1e-12 * lmax, "{kind:?} nu={nu}: eigenvalue {lmin}");
            assert!(
                lmax <= bound * (1.0 + 1e-12),
                "{kind:?} nu={nu}: {lmax} above the bound {bound}"
            );
        }
    }
}

struct Outcome {
    state: State,
    /// The kernel at the start and at the end.
    kernels: (&'static str, &'static str),
    softened: usize,
    broken: usize,
    released: Real,
    /// Largest energy-balance error over the run, relative to the work put in.
    error: Real,
}

fn softening_run(kind: LatticeKind, nu: Real, shape: SofteningShape, safety: Real) -> Outcome {
    let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 8);
    let loading = pull_ends(&body, 2e-3);
    let mut state = State::new(&body);
    let opts = IntegratorOptions {
        time_step: TimeStep::Auto { safety },
        damage_proof: true,
        ..Default::default()
    };
    let mut it = Integrator::new(&body, &mut state, loading, &opts).unwrap();
    let first = it.kernel().name();
    let law = Softening::new(0.004, 0.03, shape).unwrap();
    let mut fr = Fracture::new(&body, Box::new(law));
    let (mut worst, end) = (0.0, 300.0);
    for k in 1..=15 {
        while state.time < end * k as Real / 15.0 {
            fr.step(&body, &mut state, &mut it, None);
        }
        fr.settle(&body, &mut state, &mut it);
        it.check(&body, &state).unwrap();
        let b = it.energy(&body, &mut state);
        worst = Real::max(worst, b.relative_error.abs());
    }
    Outcome {
        kernels: (first, it.kernel().name()),
        state,
        softened: fr.softened_total,
        broken: fr.broken_total,
        released: fr.released_total,
        error: worst,
    }
}

/// Pulling a bar apart with softening springs: springs soften and then break, the energy they
/// dissipate is booked, and the balance closes to second order in dt; on the cubic lattice
/// the run starts on the stencil and moves to the general kernel at the first damage.
#[test]
fn softening_dissipates_and_the_ledger_balances() {
    for &(kind, nu) in &KINDS {
        for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
            let coarse = softening_run(kind, nu, shape, 0.8);
            let fine = softening_run(kind, nu, shape, 0.4);
            eprintln!(
                "{kind:?} nu={nu} {shape:?}: {} softenings, {} broken, released {:.3e}; balance \
                 error {:.2e} (dt/2: {:.2e})",
                coarse.softened, coarse.broken, coarse.released, coarse.error, fine.error
            );
            assert!(coarse.softened > 0, "{kind:?}: nothing softened");
            assert!(coarse.broken > 0, "{kind:?}: nothing broke");
            assert!(coarse.released > 0.0, "{kind:?}: nothing dissipated");
            assert!(coarse.state.is_softened());
            if kind == LatticeKind::Cubic {
                assert_ne!(
                    coarse.kernels.0, "csr",
                    "the cubic bar starts on the stencil"
                );
            }
            // A general kernel: CSR, or its row form on AVX-512.
            let general = coarse.kernels.1;
            assert!(general == "csr" || general.starts_with("rows"), "{general}");
            assert!(
                coarse.error < 0.05,
                "{kind:?}: balance error {}",
                coarse.error
            );
            assert!(
                coarse.error < 5e-3 || fine.error < 0.45 * coarse.error,
                "{kind:?}: balance not converging: {} -> {}",
                coarse.error,
                fine.error
            );
        }
    }
}

/// The same softening run on 1 and 2 threads: the same state, weights included, bit for bit.
#[test]
fn softening_is_bit_identical_for_any_thread_count() {
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| softening_run(LatticeKind::Random3d, 0.3, SofteningShape::Bilinear, 0.8))
    };
    let (a, b) = (run(1), run(2));
    assert!(a.softened > 0);
    assert!(a.state == b.state, "states differ between 1 and 2 threads");
    assert_eq!(a.state.weights(), b.state.weights());
}

/// A checkpoint keeps every spring's weight: the restored state equals the saved one.
#[test]
fn checkpoints_keep_the_damage() {
    use hooke_io::checkpoint::Checkpoint;
    let body = small_body(LatticeKind::Random2d, 0.2, 8);
    let mut rng = Rng::new(3);
    let mut state = State::new(&body);
    damage_randomly(&body, &mut state, &mut rng);
    state.u = random_displacement(&body, &mut rng, 0.01);
    let mut it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    it.step(&body, &mut state);
    let dir = std::env::temp_dir().join(format!("hooke-soft-ck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("c.bin");
    Checkpoint {
        digest: 9,
        state: state.clone(),
        integrator: it.checkpoint(),
        broken: 0,
        released: 0.0,
        extra: Vec::new(),
    }
    .save(&path)
    .unwrap();
    let back = Checkpoint::load(&path, &body, 9).unwrap();
    assert_eq!(back.state.weights(), state.weights());
    assert_eq!(back.state.norm(), state.norm());
    assert!(back.state.u == state.u && back.state.v == state.v);
    std::fs::remove_dir_all(&dir).ok();
}
