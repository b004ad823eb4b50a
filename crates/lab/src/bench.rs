//! The step benchmark's set-ups and measurements (`hooke bench`): the block each lattice is
//! timed on, the moving body and its integrator on the kernel asked for, the block set up from
//! parts by several processes, the timed steps with their memory and traffic, the cost of
//! switching contact on, and the dispersive law against plain springs. The command line parses
//! its flags into [`BenchOptions`] and prints the reports; nothing here prints.
//!
//! Speed is measured in unique spring-updates per second (each spring once per step). The
//! bodies are in lattice units (spacing 1, k = 1, masses 1) with a smooth velocity field, so
//! every spring does real work; the state's digest after the steps is the same for any thread
//! or process count exactly when the bits are.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result};
use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::team::{Piece, Team};
use hooke_core::{Body, Lattice, LatticeKind, Real, State};
use serde::{Deserialize, Serialize};

use crate::moduli::LatticeName;
use crate::InputError;

/// The force law a benchmark times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Law {
    /// Plain springs (q = 0, nu fixed at 1/4 or 1/3).
    Plain,
    /// The dispersive law (nu = 0.3 in 3D, 0.45 in 2D).
    #[default]
    Dispersive,
}

impl Law {
    /// The name the reports give.
    pub fn name(self) -> &'static str {
        match self {
            Law::Plain => "plain",
            Law::Dispersive => "dispersive",
        }
    }
}

/// Which kernel a benchmark runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum KernelChoice {
    /// The fastest kernel for the body (the vector stencil for cubic and hexagonal boxes, the
    /// row kernel for other lattices where the processor has AVX-512).
    #[default]
    Auto,
    /// The same kernel without vector instructions (the stencils' and the row kernel's
    /// portable paths).
    Portable,
    /// The general CSR kernel (random lattices without AVX-512; the row kernel gives its bits).
    Csr,
}

/// What a step benchmark times (the flags of `hooke bench` by the same names).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BenchOptions {
    /// Lattice of the block.
    pub lattice: LatticeName,
    /// Approximate number of nodes (a cube, or a square plate for hex).
    pub nodes: usize,
    pub law: Law,
    /// Timed steps (after 3 warm-up steps), or steps per window.
    pub steps: u64,
    pub kernel: KernelChoice,
    /// Weight the block's springs and nodes by their cells (regular lattices).
    pub cell_weights: bool,
    /// Windows per law or per variant of the alternating measurements.
    pub repeats: usize,
    /// Also time the steps with contact switched on ([`StepsReport::contact_overhead`]).
    pub contact: bool,
    /// Each rank keeps only its piece of the block (a team of 2 or more).
    pub pieces: bool,
    /// Set the block up from parts, each rank its own (random lattices).
    pub parts: bool,
    /// A block of two materials: the nodes with x past the middle four times as stiff, of
    /// another Poisson's ratio ([`hooke_core::phases`]; the CSR or row kernel).
    pub phases: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            lattice: LatticeName::Cubic,
            nodes: 1_000_000,
            law: Law::Dispersive,
            steps: 50,
            kernel: KernelChoice::Auto,
            cell_weights: false,
            repeats: 5,
            contact: false,
            pieces: false,
            parts: false,
            phases: false,
        }
    }
}

impl BenchOptions {
    /// Refuse what the step benchmark cannot time, naming the flag.
    pub fn check(&self) -> Result<(), InputError> {
        if self.parts && self.kernel == KernelChoice::Csr {
            return Err(InputError(
                "--parts times the steps alone: it takes none of --static-solve, --compare, \
                 --fracture, --frame, --contact, --export-lammps and --kernel csr"
                    .into(),
            ));
        }
        if (self.pieces || self.parts)
            && matches!(self.lattice, LatticeName::Cubic | LatticeName::Hex)
        {
            return Err(InputError(
                "--pieces and --parts split random lattices (--lattice random3d or random2d): a \
                 regular box's stencil kernel sweeps the whole box"
                    .into(),
            ));
        }
        if self.nodes < 27 || self.steps == 0 {
            return Err(InputError(format!(
                "--nodes {} --steps {}: give at least 27 nodes and 1 step",
                self.nodes, self.steps
            )));
        }
        Ok(())
    }
}

