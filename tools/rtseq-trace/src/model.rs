//! A run as the tool sees it: sequences, transitions, events, safety levels and signals,
//! whatever the source (a simulator trace file or a firmware's decoded defmt log).

use std::fmt;

/// The seven running states of a sequence (rtseq's `RunningState`).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash, PartialOrd, Ord)]
pub enum State {
    Idle,
    Running,
    Paused,
    Aborting,
    Aborted,
    Terminated,
    Restarting,
}

impl State {
    /// Every state, in the order of their VCD codes (0..=6).
    pub const ALL: [State; 7] = [
        State::Idle,
        State::Running,
        State::Paused,
        State::Aborting,
        State::Aborted,
        State::Terminated,
        State::Restarting,
    ];

    /// The name rtseq gives the state (`Running`).
    pub fn name(self) -> &'static str {
        match self {
            State::Idle => "Idle",
            State::Running => "Running",
            State::Paused => "Paused",
            State::Aborting => "Aborting",
            State::Aborted => "Aborted",
            State::Terminated => "Terminated",
            State::Restarting => "Restarting",
        }
    }

    /// Parses a state name, in any case.
    pub fn parse(s: &str) -> Option<State> {
        State::ALL
            .into_iter()
            .find(|st| st.name().eq_ignore_ascii_case(s.trim()))
    }

    /// The VCD code of the state (its position in [`State::ALL`]).
    pub fn code(self) -> u8 {
        match self {
            State::Idle => 0,
            State::Running => 1,
            State::Paused => 2,
            State::Aborting => 3,
            State::Aborted => 4,
            State::Terminated => 5,
            State::Restarting => 6,
        }
    }

    /// A run is under way (it has started and not ended).
    pub fn is_active(self) -> bool {
        matches!(
            self,
            State::Running | State::Paused | State::Aborting | State::Restarting
        )
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One registered (or seen) sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sequence {
    pub name: String,
    /// Who started it (the last run's caller); `None` for a main sequence or when unknown.
    pub caller: Option<usize>,
}

/// One state change: exactly what `rtseq::Transition` holds, with the cause as text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Transition {
    pub time_us: u64,
    /// Index into [`Run::sequences`].
    pub seq: usize,
    pub from: State,
    pub to: State,
    /// The cause as the demo prints it: `start`, `completed`, `monitor following error`,
    /// `timeout of homing`, `restart`, ...
    pub cause: String,
}

/// What kind of thing happened besides a state change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// A monitor fired (`name` = the monitor).
    Monitor,
    /// A pause, resume or abort request (from a transition's cause, or a pause button).
    Request,
    /// An injected fault.
    Fault,
    /// A critical input of the safety system tripped (`name` = the input).
    Input,
    /// An exception sequence could not run (`name` = the exception sequence).
    Exception,
    /// A run failed: its action returned an error (`name` = the sequence).
    Failure,
    /// A move finished (demo).
    Move,
    /// Anything else worth showing in the list of latest events (reactions, ...).
    Note,
}

impl EventKind {
    /// Lower-case name (CSS class, VCD scope, JSON value).
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Monitor => "monitor",
            EventKind::Request => "request",
            EventKind::Fault => "fault",
            EventKind::Input => "input",
            EventKind::Exception => "exception_not_run",
            EventKind::Failure => "failed",
            EventKind::Move => "move",
            EventKind::Note => "note",
        }
    }

    /// Parses [`EventKind::name`].
    pub fn parse(s: &str) -> Option<EventKind> {
        [
            EventKind::Monitor,
            EventKind::Request,
            EventKind::Fault,
            EventKind::Input,
            EventKind::Exception,
            EventKind::Failure,
            EventKind::Move,
            EventKind::Note,
        ]
        .into_iter()
        .find(|k| k.name() == s)
    }
}

/// An event at a point in time.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub time_us: u64,
    pub kind: EventKind,
    /// Short name: the monitor, the fault, the input, the request.
    pub name: String,
    /// The details (the whole log message).
    pub text: String,
}

