//! The application's control system: the type `C` that every rtseq sequence, step and
//! condition of this application gets `&C` access to.
//!
//! # Contexts and sharing
//!
//! One [`ControlSystem`] (usually a `static`) is shared by
//!
//! * the **control interrupt**, which calls [`ControlSystem::inject`] and
//!   [`ControlSystem::control_step`] every control period (in the host simulator: the
//!   `Sim::before_tick` hook), followed by the sequencer's
//!   `tick`;
//! * the **safety task**, which reads the critical inputs and drives the critical outputs
//!   ([`crate::safety`]);
//! * the **lanes** (sequences, steps) and the **tick** (monitor conditions), which send
//!   commands and read measurements.
//!
//! There is no `RefCell` shared across contexts: every piece of state is a `Copy` struct in
//! a [`critical_section::Mutex`]`<`[`Cell`]`>`, and every access is one copy in or out inside
//! a critical section (a `memcpy` of at most ~200 bytes, bounded). The computation of a
//! control step runs outside any critical section on a private copy of the plant and
//! controller state, which only the control step writes (call it from one context only).
//!
//! Commands are **requests**: they are queued in a mailbox and applied by the next control
//! step, which then acknowledges them ([`ControlSystem::commands_done`]); steps use that in
//! their exit conditions, so a measurement read after the acknowledgement always refers to
//! the new command (e.g. "in position" to the new target, never to the previous one).
//!
//! # Coordinates
//!
//! Positions are in metres in **homed coordinates**: the encoder position minus the zero
//! set by [`ControlSystem::set_zero`] (before homing, the zero is the power-up position).
//!
//! ```
//! use rtseq::Instant;
//! use rtseq_motor::control_system::ControlSystem;
//! let cs = ControlSystem::new(0.02);
//! cs.brake(false);
//! cs.enable(true);
//! cs.control_step(0.001); // applies the brake release and the enable
//! assert!(cs.commands_done() && cs.status().enabled);
//! cs.move_to(0.01);
//! for ms in 1..=300 {
//!     cs.inject(Instant::from_ticks(ms * 1000));
//!     cs.control_step(0.001);
//! }
//! assert!(cs.in_position());
//! assert!((cs.position() - 0.01).abs() < 20e-6);
//! ```

use core::cell::Cell;

use critical_section::Mutex;
use rtseq::{Duration, Instant};

use crate::app::{Fault, FaultPlan, Reaction, Summary, MAX_FAULTS};
use crate::controller::{DriveLimits, Gains, Limits, Profile, Servo};
use crate::hardware::{DriveCommand, Measurements};
use crate::plant::{Plant, PlantFaults};

/// "In position": |target − position| within this, m (20 µm = 16 encoder counts).
pub const POSITION_TOLERANCE: f32 = 20e-6;
/// "At standstill": |measured velocity| within this, m/s (4 encoder counts per ms).
pub const STANDSTILL_VELOCITY: f32 = 5e-3;
/// "Settled": in position and at standstill continuously for this long, s.
pub const SETTLE_TIME: f32 = 0.020;
/// "Motor stopped" for the reaction records: |true current| within this, A.
pub const STOPPED_CURRENT: f32 = 0.3;
/// Current-sensor offset injected by [`Fault::OverCurrent`], A (reads above the trip level).
pub const OVERCURRENT_OFFSET: f32 = 12.0;
/// How long an injected press of the pause button lasts, µs.
pub const BUTTON_PRESS_US: u64 = 20_000;

/// What the application is doing; the status sequence blinks the LED at a rate per phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Not started.
    #[default]
    Off,
    /// Enabling the drive.
    PowerOn,
    /// Homing.
    Homing,
    /// Point-to-point moves.
    Moving,
    /// Moves paused (feed hold).
    Paused,
    /// A safe stop is running.
    SafeStop,
    /// All moves done.
    Done,
    /// Ended after a fault (moves or homing aborted).
    Fault,
}

impl Phase {
    /// True when the application has ended (the status sequence stops blinking).
    pub const fn is_final(self) -> bool {
        matches!(self, Phase::Done | Phase::Fault)
    }
}

/// A motion command of the mailbox.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motion {
    /// Point-to-point move to a position, m (homed coordinates).
    MoveTo(f32),
    /// Jog at a velocity, m/s.
    Jog(f32),
    /// Homing seek towards the negative end stop at a speed, m/s (the magnitude is used):
    /// if its switch is closed, first leave it in the positive direction until it opens,
    /// then approach it; the encoder position where the switch closes during the approach
    /// is latched as the home edge ([`ControlSystem::seek_home`]).
    Seek(f32),
    /// Decelerate to a standstill at the normal deceleration, then hold.
    Stop,
    /// Re-synchronise the setpoint with the measured state and stop at the quick-stop
    /// deceleration; the servo integrator is emptied.
    QuickStop,
    /// Feed hold: decelerate, keep the move to resume it.
    FeedHold,
    /// Resume a held move.
    FeedResume,
}

