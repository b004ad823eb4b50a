//! Contact physics: a dynamic sphere bouncing off a free block conserves momentum to round-off
//! and energy within 1 %, no node penetrates a body beyond the stated tolerance, fragments do not
//! pass through each other, and results are bit-identical for 1 and 2 threads.

use hooke_contact::{Contact, ContactOptions, Geometry, Motion, RigidBody};
use hooke_core::dynamics::{momentum, Integrator, IntegratorOptions};
use hooke_core::loading::{Loading, TimeFunction};
use hooke_core::{Body, Elastic, Lattice, PlaneModel, Real, State};

const A: Real = 1e-3;

fn steel_block(n: [usize; 3]) -> Body {
    let lat = Lattice::cubic_box(n, A).unwrap();
    let m = Elastic {
        youngs: 200e9,
        poisson: 0.3,
        density: 7800.0,
    };
    Body::new(lat, &m, PlaneModel::Stress).unwrap()
}

fn sphere(radius: Real, at: [Real; 3], v: [Real; 3]) -> RigidBody {
    let shape = parry3d_f64::shape::SharedShape::ball(radius);
    let geometry = Geometry::D3(shape, parry3d_f64::math::Rotation::IDENTITY);
    let mass = geometry.mass(7800.0, 1.0);
    RigidBody {
        name: "sphere".into(),
        geometry,
        motion: Motion::Dynamic { mass },
        position: at,
        velocity: v,
        friction: 0.0,
        reaction: [0.0; 3],
    }
}

struct Run {
    body: Body,
    state: State,
    it: Integrator,
    contact: Contact,
}

/// A 4 mm sphere at 5 m/s onto the top of a free 16 x 16 x 8 mm block.
fn bounce_setup() -> Run {
    let body = steel_block([17, 17, 9]);
    let mut state = State::new(&body);
    let it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    let opts = ContactOptions::for_body(&body);
    let r = 4e-3;
    let top = 8.0 * A;
    let s = sphere(
        r,
        [8.0 * A, 8.0 * A, top + opts.radius + r + 0.2 * A],
        [0.0, 0.0, -5.0],
    );
    let contact = Contact::new(&body, vec![s], opts);
    Run {
        body,
        state,
        it,
        contact,
    }
}

fn total_momentum(r: &Run) -> [Real; 3] {
    let p = momentum(&r.body, &r.state.v);
    let q = r.contact.momentum();
    [p.x + q[0], p.y + q[1], p.z + q[2]]
}

fn run_until_separated(r: &mut Run, max_steps: usize) -> usize {
    let mut touched = false;
    for s in 0..max_steps {
        r.it.step_with(&r.body, &mut r.state, Some(&mut r.contact));
        let f = r.contact.bodies[0].reaction;
        let busy = f.iter().any(|&x| x != 0.0);
        touched |= busy;
        // Run a while past separation so that the sphere's velocity is final.
        if touched && !busy && s > 50 {
            for _ in 0..50 {
                r.it.step_with(&r.body, &mut r.state, Some(&mut r.contact));
            }
            return s;
        }
    }
    panic!("the sphere did not bounce off within {max_steps} steps");
}

#[test]
fn sphere_bounce_conserves_momentum_and_energy() {
    let mut r = bounce_setup();
    let p0 = total_momentum(&r);
    let e0 = r.contact.kinetic();
    let steps = run_until_separated(&mut r, 20_000);
    let p1 = total_momentum(&r);
    let scale = p0.iter().map(|x| x * x).sum::<Real>().sqrt();
    let dp = (0..3).map(|c| (p1[c] - p0[c]).powi(2)).sum::<Real>().sqrt();
    let bal = r.it.energy(&r.body, &mut r.state);
    let lattice = bal.kinetic + bal.strain.total();
    let e1 = lattice + r.contact.kinetic() + r.contact.potential;
    let v = r.contact.bodies[0].velocity[2];
    println!(
        "{steps} steps: momentum error {:.2e} (relative), energy {e1:.6e} of {e0:.6e} ({:+.3} %), \
         sphere leaves at {v:.3} m/s, lattice took {:.1} %, penetration {:.3e} m = {:.4} a, {} list builds",
        dp / scale,
        100.0 * (e1 / e0 - 1.0),
        100.0 * lattice / e0,
        r.contact.max_penetration,
        r.contact.max_penetration / A,
        r.contact.rebuilds
    );
    assert!(
        dp <= 1e-9 * scale,
        "momentum changed by {dp:e} of {scale:e}"
    );
    assert!((e1 / e0 - 1.0).abs() < 0.01, "energy {e1} of {e0}");
    assert!(v > 0.0, "the sphere must bounce back up");
    // The lattice ledger books the contact work: its own balance closes too.
    assert!(
        bal.relative_error < 1e-3,
        "lattice balance {}",
        bal.relative_error
    );
    // Stated tolerance: no node comes more than a/10 past its contact radius.
    assert!(r.contact.max_penetration < 0.1 * A);
}

