//! How the tick's cost follows the running sequences, not the registered ones: the same
//! running workload in sequencers of 8, 32, 64 and 256 sequences (instructions under QEMU
//! `-icount shift=0`, as `bench_seq`).
//!
//! Each sequencer has `N` registered sequences; the last 8 (or the last one) are started in
//! declared lanes, each with 4 rising-edge monitors on flags that stay false, 1 ms polling,
//! and ticked every millisecond, so every tick is due. The lanes are never polled: the
//! figure is the tick alone (monitor evaluation, polling classes, timeouts), without the
//! exit-condition wake-ups that `bench_seq`'s 8 × 4 figure includes. Started last, the
//! running sequences sit in the sets' last word: the worst place for a multi-word set.
//!
//! Then one more tick in which the last running sequence's last monitor fires
//! (`AbortOwner`): the teardown's cost against the number registered.
//!
//! `cargo fw-run bench_scale`; `./x bench` prints it; `tests/qemu_scenarios.rs` prints the
//! figures and checks them.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

/// `"s000"` .. `"s255"`: unique sequence names.
const NAMES: [[u8; 4]; 256] = {
    let mut names = [[0u8; 4]; 256];
    let mut i = 0;
    while i < 256 {
        names[i] = [
            b's',
            b'0' + (i / 100) as u8,
            b'0' + (i / 10 % 10) as u8,
            b'0' + (i % 10) as u8,
        ];
        i += 1;
    }
    names
};

#[rtic::app(device = rtseq_qemu_f405::pac)]
mod app {
    use super::{board, NAMES};
    use board::clock::TickTimer;
    use board::measure::measure_with;
    use core::mem::size_of;
    use rtseq::lock::Lock;
    use rtseq::{Behaviour, Duration, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    use rtseq_scenarios::{Ctrl, FlagCond};

    /// Flag 8 stays false: the monitors never fire.
    const QUIET: u8 = 8;
    /// Flag 7, set for one tick after the steady ones: the last monitor of the last
    /// running sequence watches it and fires (`AbortOwner`).
    const FAULT: u8 = 7;
    /// Ticks per measurement; the first ones start the runs' edge detection.
    const TICKS: u64 = 12;
    const STEADY_FROM: u64 = 4;

    static CTRL: Ctrl = Ctrl::new();

    /// The lock of `bench_seq`'s figures: RTIC's priority ceiling, or with the board
    /// feature `critical-section-lock` the portable default.
    #[cfg(not(feature = "critical-section-lock"))]
    type Lk = rtseq::lock::PriorityCeiling<2>;
    #[cfg(feature = "critical-section-lock")]
    type Lk = rtseq::lock::CriticalSection;

    #[cfg(not(feature = "critical-section-lock"))]
    macro_rules! sequencer {
        // SAFETY: these sequencers are used only from `idle` (priority 0, below the
        // ceiling 2); no task touches them.
        () => {
            unsafe { Sequencer::with_priority_ceiling() }
        };
    }
    #[cfg(feature = "critical-section-lock")]
    macro_rules! sequencer {
        () => {
            Sequencer::new()
        };
    }

    static S8: Sequencer<Ctrl, 8, 64, Lk> = sequencer!();
    static S32: Sequencer<Ctrl, 32, 64, Lk> = sequencer!();
    static S64: Sequencer<Ctrl, 64, 64, Lk, 8, 2> = sequencer!();
    static S256: Sequencer<Ctrl, 256, 64, Lk, 8, 8> = sequencer!();
    static S32_ONE: Sequencer<Ctrl, 32, 64, Lk> = sequencer!();
    static S8_ONE: Sequencer<Ctrl, 8, 64, Lk> = sequencer!();
    static S256_ONE: Sequencer<Ctrl, 256, 64, Lk, 8, 8> = sequencer!();

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        _timer: TickTimer,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (Shared {}, Local { _timer: timer })
    }

    /// Registers `N` sequences in `seq` and starts the last `running` of them, each with 4
    /// quiet monitors in `monitors`.
    fn set_up<const N: usize, L: Lock, const B: usize>(
        seq: &'static Sequencer<Ctrl, N, 64, L, 8, B>,
        running: usize,
        monitors: &mut Monitors<'static, Ctrl, 32, FlagCond>,
    ) -> Result<(), rtseq::Error> {
        let every_ms = Duration::from_millis(1);
        for (i, name) in NAMES.iter().enumerate().take(N) {
            let name = core::str::from_utf8(name).map_err(|_| rtseq::Error::EmptyName)?;
            let config = SeqConfig::new(name).polling(every_ms);
            if i + running < N {
                seq.register(config)?;
                continue;
            }
            let run = seq.add(config, ())?;
            for k in 0..4 {
                let flag = if i + 1 == N && k == 3 { FAULT } else { QUIET };
                monitors.add(
                    run.id(),
                    Monitor::with_condition("quiet", FlagCond { flag }, Behaviour::AbortOwner),
                )?;
            }
            let handle = seq
                .sequence_by_id(run.id())
                .ok_or(rtseq::Error::UnknownSequence(run.id()))?;
            handle.declare_lane()?;
            handle.start()?;
        }
        Ok(())
    }

