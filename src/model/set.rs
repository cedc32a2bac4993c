//! Sets of sequences, one bit per sequence id, in words of 32.
//!
//! The tick works on whole sets (active, paused, due, waiting for a poll, ...): a few word
//! operations per tick instead of a visit to every control block.
//!
//! A set of a sequencer is `B` words (the sequencer's parameter `B`, `N <= 32 * B`). A
//! sequencer of up to 32 sequences has one-word sets: exactly a `u32`. An operation on a
//! set of more words visits every word (docs/design-decisions.md, "256 sequences", says
//! what is planned so that a tick visits only the words that hold running sequences).

use crate::SeqId;

/// The most sequences and steps one [`Sequencer`](crate::Sequencer) holds (its `N`).
///
/// A [`Table`](crate::Table) longer than that is refused:
///
/// ```
/// use rtseq::{Error, SeqConfig, Table, MAX_SEQUENCES};
/// assert_eq!(MAX_SEQUENCES, 256);
/// let too_many = Table::<(), 257>::new(core::array::from_fn(|_| SeqConfig::new("s")));
/// assert!(matches!(too_many, Err(Error::SequenceCapacityExceeded)));
/// ```
pub const MAX_SEQUENCES: usize = 256;

/// Words in a set with room for every id.
pub(crate) const WORDS_MAX: usize = MAX_SEQUENCES / 32;

/// A set of sequence ids below `32 * B`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct SeqSet<const B: usize> {
    /// Bit `id % 32` of word `id / 32`.
    words: [u32; B],
}

/// The word of `id` and its bit there.
#[inline(always)]
const fn place(id: SeqId) -> (usize, u32) {
    ((id.0 >> 5) as usize, 1u32 << (id.0 & 31))
}

impl<const B: usize> SeqSet<B> {
    pub(crate) const EMPTY: Self = {
        assert!(
            B >= 1 && B <= WORDS_MAX,
            "a set has 1 to 8 words (32 to 256 sequences)"
        );
        SeqSet { words: [0; B] }
    };

    /// The set of `id` alone.
    #[inline]
    pub(crate) fn of(id: SeqId) -> Self {
        let mut s = Self::EMPTY;
        s.insert(id);
        s
    }

    /// The word that holds `id`, and its bit. A one-word set is one `u32`: every id a
    /// sequencer of such sets hands out is below 32.
    #[inline(always)]
    fn slot(&mut self, id: SeqId) -> (Option<&mut u32>, u32) {
        let (w, bit) = place(id);
        if B == 1 {
            (self.words.first_mut(), bit)
        } else {
            (self.words.get_mut(w), bit)
        }
    }

    #[inline]
    pub(crate) fn has(&self, id: SeqId) -> bool {
        let (w, bit) = place(id);
        let word = if B == 1 {
            self.words.first()
        } else {
            self.words.get(w)
        };
        word.is_some_and(|word| word & bit != 0)
    }

    /// This set with `id` in (for `const` set-up; ids beyond its words are ignored).
    pub(crate) const fn with(mut self, id: SeqId) -> Self {
        let (w, bit) = place(id);
        let mut at = 0;
        let mut rest: &mut [u32] = &mut self.words;
        while let Some((word, tail)) = rest.split_first_mut() {
            if at == w {
                *word |= bit;
            }
            at += 1;
            rest = tail;
        }
        self
    }

    /// Puts `id` in.
    #[inline]
    pub(crate) fn insert(&mut self, id: SeqId) {
        if let (Some(word), bit) = self.slot(id) {
            *word |= bit;
        }
    }

    /// Takes `id` out.
    #[inline]
    pub(crate) fn remove(&mut self, id: SeqId) {
        if let (Some(word), bit) = self.slot(id) {
            *word &= !bit;
        }
    }

    /// Puts `id` in (`on`) or takes it out.
    #[inline]
    pub(crate) fn set(&mut self, id: SeqId, on: bool) {
        if on {
            self.insert(id);
        } else {
            self.remove(id);
        }
    }

    /// Calls `f` with each word's index. A one-word set makes no loop: size-optimised
    /// builds do not unroll one.
    #[inline(always)]
    fn each_word(mut f: impl FnMut(usize)) {
        if B == 1 {
            f(0);
        } else {
            for w in 0..B {
                f(w);
            }
        }
    }

