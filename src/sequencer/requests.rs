//! Requests: pause, resume and abort of one sequence, and abort-all, queued for the next
//! tick so that every such transition happens in one place at a well-defined time. And the
//! connection to the safety system, whose levels may demand abort-all.

use core::sync::atomic::Ordering;

use crate::lock::Lock;
use crate::model::state::States;
use crate::safety::{AbortSequences, SafetyHandle};
use crate::sequencer::control_block::request;
use crate::sequencer::State;
use crate::{Error, Event, Request, Requester, RunningState, SeqId, Sequencer};

impl Request {
    /// The states in which the request can be made.
    const fn allowed(self) -> States {
        match self {
            Request::Pause => States::of(RunningState::Running),
            Request::Resume => States::of(RunningState::Paused),
            Request::Abort => States::ACTIVE_RUNNING.with(RunningState::Restarting),
        }
    }

    /// Its bit among the block's flags.
    const fn bit(self) -> u16 {
        match self {
            Request::Pause => request::PAUSE,
            Request::Resume => request::RESUME,
            Request::Abort => request::ABORT,
        }
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Whether `req` of `id` can be made: its state allows it.
    fn check_request(&self, id: SeqId, req: Request) -> Result<(), Error> {
        let b = self.block(id).ok_or(Error::UnknownSequence(id))?;
        if req.allowed().has(b.state) {
            Ok(())
        } else {
            Err(match req {
                Request::Resume => Error::NotPaused(id),
                Request::Pause | Request::Abort => Error::NotRunning(id),
            })
        }
    }

    /// Records that `by` asks for `req` of `id`, if it can be made now (else
    /// [`request`](Self::request) says why not). Done before the request is queued, so
    /// that its record comes before the transitions of the tick that carries it out.
    pub(crate) fn record_request(&mut self, id: SeqId, req: Request, by: Requester) {
        if self.block(id).is_some_and(|b| req.allowed().has(b.state)) {
            self.record(Event::Requested {
                sequence: id,
                request: req,
                by,
            });
        }
    }

    /// Queues `req` of `id` for the next tick.
    pub(crate) fn request(&mut self, id: SeqId, req: Request) -> Result<(), Error> {
        self.check_request(id, req)?;
        if let Some(b) = self.block_mut(id) {
            b.flags |= req.bit();
        }
        self.sets.requested.insert(id);
        Ok(())
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Requests that every running sequence be aborted (e.g. by the safety system). Applied
    /// by the next tick, innermost sequences first. Safe to call from any priority.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// SEQ.abort_all(); // nothing runs: the next tick has nothing to abort
    /// ```
    pub fn abort_all(&self) {
        self.abort_all
            .fetch_or(abort_all::BY_APPLICATION, Ordering::Release);
    }

    /// Takes the pending abort-all requests (the tick is their only consumer): who made
    /// them (the safety system when both did).
    pub(crate) fn take_abort_all(&self) -> Option<Requester> {
        // Load, then store: no compare-and-swap in every tick. A request raised in between
        // is served by the abort-all applied now (only its requester is not recorded).
        let asked = self.abort_all.load(Ordering::Acquire);
        if asked != 0 {
            self.abort_all.store(0, Ordering::Relaxed);
        }
        if asked & abort_all::BY_SAFETY_SYSTEM != 0 {
            Some(Requester::SafetySystem)
        } else if asked != 0 {
            Some(Requester::Application)
        } else {
            None
        }
    }

    /// Connects the safety system: sequences reach it through
    /// [`Cx::safety_system`](crate::Cx::safety_system) to trigger public events and read the
    /// level.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyHandle};
    /// use rtseq::Sequencer;
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// SEQ.set_safety_system(&SAFETY);
    /// SEQ.safety_system().unwrap().trigger(PublicEvent::new(0));
    /// ```
    pub fn set_safety_system(&self, safety: &'static SafetyHandle) {
        critical_section::with(|cs| self.safety.borrow(cs).set(Some(safety)));
    }

    /// The seed's `getSafetySystem()`: the connected safety system's handle.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// assert!(seq.safety_system().is_none());
    /// ```
    pub fn safety_system(&self) -> Option<&'static SafetyHandle> {
        critical_section::with(|cs| self.safety.borrow(cs).get())
    }
}

/// A safety level that demands it aborts every sequence through the sequencer.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize> AbortSequences
    for Sequencer<C, N, T, L, W, B>
{
    fn abort_all(&self) {
        self.abort_all
            .fetch_or(abort_all::BY_SAFETY_SYSTEM, Ordering::Release);
    }
}

/// Who asked for abort-all since the last tick: a bit per [`Requester`] that can.
pub(crate) mod abort_all {
    /// [`Sequencer::abort_all`](crate::Sequencer::abort_all).
    pub(crate) const BY_APPLICATION: u8 = 1;
    /// The safety system, through [`AbortSequences`](crate::safety::AbortSequences).
    pub(crate) const BY_SAFETY_SYSTEM: u8 = 2;
}
