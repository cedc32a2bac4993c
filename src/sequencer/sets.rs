//! The sequencer's sets of sequences: monitored, paused, fresh, waiting for a poll, ...
//!
//! The tick works on whole sets, a few word operations per tick instead of a visit to
//! every control block. It visits the words of 32 ids that hold a sequence under way one
//! at a time and, in each, reads and writes the same word of several sets. So the sets
//! are stored as a table: a [`Row`] per word of 32 ids, a column per [`Set`]. One word of
//! every set is then one reference away, whatever word the tick is in. (Stored set by
//! set, each access would need the address of its own set's word, more than the
//! registers of a Cortex-M hold.)
//!
//! The sets that are tested or walked whole (see [`Set::indexed`]) keep an index of
//! their non-empty words when there are several, so that neither visits every word.

use crate::model::set::{SeqSet, SetWord, Words};
use crate::SeqId;

/// One of the sequencer's sets of sequences.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Set {
    /// `Running` or `Paused` (`RunningStates::RUNNING_OR_PAUSED`), as of the last fold of `Changed` (the
    /// tick folds before it scans): the sequences whose monitors and timeouts are
    /// evaluated, and whose polling classes the tick scans. Narrower than
    /// [`RunningState::is_active`](crate::RunningState::is_active), which counts every run
    /// under way (`Live` here).
    Monitored,
    /// `Paused`, as `Monitored`.
    Paused,
    /// A run is under way (`RunningStates::LIVE`), as `Monitored`: the members that keep
    /// their polling class's grid (a `Restarting` one too), and, with `Changed`, the
    /// sequences a teardown or pause may have to visit (with several words; a teardown in
    /// a sequencer of at most 32 visits all of them).
    Live,
    /// The state changed since the tick last folded it into `Monitored`, `Paused`, `Live`.
    Changed,
    /// A new run or restart began: the tick resets the edge detection of these
    /// sequences' monitors before their next evaluation.
    Fresh,
    /// The timeout monitor is armed.
    Armed,
    /// `exceptionIsActive`: a monitor of the sequence fired and its handling is pending,
    /// or the sequence was aborted because of it.
    Excepting,
    /// Waiting for a polled condition (the exit condition, or `Cx::wait_until`).
    PollWait,
    /// The tick says the polled condition is due.
    PollDue,
    /// Waiting in a join (each block's `joins` says for which run).
    Joining,
    /// With a request, or whose exception sequence ended, for the next tick.
    Requested,
    /// Its caller link is set (`callerSequence`): the sequences below another one are
    /// among these, so a teardown or pause of one sequence visits only them.
    Called,
    /// A sequence object ([`Seq`](crate::Seq)) was bound to it: a property of the
    /// registration, set once and never cleared, kept apart from a run's flags, which
    /// every start writes anew.
    Bound,
}

/// The number of sets (the index has a place for each).
const SETS: usize = 13;

impl Set {
    /// Whether the set keeps an index of its non-empty words: the sets the tick tests
    /// or walks whole on every call, and those walked to find a few members.
    #[inline(always)]
    const fn indexed(self) -> bool {
        matches!(
            self,
            Set::Monitored
                | Set::Paused
                | Set::Live
                | Set::Changed
                | Set::Excepting
                | Set::Requested
                | Set::Joining
                | Set::Called
        )
    }
}

/// Word `w` of every set: bit `id % 32` of a field for the id `id` from `32 * w` to
/// `32 * w + 31`.
#[derive(Clone, Copy)]
pub(crate) struct Row {
    monitored: u32,
    paused: u32,
    live: u32,
    changed: u32,
    fresh: u32,
    armed: u32,
    excepting: u32,
    poll_wait: u32,
    poll_due: u32,
    joining: u32,
    requested: u32,
    called: u32,
    bound: u32,
}

impl Row {
    const EMPTY: Row = Row {
        monitored: 0,
        paused: 0,
        live: 0,
        changed: 0,
        fresh: 0,
        armed: 0,
        excepting: 0,
        poll_wait: 0,
        poll_due: 0,
        joining: 0,
        requested: 0,
        called: 0,
        bound: 0,
    };

