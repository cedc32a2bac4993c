//! The sequencer's trace buffer: a ring of the newest records.

use crate::trace::{Entry, Record};
use crate::{Cause, Instant, RunningState, SeqId};

#[cfg(test)]
extern crate std;

/// The sequencer's trace buffer: a ring of the newest `T` records, oldest first (`T` a
/// power of two, or 0 for no trace).
///
/// Two free-running counters, of records written and read: a push (inside the
/// transition's critical section) is one record store at `written mod T` and one
/// increment, with no test for a full ring. A reader that falls more than `T` records
/// behind finds the oldest overwritten and counts them as lost; one 2³² or more behind
/// cannot tell (the counters wrap), which `Sequencer::drain_records` documents.
pub(crate) struct Ring<const T: usize> {
    buf: [Record; T],
    /// Records pushed since the start (wrapping).
    written: u32,
    /// Records popped or lost since the start (wrapping).
    read: u32,
    /// Records overwritten before they were read, not reported yet.
    lost: u32,
}

impl<const T: usize> Ring<T> {
    /// A record for the never-read slots of an empty ring.
    const BLANK: Record = Record {
        time: Instant::from_ticks(0),
        entry: Entry::Transition {
            sequence: SeqId(0),
            from: RunningState::Idle,
            to: RunningState::Idle,
            cause: Cause::Start,
        },
    };

    /// `T` as a count (at most 2^31, checked in `new`).
    const CAPACITY: u32 = T as u32;

    /// A counter's slot is its low bits.
    const MASK: u32 = Self::CAPACITY.wrapping_sub(1);

    pub(crate) const fn new() -> Self {
        const {
            assert!(
                T == 0 || (T.is_power_of_two() && T <= 1 << 31),
                "the trace capacity T is a power of two (or 0: no trace)"
            )
        };
        Ring {
            buf: [Self::BLANK; T],
            written: 0,
            read: 0,
            lost: 0,
        }
    }

    /// Appends `entry` at `time`, over the oldest record when the ring is full.
    #[inline]
    pub(crate) fn push(&mut self, time: Instant, entry: Entry) {
        // With `T` = 0 there is no slot: the record is lost.
        if let Some(slot) = self.buf.get_mut((self.written & Self::MASK) as usize) {
            *slot = Record { time, entry };
        }
        self.written = self.written.wrapping_add(1);
    }

    /// Counts the records overwritten since the last read as lost and skips them.
    fn skip_overwritten(&mut self) {
        let unread = self.written.wrapping_sub(self.read);
        if unread > Self::CAPACITY {
            self.lost = self.lost.saturating_add(unread - Self::CAPACITY);
            self.read = self.written.wrapping_sub(Self::CAPACITY);
        }
    }

    /// Counts `n` records that never made it into the ring as lost.
    pub(crate) fn count_lost(&mut self, n: u32) {
        self.lost = self.lost.saturating_add(n);
    }

    /// How many records were overwritten before they were read, since the last call.
    pub(crate) fn take_lost(&mut self) -> u32 {
        self.skip_overwritten();
        core::mem::take(&mut self.lost)
    }

    /// Removes and returns the oldest record still held.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<Record> {
        self.skip_overwritten();
        if self.read == self.written {
            return None;
        }
        let record = self.buf.get((self.read & Self::MASK) as usize).copied();
        self.read = self.read.wrapping_add(1);
        record
    }

    /// The oldest record still held or, once there is none, how many were lost since the
    /// last time (so a drain ends with the count, in the same section as its last pop).
    #[inline]
    pub(crate) fn pop_or_lost(&mut self) -> Result<Record, u32> {
        self.pop().ok_or_else(|| self.take_lost())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn time_of(r: Record) -> u64 {
        r.time.as_ticks()
    }

    fn push<const T: usize>(r: &mut Ring<T>, n: u64) {
        r.push(Instant::from_ticks(n), Ring::<1>::BLANK.entry)
    }

    fn drain<const T: usize>(r: &mut Ring<T>) -> std::vec::Vec<u64> {
        core::iter::from_fn(|| r.pop().map(time_of)).collect()
    }

    /// Against a model (a `VecDeque` that drops its front when full), for several
    /// capacities, with pushes and pops interleaved.
    #[test]
    fn keeps_the_newest_records_oldest_first() {
        fn check<const T: usize>() {
            let mut r = Ring::<T>::new();
            let mut model = std::collections::VecDeque::new();
            let mut lost = 0;
            for n in 0..10 * T as u64 + 7 {
                if n % 7 == 3 {
                    assert_eq!(r.take_lost(), lost, "T = {T}, pop {n}");
                    lost = 0;
                    assert_eq!(r.pop().map(time_of), model.pop_front());
                } else {
                    if model.len() == T {
                        model.pop_front();
                        lost += 1;
                    }
                    model.push_back(n);
                    push(&mut r, n);
                }
            }
            assert_eq!(r.take_lost(), lost);
            assert_eq!(drain(&mut r), std::vec::Vec::from(model));
            assert_eq!(r.take_lost(), 0);
        }
        check::<1>();
        check::<2>();
        check::<4>();
        check::<8>();
        check::<64>();
    }

    #[test]
    fn empty_and_zero_capacity() {
        let mut r = Ring::<0>::new();
        push(&mut r, 1);
        assert_eq!(r.pop(), None);
        assert_eq!(r.take_lost(), 1);
        let mut r = Ring::<4>::new();
        assert_eq!(r.pop(), None);
        push(&mut r, 7);
        assert_eq!(drain(&mut r), [7]);
        assert_eq!(r.take_lost(), 0);
    }
}
