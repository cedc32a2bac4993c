//! The trace file format (JSON lines, `docs/trace-format.md`): written by
//! `rtseq::sim::Sim::save_trace` and by `rtseq-trace render --trace`.

use std::io::Write;

use serde_json::{json, Map, Value};

use crate::model::{Event, EventKind, LevelChange, Run, Sequence, State, Transition};

/// The `format` field of the header.
pub const FORMAT: &str = "rtseq-trace";
/// The version this tool reads and writes.
pub const VERSION: u64 = 1;

/// Whether `text` looks like a trace file (its first line is the header).
pub fn is_trace(text: &str) -> bool {
    let first = text.lines().next().unwrap_or("");
    serde_json::from_str::<Value>(first)
        .ok()
        .and_then(|v| v.get("format").and_then(Value::as_str).map(|f| f == FORMAT))
        .unwrap_or(false)
}

fn field<'a>(v: &'a Value, key: &str, line: usize) -> Result<&'a Value, String> {
    v.get(key).ok_or_else(|| format!("line {line}: no `{key}`"))
}

fn u64_of(v: &Value, key: &str, line: usize) -> Result<u64, String> {
    field(v, key, line)?
        .as_u64()
        .ok_or_else(|| format!("line {line}: `{key}` is not an unsigned integer"))
}

fn str_of<'a>(v: &'a Value, key: &str, line: usize) -> Result<&'a str, String> {
    field(v, key, line)?
        .as_str()
        .ok_or_else(|| format!("line {line}: `{key}` is not a string"))
}

fn opt_index(v: &Value, key: &str) -> Option<usize> {
    v.get(key)
        .and_then(Value::as_u64)
        .and_then(|i| usize::try_from(i).ok())
}

/// Reads a trace file.
pub fn read(text: &str) -> Result<Run, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, head) = lines.next().ok_or("empty trace file")?;
    let head: Value = serde_json::from_str(head).map_err(|e| format!("line 1: {e}"))?;
    if head.get("format").and_then(Value::as_str) != Some(FORMAT) {
        return Err(format!("line 1: not an {FORMAT} header"));
    }
    let version = u64_of(&head, "version", 1)?;
    if version != VERSION {
        return Err(format!(
            "line 1: version {version}; this tool reads version {VERSION}"
        ));
    }
    let mut run = Run::default();
    // Sequences and monitors by id (ids need not be dense).
    let mut seq_ids = Vec::new();
    for s in field(&head, "sequences", 1)?
        .as_array()
        .ok_or("line 1: `sequences` is not a list")?
    {
        seq_ids.push(u64_of(s, "id", 1)?);
        run.sequences.push(Sequence {
            name: str_of(s, "name", 1)?.to_string(),
            caller: None,
        });
    }
    let index_of = |id: u64| seq_ids.iter().position(|&i| i == id);
    for (k, s) in field(&head, "sequences", 1)?
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
    {
        let caller = s.get("caller").and_then(Value::as_u64).and_then(index_of);
        if let Some(seq) = run.sequences.get_mut(k) {
            seq.caller = caller;
        }
    }
    let mut monitors: Vec<(u64, String)> = Vec::new();
    if let Some(ms) = head.get("monitors").and_then(Value::as_array) {
        for m in ms {
            monitors.push((u64_of(m, "id", 1)?, str_of(m, "name", 1)?.to_string()));
        }
    }
    let monitor_name = |id: u64| {
        monitors
            .iter()
            .find(|(i, _)| *i == id)
            .map_or_else(|| format!("#{id}"), |(_, n)| n.clone())
    };
    if let Some(sigs) = head.get("signals").and_then(Value::as_array) {
        for s in sigs {
            let unit = s.get("unit").and_then(Value::as_str).unwrap_or("");
            run.signal_mut(str_of(s, "name", 1)?, unit);
        }
    }
    run.end_us = head.get("end").and_then(Value::as_u64).unwrap_or(0);

    for (n, line) in lines {
        let n = n + 1;
        let v: Value = serde_json::from_str(line).map_err(|e| format!("line {n}: {e}"))?;
        let t = u64_of(&v, "t", n)?;
        if let Some(kind) = v.get("event").and_then(Value::as_str) {
            if kind == "request" && v.get("by").is_some() {
                run.core_requests = true;
            }
            let kind = EventKind::parse(kind).unwrap_or(EventKind::Note);
            let name = match (kind, opt_index(&v, "monitor")) {
                (EventKind::Monitor, Some(m)) => monitor_name(m as u64),
                _ => v
                    .get("name")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .to_string(),
            };
            let text = v
                .get("text")
                .and_then(Value::as_str)
                .map_or_else(|| format!("{} {name}", kind.name()), str::to_string);
            run.events.push(Event {
                time_us: t,
                kind,
                name,
                text,
            });
        } else if v.get("seq").is_some() {
            let id = u64_of(&v, "seq", n)?;
            let seq = index_of(id).ok_or_else(|| format!("line {n}: unknown sequence {id}"))?;
            let state = |key| {
                State::parse(str_of(&v, key, n)?)
                    .ok_or_else(|| format!("line {n}: `{key}` is not a running state"))
            };
            let named = v.get("name").and_then(Value::as_str).map(str::to_string);
            let cause = match str_of(&v, "cause", n)? {
                "monitor" => {
                    let name = match named {
                        Some(name) => name,
                        None => monitor_name(u64_of(&v, "monitor", n)?),
                    };
                    format!("monitor {name}")
                }
                "timeout" => {
                    let name = match named {
                        Some(name) => name,
                        None => {
                            let of = u64_of(&v, "of", n)?;
                            index_of(of)
                                .and_then(|i| run.sequences.get(i))
                                .map_or_else(|| format!("#{of}"), |s| s.name.clone())
                        }
                    };
                    format!("timeout of {name}")
                }
                other => other
                    .replace('_', " ")
                    .replace("pre condition", "pre-condition"),
            };
            run.transitions.push(Transition {
                time_us: t,
                seq,
                from: state("from")?,
                to: state("to")?,
                cause,
            });
        } else if let Some(level) = v.get("level").and_then(Value::as_str) {
            run.levels.push(LevelChange {
                time_us: t,
                level: level.to_string(),
            });
        } else if let Some(name) = v.get("signal").and_then(Value::as_str) {
            let value = field(&v, "value", n)?
                .as_f64()
                .ok_or_else(|| format!("line {n}: `value` is not a number"))?;
            let unit = v.get("unit").and_then(Value::as_str).unwrap_or("");
            run.signal_mut(name, unit).samples.push((t, value));
        }
        // Unknown records are skipped: later versions may add kinds.
    }
    run.finish();
    Ok(run)
}

