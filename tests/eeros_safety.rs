//! EEROS's own safety-system tests (`test/safety/LevelTest.cpp` and
//! `test/safety/CriticalInputTest.cpp` of the EEROS framework, gtest), ported to
//! `rtseq::safety` and checked cycle by cycle: level, level change, fired inputs, unknown
//! events, outputs.
//!
//! Mapping, the same in every test:
//! * An EEROS `SafetyLevel` added with `addLevel` gets the id of its position (EEROS
//!   `SafetyProperties::addLevel`, SafetyProperties.cpp 67–70); the rtseq level has that id.
//! * `SafetySystem::run()` is `SafetySystem::cycle`; `triggerEvent` from outside is
//!   `SafetyHandle::trigger`; `getCurrentLevel()` is `CycleReport::level` /
//!   `SafetyHandle::level()`. EEROS resolves a triggered event against the current level
//!   at once (SafetySystem.cpp 86–113) and switches in the next `run()` (lines 125–142);
//!   rtseq resolves it at the start of the next cycle, against the same level (no cycle
//!   runs in between in these tests), so the levels are the same.
//! * EEROS's event type is given per transition (`kPublicEvent` / `kPrivateEvent`); rtseq's
//!   is the event's type (`PublicEvent` / `PrivateEvent`). An EEROS event used both ways
//!   is two rtseq events.
//! * EEROS's simulated HAL (an output wired back to an input) is the test's `SafetyIo`:
//!   the inputs it returns are set by the test, the outputs written are recorded exactly.

use std::sync::Mutex;

use rtseq::safety::*;

/// Tests that build a safety system take this lock, so that the handles (one per test)
/// are never shared by accident and the runs stay independent.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The IO of the level tests: no critical input or output.
struct NoIo;
impl SafetyIo for NoIo {
    fn read_input(&mut self, _: InputId) -> IoValue {
        IoValue::Bool(false)
    }
    fn write_output(&mut self, _: OutputId, _: IoValue) {}
}

// ---------------------------------------------------------------------------------------
// LevelTest.cpp, SafetyPropertiesTest1: five levels, four public events.
// ---------------------------------------------------------------------------------------

const SL1: SafetyLevel = SafetyLevel::new(0);
const SL2: SafetyLevel = SafetyLevel::new(1);
const SL3: SafetyLevel = SafetyLevel::new(2);
const SL4: SafetyLevel = SafetyLevel::new(3);
const SL5: SafetyLevel = SafetyLevel::new(4);

const SE1: PublicEvent = PublicEvent::new(0);
const SE2: PublicEvent = PublicEvent::new(1);
const SE3: PublicEvent = PublicEvent::new(2);
const SE4: PublicEvent = PublicEvent::new(3);

static TEST1: ValidProperties<'static, NoIo, 5> = match SafetyProperties::new(
    [
        LevelDef::new(SL1, "1"),
        LevelDef::new(SL2, "2"),
        LevelDef::new(SL3, "3"),
        LevelDef::new(SL4, "4"),
        LevelDef::new(SL5, "5"),
    ],
    &[],
    &[],
    &[
        LevelTransition::on(SL1, SE1, SL2),
        LevelTransition::on(SL1, SE2, SL4),
        LevelTransition::on(SL1, SE4, SL5),
        LevelTransition::on(SL2, SE1, SL3),
        // addEventToLevelAndAbove(sl3, se3, sl1)
        LevelTransition::on_level_and_above(SL3, SE3, SL1),
        // addEventToAllLevelsBetween(sl4, sl5, se1, sl2)
        LevelTransition::on_levels_between(SL4, SL5, SE1, SL2),
    ],
    SL1,
)
.validated()
{
    Ok(p) => p,
    Err(_) => panic!("invalid safety properties"),
};

/// EEROS test/safety/LevelTest.cpp, `TEST(safetyLevelTest, order)`: levels are ordered by
/// the order they were added (`sl1 < sl2`, `sl5 >= sl2`; SafetyLevel.cpp 20–42 compare the
/// ids). rtseq: `SafetyLevel` is `Ord` by its id, lower = safer; the properties list the
/// levels in id order (checked by `validate`). Passes.
#[test]
fn eeros_level_test_order_levels_compare_by_id() {
    assert!(SL1 < SL2);
    assert!(SL5 >= SL2);
    // Strict: the comparison is the id's, as EEROS's.
    assert!(SL2 >= SL1 && SL2 < SL5);
    let ids: Vec<u8> = TEST1
        .properties()
        .levels()
        .iter()
        .map(|l| l.level().id())
        .collect();
    assert_eq!(ids, [0, 1, 2, 3, 4]);
}

