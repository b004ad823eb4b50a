//! Explicit dynamics against theory: energy conservation, wave speeds, momentum, the stable
//! step, the energy ledger, reproducibility across thread counts and kernels.

use hooke_core::dynamics::{angular_momentum, momentum, Integrator, IntegratorOptions, TimeStep};
use hooke_core::kernel::Kernel;
use hooke_core::loading::{Load, Loading, Motion, Prescribed, TimeFunction};
use hooke_core::material::{q_from_nu, shear_from_k};
use hooke_core::relax::{relax, RelaxOptions};
use hooke_core::stability;
use hooke_core::statics::{self, Constraints, StaticOptions};
use hooke_core::{Body, Coords, Error, Lattice, LatticeKind, Real, State, Tangent, Vector};
use hooke_tests::{
    dofs, kernel_forces, kill_random, random_displacement, relative_drift, shadow_energies,
    simd_from_env, Rng,
};
use nalgebra::DMatrix;

fn cube(n: usize, nu: Real) -> Body {
    Body::uniform(
        Lattice::cubic_box([n, n, n], 1.0).unwrap(),
        1.0,
        q_from_nu(LatticeKind::Cubic, nu).unwrap(),
        1.0,
    )
}

/// A smooth deformation: the body starts from rest in it and vibrates freely.
fn smooth_field(body: &Body, amp: Real) -> Coords {
    let mut u = Coords::zeros(body.nodes());
    let l = body.lattice.spacing * (body.lattice.grid.unwrap()[0] - 1) as Real;
    for i in 0..body.nodes() {
        let p = body.lattice.pos.get(i) / l;
        let pi = std::f64::consts::PI;
        u.x_mut()[i] = amp * ((pi * p.y).sin() + 0.5 * (2.0 * pi * p.x).cos());
        u.y_mut()[i] = amp * (0.7 * (pi * p.z).cos() - 0.3 * (pi * p.x).sin());
        if body.lattice.dim() == 3 {
            u.z_mut()[i] = amp * 0.4 * (pi * (p.x + p.y)).sin();
        }
    }
    u
}

/// Undamped free vibration over 10^4 steps at the default safety factor.
///
/// Drift: leapfrog exactly conserves the shadow energy `H = 1/2 sum m v(t-dt/2).v(t+dt/2) +
/// U(u(t))` of a linear system (and to O(dt^2), without secular change, of a nonlinear one). Its
/// least-squares trend over the run must stay below 1e-4 of the energy.
///
/// Oscillation: the ordinary energy `K + U` (with the full-step velocity) oscillates about its
/// mean with a half-range of at most `(omega dt)^2 / 8`, omega the energy-weighted frequency of
/// the motion; for a start from the rest position with velocity v, `omega^2 = v.K.v / v.M.v`.
/// The body starts undeformed with a smooth velocity field, so no surface tractions kick the
/// highest modes.

#[test]
fn free_vibration_conserves_energy() {
    simd_from_env();
    for nu in [-0.9, 0.25, 0.45] {
        let body = cube(10, nu);
        let mut state = State::new(&body);
        state.v = smooth_field(&body, 1e-5);
        let mut tangent = Tangent::new(&body, &State::new(&body));
        let mut kv = Coords::zeros(body.nodes());
        tangent.apply(&body, &state.v, &mut kv);
        let vmv: Real = (0..body.nodes())
            .map(|i| body.mass[i] * state.v.get(i).norm_squared())
            .sum();
        let omega2 = state.v.dot(&kv) / vmv;
        let mut it = Integrator::new(
            &body,
            &mut state,
            Loading::default(),
            &IntegratorOptions::default(),
        )
        .unwrap();
        assert!(matches!(it.kernel(), Kernel::Cubic(_)));
        let b0 = it.energy(&body, &mut state);
        let e0 = b0.kinetic + b0.strain.total();
        let (shadow, energies) = shadow_energies(&mut it, &body, &mut state, 1000);
        let n = shadow.len() as Real;
        let drift = relative_drift(&shadow, e0);
        let (lo, hi) = energies
            .iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), &e| {
                (lo.min(e), hi.max(e))
            });
        let mean = energies.iter().sum::<Real>() / n;
        let half_range = 0.5 * (hi - lo) / mean;
        let bound = omega2 * it.dt() * it.dt() / 8.0;
        eprintln!("nu={nu}: shadow-energy drift {drift:.2e} over 10^4 steps; K+U half-range {half_range:.2e} vs (omega dt)^2/8 = {bound:.2e}; dt = {:.4}", it.dt());
        assert!(drift < 1e-4, "nu={nu}: energy drift {drift:.3e}");
        assert!(
            half_range < bound,
            "nu={nu}: oscillation {half_range:.3e} above (omega dt)^2/8 = {bound:.3e}"
        );
        assert!(half_range > 0.1 * bound, "nu={nu}: oscillation {half_range:.3e} far below the estimate: the test measures nothing");
    }
}

/// Peak position of a pulse along a line of nodes within `window` (parabola through the
/// maximum). The window keeps the pulse reflected off the far end out of the search.
fn peak(xs: &[Real], us: &[Real], window: (Real, Real)) -> Real {
    let (k, _) = us
        .iter()
        .enumerate()
        .filter(|&(k, _)| xs[k] > window.0 && xs[k] < window.1)
        .max_by(|a, b| a.1.partial_cmp(b.1).unwrap())
        .unwrap();
    let (y0, y1, y2) = (us[k - 1], us[k], us[k + 1]);
    let h = xs[k + 1] - xs[k];
    xs[k] + 0.5 * h * (y0 - y2) / (y0 - 2.0 * y1 + y2)
}

