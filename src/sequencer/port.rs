//! The port: the object-safe view of a [`Sequencer`] that contexts, runs and handles use,
//! so that user code is generic only over the control system `C`, not over the
//! sequencer's capacities and lock. One method per operation.

use core::task::{Poll, Waker};

use crate::lock::Lock;
use crate::model::time::Stamp;
use crate::sequencer::callers::join_would_deadlock;
use crate::sequencer::control_block::flag;
use crate::sequencer::lanes::declare_lane;
use crate::sequencer::requests::ask;
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::sequencer::transition::Clearance;
use crate::trace::StateChange;
use crate::{Cause, Error, Instant, Outcome, Request, Requester, RunningState, SeqId, Sequencer};

/// A consistent snapshot of one control block's own fields, for [`Handle`](crate::Handle).
#[derive(Clone, Debug)]
pub(crate) struct Info {
    pub(crate) name: &'static str,
    pub(crate) state: RunningState,
    /// The direct caller of the current (or last) run.
    pub(crate) caller: Option<SeqId>,
    /// The lane slot (`NO_LANE`: none).
    pub(crate) lane: u8,
    pub(crate) exception_active: bool,
    pub(crate) active_exception: Option<Cause>,
    #[cfg(feature = "counters")]
    pub(crate) counters: crate::Counters,
    pub(crate) outcome: Option<Outcome>,
}

/// What a run, a context and a handle can ask of the sequencer.
pub(crate) trait Port<C> {
    /// The last tick's time.
    fn now(&self) -> Instant;
    /// The unpaused time of `id`'s current run at the last tick (µs, modulo 2³²).
    fn run_time(&self, id: SeqId) -> u32;
    /// Starts `id`, whose sequence object was made by the sequencer tagged `maker`,
    /// blocking: it runs in `caller`'s lane, inside `caller`'s future.
    fn start_blocking(&self, id: SeqId, maker: u16, caller: SeqId) -> Result<(), Error>;
    /// Starts `id` in its own lane, by `caller` (`None`: as a main sequence).
    fn start_in_lane(&self, id: SeqId, caller: Option<SeqId>) -> Result<(), Error>;
    /// Keeps `waker` for `id`'s lane, then says what `id`'s await point must do.
    fn clearance(&self, id: SeqId, waker: &Waker) -> Clearance;
    /// As [`clearance`](Self::clearance), but `Go` only when the tick said `id`'s polled
    /// condition is due (and takes that due poll).
    fn due_poll(&self, id: SeqId, waker: &Waker) -> Clearance;
    /// Sets whether `id` waits for a polled condition; a stale due poll is dropped.
    fn set_poll_wait(&self, id: SeqId, waiting: bool);
    /// A `Restarting` sequence runs again from its pre-condition.
    fn restart(&self, id: SeqId);
    /// Ends `id`'s run with `outcome` (`Completed`, `Skipped` or `Failed`): `Terminated`;
    /// false when refused (its clearance says what to do instead).
    fn end(&self, id: SeqId, outcome: Outcome) -> bool;
    /// The run is over: records the outcome, releases the joiners.
    fn finished(&self, id: SeqId, outcome: Outcome);
    /// The future of `id`'s run was dropped before the run ended: the run and its
    /// sub-sequences are aborted now ([`Cause::Dropped`], innermost first, through their
    /// cleanup hooks).
    fn abandon(&self, id: SeqId, control: &C);
    /// Finds or claims `id`'s lane slot.
    fn declare_lane(&self, id: SeqId) -> Result<u8, Error>;
    /// A lane's wait for a start of `id`, whose sequence object was made by the sequencer
    /// tagged `maker`: declares the lane, keeps `waker` as its waker and takes a pending
    /// non-blocking start (true). The lane of another sequencer's object declares nothing
    /// and never runs here (a start of `id` finds no lane).
    fn take_start(&self, id: SeqId, maker: u16, waker: &Waker) -> bool;
    /// `joiner` waits for the end of a run of `target`: its outcome once it ended. `run`:
    /// which run, by the target's run count; the first poll of a join sets it to the
    /// current run (or the last one, if it ended), so a join never waits for a later run.
    fn join(
        &self,
        joiner: SeqId,
        target: SeqId,
        run: &mut Option<u16>,
    ) -> Poll<Result<Outcome, Error>>;
    /// A snapshot of `id`'s control block.
    fn info(&self, id: SeqId) -> Option<Info>;
    /// Queues `request` of `id`, made by `by`, for the next tick.
    fn request(&self, id: SeqId, request: Request, by: Requester) -> Result<(), Error>;
    /// Sets `id`'s timeout (µs, 0: off) for its next run.
    fn set_timeout(&self, id: SeqId, micros: u32) -> Result<(), Error>;
    /// The connected safety system.
    fn safety(&self) -> Option<&'static crate::safety::SafetyHandle>;
}

