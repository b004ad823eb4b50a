//! Fracture energy: the energy a crack dissipates per unit of new area matches the G_c the
//! springs were calibrated for, and a mode-I crack loaded dynamically runs straight, below the
//! Rayleigh speed.

use hooke_core::dynamics::{Integrator, IntegratorOptions, TimeStep};
use hooke_core::loading::{Loading, Motion, Prescribed, TimeFunction};
use hooke_core::material::q_from_nu;
use hooke_core::moduli::bulk_moduli;
use hooke_core::{Body, Lattice, LatticeKind, Real, State};
use hooke_fracture::toughness::{strip_test, StripTest};
use hooke_fracture::{Crack, CriticalStretch, Fracture};

/// Pulling a pre-cracked strip apart quasi-statically (fixed grips opened event by event,
/// equilibrium after every break): the work of the grips minus the stored energy, per unit of
/// new crack area in steady growth, is within 5 % of G_c, for the cubic and the hexagonal
/// lattice at nu = 0, 0.25 and 0.45. The calibration table was measured on strips of 40 rows
/// (hex) and 20 planes (cubic); these strips are 24 rows (hex) and 24 planes (cubic), so the
/// test also checks that the toughness is a property of the material, not of the specimen.
/// The steady-state release `U_strip / length` at the strain the crack ran at, an independent
/// route to the same number, must agree too, except for the cubic lattice at nu = 0.45: there
/// (q = 2.4) the load needed creeps up as the crack grows through the window (about 6 % in
/// strain), so the strip is never in steady state and the release at the final strain
/// overstates the dissipation by 30 %.
///
/// The hexagonal strips run in the default suite, the cubic ones (most of the time) in
/// [`dissipated_energy_per_crack_area_matches_g_c_cubic`].
#[test]
fn dissipated_energy_per_crack_area_matches_g_c() {
    dissipated_energy_matches(LatticeKind::Hex);
}

#[test]
#[ignore = "slow: three cubic strips 24 planes high, about 3 minutes"]
fn dissipated_energy_per_crack_area_matches_g_c_cubic() {
    dissipated_energy_matches(LatticeKind::Cubic);
}

fn dissipated_energy_matches(kind: LatticeKind) {
    for nu in [0.0, 0.25, 0.45] {
        let q = q_from_nu(kind, nu).unwrap();
        let r = strip_dissipates_g_c(&StripTest::new(kind, q, 24, 10), nu);
        let steady = kind == LatticeKind::Hex || nu < 0.4;
        assert!(
            !steady || (r.g_release / r.g_calibrated - 1.0).abs() < 0.05,
            "{kind:?} nu = {nu}: release {:.4} G_c",
            r.g_release / r.g_calibrated
        );
    }
}

/// The spring-energy criterion, calibrated to the same G_c (`SpringEnergy::from_fracture_energy`
/// divides its own measured toughness out of w_c): the same strips dissipate G_c within 5 %
/// (hex nu_2D = -0.5, 0, 0.45; cubic nu = 0, 0.4). Uncalibrated (w_c matched to s_c under
/// uniform stretch) the energy crack dissipates from 0.10 (hex, nu_2D = -0.9) to 4.3 (cubic,
/// 0.45) times the stretch criterion's. Cubic nu = 0.45 is outside the energy criterion's
/// range: the calibration strip's crack roughened there, and this strip gives 0.85 G_c.
///
/// The hexagonal strips run in the default suite, the cubic ones in
/// [`energy_criterion_dissipates_g_c_cubic`].
#[test]
fn energy_criterion_dissipates_g_c() {
    energy_criterion_on(LatticeKind::Hex, &[-0.5, 0.0, 0.45]);
}

#[test]
#[ignore = "slow: two cubic strips 24 planes high, about 2 minutes"]
fn energy_criterion_dissipates_g_c_cubic() {
    energy_criterion_on(LatticeKind::Cubic, &[0.0, 0.4]);
}

fn energy_criterion_on(kind: LatticeKind, nus: &[Real]) {
    for &nu in nus {
        let q = q_from_nu(kind, nu).unwrap();
        let mut t = StripTest::new(kind, q, 24, 10);
        t.energy = true;
        strip_dissipates_g_c(&t, nu);
    }
}

