//! The framework-owned control block of one registered sequence (the seed's `BaseSequence`
//! fields), plus its optional counters.

use crate::model::id::Link;
use crate::model::state::RunningStates;
#[cfg(doc)]
use crate::MAX_DEPTH;
use crate::{Behaviour, Cause, Failure, Outcome, Request, RunningState, SeqId};

/// How often a sequence did what (feature `counters`: 14 bytes per sequence). Counters wrap
/// at `u16::MAX`.
///
/// ```
/// use rtseq::{SeqConfig, Sequencer};
/// let seq: Sequencer<(), 1> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("a")).unwrap();
/// let c = seq.sequence_by_id(id).unwrap().counters();
/// assert_eq!((c.runs, c.failed, c.aborts, c.restarts, c.exceptions), (0, 0, 0, 0, 0));
/// ```
#[cfg_attr(docsrs, doc(cfg(feature = "counters")))]
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
    /// Runs whose action failed (returned `Err`).
    pub failed: u16,
    /// Aborts.
    pub aborts: u16,
    /// Restarts.
    pub restarts: u16,
    /// Exceptions raised by this sequence's monitors and timeout (a `PauseOwner`
    /// monitor's hold marks none, and is not counted).
    pub exceptions: u16,
}

#[cfg(feature = "counters")]
impl Counters {
    pub(crate) const ZERO: Counters = Counters {
        runs: 0,
        completed: 0,
        skipped: 0,
        failed: 0,
        aborts: 0,
        restarts: 0,
        exceptions: 0,
    };

    /// Counts one transition.
    pub(crate) fn count(&mut self, from: RunningState, to: RunningState, cause: Cause) {
        let c = match to {
            RunningState::Aborted => &mut self.aborts,
            RunningState::Restarting => &mut self.restarts,
            RunningState::Terminated => match cause {
                Cause::PreConditionFalse => &mut self.skipped,
                Cause::Failed => &mut self.failed,
                _ => &mut self.completed,
            },
            RunningState::Running if from != RunningState::Paused && cause != Cause::Restart => {
                &mut self.runs
            }
            _ => return,
        };
        *c = c.wrapping_add(1);
    }
}

/// Flag bits of [`ControlBlock::flags`]. What the tick reads of every sequence (monitored,
/// paused, fresh, timeout armed, exception active, waiting for a poll) is kept as sets in
/// the sequencer instead (`sequencer::sets::Sets`).
pub(crate) mod flag {
    // Bits 7 and 8 are free; bits 10 to 15 are the requests and the pending behaviour.
    /// An exception marked this run or round: as the owner of the monitor or timeout that
    /// fired, or as the target of its behaviour (the owner's caller, for a
    /// `…CallerOfOwner`). A run stopped for that exception reads `exception_is_active`
    /// (`Port::info`); a new run and a new round begin without it.
    pub const EXCEPTION_MARKED: u16 = 1 << 0;
    /// A teardown for an exception placed this run as its target (the behaviour's): once
    /// stopped (after its cleanup hook), it names the exception and, still stopped, is
    /// marked (`EXCEPTION_MARKED`). A run its lane ends before the move is not.
    pub const EXCEPTION_TARGET: u16 = 1 << 4;
    /// A non-blocking start waits for the lane to pick it up.
    pub const START_PENDING: u16 = 1 << 1;
    /// A pause request paused it: a `PauseOwner` monitor whose condition clears does not
    /// resume it (only a resume request does).
    pub const PAUSED_BY_REQUEST: u16 = 1 << 2;
    /// A teardown placed it and has not moved it yet: it starts nothing (a start by it is
    /// refused as by a stopped caller).
    pub const STOPPING: u16 = 1 << 3;
    /// The exception sequence ended; the tick applies the pending behaviour.
    pub const EXCEPTION_DONE: u16 = 1 << 5;
    /// The run's clock is stopped (it is paused): the clock (`State::clocks`,
    /// `sequencer/clock.rs`) holds its unpaused time so far. The clock's own mark, not the
    /// state, says how to read it: a pause moves the state and the clock in two sections.
    pub const CLOCK_STOPPED: u16 = 1 << 6;
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

/// The behaviour waiting for the end of an exception sequence, in the top three bits of
/// [`ControlBlock::flags`] (0 = none).
mod pending {
    use crate::Behaviour;
    pub const SHIFT: u32 = 13;
    pub const MASK: u16 = 0b111 << SHIFT;
    /// By discriminant.
    pub const BEHAVIOURS: [Behaviour; 6] = [
        Behaviour::Nothing,
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
        Behaviour::PauseOwner,
    ];
}

/// What a joiner waits for, kept in its control block: nothing, the end of one run of a
/// sequence, or, while it waits in several joins at once, any end.
///
/// The run is named by the low 7 bits of its count: a run that ended before its future
/// unwound (aborted, then started again by another lane before its lane ran) releases
/// only its own joiners, not those of the run that began since, and the cycle check
/// follows only the waits of the run under way. At most one run begins before the last
/// one's future unwinds (its lane drives both), and a join registers a wait only for the
/// run under way (a join of an earlier run never waits: `Port::join`), so 7 bits tell
/// them apart.
///
/// Its own type rather than a [`Link`]: "any" is no sequence, and
/// nothing here can be read as one by mistake. All-zero bytes are "nothing", so an empty
/// sequencer stays all zeros.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct JoinWait(u16);

impl JoinWait {
    pub(crate) const NOTHING: JoinWait = JoinWait(0);
    /// Above every run's value (a sequence `i` is `i + 1`, at most 256, in the low 9 bits).
    pub(crate) const ANY_END: JoinWait = JoinWait(u16::MAX);

