//! The safety system of the emergency scenario, shared by the host test
//! (`tests/emergency.rs`) and the QEMU firmware (`boards/qemu-f405/src/bin/emergency.rs`):
//! five levels, one critical input (the emergency-stop button), two critical outputs (drive
//! enable, status lamp). Each side brings its own I/O type, a [`Machine`].

use rtseq::safety::{
    AbortPolicy, CriticalInput, CriticalInputInfo, CriticalOutput, CriticalOutputInfo, InputAction,
    LevelDef, LevelTransition, OutputAction, PrivateEvent, PublicEvent, SafetyContext, SafetyError,
    SafetyIo, SafetyLevel, SafetyProperties, ValidProperties,
};

/// Level: emergency stop; drive off, lamp blinking, sequences aborted while active.
pub const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
/// Level: powered off (the entry level).
pub const OFF: SafetyLevel = SafetyLevel::new(1);
/// Level: the power stage comes up; lamp blinking.
pub const POWERING: SafetyLevel = SafetyLevel::new(2);
/// Level: powered, drive enabled.
pub const READY: SafetyLevel = SafetyLevel::new(3);
/// Level: moving, drive enabled.
pub const MOVING: SafetyLevel = SafetyLevel::new(4);

/// Public event: OFF → POWERING.
pub const SWITCH_ON: PublicEvent = PublicEvent::new(0);
/// Public event: READY → MOVING.
pub const START_MOVING: PublicEvent = PublicEvent::new(1);
/// Public event: any level from OFF up → EMERGENCY.
pub const FAULT: PublicEvent = PublicEvent::new(2);
/// Public event: EMERGENCY → OFF.
pub const RESET: PublicEvent = PublicEvent::new(3);
/// Private event of the emergency-stop input: any level → EMERGENCY.
pub const ESTOP: PrivateEvent = PrivateEvent::new(0);
/// Private event of [`power_up`]: POWERING → READY.
pub const POWERED: PrivateEvent = PrivateEvent::new(1);

/// Critical input: the emergency-stop button (fires [`ESTOP`] while pressed).
pub const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
/// Critical output: the drive's enable.
pub const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
/// Critical output: the status lamp.
pub const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "status lamp");

/// Cycles the power stage needs in POWERING before [`power_up`] reports [`POWERED`].
pub const POWER_UP_CYCLES: u32 = 2;

/// The machine as the safety system sees it: the critical I/O and the power stage's count
/// of cycles in POWERING.
pub trait Machine: SafetyIo {
    /// Cycles spent in POWERING so far.
    fn powering_cycles(&self) -> u32;
    /// Stores the count of cycles spent in POWERING.
    fn set_powering_cycles(&mut self, n: u32);
}

/// Level action of POWERING: counts its cycles and reports [`POWERED`] in the
/// [`POWER_UP_CYCLES`]-th.
pub fn power_up<M: Machine>(ctx: &mut SafetyContext<'_>, io: &mut M) {
    let n = io.powering_cycles().wrapping_add(1);
    io.set_powering_cycles(n);
    if n == POWER_UP_CYCLES {
        ctx.trigger(POWERED);
    }
}

const WATCH_ESTOP: [InputAction; 1] = [ESTOP_IN.check(false, ESTOP)];
const SAFE_BLINKING: [OutputAction; 2] = [ENABLE.set(false), LAMP.toggle()];
const SAFE_DARK: [OutputAction; 2] = [ENABLE.set(false), LAMP.set(false)];
const DRIVING: [OutputAction; 2] = [ENABLE.set(true), LAMP.set(true)];
const INPUTS: [CriticalInputInfo; 1] = [ESTOP_IN.info()];
const OUTPUTS: [CriticalOutputInfo; 2] = [ENABLE.info(), LAMP.info()];
const TRANSITIONS: [LevelTransition; 6] = [
    LevelTransition::on_level_and_above(EMERGENCY, ESTOP, EMERGENCY),
    LevelTransition::on_level_and_above(OFF, FAULT, EMERGENCY),
    LevelTransition::on(EMERGENCY, RESET, OFF),
    LevelTransition::on(OFF, SWITCH_ON, POWERING),
    LevelTransition::on(POWERING, POWERED, READY),
    LevelTransition::on(READY, START_MOVING, MOVING),
];

/// The validated safety properties for the I/O type `M`; entry level OFF. Meant for a
/// `static` initializer, so that an invalid table fails the build.
pub const fn properties<M: Machine>() -> Result<ValidProperties<'static, M, 5>, SafetyError> {
    SafetyProperties::new(
        [
            LevelDef::new(EMERGENCY, "emergency")
                .inputs(&WATCH_ESTOP)
                .outputs(&SAFE_BLINKING)
                .abort_sequences(AbortPolicy::WhileActive),
            LevelDef::new(OFF, "off")
                .inputs(&WATCH_ESTOP)
                .outputs(&SAFE_DARK),
            LevelDef::new(POWERING, "powering")
                .inputs(&WATCH_ESTOP)
                .outputs(&SAFE_BLINKING)
                .level_action(power_up::<M>),
            LevelDef::new(READY, "ready")
                .inputs(&WATCH_ESTOP)
                .outputs(&DRIVING),
            LevelDef::new(MOVING, "moving")
                .inputs(&WATCH_ESTOP)
                .outputs(&DRIVING),
        ],
        &INPUTS,
        &OUTPUTS,
        &TRANSITIONS,
        OFF,
    )
    .validated()
}
