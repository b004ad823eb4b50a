//! The zero-copy numpy views of a `Simulation`'s arrays: the one place with `unsafe` in the
//! Python extension.
//!
//! A view is a read-only numpy array over a Rust buffer, kept alive by the Python object that
//! owns the simulation. It is sound while the buffer neither moves nor is freed as long as that
//! object lives; which buffers may be viewed is fixed here, by [`Coords`] and the functions
//! below, each with the reason its buffer stays put. `PySimulation::sync` checks the addresses
//! after every call that ran Rust code.

use numpy::ndarray::{ArrayView1, ArrayView2, ShapeBuilder};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

use hooke_core::Real;

use crate::PySimulation;

/// The `n x 3` arrays a simulation shows.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Coords {
    /// Reference positions: the lattice is immutable and lives in the simulation.
    Positions,
    /// Displacements: `u_home` pins their allocation, `sync` keeps them in it, and the
    /// state's buffers are overwritten in place, never replaced, while the object lives.
    Displacement,
    /// Full-step velocities (made before the view is asked for): the buffer belongs to the
    /// object and is only ever overwritten in place.
    Velocity,
}

/// The `n x 3` array `which` of `owner`'s simulation, read-only, without a copy: the
/// components are stored one after the other, so a row steps 8 bytes and a column `8 n`.
pub(crate) fn coords<'py>(
    owner: &Bound<'py, PySimulation>,
    which: Coords,
) -> Bound<'py, PyArray2<Real>> {
    let me = owner.borrow();
    let c = match which {
        Coords::Positions => &me.sim().body.lattice.pos,
        Coords::Displacement => &me.sim().state.u,
        Coords::Velocity => me.velocity.as_ref().expect("made before its view"),
    };
    let n = c.len();
    let view = ArrayView2::from_shape((n, 3).strides((1, n.max(1))), c.as_flat())
        .expect("3 n values in component order");
    // SAFETY: `c` lives in `owner`'s simulation (or `owner` itself) and stays put while
    // `owner` lives, for the reason its `Coords` variant gives; numpy keeps `owner` alive.
    let a = unsafe { PyArray2::borrow_from_array(&view, owner.clone().into_any()) };
    a.readwrite().make_nonwriteable();
    a
}

/// A read-only array over a slice that lives in `owner` and stays put while it lives.
fn slice<'py, T: numpy::Element>(
    owner: &Bound<'py, PySimulation>,
    pick: impl FnOnce(&PySimulation) -> &[T],
) -> Bound<'py, PyArray1<T>> {
    let me = owner.borrow();
    let view = ArrayView1::from(pick(&me));
    // SAFETY: every caller below picks a buffer that lives in `owner` and is overwritten in
    // place, never moved or freed, while `owner` lives; numpy keeps `owner` alive.
    let a = unsafe { PyArray1::borrow_from_array(&view, owner.clone().into_any()) };
    a.readwrite().make_nonwriteable();
    a
}

/// Damage per node (made before the view is asked for): the object's own buffer, only ever
/// overwritten in place.
pub(crate) fn damage<'py>(owner: &Bound<'py, PySimulation>) -> Bound<'py, PyArray1<Real>> {
    slice(owner, |me| {
        me.damage.as_deref().expect("made before its view")
    })
}

/// Whether each spring is intact: springs are broken in place, in the state's buffer.
pub(crate) fn spring_intact<'py>(owner: &Bound<'py, PySimulation>) -> Bound<'py, PyArray1<bool>> {
    slice(owner, |me| me.sim().state.alive())
}

/// Each spring's end nodes, `m x 2`: the topology is immutable and lives in the simulation.
pub(crate) fn spring_ends<'py>(owner: &Bound<'py, PySimulation>) -> Bound<'py, PyArray2<u32>> {
    let me = owner.borrow();
    let ends = &me.sim().body.lattice.bonds.ends;
    let view = ArrayView2::from_shape((ends.len(), 2), ends.as_flattened()).expect("2 m values");
    // SAFETY: the topology never changes during a run and lives in `owner`'s simulation;
    // numpy keeps `owner` alive.
    let a = unsafe { PyArray2::borrow_from_array(&view, owner.clone().into_any()) };
    a.readwrite().make_nonwriteable();
    a
}
