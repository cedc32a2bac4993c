//! Emergency firmware (issue 4): the emergency scenario of `tests/emergency.rs` with the real
//! `Sequencer` under RTIC: a tree of blocking and non-blocking sequences powers the machine
//! up through the safety system (a step triggers public events through `cx.safety_system()`
//! and waits, in its exit condition, for the level), then an emergency arrives at tick 10:
//!
//! * `estop` (default): the emergency-stop input is pressed; the input check fires ESTOP in
//!   cycle 10, cycle 11 enters EMERGENCY;
//! * `fault`: axis B (a non-blocking sequence) detects a fault and triggers the public FAULT
//!   event; cycle 11 enters EMERGENCY.
//!
//! - `safety` (priority 3): one safety cycle per tick, woken first by the tick, with `SEQ` as
//!   its `Sequences`: the cycle entering EMERGENCY requests abort-all, which the
//!   sequencer tick at the same instant applies.
//! - `tick` (TIM2, 1 kHz, priority 2): injects the fault of the mode, wakes the safety task
//!   (it preempts here), then `SEQ.tick`; starts `main` after the first safety cycle.
//! - `lane_main`, `lane_b` (priority 1): `rtseq::lane`.
//! - `idle`: drains the trace (transitions and events), prints it, compares it with the
//!   expected one (the host's).
//!
//! The firmware checks itself: the exact trace (the same as on the host), the level of every
//! safety cycle, safe outputs, every sequence `Aborted` (or completed before), all of it at
//! 11 ms of virtual time. Exit 0 if all holds, 1 otherwise. Actions are hand-written futures
//! (no `async fn`), so the firmware has no panic path of its own.
#![no_std]
#![no_main]

use core::future::Future;
use core::pin::Pin;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use core::task::{Context, Poll};

use rtseq::safety::*;
use rtseq::{Cx, Failure, Seq, SeqId, Sequence, Step};
use rtseq_qemu_f405 as board;
use rtseq_scenarios::emergency::{
    self, Machine, EMERGENCY, ENABLE, FAULT, MOVING, READY, START_MOVING, SWITCH_ON,
};

/// Ticks run.
const RUN_TICKS: u32 = 14;
/// The emergency arrives before this tick's safety cycle.
const FAULT_TICK: u32 = 10;

// ---------------------------------------------------------------------------------------
// The control system and the safety system's I/O; the safety system itself is shared
// with the host test (`rtseq_scenarios::emergency`).
// ---------------------------------------------------------------------------------------

/// The machine's IO, shared by the safety system, the sequences and the fault injection.
pub struct Ctrl {
    estop: AtomicBool,
    fault: AtomicBool,
    enable: AtomicBool,
    lamp: AtomicBool,
    powering_cycles: AtomicU32,
}

static CTRL: Ctrl = Ctrl {
    estop: AtomicBool::new(false),
    fault: AtomicBool::new(false),
    enable: AtomicBool::new(false),
    lamp: AtomicBool::new(false),
    powering_cycles: AtomicU32::new(0),
};

/// The safety system's view of [`CTRL`].
pub struct Plant;

impl SafetyIo for Plant {
    fn read_input(&mut self, _input: InputId) -> IoValue {
        CTRL.estop.load(Relaxed).into()
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        let on = value == IoValue::Bool(true);
        if output == ENABLE.id() {
            CTRL.enable.store(on, Relaxed);
        } else {
            CTRL.lamp.store(on, Relaxed);
        }
    }
}

impl Machine for Plant {
    fn powering_cycles(&self) -> u32 {
        CTRL.powering_cycles.load(Relaxed)
    }
    fn set_powering_cycles(&mut self, n: u32) {
        CTRL.powering_cycles.store(n, Relaxed);
    }
}

static PROPS: ValidProperties<'static, Plant, 5> = match emergency::properties() {
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

// ---------------------------------------------------------------------------------------
// The sequences (hand-written action futures: no `async fn`, no panic path).
// ---------------------------------------------------------------------------------------

