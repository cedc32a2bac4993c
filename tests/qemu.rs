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
//! Adding a scenario: add a binary `boards/qemu-f405/src/bin/NAME.rs` with its `[[bin]]`
//! entry (`test = false`, as the others) in `boards/qemu-f405/Cargo.toml` (or a mode of an
//! existing one, read from its command line with `board::args`), then a test here:
//! `let out = run("NAME", &["ARGS"]); expect_exit(&out, 0); expect_line(&out, "...");`. A
//! QEMU suite of its own is a file `tests/qemu_*.rs`: the published package leaves those
//! out (Cargo.toml's `exclude`), with the harness they share; they need no `[[test]]`.

mod qemu_harness;

use std::path::PathBuf;
use std::time::Duration;

use qemu_harness::{expect_exit, expect_line, try_build, FirmwareSet, Outcome, RUN_TIMEOUT};
use qemu_run::Status;

/// Every bin of the board.
static FIRMWARE: FirmwareSet = FirmwareSet::new(&[], "qemu-suite");

/// Path of firmware `bin` built with the default features (all bins built on first use).
pub fn firmware(bin: &str) -> PathBuf {
    FIRMWARE.path(bin)
}

/// Runs firmware `bin` in QEMU with `args` on its command line.
pub fn run(bin: &str, args: &[&str]) -> Outcome {
    run_with(bin, args, RUN_TIMEOUT)
}