/// Run a strip, print its figures, and check that its crack dissipated G_c within 5 %, over a
/// window of at least 9 spacings, with at most a tenth of the broken springs off the plane.
fn strip_dissipates_g_c(t: &StripTest, nu: Real) -> hooke_fracture::toughness::StripResult {
    let kind = t.kind;
    let r = strip_test(t).unwrap();
    eprintln!(
        "{kind:?} nu = {nu}, {} criterion: G_measured / G_c = {:.4}, release / G_c = {:.4}, {} \
         broken, {} off the plane",
        if t.energy { "energy" } else { "stretch" },
        r.ratio(),
        r.g_release / r.g_calibrated,
        r.broken,
        r.off_plane
    );
    assert!(
        (r.ratio() - 1.0).abs() < 0.05,
        "{kind:?} nu = {nu}: dissipated {:.4} G_c",
        r.ratio()
    );
    assert!(r.window >= 9.0 && r.off_plane * 10 <= r.broken);
    r
}

/// Rayleigh speed from c_T and c_L: the root in (0, 1) of
/// `(2 - x^2)^2 = 4 sqrt(1 - x^2) sqrt(1 - x^2 c_T^2 / c_L^2)`, x = c / c_T.
fn rayleigh(c_t: Real, c_l: Real) -> Real {
    let f = |x: Real| {
        (2.0 - x * x).powi(2)
            - 4.0 * (1.0 - x * x).sqrt() * (1.0 - x * x * c_t * c_t / (c_l * c_l)).sqrt()
    };
    let (mut lo, mut hi) = (0.5, 0.999_999);
    for _ in 0..100 {
        let m = 0.5 * (lo + hi);
        if f(lo) * f(m) <= 0.0 {
            hi = m;
        } else {
            lo = m;
        }
    }
    0.5 * (lo + hi) * c_t
}

/// A dynamic mode-I crack in a hexagonal strip whose grips are opened smoothly to
/// `G = over x G_c` and held. Returns (growth, springs broken on the line, off it, fastest tip
/// speed over 10 spacings / c_R).
fn dynamic_strip(nu: Real, over: Real, ramp: Real, damping: Real) -> (Real, usize, usize, Real) {
    let kind = LatticeKind::Hex;
    let (nx, rows) = (220, 40);
    let q = q_from_nu(kind, nu).unwrap();
    let body = Body::uniform(Lattice::hex_box(nx, rows, 1.0, 1.0).unwrap(), 1.0, q, 1.0);
    let dy = (3.0 as Real).sqrt() / 2.0;
    let (yc, top) = ((rows as Real / 2.0 - 0.5) * dy, (rows - 1) as Real * dy);
    let notch = 40.0;
    let g_c = 1e-6;
    let mut state = State::new(&body);
    let crit = CriticalStretch::from_fracture_energy(kind, 1.0, 1.0, q, 1.0, g_c).unwrap();
    let mut fr = Fracture::new(&body, Box::new(crit));
    let crack = Crack::Segment {
        a: [-1.0, yc],
        b: [notch + 0.1, yc],
    };
    fr.precrack(&body, &mut state, &[crack]).unwrap();
    // Far ahead the strip is in uniaxial strain: G = 1/2 C11 eps^2 H.
    let m = bulk_moduli(kind, 1.0, 1.0, q);
    let eps = (2.0 * over * g_c / (m.c11 * top)).sqrt();
    let loading = strip_grips(&body, &mut fr, top, nx as Real - 30.0, eps * top, ramp);
    let opts = IntegratorOptions {
        time_step: TimeStep::Auto { safety: 0.8 },
        damage_proof: true,
        damping,
        ..Default::default()
    };
    let mut it = Integrator::new(&body, &mut state, loading, &opts).unwrap();
    let bonds = &*body.lattice.bonds;
    let crosses = |b: usize| {
        let [i, j] = bonds.ends[b].map(|v| v as usize);
        (body.lattice.pos.y()[i] - yc) * (body.lattice.pos.y()[j] - yc) < 0.0
    };
    let mut was_alive = state.alive().to_vec();
    let (mut on, mut off) = (0usize, 0usize);
    let mut tip = notch;
    let mut history: Vec<(Real, Real)> = Vec::new();
    while state.time < ramp + 1500.0 && tip < nx as Real - 40.0 {
        it.step(&body, &mut state);
        if fr.check(&body, &mut state, &mut it).broken > 0 {
            for b in 0..bonds.len() {
                if was_alive[b] && !state.alive()[b] {
                    if crosses(b) {
                        on += 1;
                        let [i, j] = bonds.ends[b].map(|v| v as usize);
                        tip = tip.max(0.5 * (body.lattice.pos.x()[i] + body.lattice.pos.x()[j]));
                        history.push((state.time, tip));
                    } else {
                        off += 1;
                    }
                }
            }
            was_alive.copy_from_slice(state.alive());
        }
    }
    it.check(&body, &state).unwrap();
    let rho = 1.0 / dy; // mass per area: one unit mass per cell of area sqrt(3)/2
    let c_r = rayleigh((m.c44 / rho).sqrt(), (m.c11 / rho).sqrt());
    let mut vmax: Real = 0.0;
    for (k, &(t0, x0)) in history.iter().enumerate() {
        if let Some(&(t1, x1)) = history[k..].iter().find(|h| h.1 >= x0 + 10.0) {
            vmax = vmax.max((x1 - x0) / (t1 - t0));
        }
    }
    (tip - notch, on, off, vmax / c_r)
}