/// With the portable lock each method is a few short sections (a waker is kept in its own
/// section before the state is read, so no wake-up is lost in between; walks take one
/// section per step), with a coarse lock fewer, longer ones.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize> Port<C>
    for Sequencer<C, N, T, L, W, B>
{
    fn now(&self) -> Instant {
        Sequencer::now(self)
    }

    fn run_time(&self, id: SeqId) -> u32 {
        self.with(|s| {
            let now = Stamp::of(s.now);
            s.block(id).map_or(0, |b| b.run_time(now))
        })
    }

    fn start_blocking(&self, id: SeqId, maker: u16, caller: SeqId) -> Result<(), Error> {
        self.begin(id, Some(caller), Mode::Blocking { maker }, Cause::Start, 0)
    }

    fn start_in_lane(&self, id: SeqId, caller: Option<SeqId>) -> Result<(), Error> {
        self.begin(id, caller, Mode::Lane, Cause::Start, 0)
    }

    fn clearance(&self, id: SeqId, waker: &Waker) -> Clearance {
        self.park_then(id, waker, |s| s.clearance(id))
    }

    fn due_poll(&self, id: SeqId, waker: &Waker) -> Clearance {
        self.park_then(id, waker, |s| match s.clearance(id) {
            Clearance::Go if s.sets.has(Set::PollDue, id) => {
                s.sets.put(Set::PollDue, id, false);
                Clearance::Go
            }
            Clearance::Go => Clearance::Hold,
            other => other,
        })
    }

    fn set_poll_wait(&self, id: SeqId, waiting: bool) {
        self.with(|s| {
            if s.block(id).is_some() {
                s.sets.put(Set::PollWait, id, waiting);
                s.sets.put(Set::PollDue, id, false);
            }
        });
    }

    fn restart(&self, id: SeqId) {
        Sequencer::restart(self, id);
    }

    fn end(&self, id: SeqId, outcome: Outcome) -> bool {
        let cause = match outcome {
            Outcome::Skipped => Cause::PreConditionFalse,
            Outcome::Completed => Cause::Completed,
            Outcome::Failed(_) => Cause::Failed,
            Outcome::Aborted(cause) => cause,
        };
        let change = StateChange::new(id, RunningState::Running, RunningState::Terminated, cause);
        self.with(|s| s.end(&change, outcome))
    }

    fn finished(&self, id: SeqId, outcome: Outcome) {
        in_sections_then_wake!(self, |s| {
            // The run no longer waits for a poll.
            s.section(|s| {
                s.sets.put(Set::PollWait, id, false);
                s.sets.put(Set::PollDue, id, false);
            });
            if s.section(|s| s.finished(id, outcome)) {
                s.section(|s| s.exception_ended(id));
            }
            s.section(|s| s.release_joiners(id))
        });
    }

    fn abandon(&self, id: SeqId, control: &C) {
        self.walk(control, Some(id), RunningState::Aborting, Cause::Dropped);
    }

    fn declare_lane(&self, id: SeqId) -> Result<u8, Error> {
        in_sections!(self, |s| declare_lane(s, id)).ok_or(Error::LaneCapacityExceeded(id))
    }

    fn take_start(&self, id: SeqId, maker: u16, waker: &Waker) -> bool {
        // Another sequencer's object declares nothing here; with no slot left the lane
        // never runs (see `lane`).
        let declared = in_sections!(self, |s| {
            if s.section(|s| s.tag == maker) {
                declare_lane(s, id)
            } else {
                None
            }
        });
        let Some(lane) = declared else {
            return false;
        };
        // The waker is kept before the start is looked for: a start in between wakes it.
        self.park_in_then(
            |_| lane,
            waker,
            |s| {
                let Some(b) = s.block_mut(id) else {
                    return false;
                };
                let pending = b.has(flag::START_PENDING);
                b.set(flag::START_PENDING, false);
                pending
            },
        )
    }

    fn join(
        &self,
        joiner: SeqId,
        target: SeqId,
        run: &mut Option<u16>,
    ) -> Poll<Result<Outcome, Error>> {
        if in_sections!(self, |s| join_would_deadlock(s, joiner, target)) {
            return Poll::Ready(Err(Error::JoinWouldDeadlock(target)));
        }
        // Registered before the run's end is looked for: an end in between releases it.
        self.with(|s| s.wait_for_join(joiner, target));
        let ended = self.with(|s| {
            let b = s.block(target).ok_or(Error::UnknownSequence(target))?;
            if b.state == RunningState::Idle {
                return Err(Error::NeverStarted(target));
            }
            let joined = *run.get_or_insert(b.runs);
            let under_way = b.state.is_active() || b.has(flag::START_PENDING);
            // The outcome is the joined run's while that run is the last one, ended, or
            // the one before the run under way.
            match (b.runs.wrapping_sub(joined), under_way) {
                (0, true) => Ok(None),
                (0, false) | (1, true) => Ok(b.outcome),
                _ => Err(Error::OutcomeLost(target)),
            }
        });
        let result = match ended {
            Ok(None) => return Poll::Pending,
            Ok(Some(outcome)) => Ok(outcome),
            Err(e) => Err(e),
        };
        self.with(|s| s.stop_waiting_for_join(joiner));
        Poll::Ready(result)
    }

    /// The block's own fields, in one section.
    fn info(&self, id: SeqId) -> Option<Info> {
        self.with(|s| {
            let b = s.block(id)?;
            Some(Info {
                name: b.name(),
                state: b.state,
                caller: b.caller.get(),
                lane: b.lane,
                exception_active: s.sets.has(Set::Excepting, id),
                active_exception: b.active_exception,
                #[cfg(feature = "counters")]
                counters: s.counters.get(id.index()).copied().unwrap_or_default(),
                outcome: b.outcome,
            })
        })
    }

    fn request(&self, id: SeqId, request: Request, by: Requester) -> Result<(), Error> {
        in_sections!(self, |s| ask(s, id, request, by))
    }

    fn set_timeout(&self, id: SeqId, micros: u32) -> Result<(), Error> {
        self.with(|s| {
            s.block_mut(id).ok_or(Error::UnknownSequence(id))?.timeout = micros;
            Ok(())
        })
    }

    fn safety(&self) -> Option<&'static crate::safety::SafetyHandle> {
        self.safety_system()
    }
}

impl<C> dyn Port<C> + '_ {
    /// The id of the sequence named `name`: one [`info`](Port::info) (one section) per
    /// registered sequence, the comparison outside.
    pub(crate) fn find(&self, name: &str) -> Option<SeqId> {
        (0..=u8::MAX)
            .map(SeqId)
            .map_while(|id| Some((id, self.info(id)?.name)))
            .find(|&(_, n)| n == name)
            .map(|(id, _)| id)
    }
}
