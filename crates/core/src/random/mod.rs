//! Random lattices: their geometry is [`hooke_lattice::random`] (re-exported here); this
//! module adds what depends on the model: the calibration of the spring constants against the
//! target moduli ([`calibration`]) and of anisotropic materials ([`anisotropic`]).

pub use hooke_lattice::random::*;

pub mod anisotropic;
pub mod calibration;