/// Speed of a plane pulse (polarisation `axis`) along x in a bar that is periodic across.
fn pulse_speed(kind: LatticeKind, nu: Real, axis: usize, c_guess: Real) -> Real {
    let nx = 300;
    let lattice = match kind {
        LatticeKind::Cubic => Lattice::cubic_box_periodic([nx, 4, 4], 1.0, [false, true, true]),
        LatticeKind::Hex => Lattice::hex_box_periodic(nx, 4, 1.0, 1.0, [false, true]),
        _ => unreachable!("periodic pulses run on the regular lattices"),
    }
    .unwrap();
    let body = Body::uniform(lattice, 1.0, q_from_nu(kind, nu).unwrap(), 1.0);
    let mut state = State::new(&body);
    let (x0, sigma) = (60.0, 6.0);
    for i in 0..body.nodes() {
        let x = body.lattice.pos.x()[i];
        state.u.comp_mut(axis)[i] = 1e-4 * (-(x - x0) * (x - x0) / (2.0 * sigma * sigma)).exp();
    }
    let mut it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    let line: Vec<usize> = (0..nx).collect(); // the first row: y = 0 (and z = 0)
    let xs: Vec<Real> = line.iter().map(|&i| body.lattice.pos.x()[i]).collect();
    let record = |t_target: Real, it: &mut Integrator, state: &mut State| {
        while state.time + 0.5 * it.dt() < t_target {
            it.step(&body, state);
        }
        let us: Vec<Real> = line.iter().map(|&i| state.u.comp(axis)[i]).collect();
        let expected = x0 + c_guess * state.time;
        (
            state.time,
            peak(&xs, &us, (expected - 30.0, expected + 30.0)),
        )
    };
    let (t1, p1) = record(40.0 / c_guess, &mut it, &mut state);
    let (t2, p2) = record(160.0 / c_guess, &mut it, &mut state);
    (p2 - p1) / (t2 - t1)
}

/// Longitudinal and shear pulses travel at c_L = sqrt((lambda + 2 mu)/rho) and
/// c_T = sqrt(mu/rho) within 2 % (plane waves: the bar is periodic across, so these are the
/// bulk speeds, not the bar speed sqrt(E/rho)), 3D and 2D, nu in {-0.5, 0.25, 0.45}.
#[test]
fn pulses_travel_at_the_continuum_wave_speeds() {
    simd_from_env();
    for kind in [LatticeKind::Cubic, LatticeKind::Hex] {
        for nu in [-0.5, 0.25, 0.45] {
            let q = q_from_nu(kind, nu).unwrap();
            let mu = shear_from_k(kind, 1.0, 1.0);
            let (lambda, rho) = match kind {
                LatticeKind::Cubic => (mu * (1.0 + 10.0 * q / 3.0), 1.0),
                LatticeKind::Hex => (mu * (1.0 + 4.0 * q), 1.0 / (3f64.sqrt() / 2.0)),
                _ => unreachable!(),
            };
            let c_l = ((lambda + 2.0 * mu) / rho).sqrt();
            let c_t = (mu / rho).sqrt();
            let long = pulse_speed(kind, nu, 0, c_l);
            let shear = pulse_speed(kind, nu, 1, c_t);
            eprintln!("{kind:?} nu={nu}: c_L {long:.5} (theory {c_l:.5}), c_T {shear:.5} (theory {c_t:.5})");
            assert!(
                (long / c_l - 1.0).abs() < 0.02,
                "{kind:?} nu={nu}: c_L measured {long}, theory {c_l}"
            );
            assert!(
                (shear / c_t - 1.0).abs() < 0.02,
                "{kind:?} nu={nu}: c_T measured {shear}, theory {c_t}"
            );
        }
    }
}

/// A free body keeps its linear momentum `sum m v` and its angular momentum
/// `sum m x(t) x v(t - dt/2)` (leapfrog's exact invariant for central forces) to round-off,
/// with damaged springs, on both kernels.
#[test]
fn free_body_conserves_momentum() {
    simd_from_env();
    for force_csr in [false, true] {
        let body = cube(7, 0.4);
        let mut rng = Rng::new(3);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.2);
        state.u = random_displacement(&body, &mut rng, 0.02);
        state.v = random_displacement(&body, &mut rng, 0.05);
        let opts = IntegratorOptions {
            force_csr,
            ..Default::default()
        };
        let mut it = Integrator::new(&body, &mut state, Loading::default(), &opts).unwrap();
        let p0 = momentum(&body, &state.v);
        let j0 = angular_momentum(&body, &state, &state.v);
        let scale: Real = (0..body.nodes())
            .map(|i| body.mass[i] * state.v.get(i).norm())
            .sum();
        it.run(&body, &mut state, 500).unwrap();
        let p1 = momentum(&body, &state.v);
        let j1 = angular_momentum(&body, &state, &state.v);
        assert!(
            (p1 - p0).norm() < 1e-13 * scale,
            "kernel {}: momentum changed by {:e}",
            it.kernel().name(),
            (p1 - p0).norm()
        );
        assert!(
            (j1 - j0).norm() < 1e-12 * scale * 7.0,
            "kernel {}: angular momentum changed by {:e}",
            it.kernel().name(),
            (j1 - j0).norm()
        );
    }
}

fn run_with_threads(threads: usize, force_csr: bool, portable: bool) -> State {
    run_body_with_threads(&|| cube(24, 0.45), threads, force_csr, portable)
}

