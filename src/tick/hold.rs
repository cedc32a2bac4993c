//! A `PauseOwner` monitor (the seed's state `paused`, held by a monitor): while its
//! condition holds, its owner and the owner's blocking children are held paused, and its exception
//! sequence runs beside them; once it clears, they resume unless something else holds
//! them.

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::model::state::RunningStates;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::{Behaviour, Cause, Event, RunningState, SeqId, Sequencer};

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// A `PauseOwner` monitor's condition became true: `owner` and its blocking children
    /// are paused (a paused owner stays paused, now held by the monitor too), and its
    /// exception sequence (if any) starts in its lane. No exception is marked: the owner's
    /// other monitors keep firing. True when the owner was monitored (running or paused).
    pub(crate) fn hold(&self, owner: SeqId, cause: Cause, exception: Option<SeqId>) -> bool {
        let monitored = self.with(|s| {
            // A run begun (or restarted) since this tick's scan is not the one the
            // evaluation saw: its monitors are evaluated from the next tick (from "false"),
            // which holds it then if the condition still holds.
            if s.sets.has(Set::Fresh, owner) {
                return None;
            }
            let b = s.block_mut(owner)?;
            // Its stop comes first.
            if b.being_stopped() {
                return None;
            }
            // Its monitors are evaluated only while it is running or paused.
            b.monitor_holds = b.monitor_holds.saturating_add(1);
            let run = RunId {
                seq: owner,
                count: b.runs,
            };
            let running = b.state == RunningState::Running;
            let monitored = RunningStates::RUNNING_OR_PAUSED.has(b.state);
            if monitored {
                s.record(Event::Fired {
                    owner,
                    cause,
                    behaviour: Behaviour::PauseOwner,
                });
            }
            monitored.then_some((run, running))
        });
        let Some((run, running)) = monitored else {
            return false;
        };
        if let Some(e) = exception {
            // Counted unless a lane of higher priority ended the run, or began its stop,
            // since the first section: the exception sequence went with it.
            if let Err(why) = self.begin(e, Mode::BesidePause { owner: run }, cause) {
                self.exception_not_run(run, e, why);
            }
        }
        if running {
            self.pause_tree(run, cause);
        }
        true
    }

    /// A `PauseOwner` monitor's condition cleared: `owner` and its blocking children
    /// resume once nothing else holds the owner: no other `PauseOwner` monitor of it, no
    /// pause request, no paused caller it blocks (whose resume then resumes it).
    pub(crate) fn release(&self, owner: SeqId, cause: Cause) {
        let released = self.with(|s| {
            if let Some(b) = s.block_mut(owner) {
                b.monitor_holds = b.monitor_holds.saturating_sub(1);
            }
            (!s.stays_paused(owner)).then(|| s.current_run(owner))
        });
        if let Some(run) = released {
            self.resume_tree(run, cause);
        }
    }
}
