//! The `hooke` command line, as a library so that tests can call [`run`] directly. It parses,
//! prints and exits; the logic is the libraries'.
//!
//! Modules: `run` (`hooke run` and `hooke check`: case files through `hooke-case`, runs
//! through `hooke-sim`, the progress bar and summaries), `moduli` and `toughness` (flags into
//! `hooke-lab`'s options, tables and plots), `bench` (timing the step), `plot`, and `mpi` (the
//! `mpi` feature: the team's collectives over rsmpi, and ending the job when a rank fails).

// `unsafe` only where the MPI communicator is shared between threads (`mpi`).
#![deny(unsafe_code)]

mod bench;
mod moduli;
#[cfg(feature = "mpi")]
#[allow(unsafe_code)]
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

/// An error in what the user asked for (exit code 2), as opposed to a run failure (exit 1): the
/// library's, so that its experiments' input errors exit with 2 too.
pub use hooke_lab::InputError;

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

/// The cores this process may run on (its CPU affinity, which a launcher's binding narrows)
/// and the cores of the machine.
fn cores() -> (usize, usize) {
    let usable = std::thread::available_parallelism().map_or(1, |c| c.get());
    (usable, hooke_sys::online_cores(usable))
}

/// Threads of a rank under an MPI launcher, `ranks` processes on a machine of `machine` cores
/// of which the rank may use `usable` (its binding): its share of the machine, but no more than
/// its binding leaves it. Launchers bind ranks: Open MPI to a core when there are at most two,
/// to a socket beyond; `mpirun --map-by slot:PE=T` and `srun --cpus-per-task=T` to T cores. An
/// unbound rank sees the whole machine and shares it; several ranks bound to one socket share
/// that socket's cores through the share.
fn launcher_threads(ranks: usize, usable: usize, machine: usize) -> usize {
    (machine / ranks).max(1).min(usable)
}

/// Why a process runs fewer or more threads than suit its cores, if it does: a rank bound to
/// fewer cores than its share of the machine leaves cores idle; `--threads` beyond the usable
/// cores makes threads take turns.
fn threads_note(
    asked: Option<usize>,
    ranks: Option<usize>,
    usable: usize,
    machine: usize,
) -> Option<String> {
    match (asked, ranks) {
        (Some(t), _) if t > usable && usable == machine => Some(format!(
            "note: --threads {t} on this machine's {machine} core(s): threads take turns on them"
        )),
        (Some(t), _) if t > usable => Some(format!(
            "note: --threads {t} on {usable} usable core(s) of this machine's {machine} (the \
             process's CPU binding): threads take turns on them"
        )),
        (None, Some(ranks)) if ranks > machine => Some(format!(
            "note: {ranks} MPI ranks on this machine's {machine} core(s): the ranks take turns on \
             the cores, one thread each, and every step waits for the slowest. Start at most \
             {machine} rank(s) per machine for speed (more only to test a split)"
        )),
        (None, Some(ranks)) if usable < (machine / ranks).max(1) => {
            let share = (machine / ranks).max(1);
            Some(format!(
                "note: the MPI launcher binds each rank to {usable} of this machine's {machine} \
                 cores, where a rank's share is {share}: {} core(s) stay idle. Bind each rank to \
                 {share} cores (Open MPI: mpirun --map-by slot:PE={share}; Slurm: srun \
                 --cpus-per-task={share}) or leave ranks unbound (mpirun --bind-to none)",
                machine - usable * ranks
            ))
        }
        _ => None,
    }
}

/// Whether this process is rank 0 of an MPI launch, or not launched by one (known before MPI
/// starts, from the launchers' environment).
fn first_rank() -> bool {
    [
        "OMPI_COMM_WORLD_RANK",
        "PMIX_RANK",
        "PMI_RANK",
        "SLURM_PROCID",
    ]
    .iter()
    .find_map(|k| std::env::var(k).ok())
    .is_none_or(|r| r.trim() == "0")
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let (usable, machine) = cores();
    let ranks = local_ranks();
    let threads = match cli.threads {
        Some(0) => return Err(InputError("--threads 0: give at least 1 thread".into()).into()),
        Some(t) => t,
        // Under an MPI launcher: the machine's cores shared by its ranks.
        None => ranks.map_or(0, |ranks| launcher_threads(ranks, usable, machine)),
    };
    if let Some(note) = threads_note(cli.threads, ranks, usable, machine) {
        if first_rank() {
            eprintln!("{note}");
        }
    }
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

#[cfg(test)]
mod tests {
    use super::{launcher_threads, threads_note};

    /// A rank's threads under a launcher: its share of the machine, within its binding.
    #[test]
    fn ranks_take_their_share_within_their_binding() {
        // Unbound: the machine shared by its ranks.
        assert_eq!(launcher_threads(2, 16, 16), 8);
        assert_eq!(launcher_threads(32, 32, 32), 1);
        // Bound to a core each (Open MPI's default for np <= 2).
        assert_eq!(launcher_threads(2, 1, 16), 1);
        assert_eq!(launcher_threads(2, 1, 2), 1);
        // Bound to PE = 8 cores each: all of them (the rank's share of the machine).
        assert_eq!(launcher_threads(2, 8, 16), 8);
        // Four ranks bound to a socket of 8 cores each, two per socket: 4 each.
        assert_eq!(launcher_threads(4, 8, 16), 4);
        // Sixteen ranks per socket: one thread each, not a socket's worth.
        assert_eq!(launcher_threads(32, 16, 32), 1);
        // More ranks than cores: still one thread.
        assert_eq!(launcher_threads(4, 2, 2), 1);
    }

    /// The notes: idle cores under a narrow binding, threads beyond the usable cores; none
    /// where threads and cores match.
    #[test]
    fn mismatched_threads_and_cores_are_noted() {
        let idle = threads_note(None, Some(2), 1, 16).expect("14 idle cores");
        assert!(idle.contains("14 core(s) stay idle"), "{idle}");
        assert!(
            idle.contains("PE=8") && idle.contains("--cpus-per-task=8"),
            "{idle}"
        );
        let turns = threads_note(Some(4), None, 2, 2).expect("4 threads on 2 cores");
        assert!(
            turns.contains("--threads 4 on this machine's 2 core(s)"),
            "{turns}"
        );
        let bound = threads_note(Some(4), Some(2), 1, 2).expect("4 threads on 1 core");
        assert!(
            bound.contains("on 1 usable core(s) of this machine's 2"),
            "{bound}"
        );
        let over = threads_note(None, Some(3), 1, 2).expect("3 ranks on 2 cores");
        assert!(
            over.contains("3 MPI ranks") && over.contains("at most 2 rank(s)"),
            "{over}"
        );
        assert_eq!(threads_note(None, Some(2), 1, 2), None);
        assert_eq!(threads_note(None, Some(2), 8, 16), None);
        assert_eq!(threads_note(Some(2), Some(2), 8, 16), None);
        assert_eq!(threads_note(None, None, 2, 2), None);
    }
}
