//! Chrome trace-event JSON, opened by Perfetto (ui.perfetto.dev) and chrome://tracing.
//!
//! One process `rtseq`; one thread (track) per sequence, in tree order, with a complete
//! event (`"ph":"X"`) per run named after the sequence and its outcome in `args`, and
//! nested complete events for the states inside a run other than `Running` (`Paused`,
//! `Aborting`, `Restarting`); a `safety level` track with a span per level; an `events`
//! track with instant events (monitor firings, requests, faults, tripped inputs, moves);
//! counters for the signals. Times in µs, as integers.
//!
//! The records decide the states (see [`Run::state_spans_in`]): a sequence whose first
//! record starts from `Paused` was paused from the trace's start, and where a record's
//! `from` is not the previous record's `to` (records lost), a `records lost` span (category
//! `gap`) covers the time between the two records, with the states at its ends in `args`;
//! a run whose end was lost has the outcome `unknown (records lost)`.
//!
//! A run with lost records (see [`Run::lost`]) says so twice: in the document's `metadata`
//! (`"lost_records"`: the count, or `"unknown"`; `"warning"`: the text) and as the
//! process's label (`process_labels`), which the Perfetto UI shows next to `rtseq`.

use std::io::Write;

use serde_json::{json, Value};

use crate::model::{secs, Lost, Run, State};

/// The thread id of sequence `i` (ids start at 1).
pub fn tid_of(seq: usize) -> usize {
    seq + 1
}

/// The thread id of the safety-level track.
pub const LEVEL_TID: usize = 100_000;
/// The thread id of the events track.
pub const EVENTS_TID: usize = 100_001;

/// The trace events of `run`.
pub fn events(run: &Run) -> Vec<Value> {
    let mut ev =
        vec![json!({"ph": "M", "pid": 1, "name": "process_name", "args": {"name": "rtseq"}})];
    if let Some(w) = run.lost.warning() {
        ev.push(json!({"ph": "M", "pid": 1, "name": "process_labels", "args": {"labels": format!("WARNING: {w}")}}));
    }
    let by_seq = run.by_sequence();
    for (row, (i, depth)) in run.tree_order().into_iter().enumerate() {
        let Some(s) = run.sequences.get(i) else {
            continue;
        };
        let tid = tid_of(i);
        let label = format!("{}{}", "  ".repeat(depth), s.name);
        ev.push(json!({"ph": "M", "pid": 1, "tid": tid, "name": "thread_name", "args": {"name": label}}));
        ev.push(json!({"ph": "M", "pid": 1, "tid": tid, "name": "thread_sort_index", "args": {"sort_index": row}}));
        let trs = by_seq.get(i).map_or(&[][..], Vec::as_slice);
        for r in run.run_spans_in(trs) {
            let steps: Vec<String> = r
                .transitions
                .iter()
                .filter_map(|&k| run.transitions.get(k))
                .map(|t| format!("{} s {} -> {} ({})", secs(t.time_us), t.from, t.to, t.cause))
                .collect();
            ev.push(json!({
                "ph": "X", "pid": 1, "tid": tid, "name": s.name, "cat": "run",
                "ts": r.start_us, "dur": r.end_us.saturating_sub(r.start_us),
                "args": {"outcome": r.outcome, "started by": r.start_cause, "transitions": steps},
            }));
        }
        for sp in run.state_spans_in(trs) {
            if matches!(
                sp.state,
                State::Paused | State::Aborting | State::Restarting
            ) {
                ev.push(json!({
                    "ph": "X", "pid": 1, "tid": tid, "name": sp.state.name(), "cat": "state",
                    "ts": sp.start_us, "dur": sp.end_us.saturating_sub(sp.start_us),
                    "args": {"cause": sp.cause},
                }));
            }
            if let Some(to) = sp.gap {
                ev.push(json!({
                    "ph": "X", "pid": 1, "tid": tid, "name": "records lost", "cat": "gap",
                    "ts": sp.start_us, "dur": sp.end_us.saturating_sub(sp.start_us),
                    "args": {
                        "state at the start": sp.state.name(),
                        "state at the end": to.name(),
                        "note": "records were lost here: what happened between is not known",
                    },
                }));
            }
        }
    }
    let rows = run.sequences.len();
    ev.push(json!({"ph": "M", "pid": 1, "tid": LEVEL_TID, "name": "thread_name", "args": {"name": "safety level"}}));
    ev.push(json!({"ph": "M", "pid": 1, "tid": LEVEL_TID, "name": "thread_sort_index", "args": {"sort_index": rows}}));
    for (k, l) in run.levels.iter().enumerate() {
        let end = run
            .levels
            .get(k + 1)
            .map_or(run.end_us, |n| n.time_us)
            .max(l.time_us);
        ev.push(json!({
            "ph": "X", "pid": 1, "tid": LEVEL_TID, "name": l.level, "cat": "level",
            "ts": l.time_us, "dur": end - l.time_us,
        }));
    }
    ev.push(json!({"ph": "M", "pid": 1, "tid": EVENTS_TID, "name": "thread_name", "args": {"name": "events"}}));
    ev.push(json!({"ph": "M", "pid": 1, "tid": EVENTS_TID, "name": "thread_sort_index", "args": {"sort_index": rows + 1}}));
    let requests = run.requests();
    for e in run.events.iter().chain(requests.iter()) {
        ev.push(json!({
            "ph": "i", "s": "t", "pid": 1, "tid": EVENTS_TID, "cat": e.kind.name(),
            "name": format!("{} {}", e.kind.name(), e.name), "ts": e.time_us,
            "args": {"text": e.text},
        }));
    }
    for s in &run.signals {
        let name = if s.unit.is_empty() {
            s.name.clone()
        } else {
            format!("{} [{}]", s.name, s.unit)
        };
        for (t, v) in &s.samples {
            if v.is_finite() {
                ev.push(json!({"ph": "C", "pid": 1, "name": name, "ts": t, "args": {"value": v}}));
            } else {
                // A counter holds numbers: a NaN or infinite sample (a failed sensor) is an
                // instant on the events track instead.
                ev.push(json!({
                    "ph": "i", "s": "t", "pid": 1, "tid": EVENTS_TID, "cat": "signal",
                    "name": format!("{name} = {v}"), "ts": t,
                }));
            }
        }
    }
    ev
}

/// The document's `metadata`: what the run's source says about it as a whole (lost records).
pub fn metadata(run: &Run) -> Value {
    let mut m = json!({"source": "rtseq-trace"});
    if let Some(w) = run.lost.warning() {
        m["lost_records"] = match run.lost {
            Lost::Count(n) => json!(n),
            _ => json!("unknown"),
        };
        m["warning"] = json!(w);
    }
    m
}

/// Writes `run` as trace-event JSON.
pub fn write(run: &Run, out: &mut impl Write) -> std::io::Result<()> {
    let doc =
        json!({"traceEvents": events(run), "displayTimeUnit": "ms", "metadata": metadata(run)});
    serde_json::to_writer(&mut *out, &doc)?;
    writeln!(out)
}