/// [`run`] with an explicit host-time limit.
pub fn run_with(bin: &str, args: &[&str], timeout: Duration) -> Outcome {
    FIRMWARE.run_with(bin, args, timeout, true)
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

/// The README's minimal firmware homes in 50 ms (1 mm at 20 µm per 1 ms tick), and the
/// README shows that very file.
#[test]
fn minimal_firmware_homes_and_is_the_readme_s() {
    let out = run("minimal", &[]);
    expect_exit(&out, 0);
    assert_eq!(out.malformed, 0, "{}", out.transcript());
    expect_line(&out, "minimal: homing Completed at 50000 us");
    let root = env!("CARGO_MANIFEST_DIR");
    let file = std::fs::read_to_string(format!("{root}/boards/qemu-f405/src/bin/minimal.rs"))
        .expect("minimal.rs");
    let readme = std::fs::read_to_string(format!("{root}/README.md")).expect("README.md");
    let block = format!("```rust,ignore\n{file}```\n");
    assert!(
        readme.contains(&block),
        "README's RTIC section is not minimal.rs"
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

/// A configuration error found by `Sequencer::validate` on the target is logged in the
/// words of its `Display` form (the defmt form is written to match).
#[test]
fn invalid_configuration_is_logged_as_on_the_host() {
    use rtseq::{ConfigError, MonitorId, Raiser, SeqId};
    let out = run("panic", &["config"]);
    expect_exit(&out, 1);
    let host = ConfigError::ExceptionWithoutLane {
        raiser: Raiser::Monitor(MonitorId::from_index(0), "jam"),
        exception: (SeqId::from_index(0), "safe stop"),
    };
    expect_line(
        &out,
        &format!("panic firmware: invalid configuration: {host}"),
    );
}

/// A declared lane that no task polls (its task was never spawned) would take the safe
/// stop's start and never run it: `check_lanes` at the top of `idle`, where every task
/// spawned in `init` has run up to its first wait, names it.
#[test]
fn a_lane_no_task_polls_is_named_at_the_top_of_idle() {
    let out = run("panic", &["lanes"]);
    expect_exit(&out, 1);
    expect_line(
        &out,
        "panic firmware: sequence `safe stop` has no lane that a task polls",
    );
}

/// Values logged with names on the target (`WithNames`'s defmt forms) read as the host
/// prints them (`Display`), from the same tables: the firmware's sequencer (`main`,
/// `safe stop`) and monitor (`jam`), failure codes (1: `part lost`) and safety levels
/// (`off`, `powered`).
#[test]
fn names_print_on_the_target_as_on_the_host() {
    use rtseq::safety::{
        CriticalInput, CriticalInputInfo, LevelDef, SafetyLevel, SafetyProperties,
    };
    use rtseq::{
        Behaviour, Cause, Entry, Error, Event, Failure, Failures, Instant, Monitor, MonitorId,
        Monitors, Outcome, Record, Request, Requester, RunningState, SeqConfig, SeqId, Sequencer,
        Transition, WithNames,
    };
    const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    const CURRENT: CriticalInput<f32> = CriticalInput::new(3, "current");
    static INPUTS: [CriticalInputInfo; 1] = [ESTOP.info()];
    let out = run("panic", &["names"]);
    expect_exit(&out, 0);
    let seq: Sequencer<(), 2> = Sequencer::new();
    seq.register(SeqConfig::new("safe stop")).unwrap();
    let main = seq.register(SeqConfig::new("main")).unwrap();
    let mut jammed = |_: &(), _: Instant| false;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let jam = monitors
        .add(
            main,
            Monitor::new("jam", &mut jammed, Behaviour::AbortOwner),
        )
        .unwrap();
    let failures = Failures(&[(1, "part lost")]);
    let levels: SafetyProperties<'static, (), 2> = SafetyProperties::new(
        [
            LevelDef::new(SafetyLevel::new(0), "off"),
            LevelDef::new(SafetyLevel::new(1), "powered"),
        ],
        &INPUTS,
        &[],
        &[],
        SafetyLevel::new(0),
    );
    let names = (&seq, &monitors, (&failures, &levels));
    let at = |us: u64, cause: Cause| Transition {
        time: Instant::from_ticks(us),
        sequence: main,
        from: RunningState::Running,
        to: RunningState::Aborting,
        cause,
    };
    let host = [
        main.named(&names).to_string(),
        SeqId::from_index(7).named(&names).to_string(),
        jam.named(&names).to_string(),
        MonitorId::from_index(5).named(&names).to_string(),
        Cause::Timeout(main).named(&names).to_string(),
        Cause::AbortAll.named(&names).to_string(),
        Outcome::Aborted(Cause::Monitor(jam))
            .named(&names)
            .to_string(),
        Outcome::Completed.named(&names).to_string(),
        Failure::App(1).named(&names).to_string(),
        Failure::App(9).named(&names).to_string(),
        Failure::Aborted(Cause::Abort).named(&names).to_string(),
        Failure::NotStarted(Error::AlreadyRunning(main))
            .named(&names)
            .to_string(),
        at(12_500, Cause::Monitor(jam)).named(&names).to_string(),
        at(3_000, Cause::Abort).named(&names).to_string(),
        SafetyLevel::new(1).named(&names).to_string(),
        SafetyLevel::new(4).named(&names).to_string(),
    ];
    // One event of each kind, as the firmware logs them, and a record.
    let stop = SeqId::from_index(0);
    let events = [
        Event::Fired {
            owner: main,
            cause: Cause::Monitor(jam),
            behaviour: Behaviour::AbortOwner,
        },
        Event::Fired {
            owner: main,
            cause: Cause::Timeout(main),
            behaviour: Behaviour::RestartOwner,
        },
        Event::ExceptionNotRun {
            exception: stop,
            owner: main,
            why: Error::NoLane(stop),
        },
        Event::Requested {
            sequence: main,
            request: Request::Pause,
            by: Requester::Sequence(stop),
        },
        Event::AbortAll {
            by: Requester::SafetySystem,
        },
        Event::Failed {
            sequence: main,
            failure: Failure::App(1),
        },
        Event::SafetyLevel {
            level: SafetyLevel::new(1),
        },
        Event::InputTripped { input: ESTOP.id() },
        Event::InputTripped {
            input: CURRENT.id(),
        },
    ];
    let mut host: Vec<String> = host.into_iter().collect();
    host.extend(events.iter().map(|e| e.named(&names).to_string()));
    let record = Record {
        time: Instant::from_ticks(12_500),
        entry: Entry::Event(Event::AbortAll {
            by: Requester::Application,
        }),
    };
    host.push(record.named(&names).to_string());
    // Errors print with the names of the sequences they name, on both sides.
    assert_eq!(host[11], "not started: sequence `main` is already running");
    assert_eq!(
        host[18],
        "exception sequence `safe stop` of `main` not run: sequence `safe stop` has no lane that a task polls"
    );
    let target: Vec<&str> = out
        .lines
        .iter()
        .filter_map(|l| l.message.strip_prefix("names: "))
        .collect();
    assert_eq!(target, host, "{}", out.transcript());
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
