//! Teardowns: a sequence and every sequence below it are aborted (innermost first, each
//! through `Aborting` and its cleanup hook) or restarted (the target restarts, those below
//! it are aborted); an abort-all aborts every active sequence; a run whose future was
//! dropped is aborted with what is below it. In sections (with the portable lock, one
//! short section per step), the cleanup hooks between them.

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::flag;
use crate::sequencer::lanes::LaneSet;
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::tick::walk::{Pass, Scope};
use crate::trace::StateChange;
use crate::{Cause, RunningState, SeqId, Sequencer};

/// What a teardown tears down. A target is a run: what was decided on one run (a monitor
/// that fired on it, a request made of it) does nothing to a later run of its sequence,
/// which a lane of higher priority may start before the teardown's first section.
#[derive(Clone, Copy)]
enum Teardown {
    /// The run and everything below it are aborted.
    Abort(RunId),
    /// The run restarts; everything below it is aborted.
    Restart(RunId),
    /// Every active sequence is aborted.
    AbortAll,
}

impl Teardown {
    /// The run whose subtree is torn down (none: every active sequence).
    const fn target(self) -> Option<RunId> {
        match self {
            Teardown::Abort(t) | Teardown::Restart(t) => Some(t),
            Teardown::AbortAll => None,
        }
    }

    /// How the target is stopped.
    const fn target_stop(self) -> Stop {
        match self {
            Teardown::Restart(_) => Stop::Restart,
            Teardown::Abort(_) | Teardown::AbortAll => Stop::Abort,
        }
    }
}

/// How a teardown stops one sequence.
#[derive(Clone, Copy)]
enum Stop {
    /// Through `Aborting` (its cleanup hook) to `Aborted`: the run is over. Its pending
    /// pause or resume and a start not taken yet go with it.
    Abort,
    /// To `Restarting` (its cleanup hook): its lane runs it again from its pre-condition,
    /// the same run, which keeps the requests made of it and starts runs again.
    Restart,
}

impl Stop {
    /// The state the sequence enters.
    const fn to(self) -> RunningState {
        match self {
            Stop::Abort => RunningState::Aborting,
            Stop::Restart => RunningState::Restarting,
        }
    }
}

/// What the first steps of a teardown's move of one sequence did.
enum Move<T> {
    /// It left its state; `T` is what the move goes on with.
    Left(T),
    /// Not in the states it would leave: nothing to do.
    Stays,
    /// In those states when looked at, but another transition came before the move.
    Raced,
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Aborts the run `target` and every active sequence below it (blocking and
    /// non-blocking), innermost first, each through `Aborting` (cleanup hook) to
    /// `Aborted`, for `cause`. Nothing, once `target` is no longer its sequence's run.
    pub(crate) fn tear_down(&self, control: &C, target: RunId, cause: Cause) {
        self.teardown(control, Teardown::Abort(target), cause);
    }

    /// Restarts the run `target` (from `Running` or `Paused`: its lane runs it again from
    /// its pre-condition) and aborts every active sequence below it, innermost first.
    /// Nothing, once `target` is no longer its sequence's run.
    pub(crate) fn restart_tree(&self, control: &C, target: RunId, cause: Cause) {
        self.teardown(control, Teardown::Restart(target), cause);
    }

    /// Aborts every active sequence, innermost first ([`Cause::AbortAll`]). False when
    /// every pass was disturbed (cleanup hooks, or parties above the tick, starting runs
    /// without a pause): runs may be left, and the abort-all is to be carried out again.
    pub(crate) fn abort_every_run(&self, control: &C) -> bool {
        self.teardown(control, Teardown::AbortAll, Cause::AbortAll)
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
            let run = self.with(|s| s.current_run(id));
            self.tear_down(control, run, Cause::Dropped);
            if self.with(|s| s.current_run(id)) == run {
                return;
            }
        }
    }

    /// The passes of a teardown. The walk places the sequences, then moves them one at a
    /// time; between two of its sections a lane of higher priority (or, in a lane's walk,
    /// the tick) may start a run below a sequence it has not reached yet, or move a
    /// sequence it placed before it gets there (a restart, an end). So it walks again
    /// while a pass was disturbed (see [`Pass`]): nothing started below a sequence outlives
    /// its teardown, and the target moves once, so a restarted target's new round is left
    /// alone. Returns whether a pass went undisturbed.
    fn teardown(&self, control: &C, teardown: Teardown, cause: Cause) -> bool {
        // A pass is disturbed by a sequence below the target that its own lane moved (an
        // end, or taking up a restart made before the walk: at most twice per sequence),
        // or by a run begun before the pass had marked what it placed.
        for _ in 0..=2 * N {
            let begun = self.with(|s| s.runs_begun);
            if self.teardown_pass(control, teardown, cause, begun) == Pass::Done {
                return true;
            }
        }
        // Disturbed every time (parties above the walker beginning runs without a pause):
        // the target, which a disturbed pass leaves in place, still moves, so no teardown
        // is lost. An abort-all has no target: its caller carries it out again.
        if let Some(t) = teardown.target() {
            self.stop(control, t.seq, cause, teardown.target_stop());
        }
        false
    }

