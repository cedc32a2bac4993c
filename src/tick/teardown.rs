//! Teardowns and pauses: a sequence and the sequences below it are aborted (innermost
//! first, each through `Aborting` and its cleanup hook), restarted, paused or resumed
//! (outermost first), one short section at a time.

use crate::lock::Lock;
use crate::model::id::Link;
use crate::model::set::SeqSet;
use crate::model::state::States;
use crate::model::time::Stamp;
use crate::sequencer::control_block::flag;
use crate::sequencer::lanes::LaneSet;
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::tick::skip_untaken_polls;
use crate::trace::StateChange;
use crate::{Cause, RunningState, SeqId, Sequencer, MAX_DEPTH};

/// The depths a sequence can have (0 to `MAX_DEPTH` callers).
const DEPTHS: usize = MAX_DEPTH + 1;

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Moves `target` and the sequences below it (every active sequence without a target)
    /// to `to`, one at a time, for `cause`: the one walk of teardowns and pauses.
    ///
    /// * `Aborting` or `Restarting`: aborts `target` and every active sub-sequence of it
    ///   (blocking and non-blocking), innermost first, each through `Aborting` (cleanup
    ///   hook) to `Aborted`; with `Restarting`, the target itself goes to `Restarting`
    ///   instead.
    /// * `Paused` (`Running`): pauses (resumes) a running (paused) `target` and the
    ///   sequences it blocks in its lane, outermost first.
    ///
    /// The walk places the sequences, then moves them one at a time; between two of its
    /// sections a lane of higher priority (or, in a lane's walk, the tick) may start a run
    /// below a sequence it has not reached yet, or move a sequence it placed before it gets
    /// there (a restart, an end). So it walks again while a pass was disturbed (see
    /// [`Pass`]): nothing started below a sequence outlives its teardown, and a teardown's
    /// target moves once, so a restarted target's new round is left alone.
    pub(crate) fn walk(&self, control: &C, target: Option<SeqId>, to: RunningState, cause: Cause) {
        // A teardown pass is disturbed by a sequence below the target that its own lane
        // moved (an end, or taking up a restart made before the walk: at most twice per
        // sequence), or by a run begun before the pass had marked what it placed.
        // A pause's (resume's) first pass moves its target from the state it leaves; a
        // pass again, for a run begun below the target during the last one, finds the
        // target in the state it entered and moves only what began below it.
        let mut target_in = left_by(to);
        for _ in 0..=2 * N {
            let begun = self.with(|s| s.runs_begun);
            if self.walk_once(control, target, to, cause, begun, target_in) == Pass::Done {
                return;
            }
            target_in = to;
        }
        // Disturbed every time (parties above the walker beginning runs without a pause):
        // the target, which a disturbed pass leaves in place, still moves, so no teardown
        // is lost.
        if let (Some(t), false) = (
            target,
            matches!(to, RunningState::Paused | RunningState::Running),
        ) {
            self.stop(control, t, cause, States::entering(to), to);
        }
    }

    /// One pass of [`walk`](Self::walk), begun when [`State::runs_begun`] was `begun`; a
    /// pause's or resume's target is in `target_in` (else the pass is done).
    #[inline(never)]
    fn walk_once(
        &self,
        control: &C,
        target: Option<SeqId>,
        to: RunningState,
        cause: Cause,
        begun: u32,
        target_in: RunningState,
    ) -> Pass {
        let pause = matches!(to, RunningState::Paused | RunningState::Running);
        let from = left_by(to);
        let (states, lane) = if pause {
            let Some(lane) = target.and_then(|t| {
                self.with(|s| s.block(t).filter(|b| b.state == target_in).map(|b| b.lane))
            }) else {
                return Pass::Done;
            };
            (States::of(from), Some(lane))
        } else {
            // Active, not already `Aborting`.
            (States::entering(RunningState::Aborting), None)
        };
        if let (RunningState::Paused, Some(lane)) = (to, lane) {
            // The target is paused first and the sequences it blocks after it.
            in_sections!(self, |s| {
                let due = s.section(|s| s.sets.words(Set::PollDue));
                skip_untaken_polls(s, lane, due);
            });
        }
        // A restart restarts its target (from `Running` or `Paused`) and aborts the
        // sequences below it.
        let move_one = |id: SeqId| match to {
            RunningState::Restarting if Some(id) == target => {
                self.stop(control, id, cause, States::entering(to), to)
            }
            RunningState::Restarting => {
                self.stop(control, id, cause, states, RunningState::Aborting)
            }
            _ => self.stop(control, id, cause, states, to),
        };
        // A teardown's target is marked first (it starts nothing from now on); a sequence
        // below it has a caller link: when no other sequence has one, the target is all
        // there is to move.
        if let (false, Some(t)) = (pause, target) {
            let alone = self.with(|s| {
                s.mark_stopping(t);
                s.sets.none_but(Set::Called, t)
            });
            if alone {
                return Pass::of(!move_one(t));
            }
        }
        // A teardown marks what it places, in the section that finds the run it looked at
        // still under way: the mark is that run's (a new run's commit clears it), and only
        // a marked sequence moves (`leave`). A pause marks nothing.
        let (rows, deepest) = self.levels(target, states, lane, &mut |id, runs| {
            pause || self.with(|s| s.mark_placed(id, runs, states))
        });
        // A teardown's pass is disturbed like a lost race by a run begun before it marked
        // what it placed: the run may not be placed, and is in the next pass.
        let mut raced = false;
        if target.is_some() && !pause {
            raced = self.with(|s| s.runs_begun) != begun;
        }
        for k in 0..=deepest {
            // Pauses outermost first, teardowns innermost first.
            let depth = if pause { k } else { deepest - k };
            for id in rows.get(depth).copied().unwrap_or_default() {
                // A teardown's target moves last, and only in a pass in which everything
                // below it moved: once it moved, its lane may take up a restart, and what
                // begins then is its new round's.
                if raced && Some(id) == target {
                    return Pass::Again;
                }
                // A resume of the target resumes the sequences it blocks unless something
                // else holds them (outermost first: one kept paused keeps those below it).
                let kept = to == RunningState::Running
                    && Some(id) != target
                    && self.with(|s| s.stays_paused(id));
                if !kept {
                    raced |= move_one(id);
                }
            }
        }
        // Below a teardown's target nothing began (it is all marked); a pause or an
        // abort-all walks again for a run begun during the pass (a blocking start below a
        // sequence not paused yet, a start anywhere).
        let begun_below = (target.is_none() || pause) && self.with(|s| s.runs_begun) != begun;
        Pass::of(!raced && !begun_below)
    }

    /// A run of `id` was dropped before it ended: it and every sequence below it are
    /// aborted ([`Cause::Dropped`]). This walk runs in a lane: the tick may preempt it,
    /// and so may a lane of higher priority that it wakes (by a cleanup hook, or by
    /// handing an abort up).
    pub(crate) fn abort_dropped(&self, control: &C, id: SeqId) {
        // A run of `id` begun during the walk (its start came once the dropped run was
        // aborted) is one that no future will take: the dropped future held the object.
        // It is aborted too.
        for _ in 0..N {
            let runs = self.with(|s| s.block(id).map(|b| b.runs));
            self.walk(control, Some(id), RunningState::Aborting, Cause::Dropped);
            if self.with(|s| s.block(id).map(|b| b.runs)) == runs {
                return;
            }
        }
    }

    /// Moves one sequence from a state in `states` (states `to` may be entered from) to
    /// `to`: to `Aborting → Aborted` or to `Restarting`, running its hook; or pauses or
    /// resumes it (`Paused`, `Running`). True when it lost a race: the sequence was in
    /// `states`, but another transition came between the look and the move.
    fn stop(&self, control: &C, id: SeqId, cause: Cause, states: States, to: RunningState) -> bool {
        // With a coarse lock, the steps before the hook in one section and those after it
        // in another: the tick runs at the ceiling, so a longer section delays no one.
        let hook = match in_sections!(self, |s| leave(s, id, cause, states, to)) {
            Leave::Left(hook) => hook,
            Leave::Stays => return false,
            Leave::Raced => return true,
        };
        if let Some(h) = hook {
            h(control);
        }
        in_sections_then_wake!(self, |s| {
            let mut lanes = LaneSet::EMPTY;
            if to == RunningState::Aborting {
                // A blocking sequence's run is dropped by its aborted caller and
                // never reports back, so the outcome is recorded here.
                let change = StateChange::new(id, to, RunningState::Aborted, cause);
                let aborted = s.section(|s| {
                    let b = s.transition(&change)?;
                    b.outcome = Some(crate::Outcome::Aborted(cause));
                    Some(())
                });
                if aborted.is_some() {
                    lanes = s.section(|s| s.release_joiners(id));
                }
            }
            lanes.with(s.section(|s| s.lane_of(id)))
        });
        false
    }

    /// For a teardown or a pause: the sequences that are `target` or below it (every one
    /// without a target) whose state is in `states` and, with a `lane`, that run in that
    /// lane, by depth (outermost first, ids ascending in each row), and the deepest row
    /// that has one.
    ///
    /// Only the sequences that can qualify are visited: below a target, the target and
    /// those with a caller link (`Called`; a sequence below another one has one); without
    /// a target, every one whose run may be under way (with several words `Live` as of
    /// the last fold and those `Changed` since, else every registered one). Each is placed
    /// by walking its caller links up (a non-blocking child may outlive its caller and
    /// still link to it): with a coarse lock in one section, else one short section per
    /// step. The tree may change meanwhile: each change made from the rows is re-checked
    /// where it is made, and a run begun meanwhile makes [`walk`](Self::walk) walk again.
    fn levels(
        &self,
        target: Option<SeqId>,
        states: States,
        lane: Option<u8>,
        keep: &mut dyn FnMut(SeqId, u16) -> bool,
    ) -> ([SeqSet<B>; DEPTHS], usize) {
        let candidates = self.with(|s| match target {
            Some(t) => s.sets.members(Set::Called).with(t),
            None if B == 1 => SeqSet::first(s.count()),
            None => s
                .sets
                .members(Set::Live)
                .union(&s.sets.members(Set::Changed)),
        });
        let mut rows = [SeqSet::EMPTY; DEPTHS];
        let mut deepest = 0;
        for id in candidates {
            let found = in_sections!(self, |s| depth_below(s, id, target, states, lane));
            let Some((depth, runs)) = found else {
                continue;
            };
            if let (Some(row), true) = (rows.get_mut(depth), keep(id, runs)) {
                row.insert(id);
                deepest = deepest.max(depth);
            }
        }
        (rows, deepest)
    }
}

