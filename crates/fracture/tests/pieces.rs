//! Breaking on pieces (`Integrator::cut`, `Fracture::cut`) with a criterion that has no
//! stretch screen, decided after each step by every rank for the springs whose lower end it
//! owns: the ranks end with one process's broken springs, released energy, ledger and state,
//! bit for bit. (The case files allow such criteria on regular lattices only, which are not
//! cut; the screened criteria on pieces are tested through the shipped random cases in
//! `crates/case/tests/team.rs`.)

use std::sync::Arc;

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::Loading;
use hooke_core::random::RandomSpec;
use hooke_core::team::{Team, Threads};
use hooke_core::{Body, Lattice, Real, State};
use hooke_fracture::{Fracture, SpringEnergy};

/// A random block stretched along x by a smooth field, more near its middle.
fn stretched() -> (Body, State) {
    let lat = Lattice::random(
        3,
        [0.0; 3],
        [30.0, 24.0, 22.0],
        1.0,
        1.0,
        RandomSpec::default(),
        &|_| true,
    )
    .unwrap();
    let body = Body::uniform(lat, 1.0, 0.3, 1.0);
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        let x = body.lattice.pos.get(i);
        state.u.x_mut()[i] = 0.02 * (x.x - 15.0).atan() + 0.003 * (0.4 * x.y).sin();
        state.u.y_mut()[i] = 0.004 * (0.3 * x.z).cos();
    }
    (body, state)
}

/// The criterion breaking the springs whose direct energy at the start is in the top
/// thousandth, and more as the block moves.
fn criterion(body: &Body, state: &State) -> SpringEnergy {
    let bonds = &*body.lattice.bonds;
    let mut e: Vec<Real> = (0..body.springs())
        .map(|b| {
            let [i, j] = bonds.ends[b].map(|n| n as usize);
            let dl = hooke_core::law::spring_geometry(
                &body.lattice,
                &state.u,
                i,
                j,
                body.lattice.rest(b),
            )
            .dl;
            let l = body.lattice.rest(b);
            0.5 * dl * dl / (l * l)
        })
        .collect();
    e.sort_by(Real::total_cmp);
    SpringEnergy {
        w_c: e[e.len() - e.len() / 1000],
        l_ref: 1.0,
    }
}

#[test]
fn an_unscreened_criterion_on_pieces_breaks_what_one_process_breaks() {
    let (body, start) = stretched();
    let crit = criterion(&body, &start);
    let opts = IntegratorOptions {
        damage_proof: true,
        ..Default::default()
    };
    let steps = 30;
    let mut alone = start.clone();
    let mut it = Integrator::new(&body, &mut alone, Loading::default(), &opts).unwrap();
    let mut fr = Fracture::new(&body, Box::new(crit));
    for _ in 0..steps {
        fr.step(&body, &mut alone, &mut it, None);
    }
    assert!(fr.broken_total > 20, "{} springs broken", fr.broken_total);
    let ledger = it.ledger();
    for size in [2, 3] {
        std::thread::scope(|scope| {
            for team in Threads::team(size) {
                let (body, start, alone, opts, fr_alone) = (&body, &start, &alone, &opts, &fr);
                scope.spawn(move || {
                    let rank = team.rank();
                    let team: Arc<dyn Team> = Arc::new(team);
                    let mut state = start.clone();
                    let mut it = Integrator::new_shared(
                        body,
                        &mut state,
                        Loading::default(),
                        opts,
                        Some(team),
                    )
                    .unwrap();
                    let (pb, mut ps) = it.cut(body, &state).unwrap();
                    drop(state);
                    let mut fr = Fracture::new(body, Box::new(crit));
                    fr.cut(it.piece().unwrap(), &pb);
                    for _ in 0..steps {
                        fr.step(&pb, &mut ps, &mut it, None);
                    }
                    let at = format!("{size} ranks, rank {rank}");
                    assert_eq!(fr.broken_total, fr_alone.broken_total, "{at}");
                    assert_eq!(
                        fr.released_total.to_bits(),
                        fr_alone.released_total.to_bits(),
                        "{at}"
                    );
                    assert_eq!(it.ledger(), ledger, "{at}");
                    let piece = it.piece().unwrap();
                    for i in piece.own.clone() {
                        let g = piece.global[i] as usize;
                        for c in 0..3 {
                            assert_eq!(ps.u.comp(c)[i].to_bits(), alone.u.comp(c)[g].to_bits());
                            assert_eq!(ps.v.comp(c)[i].to_bits(), alone.v.comp(c)[g].to_bits());
                        }
                    }
                    // Every spring of the piece is broken where it is broken in the body.
                    for (b, &g) in piece.springs.iter().enumerate() {
                        assert_eq!(ps.alive()[b], alone.alive()[g as usize], "spring {g}, {at}");
                    }
                });
            }
        });
    }
}