    /// One pass of a teardown, begun when [`State::runs_begun`] was `begun`.
    #[inline(never)]
    fn teardown_pass(&self, control: &C, teardown: Teardown, cause: Cause, begun: u32) -> Pass {
        // Active, not already `Aborting`.
        let states = RunningStates::entering(RunningState::Aborting);
        let target = teardown.target().map(|t| t.seq);
        // A restart restarts its target (from `Running` or `Paused`) and aborts the
        // sequences below it.
        let move_one = |id: SeqId| match teardown {
            Teardown::Restart(t) if id == t.seq => self.stop(control, id, cause, Stop::Restart),
            _ => self.stop(control, id, cause, Stop::Abort),
        };
        // The target is marked first (it starts nothing from now on), unless its run is
        // over and another one began; a sequence below it has a caller link: when no other
        // sequence has one, the target is all there is to move.
        if let Some(t) = teardown.target() {
            let alone = self.with(|s| {
                if s.current_run(t.seq) != t {
                    return None;
                }
                s.mark_stopping(t.seq);
                // Placed as the target of an exception's behaviour, to be marked once
                // stopped (`stop`). Not a run that is being stopped already: this teardown
                // does not move it.
                if cause.is_exception() {
                    if let Some(b) = s
                        .block_mut(t.seq)
                        .filter(|b| RunningStates::RUNNING_OR_PAUSED.has(b.state))
                    {
                        b.set(flag::EXCEPTION_TARGET, true);
                    }
                }
                Some(s.sets.none_but(Set::Called, t.seq))
            });
            match alone {
                None => return Pass::Done,
                Some(true) => return Pass::of(!move_one(t.seq)),
                Some(false) => {}
            }
        }
        // A teardown marks what it places, in the section that finds the run it looked at
        // still under way: the mark is that run's (a new run's commit clears it), and only
        // a marked sequence moves (`leave_for_teardown`).
        let scope = match target {
            Some(t) => Scope::Subtree(t),
            None => Scope::Everything,
        };
        // What is below a later run of the target is not this teardown's: a sequence is
        // marked only while the target runs the run the teardown is of.
        let of_target = teardown.target();
        let rows = self.by_depth(scope, states, &mut |id, runs| {
            self.with(|s| {
                of_target.is_none_or(|t| s.current_run(t.seq) == t)
                    && s.mark_placed(id, runs, states)
            })
        });
        // A pass is disturbed like a lost race by a run begun before it marked what it
        // placed: the run may not be placed, and is in the next pass.
        let mut raced = target.is_some() && self.with(|s| s.runs_begun) != begun;
        // Innermost first.
        for depth in (0..=rows.deepest()).rev() {
            for id in rows.at(depth) {
                // The target moves last, and only in a pass in which everything below it
                // moved: once it moved, its lane may take up a restart, and what begins
                // then is its new round's.
                if raced && Some(id) == target {
                    return Pass::Again;
                }
                raced |= move_one(id);
            }
        }
        // Below a target nothing began (it is all marked); an abort-all walks again for a
        // run begun during the pass (a start anywhere).
        let begun_anywhere = target.is_none() && self.with(|s| s.runs_begun) != begun;
        Pass::of(!raced && !begun_anywhere)
    }

