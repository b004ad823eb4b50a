//! The paper's block test and the bulk tests, as experiments with options and results: the
//! ensembles over random node sets, the relaxed-bulk extrapolation
//! `C_inf = (L C(L) - L' C(L')) / (L - L')`, the tensor statistics and the random lattices'
//! calibration table. `hooke moduli` and `hooke.moduli` (Python) both call [`value`].

use hooke_core::Designs;
use std::time::Instant;

use anyhow::{Context, Result};
use hooke_core::anisotropy::{Anisotropic, Orthotropic, Transverse};
use hooke_core::moduli::{
    block_test, relaxed_bulk_stiffness, BlockResult, BlockTest, Ends, RelaxedBulk,
    RelaxedBulkResult,
};
use hooke_core::random::anisotropic::Cached;
use hooke_core::random::{calibration, RandomSpec, Sampler};
use hooke_core::{LatticeKind, Real};

use crate::InputError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum LatticeName {
    /// Ladd's 3D cubic lattice (6 + 12 neighbours).
    Cubic,
    /// 2D hexagonal lattice (6 neighbours).
    Hex,
    /// 2D random lattice (Delaunay triangulation of scattered nodes).
    Random2d,
    /// 3D random lattice (Delaunay tetrahedralisation of scattered nodes).
    Random3d,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SamplerName {
    /// Blue noise: maximal Poisson-disk sampling.
    Poisson,
    /// A jittered grid (see --jitter).
    Jitter,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum AxisName {
    X,
    Y,
    Z,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum EndsName {
    /// End planes free to slide across the load (uniaxial stress, the paper's test).
    Slide,
    /// End planes fixed across the load.
    Clamp,
}

/// What `hooke moduli` and `hooke.moduli` ask for: the block test, the bulk test or the
/// calibration table. Fields are the command's flags (`--sampler jitter` is `sampler: Jitter`);
/// from JSON or Python keyword arguments every field is optional and takes the command's default.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModuliOptions {
    /// Lattice to test.
    pub lattice: LatticeName,
    /// The lattice's own Poisson's ratio (3D: -0.99 <= nu < 0.5; hex: the in-plane nu_2D,
    /// -0.99 <= nu_2D <= 0.99). Required unless --sweep.
    pub nu: Option<Real>,
    /// Nodes per axis: NX,NY,NZ (cubic; default 71,16,16, the paper's 70a x 15a x 15a block) or
    /// NX,ROWS (hex; default 71,16).
    pub size: Option<Vec<usize>>,
    /// How the loaded end planes are held across the load.
    pub ends: EndsName,
    /// Applied axial strain eps: the end planes move by -/+ eps Lx/2 (negative compresses).
    pub strain: Real,
    /// Lattice spacing a (m).
    pub spacing: Real,
    /// Spring stiffness k (N/m).
    pub stiffness: Real,
    /// Random lattices: seed of the first sample (sample s uses seed + s).
    pub seed: u64,
    /// Random lattices: number of seeded samples; the mean and the spread (standard deviation)
    /// of E and nu are reported.
    pub samples: usize,
    /// Random lattices: how the nodes are scattered.
    pub sampler: SamplerName,
    /// Random lattices with --sampler jitter: largest move of a node along each axis, as a
    /// fraction of the spacing (0 to 1).
    pub jitter: Real,
    /// Random lattices: the axis the bar lies and is loaded along.
    pub axis: AxisName,
    /// Instead of the block: the exact bulk (affine) test of the infinite lattice, the full
    /// stiffness tensor in Voigt order (xx, yy, zz, yz, xz, xy; Pa, or N/m per unit thickness
    /// in 2D) against the isotropic target for the lattice's E and nu (`C_measured`,
    /// `C_target` with --json). Regular lattices.
    pub bulk: bool,
    /// Regular lattices: weight each spring and node by the share of the bulk's cells (cubes,
    /// triangles) it stands for, as random lattices weight theirs by volume: the free faces'
    /// bias in nu and E disappears (E is then measured on the nominal section between the
    /// outer node planes, which is the body's material). The default on regular lattices
    /// (as for a case's body); the flag is kept for scripts that give it.
    pub cell_weights: bool,
    /// Regular lattices: every spring and node as in the bulk, the paper's block (its free
    /// faces bias nu by about +0.009 at nu = 0.25 and E by +6 to +13 % against the nominal
    /// area): the behaviour before cell weights became the default.
    pub equal_weights: bool,
    /// A transversely isotropic material instead of the isotropic one (cubic lattice, fibre
    /// along a lattice axis, `docs/anisotropy.md`): E_p,E_t,nu_p,nu_tp,G_t (Pa, -, -, Pa), with
    /// p the plane of isotropy and t the fibre; nu_tp is the contraction across the fibre under
    /// tension along it. Replaces --nu and --stiffness. With --bulk, `C_target` is this
    /// material's stiffness; the block test reports the lateral ratios along y and z.
    pub transverse: Option<Vec<Real>>,
    /// The fibre direction of --transverse: x, y, z, or three numbers X,Y,Z.
    pub fibre: String,
    /// With --transverse and --bulk: lay the lattice along the fibre (the lattice axis nearest to
    /// it turned onto it, as `lattice.rotate_to` does), so that any fibre direction is reached;
    /// `C_target` and `C_measured` are then in the global axes.
    pub rotate_lattice: bool,
    /// An orthotropic material instead of the isotropic one (cubic lattice, material axes along
    /// the lattice's): E_x,E_y,E_z,nu_xy,nu_xz,nu_yz,G_yz,G_xz,G_xy (Pa and -), with nu_ij =
    /// -eps_j/eps_i under tension along i. Replaces --nu and --stiffness.
    pub orthotropic: Option<Vec<Real>>,
    /// With --orthotropic and --bulk: the material x and y axes in the body,
    /// X1,Y1,Z1,X2,Y2,Z2 (z is their cross product; as `material.axes`): the lattice is laid
    /// along them, and `C_target` and `C_measured` are in the body's axes.
    pub axes: Option<Vec<Real>>,
    /// Random lattices: measure the calibration table (nu and E/E_affine against q over the
    /// samples) that `hooke_core::random::calibration` holds, and print it as Rust source.
    pub table: bool,
    /// random3d: test the pillar inscribed in the bar instead (a cylinder along the load axis,
    /// its diameter the smaller lateral side, e.g. --size 21,15,15 for 7 spacings in radius and
    /// 20 high): its curved wall carries nodes of its own, as the box's faces do. E is measured
    /// on the section pi R^2, nu by fitting u_r = eps_r r over the middle third's nodes.
    pub cylinder: bool,
    /// With --cylinder: keep only the box's nodes that the cylinder holds, with none on its
    /// wall (how curved surfaces were sampled before; for comparison).
    pub inner_surface: bool,
    /// With --bulk on a random lattice: also run cubes of half the side (same seeds) and
    /// extrapolate the held faces' excess away, assuming it goes like a/L: `extrapolated` in
    /// --json. A diagnostic: it helps in 3D up to nu = 0.25, not at 0.45 nor in 2D (docs/moduli.md).
    pub extrapolate: bool,
    /// With --transverse or --orthotropic on a random2d lattice (block or --bulk): how the plate
    /// stands for the 3D material, `stress` (a thin plate, the default) or `strain` (a thick
    /// body). Any fibre (one out of the plane: the plate is orthotropic in its projection and
    /// the normal to it); an orthotropic material needs one of its axes along z.
    pub plane: Option<PlaneName>,
}

impl Default for ModuliOptions {
    /// The command's defaults: the paper's cubic block at a strain of 1e-5 in lattice units.
    fn default() -> Self {
        ModuliOptions {
            lattice: LatticeName::Cubic,
            nu: None,
            size: None,
            ends: EndsName::Slide,
            strain: 1e-5,
            spacing: 1.0,
            stiffness: 1.0,
            seed: 1,
            samples: 1,
            sampler: SamplerName::Poisson,
            jitter: 0.6,
            axis: AxisName::X,
            bulk: false,
            cell_weights: false,
            equal_weights: false,
            transverse: None,
            fibre: "z".into(),
            rotate_lattice: false,
            orthotropic: None,
            axes: None,
            table: false,
            cylinder: false,
            inner_surface: false,
            extrapolate: false,
            plane: None,
        }
    }
}

impl ModuliOptions {
    /// Refuse the combinations that mean nothing, naming the flags (what the command line's
    /// parser refuses too, for callers that do not go through it).
    pub fn check(&self) -> Result<()> {
        let refuse = |m: &str| Err(InputError(m.into()).into());
        if self.cell_weights && self.equal_weights {
            return refuse("--cell-weights and --equal-weights: keep one");
        }
        if self.inner_surface && !self.cylinder {
            return refuse("--inner-surface goes with --cylinder");
        }
        if self.extrapolate && !self.bulk {
            return refuse("--extrapolate goes with --bulk");
        }
        if self.plane.is_some()
            && !(self.lattice == LatticeName::Random2d
                && (self.transverse.is_some() || self.orthotropic.is_some()))
        {
            return refuse(
                "--plane: how a random2d plate stands for an anisotropic material; it goes with --lattice random2d and --transverse or --orthotropic (an isotropic plate takes its in-plane nu_2D directly)",
            );
        }
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum PlaneName {
    Stress,
    Strain,
}

impl From<PlaneName> for hooke_core::material::PlaneModel {
    fn from(p: PlaneName) -> Self {
        match p {
            PlaneName::Stress => hooke_core::material::PlaneModel::Stress,
            PlaneName::Strain => hooke_core::material::PlaneModel::Strain,
        }
    }
}

impl From<LatticeName> for LatticeKind {
    fn from(l: LatticeName) -> Self {
        match l {
            LatticeName::Cubic => LatticeKind::Cubic,
            LatticeName::Hex => LatticeKind::Hex,
            LatticeName::Random2d => LatticeKind::Random2d,
            LatticeName::Random3d => LatticeKind::Random3d,
        }
    }
}

/// `--transverse` (with `--fibre`) or `--orthotropic` as a material (density 1: the moduli do
/// not depend on it).
pub fn anisotropic(args: &ModuliOptions) -> Result<Option<Anisotropic>> {
    if args.axes.is_some() && args.orthotropic.is_none() {
        return Err(InputError(
            "--axes: material axes go with --orthotropic (a --transverse material takes --fibre)"
                .into(),
        )
        .into());
    }
    if let Some(v) = &args.orthotropic {
        if args.transverse.is_some() {
            return Err(InputError("--transverse and --orthotropic: keep one".into()).into());
        }
        let &[ex, ey, ez, nxy, nxz, nyz, gyz, gxz, gxy] = v.as_slice() else {
            return Err(InputError(format!(
                "--orthotropic {v:?}: give nine numbers, E_x,E_y,E_z,nu_xy,nu_xz,nu_yz,G_yz,G_xz,G_xy"
            ))
            .into());
        };
        let axes = match args.axes.as_deref() {
            None => Orthotropic::AXES,
            Some(&[a, b, c, d, e, f]) => Orthotropic::axes_from([a, b, c], [d, e, f])
                .map_err(|e| InputError(format!("--axes: {e}")))?,
            Some(v) => {
                return Err(InputError(format!(
                    "--axes {v:?}: give six numbers, the material x and y axes X1,Y1,Z1,X2,Y2,Z2"
                ))
                .into())
            }
        };
        let o = Orthotropic {
            youngs: [ex, ey, ez],
            poisson: [nxy, nxz, nyz],
            shear: [gyz, gxz, gxy],
            density: 1.0,
            axes,
        };
        o.stiffness()
            .map_err(|e| InputError(format!("--orthotropic: {e}")))?;
        return Ok(Some(Anisotropic::Orthotropic(o)));
    }
    Ok(transverse(args)?.map(Anisotropic::Transverse))
}

/// `--transverse` and `--fibre` as a material (density 1: the moduli do not depend on it).
pub fn transverse(args: &ModuliOptions) -> Result<Option<Transverse>> {
    let Some(v) = &args.transverse else {
        return Ok(None);
    };
    let &[ep, et, np, ntp, gt] = v.as_slice() else {
        return Err(InputError(format!(
            "--transverse {v:?}: give five numbers, E_p,E_t,nu_p,nu_tp,G_t (e.g. 10e9,25e9,0.35,0.28,4e9)"
        ))
        .into());
    };
    let fibre = match args.fibre.as_str() {
        "x" => [1.0, 0.0, 0.0],
        "y" => [0.0, 1.0, 0.0],
        "z" => [0.0, 0.0, 1.0],
        other => {
            let parts: Vec<Real> = other
                .split(',')
                .map(|x| x.trim().parse::<Real>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| {
                    InputError(format!(
                        "--fibre {other}: give x, y, z or three numbers X,Y,Z"
                    ))
                })?;
            let &[x, y, z] = parts.as_slice() else {
                return Err(InputError(format!(
                    "--fibre {other}: give x, y, z or three numbers X,Y,Z"
                ))
                .into());
            };
            [x, y, z]
        }
    };
    let m = Transverse {
        youngs_plane: ep,
        youngs_fibre: et,
        poisson_plane: np,
        poisson_fibre: ntp,
        shear_fibre: gt,
        density: 1.0,
        fibre,
    };
    m.validate()
        .map_err(|e| InputError(format!("--transverse: {e}")))?;
    Ok(Some(m))
}

/// `--seed`, `--sampler` and `--jitter`: how a random lattice's nodes are scattered.
fn random_spec(args: &ModuliOptions) -> Result<RandomSpec> {
    let sampler = match args.sampler {
        SamplerName::Poisson => Sampler::Poisson,
        SamplerName::Jitter => {
            if !(0.0..=1.0).contains(&args.jitter) {
                return Err(InputError(format!(
                    "--jitter {}: give a fraction of the spacing in [0, 1]",
                    args.jitter
                ))
                .into());
            }
            Sampler::Jitter {
                amplitude: args.jitter,
            }
        }
    };
    Ok(RandomSpec {
        sampler,
        seed: args.seed,
    })
}

/// Refuse `--cell-weights` and `--equal-weights` where they mean nothing, saying `why`.
fn no_weights_flag(args: &ModuliOptions, why: &str) -> Result<()> {
    for (given, flag) in [
        (args.cell_weights, "--cell-weights"),
        (args.equal_weights, "--equal-weights"),
    ] {
        if given {
            return Err(InputError(format!("{flag}: {why}")).into());
        }
    }
    Ok(())
}

fn test_for(args: &ModuliOptions, nu: Real) -> Result<BlockTest> {
    let kind = LatticeKind::from(args.lattice);
    let mut t = BlockTest::paper(kind, nu);
    if kind.is_random() {
        no_weights_flag(
            args,
            "random lattices weight their springs and nodes by volume; remove it",
        )?;
    } else {
        // Cell weights by default, as a case's body has them.
        t.cell_weights = !args.equal_weights;
    }
    if args.cylinder {
        if kind != LatticeKind::Random3d {
            return Err(InputError(format!(
                "--cylinder: the pillar test is for random3d lattices, not {}; give --lattice random3d",
                kind.name()
            ))
            .into());
        }
        t.cylinder = true;
        t.conform = !args.inner_surface;
    }
    if let Some(s) = &args.size {
        t.size = match (kind.dim(), s.as_slice()) {
            (3, &[x, y, z]) => [x, y, z],
            (2, &[x, r]) => [x, r, 1],
            (3, _) => {
                return Err(InputError(format!(
                    "--size {s:?}: the {} lattice takes three numbers, NX,NY,NZ (e.g. 71,16,16)",
                    kind.name()
                ))
                .into())
            }
            _ => {
                return Err(InputError(format!(
                    "--size {s:?}: the {} lattice takes two numbers, NX,ROWS (e.g. 71,16)",
                    kind.name()
                ))
                .into())
            }
        };
        if t.size.iter().take(kind.dim()).any(|&v| v < 2) {
            return Err(InputError(format!("--size {s:?}: give at least 2 nodes per axis")).into());
        }
    }
    t.ends = match args.ends {
        EndsName::Slide => Ends::Slide,
        EndsName::Clamp => Ends::Clamp,
    };
    t.random = random_spec(args)?;
    t.axis = args.axis as usize;
    if t.axis >= kind.dim() {
        return Err(InputError(format!("--axis z: the {} lattice is 2D", kind.name())).into());
    }
    t.strain = args.strain;
    t.spacing = args.spacing;
    t.stiffness = args.stiffness;
    t.anisotropic = anisotropic(args)?;
    if args.axes.is_some() {
        return Err(InputError(
            "--axes: the block test needs faces on node planes, and a lattice laid along turned axes has steps; use it with --bulk"
                .into(),
        )
        .into());
    }
    if args.rotate_lattice {
        return Err(InputError(
            "--rotate-lattice: the block test needs faces on node planes; use it with --bulk"
                .into(),
        )
        .into());
    }
    if t.anisotropic.is_some() && kind == LatticeKind::Hex {
        return Err(InputError(
            "--transverse, --orthotropic: the block test of an anisotropic material runs on the cubic, random2d and random3d lattices; the hex lattice's is not supported yet"
                .into(),
        )
        .into());
    }
    if let Some(p) = args.plane {
        t.plane = p.into();
    }
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
    /// Random lattices: E from the middle third's axial strain (mean over the samples).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub e_measured_middle: Option<Real>,
    pub q: Real,
    pub nodes: usize,
    pub springs: usize,
    pub iterations: usize,
    pub cg_iterations: usize,
    pub residual: Real,
    pub strain: Real,
    pub seconds: f64,
    /// Springs and nodes weighted by their cells (regular lattices unless `--equal-weights`).
    pub cell_weights: bool,
    /// `--cylinder`: the pillar test (`"conforming"` wall, or `"inner"` with `--inner-surface`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cylinder: Option<&'static str>,
    /// Random lattices: the sampler, load axis, first seed and number of samples.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampler: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Standard deviation of nu and of E over the samples (`nu_measured`, `E_measured` are the
    /// means).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nu_spread: Option<Real>,
    #[serde(rename = "E_spread", skip_serializing_if = "Option::is_none")]
    pub e_spread: Option<Real>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nu_samples: Option<Vec<Real>>,
    #[serde(rename = "E_samples", skip_serializing_if = "Option::is_none")]
    pub e_samples: Option<Vec<Real>>,
    /// The cubic lattice: the lateral strain ratios `-eps_yy/eps` and `-eps_zz/eps` of the
    /// middle section (`nu_measured` is their mean) and their targets.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lateral_target: Option<[Real; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lateral_measured: Option<[Real; 2]>,
    /// `--transverse` or `--orthotropic`: the material's engineering constants (key
    /// `transverse` or `orthotropic`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transverse: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orthotropic: Option<serde_json::Value>,
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
        e_measured_middle: r.e_measured_middle,
        q: r.q,
        nodes: r.nodes,
        springs: r.springs,
        iterations: r.solve.newton_iterations,
        cg_iterations: r.solve.cg_iterations,
        residual: r.solve.residual,
        strain: t.strain,
        seconds,
        cell_weights: t.cell_weights,
        cylinder: t
            .cylinder
            .then_some(if t.conform { "conforming" } else { "inner" }),
        sampler: None,
        axis: None,
        seed: None,
        samples: None,
        nu_spread: None,
        e_spread: None,
        nu_samples: None,
        e_samples: None,
        lateral_target: r.lateral_target,
        lateral_measured: r.lateral_measured,
        transverse: match &t.anisotropic {
            Some(m @ Anisotropic::Transverse(_)) => Some(anisotropic_json(m)),
            _ => None,
        },
        orthotropic: match &t.anisotropic {
            Some(m @ Anisotropic::Orthotropic(_)) => Some(anisotropic_json(m)),
            _ => None,
        },
    }
}

/// An anisotropic material as JSON (its engineering constants, and the unit fibre).
fn anisotropic_json(m: &Anisotropic) -> serde_json::Value {
    match m {
        Anisotropic::Transverse(m) => serde_json::json!({
            "E_p": m.youngs_plane, "E_t": m.youngs_fibre, "nu_p": m.poisson_plane,
            "nu_tp": m.poisson_fibre, "G_t": m.shear_fibre, "fibre": m.axis().unwrap_or(m.fibre),
        }),
        Anisotropic::Orthotropic(o) => serde_json::json!({
            "E_x": o.youngs[0], "E_y": o.youngs[1], "E_z": o.youngs[2],
            "nu_xy": o.poisson[0], "nu_xz": o.poisson[1], "nu_yz": o.poisson[2],
            "G_yz": o.shear[0], "G_xz": o.shear[1], "G_xy": o.shear[2],
        }),
    }
}

/// The block test at `nu` (over `samples` node sets on a random lattice).
pub fn measure(args: &ModuliOptions, nu: Real) -> Result<ModuliJson> {
    let t = test_for(args, nu)?;
    if !t.kind.is_random() {
        if args.samples != 1 {
            return Err(InputError(format!(
                "--samples {}: the {} lattice is not random (every sample is the same); \
                 --samples applies to random2d and random3d",
                args.samples,
                t.kind.name()
            ))
            .into());
        }
        let start = Instant::now();
        let r = block_test(&t).with_context(|| format!("block test at nu = {nu}"))?;
        return Ok(to_json(&t, &r, start.elapsed().as_secs_f64()));
    }
    ensemble(&t, args.samples)
}

/// The block test over `samples` random lattices (seeds `seed`, `seed + 1`, ...): means and
/// standard deviations.
pub fn ensemble(t: &BlockTest, samples: usize) -> Result<ModuliJson> {
    if samples == 0 {
        return Err(InputError("--samples 0: give at least one sample".into()).into());
    }
    let start = Instant::now();
    let mut runs = Vec::with_capacity(samples);
    for s in 0..samples {
        let mut ts = t.clone();
        ts.random.seed = t.random.seed.wrapping_add(s as u64);
        let r = block_test(&ts)
            .with_context(|| format!("block test at nu = {}, seed {}", t.nu, ts.random.seed))?;
        runs.push(r);
    }
    let nus: Vec<Real> = runs.iter().map(|r| r.nu_measured).collect();
    let es: Vec<Real> = runs.iter().map(|r| r.e_measured).collect();
    let (nu_mean, nu_sd) = mean_sd(&nus);
    let (e_mean, e_sd) = mean_sd(&es);
    let mut m = to_json(t, &runs[0], start.elapsed().as_secs_f64());
    m.nu_measured = nu_mean;
    m.nu_error = nu_mean - runs[0].nu_target;
    if let Some(first) = runs[0].lateral_measured {
        // An anisotropic block: each lateral ratio's mean over the samples.
        let mut lat = [0.0; 2];
        for (c, l) in lat.iter_mut().enumerate() {
            *l = runs
                .iter()
                .map(|r| r.lateral_measured.map_or(first[c], |v| v[c]))
                .sum::<Real>()
                / samples as Real;
        }
        m.lateral_measured = Some(lat);
    }
    m.e_measured = e_mean;
    m.e_measured_cell = e_mean;
    m.e_measured_middle = runs
        .iter()
        .map(|r| r.e_measured_middle)
        .sum::<Option<Real>>()
        .map(|e| e / samples as Real);
    m.e_relative_error = e_mean / m.e_target - 1.0;
    m.nodes = runs.iter().map(|r| r.nodes).sum::<usize>() / samples;
    m.springs = runs.iter().map(|r| r.springs).sum::<usize>() / samples;
    m.iterations = runs
        .iter()
        .map(|r| r.solve.newton_iterations)
        .max()
        .unwrap_or(0);
    m.cg_iterations = runs.iter().map(|r| r.solve.cg_iterations).sum();
    m.residual = runs.iter().map(|r| r.solve.residual).fold(0.0, Real::max);
    m.sampler = Some(t.random.sampler.name());
    m.axis = Some(["x", "y", "z"][t.axis]);
    m.seed = Some(t.random.seed);
    m.samples = Some(samples);
    m.nu_spread = Some(nu_sd);
    m.e_spread = Some(e_sd);
    m.nu_samples = Some(nus);
    m.e_samples = Some(es);
    Ok(m)
}

/// One row of the random lattices' calibration table: at the dispersion ratio `q`, the
/// measured nu and E over the affine E, with their spreads over the samples.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TableRow {
    pub q: Real,
    pub nu: Real,
    pub nu_affine: Real,
    pub nu_spread: Real,
    pub youngs_ratio: Real,
    pub youngs_ratio_spread: Real,
    pub seconds: f64,
}

/// The calibration table `hooke_core::random::calibration` holds, measured again.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RandomTable {
    /// The constant's name in `hooke_core::random::calibration` (`RANDOM3D`, `JITTER2D`, ...).
    pub name: &'static str,
    pub rows: Vec<TableRow>,
}

impl RandomTable {
    /// The table as the Rust source of its constant.
    pub fn rust_source(&self) -> String {
        let mut s = format!("pub const {}: &[(Real, Real, Real)] = &[\n", self.name);
        for r in &self.rows {
            s.push_str(&format!(
                "    ({:?}, {:.4}, {:.4}),\n",
                r.q, r.nu, r.youngs_ratio
            ));
        }
        s.push_str("];\n");
        s
    }
}

/// `--table`: nu and E/E_affine of random lattices against q, over `--samples` seeds; `progress`
/// sees each row as it is measured (a row takes minutes).
pub fn random_table(
    args: &ModuliOptions,
    progress: &mut dyn FnMut(&TableRow),
) -> Result<RandomTable> {
    args.check()?;
    let kind = LatticeKind::from(args.lattice);
    if !kind.is_random() {
        return Err(InputError("--table measures the random lattices' calibration: give --lattice random2d or random3d".into()).into());
    }
    // Dense near q = -1/2 in 3D, where nu falls steeply towards -1 and the correction moves.
    let near: &[Real] = if kind.dim() == 3 {
        &[-0.4975, -0.495, -0.4925]
    } else {
        &[]
    };
    let qs = near.iter().chain(&[
        -0.49, -0.45, -0.4, -0.3, -0.2, -0.1, 0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 40.0,
    ]);
    let jitter = matches!(args.sampler, SamplerName::Jitter);
    let name = match (kind.dim(), jitter) {
        (3, false) => "RANDOM3D",
        (_, false) => "RANDOM2D",
        (3, true) => "JITTER3D",
        (_, true) => "JITTER2D",
    };
    let mut rows = Vec::new();
    for &q in qs {
        let nu_aff = calibration::nu_affine(kind, q);
        let mut t = test_for(args, nu_aff.min(0.49))?;
        t.q = Some(q);
        let m = ensemble(&t, args.samples)?;
        let e_affine = m.e_target / calibration::youngs_factor_for(kind, t.random.sampler, q);
        let row = TableRow {
            q,
            nu: m.nu_measured,
            nu_affine: nu_aff,
            nu_spread: m.nu_spread.unwrap_or(0.0),
            youngs_ratio: m.e_measured / e_affine,
            youngs_ratio_spread: m.e_spread.unwrap_or(0.0) / e_affine,
            seconds: m.seconds,
        };
        progress(&row);
        rows.push(row);
    }
    Ok(RandomTable { name, rows })
}

/// Mean and sample standard deviation (0 for one value).
fn mean_sd(v: &[Real]) -> (Real, Real) {
    let n = v.len() as Real;
    let mean = v.iter().sum::<Real>() / n;
    if v.len() < 2 {
        return (mean, 0.0);
    }
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<Real>() / (n - 1.0);
    (mean, var.sqrt())
}

/// The block test's `--json` object as a value (one Poisson's ratio, `--nu`), or with --bulk
/// the bulk test's.
pub fn value(args: &ModuliOptions) -> Result<serde_json::Value> {
    args.check()?;
    if args.table {
        return Err(InputError("--table and --sweep print tables: give --nu NU".into()).into());
    }
    let nu = nu_of(args)?;
    if args.bulk {
        return bulk(args, nu);
    }
    Ok(serde_json::to_value(measure(args, nu)?)?)
}

/// `--nu`, required unless `--transverse` gives the material (then it is unused: NaN).
pub fn nu_of(args: &ModuliOptions) -> Result<Real> {
    let aniso = args.transverse.is_some() || args.orthotropic.is_some();
    match (args.nu, aniso) {
        (Some(_), true) => Err(InputError(
            "--nu and --transverse/--orthotropic both give the material: keep one".into(),
        )
        .into()),
        (Some(nu), false) => Ok(nu),
        (None, true) => Ok(Real::NAN),
        (None, false) => Err(InputError(
            "give --nu NU (the Poisson's ratio to build), --transverse E_p,E_t,nu_p,nu_tp,G_t, --orthotropic E_x,...,G_xy, or --sweep"
                .into(),
        )
        .into()),
    }
}

/// `--bulk`: the exact stiffness tensor of the infinite lattice against the isotropic target.
pub fn bulk(args: &ModuliOptions, nu: Real) -> Result<serde_json::Value> {
    use hooke_core::material::{q_from_nu, youngs_from_k};
    no_weights_flag(
        args,
        "the bulk test has no faces, every spring is a bulk spring; remove one of the two",
    )?;
    use hooke_core::moduli::{bulk_stiffness, isotropic_stiffness};
    let kind = LatticeKind::from(args.lattice);
    for (what, v) in [("--spacing", args.spacing), ("--stiffness", args.stiffness)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(InputError(format!("{what} {v}: give a positive number")).into());
        }
    }
    if args.extrapolate && !kind.is_random() {
        return Err(InputError(format!(
            "--extrapolate: the {} lattice's bulk test is exact, there is nothing to extrapolate (random lattices only)",
            kind.name()
        ))
        .into());
    }
    if let Some(m) = anisotropic(args)? {
        if kind.is_random() {
            return random_anisotropic_bulk(args, &m, kind.dim());
        }
        if kind != LatticeKind::Cubic {
            return Err(InputError(format!(
                "--transverse, --orthotropic: anisotropic materials are built on the cubic, random2d and random3d lattices; the {} lattice is not supported yet",
                kind.name()
            ))
            .into());
        }
        let a = args.spacing;
        let f = m.families(a).map_err(|e| {
            let flag = match m {
                Anisotropic::Transverse(_) => "--transverse",
                Anisotropic::Orthotropic(_) => "--orthotropic",
            };
            InputError(format!("{flag}: {e}"))
        })?;
        let turn =
            match (args.rotate_lattice, &m) {
                (false, _) => None,
                (true, Anisotropic::Transverse(t)) => {
                    Some(hooke_core::anisotropy::lattice_rotation(t.fibre)?)
                }
                (true, Anisotropic::Orthotropic(_)) => return Err(InputError(
                    "--rotate-lattice lays the lattice along a fibre: it goes with --transverse (--axes lays it along an orthotropic material's axes)"
                        .into(),
                )
                .into()),
            };
        let turn = match &m {
            Anisotropic::Orthotropic(o) if !o.along_body_axes() => Some(o.lattice_rotation()),
            _ => turn,
        };
        // The test's box is 7 nodes across: turned about its centre node.
        let centre = hooke_core::Vector::repeat(3.0 * a);
        let measured = hooke_core::moduli::bulk_stiffness_of(kind, a, &|l| match &turn {
            Some(r) => m.body(l.rotated(r, centre)?),
            None => m.body(l),
        })
        .map_err(|e| InputError(format!("--transverse: {e}")))?;
        let target = m.stiffness()?;
        let name = match m {
            Anisotropic::Transverse(_) => "transverse",
            Anisotropic::Orthotropic(_) => "orthotropic",
        };
        let mut v = serde_json::json!({
            "test": "bulk", "lattice": kind.name(), "q": f.q, "spacing": a,
            "axis_stiffness": f.axis_k, "diagonal_stiffness": f.diagonal_k,
            "axis_weights": f.axis_w, "diagonal_weights": f.diagonal_w,
            "units": "Pa",
            "voigt": ["xx", "yy", "zz", "yz", "xz", "xy"],
            "C_target": target, "C_measured": measured,
            "max_relative_difference": max_relative_difference(&measured, &target),
        });
        v[name] = anisotropic_json(&m);
        v["rotate_lattice"] = serde_json::json!(args.rotate_lattice);
        return Ok(v);
    }
    if kind.is_random() {
        return random_bulk(args, nu);
    }
    let q = q_from_nu(kind, nu).map_err(|e| InputError(format!("--nu {nu}: {e}")))?;
    let (k, a) = (args.stiffness, args.spacing);
    let youngs = youngs_from_k(kind, k, a, q);
    let measured = bulk_stiffness(kind, k, a, q);
    let target = isotropic_stiffness(kind.dim(), youngs, nu);
    let worst = max_relative_difference(&measured, &target);
    Ok(serde_json::json!({
        "test": "bulk", "lattice": kind.name(), "nu": nu, "q": q, "stiffness": k, "spacing": a,
        "youngs": youngs,
        "units": if kind.dim() == 2 { "N/m per unit thickness" } else { "Pa" },
        "voigt": ["xx", "yy", "zz", "yz", "xz", "xy"],
        "C_target": target, "C_measured": measured,
        "max_relative_difference": worst,
    }))
}

