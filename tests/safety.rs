//! Host tests of the safety system (issue 4): transition chains, several
//! events per cycle, unknown events, action order, input checks, outputs,
//! completeness errors, abort-all, counters, the lock-free handle.

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use rtseq::safety::*;

// ---------------------------------------------------------------------------
// The machine under test: six levels, three inputs, three outputs.
// ---------------------------------------------------------------------------

const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
const OFF: SafetyLevel = SafetyLevel::new(1);
const POWER_ON: SafetyLevel = SafetyLevel::new(2);
const HOMING: SafetyLevel = SafetyLevel::new(3);
const READY: SafetyLevel = SafetyLevel::new(4);
const MOVING: SafetyLevel = SafetyLevel::new(5);
const NAMES: [&str; 6] = ["emergency", "off", "power on", "homing", "ready", "moving"];

const SWITCH_ON: PublicEvent = PublicEvent::new(0);
const SWITCH_OFF: PublicEvent = PublicEvent::new(1);
const START: PublicEvent = PublicEvent::new(2);
const STOP: PublicEvent = PublicEvent::new(3);
const RESET: PublicEvent = PublicEvent::new(4);
const STALL: PublicEvent = PublicEvent::new(5);
const NOBODY_LISTENS: PublicEvent = PublicEvent::new(9);

const ESTOP: PrivateEvent = PrivateEvent::new(0);
const POWERED: PrivateEvent = PrivateEvent::new(1);
const HOMED: PrivateEvent = PrivateEvent::new(2);
const OVERCURRENT: PrivateEvent = PrivateEvent::new(3);

const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "motor current");
const SPEED: CriticalInput<i32> = CriticalInput::new(2, "speed");
const INPUT_NAMES: [&str; 3] = ["estop", "current", "speed"];

const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "lamp");
const DUTY: CriticalOutput<i32> = CriticalOutput::new(2, "duty");
const OUTPUT_NAMES: [&str; 3] = ["enable", "lamp", "duty"];

type Log = Rc<RefCell<Vec<String>>>;

/// Simulated IO: input values set by the test, outputs recorded, every
/// action and (optionally) every read / write appended to a shared log.
struct Sim {
    inputs: [IoValue; 3],
    outputs: [Option<IoValue>; 3],
    writes: Vec<(usize, IoValue)>,
    log: Log,
    log_io: bool,
    /// Events the next level action triggers.
    level_public: Vec<PublicEvent>,
    level_private: Vec<PrivateEvent>,
    /// Events the next entry action triggers.
    entry_private: Vec<PrivateEvent>,
    /// The counters each entry and level action saw (`SafetyContext::stats`).
    seen: Vec<(&'static str, SafetyLevel, u32, u32)>,
}

impl Sim {
    fn new(log: &Log) -> Self {
        Sim {
            inputs: [IoValue::Bool(false), IoValue::Float(0.0), IoValue::Int(50)],
            outputs: [None; 3],
            writes: Vec::new(),
            log: log.clone(),
            log_io: false,
            level_public: Vec::new(),
            level_private: Vec::new(),
            entry_private: Vec::new(),
            seen: Vec::new(),
        }
    }
    fn note(&self, s: String) {
        self.log.borrow_mut().push(s);
    }
}

impl SafetyIo for Sim {
    fn read_input(&mut self, input: InputId) -> IoValue {
        if self.log_io {
            self.note(format!("read {}", INPUT_NAMES[input.index()]));
        }
        self.inputs[input.index()]
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        if self.log_io {
            self.note(format!("write {}={}", OUTPUT_NAMES[output.index()], value));
        }
        self.outputs[output.index()] = Some(value);
        self.writes.push((output.index(), value));
    }
}

fn entry<const N: usize>(ctx: &mut SafetyContext<'_>, io: &mut Sim) {
    io.note(format!("entry {}", NAMES[N]));
    let seen = ctx.stats();
    io.seen
        .push(("entry", ctx.level(), seen.activations, seen.cycles));
    for e in std::mem::take(&mut io.entry_private) {
        ctx.trigger(e);
    }
}
fn exit<const N: usize>(io: &mut Sim) {
    io.note(format!("exit {}", NAMES[N]));
}
fn action<const N: usize>(ctx: &mut SafetyContext<'_>, io: &mut Sim) {
    assert_eq!(ctx.level().index(), N);
    io.note(format!("action {}", NAMES[N]));
    let seen = ctx.stats();
    io.seen
        .push(("action", ctx.level(), seen.activations, seen.cycles));
    for e in std::mem::take(&mut io.level_public) {
        ctx.trigger(e);
    }
    for e in std::mem::take(&mut io.level_private) {
        ctx.trigger(e);
    }
}

/// Records abort requests into the shared log.
struct Recorder {
    log: Log,
    aborts: Cell<u32>,
}
impl Recorder {
    fn new(log: &Log) -> Self {
        Recorder {
            log: log.clone(),
            aborts: Cell::new(0),
        }
    }
}
impl Sequences for Recorder {
    fn abort_all(&self) {
        self.aborts.set(self.aborts.get() + 1);
        self.log.borrow_mut().push("abort all".into());
    }
}

const ESTOP_CHECK: InputAction = ESTOP_IN.check(false, ESTOP);
const CURRENT_RANGE: InputAction = CURRENT.range(-5.0, 5.0, OVERCURRENT);
const STANDSTILL: InputAction = SPEED.off_range(-10, 10, STALL);

static PROPS: SafetyProperties<'static, Sim, 6> = SafetyProperties::new(
    [
        LevelDef::new(EMERGENCY, "emergency")
            .inputs(&[ESTOP_CHECK, CURRENT.ignore(), SPEED.ignore()])
            .outputs(&[ENABLE.set(false), LAMP.toggle(), DUTY.set(0)])
            .on_entry(entry::<0>)
            .on_exit(exit::<0>)
            .level_action(action::<0>)
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(OFF, "off")
            .inputs(&[ESTOP_CHECK, CURRENT_RANGE, SPEED.ignore()])
            .outputs(&[ENABLE.set(false), LAMP.set(false), DUTY.set(0)])
            .on_entry(entry::<1>)
            .on_exit(exit::<1>)
            .level_action(action::<1>),
        LevelDef::new(POWER_ON, "power on")
            .inputs(&[ESTOP_CHECK, CURRENT.ignore(), SPEED.ignore()])
            .outputs(&[ENABLE.set(true), LAMP.leave(), DUTY.set(0)])
            .on_entry(entry::<2>)
            .on_exit(exit::<2>)
            .level_action(action::<2>),
        LevelDef::new(HOMING, "homing")
            .inputs(&[ESTOP_CHECK, CURRENT_RANGE, SPEED.ignore()])
            .outputs(&[ENABLE.set(true), LAMP.toggle(), DUTY.toggle(0, 5)])
            .on_entry(entry::<3>)
            .on_exit(exit::<3>)
            .level_action(action::<3>),
        LevelDef::new(READY, "ready")
            .inputs(&[ESTOP_CHECK, CURRENT_RANGE, STANDSTILL])
            .outputs(&[ENABLE.set(true), LAMP.set(true), DUTY.leave()])
            .on_entry(entry::<4>)
            .on_exit(exit::<4>)
            .level_action(action::<4>),
        LevelDef::new(MOVING, "moving")
            .inputs(&[ESTOP_CHECK, CURRENT_RANGE, STANDSTILL])
            .outputs(&[ENABLE.set(true), LAMP.set(true), DUTY.toggle(10, 20)])
            .on_entry(entry::<5>)
            .on_exit(exit::<5>)
            .level_action(action::<5>),
    ],
    &[ESTOP_IN.info(), CURRENT.info(), SPEED.info()],
    &[ENABLE.info(), LAMP.info(), DUTY.info()],
    &[
        LevelTransition::on_level_and_above(EMERGENCY, ESTOP, EMERGENCY),
        LevelTransition::on_level_and_below(OFF, RESET, OFF),
        LevelTransition::on(OFF, SWITCH_ON, POWER_ON),
        LevelTransition::on(POWER_ON, POWERED, HOMING),
        LevelTransition::on(HOMING, HOMED, READY),
        LevelTransition::on(READY, START, MOVING),
        LevelTransition::on(MOVING, STOP, READY),
        LevelTransition::on_levels_between(POWER_ON, MOVING, SWITCH_OFF, OFF),
        LevelTransition::on(OFF, OVERCURRENT, OFF),
        LevelTransition::on_levels_between(HOMING, MOVING, OVERCURRENT, OFF),
        LevelTransition::on_levels_between(READY, MOVING, STALL, READY),
    ],
    OFF,
);

// Completeness is checked by the compiler as well.
const _: () = assert!(PROPS.validate().is_ok());

struct Rig<'h> {
    ss: SafetySystem<'h, Sim, 6>,
    sim: Sim,
    rec: Recorder,
    log: Log,
    handle: &'h SafetyHandle,
}

