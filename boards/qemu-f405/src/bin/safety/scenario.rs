//! The safety scenario shared by the QEMU firmware (`src/bin/safety.rs`) and the host
//! (`tests/qemu_safety.rs`, which includes this file with `#[path]`): one safety system of
//! 8 levels, 8 critical inputs and 8 critical outputs, a script of stimuli per cycle, the
//! expectations per cycle, and the canonical record of a cycle. `no_std`, panic-free (no
//! indexing, no arithmetic that can overflow), so it stays inside the no-panic proof.
//!
//! The script (cycle `n` runs at tick `n`, one cycle per 1 ms tick):
//!
//! | cycle | stimulus (before the cycle) | level after | what it shows |
//! |---|---|---|---|
//! | 1 | — | OFF | entry level entered |
//! | 2 | SWITCH_ON (public) | POWER_ON | chain |
//! | 3–4 | POWERED (private, level action in 3) | HOMING in 4 | private events |
//! | 5–6 | HOMED (private, level action in 5) | READY in 6 | |
//! | 7 | speed = 50, START | MOVING | |
//! | 8 | SPEED_UP + STOP | READY | two events in one cycle: the safest wins |
//! | 9, 10 | START, SPEED_UP | MOVING, FAST | |
//! | 11 | NOBODY (no transition) | FAST | unknown event counted |
//! | 13–15 | current = 7.5 A (range ±5) | FAST, OFF, OFF | range fault, re-triggering while it lasts |
//! | 16 | current = 0 | OFF | |
//! | 17–22 | chain again | MOVING in 22 | |
//! | 23 | SPEED_UP + JOG + STOP | READY | three events: the safest wins |
//! | 24 | START | MOVING | |
//! | 25 | estop pressed | MOVING (input fires) | |
//! | 26 | — | EMERGENCY | safe outputs, abort-all, lamp and buzzer toggle |
//! | 27 | RESET (while pressed) | EMERGENCY | the pending ESTOP (stay) beats RESET |
//! | 28 | estop released | EMERGENCY | |
//! | 29 | RESET | OFF | |
//! | 30 | — | OFF | end |
//!
//! Public events (`public_events`) are triggered by a *lane* on the chip (a sequence's job,
//! lock-free through the `SafetyHandle`, at the tick before the cycle); the plant stimuli
//! (`plant`: input values, the private events the level action raises) are applied by the
//! safety task itself right before the cycle. On the host both are applied before the
//! cycle: the same events reach the same cycle.

use core::cell::Cell;

use rtseq::safety::*;

/// Number of cycles of the script.
pub const CYCLES: u32 = 30;

pub const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
pub const OFF: SafetyLevel = SafetyLevel::new(1);
pub const POWER_ON: SafetyLevel = SafetyLevel::new(2);
pub const HOMING: SafetyLevel = SafetyLevel::new(3);
pub const READY: SafetyLevel = SafetyLevel::new(4);
pub const MOVING: SafetyLevel = SafetyLevel::new(5);
pub const JOGGING: SafetyLevel = SafetyLevel::new(6);
pub const FAST: SafetyLevel = SafetyLevel::new(7);

pub const SWITCH_ON: PublicEvent = PublicEvent::new(0);
pub const SWITCH_OFF: PublicEvent = PublicEvent::new(1);
pub const START: PublicEvent = PublicEvent::new(2);
pub const STOP: PublicEvent = PublicEvent::new(3);
pub const RESET: PublicEvent = PublicEvent::new(4);
pub const JOG: PublicEvent = PublicEvent::new(5);
pub const SPEED_UP: PublicEvent = PublicEvent::new(6);
pub const STALL: PublicEvent = PublicEvent::new(7);
pub const NOBODY: PublicEvent = PublicEvent::new(9);