/// EEROS test/safety/LevelTest.cpp, `TEST(safetyLevelTest, trigger)`: from the entry level
/// `1`, fourteen events, each followed by one `run()`: se1 → 2; se3 and se2 in 2 "should
/// stay" (no transition: EEROS logs "no transition for this event", SafetySystem.cpp
/// 105–107, and keeps the level); se1 → 3; se1 in 3 stays; se3 → 1; se2 → 4; se3 → 1;
/// se4 → 5; se3 → 1; se2 → 4; se1 → 2.
///
/// rtseq: the same events through the handle, one cycle each: the same levels after every
/// cycle; each "stay" is an unknown event, counted in the cycle's report and named by
/// `last_unknown_event` (rtseq never drops one silently). Passes.
#[test]
fn eeros_level_test_trigger_follows_the_transitions_and_counts_unknown_events() {
    let _serial = serial();
    static HANDLE: SafetyHandle = SafetyHandle::new();
    let mut ss = SafetySystem::new_validated(&TEST1, &HANDLE).unwrap();
    let first = ss.cycle(&mut NoIo, &NoSequences);
    assert_eq!(first.level, SL1);
    assert_eq!(
        first.change,
        Some(LevelChange {
            from: None,
            to: SL1
        })
    );
    // (event, level after the cycle, unknown events in the cycle)
    let steps: [(PublicEvent, SafetyLevel, u32); 14] = [
        (SE1, SL2, 0),
        (SE3, SL2, 1), // should stay
        (SE2, SL2, 1), // should stay
        (SE1, SL3, 0),
        (SE1, SL3, 1), // should stay
        (SE3, SL1, 0),
        (SE2, SL4, 0),
        (SE3, SL1, 0),
        (SE4, SL5, 0),
        (SE3, SL1, 0),
        (SE2, SL4, 0),
        (SE1, SL2, 0),
        (SE1, SL3, 0), // beyond EEROS's list: 2 → 3 again, then 3 → 1
        (SE3, SL1, 0),
    ];
    let mut got = Vec::new();
    let mut unknown = Vec::new();
    for (event, _, _) in steps {
        let before = ss.level();
        HANDLE.trigger(event);
        let r = ss.cycle(&mut NoIo, &NoSequences);
        assert_eq!(HANDLE.level(), r.level);
        assert_eq!(
            r.change,
            (r.level != before).then_some(LevelChange {
                from: Some(before),
                to: r.level
            })
        );
        got.push((event, r.level, r.unknown_events));
        if r.unknown_events > 0 {
            unknown.push(ss.last_unknown_event());
        }
    }
    assert_eq!(got, steps);
    let u = |e: PublicEvent, l| {
        Some(UnknownEvent {
            event: e.id(),
            level: l,
        })
    };
    assert_eq!(unknown, [u(SE3, SL2), u(SE2, SL2), u(SE1, SL3)]);
    assert_eq!(ss.unknown_events(), 3);
    // Levels entered: 1 at the start and four times more, 2, 3 and 4 twice each, 5 once.
    let activations: Vec<u32> = [SL1, SL2, SL3, SL4, SL5]
        .iter()
        .map(|&l| ss.stats(l).unwrap().activations)
        .collect();
    assert_eq!(activations, [5, 2, 2, 2, 1]);
}

// ---------------------------------------------------------------------------------------
// LevelTest.cpp, ScaraSafetyProperties: thirty levels, level actions that trigger events.
// ---------------------------------------------------------------------------------------

mod scara {
    use super::*;

    pub const OFF: SafetyLevel = SafetyLevel::new(0);
    pub const NOTINIT_EMERGENCY: SafetyLevel = SafetyLevel::new(1);
    pub const NOTINIT_WAITING_FOR_APPROVAL: SafetyLevel = SafetyLevel::new(2);
    pub const NOTINIT_SYSTEM_ON: SafetyLevel = SafetyLevel::new(3);
    pub const MANUAL_PARKING3: SafetyLevel = SafetyLevel::new(4);
    pub const MANUAL_PARKING2: SafetyLevel = SafetyLevel::new(5);
    pub const MANUAL_PARKING1: SafetyLevel = SafetyLevel::new(6);
    pub const MANUAL_PARKING0: SafetyLevel = SafetyLevel::new(7);
    pub const ROBOT_PARKED: SafetyLevel = SafetyLevel::new(8);
    pub const HOMING3: SafetyLevel = SafetyLevel::new(9);
    pub const HOMING2: SafetyLevel = SafetyLevel::new(10);
    pub const HOMING1: SafetyLevel = SafetyLevel::new(11);
    pub const HOMING0: SafetyLevel = SafetyLevel::new(12);
    pub const ROBOT_HOMED: SafetyLevel = SafetyLevel::new(13);
    pub const EMERGENCY: SafetyLevel = SafetyLevel::new(14);
    pub const RESET_EMERGENCY: SafetyLevel = SafetyLevel::new(15);
    pub const WAITING_FOR_APPROVAL: SafetyLevel = SafetyLevel::new(16);
    pub const SYSTEM_ON: SafetyLevel = SafetyLevel::new(17);
    pub const POWER_ON: SafetyLevel = SafetyLevel::new(18);
    pub const GOING_TO_READY: SafetyLevel = SafetyLevel::new(19);
    pub const READY: SafetyLevel = SafetyLevel::new(20);
    pub const SET_MOVING: SafetyLevel = SafetyLevel::new(21);
    pub const MOVING: SafetyLevel = SafetyLevel::new(22);
    pub const SET_MOVING_JOYSTICK: SafetyLevel = SafetyLevel::new(23);
    pub const MOVING_JOYSTICK: SafetyLevel = SafetyLevel::new(24);
    pub const SET_AUTO_PARKING: SafetyLevel = SafetyLevel::new(25);
    pub const AUTO_PARKING_SHUTDOWN3: SafetyLevel = SafetyLevel::new(26);
    pub const AUTO_PARKING_SHUTDOWN2: SafetyLevel = SafetyLevel::new(27);
    pub const AUTO_PARKING_SHUTDOWN1: SafetyLevel = SafetyLevel::new(28);
    pub const AUTO_PARKING_SHUTDOWN0: SafetyLevel = SafetyLevel::new(29);

