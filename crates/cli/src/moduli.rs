//! `hooke moduli`: the paper's block test from the command line.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use hooke_core::moduli::{block_test, BlockResult, BlockTest, Ends};
use hooke_core::{LatticeKind, Real};

use crate::InputError;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LatticeArg {
    /// Ladd's 3D cubic lattice (6 + 12 neighbours).
    Cubic,
    /// 2D hexagonal lattice (6 neighbours).
    Hex,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum EndsArg {
    /// End planes free to slide across the load (uniaxial stress, the paper's test).
    Slide,
    /// End planes fixed across the load.
    Clamp,
}

#[derive(Debug, Args)]
pub struct ModuliArgs {
    /// Lattice to test.
    #[arg(long, value_enum, default_value = "cubic")]
    pub lattice: LatticeArg,
    /// The lattice's own Poisson's ratio (3D: -0.99 <= nu < 0.5; hex: the in-plane nu_2D,
    /// -0.99 <= nu_2D <= 0.99). Required unless --sweep.
    #[arg(long, allow_negative_numbers = true)]
    pub nu: Option<Real>,
    /// Nodes per axis: NX,NY,NZ (cubic; default 71,16,16, the paper's 70a x 15a x 15a block) or
    /// NX,ROWS (hex; default 71,16).
    #[arg(long, value_delimiter = ',')]
    pub size: Option<Vec<usize>>,
    /// How the loaded end planes are held across the load.
    #[arg(long, value_enum, default_value = "slide")]
    pub ends: EndsArg,
    /// Applied axial strain eps: the end planes move by -/+ eps Lx/2 (negative compresses).
    #[arg(long, default_value_t = 1e-5, allow_negative_numbers = true)]
    pub strain: Real,
    /// Lattice spacing a (m).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub spacing: Real,
    /// Spring stiffness k (N/m).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub stiffness: Real,
    /// Print one JSON object (one per line with --sweep) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Run a list of nu values and write a CSV and a PNG plot of measured against target nu
    /// (like the paper's Fig. 7).
    #[arg(long)]
    pub sweep: bool,
    /// The nu values of --sweep (default: -0.9 to 0.49 in 3D, -0.9 to 0.95 in 2D).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub sweep_nu: Option<Vec<Real>>,
    /// Where --sweep writes moduli_sweep_<lattice>.csv and .png.
    #[arg(long, default_value = ".")]
    pub out: PathBuf,
}

impl From<LatticeArg> for LatticeKind {
    fn from(l: LatticeArg) -> Self {
        match l {
            LatticeArg::Cubic => LatticeKind::Cubic,
            LatticeArg::Hex => LatticeKind::Hex,
        }
    }
}

fn test_for(args: &ModuliArgs, nu: Real) -> Result<BlockTest> {
    let kind = LatticeKind::from(args.lattice);
    let mut t = BlockTest::paper(kind, nu);
    if let Some(s) = &args.size {
        t.size = match (kind, s.as_slice()) {
            (LatticeKind::Cubic, &[x, y, z]) => [x, y, z],
            (LatticeKind::Hex, &[x, r]) => [x, r, 1],
            (LatticeKind::Cubic, _) => {
                return Err(InputError(format!(
                    "--size {s:?}: the cubic lattice takes three numbers, NX,NY,NZ (e.g. 71,16,16)"
                ))
                .into())
            }
            (LatticeKind::Hex, _) => {
                return Err(InputError(format!(
                    "--size {s:?}: the hexagonal lattice takes two numbers, NX,ROWS (e.g. 71,16)"
                ))
                .into())
            }
        };
    }
    t.ends = match args.ends {
        EndsArg::Slide => Ends::Slide,
        EndsArg::Clamp => Ends::Clamp,
    };
    t.strain = args.strain;
    t.spacing = args.spacing;
    t.stiffness = args.stiffness;
    for (name, v) in [("--spacing", t.spacing), ("--stiffness", t.stiffness)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(InputError(format!("{name} {v}: give a positive number")).into());
        }
    }
    Ok(t)
}

/// The measured figures, as printed by `--json`.
#[derive(Debug, serde::Serialize)]
pub struct ModuliJson {
    pub lattice: &'static str,
    pub ends: &'static str,
    pub size: Vec<usize>,
    pub nu_target: Real,
    pub nu_measured: Real,
    pub nu_error: Real,
    #[serde(rename = "E_target")]
    pub e_target: Real,
    #[serde(rename = "E_measured")]
    pub e_measured: Real,
    #[serde(rename = "E_relative_error")]
    pub e_relative_error: Real,
    #[serde(rename = "E_measured_cell_area")]
    pub e_measured_cell: Real,
    pub q: Real,
    pub nodes: usize,
    pub springs: usize,
    pub iterations: usize,
    pub cg_iterations: usize,
    pub residual: Real,
    pub strain: Real,
    pub seconds: f64,
}