/// A 60 x 50 hexagonal plate (its stencil: rows of 60 hold vector blocks and scalar tails) at
/// nu_2D = 0.45.
fn hex_plate() -> Body {
    let lat = Lattice::hex_box(60, 50, 1.0, 1.0).unwrap();
    Body::uniform(lat, 1.0, q_from_nu(LatticeKind::Hex, 0.45).unwrap(), 1.0)
}

/// 40 steps of `body()` with 5 % of its springs broken, a random displacement, damping and a
/// body force (along -z in 3D, in the plane for a plate), on `threads` threads.
fn run_body_with_threads(
    body: &(dyn Fn() -> Body + Send + Sync),
    threads: usize,
    force_csr: bool,
    portable: bool,
) -> State {
    run_body(body, threads, force_csr, portable, false)
}

/// [`run_body_with_threads`], and with `avx2` on the AVX2 vector path (where the processor has
/// AVX-512 too).
fn run_body(
    body: &(dyn Fn() -> Body + Send + Sync),
    threads: usize,
    force_csr: bool,
    portable: bool,
    avx2: bool,
) -> State {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let body = body();
        let mut rng = Rng::new(9);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.05);
        state.u = random_displacement(&body, &mut rng, 1e-3);
        let loading = Loading {
            body_acceleration: if body.lattice.dim() == 3 {
                Vector::new(0.0, 0.0, -1e-4)
            } else {
                Vector::new(0.0, -1e-4, 0.0)
            },
            ..Default::default()
        };
        let opts = IntegratorOptions {
            damping: 0.01,
            force_csr,
            portable,
            ..Default::default()
        };
        let mut it = Integrator::new(&body, &mut state, loading, &opts).unwrap();
        assert_eq!(it.kernel().is_stencil(), !force_csr);
        if avx2 {
            assert!(it.use_avx2(), "{}", it.kernel().name());
        }
        it.run(&body, &mut state, 40).unwrap();
        let e = it.ledger();
        state.time = e.dissipated + e.body_work; // fold the reductions into the comparison
        state
    })
}

/// The whole state after 40 steps (with damping and a body force, so that the reductions are
/// exercised) is bit-identical for 1 and 2 threads, on every kernel.
#[test]
fn runs_are_bit_identical_for_any_thread_count() {
    simd_from_env();
    for (csr, portable) in [(false, false), (false, true), (true, false)] {
        let one = run_with_threads(1, csr, portable);
        let two = run_with_threads(2, csr, portable);
        assert!(
            one.u == two.u && one.v == two.v,
            "csr={csr} portable={portable}: states differ"
        );
        assert_eq!(
            one.time.to_bits(),
            two.time.to_bits(),
            "csr={csr}: energy sums differ"
        );
    }
}

/// Each stencil's vector path performs its portable path's operations lane by lane, so a
/// damaged, deformed body reaches the same bits on either path and any thread count (which node
/// takes which path depends on where the chunks and rows begin); a plate's z components stay
/// exact zeros; and the hexagonal stencil integrates the CSR kernel's motion to round-off (the
/// same law; its reference vectors and rest lengths are the lattice's to round-off).
///
/// Cell-weighted bodies (their face and edge springs at a half or a quarter of the bulk
/// stiffness) run on the stencils too, with the same guarantees.
#[test]
fn stencil_paths_and_thread_counts_give_the_same_bits() {
    simd_from_env();
    let cube24 = || cube(24, 0.45);
    let weighted_cube = || cube(24, 0.45).with_cell_weights().unwrap();
    let weighted_plate = || hex_plate().with_cell_weights().unwrap();
    let bodies: [&(dyn Fn() -> Body + Send + Sync); 4] =
        [&hex_plate, &cube24, &weighted_cube, &weighted_plate];
    for body in bodies {
        let vector = run_body_with_threads(body, 1, false, false);
        for (threads, portable) in [(2, false), (1, true), (2, true)] {
            let s = run_body_with_threads(body, threads, false, portable);
            assert!(
                s.u == vector.u && s.v == vector.v,
                "threads {threads}, portable {portable}: states differ"
            );
            assert_eq!(s.time.to_bits(), vector.time.to_bits());
        }
        // Where the widest path is AVX-512, the AVX2 path too.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx2")
            && hooke_core::kernel::simd() != hooke_core::kernel::Simd::Portable
        {
            let s = run_body(body, 2, false, false, true);
            assert!(s.u == vector.u && s.v == vector.v, "AVX2: states differ");
            assert_eq!(s.time.to_bits(), vector.time.to_bits());
        }
    }
    let vector = run_body_with_threads(&hex_plate, 1, false, false);
    assert!(vector.u.z().iter().chain(vector.v.z()).all(|&z| z == 0.0));
    let csr = run_body_with_threads(&hex_plate, 2, true, false);
    let size = vector
        .u
        .as_flat()
        .iter()
        .fold(0.0 as Real, |m, v| m.max(v.abs()));
    let diff = vector
        .u
        .as_flat()
        .iter()
        .zip(csr.u.as_flat())
        .fold(0.0 as Real, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        diff < 1e-12 * size,
        "stencil against CSR: {diff:e} of {size:e}"
    );
}

