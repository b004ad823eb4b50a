//! `hooke run` and `hooke check`: case files end to end. The run itself is the library's
//! (`hooke_sim`); this module parses, prints and chooses the exit code.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Args;
use hooke_case::Simulation;
use hooke_core::Real;
use hooke_sim::{Observer, Progress, RunOptions};

use crate::InputError;

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The case file (TOML).
    pub case: PathBuf,
    /// Output directory (default: next to the case, CASE_STEM.out). An existing run there is
    /// never overwritten silently.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Resolution factor: the lattice spacing is divided by it (0.25: a quick, coarse look).
    #[arg(long, default_value_t = 1.0)]
    pub scale: Real,
    /// Continue from a checkpoint written by an earlier run of the same case and scale.
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Override a scalar key of the case, validated like the file: --set material.poisson=0.3
    /// (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print one JSON object summarising the run instead of the text summary.
    #[arg(long)]
    pub json: bool,
    /// When stderr is not a terminal (a batch job), print a progress line every this many
    /// seconds (0: never).
    #[arg(long, default_value_t = 30.0, value_name = "SECONDS")]
    pub progress_every: f64,
    /// Under `mpirun -np N` (N > 1): after set-up each process keeps only its piece of the
    /// body (its own nodes and their neighbours) and drops the rest, so that memory per
    /// process falls with N; the same results, bit for bit. Random lattices; each process
    /// writes its own checkpoint (NAME.RofN.ckpt) and a resume needs the same N (docs/mpi.md).
    #[arg(long)]
    pub pieces: bool,
    /// Under `mpirun -np N` (N > 1): each process builds only its part of the body, never the
    /// whole, and keeps its piece (as --pieces, which it implies), so that the set-up's memory
    /// falls with N too; the same results, bit for bit. Random lattices on a jittered grid
    /// (lattice.sampler = "jitter"), isotropic or anisotropic, with or without contact;
    /// anything else (curved surfaces, HDF5 output) is refused with the reason (docs/mpi.md).
    #[arg(long)]
    pub parts: bool,
}

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The case file (TOML).
    pub case: PathBuf,
    /// Resolution factor, as for `hooke run`.
    #[arg(long, default_value_t = 1.0)]
    pub scale: Real,
    /// Override a scalar key of the case, as for `hooke run`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print one JSON object instead of the text report.
    #[arg(long)]
    pub json: bool,
}

/// A run stopped by Ctrl-C (exit code 130, the shell's convention for SIGINT).
#[derive(Debug)]
pub struct Interrupted(pub String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Interrupted {}

/// The case built with its overrides, and the run options that carry its physics digest.
fn load(case: &Path, scale: Real, set: &[String]) -> Result<(Simulation, RunOptions)> {
    load_parts(case, scale, set, None)
}

/// [`load`], set up from parts shared by `parts` if given (`hooke run --parts`).
fn load_parts(
    case: &Path,
    scale: Real,
    set: &[String],
    parts: Option<Arc<dyn hooke_core::team::Team>>,
) -> Result<(Simulation, RunOptions)> {
    let text = std::fs::read_to_string(case).map_err(|e| {
        InputError(format!(
            "{}: cannot read the case file: {e}",
            case.display()
        ))
    })?;
    let overrides = hooke_case::parse_overrides(set).map_err(|e| InputError(e.to_string()))?;
    hooke_case::prepare_parts(case, &text, scale, &overrides, parts)
        .map_err(|e| InputError(e.to_string()).into())
}

fn stem(case: &Path) -> String {
    case.file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned())
}

pub fn check(args: CheckArgs) -> Result<()> {
    let (mut sim, _) = load(&args.case, args.scale, &args.set)?;
    let scratch = std::env::temp_dir().join(format!("hooke-check-{}", std::process::id()));
    let report = sim.check(&scratch).map_err(|e| match e {
        hooke_sim::Error::Core(e) => {
            anyhow::Error::from(InputError(format!("{}: {e}", args.case.display())))
        }
        e => e.into(),
    })?;
    if args.json {
        let mut v = serde_json::to_value(&report)?;
        v["case"] = serde_json::json!(args.case.display().to_string());
        println!("{}", serde_json::to_string(&v)?);
        return Ok(());
    }
    print_check(&args.case, &sim, &report)
}