/// `--bulk` on a random lattice: the relaxed test ([`hooke_core::moduli::RelaxedBulk`]) over
/// `--samples` node sets, the mean tensor and its spread per entry. [`bulk`] has checked the
/// options common to both bulk tests.
fn random_bulk(args: &ModuliOptions, nu: Real) -> Result<serde_json::Value> {
    let kind = LatticeKind::from(args.lattice);
    if args.cylinder {
        return Err(InputError(
            "--cylinder: the pillar is a block test; the bulk test is a cube (drop one of the two)"
                .into(),
        )
        .into());
    }
    if args.samples == 0 {
        return Err(InputError("--samples 0: give at least one sample".into()).into());
    }
    // The cube: N nodes' worth of spacings per side, (N - 1) a, as the block test's boxes.
    let default = if kind.dim() == 3 { 33 } else { 65 };
    let nodes_per_side = cube_nodes(
        args,
        kind.dim(),
        default,
        5,
        "a cube of 4 to 200 spacings; 33 or more keeps the faces' excess under 1 % in 3D",
    )?;
    let start = Instant::now();
    let test = RelaxedBulk {
        kind,
        nu,
        size: nodes_per_side as Real - 1.0,
        spacing: args.spacing,
        stiffness: args.stiffness,
        random: random_spec(args)?,
        solver: Default::default(),
    };
    let first_seed = test.random.seed;
    let runs = relaxed_ensemble(&test, args.samples)?;
    let mean = |f: &dyn Fn(&RelaxedBulkResult) -> [[Real; 6]; 6]| mean_spread(&runs, f);
    let (measured, spread) = mean(&|r| r.c_measured);
    let (affine, _) = mean(&|r| r.c_affine);
    let (interior, _) = mean(&|r| r.c_interior);
    let r0 = &runs[0];
    let target = r0.c_target;
    let relative = entry_relative_difference(&measured, &target);
    // --extrapolate: the held faces' excess goes like a / L, C(L) = C_inf + B / L; a cube of
    // half the side over the same seeds gives C_inf = (L C(L) - L' C(L')) / (L - L').
    let extrapolated = if args.extrapolate {
        let mut half = test.clone();
        half.size = (0.5 * test.size).round();
        if half.size < 8.0 {
            return Err(InputError(format!(
                "--extrapolate runs a cube of half the side too: give --size 17 or more (now {})",
                test.size + 1.0
            ))
            .into());
        }
        let (c_half, _) = mean_spread(&relaxed_ensemble(&half, args.samples)?, &|r| r.c_measured);
        let (l, lh) = (test.size, half.size);
        let mut c = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                c[i][j] = (l * measured[i][j] - lh * c_half[i][j]) / (l - lh);
            }
        }
        let rel = entry_relative_difference(&c, &target);
        Some(serde_json::json!({
            "half_cube_spacings": lh, "C_half": c_half, "C_extrapolated": c,
            "C_relative_difference": rel, "max_entry_relative_difference": max_abs(&rel),
        }))
    } else {
        None
    };
    let (youngs, poisson) = engineering(kind.dim(), &measured);
    let cg: Vec<usize> = runs
        .iter()
        .flat_map(|r| r.solves.iter().map(|s| s.cg_iterations))
        .collect();
    let residual = runs
        .iter()
        .flat_map(|r| r.solves.iter().map(|s| s.residual))
        .fold(0.0, Real::max);
    Ok(serde_json::json!({
        "test": "bulk", "relaxed": true, "lattice": kind.name(), "nu": nu, "q": r0.q,
        "stiffness": args.stiffness, "spacing": args.spacing,
        "sampler": test.random.sampler.name(), "seed": first_seed, "samples": args.samples,
        "cube_spacings": test.size, "nodes": r0.nodes, "springs": r0.springs,
        "boundary_nodes": r0.boundary_nodes,
        "youngs": r0.youngs,
        "units": if kind.dim() == 2 { "N/m per unit thickness" } else { "Pa" },
        "voigt": ["xx", "yy", "zz", "yz", "xz", "xy"],
        "C_target": target, "C_measured": measured, "C_spread": spread, "C_affine": affine,
        "C_interior": interior,
        "interior_relative_difference": entry_relative_difference(&interior, &target),
        "C_relative_difference": relative,
        "max_relative_difference": max_relative_difference(&measured, &target),
        "max_entry_relative_difference": max_abs(&relative),
        "extrapolated": extrapolated,
        "youngs_measured": youngs, "nu_measured": poisson,
        "cg_iterations": cg.iter().sum::<usize>(), "residual": residual,
        "seconds": start.elapsed().as_secs_f64(),
    }))
}

