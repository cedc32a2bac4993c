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
//! | `mod.rs` | the tick's order of work; which polls are due; the wake-ups of due exit-condition polls |
//! | `schedule.rs` | polling classes: one grid per polling period |
//! | `monitors.rs` | monitor evaluation in groups, edges and triggers |
//! | `exception.rs` | a firing: the mark, the exception sequence, the behaviour |
//! | `requests.rs` | abort-all, pause, resume and abort requests, ended exception sequences' behaviours |
//! | `teardown.rs` | aborts and restarts of a sequence and those below it, abort-all, dropped runs |
//! | `pause.rs` | pauses and resumes of a sequence and its blocking children |
//! | `walk.rs` | what teardowns and pauses share: the sequences below a target, by depth |

use core::sync::atomic::{AtomicBool, Ordering};

use crate::lock::Lock;
use crate::model::set::{SeqSet, SetWord, Words};
use crate::model::time::{Stamp, NEVER_AHEAD};
use crate::sequencer::callers::held;
use crate::sequencer::lanes::{LaneSet, NO_WAKER};
use crate::sequencer::sections::Sections;
use crate::sequencer::sets::Set;
use crate::sequencer::state::WakeMemo;
use crate::sequencer::State;
use crate::{Cause, Error, Instant, Monitors, SeqId, Sequencer};

mod exception;
mod monitors;
mod pause;
mod requests;
pub(crate) mod schedule;
mod teardown;
mod walk;

use schedule::Scan;

/// What the tick must do for the due polls in one word of the sets (the tick visits the
/// words that hold a monitored sequence one at a time).
pub(crate) struct Polls<const B: usize> {
    /// The word of the sets.
    word: usize,
    /// Monitored sequences whose polling class is due: their monitors are evaluated.
    due: u32,
    /// Due in a new run or restart: their monitors' edge detection starts from "false".
    fresh: u32,
    /// Running, due, waiting for a polled condition: their lanes are woken (after the
    /// monitors).
    wake: u32,
}

impl<const B: usize> Polls<B> {
    #[inline(always)]
    pub(crate) fn due(&self) -> SetWord<B> {
        SetWord::new(self.word, self.due)
    }

    #[inline(always)]
    pub(crate) fn fresh(&self) -> SetWord<B> {
        SetWord::new(self.word, self.fresh)
    }