pub const ESTOP: PrivateEvent = PrivateEvent::new(0);
pub const POWERED: PrivateEvent = PrivateEvent::new(1);
pub const HOMED: PrivateEvent = PrivateEvent::new(2);
pub const OVERCURRENT: PrivateEvent = PrivateEvent::new(3);
pub const OVERTEMP: PrivateEvent = PrivateEvent::new(4);
pub const DOOR_OPEN: PrivateEvent = PrivateEvent::new(5);
pub const LIMIT: PrivateEvent = PrivateEvent::new(6);

pub const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
pub const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "motor current [A]");
pub const SPEED: CriticalInput<i32> = CriticalInput::new(2, "speed [rpm]");
pub const TEMP: CriticalInput<f32> = CriticalInput::new(3, "temperature [C]");
pub const DOOR: CriticalInput<bool> = CriticalInput::new(4, "door open");
pub const POSITION: CriticalInput<i32> = CriticalInput::new(5, "position [mm]");
pub const VOLTAGE: CriticalInput<f32> = CriticalInput::new(6, "bus voltage [V]");
pub const LIMIT_IN: CriticalInput<bool> = CriticalInput::new(7, "limit switch");

pub const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
pub const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "status lamp");
pub const DUTY: CriticalOutput<i32> = CriticalOutput::new(2, "duty limit [%]");
pub const BRAKE: CriticalOutput<bool> = CriticalOutput::new(3, "brake engaged");
pub const FAN: CriticalOutput<bool> = CriticalOutput::new(4, "fan");
pub const BUZZER: CriticalOutput<bool> = CriticalOutput::new(5, "buzzer");
pub const LED: CriticalOutput<i32> = CriticalOutput::new(6, "level display");
pub const RELAY: CriticalOutput<bool> = CriticalOutput::new(7, "main relay");

/// The simulated critical IO: input values and the last value written to every output
/// (plain memory: QEMU 7.2 does not model the STM32F4 GPIO ports, they are
/// "unimplemented devices" that read 0 and ignore writes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Io {
    pub inputs: [IoValue; 8],
    pub outputs: [IoValue; 8],
    /// A private event the plant asks the level action to raise (e.g. the power stage
    /// reports "powered").
    pub request: Option<PrivateEvent>,
}

impl Io {
    /// Healthy inputs, every output off.
    pub const fn new() -> Self {
        use IoValue::{Bool as B, Float as F, Int as I};
        Io {
            inputs: [
                B(false),
                F(0.0),
                I(0),
                F(25.0),
                B(false),
                I(0),
                F(24.0),
                B(false),
            ],
            outputs: [
                B(false),
                B(false),
                I(0),
                B(false),
                B(false),
                B(false),
                I(0),
                B(false),
            ],
            request: None,
        }
    }

    fn set_input(&mut self, input: InputId, value: IoValue) {
        if let Some(slot) = self.inputs.get_mut(input.index()) {
            *slot = value;
        }
    }

    /// The outputs as integers for the record (bool 0/1, integers as they are, floats in
    /// thousandths).
    pub fn output_values(&self) -> [i32; 8] {
        let mut out = [0; 8];
        for (o, v) in out.iter_mut().zip(self.outputs.iter()) {
            *o = match *v {
                IoValue::Bool(b) => i32::from(b),
                IoValue::Int(i) => i,
                IoValue::Float(f) => (f * 1000.0) as i32,
            };
        }
        out
    }
}

impl Default for Io {
    fn default() -> Self {
        Self::new()
    }
}

impl SafetyIo for Io {
    // Ids are < 8 (validated properties); the mask keeps the index provably in bounds, so
    // the indexing has no panic path and no branch.
    #[inline]
    #[allow(clippy::indexing_slicing)]
    fn read_input(&mut self, input: InputId) -> IoValue {
        self.inputs[input.index() & 7]
    }
    #[inline]
    #[allow(clippy::indexing_slicing)]
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        self.outputs[output.index() & 7] = value;
    }
}

/// The level action of POWER_ON and HOMING: raise the private event the plant requested
/// (the power stage reports "powered", the homing "homed").
fn level_action(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    if let Some(event) = io.request.take() {
        ctx.trigger(event);
    }
}

