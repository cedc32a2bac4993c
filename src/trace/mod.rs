//! The trace: one record per state change and per event (a monitor fired, an exception
//! that could not run, a request, a run's outcome), in the order the sequencer made them.

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
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Record {
    /// Sequencer time (the last tick's time when it was recorded).
    pub time: Instant,
    /// What happened.
    pub entry: Entry,
}

/// What a [`Record`] holds: a state change or an event.
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