/// A 6x6 stiffness in Voigt order (Pa).
type Stiffness = [[Real; 6]; 6];

/// An anisotropic material's target stiffness (in the body's frame; a plate's in 2D) and the
/// material's axes.
fn target_and_frame(
    m: &Anisotropic,
    dim: usize,
    plane: hooke_core::material::PlaneModel,
) -> Result<(Stiffness, [[Real; 3]; 3])> {
    Ok(if dim == 2 {
        (m.plane_stiffness(plane)?, m.plane_axes()?.0)
    } else {
        let frame = match m {
            Anisotropic::Transverse(t) => t.frame()?,
            Anisotropic::Orthotropic(o) => o.axes,
        };
        (m.stiffness()?, frame)
    })
}

/// The calibration behind a random design, as `--json` reports it.
fn calibration_json(
    cal: &hooke_core::random::anisotropic::Calibrated,
    dim: usize,
) -> serde_json::Value {
    let opts = if dim == 2 {
        hooke_core::random::anisotropic::CalibrationOptions::plane()
    } else {
        Default::default()
    };
    serde_json::json!({
        "residuals": cal.residuals, "held_out": cal.held_out, "seconds": cal.seconds,
        "cube_spacings": opts.size, "samples": opts.samples,
        "seeds": [opts.seed, opts.seed + opts.samples as u64 - 1],
        "cache_file": cal.cache.file().map(|p| p.display().to_string()),
        "from_cache": matches!(cal.cache, Cached::Read(_)),
        "cache_note": cal.cache.note(),
    })
}