const ESTOP_CHECK: InputAction = ESTOP_IN.check(false, ESTOP);
const CURRENT_RANGE: InputAction = CURRENT.range(-5.0, 5.0, OVERCURRENT);
const TEMP_RANGE: InputAction = TEMP.range(-20.0, 80.0, OVERTEMP);
const DOOR_CHECK: InputAction = DOOR.check(false, DOOR_OPEN);
const VOLTAGE_RANGE: InputAction = VOLTAGE.range(20.0, 28.0, ESTOP);
const POSITION_RANGE: InputAction = POSITION.range(-1000, 1000, LIMIT);
const LIMIT_CHECK: InputAction = LIMIT_IN.check(false, LIMIT);
const STANDSTILL: InputAction = SPEED.off_range(-10, 10, STALL);

/// Every input watched (READY ignores only the speed).
const WATCH_ALL: [InputAction; 8] = [
    ESTOP_CHECK,
    CURRENT_RANGE,
    STANDSTILL,
    TEMP_RANGE,
    DOOR_CHECK,
    POSITION_RANGE,
    VOLTAGE_RANGE,
    LIMIT_CHECK,
];

/// The safety properties: 8 levels × 8 inputs × 8 outputs, validated by the compiler.
pub static PROPS: ValidProperties<'static, Io, 8> = match SafetyProperties::new(
    [
        LevelDef::new(EMERGENCY, "emergency")
            .inputs(&[
                ESTOP_CHECK,
                CURRENT.ignore(),
                SPEED.ignore(),
                TEMP.ignore(),
                DOOR.ignore(),
                POSITION.ignore(),
                VOLTAGE.ignore(),
                LIMIT_IN.ignore(),
            ])
            .outputs(&[
                ENABLE.set(false),
                LAMP.toggle(),
                DUTY.set(0),
                BRAKE.set(true),
                FAN.leave(),
                BUZZER.toggle(),
                LED.set(0),
                RELAY.set(false),
            ])
            .abort_sequences(AbortPolicy::WhileActive),
        LevelDef::new(OFF, "off")
            .inputs(&[
                ESTOP_CHECK,
                CURRENT_RANGE,
                SPEED.ignore(),
                TEMP.ignore(),
                DOOR.ignore(),
                POSITION.ignore(),
                VOLTAGE.ignore(),
                LIMIT_IN.ignore(),
            ])
            .outputs(&[
                ENABLE.set(false),
                LAMP.set(false),
                DUTY.set(0),
                BRAKE.set(true),
                FAN.set(false),
                BUZZER.set(false),
                LED.set(1),
                RELAY.set(false),
            ]),
        LevelDef::new(POWER_ON, "power on")
            .inputs(&[
                ESTOP_CHECK,
                CURRENT.ignore(),
                SPEED.ignore(),
                TEMP.ignore(),
                DOOR.ignore(),
                POSITION.ignore(),
                VOLTAGE_RANGE,
                LIMIT_IN.ignore(),
            ])
            .outputs(&[
                ENABLE.set(false),
                LAMP.toggle(),
                DUTY.set(0),
                BRAKE.set(true),
                FAN.set(true),
                BUZZER.set(false),
                LED.set(2),
                RELAY.set(true),
            ])
            .level_action(level_action),
        LevelDef::new(HOMING, "homing")
            .inputs(&[
                ESTOP_CHECK,
                CURRENT_RANGE,
                SPEED.ignore(),
                TEMP_RANGE,
                DOOR_CHECK,
                POSITION.ignore(),
                VOLTAGE_RANGE,
                LIMIT_IN.ignore(),
            ])
            .outputs(&[
                ENABLE.set(true),
                LAMP.toggle(),
                DUTY.toggle(0, 5),
                BRAKE.set(false),
                FAN.set(true),
                BUZZER.set(false),
                LED.set(3),
                RELAY.set(true),
            ])
            .level_action(level_action),
        LevelDef::new(READY, "ready")
            .inputs(&[
                ESTOP_CHECK,
                CURRENT_RANGE,
                SPEED.ignore(),
                TEMP_RANGE,
                DOOR_CHECK,
                POSITION_RANGE,
                VOLTAGE_RANGE,
                LIMIT_CHECK,
            ])
            .outputs(&[
                ENABLE.set(true),
                LAMP.set(true),
                DUTY.leave(),
                BRAKE.set(false),
                FAN.set(true),
                BUZZER.set(false),
                LED.set(4),
                RELAY.set(true),
            ]),
        LevelDef::new(MOVING, "moving")
            .inputs(&WATCH_ALL)
            .outputs(&[
                ENABLE.set(true),
                LAMP.set(true),
                DUTY.toggle(10, 20),
                BRAKE.set(false),
                FAN.set(true),
                BUZZER.set(false),
                LED.set(5),
                RELAY.set(true),
            ]),
        LevelDef::new(JOGGING, "jogging")
            .inputs(&WATCH_ALL)
            .outputs(&[
                ENABLE.set(true),
                LAMP.toggle(),
                DUTY.set(3),
                BRAKE.set(false),
                FAN.set(true),
                BUZZER.set(false),
                LED.set(6),
                RELAY.set(true),
            ]),
        LevelDef::new(FAST, "fast").inputs(&WATCH_ALL).outputs(&[
            ENABLE.set(true),
            LAMP.set(true),
            DUTY.set(40),
            BRAKE.set(false),
            FAN.set(true),
            BUZZER.set(false),
            LED.set(7),
            RELAY.set(true),
        ]),
    ],
    &[
        ESTOP_IN.info(),
        CURRENT.info(),
        SPEED.info(),
        TEMP.info(),
        DOOR.info(),
        POSITION.info(),
        VOLTAGE.info(),
        LIMIT_IN.info(),
    ],
    &[
        ENABLE.info(),
        LAMP.info(),
        DUTY.info(),
        BRAKE.info(),
        FAN.info(),
        BUZZER.info(),
        LED.info(),
        RELAY.info(),
    ],
    &[
        LevelTransition::on_level_and_above(EMERGENCY, ESTOP, EMERGENCY),
        LevelTransition::on_level_and_below(OFF, RESET, OFF),
        LevelTransition::on(OFF, SWITCH_ON, POWER_ON),
        LevelTransition::on(POWER_ON, POWERED, HOMING),
        LevelTransition::on(HOMING, HOMED, READY),
        LevelTransition::on(READY, START, MOVING),
        LevelTransition::on(MOVING, STOP, READY),
        LevelTransition::on(MOVING, JOG, JOGGING),
        LevelTransition::on(MOVING, SPEED_UP, FAST),
        LevelTransition::on(JOGGING, STOP, MOVING),
        LevelTransition::on(FAST, STOP, MOVING),
        LevelTransition::on_levels_between(POWER_ON, FAST, SWITCH_OFF, OFF),
        LevelTransition::on(OFF, OVERCURRENT, OFF),
        LevelTransition::on_levels_between(HOMING, FAST, OVERCURRENT, OFF),
        LevelTransition::on_levels_between(HOMING, FAST, OVERTEMP, OFF),
        LevelTransition::on_levels_between(HOMING, FAST, DOOR_OPEN, OFF),
        LevelTransition::on_levels_between(READY, FAST, LIMIT, EMERGENCY),
        LevelTransition::on_levels_between(MOVING, FAST, STALL, READY),
    ],
    OFF,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

