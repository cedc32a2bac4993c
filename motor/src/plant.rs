//! The simulated machine: a current-controlled DC servo motor driving a carriage through a
//! lead screw, with its sensors (incremental encoder, current sensor, two end-stop
//! switches, an emergency-stop button) and fault-injection hooks.
//!
//! # Model
//!
//! The axis is **linear, in metres**: the motor shaft angle θ (rad) moves the carriage by
//! `x = θ · LEAD / 2π` (a 5 mm lead screw). All dynamics are integrated on the shaft:
//!
//! ```text
//! J · dω/dt = Kt · i − b · ω − τc · sign(ω) − τ_jam · sign(ω)      (τ_brake when braked)
//! τi · di/dt = clamp(i_cmd, ±I_MAX) − i                               (current loop, first order)
//! ```
//!
//! with `J = J_MOTOR + m · (LEAD/2π)²` (the carriage mass reflected through the screw).
//! The drive is current controlled: its internal current loop is a first-order lag of time
//! constant [`CURRENT_LOOP_TAU`] and saturates at [`I_MAX`]; a disabled drive produces no
//! current.
//!
//! Coulomb friction (and the brake, and a jam) is integrated as a velocity-level impulse that
//! can stop the shaft but never reverse it, so the axis sticks exactly at zero speed while
//! the drive torque is below the friction torque (stiction), with no chattering.
//!
//! Integration: semi-implicit (symplectic) Euler with [`SUB_STEPS`] sub-steps per control
//! period (1 ms → 100 µs sub-steps, far below the mechanical and the current-loop time
//! constants).
//!
//! Geometry, in machine coordinates (metres, not the homed coordinates the controller uses):
//! the negative end-stop switch closes at `x ≤ END_STOP_NEG`, the positive one at
//! `x ≥ END_STOP_POS`; the hard (mechanical) stops are [`HARD_STOP_MARGIN`] beyond them.
//!
//! ```
//! use rtseq_motor::plant::{Plant, I_MAX};
//! let mut plant = Plant::new(0.02);
//! plant.set_enabled(true);
//! plant.set_brake(false);
//! for _ in 0..100 {
//!     plant.step(I_MAX, 0.001); // full current for 100 ms
//! }
//! assert!(plant.velocity() > 0.3); // metres per second
//! assert!(plant.encoder_position() > 0.02);
//! ```

use core::f32::consts::PI;

/// Lead of the lead screw: carriage travel per motor revolution, m/rev (5 mm).
pub const LEAD: f32 = 0.005;
/// Transmission ratio: carriage travel per shaft radian, m/rad (`LEAD / 2π`).
pub const M_PER_RAD: f32 = LEAD / (2.0 * PI);
/// Rotor inertia of the motor, kg·m² (0.2 kg·cm²).
pub const J_MOTOR: f32 = 2.0e-5;
/// Carriage (load) mass, kg.
pub const LOAD_MASS: f32 = 2.0;
/// Total inertia seen by the shaft, kg·m² (`J_MOTOR + LOAD_MASS · M_PER_RAD²`).
pub const J_TOTAL: f32 = J_MOTOR + LOAD_MASS * M_PER_RAD * M_PER_RAD;
/// Viscous friction, N·m·s/rad.
pub const VISCOUS: f32 = 1.0e-5;
/// Coulomb (dry) friction torque, N·m (5 % of the peak torque).
pub const COULOMB: f32 = 0.01;
/// Torque constant, N·m/A.
pub const KT: f32 = 0.05;
/// Current limit of the drive, A (peak torque `KT · I_MAX` = 0.2 N·m).
pub const I_MAX: f32 = 4.0;
/// Time constant of the drive's current loop, s.
pub const CURRENT_LOOP_TAU: f32 = 0.3e-3;
/// Holding torque of the motor brake, N·m (above the peak torque: a braked axis cannot move).
pub const BRAKE_TORQUE: f32 = 0.5;
/// Friction torque of a jammed axis (fault injection), N·m (above the peak torque).
pub const JAM_TORQUE: f32 = 1.0;
/// Encoder resolution, counts per motor revolution (1000 lines, quadrature).
pub const COUNTS_PER_REV: i32 = 4000;
/// Carriage travel per encoder count, m (1.25 µm).
pub const M_PER_COUNT: f32 = LEAD / COUNTS_PER_REV as f32;
/// Machine position at which the negative end-stop switch closes, m.
pub const END_STOP_NEG: f32 = 0.0;
/// Machine position at which the positive end-stop switch closes, m.
pub const END_STOP_POS: f32 = 0.300;
/// Distance of the hard (mechanical) stops beyond the switches, m: at least the axis'
/// stopping distance from full speed after a switch closes (quick stop from 0.2 m/s at
/// 6 m/s², detected one 1 ms period late: 3.53 mm,
/// [`STOPPING_DISTANCE`](crate::controller::STOPPING_DISTANCE)) plus a reserve of 1.5 mm
/// for the current loop's lag and a dirty switch. (It was 3 mm, less than the stopping
/// distance: domain review S2.)
pub const HARD_STOP_MARGIN: f32 = 0.005;
/// Integration sub-steps per [`Plant::step`].
pub const SUB_STEPS: u32 = 10;

