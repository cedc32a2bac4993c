//! The normal end of a run (completed, skipped, failed): opened and committed in two
//! sections, so a tick or a lane above that changes the run in between is seen. (The
//! transition function itself is [`State::transition`].)

use core::sync::atomic::AtomicU8;

use crate::model::id::RunId;
use crate::sequencer::callers::caller_handles_exception;
use crate::sequencer::clearance::stops_soon;
use crate::sequencer::inbox::abort_all_posted;
use crate::sequencer::sections::Sections;
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::trace::StateChange;
use crate::{Outcome, RunningState};

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Opens the end of `run`: `Some` (the count of changes its commit compares with) if
    /// `run` may end now (see [`may_end`](Self::may_end)).
    fn open_end(&self, run: RunId, abort_all_posted: bool) -> Option<u32> {
        self.may_end(run, abort_all_posted).then_some(self.changes)
    }

    /// Whether `run` may end now: it is its sequence's current run, `Running`, its
    /// exception is not being handled and the tick is not to abort it (see
    /// [`clearance`](Self::clearance): a run ends only with the clearance `Go`).
    fn may_end(&self, run: RunId, abort_all_posted: bool) -> bool {
        self.block(run.seq).is_some_and(|b| {
            b.runs == run.count
                && b.state == RunningState::Running
                && !self.sets.has(Set::Excepting, run.seq)
                && !stops_soon(b, abort_all_posted)
        })
    }

    /// The commit of a run's end opened when the count of changes was `seen`: `change`
    /// (`Running → Terminated`) with the run's outcome, stored with it (a join that sees
    /// the end sees the outcome). False if anything changed since (a transition, a
    /// start, a tick, which may have marked an exception, an abort request): open the end
    /// again.
    fn commit_end(&mut self, seen: u32, change: &StateChange, outcome: Outcome) -> bool {
        if self.changes != seen {
            return false;
        }
        let Some(b) = self.transition(change) else {
            return false;
        };
        b.outcome = Some(outcome);
        true
    }
}

/// Ends `run` with `outcome`: `change` is `Running → Terminated` (cause `Completed`,
/// `PreConditionFalse` or `Failed`). Opened and committed in two steps (the commit again if
/// anything changed in between). Not while a caller it blocks handles an exception
/// ([`caller_handles_exception`]): the hold is the owner's and its blocking children's.
/// The end of an exception sequence is reported to its owner by the next tick (see
/// [`State::fold`]). False, and nothing changes, if the run
/// was aborted or restarted meanwhile, a later run of its sequence was started, its
/// exception is being handled, or the tick is to abort it (`inbox`: the sequencer's, for an
/// abort-all; its clearance says what to do instead).
pub(crate) fn end_run<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    run: RunId,
    change: &StateChange,
    outcome: Outcome,
    inbox: &AtomicU8,
) -> bool {
    loop {
        let posted = abort_all_posted(inbox);
        let opened = s.section(|s| {
            let seen = s.open_end(run, posted)?;
            Some((seen, s.exception_in_force()))
        });
        let Some((seen, excepting)) = opened else {
            return false;
        };
        // Held with a caller that handles an exception (the tick may have marked it in
        // this very poll): no end now. A mark during the walk moves the count of changes.
        if excepting && caller_handles_exception(s, run.seq) {
            return false;
        }
        if s.section(|s| s.commit_end(seen, change, outcome)) {
            return true;
        }
        // In one section the loop never repeats (nothing changes after the opening).
        if S::ONE_SECTION {
            return false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequencer::sections::tests::{registered, Preempted, S};
    use crate::{Cause, SeqId};

    /// The end of the run of sequence 0 (run count 0: `registered` starts it without a
    /// commit), with `between` run before section `at`. Returns the end's result, the
    /// sections it took and the sequence's state.
    fn end_preempted(at: usize, between: impl FnOnce(&mut S)) -> (bool, usize, RunningState) {
        let id = SeqId(0);
        let mut state = registered(1, &[id]);
        let mut s = Preempted::new(&mut state, at, between);
        let run = RunId { seq: id, count: 0 };
        let change = StateChange::new(
            id,
            RunningState::Running,
            RunningState::Terminated,
            Cause::Completed,
        );
        let ended = end_run(&mut s, run, &change, Outcome::Completed, &AtomicU8::new(0));
        let taken = s.taken;
        (ended, taken, state.state_of(id))
    }

    #[test]
    fn an_undisturbed_end_takes_two_sections() {
        assert_eq!(
            end_preempted(usize::MAX, |_| {}),
            (true, 2, RunningState::Terminated)
        );
    }

    /// A tick between the opening and the commit (it may have marked an exception): the
    /// end opens again, and ends the run.
    #[test]
    fn a_tick_between_the_opening_and_the_commit_opens_the_end_again() {
        let tick = |s: &mut S| s.changes = s.changes.wrapping_add(1);
        assert_eq!(end_preempted(1, tick), (true, 4, RunningState::Terminated));
    }

    /// Between the opening and the commit the run is aborted and its sequence started
    /// again (a lane of higher priority): the old run's end is refused and the new run
    /// runs on.
    #[test]
    fn a_run_replaced_between_the_opening_and_the_commit_does_not_end_the_new_one() {
        let replace = |s: &mut S| {
            let id = SeqId(0);
            for (from, to, cause) in [
                (RunningState::Running, RunningState::Aborting, Cause::Abort),
                (RunningState::Aborting, RunningState::Aborted, Cause::Abort),
                (RunningState::Aborted, RunningState::Running, Cause::Start),
            ] {
                let b = s.transition(&StateChange::new(id, from, to, cause));
                assert!(b.is_some());
            }
            if let Some(b) = s.block_mut(id) {
                b.runs = 1;
            }
        };
        assert_eq!(end_preempted(1, replace), (false, 3, RunningState::Running));
    }
}
