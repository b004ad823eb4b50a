//! Errors of the fracture crate: each names the parameter and the fix.

use hooke_core::Real;

#[derive(Debug, thiserror::Error)]
pub enum FractureError {
    #[error("{what} = {value} is not usable: {fix}")]
    BadParameter {
        what: &'static str,
        value: Real,
        fix: &'static str,
    },
    #[error("pre-crack {index}: {why}")]
    BadCrack { index: usize, why: String },
    /// A toughness experiment that could not be set up or did not finish.
    #[error("{0}")]
    Experiment(String),
}
