//! Shared QEMU harness for the root test suites that run firmware from `boards/qemu-f405`
//! (the approach of `tests/qemu.rs`): check the tools, build the firmware once with a nested
//! cargo into `target/firmware`, snapshot the ELFs, run one in QEMU through `qemu_run` and
//! return its decoded log.
//!
//! Missing QEMU or target is a test FAILURE with the way to fix it (`./x setup`), never a
//! skip.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

pub use qemu_run::{Config, Echo, Outcome};

pub const TARGET: &str = "thumbv7em-none-eabihf";
pub const BOARD: &str = "boards/qemu-f405";
/// Host-time limit for one firmware run.
pub const RUN_TIMEOUT: Duration = Duration::from_secs(60);

pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Fails (with the way to fix it) unless QEMU and the target are installed. Checked once.
pub fn require_tools() {
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
pub fn board_cargo(features: &str, bins: &[&str]) -> Command {
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
    free_of_outer_cargo(&mut cmd);
    cmd
}

/// Takes the outer cargo's settings (target dir, target, flags, jobserver) out of a nested
/// cargo command, so that it builds as a user's would.
pub fn free_of_outer_cargo(cmd: &mut Command) {
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
}

/// Builds the given bins (all if empty) with `features`; Err(cargo's stderr) on failure.
/// Builds are serialized within this test binary.
pub fn try_build(features: &str, bins: &[&str]) -> Result<(), String> {
    let _g = BUILD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    build_locked(features, bins)
}

/// Serializes the builds (and the snapshots taken right after them) of one test binary.
static BUILD_LOCK: Mutex<()> = Mutex::new(());

fn build_locked(features: &str, bins: &[&str]) -> Result<(), String> {
    let t = Instant::now();
    let out = board_cargo(features, bins)
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if out.status.success() {
        eprintln!(
            "qemu harness: built firmware (features '{features}', bins {bins:?}) in {:.1?}",
            t.elapsed()
        );
        Ok(())
    } else {
        Err(stderr)
    }
}

/// Firmware bins built together once (default features) and snapshotted into
/// `target/firmware/<snapshot>/`, so a later build with other features (the no-panic proofs)
/// cannot swap an ELF under a running test. Each suite builds only its own bins, so a
/// work-in-progress firmware elsewhere in the board does not break it.
pub struct FirmwareSet {
    /// The board features the set is built with ("" = the defaults).
    features: &'static str,
    /// The bins; empty = every bin of the board.
    bins: &'static [&'static str],
    snapshot: &'static str,
    built: OnceLock<Result<PathBuf, String>>,
}

impl FirmwareSet {
    pub const fn new(bins: &'static [&'static str], snapshot: &'static str) -> Self {
        Self::with_features("", bins, snapshot)
    }

    /// A set built with the board features `features` (snapshotted under its own name).
    pub const fn with_features(
        features: &'static str,
        bins: &'static [&'static str],
        snapshot: &'static str,
    ) -> Self {
        FirmwareSet {
            features,
            bins,
            snapshot,
            built: OnceLock::new(),
        }
    }

    /// Path of firmware `bin`, building the set on first use.
    pub fn path(&self, bin: &str) -> PathBuf {
        require_tools();
        let dir = self.built.get_or_init(|| {
            // Held until the snapshot is taken: another build must not swap the ELFs first.
            let _g = BUILD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
            build_locked(self.features, self.bins)?;
            let release = root().join("target/firmware").join(TARGET).join("release");
            let snapshot = root().join("target/firmware").join(self.snapshot);
            std::fs::create_dir_all(&snapshot).map_err(|e| e.to_string())?;
            for entry in std::fs::read_dir(&release).map_err(|e| e.to_string())? {
                let path = entry.map_err(|e| e.to_string())?.path();
                let name = path
                    .file_name()
                    .and_then(|n| n.to_str())
                    .unwrap_or_default();
                let wanted = self.bins.is_empty() || self.bins.contains(&name);
                if wanted && path.is_file() && path.extension().is_none() {
                    std::fs::copy(&path, snapshot.join(name))
                        .map_err(|e| format!("copy {}: {e}", path.display()))?;
                }
            }
            Ok(snapshot)
        });
        match dir {
            Ok(d) => d.join(bin),
            Err(e) => panic!("building the QEMU firmware failed:\n{e}"),
        }
    }

    /// Runs firmware `bin` in QEMU with `args` on its command line.
    pub fn run_with(&self, bin: &str, args: &[&str], timeout: Duration, echo: bool) -> Outcome {
        let elf = self.path(bin);
        let cfg = Config {
            timeout,
            echo: if echo { Echo::Stderr } else { Echo::None },
            firmware_args: args.iter().map(|s| s.to_string()).collect(),
            ..Config::default()
        };
        if echo {
            eprintln!("--- qemu: {bin} {}", args.join(" "));
        }
        qemu_run::run(&elf, &cfg).unwrap_or_else(|e| panic!("running {bin} in QEMU: {e}"))
    }
}

/// The firmware of the scenario suite.
pub static SCENARIO_FIRMWARE: FirmwareSet = FirmwareSet::new(
    &[
        "scenarios",
        "bench_seq",
        "bench_scale",
        "bench_grid",
        "bench_size",
        "smoke",
        "demo",
    ],
    "qemu-harness",
);

/// The scenarios firmware built with the portable `critical-section` lock (board feature
/// `critical-section-lock`): its rtseq sections mask interrupts.
pub static SCENARIO_FIRMWARE_CS: FirmwareSet =
    FirmwareSet::with_features("critical-section-lock", &["scenarios"], "qemu-harness-cs");

/// Path of a scenario-suite firmware.
pub fn firmware(bin: &str) -> PathBuf {
    SCENARIO_FIRMWARE.path(bin)
}

/// Runs firmware `bin` in QEMU with `args` on its command line; `echo` the log to stderr.
pub fn run_quiet(bin: &str, args: &[&str], echo: bool) -> Outcome {
    SCENARIO_FIRMWARE.run_with(bin, args, RUN_TIMEOUT, echo)
}

/// Runs firmware `bin` in QEMU with `args`, echoing its log.
pub fn run(bin: &str, args: &[&str]) -> Outcome {
    run_quiet(bin, args, true)
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
