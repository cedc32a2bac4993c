//! QEMU suite: firmware from `boards/qemu-f405` run on the emulated STM32F405 (QEMU
//! `netduinoplus2`), asserted on its decoded defmt log and its exit code.
//!
//! Run by plain `cargo test` at the repository root (after the host tests, in the same
//! run). Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target: if either is
//! missing the tests FAIL with a message saying to run `./x setup`, never skip.
//!
//! How it works: [`firmware`] builds the board package once per feature set with a nested
//! `cargo build --release --target thumbv7em-none-eabihf` into `target/firmware` (its own
//! target dir, so it never waits on the lock of the outer `cargo test`), then [`run`] runs
//! an ELF in QEMU through `qemu_run` (tools/qemu-run, the same code as the cargo runner)
//! and returns the decoded [`Outcome`].
//!
//! Adding a scenario: add a binary `boards/qemu-f405/src/bin/NAME.rs` (or a mode of an
//! existing one, read from its command line with `board::args`), then a test here:
//! `let out = run("NAME", &["ARGS"]); expect_exit(&out, 0); expect_line(&out, "...");`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use qemu_run::{Config, Echo, Outcome, Status};

const TARGET: &str = "thumbv7em-none-eabihf";
const BOARD: &str = "boards/qemu-f405";
/// Host-time limit for one firmware run.
const RUN_TIMEOUT: Duration = Duration::from_secs(60);

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Fails (with the way to fix it) unless QEMU and the target are installed. Checked once.
fn require_tools() {
    static CHECK: OnceLock<Result<(), String>> = OnceLock::new();
    let r = CHECK.get_or_init(|| {
        let mut missing = Vec::new();
        if let Err(e) = qemu_run::check_qemu(&Config::default()) {
            missing.push(e.to_string());
        }
        let sysroot = Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
            .args(["--print", "sysroot"])
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
        let has_target =
            sysroot.is_some_and(|s| s.join("lib/rustlib").join(TARGET).join("lib").is_dir());
        if !has_target {
            missing.push(format!(
                "the Rust target {TARGET} is not installed; {}",
                qemu_run::SETUP_HINT
            ));
        }
        if missing.is_empty() {
            Ok(())
        } else {
            Err(missing.join("\n"))
        }
    });
    if let Err(e) = r {
        panic!("QEMU suite cannot run:\n{e}");
    }
}

/// The nested cargo command for the board, free of the outer cargo's settings.
fn board_cargo(features: &str, bins: &[&str]) -> Command {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(root()) // so the root .cargo/config.toml (runner, linker args) applies
        .args(["build", "--release", "--target", TARGET])
        .arg("--manifest-path")
        .arg(root().join(BOARD).join("Cargo.toml"))
        .arg("--target-dir")
        .arg(root().join("target/firmware"));
    if !features.is_empty() {
        cmd.args(["--features", features]);
    }
    for b in bins {
        cmd.args(["--bin", b]);
    }
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
    cmd
}

/// Builds the given bins (all if empty) with `features`; Err(cargo's stderr) on failure.
/// Builds are serialized (one cargo at a time on 2 cores).
fn try_build(features: &str, bins: &[&str]) -> Result<(), String> {
    static LOCK: Mutex<()> = Mutex::new(());
    let _g = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let t = Instant::now();
    let out = board_cargo(features, bins)
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if out.status.success() {
        eprintln!(
            "qemu suite: built firmware (features '{features}', bins {bins:?}) in {:.1?}",
            t.elapsed()
        );
        Ok(())
    } else {
        Err(stderr)
    }
}

/// Path of firmware `bin` built with the default features (all bins built on first use).
///
/// The ELFs are copied to `target/firmware/qemu-suite/` right after the build, so a later
/// build with other features (the no-panic proof) cannot swap them under a running test.
pub fn firmware(bin: &str) -> PathBuf {
    require_tools();
    static BUILT: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let dir = BUILT.get_or_init(|| {
        try_build("", &[])?;
        let release = root().join("target/firmware").join(TARGET).join("release");
        let suite = root().join("target/firmware/qemu-suite");
        std::fs::create_dir_all(&suite).map_err(|e| e.to_string())?;
        for entry in std::fs::read_dir(&release).map_err(|e| e.to_string())? {
            let path = entry.map_err(|e| e.to_string())?.path();
            if path.is_file() && path.extension().is_none() {
                let to = suite.join(path.file_name().unwrap_or_default());
                std::fs::copy(&path, &to).map_err(|e| format!("copy {}: {e}", path.display()))?;
            }
        }
        Ok(suite)
    });
    match dir {
        Ok(d) => d.join(bin),
        Err(e) => panic!("building the QEMU firmware failed:\n{e}"),
    }
}

/// Runs firmware `bin` in QEMU with `args` on its command line.
pub fn run(bin: &str, args: &[&str]) -> Outcome {
    run_with(bin, args, RUN_TIMEOUT)
}

/// [`run`] with an explicit host-time limit.
pub fn run_with(bin: &str, args: &[&str], timeout: Duration) -> Outcome {
    let elf = firmware(bin);
    let cfg = Config {
        timeout,
        echo: Echo::Stderr,
        firmware_args: args.iter().map(|s| s.to_string()).collect(),
        ..Config::default()
    };
    eprintln!("--- qemu: {bin} {}", args.join(" "));
    qemu_run::run(&elf, &cfg).unwrap_or_else(|e| panic!("running {bin} in QEMU: {e}"))
}

