//! `hooke bench`: throughput of explicit steps (unique spring-updates per second), and the
//! static solve time of the paper's block.

use anyhow::{Context, Result};
use clap::Args;
use hooke_core::{Body, Real, State};
use hooke_lab::bench::{BenchOptions, CompareReport, KernelChoice, Law, StepsReport};

use crate::InputError;
use hooke_lab::moduli::LatticeName;

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Lattice of the block.
    #[arg(long, value_enum, default_value = "cubic")]
    pub lattice: LatticeName,
    /// Approximate number of nodes (a cube, or a square plate for hex).
    #[arg(long, default_value_t = 1_000_000)]
    pub nodes: usize,
    /// Force law.
    #[arg(long, value_enum, default_value = "dispersive")]
    pub law: Law,
    /// Timed steps (after 3 warm-up steps).
    #[arg(long, default_value_t = 50)]
    pub steps: u64,
    /// Kernel to use.
    #[arg(long, value_enum, default_value = "auto")]
    pub kernel: KernelChoice,
    /// Weight the block's springs and nodes by their cells (regular lattices: what a case's
    /// body has by default, `lattice.cell_weights`), so the stencils carry their face classes.
    #[arg(long)]
    pub cell_weights: bool,
    /// Instead: time the plain and the dispersive law on the same block, alternating windows of
    /// --steps steps --repeats times in one process, and report the medians and their ratio
    /// (this machine is noisy; interleaving and medians make the ratio reproducible).
    #[arg(long)]
    pub compare: bool,
    /// Windows per law for --compare.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Instead: time the static solve of the paper's 71x16x16 block at nu = -0.9, 0.3 and 0.49.
    #[arg(long = "static")]
    pub static_solve: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Also time the same steps with contact switched on (fragment contact, no rigid body: the
    /// cost an intact run pays) and report the ratio as `contact_overhead`.
    #[arg(long)]
    pub contact: bool,
    /// Instead: time the step with the stretch criterion active and nothing breaking against the
    /// intact step on the same body (`fracture_overhead`), alternating windows of --steps steps
    /// --repeats times; with --case, also a running crack: the case is run to --crack-time
    /// (default: half its end time), then windows of steps with breaking alternate with windows
    /// without it (`running_crack_overhead`).
    #[arg(long)]
    pub fracture: bool,
    /// Also write the block (positions, masses, initial velocities, springs with their rest
    /// lengths and stiffnesses) as a LAMMPS data file, one bond type per spring
    /// (`bond_style harmonic`, K = k/2, r0 = L), so that LAMMPS can run exactly this network
    /// (tools/bench_lammps/).
    #[arg(long, value_name = "FILE")]
    pub export_lammps: Option<std::path::PathBuf>,
    /// Instead: the cost of an output frame (every sink the case writes: VTK, HDF5, histories)
    /// against a step, on --case run to --crack-time: windows of a frame plus --steps steps
    /// (waiting for the frame's file at the end) alternate with windows of the steps alone,
    /// --repeats times; prints `frame_over_step`, the difference in step times.
    #[arg(long)]
    pub frame: bool,
    /// A case file for --fracture's running crack and for --frame (e.g.
    /// cases/glass_branching_random.toml).
    #[arg(long)]
    pub case: Option<std::path::PathBuf>,
    /// Resolution factor of --case.
    #[arg(long, default_value_t = 1.0)]
    pub scale: Real,
    /// Simulated time (s) the --case is run to before timing.
    #[arg(long)]
    pub crack_time: Option<Real>,
    /// Under `mpirun -np N` (N > 1): after the set-up, each rank keeps only its piece of the
    /// block (its own nodes and their ghosts, `hooke_core::team::Piece`) and drops the whole
    /// body and state, as a distributed-memory run will; the steps give the same bits. Random
    /// lattices only (the regular boxes' stencil kernels sweep the whole box).
    #[arg(long)]
    pub pieces: bool,
    /// Set the block up from parts (random lattices; under `mpirun -np N`, or alone as the
    /// one-process reference): each rank samples, triangulates and numbers only its part of
    /// the block and its surroundings (`hooke_core::random::part`, `hooke_core::team::parts`),
    /// so no rank ever holds the whole block. The nodes are a jittered grid (amplitude 0.6),
    /// whose nodes any part can draw alone; the stable step is estimated on the pieces as one
    /// process estimates it, and `state_digest` is the same for any number of ranks.
    #[arg(long, conflicts_with = "pieces")]
    pub parts: bool,
    /// A block of two materials, half and half along x (the second four times as stiff and of
    /// another nu): the cost of a heterogeneous body against a homogeneous one of the same
    /// lattice and size (run both, alternating, to compare).
    #[arg(long, conflicts_with_all = ["parts", "pieces"])]
    pub phases: bool,
}

