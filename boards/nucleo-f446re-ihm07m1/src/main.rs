//! rtseq's motor-controller application on a real board: NUCLEO-F446RE + X-NUCLEO-IHM07M1
//! driving a brushed DC motor with a quadrature encoder. The same sequences, monitors and
//! safety levels as the QEMU demo and the host tests ([`rtseq_motor::app::register`]), over
//! real peripherals.
//!
//! | task | priority | trigger | does |
//! |---|---|---|---|
//! | `safety` | 3 (highest) | pended by `control` at the start of every period | one safety cycle ([`rtseq_motor::safety::safety_cycle`]); when the drive permit is withdrawn it switches the bridge off and engages the brake **itself**, at once |
//! | `control` | 2 | TIM6 update, 1 kHz | fault-plan time, pends `safety`, samples the sensors, [`ControlSystem::control_step_measured`], writes PWM / enables / brake, `SEQ.tick`, feeds the watchdog |
//! | `lanes` | 1 | woken by the tick | the five lanes of the application joined in one future ([`App::run`]) |
//! | `idle` | 0 | — | logs the status four times a second, sleeps (`wfi`) |
//!
//! Nothing moves until the user button B1 is pressed; from then on B1 is the pause button.
//! With B1 held at reset the firmware is in bring-up mode instead: B1 runs the open-loop
//! jog ([`rtseq_motor::bringup`]), which checks the motor's direction and the current
//! legs, and the application never starts.
//! Pins and jumpers: [`pins`]. Safe state everywhere an error can happen: bridge off, brake
//! engaged (init errors, a panic, a hard fault, a stopped control loop via the watchdog).
#![no_std]
#![no_main]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use defmt_rtt as _;

pub mod drive;
pub mod pins;
pub mod sensors;

use rtseq::safety::ValidProperties;
use rtseq_motor::app::{AppConfig, Travel};
use rtseq_motor::bringup::{Direction, JogConfig, JogStep, JogStop, Legs};
use rtseq_motor::control_system::ControlSystem;
use rtseq_motor::controller::{DriveLimits, Limits, M_EQ};
use rtseq_motor::plant::{COULOMB, END_STOP_NEG, END_STOP_POS, M_PER_RAD};
use rtseq_motor::safety::{DriveIo, Watches};

/// Control rate, Hz: TIM6's update rate and the sequencer's tick.
pub const CONTROL_HZ: u32 = 1_000;
/// Control period, s (TIM6 at 1 kHz).
pub const DT: f32 = 1.0 / CONTROL_HZ as f32;

/// The sequencer's time after `periods` control periods: a 64-bit count, which never wraps
/// (a 32-bit one at 1 kHz would after 49.7 days, and every tick after that would be
/// earlier than the last).
///
/// The boundary between the two `fugit`s of this firmware: stm32f4xx-hal's timers take
/// fugit 0.3 rates (`CONTROL_HZ.Hz()` in `init`), rtseq's `Instant` is fugit 0.6. No value
/// of one crosses into the other; both are made from the plain integers here.
pub fn control_time(periods: u64) -> rtseq::Instant {
    const PERIOD_US: u64 = 1_000_000 / CONTROL_HZ as u64;
    rtseq::Instant::from_ticks(periods.saturating_mul(PERIOD_US))
}
/// Watchdog timeout, ms: the control loop feeds it every period in which the sequencer's
/// tick did its work, or failed fewer than [`TICK_ERRORS_TOLERATED`] times in a row.
pub const WATCHDOG_MS: u32 = 50;
/// Tick errors in a row after which the control loop stops feeding the watchdog: a tick
/// that keeps failing evaluates no monitor and no timeout (its time base is broken).
pub const TICK_ERRORS_TOLERATED: u32 = 10;

