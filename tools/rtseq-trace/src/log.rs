//! The decoded defmt log of a firmware (the motor demo's line formats), line by line.
//!
//! A line is `[TIME] [LEVEL] MESSAGE`: `TIME` in seconds with up to 6 decimals (the
//! firmware's virtual time, as `qemu-run` and `defmt-print` show it), or `NNNms` / `NNNus`
//! (a firmware's own timestamp format, as `probe-rs run` shows it), optionally in brackets;
//! `LEVEL` one of `TRACE DEBUG INFO WARN ERROR` (optionally in brackets). Lines without a time get the previous line's. Location lines (`└─ ...`) and
//! messages the tool does not know are skipped. The messages read (see
//! `boards/qemu-f405/src/bin/demo.rs`):
//!
//! ```text
//! seq       NAME FROM -> TO (CAUSE)
//! monitor   'NAME' fired (N): EFFECT
//! timeout   of 'NAME' ran out: BEHAVIOUR
//! exception 'NAME' of 'OWNER' not run: WHY
//! request   pause|resume|abort 'NAME' by WHO  |  request   abort all by WHO
//! failed    'NAME': WHY
//! safety    level A -> B  |  safety    level A (entry level)  |  safety    critical input: NAME
//! axis      x 15.140 mm  v -21.2 mm/s  i -0.11 A  | ...
//! FAULT     NAME injected: WHAT
//! BUTTON    pause button pressed (pause|resume)
//! move      ...  |  reaction  ...
//! tree      CHILD < CALLER          (a caller hint; see `Hints`)
//! check     FAIL  no trace record or event lost
//! ```
//!
//! The firmware does not count the records its trace ring lost in the log; its final check
//! fails when it lost any (trace records or its own events). That line sets
//! [`Run::lost`](crate::model::Run::lost) to [`Lost::Uncounted`]: every output then says
//! that the trace is incomplete.

use std::collections::HashMap;

use crate::model::{Event, EventKind, LevelChange, Lost, Run, State, Transition};

/// The first `'quoted'` name in `text`.
fn quoted_name(text: &str) -> Option<&str> {
    let (_, rest) = text.split_once('\'')?;
    rest.split_once('\'').map(|(name, _)| name)
}

/// What one line was.
#[derive(Clone, Debug, PartialEq)]
pub enum Line {
    /// A transition (index into `Run::transitions`).
    Transition(usize),
    /// An event (index into `Run::events`).
    Event(usize),
    /// A safety-level change.
    Level,
    /// Signal samples.
    Signals,
    /// A caller hint.
    Hint,
    /// Nothing the tool reads.
    Other,
}

/// Callers named in advance (`CHILD < CALLER`, one a line; `#` comments): they win over
/// the guess. The log carries no caller, so without hints the parser guesses (see
/// [`LogParser`]).
#[derive(Clone, Debug, Default)]
pub struct Hints {
    callers: HashMap<String, String>,
}

impl Hints {
    /// Parses hint lines; returns the line number of a malformed one.
    pub fn parse(text: &str) -> Result<Hints, String> {
        let mut h = Hints::default();
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            if !h.add_line(line) {
                return Err(format!(
                    "line {}: expected `CHILD < CALLER`, found `{line}`",
                    n + 1
                ));
            }
        }
        Ok(h)
    }

    fn add_line(&mut self, line: &str) -> bool {
        match line.split_once('<') {
            Some((child, caller)) if !child.trim().is_empty() && !caller.trim().is_empty() => {
                self.callers
                    .insert(child.trim().to_string(), caller.trim().to_string());
                true
            }
            _ => false,
        }
    }

    /// The caller named for `child`.
    pub fn caller(&self, child: &str) -> Option<&str> {
        self.callers.get(child).map(String::as_str)
    }
}

