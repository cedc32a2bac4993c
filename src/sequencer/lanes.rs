//! The lanes' wakers, and how the sequencer calls them.
//!
//! A waker is foreign code: its `wake`, `clone` and `drop` may do anything, including
//! calling back into the sequencer (a waker written with `std::task::Wake` may read a
//! handle or request an abort). So the wakers are kept outside the sequencer's state
//! (`State`), and each is only ever moved in and out of its cell: no reference into the
//! state, or into a waker cell, lives while a waker runs. An operation that must wake lanes
//! collects them as a [`LaneSet`] inside its section and wakes them after it.

use core::cell::Cell;
use core::task::{RawWakerVTable, Waker};

use crate::lock::Lock;
use crate::model::id::Link;
use crate::model::set::SetWord;
use crate::sequencer::control_block::NO_LANE;
use crate::sequencer::sections::{in_sections, Sections};
use crate::sequencer::state::WakeMemo;
use crate::sequencer::State;
use crate::{Error, SeqId, Sequencer};

/// The identity of a waker: the addresses of its data and vtable, only ever compared.
/// Addresses rather than pointers, so that nothing suggests they are dereferenced and the
/// sequencer stays `Send`. No waker has its vtable at address 0, so [`NO_WAKER`] matches
/// none.
pub(crate) type WakerId = (usize, usize);

/// The identity of no waker.
pub(crate) const NO_WAKER: WakerId = (0, 0);

/// The identity of `w`.
#[inline]
fn identity(w: &Waker) -> WakerId {
    (
        w.data().addr(),
        (w.vtable() as *const RawWakerVTable).addr(),
    )
}

/// A set of lane slots (bit `k` = slot `k`; a sequencer has at most 32 lanes).
#[derive(Clone, Copy, PartialEq, Eq, Default, Debug)]
pub(crate) struct LaneSet(pub(crate) u32);

impl LaneSet {
    pub(crate) const EMPTY: LaneSet = LaneSet(0);

    /// The set of lane slot `lane` alone (empty for no lane, `NO_LANE`).
    #[inline]
    pub(crate) fn of(lane: u8) -> LaneSet {
        LaneSet(1u32.checked_shl(u32::from(lane)).unwrap_or(0))
    }

    /// The first `count` lane slots (every slot declared when `count` is the number
    /// declared).
    pub(crate) fn first(count: u8) -> LaneSet {
        LaneSet(
            1u32.checked_shl(u32::from(count))
                .map_or(u32::MAX, |b| b.wrapping_sub(1)),
        )
    }

    #[inline]
    pub(crate) fn with(self, other: LaneSet) -> LaneSet {
        LaneSet(self.0 | other.0)
    }
}

impl Iterator for LaneSet {
    type Item = u8;

    /// The slots in the set, lowest first.
    #[inline]
    fn next(&mut self) -> Option<u8> {
        if self.0 == 0 {
            return None;
        }
        // At most 31: fits a byte.
        let lane = self.0.trailing_zeros() as u8;
        self.0 &= self.0.wrapping_sub(1);
        Some(lane)
    }
}

/// The waker of one lane slot, once its lane has parked.
///
/// [`wake`](Self::wake) takes the waker out of its cell while it calls it, and the call may
/// come back to the slot (an executor that polls inside the wake-up). What reaches the slot
/// meanwhile is left to that wake as a mark, which it looks at when its call returns: a
/// wake-up, which it passes on by calling again, and the lane's drop, after which it drops
/// the waker instead of putting it back. So:
/// * a waker in the cell: `identity` names it, no mark;
/// * the cell empty, `identity` a waker's: a wake holds that waker out; marked: woken
///   meanwhile;
/// * `identity` [`NO_WAKER`]: the cell empty; marked: forgotten since the last
///   registration (a wake further up may still hold an older waker).
pub(crate) struct LaneWaker {
    waker: Cell<Option<Waker>>,
    /// The identity of `waker` (lanes joined in one task share a waker: woken once).
    identity: Cell<WakerId>,
    /// Woken or forgotten while a wake held the waker out.
    marked: Cell<bool>,
    /// The lane was polled (it registers at every poll) since a wake last called again.
    polled: Cell<bool>,
}

impl LaneWaker {
    const fn new() -> Self {
        LaneWaker {
            waker: Cell::new(None),
            identity: Cell::new(NO_WAKER),
            marked: Cell::new(false),
            polled: Cell::new(false),
        }
    }

