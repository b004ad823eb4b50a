//! Typed errors of the core. Each message names what was wrong and how to fix it.

use crate::math::Real;

/// Everything the core can refuse or fail at.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A material or model parameter is outside what the model can represent.
    #[error("{what} = {value} is out of range: {why}")]
    OutOfRange {
        what: &'static str,
        value: Real,
        why: String,
    },

    /// A size, count or geometric input is unusable.
    #[error("invalid {what}: {why}")]
    InvalidInput { what: &'static str, why: String },

    /// An iterative solver stopped before reaching its tolerance.
    #[error(
        "{solver} did not converge: relative residual {residual:.3e} after {iterations} iterations \
         (tolerance {tolerance:.1e}); {hint}"
    )]
    NotConverged {
        solver: &'static str,
        iterations: usize,
        residual: Real,
        tolerance: Real,
        hint: &'static str,
    },

    /// The tangent stiffness is not positive definite along a search direction: the structure
    /// buckles or a mechanism is not held by the boundary conditions.
    #[error(
        "the tangent stiffness is not positive definite (curvature {curvature:.3e} at Newton \
         iteration {newton}, CG iteration {cg}): the body buckles or has an unconstrained \
         mechanism; use a smaller load step or fix the free motion"
    )]
    NotPositiveDefinite {
        curvature: Real,
        newton: usize,
        cg: usize,
    },

    /// A requested time step exceeds the stability limit of the explicit integrator.
    #[error(
        "time step dt = {dt:.4e} s exceeds the stability limit {limit:.4e} s (2/sqrt(lambda_max) = \
         {critical:.4e} s times the safety factor {safety}); use dt <= {limit:.4e} s, or force it \
         if you know better"
    )]
    TimeStepTooLarge {
        dt: Real,
        limit: Real,
        critical: Real,
        safety: Real,
    },

    /// The explicit run blew up.
    #[error(
        "the run became unstable at step {step} (t = {time:.6e} s): node {node} {reason}; {hint}"
    )]
    Unstable {
        step: u64,
        time: Real,
        node: usize,
        reason: String,
        hint: &'static str,
    },
}

impl Error {
    /// True when the error is the user's input (exit code 2), false for a run failure (exit 1).
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            Error::OutOfRange { .. } | Error::InvalidInput { .. } | Error::TimeStepTooLarge { .. }
        )
    }
}

/// Result with the core's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;
