//! Puts this board's `memory.x` (STM32F446RE) on the linker search path, where
//! cortex-m-rt's `link.x` includes it (the repository root's `memory.x` is the STM32F405's).
use std::{env, fs, path::PathBuf};

fn main() {
    let (Some(manifest), Some(out)) = (env::var_os("CARGO_MANIFEST_DIR"), env::var_os("OUT_DIR"))
    else {
        panic!("cargo did not set CARGO_MANIFEST_DIR / OUT_DIR");
    };
    let memory_x = PathBuf::from(manifest).join("memory.x");
    let out = PathBuf::from(out);
    if let Err(e) = fs::copy(&memory_x, out.join("memory.x")) {
        panic!("copy {} to OUT_DIR: {e}", memory_x.display());
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");
}