    /// The end of `target`'s run of count `runs`.
    pub(crate) const fn end_of(target: SeqId, runs: u16) -> JoinWait {
        JoinWait((target.0 as u16 + 1) | (runs & 0x7f) << 9)
    }

    /// Whether the end of `target`'s run of count `runs` releases this joiner.
    pub(crate) fn released_by(self, target: SeqId, runs: u16) -> bool {
        self == JoinWait::end_of(target, runs) || self == JoinWait::ANY_END
    }
}

/// One registered sequence's state. Its size on the target is a budget (`bench_seq` prints
/// it, the QEMU suite checks it, docs/footprint.md has the figure): a sequencer holds one
/// per sequence.
///
/// The caller stack is not stored: each block links to its caller, and the stack, its depth
/// and its blocking part are walked from the links (at most [`MAX_DEPTH`] steps). Wakers
/// live with the lanes, not here; counters only with the feature `counters`.
pub(crate) struct ControlBlock {
    /// `None` only while unregistered.
    pub(crate) name: Option<&'static str>,
    /// Timeout in µs, 0 = off.
    pub(crate) timeout: u32,
    /// [`flag`]s, [`request`]s and the pending behaviour.
    pub(crate) flags: u16,
    /// The count of starts (not restarts), wrapping: the current run's count in its
    /// `RunId`, by which futures, contexts, joins, requests and teardowns tell its runs
    /// apart.
    pub(crate) runs: u16,
    /// `activeException`: the monitor (or timeout) whose exception is active or was last.
    pub(crate) active_exception: Option<Cause>,
    /// Cause of the last abort or restart.
    pub(crate) last_cause: Cause,
    /// The outcome of the last finished run (kept while a new run is under way).
    pub(crate) outcome: Option<Outcome>,
    pub(crate) state: RunningState,
    /// `callerSequence`.
    pub(crate) caller: Link,
    /// The lane slot whose waker drives this sequence's run (its own lane, or its
    /// blocking caller's).
    pub(crate) lane: u8,
    /// The lane slot declared for this sequence (`NO_LANE`: none).
    pub(crate) own_lane: u8,
    pub(crate) timeout_behaviour: Behaviour,
    pub(crate) timeout_exception: Link,
    pub(crate) timeout_restart_limit: u8,
    /// The restarts monitors and timeouts made of its current run (a new run begins at
    /// 0): a monitor or timeout whose restart limit this has reached escalates.
    pub(crate) restarts_made: u8,
    /// What this sequence waits for in a join.
    pub(crate) joins: JoinWait,
    /// Its [polling class](crate::tick::schedule) (the class holds the period).
    pub(crate) class: u8,
    /// Its `PauseOwner` monitors whose condition holds in this run: while any does, it
    /// stays paused. A table holds at most 255 of one sequence (`Monitors::add` and
    /// `Monitors::table` refuse a 256th), so the count cannot overflow.
    pub(crate) monitor_holds: u8,
    /// While a behaviour is pending (see [`pending`](Self::pending); meaningless
    /// otherwise): the exception sequence whose end it waits for, set with it. Only that
    /// sequence's end is credited to it: the end of one that went down with an earlier run
    /// or round of this sequence is not (`State::exception_ended`). The sequence names the
    /// run: an exception sequence starts again only once its last end is reported.
    pub(crate) awaited: Link,
}

/// No lane slot.
pub(crate) const NO_LANE: u8 = u8::MAX;

impl ControlBlock {
    /// An unregistered slot: every field's bytes are zero, so a `static` sequencer needs
    /// no initial image in flash (it lands in `.bss`, not `.data`).
    /// Of an unregistered slot only `state` is read (`Idle`); [`register`] writes
    /// [`IDLE`](Self::IDLE) over it before anything else can reach it.
    ///
    /// [`register`]: crate::Sequencer::register
    pub(crate) const UNREGISTERED: ControlBlock = ControlBlock {
        name: None,
        timeout: 0,
        flags: 0,
        runs: 0,
        // All-zero bytes (never read: `IDLE` replaces it at registration).
        active_exception: Some(Cause::Start),
        last_cause: Cause::Start,
        // All-zero bytes (never read: `IDLE` replaces it at registration).
        outcome: Some(Outcome::Failed(Failure::App(0))),
        state: RunningState::Idle,
        caller: Link::NONE,
        lane: 0,
        own_lane: 0,
        timeout_behaviour: Behaviour::Nothing,
        timeout_exception: Link::NONE,
        timeout_restart_limit: 0,
        restarts_made: 0,
        joins: JoinWait::NOTHING,
        class: 0,
        monitor_holds: 0,
        awaited: Link::NONE,
    };

