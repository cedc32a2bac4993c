//! The trace: one record per state change and per event (a monitor fired, an exception
//! that could not run, a request, a run's outcome), in the order the sequencer made them.

mod drain;
mod event;
pub(crate) mod ring;

pub use event::{Event, Request, Requester};

pub(crate) use ring::Ring;

use crate::{Cause, Instant, RunningState, SeqId};

/// One state change of one sequence: `(time, sequence, from, to, cause)`.
///
/// The sequencer keeps the most recent records in a bounded buffer; drain it with
/// [`Sequencer::drain_trace`](crate::Sequencer::drain_trace). The host
/// `Sim` (feature `std`) collects them all.
///
/// The record of a start, read from the sequencer's buffer:
///
/// ```
/// use rtseq::{Cause, Instant, RunningState, SeqConfig, Sequencer, Transition};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("blink")).unwrap();
/// let h = seq.sequence_by_id(id).unwrap();
/// h.declare_lane().unwrap();
/// h.start().unwrap();
/// let mut last = None;
/// seq.drain_trace(|t| last = Some(t));
/// assert_eq!(last, Some(Transition {
///     time: Instant::from_ticks(0),
///     sequence: id,
///     from: RunningState::Idle,
///     to: RunningState::Running,
///     cause: Cause::Start,
/// }));
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transition {
    /// Sequencer time of the change (the last tick's time).
    pub time: Instant,
    /// The sequence that changed state.
    pub sequence: crate::SeqId,
    /// State before.
    pub from: RunningState,
    /// State after.
    pub to: RunningState,
    /// Why.
    pub cause: Cause,
}

impl Transition {
    /// A compact constructor, convenient for expected traces in tests.
    ///
    /// ```
    /// use rtseq::{Cause, RunningState::*, SeqId, Transition};
    /// # fn id(s: &rtseq::Sequencer<(), 2>) -> SeqId { s.register(rtseq::SeqConfig::new("a")).unwrap() }
    /// # let s = rtseq::Sequencer::new(); let a = id(&s);
    /// let t = Transition::at_millis(5, a, Idle, Running, Cause::Start);
    /// assert_eq!(t.time.as_ticks(), 5_000);
    /// ```
    pub const fn at_millis(
        ms: u64,
        sequence: SeqId,
        from: RunningState,
        to: RunningState,
        cause: Cause,
    ) -> Self {
        Transition {
            time: Instant::from_ticks(ms.saturating_mul(1_000)),
            sequence,
            from,
            to,
            cause,
        }
    }
}

/// One record of the trace, as [`Sequencer::drain_records`](crate::Sequencer::drain_records)
/// passes it on: a state change or an event at `time`, in the order the sequencer made them.
///
/// The records of a start and a pause request after a tick at 2 ms, drained from the
/// sequencer's buffer:
///
/// ```
/// use rtseq::{Cause, Entry, Event, Instant, Monitors, Record, Request, Requester,
///             RunningState, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("press")).unwrap();
/// let press = seq.sequence_by_id(id).unwrap();
/// press.declare_lane().unwrap();
/// seq.tick(Instant::from_ticks(2_000), &(), &mut Monitors::<(), 1>::new()).unwrap();
/// press.start().unwrap();
/// press.pause().unwrap();
/// let mut records = Vec::new();
/// seq.drain_records(|r| records.push(r));
/// let time = Instant::from_ticks(2_000);
/// assert_eq!(records, [
///     Record {
///         time,
///         entry: Entry::Transition {
///             sequence: id,
///             from: RunningState::Idle,
///             to: RunningState::Running,
///             cause: Cause::Start,
///         },
///     },
///     Record {
///         time,
///         entry: Entry::Event(Event::Requested {
///             sequence: id,
///             request: Request::Pause,
///             by: Requester::Application,
///         }),
///     },
/// ]);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Record {
    /// Sequencer time (the last tick's time when it was recorded).
    pub time: Instant,
    /// What happened.
    pub entry: Entry,
}

