//! Requests: pause, resume and abort of one sequence, and abort-all, queued for the next
//! tick so that every such transition happens in one place at a well-defined time.

use core::sync::atomic::Ordering;

use crate::lock::Lock;
use crate::model::state::States;
use crate::sequencer::control_block::{flag, request};
use crate::sequencer::sets::Set;
use crate::sequencer::{inbox, State};
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
    /// Whether `req` of `id` can be made: its state allows it, and for a resume no
    /// `PauseOwner` monitor holds it.
    fn check_request(&self, id: SeqId, req: Request) -> Result<(), Error> {
        let b = self.block(id).ok_or(Error::UnknownSequence(id))?;
        if !req.allowed().has(b.state) {
            return Err(match req {
                Request::Resume => Error::NotPaused(id),
                Request::Pause | Request::Abort => Error::NotRunning(id),
            });
        }
        if req == Request::Resume && b.monitor_holds > 0 {
            return Err(Error::HeldByMonitor(id));
        }
        Ok(())
    }

    /// Records that `by` asks for `req` of `id`, if it can be made now (else
    /// [`request`](Self::request) says why not). Done before the request is queued, so
    /// that its record comes before the transitions of the tick that carries it out.
    pub(crate) fn record_request(&mut self, id: SeqId, req: Request, by: Requester) {
        if self.check_request(id, req).is_ok() {
            self.record(Event::Requested {
                sequence: id,
                request: req,
                by,
            });
        }
    }

    /// A pause request of `id` is carried out: its pause lasts until a resume request.
    pub(crate) fn pause_requested(&mut self, id: SeqId) {
        if let Some(b) = self.block_mut(id) {
            b.set(flag::PAUSED_BY_REQUEST, true);
        }
    }

    /// A resume request of `id` is carried out: true when it resumes, false while a
    /// `PauseOwner` monitor holds it (it resumes when the monitor's condition clears).
    pub(crate) fn resume_requested(&mut self, id: SeqId) -> bool {
        self.block_mut(id).is_some_and(|b| {
            b.set(flag::PAUSED_BY_REQUEST, false);
            b.monitor_holds == 0
        })
    }

    /// Queues `req` of `id` for the next tick.
    pub(crate) fn request(&mut self, id: SeqId, req: Request) -> Result<(), Error> {
        self.check_request(id, req)?;
        if let Some(b) = self.block_mut(id) {
            b.flags |= req.bit();
        }
        self.sets.insert(Set::Requested, id);
        Ok(())
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Requests that every running sequence be aborted (the safety system asks through
    /// [`Sequences`](crate::safety::Sequences)). Applied by the next tick, innermost
    /// sequences first. Safe to call from any priority.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// SEQ.abort_all(); // nothing runs: the next tick has nothing to abort
    /// ```
    pub fn abort_all(&self) {
        self.inbox
            .fetch_or(inbox::ABORT_ALL_BY_APPLICATION, Ordering::Release);
    }
}
