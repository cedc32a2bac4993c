//! Reading the trace out of a sequencer: the records, oldest first, and how many were
//! lost to overflow.

use crate::lock::Lock;
use crate::trace::{Record, Transition};
use crate::Sequencer;

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Passes the buffered records (transitions and [`Event`](crate::Event)s), oldest
    /// first, to `f` and empties the buffer; at most `T` records per call (the buffer's
    /// capacity: all it held), so that a drain returns even while `f` makes records itself
    /// (a request for each record it reads): those wait for the next call. Returns how many
    /// were lost to overflow since the last call: exact while fewer than 2³² records are
    /// written between two calls (at 1 000 records a second, about 50 days). The buffer counts its records in 32 bits and never tests
    /// for a full ring inside a transition's section, so drain at least that often.
    ///
    /// ```
    /// use rtseq::{Event, Request, Requester, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("a")).unwrap();
    /// let h = seq.sequence_by_id(id).unwrap();
    /// h.declare_lane().unwrap();
    /// h.start().unwrap();
    /// h.pause().unwrap();
    /// let mut records = Vec::new();
    /// assert_eq!(seq.drain_records(|r| records.push(r)), 0);
    /// assert!(records[0].transition().is_some()); // the start
    /// assert!(matches!(records[1].event(), Some(Event::Requested {
    ///     request: Request::Pause, by: Requester::Application, .. })));
    /// ```
    pub fn drain_records(&self, mut f: impl FnMut(Record)) -> u32 {
        for _ in 0..T {
            match self.with(|s| s.trace.pop_or_lost()) {
                Ok(record) => f(record),
                Err(lost) => return lost,
            }
        }
        self.with(|s| s.trace.take_lost())
    }

    /// As [`drain_records`](Self::drain_records), passing on the transitions only (the
    /// events are dropped).
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.register(SeqConfig::new("a")).unwrap();
    /// let mut n = 0;
    /// assert_eq!(seq.drain_trace(|_| n += 1), 0);
    /// assert_eq!(n, 0); // nothing ran yet
    /// ```
    pub fn drain_trace(&self, mut f: impl FnMut(Transition)) -> u32 {
        self.drain_records(|r| {
            if let Some(t) = r.transition() {
                f(t)
            }
        })
    }
}
