//! Failure-path firmware for the QEMU test suite, selected by its first semihosting
//! argument:
//!
//! - `panic` (default): a lane panics at tick 5 → the panic handler logs the message and ends
//!   QEMU with exit code 101;
//! - `hardfault`: executes a permanently undefined instruction (`udf`) → UsageFault escalates
//!   to HardFault → logged, exit code 102;
//! - `fail`: the firmware reports a failure it detected itself → exit code 1;
//! - `hang`: never exits (the host runner's time limit must end it, exit code 124);
//! - `config`: a sequencer whose monitor's exception sequence has no lane fails
//!   `Sequencer::validate` in `init` → the error is logged, exit code 1;
//! - `lanes`: a valid configuration whose `safe stop` lane no task polls (its task was
//!   never spawned) → `Sequencer::check_lanes` at the top of `idle` names it, exit code 1;
//! - `names`: ids, causes, outcomes, failures, transitions, events, records and safety
//!   levels logged with the names of the same sequencer's tables (`WithNames`'s defmt
//!   forms, which the host test compares with their `Display` forms) → exit code 0.
//!
//! Built with `--features no-panic` it must NOT link (it contains an explicit `panic!`): that
//! is the negative half of the no-panic proof.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

/// What the firmware was asked to do.
#[derive(Clone, Copy, PartialEq, Eq, defmt::Format)]
enum Mode {
    Panic,
    HardFault,
    Fail,
    Hang,
    Config,
    Lanes,
    Names,
}

/// Reads the mode from the semihosting command line (`qemu-run panic.elf hardfault`).
fn mode() -> Mode {
    let mut buf = [0u8; 128];
    let mut args = match board::args::args(&mut buf) {
        Ok(args) => args,
        Err(e) => {
            defmt::error!("panic firmware: {}", e);
            board::exit_failure();
        }
    };
    match args.next() {
        Some("hardfault") => Mode::HardFault,
        Some("fail") => Mode::Fail,
        Some("hang") => Mode::Hang,
        Some("config") => Mode::Config,
        Some("lanes") => Mode::Lanes,
        Some("names") => Mode::Names,
        _ => Mode::Panic,
    }
}

/// A configuration mistake a firmware engineer makes: the jam monitor's exception
/// sequence, `safe stop`, was never given a lane. `validate` finds it before the first tick.
mod config {
    use super::board;
    use rtseq::{Behaviour, Instant, Monitor, SeqConfig, Sequencer};

    pub(super) type Cond = fn(&(), Instant) -> bool;
    pub(super) fn jammed(_: &(), _: Instant) -> bool {
        false
    }
    rtseq::sequences! {
        pub(super) mod seqs for () {
            SAFE_STOP = SeqConfig::new("safe stop"),
            MAIN = SeqConfig::new("main"),
        }
    }
    rtseq::monitors! {
        pub(super) mod monitor_ids for (), Cond {
            JAM = Monitor::with_condition("jam", jammed as Cond, Behaviour::AbortOwner)
                .exception(seqs::SAFE_STOP)
                .owned_by(seqs::MAIN),
        }
    }
    pub(super) static SEQ: Sequencer<(), { seqs::COUNT }> = Sequencer::new();

    /// Builds the configuration and validates it: the error is logged, the firmware ends.
    pub fn check() -> ! {
        let registered = seqs::table()
            .map_err(|e| e.error)
            .and_then(|t| SEQ.install(&t));
        match (registered, monitor_ids::table::<{ monitor_ids::COUNT }>()) {
            (Ok(()), Ok(monitors)) => match SEQ.validate(&monitors) {
                Err(e) => defmt::error!("panic firmware: invalid configuration: {}", e),
                Ok(()) => defmt::error!("panic firmware: the configuration was accepted"),
            },
            _ => defmt::error!("panic firmware: the configuration could not be built"),
        }
        board::exit_failure()
    }
}

/// Another mistake: every lane is declared (`in_lane`), so `validate` accepts the tree,
/// but the task that runs the `safe stop` lane was never spawned. A jam would start the
/// safe stop and nothing would run it; `check_lanes` in `idle` finds the lane first.
mod lanes {
    use super::board;
    use super::config::{jammed, Cond};
    use core::convert::Infallible;
    use rtseq::{
        Behaviour, Cx, Failure, Monitor, SeqConfig, Sequence, Sequencer, Table, WithNames,
    };

