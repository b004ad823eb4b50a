//! `hooke moduli`: the paper's block test from the command line. The experiments are
//! `hooke_lab::moduli`'s; this module parses the flags, prints and plots.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use hooke_core::Real;
use hooke_lab::moduli::{
    bulk, measure, nu_of, random_table, AxisName, EndsName, LatticeName, ModuliJson, ModuliOptions,
    PlaneName, SamplerName,
};

use crate::InputError;

#[derive(Debug, Args)]
pub struct ModuliArgs {
    /// Lattice to test.
    #[arg(long, value_enum, default_value = "cubic")]
    pub lattice: LatticeName,
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
    pub ends: EndsName,
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
    /// Random lattices: seed of the first sample (sample s uses seed + s).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Random lattices: number of seeded samples; the mean and the spread (standard deviation)
    /// of E and nu are reported.
    #[arg(long, default_value_t = 1)]
    pub samples: usize,
    /// Random lattices: how the nodes are scattered.
    #[arg(long, value_enum, default_value = "poisson")]
    pub sampler: SamplerName,
    /// Random lattices with --sampler jitter: largest move of a node along each axis, as a
    /// fraction of the spacing (0 to 1).
    #[arg(long, default_value_t = 0.6)]
    pub jitter: Real,
    /// Random lattices: the axis the bar lies and is loaded along.
    #[arg(long, value_enum, default_value = "x")]
    pub axis: AxisName,
    /// Instead of the block: the exact bulk (affine) test of the infinite lattice, the full
    /// stiffness tensor in Voigt order (xx, yy, zz, yz, xz, xy; Pa, or N/m per unit thickness
    /// in 2D) against the isotropic target for the lattice's E and nu (`C_measured`,
    /// `C_target` with --json). Regular lattices.
    #[arg(long)]
    pub bulk: bool,
    /// Regular lattices: weight each spring and node by the share of the bulk's cells (cubes,
    /// triangles) it stands for, as random lattices weight theirs by volume: the free faces'
    /// bias in nu and E disappears (E is then measured on the nominal section between the
    /// outer node planes, which is the body's material). The default on regular lattices
    /// (as for a case's body); the flag is kept for scripts that give it.
    #[arg(long, conflicts_with = "equal_weights")]
    pub cell_weights: bool,
    /// Regular lattices: every spring and node as in the bulk, the paper's block (its free
    /// faces bias nu by about +0.009 at nu = 0.25 and E by +6 to +13 % against the nominal
    /// area): the behaviour before cell weights became the default.
    #[arg(long)]
    pub equal_weights: bool,
    /// A transversely isotropic material instead of the isotropic one (cubic lattice, fibre
    /// along a lattice axis, `docs/anisotropy.md`): E_p,E_t,nu_p,nu_tp,G_t (Pa, -, -, Pa), with
    /// p the plane of isotropy and t the fibre; nu_tp is the contraction across the fibre under
    /// tension along it. Replaces --nu and --stiffness. With --bulk, `C_target` is this
    /// material's stiffness; the block test reports the lateral ratios along y and z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub transverse: Option<Vec<Real>>,
    /// The fibre direction of --transverse: x, y, z, or three numbers X,Y,Z.
    #[arg(long, default_value = "z", allow_hyphen_values = true)]
    pub fibre: String,
    /// With --transverse and --bulk: lay the lattice along the fibre (the lattice axis nearest to
    /// it turned onto it, as `lattice.rotate_to` does), so that any fibre direction is reached;
    /// `C_target` and `C_measured` are then in the global axes.
    #[arg(long)]
    pub rotate_lattice: bool,
    /// An orthotropic material instead of the isotropic one (cubic lattice, material axes along
    /// the lattice's): E_x,E_y,E_z,nu_xy,nu_xz,nu_yz,G_yz,G_xz,G_xy (Pa and -), with nu_ij =
    /// -eps_j/eps_i under tension along i. Replaces --nu and --stiffness.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub orthotropic: Option<Vec<Real>>,
    /// With --orthotropic and --bulk: the material x and y axes in the body,
    /// X1,Y1,Z1,X2,Y2,Z2 (z is their cross product; as `material.axes`): the lattice is laid
    /// along them, and `C_target` and `C_measured` are in the body's axes.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub axes: Option<Vec<Real>>,
    /// Random lattices: measure the calibration table (nu and E/E_affine against q over the
    /// samples) that `hooke_core::random::calibration` holds, and print it as Rust source.
    #[arg(long)]
    pub table: bool,
    /// random3d: test the pillar inscribed in the bar instead (a cylinder along the load axis,
    /// its diameter the smaller lateral side, e.g. --size 21,15,15 for 7 spacings in radius and
    /// 20 high): its curved wall carries nodes of its own, as the box's faces do. E is measured
    /// on the section pi R^2, nu by fitting u_r = eps_r r over the middle third's nodes.
    #[arg(long)]
    pub cylinder: bool,
    /// With --cylinder: keep only the box's nodes that the cylinder holds, with none on its
    /// wall (how curved surfaces were sampled before; for comparison).
    #[arg(long, requires = "cylinder")]
    pub inner_surface: bool,
    /// With --bulk on a random lattice: also run cubes of half the side (same seeds) and
    /// extrapolate the held faces' excess away, assuming it goes like a/L: `extrapolated` in
    /// --json. A diagnostic: it helps in 3D up to nu = 0.25, not at 0.45 nor in 2D (docs/moduli.md).
    #[arg(long, requires = "bulk")]
    pub extrapolate: bool,
    /// With --transverse or --orthotropic on a random2d lattice (block or --bulk): how the plate
    /// stands for the 3D material, `stress` (a thin plate, the default) or `strain` (a thick
    /// body). Any fibre (one out of the plane: the plate is orthotropic in its projection and
    /// the normal to it); an orthotropic material needs one of its axes along z.
    #[arg(long, value_enum)]
    pub plane: Option<PlaneName>,
    /// With --bulk: a periodic laminate of two materials instead, layers normal to z:
    /// E1,nu1,E2,nu2,f2 (Pa, -, Pa, -, the volume fraction of material 2). Reports the cell's
    /// stiffness (`C_measured`) against Backus's exact laminate average (`C_target`) and the
    /// largest difference over the largest entry (`max_error`). The Ladd (cubic) lattice,
    /// periodic, 3 x 3 nodes across and --planes node planes per period
    /// (`hooke_lab::laminate`).
    #[arg(
        long,
        value_delimiter = ',',
        allow_hyphen_values = true,
        requires = "bulk"
    )]
    pub laminate: Option<Vec<Real>>,
    /// With --laminate: node planes per period (layers of about f2 and 1 - f2 of them).
    #[arg(long, default_value_t = 32, requires = "laminate")]
    pub planes: usize,
}