/// The command mailbox (written by lanes, taken by the control step).
///
/// Stop requests have a slot of their own, latched with priority over motion until the
/// next control step applies them: a stop (the abort hook in the tick, the safe stop's
/// lane) is never replaced by a move or jog another lane asks for in the same period —
/// while the axis moves, that motion is dropped (domain review F3). Only if the axis
/// already stands still, so the stop has nothing to stop, does a motion asked for after
/// it follow it in the same period (a restarted move right after its predecessor's abort
/// hook). A motion asked for before a stop is replaced by it. Between stops the stronger
/// one wins: quick stop over stop over feed hold.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Requests {
    enable: Option<bool>,
    brake: Option<bool>,
    zero: bool,
    /// Move, jog or feed resume: last writer wins; with `stop` set, one asked for after it.
    motion: Option<Motion>,
    /// Quick stop, stop or feed hold: the strongest one asked for.
    stop: Option<Motion>,
    issued: u32,
}

/// The strength of a stop request (higher wins in the mailbox).
fn stop_rank(m: Option<Motion>) -> u8 {
    match m {
        Some(Motion::QuickStop) => 3,
        Some(Motion::Stop) => 2,
        Some(Motion::FeedHold) => 1,
        _ => 0,
    }
}

/// Where the homing seek is ([`Motion::Seek`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Seek {
    /// No seek (any other motion ends it).
    Off,
    /// The negative switch was closed at the start: jogging off it (+) at this speed, m/s.
    Leaving(f32),
    /// Jogging towards the negative switch (−); its closing edge is latched.
    Approaching,
}

/// Plant and controller: written only by the control step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Core {
    plant: Plant,
    profile: Profile,
    servo: Servo,
    gains: Gains,
    /// The quick stop's deceleration, m/s² ([`DriveLimits::quick_stop_decel`]).
    quick_stop_decel: f32,
    /// Encoder position of the homed zero, m.
    zero: f32,
    /// The homing seek's state.
    seek: Seek,
    /// The negative end-stop switch in the previous sample (edge detection).
    switch_neg: bool,
    /// Encoder position (raw, m) latched at the negative switch's closing edge during the
    /// last homing seek's approach: the home position [`ControlSystem::set_zero`] takes.
    home_edge: Option<f32>,
    homed: bool,
    enabled: bool,
    brake: bool,
    settled_for: f32,
    acked: u32,
    /// The last sample of a real drive ([`ControlSystem::control_step_measured`],
    /// [`ControlSystem::update_measurements`]; raw: without injected sensor faults);
    /// `None` while the simulated plant is the drive.
    hw: Option<Measurements>,
    /// The last command to the power stage.
    drive: DriveCommand,
}

/// Inputs and outputs that are not the control loop's: injected faults, the pause button,
/// the safety system's outputs, the time of the last control tick.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Io {
    now: Instant,
    plant_faults: PlantFaults,
    pause_button: bool,
    /// The sampled pause button of a real drive.
    hw_pause_button: bool,
    drive_permit: bool,
    brake_forced: bool,
}

/// Application bookkeeping: phase, status LED, fault plan, summary.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AppState {
    phase: Phase,
    led: bool,
    plan: FaultPlan,
    summary: Summary,
}

/// A consistent snapshot of the measurements and drive state.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Measured position (encoder, homed coordinates), m.
    pub position: f32,
    /// Measured velocity (encoder difference), m/s.
    pub velocity: f32,
    /// Measured current (current sensor, including an injected offset), A.
    pub current: f32,
    /// True motor current (simulation truth, for checks), A.
    pub true_current: f32,
    /// Current command of the servo, A.
    pub current_command: f32,
    /// Profile (setpoint) position, m.
    pub setpoint: f32,
    /// Target of the current move, m.
    pub target: Option<f32>,
    /// Following error = setpoint − measured position, m.
    pub following_error: f32,
    /// The profile is done, the axis within [`POSITION_TOLERANCE`] of the setpoint and at
    /// standstill, for [`SETTLE_TIME`].
    pub in_position: bool,
    /// |measured velocity| within [`STANDSTILL_VELOCITY`] and the profile at rest.
    pub standstill: bool,
    /// Negative end-stop switch closed.
    pub end_stop_neg: bool,
    /// Positive end-stop switch closed.
    pub end_stop_pos: bool,
    /// Emergency-stop button pressed.
    pub estop: bool,
    /// Pause button pressed (raw).
    pub pause_button: bool,
    /// Drive enabled (commanded and permitted by the safety system).
    pub enabled: bool,
    /// Brake engaged.
    pub brake: bool,
    /// The zero was set by homing.
    pub homed: bool,
}