/// Puts the power stage in its safe state straight through the registers, whatever owns the
/// pins: EN1–EN3 low (PC10–PC12), DIAG/EN driven low (PA11, an open-drain output from init
/// on), the brake engaged (PB12 low), TIM1's outputs off. For the panic and fault handlers,
/// which cannot borrow the drivers.
pub fn force_safe_outputs() {
    // SAFETY: single writes to set/reset registers (BSRR: atomic, no read-modify-write) and
    // a clear of TIM1's main-output-enable; the panic and fault handlers never return to the
    // code that owns these peripherals.
    unsafe {
        let gpioc = &*stm32f4xx_hal::pac::GPIOC::ptr();
        gpioc
            .bsrr()
            .write(|w| w.br10().set_bit().br11().set_bit().br12().set_bit());
        let gpioa = &*stm32f4xx_hal::pac::GPIOA::ptr();
        gpioa.bsrr().write(|w| w.br11().set_bit());
        let gpiob = &*stm32f4xx_hal::pac::GPIOB::ptr();
        gpiob.bsrr().write(|w| w.br12().set_bit());
        let tim1 = &*stm32f4xx_hal::pac::TIM1::ptr();
        tim1.bdtr()
            .modify(|_, w| w.moe().clear_bit().aoe().clear_bit());
    }
}

/// Panic: outputs safe first, then the message, then a breakpoint-like fault that ends a
/// `probe-rs run` session.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    force_safe_outputs();
    defmt::error!("panic: {}", defmt::Display2Format(info));
    cortex_m::asm::udf()
}

/// Hard fault: outputs safe, report, stop.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    force_safe_outputs();
    defmt::error!("hard fault at pc = {=u32:#010x}", frame.pc());
    loop {
        cortex_m::asm::bkpt();
    }
}

/// An interrupt or exception nothing handles: outputs safe, report, stop (the watchdog,
/// no longer fed, then resets the chip). The runtime's default would loop with the power
/// stage as it was.
#[cortex_m_rt::exception]
unsafe fn DefaultHandler(irqn: i16) -> ! {
    force_safe_outputs();
    defmt::error!("unexpected interrupt {=i16}", irqn);
    loop {
        cortex_m::asm::bkpt();
    }
}

/// What the safety levels watch on this board: the motor application's inputs, with the
/// board's over-current trip ([`sensors::CURRENT_TRIP`]).
static WATCHES: Watches = Watches::new(sensors::CURRENT_TRIP);
/// The motor application's safety table for this board, validated by the compiler.
static PROPERTIES: ValidProperties<'static, DriveIo, 4> =
    match rtseq_motor::safety::properties(&WATCHES).validated() {
        Ok(valid) => valid,
        Err(_) => panic!("invalid safety properties"),
    };

// defmt timestamps: milliseconds of control time.
defmt::timestamp!(
    "{=u32}ms",
    app::TICKS.load(core::sync::atomic::Ordering::Relaxed)
);

/// The controller's drive limits on this board (domain review F2): the servo's current
/// limit is the bridge's [`drive::I_LIMIT`] (not the simulated drive's 4 A, which the
/// bridge would clip while the servo's integrator kept winding), and a quick stop
/// decelerates at what the bridge holds on the axis: `(KF·I_LIMIT − friction) / M_EQ`
/// ([`DriveLimits::max_quick_stop_decel`]) ≈ 2.25 m/s², from the motor constants the
/// duty conversion uses ([`drive::MotorModel::DEFAULT`]'s `ke`, the torque constant in
/// SI units) and the axis the controller is tuned for ([`rtseq_motor::controller::M_EQ`],
/// [`rtseq_motor::plant::M_PER_RAD`], [`rtseq_motor::plant::COULOMB`]). Change them with
/// the motor and the mechanics.
pub const DRIVE: DriveLimits = {
    let kf = drive::MotorModel::DEFAULT.ke / M_PER_RAD;
    let friction = COULOMB / M_PER_RAD;
    DriveLimits {
        i_max: drive::I_LIMIT,
        quick_stop_decel: DriveLimits::max_quick_stop_decel(drive::I_LIMIT, kf, M_EQ, friction),
    }
};
// The bridge holds the quick stop, and a quick stop is no gentler than the moves' own ramp
// (else a feed hold would stop sooner than the safe stop).
const _: () = {
    let kf = drive::MotorModel::DEFAULT.ke / M_PER_RAD;
    assert!(DRIVE.i_max <= drive::I_LIMIT);
    assert!(M_EQ * DRIVE.quick_stop_decel + COULOMB / M_PER_RAD <= kf * DRIVE.i_max);
    assert!(DRIVE.quick_stop_decel >= Limits::MOVE.a_max);
};
/// Distance a quick stop from full speed needs with [`DRIVE`], detected one control period
/// late, m (≈ 9.1 mm): the hard stops must sit at least this far (plus a reserve) beyond
/// the end-stop switches, or `Limits::MOVE.v_max` be lowered.
pub const STOPPING_DISTANCE: f32 = DRIVE.stopping_distance(Limits::MOVE.v_max, DT);