fn to_json(t: &BlockTest, r: &BlockResult, seconds: f64) -> ModuliJson {
    ModuliJson {
        lattice: t.kind.name(),
        ends: match t.ends {
            Ends::Slide => "slide",
            Ends::Clamp => "clamp",
        },
        size: if t.kind.dim() == 3 {
            t.size.to_vec()
        } else {
            t.size[..2].to_vec()
        },
        nu_target: r.nu_target,
        nu_measured: r.nu_measured,
        nu_error: r.nu_measured - r.nu_target,
        e_target: r.e_target,
        e_measured: r.e_measured,
        e_relative_error: r.e_measured / r.e_target - 1.0,
        e_measured_cell: r.e_measured_cell,
        q: r.q,
        nodes: r.nodes,
        springs: r.springs,
        iterations: r.solve.newton_iterations,
        cg_iterations: r.solve.cg_iterations,
        residual: r.solve.residual,
        strain: t.strain,
        seconds,
    }
}

fn measure(args: &ModuliArgs, nu: Real) -> Result<ModuliJson> {
    let t = test_for(args, nu)?;
    let start = Instant::now();
    let r = block_test(&t).with_context(|| format!("block test at nu = {nu}"))?;
    Ok(to_json(&t, &r, start.elapsed().as_secs_f64()))
}

pub fn run(args: ModuliArgs) -> Result<()> {
    if args.sweep {
        return sweep(&args);
    }
    let nu = args.nu.ok_or_else(|| {
        InputError("give --nu NU (the Poisson's ratio to build), or --sweep".into())
    })?;
    let m = measure(&args, nu)?;
    if args.json {
        println!("{}", serde_json::to_string(&m)?);
    } else {
        print_table(&m);
    }
    Ok(())
}

fn print_table(m: &ModuliJson) {
    let unit = if m.lattice == "hex" {
        "N/m per unit thickness"
    } else {
        "Pa"
    };
    println!(
        "block test: {} lattice, {:?} nodes, {} springs, {} ends, strain {:e}",
        m.lattice, m.size, m.springs, m.ends, m.strain
    );
    println!("  q = {:.6}", m.q);
    println!("               target        measured      error");
    println!(
        "  nu       {:>12.6}  {:>12.6}  {:>+10.2e} (absolute)",
        m.nu_target, m.nu_measured, m.nu_error
    );
    println!(
        "  E        {:>12.6}  {:>12.6}  {:>+10.2e} (relative; {unit}, nominal area)",
        m.e_target, m.e_measured, m.e_relative_error
    );
    println!(
        "  E (node-cell area)     {:>12.6}  {:>+10.2e}",
        m.e_measured_cell,
        m.e_measured_cell / m.e_target - 1.0
    );
    println!(
        "  solve: {} Newton / {} CG iterations, relative residual {:.2e}, {:.2} s",
        m.iterations, m.cg_iterations, m.residual, m.seconds
    );
}

fn sweep(args: &ModuliArgs) -> Result<()> {
    let three_d = matches!(args.lattice, LatticeArg::Cubic);
    let nus = args.sweep_nu.clone().unwrap_or_else(|| {
        if three_d {
            vec![
                -0.9, -0.75, -0.5, -0.25, 0.0, 0.1, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.49,
            ]
        } else {
            vec![-0.9, -0.5, 0.0, 0.2, 1.0 / 3.0, 0.5, 0.7, 0.9, 0.95]
        }
    });
    if nus.is_empty() {
        return Err(InputError("--sweep-nu is empty: give at least one value".into()).into());
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let name = if three_d { "cubic" } else { "hex" };
    let csv_path = args.out.join(format!("moduli_sweep_{name}.csv"));
    let png_path = args.out.join(format!("moduli_sweep_{name}.png"));
    let mut rows = Vec::new();
    let mut csv = String::from("nu_target,nu_measured,nu_error,E_target,E_measured,E_relative_error,q,iterations,cg_iterations,residual\n");
    for &nu in &nus {
        let m = measure(args, nu)?;
        if args.json {
            println!("{}", serde_json::to_string(&m)?);
        } else {
            println!(
                "nu target {:>8.4}  measured {:>9.5}  error {:>+9.5}   E rel. error {:>+8.4}   ({:.2} s)",
                m.nu_target, m.nu_measured, m.nu_error, m.e_relative_error, m.seconds
            );
        }
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            m.nu_target,
            m.nu_measured,
            m.nu_error,
            m.e_target,
            m.e_measured,
            m.e_relative_error,
            m.q,
            m.iterations,
            m.cg_iterations,
            m.residual
        ));
        rows.push((m.nu_target, m.nu_measured));
    }
    write_atomic(&csv_path, csv.as_bytes())?;
    let title = if three_d {
        format!(
            "Poisson's ratio, cubic (Ladd) lattice {}",
            size_label(args, "71x16x16")
        )
    } else {
        format!(
            "in-plane Poisson's ratio, hexagonal lattice {}",
            size_label(args, "71x16")
        )
    };
    crate::plot::nu_sweep(&png_path, &title, three_d, &rows)?;
    if !args.json {
        println!("wrote {} and {}", csv_path.display(), png_path.display());
    }
    Ok(())
}

fn size_label(args: &ModuliArgs, default: &str) -> String {
    args.size
        .as_ref()
        .map(|s| {
            s.iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join("x")
        })
        .unwrap_or_else(|| default.to_string())
}

/// Write through a temporary file and a rename, so a reader never sees half a file.
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))?;
    Ok(())
}
