//! The lock-free, shared part of the safety system.

use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use super::bits::bit_of;
use super::context::OutOfRange;
use super::event::{EventId, PublicEvent};
use super::level::SafetyLevel;

/// The bit of [`SafetyHandle::inbox`] by which the safety system asks for abort-all.
pub(crate) const ABORT_ALL_BY_SAFETY_SYSTEM: u8 = 2;

/// The shared, lock-free part of the safety system: lower-priority code
/// (sequences, conditions, other tasks) triggers public events and reads
/// the current level through a plain `&SafetyHandle`, while the
/// highest-priority safety task owns the [`SafetySystem`](super::SafetySystem)
/// and runs its cycle.
///
/// A [`Sequencer`](crate::Sequencer) holds one
/// ([`safety_handle`](crate::Sequencer::safety_handle)): build its safety
/// system on that one. A handle of its own, as in the examples below, is
/// for a safety system without a sequencer.
///
/// Everything is a single atomic operation (no lock, no critical
/// section): triggering is one `fetch_or` on a 32-bit pending-event
/// bitmask, reading the level is one load. Triggering the same event
/// several times before the next cycle counts once (an id ≥ 32, which has
/// no bit, is an unknown event at each trigger). Needs 8- and 32-bit
/// atomics with compare-and-swap (Cortex-M3 and up).
///
/// Const-constructible, so it lives in a `static`:
///
/// ```
/// use rtseq::safety::{PublicEvent, SafetyHandle, SafetyLevel};
/// static SAFETY: SafetyHandle = SafetyHandle::new();
/// const START: PublicEvent = PublicEvent::new(0);
///
/// // In a sequence (any priority):
/// SAFETY.trigger(START);
/// let ready = SAFETY.level() >= SafetyLevel::new(2);
/// # let _ = ready;
/// ```
///
/// # Binding, and a `static` handle in tests
///
/// A handle serves one [`SafetySystem`](super::SafetySystem) at a time:
/// building a system binds it, a second system on the same handle is an
/// `Err(SafetyError::HandleInUse)` while the first is alive. Dropping the
/// system releases the handle and returns it to the state of
/// [`new`](Self::new): no pending events, level 0, cycle count 0. So one
/// `static` handle serves one test after another in the same test binary.
/// Tests that run *at the same time* (the test harness runs them on
/// several threads) cannot share it; serialize them, e.g. with a mutex:
///
/// ```
/// use std::sync::Mutex;
/// use rtseq::safety::*;
/// # struct Io;
/// # impl SafetyIo for Io {
/// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
/// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
/// # }
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// static PROPS: SafetyProperties<'static, Io, 1> =
///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
/// static SAFETY: SafetyHandle = SafetyHandle::new();
/// static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
///
/// fn a_test() -> Result<(), SafetyError> {
///     let _serial = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
///     let mut safety = SafetySystem::new(&PROPS, &SAFETY)?;
///     safety.cycle(&mut Io, &NoSequences);
///     SAFETY.trigger(PublicEvent::new(3)); // left pending at the end of the test
///     assert_eq!(SAFETY.cycles(), 1);
///     Ok(())
/// } // `safety` dropped here: SAFETY is released and reset
///
/// a_test()?;
/// assert!(!SAFETY.is_bound());
/// assert_eq!((SAFETY.cycles(), SAFETY.pending_events()), (0, 0));
/// a_test()?; // the next test starts from a fresh handle
/// # Ok::<(), SafetyError>(())
/// ```
///
/// Only public events can be triggered here; a private event does not
/// compile:
///
/// ```compile_fail,E0308
/// use rtseq::safety::{PrivateEvent, SafetyHandle};
/// static SAFETY: SafetyHandle = SafetyHandle::new();
/// const EMERGENCY: PrivateEvent = PrivateEvent::new(0);
/// SAFETY.trigger(EMERGENCY); // expected `SafetyEvent<Public>`, found `SafetyEvent<Private>`
/// ```
#[derive(Debug)]
pub struct SafetyHandle {
    /// What the sequencer holding this handle is asked to do at its next tick, as bits:
    /// [`ABORT_ALL_BY_SAFETY_SYSTEM`], raised by the cycle of the system built on the
    /// handle, whatever [`Sequences`](super::Sequences) the cycle is given; the other bits
    /// are the sequencer's own (`sequencer::inbox`). Unread in a handle of its own.
    pub(crate) inbox: AtomicU8,
    pending: AtomicU32,
    level: AtomicU8,
    bound: AtomicBool,
    cycles: AtomicU32,
    /// Public events out of range since the last cycle: their count (saturating at
    /// 2^24 - 1) above the last one's index, in one word, so that a cycle takes the pair a
    /// trigger left (one of higher priority between the two halves of a trigger of two
    /// words would have named its own event beside the other's count).
    unknown: AtomicU32,
}

/// The most out-of-range public events a handle counts between two cycles.
const UNKNOWN_MAX: u32 = (1 << 24) - 1;

impl SafetyHandle {
    /// A handle with no pending events, level 0 (the safest) until a
    /// [`SafetySystem`](super::SafetySystem) is built on it, which
    /// publishes its entry level.
    ///
    /// ```
    /// use rtseq::safety::{SafetyHandle, SafetyLevel};
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// assert_eq!(SAFETY.level(), SafetyLevel::SAFEST);
    /// ```
    pub const fn new() -> Self {
        Self {
            inbox: AtomicU8::new(0),
            pending: AtomicU32::new(0),
            level: AtomicU8::new(0),
            bound: AtomicBool::new(false),
            cycles: AtomicU32::new(0),
            unknown: AtomicU32::new(0),
        }
    }

