//! `hooke bench`: throughput of explicit steps (unique spring-updates per second), and the
//! static solve time of the paper's block.

use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::moduli::{block_test, BlockTest};
use hooke_core::team::Piece;
use hooke_core::{Body, Lattice, LatticeKind, Real, State};

use crate::InputError;
use hooke_lab::moduli::LatticeName;

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum LawArg {
    /// Plain springs (q = 0, nu fixed at 1/4 or 1/3).
    Plain,
    /// The dispersive law (nu = 0.3 in 3D, 0.45 in 2D).
    Dispersive,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum KernelArg {
    /// The fastest kernel for the body (the vector stencil for cubic and hexagonal boxes, the
    /// row kernel for other lattices where the processor has AVX-512).
    Auto,
    /// The same kernel without vector instructions (the stencils' and the row kernel's
    /// portable paths).
    Portable,
    /// The general CSR kernel (random lattices without AVX-512; the row kernel gives its bits).
    Csr,
}

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
    pub law: LawArg,
    /// Timed steps (after 3 warm-up steps).
    #[arg(long, default_value_t = 50)]
    pub steps: u64,
    /// Kernel to use.
    #[arg(long, value_enum, default_value = "auto")]
    pub kernel: KernelArg,
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
}

#[derive(Debug, serde::Serialize)]
struct BenchJson {
    law: &'static str,
    lattice: &'static str,
    kernel: String,
    nodes: usize,
    springs: usize,
    steps: u64,
    threads: usize,
    seconds: f64,
    seconds_per_step: f64,
    spring_updates_per_s: f64,
    node_updates_per_s: f64,
    peak_memory_bytes: Option<u64>,
    /// Resident memory after the timed steps (the steady state: set-up scratch returned).
    resident_memory_bytes: Option<u64>,
    /// What the body, state, integrator and kernel hold on the heap, by part, in bytes per
    /// node (capacities: what was allocated, whether or not the system has paged it in).
    memory_parts: std::collections::BTreeMap<&'static str, f64>,
    /// Their sum, bytes per node.
    memory_bytes_per_node: f64,
    /// With --pieces: the nodes this rank holds (rank 0's: its own, its ghosts and the
    /// dummies that align its own on a chunk). `memory_parts` are still per node of the block.
    #[serde(skip_serializing_if = "Option::is_none")]
    piece_nodes: Option<usize>,
    /// Digest of every node's displacement and velocity after the steps, in hexadecimal
    /// (`Integrator::state_digest`): the same for any number of ranks, with or without
    /// --pieces, exactly when the bits are.
    state_digest: String,
    setup_seconds: f64,
    /// Where the set-up's seconds went: the lattice (nodes, springs), the body (stiffnesses,
    /// masses, state) and the integrator (its stable-step estimate, mostly).
    setup_parts: std::collections::BTreeMap<&'static str, f64>,
    /// With --contact: step time with contact over step time without (medians of alternating
    /// windows).
    #[serde(skip_serializing_if = "Option::is_none")]
    contact_overhead: Option<f64>,
    /// MPI ranks sharing each step (`mpirun -np N hooke bench`, feature `mpi`), 1 alone.
    processes: usize,
    /// Bytes each rank receives per step (rank 0's figure: its ghosts' pools and
    /// displacements, and the partial sums), the point-to-point messages it sends per step
    /// (halo trades), its ghost nodes, and the collective operations per step; zero alone.
    halo_bytes_per_step: usize,
    halo_messages_per_step: usize,
    ghost_nodes: usize,
    collectives_per_step: usize,
}

