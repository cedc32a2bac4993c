//! Which polls a tick takes: the polling classes' scan in one word of the sets, the due
//! sequences' fresh marks and exit-condition polls, their expired timeouts; and the due
//! polls a hold skips.

use crate::lock::Lock;
use crate::model::set::{SeqSet, SetWord, Words};
use crate::model::time::{Stamp, NEVER_AHEAD};
use crate::sequencer::callers::blocks_in_lane;
use crate::sequencer::sections::Sections;
use crate::sequencer::sets::{Set, Sets};
use crate::sequencer::State;
use crate::{SeqId, Sequencer};

use super::schedule::{Scan, Word};

/// What the tick must do for the due polls in one word of the sets (the tick visits the
/// words that hold a sequence under way one at a time).
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
    pub(super) fn wake(&self) -> SetWord<B> {
        SetWord::new(self.word, self.wake)
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// The due polls `due` (monitored sequences of one word whose polling class is due):
    /// takes their fresh marks and marks their due exit-condition polls (not those of
    /// sequences whose state changed since the tick's fold). Returns what to
    /// do for them, and the running ones with an armed timeout.
    #[inline(always)]
    fn take_polls(&mut self, due: SetWord<B>) -> (Polls<B>, SetWord<B>) {
        let w = due.index();
        let sets = &mut self.sets;
        let running = due.minus(sets.word(Set::Paused, w));
        let fresh = sets.word(Set::Fresh, w).and(due);
        sets.remove_all(Set::Fresh, due);
        // Not a sequence whose state changed since the fold: paused (in an earlier word of
        // this tick), ended or begun anew, it misses this poll.
        let wake = running
            .and(sets.word(Set::PollWait, w))
            .minus(sets.word(Set::Changed, w));
        sets.insert_all(Set::PollDue, wake);
        let polls = Polls {
            word: w,
            due: due.bits(),
            fresh: fresh.bits(),
            wake: wake.bits(),
        };
        (polls, running.and(sets.word(Set::Armed, w)))
    }

    /// Those of `timed` whose timeout has run out at the tick's time.
    fn expired(&self, timed: SetWord<B>) -> SetWord<B> {
        let mut out = SetWord::empty(timed.index());
        for id in timed {
            if self.timed_out(id) {
                out.insert(id);
            }
        }
        out
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Finds the due polls in word `w`: advances the schedules of the polling classes that
    /// are due, recomputes the next due time, takes the due sequences' fresh marks, marks
    /// their due exit-condition polls and finds their expired timeouts (raised after the
    /// monitors), which it returns beside the polls. With a coarse lock in one section;
    /// otherwise one short section per class and per armed timeout.
    #[inline(always)]
    pub(super) fn scan(&self, w: usize, now: Stamp, scan: &mut Scan) -> (Polls<B>, SetWord<B>) {
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
                    .scan_all(now, scanned_word(&s.sets, w), scan);
                s.polling.next_due = next_due(scan, s.polling.next_due);
                let (polls, timed) = s.take_polls(due);
                (polls, s.expired(timed))
            });
        }
        let classes = self.with(|s| s.polling.classes.len());
        let mut due = SetWord::empty(w);
        for i in 0..classes {
            due = due.or(self.with(|s| {
                s.polling
                    .classes
                    .scan(i, now, scanned_word(&s.sets, w), scan)
            }));
        }
        let (polls, timed) = self.with(|s| {
            s.polling.next_due = next_due(scan, s.polling.next_due);
            s.take_polls(due)
        });
        let mut expired = SetWord::empty(w);
        for id in timed {
            expired = expired.or(self.with(|s| s.expired(SetWord::of(id))));
        }
        (polls, expired)
    }
}

/// Word `w` of the sets the polling classes' scan reads.
#[inline(always)]
fn scanned_word<const B: usize>(sets: &Sets<B>, w: usize) -> Word<B> {
    Word {
        live: sets.word(Set::Live, w),
        monitored: sets.word(Set::Monitored, w),
    }
}

/// Before a hold (an exception marked, a pause walk) of `held` in `lane`: the due polls
/// of its blocking children (and theirs, all in its lane), which their lane has not taken
/// yet, are skipped; the held sequence's own goes with its hold. A poll that falls due
/// while held is missed, not taken once the hold ends (semantics 1); the polls of its
/// callers and of their other children stand. `due`: the words of `Set::PollDue` as read
/// before (marks only go meanwhile). Done before the hold, one section per word, per step
/// up from a mark and per mark: only the tick makes marks, so none is left for a held run
/// to take, also when a pause reaches the sequences below its target a section after the
/// target. Returns the sequences whose due poll it skipped: an exception that turns out
/// to hold nothing gives them back ([`Sequencer::raise`]).
pub(crate) fn skip_untaken_polls<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    held: SeqId,
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
            if blocks_in_lane(s, id, held, lane) {
                s.section(|s| s.sets.remove(Set::PollDue, id));
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