impl<'h> Rig<'h> {
    fn new(handle: &'h SafetyHandle) -> Self {
        let log: Log = Rc::default();
        Rig {
            ss: SafetySystem::new(&PROPS, handle).expect("valid properties"),
            sim: Sim::new(&log),
            rec: Recorder::new(&log),
            log,
            handle,
        }
    }
    fn cycle(&mut self) -> CycleReport {
        self.sim.writes.clear();
        self.ss.cycle(&mut self.sim, &self.rec)
    }
    fn take_log(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.borrow_mut())
    }
    /// OFF -> POWER_ON -> HOMING -> READY -> MOVING up to `target`,
    /// asserting each step; clears the log.
    fn drive_to(&mut self, target: SafetyLevel) {
        assert_eq!(
            self.cycle().change,
            Some(LevelChange {
                from: None,
                to: OFF
            })
        );
        if target >= POWER_ON {
            self.handle.trigger(SWITCH_ON);
            assert_eq!(self.cycle().change, change(OFF, POWER_ON));
        }
        if target >= HOMING {
            self.sim.level_private.push(POWERED);
            assert_eq!(self.cycle().level, POWER_ON);
            assert_eq!(self.cycle().change, change(POWER_ON, HOMING));
        }
        if target >= READY {
            self.sim.level_private.push(HOMED);
            assert_eq!(self.cycle().level, HOMING);
            assert_eq!(self.cycle().change, change(HOMING, READY));
        }
        if target >= MOVING {
            self.handle.trigger(START);
            assert_eq!(self.cycle().change, change(READY, MOVING));
        }
        assert_eq!(self.ss.level(), target);
        assert_eq!(self.handle.level(), target);
        self.take_log();
    }

    fn drive_to_moving(&mut self) {
        self.drive_to(MOVING);
    }
}

fn change(from: SafetyLevel, to: SafetyLevel) -> Option<LevelChange> {
    Some(LevelChange {
        from: Some(from),
        to,
    })
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

// ---------------------------------------------------------------------------
// Construction, initial state, counters
// ---------------------------------------------------------------------------

#[test]
fn initial_state_and_first_cycle() {
    let handle = SafetyHandle::new();
    assert_eq!(handle.level(), SafetyLevel::SAFEST);
    let mut rig = Rig::new(&handle);
    // Bound and published before the first cycle; all counters zero.
    assert!(handle.is_bound());
    assert_eq!(handle.level(), OFF);
    assert_eq!(rig.ss.level(), OFF);
    assert!(!rig.ss.is_started());
    for l in 0..6 {
        assert_eq!(
            rig.ss.stats(SafetyLevel::new(l)),
            Some(LevelStats::default())
        );
    }
    assert_eq!(rig.ss.stats(SafetyLevel::new(6)), None);
    assert_eq!(rig.ss.unknown_events(), 0);
    assert_eq!(rig.ss.last_unknown_event(), None);

    let r = rig.cycle();
    assert_eq!(
        r,
        CycleReport {
            level: OFF,
            change: Some(LevelChange {
                from: None,
                to: OFF
            }),
            input_events: 0,
            aborted: false,
            unknown_events: 0,
        }
    );
    // Entry action of the entry level, no exit action.
    assert_eq!(rig.take_log(), strings(&["entry off", "action off"]));
    assert_eq!(
        rig.ss.stats(OFF),
        Some(LevelStats {
            activations: 1,
            cycles: 1
        })
    );
    assert_eq!(handle.cycles(), 1);
    assert_eq!(rig.ss.level_name(), "off");
}

#[test]
fn events_before_the_first_cycle_wait_for_the_second() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    handle.trigger(SWITCH_ON);
    assert_eq!(rig.cycle().level, OFF);
    assert_eq!(handle.pending_events(), 1 << 0);
    assert_eq!(rig.cycle().change, change(OFF, POWER_ON));
    assert_eq!(handle.pending_events(), 0);
}

#[test]
fn activation_counters() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    rig.cycle(); // 2nd cycle in MOVING
    handle.trigger(STOP);
    rig.cycle(); // READY again
    handle.trigger(START);
    rig.cycle(); // MOVING again
    handle.trigger(SWITCH_OFF);
    rig.cycle(); // OFF again
    {
        let s = |l| rig.ss.stats(l).unwrap();
        assert_eq!(
            s(EMERGENCY),
            LevelStats {
                activations: 0,
                cycles: 0
            }
        );
        assert_eq!(
            s(OFF),
            LevelStats {
                activations: 2,
                cycles: 2
            }
        );
        assert_eq!(
            s(POWER_ON),
            LevelStats {
                activations: 1,
                cycles: 2
            }
        );
        assert_eq!(
            s(HOMING),
            LevelStats {
                activations: 1,
                cycles: 2
            }
        );
        assert_eq!(
            s(READY),
            LevelStats {
                activations: 2,
                cycles: 2
            }
        );
        assert_eq!(
            s(MOVING),
            LevelStats {
                activations: 2,
                cycles: 3
            }
        );
    }
    assert_eq!(handle.cycles(), 11);
    // What MOVING's actions saw (`SafetyContext::stats`): the entry counts itself and the
    // cycles before it; the level action counts its own cycle.
    let moving: Vec<_> = rig.sim.seen.iter().filter(|s| s.1 == MOVING).collect();
    assert_eq!(
        moving,
        [
            &("entry", MOVING, 1, 0),
            &("action", MOVING, 1, 1),
            &("action", MOVING, 1, 2),
            &("entry", MOVING, 2, 2),
            &("action", MOVING, 2, 3),
        ]
    );
    // Staying (a self-transition) is not an activation.
    handle.trigger(RESET);
    assert_eq!(rig.cycle().change, None);
    assert_eq!(
        rig.ss.stats(OFF),
        Some(LevelStats {
            activations: 2,
            cycles: 3
        })
    );
}

// ---------------------------------------------------------------------------
// Transitions
// ---------------------------------------------------------------------------

#[test]
fn transition_chain_over_six_levels_public_and_private() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    assert_eq!(
        rig.cycle().change,
        Some(LevelChange {
            from: None,
            to: OFF
        })
    );

    // public SWITCH_ON: OFF -> POWER_ON, applied in the next cycle
    handle.trigger(SWITCH_ON);
    assert_eq!(handle.level(), OFF);
    assert_eq!(rig.cycle().change, change(OFF, POWER_ON));
    assert_eq!(handle.level(), POWER_ON);

    // private POWERED from the level action: POWER_ON -> HOMING next cycle
    rig.sim.level_private.push(POWERED);
    let r = rig.cycle();
    assert_eq!((r.level, r.change), (POWER_ON, None));
    assert_eq!(rig.cycle().change, change(POWER_ON, HOMING));

    // private HOMED from the entry action of... the level action of HOMING
    rig.sim.level_private.push(HOMED);
    rig.cycle();
    assert_eq!(rig.cycle().change, change(HOMING, READY));

    // public START / STOP / START
    handle.trigger(START);
    assert_eq!(rig.cycle().change, change(READY, MOVING));
    handle.trigger(STOP);
    assert_eq!(rig.cycle().change, change(MOVING, READY));
    handle.trigger(START);
    assert_eq!(rig.cycle().change, change(READY, MOVING));

    // private ESTOP from a level action: MOVING -> EMERGENCY
    rig.sim.level_private.push(ESTOP);
    rig.cycle();
    assert_eq!(rig.cycle().change, change(MOVING, EMERGENCY));

    // public RESET: EMERGENCY -> OFF
    handle.trigger(RESET);
    assert_eq!(rig.cycle().change, change(EMERGENCY, OFF));
    assert_eq!(handle.level(), OFF);
    assert_eq!(rig.ss.unknown_events(), 0);

    // The visited levels, from the log of entry actions.
    let entries: Vec<String> = rig
        .take_log()
        .into_iter()
        .filter(|l| l.starts_with("entry"))
        .collect();
    assert_eq!(
        entries,
        strings(&[
            "entry off",
            "entry power on",
            "entry homing",
            "entry ready",
            "entry moving",
            "entry ready",
            "entry moving",
            "entry emergency",
            "entry off",
        ])
    );
}

#[test]
fn a_public_event_can_also_come_from_inside() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.cycle();
    rig.sim.level_public.push(SWITCH_ON);
    assert_eq!(rig.cycle().change, None);
    assert_eq!(rig.cycle().change, change(OFF, POWER_ON));
}

#[test]
fn entry_action_events_are_resolved_against_the_new_level() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.cycle();
    handle.trigger(SWITCH_ON);
    rig.sim.entry_private.push(POWERED); // POWER_ON's entry action triggers it
    assert_eq!(rig.cycle().change, change(OFF, POWER_ON));
    assert_eq!(rig.cycle().change, change(POWER_ON, HOMING));
}

