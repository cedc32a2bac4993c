//! The power stage: two L6230 half-bridges driving a brushed DC motor, written through
//! embedded-hal 1.0 traits ([`SetDutyCycle`] for IN1/IN2, [`OutputPin`] for the enables and
//! the brake), and the conversion of the controller's current command to a duty cycle.
//!
//! # Current command → duty cycle
//!
//! The application's servo commands a **current** (the simulated drive has its own current
//! loop); the L6230 is a voltage-mode bridge. At the 1 kHz control rate the firmware closes
//! the loop on the sampled leg current with a feed-forward motor model:
//!
//! ```text
//! i_ref = clamp(i_cmd, ±I_LIMIT)
//! u     = R · i_ref + Ke · ω + KP_CURRENT · (i_ref − i_meas)        (V)
//! duty  = clamp(u / SUPPLY, ±DUTY_MAX)
//! ```
//!
//! and folds the duty back to zero while the measured current exceeds [`I_LIMIT`]. `R` and
//! `Ke` are the constants of [`MotorModel::DEFAULT`]: set them for your motor. `SUPPLY` is
//! the bus voltage measured on PA1 every period ([`MotorModel::supply_v`], set by the
//! control task; below [`SUPPLY_MIN`] the duty is zero).

use core::convert::Infallible;

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::pwm::SetDutyCycle;
use rtseq_motor::hardware::DriveCommand;
use rtseq_motor::plant::M_PER_RAD;

/// The L6230's rated continuous output current, A (1.4 A r.m.s.): the command limit.
pub const I_LIMIT: f32 = 1.4;
/// Largest duty cycle magnitude (the bootstrap capacitors need some low-side time).
pub const DUTY_MAX: f32 = 0.95;
/// Proportional gain of the current correction, V/A.
pub const KP_CURRENT: f32 = 2.0;
/// Lowest bus voltage the bridge is driven at, V (the L6230's supply range starts at 8 V).
pub const SUPPLY_MIN: f32 = 8.0;

/// The motor and supply seen by the duty conversion (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorModel {
    /// Armature resistance, Ω.
    pub r_ohm: f32,
    /// Back-EMF constant, V·s/rad (= the torque constant in N·m/A).
    pub ke: f32,
    /// Motor supply voltage on the IHM07M1's J1, V: the control task writes the measured
    /// VBUS here every period.
    pub supply_v: f32,
}

impl MotorModel {
    /// A small DC motor: 2 Ω, 0.05 V·s/rad (the simulated motor's torque constant); no
    /// supply measured yet (zero duty until the first VBUS reading).
    pub const DEFAULT: MotorModel = MotorModel {
        r_ohm: 2.0,
        ke: rtseq_motor::plant::KT,
        supply_v: 0.0,
    };

    /// The duty cycle (−1 … 1) for the current command `i_cmd` (A), the measured motor
    /// current `i_meas` (A) and the axis velocity `velocity` (m/s).
    pub fn duty(&self, i_cmd: f32, i_meas: f32, velocity: f32) -> f32 {
        let supply_ok = self.supply_v.is_finite() && self.supply_v >= SUPPLY_MIN;
        if !supply_ok || !i_cmd.is_finite() || !i_meas.is_finite() {
            return 0.0;
        }
        if i_meas.abs() > I_LIMIT * 1.2 {
            // Over the limit: no voltage until the current has decayed.
            return 0.0;
        }
        let i_ref = clamp(i_cmd, -I_LIMIT, I_LIMIT);
        let omega = if velocity.is_finite() {
            velocity / M_PER_RAD
        } else {
            0.0
        };
        let u = self.r_ohm * i_ref + self.ke * omega + KP_CURRENT * (i_ref - i_meas);
        clamp(u / self.supply_v, -DUTY_MAX, DUTY_MAX)
    }
}

/// `f32::clamp` without its panic path (NaN maps to `lo`).
fn clamp(v: f32, lo: f32, hi: f32) -> f32 {
    if v > hi {
        hi
    } else if v >= lo {
        v
    } else {
        lo
    }
}