    // Events used on `kPublicEvent` transitions. (`doEmergency_posOutRange` and
    // `doEmergency_velOutRange` are declared by EEROS but used by no transition.)
    pub const NOTINIT_GO_TO_WAITING_FOR_APPROVAL: PublicEvent = PublicEvent::new(0);
    pub const EV1: PublicEvent = PublicEvent::new(1);
    pub const APPROVAL_IS_ON: PublicEvent = PublicEvent::new(2);
    pub const DO_MANUAL_PARKING: PublicEvent = PublicEvent::new(3);
    pub const EV2: PublicEvent = PublicEvent::new(4);
    pub const DO_HOMING: PublicEvent = PublicEvent::new(5);
    pub const DO_SYSTEM_ON: PublicEvent = PublicEvent::new(6);
    pub const DO_RESET_EMERGENCY: PublicEvent = PublicEvent::new(7);
    /// `doOff` on `systemOn` (public); on `notinit_emergency` it is private: `DO_OFF_PRIVATE`.
    pub const DO_OFF: PublicEvent = PublicEvent::new(8);
    pub const DO_POWER_UP: PublicEvent = PublicEvent::new(9);
    pub const DO_POWER_DOWN: PublicEvent = PublicEvent::new(10);
    pub const GO_TO_READY: PublicEvent = PublicEvent::new(11);
    pub const IS_READY: PublicEvent = PublicEvent::new(12);
    pub const DO_SET_MOVING_JOYSTICK: PublicEvent = PublicEvent::new(13);
    pub const DO_SET_MOVING: PublicEvent = PublicEvent::new(14);
    pub const DO_AUTO_PARKING_SHUTDOWN: PublicEvent = PublicEvent::new(15);
    pub const DO_START_MOVING: PublicEvent = PublicEvent::new(16);
    pub const DO_STOP_MOVING: PublicEvent = PublicEvent::new(17);
    pub const DO_START_MOVING_JOYSTICK: PublicEvent = PublicEvent::new(18);
    pub const DO_STOP_MOVING_JOYSTICK: PublicEvent = PublicEvent::new(19);
    pub const DO_EMERGENCY: PublicEvent = PublicEvent::new(20);

    // Events used on `kPrivateEvent` transitions.
    pub const DO_OFF_PRIVATE: PrivateEvent = PrivateEvent::new(0);
    pub const MANUAL_PARKING_DONE3: PrivateEvent = PrivateEvent::new(1);
    pub const MANUAL_PARKING_DONE2: PrivateEvent = PrivateEvent::new(2);
    pub const MANUAL_PARKING_DONE1: PrivateEvent = PrivateEvent::new(3);
    pub const MANUAL_PARKING_DONE0: PrivateEvent = PrivateEvent::new(4);
    pub const HOMING_DONE3: PrivateEvent = PrivateEvent::new(5);
    pub const HOMING_DONE2: PrivateEvent = PrivateEvent::new(6);
    pub const HOMING_DONE1: PrivateEvent = PrivateEvent::new(7);
    pub const HOMING_DONE0: PrivateEvent = PrivateEvent::new(8);
    pub const RESET_EMERGENCY_DONE: PrivateEvent = PrivateEvent::new(9);
    pub const DO_START_AUTO_PARKING: PrivateEvent = PrivateEvent::new(10);
    pub const AUTO_PARKING_SHUTDOWN_DONE3: PrivateEvent = PrivateEvent::new(11);
    pub const AUTO_PARKING_SHUTDOWN_DONE2: PrivateEvent = PrivateEvent::new(12);
    pub const AUTO_PARKING_SHUTDOWN_DONE1: PrivateEvent = PrivateEvent::new(13);
    pub const AUTO_PARKING_SHUTDOWN_DONE0: PrivateEvent = PrivateEvent::new(14);

    /// The application's side of the level actions: the actions that ran, with the
    /// cycles run in their level as the action saw them.
    #[derive(Default)]
    pub struct Io {
        pub actions: Vec<(u8, &'static str, u32)>,
    }
    impl SafetyIo for Io {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }

    fn off(ctx: &mut SafetyContext<'_>, io: &mut Io) {
        io.actions
            .push((ctx.level().id(), "off", ctx.stats().cycles));
    }
    fn notinit_emergency(ctx: &mut SafetyContext<'_>, io: &mut Io) {
        io.actions
            .push((ctx.level().id(), "notinit_emergency", ctx.stats().cycles));
    }
    /// EEROS: `privateContext->triggerEvent(doEmergency)` in every cycle of `homing 3`.
    fn homing3(ctx: &mut SafetyContext<'_>, io: &mut Io) {
        io.actions
            .push((ctx.level().id(), "homing3", ctx.stats().cycles));
        ctx.trigger(DO_EMERGENCY);
    }
    /// EEROS: `if (moving.getNofActivations() > 2) triggerEvent(doEmergency)`.
    fn moving(ctx: &mut SafetyContext<'_>, io: &mut Io) {
        io.actions
            .push((ctx.level().id(), "moving", ctx.stats().cycles));
        if ctx.stats().cycles > 2 {
            ctx.trigger(DO_EMERGENCY);
        }
    }

    pub static PROPS: ValidProperties<'static, Io, 30> = match SafetyProperties::new(
        [
            LevelDef::new(OFF, "off").level_action(off),
            LevelDef::new(NOTINIT_EMERGENCY, "emergency, not init").level_action(notinit_emergency),
            LevelDef::new(NOTINIT_WAITING_FOR_APPROVAL, "waitingForApproval, not init"),
            LevelDef::new(NOTINIT_SYSTEM_ON, "systemOn, not init"),
            LevelDef::new(MANUAL_PARKING3, "manualParking 3"),
            LevelDef::new(MANUAL_PARKING2, "manualParking 2"),
            LevelDef::new(MANUAL_PARKING1, "manualParking 1"),
            LevelDef::new(MANUAL_PARKING0, "manualParking 0"),
            LevelDef::new(ROBOT_PARKED, "robotParked"),
            LevelDef::new(HOMING3, "homing 3").level_action(homing3),
            LevelDef::new(HOMING2, "homing 2"),
            LevelDef::new(HOMING1, "homing 1"),
            LevelDef::new(HOMING0, "homing 0"),
            LevelDef::new(ROBOT_HOMED, "robot homed"),
            LevelDef::new(EMERGENCY, "Emergency"),
            LevelDef::new(RESET_EMERGENCY, "Emergency reset"),
            LevelDef::new(WAITING_FOR_APPROVAL, "Waiting for approval"),
            LevelDef::new(SYSTEM_ON, "System on"),
            LevelDef::new(POWER_ON, "Power on"),
            LevelDef::new(GOING_TO_READY, "System going to ready"),
            LevelDef::new(READY, "System ready"),
            LevelDef::new(SET_MOVING, "Set Moving"),
            LevelDef::new(MOVING, "Moving").level_action(moving),
            LevelDef::new(SET_MOVING_JOYSTICK, "Set Moving joystick"),
            LevelDef::new(MOVING_JOYSTICK, "Moving joystick"),
            LevelDef::new(SET_AUTO_PARKING, "Set Autoparking axes"),
            LevelDef::new(AUTO_PARKING_SHUTDOWN3, "Autoparking q3"),
            LevelDef::new(AUTO_PARKING_SHUTDOWN2, "Autoparking q2"),
            LevelDef::new(AUTO_PARKING_SHUTDOWN1, "Autoparking q1"),
            LevelDef::new(AUTO_PARKING_SHUTDOWN0, "Autoparking q0"),
        ],
        &[],
        &[],
        &[
            LevelTransition::on(
                OFF,
                NOTINIT_GO_TO_WAITING_FOR_APPROVAL,
                NOTINIT_WAITING_FOR_APPROVAL,
            ),
            LevelTransition::on(OFF, EV1, HOMING3),
            LevelTransition::on(
                NOTINIT_WAITING_FOR_APPROVAL,
                APPROVAL_IS_ON,
                NOTINIT_SYSTEM_ON,
            ),
            LevelTransition::on(NOTINIT_SYSTEM_ON, DO_MANUAL_PARKING, MANUAL_PARKING3),
            LevelTransition::on(NOTINIT_EMERGENCY, DO_OFF_PRIVATE, OFF),
            LevelTransition::on(NOTINIT_EMERGENCY, EV2, MOVING),
            LevelTransition::on(MANUAL_PARKING3, MANUAL_PARKING_DONE3, MANUAL_PARKING2),
            LevelTransition::on(MANUAL_PARKING2, MANUAL_PARKING_DONE2, MANUAL_PARKING1),
            LevelTransition::on(MANUAL_PARKING1, MANUAL_PARKING_DONE1, MANUAL_PARKING0),
            LevelTransition::on(MANUAL_PARKING0, MANUAL_PARKING_DONE0, ROBOT_PARKED),
            LevelTransition::on(ROBOT_PARKED, DO_HOMING, HOMING3),
            LevelTransition::on(HOMING3, HOMING_DONE3, HOMING2),
            LevelTransition::on(HOMING2, HOMING_DONE2, HOMING1),
            LevelTransition::on(HOMING1, HOMING_DONE1, HOMING0),
            LevelTransition::on(HOMING0, HOMING_DONE0, ROBOT_HOMED),
            LevelTransition::on(ROBOT_HOMED, DO_SYSTEM_ON, SYSTEM_ON),
            LevelTransition::on(EMERGENCY, DO_RESET_EMERGENCY, RESET_EMERGENCY),
            LevelTransition::on(RESET_EMERGENCY, RESET_EMERGENCY_DONE, WAITING_FOR_APPROVAL),
            LevelTransition::on(WAITING_FOR_APPROVAL, APPROVAL_IS_ON, SYSTEM_ON),
            LevelTransition::on(SYSTEM_ON, DO_OFF, OFF),
            LevelTransition::on(SYSTEM_ON, DO_POWER_UP, POWER_ON),
            LevelTransition::on(POWER_ON, DO_POWER_DOWN, SYSTEM_ON),
            LevelTransition::on(POWER_ON, GO_TO_READY, GOING_TO_READY),
            LevelTransition::on(GOING_TO_READY, IS_READY, READY),
            LevelTransition::on(READY, DO_SET_MOVING_JOYSTICK, SET_MOVING_JOYSTICK),
            LevelTransition::on(READY, DO_SET_MOVING, SET_MOVING),
            LevelTransition::on(READY, DO_AUTO_PARKING_SHUTDOWN, SET_AUTO_PARKING),
            LevelTransition::on(SET_MOVING, DO_START_MOVING, MOVING),
            LevelTransition::on(MOVING, DO_STOP_MOVING, READY),
            LevelTransition::on(
                SET_MOVING_JOYSTICK,
                DO_START_MOVING_JOYSTICK,
                MOVING_JOYSTICK,
            ),
            LevelTransition::on(MOVING_JOYSTICK, DO_STOP_MOVING_JOYSTICK, READY),
            LevelTransition::on(
                SET_AUTO_PARKING,
                DO_START_AUTO_PARKING,
                AUTO_PARKING_SHUTDOWN3,
            ),
            LevelTransition::on(
                AUTO_PARKING_SHUTDOWN3,
                AUTO_PARKING_SHUTDOWN_DONE3,
                AUTO_PARKING_SHUTDOWN2,
            ),
            LevelTransition::on(
                AUTO_PARKING_SHUTDOWN2,
                AUTO_PARKING_SHUTDOWN_DONE2,
                AUTO_PARKING_SHUTDOWN1,
            ),
            LevelTransition::on(
                AUTO_PARKING_SHUTDOWN1,
                AUTO_PARKING_SHUTDOWN_DONE1,
                AUTO_PARKING_SHUTDOWN0,
            ),
            LevelTransition::on(AUTO_PARKING_SHUTDOWN0, AUTO_PARKING_SHUTDOWN_DONE0, OFF),
            LevelTransition::on_levels_between(OFF, ROBOT_HOMED, DO_EMERGENCY, NOTINIT_EMERGENCY),
            LevelTransition::on_levels_between(
                RESET_EMERGENCY,
                AUTO_PARKING_SHUTDOWN0,
                DO_EMERGENCY,
                EMERGENCY,
            ),
        ],
        OFF,
    )
    .validated()
    {
        Ok(p) => p,
        Err(_) => panic!("invalid safety properties"),
    };
}

