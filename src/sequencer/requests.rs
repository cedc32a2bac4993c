//! Requests: pause, resume and abort of one sequence, and abort-all, queued for the next
//! tick so that every such transition happens in one place at a well-defined time.

use core::sync::atomic::Ordering;

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::{flag, request, ControlBlock};
use crate::sequencer::sections::Sections;
use crate::sequencer::sets::Set;
use crate::sequencer::{inbox, State};
use crate::{Error, Event, Request, Requester, RunningState, SeqId, Sequencer};

impl Request {
    /// The states in which the request can be made (a pause or a resume also while the
    /// other is pending: see [`replaces`](Self::replaces)).
    const fn allowed(self) -> RunningStates {
        match self {
            Request::Pause => RunningStates::of(RunningState::Running),
            Request::Resume => RunningStates::of(RunningState::Paused),
            Request::Abort => RunningStates::RUNNING_OR_PAUSED.with(RunningState::Restarting),
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

    /// The bit of the request it replaces: of a pause and a resume made before the same
    /// tick, the later one counts.
    const fn replaces(self) -> u16 {
        match self {
            Request::Pause => request::RESUME,
            Request::Resume => request::PAUSE,
            Request::Abort => 0,
        }
    }
}

/// The round of a run a request is made of: an abort is of the run (a restart keeps it), a
/// pause or a resume of the round, which a restart ends (semantics 4).
#[derive(Clone, Copy)]
struct Round {
    /// The run's count of starts.
    run: u16,
    /// The restarts made of the run before this round.
    restarts: u8,
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Whether `req` of `id` can be made now, and if not, why not. `Ok`: the round it is
    /// made of.
    fn check_request(&self, id: SeqId, req: Request) -> Result<Round, Error> {
        let b = self.block(id).ok_or(Error::UnknownSequence(id))?;
        let takes_back = b.flags & req.replaces() != 0;
        // A sequence held paused by something else (a `PauseOwner` monitor, the paused
        // caller it blocks) takes a pause request: it then stays paused when that hold
        // ends, until a resume request.
        let held_paused = req == Request::Pause
            && b.state == RunningState::Paused
            && !b.has(flag::PAUSED_BY_REQUEST);
        if !req.allowed().has(b.state) && !takes_back && !held_paused {
            return Err(match (req, b.state) {
                (Request::Resume, _) => Error::NotPaused(id),
                (Request::Pause, RunningState::Paused) => Error::AlreadyPaused(id),
                (Request::Pause | Request::Abort, _) => Error::NotRunning(id),
            });
        }
        if req == Request::Resume && b.monitor_holds > 0 {
            return Err(Error::HeldByMonitor(id));
        }
        Ok(Round {
            run: b.runs,
            restarts: b.restarts_made,
        })
    }

    /// Records that `by` asks for `req` of `id` (after [`check_request`](Self::check_request)
    /// accepted it). Done before the request is queued, so that its record comes before the
    /// transitions of the tick that carries it out.
    fn record_request(&mut self, id: SeqId, req: Request, by: Requester) {
        self.record(Event::Requested {
            sequence: id,
            request: req,
            by,
        });
    }

    /// Queues `req` of `id` for the next tick, if what it was made of (`round`) is still
    /// under way: an abort the run, a pause or a resume the round. Never for a later run
    /// or round, nor for one that ended since the request was checked (as if it had ended
    /// a moment before). The tick carries it out if the state still allows it (a pause
    /// may find the run paused by a monitor; a new run's start and a restart drop it). A
    /// queued abort holds the run until then: it begins nothing more and does not end (its
    /// clearance, `may_end`, `open_start`).
    fn queue_request(&mut self, id: SeqId, req: Request, round: Round) {
        let made_of = |b: &&mut ControlBlock| {
            b.runs == round.run
                && RunningStates::LIVE.has(b.state)
                && (req == Request::Abort || b.restarts_made == round.restarts)
        };
        if let Some(b) = self.block_mut(id).filter(made_of) {
            b.flags = (b.flags & !req.replaces()) | req.bit();
            self.sets.insert(Set::Requested, id);
            if req == Request::Abort {
                // An end opened before it must not commit: the run holds for the abort.
                self.changes = self.changes.wrapping_add(1);
            }
        }
    }
}

/// Makes `req` of `id` for `by`: the check, the record, the queueing. Between the steps a
/// tick or a lane of higher priority may end the run, and a lane start a new one: the
/// request was accepted and recorded, and nothing is queued (the run it was made of ended
/// first).
pub(crate) fn ask<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    req: Request,
    by: Requester,
) -> Result<(), Error> {
    let round = s.section(|s| s.check_request(id, req))?;
    record_and_queue(s, id, req, by, round);
    Ok(())
}

/// Asks, for `caller`, the abort of its child's run `child` (a dropped [`Scoped`]), as
/// [`ask`] asks of a sequence's current run. Refused ([`Error::NotRunning`]) unless `child`
/// is its sequence's current run and `caller` its caller: a later run, started by another
/// party, is never asked, even once the 16-bit run count has wrapped.
///
/// [`Scoped`]: crate::Scoped
pub(crate) fn abort_child<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    child: RunId,
    caller: SeqId,
) -> Result<(), Error> {
    let id = child.seq;
    let round = s.section(|s| {
        let round = s.check_request(id, Request::Abort)?;
        let ours =
            round.run == child.count && s.block(id).is_some_and(|b| b.caller.get() == Some(caller));
        if ours {
            Ok(round)
        } else {
            Err(Error::NotRunning(id))
        }
    })?;
    record_and_queue(s, id, Request::Abort, Requester::Sequence(caller), round);
    Ok(())
}

