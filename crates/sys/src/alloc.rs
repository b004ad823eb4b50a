//! How a large run's memory is taken from and given back to the system (glibc).
//!
//! Building a body allocates and frees far more than it keeps: a random lattice's sampling grid
//! and Delaunay tetrahedra, the volume shares, the stable-step estimate's vectors. glibc serves a
//! freed block's size from its heaps next time (it raises its mapping threshold up to 32 MiB
//! after each large free), and the heaps of worker threads' arenas do not shrink when their
//! blocks are freed, not even for `malloc_trim`. So a body's set-up temporaries stayed
//! resident for the whole run. Measured with `hooke bench --lattice L --nodes 1000000
//! --threads 1 --json` (`resident_memory_bytes` per node, after the steps):
//!
//! | lattice | before | [`release_free_memory`] | and [`map_large_blocks`] |
//! |---|---|---|---|
//! | random3d | 986 | 842 | 834 |
//! | random2d | 662 | 493 | 491 |
//! | cubic | 560 | 584 | 536 |
//! | hex | 469 | 341 | 293 |
//!
//! Where large arrays start matters as much. A block with its own mapping starts 16 bytes into
//! a page, so every per-node array began at the same address modulo 4 KiB: the kernels stream
//! through a dozen of them in step, and a load whose address matches an earlier store's in its
//! low 12 bits waits for it (4K aliasing); their vectors also straddled cache lines. The
//! hexagonal stencil lost about 10 % to it when one more array got its own mapping. [`Staggered`]
//! starts each large block on a cache line, at an offset into its page that differs from the
//! previous blocks'.
//!
//! Nothing here moves live data or changes a result. Elsewhere than on glibc the two functions
//! do nothing.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Blocks of at least this many bytes get their own mapping ([`map_large_blocks`]).
pub const LARGE_BLOCK: usize = 4 << 20;

/// Blocks below this size come from the heap once a set-up is done ([`release_free_memory`]):
/// glibc's largest mapping threshold on 64-bit systems.
pub const KEPT_BLOCK: usize = 32 << 20;

/// Whether [`map_large_blocks`] set the process's policy.
static MAPPING: AtomicBool = AtomicBool::new(false);

/// Give every block of at least [`LARGE_BLOCK`] bytes its own mapping, returned to the system
/// when it is freed (glibc's `M_MMAP_THRESHOLD`, fixed), until a set-up is done
/// ([`release_free_memory`]; a later set-up in the same process keeps the heap's policy then).
/// A process-wide policy, for a program to set at its start: the `hooke` binary does. The hot
/// loop allocates nothing, so only set-up and output see it.
///
/// Fixing the mapping threshold also fixes glibc's trim threshold, at 128 KiB unless set: every
/// free that left that much at the top of the heap gave it back. So the heap is trimmed only
/// when asked ([`release_free_memory`], after set-up).
pub fn map_large_blocks() {
    MAPPING.store(true, Ordering::Relaxed);
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only changes the allocator's policy for later allocations and frees.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, LARGE_BLOCK as libc::c_int);
        libc::mallopt(libc::M_TRIM_THRESHOLD, libc::c_int::MAX);
    }
}

/// Return the allocator's free memory to the system (glibc's `malloc_trim`); call it once a
/// large set-up is done.
///
/// After [`map_large_blocks`], blocks below [`KEPT_BLOCK`] then come from the heap and stay in
/// it when freed: an output frame allocates and frees megabytes (the springs' geometry, the
/// stresses, the encoded arrays), and in fresh mappings each of its pages was faulted in anew
/// every frame (this machine does that at about 1 GB/s). On the random glass plate (`hooke
/// bench --frame --case cases/glass_branching_random.toml`) the frame's call took 21-29 ms,
/// and takes 13-14 ms with the heap's pages reused (9-14 ms without a fixed threshold at all).
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only returns free pages of the allocator's own arenas to the
    // system; `mallopt` only changes the policy for later allocations. Both may be called at
    // any time from any thread.
    unsafe {
        libc::malloc_trim(0);
        if MAPPING.load(Ordering::Relaxed) {
            libc::mallopt(libc::M_MMAP_THRESHOLD, KEPT_BLOCK as libc::c_int);
        }
    }
}

/// A global allocator: the system's, with every block of at least [`LARGE_BLOCK`] bytes
/// starting on a cache line at a page offset that varies from block to block (see the module
/// docs). Install it in a program with
///
/// ```ignore
/// #[global_allocator]
/// static ALLOC: hooke_sys::alloc::Staggered = hooke_sys::alloc::Staggered;
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct Staggered;

/// A large block's start is `LINE`-aligned, `SPAN` at most past the system block's first line.
const LINE: usize = 64;
const SPAN: usize = 4096;

/// Large blocks so far: picks the next one's offset.
static BLOCKS: AtomicUsize = AtomicUsize::new(0);

/// Whether a request is served staggered: large, and aligned to at most a line.
fn staggered(size: usize, align: usize) -> bool {
    size >= LARGE_BLOCK && align <= LINE
}

/// The system block behind a staggered one of `size` bytes.
fn outer(size: usize) -> Option<Layout> {
    Layout::from_size_align(size.checked_add(SPAN + LINE)?, LINE).ok()
}