/// EEROS test/safety/LevelTest.cpp, `TEST(safetyLevelTest, trigger2)`: the SCARA robot's
/// thirty levels. `run()` enters `off`; `ev1` (public) and two runs: the first enters
/// `homing 3`, whose level action triggers `doEmergency` through the private context,
/// and the second enters `emergency, not init` (`doEmergency` leads from every level
/// between `off` and `robot homed` there). `ev2` (public) and one run: `Moving`. Four runs
/// more: `Moving`'s level action triggers `doEmergency` once `getNofActivations()` (the
/// cycles run in the level, counted from 1 in the entering cycle, SafetySystem.cpp 145)
/// exceeds 2, i.e. in its third cycle; the fourth run is in `Emergency`.
///
/// rtseq: the same thirty levels and transitions (`doOff`, public on one transition and
/// private on another, is two events); the same level after every cycle. The `moving`
/// action reads `SafetyContext::stats().cycles`, rtseq's `nofActivations`, and sees
/// 1, 2, 3 as EEROS's does; `SafetySystem::stats(MOVING)` agrees afterwards. Passes.
#[test]
fn eeros_level_test_trigger2_scara_level_actions_trigger_the_emergencies() {
    use scara::*;
    let _serial = serial();
    static HANDLE: SafetyHandle = SafetyHandle::new();
    let mut ss = SafetySystem::new_validated(&PROPS, &HANDLE).unwrap();
    let mut io = Io::default();
    let mut levels = Vec::new();
    let mut cycle = |ss: &mut SafetySystem<'_, Io, 30>, io: &mut Io| {
        let r = ss.cycle(io, &NoSequences);
        assert_eq!(r.unknown_events, 0);
        levels.push(r.level);
        r.level
    };
    assert_eq!(cycle(&mut ss, &mut io), OFF);
    HANDLE.trigger(EV1);
    assert_eq!(cycle(&mut ss, &mut io), HOMING3);
    assert_eq!(cycle(&mut ss, &mut io), NOTINIT_EMERGENCY);
    HANDLE.trigger(EV2);
    assert_eq!(cycle(&mut ss, &mut io), MOVING);
    assert_eq!(ss.stats(MOVING).unwrap().cycles, 1);
    assert_eq!(cycle(&mut ss, &mut io), MOVING);
    assert_eq!(cycle(&mut ss, &mut io), MOVING); // its action triggers doEmergency here
    assert_eq!(cycle(&mut ss, &mut io), EMERGENCY);
    assert_eq!(cycle(&mut ss, &mut io), EMERGENCY);
    assert_eq!(
        levels,
        [
            OFF,
            HOMING3,
            NOTINIT_EMERGENCY,
            MOVING,
            MOVING,
            MOVING,
            EMERGENCY,
            EMERGENCY
        ]
    );
    assert_eq!(ss.stats(MOVING).unwrap().cycles, 3);
    assert_eq!(
        io.actions,
        [
            (0, "off", 1),
            (9, "homing3", 1),
            (1, "notinit_emergency", 1),
            (22, "moving", 1),
            (22, "moving", 2),
            (22, "moving", 3),
        ]
    );
    assert_eq!(HANDLE.level(), EMERGENCY);
}

