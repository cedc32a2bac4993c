//! Sets of sequences, one bit per sequence id in one word.
//!
//! The tick works on whole sets (active, paused, due, waiting for a poll, ...): a few word
//! operations per tick instead of a visit to every control block. One `u32` per set is why
//! a sequencer holds at most [`MAX_SEQUENCES`] sequences and steps.

use crate::SeqId;

/// The most sequences and steps one [`Sequencer`](crate::Sequencer) holds (its `N`).
///
/// A [`Table`](crate::Table) longer than that is refused:
///
/// ```
/// use rtseq::{Error, SeqConfig, Table, MAX_SEQUENCES};
/// assert_eq!(MAX_SEQUENCES, 32);
/// let too_many = Table::<(), 33>::new(core::array::from_fn(|_| SeqConfig::new("s")));
/// assert!(matches!(too_many, Err(Error::SequenceCapacityExceeded)));
/// ```
pub const MAX_SEQUENCES: usize = 32;

/// A set of sequence ids.
#[derive(Clone, Copy, PartialEq, Eq, Default, Debug)]
pub(crate) struct SeqSet(pub(crate) u32);

impl SeqSet {
    pub(crate) const EMPTY: SeqSet = SeqSet(0);

    /// The set of `id` alone (empty for an id no sequencer hands out).
    #[inline]
    pub(crate) fn of(id: SeqId) -> SeqSet {
        SeqSet(1u32.wrapping_shl(u32::from(id.0)))
    }

    #[inline]
    pub(crate) fn has(self, id: SeqId) -> bool {
        self.0 & SeqSet::of(id).0 != 0
    }

    /// This set with `id` in (for `const` set-up).
    pub(crate) const fn with(self, id: SeqId) -> SeqSet {
        SeqSet(self.0 | 1u32.wrapping_shl(id.0 as u32))
    }

    /// Puts `id` in.
    #[inline]
    pub(crate) fn insert(&mut self, id: SeqId) {
        *self = self.with(id);
    }

    /// Puts `id` in (`on`) or takes it out.
    #[inline]
    pub(crate) fn set(&mut self, id: SeqId, on: bool) {
        if on {
            self.0 |= SeqSet::of(id).0;
        } else {
            self.0 &= !SeqSet::of(id).0;
        }
    }

    #[inline]
    pub(crate) fn is_empty(self) -> bool {
        self.0 == 0
    }

    #[inline]
    pub(crate) fn and(self, other: SeqSet) -> SeqSet {
        SeqSet(self.0 & other.0)
    }

    #[inline]
    pub(crate) fn or(self, other: SeqSet) -> SeqSet {
        SeqSet(self.0 | other.0)
    }

    #[inline]
    pub(crate) fn minus(self, other: SeqSet) -> SeqSet {
        SeqSet(self.0 & !other.0)
    }

    /// Takes the lowest id out of the set.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<SeqId> {
        if self.0 == 0 {
            return None;
        }
        // At most 31: fits a byte.
        let id = SeqId(self.0.trailing_zeros() as u8);
        self.0 &= self.0.wrapping_sub(1);
        Some(id)
    }
}

impl Iterator for SeqSet {
    type Item = SeqId;

    /// The ids in the set, lowest first.
    #[inline]
    fn next(&mut self) -> Option<SeqId> {
        self.pop()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_iterate_lowest_first() {
        let mut s = SeqSet::EMPTY;
        for i in [31u8, 0, 5] {
            s.set(SeqId(i), true);
        }
        assert!(s.has(SeqId(5)) && !s.has(SeqId(4)));
        s.set(SeqId(5), false);
        assert_eq!(s.minus(SeqSet::of(SeqId(0))), SeqSet::of(SeqId(31)));
        s.set(SeqId(5), true);
        assert!(s.eq([SeqId(0), SeqId(5), SeqId(31)]));
    }
}
