//! Per-sequence configuration given at registration.

use crate::{Behaviour, Duration, SeqId};

/// Default polling period: 1 ms, one tick of a 1 kHz heartbeat.
pub(crate) const DEFAULT_POLLING_MICROS: u32 = 1_000;

/// Configuration of a sequence or step: name, polling period, timeout monitor, cleanup hook.
///
/// ```
/// use rtseq::{Behaviour, Duration, SeqConfig, Sequencer};
/// struct Motor;
/// fn stop(_m: &Motor) {}
/// let seq: Sequencer<Motor, 4> = Sequencer::new();
/// let safe_stop = seq.register(SeqConfig::new("safe stop")).unwrap();
/// let homing = seq
///     .register(
///         SeqConfig::new("homing")
///             .polling(Duration::from_millis(10))
///             .timeout(Duration::from_secs(5))
///             .timeout_exception(safe_stop)
///             .timeout_behaviour(Behaviour::AbortOwner)
///             .on_abort(stop),
///     )
///     .unwrap();
/// assert_eq!(seq.sequence_by_name("homing").unwrap().id(), homing);
/// ```
pub struct SeqConfig<C> {
    pub(crate) name: &'static str,
    pub(crate) polling: Duration,
    pub(crate) timeout: Option<Duration>,
    pub(crate) timeout_exception: Option<SeqId>,
    pub(crate) timeout_behaviour: Behaviour,
    pub(crate) timeout_restart_limit: u8,
    pub(crate) on_abort: Option<fn(&C)>,
}

impl<C> SeqConfig<C> {
    /// A sequence polled every 1 ms, without timeout.
    // Out of line: applications build many configurations; one copy of the literal.
    #[inline(never)]
    pub const fn new(name: &'static str) -> Self {
        SeqConfig {
            name,
            polling: Duration::from_ticks(DEFAULT_POLLING_MICROS as u64),
            timeout: None,
            timeout_exception: None,
            timeout_behaviour: Behaviour::AbortOwner,
            timeout_restart_limit: crate::monitor::DEFAULT_RESTART_LIMIT,
            on_abort: None,
        }
    }

    /// The seed's `pollingTime`: how often monitors, timeout and exit condition are checked.
    pub const fn polling(mut self, period: Duration) -> Self {
        self.polling = period;
        self
    }

    /// Arms the timeout monitor: measured from the start, reset on restart, paused time
    /// excluded.
    pub const fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = Some(timeout);
        self
    }

    /// Exception sequence of the timeout monitor.
    pub const fn timeout_exception(mut self, sequence: SeqId) -> Self {
        self.timeout_exception = Some(sequence);
        self
    }

    /// Behaviour of the timeout monitor (default [`Behaviour::AbortOwner`]).
    pub const fn timeout_behaviour(mut self, behaviour: Behaviour) -> Self {
        self.timeout_behaviour = behaviour;
        self
    }

    /// Restart limit of the timeout monitor.
    pub const fn timeout_restart_limit(mut self, limit: u8) -> Self {
        self.timeout_restart_limit = limit;
        self
    }

    /// A bounded cleanup run while the sequence is `Aborting` (or restarting), e.g. stop the
    /// motor. It runs in the tick: keep it short.
    pub const fn on_abort(mut self, hook: fn(&C)) -> Self {
        self.on_abort = Some(hook);
        self
    }
}
