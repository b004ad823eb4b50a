//! # hooke-case
//!
//! Case files (TOML, SI units) to simulations, in three stages: the raw serde schema with unknown
//! keys refused ([`schema`]), validation with errors that name the file, line, column and key and
//! say how to fix it, and the builder that makes the body, state, loading, fracture and solver
//! options ([`Simulation`]). The keys are documented in `docs/case-format.md`.

pub mod error;
pub mod schema;

mod build;
mod overrides;

pub use build::{load, load_str, load_str_with, Simulation};
pub use error::CaseError;
pub use overrides::{parse_overrides, physics_text, Override};
