//! The future of a blocking start ([`Cx::run`](crate::Cx::run), [`Cx::step`](crate::Cx::step)).

use core::convert::Infallible;
use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

use crate::sequence::{BodyRef, Frame};
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

/// A child's framework as `Run` drives it: polled with the child's frame, it leaves the
/// outcome in the frame's slot.
pub(crate) trait Framework<C> {
    fn poll_framework(self: Pin<&mut Self>, w: &mut Context<'_>, frame: &Frame<'_, '_, C>);
}

/// A sequence's framework (an `async fn` that holds its own frame).
pub(crate) struct SeqFramework<F>(pub(crate) F);

impl<C, F: Future<Output = Infallible>> Framework<C> for SeqFramework<F> {
    fn poll_framework(self: Pin<&mut Self>, w: &mut Context<'_>, _: &Frame<'_, '_, C>) {
        // SAFETY: structural pinning of the only field: never moved out.
        match unsafe { self.map_unchecked_mut(|s| &mut s.0) }.poll(w) {
            Poll::Pending => {}
            Poll::Ready(never) => match never {},
        }
    }
}

/// A step's framework: the step; the rest is in the frame.
impl<C> Framework<C> for BodyRef<'_, C> {
    fn poll_framework(self: Pin<&mut Self>, w: &mut Context<'_>, frame: &Frame<'_, '_, C>) {
        frame.step(w, self.get_mut());
    }
}

/// Runs a child's framework inside the caller's future and returns its outcome.
///
/// Hand-written rather than an `async fn` so that it has no "resumed after completion"
/// panic path, and it returns only when the caller may advance: once the caller is aborted
/// or restarting it stays pending and the caller's guard drops it (sticky abort).
///
/// Only the projection is generic over the framework; `RunCore::poll` serves every child.
pub(crate) struct Run<'a, 's, C, F> {
    core: RunCore<'a, 's, C>,
    /// The child's framework; structurally pinned.
    framework: F,
}

struct RunCore<'a, 's, C> {
    /// The child's frame.
    frame: Frame<'a, 's, C>,
    caller: SeqId,
    phase: Phase,
}

impl<'a, 's, C, F: Framework<C>> Run<'a, 's, C, F> {
    /// `frame` is the child's.
    pub(crate) fn new(frame: Frame<'a, 's, C>, caller: SeqId, framework: F) -> Self {
        Run {
            core: RunCore {
                frame,
                caller,
                phase: Phase::Begin,
            },
            framework,
        }
    }
}

impl<C, F: Framework<C>> Future for Run<'_, '_, C, F> {
    type Output = Result<Outcome, Error>;

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: `framework` is structurally pinned: it is never moved out of `self` nor
        // replaced (only polled in place, and dropped with `self`); `core` is plain data
        // that may move.
        let this = unsafe { self.get_unchecked_mut() };
        // SAFETY: pinned projection of `framework`, see above.
        let framework = unsafe { Pin::new_unchecked(&mut this.framework) };
        this.core.poll(w, framework)
    }
}

impl<C> RunCore<'_, '_, C> {
    #[inline(never)]
    fn poll(
        &mut self,
        w: &mut Context<'_>,
        framework: Pin<&mut dyn Framework<C>>,
    ) -> Poll<Result<Outcome, Error>> {
        let (engine, slot) = (self.frame.cx.engine(), self.frame.slot);
        if let Phase::Begin = self.phase {
            slot.set(None);
            if let Err(e) = engine.begin(self.frame.cx.id(), Some(self.caller), Mode::Blocking) {
                self.phase = Phase::Done;
                return Poll::Ready(Err(e));
            }
            self.phase = Phase::Running;
        }
        if let Phase::Running = self.phase {
            framework.poll_framework(w, &self.frame);
            match slot.take() {
                Some(outcome) => self.phase = Phase::Returning(outcome),
                None => return Poll::Pending,
            }
        }
        if let Phase::Returning(outcome) = self.phase {
            if engine.gate(self.caller, w.waker()) == Gate::Go {
                self.phase = Phase::Done;
                return Poll::Ready(Ok(outcome));
            }
        }
        Poll::Pending
    }
}
