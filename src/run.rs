//! The future of a blocking start of a sequence ([`Cx::run`](crate::Cx::run)).

use core::cell::Cell;
use core::convert::Infallible;
use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

use crate::{Error, Outcome};

/// Runs a child's framework inside the caller's future and returns its result.
///
/// Hand-written rather than an `async fn` so that it has no "resumed after completion"
/// panic path. The child's frame does the rest (start, hand-over only once the caller may
/// advance); this only takes the result from the slot.
pub(crate) struct Run<'s, F> {
    /// The child's slot (also in its frame).
    slot: &'s Cell<Option<Result<Outcome, Error>>>,
    /// The child's framework; structurally pinned.
    framework: F,
}

impl<'s, F: Future<Output = Infallible>> Run<'s, F> {
    pub(crate) fn new(slot: &'s Cell<Option<Result<Outcome, Error>>>, framework: F) -> Self {
        Run { slot, framework }
    }
}

impl<F: Future<Output = Infallible>> Future for Run<'_, F> {
    type Output = Result<Outcome, Error>;

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: `framework` is structurally pinned: it is never moved out of `self` nor
        // replaced (only polled in place, and dropped with `self`); `slot` is a plain
        // reference that may move.
        let this = unsafe { self.get_unchecked_mut() };
        // SAFETY: pinned projection of `framework`, see above.
        let framework = unsafe { Pin::new_unchecked(&mut this.framework) };
        match framework.poll(w) {
            Poll::Pending => {}
            Poll::Ready(never) => match never {},
        }
        match this.slot.take() {
            Some(result) => Poll::Ready(result),
            None => Poll::Pending,
        }
    }
}
