//! VCD, Perfetto JSON and the trace format, read back by independent readers (the `vcd`
//! crate, `serde_json`) and checked against the run they were written from: every
//! transition present, times exact. For both sources: the demo's QEMU log and the host
//! simulator's trace file of the same run.

mod common;

use std::collections::HashMap;

use rtseq_trace::model::{EventKind, Run, State};
use rtseq_trace::{perfetto, read_run, tracefile, vcd};
use serde_json::Value;

fn sources() -> Vec<(&'static str, Run)> {
    let log = common::fixture_run();
    let host = common::host_following_error_trace(log.end_us / 1000);
    let host = read_run(
        &std::fs::read_to_string(host).unwrap(),
        rtseq_trace::log::Hints::default(),
    )
    .unwrap();
    vec![("qemu log", log), ("host trace", host)]
}

#[test]
fn the_fixture_is_the_following_error_run() {
    let run = common::fixture_run();
    let moves = run
        .sequences
        .iter()
        .position(|s| s.name == "moves")
        .unwrap();
    let to: Vec<State> = run
        .transitions
        .iter()
        .filter(|t| t.seq == moves)
        .map(|t| t.to)
        .collect();
    assert_eq!(to.iter().filter(|s| **s == State::Restarting).count(), 3);
    assert_eq!(to.last(), Some(&State::Aborted));
    let firings = run
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Monitor)
        .count();
    assert_eq!(firings, 4);
    assert_eq!(run.levels.last().unwrap().level, "off");
    assert_eq!(run.signals.len(), 3);
}

#[test]
fn vcd_has_every_transition_at_its_time() {
    for (what, run) in sources() {
        let mut buf = Vec::new();
        vcd::write(&run, &mut buf).unwrap();
        let mut parser = ::vcd::Parser::new(&buf[..]);
        let header = parser.parse_header().unwrap();
        assert_eq!(header.timescale, Some((1, ::vcd::TimescaleUnit::US)));
        let mut names = HashMap::new();
        let mut codes = HashMap::new();
        for s in &run.sequences {
            let name = vcd::sanitize(&s.name);
            let v = header
                .find_var(&["rtseq", "sequences", name.as_str()])
                .unwrap_or_else(|| panic!("{what}: no VCD variable for {}", s.name));
            assert_eq!(v.var_type, ::vcd::VarType::String);
            names.insert(v.code, s.name.clone());
            let c = header
                .find_var(&["rtseq", "state_codes", name.as_str()])
                .unwrap();
            assert_eq!(c.size, 3);
            codes.insert(c.code, s.name.clone());
        }
        let level = header.find_var(&["rtseq", "safety", "level"]).unwrap().code;
        let fire = header
            .find_var(&["rtseq", "events", "monitor_following_error"])
            .map(|v| v.code);

        let (mut t, mut in_dump) = (0u64, false);
        let mut changes: HashMap<String, Vec<(u64, String)>> = HashMap::new();
        let mut coded: HashMap<String, Vec<(u64, u8)>> = HashMap::new();
        let (mut levels, mut rises) = (Vec::new(), Vec::new());
        for cmd in parser {
            match cmd.unwrap() {
                ::vcd::Command::Timestamp(x) => {
                    assert!(x >= t, "{what}: time goes back");
                    t = x;
                }
                ::vcd::Command::Begin(::vcd::SimulationCommand::Dumpvars) => in_dump = true,
                ::vcd::Command::End(::vcd::SimulationCommand::Dumpvars) => in_dump = false,
                ::vcd::Command::ChangeString(id, s) if !in_dump => {
                    if let Some(n) = names.get(&id) {
                        changes.entry(n.clone()).or_default().push((t, s));
                    } else if id == level {
                        levels.push((t, s));
                    }
                }
                ::vcd::Command::ChangeVector(id, v) if !in_dump => {
                    if let Some(n) = codes.get(&id) {
                        let code = v
                            .iter()
                            .fold(0u8, |a, b| (a << 1) | u8::from(b == ::vcd::Value::V1));
                        coded.entry(n.clone()).or_default().push((t, code));
                    }
                }
                ::vcd::Command::ChangeScalar(id, ::vcd::Value::V1) if Some(id) == fire => {
                    rises.push(t)
                }
                _ => {}
            }
        }
        for (i, s) in run.sequences.iter().enumerate() {
            let want: Vec<(u64, String)> = run
                .transitions
                .iter()
                .filter(|t| t.seq == i)
                .map(|t| (t.time_us, vcd::sanitize(t.to.name())))
                .collect();
            let got = changes.remove(&s.name).unwrap_or_default();
            assert_eq!(got, want, "{what}: VCD states of {}", s.name);
            let want: Vec<(u64, u8)> = run
                .transitions
                .iter()
                .filter(|t| t.seq == i)
                .map(|t| (t.time_us, t.to.code()))
                .collect();
            assert_eq!(coded.remove(&s.name).unwrap_or_default(), want);
        }
        let want: Vec<(u64, String)> = run
            .levels
            .iter()
            .map(|l| (l.time_us, vcd::sanitize(&l.level)))
            .collect();
        assert_eq!(levels, want, "{what}: levels");
        let want: Vec<u64> = run
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Monitor && e.name == "following error")
            .map(|e| e.time_us)
            .collect();
        assert_eq!(rises, want, "{what}: monitor pulses");
    }
}