/// Triggers `event` through `cx.safety_system()`; done when the level is `until`.
pub struct Request {
    event: PublicEvent,
    until: SafetyLevel,
}

impl Step<Ctrl> for Request {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        if let Some(safety) = cx.safety_system() {
            safety.trigger(self.event);
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.safety_system()
            .is_some_and(|safety| safety.level() == self.until)
    }
}

/// A long motion; with `watch_fault` it ends when the axis reports a fault.
pub struct Travel {
    watch_fault: bool,
}

impl Step<Ctrl> for Travel {
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.watch_fault && cx.control().fault.load(Relaxed)
    }
}

/// An action of two children run one after the other (their futures begin on their first
/// poll), optionally starting a non-blocking sequence in between. Polling it again after
/// completion returns `Ready` again: no panic path.
struct Two<'b, 'c, A, B> {
    cx: &'b Cx<'c, Ctrl>,
    first: A,
    second: B,
    start_between: Option<SeqId>,
    stage: u8,
}

impl<A: Future, B: Future> Future for Two<'_, '_, A, B> {
    type Output = Result<(), Failure>;
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: `first` and `second` are structurally pinned (never moved out, polled in
        // place, dropped with `self`); the other fields are plain data.
        let this = unsafe { self.get_unchecked_mut() };
        if this.stage == 0 {
            // SAFETY: see above.
            match unsafe { Pin::new_unchecked(&mut this.first) }.poll(w) {
                Poll::Pending => return Poll::Pending,
                Poll::Ready(_) => this.stage = 1,
            }
            if let Some(id) = this.start_between.take() {
                let _ = this.cx.start(id);
            }
        }
        if this.stage == 1 {
            // SAFETY: see above.
            match unsafe { Pin::new_unchecked(&mut this.second) }.poll(w) {
                Poll::Pending => return Poll::Pending,
                Poll::Ready(_) => this.stage = 2,
            }
        }
        Poll::Ready(Ok(()))
    }
}

/// Blocking child of `main`: request MOVING, then travel.
pub struct MoveA {
    start: Seq<Request>,
    travel: Seq<Travel>,
}

impl Sequence<Ctrl> for MoveA {
    fn action<'a, 'b, 'c>(
        &'a mut self,
        cx: &'b Cx<'c, Ctrl>,
    ) -> impl Future<Output = Result<(), Failure>> + use<'a, 'b, 'c> {
        Two {
            cx,
            first: cx.step(&mut self.start),
            second: cx.step(&mut self.travel),
            start_between: None,
            stage: 0,
        }
    }
}

/// Non-blocking: travel until a fault, then report it (public FAULT) and wait for EMERGENCY.
pub struct AxisB {
    travel: Seq<Travel>,
    report: Seq<Request>,
}

impl Sequence<Ctrl> for AxisB {
    fn action<'a, 'b, 'c>(
        &'a mut self,
        cx: &'b Cx<'c, Ctrl>,
    ) -> impl Future<Output = Result<(), Failure>> + use<'a, 'b, 'c> {
        Two {
            cx,
            first: cx.step(&mut self.travel),
            second: cx.step(&mut self.report),
            start_between: None,
            stage: 0,
        }
    }
}

/// Power on (blocking step), start axis B (non-blocking), run move A (blocking).
pub struct Main {
    power_on: Seq<Request>,
    axis_b: SeqId,
    move_a: Seq<MoveA>,
}

impl Sequence<Ctrl> for Main {
    fn action<'a, 'b, 'c>(
        &'a mut self,
        cx: &'b Cx<'c, Ctrl>,
    ) -> impl Future<Output = Result<(), Failure>> + use<'a, 'b, 'c> {
        Two {
            cx,
            first: cx.step(&mut self.power_on),
            second: cx.run(&mut self.move_a),
            start_between: Some(self.axis_b),
            stage: 0,
        }
    }
}

type Seqr = rtseq::Sequencer<Ctrl, 8, 32>;

