//! A homing with a timeout, a monitor with an exception sequence, a safety system.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicBool, AtomicI32, Ordering::Relaxed};
use rtseq::safety::*;
use rtseq::Table;
use rtseq::{lock::PriorityCeiling, Behaviour, ConditionFn, Cx, Duration, Failure, Instant};
use rtseq::{Error, Handle, Monitor, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step};
use rtseq_qemu_f405 as board;

/// The machine: position in µm, speed in µm per tick, the e-stop, the drive's enable.
pub struct Axis {
    position: AtomicI32,
    speed: AtomicI32,
    estop: AtomicBool,
    enable: AtomicBool,
}

/// Drives towards the reference switch at 0 until it is reached.
struct Seek;
impl Step<Axis> for Seek {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().speed.store(-20, Relaxed);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
        cx.control().position.load(Relaxed) <= 0
    }
}

struct Homing {
    seek: Seq<Seek>,
}
impl Sequence<Axis> for Homing {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.step(&mut self.seek).await?; // an abort of the step fails the homing
        cx.control().speed.store(0, Relaxed);
        Ok(())
    }
}

struct SafeStop;
impl Sequence<Axis> for SafeStop {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().speed.store(0, Relaxed);
        Ok(())
    }
}

rtseq::sequences! {
    mod seqs for Axis {
        SEEK = SeqConfig::new("seek"),
        SAFE_STOP = SeqConfig::new("safe stop").in_lane(),
        HOMING = SeqConfig::new("homing")
            .in_lane()
            .timeout(Duration::from_millis(500))
            .timeout_exception(SAFE_STOP)
            .timeout_behaviour(Behaviour::AbortOwner),
    }
}
use seqs::{HOMING, SAFE_STOP, SEEK};

fn over_travel(axis: &Axis, _: Instant) -> bool {
    axis.position.load(Relaxed) < -500
}
rtseq::monitors! {
    mod monitor_ids for Axis, ConditionFn<Axis> {
        OVER_TRAVEL = Monitor::with_fn("over-travel", over_travel, Behaviour::AbortOwner)
            .exception(SAFE_STOP)
            .owned_by(HOMING),
    }
}

// Safety: in `run` a pressed e-stop leads to `emergency`, which disables the drive and
// aborts every sequence.
const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
const RUN: SafetyLevel = SafetyLevel::new(1);
const ESTOP: PrivateEvent = PrivateEvent::new(0);
const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "e-stop pressed");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
const LEVELS: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
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
);
static PROPS: ValidProperties<'static, Io, 2> = match LEVELS.validated() {
    Ok(p) => p,
    Err(_) => panic!("invalid safety properties"),
};
pub struct Io; // the safety system's inputs and outputs
impl SafetyIo for Io {
    fn read_input(&mut self, _: InputId) -> IoValue {
        IoValue::Bool(AXIS.estop.load(Relaxed))
    }
    fn write_output(&mut self, _: OutputId, on: IoValue) {
        AXIS.enable.store(on == IoValue::Bool(true), Relaxed);
    }
}

// Checked by the compiler, with the monitors: every exception sequence has a lane.
static TABLE: Table<Axis, { seqs::COUNT }> = match seqs::table() {
    Ok(t) => match monitor_ids::validate(&t) {
        Ok(()) => t,
        Err(e) => panic!("{}", e.message().as_str()),
    },
    Err(e) => panic!("{}", e.message().as_str()),
};
// SAFETY: SEQ is used at the tick's priority 2 and below; the safety task (3) only calls
// the `Sequences` methods (through its cycle), which take no lock.
static SEQ: Sequencer<Axis, { seqs::COUNT }, 64, PriorityCeiling<2>> =
    unsafe { Sequencer::with_priority_ceiling() };
static AXIS: Axis = Axis {
    position: AtomicI32::new(1_000),
    speed: AtomicI32::new(0),
    estop: AtomicBool::new(false),
    enable: AtomicBool::new(false),
};

fn or_exit<T, E: defmt::Format>(r: Result<T, E>) -> T {
    r.unwrap_or_else(|e| {
        defmt::error!("minimal: {}", e);
        board::exit_failure()
    })
}

fn handle(id: SeqId) -> Handle<'static, Axis> {
    or_exit(SEQ.sequence_by_id(id).ok_or(Error::UnknownSequence(id)))
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
        safe_stop: Seq<SafeStop>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let monitors = const {
            match monitor_ids::table() {
                Ok(m) => m,
                Err(e) => panic!("{}", e.message().as_str()),
            }
        };
        or_exit(SEQ.install(&TABLE));
        let seek = or_exit(SEQ.bind(SEEK, Seek));
        let homing = or_exit(SEQ.bind(HOMING, Homing { seek }));
        let safe_stop = or_exit(SEQ.bind(SAFE_STOP, SafeStop));
        let safety = or_exit(SafetySystem::new_validated(&PROPS, SEQ.safety_handle()));
        or_exit(handle(HOMING).start()); // at the sequencer's time 0
        lanes::spawn().ok();
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (
            Shared {},
            Local {
                timer,
                monitors,
                safety,
                homing,
                safe_stop,
            },
        )
    }

    /// The heartbeat: the safety cycle, the control step, then monitors, timeouts, wake-ups.
    #[task(binds = TIM2, priority = 2, local = [timer, monitors])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        rtic::pend(Interrupt::EXTI0); // the safety task preempts right here
        if AXIS.enable.load(Relaxed) {
            AXIS.position.fetch_add(AXIS.speed.load(Relaxed), Relaxed);
        }
        if let Err(e) = SEQ.tick(now, &AXIS, cx.local.monitors) {
            defmt::error!("minimal: tick: {}", e); // report, carry on
        }
    }

    #[task(binds = EXTI0, priority = 3, local = [safety, io: Io = Io])]
    fn safety(cx: safety::Context) {
        cx.local.safety.cycle(cx.local.io, &SEQ); // may abort every sequence
    }

    /// The lanes (non-blocking and exception sequences), joined in one task.
    #[task(priority = 1, local = [homing, safe_stop])]
    async fn lanes(cx: lanes::Context) {
        let (homing, safe_stop) = (cx.local.homing, cx.local.safe_stop);
        match rtseq::lanes!(&SEQ, &AXIS, homing, safe_stop).await {}
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        or_exit(SEQ.check_lanes()); // no lane task is missing
        loop {
            if let Some(outcome) = handle(HOMING).last_outcome() {
                defmt::info!("minimal: homing {} at {}", outcome, SEQ.now());
                board::exit_success();
            }
            cortex_m::asm::wfi();
        }
    }
}