pub use hooke_sys::peak_memory;

impl BenchArgs {
    /// The library's options for these flags.
    pub fn options(&self) -> BenchOptions {
        BenchOptions {
            lattice: self.lattice,
            nodes: self.nodes,
            law: self.law,
            steps: self.steps,
            kernel: self.kernel,
            cell_weights: self.cell_weights,
            repeats: self.repeats,
            contact: self.contact,
            pieces: self.pieces,
            parts: self.parts,
            phases: self.phases,
        }
    }
}

pub fn run(args: BenchArgs) -> Result<()> {
    if args.pieces
        && (args.static_solve || args.compare || args.fracture || args.frame || args.contact)
    {
        return Err(InputError(
            "--pieces times the steps alone: it takes none of --static-solve, --compare, \
             --fracture, --frame and --contact, which read the whole state"
                .into(),
        )
        .into());
    }
    if args.parts
        && (args.static_solve
            || args.compare
            || args.fracture
            || args.frame
            || args.contact
            || args.export_lammps.is_some()
            || args.kernel == KernelChoice::Csr)
    {
        return Err(InputError(
            "--parts times the steps alone: it takes none of --static-solve, --compare, \
             --fracture, --frame, --contact, --export-lammps and --kernel csr"
                .into(),
        )
        .into());
    }
    if (args.pieces || args.parts) && matches!(args.lattice, LatticeName::Cubic | LatticeName::Hex)
    {
        return Err(InputError(
            "--pieces and --parts split random lattices (--lattice random3d or random2d): a \
             regular box's stencil kernel sweeps the whole box"
                .into(),
        )
        .into());
    }
    if args.static_solve {
        return bench_static(&args);
    }
    if args.compare {
        let out = hooke_lab::bench::compare(&args.options())?;
        print_compare(&args, &out)?;
        return Ok(());
    }
    if args.fracture {
        return bench_fracture(&args);
    }
    if args.frame {
        return bench_frame(&args);
    }
    args.options().check()?;
    // Under `mpirun -np N` (feature `mpi`) the ranks share every step, as `hooke run` does;
    // rank 0 times and prints.
    #[cfg(feature = "mpi")]
    return crate::mpi::run(|team| bench_steps(&args, team));
    #[cfg(not(feature = "mpi"))]
    bench_steps(&args, None)
}

