//! The heartbeat: `Sequencer::tick`, called from a periodic timer interrupt.
//!
//! The tick is the only place where sequences are stopped: it applies requests (pause,
//! resume, abort, abort-all), evaluates the monitors and timeouts that are due, starts
//! exception sequences, applies behaviours, and wakes exactly the lanes that must act.
//! User conditions and cleanup hooks run outside the critical sections.

use crate::control_block::{flag, reached32, request, ControlBlock, Link, NEVER_AHEAD, NO_LANE};
use crate::lock::Lock;
use crate::monitor::{Entry, Group};
use crate::sequencer::{bit, identity, sources, Mode, NO_WAKER};
use crate::{
    Behaviour, Cause, Instant, Monitors, RunningState, SeqId, Sequencer, Transition, MAX_DEPTH,
};

/// `depth + 1` of the deepest possible sequence.
const DEPTH_LIMIT: u8 = MAX_DEPTH as u8 + 1;

/// Bits of the mark the due scan leaves for each sequence (a byte per sequence on the
/// tick's stack, so a tick allocates nothing and touches no shared state for it).
pub(crate) mod mark {
    /// Its polling period is due: its monitors are evaluated.
    pub const DUE: u8 = 1 << 0;
    /// A new run or restart: its monitors' edge detection starts from "false".
    pub const FRESH: u8 = 1 << 1;
    /// The timeout deadline has passed (checked after the monitors).
    pub const EXPIRED: u8 = 1 << 2;
    /// A polled condition is due: wake the lane (after the monitors).
    pub const WAKE: u8 = 1 << 3;
    /// Paused or handling an exception (or a monitor fired this tick): it may hold its
    /// callees back.
    pub const HELD: u8 = 1 << 4;
    /// Running or paused (its monitors and timeout are live).
    pub const ACTIVE: u8 = 1 << 5;
}

/// What the due scan found over all sequences.
struct Scan {
    /// The union of the marks.
    seen: u8,
    /// Time to the earliest next poll of an active sequence (µs).
    ahead: u32,
}

impl Scan {
    /// Scans `blocks` (marks in `marks`) and adds them to the summary.
    #[inline(always)]
    fn add(&mut self, blocks: &mut [ControlBlock], marks: &mut [u8], now: u32) {
        for (b, m) in blocks.iter_mut().zip(marks.iter_mut()) {
            let mark = b.scan(now);
            *m = mark;
            self.note(mark, b.next_poll, now);
        }
    }

    /// Adds a block's `mark` and its next poll `next` (meaningful for an active block).
    #[inline(always)]
    fn note(&mut self, mark: u8, next: u32, now: u32) {
        if mark != 0 {
            self.seen |= mark;
            self.ahead = self.ahead.min(next.wrapping_sub(now));
        }
    }
}

