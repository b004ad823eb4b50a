//! HDF5 output read back with the HDF5 library itself (feature `hdf5`).
#![cfg(feature = "hdf5")]

use hooke_core::{Body, Lattice, State};
use hooke_io::{FrameExtras, H5Series};

#[test]
fn hdf5_frames_read_back_exactly() {
    let body = Body::uniform(Lattice::cubic_box([6, 4, 3], 1e-3).unwrap(), 1e4, 0.2, 1e-6);
    let mut state = State::new(&body);
    for i in 0..body.nodes() {
        state.u.x[i] = 1e-6 * i as f64;
    }
    let dir = std::env::temp_dir().join(format!("hooke-h5-{}", std::process::id()));
    let mut s = H5Series::create(&dir, "t", &body).unwrap();
    for step in [0u64, 10] {
        state.step = step;
        state.time = step as f64 * 1e-7;
        s.write(&body, &state, FrameExtras::default()).unwrap();
    }
    let f = hdf5_metno::File::open(dir.join("t.h5")).unwrap();
    let d = f.dataset("frames/000010/displacement").unwrap();
    assert_eq!(d.shape(), vec![body.nodes(), 3]);
    assert!(d.chunk().is_some(), "not chunked");
    let v: Vec<f64> = d.read_raw().unwrap();
    for i in 0..body.nodes() {
        assert_eq!(v[3 * i], state.u.x[i]);
    }
    let x = std::fs::read_to_string(s.xdmf_path()).unwrap();
    assert_eq!(x.matches("<Time Value").count(), 2);
    std::fs::remove_dir_all(&dir).ok();
}
