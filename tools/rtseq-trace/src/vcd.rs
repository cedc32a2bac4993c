//! VCD for GTKWave and Surfer (timescale 1 ns; times are µs × 1000).
//!
//! ```text
//! rtseq.sequences.<name>   string  the running state (`Running`)
//! rtseq.state_codes.<name> 3 bits  the same as a code: Idle 0, Running 1, Paused 2,
//!                                  Aborting 3, Aborted 4, Terminated 5, Restarting 6
//! rtseq.safety.level       string  the safety level (spaces as `_`)
//! rtseq.events.<kind>_<name> 1 bit a 1 µs pulse per event (monitor, request, fault, input)
//! rtseq.signals.<name>_<unit> real  position, velocity, current
//! ```
//! Names are sanitized (characters other than letters, digits and `_` become `_`) and made
//! unique within their scope: a name an earlier variable has gets `_<n>` appended, `n` the
//! sequence's index in the header (a pulse's, a signal's number in order of appearance),
//! then `_2`, `_3`, ... while still taken: sequences `a b` and `a_b` (indexes 0, 1) are
//! `a_b` and `a_b_1` ([`sequence_names`]). A run with lost records (see [`Run::lost`]) gets a `$comment` saying so after `$timescale`.
//!
//! The records decide the states: a sequence starts (`$dumpvars`) in the `from` state of
//! its first record, and a record whose `from` is not the previous record's `to` (records
//! were lost between) gets a `$comment` at its time: `records lost: 'child' was Paused at
//! 20 us; its next record, at 30 us, starts from Aborted`, and the state code is unknown
//! (`bxxx`) between the two records (the state's name stays the earlier one's). A signal
//! has no value before its first sample.
//!
//! One value per variable per time, none lost: a variable's k-th value within one µs is
//! written k ns after the µs (the `$dumpvars` value is the first of µs 0), so a state that
//! lasts 0 µs (an abort and a restart in one tick: `Aborting`, `Aborted`, `Running` at
//! 5000 µs) is seen for 1 ns each, and every value's µs is exact (more than 1000 values of
//! one variable in one µs would share its last ns, the latest winning). A run whose times
//! do not fit in a `u64` of ns (past 584 years) is written at a timescale of 1 µs instead,
//! with the last value of each variable in each µs. An event at the last representable time
//! (`u64::MAX` µs) rises and has no fall: there is no later time to put it at. The end of
//! the run is the last time, written once.

use std::collections::{HashMap, HashSet};
use std::io::Write;

use crate::model::{EventKind, Run, State};

/// A VCD-safe name.
pub fn sanitize(s: &str) -> String {
    let out: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if out.is_empty() {
        String::from("_")
    } else {
        out
    }
}

/// The names of one scope's variables, made unique: names that differ only in characters
/// [`sanitize`] replaces (`a b`, `a_b`; `Achse Ä`, `Achse Ö`) would be one variable in a
/// viewer.
#[derive(Default)]
struct Unique(HashSet<String>);

impl Unique {
    /// `name` sanitized; when an earlier variable of the scope has that name, with
    /// `_<suffix>` (the sequence's index, ...) appended, and `_2`, `_3`, ... after that
    /// while it is still taken.
    fn name(&mut self, name: &str, suffix: usize) -> String {
        let base = sanitize(name);
        let mut candidate = base.clone();
        let mut n = 1;
        while self.0.contains(&candidate) {
            candidate = if n == 1 {
                format!("{base}_{suffix}")
            } else {
                format!("{base}_{suffix}_{n}")
            };
            n += 1;
        }
        self.0.insert(candidate.clone());
        candidate
    }
}

/// The VCD names of the sequences (in `rtseq.sequences` and `rtseq.state_codes`), by
/// index into [`Run::sequences`]: sanitized, and a sequence whose name an earlier one has
/// gets `_<index>` appended (`a b`, `a_b` are `a_b`, `a_b_1`).
pub fn sequence_names(run: &Run) -> Vec<String> {
    let mut names = Unique::default();
    run.sequences
        .iter()
        .enumerate()
        .map(|(i, s)| names.name(&s.name, i))
        .collect()
}

