//! # hooke-sim
//!
//! hooke as a library: a [`Simulation`] (a body, its state, loading, fracture, contact and what
//! the run writes), and the drivers that run it, explicit dynamics ([`Run`]: step by step or to
//! the end) and quasi-static load steps ([`run`] dispatches to whichever the simulation is).
//! The command line, the Python package and MPI runs all drive a simulation through this crate.
//!
//! A run writes through [`Sink`]s (VTK and HDF5 frames, the energy, reaction and contact
//! histories, the rigid bodies' surfaces), keeps `run.json` (provenance: version, commit,
//! command, case, resolved constants, threads, start and end, status), writes checkpoints to
//! continue bit for bit, and reports to an [`Observer`] (progress, interruption).
//!
//! Simulations come from case files (`hooke_case::load`) or from code through [`Builder`].
//!
//! Modules: `builder` ([`Builder`], and set-up from parts), `simulation` ([`Simulation`],
//! [`Solver`]), `run` ([`Run`], [`RunOptions`], checkpoints and resume), `quasi_static`,
//! `check` ([`Simulation::check`]: [`CheckReport`]), [`output`] (the [`Sink`]s), `observer`,
//! `provenance` (`run.json`), [`geometry`] (shapes, regions, lattice filling), [`rigid`] (rigid
//! bodies and contact as written), `error`.
#![forbid(unsafe_code)]
// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod builder;
mod check;
mod error;
pub mod field;
pub mod geometry;
pub mod inclusions;
mod observer;
pub mod output;
mod provenance;
mod quasi_static;
pub mod rigid;
mod run;
mod simulation;

pub use builder::{
    Bc, BreakRule, BuildError, Builder, Interface, PhaseMaterial, Strength, Toughness,
};
pub use check::{BoundaryNodes, CheckReport, Note, PhaseReport, SofteningReport};
pub use error::{Error, Result};
pub use geometry::{fill_lattice, Face, Region, Shape, Solid};
pub use hooke_fracture::Weibull;
pub use observer::{Observer, Progress, Silent, StopFlag};
pub use output::{EnergyRow, Frame, RegionReaction, Sink};
pub use provenance::{utc_now, GIT_COMMIT};
pub use rigid::{ContactSpec, RigidSpec};
pub use run::{free_space, run, run_keeping, seconds, write_probe, Run, RunOptions, Summary};
pub use simulation::{Boundary, FromParts, Held, MaterialInfo, Schedule, Simulation, Solver};
