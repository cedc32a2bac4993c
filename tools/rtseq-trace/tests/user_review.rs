//! A cold review as a motor-control engineer looking at a fault on the bench: the demo's
//! over-current run (an excerpt of `./x demo --fault overcurrent@5s`, as printed), a
//! host-simulator run with odd names, a lost-records log, an empty run, a gap; each checked
//! against the records. The four defects it found are fixed (the VCD's invented initial
//! signal values and its state across lost records, the live view on a trace file and on a
//! huge `--size`); their tests fail without the fixes.

mod common;

use std::cell::Cell;
use std::process::{Command, Output};

use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cx, Duration, Failure, Instant, Monitor, Monitors, SeqConfig, Sequence, Sequencer,
};
use rtseq_trace::log::Hints;
use rtseq_trace::{html, perfetto, read_run, vcd};
use serde_json::Value;

/// The fault part of `./x demo --fault overcurrent@5s` (lines 70..=89 of its output).
const OC_LOG: &str = "   4.947007 INFO  seq       dwell          Running -> Terminated      (completed)
   4.947009 INFO  seq       move           Terminated -> Running      (start)
   5.000008 INFO  FAULT     over-current injected: the current sensor reads +12 A
   5.000009 INFO  safety    critical input: over-current (|i| > 6 A)
   5.000012 INFO  axis      x   82.819 mm  v  102.5 mm/s  i  1.36 A  | moving, level homed, LED off
   5.001014 INFO  safety    level homed -> emergency
   5.001015 INFO  request   abort all by the safety system
   5.001016 INFO  seq       blink          Running -> Aborting        (abort all)
   5.001018 INFO  seq       blink          Aborting -> Aborted        (abort all)
   5.001020 INFO  seq       move           Running -> Aborting        (abort all)
   5.001022 INFO  seq       move           Aborting -> Aborted        (abort all)
   5.001024 INFO  seq       status         Running -> Aborting        (abort all)
   5.001026 INFO  seq       status         Aborting -> Aborted        (abort all)
   5.001028 INFO  seq       moves          Running -> Aborting        (abort all)
   5.001030 INFO  seq       moves          Aborting -> Aborted        (abort all)
   5.001033 INFO  seq       main           Running -> Aborting        (abort all)
   5.001035 INFO  seq       main           Aborting -> Aborted        (abort all)
   5.001038 INFO  reaction  over-current: the safety system tripped (level emergency, drive permit off) 1 ms after the fault
   5.006005 INFO  reaction  over-current: motor stopped 6 ms after the fault (at 83.111 mm)
   5.250006 INFO  axis      x   83.111 mm  v    0.0 mm/s  i  0.00 A  | fault, level emergency, LED off
";

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
}

