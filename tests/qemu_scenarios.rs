//! The on-target scenario suite: every scenario of `rtseq-scenarios` runs on the host in
//! `rtseq::sim::Sim` and under RTIC in QEMU (firmware `boards/qemu-f405/src/bin/scenarios.rs`,
//! one QEMU run per scenario), and the two transition traces and action summaries must be
//! **equal**. Plus the scenario firmware's no-panic proof, and the benchmark budgets
//! (firmware `bench_seq`).
//!
//! Run by plain `cargo test` at the repository root. Needs `qemu-system-arm` and the
//! `thumbv7em-none-eabihf` target; if either is missing the tests fail with a message saying
//! to run `./x setup`.
//!
//! Adding a scenario: add it to `rtseq_scenarios::SCENARIOS` (see that crate's docs); this
//! suite runs every entry of the list.

mod qemu_harness;

use qemu_harness::*;
use rtseq::Transition;
use rtseq_scenarios::{decode, host, Summary, SCENARIOS};

/// What the firmware printed: its trace, summary and lost count.
struct Target {
    trace: Vec<Transition>,
    summary: Option<(Summary, u32)>,
    bad: Vec<String>,
}

fn parse(out: &Outcome) -> Target {
    let mut t = Target {
        trace: Vec::new(),
        summary: None,
        bad: Vec::new(),
    };
    for l in &out.lines {
        if let Some(rest) = l.message.strip_prefix("T ") {
            let v: Vec<u32> = rest.split(' ').filter_map(|x| x.parse().ok()).collect();
            match <[u32; 6]>::try_from(v.as_slice())
                .ok()
                .and_then(|e| decode(&e))
            {
                Some(tr) => t.trace.push(tr),
                None => t.bad.push(l.message.clone()),
            }
        } else if let Some(rest) = l.message.strip_prefix("S ") {
            let field = |k: &str| {
                rest.split(' ')
                    .find_map(|kv| kv.strip_prefix(k)?.strip_prefix('='))
                    .and_then(|v| v.parse::<u32>().ok())
            };
            match (
                field("lines"),
                field("dead"),
                field("returns"),
                field("digest"),
                field("lost"),
            ) {
                (Some(lines), Some(dead_lines), Some(returns), Some(digest), Some(lost)) => {
                    t.summary = Some((
                        Summary {
                            lines,
                            dead_lines,
                            returns,
                            digest,
                        },
                        lost,
                    ))
                }
                _ => t.bad.push(l.message.clone()),
            }
        }
    }
    t
}

fn show(trace: &[Transition]) -> String {
    trace
        .iter()
        .map(|t| {
            format!(
                "{:>5} us  #{} {:?} -> {:?} ({:?})\n",
                t.time.as_ticks(),
                t.sequence.index(),
                t.from,
                t.to,
                t.cause
            )
        })
        .collect()
}

/// Runs one scenario on both sides; `Err(report)` when they differ.
fn compare(name: &str) -> Result<usize, String> {
    let sc = rtseq_scenarios::find(name).ok_or(format!("{name}: not in SCENARIOS"))?;
    let host = host::run(sc).map_err(|e| format!("{name}: host registration failed: {e:?}"))?;
    if host.lost != 0 || host.summary.dead_lines != 0 {
        return Err(format!("{name}: host run not clean: {host:?}"));
    }
    let out = run_quiet("scenarios", &[name], false);
    let target = parse(&out);
    let mut problems = Vec::new();
    if out.exit_code() != 0 {
        problems.push(format!("exit code {}", out.exit_code()));
    }
    if out.malformed != 0 || !target.bad.is_empty() {
        problems.push(format!(
            "{} malformed frames, unparsable lines {:?}",
            out.malformed, target.bad
        ));
    }
    if target.trace != host.trace {
        problems.push(format!(
            "traces differ\n--- host ({} transitions):\n{}--- QEMU ({} transitions):\n{}",
            host.trace.len(),
            show(&host.trace),
            target.trace.len(),
            show(&target.trace)
        ));
    }
    match target.summary {
        Some((s, 0)) if s == host.summary => {}
        other => problems.push(format!(
            "summaries differ: host {:?}, QEMU (summary, lost) {other:?}",
            host.summary
        )),
    }
    if problems.is_empty() {
        Ok(host.trace.len())
    } else {
        Err(format!(
            "scenario {name}: {}\nQEMU log:\n{}",
            problems.join("\n"),
            out.transcript()
        ))
    }
}

/// Every scenario produces the same transition trace (times, sequences, states, causes, in
/// order) and the same action summary under RTIC in QEMU as in the host simulator.
#[test]
fn every_scenario_has_the_same_trace_in_qemu_as_on_the_host() {
    firmware("scenarios");
    let names: Vec<&str> = SCENARIOS.iter().map(|s| s.name).collect();
    // Two QEMU runs at a time (each takes ~0.3 s of host time).
    let results: Vec<(String, Result<usize, String>)> = std::thread::scope(|s| {
        let handles: Vec<_> = names
            .chunks(names.len().div_ceil(2))
            .map(|chunk| {
                s.spawn(move || {
                    chunk
                        .iter()
                        .map(|n| (n.to_string(), compare(n)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("scenario thread"))
            .collect()
    });
    let mut failures = Vec::new();
    for (name, r) in &results {
        match r {
            Ok(n) => eprintln!("qemu scenarios: {name}: {n} transitions, equal"),
            Err(e) => failures.push(e.clone()),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} scenarios differ between host and QEMU:\n{}",
        failures.len(),
        results.len(),
        failures.join("\n\n")
    );
}

/// The harness notices a difference: an unknown scenario fails in the firmware, with the
/// list of known ones.
#[test]
fn unknown_scenario_fails_and_lists_the_known_ones() {
    let out = run("scenarios", &["no_such_scenario"]);
    expect_exit(&out, 1);
    expect_line(&out, "scenarios: unknown scenario 'no_such_scenario'");
    expect_line(&out, "scenarios: known: abort_all");
}

/// No-panic proof of the scenario firmware: rtseq, the scenario types (hand-written action
/// futures) and the RTIC app contain no panic path.
#[test]
fn scenario_firmware_is_panic_free() {
    firmware("scenarios"); // snapshot the normal build first
    if let Err(e) = try_build("no-panic", &["scenarios"]) {
        panic!("a panic path survived in the scenarios firmware (or the build failed):\n{e}");
    }
}
