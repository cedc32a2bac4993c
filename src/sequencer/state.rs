//! Everything the sequencer's lock guards, and the one way to a control block.

use crate::lock::Lock;
use crate::model::id::{Link, RunId};
use crate::model::set::{SeqSet, SetWord};
use crate::model::state::RunningStates;
use crate::model::time::{Micros48, Stamp};
use crate::sequencer::control_block::{flag, ControlBlock, NO_LANE};
use crate::sequencer::lanes::LaneSet;
use crate::sequencer::sets::{Set, Sets};
use crate::tick::schedule::Classes;
use crate::trace::{Entry, Event, Ring, StateChange};
use crate::{Error, Instant, RunningState, SeqId, Sequencer};

/// The sequencer's state: reached only through `Sequencer::borrow_state` (from
/// [`Sequencer::with`], `update_and_wake`, `park_in_then` and `close_lane`), under the
/// lock.
///
/// `repr(C)` in this order: the words and sets every section reads come first, the arrays
/// that grow with the capacities last, so that the hot fields stay within a load's
/// immediate offset of the base whatever `N` and `T` are.
#[repr(C)]
pub(crate) struct State<C, const N: usize, const T: usize, const W: usize, const B: usize> {
    /// The last tick's time.
    pub(crate) now: Instant,
    /// Counts the ticks, the transitions, a teardown's marks, abort requests and joins'
    /// registrations (wrapping). A start is scheduled in several sections; its commit
    /// compares this count with the one its schedule began with, and schedules again if
    /// anything happened in between that could invalidate its checks. A join's cycle check
    /// that found a cycle is made again when the count moved during it.
    pub(crate) changes: u32,
    /// Counts the runs begun (right after a start's or a restart's commit; wrapping): a
    /// teardown or a pause walks again when a run began while it walked.
    pub(crate) runs_begun: u32,
    /// The sequences as sets ([`Set`]): what the tick works on.
    pub(crate) sets: Sets<B>,
    /// When the tick must look at the sequences next.
    pub(crate) polling: Polling<B>,
    /// Exceptions whose sequence could not run (no lane, already running, too deep).
    pub(crate) exceptions_not_run: u16,
    /// The number of registered sequences: ids `0..count`.
    count: u16,
    /// The lane slots declared so far: slots `0..lanes_declared` (their wakers are in
    /// [`Sequencer::lanes`]).
    pub(crate) lanes_declared: u8,
    /// The first sequence whose lane future found all `W` lane slots taken: that lane
    /// never runs ([`Sequencer::check_lanes`](crate::Sequencer::check_lanes) names it).
    pub(crate) lane_refused: Link,
    /// The lane slots whose lane future was dropped (bit `l` for slot `l`): their sequence
    /// takes no start until a lane future waits in the slot again.
    pub(crate) lanes_closed: u32,
    /// This sequencer's tag, given at its first registration (0: none yet), unique among
    /// the first 65 535 sequencers of a program, and moving with it. A sequence object
    /// carries it, so that a lane or a blocking start refuses the object of another
    /// sequencer; so does the monitor table bound to it.
    pub(crate) tag: u16,
    blocks: [ControlBlock; N],
    /// Each sequence's cleanup hook (`SeqConfig::on_abort`).
    pub(crate) hooks: [Option<fn(&C)>; N],
    #[cfg(feature = "counters")]
    pub(crate) counters: [crate::Counters; N],
    /// The transition trace.
    pub(crate) trace: Ring<T>,
    /// Each sequence's run clock (`clock.rs`).
    pub(crate) clocks: [Micros48; N],
    /// Each sequence's restart limit of the monitor or timeout whose behaviour is pending
    /// (it waits for the end of its exception sequence), set with the pending behaviour:
    /// the behaviour is judged with it when applied. Beside the blocks rather than in
    /// them: the blocks are full to their alignment (docs/design-decisions.md).
    pub(crate) pending_restart_limits: [u8; N],
    /// The address of the monitor table this sequencer is ticked with (0: none yet): the
    /// first non-empty table a due tick came with. Due ticks with a table elsewhere are
    /// refused.
    pub(crate) monitor_table: usize,
}

