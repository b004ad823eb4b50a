//! Helpers shared by the regression tests: a seeded generator and small bodies.

use hooke_core::random::RandomSpec;
use hooke_core::{Body, Coords, Lattice, LatticeKind, Real, State};

/// A small deterministic generator (xorshift64*), so tests need no extra dependency and every
/// run sees the same numbers.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> Real {
        (self.next_u64() >> 11) as Real / (1u64 << 53) as Real
    }

    /// Uniform in [-a, a).
    pub fn sym(&mut self, a: Real) -> Real {
        a * (2.0 * self.uniform() - 1.0)
    }
}

/// A small box of either lattice with unit spacing and stiffness and the given q.
pub fn small_body(kind: LatticeKind, q: Real, n: usize) -> Body {
    let side = (n - 1) as Real;
    let lattice = match kind {
        LatticeKind::Cubic => Lattice::cubic_box([n, n, n], 1.0),
        LatticeKind::Hex => Lattice::hex_box(n, n, 1.0, 1.0),
        LatticeKind::Random2d => {
            let spec = RandomSpec {
                seed: n as u64,
                ..Default::default()
            };
            Lattice::random(2, [0.0; 3], [side, side, 0.0], 1.0, 1.0, spec, &|_| true)
        }
        LatticeKind::Random3d => {
            let spec = RandomSpec {
                seed: n as u64,
                ..Default::default()
            };
            Lattice::random(3, [0.0; 3], [side; 3], 1.0, 1.0, spec, &|_| true)
        }
    }
    .unwrap();
    if lattice.cells.is_some() {
        // Random lattices: the stiffness of each spring from its volume (kappa = 1), so the
        // springs differ as in a real run.
        Body::from_cells(lattice, 1.0, q, 1.0)
    } else {
        Body::uniform(lattice, 1.0, q, 1.0)
    }
}

/// Random displacements of size `amp` (in-plane only for 2D lattices).
pub fn random_displacement(body: &Body, rng: &mut Rng, amp: Real) -> Coords {
    let mut u = Coords::zeros(body.nodes());
    for i in 0..body.nodes() {
        u.x_mut()[i] = rng.sym(amp);
        u.y_mut()[i] = rng.sym(amp);
        if body.lattice.dim() == 3 {
            u.z_mut()[i] = rng.sym(amp);
        }
    }
    u
}

/// Kill each spring with probability `p`.
pub fn kill_random(body: &Body, state: &mut State, rng: &mut Rng, p: Real) -> usize {
    let mut killed = 0;
    for b in 0..body.springs() {
        if rng.uniform() < p && state.kill_bond(body, b) {
            killed += 1;
        }
    }
    killed
}

/// Indices of the degrees of freedom a lattice uses (x, y, z per node; x, y in 2D) as
/// (node, axis) pairs.
pub fn dofs(body: &Body) -> Vec<(usize, usize)> {
    let d = body.lattice.dim();
    (0..body.nodes())
        .flat_map(|i| (0..d).map(move |c| (i, c)))
        .collect()
}

/// The dense stiffness (tangent) matrix over [`dofs`], by columns of `Tangent::apply`; with
/// `over_mass`, `M^-1/2 K M^-1/2`, whose eigenvalues the stable step depends on.
pub fn dense_tangent(body: &Body, state: &State, over_mass: bool) -> nalgebra::DMatrix<Real> {
    let d = dofs(body);
    let mut t = hooke_core::Tangent::new(body, state);
    let mut k = nalgebra::DMatrix::zeros(d.len(), d.len());
    let mut v = Coords::zeros(body.nodes());
    let mut kv = Coords::zeros(body.nodes());
    for (col, &(i, c)) in d.iter().enumerate() {
        v.fill_zero();
        v.comp_mut(c)[i] = 1.0;
        t.apply(body, &v, &mut kv);
        for (row, &(j, r)) in d.iter().enumerate() {
            let scale = if over_mass {
                (body.mass[i] * body.mass[j]).sqrt()
            } else {
                1.0
            };
            k[(row, col)] = kv.comp(r)[j] / scale;
        }
    }
    k
}

/// The forces `kernel` computes for `state` (its velocities are ignored), read from one sweep
/// with dt = 1, no damping and unit inverse masses from rest, where the kicked velocity is the
/// force itself.
pub fn kernel_forces(kernel: &hooke_core::kernel::Kernel, body: &Body, state: &State) -> Coords {
    use hooke_core::kernel::{partials_len, StepParams};
    let mut s = state.clone();
    s.v = Coords::zeros(body.nodes());
    let inv = vec![1.0; body.nodes()];
    let p = StepParams {
        dt: 1.0,
        damping: 0.0,
        accel: [0.0; 3],
        plane: false,
    };
    let mut u_next = Coords::zeros(body.nodes());
    let mut partials = vec![Default::default(); partials_len(body.nodes())];
    kernel.pools(body, &mut s);
    kernel.force_kick_drift(body, &mut s, &inv, &p, &mut u_next, &mut partials);
    s.v
}

