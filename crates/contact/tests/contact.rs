//! Contact physics: a dynamic sphere bouncing off a free block conserves momentum to round-off
//! and energy within 1 %, no node penetrates a body beyond the stated tolerance, fragments do not
//! pass through each other, and results are bit-identical for 1 and 2 threads.

use hooke_contact::{Contact, ContactOptions, Geometry, Motion, RigidBody};
use hooke_core::dynamics::{momentum, Integrator, IntegratorOptions};
use hooke_core::loading::{Loading, TimeFunction};
use hooke_core::{Body, Elastic, Lattice, PlaneModel, Real, State};

const A: Real = 1e-3;

fn steel(lat: Lattice) -> Body {
    let m = Elastic {
        youngs: 200e9,
        poisson: 0.3,
        density: 7800.0,
    };
    Body::new(lat, &m, PlaneModel::Stress).unwrap()
}

fn steel_block(n: [usize; 3]) -> Body {
    steel(Lattice::cubic_box(n, A).unwrap())
}

/// At rest, with no loading: what every contact test starts from.
fn at_rest(body: &Body) -> (State, Integrator) {
    let mut state = State::new(body);
    let it = Integrator::new(
        body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    (state, it)
}

fn sphere(radius: Real, at: [Real; 3], v: [Real; 3]) -> RigidBody {
    let shape = parry3d_f64::shape::SharedShape::ball(radius);
    let geometry = Geometry::D3(shape, parry3d_f64::math::Rotation::IDENTITY);
    let mass = geometry.mass(7800.0, 1.0);
    RigidBody::new("sphere", geometry, Motion::Dynamic { mass }, at, v, 0.0)
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
    let (state, it) = at_rest(&body);
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
    let platen = RigidBody::new(
        "platen",
        Geometry::D3(shape, parry3d_f64::math::Rotation::IDENTITY),
        Motion::Kinematic([
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(-0.2),
        ]),
        [0.0, 0.0, 8.0 * A + opts.radius],
        [0.0; 3],
        0.3,
    );
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

/// Angular momentum of the lattice about the origin, `sum m x(t + dt) x v(t + dt/2)`: with the
/// rigid bodies' `X_c x M V + L`, what leapfrog conserves exactly when every force acts in
/// equal and opposite pairs on one line (springs, contact, friction).
fn total_angular_momentum(r: &Run) -> [Real; 3] {
    let (p, u, v) = (&r.body.lattice.pos, &r.state.u, &r.state.v);
    let mut l = r.contact.angular_momentum();
    for i in 0..r.body.nodes() {
        let x = [
            p.x()[i] + u.x()[i],
            p.y()[i] + u.y()[i],
            p.z()[i] + u.z()[i],
        ];
        let m = r.body.mass[i];
        let c = hooke_contact::rigid::cross(x, [v.x()[i], v.y()[i], v.z()[i]]);
        for k in 0..3 {
            l[k] += m * c[k];
        }
    }
    l
}

fn norm(a: [Real; 3]) -> Real {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// A spinning sphere (about x, 2000 rad/s) dropped with friction onto a free block: friction
/// brakes the spin and sets the block turning; the total angular momentum is conserved to
/// round-off, and the body's kinetic energy counts its rotation.
#[test]
fn spinning_sphere_exchanges_angular_momentum_with_a_block() {
    let mut r = bounce_setup();
    r.contact.bodies[0].friction = 0.5;
    r.contact.bodies[0] = r.contact.bodies[0].clone().with_spin([2000.0, 0.0, 0.0], 3);
    let l_sphere0 = r.contact.bodies[0].angular_momentum;
    assert!(l_sphere0[0] > 0.0 && r.contact.bodies[0].kinetic() > 0.0);
    let l0 = total_angular_momentum(&r);
    run_until_separated(&mut r, 20_000);
    let l1 = total_angular_momentum(&r);
    let scale = norm(l0);
    let dl = norm([0, 1, 2].map(|c| l1[c] - l0[c]));
    let b = &r.contact.bodies[0];
    println!(
        "angular momentum error {:.2e} (relative); sphere spin {:?} rad/s (was 2000 about x); \
         its L_x {:.4e} of {:.4e}",
        dl / scale,
        b.spin,
        b.angular_momentum[0],
        l_sphere0[0]
    );
    assert!(
        dl <= 1e-9 * scale,
        "angular momentum changed by {dl:e} of {scale:e}"
    );
    // Friction took a good part of the spin, and the orientation stayed a unit quaternion.
    assert!(b.angular_momentum[0] < 0.95 * l_sphere0[0] && b.angular_momentum[0] > 0.0);
    let q = b.orientation;
    assert!((q.iter().map(|x| x * x).sum::<Real>() - 1.0).abs() < 1e-12);
    // Friction dragged the block the way the sphere's bottom moved: +y for a spin about +x.
    let p = momentum(&r.body, &r.state.v);
    assert!(p.y > 0.0, "the block should be dragged along +y: {p:?}");
}

/// A free body (no contact) keeps its angular momentum exactly, whatever its inertia; an
/// asymmetric box precesses (its spin vector moves) with its energy kept to 1e-6.
#[test]
fn free_body_keeps_its_angular_momentum_exactly() {
    let body = steel_block([3, 3, 3]);
    let (mut state, mut it) = at_rest(&body);
    let geometry = Geometry::D3(
        parry3d_f64::shape::SharedShape::cuboid(3e-3, 2e-3, 1e-3),
        parry3d_f64::math::Rotation::IDENTITY,
    );
    let mass = geometry.mass(7800.0, 1.0);
    let brick = RigidBody::new(
        "brick",
        geometry,
        Motion::Dynamic { mass },
        [1.0, 1.0, 1.0],
        [1.0, 0.0, 0.0],
        0.0,
    )
    .with_spin([300.0, 20.0, 500.0], 3);
    let mut contact = Contact::new(&body, vec![brick], ContactOptions::for_body(&body));
    let (l0, e0, w0) = {
        let b = &contact.bodies[0];
        (b.angular_momentum, b.kinetic(), b.spin)
    };
    for _ in 0..20_000 {
        it.step_with(&body, &mut state, Some(&mut contact));
    }
    let b = &contact.bodies[0];
    assert_eq!(
        b.angular_momentum, l0,
        "a free body's angular momentum is not touched"
    );
    assert!(
        (b.kinetic() / e0 - 1.0).abs() < 1e-6,
        "energy {} of {e0}",
        b.kinetic()
    );
    let dw = norm([0, 1, 2].map(|c| b.spin[c] - w0[c]));
    assert!(
        dw > 1e-3 * norm(w0),
        "an asymmetric body precesses: {:?} from {w0:?}",
        b.spin
    );
    // The centre of mass moves on at its velocity, to the rounding of the 20 000 additions
    // `x += v dt` (each within half an ulp of x; how they add up depends on dt's last bits).
    let t = 20_000.0 * it.dt();
    let drift = (b.position[0] - (1.0 + t)).abs();
    assert!(
        drift <= 20_000.0 * 0.5 * f64::EPSILON * (1.0 + t),
        "centre of mass off by {drift:e}"
    );
}

/// A sphere hitting a block obliquely with friction leaves rolling: it turns about the axis
/// normal to its sliding direction and the surface normal (here -x for sliding along +y on a
/// top face), and the lattice ledger still closes.
#[test]
fn oblique_impact_sets_a_projectile_rotating() {
    let mut r = bounce_setup();
    r.contact.bodies[0].friction = 0.5;
    r.contact.bodies[0].velocity = [0.0, 3.0, -5.0];
    let l0 = total_angular_momentum(&r);
    run_until_separated(&mut r, 20_000);
    let b = &r.contact.bodies[0];
    println!(
        "spin after the impact {:?} rad/s, torque {:?}",
        b.spin, b.torque
    );
    // Rolling along +y on a face with normal +z: w = n x v / r points along -x... the friction
    // on the sphere acts along -y at its bottom, so its torque (and spin) is about -x.
    assert!(
        b.spin[0] < -1.0,
        "the sphere should turn about -x: {:?}",
        b.spin
    );
    assert!(b.spin[1].abs() < 1e-3 * b.spin[0].abs() && b.spin[2].abs() < 1e-3 * b.spin[0].abs());
    let l1 = total_angular_momentum(&r);
    let dl = norm([0, 1, 2].map(|c| l1[c] - l0[c]));
    assert!(
        dl <= 1e-9 * norm(l0),
        "angular momentum changed by {dl:e} of {:e}",
        norm(l0)
    );
    let bal = r.it.energy(&r.body, &mut r.state);
    assert!(
        bal.relative_error < 1e-3,
        "lattice balance {}",
        bal.relative_error
    );
}

/// A checkpoint of a turning body (its snapshot: orientation, spin, angular momentum, torque
/// with the rest) continues bit for bit, and a snapshot from before rotation existed (9 values
/// per body) still restores.
#[test]
fn turning_bodies_restart_bit_for_bit() {
    let setup = || {
        let mut r = bounce_setup();
        r.contact.bodies[0].friction = 0.5;
        r.contact.bodies[0].velocity = [0.0, 3.0, -5.0];
        r.contact.bodies[0] = r.contact.bodies[0]
            .clone()
            .with_spin([500.0, -300.0, 100.0], 3);
        r
    };
    let mut a = setup();
    // Into the contact, and some way through it.
    let mut k = 0;
    while a.contact.bodies[0].torque == [0.0; 3] {
        a.it.step_with(&a.body, &mut a.state, Some(&mut a.contact));
        k += 1;
        assert!(k < 20_000, "the sphere never touched");
    }
    for _ in 0..20 {
        a.it.step_with(&a.body, &mut a.state, Some(&mut a.contact));
    }
    assert!(
        a.contact.bodies[0].torque != [0.0; 3],
        "the sphere must be in contact"
    );
    let (state, ck, snap) = (a.state.clone(), a.it.checkpoint(), a.contact.snapshot());
    for _ in 0..300 {
        a.it.step_with(&a.body, &mut a.state, Some(&mut a.contact));
    }
    let mut b = setup();
    b.state = state;
    b.it = Integrator::resume(
        &b.body,
        &b.state,
        Loading::default(),
        &IntegratorOptions::default(),
        &ck,
    )
    .unwrap();
    b.contact.restore(&snap).unwrap();
    for _ in 0..300 {
        b.it.step_with(&b.body, &mut b.state, Some(&mut b.contact));
    }
    assert!(a.state.u == b.state.u && a.state.v == b.state.v);
    let (x, y) = (&a.contact.bodies[0], &b.contact.bodies[0]);
    assert_eq!(
        (
            x.position,
            x.velocity,
            x.orientation,
            x.spin,
            x.angular_momentum
        ),
        (
            y.position,
            y.velocity,
            y.orientation,
            y.spin,
            y.angular_momentum
        )
    );
    // The old layout: position, velocity, reaction per body.
    let old: Vec<Real> = [1.0]
        .into_iter()
        .chain(snap[1..10].iter().copied())
        .chain(snap[snap.len() - 3..].iter().copied())
        .collect();
    let mut c = setup();
    c.contact.restore(&old).unwrap();
    assert_eq!(c.contact.bodies[0].position, [snap[1], snap[2], snap[3]]);
    assert_eq!(
        c.contact.bodies[0].orientation,
        hooke_contact::rigid::IDENTITY
    );
    assert!(c.contact.restore(&snap[..snap.len() - 1]).is_err());
}

/// A kinematic body spinning in place (a roller about x, friction 0.5) drags the free block it
/// presses on along y, the way its bottom moves, and does not move itself.
#[test]
fn a_spinning_kinematic_roller_drags_a_block() {
    let body = steel_block([9, 9, 5]);
    let (mut state, mut it) = at_rest(&body);
    let opts = ContactOptions::for_body(&body);
    let r = 3e-3;
    let geometry = Geometry::D3(
        parry3d_f64::shape::SharedShape::ball(r),
        parry3d_f64::math::Rotation::IDENTITY,
    );
    let still = [
        TimeFunction::Constant(0.0),
        TimeFunction::Constant(0.0),
        TimeFunction::Constant(0.0),
    ];
    // Pressed 0.05 a into the contact range of the top face (z = 4 a).
    let at = [4.0 * A, 4.0 * A, 4.0 * A + opts.radius + r - 0.05 * A];
    let roller = RigidBody::new(
        "roller",
        geometry,
        Motion::Kinematic(still),
        at,
        [0.0; 3],
        0.5,
    )
    .with_spin([2000.0, 0.0, 0.0], 3);
    assert!(roller.inertia.is_none() && roller.spin == [2000.0, 0.0, 0.0]);
    let mut contact = Contact::new(&body, vec![roller], opts);
    for _ in 0..400 {
        it.step_with(&body, &mut state, Some(&mut contact));
    }
    let p = momentum(&body, &state.v);
    let b = &contact.bodies[0];
    println!(
        "block momentum {p:?}, roller at {:?}, orientation {:?}",
        b.position, b.orientation
    );
    // Bottom of a roller spinning +x moves along +y: the block follows.
    assert!(p.y > 0.0 && p.y.abs() > 10.0 * p.x.abs(), "{p:?}");
    assert_eq!(b.position, at);
    // It turned by 2000 rad/s for 400 steps: the quaternion's angle says so.
    let angle = 2.0 * b.orientation[1].atan2(b.orientation[0]);
    let expect = (2000.0 * 400.0 * it.dt()) % (2.0 * std::f64::consts::PI);
    let wrapped = (angle - expect).rem_euclid(2.0 * std::f64::consts::PI);
    assert!(
        wrapped.min(2.0 * std::f64::consts::PI - wrapped) < 1e-9,
        "{angle} vs {expect}"
    );
}

/// In 2D (a plate), a disk striking a free plate obliquely with friction turns about z only,
/// the way it rolls, and the plate and disk conserve angular momentum to round-off.
#[test]
fn a_disk_on_a_plate_turns_about_z() {
    let body = steel(Lattice::hex_box(21, 11, A, 2e-3).unwrap());
    let (state, it) = at_rest(&body);
    let opts = ContactOptions::for_body(&body);
    let top = (0..body.nodes())
        .map(|i| body.lattice.pos.y()[i])
        .fold(0.0, Real::max);
    let r = 3e-3;
    let geometry = Geometry::ball(2, r);
    let mass = geometry.mass(7800.0, 2e-3);
    let disk = RigidBody::new(
        "disk",
        geometry,
        Motion::Dynamic { mass },
        [10.0 * A, top + opts.radius + r + 0.1 * A, 0.0],
        [4.0, -5.0, 0.0],
        0.5,
    );
    let i = disk.inertia.expect("a dynamic disk turns");
    assert!((i.tensor[2][2] / (0.5 * mass * r * r) - 1.0).abs() < 1e-9);
    assert!(i.inverse[0][0] == 0.0 && i.inverse[1][1] == 0.0);
    let contact = Contact::new(&body, vec![disk], opts);
    let mut run = Run {
        body,
        state,
        it,
        contact,
    };
    let l0 = total_angular_momentum(&run);
    run_until_separated(&mut run, 20_000);
    let l1 = total_angular_momentum(&run);
    let b = &run.contact.bodies[0];
    println!("disk spin {:?} rad/s", b.spin);
    // Sliding along +x on a face with normal +y: friction on its bottom acts along -x, a
    // torque about -z.
    assert!(
        b.spin[2] < -1.0 && b.spin[0] == 0.0 && b.spin[1] == 0.0,
        "{:?}",
        b.spin
    );
    assert!(b.position[2] == 0.0 && b.orientation[1] == 0.0 && b.orientation[2] == 0.0);
    let dl = norm([0, 1, 2].map(|c| l1[c] - l0[c]));
    assert!(
        dl <= 1e-9 * norm(l0),
        "angular momentum changed by {dl:e} of {:e}",
        norm(l0)
    );
}

/// A plate's rigid body that has turned (about z) keeps bounds in x and y that hold it, so the
/// contact lists keep only the nodes near it (an unbounded z once made every node of the plate
/// a candidate, a distance query each per step); z stays unbounded, and a half-space that
/// spins is unbounded wherever its turn mixes its unbounded axes in.
#[test]
fn turned_bodies_keep_bounds_that_hold_them() {
    let mut b = RigidBody::new(
        "projectile",
        Geometry::cuboid(2, [50e-3, 48e-3, 0.0]),
        Motion::Dynamic { mass: 0.77 },
        [-25e-3, 100e-3, 0.0],
        [32.0, 0.0, 0.0],
        0.0,
    );
    let (th, c) = (0.3 as Real, [-25e-3, 100e-3]);
    b.orientation = [(0.5 * th).cos(), 0.0, 0.0, (0.5 * th).sin()];
    let (lo, hi) = b.bounds();
    assert!(lo[2] == Real::NEG_INFINITY && hi[2] == Real::INFINITY);
    for (sx, sy) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
        let (x, y) = (sx * 25e-3, sy * 24e-3);
        let p = [
            c[0] + th.cos() * x - th.sin() * y,
            c[1] + th.sin() * x + th.cos() * y,
        ];
        for k in 0..2 {
            assert!(
                lo[k] - 1e-15 <= p[k] && p[k] <= hi[k] + 1e-15,
                "corner {p:?}: {lo:?} {hi:?}"
            );
        }
    }
    // Tight: the turned box's own extent, not more.
    let half = 25e-3 * th.cos() + 24e-3 * th.sin();
    assert!((hi[0] - lo[0] - 2.0 * half).abs() < 1e-12);
    // A kinematic half-space spinning about an axis in its plane reaches everywhere (parry
    // bounds a half-space by the largest reals).
    let mut wall = RigidBody::new(
        "wall",
        Geometry::halfspace(3, [0.0, 0.0, 1.0]),
        Motion::Kinematic([
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(0.0),
            TimeFunction::Constant(0.0),
        ]),
        [0.0; 3],
        [0.0; 3],
        0.0,
    );
    wall.orientation = [(0.1 as Real).cos(), (0.1 as Real).sin(), 0.0, 0.0];
    let (lo, hi) = wall.bounds();
    assert!(
        lo.iter().chain(&hi).all(|v| v.abs() > 1e300),
        "{lo:?} {hi:?}"
    );
}
