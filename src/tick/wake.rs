//! The wake-ups of due exit-condition polls: which lanes to wake, leaving out the held
//! sequences while something is held, and remembering the lanes from tick to tick.

use crate::lock::Lock;
use crate::model::set::SetWord;
use crate::sequencer::callers::held;
use crate::sequencer::lanes::{LaneSet, NO_WAKER};
use crate::sequencer::sets::Set;
use crate::sequencer::state::WakeMemo;
use crate::sequencer::State;
use crate::{SeqId, Sequencer};

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
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

    /// Those of `wake` that neither changed state in this tick nor are held (see
    /// [`Sequencer::wake_due_polls`]); the held ones miss this poll: their marks go, else
    /// they would take the poll off their grid once let go. In one section; out of line,
    /// as the wake-ups of a tick with nothing held do not take it.
    #[inline(never)]
    fn unheld_and_unchanged(&mut self, wake: SetWord<B>) -> SetWord<B> {
        let unchanged = wake.minus(self.sets.word(Set::Changed, wake.index()));
        let unheld = self.unheld(unchanged);
        self.sets.remove_all(Set::PollDue, unchanged.minus(unheld));
        unheld
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
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Wakes the lanes of the due exit-condition polls `wake` (in one word of the sets).
    /// `raised`: a monitor fired or a timeout expired in this tick, so a wake-up checks
    /// that its sequence is not held, as it does while a monitored sequence is paused or
    /// handles an exception.
    ///
    /// A sequence whose state changed in this tick is not woken for its poll: the change
    /// woke its lane. It is left out before the held check, whose only other effect, the
    /// removal of a held sequence's due-poll mark, it does not need. Its mark was made by
    /// this word's scan (a sequence changed before the scan gets none, `take_polls`), so
    /// it changed after it: a hold the tick gave it then (an exception, a pause) took the
    /// mark, a new run drops a stale mark when it first waits for a poll, and an ended
    /// run takes no poll.
    #[inline(always)]
    pub(super) fn wake_due_polls(&self, wake: SetWord<B>, raised: bool) {
        if wake.is_empty() {
            return;
        }
        if !L::COARSE {
            self.wake_lanes(self.lanes_to_wake(wake, raised));
            return;
        }
        // One section: the held check walks the callers inside it.
        self.update_and_wake(|s| {
            let wake = if raised || s.any_held() {
                s.unheld_and_unchanged(wake)
            } else {
                wake
            };
            s.lanes_of_polls(wake, &self.lanes)
        });
    }

    /// With a portable lock: the lanes of the due polls `wake`. While something is held
    /// (`raised`, or a paused or excepting monitored sequence) found by a walk that skips the
    /// held ones and those whose state changed in this tick; else those remembered from the
    /// last tick with the same polls, or found by a walk and remembered, unless a lane or
    /// waker changed meanwhile.
    fn lanes_to_wake(&self, wake: SetWord<B>, raised: bool) -> LaneSet {
        let (held, remembered, forgets, changed) = self.with(|s| {
            let held = raised || s.any_held();
            let changed = s.sets.word(Set::Changed, wake.index());
            (held, s.polling.remembered(wake), s.polling.forgets, changed)
        });
        if held {
            // Those whose state changed in this tick are left out first (see
            // `wake_due_polls`). A held sequence misses this poll: its mark goes, else it
            // would take the poll off its grid once it is let go.
            return self.lanes_of_polls_in_sections(wake.minus(changed), |id| {
                let held = self.held_in_sections(id);
                if held {
                    self.with(|s| s.sets.remove(Set::PollDue, id));
                }
                held
            });
        }
        if let Some(lanes) = remembered {
            return lanes;
        }
        let lanes = self.lanes_of_polls_in_sections(wake, |_| false);
        self.with(|s| {
            if s.polling.forgets == forgets {
                s.polling.woken = WakeMemo { polls: wake, lanes };
            }
        });
        lanes
    }

    /// With a portable lock: the lanes whose polled condition is due (`wake`), except those
    /// of the sequences that `skip` leaves out, in short sections. A lane whose waker is
    /// already among them (lanes joined in one task) is not woken again: its waker is
    /// compared with theirs one section each.
    #[inline(never)]
    fn lanes_of_polls_in_sections(
        &self,
        wake: SetWord<B>,
        mut skip: impl FnMut(SeqId) -> bool,
    ) -> LaneSet {
        let mut lanes = LaneSet::EMPTY;
        for id in wake {
            if skip(id) {
                continue;
            }
            let (lane, waker) = self.with(|s| {
                let lane = s.lane_slot(id);
                (lane, self.lanes.identity(lane))
            });
            if waker == NO_WAKER {
                continue;
            }
            let mut chosen = lanes;
            if !chosen.any(|l| L::lock(|| self.lanes.identity(l)) == waker) {
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
