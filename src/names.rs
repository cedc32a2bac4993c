//! Printing with the application's names: sequences, monitors and safety levels by the
//! names their tables give them, not by number, with `Display` and (feature `defmt`)
//! `defmt::Format`.
//!
//! A [`Names`] source answers names: a [`Sequencer`] its sequences', a [`Monitors`] table
//! its monitors', [`SafetyProperties`] their levels' and critical inputs', [`Failures`] the
//! application's failure codes; a tuple of up to four sources asks each in turn.
//! [`WithNames::named`] pairs a value (an id, a [`Cause`], an [`Outcome`], a [`Failure`], an
//! [`Error`], a [`Transition`], an [`Event`], a [`Record`], a [`SafetyLevel`]) with a source
//! for printing: a run's records print as the lines of the run ("4 ms monitor `jam` of
//! `cycle` fired: AbortOwner"), an error as its message with the sequence's name ("sequence
//! `safe stop` has no lane that a task polls"). The `defmt` forms read as the `Display` forms.
//!
//! ```
//! use rtseq::{Behaviour, Cause, Instant, Monitor, Monitors, RunningState, SeqConfig, Sequencer,
//!             Transition, WithNames};
//! let seq: Sequencer<(), 2> = Sequencer::new();
//! let homing = seq.register(SeqConfig::new("homing")).unwrap();
//! let mut jam = |_: &(), _: Instant| false;
//! let mut monitors: Monitors<(), 1> = Monitors::new();
//! let m = monitors.add(homing, Monitor::new("jam", &mut jam, Behaviour::AbortOwner)).unwrap();
//! let names = (&seq, &monitors);
//! let t = Transition::at_millis(12, homing, RunningState::Running, RunningState::Aborting,
//!                               Cause::Monitor(m));
//! assert_eq!(t.named(&names).to_string(), "12 ms homing: Running -> Aborting (monitor `jam`)");
//! assert_eq!(Cause::Timeout(homing).named(&names).to_string(), "timeout of `homing`");
//! assert_eq!(rtseq::Error::NoLane(homing).named(&names).to_string(),
//!            "sequence `homing` has no lane that a task polls");
//! // Without a name: the number.
//! assert_eq!(rtseq::SeqId::from_index(7).named(&names).to_string(), "#7");
//! ```

use core::fmt;

use crate::lock::Lock;
use crate::safety::{InputId, SafetyLevel, SafetyProperties};
use crate::{
    Cause, Entry, Error, Event, Failure, MonitorId, Monitors, Outcome, OwnedMonitor, Record,
    Requester, SeqId, Sequencer, Transition,
};

/// A source of names for printing with [`WithNames::named`]. Each method answers `None`
/// for what the source does not name.
///
/// The application's own source (here, the axes of its wiring list), beside the
/// sequencer's:
///
/// ```
/// use rtseq::{Cause, Names, SeqConfig, SeqId, Sequencer, WithNames};
/// struct Axes;
/// impl Names for Axes {
///     fn sequence(&self, id: SeqId) -> Option<&'static str> {
///         ["x axis", "y axis"].get(id.index()).copied()
///     }
/// }
/// let y = SeqId::from_index(1);
/// assert_eq!(Axes.sequence(y), Some("y axis"));
/// assert_eq!(Cause::Timeout(y).named(&Axes).to_string(), "timeout of `y axis`");
/// assert_eq!(SeqId::from_index(2).named(&Axes).to_string(), "#2"); // no name
/// let seq: Sequencer<(), 1> = Sequencer::new();
/// let homing = seq.register(SeqConfig::new("homing")).unwrap();
/// assert_eq!(seq.sequence(homing), Some("homing"));
/// assert_eq!(seq.monitor(rtseq::MonitorId::from_index(0)), None); // not its kind of name
/// ```
pub trait Names {
    /// The name of sequence `id`.
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        let _ = id;
        None
    }

    /// The name of monitor `id`.
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        let _ = id;
        None
    }

    /// The name of safety level `level`.
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        let _ = level;
        None
    }

    /// The name of the application's failure code `code` ([`Failure::App`]).
    fn failure(&self, code: u16) -> Option<&'static str> {
        let _ = code;
        None
    }

    /// The name of critical input `input` of the safety system.
    fn input(&self, input: InputId) -> Option<&'static str> {
        let _ = input;
        None
    }
}