/// Injected faults of the machine (see [`Plant::faults_mut`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlantFaults {
    /// The axis is jammed: an extra friction torque of [`JAM_TORQUE`] (a following error).
    pub jammed: bool,
    /// Extra load torque on the shaft, N·m (e.g. a collision).
    pub load_torque: f32,
    /// Offset added by the current sensor, A (a high reading is an over-current).
    pub current_sensor_offset: f32,
    /// The negative end-stop switch reads closed whatever the position.
    pub end_stop_neg_closed: bool,
    /// The positive end-stop switch reads closed whatever the position.
    pub end_stop_pos_closed: bool,
    /// The emergency-stop button is pressed.
    pub estop_pressed: bool,
}

impl PlantFaults {
    /// No fault.
    pub const NONE: PlantFaults = PlantFaults {
        jammed: false,
        load_torque: 0.0,
        current_sensor_offset: 0.0,
        end_stop_neg_closed: false,
        end_stop_pos_closed: false,
        estop_pressed: false,
    };
}

/// The simulated machine state. Plain data (`Copy`): the control system keeps it in a
/// critical-section cell and steps it from the control interrupt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plant {
    /// Shaft angle, rad (machine coordinates: `x = angle · M_PER_RAD`).
    angle: f32,
    /// Shaft speed, rad/s.
    omega: f32,
    /// Motor current, A.
    current: f32,
    /// Drive power stage enabled.
    enabled: bool,
    /// Holding brake engaged.
    brake: bool,
    faults: PlantFaults,
}

impl Plant {
    /// A machine at rest at machine position `x` (m), drive disabled, brake engaged.
    pub const fn new(x: f32) -> Self {
        Plant {
            angle: x / M_PER_RAD,
            omega: 0.0,
            current: 0.0,
            enabled: false,
            brake: true,
            faults: PlantFaults::NONE,
        }
    }

