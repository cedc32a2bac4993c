//! What the running state means for a run's await points: advance, hold, unwind or run
//! again; and the poll wait of a polled condition. (The end of a run is `end.rs`'s.)

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::sequencer::callers::caller_handles_exception;
use crate::sequencer::control_block::{request, ControlBlock};
use crate::sequencer::inbox::abort_all_posted;
use crate::sequencer::sections::{in_sections, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::{Cause, RunningState, Sequencer};

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
    /// What an await point of `run` must do now. A run that is not its sequence's
    /// current one was aborted, and its sequence started again before its future
    /// unwound: it is over (the cause of the last teardown). A run whose abort is
    /// requested, or (`abort_all_posted`) that an abort-all in the inbox is to abort,
    /// holds until the tick carries the abort out: its action begins nothing more
    /// (semantics item 8).
    pub(crate) fn clearance(&self, run: RunId, abort_all_posted: bool) -> Clearance {
        let id = run.seq;
        let Some(b) = self.block(id) else {
            return Clearance::Aborted(Cause::Abort);
        };
        if b.runs != run.count {
            return Clearance::Aborted(b.last_cause);
        }
        match b.state {
            RunningState::Running
                if !self.sets.has(Set::Excepting, id) && !stops_soon(b, abort_all_posted) =>
            {
                Clearance::Go
            }
            RunningState::Running | RunningState::Paused => Clearance::Hold,
            // Its next round is not begun while the tick is to abort it.
            RunningState::Restarting if stops_soon(b, abort_all_posted) => Clearance::Hold,
            RunningState::Restarting => Clearance::Restart,
            RunningState::Aborting | RunningState::Aborted => Clearance::Aborted(b.last_cause),
            // Not started by this run: treat as aborted so nothing of it advances.
            RunningState::Idle | RunningState::Terminated => Clearance::Aborted(b.last_cause),
        }
    }

    /// As [`clearance`](Self::clearance), but `Go` only when the tick said `run`'s polled
    /// condition is due, and then the due poll is taken. Inline: it is the whole of a
    /// due poll's section, which must stay short.
    #[inline(always)]
    pub(crate) fn take_due_poll(&mut self, run: RunId, abort_all_posted: bool) -> Clearance {
        let id = run.seq;
        match self.clearance(run, abort_all_posted) {
            Clearance::Go if self.sets.has(Set::PollDue, id) => {
                self.sets.put(Set::PollDue, id, false);
                Clearance::Go
            }
            Clearance::Go => Clearance::Hold,
            other => other,
        }
    }

    /// Sets whether `run` waits for a polled condition (the tick then wakes it when its
    /// poll is due); a stale due poll is dropped. Only for the current run.
    pub(crate) fn set_poll_wait(&mut self, run: RunId, waiting: bool) {
        let id = run.seq;
        if self.block(id).is_some_and(|b| b.runs == run.count) {
            self.sets.put(Set::PollWait, id, waiting);
            self.sets.put(Set::PollDue, id, false);
        }
    }

    /// Whether some sequence under way (monitored as of the tick's last fold) handles an
    /// exception. The mark of an owner whose run ended stays (`exception_is_active`) and
    /// holds nothing.
    pub(crate) fn exception_in_force(&self) -> bool {
        let sets = &self.sets;
        if B == 1 {
            return sets
                .word(Set::Excepting, 0)
                .meets(sets.word(Set::Monitored, 0));
        }
        sets.words(Set::Excepting).any(|w| {
            sets.word(Set::Excepting, w)
                .meets(sets.word(Set::Monitored, w))
        })
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// What an await point of `run` inside its lane's poll must do (a blocking run's, or
    /// one of its action's futures'): its own clearance, or `Hold` while a caller it
    /// blocks handles an exception ([`caller_handles_exception`]).
    pub(crate) fn clearance_in_lane(&self, run: RunId) -> Clearance {
        let posted = abort_all_posted(&self.safety.inbox);
        in_sections!(self, |s| held_in_lane(s, run, posted))
    }
}

/// See [`Sequencer::clearance_in_lane`]. The first section gives the run's own clearance
/// and, when no sequence under way handles an exception, that is all. Else the callers
/// are walked, and the answer is `Go` only if nothing changed from the section that gave
/// it to the end of the walk (the count of changes): a tick that paused or stopped the
/// run or marked an exception meanwhile makes it look again, so what follows the answer
/// follows it with no section in between, as with one section.
fn held_in_lane<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    run: RunId,
    posted: bool,
) -> Clearance {
    let (mut got, mut seen, excepting) = s.section(|s| {
        let got = s.clearance(run, posted);
        (got, s.changes, s.exception_in_force())
    });
    while excepting && got == Clearance::Go {
        if caller_handles_exception(s, run.seq) {
            return Clearance::Hold;
        }
        if S::ONE_SECTION || s.section(|s| s.changes == seen) {
            break;
        }
        (got, seen) = s.section(|s| (s.clearance(run, posted), s.changes));
    }
    got
}

