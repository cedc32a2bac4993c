//! Sets of sequences, one bit per sequence id, in words of 32.
//!
//! The tick works on whole sets (monitored, paused, due, waiting for a poll, ...): a few word
//! operations per tick instead of a visit to every control block.
//!
//! A set of a sequencer is `B` words (the sequencer's parameter `B`, `N <= 32 * B`). A
//! sequencer of up to 32 sequences has one-word sets: exactly a `u32`. The tick of a
//! sequencer of more words visits only the words that hold a sequence under way, one at a
//! time, and works on each as a one-word sequencer does: a word of a set is a
//! [`SetWord`], and a set of words is [`Words`]. The sequencer's own sets are stored a
//! word of every set together (`sequencer::sets`); a [`SeqSet`] is a set on its own.

use crate::SeqId;

/// The most sequences and steps one [`Sequencer`](crate::Sequencer) holds (its `N`).
///
/// A [`Table`](crate::Table) longer than that is refused:
///
/// ```
/// use rtseq::{Error, SeqConfig, Table, TableError, MAX_SEQUENCES};
/// assert_eq!(MAX_SEQUENCES, 256);
/// let too_many = Table::<(), 257>::new(core::array::from_fn(|_| SeqConfig::new("s")));
/// assert!(matches!(
///     too_many,
///     Err(TableError { entry: 256, error: Error::SequenceCapacityExceeded, .. })
/// ));
/// ```
pub const MAX_SEQUENCES: usize = 256;

/// The words of 32 sequences that the sets of a sequencer of `sequences` sequences and steps
/// need: the least `B` of a [`Sequencer`](crate::Sequencer) with `N = sequences`.
///
/// ```
/// use rtseq::{lock::CriticalSection, set_words, Sequencer};
/// assert_eq!([8, 32, 33, 256].map(set_words), [1, 1, 2, 8]);
/// // 100 sequences and steps: sets of 4 words.
/// static SEQ: Sequencer<(), 100, 64, CriticalSection, 8, { set_words(100) }> =
///     Sequencer::new();
/// ```
pub const fn set_words(sequences: usize) -> usize {
    if sequences == 0 {
        1
    } else {
        sequences.div_ceil(32)
    }
}

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

    /// The ids below `n` (those the set can hold).
    pub(crate) fn first(n: usize) -> Self {
        let mut out = Self::EMPTY;
        for (w, word) in out.words.iter_mut().enumerate() {
            let below = n.saturating_sub(w.saturating_mul(32));
            *word = if below >= 32 {
                u32::MAX
            } else {
                (1u32 << below).wrapping_sub(1)
            };
        }
        out
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

    /// Whether `id` is in.
    pub(crate) fn has(&self, id: SeqId) -> bool {
        self.word(place(id).0).has(id)
    }

    /// Whether no id is in.
    pub(crate) fn is_empty(&self) -> bool {
        self.words.iter().all(|&w| w == 0)
    }

    /// The ids of this set that are not in `other`.
    pub(crate) fn minus(&self, other: &Self) -> Self {
        let mut out = *self;
        for (o, w) in out.words.iter_mut().zip(other.words.iter()) {
            *o &= !*w;
        }
        out
    }

    /// The ids of both sets.
    #[inline]
    pub(crate) fn union(&self, other: &Self) -> Self {
        let mut out = *self;
        for (o, w) in out.words.iter_mut().zip(other.words.iter()) {
            *o |= *w;
        }
        out
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

    /// Word `w` of the set (empty beyond it).
    #[inline(always)]
    pub(crate) fn word(&self, w: usize) -> SetWord<B> {
        let bits = if B == 1 {
            self.words.first()
        } else {
            self.words.get(w)
        };
        SetWord {
            // `w < B <= 8`.
            word: w as u8,
            bits: bits.copied().unwrap_or(0),
        }
    }

    /// The word of `part`, to change.
    #[inline(always)]
    fn word_mut(&mut self, part: SetWord<B>) -> Option<&mut u32> {
        if B == 1 {
            self.words.first_mut()
        } else {
            self.words.get_mut(part.index())
        }
    }

    /// Puts the ids of `part` in.
    #[inline(always)]
    pub(crate) fn insert_all(&mut self, part: SetWord<B>) {
        if let Some(word) = self.word_mut(part) {
            *word |= part.bits;
        }
    }
}

/// Words of a set, bit `w` for word `w` (a set has at most 8).
#[derive(Clone, Copy, PartialEq, Eq, Default, Debug)]
pub(crate) struct Words(u8);

impl Words {
    pub(crate) const EMPTY: Words = Words(0);

    /// The word that holds `id`.
    #[inline(always)]
    pub(crate) const fn of(id: SeqId) -> Words {
        Words(1 << (id.0 >> 5))
    }

    /// Words `0..count` (`count <= 8`).
    #[inline(always)]
    pub(crate) const fn below(count: usize) -> Words {
        Words(((1u16 << (count & 15)) - 1) as u8)
    }

    /// Word `w` alone (`w < 8`).
    #[inline(always)]
    pub(crate) const fn single(w: usize) -> Words {
        Words(1 << (w & 7))
    }

    /// These words without `other`'s.
    #[inline(always)]
    pub(crate) const fn without(self, other: Words) -> Words {
        Words(self.0 & !other.0)
    }

    /// Whether these and `other` share a word.
    #[inline(always)]
    pub(crate) fn meets(self, other: Words) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether these are the same words as `other` (a `const` `==`).
    #[inline(always)]
    pub(crate) const fn same(self, other: Words) -> bool {
        self.0 == other.0
    }

    /// These words and `other`'s.
    #[inline(always)]
    pub(crate) const fn with(self, other: Words) -> Words {
        Words(self.0 | other.0)
    }

    #[inline(always)]
    pub(crate) fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The lowest word.
    #[inline(always)]
    pub(crate) fn first(mut self) -> Option<usize> {
        self.next()
    }
}

impl Iterator for Words {
    type Item = usize;

    /// The words, lowest first.
    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let w = self.0.trailing_zeros() as usize;
        self.0 &= self.0.wrapping_sub(1);
        Some(w)
    }
}