    rtseq::sequences! {
        pub(super) mod seqs for () {
            MAIN = SeqConfig::new("main").in_lane(),
            SAFE_STOP = SeqConfig::new("safe stop").in_lane(),
        }
    }
    rtseq::monitors! {
        pub(super) mod monitor_ids for (), Cond {
            JAM = Monitor::with_condition("jam", jammed as Cond, Behaviour::AbortOwner)
                .exception(seqs::SAFE_STOP)
                .owned_by(seqs::MAIN),
        }
    }
    /// Checked by the compiler: every exception sequence has a lane.
    static TABLE: Table<(), { seqs::COUNT }> = match seqs::table() {
        Ok(table) => match monitor_ids::validate(&table) {
            Ok(()) => table,
            Err(e) => panic!("{}", e.message().as_str()),
        },
        Err(e) => panic!("{}", e.message().as_str()),
    };
    pub(super) static SEQ: Sequencer<(), { seqs::COUNT }> = Sequencer::new();

    /// The main sequence: nothing to do.
    struct Main;
    impl Sequence<()> for Main {
        async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
            Ok(())
        }
    }

    /// Installs the table (in `init`).
    pub fn install() {
        if let Err(e) = SEQ.install(&TABLE) {
            defmt::error!("panic firmware: install: {}", e);
            board::exit_failure();
        }
    }

    /// The lane of `main`, the only lane task the firmware spawns.
    pub async fn main_lane() -> Infallible {
        let mut main = match SEQ.bind(seqs::MAIN, Main) {
            Ok(main) => main,
            Err(e) => {
                defmt::error!("panic firmware: bind: {}", e);
                board::exit_failure();
            }
        };
        rtseq::lane(&SEQ, &(), &mut main).await
    }

    /// At the top of `idle`: every spawned lane task has run up to its first wait (`main`,
    /// the first id, was polled: the check names the second).
    pub fn check() -> ! {
        match SEQ.check_lanes() {
            Err(e) => defmt::error!("panic firmware: {}", e.named(&SEQ)),
            Ok(()) => defmt::error!("panic firmware: every lane was polled"),
        }
        board::exit_failure()
    }
}

/// The values a firmware logs, with the names of the `config` sequencer's tables, a table
/// of failure codes and a safety system's levels; what no table names, by number.
mod names {
    use super::{board, config};
    use rtseq::safety::{CriticalInput, LevelDef, SafetyLevel, SafetyProperties};
    use rtseq::{
        Behaviour, Cause, Entry, Error, Event, Failure, Failures, Instant, MonitorId, Outcome,
        Record, Request, Requester, RunningState, SeqId, Transition, WithNames,
    };