/// The motor controller's control system: plant (simulated machine), controller, command
/// mailbox, fault injection and application bookkeeping. See the [module docs](self).
pub struct ControlSystem {
    core: Mutex<Cell<Core>>,
    requests: Mutex<Cell<Requests>>,
    io: Mutex<Cell<Io>>,
    app: Mutex<Cell<AppState>>,
}

impl ControlSystem {
    /// A machine at rest at machine position `start` (m; the negative end stop is at 0),
    /// drive disabled, brake engaged, no faults planned, with the simulated drive's limits
    /// ([`DriveLimits::SIMULATED`]). `const`: can be a `static`.
    pub const fn new(start: f32) -> Self {
        Self::with_drive(start, DriveLimits::SIMULATED)
    }

    /// Like [`new`](Self::new), for a drive with the limits `drive`: the servo's current
    /// limit ([`Gains::i_max`]) is `drive.i_max`, quick stops decelerate at
    /// `drive.quick_stop_decel`. A real board sets its power stage's (domain review F2).
    pub const fn with_drive(start: f32, drive: DriveLimits) -> Self {
        ControlSystem {
            core: Mutex::new(Cell::new(Core {
                plant: Plant::new(start),
                profile: Profile::new(0.0, Limits::MOVE),
                servo: Servo::new(),
                gains: Gains {
                    i_max: drive.i_max,
                    ..Gains::DEFAULT
                },
                quick_stop_decel: drive.quick_stop_decel,
                zero: 0.0,
                seek: Seek::Off,
                switch_neg: false,
                home_edge: None,
                homed: false,
                enabled: false,
                brake: true,
                settled_for: 0.0,
                acked: 0,
                hw: None,
                drive: DriveCommand::SAFE,
            })),
            requests: Mutex::new(Cell::new(Requests {
                enable: None,
                brake: None,
                zero: false,
                motion: None,
                stop: None,
                issued: 0,
            })),
            io: Mutex::new(Cell::new(Io {
                now: Instant::from_ticks(0),
                plant_faults: PlantFaults::NONE,
                pause_button: false,
                hw_pause_button: false,
                drive_permit: true,
                brake_forced: false,
            })),
            app: Mutex::new(Cell::new(AppState {
                phase: Phase::Off,
                led: false,
                plan: FaultPlan::NONE,
                summary: Summary::EMPTY,
            })),
        }
    }

    /// Sets the fault plan (before the run; e.g. from the firmware's command line). The
    /// encoder's power-up position becomes the zero until homing sets it.
    pub fn set_fault_plan(&self, plan: FaultPlan) {
        self.update_app(|a| a.plan = plan);
    }

    /// The fault plan.
    pub fn fault_plan(&self) -> FaultPlan {
        self.read_app().plan
    }

    // ---- the control loop -------------------------------------------------------------

    /// Applies the fault plan at time `now` (the control tick's time, also used for the
    /// summary's records): faults whose time has come are switched on, the pause button is
    /// pressed for [`BUTTON_PRESS_US`] at the start and at the end of the pause window.
    /// Call it right before [`control_step`](Self::control_step).
    pub fn inject(&self, now: Instant) {
        let plan = self.read_app().plan;
        let mut faults = PlantFaults::default();
        let mut injected: [Option<(Fault, Instant)>; MAX_FAULTS] = [None; MAX_FAULTS];
        for (slot, fault) in injected.iter_mut().zip(plan.faults.iter()) {
            let Some(fault) = *fault else { continue };
            let at = fault.at();
            if now < at {
                continue;
            }
            match fault {
                Fault::FollowingError { .. } => faults.jammed = true,
                Fault::OverCurrent { .. } => faults.current_sensor_offset = OVERCURRENT_OFFSET,
                Fault::EndStop { .. } => faults.end_stop_pos_closed = true,
                Fault::EStop { .. } => faults.estop_pressed = true,
            }
            *slot = Some((fault, at));
        }
        let pressed = |t: Instant| {
            now.checked_duration_since(t)
                .is_some_and(|d| d < Duration::from_ticks(BUTTON_PRESS_US))
        };
        let button = plan
            .pause
            .is_some_and(|w| pressed(w.start) || pressed(w.end));
        critical_section::with(|cs| {
            let io = self.io.borrow(cs);
            let mut v = io.get();
            v.now = now;
            v.plant_faults = faults;
            v.pause_button = button;
            io.set(v);
        });
        self.update_app(|a| {
            for (fault, at) in injected.iter().flatten() {
                let r = a.summary.reaction_mut(fault.kind());
                if r.injected.is_none() {
                    r.injected = Some(*at);
                }
            }
        });
    }

