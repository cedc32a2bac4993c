//! The framework-owned control block of one registered sequence (the seed's `BaseSequence`
//! fields), plus its optional counters.

#[cfg(doc)]
use crate::MAX_DEPTH;
use crate::{Behaviour, Cause, Outcome, RunningState, SeqId};

/// How often a sequence did what (feature `counters`: 12 bytes per sequence). Counters wrap
/// at `u16::MAX`.
///
/// ```
/// use rtseq::{SeqConfig, Sequencer};
/// let seq: Sequencer<(), 1> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("a")).unwrap();
/// let c = seq.sequence_by_id(id).unwrap().counters();
/// assert_eq!((c.runs, c.aborts, c.restarts, c.exceptions), (0, 0, 0, 0));
/// ```
#[cfg(feature = "counters")]
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

#[cfg(feature = "counters")]
impl Counters {
    pub(crate) const ZERO: Counters = Counters {
        runs: 0,
        completed: 0,
        skipped: 0,
        aborts: 0,
        restarts: 0,
        exceptions: 0,
    };

    /// Counts one transition.
    pub(crate) fn count(&mut self, from: RunningState, to: RunningState, cause: Cause) {
        let c = match to {
            RunningState::Aborted => &mut self.aborts,
            RunningState::Restarting => &mut self.restarts,
            RunningState::Terminated if cause == Cause::PreConditionFalse => &mut self.skipped,
            RunningState::Terminated => &mut self.completed,
            RunningState::Running if from != RunningState::Paused && cause != Cause::Restart => {
                &mut self.runs
            }
            _ => return,
        };
        *c = c.wrapping_add(1);
    }
}

/// Flag bits of [`ControlBlock::flags`].
pub(crate) mod flag {
    // Bit 0 is free (a declared lane is known by its lane slot).
    /// A non-blocking start waits for the lane to pick it up.
    pub const START_PENDING: u16 = 1 << 1;
    /// Waiting for a polled condition (the exit condition, or `Cx::wait_until`).
    pub const POLL_WAIT: u16 = 1 << 2;
    /// The tick says the exit condition is due.
    pub const POLL_DUE: u16 = 1 << 3;
    /// `exceptionIsActive`: a monitor of this sequence fired and its handling is pending, or
    /// this sequence was aborted because of it.
    pub const EXCEPTION_ACTIVE: u16 = 1 << 4;
    /// The exception sequence ended; the tick applies the pending behaviour.
    pub const EXCEPTION_DONE: u16 = 1 << 5;
    /// A [`Seq`](crate::Seq) object was bound to this id.
    pub const BOUND: u16 = 1 << 6;
    /// The timeout monitor is armed (`deadline` is meaningful).
    pub const TIMEOUT_ARMED: u16 = 1 << 7;
    /// A new run or restart began: the tick resets the edge detection of this sequence's
    /// monitors before their next evaluation.
    pub const FRESH: u16 = 1 << 8;
    /// This run is an exception sequence: its caller is the owner whose exception it
    /// handles, and its end is reported to the tick.
    pub const HANDLES_EXCEPTION: u16 = 1 << 9;
}

/// Request bits of [`ControlBlock::flags`], applied by the next tick.
pub(crate) mod request {
    pub const ABORT: u16 = 1 << 10;
    pub const PAUSE: u16 = 1 << 11;
    pub const RESUME: u16 = 1 << 12;
    /// All request bits.
    pub const ALL: u16 = ABORT | PAUSE | RESUME;
}

/// The bits of the pending behaviour in [`ControlBlock::flags`].
pub(crate) const PENDING_MASK: u16 = pending::MASK;

/// The behaviour waiting for the end of an exception sequence, in the top three bits of
/// [`ControlBlock::flags`] (0 = none).
mod pending {
    use crate::Behaviour;
    pub const SHIFT: u32 = 13;
    pub const MASK: u16 = 0b111 << SHIFT;
    /// By discriminant.
    pub const BEHAVIOURS: [Behaviour; 5] = [
        Behaviour::Nothing,
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ];
}

/// A 1-byte optional sequence id (`SeqId` values stop at 254).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct Link(u8);

impl Link {
    pub(crate) const NONE: Link = Link(u8::MAX);

