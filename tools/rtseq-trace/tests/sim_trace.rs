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