/// Restart bookkeeping of one monitor (or timeout monitor).
struct RestartBook {
    restarts: u8,
    runs_seen: u16,
    limit: u8,
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Sequencer<C, N, T, L, W> {
    /// The heartbeat (one call per timer interrupt): sets the sequencer time to `now`, applies
    /// pending requests, evaluates the monitors and timeouts of every sequence whose polling
    /// period is due, and wakes the lanes that must act.
    ///
    /// A tick with nothing due returns after one short critical section.
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
        let (work, any_due) = self.with(|s| {
            s.now = now_us;
            // Truncation is the point: control-block times are the low 32 bits.
            (
                core::mem::take(&mut s.work),
                reached32(now_us as u32, s.next_due),
            )
        });
        if abort_all {
            self.apply_abort_all(control);
        }
        if work {
            self.apply_requests(control);
        }
        if !any_due {
            return;
        }
        let mut marks = [0u8; N];
        let scan = self.scan(now_us, &mut marks);
        let mut seen = scan.seen;
        // The hot loop, one owner group at a time: one mark test per group, then its
        // conditions shifted into a bit set; edges and triggers are a few word operations
        // per group, and firing is the rare, out-of-line path.
        let mut rest = monitors.entries.as_mut_slice();
        for g in monitors.groups.iter_mut() {
            // The groups tile the table in order.
            let Some((members, tail)) =
                core::mem::take(&mut rest).split_at_mut_checked(usize::from(g.len))
            else {
                break;
            };
            rest = tail;
            let m = marks.get(g.owner.index()).copied().unwrap_or(0);
            if m & mark::DUE == 0 {
                continue;
            }
            if m & mark::FRESH != 0 {
                g.last = 0;
            }
            let mut values = 0u32;
            for e in members.iter_mut() {
                values = (values << 1) | u32::from(e.def.condition.validate(control, now));
            }
            // The common case, nothing changed and no level monitor true, is one test.
            let last = u32::from(g.last);
            if (values ^ last) | (values & u32::from(g.level)) != 0 {
                let firing = g.firing(values);
                // Truncation keeps the group's (at most 8) bits.
                g.last = values as u8;
                if firing != 0 {
                    self.fire_group(g, members, firing, control);
                    seen |= mark::HELD;
                }
            }
        }
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        if seen & mark::EXPIRED != 0 {
            for (i, m) in marks.iter().enumerate() {
                if m & mark::EXPIRED != 0 {
                    if let Ok(id) = u8::try_from(i).map(SeqId) {
                        self.timeout(id, control);
                    }
                }
            }
            seen |= mark::HELD;
        }
        if seen & mark::WAKE != 0 {
            self.wake_due(&marks, seen & mark::HELD != 0);
        }
    }

    /// Marks due sequences, advances their polling schedule, notes expired timeouts and due
    /// exit-condition polls and recomputes `next_due`: one short section per registered
    /// sequence, or one for all with a coarse lock.
    fn scan(&self, now: u64, marks: &mut [u8; N]) -> Scan {
        // Truncation is the point: control-block times are the low 32 bits.
        let now32 = now as u32;
        let mut sum = Scan {
            seen: 0,
            ahead: u32::MAX,
        };
        let next_due = |ahead: u32| now32.wrapping_add(ahead.min(NEVER_AHEAD));
        if L::COARSE {
            self.with(|s| {
                let count = usize::from(s.count);
                let blocks = s.blocks.get_mut(..count).unwrap_or_default();
                sum.add(blocks, marks, now32);
                s.next_due = next_due(sum.ahead);
            });
        } else {
            let count = self.with(|s| usize::from(s.count));
            for (i, m) in marks.iter_mut().enumerate().take(count) {
                // The block's scan in the section, the summary outside.
                let (mark, next) = self.with(|s| {
                    s.blocks
                        .get_mut(i)
                        .map_or((0, 0), |b| (b.scan(now32), b.next_poll))
                });
                *m = mark;
                sum.note(mark, next, now32);
            }
            self.with(|s| s.next_due = next_due(sum.ahead));
        }
        sum
    }

    /// Wakes the lanes whose polled condition is due, except those held (checked only when
    /// `careful`: after a monitor fired or while something is held).
    #[inline(never)]
    fn wake_due(&self, marks: &[u8; N], careful: bool) {
        let mut woken = NO_WAKER;
        let due = marks
            .iter()
            .enumerate()
            .filter(|(_, m)| *m & mark::WAKE != 0)
            .map(|(i, _)| i);
        if L::COARSE && !careful {
            self.with(|s| due.for_each(|i| s.wake_due(i, &mut woken)));
        } else {
            for i in due {
                if careful && self.held(i) {
                    continue;
                }
                // The identity in one section, the wake-up in another (only for a waker
                // not woken yet): each a few instructions.
                let w = self.with(|s| s.waker_of(i).map_or(NO_WAKER, identity));
                if w != NO_WAKER && w != woken {
                    woken = w;
                    if let Ok(id) = u8::try_from(i).map(SeqId) {
                        self.wake_lane(id);
                    }
                }
            }
        }
    }