/// Reserve between a soft travel limit and the stopping distance, m.
const TRAVEL_RESERVE: f32 = 0.0005;
/// The soft travel limits on this board: the axis' switch span (set it to the real axis),
/// inset at each end by this bridge's [`STOPPING_DISTANCE`] plus a reserve, so a move that
/// runs away from a soft limit at full speed stops before the switch.
pub const TRAVEL: Travel = Travel {
    min: STOPPING_DISTANCE + TRAVEL_RESERVE,
    max: (END_STOP_POS - END_STOP_NEG) - STOPPING_DISTANCE - TRAVEL_RESERVE,
};
const _: () = assert!(TRAVEL.min < TRAVEL.max);
/// The application's parameters on this board: the defaults with [`TRAVEL`].
pub const CONFIG: AppConfig = AppConfig {
    travel: TRAVEL,
    ..AppConfig::DEFAULT
};

/// The bring-up jog: the defaults, its own current limit the bridge's.
pub const JOG: JogConfig = JogConfig {
    trip_amps: drive::I_LIMIT,
    ..JogConfig::DEFAULT
};

/// What to do about the motor's direction the jog found.
fn direction_advice(d: Direction) -> &'static str {
    match d {
        Direction::Correct => "correct",
        Direction::Reversed => "reversed: swap the motor wires on OUT1 / OUT2",
        Direction::NoMotion => {
            "the motor did not turn: check the motor wiring and the brake, or raise JogConfig::volts"
        }
        Direction::Inconsistent => {
            "not one way and back (one way only, or the same way twice): check the mechanics, then jog again"
        }
    }
}

/// What to do about the current legs the jog found.
fn legs_advice(l: Legs) -> &'static str {
    match l {
        Legs::Correct => "correct",
        Legs::SignInverted => "sign inverted: set sensors::CURRENT_SIGN = -1.0",
        Legs::Swapped => {
            "swapped: swap CurrentU / CurrentV in src/pins.rs (and their pins in init)"
        }
        Legs::SwappedOrInverted => {
            "read negative: the inputs swapped (src/pins.rs) or the amplifiers inverted (sensors::CURRENT_SIGN); this jog cannot tell which: check PA0 / PC1 against UM1943"
        }
        Legs::NoCurrent => {
            "no current: check the motor circuit and the three-shunt jumpers J5 / J6"
        }
        Legs::Inconsistent => "inconsistent: check the jumpers and the amplifiers, then jog again",
    }
}

/// Logs how a jog ended.
fn log_jog(end: JogStep) {
    match end {
        JogStep::Done(report) => {
            defmt::info!("jog: {}", report);
            defmt::info!(
                "jog: motor direction {}",
                direction_advice(report.direction())
            );
            defmt::info!("jog: current legs {}", legs_advice(report.legs()));
            if report.is_correct() {
                defmt::info!("jog: wiring correct: reset without B1 to run the application");
            }
        }
        JogStep::Stopped(why) => {
            defmt::warn!("jog stopped: {}", why);
            if let JogStop::PermitWithdrawn | JogStop::OverCurrent = why {
                defmt::warn!(
                    "jog: an e-stop, over-current or driver fault leaves the safety system in emergency: reset with B1 held to jog again"
                );
            }
        }
        JogStep::AskPermit | JogStep::Drive(_) | JogStep::Coast => {}
    }
}