impl<T: Names + ?Sized> Names for &T {
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        (**self).sequence(id)
    }
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        (**self).monitor(id)
    }
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        (**self).level(level)
    }
    fn failure(&self, code: u16) -> Option<&'static str> {
        (**self).failure(code)
    }
    fn input(&self, input: InputId) -> Option<&'static str> {
        (**self).input(input)
    }
}

impl<A: Names, B: Names> Names for (A, B) {
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        self.0.sequence(id).or_else(|| self.1.sequence(id))
    }
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        self.0.monitor(id).or_else(|| self.1.monitor(id))
    }
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        self.0.level(level).or_else(|| self.1.level(level))
    }
    fn failure(&self, code: u16) -> Option<&'static str> {
        self.0.failure(code).or_else(|| self.1.failure(code))
    }
    fn input(&self, input: InputId) -> Option<&'static str> {
        self.0.input(input).or_else(|| self.1.input(input))
    }
}

impl<A: Names, B: Names, C: Names> Names for (A, B, C) {
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        (&self.0, (&self.1, &self.2)).sequence(id)
    }
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        (&self.0, (&self.1, &self.2)).monitor(id)
    }
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        (&self.0, (&self.1, &self.2)).level(level)
    }
    fn failure(&self, code: u16) -> Option<&'static str> {
        (&self.0, (&self.1, &self.2)).failure(code)
    }
    fn input(&self, input: InputId) -> Option<&'static str> {
        (&self.0, (&self.1, &self.2)).input(input)
    }
}

/// All four kinds of source at once: the sequencer, the monitor table, the safety
/// properties and the failure codes.
impl<A: Names, B: Names, C: Names, D: Names> Names for (A, B, C, D) {
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        ((&self.0, &self.1), (&self.2, &self.3)).sequence(id)
    }
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        ((&self.0, &self.1), (&self.2, &self.3)).monitor(id)
    }
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        ((&self.0, &self.1), (&self.2, &self.3)).level(level)
    }
    fn failure(&self, code: u16) -> Option<&'static str> {
        ((&self.0, &self.1), (&self.2, &self.3)).failure(code)
    }
    fn input(&self, input: InputId) -> Option<&'static str> {
        ((&self.0, &self.1), (&self.2, &self.3)).input(input)
    }
}

/// The registered sequences' names.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize> Names
    for Sequencer<C, N, T, L, W, B>
{
    fn sequence(&self, id: SeqId) -> Option<&'static str> {
        self.sequence_by_id(id).map(|h| h.name())
    }
}

/// The table's monitors' names.
impl<C, const M: usize, K> Names for Monitors<'_, C, M, K> {
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        self.name(id)
    }
}

/// The monitors' names by id, apart from their table: for printing where the tick's table
/// is out of reach (on the chip, the `idle` task that drains the records while the control
/// task owns the table). `rtseq::monitors!` makes them at compile time (`names`); a few
/// bytes of flash per monitor, no copy of the conditions.
///
/// ```
/// use rtseq::{Behaviour, Cause, ConditionFn, Instant, Monitor, MonitorNames, OwnedMonitor,
///             SeqId, WithNames};
/// fn jammed(_: &(), _: Instant) -> bool { false }
/// const MOVE: SeqId = SeqId::from_index(0);
/// const NAMES: MonitorNames<1> = MonitorNames::of(&[
///     Monitor::with_fn("jam", jammed, Behaviour::AbortOwner).owned_by(MOVE),
/// ]);
/// let jam = Cause::Monitor(rtseq::MonitorId::from_index(0));
/// assert_eq!(jam.named(&NAMES).to_string(), "monitor `jam`");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MonitorNames<const M: usize>(pub [&'static str; M]);