/// The state a pause (`to`: `Paused`) or a resume (`Running`) moves its sequences from.
fn left_by(to: RunningState) -> RunningState {
    if to == RunningState::Paused {
        RunningState::Running
    } else {
        RunningState::Paused
    }
}

/// Where [`Sequencer::levels`] places `id`: its depth (its number of callers, at most
/// `MAX_DEPTH`) when its state is in `states`, it runs in `lane` (if given) and it is
/// `target` or below it (every one without a target), with the count of the run looked
/// at; else `None`.
fn depth_below<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    target: Option<SeqId>,
    states: States,
    lane: Option<u8>,
) -> Option<(usize, u16)> {
    let (mut up, runs) = s.section(|s| {
        let b = s.block(id)?;
        let ok = states.has(b.state) && lane.is_none_or(|l| l == b.lane);
        ok.then_some((b.caller, b.runs))
    })?;
    let mut below = target.is_none_or(|t| t == id);
    let mut depth = 0;
    while let Some(at) = up.get() {
        if depth == MAX_DEPTH {
            break;
        }
        below |= target == Some(at);
        depth += 1;
        up = s.section(|s| s.block(at).map_or(Link::NONE, |b| b.caller));
    }
    below.then_some((depth, runs))
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// A teardown placed `id` when its run `runs` was in `states`: if that run is still
    /// under way there, it is marked ([`mark_stopping`](Self::mark_stopping)). False when
    /// it ended meanwhile, or another run began: that one is not this teardown's.
    fn mark_placed(&mut self, id: SeqId, runs: u16, states: States) -> bool {
        let placed = self
            .block(id)
            .is_some_and(|b| b.runs == runs && states.has(b.state));
        if placed {
            self.mark_stopping(id);
        }
        placed
    }

    /// A teardown placed `id`: it starts nothing until it is moved ([`flag::STOPPING`]).
    /// Counted as a change, so a start by it that was scheduled before is scheduled again,
    /// and refused ([`State::changes`]).
    fn mark_stopping(&mut self, id: SeqId) {
        if let Some(b) = self.block_mut(id) {
            b.set(flag::STOPPING, true);
            self.changes = self.changes.wrapping_add(1);
        }
    }
}

