//! The mode-I plate of `cases/mode1_plate.toml`, built in code: a pre-cracked glass plate whose
//! top and bottom strips are pulled apart; a crack runs from the notch across the plate. Its
//! output is bit for bit that of `hooke run cases/mode1_plate.toml` at the same scale (CI checks
//! it with tools/compare_runs.py).
//!
//!     cargo run --release -p hooke-sim --example mode1_plate -- [OUT_DIR] [SCALE]

use hooke_core::loading::TimeFunction;
use hooke_core::LatticeKind;
use hooke_fracture::Crack;
use hooke_sim::{Bc, Builder, Region, RunOptions, Silent, Solid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "mode1_plate.out".into());
    let scale: f64 = args.next().map_or(Ok(1.0), |s| s.parse())?;
    let pull = |v: f64| TimeFunction::SmoothRamp {
        t0: 0.0,
        t1: 5e-6,
        from: 0.0,
        to: v,
    };
    let grip = |lo: f64, hi: f64| Region::Box {
        lo: [-1.0, lo, 0.0].into(),
        hi: [1.0, hi, 0.0].into(),
    };
    let sim = Builder::new(LatticeKind::Random2d, 0.5e-3 / scale)
        .thickness(1e-3)
        .solid(Solid::cuboid([0.0; 3], [60e-3, 30e-3, 0.0]))
        .material(72e9, 0.22, 2440.0) // soda-lime glass: E (Pa), nu, rho (kg/m^3)
        .fracture_energy(3.8) // G_c (J/m^2)
        .precrack(Crack::Segment {
            a: [-1e-3, 15.05e-3],
            b: [15e-3, 15.05e-3],
        })
        .boundary(Bc::on(grip(29e-3, 1.0)).velocity(1, pull(0.02)).no_fail())
        .boundary(Bc::on(grip(-1.0, 1e-3)).velocity(1, pull(-0.02)).no_fail())
        .end_time(60e-6)
        .output_every(1e-6)
        .build()?;
    println!("{} nodes, {} springs", sim.body.nodes(), sim.body.springs());
    let summary = hooke_sim::run(sim, RunOptions::new(&out, "mode1_plate"), &mut Silent)?;
    println!(
        "{} springs broken in {:.1} s; frames in {out}/mode1_plate.pvd",
        summary.broken_springs, summary.wall_seconds
    );
    for r in &summary.reactions {
        println!("  {}: force {:.3e} N along y", r.name, r.force[1]);
    }
    Ok(())
}
