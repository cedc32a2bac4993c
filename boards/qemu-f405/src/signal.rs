//! [`TickSignal`]: how the tick interrupt wakes a lane.
//!
//! A "latest value" cell plus one waker, usable from a `static`: the interrupt calls
//! [`TickSignal::signal`] with the current time, a lane `.await`s [`TickSignal::wait`] and
//! sleeps (its RTIC dispatcher is not pended) until the next signal. Signals that arrive
//! while the lane is busy coalesce into the latest one, never queue up. Panic-free (no
//! `RefCell`, no "reader already taken" check as in `rtic_sync::signal`), so it stays
//! inside the no-panic proof. One waiting lane per signal.

use core::cell::Cell;
use core::future::{poll_fn, Future};
use core::task::{Poll, Waker};

use critical_section::Mutex;

use crate::clock::Instant;

/// Wakes one lane from an interrupt with the time of the wake-up.
pub struct TickSignal {
    value: Mutex<Cell<Option<Instant>>>,
    waker: Mutex<Cell<Option<Waker>>>,
}

impl Default for TickSignal {
    fn default() -> Self {
        Self::new()
    }
}

impl TickSignal {
    /// An empty signal (for a `static`).
    pub const fn new() -> Self {
        Self {
            value: Mutex::new(Cell::new(None)),
            waker: Mutex::new(Cell::new(None)),
        }
    }

    /// Stores `now` (replacing an unread value) and wakes the waiting lane, if any.
    #[inline]
    pub fn signal(&self, now: Instant) {
        let waker = critical_section::with(|cs| {
            self.value.borrow(cs).set(Some(now));
            self.waker.borrow(cs).take()
        });
        if let Some(w) = waker {
            w.wake();
        }
    }

    /// Takes the pending value without waiting.
    #[inline]
    pub fn try_take(&self) -> Option<Instant> {
        critical_section::with(|cs| self.value.borrow(cs).take())
    }

    /// Waits for the next signal (or returns a pending one at once) and takes its value.
    ///
    /// A plain `poll_fn` future, deliberately not an `async fn`: the state machine of an
    /// `async fn` that can return panics when resumed after completion, a panic path the
    /// no-panic proof would find.
    pub fn wait(&self) -> impl Future<Output = Instant> + '_ {
        poll_fn(move |cx| {
            critical_section::with(|cs| {
                if let Some(v) = self.value.borrow(cs).take() {
                    return Poll::Ready(v);
                }
                let slot = self.waker.borrow(cs);
                match slot.take() {
                    Some(w) if w.will_wake(cx.waker()) => slot.set(Some(w)),
                    _ => slot.set(Some(cx.waker().clone())),
                }
                Poll::Pending
            })
        })
    }
}