// ---------------------------------------------------------------------------------------
// CriticalInputTest.cpp: one critical input, one critical output, two levels.
// ---------------------------------------------------------------------------------------

/// The simulated HAL of the critical-input tests: the input's value, set by the test (EEROS
/// drives it through a constant, a peripheral output and the simulator's loop-back), and
/// every value written to the output.
struct Hal {
    input: IoValue,
    written: Vec<IoValue>,
}
impl Hal {
    fn new(input: IoValue) -> Self {
        Hal {
            input,
            written: Vec::new(),
        }
    }
}
impl SafetyIo for Hal {
    fn read_input(&mut self, _: InputId) -> IoValue {
        self.input
    }
    fn write_output(&mut self, _: OutputId, value: IoValue) {
        self.written.push(value);
    }
}

const C_SL1: SafetyLevel = SafetyLevel::new(0);
const C_SL2: SafetyLevel = SafetyLevel::new(1);
const C_SE1: PublicEvent = PublicEvent::new(0);
const C_SE2: PublicEvent = PublicEvent::new(1);
const C_TRANSITIONS: [LevelTransition; 2] = [
    LevelTransition::on(C_SL1, C_SE1, C_SL2),
    LevelTransition::on(C_SL2, C_SE2, C_SL1),
];

const IO_IN: CriticalInput<bool> = CriticalInput::new(0, "ioIn");
const IO1: CriticalOutput<bool> = CriticalOutput::new(0, "io1");

/// EEROS `SafetyPropertiesTestc1`.
const DIGITAL: SafetyProperties<'static, Hal, 2> = SafetyProperties::new(
    [
        LevelDef::new(C_SL1, "1")
            .inputs(&[IO_IN.check(false, C_SE1)])
            .outputs(&[IO1.set(true)]),
        LevelDef::new(C_SL2, "2")
            .inputs(&[IO_IN.check(true, C_SE2)])
            .outputs(&[IO1.set(false)]),
    ],
    &[IO_IN.info()],
    &[IO1.info()],
    &C_TRANSITIONS,
    C_SL1,
);

const A_IN1: CriticalInput<f32> = CriticalInput::new(0, "aIn1");
const A_OUT0: CriticalOutput<f32> = CriticalOutput::new(0, "aOut0");

const HI_OUT: &[OutputAction] = &[A_OUT0.set(2.3)];
const LO_OUT: &[OutputAction] = &[A_OUT0.set(-1.4)];
const LEVEL2_IN: &[InputAction] = &[A_IN1.range(2.9, 3.1, C_SE2)];
const A_INPUTS: &[CriticalInputInfo] = &[A_IN1.info()];
const A_OUTPUTS: &[CriticalOutputInfo] = &[A_OUT0.info()];