    /// A registered sequence that never ran, before its configuration is written.
    pub(crate) const IDLE: ControlBlock = ControlBlock {
        active_exception: None,
        outcome: None,
        lane: NO_LANE,
        own_lane: NO_LANE,
        timeout_behaviour: Behaviour::AbortOwner,
        timeout_restart_limit: crate::monitor::DEFAULT_RESTART_LIMIT,
        ..ControlBlock::UNREGISTERED
    };

    /// A run starts (or restarts) unpaused: no `PauseOwner` monitor holds it (their edge
    /// detection starts again) and no pause request's pause is in force.
    #[inline]
    pub(crate) fn lift_pauses(&mut self) {
        self.monitor_holds = 0;
        self.set(flag::PAUSED_BY_REQUEST, false);
    }

    /// The registered name ("" only for an unregistered slot, which no reader reaches).
    pub(crate) fn name(&self) -> &'static str {
        self.name.unwrap_or("")
    }

    /// A new run of it may start: no run is under way, and it is not an exception sequence
    /// whose end the tick has not reported to its owner yet (until then it is the owner's:
    /// a new run would overwrite the owner it names).
    pub(crate) fn may_start(&self) -> bool {
        RunningStates::STARTABLE.has(self.state) && !self.has(flag::HANDLES_EXCEPTION)
    }

    pub(crate) fn has(&self, f: u16) -> bool {
        self.flags & f != 0
    }

    /// A teardown has placed it and not moved it yet, or its abort is requested (by a
    /// lane of higher priority than the tick, during the tick): its stop comes first, so
    /// it takes no exception and starts no exception sequence (semantics 9).
    pub(crate) fn being_stopped(&self) -> bool {
        self.has(flag::STOPPING | request::ABORT)
    }

    pub(crate) fn set(&mut self, f: u16, on: bool) {
        if on {
            self.flags |= f;
        } else {
            self.flags &= !f;
        }
    }

    /// Drops the pending pause and resume requests (an abort's teardown leaves none). An
    /// abort request stays with the run it aborts: it holds the run until the teardown has
    /// moved it (only a run under way reads it), and the next start replaces the flags.
    pub(crate) fn drop_pause_and_resume(&mut self) {
        self.flags &= !(request::PAUSE | request::RESUME);
    }

    /// Takes the pending requests and returns the one to carry out: an abort before a
    /// pause before a resume. A pause request's pause lasts until a resume request,
    /// whatever `PauseOwner` monitors do; a resume is carried out only while no such
    /// monitor holds (it was checked when made, but a monitor may have fired since). An
    /// abort request stays (see [`drop_pause_and_resume`](Self::drop_pause_and_resume)):
    /// until its teardown has moved the run, the run holds and cannot end.
    pub(crate) fn take_request(&mut self) -> Option<Request> {
        let r = self.flags & request::ALL;
        self.drop_pause_and_resume();
        if r & request::ABORT != 0 {
            Some(Request::Abort)
        } else if r & request::PAUSE != 0 {
            self.set(flag::PAUSED_BY_REQUEST, true);
            Some(Request::Pause)
        } else if r & request::RESUME != 0 {
            self.set(flag::PAUSED_BY_REQUEST, false);
            (self.monitor_holds == 0).then_some(Request::Resume)
        } else {
            None
        }
    }

