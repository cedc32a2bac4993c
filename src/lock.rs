//! How the sequencer keeps the tick and the lanes apart.
//!
//! Every access to the sequencer's state is one short section under a [`Lock`]:
//!
//! * [`CriticalSection`] (the default, [`Sequencer::new`]): the `critical-section` crate —
//!   interrupts masked on a single-core MCU, a global mutex on the host. Portable, but every
//!   section also delays interrupts that never touch the sequencer (e.g. the safety task).
//! * `PriorityCeiling` (feature `cortex-m`, `Sequencer::with_priority_ceiling`): RTIC's
//!   Stack Resource Policy. A section raises BASEPRI to the ceiling (the priority of the
//!   tick), so lanes and the tick exclude each other while every higher-priority interrupt —
//!   the safety task first — runs at once: rtseq then masks no interrupt globally (unless
//!   the tick runs at RTIC's highest priority, where RTIC too disables interrupts).
//! * [`SingleThread`] (`Sequencer::single_thread`): no lock, for a sequencer one thread
//!   uses alone (host tests, the simulator); such a sequencer is not `Sync`.
//!
//! [`Sequencer::new`]: crate::Sequencer::new

mod sealed {
    pub trait Sealed {}
}

/// A way to run a short section exclusively against every other user of one sequencer.
///
/// Sealed: rtseq's own implementations are the only ones, because the sequencer's soundness
/// rests on them.
///
/// A sequencer's lock is its type parameter `L`, [`CriticalSection`] by default:
///
/// ```
/// use rtseq::lock::{CriticalSection, Lock};
/// use rtseq::Sequencer;
/// fn capacity<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>(
///     _: &Sequencer<C, N, T, L, W, B>,
/// ) -> usize {
///     N
/// }
/// static SEQ: Sequencer<(), 8> = Sequencer::new();
/// let same: &Sequencer<(), 8, 64, CriticalSection, 8> = &SEQ;
/// assert_eq!(capacity(same), 8);
/// ```
///
/// No other crate can implement it:
///
/// ```compile_fail,E0277
/// struct NoLock;
/// impl rtseq::lock::Lock for NoLock {
///     const COARSE: bool = true;
///     fn lock<R>(f: impl FnOnce() -> R) -> R { f() }
/// }
/// ```
pub trait Lock: sealed::Sealed {
    /// True when a section holds off only the sequencer's own users (not every interrupt),
    /// so the tick may do a whole pass in one section instead of one per sequence.
    #[doc(hidden)]
    const COARSE: bool;

    /// Runs `f` with every other context that uses the sequencer kept out.
    #[doc(hidden)]
    fn lock<R>(f: impl FnOnce() -> R) -> R;
}

/// The default lock: a `critical-section` critical section.
///
/// ```
/// use rtseq::{lock::CriticalSection, Sequencer};
/// static SEQ: Sequencer<(), 4, 64, CriticalSection> = Sequencer::new();
/// ```
#[derive(Debug)]
pub struct CriticalSection;

impl sealed::Sealed for CriticalSection {}

impl Lock for CriticalSection {
    const COARSE: bool = false;

    #[inline]
    fn lock<R>(f: impl FnOnce() -> R) -> R {
        critical_section::with(|_| f())
    }
}

/// No lock at all, for a sequencer that one thread uses alone: host tests and the host
/// simulator ([`Sequencer::single_thread`](crate::Sequencer::single_thread)). A sequencer
/// with it is not `Sync`, so no other thread, and on a chip no interrupt (whose handlers
/// reach a sequencer only through a `static`, which must be `Sync`), can use it
/// meanwhile; within its thread, no section is ever entered from inside another (the
/// sequencer runs no foreign code inside a section).
///
/// ```
/// use rtseq::{lock::SingleThread, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 4, 64, SingleThread> = Sequencer::single_thread();
/// seq.register(SeqConfig::new("main")).unwrap();
/// assert_eq!(seq.len(), 1);
/// ```
///
/// It cannot be shared:
///
/// ```compile_fail,E0277
/// use rtseq::{lock::SingleThread, Sequencer};
/// static SEQ: Sequencer<(), 4, 64, SingleThread> = Sequencer::single_thread();
/// ```
#[derive(Debug)]
pub struct SingleThread;

impl sealed::Sealed for SingleThread {}

impl Lock for SingleThread {
    // Nothing else runs meanwhile: a whole pass in one section delays no one.
    const COARSE: bool = true;

