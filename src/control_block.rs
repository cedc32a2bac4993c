//! The framework-owned control block of one registered sequence (the seed's `BaseSequence`
//! fields), plus its counters.

use crate::{Behaviour, Cause, Outcome, RunningState, SeqId, MAX_DEPTH};
use core::task::Waker;

/// How often a sequence did what. Counters wrap at `u16::MAX`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Starts (not counting restarts).
    pub runs: u16,
    /// Runs that completed (exit condition true).
    pub completed: u16,
    /// Runs skipped because the pre-condition was false.
    pub skipped: u16,
    /// Aborts.
    pub aborts: u16,
    /// Restarts.
    pub restarts: u16,
    /// Exceptions raised by this sequence's monitors and timeout.
    pub exceptions: u16,
}

/// Flag bits of [`ControlBlock::flags`].
pub(crate) mod flag {
    /// A lane runs this sequence non-blocking.
    pub const HAS_LANE: u8 = 1 << 0;
    /// A non-blocking start waits for the lane to pick it up.
    pub const START_PENDING: u8 = 1 << 1;
    /// Waiting for a polled condition (the exit condition, or `Cx::wait_until`).
    pub const POLL_WAIT: u8 = 1 << 2;
    /// The tick says the exit condition is due.
    pub const POLL_DUE: u8 = 1 << 3;
    /// `exceptionIsActive`: a monitor of this sequence fired and its handling is pending, or
    /// this sequence was aborted because of it.
    pub const EXCEPTION_ACTIVE: u8 = 1 << 4;
    /// The exception sequence ended; the tick applies the pending behaviour.
    pub const EXCEPTION_DONE: u8 = 1 << 5;
    /// A [`Seq`](crate::Seq) object was bound to this id.
    pub const BOUND: u8 = 1 << 6;
}

/// Request bits of [`ControlBlock::requests`], applied by the next tick.
pub(crate) mod request {
    pub const ABORT: u8 = 1 << 0;
    pub const PAUSE: u8 = 1 << 1;
    pub const RESUME: u8 = 1 << 2;
}

/// `deadline` value of a timeout that is not armed.
pub(crate) const DISARMED: u64 = u64::MAX;

/// One registered sequence's state.
pub(crate) struct ControlBlock {
    pub(crate) name: &'static str,
    pub(crate) state: RunningState,
    /// `callerStack`: ids of all callers up to the main sequence, outermost first.
    pub(crate) stack: [u8; MAX_DEPTH],
    pub(crate) depth: u8,
    /// How many of the innermost callers this sequence blocks (`callerStackBlocking`).
    pub(crate) blocking: u8,
    /// The lane root whose waker drives this sequence.
    pub(crate) root: u8,
    pub(crate) flags: u8,
    pub(crate) requests: u8,
    /// Polling period in µs.
    pub(crate) polling: u32,
    /// Timeout in µs, 0 = off.
    pub(crate) timeout: u32,
    pub(crate) timeout_behaviour: Behaviour,
    pub(crate) timeout_exception: Option<SeqId>,
    pub(crate) timeout_restart_limit: u8,
    pub(crate) timeout_restarts: u8,
    pub(crate) timeout_runs_seen: u16,
    /// Next due poll (µs).
    pub(crate) next_poll: u64,
    /// Absolute timeout deadline while running; the remaining time while paused; `DISARMED`.
    pub(crate) deadline: u64,
    /// `activeException`: the monitor (or timeout) whose exception is active or was last.
    pub(crate) active_exception: Option<Cause>,
    /// Behaviour and target waiting for this sequence's exception sequence to end.
    pub(crate) pending: Option<(Behaviour, SeqId, Cause)>,
    /// For a running exception sequence: the owner whose exception it handles.
    pub(crate) exception_of: Option<SeqId>,
    /// A sequence waiting in `join` for this one.
    pub(crate) joiner: Option<SeqId>,
    /// Cause of the last abort or restart.
    pub(crate) last_cause: Cause,
    pub(crate) outcome: Option<Outcome>,
    pub(crate) counters: Counters,
    pub(crate) waker: Option<Waker>,
}

impl ControlBlock {
    pub(crate) const EMPTY: ControlBlock = ControlBlock {
        name: "",
        state: RunningState::Idle,
        stack: [0; MAX_DEPTH],
        depth: 0,
        blocking: 0,
        root: 0,
        flags: 0,
        requests: 0,
        polling: crate::config::DEFAULT_POLLING_MICROS,
        timeout: 0,
        timeout_behaviour: Behaviour::AbortOwner,
        timeout_exception: None,
        timeout_restart_limit: crate::monitor::DEFAULT_RESTART_LIMIT,
        timeout_restarts: 0,
        timeout_runs_seen: 0,
        next_poll: 0,
        deadline: DISARMED,
        active_exception: None,
        pending: None,
        exception_of: None,
        joiner: None,
        last_cause: Cause::Start,
        outcome: None,
        counters: Counters {
            runs: 0,
            completed: 0,
            skipped: 0,
            aborts: 0,
            restarts: 0,
            exceptions: 0,
        },
        waker: None,
    };

    pub(crate) fn has(&self, f: u8) -> bool {
        self.flags & f != 0
    }

    pub(crate) fn set(&mut self, f: u8, on: bool) {
        if on {
            self.flags |= f;
        } else {
            self.flags &= !f;
        }
    }

    /// The caller that started this sequence (`callerSequence`).
    pub(crate) fn caller(&self) -> Option<SeqId> {
        let d = usize::from(self.depth);
        d.checked_sub(1)
            .and_then(|i| self.stack.get(i))
            .map(|&c| SeqId(c))
    }

    /// True when `ancestor` is in this sequence's caller stack.
    pub(crate) fn descends_from(&self, ancestor: SeqId) -> bool {
        self.stack
            .iter()
            .take(usize::from(self.depth))
            .any(|&c| c == ancestor.0)
    }

    /// Monitors and timeout of this sequence may raise an exception now.
    pub(crate) fn accepts_exception(&self) -> bool {
        matches!(self.state, RunningState::Running | RunningState::Paused)
            && !self.has(flag::EXCEPTION_ACTIVE)
    }

    /// Run epoch: changes on every start and restart (resets edge detection).
    pub(crate) fn epoch(&self) -> u16 {
        self.counters.runs.wrapping_add(self.counters.restarts)
    }

    pub(crate) fn wake(&self) {
        if let Some(w) = &self.waker {
            w.wake_by_ref();
        }
    }
}
