//! The sequencer (seed §1.1): the [`Sequencer`] type and every `impl` of it except the
//! tick's.
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | the type, its constructors, [`Sequencer::with`] and `borrow_state` (the only way into the state) |
//! | `state.rs` | [`State`]: everything the lock guards, grouped; the one accessor pair for control blocks; the transition function |
//! | `sets.rs` | the sets of sequences the tick works on (monitored, paused, due, ...), stored a word of every set together |
//! | `control_block.rs` | one sequence's control block (the seed's `BaseSequence` fields) |
//! | `clock.rs` | each sequence's run clock: run time, timeouts run out, start, stop, run on |
//! | `clearance.rs` | the clearance of an await point, the normal end of a run |
//! | `registry.rs` | registration, tables, binding, look-up by id and name |
//! | `start.rs` | starts and restarts: the checks, the schedule, the commit |
//! | `requests.rs` | pause, resume and abort requests for the next tick; abort-all |
//! | `inbox.rs` | what any priority leaves for the next tick without the lock |
//! | `safety.rs` | the connection to the safety system: its handle, abort-all, the levels and tripped inputs it notes for the trace |
//! | `callers.rs` | the caller tree: depth, cycles, who blocks whom |
//! | `joins.rs` | sequences waiting for the end of another run |
//! | `lanes.rs` | lane slots and their wakers (foreign code, called outside the state) |
//! | `sections.rs` | how an operation of several steps takes its sections under each lock |
//! | `validation.rs` | the check of a whole configuration before the first tick |
//! | `port.rs` | the object-safe port contexts and handles use: one method per operation |
//! | `handle.rs` | [`Handle`](crate::Handle): inspect and command one sequence |

use core::cell::UnsafeCell;
use core::marker::PhantomData;
use core::sync::atomic::AtomicBool;

use crate::lock::{CriticalSection, Lock};
use crate::safety::SafetyHandle;

pub(crate) mod callers;
pub(crate) mod clearance;
mod clock;
pub(crate) mod control_block;
pub(crate) mod end;
pub(crate) mod handle;
pub(crate) mod inbox;
#[cfg(test)]
mod interleavings;
pub(crate) mod joins;
pub(crate) mod lanes;
pub(crate) mod port;
mod registry;
pub(crate) mod requests;
mod safety;
pub(crate) mod sections;
pub(crate) mod sets;
pub(crate) mod start;
pub(crate) mod state;
pub(crate) mod validation;

use lanes::Lanes;
use safety::SafetyNotes;
pub(crate) use state::State;

/// The sequencer (seed §1.1): one per application, usually a `static`.
///
/// `C` is the application's control system: conditions, steps and sequences get typed `&C`
/// access to it (use atomics or [`critical_section::Mutex`] inside `C` for commands). `N` is
/// the capacity of sequences and steps, `T` of the trace ring of transitions and sequencer
/// events (a power of two), `L` the [`Lock`], `W` the capacity of lanes (sequences that can run
/// non-blocking), `B` the words of 32 sequences in each of the sequencer's sets of
/// sequences: `N <= 32 * B`, at most [`MAX_SEQUENCES`](crate::MAX_SEQUENCES) = 256 with
/// `B = 8`; [`set_words(N)`](crate::set_words) computes it. (Stable Rust cannot size an
/// array by `N / 32`, hence the second parameter.)
///
/// ```
/// use rtseq::lock::CriticalSection;
/// use rtseq::{SeqConfig, Sequencer};
/// // 256 sequences and steps: sets of 8 words.
/// static BIG: Sequencer<(), 256, 64, CriticalSection, 8, 8> = Sequencer::new();
/// assert!(BIG.register(SeqConfig::new("first")).is_ok());
/// ```
///
/// A capacity its sets cannot hold does not compile:
///
/// ```compile_fail,E0080
/// use rtseq::Sequencer;
/// static TOO_BIG: Sequencer<(), 64> = Sequencer::new(); // needs B = 2
/// ```
///
/// ```
/// use rtseq::{SeqConfig, Sequencer, Error};
/// static SEQ: Sequencer<(), 8> = Sequencer::new();
/// let main = SEQ.register(SeqConfig::new("main")).unwrap();
/// assert_eq!(SEQ.register(SeqConfig::new("main")), Err(Error::DuplicateName(main)));
/// assert_eq!(SEQ.sequence_by_name("main").map(|h| h.id()), Some(main));
/// ```
// `repr(C)`, the state first: every section reaches it at the sequencer's own address.
#[repr(C)]
pub struct Sequencer<
    C,
    const N: usize,
    const T: usize = 64,
    L: Lock = CriticalSection,
    const W: usize = 8,
    const B: usize = 1,
