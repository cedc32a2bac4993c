//! Requests the tick carries out: an abort-all (the safety system's, or a handle's), the
//! pause, resume and abort requests queued since the last tick, and the behaviours of
//! exception sequences that ended (their owners are requested when the tick folds the end).

use crate::lock::Lock;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::flag;
use crate::sequencer::sets::Set;
use crate::tick::exception::judged;
use crate::{Behaviour, Cause, Event, Request, Requester, RunningState, SeqId, Sequencer};

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Aborts every active sequence, innermost first, for an abort-all request by `by`,
    /// which is recorded when there is anything to abort (a safety level that demands
    /// abort-all while it lasts asks at every cycle). False when runs may be left (see
    /// [`abort_every_run`](Self::abort_every_run)).
    #[inline(never)]
    pub(crate) fn apply_abort_all(&self, control: &C, by: Requester) -> bool {
        if !self.any_under_way() {
            return true;
        }
        self.with(|s| s.record(Event::AbortAll { by }));
        self.abort_every_run(control)
    }

    /// Whether a run is under way that an abort-all would abort (`Running`, `Paused`,
    /// `Restarting`). The set `Monitored` says it of the sequences as of the tick's last fold;
    /// while it is empty, one short section per candidate (every registered sequence, or
    /// with several words those live at the fold or changed since), and a run begun
    /// meanwhile counts too (a lane of higher priority may start one while the tick looks).
    fn any_under_way(&self) -> bool {
        let (monitored, candidates, begun) = self.with(|s| {
            (
                !s.sets.is_empty(Set::Monitored),
                s.maybe_under_way(),
                s.runs_begun,
            )
        });
        if monitored {
            return true;
        }
        let abortable = RunningStates::entering(RunningState::Aborting);
        candidates
            .into_iter()
            .any(|id| self.with(|s| abortable.has(s.state_of(id))))
            || self.with(|s| s.runs_begun) != begun
    }

    /// Applies the behaviours of finished exception sequences, then the pause, resume and
    /// abort requests of the sequences that have them, each in id order (out of line: one
    /// copy, whatever the monitor tables the tick is instantiated for). Every behaviour
    /// comes before every request (semantics 8): a fault's abort of an owner comes before
    /// an operator's resume of its blocking child, whichever id is lower, so the child is
    /// never let go for a moment between the two.
    #[inline(never)]
    pub(crate) fn apply_requests(&self, control: &C) {
        let requested = self.with(|s| s.sets.take(Set::Requested));
        for id in requested {
            self.apply_ended_exception(control, id);
        }
        for id in requested {
            // The requests of the current run: a new run's commit clears them, a
            // teardown of the behaviours above dropped its pause and resume.
            let (req, run) = self.with(|s| {
                let run = s.current_run(id);
                (s.block_mut(id).and_then(|b| b.take_request()), run)
            });
            match req {
                Some(Request::Abort) => self.tear_down(control, run, Cause::Abort),
                Some(Request::Pause) => self.pause_tree(run, Cause::Pause),
                // A sequence frozen by the paused caller it blocks resumes with that
                // caller (its clock stays stopped meanwhile): the request lifted its own
                // pause, if any.
                Some(Request::Resume) if self.with(|s| s.stays_paused(id)) => {}
                Some(Request::Resume) => self.resume_tree(run, Cause::Resume),
                None => {}
            }
        }
    }

    /// The behaviour pending for `id`'s exception sequence, if it ended: applied to the
    /// target's run, unless the marked run was stopped meanwhile. Out of line: inlined
    /// into the requests' loop, its sections outgrow the portable lock's budget.
    #[inline(never)]
    fn apply_ended_exception(&self, control: &C, id: SeqId) {
        let (done, run) = self.with(|s| {
            let run = s.current_run(id);
            let Some(b) = s.block_mut(id) else {
                return (None, run);
            };
            if !b.has(flag::EXCEPTION_DONE) {
                return (None, run);
            }
            b.set(flag::EXCEPTION_DONE, false);
            let done = b.pending();
            b.set_pending(None);
            (done, run)
        });
        let Some(behaviour) = done else {
            return;
        };
        // Unless it was stopped meanwhile: the cause and the target.
        let still = self.with(|s| {
            // Still the marked run, still held by the exception: a lane of higher
            // priority may have run the restart of this run since the first section (the
            // same run count), whose new round begins without it.
            if s.current_run(id) != run || !s.sets.has(Set::Excepting, id) {
                return None;
            }
            let b = s
                .block(id)
                .filter(|b| RunningStates::RUNNING_OR_PAUSED.has(b.state))?;
            // One that acts on the caller was kept for an owner that had one (`raise`).
            // Without the link now, its caller ended and was started again below it (the
            // start cut the link): the owner is aborted, as an owner whose caller has
            // ended is.
            let (behaviour, target) = match b.caller.get() {
                None if behaviour.targets_caller() => (Behaviour::AbortOwner, id),
                caller => (behaviour, behaviour.target(id, caller)),
            };
            // Set by the firing that made the behaviour pending, in the same run.
            let cause = b.active_exception?;
            Some((behaviour, cause, s.current_run(target)))
        });
        // Judged on the target's run now: the one under way at the firing may have ended
        // and another begun meanwhile (a restart of the target would have taken this
        // owner down with it). Should a lane of higher priority replace it before the
        // teardown, `apply` aborts the owner.
        let judged = still.and_then(|(behaviour, cause, target)| {
            self.with(|s| {
                let limit = *s.pending_restart_limits.get(id.index())?;
                let judged = judged(behaviour, limit, s.block(target.seq)?);
                Some((judged, cause, target))
            })
        });
        if let Some((behaviour, cause, target)) = judged {
            self.apply(control, run, behaviour, target, cause);
        }
    }
}