    /// Enables or disables the drive's power stage (disabled: no current).
    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
    }

    /// Engages or releases the holding brake.
    pub fn set_brake(&mut self, on: bool) {
        self.brake = on;
    }

    /// True while the power stage is enabled.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// True while the brake is engaged.
    pub fn brake(&self) -> bool {
        self.brake
    }

    /// The injected faults.
    pub fn faults(&self) -> PlantFaults {
        self.faults
    }

    /// The injected faults, to change them.
    pub fn faults_mut(&mut self) -> &mut PlantFaults {
        &mut self.faults
    }

    /// Advances the machine by `dt` seconds with current command `i_cmd` (A), clamped to
    /// ±[`I_MAX`] by the drive.
    pub fn step(&mut self, i_cmd: f32, dt: f32) {
        if dt.is_nan() || dt <= 0.0 {
            return;
        }
        let h = dt / SUB_STEPS as f32;
        let target = if self.enabled {
            clamp(i_cmd, -I_MAX, I_MAX)
        } else {
            0.0
        };
        // Exact discretisation of the first-order current loop over one sub-step.
        let alpha = 1.0 - libm::expf(-h / CURRENT_LOOP_TAU);
        let mut dry = COULOMB;
        if self.faults.jammed {
            dry += JAM_TORQUE;
        }
        if self.brake {
            dry += BRAKE_TORQUE;
        }
        let x_min = (END_STOP_NEG - HARD_STOP_MARGIN) / M_PER_RAD;
        let x_max = (END_STOP_POS + HARD_STOP_MARGIN) / M_PER_RAD;
        for _ in 0..SUB_STEPS {
            self.current += alpha * (target - self.current);
            let drive = KT * self.current + self.faults.load_torque - VISCOUS * self.omega;
            let free = self.omega + drive / J_TOTAL * h;
            // Dry friction as an impulse that can stop the shaft but never reverse it.
            let stop = dry / J_TOTAL * h;
            self.omega = if free.abs() <= stop {
                0.0
            } else {
                free - stop.copysign(free)
            };
            self.angle += self.omega * h;
            if self.angle < x_min {
                self.angle = x_min;
                self.omega = self.omega.max(0.0);
            } else if self.angle > x_max {
                self.angle = x_max;
                self.omega = self.omega.min(0.0);
            }
        }
    }

    /// True carriage position, m (machine coordinates).
    pub fn position(&self) -> f32 {
        self.angle * M_PER_RAD
    }

    /// True carriage velocity, m/s.
    pub fn velocity(&self) -> f32 {
        self.omega * M_PER_RAD
    }

    /// True motor current, A.
    pub fn current(&self) -> f32 {
        self.current
    }

    /// The incremental encoder: counts since power-up (quantised shaft angle).
    pub fn encoder_counts(&self) -> i32 {
        let counts = self.angle / (2.0 * PI) * COUNTS_PER_REV as f32;
        // Saturating float → int conversion; the travel is ±10⁵ counts.
        libm::floorf(counts) as i32
    }

    /// The encoder reading converted to a position, m (quantised to [`M_PER_COUNT`]).
    pub fn encoder_position(&self) -> f32 {
        self.encoder_counts() as f32 * M_PER_COUNT
    }

    /// The current sensor: true current plus the injected offset, A.
    pub fn measured_current(&self) -> f32 {
        self.current + self.faults.current_sensor_offset
    }

    /// The negative end-stop switch (closed = true).
    pub fn end_stop_neg(&self) -> bool {
        self.faults.end_stop_neg_closed || self.position() <= END_STOP_NEG
    }

    /// The positive end-stop switch (closed = true).
    pub fn end_stop_pos(&self) -> bool {
        self.faults.end_stop_pos_closed || self.position() >= END_STOP_POS
    }

    /// The emergency-stop button (pressed = true).
    pub fn estop(&self) -> bool {
        self.faults.estop_pressed
    }
}

/// `f32::clamp` without its panic on NaN bounds (ours are constants): NaN maps to `lo`.
pub(crate) fn clamp(v: f32, lo: f32, hi: f32) -> f32 {
    if v > hi {
        hi
    } else if v >= lo {
        v
    } else {
        lo
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiction_holds_below_the_friction_torque() {
        let mut p = Plant::new(0.1);
        p.set_enabled(true);
        p.set_brake(false);
        // 0.1 A → 5 mN·m < 10 mN·m Coulomb friction.
        for _ in 0..100 {
            p.step(0.1, 0.001);
        }
        assert_eq!(p.velocity(), 0.0);
        assert!((p.position() - 0.1).abs() < 1e-6);
    }

    #[test]
    fn jam_and_brake_hold_at_full_current() {
        let mut p = Plant::new(0.1);
        p.set_enabled(true);
        p.faults_mut().jammed = true;
        for _ in 0..100 {
            p.step(I_MAX, 0.001);
        }
        assert_eq!(p.velocity(), 0.0);
    }

    #[test]
    fn hard_stop_limits_travel() {
        let mut p = Plant::new(0.001);
        p.set_enabled(true);
        p.set_brake(false);
        for _ in 0..500 {
            p.step(-I_MAX, 0.001);
        }
        assert!(p.end_stop_neg());
        assert!((p.position() - (END_STOP_NEG - HARD_STOP_MARGIN)).abs() < 1e-6);
    }
}
