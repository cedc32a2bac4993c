//! The transition trace: one record per state change.

use crate::{Cause, Instant, RunningState, SeqId};

#[cfg(test)]
extern crate std;

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

/// A transition without its time: what [`shift`](crate::sequencer::Inner) is asked to
/// make, and what a ring slot keeps beside the time.
#[derive(Clone, Copy)]
pub(crate) struct Edge {
    pub(crate) sequence: SeqId,
    pub(crate) from: RunningState,
    pub(crate) to: RunningState,
    pub(crate) cause: Cause,
}

impl Transition {
    /// The transition of `sequence` from `from` to `to` for `cause`, its time still open.
    pub(crate) const fn edge(
        sequence: SeqId,
        from: RunningState,
        to: RunningState,
        cause: Cause,
    ) -> Edge {
        Edge {
            sequence,
            from,
            to,
            cause,
        }
    }
}

/// One ring slot.
#[derive(Clone, Copy)]
struct Rec {
    time: u64,
    edge: Edge,
}

/// The sequencer's trace buffer: a ring of the newest `T` records, oldest first.
///
/// A push is O(1) and short (it runs inside the transition's critical section): one index
/// computation and one record store; when full it overwrites the oldest record, which the
/// sequencer counts as lost. With a power-of-two `T` (the default 64) the index is a mask.
pub(crate) struct Ring<const T: usize> {
    buf: [Rec; T],
    /// Index of the oldest record.
    head: usize,
    /// Number of records held (≤ `T`).
    len: usize,
}

impl<const T: usize> Ring<T> {
    /// A record for the never-read slots of an empty ring.
    const BLANK: Rec = Rec {
        time: 0,
        edge: Transition::edge(
            SeqId(0),
            RunningState::Idle,
            RunningState::Idle,
            Cause::Start,
        ),
    };

    pub(crate) const fn new() -> Self {
        Ring {
            buf: [Self::BLANK; T],
            head: 0,
            len: 0,
        }
    }

    /// `head + k` wrapped into `0..T` (`head < T`, `k ≤ T`).
    #[inline]
    fn at(&self, k: usize) -> usize {
        let i = self.head.wrapping_add(k);
        if T.is_power_of_two() {
            i & T.wrapping_sub(1)
        } else if i >= T {
            i.wrapping_sub(T)
        } else {
            i
        }
    }

    /// Appends `edge` at `time`; when full the oldest record is dropped. Returns true when
    /// one was.
    #[inline]
    pub(crate) fn push(&mut self, time: u64, edge: &Edge) -> bool {
        let i = self.at(self.len);
        if let Some(slot) = self.buf.get_mut(i) {
            *slot = Rec { time, edge: *edge };
        }
        if self.len < T {
            self.len = self.len.wrapping_add(1);
            false
        } else {
            // Keep the newest records: the oldest are the least useful to a live observer.
            self.head = self.at(1);
            true
        }
    }

    /// Removes and returns the oldest record.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<Transition> {
        if self.len == 0 {
            return None;
        }
        let r = self.buf.get(self.head).copied();
        self.head = self.at(1);
        self.len = self.len.wrapping_sub(1);
        r.map(|Rec { time, edge: e }| Transition {
            time: Instant::from_ticks(time),
            sequence: e.sequence,
            from: e.from,
            to: e.to,
            cause: e.cause,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn push<const T: usize>(r: &mut Ring<T>, n: u64) -> bool {
        r.push(n, &Ring::<1>::BLANK.edge)
    }

    fn drain<const T: usize>(r: &mut Ring<T>) -> std::vec::Vec<u64> {
        core::iter::from_fn(|| r.pop().map(|t| t.time.as_ticks())).collect()
    }

    /// Against a model (a `VecDeque` that drops its front when full), for several
    /// capacities, power of two or not, with pushes and pops interleaved.
    #[test]
    fn keeps_the_newest_records_oldest_first() {
        fn check<const T: usize>() {
            let mut r = Ring::<T>::new();
            let mut model = std::collections::VecDeque::new();
            for n in 0..10 * T as u64 + 7 {
                if n % 7 == 3 {
                    assert_eq!(r.pop().map(|t| t.time.as_ticks()), model.pop_front());
                } else {
                    let full = model.len() == T;
                    if full {
                        model.pop_front();
                    }
                    model.push_back(n);
                    assert_eq!(push(&mut r, n), full, "T = {T}, push {n}");
                }
            }
            assert_eq!(drain(&mut r), std::vec::Vec::from(model));
        }
        check::<1>();
        check::<3>();
        check::<4>();
        check::<6>();
        check::<64>();
    }

    #[test]
    fn empty_and_zero_capacity() {
        let mut r = Ring::<0>::new();
        assert!(push(&mut r, 1));
        assert_eq!(r.pop(), None);
        let mut r = Ring::<4>::new();
        assert_eq!(r.pop(), None);
        push(&mut r, 7);
        assert_eq!(drain(&mut r), [7]);
    }
}
