//! Safety firmware (issue 4): the rtseq safety system in the highest-priority RTIC task of
//! the emulated STM32F405, running the scenario of `safety/scenario.rs` (8 levels, 8
//! critical inputs and outputs: a transition chain, two and three events in one cycle, an
//! unknown event, an input range fault re-triggering while it lasts, outputs with `set`,
//! `leave` and `toggle`, an emergency with abort-all), and checking itself.
//!
//! - `safety` (priority 3, highest): one safety cycle per 1 kHz tick, woken first by the
//!   tick; applies the plant stimuli of the script (input values, private-event requests),
//!   runs `SafetySystem::cycle`, logs the canonical record of the cycle (the host test
//!   compares it with the same scenario run on the host) and its timing: the latency from
//!   the tick interrupt to the cycle and the cycle's cost, in instructions (TIM2 under
//!   `-icount shift=0`).
//! - `tick` (TIM2, priority 2): the heartbeat.
//! - `lane` (priority 1): what a sequence does: triggers the script's public events through
//!   the lock-free `SafetyHandle` one tick before the cycle that resolves them; at tick 12 it
//!   runs a long computation (≈ 3.3 M instructions = 3.3 ms) during which the safety task
//!   must still run cycles 13, 14 and 15 on time: it preempts the lane.
//! - `init` also measures the figures of the README: instructions of one cycle with 8
//!   levels, 8 inputs, 8 outputs, with and without a transition.
//!
//! Exit 0 when every expectation holds, 1 otherwise. Links with `--features no-panic`.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

#[path = "safety/scenario.rs"]
mod scenario;

/// The lane starts its long computation when woken by this tick.
const BUSY_AT_TICK: u64 = 12;
/// Iterations of the lane's computation (6 instructions each: ≈ 3.3 ms of virtual time).
const BUSY_ITERATIONS: u32 = 550_000;
/// The cycles that must run while the lane computes (bit n = cycle n).
const CYCLES_DURING_BUSY: u32 = (1 << 13) | (1 << 14) | (1 << 15);
/// Bound on the latency from the tick interrupt to the start of the safety cycle, in
/// instructions (the tick ISR's first lines, the signal, the priority-3 dispatcher).
const LATENCY_BOUND: u32 = 1_000;

/// One safety cycle, not inlined: the unit measured, and the function whose size the
/// README reports.
#[inline(never)]
fn run_cycle(
    system: &mut rtseq::safety::SafetySystem<'static, scenario::Io, 8>,
    io: &mut scenario::Io,
    aborts: &scenario::Aborts,
) -> rtseq::safety::CycleReport {
    system.cycle(io, aborts)
}