#[test]
fn band_rows_cover_exactly_their_levels() {
    // SWITCH_OFF: POWER_ON..=MOVING -> OFF
    for from in 0..6u8 {
        let from = SafetyLevel::new(from);
        let expected = (POWER_ON <= from).then_some(OFF);
        assert_eq!(PROPS.destination(from, SWITCH_OFF), expected, "{from}");
    }
    // ESTOP: every level -> EMERGENCY; RESET: EMERGENCY and OFF -> OFF
    for from in 0..6u8 {
        let from = SafetyLevel::new(from);
        assert_eq!(PROPS.destination(from, ESTOP), Some(EMERGENCY));
        assert_eq!(PROPS.destination(from, RESET), (from <= OFF).then_some(OFF));
    }
    // OVERCURRENT: OFF stays, HOMING..=MOVING -> OFF, not in EMERGENCY / POWER_ON
    let over: Vec<_> = (0..6u8)
        .map(|l| PROPS.destination(SafetyLevel::new(l), OVERCURRENT))
        .collect();
    assert_eq!(
        over,
        [None, Some(OFF), None, Some(OFF), Some(OFF), Some(OFF)]
    );

    // And at run time, from each level of the band.
    for level in [POWER_ON, HOMING, READY, MOVING] {
        let handle = SafetyHandle::new();
        let mut rig = Rig::new(&handle);
        rig.drive_to(level);
        handle.trigger(SWITCH_OFF);
        assert_eq!(rig.cycle().change, change(level, OFF));
    }
}

#[test]
fn two_events_in_one_cycle_the_safest_wins() {
    for order in [[STOP, SWITCH_OFF], [SWITCH_OFF, STOP]] {
        let handle = SafetyHandle::new();
        let mut rig = Rig::new(&handle);
        rig.drive_to_moving();
        handle.trigger(order[0]); // STOP: MOVING -> READY
        handle.trigger(order[1]); // SWITCH_OFF: MOVING -> OFF
        let r = rig.cycle();
        assert_eq!(r.change, change(MOVING, OFF));
        // READY was never entered.
        assert_eq!(
            rig.take_log(),
            strings(&["exit moving", "entry off", "action off"])
        );
        assert_eq!(rig.ss.stats(READY).unwrap().activations, 1);
    }
}

#[test]
fn two_events_one_public_one_private_the_safest_wins() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    rig.sim.inputs[1] = IoValue::Float(6.0); // cycle n: private OVERCURRENT (-> OFF)
    assert_eq!(rig.cycle().input_events, 0b010);
    rig.sim.inputs[1] = IoValue::Float(0.0);
    handle.trigger(STOP); // public, -> READY
    let r = rig.cycle();
    assert_eq!(r.change, change(MOVING, OFF));
    assert_eq!(rig.ss.stats(READY).unwrap().activations, 1);
}

#[test]
fn a_stay_event_beats_a_less_safe_one() {
    // STALL keeps READY in READY; START would lead up to MOVING. In the
    // same cycle, the safest result is "stay": no exit, no entry.
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to(READY);
    rig.sim.inputs[2] = IoValue::Int(0); // standstill fires STALL (READY -> READY)
    assert_eq!(rig.cycle().input_events, 0b100);
    handle.trigger(START); // READY -> MOVING
    let r = rig.cycle();
    assert_eq!((r.level, r.change), (READY, None));
    assert_eq!(rig.take_log(), strings(&["action ready", "action ready"]));
}

#[test]
fn three_events_in_one_cycle_the_safest_wins() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    rig.sim.level_private.push(ESTOP); // -> EMERGENCY (private, from the level action)
    let r = rig.cycle();
    assert_eq!(
        (r.level, r.change),
        (MOVING, None),
        "inside events wait a cycle"
    );
    handle.trigger(STOP); // -> READY
    handle.trigger(SWITCH_OFF); // -> OFF
    let r = rig.cycle(); // all three are resolved here
    assert_eq!(r.change, change(MOVING, EMERGENCY));
    assert_eq!(r.unknown_events, 0);
    assert_eq!(
        rig.take_log(),
        strings(&[
            "action moving",
            "exit moving",
            "entry emergency",
            "abort all",
            "action emergency",
        ])
    );

    // Three events of which one is unknown in the current level.
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    handle.trigger(STOP); // -> READY
    handle.trigger(SWITCH_ON); // unknown in MOVING
    handle.trigger(STALL); // -> READY
    let r = rig.cycle();
    assert_eq!(r.change, change(MOVING, READY));
    assert_eq!(r.unknown_events, 1);
    assert_eq!(
        rig.ss.last_unknown_event(),
        Some(UnknownEvent {
            event: SWITCH_ON.id(),
            level: MOVING
        })
    );
}

#[test]
fn unknown_events_are_counted_and_reported() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.cycle();
    rig.take_log();

    // A public event with no transition from OFF.
    handle.trigger(START);
    let r = rig.cycle();
    assert_eq!((r.change, r.unknown_events), (None, 1));
    assert_eq!(rig.ss.unknown_events(), 1);
    assert_eq!(
        rig.ss.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::public(2),
            level: OFF
        })
    );
    assert_eq!(rig.take_log(), strings(&["action off"]), "no exit / entry");

    // A public event no row mentions at all.
    handle.trigger(NOBODY_LISTENS);
    rig.cycle();
    assert_eq!(rig.ss.unknown_events(), 2);
    assert_eq!(
        rig.ss.last_unknown_event().unwrap().event,
        EventId::public(9)
    );

    // A private event from the level action, unknown in OFF.
    rig.sim.level_private.push(HOMED);
    rig.cycle();
    let r = rig.cycle();
    assert_eq!(r.unknown_events, 1);
    assert_eq!(rig.ss.unknown_events(), 3);
    assert_eq!(
        rig.ss.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::private(2),
            level: OFF
        })
    );

    // Ids beyond the bitmask: from the handle and from inside.
    handle.trigger(PublicEvent::new(40));
    handle.trigger(PublicEvent::new(41));
    let r = rig.cycle();
    assert_eq!(r.unknown_events, 2);
    assert_eq!(rig.ss.unknown_events(), 5);
    assert_eq!(
        rig.ss.last_unknown_event().unwrap().event,
        EventId::public(41)
    );
    rig.sim.level_private.push(PrivateEvent::new(200));
    rig.cycle();
    assert_eq!(rig.cycle().unknown_events, 1);
    assert_eq!(
        rig.ss.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::private(200),
            level: OFF
        })
    );
    assert_eq!(rig.ss.unknown_events(), 6);
    assert_eq!(rig.ss.level(), OFF);

    // Several unknown ones in one cycle: ascending public, then private.
    handle.trigger(NOBODY_LISTENS);
    handle.trigger(START);
    rig.sim.level_private.push(POWERED);
    rig.cycle(); // NOBODY_LISTENS, START unknown now; POWERED next cycle
    assert_eq!(rig.ss.unknown_events(), 8);
    assert_eq!(
        rig.ss.last_unknown_event().unwrap().event,
        NOBODY_LISTENS.id()
    );
    rig.cycle();
    assert_eq!(rig.ss.unknown_events(), 9);
    assert_eq!(rig.ss.last_unknown_event().unwrap().event, POWERED.id());
}

#[test]
fn repeated_triggers_between_cycles_count_once() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.cycle();
    handle.trigger(START);
    handle.trigger(START);
    handle.trigger(START);
    assert_eq!(rig.cycle().unknown_events, 1);
}

// ---------------------------------------------------------------------------
// Order of a cycle
// ---------------------------------------------------------------------------

#[test]
fn cycle_order_exit_entry_abort_inputs_action_outputs() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.sim.log_io = true;
    rig.cycle();
    assert_eq!(
        rig.take_log(),
        strings(&[
            "entry off",
            "read estop",
            "read current",
            "action off",
            "write enable=false",
            "write lamp=false",
            "write duty=0",
        ])
    );

    // A cycle with a transition: the new level's inputs, action and
    // outputs run in the cycle it is entered.
    handle.trigger(SWITCH_ON);
    rig.cycle();
    assert_eq!(
        rig.take_log(),
        strings(&[
            "exit off",
            "entry power on",
            "read estop",
            "action power on",
            "write enable=true",
            "write duty=0",
        ])
    );

    // A cycle without a transition.
    rig.cycle();
    assert_eq!(
        rig.take_log(),
        strings(&[
            "read estop",
            "action power on",
            "write enable=true",
            "write duty=0",
        ])
    );

    // Into the emergency level: exit, entry, abort, inputs, action, outputs.
    rig.sim.level_private.push(ESTOP);
    rig.cycle();
    rig.take_log();
    rig.cycle();
    assert_eq!(
        rig.take_log(),
        strings(&[
            "exit power on",
            "entry emergency",
            "abort all",
            "read estop",
            "action emergency",
            "write enable=false",
            "write lamp=false",
            "write duty=0",
        ])
    );
}

// ---------------------------------------------------------------------------
// Critical inputs
// ---------------------------------------------------------------------------