    /// Stops one sequence as `how` says, from a state its target state may be entered
    /// from, running its hook. True when it lost a race: the sequence was in such a state,
    /// but another transition came between the look and the move.
    fn stop(&self, control: &C, id: SeqId, cause: Cause, how: Stop) -> bool {
        // With a coarse lock, the steps before the hook in one section and those after it
        // in another: the tick runs at the ceiling, so a longer section delays no one.
        let exception = cause.is_exception();
        let hook = match in_sections!(self, |s| leave_for_teardown(s, id, cause, how)) {
            Move::Left(hook) => hook,
            Move::Stays => return false,
            Move::Raced => return true,
        };
        if let Some(h) = hook {
            h(control);
        }
        in_sections_then_wake!(self, |s| {
            // The target of an exception's behaviour (placed as such by `teardown_pass`) is
            // marked once stopped, before any lane this wakes runs.
            if exception {
                s.section(|s| s.mark_exception_target(id, cause));
            }
            let mut lanes = LaneSet::EMPTY;
            if let Stop::Abort = how {
                // A blocking sequence's run is dropped by its aborted caller and
                // never reports back, so the outcome is recorded here.
                let change = StateChange::new(id, how.to(), RunningState::Aborted, cause);
                let aborted = s.section(|s| {
                    let b = s.transition(&change)?;
                    b.outcome = Some(crate::Outcome::Aborted(cause));
                    let run = RunId {
                        seq: id,
                        count: b.runs,
                    };
                    // Aborted for a cause of its own exception, the mark stays; for any
                    // other (an abort-all, a request, a teardown from above), no exception
                    // is handled any more. (`exception_is_active` of a stopped run reads
                    // its last cause, `Port::info`, which a start refused later leaves.)
                    if b.active_exception != Some(cause) {
                        s.sets.put(Set::Excepting, id, false);
                    }
                    Some(run)
                });
                if let Some(run) = aborted {
                    // Its joiners are released; its own wait in a join is over with it (its
                    // future, unwound later, would clear it only then, and a new run of it
                    // started meanwhile must not be taken for waiting). Unless a lane above
                    // the tick has since unwound it and begun the next run, whose wait it
                    // is then (and whose joiners are not this run's).
                    lanes = s.section(|s| {
                        if !s.began_after(run) {
                            s.forget_wait(id);
                        }
                        s.release_joiners(run)
                    });
                }
            }
            lanes.with(s.section(|s| s.lane_of(id)))
        });
        false
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// A teardown placed `id` when its run `runs` was in `states`: if that run is still
    /// under way there, it is marked ([`mark_stopping`](Self::mark_stopping)). False when
    /// it ended meanwhile, or another run began: that one is not this teardown's.
    fn mark_placed(&mut self, id: SeqId, runs: u16, states: RunningStates) -> bool {
        let placed = self
            .block(id)
            .is_some_and(|b| b.runs == runs && states.has(b.state));
        if placed {
            self.mark_stopping(id);
        }
        placed
    }

    /// `id`, placed as the target of an exception's behaviour (`teardown_pass`), was
    /// stopped for the exception `cause` (this runs only after the move): stopped because
    /// of it, it names it (`activeException`) and, while it is still stopped for it
    /// (`Aborting`, `Aborted`, `Restarting`), is marked (`exceptionIsActive`). A lane of
    /// higher priority may have taken up the restart since, and even ended the new round:
    /// named, not marked. A new run began without the placing: nothing.
    fn mark_exception_target(&mut self, id: SeqId, cause: Cause) {
        let Some(b) = self.block_mut(id).filter(|b| b.has(flag::EXCEPTION_TARGET)) else {
            return;
        };
        b.set(flag::EXCEPTION_TARGET, false);
        b.active_exception = Some(cause);
        let stopped = RunningStates::STOPPED_BY_TEARDOWN.has(b.state) && b.last_cause == cause;
        b.set(flag::EXCEPTION_MARKED, stopped);
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

/// The steps of [`Sequencer::stop`] before the hook: `id` leaves a state that `how`'s
/// target state may be entered from for it. Returns the hook to run.
fn leave_for_teardown<
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
    how: Stop,
) -> Move<Option<fn(&C)>> {
    let to = how.to();
    // Before a teardown, what it leaves behind: the cause a later clearance reports; after an
    // abort no pending pause or resume and no start left for its lane to take (the run is
    // over before it began: nothing of it must look under way; a restart goes on with the
    // same run, which keeps the requests made of it); and the hook.
    let looked = s.section(|s| {
        let b = s.block_mut(id).ok_or(Move::Stays)?;
        let from = b.state;
        if !RunningStates::entering(to).has(from) {
            return Err(Move::Stays);
        }
        // A teardown moves only a run it marked (`teardown_pass`): without its mark, the
        // run it marked ended and a new one began, or another teardown moved it meanwhile.
        if !b.has(flag::STOPPING) {
            return Err(Move::Raced);
        }
        b.last_cause = cause;
        if let Stop::Abort = how {
            b.drop_pause_and_resume();
            b.set(flag::START_PENDING, false);
        }
        Ok((from, s.hooks.get(id.index()).copied().flatten()))
    });
    let (from, hook) = match looked {
        Ok(found) => found,
        Err(other) => return other,
    };
    let change = StateChange::new(id, from, to, cause);
    let moved = s.section(|s| {
        // The mark may be gone as in the look above: the next pass marks what is there
        // then. (A pause keeps a teardown's mark: the teardown still moves the paused run.)
        let moved = s.transition_if(&change, |b| b.has(flag::STOPPING));
        // A restarted run is no longer being stopped: its new round starts runs. (An
        // aborted one starts nothing, marked or not, and a new run clears the mark.) The
        // round ends with the move: its pause and resume requests with it (a request
        // checked in it and queued later finds the count moved), and the restart is
        // counted in the run (a monitor's or timeout's limit is checked against it when the
        // monitor fires, and again where a behaviour that waited for its exception
        // sequence is applied; a new run begins at 0).
        moved
            .map(|b| {
                if let Stop::Restart = how {
                    b.set(flag::STOPPING, false);
                    b.drop_pause_and_resume();
                    b.restarts_made = b.restarts_made.saturating_add(1);
                }
            })
            .is_some()
    });
    if !moved {
        return Move::Raced;
    }
    Move::Left(hook)
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
        Port::start_child(seq, y, run(r)).unwrap();
        seq.begin(
            x,
            Mode::Blocking {
                caller: run(y),
                maker: seq.tag(),
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
                *result.borrow_mut() = Some(Port::start_child(seq, g, run(y)).map(drop));
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
        assert!(Port::take_start(seq, o, seq.tag(), waker).is_some());
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