/// Whether the run of `b` is to be aborted by the tick: its abort is requested, or
/// (`abort_all_posted`) an abort-all waits in the inbox.
pub(crate) fn stops_soon(b: &ControlBlock, abort_all_posted: bool) -> bool {
    b.has(request::ABORT) || abort_all_posted
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequencer::sections::tests::{registered, Preempted, S};
    use crate::SeqId;

    /// A run that was replaced (its sequence started again, run 1) neither makes the new
    /// run wait for a poll nor drops its due poll; the current run does.
    #[test]
    fn only_the_current_run_sets_its_poll_wait() {
        let id = SeqId(0);
        let mut state = registered(1, &[id]);
        if let Some(b) = state.block_mut(id) {
            b.runs = 1;
        }
        state.sets.put(Set::PollDue, id, true);
        state.set_poll_wait(RunId { seq: id, count: 0 }, true);
        assert_eq!(
            (
                state.sets.has(Set::PollWait, id),
                state.sets.has(Set::PollDue, id)
            ),
            (false, true)
        );
        state.set_poll_wait(RunId { seq: id, count: 1 }, true);
        assert_eq!(
            (
                state.sets.has(Set::PollWait, id),
                state.sets.has(Set::PollDue, id)
            ),
            (true, false)
        );
    }

    /// A lane of three: main 0 runs axis 1, which runs step 2, all running and monitored;
    /// sequence 3, in another lane, handles an exception when `elsewhere`. Returns the
    /// step's clearance when `between` runs before section `at`, and the sections taken.
    fn step_clearance(
        elsewhere: bool,
        at: usize,
        between: impl FnOnce(&mut S),
    ) -> (Clearance, usize) {
        use crate::model::id::Link;
        let ids = [0, 1, 2, 3].map(SeqId);
        let mut state = registered(4, &ids);
        for (id, caller, lane) in [(0, None, 0), (1, Some(0), 0), (2, Some(1), 0), (3, None, 1)] {
            if let Some(b) = state.block_mut(SeqId(id)) {
                b.caller = Link::to(caller.map(SeqId));
                b.lane = lane;
            }
            state.sets.insert(Set::Monitored, SeqId(id));
        }
        state.sets.put(Set::Excepting, SeqId(3), elsewhere);
        let mut s = Preempted::new(&mut state, at, between);
        let got = held_in_lane(
            &mut s,
            RunId {
                seq: SeqId(2),
                count: 0,
            },
            false,
        );
        (got, s.taken)
    }

    /// The tick marks main's exception (a change counted).
    fn mark_main(s: &mut S) {
        s.sets.put(Set::Excepting, SeqId(0), true);
        s.changes = s.changes.wrapping_add(1);
    }

    /// No exception in force: one section. One elsewhere: the step walks up to main (two
    /// steps and the top) and checks the count of changes.
    #[test]
    fn the_walk_up_the_callers_comes_only_while_an_exception_is_in_force() {
        assert_eq!(
            step_clearance(false, usize::MAX, |_| {}),
            (Clearance::Go, 1)
        );
        assert_eq!(step_clearance(true, usize::MAX, |_| {}), (Clearance::Go, 5));
        // A mark of a sequence no longer under way (its run ended) holds nothing.
        let ended = |s: &mut S| {
            s.sets.remove(Set::Monitored, SeqId(3));
        };
        assert_eq!(step_clearance(true, 0, ended), (Clearance::Go, 1));
    }

    /// Main marked before any section of the step's check, between two of its steps up,
    /// or before the check of the count of changes: the step holds.
    #[test]
    fn a_mark_anywhere_in_the_walk_holds_the_step() {
        for at in 0..5 {
            let (got, _) = step_clearance(true, at, mark_main);
            assert_eq!(got, Clearance::Hold, "marked before section {at}");
        }
    }
}
