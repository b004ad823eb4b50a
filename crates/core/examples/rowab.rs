//! A/B of the row kernel in one process, medians of 10 alternating windows (dev aid):
//! `rowab NODES DIM` recomputed against streamed rest lengths, `rowab NODES DIM deal` groups
//! dealt by row length against groups of 8 consecutive nodes.
use hooke_core::body::Body;
use hooke_core::kernel::{partials_len, Kernel, StepParams};
use hooke_core::lattice::Lattice;
use hooke_core::math::Coords;
use hooke_core::state::State;
use std::time::Instant;

fn main() {
    let nodes: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1e6);
    let dim: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(3);
    let spec = hooke_core::random::RandomSpec::default();
    let lat = if dim == 3 {
        let side = nodes.cbrt().round() - 1.0;
        Lattice::random(3, [0.0; 3], [side; 3], 1.0, 1.0, spec, &|_| true).unwrap()
    } else {
        let side = nodes.sqrt().round() - 1.0;
        Lattice::random(2, [0.0; 3], [side, side, 0.0], 1.0, 1.0, spec, &|_| true).unwrap()
    };
    let dealing = std::env::args().nth(3).is_some_and(|m| m == "deal");
    let a = Body::uniform(lat, 1.0, 0.2, 1.0);
    let mut b = a.clone();
    if !dealing {
        b.lattice.rest_lengths_mut()[3] *= 1.0 + 4.0 * f64::EPSILON;
    }
    let mut sa = State::new(&a);
    for i in 0..a.nodes() {
        sa.u.x_mut()[i] = 1e-3 * (0.1 * a.lattice.pos.y()[i]).sin();
    }
    let mut sb = sa.clone();
    let ka = Kernel::for_body(&a, &sa);
    let kb = if dealing {
        Kernel::Rows(hooke_core::kernel::rows::RowKernel::undealt(&b, &sb).unwrap())
    } else {
        Kernel::for_body(&b, &sb)
    };
    let n = a.nodes();
    let inv_mass = vec![1.0; n];
    let mut un = Coords::zeros(n);
    let mut partials = vec![Default::default(); partials_len(n)];
    let p = StepParams {
        dt: 0.01,
        damping: 0.0,
        accel: [0.0; 3],
        plane: dim == 2,
    };
    let reps = 20;
    let sp = a.springs() as f64 * reps as f64;
    let (mut ra, mut rb) = (vec![], vec![]);
    for round in 0..10 {
        for (k, body, state, out) in [(&ka, &a, &mut sa, &mut ra), (&kb, &b, &mut sb, &mut rb)] {
            let t = Instant::now();
            for _ in 0..reps {
                k.pools(body, state);
                k.force_kick_drift(body, state, &inv_mass, &p, &mut un, &mut partials);
            }
            out.push(sp / t.elapsed().as_secs_f64() / 1e6);
        }
        let _ = round;
    }
    ra.sort_by(|x, y| x.partial_cmp(y).unwrap());
    rb.sort_by(|x, y| x.partial_cmp(y).unwrap());
    let (wa, wb) = if dealing {
        ("groups dealt by row length", "groups of consecutive nodes")
    } else {
        ("recomputed rest", "stored rest")
    };
    println!(
        "{} {wa}: median {:.1} M/s; {wb}: median {:.1} M/s; ratio {:.3}",
        ka.name(),
        ra[5],
        rb[5],
        ra[5] / rb[5]
    );
}
