//! A single linear axis, written from the user docs alone (README, firmware guide,
//! semantics, safety): homing with a timeout, moves commanded from an interrupt-driven
//! command task, a following-error monitor (safe stop, restart limit), an end-stop
//! monitor, and a safety system with an e-stop that aborts everything.
//!
//! The axis is simulated in the tick; a scripted scenario (`scenario_*` below) injects
//! commands and faults at fixed milliseconds. `tests/qemu_axis.rs` asserts the log.
//!
//! Modes (command line): `main` (default), `homing-timeout` (the reference switch is
//! broken: homing runs into its timeout), `homing-pause` (the same, homing paused for
//! 50 ms), `slow-poll` (the moves' monitors polled every 10 ms), `abort-in-exception` and
//! `pause-in-exception` (an operator's request while the safe stop runs), `endstop-held`
//! (a move started on a closed end stop).
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicBool, AtomicI32, AtomicU32, AtomicU8, Ordering::Relaxed};
use rtseq::safety::*;
use rtseq::{lock::PriorityCeiling, Behaviour, ConditionFn, Cx, Duration, Failure, Instant};
use rtseq::{Error, Handle, Monitor, MonitorNames, Seq, SeqConfig, SeqId, Sequence};
use rtseq::{Sequencer, Step, Table, WithNames};
use rtseq_qemu_f405 as board;

// ---------------------------------------------------------------------------------------
// The machine
// ---------------------------------------------------------------------------------------

/// Positions in µm, speeds in µm per 1 ms tick.
pub struct Axis {
    /// Measured position (the encoder).
    position: AtomicI32,
    /// Commanded position (integrated command); following error = commanded - measured.
    commanded: AtomicI32,
    /// Commanded speed.
    speed: AtomicI32,
    /// Target of the current move.
    target: AtomicI32,
    /// Feed hold: the control loop holds the motion (set with a pause request).
    hold: AtomicBool,
    /// Simulated faults / inputs.
    jam: AtomicBool,
    end_switch: AtomicBool,
    ref_broken: AtomicBool,
    estop: AtomicBool,
    /// The drive enable (a critical output of the safety system).
    enable: AtomicBool,
}

static AXIS: Axis = Axis {
    position: AtomicI32::new(1_000),
    commanded: AtomicI32::new(1_000),
    speed: AtomicI32::new(0),
    target: AtomicI32::new(0),
    hold: AtomicBool::new(false),
    jam: AtomicBool::new(false),
    end_switch: AtomicBool::new(false),
    ref_broken: AtomicBool::new(false),
    estop: AtomicBool::new(false),
    enable: AtomicBool::new(false),
};

const MOVE_SPEED: i32 = 100;
const SEEK_SPEED: i32 = -20;
const FOLLOWING_LIMIT: i32 = 1_000;

/// One control step: the drive follows the command unless jammed.
fn plant_step(a: &Axis) {
    if !a.enable.load(Relaxed) || a.hold.load(Relaxed) {
        return;
    }
    let v = a.speed.load(Relaxed);
    a.commanded.fetch_add(v, Relaxed);
    if !a.jam.load(Relaxed) {
        a.position.fetch_add(v, Relaxed);
    }
}

// ---------------------------------------------------------------------------------------
// Sequences
// ---------------------------------------------------------------------------------------

/// Drives towards the reference switch (at 0) until it closes.
struct Seek;
impl Step<Axis> for Seek {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().speed.store(SEEK_SPEED, Relaxed);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
        let a = cx.control();
        !a.ref_broken.load(Relaxed) && a.position.load(Relaxed) <= 0
    }
}

struct Homing {
    seek: Seq<Seek>,
}
impl Sequence<Axis> for Homing {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.step(&mut self.seek).await?;
        let a = cx.control();
        a.speed.store(0, Relaxed);
        a.commanded.store(a.position.load(Relaxed), Relaxed);
        Ok(())
    }
}

/// Commands the speed towards the target; ends in position.
struct MoveTo;
impl Step<Axis> for MoveTo {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        let a = cx.control();
        let d = a.target.load(Relaxed) - a.position.load(Relaxed);
        a.speed.store(d.signum() * MOVE_SPEED, Relaxed);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
        let a = cx.control();
        let (p, t) = (a.position.load(Relaxed), a.target.load(Relaxed));
        match a.speed.load(Relaxed) {
            s if s > 0 => p >= t,
            s if s < 0 => p <= t,
            _ => true,
        }
    }
}

struct Move {
    to: Seq<MoveTo>,
}
impl Sequence<Axis> for Move {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.step(&mut self.to).await?;
        cx.control().speed.store(0, Relaxed);
        Ok(())
    }
}