    #[inline]
    fn lock<R>(f: impl FnOnce() -> R) -> R {
        f()
    }
}

/// RTIC's priority-ceiling lock for a sequencer whose highest user runs at RTIC priority
/// `PRIORITY` on a device with `NVIC_PRIO_BITS` priority bits (4 on STM32, the default).
///
/// A section does what RTIC does to lock a resource of that ceiling ([`Ceiling::of`]):
/// below RTIC's highest priority it raises BASEPRI, so that only the sequencer's users are
/// kept out; at the highest priority, which no BASEPRI value masks, it disables interrupts.
/// A priority or bit count RTIC does not accept is a compile error.
///
/// Only the sequencer's users at or below the ceiling are kept out, which is why a
/// sequencer with this lock is created with the `unsafe`
/// [`Sequencer::with_priority_ceiling`](crate::Sequencer::with_priority_ceiling). Its
/// contract (the "# Safety" of that constructor, and the first row of the table in
/// section 3, "Priorities and the lock", of `docs/firmware-guide.md`): above the ceiling,
/// only [`abort_all`](crate::Sequencer::abort_all),
/// [`safety_handle`](crate::Sequencer::safety_handle),
/// [`safety_system`](crate::Sequencer::safety_system) and the
/// [`Sequences`](crate::safety::Sequences) methods (those a safety system's `cycle` calls)
/// are called; they take no lock.
///
/// ```
/// use rtseq::lock::PriorityCeiling;
/// use rtseq::Sequencer;
/// // The tick runs at RTIC priority 2 on an STM32 (4 priority bits).
/// // SAFETY: no method but `abort_all`, `safety_handle`, `safety_system` and those of
/// // `Sequences` is called above priority 2.
/// static SEQ: Sequencer<(), 8, 64, PriorityCeiling<2>> =
///     unsafe { Sequencer::with_priority_ceiling() };
/// ```
#[cfg_attr(docsrs, doc(cfg(feature = "cortex-m")))]
#[cfg(feature = "cortex-m")]
#[derive(Debug)]
pub struct PriorityCeiling<const PRIORITY: u8, const NVIC_PRIO_BITS: u8 = 4>;

#[cfg(feature = "cortex-m")]
impl<const PRIORITY: u8, const NVIC_PRIO_BITS: u8> PriorityCeiling<PRIORITY, NVIC_PRIO_BITS> {
    /// The ceiling's section; evaluated by the compiler, so a bad pair does not compile.
    #[allow(clippy::panic)] // evaluated at compile time: a compile error, never a run-time panic
    const CEILING: Ceiling = match Ceiling::of(PRIORITY, NVIC_PRIO_BITS) {
        Some(c) => c,
        None => panic!("RTIC priorities are 1 ..= 2^NVIC_PRIO_BITS, with 2 ..= 8 priority bits"),
    };
}

#[cfg(feature = "cortex-m")]
impl<const PRIORITY: u8, const NVIC_PRIO_BITS: u8> sealed::Sealed
    for PriorityCeiling<PRIORITY, NVIC_PRIO_BITS>
{
}

#[cfg(feature = "cortex-m")]
impl<const PRIORITY: u8, const NVIC_PRIO_BITS: u8> Lock
    for PriorityCeiling<PRIORITY, NVIC_PRIO_BITS>
{
    // At the top priority a section masks every interrupt: keep those short.
    const COARSE: bool = matches!(Self::CEILING, Ceiling::Basepri(_));

    #[inline]
    fn lock<R>(f: impl FnOnce() -> R) -> R {
        match Self::CEILING {
            Ceiling::Basepri(basepri) => {
                let old = raise_basepri(basepri);
                let r = f();
                // SAFETY: restores the value read above, ending this section only; it cannot
                // end a section of an outer context (that one restores its own value on
                // return).
                unsafe { lower_basepri(old) };
                r
            }
            Ceiling::InterruptsDisabled => cortex_m::interrupt::free(|_| f()),
        }
    }
}