/// `--bulk --lattice random3d` (or `random2d`) with an anisotropic material: calibrate the
/// direction functions on cubes (squares) of their own seeds
/// ([`hooke_core::random::anisotropic::calibrate`], seeds 1001 on), then measure the design on
/// `--samples` unseen node sets (seeds `--seed` on) in cubes (squares) of `--size` nodes per
/// side, turned into the body's frame: the inner cubes' tensor, its mean and spread per entry
/// against the target (a plate's: its in-plane stiffness in plane stress or strain, `--plane`).
fn random_anisotropic_bulk(
    args: &ModuliOptions,
    m: &Anisotropic,
    dim: usize,
) -> Result<serde_json::Value> {
    use hooke_core::random::anisotropic::{boxes, mean, measure, orthotropic_entries};
    if args.rotate_lattice || args.extrapolate || args.cylinder {
        return Err(InputError(
            "--rotate-lattice, --extrapolate, --cylinder: not for a random lattice's anisotropic bulk test (a random lattice has no axes to turn; its inner-cube tensor has no face excess to extrapolate)"
                .into(),
        )
        .into());
    }
    if args.samples == 0 {
        return Err(InputError("--samples 0: give at least one sample".into()).into());
    }
    let (default_side, min_side) = if dim == 2 { (65, 19) } else { (33, 13) };
    let nodes_per_side = cube_nodes(
        args,
        dim,
        default_side,
        min_side,
        "the inner cube, two thirds of the side, must hold a network",
    )?;
    let flag = match m {
        Anisotropic::Transverse(_) => "--transverse",
        Anisotropic::Orthotropic(_) => "--orthotropic",
    };
    let plane: hooke_core::material::PlaneModel = args.plane.map_or(Default::default(), Into::into);
    let start = Instant::now();
    let spec = random_spec(args)?;
    let cal = m
        .random_design_for(dim, spec.sampler, plane)
        .map_err(|e| InputError(format!("{flag}: {e}")))?;
    let side = nodes_per_side as Real - 1.0;
    let lattices = boxes(dim, side, args.samples, spec.seed, spec.sampler)?;
    let runs = measure(&cal.design, &lattices, side, &Default::default())?;
    let measured = mean(&runs);
    let spread = hooke_core::random::anisotropic::spread(&runs, &measured);
    // In the material axes every orthotropic entry is sizeable, so each can be held to a
    // relative tolerance (turned into the body's frame, small entries carry the noise).
    let (target, frame) = target_and_frame(m, dim, plane)?;
    let relative = entry_relative_difference(&measured, &target);
    let d = &cal.design;
    let local = hooke_core::random::anisotropic::to_material(&measured, &frame);
    let local_target = hooke_core::random::anisotropic::to_material(&target, &frame);
    let material_relative: Vec<Real> = orthotropic_entries(dim)
        .iter()
        .map(|&(i, j)| local[i][j] / local_target[i][j] - 1.0)
        .collect();
    let name = match m {
        Anisotropic::Transverse(_) => "transverse",
        Anisotropic::Orthotropic(_) => "orthotropic",
    };
    let material_entries: Vec<String> = orthotropic_entries(dim)
        .iter()
        .map(|&(i, j)| format!("{}{}", i + 1, j + 1))
        .collect();
    let mut v = serde_json::json!({
        "test": "bulk", "relaxed": true, "lattice": if dim == 2 { "random2d" } else { "random3d" }, "q": d.q,
        "sampler": spec.sampler.name(), "seed": spec.seed, "samples": args.samples,
        "cube_spacings": side,
        "design": {
            "kappa": d.kappa, "kappa_terms": ["xx", "yy", "zz", "yz", "xz", "xy"],
            "alpha": d.alpha, "q": d.q, "axes": d.axes, "sharpness": d.sharpness,
        },
        "calibration": calibration_json(&cal, dim),
        "units": if dim == 2 { "Pa (times the thickness: N/m)" } else { "Pa" },
        "voigt": ["xx", "yy", "zz", "yz", "xz", "xy"],
        "C_target": target, "C_measured": measured, "C_spread": spread,
        "C_relative_difference": relative,
        "max_relative_difference": max_relative_difference(&measured, &target),
        "max_entry_relative_difference": max_abs(&relative),
        "C_measured_material": local, "C_target_material": local_target,
        "material_entries": material_entries,
        "material_relative_difference": material_relative,
        "max_material_relative_difference": material_relative.iter().fold(0.0 as Real, |a, b| a.max(b.abs())),
        "seconds": start.elapsed().as_secs_f64(),
    });
    v[name] = anisotropic_json(m);
    if dim == 2 {
        v["plane"] = serde_json::json!(plane.name());
    }
    Ok(v)
}