/// The status line of the idle loop.
fn log_status(cs: &ControlSystem, level: u8, sw: sensors::Switches) {
    let s = cs.status();
    defmt::info!(
        "{} level {=u8} | x = {=f32} mm (target {}) | v = {=f32} mm/s | i = {=f32} A (cmd {=f32}) | enabled {=bool} brake {=bool} | {}",
        cs.phase(),
        level,
        s.position * 1e3,
        s.target.map(|t| t * 1e3),
        s.velocity * 1e3,
        s.current,
        s.current_command,
        s.enabled,
        s.brake,
        sw
    );
}

#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART6])]
mod app {
    use core::cell::Cell;
    use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

    use critical_section::Mutex;

    use rtseq::lock::PriorityCeiling;
    use rtseq::safety::SafetySystem;
    use rtseq::{MonitorNames, SeqId, Sequencer, WithNames};
    use rtseq_motor::app::seq_ids::MAIN;
    use rtseq_motor::app::{self, App, FaultPlan, Setup};
    use rtseq_motor::bringup::{Jog, JogSample, JogStep};
    use rtseq_motor::control_system::ControlSystem;
    use rtseq_motor::hardware::DriveCommand;
    use rtseq_motor::safety::{self as levels, safety_cycle, DriveIo};
    use stm32f4xx_hal::adc::config::{AdcConfig, Clock};
    use stm32f4xx_hal::adc::Adc;
    use stm32f4xx_hal::gpio::PinState;
    use stm32f4xx_hal::pac;
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::qei::Qei;
    use stm32f4xx_hal::rcc::Config;
    use stm32f4xx_hal::timer::{CounterHz, Event, Flag};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    use super::drive::{Bridge, MotorModel};
    use super::pins;
    use super::sensors::{Sensors, Switches};
    use super::{control_time, CONTROL_HZ};
    use super::{log_jog, log_status, CONFIG, DRIVE, DT, PROPERTIES, WATCHDOG_MS};

    /// The power stage with this board's pins.
    pub type Power = Bridge<
        pins::In1,
        pins::In2,
        pins::En1,
        pins::En2,
        pins::En3,
        pins::Diag,
        pins::BrakeRelease,
    >;

    /// The sequencer: the application's sequences and steps. Its sections raise BASEPRI to
    /// the control task's priority, so they never hold off the safety task.
    // SAFETY: SEQ is used at the control task's priority 2 and below; the safety task (3)
    // only calls the `Sequences` methods, through `safety_cycle`, which take no lock.
    static SEQ: Sequencer<ControlSystem, { app::SEQUENCES }, 64, PriorityCeiling<2>> =
        unsafe { Sequencer::with_priority_ceiling() };
    /// The control system (its simulated plant is not used: the sensors are the truth),
    /// with this board's drive limits ([`DRIVE`]).
    static CS: ControlSystem = ControlSystem::with_drive(CONFIG.start_position, DRIVE);
    /// The sequence table of [`CONFIG`], checked by the compiler: `init` only copies it in.
    static SETUP: Setup = match Setup::new(CONFIG) {
        Ok(setup) => match setup.validate() {
            Ok(()) => setup,
            Err(e) => panic!("{}", e.message().as_str()),
        },
        Err(e) => panic!("{}", e.message().as_str()),
    };
    /// The monitors' names, for the records `idle` prints (the control task owns the table).
    static MONITOR_NAMES: MonitorNames<{ app::monitor_ids::COUNT }> =
        app::monitor_ids::names(&CONFIG);
    /// Control periods since start, wrapping (the defmt timestamp and the idle loop's
    /// pace; the sequencer's clock counts them in 64 bits).
    pub static TICKS: AtomicU32 = AtomicU32::new(0);
    /// The safety level, for the log.
    static LEVEL: AtomicU8 = AtomicU8::new(0);
    /// The switches of the last sample, packed, for the log.
    static SWITCHES: AtomicU32 = AtomicU32::new(0);
    /// Every declared lane has a task that polls it (`idle` checks once): B1 may start.
    static LANES_READY: AtomicBool = AtomicBool::new(false);
    /// What the control task has to report, logged by `idle`: a log is formatted and copied
    /// into the RTT buffer inside a critical section that masks every interrupt, so it
    /// stays out of the control and safety tasks (and `defmt-rtt`'s `disable-blocking-mode`
    /// keeps a full buffer from holding them off while the host is slow or gone).
    static REPORT: Mutex<Cell<Report>> = Mutex::new(Cell::new(Report::NONE));