#[test]
fn input_check_fires_in_its_cycle_and_retriggers_while_the_fault_lasts() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();

    // Cycle n: the estop is pressed; the check fires, the level is still MOVING.
    rig.sim.inputs[0] = IoValue::Bool(true);
    let r = rig.cycle();
    assert_eq!((r.level, r.change, r.input_events), (MOVING, None, 0b001));
    // Cycle n+1: EMERGENCY, whose own estop check fires again (it stays).
    let r = rig.cycle();
    assert_eq!(
        (r.change, r.input_events),
        (change(MOVING, EMERGENCY), 0b001)
    );
    // While the fault lasts, it re-triggers every cycle; a RESET cannot
    // win against it (ESTOP -> EMERGENCY is safer than RESET -> OFF).
    for _ in 0..3 {
        handle.trigger(RESET);
        let r = rig.cycle();
        assert_eq!(
            (r.level, r.change, r.input_events),
            (EMERGENCY, None, 0b001)
        );
    }
    // Released: the last ESTOP (from the previous cycle) still counts once.
    rig.sim.inputs[0] = IoValue::Bool(false);
    handle.trigger(RESET);
    let r = rig.cycle();
    assert_eq!((r.level, r.change, r.input_events), (EMERGENCY, None, 0));
    handle.trigger(RESET);
    let r = rig.cycle();
    assert_eq!((r.change, r.input_events), (change(EMERGENCY, OFF), 0));
    assert_eq!(rig.ss.unknown_events(), 0);
}

#[test]
fn input_range_fires_outside_bounds_inclusive_and_on_nan() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.cycle(); // OFF checks the current range, OVERCURRENT stays in OFF

    let cases: [(f32, u32); 8] = [
        (0.0, 0),
        (5.0, 0),
        (-5.0, 0),
        (5.001, 0b010),
        (-5.5, 0b010),
        (f32::NAN, 0b010),
        (f32::INFINITY, 0b010),
        (4.999, 0),
    ];
    for (value, fired) in cases {
        rig.sim.inputs[1] = IoValue::Float(value);
        assert_eq!(rig.cycle().input_events, fired, "current {value}");
    }
    // A reading of the wrong kind fails the check (fail-safe).
    rig.sim.inputs[1] = IoValue::Int(0);
    assert_eq!(rig.cycle().input_events, 0b010);
    rig.sim.inputs[1] = IoValue::Float(0.0);
    rig.cycle();
    assert_eq!(rig.ss.level(), OFF);
    assert_eq!(rig.ss.unknown_events(), 0);
}

#[test]
fn input_range_retriggers_and_leads_to_off_in_the_next_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    rig.sim.inputs[1] = IoValue::Float(7.5);
    let r = rig.cycle(); // cycle n: fires in MOVING
    assert_eq!((r.level, r.change, r.input_events), (MOVING, None, 0b010));
    let r = rig.cycle(); // n+1: OFF, whose range check fires again
    assert_eq!((r.change, r.input_events), (change(MOVING, OFF), 0b010));
    for _ in 0..3 {
        let r = rig.cycle(); // OVERCURRENT in OFF: known, stays
        assert_eq!(
            (r.level, r.change, r.input_events, r.unknown_events),
            (OFF, None, 0b010, 0)
        );
    }
    rig.sim.inputs[1] = IoValue::Float(1.0);
    assert_eq!(rig.cycle().input_events, 0);
    assert_eq!(rig.ss.stats(OFF).unwrap().activations, 2);
}

#[test]
fn input_off_range_fires_strictly_inside_the_band() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving(); // speed is 50: fine
    for (speed, fired) in [(50, 0), (10, 0), (-10, 0), (-200, 0)] {
        rig.sim.inputs[2] = IoValue::Int(speed);
        let r = rig.cycle();
        assert_eq!((r.level, r.input_events), (MOVING, fired), "speed {speed}");
    }
    // Cycle n: speed 9 is inside (-10, 10): STALL (public) fires ...
    rig.sim.inputs[2] = IoValue::Int(9);
    let r = rig.cycle();
    assert_eq!((r.level, r.input_events), (MOVING, 0b100));
    // ... n+1: READY, where the standstill check fires again and stays.
    let r = rig.cycle();
    assert_eq!((r.change, r.input_events), (change(MOVING, READY), 0b100));
    for speed in [0, -9, 9] {
        rig.sim.inputs[2] = IoValue::Int(speed);
        let r = rig.cycle();
        assert_eq!((r.level, r.change, r.input_events), (READY, None, 0b100));
    }
    rig.sim.inputs[2] = IoValue::Int(10);
    assert_eq!(rig.cycle().input_events, 0);
    assert_eq!(rig.ss.unknown_events(), 0);
}

#[test]
fn several_inputs_fire_in_the_same_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    rig.sim.inputs = [IoValue::Bool(true), IoValue::Float(9.0), IoValue::Int(0)];
    let r = rig.cycle();
    assert_eq!(r.input_events, 0b111);
    // ESTOP -> EMERGENCY, OVERCURRENT -> OFF, STALL -> READY: EMERGENCY wins.
    assert_eq!(rig.cycle().change, change(MOVING, EMERGENCY));
}

#[test]
fn ignored_inputs_are_not_read() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.sim.log_io = true;
    rig.cycle();
    handle.trigger(SWITCH_ON);
    rig.cycle(); // POWER_ON reads only the estop
    let reads: Vec<String> = rig
        .take_log()
        .into_iter()
        .filter(|l| l.starts_with("read"))
        .collect();
    assert_eq!(
        reads,
        strings(&["read estop", "read current", "read estop"])
    );
}

// ---------------------------------------------------------------------------
// Critical outputs
// ---------------------------------------------------------------------------

fn b(v: bool) -> IoValue {
    IoValue::Bool(v)
}
fn i(v: i32) -> IoValue {
    IoValue::Int(v)
}

#[test]
fn outputs_are_written_every_cycle_per_level() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);

    // OFF: enable=false, lamp=false, duty=0, every cycle.
    for _ in 0..3 {
        rig.cycle();
        assert_eq!(rig.sim.writes, [(0, b(false)), (1, b(false)), (2, i(0))]);
    }
    // POWER_ON: lamp is left alone (keeps false).
    handle.trigger(SWITCH_ON);
    for _ in 0..3 {
        rig.cycle();
        assert_eq!(rig.sim.writes, [(0, b(true)), (2, i(0))]);
        assert_eq!(rig.sim.outputs[1], Some(b(false)));
    }
    // HOMING: lamp toggles false/true, duty toggles 0/5, low first.
    rig.sim.level_private.push(POWERED);
    rig.cycle();
    let mut seen = Vec::new();
    for _ in 0..4 {
        rig.cycle();
        assert_eq!(rig.ss.level(), HOMING);
        seen.push(rig.sim.writes.clone());
    }
    assert_eq!(
        seen,
        [
            vec![(0, b(true)), (1, b(false)), (2, i(0))],
            vec![(0, b(true)), (1, b(true)), (2, i(5))],
            vec![(0, b(true)), (1, b(false)), (2, i(0))],
            vec![(0, b(true)), (1, b(true)), (2, i(5))],
        ]
    );
    // READY: duty left at its last value (5).
    rig.sim.level_private.push(HOMED);
    rig.cycle();
    assert_eq!(rig.sim.writes[2], (2, i(0)), "last HOMING cycle");
    for _ in 0..2 {
        rig.cycle();
        assert_eq!(rig.ss.level(), READY);
        assert_eq!(rig.sim.writes, [(0, b(true)), (1, b(true))]);
        assert_eq!(rig.sim.outputs[2], Some(i(0)));
    }
    // MOVING: duty toggles 10/20 starting with 10 in the entering cycle.
    handle.trigger(START);
    let mut duty = Vec::new();
    for _ in 0..4 {
        rig.cycle();
        duty.push(rig.sim.writes[2]);
    }
    assert_eq!(duty, [(2, i(10)), (2, i(20)), (2, i(10)), (2, i(20))]);
    // Re-entering MOVING restarts the toggle at `low`.
    handle.trigger(STOP);
    rig.cycle();
    handle.trigger(START);
    rig.cycle();
    assert_eq!(rig.sim.writes[2], (2, i(10)));
}

#[test]
fn emergency_lamp_blinks_and_drive_is_disabled_in_the_entering_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    assert_eq!(rig.sim.outputs[0], Some(b(true)));
    rig.sim.inputs[0] = IoValue::Bool(true);
    rig.cycle();
    assert_eq!(rig.sim.outputs[0], Some(b(true)), "still MOVING in cycle n");
    let mut lamp = Vec::new();
    for _ in 0..5 {
        rig.cycle();
        assert_eq!(rig.sim.writes[0], (0, b(false)));
        assert_eq!(rig.sim.writes[2], (2, i(0)));
        lamp.push(rig.sim.writes[1].1);
    }
    assert_eq!(lamp, [b(false), b(true), b(false), b(true), b(false)]);
}