/// The cause as a record's fields (`"cause":"monitor","monitor":0` needs monitor ids: a
/// run read from a log has names only, so such causes are written with a `name`).
fn cause_fields(cause: &str, obj: &mut Map<String, Value>) {
    let (kind, name) = match cause.split_once(' ') {
        Some(("monitor", name)) => ("monitor", Some(name)),
        Some(("timeout", name)) => ("timeout", name.strip_prefix("of ")),
        _ => ("", None),
    };
    match name {
        Some(name) => {
            obj.insert("cause".into(), json!(kind));
            obj.insert("name".into(), json!(name));
        }
        None => {
            let c = cause
                .replace("pre-condition", "pre_condition")
                .replace(' ', "_");
            obj.insert("cause".into(), json!(c));
        }
    }
}

/// Writes `run` as a trace file. Monitor and timeout causes carry the monitor's or the
/// sequence's name (`"name"`) instead of an id.
pub fn write(run: &Run, out: &mut impl Write) -> std::io::Result<()> {
    let sequences: Vec<Value> = run
        .sequences
        .iter()
        .enumerate()
        .map(|(i, s)| json!({"id": i, "name": s.name, "caller": s.caller}))
        .collect();
    let signals: Vec<Value> = run
        .signals
        .iter()
        .map(|s| json!({"name": s.name, "unit": s.unit}))
        .collect();
    let head = json!({
        "format": FORMAT, "version": VERSION, "time_unit": "us", "end": run.end_us,
        "sequences": sequences, "monitors": [], "signals": signals,
    });
    writeln!(out, "{head}")?;
    for t in &run.transitions {
        let mut o = Map::new();
        o.insert("t".into(), json!(t.time_us));
        o.insert("seq".into(), json!(t.seq));
        o.insert("from".into(), json!(t.from.name()));
        o.insert("to".into(), json!(t.to.name()));
        cause_fields(&t.cause, &mut o);
        writeln!(out, "{}", Value::Object(o))?;
    }
    for e in &run.events {
        let mut v = json!({"t": e.time_us, "event": e.kind.name(), "name": e.name, "text": e.text});
        if run.core_requests && e.kind == EventKind::Request {
            // The sequencer recorded it (the requester is in the text).
            v["by"] = json!("recorded");
        }
        writeln!(out, "{v}")?;
    }
    for l in &run.levels {
        writeln!(out, "{}", json!({"t": l.time_us, "level": l.level}))?;
    }
    for s in &run.signals {
        for (t, v) in &s.samples {
            writeln!(out, "{}", json!({"t": t, "signal": s.name, "value": v}))?;
        }
    }
    Ok(())
}