/// EEROS `SafetyPropertiesTestc2` (`level1` = `range(in, 0.9, 1.1, se1)`) and
/// `SafetyPropertiesTestc3` (`level1` = `range(in, 1.5, 3.5, se1, true)`, off-range).
const fn analog(level1: &'static [InputAction]) -> SafetyProperties<'static, Hal, 2> {
    SafetyProperties::new(
        [
            LevelDef::new(C_SL1, "1").inputs(level1).outputs(HI_OUT),
            LevelDef::new(C_SL2, "2").inputs(LEVEL2_IN).outputs(LO_OUT),
        ],
        A_INPUTS,
        A_OUTPUTS,
        &C_TRANSITIONS,
        C_SL1,
    )
}
static ANALOG: SafetyProperties<'static, Hal, 2> = analog(&[A_IN1.range(0.9, 1.1, C_SE1)]);
static ANALOG_OFF_RANGE: SafetyProperties<'static, Hal, 2> =
    analog(&[A_IN1.off_range(1.5, 3.5, C_SE1)]);
static DIGITAL_PROPS: SafetyProperties<'static, Hal, 2> = DIGITAL;

/// One cycle of the critical-input tests: the input value the cycle reads, and what the
/// cycle must report: the level, whether it changed, whether the input's check fired,
/// and the value written to the output.
type Row = (IoValue, SafetyLevel, bool, bool, IoValue);

/// Runs `rows`, one cycle each, and checks every report and write exactly.
fn run_rows(
    props: &'static SafetyProperties<'static, Hal, 2>,
    handle: &'static SafetyHandle,
    rows: &[Row],
) {
    let mut ss = SafetySystem::new(props, handle).unwrap();
    let mut hal = Hal::new(rows[0].0);
    let mut got = Vec::new();
    for &(input, ..) in rows {
        hal.input = input;
        let r = ss.cycle(&mut hal, &NoSequences);
        let changed = r.change.is_some();
        got.push((
            input,
            r.level,
            changed,
            r.input_events == 1,
            *hal.written.last().unwrap(),
        ));
        assert_eq!(hal.written.len(), got.len(), "one write per cycle");
        assert_eq!(r.unknown_events, 0);
    }
    assert_eq!(got, rows);
}

const F: IoValue = IoValue::Bool(false);
const T: IoValue = IoValue::Bool(true);

/// EEROS test/safety/CriticalInputTest.cpp, `TEST(safetyCriticalTest, digitalInput)`: level
/// 1 checks `ioIn == false` (else `se1` → 2) and sets `io1` true; level 2 checks
/// `ioIn == true` (else `se2` → 1) and sets `io1` false. EEROS's nine `run()`s with the
/// input false, false, true, true, true, false, false, false, false: levels 1, 1, 1 (the
/// check fires, CheckInputAction, InputAction.hpp 37–43), 2 (switched at the start of the
/// run, SafetySystem.cpp 125–142), 2, 2 (fires), 1, 1, 1; the output read back true in
/// level 1 and false in level 2 (the test's `in0`).
///
/// rtseq: `check(false, SE1)` / `check(true, SE2)`, `set(true)` / `set(false)`: the same
/// level, the same firing and the same output value in every cycle. Passes.
#[test]
fn eeros_critical_input_digital_check_switches_levels_and_sets_the_output() {
    let _serial = serial();
    static HANDLE: SafetyHandle = SafetyHandle::new();
    run_rows(
        &DIGITAL_PROPS,
        &HANDLE,
        &[
            (F, C_SL1, true, false, T), // the entry level
            (F, C_SL1, false, false, T),
            (T, C_SL1, false, true, T),
            (T, C_SL2, true, false, F),
            (T, C_SL2, false, false, F),
            (F, C_SL2, false, true, F),
            (F, C_SL1, true, false, T),
            (F, C_SL1, false, false, T),
            (F, C_SL1, false, false, T),
        ],
    );
}

/// EEROS `SafetyProperties::verify` throws "all critical outputs must be defined in level"
/// (SafetyProperties.cpp 34–38) when a level of `SafetyPropertiesTestc1` lacks the action
/// of `io1`, and the `SafetySystem` constructor throws "verification of safety properties
/// failed" (SafetySystem.cpp 24–26). rtseq: `validate` (a `const fn`) returns the exact
/// error, `SafetySystem::new` returns it as `Err` (and `validated()` makes it a compile
/// error in a `static`). The same for a missing input action. Passes.
#[test]
fn eeros_critical_input_a_level_without_an_action_is_refused() {
    const NO_OUTPUT: SafetyProperties<'static, Hal, 2> = SafetyProperties::new(
        [
            LevelDef::new(C_SL1, "1")
                .inputs(&[IO_IN.check(false, C_SE1)])
                .outputs(&[IO1.set(true)]),
            LevelDef::new(C_SL2, "2").inputs(&[IO_IN.check(true, C_SE2)]),
        ],
        &[IO_IN.info()],
        &[IO1.info()],
        &C_TRANSITIONS,
        C_SL1,
    );
    const NO_INPUT: SafetyProperties<'static, Hal, 2> = SafetyProperties::new(
        [
            LevelDef::new(C_SL1, "1").outputs(&[IO1.set(true)]),
            LevelDef::new(C_SL2, "2")
                .inputs(&[IO_IN.check(true, C_SE2)])
                .outputs(&[IO1.set(false)]),
        ],
        &[IO_IN.info()],
        &[IO1.info()],
        &C_TRANSITIONS,
        C_SL1,
    );
    static NO_OUTPUT_PROPS: SafetyProperties<'static, Hal, 2> = NO_OUTPUT;
    static HANDLE: SafetyHandle = SafetyHandle::new();
    let _serial = serial();
    let missing_output = SafetyError::MissingOutputAction {
        level: C_SL2,
        level_name: "2",
        output: IO1.id(),
        output_name: "io1",
    };
    assert_eq!(NO_OUTPUT.validate(), Err(missing_output));
    assert_eq!(
        SafetySystem::new(&NO_OUTPUT_PROPS, &HANDLE).err(),
        Some(missing_output)
    );
    assert!(!HANDLE.is_bound());
    assert_eq!(
        NO_INPUT.validate(),
        Err(SafetyError::MissingInputAction {
            level: C_SL1,
            level_name: "1",
            input: IO_IN.id(),
            input_name: "ioIn",
        })
    );
    assert_eq!(DIGITAL.validate(), Ok(()));
}