/// What sees the whole block before the steps: its body, state and time step.
pub type Export<'a> = dyn FnMut(&Body, &State, Real) -> Result<()> + 'a;

/// The step benchmark's result (`hooke bench --json`'s keys).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepsReport {
    pub law: String,
    pub lattice: String,
    /// Materials in the block: 1, or 2 with `--phases`.
    pub materials: usize,
    pub kernel: String,
    pub nodes: usize,
    pub springs: usize,
    pub steps: u64,
    pub threads: usize,
    pub seconds: f64,
    pub seconds_per_step: f64,
    pub spring_updates_per_s: f64,
    pub node_updates_per_s: f64,
    pub peak_memory_bytes: Option<u64>,
    /// Resident memory after the timed steps (the steady state: set-up scratch returned).
    pub resident_memory_bytes: Option<u64>,
    /// What the body, state, integrator and kernel hold on the heap, by part, in bytes per
    /// node (capacities: what was allocated, whether or not the system has paged it in).
    pub memory_parts: BTreeMap<String, f64>,
    /// Their sum, bytes per node.
    pub memory_bytes_per_node: f64,
    /// With --pieces: the nodes this rank holds (rank 0's: its own, its ghosts and the
    /// dummies that align its own on a chunk). `memory_parts` are still per node of the block.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub piece_nodes: Option<usize>,
    /// Digest of every node's displacement and velocity after the steps, in hexadecimal
    /// (`Integrator::state_digest`): the same for any number of ranks, with or without
    /// --pieces, exactly when the bits are.
    pub state_digest: String,
    pub setup_seconds: f64,
    /// Where the set-up's seconds went: the lattice (nodes, springs), the body (stiffnesses,
    /// masses, state) and the integrator (its stable-step estimate, mostly).
    pub setup_parts: BTreeMap<String, f64>,
    /// With --contact: step time with contact over step time without (medians of alternating
    /// windows).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_overhead: Option<f64>,
    /// MPI ranks sharing each step (`mpirun -np N hooke bench`, feature `mpi`), 1 alone.
    pub processes: usize,
    /// Bytes each rank receives per step (rank 0's figure: its ghosts' pools and
    /// displacements, and the partial sums), the point-to-point messages it sends per step
    /// (halo trades), its ghost nodes, and the collective operations per step; zero alone.
    pub halo_bytes_per_step: usize,
    pub halo_messages_per_step: usize,
    pub ghost_nodes: usize,
    pub collectives_per_step: usize,
}

