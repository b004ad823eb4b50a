//! Output and restart: VTK frames read back exactly, checkpoints continue a run bit for bit and
//! refuse what is not theirs, output problems are reported before a run starts, and a run killed
//! with SIGKILL leaves every listed frame readable.

use std::path::{Path, PathBuf};

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::{Loading, Motion, Prescribed, TimeFunction};
use hooke_core::material::q_from_nu;
use hooke_core::{Body, Lattice, LatticeKind, Real, State};
use hooke_fracture::{CriticalStretch, Fracture};
use hooke_io::checkpoint::digest;
use hooke_io::{Checkpoint, FieldSet, FrameExtras, IoError, VtkSeries};
use hooke_tests::{random_displacement, Rng};
use vtkio::model::{Attribute, DataSet, IOBuffer, Vtk};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn bar() -> Body {
    Body::uniform(
        Lattice::cubic_box([14, 5, 5], 1.0).unwrap(),
        1.0,
        q_from_nu(LatticeKind::Cubic, 0.4).unwrap(),
        1.0,
    )
}

fn pulled(body: &Body) -> Loading {
    let ends = |x: Real| {
        (0..body.nodes() as u32)
            .filter(|&i| (body.lattice.pos.x()[i as usize] - x).abs() < 0.1)
            .collect::<Vec<_>>()
    };
    let v = |to: Real| {
        Motion::Velocity(TimeFunction::SmoothRamp {
            t0: 0.0,
            t1: 10.0,
            from: 0.0,
            to,
        })
    };
    Loading {
        prescribed: vec![
            Prescribed {
                nodes: ends(0.0),
                axis: 0,
                motion: v(-5e-3),
            },
            Prescribed {
                nodes: ends(13.0),
                axis: 0,
                motion: v(5e-3),
            },
        ],
        ..Default::default()
    }
}

fn f64s(a: &Attribute) -> Vec<f64> {
    match a {
        Attribute::DataArray(d) => match &d.data {
            IOBuffer::F64(v) => v.clone(),
            other => panic!("expected f64 data, got {other:?}"),
        },
        _ => panic!("expected a data array"),
    }
}