/// `--size` of a relaxed bulk test: one number N (nodes per side; the side is (N - 1)
/// spacings), or `dim` equal numbers; `default` without it; `min` to 201 accepted, `why` says
/// what the range keeps.
fn cube_nodes(
    args: &ModuliOptions,
    dim: usize,
    default: usize,
    min: usize,
    why: &str,
) -> Result<usize> {
    let n = match args.size.as_deref() {
        None => default,
        Some([n]) => *n,
        Some(s) if s.len() == dim && s.iter().all(|v| *v == s[0]) => s[0],
        Some(s) => {
            return Err(InputError(format!(
                "--size {s:?}: the relaxed bulk test is a cube; give one number N (nodes per side, the side is (N - 1) spacings; default {default})"
            ))
            .into())
        }
    };
    if !(min..=201).contains(&n) {
        return Err(InputError(format!(
            "--size {n}: give {min} to 201 nodes per side ({why})"
        ))
        .into());
    }
    Ok(n)
}

/// The relaxed bulk test over `samples` node sets, seeds from `test.random.seed` on.
fn relaxed_ensemble(test: &RelaxedBulk, samples: usize) -> Result<Vec<RelaxedBulkResult>> {
    let mut test = test.clone();
    let first_seed = test.random.seed;
    let mut runs = Vec::with_capacity(samples);
    for s in 0..samples {
        test.random.seed = first_seed.wrapping_add(s as u64);
        let r = relaxed_bulk_stiffness(&test).map_err(|e| match e {
            hooke_core::Error::OutOfRange { .. } => {
                anyhow::Error::from(InputError(format!("--nu {}: {e}", test.nu)))
            }
            e => anyhow::Error::from(e).context(format!(
                "relaxed bulk test, {} spacings, seed {}",
                test.size, test.random.seed
            )),
        })?;
        runs.push(r);
    }
    Ok(runs)
}

