//! The inbox: what code above the sequencer's priority ceiling (the safety task) or any
//! other context left for the next tick without taking the lock, as bits of one atomic.
//! It is kept in the sequencer's safety handle, so that the cycle of the safety system
//! built on that handle reaches it whatever `Sequences` the cycle is given.

use core::sync::atomic::Ordering;

use crate::lock::Lock;
use crate::{Requester, Sequencer};

/// [`Sequencer::abort_all`](crate::Sequencer::abort_all) was called.
pub(crate) const ABORT_ALL_BY_APPLICATION: u8 = 1;
/// The safety system asked for abort-all: its cycle on the sequencer's handle, or through
/// [`Sequences`](crate::safety::Sequences).
pub(crate) use crate::safety::ABORT_ALL_BY_SAFETY_SYSTEM;
/// The safety system queued notes for the trace (`sequencer::safety`).
pub(crate) const SAFETY_NOTES: u8 = 4;

/// What the tick took from the inbox.
#[derive(Clone, Copy)]
pub(crate) struct Inbox(u8);

impl Inbox {
    /// Who asked for abort-all, if anyone did (the safety system when both did).
    pub(crate) fn abort_all(self) -> Option<Requester> {
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
    /// Empties the inbox (the tick is its only reader): `None` when nothing is in it, which
    /// costs one load; the atomic swap is only for a tick that finds something.
    #[inline(always)]
    pub(crate) fn take_inbox(&self) -> Option<Inbox> {
        let inbox = &self.safety.inbox;
        if inbox.load(Ordering::Relaxed) == 0 {
            return None;
        }
        // Acquire: the safety system's notes are queued before their bit is raised.
        Some(Inbox(inbox.swap(0, Ordering::Acquire)))
    }

    /// Does what the tick found in the inbox: records the safety system's notes, then
    /// applies abort-all if asked. Returns whether it was asked.
    #[inline(never)]
    pub(crate) fn apply_inbox(&self, control: &C, inbox: Inbox) -> bool {
        if inbox.safety_notes() {
            self.record_safety_notes();
        }
        let Some(by) = inbox.abort_all() else {
            return false;
        };
        self.apply_abort_all(control, by);
        true
    }
}