    pub(crate) fn to(id: Option<SeqId>) -> Link {
        id.map_or(Link::NONE, |i| Link(i.0))
    }

    pub(crate) fn get(self) -> Option<SeqId> {
        (self != Link::NONE).then_some(SeqId(self.0))
    }
}

/// Times in a control block are the low 32 bits of sequencer microseconds, compared by
/// wrapping difference: correct while every interval (polling period, timeout) is below
/// 2^31 µs (35 min), which registration enforces. Half the RAM and cheaper arithmetic on a
/// 32-bit core than `u64`.
pub(crate) type Micros32 = u32;

/// Whether `now` (the low 32 bits of sequencer time) has reached `at` (wrapping
/// comparison, see [`Micros32`]).
#[inline]
pub(crate) fn reached32(now: u32, at: Micros32) -> bool {
    now.wrapping_sub(at) < 0x8000_0000
}

/// Horizon of "nothing to poll": the tick scans again after this long at the latest.
pub(crate) const NEVER_AHEAD: u32 = 0x7FFF_FFFF;

/// Whichever of `a` and `b` comes first after `now` (wrapping, see [`Micros32`]).
#[inline]
pub(crate) fn earlier(now: u32, a: Micros32, b: Micros32) -> Micros32 {
    if a.wrapping_sub(now) <= b.wrapping_sub(now) {
        a
    } else {
        b
    }
}

/// `now + d` in the low 32 bits.
#[inline]
pub(crate) fn after(now: u64, d: u32) -> Micros32 {
    (now as u32).wrapping_add(d)
}

/// One registered sequence's state: 44 bytes on a 32-bit target (with its cleanup-hook slot
/// 48), so a sequencer for 32 sequences needs 1.5 KiB.
///
/// The caller stack is not stored: each block links to its caller, and the stack, its depth
/// and its blocking part are walked from the links (at most [`MAX_DEPTH`] steps). Wakers
/// live with the lanes, not here; counters only with the feature `counters`.
pub(crate) struct ControlBlock {
    pub(crate) name: &'static str,
    /// Polling period in µs.
    pub(crate) polling: u32,
    /// Timeout in µs, 0 = off.
    pub(crate) timeout: u32,
    /// Next due poll (µs).
    pub(crate) next_poll: Micros32,
    /// Timeout deadline while running; the remaining time while paused; only meaningful
    /// with `flag::TIMEOUT_ARMED`.
    pub(crate) deadline: Micros32,
    /// [`flag`]s, [`request`]s and the pending behaviour.
    pub(crate) flags: u16,
    /// Starts (not restarts): a new run resets the restart books of the monitors.
    pub(crate) runs: u16,
    pub(crate) timeout_runs_seen: u16,
    /// `activeException`: the monitor (or timeout) whose exception is active or was last.
    pub(crate) active_exception: Option<Cause>,
    /// Cause of the last abort or restart.
    pub(crate) last_cause: Cause,
    pub(crate) outcome: Option<Outcome>,
    pub(crate) state: RunningState,
    /// `callerSequence`.
    pub(crate) caller: Link,
    /// The lane slot whose waker drives this sequence.
    pub(crate) lane: u8,
    pub(crate) timeout_behaviour: Behaviour,
    pub(crate) timeout_exception: Link,
    pub(crate) timeout_restart_limit: u8,
    pub(crate) timeout_restarts: u8,
    /// A sequence waiting in `join` for this one.
    pub(crate) joiner: Link,
}

/// No lane slot.
pub(crate) const NO_LANE: u8 = u8::MAX;

impl ControlBlock {
    pub(crate) const EMPTY: ControlBlock = ControlBlock {
        name: "",
        polling: crate::config::DEFAULT_POLLING_MICROS,
        timeout: 0,
        next_poll: 0,
        deadline: 0,
        flags: 0,
        runs: 0,
        timeout_runs_seen: 0,
        active_exception: None,
        last_cause: Cause::Start,
        outcome: None,
        state: RunningState::Idle,
        caller: Link::NONE,
        lane: NO_LANE,
        timeout_behaviour: Behaviour::AbortOwner,
        timeout_exception: Link::NONE,
        timeout_restart_limit: crate::monitor::DEFAULT_RESTART_LIMIT,
        timeout_restarts: 0,
        joiner: Link::NONE,
    };

