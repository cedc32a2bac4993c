//! VCD, Perfetto JSON and the trace format, read back by independent readers (the `vcd`
//! crate, `serde_json`) and checked against the run they were written from: every
//! transition present, times exact. For both sources: the demo's QEMU log and the host
//! simulator's trace file of the same run.

mod common;

use std::collections::HashMap;

use rtseq_trace::model::{EventKind, Lost, Run, State};
use rtseq_trace::{html, perfetto, read_run, tracefile, vcd};
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

/// The VCD times (ns) of one variable's values at `times` (µs, in order): the k-th value of
/// one µs k ns after it, the initial value (`$dumpvars`) being the first of µs 0.
fn ns(times: impl Iterator<Item = u64>) -> Vec<u64> {
    let mut out: Vec<u64> = Vec::new();
    let (mut at, mut k) = (0, 1);
    for t in times {
        k = if t == at { k + 1 } else { 1 };
        at = t;
        out.push(t * 1000 + k - 1);
    }
    out
}

#[test]
fn vcd_has_every_transition_at_its_time() {
    for (what, run) in sources() {
        let mut buf = Vec::new();
        vcd::write(&run, &mut buf).unwrap();
        let mut parser = ::vcd::Parser::new(&buf[..]);
        let header = parser.parse_header().unwrap();
        assert_eq!(header.timescale, Some((1, ::vcd::TimescaleUnit::NS)));
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
            let trs: Vec<_> = run.transitions.iter().filter(|t| t.seq == i).collect();
            let times = ns(trs.iter().map(|t| t.time_us));
            let want: Vec<(u64, String)> = trs
                .iter()
                .zip(&times)
                .map(|(t, &ns)| (ns, vcd::sanitize(t.to.name())))
                .collect();
            let got = changes.remove(&s.name).unwrap_or_default();
            assert_eq!(got, want, "{what}: VCD states of {}", s.name);
            let want: Vec<(u64, u8)> = trs
                .iter()
                .zip(&times)
                .map(|(t, &ns)| (ns, t.to.code()))
                .collect();
            assert_eq!(coded.remove(&s.name).unwrap_or_default(), want);
        }
        let times = ns(run.levels.iter().map(|l| l.time_us));
        let want: Vec<(u64, String)> = run
            .levels
            .iter()
            .zip(times)
            .map(|(l, ns)| (ns, vcd::sanitize(&l.level)))
            .collect();
        assert_eq!(levels, want, "{what}: levels");
        let want: Vec<u64> = ns(run
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Monitor && e.name == "following error")
            .map(|e| e.time_us));
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
        assert_eq!(back.lost, run.lost, "{what}");
    }
}

/// A trace of one sequence and two faults, the second at the last time a file can hold.
fn trace_text(lost: &str, last_fault_us: u64) -> String {
    format!(
        r#"{{"format":"rtseq-trace","version":1,"time_unit":"us","end":9000{lost},"sequences":[{{"id":0,"name":"homing","caller":null}}],"monitors":[]}}
{{"t":1000,"seq":0,"from":"Idle","to":"Running","cause":"start"}}
{{"t":5000,"event":"fault","name":"jam","text":"jam injected"}}
{{"t":{last_fault_us},"event":"fault","name":"jam","text":"jam injected"}}
"#
    )
}

/// The comments of a VCD file's header, read by the `vcd` crate.
fn vcd_comments(buf: &[u8]) -> Vec<String> {
    let header = ::vcd::Parser::new(buf).parse_header().unwrap();
    header
        .items
        .iter()
        .filter_map(|i| match i {
            ::vcd::ScopeItem::Comment(c) => Some(c.trim().to_string()),
            _ => None,
        })
        .collect()
}

