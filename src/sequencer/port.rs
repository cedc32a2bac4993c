//! The port: the object-safe view of a [`Sequencer`] that contexts, runs and handles use,
//! so that user code is generic only over the control system `C`, not over the
//! sequencer's capacities and lock. One method per operation.

use core::task::{Poll, Waker};

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::sequencer::callers::join_would_deadlock;
use crate::sequencer::clearance::Clearance;
use crate::sequencer::control_block::{flag, ControlBlock};
use crate::sequencer::end::end_run;
use crate::sequencer::inbox::abort_all_posted;
use crate::sequencer::lanes::declare_lane;
use crate::sequencer::requests::{abort_child, ask};
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::trace::StateChange;
use crate::{
    Cause, Error, Event, Instant, Outcome, Request, Requester, RunningState, SeqId, Sequencer,
};

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
    /// The unpaused time of `id`'s current run at the last tick (µs).
    fn run_time(&self, id: SeqId) -> u64;
    /// Starts `id`, whose sequence object was made by the sequencer tagged `maker`,
    /// blocking: it runs in the lane of `caller`, inside its future. Returns the new run.
    fn start_blocking(&self, id: SeqId, maker: u16, caller: RunId) -> Result<RunId, Error>;
    /// Starts `id` in its own lane as a main sequence (the application's start, through a
    /// handle of its own). Returns the new run.
    fn start_main(&self, id: SeqId) -> Result<RunId, Error>;
    /// Starts `id` in its own lane as a non-blocking child of the run `caller`. Returns
    /// the new run.
    fn start_child(&self, id: SeqId, caller: RunId) -> Result<RunId, Error>;
    /// Starts `id` in its own lane as a main sequence, for the run `by` (through a handle
    /// of its context): refused as `by`'s own starts are. Returns the new run.
    fn start_main_by(&self, id: SeqId, by: RunId) -> Result<RunId, Error>;
    /// Keeps `waker` for the lane of `run`'s sequence, then says what an await point of
    /// `run` must do (a run that is not the current one: `Aborted`). For the run that
    /// drives a lane: the lane's wake-ups go to the waker it polls with.
    fn clearance(&self, run: RunId, waker: &Waker) -> Clearance;
    /// As [`clearance`](Self::clearance), but `Go` only when the tick said `run`'s polled
    /// condition is due (and takes that due poll).
    fn due_poll(&self, run: RunId, waker: &Waker) -> Clearance;
    /// What an await point of `run` must do, keeping no waker: for what is polled inside
    /// a lane's poll after the lane's run kept its waker (an action's futures, a blocking
    /// run), so no wake-up between the two is lost. A future polled elsewhere, with
    /// another waker (from a condition method), leaves the lane's waker alone.
    fn clearance_of(&self, run: RunId) -> Clearance;
    /// As [`clearance_of`](Self::clearance_of), but `Go` only when `run`'s polled condition
    /// is due (and takes that due poll).
    fn due_poll_of(&self, run: RunId) -> Clearance;
    /// Sets whether `run` waits for a polled condition; a stale due poll is dropped.
    fn set_poll_wait(&self, run: RunId, waiting: bool);
    /// `run`, `Restarting`, runs again from its pre-condition.
    fn restart(&self, run: RunId);
    /// Ends `run` with `outcome` (`Completed`, `Skipped` or `Failed`): `Terminated`, and
    /// a failure recorded; false when refused (its clearance says what to do instead).
    fn end(&self, run: RunId, outcome: Outcome) -> bool;
    /// `run` is over (it ended, or was aborted): releases the joiners.
    fn finished(&self, run: RunId);
    /// The future of a run of `id` was dropped before the run ended: the run and its
    /// sub-sequences are aborted now ([`Cause::Dropped`], innermost first, through their
    /// cleanup hooks). The future borrows `id`'s sequence object until it is dropped, so
    /// no other future drives `id` meanwhile: a later run is one started in `id`'s lane
    /// and not taken yet, which no one would drive once that lane is gone, and it is
    /// aborted too.
    fn abandon(&self, id: SeqId, control: &C);
    /// The lane of `id`, whose sequence object was made by the sequencer tagged `maker`,
    /// was dropped while it waited for a start: a start made but not taken is aborted as
    /// in [`abandon`](Self::abandon), since only a future holding that object could take
    /// it. The lane of another sequencer's object changes nothing here.
    fn abandon_start(&self, id: SeqId, maker: u16, control: &C);
    /// The lane future of `id`, whose sequence object was made by the sequencer tagged
    /// `maker`, was dropped: its lane takes no start until a lane future waits in it again.
    fn close_lane(&self, id: SeqId, maker: u16);
    /// Finds or claims `id`'s lane slot.
    fn declare_lane(&self, id: SeqId) -> Result<u8, Error>;
    /// A lane's wait for a start of `id`, whose sequence object was made by the sequencer
    /// tagged `maker`: declares the lane, keeps `waker` as its waker and takes a pending
    /// non-blocking start: its run. The lane of another sequencer's object declares
    /// nothing and never runs here (a start of `id` finds no lane).
    fn take_start(&self, id: SeqId, maker: u16, waker: &Waker) -> Option<RunId>;
    /// The run of `target` that a join made now waits for: the current run, or the last
    /// one if it ended, so a join never waits for a later run. Taken in the join's first
    /// poll, before its registration, cycle check and look, which are then all of that
    /// run. `NeverStarted` for a sequence that has no run yet.
    fn join_run(&self, target: SeqId) -> Result<RunId, Error>;
    /// `joiner` waits for the end of `run`: its outcome once it ended. A cycle found is
    /// none once a later run of its sequence has begun.
    fn join(&self, joiner: SeqId, run: RunId) -> Poll<Result<Outcome, Error>>;
    /// A join of `joiner` was dropped while it waited (the loser of a `select`, an action
    /// aborted or restarted): it no longer waits.
    fn stop_join(&self, joiner: SeqId);
    /// A snapshot of `id`'s control block.
    fn info(&self, id: SeqId) -> Option<Info>;
    /// Queues `request` of `id`, made by `by`, for the next tick.
    fn request(&self, id: SeqId, request: Request, by: Requester) -> Result<(), Error>;
    /// Queues an abort of `child`, a run started by `caller` (not of a later run of its
    /// sequence), made by `caller`, for the next tick.
    fn abort_child(&self, child: RunId, caller: SeqId) -> Result<(), Error>;
    /// Sets `id`'s timeout (µs, 0: off): at once for a run under way whose timeout is
    /// armed, otherwise from the next start or restart.
    fn set_timeout(&self, id: SeqId, micros: u32) -> Result<(), Error>;
    /// The handle of the safety system built on this sequencer's handle, if one is.
    fn safety_system(&self) -> Option<&crate::safety::SafetyHandle>;
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

    fn run_time(&self, id: SeqId) -> u64 {
        self.with(|s| s.run_time(id))
    }

    fn start_blocking(&self, id: SeqId, maker: u16, caller: RunId) -> Result<RunId, Error> {
        self.begin(id, Mode::Blocking { caller, maker }, Cause::Start)
    }

    fn start_main(&self, id: SeqId) -> Result<RunId, Error> {
        self.begin(id, Mode::NonBlocking { caller: None }, Cause::Start)
    }

    fn start_child(&self, id: SeqId, caller: RunId) -> Result<RunId, Error> {
        let caller = Some(caller);
        self.begin(id, Mode::NonBlocking { caller }, Cause::Start)
    }

    fn start_main_by(&self, id: SeqId, by: RunId) -> Result<RunId, Error> {
        self.begin(id, Mode::MainBy { by }, Cause::Start)
    }

    fn clearance(&self, run: RunId, waker: &Waker) -> Clearance {
        let posted = abort_all_posted(&self.safety.inbox);
        self.park_then(run.seq, waker, |s| s.clearance(run, posted))
    }

    fn due_poll(&self, run: RunId, waker: &Waker) -> Clearance {
        let posted = abort_all_posted(&self.safety.inbox);
        self.park_then(run.seq, waker, |s| s.take_due_poll(run, posted))
    }

    fn clearance_of(&self, run: RunId) -> Clearance {
        self.clearance_in_lane(run)
    }

    // A blocking child held with its caller has no due poll: the hold skips those not
    // taken yet (`skip_untaken_polls`), and the tick wakes no held sequence for one.
    fn due_poll_of(&self, run: RunId) -> Clearance {
        let posted = abort_all_posted(&self.safety.inbox);
        self.with(|s| s.take_due_poll(run, posted))
    }

    fn set_poll_wait(&self, run: RunId, waiting: bool) {
        self.with(|s| s.set_poll_wait(run, waiting));
    }

    fn restart(&self, run: RunId) {
        Sequencer::restart(self, run);
    }

    fn end(&self, run: RunId, outcome: Outcome) -> bool {
        let cause = match outcome {
            Outcome::Skipped => Cause::PreConditionFalse,
            Outcome::Completed => Cause::Completed,
            Outcome::Failed(_) => Cause::Failed,
            Outcome::Aborted(cause) => cause,
        };
        let change = StateChange::new(
            run.seq,
            RunningState::Running,
            RunningState::Terminated,
            cause,
        );
        let inbox = &self.safety.inbox;
        let ended = in_sections!(self, |s| end_run(s, run, &change, outcome, inbox));
        if let (true, Outcome::Failed(failure)) = (ended, outcome) {
            self.with(|s| {
                s.record(Event::Failed {
                    sequence: run.seq,
                    failure,
                })
            });
        }
        ended
    }

    fn finished(&self, run: RunId) {
        in_sections_then_wake!(self, |s| {
            // The run no longer waits for a poll.
            s.section(|s| s.set_poll_wait(run, false));
            s.section(|s| s.release_joiners(run))
        });
    }

    fn abandon(&self, id: SeqId, control: &C) {
        self.abort_dropped(control, id);
    }

    fn abandon_start(&self, id: SeqId, maker: u16, control: &C) {
        let pending = self
            .with(|s| s.tag == maker && s.block(id).is_some_and(|b| b.has(flag::START_PENDING)));
        if pending {
            self.abort_dropped(control, id);
        }
    }

    fn declare_lane(&self, id: SeqId) -> Result<u8, Error> {
        in_sections!(self, |s| declare_lane(s, id)).ok_or(Error::LaneCapacityExceeded(id))
    }

    fn close_lane(&self, id: SeqId, maker: u16) {
        Sequencer::close_lane(self, id, maker);
    }

    fn take_start(&self, id: SeqId, maker: u16, waker: &Waker) -> Option<RunId> {
        // Another sequencer's object declares nothing here; with no slot left the lane
        // never runs (see `lane`), and is remembered for `check_lanes`.
        let declared = in_sections!(self, |s| {
            if s.section(|s| s.tag == maker) {
                let lane = declare_lane(s, id);
                if lane.is_none() {
                    s.section(|s| s.refuse_lane(id));
                }
                lane
            } else {
                None
            }
        });
        let lane = declared?;
        // The waker is kept before the start is looked for: a start in between wakes it.
        self.park_in_then(
            |_| lane,
            waker,
            |s| {
                s.open_lane(lane);
                let b = s.block_mut(id).filter(|b| b.has(flag::START_PENDING))?;
                b.set(flag::START_PENDING, false);
                Some(RunId {
                    seq: id,
                    count: b.runs,
                })
            },
        )
    }

    fn join_run(&self, target: SeqId) -> Result<RunId, Error> {
        // The run joined is the one current at the first poll's first section (semantics
        // 14), so the wait always names the run the look looks at. A sequence never started
        // then has no run to join: a start of it after that section is a later run, which
        // the join does not wait for.
        self.with(|s| {
            let b = s.block(target).ok_or(Error::UnknownSequence(target))?;
            if b.state == RunningState::Idle {
                return Err(Error::NeverStarted(target));
            }
            Ok(RunId {
                seq: target,
                count: b.runs,
            })
        })
    }

    fn join(&self, joiner: SeqId, run: RunId) -> Poll<Result<Outcome, Error>> {
        let RunId {
            seq: target,
            count: registered,
        } = run;
        // Registered before the cycle check and the look for the run's end. Of two joins
        // that close a cycle, the one registered later sees the other's registration (a
        // check before the registration could miss a join registered in between, and both
        // would wait for good); an end in between releases it. A join of a run before the
        // current one never waits (its outcome is kept, or lost): it registers nothing and
        // closes no cycle.
        let waits = self.with(|s| {
            let waits = s.block(target).is_some_and(|b| b.runs == registered);
            if waits {
                s.wait_for_join(joiner, target, registered);
            }
            waits
        });
        // A registration is a change to a cycle check under way in a lane below, which may
        // have read the waits before it (that lane resumes only after this poll). The count
        // after it is the one this check begins with: what came before, the check sees.
        let mut seen = self.with(|s| {
            if waits {
                s.changes = s.changes.wrapping_add(1);
            }
            s.changes
        });
        // A cycle found is none once a later run of the target has begun (before the
        // check, or during it): the joined run ended and released this join, which waits
        // for nothing then, and the wait the check found is the later run's. The check
        // reads the waits in several sections: a cycle found while they changed (a run
        // that waited ended, a new wait was made) may join waits that never stood
        // together, so the check is made again on the waits as they are. A refused join
        // stops counting as a wait in the look's own section: a wait followed until a later
        // section would be met, in between, by the cycle check of a join of a lane above,
        // as if this join still waited. (The wait of a join that got an outcome is for a
        // run that is over: no check follows it.)
        let ended = loop {
            let cycle = waits && in_sections!(self, |s| join_would_deadlock(s, joiner, target));
            let look = self.with(|s| {
                let later_begun = s.block(target).is_some_and(|b| b.runs != registered);
                match (cycle && !later_begun, s.changes == seen) {
                    (true, false) => Err(s.changes),
                    (true, true) => {
                        s.join_decided(joiner);
                        Ok(Err(Error::JoinWouldDeadlock(target)))
                    }
                    (false, _) => Ok(s.joined_outcome(run)),
                }
            });
            match look {
                Ok(ended) => break ended,
                Err(changes) => seen = changes,
            }
        };
        let result = match ended {
            Ok(None) => return Poll::Pending,
            Ok(Some(outcome)) => Ok(outcome),
            Err(e) => Err(e),
        };
        self.update_and_wake(|s| s.join_returned(joiner, target, registered));
        Poll::Ready(result)
    }

    fn stop_join(&self, joiner: SeqId) {
        self.update_and_wake(|s| s.join_dropped(joiner));
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
                exception_active: exception_active(b, s.sets.has(Set::Excepting, id)),
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

    fn abort_child(&self, child: RunId, caller: SeqId) -> Result<(), Error> {
        in_sections!(self, |s| abort_child(s, child, caller))
    }

    fn set_timeout(&self, id: SeqId, micros: u32) -> Result<(), Error> {
        self.with(|s| {
            s.block_mut(id).ok_or(Error::UnknownSequence(id))?.timeout = micros;
            Ok(())
        })
    }

    fn safety_system(&self) -> Option<&crate::safety::SafetyHandle> {
        Sequencer::safety_system(self)
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

/// `exception_is_active` of a block whose mark of an exception is `excepting`: of a run
/// under way the mark; of one being stopped or stopped (`Aborting`, `Aborted`,
/// `Restarting`), whether an exception marked this run or round (as its owner, or as its
/// behaviour's target) and is what stops it (the cause of its teardown, set in its first
/// section), whatever a teardown for another cause, or from above for an exception that
/// marked an earlier round, or a start refused after its schedule left of the mark.
fn exception_active(b: &ControlBlock, excepting: bool) -> bool {
    match b.state {
        RunningState::Aborting | RunningState::Aborted | RunningState::Restarting => {
            b.has(flag::EXCEPTION_MARKED) && b.active_exception == Some(b.last_cause)
        }
        _ => excepting,
    }
}