    #[inline(always)]
    fn get(&self, set: Set) -> u32 {
        match set {
            Set::Monitored => self.monitored,
            Set::Paused => self.paused,
            Set::Live => self.live,
            Set::Changed => self.changed,
            Set::Fresh => self.fresh,
            Set::Armed => self.armed,
            Set::Excepting => self.excepting,
            Set::PollWait => self.poll_wait,
            Set::PollDue => self.poll_due,
            Set::Joining => self.joining,
            Set::Requested => self.requested,
            Set::Called => self.called,
            Set::Bound => self.bound,
        }
    }

    #[inline(always)]
    fn get_mut(&mut self, set: Set) -> &mut u32 {
        match set {
            Set::Monitored => &mut self.monitored,
            Set::Paused => &mut self.paused,
            Set::Live => &mut self.live,
            Set::Changed => &mut self.changed,
            Set::Fresh => &mut self.fresh,
            Set::Armed => &mut self.armed,
            Set::Excepting => &mut self.excepting,
            Set::PollWait => &mut self.poll_wait,
            Set::PollDue => &mut self.poll_due,
            Set::Joining => &mut self.joining,
            Set::Requested => &mut self.requested,
            Set::Called => &mut self.called,
            Set::Bound => &mut self.bound,
        }
    }
}

/// Every set of a sequencer with `B`-word sets (`N <= 32 * B`).
#[derive(Clone, Copy)]
pub(crate) struct Sets<const B: usize> {
    rows: [Row; B],
    /// The non-empty words of each indexed set, bit `w` for word `w` (`B > 1` only: a
    /// one-word set is its own index).
    index: [Words; SETS],
}

/// The word of `id` and its bit there.
#[inline(always)]
fn place(id: SeqId) -> (usize, u32) {
    ((id.0 >> 5) as usize, 1u32 << (id.0 & 31))
}

impl<const B: usize> Sets<B> {
    pub(crate) const EMPTY: Self = {
        assert!(
            B >= 1 && B <= crate::model::set::WORDS_MAX,
            "a set has 1 to 8 words (32 to 256 sequences)"
        );
        Sets {
            rows: [Row::EMPTY; B],
            index: [Words::EMPTY; SETS],
        }
    };

    /// Row `w`. A sequencer of one-word sets hands out only ids below 32, so its one row
    /// is every row: the index needs no check.
    #[inline(always)]
    fn row(&self, w: usize) -> Option<&Row> {
        if B == 1 {
            self.rows.first()
        } else {
            self.rows.get(w)
        }
    }

    #[inline(always)]
    fn row_mut(&mut self, w: usize) -> Option<&mut Row> {
        if B == 1 {
            self.rows.first_mut()
        } else {
            self.rows.get_mut(w)
        }
    }

    /// Notes whether word `w` of `set` holds an id, for an indexed set.
    #[inline(always)]
    fn reindex(&mut self, set: Set, w: usize, bits: u32) {
        if B > 1 && set.indexed() {
            if let Some(words) = self.index.get_mut(set as usize) {
                *words = if bits != 0 {
                    words.with(Words::single(w))
                } else {
                    words.without(Words::single(w))
                };
            }
        }
    }

    /// Whether `id` is in `set`.
    #[inline]
    pub(crate) fn has(&self, set: Set, id: SeqId) -> bool {
        let (w, bit) = place(id);
        self.row(w).is_some_and(|row| row.get(set) & bit != 0)
    }

    /// Puts `id` in `set`.
    #[inline]
    pub(crate) fn insert(&mut self, set: Set, id: SeqId) {
        self.insert_all(set, SetWord::of(id));
    }

    /// Takes `id` out of `set`.
    #[inline]
    pub(crate) fn remove(&mut self, set: Set, id: SeqId) {
        self.remove_all(set, SetWord::of(id));
    }

    /// Puts `id` in `set` (`on`) or takes it out.
    #[inline]
    pub(crate) fn put(&mut self, set: Set, id: SeqId, on: bool) {
        if on {
            self.insert(set, id);
        } else {
            self.remove(set, id);
        }
    }

