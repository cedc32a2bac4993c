//! Running states, the transition table, causes and outcomes.

use crate::{MonitorId, SeqId};

/// The seven running states of a sequence or step (the seed's `runningStateEnum`).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RunningState {
    /// Registered, never started.
    Idle,
    /// Started and advancing (or blocked by a blocking child).
    Running,
    /// Paused by a request: stops at its next await point, monitors stay active.
    Paused,
    /// Being aborted: the cleanup hook runs in this state.
    Aborting,
    /// Aborted by a monitor, the timeout, a request or abort-all. Sticky until started again.
    Aborted,
    /// Ended normally (exit condition true) or skipped (pre-condition false).
    Terminated,
    /// Aborted for a restart; runs again from the pre-condition at its lane's next poll.
    Restarting,
}

impl RunningState {
    /// True while the sequence occupies its control block: `Running`, `Paused`, `Aborting`
    /// or `Restarting`. Starting an active sequence is an error.
    ///
    /// ```
    /// use rtseq::RunningState;
    /// assert!(RunningState::Paused.is_active());
    /// assert!(!RunningState::Terminated.is_active());
    /// ```
    pub const fn is_active(self) -> bool {
        matches!(
            self,
            RunningState::Running
                | RunningState::Paused
                | RunningState::Aborting
                | RunningState::Restarting
        )
    }

    /// The transition table: whether `self → to` is a legal transition.
    ///
    /// | from | to |
    /// |---|---|
    /// | `Idle`, `Terminated`, `Aborted` | `Running` (start) |
    /// | `Running` | `Paused`, `Aborting`, `Restarting`, `Terminated` |
    /// | `Paused` | `Running` (resume), `Aborting`, `Restarting` |
    /// | `Restarting` | `Running`, `Aborting` |
    /// | `Aborting` | `Aborted` |
    ///
    /// ```
    /// use rtseq::RunningState::*;
    /// assert!(Running.can_transition_to(Paused));
    /// assert!(!Aborted.can_transition_to(Terminated));
    /// ```
    pub const fn can_transition_to(self, to: RunningState) -> bool {
        use RunningState::*;
        matches!(
            (self, to),
            (Idle | Terminated | Aborted, Running)
                | (Running, Paused | Aborting | Restarting | Terminated)
                | (Paused, Running | Aborting | Restarting)
                | (Restarting, Running | Aborting)
                | (Aborting, Aborted)
        )
    }

    /// All seven states, for exhaustive checks.
    pub const ALL: [RunningState; 7] = [
        RunningState::Idle,
        RunningState::Running,
        RunningState::Paused,
        RunningState::Aborting,
        RunningState::Aborted,
        RunningState::Terminated,
        RunningState::Restarting,
    ];
}

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