/// The safety level from `time_us` on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LevelChange {
    pub time_us: u64,
    pub level: String,
}

/// A sampled signal (position, velocity, current, ...).
#[derive(Clone, Debug, PartialEq)]
pub struct Signal {
    pub name: String,
    pub unit: String,
    pub samples: Vec<(u64, f64)>,
}

/// Records the source says are missing: the sequencer's trace ring overwrote them before
/// they were read (`"lost"` in a trace file's header), or a firmware reported losing some.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lost {
    /// None lost (or the source does not say).
    #[default]
    None,
    /// This many records were lost (more than 0).
    Count(u64),
    /// Records were lost; the source does not say how many (the demo firmware's failed check
    /// `no trace record or event lost`).
    Uncounted,
}

impl Lost {
    /// `n` records lost (`Lost::None` for 0).
    pub fn count(n: u64) -> Lost {
        if n == 0 {
            Lost::None
        } else {
            Lost::Count(n)
        }
    }

    /// Whether any record is missing.
    pub fn any(self) -> bool {
        self != Lost::None
    }

    /// The warning every output shows when records are missing (`None` when none are):
    /// `3 records were lost: the trace is incomplete`.
    pub fn warning(self) -> Option<String> {
        match self {
            Lost::None => None,
            Lost::Count(1) => Some(String::from("1 record was lost: the trace is incomplete")),
            Lost::Count(n) => Some(format!("{n} records were lost: the trace is incomplete")),
            Lost::Uncounted => Some(String::from(
                "records were lost (the source does not say how many): the trace is incomplete",
            )),
        }
    }
}

/// One whole run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Run {
    pub sequences: Vec<Sequence>,
    pub transitions: Vec<Transition>,
    pub events: Vec<Event>,
    pub levels: Vec<LevelChange>,
    pub signals: Vec<Signal>,
    /// The last time seen (or the simulator's end time).
    pub end_us: u64,
    /// The source recorded the sequencer's requests as events (a trace of rtseq with
    /// events, or a log that prints them): none is guessed from transitions.
    pub core_requests: bool,
    /// Records missing from the source (the ring overwrote them before they were read).
    /// Where in time they were is unknown: every output warns about the whole run.
    pub lost: Lost,
}

/// A span of one state of one sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StateSpan {
    pub start_us: u64,
    pub end_us: u64,
    pub state: State,
    /// The cause of the transition into the state (`None` for the state before the
    /// sequence's first record).
    pub cause: Option<String>,
    /// The index into [`Run::transitions`] of the transition into the state (`None` for
    /// the state before the sequence's first record).
    pub transition: Option<usize>,
    /// Records were lost inside the span: the record that ends it starts from this state,
    /// not from [`StateSpan::state`]. The sequence was in `state` at the span's start and in
    /// this one at its end; what happened between is not known.
    pub gap: Option<State>,
}

/// One run of one sequence: from leaving an inactive state to entering one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunSpan {
    pub start_us: u64,
    pub end_us: u64,
    /// The cause of the start (`start`, `monitor ...` for an exception sequence);
    /// `(before the record)` for a run under way at the sequence's first record (it starts
    /// at 0), `(records lost)` for one whose start was lost.
    pub start_cause: String,
    /// `completed`, `failed`, `aborted (monitor following error)`, `skipped (...)`,
    /// `still running` when the run had not ended at the end of the record, or
    /// [`LOST_END`] when the next record starts another run (the end was lost).
    pub outcome: String,
    /// Indexes into [`Run::transitions`] of the transitions of this run, in order.
    pub transitions: Vec<usize>,
}

impl Run {
    /// The index of the sequence called `name`, added when new.
    pub fn sequence_index(&mut self, name: &str) -> usize {
        if let Some(i) = self.sequences.iter().position(|s| s.name == name) {
            return i;
        }
        self.sequences.push(Sequence {
            name: name.to_string(),
            caller: None,
        });
        self.sequences.len() - 1
    }