fn run_bin(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

fn write_tmp(name: &str, text: &str) -> String {
    let p = common::scratch("review").join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// `rtseq-trace live FILE --plain --size SIZE` (with the demo's tree), its stdout.
fn live_plain(log: &str, tree: bool, size: &str) -> String {
    let path = write_tmp("live.log", log);
    let tree_file = common::manifest_dir().join("demo.tree");
    let mut c = bin();
    c.args(["live", &path, "--plain", "--size", size]);
    if tree {
        c.arg("--tree").arg(tree_file);
    }
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn vcd_text(run: &rtseq_trace::model::Run) -> String {
    let mut b = Vec::new();
    vcd::write(run, &mut b).unwrap();
    String::from_utf8(b).unwrap()
}

fn perfetto_doc(run: &rtseq_trace::model::Run) -> Value {
    let mut b = Vec::new();
    perfetto::write(run, &mut b).unwrap();
    serde_json::from_slice(&b).unwrap()
}

/// The value-change section after `$enddefinitions`, `$dumpvars` included.
fn changes(vcd: &str) -> &str {
    vcd.split_once("$enddefinitions $end\n").unwrap().1
}

/// The live view of the over-current fault: every sequence's final state, the level, every
/// record in the latest events, in log order, with the log's times.
#[test]
fn live_view_of_the_overcurrent_fault() {
    let out = live_plain(OC_LOG, true, "100x26");
    let want = "\
┌ rtseq live ──────────────────────────────────────────────────────────────────────────────────────┐
│t = 5.250006 s   safety level: emergency   6 sequences, 12 transitions   input ended; q: quit     │
└──────────────────────────────────────────────────────────────────────────────────────────────────┘
┌ sequences (nested by caller) ─────────────┐┌ latest events ──────────────────────────────────────┐
│main       Aborted                         ││4.947007 dwell: Running -> Terminated (completed)    │
│  status   Aborted                         ││4.947009 move: Terminated -> Running (start)         │
│    blink  Aborted                         ││5.000008 FAULT over-current injected: the current sen│
│  moves    Aborted                         ││5.000009 safety critical input: over-current (|i| > 6│
│    dwell  Terminated                      ││5.001014 safety level emergency                      │
│    move   Aborted                         ││5.001015 request abort all by the safety system      │
│                                           ││5.001016 blink: Running -> Aborting (abort all)      │
│                                           ││5.001018 blink: Aborting -> Aborted (abort all)      │
│                                           ││5.001020 move: Running -> Aborting (abort all)       │
│                                           ││5.001022 move: Aborting -> Aborted (abort all)       │
│                                           ││5.001024 status: Running -> Aborting (abort all)     │
│                                           ││5.001026 status: Aborting -> Aborted (abort all)     │
│                                           ││5.001028 moves: Running -> Aborting (abort all)      │
│                                           ││5.001030 moves: Aborting -> Aborted (abort all)      │
│                                           ││5.001033 main: Running -> Aborting (abort all)       │
│                                           ││5.001035 main: Aborting -> Aborted (abort all)       │
│                                           ││5.001038 reaction over-current: the safety system tri│
│                                           ││5.006005 reaction over-current: motor stopped 6 ms af│
│                                           ││                                                     │
│                                           ││                                                     │
│                                           ││                                                     │
└───────────────────────────────────────────┘└─────────────────────────────────────────────────────┘
";
    assert_eq!(out, want);
}

/// The Perfetto export of the fault: valid trace-event JSON (`ph`, integer `ts` in µs,
/// `pid`/`tid`), every abort-all at its logged µs, the emergency level from 5.001014 s to
/// the end, one abort-all request (the logged one, no guessed ones), nothing invented.
#[test]
fn perfetto_of_the_overcurrent_fault() {
    let run = read_run(OC_LOG, common::demo_hints()).unwrap();
    let doc = perfetto_doc(&run);
    let evs = doc["traceEvents"].as_array().unwrap();
    for e in evs {
        let ph = e["ph"].as_str().unwrap();
        assert!(matches!(ph, "M" | "X" | "i" | "C"), "{e}");
        assert_eq!(e["pid"], 1, "{e}");
        if ph != "M" {
            assert!(e["ts"].is_u64(), "{e}");
        }
        if ph == "X" || ph == "i" {
            assert!(e["tid"].is_u64(), "{e}");
        }
        if ph == "X" {
            assert!(e["dur"].is_u64(), "{e}");
        }
    }
    // Aborting spans: 2 µs each, at the logged times, on each sequence's track.
    let mut aborting: Vec<(String, u64, u64)> = evs
        .iter()
        .filter(|e| e["cat"] == "state")
        .map(|e| {
            let tid = e["tid"].as_u64().unwrap();
            let name = evs
                .iter()
                .find(|m| m["name"] == "thread_name" && m["tid"] == tid)
                .unwrap()["args"]["name"]
                .as_str()
                .unwrap()
                .trim()
                .to_string();
            (name, e["ts"].as_u64().unwrap(), e["dur"].as_u64().unwrap())
        })
        .collect();
    aborting.sort_by_key(|a| a.1);
    assert_eq!(
        aborting,
        [
            ("blink".to_string(), 5_001_016, 2),
            ("move".to_string(), 5_001_020, 2),
            ("status".to_string(), 5_001_024, 2),
            ("moves".to_string(), 5_001_028, 2),
            ("main".to_string(), 5_001_033, 2),
        ]
    );
    let levels: Vec<(&str, u64, u64)> = evs
        .iter()
        .filter(|e| e["cat"] == "level")
        .map(|e| {
            (
                e["name"].as_str().unwrap(),
                e["ts"].as_u64().unwrap(),
                e["dur"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(levels, [("emergency", 5_001_014, 5_250_006 - 5_001_014)]);
    let instants: Vec<(&str, u64)> = evs
        .iter()
        .filter(|e| e["ph"] == "i")
        .map(|e| (e["name"].as_str().unwrap(), e["ts"].as_u64().unwrap()))
        .collect();
    assert_eq!(
        instants,
        [
            ("fault over-current", 5_000_008),
            ("input over-current (|i| > 6 A)", 5_000_009),
            ("request abort all", 5_001_015),
            ("note reaction", 5_001_038),
            ("note reaction", 5_006_005),
        ]
    );
    // The move run: started at 4.947009, aborted (abort all) at 5.001022.
    let mv = evs
        .iter()
        .find(|e| e["cat"] == "run" && e["name"] == "move")
        .unwrap();
    assert_eq!(mv["ts"], 4_947_009);
    assert_eq!(mv["dur"], 5_001_022 - 4_947_009);
    assert_eq!(mv["args"]["outcome"], "aborted (abort all)");
}

/// The VCD of the fault: IEEE 1364 header (`$timescale 1 ns`, scopes, `$var`s with
/// one-character ids), the abort-all transitions at their µs × 1000, the level, pulses.
#[test]
fn vcd_of_the_overcurrent_fault() {
    let run = read_run(OC_LOG, common::demo_hints()).unwrap();
    let text = vcd_text(&run);
    let (head, _) = text.split_once("$enddefinitions $end\n").unwrap();
    assert!(head.starts_with(
        "$version rtseq-trace 0.1.0 $end\n$timescale 1 ns $end\n$scope module rtseq $end\n"
    ));
    assert!(head.contains("$var string 1 & main $end\n"), "{head}");
    assert!(head.contains("$var wire 3 , main $end\n"), "{head}");
    assert!(
        head.contains("$var wire 1 0 request_abort_all $end\n"),
        "{head}"
    );
    assert!(head.contains("$var real 64 1 position_mm $end\n"), "{head}");
    let ch = changes(&text);
    for want in [
        "#5001014000\nsemergency -\n#5001015000\n10\n#5001016000\n00\nsAborting $\nb011 *\n",
        "#5001033000\nsAborting &\nb011 ,\n#5001035000\nsAborted &\nb100 ,\n",
        "#5000012000\nr82.819 1\nr102.5 2\nr1.36 3\n",
    ] {
        assert!(ch.contains(want), "{want} not in\n{ch}");
    }
    // Readable by an independent parser.
    let mut p = ::vcd::Parser::new(text.as_bytes());
    p.parse_header().unwrap();
    for c in p {
        c.unwrap();
    }
}

#[test]
fn vcd_signal_has_no_value_before_its_first_sample() {
    let run = read_run(OC_LOG, common::demo_hints()).unwrap();
    let text = vcd_text(&run);
    let ch = changes(&text);
    let dumpvars = ch.split_once("$end\n").unwrap().0;
    // Position, velocity and current (ids 1, 2, 3) have no value before 5.000012 s.
    for id in ["1", "2", "3"] {
        assert!(
            !dumpvars
                .lines()
                .any(|l| l.starts_with('r') && l.ends_with(&format!(" {id}"))),
            "signal {id} has a value at 0 s:\n{dumpvars}"
        );
    }
    assert!(ch.contains("#5000012000\nr82.819 1\n"));
}

/// Odd names (quotes, `<`, `&`, `$end`, unicode, a script end tag) from a host-simulator
/// run: escaped in the HTML, exact in the Perfetto JSON, `_` in VCD identifiers; the
/// states and times are the simulator's.
#[test]
fn sim_run_with_odd_names_in_every_output() {
    const SEQ: &str = "run \"x\" <y> & ü ✓ </script>";
    const MON: &str = "over-current 'i' > 5 A & $end";
    struct Run;
    impl Sequence<Cell<f32>> for Run {
        async fn action(&mut self, cx: &Cx<'_, Cell<f32>>) -> Result<(), Failure> {
            cx.wait_until(|_| false).await;
            Ok(())
        }
    }
    let seq: &'static Sequencer<Cell<f32>, 4> = Box::leak(Box::new(Sequencer::new()));
    let run = seq.add(SeqConfig::new(SEQ), Run).unwrap();
    let id = run.id();
    let cond: &'static mut _ = Box::leak(Box::new(|a: &Cell<f32>, _: Instant| a.get() > 5.0));
    let mut monitors = Monitors::<Cell<f32>, 1>::new();
    monitors
        .add(id, Monitor::new(MON, cond, Behaviour::AbortOwner))
        .unwrap();
    let amps: &'static Cell<f32> = Box::leak(Box::new(Cell::new(0.0)));
    let mut sim = Sim::new(seq, amps, monitors);
    sim.lane(run);
    sim.before_tick(|now, a| {
        if now.as_ticks() >= 20_000 {
            a.set(8.0)
        }
    });
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(50));
    let mut out = Vec::new();
    sim.write_trace(&mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let r = read_run(&text, Hints::default()).unwrap();
    let got: Vec<(u64, &str, &str, &str)> = r
        .transitions
        .iter()
        .map(|t| (t.time_us, t.from.name(), t.to.name(), t.cause.as_str()))
        .collect();
    let cause = format!("monitor {MON}");
    assert_eq!(
        got,
        [
            (0, "Idle", "Running", "start"),
            (20_000, "Running", "Aborting", cause.as_str()),
            (20_000, "Aborting", "Aborted", cause.as_str()),
        ]
    );
    // HTML: escaped, never raw.
    let page = html::render(&r, "t");
    assert!(!page.contains("</script>\"") && !page.contains("<y>"));
    assert!(page.contains("run &quot;x&quot; &lt;y&gt; &amp; ü ✓ &lt;/script&gt;"));
    assert_eq!(page.matches("<script>").count(), 1);
    // Perfetto: the names exactly.
    let doc = perfetto_doc(&r);
    let evs = doc["traceEvents"].as_array().unwrap();
    let span = evs.iter().find(|e| e["cat"] == "run").unwrap();
    assert_eq!(span["name"], SEQ);
    assert_eq!(span["ts"], 0);
    assert_eq!(span["dur"], 20_000);
    assert_eq!(span["args"]["outcome"], format!("aborted (monitor {MON})"));
    let fired = evs.iter().find(|e| e["cat"] == "monitor").unwrap();
    assert_eq!(fired["name"], format!("monitor {MON}"));
    assert_eq!(fired["ts"], 20_000);
    // VCD: identifiers of `_`; the abort at 20 ms (both states, 1 ns apart).
    let v = vcd_text(&r);
    assert!(
        v.contains("$var string 1 ! run__x___y__________script_ $end\n"),
        "{v}"
    );
    assert!(
        v.contains("$var wire 1 $ monitor_over_current__i____5_A____end $end\n"),
        "{v}"
    );
    assert!(
        changes(&v)
            .contains("#20000000\nsAborting !\nb011 \"\n1$\n#20000001\nsAborted !\nb100 \"\n"),
        "{v}"
    );
}

/// A log whose firmware check says records were lost: a banner in the HTML, a `$comment`
/// in the VCD header, metadata in Perfetto, `RECORDS LOST` in the live view, a warning on
/// standard error.
#[test]
fn lost_records_from_a_failed_check_everywhere() {
    let log = format!("{OC_LOG}   5.301035 INFO  check     FAIL  no trace record or event lost\n");
    let run = read_run(&log, Hints::default()).unwrap();
    let w = "records were lost (the source does not say how many): the trace is incomplete";
    assert!(html::render(&run, "t").contains(&format!(
        "<div class=\"lost-warning\" role=\"alert\"><b>Warning:</b> {w}."
    )));
    assert!(vcd_text(&run).contains(&format!("$timescale 1 ns $end\n$comment {w} $end\n")));
    let doc = perfetto_doc(&run);
    assert_eq!(doc["metadata"]["lost_records"], "unknown");
    assert_eq!(doc["metadata"]["warning"], w);
    let out = live_plain(&log, false, "100x6");
    assert!(
        out.lines()
            .nth(1)
            .unwrap()
            .starts_with("│RECORDS LOST (incomplete)   t = 5.301035 s"),
        "{out}"
    );
    let path = write_tmp("lost.log", &log);
    let html_out = format!("{path}.html");
    let o = run_bin(&["render", &path, "--html", &html_out]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).starts_with(&format!("rtseq-trace: warning: {w}\n")));
}

/// An empty simulator run (a header, no records): every output says so without inventing
/// anything, and the command line does not fail.
#[test]
fn empty_sim_run() {
    let text = "{\"format\":\"rtseq-trace\",\"version\":1,\"time_unit\":\"us\",\"end\":0,\"lost\":0,\"sequences\":[{\"id\":0,\"name\":\"idle one\",\"caller\":null}],\"monitors\":[]}\n";
    let path = write_tmp("empty.jsonl", text);
    let (h, v, p) = (
        format!("{path}.html"),
        format!("{path}.vcd"),
        format!("{path}.json"),
    );
    let o = run_bin(&["render", &path, "--html", &h, "--vcd", &v, "--perfetto", &p]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let vcd = std::fs::read_to_string(&v).unwrap();
    assert_eq!(
        changes(&vcd),
        "#0\n$dumpvars\nsIdle !\nb000 \"\nsunknown #\n$end\n"
    );
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    assert!(doc["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .all(|e| e["ph"] == "M"));
    let page = std::fs::read_to_string(&h).unwrap();
    assert!(!page.contains("lost-warning\""));
    assert!(page.contains("<g class=\"seq-row\" data-seq=\"idle one\"><rect class=\"row-bg\""));
}

#[test]
fn live_on_a_trace_file_is_not_shown_as_empty() {
    let text = "{\"format\":\"rtseq-trace\",\"version\":1,\"time_unit\":\"us\",\"end\":30,\"sequences\":[{\"id\":0,\"name\":\"main\",\"caller\":null},{\"id\":1,\"name\":\"child\",\"caller\":0}],\"monitors\":[{\"id\":0,\"name\":\"jam\",\"owner\":0}]}
{\"t\":0,\"seq\":0,\"from\":\"Idle\",\"to\":\"Running\",\"cause\":\"start\"}
{\"t\":5,\"seq\":1,\"from\":\"Idle\",\"to\":\"Running\",\"cause\":\"start\"}
{\"t\":10,\"event\":\"monitor\",\"owner\":0,\"behaviour\":\"AbortOwner\",\"monitor\":0,\"text\":\"monitor 'jam' of 'main' fired: AbortOwner\"}
{\"t\":10,\"seq\":1,\"from\":\"Running\",\"to\":\"Aborted\",\"cause\":\"monitor\",\"monitor\":0}
{\"t\":10,\"seq\":0,\"from\":\"Running\",\"to\":\"Aborted\",\"cause\":\"monitor\",\"monitor\":0}
";
    let path = write_tmp("run.jsonl", text);
    let o = run_bin(&["live", &path, "--plain", "--size", "100x8"]);
    let out = String::from_utf8_lossy(&o.stdout);
    // Refused, as `render` refuses input it cannot read: the live view reads a log.
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert_eq!(
        String::from_utf8_lossy(&o.stderr),
        format!(
            "rtseq-trace: {path}: a trace file (JSON Lines); the live view reads a firmware's \
             log (render a trace file with `rtseq-trace render`)\n"
        )
    );
}

#[test]
fn live_size_too_large_is_refused() {
    let path = write_tmp("oc.log", OC_LOG);
    for size in ["65535x65535", "100000x2"] {
        let o = run_bin(&["live", &path, "--plain", "--size", size]);
        assert_eq!(o.status.code(), Some(1), "{size}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.starts_with(&format!("rtseq-trace: --size {size}:")),
            "{err}"
        );
        assert!(err.contains("too large"), "{err}");
    }
}

#[test]
fn vcd_gap_is_not_the_earlier_state() {
    let text = "{\"format\":\"rtseq-trace\",\"version\":1,\"time_unit\":\"us\",\"end\":100,\"sequences\":[{\"id\":0,\"name\":\"s\",\"caller\":null}],\"monitors\":[]}
{\"t\":10,\"seq\":0,\"from\":\"Running\",\"to\":\"Paused\",\"cause\":\"pause\"}
{\"t\":30,\"seq\":0,\"from\":\"Aborting\",\"to\":\"Aborted\",\"cause\":\"abort\"}
";
    let run = read_run(text, Hints::default()).unwrap();
    let v = vcd_text(&run);
    // The last value of the state code (id `"`) before 30 µs.
    let mut now = 0u64;
    let mut code_before_30 = String::new();
    for l in changes(&v).lines() {
        if let Some(t) = l.strip_prefix('#') {
            now = t.parse().unwrap();
        } else if now < 30_000 && l.ends_with(" \"") && l.starts_with('b') {
            code_before_30 = l.to_string();
        }
    }
    assert_eq!(code_before_30, "bxxx \"", "{v}");
}