/// Supports that pull a bar apart along x: the nodes within 0.6 of either end move outwards at
/// `speed`, reached along a smooth ramp over 20 time units.
pub fn pull_ends(body: &Body, speed: Real) -> hooke_core::loading::Loading {
    use hooke_core::loading::{Loading, Motion, Prescribed, TimeFunction};
    let x = body.lattice.pos.x();
    let lo = x.iter().cloned().fold(Real::INFINITY, Real::min);
    let hi = x.iter().cloned().fold(Real::NEG_INFINITY, Real::max);
    let ends = |f: &dyn Fn(Real) -> bool| -> Vec<u32> {
        (0..body.nodes() as u32)
            .filter(|&i| f(x[i as usize]))
            .collect()
    };
    let ramp = |to: Real| {
        Motion::Velocity(TimeFunction::SmoothRamp {
            t0: 0.0,
            t1: 20.0,
            from: 0.0,
            to,
        })
    };
    Loading {
        prescribed: vec![
            Prescribed {
                nodes: ends(&|v| v < lo + 0.6),
                axis: 0,
                motion: ramp(-speed),
            },
            Prescribed {
                nodes: ends(&|v| v > hi - 0.6),
                axis: 0,
                motion: ramp(speed),
            },
        ],
        ..Default::default()
    }
}

/// Asserts force = -grad U at `state` (its forces current) by central differences of step `h`:
/// every component within `tol` of the largest force (the O(h^2) truncation).
pub fn assert_force_is_minus_energy_gradient(
    body: &Body,
    state: &State,
    h: Real,
    tol: Real,
    what: &str,
) {
    let energy =
        |u: &Coords| hooke_core::law::energy(body, u, state.springs(body), state.norm()).total();
    let fmax = dofs(body)
        .iter()
        .map(|&(i, c)| state.f.comp(c)[i].abs())
        .fold(0.0, Real::max);
    for (i, c) in dofs(body) {
        let mut up = state.u.clone();
        up.comp_mut(c)[i] += h;
        let mut dn = state.u.clone();
        dn.comp_mut(c)[i] -= h;
        let grad = (energy(&up) - energy(&dn)) / (2.0 * h);
        let f = state.f.comp(c)[i];
        assert!(
            (f + grad).abs() < tol * fmax,
            "{what}: node {i} axis {c}: f={f}, -dU={}",
            -grad
        );
    }
}

/// Asserts the tangent at `state` (its pools current) is the force Jacobian along `v`:
/// `K v = -(f(u + h v) - f(u - h v)) / 2h` within `tol` of `|K v|`.
pub fn assert_tangent_is_force_jacobian(
    body: &Body,
    state: &State,
    v: &Coords,
    h: Real,
    tol: Real,
    what: &str,
) {
    let mut tangent = hooke_core::Tangent::new(body, state);
    let mut kv = Coords::zeros(body.nodes());
    tangent.apply(body, v, &mut kv);
    let mut fp = state.clone();
    fp.u.axpy(h, v);
    hooke_core::law::update_forces(body, &mut fp);
    let mut fm = state.clone();
    fm.u.axpy(-h, v);
    hooke_core::law::update_forces(body, &mut fm);
    let mut diff = kv.clone();
    diff.axpy(1.0 / (2.0 * h), &fp.f);
    diff.axpy(-1.0 / (2.0 * h), &fm.f);
    assert!(
        diff.norm() < tol * kv.norm(),
        "{what}: |Kv + df/dv| = {} vs |Kv| = {}",
        diff.norm(),
        kv.norm()
    );
}

/// The kernels' paths as the environment asks (`HOOKE_NO_SIMD=1`: the portable ones, how CI
/// runs the kernel tests a second time; `HOOKE_SIMD=avx2`), as the `hooke` binary maps them.
/// Every test that runs kernels calls it first (the setting is the process's; all set the same).
pub fn simd_from_env() {
    hooke_core::kernel::set_simd(hooke_core::kernel::Simd::from_env_values(
        std::env::var_os("HOOKE_NO_SIMD").is_some(),
        std::env::var("HOOKE_SIMD").ok().as_deref(),
    ));
}

/// Free vibration sampled every 10 steps, `rounds` times: the leapfrog's shadow energy `H =
/// 1/2 sum m v(t-dt/2).v(t+dt/2) + U(u(t))` (exactly conserved for a linear system) and the
/// ordinary `K + U` (full-step velocity) at each sample.
pub fn shadow_energies(
    it: &mut hooke_core::dynamics::Integrator,
    body: &Body,
    state: &mut State,
    rounds: usize,
) -> (Vec<Real>, Vec<Real>) {
    let (mut shadow, mut energies) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        it.run(body, state, 9).unwrap();
        let (v_before, u_before) = (state.v.clone(), state.u.clone());
        it.step(body, state);
        let kin: Real = (0..body.nodes())
            .map(|i| 0.5 * body.mass[i] * v_before.get(i).dot(&state.v.get(i)))
            .sum();
        shadow.push(
            kin + hooke_core::law::energy(body, &u_before, state.springs(body), state.norm())
                .total(),
        );
        let b = it.energy(body, state);
        energies.push(b.kinetic + b.strain.total());
    }
    (shadow, energies)
}

/// The drift of a series over its length relative to `e0`: the least-squares line's slope
/// through `(k, h_k)` times the number of samples.
pub fn relative_drift(series: &[Real], e0: Real) -> Real {
    let n = series.len() as Real;
    let km = (n - 1.0) / 2.0;
    let hm = series.iter().sum::<Real>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, h) in series.iter().enumerate() {
        sxy += (k as Real - km) * (h - hm);
        sxx += (k as Real - km).powi(2);
    }
    (sxy / sxx * n).abs() / e0
}