    /// The signal called `name`, added when new.
    pub fn signal_mut(&mut self, name: &str, unit: &str) -> &mut Signal {
        let i = match self.signals.iter().position(|s| s.name == name) {
            Some(i) => i,
            None => {
                self.signals.push(Signal {
                    name: name.to_string(),
                    unit: unit.to_string(),
                    samples: Vec::new(),
                });
                self.signals.len() - 1
            }
        };
        &mut self.signals[i]
    }

    /// Sorts everything by time (stable: records of one instant keep their order) and
    /// makes `end_us` cover every record. Decoded logs can have lines slightly out of order
    /// (tasks of different priorities log into one stream).
    pub fn finish(&mut self) {
        self.transitions.sort_by_key(|t| t.time_us);
        self.events.sort_by_key(|e| e.time_us);
        self.levels.sort_by_key(|l| l.time_us);
        for s in &mut self.signals {
            s.samples.sort_by_key(|p| p.0);
        }
        let last = self
            .transitions
            .iter()
            .map(|t| t.time_us)
            .chain(self.events.iter().map(|e| e.time_us))
            .chain(self.levels.iter().map(|l| l.time_us))
            .chain(
                self.signals
                    .iter()
                    .flat_map(|s| s.samples.iter().map(|p| p.0)),
            )
            .max()
            .unwrap_or(0);
        self.end_us = self.end_us.max(last);
    }