    pub(crate) fn has(&self, f: u16) -> bool {
        self.flags & f != 0
    }

    pub(crate) fn set(&mut self, f: u16, on: bool) {
        if on {
            self.flags |= f;
        } else {
            self.flags &= !f;
        }
    }

    /// Takes the pending request bits.
    pub(crate) fn take_requests(&mut self) -> u16 {
        let r = self.flags & request::ALL;
        self.flags &= !request::ALL;
        r
    }

    /// The behaviour waiting for this sequence's exception sequence to end.
    pub(crate) fn pending(&self) -> Option<Behaviour> {
        let code = usize::from((self.flags & pending::MASK) >> pending::SHIFT);
        pending::BEHAVIOURS.get(code.wrapping_sub(1)).copied()
    }

    pub(crate) fn set_pending(&mut self, b: Option<Behaviour>) {
        // Codes 1..=5 (the enum's discriminant + 1); 0 = none.
        let code = b.map_or(0, |b| b as u16 + 1);
        self.flags = (self.flags & !pending::MASK) | (code << pending::SHIFT);
    }

    /// The tick's scan of this block at `now` (the low 32 bits): when its polling period is
    /// due, advances its polling schedule and notes an expired timeout and a due
    /// exit-condition poll. Returns its [`mark`](crate::tick::mark): 0 for an inactive
    /// sequence, `ACTIVE` and more for a running or paused one.
    #[inline(always)]
    pub(crate) fn scan(&mut self, now: u32) -> u8 {
        use crate::tick::mark;
        let running = self.state == RunningState::Running;
        if !running && self.state != RunningState::Paused {
            return 0;
        }
        let f = self.flags;
        let mut m = mark::ACTIVE;
        if !running || f & flag::EXCEPTION_ACTIVE != 0 {
            m |= mark::HELD;
        }
        if !reached32(now, self.next_poll) {
            return m;
        }
        m |= mark::DUE;
        let mut next = self.next_poll.wrapping_add(self.polling);
        if reached32(now, next) {
            // Missed periods (a late tick) are not replayed.
            next = now.wrapping_add(self.polling);
        }
        self.next_poll = next;
        // One test for the three things a due poll may have to do besides its monitors.
        if f & (flag::FRESH | flag::TIMEOUT_ARMED | flag::POLL_WAIT) != 0 {
            let mut f = f;
            if f & flag::FRESH != 0 {
                f &= !flag::FRESH;
                m |= mark::FRESH;
            }
            if running {
                if f & flag::TIMEOUT_ARMED != 0 && reached32(now, self.deadline) {
                    m |= mark::EXPIRED;
                }
                if f & flag::POLL_WAIT != 0 {
                    f |= flag::POLL_DUE;
                    m |= mark::WAKE;
                }
            }
            self.flags = f;
        }
        m
    }

    /// Monitors and timeout of this sequence may raise an exception now.
    pub(crate) fn accepts_exception(&self) -> bool {
        matches!(self.state, RunningState::Running | RunningState::Paused)
            && !self.has(flag::EXCEPTION_ACTIVE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pending_behaviour_round_trips_without_touching_the_flags() {
        let mut b = ControlBlock::EMPTY;
        b.flags = flag::BOUND | flag::FRESH | request::PAUSE;
        for p in pending::BEHAVIOURS.iter().copied().map(Some).chain([None]) {
            b.set_pending(p);
            assert_eq!(b.pending(), p);
            assert_eq!(
                b.flags & !pending::MASK,
                flag::BOUND | flag::FRESH | request::PAUSE
            );
        }
        assert_eq!(b.take_requests(), request::PAUSE);
        assert_eq!(b.flags, flag::BOUND | flag::FRESH);
    }

    #[test]
    fn wrapping_times_compare_across_the_wrap() {
        assert!(reached32(5, 5));
        assert!(reached32(3, u32::MAX - 2));
        assert!(!reached32(u32::MAX - 2, 3));
        assert_eq!(after(u64::from(u32::MAX), 2), 1);
    }
}