/// Writes BASEPRI back to `old` at the end of a section, without a barrier: raising needs
/// one, so that no instruction of the section runs at the old priority ([`raise_basepri`]
/// has it); lowering does not, because an interrupt the lower BASEPRI admits is taken at
/// most a few instructions later, never lost.
///
/// # Safety
///
/// Only to end a section begun by [`raise_basepri`], with the value it returned.
#[cfg(feature = "cortex-m")]
#[inline(always)]
unsafe fn lower_basepri(old: u8) {
    #[cfg(target_arch = "arm")]
    {
        // No `nomem`: the asm is a compiler barrier, so no access of the section moves
        // below it.
        // SAFETY: the caller's contract; `msr BASEPRI` touches no memory or stack.
        unsafe {
            core::arch::asm!("msr BASEPRI, {}", in(reg) old, options(nostack, preserves_flags))
        };
    }
    #[cfg(not(target_arch = "arm"))]
    // SAFETY: the caller's contract (cortex-m's host stub, for host builds of this feature).
    unsafe {
        cortex_m::register::basepri::write(old)
    };
}

/// Raises BASEPRI to `basepri` and returns the value before. Out of line: one copy for
/// every section of the sequencer.
#[cfg(feature = "cortex-m")]
#[inline(never)]
fn raise_basepri(basepri: u8) -> u8 {
    let old = cortex_m::register::basepri::read();
    // `basepri_max` only ever raises the priority: nested sections are free.
    cortex_m::register::basepri_max::write(basepri);
    old
}

/// How RTIC locks a resource whose ceiling is a given priority (what
/// `PriorityCeiling` does for the sequencer, feature `cortex-m`).
///
/// ```
/// use rtseq::lock::Ceiling;
/// assert_eq!(Ceiling::of(2, 4), Some(Ceiling::Basepri(0xE0)));
/// assert_eq!(Ceiling::of(1, 4), Some(Ceiling::Basepri(0xF0)));
/// // RTIC's highest priority: no BASEPRI value masks it.
/// assert_eq!(Ceiling::of(16, 4), Some(Ceiling::InterruptsDisabled));
/// assert_eq!(Ceiling::of(17, 4), None);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Ceiling {
    /// BASEPRI is raised to this value (never 0: BASEPRI 0 masks nothing).
    Basepri(u8),
    /// The ceiling is RTIC's highest priority: interrupts are disabled for the section.
    InterruptsDisabled,
}

