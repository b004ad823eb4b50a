//! # hooke-model
//!
//! The model of a hooke body, with no solver in it: what each spring and node is made of, and
//! the force law of Kot and Nagahashi's *momentum dispersion* ("Second degree of freedom of
//! elastic objects: adjustable Poisson's ratio for mass spring models"). A plain central-spring
//! lattice has nu = 1/4 (3D) or 1/3 (2D); here every node collects part of its springs' load in
//! a pool and spreads it back over all its springs in proportion to their length, which adds a
//! pressure-like modulus B (paper eqs. 5-8).
//!
//! Modules:
//!
//! - [`material`]: (E, nu) to the spring constants (k, q), per lattice kind;
//! - [`anisotropy`]: transversely isotropic and orthotropic materials by direction-weighted
//!   dispersion (their calibration on random lattices measures, so it is the solver crate's);
//! - [`random`]: the random lattices' geometry ([`hooke_lattice::random`], re-exported) with
//!   their measured calibration tables ([`random::calibration`]);
//! - [`body`]: a lattice with its constants (immutable during a run);
//! - [`phases`]: bodies of several materials (a phase per node, the interface springs in
//!   series, a dispersion ratio per node);
//! - [`state`]: everything that changes, with the spring masks and normalisers kept
//!   consistent, and the kernels' scratch;
//! - [`loading`]: prescribed motion, tractions, body force;
//! - [`law`]: the reference force law, its energy and the frame's derived fields;
//! - [`tangent`]: the law's exact stiffness, matrix-free.
//!
//! The geometry below is `hooke-lattice` (re-exported as [`lattice`], [`math`], [`error`],
//! [`memory`]); the kernels (`hooke-kernel`) and the solvers (`hooke-core`) build on this crate.
//! Units: SI throughout. No I/O, no `unsafe`.

// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![forbid(unsafe_code)]

pub use hooke_lattice::{error, lattice, math, memory, CHUNK};

pub mod anisotropy;
pub mod body;
pub mod law;
pub mod loading;
pub mod material;
pub mod phases;
pub mod state;
pub mod tangent;

/// Random lattices: their geometry ([`hooke_lattice::random`]) and the calibration of their
/// spring constants against the target moduli.
pub mod random {
    pub use hooke_lattice::random::*;

    pub mod calibration;
}

pub use anisotropy::{Anisotropic, Orthotropic, Transverse};
pub use body::Body;
pub use error::{Error, Result};
pub use material::{Elastic, PlaneModel, SpringConstants};
pub use state::State;
pub use tangent::Tangent;
