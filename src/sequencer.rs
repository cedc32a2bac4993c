//! The sequencer: registry of control blocks, the transition function, starts and requests.

use core::cell::{Cell, UnsafeCell};
use core::marker::PhantomData;
use core::sync::atomic::{AtomicBool, Ordering};
use core::task::{RawWakerVTable, Waker};

use crate::bits::Bits;
use crate::control_block::{after, earlier, flag, request, ControlBlock, Link, NO_LANE};
use crate::lock::{CriticalSection, Lock};
use crate::polling::Classes;
use crate::safety::{AbortSequences, SafetyHandle};
use crate::table::{Entry, Table};
use crate::{
    Cause, Error, Handle, Instant, Outcome, RunningState, SeqConfig, SeqId, Transition, MAX_DEPTH,
};

/// What a start gives its new run (a restart keeps its run's own).
#[derive(Clone, Copy)]
pub(crate) struct NewRun {
    /// Its lane slot.
    lane: u8,
    /// The link to its caller.
    link: Link,
    /// Its flags, all of them.
    flags: u16,
}

/// How a sequence is started.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Mode {
    /// Inside the caller's future; the caller waits.
    Blocking,
    /// In the sequence's own lane; the caller continues.
    Lane,
}

/// What a framework await point must do, decided by the control block.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Gate {
    /// Advance.
    Go,
    /// Paused or an exception is being handled: stay at this await point.
    Hold,
    /// Aborted: unwind with this cause; no further line of the action runs.
    Aborted(Cause),
    /// Restarting: drop the action and run again from the pre-condition.
    Restart,
}

/// The mutable state, guarded by a critical section.
pub(crate) struct Inner<C, const N: usize, const T: usize, const W: usize> {
    pub(crate) now: u64,
    pub(crate) count: u8,
    pub(crate) blocks: [ControlBlock; N],
    pub(crate) hooks: [Option<fn(&C)>; N],
    /// The lanes' wakers: a lane is the only context that polls its sequences.
    pub(crate) lanes: [LaneSlot; W],
    #[cfg(feature = "counters")]
    pub(crate) counters: [crate::Counters; N],
    /// The polling classes: one schedule per distinct polling period.
    pub(crate) classes: Classes,
    /// Earliest next poll of a class with an active member (low 32 bits of µs, like the
    /// blocks' times; `NEVER_AHEAD` after the last scan when none is active).
    pub(crate) next_due: u32,
    /// `Running` or `Paused`, as of the start of the last tick (the tick folds `changed`
    /// in before it scans).
    pub(crate) active: Bits,
    /// `Paused`, as `active`.
    pub(crate) paused: Bits,
    /// The state changed since the tick last folded it into `active` and `paused` (kept by
    /// [`shift`](Inner::shift): one word operation per transition).
    pub(crate) changed: Bits,
    /// A new run or restart began: the tick resets the edge detection of these sequences'
    /// monitors before their next evaluation.
    pub(crate) fresh: Bits,
    /// The timeout monitor is armed (the block's `deadline` is meaningful).
    pub(crate) armed: Bits,
    /// `exceptionIsActive`: a monitor of the sequence fired and its handling is pending,
    /// or the sequence was aborted because of it.
    pub(crate) excepting: Bits,
    /// Waiting for a polled condition (the exit condition, or `Cx::wait_until`).
    pub(crate) poll_wait: Bits,
    /// The tick says the polled condition is due.
    pub(crate) poll_due: Bits,
    /// The lanes the tick's last exit-condition wake-up woke, for reuse.
    pub(crate) wake_memo: WakeMemo,
    /// Requests or finished exception sequences wait for the tick.
    pub(crate) work: bool,
    pub(crate) trace: crate::trace::Ring<T>,
    pub(crate) trace_lost: u32,
    /// Exceptions whose sequence could not run (no lane, already running, too deep).
    pub(crate) exceptions_not_run: u16,
}

/// The lane slots woken for a set of due exit-condition polls: in a steady state the set
/// repeats from poll to poll, and the tick wakes the same lanes again without visiting the
/// sequences. Forgotten whenever a sequence's lane or a lane's waker changes.
#[derive(Clone, Copy)]
pub(crate) struct WakeMemo {
    /// The polls (never empty while the memo is valid).
    pub(crate) polls: Bits,
    /// Their lane slots, one per distinct waker (bit `k` = slot `k`).
    pub(crate) lanes: u32,
}

impl WakeMemo {
    pub(crate) const NONE: WakeMemo = WakeMemo {
        polls: Bits::EMPTY,
        lanes: 0,
    };
}

/// The waker of one lane, and the sequence that declared it.
pub(crate) struct LaneSlot {
    pub(crate) seq: Link,
    pub(crate) waker: Option<Waker>,
}

impl LaneSlot {
    const EMPTY: LaneSlot = LaneSlot {
        seq: Link::NONE,
        waker: None,
    };

    /// Keeps `waker` as this lane's waker (cloned only when it changed). True when it
    /// changed.
    fn park(&mut self, waker: &Waker) -> bool {
        match &self.waker {
            Some(w) if w.will_wake(waker) => false,
            _ => {
                self.waker = Some(waker.clone());
                true
            }
        }
    }
}

/// The identity of a waker (data and vtable pointers, compared, never dereferenced); no
/// waker has a null vtable, so [`NO_WAKER`] matches none.
pub(crate) type WakerId = (*const (), *const RawWakerVTable);

/// The identity of no waker.
pub(crate) const NO_WAKER: WakerId = (core::ptr::null(), core::ptr::null());

