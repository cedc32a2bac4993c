//! The motor controller's safety levels for rtseq's safety system ([`rtseq::safety`]).
//!
//! | level | drive enable | brake | e-stop | current | end stops | entered by |
//! |---|---|---|---|---|---|---|
//! | `EMERGENCY` (0) | off | on | ignore | ignore | ignore | `EMERGENCY_STOP` (private) from any level ≥ `OFF`; aborts every sequence while active |
//! | `OFF` (1) | off | on | check | range ± the trip ([`Watches`]; [`CURRENT_TRIP`] in [`PROPERTIES`]) | ignore | start; `SWITCH_OFF`; `RESET` from `EMERGENCY` |
//! | `POWER_ON` (2) | on | off | check | range | ignore (homing seeks the switch) | [`SWITCH_ON`] from `OFF`; `LIMIT` from `HOMED` |
//! | `HOMED` (3) | on | off | check | range | check open → `LIMIT` | [`HOMED_EVENT`] from `POWER_ON` |
//!
//! The e-stop and over-current input checks trigger the private `EMERGENCY_STOP` event,
//! applied in the next safety cycle: drive off, brake on, every sequence aborted.
//!
//! The safety task samples the [`ControlSystem`] into a [`DriveIo`], runs one cycle and
//! writes the outputs back — [`safety_cycle`] does the three:
//!
//! ```
//! use rtseq::safety::SafetySystem;
//! use rtseq::Sequencer;
//! use rtseq_motor::control_system::ControlSystem;
//! use rtseq_motor::safety::{self, PROPERTIES};
//! static SEQ: Sequencer<ControlSystem, 4> = Sequencer::new();
//! let cs = ControlSystem::new(0.02);
//! let mut system = SafetySystem::new_validated(&PROPERTIES, SEQ.safety_handle()).unwrap();
//! safety::safety_cycle(&cs, &mut system, &SEQ);
//! let handle = SEQ.safety_handle();
//! assert_eq!(handle.level(), safety::OFF);
//! assert!(!cs.drive_permit());
//! handle.trigger(safety::SWITCH_ON);
//! safety::safety_cycle(&cs, &mut system, &SEQ);
//! assert_eq!(handle.level(), safety::POWER_ON);
//! assert!(cs.drive_permit());
//! ```

use rtseq::safety::{
    AbortPolicy, CriticalInput, CriticalInputInfo, CriticalOutput, CriticalOutputInfo, CycleReport,
    InputAction, InputId, IoValue, LevelDef, LevelTransition, OutputAction, OutputId, PrivateEvent,
    PublicEvent, SafetyIo, SafetyLevel, SafetyProperties, SafetySystem, Sequences, ValidProperties,
};

use crate::control_system::ControlSystem;

/// Emergency: drive off, brake on, sequences aborted.
pub const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
/// Off: drive off, brake on.
pub const OFF: SafetyLevel = SafetyLevel::new(1);
/// Power on: drive permitted (homing).
pub const POWER_ON: SafetyLevel = SafetyLevel::new(2);
/// Homed: drive permitted, end stops watched.
pub const HOMED: SafetyLevel = SafetyLevel::new(3);

/// Public: off → power on (the power-on step).
pub const SWITCH_ON: PublicEvent = PublicEvent::new(0);
/// Public: power on → homed (main, after homing).
pub const HOMED_EVENT: PublicEvent = PublicEvent::new(1);
/// Public: power on / homed → off (the power-off step).
pub const SWITCH_OFF: PublicEvent = PublicEvent::new(2);
/// Public: emergency → off (acknowledge).
pub const RESET: PublicEvent = PublicEvent::new(3);
/// Private: e-stop pressed or over-current.
pub const EMERGENCY_STOP: PrivateEvent = PrivateEvent::new(0);
/// Private: an end stop closed while homed.
pub const LIMIT: PrivateEvent = PrivateEvent::new(1);

/// Over-current trip level of the current input of the simulated drive, A (its current
/// limit is 4 A), in [`PROPERTIES`]. A real drive trips where its sensor can still
/// measure: build its table with [`Watches::new`] and [`properties`].
///
/// Above the drive's own limit, this is a **sensor-plausibility check**: the simulated
/// machine cannot make 6 A, so only a faulty reading (the demo's injected +12 A offset)
/// trips it. It is not a thermal or stall protection: there is no I²t or stall
/// supervision (domain review S4). A stall the following-error monitors cannot see — a jam
/// at rest within the following-error limit — holds the drive at its current limit until
/// a sequence's timeout ends it (≈1.4 s at 4 A when jammed at the end of the homing back
/// off); a production drive adds an i²·t trip or foldback (e.g. |i| at the limit at
/// standstill for more than a few hundred ms → emergency) as a critical input.
pub const CURRENT_TRIP: f32 = 6.0;