/// Reads a log into a [`Run`], line by line (the live view feeds it as lines arrive).
///
/// Callers: a hint wins. Otherwise, for a transition with cause `start`, the caller is
/// guessed from the transition just before it: if that one started (or restarted) a
/// sequence P, P is the caller (its first child); if it ended a sequence Y, Y's caller is
/// (the next child of the same caller). Exact for blocking starts; a sequence started
/// non-blocking just before its caller starts a blocking one is taken for the caller: give
/// a hint for those. Exception sequences (cause `monitor ...`) get no caller.
#[derive(Debug, Default)]
pub struct LogParser {
    pub run: Run,
    hints: Hints,
    time_us: u64,
    /// The last stamp as the line gave it, and what the wraps of a 32-bit counter seen so
    /// far add to it.
    last_stamp: Option<u64>,
    wrapped_us: u64,
}

impl LogParser {
    /// A parser with caller hints.
    pub fn new(hints: Hints) -> LogParser {
        LogParser {
            run: Run::default(),
            hints,
            time_us: 0,
            last_stamp: None,
            wrapped_us: 0,
        }
    }

    /// Reads a whole log.
    pub fn parse_all(text: &str, hints: Hints) -> Run {
        let mut p = LogParser::new(hints);
        for line in text.lines() {
            p.line(line);
        }
        p.finish()
    }

    /// The run, sorted by time.
    pub fn finish(mut self) -> Run {
        self.run.finish();
        self.run
    }

    /// The time of the last line read.
    pub fn now_us(&self) -> u64 {
        self.time_us
    }

    /// The time of a stamp, in µs since the first line's counter was 0. A firmware that
    /// stamps its lines with a 32-bit counter (`{=u32}ms`, the NUCLEO board's; `{=u32}us`)
    /// wraps it: a stamp more than half the counter's range before the last one is the
    /// counter's next turn. A smaller step back (a reset) is taken as it is.
    fn unwrap(&mut self, stamp: Stamp) -> u64 {
        if let (Some(range), Some(last)) = (stamp.counter_range_us, self.last_stamp) {
            if last > stamp.us && last - stamp.us > range / 2 {
                self.wrapped_us = self.wrapped_us.saturating_add(range);
            }
        }
        self.last_stamp = Some(stamp.us);
        stamp.us.saturating_add(self.wrapped_us)
    }

    /// Reads one line.
    pub fn line(&mut self, line: &str) -> Line {
        let (time, msg) = split_line(line);
        let Some(msg) = msg else {
            return Line::Other;
        };
        if let Some(stamp) = time {
            let t = self.unwrap(stamp);
            self.time_us = t;
            self.run.end_us = self.run.end_us.max(t);
        }
        let t = self.time_us;
        let (word, rest) = match msg.split_once(char::is_whitespace) {
            Some((w, r)) => (w, r.trim()),
            None => (msg, ""),
        };
        match word {
            "seq" => self.seq_line(t, rest),
            "monitor" => self.monitor_line(t, rest, msg),
            "safety" => self.safety_line(t, rest, msg),
            "axis" => self.axis_line(t, rest),
            "FAULT" => {
                let name = rest.split(" injected").next().unwrap_or(rest);
                self.event(t, EventKind::Fault, name, msg)
            }
            "BUTTON" => {
                let name = if rest.contains("(resume)") {
                    "resume button"
                } else {
                    "pause button"
                };
                self.event(t, EventKind::Request, name, msg)
            }
            "move" => self.event(
                t,
                EventKind::Move,
                rest.split(':').next().unwrap_or(""),
                msg,
            ),
            "reaction" => self.event(t, EventKind::Note, "reaction", msg),
            // The sequencer's own events (from its trace).
            "timeout" => {
                let name = quoted_name(rest).unwrap_or(rest);
                self.event(t, EventKind::Monitor, &format!("timeout of {name}"), msg)
            }
            "exception" => self.event(
                t,
                EventKind::Exception,
                quoted_name(rest).unwrap_or(rest),
                msg,
            ),
            "failed" => self.event(
                t,
                EventKind::Failure,
                quoted_name(rest).unwrap_or(rest),
                msg,
            ),
            "request" => {
                self.run.core_requests = true;
                let name = rest.split(" by ").next().unwrap_or(rest).replace('\'', "");
                self.event(t, EventKind::Request, &name, msg)
            }
            "check" => match rest.strip_prefix("FAIL") {
                Some(what) if what.contains("lost") => {
                    if !self.run.lost.any() {
                        self.run.lost = Lost::Uncounted;
                    }
                    self.event(t, EventKind::Note, "records lost", msg)
                }
                _ => Line::Other,
            },
            "tree" => {
                if self.hints.add_line(rest) {
                    Line::Hint
                } else {
                    Line::Other
                }
            }
            _ => Line::Other,
        }
    }

