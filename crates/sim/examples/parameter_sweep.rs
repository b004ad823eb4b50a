//! A parameter study in code: the same notched plate at several Poisson's ratios, stepped
//! through the library, recording the peak load on the top grip and the springs broken.
//!
//!     cargo run --release -p hooke-sim --example parameter_sweep -- [OUT_DIR] [SCALE]
//!
//! Writes `OUT_DIR/sweep.csv` (nu, peak force in N, springs broken, time of the peak in s).

use hooke_core::loading::TimeFunction;
use hooke_core::LatticeKind;
use hooke_fracture::Crack;
use hooke_sim::{Bc, Builder, Region, Run, RunOptions, Silent, Solid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(args.next().unwrap_or_else(|| "sweep.out".into()));
    let scale: f64 = args.next().map_or(Ok(1.0), |s| s.parse())?;
    std::fs::create_dir_all(&out)?;
    let mut csv = String::from("nu,peak_force_N,springs_broken,peak_time_s\n");
    for nu in [0.0, 0.1, 0.2, 0.3] {
        let grip = |lo: f64, hi: f64| Region::Box {
            lo: [-1.0, lo, 0.0].into(),
            hi: [1.0, hi, 0.0].into(),
        };
        let pull = |v: f64| TimeFunction::SmoothRamp {
            t0: 0.0,
            t1: 5e-6,
            from: 0.0,
            to: v,
        };
        let sim = Builder::new(LatticeKind::Random2d, 0.5e-3 / scale)
            .thickness(1e-3)
            .solid(Solid::cuboid([0.0; 3], [40e-3, 20e-3, 0.0]))
            .material(72e9, nu, 2440.0)
            .fracture_energy(3.8)
            .precrack(Crack::Segment {
                a: [-1e-3, 10.05e-3],
                b: [10e-3, 10.05e-3],
            })
            .boundary(
                Bc::on(grip(19e-3, 1.0))
                    .velocity(1, pull(0.02))
                    .no_fail()
                    .named("top"),
            )
            .boundary(
                Bc::on(grip(-1.0, 1e-3))
                    .velocity(1, pull(-0.02))
                    .no_fail()
                    .named("bottom"),
            )
            .end_time(40e-6)
            .output_every(10e-6)
            .build()?;
        let mut run = Run::start(sim, RunOptions::new(out.join(format!("nu{nu}")), "plate"))?;
        let (mut peak, mut peak_time) = (0.0f64, 0.0);
        while !run.done() {
            run.steps(10, &mut Silent)?;
            let top = run.reactions()[0].force[1];
            if top > peak {
                (peak, peak_time) = (top, run.simulation().state.time);
            }
        }
        let broken = run.simulation().broken().0;
        run.finish(&mut Silent)?;
        println!("nu = {nu}: peak {peak:.3e} N at {peak_time:.2e} s, {broken} springs broken");
        csv.push_str(&format!("{nu},{peak:e},{broken},{peak_time:e}\n"));
    }
    std::fs::write(out.join("sweep.csv"), csv)?;
    println!("{}", out.join("sweep.csv").display());
    Ok(())
}
