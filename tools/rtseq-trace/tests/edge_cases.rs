//! The tool on edge cases — hostile names, empty runs, 256
//! sequences, records out of order, a file cut off, the live view — and the round trip
//! from the simulator's records to what the tool shows.

use std::cell::Cell;
use std::collections::{HashMap, HashSet};

use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cx, Duration, Failure, Instant, Monitor, Monitors, Seq, SeqConfig, Sequence,
    Sequencer, Wait,
};
use rtseq_trace::live::Live;
use rtseq_trace::log::{Hints, LogParser};
use rtseq_trace::model::{EventKind, Run, State};
use rtseq_trace::{html, perfetto, read_run, tracefile, vcd};
use serde_json::Value;

const MAIN: &str = "<script>alert(\"main\")</script>";
const CHILD: &str = "a\"b\\c 'q' &amp; ünï ✓ 𝄞";
const SAFE: &str = "tab\there\nnewline $end";
const MON: &str = "</title><img src=x onerror=alert(1)>";

/// Steps a 10 ms wait.
struct Main(Seq<Wait>);
impl Sequence<Cell<bool>> for Main {
    async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

/// Fails at once.
struct Fails;
impl Sequence<Cell<bool>> for Fails {
    async fn action(&mut self, _cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
        Err(Failure::App(3))
    }
}

/// A run with hostile names: main (steps child), a monitor on main that fires at 3 ms and
/// runs the exception sequence `SAFE` (which fails), then aborts main; main is paused and
/// resumed before. Returns the trace file's text and the simulator's records.
fn hostile_run() -> (String, Vec<rtseq::Record>, Vec<rtseq::Transition>) {
    let seq: &'static Sequencer<Cell<bool>, 4> = Box::leak(Box::new(Sequencer::new()));
    let child = seq
        .add(SeqConfig::new(CHILD), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let safe = seq.add(SeqConfig::new(SAFE), Fails).unwrap();
    let s = safe.id();
    let main = seq.add(SeqConfig::new(MAIN), Main(child)).unwrap();
    let m = main.id();
    let cond: &'static mut _ = Box::leak(Box::new(|c: &Cell<bool>, _: Instant| c.get()));
    let mut monitors: Monitors<Cell<bool>, 1> = Monitors::new();
    monitors
        .add(
            m,
            Monitor::new(MON, cond, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let ctrl: &'static Cell<bool> = Box::leak(Box::new(Cell::new(false)));
    let mut sim = Sim::new(seq, ctrl, monitors);
    sim.lane(main);
    sim.lane(safe);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(1));
    sim.pause(m).unwrap();
    sim.run_for(Duration::from_millis(1));
    sim.resume(m).unwrap();
    sim.run_for(Duration::from_millis(1));
    ctrl.set(true);
    sim.run_for(Duration::from_millis(5));
    let mut out = Vec::new();
    sim.write_trace(&mut out).unwrap();
    (
        String::from_utf8(out).unwrap(),
        sim.records().to_vec(),
        sim.trace().to_vec(),
    )
}

/// Every line of the simulator's file is JSON, the names survive exactly, and what the
/// tool reads is what the simulator recorded: every transition (time, sequence, from, to)
/// in order, every event.
#[test]
fn sim_round_trip_with_hostile_names() {
    let (text, records, trace) = hostile_run();
    for l in text.lines() {
        serde_json::from_str::<Value>(l).unwrap_or_else(|e| panic!("{e}: {l}"));
    }
    let run = read_run(&text, Hints::default()).unwrap();
    let names: Vec<&str> = run.sequences.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, [CHILD, SAFE, MAIN]);
    // Transitions: exactly the simulator's, in order.
    let got: Vec<(u64, usize, State, State)> = run
        .transitions
        .iter()
        .map(|t| (t.time_us, t.seq, t.from, t.to))
        .collect();
    let want: Vec<(u64, usize, State, State)> = trace
        .iter()
        .map(|t| {
            let st = |s: rtseq::RunningState| State::parse(&format!("{s:?}")).unwrap();
            (t.time.as_ticks(), t.sequence.index(), st(t.from), st(t.to))
        })
        .collect();
    assert_eq!(got, want);
    // Events: as many, at the same times, in order.
    let ev_want: Vec<u64> = records
        .iter()
        .filter(|r| r.event().is_some())
        .map(|r| r.time.as_ticks())
        .collect();
    let ev_got: Vec<u64> = run
        .events
        .iter()
        .map(|e| e.time_us)
        .chain(run.levels.iter().map(|l| l.time_us))
        .collect();
    assert_eq!(ev_got, ev_want, "{:#?}", run.events);
    let kinds: HashSet<EventKind> = run.events.iter().map(|e| e.kind).collect();
    for k in [EventKind::Monitor, EventKind::Request, EventKind::Failure] {
        assert!(kinds.contains(&k), "{k:?} missing: {:#?}", run.events);
    }
    let fired = run
        .events
        .iter()
        .find(|e| e.kind == EventKind::Monitor)
        .unwrap();
    assert_eq!(fired.name, MON);
    // The monitor's name in the abort's cause.
    assert!(run
        .transitions
        .iter()
        .any(|t| t.cause == format!("monitor {MON}")));
    // The exception sequence's caller is the monitor's owner.
    assert_eq!(run.sequences[1].caller, Some(2));
}

/// The HTML page of hostile names has no markup of theirs: every name is escaped (no
/// `<script>alert`, no `<img`), and the names are there, escaped.
#[test]
fn html_escapes_hostile_names() {
    let (text, _, _) = hostile_run();
    let run = read_run(&text, Hints::default()).unwrap();
    let page = html::render(&run, "<b>title</b> & \"q\"");
    assert!(!page.contains("<script>alert"), "unescaped script");
    assert!(!page.contains("<img"), "unescaped img");
    assert!(!page.contains("<b>title"), "unescaped title");
    assert!(page.contains(&html::esc(MAIN)));
    assert!(page.contains(&html::esc(CHILD)));
    assert_eq!(
        page.matches("<script>").count(),
        1,
        "one script: the page's own"
    );
    // Markers for the monitor firing, the failure of the exception sequence, requests.
    for class in ["marker monitor-fire", "marker failure", "marker request"] {
        assert!(page.contains(class), "{class}");
    }
}

/// Perfetto: valid JSON whose thread names are the names, exactly; the complete events of
/// each track nest (a span contains or is disjoint from every other of its track).
#[test]
fn perfetto_names_and_nesting() {
    let (text, _, _) = hostile_run();
    let run = read_run(&text, Hints::default()).unwrap();
    let mut buf = Vec::new();
    perfetto::write(&run, &mut buf).unwrap();
    let doc: Value = serde_json::from_slice(&buf).unwrap();
    let evs = doc["traceEvents"].as_array().unwrap();
    let threads: HashSet<String> = evs
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .map(|e| e["args"]["name"].as_str().unwrap().trim_start().to_string())
        .collect();
    for n in [MAIN, CHILD, SAFE] {
        assert!(threads.contains(n), "{n:?} not among {threads:?}");
    }
    let mut by_tid: HashMap<u64, Vec<(u64, u64)>> = HashMap::new();
    for e in evs.iter().filter(|e| e["ph"] == "X") {
        let ts = e["ts"].as_u64().unwrap();
        let end = ts + e["dur"].as_u64().unwrap();
        by_tid
            .entry(e["tid"].as_u64().unwrap())
            .or_default()
            .push((ts, end));
    }
    for (tid, spans) in by_tid {
        for a in &spans {
            for b in &spans {
                let disjoint = a.1 <= b.0 || b.1 <= a.0;
                let nested = (a.0 <= b.0 && b.1 <= a.1) || (b.0 <= a.0 && a.1 <= b.1);
                assert!(disjoint || nested, "tid {tid}: {a:?} and {b:?} overlap");
            }
        }
    }
}

/// VCD of hostile names: read by the `vcd` crate; one variable per sequence in each scope.
#[test]
fn vcd_of_hostile_names_parses() {
    let (text, _, _) = hostile_run();
    let run = read_run(&text, Hints::default()).unwrap();
    let mut buf = Vec::new();
    vcd::write(&run, &mut buf).unwrap();
    let mut parser = ::vcd::Parser::new(&buf[..]);
    let header = parser.parse_header().unwrap();
    for name in vcd::sequence_names(&run) {
        assert!(
            header.find_var(&["rtseq", "sequences", &name]).is_some(),
            "{name}"
        );
    }
    for cmd in parser {
        cmd.unwrap();
    }
}

fn header(seqs: &str, end: u64) -> String {
    format!(
        r#"{{"format":"rtseq-trace","version":1,"time_unit":"us","end":{end},"lost":0,"sequences":[{seqs}],"monitors":[]}}"#
    )
}

/// Every export of `run`; the VCD and the Perfetto JSON read back.
fn all_exports(run: &Run) -> (String, Vec<u8>, Value) {
    let page = html::render(run, "t");
    let mut v = Vec::new();
    vcd::write(run, &mut v).unwrap();
    let mut parser = ::vcd::Parser::new(&v[..]);
    parser.parse_header().unwrap();
    for cmd in parser {
        cmd.unwrap();
    }
    let mut p = Vec::new();
    perfetto::write(run, &mut p).unwrap();
    let doc: Value = serde_json::from_slice(&p).unwrap();
    (page, v, doc)
}

/// Empty runs: no sequence at all, and sequences without records (the simulator's file of
/// a run never started). Every export works.
#[test]
fn empty_runs() {
    for text in [
        header("", 0),
        header(r#"{"id":0,"name":"idle","caller":null}"#, 0),
        header(r#"{"id":0,"name":"idle","caller":null}"#, 5000),
    ] {
        let run = read_run(&text, Hints::default()).unwrap();
        assert!(run.transitions.is_empty());
        let (page, _, doc) = all_exports(&run);
        assert!(page.contains("</html>"));
        assert!(doc["traceEvents"].is_array());
    }
    // The simulator's file of a run where nothing started.
    let seq: Sequencer<(), 2> = Sequencer::new();
    seq.add(SeqConfig::new("never"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    let mut out = Vec::new();
    sim.write_trace(&mut out).unwrap();
    let run = read_run(&String::from_utf8(out).unwrap(), Hints::default()).unwrap();
    assert_eq!(run.sequences.len(), 1);
    all_exports(&run);
}

/// 256 sequences (the most a sequencer has), each started at its own µs: every export has
/// all of them, with distinct VCD identifiers and Perfetto tracks.
#[test]
fn two_hundred_fifty_six_sequences() {
    let seqs: Vec<String> = (0..256)
        .map(|i| {
            format!(
                r#"{{"id":{i},"name":"s{i}","caller":{}}}"#,
                if i == 0 {
                    "null".to_string()
                } else {
                    ((i - 1) / 2).to_string()
                }
            )
        })
        .collect();
    let mut text = header(&seqs.join(","), 10_000);
    for i in 0..256 {
        text.push_str(&format!(
            "\n{{\"t\":{i},\"seq\":{i},\"from\":\"Idle\",\"to\":\"Running\",\"cause\":\"start\"}}"
        ));
    }
    let run = read_run(&text, Hints::default()).unwrap();
    assert_eq!(run.sequences.len(), 256);
    assert_eq!(run.transitions.len(), 256);
    let (page, v, doc) = all_exports(&run);
    assert_eq!(page.matches("class=\"seq-row\"").count(), 256);
    let mut parser = ::vcd::Parser::new(&v[..]);
    let h = parser.parse_header().unwrap();
    let mut codes = HashSet::new();
    for i in 0..256 {
        let name = format!("s{i}");
        for scope in ["sequences", "state_codes"] {
            let var = h.find_var(&["rtseq", scope, &name]).unwrap();
            assert!(codes.insert(var.code), "{scope}.{name}: code taken");
        }
    }
    let tids: HashSet<u64> = doc["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .map(|e| e["tid"].as_u64().unwrap())
        .collect();
    assert_eq!(tids.len(), 256 + 2);
}

/// Records out of time order (a converted log lists transitions first): the reader orders
/// them by time ("readers order records by time"); a record's place in the file does not
/// matter when the times differ.
#[test]
fn records_out_of_order() {
    let head = header(
        r#"{"id":0,"name":"a","caller":null},{"id":1,"name":"b","caller":0}"#,
        100,
    );
    let lines = [
        r#"{"t":10,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
        r#"{"t":20,"seq":1,"from":"Idle","to":"Running","cause":"start"}"#,
        r#"{"t":25,"event":"request","sequence":0,"request":"pause","by":"application","name":"pause a","text":"x"}"#,
        r#"{"t":30,"seq":0,"from":"Running","to":"Paused","cause":"pause"}"#,
        r#"{"t":40,"seq":0,"from":"Paused","to":"Running","cause":"resume"}"#,
        r#"{"t":50,"seq":1,"from":"Running","to":"Terminated","cause":"completed"}"#,
        r#"{"t":60,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}"#,
    ];
    let ordered = tracefile::read(&format!("{head}\n{}\n", lines.join("\n"))).unwrap();
    let mut rev = lines.to_vec();
    rev.reverse();
    let reversed = tracefile::read(&format!("{head}\n{}\n", rev.join("\n"))).unwrap();
    assert_eq!(ordered, reversed);
    assert!(ordered.state_spans(0).iter().all(|s| s.gap.is_none()));
}

/// A file cut off in the middle of its last line (a run killed while saving): an error that
/// names the line ("Malformed input is an `Err` naming the line").
#[test]
fn cut_off_file_names_the_line() {
    let text = format!(
        "{}\n{}\n{}",
        header(r#"{"id":0,"name":"a","caller":null}"#, 100),
        r#"{"t":10,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
        r#"{"t":60,"seq":0,"from":"Runn"#
    );
    let err = read_run(&text, Hints::default()).unwrap_err();
    assert!(err.starts_with("line 3:"), "{err}");
}

/// A run cut off mid-way (the record ends while a sequence runs, paused): its run is
/// `still running` up to the end, its pause reaches the end.
#[test]
fn run_cut_off_mid_way() {
    let text = format!(
        "{}\n{}\n{}\n",
        header(r#"{"id":0,"name":"a","caller":null}"#, 100),
        r#"{"t":10,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
        r#"{"t":60,"seq":0,"from":"Running","to":"Paused","cause":"pause"}"#,
    );
    let run = read_run(&text, Hints::default()).unwrap();
    let runs = run.run_spans(0);
    assert_eq!(runs.len(), 1);
    assert_eq!((runs[0].start_us, runs[0].end_us), (10, 100));
    assert_eq!(runs[0].outcome, "still running");
    let last = run.state_spans(0).pop().unwrap();
    assert_eq!(
        (last.state, last.start_us, last.end_us),
        (State::Paused, 60, 100)
    );
}

/// The live view, fed the demo's log: after `Restarting -> Running (restart)` the
/// sequence's exception is over (semantics.md: `exceptionIsActive` "ends with a restart,
/// a new start, or an abort for another cause during the exception"), so the view, which
/// shows "each one's state and active exception", shows none for it.
#[test]
fn live_view_exception_ends_with_the_restart() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/demo-following-error.log"),
    )
    .unwrap();
    let hints = Hints::parse(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("demo.tree"),
        )
        .unwrap(),
    )
    .unwrap();
    let mut live = Live::new(hints, "t");
    let mut checked = false;
    for line in text.lines() {
        live.feed(line);
        if line.contains("moves") && line.contains("Restarting -> Running") {
            let screen = live.to_text(140, 32);
            let row = screen
                .lines()
                .map(|l| l.split('│').nth(1).unwrap_or(""))
                .find(|l| l.trim_start().starts_with("moves "))
                .unwrap()
                .to_string();
            assert!(row.contains("Running"), "{row}");
            assert!(!row.contains("exception:"), "after the restart: {row}");
            checked = true;
        }
    }
    assert!(checked);
}

/// The log of a board whose timestamp is `{=u32}ms` (the NUCLEO board's, log.rs) wraps
/// after 2^32 ms: the line after the wrap comes after the line before it; a board reset
/// (a step back of less than half the counter's range) is taken as it is.
#[test]
fn a_32_bit_ms_stamp_that_wraps_goes_on_counting() {
    let log = "4294967290ms INFO  seq       main  Idle -> Running  (start)\n\
               3ms INFO  seq       main  Running -> Terminated  (completed)\n";
    let run = LogParser::parse_all(log, Hints::default());
    assert_eq!(run.transitions[0].to, State::Running);
    assert_eq!(run.transitions[1].to, State::Terminated);
    assert_eq!(run.transitions[1].time_us, (4_294_967_296 + 3) * 1000);
    let us = "4294967000us INFO  seq       main  Idle -> Running  (start)\n\
              200us INFO  seq       main  Running -> Terminated  (completed)\n";
    let run = LogParser::parse_all(us, Hints::default());
    assert_eq!(run.transitions[1].time_us, 4_294_967_296 + 200);
    let reset = "600000ms INFO  seq       main  Idle -> Running  (start)\n\
                 5ms INFO  seq       main  Running -> Terminated  (completed)\n";
    let run = LogParser::parse_all(reset, Hints::default());
    assert_eq!(run.transitions[0].time_us, 5_000);
}

/// `render --trace` of the hostile run, read back, is the same run (trace-format.md: the
/// tool writes the format it reads).
#[test]
fn trace_written_by_the_tool_reads_back() {
    let (text, _, _) = hostile_run();
    let run = read_run(&text, Hints::default()).unwrap();
    let mut out = Vec::new();
    tracefile::write(&run, &mut out).unwrap();
    let back = tracefile::read(&String::from_utf8(out).unwrap()).unwrap();
    assert_eq!(back.sequences, run.sequences);
    assert_eq!(back.transitions, run.transitions);
    assert_eq!(back.events, run.events);
    assert_eq!(back.levels, run.levels);
}

/// A log whose signal sample is not a number (a sensor fault: defmt prints an `f32` NaN as
/// `NaN`, an overflow as `inf`): the log is read; `render --trace` writes it and the file
/// it wrote must read back (the tool "converts a log into" the trace format, which it
/// reads), and the VCD must stay readable.
#[test]
fn non_finite_signal_samples_survive_the_exports() {
    let log = "0.000005 INFO  seq       main  Idle -> Running  (start)\n\
               0.001000 INFO  axis      x NaN mm  v inf mm/s  i -0.11 A  | x\n\
               0.002000 INFO  axis      x 1.5 mm  v 2.0 mm/s  i 0.5 A  | x\n";
    let run = read_run(log, Hints::default()).unwrap();
    assert_eq!(run.signals.len(), 3);
    let mut out = Vec::new();
    tracefile::write(&run, &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let back = tracefile::read(&text);
    assert!(back.is_ok(), "the tool's own trace file: {back:?}\n{text}");
    let back = back.unwrap();
    let first = |r: &Run, name: &str| {
        r.signals
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.samples[0].1)
            .unwrap()
    };
    assert!(first(&back, "position").is_nan());
    assert_eq!(first(&back, "velocity"), f64::INFINITY);
    assert_eq!(first(&back, "current"), -0.11);
    assert!(text.contains(r#""value":"NaN""#), "{text}");
    // The HTML's lines skip them (no NaN coordinates), and marks them.
    let page = html::render(&run, "t");
    assert!(!page.contains("NaN,") && !page.contains(",NaN"), "{page}");
    assert_eq!(page.matches(r#"class="sample fault""#).count(), 2);
    // Perfetto: counters hold numbers only; the failed samples are instants.
    let events = perfetto::events(&run);
    for e in events.iter().filter(|e| e["ph"] == "C") {
        assert!(e["args"]["value"].is_f64(), "{e}");
    }
    let instants: Vec<&str> = events
        .iter()
        .filter(|e| e["cat"] == "signal")
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(instants, ["position [mm] = NaN", "velocity [mm/s] = inf"]);
}

/// The VCD of the same log (non-finite samples) is read by the `vcd` crate.
#[test]
fn non_finite_signal_samples_in_the_vcd() {
    let log = "0.000005 INFO  seq       main  Idle -> Running  (start)\n\
               0.001000 INFO  axis      x NaN mm  v inf mm/s  i -0.11 A  | x\n";
    let run = read_run(log, Hints::default()).unwrap();
    let mut v = Vec::new();
    vcd::write(&run, &mut v).unwrap();
    let mut parser = ::vcd::Parser::new(&v[..]);
    parser.parse_header().unwrap();
    for cmd in parser {
        assert!(cmd.is_ok(), "{cmd:?}\n{}", String::from_utf8_lossy(&v));
    }
}

/// The live view marks an exception on the sequence whose exception it is (the monitor's
/// owner: semantics.md item 3, "the owner gets `exceptionIsActive`/`activeException`"),
/// not on the exception sequence that handles it: `safe stop`, started with cause
/// `monitor following error`, has no exception of its own.
#[test]
fn live_view_exception_sequence_has_no_exception_of_its_own() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text =
        std::fs::read_to_string(dir.join("tests/fixtures/demo-following-error.log")).unwrap();
    let hints = Hints::parse(&std::fs::read_to_string(dir.join("demo.tree")).unwrap()).unwrap();
    let mut live = Live::new(hints, "t");
    for line in text.lines() {
        live.feed(line);
    }
    live.end();
    let screen = live.to_text(140, 32);
    let row = screen
        .lines()
        .map(|l| l.split('│').nth(1).unwrap_or(""))
        .find(|l| l.trim_start().starts_with("safe stop "))
        .unwrap()
        .to_string();
    assert!(!row.contains("exception:"), "{row}\n{screen}");
}