/// The grips of a dynamic strip: the bottom (y = 0) and top (y = `top`) node rows are held in x
/// and opened apart in y by `opening` with a smooth ramp over `ramp`; they and everything beyond
/// `far_x` never break (the crack must not start at the far end).
fn strip_grips(
    body: &Body,
    fr: &mut Fracture,
    top: Real,
    far_x: Real,
    opening: Real,
    ramp: Real,
) -> Loading {
    let pos = &body.lattice.pos;
    let rows_where = |sel: &dyn Fn(Real) -> bool| -> Vec<u32> {
        (0..body.nodes() as u32)
            .filter(|&i| sel(pos.y()[i as usize]))
            .collect()
    };
    let (lower, upper) = (rows_where(&|y| y < 1e-9), rows_where(&|y| y > top - 1e-9));
    let mut prescribed = Vec::new();
    for (nodes, sign) in [(lower.clone(), -1.0), (upper.clone(), 1.0)] {
        prescribed.push(Prescribed {
            nodes: nodes.clone(),
            axis: 0,
            motion: Motion::Fixed,
        });
        prescribed.push(Prescribed {
            nodes,
            axis: 1,
            motion: Motion::Displacement(TimeFunction::SmoothRamp {
                t0: 0.0,
                t1: ramp,
                from: 0.0,
                to: sign * 0.5 * opening,
            }),
        });
    }
    let mut keep: Vec<u32> = lower.iter().chain(&upper).copied().collect();
    keep.extend((0..body.nodes() as u32).filter(|&i| pos.x()[i as usize] > far_x));
    fr.set_no_fail(&keep);
    Loading {
        prescribed,
        ..Default::default()
    }
}

/// The dynamic mode-I crack on the regular hexagonal lattice, a record of why the mode-I and
/// Kalthoff-Winkler cases use a random lattice: grips opened smoothly to 1.2 G_c over 400 time
/// units and held, mass-proportional damping 0.05, as in the random-lattice test. The crack does
/// not stay on its row: it leaves it after a few spacings and runs along the lattice's 60-degree
/// directions, so more springs break off the line than on it (nu = 0 / 0.25 / 0.45: 112 / 65 / 8
/// on, 270 / 233 / 377 off). The
/// lattice-trapping factor of 3 to 7 makes the crack start overdriven, and the six-fold lattice
/// offers it easy paths off the line. Should a change make the hexagonal crack run straight,
/// this test fails and the cases and docs/fracture.md should say so. `cargo test --release -p
/// hooke-tests --test toughness -- --ignored --nocapture`.
#[test]
#[ignore = "slow-ish record of a lattice limitation (about 30 s)"]
fn dynamic_crack_on_the_regular_hexagonal_lattice_leaves_its_row() {
    for nu in [0.0, 0.25, 0.45] {
        let (growth, on, off, v) = dynamic_strip(nu, 1.2, 400.0, 0.05);
        eprintln!("hex nu = {nu}: growth {growth:.1}, {on} springs on the line, {off} off it, fastest {v:.3} c_R");
        assert!(
            on + off >= 100,
            "nu = {nu}: only {} springs broke",
            on + off
        );
        assert!(
            off > on,
            "nu = {nu}: the crack stayed on its row ({on} on, {off} off): update the cases and docs/fracture.md"
        );
    }
}