impl Staggered {
    /// Place a staggered block in the system block `base` (null passes through): the next of
    /// 63 line offsets in [64, 4032] bytes, stepping 17 lines at a time, and `base` stored
    /// just before it for `dealloc`.
    fn place(base: *mut u8) -> *mut u8 {
        if base.is_null() {
            return base;
        }
        let k = BLOCKS.fetch_add(1, Ordering::Relaxed);
        let skew = LINE * (1 + (k * 17) % 63);
        let start = (base as usize).next_multiple_of(LINE) + skew;
        let p = base.wrapping_add(start - base as usize);
        // SAFETY: `p - 8 >= base + 56`, inside the system block, and aligned for a pointer.
        unsafe { p.cast::<*mut u8>().sub(1).write(base) };
        p
    }

    /// A staggered block for `layout`, placed in the system block `get` returns for the
    /// longer layout (null if that fails or the size overflows).
    fn large(layout: Layout, get: impl FnOnce(Layout) -> *mut u8) -> *mut u8 {
        outer(layout.size()).map_or(std::ptr::null_mut(), |o| Self::place(get(o)))
    }

    /// The system block of a staggered block `p`.
    ///
    /// # Safety
    /// `p` was returned by [`Staggered::place`].
    unsafe fn base(p: *mut u8) -> *mut u8 {
        // SAFETY: `place` stored it there.
        unsafe { p.cast::<*mut u8>().sub(1).read() }
    }
}

// SAFETY: small or over-aligned requests go to `System` unchanged. A large one is served from
// a system block `SPAN + LINE` bytes longer, inside which the returned pointer is
// `LINE`-aligned (so aligned for the request) with `size` bytes after it; the system block is
// found again from the pointer stored just before it, and every request is classified by its
// layout alone, the same in `alloc` and `dealloc`.
unsafe impl GlobalAlloc for Staggered {
    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !staggered(layout.size(), layout.align()) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.alloc(layout) };
        }
        // SAFETY: a non-zero size.
        Self::large(layout, |o| unsafe { System.alloc(o) })
    }

    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !staggered(layout.size(), layout.align()) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.alloc_zeroed(layout) };
        }
        // SAFETY: a non-zero size (a fresh mapping is zero without being touched).
        Self::large(layout, |o| unsafe { System.alloc_zeroed(o) })
    }

    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if !staggered(layout.size(), layout.align()) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.dealloc(ptr, layout) };
        }
        let o = outer(layout.size()).expect("the layout was allocated");
        // SAFETY: a staggered block, allocated with `o`.
        unsafe { System.dealloc(Self::base(ptr), o) }
    }

    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !staggered(layout.size(), layout.align()) && !staggered(new_size, layout.align()) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        // SAFETY: the caller guarantees a valid layout for `new_size`.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        // SAFETY: a non-zero size (the caller's guarantee); both blocks are valid for the
        // bytes copied, and the old one is freed with its own layout.
        unsafe {
            let q = self.alloc(new);
            if !q.is_null() {
                std::ptr::copy_nonoverlapping(ptr, q, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
            q
        }
    }
}

/// Start loading the cache line that holds `x`, for a read soon after: a gather whose
/// addresses are known some iterations ahead (the simplices around the next nodes) then waits
/// for one miss at a time no longer. Changes no value; does nothing off x86-64.
#[inline(always)]
pub fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing and cannot fault; the reference is valid anyway.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(x as *const T as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Large blocks start on distinct lines past their system blocks' first lines (so on
    /// distinct lines of their pages where those blocks are mappings), keep their contents through
    /// growth and shrinking, and come back zeroed from `alloc_zeroed`; small ones pass through.
    #[test]
    fn staggered_blocks_hold_their_bytes() {
        let a = Staggered;
        let mut offsets = Vec::new();
        for size in [100, LARGE_BLOCK, LARGE_BLOCK + 12345, 3 * LARGE_BLOCK] {
            let layout = Layout::from_size_align(size, 64).unwrap();
            // SAFETY: non-zero sizes; every block is used within its size and freed with its
            // layout.
            unsafe {
                let p = a.alloc_zeroed(layout);
                assert!(!p.is_null() && (p as usize).is_multiple_of(64));
                if size >= LARGE_BLOCK {
                    // The skew past the system block's first line: where glibc puts the
                    // system block (a mapping, or the heap once its dynamic threshold has
                    // risen, as it does unless `map_large_blocks` ran earlier in the process)
                    // is not this allocator's doing, and comparing pages' offsets made the
                    // test depend on the order the tests ran in.
                    let first = (Staggered::base(p) as usize).next_multiple_of(LINE);
                    offsets.push(p as usize - first);
                }
                assert!((0..size).step_by(997).all(|i| *p.add(i) == 0));
                for i in (0..size).step_by(997) {
                    *p.add(i) = (i % 251) as u8;
                }
                let big = a.realloc(p, layout, 2 * size);
                assert!((0..size)
                    .step_by(997)
                    .all(|i| *big.add(i) == (i % 251) as u8));
                let wide = Layout::from_size_align(2 * size, 64).unwrap();
                let small = a.realloc(big, wide, 64);
                assert_eq!(*small.add(0), 0);
                a.dealloc(small, Layout::from_size_align(64, 64).unwrap());
            }
        }
        offsets.sort_unstable();
        offsets.dedup();
        assert_eq!(offsets.len(), 3, "{offsets:?}");
    }
}