/// Stops the axis and clears the following error (the command follows the encoder).
struct SafeStop;
impl Sequence<Axis> for SafeStop {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        let a = cx.control();
        a.speed.store(0, Relaxed);
        a.commanded.store(a.position.load(Relaxed), Relaxed);
        Ok(())
    }
}

/// Cleanup hook of an aborted move: the drive stops.
fn stop_drive(a: &Axis) {
    a.speed.store(0, Relaxed);
}

rtseq::sequences! {
    mod seqs(move_polling: Duration) for Axis {
        SEEK = SeqConfig::new("seek"),
        MOVE_TO = SeqConfig::new("move to"),
        SAFE_STOP = SeqConfig::new("safe stop").in_lane(),
        HOMING = SeqConfig::new("homing")
            .in_lane()
            .timeout(Duration::from_millis(500))
            .timeout_exception(SAFE_STOP)
            .timeout_behaviour(Behaviour::AbortOwner),
        MOVE = SeqConfig::new("move")
            .in_lane()
            .polling(move_polling)
            .on_abort(stop_drive),
    }
}
use seqs::{HOMING, MOVE, MOVE_TO, SAFE_STOP, SEEK};

fn following_error(a: &Axis, _: Instant) -> bool {
    (a.commanded.load(Relaxed) - a.position.load(Relaxed)).abs() > FOLLOWING_LIMIT
}
fn end_stop(a: &Axis, _: Instant) -> bool {
    a.end_switch.load(Relaxed)
}

rtseq::monitors! {
    mod monitor_ids for Axis, ConditionFn<Axis> {
        FOLLOWING = Monitor::with_fn("following error", following_error, Behaviour::RestartOwner)
            .exception(SAFE_STOP)
            .restart_limit(2)
            .owned_by(MOVE),
        END_STOP = Monitor::with_fn("end stop", end_stop, Behaviour::AbortOwner)
            .owned_by(MOVE),
    }
}

const fn checked(move_polling: Duration) -> Table<Axis, { seqs::COUNT }> {
    match seqs::table(move_polling) {
        Ok(t) => match monitor_ids::validate(&t) {
            Ok(()) => t,
            Err(e) => panic!("{}", e.message().as_str()),
        },
        Err(e) => panic!("{}", e.message().as_str()),
    }
}
static TABLE: Table<Axis, { seqs::COUNT }> = checked(Duration::from_millis(1));
/// The moves' monitors polled every 10 ms (mode `slow-poll`).
static TABLE_SLOW: Table<Axis, { seqs::COUNT }> = checked(Duration::from_millis(10));
static MONITOR_NAMES: MonitorNames<{ monitor_ids::COUNT }> = monitor_ids::names();

// ---------------------------------------------------------------------------------------
// Safety: `run` -> e-stop -> `emergency` (drive off, abort every sequence).
// ---------------------------------------------------------------------------------------

const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
const RUN: SafetyLevel = SafetyLevel::new(1);
const ESTOP: PrivateEvent = PrivateEvent::new(0);
const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "e-stop");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
static PROPS: ValidProperties<'static, Io, 2> = match SafetyProperties::new(
    [
        LevelDef::new(EMERGENCY, "emergency")
            .inputs(&[ESTOP_IN.ignore()])
            .outputs(&[ENABLE.set(false)])
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(RUN, "run")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(true)]),
    ],
    &[ESTOP_IN.info()],
    &[ENABLE.info()],
    &[LevelTransition::on(RUN, ESTOP, EMERGENCY)],
    RUN,
)
.validated()
{
    Ok(p) => p,
    Err(_) => panic!("invalid safety properties"),
};
pub struct Io;
impl SafetyIo for Io {
    fn read_input(&mut self, _: InputId) -> IoValue {
        AXIS.estop.load(Relaxed).into()
    }
    fn write_output(&mut self, _: OutputId, v: IoValue) {
        AXIS.enable.store(v == IoValue::Bool(true), Relaxed);
    }
}

// SAFETY: SEQ is used at priority 2 (tick, command task) and below; the safety task (3)
// only runs `SafetySystem::cycle` on it.
static SEQ: Sequencer<Axis, { seqs::COUNT }, 128, PriorityCeiling<2>> =
    unsafe { Sequencer::with_priority_ceiling() };

// ---------------------------------------------------------------------------------------
// The scenario
// ---------------------------------------------------------------------------------------

const MODE_MAIN: u8 = 0;
const MODE_HOMING_TIMEOUT: u8 = 1;
const MODE_HOMING_PAUSE: u8 = 2;
const MODE_SLOW_POLL: u8 = 3;
const MODE_ABORT_IN_EXCEPTION: u8 = 4;
const MODE_ENDSTOP_HELD: u8 = 5;
const MODE_PAUSE_IN_EXCEPTION: u8 = 6;
static MODE: AtomicU8 = AtomicU8::new(MODE_MAIN);
static DONE: AtomicBool = AtomicBool::new(false);
static TICK_ERRORS: AtomicU32 = AtomicU32::new(0);
const END_MS: u64 = 600;