// ---------------------------------------------------------------------------
// Abort all sequences
// ---------------------------------------------------------------------------

#[test]
fn entering_emergency_aborts_all_sequences_in_the_same_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    assert_eq!(rig.rec.aborts.get(), 0);

    // A sequence has no way to trigger the private ESTOP; the input does.
    rig.sim.inputs[0] = IoValue::Bool(true);
    let r = rig.cycle();
    assert!(!r.aborted);
    assert_eq!(rig.rec.aborts.get(), 0);
    let r = rig.cycle();
    assert_eq!(r.change, change(MOVING, EMERGENCY));
    assert!(r.aborted);
    assert_eq!(rig.rec.aborts.get(), 1);
    assert_eq!(handle.level(), EMERGENCY);
    assert_eq!(rig.sim.outputs[0], Some(b(false)));
    assert_eq!(
        rig.take_log(),
        strings(&[
            "action moving",
            "exit moving",
            "entry emergency",
            "abort all",
            "action emergency",
        ])
    );
    // OnEntry: not again while staying.
    for _ in 0..3 {
        assert!(!rig.cycle().aborted);
    }
    assert_eq!(rig.rec.aborts.get(), 1);
}

mod while_active {
    use super::*;

    const SAFE: SafetyLevel = SafetyLevel::new(0);
    const RUN: SafetyLevel = SafetyLevel::new(1);
    const HALT: PublicEvent = PublicEvent::new(0);
    const GO: PublicEvent = PublicEvent::new(1);

    static PROPS: SafetyProperties<'static, Sim, 2> = SafetyProperties::new(
        [
            LevelDef::new(SAFE, "safe").abort_sequences(AbortPolicy::WhileActive),
            LevelDef::new(RUN, "run"),
        ],
        &[],
        &[],
        &[
            LevelTransition::on(RUN, HALT, SAFE),
            LevelTransition::on(SAFE, GO, RUN),
        ],
        RUN,
    );

    #[test]
    fn abort_every_cycle_while_the_level_is_active() {
        let log: Log = Rc::default();
        let mut sim = Sim::new(&log);
        let rec = Recorder::new(&log);
        let handle = SafetyHandle::new();
        let mut ss = SafetySystem::new(&PROPS, &handle).unwrap();
        assert!(!ss.cycle(&mut sim, &rec).aborted);
        handle.trigger(HALT);
        let flags: Vec<bool> = (0..4).map(|_| ss.cycle(&mut sim, &rec).aborted).collect();
        assert_eq!(flags, [true, true, true, true]);
        handle.trigger(GO);
        assert!(!ss.cycle(&mut sim, &rec).aborted);
        assert_eq!(rec.aborts.get(), 4);
        // Also through a `&dyn` and `NoSequences`.
        let dyn_rec: &dyn Sequences = &rec;
        handle.trigger(HALT);
        assert!(ss.cycle(&mut sim, dyn_rec).aborted);
        assert!(ss.cycle(&mut sim, &NoSequences).aborted);
        assert_eq!(rec.aborts.get(), 5);
    }
}

// ---------------------------------------------------------------------------
// What the cycle tells the sequences: levels entered, inputs tripped
// ---------------------------------------------------------------------------

mod told {
    use super::*;

    /// Everything the cycle tells the sequences, in order.
    #[derive(Default)]
    struct Told(RefCell<Vec<String>>);
    impl Sequences for Told {
        fn abort_all(&self) {
            self.0.borrow_mut().push("abort all".into());
        }
        fn level_entered(&self, level: SafetyLevel) {
            self.0
                .borrow_mut()
                .push(format!("level {}", NAMES[level.index()]));
        }
        fn input_tripped(&self, input: InputId) {
            self.0
                .borrow_mut()
                .push(format!("tripped {}", INPUT_NAMES[input.index()]));
        }
    }
    impl Told {
        fn take(&self) -> Vec<String> {
            std::mem::take(&mut *self.0.borrow_mut())
        }
    }

    /// A level is told when it is entered; an input when its check starts firing: one trip
    /// while it goes on firing, a new one after it stopped or was not checked. Within a
    /// cycle: the level, then abort-all, then the trips.
    #[test]
    fn levels_when_entered_and_inputs_when_their_check_starts_firing() {
        let log: Log = Rc::default();
        let mut sim = Sim::new(&log);
        let told = Told::default();
        let handle = SafetyHandle::new();
        let mut ss = SafetySystem::new(&PROPS, &handle).unwrap();
        let mut cycle = |sim: &mut Sim| {
            ss.cycle(sim, &told);
            told.take()
        };
        assert_eq!(cycle(&mut sim), ["level off"]);
        assert!(cycle(&mut sim).is_empty());

        // Over-current in OFF: one trip; OVERCURRENT leads from OFF to OFF (no change).
        sim.inputs[1] = IoValue::Float(7.0);
        assert_eq!(cycle(&mut sim), ["tripped current"]);
        assert!(cycle(&mut sim).is_empty());
        sim.inputs[1] = IoValue::Float(0.0);
        assert!(cycle(&mut sim).is_empty());
        sim.inputs[1] = IoValue::Float(-9.0);
        assert_eq!(cycle(&mut sim), ["tripped current"]);
        sim.inputs[1] = IoValue::Float(0.0);
        assert!(cycle(&mut sim).is_empty()); // OVERCURRENT: OFF to OFF

        // POWER ON ignores the current; HOMING checks it again: a new trip, after the level.
        handle.trigger(SWITCH_ON);
        assert_eq!(cycle(&mut sim), ["level power on"]);
        sim.inputs[1] = IoValue::Float(7.0);
        sim.level_private.push(POWERED);
        assert!(cycle(&mut sim).is_empty());
        assert_eq!(cycle(&mut sim), ["level homing", "tripped current"]);
        // ... whose OVERCURRENT leads to OFF.
        assert_eq!(cycle(&mut sim), ["level off"]);

        // The emergency stop: tripped, then EMERGENCY aborts on entry; still pressed, no
        // new trip.
        sim.inputs[1] = IoValue::Float(0.0);
        sim.inputs[0] = IoValue::Bool(true);
        assert_eq!(cycle(&mut sim), ["tripped estop"]);
        assert_eq!(cycle(&mut sim), ["level emergency", "abort all"]);
        assert!(cycle(&mut sim).is_empty());
    }

    /// An application that keeps its sequences as a reference (`&'static Sequencer`,
    /// say) and passes that on: every call reaches the referenced sequences.
    #[test]
    fn a_reference_to_the_sequences_is_told_everything() {
        let log: Log = Rc::default();
        let mut sim = Sim::new(&log);
        let told = Told::default();
        let by_reference: &Told = &told;
        let handle = SafetyHandle::new();
        let mut ss = SafetySystem::new(&PROPS, &handle).unwrap();
        let mut cycle = |sim: &mut Sim| {
            ss.cycle(sim, &by_reference);
            told.take()
        };
        assert_eq!(cycle(&mut sim), ["level off"]);
        sim.inputs[0] = IoValue::Bool(true);
        assert_eq!(cycle(&mut sim), ["tripped estop"]);
        assert_eq!(cycle(&mut sim), ["level emergency", "abort all"]);
    }
}

// ---------------------------------------------------------------------------
// Completeness and other construction errors (exact values)
// ---------------------------------------------------------------------------

mod errors {
    use super::*;

    struct Io;
    type P<const L: usize> = SafetyProperties<'static, Io, L>;

    const A: SafetyLevel = SafetyLevel::new(0);
    const B: SafetyLevel = SafetyLevel::new(1);
    const EV: PublicEvent = PublicEvent::new(0);
    const FAULT: PrivateEvent = PrivateEvent::new(0);
    const IN0: CriticalInput<bool> = CriticalInput::new(0, "in0");
    const IN1: CriticalInput<f32> = CriticalInput::new(1, "in1");
    const IN1_AS_INT: CriticalInput<i32> = CriticalInput::new(1, "in1 (int)");
    const IN7: CriticalInput<bool> = CriticalInput::new(7, "in7");
    const OUT0: CriticalOutput<bool> = CriticalOutput::new(0, "out0");
    const OUT1: CriticalOutput<i32> = CriticalOutput::new(1, "out1");
    const OUT1_AS_BOOL: CriticalOutput<bool> = CriticalOutput::new(1, "out1 (bool)");
    const INS: [CriticalInputInfo; 2] = [IN0.info(), IN1.info()];
    const OUTS: [CriticalOutputInfo; 2] = [OUT0.info(), OUT1.info()];
    const IN_OK: [InputAction; 2] = [IN0.ignore(), IN1.ignore()];
    const OUT_OK: [OutputAction; 2] = [OUT0.set(false), OUT1.leave()];

