//! `hooke toughness`: the fracture energy a lattice crack really dissipates, measured on a strip
//! under fixed grips (see `hooke_fracture::toughness`), and the table the G_c calibration uses.

use std::time::Instant;

use anyhow::Result;
use clap::{Args, ValueEnum};
use hooke_core::material::q_from_nu;
use hooke_core::{LatticeKind, Real};
use hooke_fracture::stretch::{nominal_toughness, table_nu};
use hooke_fracture::toughness::{strip_test, StripResult, StripTest};
use hooke_fracture::SofteningShape;

use crate::moduli::LatticeArg;
use crate::InputError;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum CriterionArg {
    /// Critical stretch (the calibrated criterion).
    Stretch,
    /// Spring energy matching the critical stretch under uniform stretch.
    Energy,
    /// Softening springs whose equivalent stretch is the critical stretch (G_f calibration).
    Softening,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ShapeArg {
    Linear,
    Bilinear,
}

#[derive(Debug, Args)]
pub struct ToughnessArgs {
    /// Lattice to test.
    #[arg(long, value_enum, default_value = "hex")]
    pub lattice: LatticeArg,
    /// The lattice's Poisson's ratio (3D nu, or the hexagonal lattice's nu_2D). Required unless
    /// --table.
    #[arg(long, allow_negative_numbers = true)]
    pub nu: Option<Real>,
    /// Node rows between the grips (even; default 40 hex and random2d, 20 cubic, 16 random3d:
    /// the sizes the tables were measured at). Larger is closer to the limit of a crack in an
    /// infinite body and slower.
    #[arg(long)]
    pub height: Option<usize>,
    /// Crack growth to measure over (spacings; default 10, random3d 8).
    #[arg(long)]
    pub window: Option<usize>,
    /// 3D lattices: nodes across the front (cubic: periodic, default 3; random3d: a slab with
    /// free faces, default 8).
    #[arg(long)]
    pub depth: Option<usize>,
    /// Failure criterion.
    #[arg(long, value_enum, default_value = "stretch")]
    pub criterion: CriterionArg,
    /// --criterion softening: the shape of the softening branch.
    #[arg(long, value_enum, default_value = "linear")]
    pub softening: ShapeArg,
    /// --criterion softening: the peak stretch over the equivalent stretch (0 < f < 1; small:
    /// a long softening tail, near 1: nearly brittle).
    #[arg(long, default_value_t = 0.5)]
    pub peak_fraction: Real,
    /// Print one JSON object per nu.
    #[arg(long)]
    pub json: bool,
    /// Measure the calibration table (all nu of the lattice's table) and print it as the Rust
    /// constant `hooke_fracture::stretch` holds.
    #[arg(long)]
    pub table: bool,
    /// Random lattices: seed of the first node set; --samples strips are run (seeds S, S+1, ...)
    /// and their G averaged.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Random lattices: number of strips to average.
    #[arg(long, default_value_t = 1)]
    pub samples: usize,
}

/// The figures of one strip, as printed by `--json`.
#[derive(Debug, serde::Serialize)]
pub struct ToughnessJson {
    pub lattice: &'static str,
    pub criterion: &'static str,
    /// Softening springs: their shape and peak fraction (absent for brittle criteria).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub softening: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_fraction: Option<Real>,
    pub nu: Real,
    pub q: Real,
    pub height: usize,
    pub window: Real,
    /// Fracture energy the calibration assigns to the springs' s_c (lattice units).
    #[serde(rename = "G_c")]
    pub g_c: Real,
    /// Energy dissipated per unit of new crack area in steady growth (work of the grips minus
    /// stored energy, against crack length).
    #[serde(rename = "G_measured")]
    pub g_measured: Real,
    /// G / G_c, G from `measure`.
    pub ratio: Real,
    /// Which G the ratio stands on: "dissipation" (`G_measured`) or, for brittle random3d
    /// slabs, "release" (`G_release`, the release rate at the running strain).
    pub measure: &'static str,
    /// Steady-state release U_strip / (length x width) at the running strain (the cross-check;
    /// random3d: the slab's own release rate by the compliance method, its measure of G).
    #[serde(rename = "G_release")]
    pub g_release: Real,
    pub gamma: Real,
    pub gamma_nominal: Real,
    pub eps_run: Real,
    pub broken: usize,
    pub off_plane: usize,
    pub solves: usize,
    pub seconds: f64,
}

fn measure(args: &ToughnessArgs, nu: Real) -> Result<ToughnessJson> {
    let kind = LatticeKind::from(args.lattice);
    let q = q_from_nu(kind, nu).map_err(|e| InputError(format!("--nu {nu}: {e}")))?;
    let height = args.height.unwrap_or(match kind {
        LatticeKind::Random3d => 16,
        LatticeKind::Cubic => 20,
        _ => 40,
    });
    let window = args.window.unwrap_or(match kind {
        LatticeKind::Random3d => 8,
        _ => 10,
    });
    let mut t = StripTest::new(kind, q, height, window);
    t.depth = args.depth.unwrap_or(match kind {
        LatticeKind::Random3d => 8,
        _ => 3,
    });
    t.energy = matches!(args.criterion, CriterionArg::Energy);
    if let Some(shape) = t_shape(args) {
        t.softening = Some((shape, args.peak_fraction));
        t.max_solves = 200_000;
    }
    let start = Instant::now();
    let samples = if kind.is_random() {
        args.samples.max(1)
    } else {
        1
    };
    let mut runs: Vec<StripResult> = Vec::with_capacity(samples);
    for s in 0..samples {
        t.seed = args.seed + s as u64;
        runs.push(
            strip_test(&t)
                .map_err(|e| anyhow::anyhow!("strip at nu = {nu}, seed {}: {e}", t.seed))?,
        );
    }
    // Random lattices: the mean over the node sets.
    let mut r = runs[0].clone();
    let n = runs.len() as Real;
    r.g_measured = runs.iter().map(|x| x.g_measured).sum::<Real>() / n;
    r.g_release = runs.iter().map(|x| x.g_release).sum::<Real>() / n;
    r.gamma = runs.iter().map(|x| x.gamma).sum::<Real>() / n;
    r.eps_run = runs.iter().map(|x| x.eps_run).sum::<Real>() / n;
    r.broken = runs.iter().map(|x| x.broken).sum::<usize>() / runs.len();
    r.off_plane = runs.iter().map(|x| x.off_plane).sum::<usize>() / runs.len();
    r.solves = runs.iter().map(|x| x.solves).sum();
    Ok(ToughnessJson {
        lattice: kind.name(),
        criterion: match args.criterion {
            CriterionArg::Stretch => "stretch",
            CriterionArg::Energy => "energy",
            CriterionArg::Softening => "softening",
        },
        softening: t.softening.map(|(s, _)| s.name()),
        peak_fraction: t.softening.map(|(_, f)| f),
        nu,
        q,
        height,
        window: r.window,
        g_c: r.g_calibrated,
        g_measured: r.g_measured,
        ratio: r.ratio(),
        measure: if r.release_is_measure {
            "release"
        } else {
            "dissipation"
        },
        g_release: r.g_release,
        gamma: r.gamma,
        gamma_nominal: nominal_toughness(kind, q),
        eps_run: r.eps_run,
        broken: r.broken,
        off_plane: r.off_plane,
        solves: r.solves,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The softening shape when the criterion is softening.
fn t_shape(args: &ToughnessArgs) -> Option<SofteningShape> {
    matches!(args.criterion, CriterionArg::Softening).then_some(match args.softening {
        ShapeArg::Linear => SofteningShape::Linear,
        ShapeArg::Bilinear => SofteningShape::Bilinear,
    })
}

fn check_args(args: &ToughnessArgs) -> Result<()> {
    if args.height.is_some_and(|h| h < 6 || h % 2 == 1) {
        return Err(InputError(format!(
            "--height {}: give an even number of rows, 6 or more",
            args.height.unwrap()
        ))
        .into());
    }
    if !(args.peak_fraction > 0.0 && args.peak_fraction < 1.0) {
        return Err(InputError(format!(
            "--peak-fraction {}: give a number between 0 and 1 (the peak stretch over the \
             equivalent stretch)",
            args.peak_fraction
        ))
        .into());
    }
    let depth = args.depth.unwrap_or(3);
    if args.window.is_some_and(|w| w < 2) || depth < 3 {
        return Err(InputError(format!(
            "--window {} --depth {depth}: give a window of 2 or more spacings and a depth of 3 \
             or more nodes",
            args.window.unwrap_or(10)
        ))
        .into());
    }
    Ok(())
}

/// One strip's `--json` object as a value (`--nu`, not `--table`).
pub fn value(args: &ToughnessArgs) -> Result<serde_json::Value> {
    check_args(args)?;
    let nu = match (args.table, args.nu) {
        (false, Some(nu)) => nu,
        _ => return Err(InputError("give --nu NU (--table prints a table)".into()).into()),
    };
    Ok(serde_json::to_value(measure(args, nu)?)?)
}

pub fn run(args: ToughnessArgs) -> Result<()> {
    check_args(&args)?;
    let kind = LatticeKind::from(args.lattice);
    let list: Vec<Real> = match (args.table, args.nu) {
        (true, _) if t_shape(&args).is_some() => hooke_fracture::softening::TABLE_NU.to_vec(),
        (true, _) => table_nu(kind).to_vec(),
        (false, Some(nu)) => vec![nu],
        (false, None) => {
            return Err(
                InputError("give --nu NU, or --table for the calibration table".into()).into(),
            )
        }
    };
    let mut rows = Vec::new();
    for nu in list {
        let j = measure(&args, nu)?;
        if args.json {
            println!("{}", serde_json::to_string(&j)?);
        } else {
            println!(
                "{} nu = {:+.3} (q = {:+.4}): G / G_c = {:.4} (dissipated {:.4}, released at the \
                 running strain {:.4}), Gamma = {:.4} (nominal {:.4}, trapping x{:.2}), {} springs broken, {} off the \
                 plane, {} solves, {:.1} s",
                j.lattice,
                j.nu,
                j.q,
                j.ratio,
                j.g_measured / j.g_c,
                j.g_release / j.g_c,
                j.gamma,
                j.gamma_nominal,
                j.gamma / j.gamma_nominal,
                j.broken,
                j.off_plane,
                j.solves,
                j.seconds
            );
        }
        rows.push((
            nu,
            if let (Some(rho), Some(shape)) = (j.peak_fraction, t_shape(&args)) {
                // Softening springs tabulate F, the factor over the brittle calibration.
                j.ratio * hooke_fracture::softening::toughness_factor(kind, j.nu, rho, shape)
            } else if j.criterion == "energy" {
                // The energy criterion tabulates its toughness over the stretch calibration.
                j.ratio * hooke_fracture::energy::energy_toughness_factor(kind, j.nu)
            } else if kind.is_random() {
                // Random lattices tabulate the factor on the hexagonal mapping.
                j.ratio * hooke_fracture::stretch::random_toughness_factor(kind, j.nu)
            } else {
                j.gamma
            },
        ));
    }
    if let (true, Some(shape)) = (args.table, t_shape(&args)) {
        // One column of the softening tables (`hooke_fracture::softening`).
        println!(
            "// F of {} {} softening at peak fraction {} over nu = {:?}",
            kind.name(),
            shape.name(),
            args.peak_fraction,
            hooke_fracture::softening::TABLE_NU
        );
        for (nu, f) in &rows {
            println!("    ({nu:?}, {f:.4}),");
        }
        return Ok(());
    }
    if args.table {
        let energy = matches!(args.criterion, CriterionArg::Energy);
        let name = match (kind, energy) {
            (LatticeKind::Cubic, true) => "CUBIC_ENERGY_FACTOR",
            (_, true) => "HEX_ENERGY_FACTOR",
            (LatticeKind::Cubic, false) => "CUBIC_TOUGHNESS",
            (LatticeKind::Random2d, false) => "RANDOM2D_TOUGHNESS",
            (LatticeKind::Random3d, false) => "RANDOM3D_TOUGHNESS",
            _ => "HEX_TOUGHNESS",
        };
        println!("const {name}: &[(Real, Real)] = &[");
        for (nu, g) in &rows {
            println!("    ({nu:?}, {g:.4}),");
        }
        println!("];");
    }
    Ok(())
}
