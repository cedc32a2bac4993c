//! Instruction counting under QEMU `-icount shift=0`.
//!
//! With `-icount shift=0` every guest instruction advances the virtual clock by exactly
//! 1 ns, and QEMU's TIM2 counts at 1 GHz of virtual time, so the difference of two reads of
//! `TIM2.CNT` is the number of instructions executed between them (DWT.CYCCNT reads 0 in
//! QEMU, and would count cycles anyway).
//!
//! Measured fact (QEMU 7.2): TIM2's counter is *not* reset by its update events in QEMU; it
//! free-runs over 32 bits (wraps after 2^32 ns ≈ 4.3 s of virtual time) while the update
//! interrupt still fires every `ARR + 1` (+370) counts. So a region's count is the wrapping
//! difference of two reads, exact for regions below 2^32 instructions. (On silicon the
//! counter wraps at ARR; this helper is a QEMU tool.)
//!
//! The region runs in a critical section, so no interrupt (not even the tick) is counted.
//! The raw count includes the cost of the measurement itself ([`OVERHEAD`], checked by
//! `src/bin/bench.rs` and the QEMU test suite); use [`measure`] for net figures.
//!
//! Keep the optimiser honest: pass inputs through [`core::hint::black_box`] and consume
//! results the same way, otherwise a pure region may be moved out of it or folded away.

use crate::clock::tim2;

/// Instructions counted for an empty region (the second counter read: `ldr` of CNT, whose
/// address is already in a register); subtracted by [`measure`]. `src/bin/bench.rs` prints
/// it and the QEMU test suite checks it.
pub const OVERHEAD: u32 = 1;

#[inline(always)]
fn cnt() -> u32 {
    tim2().cnt().read().bits()
}

/// Runs `f` with interrupts masked and returns `(raw instruction count, f's result)`. The
/// raw count includes [`OVERHEAD`].
#[inline(always)]
pub fn measure_raw<R>(f: impl FnOnce() -> R) -> (u32, R) {
    critical_section::with(|_| {
        let start = cnt();
        let r = f();
        let end = cnt();
        (end.wrapping_sub(start), r)
    })
}

/// Instructions executed by `f` (net: [`OVERHEAD`] subtracted), and its result.
#[inline(always)]
pub fn measure_with<R>(f: impl FnOnce() -> R) -> (u32, R) {
    let (d, r) = measure_raw(f);
    (d.saturating_sub(OVERHEAD), r)
}

/// Instructions executed by `f` (net: [`OVERHEAD`] subtracted).
#[inline(always)]
pub fn measure(f: impl FnOnce()) -> u32 {
    measure_with(f).0
}
