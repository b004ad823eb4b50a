//! Writes a small run (a bar pulled apart until springs break) as a VTK series, plus a
//! `manifest.json` of what the files must contain, for `tools/check_output.py` to verify with
//! real readers (meshio, pyvista/VTK).
//!
//!     cargo run --release -p hooke-io --example write_series -- OUTDIR

use std::fmt::Write as _;

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::{Loading, Motion, Prescribed, TimeFunction};
use hooke_core::material::q_from_nu;
use hooke_core::{Body, Lattice, LatticeKind, Real, State};
use hooke_fracture::{CriticalStretch, Fracture};
use hooke_io::{FrameExtras, VtkSeries};

fn main() {
    let dir =
        std::path::PathBuf::from(std::env::args().nth(1).expect("usage: write_series OUTDIR"));
    let body = Body::uniform(
        Lattice::cubic_box([16, 5, 5], 1e-3).unwrap(),
        2e4,
        q_from_nu(LatticeKind::Cubic, 0.3).unwrap(),
        7.8e-6,
    );
    let ends = |x: Real| {
        (0..body.nodes() as u32)
            .filter(|&i| (body.lattice.pos.x()[i as usize] - x).abs() < 1e-6)
            .collect::<Vec<_>>()
    };
    let v = |to: Real| {
        Motion::Velocity(TimeFunction::SmoothRamp {
            t0: 0.0,
            t1: 2e-6,
            from: 0.0,
            to,
        })
    };
    let loading = Loading {
        prescribed: vec![
            Prescribed {
                nodes: ends(0.0),
                axis: 0,
                motion: v(-2.0),
            },
            Prescribed {
                nodes: ends(15e-3),
                axis: 0,
                motion: v(2.0),
            },
        ],
        ..Default::default()
    };
    let mut state = State::new(&body);
    let opts = IntegratorOptions {
        damage_proof: true,
        ..Default::default()
    };
    let mut it = Integrator::new(&body, &mut state, loading, &opts).unwrap();
    let mut fr = Fracture::new(&body, Box::new(CriticalStretch::new(2e-3).unwrap()));
    let mut series = VtkSeries::create(&dir, "bar", true).unwrap();
    #[cfg(feature = "hdf5")]
    let mut h5 = hooke_io::H5Series::create(&dir, "bar", &body).unwrap();
    let mut frames = Vec::new();
    for k in 0..6 {
        if k > 0 {
            for _ in 0..150 {
                it.step(&body, &mut state);
                fr.check(&body, &mut state, &mut it);
            }
        }
        let velocity = it.full_velocity(&body, &mut state);
        let damage = fr.damage(&body, &state);
        let extras = FrameExtras {
            velocity: Some(&velocity),
            damage: Some(&damage),
            ..Default::default()
        };
        let path = series.write(&body, &state, extras).unwrap();
        #[cfg(feature = "hdf5")]
        h5.write(&body, &state, extras).unwrap();
        let last = body.nodes() - 1;
        let dmax = damage.iter().cloned().fold(0.0, Real::max);
        let intact = state.alive().iter().filter(|&&a| a).count();
        frames.push(format!(
            "{{\"file\": \"{}\", \"time\": {:e}, \"ux_first\": {:e}, \"ux_last\": {:e}, \"vx_last\": {:e}, \"damage_max\": {:e}, \"lines\": {}}}",
            path.file_name().unwrap().to_string_lossy(),
            state.time,
            state.u.x()[0],
            state.u.x()[last],
            velocity.x()[last],
            dmax,
            intact
        ));
    }
    #[cfg(feature = "hdf5")]
    h5.finish().unwrap();
    let mut manifest = String::new();
    write!(
        manifest,
        "{{\"pvd\": \"bar.pvd\", \"xdmf\": {}, \"points\": {}, \"frames\": [\n  {}\n]}}\n",
        if cfg!(feature = "hdf5") {
            "\"bar.xdmf\""
        } else {
            "null"
        },
        body.nodes(),
        frames.join(",\n  ")
    )
    .unwrap();
    std::fs::write(dir.join("manifest.json"), manifest).unwrap();
    println!(
        "wrote {} frames to {} ({} springs broke)",
        frames.len(),
        dir.display(),
        fr.broken_total
    );
}
