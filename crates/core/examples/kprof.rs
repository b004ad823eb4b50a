//! Times the CSR kernel's sweeps separately (development aid).
use hooke_core::body::Body;
use hooke_core::kernel::{partials_len, Kernel, StepParams};
use hooke_core::lattice::Lattice;
use hooke_core::math::Coords;
use hooke_core::state::State;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dim: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(3);
    let nodes: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(2e5);
    let spec = hooke_core::random::RandomSpec::default();
    let lat = if dim == 3 {
        let side = nodes.cbrt().round() - 1.0;
        Lattice::random(3, [0.0; 3], [side; 3], 1.0, 1.0, spec, &|_| true).unwrap()
    } else {
        let side = nodes.sqrt().round() - 1.0;
        Lattice::random(2, [0.0; 3], [side, side, 0.0], 1.0, 1.0, spec, &|_| true).unwrap()
    };
    let mut body = Body::uniform(lat, 1.0, 0.2, 1.0);
    body.lattice.bonds.keep_neighbours();
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        state.u.x_mut()[i] = 1e-3 * (0.1 * body.lattice.pos.y()[i]).sin();
    }
    let k = Kernel::Csr { plain: false };
    let inv_mass = vec![1.0; body.nodes()];
    let mut un = Coords::zeros(body.nodes());
    let mut partials = vec![Default::default(); partials_len(body.nodes())];
    let p = StepParams {
        dt: 0.01,
        damping: 0.0,
        accel: [0.0; 3],
        plane: false,
    };
    k.pools(&body, &mut state);
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let (mut t1, mut t2) = (0.0, 0.0);
    for _ in 0..reps {
        let t = Instant::now();
        k.pools(&body, &mut state);
        t1 += t.elapsed().as_secs_f64();
        let t = Instant::now();
        k.force_kick_drift(&body, &mut state, &inv_mass, &p, &mut un, &mut partials);
        t2 += t.elapsed().as_secs_f64();
    }
    let s = body.springs() as f64 * reps as f64;
    println!(
        "{} nodes {} springs: pools {:.1} ns/spring, force {:.1} ns/spring, total {:.1} M/s",
        body.nodes(),
        body.springs(),
        t1 / s * 1e9,
        t2 / s * 1e9,
        s / (t1 + t2) / 1e6
    );
    let kp = Kernel::Csr { plain: true };
    let t = Instant::now();
    for _ in 0..reps {
        kp.pools(&body, &mut state);
    }
    println!(
        "sweep 1 without the pool gather: {:.1} ns/spring",
        t.elapsed().as_secs_f64() / s * 1e9
    );
    let opts = hooke_core::dynamics::IntegratorOptions {
        force_csr: true,
        ..Default::default()
    };
    let mut it =
        hooke_core::dynamics::Integrator::new(&body, &mut state, Default::default(), &opts)
            .unwrap();
    for _ in 0..3 {
        it.step(&body, &mut state);
    }
    let t = Instant::now();
    for _ in 0..reps {
        it.step(&body, &mut state);
    }
    println!(
        "integrator step: {:.1} M/s",
        s / t.elapsed().as_secs_f64() / 1e6
    );
}