    /// One control period of `dt` seconds on the simulated machine: reads its sensors,
    /// applies the pending commands, runs the setpoint generator and the servo on the
    /// encoder reading (the same code as [`control_step_measured`](Self::control_step_measured)),
    /// and advances the plant with the resulting [`DriveCommand`].
    ///
    /// Call it from one context only (the control interrupt).
    pub fn control_step(&self, dt: f32) {
        let req = self.take_requests();
        let io = self.read_io();
        let mut c = critical_section::with(|cs| self.core.borrow(cs).get());
        *c.plant.faults_mut() = io.plant_faults;
        let m = Measurements::of_plant(&c.plant);
        let cmd = regulate(&mut c, req, &io, &m, dt);
        c.plant.set_enabled(cmd.enable);
        c.plant.set_brake(cmd.brake);
        c.plant.step(cmd.current, dt);
        critical_section::with(|cs| self.core.borrow(cs).set(c));

        // Reaction records: the first time the motor is stopped after a reaction.
        self.record_stopped(
            &io,
            c.plant.velocity().abs() <= STANDSTILL_VELOCITY
                && c.plant.current().abs() <= STOPPED_CURRENT,
        );
    }

    /// One control period of `dt` seconds on a **real drive**: `m` is the sample of its
    /// sensors taken at the start of the period (raw: the sensor faults of the fault plan
    /// are applied here), the result is what to write to the power stage until the next
    /// call. Applies the pending commands and runs the setpoint generator and the servo
    /// exactly like [`control_step`](Self::control_step); from the first call on, every
    /// measurement this control system reports ([`status`](Self::status), the safety
    /// system's inputs, the monitors' conditions) comes from these samples, and
    /// [`plant`](Self::plant) is no longer stepped.
    ///
    /// Call it from one context only (the control interrupt), after
    /// [`inject`](Self::inject) (which sets the time).
    pub fn control_step_measured(&self, m: &Measurements, dt: f32) -> DriveCommand {
        let req = self.take_requests();
        let io = self.read_io();
        let mut c = critical_section::with(|cs| self.core.borrow(cs).get());
        let sample = m.with_sensor_faults(&io.plant_faults);
        let cmd = regulate(&mut c, req, &io, &sample, dt);
        c.hw = Some(*m);
        critical_section::with(|cs| {
            self.core.borrow(cs).set(c);
            self.set_hw_pause_button(cs, m.pause_button);
        });

        // Reaction records: no simulation truth here, the measurements decide (the raw
        // current: an injected sensor offset must not hide a stopped motor).
        self.record_stopped(
            &io,
            c.servo.velocity().abs() <= STANDSTILL_VELOCITY && m.current.abs() <= STOPPED_CURRENT,
        );
        cmd
    }

    /// [`inject`](Self::inject) then [`control_step_measured`](Self::control_step_measured):
    /// the whole control interrupt of a real board.
    pub fn control_tick_measured(&self, now: Instant, m: &Measurements, dt: f32) -> DriveCommand {
        self.inject(now);
        self.control_step_measured(m, dt)
    }

    /// Stores a newer sample of a real drive without running the controller: what
    /// [`status`](Self::status), the safety system and the monitors see until the next
    /// control step. For drives sampled faster than the control period, and for machines
    /// simulated in the loop, whose state at the end of the period is known at once (then
    /// the run is bit-identical to [`control_step`](Self::control_step) on the same plant).
    ///
    /// Call it from the context that runs the control step.
    pub fn update_measurements(&self, m: &Measurements) {
        critical_section::with(|cs| {
            let cell = self.core.borrow(cs);
            let mut c = cell.get();
            c.hw = Some(*m);
            cell.set(c);
            self.set_hw_pause_button(cs, m.pause_button);
        });
    }

    fn set_hw_pause_button(&self, cs: critical_section::CriticalSection<'_>, on: bool) {
        let cell = self.io.borrow(cs);
        let mut v = cell.get();
        v.hw_pause_button = on;
        cell.set(v);
    }

