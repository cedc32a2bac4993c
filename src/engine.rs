//! The object-safe view of a [`Sequencer`] that contexts and handles use, so user code is
//! generic only over the control system `C`, not over the sequencer's capacities.

use core::task::{Poll, Waker};

use crate::control_block::flag;
use crate::lock::Lock;
use crate::sequencer::{steps, Gate, Mode, Steps};
use crate::{Cause, Error, Instant, Outcome, RunningState, SeqId, Sequencer, Transition};

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

/// The `bit` of [`Engine::edit`] that sets whether a sequence waits for a polled condition
/// (bit 0 of the flags: never a request).
const POLL_WAIT: u16 = 1;

pub(crate) trait Engine<C> {
    fn now(&self) -> Instant;
    fn begin(&self, id: SeqId, caller: Option<SeqId>, mode: Mode) -> Result<(), Error>;
    /// Parks `waker` for `id`'s lane and says what an await point must do; with `polled`,
    /// `Go` only when the tick said a polled condition is due (one vtable entry for
    /// `gate` and `poll_due` below).
    fn wait(&self, id: SeqId, waker: &Waker, polled: bool) -> Gate;
    fn restarted(&self, id: SeqId);
    /// Ends `id`'s run normally with `outcome` (`Completed` or `Skipped`); false when
    /// refused (the gate says what to do instead).
    fn end(&self, id: SeqId, outcome: Outcome) -> bool;
    fn finished(&self, id: SeqId, outcome: Outcome);
    /// The future of `id`'s run was dropped before the run ended: the run and its
    /// sub-sequences are aborted now ([`Cause::Dropped`], innermost first, through their
    /// cleanup hooks).
    fn abandon(&self, id: SeqId, control: &C);
    /// Finds or claims `id`'s lane slot.
    fn declare_lane(&self, id: SeqId) -> Result<u8, Error>;
    /// A lane's wait for a start of `id`: declares the lane, keeps `waker` as its waker
    /// and takes a pending non-blocking start (true).
    fn take_start(&self, id: SeqId, waker: &Waker) -> bool;
    fn join(&self, joiner: SeqId, target: SeqId) -> Poll<Result<Outcome, Error>>;
    fn info(&self, id: SeqId) -> Option<Info>;
    /// Queues request `bit` for the next tick, or with `bit` 0 sets the timeout to
    /// `value` µs, or with [`POLL_WAIT`] sets whether `id` waits for a polled condition
    /// (`value` 1) or not: one vtable entry for `request`, `set_timeout` and `poll_wait`
    /// below.
    fn edit(&self, id: SeqId, bit: u16, value: u32) -> Result<(), Error>;
    fn safety(&self) -> Option<&'static crate::safety::SafetyHandle>;
}