/// Public events triggered before cycle `n` (by a lane on the chip).
pub fn public_events(n: u32) -> &'static [PublicEvent] {
    match n {
        2 | 17 => &[SWITCH_ON],
        7 | 9 | 22 | 24 => &[START],
        8 => &[SPEED_UP, STOP],
        10 => &[SPEED_UP],
        11 => &[NOBODY],
        23 => &[SPEED_UP, JOG, STOP],
        27 | 29 => &[RESET],
        _ => &[],
    }
}

/// Plant stimuli applied right before cycle `n`: input values, private-event requests.
pub fn plant(n: u32, io: &mut Io) {
    match n {
        3 | 18 => io.request = Some(POWERED),
        5 | 20 => io.request = Some(HOMED),
        7 => io.set_input(SPEED.id(), IoValue::Int(50)),
        13 => io.set_input(CURRENT.id(), IoValue::Float(7.5)),
        16 => io.set_input(CURRENT.id(), IoValue::Float(0.0)),
        25 => io.set_input(ESTOP_IN.id(), IoValue::Bool(true)),
        28 => io.set_input(ESTOP_IN.id(), IoValue::Bool(false)),
        _ => {}
    }
}

/// Counts abort-all requests (there is no sequencer in this scenario).
#[derive(Debug, Default)]
pub struct Aborts(pub Cell<u32>);