impl ModuliArgs {
    /// The experiment's options (the flags the library takes).
    pub fn options(&self) -> ModuliOptions {
        ModuliOptions {
            lattice: self.lattice,
            nu: self.nu,
            size: self.size.clone(),
            ends: self.ends,
            strain: self.strain,
            spacing: self.spacing,
            stiffness: self.stiffness,
            seed: self.seed,
            samples: self.samples,
            sampler: self.sampler,
            jitter: self.jitter,
            axis: self.axis,
            bulk: self.bulk,
            cell_weights: self.cell_weights,
            equal_weights: self.equal_weights,
            transverse: self.transverse.clone(),
            fibre: self.fibre.clone(),
            rotate_lattice: self.rotate_lattice,
            orthotropic: self.orthotropic.clone(),
            axes: self.axes.clone(),
            table: self.table,
            cylinder: self.cylinder,
            inner_surface: self.inner_surface,
            extrapolate: self.extrapolate,
            plane: self.plane,
        }
    }
}

pub fn run(args: ModuliArgs) -> Result<()> {
    let opts = args.options();
    opts.check()?;
    if args.table {
        let table = random_table(&opts, &mut |r| {
            eprintln!(
                "q {:>6}: nu {:.4} (affine {:.4}, spread {:.4}), E/E_affine {:.4} (spread {:.4}), {:.1} s",
                r.q, r.nu, r.nu_affine, r.nu_spread, r.youngs_ratio, r.youngs_ratio_spread, r.seconds
            )
        })?;
        print!("{}", table.rust_source());
        return Ok(());
    }
    if args.sweep {
        return sweep(&args, &opts);
    }
    if let Some(l) = &args.laminate {
        return laminate(&args, l);
    }
    let nu = nu_of(&opts)?;
    if args.bulk {
        let v = bulk(&opts, nu)?;
        if args.json {
            println!("{v}");
        } else {
            print_bulk(&v);
        }
        return Ok(());
    }
    let m = measure(&opts, nu)?;
    if args.json {
        println!("{}", serde_json::to_string(&m)?);
    } else {
        print_table(&m);
    }
    Ok(())
}

