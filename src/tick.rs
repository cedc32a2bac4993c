//! The heartbeat: `Sequencer::tick`, called from a periodic timer interrupt.
//!
//! The tick is the only place where sequences are stopped: it applies requests (pause,
//! resume, abort, abort-all), evaluates the monitors and timeouts that are due, starts
//! exception sequences, applies behaviours, and wakes exactly the lanes that must act.
//! User conditions and cleanup hooks run outside the critical sections.

use crate::control_block::{after, flag, request};
use crate::lock::Lock;
use crate::monitor::Entry;
use crate::sequencer::Inner;
use crate::sequencer::{Gate, Mode};
use crate::{Behaviour, Cause, Instant, Monitors, RunningState, SeqId, Sequencer, MAX_DEPTH};

/// `depth + 1` of the deepest possible sequence.
const DEPTH_LIMIT: u8 = MAX_DEPTH as u8 + 1;

/// What the due scan saw of one sequence.
#[derive(Clone, Copy, Default)]
pub(crate) struct Due {
    pub(crate) due: bool,
    /// The timeout deadline has passed (checked after the monitors).
    pub(crate) expired: bool,
    /// A polled condition is due: wake the lane (after the monitors).
    pub(crate) wake: bool,
    pub(crate) epoch: u16,
}

/// Restart bookkeeping of one monitor (or timeout monitor).
struct RestartBook {
    restarts: u8,
    runs_seen: u16,
    limit: u8,
}

