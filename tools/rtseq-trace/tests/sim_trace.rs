//! `Sim::save_trace` against the firmware: the demo application with the following error
//! at 2.5 s on the host simulator writes a trace file whose transitions are the QEMU log's
//! (same times in ms, names, states, causes), whose safety levels are the log's, and whose
//! callers are `demo.tree`'s.

mod common;

use rtseq_trace::tracefile;

#[test]
fn host_trace_file_equals_the_qemu_log() {
    let log = common::fixture_run();
    let end_ms = log.end_us / 1000;
    let path = common::host_following_error_trace(end_ms);
    let host = tracefile::read(&std::fs::read_to_string(&path).unwrap()).unwrap();

    let name = |run: &rtseq_trace::model::Run, i: usize| run.sequences[i].name.clone();
    // The firmware does not print blink's starts and completions.
    let host_tr: Vec<_> = host
        .transitions
        .iter()
        .filter(|t| {
            !(name(&host, t.seq) == "blink" && matches!(t.cause.as_str(), "start" | "completed"))
        })
        .map(|t| {
            (
                t.time_us / 1000,
                name(&host, t.seq),
                t.from,
                t.to,
                t.cause.clone(),
            )
        })
        .collect();
    let log_tr: Vec<_> = log
        .transitions
        .iter()
        .map(|t| {
            (
                t.time_us / 1000,
                name(&log, t.seq),
                t.from,
                t.to,
                t.cause.clone(),
            )
        })
        .collect();
    assert_eq!(host_tr, log_tr);
    // The simulator's times are the ticks' (whole ms).
    assert!(host.transitions.iter().all(|t| t.time_us % 1000 == 0));
    // The safety levels the sequencer recorded are the firmware's, named.
    let levels = |run: &rtseq_trace::model::Run| -> Vec<_> {
        run.levels
            .iter()
            .map(|l| (l.time_us / 1000, l.level.clone()))
            .collect()
    };
    assert_eq!(levels(&host), levels(&log));
    assert!(levels(&host).len() >= 3, "{:?}", levels(&host));

    // The callers the simulator knows are the ones `./x demo` gives the tool for logs.
    let hints = common::demo_hints();
    let tree: String = host
        .sequences
        .iter()
        .filter_map(|s| Some(format!("{} < {}\n", s.name, host.sequences[s.caller?].name)))
        .collect();
    for s in &host.sequences {
        if let Some(c) = s.caller.map(|c| host.sequences[c].name.as_str()) {
            assert_eq!(
                hints.caller(&s.name),
                Some(c),
                "{}'s caller: the simulator's callers are\n{tree}fix demo.tree",
                s.name
            );
        }
    }
    // And the log, read with the hints, has the simulator's tree.
    for s in &log.sequences {
        let h = host.sequences.iter().find(|h| h.name == s.name).unwrap();
        assert_eq!(
            s.caller.map(|c| &log.sequences[c].name),
            h.caller.map(|c| &host.sequences[c].name),
            "caller of {}",
            s.name
        );
    }
}

/// A simulator whose trace ring (`T` = 1 record) is too small for what one poll records:
/// it loses records and writes how many (`"lost"`); the tool keeps the count and every
/// output of the command line says the trace is incomplete.
#[test]
fn records_the_simulator_lost_are_reported_everywhere() {
    use rtseq::sim::Sim;
    use rtseq::{Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer, Wait};
    use rtseq_trace::model::Lost;
    use std::process::Command;

    struct Dwells(Seq<Wait>);
    impl Sequence<()> for Dwells {
        async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
            for _ in 0..4 {
                cx.step(&mut self.0).await?;
            }
            Ok(())
        }
    }
    let seq: Sequencer<(), 2, 1> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwells(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_until_idle(Duration::from_millis(50)).unwrap();
    let lost = u64::from(sim.lost());
    assert!(lost > 0, "nothing lost: make the scenario busier");
    let dir = common::scratch("sim-lost");
    let path = dir.join("lost.jsonl");
    sim.save_trace(&path).unwrap();

    let run = tracefile::read(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(run.lost, Lost::Count(lost));
    // What survived is there.
    assert!(!run.transitions.is_empty());
    let warning = format!("{lost} records were lost: the trace is incomplete");
    let warning = if lost == 1 {
        String::from("1 record was lost: the trace is incomplete")
    } else {
        warning
    };

    let out = Command::new(env!("CARGO_BIN_EXE_rtseq-trace"))
        .arg("render")
        .arg(&path)
        .args(["--html", "t.html", "--vcd", "t.vcd", "--perfetto", "t.json"])
        .args(["--trace", "t.jsonl"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr.lines().next(),
        Some(format!("rtseq-trace: warning: {warning}").as_str()),
        "{stderr}"
    );
    let file = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    assert!(file("t.html").contains(&format!("<b>Warning:</b> {warning}.")));
    assert!(file("t.vcd").contains(&format!("$comment {warning} $end")));
    let doc: serde_json::Value = serde_json::from_str(&file("t.json")).unwrap();
    assert_eq!(doc["metadata"]["lost_records"], lost);
    assert_eq!(doc["metadata"]["warning"], warning.as_str());
    assert_eq!(tracefile::read(&file("t.jsonl")).unwrap().lost, run.lost);
}