/// Critical input: e-stop button pressed.
pub const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
/// Critical input: measured motor current, A.
pub const CURRENT_IN: CriticalInput<f32> = CriticalInput::new(1, "motor current [A]");
/// Critical input: negative end stop closed.
pub const END_NEG_IN: CriticalInput<bool> = CriticalInput::new(2, "end stop -");
/// Critical input: positive end stop closed.
pub const END_POS_IN: CriticalInput<bool> = CriticalInput::new(3, "end stop +");
/// Critical output: drive enable (permit).
pub const ENABLE_OUT: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
/// Critical output: brake engaged.
pub const BRAKE_OUT: CriticalOutput<bool> = CriticalOutput::new(1, "brake");

/// What the levels above `EMERGENCY` watch, for a drive whose over-current trip is
/// ±`current_trip` A: the input lists [`properties`] builds the table from. A `static`, so
/// the table can borrow it for good:
///
/// ```
/// use rtseq::safety::{SafetySystem, ValidProperties};
/// use rtseq::Sequencer;
/// use rtseq_motor::control_system::ControlSystem;
/// use rtseq_motor::safety::{self, DriveIo, Watches};
/// /// A board whose current sensor measures up to ±3.2 A trips at 2 A.
/// static WATCHES: Watches = Watches::new(2.0);
/// static PROPERTIES: ValidProperties<'static, DriveIo, 4> =
///     match safety::properties(&WATCHES).validated() {
///         Ok(valid) => valid,
///         Err(_) => panic!("invalid safety properties"),
///     };
/// static SEQ: Sequencer<ControlSystem, 4> = Sequencer::new();
/// let mut system = SafetySystem::new_validated(&PROPERTIES, SEQ.safety_handle()).unwrap();
/// let mut level_at = |amps: f32| {
///     let mut io = DriveIo { current: amps, ..DriveIo::default() };
///     system.cycle(&mut io, &SEQ);
///     system.cycle(&mut io, &SEQ);
///     SEQ.safety_handle().level()
/// };
/// assert_eq!(level_at(1.9), safety::OFF);
/// assert_eq!(level_at(2.1), safety::EMERGENCY);
/// ```
pub struct Watches {
    /// Off and power on: e-stop and current; the end stops are ignored (homing seeks one).
    off: [InputAction; 4],
    /// Homed: e-stop, current and both end stops.
    homed: [InputAction; 4],
}

impl Watches {
    /// The watches of a drive that trips at ±`current_trip` A.
    pub const fn new(current_trip: f32) -> Self {
        let current = CURRENT_IN.range(-current_trip, current_trip, EMERGENCY_STOP);
        Watches {
            off: [
                ESTOP_IN.check(false, EMERGENCY_STOP),
                current,
                END_NEG_IN.ignore(),
                END_POS_IN.ignore(),
            ],
            homed: [
                ESTOP_IN.check(false, EMERGENCY_STOP),
                current,
                END_NEG_IN.check(false, LIMIT),
                END_POS_IN.check(false, LIMIT),
            ],
        }
    }
}

/// The simulated drive's watches (trip at [`CURRENT_TRIP`]).
static WATCHES: Watches = Watches::new(CURRENT_TRIP);

const IGNORE_ALL: [InputAction; 4] = [
    ESTOP_IN.ignore(),
    CURRENT_IN.ignore(),
    END_NEG_IN.ignore(),
    END_POS_IN.ignore(),
];
const SAFE: [OutputAction; 2] = [ENABLE_OUT.set(false), BRAKE_OUT.set(true)];
const DRIVE: [OutputAction; 2] = [ENABLE_OUT.set(true), BRAKE_OUT.set(false)];

/// The safety properties of the simulated drive, validated at compile time: start the
/// system with [`SafetySystem::new_validated`], which links no run-time validation.
pub static PROPERTIES: ValidProperties<'static, DriveIo, 4> = match properties(&WATCHES).validated()
{
    Ok(valid) => valid,
    // A compile error (the `static` is evaluated by the compiler), never a run-time panic.
    Err(_) => panic!("invalid safety properties"),
};

