//! Why a transition happened, and what a run returns.

use crate::{MonitorId, SeqId};

/// Why a transition happened. Recorded in every [`Transition`](crate::Transition) and carried
/// by [`Outcome::Aborted`].
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