/// The step benchmark (`hooke bench` without a mode of its own), on this rank of a team or
/// alone: rank 0 prints.
fn bench_steps(
    args: &BenchArgs,
    team: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<()> {
    if team.as_ref().is_some_and(|t| t.rank() != 0) {
        crate::set_quiet();
    }
    let mut export = |body: &Body, state: &State, dt: Real| -> Result<()> {
        match &args.export_lammps {
            Some(path) => write_lammps(path, body, state, dt)
                .with_context(|| format!("writing the LAMMPS data file {}", path.display())),
            None => Ok(()),
        }
    };
    let out = hooke_lab::bench::steps(&args.options(), team, Some(&mut export))?;
    if crate::quiet() {
        return Ok(());
    }
    if args.json {
        println!("{}", serde_json::to_string(&out)?);
    } else {
        print_bench(&out);
    }
    Ok(())
}

/// `--compare`'s JSON or text.
fn print_compare(args: &BenchArgs, out: &CompareReport) -> Result<()> {
    if args.json {
        println!("{}", serde_json::to_string(out)?);
    } else {
        println!(
            "{} lattice, {} nodes, {} springs, {} kernel, {} threads, medians of {} windows of {} steps:\n  plain {:.3} ms/step ({:.1} M spring-updates/s), dispersive {:.3} ms/step ({:.1} M/s), ratio {:.3}",
            out.lattice, out.nodes, out.springs, out.kernel, out.threads, out.repeats, out.steps,
            out.plain_seconds_per_step * 1e3, out.plain_spring_updates_per_s / 1e6,
            out.dispersive_seconds_per_step * 1e3, out.dispersive_spring_updates_per_s / 1e6,
            out.ratio_dispersive_over_plain
        );
    }
    Ok(())
}

/// A benchmark's text: throughput, set-up, memory per node, the ranks' traffic, contact.
fn print_bench(out: &StepsReport) {
    println!(
        "{} law, {} lattice, {} kernel, {} threads: {} nodes, {} springs, {} steps in {:.3} s\n  {:.1} million spring-updates/s, {:.3} ms/step, peak memory {}",
        out.law,
        out.lattice,
        out.kernel,
        out.threads,
        out.nodes,
        out.springs,
        out.steps,
        out.seconds,
        out.spring_updates_per_s / 1e6,
        out.seconds_per_step * 1e3,
        out.peak_memory_bytes.map_or("unknown".into(), |b| format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64)),
    );
    let largest: Vec<String> = {
        let mut parts: Vec<_> = out.memory_parts.iter().collect();
        parts.sort_by(|a, b| b.1.total_cmp(a.1));
        parts
            .iter()
            .take(4)
            .map(|(name, b)| format!("{name} {b:.0}"))
            .collect()
    };
    println!(
        "  set-up {:.2} s: lattice {:.2}, body {:.2}, integrator (stable step) {:.2}",
        out.setup_seconds,
        out.setup_parts["lattice"],
        out.setup_parts["body"],
        out.setup_parts["integrator"],
    );
    println!(
        "  arrays {:.0} bytes per node ({}, ...; --json lists them all)",
        out.memory_bytes_per_node,
        largest.join(", ")
    );
    if let Some(n) = out.piece_nodes {
        println!("  each rank holds its piece only: rank 0 {n} nodes");
    }
    if out.processes > 1 {
        println!(
            "  {} MPI ranks: {:.2} MB received per rank and step ({} ghost nodes), {} halo \
             messages and {} collectives",
            out.processes,
            out.halo_bytes_per_step as f64 / 1e6,
            out.ghost_nodes,
            out.halo_messages_per_step,
            out.collectives_per_step
        );
    }
    if let Some(r) = out.contact_overhead {
        println!("  with contact switched on (no fragments yet): {r:.3} x the step time");
    }
}

/// `--fracture`: the library's measurement, as JSON or text.
fn bench_fracture(args: &BenchArgs) -> Result<()> {
    let name = args.case.as_ref().map(|p| p.display().to_string());
    let sim = match &args.case {
        Some(path) => {
            Some(hooke_case::load(path, args.scale).map_err(|e| InputError(e.to_string()))?)
        }
        None => None,
    };
    let case = name.as_deref().zip(sim);
    let out = hooke_lab::overhead::fracture(&args.options(), case, args.crack_time)?;
    if args.json {
        println!("{}", serde_json::to_value(&out)?);
        return Ok(());
    }
    println!(
        "{} lattice, {} kernel, {} nodes, {} threads, medians of {} alternating windows of {} steps:\n  stretch criterion, nothing breaking: {:.3} x the intact step ({:.3} vs {:.3} ms)",
        out.lattice, out.kernel, out.nodes, out.threads, out.repeats, out.steps,
        out.fracture_overhead, out.fracture_seconds_per_step * 1e3, out.intact_seconds_per_step * 1e3
    );
    if let Some(r) = &out.running {
        println!(
            "  running crack ({}, {} springs broken while timed): {:.3} x the step without breaking",
            r.case, r.springs_broken_while_timed, r.running_crack_overhead
        );
    }
    Ok(())
}

/// `--static`: the library's solves of the paper's block, as JSON or text.
fn bench_static(args: &BenchArgs) -> Result<()> {
    let rows = hooke_lab::overhead::static_solves()?;
    if args.json {
        println!(
            "{}",
            serde_json::json!({ "static_solve": rows, "threads": rayon::current_num_threads() })
        );
        return Ok(());
    }
    for r in &rows {
        println!(
            "static solve, 71x16x16 block, nu = {:>5}: {:.3} s ({} Newton, {} CG, residual {:.1e})",
            r.nu, r.seconds, r.newton, r.cg, r.residual
        );
    }
    Ok(())
}

