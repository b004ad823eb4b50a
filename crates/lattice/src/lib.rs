//! hooke-lattice: where the nodes and springs are. The geometry every other crate builds on,
//! with no physics in it: no stiffness, no force law, no time.
//!
//! - [`lattice`]: the lattice kinds (Ladd cubic, hexagonal, random 2D and 3D), a [`Lattice`]'s
//!   nodes, its springs ([`lattice::Bonds`], a CSR of rows), their rest lengths and
//!   reference vectors, periodic boxes and the cells that weight a regular lattice's surface;
//! - [`random`]: random lattices (scattered nodes, Delaunay springs, the spring volumes `V_s`)
//!   and the parts of one built by several processes ([`random::part`]);
//! - [`math`]: the scalar type and the coordinate arrays (structure of arrays);
//! - [`error`]: the typed errors shared by the model crates above this one;
//! - [`memory`]: what arrays hold (heap bytes by part).
//!
//! `hooke-core` re-exports these modules under the same names (`hooke_core::lattice`, ...), so
//! a user of the model reaches the geometry without naming this crate.

#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![forbid(unsafe_code)]

pub mod error;
pub mod lattice;
pub mod math;
pub mod memory;
pub mod random;

pub use error::{Error, Result};
pub use lattice::{Cells, Lattice, LatticeKind};
pub use math::{Coords, Matrix, Real, Vector};

/// Nodes per parallel task and per partial sum. Fixed, not derived from the thread count, so
/// reductions always add the same partial sums in the same order (the kernels' chunks, and a
/// random lattice's volume summed alike by the processes that build its parts).
pub const CHUNK: usize = 4096;