/// The safety table of the motor application (the levels, events and transitions above)
/// for a drive with `watches`.
pub const fn properties(watches: &Watches) -> SafetyProperties<'_, DriveIo, 4> {
    SafetyProperties::new(
        [
            LevelDef::new(EMERGENCY, "emergency")
                .inputs(&IGNORE_ALL)
                .outputs(&SAFE)
                .abort_sequences(AbortPolicy::WhileActive),
            LevelDef::new(OFF, "off")
                .inputs(&watches.off)
                .outputs(&SAFE),
            LevelDef::new(POWER_ON, "power on")
                .inputs(&watches.off)
                .outputs(&DRIVE),
            LevelDef::new(HOMED, "homed")
                .inputs(&watches.homed)
                .outputs(&DRIVE),
        ],
        &INPUTS,
        &OUTPUTS,
        &TRANSITIONS,
        OFF,
    )
}

const INPUTS: [CriticalInputInfo; 4] = [
    ESTOP_IN.info(),
    CURRENT_IN.info(),
    END_NEG_IN.info(),
    END_POS_IN.info(),
];
const OUTPUTS: [CriticalOutputInfo; 2] = [ENABLE_OUT.info(), BRAKE_OUT.info()];
const TRANSITIONS: [LevelTransition; 6] = [
    LevelTransition::on_level_and_above(OFF, EMERGENCY_STOP, EMERGENCY),
    LevelTransition::on(EMERGENCY, RESET, OFF),
    LevelTransition::on(OFF, SWITCH_ON, POWER_ON),
    LevelTransition::on(POWER_ON, HOMED_EVENT, HOMED),
    LevelTransition::on(HOMED, LIMIT, POWER_ON),
    LevelTransition::on_levels_between(POWER_ON, HOMED, SWITCH_OFF, OFF),
];

/// The safety system's view of the drive for one cycle: inputs sampled from the control
/// system, outputs collected and written back by [`DriveIo::apply`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriveIo {
    /// E-stop pressed.
    pub estop: bool,
    /// Measured current, A.
    pub current: f32,
    /// Negative end stop closed.
    pub end_neg: bool,
    /// Positive end stop closed.
    pub end_pos: bool,
    /// Output: drive enable.
    pub enable: bool,
    /// Output: brake.
    pub brake: bool,
}

impl DriveIo {
    /// Samples the critical inputs (outputs keep the control system's current values).
    pub fn sample(cs: &ControlSystem) -> Self {
        let s = cs.status();
        DriveIo {
            estop: s.estop,
            current: s.current,
            end_neg: s.end_stop_neg,
            end_pos: s.end_stop_pos,
            enable: cs.drive_permit(),
            brake: s.brake,
        }
    }

    /// Writes the critical outputs to the control system.
    pub fn apply(&self, cs: &ControlSystem) {
        cs.set_drive_permit(self.enable);
        cs.set_brake_output(self.brake);
    }
}

impl SafetyIo for DriveIo {
    fn read_input(&mut self, input: InputId) -> IoValue {
        if input == ESTOP_IN.id() {
            self.estop.into()
        } else if input == CURRENT_IN.id() {
            self.current.into()
        } else if input == END_NEG_IN.id() {
            self.end_neg.into()
        } else {
            self.end_pos.into()
        }
    }

    fn write_output(&mut self, output: OutputId, value: IoValue) {
        // A pattern, not `==`: no derived comparison of rtseq's `IoValue` is linked.
        let on = matches!(value, IoValue::Bool(true));
        if output == ENABLE_OUT.id() {
            self.enable = on;
        } else if output == BRAKE_OUT.id() {
            self.brake = on;
        }
    }
}

/// One safety cycle on the control system: sample, cycle, apply; a cycle that entered
/// `EMERGENCY` is the trip ([`ControlSystem::safety_tripped`]). Call it from the safety
/// task (highest priority) at the safety period; `sequences` is the sequencer (abort-all).
pub fn safety_cycle<const L: usize, A: Sequences + ?Sized>(
    cs: &ControlSystem,
    system: &mut SafetySystem<'_, DriveIo, L>,
    sequences: &A,
) -> CycleReport {
    let mut io = DriveIo::sample(cs);
    let report = system.cycle(&mut io, sequences);
    io.apply(cs);
    if report.change.is_some_and(|c| c.to == EMERGENCY) {
        cs.safety_tripped();
    }
    report
}