impl<const M: usize> MonitorNames<M> {
    /// The names of `monitors`, in table order (monitor `i` is the table's entry `i`).
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, MonitorId, MonitorNames, Names, SeqId};
    /// fn never(_: &(), _: Instant) -> bool { false }
    /// const RUN: SeqId = SeqId::from_index(0);
    /// const NAMES: MonitorNames<2> = MonitorNames::of(&[
    ///     Monitor::with_fn("jam", never, Behaviour::AbortOwner).owned_by(RUN),
    ///     Monitor::with_fn("door", never, Behaviour::PauseOwner).owned_by(RUN),
    /// ]);
    /// assert_eq!(NAMES.monitor(MonitorId::from_index(1)), Some("door"));
    /// assert_eq!(NAMES.monitor(MonitorId::from_index(2)), None);
    /// ```
    pub const fn of<C, K>(monitors: &[OwnedMonitor<'_, C, K>; M]) -> Self {
        let mut names = [""; M];
        let mut slots: &mut [&'static str] = &mut names;
        let mut rest: &[OwnedMonitor<'_, C, K>] = monitors;
        while let (Some((slot, more)), Some((monitor, tail))) =
            (slots.split_first_mut(), rest.split_first())
        {
            *slot = monitor.def.name;
            slots = more;
            rest = tail;
        }
        MonitorNames(names)
    }
}

impl<const M: usize> Names for MonitorNames<M> {
    fn monitor(&self, id: MonitorId) -> Option<&'static str> {
        self.0.get(id.index()).copied()
    }
}

/// The levels' and the critical inputs' names.
impl<IO, const L: usize> Names for SafetyProperties<'_, IO, L> {
    fn level(&self, level: SafetyLevel) -> Option<&'static str> {
        self.level(level).map(|d| d.name())
    }
    fn input(&self, input: InputId) -> Option<&'static str> {
        self.inputs()
            .iter()
            .find(|i| i.id() == input)
            .map(|i| i.name())
    }
}

/// The names of the application's failure codes ([`Failure::App`]): code and name.
///
/// ```
/// use rtseq::{Failure, Failures, WithNames};
/// const FAILURES: Failures = Failures(&[(1, "part lost"), (2, "gripper stuck")]);
/// assert_eq!(Failure::App(2).named(&FAILURES).to_string(), "gripper stuck");
/// assert_eq!(Failure::App(9).named(&FAILURES).to_string(), "failure #9");
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Failures<'a>(pub &'a [(u16, &'static str)]);

impl Names for Failures<'_> {
    fn failure(&self, code: u16) -> Option<&'static str> {
        self.0
            .iter()
            .find(|(c, _)| *c == code)
            .map(|(_, name)| *name)
    }
}

/// A value with the names to print it with ([`WithNames::named`]).
///
/// A run's records printed as its lines, with the sequencer's names and the application's
/// failure codes:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cx, Failure, Failures, Monitors, SeqConfig, Sequence, Sequencer,
///             WithNames};
/// struct Grip;
/// impl Sequence<()> for Grip {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         Err(Failure::App(1))
///     }
/// }
/// const FAILURES: Failures = Failures(&[(1, "no part")]);
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let grip = seq.add(SeqConfig::new("grip"), Grip).unwrap();
/// let id = grip.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(grip);
/// sim.start(id).unwrap();
/// let names = (&seq, &FAILURES);
/// let lines: Vec<String> = sim.records().iter().map(|r| r.named(&names).to_string()).collect();
/// assert_eq!(lines, [
///     "0 ms grip: Idle -> Running (start)",
///     "0 ms grip: Running -> Terminated (failed)",
///     "0 ms `grip` failed: no part",
/// ]);
/// # }
/// ```
pub struct Named<'n, V, N: ?Sized> {
    value: V,
    names: &'n N,
}

impl<V: Copy, N: Names + ?Sized> Named<'_, V, N> {
    fn with<U>(&self, value: U) -> Named<'_, U, N> {
        Named {
            value,
            names: self.names,
        }
    }
}