/// The mode, from the command line: `fault` or (default) `estop`.
fn fault_mode() -> bool {
    let mut buf = [0u8; 64];
    let line = match board::args::cmdline(&mut buf) {
        Ok(line) => line,
        Err(e) => {
            defmt::error!("emergency: {}", e);
            board::exit_failure();
        }
    };
    line.as_bytes().ends_with(b" fault")
}

// ---------------------------------------------------------------------------------------
// Expectations (the host's, tests/emergency.rs).
// ---------------------------------------------------------------------------------------

mod expect {
    use rtseq::Cause::{AbortAll, Completed, Start};
    use rtseq::RunningState::{Aborted, Aborting, Idle, Running, Terminated};
    use rtseq::{Event, Requester, SeqId, Transition};
    use rtseq_scenarios::emergency::{EMERGENCY, ESTOP_IN, MOVING, OFF, POWERING, READY};

    const fn id(i: usize) -> SeqId {
        SeqId::from_index(i)
    }
    // Registration order.
    pub const POWER_ON: SeqId = id(0);
    pub const START: SeqId = id(1);
    pub const TRAVEL_A: SeqId = id(2);
    pub const MOVE_A: SeqId = id(3);
    pub const TRAVEL_B: SeqId = id(4);
    pub const REPORT: SeqId = id(5);
    pub const AXIS_B: SeqId = id(6);
    pub const MAIN: SeqId = id(7);

    const fn tr(
        ms: u64,
        s: SeqId,
        from: rtseq::RunningState,
        to: rtseq::RunningState,
        c: rtseq::Cause,
    ) -> Transition {
        Transition::at_millis(ms, s, from, to, c)
    }

    const POWER_UP: [Transition; 9] = [
        tr(1, MAIN, Idle, Running, Start),
        tr(1, POWER_ON, Idle, Running, Start),
        tr(4, POWER_ON, Running, Terminated, Completed),
        tr(4, AXIS_B, Idle, Running, Start),
        tr(4, MOVE_A, Idle, Running, Start),
        tr(4, START, Idle, Running, Start),
        tr(4, TRAVEL_B, Idle, Running, Start),
        tr(5, START, Running, Terminated, Completed),
        tr(5, TRAVEL_A, Idle, Running, Start),
    ];

    const fn abort(s: SeqId) -> [Transition; 2] {
        [
            tr(11, s, Running, Aborting, AbortAll),
            tr(11, s, Aborting, Aborted, AbortAll),
        ]
    }

    /// Transition `k` of the expected trace.
    pub fn transition(fault: bool, k: usize) -> Option<Transition> {
        if let Some(t) = POWER_UP.get(k) {
            return Some(*t);
        }
        let k = k.wrapping_sub(POWER_UP.len());
        let (prefix, order): (&[Transition], [SeqId; 5]) = if fault {
            (
                &[
                    tr(10, TRAVEL_B, Running, Terminated, Completed),
                    tr(10, REPORT, Idle, Running, Start),
                ],
                [TRAVEL_A, REPORT, MOVE_A, AXIS_B, MAIN],
            )
        } else {
            (&[], [TRAVEL_A, TRAVEL_B, MOVE_A, AXIS_B, MAIN])
        };
        if let Some(t) = prefix.get(k) {
            return Some(*t);
        }
        let k = k.wrapping_sub(prefix.len());
        let seq = order.get(k / 2)?;
        abort(*seq).get(k % 2).copied()
    }

