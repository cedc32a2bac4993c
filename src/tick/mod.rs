//! The heartbeat: [`Sequencer::tick`], called from a periodic timer interrupt.
//!
//! The tick is where sequences are stopped (the one exception: a run whose future was
//! dropped is torn down from its `Drop`): it applies requests (pause, resume, abort,
//! abort-all), evaluates the monitors and timeouts that are due, starts exception
//! sequences, applies behaviours, and wakes exactly the lanes that must act. User
//! conditions and cleanup hooks run between sections, wakers once the state's borrow has
//! ended (with a coarse lock still inside the lock's section).
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | the tick's order of work, word by word; the fold of the changed sequences |
//! | `table.rs` | the monitor table a sequencer is ticked with, bound by the first due tick that brings a non-empty one |
//! | `schedule.rs` | polling classes: one grid per polling period |
//! | `polls.rs` | which polls are due in a word, their expired timeouts; the due polls a hold skips |
//! | `wake.rs` | the wake-ups of due exit-condition polls, without the held sequences and those the tick changed |
//! | `monitors.rs` | monitor evaluation in groups, edges and triggers; the firings (`fire_group`, `fire`, `hold_owner`, `release_pending`) |
//! | `exception.rs` | a firing: the mark, the exception sequence, the behaviour |
//! | `hold.rs` | a `PauseOwner` monitor's hold and release |
//! | `requests.rs` | abort-all, pause, resume and abort requests, ended exception sequences' behaviours |
//! | `teardown.rs` | aborts and restarts of a sequence and those below it, abort-all, dropped runs |
//! | `pause.rs` | pauses and resumes of a sequence and its blocking children |
//! | `walk.rs` | what teardowns and pauses share: the sequences below a target, by depth |

use core::sync::atomic::{AtomicBool, Ordering};

use crate::lock::Lock;
use crate::model::set::Words;
use crate::model::time::{Stamp, MAX_INTERVAL, NEVER_AHEAD};
use crate::sequencer::sets::Set;
use crate::{Cause, Error, Instant, Monitors, Sequencer};

mod exception;
mod hold;
mod monitors;
mod pause;
mod polls;
mod requests;
pub(crate) mod schedule;
mod table;
mod teardown;
mod wake;
mod walk;