/// `hooke check`'s text: the report, with the material and the rigid bodies described from the
/// simulation.
fn print_check(case: &Path, sim: &Simulation, r: &hooke_sim::CheckReport) -> Result<()> {
    println!("{}: valid", case.display());
    println!(
        "  lattice      {} ({} kernel), spacing {:e} m",
        r.lattice, r.kernel, r.spacing
    );
    println!("  nodes        {}", r.nodes);
    println!(
        "  springs      {} ({} removed by pre-cracks)",
        r.springs, r.springs_precracked
    );
    if !sim.body.lattice.kind.is_random() {
        println!(
            "  cell weights {}",
            if r.cell_weights {
                "on: face and edge springs and nodes stand for their share of the bulk's cells (lattice.cell_weights)"
            } else {
                "off: every spring and node as in the bulk (lattice.cell_weights = false, or a body too thin, turned or periodic)"
            }
        );
    }
    print_constants(sim)?;
    for p in &r.phases {
        println!(
            "  phase {:<6} {}: E {:e} Pa, nu {}, density {} kg/m^3, q {:.4}; {} nodes, {} springs{}",
            p.material.index,
            p.material.name,
            p.material.youngs,
            p.material.poisson,
            p.material.density,
            p.material.q,
            p.nodes,
            p.springs,
            p.critical_stretch.map_or(String::new(), |[lo, mean, hi]| if lo == hi {
                format!(", critical stretch {lo:e}")
            } else {
                format!(", critical stretch {lo:.3e} to {hi:.3e} (mean {mean:.3e})")
            })
        );
    }
    if let Some(n) = r.interface_springs {
        println!("  interfaces   {n} springs join two materials (each its two halves in series)");
    }
    println!("  fracture     {}", r.criterion.as_deref().unwrap_or("off"));
    if let Some([lo, mean, hi]) = r.strength_factors {
        println!(
            "  strength     each spring's critical stretch is the criterion's times its own factor: {lo:.3} to {hi:.3}, mean {mean:.4} (materials, interfaces, Weibull scatter)"
        );
    }
    print_contact(sim);
    for n in r
        .notes
        .iter()
        .filter(|n| n.about != "softening" && n.about != "energy-criterion")
    {
        println!("  note         {}", n.text);
    }
    if let Some(s) = &r.softening {
        println!(
            "  softening    {}: peak stretch {:e}, final stretch {:e} ({:.1} x the peak), \
             equivalent stretch {:e} (peak fraction {:.3}), measured toughness factor F = {:.3}, \
             strength factor S = {}",
            s.shape,
            s.peak,
            s.last,
            s.last / s.peak,
            s.equivalent_stretch,
            s.peak_fraction,
            s.toughness_factor,
            match s.strength_factor {
                Some(v) =>
                    format!("{v:.3} (a body's tensile strength is S E times the peak stretch)"),
                None => "not measured on this lattice (the springs peak at f_t / E)".into(),
            }
        );
    }
    for n in r
        .notes
        .iter()
        .filter(|n| n.about == "softening" || n.about == "energy-criterion")
    {
        println!("  note         {}", n.text);
    }
    println!(
        "  dt           {:e} s (critical {:e} s), {} steps to {:e} s",
        r.dt, r.dt_critical, r.steps, r.end_time
    );
    println!(
        "  memory       about {:.1} MiB for the body, state and integrator; peak {} while \
         checking (set-up, a few steps, one output frame and a checkpoint; a run's own peak, \
         printed at its end, lies within about a third of it)",
        r.state_bytes as f64 / (1 << 20) as f64,
        r.peak_memory_bytes
            .map_or("unknown".to_string(), |b| format!(
                "{:.0} MiB",
                b as f64 / (1 << 20) as f64
            ))
    );
    println!(
        "  time         {:.3} ms per step, about {:.1} s in all",
        r.seconds_per_step * 1e3,
        r.estimated_seconds
    );
    Ok(())
}

