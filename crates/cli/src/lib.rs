//! The `hooke` command line, as a library so that tests can call [`run`] directly.

mod bench;
mod moduli;
#[cfg(feature = "mpi")]
mod mpi;
mod plot;
mod run;
mod toughness;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// hooke: elastic solids and their fracture with mass-spring lattices of any Poisson's ratio.
#[derive(Debug, Parser)]
#[command(name = "hooke", version, about, long_about = None)]
pub struct Cli {
    /// Worker threads (default: all cores, shared among the MPI ranks of a machine). Results do
    /// not depend on it.
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// The paper's Section 4 block test: measure E and nu of a lattice block under an axial
    /// strain and compare them with theory.
    Moduli(moduli::ModuliArgs),
    /// Throughput of explicit steps on a block (unique spring-updates per second), or with
    /// --static the solve time of the paper's block.
    Bench(bench::BenchArgs),
    /// Run a case file (TOML): VTK frames, energy history and checkpoints in the output folder.
    Run(run::RunArgs),
    /// Measure the fracture energy a lattice crack dissipates (a strip under fixed grips) and
    /// compare it with the G_c calibration; --table regenerates the calibration table.
    Toughness(toughness::ToughnessArgs),
    /// Validate a case file and print what would run: nodes, springs, k and q, dt, memory,
    /// expected time.
    Check(run::CheckArgs),
}

/// An error in what the user asked for (exit code 2), as opposed to a run failure (exit 1).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

/// Exit code for an error: 2 for bad input anywhere in the chain, 130 for Ctrl-C, 1 otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if cause.is::<run::Interrupted>() {
            return 130;
        }
        if cause.is::<InputError>() {
            return 2;
        }
        if let Some(e) = cause.downcast_ref::<hooke_sim::Error>() {
            return match e {
                hooke_sim::Error::Interrupted { .. } => 130,
                e if e.is_input() => 2,
                _ => 1,
            };
        }
        if let Some(core) = cause.downcast_ref::<hooke_core::Error>() {
            return if core.is_input_error() { 2 } else { 1 };
        }
    }
    1
}

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// This process is an MPI rank other than 0: rank 0 prints for the run (messages, errors and
/// the summary would otherwise appear once per rank).
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

fn set_quiet() {
    QUIET.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Processes per machine when started by an MPI launcher (Open MPI, MPICH), so that ranks on
/// one machine share its cores rather than each taking all of them.
fn local_ranks() -> Option<usize> {
    ["OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .find_map(|k| std::env::var(k).ok()?.parse().ok())
        .filter(|&n: &usize| n > 0)
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let threads = match cli.threads {
        Some(0) => return Err(InputError("--threads 0: give at least 1 thread".into()).into()),
        Some(t) => t,
        // Under an MPI launcher: the machine's cores shared by its ranks.
        None => local_ranks().map_or(0, |ranks| {
            let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
            (cores / ranks).max(1)
        }),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    pool.install(|| match cli.command {
        Command::Moduli(args) => moduli::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Run(args) => run::run(args),
        Command::Check(args) => run::check(args),
        Command::Toughness(args) => toughness::run(args),
    })
}

/// `hooke moduli FLAGS --json`'s object as a value, for callers in other languages (the Python
/// package): `flags` are the command's own, e.g. `["--lattice", "cubic", "--nu", "0.3"]`, so
/// the keys and the numbers are the command's exactly. Bad flags are an [`InputError`] with
/// clap's message.
pub fn moduli_json(flags: &[String]) -> Result<serde_json::Value> {
    match parse_command("moduli", flags)? {
        Command::Moduli(args) => moduli::value(&args),
        _ => unreachable!("parsed as the moduli command"),
    }
}

/// `hooke toughness FLAGS --json`'s object (one `--nu`) as a value, like [`moduli_json`].
pub fn toughness_json(flags: &[String]) -> Result<serde_json::Value> {
    match parse_command("toughness", flags)? {
        Command::Toughness(args) => toughness::value(&args),
        _ => unreachable!("parsed as the toughness command"),
    }
}

fn parse_command(name: &str, flags: &[String]) -> Result<Command> {
    let argv = ["hooke", name]
        .into_iter()
        .map(String::from)
        .chain(flags.iter().cloned());
    Ok(Cli::try_parse_from(argv)
        .map_err(|e| InputError(e.to_string()))?
        .command)
}