/// The n-th short identifier code (`!`, `"`, ..., `!!`, ...).
fn code(mut n: usize) -> String {
    let mut s = String::new();
    loop {
        s.push(char::from(b'!' + (n % 94) as u8));
        n /= 94;
        if n == 0 {
            return s;
        }
        n -= 1;
    }
}

enum Val {
    Str(String),
    Bits(u8, usize),
    /// `x` in every one of this many bits.
    Unknown(usize),
    Bit(bool),
    Real(f64),
    /// A `$comment` among the changes (its id is unused).
    Comment(String),
}

impl Val {
    fn line(&self, id: &str) -> String {
        match self {
            // `$end` closes a comment: the text has no `$`.
            Val::Comment(c) => format!("$comment {} $end", c.replace('$', "S")),
            Val::Str(s) => format!("s{} {id}", sanitize(s)),
            Val::Bits(v, w) => format!("b{:0w$b} {id}", v, w = *w),
            Val::Unknown(w) => format!("b{} {id}", "x".repeat(*w)),
            Val::Bit(b) => format!("{}{id}", u8::from(*b)),
            Val::Real(r) => format!("r{r} {id}"),
        }
    }
}

/// The events drawn as pulses: kind and name, in order of first appearance.
pub fn pulse_names(run: &Run) -> Vec<(EventKind, String)> {
    let requests = run.requests();
    let mut names: Vec<(EventKind, String)> = Vec::new();
    let mut seen: HashSet<(EventKind, &str)> = HashSet::new();
    for e in run.events.iter().chain(requests.iter()) {
        if matches!(e.kind, EventKind::Move | EventKind::Note) {
            continue;
        }
        if seen.insert((e.kind, e.name.as_str())) {
            names.push((e.kind, e.name.clone()));
        }
    }
    names
}