    /// The behaviour waiting for this sequence's exception sequence to end.
    pub(crate) fn pending(&self) -> Option<Behaviour> {
        let code = usize::from((self.flags & pending::MASK) >> pending::SHIFT);
        pending::BEHAVIOURS.get(code.wrapping_sub(1)).copied()
    }

    /// A round ends (a restart's commit): the behaviour it waited to apply goes, and so
    /// do the credit of an exception sequence's end given to it (`EXCEPTION_DONE`), for
    /// the next round waits for its own, and its exception's mark (`EXCEPTION_MARKED`),
    /// for the next round begins without it (a target's mark still to be made after its
    /// move, `EXCEPTION_TARGET`, names the exception that restarted it, and marks
    /// nothing).
    pub(crate) fn end_round(&mut self) {
        self.flags &= !(pending::MASK | flag::EXCEPTION_DONE | flag::EXCEPTION_MARKED);
    }

    pub(crate) fn set_pending(&mut self, b: Option<Behaviour>) {
        // Codes 1..=6 (the enum's discriminant + 1); 0 = none.
        let code = b.map_or(0, |b| b as u16 + 1);
        self.flags = (self.flags & !pending::MASK) | (code << pending::SHIFT);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wait names the sequence and 7 bits of its run's count, and is never "nothing"
    /// or "any end", whatever the run (the 128th start's tag is 0).
    #[test]
    fn a_join_wait_names_the_sequence_and_the_run() {
        let wait = JoinWait::end_of;
        assert_ne!(wait(SeqId(0), 128), JoinWait::NOTHING);
        assert_ne!(wait(SeqId(255), 127), JoinWait::ANY_END);
        assert_ne!(wait(SeqId(0), 1), wait(SeqId(1), 1));
        assert_ne!(wait(SeqId(3), 5), wait(SeqId(3), 6));
        assert_eq!(wait(SeqId(3), 5), wait(SeqId(3), 133));
        assert!(wait(SeqId(3), 5).released_by(SeqId(3), 5));
        assert!(!wait(SeqId(3), 5).released_by(SeqId(3), 6));
        assert!(JoinWait::ANY_END.released_by(SeqId(7), 9));
    }

    #[test]
    fn pending_behaviour_round_trips_without_touching_the_flags() {
        let mut b = ControlBlock::IDLE;
        b.flags = flag::STOPPING | flag::START_PENDING | request::PAUSE;
        for p in pending::BEHAVIOURS.iter().copied().map(Some).chain([None]) {
            b.set_pending(p);
            assert_eq!(b.pending(), p);
            assert_eq!(
                b.flags & !pending::MASK,
                flag::STOPPING | flag::START_PENDING | request::PAUSE
            );
        }
        assert_eq!(b.take_request(), Some(Request::Pause));
        assert_eq!(
            b.flags,
            flag::STOPPING | flag::START_PENDING | flag::PAUSED_BY_REQUEST
        );
    }

    #[test]
    fn an_abort_goes_before_a_pause_and_a_held_resume_is_dropped() {
        let mut b = ControlBlock::IDLE;
        b.flags = request::ALL;
        assert_eq!(b.take_request(), Some(Request::Abort));
        // The abort stays with the run; the pause and resume are gone.
        assert_eq!(b.flags, request::ABORT);
        b.flags = request::RESUME | request::PAUSE;
        assert_eq!(b.take_request(), Some(Request::Pause));
        assert!(b.has(flag::PAUSED_BY_REQUEST));
        // A resume lifts the request's pause, and resumes only if no monitor holds.
        b.monitor_holds = 1;
        b.flags |= request::RESUME;
        assert_eq!(b.take_request(), None);
        assert!(!b.has(flag::PAUSED_BY_REQUEST));
        b.monitor_holds = 0;
        b.flags |= request::RESUME;
        assert_eq!(b.take_request(), Some(Request::Resume));
    }

    #[test]
    fn an_unregistered_block_reads_as_idle_and_unlinked() {
        let b = ControlBlock::UNREGISTERED;
        assert_eq!(
            (b.state, b.caller.get(), b.joins),
            (RunningState::Idle, None, JoinWait::NOTHING)
        );
        assert_eq!(
            (ControlBlock::IDLE.lane, ControlBlock::IDLE.outcome),
            (NO_LANE, None)
        );
    }
}
