//! The heartbeat: `Sequencer::tick`, called from a periodic timer interrupt.
//!
//! The tick is the only place where sequences are stopped: it applies requests (pause,
//! resume, abort, abort-all), evaluates the monitors and timeouts that are due, starts
//! exception sequences, applies behaviours, and wakes exactly the lanes that must act.
//! User conditions and cleanup hooks run outside the critical sections.

use crate::bits::Bits;
use crate::control_block::{flag, reached32, request, ControlBlock, Link, NEVER_AHEAD, NO_LANE};
use crate::lanes::LaneSet;
use crate::lock::Lock;
use crate::monitor::{Entry, Group};
use crate::polling::Due;
use crate::sequencer::{bit, sources, steps, Inner, Mode, Steps, NO_WAKER};
use crate::{
    Behaviour, Cause, Instant, Monitors, RunningState, SeqId, Sequencer, Transition, MAX_DEPTH,
};

/// `depth + 1` of the deepest possible sequence.
const DEPTH_LIMIT: u8 = MAX_DEPTH as u8 + 1;

/// The depths a sequence can have (0 to `MAX_DEPTH` callers).
const DEPTHS: usize = MAX_DEPTH + 1;

/// What the tick must do for the sequences whose poll is due.
struct Polls {
    /// Active sequences whose polling class is due: their monitors are evaluated.
    due: Bits,
    /// Due in a new run or restart: their monitors' edge detection starts from "false".
    fresh: Bits,
    /// Running, due, with an expired timeout (raised after the monitors).
    expired: Bits,
    /// Running, due, waiting for a polled condition: their lanes are woken (after the
    /// monitors).
    wake: Bits,
    /// Some active sequence is paused or handles an exception: a wake-up checks that its
    /// sequence is not held.
    careful: bool,
}

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
    /// The due polls `due` (active sequences whose polling class is due): takes their
    /// fresh marks and marks their due exit-condition polls. Returns what to do, without
    /// the expired timeouts, and the running ones with an armed timeout.
    #[inline(always)]
    fn take_polls(&mut self, due: Bits) -> (Polls, Bits) {
        let running = due.minus(self.paused);
        let fresh = self.fresh.and(due);
        self.fresh = self.fresh.minus(due);
        let wake = running.and(self.poll_wait);
        self.poll_due = self.poll_due.or(wake);
        let polls = Polls {
            due,
            fresh,
            expired: Bits::EMPTY,
            wake,
            careful: !self.paused.or(self.excepting).and(self.active).is_empty(),
        };
        (polls, running.and(self.armed))
    }

    /// The block of `id`, registered or not, without comparing with `count`: an
    /// unregistered block is idle, in no lane and linked to nothing. Each use in this
    /// module reads the block of an active sequence or of its caller, or tests for
    /// `Running` or `Paused`, where that answers as no block would.
    #[inline]
    fn slot(&self, id: SeqId) -> Option<&ControlBlock> {
        self.blocks.get(id.index())
    }

    /// Those of `wake` that are not held (see [`Sequencer::held`]), in one section.
    fn unheld(&self, wake: Bits) -> Bits {
        let mut out = wake;
        for id in wake {
            let lane = self.slot(id).map_or(NO_LANE, |b| b.lane);
            if held_by(id, |c| self.held_step(c, lane)) {
                out.set(id, false);
            }
        }
        out
    }

    /// Those of `timed` whose timeout deadline has passed at `now`.
    fn expired(&self, timed: Bits, now: u32) -> Bits {
        let mut out = Bits::EMPTY;
        for id in timed {
            if self.fast(id).is_some_and(|b| reached32(now, b.deadline)) {
                out.set(id, true);
            }
        }
        out
    }
}