/// Instruction counts of one cycle of the 8 × 8 × 8 system (`init`, before anything runs).
fn measure_figures() -> bool {
    use core::hint::black_box;
    use rtseq::safety::{LevelChange, SafetyHandle, SafetySystem};
    use scenario::*;

    static MEASURE: SafetyHandle = SafetyHandle::new();
    let Ok(mut system) = SafetySystem::new_validated(&PROPS, &MEASURE) else {
        defmt::error!("figures: cannot bind the measurement handle");
        return false;
    };
    let mut io = Io::new();
    let aborts = Aborts::default();
    let cycle = |system: &mut SafetySystem<'static, Io, 8>, io: &mut Io| {
        board::measure_with(|| run_cycle(black_box(system), black_box(io), &aborts))
    };
    // Up the chain to FAST, where all 8 inputs are checked and all 8 outputs set.
    io.inputs[SPEED.id().index()] = 50.into();
    cycle(&mut system, &mut io);
    MEASURE.trigger(SWITCH_ON);
    cycle(&mut system, &mut io);
    io.request = Some(POWERED);
    cycle(&mut system, &mut io);
    cycle(&mut system, &mut io);
    io.request = Some(HOMED);
    cycle(&mut system, &mut io);
    cycle(&mut system, &mut io);
    MEASURE.trigger(START);
    cycle(&mut system, &mut io);
    MEASURE.trigger(SPEED_UP);
    let (_, r) = cycle(&mut system, &mut io);
    let mut ok = r.level == FAST;

    let mut quiet = [0u32; 3];
    for q in quiet.iter_mut() {
        let (n, r) = cycle(&mut system, &mut io);
        ok &= r.change.is_none() && r.input_events == 0;
        *q = n;
    }
    MEASURE.trigger(STOP);
    let (transition, r) = cycle(&mut system, &mut io);
    ok &= r.change
        == Some(LevelChange {
            from: Some(FAST),
            to: MOVING,
        });
    io.inputs[ESTOP_IN.id().index()] = true.into();
    let (firing, r) = cycle(&mut system, &mut io);
    ok &= r.input_events == 1;
    let (emergency, r) = cycle(&mut system, &mut io);
    ok &= r.level == EMERGENCY && r.aborted;
    let quiet_max = quiet.iter().copied().max().unwrap_or(0);
    let quiet_min = quiet.iter().copied().min().unwrap_or(0);
    defmt::info!(
        "figures: cycle, 8 levels x 8 inputs x 8 outputs, no transition = {=u32} instructions (min {=u32}, budget 400)",
        quiet_max,
        quiet_min
    );
    defmt::info!(
        "figures: cycle with a transition (FAST -> MOVING, exit/entry, toggles reset) = {=u32} instructions",
        transition
    );
    defmt::info!(
        "figures: cycle whose input check fires (estop) = {=u32} instructions",
        firing
    );
    defmt::info!(
        "figures: cycle entering EMERGENCY with abort-all = {=u32} instructions",
        emergency
    );
    defmt::info!(
        "figures: RAM size_of SafetySystem<8 levels> = {=usize} B, SafetyHandle = {=usize} B, CycleReport = {=usize} B",
        core::mem::size_of::<SafetySystem<'static, Io, 8>>(),
        core::mem::size_of::<SafetyHandle>(),
        core::mem::size_of::<rtseq::safety::CycleReport>()
    );
    ok
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX, CAN1_RX0])]
mod app {
    use super::{board, run_cycle, scenario};
    use super::{BUSY_AT_TICK, BUSY_ITERATIONS, CYCLES_DURING_BUSY, LATENCY_BOUND};
    use board::clock::{self, TickTimer};
    use board::signal::TickSignal;
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use rtseq::safety::{SafetyHandle, SafetySystem};
    use scenario::{Aborts, Io, Record};