    /// The drive's limits this control system was built with
    /// ([`with_drive`](Self::with_drive)).
    pub fn drive_limits(&self) -> DriveLimits {
        let c = critical_section::with(|cs| self.core.borrow(cs).get());
        DriveLimits {
            i_max: c.gains.i_max,
            quick_stop_decel: c.quick_stop_decel,
        }
    }

    /// The last command the control step sent to the power stage.
    pub fn drive_command(&self) -> DriveCommand {
        critical_section::with(|cs| self.core.borrow(cs).get()).drive
    }

    /// The faults of the fault plan active now (both sensor and mechanical ones).
    pub fn injected_faults(&self) -> PlantFaults {
        self.read_io().plant_faults
    }

    fn take_requests(&self) -> Requests {
        critical_section::with(|cs| {
            let cell = self.requests.borrow(cs);
            let r = cell.get();
            cell.set(Requests {
                issued: r.issued,
                ..Requests::default()
            });
            r
        })
    }

    fn record_stopped(&self, io: &Io, stopped: bool) {
        if stopped {
            self.update_app(|a| {
                for r in a.summary.reactions_mut() {
                    if r.reacted.is_some() && r.stopped.is_none() {
                        r.stopped = Some(io.now);
                    }
                }
            });
        }
    }

    /// [`inject`](Self::inject) then [`control_step`](Self::control_step): the whole control
    /// interrupt.
    pub fn control_tick(&self, now: Instant, dt: f32) {
        self.inject(now);
        self.control_step(dt);
    }

    // ---- commands (requests applied by the next control step) --------------------------

    fn request(&self, f: impl FnOnce(&mut Requests)) {
        critical_section::with(|cs| {
            let cell = self.requests.borrow(cs);
            let mut r = cell.get();
            f(&mut r);
            r.issued = r.issued.wrapping_add(1);
            cell.set(r);
        });
    }

    /// Enables (or disables) the drive; the setpoint starts at the measured position.
    pub fn enable(&self, on: bool) {
        self.request(|r| r.enable = Some(on));
    }

    /// Engages (or releases) the holding brake.
    pub fn brake(&self, on: bool) {
        self.request(|r| r.brake = Some(on));
    }

    /// Starts a point-to-point move to `target` (m, homed coordinates).
    pub fn move_to(&self, target: f32) {
        self.request(|r| r.motion = Some(Motion::MoveTo(target)));
    }

    /// Jogs at `velocity` (m/s).
    pub fn jog(&self, velocity: f32) {
        self.request(|r| r.motion = Some(Motion::Jog(velocity)));
    }

    /// Homing seek towards the negative end stop at `speed` (m/s, the magnitude is used),
    /// the way a drive's homing mode does it: if the negative switch is closed when the
    /// seek starts, the axis first jogs off it in the positive direction until it opens
    /// ([`leaving_end_stop`](Self::leaving_end_stop)), then jogs towards it; the encoder
    /// position of the control period in which the switch input changes from open to
    /// closed during that approach is latched as the home edge, which
    /// [`set_zero`](Self::set_zero) takes as zero (wherever the axis then comes to rest).
    ///
    /// The edge is found in software, in the sampled switch input: the latched position is
    /// the first sample that reads closed, up to one control period's travel at the
    /// approach speed beyond the true edge (20 µm at 20 mm/s and 1 kHz), plus the encoder's
    /// resolution. On a real board a timer's input capture of the encoder count on the
    /// switch edge would remove the sampling error. Any other motion command ends the seek
    /// (a latched edge stays).
    pub fn seek_home(&self, speed: f32) {
        self.request(|r| r.motion = Some(Motion::Seek(speed)));
    }

    /// Decelerates to a standstill and holds (a stop request: see [`quick_stop`](Self::quick_stop)).
    pub fn stop(&self) {
        self.request_stop(Motion::Stop);
    }

    /// Quick stop: setpoint re-synchronised with the axis, ramp down at the quick-stop
    /// deceleration, integrator emptied. The safe stop of this application.
    ///
    /// Stop requests are latched with priority over motion until the next control step:
    /// a move or jog requested after it in the same period is dropped (still
    /// acknowledged by [`commands_done`](Self::commands_done); [`MoveTo`](crate::sequences::MoveTo)
    /// therefore also checks that the setpoint is at its target) unless the axis already
    /// stands still, and of several stops the strongest is applied (quick stop, stop,
    /// feed hold).
    pub fn quick_stop(&self) {
        self.request_stop(Motion::QuickStop);
    }

