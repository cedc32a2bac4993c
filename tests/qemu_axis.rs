//! QEMU suite of `boards/qemu-f405/src/bin/axis.rs`: a single linear axis written from the
//! user docs alone (homing with a timeout, moves commanded from an interrupt-driven
//! command task, a following-error monitor with a safe stop and a restart limit, an
//! end-stop monitor, a safety system with an e-stop). The firmware simulates the axis and
//! runs a scripted scenario per mode; each test asserts the sequencer's records, which the
//! firmware's `idle` drains and logs as `rec: <record>` lines, against the timings
//! docs/semantics.md promises.
//!
//! Run: `CARGO_BUILD_JOBS=1 cargo test --test qemu_axis` (needs `./x setup`).

mod qemu_harness;

use qemu_harness::{expect_exit, expect_line, FirmwareSet, Outcome, RUN_TIMEOUT};

static AXIS: FirmwareSet = FirmwareSet::new(&["axis"], "qemu-axis");

/// The `rec:` lines of a run, without the prefix.
fn records(out: &Outcome) -> Vec<String> {
    out.lines
        .iter()
        .filter_map(|l| l.message.strip_prefix("rec: ").map(str::to_string))
        .collect()
}

/// How many records the firmware says it drained (`final: records N`).
fn drained(out: &Outcome) -> usize {
    out.lines
        .iter()
        .find_map(|l| l.message.strip_prefix("final: records "))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no `final: records` line:\n{}", out.transcript()))
}

/// Runs `mode`: exit 0 (the board exits with 104 instead when its logger lost bytes), no
/// malformed frame, and every record the firmware drained reached the host.
fn run(mode: &str) -> Outcome {
    let out = AXIS.run_with("axis", &[mode], RUN_TIMEOUT, true);
    expect_exit(&out, 0);
    assert_eq!(out.malformed, 0, "{}", out.transcript());
    assert_eq!(records(&out).len(), drained(&out), "{}", out.transcript());
    out
}

fn has(recs: &[String], line: &str) -> bool {
    recs.iter().any(|r| r == line)
}

fn expect_records(out: &Outcome, lines: &[&str]) {
    let recs = records(out);
    for l in lines {
        assert!(
            has(&recs, l),
            "no record {l:?}; records:\n{}",
            recs.join("\n")
        );
    }
}

/// The whole main scenario, record by record. Each timing checked against semantics.md:
/// * homing: 1 000 µm at 20 µm/tick, the safety system's first cycle (1 ms) enables the
///   drive: the seek step's exit condition holds at 50 ms;
/// * requests (pause 120, resume 140, abort 250) from the command task (priority 2, pended
///   after the tick) apply at the next tick (item 8): 121, 141, 251; the cleanup order is
///   innermost first (item 4);
/// * following error (jam from 320 ms, limit 1 000 µm at 100 µm/tick): true at 330, fires
///   in that tick (1 ms polling); the safe stop runs and ends in its lane at 330; the
///   behaviour applies at the next tick (item 3): restart at 331; again at 342/343; the
///   third firing is escalated (restart_limit 2) to AbortOwner: aborted at 355;
/// * end stop closed at 450 (before the tick): no exception sequence, so the abort comes in
///   the firing tick itself (item 3);
/// * e-stop pressed at 520 before the safety cycle: tripped at 520, level emergency and
///   every sequence aborted at 521 (semantics.md "Emergency", safety.md).
const MAIN_TRACE: &[&str] = &[
    "0 ms homing: Idle -> Running (start)",
    "0 ms seek: Idle -> Running (start)",
    "1 ms safety level run",
    "50 ms seek: Running -> Terminated (completed)",
    "50 ms homing: Running -> Terminated (completed)",
    "100 ms move: Idle -> Running (start)",
    "100 ms move to: Idle -> Running (start)",
    "120 ms pause of `move` requested by the application",
    "121 ms move: Running -> Paused (pause)",
    "121 ms move to: Running -> Paused (pause)",
    "140 ms resume of `move` requested by the application",
    "141 ms move: Paused -> Running (resume)",
    "141 ms move to: Paused -> Running (resume)",
    "170 ms move to: Running -> Terminated (completed)",
    "170 ms move: Running -> Terminated (completed)",
    "200 ms move: Terminated -> Running (start)",
    "200 ms move to: Terminated -> Running (start)",
    "250 ms abort of `move` requested by the application",
    "251 ms move to: Running -> Aborting (abort)",
    "251 ms move to: Aborting -> Aborted (abort)",
    "251 ms move: Running -> Aborting (abort)",
    "251 ms move: Aborting -> Aborted (abort)",
    "300 ms move: Aborted -> Running (start)",
    "300 ms move to: Aborted -> Running (start)",
    "330 ms monitor `following error` of `move` fired: RestartOwner",
    "330 ms safe stop: Idle -> Running (monitor `following error`)",
    "330 ms safe stop: Running -> Terminated (completed)",
    "331 ms move to: Running -> Aborting (monitor `following error`)",
    "331 ms move to: Aborting -> Aborted (monitor `following error`)",
    "331 ms move: Running -> Restarting (monitor `following error`)",
    "331 ms move: Restarting -> Running (restart)",
    "331 ms move to: Aborted -> Running (start)",
    "342 ms monitor `following error` of `move` fired: RestartOwner",
    "342 ms safe stop: Terminated -> Running (monitor `following error`)",
    "342 ms safe stop: Running -> Terminated (completed)",
    "343 ms move to: Running -> Aborting (monitor `following error`)",
    "343 ms move to: Aborting -> Aborted (monitor `following error`)",
    "343 ms move: Running -> Restarting (monitor `following error`)",
    "343 ms move: Restarting -> Running (restart)",
    "343 ms move to: Aborted -> Running (start)",
    "354 ms monitor `following error` of `move` fired: AbortOwner",
    "354 ms safe stop: Terminated -> Running (monitor `following error`)",
    "354 ms safe stop: Running -> Terminated (completed)",
    "355 ms move to: Running -> Aborting (monitor `following error`)",
    "355 ms move to: Aborting -> Aborted (monitor `following error`)",
    "355 ms move: Running -> Aborting (monitor `following error`)",
    "355 ms move: Aborting -> Aborted (monitor `following error`)",
    "400 ms move: Aborted -> Running (start)",
    "400 ms move to: Aborted -> Running (start)",
    "450 ms monitor `end stop` of `move` fired: AbortOwner",
    "450 ms move to: Running -> Aborting (monitor `end stop`)",
    "450 ms move to: Aborting -> Aborted (monitor `end stop`)",
    "450 ms move: Running -> Aborting (monitor `end stop`)",
    "450 ms move: Aborting -> Aborted (monitor `end stop`)",
    "500 ms move: Aborted -> Running (start)",
    "500 ms move to: Aborted -> Running (start)",
    "520 ms critical input `e-stop` tripped",
    "521 ms safety level emergency",
    "521 ms abort-all requested by the safety system",
    "521 ms move to: Running -> Aborting (abort-all)",
    "521 ms move to: Aborting -> Aborted (abort-all)",
    "521 ms move: Running -> Aborting (abort-all)",
    "521 ms move: Aborting -> Aborted (abort-all)",
];