    const fn level(l: SafetyLevel, name: &'static str) -> LevelDef<'static, Io> {
        LevelDef::new(l, name).inputs(&IN_OK).outputs(&OUT_OK)
    }

    #[test]
    fn valid_reference_properties() {
        const OK: P<2> = P::new([level(A, "a"), level(B, "b")], &INS, &OUTS, &[], A);
        assert_eq!(OK.validate(), Ok(()));
    }

    #[test]
    fn missing_input_action() {
        const BAD: P<2> = P::new(
            [level(A, "a"), level(B, "b").inputs(&[IN0.ignore()])],
            &INS,
            &OUTS,
            &[],
            A,
        );
        let expected = SafetyError::MissingInputAction {
            level: B,
            level_name: "b",
            input: IN1.id(),
            input_name: "in1",
        };
        assert_eq!(BAD.validate(), Err(expected));
        let handle = SafetyHandle::new();
        assert_eq!(SafetySystem::new(&BAD, &handle).err(), Some(expected));
        assert!(!handle.is_bound(), "a failed construction does not bind");
        assert_eq!(
            expected.to_string(),
            "level 'b' has no action for critical input 'in1'"
        );
    }

    #[test]
    fn missing_output_action() {
        const BAD: P<2> = P::new(
            [level(A, "a").outputs(&[OUT1.set(3)]), level(B, "b")],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BAD.validate(),
            Err(SafetyError::MissingOutputAction {
                level: A,
                level_name: "a",
                output: OUT0.id(),
                output_name: "out0",
            })
        );
    }

    #[test]
    fn level_with_no_actions_at_all() {
        const BAD: P<1> = P::new([LevelDef::new(A, "bare")], &INS, &OUTS, &[], A);
        assert_eq!(
            BAD.validate(),
            Err(SafetyError::MissingInputAction {
                level: A,
                level_name: "bare",
                input: IN0.id(),
                input_name: "in0",
            })
        );
        const BARE_OUT: P<1> = P::new(
            [LevelDef::new(A, "bare").inputs(&IN_OK)],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BARE_OUT.validate(),
            Err(SafetyError::MissingOutputAction {
                level: A,
                level_name: "bare",
                output: OUT0.id(),
                output_name: "out0",
            })
        );
    }

    #[test]
    fn duplicate_actions() {
        const BAD_IN: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1.ignore(), IN0.check(true, EV)])],
            &INS,
            &OUTS,
            &[LevelTransition::on(A, EV, A)],
            A,
        );
        assert_eq!(
            BAD_IN.validate(),
            Err(SafetyError::DuplicateInputAction {
                level: A,
                level_name: "a",
                input: IN0.id(),
                input_name: "in0",
            })
        );
        const BAD_OUT: P<1> = P::new(
            [level(A, "a").outputs(&[OUT1.set(1), OUT0.leave(), OUT1.set(2)])],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BAD_OUT.validate(),
            Err(SafetyError::DuplicateOutputAction {
                level: A,
                level_name: "a",
                output: OUT1.id(),
                output_name: "out1",
            })
        );
    }

    #[test]
    fn undeclared_input_and_output() {
        const BAD_IN: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1.ignore(), IN7.ignore()])],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BAD_IN.validate(),
            Err(SafetyError::UnknownInput {
                level: A,
                level_name: "a",
                input: IN7.id(),
            })
        );
        const OUT5: CriticalOutput<bool> = CriticalOutput::new(5, "out5");
        const BAD_OUT: P<1> = P::new(
            [level(A, "a").outputs(&[OUT5.set(true)])],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BAD_OUT.validate(),
            Err(SafetyError::UnknownOutput {
                level: A,
                level_name: "a",
                output: OUT5.id(),
            })
        );
    }

    #[test]
    fn kind_mismatches() {
        const BAD_IN: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1_AS_INT.range(0, 1, EV)])],
            &INS,
            &OUTS,
            &[LevelTransition::on(A, EV, A)],
            A,
        );
        assert_eq!(
            BAD_IN.validate(),
            Err(SafetyError::InputKindMismatch {
                level: A,
                level_name: "a",
                input: IN1.id(),
                input_name: "in1",
            })
        );
        const BAD_OUT: P<1> = P::new(
            [level(A, "a").outputs(&[OUT0.leave(), OUT1_AS_BOOL.toggle()])],
            &INS,
            &OUTS,
            &[],
            A,
        );
        assert_eq!(
            BAD_OUT.validate(),
            Err(SafetyError::OutputKindMismatch {
                level: A,
                level_name: "a",
                output: OUT1.id(),
                output_name: "out1",
            })
        );
    }

    #[test]
    fn invalid_ranges() {
        const T: [LevelTransition; 1] = [LevelTransition::on(A, FAULT, A)];
        const REVERSED: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1.range(2.0, 1.0, FAULT)])],
            &INS,
            &OUTS,
            &T,
            A,
        );
        const NAN: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1.off_range(f32::NAN, 1.0, FAULT)])],
            &INS,
            &OUTS,
            &T,
            A,
        );
        let expected = Err(SafetyError::InvalidRange {
            level: A,
            level_name: "a",
            input: IN1.id(),
            input_name: "in1",
        });
        assert_eq!(REVERSED.validate(), expected);
        assert_eq!(NAN.validate(), expected);
        // Equal bounds are fine.
        const POINT: P<1> = P::new(
            [level(A, "a").inputs(&[IN0.ignore(), IN1.range(1.0, 1.0, FAULT)])],
            &INS,
            &OUTS,
            &T,
            A,
        );
        assert_eq!(POINT.validate(), Ok(()));
    }

    #[test]
    fn input_event_without_transition() {
        const BAD: P<2> = P::new(
            [
                level(A, "a"),
                level(B, "b").inputs(&[IN0.check(false, FAULT), IN1.ignore()]),
            ],
            &INS,
            &OUTS,
            &[LevelTransition::on(A, FAULT, A)], // but not from B
            A,
        );
        assert_eq!(
            BAD.validate(),
            Err(SafetyError::InputEventWithoutTransition {
                level: B,
                level_name: "b",
                input: IN0.id(),
                input_name: "in0",
                event: FAULT.id(),
            })
        );
    }

    #[test]
    fn level_list_errors() {
        const EMPTY: P<0> = P::new([], &[], &[], &[], A);
        assert_eq!(EMPTY.validate(), Err(SafetyError::NoLevels));
        const SWAPPED: P<2> = P::new([level(B, "b"), level(A, "a")], &INS, &OUTS, &[], A);
        assert_eq!(
            SWAPPED.validate(),
            Err(SafetyError::LevelOutOfOrder { index: 0, level: B })
        );
        const ENTRY: P<2> = P::new(
            [level(A, "a"), level(B, "b")],
            &INS,
            &OUTS,
            &[],
            SafetyLevel::new(2),
        );
        assert_eq!(
            ENTRY.validate(),
            Err(SafetyError::UnknownEntryLevel {
                level: SafetyLevel::new(2)
            })
        );
    }

    #[test]
    fn io_list_errors() {
        const SWAPPED_IN: P<1> = P::new([level(A, "a")], &[IN1.info(), IN0.info()], &OUTS, &[], A);
        assert_eq!(
            SWAPPED_IN.validate(),
            Err(SafetyError::InputOutOfOrder {
                index: 0,
                input: IN1.id()
            })
        );
        const SWAPPED_OUT: P<1> =
            P::new([level(A, "a")], &INS, &[OUT1.info(), OUT0.info()], &[], A);
        assert_eq!(
            SWAPPED_OUT.validate(),
            Err(SafetyError::OutputOutOfOrder {
                index: 0,
                output: OUT1.id()
            })
        );
        const MANY: [CriticalInputInfo; 33] = [IN0.info(); 33];
        const TOO_MANY: P<1> = P::new([level(A, "a")], &MANY, &OUTS, &[], A);
        assert_eq!(
            TOO_MANY.validate(),
            Err(SafetyError::TooManyInputs { count: 33 })
        );
        const MANY_OUT: [CriticalOutputInfo; 40] = [OUT0.info(); 40];
        const TOO_MANY_OUT: P<1> = P::new([level(A, "a")], &INS, &MANY_OUT, &[], A);
        assert_eq!(
            TOO_MANY_OUT.validate(),
            Err(SafetyError::TooManyOutputs { count: 40 })
        );
    }

    #[test]
    fn transition_errors() {
        const OUT_OF_RANGE: P<2> = P::new(
            [level(A, "a"), level(B, "b")],
            &INS,
            &OUTS,
            &[LevelTransition::on(A, PublicEvent::new(32), B)],
            A,
        );
        assert_eq!(
            OUT_OF_RANGE.validate(),
            Err(SafetyError::EventOutOfRange {
                event: EventId::public(32)
            })
        );
        const BAD_DEST: P<2> = P::new(
            [level(A, "a"), level(B, "b")],
            &INS,
            &OUTS,
            &[
                LevelTransition::on(A, EV, B),
                LevelTransition::on(B, EV, SafetyLevel::new(2)),
            ],
            A,
        );
        assert_eq!(
            BAD_DEST.validate(),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 1,
                level: SafetyLevel::new(2)
            })
        );
        const BAD_BAND: P<2> = P::new(
            [level(A, "a"), level(B, "b")],
            &INS,
            &OUTS,
            &[LevelTransition::on_levels_between(B, A, EV, A)],
            A,
        );
        assert_eq!(
            BAD_BAND.validate(),
            Err(SafetyError::InvalidTransition { index: 0 })
        );
        const BAD_SOURCE: P<2> = P::new(
            [level(A, "a"), level(B, "b")],
            &INS,
            &OUTS,
            &[LevelTransition::on(SafetyLevel::new(5), EV, A)],
            A,
        );
        assert_eq!(
            BAD_SOURCE.validate(),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: SafetyLevel::new(5)
            })
        );
    }

    #[test]
    fn conflicting_transitions() {
        const C: SafetyLevel = SafetyLevel::new(2);
        const CONFLICT: P<3> = P::new(
            [level(A, "a"), level(B, "b"), level(C, "c")],
            &INS,
            &OUTS,
            &[
                LevelTransition::on(A, EV, B),
                LevelTransition::on_level_and_above(B, FAULT, A),
                LevelTransition::on(C, EV, A),
                LevelTransition::on(C, FAULT, B), // overlaps the band row at C
            ],
            A,
        );
        assert_eq!(
            CONFLICT.validate(),
            Err(SafetyError::ConflictingTransition {
                level: C,
                event: FAULT.id()
            })
        );
        // The same index as public and private is not a conflict.
        const DISTINCT: P<3> = P::new(
            [level(A, "a"), level(B, "b"), level(C, "c")],
            &INS,
            &OUTS,
            &[
                LevelTransition::on(A, EV, B),
                LevelTransition::on(A, FAULT, C),
            ],
            A,
        );
        assert_eq!(DISTINCT.validate(), Ok(()));
    }

    #[test]
    fn handle_in_use_and_released_on_drop() {
        const OK: P<1> = P::new([level(A, "a")], &INS, &OUTS, &[], A);
        let handle = SafetyHandle::new();
        let first = SafetySystem::new(&OK, &handle).unwrap();
        assert_eq!(
            SafetySystem::new(&OK, &handle).err(),
            Some(SafetyError::HandleInUse)
        );
        drop(first);
        assert!(!handle.is_bound());
        assert!(SafetySystem::new(&OK, &handle).is_ok());
    }
}