/// The identity of `w`.
#[inline]
pub(crate) fn identity(w: &Waker) -> WakerId {
    (w.data(), w.vtable() as *const RawWakerVTable)
}

/// The sequencer (seed §1.1): one per application, usually a `static`.
///
/// `C` is the application's control system: conditions, steps and sequences get typed `&C`
/// access to it (use atomics or [`critical_section::Mutex`] inside `C` for commands). `N` is
/// the capacity of sequences and steps, `T` of the transition trace buffer, `L` the
/// [`Lock`], `W` the capacity of lanes (sequences that can run non-blocking; a lane costs
/// 12 bytes, a sequence 48).
///
/// ```
/// use rtseq::{SeqConfig, Sequencer, Error};
/// static SEQ: Sequencer<(), 8> = Sequencer::new();
/// let main = SEQ.register(SeqConfig::new("main")).unwrap();
/// assert_eq!(SEQ.register(SeqConfig::new("main")), Err(Error::DuplicateName("main")));
/// assert_eq!(SEQ.sequence_by_name("main").map(|h| h.id()), Some(main));
/// ```
pub struct Sequencer<
    C,
    const N: usize,
    const T: usize = 64,
    L: Lock = CriticalSection,
    const W: usize = 8,
> {
    pub(crate) inner: UnsafeCell<Inner<C, N, T, W>>,
    /// Abort-all requests: an atomic, so any priority may raise one (the safety task sits
    /// above a priority ceiling).
    abort_all: AtomicBool,
    /// The safety system's lock-free handle (the seed's `getSafetySystem()`).
    safety: critical_section::Mutex<Cell<Option<&'static SafetyHandle>>>,
    _control: PhantomData<fn(&C)>,
    _lock: PhantomData<L>,
}

// SAFETY: `inner` is only reached through `Sequencer::with`, which runs under `L`, and `L`
// keeps every other user of this sequencer out (by its contract; for `PriorityCeiling`, the
// caller of the `unsafe` constructor promised that no user runs above the ceiling). The
// other fields are `Sync` themselves. `Inner` is `Send` for every `C` (it holds only plain
// data, wakers and `fn(&C)` pointers).
unsafe impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Sync
    for Sequencer<C, N, T, L, W>
{
}

impl<C, const N: usize, const T: usize, const W: usize> Default
    for Sequencer<C, N, T, CriticalSection, W>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<C, const N: usize, const T: usize, const W: usize> Sequencer<C, N, T, CriticalSection, W> {
    /// An empty sequencer guarded by critical sections; `const`, so it can be a `static`.
    pub const fn new() -> Self {
        Self::empty()
    }
}

