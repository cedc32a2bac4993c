//! The safety system in QEMU under RTIC (issue 4), from plain `cargo test`:
//!
//! * `safety` firmware (`boards/qemu-f405/src/bin/safety.rs`): the scenario of
//!   `boards/qemu-f405/src/bin/safety/scenario.rs` in the highest-priority task, with a lane
//!   preempted by it. The same scenario file is compiled into this test and run on the
//!   host: every cycle record the firmware logs must equal the host's, line by line, and
//!   the digests must match.
//! * `emergency` firmware (`boards/qemu-f405/src/bin/emergency.rs`): the host emergency
//!   scenario of `tests/emergency.rs` with the real `Sequencer` under RTIC.
//! * The no-panic proof of the safety firmware (`--features no-panic` links).
//!
//! Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target (`./x setup`); fails, never
//! skips, without them. Firmware is built with a nested cargo into `target/firmware` (as
//! `tests/qemu.rs` does) and copied to `target/firmware/qemu-safety/` so a later build with
//! other features cannot swap it under a running test.

mod qemu_harness;

use std::path::PathBuf;

use qemu_harness::{expect_exit, expect_line, try_build, FirmwareSet, Outcome, RUN_TIMEOUT};
use rtseq::safety::{SafetyHandle, SafetySystem};

#[path = "../boards/qemu-f405/src/bin/safety/scenario.rs"]
#[allow(dead_code)]
mod scenario;

/// The safety suite's firmware.
static FIRMWARE: FirmwareSet = FirmwareSet::new(&BINS, "qemu-safety");
const BINS: [&str; 2] = ["safety", "emergency"];

/// The nested board build of `bins` with `features` (the no-panic proof).
fn build(features: &str, bins: &[&str]) -> Result<(), String> {
    try_build(features, bins)
}

fn firmware(bin: &str) -> PathBuf {
    FIRMWARE.path(bin)
}

fn run(bin: &str) -> Outcome {
    run_args(bin, &[])
}

fn run_args(bin: &str, args: &[&str]) -> Outcome {
    FIRMWARE.run_with(bin, args, RUN_TIMEOUT, true)
}

fn number_after(message: &str, key: &str) -> u64 {
    let rest = &message[message
        .find(key)
        .unwrap_or_else(|| panic!("no {key:?} in {message:?}"))
        + key.len()..];
    let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("no number after {key:?} in {message:?}"))
}

// ---------------------------------------------------------------------------------------
// The scenario on the host
// ---------------------------------------------------------------------------------------

struct HostRun {
    records: Vec<scenario::Record>,
    digest: u32,
    aborts: u32,
}

/// The scenario on the host, in the order the chip applies it: the public events of cycle
/// `n` (triggered by the lane at tick `n - 1`), then the plant stimuli, then the cycle.
fn host_run() -> HostRun {
    let handle: &'static SafetyHandle = Box::leak(Box::new(SafetyHandle::new()));
    let mut system = SafetySystem::new_validated(&scenario::PROPS, handle).unwrap();
    let mut io = scenario::Io::new();
    let aborts = scenario::Aborts::default();
    let mut records = Vec::new();
    let mut digest = scenario::DIGEST_SEED;
    for n in 1..=scenario::CYCLES {
        for &e in scenario::public_events(n) {
            handle.trigger(e);
        }
        scenario::plant(n, &mut io);
        let report = system.cycle(&mut io, &aborts);
        let r = scenario::Record::new(n, &report, &io);
        digest = r.digest(digest);
        records.push(r);
    }
    HostRun {
        records,
        digest,
        aborts: aborts.0.get(),
    }
}

/// The firmware's log line of a record (same text as its defmt format string).
fn line(r: &scenario::Record) -> String {
    let o = r.outputs;
    format!(
        "safety: cycle {} level {} change {}>{} inputs {} unknown {} aborted {} out {} {} {} {} {} {} {} {}",
        r.cycle, r.level, r.from, r.to, r.input_events, r.unknown, r.aborted,
        o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7]
    )
}

#[test]
fn host_scenario_meets_every_expectation() {
    let h = host_run();
    for r in &h.records {
        assert_eq!(scenario::check(r), Ok(()), "{r:?}");
    }
    assert_eq!(h.aborts, scenario::EXPECTED_ABORTS);
    assert_eq!(h.records.len() as u32, scenario::CYCLES);
}

// ---------------------------------------------------------------------------------------
// The scenario in QEMU
// ---------------------------------------------------------------------------------------