/// Writes `run` as VCD.
pub fn write(run: &Run, out: &mut impl Write) -> std::io::Result<()> {
    let mut n = 0;
    let mut next = || {
        n += 1;
        code(n - 1)
    };
    writeln!(
        out,
        "$version rtseq-trace {} $end",
        env!("CARGO_PKG_VERSION")
    )?;
    let per_us = ns_per_us(run);
    writeln!(
        out,
        "$timescale 1 {} $end",
        if per_us == 1 { "us" } else { "ns" }
    )?;
    if let Some(w) = run.lost.warning() {
        // `$end` closes a comment: the warning has no `$`.
        writeln!(out, "$comment {} $end", w.replace('$', "S"))?;
    }
    writeln!(out, "$scope module rtseq $end")?;
    // Changes: (time, order within the time, id, value). Pulse ends (order 0) come before
    // the values of the same time.
    let mut changes: Vec<(u64, u8, String, Val)> = Vec::new();
    let mut init: Vec<(String, Val)> = Vec::new();

    // Before its first record a sequence was in that record's `from` state.
    let by_seq = run.by_sequence();
    let first_state = |i: usize| {
        by_seq
            .get(i)
            .and_then(|trs| trs.first())
            .and_then(|&k| run.transitions.get(k))
            .map_or(State::Idle, |t| t.from)
    };
    let seq_names = sequence_names(run);
    writeln!(out, "$scope module sequences $end")?;
    let seq_ids: Vec<String> = run.sequences.iter().map(|_| next()).collect();
    for (i, (name, id)) in seq_names.iter().zip(&seq_ids).enumerate() {
        writeln!(out, "$var string 1 {id} {name} $end")?;
        init.push((id.clone(), Val::Str(first_state(i).name().into())));
    }
    writeln!(out, "$upscope $end")?;
    writeln!(out, "$scope module state_codes $end")?;
    let code_ids: Vec<String> = run.sequences.iter().map(|_| next()).collect();
    for (i, (name, id)) in seq_names.iter().zip(&code_ids).enumerate() {
        writeln!(out, "$var wire 3 {id} {name} $end")?;
        init.push((id.clone(), Val::Bits(first_state(i).code(), 3)));
    }
    writeln!(out, "$upscope $end")?;
    // A record whose `from` is not the previous record's `to`: records were lost between.
    // The state code is unknown from right after the earlier record to the later one (the
    // state's name stays the earlier record's, and a comment says what is known).
    for ((s, trs), code) in run.sequences.iter().zip(&by_seq).zip(&code_ids) {
        for sp in run.state_spans_in(trs) {
            if let Some(to) = sp.gap {
                changes.push((sp.start_us, 2, code.clone(), Val::Unknown(3)));
                let text = format!(
                    "records lost: '{}' was {} at {} us; its next record, at {} us, starts from {to}",
                    s.name, sp.state, sp.start_us, sp.end_us
                );
                changes.push((sp.end_us, 1, String::new(), Val::Comment(text)));
            }
        }
    }
    for t in &run.transitions {
        if let (Some(s), Some(c)) = (seq_ids.get(t.seq), code_ids.get(t.seq)) {
            changes.push((t.time_us, 1, s.clone(), Val::Str(t.to.name().into())));
            changes.push((t.time_us, 1, c.clone(), Val::Bits(t.to.code(), 3)));
        }
    }

    writeln!(out, "$scope module safety $end")?;
    let level = next();
    writeln!(out, "$var string 1 {level} level $end")?;
    writeln!(out, "$upscope $end")?;
    init.push((level.clone(), Val::Str("unknown".into())));
    for l in &run.levels {
        changes.push((l.time_us, 1, level.clone(), Val::Str(l.level.clone())));
    }

    writeln!(out, "$scope module events $end")?;
    let requests = run.requests();
    let events = || run.events.iter().chain(requests.iter());
    // In order of first appearance (`pulse_names`).
    let mut pulse_ids: HashMap<(EventKind, &str), String> = HashMap::new();
    let mut pulse_names = Unique::default();
    for e in events() {
        if matches!(e.kind, EventKind::Move | EventKind::Note)
            || pulse_ids.contains_key(&(e.kind, e.name.as_str()))
        {
            continue;
        }
        let id = next();
        // Suffixed with the pulse's number (in order of first appearance) when taken.
        let name = pulse_names.name(&format!("{}_{}", e.kind.name(), e.name), pulse_ids.len());
        writeln!(out, "$var wire 1 {id} {name} $end")?;
        init.push((id.clone(), Val::Bit(false)));
        pulse_ids.insert((e.kind, e.name.as_str()), id);
    }
    writeln!(out, "$upscope $end")?;
    for e in events() {
        if let Some(id) = pulse_ids.get(&(e.kind, e.name.as_str())) {
            changes.push((e.time_us, 1, id.clone(), Val::Bit(true)));
            // A pulse at `u64::MAX` has no later time to fall at: it stays high.
            if let Some(fall) = e.time_us.checked_add(1) {
                changes.push((fall, 0, id.clone(), Val::Bit(false)));
            }
        }
    }

    writeln!(out, "$scope module signals $end")?;
    let mut signal_names = Unique::default();
    for (k, s) in run.signals.iter().enumerate() {
        let id = next();
        // Suffixed with the signal's index when taken.
        let name = if s.unit.is_empty() {
            signal_names.name(&s.name, k)
        } else {
            signal_names.name(&format!("{}_{}", s.name, s.unit), k)
        };
        // No value before its first sample (none in `$dumpvars`: unknown until then).
        writeln!(out, "$var real 64 {id} {name} $end")?;
        for (t, v) in &s.samples {
            changes.push((*t, 1, id.clone(), Val::Real(*v)));
        }
    }
    writeln!(out, "$upscope $end")?;
    writeln!(out, "$upscope $end")?;
    writeln!(out, "$enddefinitions $end")?;

    let timed = timed(changes, &mut init, per_us);
    writeln!(out, "#0")?;
    writeln!(out, "$dumpvars")?;
    for (id, v) in &init {
        writeln!(out, "{}", v.line(id))?;
    }
    writeln!(out, "$end")?;
    let mut now = Some(0);
    for (t, id, v) in &timed {
        if now != Some(*t) {
            writeln!(out, "#{t}")?;
            now = Some(*t);
        }
        writeln!(out, "{}", v.line(id))?;
    }
    // The end, once (unless a change is there already).
    let end = run.end_us.saturating_mul(per_us);
    if now.is_none_or(|n| end > n) {
        writeln!(out, "#{end}")?;
    }
    Ok(())
}

