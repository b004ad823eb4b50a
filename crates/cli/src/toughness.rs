//! `hooke toughness`: the fracture energy a lattice crack really dissipates, measured on a strip
//! under fixed grips, and the table the G_c calibration uses. The experiment is
//! `hooke_lab::toughness`'s; this module parses the flags and prints.

use anyhow::Result;
use clap::Args;
use hooke_core::Real;
use hooke_lab::moduli::LatticeName;
use hooke_lab::toughness::{
    check_args, measure, nu_list, table, CriterionName, ShapeName, ToughnessJson, ToughnessOptions,
};

#[derive(Debug, Args)]
pub struct ToughnessArgs {
    /// Lattice to test.
    #[arg(long, value_enum, default_value = "hex")]
    pub lattice: LatticeName,
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
    pub criterion: CriterionName,
    /// --criterion softening: the shape of the softening branch.
    #[arg(long, value_enum, default_value = "linear")]
    pub softening: ShapeName,
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

impl ToughnessArgs {
    /// The experiment's options (the flags the library takes).
    pub fn options(&self) -> ToughnessOptions {
        ToughnessOptions {
            lattice: self.lattice,
            nu: self.nu,
            height: self.height,
            window: self.window,
            depth: self.depth,
            criterion: self.criterion,
            softening: self.softening,
            peak_fraction: self.peak_fraction,
            table: self.table,
            seed: self.seed,
            samples: self.samples,
        }
    }
}

/// One strip's line of text.
fn print_strip(j: &ToughnessJson, json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string(j)?);
        return Ok(());
    }
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
    Ok(())
}

pub fn run(args: ToughnessArgs) -> Result<()> {
    let opts = args.options();
    check_args(&opts)?;
    if args.table {
        let mut failed = None;
        let t = table(&opts, &mut |j| {
            if let Err(e) = print_strip(j, args.json) {
                failed.get_or_insert(e);
            }
        })?;
        if let Some(e) = failed {
            return Err(e);
        }
        print!("{}", t.rust_source());
        return Ok(());
    }
    for nu in nu_list(&opts)? {
        print_strip(&measure(&opts, nu)?, args.json)?;
    }
    Ok(())
}