/// The random2d calibration holds on node sets it was not measured with: the mean of three
/// strips (40 spacings high, 20-spacing window) dissipates G_c within 10 % (one strip scatters
/// by about 8 %).
#[test]
#[ignore = "slow (60 s here): random2d strips on unseen node sets; run with --ignored before changing fracture"]
fn random2d_crack_dissipates_g_c_on_unseen_node_sets() {
    let kind = LatticeKind::Random2d;
    let q = q_from_nu(kind, 0.25).unwrap();
    let mut t = StripTest::new(kind, q, 40, 20);
    let mut ratios = Vec::new();
    for seed in [11, 12, 13] {
        t.seed = seed;
        let r = strip_test(&t).unwrap();
        assert_eq!(
            r.off_plane, 0,
            "seed {seed}: springs broke away from the crack"
        );
        ratios.push(r.ratio());
    }
    let mean = ratios.iter().sum::<Real>() / 3.0;
    println!("random2d nu = 0.25: G / G_c = {ratios:.3?}, mean {mean:.3}");
    assert!((mean - 1.0).abs() < 0.10, "mean ratio {mean}");
}

/// What a dynamic crack in a strip left behind.
#[derive(Debug)]
struct DynamicCrack {
    /// Spacings from the notch tip to the furthest broken spring.
    growth: Real,
    /// Largest distance of a broken spring's midpoint from the crack line (spacings).
    band: Real,
    /// Smallest opening across the band behind the tip (10-spacing columns from the notch to
    /// half a strip height behind the tip), over the grips' opening: 1 when the faces are free.
    opening: Real,
    /// Fastest tip speed over 10 spacings, over c_R.
    speed: Real,
    /// Least-squares slope of the broken springs' midpoints y(x).
    slope: Real,
    broken: usize,
}

