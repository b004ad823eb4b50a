//! # hooke-core
//!
//! The solvers of hooke's mass-spring lattices with momentum dispersion (Kot and Nagahashi):
//! what advances, relaxes or measures a body of [`hooke_model`] with the kernels of
//! [`hooke_kernel`], and how several processes share that work.
//!
//! Modules:
//!
//! - [`dynamics`]: the explicit integrator (leapfrog with damping, loads, breaking decided by
//!   a criterion and committed here, the energy ledger; `dynamics::partition` holds everything
//!   that knows about ranks);
//! - [`stability`]: the stable step; [`statics`]: Newton-CG equilibrium; [`relax`]: dynamic
//!   relaxation;
//! - [`moduli`]: the paper's block test and the bulk tests; [`cube`]: the relaxed cube they
//!   and the anisotropic calibration measure on;
//! - [`frame`]: an output frame's derived fields (also under [`law`]);
//! - [`random`]: the random lattices, their calibration tables, and the calibration of
//!   anisotropic designs by measurement ([`random::anisotropic`]);
//! - [`team`]: sharing a step between processes; pieces and parts.
//!
//! Below it, re-exported under their old names so that every path stays:
//! `hooke-lattice` ([`lattice`], [`math`], [`error`], [`memory`]), `hooke-model`
//! ([`material`], [`anisotropy`], [`body`], [`state`], [`loading`], [`law`], [`tangent`])
//! and `hooke-kernel` ([`kernel`], which holds every `unsafe` block of the physics).
//!
//! Units: SI throughout. No I/O here.

// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![forbid(unsafe_code)]

pub use hooke_kernel as kernel;
pub use hooke_lattice::{error, lattice, math, memory};
pub use hooke_model::{anisotropy, body, loading, material, phases, state, tangent};

pub mod cube;
pub mod dynamics;
pub mod frame;
pub mod moduli;
pub mod random;
pub mod relax;
pub mod stability;
pub mod statics;
pub mod team;

#[cfg(test)]
mod anisotropy_tests;

/// The force law ([`hooke_model::law`]) with the frame's derived fields ([`frame`]).
pub mod law {
    pub use crate::frame::*;
    pub use hooke_model::law::*;
}

pub use anisotropy::{Anisotropic, Orthotropic, Transverse};
pub use body::Body;
pub use error::{Error, Result};
pub use lattice::{Cells, Lattice, LatticeKind};
pub use material::{Elastic, PlaneModel, SpringConstants};
pub use math::{Coords, Matrix, Real, Vector};
pub use random::anisotropic::Designs;
pub use state::State;
pub use tangent::Tangent;
