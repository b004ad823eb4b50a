//! # hooke-io
//!
//! Output of hooke runs: VTK time series (`.vtu` frames and a `.pvd` collection) that ParaView,
//! pyvista, VTK and meshio open, with the derived fields users look at (displacement, velocity,
//! damage, pool ratio, strain energy density, virial stress, region ids) computed only here, at
//! output time; and checkpoints from which a run continues bit for bit.
//!
//! Everything is written to a temporary file and renamed into place: a run killed at any moment
//! (even with `kill -9`) leaves every completed frame, the collection and the last checkpoint
//! readable.
//!
//! Modules: [`vtk`] (frames, series, rigid surfaces; `vtu` streams a frame's arrays),
//! [`fields`] (the point fields a case chooses), `h5` (HDF5 + XDMF, feature `hdf5`),
//! [`checkpoint`], [`error`].
#![forbid(unsafe_code)]

pub mod checkpoint;
pub mod error;
pub mod fields;
#[cfg(feature = "hdf5")]
pub mod h5;
pub mod vtk;
mod vtu;

pub use checkpoint::Checkpoint;
pub use error::IoError;
pub use fields::FieldSet;
#[cfg(feature = "hdf5")]
pub use h5::H5Series;
pub use vtk::{FrameExtras, RigidPart, RigidSeries, VtkSeries};