/// One word of a set of a sequencer with `B`-word sets: the ids from `32 * word` to
/// `32 * word + 31` of the set. The tick works on a sequencer's sets one such word at a
/// time; the operations between two `SetWord`s combine their bits and are meant for
/// words of the same index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SetWord<const B: usize> {
    word: u8,
    bits: u32,
}

impl<const B: usize> SetWord<B> {
    /// The word's index (always 0 in one-word sets).
    #[inline(always)]
    pub(crate) fn index(self) -> usize {
        if B == 1 {
            0
        } else {
            usize::from(self.word)
        }
    }

    /// No id of word `w`.
    #[inline(always)]
    pub(crate) const fn empty(w: usize) -> Self {
        // `w < B <= 8`.
        SetWord {
            word: w as u8,
            bits: 0,
        }
    }

    /// The ids `32 * w + i` for each bit `i` of `bits` (`w < B`).
    #[inline(always)]
    pub(crate) const fn new(w: usize, bits: u32) -> Self {
        // `w < B <= 8`.
        SetWord {
            word: w as u8,
            bits,
        }
    }

    /// Its bits: bit `i` for the id `32 * word + i`.
    #[inline(always)]
    pub(crate) fn bits(self) -> u32 {
        self.bits
    }

    /// The word of `id` with `id` alone.
    #[inline(always)]
    pub(crate) fn of(id: SeqId) -> Self {
        let (w, bit) = place(id);
        SetWord {
            // `w < 8`.
            word: w as u8,
            bits: bit,
        }
    }

    #[inline(always)]
    pub(crate) fn is_empty(self) -> bool {
        self.bits == 0
    }

    #[inline(always)]
    pub(crate) fn has(self, id: SeqId) -> bool {
        let (w, bit) = place(id);
        w == self.index() && self.bits & bit != 0
    }

    /// This word with `id` in, if `id` belongs to it.
    #[inline(always)]
    pub(crate) fn insert(&mut self, id: SeqId) {
        let (w, bit) = place(id);
        if w == self.index() {
            self.bits |= bit;
        }
    }

    #[inline(always)]
    pub(crate) fn and(self, other: Self) -> Self {
        SetWord {
            bits: self.bits & other.bits,
            ..self
        }
    }

    #[inline(always)]
    pub(crate) fn or(self, other: Self) -> Self {
        SetWord {
            bits: self.bits | other.bits,
            ..self
        }
    }

    #[inline(always)]
    pub(crate) fn minus(self, other: Self) -> Self {
        SetWord {
            bits: self.bits & !other.bits,
            ..self
        }
    }

    /// Whether the two words share an id.
    #[inline(always)]
    pub(crate) fn meets(self, other: Self) -> bool {
        self.bits & other.bits != 0
    }

    /// Whether every id of this word is in `other`.
    #[inline(always)]
    pub(crate) fn within(self, other: Self) -> bool {
        self.bits & !other.bits == 0
    }
}

/// The same ids (the word's index counts only in sets of several words).
impl<const B: usize> PartialEq for SetWord<B> {
    #[inline(always)]
    fn eq(&self, other: &Self) -> bool {
        self.index() == other.index() && self.bits == other.bits
    }
}

impl<const B: usize> Eq for SetWord<B> {}

impl<const B: usize> Iterator for SetWord<B> {
    type Item = SeqId;

    /// The ids, lowest first.
    #[inline(always)]
    fn next(&mut self) -> Option<SeqId> {
        if self.bits == 0 {
            return None;
        }
        // `word < 8` and the bit index `< 32`: the id fits a byte.
        let id = SeqId((self.index() as u32 * 32 + self.bits.trailing_zeros()) as u8);
        self.bits &= self.bits.wrapping_sub(1);
        Some(id)
    }
}

