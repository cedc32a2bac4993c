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
use rtseq_scenarios::{decode, encode_record, host, Summary, SCENARIOS};
use std::path::{Path, PathBuf};

/// What the firmware printed: its trace, summary and lost count.
struct Target {
    trace: Vec<Transition>,
    /// Every record as printed: `T` (a transition) or `E` (an event) and six integers.
    records: Vec<(char, [u32; 6])>,
    summary: Option<(Summary, u32)>,
    bad: Vec<String>,
}

fn parse(out: &Outcome) -> Target {
    let mut t = Target {
        trace: Vec::new(),
        records: Vec::new(),
        summary: None,
        bad: Vec::new(),
    };
    for l in &out.lines {
        if let Some(rest) = l.message.strip_prefix("T ") {
            let v: Vec<u32> = rest.split(' ').filter_map(|x| x.parse().ok()).collect();
            match <[u32; 6]>::try_from(v.as_slice())
                .ok()
                .and_then(|e| Some((e, decode(&e)?)))
            {
                Some((e, tr)) => {
                    t.trace.push(tr);
                    t.records.push(('T', e));
                }
                None => t.bad.push(l.message.clone()),
            }
        } else if let Some(rest) = l.message.strip_prefix("E ") {
            let v: Vec<u32> = rest.split(' ').filter_map(|x| x.parse().ok()).collect();
            match <[u32; 6]>::try_from(v.as_slice()) {
                Ok(e) => t.records.push(('E', e)),
                Err(_) => t.bad.push(l.message.clone()),
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

fn show_records(records: &[(char, [u32; 6])]) -> String {
    records
        .iter()
        .map(|(kind, e)| format!("{kind} {e:?}\n"))
        .collect()
}

/// A scenario compared: the number of its transitions, the kinds of its events and the
/// deepest its firmware's stack went, or the report of how host and QEMU differ.
type Compared = Result<(usize, Vec<u32>, u64), String>;

/// Runs one scenario on both sides.
fn compare(set: &FirmwareSet, name: &str) -> Compared {
    let sc = rtseq_scenarios::find(name).ok_or(format!("{name}: not in SCENARIOS"))?;
    let host = host::run(sc).map_err(|e| format!("{name}: host registration failed: {e:?}"))?;
    if host.lost != 0 || host.summary.dead_lines != 0 {
        return Err(format!("{name}: host run not clean: {host:?}"));
    }
    let out = set.run_with("scenarios", &[name], RUN_TIMEOUT, false);
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
    // The events between them (monitor firings, requests, failures, exceptions not run),
    // in the same order on both sides.
    let host_records: Vec<(char, [u32; 6])> = host.records.iter().map(encode_record).collect();
    if target.trace == host.trace && target.records != host_records {
        problems.push(format!(
            "records differ\n--- host:\n{}--- QEMU:\n{}",
            show_records(&host_records),
            show_records(&target.records)
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
        let kinds = host_records
            .iter()
            .filter(|(kind, _)| *kind == 'E')
            .map(|(_, e)| e[1])
            .collect();
        Ok((host.trace.len(), kinds, figure(&out, "stack: ")))
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
    compare_all(&SCENARIO_FIRMWARE);
}

/// The same with the portable `critical-section` lock (board feature
/// `critical-section-lock`): the tick's per-sequence sections give the same traces.
#[test]
fn every_scenario_has_the_same_trace_in_qemu_with_the_portable_lock() {
    compare_all(&SCENARIO_FIRMWARE_CS);
}

fn compare_all(set: &FirmwareSet) {
    set.path("scenarios");
    let names: Vec<&str> = SCENARIOS.iter().map(|s| s.name).collect();
    // Two QEMU runs at a time (each takes ~0.3 s of host time).
    let results: Vec<(String, Compared)> = std::thread::scope(|s| {
        let handles: Vec<_> = names
            .chunks(names.len().div_ceil(2))
            .map(|chunk| {
                s.spawn(move || {
                    chunk
                        .iter()
                        .map(|n| (n.to_string(), compare(set, n)))
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
    let mut kinds = std::collections::BTreeSet::new();
    let mut deepest = (0, "");
    for (name, r) in &results {
        match r {
            Ok((n, events, stack)) => {
                eprintln!(
                    "qemu scenarios: {name}: {n} transitions, {} events, equal, stack {stack} B",
                    events.len()
                );
                kinds.extend(events.iter().copied());
                deepest = deepest.max((*stack, name));
            }
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
    // The deepest stack of a scenario's run is its set-up in `init` (the monitor tables
    // built by value), held to a ceiling (docs/footprint.md, "Stack").
    eprintln!(
        "figure: scenario firmware stack at the deepest [bytes] = {} ({})",
        deepest.0, deepest.1
    );
    assert!((1..=6_144).contains(&deepest.0), "stack: {deepest:?}");
    // The scenarios make every kind of event: a monitor firing (1), an exception sequence
    // that cannot run (2), a request (3), abort-all (4), a failure (5).
    assert_eq!(
        kinds,
        (1..=5).collect(),
        "the kinds of event the scenarios made"
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

// ---------------------------------------------------------------------------------------
// Figures and budgets (issue 3). Printed with `--nocapture`; the README's "Figures" section explains them.
// ---------------------------------------------------------------------------------------

/// A figure with its budget. Figures that meet their budget are asserted against it; a
/// known miss (documented in the README's "Figures" section) is asserted against its
/// `ceiling` instead, so it cannot silently get worse.
fn budget(what: &str, value: u64, budget: u64, ceiling: u64) {
    if value <= budget {
        eprintln!("figure: {what} = {value} (budget {budget}: met)");
    } else {
        eprintln!(
            "figure: {what} = {value} (budget {budget}: MISSED by {}, {:.1}x; known ceiling {ceiling})",
            value - budget,
            value as f64 / budget as f64
        );
        assert!(
            value <= ceiling,
            "{what} = {value} exceeds its budget {budget} and the documented ceiling {ceiling}"
        );
    }
}

/// `N` from the first line `prefix N ...` of the log.
fn figure(out: &Outcome, prefix: &str) -> u64 {
    let l = out
        .find(prefix)
        .unwrap_or_else(|| panic!("no line {prefix:?}:\n{}", out.transcript()));
    l.message[prefix.len()..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after {prefix:?} in {:?}", l.message))
}

/// The tick's cost against the number of registered sequences (`bench_scale`): sets of one
/// word cost the same whatever the number registered, one running sequence costs less
/// than eight, and 256 registered cost what the words holding the running ones cost (the
/// issue's budget: within 10 % of 8 registered; see docs/footprint.md).
#[test]
fn bench_scale_tick_follows_the_running_sequences_in_one_word_sets() {
    let out = run("bench_scale", &[]);
    expect_exit(&out, 0);
    let f = |running: u32, registered: u32| {
        figure(
            &out,
            &format!("bench_scale: tick {running} x 4 due, {registered} registered = "),
        )
    };
    for (running, registered) in [
        (8, 8),
        (8, 32),
        (8, 64),
        (8, 256),
        (1, 8),
        (1, 32),
        (1, 256),
    ] {
        println!(
            "figure: tick {running} x 4 due, {registered} registered [instructions] = {}",
            f(running, registered)
        );
        let firing = figure(
            &out,
            &format!(
                "bench_scale: firing tick (AbortOwner), {running} running, {registered} registered = "
            ),
        );
        println!(
            "figure: firing tick, {running} running, {registered} registered [instructions] = {firing}"
        );
    }
    // One-word sets: the number registered is free. The two sequencers are separate
    // monomorphizations of the same code, and inlining may differ between them by a few
    // instructions (both ticks take the same path); a cost per registered sequence would
    // show as dozens.
    let free = |a: u64, b: u64| a.abs_diff(b) <= 12;
    assert!(
        free(f(8, 8), f(8, 32)),
        "one-word sets: the number registered is free"
    );
    assert!(free(f(1, 8), f(1, 32)));
    assert!(
        f(1, 32) < f(8, 8),
        "one running of 32 costs less than 8 running of 8"
    );
    assert!(f(1, 256) < f(8, 256), "and in a sequencer of 256");
    // A teardown visits the target and the sequences with a caller, not every registered
    // one.
    let firing = |registered: u32| {
        figure(
            &out,
            &format!(
                "bench_scale: firing tick (AbortOwner), 8 running, {registered} registered = "
            ),
        )
    };
    assert!(
        free(firing(8), firing(32)),
        "a firing costs the same in 8 and 32"
    );
    assert!(
        firing(256) * 2 < firing(8) * 3,
        "a firing with 256 registered costs less than 1.5 times one with 8"
    );
    // The tick's stack (bytes, painted around one tick: `board::stack::deepest`): free of
    // the number registered in one-word sets, and within a ceiling at 256 (docs/footprint.md,
    // "Stack"), where the teardown's rows of 8-word sets are the deepest frames.
    for (running, registered) in [(8, 8), (8, 32), (8, 64), (8, 256), (1, 256)] {
        let prefix = format!("bench_scale: stack, {running} running, {registered} registered: ");
        let due = figure(&out, &format!("{prefix}due tick "));
        let line = out.find(&prefix).expect("the stack line");
        let firing: u64 = line.message[line
            .message
            .find("firing tick ")
            .expect("its firing figure")
            + "firing tick ".len()..]
            .split(' ')
            .next()
            .and_then(|n| n.parse().ok())
            .expect("a number of bytes");
        println!("figure: stack of a due tick, {running} running, {registered} registered [bytes] = {due}");
        println!("figure: stack of a firing tick, {running} running, {registered} registered [bytes] = {firing}");
        assert!(
            due <= 256 && firing <= 1_280,
            "{registered} registered: {due} B, {firing} B"
        );
        assert!(
            due > 0 && firing > due,
            "a firing goes deeper than a due tick"
        );
    }
    let stack = |registered: u32| {
        figure(
            &out,
            &format!("bench_scale: stack, 8 running, {registered} registered: due tick "),
        )
    };
    assert_eq!(stack(8), stack(32), "one-word sets: the same stack");
    // Rounded to the nearest per cent, as the firmware prints it. Held to a known ceiling
    // of 120 % (docs/footprint.md says why the goal is missed).
    budget(
        "tick 8 x 4 due with 256 registered, in % of the same with 8 registered",
        (f(8, 256) * 200 / f(8, 8)).div_ceil(2),
        110,
        120,
    );
}

/// The cost model's grid (`bench_grid`, `./x bench --scale`): 256 registered, running
/// sequences × monitors each. The tick follows the woken lanes and the monitors, not the
/// sequences that wait for a blocking child; the period adds the lanes' polls.
#[test]
fn bench_grid_tick_follows_the_due_polls_and_the_monitors() {
    let out = run("bench_grid", &[]);
    expect_exit(&out, 0);
    let cell = |running: u32, monitors: u32| {
        let prefix = format!("bench_grid: running {running} x monitors {monitors}: ");
        let line = out
            .lines
            .iter()
            .find(|l| l.message.starts_with(&prefix))
            .unwrap_or_else(|| panic!("no line {prefix:?}"));
        let rest = &line.message[prefix.len()..];
        if rest.starts_with('-') {
            return None;
        }
        let number = |key: &str| -> u64 {
            let at = rest.find(key).map(|i| i + key.len()).expect("a figure");
            let digits: String = rest[at..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            digits.parse().expect("a number")
        };
        Some((number("tick = "), number("period = ")))
    };
    let mut measured = 0;
    for running in [1, 8, 32, 64, 256] {
        for monitors in [0, 1, 4, 8] {
            match cell(running, monitors) {
                Some((tick, period)) => {
                    measured += 1;
                    println!("figure: grid {running} running x {monitors} monitors: tick {tick}, period {period}");
                    assert!(tick < period, "the period includes the tick");
                }
                None => assert!(
                    running * monitors > 256,
                    "only cells beyond one table are skipped"
                ),
            }
        }
    }
    assert_eq!(measured, 17);
    let tick = |r, m| cell(r, m).map(|c| c.0).expect("measured");
    let period = |r, m| cell(r, m).map(|c| c.1).expect("measured");
    for running in [1, 8, 32] {
        assert!(tick(running, 0) < tick(running, 1) && tick(running, 1) < tick(running, 4));
        assert!(
            tick(running, 4) < tick(running, 8),
            "more monitors cost more"
        );
    }
    // 32 lanes in every shape from 32 on: sequences waiting for a blocking child add
    // nothing to the tick, only their monitors do (256 monitors cost the same however
    // they are spread).
    assert_eq!(tick(32, 0), tick(64, 0));
    assert_eq!(tick(32, 0), tick(256, 0));
    assert!(tick(32, 8).abs_diff(tick(256, 1)) <= 16);
    assert!(tick(32, 8).abs_diff(tick(64, 4)) <= 16);
    // A deeper chain makes each lane's poll dearer (every level's await point).
    assert!(period(32, 0) < period(64, 0) && period(64, 0) < period(256, 0));
}

/// `bench_size` (the firmware `./x bench` takes rtseq's flash and RAM from): the workloads
/// of `bench_hand` in one sequencer run, and both reactions happen.
#[test]
fn bench_size_runs_the_workloads_and_reacts() {
    let out = run("bench_size", &[]);
    expect_exit(&out, 0);
    assert!(
        out.find("bench_size: the cleanup hook and the exception sequence ran")
            .is_some(),
        "{}",
        out.transcript()
    );
    assert_eq!(
        figure(&out, "bench_size: size trace buffer (64 records) = "),
        1024
    );
}

/// Instructions per tick, reaction latency and sizes from the `bench_seq` firmware.
#[test]
fn bench_tick_costs_latency_and_sizes_meet_their_budgets() {
    let out = run("bench_seq", &[]);
    expect_exit(&out, 0);
    let f = |p: &str| figure(&out, &format!("bench_seq: {p} = "));
    budget(
        "tick, 8 sequences x 4 monitors due, nothing firing [instructions]",
        f("tick 8 x 4 due, nothing firing"),
        600,
        600,
    );
    budget(
        "tick, 1 sequence x 4 monitors due, nothing firing [instructions]",
        f("tick 1 x 4 due, nothing firing"),
        600,
        600,
    );
    budget(
        "tick, nothing due (8 sequences running) [instructions]",
        f("tick nothing due (8 running)"),
        60,
        60,
    );
    let fire = f("tick 1 monitor fires AbortOwner");
    eprintln!("figure: tick in which one monitor fires with AbortOwner = {fire} instructions");
    assert!(fire < 2_000, "{}", out.transcript());
    // Reaction: the condition becomes true right after a tick evaluated it (worst phase), so
    // it waits one polling period (= one tick here) for the next evaluation; what rtseq adds
    // is measured from the entry of that tick's handler.
    let period = f("tick period");
    let wait = figure(&out, "bench_seq: tick period = ");
    let to_next = {
        let l = out.find("bench_seq: tick period = ").expect("period line");
        l.message
            .rsplit("next tick = ")
            .next()
            .and_then(|s| s.split(' ').next())
            .and_then(|n| n.parse::<u64>().ok())
            .expect("next tick figure")
    };
    assert_eq!(period, wait);
    assert!(to_next <= period, "{}", out.transcript());
    let aborted = f("latency condition true -> owner Aborted");
    let exception = f("latency condition true -> exception sequence first instruction");
    // Lane dispatch allowance: the tick handler plus one lane dispatch, 5 µs (5000
    // instructions) at most.
    const DISPATCH_NS: u64 = 5_000;
    budget(
        "reaction, condition true -> owner Aborted [ns of virtual time]",
        aborted,
        period + DISPATCH_NS,
        period + DISPATCH_NS,
    );
    budget(
        "reaction, condition true -> exception sequence first instruction [ns]",
        exception,
        period + DISPATCH_NS,
        period + DISPATCH_NS,
    );
    // A control block with its run clock (6 B: 48 bits, a run's time exact however long an
    // exception held it, docs/design-decisions.md) and the restart limit of the exception
    // it handles (1 B), both kept beside it.
    budget(
        "RAM per control block [bytes]",
        f("size control block"),
        48,
        50,
    );
    let per_sequence: u64 = out
        .find("bench_seq: size control block = ")
        .and_then(|l| {
            l.message
                .split("per sequence ")
                .nth(1)?
                .split(',')
                .next()?
                .parse()
                .ok()
        })
        .expect("the RAM per sequence");
    println!("figure: RAM per sequence, with its cleanup-hook slot [bytes] = {per_sequence}");
    assert_eq!(
        per_sequence,
        f("size control block") + 4,
        "a hook slot is a `fn` pointer"
    );
    for p in [
        "size trace record",
        "size monitor entry",
        "size lane future (Seq<Node>, scenarios' node)",
        "size lane future (one-shot sequence)",
        "size Seq<Node>",
    ] {
        eprintln!("figure: {p} = {} bytes", f(p));
    }
}

fn llvm_tool(name: &str) -> PathBuf {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = |args: &[&str]| {
        std::process::Command::new(&rustc)
            .args(args)
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default()
    };
    let sysroot = out(&["--print", "sysroot"]);
    let host = out(&["-vV"])
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_owned))
        .unwrap_or_default();
    let p = Path::new(sysroot.trim())
        .join("lib/rustlib")
        .join(host)
        .join("bin")
        .join(name);
    assert!(
        p.is_file(),
        "{name} not found at {}: run ./x setup (rustup component add llvm-tools)",
        p.display()
    );
    p
}

fn tool_output(tool: &Path, args: &[&str], elf: &Path) -> String {
    let o = std::process::Command::new(tool)
        .args(args)
        .arg(elf)
        .output()
        .unwrap_or_else(|e| panic!("running {}: {e}", tool.display()));
    assert!(o.status.success(), "{} failed", tool.display());
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// (flash = text + data, RAM = data + bss) of an ELF.
fn flash_ram(elf: &Path) -> (u64, u64) {
    let out = tool_output(&llvm_tool("llvm-size"), &[], elf);
    let nums: Vec<u64> = out
        .lines()
        .nth(1)
        .unwrap_or("")
        .split_whitespace()
        .take(3)
        .filter_map(|n| n.parse().ok())
        .collect();
    match nums[..] {
        [text, data, bss] => (text + data, data + bss),
        _ => panic!("llvm-size output: {out}"),
    }
}

/// Flash and RAM with and without rtseq, rtseq's own code, no allocator.
#[test]
fn firmware_sizes_with_and_without_rtseq() {
    let (smoke, scen, bench) = (
        firmware("smoke"),
        firmware("scenarios"),
        firmware("bench_seq"),
    );
    let (f0, r0) = flash_ram(&smoke);
    let (f1, r1) = flash_ram(&scen);
    let (f2, r2) = flash_ram(&bench);
    eprintln!("figure: smoke (RTIC app, no rtseq): flash {f0} B, RAM {r0} B");
    eprintln!(
        "figure: scenarios (rtseq + {} scenarios): flash {f1} B, RAM {r1} B",
        SCENARIOS.len()
    );
    eprintln!("figure: bench_seq (rtseq, 4 sequencers): flash {f2} B, RAM {r2} B");
    let nm = tool_output(&llvm_tool("llvm-nm"), &["--demangle"], &scen);
    let alloc: Vec<&str> = nm
        .lines()
        .filter(|l| {
            l.contains("__rust_alloc") || l.contains("__rg_alloc") || l.contains("GlobalAlloc")
        })
        .collect();
    let demo = firmware("demo");
    let (scen_code, demo_code, bench_code) =
        (code_owners(&scen), code_owners(&demo), code_owners(&bench));
    for (what, c) in [
        ("scenarios (every scenario, 1 sequencer)", &scen_code),
        ("demo (motor controller)", &demo_code),
        ("bench_seq (4 sequencers)", &bench_code),
    ] {
        eprintln!(
            "figure: code in {what}: rtseq {} B (sequencer {} B, safety system {} B), application {} B, libraries {} B",
            c.rtseq,
            c.rtseq - c.safety,
            c.safety,
            c.app,
            c.library
        );
    }
    for (what, c) in [("scenarios", &scen_code), ("demo", &demo_code)] {
        eprintln!("rtseq's largest functions in the {what} firmware (bytes of rtseq code):");
        for (name, bytes) in c.largest.iter().take(40) {
            eprintln!("  {bytes:5} {name}");
        }
    }
    eprintln!(
        "figure: scenarios firmware - smoke = {} B flash (rtseq + {} scenarios' monomorphised trees + defmt strings)",
        f1.saturating_sub(f0),
        SCENARIOS.len()
    );
    // The README's firmware (the motor controller) and the scenario suite's (one set-up per
    // scenario, each building its tree by value: their moves into `Seq`s are rtseq's lines).
    // Budgets (ceilings, not targets): the sequencer's code 12 KiB, the safety system's
    // 2 KiB. The sequencer's code misses its budget by the defect fixes that followed the
    // 0.2 core; the test holds it to known ceilings so that growth is a decision, not a
    // drift. docs/footprint.md says what each fix cost and why.
    budget(
        "rtseq's own flash in the scenarios firmware [bytes]",
        scen_code.rtseq,
        12 * 1024,
        79 * 256,
    );
    budget(
        "rtseq's sequencer code in the demo firmware [bytes]",
        demo_code.rtseq - demo_code.safety,
        12 * 1024,
        83 * 256,
    );
    budget(
        "rtseq's safety-system code in the demo firmware [bytes]",
        demo_code.safety,
        2 * 1024,
        2 * 1024,
    );
    assert!(alloc.is_empty(), "an allocator is linked: {alloc:?}");
    eprintln!("figure: no allocator linked");
    // An empty sequencer is all zeros: its `static` needs no initial image in flash.
    let demo_nm = tool_output(&llvm_tool("llvm-nm"), &["--demangle"], &demo);
    for (what, nm) in [("demo", &demo_nm), ("scenarios", &nm)] {
        let seq = nm
            .lines()
            .find(|l| l.ends_with("::SEQ") || l.contains("::SEQ::h"))
            .unwrap_or_else(|| panic!("no `SEQ` static in the {what} firmware:\n{nm}"));
        assert!(
            seq.contains(" b ") || seq.contains(" B "),
            "the {what} firmware's sequencer has an initial image in flash (.data): {seq}"
        );
    }
    eprintln!("figure: the sequencer static's initial image in flash = 0 B (it is in .bss)");
}

/// Code bytes of a firmware by owner.
struct CodeOwners {
    /// rtseq's code: its functions and its code inlined anywhere, with the `core` helpers
    /// and lock code inlined into it; not the application's code inlined into rtseq's
    /// generic functions (a step's action in its framework).
    rtseq: u64,
    /// Of `rtseq`, the safety system's code (`rtseq::safety`, issue 4's own budget).
    safety: u64,
    app: u64,
    /// Out-of-line library functions (`core`, `defmt`, `rtic`, ...).
    library: u64,
    /// The functions holding rtseq code, largest first (demangled, bytes).
    largest: Vec<(String, u64)>,
}

/// The crate a legacy-mangled symbol belongs to (for `<T as Trait>::f`, `T`'s crate);
/// unmangled symbols (interrupt handlers, `main`) are the application's.
fn symbol_crate(sym: &str) -> &str {
    let Some(rest) = sym.strip_prefix("_ZN") else {
        return "";
    };
    let digits = rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(0);
    let len: usize = rest[..digits].parse().unwrap_or(0);
    let name = rest.get(digits..digits + len).unwrap_or("");
    let name = name.strip_prefix("_$LT$").unwrap_or(name);
    let end = name
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(name.len());
    let krate = &name[..end];
    // `_$LT$impl$u20$...`: an inherent impl's block, named after its module path.
    krate.strip_prefix("impl").map_or(krate, |_| "")
}

/// Attributes every instruction to rtseq or the application by its innermost source line
/// when that line is in this repository (`src/` is rtseq's, the rest the application's);
/// a library line (`core`, `cortex_m`, `heapless`, ...) goes to the innermost frame of its
/// inline stack that belongs to this repository (crate `rtseq`; the other `rtseq_*`
/// crates, the firmware binaries and unmangled symbols are the application's). Lines come
/// first because the inline stacks of `async` code are incomplete: a lane inlined into an
/// RTIC dispatcher shows no rtseq frame. Uses
/// `llvm-objdump -d -l --debug-inlined-funcs=limits-only`.
fn code_owners(elf: &Path) -> CodeOwners {
    let text = tool_output(
        &llvm_tool("llvm-objdump"),
        &[
            "-d",
            "-l",
            "--no-show-raw-insn",
            "--debug-inlined-funcs=limits-only",
        ],
        elf,
    );
    #[derive(Clone, Copy, PartialEq)]
    enum Owner {
        Rtseq,
        App,
        Library,
    }
    let owner = |sym: &str| -> Option<Owner> {
        match symbol_crate(sym) {
            "rtseq" => Some(Owner::Rtseq),
            "" => Some(Owner::App),
            c if c.starts_with("rtseq_") => Some(Owner::App),
            "scenarios" | "demo" | "bench_seq" | "bench" | "smoke" | "safety" | "emergency"
            | "panic" => Some(Owner::App),
            _ => None,
        }
    };
    // (address, owner, function, the safety system's)
    let mut rows: Vec<(u32, Owner, usize, bool)> = Vec::new();
    let mut functions: Vec<String> = Vec::new();
    let mut stack: Vec<String> = Vec::new();
    let repo = format!("{}/", root().display());
    let rtseq_src = format!("{}/", root().join("src").display());
    // The owner of the current source line, when it is in this repository.
    let mut line_owner: Option<Owner> = None;
    let mut line_safety = false;
    let rtseq_safety_src = format!("{}/", root().join("src/safety").display());
    for line in text.lines() {
        if let Some(head) = line.strip_suffix(">:") {
            if let Some((_, name)) = head.split_once(" <") {
                functions.push(name.to_owned());
                stack.clear();
                line_owner = None;
            }
            continue;
        }
        if let Some(note) = line.strip_prefix("; ") {
            // "; FILE:LINE": the instruction's innermost source line.
            if note.starts_with('/') && !note.contains(' ') {
                line_safety = note.starts_with(&rtseq_safety_src);
                line_owner = if note.starts_with(&rtseq_src) {
                    Some(Owner::Rtseq)
                } else if note.starts_with(&repo) {
                    Some(Owner::App)
                } else {
                    None
                };
                continue;
            }
            // "; FILE:LINE:COL: [end of ]SYMBOL inlined into SYMBOL"
            if let Some((head, _)) = note.split_once(" inlined into ") {
                let sym = head.rsplit(' ').next().unwrap_or("");
                if head.contains(": end of ") {
                    if let Some(i) = stack.iter().rposition(|s| s == sym) {
                        stack.truncate(i);
                    }
                } else {
                    stack.push(sym.to_owned());
                }
            }
            continue;
        }
        let Some(function) = functions.last() else {
            continue;
        };
        let Some((addr, _)) = line.trim_start().split_once(':') else {
            continue;
        };
        let Ok(addr) = u32::from_str_radix(addr, 16) else {
            continue;
        };
        // An unmangled inline frame is a library's C-ABI function (the critical-section
        // implementation `_critical_section_1_0_acquire` of cortex-m, `memcpy`), not the
        // application: only an unmangled outer function (an interrupt handler) is.
        // With the owner: whether the code is the safety system's (`src/safety/`, or a
        // function of the module `rtseq::safety`).
        let in_safety = |sym: &str| sym.contains("5rtseq6safety");
        let (who, safety) = line_owner
            .map(|o| (o, line_safety))
            .or_else(|| {
                stack
                    .iter()
                    .rev()
                    .filter(|s| s.starts_with("_ZN"))
                    .find_map(|s| owner(s).map(|o| (o, in_safety(s))))
            })
            .or_else(|| owner(function).map(|o| (o, in_safety(function))))
            .unwrap_or((Owner::Library, false));
        rows.push((addr, who, functions.len() - 1, safety));
    }
    rows.sort_unstable_by_key(|r| r.0);
    let mut c = CodeOwners {
        rtseq: 0,
        safety: 0,
        app: 0,
        library: 0,
        largest: Vec::new(),
    };
    let mut per_function = std::collections::HashMap::<usize, u64>::new();
    for w in rows.windows(2) {
        let bytes = u64::from((w[1].0 - w[0].0).min(4));
        match w[0].1 {
            Owner::Rtseq => {
                c.rtseq += bytes;
                if w[0].3 {
                    c.safety += bytes;
                }
                *per_function.entry(w[0].2).or_default() += bytes;
            }
            Owner::App => c.app += bytes,
            Owner::Library => c.library += bytes,
        }
    }
    c.largest = per_function
        .into_iter()
        .map(|(f, b)| (demangle(&functions[f]), b))
        .collect();
    c.largest.sort_by_key(|b| std::cmp::Reverse(b.1));
    c
}

/// Disassembly facts for the critical-section analysis.
struct Disasm {
    cpsid: std::collections::HashSet<u32>,
    cpsie: std::collections::HashSet<u32>,
    mrs_primask: std::collections::HashSet<u32>,
    msr_primask: std::collections::HashSet<u32>,
    /// `msr basepri_max` (a priority-ceiling lock raises BASEPRI) and `msr basepri` (restores).
    msr_basepri_max: std::collections::HashSet<u32>,
    msr_basepri: std::collections::HashSet<u32>,
    /// Address → index into `files` of its (innermost) source location.
    src: std::collections::HashMap<u32, usize>,
    files: Vec<String>,
}

fn disassemble(elf: &Path) -> Disasm {
    let text = tool_output(
        &llvm_tool("llvm-objdump"),
        &["-d", "-l", "--no-show-raw-insn"],
        elf,
    );
    let mut d = Disasm {
        cpsid: Default::default(),
        cpsie: Default::default(),
        mrs_primask: Default::default(),
        msr_primask: Default::default(),
        msr_basepri_max: Default::default(),
        msr_basepri: Default::default(),
        src: Default::default(),
        files: vec![String::new()],
    };
    let mut cur = 0usize;
    for line in text.lines() {
        if let Some(loc) = line.strip_prefix("; ") {
            d.files.push(loc.to_owned());
            cur = d.files.len() - 1;
            continue;
        }
        if line.ends_with(">:") {
            cur = 0; // a new function: no location until its first line comment
            continue;
        }
        let t = line.trim_start();
        let Some((addr, rest)) = t.split_once(':') else {
            continue;
        };
        let Ok(addr) = u32::from_str_radix(addr, 16) else {
            continue;
        };
        let insn = rest.trim();
        d.src.insert(addr, cur);
        if insn.starts_with("cpsid") {
            d.cpsid.insert(addr);
        } else if insn.starts_with("cpsie") {
            d.cpsie.insert(addr);
        } else if insn.starts_with("mrs") && insn.contains("primask") {
            d.mrs_primask.insert(addr);
        } else if insn.starts_with("msr") && insn.contains("primask") {
            d.msr_primask.insert(addr);
        } else if insn.starts_with("msr") && insn.contains("basepri_max") {
            d.msr_basepri_max.insert(addr);
        } else if insn.starts_with("msr") && insn.contains("basepri") {
            d.msr_basepri.insert(addr);
        }
    }
    d
}

/// Readable form of a legacy-mangled Rust symbol (`_ZN5rtseq4tick...17h<hash>E`).
fn demangle(sym: &str) -> String {
    let Some(mut rest) = sym.strip_prefix("_ZN") else {
        return sym.to_owned();
    };
    let mut parts = Vec::new();
    while let Some(end) = rest.find(|c: char| !c.is_ascii_digit()) {
        let Ok(n) = rest[..end].parse::<usize>() else {
            break;
        };
        let Some(seg) = rest.get(end..end + n) else {
            break;
        };
        if !(seg.len() == 17 && seg.starts_with('h')) {
            parts.push(seg);
        }
        rest = &rest[end + n..];
    }
    parts
        .join("::")
        .replace("_$", "$")
        .replace("$LT$", "<")
        .replace("$GT$", ">")
        .replace("$u20$", " ")
        .replace("$C$", ",")
        .replace("$RF$", "&")
        .replace("$u7b$", "{")
        .replace("$u7d$", "}")
        .replace("..", "::")
}

/// Sites of critical sections (`src/file.rs:line (in function)`) → longest, in instructions.
type Sites = std::collections::BTreeMap<String, u64>;

/// Walks one instruction trace and records, per site, the longest top-level critical
/// section that executes rtseq code: in `sites` those that masked interrupts, in `masked`
/// those taken while interrupts were masked already (RTIC's `init`, the idle's sleep check).
///
/// cortex-m's `critical-section` implementation acquires with `mrs rX, PRIMASK; cpsid i`
/// and releases by writing the saved PRIMASK back (`msr PRIMASK, rX`); nested sections
/// restore "masked", only the outermost release unmasks. A plain `cpsid i` without the
/// PRIMASK read is `interrupt::disable()` (RTIC before `init`, the idle's WFI pattern),
/// ended by `cpsie i`; sections nested in it mask nothing that was not masked.
fn critical_sections(
    d: &Disasm,
    trace: &str,
    rtseq_src: &str,
    sites: &mut Sites,
    masked: &mut Sites,
) {
    let mut recent = [0u32; 4];
    let mut plain_masked = false;
    let mut depth = 0u32;
    let (mut start, mut counted, mut site) = (0usize, false, None::<String>);
    for (i, pc, sym) in executed(trace) {
        if d.cpsid.contains(&pc) {
            if recent.iter().any(|p| d.mrs_primask.contains(p)) {
                depth += 1;
                if depth == 1 {
                    start = i;
                    counted = !plain_masked;
                    site = None;
                }
            } else {
                plain_masked = true;
            }
        } else if d.msr_primask.contains(&pc) {
            if depth > 0 {
                depth -= 1;
                if depth == 0 {
                    if let Some(s) = site.take() {
                        let len = (i - start) as u64;
                        let map = if counted { &mut *sites } else { &mut *masked };
                        let e = map.entry(s).or_insert(0);
                        *e = (*e).max(len);
                    }
                }
            }
        } else if d.cpsie.contains(&pc) {
            plain_masked = false;
        } else if depth > 0 && site.is_none() {
            if let Some(f) = d.src.get(&pc).and_then(|&k| d.files.get(k)) {
                if let Some(rel) = f.strip_prefix(rtseq_src) {
                    site = Some(format!("src/{rel} (in {})", demangle(sym)));
                }
            }
        }
        recent.rotate_left(1);
        recent[3] = pc;
    }
}

/// The executed instructions of a QEMU `-d exec,nochain` trace, numbered from 1:
/// `(n, pc, symbol)` from lines like
/// `Trace 0: 0x7f.. [00800408/08003e56/00000110/ff020201] symbol`.
fn executed(trace: &str) -> impl Iterator<Item = (usize, u32, &str)> {
    trace
        .lines()
        .filter_map(|line| {
            let b = line.find('[')?;
            let pc = line[b + 1..]
                .split('/')
                .nth(1)
                .and_then(|h| u32::from_str_radix(h, 16).ok())?;
            Some((pc, line.rsplit("] ").next().unwrap_or("").trim()))
        })
        .enumerate()
        .map(|(i, (pc, sym))| (i + 1, pc, sym))
}

/// Priority-ceiling sections (`msr basepri_max` … `msr basepri`) that execute rtseq code:
/// the longest per site, in instructions. They delay the tick and the lanes, never an
/// interrupt above the ceiling.
fn ceiling_sections(d: &Disasm, trace: &str, rtseq_src: &str, sites: &mut Sites) {
    let mut depth = 0u32;
    let (mut start, mut site) = (0usize, None::<String>);
    for (i, pc, sym) in executed(trace) {
        if d.msr_basepri_max.contains(&pc) {
            if depth == 0 {
                start = i;
                site = None;
            }
            depth += 1;
        } else if d.msr_basepri.contains(&pc) {
            if depth > 0 {
                depth -= 1;
                if depth == 0 {
                    if let Some(s) = site.take() {
                        let e = sites.entry(s).or_insert(0);
                        *e = (*e).max((i - start) as u64);
                    }
                }
            }
        } else if depth > 0 && site.is_none() {
            if let Some(f) = d.src.get(&pc).and_then(|&k| d.files.get(k)) {
                // The section is named after its first line outside the lock itself (the
                // out-of-line raise has lines in `src/lock.rs`, and its symbol would hide
                // whether the section is the tick's).
                if let Some(rel) = f.strip_prefix(rtseq_src) {
                    if !rel.starts_with("lock.rs") {
                        site = Some(format!("src/{rel} (in {})", demangle(sym)));
                    }
                }
            }
        }
    }
}

/// Runs every scenario of `elf` in QEMU with an instruction trace
/// (`-singlestep -d exec,nochain`) and passes each trace to `f`.
fn for_each_trace(elf: &Path, tag: &str, mut f: impl FnMut(&str)) {
    let dir = root().join("target/firmware").join(tag);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for sc in SCENARIOS {
        let log = dir.join(format!("exec-{}.log", sc.name));
        let cfg = Config {
            timeout: RUN_TIMEOUT,
            echo: Echo::None,
            firmware_args: vec![sc.name.to_owned()],
            extra_qemu_args: ["-singlestep", "-d", "exec,nochain", "-D"]
                .iter()
                .map(|s| s.to_string())
                .chain([log.display().to_string()])
                .collect(),
            ..Config::default()
        };
        let out = qemu_run::run(elf, &cfg).unwrap_or_else(|e| panic!("{}: {e}", sc.name));
        expect_exit(&out, 0);
        let trace = std::fs::read_to_string(&log).unwrap_or_else(|e| panic!("{e}"));
        let _ = std::fs::remove_file(&log);
        f(&trace);
    }
}

/// The sites of `sites`, longest first.
fn longest_first(sites: &Sites) -> Vec<(&String, u64)> {
    let mut v: Vec<_> = sites.iter().map(|(s, &l)| (s, l)).collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(b.0)));
    v
}

/// The longest critical section inside rtseq with the portable `critical-section` lock
/// (the default `Sequencer::new()`; the scenarios firmware built with the board feature
/// `critical-section-lock`), measured on the instruction traces of every scenario (QEMU
/// `-singlestep -d exec,nochain`): instructions from the `cpsid` of a
/// `critical_section::acquire` to its release, for every section that executes rtseq code.
/// Sections taken while interrupts were masked anyway (registration in RTIC's `init`) are
/// reported separately.
#[test]
fn longest_critical_section_inside_rtseq() {
    let elf = SCENARIO_FIRMWARE_CS.path("scenarios");
    let d = disassemble(&elf);
    let rtseq_src = format!("{}/", root().join("src").display());
    let (mut sites, mut masked) = (Sites::new(), Sites::new());
    for_each_trace(&elf, "qemu-harness-cs", |trace| {
        critical_sections(&d, trace, &rtseq_src, &mut sites, &mut masked)
    });
    assert!(
        !sites.is_empty(),
        "no rtseq critical section found in the traces"
    );
    for (site, len) in longest_first(&masked) {
        eprintln!(
            "figure: critical section {len:>4} instructions at {site} (interrupts masked already: init)"
        );
    }
    let by_len = longest_first(&sites);
    for (site, len) in &by_len {
        eprintln!("figure: critical section {len:>4} instructions at {site}");
    }
    let max = by_len.first().map_or(0, |&(_, l)| l);
    eprintln!(
        "figure: longest critical section (interrupts masked) inside rtseq, portable lock: {max} instructions"
    );
    // Every section, the tick handler's included: its scan takes one section per
    // sequence, its wake-ups one per sequence (and one per caller for the held check).
    budget(
        "longest critical section inside rtseq, portable critical-section lock [instructions]",
        max,
        50,
        50,
    );
    let init_max = longest_first(&masked).first().map_or(0, |&(_, l)| l);
    eprintln!(
        "figure: longest rtseq section in init (interrupts masked anyway: registration) = {init_max} instructions"
    );
}

/// The same traces with RTIC's priority-ceiling lock (the scenarios firmware's default):
/// rtseq masks no interrupt globally there, its sections (`msr basepri_max` … `msr
/// basepri`) only hold off the tick and the lanes.
#[test]
fn longest_critical_section_inside_rtseq_priority_ceiling() {
    let elf = firmware("scenarios");
    let d = disassemble(&elf);
    let rtseq_src = format!("{}/", root().join("src").display());
    let (mut sites, mut masked, mut ceilings) = (Sites::new(), Sites::new(), Sites::new());
    for_each_trace(&elf, "qemu-harness", |trace| {
        critical_sections(&d, trace, &rtseq_src, &mut sites, &mut masked);
        ceiling_sections(&d, trace, &rtseq_src, &mut ceilings);
    });
    assert!(!ceilings.is_empty(), "no rtseq section found in the traces");
    let max = longest_first(&sites).first().map_or(0, |&(_, l)| l);
    eprintln!(
        "figure: longest critical section (interrupts masked) inside rtseq, priority-ceiling lock: {max} instructions"
    );
    budget(
        "longest interrupt-masking section inside rtseq, priority-ceiling lock [instructions]",
        max,
        50,
        50,
    );
    // Sections the tick itself runs (inlined into its TIM2 handler) are taken at the
    // ceiling priority the tick already has: they hold off nothing. Those of the lanes
    // (lower priority) delay the tick: that is the figure.
    let mut by_len = longest_first(&ceilings);
    for (site, len) in &by_len {
        eprintln!("figure: priority-ceiling section {len:>4} instructions at {site}");
    }
    by_len.retain(|(site, _)| !site.ends_with("(in TIM2)"));
    let cmax = by_len.first().map_or(0, |&(_, l)| l);
    eprintln!(
        "figure: longest priority-ceiling section inside rtseq outside the tick (holds off the tick only): {cmax} instructions"
    );
    budget(
        "longest priority-ceiling section inside rtseq outside the tick [instructions]",
        cmax,
        400,
        400,
    );
}