/// When the tick must look again, and whom it woke last time.
pub(crate) struct Polling<const B: usize> {
    /// The polling classes: one schedule per distinct polling period.
    pub(crate) classes: Classes<B>,
    /// Earliest next poll of a class with a member under way (`NEVER_AHEAD` after the last
    /// scan when none has one).
    pub(crate) next_due: Stamp,
    /// The lanes the tick's last exit-condition wake-up woke, for reuse.
    pub(crate) woken: WakeMemo<B>,
    /// Counts the times `woken` was forgotten: with the portable lock the tick finds the
    /// lanes in sections of their own, and remembers them only if none changed meanwhile.
    pub(crate) forgets: u8,
    /// The classes whose grid a tick after a long gap has yet to restart (bit `i` for
    /// class `i`): their 32-bit next poll no longer tells ahead from behind. A start that
    /// places a class's grid anew clears its bit.
    pub(crate) stale: u8,
}

impl<const B: usize> Polling<B> {
    /// A sequence's lane or a lane's waker changed: the lanes remembered for the tick's
    /// wake-ups no longer hold.
    pub(crate) fn forget_woken(&mut self) {
        self.woken = WakeMemo::NONE;
        self.forgets = self.forgets.wrapping_add(1);
    }

    /// The lanes remembered for the due polls `polls`, if they are the last ones.
    pub(crate) fn remembered(&self, polls: SetWord<B>) -> Option<LaneSet> {
        (self.woken.polls == polls).then_some(self.woken.lanes)
    }
}

/// The lane slots woken for a set of due exit-condition polls (in one word of the sets):
/// in a steady state the set repeats from poll to poll, and the tick wakes the same lanes
/// again without visiting the sequences. Forgotten whenever a sequence's lane or a lane's
/// waker changes.
#[derive(Clone, Copy)]
pub(crate) struct WakeMemo<const B: usize> {
    /// The polls (never empty while the memo is valid).
    pub(crate) polls: SetWord<B>,
    /// Their lane slots, one per distinct waker.
    pub(crate) lanes: LaneSet,
}

impl<const B: usize> WakeMemo<B> {
    pub(crate) const NONE: Self = WakeMemo {
        polls: SetWord::empty(0),
        lanes: LaneSet::EMPTY,
    };
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Nothing registered, time 0.
    pub(crate) const fn new() -> Self {
        State {
            now: Instant::from_ticks(0),
            changes: 0,
            runs_begun: 0,
            sets: Sets::EMPTY,
            polling: Polling {
                classes: Classes::new(),
                next_due: Stamp(0),
                woken: WakeMemo::NONE,
                forgets: 0,
                stale: 0,
            },
            exceptions_not_run: 0,
            count: 0,
            lanes_declared: 0,
            lane_refused: Link::NONE,
            lanes_closed: 0,
            tag: 0,
            blocks: [ControlBlock::UNREGISTERED; N],
            hooks: [None; N],
            #[cfg(feature = "counters")]
            counters: [crate::Counters::ZERO; N],
            trace: Ring::new(),
            clocks: [Micros48::ZERO; N],
            pending_restart_limits: [0; N],
            monitor_table: 0,
        }
    }

    /// The control block of registered sequence `id` (`None`: not registered).
    #[inline]
    pub(crate) fn block(&self, id: SeqId) -> Option<&ControlBlock> {
        if u16::from(id.0) >= self.count {
            return None;
        }
        self.blocks.get(id.index())
    }

    /// The control block of registered sequence `id`, to change.
    #[inline]
    pub(crate) fn block_mut(&mut self, id: SeqId) -> Option<&mut ControlBlock> {
        if u16::from(id.0) >= self.count {
            return None;
        }
        self.blocks.get_mut(id.index())
    }

    /// The number of registered sequences.
    pub(crate) fn count(&self) -> usize {
        usize::from(self.count)
    }

    /// The running state of `id` (`Idle` for an id not registered).
    #[inline]
    pub(crate) fn state_of(&self, id: SeqId) -> RunningState {
        self.block(id).map_or(RunningState::Idle, |b| b.state)
    }

    /// Registers `block` and its cleanup hook under the next id.
    pub(crate) fn push_block(
        &mut self,
        block: ControlBlock,
        hook: Option<fn(&C)>,
    ) -> Result<SeqId, Error> {
        if self.count() >= N {
            return Err(Error::SequenceCapacityExceeded);
        }
        let id = SeqId::from_index(self.count());
        let (Some(b), Some(h)) = (
            self.blocks.get_mut(id.index()),
            self.hooks.get_mut(id.index()),
        ) else {
            return Err(Error::SequenceCapacityExceeded);
        };
        *b = block;
        *h = hook;
        self.count = self.count.saturating_add(1);
        Ok(id)
    }

