//! Demo firmware (placeholder until the motor-controller demo replaces it): the heartbeat and
//! one lane, with readable logs, for one second of virtual time. `./x demo` runs it.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::board;
    use board::clock::{self, TickTimer};
    use board::signal::TickSignal;

    static TO_LANE: TickSignal = TickSignal::new();

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        defmt::info!(
            "demo: rtseq heartbeat at {=u32} Hz on the emulated STM32F405",
            clock::TICK_HZ
        );
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        lane::spawn().ok();
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
        TO_LANE.signal(cx.local.timer.on_interrupt());
    }

    #[task(priority = 1)]
    async fn lane(_: lane::Context) {
        let mut wakes: u32 = 0;
        loop {
            let now = TO_LANE.wait().await;
            wakes += 1;
            if wakes % 100 == 0 {
                defmt::info!(
                    "demo: lane woke {=u32} times, t = {=u64} ms",
                    wakes,
                    now.as_ticks() / 1000
                );
            }
            if wakes >= 1000 {
                defmt::info!("demo: done");
                board::exit_success();
            }
        }
    }
}