    /// Whether sequence `i` is held, or frozen by a caller it blocks (paused, or holding
    /// for an exception): it is woken when it may go on. One short section per caller.
    fn held(&self, i: usize) -> bool {
        let Ok(id) = u8::try_from(i).map(SeqId) else {
            return true;
        };
        let lane = self.with(|s| s.fast(id).map_or(NO_LANE, |b| b.lane));
        let mut at = Link::to(Some(id));
        // The sequence and at most `MAX_DEPTH` callers.
        for _ in 0..DEPTH_LIMIT {
            let Some(c) = at.get() else { return false };
            match self.with(|s| s.held_step(c, lane)) {
                Some(up) => at = up,
                None => return true,
            }
        }
        false
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
        let mut bit = 1u32 << (group.len.saturating_sub(1) & 7);
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
        let mut book = RestartBook {
            restarts: entry.restarts,
            runs_seen: entry.target_runs_seen,
            limit: entry.def.restart_limit,
        };
        let cause = Cause::Monitor(id);
        if self.raise(
            control,
            entry.owner,
            cause,
            entry.def.behaviour,
            entry.def.exception,
            &mut book,
        ) {
            entry.fired = entry.fired.wrapping_add(1);
        }
        entry.restarts = book.restarts;
        entry.target_runs_seen = book.runs_seen;
    }

    /// The timeout of a due sequence expired: raise its exception unless the sequence no
    /// longer takes one (then it is checked again at its next poll).
    #[inline(never)]
    fn timeout(&self, id: SeqId, control: &C) {
        let expired = self.with(|s| {
            let Ok(b) = s.block_mut(id) else { return None };
            if b.state != RunningState::Running || !b.accepts_exception() {
                return None;
            }
            b.set(flag::TIMEOUT_ARMED, false);
            Some((
                b.timeout_behaviour,
                b.timeout_exception.get(),
                RestartBook {
                    restarts: b.timeout_restarts,
                    runs_seen: b.timeout_runs_seen,
                    limit: b.timeout_restart_limit,
                },
            ))
        });
        if let Some((behaviour, exception, mut book)) = expired {
            self.raise(
                control,
                id,
                Cause::Timeout(id),
                behaviour,
                exception,
                &mut book,
            );
            self.with(|s| {
                if let Ok(b) = s.block_mut(id) {
                    b.timeout_restarts = book.restarts;
                    b.timeout_runs_seen = book.runs_seen;
                }
            });
        }
    }