/// Frames read back with the same point count and exactly the same field values; the
/// collection lists every frame with its time.
#[test]
fn vtk_frames_read_back_exactly() {
    let body = bar();
    let mut state = State::new(&body);
    let mut rng = Rng::new(4);
    state.u = random_displacement(&body, &mut rng, 0.01);
    state.kill_bond(&body, 3);
    let dir = tmpdir("frames");
    let mut series = VtkSeries::create(&dir, "bar", true).unwrap();
    let damage: Vec<Real> = (0..body.nodes()).map(|i| (i % 7) as Real / 7.0).collect();
    for step in 0..2 {
        state.step = step;
        state.time = step as Real * 0.25;
        let path = series
            .write(
                &body,
                &state,
                FrameExtras {
                    damage: Some(&damage),
                    ..Default::default()
                },
            )
            .unwrap();
        let vtk = Vtk::import(&path).unwrap();
        let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
            panic!("not an unstructured grid")
        };
        let piece = pieces[0].load_piece_data(None).unwrap();
        assert_eq!(piece.num_points(), body.nodes());
        let get = |name: &str| {
            piece
                .data
                .point
                .iter()
                .find(|a| a.name() == name)
                .unwrap_or_else(|| panic!("no {name}"))
        };
        let u = f64s(get("displacement"));
        for i in 0..body.nodes() {
            assert_eq!(
                [u[3 * i], u[3 * i + 1], u[3 * i + 2]],
                [state.u.x()[i], state.u.y()[i], state.u.z()[i]]
            );
        }
        assert_eq!(f64s(get("damage")), damage);
        for name in ["velocity", "pool_ratio", "strain_energy_density", "stress"] {
            get(name);
        }
        // Energy density integrates to U.
        let w: Real =
            f64s(get("strain_energy_density")).iter().sum::<Real>() * body.lattice.cell_volume;
        let u_total =
            hooke_core::law::energy(&body, &state.u, state.springs(&body), state.norm()).total();
        assert!((w / u_total - 1.0).abs() < 1e-12, "{w} vs {u_total}");
    }
    let pvd = std::fs::read_to_string(series.pvd_path()).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 2);
    assert!(
        pvd.contains("bar_000001.vtu") && pvd.contains("timestep=\"2.50000000000000000e-1\""),
        "{pvd}"
    );
    // Written in the background: after a flush, or when the series is dropped, every frame is
    // on disk and listed, with the same bytes as the synchronous writer's.
    let bg = tmpdir("frames_background");
    let mut series_bg = VtkSeries::create(&bg, "bar", true).unwrap();
    series_bg.set_background(true);
    for step in 0..3 {
        state.step = step;
        state.time = step as Real * 0.25;
        series_bg.write(&body, &state, Default::default()).unwrap();
    }
    series_bg.flush().unwrap();
    let pvd = std::fs::read_to_string(series_bg.pvd_path()).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 3, "{pvd}");
    state.step = 3;
    series_bg.write(&body, &state, Default::default()).unwrap();
    drop(series_bg);
    let sync_dir = tmpdir("frames_sync");
    let mut series_sync = VtkSeries::create(&sync_dir, "bar", true).unwrap();
    let p = series_sync
        .write(&body, &state, Default::default())
        .unwrap();
    assert_eq!(
        std::fs::read(bg.join("bar_000003.vtu")).unwrap(),
        std::fs::read(p).unwrap()
    );
    assert_eq!(
        std::fs::read_to_string(bg.join("bar.pvd"))
            .unwrap()
            .matches("<DataSet")
            .count(),
        4
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A series given a set of fields writes those and `node_id`, nothing else, in the order of
/// the full frame and with the same values; in pieces, each piece and the `.pvtu` list the same.
#[test]
fn vtk_frames_carry_only_the_chosen_fields() {
    let body = bar();
    let mut state = State::new(&body);
    let mut rng = Rng::new(5);
    state.u = random_displacement(&body, &mut rng, 0.01);
    let damage: Vec<Real> = (0..body.nodes()).map(|i| (i % 5) as Real / 5.0).collect();
    let regions: Vec<u32> = (0..body.nodes() as u32).map(|i| i % 3).collect();
    let names = |path: &Path| -> (Vec<String>, Vec<Attribute>) {
        let vtk = Vtk::import(path).unwrap();
        let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
            panic!("not an unstructured grid")
        };
        let piece = pieces[0].load_piece_data(None).unwrap();
        let point = piece.data.point;
        (point.iter().map(|a| a.name().to_string()).collect(), point)
    };
    let extras = FrameExtras {
        damage: Some(&damage),
        region: Some(&regions),
        ..Default::default()
    };
    let all_dir = tmpdir("fields_all");
    let all = VtkSeries::create(&all_dir, "bar", false)
        .unwrap()
        .write(&body, &state, extras)
        .unwrap();
    let (all_names, all_arrays) = names(&all);
    // Every field in `FieldSet::NAMES` order, `node_id` before `region` (and no `material`:
    // the bar is of one material).
    let mut every: Vec<&str> = FieldSet::NAMES
        .iter()
        .copied()
        .filter(|&n| n != "material")
        .collect();
    every.insert(every.len() - 1, "node_id");
    assert_eq!(all_names, every);
    for chosen in [
        vec!["stress", "displacement"],
        vec!["damage", "region"],
        vec![],
    ] {
        let fields = FieldSet::from_names(&chosen).unwrap();
        let dir = tmpdir("fields_some");
        let mut series = VtkSeries::create(&dir, "bar", false).unwrap();
        series.set_fields(fields);
        let path = series.write(&body, &state, extras).unwrap();
        let (got, arrays) = names(&path);
        let want: Vec<&str> = all_names
            .iter()
            .map(String::as_str)
            .filter(|n| *n == "node_id" || chosen.contains(n))
            .collect();
        assert_eq!(got, want, "{chosen:?}");
        // The same values (the reader's attribute kind follows which scalar comes first).
        let data = |a: &Attribute| match a {
            Attribute::DataArray(d) => d.data.clone(),
            _ => panic!("expected a data array"),
        };
        for (name, a) in got.iter().zip(&arrays) {
            let b = &all_arrays[all_names.iter().position(|n| n == name).unwrap()];
            assert_eq!(data(a), data(b), "{name} differs from the full frame's");
        }
        // In pieces: each piece and the .pvtu hold the same arrays.
        let pdir = tmpdir("fields_pieces");
        let n = body.nodes();
        let ranges = vec![0..n / 2, n / 2..n];
        for rank in [1, 0] {
            let mut s = VtkSeries::create(&pdir, "bar", false).unwrap();
            s.set_fields(fields);
            s.set_pieces(rank, ranges.clone());
            let p = s.write(&body, &state, extras).unwrap();
            assert_eq!(names(&p).0, want, "piece {rank}");
            if rank == 0 {
                s.publish().unwrap();
            }
        }
        let pvtu = std::fs::read_to_string(pdir.join("bar_000000.pvtu")).unwrap();
        assert_eq!(
            pvtu.matches("<PDataArray").count(),
            want.len() + 1,
            "{pvtu}"
        );
        for name in &want {
            assert!(pvtu.contains(&format!("Name=\"{name}\"")), "{pvtu}");
        }
        std::fs::remove_dir_all(&dir).ok();
        std::fs::remove_dir_all(&pdir).ok();
    }
    std::fs::remove_dir_all(&all_dir).ok();
}