pub(crate) use polls::{skip_untaken_polls, Polls};
use schedule::Scan;

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// The heartbeat (one call per timer interrupt): sets the sequencer time to `now`, applies
    /// pending requests, evaluates the monitors and timeouts of every sequence whose polling
    /// period is due, and wakes the lanes that must act.
    ///
    /// A tick with nothing due (and no state change since the last one) returns after one
    /// short critical section. A tick with a time earlier than the last tick's returns
    /// [`Error::TickBeforeLast`]: time does not go back, so it evaluates nothing, but it
    /// carries out the requests and abort-alls made since the last tick, at the last
    /// tick's time, so a broken time base never holds off the safety system's abort-all.
    /// A sequencer has one heartbeat: a tick while another tick of it is under way (a
    /// second task that ticks it, or a condition, cleanup hook or waker of the tick that
    /// does) does nothing and returns [`Error::TickInProgress`].
    ///
    /// A sequencer is ticked with one monitor table, and a table belongs to one sequencer
    /// (its owners are that sequencer's ids). The first non-empty table that comes with a
    /// due tick becomes the sequencer's; keep it in one place (a `static`, an RTIC
    /// resource, a local of the function that ticks). A tick with polls due and another
    /// table, or with the table of another sequencer, would take polls that the
    /// sequencer's table then misses: it returns [`Error::ForeignMonitorTable`] and
    /// evaluates nothing (it carries out the requests and abort-alls, as a late tick
    /// does). A table made anew in the place of the sequencer's is its table, and so is
    /// its table after the sequencer moved (a table knows its sequencer by a tag, given at
    /// the first registration, not by its address).
    ///
    /// `now` is a monotonic 64-bit count of µs (extend a 32-bit hardware timer, as RTIC's
    /// monotonics do). The sequencer's time is that of its last tick, 0 before the first: a
    /// sequence started before the first tick starts at 0, and its run clock counts from
    /// there (with a time base that is not near 0 then, tick once before the start). Run
    /// clocks keep 48 bits of µs; the polling grids keep 32 and compare them by wrapping
    /// difference, so a tick 2^31 µs (about 35.8 minutes) or more after the last one (the
    /// first tick after time 0 included), which a periodic timer interrupt never makes,
    /// cannot tell their polls ahead from behind: it polls every class at once, and its
    /// grid starts again from that tick. In a
    /// sequencer of more than 32 sequences (sets of `B > 1` words) the tick visits only the
    /// words of 32 ids that hold a sequence under way, lowest first, and in each does what
    /// the tick of a sequencer of 32 does: monitors in table order, then timeouts, then
    /// wake-ups. With any number of words, the releases of `PauseOwner` monitors whose
    /// condition cleared come last, once every word's holds are made.
    ///
    /// ```
    /// use rtseq::{Instant, Monitors, Sequencer};
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// seq.tick(Instant::from_ticks(1_000), &(), &mut monitors).unwrap();
    /// assert_eq!(seq.now().as_ticks(), 1_000);
    /// let late = seq.tick(Instant::from_ticks(400), &(), &mut monitors);
    /// assert_eq!(late, Err(rtseq::Error::TickBeforeLast));
    /// assert_eq!(seq.now().as_ticks(), 1_000);
    /// ```
    ///
    /// ```
    /// use rtseq::{Behaviour, Error, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let run = seq.register(SeqConfig::new("run")).unwrap();
    /// seq.sequence_by_id(run).unwrap().declare_lane().unwrap();
    /// seq.sequence_by_id(run).unwrap().start().unwrap();
    /// let (mut jam, mut also_jam) = (|_: &(), _: Instant| false, |_: &(), _: Instant| false);
    /// let mut monitors: Monitors<(), 1> = Monitors::new();
    /// monitors.add(run, Monitor::new("jam", &mut jam, Behaviour::AbortOwner)).unwrap();
    /// let mut other: Monitors<(), 1> = Monitors::new();
    /// other.add(run, Monitor::new("jam", &mut also_jam, Behaviour::AbortOwner)).unwrap();
    /// let ms = |n: u64| Instant::from_ticks(n * 1_000);
    /// seq.tick(ms(1), &(), &mut monitors).unwrap(); // the sequencer's table from now on
    /// assert_eq!(seq.tick(ms(2), &(), &mut other), Err(Error::ForeignMonitorTable));
    /// assert_eq!(seq.tick(ms(2), &(), &mut monitors), Ok(()));
    /// ```
    pub fn tick<const M: usize, K: crate::Condition<C>>(
        &self,
        now: Instant,
        control: &C,
        monitors: &mut Monitors<'_, C, M, K>,
    ) -> Result<(), Error> {
        // A tick out of step with the last one (see `Opening::out_of_step`) that is a long
        // gap restarts the polling grids and opens again, keeping its turn: a second tick
        // meanwhile is refused as in any other section of this one.
        let mut reopening = false;
        let (opening, _turn) = loop {
            let first = self.with(|s| {
                // One tick at a time: a second one would walk and scan beside the first.
                if !reopening {
                    if self.ticking.load(Ordering::Relaxed) {
                        return None;
                    }
                    self.ticking.store(true, Ordering::Relaxed);
                }
                Some(s.open_tick(now, monitors))
            });
            let Some(opening) = first else {
                return Err(Error::TickInProgress);
            };
            let turn = TickTurn(&self.ticking);
            if opening.out_of_step && self.restart_stale_grids(now) {
                // The turn stays taken for the section that opens again.
                core::mem::forget(turn);
                reopening = true;
                continue;
            }
            break (opening, turn);
        };
        let Opening {
            out_of_step,
            foreign,
            mut requests,
            any_due,
            changed,
            mut words,
        } = opening;
        if out_of_step || foreign {
            self.carry_out_requests(control);
            return Err(if out_of_step {
                Error::TickBeforeLast
            } else {
                Error::ForeignMonitorTable
            });
        }
        let inbox = self.take_inbox();
        if changed {
            // Folding reports the ends of exception sequences: their owners are requested.
            let requested;
            (words, requested) = self.fold_changed();
            requests |= requested;
        }
        let aborted_all = match inbox {
            Some(inbox) => self.apply_inbox(control, inbox),
            None => false,
        };
        if requests {
            self.apply_requests(control);
        }
        if !any_due {
            return Ok(());
        }
        if aborted_all || requests {
            // What they stopped or paused is not due any more.
            words = self.fold_changed().0;
        }
        let mut scan = Scan::new();
        let mut found = Found::default();
        if B == 1 {
            self.tick_word(0, now, &mut scan, &mut found, monitors, control);
            if found.releasing {
                self.release_pending(monitors.entries.as_mut_slice());
            }
            return Ok(());
        }
        // With no sequence under way the first section's horizon stands.
        for w in words {
            self.tick_word(w, now, &mut scan, &mut found, monitors, control);
        }
        // Once every word's holds are made: a hold in a later word of the owner, or of a
        // sequence its release would resume, keeps it paused rather than paused again.
        if found.releasing {
            self.release_pending(monitors.entries.as_mut_slice());
        }
        Ok(())
    }

    /// The work of a tick that evaluates nothing (its time went back, or it came with
    /// another sequencer's or another monitor table): the abort-all and the requests made
    /// since the last tick, at the last tick's time. A broken time base or a misused table
    /// must not hold off the safety system's abort-all.
    #[cold]
    #[inline(never)]
    fn carry_out_requests(&self, control: &C) {
        let inbox = self.take_inbox();
        self.fold_changed();
        if let Some(inbox) = inbox {
            self.apply_inbox(control, inbox);
        }
        self.apply_requests(control);
    }

    /// A tick 2^31 µs or more after the last one (the first after time 0 included): the
    /// polling grids' 32-bit stamps no longer tell ahead from behind (a stale one may read
    /// as due in a moment, or in 35 minutes). Moves the time to `now`, makes the scan come
    /// now and marks every class's grid stale; then restarts each grid still stale from
    /// now, one section per class (a start that placed a grid meanwhile, at `now`, cleared
    /// its mark), so every class is due now. Returns whether it did: a tick out of step
    /// the other way is late.
    #[cold]
    #[inline(never)]
    fn restart_stale_grids(&self, now: Instant) -> bool {
        let stamp = Stamp::of(now);
        let classes = self.with(|s| {
            let long_gap = now > s.now;
            if long_gap {
                s.now = now;
                s.polling.next_due = stamp;
                s.polling.stale = s.polling.classes.used();
                // A start scheduled before this, at the old time, schedules again.
                s.changes = s.changes.wrapping_add(1);
            }
            long_gap.then(|| s.polling.classes.len())
        });
        let Some(classes) = classes else {
            return false;
        };
        for index in 0..classes {
            let bit = 1 << (index & 7);
            self.with(|s| {
                if s.polling.stale & bit != 0 {
                    s.polling.stale &= !bit;
                    s.polling.classes.restart_grid(index, stamp);
                }
            });
        }
        true
    }

    /// The tick's work in word `w` of the sets: the scan of the polling classes, the
    /// monitors of the due sequences, their expired timeouts and the wake-ups of their due
    /// exit-condition polls. `found`: what the words before found, and now this one too.
    #[inline(always)]
    fn tick_word<const M: usize, K: crate::Condition<C>>(
        &self,
        w: usize,
        now: Instant,
        scan: &mut Scan,
        found: &mut Found,
        monitors: &mut Monitors<'_, C, M, K>,
        control: &C,
    ) {
        let (polls, expired) = self.scan(w, Stamp::of(now), scan);
        let evaluation = self.evaluate_monitors(&polls, monitors, control, now);
        found.releasing |= evaluation.releasing;
        let mut raised = found.raised || evaluation.fired;
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        for id in expired {
            // The timeout's configuration is fixed: read once.
            if let Some(reaction) = self.with(|s| s.block(id).map(|b| b.timeout_reaction())) {
                self.raise(control, id, Cause::Timeout(id), &reaction);
            }
            raised = true;
        }
        self.wake_due_polls(polls.wake(), raised);
        found.raised = raised;
    }

    /// Folds the state of the sequences that changed into the sets `Monitored`, `Paused` and
    /// `Live`, one short section per sequence. Returns the words that then hold a sequence
    /// under way, and whether any sequence is requested (the owner of an exception
    /// sequence that ended is).
    fn fold_changed(&self) -> (Words, bool) {
        let mut reported = false;
        loop {
            // Each section says whether more are left.
            let (ended, more) = self.with(|s| {
                let changed = s.sets.pop(Set::Changed);
                if let Some(id) = changed {
                    s.fold(id);
                }
                let ended = changed.filter(|&id| s.exception_run_ended(id));
                (ended, !s.sets.is_empty(Set::Changed))
            });
            // The exception sequence cannot start again before this report (its
            // `HANDLES_EXCEPTION`), so its caller link still names its owner; a lane above
            // may have moved the owner in between, and the report credits only a behaviour
            // of the owner's that waits for this sequence (`exception_ended`).
            if let Some(e) = ended {
                self.with(|s| s.exception_ended(e));
                reported = true;
            }
            if !more {
                break;
            }
        }
        self.with(|s| {
            let requested = !s.sets.is_empty(Set::Requested);
            (s.sets.words(Set::Live), requested || reported)
        })
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize>
    crate::sequencer::State<C, N, T, W, B>
{
    /// The work of a tick's first section after it took its turn: moves the time to `now`
    /// unless the tick is out of step or comes with a foreign table (polls due), puts the
    /// next due time off to the horizon when polls are due, and finds what the tick must
    /// do.
    #[inline(always)]
    fn open_tick<const M: usize, K>(
        &mut self,
        now: Instant,
        monitors: &mut Monitors<'_, C, M, K>,
    ) -> Opening {
        let stamp = Stamp::of(now);
        // Back in time, or 2^31 µs or more ahead (not a wrapping difference: near the end
        // of u64 an earlier time would read as a step forward).
        let out_of_step = now < self.now || now.as_ticks() - self.now.as_ticks() > MAX_INTERVAL;
        let any_due = stamp.reached(self.polling.next_due);
        let foreign = any_due && !out_of_step && !self.takes_polls(monitors);
        if !out_of_step && !foreign {
            self.now = now;
            if any_due {
                // The scans bring it forward again, and so does a start made meanwhile
                // (see `scan`).
                self.polling.next_due = stamp.plus(NEVER_AHEAD);
            }
        }
        self.changes = self.changes.wrapping_add(1);
        Opening {
            out_of_step,
            foreign,
            requests: !self.sets.is_empty(Set::Requested),
            any_due,
            changed: !self.sets.is_empty(Set::Changed),
            words: self.sets.words(Set::Live),
        }
    }
}

/// What the words a tick visited so far found.
#[derive(Default)]
struct Found {
    /// A monitor fired or a timeout expired: a wake-up checks that its sequence is not
    /// held, as it does while a monitored sequence is paused or handles an exception.
    raised: bool,
    /// A `PauseOwner` monitor's condition cleared: its owner is released once every
    /// word's monitors are evaluated.
    releasing: bool,
}

/// What a tick's first section finds.
struct Opening {
    /// The tick's time is before the last tick's (a late tick), or 2^31 µs or more after
    /// it (a long gap, after which the tick opens again).
    out_of_step: bool,
    /// Polls are due, and the monitor table is not the one the sequencer evaluates.
    foreign: bool,
    /// Some sequence has a request queued (`Set::Requested`).
    requests: bool,
    /// Polls are due: the scheduling horizon has been reached.
    any_due: bool,
    /// Some sequence changed state since the last fold (`Set::Changed`).
    changed: bool,
    /// The words of the sets that hold a sequence under way (the polling classes keep
    /// their grids there), as of the last fold.
    words: Words,
}

/// The turn of the tick under way: when the tick returns, the next one may begin.
struct TickTurn<'a>(&'a AtomicBool);

impl Drop for TickTurn<'_> {
    fn drop(&mut self) {
        // Release: the next tick, on another core, sees what this one did.
        self.0.store(false, Ordering::Release);
    }
}