/// The conditions of those `members` (a group, bits as in [`Group`]) whose owner is due;
/// the others keep their `last` values. The edge detection of the monitors of fresh
/// owners (all due) starts again from "false": their bits of `last` are cleared. Returns
/// the values and the bits evaluated.
#[inline(never)]
fn evaluate_due<C, K: crate::Condition<C>>(
    members: &mut [Entry<'_, C, K>],
    last: &mut u32,
    polls: &Polls,
    control: &C,
    now: Instant,
) -> (u32, u32) {
    let (due, fresh) = (polls.due, polls.fresh);
    let mut values = 0u32;
    let mut evaluated = 0u32;
    let mut renewed = 0u32;
    let mut bit = 1u32 << (members.len().saturating_sub(1) & 31);
    for e in members.iter_mut() {
        if due.has(e.owner) {
            evaluated |= bit;
            if fresh.has(e.owner) {
                renewed |= bit;
            }
            if e.def.condition.validate(control, now) {
                values |= bit;
            }
        }
        bit >>= 1;
    }
    *last &= !renewed;
    (values | (*last & !evaluated), evaluated)
}

/// Whether sequence `id` is held: `step` is one step up its blocking callers
/// ([`Inner::held_step`]).
fn held_by(id: SeqId, mut step: impl FnMut(SeqId) -> Option<Link>) -> bool {
    let mut at = Link::to(Some(id));
    // The sequence and at most `MAX_DEPTH` callers.
    for _ in 0..DEPTH_LIMIT {
        let Some(c) = at.get() else { return false };
        match step(c) {
            Some(up) => at = up,
            None => return true,
        }
    }
    false
}

/// How an exception of one monitor (or of a sequence's timeout) is handled, with its
/// restart bookkeeping.
struct Reaction {
    behaviour: Behaviour,
    exception: Option<SeqId>,
    restarts: u8,
    runs_seen: u16,
    limit: u8,
}

impl ControlBlock {
    /// How this sequence's timeout monitor reacts, with its restart bookkeeping.
    fn timeout_reaction(&self) -> Reaction {
        Reaction {
            behaviour: self.timeout_behaviour,
            exception: self.timeout_exception.get(),
            restarts: self.timeout_restarts,
            runs_seen: self.timeout_runs_seen,
            limit: self.timeout_restart_limit,
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Sequencer<C, N, T, L, W> {
    /// The heartbeat (one call per timer interrupt): sets the sequencer time to `now`, applies
    /// pending requests, evaluates the monitors and timeouts of every sequence whose polling
    /// period is due, and wakes the lanes that must act.
    ///
    /// A tick with nothing due (and no state change since the last one) returns after one
    /// short critical section.
    ///
    /// ```
    /// use rtseq::{Instant, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// seq.tick(Instant::from_ticks(1_000), &(), &mut monitors);
    /// assert_eq!(seq.now().as_ticks(), 1_000);
    /// ```
    pub fn tick<const M: usize, K: crate::Condition<C>>(
        &self,
        now: Instant,
        control: &C,
        monitors: &mut Monitors<'_, C, M, K>,
    ) {
        let now_us = now.as_ticks();
        let abort_all = self.take_abort_all();
        let (work, any_due, changed) = self.with(|s| {
            s.now = now_us;
            // Truncation is the point: control-block times are the low 32 bits.
            (
                core::mem::take(&mut s.work),
                reached32(now_us as u32, s.next_due),
                core::mem::take(&mut s.changed),
            )
        });
        self.fold(changed);
        if abort_all {
            self.apply_abort_all(control);
        }
        if work {
            self.apply_requests(control);
        }
        if !any_due {
            return;
        }
        if abort_all || work {
            // What they stopped or paused is not due any more.
            self.fold(self.with(|s| core::mem::take(&mut s.changed)));
        }
        let polls = self.scan(now_us);
        let mut careful = polls.careful;
        // The hot loop, one group of up to 32 monitors at a time: when all their owners
        // are due (the common case), their conditions shifted into a bit set in one flat
        // loop; edges and triggers are a few word operations per group, and firing is the
        // rare, out-of-line path.
        let due = polls.due;
        // Due owners whose monitors keep their edge state: a group of only these takes the
        // flat loop.
        let steady = due.minus(polls.fresh);
        let mut rest = monitors.entries.as_mut_slice();
        let used = usize::from(monitors.used_groups);
        for g in monitors.groups.iter_mut().take(used) {
            // The groups tile the table in order.
            let Some((members, tail)) =
                core::mem::take(&mut rest).split_at_mut_checked(usize::from(g.len))
            else {
                break;
            };
            rest = tail;
            let owners_due = g.owners.and(due);
            if owners_due.is_empty() {
                continue;
            }
            // A monitor of a fresh owner starts its edge detection from "false": the
            // per-monitor path.
            let (values, evaluated) = if g.owners.minus(steady).is_empty() {
                let mut values = 0u32;
                for e in members.iter_mut() {
                    values = (values << 1) | u32::from(e.def.condition.validate(control, now));
                }
                (values, u32::MAX)
            } else {
                evaluate_due(members, &mut g.last, &polls, control, now)
            };
            // The common case, nothing changed and no level monitor true, is one test.
            if (values ^ g.last) | (values & g.level) != 0 {
                let firing = g.firing(values) & evaluated;
                g.last = values;
                if firing != 0 {
                    self.fire_group(g, members, firing, control);
                    careful = true;
                }
            }
        }
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        for id in polls.expired {
            // The configuration is fixed and its bookkeeping is the tick's: read once.
            if let Some(mut reaction) = self.with(|s| s.slot(id).map(|b| b.timeout_reaction())) {
                self.raise(control, id, Cause::Timeout(id), &mut reaction);
            }
            careful = true;
        }
        if !polls.wake.is_empty() {
            let lanes = if L::COARSE {
                // One section: the held check walks the callers inside it.
                self.with(|s| {
                    let wake = if careful {
                        s.unheld(polls.wake)
                    } else {
                        polls.wake
                    };
                    s.lanes_of_polls(wake, &self.lanes)
                })
            } else {
                self.lanes_of_polls(polls.wake, careful)
            };
            self.wake_lanes(lanes);
        }
    }

    /// Folds the state of the sequences `changed` into the sets `active` and `paused`, one
    /// short section per sequence.
    fn fold(&self, changed: Bits) {
        for id in changed {
            self.with(|s| s.fold(id));
        }
    }

    /// Finds the due polls: advances the schedules of the polling classes that are due,
    /// recomputes `next_due`, takes the due sequences' fresh marks, marks their due
    /// exit-condition polls and finds their expired timeouts. With a coarse lock in one
    /// section; otherwise one short section per class and per armed timeout.
    #[inline(always)]
    fn scan(&self, now: u64) -> Polls {
        // Truncation is the point: control-block times are the low 32 bits.
        let now32 = now as u32;
        let mut due = Due {
            sequences: Bits::EMPTY,
            ahead: u32::MAX,
        };
        let next_due = |ahead: u32| now32.wrapping_add(ahead.min(NEVER_AHEAD));
        if L::COARSE {
            return self.with(|s| {
                s.classes.scan_all(now32, s.active, &mut due);
                s.next_due = next_due(due.ahead);
                let (mut polls, timed) = s.take_polls(due.sequences);
                polls.expired = s.expired(timed, now32);
                polls
            });
        }
        let classes = self.with(|s| s.classes.len());
        for i in 0..classes {
            self.with(|s| s.classes.scan(i, now32, s.active, &mut due));
        }
        let (mut polls, timed) = self.with(|s| {
            s.next_due = next_due(due.ahead);
            s.take_polls(due.sequences)
        });
        for id in timed {
            polls.expired = polls
                .expired
                .or(self.with(|s| s.expired(Bits::of(id), now32)));
        }
        polls
    }

    /// With a portable lock: the lanes whose polled condition is due, except those held
    /// (checked only when `careful`: after a monitor fired or while something is held), in
    /// short sections. Lanes joined in one task share their waker, which is woken once.
    #[inline(never)]
    fn lanes_of_polls(&self, wake: Bits, careful: bool) -> LaneSet {
        let mut lanes = LaneSet::EMPTY;
        let mut woken = NO_WAKER;
        for id in wake {
            if careful && self.held(id) {
                continue;
            }
            let (lane, waker) = self.with(|s| {
                let lane = s.lane_slot(id);
                (lane, self.lanes.identity(lane))
            });
            if waker != NO_WAKER && waker != woken {
                woken = waker;
                lanes = lanes.with(LaneSet::of(lane));
            }
        }
        lanes
    }

    /// Whether sequence `id` is held, or frozen by a caller it blocks (paused, or holding
    /// for an exception): it is woken when it may go on. One short section per caller.
    fn held(&self, id: SeqId) -> bool {
        let lane = self.with(|s| s.slot(id).map_or(NO_LANE, |b| b.lane));
        held_by(id, |c| self.with(|s| s.held_step(c, lane)))
    }

    /// Monitors of `group` triggered (`firing`, bits as in [`Group`]): raise their
    /// exceptions in table order (out of the hot loop).
    #[inline(never)]
    fn fire_group<K>(
        &self,
        group: &Group,
        members: &mut [Entry<'_, C, K>],
        firing: u32,
        control: &C,
    ) {
        // The group's first monitor holds its highest bit.
        let mut bit = group.first_bit();
        let mut id = group.start;
        for entry in members.iter_mut() {
            if firing & bit != 0 {
                self.fire(entry, crate::MonitorId(id), control);
            }
            bit >>= 1;
            id = id.wrapping_add(1);
        }
    }

    /// A monitor triggered: raise its exception.
    fn fire<K>(&self, entry: &mut Entry<'_, C, K>, id: crate::MonitorId, control: &C) {
        let mut reaction = Reaction {
            behaviour: entry.def.behaviour,
            exception: entry.def.exception,
            restarts: entry.restarts,
            runs_seen: entry.target_runs_seen,
            limit: entry.def.restart_limit,
        };
        if self.raise(control, entry.owner, Cause::Monitor(id), &mut reaction) {
            entry.fired = entry.fired.wrapping_add(1);
        }
        entry.restarts = reaction.restarts;
        entry.target_runs_seen = reaction.runs_seen;
    }

    /// A monitor (or `owner`'s timeout, `Cause::Timeout`) of `owner` fired with `reaction`:
    /// mark the exception, then start the exception sequence (the behaviour waits for its
    /// end) or apply the behaviour now. Returns false when the owner could not take an
    /// exception any more (a timeout: unless running, its timeout stays armed and is
    /// checked again at its next poll). The reaction's restart bookkeeping is updated; a
    /// timeout's is written back to the owner's block with the mark (which also disarms
    /// the timeout).
    #[inline(never)]
    fn raise(&self, control: &C, owner: SeqId, cause: Cause, reaction: &mut Reaction) -> bool {
        // With a coarse lock one section, else the check and the mark in one each.
        let Some((target, behaviour)) = steps!(self, |s| mark(s, owner, cause, reaction)) else {
            return false;
        };
        let deferred = reaction.exception.is_some_and(|e| {
            let started = self
                .begin(e, Some(owner), Mode::Lane, cause, flag::HANDLES_EXCEPTION)
                .is_ok();
            self.with(|s| {
                if started {
                    if let Ok(b) = s.block_mut(owner) {
                        b.set_pending(Some(behaviour));
                    }
                } else {
                    s.exceptions_not_run = s.exceptions_not_run.saturating_add(1);
                }
            });
            started
        });
        if !deferred {
            self.apply(control, owner, behaviour, target, cause);
        }
        true
    }

    /// Applies a behaviour after an exception (and its exception sequence) of `owner`.
    fn apply(&self, control: &C, owner: SeqId, behaviour: Behaviour, target: SeqId, cause: Cause) {
        let to = match behaviour {
            Behaviour::Nothing => {
                let lane = steps!(self, |s| {
                    s.step(|s| s.excepting.set(owner, false));
                    s.step(|s| s.lane_of(owner))
                });
                self.wake_lanes(lane);
                return;
            }
            Behaviour::AbortOwner | Behaviour::AbortCallerOfOwner => RunningState::Aborting,
            Behaviour::RestartOwner | Behaviour::RestartCallerOfOwner => RunningState::Restarting,
        };
        self.walk(control, Some(target), to, cause);
    }

    /// Aborts every active sequence, innermost first.
    #[inline(never)]
    fn apply_abort_all(&self, control: &C) {
        self.walk(control, None, RunningState::Aborting, Cause::AbortAll);
    }

    /// Applies finished exception sequences and abort/pause/resume requests (out of line:
    /// one copy, whatever the monitor tables the tick is instantiated for).
    #[inline(never)]
    fn apply_requests(&self, control: &C) {
        // Unregistered blocks have neither.
        for i in 0..N {
            // At most 31 (`N` ≤ 32): fits a byte.
            let id = SeqId(i as u8);
            // The requests, and the behaviour pending for an exception sequence that ended.
            let (req, done) = self.with(|s| {
                let Some(b) = s.blocks.get_mut(i) else {
                    return (0, None);
                };
                let mut done = None;
                if b.has(flag::EXCEPTION_DONE) {
                    b.set(flag::EXCEPTION_DONE, false);
                    done = b.pending();
                    b.set_pending(None);
                }
                (b.take_requests(), done)
            });
            if let Some(behaviour) = done {
                // Unless it was stopped meanwhile: the cause and the target.
                let still = self.with(|s| {
                    s.slot(id)
                        .filter(|b| matches!(b.state, RunningState::Running | RunningState::Paused))
                        .map(|b| (b.active_exception.unwrap_or(Cause::Abort), b.caller.get()))
                });
                if let Some((cause, caller)) = still {
                    let target = if behaviour.targets_caller() {
                        caller.unwrap_or(id)
                    } else {
                        id
                    };
                    self.apply(control, id, behaviour, target, cause);
                }
            }
            // One request at a time, abort first.
            let (to, cause) = if req & request::ABORT != 0 {
                (RunningState::Aborting, Cause::Abort)
            } else if req & request::PAUSE != 0 {
                (RunningState::Paused, Cause::Pause)
            } else if req & request::RESUME != 0 {
                (RunningState::Running, Cause::Resume)
            } else {
                continue;
            };
            self.walk(control, Some(id), to, cause);
        }
    }

    /// Moves `target` and the sequences below it (every active sequence without a target)
    /// to `to`, one at a time, for `cause`: the one walk of teardowns and pauses.
    ///
    /// * `Aborting` or `Restarting`: aborts `target` and every active sub-sequence of it
    ///   (blocking and non-blocking), innermost first, each through `Aborting` (cleanup
    ///   hook) to `Aborted`; with `Restarting`, the target itself goes to `Restarting`
    ///   instead.
    /// * `Paused` (`Running`): pauses (resumes) a running (paused) `target` and the
    ///   sequences it blocks in its lane, outermost first.
    #[inline(never)]
    pub(crate) fn walk(&self, control: &C, target: Option<SeqId>, to: RunningState, cause: Cause) {
        let pause = matches!(to, RunningState::Paused | RunningState::Running);
        // What a pause leaves (a resume: `Paused`).
        let from = if to == RunningState::Paused {
            RunningState::Running
        } else {
            RunningState::Paused
        };
        let (states, lane) = if pause {
            let Some(lane) = target
                .and_then(|t| self.with(|s| s.slot(t).filter(|b| b.state == from).map(|b| b.lane)))
            else {
                return;
            };
            (bit(from), Some(lane))
        } else {
            // Active, not already `Aborting`.
            (sources(RunningState::Aborting), None)
        };
        let rows = self.levels(target, states, lane);
        for k in 0..DEPTHS {
            // Pauses outermost first, teardowns innermost first.
            let depth = if pause { k } else { MAX_DEPTH - k };
            for id in rows.get(depth).copied().unwrap_or_default() {
                // A restart restarts its target (from `Running` or `Paused`) and aborts the
                // sequences below it.
                if to == RunningState::Restarting && Some(id) == target {
                    self.stop(control, id, cause, sources(to), to);
                } else if to == RunningState::Restarting {
                    self.stop(control, id, cause, states, RunningState::Aborting);
                } else {
                    self.stop(control, id, cause, states, to);
                }
            }
        }
    }

    /// Moves one sequence from a state in `states` (states `to` may be entered from) to
    /// `to`: to `Aborting → Aborted` or to `Restarting`, running its hook; or pauses or
    /// resumes it (`Paused`, `Running`).
    fn stop(&self, control: &C, id: SeqId, cause: Cause, states: u8, to: RunningState) {
        // With a coarse lock, the steps before the hook in one section and those after it
        // in another: the tick runs at the ceiling, so a longer section delays no one.
        let Some(hook) = steps!(self, |s| leave(s, id, cause, states, to)) else {
            return;
        };
        if let Some(h) = hook {
            h(control);
        }
        let lanes = steps!(self, |s| {
            let mut lanes = LaneSet::EMPTY;
            if to == RunningState::Aborting {
                // A blocking sequence's framework is dropped by its aborted caller and
                // never reports back, so the outcome is recorded here.
                let t = Transition::edge(id, to, RunningState::Aborted, cause);
                let aborted = s.step(|s| {
                    let b = s.shift(&t)?;
                    b.outcome = Some(crate::Outcome::Aborted(cause));
                    Some(())
                });
                if aborted.is_some() {
                    lanes = s.step(|s| s.release_joiners(id));
                }
            }
            lanes.with(s.step(|s| s.lane_of(id)))
        });
        self.wake_lanes(lanes);
    }

    /// For a teardown or a pause: the sequences that are `target` or below it (every one
    /// without a target) whose state is in `states` and, with a `lane`, that run in that
    /// lane, by depth (outermost first, ids ascending in each row).
    ///
    /// One short section per block (registered or not: an unregistered one is idle and
    /// links to no caller) copies its caller link and whether it qualifies; the tree is
    /// walked in that copy, outside any section. Lanes cannot change
    /// it meanwhile (the tick preempts them), and each change made from it is re-checked
    /// where it is made.
    fn levels(&self, target: Option<SeqId>, states: u8, lane: Option<u8>) -> [Bits; DEPTHS] {
        let mut links = [Link::NONE; N];
        let mut picked = Bits::EMPTY;
        // Unregistered blocks are idle and link to no caller: never picked.
        for (i, l) in links.iter_mut().enumerate() {
            let ok;
            (*l, ok) = self.with(|s| {
                s.blocks.get(i).map_or((Link::NONE, false), |b| {
                    let ok = states & bit(b.state) != 0 && lane.is_none_or(|l| l == b.lane);
                    (b.caller, ok)
                })
            });
            // At most 31 (`N` ≤ 32): fits a byte.
            picked.set(SeqId(i as u8), ok);
        }
        let target = Link::to(target);
        let mut rows = [Bits::EMPTY; DEPTHS];
        for id in picked {
            // Up the caller links (at most MAX_DEPTH): the depth, and whether the target
            // is on the way.
            let mut below = target == Link::NONE || target == Link::to(Some(id));
            let mut depth = 0;
            let mut at = id;
            while let Some(up) = links.get(at.index()).and_then(|l| l.get()) {
                if depth == MAX_DEPTH {
                    break;
                }
                below |= target == Link::to(Some(up));
                depth += 1;
                at = up;
            }
            if let (true, Some(row)) = (below, rows.get_mut(depth)) {
                row.set(id, true);
            }
        }
        rows
    }
}

/// The steps of [`Sequencer::stop`] before the hook: `id` leaves a state in `states` for
/// `to` (a paused timeout keeps its remaining time). Returns the hook to run (set at
/// registration; none for a pause or resume), or `None` when `id` does not move.
#[allow(clippy::type_complexity)]
fn leave<C, S: Steps<C, N, T, W>, const N: usize, const T: usize, const W: usize>(
    s: &mut S,
    id: SeqId,
    cause: Cause,
    states: u8,
    to: RunningState,
) -> Option<Option<fn(&C)>> {
    let pause = matches!(to, RunningState::Paused | RunningState::Running);
    // Before a teardown, what it leaves behind: the cause a later gate reports, no pending
    // requests; and the hook.
    let (from, hook) = s.step(|s| {
        let b = s.block_mut(id).ok()?;
        let from = b.state;
        if states & bit(from) == 0 {
            return None;
        }
        if pause {
            return Some((from, None));
        }
        b.last_cause = cause;
        b.take_requests();
        Some((from, s.hooks.get(id.index()).copied().flatten()))
    })?;
    let t = Transition::edge(id, from, to, cause);
    s.step(|s| s.shift(&t).map(|_| ()))?;
    if pause {
        // A paused timeout keeps its remaining time, not a deadline (nothing reads either
        // before this: the tick is the one that would).
        s.step(|s| {
            let now = s.now as u32;
            let armed = s.armed.has(id);
            let Ok(b) = s.block_mut(id) else { return };
            if armed {
                b.deadline = if to == RunningState::Paused {
                    let left = b.deadline.wrapping_sub(now);
                    if left >= 0x8000_0000 {
                        0
                    } else {
                        left
                    }
                } else {
                    now.wrapping_add(b.deadline)
                };
            }
        });
    }
    Some(hook)
}

/// The steps of [`Sequencer::raise`] before the exception sequence: if `owner` can take
/// the exception (active; for a timeout, running; not handling one already), counts the
/// restart and marks the exception.
/// Returns the behaviour's target and the behaviour (escalated past the restart limit).
fn mark<C, S: Steps<C, N, T, W>, const N: usize, const T: usize, const W: usize>(
    s: &mut S,
    owner: SeqId,
    cause: Cause,
    reaction: &mut Reaction,
) -> Option<(SeqId, Behaviour)> {
    let timeout = matches!(cause, Cause::Timeout(_));
    // Active (a paused timeout is frozen), and not handling an exception already.
    let states = if timeout {
        bit(RunningState::Running)
    } else {
        bit(RunningState::Running) | bit(RunningState::Paused)
    };
    let (target, target_runs) = s.step(|s| {
        let b = s.slot(owner)?;
        if states & bit(b.state) == 0 || s.excepting.has(owner) {
            return None;
        }
        let target = if reaction.behaviour.targets_caller() {
            b.caller.get().unwrap_or(owner)
        } else {
            owner
        };
        Some((target, s.slot(target)?.runs))
    })?;
    let mut behaviour = reaction.behaviour;
    if behaviour.is_restart() {
        if reaction.runs_seen != target_runs {
            reaction.runs_seen = target_runs;
            reaction.restarts = 0;
        }
        if reaction.restarts >= reaction.limit {
            behaviour = behaviour.escalated();
        } else {
            reaction.restarts = reaction.restarts.saturating_add(1);
        }
    }
    s.step(|s| {
        if let Ok(b) = s.block_mut(owner) {
            b.active_exception = Some(cause);
            if timeout {
                b.timeout_restarts = reaction.restarts;
                b.timeout_runs_seen = reaction.runs_seen;
                s.armed.set(owner, false);
            }
            s.excepting.set(owner, true);
        }
        #[cfg(feature = "counters")]
        if let Some(c) = s.counters.get_mut(owner.index()) {
            c.exceptions = c.exceptions.wrapping_add(1);
        }
    });
    Some((target, behaviour))
}