    /// Word `w` of `set`: empty beyond the sets' words, except with one word, where every
    /// `w` reads word 0 (see [`row`](Self::row)): such a sequencer has no ids of 32 and
    /// above, so no caller asks for another word.
    #[inline(always)]
    pub(crate) fn word(&self, set: Set, w: usize) -> SetWord<B> {
        let bits = self.row(w).map_or(0, |row| row.get(set));
        SetWord::new(w, bits)
    }

    /// Puts the ids of `part` in `set`.
    #[inline(always)]
    pub(crate) fn insert_all(&mut self, set: Set, part: SetWord<B>) {
        self.change(set, part.index(), |word| word | part.bits());
    }

    /// Takes the ids of `part` out of `set`.
    #[inline(always)]
    pub(crate) fn remove_all(&mut self, set: Set, part: SetWord<B>) {
        self.change(set, part.index(), |word| word & !part.bits());
    }

    /// Replaces word `w` of `set` by `f` of it, and keeps the set's index.
    #[inline(always)]
    fn change(&mut self, set: Set, w: usize, f: impl FnOnce(u32) -> u32) {
        if let Some(row) = self.row_mut(w) {
            let word = row.get_mut(set);
            *word = f(*word);
            let bits = *word;
            self.reindex(set, w, bits);
        }
    }

    /// The words of `set` that hold an id.
    #[inline(always)]
    pub(crate) fn words(&self, set: Set) -> Words {
        if B > 1 && set.indexed() {
            return self
                .index
                .get(set as usize)
                .copied()
                .unwrap_or(Words::EMPTY);
        }
        let mut words = Words::EMPTY;
        for (w, row) in self.rows.iter().enumerate() {
            if row.get(set) != 0 {
                words = words.with(Words::single(w));
            }
        }
        words
    }

    /// Whether `set` is empty.
    #[inline(always)]
    pub(crate) fn is_empty(&self, set: Set) -> bool {
        if B == 1 {
            return self.word(set, 0).is_empty();
        }
        self.words(set).is_empty()
    }

    /// Whether `set` holds no id but `id` (which it may hold or not).
    pub(crate) fn none_but(&self, set: Set, id: SeqId) -> bool {
        let own = SetWord::<B>::of(id);
        self.word(set, own.index()).minus(own).is_empty()
            && (B == 1 || self.words(set).without(Words::of(id)).is_empty())
    }

    /// The ids of `set`, as a set on its own.
    pub(crate) fn members(&self, set: Set) -> SeqSet<B> {
        let mut out = SeqSet::EMPTY;
        for w in self.words(set) {
            out.insert_all(self.word(set, w));
        }
        out
    }

    /// Empties `set` and returns what it held.
    pub(crate) fn take(&mut self, set: Set) -> SeqSet<B> {
        let out = self.members(set);
        for w in self.words(set) {
            self.remove_all(set, self.word(set, w));
        }
        out
    }