    const FAILURES: Failures = Failures(&[(1, "part lost")]);
    const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    const CURRENT: CriticalInput<f32> = CriticalInput::new(3, "current");
    static LEVELS: SafetyProperties<'static, (), 2> = SafetyProperties::new(
        [
            LevelDef::new(SafetyLevel::new(0), "off"),
            LevelDef::new(SafetyLevel::new(1), "powered"),
        ],
        &[ESTOP.info()],
        &[],
        &[],
        SafetyLevel::new(0),
    );

    /// One event of each kind (`tests/qemu.rs` prints the same on the host).
    fn events(main: SeqId, jam: MonitorId) -> [Event; 9] {
        let stop = SeqId::from_index(0);
        [
            Event::Fired {
                owner: main,
                cause: Cause::Monitor(jam),
                behaviour: Behaviour::AbortOwner,
            },
            Event::Fired {
                owner: main,
                cause: Cause::Timeout(main),
                behaviour: Behaviour::RestartOwner,
            },
            Event::ExceptionNotRun {
                exception: stop,
                owner: main,
                why: Error::NoLane(stop),
            },
            Event::Requested {
                sequence: main,
                request: Request::Pause,
                by: Requester::Sequence(stop),
            },
            Event::AbortAll {
                by: Requester::SafetySystem,
            },
            Event::Failed {
                sequence: main,
                failure: Failure::App(1),
            },
            Event::SafetyLevel {
                level: SafetyLevel::new(1),
            },
            Event::InputTripped { input: ESTOP.id() },
            Event::InputTripped {
                input: CURRENT.id(),
            },
        ]
    }

    pub fn print() -> ! {
        let (Ok(()), Ok(monitors)) = (
            config::seqs::table()
                .map_err(|e| e.error)
                .and_then(|t| config::SEQ.install(&t)),
            config::monitor_ids::table::<{ config::monitor_ids::COUNT }>(),
        ) else {
            defmt::error!("panic firmware: the tables could not be built");
            board::exit_failure()
        };
        let names = (&config::SEQ, &monitors, (&FAILURES, &LEVELS));
        let (main, jam) = (config::seqs::MAIN, config::monitor_ids::JAM);
        defmt::info!("names: {}", main.named(&names));
        defmt::info!("names: {}", SeqId::from_index(7).named(&names));
        defmt::info!("names: {}", jam.named(&names));
        defmt::info!("names: {}", MonitorId::from_index(5).named(&names));
        defmt::info!("names: {}", Cause::Timeout(main).named(&names));
        defmt::info!("names: {}", Cause::AbortAll.named(&names));
        defmt::info!(
            "names: {}",
            Outcome::Aborted(Cause::Monitor(jam)).named(&names)
        );
        defmt::info!("names: {}", Outcome::Completed.named(&names));
        defmt::info!("names: {}", Failure::App(1).named(&names));
        defmt::info!("names: {}", Failure::App(9).named(&names));
        defmt::info!("names: {}", Failure::Aborted(Cause::Abort).named(&names));
        defmt::info!(
            "names: {}",
            Failure::NotStarted(Error::AlreadyRunning(main)).named(&names)
        );
        let at = |us: u64, cause: Cause| Transition {
            time: Instant::from_ticks(us),
            sequence: main,
            from: RunningState::Running,
            to: RunningState::Aborting,
            cause,
        };
        defmt::info!("names: {}", at(12_500, Cause::Monitor(jam)).named(&names));
        defmt::info!("names: {}", at(3_000, Cause::Abort).named(&names));
        defmt::info!("names: {}", SafetyLevel::new(1).named(&names));
        defmt::info!("names: {}", SafetyLevel::new(4).named(&names));
        for event in events(main, jam) {
            defmt::info!("names: {}", event.named(&names));
        }
        let record = Record {
            time: Instant::from_ticks(12_500),
            entry: Entry::Event(Event::AbortAll {
                by: Requester::Application,
            }),
        };
        defmt::info!("names: {}", record.named(&names));
        board::exit_success()
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{board, config, lanes, mode, names, Mode};
    use board::clock::TickTimer;
    use board::signal::TickSignal;

    static TO_LANE: TickSignal = TickSignal::new();

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        mode: Mode,
        idle_mode: Mode,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mode = mode();
        defmt::info!("panic firmware: mode {}", mode);
        match mode {
            Mode::Config => config::check(),
            Mode::Names => names::print(),
            Mode::Lanes => {
                lanes::install();
                // The safe stop's lane task is forgotten: only `main`'s is spawned.
                main_lane::spawn().ok();
            }
            _ => {}
        }
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        lane::spawn().ok();
        let local = Local {
            timer,
            mode,
            idle_mode: mode,
        };
        (Shared {}, local)
    }

    #[idle(local = [idle_mode])]
    fn idle(cx: idle::Context) -> ! {
        if *cx.local.idle_mode == Mode::Lanes {
            lanes::check();
        }
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[task(binds = TIM2, priority = 2, local = [timer])]
    fn tick(cx: tick::Context) {
        TO_LANE.signal(cx.local.timer.on_interrupt());
    }

    #[task(priority = 1)]
    async fn main_lane(_: main_lane::Context) {
        match lanes::main_lane().await {}
    }

    #[task(priority = 1, local = [mode])]
    async fn lane(cx: lane::Context) {
        let mode = *cx.local.mode;
        loop {
            let now = TO_LANE.wait().await;
            if now.as_ticks() < 5_000 {
                continue;
            }
            match mode {
                Mode::Panic => panic!("deliberate panic at {} us", now.as_ticks()),
                // SAFETY: deliberately faulting.
                Mode::HardFault => cortex_m::asm::udf(),
                Mode::Fail => {
                    defmt::error!("deliberate failure at {=u64} us", now.as_ticks());
                    board::exit_failure()
                }
                Mode::Hang | Mode::Config | Mode::Lanes | Mode::Names => {}
            }
        }
    }
}