/// A box of one stiffness runs on its stencil without its rows and ends or a stiffness per
/// spring (issue 15: on Ladd's lattice 146 + 71 bytes per node it does not hold), and reaches
/// the same bits as the same body with both stored: the normalisers, the stable step (its
/// Lanczos sweeps and the damage bound), 30 steps of motion and the energy. A spacing whose
/// multiples round makes the rest lengths of one direction differ in their last bits from node
/// to node. A Ladd block, a hexagonal plate, and a Ladd block weighted by its cubes (what a
/// case file's box is by default), against the same block weighted through its built rows:
/// its face, edge and corner springs and nodes stand for 1/2, 1/4 and 1/8 of the bulk's.
#[test]
fn a_box_of_one_stiffness_runs_without_its_rows_or_stiffnesses() {
    simd_from_env();
    let stored = |lean: &Body| {
        let mut stored = lean.clone();
        // Changed through `DerefMut`, both are stored for good.
        let _ = &mut *stored.lattice.bonds;
        stored.k = stored.k.to_vec().into();
        stored
    };
    let cubic = || Lattice::cubic_box([11, 9, 14], 0.1).unwrap();
    let hex = Body::uniform(Lattice::hex_box(23, 17, 0.1, 0.2).unwrap(), 3.0, 0.3, 2.0);
    let block = Body::uniform(cubic(), 3.0, 0.3, 2.0);
    let weighted = block.clone().with_cell_weights().unwrap();
    // Weighted through the rows: the lattice built first, each spring's fraction from them.
    let mut built = cubic();
    let _ = &mut *built.bonds;
    let weighted_built = Body::uniform(built, 3.0, 0.3, 2.0)
        .with_cell_weights()
        .unwrap();
    assert!(weighted.k.rule().is_some() && weighted.k.bytes() == 0);
    assert!(weighted_built.k.rule().is_none());
    for (lean, stored) in [
        (block.clone(), stored(&block)),
        (hex.clone(), stored(&hex)),
        (weighted, weighted_built),
    ] {
        assert!(stored.lattice.bonds.grid().is_none() && stored.k.rule().is_none());
        let run = |body: &Body, lean: bool| {
            let mut state = State::new(body);
            state.v = smooth_field(body, 1e-3);
            // One end pulled: the step computes its nodes' forces by the law (from the grid).
            let loading = Loading {
                prescribed: vec![pulled(x_end(body, true))],
                ..Default::default()
            };
            let mut it =
                Integrator::new(body, &mut state, loading, &IntegratorOptions::default()).unwrap();
            assert!(matches!(it.kernel(), Kernel::Cubic(_) | Kernel::Hex(_)));
            it.run(body, &mut state, 30).unwrap();
            // A frame reads the grid and the rule too (`law::frame_fields_grid`).
            let (v, balance, fields) = it.frame_view(body, &mut state, true);
            it.run(body, &mut state, 5).unwrap();
            assert!(
                !lean || (!body.lattice.bonds.is_built() && body.k.bytes() == 0),
                "the run or its frame built the rows or the stiffnesses"
            );
            let frame: Vec<u64> = [v.as_flat(), fields.stress.as_flattened()]
                .concat()
                .iter()
                .chain(&fields.energy_density)
                .map(|x| x.to_bits())
                .collect();
            // The energy at a run's end reads the grid too; the reference law builds both.
            let e = it.energy(body, &mut state);
            assert!(!lean || !body.lattice.bonds.is_built());
            let reference =
                hooke_core::law::energy(body, &state.u, state.springs(body), state.norm());
            assert_eq!(e.strain, reference);
            (
                state,
                it.dt(),
                e.kinetic + e.strain.total(),
                (frame, balance),
            )
        };
        let (a, dt_a, e_a, frame_a) = run(&lean, true);
        let (b, dt_b, e_b, frame_b) = run(&stored, false);
        assert!(a == b, "{:?}: states differ", lean.lattice.kind);
        assert!(frame_a == frame_b, "{:?}: frames differ", lean.lattice.kind);
        assert_eq!(dt_a.to_bits(), dt_b.to_bits());
        assert_eq!(e_a.to_bits(), e_b.to_bits());
        assert_eq!(
            stability::damage_bound(&lean).to_bits(),
            stability::damage_bound(&stored).to_bits()
        );
        assert!(a.u.as_flat().iter().any(|&x| x != 0.0), "the body moved");
        // The stiffnesses a rule fills (for the energy above) and the masses are the stored
        // ones, bit for bit.
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&lean.k), bits(&stored.k));
        assert_eq!(bits(&lean.mass), bits(&stored.mass));
    }
}

/// The stencil kernels (vector and portable) and the CSR kernel integrate the same motion: after
/// 40 steps on a damaged, deformed block the displacements agree to 1e-9 of their size. (They
/// are not bit-identical: the stencil forms the extension as `l - L`, the CSR kernel in its
/// cancellation-free form, a difference of about 1e-13 of dL per step at these strains.)
#[test]
fn kernels_agree() {
    simd_from_env();
    let csr = run_with_threads(2, true, false);
    let umax = csr
        .u
        .x()
        .iter()
        .chain(csr.u.y())
        .chain(csr.u.z())
        .fold(0.0 as Real, |m, v| m.max(v.abs()));
    for portable in [false, true] {
        let s = run_with_threads(2, false, portable);
        let mut d = s.u.clone();
        d.axpy(-1.0, &csr.u);
        let dmax = d
            .x()
            .iter()
            .chain(d.y())
            .chain(d.z())
            .fold(0.0 as Real, |m, v| m.max(v.abs()));
        assert!(
            dmax < 1e-9 * umax,
            "portable={portable}: max difference {dmax:e} of {umax:e}"
        );
    }
}

