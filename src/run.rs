//! The future of a blocking start ([`Cx::run`](crate::Cx::run), [`Cx::step`](crate::Cx::step)).

use core::cell::Cell;
use core::convert::Infallible;
use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

use crate::engine::Engine;
use crate::sequencer::{Gate, Mode};
use crate::{Error, Outcome, SeqId};

enum Phase {
    /// Not started yet: the first poll starts the child.
    Begin,
    /// The child's framework runs inside this future.
    Running,
    /// The child ended; waiting until the caller may advance to hand over the outcome.
    Returning(Outcome),
    /// Returned (or failed to start). Polling again stays pending, never panics.
    Done,
}

/// Runs a child's framework inside the caller's future and returns its outcome.
///
/// Hand-written rather than an `async fn` so that it has no "resumed after completion"
/// panic path, and it returns only when the caller may advance: once the caller is aborted
/// or restarting it stays pending and the caller's guard drops it (sticky abort).
pub(crate) struct Run<'e, 's, C, F> {
    engine: &'e dyn Engine<C>,
    caller: SeqId,
    child: SeqId,
    slot: &'s Cell<Option<Outcome>>,
    phase: Phase,
    /// The child's framework; structurally pinned.
    framework: F,
}

impl<'e, 's, C, F: Future<Output = Infallible>> Run<'e, 's, C, F> {
    pub(crate) fn new(
        engine: &'e dyn Engine<C>,
        caller: SeqId,
        child: SeqId,
        slot: &'s Cell<Option<Outcome>>,
        framework: F,
    ) -> Self {
        Run {
            engine,
            caller,
            child,
            slot,
            phase: Phase::Begin,
            framework,
        }
    }
}

impl<C, F: Future<Output = Infallible>> Future for Run<'_, '_, C, F> {
    type Output = Result<Outcome, Error>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: `framework` is structurally pinned: it is never moved out of `self` nor
        // replaced (only polled in place, and dropped with `self`); every other field is
        // plain data that may move.
        let this = unsafe { self.get_unchecked_mut() };
        if let Phase::Begin = this.phase {
            this.slot.set(None);
            if let Err(e) = this
                .engine
                .begin(this.child, Some(this.caller), Mode::Blocking)
            {
                this.phase = Phase::Done;
                return Poll::Ready(Err(e));
            }
            this.phase = Phase::Running;
        }
        if let Phase::Running = this.phase {
            // SAFETY: pinned projection of `framework`, see above.
            let framework = unsafe { Pin::new_unchecked(&mut this.framework) };
            match framework.poll(cx) {
                Poll::Pending => {}
                Poll::Ready(never) => match never {},
            }
            match this.slot.take() {
                Some(outcome) => this.phase = Phase::Returning(outcome),
                None => return Poll::Pending,
            }
        }
        if let Phase::Returning(outcome) = this.phase {
            if this.engine.gate(this.caller, cx.waker()) == Gate::Go {
                this.phase = Phase::Done;
                return Poll::Ready(Ok(outcome));
            }
        }
        Poll::Pending
    }
}