    /// Writes the block and hook of `id` ahead of a [`commit_count`](Self::commit_count)
    /// that makes them visible (a table's install): nothing reads a block at or above
    /// `count`.
    pub(crate) fn prepare_block(&mut self, id: SeqId, block: ControlBlock, hook: Option<fn(&C)>) {
        if let (Some(b), Some(h)) = (
            self.blocks.get_mut(id.index()),
            self.hooks.get_mut(id.index()),
        ) {
            *b = block;
            *h = hook;
        }
    }

    /// Makes the first `count` prepared blocks visible at once (at most `N`).
    pub(crate) fn commit_count(&mut self, count: usize) {
        self.count = u16::try_from(count.min(N)).unwrap_or(u16::MAX);
    }

    /// The registered blocks, by id.
    pub(crate) fn registered(&self) -> impl Iterator<Item = &ControlBlock> {
        self.blocks.iter().take(self.count())
    }

    /// The lane slot that drives `id` (`NO_LANE`: none).
    #[inline]
    pub(crate) fn lane_slot(&self, id: SeqId) -> u8 {
        self.block(id).map_or(NO_LANE, |b| b.lane)
    }

    /// The lane that drives `id`, as a set to wake.
    #[inline]
    pub(crate) fn lane_of(&self, id: SeqId) -> LaneSet {
        LaneSet::of(self.lane_slot(id))
    }

    /// Folds the state of sequence `id` into the sets `Monitored`, `Paused` and `Live`.
    pub(crate) fn fold(&mut self, id: SeqId) {
        let state = self.state_of(id);
        self.sets.put(
            Set::Monitored,
            id,
            RunningStates::RUNNING_OR_PAUSED.has(state),
        );
        self.sets
            .put(Set::Paused, id, state == RunningState::Paused);
        self.sets.put(Set::Live, id, RunningStates::LIVE.has(state));
    }

    /// Whether `id` is an exception sequence whose run ended: the tick then reports the end
    /// to its owner ([`exception_ended`](Self::exception_ended)). Until then it keeps its
    /// owner and may not be started again ([`ControlBlock::may_start`]), so no later run of
    /// it, for another owner, can be credited with this end.
    pub(crate) fn exception_run_ended(&self, id: SeqId) -> bool {
        self.block(id)
            .is_some_and(|b| !RunningStates::LIVE.has(b.state) && b.has(flag::HANDLES_EXCEPTION))
    }

    /// The current (or last) run of `id` (count 0 for an id not registered).
    pub(crate) fn current_run(&self, id: SeqId) -> RunId {
        RunId {
            seq: id,
            count: self.block(id).map_or(0, |b| b.runs),
        }
    }

    /// The sequences whose run may be under way: with one word every registered one (a
    /// word is cheap to walk), with several those live at the tick's last fold
    /// (`Set::Live`) and those changed since (`Set::Changed`).
    pub(crate) fn maybe_under_way(&self) -> SeqSet<B> {
        if B == 1 {
            SeqSet::first(self.count())
        } else {
            self.sets
                .members(Set::Live)
                .union(&self.sets.members(Set::Changed))
        }
    }

    /// The run of exception sequence `id` ended: its owner's pending behaviour is applied
    /// by this tick or the next, if it waits for this sequence (else the owner's run or
    /// round it handled an exception of went down with it, and a later one may wait for
    /// another).
    pub(crate) fn exception_ended(&mut self, id: SeqId) {
        let Some(b) = self.block_mut(id) else {
            return;
        };
        b.set(flag::HANDLES_EXCEPTION, false);
        let owner = b.caller.get();
        if let Some(o) = owner {
            // Only to a behaviour pending now: `awaited` stays when a new run or a restart
            // drops the behaviour, and a credit without one would be taken by the next
            // behaviour of the owner (with the same exception sequence, started again
            // once this end is reported) before its own exception sequence ended.
            let this = Link::to(Some(id));
            if let Some(ob) = self
                .block_mut(o)
                .filter(|ob| ob.pending().is_some() && ob.awaited == this)
            {
                ob.set(flag::EXCEPTION_DONE, true);
                self.sets.insert(Set::Requested, o);
            }
        }
    }