impl Sequences for Aborts {
    fn abort_all(&self) {
        self.0.set(self.0.get().wrapping_add(1));
    }
}

/// The canonical record of one cycle, logged by the firmware and compared with the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    pub cycle: u32,
    pub level: u8,
    /// Level left (-1: none, the very first cycle or no change).
    pub from: i16,
    /// Level entered (-1: no change).
    pub to: i16,
    pub input_events: u32,
    pub unknown: u32,
    pub aborted: bool,
    pub outputs: [i32; 8],
}

impl Record {
    pub fn new(cycle: u32, report: &CycleReport, io: &Io) -> Self {
        let (from, to) = match report.change {
            Some(c) => (
                c.from.map_or(-1, |l| i16::from(l.id())),
                i16::from(c.to.id()),
            ),
            None => (-1, -1),
        };
        Record {
            cycle,
            level: report.level.id(),
            from,
            to,
            input_events: report.input_events,
            unknown: report.unknown_events,
            aborted: report.aborted,
            outputs: io.output_values(),
        }
    }

    /// FNV-1a over every field: one number for the whole run.
    pub fn digest(&self, mut h: u32) -> u32 {
        let mut eat = |v: u32| {
            for b in v.to_le_bytes() {
                h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
            }
        };
        eat(self.cycle);
        eat(u32::from(self.level));
        eat(self.from as u32);
        eat(self.to as u32);
        eat(self.input_events);
        eat(self.unknown);
        eat(u32::from(self.aborted));
        for o in self.outputs {
            eat(o as u32);
        }
        h
    }
}

/// FNV-1a offset basis.
pub const DIGEST_SEED: u32 = 0x811c_9dc5;