fn run(body: &Body, state: &mut State, it: &mut Integrator, fr: &mut Fracture, steps: u64) {
    for _ in 0..steps {
        it.step(body, state);
        fr.check(body, state, it);
    }
}

/// A run resumed from a checkpoint file continues bit for bit like the uninterrupted run, with
/// springs breaking on both sides of the checkpoint.
#[test]
fn restart_is_bit_identical() {
    let body = bar();
    let opts = IntegratorOptions {
        damage_proof: true,
        ..Default::default()
    };
    let crit = || Box::new(CriticalStretch::new(0.004).unwrap());
    let case = digest(b"the pulled bar of restart_is_bit_identical");
    // Uninterrupted.
    let mut a = State::new(&body);
    let mut it = Integrator::new(&body, &mut a, pulled(&body), &opts).unwrap();
    let mut fr = Fracture::new(&body, crit());
    run(&body, &mut a, &mut it, &mut fr, 700);
    let ledger_a = it.ledger();
    assert!(
        fr.broken_total > 0,
        "nothing broke: the test would not cover breaking"
    );
    // Interrupted at step 350, written to disk, read back, continued.
    let dir = tmpdir("restart");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.ckpt");
    {
        let mut b = State::new(&body);
        let mut it = Integrator::new(&body, &mut b, pulled(&body), &opts).unwrap();
        let mut fr = Fracture::new(&body, crit());
        run(&body, &mut b, &mut it, &mut fr, 350);
        Checkpoint {
            digest: case,
            state: b,
            integrator: it.checkpoint(),
            broken: fr.broken_total as u64,
            released: fr.released_total,
            extra: Vec::new(),
        }
        .save(&path)
        .unwrap();
    }
    let ck = Checkpoint::load(&path, &body, case).unwrap();
    let mut b = ck.state.clone();
    let mut it = Integrator::resume(&body, &b, pulled(&body), &opts, &ck.integrator).unwrap();
    let mut fr2 = Fracture::new(&body, crit());
    fr2.broken_total = ck.broken as usize;
    fr2.released_total = ck.released;
    run(&body, &mut b, &mut it, &mut fr2, 350);
    assert!(
        a.u == b.u && a.v == b.v && a.alive() == b.alive(),
        "resumed run differs"
    );
    assert_eq!((a.step, a.time.to_bits()), (b.step, b.time.to_bits()));
    assert_eq!(ledger_a, it.ledger());
    assert_eq!(
        (fr.broken_total, fr.released_total.to_bits()),
        (fr2.broken_total, fr2.released_total.to_bits())
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Write the checkpoint of a run in which nothing broke.
fn save_unbroken(path: &Path, digest: u64, state: State, it: &Integrator) {
    Checkpoint {
        digest,
        state,
        integrator: it.checkpoint(),
        broken: 0,
        released: 0.0,
        extra: Vec::new(),
    }
    .save(path)
    .unwrap();
}

/// An intact box read back from its checkpoint is the state `State::new` makes (pristine), so
/// the resumed run, its frame and its final energy still read the box's grid and build no rows,
/// and it continues bit for bit like the uninterrupted run.
#[test]
fn an_intact_box_resumes_without_its_rows() {
    let opts = IntegratorOptions::default();
    let case = digest(b"the pulled bar of an_intact_box_resumes_without_its_rows");
    let body = bar();
    let mut a = State::new(&body);
    let mut it = Integrator::new(&body, &mut a, pulled(&body), &opts).unwrap();
    it.run(&body, &mut a, 120).unwrap();
    let (v_a, e_a, _) = it.frame_view(&body, &mut a, true);
    let dir = tmpdir("intact-restart");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.ckpt");
    {
        let mut b = State::new(&body);
        let mut it = Integrator::new(&body, &mut b, pulled(&body), &opts).unwrap();
        it.run(&body, &mut b, 60).unwrap();
        save_unbroken(&path, case, b, &it);
    }
    let lean = bar();
    let ck = Checkpoint::load(&path, &lean, case).unwrap();
    assert!(ck.state.is_pristine());
    let mut b = ck.state.clone();
    let mut it = Integrator::resume(&lean, &b, pulled(&lean), &opts, &ck.integrator).unwrap();
    it.run(&lean, &mut b, 60).unwrap();
    let (v_b, e_b, _) = it.frame_view(&lean, &mut b, true);
    assert!(!lean.lattice.bonds.is_built() && lean.k.bytes() == 0);
    assert!(a == b && v_a == v_b, "resumed run differs");
    assert_eq!(e_a, e_b);
    std::fs::remove_dir_all(&dir).ok();
}

/// A checkpoint refuses another case, another body, and damaged or truncated files, each with
/// its reason; none of them panics.
#[test]
fn checkpoints_refuse_what_is_not_theirs() {
    let body = bar();
    let dir = tmpdir("refuse");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.ckpt");
    let mut state = State::new(&body);
    let it = Integrator::new(
        &body,
        &mut state,
        Loading::default(),
        &IntegratorOptions::default(),
    )
    .unwrap();
    save_unbroken(&path, 7, state, &it);
    assert!(Checkpoint::load(&path, &body, 7).is_ok());
    let e = Checkpoint::load(&path, &body, 8).unwrap_err();
    assert!(
        matches!(e, IoError::DigestMismatch { .. }) && e.to_string().contains("another case"),
        "{e}"
    );
    let other = Body::uniform(Lattice::cubic_box([5, 5, 5], 1.0).unwrap(), 1.0, 0.0, 1.0);
    assert!(Checkpoint::load(&path, &other, 7)
        .unwrap_err()
        .to_string()
        .contains("nodes"));
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[100] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    assert!(Checkpoint::load(&path, &body, 7)
        .unwrap_err()
        .to_string()
        .contains("checksum"));
    for len in [0, 5, 30, 60, bytes.len() / 2] {
        std::fs::write(&path, &bytes[..len]).unwrap();
        let e = Checkpoint::load(&path, &body, 7).unwrap_err();
        assert!(matches!(e, IoError::Format { .. }), "{len}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// An output directory that cannot be written is reported when the series is created, before
/// any computing, with the path and the fix.
#[test]
fn unwritable_output_is_reported_up_front() {
    let dir = tmpdir("unwritable");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let e = VtkSeries::create(&file.join("out"), "run", false).unwrap_err();
    assert!(
        matches!(e, IoError::NotWritable { .. }) && e.to_string().contains("--out"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

const CHILD: &str = "HOOKE_KILL_TEST_DIR";

/// Child side of the kill test: write frames (and checkpoints) as fast as possible, forever.
fn child_writer(dir: &Path) -> ! {
    let body = bar();
    let mut state = State::new(&body);
    let mut it = Integrator::new(
        &body,
        &mut state,
        pulled(&body),
        &IntegratorOptions::default(),
    )
    .unwrap();
    let mut series = VtkSeries::create(dir, "run", true).unwrap();
    loop {
        it.run(&body, &mut state, 5).unwrap();
        series.write(&body, &state, FrameExtras::default()).unwrap();
        Checkpoint {
            digest: 1,
            state: state.clone(),
            integrator: it.checkpoint(),
            broken: 0,
            released: 0.0,
            extra: Vec::new(),
        }
        .save(&dir.join("run.ckpt"))
        .unwrap();
    }
}

/// SIGKILL at an arbitrary moment leaves every frame the collection lists, the collection
/// itself and the last checkpoint complete and readable.
#[test]
fn killed_run_leaves_readable_output() {
    if let Some(dir) = std::env::var_os(CHILD) {
        child_writer(Path::new(&dir));
    }
    for round in 0..3 {
        let dir = tmpdir(&format!("kill{round}"));
        std::fs::create_dir_all(&dir).unwrap();
        let mut child = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "--exact",
                "killed_run_leaves_readable_output",
                "--nocapture",
            ])
            .env(CHILD, &dir)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Wait until the first checkpoint exists (on a loaded machine the child's set-up can
        // take longer than the kill delay), then kill at an arbitrary moment after it.
        let start = std::time::Instant::now();
        while !dir.join("run.ckpt").exists() && start.elapsed().as_secs() < 60 {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        std::thread::sleep(std::time::Duration::from_millis(100 + 170 * round));
        child.kill().unwrap(); // SIGKILL on Unix
        child.wait().unwrap();
        let pvd = std::fs::read_to_string(dir.join("run.pvd"))
            .expect("the collection exists and is complete");
        assert!(
            pvd.trim_end().ends_with("</VTKFile>"),
            "truncated collection"
        );
        let files: Vec<&str> = pvd
            .lines()
            .filter_map(|l| l.split("file=\"").nth(1))
            .map(|r| r.split('"').next().unwrap())
            .collect();
        assert!(!files.is_empty(), "no frame was written in time");
        for f in &files {
            Vtk::import(dir.join(f)).unwrap_or_else(|e| panic!("listed frame {f} unreadable: {e}"));
        }
        Checkpoint::load(&dir.join("run.ckpt"), &bar(), 1)
            .expect("the last checkpoint is readable");
        std::fs::remove_dir_all(&dir).ok();
    }
}