> {
    state: UnsafeCell<State<C, N, T, W, B>>,
    /// The lanes' wakers, outside `state`: a waker is foreign code, called only while the
    /// state is not borrowed.
    pub(crate) lanes: Lanes<W>,
    /// A tick is under way: set in its first section, cleared when it returns (see
    /// [`Sequencer::tick`]). An atomic, so that the tick clears it without a section.
    pub(crate) ticking: AtomicBool,
    /// The safety system's levels and tripped inputs, until the tick records them.
    pub(crate) safety_notes: SafetyNotes,
    /// The lock-free handle of this sequencer's safety system (the seed's
    /// `getSafetySystem()`): the system is built on it, so there is no connection to forget.
    /// It holds the inbox (`inbox`): what any priority left for the next tick, abort-all
    /// requests and whether the safety system queued notes; an atomic, as the safety task
    /// sits above the ceiling.
    pub(crate) safety: SafetyHandle,
    _control: PhantomData<fn(&C)>,
    _lock: PhantomData<L>,
}

// SAFETY: `state` is only reached through `Sequencer::borrow_state` (from `with`,
// `update_and_wake`, `park_in_then` and `close_lane`), and the cells of `lanes` only
// through `park_in_then` (a waker registered), `close_lane` (forgotten), `wake_lane` and
// the reads of a slot's identity (`check_lanes`, `lanes_of_polls_in_sections` and
// `State::lanes_of_polls`); all of them run under the lock, and a critical section keeps
// every other user of this sequencer out. The other fields are
// `Sync` themselves. `State` and `Lanes` are `Send` for every `C` (they hold only plain
// data, wakers and `fn(&C)` pointers). (`SingleThread`, which keeps no one out, has no
// such impl: its sequencers are not `Sync`.)
unsafe impl<C, const N: usize, const T: usize, const W: usize, const B: usize> Sync
    for Sequencer<C, N, T, CriticalSection, W, B>
{
}

