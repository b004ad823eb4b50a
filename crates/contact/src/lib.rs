//! # hooke-contact
//!
//! The one crate that depends on parry. Today it holds [`mesh`]: closed triangle meshes (STL,
//! OBJ) read, validated and used as body shapes through parry's point containment, so random
//! and regular lattices can fill any shape a CAD tool exports. Contact between lattices and rigid
//! bodies, and between fragments, will live here too.
//!
//! parry 0.26 and later speaks glam (`DVec3`); the conversion from our `[f64; 3]` happens at
//! this crate's boundary and nowhere else.

pub mod mesh;

pub use mesh::{MeshError, MeshShape};