/// The Lanczos estimate of lambda_max(M^-1 K) matches a dense eigensolver on a damaged body with
/// unequal masses, and the damage-proof bound lies above it.
#[test]
fn stable_step_estimate_matches_dense_eigenvalues() {
    simd_from_env();
    for nu in [-0.9, 0.25, 0.49] {
        let mut body = cube(5, nu);
        let mut rng = Rng::new(17);
        for m in body.mass.iter_mut() {
            *m = 0.5 + rng.uniform();
        }
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.3);
        hooke_core::law::update_forces(&body, &mut state);
        let est = stability::estimate(&body, &state, &Kernel::Csr { plain: false }, 200, 1e-12);
        let d = dofs(&body);
        let mut t = Tangent::new(&body, &state);
        let mut k = DMatrix::zeros(d.len(), d.len());
        let (mut v, mut kv) = (Coords::zeros(body.nodes()), Coords::zeros(body.nodes()));
        for (col, &(i, c)) in d.iter().enumerate() {
            v.fill_zero();
            v.comp_mut(c)[i] = 1.0 / body.mass[i].sqrt();
            t.apply(&body, &v, &mut kv);
            for (row, &(j, r)) in d.iter().enumerate() {
                k[(row, col)] = kv.comp(r)[j] / body.mass[j].sqrt();
            }
        }
        let dense = k.symmetric_eigen().eigenvalues.max();
        assert!(
            (est.lambda_max / dense - 1.0).abs() < 1e-6,
            "nu={nu}: Lanczos {} dense {dense}",
            est.lambda_max
        );
        assert!(
            est.lambda_bound >= dense,
            "nu={nu}: bound {} below {dense}",
            est.lambda_bound
        );
    }
    // The plain Ladd lattice: lambda_max <= 12 k/m (MODEL.md), approached in a large block.
    let body = cube(12, 0.25);
    let mut state = State::new(&body);
    hooke_core::law::update_forces(&body, &mut state);
    let est = stability::estimate(&body, &state, &Kernel::for_body(&body, &state), 200, 1e-9);
    assert!(
        est.lambda_max <= 12.0 * (1.0 + 1e-9) && est.lambda_max > 11.0,
        "plain: {}",
        est.lambda_max
    );
}

/// The estimate runs its force sweeps in the state it is given and hands the displacements and
/// velocities back bit for bit: at rest (where it keeps no copy of them, signed zeros included)
/// and in motion.
#[test]
fn stable_step_estimate_gives_the_state_back() {
    simd_from_env();
    let body = cube(6, 0.3);
    let kernel = Kernel::for_body(&body, &State::new(&body));
    let mut moving = State::new(&body);
    moving.u = smooth_field(&body, 1e-3);
    moving.v = smooth_field(&body, 2.0);
    let mut signed = State::new(&body);
    signed.v.x_mut()[3] = -0.0;
    signed.u.y_mut()[5] = -0.0;
    // Forces left from an evaluation: the estimate cannot use their array.
    let mut forced = State::new(&body);
    forced.f = smooth_field(&body, 5.0);
    let mut at_rest = Vec::new();
    for state in [State::new(&body), moving, signed, forced] {
        let mut s = state.clone();
        let est = stability::estimate_in(&body, &mut s, &kernel, 40, 1e-3);
        assert!(est.lambda_max > 0.0);
        let bits = |c: &Coords| c.as_flat().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&s.u), bits(&state.u));
        assert_eq!(bits(&s.v), bits(&state.v));
        assert_eq!(bits(&s.f), bits(&state.f));
        // The same estimate from a copy.
        let again = stability::estimate(&body, &state, &kernel, 40, 1e-3);
        assert_eq!(again.lambda_max.to_bits(), est.lambda_max.to_bits());
        if state.u.as_flat().iter().all(|&x| x == 0.0) {
            at_rest.push(est.lambda_max.to_bits());
        }
    }
    // At rest, whether the base force is found to be zero (a fresh state, whose force array
    // then serves as a Lanczos vector; one with forces left, whose array does not) or kept in the
    // force array (a signed zero displacement, not taken for rest): the same bits.
    assert_eq!(at_rest.len(), 3);
    assert!(at_rest.iter().all(|&e| e == at_rest[0]), "{at_rest:?}");
    // The same bits for any thread count, on a body of several parallel blocks.
    let big = cube(28, 0.3);
    let mut state = State::new(&big);
    state.v = smooth_field(&big, 2.0);
    let kernel = Kernel::for_body(&big, &state);
    let est: Vec<u64> = [1, 2, 3]
        .map(|threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| stability::estimate(&big, &state, &kernel, 40, 1e-3))
                .lambda_max
                .to_bits()
        })
        .to_vec();
    assert!(est.iter().all(|&e| e == est[0]), "{est:?}");
}