#[cfg_attr(docsrs, doc(cfg(feature = "cortex-m")))]
#[cfg(feature = "cortex-m")]
impl<C, const N: usize, const T: usize, const BASEPRI: u8, const W: usize>
    Sequencer<C, N, T, crate::lock::PriorityCeiling<BASEPRI>, W>
{
    /// An empty sequencer guarded by RTIC's priority ceiling instead of critical sections:
    /// no interrupt above the ceiling is ever masked by rtseq.
    ///
    /// # Safety
    ///
    /// `BASEPRI` must be the BASEPRI value ([`rtic_basepri`](crate::lock::rtic_basepri)) of
    /// the highest priority at which any method of this sequencer is called — normally the
    /// tick's — and no method other than [`abort_all`](Self::abort_all) and
    /// [`safety_system`](Self::safety_system) may be called from above it.
    pub const unsafe fn with_priority_ceiling() -> Self {
        Self::empty()
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Sequencer<C, N, T, L, W> {
    const fn empty() -> Self {
        const {
            assert!(
                N <= crate::MAX_SEQUENCES,
                "at most MAX_SEQUENCES (32) sequences and steps"
            )
        };
        const { assert!(W <= 32, "at most 32 lanes") };
        Sequencer {
            abort_all: AtomicBool::new(false),
            safety: critical_section::Mutex::new(Cell::new(None)),
            _lock: PhantomData,
            inner: UnsafeCell::new(Inner {
                now: 0,
                count: 0,
                blocks: [ControlBlock::UNREGISTERED; N],
                hooks: [None; N],
                lanes: [LaneSlot::EMPTY; W],
                #[cfg(feature = "counters")]
                counters: [crate::Counters::ZERO; N],
                classes: Classes::new(),
                next_due: 0,
                active: Bits::EMPTY,
                paused: Bits::EMPTY,
                changed: Bits::EMPTY,
                fresh: Bits::EMPTY,
                armed: Bits::EMPTY,
                excepting: Bits::EMPTY,
                poll_wait: Bits::EMPTY,
                poll_due: Bits::EMPTY,
                wake_memo: WakeMemo::NONE,
                work: false,
                trace: crate::trace::Ring::new(),
                trace_lost: 0,
                exceptions_not_run: 0,
            }),
            _control: PhantomData,
        }
    }

    /// Runs `f` on the state inside a short section under the lock `L`.
    ///
    /// This is the crate's only access to `Inner`. A `RefCell` would add a panic path (the
    /// "already borrowed" check) to every operation; instead exclusivity rests on two facts:
    /// the lock keeps every other context out, and no closure passed here calls `with` again
    /// (they only touch `Inner`, and the wakers they call only flag a task).
    #[inline]
    pub(crate) fn with<R>(&self, f: impl FnOnce(&mut Inner<C, N, T, W>) -> R) -> R {
        L::lock(|| {
            // SAFETY: see above — under the lock and without re-entry this is the only
            // reference to `Inner`.
            let inner = unsafe { &mut *self.inner.get() };
            f(inner)
        })
    }

    /// Registers a sequence or step. Errors on an empty or duplicate name, an out-of-range
    /// duration, or when all `N` slots are taken.
    pub fn register(&self, config: SeqConfig<C>) -> Result<SeqId, Error> {
        let mut entry = Entry::checked(&config)?;
        self.with(|s| {
            let used = usize::from(s.count);
            if s.blocks
                .iter()
                .take(used)
                .any(|b| b.name == Some(config.name))
            {
                return Err(Error::DuplicateName(config.name));
            }
            let id = SeqId(s.count);
            let slot = s
                .blocks
                .get_mut(used)
                .ok_or(Error::SequenceCapacityExceeded)?;
            entry.class = s.classes.join(id, entry.polling)?;
            *slot = entry.block();
            if let Some(h) = s.hooks.get_mut(used) {
                *h = entry.on_abort();
            }
            s.count = s.count.saturating_add(1);
            Ok(id)
        })
    }

    /// Installs a [`Table`] checked at compile time into this empty sequencer: sequence
    /// `i` of the table gets the id `SeqId::from_index(i)`. Bind the sequence objects with
    /// [`bind`](Self::bind) afterwards. A table larger than `N` does not compile.
    ///
    /// One short section per entry, and one that copies the polling classes and makes
    /// everything visible at once (its length grows with the number of classes); errors
    /// (without a visible change) when anything is registered already.
    pub fn install<const K: usize>(&self, table: &Table<C, K>) -> Result<(), Error> {
        const {
            assert!(
                K <= N,
                "the table holds more sequences than the sequencer's N"
            )
        };
        self.install_entries(&table.entries, &table.classes)
    }

    /// The part of [`install`](Self::install) that does not depend on the table's size
    /// (one copy, not one per size; a firmware that installs one table inlines it).
    fn install_entries(&self, entries: &[Entry<C>], classes: &Classes) -> Result<(), Error> {
        for (used, entry) in entries.iter().enumerate() {
            self.with(|s| {
                // A block at or above `count` is invisible: nothing reads it before the
                // commit.
                if s.count != 0 {
                    return Err(Error::NotEmpty);
                }
                if let (Some(b), Some(h)) = (s.blocks.get_mut(used), s.hooks.get_mut(used)) {
                    *b = entry.block();
                    *h = entry.on_abort();
                }
                Ok(())
            })?;
        }
        self.with(|s| {
            if s.count != 0 {
                return Err(Error::NotEmpty);
            }
            s.classes.copy_used(classes);
            // At most `N` entries (checked by `install`), and `N` fits a `u8`.
            s.count = entries.len() as u8;
            Ok(())
        })
    }

    /// Binds the sequence or step object `body` to a registered id; each id binds once.
    // Inline, like `add`: the work is in `claim`.
    #[inline]
    pub fn bind<S>(&self, id: SeqId, body: S) -> Result<crate::Seq<S>, Error> {
        self.claim(id)?;
        Ok(crate::Seq::new(id, body))
    }

    /// The part of [`add`](Self::add) that does not depend on the body type (one copy, not
    /// one per sequence type).
    #[inline(never)]
    fn register_bound(&self, config: SeqConfig<C>) -> Result<SeqId, Error> {
        let id = self.register(config)?;
        self.claim(id)?;
        Ok(id)
    }

    /// The part of [`bind`](Self::bind) that does not depend on the body type.
    #[inline(never)]
    fn claim(&self, id: SeqId) -> Result<(), Error> {
        self.with(|s| {
            let b = s.block_mut(id)?;
            if b.has(flag::BOUND) {
                return Err(Error::AlreadyBound(id));
            }
            b.set(flag::BOUND, true);
            Ok(())
        })
    }

    /// [`register`](Self::register) and [`bind`](Self::bind) in one.
    ///
    /// ```
    /// use rtseq::{Cx, SeqConfig, Sequencer, Step};
    /// struct Enable;
    /// impl Step<()> for Enable { fn action(&mut self, _cx: &Cx<'_, ()>) {} }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let enable = seq.add(SeqConfig::new("enable"), Enable).unwrap();
    /// assert_eq!(seq.sequence_by_id(enable.id()).unwrap().name(), "enable");
    /// ```
    // Inline (the work is in `register_bound`): out of line, every body type had a copy
    // that moved the body and the error into the result (≈ 90 B each, measured).
    #[inline]
    pub fn add<S>(&self, config: SeqConfig<C>, body: S) -> Result<crate::Seq<S>, Error> {
        let id = self.register_bound(config)?;
        Ok(crate::Seq::new(id, body))
    }

    /// The seed's `getSequenceByID`.
    pub fn sequence_by_id(&self, id: SeqId) -> Option<Handle<'_, C>> {
        let known = self.with(|s| s.block(id).is_ok());
        known.then(|| Handle::new(self, id))
    }

    /// The seed's `getSequenceByName`.
    pub fn sequence_by_name(&self, name: &str) -> Option<Handle<'_, C>> {
        // One short section per registered name; the comparison runs outside.
        let engine: &dyn crate::engine::Engine<C> = self;
        engine.find(name).map(|id| Handle::new(self, id))
    }

    /// Number of registered sequences and steps.
    pub fn len(&self) -> usize {
        self.with(|s| usize::from(s.count))
    }

    /// True when nothing is registered.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The last tick's time.
    pub fn now(&self) -> Instant {
        self.with(|s| Instant::from_ticks(s.now))
    }

    /// Requests that every running sequence be aborted (e.g. by the safety system). Applied
    /// by the next tick, innermost sequences first. Safe to call from any priority.
    pub fn abort_all(&self) {
        self.abort_all.store(true, Ordering::Release);
    }

    /// Takes a pending abort-all request (the tick is its only consumer).
    pub(crate) fn take_abort_all(&self) -> bool {
        // Load, then store: no compare-and-swap needed. A request raised in between is
        // served by the abort-all being applied now.
        let requested = self.abort_all.load(Ordering::Acquire);
        if requested {
            self.abort_all.store(false, Ordering::Relaxed);
        }
        requested
    }

    /// Connects the safety system: sequences reach it through
    /// [`Cx::safety_system`](crate::Cx::safety_system) to trigger public events and read the
    /// level.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyHandle};
    /// use rtseq::Sequencer;
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// SEQ.set_safety_system(&SAFETY);
    /// SEQ.safety_system().unwrap().trigger(PublicEvent::new(0));
    /// ```
    pub fn set_safety_system(&self, safety: &'static SafetyHandle) {
        critical_section::with(|cs| self.safety.borrow(cs).set(Some(safety)));
    }

    /// The seed's `getSafetySystem()`: the connected safety system's handle.
    pub fn safety_system(&self) -> Option<&'static SafetyHandle> {
        critical_section::with(|cs| self.safety.borrow(cs).get())
    }

    /// Passes the buffered transitions, oldest first, to `f` and empties the buffer.
    /// Returns how many were lost to overflow since the last call.
    pub fn drain_trace(&self, mut f: impl FnMut(Transition)) -> u32 {
        loop {
            let (t, lost) = self.with(|s| {
                let t = s.trace.pop();
                let lost = if t.is_none() {
                    core::mem::take(&mut s.trace_lost)
                } else {
                    0
                };
                (t, lost)
            });
            match t {
                Some(t) => f(t),
                None => return lost,
            }
        }
    }

    /// Exceptions whose sequence could not run (it had no lane, was already running, or
    /// would nest too deep); their behaviour was applied at once.
    pub fn exceptions_not_run(&self) -> u16 {
        self.with(|s| s.exceptions_not_run)
    }
}

