//! A [`Transition`] as six integers: the firmware prints these, the host decodes them.

use rtseq::{Cause, Done, Error, Failure, Instant, MonitorId, RunningState, SeqId, Transition};

/// `[time µs, sequence, from, to, cause kind, cause arg]`.
///
/// States are their position in [`RunningState::ALL`]; cause kinds: 0 `Start`,
/// 1 `PreConditionFalse`, 2 `Completed`, 3 `Pause`, 4 `Resume`, 5 `Abort`, 6 `AbortAll`,
/// 7 `Monitor` (arg: monitor index), 8 `Timeout` (arg: sequence index), 9 `Restart`,
/// 10 `Dropped`, 11 `Failed`.
/// Times saturate at `u32::MAX` µs (71 minutes).
pub type Encoded = [u32; 6];

fn state_code(s: RunningState) -> u32 {
    RunningState::ALL
        .iter()
        .position(|&x| x == s)
        .and_then(|p| u32::try_from(p).ok())
        .unwrap_or(u32::MAX)
}

fn index(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

fn cause_code(c: Cause) -> (u32, u32) {
    match c {
        Cause::Start => (0, 0),
        Cause::PreConditionFalse => (1, 0),
        Cause::Completed => (2, 0),
        Cause::Pause => (3, 0),
        Cause::Resume => (4, 0),
        Cause::Abort => (5, 0),
        Cause::AbortAll => (6, 0),
        Cause::Monitor(m) => (7, index(m.index())),
        Cause::Timeout(s) => (8, index(s.index())),
        Cause::Restart => (9, 0),
        Cause::Dropped => (10, 0),
        Cause::Failed => (11, 0),
    }
}

fn cause_of(kind: u32, arg: u32) -> Option<Cause> {
    let arg = usize::try_from(arg).ok()?;
    Some(match kind {
        0 => Cause::Start,
        1 => Cause::PreConditionFalse,
        2 => Cause::Completed,
        3 => Cause::Pause,
        4 => Cause::Resume,
        5 => Cause::Abort,
        6 => Cause::AbortAll,
        7 => Cause::Monitor(MonitorId::from_index(arg)),
        8 => Cause::Timeout(SeqId::from_index(arg)),
        9 => Cause::Restart,
        10 => Cause::Dropped,
        11 => Cause::Failed,
        _ => return None,
    })
}

/// Encodes a transition.
///
/// ```
/// use rtseq::{Cause, RunningState::*, SeqId, Transition};
/// let t = Transition::at_millis(5, SeqId::from_index(3), Running, Aborting, Cause::Abort);
/// let e = rtseq_scenarios::encode(&t);
/// assert_eq!(e, [5_000, 3, 1, 3, 5, 0]);
/// assert_eq!(rtseq_scenarios::decode(&e), Some(t));
/// ```
pub fn encode(t: &Transition) -> Encoded {
    let (kind, arg) = cause_code(t.cause);
    [
        u32::try_from(t.time.as_ticks()).unwrap_or(u32::MAX),
        index(t.sequence.index()),
        state_code(t.from),
        state_code(t.to),
        kind,
        arg,
    ]
}

/// Decodes [`encode`]'s integers; `None` for codes that name no state or cause.
pub fn decode(e: &Encoded) -> Option<Transition> {
    let [time, seq, from, to, kind, arg] = *e;
    let state = |c: u32| {
        usize::try_from(c)
            .ok()
            .and_then(|c| RunningState::ALL.get(c).copied())
    };
    Some(Transition {
        time: Instant::from_ticks(u64::from(time)),
        sequence: SeqId::from_index(usize::try_from(seq).ok()?),
        from: state(from)?,
        to: state(to)?,
        cause: cause_of(kind, arg)?,
    })
}

/// A blocking run's result as one integer, for the action digest: 1 `Completed`,
/// 2 `Skipped`, `0x100 | kind << 8 | arg << 16` for `Aborted(cause)`,
/// `0x4000_0000 | code` for `App(code)`, `0x8000_0000 | n` for `NotStarted` with the n-th
/// [`Error`] variant.
pub fn outcome_code(r: Result<Done, Failure>) -> u32 {
    match r {
        Ok(Done::Completed) => 1,
        Ok(Done::Skipped) => 2,
        Err(Failure::Aborted(c)) => {
            let (kind, arg) = cause_code(c);
            0x100 | (kind & 0xff) << 8 | (arg & 0xffff) << 16
        }
        Err(Failure::App(code)) => 0x4000_0000 | u32::from(code),
        Err(Failure::NotStarted(e)) => {
            let n = match e {
                Error::EmptyName => 0,
                Error::DuplicateName(_) => 1,
                Error::SequenceCapacityExceeded => 2,
                Error::MonitorCapacityExceeded => 3,
                Error::UnknownSequence(_) => 4,
                Error::AlreadyRunning(_) => 5,
                Error::NotRunning(_) => 6,
                Error::NotPaused(_) => 7,
                Error::CallerDepthExceeded(_) => 8,
                Error::NoLane(_) => 9,
                Error::DurationOutOfRange => 10,
                Error::NeverStarted(_) => 11,
                Error::AlreadyBound(_) => 12,
                Error::LaneCapacityExceeded(_) => 13,
                Error::PollingClassesExceeded => 14,
                Error::NotEmpty => 15,
                Error::JoinWouldDeadlock(_) => 16,
                Error::InvalidConfig => 17,
                Error::TickBeforeLast => 18,
                Error::PauseOnTimeout => 19,
                Error::ForeignSequence(_) => 20,
            };
            0x8000_0000 | n
        }
    }
}
