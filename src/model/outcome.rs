//! Why a transition happened, what a run returns, and why an action fails.

use crate::{Error, MonitorId, SeqId};

/// Why a transition happened. Recorded in every [`Transition`](crate::Transition) and carried
/// by [`Outcome::Aborted`].
///
/// Causes in a trace: a start, and a completion.
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cause, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
/// struct Blink;
/// impl Sequence<()> for Blink {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
/// let id = blink.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(blink);
/// sim.start(id).unwrap();
/// let causes: Vec<Cause> = sim.trace().iter().map(|t| t.cause).collect();
/// assert_eq!(causes, [Cause::Start, Cause::Completed]);
/// # }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Cause {
    /// Started by a caller or a handle.
    Start,
    /// The pre-condition was false: the sequence was skipped.
    PreConditionFalse,
    /// The exit condition became true.
    Completed,
    /// A pause request.
    Pause,
    /// A resume request.
    Resume,
    /// An explicit abort request through a [`Handle`](crate::Handle), or that of a
    /// scoped child whose [`Scoped`](crate::Scoped) its caller dropped.
    Abort,
    /// [`Sequencer::abort_all`](crate::Sequencer::abort_all), e.g. from the safety system.
    AbortAll,
    /// A monitor fired (also the cause of everything its behaviour aborts or restarts, and of
    /// its exception sequence's start).
    Monitor(MonitorId),
    /// The timeout monitor of the given sequence fired.
    Timeout(SeqId),
    /// A `Restarting` sequence runs again.
    Restart,
    /// The future of the run was dropped before the run ended (the loser of a `select`, a
    /// timeout combinator): the run is aborted, with its sub-sequences, where it was.
    Dropped,
    /// The action returned an error: the run ended with [`Outcome::Failed`].
    Failed,
}

impl Cause {
    /// An exception: a monitor or a timeout fired (`Monitor`, `Timeout`). What it aborts
    /// or restarts as its behaviour's target has [`exception_is_active`] set.
    ///
    /// [`exception_is_active`]: crate::Handle::exception_is_active
    ///
    /// ```
    /// use rtseq::{Cause, SeqId};
    /// assert!(Cause::Timeout(SeqId::from_index(0)).is_exception());
    /// assert!(!Cause::AbortAll.is_exception());
    /// ```
    pub const fn is_exception(self) -> bool {
        matches!(self, Cause::Monitor(_) | Cause::Timeout(_))
    }
}

/// The result of one run: how it ended ([`Handle::last_outcome`], [`Cx::join`]).
///
/// A blocking caller gets it as a `Result` ([`Outcome::done`]): [`Done`] when the run
/// completed or was skipped, a [`Failure`] when it was aborted or failed, so `?` hands an
/// aborted or failed child on to the caller's own outcome.
///
/// A gripper that fails without a part, then completes with one:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use core::cell::Cell;
/// use rtseq::{sim::Sim, Cx, Done, Failure, Monitors, Outcome, SeqConfig, Sequence, Sequencer};
/// struct Grip;
/// impl Sequence<Cell<bool>> for Grip {
///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
///         if cx.control().get() { Ok(()) } else { Err(Failure::App(1)) } // 1: no part
///     }
/// }
/// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
/// let grip = seq.add(SeqConfig::new("grip"), Grip).unwrap();
/// let h = seq.sequence_by_id(grip.id()).unwrap();
/// let part = Cell::new(false);
/// let mut sim = Sim::new(&seq, &part, Monitors::<Cell<bool>, 1>::new());
/// sim.lane(grip);
/// sim.start(h.id()).unwrap();
/// assert_eq!(h.last_outcome(), Some(Outcome::Failed(Failure::App(1))));
/// assert_eq!(h.last_outcome().map(Outcome::done), Some(Err(Failure::App(1))));
/// part.set(true);
/// sim.start(h.id()).unwrap();
/// assert_eq!(h.last_outcome(), Some(Outcome::Completed));
/// assert_eq!(h.last_outcome().map(Outcome::done), Some(Ok(Done::Completed)));
/// # }
/// ```
///
/// [`Handle::last_outcome`]: crate::Handle::last_outcome
/// [`Cx::join`]: crate::Cx::join
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// The action ran and the exit condition became true.
    Completed,
    /// The pre-condition was false; the action did not run.
    Skipped,
    /// Aborted; the cause names the monitor, timeout or request responsible.
    Aborted(Cause),
    /// The action returned `Err`: it gave up, for this reason.
    Failed(Failure),
}

