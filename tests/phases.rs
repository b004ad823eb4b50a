//! Bodies of several materials (`hooke_model::phases`): every kernel follows each node's own
//! dispersion ratio, the stable-step bound holds, and free vibration conserves energy.

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::kernel::Kernel;
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::phases::{assemble, Phase};
use hooke_core::random::RandomSpec;
use hooke_core::stability;
use hooke_core::{Body, Lattice, LatticeKind, Real, State};
use hooke_tests::{
    dense_tangent, kernel_forces, kill_random, random_displacement, relative_drift,
    shadow_energies, simd_from_env, Rng,
};

/// Three materials in slabs along x: an auxetic one (nu = -0.5), one at nu = 0.1 and one at
/// nu = 0.4, with stiffnesses 1 : 10 : 3 and different densities.
fn slabs(lattice: Lattice) -> Body {
    let kind = lattice.kind;
    let x = lattice.pos.x().to_vec();
    let (lo, hi) = x.iter().fold((Real::MAX, Real::MIN), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    let phase: Vec<u8> = x
        .iter()
        .map(|&v| ((3.0 * (v - lo) / (hi - lo + 1e-9)) as u8).min(2))
        .collect();
    let phases = [(-0.5, 1.0, 1.0), (0.1, 10.0, 2.5), (0.4, 3.0, 0.7)]
        .map(|(nu, k, rho)| {
            let q = q_from_nu(kind, nu).unwrap();
            Phase::of(Body::from_cells(lattice.clone(), k, q, rho)).unwrap()
        })
        .to_vec();
    assemble(lattice, phases, &phase).unwrap()
}

/// A random plate (2D) or block (3D) of unit spacing from the origin to `hi`.
fn random(dim: usize, hi: [Real; 3]) -> Lattice {
    Lattice::random(dim, [0.0; 3], hi, 1.0, 1.0, RandomSpec::default(), &|_| {
        true
    })
    .unwrap()
}

fn lattices() -> Vec<Lattice> {
    vec![
        Lattice::cubic_box([7, 6, 5], 1.0).unwrap(),
        Lattice::hex_box(12, 10, 1.0, 1.0).unwrap(),
        random(2, [10.0, 8.0, 0.0]),
        random(3, [6.0, 5.0, 4.0]),
    ]
}

/// On every lattice kind, with a fifth of the springs broken and a random displacement, every
/// kernel a body of three materials can take gives the reference law's forces to 1e-12 of the
/// largest; the row kernel gives the CSR kernel's bits (on either of its paths); and no
/// stencil takes such a body (a stencil keeps one normaliser rule for its box).
#[test]
fn kernels_follow_each_nodes_dispersion_ratio() {
    simd_from_env();
    for lattice in lattices() {
        let body = slabs(lattice);
        let kind = body.lattice.kind;
        assert!(body.q_node.is_some(), "{}", kind.name());
        let mut rng = Rng::new(5);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.2);
        state.u = random_displacement(&body, &mut rng, 0.05);
        let mut reference = state.clone();
        hooke_core::law::update_forces(&body, &mut reference);
        let fmax = (0..body.nodes())
            .map(|i| reference.f.get(i).norm())
            .fold(0.0, Real::max);
        let chosen = Kernel::for_body(&body, &state);
        assert!(!chosen.is_stencil(), "{}: {}", kind.name(), chosen.name());
        let csr = Kernel::Csr { plain: false };
        let csr_f = kernel_forces(&csr, &body, &state);
        let mut kernels = vec![chosen.clone()];
        if matches!(chosen, Kernel::Rows(_)) {
            let mut portable = chosen.clone();
            portable.set_simd(false);
            kernels.push(portable);
        }
        for i in 0..body.nodes() {
            let (a, b) = (csr_f.get(i), reference.f.get(i));
            assert!(
                (a - b).norm() <= 1e-12 * fmax,
                "{} csr: node {i}: {a:?} vs {b:?}",
                kind.name()
            );
        }
        for kernel in kernels {
            let f = kernel_forces(&kernel, &body, &state);
            let same = f
                .as_flat()
                .iter()
                .zip(csr_f.as_flat())
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{} {}: not the CSR kernel's bits",
                kind.name(),
                kernel.name()
            );
        }
    }
}

/// The stable step of a body of several materials, with springs broken: the Lanczos estimate
/// matches the dense largest eigenvalue of `M^-1/2 K M^-1/2` to 1e-6, and the damage-proof
/// bound, `(1 + 2 max(q_n, 0))` times the plain lattice's, lies above it.
#[test]
fn the_stable_step_bounds_a_body_of_several_materials() {
    simd_from_env();
    for lattice in [
        Lattice::cubic_box([5, 5, 4], 1.0).unwrap(),
        random(3, [4.0, 4.0, 3.0]),
    ] {
        let body = slabs(lattice);
        let mut rng = Rng::new(17);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.3);
        hooke_core::law::update_forces(&body, &mut state);
        let est = stability::estimate(&body, &state, &Kernel::Csr { plain: false }, 300, 1e-12);
        let eig = dense_tangent(&body, &state, true)
            .symmetric_eigen()
            .eigenvalues;
        let (dense, least) = (eig.max(), eig.min());
        let kind = body.lattice.kind.name();
        assert!(
            least > -1e-9 * dense,
            "{kind}: a negative eigenvalue {least}"
        );
        assert!(
            (est.lambda_max / dense - 1.0).abs() < 1e-6,
            "{kind}: Lanczos {} dense {dense}",
            est.lambda_max
        );
        let bound = stability::damage_bound(&body);
        assert!(
            bound >= dense,
            "{kind}: damage-proof bound {bound} below {dense}"
        );
    }
}

/// Undamped free vibration of a Ladd block of three materials from a smooth velocity field,
/// 4,000 steps at the default safety factor: the leapfrog's shadow energy (see
/// `tests/dynamics.rs`) drifts by less than 1e-4 of the energy.
#[test]
fn a_body_of_several_materials_conserves_energy() {
    simd_from_env();
    let body = slabs(Lattice::cubic_box([9, 8, 8], 1.0).unwrap());
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        let p = body.lattice.pos.get(i) / 8.0;
        let pi = std::f64::consts::PI;
        state.v.x_mut()[i] = 1e-5 * (pi * p.y).sin();
        state.v.y_mut()[i] = 1e-5 * 0.7 * (pi * p.z).cos();
        state.v.z_mut()[i] = 1e-5 * 0.4 * (pi * (p.x + p.y)).sin();
    }
    let mut it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    let b0 = it.energy(&body, &mut state);
    let e0 = b0.kinetic + b0.strain.total();
    let (shadow, _) = shadow_energies(&mut it, &body, &mut state, 400);
    let drift = relative_drift(&shadow, e0);
    let spread = shadow
        .iter()
        .fold(0.0, |m: Real, &h| m.max((h - e0).abs() / e0));
    eprintln!(
        "three materials: shadow-energy drift {drift:.2e}, spread {spread:.2e}, dt {}",
        it.dt()
    );
    assert!(drift < 1e-4, "energy drift {drift:.3e}");
    assert!(
        spread < 1e-3,
        "shadow energy strays {spread:.3e} from the start's"
    );
    assert!(e0 > 0.0 && LatticeKind::Cubic == body.lattice.kind);
}