/// `--bulk --laminate`: the periodic laminate against Backus's average.
fn laminate(args: &ModuliArgs, l: &[Real]) -> Result<()> {
    use hooke_lab::laminate::{laminate, LaminateSpec};
    let [e1, nu1, e2, nu2, f2] = l[..] else {
        return Err(InputError(format!(
            "--laminate: {} numbers; give E1,nu1,E2,nu2,f2 (e.g. 10e9,0.1,100e9,0.4,0.5)",
            l.len()
        ))
        .into());
    };
    if !matches!(args.lattice, LatticeName::Cubic) {
        return Err(InputError(
            "--laminate runs on the Ladd lattice (--lattice cubic): the random lattices are not built periodic".into(),
        )
        .into());
    }
    let spec = LaminateSpec::new([e1, nu1, e2, nu2, f2], args.planes, args.spacing);
    let r = laminate(&spec)?;
    if args.json {
        println!("{}", serde_json::to_string(&r)?);
        return Ok(());
    }
    println!(
        "periodic laminate, cubic lattice: {} + {} node planes per period ({} nodes), f2 = {} (asked {}); layers E {:e} Pa, nu {} and E {:e} Pa, nu {}; Voigt xx yy zz yz xz xy",
        r.planes[0], r.planes[1], r.nodes, r.f2, r.f2_asked, e1, nu1, e2, nu2
    );
    for (name, c) in [("measured", &r.c_measured), ("Backus", &r.c_target)] {
        println!("  C {name}:");
        for row in c {
            println!(
                "    {}",
                row.iter()
                    .map(|x| format!("{x:>12.4e}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
    }
    println!(
        "  largest difference over the largest entry: {:.3e}",
        r.max_error
    );
    Ok(())
}

fn print_bulk(v: &serde_json::Value) {
    if let Some(name) = ["transverse", "orthotropic"]
        .into_iter()
        .find(|n| v[*n].is_object())
    {
        print_anisotropic_header(v, name);
    } else if v["relaxed"].as_bool() == Some(true) {
        println!(
            "relaxed bulk test: {} lattice, cube of {} spacings with its faces on the affine field, {} nodes ({} on the faces), {} sample(s) from seed {}",
            v["lattice"].as_str().unwrap_or(""),
            v["cube_spacings"],
            v["nodes"],
            v["boundary_nodes"],
            v["samples"],
            v["seed"]
        );
        println!(
            "nu = {}, q = {:.6}, calibrated E = {:.6e} ({}); measured E = {:.6e}, nu = {:.4}; Voigt xx yy zz yz xz xy",
            v["nu"],
            v["q"].as_f64().unwrap_or(0.0),
            v["youngs"].as_f64().unwrap_or(0.0),
            v["units"].as_str().unwrap_or(""),
            v["youngs_measured"].as_f64().unwrap_or(0.0),
            v["nu_measured"].as_f64().unwrap_or(0.0),
        );
    } else {
        println!(
            "bulk (affine) test: {} lattice, nu = {}, q = {:.6}, E = {:.6e} ({}); Voigt xx yy zz yz xz xy",
            v["lattice"].as_str().unwrap_or(""), v["nu"], v["q"].as_f64().unwrap_or(0.0),
            v["youngs"].as_f64().unwrap_or(0.0), v["units"].as_str().unwrap_or("")
        );
    }
    print_tensors(v);
}

/// `--bulk`'s header for an anisotropic material: its calibrated design on a random lattice
/// (design, calibration, the material-axes differences), or its springs on the Ladd lattice.
fn print_anisotropic_header(v: &serde_json::Value, name: &str) {
    if v["design"].is_object() {
        let plate = v["lattice"] == "random2d";
        let cubes = if plate { "squares" } else { "cubes" };
        println!(
            "relaxed bulk test: {} lattice{}, {name} {}; inner {cubes} (two thirds of the side) of {} {cubes} of {} spacings, seeds {} on; Voigt xx yy zz yz xz xy ({})",
            v["lattice"].as_str().unwrap_or(""),
            v["plane"].as_str().map_or(String::new(), |p| format!(" (plane {p})")),
            v[name], v["samples"], v["cube_spacings"], v["seed"], v["units"].as_str().unwrap_or("")
        );
        let d = &v["design"];
        println!(
            "design: kappa(n) = sum_a kappa_aa n_a^2P + sum_a<b kappa_ab n_a^2 n_b^2, P = {}, over xx yy zz yz xz xy (material axes) = {} Pa; w(n) = sum alpha_a n_a^2, alpha = {}; q = {:.6}",
            d["sharpness"], d["kappa"], d["alpha"], v["q"].as_f64().unwrap_or(0.0)
        );
        let cal = &v["calibration"];
        println!(
            "calibration: largest entry off the target over the largest normal entry after each measurement {}, on as many other {cubes} {:.2e} ({:.1} s; {} {cubes} of {} spacings, seeds {} to {}){}",
            cal["residuals"], cal["held_out"].as_f64().unwrap_or(Real::NAN), cal["seconds"].as_f64().unwrap_or(0.0),
            cal["samples"], cal["cube_spacings"], cal["seeds"][0], cal["seeds"][1],
            cal["cache_note"].as_str().unwrap_or("")
        );
        println!(
            "in the material axes, {} measured / target - 1: {}",
            v["material_entries"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|e| format!("C{}", e.as_str().unwrap_or("")))
                .collect::<Vec<_>>()
                .join(" "),
            v["material_relative_difference"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|x| format!("{:+.4}", x.as_f64().unwrap_or(Real::NAN)))
                .collect::<Vec<_>>()
                .join(" ")
        );
    } else {
        println!(
            "bulk (affine) test: {} lattice, {name} {}, q = {:.6} ({}); Voigt xx yy zz yz xz xy",
            v["lattice"].as_str().unwrap_or(""),
            v[name],
            v["q"].as_f64().unwrap_or(0.0),
            v["units"].as_str().unwrap_or("")
        );
        println!(
            "springs: axes x y z k = {} w = {}; face diagonals yz xz xy k = {} w = {} (N/m)",
            v["axis_stiffness"], v["axis_weights"], v["diagonal_stiffness"], v["diagonal_weights"]
        );
    }
}

/// `--bulk`'s tensors and their differences, and the extrapolation where there is one.
fn print_tensors(v: &serde_json::Value) {
    for name in [
        "C_measured",
        "C_target",
        "C_spread",
        "C_affine",
        "C_interior",
    ] {
        if v[name].is_null() {
            continue;
        }
        println!("{name}:");
        for row in v[name].as_array().into_iter().flatten() {
            let cells: Vec<String> = row
                .as_array()
                .into_iter()
                .flatten()
                .map(|x| format!("{:>13.6e}", x.as_f64().unwrap_or(0.0)))
                .collect();
            println!("  {}", cells.join(" "));
        }
    }
    println!(
        "largest difference: {:.2e} of the largest entry",
        v["max_relative_difference"].as_f64().unwrap_or(0.0)
    );
    if let Some(e) = v["max_entry_relative_difference"].as_f64() {
        println!(
            "largest difference entry by entry: {:.2} % (of the entry, or of the largest where the target's is zero)",
            100.0 * e
        );
    }
    let x = &v["extrapolated"];
    if let Some(e) = x["max_entry_relative_difference"].as_f64() {
        println!(
            "extrapolated to an infinite cube (with {} spacings): C11 {:.6e}, largest difference entry by entry {:.2} %",
            x["half_cube_spacings"],
            x["C_extrapolated"][0][0].as_f64().unwrap_or(0.0),
            100.0 * e
        );
    }
}

fn print_table(m: &ModuliJson) {
    let unit = if m.lattice == "hex" || m.lattice == "random2d" {
        "N/m per unit thickness"
    } else {
        "Pa"
    };
    let weights = match (m.lattice, m.cell_weights) {
        ("random2d" | "random3d", _) => "",
        (_, true) => ", cell weights",
        (_, false) => ", equal weights",
    };
    println!(
        "block test: {} lattice, {:?} nodes, {} springs, {} ends, strain {:e}{weights}",
        m.lattice, m.size, m.springs, m.ends, m.strain
    );
    println!("  q = {:.6}", m.q);
    if let (Some(n), Some(nsd), Some(esd)) = (m.samples, m.nu_spread, m.e_spread) {
        println!(
            "  {n} samples ({} sampler, load along {}, seeds from {}): means below; spread \
             (standard deviation) nu {nsd:.4}, E {:.2} %",
            m.sampler.unwrap_or("?"),
            m.axis.unwrap_or("x"),
            m.seed.unwrap_or(0),
            100.0 * esd / m.e_measured
        );
    }
    println!("               target        measured      error");
    println!(
        "  nu       {:>12.6}  {:>12.6}  {:>+10.2e} (absolute)",
        m.nu_target, m.nu_measured, m.nu_error
    );
    println!(
        "  E        {:>12.6}  {:>12.6}  {:>+10.2e} (relative; {unit}, nominal area)",
        m.e_target, m.e_measured, m.e_relative_error
    );
    if let Some(e) = m.e_measured_middle {
        println!(
            "  E (middle third's strain) {:>9.6e}  {:>+10.2e}",
            e,
            e / m.e_target - 1.0
        );
    } else {
        println!(
            "  E (node-cell area)     {:>12.6}  {:>+10.2e}",
            m.e_measured_cell,
            m.e_measured_cell / m.e_target - 1.0
        );
    }
    if let (Some(lm), Some(lt)) = (m.lateral_measured, m.lateral_target) {
        println!(
            "  lateral  {:>12.6} {:>12.6}  measured {:>12.6} {:>12.6} (the two lateral axes' -eps/eps)",
            lt[0], lt[1], lm[0], lm[1]
        );
    }
    println!(
        "  solve: {} Newton / {} CG iterations, relative residual {:.2e}, {:.2} s",
        m.iterations, m.cg_iterations, m.residual, m.seconds
    );
}

fn sweep(args: &ModuliArgs, opts: &ModuliOptions) -> Result<()> {
    let three_d = matches!(args.lattice, LatticeName::Cubic);
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
        let m = measure(opts, nu)?;
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
    let weights = if args.equal_weights {
        ", equal weights"
    } else {
        ", cell weights"
    };
    let title = if three_d {
        format!(
            "Poisson's ratio, cubic (Ladd) lattice {}{weights}",
            size_label(args, "71x16x16")
        )
    } else {
        format!(
            "in-plane Poisson's ratio, hexagonal lattice {}{weights}",
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
