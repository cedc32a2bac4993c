//! What the running state means for a run's await points, and the normal end of a run.
//! (The transition function itself is [`State::transition`].)

use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::trace::StateChange;
use crate::{Cause, Outcome, RunningState, SeqId};

/// What a run's await point must do, decided by its control block.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Clearance {
    /// Advance.
    Go,
    /// Paused, or an exception is being handled: stay at this await point.
    Hold,
    /// Aborted: unwind with this cause; no further line of the action runs.
    Aborted(Cause),
    /// Restarting: drop the action and run again from the pre-condition.
    Restart,
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// What an await point of `id` must do now.
    pub(crate) fn clearance(&self, id: SeqId) -> Clearance {
        let Some(b) = self.block(id) else {
            return Clearance::Aborted(Cause::Abort);
        };
        match b.state {
            RunningState::Running if !self.sets.has(Set::Excepting, id) => Clearance::Go,
            RunningState::Running | RunningState::Paused => Clearance::Hold,
            RunningState::Restarting => Clearance::Restart,
            RunningState::Aborting | RunningState::Aborted => Clearance::Aborted(b.last_cause),
            // Not started by this run: treat as aborted so nothing of it advances.
            RunningState::Idle | RunningState::Terminated => Clearance::Aborted(b.last_cause),
        }
    }

    /// Ends a run with `outcome`: `change` is `Running → Terminated` (cause `Completed`,
    /// `PreConditionFalse` or `Failed`), and the outcome is stored with it (a join that
    /// sees the end sees the outcome). False, and nothing changes, if the sequence was
    /// aborted or restarted meanwhile or its exception is being handled (its clearance says
    /// what to do instead).
    pub(crate) fn end(&mut self, change: &StateChange, outcome: Outcome) -> bool {
        // A run ends only with the clearance `Go`: not while its exception is handled.
        if self.sets.has(Set::Excepting, change.sequence) {
            return false;
        }
        let Some(b) = self.transition(change) else {
            return false;
        };
        b.outcome = Some(outcome);
        true
    }
}