// ---------------------------------------------------------------------------
// The lock-free handle
// ---------------------------------------------------------------------------

#[test]
fn handle_is_shared_across_threads_and_the_safest_event_wins() {
    fn assert_sync_send<T: Sync + Send>() {}
    assert_sync_send::<SafetyHandle>();
    assert_sync_send::<SafetyProperties<'static, Sim, 6>>();
    assert_sync_send::<SafetySystem<'static, Sim, 6>>();

    let handle = SafetyHandle::new();
    let mut rig = Rig::new(&handle);
    rig.drive_to_moving();
    // Lower-priority contexts trigger concurrently through `&SafetyHandle`.
    std::thread::scope(|s| {
        for ev in [STOP, SWITCH_OFF, STALL, SWITCH_ON] {
            let h = &handle;
            s.spawn(move || {
                for _ in 0..1000 {
                    h.trigger(ev);
                    assert!(h.level() >= MOVING);
                }
            });
        }
    });
    let r = rig.cycle();
    assert_eq!(r.change, change(MOVING, OFF));
    assert_eq!(r.unknown_events, 1, "SWITCH_ON, once");
    assert_eq!(handle.level(), OFF);
}

#[test]
fn sizes_are_small() {
    use core::mem::size_of;
    // Host (64-bit) figures; the README lists the thumbv7em ones.
    assert!(
        size_of::<SafetyHandle>() <= 20,
        "{}",
        size_of::<SafetyHandle>()
    );
    assert!(size_of::<SafetySystem<'static, Sim, 6>>() <= 128);
    assert_eq!(size_of::<SafetyLevel>(), 1);
    assert_eq!(size_of::<PublicEvent>(), 1);
}

#[test]
fn compile_time_validated_properties() {
    // The whole table of this file, proven valid by the compiler.
    static VALID: ValidProperties<'static, Sim, 6> = match SafetyProperties::new(
        *PROPS.levels(),
        PROPS.inputs(),
        PROPS.outputs(),
        PROPS.transitions(),
        OFF,
    )
    .validated()
    {
        Ok(valid) => valid,
        Err(_) => panic!("invalid safety properties"),
    };
    let log: Log = Rc::default();
    let mut sim = Sim::new(&log);
    let handle = SafetyHandle::new();
    let mut ss = SafetySystem::new_validated(&VALID, &handle).unwrap();
    assert_eq!(ss.cycle(&mut sim, &NoSequences).level, OFF);
    handle.trigger(SWITCH_ON);
    assert_eq!(
        ss.cycle(&mut sim, &NoSequences).change,
        change(OFF, POWER_ON)
    );
    assert_eq!(
        SafetySystem::new_validated(&VALID, &handle).err(),
        Some(SafetyError::HandleInUse)
    );
}

// ---------------------------------------------------------------------------
// One `static` handle for several tests: released and reset by the drop
// ---------------------------------------------------------------------------

/// The handle these tests share, as a firmware's `static` would be shared by
/// the tests of one test binary; `STATIC_SERIAL` keeps them from running at
/// the same time (the harness runs tests on several threads).
static STATIC_HANDLE: SafetyHandle = SafetyHandle::new();
static STATIC_SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    STATIC_SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

#[test]
fn a_static_handle_serves_one_system_after_another_from_a_fresh_state() {
    let _serial = serial();
    {
        let mut rig = Rig::new(&STATIC_HANDLE);
        rig.drive_to_moving();
        assert_eq!(STATIC_HANDLE.level(), MOVING);
        // Left behind: a pending event (STOP would take MOVING to READY) and an
        // out-of-range one.
        STATIC_HANDLE.trigger(STOP);
        STATIC_HANDLE.trigger(PublicEvent::new(40));
        assert_eq!(STATIC_HANDLE.pending_events(), 1 << 3);
        assert_ne!(STATIC_HANDLE.cycles(), 0);
    } // the first system is dropped here
    assert!(!STATIC_HANDLE.is_bound());
    assert_eq!(STATIC_HANDLE.level(), SafetyLevel::SAFEST);
    assert_eq!(STATIC_HANDLE.pending_events(), 0);
    assert_eq!(STATIC_HANDLE.cycles(), 0);

    // The second system on the same static handle sees none of it.
    let mut rig = Rig::new(&STATIC_HANDLE);
    assert!(STATIC_HANDLE.is_bound());
    assert_eq!(STATIC_HANDLE.level(), OFF);
    let first = rig.cycle();
    assert_eq!(
        first,
        CycleReport {
            level: OFF,
            change: Some(LevelChange {
                from: None,
                to: OFF
            }),
            input_events: 0,
            aborted: false,
            unknown_events: 0,
        }
    );
    assert_eq!(rig.ss.unknown_events(), 0);
    assert_eq!(rig.ss.last_unknown_event(), None);
    assert_eq!(STATIC_HANDLE.cycles(), 1);
    // And it works as the first did.
    STATIC_HANDLE.trigger(SWITCH_ON);
    assert_eq!(rig.cycle().change, change(OFF, POWER_ON));
}

#[test]
fn a_bound_static_handle_still_refuses_a_second_live_system() {
    let _serial = serial();
    let first = SafetySystem::new(&PROPS, &STATIC_HANDLE).unwrap();
    STATIC_HANDLE.trigger(SWITCH_ON);
    for _ in 0..2 {
        assert_eq!(
            SafetySystem::new(&PROPS, &STATIC_HANDLE).err(),
            Some(SafetyError::HandleInUse)
        );
    }
    // The refused attempts changed nothing of the live system's handle.
    assert!(STATIC_HANDLE.is_bound());
    assert_eq!(STATIC_HANDLE.level(), OFF);
    assert_eq!(STATIC_HANDLE.pending_events(), 1 << 0);
    assert_eq!(
        SafetyError::HandleInUse.to_string(),
        "safety handle already bound to a live safety system (drop it first)"
    );
    drop(first);
    let second = SafetySystem::new(&PROPS, &STATIC_HANDLE);
    assert!(second.is_ok());
}

// ---------------------------------------------------------------------------
// Events waiting in several places at once: each is taken in the next cycle
// ---------------------------------------------------------------------------

/// A rig whose first cycle has run (level OFF), its log cleared.
fn started_in_off(handle: &SafetyHandle) -> Rig<'_> {
    let mut rig = Rig::new(handle);
    rig.cycle();
    assert!(rig.ss.is_started());
    rig.take_log();
    rig
}