/// Asserts the exit code, showing the whole log otherwise.
pub fn expect_exit(out: &Outcome, code: i32) {
    assert_eq!(
        out.exit_code(),
        code,
        "unexpected exit code; log:\n{}",
        out.transcript()
    );
}

/// Asserts that a line with exactly this message was logged; returns it.
pub fn expect_line<'a>(out: &'a Outcome, message: &str) -> &'a qemu_run::LogLine {
    out.lines
        .iter()
        .find(|l| l.message == message)
        .unwrap_or_else(|| panic!("no line {message:?} in the log:\n{}", out.transcript()))
}

// ---------------------------------------------------------------------------------------
// Scenarios
// ---------------------------------------------------------------------------------------

/// The heartbeat, the safety slot and two lanes run 100 ticks with exact counts.
#[test]
fn smoke_tick_lanes_and_safety_run_100_ticks() {
    let out = run("smoke", &[]);
    expect_exit(&out, 0);
    assert_eq!(out.malformed, 0, "{}", out.transcript());
    expect_line(&out, "smoke: start, 100 ticks at 1000 Hz");
    for n in [25u64, 50, 75, 100] {
        let l = expect_line(&out, &format!("lane_main: wake {n} at {} us", n * 1000));
        // The lane runs in the same tick it was woken in (virtual time, µs).
        let t = l.time_us.expect("timestamp");
        assert!(
            (n * 1000..n * 1000 + 1000).contains(&t),
            "lane woke at {t} us for tick {n}"
        );
    }
    expect_line(
        &out,
        "smoke: done ticks=100 safety_cycles=100 main_wakes=100 parallel_wakes=10 now_us=100000",
    );
}

/// A panic ends QEMU with exit code 101 and logs the message and location.
#[test]
fn panic_exits_101_with_message() {
    let out = run("panic", &["panic"]);
    expect_exit(&out, 101);
    let l = out
        .find("PANIC: ")
        .unwrap_or_else(|| panic!("no PANIC line:\n{}", out.transcript()));
    assert!(
        l.message.contains("deliberate panic at 5000 us"),
        "{}",
        out.transcript()
    );
    assert!(
        l.message.contains("src/bin/panic.rs"),
        "{}",
        out.transcript()
    );
    assert_eq!(l.level, Some("ERROR"));
}

/// A HardFault ends QEMU with exit code 102.
#[test]
fn hardfault_exits_102() {
    let out = run("panic", &["hardfault"]);
    expect_exit(&out, 102);
    assert!(out.find("HardFault: pc=").is_some(), "{}", out.transcript());
}

/// A failure detected by the firmware itself ends QEMU with exit code 1.
#[test]
fn firmware_failure_exits_1() {
    let out = run("panic", &["fail"]);
    expect_exit(&out, 1);
    expect_line(&out, "deliberate failure at 5000 us");
}

/// Firmware that never exits is killed by the runner's time limit (exit code 124).
#[test]
fn hanging_firmware_hits_the_time_limit() {
    let out = run_with("panic", &["hang"], Duration::from_secs(2));
    assert_eq!(out.status, Status::TimedOut, "{}", out.transcript());
    assert_eq!(out.exit_code(), qemu_run::EXIT_TIMEOUT);
    expect_line(&out, "panic firmware: mode Hang");
}

/// Instruction counting: TIM2 under `-icount shift=0` counts exactly one per instruction.
#[test]
fn bench_counts_instructions_exactly() {
    let out = run("bench", &[]);
    expect_exit(&out, 0);
    expect_line(
        &out,
        "bench: empty region raw = 1 instructions (measure::OVERHEAD = 1)",
    );
    expect_line(&out, "bench: 10 x nop = 10 instructions");
    let l = out
        .find("bench: counted_loop(1000) = ")
        .expect("counted loop line");
    assert!(
        l.message.ends_with("per iteration = 2"),
        "{}",
        out.transcript()
    );
    expect_line(&out, "bench: counted_loop(1500000) = 3000009 instructions");
}

/// No-panic proof: with `--features no-panic` the panic handler calls a symbol that does not
/// exist. The panic-free firmware links — `smoke` (the skeleton), `scenarios` (rtseq's
/// sequencer, lanes and monitors under RTIC, with hand-written action futures) and `safety`
/// (the safety system) —; the panic firmware (explicit `panic!`) does not, and the linker
/// names the symbol.
///
/// `demo` is not in the list: the motor application's sequences (`rtseq-motor`) are
/// `async fn`s, each of which keeps the compiler's "`async fn` resumed after completion"
/// panic path (7 of them; `tools/panic-paths target/firmware/thumbv7em-none-eabihf/release/demo`
/// lists them). rtseq itself adds none.
#[test]
fn no_panic_proof_links_only_panic_free_firmware() {
    // Build (and snapshot) the normal firmware first, so the two feature sets never race.
    firmware("smoke");
    if let Err(e) = try_build("no-panic", &["smoke", "scenarios", "safety"]) {
        panic!("a panic path survived in smoke/scenarios/safety (or the build failed):\n{e}");
    }
    match try_build("no-panic", &["panic"]) {
        Ok(()) => panic!("the panic firmware linked with --features no-panic: the proof is broken"),
        Err(e) => assert!(
            e.contains("rtseq_no_panic_proof__a_panic_path_survived_optimisation"),
            "the panic firmware failed for another reason:\n{e}"
        ),
    }
}