    /// Takes the lowest id out of `set`.
    #[inline]
    pub(crate) fn pop(&mut self, set: Set) -> Option<SeqId> {
        let w = self.words(set).first()?;
        let id = self.word(set, w).next()?;
        self.remove(set, id);
        Some(id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `set` of `s` holds exactly `ids`.
    fn holds<const B: usize>(s: &Sets<B>, set: Set, ids: &[u8]) -> bool {
        s.members(set)
            .into_iter()
            .eq(ids.iter().map(|&id| SeqId(id)))
    }

    #[test]
    fn each_set_holds_its_own_ids() {
        let mut s = Sets::<8>::EMPTY;
        for id in [200, 3, 40, 41] {
            s.insert(Set::Monitored, SeqId(id));
        }
        s.insert(Set::Paused, SeqId(40));
        s.put(Set::Fresh, SeqId(255), true);
        assert!(holds(&s, Set::Monitored, &[3, 40, 41, 200]));
        assert!(holds(&s, Set::Paused, &[40]));
        assert!(holds(&s, Set::Fresh, &[255]));
        assert!(s.has(Set::Monitored, SeqId(41)) && !s.has(Set::Paused, SeqId(41)));
        assert!(s.is_empty(Set::Armed) && !s.is_empty(Set::Fresh));
        s.put(Set::Fresh, SeqId(255), false);
        assert!(s.is_empty(Set::Fresh));
    }

    #[test]
    fn an_indexed_set_knows_its_words() {
        let mut s = Sets::<8>::EMPTY;
        assert!(s.is_empty(Set::Monitored) && s.words(Set::Monitored).next().is_none());
        for id in [200, 3, 40, 41] {
            s.insert(Set::Monitored, SeqId(id));
        }
        assert!(s.words(Set::Monitored).eq([0, 1, 6]));
        s.remove(Set::Monitored, SeqId(40));
        assert!(s.words(Set::Monitored).eq([0, 1, 6]));
        s.remove(Set::Monitored, SeqId(41));
        assert!(s.words(Set::Monitored).eq([0, 6]));
        assert!(s.word(Set::Monitored, 6).eq([SeqId(200)]));
        let mut t = s;
        assert!(holds(&t, Set::Monitored, &[3, 200]));
        assert!(t
            .take(Set::Monitored)
            .into_iter()
            .eq([SeqId(3), SeqId(200)]));
        assert!(t.is_empty(Set::Monitored) && t.words(Set::Monitored).next().is_none());
        assert_eq!(s.pop(Set::Monitored), Some(SeqId(3)));
        assert!(s.words(Set::Monitored).eq([6]) && !s.is_empty(Set::Monitored));
        assert_eq!(s.pop(Set::Monitored), Some(SeqId(200)));
        assert!(s.is_empty(Set::Monitored) && s.pop(Set::Monitored).is_none());
        // A set without an index finds its words too.
        s.insert(Set::Fresh, SeqId(100));
        assert!(s.words(Set::Fresh).eq([3]));
    }

    #[test]
    fn words_of_a_set_are_changed_whole() {
        let mut s = Sets::<8>::EMPTY;
        s.insert_all(Set::PollDue, SetWord::new(1, 0b101));
        assert!(s
            .members(Set::PollDue)
            .into_iter()
            .eq([SeqId(32), SeqId(34)]));
        s.remove_all(Set::PollDue, SetWord::new(1, 0b1));
        assert!(s.word(Set::PollDue, 1).eq([SeqId(34)]));
        s.insert_all(Set::Changed, SetWord::new(2, 1));
        s.remove_all(Set::Changed, SetWord::new(2, 1));
        assert!(s.is_empty(Set::Changed));
    }

    #[test]
    fn none_but_one_id_looks_at_every_word() {
        let mut s = Sets::<8>::EMPTY;
        assert!(s.none_but(Set::Called, SeqId(40)));
        s.insert(Set::Called, SeqId(40));
        assert!(s.none_but(Set::Called, SeqId(40)));
        assert!(!s.none_but(Set::Called, SeqId(41)));
        assert!(!s.none_but(Set::Called, SeqId(200)));
        s.insert(Set::Called, SeqId(200));
        assert!(!s.none_but(Set::Called, SeqId(40)));
        let mut one = Sets::<1>::EMPTY;
        one.insert(Set::Called, SeqId(3));
        assert!(one.none_but(Set::Called, SeqId(3)));
        assert!(!one.none_but(Set::Called, SeqId(4)));
    }

    #[test]
    fn one_word_sets_have_ids_below_32() {
        let mut s = Sets::<1>::EMPTY;
        assert!(s.is_empty(Set::Requested));
        s.insert(Set::Requested, SeqId(9));
        s.insert(Set::Requested, SeqId(31));
        assert!(s.words(Set::Requested).eq([0]));
        assert!(holds(&s, Set::Requested, &[9, 31]));
        assert_eq!(s.pop(Set::Requested), Some(SeqId(9)));
        assert!(s.take(Set::Requested).into_iter().eq([SeqId(31)]));
        assert!(s.is_empty(Set::Requested));
    }
}
