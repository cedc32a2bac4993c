//! Smoke firmware: the skeleton every rtseq firmware on this board follows.
//!
//! - `tick` (TIM2 update, 1 kHz, priority 2): the sequencer heartbeat. Advances the clock,
//!   wakes the safety task, then (later: `rtseq` tick) wakes the lanes.
//! - `safety` (priority 3, highest): one cycle per tick, woken first by `tick`; it preempts
//!   the rest of the tick at once. The slot for the safety system.
//! - `lane_main`, `lane_parallel` (priority 1): async software tasks ("lanes") that sleep on
//!   a signal until the tick wakes them; `lane_parallel` only every 10th tick.
//! - `idle`: `wfi`, so QEMU (`-icount sleep=off`) jumps straight to the next tick; it also
//!   ends the run once the tick has stopped and every task has gone back to sleep.
//!
//! Runs for 100 ticks (100 ms virtual time), prints the counts and exits 0. The QEMU test
//! suite (tests/qemu.rs) asserts the exact final line.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

/// Length of the run in ticks.
const RUN_TICKS: u32 = 100;
/// `lane_parallel` is woken every this many ticks.
const PARALLEL_EVERY: u32 = 10;

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX, CAN1_RX0])]
mod app {
    use super::{board, PARALLEL_EVERY, RUN_TICKS};
    use board::clock::{self, TickTimer};
    use board::signal::TickSignal;

    /// Tick → safety task.
    static TO_SAFETY: TickSignal = TickSignal::new();
    /// Tick → main lane.
    static TO_MAIN: TickSignal = TickSignal::new();
    /// Tick → parallel lane.
    static TO_PARALLEL: TickSignal = TickSignal::new();

    /// Counters shared between priorities (SRP locks for the lower ones).
    pub struct Stats {
        pub ticks: u32,
        pub safety_cycles: u32,
        pub main_wakes: u32,
        pub parallel_wakes: u32,
    }

    #[shared]
    struct Shared {
        stats: Stats,
    }

    #[local]
    struct Local {
        timer: TickTimer,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        // Spawning from init cannot fail (each task is spawned once, nothing runs yet);
        // `.ok()` keeps the no-panic proof free of an `unwrap`.
        safety::spawn().ok();
        lane_main::spawn().ok();
        lane_parallel::spawn().ok();
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        defmt::info!(
            "smoke: start, {=u32} ticks at {=u32} Hz",
            RUN_TICKS,
            clock::TICK_HZ
        );
        (
            Shared {
                stats: Stats {
                    ticks: 0,
                    safety_cycles: 0,
                    main_wakes: 0,
                    parallel_wakes: 0,
                },
            },
            Local { timer },
        )
    }

    /// Lowest priority: runs only when every task sleeps. Ends the run after the last tick,
    /// when all lanes have handled it.
    #[idle(shared = [stats])]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            // Check and sleep with interrupts masked: WFI still wakes on a pending interrupt,
            // and one that fires between the check and WFI cannot be missed.
            cortex_m::interrupt::disable();
            let (t, sc, mw, pw) = cx
                .shared
                .stats
                .lock(|s| (s.ticks, s.safety_cycles, s.main_wakes, s.parallel_wakes));
            if t >= RUN_TICKS {
                defmt::info!(
                    "smoke: done ticks={=u32} safety_cycles={=u32} main_wakes={=u32} parallel_wakes={=u32} now_us={=u64}",
                    t,
                    sc,
                    mw,
                    pw,
                    clock::now().as_ticks()
                );
                board::exit_success();
            }
            cortex_m::asm::wfi();
            // SAFETY: not inside a critical section of ours; RTIC uses BASEPRI, not PRIMASK.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    /// The heartbeat (later: `rtseq` tick, monitors and timeouts).
    #[task(binds = TIM2, priority = 2, shared = [stats], local = [timer])]
    fn tick(mut cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        // Safety first: this pends the priority-3 task, which preempts here and now.
        TO_SAFETY.signal(now);
        let n = cx.shared.stats.lock(|s| {
            s.ticks += 1;
            s.ticks
        });
        TO_MAIN.signal(now);
        if n % PARALLEL_EVERY == 0 {
            TO_PARALLEL.signal(now);
        }
        if n >= RUN_TICKS {
            cx.local.timer.stop();
        }
    }

    /// Slot for the safety system: highest priority, one cycle per tick.
    #[task(priority = 3, shared = [stats])]
    async fn safety(mut cx: safety::Context) {
        loop {
            let _now = TO_SAFETY.wait().await;
            cx.shared.stats.lock(|s| s.safety_cycles += 1);
        }
    }

    /// The main lane: woken every tick.
    #[task(priority = 1, shared = [stats])]
    async fn lane_main(mut cx: lane_main::Context) {
        loop {
            let now = TO_MAIN.wait().await;
            let wakes = cx.shared.stats.lock(|s| {
                s.main_wakes += 1;
                s.main_wakes
            });
            if wakes % 25 == 0 {
                defmt::info!("lane_main: wake {=u32} at {=u64} us", wakes, now.as_ticks());
            }
        }
    }

    /// A second lane with a slower period (every 10th tick).
    #[task(priority = 1, shared = [stats])]
    async fn lane_parallel(mut cx: lane_parallel::Context) {
        loop {
            let _now = TO_PARALLEL.wait().await;
            cx.shared.stats.lock(|s| s.parallel_wakes += 1);
        }
    }
}
