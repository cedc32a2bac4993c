//! Requests: pause, resume and abort of one sequence, and abort-all, queued for the next
//! tick so that every such transition happens in one place at a well-defined time.

use core::sync::atomic::Ordering;

use crate::lock::Lock;
use crate::model::state::States;
use crate::sequencer::control_block::request;
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
    /// Whether `req` of `id` can be made now, and if not, why not.
    pub(crate) fn check_request(&self, id: SeqId, req: Request) -> Result<(), Error> {
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

    /// Records that `by` asks for `req` of `id` (after [`check_request`](Self::check_request)
    /// accepted it). Done before the request is queued, so that its record comes before the
    /// transitions of the tick that carries it out.
    pub(crate) fn record_request(&mut self, id: SeqId, req: Request, by: Requester) {
        self.record(Event::Requested {
            sequence: id,
            request: req,
            by,
        });
    }

    /// Queues `req` of `id` for the next tick, which carries it out if the state still
    /// allows it (a run may end between the check and the tick).
    pub(crate) fn queue_request(&mut self, id: SeqId, req: Request) {
        if let Some(b) = self.block_mut(id) {
            b.flags |= req.bit();
            self.sets.insert(Set::Requested, id);
        }
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