/// How one operation of several steps reaches [`Inner`]: with the portable lock each step
/// is a section of its own ([`Sections`]: its sections mask interrupts and must stay short),
/// with a coarse lock all of them run inside the one section the operation's caller took
/// (`Inner` itself: those sections only hold off the tick and the lanes). The operations
/// are written once, over `Steps`, and [`steps!`] picks the implementation by the lock.
pub(crate) trait Steps<C, const N: usize, const T: usize, const W: usize> {
    /// True when every step runs inside one section: nothing changes between two steps,
    /// so a commit never has to be tried again.
    const ONE_SECTION: bool = false;

    /// Runs `f` on the state: in a section of its own, or inside the caller's.
    fn step<R>(&mut self, f: impl FnOnce(&mut Inner<C, N, T, W>) -> R) -> R;

    /// The checks of a start of `id` (blocking in `caller`'s lane, or in its own lane) in
    /// the order a start in one piece would fail them, and the cut of a link to an old run
    /// of `id` among `caller`'s callers ([`cut_and_depth`](Self::cut_and_depth), one step
    /// per link). Returns the new run's lane and its flags (with `extra`) for
    /// [`launch`](Self::launch).
    fn admit(
        &mut self,
        id: SeqId,
        caller: Option<SeqId>,
        mode: Mode,
        extra: u16,
    ) -> Result<(u8, u16), Error> {
        let (bound, caller_lane) = self.step(|s| s.check_start(id, caller, mode))?;
        let (lane, pending) = match mode {
            Mode::Blocking => (caller_lane, 0),
            // A sequence has a lane once one was declared for it (`rtseq::lane`,
            // `Handle::declare_lane`).
            Mode::Lane => (
                self.lane_slot_of(id).ok_or(Error::NoLane(id))?,
                flag::START_PENDING,
            ),
        };
        // `caller` is the starting sequence itself (a context's or an exception's owner):
        // registered by construction.
        if let Some(c) = caller {
            if usize::from(self.cut_and_depth(id, c)) >= MAX_DEPTH {
                return Err(Error::CallerDepthExceeded(id));
            }
        }
        Ok((lane, bound | pending | extra))
    }

    /// Schedules and commits a run of `id`: a new one (`run`: its lane slot, the link to
    /// its caller and its flags) from a state that is not active, or (`run` `None`) a
    /// `Restarting` sequence's run again in its lane, caller and flags as they are (from
    /// `Restarting`, or, if the tick stopped it since the lane saw that, as the transition
    /// table allows; a scanned `Running` or `Paused` one stays). Schedule, then commit,
    /// and again if a tick ran in between (it may have rescanned without the new run, or
    /// changed its state: the commit re-checks both). False (nothing changed) when the
    /// state does not allow it: for a new run, `AlreadyRunning`. One function for both, so
    /// a firmware links one copy.
    #[inline(never)]
    fn launch(&mut self, id: SeqId, run: Option<NewRun>, cause: Cause) -> bool {
        let legal = match run {
            Some(_) => STARTABLE,
            None => sources(RunningState::Running) & !bit(RunningState::Paused),
        };
        loop {
            let (from, seen, armed) = self.step(|s| s.schedule(id, run.map(|r| r.lane)));
            if legal & bit(from) == 0 {
                return false;
            }
            self.step(|s| s.new_run(id, run.map(|r| r.link), armed));
            self.step(|s| s.due_by(id));
            let t = Transition::edge(id, from, RunningState::Running, cause);
            let done = self.commit(&t, seen, run.map(|r| r.flags));
            // In one section the loop never repeats: its head is then one call.
            if done || Self::ONE_SECTION {
                return done;
            }
        }
    }