impl<C, const N: usize, const T: usize, L: Lock> Sequencer<C, N, T, L> {
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
            (core::mem::take(&mut s.work), now_us >= s.next_due)
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
        let mut due = [Due::default(); N];
        let mut any_held = self.scan(now_us, &mut due);
        // The hot loop: one condition per due monitor, firing is the rare, out-of-line path.
        for entry in monitors.entries.iter_mut() {
            let Some(d) = due.get(entry.owner.index()) else {
                continue;
            };
            if !d.due {
                continue;
            }
            if entry.epoch_seen != d.epoch {
                // A new run or restart of the owner: the edge starts from "false".
                entry.epoch_seen = d.epoch;
                entry.last = false;
            }
            let value = entry.def.condition.validate(control, now);
            let last = core::mem::replace(&mut entry.last, value);
            if entry.def.trigger.fires(last, value) {
                self.fire(entry, control);
                any_held = true;
            }
        }
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        for (i, d) in due.iter().enumerate() {
            if d.expired {
                if let Ok(id) = u8::try_from(i).map(SeqId) {
                    self.timeout(id, control);
                    any_held = true;
                }
            }
        }
        self.wake_due(&due, any_held);
    }

    /// Marks due sequences, advances their polling schedule, notes due exit-condition
    /// polls and expired timeouts, and recomputes `next_due`: one short section per
    /// registered sequence, or one for all with a coarse lock. Returns whether any sequence
    /// is paused or handling an exception (only then can a sequence be frozen by a held
    /// caller).
    fn scan(&self, now: u64, due: &mut [Due; N]) -> bool {
        // (earliest next poll, anything held) folded over the active sequences.
        let fold = |acc: (u64, bool), seen: Option<(u64, bool)>| match seen {
            Some((next, held)) => (acc.0.min(next), acc.1 | held),
            None => acc,
        };
        if L::COARSE {
            self.with(|s| {
                let count = usize::from(s.count);
                let (next_due, any_held) = due
                    .iter_mut()
                    .enumerate()
                    .take(count)
                    .fold((u64::MAX, false), |acc, (i, d)| {
                        fold(acc, s.scan_one(i, now, d))
                    });
                s.next_due = next_due;
                any_held
            })
        } else {
            let count = self.with(|s| usize::from(s.count));
            let (next_due, any_held) = due
                .iter_mut()
                .enumerate()
                .take(count)
                .fold((u64::MAX, false), |acc, (i, d)| {
                    fold(acc, self.with(|s| s.scan_one(i, now, d)))
                });
            self.with(|s| s.next_due = next_due);
            any_held
        }
    }

    /// Wakes the lanes whose polled condition is due, unless the sequence is held or frozen
    /// by a caller it blocks (paused, or holding for an exception): such a lane is woken
    /// when it may go on. Nothing can be held unless `any_held`.
    fn wake_due(&self, due: &[Due; N], any_held: bool) {
        let one = |s: &mut Inner<C, N, T>, id: SeqId| {
            if !any_held || (s.gate(id) == Gate::Go && !s.blocked_by_held_caller(id)) {
                s.wake(id);
            }
        };
        let ids = due
            .iter()
            .enumerate()
            .filter(|(_, d)| d.wake)
            .filter_map(|(i, _)| u8::try_from(i).ok().map(SeqId));
        if L::COARSE {
            self.with(|s| ids.for_each(|id| one(s, id)));
        } else {
            ids.for_each(|id| self.with(|s| one(s, id)));
        }
    }

    /// A monitor triggered: raise its exception (out of the hot loop).
    #[inline(never)]
    fn fire<K>(&self, entry: &mut Entry<'_, C, K>, control: &C) {
        let mut book = RestartBook {
            restarts: entry.restarts,
            runs_seen: entry.target_runs_seen,
            limit: entry.def.restart_limit,
        };
        let cause = Cause::Monitor(crate::MonitorId(entry.index));
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
                b.timeout_exception,
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
            let b = s.block(owner).ok()?;
            if !b.accepts_exception() {
                return None;
            }
            let target = if behaviour.targets_caller() {
                b.caller().unwrap_or(owner)
            } else {
                owner
            };
            Some((target, s.block(target).ok()?.counters.runs))
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
        let deferred = self.with(|s| {
            if let Ok(b) = s.block_mut(owner) {
                b.set(flag::EXCEPTION_ACTIVE, true);
                b.active_exception = Some(cause);
                b.counters.exceptions = b.counters.exceptions.wrapping_add(1);
            }
            let Some(e) = exception else { return false };
            if s.begin(e, Some(owner), Mode::Lane, cause).is_err() {
                s.exceptions_not_run = s.exceptions_not_run.saturating_add(1);
                return false;
            }
            if let Ok(eb) = s.block_mut(e) {
                eb.exception_of = Some(owner);
            }
            if let Ok(b) = s.block_mut(owner) {
                b.pending = Some((behaviour, target, cause));
            }
            true
        });
        if !deferred {
            self.apply(control, owner, behaviour, target, cause);
        }
        true
    }

    /// Applies a behaviour after an exception (and its exception sequence) of `owner`.
    fn apply(&self, control: &C, owner: SeqId, behaviour: Behaviour, target: SeqId, cause: Cause) {
        match behaviour {
            Behaviour::Nothing => self.with(|s| {
                if let Ok(b) = s.block_mut(owner) {
                    b.set(flag::EXCEPTION_ACTIVE, false);
                }
                s.wake(owner);
            }),
            Behaviour::AbortOwner | Behaviour::AbortCallerOfOwner => {
                self.tear_down(control, target, cause, false)
            }
            Behaviour::RestartOwner | Behaviour::RestartCallerOfOwner => {
                self.tear_down(control, target, cause, true)
            }
        }
    }

    /// Aborts `target` and every active sub-sequence of it (blocking and non-blocking),
    /// innermost first, each through `Aborting` (cleanup hook) to `Aborted`. With `restart`,
    /// the target itself goes to `Restarting` instead.
    fn tear_down(&self, control: &C, target: SeqId, cause: Cause, restart: bool) {
        // depth + 1 of each affected sequence, 0 = unaffected.
        let mut affected = [0u8; N];
        for (i, a) in affected.iter_mut().enumerate() {
            self.with(|s| {
                let Some(b) = s.blocks.get(i).filter(|_| i < usize::from(s.count)) else {
                    return;
                };
                let hit = i == target.index() || b.descends_from(target);
                if hit && b.state.is_active() && b.state != RunningState::Aborting {
                    *a = b.depth.saturating_add(1);
                }
            });
        }
        for depth in (1..=DEPTH_LIMIT).rev() {
            for (i, a) in affected.iter().enumerate() {
                let Ok(id) = u8::try_from(i).map(SeqId) else {
                    continue;
                };
                if *a != depth {
                    continue;
                }
                if restart && id == target {
                    self.stop(control, id, cause, RunningState::Restarting);
                } else {
                    self.stop(control, id, cause, RunningState::Aborting);
                }
            }
        }
    }

    /// Moves one sequence to `Aborting → Aborted` or to `Restarting`, running its hook.
    fn stop(&self, control: &C, id: SeqId, cause: Cause, to: RunningState) {
        let hook = self.with(|s| {
            if !s.transition(id, to, cause) {
                return None;
            }
            if let Ok(b) = s.block_mut(id) {
                b.last_cause = cause;
                b.requests = 0;
            }
            Some(s.hooks.get(id.index()).copied().flatten())
        });
        let Some(hook) = hook else { return };
        if let Some(h) = hook {
            h(control);
        }
        self.with(|s| {
            if to == RunningState::Aborting && s.transition(id, RunningState::Aborted, cause) {
                // A blocking sequence's framework is dropped by its aborted caller and never
                // reports back, so the outcome is recorded here.
                if let Ok(b) = s.block_mut(id) {
                    b.outcome = Some(crate::Outcome::Aborted(cause));
                    if let Some(j) = b.joiner.take() {
                        s.wake(j);
                    }
                }
            }
            s.wake(id);
        });
    }

    /// Aborts every active sequence, innermost first.
    #[inline(never)]
    fn apply_abort_all(&self, control: &C) {
        let count = self.with(|s| s.count);
        for depth in (0..=MAX_DEPTH as u8).rev() {
            for id in (0..count).map(SeqId) {
                let hit = self.with(|s| {
                    s.block(id)
                        .is_ok_and(|b| b.depth == depth && b.state.is_active())
                });
                if hit {
                    self.stop(control, id, Cause::AbortAll, RunningState::Aborting);
                }
            }
        }
    }

    /// Applies finished exception sequences and abort/pause/resume requests.
    fn apply_requests(&self, control: &C) {
        let count = self.with(|s| s.count);
        for i in 0..count {
            let id = SeqId(i);
            let (req, done) = self.with(|s| {
                let Ok(b) = s.block_mut(id) else {
                    return (0, None);
                };
                let req = core::mem::take(&mut b.requests);
                let done = if b.has(flag::EXCEPTION_DONE) {
                    b.set(flag::EXCEPTION_DONE, false);
                    b.pending.take()
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
                self.tear_down(control, id, Cause::Abort, false);
            } else if req & request::PAUSE != 0 {
                self.pause_tree(id, true);
            } else if req & request::RESUME != 0 {
                self.pause_tree(id, false);
            }
        }
    }

    /// Pauses (or resumes) `target` and the sequences it blocks in its lane.
    fn pause_tree(&self, target: SeqId, pause: bool) {
        let (from, to, cause) = if pause {
            (RunningState::Running, RunningState::Paused, Cause::Pause)
        } else {
            (RunningState::Paused, RunningState::Running, Cause::Resume)
        };
        let Some((root, depth)) = self.with(|s| {
            s.block(target)
                .ok()
                .filter(|b| b.state == from)
                .map(|b| (b.root, b.depth))
        }) else {
            return;
        };
        for d in depth..=MAX_DEPTH as u8 {
            let count = self.with(|s| s.count);
            for i in 0..count {
                let id = SeqId(i);
                self.with(|s| {
                    let now = s.now;
                    let Ok(b) = s.block(id) else { return };
                    let inside = id == target
                        || (b.root == root
                            && b.depth > depth
                            && b.stack.get(usize::from(depth)) == Some(&target.0));
                    if !(inside && b.depth == d && b.state == from) {
                        return;
                    }
                    if s.transition(id, to, cause) {
                        if let Ok(b) = s.block_mut(id) {
                            // A paused timeout keeps its remaining time, not a deadline.
                            if b.has(flag::TIMEOUT_ARMED) {
                                b.deadline = if pause {
                                    let left = b.deadline.wrapping_sub(now as u32);
                                    if left >= 0x8000_0000 {
                                        0
                                    } else {
                                        left
                                    }
                                } else {
                                    after(now, b.deadline)
                                };
                            }
                        }
                        s.wake(id);
                    }
                });
            }
        }
    }
}