    /// See [`REPORT`].
    #[derive(Clone, Copy)]
    struct Report {
        /// B1's start of `main`: `Ok` or why it was refused.
        start: Option<Result<(), rtseq::Error>>,
        /// Failed ticks since the last report, and the last one's error.
        tick_errors: u32,
        last_tick_error: Option<rtseq::Error>,
        /// How the bring-up jog ended (`Done` or `Stopped`).
        jog: Option<JogStep>,
    }

    impl Report {
        const NONE: Report = Report {
            start: None,
            tick_errors: 0,
            last_tick_error: None,
            jog: None,
        };
    }

    /// What the power stage gets in a control period.
    enum Output {
        /// The command, at this duty, if the safety system permits driving.
        Drive(DriveCommand, f32),
        /// The safe state.
        Off,
    }

    /// What the bring-up jog commands while it drives: enabled, brake released.
    const JOG_COMMAND: DriveCommand = DriveCommand {
        current: 0.0,
        enable: true,
        brake: false,
    };

    /// Changes what the control task has to report (a short critical section).
    fn report(f: impl FnOnce(&mut Report)) {
        critical_section::with(|cs| {
            let cell = REPORT.borrow(cs);
            let mut r = cell.get();
            f(&mut r);
            cell.set(r);
        });
    }

    #[shared]
    struct Shared {
        /// The power stage: written by `control` every period, forced off by `safety`.
        bridge: Power,
    }

    #[local]
    struct Local {
        timer: CounterHz<pac::TIM6>,
        sensors: Sensors,
        monitors: app::AppMonitors,
        system: Option<SafetySystem<'static, DriveIo, 4>>,
        app: Option<App>,
        main: Option<SeqId>,
        watchdog: IndependentWatchdog,
        led: pins::Led,
        model: MotorModel,
        /// B1 was held at reset: B1 runs the jog, not the application.
        bringup: bool,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        // Debugging: keep the debug port alive in `wfi`, freeze the watchdog at a breakpoint,
        // and stop TIM1 there too: a halted core runs no control loop, no safety task and no
        // watchdog, and a stopped advanced timer disables its outputs as if MOE were cleared
        // (RM0390, TIM1 "Debug mode"), so the bridge does not keep switching at the last duty.
        dp.DBGMCU.cr().modify(|_, w| w.dbg_sleep().set_bit());
        dp.DBGMCU
            .apb1_fz()
            .modify(|_, w| w.dbg_iwdg_stop().set_bit());
        dp.DBGMCU
            .apb2_fz()
            .modify(|_, w| w.dbg_tim1_stop().set_bit());

        // 84 MHz from the internal oscillator (no dependence on the ST-LINK's MCO): APB2
        // timers (TIM1) at 84 MHz, APB1 timers (TIM2, TIM6) at 84 MHz, ADC at 84 / 4 MHz.
        let mut rcc = dp
            .RCC
            .freeze(Config::hsi().sysclk(84.MHz()).pclk1(42.MHz()));

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);