    /// The sequences in tree order (roots in order of first appearance, each followed by
    /// the sequences it called), with their depth. A sequence whose callers lead nowhere
    /// (an unknown id) or into a cycle is a root. Linear in the sequences and transitions,
    /// without recursion (a header can chain any number of callers).
    pub fn tree_order(&self) -> Vec<(usize, usize)> {
        let n = self.sequences.len();
        // First appearance in the trace, then registration order.
        let mut first = vec![u64::MAX; n];
        for t in &self.transitions {
            if let Some(f) = first.get_mut(t.seq) {
                *f = (*f).min(t.time_us);
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&i| (first[i], i));
        let caller = |i: usize| self.sequences.get(i).and_then(|s| s.caller);
        // Whether the callers of a sequence end at a sequence without a caller (else they
        // reach an unknown id or a cycle).
        #[derive(Clone, Copy, PartialEq)]
        enum Chain {
            Unknown,
            Walking,
            Ends,
            Broken,
        }
        let mut chain = vec![Chain::Unknown; n];
        let mut path = Vec::new();
        for i in 0..n {
            let mut at = i;
            let result = loop {
                match chain[at] {
                    Chain::Ends => break Chain::Ends,
                    Chain::Broken | Chain::Walking => break Chain::Broken,
                    Chain::Unknown => {}
                }
                chain[at] = Chain::Walking;
                path.push(at);
                match caller(at) {
                    None => break Chain::Ends,
                    Some(c) if c >= n => break Chain::Broken,
                    Some(c) => at = c,
                }
            };
            for k in path.drain(..) {
                chain[k] = result;
            }
        }
        let is_root = |i: usize| caller(i).is_none() || chain[i] == Chain::Broken;
        // The sequences each one called, in `order`.
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &c in &order {
            if let Some(p) = caller(c).filter(|&p| p < n) {
                children[p].push(c);
            }
        }
        let mut out = Vec::with_capacity(n);
        let mut seen = vec![false; n];
        let mut stack: Vec<(usize, usize)> = Vec::new();
        // Roots first, then whatever a cycle left out.
        let starts = order
            .iter()
            .filter(|&&i| is_root(i))
            .chain(order.iter())
            .copied();
        for start in starts {
            stack.push((start, 0));
            while let Some((i, depth)) = stack.pop() {
                if seen[i] {
                    continue;
                }
                seen[i] = true;
                out.push((i, depth));
                // Pushed in reverse: visited in order.
                for &c in children[i].iter().rev() {
                    if !seen[c] {
                        stack.push((c, depth + 1));
                    }
                }
            }
        }
        out
    }

    /// The transitions of every sequence, grouped in one pass: per sequence (index into
    /// [`Run::sequences`]), the indexes into [`Run::transitions`] of its transitions, in
    /// order. For [`Run::state_spans_in`] and [`Run::run_spans_in`].
    pub fn by_sequence(&self) -> Vec<Vec<usize>> {
        let mut out = vec![Vec::new(); self.sequences.len()];
        for (k, t) in self.transitions.iter().enumerate() {
            if let Some(v) = out.get_mut(t.seq) {
                v.push(k);
            }
        }
        out
    }

    fn indexes_of(&self, seq: usize) -> Vec<usize> {
        self.transitions
            .iter()
            .enumerate()
            .filter(|(_, t)| t.seq == seq)
            .map(|(k, _)| k)
            .collect()
    }

    /// The state spans of sequence `seq`, from 0 to `end_us`. (One pass over all
    /// transitions: for every sequence, use [`Run::by_sequence`] and
    /// [`Run::state_spans_in`].)
    pub fn state_spans(&self, seq: usize) -> Vec<StateSpan> {
        self.state_spans_in(&self.indexes_of(seq))
    }

    /// The state spans of the sequence whose transitions are `transitions` (indexes into
    /// [`Run::transitions`], in order: an entry of [`Run::by_sequence`]).
    ///
    /// The records decide: before its first record the sequence was in that record's
    /// `from` state (drawn from 0, the trace's start: a trace that begins in the middle of a
    /// run has no record of how it began; `Idle` for a sequence without records), and a
    /// record whose `from` is not the previous record's `to` ends a span with a
    /// [`StateSpan::gap`].
    pub fn state_spans_in(&self, transitions: &[usize]) -> Vec<StateSpan> {
        let mut trs = transitions
            .iter()
            .filter_map(|&k| self.transitions.get(k).map(|t| (k, t)))
            .peekable();
        let mut spans = Vec::with_capacity(transitions.len() + 1);
        let mut cur = StateSpan {
            start_us: 0,
            end_us: 0,
            state: trs.peek().map_or(State::Idle, |(_, t)| t.from),
            cause: None,
            transition: None,
            gap: None,
        };
        for (k, t) in trs {
            let next = StateSpan {
                start_us: t.time_us,
                end_us: 0,
                state: t.to,
                cause: Some(t.cause.clone()),
                transition: Some(k),
                gap: None,
            };
            let mut done = std::mem::replace(&mut cur, next);
            done.end_us = t.time_us;
            done.gap = (t.from != done.state).then_some(t.from);
            spans.push(done);
        }
        cur.end_us = self.end_us.max(cur.start_us);
        spans.push(cur);
        spans
    }

    /// The runs of sequence `seq`: a run starts when the sequence leaves an inactive state
    /// (`Idle`, `Terminated`, `Aborted`) and ends when it enters one. (One pass over all
    /// transitions: for every sequence, use [`Run::by_sequence`] and [`Run::run_spans_in`].)
    pub fn run_spans(&self, seq: usize) -> Vec<RunSpan> {
        self.run_spans_in(&self.indexes_of(seq))
    }

    /// The runs of the sequence whose transitions are `transitions` (indexes into
    /// [`Run::transitions`], in order: an entry of [`Run::by_sequence`]).
    pub fn run_spans_in(&self, transitions: &[usize]) -> Vec<RunSpan> {
        let mut runs = Vec::new();
        let mut open: Option<RunSpan> = None;
        // The previous record's `to` (`None` before the first record).
        let mut before: Option<State> = None;
        for (k, t) in transitions
            .iter()
            .filter_map(|&k| self.transitions.get(k).map(|t| (k, t)))
        {
            let gap = before.is_some_and(|b| b != t.from);
            before = Some(t.to);
            if !t.from.is_active() {
                if let Some(mut r) = open.take() {
                    // Its end is among the records lost.
                    r.end_us = t.time_us;
                    r.outcome = String::from(LOST_END);
                    runs.push(r);
                }
                open = Some(RunSpan {
                    start_us: t.time_us,
                    end_us: t.time_us,
                    start_cause: t.cause.clone(),
                    outcome: String::new(),
                    transitions: Vec::new(),
                });
            }
            let r = open.get_or_insert_with(|| RunSpan {
                // A run that began before the sequence's first record (from the trace's
                // start, as its state span), or whose start was lost.
                start_us: if gap { t.time_us } else { 0 },
                end_us: t.time_us,
                start_cause: String::from(if gap {
                    "(records lost)"
                } else {
                    "(before the record)"
                }),
                outcome: String::new(),
                transitions: Vec::new(),
            });
            r.transitions.push(k);
            if !t.to.is_active() {
                r.end_us = t.time_us;
                r.outcome = outcome_text(t);
                if let Some(r) = open.take() {
                    runs.push(r);
                }
            }
        }
        if let Some(mut r) = open {
            r.end_us = self.end_us.max(r.start_us);
            r.outcome = String::from("still running");
            runs.push(r);
        }
        runs
    }

    /// Requests (pause, resume, abort, abort all) guessed from the transitions' causes, one
    /// per distinct time and cause, for a source that does not record them (see
    /// [`Run::core_requests`]).
    pub fn requests(&self) -> Vec<Event> {
        let mut out: Vec<Event> = Vec::new();
        if self.core_requests {
            return out;
        }
        let mut last: Option<(u64, String)> = None;
        for t in &self.transitions {
            if matches!(t.cause.as_str(), "pause" | "resume" | "abort" | "abort all") {
                let key = (t.time_us, t.cause.clone());
                if last.as_ref() != Some(&key) {
                    let name = self.sequences.get(t.seq).map_or("?", |s| s.name.as_str());
                    out.push(Event {
                        time_us: t.time_us,
                        kind: EventKind::Request,
                        name: t.cause.clone(),
                        text: format!("request {} ({} {} -> {})", t.cause, name, t.from, t.to),
                    });
                }
                last = Some(key);
            }
        }
        out.sort_by_key(|e| e.time_us);
        out
    }

    /// The safety level at `t` (`None` before the first level is known).
    pub fn level_at(&self, t: u64) -> Option<&str> {
        self.levels
            .iter()
            .take_while(|l| l.time_us <= t)
            .last()
            .map(|l| l.level.as_str())
    }
}

/// The outcome of a run whose end is among the lost records (the next record starts a run).
pub const LOST_END: &str = "unknown (records lost)";

/// What a run that ended with `t` returns.
fn outcome_text(t: &Transition) -> String {
    match (t.from.is_active(), t.to) {
        (false, _) => format!("skipped ({})", t.cause),
        (true, State::Terminated) if t.cause == "completed" => String::from("completed"),
        (true, State::Terminated) if t.cause == "failed" => String::from("failed"),
        (true, State::Aborted) => format!("aborted ({})", t.cause),
        (true, to) => format!("{} ({})", to.name().to_lowercase(), t.cause),
    }
}

/// Formats µs as seconds with 6 decimals (`2.514011`).
pub fn secs(us: u64) -> String {
    format!("{}.{:06}", us / 1_000_000, us % 1_000_000)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ended(from: State, to: State, cause: &str) -> Transition {
        Transition {
            time_us: 0,
            seq: 0,
            from,
            to,
            cause: cause.to_string(),
        }
    }

    #[test]
    fn the_lost_warning() {
        assert_eq!(Lost::count(0), Lost::None);
        assert_eq!(Lost::None.warning(), None);
        assert!(!Lost::None.any());
        assert_eq!(
            Lost::count(1).warning().as_deref(),
            Some("1 record was lost: the trace is incomplete")
        );
        assert_eq!(
            Lost::count(82).warning().as_deref(),
            Some("82 records were lost: the trace is incomplete")
        );
        assert!(Lost::Uncounted.any());
    }

    fn seqs(callers: &[Option<usize>]) -> Run {
        Run {
            sequences: callers
                .iter()
                .enumerate()
                .map(|(i, &caller)| Sequence {
                    name: format!("s{i}"),
                    caller,
                })
                .collect(),
            ..Run::default()
        }
    }

    #[test]
    fn tree_order_of_callers_cycles_and_unknown_ids() {
        // 0 calls 1 and 3, 1 calls 2; 4 calls 5 calls 4 (a cycle); 6 calls itself; 7's
        // caller is unknown; 8's caller is on the cycle.
        let run = seqs(&[
            None,
            Some(0),
            Some(1),
            Some(0),
            Some(5),
            Some(4),
            Some(6),
            Some(99),
            Some(4),
        ]);
        assert_eq!(
            run.tree_order(),
            [
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 1),
                (4, 0),
                (5, 1),
                (8, 1),
                (6, 0),
                (7, 0)
            ]
        );
        // First appearance orders the roots and the children.
        let mut run = seqs(&[None, Some(0), Some(0), None]);
        for (t, seq) in [(10, 3), (20, 2), (30, 0), (40, 1)] {
            run.transitions.push(Transition {
                time_us: t,
                seq,
                from: State::Idle,
                to: State::Running,
                cause: String::from("start"),
            });
        }
        assert_eq!(run.tree_order(), [(3, 0), (0, 0), (2, 1), (1, 1)]);
    }

