//! The sequencer heartbeat: TIM2 update interrupt at [`TICK_HZ`], and the monotonic time
//! counted by it.
//!
//! # Why `ARR = 1_000_000 - 1` gives 1 kHz
//! On a real STM32F405 (HSI 16 MHz, no PLL) TIM2 would count at 16 MHz and need
//! `PSC = 15, ARR = 999` for 1 kHz. QEMU's STM32F2xx/F4xx timer model counts at a fixed
//! 1 GHz (one count per nanosecond of virtual time) and, for the update interrupt, does
//! not honour the prescaler. So in QEMU: `PSC = 0`, `ARR = 1_000_000 - 1` → one update
//! every 1 000 000 ns = 1 ms. With `-icount shift=0` a nanosecond of virtual time is one
//! guest instruction, hence TIM2's counter doubles as an instruction counter
//! ([`crate::measure`]).
//!
//! Measured in QEMU 7.2 (`src/bin/bench.rs`): the update interrupt actually comes every
//! 1 000 370 ns (QEMU re-arms the alarm relative to the moment its callback ran), i.e. a
//! tick is 0.037 % longer than 1 ms of virtual time, and the counter is not reset by the
//! update (it free-runs over 32 bits). Neither matters to the sequencer: its time is the
//! tick count ([`now`]), exact by construction.
//!
//! # Time
//! [`TickTimer::on_interrupt`] (called first thing in the TIM2 ISR) counts ticks;
//! [`now`] is `ticks × 1000 µs`, a `fugit::Instant<u64, 1, 1_000_000>`. This is the only
//! time base of the sequencer: it advances exactly once per tick, so host simulation and
//! QEMU agree to the microsecond. [`now_fine`] adds the position of TIM2 inside the
//! current tick (for log timestamps only).

use core::cell::Cell;
use critical_section::Mutex;

use crate::pac;

/// Heartbeat frequency.
pub const TICK_HZ: u32 = 1_000;
/// Counting frequency of TIM2–5 in QEMU (fixed, whatever the prescaler says).
pub const TIMER_HZ: u32 = 1_000_000_000;
/// Counts per tick (= instructions per tick under `-icount shift=0`).
pub const COUNTS_PER_TICK: u32 = TIMER_HZ / TICK_HZ;
/// Auto-reload value of TIM2.
pub const ARR: u32 = COUNTS_PER_TICK - 1;

/// Sequencer time: microseconds since reset (a non-wrapping `u64` timeline, hence fugit's
/// `Monotonic` kind: `Ord`, plain comparisons).
pub type Instant = fugit::MonotonicTimerInstantU64<1_000_000>;
/// Sequencer durations in microseconds.
pub type Duration = fugit::MicrosDurationU64;
/// Length of one tick.
pub const TICK: Duration = Duration::from_ticks(1_000_000 / TICK_HZ as u64);

/// Ticks since the timer was started. Written only by the TIM2 ISR; a `u64` cannot be
/// read atomically on Cortex-M4, so reads take a critical section of a few instructions.
static TICKS: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));
/// TIM2 counter when the last tick was counted (for [`now_fine`]).
static LAST_TICK_CNT: Mutex<Cell<u32>> = Mutex::new(Cell::new(0));

/// Number of ticks since [`TickTimer::start`].
#[inline]
pub fn ticks() -> u64 {
    critical_section::with(|cs| TICKS.borrow(cs).get())
}

/// Current sequencer time (advances by [`TICK`] in each TIM2 interrupt).
#[inline]
pub fn now() -> Instant {
    Instant::from_ticks(ticks().wrapping_mul(TICK.as_ticks()))
}