#[derive(Clone, Copy)]
enum Command {
    PauseHoming,
    ResumeHoming,
    Start(i32),
    Pause,
    Resume,
    Abort,
}

/// The operator's commands, by millisecond (main mode).
fn command_at(ms: u64) -> Option<Command> {
    match (MODE.load(Relaxed), ms) {
        (MODE_HOMING_PAUSE, 100) => return Some(Command::PauseHoming),
        (MODE_HOMING_PAUSE, 150) => return Some(Command::ResumeHoming),
        (MODE_ABORT_IN_EXCEPTION, 330) => return Some(Command::Abort),
        (MODE_PAUSE_IN_EXCEPTION, 330) => return Some(Command::Pause),
        (MODE_PAUSE_IN_EXCEPTION, 340) => return Some(Command::Resume),
        (
            MODE_MAIN
            | MODE_SLOW_POLL
            | MODE_ABORT_IN_EXCEPTION
            | MODE_ENDSTOP_HELD
            | MODE_PAUSE_IN_EXCEPTION,
            _,
        ) => {}
        _ => return None,
    }
    match ms {
        100 => Some(Command::Start(5_000)),
        120 => Some(Command::Pause),
        140 => Some(Command::Resume),
        200 => Some(Command::Start(20_000)),
        250 => Some(Command::Abort),
        300 => Some(Command::Start(0)),
        400 => Some(Command::Start(40_000)),
        500 => Some(Command::Start(20_000)),
        _ => None,
    }
}

/// The inputs the scenario drives, set before the safety cycle of tick `ms`.
fn inputs_at(ms: u64) {
    let a = &AXIS;
    match MODE.load(Relaxed) {
        MODE_MAIN | MODE_ABORT_IN_EXCEPTION | MODE_PAUSE_IN_EXCEPTION => {
            a.jam.store((320..400).contains(&ms), Relaxed);
            a.end_switch.store((450..460).contains(&ms), Relaxed);
            a.estop.store(ms >= 520, Relaxed);
        }
        MODE_ENDSTOP_HELD => {
            // The axis stays on the end stop: the next move starts with the switch closed.
            a.jam.store((320..400).contains(&ms), Relaxed);
            a.end_switch.store(ms >= 450, Relaxed);
            a.estop.store(ms >= 520, Relaxed);
        }
        MODE_SLOW_POLL => {
            a.jam.store((320..400).contains(&ms), Relaxed);
            a.end_switch.store((455..470).contains(&ms), Relaxed);
            a.estop.store(ms >= 520, Relaxed);
        }
        _ => a.ref_broken.store(true, Relaxed),
    }
}

fn or_exit<T, E: defmt::Format>(r: Result<T, E>) -> T {
    r.unwrap_or_else(|e| {
        defmt::error!("axis: {}", e);
        board::exit_failure()
    })
}

fn handle(id: SeqId) -> Handle<'static, Axis> {
    or_exit(SEQ.sequence_by_id(id).ok_or(Error::UnknownSequence(id)))
}