impl Outcome {
    /// The outcome as a blocking caller receives it: `Ok` when the run completed or was
    /// skipped; an abort becomes [`Failure::Aborted`], a failure stays what it is.
    ///
    /// ```
    /// use rtseq::{Cause, Done, Failure, Outcome};
    /// assert_eq!(Outcome::Skipped.done(), Ok(Done::Skipped));
    /// assert_eq!(
    ///     Outcome::Aborted(Cause::Abort).done(),
    ///     Err(Failure::Aborted(Cause::Abort))
    /// );
    /// assert_eq!(Outcome::Failed(Failure::App(7)).done(), Err(Failure::App(7)));
    /// ```
    pub const fn done(self) -> Result<Done, Failure> {
        match self {
            Outcome::Completed => Ok(Done::Completed),
            Outcome::Skipped => Ok(Done::Skipped),
            Outcome::Aborted(cause) => Err(Failure::Aborted(cause)),
            Outcome::Failed(failure) => Err(failure),
        }
    }
}

/// How a run that a blocking caller waited for ended well ([`Cx::run`], [`Cx::step`]).
///
/// What a caller does with the result of a blocking run:
///
/// ```
/// use rtseq::{Cause, Cx, Done, Failure, Seq, Sequence, Step};
/// struct Home;
/// impl Step<()> for Home {
///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// struct Main { home: Seq<Home> }
/// impl Sequence<()> for Main {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         match cx.step(&mut self.home).await {
///             Ok(Done::Completed) => { /* homed: go on */ }
///             Ok(Done::Skipped) => { /* already homed (pre-condition false) */ }
///             Err(Failure::Aborted(Cause::Timeout(_))) => { /* took too long: retry */ }
///             // A monitor, a request, abort-all, a failure of its own, or it could
///             // not start (e.g. already running): this run fails with it.
///             Err(other) => return Err(other),
///         }
///         // Or, when every failure of the child is this run's failure too:
///         cx.step(&mut self.home).await?;
///         Ok(())
///     }
/// }
/// ```
///
/// [`Cx::run`]: crate::Cx::run
/// [`Cx::step`]: crate::Cx::step
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Done {
    /// The action ran and the exit condition became true.
    Completed,
    /// The pre-condition was false; the action did not run.
    Skipped,
}

/// Why an action gave up: the `Err` of [`Sequence::action`] and [`Step::action`], and the
/// `Err` a blocking caller receives.
///
/// The application names its own reasons as codes ([`Failure::App`]); a `From`
/// implementation for its error type lets `?` and `.into()` turn them into failures:
///
/// ```
/// use rtseq::Failure;
/// #[derive(Clone, Copy, Debug)]
/// enum CellFault { PartLost = 1, GripperStuck = 2 }
/// impl From<CellFault> for Failure {
///     fn from(fault: CellFault) -> Self { Failure::App(fault as u16) }
/// }
/// let failure: Failure = CellFault::GripperStuck.into();
/// assert_eq!(failure, Failure::App(2));
/// ```
///
/// [`Sequence::action`]: crate::Sequence::action
/// [`Step::action`]: crate::Step::action
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Failure {
    /// The application's own reason: a code it defines.
    App(u16),
    /// A sequence or step this action waited for was aborted, for this cause.
    Aborted(Cause),
    /// A sequence or step this action asked for could not start, for this reason.
    NotStarted(Error),
}

impl From<Error> for Failure {
    /// A start that was refused: `?` on a start hands the error on as a failure.
    fn from(e: Error) -> Self {
        Failure::NotStarted(e)
    }
}