    /// The most instructions of one steady due tick.
    fn steady_tick<const N: usize, L: Lock, const B: usize>(
        seq: &'static Sequencer<Ctrl, N, 64, L, 8, B>,
        monitors: &mut Monitors<'static, Ctrl, 32, FlagCond>,
    ) -> u32 {
        let mut most = 0;
        for ms in 1..=TICKS {
            let now = Instant::from_ticks(ms * 1_000);
            let (cost, ticked) = measure_with(|| seq.tick(now, &CTRL, monitors));
            if let Err(e) = ticked {
                defmt::error!("bench_scale: tick: {}", e);
                board::exit_failure();
            }
            if ms >= STEADY_FROM {
                most = most.max(cost);
            }
        }
        most
    }

    /// The stack one more steady tick uses, in bytes.
    #[inline(never)]
    fn steady_stack<const N: usize, L: Lock, const B: usize>(
        seq: &'static Sequencer<Ctrl, N, 64, L, 8, B>,
        monitors: &mut Monitors<'static, Ctrl, 32, FlagCond>,
    ) -> Result<usize, rtseq::Error> {
        let now = Instant::from_ticks((TICKS + 1) * 1_000);
        let mut ticked = Ok(());
        let bytes = board::stack::deepest(&mut || ticked = seq.tick(now, &CTRL, monitors));
        ticked.map(|()| bytes)
    }

    /// One more tick, in which the last running sequence's fault monitor fires (out of
    /// line: the steady ticks' measurement stays as it is without it): its instructions
    /// and the bytes of stack it uses.
    #[inline(never)]
    fn firing_tick<const N: usize, L: Lock, const B: usize>(
        seq: &'static Sequencer<Ctrl, N, 64, L, 8, B>,
        monitors: &mut Monitors<'static, Ctrl, 32, FlagCond>,
    ) -> Result<(u32, usize), rtseq::Error> {
        CTRL.set(FAULT, true);
        let now = Instant::from_ticks((TICKS + 2) * 1_000);
        let (mut firing, mut ticked) = (0, Ok(()));
        let bytes = board::stack::deepest(&mut || {
            (firing, ticked) = measure_with(|| seq.tick(now, &CTRL, monitors));
        });
        CTRL.set(FAULT, false);
        ticked.map(|()| (firing, bytes))
    }

    /// Sets up, ticks and prints one figure.
    fn figure<const N: usize, L: Lock, const B: usize>(
        seq: &'static Sequencer<Ctrl, N, 64, L, 8, B>,
        running: usize,
    ) -> Result<u32, rtseq::Error> {
        let mut monitors = Monitors::new();
        set_up(seq, running, &mut monitors)?;
        let cost = steady_tick(seq, &mut monitors);
        defmt::info!(
            "bench_scale: tick {=usize} x 4 due, {=usize} registered = {=u32} instructions",
            running,
            N,
            cost
        );
        let steady_bytes = steady_stack(seq, &mut monitors)?;
        let (firing, firing_bytes) = firing_tick(seq, &mut monitors)?;
        defmt::info!(
            "bench_scale: firing tick (AbortOwner), {=usize} running, {=usize} registered = {=u32} instructions",
            running,
            N,
            firing
        );
        defmt::info!(
            "bench_scale: stack, {=usize} running, {=usize} registered: due tick {=usize} B, firing tick {=usize} B",
            running,
            N,
            steady_bytes,
            firing_bytes
        );
        Ok(cost)
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        let run = || -> Result<(), rtseq::Error> {
            let base = figure(&S8, 8)?;
            figure(&S32, 8)?;
            figure(&S64, 8)?;
            let big = figure(&S256, 8)?;
            figure(&S8_ONE, 1)?;
            figure(&S32_ONE, 1)?;
            figure(&S256_ONE, 1)?;
            // Rounded to the nearest per cent.
            defmt::info!(
                "bench_scale: 256 registered / 8 registered, 8 x 4 due = {=u32} %",
                (big.saturating_mul(100) + base / 2) / base.max(1)
            );
            defmt::info!(
                "bench_scale: size Sequencer<Ctrl, N, 64> N = 8: {=usize} B, 32: {=usize} B, 64 (B = 2): {=usize} B, 256 (B = 8): {=usize} B",
                size_of::<Sequencer<Ctrl, 8, 64, Lk>>(),
                size_of::<Sequencer<Ctrl, 32, 64, Lk>>(),
                size_of::<Sequencer<Ctrl, 64, 64, Lk, 8, 2>>(),
                size_of::<Sequencer<Ctrl, 256, 64, Lk, 8, 8>>()
            );
            Ok(())
        };
        match run() {
            Ok(()) => board::exit_success(),
            Err(e) => {
                defmt::error!("bench_scale: setup failed: {}", e);
                board::exit_failure()
            }
        }
    }
}
