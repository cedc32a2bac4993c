//! Handles: inspect and command a registered sequence from anywhere.

use crate::sequencer::port::Port;
use crate::sequencer::requests::Request;
#[cfg(feature = "counters")]
use crate::Counters;
use crate::{Cause, Duration, Error, Outcome, RunningState, SeqId, Sequencer, MAX_DEPTH};

/// A callers list (`callerStack` or `callerStackBlocking`), outermost first.
pub type CallerStack = heapless::Vec<SeqId, MAX_DEPTH>;

/// A handle to one registered sequence: state, callers, exceptions, counters; start, pause,
/// resume, abort.
///
/// Commands that stop or hold a sequence (pause, resume, abort) are requests applied by the
/// next tick, so every such transition happens in one place at a well-defined time.
///
/// ```
/// use rtseq::{RunningState, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("homing")).unwrap();
/// let h = seq.sequence_by_id(id).unwrap();
/// assert_eq!(h.name(), "homing");
/// assert_eq!(h.state(), RunningState::Idle);
/// assert!(h.caller().is_none());
/// assert!(h.pause().is_err()); // not running
/// ```
#[derive(Clone, Copy)]
pub struct Handle<'a, C> {
    port: &'a dyn Port<C>,
    id: SeqId,
}

impl<'a, C> Handle<'a, C> {
    pub(crate) fn new<const N: usize, const T: usize, L: crate::lock::Lock, const W: usize>(
        seq: &'a Sequencer<C, N, T, L, W>,
        id: SeqId,
    ) -> Self {
        Handle { port: seq, id }
    }

    pub(crate) fn from_port(port: &'a dyn Port<C>, id: SeqId) -> Self {
        Handle { port, id }
    }

    /// The sequence's id.
    pub fn id(&self) -> SeqId {
        self.id
    }

    /// The registered name.
    pub fn name(&self) -> &'static str {
        self.port.info(self.id).map_or("", |i| i.name)
    }

    /// The current running state.
    pub fn state(&self) -> RunningState {
        self.port
            .info(self.id)
            .map_or(RunningState::Idle, |i| i.state)
    }

    /// `callerSequence`: who started the current (or last) run; `None` for a main sequence.
    pub fn caller(&self) -> Option<SeqId> {
        self.port.info(self.id).and_then(|i| i.caller)
    }

    /// `callerStack`: all callers up to the main sequence, outermost first, not itself.
    pub fn caller_stack(&self) -> CallerStack {
        self.callers().0
    }

    /// `callerStackBlocking`: the callers this sequence blocks (up to the first
    /// non-blocking start), outermost first.
    pub fn caller_stack_blocking(&self) -> CallerStack {
        let (stack, blocking) = self.callers();
        let skip = stack.len().saturating_sub(usize::from(blocking));
        stack.iter().skip(skip).copied().collect()
    }

    /// The caller stack, outermost first, and how many of its innermost callers this
    /// sequence blocks (those in its lane). One short section per caller: a stack the tick
    /// relinks meanwhile may mix old and new links.
    fn callers(&self) -> (CallerStack, u8) {
        let mut stack = CallerStack::new();
        let Some(me) = self.port.info(self.id) else {
            return (stack, 0);
        };
        // Innermost first; the blocking callers are the innermost ones in this lane.
        let (mut up, mut blocking, mut blocked) = (me.caller, true, 0u8);
        for _ in 0..MAX_DEPTH {
            let Some(c) = up else { break };
            // At most MAX_DEPTH pushes: every one fits.
            let _ = stack.push(c);
            let (next, lane) = self
                .port
                .info(c)
                .map_or((None, None), |i| (i.caller, Some(i.lane)));
            blocking &= lane == Some(me.lane);
            if blocking {
                blocked = blocked.saturating_add(1);
            }
            up = next;
        }
        stack.reverse();
        (stack, blocked)
    }

    /// `exceptionIsActive`: a monitor of this sequence fired and is being handled, or this
    /// sequence was aborted because of it.
    pub fn exception_is_active(&self) -> bool {
        self.port.info(self.id).is_some_and(|i| i.exception_active)
    }

    /// `activeException`: the monitor or timeout of the active (or last) exception.
    pub fn active_exception(&self) -> Option<Cause> {
        self.port.info(self.id).and_then(|i| i.active_exception)
    }

    /// Runs, completions, skips, aborts, restarts, exceptions (feature `counters`).
    #[cfg_attr(docsrs, doc(cfg(feature = "counters")))]
    #[cfg(feature = "counters")]
    pub fn counters(&self) -> Counters {
        self.port
            .info(self.id)
            .map(|i| i.counters)
            .unwrap_or_default()
    }

    /// The outcome of the last finished run.
    pub fn last_outcome(&self) -> Option<Outcome> {
        self.port.info(self.id).and_then(|i| i.outcome)
    }

    /// Starts the sequence non-blocking in its lane, as a main sequence (no caller).
    pub fn start(&self) -> Result<(), Error> {
        self.port.start_in_lane(self.id, None)
    }

    /// Requests a pause of the sequence and the sequences it blocks (next tick).
    pub fn pause(&self) -> Result<(), Error> {
        self.port.request(self.id, Request::Pause)
    }

    /// Requests that a paused sequence resume where it stopped (next tick).
    pub fn resume(&self) -> Result<(), Error> {
        self.port.request(self.id, Request::Resume)
    }

    /// Requests an abort of the sequence and all its sub-sequences (next tick).
    pub fn abort(&self) -> Result<(), Error> {
        self.port.request(self.id, Request::Abort)
    }

    /// Sets (or with `None` switches off) the timeout monitor; it applies from the next
    /// start or restart, like EEROS's `setTimeoutTime`.
    ///
    /// ```
    /// use rtseq::{Duration, Error, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let h = seq.sequence_by_id(seq.register(SeqConfig::new("move")).unwrap()).unwrap();
    /// assert_eq!(h.set_timeout(Some(Duration::from_secs(2))), Ok(()));
    /// assert_eq!(h.set_timeout(Some(Duration::from_ticks(0))), Err(Error::DurationOutOfRange));
    /// ```
    pub fn set_timeout(&self, timeout: Option<Duration>) -> Result<(), Error> {
        let micros = match timeout {
            Some(t) => crate::model::time::to_interval(t).ok_or(Error::DurationOutOfRange)?,
            None => 0,
        };
        self.port.set_timeout(self.id, micros)
    }

    /// Declares that a lane runs this sequence, so it can be started non-blocking before the
    /// lane first ran (e.g. from RTIC `init`). [`lane`](crate::lane) declares it too.
    pub fn declare_lane(&self) -> Result<(), Error> {
        self.port.declare_lane(self.id).map(|_| ())
    }
}