impl Ceiling {
    /// The lock of RTIC logical priority `priority` on a device with `nvic_prio_bits`
    /// priority bits; `None` for a pair RTIC does not accept (priorities are
    /// `1 ..= 2^nvic_prio_bits`, the Cortex-M architecture has 2 to 8 priority bits).
    ///
    /// On a device with 3 priority bits (8 RTIC priorities):
    ///
    /// ```
    /// use rtseq::lock::Ceiling;
    /// assert_eq!(Ceiling::of(1, 3), Some(Ceiling::Basepri(0xE0)));
    /// assert_eq!(Ceiling::of(7, 3), Some(Ceiling::Basepri(0x20)));
    /// assert_eq!(Ceiling::of(8, 3), Some(Ceiling::InterruptsDisabled));
    /// assert_eq!(Ceiling::of(0, 3), None); // RTIC priorities start at 1
    /// assert_eq!(Ceiling::of(1, 1), None); // Cortex-M has 2 to 8 bits
    /// ```
    pub const fn of(priority: u8, nvic_prio_bits: u8) -> Option<Ceiling> {
        if nvic_prio_bits < 2 || nvic_prio_bits > 8 {
            return None;
        }
        let levels: u16 = 1 << nvic_prio_bits;
        let p = priority as u16;
        if p == 0 || p > levels {
            return None;
        }
        if p == levels {
            return Some(Ceiling::InterruptsDisabled);
        }
        // RTIC's `logical2hw`: the highest logical priority is the lowest hardware value,
        // kept in the register's top `nvic_prio_bits` bits. Non-zero: `p < levels`.
        Some(Ceiling::Basepri(
            ((levels - p) << (8 - nvic_prio_bits)) as u8,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::Ceiling;

    /// The hardware priority value of RTIC logical priority `p` (RTIC's own formula).
    fn hardware(p: u16, bits: u8) -> u16 {
        ((1u16 << bits) - p) << (8 - bits)
    }

    #[test]
    fn every_rtic_priority_is_excluded_by_its_ceiling_and_no_higher_one_is() {
        for bits in 2..=8u8 {
            let levels = 1u16 << bits;
            // RTIC priorities are `u8`: with 8 bits the highest is 255.
            for p in 1..=levels.min(255) {
                let ceiling = Ceiling::of(p as u8, bits);
                if p == levels {
                    assert_eq!(ceiling, Some(Ceiling::InterruptsDisabled), "{p}/{bits}");
                    continue;
                }
                assert!(
                    matches!(ceiling, Some(Ceiling::Basepri(_))),
                    "{p}/{bits}: {ceiling:?}"
                );
                let Some(Ceiling::Basepri(v)) = ceiling else {
                    continue;
                };
                assert_ne!(v, 0, "BASEPRI 0 masks nothing ({p}/{bits})");
                // An interrupt is masked when its hardware value is at or above BASEPRI.
                for q in 1..=levels.min(255) {
                    let masked = hardware(q, bits) >= u16::from(v);
                    assert_eq!(
                        masked,
                        q <= p,
                        "priority {q} under ceiling {p} ({bits} bits)"
                    );
                }
            }
            assert_eq!(Ceiling::of(0, bits), None);
            if levels < 256 {
                assert_eq!(Ceiling::of((levels + 1) as u8, bits), None);
            }
        }
        assert_eq!(Ceiling::of(1, 1), None);
        assert_eq!(Ceiling::of(1, 9), None);
        assert_eq!(Ceiling::of(16, 4), Some(Ceiling::InterruptsDisabled));
        assert_eq!(Ceiling::of(2, 4), Some(Ceiling::Basepri(0xE0)));
    }
}

/// For tests: the portable lock (one critical section per step) that runs a closure
/// before section `k` (counted from [`interleaved::at`]): a tick or a lane of higher
/// priority preempting an operation between two of its sections. `InterleavedCoarse` is
/// the same hook on a coarse lock (as RTIC's `PriorityCeiling`: an operation's steps in one
/// section); both count their sections in the same thread-locals.
#[cfg(test)]
pub(crate) mod interleaved {
    extern crate std;
    use std::boxed::Box;
    use std::cell::{Cell, RefCell};

    #[derive(Debug)]
    pub(crate) struct Interleaved;

    impl super::sealed::Sealed for Interleaved {}

    /// The coarse twin of [`Interleaved`] (`COARSE = true`): what RTIC's priority ceiling
    /// does below the top priority. A section taken inside another one (none is expected)
    /// is part of it: neither counted nor preceded by the closure.
    #[derive(Debug)]
    pub(crate) struct InterleavedCoarse;

    impl super::sealed::Sealed for InterleavedCoarse {}

    std::thread_local! {
        static TAKEN: Cell<usize> = const { Cell::new(0) };
        static AT: Cell<usize> = const { Cell::new(usize::MAX) };
        static BETWEEN: RefCell<Option<Box<dyn FnOnce()>>> = RefCell::new(None);
        /// The coarse sections open on this thread.
        static OPEN: Cell<usize> = const { Cell::new(0) };
    }

    /// The sections taken since the last [`at`].
    pub(crate) fn taken() -> usize {
        TAKEN.with(Cell::get)
    }

    /// From now on, `between` runs before section `k` (0: the next one).
    pub(crate) fn at(k: usize, between: impl FnOnce() + 'static) {
        TAKEN.with(|t| t.set(0));
        AT.with(|a| a.set(k));
        BETWEEN.with(|b| *b.borrow_mut() = Some(Box::new(between)));
    }

    /// Counts a section about to be taken and, if it is section `k`, runs the closure.
    fn next_section() {
        let k = TAKEN.with(|t| {
            let k = t.get();
            t.set(k + 1);
            k
        });
        if k == AT.with(|a| a.get()) {
            if let Some(between) = BETWEEN.with(|b| b.borrow_mut().take()) {
                between();
            }
        }
    }

    impl super::Lock for Interleaved {
        const COARSE: bool = false;

        fn lock<R>(f: impl FnOnce() -> R) -> R {
            next_section();
            critical_section::with(|_| f())
        }
    }

    /// Closes a coarse section, also when its closure panics.
    struct Open;

    impl Drop for Open {
        fn drop(&mut self) {
            OPEN.with(|o| o.set(o.get().saturating_sub(1)));
        }
    }

    impl super::Lock for InterleavedCoarse {
        const COARSE: bool = true;

        fn lock<R>(f: impl FnOnce() -> R) -> R {
            if OPEN.with(Cell::get) > 0 {
                return f();
            }
            next_section();
            OPEN.with(|o| o.set(o.get() + 1));
            let _open = Open;
            critical_section::with(|_| f())
        }
    }
}
