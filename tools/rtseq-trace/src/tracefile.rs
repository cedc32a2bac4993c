//! The trace file format (JSON lines, `docs/trace-format.md`): written by
//! `rtseq::sim::Sim::save_trace` and by `rtseq-trace render --trace`.

use std::collections::HashMap;
use std::io::Write;

use serde_json::{json, Map, Value};

use crate::model::{Event, EventKind, LevelChange, Lost, Run, Sequence, State, Transition};

/// The `format` field of the header.
pub const FORMAT: &str = "rtseq-trace";
/// The version this tool reads and writes.
pub const VERSION: u64 = 1;

/// The lines of `text` that are not blank, numbered from 1 (blank ones counted), without a
/// UTF-8 byte order mark at the start. The first is the header: [`is_trace`] and [`read`]
/// agree on where it is.
fn records(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.strip_prefix('\u{feff}')
        .unwrap_or(text)
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(n, l)| (n + 1, l))
}

/// Whether `text` looks like a trace file: its first line that is not blank is the header
/// (a UTF-8 byte order mark before it is skipped, as [`read`] does).
pub fn is_trace(text: &str) -> bool {
    let first = records(text).next().map_or("", |(_, l)| l);
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

/// Reads the header's `lost`: absent, a count, or `true` (lost, count unknown).
fn lost_of(head: &Value, line: usize) -> Result<Lost, String> {
    match head.get("lost") {
        None | Some(Value::Null) => Ok(Lost::None),
        Some(Value::Bool(true)) => Ok(Lost::Uncounted),
        Some(v) => v.as_u64().map(Lost::count).ok_or_else(|| {
            format!("line {line}: `lost` is neither an unsigned integer nor `true`")
        }),
    }
}

/// Reads a trace file (blank lines and a UTF-8 byte order mark at the start are skipped).
/// Malformed input is an `Err` naming the line: a header that is not
/// one, a sequence or monitor id given twice, a record of an unknown sequence, a field of
/// the wrong type.
pub fn read(text: &str) -> Result<Run, String> {
    let mut lines = records(text);
    let (h, head) = lines.next().ok_or("empty trace file")?;
    let head: Value = serde_json::from_str(head).map_err(|e| format!("line {h}: {e}"))?;
    if head.get("format").and_then(Value::as_str) != Some(FORMAT) {
        return Err(format!("line {h}: not an {FORMAT} header"));
    }
    let version = u64_of(&head, "version", h)?;
    if version != VERSION {
        return Err(format!(
            "line {h}: version {version}; this tool reads version {VERSION}"
        ));
    }
    let mut run = Run::default();
    // Sequences and monitors by id (ids need not be dense).
    let sequences = field(&head, "sequences", h)?
        .as_array()
        .ok_or_else(|| format!("line {h}: `sequences` is not a list"))?;
    let mut seq_index: HashMap<u64, usize> = HashMap::with_capacity(sequences.len());
    for s in sequences {
        let id = u64_of(s, "id", h)?;
        if seq_index.insert(id, run.sequences.len()).is_some() {
            return Err(format!("line {h}: sequence id {id} twice"));
        }
        run.sequences.push(Sequence {
            name: str_of(s, "name", h)?.to_string(),
            caller: None,
        });
    }
    let index_of = |id: u64| seq_index.get(&id).copied();
    for (s, seq) in sequences.iter().zip(run.sequences.iter_mut()) {
        seq.caller = s.get("caller").and_then(Value::as_u64).and_then(index_of);
    }
    let mut monitors: HashMap<u64, String> = HashMap::new();
    if let Some(ms) = head.get("monitors").and_then(Value::as_array) {
        for m in ms {
            let id = u64_of(m, "id", h)?;
            let name = str_of(m, "name", h)?.to_string();
            if monitors.insert(id, name).is_some() {
                return Err(format!("line {h}: monitor id {id} twice"));
            }
        }
    }
    let monitor_name = |id: u64| {
        monitors
            .get(&id)
            .map_or_else(|| format!("#{id}"), String::clone)
    };
    if let Some(sigs) = head.get("signals").and_then(Value::as_array) {
        for s in sigs {
            let unit = s.get("unit").and_then(Value::as_str).unwrap_or("");
            run.signal_mut(str_of(s, "name", h)?, unit);
        }
    }
    run.end_us = head.get("end").and_then(Value::as_u64).unwrap_or(0);
    run.lost = lost_of(&head, h)?;

    for (n, line) in lines {
        let v: Value = serde_json::from_str(line).map_err(|e| format!("line {n}: {e}"))?;
        let t = u64_of(&v, "t", n)?;
        if let Some(kind) = v.get("event").and_then(Value::as_str) {
            if kind == "request" && v.get("by").is_some() {
                run.core_requests = true;
            }
            let kind = EventKind::parse(kind).unwrap_or(EventKind::Note);
            let name = match (kind, v.get("monitor").and_then(Value::as_u64)) {
                (EventKind::Monitor, Some(m)) => monitor_name(m),
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
            let value = sample_of(field(&v, "value", n)?)
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
/// A sample as JSON: a number, or `"NaN"`, `"inf"`, `"-inf"` (JSON has no such numbers; a
/// log shows them where a sensor failed).
fn sample_json(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else if v.is_nan() {
        json!("NaN")
    } else if v > 0.0 {
        json!("inf")
    } else {
        json!("-inf")
    }
}

/// What [`sample_json`] wrote.
fn sample_of(v: &Value) -> Option<f64> {
    match v {
        Value::String(s) => match s.as_str() {
            "NaN" => Some(f64::NAN),
            "inf" => Some(f64::INFINITY),
            "-inf" => Some(f64::NEG_INFINITY),
            _ => None,
        },
        _ => v.as_f64(),
    }
}

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
    let mut head = json!({
        "format": FORMAT, "version": VERSION, "time_unit": "us", "end": run.end_us,
        "sequences": sequences, "monitors": [], "signals": signals,
    });
    match run.lost {
        Lost::None => {}
        Lost::Count(n) => head["lost"] = json!(n),
        Lost::Uncounted => head["lost"] = json!(true),
    }
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
            writeln!(
                out,
                "{}",
                json!({"t": t, "signal": s.name, "value": sample_json(*v)})
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(fields: &str, sequences: &str, monitors: &str) -> String {
        format!(
            r#"{{"format":"rtseq-trace","version":1,"time_unit":"us","end":5000{fields},"sequences":[{sequences}],"monitors":[{monitors}]}}"#
        )
    }

    const TWO: &str =
        r#"{"id":0,"name":"homing","caller":null},{"id":3,"name":"moves","caller":0}"#;

    #[test]
    fn the_header_lost_count_is_kept() {
        let lost = |fields: &str| read(&head(fields, TWO, "")).map(|r| r.lost);
        assert_eq!(lost(""), Ok(Lost::None));
        assert_eq!(lost(r#","lost":0"#), Ok(Lost::None));
        assert_eq!(lost(r#","lost":null"#), Ok(Lost::None));
        assert_eq!(lost(r#","lost":17"#), Ok(Lost::Count(17)));
        assert_eq!(lost(r#","lost":true"#), Ok(Lost::Uncounted));
        let bad = Err(String::from(
            "line 1: `lost` is neither an unsigned integer nor `true`",
        ));
        assert_eq!(lost(r#","lost":-1"#), bad);
        assert_eq!(lost(r#","lost":"many""#), bad);
        assert_eq!(lost(r#","lost":false"#), bad);
        assert_eq!(lost(r#","lost":2.5"#), bad);
    }

    #[test]
    fn the_lost_count_is_written() {
        for lost in [
            Lost::None,
            Lost::Count(1),
            Lost::Count(123),
            Lost::Uncounted,
        ] {
            let run = Run {
                lost,
                ..Run::default()
            };
            let mut out = Vec::new();
            write(&run, &mut out).unwrap();
            let text = String::from_utf8(out).unwrap();
            let header: Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
            let want = match lost {
                Lost::None => Value::Null,
                Lost::Count(n) => json!(n),
                Lost::Uncounted => json!(true),
            };
            assert_eq!(header.get("lost").cloned().unwrap_or(Value::Null), want);
            assert_eq!(read(&text).unwrap().lost, lost);
        }
    }

    #[test]
    fn duplicate_ids_in_the_header_are_errors() {
        let seqs =
            r#"{"id":0,"name":"homing","caller":null},{"id":0,"name":"moves","caller":null}"#;
        let record = r#"{"t":1000,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#;
        assert_eq!(
            read(&format!("{}\n{record}\n", head("", seqs, ""))),
            Err(String::from("line 1: sequence id 0 twice"))
        );
        let seqs = r#"{"id":4,"name":"a","caller":null},{"id":2,"name":"b","caller":null},{"id":4,"name":"c","caller":null}"#;
        assert_eq!(
            read(&head("", seqs, "")),
            Err(String::from("line 1: sequence id 4 twice"))
        );
        // The same name under two ids is two sequences.
        let seqs = r#"{"id":0,"name":"same","caller":null},{"id":1,"name":"same","caller":null}"#;
        assert_eq!(read(&head("", seqs, "")).unwrap().sequences.len(), 2);
        let mons = r#"{"id":2,"name":"jam","owner":0},{"id":5,"name":"x","owner":3},{"id":2,"name":"over-current","owner":3}"#;
        assert_eq!(
            read(&head("", TWO, mons)),
            Err(String::from("line 1: monitor id 2 twice"))
        );
        // The header's line, blank lines before it counted.
        assert_eq!(
            read(&format!("\n  \n{}\n", head("", TWO, mons))),
            Err(String::from("line 3: monitor id 2 twice"))
        );
        let mons = r#"{"id":2,"name":"jam","owner":0},{"id":5,"name":"jam","owner":3}"#;
        assert!(read(&head("", TWO, mons)).is_ok());
    }

    #[test]
    fn ids_need_not_be_dense() {
        let mons = r#"{"id":9,"name":"jam","owner":3}"#;
        let text = format!(
            "{}\n{}\n{}\n",
            head("", TWO, mons),
            r#"{"t":1000,"seq":3,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":2000,"seq":3,"from":"Running","to":"Aborting","cause":"monitor","monitor":9}"#
        );
        let run = read(&text).unwrap();
        assert_eq!(run.sequences[1].name, "moves");
        assert_eq!(run.sequences[1].caller, Some(0));
        assert_eq!(run.transitions[0].seq, 1);
        assert_eq!(run.transitions[1].cause, "monitor jam");
    }

    /// A header after blank lines or a UTF-8 byte order mark is a trace file's header for
    /// the detection as for the reader (the detection looked at the first line only, so
    /// such a file was read as a log and refused as neither).
    #[test]
    fn the_header_after_blank_lines_or_a_bom() {
        let record = r#"{"t":1000,"seq":3,"from":"Idle","to":"Running","cause":"start"}"#;
        let plain = format!("{}\n{record}\n", head("", TWO, ""));
        for text in [
            plain.clone(),
            format!("\n  \n{plain}"),
            format!("\u{feff}{plain}"),
            format!("\u{feff}\n{plain}"),
            plain.replace('\n', "\r\n"),
        ] {
            assert!(is_trace(&text), "{text:?}");
            let run = crate::read_run(&text, crate::log::Hints::default()).unwrap();
            assert_eq!(run.transitions.len(), 1, "{text:?}");
            assert_eq!(run.sequences[1].name, "moves");
        }
        // Line numbers count the blank lines (and the line of the mark).
        let bad = format!("\u{feff}\n{}\n{{\"t\":-1}}\n", head("", TWO, ""));
        assert_eq!(
            read(&bad),
            Err(String::from("line 3: `t` is not an unsigned integer"))
        );
        assert!(!is_trace("\n\nhello\n"));
        assert!(!is_trace(""));
    }

    /// Times up to `u64::MAX` are times (the sequencer's `Instant` is a `u64` of µs).
    #[test]
    fn the_last_time_is_read() {
        let text = format!(
            "{}\n{{\"t\":{},\"event\":\"fault\",\"name\":\"x\"}}\n",
            head("", TWO, ""),
            u64::MAX
        );
        let run = read(&text).unwrap();
        assert_eq!(run.events[0].time_us, u64::MAX);
        assert_eq!(run.end_us, u64::MAX);
        let text = text.replace(&u64::MAX.to_string(), "18446744073709551616");
        assert_eq!(
            read(&text),
            Err(String::from("line 2: `t` is not an unsigned integer"))
        );
    }
}