        // Outputs first, in their safe state.
        let en1 = gpioc.pc10.into_push_pull_output_in_state(PinState::Low);
        let en2 = gpioc.pc11.into_push_pull_output_in_state(PinState::Low);
        let en3 = gpioc.pc12.into_push_pull_output_in_state(PinState::Low);
        let brake = gpiob.pb12.into_push_pull_output_in_state(PinState::Low);
        let led = gpioa.pa5.into_push_pull_output_in_state(PinState::Low);
        let (_pwm, (ch1, ch2, ..)) = dp.TIM1.pwm_hz(20.kHz(), &mut rcc);
        let mut in1 = ch1.with(gpioa.pa8);
        let mut in2 = ch2.with(gpioa.pa9);
        in1.set_duty(0);
        in2.set_duty(0);
        in1.enable();
        in2.enable();
        // DIAG/EN: open drain, driven low (the bridges off) until the drive is enabled.
        let diag = gpioa.pa11.into_open_drain_output_in_state(PinState::Low);
        let mut bridge = Bridge::new(in1, in2, en1, en2, en3, diag, brake);
        bridge.off();

        // Sensors.
        let encoder = Qei::new(
            dp.TIM2,
            (
                // JTDI / JTDO after reset: inputs with pull-ups first, then TIM2's AF1.
                gpioa.pa15.into_pull_up_input(),
                gpiob.pb3.into_pull_up_input(),
            ),
            &mut rcc,
        );
        let adc = Adc::new(
            dp.ADC1,
            true,
            AdcConfig::default().clock(Clock::Pclk2_div_4),
            &mut rcc,
        );
        let mut sensors = Sensors::new(
            encoder,
            adc,
            gpioa.pa0.into_analog(),
            gpioc.pc1.into_analog(),
            gpioc.pc8.into_pull_up_input(),
            gpioc.pc6.into_pull_up_input(),
            gpioc.pc5.into_pull_up_input(),
            gpioc.pc13.into_floating_input(),
            gpioa.pa1.into_analog(),
        );
        let bringup = sensors.switches(false).button;
        let (off_u, off_v) = sensors.calibrate();
        defmt::info!(
            "current offsets: U {=f32} V {=f32} ADC counts (expected near 2048)",
            off_u,
            off_v
        );
        let offsets_ok = super::sensors::offsets_plausible(off_u, off_v);
        if !offsets_ok {
            defmt::error!("init: current offsets implausible (check J5/J6): drive stays off");
        }
        // The first safety cycle, before the first control step, reads these (a pressed
        // e-stop, an end stop), not the control system's simulated plant.
        let (first, ..) = sensors.sample(true, false, false);
        CS.update_measurements(&first);

        // The application, its safety system, its lanes.
        CS.set_fault_plan(FaultPlan::NONE);
        // Built by the compiler: no monitor set-up code in the firmware.
        let monitors = const {
            match app::monitor_ids::table(&CONFIG) {
                Ok(m) => m,
                Err(e) => panic!("{}", e.message().as_str()),
            }
        };
        let app = match app::register(&SEQ, &SETUP) {
            Ok(app) => Some(app),
            Err(e) => {
                defmt::error!("init: registering the application failed: {}", e);
                None
            }
        };
        let system = match SafetySystem::new_validated(&PROPERTIES, SEQ.safety_handle()) {
            Ok(s) => Some(s),
            Err(e) => {
                defmt::error!("init: the safety system cannot start: {}", e);
                None
            }
        };
        let main = app.as_ref().map(|_| MAIN);

        let mut timer = dp.TIM6.counter_hz(&mut rcc);
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        if app.is_some() && system.is_some() && offsets_ok {
            if timer.start(CONTROL_HZ.Hz()).is_ok() {
                timer.listen(Event::Update);
                watchdog.start(WATCHDOG_MS.millis());
                if lanes::spawn().is_err() {
                    defmt::error!("init: the lanes task could not be spawned");
                }
                if bringup {
                    defmt::info!(
                        "bring-up (B1 held at reset): press B1 to jog the motor open-loop, motor uncoupled"
                    );
                } else {
                    defmt::info!(
                        "ready: press B1 (blue button) to power on, home and move; B1 again pauses / resumes"
                    );
                }
            } else {
                defmt::error!("init: the 1 kHz control timer cannot be set; drive stays off");
            }
        } else {
            defmt::error!("init failed: the drive stays off (bridge disabled, brake engaged)");
        }