    /// Feed hold: decelerate the current move and keep it for [`feed_resume`](Self::feed_resume)
    /// (a stop request: see [`quick_stop`](Self::quick_stop)).
    pub fn feed_hold(&self) {
        self.request_stop(Motion::FeedHold);
    }

    fn request_stop(&self, stop: Motion) {
        self.request(|r| {
            // A motion asked for earlier is stopped, whatever it was.
            r.motion = None;
            if stop_rank(Some(stop)) > stop_rank(r.stop) {
                r.stop = Some(stop);
            }
        });
    }

    /// Resumes a held move.
    pub fn feed_resume(&self) {
        self.request(|r| r.motion = Some(Motion::FeedResume));
    }

    /// Sets the zero (homing) and holds where the axis is: at the home edge latched by the
    /// last [`seek_home`](Self::seek_home), or without one at the current encoder
    /// position. The setpoint is re-synchronised with the axis (in the new coordinates),
    /// so the axis does not move.
    pub fn set_zero(&self) {
        self.request(|r| r.zero = true);
    }

    /// Stops the axis: an abort hook for [`SeqConfig::on_abort`](rtseq::SeqConfig::on_abort)
    /// (runs in the tick; only queues a [`quick_stop`](Self::quick_stop)). Records the
    /// reaction to an injected end-stop fault.
    pub fn abort_hook(cs: &ControlSystem) {
        cs.quick_stop();
        cs.record_reaction(crate::app::FaultKind::EndStop);
    }

    /// True when every command sent so far has been applied by a control step.
    pub fn commands_done(&self) -> bool {
        let issued = critical_section::with(|cs| self.requests.borrow(cs).get().issued);
        let acked = critical_section::with(|cs| self.core.borrow(cs).get().acked);
        issued == acked
    }

    // ---- measurements -----------------------------------------------------------------

    /// A consistent snapshot of every measurement (on a real drive: of the last sample
    /// given to [`control_step_measured`](Self::control_step_measured) or
    /// [`update_measurements`](Self::update_measurements); `true_current` is then the
    /// measured current without an injected offset).
    pub fn status(&self) -> Status {
        let mut c = critical_section::with(|cs| self.core.borrow(cs).get());
        let io = self.read_io();
        if let Some(raw) = c.hw {
            // Sensor faults show at once, as on the simulated plant.
            let m = raw.with_sensor_faults(&io.plant_faults);
            let position = m.position - c.zero;
            return Status {
                position,
                velocity: c.servo.velocity(),
                current: m.current,
                true_current: raw.current,
                current_command: c.servo.command(),
                setpoint: c.profile.position(),
                target: c.profile.target(),
                following_error: c.profile.position() - position,
                in_position: c.settled_for >= SETTLE_TIME - 1e-6,
                standstill: c.servo.velocity().abs() <= STANDSTILL_VELOCITY && c.profile.done(),
                end_stop_neg: m.end_stop_neg,
                end_stop_pos: m.end_stop_pos,
                estop: m.estop,
                pause_button: io.pause_button || io.hw_pause_button,
                enabled: c.drive.enable,
                brake: c.drive.brake,
                homed: c.homed,
            };
        }
        // Sensor faults show at once, not only from the next control step.
        *c.plant.faults_mut() = io.plant_faults;
        let position = c.plant.encoder_position() - c.zero;
        Status {
            position,
            velocity: c.servo.velocity(),
            current: c.plant.measured_current(),
            true_current: c.plant.current(),
            current_command: c.servo.command(),
            setpoint: c.profile.position(),
            target: c.profile.target(),
            following_error: c.profile.position() - position,
            in_position: c.settled_for >= SETTLE_TIME - 1e-6,
            standstill: c.servo.velocity().abs() <= STANDSTILL_VELOCITY && c.profile.done(),
            end_stop_neg: c.plant.end_stop_neg(),
            end_stop_pos: c.plant.end_stop_pos(),
            estop: c.plant.estop(),
            pause_button: io.pause_button,
            enabled: c.plant.enabled(),
            brake: c.plant.brake(),
            homed: c.homed,
        }
    }

    /// Measured position, m (homed coordinates).
    pub fn position(&self) -> f32 {
        self.status().position
    }

    /// Measured velocity, m/s.
    pub fn velocity(&self) -> f32 {
        self.status().velocity
    }

    /// Measured current (the current sensor), A: the safety system's critical input.
    pub fn current(&self) -> f32 {
        self.status().current
    }

    /// Following error (setpoint − measured position), m.
    pub fn following_error(&self) -> f32 {
        self.status().following_error
    }