/// A time step above the limit is refused with the limit in the message; forced, the run blows
/// up and the error names the step and the node.
#[test]
fn unstable_time_steps_are_refused_or_reported() {
    simd_from_env();
    let body = cube(6, 0.3);
    let mut state = State::new(&body);
    state.u = smooth_field(&body, 1e-3);
    let auto = Integrator::new(
        &body,
        &mut state.clone(),
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    let limit = auto.stable().dt_critical;
    let too_big = IntegratorOptions {
        time_step: TimeStep::Fixed {
            dt: 1.2 * limit,
            force: false,
        },
        ..Default::default()
    };
    let e = Integrator::new(&body, &mut state.clone(), Loading::default(), &too_big).unwrap_err();
    assert!(
        matches!(e, Error::TimeStepTooLarge { .. }) && e.is_input_error(),
        "{e}"
    );
    assert!(e.to_string().contains(&format!("{limit:.4e}")), "{e}");
    let forced = IntegratorOptions {
        time_step: TimeStep::Fixed {
            dt: 1.2 * limit,
            force: true,
        },
        ..Default::default()
    };
    let mut it = Integrator::new(&body, &mut state, Loading::default(), &forced).unwrap();
    let e = it.run(&body, &mut state, 100_000).unwrap_err();
    match &e {
        Error::Unstable { step, node, .. } => assert!(*step > 0 && *node < body.nodes()),
        other => panic!("expected an instability, got {other}"),
    }
    assert!(
        e.to_string().contains("step") && e.to_string().contains("node"),
        "{e}"
    );
}

/// `nodes` pulled along x at a velocity ramped from 0 to 1e-3 over 20 time units.
fn pulled(nodes: Vec<u32>) -> Prescribed {
    Prescribed {
        nodes,
        axis: 0,
        motion: Motion::Velocity(TimeFunction::Ramp {
            t0: 0.0,
            t1: 20.0,
            from: 0.0,
            to: 1e-3,
        }),
    }
}

fn x_end(body: &Body, right: bool) -> Vec<u32> {
    let xmax = body.lattice.pos.x().iter().cloned().fold(0.0, Real::max);
    (0..body.nodes() as u32)
        .filter(|&i| {
            (body.lattice.pos.x()[i as usize] - if right { xmax } else { 0.0 }).abs() < 1e-9
        })
        .collect()
}

/// The energy ledger balances: kinetic + strain = initial + external work + boundary work +
/// body-force work - damping dissipation, for each kind of loading, at every check. The error is
/// velocity Verlet's O(dt^2): halving dt divides it by about 4 (unless it is at round-off
/// already). At the default step it stays below 5e-3 of the largest figure of the run, the size
/// of the energy oscillation (omega dt)^2/8 of the modes these loadings excite (see
/// `free_vibration_conserves_energy`); quasi-static loadings stay far below (1e-8 to 2e-5). A table
/// with kinks, or a motion that starts with a jump in velocity, moves nodes impulsively: the
/// midpoint bookkeeping then carries a one-off error of the order of the jerked nodes' kinetic
/// energy, which does not grow; smooth ramps avoid it.
#[test]
fn energy_balance_holds_with_loads_supports_and_damping() {
    simd_from_env();
    let body = Body::uniform(
        Lattice::cubic_box([20, 5, 5], 1.0).unwrap(),
        1.0,
        q_from_nu(LatticeKind::Cubic, 0.4).unwrap(),
        1.0,
    );
    let (left, right) = (x_end(&body, false), x_end(&body, true));
    let fixed_left = |axis| Prescribed {
        nodes: left.clone(),
        axis,
        motion: Motion::Fixed,
    };
    // (name, loading, damping, initial velocity)
    let cases: Vec<(&str, Loading, Real, Option<Coords>)> = vec![
        (
            "pulled end (prescribed velocity)",
            Loading {
                prescribed: vec![
                    fixed_left(0),
                    fixed_left(1),
                    fixed_left(2),
                    pulled(right.clone()),
                ],
                ..Default::default()
            },
            0.0,
            None,
        ),
        (
            "prescribed displacement, smooth ramp",
            Loading {
                prescribed: vec![
                    fixed_left(0),
                    Prescribed {
                        nodes: right.clone(),
                        axis: 1,
                        motion: Motion::Displacement(TimeFunction::SmoothRamp {
                            t0: 0.0,
                            t1: 60.0,
                            from: 0.0,
                            to: 2e-3,
                        }),
                    },
                ],
                ..Default::default()
            },
            0.0,
            None,
        ),
        (
            "end load with gravity and a support",
            Loading {
                prescribed: vec![fixed_left(0), fixed_left(1), fixed_left(2)],
                loads: vec![Load {
                    nodes: right.clone(),
                    force: Vector::new(1e-4, 0.0, -2e-4),
                    scale: TimeFunction::Ramp {
                        t0: 0.0,
                        t1: 10.0,
                        from: 0.0,
                        to: 1.0,
                    },
                }],
                body_acceleration: Vector::new(0.0, 0.0, -1e-5),
            },
            0.0,
            None,
        ),
        // Loads on supported nodes too (two loads on each of them): the supports' reactions
        // must take exactly those loads out.
        (
            "loads on the supports as well",
            Loading {
                prescribed: vec![fixed_left(0), fixed_left(2)],
                loads: vec![
                    Load {
                        nodes: right.clone(),
                        force: Vector::new(1e-4, 0.0, -2e-4),
                        scale: TimeFunction::Constant(1.0),
                    },
                    Load {
                        nodes: left.clone(),
                        force: Vector::new(-3e-4, 1e-4, 5e-5),
                        scale: TimeFunction::Constant(1.0),
                    },
                    Load {
                        nodes: left.clone(),
                        force: Vector::new(1e-4, 0.0, -1e-4),
                        scale: TimeFunction::Constant(1.0),
                    },
                ],
                body_acceleration: Vector::zeros(),
            },
            0.0,
            None,
        ),
        // Starts undeformed with a smooth velocity: an initial displacement that is not traction
        // free at the faces would kick the highest modes (omega dt ~ 1.6), where velocity
        // Verlet's O(dt^2) energy error is tens of percent.
        (
            "damped free vibration",
            Loading::default(),
            0.05,
            Some(smooth_field(&body, 1e-3)),
        ),
    ];
    for (name, loading, damping, u0) in cases {
        // Run to the same end time at the default step and at half of it.
        let run = |safety: Real| {
            let mut state = State::new(&body);
            if let Some(v) = &u0 {
                state.v = v.clone();
            }
            let opts = IntegratorOptions {
                damping,
                time_step: TimeStep::Auto { safety },
                ..Default::default()
            };
            let mut it = Integrator::new(&body, &mut state, loading.clone(), &opts).unwrap();
            let end = 2000.0 * it.stable().dt_critical * 0.8;
            let checks = 40;
            // The worst imbalance at any check, over the largest energy figure of the run.
            let (mut worst_error, mut scale): (Real, Real) = (0.0, 0.0);
            for k in 1..=checks {
                while state.time < end * k as Real / checks as Real - 1e-9 * end {
                    it.step(&body, &mut state);
                }
                let b = it.energy(&body, &mut state);
                worst_error = worst_error.max(b.error.abs());
                scale = scale.max(b.error.abs() / b.relative_error.max(1e-300));
            }
            let b = it.energy(&body, &mut state);
            (worst_error / scale, b)
        };
        let (coarse, b) = run(0.8);
        let (fine, _) = run(0.4);
        eprintln!("{name}: worst relative balance error {coarse:.2e} at the default step, {fine:.2e} at half of it");
        let l = b.ledger;
        let activity =
            l.external_work.abs() + l.boundary_work.abs() + l.body_work.abs() + l.dissipated;
        assert!(
            activity > 0.0 && b.kinetic + b.strain.total() > 0.0,
            "{name}: nothing happened"
        );
        assert!(coarse < 5e-3, "{name}: balance error {coarse:.3e}");
        assert!(
            coarse < 1e-7 || fine / coarse < 0.35,
            "{name}: not second order: {coarse:.3e} -> {fine:.3e}"
        );
    }
}

/// Adaptive dynamic relaxation reaches the same equilibrium as Newton-CG.
#[test]
fn dynamic_relaxation_matches_the_static_solver() {
    simd_from_env();
    let body = Body::uniform(
        Lattice::cubic_box([12, 4, 4], 1.0).unwrap(),
        1.0,
        q_from_nu(LatticeKind::Cubic, -0.3).unwrap(),
        1.0,
    );
    let mut cons = Constraints::all_free(body.nodes());
    let mut start = State::new(&body);
    for i in x_end(&body, false) {
        for c in 0..3 {
            cons.fix(i as usize, c);
        }
    }
    for i in x_end(&body, true) {
        cons.fix(i as usize, 0);
        cons.fix(i as usize, 1);
        start.u.x_mut()[i as usize] = 1e-3;
        start.u.y_mut()[i as usize] = 5e-4;
    }
    let mut newton = start.clone();
    statics::solve(
        &body,
        &mut newton,
        &cons,
        None,
        &StaticOptions {
            tolerance: 1e-11,
            ..Default::default()
        },
    )
    .unwrap();
    let mut adr = start.clone();
    let report = relax(
        &body,
        &mut adr,
        &cons,
        None,
        &RelaxOptions {
            tolerance: 1e-9,
            max_iterations: 200_000,
            reference_force: None,
        },
    )
    .unwrap();
    let mut d = adr.u.clone();
    d.axpy(-1.0, &newton.u);
    eprintln!(
        "ADR: {} iterations, |u_adr - u_newton| / |u| = {:.2e}",
        report.iterations,
        d.norm() / newton.u.norm()
    );
    assert!(
        d.norm() < 1e-6 * newton.u.norm(),
        "ADR and Newton differ by {}",
        d.norm() / newton.u.norm()
    );
}

/// Breaking springs keeps the state and the stencil kernel consistent whoever breaks them:
/// through `Integrator::break_spring` (what fracture does), or by a caller's `State::kill_bond`
/// between steps, which the integrator notices and follows. Both give, bit for bit, the run of
/// the CSR kernel (which reads the springs' flags directly) to round-off.
#[test]
fn springs_broken_between_steps_reach_the_kernel() {
    simd_from_env();
    let body = cube(9, 0.3);
    let mut rng = Rng::new(11);
    let mut start = State::new(&body);
    start.u = random_displacement(&body, &mut rng, 0.02);
    let victims: Vec<usize> = (0..body.springs()).step_by(13).collect();
    let run = |how: u8| {
        let mut state = start.clone();
        let opts = IntegratorOptions {
            force_csr: how == 2,
            ..Default::default()
        };
        let mut it = Integrator::new(&body, &mut state, Loading::default(), &opts).unwrap();
        assert_eq!(it.kernel().name() == "csr", how == 2);
        for k in 0..60 {
            if k == 20 {
                for &b in &victims {
                    match how {
                        0 => {
                            it.break_spring(&body, &mut state, b);
                        }
                        _ => {
                            state.kill_bond(&body, b);
                        }
                    }
                }
            }
            it.step(&body, &mut state);
        }
        state
    };
    let (through_integrator, by_caller, csr) = (run(0), run(1), run(2));
    assert!(
        through_integrator == by_caller,
        "a caller's kill_bond did not reach the kernel"
    );
    let diff = (0..body.nodes())
        .map(|i| (through_integrator.u.get(i) - csr.u.get(i)).norm())
        .fold(0.0, Real::max);
    let size = (0..body.nodes())
        .map(|i| csr.u.get(i).norm())
        .fold(0.0, Real::max);
    // The kernels sum in different orders: round-off, grown over 60 steps (measured 2.5e-10).
    assert!(
        diff <= 1e-8 * size,
        "stencil and CSR kernels differ by {diff:e} of {size:e}"
    );
}

/// Every kernel's forces against the reference law (`law::node_force`), on every lattice kind,
/// with a fifth of the springs broken and a random displacement, every kernel (the CSR kernel
/// computes each spring's length, extension and unit vector once and shares them between its
/// ends; the stencils compute them from each end) to 1e-12 of the largest force. The forces are read from one sweep with dt = 1, no damping and
/// unit inverse masses from rest, where the kicked velocity is the force itself. Regular boxes
/// are also checked cell-weighted (their stencils then scale each spring by its node class's
/// factor), and must keep their stencil.
#[test]
fn kernel_forces_match_the_reference_law_on_every_lattice() {
    simd_from_env();
    use hooke_core::random::RandomSpec;
    let lattices = [
        Lattice::cubic_box([7, 6, 5], 1.0).unwrap(),
        Lattice::cubic_box([13, 10, 9], 1.0).unwrap(),
        Lattice::cubic_box_periodic([7, 6, 5], 1.0, [true, false, true]).unwrap(),
        Lattice::hex_box(12, 10, 1.0, 1.0).unwrap(),
        Lattice::hex_box(30, 12, 1.0, 1.0).unwrap(),
        Lattice::random(
            2,
            [0.0; 3],
            [10.0, 8.0, 0.0],
            1.0,
            1.0,
            RandomSpec::default(),
            &|_| true,
        )
        .unwrap(),
        Lattice::random(
            3,
            [0.0; 3],
            [6.0, 5.0, 4.0],
            1.0,
            1.0,
            RandomSpec::default(),
            &|_| true,
        )
        .unwrap(),
    ];
    let bodies = lattices.into_iter().flat_map(|lattice| {
        let kind = lattice.kind;
        let body = Body::uniform(lattice, 1.0, q_from_nu(kind, 0.3).unwrap(), 1.0);
        let weighted = body.clone().with_cell_weights().ok();
        std::iter::once(body).chain(weighted)
    });
    for body in bodies {
        let kind = body.lattice.kind;
        let mut rng = Rng::new(5);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.2);
        state.u = random_displacement(&body, &mut rng, 0.05);
        let mut reference = state.clone();
        hooke_core::law::update_forces(&body, &mut reference);
        let fmax = (0..body.nodes())
            .map(|i| reference.f.get(i).norm())
            .fold(0.0, Real::max);
        let mut kernels = vec![Kernel::Csr { plain: false }];
        let stencil = Kernel::for_body(&body, &state);
        if stencil.is_stencil() {
            let mut portable = stencil.clone();
            portable.set_simd(false);
            kernels.push(stencil);
            kernels.push(portable);
        }
        // Each box of a regular lattice has its stencil (the periodic one runs on CSR).
        assert_eq!(
            kernels.len() > 1,
            matches!(kind, LatticeKind::Cubic | LatticeKind::Hex) && !body.lattice.is_periodic(),
            "{}",
            kind.name()
        );
        for kernel in kernels {
            let f = kernel_forces(&kernel, &body, &state);
            for i in 0..body.nodes() {
                let (a, b) = (f.get(i), reference.f.get(i));
                assert!(
                    (a - b).norm() <= 1e-12 * fmax,
                    "{} {}: node {i}: {a:?} vs {b:?}",
                    kind.name(),
                    kernel.name()
                );
            }
        }
    }
}

