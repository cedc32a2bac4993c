//! The heartbeat: [`Sequencer::tick`], called from a periodic timer interrupt.
//!
//! The tick is the only place where sequences are stopped: it applies requests (pause,
//! resume, abort, abort-all), evaluates the monitors and timeouts that are due, starts
//! exception sequences, applies behaviours, and wakes exactly the lanes that must act.
//! User conditions, cleanup hooks and wakers run outside the sections.
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | the tick's order of work; which polls are due; the wake-ups of due exit-condition polls |
//! | `schedule.rs` | polling classes: one grid per polling period |
//! | `monitors.rs` | monitor evaluation in groups, edges and triggers |
//! | `exception.rs` | a firing: the mark, the exception sequence, the behaviour, requests |
//! | `teardown.rs` | aborts, restarts, pauses and resumes of a sequence and those below it |

use crate::lock::Lock;
use crate::model::set::SeqSet;
use crate::model::time::{Stamp, NEVER_AHEAD};
use crate::sequencer::callers::held;
use crate::sequencer::lanes::{LaneSet, NO_WAKER};
use crate::sequencer::State;
use crate::{Cause, Instant, Monitors, SeqId, Sequencer};

mod exception;
mod monitors;
pub(crate) mod schedule;
mod teardown;

use schedule::Due;

/// What the tick must do for the sequences whose poll is due.
pub(crate) struct Polls<const B: usize> {
    /// Active sequences whose polling class is due: their monitors are evaluated.
    pub(crate) due: SeqSet<B>,
    /// Due in a new run or restart: their monitors' edge detection starts from "false".
    pub(crate) fresh: SeqSet<B>,
    /// Running, due, with an expired timeout (raised after the monitors).
    expired: SeqSet<B>,
    /// Running, due, waiting for a polled condition: their lanes are woken (after the
    /// monitors).
    wake: SeqSet<B>,
    /// Some active sequence is paused or handles an exception: a wake-up checks that its
    /// sequence is not held.
    careful: bool,
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// The due polls `due` (active sequences whose polling class is due): takes their
    /// fresh marks and marks their due exit-condition polls. Returns what to do, without
    /// the expired timeouts, and the running ones with an armed timeout.
    #[inline(always)]
    fn take_polls(&mut self, due: SeqSet<B>) -> (Polls<B>, SeqSet<B>) {
        let sets = &mut self.sets;
        let running = due.minus(&sets.paused);
        let fresh = sets.fresh.and(&due);
        sets.fresh = sets.fresh.minus(&due);
        let wake = running.and(&sets.poll_wait);
        sets.poll_due = sets.poll_due.or(&wake);
        let polls = Polls {
            due,
            fresh,
            expired: SeqSet::EMPTY,
            wake,
            careful: sets.paused.or(&sets.excepting).meets(&sets.active),
        };
        (polls, running.and(&sets.armed))
    }

    /// Those of `wake` that are not held (see [`held`]), in one section.
    fn unheld(&self, wake: SeqSet<B>) -> SeqSet<B> {
        let mut out = wake;
        for id in wake {
            let lane = self.lane_slot(id);
            if held(id, |c| self.held_step(c, lane)) {
                out.remove(id);
            }
        }
        out
    }

