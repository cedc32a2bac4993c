//! The inbox: what code above the sequencer's priority ceiling (the safety task) or any
//! other context left for the next tick without taking the lock, as bits of one atomic.
//! It is kept in the sequencer's safety handle, so that the cycle of the safety system
//! built on that handle reaches it whatever `Sequences` the cycle is given.

use core::sync::atomic::{AtomicU8, Ordering};

use crate::lock::Lock;
use crate::sequencer::lanes::LaneSet;
use crate::{Requester, Sequencer};

/// [`Sequencer::abort_all`](crate::Sequencer::abort_all) was called.
pub(crate) const ABORT_ALL_BY_APPLICATION: u8 = 1;
/// The safety system asked for abort-all: its cycle on the sequencer's handle, or through
/// [`Sequences`](crate::safety::Sequences).
pub(crate) use crate::safety::ABORT_ALL_BY_SAFETY_SYSTEM;
/// The safety system queued notes for the trace (`sequencer::safety`).
pub(crate) const SAFETY_NOTES: u8 = 4;
/// Either abort-all bit.
const ABORT_ALL: u8 = ABORT_ALL_BY_APPLICATION | ABORT_ALL_BY_SAFETY_SYSTEM;
/// The abort-all the tick took and is carrying out: its bits, moved up by this much. One
/// asked for again meanwhile raises its bit again, which stays for the next tick.
const TAKEN_SHIFT: u32 = 4;
/// The bits of an abort-all taken.
const ABORT_ALL_TAKEN: u8 = ABORT_ALL << TAKEN_SHIFT;

/// Whether an abort-all waits in `inbox` (a sequencer's): asked for, or taken by the tick,
/// and not carried out yet. Until it is, a run begins nothing more, as a run whose abort
/// is requested (semantics item 8): its await points hold, its end and the starts it
/// makes are refused.
pub(crate) fn abort_all_posted(inbox: &AtomicU8) -> bool {
    inbox.load(Ordering::Relaxed) & (ABORT_ALL | ABORT_ALL_TAKEN) != 0
}

/// What the tick found in the inbox.
#[derive(Clone, Copy)]
pub(crate) struct Inbox(u8);

impl Inbox {
    /// Who asked for abort-all, if anyone did (the safety system when both did).
    pub(crate) fn abort_all_by(self) -> Option<Requester> {
        if self.0 & ABORT_ALL_BY_SAFETY_SYSTEM != 0 {
            Some(Requester::SafetySystem)
        } else if self.0 & ABORT_ALL_BY_APPLICATION != 0 {
            Some(Requester::Application)
        } else {
            None
        }
    }

    /// Whether the safety system queued notes.
    pub(crate) fn safety_notes(self) -> bool {
        self.0 & SAFETY_NOTES != 0
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Takes what is in the inbox (the tick is its only reader): `None` when nothing is in
    /// it, which costs one load. The safety system's notes are taken out: their bit is
    /// cleared before they are read, so a note queued meanwhile raises it again. An
    /// abort-all is marked taken and stays in until it is carried out
    /// ([`apply_inbox`](Self::apply_inbox)): until then the runs under way hold for it
    /// ([`abort_all_posted`]); one asked for again meanwhile stays for the next tick.
    #[inline(always)]
    pub(crate) fn take_inbox(&self) -> Option<Inbox> {
        let inbox = &self.safety.inbox;
        if inbox.load(Ordering::Relaxed) == 0 {
            return None;
        }
        let take = |bits: u8| {
            let asked = bits & ABORT_ALL;
            Some((bits & !(SAFETY_NOTES | ABORT_ALL)) | (asked << TAKEN_SHIFT))
        };
        // Acquire: the safety system's notes are queued before their bit is raised.
        let found = inbox.fetch_update(Ordering::Acquire, Ordering::Relaxed, take);
        Some(Inbox(found.unwrap_or_else(|bits| bits)))
    }

    /// Does what the tick found in the inbox: records the safety system's notes, then
    /// carries out abort-all if asked. Returns whether it was asked.
    #[inline(never)]
    pub(crate) fn apply_inbox(&self, control: &C, inbox: Inbox) -> bool {
        if inbox.safety_notes() {
            self.record_safety_notes();
        }
        let Some(by) = inbox.abort_all_by() else {
            return false;
        };
        let begun = self.with(|s| s.runs_begun);
        if self.apply_abort_all(control, by) {
            self.lift_abort_all(begun);
        } else {
            self.keep_abort_all();
        }
        true
    }

    /// The abort-all taken could not be carried out to its end: cleanup hooks (or parties
    /// above the tick) began runs during every pass. It is asked for again, for the next
    /// tick, and the runs keep holding for it: each tick's work stays bounded, and no run
    /// goes on past an abort-all.
    #[cold]
    fn keep_abort_all(&self) {
        let again = |bits: u8| {
            let taken = bits & ABORT_ALL_TAKEN;
            Some((bits & !ABORT_ALL_TAKEN) | (taken >> TAKEN_SHIFT))
        };
        // Never `Err`: `again` always gives a value.
        let _ = self
            .safety
            .inbox
            .fetch_update(Ordering::Release, Ordering::Relaxed, again);
    }

    /// The abort-all taken was carried out: it leaves the inbox (one asked for since stays
    /// for the next tick), and the runs hold for it no more. A run begun since `begun` (by
    /// a lane of higher priority than the tick) may have begun after the teardown looked:
    /// it held for the abort-all, and nothing else wakes it, so every lane looks again (a
    /// lane with nothing to do goes back to waiting). In one section: a run begun after it
    /// does not hold.
    fn lift_abort_all(&self, begun: u32) {
        let (begun_since, declared) = self.with(|s| {
            self.safety
                .inbox
                .fetch_and(!ABORT_ALL_TAKEN, Ordering::Release);
            (s.runs_begun != begun, s.lanes_declared)
        });
        if begun_since {
            self.wake_lanes(LaneSet::first(declared));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Sequencer;

    /// An abort-all kept for the next tick is asked for again by whoever took it, beside
    /// one asked for meanwhile and the safety system's notes; nothing of it stays taken.
    #[test]
    fn a_kept_abort_all_is_asked_for_again_as_it_was_taken() {
        let seq: Sequencer<(), 2> = Sequencer::new();
        let inbox = &seq.safety.inbox;
        for (before, after) in [
            (
                ABORT_ALL_BY_APPLICATION << TAKEN_SHIFT,
                ABORT_ALL_BY_APPLICATION,
            ),
            (
                (ABORT_ALL_BY_SAFETY_SYSTEM << TAKEN_SHIFT) | SAFETY_NOTES,
                ABORT_ALL_BY_SAFETY_SYSTEM | SAFETY_NOTES,
            ),
            (
                (ABORT_ALL_BY_APPLICATION << TAKEN_SHIFT) | ABORT_ALL_BY_SAFETY_SYSTEM,
                ABORT_ALL,
            ),
        ] {
            inbox.store(before, Ordering::Relaxed);
            seq.keep_abort_all();
            assert_eq!(inbox.load(Ordering::Relaxed), after, "from {before:#010b}");
            assert!(abort_all_posted(inbox));
        }
    }
}