/// On a plate, sweep 2 with `plane` (z neither read nor written) gives the bits of the sweep
/// over all three components, whose z lanes compute exact zeros: on the CSR kernel and both
/// paths of the hexagonal stencil, with damping and an in-plane body force.
#[test]
fn plane_sweeps_skip_only_exact_zeros() {
    simd_from_env();
    use hooke_core::kernel::{partials_len, StepParams};
    use hooke_core::random::RandomSpec;
    let random = Lattice::random(
        2,
        [0.0; 3],
        [30.0, 20.0, 0.0],
        1.0,
        1.0,
        RandomSpec::default(),
        &|_| true,
    )
    .unwrap();
    let random = Body::uniform(
        random,
        1.0,
        q_from_nu(LatticeKind::Random2d, 0.3).unwrap(),
        1.0,
    );
    for body in [random, hex_plate()] {
        let mut rng = Rng::new(3);
        let mut state = State::new(&body);
        kill_random(&body, &mut state, &mut rng, 0.1);
        state.u = random_displacement(&body, &mut rng, 1e-3);
        state.v = random_displacement(&body, &mut rng, 1e-2);
        state.u.z_mut().fill(0.0);
        state.v.z_mut().fill(0.0);
        let inv = vec![0.7; body.nodes()];
        let mut kernels = vec![Kernel::Csr { plain: false }];
        let stencil = Kernel::for_body(&body, &state);
        if stencil.is_stencil() {
            let mut portable = stencil.clone();
            portable.set_simd(false);
            kernels.extend([stencil, portable]);
        }
        for kernel in kernels {
            let run = |plane: bool| {
                let mut s = state.clone();
                let p = StepParams {
                    dt: 0.05,
                    damping: 0.3,
                    accel: [0.1, -0.2, 0.0],
                    plane,
                };
                let mut u_next = Coords::zeros(body.nodes());
                let mut partials = vec![Default::default(); partials_len(body.nodes())];
                kernel.pools(&body, &mut s);
                let sums =
                    kernel.force_kick_drift(&body, &mut s, &inv, &p, &mut u_next, &mut partials);
                (s.v, u_next, sums)
            };
            let (full, plane) = (run(false), run(true));
            assert!(full.0 == plane.0 && full.1 == plane.1, "{}", kernel.name());
            assert_eq!(full.2, plane.2, "{}", kernel.name());
            assert!(full
                .0
                .z()
                .iter()
                .chain(full.1.z())
                .all(|&z| z.to_bits() == 0));
        }
    }
}
