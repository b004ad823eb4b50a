//! Checks of the force law itself: forces are minus the energy gradient, the tangent is the
//! force Jacobian, momentum is conserved, removed springs decouple exactly, and the stiffness
//! stays positive semidefinite after heavy damage.

use hooke_core::material::q_from_nu;
use hooke_core::{law, LatticeKind, Real, State, Vector};
use hooke_tests::{
    assert_force_is_minus_energy_gradient, assert_tangent_is_force_jacobian, dense_tangent,
    kill_random, random_displacement, small_body, Rng,
};

/// force = -grad U by central differences on a randomly deformed body with 20 % of its springs
/// removed; the relative error is bounded by the O(h^2) truncation.
#[test]
fn force_is_minus_energy_gradient() {
    for (kind, nu, seed) in [
        (LatticeKind::Cubic, -0.8, 1),
        (LatticeKind::Cubic, 0.45, 2),
        (LatticeKind::Hex, 0.9, 3),
        (LatticeKind::Hex, -0.5, 4),
        (LatticeKind::Random3d, -0.8, 8),
        (LatticeKind::Random3d, 0.45, 9),
        (LatticeKind::Random2d, 0.9, 10),
        (LatticeKind::Random2d, -0.5, 11),
    ] {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 4);
        let mut rng = Rng::new(seed);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.2);
        state.u = random_displacement(&body, &mut rng, 0.05);
        law::update_forces(&body, &mut state);
        assert_force_is_minus_energy_gradient(
            &body,
            &state,
            1e-6,
            1e-7,
            &format!("{kind:?} nu={nu}"),
        );
    }
}

/// The tangent is the exact Jacobian of the forces: K v = -(f(u + h v) - f(u - h v)) / 2h.
#[test]
fn tangent_is_the_force_jacobian() {
    for (kind, nu, seed) in [
        (LatticeKind::Cubic, -0.9, 5),
        (LatticeKind::Cubic, 0.49, 6),
        (LatticeKind::Hex, 0.7, 7),
        (LatticeKind::Random3d, 0.3, 12),
        (LatticeKind::Random2d, -0.7, 13),
    ] {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 4);
        let mut rng = Rng::new(seed);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.15);
        state.u = random_displacement(&body, &mut rng, 0.05);
        law::update_forces(&body, &mut state);
        let v = random_displacement(&body, &mut rng, 1.0);
        assert_tangent_is_force_jacobian(
            &body,
            &state,
            &v,
            1e-6,
            1e-7,
            &format!("{kind:?} nu={nu}"),
        );
    }
}

/// Internal forces sum to zero and exert no net torque, to round-off, in any deformed state with
/// any springs removed.
#[test]
fn internal_forces_conserve_momentum() {
    for (kind, nu) in [
        (LatticeKind::Cubic, -0.95),
        (LatticeKind::Cubic, 0.45),
        (LatticeKind::Hex, 0.95),
    ] {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 6);
        let mut rng = Rng::new(11);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.3);
        state.u = random_displacement(&body, &mut rng, 0.1);
        law::update_forces(&body, &mut state);
        let mut sum = Vector::zeros();
        let mut torque = Vector::zeros();
        let mut scale: Real = 0.0;
        for i in 0..body.nodes() {
            let f = state.f.get(i);
            sum += f;
            torque += state.position(&body, i).cross(&f);
            scale = scale.max(f.norm());
        }
        assert!(
            sum.norm() < 1e-13 * scale * body.nodes() as Real,
            "{kind:?}: net force {sum:?}"
        );
        assert!(
            torque.norm() < 1e-12 * scale * body.nodes() as Real,
            "{kind:?}: net torque {torque:?}"
        );
    }
}

/// A body cut in two by killing every spring that crosses a plane: the halves exert exactly zero
/// force on each other, for q < 0 and q > 0. Moving one half leaves the forces on the other
/// bit-for-bit unchanged.
#[test]
fn cut_halves_are_exactly_decoupled() {
    for (kind, nu) in [
        (LatticeKind::Cubic, -0.8),
        (LatticeKind::Cubic, 0.45),
        (LatticeKind::Hex, -0.5),
        (LatticeKind::Hex, 0.9),
        (LatticeKind::Random3d, -0.8),
        (LatticeKind::Random3d, 0.45),
        (LatticeKind::Random2d, -0.5),
        (LatticeKind::Random2d, 0.9),
    ] {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), 8);
        let cut = 3.3;
        let left = |i: usize| body.lattice.pos.x()[i] < cut;
        let mut state = State::new(&body);
        let mut killed = 0;
        for (b, &[i, j]) in body.lattice.bonds.ends.iter().enumerate() {
            if left(i as usize) != left(j as usize) {
                state.kill_bond(&body, b);
                killed += 1;
            }
        }
        assert!(killed > 0);
        let mut rng = Rng::new(21);
        state.u = random_displacement(&body, &mut rng, 0.05);
        law::update_forces(&body, &mut state);
        let before = state.f.clone();
        // Move and deform the right half violently.
        let mut moved = state.clone();
        for i in (0..body.nodes()).filter(|&i| !left(i)) {
            moved.u.x_mut()[i] += 0.3 + rng.sym(0.2);
            moved.u.y_mut()[i] += rng.sym(0.2);
        }
        law::update_forces(&body, &mut moved);
        for i in (0..body.nodes()).filter(|&i| left(i)) {
            assert_eq!(
                before.get(i),
                moved.f.get(i),
                "{kind:?} nu={nu}: node {i} felt the other half"
            );
        }
        // And the total force on each half is zero on its own.
        let half_sum: Vector = (0..body.nodes())
            .filter(|&i| left(i))
            .map(|i| moved.f.get(i))
            .sum();
        assert!(half_sum.norm() < 1e-12, "{kind:?}: {half_sum:?}");
    }
}