    /// A chain of callers as long as a header can make does not recurse.
    #[test]
    fn tree_order_of_a_long_chain() {
        let n: usize = 200_000;
        let callers: Vec<Option<usize>> = (0..n).map(|i| i.checked_sub(1)).collect();
        let order = seqs(&callers).tree_order();
        assert_eq!(order.len(), n);
        assert!(order
            .iter()
            .enumerate()
            .all(|(k, &(i, d))| i == k && d == k));
        // Closed into a cycle: one root, the first.
        let mut callers = callers;
        callers[0] = Some(n - 1);
        let order = seqs(&callers).tree_order();
        assert_eq!(order.len(), n);
        assert!(order
            .iter()
            .enumerate()
            .all(|(k, &(i, d))| i == k && d == k));
    }

    /// Appends transitions given as (time µs, sequence, from, to, cause).
    fn push(run: &mut Run, steps: &[(u64, usize, State, State, &str)]) {
        for &(t, seq, from, to, cause) in steps {
            run.transitions.push(Transition {
                time_us: t,
                seq,
                from,
                to,
                cause: cause.to_string(),
            });
        }
    }

    /// Grouped once or filtered per sequence, the spans are the same.
    #[test]
    fn spans_from_the_grouped_transitions() {
        let mut run = seqs(&[None, Some(0)]);
        let steps = [
            (0, 0, State::Idle, State::Running, "start"),
            (5, 1, State::Idle, State::Running, "start"),
            (7, 1, State::Running, State::Paused, "pause"),
            (9, 0, State::Running, State::Aborting, "abort"),
            (9, 1, State::Paused, State::Aborted, "abort"),
            (12, 0, State::Aborting, State::Aborted, "abort"),
            (20, 1, State::Aborted, State::Running, "start"),
        ];
        push(&mut run, &steps);
        run.finish();
        let by = run.by_sequence();
        assert_eq!(by, [vec![0, 3, 5], vec![1, 2, 4, 6]]);
        for (i, trs) in by.iter().enumerate() {
            assert_eq!(run.state_spans_in(trs), run.state_spans(i));
            assert_eq!(run.run_spans_in(trs), run.run_spans(i));
        }
        let runs = run.run_spans(1);
        let got: Vec<_> = runs
            .iter()
            .map(|r| (r.start_us, r.end_us, r.outcome.as_str()))
            .collect();
        assert_eq!(got, [(5, 9, "aborted (abort)"), (20, 20, "still running")]);
        assert_eq!(runs[0].transitions, [1, 2, 4]);
        // Indexes out of range are skipped.
        assert_eq!(run.run_spans_in(&[99]), []);
        assert_eq!(run.state_spans_in(&[99]).len(), 1);
    }