#[test]
fn a_known_and_an_out_of_range_event_from_outside_are_taken_in_one_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = started_in_off(&handle);
    handle.trigger(SWITCH_ON);
    handle.trigger(PublicEvent::new(40));
    let r = rig.cycle();
    assert_eq!((r.change, r.unknown_events), (change(OFF, POWER_ON), 1));
    assert_eq!(
        rig.ss.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::public(40),
            level: OFF
        })
    );
}

#[test]
fn an_out_of_range_event_from_outside_and_one_from_inside_are_taken_in_one_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = started_in_off(&handle);
    rig.sim.level_private.push(ESTOP);
    assert_eq!(rig.cycle().change, None); // ESTOP waits for the next cycle
    handle.trigger(PublicEvent::new(40));
    let r = rig.cycle();
    assert_eq!((r.change, r.unknown_events), (change(OFF, EMERGENCY), 1));
}

#[test]
fn a_private_and_an_out_of_range_public_event_from_inside_are_taken_in_one_cycle() {
    let handle = SafetyHandle::new();
    let mut rig = started_in_off(&handle);
    rig.sim.level_private.push(ESTOP);
    rig.sim.level_public.push(PublicEvent::new(40));
    assert_eq!(rig.cycle().change, None);
    let r = rig.cycle();
    assert_eq!((r.change, r.unknown_events), (change(OFF, EMERGENCY), 1));
}

/// A public and a private event of the same index, both raised by a level action.
#[test]
fn a_public_and_a_private_event_of_one_index_from_inside_are_both_resolved() {
    let handle = SafetyHandle::new();
    let mut rig = started_in_off(&handle);
    rig.sim.level_public.push(SWITCH_ON); // public 0: OFF -> POWER ON
    rig.sim.level_private.push(ESTOP); // private 0: -> EMERGENCY, the safer
    assert_eq!(rig.cycle().change, None);
    assert_eq!(rig.cycle().change, change(OFF, EMERGENCY));
}

/// The same public event raised by a level action and triggered from outside before the
/// next cycle is one event.
#[test]
fn a_public_event_from_inside_and_outside_at_once_is_taken_once() {
    let handle = SafetyHandle::new();
    let mut rig = started_in_off(&handle);
    rig.sim.level_public.push(SWITCH_ON);
    assert_eq!(rig.cycle().change, None);
    handle.trigger(SWITCH_ON);
    let r = rig.cycle();
    assert_eq!((r.change, r.unknown_events), (change(OFF, POWER_ON), 0));
    assert_eq!(rig.ss.stats(POWER_ON).unwrap().activations, 1);
}

// ---------------------------------------------------------------------------
// Values, names, equality and diagnostic forms
// ---------------------------------------------------------------------------

#[test]
fn io_values_give_their_own_kind_only() {
    let values = [IoValue::Bool(true), IoValue::Int(-7), IoValue::Float(2.5)];
    let as_bool: Vec<_> = values.iter().map(|v| v.as_bool()).collect();
    let as_int: Vec<_> = values.iter().map(|v| v.as_int()).collect();
    let as_float: Vec<_> = values.iter().map(|v| v.as_float()).collect();
    assert_eq!(as_bool, [Some(true), None, None]);
    assert_eq!(as_int, [None, Some(-7), None]);
    assert_eq!(as_float, [None, None, Some(2.5)]);
    assert_eq!(IoValue::Bool(false).as_bool(), Some(false));
    assert_eq!(IoValue::Int(0).as_int(), Some(0));
}

#[test]
fn inputs_and_outputs_keep_their_names() {
    assert_eq!(ESTOP_IN.name(), "estop pressed");
    assert_eq!(SPEED.name(), "speed");
    assert_eq!(ENABLE.name(), "drive enable");
    assert_eq!(DUTY.name(), "duty");
    assert_eq!(
        format!("{ESTOP_IN:?}"),
        r#"CriticalInput { id: InputId(0), name: "estop pressed" }"#
    );
    assert_eq!(
        format!("{DUTY:?}"),
        r#"CriticalOutput { id: OutputId(2), name: "duty" }"#
    );
}

#[test]
fn events_are_equal_by_index() {
    assert_eq!(SWITCH_ON, PublicEvent::new(0));
    assert_ne!(SWITCH_ON, SWITCH_OFF);
    assert_eq!(HOMED, PrivateEvent::new(2));
    assert_ne!(HOMED, OVERCURRENT);
}

#[test]
fn events_and_levels_are_shown_by_kind_and_number() {
    assert_eq!(EventId::public(3).to_string(), "public event 3");
    assert_eq!(EventId::private(200).to_string(), "private event 200");
    assert_eq!(format!("{STOP:?}"), format!("{:?}", EventId::public(3)));
    assert_eq!(format!("{HOMED:?}"), format!("{:?}", EventId::private(2)));
    assert_eq!(MOVING.to_string(), "level 5");
}

#[test]
fn properties_and_systems_show_their_definitions_and_state() {
    let props = format!("{PROPS:?}");
    assert!(
        props.starts_with(
            "SafetyProperties { levels: [LevelDef { level: SafetyLevel(0), name: \"emergency\", "
        ),
        "{props}"
    );
    assert!(props.ends_with(", entry: SafetyLevel(1) }"), "{props}");
    for name in NAMES {
        assert!(props.contains(&format!("name: \"{name}\"")), "{name}");
    }
    const ONE_LEVEL: SafetyProperties<'static, Sim, 1> = SafetyProperties::new(
        [LevelDef::new(SafetyLevel::new(0), "only")],
        &[],
        &[],
        &[],
        SafetyLevel::new(0),
    );
    let valid = format!("{:?}", ONE_LEVEL.validated().unwrap());
    assert_eq!(valid, format!("ValidProperties({ONE_LEVEL:?})"));
    assert!(valid.contains("name: \"only\""), "{valid}");

    let handle = SafetyHandle::new();
    let rig = started_in_off(&handle);
    let system = format!("{:?}", rig.ss);
    assert!(
        system.starts_with("SafetySystem { level: SafetyLevel(1), started: true, "),
        "{system}"
    );
    assert!(
        system.ends_with("unknown_events: 0, last_unknown: None }"),
        "{system}"
    );
}

/// The safety system's input and output lists hold up to 32 entries each.
#[test]
fn thirty_two_inputs_and_outputs_are_accepted_and_thirty_three_refused() {
    struct NoIo;
    impl SafetyIo for NoIo {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }
    const fn inputs<const K: usize>() -> [CriticalInputInfo; K] {
        let mut list = [CriticalInput::<bool>::new(0, "in").info(); K];
        let mut i = 0;
        while i < K {
            list[i] = CriticalInput::<bool>::new(i as u8, "in").info();
            i += 1;
        }
        list
    }
    const fn outputs<const K: usize>() -> [CriticalOutputInfo; K] {
        let mut list = [CriticalOutput::<bool>::new(0, "out").info(); K];
        let mut i = 0;
        while i < K {
            list[i] = CriticalOutput::<bool>::new(i as u8, "out").info();
            i += 1;
        }
        list
    }
    const OFF_ONLY: SafetyLevel = SafetyLevel::new(0);
    static IN_32: [CriticalInputInfo; 32] = inputs::<32>();
    static IN_33: [CriticalInputInfo; 33] = inputs::<33>();
    static OUT_32: [CriticalOutputInfo; 32] = outputs::<32>();
    static OUT_33: [CriticalOutputInfo; 33] = outputs::<33>();
    let level = |inputs: &'static [InputAction], outputs: &'static [OutputAction]| {
        [LevelDef::<NoIo>::new(OFF_ONLY, "off")
            .inputs(inputs)
            .outputs(outputs)]
    };
    static IGNORE_32: [InputAction; 32] = {
        let mut list = [CriticalInput::<bool>::new(0, "in").ignore(); 32];
        let mut i = 0;
        while i < 32 {
            list[i] = CriticalInput::<bool>::new(i as u8, "in").ignore();
            i += 1;
        }
        list
    };
    static LEAVE_32: [OutputAction; 32] = {
        let mut list = [CriticalOutput::<bool>::new(0, "out").leave(); 32];
        let mut i = 0;
        while i < 32 {
            list[i] = CriticalOutput::<bool>::new(i as u8, "out").leave();
            i += 1;
        }
        list
    };
    let full = SafetyProperties::new(level(&IGNORE_32, &LEAVE_32), &IN_32, &OUT_32, &[], OFF_ONLY);
    assert_eq!(full.validate(), Ok(()));
    let inputs_33 = SafetyProperties::new(level(&[], &[]), &IN_33, &[], &[], OFF_ONLY);
    assert_eq!(
        inputs_33.validate(),
        Err(SafetyError::TooManyInputs { count: 33 })
    );
    let outputs_33 = SafetyProperties::new(level(&[], &[]), &[], &OUT_33, &[], OFF_ONLY);
    assert_eq!(
        outputs_33.validate(),
        Err(SafetyError::TooManyOutputs { count: 33 })
    );
}