    fn event(&mut self, t: u64, kind: EventKind, name: &str, text: &str) -> Line {
        self.run.events.push(Event {
            time_us: t,
            kind,
            name: name.trim().to_string(),
            text: text.trim().to_string(),
        });
        Line::Event(self.run.events.len() - 1)
    }

    /// `NAME FROM -> TO (CAUSE)`; names may contain spaces, states do not.
    fn seq_line(&mut self, t: u64, rest: &str) -> Line {
        let Some((left, right)) = rest.split_once(" -> ") else {
            return Line::Other;
        };
        let Some((name, from)) = left.trim().rsplit_once(char::is_whitespace) else {
            return Line::Other;
        };
        let (to, cause) = match right.split_once('(') {
            Some((to, cause)) => (to, cause.trim().strip_suffix(')').unwrap_or(cause)),
            None => (right, ""),
        };
        let (Some(from), Some(to)) = (State::parse(from), State::parse(to)) else {
            return Line::Other;
        };
        let name = name.trim();
        let seq = self.run.sequence_index(name);
        let cause = cause.trim().to_string();
        if let Some(c) = self.hints.caller(name).map(str::to_string) {
            let c = self.run.sequence_index(&c);
            if let Some(s) = self.run.sequences.get_mut(seq) {
                s.caller = (c != seq).then_some(c);
            }
        } else if cause == "start" {
            self.guess_caller(seq);
        }
        self.run.transitions.push(Transition {
            time_us: t,
            seq,
            from,
            to,
            cause,
        });
        Line::Transition(self.run.transitions.len() - 1)
    }

    fn guess_caller(&mut self, seq: usize) {
        let caller = self.run.transitions.last().and_then(|p| {
            if p.seq == seq {
                None
            } else if p.to.is_active() {
                Some(p.seq)
            } else {
                self.run.sequences.get(p.seq).and_then(|s| s.caller)
            }
        });
        if let (Some(c), Some(s)) = (caller, self.run.sequences.get_mut(seq)) {
            if c != seq {
                s.caller = Some(c);
            }
        }
    }

    /// `'NAME' fired (N): EFFECT`
    fn monitor_line(&mut self, t: u64, rest: &str, msg: &str) -> Line {
        let name = rest
            .strip_prefix('\'')
            .and_then(|r| r.split_once('\''))
            .map_or(rest, |(n, _)| n);
        self.event(t, EventKind::Monitor, name, msg)
    }

    fn safety_line(&mut self, t: u64, rest: &str, msg: &str) -> Line {
        if let Some(l) = rest.strip_prefix("level ") {
            let level = match l.split_once(" -> ") {
                Some((_, to)) => to,
                None => l.split(" (").next().unwrap_or(l),
            };
            self.run.levels.push(LevelChange {
                time_us: t,
                level: level.trim().to_string(),
            });
            Line::Level
        } else if let Some(input) = rest.strip_prefix("critical input:") {
            self.event(t, EventKind::Input, input, msg)
        } else {
            Line::Other
        }
    }

    /// `x 15.140 mm  v -21.2 mm/s  i -0.11 A  | ...`
    fn axis_line(&mut self, t: u64, rest: &str) -> Line {
        let values = rest.split('|').next().unwrap_or("");
        let mut words = values.split_whitespace();
        let mut any = false;
        while let Some(w) = words.next() {
            let (name, unit) = match w {
                "x" => ("position", "mm"),
                "v" => ("velocity", "mm/s"),
                "i" => ("current", "A"),
                _ => continue,
            };
            if let Some(v) = words.next().and_then(|v| v.parse::<f64>().ok()) {
                self.run.signal_mut(name, unit).samples.push((t, v));
                any = true;
            }
        }
        if any {
            Line::Signals
        } else {
            Line::Other
        }
    }
}

