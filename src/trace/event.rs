//! Events: what the sequencer records besides state changes.

use crate::safety::{InputId, SafetyLevel};
use crate::{Behaviour, Cause, Error, Failure, SeqId};

/// Something the sequencer did or was asked, recorded in the trace between the transitions
/// it explains (drain both with
/// [`Sequencer::drain_records`](crate::Sequencer::drain_records)).
///
/// A monitor that fires is recorded before the transitions of its behaviour:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Event, Failure, Instant, Monitor, Monitors,
///             SeqConfig, Sequence, Sequencer};
/// use core::cell::Cell;
/// struct Hold;
/// impl Sequence<Cell<bool>> for Hold {
///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
///         cx.wait_until(|_| false).await;
///         Ok(())
///     }
/// }
/// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
/// let hold = seq.add(SeqConfig::new("hold"), Hold).unwrap();
/// let owner = hold.id();
/// let mut jammed_now = |c: &Cell<bool>, _: Instant| c.get();
/// let mut monitors: Monitors<Cell<bool>, 1> = Monitors::new();
/// let jam = monitors
///     .add(owner, Monitor::new("jam", &mut jammed_now, Behaviour::AbortOwner))
///     .unwrap();
/// let jammed = Cell::new(false);
/// let mut sim = Sim::new(&seq, &jammed, monitors);
/// sim.lane(hold);
/// sim.start(owner).unwrap();
/// jammed.set(true);
/// sim.run_for(rtseq::Duration::from_millis(1));
/// let fired = sim.records().iter().find_map(|r| r.event());
/// assert_eq!(fired, Some(Event::Fired {
///     owner,
///     cause: Cause::Monitor(jam),
///     behaviour: Behaviour::AbortOwner,
/// }));
/// # }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// A monitor of `owner` fired (`cause`: [`Cause::Monitor`]) or its timeout ran out
    /// ([`Cause::Timeout`]); `behaviour` follows (once its restarts are used up, the one it
    /// escalates to), as judged at the firing. One that waits for its exception sequence
    /// is judged again when it is applied, on the target's run then (semantics item 5):
    /// if that run is another one, what is applied may differ, and the transitions that
    /// follow show it.
    Fired {
        /// The monitor's owner.
        owner: SeqId,
        /// Which monitor, or the timeout.
        cause: Cause,
        /// The behaviour, as judged at the firing, applied at once or after the exception
        /// sequence.
        behaviour: Behaviour,
    },
    /// The exception sequence of an exception of `owner` could not run, so the behaviour
    /// was applied at once (a `PauseOwner` monitor's hold pauses without it): `why` says
    /// what stopped it (no lane, already running, too deep). A start refused once the
    /// owner's run was over or being stopped is not recorded: the exception went with its
    /// run (semantics 10).
    ExceptionNotRun {
        /// The exception sequence.
        exception: SeqId,
        /// The owner of the monitor or timeout.
        owner: SeqId,
        /// The error its start gave.
        why: Error,
    },
    /// `by` asked for `request` of `sequence`; the next tick carries it out.
    Requested {
        /// The sequence to pause, resume or abort.
        sequence: SeqId,
        /// What was asked.
        request: Request,
        /// Who asked.
        by: Requester,
    },
    /// The tick took a request to abort every sequence, made by `by`. One that a tick
    /// could not carry out to its end (cleanup hooks that kept starting runs during it)
    /// stays asked for, and is recorded again by each tick that takes it.
    AbortAll {
        /// Who asked.
        by: Requester,
    },
    /// A run of `sequence` failed: its action returned `Err(failure)`. The transition
    /// `Running → Terminated` (cause [`Cause::Failed`]) before it says when (usually just
    /// before; a tick or lane of higher priority that preempts the end may record in
    /// between); the other outcomes are told by their transitions alone.
    Failed {
        /// The sequence whose run failed.
        sequence: SeqId,
        /// What its action returned.
        failure: Failure,
    },
    /// The safety system entered `level` (in its first cycle, the entry level). Recorded by
    /// the tick after the safety cycle that made the change, before an abort-all it asked for.
    SafetyLevel {
        /// The level entered.
        level: SafetyLevel,
    },
    /// A critical input tripped: the safety system's check of `input` fired, and did not in
    /// the cycle before. Recorded by the tick after that safety cycle.
    InputTripped {
        /// The critical input.
        input: InputId,
    },
}

/// A request to a running sequence ([`Handle::pause`](crate::Handle::pause),
/// [`resume`](crate::Handle::resume), [`abort`](crate::Handle::abort)).
///
/// Each request is recorded as it is made; the next tick carries it out:
///
/// ```
/// use rtseq::{Event, Record, Request, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("press")).unwrap();
/// let press = seq.sequence_by_id(id).unwrap();
/// press.declare_lane().unwrap();
/// press.start().unwrap();
/// press.pause().unwrap();
/// press.abort().unwrap();
/// let mut records = Vec::new();
/// seq.drain_records(|r| records.push(r));
/// let requests: Vec<Request> = records
///     .iter()
///     .filter_map(Record::event)
///     .filter_map(|e| match e {
///         Event::Requested { request, .. } => Some(request),
///         _ => None,
///     })
///     .collect();
/// assert_eq!(requests, [Request::Pause, Request::Abort]);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request {
    /// Pause a running sequence and its blocking children.
    Pause,
    /// Resume a paused sequence where it stopped.
    Resume,
    /// Abort an active sequence and all its sub-sequences.
    Abort,
}

/// Who made a request.
///
/// A pause by the application, then an abort by the sequence `stop`:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cx, Event, Failure, Monitors, Record, Requester, SeqConfig, SeqId,
///             Sequence, Sequencer};
/// struct Belt;
/// impl Sequence<()> for Belt {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         cx.wait_until(|_| false).await;
///         Ok(())
///     }
/// }
/// struct Stop(SeqId);
/// impl Sequence<()> for Stop {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         if let Some(belt) = cx.sequence_by_id(self.0) {
///             belt.abort()?;
///         }
///         Ok(())
///     }
/// }
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let belt = seq.add(SeqConfig::new("belt"), Belt).unwrap();
/// let b = belt.id();
/// let stop = seq.add(SeqConfig::new("stop"), Stop(b)).unwrap();
/// let s = stop.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(belt);
/// sim.lane(stop);
/// sim.start(b).unwrap();
/// sim.pause(b).unwrap();
/// sim.start(s).unwrap();
/// let by: Vec<Requester> = sim
///     .records()
///     .iter()
///     .filter_map(Record::event)
///     .filter_map(|e| match e {
///         Event::Requested { by, .. } => Some(by),
///         _ => None,
///     })
///     .collect();
/// assert_eq!(by, [Requester::Application, Requester::Sequence(s)]);
/// # }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Requester {
    /// A sequence, through a handle from its context
    /// ([`Cx::sequence_by_id`](crate::Cx::sequence_by_id)), or the abort of a child it
    /// started scoped, when it dropped the [`Scoped`](crate::Scoped).
    Sequence(SeqId),
    /// The application, through a handle from the sequencer
    /// ([`Sequencer::sequence_by_id`](crate::Sequencer::sequence_by_id)) or
    /// [`Sequencer::abort_all`](crate::Sequencer::abort_all).
    Application,
    /// The safety system (a level that aborts every sequence).
    SafetySystem,
}