/// The material's constants: the anisotropic design or spring families with the stiffness
/// tensor, or k (kappa) and q.
fn print_constants(sim: &Simulation) -> Result<()> {
    if let (Some(m), Some(cal)) = (&sim.anisotropic, &sim.random_design) {
        print_material(m)?;
        let d = &cal.design;
        println!(
            "  springs      k_s = kappa(n) V_s / L_s^2, kappa(n) = sum_a kappa_aa n_a^2P + sum_a<b kappa_ab n_a^2 n_b^2, P = {}, over xx yy zz yz xz xy (material axes) = {:.6e} {:.6e} {:.6e} {:.6e} {:.6e} {:.6e} Pa",
            d.sharpness, d.kappa[0], d.kappa[1], d.kappa[2], d.kappa[3], d.kappa[4], d.kappa[5]
        );
        println!(
            "  weights, q   w(n) = sum alpha_a n_a^2, alpha = {:.6} {:.6} {:.6}; q = {:.6}",
            d.alpha[0], d.alpha[1], d.alpha[2], d.q
        );
        let plate = sim.body.lattice.dim() == 2;
        let (boxes, stiffness) = if plate {
            let o = hooke_core::random::anisotropic::CalibrationOptions::plane();
            (
                format!("{} squares of {} spacings", o.samples, o.size),
                m.plane_stiffness(sim.plane)?,
            )
        } else {
            let o = hooke_core::random::anisotropic::CalibrationOptions::default();
            (
                format!("{} cubes of {} spacings", o.samples, o.size),
                m.stiffness()?,
            )
        };
        println!(
            "  calibration  largest entry off the target over the largest normal entry: {}, on as many other node sets {:.2e} ({:.1} s; {boxes}){}",
            cal.residuals
                .iter()
                .map(|r| format!("{r:.2e}"))
                .collect::<Vec<_>>()
                .join(" -> "),
            cal.held_out,
            cal.seconds,
            cal.cache.note()
        );
        if plate {
            println!(
                "  stiffness    C of the plate in plane {} (Pa; times the thickness, N/m), Voigt xx yy zz yz xz xy, global axes:",
                sim.plane.name()
            );
        } else {
            println!("  stiffness    C (Pa, Voigt xx yy zz yz xz xy, global axes):");
        }
        print_tensor(&stiffness);
    } else if !sim.materials.is_empty() {
        println!(
            "  materials    {} (each node its material's q; springs between two take both in series)",
            sim.materials.len()
        );
    } else if sim.body.lattice.kind.is_random() {
        let unit = if sim.body.lattice.dim() == 3 {
            "Pa"
        } else {
            "N/m"
        };
        println!(
            "  kappa, q     {:e} {unit} (k_s = kappa V_s / L_s^2), {:.6}",
            sim.k, sim.q
        );
    } else if let Some(m) = &sim.anisotropic {
        let f = m.families(sim.body.lattice.spacing)?;
        print_material(m)?;
        println!(
            "  springs k    axes x y z {:.6e} {:.6e} {:.6e}, face diagonals yz xz xy {:.6e} {:.6e} {:.6e} N/m{}",
            f.axis_k[0], f.axis_k[1], f.axis_k[2], f.diagonal_k[0], f.diagonal_k[1], f.diagonal_k[2],
            match m {
                hooke_core::Anisotropic::Transverse(_) => " (in the fibre's frame: z along the fibre)",
                hooke_core::Anisotropic::Orthotropic(_) => "",
            }
        );
        println!(
            "  weights, q   w = {:.6} {:.6} {:.6}, {:.6} {:.6} {:.6} (same order), q = {:.6}",
            f.axis_w[0],
            f.axis_w[1],
            f.axis_w[2],
            f.diagonal_w[0],
            f.diagonal_w[1],
            f.diagonal_w[2],
            f.q
        );
        println!(
            "  stiffness    C (Pa, Voigt xx yy zz yz xz xy, global axes){}:",
            match (&m, sim.body.lattice.grid.is_none()) {
                (hooke_core::Anisotropic::Orthotropic(o), true) if !o.along_body_axes() =>
                    "; the lattice is laid along the material axes (material.axes)",
                (_, true) => "; the lattice is laid along the fibre (lattice.rotate_to)",
                _ => "",
            }
        );
        print_tensor(&m.stiffness()?);
    } else {
        println!("  k, q         {:e} N/m, {:.6}", sim.k, sim.q);
    }
    Ok(())
}

