use hooke_core::*;
use std::time::Instant;
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(100);
    let t = Instant::now();
    let lat = Lattice::cubic_box([n, n, n], 1.0).unwrap();
    eprintln!("lattice {:.2}s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let body = Body::uniform(lat, 1.0, 0.15, 1.0);
    let mut state = State::new(&body);
    eprintln!("body+state {:.2}s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    law::update_forces(&body, &mut state);
    eprintln!("forces {:.2}s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let k = kernel::Kernel::for_body(&body, &state);
    eprintln!("kernel {:.2}s {}", t.elapsed().as_secs_f64(), k.name());
    let t = Instant::now();
    let s = stability::estimate(&body, &state, &k, 40, 1e-3);
    eprintln!("stability {:.2}s {:?}", t.elapsed().as_secs_f64(), s);
}
