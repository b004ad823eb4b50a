//! Set-up of a random body, timed and fingerprinted (dev aid): `setup NODES DIM [SEED]` builds
//! the lattice `hooke bench` builds (a cube or square of side about NODES^(1/DIM) spacings),
//! a body with nu = 0.3 (3D) or 0.45 (2D) and its integrator, and prints the seconds of each
//! part and one hash of every bit they produced (positions, springs, rest lengths, volume
//! shares, boundary areas, masses, the stable step). A set-up change that should change no
//! result must leave the hash as it was.
use hooke_core::body::Body;
use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::lattice::Lattice;
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::state::State;
use std::time::Instant;

/// FNV-1a over 64-bit words.
struct Hash(u64);

impl Hash {
    fn word(&mut self, w: u64) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    fn reals(&mut self, xs: impl IntoIterator<Item = f64>) {
        for x in xs {
            self.word(x.to_bits());
        }
    }
}

fn main() {
    let arg = |k: usize| std::env::args().nth(k);
    let nodes: f64 = arg(1).and_then(|s| s.parse().ok()).unwrap_or(1e6);
    let dim: usize = arg(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let seed: u64 = arg(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let spec = hooke_core::random::RandomSpec {
        seed,
        ..Default::default()
    };
    let start = Instant::now();
    let lat = if dim == 3 {
        let side = nodes.cbrt().round() - 1.0;
        Lattice::random(3, [0.0; 3], [side; 3], 1.0, 1.0, spec, &|_| true)
    } else {
        let side = nodes.sqrt().round() - 1.0;
        Lattice::random(2, [0.0; 3], [side, side, 0.0], 1.0, 1.0, spec, &|_| true)
    }
    .expect("the lattice");
    let lattice_s = start.elapsed().as_secs_f64();
    let nu = if dim == 3 { 0.3 } else { 0.45 };
    let body = Body::uniform(lat.clone(), 1.0, q_from_nu(lat.kind, nu).unwrap(), 1.0);
    let mut state = State::new(&body);
    let it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .expect("the integrator");
    let total_s = start.elapsed().as_secs_f64();
    let mut h = Hash(0xcbf2_9ce4_8422_2325);
    h.reals(lat.pos.as_flat().iter().copied());
    for e in &lat.bonds.ends {
        h.word(((e[0] as u64) << 32) | e[1] as u64);
    }
    h.reals(lat.rest_lengths().iter().copied());
    if let Some(c) = &lat.cells {
        h.reals(c.node.iter().copied());
        h.reals(c.spring.iter().copied());
        h.reals(c.surface.iter().flatten().copied());
    }
    h.reals(body.mass.iter().copied());
    h.reals([it.dt(), it.stable().lambda_max]);
    println!(
        "nodes {} springs {} lattice {lattice_s:.3} s total {total_s:.3} s dt {:e} hash {:016x}",
        lat.pos.len(),
        lat.bonds.len(),
        it.dt(),
        h.0
    );
}