// SAFETY: as for `CriticalSection`: the priority ceiling keeps out every user at or below
// it, and the caller of the `unsafe` constructor promised that no user runs above it.
#[cfg(feature = "cortex-m")]
unsafe impl<
        C,
        const N: usize,
        const T: usize,
        const PRIORITY: u8,
        const BITS: u8,
        const W: usize,
        const B: usize,
    > Sync for Sequencer<C, N, T, crate::lock::PriorityCeiling<PRIORITY, BITS>, W, B>
{
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> Default
    for Sequencer<C, N, T, CriticalSection, W, B>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize>
    Sequencer<C, N, T, CriticalSection, W, B>
{
    /// An empty sequencer guarded by critical sections; `const`, so it can be a `static`.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// static SEQ: Sequencer<(), 16> = Sequencer::new();
    /// assert!(SEQ.is_empty());
    /// ```
    pub const fn new() -> Self {
        Self::empty()
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize>
    Sequencer<C, N, T, crate::lock::SingleThread, W, B>
{
    /// An empty sequencer for one thread alone (host tests, the simulator): no lock, and
    /// not `Sync` ([`SingleThread`](crate::lock::SingleThread)).
    ///
    /// ```
    /// use rtseq::{lock::SingleThread, Sequencer};
    /// let seq: Sequencer<(), 4, 64, SingleThread> = Sequencer::single_thread();
    /// assert!(seq.is_empty());
    /// ```
    pub const fn single_thread() -> Self {
        Self::empty()
    }
}

#[cfg_attr(docsrs, doc(cfg(feature = "cortex-m")))]
#[cfg(feature = "cortex-m")]
impl<
        C,
        const N: usize,
        const T: usize,
        const PRIORITY: u8,
        const BITS: u8,
        const W: usize,
        const B: usize,
    > Sequencer<C, N, T, crate::lock::PriorityCeiling<PRIORITY, BITS>, W, B>
{
    /// An empty sequencer guarded by RTIC's priority ceiling instead of critical sections:
    /// no interrupt above the ceiling is ever masked by rtseq.
    ///
    /// # Safety
    ///
    /// `PRIORITY` must be the highest RTIC priority at which any method of this sequencer is
    /// called — normally the tick's — and no method other than [`abort_all`](Self::abort_all),
    /// [`safety_handle`](Self::safety_handle), [`safety_system`](Self::safety_system) and those of
    /// [`Sequences`](crate::safety::Sequences) may be called from above it.
    ///
    /// The tick runs at RTIC priority 2, the lanes at 1; the safety task at 3 only calls
    /// [`abort_all`](Self::abort_all) and, through its cycle, the sequencer's
    /// [`Sequences`](crate::safety::Sequences) methods, which take no lock:
    ///
    /// ```
    /// use rtseq::lock::PriorityCeiling;
    /// use rtseq::{SeqConfig, Sequencer};
    /// // SAFETY: no method but `abort_all`, `safety_handle`, `safety_system` and those of
    /// // `Sequences` is called above priority 2.
    /// static SEQ: Sequencer<(), 8, 64, PriorityCeiling<2>> =
    ///     unsafe { Sequencer::with_priority_ceiling() };
    /// fn init() { // RTIC `init` (priority 0 with interrupts off): register the tree
    ///     SEQ.register(SeqConfig::new("main")).unwrap();
    /// }
    /// fn safety_task() { // priority 3, above the ceiling
    ///     SEQ.abort_all();
    /// }
    /// # let _ = init; // sections raise BASEPRI: run on the chip only
    /// safety_task();
    /// ```
    pub const unsafe fn with_priority_ceiling() -> Self {
        Self::empty()
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    pub(crate) const fn empty() -> Self {
        const {
            assert!(
                N <= crate::MAX_SEQUENCES,
                "a sequencer holds at most MAX_SEQUENCES sequences and steps"
            )
        };
        const {
            assert!(
                N <= 32 * B,
                "the sets of a sequencer of N sequences need B = rtseq::set_words(N) words"
            )
        };
        const { assert!(W <= 32, "at most 32 lanes") };
        Sequencer {
            state: UnsafeCell::new(State::new()),
            lanes: Lanes::new(),
            ticking: AtomicBool::new(false),
            safety_notes: SafetyNotes::new(),
            safety: SafetyHandle::new(),
            _control: PhantomData,
            _lock: PhantomData,
        }
    }

    /// Runs `f` on the state inside a short section under the lock `L`.
    ///
    /// With [`borrow_state`](Self::borrow_state), which it calls, this is the crate's only
    /// access to the state. A `RefCell` would add a panic path (the "already borrowed"
    /// check) to every operation; instead exclusivity rests on two facts: the lock keeps
    /// every other context out, and no closure passed here calls `with` again or any
    /// foreign code that could — closures only touch the state. Wakers are woken by
    /// [`wake_lanes`](Self::wake_lanes) and [`update_and_wake`](Self::update_and_wake), and
    /// kept (cloned, dropped) by [`park_in_then`](Self::park_in_then) and forgotten by
    /// [`close_lane`](Self::close_lane), each after the state's borrow has ended. User code
    /// runs between sections: monitor conditions in the tick, a sequence's conditions and
    /// action in its lane's poll, cleanup hooks in the tick's teardowns or in a dropped
    /// run's.
    #[inline]
    pub(crate) fn with<R>(&self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> R) -> R {
        L::lock(|| self.borrow_state(f))
    }

    /// This sequencer's tag (what its sequence objects carry): tests that drive the port
    /// by hand pass it as a lane's or a blocking start's maker.
    #[cfg(test)]
    pub(crate) fn tag(&self) -> u16 {
        self.with(|s| s.tag)
    }

    /// Runs `f` on the state; the caller holds the lock. The borrow ends when `f` returns.
    #[inline(always)]
    fn borrow_state<R>(&self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> R) -> R {
        // SAFETY: only called under the lock `L` (by `with`, `update_and_wake`,
        // `park_in_then` and `close_lane`), which keeps every other context out (with `SingleThread` the
        // sequencer is not `Sync`: no other thread or interrupt reaches it), and `f` does
        // not re-enter (see `with`): this is the only reference to the state while it
        // lives.
        let state = unsafe { &mut *self.state.get() };
        f(state)
    }
}