/// Values that print with names: ids, causes, outcomes, failures, errors, transitions,
/// events, records, safety levels.
///
/// Outcomes and failures, with the sequencer's names and the application's failure codes:
///
/// ```
/// use rtseq::{Cause, Error, Failure, Failures, Outcome, SeqConfig, Sequencer, WithNames};
/// const FAILURES: Failures = Failures(&[(1, "no part")]);
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let belt = seq.register(SeqConfig::new("belt")).unwrap();
/// let names = (&seq, &FAILURES);
/// let failed = Outcome::Failed(Failure::App(1));
/// assert_eq!(failed.named(&names).to_string(), "failed (no part)");
/// let timed_out = Outcome::Aborted(Cause::Timeout(belt));
/// assert_eq!(timed_out.named(&names).to_string(), "aborted (timeout of `belt`)");
/// let refused = Failure::NotStarted(Error::NoLane(belt));
/// assert_eq!(refused.named(&names).to_string(), "not started: sequence `belt` has no lane that a task polls");
/// ```
pub trait WithNames: Copy {
    /// This value with `names`, for `Display` and `defmt::Format`.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer, WithNames};
    /// let seq: Sequencer<(), 1> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("main")).unwrap();
    /// assert_eq!(format!("{}", id.named(&seq)), "main");
    /// ```
    fn named<N: Names + ?Sized>(self, names: &N) -> Named<'_, Self, N> {
        Named { value: self, names }
    }
}

impl WithNames for SeqId {}
impl WithNames for MonitorId {}
impl WithNames for Cause {}
impl WithNames for Outcome {}
impl WithNames for Failure {}
impl WithNames for Error {}
impl WithNames for Transition {}
impl WithNames for SafetyLevel {}
impl WithNames for Event {}
impl WithNames for Record {}

/// What a cause without an id says.
fn cause_word(c: Cause) -> Option<&'static str> {
    Some(match c {
        Cause::Start => "start",
        Cause::PreConditionFalse => "pre-condition false",
        Cause::Completed => "completed",
        Cause::Pause => "pause",
        Cause::Resume => "resume",
        Cause::Abort => "abort",
        Cause::AbortAll => "abort-all",
        Cause::Restart => "restart",
        Cause::Dropped => "dropped",
        Cause::Failed => "failed",
        Cause::Monitor(_) | Cause::Timeout(_) => return None,
    })
}

/// Milliseconds and the µs beyond them (none when zero).
fn millis(t: crate::Instant) -> (u64, Option<u64>) {
    let us = t.duration_since_epoch().as_micros();
    (us / 1_000, Some(us % 1_000).filter(|&r| r != 0))
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, SeqId, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.names.sequence(self.value) {
            Some(name) => f.write_str(name),
            None => write!(f, "#{}", self.value.index()),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, MonitorId, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.names.monitor(self.value) {
            Some(name) => write!(f, "monitor `{name}`"),
            None => write!(f, "monitor #{}", self.value.index()),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Cause, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Cause::Monitor(m) => write!(f, "{}", self.with(m)),
            Cause::Timeout(s) => write!(f, "timeout of `{}`", self.with(s)),
            c => f.write_str(cause_word(c).unwrap_or("")),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Outcome, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Outcome::Completed => f.write_str("completed"),
            Outcome::Skipped => f.write_str("skipped"),
            Outcome::Aborted(c) => write!(f, "aborted ({})", self.with(c)),
            Outcome::Failed(failure) => write!(f, "failed ({})", self.with(failure)),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Failure, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Failure::App(code) => match self.names.failure(code) {
                Some(name) => f.write_str(name),
                None => write!(f, "failure #{code}"),
            },
            Failure::Aborted(c) => write!(f, "aborted ({})", self.with(c)),
            Failure::NotStarted(e) => write!(f, "not started: {}", self.with(e)),
        }
    }
}