fn print_tensor(c: &[[Real; 6]; 6]) {
    for row in c {
        let cells: Vec<String> = row.iter().map(|x| format!("{x:>12.4e}")).collect();
        println!("               {}", cells.join(" "));
    }
}

/// The contact options and the rigid bodies.
fn print_contact(sim: &Simulation) {
    let Some(c) = &sim.contact else {
        return;
    };
    println!(
        "  contact      penalty k = {} m/dt^2 per node, node radius {:e} m, fragments {}",
        c.opts.stiffness_factor,
        c.opts.radius,
        c.opts
            .fragment_distance
            .map_or("off".to_string(), |d| format!("below {d:e} m"))
    );
    for b in &c.bodies {
        let motion = match &b.motion {
            hooke_contact::Motion::Dynamic { mass } => format!("dynamic, {mass:.4e} kg"),
            hooke_contact::Motion::Kinematic(_) => "kinematic".to_string(),
        };
        println!(
            "  rigid        {}: {:?}, {motion}, at {:?} m, velocity {:?} m/s, friction {}",
            b.name, b.geometry, b.position, b.velocity, b.friction
        );
    }
}

pub fn run(args: RunArgs) -> Result<()> {
    // Under `mpirun -np N` (feature `mpi`), N processes run this same function; each builds the
    // same simulation, rank 0 alone writes and prints (`docs/mpi.md`).
    #[cfg(feature = "mpi")]
    return crate::mpi::run(|team| run_in(args, team));
    #[cfg(not(feature = "mpi"))]
    run_in(args, None)
}

fn run_in(args: RunArgs, team: Option<Arc<dyn hooke_core::team::Team>>) -> Result<()> {
    let processes = team.as_ref().map_or(1, |t| t.size());
    if team.as_ref().is_some_and(|t| t.rank() != 0) {
        crate::set_quiet();
    }
    if args.pieces && team.is_none() {
        return Err(InputError(
            "--pieces cuts the body between MPI ranks: run under `mpirun -np N` with N > 1, with a hooke built with --features mpi (tools/install-mpi.sh)".into(),
        )
        .into());
    }
    if args.parts && team.is_none() {
        return Err(InputError(
            "--parts builds the body in parts, one per MPI rank: run under `mpirun -np N` with N > 1, with a hooke built with --features mpi (tools/install-mpi.sh)".into(),
        )
        .into());
    }
    let fault = Fault::from_env(team.as_ref().map_or(0, |t| t.rank()))?;
    if let Some(f) = &fault {
        if f.kind == FaultKind::Error {
            return Err(anyhow::anyhow!(
                "HOOKE_TEST_FAIL: an error injected on this rank alone"
            ));
        }
    }
    let parts = team.clone().filter(|_| args.parts);
    let (sim, base) = load_parts(&args.case, args.scale, &args.set, parts)?;
    let name = stem(&args.case);
    let out = args.out.clone().unwrap_or_else(|| {
        let dir = args.case.parent().unwrap_or(Path::new("."));
        if args.scale == 1.0 {
            dir.join(format!("{name}.out"))
        } else {
            dir.join(format!("{name}.scale{}.out", args.scale))
        }
    });
    if !(args.progress_every.is_finite() && args.progress_every >= 0.0) {
        return Err(InputError(format!(
            "--progress-every {}: give seconds, 0 or more",
            args.progress_every
        ))
        .into());
    }
    let opts = RunOptions {
        out: out.clone(),
        name,
        resume: args.resume.clone(),
        command: std::env::args().collect(),
        team,
        pieces: args.pieces || args.parts,
        ..base
    };
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second handler cannot be installed in one process; tests call run() once per process.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let quasi = sim.solver.quasi_static_steps();
    let every = if crate::quiet() {
        0.0
    } else {
        args.progress_every
    };
    let mut obs = CliObserver::new(stop, every, quasi);
    obs.fault = fault;
    let summary = match hooke_sim::run(sim, opts, &mut obs) {
        Ok(s) => s,
        Err(e) => {
            obs.bar.abandon();
            return Err(run_error(&args, &out, e));
        }
    };
    obs.bar.finish_and_clear();
    if crate::quiet() {
        return Ok(());
    }
    let peak = crate::bench::peak_memory();
    if args.json {
        let mut v = serde_json::to_value(&summary)?;
        v["processes"] = serde_json::json!(processes);
        v["case"] = serde_json::json!(args.case.display().to_string());
        v["output_dir"] = serde_json::json!(out.display().to_string());
        v["peak_memory_bytes"] = serde_json::json!(peak);
        println!("{}", serde_json::to_string(&v)?);
        return Ok(());
    }
    print_summary(&args.case, &summary);
    if processes > 1 {
        println!("  processes   {processes} (MPI ranks; rank 0 wrote the output)");
    }
    if let Some(b) = peak {
        println!("  peak memory {:.0} MiB", b as f64 / (1 << 20) as f64);
    }
    Ok(())
}