/// Mean and spread (sample standard deviation) of a tensor over the runs, entry by entry.
fn mean_spread(
    runs: &[RelaxedBulkResult],
    f: &dyn Fn(&RelaxedBulkResult) -> [[Real; 6]; 6],
) -> ([[Real; 6]; 6], [[Real; 6]; 6]) {
    let mut mean = [[0.0; 6]; 6];
    let mut spread = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            let v: Vec<Real> = runs.iter().map(|r| f(r)[i][j]).collect();
            (mean[i][j], spread[i][j]) = mean_sd(&v);
        }
    }
    (mean, spread)
}

/// Entry by entry: the difference over the target's entry where it has one, else over the
/// target's largest entry.
fn entry_relative_difference(c: &[[Real; 6]; 6], target: &[[Real; 6]; 6]) -> [[Real; 6]; 6] {
    let scale = max_abs(target);
    let mut relative = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            let (t, d) = (target[i][j], c[i][j] - target[i][j]);
            relative[i][j] = if t.abs() > 1e-12 * scale {
                d / t
            } else {
                d / scale
            };
        }
    }
    relative
}

fn max_abs(m: &[[Real; 6]; 6]) -> Real {
    m.iter().flatten().fold(0.0 as Real, |a, x| a.max(x.abs()))
}