#[test]
fn axis_main_scenario_matches_the_documented_timings() {
    let out = run("main");
    assert_eq!(records(&out), MAIN_TRACE, "{}", out.transcript());
    for l in [
        "cmd: 100 ms start ok",
        "cmd: 120 ms pause ok",
        "cmd: 140 ms resume ok",
        "cmd: 250 ms abort ok",
        "final: move aborted (abort-all)",
        "final: position 15200 enable false tick errors 0 exceptions not run 0",
    ] {
        expect_line(&out, l);
    }
}

/// A broken reference switch: the homing timeout (500 ms) fires at 500, its exception
/// sequence runs at once, the `AbortOwner` applies at the next tick (the README's homing
/// example shows the same shape).
#[test]
fn axis_homing_timeout_runs_the_safe_stop_then_aborts() {
    let out = run("homing-timeout");
    assert_eq!(
        records(&out),
        [
            "0 ms homing: Idle -> Running (start)",
            "0 ms seek: Idle -> Running (start)",
            "1 ms safety level run",
            "500 ms timeout of `homing` ran out: AbortOwner",
            "500 ms safe stop: Idle -> Running (timeout of `homing`)",
            "500 ms safe stop: Running -> Terminated (completed)",
            "501 ms seek: Running -> Aborting (timeout of `homing`)",
            "501 ms seek: Aborting -> Aborted (timeout of `homing`)",
            "501 ms homing: Running -> Aborting (timeout of `homing`)",
            "501 ms homing: Aborting -> Aborted (timeout of `homing`)",
        ],
        "{}",
        out.transcript()
    );
}

/// "Timeouts count unpaused time": homing paused 101..151 ms runs out at 550, not 500.
#[test]
fn axis_homing_timeout_excludes_paused_time() {
    let out = run("homing-pause");
    expect_records(
        &out,
        &[
            "101 ms homing: Running -> Paused (pause)",
            "101 ms seek: Running -> Paused (pause)",
            "151 ms homing: Paused -> Running (resume)",
            "550 ms timeout of `homing` ran out: AbortOwner",
            "551 ms homing: Aborting -> Aborted (timeout of `homing`)",
        ],
    );
    assert!(!has(
        &records(&out),
        "500 ms timeout of `homing` ran out: AbortOwner"
    ));
}

