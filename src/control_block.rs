//! The framework-owned control block of one registered sequence (the seed's `BaseSequence`
//! fields), plus its counters.

use crate::{Behaviour, Cause, Outcome, RunningState, SeqId, MAX_DEPTH};
use core::task::Waker;

/// How often a sequence did what. Counters wrap at `u16::MAX`.
///
/// ```
/// use rtseq::{SeqConfig, Sequencer};
/// let seq: Sequencer<(), 1> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("a")).unwrap();
/// let c = seq.sequence_by_id(id).unwrap().counters();
/// assert_eq!((c.runs, c.aborts, c.restarts, c.exceptions), (0, 0, 0, 0));
/// ```
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
    /// The timeout monitor is armed (`deadline` is meaningful).
    pub const TIMEOUT_ARMED: u8 = 1 << 7;
}

/// Request bits of [`ControlBlock::requests`], applied by the next tick.
pub(crate) mod request {
    pub const ABORT: u8 = 1 << 0;
    pub const PAUSE: u8 = 1 << 1;
    pub const RESUME: u8 = 1 << 2;
}

/// Times in a control block are the low 32 bits of sequencer microseconds, compared by
/// wrapping difference: correct while every interval (polling period, timeout) is below
/// 2^31 µs (35 min), which registration enforces. Half the RAM and cheaper arithmetic on a
/// 32-bit core than `u64`.
pub(crate) type Micros32 = u32;

/// Whether `now` has reached `at` (wrapping comparison, see [`Micros32`]).
#[inline]
pub(crate) fn reached(now: u64, at: Micros32) -> bool {
    // Truncation is the point: both sides are the low 32 bits.
    (now as u32).wrapping_sub(at) < 0x8000_0000
}

/// `now + d` in the low 32 bits.
#[inline]
pub(crate) fn after(now: u64, d: u32) -> Micros32 {
    (now as u32).wrapping_add(d)
}

/// The absolute time (full width) of `at`, a time not more than 2^31 µs after `now`.
#[inline]
pub(crate) fn absolute(now: u64, at: Micros32) -> u64 {
    let ahead = at.wrapping_sub(now as u32);
    if ahead >= 0x8000_0000 {
        now
    } else {
        now.saturating_add(u64::from(ahead))
    }
}

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
    pub(crate) next_poll: Micros32,
    /// Timeout deadline while running; the remaining time while paused; only meaningful
    /// with `flag::TIMEOUT_ARMED`.
    pub(crate) deadline: Micros32,
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
        deadline: 0,
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