    /// A monitor (or timeout) of `owner` fired: mark the exception, then start the
    /// exception sequence (the behaviour waits for its end) or apply the behaviour now.
    /// Returns false when the owner could not take an exception any more.
    fn raise(
        &self,
        control: &C,
        owner: SeqId,
        cause: Cause,
        behaviour: Behaviour,
        exception: Option<SeqId>,
        book: &mut RestartBook,
    ) -> bool {
        let Some((target, target_runs)) = self.with(|s| {
            let b = s.fast(owner)?;
            if !b.accepts_exception() {
                return None;
            }
            let target = if behaviour.targets_caller() {
                b.caller.get().unwrap_or(owner)
            } else {
                owner
            };
            Some((target, s.fast(target)?.runs))
        }) else {
            return false;
        };
        let mut behaviour = behaviour;
        if behaviour.is_restart() {
            if book.runs_seen != target_runs {
                book.runs_seen = target_runs;
                book.restarts = 0;
            }
            if book.restarts >= book.limit {
                behaviour = behaviour.escalated();
            } else {
                book.restarts = book.restarts.saturating_add(1);
            }
        }
        self.with(|s| {
            if let Ok(b) = s.block_mut(owner) {
                b.set(flag::EXCEPTION_ACTIVE, true);
                b.active_exception = Some(cause);
            }
            #[cfg(feature = "counters")]
            if let Some(c) = s.counters.get_mut(owner.index()) {
                c.exceptions = c.exceptions.wrapping_add(1);
            }
        });
        let deferred = exception.is_some_and(|e| {
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
        match behaviour {
            Behaviour::Nothing => {
                self.with(|s| {
                    if let Ok(b) = s.block_mut(owner) {
                        b.set(flag::EXCEPTION_ACTIVE, false);
                    }
                });
                self.wake_lane(owner);
            }
            Behaviour::AbortOwner | Behaviour::AbortCallerOfOwner => {
                self.tear_down(control, Some(target), cause, false)
            }
            Behaviour::RestartOwner | Behaviour::RestartCallerOfOwner => {
                self.tear_down(control, Some(target), cause, true)
            }
        }
    }

    /// Aborts `target` and every active sub-sequence of it (blocking and non-blocking), or
    /// every active sequence when `target` is `None` (abort-all), innermost first, each
    /// through `Aborting` (cleanup hook) to `Aborted`. With `restart`, the target itself
    /// goes to `Restarting` instead.
    fn tear_down(&self, control: &C, target: Option<SeqId>, cause: Cause, restart: bool) {
        // Active, not already `Aborting`.
        let stoppable = sources(RunningState::Aborting);
        let affected = self.levels(target, stoppable, None);
        for depth in (1..=DEPTH_LIMIT).rev() {
            for (i, a) in affected.iter().enumerate() {
                let Ok(id) = u8::try_from(i).map(SeqId) else {
                    continue;
                };
                if *a != depth {
                    continue;
                }
                if restart && Some(id) == target {
                    self.stop(control, id, cause, RunningState::Restarting);
                } else {
                    self.stop(control, id, cause, RunningState::Aborting);
                }
            }
        }
    }

    /// Moves one sequence to `Aborting → Aborted` or to `Restarting`, running its hook.
    fn stop(&self, control: &C, id: SeqId, cause: Cause, to: RunningState) {
        // Before the transition, what it leaves behind: the cause a later gate reports,
        // no pending requests; and the hook (set at registration).
        let pre = self.with(|s| {
            let b = s.block_mut(id).ok()?;
            let from = b.state;
            if sources(to) & bit(from) == 0 {
                return None;
            }
            b.last_cause = cause;
            b.take_requests();
            Some((from, s.hooks.get(id.index()).copied().flatten()))
        });
        let Some((from, hook)) = pre else { return };
        let t = Transition::edge(id, from, to, cause);
        if self.with(|s| s.shift(&t).is_none()) {
            return;
        }
        if let Some(h) = hook {
            h(control);
        }
        if to == RunningState::Aborting {
            // A blocking sequence's framework is dropped by its aborted caller and never
            // reports back, so the outcome is recorded here.
            let t = Transition::edge(id, to, RunningState::Aborted, cause);
            let joiner = self.with(|s| {
                let b = s.shift(&t)?;
                b.outcome = Some(crate::Outcome::Aborted(cause));
                core::mem::replace(&mut b.joiner, Link::NONE).get()
            });
            if let Some(j) = joiner {
                self.wake_lane(j);
            }
        }
        self.wake_lane(id);
    }

    /// Aborts every active sequence, innermost first.
    #[inline(never)]
    fn apply_abort_all(&self, control: &C) {
        self.tear_down(control, None, Cause::AbortAll, false);
    }

    /// Applies finished exception sequences and abort/pause/resume requests.
    fn apply_requests(&self, control: &C) {
        let count = self.with(|s| s.count);
        for i in 0..count {
            let id = SeqId(i);
            let (req, done) = self.with(|s| {
                let Some(b) = s.fast_mut(id) else {
                    return (0, None);
                };
                let req = b.take_requests();
                let done = if b.has(flag::EXCEPTION_DONE) {
                    b.set(flag::EXCEPTION_DONE, false);
                    let behaviour = b.pending();
                    b.set_pending(None);
                    let cause = b.active_exception.unwrap_or(Cause::Abort);
                    let caller = b.caller.get();
                    behaviour.map(|behaviour| {
                        let target = if behaviour.targets_caller() {
                            caller.unwrap_or(id)
                        } else {
                            id
                        };
                        (behaviour, target, cause)
                    })
                } else {
                    None
                };
                (req, done)
            });
            if let Some((behaviour, target, cause)) = done {
                let still = self.with(|s| {
                    s.block(id).is_ok_and(|b| {
                        matches!(b.state, RunningState::Running | RunningState::Paused)
                    })
                });
                if still {
                    self.apply(control, id, behaviour, target, cause);
                }
            }
            if req & request::ABORT != 0 {
                self.tear_down(control, Some(id), Cause::Abort, false);
            } else if req & request::PAUSE != 0 {
                self.pause_tree(id, true);
            } else if req & request::RESUME != 0 {
                self.pause_tree(id, false);
            }
        }
    }

    /// Pauses (or resumes) `target` and the sequences it blocks in its lane, outermost
    /// first.
    fn pause_tree(&self, target: SeqId, pause: bool) {
        let (from, to, cause) = if pause {
            (RunningState::Running, RunningState::Paused, Cause::Pause)
        } else {
            (RunningState::Paused, RunningState::Running, Cause::Resume)
        };
        let Some(lane) = self.with(|s| {
            s.block(target)
                .ok()
                .filter(|b| b.state == from)
                .map(|b| b.lane)
        }) else {
            return;
        };
        // depth + 1 of each sequence inside, 0 = outside.
        let inside = self.levels(Some(target), bit(from), Some(lane));
        for d in 1..=DEPTH_LIMIT {
            for (i, _) in inside.iter().enumerate().filter(|(_, &x)| x == d) {
                let Ok(id) = u8::try_from(i).map(SeqId) else {
                    continue;
                };
                let t = Transition::edge(id, from, to, cause);
                if self.with(|s| s.shift(&t).is_none()) {
                    continue;
                }
                // A paused timeout keeps its remaining time, not a deadline (nothing reads
                // either before this: the tick is the one that would).
                self.with(|s| {
                    let now = s.now as u32;
                    let Ok(b) = s.block_mut(id) else { return };
                    if b.has(flag::TIMEOUT_ARMED) {
                        b.deadline = if pause {
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
                self.wake_lane(id);
            }
        }
    }

    /// For a teardown or a pause: depth + 1 of every sequence that is `target` or below it
    /// (every one without a target) whose state is in `states` and, with a `lane`, that
    /// runs in that lane; 0 for every other.
    ///
    /// One short section per registered sequence copies its caller link and whether it
    /// qualifies; the tree is walked in that copy, outside any section. Lanes cannot change
    /// it meanwhile (the tick preempts them), and each change made from it is re-checked
    /// where it is made.
    fn levels(&self, target: Option<SeqId>, states: u8, lane: Option<u8>) -> [u8; N] {
        let mut links = [Link::NONE; N];
        let mut picked = [false; N];
        let count = self.with(|s| usize::from(s.count));
        for (i, (l, p)) in links
            .iter_mut()
            .zip(picked.iter_mut())
            .enumerate()
            .take(count)
        {
            (*l, *p) = self.with(|s| {
                s.blocks.get(i).map_or((Link::NONE, false), |b| {
                    let ok = states & bit(b.state) != 0 && lane.is_none_or(|l| l == b.lane);
                    (b.caller, ok)
                })
            });
        }
        let mut level = [0u8; N];
        for (i, (d, p)) in level.iter_mut().zip(picked).enumerate() {
            let Ok(id) = u8::try_from(i).map(SeqId) else {
                continue;
            };
            if p {
                // Up the caller links (at most MAX_DEPTH): the depth, and whether the
                // target is on the way.
                let mut below = target.is_none_or(|t| t == id);
                let mut depth: u8 = 1;
                let mut at = id;
                for _ in 0..MAX_DEPTH {
                    let Some(up) = links.get(at.index()).and_then(|l| l.get()) else {
                        break;
                    };
                    below |= Some(up) == target;
                    depth = depth.saturating_add(1);
                    at = up;
                }
                if below {
                    *d = depth;
                }
            }
        }
        level
    }
}