#[test]
fn contact_is_bit_identical_for_one_and_two_threads() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut r = bounce_setup();
            for _ in 0..600 {
                r.it.step_with(&r.body, &mut r.state, Some(&mut r.contact));
            }
            (
                r.state.u.clone(),
                r.state.v.clone(),
                r.contact.bodies[0].position,
            )
        })
    };
    let (u1, v1, x1) = run(1);
    let (u2, v2, x2) = run(2);
    let same = |a: &[Real], b: &[Real]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
    assert!(same(u1.x(), u2.x()) && same(u1.y(), u2.y()) && same(u1.z(), u2.z()));
    assert!(same(v1.x(), v2.x()) && same(v1.y(), v2.y()) && same(v1.z(), v2.z()));
    assert_eq!(x1.map(f64::to_bits), x2.map(f64::to_bits));
    assert!(
        u1.z().iter().any(|&z| z != 0.0),
        "the sphere must have hit the block"
    );
}

/// Two halves of a block, cut apart (every spring across the plane removed) and thrown at each
/// other at 20 m/s: with fragment contact no node of one half comes within half a spacing of a
/// node of the other; without it the halves pass into each other (so the check can fail).
#[test]
fn fragments_do_not_interpenetrate() {
    let closest = |fragments: bool| {
        let body = steel_block([12, 6, 6]);
        let mut state = State::new(&body);
        let left = |i: usize| body.lattice.pos.x()[i] < 5.5 * A;
        let cut: Vec<usize> = (0..body.springs())
            .filter(|&b| {
                let [i, j] = body.lattice.bonds.ends[b];
                left(i as usize) != left(j as usize)
            })
            .collect();
        for b in cut {
            state.kill_bond(&body, b);
        }
        for i in 0..body.nodes() {
            state.v.x_mut()[i] = if left(i) { 20.0 } else { -20.0 };
        }
        let mut it = Integrator::new(
            &body,
            &mut state,
            Loading::default(),
            &IntegratorOptions::default(),
        )
        .unwrap();
        let mut opts = ContactOptions::for_body(&body);
        if !fragments {
            opts.fragment_distance = None;
        }
        let mut contact = Contact::new(&body, Vec::new(), opts);
        let mut min_d = Real::INFINITY;
        let p0 = momentum(&body, &state.v);
        for _ in 0..3000 {
            it.step_with(&body, &mut state, Some(&mut contact));
            for i in (0..body.nodes()).filter(|&i| left(i)) {
                for j in (0..body.nodes()).filter(|&j| !left(j)) {
                    let d = [0, 1, 2].map(|c| {
                        body.lattice.pos.comp(c)[i] + state.u.comp(c)[i]
                            - body.lattice.pos.comp(c)[j]
                            - state.u.comp(c)[j]
                    });
                    min_d = min_d.min((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
                }
            }
        }
        let p1 = momentum(&body, &state.v);
        let total: Real = body.mass.iter().sum();
        assert!((p1 - p0).norm() < 1e-12 * total * 20.0);
        (min_d, contact.rebuilds)
    };
    let (with, builds) = closest(true);
    let (without, _) = closest(false);
    println!(
        "closest approach across the cut: {with:.3e} m with fragment contact ({builds} list \
         builds), {without:.3e} m without"
    );
    assert!(with > 0.5 * A, "fragments came within {with}");
    assert!(
        without < 0.5 * A,
        "without contact the halves must interpenetrate: {without}"
    );
}

#[test]
fn kinematic_platen_pushes_and_records_its_reaction() {
    let body = steel_block([9, 9, 9]);
    let mut state = State::new(&body);
    // Hold the bottom face; press a rigid half-space down onto the top at 0.2 m/s, to a mean
    // strain of about 0.3 %.
    let mut loading = Loading::default();
    let bottom: Vec<u32> = (0..body.nodes() as u32)
        .filter(|&i| body.lattice.pos.z()[i as usize] == 0.0)
        .collect();
    for axis in 0..3 {
        loading.prescribed.push(hooke_core::loading::Prescribed {
            nodes: bottom.clone(),
            axis,
            motion: hooke_core::loading::Motion::Fixed,
        });
    }
    let mut it =
        Integrator::new(&body, &mut state, loading, &IntegratorOptions::default()).unwrap();
    let opts = ContactOptions::for_body(&body);
    let shape =
        parry3d_f64::shape::SharedShape::halfspace(parry3d_f64::math::Vector::new(0.0, 0.0, -1.0));
    let platen = RigidBody {
        name: "platen".into(),
        geometry: Geometry::D3(shape, parry3d_f64::math::Rotation::IDENTITY),
        motion: Motion::Kinematic([
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(-0.2),
        ]),
        position: [0.0, 0.0, 8.0 * A + opts.radius],
        velocity: [0.0; 3],
        friction: 0.3,
        reaction: [0.0; 3],
    };
    let mut contact = Contact::new(&body, vec![platen], opts);
    for _ in 0..4000 {
        it.step_with(&body, &mut state, Some(&mut contact));
    }
    let last = *contact.history.last().unwrap();
    // The reaction points up and the block is compressed; at this stress (about E/300) the
    // penalty gives way by far less than the stated tolerance.
    let top: Vec<usize> = (0..body.nodes())
        .filter(|&i| body.lattice.pos.z()[i] == 8.0 * A)
        .collect();
    let dz: Real = top.iter().map(|&i| state.u.z()[i]).sum::<Real>() / top.len() as Real;
    println!(
        "platen moved {:.3e} m, top face {dz:.3e} m, reaction {:.3e} N, penetration {:.3e} m",
        8.5 * A - last.position[2],
        last.reaction[2],
        contact.max_penetration
    );
    assert!(last.reaction[2] > 0.0);
    assert!(dz < 0.0);
    assert_eq!(contact.history.len(), 4000);
    assert!(contact.max_penetration < 0.1 * A);
}

/// Fragment contact is bit-identical for 1 and 2 threads: the cut halves of
/// `fragments_do_not_interpenetrate`, in contact for most of the run.
#[test]
fn fragment_contact_is_bit_identical_for_one_and_two_threads() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let body = steel_block([12, 6, 6]);
            let mut state = State::new(&body);
            let left = |i: usize| body.lattice.pos.x()[i] < 5.5 * A;
            for b in 0..body.springs() {
                let [i, j] = body.lattice.bonds.ends[b];
                if left(i as usize) != left(j as usize) {
                    state.kill_bond(&body, b);
                }
            }
            for i in 0..body.nodes() {
                state.v.x_mut()[i] = if left(i) { 20.0 } else { -20.0 };
            }
            let mut it = Integrator::new(
                &body,
                &mut state,
                Loading::default(),
                &IntegratorOptions::default(),
            )
            .unwrap();
            let mut contact = Contact::new(&body, Vec::new(), ContactOptions::for_body(&body));
            for _ in 0..800 {
                it.step_with(&body, &mut state, Some(&mut contact));
            }
            (state.u.clone(), contact.rebuilds)
        })
    };
    let (u1, b1) = run(1);
    let (u2, b2) = run(2);
    assert_eq!(b1, b2);
    for c in 0..3 {
        assert!(u1
            .comp(c)
            .iter()
            .zip(u2.comp(c))
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