/// Monitors polled every 10 ms: the grid starts one period after the start into an idle
/// class (300 -> 310, 320, 330) and a restart does not move it; a monitor reacts within one
/// polling period: the following error (true from 330, 342, 362) fires at 330, 350, 370;
/// the end stop closed at 455 fires at 460.
#[test]
fn axis_slow_polling_reacts_on_the_polling_grid() {
    let out = run("slow-poll");
    expect_records(
        &out,
        &[
            "330 ms monitor `following error` of `move` fired: RestartOwner",
            "331 ms move: Running -> Restarting (monitor `following error`)",
            "350 ms monitor `following error` of `move` fired: RestartOwner",
            "351 ms move: Restarting -> Running (restart)",
            "370 ms monitor `following error` of `move` fired: AbortOwner",
            "371 ms move: Aborting -> Aborted (monitor `following error`)",
            "460 ms monitor `end stop` of `move` fired: AbortOwner",
            "460 ms move: Aborting -> Aborted (monitor `end stop`)",
        ],
    );
}

/// An operator's abort while the safe stop (exception sequence) runs: the safe stop ends
/// before the next tick, so that tick applies the restart first, then the abort request
/// (semantics items 3, 4, 8, 10): aborted from `Restarting` with the cause `abort`.
#[test]
fn axis_abort_during_the_exception_aborts_from_restarting() {
    let out = run("abort-in-exception");
    let recs = records(&out);
    let at_331: Vec<&str> = recs
        .iter()
        .filter(|r| r.starts_with("331 ms "))
        .map(String::as_str)
        .collect();
    assert_eq!(
        at_331,
        [
            "331 ms move to: Running -> Aborting (monitor `following error`)",
            "331 ms move to: Aborting -> Aborted (monitor `following error`)",
            "331 ms move: Running -> Restarting (monitor `following error`)",
            "331 ms move: Restarting -> Aborting (abort)",
            "331 ms move: Aborting -> Aborted (abort)",
        ],
        "{}",
        out.transcript()
    );
    assert!(
        !recs.iter().any(|r| r.starts_with("342 ms")),
        "no second firing"
    );
}

/// The axis stays on the end stop: a move started there (500 ms) is aborted at its first
/// poll (501), since a monitor starts every run from "false" (semantics item 5).
#[test]
fn axis_move_started_on_a_closed_end_stop_is_aborted_at_its_first_poll() {
    let out = run("endstop-held");
    expect_records(
        &out,
        &[
            "500 ms move: Aborted -> Running (start)",
            "501 ms monitor `end stop` of `move` fired: AbortOwner",
            "501 ms move: Aborting -> Aborted (monitor `end stop`)",
        ],
    );
}

/// FRICTION (documented in semantics.md item 4 only): a pause requested while the
/// following-error safe stop runs returns `Ok` and is recorded, but the restart the next
/// tick applies drops it without a record, and the operator's resume is then refused with
/// `NotPaused`. A feed hold built as the docs suggest (hold in the control system, then
/// `Handle::pause`) is left holding the axis while the sequence runs on.
#[test]
fn axis_pause_during_the_exception_is_dropped_by_the_restart() {
    let out = run("pause-in-exception");
    expect_line(&out, "cmd: 330 ms pause ok");
    expect_line(
        &out,
        "cmd: 340 ms resume refused: sequence `move` is not paused",
    );
    let recs = records(&out);
    assert!(has(
        &recs,
        "330 ms pause of `move` requested by the application"
    ));
    let paused_after_330 = recs.iter().any(|r| {
        let ms: u64 = r
            .split(' ')
            .next()
            .and_then(|t| t.parse().ok())
            .unwrap_or(0);
        ms >= 330 && r.contains("-> Paused")
    });
    assert!(!paused_after_330, "{}", recs.join("\n"));
}

/// The board's logger (`boards/qemu-f405/src/logger.rs`) loses no frame silently: every
/// record the firmware drains reaches the host, run after run (`run` checks the count).
#[test]
fn log_frames_are_never_lost_silently() {
    for _ in 0..5 {
        run("main");
    }
}

/// A host that refuses the log (here: QEMU's stdout is a pipe whose reader has gone, so
/// each `SYS_WRITE` fails with `EPIPE`) makes the run fail: the logger gives up after 100 000
/// refused writes, counts the bytes, and the firmware's successful exit becomes exit code 104.
#[test]
fn log_bytes_the_host_refuses_fail_the_run() {
    let elf = AXIS.path("axis");
    let cfg = qemu_harness::Config {
        firmware_args: vec!["main".into()],
        ..qemu_harness::Config::default()
    };
    let mut child = qemu_run::qemu_command(&elf, &cfg)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start QEMU");
    drop(child.stdout.take()); // nobody reads the log
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for QEMU") {
            break s;
        }
        if start.elapsed() > RUN_TIMEOUT {
            let _ = child.kill();
            panic!("QEMU did not end within {RUN_TIMEOUT:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert_eq!(status.code(), Some(qemu_run::EXIT_LOG_LOST), "{status:?}");
}
