//! Delaunay triangulation of a random node set, timed (dev aid): `tri NODES DIM REPEATS`
//! samples the box `hooke bench` fills once, triangulates it REPEATS times and prints the
//! median and the fastest seconds and the number of simplices.
use hooke_core::random::{delaunay, sample};
use std::time::Instant;

fn main() {
    let arg = |k: usize| std::env::args().nth(k);
    let nodes: f64 = arg(1).and_then(|s| s.parse().ok()).unwrap_or(1e6);
    let dim: usize = arg(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let repeats: usize = arg(3).and_then(|s| s.parse().ok()).unwrap_or(5).max(1);
    let side = nodes.powf(1.0 / dim as f64).round() - 1.0;
    let hi = if dim == 3 {
        [side; 3]
    } else {
        [side, side, 0.0]
    };
    let pts = sample::sample_box(dim, [0.0; 3], hi, 1.0, sample::Sampler::Poisson, 1, &|_| {
        true
    });
    let mut seconds = Vec::new();
    let mut count = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        count = if dim == 3 {
            delaunay::triangulate::<4>(&pts).map(|m| m.simplices.len())
        } else {
            delaunay::triangulate::<3>(&pts).map(|m| m.simplices.len())
        }
        .expect("the triangulation");
        seconds.push(t.elapsed().as_secs_f64());
    }
    seconds.sort_by(f64::total_cmp);
    println!(
        "points {} simplices {count} median {:.3} s fastest {:.3} s",
        pts.len(),
        seconds[repeats / 2],
        seconds[0]
    );
}