/// The safety firmware runs the scenario in the highest-priority task, checks itself (exit
/// 0), and logs exactly the host's records; cycles 13–15 run on time while the lane
/// computes (preemption), every cycle starts within a bounded latency of its tick.
#[test]
fn qemu_safety_scenario_equals_the_host_and_preempts_the_lane() {
    let out = run("safety");
    expect_exit(&out, 0);
    assert_eq!(out.malformed, 0, "{}", out.transcript());
    expect_line(&out, "safety: all expectations hold");

    // Same records, in the same order, as on the host.
    let host = host_run();
    let want: Vec<String> = host.records.iter().map(line).collect();
    let got: Vec<&str> = out
        .messages()
        .filter(|m| m.starts_with("safety: cycle "))
        .collect();
    assert_eq!(got, want, "{}", out.transcript());
    let done = out.find("safety: done ").expect("done line");
    assert!(
        done.message.contains(&format!(
            "cycles={} digest={:#010x} aborts={} failures=0",
            scenario::CYCLES,
            host.digest,
            host.aborts
        )),
        "{} (host digest {:#010x})",
        done.message,
        host.digest
    );

    // Timing: the record of cycle n is logged within 10 µs after tick n, also while the
    // lane computes; the latency from the tick interrupt to the cycle is bounded.
    for n in 1..=u64::from(scenario::CYCLES) {
        let rec = out
            .lines
            .iter()
            .find(|l| l.message.starts_with(&format!("safety: cycle {n} level")))
            .expect("record line");
        let t = rec.time_us.expect("timestamp");
        assert!(
            (n * 1000..n * 1000 + 10).contains(&t),
            "cycle {n} logged at {t} us"
        );
        let timing = out
            .find(&format!("safety: timing cycle {n} tick "))
            .expect("timing line");
        assert_eq!(number_after(&timing.message, " tick "), n * 1000);
        assert!(number_after(&timing.message, "latency ") <= 1000);
        let busy = timing.message.ends_with("lane busy true");
        assert_eq!(busy, (13..=15).contains(&n), "{}", timing.message);
    }
    // The lane's computation spans ticks 12..15 and saw 3 safety cycles happen.
    let lane = out.find("lane: busy from ").expect("lane line");
    let (from, to) = (
        number_after(&lane.message, "busy from "),
        number_after(&lane.message, " us to "),
    );
    assert!(from > 12_000 && from < 12_100, "{}", lane.message);
    assert!(to > 15_000 && to < 16_000, "{}", lane.message);
    assert!(
        lane.message.ends_with("safety cycles 12 -> 15 meanwhile"),
        "{}",
        lane.message
    );
}

/// The README figures, measured by the safety firmware's `init`: printed here, and guarded
/// against regressions (the budget is 400; see the README's safety section).
#[test]
fn qemu_safety_cycle_figures() {
    let out = run("safety");
    expect_exit(&out, 0);
    let quiet = out
        .find("figures: cycle, 8 levels x 8 inputs x 8 outputs, no transition = ")
        .expect("figure");
    let n = number_after(&quiet.message, "no transition = ");
    let t = number_after(
        &out.find("figures: cycle with a transition")
            .expect("figure")
            .message,
        ") = ",
    );
    eprintln!("safety cycle: {n} instructions without transition, {t} with one");
    for l in out
        .lines
        .iter()
        .filter(|l| l.message.starts_with("figures:"))
    {
        eprintln!("{}", l.message);
    }
    assert!(n <= 400, "over the budget: {n} instructions per cycle");
    assert!(
        t <= 850,
        "regression: {t} instructions per cycle with a transition"
    );
}

/// No-panic proof: the safety and emergency firmware link with `--features no-panic`.
#[test]
fn safety_firmware_is_panic_free() {
    firmware("safety"); // the default build first (and its snapshot)
    if let Err(e) = build("no-panic", &BINS) {
        panic!("a panic path survived in the safety firmware (or the build failed):\n{e}");
    }
}

// ---------------------------------------------------------------------------------------
// The emergency scenario with the real Sequencer under RTIC
// ---------------------------------------------------------------------------------------

/// The trace of powering up (ids in registration order: 0 power on, 1 start moving,
/// 2 travel A, 3 move A, 4 travel B, 5 report fault, 6 axis B, 7 main) — the same as
/// `tests/emergency.rs` on the host.
const POWER_UP: [&str; 9] = [
    "trace: 1 ms #7 Idle -> Running (Start)",
    "trace: 1 ms #0 Idle -> Running (Start)",
    "trace: 4 ms #0 Running -> Terminated (Completed)",
    "trace: 4 ms #6 Idle -> Running (Start)",
    "trace: 4 ms #3 Idle -> Running (Start)",
    "trace: 4 ms #1 Idle -> Running (Start)",
    "trace: 4 ms #4 Idle -> Running (Start)",
    "trace: 5 ms #1 Running -> Terminated (Completed)",
    "trace: 5 ms #2 Idle -> Running (Start)",
];

fn aborted_at_11(ids: &[usize]) -> Vec<String> {
    ids.iter()
        .flat_map(|i| {
            [
                format!("trace: 11 ms #{i} Running -> Aborting (AbortAll)"),
                format!("trace: 11 ms #{i} Aborting -> Aborted (AbortAll)"),
            ]
        })
        .collect()
}