/// A dynamic mode-I crack in a strip of the 2D random lattice (blue noise, unit mean spacing,
/// `height` spacings high, 220 long, a 40-spacing pre-crack on its mid-line), grips opened
/// smoothly to `G = over x G_c` over 400 time units and held, mass-proportional damping 0.05.
/// Runs until the tip is 40 spacings from the far end (the last 30 never break).
fn dynamic_strip_random(nu: Real, over: Real, height: Real, seed: u64) -> DynamicCrack {
    use hooke_core::random::{calibration, RandomSpec, Sampler};
    let kind = LatticeKind::Random2d;
    let (len, top, ramp) = (220.0, height, 400.0);
    let spec = RandomSpec {
        sampler: Sampler::Poisson,
        seed,
    };
    let lattice = Lattice::random(2, [0.0; 3], [len, top, 0.0], 1.0, 1.0, spec, &|_| true).unwrap();
    let q = calibration::q_for_nu(kind, nu).unwrap();
    let body = Body::from_cells(lattice, 1.0, q, 1.0);
    let yc = 0.5 * top;
    let notch = 40.0;
    let g_c = 1e-6;
    let mut state = State::new(&body);
    let crit = CriticalStretch::from_fracture_energy(kind, 1.0, 1.0, q, 1.0, g_c).unwrap();
    let mut fr = Fracture::new(&body, Box::new(crit));
    fr.precrack(
        &body,
        &mut state,
        &[Crack::Segment {
            a: [-1.0, yc],
            b: [notch, yc],
        }],
    )
    .unwrap();
    // Uniaxial strain far ahead: G = 1/2 C11 eps^2 H, C11 = E/(1 - nu^2) in the plane.
    let e = calibration::youngs_for(kind, Sampler::Poisson, 1.0, q);
    let c11 = e / (1.0 - nu * nu);
    let mu = e / (2.0 * (1.0 + nu));
    let eps = (2.0 * over * g_c / (c11 * top)).sqrt();
    let pos = &body.lattice.pos;
    let loading = strip_grips(&body, &mut fr, top, len - 30.0, eps * top, ramp);
    let opts = IntegratorOptions {
        time_step: TimeStep::Auto { safety: 0.8 },
        damage_proof: true,
        damping: 0.05,
        ..Default::default()
    };
    let mut it = Integrator::new(&body, &mut state, loading, &opts).unwrap();
    let bonds = &*body.lattice.bonds;
    let mut was_alive = state.alive().to_vec();
    let mut tip = notch;
    let mut history: Vec<(Real, Real)> = Vec::new();
    let mut path: Vec<(Real, Real)> = Vec::new();
    while state.time < ramp + 1500.0 * height / 35.0 && tip < len - 40.0 {
        it.step(&body, &mut state);
        if fr.check(&body, &mut state, &mut it).broken > 0 {
            for b in 0..bonds.len() {
                if was_alive[b] && !state.alive()[b] {
                    let [i, j] = bonds.ends[b].map(|v| v as usize);
                    let (xm, ym) = (
                        0.5 * (pos.x()[i] + pos.x()[j]),
                        0.5 * (pos.y()[i] + pos.y()[j]),
                    );
                    path.push((xm, ym));
                    if xm > tip {
                        tip = xm;
                        history.push((state.time, tip));
                    }
                }
            }
            was_alive.copy_from_slice(state.alive());
        }
    }
    it.check(&body, &state).unwrap();
    let c_r = rayleigh(mu.sqrt(), c11.sqrt());
    let mut speed: Real = 0.0;
    for (k, &(t0, x0)) in history.iter().enumerate() {
        if let Some(&(t1, x1)) = history[k..].iter().find(|h| h.1 >= x0 + 10.0) {
            speed = speed.max((x1 - x0) / (t1 - t0));
        }
    }
    let n = path.len().max(1) as Real;
    let (mx, my) = (
        path.iter().map(|p| p.0).sum::<Real>() / n,
        path.iter().map(|p| p.1).sum::<Real>() / n,
    );
    let sxy: Real = path.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: Real = path
        .iter()
        .map(|p| (p.0 - mx).powi(2))
        .sum::<Real>()
        .max(1e-300);
    // Behind the tip one crack splits the strip into the two grips' pieces; whatever lies in
    // neither was cut loose by a second crack or a branch that rejoined.
    // Behind the tip the crack is open and traction-free: across the damage band the two
    // halves have moved apart by the whole grip opening (the halves are unloaded, so the
    // strain that was in them is gone). Bridges of springs that a rough crack leaves across
    // its faces hinge without carrying load (central forces), so piece counting would miss
    // the point; the opening does not.
    let mean_uy = |x0: Real, y0: Real, y1: Real| {
        let (mut s, mut n) = (0.0, 0usize);
        for i in 0..body.nodes() {
            if pos.x()[i] >= x0 && pos.x()[i] < x0 + 10.0 && pos.y()[i] >= y0 && pos.y()[i] < y1 {
                s += state.u.y()[i];
                n += 1;
            }
        }
        s / n as Real
    };
    let grip = eps * top;
    let mut opening = Real::INFINITY;
    let mut x0 = notch + 5.0;
    while x0 + 10.0 <= tip - 0.5 * height {
        let jump = mean_uy(x0, yc + 8.0, yc + 10.0) - mean_uy(x0, yc - 10.0, yc - 8.0);
        opening = opening.min(jump / grip);
        x0 += 10.0;
    }
    DynamicCrack {
        growth: tip - notch,
        band: path.iter().map(|p| (p.1 - yc).abs()).fold(0.0, Real::max),
        opening,
        speed: speed / c_r,
        slope: sxy / sxx,
        broken: path.len(),
    }
}

/// The dynamic mode-I requirement, on the random lattice, where no lattice row guides or
/// traps the crack: grips opened smoothly to 1.1 G_c (G_c calibrated on random2d strips) and
/// held, nu_2D = 0, 0.22 (glass) and 0.25, two node sets each. Wanted: the crack crosses the
/// strip (at least 130 spacings of growth); it is open and traction-free behind its tip (the
/// halves have moved apart by more than 0.8 of the grips' opening); it is straight (path slope
/// below 0.05 and every broken spring within 10 spacings of the line, while the grips are 17.5
/// away: a branch would run to them); its tip stays below c_R. Measured (the test prints them): growth 140, band 5.0-7.7
/// spacings, opening 0.90-0.94, tip 0.82-0.87 c_R, slope below 0.026. The crack is rough on the
/// lattice scale and micro-branches (about half the broken springs lie more than 2 spacings
/// off the line) at these speeds, as brittle cracks do above about 0.4 c_R, but no branch
/// grows towards the grips. At nu_2D = 0.45 it does not hold (band 10-12, the faces not open):
/// not asserted, see the fracture issue. The band is a lattice-scale property, see
/// `dynamic_crack_roughness_does_not_grow_with_the_strip`.
#[test]
fn dynamic_mode_one_crack_on_a_random_lattice_runs_straight_below_the_rayleigh_speed() {
    for nu in [0.0, 0.22, 0.25] {
        for seed in [1, 2] {
            let c = dynamic_strip_random(nu, 1.1, 35.0, seed);
            eprintln!("random2d nu = {nu}, seed {seed}: {c:?}");
            assert!(
                c.growth >= 130.0 && c.broken >= 140,
                "nu = {nu}, seed {seed}: {c:?}"
            );
            assert!(
                c.opening > 0.8,
                "nu = {nu}, seed {seed}: the crack is not open behind its tip: {c:?}"
            );
            assert!(
                c.slope.abs() < 0.05 && c.band <= 10.0,
                "nu = {nu}, seed {seed}: not straight: {c:?}"
            );
            assert!(
                c.speed > 0.0 && c.speed < 1.0,
                "nu = {nu}, seed {seed}: tip speed: {c:?}"
            );
        }
    }
}

