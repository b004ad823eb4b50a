//! MPI ranks as a [`Team`] (feature `mpi`): `mpirun -np N hooke run CASE.toml`.
//!
//! The library does the sharing (`hooke_core::team`); this module only carries its three
//! operations over MPI: an in-place all-gather of doubles (`MPI_Allgatherv`), a logical or of
//! flags (`MPI_Allreduce` with `MPI_LOR`) and the halo trade (`MPI_Isend` and `MPI_Recv`
//! between the ranks that share a cut).

use std::ops::Range;
use std::sync::{Arc, Mutex};

use hooke_core::team::Team;
use hooke_core::Real;
use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;

/// MPI_COMM_WORLD of a run, with the scratch its collectives reuse (nothing is allocated per
/// step once the first step has sized it).
pub struct MpiTeam {
    world: SimpleCommunicator,
    rank: usize,
    size: usize,
    scratch: Mutex<Scratch>,
}

#[derive(Default)]
struct Scratch {
    send: Vec<Real>,
    flags: Vec<bool>,
    /// Counts and displacements of the part lists seen so far (a run uses a few).
    layouts: Vec<Layout>,
}

/// A part list of an all-gather with its counts and displacements.
type Layout = (Vec<Range<usize>>, Vec<Count>, Vec<Count>);

// SAFETY: the communicator is a handle that MPI itself owns. hooke calls the collectives from
// the run's driver only, one at a time (rayon's workers never reach them), which is the
// `MPI_THREAD_SERIALIZED` contract asked for at initialisation.
unsafe impl Send for MpiTeam {}
// SAFETY: as above; the scratch is behind a mutex.
unsafe impl Sync for MpiTeam {}

impl std::fmt::Debug for MpiTeam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MpiTeam {{ rank: {}, size: {} }}", self.rank, self.size)
    }
}

impl Team for MpiTeam {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn gather(&self, data: &mut [Real], parts: &[Range<usize>]) {
        assert!(
            hooke_core::team::parts_fit(parts, self.size, data.len()),
            "all-gather parts {parts:?} over {} values are not one per rank, ascending and disjoint",
            data.len()
        );
        let mut guard = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let s = &mut *guard;
        let k = match s.layouts.iter().position(|l| l.0 == parts) {
            Some(k) => k,
            None => {
                let counts = parts.iter().map(|p| p.len() as Count).collect();
                let displs = parts.iter().map(|p| p.start as Count).collect();
                s.layouts.push((parts.to_vec(), counts, displs));
                s.layouts.len() - 1
            }
        };
        let mine = parts[self.rank].clone();
        s.send.clear();
        s.send.extend_from_slice(&data[mine]);
        let (_, counts, displs) = &s.layouts[k];
        let mut recv = PartitionMut::new(data, &counts[..], &displs[..]);
        self.world.all_gather_varcount_into(&s.send[..], &mut recv);
    }

    fn any(&self, flags: &mut [bool]) {
        let mut guard = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let s = &mut *guard;
        s.flags.clear();
        s.flags.extend_from_slice(flags);
        self.world
            .all_reduce_into(&s.flags[..], flags, SystemOperation::logical_or());
    }

    fn trade(&self, out: &[Vec<Real>], inp: &mut [Vec<Real>]) {
        // Round k pairs each rank with the one k after it (to send) and k before it (to
        // receive), so every ordered pair meets in exactly one round and no receive waits on a
        // send that is not already posted. Every rank knows every message's length (the halo is
        // computed alike everywhere), so an empty one is neither sent nor awaited.
        let (rank, size) = (self.rank, self.size);
        for k in 1..size {
            let (to, from) = ((rank + k) % size, (rank + size - k) % size);
            mpi::request::scope(|scope| {
                let sent = (!out[to].is_empty()).then(|| {
                    self.world
                        .process_at_rank(to as i32)
                        .immediate_send(scope, &out[to][..])
                });
                if !inp[from].is_empty() {
                    self.world
                        .process_at_rank(from as i32)
                        .receive_into(&mut inp[from][..]);
                }
                if let Some(r) = sent {
                    r.wait();
                }
            });
        }
    }
}

/// How long a rank whose run failed waits for the others to fail alike before it ends the
/// job: ranks that fail alike (bad input, an instability, Ctrl-C) reach the end together, within
/// a moment of each other; a rank that fails alone would otherwise leave the others waiting in
/// their next collective for ever.
const AGREE: std::time::Duration = std::time::Duration::from_secs(5);