/// The error's message with the name of the sequence it names; by index (as its own
/// `Display`) where the source has no name for it.
impl<N: Names + ?Sized> fmt::Display for Named<'_, Error, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value.parts() {
            (before, Some(id), after) => match self.names.sequence(id) {
                Some(name) => write!(f, "{before}`{name}`{after}"),
                None => f.write_str(self.value.message().as_str()),
            },
            (text, None, _) => f.write_str(text),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Transition, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.value;
        write_time(f, t.time)?;
        write!(
            f,
            "{}: {:?} -> {:?} ({})",
            self.with(t.sequence),
            t.from,
            t.to,
            self.with(t.cause)
        )
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, SafetyLevel, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.names.level(self.value) {
            Some(name) => f.write_str(name),
            None => write!(f, "level {}", self.value.id()),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Requester, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Requester::Sequence(id) => write!(f, "`{}`", self.with(id)),
            Requester::Application => f.write_str("the application"),
            Requester::SafetySystem => f.write_str("the safety system"),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, InputId, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.names.input(self.value) {
            Some(name) => write!(f, "critical input `{name}`"),
            None => write!(f, "critical input #{}", self.value.index()),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Event, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Event::Fired {
                cause: cause @ Cause::Timeout(_),
                behaviour,
                ..
            } => write!(f, "{} ran out: {behaviour:?}", self.with(cause)),
            Event::Fired {
                owner,
                cause,
                behaviour,
            } => write!(
                f,
                "{} of `{}` fired: {behaviour:?}",
                self.with(cause),
                self.with(owner)
            ),
            Event::ExceptionNotRun {
                exception,
                owner,
                why,
            } => write!(
                f,
                "exception sequence `{}` of `{}` not run: {}",
                self.with(exception),
                self.with(owner),
                self.with(why)
            ),
            Event::Requested {
                sequence,
                request,
                by,
            } => write!(
                f,
                "{} of `{}` requested by {}",
                request_word(request),
                self.with(sequence),
                self.with(by)
            ),
            Event::AbortAll { by } => write!(f, "abort-all requested by {}", self.with(by)),
            Event::Failed { sequence, failure } => {
                write!(
                    f,
                    "`{}` failed: {}",
                    self.with(sequence),
                    self.with(failure)
                )
            }
            Event::SafetyLevel { level } => write!(f, "safety level {}", self.with(level)),
            Event::InputTripped { input } => write!(f, "{} tripped", self.with(input)),
        }
    }
}

impl<N: Names + ?Sized> fmt::Display for Named<'_, Record, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let time = self.value.time;
        match self.value.entry {
            Entry::Transition {
                sequence,
                from,
                to,
                cause,
            } => {
                let t = Transition {
                    time,
                    sequence,
                    from,
                    to,
                    cause,
                };
                write!(f, "{}", self.with(t))
            }
            Entry::Event(e) => {
                write_time(f, time)?;
                write!(f, "{}", self.with(e))
            }
        }
    }
}

/// What a request is called in a sentence.
fn request_word(r: crate::Request) -> &'static str {
    match r {
        crate::Request::Pause => "pause",
        crate::Request::Resume => "resume",
        crate::Request::Abort => "abort",
    }
}

/// `t` as the lines of a run print it: "12 ms ", "12.500 ms ".
fn write_time(f: &mut fmt::Formatter<'_>, t: crate::Instant) -> fmt::Result {
    match millis(t) {
        (ms, None) => write!(f, "{ms} ms "),
        (ms, Some(us)) => write!(f, "{ms}.{us:03} ms "),
    }
}

#[cfg(feature = "defmt")]
mod defmt_format {
    use super::{cause_word, millis, request_word, Named, Names};
    use crate::safety::{InputId, SafetyLevel};
    use crate::{
        Cause, Entry, Error, Event, Failure, MonitorId, Outcome, Record, Requester, SeqId,
        Transition,
    };