    /// In position and settled (see [`Status::in_position`]).
    pub fn in_position(&self) -> bool {
        self.status().in_position
    }

    /// At standstill (see [`Status::standstill`]).
    pub fn standstill(&self) -> bool {
        self.status().standstill
    }

    /// Negative end-stop switch closed.
    pub fn end_stop_neg(&self) -> bool {
        self.status().end_stop_neg
    }

    /// True while the homing seek ([`seek_home`](Self::seek_home)) is still jogging off a
    /// negative switch that was closed at its start: the switch reads closed, but it has
    /// not been found yet.
    pub fn leaving_end_stop(&self) -> bool {
        let c = critical_section::with(|cs| self.core.borrow(cs).get());
        matches!(c.seek, Seek::Leaving(_))
    }

    /// The home edge latched by the last homing seek: the encoder position (machine
    /// coordinates of the encoder, m) where the negative switch closed during its approach.
    pub fn home_edge(&self) -> Option<f32> {
        critical_section::with(|cs| self.core.borrow(cs).get()).home_edge
    }

    /// Either end-stop switch closed.
    pub fn any_end_stop(&self) -> bool {
        let s = self.status();
        s.end_stop_neg || s.end_stop_pos
    }

    /// Emergency-stop button pressed.
    pub fn estop(&self) -> bool {
        self.status().estop
    }

    /// The raw pause button (pressed = true): the injected presses, and on a real drive the
    /// sampled button.
    pub fn pause_button(&self) -> bool {
        let io = self.read_io();
        io.pause_button || io.hw_pause_button
    }

    /// The simulated machine (truth: machine coordinates, true current). On a real drive
    /// ([`control_step_measured`](Self::control_step_measured)) it is not stepped.
    pub fn plant(&self) -> Plant {
        critical_section::with(|cs| self.core.borrow(cs).get()).plant
    }

    // ---- safety system outputs -----------------------------------------------------------

    /// The safety system's drive-enable output: without the permit the power stage is off
    /// whatever the sequences command. Default: permitted (no safety system).
    pub fn set_drive_permit(&self, on: bool) {
        critical_section::with(|cs| {
            let cell = self.io.borrow(cs);
            let mut io = cell.get();
            io.drive_permit = on;
            cell.set(io);
        });
    }

    /// The safety system tripped (entered emergency: drive permit withdrawn, brake on):
    /// records the reaction to an injected over-current or e-stop. Only the trip counts;
    /// the permit is withdrawn at power off and at start-up too.
    pub fn safety_tripped(&self) {
        self.record_reaction(crate::app::FaultKind::OverCurrent);
        self.record_reaction(crate::app::FaultKind::EStop);
    }

    /// The safety system's brake output (true: brake forced on).
    pub fn set_brake_output(&self, on: bool) {
        critical_section::with(|cs| {
            let cell = self.io.borrow(cs);
            let mut io = cell.get();
            io.brake_forced = on;
            cell.set(io);
        });
    }

    /// The drive permit as last set by the safety system.
    pub fn drive_permit(&self) -> bool {
        self.read_io().drive_permit
    }

    // ---- application state ---------------------------------------------------------------

    /// The time of the last control tick ([`inject`](Self::inject)).
    pub fn now(&self) -> Instant {
        self.read_io().now
    }

    /// The application phase.
    pub fn phase(&self) -> Phase {
        self.read_app().phase
    }

    /// Sets the application phase.
    pub fn set_phase(&self, phase: Phase) {
        self.update_app(|a| a.phase = phase);
    }

    /// The status LED output.
    pub fn led(&self) -> bool {
        self.read_app().led
    }

    /// Drives the status LED output.
    pub fn set_led(&self, on: bool) {
        self.update_app(|a| a.led = on);
    }

    /// The run's summary so far.
    pub fn summary(&self) -> Summary {
        self.read_app().summary
    }

    /// Records the reaction to an injected fault of `kind` now (the first one only).
    pub fn record_reaction(&self, kind: crate::app::FaultKind) {
        let now = self.now();
        self.update_app(|a| {
            let r: &mut Reaction = a.summary.reaction_mut(kind);
            if r.injected.is_some() && r.reacted.is_none() {
                r.reacted = Some(now);
            }
        });
    }

    /// Updates the summary (for the sequences of [`crate::sequences`]).
    pub fn update_summary(&self, f: impl FnOnce(&mut Summary, Instant)) {
        let now = self.now();
        self.update_app(|a| f(&mut a.summary, now));
    }