/// Infallible HAL writes: nothing to handle, and no `unwrap`.
fn done(r: Result<(), Infallible>) {
    match r {
        Ok(()) => {}
        Err(never) => match never {},
    }
}

/// The two half-bridges, their enables, the unused third half-bridge's enable, the L6230's
/// DIAG/EN line and the brake release output.
pub struct Bridge<P1, P2, E1, E2, E3, D, B> {
    in1: P1,
    in2: P2,
    en1: E1,
    en2: E2,
    en3: E3,
    /// DIAG/EN (open drain): low in the safe state, a second way to switch the bridges off
    /// that does not depend on EN1–EN3.
    diag: D,
    brake_release: B,
    /// Sign of the last duty (for the current measurement: which leg's shunt carries the
    /// motor current continuously).
    forward: bool,
    on: bool,
}

impl<P1, P2, E1, E2, E3, D, B> Bridge<P1, P2, E1, E2, E3, D, B>
where
    P1: SetDutyCycle<Error = Infallible>,
    P2: SetDutyCycle<Error = Infallible>,
    E1: OutputPin<Error = Infallible>,
    E2: OutputPin<Error = Infallible>,
    E3: OutputPin<Error = Infallible>,
    D: OutputPin<Error = Infallible> + InputPin<Error = Infallible>,
    B: OutputPin<Error = Infallible>,
{
    /// Takes the outputs and puts them in the safe state at once.
    pub fn new(in1: P1, in2: P2, en1: E1, en2: E2, en3: E3, diag: D, brake_release: B) -> Self {
        let mut b = Bridge {
            in1,
            in2,
            en1,
            en2,
            en3,
            diag,
            brake_release,
            forward: true,
            on: false,
        };
        b.off();
        b
    }

    /// The safe state: both half-bridges off (the motor coasts), zero duty, brake engaged.
    /// Two independent paths switch the bridges off: EN1/EN2 low and DIAG/EN driven low.
    pub fn off(&mut self) {
        done(self.diag.set_low());
        done(self.en1.set_low());
        done(self.en2.set_low());
        done(self.en3.set_low());
        done(self.in1.set_duty_cycle_fully_off());
        done(self.in2.set_duty_cycle_fully_off());
        done(self.brake_release.set_low());
        self.on = false;
    }

    /// Writes one control period's command: `duty` (−1 … 1, sign-magnitude) when the
    /// command enables the drive, the safe state otherwise; the brake output follows
    /// `cmd.brake`.
    pub fn apply(&mut self, cmd: &DriveCommand, duty: f32) {
        if !cmd.enable {
            self.off();
            return;
        }
        let forward = duty >= 0.0;
        let magnitude = clamp(duty.abs(), 0.0, DUTY_MAX);
        // Duty in 1/10000: u16 and exact enough (the timer has 4200 steps at 20 kHz).
        let num = (magnitude * 10_000.0) as u16;
        // The idle leg's low side first, then the switching leg.
        if forward {
            done(self.in2.set_duty_cycle_fully_off());
            done(self.in1.set_duty_cycle_fraction(num, 10_000));
        } else {
            done(self.in1.set_duty_cycle_fully_off());
            done(self.in2.set_duty_cycle_fraction(num, 10_000));
        }
        done(self.en3.set_low());
        // Release DIAG/EN (open drain: the L6230's own pull-down still wins on a fault).
        done(self.diag.set_high());
        done(self.en1.set_high());
        done(self.en2.set_high());
        if cmd.brake {
            done(self.brake_release.set_low());
        } else {
            done(self.brake_release.set_high());
        }
        self.forward = forward;
        self.on = true;
    }

    /// True when the last duty was ≥ 0 (IN1 switching, V's low side on).
    pub fn forward(&self) -> bool {
        self.forward
    }

    /// True while the half-bridges are enabled.
    pub fn is_on(&self) -> bool {
        self.on
    }

    /// The L6230 signals a fault: DIAG/EN reads low while the firmware has released it. In
    /// the safe state the firmware holds the line low itself, so there is nothing to read.
    pub fn driver_fault(&mut self) -> bool {
        let released_high = match self.diag.is_high() {
            Ok(level) => level,
            Err(never) => match never {},
        };
        self.on && !released_high
    }
}
