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
///
/// Only the projection is generic over the framework; `RunCore::poll` serves every child
/// type.
pub(crate) struct Run<'e, 's, C, F> {
    core: RunCore<'e, 's, C>,
    /// The child's framework; structurally pinned.
    framework: F,
}

struct RunCore<'e, 's, C> {
    engine: &'e dyn Engine<C>,
    caller: SeqId,
    child: SeqId,
    slot: &'s Cell<Option<Outcome>>,
    phase: Phase,
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
            core: RunCore {
                engine,
                caller,
                child,
                slot,
                phase: Phase::Begin,
            },
            framework,
        }
    }
}

impl<C, F: Future<Output = Infallible>> Future for Run<'_, '_, C, F> {
    type Output = Result<Outcome, Error>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: `framework` is structurally pinned: it is never moved out of `self` nor
        // replaced (only polled in place, and dropped with `self`); `core` is plain data
        // that may move.
        let this = unsafe { self.get_unchecked_mut() };
        // SAFETY: pinned projection of `framework`, see above.
        let framework = unsafe { Pin::new_unchecked(&mut this.framework) };
        this.core.poll(cx, framework)
    }
}

impl<C> RunCore<'_, '_, C> {
    #[inline(never)]
    fn poll(
        &mut self,
        cx: &mut Context<'_>,
        framework: Pin<&mut dyn Future<Output = Infallible>>,
    ) -> Poll<Result<Outcome, Error>> {
        if let Phase::Begin = self.phase {
            self.slot.set(None);
            if let Err(e) = self
                .engine
                .begin(self.child, Some(self.caller), Mode::Blocking)
            {
                self.phase = Phase::Done;
                return Poll::Ready(Err(e));
            }
            self.phase = Phase::Running;
        }
        if let Phase::Running = self.phase {
            match framework.poll(cx) {
                Poll::Pending => {}
                Poll::Ready(never) => match never {},
            }
            match self.slot.take() {
                Some(outcome) => self.phase = Phase::Returning(outcome),
                None => return Poll::Pending,
            }
        }
        if let Phase::Returning(outcome) = self.phase {
            if self.engine.gate(self.caller, cx.waker()) == Gate::Go {
                self.phase = Phase::Done;
                return Poll::Ready(Ok(outcome));
            }
        }
        Poll::Pending
    }
}
