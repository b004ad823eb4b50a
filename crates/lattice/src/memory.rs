//! Memory accounting: what the arrays of a run hold ([`Footprint`], [`bytes`]). How memory is
//! taken from and given back to the system (the allocator, glibc's tuning) is `hooke_sys::alloc`.

/// Where a run's memory lies: named parts with their heap bytes (capacity, not length), as
/// `hooke_core`'s `Body::footprint`, `State::footprint` and `Integrator::footprint` list them. `hooke bench --json` prints them per
/// node (`memory_parts`), beside the resident memory that the system reports.
pub type Footprint = Vec<(&'static str, usize)>;

/// Heap bytes of a vector (its capacity).
#[allow(clippy::ptr_arg)] // the capacity, which a slice does not have
pub fn bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}
