//! Why a transition happened, and what a run returns.

use crate::{MonitorId, SeqId};

/// Why a transition happened. Recorded in every [`Transition`](crate::Transition) and carried
/// by [`Outcome::Aborted`].
///
/// Causes in a trace: a start, and a completion.
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cause, Cx, Monitors, SeqConfig, Sequence, Sequencer};
/// struct Blink;
/// impl Sequence<()> for Blink {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) {}
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
    /// An explicit abort request through a [`Handle`](crate::Handle).
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
}

/// The result of one run, returned to a blocking caller (no magic `-1`).
///
/// What a caller does with the outcome of a blocking run:
///
/// ```
/// use rtseq::{Cause, Cx, Outcome, Seq, Sequence, Step};
/// struct Home;
/// impl Step<()> for Home { fn action(&mut self, _cx: &Cx<'_, ()>) {} }
/// struct Main { home: Seq<Home> }
/// impl Sequence<()> for Main {
///     async fn action(&mut self, cx: &Cx<'_, ()>) {
///         match cx.step(&mut self.home).await {
///             Ok(Outcome::Completed) => { /* homed: go on */ }
///             Ok(Outcome::Skipped) => { /* already homed (pre-condition false) */ }
///             Ok(Outcome::Aborted(Cause::Timeout(_))) => { /* took too long */ }
///             Ok(Outcome::Aborted(_)) => { /* a monitor, a request, abort-all */ }
///             Err(_) => { /* could not start it, e.g. already running */ }
///         }
///     }
/// }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// The action ran and the exit condition became true.
    Completed,
    /// The pre-condition was false; the action did not run.
    Skipped,
    /// Aborted; the cause names the monitor, timeout or request responsible.
    Aborted(Cause),
}
