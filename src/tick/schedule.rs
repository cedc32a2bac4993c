//! Polling classes: the sequences that share a polling period poll together.
//!
//! Each distinct polling period registered with a sequencer is one class with one
//! schedule, like the cyclic tasks of a PLC. The tick tests one deadline per class, not
//! one per sequence, and takes the due sequences as a set. While a class has members
//! whose run is under way (running, paused, restarting) its polls keep a fixed grid of
//! its period; the monitored (running, paused) ones are polled. A start into an idle
//! class starts the grid: the first poll comes one period after that start. A start
//! into a busy class, and a restart, join its grid: the first poll comes within one
//! period.

use core::num::NonZeroU32;

use crate::model::set::{SeqSet, SetWord};
use crate::model::time::Stamp;
use crate::{Error, SeqId};

/// The most distinct polling periods one sequencer holds.
///
/// Eight periods fit; a ninth is refused, while a period already in use joins its class:
///
/// ```
/// use rtseq::{Duration, Error, SeqConfig, Sequencer, MAX_POLLING_CLASSES};
/// let seq: Sequencer<(), 10> = Sequencer::new();
/// let names = ["p1", "p2", "p3", "p4", "p5", "p6", "p7", "p8"];
/// assert_eq!(names.len(), MAX_POLLING_CLASSES);
/// for (ms, name) in (1..).zip(names) {
///     seq.register(SeqConfig::new(name).polling(Duration::from_millis(ms))).unwrap();
/// }
/// let ninth = SeqConfig::new("p9").polling(Duration::from_millis(9));
/// assert_eq!(seq.register(ninth), Err(Error::PollingClassesExceeded));
/// let again = SeqConfig::new("p1 again").polling(Duration::from_millis(1));
/// assert_eq!(seq.register(again).map(|id| id.index()), Ok(8));
/// ```
pub const MAX_POLLING_CLASSES: usize = 8;

/// One polling period and the sequences registered with it.
#[derive(Clone, Copy)]
pub(crate) struct Class<const B: usize> {
    /// The period (µs); `None` (zero bytes, so an empty sequencer is all zeros) only in
    /// an unused class.
    period: Option<NonZeroU32>,
    /// The next poll while the class has a member under way.
    next: Stamp,
    members: SeqSet<B>,
}

/// The classes of one sequencer.
// A fixed array and a length rather than a `heapless::Vec`: `join` is a `const fn`, so a
// `Table` computes the classes at compile time.
#[derive(Clone, Copy)]
pub(crate) struct Classes<const B: usize> {
    list: [Class<B>; MAX_POLLING_CLASSES],
    len: u8,
}

/// What the scans of one tick found so far. A tick scans the classes once for each word
/// of the sets it visits (one word in a sequencer of up to 32 sequences).
pub(crate) struct Scan {
    /// The classes found due in this tick, bit `i` for class `i`: a class is due once per
    /// tick, whichever words hold its members under way.
    due_classes: u8,
    /// Time from now to the next poll of a class with a member under way (µs; `u32::MAX`
    /// when there is none).
    pub(crate) ahead: u32,
}

impl Scan {
    /// Nothing found yet.
    pub(crate) const fn new() -> Self {
        Scan {
            due_classes: 0,
            ahead: u32::MAX,
        }
    }
}

impl<const B: usize> Classes<B> {
    pub(crate) const fn new() -> Self {
        let unused = Class {
            period: None,
            next: Stamp(0),
            members: SeqSet::EMPTY,
        };
        Classes {
            list: [unused; MAX_POLLING_CLASSES],
            len: 0,
        }
    }

    /// Puts `id` in the class of `period` (a new class for a new period). Returns the
    /// class's index.
    #[inline]
    pub(crate) const fn join(&mut self, id: SeqId, period: u32) -> Result<u8, Error> {
        let Some(period) = NonZeroU32::new(period) else {
            return Err(Error::DurationOutOfRange);
        };
        let Classes { list, len } = self;
        let mut rest: &mut [Class<B>] = list;
        let mut at: u8 = 0;
        while let Some((class, tail)) = rest.split_first_mut() {
            if at == *len {
                *class = Class {
                    period: Some(period),
                    next: Stamp(0),
                    members: SeqSet::EMPTY,
                };
                *len = at.saturating_add(1);
            }
            if matches!(class.period, Some(p) if p.get() == period.get()) {
                class.members = class.members.with(id);
                return Ok(at);
            }
            rest = tail;
            at = at.saturating_add(1);
        }
        Err(Error::PollingClassesExceeded)
    }

    /// The number of classes.
    pub(crate) fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Becomes a copy of `from`'s used classes (a table's install; only the used ones
    /// are copied, to keep the section short).
    pub(crate) fn copy_used(&mut self, from: &Classes<B>) {
        let len = from.len();
        for (to, c) in self.list.iter_mut().zip(from.list.iter()).take(len) {
            *to = *c;
        }
        self.len = from.len;
    }