    /// The commit of a start or restart: [`Inner::start`] in a step.
    fn commit(&mut self, t: &crate::trace::Edge, seen: u32, flags: Option<u16>) -> bool {
        self.step(|s| s.start(t, seen, flags))
    }

    /// Before `id` is started by `caller`: walks `caller`'s caller links, one step per
    /// link, and returns its depth (its number of callers, at most `MAX_DEPTH`). If `id` is
    /// itself a (finished) caller of `caller`, the link to its old run is cut there, so the
    /// links never form a cycle.
    fn cut_and_depth(&mut self, id: SeqId, caller: SeqId) -> u8 {
        let mut at = caller;
        let mut depth: u8 = 0;
        for _ in 0..MAX_DEPTH {
            match self.step(|s| s.cut_step(id, at)) {
                Some(up) => {
                    at = up;
                    depth = depth.saturating_add(1);
                }
                None => break,
            }
        }
        depth
    }

    /// The lane slot `id` declared: one step per slot (a declared slot never changes).
    fn lane_slot_of(&mut self, id: SeqId) -> Option<u8> {
        let me = Link::to(Some(id));
        (0..W)
            .find(|&k| self.step(|s| s.lanes.get(k).is_some_and(|l| l.seq == me)))
            .and_then(|k| u8::try_from(k).ok())
    }

    /// Declares a lane for `id` (idempotent) and returns its slot (`None`: all slots are
    /// taken): one step per slot looked at. `id` is registered (a `Seq` or a `Handle` of
    /// it exists).
    fn declare_lane(&mut self, id: SeqId) -> Option<u8> {
        // Slots fill in order and are never freed: the first slot that is `id`'s or free.
        let me = Link::to(Some(id));
        (0..W)
            .find(|&k| {
                self.step(|s| match s.lanes.get_mut(k) {
                    Some(l) if l.seq == me => true,
                    Some(l) if l.seq == Link::NONE => {
                        l.seq = me;
                        true
                    }
                    _ => false,
                })
            })
            .and_then(|k| u8::try_from(k).ok())
    }
}

/// Inside the section a coarse lock's caller holds: every step runs at once.
impl<C, const N: usize, const T: usize, const W: usize> Steps<C, N, T, W> for Inner<C, N, T, W> {
    const ONE_SECTION: bool = true;

    #[inline(always)]
    fn step<R>(&mut self, f: impl FnOnce(&mut Inner<C, N, T, W>) -> R) -> R {
        f(self)
    }
}

/// With the portable lock: one section per step.
pub(crate) struct Sections<'a, C, const N: usize, const T: usize, L: Lock, const W: usize>(
    pub(crate) &'a Sequencer<C, N, T, L, W>,
);

impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Steps<C, N, T, W>
    for Sections<'_, C, N, T, L, W>
{
    #[inline(always)]
    fn step<R>(&mut self, f: impl FnOnce(&mut Inner<C, N, T, W>) -> R) -> R {
        self.0.with(f)
    }

    /// A start and a restart commit in functions of their own, each one section without
    /// a test of `flags`: a test inside the section (where the compiler puts it when both
    /// sections are in one function) would lengthen it beyond the budget of 50
    /// instructions.
    fn commit(&mut self, t: &crate::trace::Edge, seen: u32, flags: Option<u16>) -> bool {
        match flags {
            Some(flags) => self.0.commit_start(t, seen, flags),
            None => self.0.commit_restart(t, seen),
        }
    }
}

/// `steps!(sequencer, |s| body)` runs `body` with `s` as its [`Steps`]: with a coarse lock
/// (`L::COARSE`, the lock type in scope) inside one section, else with a section per step.
/// The body is written once and compiled for the one case the lock needs.
macro_rules! steps {
    ($seq:expr, |$s:ident| $body:expr) => {
        if L::COARSE {
            $seq.with(|$s| $body)
        } else {
            let $s = &mut $crate::sequencer::Sections($seq);
            $body
        }
    };
}
pub(crate) use steps;

impl<C, const N: usize, const T: usize, L: Lock, const W: usize> Sequencer<C, N, T, L, W> {
    /// Starts `id` (blocking in `caller`'s lane, or in its own lane), with `extra` flags for
    /// the new run: [`admit`](Steps::admit), then [`launch`](Steps::launch) and, in its
    /// lane, the wake-up; with a coarse lock two sections (a whole start in one took 339
    /// instructions in the scenarios' traces, and its caller walk grows with the depth).
    pub(crate) fn begin(
        &self,
        id: SeqId,
        caller: Option<SeqId>,
        mode: Mode,
        cause: Cause,
        extra: u16,
    ) -> Result<(), Error> {
        let (lane, flags) = steps!(self, |s| s.admit(id, caller, mode, extra))?;
        let run = NewRun {
            lane,
            link: Link::to(caller),
            flags,
        };
        steps!(self, |s| {
            if !s.launch(id, Some(run), cause) {
                return Err(Error::AlreadyRunning(id));
            }
            if mode == Mode::Lane {
                s.step(|s| s.wake(id));
            }
            Ok(())
        })
    }