/// The bench body as a LAMMPS data file (`atom_style bond`, `bond_style harmonic`): one atom per
/// node with its half-step velocity, one bond type per spring with `K = k/2` (LAMMPS's
/// harmonic energy is `K (r - r0)^2`) and `r0 = L`, so that LAMMPS integrates exactly the
/// network hooke does with plain springs. Masses are per atom type in LAMMPS, and a type per
/// node would make its per-type-pair tables quadratic, so every atom gets the mean node mass
/// (the cost of a step does not depend on it). Lattice units; the header names the time step.
fn write_lammps(
    path: &std::path::Path,
    body: &hooke_core::body::Body,
    state: &hooke_core::state::State,
    dt: Real,
) -> Result<()> {
    use std::io::Write;
    let lat = &body.lattice;
    let (n, m) = (body.nodes(), body.springs());
    let mut lo = [Real::INFINITY; 3];
    let mut hi = [Real::NEG_INFINITY; 3];
    for i in 0..n {
        let p = lat.pos.get(i);
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "hooke {} network: {n} nodes, {m} springs, dt {dt:e} (lattice units)\n",
        lat.kind.name()
    )?;
    writeln!(f, "{n} atoms\n{m} bonds\n1 atom types\n{m} bond types\n")?;
    // A margin so that no node sits on the box face; 2D plates get a slab in z.
    for (c, name) in ["x", "y", "z"].iter().enumerate() {
        let pad = 1.0 + 0.01 * (hi[c] - lo[c]);
        writeln!(
            f,
            "{:.17e} {:.17e} {name}lo {name}hi",
            lo[c] - pad,
            hi[c] + pad
        )?;
    }
    let mean_mass = body.mass.iter().sum::<Real>() / n as Real;
    writeln!(f, "\nMasses\n\n1 {mean_mass:.17e}")?;
    writeln!(f, "\nBond Coeffs # harmonic\n")?;
    for b in 0..m {
        writeln!(f, "{} {:.17e} {:.17e}", b + 1, 0.5 * body.k[b], lat.rest(b))?;
    }
    writeln!(f, "\nAtoms # bond\n")?;
    for i in 0..n {
        let p = lat.pos.get(i);
        writeln!(f, "{} 1 1 {:.17e} {:.17e} {:.17e}", i + 1, p.x, p.y, p.z)?;
    }
    writeln!(f, "\nVelocities\n")?;
    for i in 0..n {
        let v = state.v.get(i);
        writeln!(f, "{} {:.17e} {:.17e} {:.17e}", i + 1, v.x, v.y, v.z)?;
    }
    writeln!(f, "\nBonds\n")?;
    for (b, &[i, j]) in lat.bonds.ends.iter().enumerate() {
        writeln!(f, "{} {} {} {}", b + 1, b + 1, i + 1, j + 1)?;
    }
    f.flush()?;
    Ok(())
}

/// `--frame`: the library's measurement on the case, as JSON or text.
fn bench_frame(args: &BenchArgs) -> Result<()> {
    let Some(case) = &args.case else {
        return Err(InputError("--frame needs --case CASE.toml".into()).into());
    };
    let text = std::fs::read_to_string(case)
        .map_err(|e| InputError(format!("{}: {e}", case.display())))?;
    let (sim, opts) =
        hooke_case::prepare(case, &text, args.scale, &[]).map_err(|e| InputError(e.to_string()))?;
    let name = case.display().to_string();
    let out = hooke_lab::overhead::frame(&name, sim, opts, &args.options(), args.crack_time)?;
    if args.json {
        println!("{}", serde_json::to_value(&out)?);
        return Ok(());
    }
    println!(
        "{} ({} nodes, {} springs broken), {} kernel, {} threads, medians of {} alternating windows of {} steps:\n  step {:.3} ms; a frame adds {:.3} ms = {:.2} steps to the run (the stepping thread waits {:.3} ms for it)",
        out.case, out.nodes, out.broken_springs, out.kernel, out.threads, out.repeats, out.steps,
        out.step_seconds * 1e3, out.frame_seconds * 1e3, out.frame_over_step, out.frame_call_seconds * 1e3
    );
    if let Some(r) = out.resident_memory_bytes {
        println!(
            "  resident after the frames: {:.1} bytes per node (the springs' rows {})",
            r as f64 / out.nodes as f64,
            if out.rows_built { "built" } else { "not built" }
        );
    }
    Ok(())
}