fn read_mode() -> u8 {
    let mut buf = [0u8; 64];
    let mut mode = MODE_MAIN;
    for arg in or_exit(board::args::args(&mut buf)) {
        match arg {
            "main" => mode = MODE_MAIN,
            "homing-timeout" => mode = MODE_HOMING_TIMEOUT,
            "homing-pause" => mode = MODE_HOMING_PAUSE,
            "slow-poll" => mode = MODE_SLOW_POLL,
            "abort-in-exception" => mode = MODE_ABORT_IN_EXCEPTION,
            "endstop-held" => mode = MODE_ENDSTOP_HELD,
            "pause-in-exception" => mode = MODE_PAUSE_IN_EXCEPTION,
            _ => {
                defmt::error!("axis: unknown mode {=str}", arg);
                board::exit_failure();
            }
        }
    }
    mode
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::*;
    use board::{clock::TickTimer, pac::Interrupt};

    #[shared]
    struct Shared {}
    #[local]
    struct Local {
        timer: TickTimer,
        monitors: monitor_ids::MonitorTable,
        safety: SafetySystem<'static, Io, 2>,
        homing: Seq<Homing>,
        moving: Seq<Move>,
        safe_stop: Seq<SafeStop>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        MODE.store(read_mode(), Relaxed);
        let monitors = const {
            match monitor_ids::table() {
                Ok(m) => m,
                Err(e) => panic!("{}", e.message().as_str()),
            }
        };
        let slow = MODE.load(Relaxed) == MODE_SLOW_POLL;
        or_exit(SEQ.install(if slow { &TABLE_SLOW } else { &TABLE }));
        let seek = or_exit(SEQ.bind(SEEK, Seek));
        let to = or_exit(SEQ.bind(MOVE_TO, MoveTo));
        let homing = or_exit(SEQ.bind(HOMING, Homing { seek }));
        let moving = or_exit(SEQ.bind(MOVE, Move { to }));
        let safe_stop = or_exit(SEQ.bind(SAFE_STOP, SafeStop));
        let safety = or_exit(SafetySystem::new_validated(&PROPS, SEQ.safety_handle()));
        or_exit(handle(HOMING).start());
        lanes::spawn().ok();
        defmt::info!("axis: mode {=u8}", MODE.load(Relaxed));
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (
            Shared {},
            Local {
                timer,
                monitors,
                safety,
                homing,
                moving,
                safe_stop,
            },
        )
    }

    /// The heartbeat: scenario inputs, the safety cycle (preempts), the control step, the
    /// sequencer; then the operator's command for this millisecond, if any.
    #[task(binds = TIM2, priority = 2, local = [timer, monitors])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        let ms = now.as_ticks() / 1_000;
        inputs_at(ms);
        rtic::pend(Interrupt::EXTI0); // the safety task preempts right here
        plant_step(&AXIS);
        if SEQ.tick(now, &AXIS, cx.local.monitors).is_err() {
            TICK_ERRORS.fetch_add(1, Relaxed);
        }
        if command_at(ms).is_some() {
            rtic::pend(Interrupt::EXTI1); // the command "button"
        }
        if ms >= END_MS {
            DONE.store(true, Relaxed);
        }
    }

    #[task(binds = EXTI0, priority = 3, local = [safety, io: Io = Io])]
    fn safety(cx: safety::Context) {
        cx.local.safety.cycle(cx.local.io, &SEQ);
    }

    /// The operator's commands: a hardware task above the lanes, at the tick's priority
    /// (the ceiling: the highest that may use a `Handle`).
    #[task(binds = EXTI1, priority = 2)]
    fn command(_: command::Context) {
        let ms = SEQ.now().as_ticks() / 1_000;
        let h = handle(MOVE);
        let (what, r) = match command_at(ms) {
            Some(Command::Start(target)) => {
                AXIS.target.store(target, Relaxed);
                ("start", h.start())
            }
            Some(Command::Pause) => {
                AXIS.hold.store(true, Relaxed); // feed hold in the control loop
                ("pause", h.pause())
            }
            Some(Command::Resume) => {
                let r = h.resume();
                AXIS.hold.store(false, Relaxed);
                ("resume", r)
            }
            Some(Command::Abort) => ("abort", h.abort()),
            Some(Command::PauseHoming) => ("pause homing", handle(HOMING).pause()),
            Some(Command::ResumeHoming) => ("resume homing", handle(HOMING).resume()),
            None => ("none", Ok(())),
        };
        match r {
            Ok(()) => defmt::info!("cmd: {=u64} ms {=str} ok", ms, what),
            Err(e) => defmt::info!("cmd: {=u64} ms {=str} refused: {}", ms, what, e.named(&SEQ)),
        }
    }

    #[task(priority = 1, local = [homing, moving, safe_stop])]
    async fn lanes(cx: lanes::Context) {
        let (homing, moving, safe_stop) = (cx.local.homing, cx.local.moving, cx.local.safe_stop);
        match rtseq::lanes!(&SEQ, &AXIS, homing, moving, safe_stop).await {}
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        or_exit(SEQ.check_lanes());
        let names = (&SEQ, &MONITOR_NAMES, PROPS.properties());
        let mut records: u32 = 0;
        loop {
            let done = DONE.load(Relaxed);
            let lost = SEQ.drain_records(|r| {
                records = records.wrapping_add(1);
                defmt::info!("rec: {}", r.named(&names))
            });
            if lost != 0 {
                defmt::error!("axis: {=u32} records lost", lost);
            }
            if done {
                for id in [HOMING, SEEK, MOVE, MOVE_TO, SAFE_STOP] {
                    let h = handle(id);
                    match h.last_outcome() {
                        Some(o) => defmt::info!("final: {=str} {}", h.name(), o.named(&names)),
                        None => defmt::info!("final: {=str} never ran", h.name()),
                    }
                }
                defmt::info!(
                    "final: position {=i32} enable {=bool} tick errors {=u32} exceptions not run {=u16}",
                    AXIS.position.load(Relaxed),
                    AXIS.enable.load(Relaxed),
                    TICK_ERRORS.load(Relaxed),
                    SEQ.exceptions_not_run()
                );
                defmt::info!("final: records {=u32}", records);
                board::exit_success();
            }
            cortex_m::asm::wfi();
        }
    }
}