    /// Keeps `waker` as this lane's waker, cloned only when it changed. True when it
    /// changed.
    ///
    /// The old waker stays in its cell while the new one is cloned, so a wake-up from the
    /// clone finds the slot as it was. A new waker clears the mark: this lane is being
    /// polled (its await point keeps the waker first, then reads the state), so a wake-up
    /// marked before is answered by that read, and a wake still holding an older waker
    /// finds the new one in the cell and drops its own. The same waker leaves the cell and
    /// the mark as they are: a wake that holds it out puts it back, and calls it again if
    /// woken after this poll.
    fn register(&self, waker: &Waker) -> bool {
        self.polled.set(true);
        // The same waker as kept (what `Waker::will_wake` compares): nothing to do.
        if self.identity.get() == identity(waker) {
            return false;
        }
        let new = waker.clone();
        self.identity.set(identity(&new));
        let displaced = self.waker.replace(Some(new));
        self.marked.set(false);
        // Dropped after the cell is consistent again: its `drop` may call back.
        drop(displaced);
        true
    }

    /// Forgets the lane's waker: its lane future was dropped. Marked for a wake that holds
    /// the waker out (the drop came from inside its call): it drops the waker.
    fn forget(&self) {
        let kept = self.waker.take();
        self.identity.set(NO_WAKER);
        self.marked.set(true);
        // Dropped after the cell is consistent again: its `drop` may call back.
        drop(kept);
    }

    /// Wakes the lane (nothing before it first parked, or once forgotten).
    #[inline]
    fn wake(&self) {
        let Some(waker) = self.waker.take() else {
            // A wake further up the stack holds the waker: it calls it again if need be.
            if self.identity.get() != NO_WAKER {
                self.marked.set(true);
            }
            return;
        };
        waker.wake_by_ref();
        if self.marked.get() {
            self.wake_again(waker);
            return;
        }
        self.put_back(waker);
    }

    /// The rest of a wake whose call left the slot marked: calls `waker` again while a
    /// wake-up came after the lane's poll inside the last call, or drops it once the lane
    /// is forgotten.
    #[cold]
    fn wake_again(&self, waker: Waker) {
        while self.marked.replace(false) {
            if self.identity.get() == NO_WAKER {
                // The mark stays for a wake further up that holds an older waker. The cell
                // is empty, consistent, before the drop, which may call back.
                self.marked.set(true);
                drop(waker);
                return;
            }
            // Not polled since the last call began: the poll it asked for is still to come
            // and reads what the wake-up announced. (Before the first call `polled` may be
            // older: one call more at most.) Calling whenever marked would never end with a
            // waker whose every call changes its own lane's state.
            if !self.polled.replace(false) {
                break;
            }
            // Marked and a waker named: the cell is empty, `waker` is the one named.
            waker.wake_by_ref();
        }
        self.put_back(waker);
    }

    /// Puts `waker` back after its call, unless a waker registered meanwhile (by the
    /// wake-up itself) took its place: that one is the newer, kept.
    #[inline]
    fn put_back(&self, waker: Waker) {
        match self.waker.take() {
            None => self.waker.set(Some(waker)),
            Some(newer) => {
                self.waker.set(Some(newer));
                drop(waker);
            }
        }
    }
}

/// The wakers of a sequencer's `W` lane slots.
pub(crate) struct Lanes<const W: usize> {
    slots: [LaneWaker; W],
}

impl<const W: usize> Lanes<W> {
    pub(crate) const fn new() -> Self {
        Lanes {
            slots: [const { LaneWaker::new() }; W],
        }
    }

    /// The identity of lane slot `lane`'s waker ([`NO_WAKER`] before it parked). Only
    /// under the sequencer's lock.
    pub(crate) fn identity(&self, lane: u8) -> WakerId {
        self.slots
            .get(usize::from(lane))
            .map_or(NO_WAKER, |s| s.identity.get())
    }