    /// Records that move number `index` (0-based) completed now.
    pub fn record_move_done(&self, index: usize) {
        self.update_summary(|s, now| {
            s.moves_done = s.moves_done.saturating_add(1);
            if let Some(slot) = s.move_done_at.get_mut(index) {
                *slot = Some(now);
            }
        });
    }

    fn read_io(&self) -> Io {
        critical_section::with(|cs| self.io.borrow(cs).get())
    }

    fn read_app(&self) -> AppState {
        critical_section::with(|cs| self.app.borrow(cs).get())
    }

    fn update_app(&self, f: impl FnOnce(&mut AppState)) {
        critical_section::with(|cs| {
            let cell = self.app.borrow(cs);
            let mut a = cell.get();
            f(&mut a);
            cell.set(a);
        });
    }
}

/// The controller of one control period on the working copy `c` of the core: applies the
/// pending commands `req`, runs the setpoint generator and the servo on the sample `m`,
/// updates the settle timer, and returns the power stage's command (also kept in
/// `c.drive`). Shared by the simulated and the real drive, so both run the same arithmetic
/// in the same order.
fn regulate(c: &mut Core, req: Requests, io: &Io, m: &Measurements, dt: f32) -> DriveCommand {
    let measured = m.position - c.zero;
    if let Some(on) = req.enable {
        c.enabled = on;
        // Start (or stop) from where the axis is: no jump of the setpoint.
        c.profile.reset(measured);
        c.servo.clear_integral();
    }
    if let Some(on) = req.brake {
        c.brake = on;
    }
    // The homing seek, on this period's sample of the negative switch: off the switch,
    // turn towards it; approaching it, latch the position where it closes.
    let switch = m.end_stop_neg;
    match c.seek {
        Seek::Leaving(v) if !switch => {
            c.seek = Seek::Approaching;
            c.profile.jog(-v);
        }
        Seek::Approaching if switch && !c.switch_neg && c.home_edge.is_none() => {
            c.home_edge = Some(m.position);
        }
        _ => {}
    }
    c.switch_neg = switch;
    if req.zero {
        c.zero = c.home_edge.unwrap_or(m.position);
        c.homed = true;
        // At rest where the axis is, in the new coordinates.
        c.profile.reset(m.position - c.zero);
        c.servo.reset();
    }
    let measured = m.position - c.zero;
    // A pending stop has priority over a motion asked for after it in the same period,
    // unless the axis already stands still (see `Requests`).
    let at_rest = c.servo.velocity().abs() <= STANDSTILL_VELOCITY && c.profile.velocity() == 0.0;
    let motion = match req.stop {
        Some(_) if !at_rest => None,
        _ => req.motion,
    };
    for motion in [req.stop, motion].into_iter().flatten() {
        if !matches!(motion, Motion::Seek(_)) {
            c.seek = Seek::Off;
        }
        match motion {
            Motion::MoveTo(t) => c.profile.move_to(t),
            Motion::Jog(v) => c.profile.jog(v),
            Motion::Seek(v) => {
                let v = v.abs();
                c.home_edge = None;
                if switch {
                    c.seek = Seek::Leaving(v);
                    c.profile.jog(v);
                } else {
                    c.seek = Seek::Approaching;
                    c.profile.jog(-v);
                }
            }
            Motion::Stop | Motion::FeedHold => c.profile.stop(),
            Motion::FeedResume => c.profile.resume(),
            Motion::QuickStop => {
                c.profile
                    .quick_stop_at(measured, c.servo.velocity(), c.quick_stop_decel);
                c.servo.clear_integral();
            }
        }
    }
    c.acked = req.issued;

    let active = c.enabled && io.drive_permit;
    let brake = c.brake || io.brake_forced || !active;
    let current = if active {
        // The servo compares the setpoint and the measurement of the same instant; the
        // profile's acceleration over the coming period is the feed-forward.
        let (p_ref, v_ref) = (c.profile.position(), c.profile.velocity());
        c.profile.step(dt);
        let sp = (p_ref, v_ref, c.profile.acceleration());
        c.servo.step(&c.gains, sp, measured, dt)
    } else {
        // Disabled: the setpoint follows the axis, the integrator stays empty.
        c.profile.reset(measured);
        c.servo.idle(measured, dt);
        0.0
    };

    let in_tol = (c.profile.position() - measured).abs() <= POSITION_TOLERANCE
        && c.servo.velocity().abs() <= STANDSTILL_VELOCITY
        && c.profile.done();
    c.settled_for = if in_tol { c.settled_for + dt } else { 0.0 };
    c.drive = DriveCommand {
        current,
        enable: active,
        brake,
    };
    c.drive
}