/// The VCD time units per µs: 1000 (a timescale of 1 ns) when every time of the run, its
/// pulses' falls and their sub-µs steps fit in a `u64` of ns (runs of up to 584 years),
/// else 1 (1 µs).
fn ns_per_us(run: &Run) -> u64 {
    let last = run
        .transitions
        .iter()
        .map(|t| t.time_us)
        .chain(run.events.iter().map(|e| e.time_us))
        .chain(run.levels.iter().map(|l| l.time_us))
        .chain(
            run.signals
                .iter()
                .flat_map(|s| s.samples.iter().map(|p| p.0)),
        )
        .fold(run.end_us, u64::max);
    let fits = last
        .checked_add(1)
        .and_then(|t| t.checked_mul(1000))
        .and_then(|t| t.checked_add(999))
        .is_some();
    if fits {
        1000
    } else {
        1
    }
}

/// The changes (µs, order within the µs, id, value) at VCD times, in time order, one value
/// per variable per time: the k-th value a variable takes in one µs is put k units after
/// the µs (k ns at a timescale of 1 ns), so a state that lasts 0 µs (an abort and a restart
/// in one tick) is seen for 1 ns and the time of every value is exact to the µs. The
/// initial values (`$dumpvars`, `init`) are the first values of µs 0. Where there is no
/// room (a timescale of 1 µs, or more than 1000 values of one variable in one µs), a later
/// value replaces the one at the same time (a change at 0 µs, the initial value).
fn timed(
    mut changes: Vec<(u64, u8, String, Val)>,
    init: &mut [(String, Val)],
    per_us: u64,
) -> Vec<(u64, String, Val)> {
    /// Where a variable's last value is.
    #[derive(Clone, Copy)]
    enum At {
        Init(usize),
        Out(usize),
    }
    // Stable: the changes of one time keep the order of the record.
    changes.sort_by_key(|c| (c.0, c.1));
    let mut out: Vec<(u64, String, Val)> = Vec::with_capacity(changes.len());
    // Per variable: the µs of its last value, how many values it took in that µs, and
    // where that value is.
    let mut last: HashMap<String, (u64, u64, At)> = init
        .iter()
        .enumerate()
        .map(|(i, (id, _))| (id.clone(), (0, 1, At::Init(i))))
        .collect();
    for (t, _, id, v) in changes {
        let base = t.saturating_mul(per_us);
        if matches!(v, Val::Comment(_)) {
            out.push((base, id, v));
            continue;
        }
        let (k, before) = match last.get(&id) {
            Some(&(u, n, at)) if u == t => (n, Some(at)),
            Some(&(_, _, at)) => (0, Some(at)),
            None => (0, None),
        };
        let time = base + k.min(per_us - 1);
        let taken = match before {
            Some(At::Init(i)) if time == 0 => init.get_mut(i).map(|slot| &mut slot.1),
            Some(At::Out(i)) => out
                .get_mut(i)
                .filter(|o| o.0 == time)
                .map(|slot| &mut slot.2),
            _ => None,
        };
        if let Some(value) = taken {
            *value = v;
            continue;
        }
        last.insert(id.clone(), (t, k + 1, At::Out(out.len())));
        out.push((time, id, v));
    }
    // Stable: the values of one time keep their order.
    out.sort_by_key(|c| c.0);
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn codes() {
        assert_eq!(super::code(0), "!");
        assert_eq!(super::code(93), "~");
        assert_eq!(super::code(94), "!!");
        assert_eq!(super::sanitize("power on"), "power_on");
    }

    /// Names that sanitize to one are made unique: the first keeps it, later ones get the
    /// suffix, then `_2`, ... while still taken.
    #[test]
    fn unique_names() {
        let mut names = super::Unique::default();
        let got: Vec<String> = [
            ("a b", 0),
            ("a_b", 1),
            ("Achse Ä", 2),
            ("Achse Ö", 3),
            ("a_b_1", 4),
            ("a b", 5),
            ("a.b", 1),
        ]
        .iter()
        .map(|&(n, i)| names.name(n, i))
        .collect();
        assert_eq!(
            got,
            [
                "a_b",
                "a_b_1",
                "Achse__",
                "Achse___3",
                "a_b_1_4",
                "a_b_5",
                "a_b_1_2"
            ]
        );
    }
}
