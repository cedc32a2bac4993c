//! The hardware boundary: what a real drive measures ([`Measurements`]) and what the
//! controller commands back ([`DriveCommand`]).
//!
//! The simulated machine ([`crate::plant::Plant`]) is one implementation of this boundary:
//! [`ControlSystem::control_step`] reads the plant's sensors into a [`Measurements`],
//! runs the controller, and steps the plant with the resulting [`DriveCommand`]. A firmware
//! for a real board calls [`ControlSystem::control_step_measured`] instead: it samples
//! its encoder timer, current ADC and switches into a [`Measurements`], gets the
//! [`DriveCommand`] back and writes it to its PWM and enable outputs. The controller, the
//! sequences, the monitors and the safety system are the same code in both cases.
//!
//! ```
//! use rtseq_motor::control_system::ControlSystem;
//! use rtseq_motor::hardware::Measurements;
//! let cs = ControlSystem::new(0.02);
//! cs.brake(false);
//! cs.enable(true);
//! let m = Measurements { position: 0.02, ..Measurements::NONE };
//! let cmd = cs.control_step_measured(&m, 0.001);
//! assert!(cmd.enable && !cmd.brake);
//! assert_eq!(cs.position(), 0.02); // homed coordinates: the zero is still 0
//! ```
//!
//! [`ControlSystem::control_step`]: crate::control_system::ControlSystem::control_step
//! [`ControlSystem::control_step_measured`]: crate::control_system::ControlSystem::control_step_measured

use crate::plant::{Plant, PlantFaults};

/// One sample of the drive's sensors, taken at the start of a control period.
///
/// Units are the axis' (m, A); switches are `true` when closed / pressed, whatever their
/// electrical polarity (the board converts).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurements {
    /// Encoder position, m, in machine coordinates (counts since power-up times the
    /// travel per count; see [`Measurements::counts_to_metres`]).
    pub position: f32,
    /// Measured motor current, A (signed: positive drives towards +position).
    pub current: f32,
    /// Negative end-stop switch closed.
    pub end_stop_neg: bool,
    /// Positive end-stop switch closed.
    pub end_stop_pos: bool,
    /// Emergency-stop button pressed.
    pub estop: bool,
    /// Pause button pressed (raw level; the application's toggle does the rest).
    pub pause_button: bool,
}

impl Measurements {
    /// Position 0, no current, every switch open.
    pub const NONE: Measurements = Measurements {
        position: 0.0,
        current: 0.0,
        end_stop_neg: false,
        end_stop_pos: false,
        estop: false,
        pause_button: false,
    };

    /// The sensors of the simulated machine (its injected faults included).
    pub fn of_plant(plant: &Plant) -> Measurements {
        Measurements {
            position: plant.encoder_position(),
            current: plant.measured_current(),
            end_stop_neg: plant.end_stop_neg(),
            end_stop_pos: plant.end_stop_pos(),
            estop: plant.estop(),
            pause_button: false,
        }
    }

    /// Encoder counts to metres: `counts as f32 * metres_per_count` (the same conversion
    /// as [`Plant::encoder_position`] with [`M_PER_COUNT`](crate::plant::M_PER_COUNT)).
    pub fn counts_to_metres(counts: i32, metres_per_count: f32) -> f32 {
        counts as f32 * metres_per_count
    }

    /// The sensor faults of `faults` applied to this sample (current-sensor offset, stuck
    /// switches, pressed e-stop), so the fault plan works on a real drive as well; the
    /// mechanical faults (jam, load torque) cannot be injected into a real machine and are
    /// ignored.
    pub fn with_sensor_faults(self, faults: &PlantFaults) -> Measurements {
        Measurements {
            position: self.position,
            current: self.current + faults.current_sensor_offset,
            end_stop_neg: self.end_stop_neg || faults.end_stop_neg_closed,
            end_stop_pos: self.end_stop_pos || faults.end_stop_pos_closed,
            estop: self.estop || faults.estop_pressed,
            pause_button: self.pause_button,
        }
    }
}

impl Default for Measurements {
    fn default() -> Self {
        Measurements::NONE
    }
}

/// What the controller asks of the power stage for the coming control period.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveCommand {
    /// Current command, A (0 when not enabled). The drive limits it to its own maximum;
    /// a voltage-mode bridge converts it to a duty cycle.
    pub current: f32,
    /// Power stage on: commanded by the sequences **and** permitted by the safety system.
    pub enable: bool,
    /// Holding brake engaged (always engaged while the power stage is off).
    pub brake: bool,
}

impl DriveCommand {
    /// The safe state: power stage off, brake engaged, no current.
    pub const SAFE: DriveCommand = DriveCommand {
        current: 0.0,
        enable: false,
        brake: true,
    };
}

impl Default for DriveCommand {
    fn default() -> Self {
        DriveCommand::SAFE
    }
}

impl PlantFaults {
    /// Only the mechanical faults (jam, load torque): what a machine in the loop of
    /// [`control_step_measured`](crate::control_system::ControlSystem::control_step_measured)
    /// must simulate itself, since that path applies the sensor faults to the samples.
    pub const fn mechanical(&self) -> PlantFaults {
        PlantFaults {
            jammed: self.jammed,
            load_torque: self.load_torque,
            ..PlantFaults::NONE
        }
    }
}