    /// The records decide: a sequence whose first record starts from `Paused` was paused
    /// from the start, and a `from` that is not the previous `to` marks a gap (records
    /// lost) instead of continuing the earlier state.
    #[test]
    fn spans_follow_the_records_from_state() {
        let mut run = seqs(&[None, Some(0)]);
        let steps = [
            (10, 0, State::Paused, State::Running, "resume"),
            (10, 1, State::Idle, State::Running, "start"),
            (20, 1, State::Running, State::Paused, "pause"),
            // Lost: the pause ended, the run was aborted.
            (30, 1, State::Aborted, State::Running, "start"),
            (40, 1, State::Running, State::Terminated, "completed"),
            // Lost: another run started.
            (50, 1, State::Running, State::Terminated, "completed"),
            (60, 0, State::Running, State::Terminated, "completed"),
        ];
        push(&mut run, &steps);
        run.end_us = 100;
        run.finish();
        let spans = |seq| -> Vec<_> {
            run.state_spans(seq)
                .into_iter()
                .map(|s| (s.start_us, s.end_us, s.state, s.gap, s.transition))
                .collect()
        };
        use State::*;
        assert_eq!(
            spans(0),
            [
                (0, 10, Paused, None, None),
                (10, 60, Running, None, Some(0)),
                (60, 100, Terminated, None, Some(6)),
            ]
        );
        assert_eq!(
            spans(1),
            [
                (0, 10, Idle, None, None),
                (10, 20, Running, None, Some(1)),
                (20, 30, Paused, Some(Aborted), Some(2)),
                (30, 40, Running, None, Some(3)),
                (40, 50, Terminated, Some(Running), Some(4)),
                (50, 100, Terminated, None, Some(5)),
            ]
        );
        let runs = |seq| -> Vec<_> {
            run.run_spans(seq)
                .into_iter()
                .map(|r| {
                    (
                        r.start_us,
                        r.end_us,
                        r.start_cause,
                        r.outcome,
                        r.transitions,
                    )
                })
                .collect()
        };
        let owned = |s: &str| s.to_string();
        assert_eq!(
            runs(0),
            [(
                0,
                60,
                owned("(before the record)"),
                owned("completed"),
                vec![0, 6]
            )]
        );
        assert_eq!(
            runs(1),
            [
                (10, 30, owned("start"), owned(LOST_END), vec![1, 2]),
                (30, 40, owned("start"), owned("completed"), vec![3, 4]),
                (50, 50, owned("(records lost)"), owned("completed"), vec![5]),
            ]
        );
        // No records: idle throughout.
        let idle = seqs(&[None]);
        assert_eq!(idle.state_spans(0).len(), 1);
        assert_eq!(idle.state_spans(0)[0].state, State::Idle);
    }

    #[test]
    fn a_run_is_named_by_how_it_ended() {
        let t = |from, to, cause| outcome_text(&ended(from, to, cause));
        assert_eq!(
            t(State::Running, State::Terminated, "completed"),
            "completed"
        );
        assert_eq!(t(State::Running, State::Terminated, "failed"), "failed");
        assert_eq!(
            t(State::Aborting, State::Aborted, "monitor jam"),
            "aborted (monitor jam)"
        );
        assert_eq!(
            t(State::Idle, State::Terminated, "precondition false"),
            "skipped (precondition false)"
        );
    }
}