/// Isotropic E and nu from the mean of the stiffness' cubic-invariant parts: C11 the mean of
/// the normal diagonal, C12 of the normal off-diagonal (3D), the plane entries in 2D.
fn engineering(dim: usize, c: &[[Real; 6]; 6]) -> (Real, Real) {
    if dim == 3 {
        let c11 = (c[0][0] + c[1][1] + c[2][2]) / 3.0;
        let c12 = (c[0][1] + c[0][2] + c[1][2] + c[1][0] + c[2][0] + c[2][1]) / 6.0;
        (
            (c11 - c12) * (c11 + 2.0 * c12) / (c11 + c12),
            c12 / (c11 + c12),
        )
    } else {
        let c11 = 0.5 * (c[0][0] + c[1][1]);
        let c12 = 0.5 * (c[0][1] + c[1][0]);
        ((c11 * c11 - c12 * c12) / c11, c12 / c11)
    }
}

/// Largest entry difference over the largest target entry.
fn max_relative_difference(measured: &[[Real; 6]; 6], target: &[[Real; 6]; 6]) -> Real {
    let scale = max_abs(target);
    measured
        .iter()
        .flatten()
        .zip(target.iter().flatten())
        .fold(0.0 as Real, |m, (x, y)| m.max((x - y).abs()))
        / scale
}