/// The damage band of the running crack is set by the lattice, not the specimen: in a strip
/// twice as high (70 spacings, grips opened to 1.3 G_c: at 1.1-1.2 the crack in the taller strip
/// can arrest on a tough spot of the disorder) the broken springs lie no further from the line
/// than in the 35-spacing strip (at most 8 spacings, where the 35-spacing strips reached 7.7;
/// measured 4.4-6.6). In physical units the band
/// therefore shrinks with the spacing and the crack converges to a line. Measured tip speeds
/// 0.63-0.70 c_R. About 10 s.
#[test]
#[ignore = "slow: a 220 x 70 strip"]
fn dynamic_crack_roughness_does_not_grow_with_the_strip() {
    for nu in [0.0, 0.22, 0.25] {
        let c = dynamic_strip_random(nu, 1.3, 70.0, 1);
        eprintln!("random2d nu = {nu}, height 70: {c:?}");
        assert!(c.growth >= 90.0 && c.opening > 0.8, "nu = {nu}: {c:?}");
        assert!(c.band <= 8.0, "nu = {nu}: {c:?}");
        assert!(c.speed < 1.0, "nu = {nu}: {c:?}");
    }
}

/// Run a softening strip and return G_measured / G_f, G_f the fracture energy the calibration
/// promises for its springs (`Softening::from_fracture_energy` solves for the law that gives
/// it; `StripResult::ratio` divides by it).
fn softening_ratio(
    kind: LatticeKind,
    nu: Real,
    shape: hooke_fracture::SofteningShape,
    rho: Real,
    height: usize,
) -> Real {
    let q = q_from_nu(kind, nu).unwrap();
    let mut t = StripTest::new(kind, q, height, 6);
    t.softening = Some((shape, rho));
    t.max_solves = 200_000;
    let r = strip_test(&t).unwrap();
    eprintln!(
        "{kind:?} nu = {nu} {shape:?} rho = {rho}, {height} rows: G_measured / G_f = {:.4}, \
         release / G_f = {:.4}, {} broken, {} off the plane, {} solves",
        r.ratio(),
        r.g_release / r.g_calibrated,
        r.broken,
        r.off_plane,
        r.solves
    );
    r.ratio()
}

/// The softening table reproduces its own measurement: a hex strip of the table's size at one
/// of its points (nu_2D = 0.25, peak fraction 0.7) dissipates the G_f the calibration promises,
/// within 3 % (the strip's solver tolerances differ from the table's run).
#[test]
fn softening_strip_dissipates_the_tabulated_g_f() {
    use hooke_fracture::SofteningShape;
    let r = softening_ratio(LatticeKind::Hex, 0.25, SofteningShape::Linear, 0.7, 16);
    assert!((r - 1.0).abs() < 0.03, "G / G_f = {r}");
}

