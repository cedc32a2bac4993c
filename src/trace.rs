//! The transition trace: one record per state change.

use crate::{Cause, Instant, RunningState, SeqId};

/// One state change of one sequence: `(time, sequence, from, to, cause)`.
///
/// The sequencer keeps the most recent records in a bounded buffer; drain it with
/// [`Sequencer::drain_trace`](crate::Sequencer::drain_trace). The host
/// `Sim` (feature `std`) collects them all.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transition {
    /// Sequencer time of the change (the last tick's time).
    pub time: Instant,
    /// The sequence that changed state.
    pub sequence: crate::SeqId,
    /// State before.
    pub from: RunningState,
    /// State after.
    pub to: RunningState,
    /// Why.
    pub cause: Cause,
}

impl Transition {
    /// A compact constructor, convenient for expected traces in tests.
    ///
    /// ```
    /// use rtseq::{Cause, RunningState::*, SeqId, Transition};
    /// # fn id(s: &rtseq::Sequencer<(), 2>) -> SeqId { s.register(rtseq::SeqConfig::new("a")).unwrap() }
    /// # let s = rtseq::Sequencer::new(); let a = id(&s);
    /// let t = Transition::at_millis(5, a, Idle, Running, Cause::Start);
    /// assert_eq!(t.time.as_ticks(), 5_000);
    /// ```
    pub const fn at_millis(
        ms: u64,
        sequence: SeqId,
        from: RunningState,
        to: RunningState,
        cause: Cause,
    ) -> Self {
        Transition {
            time: Instant::from_ticks(ms.saturating_mul(1_000)),
            sequence,
            from,
            to,
            cause,
        }
    }
}