/// [`now`] plus the microseconds elapsed inside the current tick (read from TIM2). Used for
/// log timestamps; never for sequencer decisions.
pub fn now_fine() -> Instant {
    let (ticks, since_tick, pending) = critical_section::with(|cs| {
        let tim = tim2();
        let cnt = tim.cnt().read().bits();
        // An update that happened but was not yet counted by the ISR (we may be running
        // inside a higher-priority task, or with interrupts masked).
        let pending = tim.sr().read().uif().bit_is_set();
        (
            TICKS.borrow(cs).get(),
            cnt.wrapping_sub(LAST_TICK_CNT.borrow(cs).get()),
            pending,
        )
    });
    let (ticks, us_in_tick) = if pending {
        (ticks.wrapping_add(1), 0)
    } else {
        (
            ticks,
            u64::from(since_tick / (TIMER_HZ / 1_000_000)).min(TICK.as_ticks() - 1),
        )
    };
    Instant::from_ticks(ticks.wrapping_mul(TICK.as_ticks()).wrapping_add(us_in_tick))
}

/// Current TIM2 counter (0..=[`ARR`]; instructions since the last tick under
/// `-icount shift=0`).
#[inline(always)]
pub fn tim2_count() -> u32 {
    tim2().cnt().read().bits()
}

/// Shared read-only view of TIM2 (used for [`now_fine`] and [`crate::measure`]). Only
/// status and counter registers are read through it; TIM2 is owned by [`TickTimer`].
#[inline(always)]
pub(crate) fn tim2() -> &'static pac::tim2::RegisterBlock {
    // SAFETY: TIM2 lives at a fixed address for the whole program; we only read CNT/SR.
    unsafe { &*pac::TIM2::ptr() }
}

/// Owner of TIM2, the heartbeat timer. Put it in the `#[local]` resources of the task bound
/// to `TIM2` and call [`TickTimer::on_interrupt`] first thing there.
pub struct TickTimer {
    tim: pac::TIM2,
}

impl TickTimer {
    /// Enables TIM2 (RCC), sets 1 kHz update interrupts and starts counting from 0.
    /// The NVIC line is unmasked by RTIC because a task is bound to `TIM2`.
    pub fn start(tim: pac::TIM2, rcc: &pac::RCC) -> Self {
        // QEMU has no RCC model (the write is ignored); on silicon this clocks TIM2.
        rcc.apb1enr().modify(|_, w| w.tim2en().set_bit());
        tim.cr1().write(|w| w.cen().clear_bit());
        tim.psc().write(|w| w.psc().set(0));
        tim.arr().write(|w| w.arr().set(ARR));
        tim.cnt().write(|w| w.cnt().set(0));
        // Load PSC/ARR now (update generation), then drop the flag that this raised.
        tim.egr().write(|w| w.ug().set_bit());
        tim.sr().write(|w| w.uif().clear());
        critical_section::with(|cs| TICKS.borrow(cs).set(0));
        tim.dier().write(|w| w.uie().set_bit());
        tim.cr1().write(|w| w.cen().set_bit());
        Self { tim }
    }

    /// Acknowledges the update interrupt and advances the time by one tick. Returns the new
    /// [`now`]. A spurious call (no update pending) does not advance the time.
    #[inline]
    pub fn on_interrupt(&mut self) -> Instant {
        let sr = self.tim.sr().read();
        let cnt = self.tim.cnt().read().bits();
        let ticks = critical_section::with(|cs| {
            let cell = TICKS.borrow(cs);
            let t = cell.get().wrapping_add(u64::from(sr.uif().bit_is_set()));
            cell.set(t);
            LAST_TICK_CNT.borrow(cs).set(cnt);
            t
        });
        if sr.uif().bit_is_set() {
            self.tim.sr().write(|w| w.uif().clear());
        }
        Instant::from_ticks(ticks.wrapping_mul(TICK.as_ticks()))
    }

    /// Stops the heartbeat (no further TIM2 interrupts).
    pub fn stop(&mut self) {
        self.tim.dier().write(|w| w.uie().clear_bit());
        self.tim.cr1().write(|w| w.cen().clear_bit());
    }
}