/// How a pass of [`Sequencer::walk`] ended.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Pass {
    /// Everything it placed moved, and nothing it should have placed began meanwhile.
    Done,
    /// A move lost a race to another transition, or a run began that the pass did not
    /// place: walk again.
    Again,
}

impl Pass {
    fn of(done: bool) -> Pass {
        if done {
            Pass::Done
        } else {
            Pass::Again
        }
    }
}

/// What [`leave`] did.
enum Leave<C> {
    /// Left its state, with the hook to run (set at registration; none for a pause or
    /// resume).
    Left(Option<fn(&C)>),
    /// Not in the states it would leave: nothing to do.
    Stays,
    /// In those states when looked at, but another transition came before the move.
    Raced,
}

/// The steps of [`Sequencer::stop`] before the hook: `id` leaves a state in `states` for
/// `to` (a paused timeout keeps its remaining time).
fn leave<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    cause: Cause,
    states: States,
    to: RunningState,
) -> Leave<C> {
    let pause = matches!(to, RunningState::Paused | RunningState::Running);
    // Before a teardown, what it leaves behind: the cause a later gate reports; after an
    // abort no pending request and no start left for its lane to take (the run is over
    // before it began: nothing of it must look under way; a restart goes on with the same
    // run, which keeps the requests made of it); and the hook.
    let looked = s.section(|s| {
        let b = s.block_mut(id).ok_or(Leave::Stays)?;
        let from = b.state;
        if !states.has(from) {
            return Err(Leave::Stays);
        }
        if pause {
            return Ok((from, None));
        }
        // A teardown moves only a run it marked (`walk_once`): without its mark, the run
        // it marked ended and a new one began, or another teardown moved it meanwhile.
        if !b.has(flag::STOPPING) {
            return Err(Leave::Raced);
        }
        b.last_cause = cause;
        if to == RunningState::Aborting {
            b.drop_requests();
            b.set(flag::START_PENDING, false);
        }
        Ok((from, s.hooks.get(id.index()).copied().flatten()))
    });
    let (from, hook) = match looked {
        Ok(found) => found,
        Err(other) => return other,
    };
    let change = StateChange::new(id, from, to, cause);
    let moved = if pause {
        s.section(|s| s.transition(&change).is_some())
    } else {
        s.section(|s| {
            // The mark may be gone as in the look above: the next pass marks what is there
            // then. (A pause keeps a teardown's mark: the teardown still moves the paused
            // run.)
            let moved = s.transition_if(&change, |b| b.has(flag::STOPPING));
            // A restarted run is no longer being stopped: its new round starts runs. (An
            // aborted one starts nothing, marked or not, and a new run clears the mark.)
            moved
                .map(|b| {
                    if to == RunningState::Restarting {
                        b.set(flag::STOPPING, false);
                    }
                })
                .is_some()
        })
    };
    if !moved {
        return Leave::Raced;
    }
    if pause {
        // The run's clock (and its timeout) stops while paused, and a due poll its lane has
        // not taken yet is skipped, not taken when the pause ends (semantics 1).
        s.section(|s| {
            let now = Stamp::of(s.now);
            if let Some(b) = s.block_mut(id) {
                b.flip_clock(now);
            }
            if to == RunningState::Paused {
                s.sets.remove(Set::PollDue, id);
            }
        });
    }
    Leave::Left(hook)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    extern crate std;
    use std::boxed::Box;
    use std::cell::RefCell;

    use crate::lock::interleaved::{self, Interleaved};
    use crate::sequencer::port::Port;
    use crate::sequencer::start::Mode;
    use crate::{
        Behaviour, Cause, Instant, Monitor, Monitors, RunningState, SeqConfig, SeqId, Sequencer,
    };

    std::thread_local! {
        /// What runs between two sections of the walk (at X's cleanup hook): a lane of
        /// higher priority, woken by the walk, preempting it.
        static BETWEEN: RefCell<Option<Box<dyn FnOnce()>>> = RefCell::new(None);
    }

    fn between(_: &()) {
        if let Some(f) = BETWEEN.with(|b| b.borrow_mut().take()) {
            f();
        }
    }

    /// R (lane of priority 1) started Y non-blocking (its lane, priority 2), and Y runs X
    /// blocking in its lane. R's run is dropped: the walk tears R's tree down innermost
    /// first, X, then Y, then R. After X's stop, Y's lane is woken and, of higher priority,
    /// preempts the walk: X's run hands `Err(Aborted(Dropped))` to Y, still running, whose
    /// action starts G (a fallback). G's start is made while Y runs, but the walk placed Y
    /// before: Y is being stopped and starts nothing (`NotRunning`), so nothing it starts
    /// outlives its abort (semantics 9); G is not started and then torn down by a second
    /// walk.
    #[test]
    fn a_start_made_below_a_dropped_run_while_its_walk_is_preempted_does_not_outlive_it() {
        let seq: &'static Sequencer<(), 8> = Box::leak(Box::new(Sequencer::new()));
        let r = seq.register(SeqConfig::new("R")).unwrap();
        let y = seq.register(SeqConfig::new("Y")).unwrap();
        let x = seq.register(SeqConfig::new("X").on_abort(between)).unwrap();
        let g = seq.register(SeqConfig::new("G")).unwrap();
        for id in [r, y, g] {
            seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        }
        seq.sequence_by_id(r).unwrap().start().unwrap();
        let run = |id: SeqId| seq.with(|s| s.current_run(id));
        Port::start_in_lane(seq, y, Some(run(r))).unwrap();
        seq.begin(
            x,
            Mode::Blocking {
                caller: run(y),
                maker: 0,
            },
            Cause::Start,
        )
        .unwrap();
        let state = |id: SeqId| seq.with(|s| s.state_of(id));
        assert_eq!(
            [r, y, x, g].map(state),
            [
                RunningState::Running,
                RunningState::Running,
                RunningState::Running,
                RunningState::Idle
            ]
        );
        let fallback = std::rc::Rc::new(RefCell::new(None));
        let result = fallback.clone();
        BETWEEN.with(|b| {
            *b.borrow_mut() = Some(Box::new(move || {
                // Y's lane: Y is still running, its child X was aborted; it starts G.
                *result.borrow_mut() = Some(Port::start_in_lane(seq, g, Some(run(y))));
            }))
        });
        Port::abandon(seq, r, &());
        assert_eq!(
            [r, y, x].map(state),
            [
                RunningState::Aborted,
                RunningState::Aborted,
                RunningState::Aborted
            ]
        );
        // Y, still running but being stopped, started nothing.
        assert_eq!(*fallback.borrow(), Some(Err(crate::Error::NotRunning(y))));
        assert_eq!(state(g), RunningState::Idle);
    }

    /// O, a main sequence with nothing below it, has an `AbortOwner` monitor with
    /// exception sequence E. O's run is dropped (its lane's future is dropped):
    /// `abort_dropped` walks O. Nothing has a caller link, so the walk takes its shortcut:
    /// one section to see that, then O's stop, and no second walk. The tick preempts the
    /// lane between the two: O, still running, has its monitor fire, and the tick starts E
    /// below O (caller O). Nothing started below a sequence outlives its abort (semantics
    /// 9): E must be aborted with O (`Dropped`). A walk that returned after O's stop,
    /// without looking again, would leave E running below the aborted O.
    #[test]
    fn an_exception_sequence_the_tick_starts_during_a_dropped_runs_shortcut_walk_is_torn_down() {
        let seq: &'static Sequencer<(), 4, 64, Interleaved> =
            Box::leak(Box::new(Sequencer::empty()));
        let [o, e] = ["O", "E"].map(|n| seq.register(SeqConfig::new(n)).unwrap());
        for id in [o, e] {
            seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        }
        seq.sequence_by_id(o).unwrap().start().unwrap();
        let waker = core::task::Waker::noop();
        assert!(Port::take_start(seq, o, 0, waker).is_some());
        // The tick, between the walk's first section (nothing linked) and O's stop.
        interleaved::at(1, move || {
            let mut fault = |_: &(), _: Instant| true;
            let mut monitors = Monitors::<(), 1>::new();
            monitors
                .add(
                    o,
                    Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(e),
                )
                .unwrap();
            seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
                .unwrap();
        });
        Port::abandon(seq, o, &());
        let state = |id: SeqId| seq.with(|s| (s.state_of(id), s.block(id).unwrap().last_cause));
        // E was started below O by the tick ...
        assert_eq!(
            seq.with(|s| s.block(e).and_then(|b| b.caller.get())),
            Some(o)
        );
        // ... and is torn down with it.
        assert_eq!(
            [o, e].map(state),
            [
                (RunningState::Aborted, Cause::Dropped),
                (RunningState::Aborted, Cause::Dropped)
            ]
        );
    }
}