    /// `t` as the lines of a run print it.
    fn write_time(f: defmt::Formatter<'_>, t: crate::Instant) {
        match millis(t) {
            (ms, None) => defmt::write!(f, "{=u64} ms ", ms),
            (ms, Some(us)) => defmt::write!(f, "{=u64}.{=u64:03} ms ", ms, us),
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, SeqId, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.names.sequence(self.value) {
                Some(name) => defmt::write!(f, "{=str}", name),
                None => defmt::write!(f, "#{=usize}", self.value.index()),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, MonitorId, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.names.monitor(self.value) {
                Some(name) => defmt::write!(f, "monitor `{=str}`", name),
                None => defmt::write!(f, "monitor #{=usize}", self.value.index()),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Cause, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value {
                Cause::Monitor(m) => defmt::write!(f, "{}", self.with(m)),
                Cause::Timeout(s) => defmt::write!(f, "timeout of `{}`", self.with(s)),
                c => defmt::write!(f, "{=str}", cause_word(c).unwrap_or("")),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Outcome, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value {
                Outcome::Completed => defmt::write!(f, "completed"),
                Outcome::Skipped => defmt::write!(f, "skipped"),
                Outcome::Aborted(c) => defmt::write!(f, "aborted ({})", self.with(c)),
                Outcome::Failed(failure) => defmt::write!(f, "failed ({})", self.with(failure)),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Failure, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value {
                Failure::App(code) => match self.names.failure(code) {
                    Some(name) => defmt::write!(f, "{=str}", name),
                    None => defmt::write!(f, "failure #{=u16}", code),
                },
                Failure::Aborted(c) => defmt::write!(f, "aborted ({})", self.with(c)),
                Failure::NotStarted(e) => defmt::write!(f, "not started: {}", self.with(e)),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Error, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value.parts() {
                (before, Some(id), after) => match self.names.sequence(id) {
                    Some(name) => defmt::write!(f, "{=str}`{=str}`{=str}", before, name, after),
                    None => defmt::write!(f, "{=str}{=usize}{=str}", before, id.index(), after),
                },
                (text, None, _) => defmt::write!(f, "{=str}", text),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Transition, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            let t = self.value;
            write_time(f, t.time);
            defmt::write!(
                f,
                "{}: {} -> {} ({})",
                self.with(t.sequence),
                t.from,
                t.to,
                self.with(t.cause)
            );
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, SafetyLevel, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.names.level(self.value) {
                Some(name) => defmt::write!(f, "{=str}", name),
                None => defmt::write!(f, "level {=u8}", self.value.id()),
            }
        }
    }
    impl<N: Names + ?Sized> defmt::Format for Named<'_, Requester, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value {
                Requester::Sequence(id) => defmt::write!(f, "`{}`", self.with(id)),
                Requester::Application => defmt::write!(f, "the application"),
                Requester::SafetySystem => defmt::write!(f, "the safety system"),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, InputId, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.names.input(self.value) {
                Some(name) => defmt::write!(f, "critical input `{=str}`", name),
                None => defmt::write!(f, "critical input #{=usize}", self.value.index()),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Event, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.value {
                Event::Fired {
                    cause: cause @ Cause::Timeout(_),
                    behaviour,
                    ..
                } => defmt::write!(f, "{} ran out: {}", self.with(cause), behaviour),
                Event::Fired {
                    owner,
                    cause,
                    behaviour,
                } => defmt::write!(
                    f,
                    "{} of `{}` fired: {}",
                    self.with(cause),
                    self.with(owner),
                    behaviour
                ),
                Event::ExceptionNotRun {
                    exception,
                    owner,
                    why,
                } => defmt::write!(
                    f,
                    "exception sequence `{}` of `{}` not run: {}",
                    self.with(exception),
                    self.with(owner),
                    self.with(why)
                ),
                Event::Requested {
                    sequence,
                    request,
                    by,
                } => defmt::write!(
                    f,
                    "{=str} of `{}` requested by {}",
                    request_word(request),
                    self.with(sequence),
                    self.with(by)
                ),
                Event::AbortAll { by } => {
                    defmt::write!(f, "abort-all requested by {}", self.with(by))
                }
                Event::Failed { sequence, failure } => defmt::write!(
                    f,
                    "`{}` failed: {}",
                    self.with(sequence),
                    self.with(failure)
                ),
                Event::SafetyLevel { level } => {
                    defmt::write!(f, "safety level {}", self.with(level))
                }
                Event::InputTripped { input } => defmt::write!(f, "{} tripped", self.with(input)),
            }
        }
    }

    impl<N: Names + ?Sized> defmt::Format for Named<'_, Record, N> {
        fn format(&self, f: defmt::Formatter<'_>) {
            let time = self.value.time;
            match self.value.entry {
                Entry::Transition {
                    sequence,
                    from,
                    to,
                    cause,
                } => {
                    let t = Transition {
                        time,
                        sequence,
                        from,
                        to,
                        cause,
                    };
                    defmt::write!(f, "{}", self.with(t));
                }
                Entry::Event(e) => {
                    write_time(f, time);
                    defmt::write!(f, "{}", self.with(e));
                }
            }
        }
    }
}