#[test]
fn perfetto_has_every_transition_at_its_time() {
    for (what, run) in sources() {
        let mut buf = Vec::new();
        perfetto::write(&run, &mut buf).unwrap();
        let doc: Value = serde_json::from_slice(&buf).unwrap();
        let events = doc["traceEvents"].as_array().unwrap();
        // Track names.
        for (i, s) in run.sequences.iter().enumerate() {
            let named = events.iter().any(|e| {
                e["ph"] == "M"
                    && e["name"] == "thread_name"
                    && e["tid"] == perfetto::tid_of(i)
                    && e["args"]["name"].as_str().unwrap().trim() == s.name
            });
            assert!(named, "{what}: no track for {}", s.name);
        }
        let spans = |tid: usize, cat: &str| -> Vec<(u64, u64, String, Value)> {
            events
                .iter()
                .filter(|e| e["ph"] == "X" && e["tid"] == tid && e["cat"] == cat)
                .map(|e| {
                    let ts = e["ts"].as_u64().unwrap();
                    let end = ts + e["dur"].as_u64().unwrap();
                    (
                        ts,
                        end,
                        e["name"].as_str().unwrap().to_string(),
                        e["args"].clone(),
                    )
                })
                .collect()
        };
        for t in &run.transitions {
            let tid = perfetto::tid_of(t.seq);
            let name = &run.sequences[t.seq].name;
            let runs = spans(tid, "run");
            let states = spans(tid, "state");
            let ctx = format!("{what}: {name} {} -> {} at {}", t.from, t.to, t.time_us);
            if !t.from.is_active() {
                assert!(
                    runs.iter().any(|r| r.0 == t.time_us && r.2 == *name),
                    "{ctx}: no run starts"
                );
            }
            if !t.to.is_active() {
                let r = runs
                    .iter()
                    .find(|r| r.1 == t.time_us)
                    .unwrap_or_else(|| panic!("{ctx}: no run ends"));
                let outcome = r.3["outcome"].as_str().unwrap();
                match t.to {
                    State::Terminated => assert_eq!(outcome, "completed", "{ctx}"),
                    State::Aborted => assert_eq!(outcome, format!("aborted ({})", t.cause)),
                    _ => {}
                }
            }
            if matches!(t.to, State::Paused | State::Aborting | State::Restarting) {
                assert!(
                    states
                        .iter()
                        .any(|s| s.0 == t.time_us && s.2 == t.to.name()),
                    "{ctx}: no state span starts"
                );
            }
            if matches!(t.from, State::Paused | State::Aborting | State::Restarting) {
                assert!(
                    states
                        .iter()
                        .any(|s| s.1 == t.time_us && s.2 == t.from.name()),
                    "{ctx}: no state span ends"
                );
            }
            // And the run that holds it lists it, with its exact time.
            let line = format!(
                "{} s {} -> {} ({})",
                rtseq_trace::model::secs(t.time_us),
                t.from,
                t.to,
                t.cause
            );
            assert!(
                runs.iter().any(|r| r.3["transitions"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|x| x == &Value::from(line.clone()))),
                "{ctx}: not listed in a run"
            );
        }
        let fired = events
            .iter()
            .filter(|e| e["ph"] == "i" && e["cat"] == "monitor")
            .count();
        let want = run
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Monitor)
            .count();
        assert_eq!(fired, want, "{what}: monitor firings");
    }
}

#[test]
fn trace_format_round_trip() {
    for (what, run) in sources() {
        let mut buf = Vec::new();
        tracefile::write(&run, &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(tracefile::is_trace(&text));
        let back = tracefile::read(&text).unwrap();
        assert_eq!(back.sequences, run.sequences, "{what}");
        assert_eq!(back.transitions, run.transitions, "{what}");
        assert_eq!(back.events, run.events, "{what}");
        assert_eq!(back.levels, run.levels, "{what}");
        assert_eq!(back.signals, run.signals, "{what}");
        assert_eq!(back.end_us, run.end_us, "{what}");
    }
}
