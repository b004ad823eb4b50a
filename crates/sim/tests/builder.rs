//! The builder refuses bad input with the item and the fix, never a panic; what it builds runs.

use hooke_core::loading::TimeFunction;
use hooke_core::LatticeKind;
use hooke_sim::{Bc, Builder, Face, Region, Solid};

fn plate() -> Builder {
    Builder::new(LatticeKind::Hex, 1e-3)
        .thickness(1e-3)
        .solid(Solid::cuboid([0.0; 3], [10e-3, 5e-3, 0.0]))
        .material(70e9, 0.25, 2500.0)
        .end_time(1e-6)
}

/// The plate held at its bottom edge ("bottom") and moved at its top edge ("top") by `top`.
fn gripped(top: impl FnOnce(Bc) -> Bc) -> Builder {
    let edge = |high| Bc::on(Region::Face(Face { axis: 1, high }));
    plate()
        .boundary(edge(false).fixed(0).fixed(1).named("bottom"))
        .boundary(top(edge(true)).named("top"))
}

fn err(b: Builder) -> hooke_sim::BuildError {
    b.build().expect_err("should be refused")
}

#[test]
fn bad_input_names_the_item_and_the_fix() {
    let e = err(plate().boundary(
        Bc::on(Region::Box {
            lo: [1.0, 1.0, 0.0].into(),
            hi: [2.0, 2.0, 0.0].into(),
        })
        .fixed(0),
    ));
    assert_eq!(e.key, "boundary[0].region");
    assert!(e.message.contains("selects no node"), "{e}");

    let e = err(plate().boundary(
        Bc::on(Region::Face(Face {
            axis: 0,
            high: false,
        }))
        .fixed(2),
    ));
    assert_eq!(e.key, "boundary[0].fixed");
    assert!(e.message.contains("2D body"), "{e}");

    let e = err(plate()
        .quasi_static(4)
        .contact(hooke_sim::ContactSpec::default(), Vec::new()));
    assert_eq!(e.key, "contact");
    assert!(e.message.contains("explicit"), "{e}");

    let e = err(plate().material(70e9, 0.7, 2500.0));
    assert_eq!(e.key, "material.poisson");

    let e = err(Builder::new(LatticeKind::Hex, 1e-3)
        .material(70e9, 0.25, 2500.0)
        .end_time(1e-6));
    assert_eq!(e.key, "lattice.thickness");

    let e = err(plate().boundary(Bc::on(Region::All)));
    assert!(e.message.contains("does nothing"), "{e}");

    let e = err(plate().end_time(-1.0));
    assert_eq!(e.key, "solver.end_time");

    let e = err(Builder::new(LatticeKind::Cubic, 1e-9)
        .solid(Solid::cuboid([0.0; 3], [1.0, 1.0, 1.0]))
        .material(70e9, 0.25, 2500.0)
        .end_time(1e-6));
    assert_eq!(e.key, "lattice.spacing");
    assert!(e.message.contains("memory"), "{e}");

    let e = err(plate().boundary(
        Bc::on(Region::All).velocity(1, TimeFunction::Table(vec![(1.0, 0.0), (0.5, 1.0)])),
    ));
    assert_eq!(e.key, "boundary[0].motion[0]");
}