/// A failed run's error for the user: an interruption with the command that continues it,
/// a mistake in the case naming the case, or the run's failure with its cause.
fn run_error(args: &RunArgs, out: &Path, e: hooke_sim::Error) -> anyhow::Error {
    match e {
        hooke_sim::Error::Interrupted {
            checkpoint: Some(ref ck),
            ..
        } => Interrupted(format!(
            "{e}: continue with\n  hooke run {} --resume {}{}",
            args.case.display(),
            ck.display(),
            if args.out.is_some() {
                format!(" --out {}", out.display())
            } else {
                String::new()
            }
        ))
        .into(),
        hooke_sim::Error::Interrupted { .. } => Interrupted(e.to_string()).into(),
        e if e.is_input() => InputError(format!("{}: {e}", args.case.display())).into(),
        e => anyhow::Error::new(e).context(format!("{}: the run failed", args.case.display())),
    }
}

fn print_summary(case: &Path, s: &hooke_sim::Summary) {
    let e = &s.energy;
    let strain = e.strain_direct + e.strain_dispersive;
    if s.quasi_static {
        println!(
            "{}: {} quasi-static load steps in {:.1} s",
            case.display(),
            s.steps,
            s.wall_seconds
        );
        println!(
            "  springs broken {}, strain energy {:.4e} J, work in {:.4e} J, released {:.4e} J, dissipated in re-equilibration {:.4e} J, balance error {:.2e}",
            s.broken_springs,
            strain,
            e.external_work + e.boundary_work,
            e.released,
            e.dissipated,
            s.balance
        );
    } else {
        println!(
            "{}: {} steps to t = {:e} s in {:.1} s ({:.0} steps/s)",
            case.display(),
            s.steps,
            s.time,
            s.wall_seconds,
            s.steps as f64 / s.wall_seconds.max(1e-9)
        );
        for (name, x, v) in &s.rigid {
            println!("  rigid {name}: at {x:?} m, velocity {v:?} m/s");
        }
        if let Some((builds, depth, ratio)) = s.contact {
            println!(
                "  contact: {builds} list builds, deepest penetration {depth:.3e} m ({ratio:.3} of the contact radius)"
            );
        }
        println!(
            "  springs broken {}, energy: kinetic {:.4e} J, strain {:.4e} J, released {:.4e} J, balance error {:.2e}",
            s.broken_springs, e.kinetic, strain, e.released, s.balance
        );
    }
    if !s.strain_by_material.is_empty() {
        let parts: Vec<String> = s
            .strain_by_material
            .iter()
            .map(|(name, e)| format!("{name} {e:.4e} J"))
            .collect();
        println!("  strain energy by material: {}", parts.join(", "));
    }
    for r in &s.reactions {
        println!(
            "  {}: force [{:.4e}, {:.4e}, {:.4e}] N, mean displacement [{:.4e}, {:.4e}, {:.4e}] m",
            r.name,
            r.force[0],
            r.force[1],
            r.force[2],
            r.displacement[0],
            r.displacement[1],
            r.displacement[2]
        );
    }
    for (what, path) in &s.outputs {
        println!("  {what}: {}", path.display());
    }
}

