//! # hooke-fracture
//!
//! Bond breaking that keeps the dispersion consistent: a broken spring carries no direct and no
//! dispersed force and leaves both of its nodes' pools, whose normalisers `S_n` are recomputed
//! ([`hooke_core::State::kill_bond`]); with that, a body cut in two has exactly zero coupling
//! between its halves, and the stiffness stays positive semidefinite for any pattern of broken
//! springs (`docs/model.md`).
//!
//! * [`Criterion`]: when a spring fails; [`CriticalStretch`] (with the calibration from the
//!   fracture energy G_c, derived in [`stretch`]) and [`SpringEnergy`], each in its own file.
//! * [`Fracture`]: decides breaks in a parallel pass over the springs and commits them after it,
//!   in spring order, so the result depends neither on iteration order nor on thread count. The
//!   energy a commit releases is `U(before) - U(after)` over the springs and nodes it touches
//!   (the direct energy of the springs plus the change of their nodes' dispersive energy), and
//!   goes into the integrator's energy ledger.
//! * [`Softening`]: a cohesive spring law for quasi-brittle materials, linear or bilinear, whose
//!   springs lose stiffness gradually (a damage weight in the pools and normalisers) and break
//!   at their final stretch; calibrated from G_f and the tensile strength ([`softening`]).
//! * [`Weibull`]: random strength, each spring's critical stretch scaled by a seeded draw
//!   that depends only on the nodes it joins ([`Fracture::with_strength`] takes the factors,
//!   which also carry a material's or an interface's own strength).
//! * [`precrack`]: springs crossing segments (2D) or planar polygons (3D) removed at set-up.
//! * Damage per node: the fraction of its springs that are broken (softened springs count by
//!   their lost weight).
#![forbid(unsafe_code)]
// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod criterion;
pub mod energy;
pub mod error;
pub mod precrack;
pub mod softening;
pub mod stretch;
pub mod toughness;
pub mod weibull;

mod fracture;

pub use criterion::{Criterion, SpringState};
pub use energy::SpringEnergy;
pub use error::FractureError;
pub use fracture::{node_dispersive_energy, BreakReport, Fracture};
pub use precrack::Crack;
pub use softening::{Softening, SofteningShape};
pub use stretch::{CriticalStretch, FibreStretch};
pub use weibull::Weibull;
