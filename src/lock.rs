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
//!   the safety task first — runs at once: rtseq then masks no interrupt globally.
//!
//! [`Sequencer::new`]: crate::Sequencer::new

mod sealed {
    pub trait Sealed {}
}

/// A way to run a short section exclusively against every other user of one sequencer.
///
/// Sealed: rtseq's own implementations are the only ones, because the sequencer's soundness
/// rests on them.
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

/// RTIC's priority-ceiling lock: BASEPRI is raised to `BASEPRI` (the hardware value of the
/// tick's priority, see [`rtic_basepri`]) for the section.
///
/// Only the sequencer's users at or below the ceiling are kept out, which is why a
/// sequencer with this lock is created with the `unsafe`
/// [`Sequencer::with_priority_ceiling`](crate::Sequencer::with_priority_ceiling).
#[cfg_attr(docsrs, doc(cfg(feature = "cortex-m")))]
#[cfg(feature = "cortex-m")]
#[derive(Debug)]
pub struct PriorityCeiling<const BASEPRI: u8>;

#[cfg(feature = "cortex-m")]
impl<const BASEPRI: u8> sealed::Sealed for PriorityCeiling<BASEPRI> {}

#[cfg_attr(docsrs, doc(cfg(feature = "cortex-m")))]
#[cfg(feature = "cortex-m")]
impl<const BASEPRI: u8> Lock for PriorityCeiling<BASEPRI> {
    const COARSE: bool = true;

    #[inline]
    fn lock<R>(f: impl FnOnce() -> R) -> R {
        let old = raise_basepri::<BASEPRI>();
        let r = f();
        // SAFETY: restores the value read above, ending this section only; it cannot end a
        // section of an outer context (that one restores its own value on return).
        unsafe { lower_basepri(old) };
        r
    }
}

/// Writes BASEPRI back to `old` at the end of a section: `msr` alone (4 bytes at each of
/// the ≈ 70 section ends of a firmware), without the `isb` of
/// `cortex_m::register::basepri::write`. Raising needs the barrier, so that no instruction
/// of the section runs at the old priority ([`raise_basepri`] has it); lowering does not: an
/// interrupt the lower BASEPRI admits is taken at most a few instructions later, never lost
/// (FreeRTOS's Cortex-M4 port lowers BASEPRI the same way).
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

/// Raises BASEPRI to `BASEPRI` and returns the value before. Out of line: one copy instead
/// of ≈ 14 bytes at each of the sequencer's sections; the restore stays inline (one
/// instruction).
#[cfg(feature = "cortex-m")]
#[inline(never)]
fn raise_basepri<const BASEPRI: u8>() -> u8 {
    let old = cortex_m::register::basepri::read();
    // `basepri_max` only ever raises the priority: nested sections are free.
    cortex_m::register::basepri_max::write(BASEPRI);
    old
}

/// The BASEPRI value of RTIC logical priority `priority` on a device with `nvic_prio_bits`
/// priority bits (4 on STM32): what RTIC writes to lock a resource of that ceiling.
///
/// ```
/// assert_eq!(rtseq::lock::rtic_basepri(2, 4), 0xE0);
/// assert_eq!(rtseq::lock::rtic_basepri(1, 4), 0xF0);
/// ```
pub const fn rtic_basepri(priority: u8, nvic_prio_bits: u8) -> u8 {
    let levels: u16 = 1 << (nvic_prio_bits & 7);
    let p = priority as u16;
    let hw = levels.saturating_sub(p);
    let shift = 8u8.saturating_sub(nvic_prio_bits);
    ((hw << shift) & 0xFF) as u8
}
