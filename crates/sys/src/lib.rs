//! hooke-sys: the system calls and the allocator, the one place outside the kernels where hooke
//! needs `unsafe`.
//!
//! Elsewhere `unsafe` sits only in `hooke-kernel` (the SIMD kernels), the MPI transport of
//! the binary (`hooke_cli`'s `mpi` module: a communicator shared between threads) and the
//! Python bindings (`hooke-py`'s `views` module: numpy views over the simulation's arrays);
//! every other crate has `#![forbid(unsafe_code)]` and reaches the system through here:
//!
//! - [`alloc`]: the global allocator [`alloc::Staggered`] (large blocks on staggered cache
//!   lines), glibc's tuning ([`alloc::map_large_blocks`], [`alloc::release_free_memory`]) and
//!   [`alloc::prefetch`];
//! - [`simd`]: which vector instructions the kernels may use (the process's choice and the
//!   processor's features);
//! - [`free_space`]: free bytes on a file system (`statvfs`);
//! - [`online_cores`]: the machine's cores (`sysconf`);
//! - [`peak_memory`], [`resident_memory`]: this process's resident memory (`/proc`);
//! - [`default_sigpipe`]: a closed pipe ends the program quietly (`signal`);
//! - [`cache_dir`]: where programs keep calibrations between processes (the environment: the
//!   libraries take the directory as an option, the programs read the variables here).

pub mod alloc;
pub mod simd;

pub use alloc::prefetch;

use std::path::Path;

/// Free bytes on the file system that holds `dir` (or its nearest existing ancestor); `None`
/// where the system cannot tell.
pub fn free_space(dir: &Path) -> Option<u64> {
    let mut p = dir;
    while !p.exists() {
        p = p.parent()?;
    }
    statvfs_free(p)
}

#[cfg(unix)]
fn statvfs_free(p: &Path) -> Option<u64> {
    let c = std::ffi::CString::new(p.as_os_str().as_encoded_bytes()).ok()?;
    let mut s = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a valid NUL-terminated path and `s` points to writable memory of the right
    // type; statvfs only writes through it and reports failure by its return value.
    let r = unsafe { libc::statvfs(c.as_ptr(), s.as_mut_ptr()) };
    if r != 0 {
        return None;
    }
    // SAFETY: statvfs succeeded, so it filled the struct.
    let s = unsafe { s.assume_init() };
    #[allow(clippy::unnecessary_cast)] // the fields' widths differ between platforms
    Some(s.f_bavail as u64 * s.f_frsize as u64)
}

#[cfg(not(unix))]
fn statvfs_free(_: &Path) -> Option<u64> {
    None
}

/// The cores the machine has online, at least `usable` (the ones this process may run on).
pub fn online_cores(usable: usize) -> usize {
    #[cfg(unix)]
    // SAFETY: sysconf reads a value of the running system; no memory is passed.
    let online = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    #[cfg(not(unix))]
    let online = usable as i64;
    usize::try_from(online).unwrap_or(1).max(usable)
}

/// Restore SIGPIPE's default action, so that a program whose output pipe closes (`| head`)
/// stops quietly, as Unix programs do, instead of failing its next write. Call it first in
/// `main`, before any thread starts.
pub fn default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to its default, before any thread starts (the
    // caller's part), races with nothing.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// The conventional cache directory of a program built on hooke (for
/// `hooke_core::random::anisotropic::set_cache_dir`): `$HOOKE_CACHE` if set (empty or `off`: no
/// cache), else `$XDG_CACHE_HOME/hooke`, else `$HOME/.cache/hooke`. For programs: libraries take
/// the directory, they do not read the environment.
pub fn cache_dir() -> Option<std::path::PathBuf> {
    use std::path::PathBuf;
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    match std::env::var_os("HOOKE_CACHE") {
        Some(v) if v.is_empty() || v == "off" => None,
        Some(v) => Some(PathBuf::from(v)),
        None => var("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache")))
            .map(|d| d.join("hooke")),
    }
}

/// Peak resident memory of this process (Linux: `VmHWM` of `/proc/self/status`), in bytes.
pub fn peak_memory() -> Option<u64> {
    status_bytes("VmHWM:")
}

/// Resident memory of this process now (Linux: `VmRSS`), in bytes: after set-up, what a run
/// keeps.
pub fn resident_memory() -> Option<u64> {
    status_bytes("VmRSS:")
}

fn status_bytes(key: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