/// The step benchmark, on this rank of a team or alone: set the block up, take 3 steps, time
/// `steps`, and report. `export`, if given, sees the whole body, state and time step before any
/// cut into pieces (the command line writes a LAMMPS data file there). Collective in a team.
pub fn steps(
    args: &BenchOptions,
    team: Option<Arc<dyn Team>>,
    export: Option<&mut Export<'_>>,
) -> Result<StepsReport> {
    args.check()?;
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
        from_parts(args, team.clone())?
    } else {
        let lattice = block(args)?;
        let lattice_seconds = setup.elapsed().as_secs_f64();
        let kind = lattice.kind;
        let nu = match (args.law, kind) {
            (Law::Plain, _) => hooke_core::material::nu_from_q(kind, 0.0),
            (Law::Dispersive, LatticeKind::Cubic | LatticeKind::Random3d) => 0.3,
            (Law::Dispersive, LatticeKind::Hex | LatticeKind::Random2d) => 0.45,
        };
        let (body, state, mut it, [body_seconds, integrator_seconds]) =
            moving_body(args, lattice, q_from_nu(kind, nu)?, team.clone())?;
        let setup_parts = setup_seconds_by_part(lattice_seconds, body_seconds, integrator_seconds);
        if let Some(export) = export {
            export(&body, &state, it.dt())?;
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
    let mut memory_parts = BTreeMap::new();
    for (name, b) in body
        .footprint()
        .into_iter()
        .chain(state.footprint())
        .chain(it.footprint())
    {
        *memory_parts.entry(name.to_string()).or_insert(0.0) += b as f64 / nodes as f64;
    }
    memory_parts.retain(|_, b| *b > 0.0);
    let memory_bytes_per_node = memory_parts.values().sum();
    Ok(StepsReport {
        law: args.law.name().into(),
        lattice: body.lattice.kind.name().into(),
        materials: if body.phase.is_some() { 2 } else { 1 },
        kernel: it.kernel().name().to_string(),
        nodes,
        springs,
        steps: args.steps,
        threads: rayon::current_num_threads(),
        seconds,
        seconds_per_step: seconds / args.steps as f64,
        spring_updates_per_s: springs as f64 * args.steps as f64 / seconds,
        node_updates_per_s: nodes as f64 * args.steps as f64 / seconds,
        peak_memory_bytes: hooke_sys::peak_memory(),
        resident_memory_bytes: hooke_sys::resident_memory(),
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
    })
}

/// The set-up's seconds by part, as the reports name them.
fn setup_seconds_by_part(lattice: f64, body: f64, integrator: f64) -> BTreeMap<String, f64> {
    [
        ("lattice", lattice),
        ("body", body),
        ("integrator", integrator),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// The step time with contact switched on (no fragments yet) over the time without, medians of
/// alternating windows: this machine's speed drifts by more than the figure we want.
pub fn contact_overhead(
    args: &BenchOptions,
    body: &Body,
    state: &mut State,
    it: &mut Integrator,
) -> f64 {
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

/// The block the benchmarks run on: about `nodes` nodes of `lattice` in lattice units.
pub fn block(args: &BenchOptions) -> Result<Lattice> {
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

/// The set-up from parts (`--parts`): the block of `random3d` or `random2d` as a jittered grid
/// (amplitude 0.6, seed 1) whose parts each rank samples, triangulates and numbers alone, the
/// body in lattice units on the piece, at rest, its integrator (the stable step estimated on
/// the pieces as one process estimates it), then moving as [`moving_body`] sets it. Alone, the team is one
/// process. Returns what `run` times, with the block's node and spring counts and the
/// set-up's seconds by part.
#[allow(clippy::type_complexity)]
pub fn from_parts(
    args: &BenchOptions,
    team: Option<Arc<dyn Team>>,
) -> Result<(Body, State, Integrator, usize, usize, BTreeMap<String, f64>)> {
    use hooke_core::random::part::Sampling;
    use hooke_core::random::{RandomSpec, Sampler};
    use hooke_core::team::parts::assemble;
    let team: Arc<dyn Team> = team.unwrap_or_else(|| Arc::new(hooke_core::team::Alone));
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
        (Law::Plain, _) => hooke_core::material::nu_from_q(kind, 0.0),
        (Law::Dispersive, 3) => 0.3,
        (Law::Dispersive, _) => 0.45,
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
        &integrator_options(args),
    )
    .context("setting up the integrator on the piece")?;
    for (i, _) in dummy.iter().enumerate().filter(|(_, &d)| !d) {
        let p = body.lattice.pos.get(i);
        state.v.x_mut()[i] = 1e-3 * (0.1 * p.y).sin();
        state.v.y_mut()[i] = 1e-3 * (0.13 * p.z + 0.07 * p.x).cos();
    }
    let integrator_seconds = start.elapsed().as_secs_f64();
    let parts = setup_seconds_by_part(lattice_seconds, body_seconds, integrator_seconds);
    Ok((body, state, it, nodes, springs, parts))
}

/// `--phases`: the block's nodes with x past the middle of material 2 (four times as stiff,
/// twice as dense, q of nu = 0.2, or 0 with `q` 0), the others of material 1 (`k` 1, `q`).
fn two_materials(lattice: Lattice, q: Real) -> Result<Body> {
    let kind = lattice.kind;
    let x = lattice.pos.x();
    let mid = 0.5 * x.iter().fold(0.0, |m: Real, &v| m.max(v));
    let node_phase: Vec<u8> = x.iter().map(|&v| u8::from(v > mid)).collect();
    let q2 = if q == 0.0 { 0.0 } else { q_from_nu(kind, 0.2)? };
    let one = Body::uniform(lattice.clone(), 1.0, q, 1.0);
    let two = Body::uniform(lattice.clone(), 4.0, q2, 2.0);
    let phases = vec![
        hooke_core::phases::Phase::of(one)?,
        hooke_core::phases::Phase::of(two)?,
    ];
    Ok(hooke_core::phases::assemble(lattice, phases, &node_phase)?)
}

/// A body on `lattice` in lattice units with ratio `q`, moving with a smooth velocity field (so
/// the springs do real work), and its integrator on the kernel `args` asks for.
pub fn moving(args: &BenchOptions, lattice: Lattice, q: Real) -> Result<(Body, State, Integrator)> {
    moving_body(args, lattice, q, None).map(|(b, s, i, _)| (b, s, i))
}

/// [`moving`], with the seconds spent on the body (and state) and on the integrator (its
/// stable-step estimate, mostly); with `team`, shared by its members and distributed.
pub fn moving_body(
    args: &BenchOptions,
    lattice: Lattice,
    q: Real,
    team: Option<Arc<dyn Team>>,
) -> Result<(Body, State, Integrator, [f64; 2])> {
    let start = Instant::now();
    let mut body = if args.phases {
        two_materials(lattice, q)?
    } else {
        Body::uniform(lattice, 1.0, q, 1.0)
    };
    if args.cell_weights {
        body = body
            .with_cell_weights()
            .context("--cell-weights (regular lattices only)")?;
    }
    // As a case's set-up does (hooke_sim's builder), once nothing more is built from them.
    body.lattice.shed_setup();
    // The CSR kernel, asked for where it would not run, streams the neighbours and the rest
    // lengths.
    if args.kernel == KernelChoice::Csr {
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
        &integrator_options(args),
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

/// The integrator options the kernel choice asks for.
pub fn integrator_options(args: &BenchOptions) -> IntegratorOptions {
    IntegratorOptions {
        portable: args.kernel == KernelChoice::Portable,
        force_csr: args.kernel == KernelChoice::Csr,
        ..Default::default()
    }
}

/// The median (the mean of the middle two for an even count).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The dispersive law against plain springs on the same block (`hooke bench --compare`):
/// alternating windows of `steps` steps, `repeats` per law, in one process.
pub fn compare(args: &BenchOptions) -> Result<CompareReport> {
    if args.repeats == 0 || args.steps == 0 {
        return Err(InputError("--repeats and --steps must be at least 1".into()).into());
    }
    let lattice = block(args)?;
    let kind = lattice.kind;
    // The dispersive law at the bench's Poisson's ratio against plain springs on the same
    // lattice (the plain lattice's own ratio: 1/4 in 3D, 1/3 in 2D).
    let nu = match kind {
        LatticeKind::Cubic | LatticeKind::Random3d => 0.3,
        LatticeKind::Hex | LatticeKind::Random2d => 0.45,
    };
    let mut runs = Vec::new();
    for q in [0.0, q_from_nu(kind, nu)?] {
        let (body, mut state, mut it) = moving(args, lattice.clone(), q)?;
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
    Ok(CompareReport {
        lattice: kind.name().into(),
        nodes: runs[0].0.nodes(),
        springs,
        threads: rayon::current_num_threads(),
        kernel: runs[1].2.kernel().name().to_string(),
        repeats: args.repeats,
        steps: args.steps,
        plain_seconds_per_step: plain,
        dispersive_seconds_per_step: disp,
        plain_spring_updates_per_s: springs as f64 / plain,
        dispersive_spring_updates_per_s: springs as f64 / disp,
        ratio_dispersive_over_plain: disp / plain,
    })
}

/// The dispersive law against plain springs (`hooke bench --compare --json`'s keys): medians
/// of the windows' seconds per step.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CompareReport {
    pub lattice: String,
    pub nodes: usize,
    pub springs: usize,
    pub threads: usize,
    pub kernel: String,
    pub repeats: usize,
    pub steps: u64,
    pub plain_seconds_per_step: f64,
    pub dispersive_seconds_per_step: f64,
    pub plain_spring_updates_per_s: f64,
    pub dispersive_spring_updates_per_s: f64,
    pub ratio_dispersive_over_plain: f64,
}

/// Medians of alternating windows: `a` and `b` each take `steps` steps per window.
pub fn alternate(
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

#[cfg(test)]
mod tests {
    use super::*;

    fn small(lattice: LatticeName) -> BenchOptions {
        BenchOptions {
            lattice,
            nodes: 3000,
            steps: 4,
            repeats: 1,
            ..Default::default()
        }
    }

    /// The report adds up: rates from the counts and seconds, memory per node from its parts,
    /// and the same digest for the same block whichever kernel path ran (the portable path is
    /// the reference the vector ones reproduce lane by lane).
    #[test]
    fn the_step_report_is_consistent_and_the_kernels_agree() {
        for lattice in [LatticeName::Cubic, LatticeName::Hex, LatticeName::Random3d] {
            let fast = steps(&small(lattice), None, None).unwrap();
            let rate = fast.springs as f64 * fast.steps as f64 / fast.seconds;
            assert!((fast.spring_updates_per_s / rate - 1.0).abs() < 1e-12);
            let sum: f64 = fast.memory_parts.values().sum();
            assert!((fast.memory_bytes_per_node - sum).abs() <= 1e-9 * sum);
            assert_eq!(fast.processes, 1);
            assert_eq!(fast.halo_bytes_per_step, 0);
            let portable = BenchOptions {
                kernel: KernelChoice::Portable,
                ..small(lattice)
            };
            let slow = steps(&portable, None, None).unwrap();
            assert_eq!(fast.state_digest, slow.state_digest, "{lattice:?}");
            assert_eq!((fast.nodes, fast.springs), (slow.nodes, slow.springs));
        }
    }

    /// The export sees the whole block once, before the steps.
    #[test]
    fn the_export_sees_the_block() {
        let mut seen = Vec::new();
        let mut export = |body: &Body, _: &State, dt: Real| -> Result<()> {
            seen.push((body.nodes(), dt));
            Ok(())
        };
        let r = steps(&small(LatticeName::Cubic), None, Some(&mut export)).unwrap();
        assert_eq!(seen.len(), 1);
        assert_eq!(seen[0].0, r.nodes);
        assert!(seen[0].1 > 0.0);
    }

    /// What the step benchmark cannot time is refused with the flag's name.
    #[test]
    fn bad_options_are_refused() {
        let bad = [
            BenchOptions {
                nodes: 5,
                ..Default::default()
            },
            BenchOptions {
                steps: 0,
                ..Default::default()
            },
            BenchOptions {
                parts: true,
                ..Default::default()
            },
            BenchOptions {
                pieces: true,
                lattice: LatticeName::Random3d,
                ..small(LatticeName::Random3d)
            },
        ];
        for o in bad {
            let e = steps(&o, None, None).unwrap_err();
            assert!(e.is::<InputError>(), "{o:?}: {e}");
            assert!(e.to_string().contains("--"), "{e}");
        }
        let r = compare(&BenchOptions {
            repeats: 0,
            ..Default::default()
        });
        assert!(r.unwrap_err().is::<InputError>());
    }

    /// The dispersive law's ratio is the ratio of the medians it reports.
    #[test]
    fn compare_reports_the_ratio_of_its_medians() {
        let r = compare(&small(LatticeName::Random3d)).unwrap();
        let ratio = r.dispersive_seconds_per_step / r.plain_seconds_per_step;
        assert!((r.ratio_dispersive_over_plain / ratio - 1.0).abs() < 1e-12);
        assert_eq!(r.repeats, 1);
    }
}