    /// [`Inner::start`] of a start in a section of its own (with the portable lock).
    #[inline(never)]
    fn commit_start(&self, t: &crate::trace::Edge, seen: u32, flags: u16) -> bool {
        self.with(|s| s.start(t, seen, Some(flags)))
    }

    /// [`Inner::start`] of a restart in a section of its own (with the portable lock).
    #[inline(never)]
    fn commit_restart(&self, t: &crate::trace::Edge, seen: u32) -> bool {
        self.with(|s| s.start(t, seen, None))
    }

    /// Wakes the lane that drives `id`, in a section of its own.
    #[inline(never)]
    pub(crate) fn wake_lane(&self, id: SeqId) {
        self.with(|s| s.wake(id));
    }
}

/// [`bit`] under a name that does not clash with a request bit.
const fn bit_of(s: RunningState) -> u8 {
    bit(s)
}

/// Bit of state `s` in a set of states.
pub(crate) const fn bit(s: RunningState) -> u8 {
    1 << s as u8
}

/// The states a start may leave (`Idle`, `Terminated`, `Aborted`: not active).
const STARTABLE: u8 =
    bit(RunningState::Idle) | bit(RunningState::Terminated) | bit(RunningState::Aborted);

/// The states from which `to` may be entered: [`RunningState::can_transition_to`] as a set.
pub(crate) const fn sources(to: RunningState) -> u8 {
    use RunningState::*;
    match to {
        Running => STARTABLE | bit(Paused) | bit(Restarting),
        Paused | Terminated => bit(Running),
        Restarting => bit(Running) | bit(Paused),
        Aborting => bit(Running) | bit(Paused) | bit(Restarting),
        Aborted => bit(Aborting),
        Idle => 0,
    }
}