    /// The events, as on the host: the levels of powering up; with `estop`, the input
    /// that trips at 10 ms; EMERGENCY and the abort-all it asks for at 11 ms.
    pub fn event(fault: bool, k: usize) -> Option<(u64, Event)> {
        let level = |level| Event::SafetyLevel { level };
        let power_up = [(1, OFF), (2, POWERING), (4, READY), (5, MOVING)];
        if let Some(&(ms, l)) = power_up.get(k) {
            return Some((ms, level(l)));
        }
        let tripped = (
            10,
            Event::InputTripped {
                input: ESTOP_IN.id(),
            },
        );
        let emergency = [
            (11, level(EMERGENCY)),
            (
                11,
                Event::AbortAll {
                    by: Requester::SafetySystem,
                },
            ),
        ];
        let k = k.wrapping_sub(power_up.len());
        match (fault, k) {
            (false, 0) => Some(tripped),
            (false, k) => emergency.get(k.wrapping_sub(1)).copied(),
            (true, k) => emergency.get(k).copied(),
        }
    }

    /// Number of expected events.
    pub fn events(fault: bool) -> usize {
        if fault {
            4 + 2
        } else {
            4 + 3
        }
    }

    /// Length of the expected trace.
    pub fn len(fault: bool) -> usize {
        if fault {
            9 + 2 + 10
        } else {
            9 + 10
        }
    }

    /// Sequences that completed before the emergency (the others that ran are aborted).
    pub fn completed(fault: bool, s: SeqId) -> bool {
        s == POWER_ON || s == START || (fault && s == TRAVEL_B)
    }

    /// Sequences that never ran.
    pub fn idle(fault: bool, s: SeqId) -> bool {
        !fault && s == REPORT
    }

    /// (level, entered this cycle, aborted, enable, lamp) of safety cycle `n`.
    pub fn cycle(fault: bool, n: u32) -> (u8, bool, bool, bool, bool) {
        let _ = fault;
        match n {
            1 => (1, true, false, false, false),
            2 => (2, true, false, false, false),
            3 => (2, false, false, false, true),
            4 => (3, true, false, true, true),
            5 => (4, true, false, true, true),
            6..=10 => (4, false, false, true, true),
            11 => (0, true, true, false, false),
            n => (0, false, true, false, n % 2 == 0),
        }
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX, CAN1_RX0])]
mod app {
    use super::*;
    use board::clock::{self, TickTimer};
    use board::signal::TickSignal;
    use rtseq::{Monitors, RunningState};