/// Common checks: exit 0, the exact trace, the safety cycle that enters EMERGENCY at
/// 11 ms (safe outputs, abort-all), every sequence stopped within 100 µs of that tick.
fn check_emergency(out: &Outcome, want_trace: &[String], cycle_10_inputs: u32) {
    expect_exit(out, 0);
    expect_line(out, "emergency: all expectations hold");
    let trace: Vec<&str> = out
        .messages()
        .filter(|m| m.starts_with("trace: "))
        .collect();
    assert_eq!(trace, want_trace, "{}", out.transcript());
    // The sequencer's events, as on the host: the levels, the tripped input (estop only),
    // EMERGENCY and the abort-all it asks for, in the tick after each safety cycle.
    let level = |ms: u32, id: u8| {
        format!("event: {ms} ms Some(SafetyLevel {{ level: SafetyLevel({id}) }})")
    };
    let mut want_events: Vec<String> = [(1, 1), (2, 2), (4, 3), (5, 4)]
        .map(|(ms, id)| level(ms, id))
        .to_vec();
    if cycle_10_inputs != 0 {
        want_events.push("event: 10 ms Some(InputTripped { input: InputId(0) })".into());
    }
    want_events.push(level(11, 0));
    want_events.push("event: 11 ms Some(AbortAll { by: SafetySystem })".into());
    let events: Vec<&str> = out
        .messages()
        .filter(|m| m.starts_with("event: "))
        .collect();
    assert_eq!(events, want_events, "{}", out.transcript());
    expect_line(
        out,
        &format!(
            "safety: cycle 10 at 10000 us level 4 entered false inputs {cycle_10_inputs} aborted false enable true lamp true"
        ),
    );
    let entering = expect_line(
        out,
        &format!(
            "safety: cycle 11 at 11000 us level 0 entered true inputs {cycle_10_inputs} aborted true enable false lamp false"
        ),
    );
    let t = entering.time_us.expect("timestamp");
    assert!((11_000..11_010).contains(&t), "cycle 11 at {t} us");
    // The aborts are logged (by idle) right after the tick at 11 ms.
    let first_abort = out
        .lines
        .iter()
        .find(|l| l.message.contains("(AbortAll)"))
        .expect("abort line");
    assert!(first_abort.time_us.expect("timestamp") < 11_100);
    let done = out.find("emergency: done ").expect("done line");
    let stopped = number_after(&done.message, "all_stopped_us=");
    assert!(
        (11_000..11_100).contains(&stopped),
        "every sequence stopped at {stopped} us"
    );
    assert!(done.message.contains("failures=0 cycle_failures=0"));
    assert!(done.message.ends_with("level=0 enable=false"));
}

/// Emergency-stop input pressed at 10 ms while the tree runs: cycle 10 sees the input
/// fire, cycle 11 enters EMERGENCY and the tick at 11 ms aborts the five running sequences
/// innermost first; every sequence is `Aborted` (or completed before, or never started).
#[test]
fn qemu_emergency_estop_aborts_every_sequence_within_one_safety_cycle() {
    let out = run_args("emergency", &["estop"]);
    let mut want: Vec<String> = POWER_UP.iter().map(|s| s.to_string()).collect();
    want.extend(aborted_at_11(&[2, 4, 3, 6, 7]));
    check_emergency(&out, &want, 1);
    for (i, state) in [
        (0, "power on Terminated Some(Completed)"),
        (1, "start moving Terminated Some(Completed)"),
        (2, "travel A Aborted Some(Aborted(AbortAll))"),
        (3, "move A Aborted Some(Aborted(AbortAll))"),
        (4, "travel B Aborted Some(Aborted(AbortAll))"),
        (5, "report fault Idle None"),
        (6, "axis B Aborted Some(Aborted(AbortAll))"),
        (7, "main Aborted Some(Aborted(AbortAll))"),
    ] {
        expect_line(&out, &format!("final: #{i} {state}"));
    }
}

/// Axis B triggers the public FAULT event at 10 ms: the same within one safety cycle.
#[test]
fn qemu_emergency_public_fault_from_a_sequence_aborts_every_sequence() {
    let out = run_args("emergency", &["fault"]);
    let mut want: Vec<String> = POWER_UP.iter().map(|s| s.to_string()).collect();
    want.push("trace: 10 ms #4 Running -> Terminated (Completed)".into());
    want.push("trace: 10 ms #5 Idle -> Running (Start)".into());
    want.extend(aborted_at_11(&[2, 5, 3, 6, 7]));
    check_emergency(&out, &want, 0);
    expect_line(
        &out,
        "final: #5 report fault Aborted Some(Aborted(AbortAll))",
    );
    expect_line(&out, "final: #4 travel B Terminated Some(Completed)");
}