/// A line's time stamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
    /// As µs.
    pub us: u64,
    /// The range of the 32-bit counter a stamp in ms or µs may come from, as µs (2^32 ms or
    /// 2^32 µs); `None` for seconds (the emulator's 64-bit clock).
    pub counter_range_us: Option<u64>,
}

/// Splits a decoded line into its time stamp and its message (`None`: not a log message).
pub fn split_line(line: &str) -> (Option<Stamp>, Option<&str>) {
    let mut rest = line.trim();
    if rest.is_empty() || rest.starts_with("└─") || rest.starts_with("(HOST)") {
        return (None, None);
    }
    let mut time = None;
    if let Some((w, r)) = first_word(rest) {
        let token = w.trim_start_matches('[').trim_end_matches(']');
        if let Some(us) = parse_time(token) {
            let counter_range_us = if token.ends_with("ms") {
                Some(1000 << 32)
            } else if token.ends_with("us") {
                Some(1 << 32)
            } else {
                None
            };
            time = Some(Stamp {
                us,
                counter_range_us,
            });
            rest = r;
        }
    }
    if let Some((w, r)) = first_word(rest) {
        let level = w.trim_start_matches('[').trim_end_matches(']');
        if matches!(level, "TRACE" | "DEBUG" | "INFO" | "WARN" | "ERROR") {
            // `[INFO ]`: the bracket may close after a blank.
            rest = r.strip_prefix(']').map_or(r, str::trim_start);
        }
    }
    (time, Some(rest))
}

fn first_word(s: &str) -> Option<(&str, &str)> {
    let s = s.trim_start();
    let (w, r) = s.split_once(char::is_whitespace).unwrap_or((s, ""));
    (!w.is_empty()).then_some((w, r.trim_start()))
}

/// A timestamp as µs: `2.514011` (seconds, up to 6 decimals; qemu-run, defmt-print) or
/// `2514ms` / `2514011us` (a firmware's own `defmt::timestamp!` format, as `probe-rs run`
/// shows it; the NUCLEO board's is `{=u32}ms`).
pub fn parse_time(s: &str) -> Option<u64> {
    let digits = |d: &str| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit());
    if let Some(ms) = s.strip_suffix("ms").filter(|d| digits(d)) {
        return ms.parse::<u64>().ok()?.checked_mul(1000);
    }
    if let Some(us) = s.strip_suffix("us").filter(|d| digits(d)) {
        return us.parse().ok();
    }
    parse_secs(s)
}

