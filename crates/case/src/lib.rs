//! # hooke-case
//!
//! Case files (TOML, SI units) to simulations, in three stages: the raw serde schema with unknown
//! keys refused ([`schema`]), validation with errors that name the file, line, column and key and
//! say how to fix it, and the builder that makes the body, state, loading, fracture and solver
//! options ([`Simulation`]). The keys are documented in `docs/case-format.md`.
#![forbid(unsafe_code)]
// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod error;
pub mod schema;

mod build;
mod overrides;

pub use build::{load, load_parts, load_str, load_str_with, Simulation};
pub use error::CaseError;
pub use overrides::{parse_overrides, physics_text, Override};

/// A case ready to run: the simulation, and the run options that make its output, checkpoint
/// and `run.json` the same whoever runs it (the command line, the Python package): the digest
/// of its physics (`--set` overrides and `scale` included; what a resumed checkpoint must
/// match) and the physics lines `run.json` keeps. `out`, `name`, `command` and `resume` are the
/// caller's to fill in.
pub fn prepare(
    path: &std::path::Path,
    text: &str,
    scale: hooke_core::Real,
    overrides: &[Override],
) -> Result<(Simulation, hooke_sim::RunOptions), CaseError> {
    prepare_parts(path, text, scale, overrides, None)
}

/// [`prepare`], the body set up from parts shared by `parts` if given (each process builds
/// and holds only its piece: [`load_parts`]); the run options then name the team and hold
/// pieces. Collective with a team.
pub fn prepare_parts(
    path: &std::path::Path,
    text: &str,
    scale: hooke_core::Real,
    overrides: &[Override],
    parts: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<(Simulation, hooke_sim::RunOptions), CaseError> {
    let sim = load_parts(path, text, scale, overrides, parts.clone())?;
    let physics = format!(
        "{}scale = {scale:e}\n",
        physics_text(path, text, overrides)?
    );
    let opts = hooke_sim::RunOptions {
        digest: hooke_io::checkpoint::digest(physics.as_bytes()),
        case_text: text.to_string(),
        physics,
        pieces: parts.is_some(),
        team: parts,
        ..Default::default()
    };
    Ok((sim, opts))
}