    /// Those of `timed` whose timeout deadline has passed at `now`.
    fn expired(&self, timed: SeqSet<B>, now: Stamp) -> SeqSet<B> {
        let mut out = SeqSet::EMPTY;
        for id in timed {
            if self.block(id).is_ok_and(|b| now.reached(Stamp(b.deadline))) {
                out.insert(id);
            }
        }
        out
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// The heartbeat (one call per timer interrupt): sets the sequencer time to `now`, applies
    /// pending requests, evaluates the monitors and timeouts of every sequence whose polling
    /// period is due, and wakes the lanes that must act.
    ///
    /// A tick with nothing due (and no state change since the last one) returns after one
    /// short critical section.
    ///
    /// ```
    /// use rtseq::{Instant, Monitors, Sequencer};
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
        let stamp = Stamp::of(now);
        let abort_all = self.take_abort_all();
        let (requests, any_due, changed) = self.with(|s| {
            s.now = now;
            (
                !s.sets.requested.is_empty(),
                stamp.reached(s.polling.next_due),
                s.sets.changed.take_all(),
            )
        });
        self.fold(changed);
        if abort_all {
            self.apply_abort_all(control);
        }
        if requests {
            self.apply_requests(control);
        }
        if !any_due {
            return;
        }
        if abort_all || requests {
            // What they stopped or paused is not due any more.
            self.fold(self.with(|s| s.sets.changed.take_all()));
        }
        let polls = self.scan(stamp);
        let mut careful = polls.careful;
        if self.evaluate_monitors(&polls, monitors, control, now) {
            careful = true;
        }
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        for id in polls.expired {
            // The configuration is fixed and its bookkeeping is the tick's: read once.
            if let Some(mut reaction) =
                self.with(|s| s.block(id).ok().map(|b| b.timeout_reaction()))
            {
                self.raise(control, id, Cause::Timeout(id), &mut reaction);
            }
            careful = true;
        }
        if !polls.wake.is_empty() {
            if L::COARSE {
                // One section: the held check walks the callers inside it.
                self.update_and_wake(|s| {
                    let wake = if careful {
                        s.unheld(polls.wake)
                    } else {
                        polls.wake
                    };
                    s.lanes_of_polls(wake, &self.lanes)
                });
            } else {
                self.wake_lanes(self.lanes_of_polls(polls.wake, careful));
            }
        }
    }

    /// Folds the state of the sequences `changed` into the sets `active` and `paused`, one
    /// short section per sequence.
    fn fold(&self, changed: SeqSet<B>) {
        for id in changed {
            self.with(|s| s.fold(id));
        }
    }

    /// Finds the due polls: advances the schedules of the polling classes that are due,
    /// recomputes the next due time, takes the due sequences' fresh marks, marks their
    /// due exit-condition polls and finds their expired timeouts. With a coarse lock in
    /// one section; otherwise one short section per class and per armed timeout.
    #[inline(always)]
    fn scan(&self, now: Stamp) -> Polls<B> {
        let mut due = Due {
            sequences: SeqSet::EMPTY,
            ahead: u32::MAX,
        };
        let next_due = |ahead: u32| now.plus(ahead.min(NEVER_AHEAD));
        if L::COARSE {
            return self.with(|s| {
                s.polling.classes.scan_all(now, &s.sets.active, &mut due);
                s.polling.next_due = next_due(due.ahead);
                let (mut polls, timed) = s.take_polls(due.sequences);
                polls.expired = s.expired(timed, now);
                polls
            });
        }
        let classes = self.with(|s| s.polling.classes.len());
        for i in 0..classes {
            self.with(|s| s.polling.classes.scan(i, now, &s.sets.active, &mut due));
        }
        let (mut polls, timed) = self.with(|s| {
            s.polling.next_due = next_due(due.ahead);
            s.take_polls(due.sequences)
        });
        for id in timed {
            polls.expired = polls
                .expired
                .or(&self.with(|s| s.expired(SeqSet::of(id), now)));
        }
        polls
    }

    /// With a portable lock: the lanes whose polled condition is due, except those held
    /// (checked only when `careful`: after a monitor fired or while something is held), in
    /// short sections. Lanes joined in one task share their waker, which is woken once.
    #[inline(never)]
    fn lanes_of_polls(&self, wake: SeqSet<B>, careful: bool) -> LaneSet {
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

    /// Whether sequence `id` is held, or frozen by a caller it blocks: one short section
    /// per caller.
    fn held(&self, id: SeqId) -> bool {
        let lane = self.with(|s| s.lane_slot(id));
        held(id, |c| self.with(|s| s.held_step(c, lane)))
    }
}