impl<const B: usize> Default for SeqSet<B> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const B: usize> IntoIterator for SeqSet<B> {
    type Item = SeqId;
    type IntoIter = Ids<B>;

    #[inline]
    fn into_iter(self) -> Ids<B> {
        Ids {
            words: self.words,
            at: 0,
        }
    }
}

/// The ids of a [`SeqSet`], lowest first: each word is passed once, so a walk of a
/// set of several words costs its ids, not a scan from the first word for each.
pub(crate) struct Ids<const B: usize> {
    words: [u32; B],
    /// The word the next id is looked for in (the ones before it are done).
    at: usize,
}

impl<const B: usize> Iterator for Ids<B> {
    type Item = SeqId;

    #[inline]
    fn next(&mut self) -> Option<SeqId> {
        while let Some(word) = self.words.get_mut(self.at) {
            if *word != 0 {
                // `at < 8` and the bit index `< 32`: the id fits a byte.
                let id = SeqId(((self.at as u32) << 5 | word.trailing_zeros()) as u8);
                *word &= word.wrapping_sub(1);
                return Some(id);
            }
            self.at = self.at.wrapping_add(1);
        }
        None
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
    fn membership_emptiness_and_difference_in_every_word() {
        let a: SeqSet<8> = set(&[0, 31, 32, 200, 255]);
        let b: SeqSet<8> = set(&[31, 200]);
        assert!(a.has(SeqId(255)) && a.has(SeqId(32)) && !a.has(SeqId(33)));
        assert!(!a.is_empty() && SeqSet::<8>::EMPTY.is_empty());
        assert!(a.minus(&b).into_iter().eq([0, 32, 255].map(SeqId)));
        assert!(b.minus(&a).is_empty());
        let one: SeqSet<1> = set(&[3]);
        assert!(one.has(SeqId(3)) && !one.has(SeqId(35)));
    }

    #[test]
    fn one_word_sets_iterate_lowest_first() {
        let mut s = set::<1>(&[31, 0]);
        assert!(s.into_iter().eq([SeqId(0), SeqId(31)]));
        s.insert(SeqId(5));
        assert!(s.into_iter().eq([SeqId(0), SeqId(5), SeqId(31)]));
        // A one-word set's only word.
        assert!(s.word(0).eq([SeqId(0), SeqId(5), SeqId(31)]));
    }

    #[test]
    fn multi_word_sets() {
        let a = set::<8>(&[255, 0, 40, 41, 130]);
        let b = set::<8>(&[41, 130, 200]);
        assert!(a
            .union(&b)
            .into_iter()
            .eq([0u8, 40, 41, 130, 200, 255].map(SeqId)));
        // Words beyond a smaller sequencer's are dropped.
        assert!(a
            .resized::<2>()
            .into_iter()
            .eq([SeqId(0), SeqId(40), SeqId(41)]));
        assert!(SeqSet::<2>::EMPTY
            .with(SeqId(63))
            .with(SeqId(64))
            .into_iter()
            .eq([SeqId(63)]));
        // The first ids, across words.
        assert!(SeqSet::<8>::first(34).into_iter().eq((0..34).map(SeqId)));
        assert!(SeqSet::<1>::first(0) == SeqSet::EMPTY);
        assert!(SeqSet::<2>::first(99) == SeqSet::<2>::first(64));
    }

    #[test]
    fn words_of_a_set_combine_as_one_word_sets() {
        let a = set::<8>(&[255, 0, 40, 41, 130]);
        let b = set::<8>(&[41, 130, 200]);
        let (a1, b1) = (a.word(1), b.word(1));
        assert!(a1.eq([SeqId(40), SeqId(41)]));
        assert!(a1.and(b1).eq([SeqId(41)]));
        assert!(a1.or(b1).eq([SeqId(40), SeqId(41)]));
        assert!(a1.minus(b1).eq([SeqId(40)]));
        assert!(a1.meets(b1) && b1.within(a1) && !a1.within(b1));
        assert!(a1.has(SeqId(40)) && !a1.has(SeqId(0)) && !a.word(0).has(SeqId(40)));
        assert_eq!(SetWord::<8>::of(SeqId(200)), b.word(6));
        assert!(a.word(7).eq([SeqId(255)]) && a.word(5).is_empty());
        // An id of another word is not put in.
        let mut w = SetWord::<8>::empty(1);
        w.insert(SeqId(3));
        w.insert(SeqId(33));
        assert!(w.eq([SeqId(33)]));
        let mut c = a;
        c.insert_all(b.word(6));
        assert!(c.into_iter().eq([0u8, 40, 41, 130, 200, 255].map(SeqId)));
    }
}
