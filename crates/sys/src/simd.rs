//! Which vector instructions the kernels may use: the process's choice ([`Simd`], set once by
//! a program) and what the processor offers ([`lanes`]). It lives here, below every crate that
//! asks: the kernels pick their paths from it, and a lattice keeps the arrays the general
//! kernel needs when no vector stencil can run.

/// Which vector instructions the kernels may use, for the whole process. Every choice gives the
/// same bits (each vector path performs the portable path's operations lane by lane); the
/// setting exists to test and measure the paths against each other. Programs set it once,
/// before they build integrators: the `hooke` binary and the Python module map the environment
/// variables `HOOKE_NO_SIMD` (portable) and `HOOKE_SIMD=avx2` onto it ([`Simd::from_env_values`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Simd {
    /// The widest the processor has: AVX-512, else AVX2 (AVX for the CSR kernel's sweep 1).
    #[default]
    Best,
    /// AVX2 where the processor has AVX-512 too.
    Avx2,
    /// No vector instructions: every kernel takes its portable path.
    Portable,
}

static SIMD: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(0);

impl Simd {
    /// The choice the two environment variables make: `HOOKE_NO_SIMD` set (`no_simd`) is
    /// [`Simd::Portable`], else `HOOKE_SIMD=avx2` is [`Simd::Avx2`], else [`Simd::Best`].
    pub fn from_env_values(no_simd: bool, simd: Option<&str>) -> Simd {
        match (no_simd, simd) {
            (true, _) => Simd::Portable,
            (false, Some("avx2")) => Simd::Avx2,
            _ => Simd::Best,
        }
    }
}

/// Set the process's [`Simd`] choice (before integrators are built: a kernel picks its path
/// when it is made).
pub fn set_simd(choice: Simd) {
    SIMD.store(choice as u8, std::sync::atomic::Ordering::Relaxed);
}

/// The process's [`Simd`] choice.
pub fn simd() -> Simd {
    match SIMD.load(std::sync::atomic::Ordering::Relaxed) {
        1 => Simd::Avx2,
        2 => Simd::Portable,
        _ => Simd::Best,
    }
}

/// False when the process runs the portable paths only ([`Simd::Portable`]).
pub fn simd_allowed() -> bool {
    simd() != Simd::Portable
}

/// The vector instructions the kernels' vector paths use: AVX-512 (8 lanes) where the
/// processor has it, else AVX2 (4 lanes; a block of 8 nodes as two halves); `None` without
/// either or with [`Simd::Portable`]. [`Simd::Avx2`] takes AVX2 where AVX-512 is
/// there too (to test and measure that path on such a machine).
pub fn lanes() -> Option<Lanes> {
    if !simd_allowed() {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        let want_avx2 = simd() == Simd::Avx2;
        if !want_avx2 && std::arch::is_x86_feature_detected!("avx512f") {
            return Some(Lanes::Avx512);
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Lanes::Avx2);
        }
    }
    None
}

/// AVX2 where the processor has it and the portable paths are not forced, whatever else it has: what
/// the kernels' `use_avx2` switch to (to test and measure that path on an AVX-512 processor).
pub fn avx2_lanes() -> Option<Lanes> {
    #[cfg(target_arch = "x86_64")]
    if simd_allowed() && std::arch::is_x86_feature_detected!("avx2") {
        return Some(Lanes::Avx2);
    }
    None
}

/// Which vector instructions a kernel's vector path runs on (see [`lanes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lanes {
    /// AVX-512F: 8 doubles to a vector.
    Avx512,
    /// AVX2: 4 doubles to a vector.
    Avx2,
}
