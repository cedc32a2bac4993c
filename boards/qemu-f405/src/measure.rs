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

use core::future::{poll_fn, Future};
use core::pin::{pin, Pin};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use core::task::Poll;

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

/// Instruction counts of single future polls, collected by [`join_measured`] while enabled
/// (a benchmark enables it for the ticks it wants, so other ticks are not slowed down).
pub struct PollCosts {
    on: AtomicBool,
    sum: AtomicU32,
    count: AtomicU32,
    max: AtomicU32,
}

impl PollCosts {
    /// Disabled, nothing recorded.
    pub const fn new() -> Self {
        PollCosts {
            on: AtomicBool::new(false),
            sum: AtomicU32::new(0),
            count: AtomicU32::new(0),
            max: AtomicU32::new(0),
        }
    }

    /// Measure the polls from now on (`true`) or not (`false`).
    pub fn enable(&self, on: bool) {
        self.on.store(on, Relaxed);
    }

    fn record(&self, n: u32) {
        self.sum.fetch_add(n, Relaxed);
        self.count.fetch_add(1, Relaxed);
        self.max.fetch_max(n, Relaxed);
    }

    /// Mean instructions per measured poll (0 if none).
    pub fn mean(&self) -> u32 {
        self.sum
            .load(Relaxed)
            .checked_div(self.count.load(Relaxed))
            .unwrap_or(0)
    }

    /// The most expensive measured poll.
    pub fn max(&self) -> u32 {
        self.max.load(Relaxed)
    }

    /// Number of measured polls.
    pub fn count(&self) -> u32 {
        self.count.load(Relaxed)
    }
}

impl Default for PollCosts {
    fn default() -> Self {
        Self::new()
    }
}

/// Polls `K` futures in one task forever (the "several futures joined in one task" form of
/// a lane): each wake-up of the task polls every future not yet finished, each poll measured
/// into `costs` while it is enabled.
pub async fn join_measured<F: Future, const K: usize>(futs: [F; K], costs: &PollCosts) -> ! {
    let mut futs = pin!(futs);
    let mut done = [false; K];
    poll_fn(|w| {
        // SAFETY: the array is pinned; its elements are never moved out of it.
        let all = unsafe { futs.as_mut().get_unchecked_mut() };
        for (f, d) in all.iter_mut().zip(done.iter_mut()).filter(|(_, d)| !**d) {
            // SAFETY: structural pinning of the array's elements.
            let f = unsafe { Pin::new_unchecked(f) };
            let ready = if costs.on.load(Relaxed) {
                let (n, p) = measure_with(|| f.poll(w));
                costs.record(n);
                p.is_ready()
            } else {
                f.poll(w).is_ready()
            };
            *d = ready;
        }
        Poll::<()>::Pending
    })
    .await;
    loop {
        core::future::pending::<()>().await;
    }
}