    #[inline(always)]
    fn wake(&self) -> SetWord<B> {
        SetWord::new(self.word, self.wake)
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// The due polls `due` (monitored sequences of one word whose polling class is due):
    /// takes their fresh marks and marks their due exit-condition polls. Returns what to
    /// do for them, and the running ones with an armed timeout.
    #[inline(always)]
    fn take_polls(&mut self, due: SetWord<B>) -> (Polls<B>, SetWord<B>) {
        let w = due.index();
        let sets = &mut self.sets;
        let running = due.minus(sets.word(Set::Paused, w));
        let fresh = sets.word(Set::Fresh, w).and(due);
        sets.remove_all(Set::Fresh, due);
        let wake = running.and(sets.word(Set::PollWait, w));
        sets.insert_all(Set::PollDue, wake);
        let polls = Polls {
            word: w,
            due: due.bits(),
            fresh: fresh.bits(),
            wake: wake.bits(),
        };
        (polls, running.and(sets.word(Set::Armed, w)))
    }

    /// Whether a due tick with `table` may take the due polls: the table is this
    /// sequencer's (it is where the sequencer's table is, and its `ticked_by` is `me`,
    /// this sequencer's address), or the first non-empty table a due tick came with,
    /// which is bound here (both ways); or an empty table while none is bound (it
    /// evaluates nothing, and no table misses the polls). A table that another sequencer
    /// ticks, or any table at another place once one is bound, may not: the polls it took
    /// would be lost to the table that holds their monitors. A table made anew in the
    /// place of the bound one is bound again.
    #[inline(always)]
    fn takes_polls<const M: usize, K>(
        &mut self,
        me: usize,
        table: &mut Monitors<'_, C, M, K>,
    ) -> bool {
        let here = core::ptr::from_ref(table).addr();
        if self.table == here && table.ticked_by == me {
            return true;
        }
        if self.is_foreign(me, table) {
            return false;
        }
        if !table.is_empty() {
            self.table = here;
            table.ticked_by = me;
        }
        true
    }

    /// Whether `table` may not be ticked by this sequencer (`me`, its address): another
    /// table is bound here, or `table` is bound to another sequencer.
    #[inline(always)]
    fn is_foreign<const M: usize, K>(&self, me: usize, table: &Monitors<'_, C, M, K>) -> bool {
        let here = core::ptr::from_ref(table).addr();
        let ours = self.table == 0 || self.table == here;
        !ours || (table.ticked_by != 0 && table.ticked_by != me)
    }

    /// Whether some monitored sequence is paused or handles an exception.
    #[inline(always)]
    fn any_held(&self) -> bool {
        let sets = &self.sets;
        if B == 1 {
            let held = sets.word(Set::Paused, 0).or(sets.word(Set::Excepting, 0));
            return sets.word(Set::Monitored, 0).meets(held);
        }
        // The paused sequences are monitored (both sets are folded from the same states);
        // a sequence that handled an exception may have ended since.
        !sets.is_empty(Set::Paused)
            || sets.words(Set::Excepting).any(|w| {
                sets.word(Set::Excepting, w)
                    .meets(sets.word(Set::Monitored, w))
            })
    }

    /// Those of `wake` that are not held (see [`held`]), in one section.
    fn unheld(&self, wake: SetWord<B>) -> SetWord<B> {
        let mut out = SetWord::empty(wake.index());
        for id in wake {
            let lane = self.lane_slot(id);
            if !held(id, |c| self.held_step(c, lane)) {
                out.insert(id);
            }
        }
        out
    }

    /// Those of `timed` whose timeout has run out at `now`.
    fn expired(&self, timed: SetWord<B>, now: Stamp) -> SetWord<B> {
        let mut out = SetWord::empty(timed.index());
        for id in timed {
            if self.block(id).is_some_and(|b| b.timed_out(now)) {
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
    /// does). A table made anew in the place of the sequencer's is its table.
    ///
    /// `now` is a monotonic 64-bit count of µs (extend a 32-bit hardware timer, as RTIC's
    /// monotonics do). The sequencer keeps its deadlines as 32-bit µs and compares them by
    /// wrapping difference, so it runs for any length of time as long as ticks come less
    /// than 2^31 µs (about 35.8 minutes) apart, which a periodic timer interrupt always
    /// does; after a longer gap, polls and timeouts that fell due in it may come late. In a
    /// sequencer of more than 32 sequences (sets of `B > 1` words) the tick visits only the
    /// words of 32 ids that hold a running or paused sequence, lowest first, and in each does what
    /// the tick of a sequencer of 32 does: monitors in table order, then timeouts, then
    /// wake-ups.
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
        let stamp = Stamp::of(now);
        let me = core::ptr::from_ref(self).addr();
        // The words of the sets that hold a monitored sequence, as of the last fold.
        let first = self.with(|s| {
            // One tick at a time: a second one would walk and scan beside the first.
            if self.ticking.load(Ordering::Relaxed) {
                return None;
            }
            self.ticking.store(true, Ordering::Relaxed);
            let late = now < s.now;
            let any_due = stamp.reached(s.polling.next_due);
            let foreign = any_due && !late && !s.takes_polls(me, monitors);
            if !late && !foreign {
                s.now = now;
                if any_due {
                    // The scans bring it forward again, and so does a start made meanwhile
                    // (see `scan`).
                    s.polling.next_due = stamp.plus(NEVER_AHEAD);
                }
            }
            s.changes = s.changes.wrapping_add(1);
            Some((
                late,
                foreign,
                !s.sets.is_empty(Set::Requested),
                any_due,
                !s.sets.is_empty(Set::Changed),
                s.sets.words(Set::Monitored),
            ))
        });
        let Some((late, foreign, mut requests, any_due, changed, mut words)) = first else {
            return Err(Error::TickInProgress);
        };
        let _turn = TickTurn(&self.ticking);
        if late || foreign {
            self.carry_out_requests(control);
            return Err(if late {
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
        if B == 1 {
            self.tick_word(0, now, &mut scan, false, monitors, control);
            return Ok(());
        }
        let mut raised = false;
        // With no monitored sequence the first section's horizon stands.
        for w in words {
            raised = self.tick_word(w, now, &mut scan, raised, monitors, control);
        }
        Ok(())
    }

    /// Whether a due tick with `table` would be refused with
    /// [`Error::ForeignMonitorTable`]: the simulator's first start asks.
    #[cfg(feature = "std")]
    pub(crate) fn is_foreign_table<const M: usize, K>(
        &self,
        table: &Monitors<'_, C, M, K>,
    ) -> bool {
        let me = core::ptr::from_ref(self).addr();
        self.with(|s| s.is_foreign(me, table))
    }

    /// `table`, bound to this sequencer, is dropped (with the simulator that owned it):
    /// the next table that comes with a due tick is the sequencer's.
    #[cfg(feature = "std")]
    pub(crate) fn release_table<const M: usize, K>(&self, table: &Monitors<'_, C, M, K>) {
        let here = core::ptr::from_ref(table).addr();
        self.with(|s| {
            if s.table == here {
                s.table = 0;
            }
        });
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

    /// The tick's work in word `w` of the sets: the scan of the polling classes, the
    /// monitors of the due sequences, their expired timeouts and the wake-ups of their due
    /// exit-condition polls. `raised`: a monitor fired or a timeout expired in this tick
    /// (in this word or an earlier one), so a wake-up checks that its sequence is not held,
    /// as it does while a monitored sequence is paused or handles an exception. Returns it
    /// for the next word.
    #[inline(always)]
    fn tick_word<const M: usize, K: crate::Condition<C>>(
        &self,
        w: usize,
        now: Instant,
        scan: &mut Scan,
        mut raised: bool,
        monitors: &mut Monitors<'_, C, M, K>,
        control: &C,
    ) -> bool {
        let (polls, expired) = self.scan(w, Stamp::of(now), scan);
        if self.evaluate_monitors(&polls, monitors, control, now) {
            raised = true;
        }
        // Timeouts and exit-condition wake-ups after the monitors: a monitor that fired in
        // the same tick comes first.
        for id in expired {
            // The configuration is fixed and its bookkeeping is the tick's: read once.
            if let Some(mut reaction) = self.with(|s| s.block(id).map(|b| b.timeout_reaction())) {
                self.raise(control, id, Cause::Timeout(id), &mut reaction);
            }
            raised = true;
        }
        if polls.wake != 0 {
            if L::COARSE {
                // One section: the held check walks the callers inside it.
                self.update_and_wake(|s| {
                    let wake = if raised || s.any_held() {
                        let unheld = s.unheld(polls.wake());
                        // A held sequence misses this poll: its mark goes, else it would
                        // take the poll off its grid once it is let go.
                        s.sets.remove_all(Set::PollDue, polls.wake().minus(unheld));
                        // A sequence whose state changed in this tick is not woken
                        // for its poll: the change woke its lane.
                        unheld.minus(s.sets.word(Set::Changed, polls.word))
                    } else {
                        polls.wake()
                    };
                    s.lanes_of_polls(wake, &self.lanes)
                });
            } else {
                self.wake_lanes(self.lanes_to_wake(polls.wake(), raised));
            }
        }
        raised
    }

    /// Folds the state of the sequences that changed into the sets `Monitored`, `Paused` (and,
    /// with several words, `live`), one short section per sequence. Returns the words that
    /// then hold a monitored sequence, and whether any sequence is requested (the owner of
    /// an exception sequence that ended is).
    fn fold_changed(&self) -> (Words, bool) {
        let mut reported = false;
        loop {
            // Each section says whether more are left.
            let (ended, more, words, requested) = self.with(|s| {
                let ended = s.sets.pop(Set::Changed).filter(|&id| s.fold(id));
                let more = !s.sets.is_empty(Set::Changed);
                (
                    ended,
                    more,
                    s.sets.words(Set::Monitored),
                    !s.sets.is_empty(Set::Requested),
                )
            });
            // No lane runs in between: the exception sequence still has its owner.
            if let Some(e) = ended {
                self.with(|s| s.exception_ended(e));
                reported = true;
            }
            if !more {
                return (words, requested || reported);
            }
        }
    }

    /// Finds the due polls in word `w`: advances the schedules of the polling classes that
    /// are due, recomputes the next due time, takes the due sequences' fresh marks, marks
    /// their due exit-condition polls and finds their expired timeouts (raised after the
    /// monitors), which it returns beside the polls. With a coarse lock in one section;
    /// otherwise one short section per class and per armed timeout.
    #[inline(always)]
    fn scan(&self, w: usize, now: Stamp, scan: &mut Scan) -> (Polls<B>, SetWord<B>) {
        // A scan only brings the next due time forward: the tick's first section put it
        // off to the horizon, and a start made since may have brought it forward (an
        // exception sequence the work in an earlier word started, or, with the portable
        // lock, a lane of higher priority that preempted the tick): its first poll, one
        // period after a start into an idle class, is one no scan of this tick sees.
        let next_due = |scan: &Scan, set: Stamp| {
            let found = now.plus(scan.ahead.min(NEVER_AHEAD));
            now.first_of(found, set)
        };
        if L::COARSE {
            return self.with(|s| {
                let due = s
                    .polling
                    .classes
                    .scan_all(now, s.sets.word(Set::Monitored, w), scan);
                s.polling.next_due = next_due(scan, s.polling.next_due);
                let (polls, timed) = s.take_polls(due);
                (polls, s.expired(timed, now))
            });
        }
        let classes = self.with(|s| s.polling.classes.len());
        let mut due = SetWord::empty(w);
        for i in 0..classes {
            due = due.or(self.with(|s| {
                s.polling
                    .classes
                    .scan(i, now, s.sets.word(Set::Monitored, w), scan)
            }));
        }
        let (polls, timed) = self.with(|s| {
            s.polling.next_due = next_due(scan, s.polling.next_due);
            s.take_polls(due)
        });
        let mut expired = SetWord::empty(w);
        for id in timed {
            expired = expired.or(self.with(|s| s.expired(SetWord::of(id), now)));
        }
        (polls, expired)
    }

    /// With a portable lock: the lanes of the due polls `wake`. While something is held
    /// (`raised`, or a paused or excepting monitored sequence) found by a walk that skips the
    /// held ones and those whose state changed in this tick; else those remembered from the
    /// last tick with the same polls, or found by a walk and remembered, unless a lane or
    /// waker changed meanwhile.
    fn lanes_to_wake(&self, wake: SetWord<B>, raised: bool) -> LaneSet {
        let (held, remembered, forgotten, changed) = self.with(|s| {
            let held = raised || s.any_held();
            let changed = s.sets.word(Set::Changed, wake.index());
            (
                held,
                s.polling.remembered(wake),
                s.polling.forgotten,
                changed,
            )
        });
        if held {
            // A held sequence misses this poll: its mark goes, else it would take the poll
            // off its grid once it is let go. A sequence whose state changed in this tick
            // is not woken for its poll: the change woke its lane.
            return self.lanes_of_polls_in_sections(wake, |id| {
                if self.held_in_sections(id) {
                    self.with(|s| s.sets.remove(Set::PollDue, id));
                    return true;
                }
                changed.has(id)
            });
        }
        if let Some(lanes) = remembered {
            return lanes;
        }
        let lanes = self.lanes_of_polls_in_sections(wake, |_| false);
        self.with(|s| {
            if s.polling.forgotten == forgotten {
                s.polling.woken = WakeMemo { polls: wake, lanes };
            }
        });
        lanes
    }

    /// With a portable lock: the lanes whose polled condition is due (`wake`), except those
    /// of the sequences that `skip` leaves out, in short sections. A lane whose waker is the
    /// one just found (lanes joined in one task, in id order) is not woken again; a task
    /// woken twice is still polled once.
    #[inline(never)]
    fn lanes_of_polls_in_sections(
        &self,
        wake: SetWord<B>,
        mut skip: impl FnMut(SeqId) -> bool,
    ) -> LaneSet {
        let mut lanes = LaneSet::EMPTY;
        let mut woken = NO_WAKER;
        for id in wake {
            if skip(id) {
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
    fn held_in_sections(&self, id: SeqId) -> bool {
        let lane = self.with(|s| s.lane_slot(id));
        held(id, |c| self.with(|s| s.held_step(c, lane)))
    }
}

/// The turn of the tick under way: when the tick returns, the next one may begin.
struct TickTurn<'a>(&'a AtomicBool);

impl Drop for TickTurn<'_> {
    fn drop(&mut self) {
        // Release: the next tick, on another core, sees what this one did.
        self.0.store(false, Ordering::Release);
    }
}

/// Before a hold (an exception marked, a pause walk) of a sequence in `lane`: the due
/// polls of its blocking children (called sequences, in its lane), which their lane has
/// not taken yet, are skipped; the held sequence's own goes with its hold. A poll that
/// falls due while held is missed, not taken once the hold ends (semantics 1). `due`: the
/// words of `Set::PollDue` as read before (marks only go meanwhile). Done before the hold,
/// one section per word and per mark: only the tick makes marks, so none is left for a
/// held run to take, also when a pause reaches the sequences below its target a section
/// after the target. Returns the sequences whose due poll it skipped: an exception that
/// turns out to hold nothing gives them back ([`Sequencer::raise`]).
pub(crate) fn skip_untaken_polls<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    lane: u8,
    due: Words,
) -> SeqSet<B> {
    let mut skipped = SeqSet::EMPTY;
    for w in due {
        let called = s.section(|s| {
            s.sets
                .word(Set::PollDue, w)
                .and(s.sets.word(Set::Called, w))
        });
        for id in called {
            let in_lane = s.section(|s| {
                let in_lane = s.lane_slot(id) == lane;
                if in_lane {
                    s.sets.remove(Set::PollDue, id);
                }
                in_lane
            });
            if in_lane {
                skipped.insert(id);
            }
        }
    }
    skipped
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    extern crate std;
    use std::boxed::Box;

    use crate::lock::interleaved::{self, Interleaved};
    use crate::{Cause, Duration, Instant, Monitors, RunningState, SeqConfig, Sequencer};

    type Seq<const N: usize, const B: usize> = Sequencer<(), N, 64, Interleaved, 8, B>;

    /// A (polling every 100 ms) runs; B (every 10 ms, a 5 ms timeout) is started by a lane
    /// of higher priority before section `k` of the tick at 100 ms, where A is due (with
    /// the portable lock any task may call anything). `fillers` sequences are registered
    /// first (32: A and B in the sets' second word). With `abort_a`, A's abort is requested
    /// before that tick: the tick finds no monitored sequence left to scan. Returns the
    /// sequencer, B, and the number of sections that tick took.
    fn start_during_the_tick<const N: usize, const B: usize>(
        fillers: usize,
        abort_a: bool,
        k: usize,
    ) -> (&'static Seq<N, B>, crate::SeqId, usize) {
        let seq: &'static Seq<N, B> = Box::leak(Box::new(Sequencer::empty()));
        for i in 0..fillers {
            let name: &'static str = Box::leak(std::format!("filler {i}").into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
        let config = |name, ms| SeqConfig::new(name).polling(Duration::from_millis(ms));
        let a = seq.register(config("A", 100)).unwrap();
        let b = seq
            .register(config("B", 10).timeout(Duration::from_millis(5)))
            .unwrap();
        for id in [a, b] {
            seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        }
        let mut monitors = Monitors::<(), 1>::new();
        seq.sequence_by_id(a).unwrap().start().unwrap();
        seq.tick(Instant::from_ticks(0), &(), &mut monitors)
            .unwrap();
        if abort_a {
            seq.sequence_by_id(a).unwrap().abort().unwrap();
        }
        interleaved::at(k, move || {
            seq.sequence_by_id(b).unwrap().start().unwrap();
        });
        seq.tick(Instant::from_ticks(100_000), &(), &mut monitors)
            .unwrap();
        (seq, b, interleaved::taken())
    }

    /// Wherever the start lands in the tick's sections, B's first poll comes one period
    /// after its start (its class was idle), at 110 ms, and finds its timeout expired.
    fn first_poll_kept<const N: usize, const B: usize>(fillers: usize, abort_a: bool) {
        let (_, _, sections) = start_during_the_tick::<N, B>(fillers, abort_a, usize::MAX);
        assert!(sections > 2);
        for k in 1..sections {
            let (seq, b, _) = start_during_the_tick::<N, B>(fillers, abort_a, k);
            let mut monitors = Monitors::<(), 1>::new();
            seq.tick(Instant::from_ticks(110_000), &(), &mut monitors)
                .unwrap();
            let ended = seq.with(|s| (s.state_of(b), s.block(b).unwrap().last_cause));
            assert_eq!(
                ended,
                (RunningState::Aborted, Cause::Timeout(b)),
                "start before section {k} of {sections}"
            );
        }
    }

    /// A start made between the tick's scan of the polling classes and its last section
    /// keeps its first poll: the next due time the tick sets is not the one of the
    /// classes it scanned (A's, 200 ms), nor, in a sequencer of several words with no
    /// monitored sequence, the horizon.
    #[test]
    fn a_start_that_preempts_the_tick_keeps_its_first_poll() {
        for abort_a in [false, true] {
            first_poll_kept::<4, 1>(0, abort_a);
            first_poll_kept::<64, 2>(32, abort_a);
        }
    }
}
