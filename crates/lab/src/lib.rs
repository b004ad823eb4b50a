//! hooke-lab: the measurement science, as experiments with typed options and results.
//!
//! The command line (`hooke moduli`, `hooke toughness`) and the Python package call the same
//! functions with the same options, so a figure is the same from either. Nothing here prints:
//! long experiments report their progress through a callback.
//!
//! - [`moduli`]: the paper's Section 4 block test and the exact and relaxed bulk tests, their
//!   ensembles over random node sets, the relaxed-bulk extrapolation and the tensor statistics,
//!   and the random lattices' calibration table (`hooke_core::random::calibration`).
//! - [`bench`](mod@bench): the step benchmark's blocks and set-ups (alone, shared, from parts), the timed
//!   steps with memory and traffic, contact's cost, and the dispersive law against plain
//!   springs (`hooke bench`).
//! - [`overhead`]: what a fracture criterion, a running crack, an output frame and the static
//!   solver cost against a step (`hooke bench --fracture`, `--frame`, `--static`).
//! - [`toughness`]: the fracture energy a lattice crack dissipates in a strip under fixed grips,
//!   the strip's size per lattice, the mean over node sets, and the G_c calibration tables
//!   (`hooke_fracture::stretch`, `energy`, `softening`).
#![forbid(unsafe_code)]

pub mod bench;
pub mod laminate;
pub mod moduli;
pub mod overhead;
pub mod toughness;

/// An error in what the caller asked for (the command line exits with 2), as opposed to a
/// failed experiment. Its message names the flag (`--samples 0: ...`), which is also the name
/// of the option.
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}