/// Progress on a terminal (a bar, twice a second), as lines every N seconds in a batch job,
/// and Ctrl-C.
struct CliObserver {
    stop: Arc<AtomicBool>,
    bar: indicatif::ProgressBar,
    interactive: bool,
    interval: Option<Duration>,
    started: Instant,
    /// A failure to inject (tests only), and the steps seen so far.
    fault: Option<Fault>,
    steps: std::cell::Cell<u64>,
}

/// A failure injected on one rank of an MPI run, for the tests of what the job does then
/// (`tools/mpi_check.sh`): `HOOKE_TEST_FAIL=KIND:RANK:STEP`, with KIND one of `panic` (in the
/// run's driver), `worker-panic` (in a worker thread), `exit` (the process exits without
/// finalising MPI) after STEP steps, or `error` (the rank's set-up fails alone; STEP is
/// ignored). Read by the binary alone: the libraries take no environment variables. (A rank
/// killed by a signal is tested with `kill -9` itself.)
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fault {
    kind: FaultKind,
    step: u64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum FaultKind {
    Panic,
    WorkerPanic,
    Exit,
    Error,
}

impl Fault {
    /// The failure `HOOKE_TEST_FAIL` asks of rank `rank`, if any.
    fn from_env(rank: usize) -> Result<Option<Fault>> {
        let Ok(text) = std::env::var("HOOKE_TEST_FAIL") else {
            return Ok(None);
        };
        let bad = || {
            InputError(format!(
                "HOOKE_TEST_FAIL={text}: give KIND:RANK:STEP, KIND one of panic, worker-panic, exit, error"
            ))
        };
        let f: Vec<&str> = text.split(':').collect();
        let [kind, r, step] = f[..] else {
            return Err(bad().into());
        };
        let kind = match kind {
            "panic" => FaultKind::Panic,
            "worker-panic" => FaultKind::WorkerPanic,
            "exit" => FaultKind::Exit,
            "error" => FaultKind::Error,
            _ => return Err(bad().into()),
        };
        let (Ok(r), Ok(step)) = (r.parse::<usize>(), step.parse::<u64>()) else {
            return Err(bad().into());
        };
        Ok((r == rank).then_some(Fault { kind, step }))
    }

    /// Fail as asked.
    fn strike(&self) {
        match self.kind {
            FaultKind::Panic => panic!("HOOKE_TEST_FAIL: a panic injected at step {}", self.step),
            FaultKind::WorkerPanic => {
                use rayon::prelude::*;
                (0..64).into_par_iter().with_max_len(1).for_each(|i| {
                    if i == 63 {
                        panic!("HOOKE_TEST_FAIL: a panic injected in a worker thread");
                    }
                });
            }
            FaultKind::Exit => std::process::exit(3),
            FaultKind::Error => {}
        }
    }
}

impl CliObserver {
    fn new(stop: Arc<AtomicBool>, batch_every: f64, quasi: Option<usize>) -> Self {
        let interactive = std::io::stderr().is_terminal();
        let len = quasi.map_or(BAR_LEN, |n| n as u64);
        CliObserver {
            stop,
            bar: progress_bar(interactive, len),
            interactive,
            interval: if interactive {
                Some(Duration::from_millis(500))
            } else if batch_every > 0.0 {
                Some(hooke_sim::seconds(batch_every))
            } else {
                None
            },
            started: Instant::now(),
            fault: None,
            steps: std::cell::Cell::new(0),
        }
    }
}

impl Observer for CliObserver {
    fn progress_interval(&self) -> Option<Duration> {
        self.interval
    }

    fn progress(&mut self, p: &Progress) {
        if self.interactive {
            match p.load_step {
                Some((k, n)) => {
                    self.bar.set_position(k as u64);
                    self.bar.set_message(format!(
                        "load step {k}/{n}  broken springs {}",
                        p.broken_springs
                    ));
                }
                None => {
                    self.bar.set_position((p.fraction * BAR_LEN as f64) as u64);
                    self.bar.set_message(format!(
                        "t = {:.3e} s  {:.0} steps/s  broken springs {}  energy {:.3e} J{} (balance {:.1e})",
                        p.time, p.steps_per_second, p.broken_springs, p.energy, energy_when(p, 3), p.balance
                    ));
                }
            }
        } else {
            // One line a report, for a cluster job's log.
            eprintln!(
                "[{:>7.0} s] t = {:.4e} s of {:.4e} s ({:5.1} %), {:.0} steps/s, ETA {}, broken springs {}, energy {:.4e} J{}, balance {:.1e}",
                self.started.elapsed().as_secs_f64(),
                p.time,
                p.end_time,
                100.0 * p.fraction,
                p.steps_per_second,
                p.eta_seconds
                    .map_or("unknown".to_string(), |s| format!("{s:.0} s")),
                p.broken_springs,
                p.energy,
                energy_when(p, 4),
                p.balance
            );
        }
    }

    fn interrupted(&self) -> bool {
        // Asked once per step: the injected failure's clock.
        if let Some(f) = &self.fault {
            self.steps.set(self.steps.get() + 1);
            if self.steps.get() == f.step {
                f.strike();
            }
        }
        self.stop.load(Ordering::SeqCst)
    }
}

/// Where a progress report shows an earlier evaluation of the energy (a large body's, see
/// `Progress::energy_time`), when it was: " at t = ... s"; nothing otherwise.
fn energy_when(p: &hooke_sim::Progress, digits: usize) -> String {
    if p.energy_time == p.time {
        String::new()
    } else {
        format!(" at t = {:.*e} s", digits, p.energy_time)
    }
}

/// Resolution of the explicit run's progress bar (it shows simulated time, not steps).
const BAR_LEN: u64 = 1000;

/// A progress bar on stderr when it is a terminal (ETA from the progress rate, the message
/// carrying step rate, broken springs and energy); hidden otherwise, so logs stay clean.
fn progress_bar(interactive: bool, len: u64) -> indicatif::ProgressBar {
    if !interactive {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    let style =
        indicatif::ProgressStyle::with_template("  [{bar:32}] {percent:>3} %  ETA {eta:>4}  {msg}")
            .map(|s| s.progress_chars("=> "))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
    bar.set_style(style);
    bar
}

/// The anisotropic material's engineering constants, as `hooke check` prints them.
fn print_material(m: &hooke_core::Anisotropic) -> Result<()> {
    match m {
        hooke_core::Anisotropic::Transverse(t) => println!(
            "  material     transversely isotropic, fibre {:?}: E_p {:e} Pa, E_t {:e} Pa, nu_p {}, nu_tp {}, G_t {:e} Pa",
            t.axis()?, t.youngs_plane, t.youngs_fibre, t.poisson_plane, t.poisson_fibre, t.shear_fibre
        ),
        hooke_core::Anisotropic::Orthotropic(o) => {
            println!(
                "  material     orthotropic, axes x y z: E {:?} Pa, nu_xy nu_xz nu_yz {:?}, G_yz G_xz G_xy {:?} Pa",
                o.youngs, o.poisson, o.shear
            );
            if !o.along_body_axes() {
                let a = o.axes;
                println!(
                    "  axes         x = [{:.6}, {:.6}, {:.6}], y = [{:.6}, {:.6}, {:.6}], z = [{:.6}, {:.6}, {:.6}] in the body",
                    a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2], a[2][0], a[2][1], a[2][2]
                );
            }
        }
    }
    Ok(())
}
