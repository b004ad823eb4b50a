//! The `hooke` binary: parse arguments, run, map errors to exit codes
//! (0 success, 2 bad input, 1 run failure).
#![forbid(unsafe_code)]

use std::process::ExitCode;

use clap::Parser;

// Large arrays start at staggered offsets into their pages, so that the kernels' streams do
// not alias modulo 4 KiB (hooke_sys::alloc).
#[global_allocator]
static ALLOC: hooke_sys::alloc::Staggered = hooke_sys::alloc::Staggered;

fn main() -> ExitCode {
    // `hooke check case.toml | head` closes our stdout early. Rust ignores SIGPIPE, so the next
    // println! would panic with a backtrace; the Unix convention (and what users of `head` and
    // `grep -q` expect) is to stop quietly, which the default action of SIGPIPE does. Anything a
    // run writes to its output folder is written before the summary it prints.
    hooke_sys::default_sigpipe();
    // Large blocks in mappings of their own, given back when freed: a body's set-up
    // temporaries otherwise stay resident for the whole run (hooke_sys::alloc).
    hooke_sys::alloc::map_large_blocks();
    // HOOKE_NO_SIMD forces the kernels' portable paths, HOOKE_SIMD=avx2 AVX2 over AVX-512 (the
    // same bits either way: to test and measure the paths against each other).
    hooke_core::kernel::set_simd(hooke_core::kernel::Simd::from_env_values(
        std::env::var_os("HOOKE_NO_SIMD").is_some(),
        std::env::var("HOOKE_SIMD").ok().as_deref(),
    ));
    // Anisotropic random-lattice materials are calibrated once per machine, not once per run.
    hooke_core::random::anisotropic::set_cache_dir(hooke_sys::cache_dir());
    let cli = match hooke_cli::Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // clap prints help/version on stdout with exit 0, and usage errors with exit 2.
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match hooke_cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Every rank of an MPI run fails alike; rank 0 says why.
            if !hooke_cli::quiet() {
                eprintln!("error: {e:#}");
            }
            ExitCode::from(hooke_cli::exit_code(&e))
        }
    }
}