/// A simulation built in code runs through the library and writes its outputs, the reactions
/// among them; the bottom grip holds what the top one pulls (equilibrium at the end of a slow,
/// damped pull, within 2 %).
#[test]
fn a_built_simulation_runs_and_its_grips_balance() {
    let dir = std::env::temp_dir().join(format!("hooke-builder-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sim = gripped(|top| {
        top.displacement(
            1,
            TimeFunction::SmoothRamp {
                t0: 0.0,
                t1: 20e-6,
                from: 0.0,
                to: 1e-7,
            },
        )
    })
    .damping(2e5)
    .end_time(40e-6)
    .output_every(10e-6)
    .build()
    .unwrap();
    let s = hooke_sim::run(
        sim,
        hooke_sim::RunOptions::new(&dir, "plate"),
        &mut hooke_sim::Silent,
    )
    .unwrap();
    let (bottom, top) = (s.reactions[0].force[1], s.reactions[1].force[1]);
    eprintln!("bottom {bottom:e} N, top {top:e} N");
    assert!(
        top > 0.0 && ((bottom + top) / top).abs() < 0.02,
        "bottom {bottom} top {top}"
    );
    assert!((s.reactions[1].displacement[1] - 1e-7).abs() < 1e-12);
    for f in [
        "plate.pvd",
        "plate_energy.csv",
        "plate_reactions.csv",
        "plate.ckpt",
        "run.json",
    ] {
        assert!(dir.join(f).exists(), "no {f}");
    }
    let csv = std::fs::read_to_string(dir.join("plate_reactions.csv")).unwrap();
    assert!(csv.lines().any(|l| l.contains(",top,")), "{csv}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A random body keeps what a run reads, not what only its set-up read: the springs' volumes
/// (in its stiffnesses now) and the boundary areas (in its traction loads now) are freed once
/// it is built, and the loads still add up to the traction times the loaded face's area.
#[test]
fn a_random_body_sheds_its_set_up_volumes_once_built() {
    let (w, h, t) = (10e-3, 5e-3, 1e-3);
    let traction = 2e6;
    let sim = Builder::new(LatticeKind::Random2d, 0.5e-3)
        .thickness(t)
        .solid(Solid::cuboid([0.0; 3], [w, h, 0.0]))
        .material(70e9, 0.25, 2500.0)
        .boundary(
            Bc::on(Region::Face(Face {
                axis: 1,
                high: false,
            }))
            .fixed(0)
            .fixed(1),
        )
        .boundary(
            Bc::on(Region::Face(Face {
                axis: 1,
                high: true,
            }))
            .traction([0.0, traction, 0.0], 1, TimeFunction::Constant(1.0)),
        )
        .end_time(1e-6)
        .build()
        .unwrap();
    let lat = &sim.body.lattice;
    let cells = lat.cells.as_ref().expect("a random lattice has cells");
    assert!(lat.is_shed());
    assert!(cells.spring.is_empty() && cells.surface.is_empty());
    assert_eq!(cells.node.len(), sim.body.nodes());
    let parts: Vec<_> = sim.body.footprint().into_iter().map(|(p, _)| p).collect();
    assert!(parts.contains(&"node volumes") && parts.contains(&"stiffnesses"));
    // The rest lengths go too where no kernel streams them: a case's random lattice is built
    // where it stands, so each one is `|X_j - X_i|` to the bit.
    let may_stream = hooke_core::kernel::Kernel::csr_may_run(lat.period);
    assert_eq!(lat.bonds.stored_rest().is_some(), may_stream);
    // The top face's area is w t; the loads spread the traction over exactly that (to the
    // rounding of the boundary facets' areas).
    let total: f64 = sim.loading.loads.iter().map(|l| l.force[1]).sum();
    let want = traction * w * t;
    assert!(
        ((total - want) / want).abs() < 1e-9,
        "loads add up to {total} N, the traction over the face to {want} N"
    );
    // A body cannot be built again from the shed lattice: it would have no spring volumes.
    let again = std::panic::catch_unwind(|| {
        hooke_core::body::Body::from_cells(sim.body.lattice.clone(), 1.0, 0.0, 1.0)
    });
    assert!(again.is_err());
}

/// Progress reports every step (an observer asking that often): the energy they show is
/// evaluated again only once twenty times its cost has passed, so the reports cannot take over
/// the run, and a report that shows an earlier evaluation says when it was.
#[test]
fn progress_reports_reuse_the_energy_they_cannot_afford() {
    struct EveryStep(Vec<hooke_sim::Progress>);
    impl hooke_sim::Observer for EveryStep {
        fn progress_interval(&self) -> Option<std::time::Duration> {
            Some(std::time::Duration::ZERO)
        }
        fn progress(&mut self, p: &hooke_sim::Progress) {
            self.0.push(p.clone());
        }
    }
    let dir = std::env::temp_dir().join(format!("hooke-progress-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sim = Builder::new(LatticeKind::Hex, 0.1e-3)
        .thickness(1e-3)
        .solid(Solid::cuboid([0.0; 3], [10e-3, 5e-3, 0.0]))
        .material(70e9, 0.25, 2500.0)
        .boundary(
            Bc::on(Region::Face(Face {
                axis: 0,
                high: true,
            }))
            .velocity(0, TimeFunction::Constant(1.0)),
        )
        .end_time(20e-6)
        .output_every(1.0)
        .build()
        .unwrap();
    let mut obs = EveryStep(Vec::new());
    let s = hooke_sim::run(sim, hooke_sim::RunOptions::new(&dir, "p"), &mut obs).unwrap();
    let reports = &obs.0;
    assert!(
        reports.len() as u64 + 1 >= s.steps,
        "{} reports",
        reports.len()
    );
    // The first report evaluates; none shows an evaluation from its future or older than the
    // one before it, and reports that show one evaluation show the same numbers.
    assert_eq!(reports[0].energy_time, reports[0].time);
    for w in reports.windows(2) {
        assert!(w[1].energy_time <= w[1].time);
        assert!(w[1].energy_time >= w[0].energy_time);
        if w[1].energy_time == w[0].energy_time {
            assert_eq!(w[1].energy.to_bits(), w[0].energy.to_bits());
            assert_eq!(w[1].balance.to_bits(), w[0].balance.to_bits());
        }
    }
    // An evaluation costs more than a step (the reference law's four passes against the
    // kernel's two sweeps), so most reports show an earlier one, and some are fresh.
    let fresh = reports.iter().filter(|p| p.energy_time == p.time).count();
    eprintln!("{fresh} of {} reports evaluated the energy", reports.len());
    assert!(
        fresh * 4 < reports.len(),
        "{fresh} of {} reports evaluated the energy",
        reports.len()
    );
    assert!(
        fresh >= 2,
        "only {fresh} evaluations in {} reports",
        reports.len()
    );
    assert!(reports.iter().all(|p| p.energy > 0.0 || p.time == 0.0));
    std::fs::remove_dir_all(&dir).ok();
}

/// A run ends on a frame, and its summary takes the energy balance and the reactions from it;
/// a run resumed at its end writes no frame and evaluates them: the same bits.
#[test]
fn a_summary_from_the_last_frame_is_the_evaluated_one() {
    let dir = std::env::temp_dir().join(format!("hooke-summary-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sim = || {
        gripped(|top| top.velocity(1, TimeFunction::Constant(0.5)))
            .end_time(5e-6)
            .output_every(2e-6)
            .build()
            .unwrap()
    };
    let first = hooke_sim::run(
        sim(),
        hooke_sim::RunOptions::new(&dir, "s"),
        &mut hooke_sim::Silent,
    )
    .unwrap();
    let mut opts = hooke_sim::RunOptions::new(dir.join("again"), "s");
    opts.resume = Some(dir.join("s.ckpt"));
    let again = hooke_sim::run(sim(), opts, &mut hooke_sim::Silent).unwrap();
    assert_eq!(again.steps, 0, "the resumed run starts at its end");
    assert!(first.energy.kinetic > 0.0 && first.reactions[1].force[1] != 0.0);
    let bits = |s: &hooke_sim::Summary| {
        let e = &s.energy;
        let mut v = vec![
            e.kinetic,
            e.strain_direct,
            e.strain_dispersive,
            e.external_work,
            e.boundary_work,
            e.balance_error,
            s.balance,
        ];
        for r in &s.reactions {
            v.extend(r.force);
        }
        v.into_iter().map(f64::to_bits).collect::<Vec<_>>()
    };
    assert_eq!(bits(&first), bits(&again));
    std::fs::remove_dir_all(&dir).ok();
}

/// A reaction record between frames evaluates only the prescribed nodes' forces: the bits of
/// the boundary forces after a whole-body force evaluation, at several times of a pull.
#[test]
fn reactions_from_the_prescribed_nodes_are_the_whole_evaluations() {
    let dir = std::env::temp_dir().join(format!("hooke-reactions-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // The left edge prescribed too, so that its corners are prescribed twice along y (the
    // velocity written last counts, as in the whole evaluation), with damping reading it.
    let left = Bc::on(Region::Face(Face {
        axis: 0,
        high: false,
    }))
    .velocity(1, TimeFunction::Constant(-0.2));
    let sim = gripped(|top| top.velocity(1, TimeFunction::Constant(0.5)))
        .boundary(left)
        .damping(1e5)
        .end_time(5e-6)
        .build()
        .unwrap();
    let mut run = hooke_sim::Run::start(sim, hooke_sim::RunOptions::new(&dir, "r")).unwrap();
    for _ in 0..4 {
        run.steps(37, &mut hooke_sim::Silent).unwrap();
        let (body, it) = (&run.simulation().body, run.integrator());
        let mut state = run.simulation().state.clone();
        let v = it.full_velocity(body, &mut state);
        let whole = it.boundary_forces(body, &state, &v);
        let sparse = it.boundary_forces_now(body, &run.simulation().state);
        let bits =
            |c: &hooke_core::Coords| c.as_flat().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&whole), bits(&sparse));
        assert!(whole.as_flat().iter().any(|&f| f != 0.0));
    }
    std::fs::remove_dir_all(&dir).ok();
}