    /// Whether one of `lanes` has the waker `waker` (lanes joined in one task share it).
    /// Only under the sequencer's lock.
    pub(crate) fn has_waker(&self, lanes: LaneSet, waker: WakerId) -> bool {
        let mut lanes = lanes;
        lanes.any(|lane| self.identity(lane) == waker)
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Checks that every declared lane has run up to its first wait. A lane declared with
    /// [`SeqConfig::in_lane`](crate::SeqConfig::in_lane) or
    /// [`Handle::declare_lane`](crate::Handle::declare_lane) whose future no task polls takes
    /// no start: a non-blocking start of its sequence (a monitor's safe stop) would be
    /// `Running` for good, and its owner held by the exception it never handles.
    /// Returns [`Error::NoLane`] with the first such sequence, or first
    /// [`Error::LaneCapacityExceeded`] with the first sequence whose lane future found all
    /// `W` lane slots taken (that lane never runs either).
    ///
    /// Call it once every lane task has been polled: in RTIC, at the top of `idle` (the
    /// tasks spawned in `init` run up to their first wait before `idle` starts). The host
    /// simulator makes the same check at its first start (and again after sequences or
    /// lanes were added).
    ///
    /// ```
    /// use core::pin::pin;
    /// use core::future::Future;
    /// use core::task::{Context, Waker};
    /// use rtseq::{lane, Cx, Error, Failure, SeqConfig, Sequence, Sequencer};
    /// struct SafeStop;
    /// impl Sequence<()> for SafeStop {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut safe_stop = seq.add(SeqConfig::new("safe stop").in_lane(), SafeStop).unwrap();
    /// let id = safe_stop.id();
    /// // Declared, but no task polls its lane yet.
    /// assert_eq!(seq.check_lanes(), Err(Error::NoLane(id)));
    /// let mut task = pin!(lane(&seq, &(), &mut safe_stop));
    /// let _ = task.as_mut().poll(&mut Context::from_waker(Waker::noop()));
    /// assert_eq!(seq.check_lanes(), Ok(()));
    /// ```
    pub fn check_lanes(&self) -> Result<(), Error> {
        if let Some(id) = self.with(|s| s.lane_refused.get()) {
            return Err(Error::LaneCapacityExceeded(id));
        }
        // A closed lane's waker is forgotten too.
        let never_run = self.with(|s| {
            s.registered().enumerate().find_map(|(i, b)| {
                let never_run =
                    b.own_lane != NO_LANE && self.lanes.identity(b.own_lane) == NO_WAKER;
                never_run.then(|| SeqId::from_index(i))
            })
        });
        match never_run {
            Some(id) => Err(Error::NoLane(id)),
            None => Ok(()),
        }
    }

    /// The lane future of `id`, whose sequence object was made by the sequencer tagged
    /// `maker`, was dropped (the loser of a `select`, a task that stopped its lane): the
    /// lane is closed and its waker forgotten, so that a start of `id` is
    /// [`Error::NoLane`] (an exception sequence's counts as not run) and
    /// [`check_lanes`](Self::check_lanes) names it, until a lane future waits in it
    /// again. The lane of another sequencer's object changes nothing here.
    pub(crate) fn close_lane(&self, id: SeqId, maker: u16) {
        L::lock(|| {
            let closed = self.borrow_state(|s| s.close_lane(id, maker));
            if let Some(lane) = closed.and_then(|l| self.lanes.slots.get(usize::from(l))) {
                lane.forget();
            }
        });
    }

    /// Keeps `waker` as the waker of `id`'s lane, then runs `read` on the state: an await
    /// point's wait, in which no wake-up between the registration and the read can be
    /// lost (see [`park_in_then`](Self::park_in_then)).
    pub(crate) fn park_then<R>(
        &self,
        id: SeqId,
        waker: &Waker,
        read: impl FnOnce(&mut State<C, N, T, W, B>) -> R,
    ) -> R {
        self.park_in_then(|s| s.lane_slot(id), waker, read)
    }

    /// Keeps `waker` as the waker of the lane slot `lane` finds in the state, then runs
    /// `read` on the state. With a coarse lock in one section; with the portable lock the
    /// slot and the waker in one section, the read in another (and, when the waker changed,
    /// a section between them that forgets the remembered lanes). Either way the state is not
    /// borrowed while a changed waker is cloned or dropped, and a changed waker forgets
    /// the lanes remembered for the tick's wake-ups.
    pub(crate) fn park_in_then<R>(
        &self,
        lane: impl FnOnce(&State<C, N, T, W, B>) -> u8,
        waker: &Waker,
        read: impl FnOnce(&mut State<C, N, T, W, B>) -> R,
    ) -> R {
        let register = || {
            let lane = self.borrow_state(|s| lane(s));
            self.lanes
                .slots
                .get(usize::from(lane))
                .is_some_and(|slot| slot.register(waker))
        };
        if !L::COARSE {
            if L::lock(register) {
                self.with(|s| s.polling.forget_woken());
            }
            return self.with(read);
        }
        L::lock(|| {
            let changed = register();
            self.borrow_state(|s| {
                if changed {
                    s.polling.forget_woken();
                }
                read(s)
            })
        })
    }

    /// Whether a lane was declared for `id`.
    pub(crate) fn has_lane(&self, id: SeqId) -> bool {
        in_sections!(self, |s| lane_slot_of(s, id)).is_some()
    }

    /// Wakes the lanes `lanes`, outside the state, each in a section of its own.
    pub(crate) fn wake_lanes(&self, lanes: LaneSet) {
        for lane in lanes {
            L::lock(|| self.wake_lane(lane));
        }
    }

    /// Wakes lane slot `lane` (under the lock, the state not borrowed).
    fn wake_lane(&self, lane: u8) {
        if let Some(slot) = self.lanes.slots.get(usize::from(lane)) {
            slot.wake();
        }
    }

    /// Runs `f` on the state, then wakes the lanes it returns once the state is no longer
    /// borrowed: with a coarse lock all in one section, else in sections of their own (a
    /// waker's length is not rtseq's to bound).
    pub(crate) fn update_and_wake(&self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> LaneSet) {
        if L::COARSE {
            L::lock(|| {
                let lanes = self.borrow_state(f);
                lanes.for_each(|lane| self.wake_lane(lane));
            });
        } else {
            let lanes = self.with(f);
            self.wake_lanes(lanes);
        }
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Closes the lane of `id` if the object `maker` made is this sequencer's (see
    /// [`Sequencer::close_lane`]): its slot, whose waker is to be forgotten.
    fn close_lane(&mut self, id: SeqId, maker: u16) -> Option<u8> {
        if self.tag != maker {
            return None;
        }
        // A refused lane future (no slot) is gone with it.
        if self.lane_refused.get() == Some(id) {
            self.lane_refused = Link::NONE;
        }
        let lane = self
            .block(id)
            .map(|b| b.own_lane)
            .filter(|&l| l != NO_LANE)?;
        self.lanes_closed |= 1 << (lane & 31);
        // A start that checked the lane before schedules again (its commit compares the
        // count of changes) and is refused.
        self.changes = self.changes.wrapping_add(1);
        // The remembered wake-ups may name its waker.
        self.polling.forget_woken();
        Some(lane)
    }

    /// A lane future waits in slot `lane`: the lane is open (again).
    pub(crate) fn open_lane(&mut self, lane: u8) {
        self.lanes_closed &= !(1 << (lane & 31));
    }

    /// A lane future of `id` found all `W` lane slots taken: the first such is remembered,
    /// until it is dropped (`close_lane`).
    pub(crate) fn refuse_lane(&mut self, id: SeqId) {
        if self.block(id).is_some() && self.lane_refused.get().is_none() {
            self.lane_refused = Link::to(Some(id));
        }
    }

    /// Why `id` has no open lane to start in: all `W` slots were taken before one was
    /// declared for it ([`Error::LaneCapacityExceeded`]), or none was declared or its lane
    /// future was dropped ([`Error::NoLane`]).
    pub(crate) fn no_lane(&self, id: SeqId) -> Error {
        let unslotted = self.block(id).is_some_and(|b| b.own_lane == NO_LANE);
        if unslotted && usize::from(self.lanes_declared) >= W {
            Error::LaneCapacityExceeded(id)
        } else {
            Error::NoLane(id)
        }
    }

    /// Whether `lane` is open: no lane future in it was dropped since one last waited.
    pub(crate) fn lane_open(&self, lane: u8) -> bool {
        self.lanes_closed & (1 << (lane & 31)) == 0
    }

    /// The lanes to wake for the due exit-condition polls `polls`: the lanes found for the
    /// same set last time, or, when the set changed, a walk over the sequences. A lane
    /// whose waker is already among them (lanes joined in one task) is not woken again.
    #[inline(always)]
    pub(crate) fn lanes_of_polls(&mut self, polls: SetWord<B>, wakers: &Lanes<W>) -> LaneSet {
        if self.polling.woken.polls != polls {
            let mut lanes = LaneSet::EMPTY;
            for id in polls {
                let lane = self.lane_slot(id);
                let waker = wakers.identity(lane);
                if waker != NO_WAKER && !wakers.has_waker(lanes, waker) {
                    lanes = lanes.with(LaneSet::of(lane));
                }
            }
            self.polling.woken = WakeMemo { polls, lanes };
        }
        self.polling.woken.lanes
    }
}

/// The lane slot `id` declared, if any and open (see [`Sequencer::close_lane`]).
pub(crate) fn lane_slot_of<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
) -> Option<u8> {
    s.section(|s| {
        s.block(id)
            .map(|b| b.own_lane)
            .filter(|&l| l != NO_LANE && s.lane_open(l))
    })
}

/// Declares a lane for `id` (idempotent) and returns its slot (`None`: all `W` slots are
/// taken). Slots are handed out in order and never freed.
pub(crate) fn declare_lane<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
) -> Option<u8> {
    s.section(|s| {
        let next = s.lanes_declared;
        let b = s.block_mut(id)?;
        if b.own_lane != NO_LANE {
            return Some(b.own_lane);
        }
        if usize::from(next) >= W {
            return None;
        }
        b.own_lane = next;
        s.lanes_declared = next.saturating_add(1);
        Some(next)
    })
}

#[cfg(test)]
mod tests {
    use super::LaneSet;

    #[test]
    fn the_first_lane_slots() {
        assert_eq!(LaneSet::first(0), LaneSet::EMPTY);
        let mut three = LaneSet::first(3);
        assert_eq!(
            [three.next(), three.next(), three.next()],
            [Some(0), Some(1), Some(2)]
        );
        assert_eq!(three, LaneSet::EMPTY);
        assert_eq!(LaneSet::first(32).count(), 32);
    }
}