/// What a [`Record`] holds: a state change or an event.
///
/// A run that fails records its end, then the failure:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cause, Cx, Entry, Event, Failure, Monitors, RunningState, SeqConfig,
///             Sequence, Sequencer};
/// struct Grip;
/// impl Sequence<()> for Grip {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         Err(Failure::App(1)) // no part
///     }
/// }
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let grip = seq.add(SeqConfig::new("grip"), Grip).unwrap();
/// let id = grip.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(grip);
/// sim.start(id).unwrap();
/// let entries: Vec<Entry> = sim.records().iter().map(|r| r.entry).collect();
/// assert_eq!(entries[1..], [
///     Entry::Transition {
///         sequence: id,
///         from: RunningState::Running,
///         to: RunningState::Terminated,
///         cause: Cause::Failed,
///     },
///     Entry::Event(Event::Failed { sequence: id, failure: Failure::App(1) }),
/// ]);
/// # }
/// ```
// `repr(u8)` with the transition first: the blank records of an empty ring are zero bytes,
// so a sequencer `static` needs no initial image in flash.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Entry {
    /// A state change (a [`Transition`] without its time).
    Transition {
        /// The sequence that changed state.
        sequence: SeqId,
        /// State before.
        from: RunningState,
        /// State after.
        to: RunningState,
        /// Why.
        cause: Cause,
    },
    /// An event.
    Event(Event),
}

impl Record {
    /// The state change, if this record is one.
    ///
    /// The transitions among the records, events left out:
    ///
    /// ```
    /// use rtseq::{Cause, Record, RunningState::*, SeqConfig, Sequencer, Transition};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("press")).unwrap();
    /// let press = seq.sequence_by_id(id).unwrap();
    /// press.declare_lane().unwrap();
    /// press.start().unwrap();
    /// press.pause().unwrap(); // a request: an event
    /// let mut records = Vec::new();
    /// seq.drain_records(|r| records.push(r));
    /// let changes: Vec<Transition> = records.iter().filter_map(Record::transition).collect();
    /// assert_eq!(changes, [Transition::at_millis(0, id, Idle, Running, Cause::Start)]);
    /// ```
    pub const fn transition(&self) -> Option<Transition> {
        match self.entry {
            Entry::Transition {
                sequence,
                from,
                to,
                cause,
            } => Some(Transition {
                time: self.time,
                sequence,
                from,
                to,
                cause,
            }),
            Entry::Event(_) => None,
        }
    }

    /// The event, if this record is one.
    ///
    /// The events among the records, transitions left out:
    ///
    /// ```
    /// use rtseq::{Event, Record, Request, Requester, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("press")).unwrap();
    /// let press = seq.sequence_by_id(id).unwrap();
    /// press.declare_lane().unwrap();
    /// press.start().unwrap(); // a state change
    /// press.pause().unwrap();
    /// let mut records = Vec::new();
    /// seq.drain_records(|r| records.push(r));
    /// let events: Vec<Event> = records.iter().filter_map(Record::event).collect();
    /// assert_eq!(events, [Event::Requested {
    ///     sequence: id,
    ///     request: Request::Pause,
    ///     by: Requester::Application,
    /// }]);
    /// ```
    pub const fn event(&self) -> Option<Event> {
        match self.entry {
            Entry::Event(e) => Some(e),
            Entry::Transition { .. } => None,
        }
    }
}

/// A state change to make, without its time: what the transition function
/// (`State::transition`) is asked for, and what a ring slot keeps beside the time.
#[derive(Clone, Copy)]
pub(crate) struct StateChange {
    pub(crate) sequence: SeqId,
    pub(crate) from: RunningState,
    pub(crate) to: RunningState,
    pub(crate) cause: Cause,
}

impl StateChange {
    /// The change of `sequence` from `from` to `to` for `cause`.
    pub(crate) const fn new(
        sequence: SeqId,
        from: RunningState,
        to: RunningState,
        cause: Cause,
    ) -> Self {
        StateChange {
            sequence,
            from,
            to,
            cause,
        }
    }
}
