//! The real-board firmware (`boards/nucleo-f446re-ihm07m1`: NUCLEO-F446RE + X-NUCLEO-IHM07M1)
//! builds: plain `cargo test` proves it, although nothing can run it here. The build is the
//! user's command (`cargo build --release` in the board's directory, so its
//! `.cargo/config.toml` applies), into the shared `target/firmware-nucleo`.
//!
//! The ELF is then checked against the chip: a Cortex-M image whose vector table sits at the
//! start of the STM32F446RE's flash, whose loadable segments fit the 512 KiB of flash and
//! the 128 KiB of RAM (the board's `memory.x`, not the root's STM32F405 one), and whose RAM
//! is laid out by flip-link: the stack at the bottom, growing down towards the start of RAM
//! (an overflow faults), the statics above it up to the end of RAM.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const TARGET: &str = "thumbv7em-none-eabihf";
const BOARD: &str = "boards/nucleo-f446re-ihm07m1";
const BIN: &str = "nucleo-f446re-ihm07m1";
const FLASH: (u32, u32) = (0x0800_0000, 512 * 1024);
const RAM: (u32, u32) = (0x2000_0000, 128 * 1024);

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn target_installed() -> bool {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    Command::new(rustc)
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()))
        .is_some_and(|s| s.join("lib/rustlib").join(TARGET).join("lib").is_dir())
}

/// Builds the firmware as a user does; returns the ELF's path.
fn build() -> PathBuf {
    assert!(
        target_installed(),
        "the Rust target {TARGET} is not installed: run `./x setup` (or `rustup target add {TARGET}`)"
    );
    let target_dir = root().join("target/firmware-nucleo");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(root().join(BOARD))
        .args(["build", "--release", "--target-dir"])
        .arg(&target_dir);
    // Free of the outer cargo's settings.
    for v in [
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET",
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_MAKEFLAGS",
        "MAKEFLAGS",
        "MFLAGS",
    ] {
        cmd.env_remove(v);
    }
    let t = Instant::now();
    let out = cmd.output().expect("cannot run cargo");
    assert!(
        out.status.success(),
        "the NUCLEO-F446RE firmware does not build:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("real board: firmware built in {:.1?}", t.elapsed());
    target_dir.join(TARGET).join("release").join(BIN)
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(b[at..at + 2].try_into().unwrap())
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// A loadable segment: (file offset, physical = load address, virtual address, file size,
/// memory size).
struct Segment {
    offset: u32,
    paddr: u32,
    vaddr: u32,
    filesz: u32,
    memsz: u32,
}

/// The PT_LOAD segments of a little-endian ELF32 ARM executable.
fn load_segments(elf: &[u8]) -> Vec<Segment> {
    assert_eq!(&elf[..4], b"\x7fELF", "not an ELF file");
    assert_eq!(elf[4], 1, "not ELF32");
    assert_eq!(elf[5], 1, "not little-endian");
    assert_eq!(u16_at(elf, 18), 40, "e_machine is not ARM");
    let (phoff, phentsize, phnum) = (
        u32_at(elf, 28) as usize,
        u16_at(elf, 42) as usize,
        u16_at(elf, 44) as usize,
    );
    (0..phnum)
        .map(|i| phoff + i * phentsize)
        .filter(|&ph| u32_at(elf, ph) == 1)
        .map(|ph| Segment {
            offset: u32_at(elf, ph + 4),
            vaddr: u32_at(elf, ph + 8),
            paddr: u32_at(elf, ph + 12),
            filesz: u32_at(elf, ph + 16),
            memsz: u32_at(elf, ph + 20),
        })
        .collect()
}

fn within((start, len): (u32, u32), addr: u32, size: u32) -> bool {
    addr >= start && u64::from(addr) + u64::from(size) <= u64::from(start) + u64::from(len)
}

#[test]
fn nucleo_f446re_ihm07m1_firmware_builds_for_the_chip() {
    let elf_path = build();
    let elf = std::fs::read(&elf_path).unwrap_or_else(|e| panic!("{}: {e}", elf_path.display()));
    let segments = load_segments(&elf);
    assert!(!segments.is_empty(), "no loadable segment");

    let mut flash_used = 0u32;
    let mut ram_used = 0u32;
    for s in &segments {
        if s.filesz > 0 {
            assert!(
                within(FLASH, s.paddr, s.filesz),
                "segment loaded at {:#010x} (+{}) is outside the F446RE's flash",
                s.paddr,
                s.filesz
            );
            flash_used += s.filesz;
        }
        if within(RAM, s.vaddr, s.memsz) {
            ram_used += s.memsz;
        } else {
            assert!(
                within(FLASH, s.vaddr, s.memsz),
                "segment at {:#010x} (+{}) is neither in flash nor in RAM",
                s.vaddr,
                s.memsz
            );
        }
    }

    // The vector table at the start of flash: the initial stack pointer below every static
    // (flip-link's layout; without it the stack would start at the end of RAM, above them),
    // reset vector = a Thumb address in flash.
    let vectors = segments
        .iter()
        .find(|s| s.paddr == FLASH.0 && s.filesz >= 8)
        .expect("no segment at the start of flash (vector table)");
    let at = vectors.offset as usize;
    let initial_sp = u32_at(&elf, at);
    let reset = u32_at(&elf, at + 4);
    assert!(
        within(RAM, initial_sp - 4, 4),
        "initial SP {initial_sp:#010x}: not in the F446RE's RAM (wrong memory.x?)"
    );
    for s in segments.iter().filter(|s| within(RAM, s.vaddr, s.memsz)) {
        assert!(
            s.vaddr >= initial_sp,
            "static RAM at {:#010x} lies below the initial SP {initial_sp:#010x}: not linked with flip-link",
            s.vaddr
        );
    }
    assert!(
        reset & 1 == 1 && within(FLASH, reset & !1, 2),
        "reset vector {reset:#010x}"
    );
    eprintln!(
        "real board: {BIN}: {flash_used} B flash of {} KiB, {ram_used} B static RAM of {} KiB",
        FLASH.1 / 1024,
        RAM.1 / 1024
    );
}