pub use hooke_sys::{peak_memory, resident_memory};

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
            || args.kernel == KernelArg::Csr)
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
        return bench_compare(&args);
    }
    if args.fracture {
        return bench_fracture(&args);
    }
    if args.frame {
        return bench_frame(&args);
    }
    if args.nodes < 27 || args.steps == 0 {
        return Err(InputError(format!(
            "--nodes {} --steps {}: give at least 27 nodes and 1 step",
            args.nodes, args.steps
        ))
        .into());
    }
    // Under `mpirun -np N` (feature `mpi`) the ranks share every step, as `hooke run` does;
    // rank 0 times and prints.
    #[cfg(feature = "mpi")]
    return crate::mpi::run(|team| bench_steps(&args, team));
    #[cfg(not(feature = "mpi"))]
    bench_steps(&args, None)
}

/// The step benchmark (`hooke bench` without a mode of its own), on this rank of a team or
/// alone.
fn bench_steps(
    args: &BenchArgs,
    team: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<()> {
    if team.as_ref().is_some_and(|t| t.rank() != 0) {
        crate::set_quiet();
    }
    if args.pieces && team.as_ref().is_none_or(|t| t.size() < 2) {
        return Err(InputError(
            "--pieces cuts the block between MPI ranks: run it under `mpirun -np N` with N > 1 \
             (a build with `--features mpi`)"
                .into(),
        )
        .into());
    }
    let setup = Instant::now();
    let (body, mut state, mut it, nodes, springs, setup_parts) = if args.parts {
        bench_from_parts(args, team.clone())?
    } else {
        let lattice = bench_lattice(args)?;
        let lattice_seconds = setup.elapsed().as_secs_f64();
        let kind = lattice.kind;
        let nu = match (args.law, kind) {
            (LawArg::Plain, _) => hooke_core::material::nu_from_q(kind, 0.0),
            (LawArg::Dispersive, LatticeKind::Cubic | LatticeKind::Random3d) => 0.3,
            (LawArg::Dispersive, LatticeKind::Hex | LatticeKind::Random2d) => 0.45,
        };
        let (body, state, mut it, [body_seconds, integrator_seconds]) =
            bench_run_timed(args, lattice, q_from_nu(kind, nu)?, team.clone())?;
        let setup_parts = [
            ("lattice", lattice_seconds),
            ("body", body_seconds),
            ("integrator", integrator_seconds),
        ]
        .into_iter()
        .collect();
        if let Some(path) = &args.export_lammps {
            write_lammps(path, &body, &state, it.dt)
                .with_context(|| format!("writing the LAMMPS data file {}", path.display()))?;
        }
        let (nodes, springs) = (body.nodes(), body.springs());
        let (body, state) = if args.pieces {
            let piece = it.cut(&body, &state)?;
            drop((body, state));
            piece
        } else {
            (body, state)
        };
        (body, state, it, nodes, springs, setup_parts)
    };
    let setup_seconds = setup.elapsed().as_secs_f64();
    // As `hooke run` does after its set-up (hooke_sim::Run::start).
    hooke_sys::alloc::release_free_memory();
    for _ in 0..3 {
        it.step(&body, &mut state);
    }
    let start = Instant::now();
    for _ in 0..args.steps {
        it.step(&body, &mut state);
    }
    let seconds = start.elapsed().as_secs_f64();
    it.check_shared(&body, &mut state)?;
    let state_digest = format!("{:016x}", it.state_digest(&state));
    let contact_overhead = args
        .contact
        .then(|| contact_overhead(args, &body, &mut state, &mut it));
    let mut memory_parts = std::collections::BTreeMap::new();
    for (name, b) in body
        .footprint()
        .into_iter()
        .chain(state.footprint())
        .chain(it.footprint())
    {
        *memory_parts.entry(name).or_insert(0.0) += b as f64 / nodes as f64;
    }
    memory_parts.retain(|_, b| *b > 0.0);
    let memory_bytes_per_node = memory_parts.values().sum();
    let out = BenchJson {
        law: match args.law {
            LawArg::Plain => "plain",
            LawArg::Dispersive => "dispersive",
        },
        lattice: body.lattice.kind.name(),
        kernel: it.kernel.name().to_string(),
        nodes,
        springs,
        steps: args.steps,
        threads: rayon::current_num_threads(),
        seconds,
        seconds_per_step: seconds / args.steps as f64,
        spring_updates_per_s: springs as f64 * args.steps as f64 / seconds,
        node_updates_per_s: nodes as f64 * args.steps as f64 / seconds,
        peak_memory_bytes: peak_memory(),
        resident_memory_bytes: resident_memory(),
        memory_parts,
        memory_bytes_per_node,
        piece_nodes: it.piece().map(Piece::len),
        state_digest,
        setup_seconds,
        setup_parts,
        contact_overhead,
        processes: team.as_ref().map_or(1, |t| t.size()),
        halo_bytes_per_step: it
            .share()
            .map_or(0, |s| s.received_per_step(body.lattice.dim())),
        halo_messages_per_step: it.share().map_or(0, |s| s.messages_per_step()),
        ghost_nodes: it.share().map_or(0, |s| s.halo.ghosts()),
        collectives_per_step: it.collectives_per_step(),
    };
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

/// The step time with contact switched on (no fragments yet) over the time without, medians of
/// alternating windows: this machine's speed drifts by more than the figure we want.
fn contact_overhead(args: &BenchArgs, body: &Body, state: &mut State, it: &mut Integrator) -> f64 {
    // Alternate windows with and without contact on the same body and take the median of
    // each: this machine's speed drifts by more than the figure we want.
    let mut contact = hooke_contact::Contact::new(
        body,
        Vec::new(),
        hooke_contact::ContactOptions::for_body(body),
    );
    let (mut with, mut without) = (Vec::new(), Vec::new());
    for _ in 0..args.repeats.max(1) {
        let t0 = Instant::now();
        for _ in 0..args.steps {
            it.step(body, state);
        }
        without.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        for _ in 0..args.steps {
            it.step_with(body, state, Some(&mut contact));
        }
        with.push(t0.elapsed().as_secs_f64());
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(|a, b| a.total_cmp(b));
        v[v.len() / 2]
    };
    median(&mut with) / median(&mut without)
}

/// A benchmark's text: throughput, set-up, memory per node, the ranks' traffic, contact.
fn print_bench(out: &BenchJson) {
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

/// The block the benchmarks run on: about `--nodes` nodes of `--lattice` in lattice units.
fn bench_lattice(args: &BenchArgs) -> Result<Lattice> {
    Ok(match args.lattice {
        LatticeName::Cubic => {
            let side = (args.nodes as f64).cbrt().round().max(3.0) as usize;
            Lattice::cubic_box([side, side, side], 1.0)?
        }
        LatticeName::Hex => {
            let side = (args.nodes as f64).sqrt().round().max(3.0) as usize;
            Lattice::hex_box(side, side, 1.0, 1.0)?
        }
        LatticeName::Random3d => {
            let side = (args.nodes as f64).cbrt().round().max(3.0) - 1.0;
            let spec = hooke_core::random::RandomSpec::default();
            Lattice::random(3, [0.0; 3], [side; 3], 1.0, 1.0, spec, &|_| true)?
        }
        LatticeName::Random2d => {
            let side = (args.nodes as f64).sqrt().round().max(3.0) - 1.0;
            let spec = hooke_core::random::RandomSpec::default();
            Lattice::random(2, [0.0; 3], [side, side, 0.0], 1.0, 1.0, spec, &|_| true)?
        }
    })
}

/// The set-up of `--parts`: the block of `--lattice random3d` or `random2d` as a jittered grid
/// (amplitude 0.6, seed 1) whose parts each rank samples, triangulates and numbers alone, the
/// body in lattice units on the piece, at rest, its integrator (the stable step estimated on
/// the pieces as one process estimates it), then moving as `bench_run_timed` sets it. Alone, the team is one
/// process. Returns what `run` times, with the block's node and spring counts and the
/// set-up's seconds by part.
#[allow(clippy::type_complexity)]
fn bench_from_parts(
    args: &BenchArgs,
    team: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<(
    Body,
    State,
    Integrator,
    usize,
    usize,
    std::collections::BTreeMap<&'static str, f64>,
)> {
    use hooke_core::random::part::Sampling;
    use hooke_core::random::{RandomSpec, Sampler};
    use hooke_core::team::parts::assemble;
    let team: std::sync::Arc<dyn hooke_core::team::Team> =
        team.unwrap_or_else(|| std::sync::Arc::new(hooke_core::team::Alone));
    let (dim, kind) = match args.lattice {
        LatticeName::Random2d => (2, LatticeKind::Random2d),
        _ => (3, LatticeKind::Random3d),
    };
    let hi = if dim == 3 {
        [(args.nodes as f64).cbrt().round().max(3.0) - 1.0; 3]
    } else {
        let side = (args.nodes as f64).sqrt().round().max(3.0) - 1.0;
        [side, side, 0.0]
    };
    let spec = RandomSpec {
        sampler: Sampler::Jitter { amplitude: 0.6 },
        seed: 1,
    };
    let start = Instant::now();
    let block = Sampling {
        dim,
        lo: [0.0; 3],
        hi,
        a: 1.0,
        h: 1.0,
        spec,
        inside: &|_| true,
    };
    let (piece, lattice, share) = assemble(&*team, &block, 4.0)?;
    let lattice_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let nu = match (args.law, dim) {
        (LawArg::Plain, _) => hooke_core::material::nu_from_q(kind, 0.0),
        (LawArg::Dispersive, 3) => 0.3,
        (LawArg::Dispersive, _) => 0.45,
    };
    let mut body = Body::uniform(lattice, 1.0, q_from_nu(kind, nu)?, 1.0);
    body.lattice.shed_setup();
    let mut state = State::new(&body);
    let body_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let size = team.size();
    let mut counts = vec![0.0; size];
    counts[team.rank()] = share.springs.len() as Real;
    let singles: Vec<_> = (0..size).map(|r| r..r + 1).collect();
    team.gather(&mut counts, &singles);
    let springs = counts.iter().sum::<Real>() as usize;
    let nodes = piece.total;
    let dummy: Vec<bool> = piece
        .global
        .iter()
        .map(|&g| g == hooke_core::team::PAD)
        .collect();
    let it = Integrator::on_piece(
        &body,
        &mut state,
        Loading::default(),
        piece,
        share,
        team,
        &bench_opts(args),
    )
    .context("setting up the integrator on the piece")?;
    for (i, _) in dummy.iter().enumerate().filter(|(_, &d)| !d) {
        let p = body.lattice.pos.get(i);
        state.v.x_mut()[i] = 1e-3 * (0.1 * p.y).sin();
        state.v.y_mut()[i] = 1e-3 * (0.13 * p.z + 0.07 * p.x).cos();
    }
    let integrator_seconds = start.elapsed().as_secs_f64();
    let parts = [
        ("lattice", lattice_seconds),
        ("body", body_seconds),
        ("integrator", integrator_seconds),
    ]
    .into_iter()
    .collect();
    Ok((body, state, it, nodes, springs, parts))
}

/// A body on `lattice` in lattice units with ratio `q`, moving with a smooth velocity field (so
/// the springs do real work), and its integrator on the kernel `args` asks for.
fn bench_run(args: &BenchArgs, lattice: Lattice, q: Real) -> Result<(Body, State, Integrator)> {
    bench_run_timed(args, lattice, q, None).map(|(b, s, i, _)| (b, s, i))
}

/// [`bench_run`], with the seconds spent on the body (and state) and on the integrator (its
/// stable-step estimate, mostly); with `team`, shared by its members and distributed.
fn bench_run_timed(
    args: &BenchArgs,
    lattice: Lattice,
    q: Real,
    team: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<(Body, State, Integrator, [f64; 2])> {
    let start = Instant::now();
    let mut body = Body::uniform(lattice, 1.0, q, 1.0);
    if args.cell_weights {
        body = body
            .with_cell_weights()
            .context("--cell-weights (regular lattices only)")?;
    }
    // As a case's set-up does (hooke_sim's builder), once nothing more is built from them.
    body.lattice.shed_setup();
    // The CSR kernel, asked for where it would not run, streams the neighbours and the rest
    // lengths.
    if args.kernel == KernelArg::Csr {
        body.lattice.bonds.keep_neighbours();
        body.lattice.keep_rest();
    }
    let mut state = State::new(&body);
    let body_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    // Set up at rest, as a case usually is (a moving start would make the estimate keep a copy
    // of the velocities), then moving: the velocities below are the half-step ones.
    // Under mpirun the team shares the estimate, and the integrator comes back distributed.
    let it = Integrator::new_shared(
        &body,
        &mut state,
        Loading::default(),
        &bench_opts(args),
        team,
    )
    .context("setting up the integrator")?;
    let integrator_seconds = start.elapsed().as_secs_f64();
    for i in 0..body.nodes() {
        let p = body.lattice.pos.get(i);
        state.v.x_mut()[i] = 1e-3 * (0.1 * p.y).sin();
        state.v.y_mut()[i] = 1e-3 * (0.13 * p.z + 0.07 * p.x).cos();
    }
    Ok((body, state, it, [body_seconds, integrator_seconds]))
}

/// The integrator options `--kernel` asks for.
fn bench_opts(args: &BenchArgs) -> IntegratorOptions {
    IntegratorOptions {
        portable: args.kernel == KernelArg::Portable,
        force_csr: args.kernel == KernelArg::Csr,
        ..Default::default()
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn bench_compare(args: &BenchArgs) -> Result<()> {
    if args.repeats == 0 || args.steps == 0 {
        return Err(InputError("--repeats and --steps must be at least 1".into()).into());
    }
    let lattice = bench_lattice(args)?;
    let kind = lattice.kind;
    // The dispersive law at the bench's Poisson's ratio against plain springs on the same
    // lattice (the plain lattice's own ratio: 1/4 in 3D, 1/3 in 2D).
    let nu = match kind {
        LatticeKind::Cubic | LatticeKind::Random3d => 0.3,
        LatticeKind::Hex | LatticeKind::Random2d => 0.45,
    };
    let mut runs = Vec::new();
    for q in [0.0, q_from_nu(kind, nu)?] {
        let (body, mut state, mut it) = bench_run(args, lattice.clone(), q)?;
        for _ in 0..3 {
            it.step(&body, &mut state);
        }
        runs.push((body, state, it, Vec::new()));
    }
    for _ in 0..args.repeats {
        for (body, state, it, times) in runs.iter_mut() {
            let start = Instant::now();
            for _ in 0..args.steps {
                it.step(body, state);
            }
            times.push(start.elapsed().as_secs_f64() / args.steps as f64);
        }
    }
    let springs = runs[0].0.springs();
    let plain = median(&mut runs[0].3.clone());
    let disp = median(&mut runs[1].3.clone());
    let out = serde_json::json!({
        "lattice": kind.name(), "nodes": runs[0].0.nodes(), "springs": springs, "threads": rayon::current_num_threads(),
        "kernel": runs[1].2.kernel.name(), "repeats": args.repeats, "steps": args.steps,
        "plain_seconds_per_step": plain, "dispersive_seconds_per_step": disp,
        "plain_spring_updates_per_s": springs as f64 / plain, "dispersive_spring_updates_per_s": springs as f64 / disp,
        "ratio_dispersive_over_plain": disp / plain,
    });
    if args.json {
        println!("{out}");
    } else {
        println!(
            "{} lattice, {} nodes, {} springs, {} kernel, {} threads, medians of {} windows of {} steps:\n  plain {:.3} ms/step ({:.1} M spring-updates/s), dispersive {:.3} ms/step ({:.1} M/s), ratio {:.3}",
            kind.name(), runs[0].0.nodes(), springs, runs[1].2.kernel.name(), rayon::current_num_threads(), args.repeats, args.steps,
            plain * 1e3, springs as f64 / plain / 1e6, disp * 1e3, springs as f64 / disp / 1e6, disp / plain
        );
    }
    Ok(())
}

/// Medians of alternating windows: `a` and `b` each take `steps` steps per window.
fn alternate(
    repeats: usize,
    mut a: impl FnMut() -> Result<()>,
    mut b: impl FnMut() -> Result<()>,
) -> Result<(f64, f64)> {
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        a()?;
        ta.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        b()?;
        tb.push(t0.elapsed().as_secs_f64());
    }
    Ok((median(&mut ta), median(&mut tb)))
}

fn bench_fracture(args: &BenchArgs) -> Result<()> {
    if args.repeats == 0 || args.steps == 0 {
        return Err(InputError("--repeats and --steps must be at least 1".into()).into());
    }
    // Nothing breaking: a random3d (or the chosen lattice's) block with a criterion no spring
    // reaches, against the same block without fracture.
    let lattice = bench_lattice(args)?;
    let kind = lattice.kind;
    let q = q_from_nu(kind, if kind.dim() == 3 { 0.3 } else { 0.45 })?;
    let (body, mut state, mut it) = bench_run(args, lattice, q)?;
    let mut fr =
        hooke_fracture::Fracture::new(&body, Box::new(hooke_fracture::CriticalStretch::new(1.0)?));
    let mut plain_state = state.clone();
    let mut plain_it = Integrator::resume(
        &body,
        &plain_state,
        Loading::default(),
        &bench_opts(args),
        &it.checkpoint(),
    )?;
    let steps = args.steps;
    let (with, without) = alternate(
        args.repeats,
        || {
            for _ in 0..steps {
                fr.step(&body, &mut state, &mut it, None);
            }
            Ok(())
        },
        || {
            for _ in 0..steps {
                plain_it.step(&body, &mut plain_state);
            }
            Ok(())
        },
    )?;
    if fr.broken_total > 0 {
        return Err(anyhow::anyhow!(
            "{} springs broke in the intact benchmark",
            fr.broken_total
        ));
    }
    let mut out = serde_json::json!({
        "lattice": kind.name(), "kernel": it.kernel.name(), "nodes": body.nodes(),
        "springs": body.springs(), "threads": rayon::current_num_threads(),
        "repeats": args.repeats, "steps": steps,
        "intact_seconds_per_step": without / steps as f64,
        "fracture_seconds_per_step": with / steps as f64,
        "fracture_overhead": with / without,
    });
    if let Some(case) = &args.case {
        let sim = hooke_case::load(case, args.scale).map_err(|e| InputError(e.to_string()))?;
        let mut sim = sim;
        let until = args.crack_time.unwrap_or(0.5 * sim.end_time);
        let body = &sim.body;
        let mut it = Integrator::new(body, &mut sim.state, sim.loading.clone(), &sim.options)?;
        let Some(mut fr) = sim.fracture.take() else {
            return Err(InputError(format!("{}: the case has no fracture", case.display())).into());
        };
        let mut state = sim.state.clone();
        while state.time < until {
            fr.step(body, &mut state, &mut it, None);
        }
        let before = fr.broken_total;
        // Without breaking: a copy of the same state and integrator, stepped on its own.
        let mut plain_state = state.clone();
        let mut plain_it = Integrator::resume(
            body,
            &plain_state,
            sim.loading.clone(),
            &sim.options,
            &it.checkpoint(),
        )?;
        let (with, without) = alternate(
            args.repeats,
            || {
                for _ in 0..steps {
                    fr.step(body, &mut state, &mut it, None);
                }
                Ok(())
            },
            || {
                for _ in 0..steps {
                    plain_it.step(body, &mut plain_state);
                }
                Ok(())
            },
        )?;
        out["case"] = serde_json::json!(case.display().to_string());
        out["case_nodes"] = serde_json::json!(body.nodes());
        out["case_kernel"] = serde_json::json!(it.kernel.name());
        out["crack_time"] = serde_json::json!(until);
        out["springs_broken_while_timed"] = serde_json::json!(fr.broken_total - before);
        out["case_intact_seconds_per_step"] = serde_json::json!(without / steps as f64);
        out["case_fracture_seconds_per_step"] = serde_json::json!(with / steps as f64);
        out["running_crack_overhead"] = serde_json::json!(with / without);
    }
    if args.json {
        println!("{out}");
    } else {
        println!(
            "{} lattice, {} kernel, {} nodes, {} threads, medians of {} alternating windows of {} steps:\n  stretch criterion, nothing breaking: {:.3} x the intact step ({:.3} vs {:.3} ms)",
            out["lattice"].as_str().unwrap_or(""), out["kernel"].as_str().unwrap_or(""), out["nodes"], out["threads"], args.repeats, steps,
            out["fracture_overhead"].as_f64().unwrap_or(0.0), with / steps as f64 * 1e3, without / steps as f64 * 1e3
        );
        if let Some(r) = out.get("running_crack_overhead").and_then(|v| v.as_f64()) {
            println!(
                "  running crack ({}, {} springs broken while timed): {:.3} x the step without breaking",
                out["case"].as_str().unwrap_or(""), out["springs_broken_while_timed"], r
            );
        }
    }
    Ok(())
}

fn bench_static(args: &BenchArgs) -> Result<()> {
    let mut rows = Vec::new();
    for nu in [-0.9, 0.3, 0.49] {
        let t = BlockTest::paper(LatticeKind::Cubic, nu);
        // Best of 3: the figure is the solver's, not the machine's noise.
        let mut best = f64::INFINITY;
        let mut last = None;
        for _ in 0..3 {
            let start = Instant::now();
            let r = block_test(&t)?;
            best = best.min(start.elapsed().as_secs_f64());
            last = Some(r);
        }
        let r = last.expect("ran three times");
        rows.push(serde_json::json!({
            "nu": nu, "seconds": best, "newton": r.solve.newton_iterations,
            "cg": r.solve.cg_iterations, "residual": r.solve.residual, "nodes": r.nodes,
        }));
        if !args.json {
            println!(
                "static solve, 71x16x16 block, nu = {nu:>5}: {best:.3} s ({} Newton, {} CG, residual {:.1e})",
                r.solve.newton_iterations, r.solve.cg_iterations, r.solve.residual
            );
        }
    }
    if args.json {
        println!(
            "{}",
            serde_json::json!({ "static_solve": rows, "threads": rayon::current_num_threads() })
        );
    }
    let _: Real = 0.0;
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

fn bench_frame(args: &BenchArgs) -> Result<()> {
    let Some(case) = &args.case else {
        return Err(InputError("--frame needs --case CASE.toml".into()).into());
    };
    if args.repeats == 0 || args.steps == 0 {
        return Err(InputError("--repeats and --steps must be at least 1".into()).into());
    }
    let text = std::fs::read_to_string(case)
        .map_err(|e| InputError(format!("{}: {e}", case.display())))?;
    let (mut sim, mut opts) =
        hooke_case::prepare(case, &text, args.scale, &[]).map_err(|e| InputError(e.to_string()))?;
    // Only the frames the benchmark asks for: none from the case's schedule inside a window.
    sim.output_every = Real::INFINITY;
    sim.checkpoint_every = Real::INFINITY;
    let out = std::env::temp_dir().join(format!("hooke-bench-frame-{}", std::process::id()));
    opts.out = out.clone();
    let until = args.crack_time.unwrap_or(0.5 * sim.end_time);
    let (nodes, springs) = (sim.body.nodes(), sim.body.springs());
    // What the windows measured, and what the run holds after them.
    struct Windows {
        with: f64,
        without: f64,
        call: f64,
        kernel: String,
        broken: usize,
        resident: Option<u64>,
        rows: bool,
    }
    let result = (|| -> Result<Windows> {
        let mut run = hooke_sim::Run::start(sim, opts)?;
        let mut quiet = hooke_sim::Silent;
        run.advance(until, &mut quiet)?;
        // Window A: a frame, --steps steps, and the wait for the frame's file; window B: the
        // same steps alone. A - B is what a frame adds to the run's wall time (the background
        // writer included); the frame call alone is what the stepping thread waits.
        let (mut ta, mut tb, mut tf) = (Vec::new(), Vec::new(), Vec::new());
        // Every window must take its steps: a run that reaches its end time stops stepping,
        // and windows of no steps would time nothing.
        let needed = 2 * args.repeats as u64 * args.steps;
        let left = run.simulation().end_time - run.simulation().state.time;
        let dt = run.integrator().dt;
        if (needed as Real) * dt > left {
            return Err(InputError(format!(
                "the windows need {needed} steps ({:.3e} s) but the case ends {left:.3e} s after --crack-time: use fewer --repeats or --steps, or an earlier --crack-time",
                needed as Real * dt
            ))
            .into());
        }
        for _ in 0..args.repeats {
            let t0 = Instant::now();
            run.frame()?;
            tf.push(t0.elapsed().as_secs_f64());
            run.steps(args.steps, &mut quiet)?;
            run.flush_outputs()?;
            ta.push(t0.elapsed().as_secs_f64());
            let t0 = Instant::now();
            run.steps(args.steps, &mut quiet)?;
            tb.push(t0.elapsed().as_secs_f64());
        }
        let kernel = run.integrator().kernel.name().to_string();
        let broken = run.simulation().broken().0;
        // What the run holds once it has written frames: a box on a stencil keeps no rows.
        let rows = run.simulation().body.lattice.bonds.is_built();
        let (a, b, f) = (median(&mut ta), median(&mut tb), median(&mut tf));
        Ok(Windows {
            with: a,
            without: b,
            call: f,
            kernel,
            broken,
            resident: resident_memory(),
            rows,
        })
    })();
    let _ = std::fs::remove_dir_all(&out);
    let Windows {
        with,
        without,
        call,
        kernel,
        broken,
        resident,
        rows,
    } = result?;
    let step = without / args.steps as f64;
    let cost = (with - without).max(0.0);
    let json = serde_json::json!({
        "case": case.display().to_string(), "nodes": nodes, "springs": springs,
        "kernel": kernel, "threads": rayon::current_num_threads(), "repeats": args.repeats,
        "steps": args.steps, "crack_time": until, "broken_springs": broken,
        "step_seconds": step, "frame_seconds": cost, "frame_call_seconds": call,
        "frame_over_step": cost / step, "resident_memory_bytes": resident,
        "resident_bytes_per_node": resident.map(|r| r as f64 / nodes as f64),
        "rows_built": rows,
    });
    if args.json {
        println!("{json}");
    } else {
        println!(
            "{} ({nodes} nodes, {broken} springs broken), {kernel} kernel, {} threads, medians of {} alternating windows of {} steps:\n  step {:.3} ms; a frame adds {:.3} ms = {:.2} steps to the run (the stepping thread waits {:.3} ms for it)",
            case.display(), rayon::current_num_threads(), args.repeats, args.steps, step * 1e3, cost * 1e3, cost / step, call * 1e3
        );
        if let Some(r) = resident {
            println!(
                "  resident after the frames: {:.1} bytes per node (the springs' rows {})",
                r as f64 / nodes as f64,
                if rows { "built" } else { "not built" }
            );
        }
    }
    Ok(())
}
