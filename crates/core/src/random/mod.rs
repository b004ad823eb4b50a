//! Random lattices: their geometry is [`hooke_lattice::random`] and their calibration tables
//! [`calibration`] (`hooke-model`), both re-exported here; this module adds the calibration of
//! anisotropic materials by measurement ([`anisotropic`]), which needs the static solver.

pub use hooke_model::random::*;

pub mod anisotropic;
