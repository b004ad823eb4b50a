//! A fingerprint of this crate's sources, of those below it (`hooke-lattice`, whose random
//! lattices the calibrations are measured on, `hooke-model` and `hooke-kernel`) and of the
//! workspace's lock file, where there is one, for the on-disk cache of calibrations (`random::anisotropic`): a cached design is used only
//! by a build of exactly the code that computed it, so a cache hit gives the bits a fresh
//! calibration would.

use std::path::{Path, PathBuf};

/// FNV-1a, 64 bits: stable across Rust versions (std's hasher is not).
fn fnv(h: &mut u64, bytes: &[u8]) {
    for &b in bytes {
        *h ^= b as u64;
        *h = h.wrapping_mul(0x100_0000_01b3);
    }
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// The crates core builds on whose sources a calibration's bits depend on.
const BELOW: [&str; 3] = ["lattice", "model", "kernel"];

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let mut list = Vec::new();
    files(&root.join("src"), &mut list);
    list.push(root.join("Cargo.toml"));
    // The crates below, whose code a calibration runs.
    for below in BELOW {
        let dir = root.join("..").join(below);
        files(&dir.join("src"), &mut list);
        list.push(dir.join("Cargo.toml"));
    }
    list.push(root.join("../../Cargo.lock"));
    // The order of a directory listing is the file system's: sort for a stable hash.
    list.sort();
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in &list {
        if let Ok(bytes) = std::fs::read(p) {
            // Named from the crates' folder, so that where the checkout lies changes nothing
            // (core's own files keep the names they had before the lattice crate left it).
            let name = p
                .strip_prefix(&root)
                .or_else(|_| p.strip_prefix(root.join("..")))
                .unwrap_or(p);
            fnv(&mut h, name.to_string_lossy().as_bytes());
            fnv(&mut h, &bytes);
        }
    }
    println!("cargo:rustc-env=HOOKE_CORE_FINGERPRINT={h:016x}");
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=Cargo.toml");
    for below in BELOW {
        println!("cargo:rerun-if-changed=../{below}/src");
        println!("cargo:rerun-if-changed=../{below}/Cargo.toml");
    }
    if root.join("../../Cargo.lock").exists() {
        println!("cargo:rerun-if-changed=../../Cargo.lock");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