    static SEQ: Seqr = Seqr::new();
    static TO_SAFETY: TickSignal = TickSignal::new();
    static DONE: AtomicBool = AtomicBool::new(false);
    static FAULT_MODE: AtomicBool = AtomicBool::new(false);
    /// Failed safety-cycle expectations.
    static CYCLE_FAILURES: AtomicU32 = AtomicU32::new(0);
    /// Virtual time (µs) at which no sequence was active any more after the emergency.
    static ALL_STOPPED_US: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        system: SafetySystem<'static, Plant, 5>,
        main: Option<Seq<Main>>,
        axis_b: Option<Seq<AxisB>>,
    }

    /// Registers the tree (same order as the host test).
    fn build() -> Result<(Seq<Main>, Seq<AxisB>), rtseq::Error> {
        use rtseq::SeqConfig as Cfg;
        let request = |event, until| Request { event, until };
        let power_on = SEQ.add(Cfg::new("power on"), request(SWITCH_ON, READY))?;
        let start = SEQ.add(Cfg::new("start moving"), request(START_MOVING, MOVING))?;
        let travel_a = SEQ.add(Cfg::new("travel A"), Travel { watch_fault: false })?;
        let move_a = SEQ.add(
            Cfg::new("move A"),
            MoveA {
                start,
                travel: travel_a,
            },
        )?;
        let travel_b = SEQ.add(Cfg::new("travel B"), Travel { watch_fault: true })?;
        let report = SEQ.add(Cfg::new("report fault"), request(FAULT, EMERGENCY))?;
        let axis_b = SEQ.add(
            Cfg::new("axis B"),
            AxisB {
                travel: travel_b,
                report,
            },
        )?;
        let main = SEQ.add(
            Cfg::new("main"),
            Main {
                power_on,
                axis_b: axis_b.id(),
                move_a,
            },
        )?;
        Ok((main, axis_b))
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let fault = fault_mode();
        FAULT_MODE.store(fault, Relaxed);
        let Ok((main, axis_b)) = build() else {
            defmt::error!("emergency: registration failed");
            board::exit_failure();
        };
        for id in [main.id(), axis_b.id()] {
            if let Some(h) = SEQ.sequence_by_id(id) {
                let _ = h.declare_lane();
            }
        }
        let Ok(system) = SafetySystem::new_validated(&PROPS, SEQ.safety_handle()) else {
            defmt::error!("emergency: cannot bind the safety handle");
            board::exit_failure();
        };
        safety::spawn().ok();
        lane_main::spawn().ok();
        lane_b::spawn().ok();
        defmt::info!(
            "emergency: mode {=str}, {=usize} sequences, {=u32} ticks",
            if fault { "fault" } else { "estop" },
            SEQ.len(),
            RUN_TICKS
        );
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (
            Shared {},
            Local {
                timer,
                system,
                main: Some(main),
                axis_b: Some(axis_b),
            },
        )
    }

    fn any_active() -> bool {
        (0..SEQ.len()).any(|i| {
            SEQ.sequence_by_id(SeqId::from_index(i))
                .is_some_and(|h| h.state().is_active())
        })
    }

    /// The heartbeat: fault injection, the safety cycle (preempts), the sequencer tick.
    #[task(binds = TIM2, priority = 2, local = [timer, monitors: Monitors<'static, Ctrl, 1> = Monitors::new(), n: u32 = 0])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        let n = cx.local.n.wrapping_add(1);
        *cx.local.n = n;
        if n == FAULT_TICK {
            if FAULT_MODE.load(Relaxed) {
                CTRL.fault.store(true, Relaxed);
            } else {
                CTRL.estop.store(true, Relaxed);
            }
        }
        TO_SAFETY.signal(now);
        if let Err(e) = SEQ.tick(now, &CTRL, cx.local.monitors) {
            defmt::error!("tick: {}", e);
        }
        if n == 1 {
            if let Some(h) = SEQ.sequence_by_id(expect::MAIN) {
                if h.start().is_err() {
                    defmt::error!("emergency: cannot start main");
                }
            }
        }
        if n > FAULT_TICK && ALL_STOPPED_US.load(Relaxed) == 0 && !any_active() {
            let t = clock::now_fine().as_ticks();
            ALL_STOPPED_US.store(u32::try_from(t).unwrap_or(u32::MAX), Relaxed);
        }
        if n >= RUN_TICKS {
            cx.local.timer.stop();
            DONE.store(true, Relaxed);
        }
    }

    /// The safety system: highest priority, one cycle per tick, aborts through `SEQ`.
    #[task(priority = 3, local = [system, io: Plant = Plant])]
    async fn safety(cx: safety::Context) {
        let fault = FAULT_MODE.load(Relaxed);
        let mut n: u32 = 0;
        loop {
            let now = TO_SAFETY.wait().await;
            n = n.wrapping_add(1);
            let r = cx.local.system.cycle(cx.local.io, &SEQ);
            let (enable, lamp) = (CTRL.enable.load(Relaxed), CTRL.lamp.load(Relaxed));
            defmt::info!(
                "safety: cycle {=u32} at {=u64} us level {=u8} entered {=bool} inputs {=u32} aborted {=bool} enable {=bool} lamp {=bool}",
                n,
                now.as_ticks(),
                r.level.id(),
                r.change.is_some(),
                r.input_events,
                r.aborted,
                enable,
                lamp
            );
            let got = (r.level.id(), r.change.is_some(), r.aborted, enable, lamp);
            if got != expect::cycle(fault, n) {
                defmt::error!("safety: cycle {=u32} unexpected", n);
                CYCLE_FAILURES.fetch_add(1, Relaxed);
            }
        }
    }

    #[task(priority = 1, local = [main])]
    async fn lane_main(cx: lane_main::Context) {
        if let Some(seq) = cx.local.main {
            match rtseq::lane(&SEQ, &CTRL, seq).await {}
        }
        loop {
            core::future::pending::<()>().await;
        }
    }

    #[task(priority = 1, local = [axis_b])]
    async fn lane_b(cx: lane_b::Context) {
        if let Some(seq) = cx.local.axis_b {
            match rtseq::lane(&SEQ, &CTRL, seq).await {}
        }
        loop {
            core::future::pending::<()>().await;
        }
    }

    /// Drains and checks the trace; at the end, checks the final states and exits.
    #[idle]
    fn idle(_: idle::Context) -> ! {
        let fault = FAULT_MODE.load(Relaxed);
        let mut k: usize = 0;
        let mut events: usize = 0;
        let mut failures: u32 = 0;
        loop {
            let lost = SEQ.drain_records(|r| {
                let Some(t) = r.transition() else {
                    let ms = r.time.as_ticks() / 1000;
                    let event = r.event();
                    defmt::info!("event: {=u64} ms {}", ms, event);
                    if expect::event(fault, events) != event.map(|e| (ms, e)) {
                        defmt::error!("trace: event {=usize} unexpected", events);
                        failures = failures.wrapping_add(1);
                    }
                    events = events.wrapping_add(1);
                    return;
                };
                defmt::info!(
                    "trace: {=u64} ms #{=usize} {} -> {} ({})",
                    t.time.as_ticks() / 1000,
                    t.sequence.index(),
                    t.from,
                    t.to,
                    t.cause
                );
                if expect::transition(fault, k) != Some(t) {
                    defmt::error!("trace: transition {=usize} unexpected", k);
                    failures = failures.wrapping_add(1);
                }
                k = k.wrapping_add(1);
            });
            failures = failures.wrapping_add(lost);
            cortex_m::interrupt::disable();
            if DONE.load(Relaxed) {
                for i in 0..SEQ.len() {
                    let id = SeqId::from_index(i);
                    let Some(h) = SEQ.sequence_by_id(id) else {
                        continue;
                    };
                    let (state, outcome) = (h.state(), h.last_outcome());
                    defmt::info!("final: #{=usize} {=str} {} {}", i, h.name(), state, outcome);
                    let ok = if expect::idle(fault, id) {
                        state == RunningState::Idle
                    } else if expect::completed(fault, id) {
                        state == RunningState::Terminated
                            && outcome == Some(rtseq::Outcome::Completed)
                    } else {
                        state == RunningState::Aborted
                            && outcome == Some(rtseq::Outcome::Aborted(rtseq::Cause::AbortAll))
                    };
                    if !ok {
                        failures = failures.wrapping_add(1);
                    }
                }
                if k != expect::len(fault) || events != expect::events(fault) {
                    failures = failures.wrapping_add(1);
                }
                let cycle_failures = CYCLE_FAILURES.load(Relaxed);
                let stopped = ALL_STOPPED_US.load(Relaxed);
                defmt::info!(
                    "emergency: done transitions={=usize} failures={=u32} cycle_failures={=u32} all_stopped_us={=u32} level={=u8} enable={=bool}",
                    k,
                    failures,
                    cycle_failures,
                    stopped,
                    SEQ.safety_handle().level().id(),
                    CTRL.enable.load(Relaxed)
                );
                // Every sequence stopped in the tick of the cycle that entered EMERGENCY.
                let in_time = (11_000..11_100).contains(&stopped);
                if failures == 0
                    && cycle_failures == 0
                    && in_time
                    && SEQ.safety_handle().level() == EMERGENCY
                    && !CTRL.enable.load(Relaxed)
                {
                    defmt::info!("emergency: all expectations hold");
                    board::exit_success();
                }
                defmt::error!("emergency: expectations failed");
                board::exit_failure();
            }
            cortex_m::asm::wfi();
            // SAFETY: not inside a critical section of ours; RTIC uses BASEPRI, not PRIMASK.
            unsafe { cortex_m::interrupt::enable() };
        }
    }
}