/// Softening springs calibrated from G_f (the measured factor F(nu, rho) folded in) dissipate G_f
/// on strips other than the calibration's: hex 20 rows (the table: 16) and cubic 14 and 18
/// planes (the table: 16), both shapes, at nu and peak fractions on and between the table's
/// points. Measured (in the order below): hex 1.010, 1.022, 1.005, 0.981, 0.98; cubic 1.014,
/// 1.042, 0.989, 1.003, 0.979 (2026-12-04). The cubic strip at nu = 0.25, rho = 0.65 is the
/// fragile point: its F is 0.674 at 16 planes (the table's size) but 0.613 and 0.611 at 18 and
/// 20, where the table's interpolation between 0.6 and 0.7 gives 0.620; an earlier build read
/// 1.09 at 18 planes there (recorded then with a 10 % tolerance). Columns at 0.65 and 0.675
/// measured at 16 planes were tried and dropped: they took the 18-plane strip to 0.910. Before the
/// tables were measured at 16 cubic planes with a column at rho = 0.6 (12 planes, no 0.6): hex
/// nu_2D = -0.5 at rho = 0.6 read 0.942 and cubic bilinear at 14 planes 1.055. Random2d is not
/// checked: its node sets scatter by 10-30 % at the table's strip size.
#[test]
#[ignore = "slow: about 3 minutes of strips"]
fn softening_springs_dissipate_g_f_on_other_strips() {
    use hooke_fracture::SofteningShape::{Bilinear, Linear};
    for (kind, nu, shape, rho, h, tol) in [
        (LatticeKind::Hex, 0.0, Linear, 0.5, 20, 0.05),
        (LatticeKind::Hex, 0.25, Linear, 0.7, 20, 0.05),
        (LatticeKind::Hex, 0.25, Bilinear, 0.5, 20, 0.05),
        (LatticeKind::Hex, -0.5, Linear, 0.6, 20, 0.05),
        (LatticeKind::Hex, 0.0, Linear, 0.55, 20, 0.05),
        (LatticeKind::Cubic, 0.25, Linear, 0.5, 14, 0.05),
        (LatticeKind::Cubic, 0.0, Bilinear, 0.7, 14, 0.05),
        (LatticeKind::Cubic, 0.25, Linear, 0.65, 18, 0.05),
        (LatticeKind::Cubic, 0.25, Linear, 0.66, 18, 0.05),
        (LatticeKind::Cubic, 0.0, Bilinear, 0.66, 14, 0.05),
    ] {
        let r = softening_ratio(kind, nu, shape, rho, h);
        assert!(
            (r - 1.0).abs() < tol,
            "{kind:?} nu = {nu} {shape:?} rho = {rho}, {h} rows: G / G_f = {r:.3}"
        );
    }
}

/// The random3d calibration (slabs 16 spacings high, 7 across, free faces; G the release rate
/// at the strain at which the crack runs, see `hooke_fracture::toughness`, "Random3d") holds on
/// node sets it was not measured with: the mean G / G_c of eight slabs (seeds 57-64, the table
/// was fitted on 17-56) within 5 % at each nu. Single slabs scatter by about 6 % (one standard
/// deviation), so eight pin the mean to about 2 %. Measured: see docs/fracture.md
/// (`docs/data/random3d_toughness_release.csv` has every slab). About 10 minutes a nu (0.45:
/// 40); run one nu with `HOOKE_R3_NU=0.25 cargo test --release -p hooke-tests --test toughness
/// random3d -- --ignored`.
#[test]
#[ignore = "slow: eight 3D slabs per nu, 10 to 40 minutes each nu"]
fn random3d_crack_runs_at_g_c_on_unseen_node_sets() {
    let kind = LatticeKind::Random3d;
    let nus: Vec<Real> = match std::env::var("HOOKE_R3_NU") {
        Ok(v) => vec![v.parse().expect("HOOKE_R3_NU: a Poisson's ratio")],
        Err(_) => NUS_R3.to_vec(),
    };
    let seeds = 57..=64;
    for nu in nus {
        let mut mean = 0.0;
        for seed in seeds.clone() {
            let mut t = StripTest::new(kind, q_from_nu(kind, nu).unwrap(), 16, 8);
            t.depth = 8;
            t.seed = seed;
            let r = strip_test(&t).unwrap();
            assert!(r.release_is_measure);
            eprintln!(
                "random3d nu = {nu}, node set {seed}: G / G_c = {:.3} (dissipated {:.3}, {} broken, \
                 {} off the plane)",
                r.ratio(),
                r.g_measured / r.g_calibrated,
                r.broken,
                r.off_plane
            );
            mean += r.ratio() / seeds.clone().count() as Real;
        }
        eprintln!("random3d nu = {nu}: mean G / G_c = {mean:.3}");
        assert!((mean - 1.0).abs() < 0.05, "nu = {nu}: mean ratio {mean}");
    }
}

/// The nu of the random3d table.
const NUS_R3: [Real; 4] = [0.0, 0.25, 0.35, 0.45];