    /// Triggers a public event; the safety system resolves it against its
    /// level at the start of its next cycle. Lock-free, wait-free on
    /// Cortex-M (one `LDREX`/`STREX` loop), callable from any priority.
    ///
    /// An event with an id `>= 32` cannot be in any valid table; it is
    /// counted as an unknown event in the next cycle (each trigger, up to
    /// 2^24 - 1 between two cycles).
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyHandle};
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// SAFETY.trigger(PublicEvent::new(2));
    /// assert_eq!(SAFETY.pending_events(), 1 << 2);
    /// ```
    pub fn trigger(&self, event: PublicEvent) {
        let index = event.id().index();
        let bit = bit_of(usize::from(index));
        if bit == 0 {
            // Lock-free: retried only when a trigger of higher priority came in between.
            let counted = |word: u32| {
                let count = (word >> 8).saturating_add(1).min(UNKNOWN_MAX);
                Some(count << 8 | u32::from(index))
            };
            let _ = self
                .unknown
                .fetch_update(Ordering::Release, Ordering::Relaxed, counted);
        } else {
            self.pending.fetch_or(bit, Ordering::Release);
        }
    }

    /// The current safety level (as of the last applied transition).
    ///
    /// ```
    /// use rtseq::safety::{SafetyHandle, SafetyLevel};
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// let moving_allowed = SAFETY.level() >= SafetyLevel::new(3);
    /// assert!(!moving_allowed);
    /// ```
    pub fn level(&self) -> SafetyLevel {
        SafetyLevel::new(self.level.load(Ordering::Acquire))
    }

    /// Public events triggered but not yet consumed by a cycle (bit `i` =
    /// public event `i`).
    ///
    /// ```
    /// use rtseq::safety::SafetyHandle;
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// assert_eq!(SAFETY.pending_events(), 0);
    /// ```
    pub fn pending_events(&self) -> u32 {
        self.pending.load(Ordering::Acquire)
    }

    /// Number of safety cycles run so far (wraps), e.g. to wait "one
    /// safety cycle" after triggering an event.
    ///
    /// ```
    /// use rtseq::safety::SafetyHandle;
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// assert_eq!(SAFETY.cycles(), 0);
    /// ```
    pub fn cycles(&self) -> u32 {
        self.cycles.load(Ordering::Acquire)
    }

    /// Whether a [`SafetySystem`](super::SafetySystem) currently owns the
    /// handle (from its construction until it is dropped).
    ///
    /// ```
    /// use rtseq::safety::SafetyHandle;
    /// static SAFETY: SafetyHandle = SafetyHandle::new();
    /// assert!(!SAFETY.is_bound());
    /// ```
    pub fn is_bound(&self) -> bool {
        self.bound.load(Ordering::Acquire)
    }

    pub(crate) fn bind(&self) -> bool {
        self.bound
            .compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
    }

    /// Back to the state of [`new`](Self::new), then unbound: called by the
    /// owning system's `Drop` only, so no other system writes the handle
    /// meanwhile (the binding is given up last). The inbox is the holding
    /// sequencer's and is left to it. An event triggered while
    /// the reset runs may be kept for the next system or dropped; nothing
    /// was bound to resolve it.
    pub(crate) fn release(&self) {
        self.pending.store(0, Ordering::Relaxed);
        self.unknown.store(0, Ordering::Relaxed);
        self.cycles.store(0, Ordering::Relaxed);
        self.level
            .store(SafetyLevel::SAFEST.id(), Ordering::Relaxed);
        self.bound.store(false, Ordering::Release);
    }

    /// Asks the sequencer holding this handle to abort every sequence at its next tick.
    pub(crate) fn request_abort_all(&self) {
        self.inbox
            .fetch_or(ABORT_ALL_BY_SAFETY_SYSTEM, Ordering::Release);
    }

    pub(crate) fn publish_level(&self, level: SafetyLevel) {
        self.level.store(level.id(), Ordering::Release);
    }

    pub(crate) fn count_cycle(&self) {
        // Only the owning SafetySystem writes; load + store is enough.
        let n = self.cycles.load(Ordering::Relaxed).wrapping_add(1);
        self.cycles.store(n, Ordering::Release);
    }

    /// Whether public events wait for the next cycle.
    #[inline(always)]
    pub(crate) fn has_pending(&self) -> bool {
        self.pending.load(Ordering::Relaxed) != 0
    }

    /// Takes the pending public events (only when something is pending:
    /// the common cycle peeks with [`has_pending`](Self::has_pending)).
    pub(crate) fn take_pending(&self) -> u32 {
        self.pending.swap(0, Ordering::Acquire)
    }

    /// Whether out-of-range public events wait for the next cycle.
    #[inline(always)]
    pub(crate) fn has_out_of_range(&self) -> bool {
        self.unknown.load(Ordering::Relaxed) != 0
    }

    /// The out-of-range public events since the last call, if any.
    pub(crate) fn take_out_of_range(&self) -> Option<OutOfRange> {
        let word = self.unknown.swap(0, Ordering::Acquire);
        let count = word >> 8;
        (count != 0).then_some(OutOfRange {
            count,
            last: EventId::public(word as u8),
        })
    }
}

impl Default for SafetyHandle {
    fn default() -> Self {
        Self::new()
    }
}