    /// Records `event` in the trace at the last tick's time. One copy for every kind of
    /// event: the callers only build the event.
    #[inline(never)]
    pub(crate) fn record(&mut self, event: Event) {
        self.trace.push(self.now, Entry::Event(event));
    }

    /// THE transition function: every state change goes through here. Makes `change` if
    /// the sequence is in state `change.from`, records it at the current time (the trace,
    /// the counters, the set of changed sequences) and returns the block for the caller's
    /// bookkeeping in the same section. Otherwise changes nothing and returns `None`.
    ///
    /// Callers read `change.from` in an earlier section and pick a change the transition
    /// table allows ([`RunningState::can_transition_to`](crate::RunningState::can_transition_to);
    /// tests/properties.rs checks every recorded change against it); a state that changed
    /// in between fails here. The sequence is one callers
    /// found registered (an unregistered slot is `Idle`, and only a start, which checks
    /// registration, leaves `Idle`). Inline: it is the bulk of the sections that make a
    /// transition, which must stay short.
    #[inline]
    pub(crate) fn transition(&mut self, change: &StateChange) -> Option<&mut ControlBlock> {
        self.transition_if(change, |_| true)
    }

    /// As [`transition`](Self::transition), only if the sequence's block also satisfies
    /// `allowed` (read in the same section, with the state).
    #[inline]
    pub(crate) fn transition_if(
        &mut self,
        change: &StateChange,
        allowed: impl FnOnce(&ControlBlock) -> bool,
    ) -> Option<&mut ControlBlock> {
        let id = change.sequence;
        // The field itself, not `block_mut`: the block stays borrowed while the sets and
        // the trace, the state's other fields, are written. `block_mut`'s registration
        // check is not needed: an unregistered slot is `Idle`, which no change leaves
        // but a start's, and a start checks registration (see above).
        let b = self.blocks.get_mut(id.index())?;
        if b.state != change.from || !allowed(b) {
            return None;
        }
        b.state = change.to;
        self.changes = self.changes.wrapping_add(1);
        self.sets.insert(Set::Changed, id);
        self.trace.push(
            self.now,
            Entry::Transition {
                sequence: change.sequence,
                from: change.from,
                to: change.to,
                cause: change.cause,
            },
        );
        #[cfg(feature = "counters")]
        if let Some(c) = self.counters.get_mut(id.index()) {
            c.count(change.from, change.to, change.cause);
        }
        Some(b)
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// The last tick's time.
    ///
    /// ```
    /// use rtseq::{Instant, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.tick(Instant::from_ticks(2_000), &(), &mut Monitors::<(), 1>::new()).unwrap();
    /// assert_eq!(seq.now(), Instant::from_ticks(2_000));
    /// ```
    pub fn now(&self) -> Instant {
        self.with(|s| s.now)
    }

    /// Exceptions whose sequence could not run (it had no lane, was already running, or
    /// would nest too deep) while their owner's run was under way; their behaviour was
    /// applied at once (a `PauseOwner` monitor's hold pauses without it). One whose run
    /// ended, or began its stop, first went with the run and is not counted.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// assert_eq!(seq.exceptions_not_run(), 0);
    /// ```
    pub fn exceptions_not_run(&self) -> u16 {
        self.with(|s| s.exceptions_not_run)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembered_lanes_hold_until_forgotten() {
        let mut p = Polling::<1> {
            classes: Classes::new(),
            next_due: Stamp(0),
            woken: WakeMemo::NONE,
            forgets: 0,
            stale: 0,
        };
        let polls = SetWord::<1>::new(0, 0b101);
        // Nothing remembered: not even for no polls of word 0.
        assert_eq!(p.remembered(polls), None);
        let lanes = LaneSet::of(3);
        p.woken = WakeMemo { polls, lanes };
        assert_eq!(p.remembered(polls), Some(lanes));
        assert_eq!(p.remembered(SetWord::new(0, 0b100)), None);
        // A changed lane or waker forgets them and counts it (the portable tick compares
        // the count before and after its walk).
        p.forget_woken();
        assert_eq!((p.remembered(polls), p.forgets), (None, 1));
    }
}