    /// The same classes for a sequencer of capacity `M` (a table's for the sequencer it
    /// is installed in, `N <= M`).
    pub(crate) fn resized<const M: usize>(&self) -> Classes<M> {
        let mut out = Classes::new();
        for (to, c) in out.list.iter_mut().zip(self.list.iter()).take(self.len()) {
            *to = Class {
                period: c.period,
                next: c.next,
                members: c.members.resized(),
            };
        }
        out.len = self.len;
        out
    }

    /// The members of class `index` (empty for an unused index).
    pub(crate) fn members(&self, index: u8) -> SeqSet<B> {
        self.list
            .get(usize::from(index))
            .map_or(SeqSet::EMPTY, |c| c.members)
    }

    /// The next poll of class `index`, whose grid a start into it joins (a member whose run
    /// is under way keeps the grid).
    pub(crate) fn next_poll(&self, index: u8, now: Stamp) -> Stamp {
        self.list.get(usize::from(index)).map_or(now, |c| c.next)
    }

    /// Starts the grid of class `index`, which has no member under way, for a start at `now`:
    /// its first poll one period from now. Returns that poll.
    pub(crate) fn start_grid(&mut self, index: u8, now: Stamp) -> Stamp {
        match self.list.get_mut(usize::from(index)) {
            Some(c) => {
                c.next = now.plus(c.period.map_or(0, NonZeroU32::get));
                c.next
            }
            None => now,
        }
    }

    /// Class `index` is due now, its grid starting again from now (after a long gap
    /// between ticks).
    pub(crate) fn restart_grid(&mut self, index: usize, now: Stamp) {
        if let Some(c) = self.list.get_mut(index) {
            c.next = now;
        }
    }

    /// The classes in use, bit `i` for class `i`.
    pub(crate) fn used(&self) -> u8 {
        // At most eight: `len` fits.
        (1u16 << self.len).wrapping_sub(1) as u8
    }

    /// The scan of class `index` at `now` in one word of the sets (see [`Class::scan`]).
    #[inline(always)]
    pub(crate) fn scan(
        &mut self,
        index: usize,
        now: Stamp,
        word: Word<B>,
        scan: &mut Scan,
    ) -> SetWord<B> {
        // An unused class has no members: no need to test `len`.
        match self.list.get_mut(index) {
            Some(c) => c.scan(1 << (index & 7), now, word, scan),
            None => SetWord::empty(word.live.index()),
        }
    }

    /// The scan of every class at `now` in one word of the sets.
    #[inline(always)]
    pub(crate) fn scan_all(&mut self, now: Stamp, word: Word<B>, scan: &mut Scan) -> SetWord<B> {
        let len = self.len();
        let mut due = SetWord::empty(word.live.index());
        let mut bit = 1;
        for c in self.list.iter_mut().take(len) {
            due = due.or(c.scan(bit, now, word, scan));
            bit <<= 1;
        }
        due
    }
}

/// One word of the sets a scan reads.
#[derive(Clone, Copy)]
pub(crate) struct Word<const B: usize> {
    /// The sequences whose run is under way: a class with such a member keeps its grid.
    pub(crate) live: SetWord<B>,
    /// The monitored sequences (a subset): a due class's are polled.
    pub(crate) monitored: SetWord<B>,
}