    /// The bitwise OR over the words of `op` applied to the words of both sets.
    #[inline(always)]
    fn any_bits(&self, other: &Self, op: impl Fn(u32, u32) -> u32) -> u32 {
        let mut bits = 0;
        Self::each_word(|w| {
            if let (Some(a), Some(b)) = (self.words.get(w), other.words.get(w)) {
                bits |= op(*a, *b);
            }
        });
        bits
    }

    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.any_bits(self, |a, _| a) == 0
    }

    /// The set made word by word with `op`.
    #[inline(always)]
    fn combine(&self, other: &Self, op: impl Fn(u32, u32) -> u32) -> Self {
        let mut out = *self;
        Self::each_word(|w| {
            if let (Some(o), Some(b)) = (out.words.get_mut(w), other.words.get(w)) {
                *o = op(*o, *b);
            }
        });
        out
    }

    #[inline]
    pub(crate) fn and(&self, other: &Self) -> Self {
        self.combine(other, |a, b| a & b)
    }

    #[inline]
    pub(crate) fn or(&self, other: &Self) -> Self {
        self.combine(other, |a, b| a | b)
    }

    #[inline]
    pub(crate) fn minus(&self, other: &Self) -> Self {
        self.combine(other, |a, b| a & !b)
    }

    /// Whether the two sets share an id.
    #[inline]
    pub(crate) fn meets(&self, other: &Self) -> bool {
        self.any_bits(other, |a, b| a & b) != 0
    }

    /// Whether every id of this set is in `other`.
    #[inline]
    pub(crate) fn within(&self, other: &Self) -> bool {
        self.any_bits(other, |a, b| a & !b) == 0
    }

    /// Empties the set and returns what it held.
    #[inline]
    pub(crate) fn take_all(&mut self) -> Self {
        core::mem::replace(self, Self::EMPTY)
    }

    /// The same ids in a set of `M` words (ids it cannot hold are dropped).
    #[inline]
    pub(crate) fn resized<const M: usize>(&self) -> SeqSet<M> {
        let mut out = SeqSet::<M>::EMPTY;
        for (o, w) in out.words.iter_mut().zip(self.words.iter()) {
            *o = *w;
        }
        out
    }

    /// Takes the lowest id out of the set.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<SeqId> {
        if let (1, Some(word)) = (B, self.words.first_mut()) {
            if *word == 0 {
                return None;
            }
            // The bit index is below 32: the id fits a byte.
            let id = SeqId(word.trailing_zeros() as u8);
            *word &= word.wrapping_sub(1);
            return Some(id);
        }
        for (w, word) in self.words.iter_mut().enumerate() {
            if *word != 0 {
                // `w < 8` and the bit index `< 32`: the id fits a byte.
                let id = SeqId(((w as u32) << 5 | word.trailing_zeros()) as u8);
                *word &= word.wrapping_sub(1);
                return Some(id);
            }
        }
        None
    }
}

impl<const B: usize> Default for SeqSet<B> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const B: usize> Iterator for SeqSet<B> {
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

    fn set<const B: usize>(ids: &[u8]) -> SeqSet<B> {
        let mut s = SeqSet::EMPTY;
        for &i in ids {
            s.insert(SeqId(i));
        }
        s
    }

    #[test]
    fn one_word_sets_iterate_lowest_first() {
        let mut s = set::<1>(&[31, 0, 5]);
        assert!(s.has(SeqId(5)) && !s.has(SeqId(4)));
        s.remove(SeqId(5));
        assert_eq!(s.minus(&SeqSet::of(SeqId(0))), SeqSet::of(SeqId(31)));
        s.insert(SeqId(5));
        assert!(s.eq([SeqId(0), SeqId(5), SeqId(31)]));
    }

    #[test]
    fn multi_word_sets() {
        let a = set::<8>(&[255, 0, 40, 41, 130]);
        let b = set::<8>(&[41, 130, 200]);
        assert!(a.and(&b).eq([SeqId(41), SeqId(130)]));
        assert!(a.or(&b).eq([0u8, 40, 41, 130, 200, 255].map(SeqId)));
        assert!(a.minus(&b).eq([SeqId(0), SeqId(40), SeqId(255)]));
        assert!(a.meets(&b) && !a.within(&b) && a.and(&b).within(&b));
        let mut c = set::<8>(&[200]);
        c.remove(SeqId(200));
        assert!(c.is_empty() && c == SeqSet::EMPTY);
        let mut d = a;
        assert_eq!(d.take_all(), a);
        assert!(d.is_empty());
        // Words a smaller sequencer cannot hold are dropped.
        assert!(a.resized::<2>().eq([SeqId(0), SeqId(40), SeqId(41)]));
        assert!(SeqSet::<2>::EMPTY
            .with(SeqId(63))
            .with(SeqId(64))
            .eq([SeqId(63)]));
    }
}
