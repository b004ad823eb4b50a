//! # hooke-contact
//!
//! The one crate that depends on parry. It holds
//!
//! * [`rigid`]: rigid bodies (parry shapes in 2D and 3D: ball, cuboid, cylinder, capsule,
//!   half-space, convex polygon, triangle mesh) that move kinematically or dynamically;
//! * [`contact`]: penalty contact of lattice nodes with those bodies (optional Coulomb
//!   friction, reactions recorded over time) and between nodes that no intact spring joins
//!   (crack faces, fragments), plugged into the integrator as a
//!   [`hooke_core::dynamics::Interaction`];
//! * [`mesh`]: closed triangle meshes (STL, OBJ) read, validated and used as body shapes through
//!   parry's point containment.
//!
//! parry 0.26 and later speaks glam (`DVec2`, `DVec3`); the conversion from our `[f64; 3]`
//! happens at this crate's boundary and nowhere else.
#![forbid(unsafe_code)]
// Checks are written `!(x > 0.0)` on purpose: a NaN fails them, where `x <= 0.0` would let it
// through; clippy's suggestion (partial_cmp) would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod contact;
pub mod mesh;
pub mod rigid;

pub use contact::{Contact, ContactOptions, Record};
pub use mesh::{MeshError, MeshShape};
pub use rigid::{Geometry, Motion, RigidBody};