/// `2.514011` (seconds, up to 6 decimals) as µs.
pub fn parse_secs(s: &str) -> Option<u64> {
    let (whole, frac) = s.split_once('.')?;
    if whole.is_empty()
        || frac.is_empty()
        || frac.len() > 6
        || !whole.bytes().all(|b| b.is_ascii_digit())
        || !frac.bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let whole: u64 = whole.parse().ok()?;
    let mut f: u64 = frac.parse().ok()?;
    for _ in frac.len()..6 {
        f *= 10;
    }
    whole.checked_mul(1_000_000)?.checked_add(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines() {
        let mut p = LogParser::default();
        p.line("   0.000005 INFO  seq       main           Idle -> Running            (start)");
        p.line("   0.002012 INFO  seq       seek end stop  Idle -> Running            (start)");
        p.line("   2.512007 INFO  monitor   'following error' fired (1): safe stop, then restart");
        p.line("   2.655017 INFO  seq       moves          Running -> Aborting        (monitor following error)");
        p.line("   1.144005 INFO  safety    level power on -> homed");
        p.line("   0.001007 INFO  safety    level off (entry level)");
        p.line("   0.250007 INFO  axis      x   15.140 mm  v  -21.2 mm/s  i -0.11 A  | homing, level power on, LED on");
        p.line("└─ demo::x @ src/bin/demo.rs:12");
        p.line("[2.700000] [INFO ] safety    critical input: over-current (|i| > 6 A)");
        let r = p.finish();
        let names: Vec<_> = r.sequences.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["main", "seek end stop", "moves"]);
        assert_eq!(r.sequences[1].caller, Some(0));
        let t = &r.transitions[2];
        assert_eq!(
            (t.time_us, t.from, t.to),
            (2_655_017, State::Running, State::Aborting)
        );
        assert_eq!(t.cause, "monitor following error");
        assert_eq!(r.events[0].name, "following error");
        assert_eq!(r.events[1].kind, EventKind::Input);
        assert_eq!(r.levels[0].level, "off");
        assert_eq!(r.levels[1].level, "homed");
        assert_eq!(r.signals[1].samples, [(250_007, -21.2)]);
        assert_eq!(r.end_us, 2_700_000);
    }

    /// The sequencer's events, as the demo prints them from its trace.
    #[test]
    fn sequencer_events() {
        let mut p = LogParser::default();
        p.line("   1.000000 INFO  request   pause 'moves' by sequence feed hold");
        p.line("   1.500000 WARN  exception 'safe stop' of 'moves' not run: no lane");
        p.line("   2.000000 WARN  failed    'move': application code 3");
        p.line("   2.100000 INFO  timeout   of 'homing' ran out: abort the owner");
        p.line("   2.200000 INFO  seq       moves          Running -> Paused          (pause)");
        let r = p.finish();
        let got: Vec<(u64, EventKind, &str)> = r
            .events
            .iter()
            .map(|e| (e.time_us, e.kind, e.name.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (1_000_000, EventKind::Request, "pause moves"),
                (1_500_000, EventKind::Exception, "safe stop"),
                (2_000_000, EventKind::Failure, "move"),
                (2_100_000, EventKind::Monitor, "timeout of homing"),
            ]
        );
        // The recorded request replaces the one guessed from the transition's cause.
        assert!(r.core_requests);
        assert!(r.requests().is_empty());
    }

    /// The demo firmware's final check says whether it lost trace records (it does not
    /// print how many).
    #[test]
    fn a_failed_lost_check_marks_the_run_incomplete() {
        let mut p = LogParser::default();
        p.line("   0.000005 INFO  seq       main           Idle -> Running            (start)");
        p.line("   2.957034 INFO  check     ok    every exception sequence ran");
        assert_eq!(p.run.lost, Lost::None);
        p.line("   2.957034 INFO  check     ok    no trace record or event lost");
        assert_eq!(p.run.lost, Lost::None);
        assert_eq!(
            p.line("   2.957040 ERROR check     FAIL  no trace record or event lost"),
            Line::Event(0)
        );
        let r = p.finish();
        assert_eq!(r.lost, Lost::Uncounted);
        assert_eq!(
            (
                r.events[0].time_us,
                r.events[0].kind,
                r.events[0].name.as_str()
            ),
            (2_957_040, EventKind::Note, "records lost")
        );
        assert_eq!(
            r.lost.warning().as_deref(),
            Some("records were lost (the source does not say how many): the trace is incomplete")
        );
        // Another failed check is not a loss.
        let r = LogParser::parse_all(
            "   1.000000 ERROR check     FAIL  main has ended\n",
            Hints::default(),
        );
        assert_eq!(r.lost, Lost::None);
    }

    #[test]
    fn seconds() {
        assert_eq!(parse_secs("2.5"), Some(2_500_000));
        assert_eq!(parse_secs("0.000007"), Some(7));
        assert_eq!(parse_secs("INFO"), None);
        assert_eq!(parse_secs("1.0000001"), None);
        assert_eq!(parse_time("2514ms"), Some(2_514_000));
        assert_eq!(parse_time("17us"), Some(17));
        assert_eq!(parse_time("ms"), None);
        assert_eq!(
            split_line("2514ms INFO  seq  move  Running -> Aborted (abort)"),
            (
                Some(Stamp {
                    us: 2_514_000,
                    counter_range_us: Some(1000 << 32)
                }),
                Some("seq  move  Running -> Aborted (abort)")
            )
        );
    }

    #[test]
    fn hints() {
        let h = Hints::parse("# demo\npower on < main\n").unwrap();
        assert_eq!(h.caller("power on"), Some("main"));
        assert!(Hints::parse("nonsense").is_err());
    }
}