/// The exit code of a job ended by a panic (Rust's own for a panicking process).
const PANIC_CODE: i32 = 101;

/// MPI for one `hooke run` or `hooke bench`: the universe (MPI is finalised when it is
/// dropped), the team (`None` for a single process), and a communicator of its own for the
/// agreement at the end ([`Mpi::finish`]), so that it can never match a collective of the run.
pub struct Mpi {
    pub team: Option<Arc<dyn Team>>,
    agree: Option<SimpleCommunicator>,
    rank: usize,
    size: usize,
    // Last: finalised after the communicators above are freed.
    _universe: mpi::environment::Universe,
}

/// Initialise MPI. Started by `mpirun -np N`, the team has N members; started alone, none.
///
/// In a team, a panic on any rank (in the driver or in a worker thread) prints the rank and
/// its message, then aborts the whole job (`MPI_Abort`): unwinding would finalise MPI, which
/// waits for ranks that wait in a collective for this one. A rank killed by a signal is seen by
/// `mpirun`, which ends the others.
pub fn start() -> anyhow::Result<Mpi> {
    let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Serialized)
        .ok_or_else(|| anyhow::anyhow!("MPI was already initialised in this process"))?;
    let world = universe.world();
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let agree = (size > 1).then(|| world.duplicate());
    if size > 1 {
        std::panic::set_hook(Box::new(move |info| {
            let at = info
                .location()
                .map_or(String::new(), |l| format!(" at {}:{}", l.file(), l.line()));
            let p = info.payload();
            let what = p
                .downcast_ref::<&str>()
                .copied()
                .or_else(|| p.downcast_ref::<String>().map(String::as_str))
                .unwrap_or("(no message)");
            eprintln!(
                "error: rank {rank} of {size} panicked{at}: {what}\n  ending every rank of the job (MPI_Abort)"
            );
            SimpleCommunicator::world().abort(PANIC_CODE);
        }));
    }
    let team: Option<Arc<dyn Team>> = (size > 1).then(|| {
        Arc::new(MpiTeam {
            world,
            rank,
            size,
            scratch: Mutex::new(Scratch::default()),
        }) as Arc<dyn Team>
    });
    Ok(Mpi {
        team,
        agree,
        rank,
        size,
        _universe: universe,
    })
}

impl Mpi {
    /// Called on every rank when its run has ended, with its error if it failed. A success, or a failure
    /// that every rank meets (they reach a barrier of their own within [`AGREE`]), ends as
    /// usual: MPI is finalised and rank 0 reports. A failure on this rank that the others do
    /// not share (they are still running, or waiting in a collective for this rank) is
    /// printed with the rank and ends the whole job with the failure's exit code.
    pub fn finish(&self, error: Option<&anyhow::Error>) {
        let (Some(agree), Some(e)) = (&self.agree, error) else {
            return;
        };
        let mut barrier = agree.immediate_barrier();
        let deadline = std::time::Instant::now() + AGREE;
        loop {
            match barrier.test() {
                Ok(_) => return,
                Err(pending) => barrier = pending,
            }
            if std::time::Instant::now() >= deadline {
                eprintln!(
                    "error: rank {} of {}: {e:#}\n  the other ranks did not stop with it: ending every rank of the job (MPI_Abort)",
                    self.rank, self.size
                );
                SimpleCommunicator::world().abort(crate::exit_code(e) as i32);
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
}

impl Drop for Mpi {
    fn drop(&mut self) {
        // A panic after MPI is finalised must not call MPI_Abort: the default hook again.
        if self.size > 1 {
            let _ = std::panic::take_hook();
        }
    }
}

/// Run `go` on this rank of the job `mpirun` started (alone: with no team), with MPI's
/// failure handling ([`start`], [`Mpi::finish`]).
pub fn run<T>(go: impl FnOnce(Option<Arc<dyn Team>>) -> anyhow::Result<T>) -> anyhow::Result<T> {
    let mpi = start()?;
    let result = go(mpi.team.clone());
    if let Err(e) = &result {
        if mpi.team.is_some() && !crate::quiet() {
            // Rank 0 says why before MPI is finalised: the other ranks wait in MPI_Finalize
            // for it, whereas once they have exited with an error the launcher may kill rank 0
            // before main() prints.
            eprintln!("error: {e:#}");
            crate::set_quiet();
        }
    }
    mpi.finish(result.as_ref().err());
    drop(mpi);
    result
}