impl<const B: usize> Class<B> {
    /// The due polls of this class (bit `bit` of [`Scan::due_classes`]) in one word of the
    /// sets: its monitored members there, when its poll is due. When the class has a
    /// member under way there (a restarting one keeps the grid too) and its poll is due,
    /// advances its grid, unless an earlier word of this tick did.
    #[inline(always)]
    fn scan(&mut self, bit: u8, now: Stamp, word: Word<B>, scan: &mut Scan) -> SetWord<B> {
        let members = self.members.word(word.live.index());
        let live = members.and(word.live);
        // A class with members has a period.
        let (false, Some(period)) = (live.is_empty(), self.period) else {
            return SetWord::empty(word.live.index());
        };
        let advanced = B > 1 && scan.due_classes & bit != 0;
        let due = advanced || now.reached(self.next);
        if due && !advanced {
            // The next grid point after now: missed periods (a late tick) are not
            // replayed.
            let behind = self.next.until(now);
            let skip = (behind / period).wrapping_add(1);
            self.next = self.next.plus(skip.wrapping_mul(period.get()));
            scan.due_classes |= bit;
        }
        scan.ahead = scan.ahead.min(now.until(self.next));
        if due {
            members.and(word.monitored)
        } else {
            SetWord::empty(word.live.index())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Word `w` of the sets with `ids` under way and monitored.
    fn all_monitored(ids: &SeqSet<8>, w: usize) -> Word<8> {
        Word {
            live: ids.word(w),
            monitored: ids.word(w),
        }
    }

    fn live(ids: &[u8]) -> SeqSet<8> {
        let mut b = SeqSet::EMPTY;
        for &i in ids {
            b.insert(SeqId(i));
        }
        b
    }

    #[test]
    fn a_class_polls_its_monitored_members_on_its_grid() {
        let mut c = Classes::<8>::new();
        assert_eq!(c.join(SeqId(0), 1_000), Ok(0));
        assert_eq!(c.join(SeqId(1), 2_000), Ok(1));
        assert_eq!(c.join(SeqId(2), 1_000), Ok(0));
        let monitored = live(&[0, 1]);
        assert_eq!(c.start_grid(0, Stamp(500)), Stamp(1_500));
        assert_eq!(c.start_grid(1, Stamp(500)), Stamp(2_500));
        // Already busy: sequence 2 joins the grid of sequence 0.
        assert!(c.members(0).word(0).meets(monitored.word(0)));
        assert_eq!(c.next_poll(0, Stamp(900)), Stamp(1_500));
        let scan = |c: &mut Classes<8>, now| {
            let mut scan = Scan::new();
            let mut due = SetWord::empty(0);
            for i in 0..c.len() {
                due = due.or(c.scan(
                    i,
                    Stamp(now),
                    all_monitored(&live(&[0, 1, 2]), 0),
                    &mut scan,
                ));
            }
            (due, scan.ahead)
        };
        assert_eq!(scan(&mut c, 1_000), (SetWord::empty(0), 500));
        assert_eq!(scan(&mut c, 1_500), (live(&[0, 2]).word(0), 1_000));
        // A late tick: 3 700 is past 2 500 and 3 500; the next polls stay on the grids.
        assert_eq!(scan(&mut c, 3_700), (live(&[0, 1, 2]).word(0), 800));
        assert_eq!(scan(&mut c, 4_500), (live(&[0, 1, 2]).word(0), 1_000));
    }

    #[test]
    fn a_class_is_due_once_per_tick_in_every_word_of_its_members() {
        let mut c = Classes::<8>::new();
        for id in [3, 100, 250] {
            assert_eq!(c.join(SeqId(id), 1_000), Ok(0));
        }
        let monitored = live(&[3, 100, 250]);
        assert_eq!(c.start_grid(0, Stamp(0)), Stamp(1_000));
        let tick = |c: &mut Classes<8>, now| {
            let mut scan = Scan::new();
            let due: [SetWord<8>; 3] =
                [0, 3, 7].map(|w| c.scan_all(Stamp(now), all_monitored(&monitored, w), &mut scan));
            (due.map(|d| d.count()), scan.ahead)
        };
        // Word 0 advances the grid to 2 000; words 3 and 7 are due in the same tick.
        assert_eq!(tick(&mut c, 1_000), ([1, 1, 1], 1_000));
        assert_eq!(tick(&mut c, 1_500), ([0, 0, 0], 500));
        assert_eq!(tick(&mut c, 2_000), ([1, 1, 1], 1_000));
    }

    /// A member under way but not monitored (restarting) keeps its class's grid: the scan
    /// advances it on its points, polling only the monitored members.
    #[test]
    fn a_restarting_member_keeps_the_grid_and_is_not_polled() {
        let mut c = Classes::<1>::new();
        assert_eq!(c.join(SeqId(0), 10_000), Ok(0));
        assert_eq!(c.join(SeqId(1), 10_000), Ok(0));
        assert_eq!(c.start_grid(0, Stamp(0)), Stamp(10_000));
        let restarting = Word {
            live: SetWord::new(0, 0b01),
            monitored: SetWord::empty(0),
        };
        let mut scan = Scan::new();
        assert!(c.scan_all(Stamp(10_000), restarting, &mut scan).is_empty());
        assert_eq!(
            (c.next_poll(0, Stamp(14_000)), scan.ahead),
            (Stamp(20_000), 10_000)
        );
        // Running again from 14 000: polled on the grid it kept.
        let running = Word {
            live: SetWord::new(0, 0b01),
            monitored: SetWord::new(0, 0b01),
        };
        let mut scan = Scan::new();
        assert!(c.scan_all(Stamp(15_000), running, &mut scan).is_empty());
        assert_eq!(c.scan_all(Stamp(20_000), running, &mut scan).bits(), 0b01);
    }

    #[test]
    fn more_periods_than_classes_is_an_error() {
        let mut c = Classes::<8>::new();
        for p in 1..=MAX_POLLING_CLASSES as u32 {
            assert!(c.join(SeqId(0), p).is_ok());
        }
        assert_eq!(c.join(SeqId(1), 99), Err(Error::PollingClassesExceeded));
        assert_eq!(c.join(SeqId(1), 3), Ok(2));
    }
}
