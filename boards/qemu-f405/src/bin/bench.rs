//! Benchmarks in instructions (QEMU `-icount shift=0`: one TIM2 count = one instruction).
//!
//! Prints one `bench: NAME = N instructions` line per figure and exits 0. For now it proves
//! the method (empty region, straight-line code of known length, a counted loop, the tick
//! interrupt's own cost); the rtseq figures (tick with 1 and 8 running sequences × 4
//! monitors, a firing monitor, the longest critical section) are added here once the core
//! library's API settles. `./x bench` runs it.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

/// `n` iterations of a loop of known length: `subs` + `bne` = 2 instructions per iteration.
#[inline(never)]
fn counted_loop(n: u32) {
    if n == 0 {
        return;
    }
    // SAFETY: pure register arithmetic.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {n}, {n}, #1",
            "bne 1b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{board, counted_loop};
    use board::clock::TickTimer;
    use board::measure::{measure, measure_raw, OVERHEAD};
    use core::hint::black_box;
    use core::sync::atomic::{AtomicU32, Ordering};

    /// TIM2 counter value at the start of the tick handler (interrupt entry latency).
    static ENTRY_CNT: AtomicU32 = AtomicU32::new(0);
    /// Instructions of the last tick handler body.
    static TICK_COST: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        run::spawn().ok();
        (Shared {}, Local { timer })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[task(binds = TIM2, priority = 2, local = [timer])]
    fn tick(cx: tick::Context) {
        ENTRY_CNT.store(board::clock::tim2_count(), Ordering::Relaxed);
        let timer = cx.local.timer;
        let (n, _) = measure_raw(|| timer.on_interrupt());
        TICK_COST.store(n.saturating_sub(OVERHEAD), Ordering::Relaxed);
    }

    #[task(priority = 1)]
    async fn run(_: run::Context) {
        let (raw, ()) = measure_raw(|| ());
        defmt::info!(
            "bench: empty region raw = {=u32} instructions (measure::OVERHEAD = {=u32})",
            raw,
            OVERHEAD
        );
        let nops = measure(|| {
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
            cortex_m::asm::nop();
        });
        defmt::info!("bench: 10 x nop = {=u32} instructions", nops);
        let l1000 = measure(|| counted_loop(black_box(1000)));
        let l2000 = measure(|| counted_loop(black_box(2000)));
        defmt::info!(
            "bench: counted_loop(1000) = {=u32} instructions, counted_loop(2000) = {=u32}, per iteration = {=u32}",
            l1000,
            l2000,
            l2000.wrapping_sub(l1000) / 1000
        );
        // Longer than a tick: the counter keeps counting across update events (the masked
        // tick interrupts are lost meanwhile: keep measured regions short).
        let long = measure(|| counted_loop(black_box(1_500_000)));
        defmt::info!("bench: counted_loop(1500000) = {=u32} instructions", long);

        // The heartbeat itself: period in TIM2 counts, entry latency, handler cost.
        let mut prev = None;
        for _ in 0..3 {
            let t0 = board::clock::ticks();
            while board::clock::ticks() == t0 {
                cortex_m::asm::wfi();
            }
            let entry = ENTRY_CNT.load(Ordering::Relaxed);
            if let Some(p) = prev {
                defmt::info!(
                    "bench: tick period = {=u32} TIM2 counts",
                    entry.wrapping_sub(p)
                );
            }
            prev = Some(entry);
        }
        defmt::info!(
            "bench: TickTimer::on_interrupt = {=u32} instructions",
            TICK_COST.load(Ordering::Relaxed)
        );
        board::exit_success();
    }
}