/// The record and the queueing of an accepted request `req` of `id`'s `round`.
fn record_and_queue<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    req: Request,
    by: Requester,
    round: Round,
) {
    s.section(|s| s.record_request(id, req, by));
    s.section(|s| s.queue_request(id, req, round));
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Requests that every running sequence be aborted (the safety system asks through
    /// [`Sequences`](crate::safety::Sequences)). Applied by the next tick, innermost
    /// sequences first. Safe to call from any priority (it sets an atomic flag). Until
    /// the tick has carried it out every run holds: a start it makes is refused with
    /// [`Error::NotRunning`], its await points wait and it does
    /// not end, so every run under way ends aborted (`Cause::AbortAll`).
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// SEQ.abort_all(); // nothing runs: the next tick has nothing to abort
    /// ```
    pub fn abort_all(&self) {
        self.safety
            .inbox
            .fetch_or(inbox::ABORT_ALL_BY_APPLICATION, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequencer::sections::tests::{registered, Preempted, S};
    use crate::trace::StateChange;
    use crate::Cause;

    /// A running sequence 0; `between` runs before section `at` of an abort request of it.
    /// Returns the request's result and whether the abort is queued for the tick.
    fn abort_preempted(at: usize, between: impl FnOnce(&mut S)) -> (Result<(), Error>, bool) {
        let id = SeqId(0);
        let mut state = registered(1, &[id]);
        let mut s = Preempted::new(&mut state, at, between);
        let result = ask(&mut s, id, Request::Abort, Requester::Application);
        let queued = state.sets.has(Set::Requested, id)
            && state
                .block(id)
                .is_some_and(|b| b.flags & request::ABORT != 0);
        (result, queued)
    }

    #[test]
    fn an_undisturbed_request_is_queued() {
        assert_eq!(abort_preempted(usize::MAX, |_| {}), (Ok(()), true));
    }

    /// The end of sequence 0's run.
    fn end(s: &mut S) {
        let end = StateChange::new(
            SeqId(0),
            RunningState::Running,
            RunningState::Terminated,
            Cause::Completed,
        );
        assert!(s.transition(&end).is_some());
    }

    /// The run the request was made of ends before it is queued: nothing is queued for the
    /// tick to carry out on a run that is over (found by the random preemption test, seed
    /// 5 833 146, where the tick's teardown then aborted below the sequence's next run).
    #[test]
    fn a_request_is_never_queued_for_an_ended_run() {
        assert_eq!(abort_preempted(2, end), (Ok(()), false));
    }

    /// The run the request was made of ends, and a new run starts, before it is queued: the
    /// new run is not aborted.
    #[test]
    fn a_request_is_never_queued_for_a_later_run() {
        let (result, queued) = abort_preempted(2, |s| {
            let id = SeqId(0);
            end(s);
            if let Some(b) = s.block_mut(id) {
                b.runs = b.runs.wrapping_add(1);
            }
            let again = StateChange::new(
                id,
                RunningState::Terminated,
                RunningState::Running,
                Cause::Start,
            );
            assert!(s.transition(&again).is_some());
        });
        assert_eq!((result, queued), (Ok(()), false));
    }
}