/// Expected (level, level entered or -1, input events, unknown events, aborted) per cycle.
const EXPECT: [(SafetyLevel, i16, u32, u32, bool); CYCLES as usize] = [
    (OFF, 1, 0, 0, false),        // 1 entry level
    (POWER_ON, 2, 0, 0, false),   // 2 SWITCH_ON
    (POWER_ON, -1, 0, 0, false),  // 3 level action raises POWERED
    (HOMING, 3, 0, 0, false),     // 4
    (HOMING, -1, 0, 0, false),    // 5 level action raises HOMED
    (READY, 4, 0, 0, false),      // 6
    (MOVING, 5, 0, 0, false),     // 7 START
    (READY, 4, 0, 0, false),      // 8 SPEED_UP (FAST) + STOP (READY): READY wins
    (MOVING, 5, 0, 0, false),     // 9
    (FAST, 7, 0, 0, false),       // 10
    (FAST, -1, 0, 1, false),      // 11 NOBODY: unknown
    (FAST, -1, 0, 0, false),      // 12
    (FAST, -1, 1 << 1, 0, false), // 13 current 7.5 A: OVERCURRENT fires
    (OFF, 1, 1 << 1, 0, false),   // 14 -> OFF; fires again (OFF watches the current)
    (OFF, -1, 1 << 1, 0, false),  // 15 still firing; OVERCURRENT -> OFF is a stay
    (OFF, -1, 0, 0, false),       // 16 current back to 0
    (POWER_ON, 2, 0, 0, false),   // 17
    (POWER_ON, -1, 0, 0, false),  // 18
    (HOMING, 3, 0, 0, false),     // 19
    (HOMING, -1, 0, 0, false),    // 20
    (READY, 4, 0, 0, false),      // 21
    (MOVING, 5, 0, 0, false),     // 22
    (READY, 4, 0, 0, false),      // 23 SPEED_UP (FAST) + JOG (JOGGING) + STOP (READY)
    (MOVING, 5, 0, 0, false),     // 24
    (MOVING, -1, 1, 0, false),    // 25 estop pressed: ESTOP fires
    (EMERGENCY, 0, 1, 0, true),   // 26 emergency: safe outputs, abort-all
    (EMERGENCY, -1, 1, 0, true),  // 27 RESET loses against the pending ESTOP (stay)
    (EMERGENCY, -1, 0, 0, true),  // 28 estop released
    (OFF, 1, 0, 0, false),        // 29 RESET
    (OFF, -1, 0, 0, false),       // 30
];

/// Checks a record against the expectations: `Err(what)` names the first mismatch.
pub fn check(r: &Record) -> Result<(), &'static str> {
    let Some(&(level, to, inputs, unknown, aborted)) =
        EXPECT.get((r.cycle as usize).wrapping_sub(1))
    else {
        return Err("cycle out of the script");
    };
    if r.level != level.id() {
        return Err("level");
    }
    if r.to != to {
        return Err("level change");
    }
    if r.input_events != inputs {
        return Err("input events");
    }
    if r.unknown != unknown {
        return Err("unknown events");
    }
    if r.aborted != aborted {
        return Err("abort-all");
    }
    // Outputs: every level drives its values every cycle; toggles alternate low/high from
    // the entering cycle; `leave` keeps the last value.
    let o = r.outputs;
    let want: Option<[i32; 8]> = match r.cycle {
        1 | 16 | 30 => Some([0, 0, 0, 1, 0, 0, 1, 0]),
        2 => Some([0, 0, 0, 1, 1, 0, 2, 1]), // POWER_ON: lamp toggles, low first
        3 => Some([0, 1, 0, 1, 1, 0, 2, 1]), // ... then high
        4 => Some([1, 0, 0, 0, 1, 0, 3, 1]), // HOMING: lamp low, duty toggles 0 ...
        5 => Some([1, 1, 5, 0, 1, 0, 3, 1]), // ... then high, 5
        6 => Some([1, 1, 5, 0, 1, 0, 4, 1]), // READY: duty left at 5
        7 => Some([1, 1, 10, 0, 1, 0, 5, 1]), // MOVING: duty toggles 10 ...
        8 => Some([1, 1, 10, 0, 1, 0, 4, 1]), // READY: duty left at 10
        10 => Some([1, 1, 40, 0, 1, 0, 7, 1]), // FAST
        25 => Some([1, 1, 20, 0, 1, 0, 5, 1]), // MOVING, 2nd cycle: duty 20
        // EMERGENCY: drive off, brake on, relay off; lamp and buzzer blink; fan left on.
        26 => Some([0, 0, 0, 1, 1, 0, 0, 0]),
        27 => Some([0, 1, 0, 1, 1, 1, 0, 0]),
        28 => Some([0, 0, 0, 1, 1, 0, 0, 0]),
        29 => Some([0, 0, 0, 1, 0, 0, 1, 0]),
        _ => None,
    };
    match want {
        Some(w) if w != o => Err("outputs"),
        _ => Ok(()),
    }
}

/// Abort-all requests expected over the whole script (cycles 26, 27, 28).
pub const EXPECTED_ABORTS: u32 = 3;