/// Each method is a few [`Steps`]: with the portable lock a few short sections (a waker is
/// parked in its own section before the state is read, so no wake-up is lost in between;
/// walks take one section per step), with a coarse lock one section.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Engine<C>
    for Sequencer<C, N, T, L, W>
{
    fn now(&self) -> Instant {
        Sequencer::now(self)
    }

    fn begin(&self, id: SeqId, caller: Option<SeqId>, mode: Mode) -> Result<(), Error> {
        Sequencer::begin(self, id, caller, mode, Cause::Start, 0)
    }

    fn wait(&self, id: SeqId, waker: &Waker, polled: bool) -> Gate {
        // The waker is kept before the state is read: a wake-up in between is not lost.
        let lane = self.with(|s| s.lane_slot(id));
        self.park_lane(lane, waker);
        steps!(self, |s| {
            s.step(|s| match s.gate(id) {
                Gate::Go if polled && s.poll_due.has(id) => {
                    s.poll_due.set(id, false);
                    Gate::Go
                }
                Gate::Go if polled => Gate::Hold,
                other => other,
            })
        })
    }

    fn restarted(&self, id: SeqId) {
        steps!(self, |s| {
            s.launch(id, None, Cause::Restart);
        });
    }

    fn end(&self, id: SeqId, outcome: Outcome) -> bool {
        let cause = match outcome {
            Outcome::Skipped => Cause::PreConditionFalse,
            _ => Cause::Completed,
        };
        let t = Transition::edge(id, RunningState::Running, RunningState::Terminated, cause);
        self.with(|s| s.end(&t))
    }

    fn finished(&self, id: SeqId, outcome: Outcome) {
        let joiners = steps!(self, |s| {
            // The run no longer waits for a poll (`poll_wait(id, false)`, a step of its own:
            // the section of the end stays short).
            s.step(|s| {
                s.poll_wait.set(id, false);
                s.poll_due.set(id, false);
            });
            s.step(|s| s.finished(id, outcome));
            s.step(|s| s.release_joiners(id))
        });
        self.wake_lanes(joiners);
    }

    fn abandon(&self, id: SeqId, control: &C) {
        self.walk(control, Some(id), RunningState::Aborting, Cause::Dropped);
    }

    fn declare_lane(&self, id: SeqId) -> Result<u8, Error> {
        steps!(self, |s| s.declare_lane(id)).ok_or(Error::LaneCapacityExceeded(id))
    }

    fn take_start(&self, id: SeqId, waker: &Waker) -> bool {
        let Ok(lane) = Engine::declare_lane(self, id) else {
            // No slot left: the lane never runs (see `lane`).
            return false;
        };
        // The waker is kept before the start is looked for: a start in between wakes it.
        self.park_lane(lane, waker);
        self.with(|s| {
            let Ok(b) = s.block_mut(id) else {
                return false;
            };
            let pending = b.has(flag::START_PENDING);
            b.set(flag::START_PENDING, false);
            pending
        })
    }

    fn join(&self, joiner: SeqId, target: SeqId) -> Poll<Result<Outcome, Error>> {
        if steps!(self, |s| s.join_would_deadlock(joiner, target)) {
            return Poll::Ready(Err(Error::JoinWouldDeadlock(target)));
        }
        // Registered before the run's end is looked for: an end in between releases it.
        self.with(|s| s.wait_for_join(joiner, target));
        let ended = self.with(|s| {
            let b = s.block(target)?;
            if b.state == RunningState::Idle {
                return Err(Error::NeverStarted(target));
            }
            Ok(match b.outcome {
                Some(o) if !b.state.is_active() && !b.has(flag::START_PENDING) => Some(o),
                // Running, or ended but its framework has not returned yet.
                _ => None,
            })
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
            let b = s.block(id).ok()?;
            Some(Info {
                name: b.name(),
                state: b.state,
                caller: b.caller.get(),
                lane: b.lane,
                exception_active: s.excepting.has(id),
                active_exception: b.active_exception,
                #[cfg(feature = "counters")]
                counters: s.counters.get(id.index()).copied().unwrap_or_default(),
                outcome: b.outcome,
            })
        })
    }

    fn edit(&self, id: SeqId, bit: u16, value: u32) -> Result<(), Error> {
        self.with(|s| {
            let b = s.block_mut(id)?;
            match bit {
                0 => b.timeout = value,
                POLL_WAIT => {
                    s.poll_wait.set(id, value != 0);
                    // A stale due poll is dropped either way.
                    s.poll_due.set(id, false);
                }
                _ => return s.request(id, bit),
            }
            Ok(())
        })
    }

    fn safety(&self) -> Option<&'static crate::safety::SafetyHandle> {
        self.safety_system()
    }
}

impl<C> dyn Engine<C> + '_ {
    /// Parks `waker` for `id`'s lane and says what an await point must do.
    #[inline]
    pub(crate) fn gate(&self, id: SeqId, waker: &Waker) -> Gate {
        self.wait(id, waker, false)
    }

    /// Like [`gate`](Self::gate), but `Go` only when the tick said a polled condition is
    /// due.
    #[inline]
    pub(crate) fn poll_due(&self, id: SeqId, waker: &Waker) -> Gate {
        self.wait(id, waker, true)
    }

    /// Queues a pause, resume or abort request (`bit`) for the next tick.
    pub(crate) fn request(&self, id: SeqId, bit: u16) -> Result<(), Error> {
        self.edit(id, bit, 0)
    }

    /// Sets the timeout of `id` (µs, 0 = off) for its next run.
    pub(crate) fn set_timeout(&self, id: SeqId, micros: u32) -> Result<(), Error> {
        self.edit(id, 0, micros)
    }

    /// Marks `id` as waiting for a polled condition (`on`) or not; a stale due poll is
    /// dropped either way. Nothing for an unknown id.
    pub(crate) fn poll_wait(&self, id: SeqId, on: bool) {
        let _ = self.edit(id, POLL_WAIT, u32::from(on));
    }

    /// The id of the sequence named `name`: one [`info`](Engine::info) (one section) per
    /// registered sequence, the comparison outside. Not a method of the vtable, so a
    /// firmware that never looks a name up links none of it.
    pub(crate) fn find(&self, name: &str) -> Option<SeqId> {
        (0..=u8::MAX)
            .map(SeqId)
            .map_while(|id| Some((id, self.info(id)?.name)))
            .find(|&(_, n)| n == name)
            .map(|(id, _)| id)
    }
}
