//! Joins: sequences waiting for the end of another sequence's run.
//!
//! A joiner records in its own block which run it waits for, and is in the set `joining`;
//! the end of a run releases every joiner of it and wakes their lanes. So any number of
//! sequences can join one run.

use crate::model::id::RunId;
use crate::model::set::SeqSet;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::flag;
use crate::sequencer::control_block::JoinWait;
use crate::sequencer::lanes::LaneSet;
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::{Error, Outcome, RunningState, SeqId};

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// `joiner` waits for the end of `target`'s run of count `runs`. An action may wait in
    /// several joins at once (joins raced with `select`, or joined): a joiner already
    /// waiting for another run waits for any end until it is released, so the end
    /// of neither run is missed (a spurious wake-up costs one poll).
    pub(crate) fn wait_for_join(&mut self, joiner: SeqId, target: SeqId, runs: u16) {
        let joining = self.sets.has(Set::Joining, joiner);
        if let Some(b) = self.block_mut(joiner) {
            let wait = JoinWait::end_of(target, runs);
            b.joins = if joining && b.joins != wait {
                JoinWait::ANY_END
            } else {
                wait
            };
            self.sets.put(Set::Joining, joiner, true);
        }
    }

    /// A join of `joiner` is refused: from now on no cycle check and no end follows its
    /// wait. [`join_returned`](Self::join_returned) clears the wait and wakes, in a
    /// section of its own.
    pub(crate) fn join_decided(&mut self, joiner: SeqId) {
        self.sets.put(Set::Joining, joiner, false);
    }

    /// A join of `joiner` of `target` returned: `joiner` no longer waits. A wait that was
    /// not this join's alone (several joins at once, `JoinWait::ANY_END`) is cleared all
    /// the same, and the joiner's lane is returned, to wake, so that its pending joins,
    /// polled again, register anew (one alone as the join of its own run, which the cycle
    /// check follows): else the wait in several joins would stay after a `select` of
    /// joins, and a cycle closed by a later join go unseen.
    pub(crate) fn join_returned(&mut self, joiner: SeqId, target: SeqId, runs: u16) -> LaneSet {
        let own = JoinWait::end_of(target, runs);
        self.stop_waiting(joiner, |wait| wait != JoinWait::NOTHING && wait != own)
    }

    /// A join of `joiner` was dropped while it waited (the loser of a `select`, an action
    /// aborted or restarted): `joiner` no longer waits. Another join of the same action
    /// may still be pending, of another run or of the same one, and nothing says which:
    /// the joiner's lane is returned, to wake, so that those register anew.
    pub(crate) fn join_dropped(&mut self, joiner: SeqId) -> LaneSet {
        self.stop_waiting(joiner, |wait| wait != JoinWait::NOTHING)
    }

    /// A run of `run`'s sequence after `run` has begun its action (its lane took its start,
    /// which it does only once `run` has unwound): a wait of the sequence is that run's.
    pub(crate) fn began_after(&self, run: RunId) -> bool {
        self.block(run.seq)
            .is_some_and(|b| b.runs != run.count && !b.has(flag::START_PENDING))
    }

    /// The run of `joiner` was aborted: its wait in a join, if any, is over (its join's
    /// future, dropped when the run unwinds, finds nothing left to clear).
    pub(crate) fn forget_wait(&mut self, joiner: SeqId) {
        if let Some(b) = self.block_mut(joiner) {
            b.joins = JoinWait::NOTHING;
        }
        self.sets.put(Set::Joining, joiner, false);
    }

    /// Clears `joiner`'s wait; its lane, to wake, if `wake` says so of the wait.
    fn stop_waiting(&mut self, joiner: SeqId, wake: impl FnOnce(JoinWait) -> bool) -> LaneSet {
        let Some(b) = self.block_mut(joiner) else {
            return LaneSet::EMPTY;
        };
        let woken = wake(b.joins);
        b.joins = JoinWait::NOTHING;
        let lane = b.lane;
        self.sets.put(Set::Joining, joiner, false);
        if woken {
            LaneSet::of(lane)
        } else {
            LaneSet::EMPTY
        }
    }

    /// What a join of `run` sees: `None` while that run is under way, else its outcome,
    /// which is kept while that run is the last one, ended, or the one before the run
    /// under way.
    pub(crate) fn joined_outcome(&self, run: RunId) -> Result<Option<Outcome>, Error> {
        let target = run.seq;
        let b = self.block(target).ok_or(Error::UnknownSequence(target))?;
        // Never with a run taken by `join_run` or a scoped start; a wait here would be for
        // good.
        if b.state == RunningState::Idle {
            return Err(Error::NeverStarted(target));
        }
        let under_way = b.state.is_active() || b.has(flag::START_PENDING);
        match (b.runs.wrapping_sub(run.count), under_way) {
            (0, true) => Ok(None),
            (0, false) | (1, true) => Ok(b.outcome),
            _ => Err(Error::OutcomeLost(target)),
        }
    }

    /// The sequences waiting in a join for the end of `target`'s run under way alone (one
    /// waiting in several joins at once is left out: it may go on at another end), and
    /// still running or paused: the join of a run that the tick aborted or restarted is
    /// over, although its future, which clears the wait when dropped, has not unwound yet.
    /// Nor is one whose start its lane has not taken: its run has not begun its action, and
    /// a wait is the last run's (registered after the abort of that run, which had
    /// looked at its clearance just before), until its lane unwinds that run.
    pub(crate) fn joiners_of(&self, target: SeqId) -> SeqSet<B> {
        let mut out = SeqSet::EMPTY;
        let Some(runs) = self.block(target).map(|b| b.runs) else {
            return out;
        };
        for j in self.sets.members(Set::Joining) {
            if self.block(j).is_some_and(|b| {
                b.joins == JoinWait::end_of(target, runs)
                    && RunningStates::RUNNING_OR_PAUSED.has(b.state)
                    && !b.has(flag::START_PENDING)
            }) {
                out.insert(j);
            }
        }
        out
    }

    /// The run `run` ended: every sequence waiting in a join for it is released (not those
    /// of a later run of the same sequence). Returns their lanes, to wake.
    pub(crate) fn release_joiners(&mut self, run: RunId) -> LaneSet {
        let mut lanes = LaneSet::EMPTY;
        for j in self.sets.members(Set::Joining) {
            let Some(b) = self.block_mut(j) else {
                continue;
            };
            if b.joins.released_by(run.seq, run.count) {
                b.joins = JoinWait::NOTHING;
                lanes = lanes.with(LaneSet::of(b.lane));
                self.sets.put(Set::Joining, j, false);
            }
        }
        lanes
    }
}
