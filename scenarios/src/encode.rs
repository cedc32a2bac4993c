//! A [`Transition`] or an [`Event`] as six integers: the firmware prints these, the host
//! decodes them or encodes its own records the same way.

use rtseq::{
    Cause, Done, Entry, Error, Event, Failure, Instant, MonitorId, Record, Request, Requester,
    RunningState, SeqId, Transition,
};

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
        Err(Failure::NotStarted(e)) => 0x8000_0000 | error_code(e),
    }
}

/// The position of `e`'s variant in [`Error`].
fn error_code(e: Error) -> u32 {
    match e {
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
        Error::HeldByMonitor(_) => 21,
        Error::OutcomeLost(_) => 22,
        Error::PauseOwnerMonitorsExceeded(_) => 23,
        Error::TickInProgress => 24,
        Error::ForeignMonitorTable => 25,
        Error::AlreadyPaused(_) => 26,
        Error::OutsideAction(_) => 27,
    }
}

/// What a record of the trace is: `T` a transition ([`encode`]), `E` an event
/// ([`encode_event`]).
pub type Kind = char;

/// An [`Event`] at `time` as six integers: `[time µs, kind, a, b, c, d]`, kinds:
/// 1 `Fired` (owner, cause kind, cause arg, behaviour), 2 `ExceptionNotRun` (exception,
/// owner, error variant, 0), 3 `Requested` (sequence, 0 pause / 1 resume / 2 abort,
/// requester kind, requester arg), 4 `AbortAll` (requester kind, requester arg, 0, 0),
/// 5 `Failed` (sequence, [`outcome_code`] of the failure, 0, 0), 6 `SafetyLevel` (level,
/// 0, 0, 0), 7 `InputTripped` (input, 0, 0, 0). Requester kinds:
/// 0 a sequence (arg: its index), 1 the application, 2 the safety system.
///
/// ```
/// use rtseq::{Event, Failure, Instant, SeqId};
/// let e = Event::Failed { sequence: SeqId::from_index(2), failure: Failure::App(7) };
/// let got = rtseq_scenarios::encode_event(Instant::from_ticks(3_000), &e);
/// assert_eq!(got, [3_000, 5, 2, 0x4000_0007, 0, 0]);
/// ```
pub fn encode_event(time: Instant, e: &Event) -> Encoded {
    let requester = |r: Requester| match r {
        Requester::Sequence(id) => (0, index(id.index())),
        Requester::Application => (1, 0),
        Requester::SafetySystem => (2, 0),
    };
    let body = match *e {
        Event::Fired {
            owner,
            cause,
            behaviour,
        } => {
            let (kind, arg) = cause_code(cause);
            [1, index(owner.index()), kind, arg, behaviour as u32]
        }
        Event::ExceptionNotRun {
            exception,
            owner,
            why,
        } => [
            2,
            index(exception.index()),
            index(owner.index()),
            error_code(why),
            0,
        ],
        Event::Requested {
            sequence,
            request,
            by,
        } => {
            let (kind, arg) = requester(by);
            let request = match request {
                Request::Pause => 0,
                Request::Resume => 1,
                Request::Abort => 2,
            };
            [3, index(sequence.index()), request, kind, arg]
        }
        Event::AbortAll { by } => {
            let (kind, arg) = requester(by);
            [4, kind, arg, 0, 0]
        }
        Event::Failed { sequence, failure } => {
            [5, index(sequence.index()), outcome_code(Err(failure)), 0, 0]
        }
        Event::SafetyLevel { level } => [6, u32::from(level.id()), 0, 0, 0],
        Event::InputTripped { input } => [7, index(input.index()), 0, 0, 0],
    };
    let [kind, a, b, c, d] = body;
    [
        u32::try_from(time.as_ticks()).unwrap_or(u32::MAX),
        kind,
        a,
        b,
        c,
        d,
    ]
}

/// A record of the trace as its kind and six integers.
pub fn encode_record(r: &Record) -> (Kind, Encoded) {
    match r.entry {
        Entry::Transition {
            sequence,
            from,
            to,
            cause,
        } => (
            'T',
            encode(&Transition {
                time: r.time,
                sequence,
                from,
                to,
                cause,
            }),
        ),
        Entry::Event(e) => ('E', encode_event(r.time, &e)),
    }
}