    /// Tick → safety task.
    static TO_SAFETY: TickSignal = TickSignal::new();
    /// Tick → lane.
    static TO_LANE: TickSignal = TickSignal::new();
    /// The lock-free part of the safety system, shared with the lane.
    static SAFETY: SafetyHandle = SafetyHandle::new();
    /// TIM2 count at the start of the last tick interrupt.
    static TICK_CNT: AtomicU32 = AtomicU32::new(0);
    /// The lane is inside its long computation.
    static LANE_BUSY: AtomicBool = AtomicBool::new(false);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        system: SafetySystem<'static, Io, 8>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        defmt::info!(
            "safety: start, {=u32} cycles at {=u32} Hz",
            scenario::CYCLES,
            clock::TICK_HZ
        );
        if !super::measure_figures() {
            defmt::error!("figures: the measured cycles did not do what they should");
            board::exit_failure();
        }
        let Ok(system) = SafetySystem::new_validated(&scenario::PROPS, &SAFETY) else {
            defmt::error!("safety: cannot bind the handle");
            board::exit_failure();
        };
        safety::spawn().ok();
        lane::spawn().ok();
        (Shared {}, Local { timer, system })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// The heartbeat: wakes the safety task first (it preempts here), then the lane.
    #[task(binds = TIM2, priority = 2, local = [timer])]
    fn tick(cx: tick::Context) {
        TICK_CNT.store(clock::tim2_count(), Ordering::Relaxed);
        let now = cx.local.timer.on_interrupt();
        TO_SAFETY.signal(now);
        TO_LANE.signal(now);
    }

    /// The safety system: highest priority, one cycle per tick.
    #[task(priority = 3, local = [system, io: Io = Io::new(), aborts: Aborts = Aborts(core::cell::Cell::new(0))])]
    async fn safety(cx: safety::Context) {
        let safety::LocalResources {
            system, io, aborts, ..
        } = cx.local;
        let mut n: u32 = 0;
        let mut digest = scenario::DIGEST_SEED;
        let mut failures: u32 = 0;
        let mut max_latency: u32 = 0;
        let mut busy_cycles: u32 = 0;
        loop {
            let now = TO_SAFETY.wait().await;
            let latency = clock::tim2_count().wrapping_sub(TICK_CNT.load(Ordering::Relaxed));
            let lane_busy = LANE_BUSY.load(Ordering::Relaxed);
            n = n.wrapping_add(1);
            scenario::plant(n, io);
            let (cost, report) = board::measure_with(|| run_cycle(system, io, aborts));
            let r = Record::new(n, &report, io);
            digest = r.digest(digest);
            let o = r.outputs;
            defmt::info!(
                "safety: cycle {=u32} level {=u8} change {=i16}>{=i16} inputs {=u32} unknown {=u32} aborted {=bool} out {=i32} {=i32} {=i32} {=i32} {=i32} {=i32} {=i32} {=i32}",
                r.cycle, r.level, r.from, r.to, r.input_events, r.unknown, r.aborted,
                o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7]
            );
            defmt::info!(
                "safety: timing cycle {=u32} tick {=u64} us latency {=u32} instructions cost {=u32} instructions lane busy {=bool}",
                n,
                now.as_ticks(),
                latency,
                cost,
                lane_busy
            );
            if let Err(what) = scenario::check(&r) {
                defmt::error!("safety: cycle {=u32}: unexpected {=str}", n, what);
                failures = failures.wrapping_add(1);
            }
            max_latency = max_latency.max(latency);
            if lane_busy {
                busy_cycles |= 1u32.checked_shl(n).unwrap_or(0);
            }
            if n >= scenario::CYCLES {
                break;
            }
        }
        let aborts = aborts.0.get();
        defmt::info!(
            "safety: done cycles={=u32} digest={=u32:#010x} aborts={=u32} failures={=u32} max_latency={=u32} cycles_during_busy_lane={=u32:#x}",
            SAFETY.cycles(),
            digest,
            aborts,
            failures,
            max_latency,
            busy_cycles
        );
        let ok = failures == 0
            && aborts == scenario::EXPECTED_ABORTS
            && SAFETY.cycles() == scenario::CYCLES
            && busy_cycles == CYCLES_DURING_BUSY
            && max_latency <= LATENCY_BOUND;
        if ok {
            defmt::info!("safety: all expectations hold");
            board::exit_success();
        }
        defmt::error!("safety: expectations failed");
        board::exit_failure();
    }

    /// What a sequence does: trigger public events (lock-free), and compute for a long time.
    #[task(priority = 1)]
    async fn lane(_: lane::Context) {
        loop {
            let now = TO_LANE.wait().await;
            let tick = now.as_ticks() / clock::TICK.as_ticks();
            let next = u32::try_from(tick.wrapping_add(1)).unwrap_or(u32::MAX);
            for &event in scenario::public_events(next) {
                SAFETY.trigger(event);
            }
            if tick == BUSY_AT_TICK {
                let (start, cycles_before) = (clock::now_fine(), SAFETY.cycles());
                LANE_BUSY.store(true, Ordering::Relaxed);
                let mut x: u32 = 0;
                for i in 0..BUSY_ITERATIONS {
                    x = core::hint::black_box(x.wrapping_add(i));
                }
                LANE_BUSY.store(false, Ordering::Relaxed);
                let (end, cycles_after) = (clock::now_fine(), SAFETY.cycles());
                defmt::info!(
                    "lane: busy from {=u64} us to {=u64} us ({=u32}), safety cycles {=u32} -> {=u32} meanwhile",
                    start.as_ticks(),
                    end.as_ticks(),
                    x,
                    cycles_before,
                    cycles_after
                );
            }
        }
    }
}