/// Records the source lost: the VCD has a `$comment`, the Perfetto JSON a `metadata` entry
/// and a process label, the written trace file `"lost"`; a complete run has none of them.
#[test]
fn lost_records_are_in_every_export() {
    let cases = [
        (
            r#","lost":82"#,
            Lost::Count(82),
            Some("82 records were lost: the trace is incomplete"),
            Value::from(82),
        ),
        (
            r#","lost":true"#,
            Lost::Uncounted,
            Some("records were lost (the source does not say how many): the trace is incomplete"),
            Value::from("unknown"),
        ),
        (r#","lost":0"#, Lost::None, None, Value::Null),
        ("", Lost::None, None, Value::Null),
    ];
    for (field, lost, warning, count) in cases {
        let run = tracefile::read(&trace_text(field, 6000)).unwrap();
        assert_eq!(run.lost, lost, "{field}");

        let mut buf = Vec::new();
        vcd::write(&run, &mut buf).unwrap();
        let comments = vcd_comments(&buf);
        match warning {
            Some(w) => assert_eq!(comments, [w], "{field}"),
            None => assert!(comments.is_empty(), "{field}: {comments:?}"),
        }

        let mut buf = Vec::new();
        perfetto::write(&run, &mut buf).unwrap();
        let doc: Value = serde_json::from_slice(&buf).unwrap();
        let meta = &doc["metadata"];
        assert_eq!(meta["lost_records"], count, "{field}");
        assert_eq!(
            meta["warning"],
            warning.map_or(Value::Null, Value::from),
            "{field}"
        );
        let labels: Vec<&Value> = doc["traceEvents"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|e| e["ph"] == "M" && e["name"] == "process_labels")
            .map(|e| &e["args"]["labels"])
            .collect();
        match warning {
            Some(w) => assert_eq!(labels, [&Value::from(format!("WARNING: {w}"))]),
            None => assert!(labels.is_empty(), "{field}"),
        }

        let mut buf = Vec::new();
        tracefile::write(&run, &mut buf).unwrap();
        assert_eq!(
            tracefile::read(&String::from_utf8(buf).unwrap())
                .unwrap()
                .lost,
            lost
        );
    }
    // The demo's log and the simulator's trace of it lost nothing.
    for (what, run) in sources() {
        assert_eq!(run.lost, Lost::None, "{what}");
    }
}

/// An event at `u64::MAX` µs, the last time a trace file holds: its pulse rises there and
/// has no fall (there is no later time), the earlier pulse of the same name falls 1 µs
/// after it rose, and no time goes back. The other exports take it too.
#[test]
fn vcd_pulse_at_the_last_time() {
    let run = tracefile::read(&trace_text("", u64::MAX)).unwrap();
    assert_eq!(run.end_us, u64::MAX);
    let mut buf = Vec::new();
    vcd::write(&run, &mut buf).unwrap();
    let mut parser = ::vcd::Parser::new(&buf[..]);
    let header = parser.parse_header().unwrap();
    let jam = header
        .find_var(&["rtseq", "events", "fault_jam"])
        .unwrap()
        .code;
    let (mut t, mut in_dump) = (0u64, false);
    let mut pulse = Vec::new();
    for cmd in parser {
        match cmd.unwrap() {
            ::vcd::Command::Timestamp(x) => {
                assert!(x >= t, "time goes back: {x} after {t}");
                t = x;
            }
            ::vcd::Command::Begin(::vcd::SimulationCommand::Dumpvars) => in_dump = true,
            ::vcd::Command::End(::vcd::SimulationCommand::Dumpvars) => in_dump = false,
            ::vcd::Command::ChangeScalar(id, v) if id == jam && !in_dump => pulse.push((t, v)),
            _ => {}
        }
    }
    assert_eq!(t, u64::MAX);
    assert_eq!(
        pulse,
        [
            (5000, ::vcd::Value::V1),
            (5001, ::vcd::Value::V0),
            (u64::MAX, ::vcd::Value::V1)
        ]
    );
    let mut out = Vec::new();
    perfetto::write(&run, &mut out).unwrap();
    let doc: Value = serde_json::from_slice(&out).unwrap();
    let last = doc["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["ph"] == "i")
        .map(|e| e["ts"].as_u64().unwrap())
        .max();
    assert_eq!(last, Some(u64::MAX));
    // The run of `homing` lasts to the end of the record.
    let page = html::render(&run, "end of time");
    assert!(page.contains(&format!(
        "homing: Running from 0.001000 s to {} s ({} µs)",
        rtseq_trace::model::secs(u64::MAX),
        u64::MAX - 1000
    )));
}

/// `main`'s first record resumes it (the trace starts mid-run); `child`'s third record starts
/// from `Aborted` although its second left it `Paused` (records lost).
const MID_RUN_AND_GAP: &str = r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":100,"lost":3,"sequences":[{"id":0,"name":"main","caller":null},{"id":1,"name":"child","caller":0}],"monitors":[]}
{"t":10,"seq":0,"from":"Paused","to":"Running","cause":"resume"}
{"t":10,"seq":1,"from":"Idle","to":"Running","cause":"start"}
{"t":20,"seq":1,"from":"Running","to":"Paused","cause":"pause"}
{"t":30,"seq":1,"from":"Aborted","to":"Running","cause":"start"}
{"t":40,"seq":1,"from":"Running","to":"Terminated","cause":"completed"}
{"t":60,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}
"#;

/// The exports follow a record's `from`: VCD starts `main` in `Paused` and comments the
/// gap; Perfetto has `main`'s `Paused` from 0, a `records lost` span over the gap and a
/// run whose end was lost.
#[test]
fn exports_follow_the_records_from_state() {
    let run = tracefile::read(MID_RUN_AND_GAP).unwrap();
    let mut buf = Vec::new();
    vcd::write(&run, &mut buf).unwrap();
    let mut parser = ::vcd::Parser::new(&buf[..]);
    let header = parser.parse_header().unwrap();
    let main = header
        .find_var(&["rtseq", "sequences", "main"])
        .unwrap()
        .code;
    let main_code = header
        .find_var(&["rtseq", "state_codes", "main"])
        .unwrap()
        .code;
    let (mut t, mut in_dump) = (0u64, false);
    let (mut initial, mut initial_code, mut comments) = (None, None, Vec::new());
    for cmd in parser {
        match cmd.unwrap() {
            ::vcd::Command::Timestamp(x) => t = x,
            ::vcd::Command::Begin(::vcd::SimulationCommand::Dumpvars) => in_dump = true,
            ::vcd::Command::End(::vcd::SimulationCommand::Dumpvars) => in_dump = false,
            ::vcd::Command::ChangeString(id, s) if in_dump && id == main => initial = Some(s),
            ::vcd::Command::ChangeVector(id, v) if in_dump && id == main_code => {
                initial_code = Some(v.to_string())
            }
            ::vcd::Command::Comment(c) => comments.push((t, c.trim().to_string())),
            _ => {}
        }
    }
    assert_eq!(initial.as_deref(), Some("Paused"));
    assert_eq!(initial_code.as_deref(), Some("010"));
    assert_eq!(
        comments,
        [(
            30_000,
            String::from(
                "records lost: 'child' was Paused at 20 us; its next record, at 30 us, starts from Aborted"
            )
        )]
    );

    let events = perfetto::events(&run);
    let on = |tid: usize, cat: &str| -> Vec<(u64, u64, String, Value)> {
        events
            .iter()
            .filter(|e| e["tid"] == tid && e["cat"] == cat)
            .map(|e| {
                (
                    e["ts"].as_u64().unwrap(),
                    e["dur"].as_u64().unwrap(),
                    e["name"].as_str().unwrap().to_string(),
                    e["args"].clone(),
                )
            })
            .collect()
    };
    let (main, child) = (perfetto::tid_of(0), perfetto::tid_of(1));
    let states: Vec<_> = on(main, "state")
        .into_iter()
        .map(|e| (e.0, e.1, e.2))
        .collect();
    assert_eq!(states, [(0, 10, String::from("Paused"))]);
    let runs: Vec<_> = on(main, "run")
        .into_iter()
        .map(|e| (e.0, e.1, e.3["started by"].clone(), e.3["outcome"].clone()))
        .collect();
    assert_eq!(
        runs,
        [(
            0,
            60,
            Value::from("(before the record)"),
            Value::from("completed")
        )]
    );
    assert_eq!(
        on(child, "gap"),
        [(
            20,
            10,
            String::from("records lost"),
            serde_json::json!({
                "state at the start": "Paused",
                "state at the end": "Aborted",
                "note": "records were lost here: what happened between is not known",
            })
        )]
    );
    let outcomes: Vec<_> = on(child, "run")
        .into_iter()
        .map(|e| (e.0, e.1, e.3["outcome"].clone()))
        .collect();
    assert_eq!(
        outcomes,
        [
            (10, 20, Value::from("unknown (records lost)")),
            (30, 10, Value::from("completed"))
        ]
    );

    // The HTML timeline: `main` paused from 0, the gap drawn as one (class `gap`).
    let page = html::render(&run, "gap");
    let tip = |s: &str| html::esc(s);
    assert!(page.contains(&tip(
        "main: Paused from 0.000000 s to 0.000010 s (10 µs)\ncause: unknown: the state before the sequence's first record\nrun: started by (before the record); outcome completed"
    )));
    assert!(page.contains(r#"<rect class="span s-paused gap" data-t0="20" data-t1="30""#));
    let key = r#"<span class="key"><i class="s-running gap"></i>records lost</span>"#;
    assert_eq!(page.matches(key).count(), 1);
    // Without a gap, no key for one.
    let whole = MID_RUN_AND_GAP.replace(
        r#""from":"Aborted","to":"Running""#,
        r#""from":"Paused","to":"Running""#,
    );
    assert!(!html::render(&tracefile::read(&whole).unwrap(), "no gap").contains(key));
    assert!(page.contains(&tip(
        "child: Paused from 0.000020 s to 0.000030 s (10 µs)\ncause: pause\nrun: started by start; outcome unknown (records lost)\nRECORDS LOST: the next record starts from Aborted, not Paused; what happened between is not known"
    )));
}

/// An owner restarted by its monitor in one tick (the simulator's `restart_owner`): at
/// 5000 µs `S` is `Aborting`, `Aborted` and `Running` again, `A` `Restarting` and `Running`.
/// Each state is seen for 1 ns (a timescale of 1 ns), no variable has two values at one
/// time, and the end is written once. (At 1 µs, `S` took three values at #5000: a viewer
/// showed only the last, so the abort and restart were invisible.)
#[test]
fn vcd_shows_states_of_0_us() {
    let text = r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":10000,"sequences":[{"id":0,"name":"S","caller":1},{"id":1,"name":"A","caller":null}],"monitors":[{"id":0,"name":"m","owner":1}]}
{"t":0,"seq":1,"from":"Idle","to":"Running","cause":"start"}
{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}
{"t":5000,"event":"monitor","owner":1,"behaviour":"RestartOwner","monitor":0,"text":"monitor 'm' of 'A' fired: RestartOwner"}
{"t":5000,"seq":0,"from":"Running","to":"Aborting","cause":"monitor","monitor":0}
{"t":5000,"seq":0,"from":"Aborting","to":"Aborted","cause":"monitor","monitor":0}
{"t":5000,"seq":1,"from":"Running","to":"Restarting","cause":"monitor","monitor":0}
{"t":5000,"seq":1,"from":"Restarting","to":"Running","cause":"restart"}
{"t":5000,"seq":0,"from":"Aborted","to":"Running","cause":"start"}
{"t":10000,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}
{"t":10000,"seq":1,"from":"Running","to":"Terminated","cause":"completed"}
"#;
    let run = tracefile::read(text).unwrap();
    let mut buf = Vec::new();
    vcd::write(&run, &mut buf).unwrap();
    let mut parser = ::vcd::Parser::new(&buf[..]);
    let header = parser.parse_header().unwrap();
    assert_eq!(header.timescale, Some((1, ::vcd::TimescaleUnit::NS)));
    let var = |scope: &str, name: &str| header.find_var(&["rtseq", scope, name]).unwrap().code;
    let (s, a, s_code) = (
        var("sequences", "S"),
        var("sequences", "A"),
        var("state_codes", "S"),
    );
    let (mut t, mut in_dump) = (0u64, false);
    let (mut s_states, mut a_states, mut s_codes) = (Vec::new(), Vec::new(), Vec::new());
    let (mut times, mut set_at) = (Vec::new(), std::collections::HashSet::new());
    for cmd in parser {
        let cmd = cmd.unwrap();
        let id = match &cmd {
            ::vcd::Command::Timestamp(x) => {
                times.push(*x);
                t = *x;
                None
            }
            ::vcd::Command::Begin(::vcd::SimulationCommand::Dumpvars) => {
                in_dump = true;
                None
            }
            ::vcd::Command::End(::vcd::SimulationCommand::Dumpvars) => {
                in_dump = false;
                None
            }
            ::vcd::Command::ChangeString(id, v) => {
                if *id == s && !in_dump {
                    s_states.push((t, v.clone()));
                }
                if *id == a && !in_dump {
                    a_states.push((t, v.clone()));
                }
                Some(*id)
            }
            ::vcd::Command::ChangeVector(id, v) => {
                if *id == s_code && !in_dump {
                    s_codes.push((t, v.to_string()));
                }
                Some(*id)
            }
            ::vcd::Command::ChangeScalar(id, _) | ::vcd::Command::ChangeReal(id, _) => Some(*id),
            _ => None,
        };
        if let Some(id) = id {
            assert!(set_at.insert((t, id)), "{id} twice at #{t}");
        }
    }
    let owned = |v: &[(u64, &str)]| -> Vec<(u64, String)> {
        v.iter().map(|&(t, s)| (t, s.to_string())).collect()
    };
    assert_eq!(
        s_states,
        owned(&[
            (1, "Running"),
            (5_000_000, "Aborting"),
            (5_000_001, "Aborted"),
            (5_000_002, "Running"),
            (10_000_000, "Terminated"),
        ])
    );
    assert_eq!(
        s_codes,
        owned(&[
            (1, "001"),
            (5_000_000, "011"),
            (5_000_001, "100"),
            (5_000_002, "001"),
            (10_000_000, "101"),
        ])
    );
    assert_eq!(
        a_states,
        owned(&[
            (1, "Running"),
            (5_000_000, "Restarting"),
            (5_000_001, "Running"),
            (10_000_000, "Terminated"),
        ])
    );
    // Every time once, in order; the last is the end (a change is there).
    assert_eq!(
        times,
        [0, 1, 5_000_000, 5_000_001, 5_000_002, 5_001_000, 10_000_000]
    );
}

/// Sequences whose names sanitize to one (`a b`, `a_b`; `Achse Ä`, `Achse Ö`) are distinct
/// VCD variables, each with its own states; so are faults `jam x` and `jam_x`.
#[test]
fn vcd_names_are_unique() {
    let text = r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":100,"sequences":[{"id":0,"name":"a b","caller":null},{"id":1,"name":"a_b","caller":null},{"id":2,"name":"Achse Ä","caller":null},{"id":3,"name":"Achse Ö","caller":null}],"monitors":[]}
{"t":10,"seq":0,"from":"Idle","to":"Running","cause":"start"}
{"t":20,"seq":1,"from":"Idle","to":"Running","cause":"start"}
{"t":30,"seq":2,"from":"Idle","to":"Running","cause":"start"}
{"t":40,"seq":3,"from":"Idle","to":"Running","cause":"start"}
{"t":50,"event":"fault","name":"jam x"}
{"t":60,"event":"fault","name":"jam_x"}
"#;
    let run = tracefile::read(text).unwrap();
    assert_eq!(
        vcd::sequence_names(&run),
        ["a_b", "a_b_1", "Achse__", "Achse___3"]
    );
    let mut buf = Vec::new();
    vcd::write(&run, &mut buf).unwrap();
    let mut parser = ::vcd::Parser::new(&buf[..]);
    let header = parser.parse_header().unwrap();
    let mut by_code = HashMap::new();
    for (name, started) in [
        ("a_b", 10_000),
        ("a_b_1", 20_000),
        ("Achse__", 30_000),
        ("Achse___3", 40_000),
    ] {
        let v = header
            .find_var(&["rtseq", "sequences", name])
            .unwrap_or_else(|| panic!("no variable {name}"));
        assert!(
            by_code.insert(v.code, started).is_none(),
            "{name} shares a code"
        );
    }
    let mut pulses = HashMap::new();
    for (name, at) in [("fault_jam_x", 50_000), ("fault_jam_x_1", 60_000)] {
        let v = header.find_var(&["rtseq", "events", name]).unwrap();
        pulses.insert(v.code, at);
    }
    let (mut t, mut in_dump) = (0u64, false);
    for cmd in parser {
        match cmd.unwrap() {
            ::vcd::Command::Timestamp(x) => t = x,
            ::vcd::Command::Begin(::vcd::SimulationCommand::Dumpvars) => in_dump = true,
            ::vcd::Command::End(::vcd::SimulationCommand::Dumpvars) => in_dump = false,
            ::vcd::Command::ChangeString(id, s) if !in_dump && by_code.contains_key(&id) => {
                assert_eq!((s.as_str(), t), ("Running", by_code[&id]));
            }
            ::vcd::Command::ChangeScalar(id, ::vcd::Value::V1) if pulses.contains_key(&id) => {
                assert_eq!(t, pulses[&id]);
            }
            _ => {}
        }
    }
}