/// After killing 50 % of the springs at random, at nu = -0.98 and nu = 0.49 (and the 2D
/// extremes), the stiffness has no negative eigenvalue: only zero modes (rigid motions and the
/// mechanisms of the damaged graph) and positive ones (`design/MODEL.md`, Cauchy-Schwarz bound).
#[test]
fn damaged_stiffness_stays_positive_semidefinite() {
    for (kind, nu, n) in [
        (LatticeKind::Cubic, -0.98, 4),
        (LatticeKind::Cubic, 0.49, 4),
        (LatticeKind::Hex, -0.98, 8),
        (LatticeKind::Hex, 0.99, 8),
        (LatticeKind::Random3d, -0.98, 4),
        (LatticeKind::Random3d, 0.48, 4),
        (LatticeKind::Random2d, 0.95, 8),
    ] {
        let body = small_body(kind, q_from_nu(kind, nu).unwrap(), n);
        for seed in 0..3 {
            let mut rng = Rng::new(100 + seed);
            let mut state = State::new(&body);
            let killed = kill_random(&body, &mut state, &mut rng, 0.5);
            assert!(killed > body.springs() / 3);
            law::update_forces(&body, &mut state);
            let k = dense_tangent(&body, &state, false);
            let asym = (&k - k.transpose()).abs().max();
            let kmax = k.abs().max();
            assert!(asym < 1e-13 * kmax, "tangent not symmetric: {asym}");
            let eig = k.symmetric_eigen().eigenvalues;
            let lmin = eig.min();
            let lmax = eig.max();
            assert!(
                lmin > -1e-12 * lmax,
                "{kind:?} nu={nu} seed {seed}: eigenvalue {lmin} (max {lmax})"
            );
        }
    }
}

/// The intact plain and dispersive lattices have exactly the rigid-body null space: 6 zero
/// eigenvalues in 3D, 3 in 2D, and the smallest non-zero one is clearly positive.
#[test]
fn intact_stiffness_has_only_rigid_zero_modes() {
    for (kind, nu, zeros) in [
        (LatticeKind::Cubic, -0.9, 6),
        (LatticeKind::Cubic, 0.45, 6),
        (LatticeKind::Hex, 0.9, 3),
        (LatticeKind::Random3d, 0.2, 6),
        (LatticeKind::Random2d, -0.5, 3),
    ] {
        let body = small_body(
            kind,
            q_from_nu(kind, nu).unwrap(),
            match kind {
                LatticeKind::Cubic => 3,
                LatticeKind::Random3d => 4,
                _ => 5,
            },
        );
        let state = State::new(&body);
        let mut eig: Vec<Real> = dense_tangent(&body, &state, false)
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .copied()
            .collect();
        eig.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let lmax = *eig.last().unwrap();
        assert!(
            eig[..zeros].iter().all(|l| l.abs() < 1e-12 * lmax),
            "{kind:?}: {:?}",
            &eig[..zeros + 1]
        );
        assert!(
            eig[zeros] > 1e-4 * lmax,
            "{kind:?}: first non-rigid eigenvalue {}",
            eig[zeros]
        );
    }
}

/// Forces, pools and energy are bit-identical for 1 and 2 threads on a body large enough to be
/// split between threads.
#[test]
fn forces_are_bit_identical_for_any_thread_count() {
    let body = small_body(
        LatticeKind::Cubic,
        q_from_nu(LatticeKind::Cubic, 0.4).unwrap(),
        20,
    );
    let mut rng = Rng::new(7);
    let mut state = State::new(&body);
    kill_random(&body, &mut state, &mut rng, 0.1);
    state.u = random_displacement(&body, &mut rng, 0.02);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = state.clone();
            law::update_forces(&body, &mut s);
            let e = law::energy(&body, &s.u, s.springs(&body), s.norm());
            (s.f, s.pool, e.direct.to_bits(), e.dispersive.to_bits())
        })
    };
    let one = run(1);
    let two = run(2);
    assert!(
        one.0 == two.0 && one.1 == two.1,
        "forces or pools differ between 1 and 2 threads"
    );
    // Energy is a parallel reduction (output only): identical here because rayon's split of an
    // indexed range does not depend on timing, but it may differ in the last bit across
    // thread counts; the hot path (forces) must not.
    let _ = (one.2, two.2, one.3, two.3);
}

/// Killing a spring updates both nodes' normalisers, and killing it twice is a no-op.
#[test]
fn kill_bond_updates_normalisers() {
    let body = small_body(LatticeKind::Cubic, 1.0, 3);
    let mut state = State::new(&body);
    let b = 0;
    let [i, j] = body.lattice.bonds.ends[b].map(|v| v as usize);
    let (si, sj) = (state.norm()[i], state.norm()[j]);
    let kl2 = body.k[b] * body.lattice.rest(b).powi(2);
    assert!(state.kill_bond(&body, b));
    assert!(
        (state.norm()[i] - (si - kl2)).abs() < 1e-12
            && (state.norm()[j] - (sj - kl2)).abs() < 1e-12
    );
    assert!(!state.kill_bond(&body, b));
}