        (
            Shared { bridge },
            Local {
                timer,
                sensors,
                monitors,
                system,
                app,
                main,
                watchdog,
                led,
                model: MotorModel::DEFAULT,
                bringup,
            },
        )
    }

    /// Logs the status four times a second; sleeps in between.
    #[idle]
    fn idle(_: idle::Context) -> ! {
        // The tasks spawned in `init` have run up to their first wait: a declared lane no
        // task polls would take a start (a safe stop) and never run it.
        match SEQ.check_lanes() {
            Ok(()) => LANES_READY.store(true, Ordering::Relaxed),
            Err(e) => defmt::error!("idle: {}: B1 will not start the machine", e),
        }
        let (mut last, mut not_run_seen) = (0u32, 0u16);
        loop {
            // The run as the sequencer recorded it, by name, and what went wrong without a
            // panic (firmware guide, section 5).
            let lost = SEQ.drain_records(|r| {
                defmt::info!("{}", r.named(&(&SEQ, &MONITOR_NAMES)));
            });
            if lost != 0 {
                defmt::warn!("trace: {=u32} records lost", lost);
            }
            let r = critical_section::with(|cs| REPORT.borrow(cs).replace(Report::NONE));
            if let Some(end) = r.jog {
                log_jog(end);
            }
            match r.start {
                Some(Ok(())) => defmt::info!("B1: main started"),
                Some(Err(e)) => defmt::error!("B1: main cannot start: {}", e.named(&SEQ)),
                None => {}
            }
            if let Some(e) = r.last_tick_error {
                defmt::error!("tick failed {=u32} times: {}", r.tick_errors, e.named(&SEQ));
            }
            let not_run = SEQ.exceptions_not_run();
            if not_run != not_run_seen {
                not_run_seen = not_run;
                defmt::error!("{=u16} exception sequences could not run", not_run);
            }
            let now = TICKS.load(Ordering::Relaxed);
            if now.wrapping_sub(last) >= 250 {
                last = now;
                let bits = SWITCHES.load(Ordering::Relaxed);
                let sw = Switches {
                    end_neg: bits & 1 != 0,
                    end_pos: bits & 2 != 0,
                    estop: bits & 4 != 0,
                    driver_fault: bits & 8 != 0,
                    button: bits & 16 != 0,
                };
                log_status(&CS, LEVEL.load(Ordering::Relaxed), sw);
            }
            cortex_m::asm::wfi();
        }
    }

    /// The control loop, 1 kHz: sensors → controller → power stage, then the sequencer's
    /// heartbeat.
    #[task(binds = TIM6_DAC, priority = 2, shared = [bridge],
           local = [timer, sensors, monitors, main, watchdog, led, model, bringup,
                    started: bool = false, button_was: bool = true, periods: u64 = 0,
                    tick_errors: u32 = 0, jog: Option<Jog> = None])]
    fn control(mut cx: control::Context) {
        cx.local.timer.clear_flags(Flag::Update);
        *cx.local.periods += 1;
        TICKS.store(*cx.local.periods as u32, Ordering::Relaxed);
        let now = control_time(*cx.local.periods);

        // The fault plan's time, then the safety cycle (it preempts right here) on the
        // measurements of the previous period, as in the host simulation.
        CS.inject(now);
        rtic::pend(pac::Interrupt::SPI4);

        let (forward, driver_fault) = cx.shared.bridge.lock(|b| (b.forward(), b.driver_fault()));
        let bringup = *cx.local.bringup;
        let (m, sw, shunts) =
            cx.local
                .sensors
                .sample(forward, *cx.local.started && !bringup, driver_fault);
        cx.local.model.supply_v = cx.local.sensors.vbus();
        let cmd: DriveCommand = CS.control_step_measured(&m, DT);
        let output = match cx.local.jog.as_mut() {
            // The jog drives instead of the application (which is not started).
            Some(jog) => {
                let sample = JogSample {
                    counts: cx.local.sensors.counts(),
                    shunts,
                    supply_v: cx.local.model.supply_v,
                    permit: CS.drive_permit(),
                };
                match jog.step(&sample) {
                    JogStep::Drive(duty) => Output::Drive(JOG_COMMAND, duty),
                    JogStep::AskPermit | JogStep::Coast => Output::Off,
                    end @ (JogStep::Done(_) | JogStep::Stopped(_)) => {
                        // The permit back; B1 jogs again.
                        SEQ.safety_handle().trigger(levels::SWITCH_OFF);
                        report(|r| r.jog = Some(end));
                        *cx.local.jog = None;
                        *cx.local.started = false;
                        Output::Off
                    }
                }
            }
            None => {
                let duty = cx
                    .local
                    .model
                    .duty(cmd.current, m.current, CS.status().velocity);
                Output::Drive(cmd, duty)
            }
        };
        cx.shared.bridge.lock(|b| match output {
            // The safety task may have withdrawn the permit since the control step: never
            // switch on against it.
            Output::Drive(cmd, duty) if CS.drive_permit() => b.apply(&cmd, duty),
            Output::Drive(..) | Output::Off => b.off(),
        });

        // In bring-up mode B1 starts a jog: the safety system's permit first (it stays in
        // charge: an e-stop or over-current ends the jog).
        if bringup && !*cx.local.started && sw.button && !*cx.local.button_was {
            SEQ.safety_handle().trigger(levels::SWITCH_ON);
            *cx.local.jog = Some(Jog::new(super::JOG));
            *cx.local.started = true;
        }
        // Start on the first press of B1 (a falling edge of the raw button).
        if !bringup && !*cx.local.started && sw.button && !*cx.local.button_was {
            let ready = LANES_READY.load(Ordering::Relaxed);
            if let Some(h) = cx
                .local
                .main
                .filter(|_| ready)
                .and_then(|id| SEQ.sequence_by_id(id))
            {
                let started = h.start();
                *cx.local.started = started.is_ok();
                report(|r| r.start = Some(started));
            }
        }
        *cx.local.button_was = sw.button;

        match SEQ.tick(now, &CS, cx.local.monitors) {
            Ok(()) => *cx.local.tick_errors = 0,
            Err(e) => {
                *cx.local.tick_errors = cx.local.tick_errors.saturating_add(1);
                report(|r| {
                    r.tick_errors = r.tick_errors.saturating_add(1);
                    r.last_tick_error = Some(e);
                });
            }
        }

        if CS.led() {
            cx.local.led.set_high();
        } else {
            cx.local.led.set_low();
        }
        let bits = u32::from(sw.end_neg)
            | u32::from(sw.end_pos) << 1
            | u32::from(sw.estop) << 2
            | u32::from(sw.driver_fault) << 3
            | u32::from(sw.button) << 4;
        SWITCHES.store(bits, Ordering::Relaxed);
        if *cx.local.tick_errors < crate::TICK_ERRORS_TOLERATED {
            cx.local.watchdog.feed();
        }
    }

    /// The safety system, highest priority: one cycle per control period. Withdrawing the
    /// drive permit switches the power stage off here, not one period later.
    #[task(binds = SPI4, priority = 3, shared = [bridge], local = [system])]
    fn safety(mut cx: safety::Context) {
        let Some(system) = cx.local.system.as_mut() else {
            cx.shared.bridge.lock(|b| b.off());
            return;
        };
        let report = safety_cycle(&CS, system, &SEQ);
        LEVEL.store(report.level.index() as u8, Ordering::Relaxed);
        if !CS.drive_permit() {
            cx.shared.bridge.lock(|b| {
                if b.is_on() {
                    b.off();
                }
            });
        }
        // Its level changes reach the log as the sequencer's records (`idle`).
    }

    /// The application's five lanes, joined (they sleep until the tick wakes them).
    #[task(priority = 1, local = [app])]
    async fn lanes(cx: lanes::Context) {
        if let Some(app) = cx.local.app {
            match app.run(&SEQ, &CS).await {}
        }
    }
}
