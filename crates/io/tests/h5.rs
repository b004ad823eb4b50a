//! HDF5 output read back with the HDF5 library itself (feature `hdf5`).
#![cfg(feature = "hdf5")]

use std::path::{Path, PathBuf};

use hooke_core::{Body, Lattice, State};
use hooke_io::{FieldSet, FrameExtras, H5Series};

fn body() -> Body {
    Body::uniform(Lattice::cubic_box([6, 4, 3], 1e-3).unwrap(), 1e4, 0.2, 1e-6)
}

/// The HDF5 library locks files per process and its state is global: the two tests, run on
/// parallel test threads, once failed with "unable to lock file" (errno 11). They take turns.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-h5-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Frames are written one file each while the run goes on, merged into one chunked file at the
/// end, and read back exactly from either.
#[test]
fn hdf5_frames_read_back_exactly() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let body = body();
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        state.u.x_mut()[i] = 1e-6 * i as f64;
    }
    let dir = tmp("frames");
    let mut s = H5Series::create(&dir, "t", &body).unwrap();
    for step in [0u64, 10] {
        state.step = step;
        state.time = step as f64 * 1e-7;
        s.write(&body, &state, FrameExtras::default()).unwrap();
    }
    let read = |file: &Path| -> Vec<f64> {
        let f = hdf5_metno::File::open(file).unwrap();
        let d = f.dataset("frames/000010/displacement").unwrap();
        assert_eq!(d.shape(), vec![body.nodes(), 3]);
        assert!(d.chunk().is_some(), "not chunked");
        d.read_raw().unwrap()
    };
    let during = read(&dir.join("t.frames/000010.h5"));
    let x = std::fs::read_to_string(s.xdmf_path()).unwrap();
    assert_eq!(x.matches("<Time Value").count(), 2);
    assert!(
        x.contains("t.frames/000010.h5:/frames/000010/displacement"),
        "{x}"
    );
    let merged = s.finish().unwrap();
    assert_eq!(read(&merged), during);
    for i in 0..body.nodes() {
        assert_eq!(during[3 * i], state.u.x()[i]);
    }
    let x = std::fs::read_to_string(s.xdmf_path()).unwrap();
    assert!(
        x.contains("t.h5:/frames/000000/displacement") && !x.contains("t.frames"),
        "{x}"
    );
    assert!(
        !dir.join("t.frames").exists(),
        "per-frame files are removed after the merge"
    );
    std::fs::remove_dir_all(&dir).ok();
}

const CHILD: &str = "HOOKE_H5_KILL_DIR";

/// SIGKILL at an arbitrary moment while HDF5 frames are written: every frame the XDMF lists
/// opens and reads.
#[test]
fn killed_run_leaves_readable_hdf5_frames() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(dir) = std::env::var_os(CHILD) {
        let body = body();
        let mut state = State::new(&body);
        let mut s = H5Series::create(Path::new(&dir), "run", &body).unwrap();
        loop {
            state.step += 1;
            state.time += 1e-7;
            state.u.x_mut()[0] += 1e-9;
            s.write(&body, &state, FrameExtras::default()).unwrap();
        }
    }
    for round in 0..3u64 {
        let dir = tmp(&format!("kill{round}"));
        std::fs::create_dir_all(&dir).unwrap();
        let mut child = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "--exact",
                "killed_run_leaves_readable_hdf5_frames",
                "--nocapture",
            ])
            .env(CHILD, &dir)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Wait until the description lists more than ten data items (on a loaded machine the
        // child's set-up can outlast a fixed delay), then kill at an arbitrary moment after.
        let start = std::time::Instant::now();
        while std::fs::read_to_string(dir.join("run.xdmf"))
            .map_or(0, |x| x.matches("Precision=\"8\">").count())
            <= 10
            && start.elapsed().as_secs() < 60
        {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        std::thread::sleep(std::time::Duration::from_millis(100 + 130 * round));
        child.kill().unwrap();
        child.wait().unwrap();
        let x = std::fs::read_to_string(dir.join("run.xdmf"))
            .expect("the description exists and is complete");
        assert!(x.trim_end().ends_with("</Xdmf>"));
        let mut n = 0;
        for item in x.split("Precision=\"8\">").skip(1) {
            let item = item.split('<').next().unwrap();
            let (file, path) = item.split_once(':').unwrap();
            let f =
                hdf5_metno::File::open(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
            let d = f
                .dataset(path.trim_start_matches('/'))
                .unwrap_or_else(|e| panic!("{item}: {e}"));
            let _: Vec<f64> = if path.ends_with("vertices") {
                Vec::new()
            } else {
                d.read_raw().unwrap()
            };
            n += 1;
        }
        assert!(n > 10, "too few data items listed ({n})");
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// A series given a set of fields writes those (and the geometry and `node_id`) in each frame
/// and its description lists each frame's own: a resumed series that asks for more fields
/// keeps its earlier frames as they were written, and the merged file holds what each held.
#[test]
fn hdf5_frames_carry_only_the_chosen_fields() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let body = body();
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        state.u.x_mut()[i] = 1e-6 * i as f64;
    }
    let damage = vec![0.25; body.nodes()];
    let extras = FrameExtras {
        damage: Some(&damage),
        ..Default::default()
    };
    let dir = tmp("fields");
    let mut s = H5Series::create(&dir, "t", &body).unwrap();
    s.set_fields(FieldSet::from_names(&["stress", "damage"]).unwrap());
    s.write(&body, &state, extras).unwrap();
    let held = |file: &Path, frame: &str| -> Vec<String> {
        let f = hdf5_metno::File::open(file).unwrap();
        let mut names = f
            .group(&format!("frames/{frame}"))
            .unwrap()
            .member_names()
            .unwrap();
        names.sort();
        names
    };
    assert_eq!(
        held(&dir.join("t.frames/000000.h5"), "000000"),
        ["damage", "node_id", "points", "stress"]
    );
    // Resumed with every field: frame 0 is listed as it was written.
    let mut s = H5Series::reopen(&dir, "t", &body, 1.0).unwrap();
    state.step = 10;
    state.time = 1e-7;
    s.write(&body, &state, extras).unwrap();
    let x = std::fs::read_to_string(s.xdmf_path()).unwrap();
    let grids: Vec<&str> = x.split("<Grid Name=\"step_").skip(1).collect();
    assert_eq!(grids.len(), 2, "{x}");
    let attributes = |g: &str| g.matches("<Attribute ").count();
    assert_eq!(attributes(grids[0]), 3, "{}", grids[0]);
    assert!(grids[0].contains("Name=\"stress\"") && !grids[0].contains("Name=\"velocity\""));
    // Every field but region (the frame has none).
    assert_eq!(attributes(grids[1]), 8, "{}", grids[1]);
    let merged = s.finish().unwrap();
    assert_eq!(
        held(&merged, "000000"),
        ["damage", "node_id", "points", "stress"]
    );
    assert_eq!(held(&merged, "000010").len(), 9);
    std::fs::remove_dir_all(&dir).ok();
}
