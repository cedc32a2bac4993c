//! QEMU suite: the hand-written RTIC baseline of `./x bench`'s comparison (`bench_hand`)
//! runs and prints every figure `./x bench` compares with rtseq's (`bench_seq`, asserted by
//! tests/qemu_scenarios.rs). Only checks that the figures are there and plausible: the
//! comparison itself is `./x bench`'s.

mod qemu_harness;

use std::time::Duration;

use qemu_harness::{expect_exit, FirmwareSet};

static FIRMWARE: FirmwareSet = FirmwareSet::new(&["bench_hand"], "qemu-bench");

/// `N` from the first line containing `key = N`.
fn figure(out: &qemu_harness::Outcome, key: &str) -> u64 {
    let pat = format!("{key} = ");
    let l = out
        .lines
        .iter()
        .find(|l| l.message.contains(&pat))
        .unwrap_or_else(|| panic!("no line with {pat:?}:\n{}", out.transcript()));
    let rest = &l.message[l.message.find(&pat).unwrap_or(0) + pat.len()..];
    rest.split(|c: char| !c.is_ascii_digit())
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after {pat:?} in {:?}", l.message))
}

#[test]
fn hand_written_baseline_prints_every_compared_figure() {
    let out = FIRMWARE.run_with("bench_hand", &[], Duration::from_secs(60), true);
    expect_exit(&out, 0);
    for key in [
        "bench_hand: tick 8 x 4 due, nothing firing",
        "bench_hand: period CPU 8 x 4 due (tick entry -> idle)",
        "bench_hand: exit poll (one lane, due, condition false)",
        "bench_hand: tick nothing due (8 running)",
        "bench_hand: tick 1 monitor fires AbortOwner",
        "tick entry -> Aborted",
        "tick entry -> exception",
    ] {
        let n = figure(&out, key);
        assert!(n > 0 && n < 100_000, "{key} = {n}\n{}", out.transcript());
    }
    // The due period includes the tick and the 8 exit polls.
    assert!(
        figure(
            &out,
            "bench_hand: period CPU 8 x 4 due (tick entry -> idle)"
        ) > figure(&out, "bench_hand: tick 8 x 4 due, nothing firing"),
        "{}",
        out.transcript()
    );
}
