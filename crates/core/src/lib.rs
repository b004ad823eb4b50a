//! # hooke-core
//!
//! Mass-spring lattices whose Poisson's ratio is a free parameter: the *momentum dispersion* of
//! Kot and Nagahashi ("Second degree of freedom of elastic objects: adjustable Poisson's ratio
//! for mass spring models"). A plain central-spring lattice has nu = 1/4 (3D) or 1/3 (2D); here
//! every node collects part of its springs' load in a pool and spreads it back over all its
//! springs in proportion to their length, which adds a pressure-like modulus B (paper eqs. 5-8)
//! at the cost of one extra gather per step and no extra elements.
//!
//! Modules, by reason to change:
//!
//! - geometry and topology, the crate `hooke-lattice` re-exported: [`math`] (scalar and vector
//!   types), [`lattice`] (positions and CSR topology, immutable), [`random`] (Poisson-disk and
//!   jittered nodes, Delaunay springs, parts; here with the calibrations below);
//! - material mapping: [`material`] ((E, nu) to (k, q)), [`anisotropy`] (transversely isotropic
//!   and orthotropic materials by direction-weighted dispersion), `random::calibration` and
//!   `random::anisotropic` (the random lattices' measured tables and designs);
//! - body, state, loads and law: [`body`] (a lattice with its constants), [`state`] (everything
//!   that changes), [`loading`], [`law`] (the force law and its energy), [`tangent`] (its exact
//!   stiffness, matrix-free);
//! - kernels: [`kernel`] (the explicit step's sweeps; every `unsafe` block of this crate);
//! - solvers: [`dynamics`] (the explicit integrator), [`stability`] (the stable step),
//!   [`statics`] (Newton-CG equilibrium), [`relax`] (dynamic relaxation), [`moduli`] (the
//!   paper's block test and the bulk tests);
//! - decomposition: [`team`] (sharing a step between processes; pieces and parts);
//! - plumbing, from `hooke-lattice` too: [`error`], [`memory`] (what the arrays hold).
//!
//! Units: SI throughout. No I/O here.

// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// `unsafe` only in the SIMD kernels (`kernel`), each block with its SAFETY comment.
#![deny(unsafe_code)]

pub use hooke_lattice::{error, lattice, math, memory};

pub mod anisotropy;
pub mod body;
pub mod dynamics;
#[allow(unsafe_code)]
pub mod kernel;
pub mod law;
pub mod loading;
pub mod material;
pub mod moduli;
pub mod random;
pub mod relax;
pub mod stability;
pub mod state;
pub mod statics;
pub mod tangent;
pub mod team;

pub use anisotropy::{Anisotropic, Orthotropic, Transverse};
pub use body::Body;
pub use error::{Error, Result};
pub use lattice::{Cells, Lattice, LatticeKind};
pub use material::{Elastic, PlaneModel, SpringConstants};
pub use math::{Coords, Matrix, Real, Vector};
pub use state::State;
pub use tangent::Tangent;