/// EEROS test/safety/CriticalInputTest.cpp, `TEST(safetyCriticalTest, analogInput)`: level
/// 1 checks `aIn1` in [0.9, 1.1] (else `se1`) and sets `aOut0` to 2.3; level 2 checks
/// [2.9, 3.1] (else `se2`) and sets −1.4. Eight `run()`s with the input 1.0, 3.0, 3.0, 3.0,
/// 1.0, 1.0, 1.0, 1.0: levels 1, 1 (fires: `value < min || value > max`, InputAction.hpp
/// 63), 2, 2, 2 (fires), 1, 1, 1; EEROS reads the output back through its simulated
/// converter (≈ 2.4 and ≈ −1.5, tolerance 0.1).
///
/// rtseq: `CriticalInput<f32>::range` and `CriticalOutput<f32>::set` (EEROS's `double`
/// is `f32` here): the same levels and firings, and exactly 2.3 / −1.4 written. Passes.
#[test]
fn eeros_critical_input_analog_range_switches_levels_and_sets_the_output() {
    let _serial = serial();
    static HANDLE: SafetyHandle = SafetyHandle::new();
    let (one, three) = (IoValue::Float(1.0), IoValue::Float(3.0));
    let (hi, lo) = (IoValue::Float(2.3), IoValue::Float(-1.4));
    run_rows(
        &ANALOG,
        &HANDLE,
        &[
            (one, C_SL1, true, false, hi),
            (three, C_SL1, false, true, hi),
            (three, C_SL2, true, false, lo),
            (three, C_SL2, false, false, lo),
            (one, C_SL2, false, true, lo),
            (one, C_SL1, true, false, hi),
            (one, C_SL1, false, false, hi),
            (one, C_SL1, false, false, hi),
        ],
    );
}

/// EEROS test/safety/CriticalInputTest.cpp, `TEST(safetyCriticalTest, analogInputOffRange)`:
/// as `analogInput`, but level 1's check is `range(in, 1.5, 3.5, se1, true)`, which fires
/// while the value is strictly inside (1.5, 3.5) (InputAction.hpp 57–61): 1.0 does not
/// fire, 3.0 does. The same eight runs and levels as `analogInput`.
///
/// rtseq: `CriticalInput<f32>::off_range(1.5, 3.5, SE1)`, which fires strictly inside:
/// the same levels, firings and outputs. Passes.
#[test]
fn eeros_critical_input_analog_off_range_switches_levels_and_sets_the_output() {
    let _serial = serial();
    static HANDLE: SafetyHandle = SafetyHandle::new();
    let (one, three) = (IoValue::Float(1.0), IoValue::Float(3.0));
    let (hi, lo) = (IoValue::Float(2.3), IoValue::Float(-1.4));
    run_rows(
        &ANALOG_OFF_RANGE,
        &HANDLE,
        &[
            (one, C_SL1, true, false, hi),
            (three, C_SL1, false, true, hi),
            (three, C_SL2, true, false, lo),
            (three, C_SL2, false, false, lo),
            (one, C_SL2, false, true, lo),
            (one, C_SL1, true, false, hi),
            (one, C_SL1, false, false, hi),
            (one, C_SL1, false, false, hi),
        ],
    );
    // The bounds themselves are outside the open interval: 1.5 and 3.5 do not fire.
    assert_eq!(
        A_IN1
            .off_range(1.5, 3.5, C_SE1)
            .check()
            .evaluate(IoValue::Float(1.5)),
        None
    );
    assert_eq!(
        A_IN1
            .off_range(1.5, 3.5, C_SE1)
            .check()
            .evaluate(IoValue::Float(3.5)),
        None
    );
    assert_eq!(
        A_IN1
            .off_range(1.5, 3.5, C_SE1)
            .check()
            .evaluate(IoValue::Float(3.0)),
        Some(C_SE1.id())
    );
}
