//! The fracture energy a lattice crack really dissipates, measured on a strip under fixed grips
//! (the experiment is `hooke_fracture::toughness`): the strip's default size per lattice, the
//! mean over random node sets, and the tables the G_c calibrations hold. `hooke toughness` and
//! `hooke.toughness` (Python) both call [`value`] or [`table`].

use std::time::Instant;

use anyhow::Result;
use hooke_core::material::q_from_nu;
use hooke_core::{LatticeKind, Real};
use hooke_fracture::stretch::{nominal_toughness, table_nu};
use hooke_fracture::toughness::{strip_test, StripResult, StripTest};
use hooke_fracture::SofteningShape;

use crate::moduli::LatticeName;
use crate::InputError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum CriterionName {
    /// Critical stretch (the calibrated criterion).
    Stretch,
    /// Spring energy matching the critical stretch under uniform stretch.
    Energy,
    /// Softening springs whose equivalent stretch is the critical stretch (G_f calibration).
    Softening,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ShapeName {
    Linear,
    Bilinear,
}

/// What `hooke toughness` and `hooke.toughness` ask for. Fields are the command's flags; from
/// JSON or Python keyword arguments every field is optional and takes the command's default.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ToughnessOptions {
    /// Lattice to test.
    pub lattice: LatticeName,
    /// The lattice's Poisson's ratio (3D nu, or the hexagonal lattice's nu_2D). Required unless
    /// --table.
    pub nu: Option<Real>,
    /// Node rows between the grips (even; default 40 hex and random2d, 20 cubic, 16 random3d:
    /// the sizes the tables were measured at). Larger is closer to the limit of a crack in an
    /// infinite body and slower.
    pub height: Option<usize>,
    /// Crack growth to measure over (spacings; default 10, random3d 8).
    pub window: Option<usize>,
    /// 3D lattices: nodes across the front (cubic: periodic, default 3; random3d: a slab with
    /// free faces, default 8).
    pub depth: Option<usize>,
    /// Failure criterion.
    pub criterion: CriterionName,
    /// --criterion softening: the shape of the softening branch.
    pub softening: ShapeName,
    /// --criterion softening: the peak stretch over the equivalent stretch (0 < f < 1; small:
    /// a long softening tail, near 1: nearly brittle).
    pub peak_fraction: Real,
    /// Measure the calibration table (all nu of the lattice's table) and print it as the Rust
    /// constant `hooke_fracture::stretch` holds.
    pub table: bool,
    /// Random lattices: seed of the first node set; --samples strips are run (seeds S, S+1, ...)
    /// and their G averaged.
    pub seed: u64,
    /// Random lattices: number of strips to average.
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

/// One strip (the mean over `samples` node sets on a random lattice) at `nu`.
pub fn measure(args: &ToughnessOptions, nu: Real) -> Result<ToughnessJson> {
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
    t.energy = matches!(args.criterion, CriterionName::Energy);
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
            CriterionName::Stretch => "stretch",
            CriterionName::Energy => "energy",
            CriterionName::Softening => "softening",
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
pub fn t_shape(args: &ToughnessOptions) -> Option<SofteningShape> {
    matches!(args.criterion, CriterionName::Softening).then_some(match args.softening {
        ShapeName::Linear => SofteningShape::Linear,
        ShapeName::Bilinear => SofteningShape::Bilinear,
    })
}

pub fn check_args(args: &ToughnessOptions) -> Result<()> {
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
pub fn value(args: &ToughnessOptions) -> Result<serde_json::Value> {
    check_args(args)?;
    let nu = match (args.table, args.nu) {
        (false, Some(nu)) => nu,
        _ => return Err(InputError("give --nu NU (--table prints a table)".into()).into()),
    };
    Ok(serde_json::to_value(measure(args, nu)?)?)
}

impl Default for ToughnessOptions {
    /// The command's defaults: the hexagonal strip, brittle springs.
    fn default() -> Self {
        ToughnessOptions {
            lattice: LatticeName::Hex,
            nu: None,
            height: None,
            window: None,
            depth: None,
            criterion: CriterionName::Stretch,
            softening: ShapeName::Linear,
            peak_fraction: 0.5,
            table: false,
            seed: 1,
            samples: 1,
        }
    }
}

/// A calibration table measured again: the nu values, each strip's figures and the value the
/// table holds for it.
#[derive(Debug, serde::Serialize)]
pub struct ToughnessTable {
    /// The constant's name (`HEX_TOUGHNESS`, ...) or, for softening springs, a comment naming the
    /// column of `hooke_fracture::softening`'s tables.
    pub name: String,
    pub softening: bool,
    pub rows: Vec<(Real, Real)>,
}

impl ToughnessTable {
    /// The table as the Rust source `hooke_fracture` holds.
    pub fn rust_source(&self) -> String {
        let mut s = String::new();
        if self.softening {
            s.push_str(&format!("{}\n", self.name));
            for (nu, f) in &self.rows {
                s.push_str(&format!("    ({nu:?}, {f:.4}),\n"));
            }
            return s;
        }
        s.push_str(&format!("const {}: &[(Real, Real)] = &[\n", self.name));
        for (nu, g) in &self.rows {
            s.push_str(&format!("    ({nu:?}, {g:.4}),\n"));
        }
        s.push_str("];\n");
        s
    }
}

/// The nu values to measure: the table's (`--table`) or the one `--nu`.
pub fn nu_list(args: &ToughnessOptions) -> Result<Vec<Real>> {
    let kind = LatticeKind::from(args.lattice);
    Ok(match (args.table, args.nu) {
        (true, _) if t_shape(args).is_some() => hooke_fracture::softening::TABLE_NU.to_vec(),
        (true, _) => table_nu(kind).to_vec(),
        (false, Some(nu)) => vec![nu],
        (false, None) => {
            return Err(
                InputError("give --nu NU, or --table for the calibration table".into()).into(),
            )
        }
    })
}

/// The value a table holds for one strip: F over the brittle calibration for softening springs,
/// the energy criterion's factor, the random lattices' factor on the hexagonal mapping, or the
/// regular lattices' Gamma.
pub fn table_value(args: &ToughnessOptions, j: &ToughnessJson) -> Real {
    let kind = LatticeKind::from(args.lattice);
    if let (Some(rho), Some(shape)) = (j.peak_fraction, t_shape(args)) {
        j.ratio * hooke_fracture::softening::toughness_factor(kind, j.nu, rho, shape)
    } else if j.criterion == "energy" {
        j.ratio * hooke_fracture::energy::energy_toughness_factor(kind, j.nu)
    } else if kind.is_random() {
        j.ratio * hooke_fracture::stretch::random_toughness_factor(kind, j.nu)
    } else {
        j.gamma
    }
}

/// `--table`: every nu of the lattice's table measured; `progress` sees each strip as it ends.
pub fn table(
    args: &ToughnessOptions,
    progress: &mut dyn FnMut(&ToughnessJson),
) -> Result<ToughnessTable> {
    check_args(args)?;
    if !args.table {
        return Err(InputError("give --table for the calibration table".into()).into());
    }
    let kind = LatticeKind::from(args.lattice);
    let mut rows = Vec::new();
    for nu in nu_list(args)? {
        let j = measure(args, nu)?;
        progress(&j);
        rows.push((nu, table_value(args, &j)));
    }
    if let Some(shape) = t_shape(args) {
        let name = format!(
            "// F of {} {} softening at peak fraction {} over nu = {:?}",
            kind.name(),
            shape.name(),
            args.peak_fraction,
            hooke_fracture::softening::TABLE_NU
        );
        return Ok(ToughnessTable {
            name,
            softening: true,
            rows,
        });
    }
    let energy = matches!(args.criterion, CriterionName::Energy);
    let name = match (kind, energy) {
        (LatticeKind::Cubic, true) => "CUBIC_ENERGY_FACTOR",
        (_, true) => "HEX_ENERGY_FACTOR",
        (LatticeKind::Cubic, false) => "CUBIC_TOUGHNESS",
        (LatticeKind::Random2d, false) => "RANDOM2D_TOUGHNESS",
        (LatticeKind::Random3d, false) => "RANDOM3D_TOUGHNESS",
        _ => "HEX_TOUGHNESS",
    };
    Ok(ToughnessTable {
        name: name.into(),
        softening: false,
        rows,
    })
}