/// A safety level that demands it aborts every sequence through the sequencer.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize> AbortSequences
    for Sequencer<C, N, T, L, W>
{
    fn abort_all(&self) {
        Sequencer::abort_all(self);
    }
}

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
    /// The block of registered sequence `id`.
    #[inline]
    pub(crate) fn block(&self, id: SeqId) -> Result<&ControlBlock, Error> {
        self.at(id).ok_or(Error::UnknownSequence(id))
    }

    /// The block of registered sequence `id`, to change.
    #[inline]
    pub(crate) fn block_mut(&mut self, id: SeqId) -> Result<&mut ControlBlock, Error> {
        self.at_mut(id).ok_or(Error::UnknownSequence(id))
    }

    /// The block of registered sequence `id`, inline: for the tick's and the lanes' hot
    /// paths and the tightest sections (elsewhere [`block`](Self::block), a call, saves
    /// the flash of one copy of the range checks per lookup).
    #[inline]
    pub(crate) fn fast(&self, id: SeqId) -> Option<&ControlBlock> {
        if id.0 >= self.count {
            return None;
        }
        self.blocks.get(id.index())
    }

    /// [`fast`](Self::fast), to change.
    #[inline]
    pub(crate) fn fast_mut(&mut self, id: SeqId) -> Option<&mut ControlBlock> {
        if id.0 >= self.count {
            return None;
        }
        self.blocks.get_mut(id.index())
    }

    /// Out of line, like [`at_mut`](Self::at_mut): one copy of the range checks.
    #[inline(never)]
    fn at(&self, id: SeqId) -> Option<&ControlBlock> {
        if id.0 >= self.count {
            return None;
        }
        self.blocks.get(id.index())
    }

    #[inline(never)]
    fn at_mut(&mut self, id: SeqId) -> Option<&mut ControlBlock> {
        if id.0 >= self.count {
            return None;
        }
        self.blocks.get_mut(id.index())
    }

    /// THE transition function: every state change goes through here. Makes transition
    /// `t` (its time is ignored: now is recorded) if the sequence is in state `t.from`,
    /// records it and returns the block for the caller's bookkeeping in the same section.
    /// Otherwise changes nothing and returns `None`.
    ///
    /// Callers read `t.from` in an earlier section and check the transition table there;
    /// a state that changed in between fails here. Out of line (one copy for every
    /// transition) and lean: it runs inside sections.
    #[inline(never)]
    pub(crate) fn shift(&mut self, t: &crate::trace::Edge) -> Option<&mut ControlBlock> {
        let b = self.blocks.get_mut(t.sequence.index())?;
        if b.state != t.from {
            return None;
        }
        b.state = t.to;
        self.changed = self.changed.or(Bits::of(t.sequence));
        if self.trace.push(self.now, t) {
            self.trace_lost = self.trace_lost.saturating_add(1);
        }
        #[cfg(feature = "counters")]
        if let Some(c) = self.counters.get_mut(t.sequence.index()) {
            c.count(t.from, t.to, t.cause);
        }
        Some(b)
    }

    /// The read-only checks of a start of `id`: not active; with a blocking caller, the
    /// caller's lane. Returns `id`'s `BOUND` flag (set once, never cleared) and that lane.
    pub(crate) fn check_start(
        &self,
        id: SeqId,
        caller: Option<SeqId>,
        mode: Mode,
    ) -> Result<(u16, u8), Error> {
        let b = self.block(id)?;
        if STARTABLE & bit(b.state) == 0 {
            return Err(Error::AlreadyRunning(id));
        }
        let lane = match (mode, caller) {
            // A blocking caller is the starting sequence itself: registered by construction.
            (Mode::Blocking, Some(c)) => self.blocks.get(c.index()).map_or(NO_LANE, |c| c.lane),
            _ => NO_LANE,
        };
        Ok((b.flags & flag::BOUND, lane))
    }

    /// Schedules a new run (or restart) of `id` from now, before its commit: its timeout
    /// deadline; for a new run (`start`: its lane slot) also its lane, run count, and no
    /// last exception or outcome yet. Only for a sequence that is not `Running` or
    /// `Paused` (then it only returns that state): the tick neither scans it nor walks
    /// through these fields, and the caller link, flags and state, which it does read,
    /// change in the commit. (A handle reading the sequence from a context that preempts a
    /// start in between sees no last outcome or exception.) Returns the state, the low 32
    /// bits of now and whether the timeout is armed, for the commit.
    #[inline]
    pub(crate) fn schedule(&mut self, id: SeqId, start: Option<u8>) -> (RunningState, u32, bool) {
        let now = self.now;
        // `id` is registered (checked before, and a registration is never undone): no
        // need to compare with `count` here, in `new_run` and in `due_by`.
        let Some(b) = self.blocks.get_mut(id.index()) else {
            return (RunningState::Running, 0, false);
        };
        let state = b.state;
        if matches!(state, RunningState::Running | RunningState::Paused) {
            return (state, 0, false);
        }
        b.deadline = after(now, b.timeout);
        if let Some(lane) = start {
            b.lane = lane;
            b.runs = b.runs.wrapping_add(1);
            b.active_exception = None;
            b.outcome = None;
        }
        let armed = b.timeout != 0;
        if start.is_some() {
            // Its lane may be another one now.
            self.wake_memo = WakeMemo::NONE;
        }
        // Truncation is the point: a commit compares the low 32 bits of the time (a tick in
        // between moves them; a wrap back to the same value takes 71 minutes).
        (state, now as u32, armed)
    }

    /// After [`schedule`](Self::schedule), before the commit: the tick scans by the first
    /// poll of `id`'s run starting now (its class's next poll; an idle class starts its
    /// grid now).
    pub(crate) fn due_by(&mut self, id: SeqId) {
        let now = self.now as u32;
        let class = self.blocks.get(id.index()).map_or(0, |b| b.class);
        let next = self.classes.resume(class, now, self.active);
        self.next_due = earlier(now, next, self.next_due);
    }

    /// The commit of a start or restart `t` ([`Steps::launch`] validated it and scheduled
    /// it at `seen`): a new run gets `flags` (all of them), a restart keeps its own.
    /// False: a tick ran since (the time moved, or the state is not `t.from` any more),
    /// nothing changed, schedule again (which fails with `AlreadyRunning` if the tick
    /// started it).
    pub(crate) fn start(&mut self, t: &crate::trace::Edge, seen: u32, flags: Option<u16>) -> bool {
        if self.now as u32 != seen {
            return false;
        }
        let Some(b) = self.shift(t) else {
            return false;
        };
        if let Some(flags) = flags {
            // Clears the requests and the pending behaviour too.
            b.flags = flags;
        }
        true
    }

    /// After [`schedule`](Self::schedule), before the commit, for a sequence that is not
    /// active (else nothing): its caller link (`Some` for a new run; a restart keeps it
    /// and drops its pending behaviour) and its sets (fresh, no exception, not waiting for
    /// a poll, the timeout `armed` or not). The tick reads them only of active sequences.
    pub(crate) fn new_run(&mut self, id: SeqId, caller: Option<Link>, armed: bool) {
        let Some(b) = self.blocks.get_mut(id.index()) else {
            return;
        };
        if matches!(b.state, RunningState::Running | RunningState::Paused) {
            return;
        }
        match caller {
            Some(c) => b.caller = c,
            // A new run's flags (set in its commit) have no pending behaviour either.
            None => b.set_pending(None),
        }
        self.fresh.set(id, true);
        self.armed.set(id, armed);
        self.excepting.set(id, false);
        // A stale `poll_due` is cleared when the run first waits for a poll.
        self.poll_wait.set(id, false);
    }

    /// Folds the state of sequence `id` into `active` and `paused`: two masked word
    /// updates, no branch on the state.
    pub(crate) fn fold(&mut self, id: SeqId) {
        // An unregistered block is idle: no need to compare with `count`.
        let state = self
            .blocks
            .get(id.index())
            .map_or(RunningState::Idle, |b| b.state);
        let me = Bits::of(id).0;
        // All ones when the state is in `states`, else zero.
        let mask = |states: u8| 0u32.wrapping_sub(u32::from(states & bit(state) != 0)) & me;
        let active = bit(RunningState::Running) | bit(RunningState::Paused);
        self.active.0 = (self.active.0 & !me) | mask(active);
        self.paused.0 = (self.paused.0 & !me) | mask(bit(RunningState::Paused));
    }

    /// Wakes the lanes of the due exit-condition polls `polls` (with a coarse lock, in one
    /// section): the lanes found for the same set last time, or, when the set changed, a
    /// walk over the sequences. Lanes joined in one task share their waker, which is
    /// woken once.
    #[inline(always)]
    pub(crate) fn wake_polls(&mut self, polls: Bits) {
        if self.wake_memo.polls != polls {
            let mut lanes = 0u32;
            let mut woken = NO_WAKER;
            for id in polls {
                let lane = self.fast(id).map_or(NO_LANE, |b| b.lane);
                if let Some(w) = self.lane_waker(lane) {
                    if identity(w) != woken {
                        woken = identity(w);
                        lanes |= 1u32.checked_shl(u32::from(lane)).unwrap_or(0);
                    }
                }
            }
            self.wake_memo = WakeMemo { polls, lanes };
        }
        let mut lanes = self.wake_memo.lanes;
        while lanes != 0 {
            // At most 31: fits a byte.
            let lane = lanes.trailing_zeros() as u8;
            lanes &= lanes.wrapping_sub(1);
            if let Some(w) = self.lane_waker(lane) {
                w.wake_by_ref();
            }
        }
    }

    /// The waker of sequence `id`'s lane, once its lane has parked.
    #[inline]
    pub(crate) fn waker_of(&self, id: SeqId) -> Option<&Waker> {
        self.lane_waker(self.fast(id)?.lane)
    }

    /// One step of the held check of a due wake-up (see `Sequencer::held`): `None` when
    /// `at` holds its callees (its gate is not `Go`), else its caller in `lane` to check
    /// next ([`Link::NONE`] at the top of the lane).
    pub(crate) fn held_step(&self, at: SeqId, lane: u8) -> Option<Link> {
        // The gate's `Go`, without building the gate. Plain slot lookups: a slot past
        // `count` is never `Running`, and a running block's caller is registered.
        let b = self.blocks.get(at.index())?;
        if b.state != RunningState::Running || self.excepting.has(at) {
            return None;
        }
        let up = b.caller;
        Some(match up.get().and_then(|c| self.blocks.get(c.index())) {
            Some(c) if c.lane == lane => up,
            _ => Link::NONE,
        })
    }

    /// The waker of lane slot `lane`, once its lane has parked.
    fn lane_waker(&self, lane: u8) -> Option<&Waker> {
        self.lanes.get(usize::from(lane))?.waker.as_ref()
    }

    /// Wakes the lane that drives `id` (a registered sequence: a plain slot lookup).
    #[inline(never)]
    pub(crate) fn wake(&self, id: SeqId) {
        let lane = self.blocks.get(id.index()).map_or(NO_LANE, |b| b.lane);
        if let Some(w) = self.lane_waker(lane) {
            w.wake_by_ref();
        }
    }

    /// Parks `waker` as the waker of `id`'s lane (a registered sequence, the waker's own:
    /// a plain slot lookup).
    pub(crate) fn park(&mut self, id: SeqId, waker: &Waker) {
        let lane = self.blocks.get(id.index()).map_or(NO_LANE, |b| b.lane);
        self.park_lane(lane, waker);
    }

    /// Parks `waker` as the waker of lane slot `lane`.
    pub(crate) fn park_lane(&mut self, lane: u8, waker: &Waker) {
        if let Some(slot) = self.lanes.get_mut(usize::from(lane)) {
            if slot.park(waker) {
                self.wake_memo = WakeMemo::NONE;
            }
        }
    }

    /// What an await point of `id` must do now.
    pub(crate) fn gate(&self, id: SeqId) -> Gate {
        let Some(b) = self.fast(id) else {
            return Gate::Aborted(Cause::Abort);
        };
        match b.state {
            RunningState::Running if !self.excepting.has(id) => Gate::Go,
            RunningState::Running | RunningState::Paused => Gate::Hold,
            RunningState::Restarting => Gate::Restart,
            RunningState::Aborting | RunningState::Aborted => Gate::Aborted(b.last_cause),
            // Not started by this run: treat as aborted so nothing of it advances.
            RunningState::Idle | RunningState::Terminated => Gate::Aborted(b.last_cause),
        }
    }

    /// Ends a run normally: `t` is `Running → Terminated` (cause `Completed` or
    /// `PreConditionFalse`). False, and nothing changes, if the sequence was aborted or
    /// restarted meanwhile or its exception is being handled (the gate says what to do
    /// instead).
    pub(crate) fn end(&mut self, t: &crate::trace::Edge) -> bool {
        // A run ends only through the gate `Go`: not while its exception is handled.
        !self.excepting.has(t.sequence) && self.shift(t).is_some()
    }

    /// After a run's framework returned: store the outcome and report the end of an
    /// exception sequence to the tick. Returns the joiner to wake.
    pub(crate) fn finished(&mut self, id: SeqId, outcome: Outcome) -> Option<SeqId> {
        let b = self.fast_mut(id)?;
        b.outcome = Some(outcome);
        let joiner = core::mem::replace(&mut b.joiner, Link::NONE).get();
        if b.has(flag::HANDLES_EXCEPTION) {
            b.set(flag::HANDLES_EXCEPTION, false);
            if let Some(ob) = b.caller.get().and_then(|o| self.block_mut(o).ok()) {
                ob.set(flag::EXCEPTION_DONE, true);
                self.work = true;
            }
        }
        joiner
    }

    /// Queues a pause, resume or abort request for the next tick.
    pub(crate) fn request(&mut self, id: SeqId, bit: u16) -> Result<(), Error> {
        let b = self.block_mut(id)?;
        let states = match bit {
            request::RESUME => bit_of(RunningState::Paused),
            request::PAUSE => bit_of(RunningState::Running),
            _ => !STARTABLE,
        };
        if states & bit_of(b.state) == 0 {
            return Err(if bit == request::RESUME {
                Error::NotPaused(id)
            } else {
                Error::NotRunning(id)
            });
        }
        b.flags |= bit;
        self.work = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_is_the_transition_table() {
        for from in RunningState::ALL {
            for to in RunningState::ALL {
                assert_eq!(
                    sources(to) & bit(from) != 0,
                    from.can_transition_to(to),
                    "{from:?} -> {to:?}"
                );
                assert_eq!(STARTABLE & bit(from) != 0, !from.is_active());
            }
        }
    }
}
