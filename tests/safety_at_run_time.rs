//! The safety system at run time, black box through the public API (a cold review,
//! session 58): several events in one cycle, events raised mid-cycle and by actions, the
//! published level, outputs, input trips, counters, range rows, unknown events, and the
//! sequencer's records and aborts around level changes, at exact cycles and times.

use std::cell::Cell;

use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::{Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Sequencer, WithNames};

// ---------------------------------------------------------------------------------------
// A four-level machine: EMERG (0, aborts on entry), OFF (1, entry), READY (2), RUN (3).
// ---------------------------------------------------------------------------------------

const EMERG: SafetyLevel = SafetyLevel::new(0);
const OFF: SafetyLevel = SafetyLevel::new(1);
const READY: SafetyLevel = SafetyLevel::new(2);
const RUN: SafetyLevel = SafetyLevel::new(3);

const START: PublicEvent = PublicEvent::new(0); // OFF -> READY
const GO: PublicEvent = PublicEvent::new(1); // READY -> RUN
const STOP: PublicEvent = PublicEvent::new(2); // RUN -> READY
const RESET: PublicEvent = PublicEvent::new(3); // EMERG -> OFF
const DISARM: PublicEvent = PublicEvent::new(4); // READY -> OFF
const PING: PublicEvent = PublicEvent::new(5); // READY -> READY ("stay")
const HALT: PublicEvent = PublicEvent::new(6); // every level -> EMERG (public)
const ESTOP: PrivateEvent = PrivateEvent::new(0); // every level -> EMERG
const OVERCUR: PrivateEvent = PrivateEvent::new(1); // RUN -> READY

const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop");
const CURRENT: CriticalInput<i32> = CriticalInput::new(1, "current");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "lamp");

/// The IO of one system: inputs set by the test, every write and every action logged.
#[derive(Default)]
struct Io {
    estop: bool,
    current: i32,
    reads: Vec<u8>,
    writes: Vec<(u8, IoValue)>,
    log: Vec<String>,
    /// Triggered by the entry action of the level entered.
    entry_trigger: Option<PublicEvent>,
    /// Triggered by RUN's level action (through its context).
    action_trigger: Option<PublicEvent>,
    /// A "higher-priority interrupt": triggers on the handle while an exit action runs.
    on_exit: Option<(&'static SafetyHandle, PublicEvent)>,
    /// A "higher-priority interrupt": triggers on the handle while an input is read.
    on_read: Option<(&'static SafetyHandle, PublicEvent)>,
    /// The handle, to read its published level from the actions.
    handle: Option<&'static SafetyHandle>,
}

impl SafetyIo for Io {
    fn read_input(&mut self, input: InputId) -> IoValue {
        self.reads.push(input.index() as u8);
        if let Some((h, e)) = self.on_read.take() {
            h.trigger(e);
        }
        if input == ESTOP_IN.id() {
            self.estop.into()
        } else {
            IoValue::Int(self.current)
        }
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        self.writes.push((output.index() as u8, value));
    }
}

fn published(io: &Io) -> String {
    io.handle
        .map_or(String::from("-"), |h| h.level().id().to_string())
}

fn entry(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    let s = ctx.stats();
    let line = format!(
        "entry {} (activations {}, cycles {}, handle level {})",
        ctx.level().id(),
        s.activations,
        s.cycles,
        published(io)
    );
    io.log.push(line);
    if let Some(e) = io.entry_trigger.take() {
        ctx.trigger(e);
    }
}

fn exit(io: &mut Io) {
    let line = format!("exit (handle level {})", published(io));
    io.log.push(line);
    if let Some((h, e)) = io.on_exit.take() {
        h.trigger(e);
    }
}

fn run_action(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    let s = ctx.stats();
    io.log.push(format!("action 3 (cycles {})", s.cycles));
    if let Some(e) = io.action_trigger.take() {
        ctx.trigger(e);
    }
}

const TRANSITIONS: &[LevelTransition] = &[
    LevelTransition::on_level_and_above(EMERG, ESTOP, EMERG),
    LevelTransition::on_level_and_above(EMERG, HALT, EMERG),
    LevelTransition::on(EMERG, RESET, OFF),
    LevelTransition::on(OFF, START, READY),
    LevelTransition::on(READY, GO, RUN),
    LevelTransition::on(READY, DISARM, OFF),
    LevelTransition::on(READY, PING, READY),
    LevelTransition::on(RUN, STOP, READY),
    LevelTransition::on(RUN, OVERCUR, READY),
];

static PROPS: ValidProperties<'static, Io, 4> = match SafetyProperties::new(
    [
        LevelDef::new(EMERG, "emergency")
            .inputs(&[ESTOP_IN.ignore(), CURRENT.ignore()])
            .outputs(&[ENABLE.set(false), LAMP.toggle()])
            .on_entry(entry)
            .on_exit(exit)
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(OFF, "off")
            .inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.ignore()])
            .outputs(&[ENABLE.set(false), LAMP.set(false)])
            .on_entry(entry)
            .on_exit(exit),
        LevelDef::new(READY, "ready")
            .inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.ignore()])
            .outputs(&[ENABLE.leave(), LAMP.toggle()])
            .on_entry(entry)
            .on_exit(exit),
        LevelDef::new(RUN, "run")
            .inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.range(-8, 8, OVERCUR)])
            .outputs(&[ENABLE.set(true), LAMP.set(true)])
            .on_entry(entry)
            .on_exit(exit)
            .level_action(run_action),
    ],
    &[ESTOP_IN.info(), CURRENT.info()],
    &[ENABLE.info(), LAMP.info()],
    TRANSITIONS,
    OFF,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

/// Records what the cycle tells the sequences.
#[derive(Default)]
struct Told(std::cell::RefCell<Vec<String>>);
impl Sequences for Told {
    fn abort_all(&self) {
        self.0.borrow_mut().push("abort".into());
    }
    fn level_entered(&self, level: SafetyLevel) {
        self.0.borrow_mut().push(format!("level {}", level.id()));
    }
    fn input_tripped(&self, input: InputId) {
        self.0.borrow_mut().push(format!("trip {}", input.index()));
    }
}
impl Told {
    fn take(&self) -> Vec<String> {
        std::mem::take(&mut *self.0.borrow_mut())
    }
}

fn b(v: bool) -> IoValue {
    IoValue::Bool(v)
}

/// A started system in RUN (cycles: 1 enters OFF, 2 READY, 3 RUN), logs cleared.
fn to_run(safety: &mut SafetySystem<'static, Io, 4>, handle: &SafetyHandle, io: &mut Io) {
    safety.cycle(io, &NoSequences);
    handle.trigger(START);
    safety.cycle(io, &NoSequences);
    handle.trigger(GO);
    let r = safety.cycle(io, &NoSequences);
    assert_eq!(r.level, RUN);
    io.log.clear();
    io.writes.clear();
    io.reads.clear();
}

// ---------------------------------------------------------------------------------------
// Several events in one cycle, from every source.
// ---------------------------------------------------------------------------------------

/// Two input events, a level-action event and a handle event, all raised for the same next
/// cycle: every one is resolved against RUN, the safest (EMERG) wins, the losers are not
/// counted as unknown and leave no trace (no READY activation).
#[test]
fn four_sources_in_one_cycle_the_safest_wins_and_the_losers_vanish() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    to_run(&mut safety, &H, &mut io);
    io.estop = true; // ESTOP -> EMERG
    io.current = 9; // OVERCUR -> READY
    io.action_trigger = Some(STOP); // -> READY
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.input_events, r.change), (RUN, 0b11, None));
    H.trigger(STOP); // -> READY, from a sequence
    let told = Told::default();
    let r = safety.cycle(&mut io, &told);
    assert_eq!(
        r.change,
        Some(LevelChange {
            from: Some(RUN),
            to: EMERG
        })
    );
    assert_eq!((r.unknown_events, r.aborted), (0, true));
    assert_eq!(safety.stats(READY).unwrap().activations, 1);
    assert_eq!(
        safety.stats(EMERG).unwrap(),
        LevelStats {
            activations: 1,
            cycles: 1
        }
    );
    assert_eq!(told.take(), ["level 0", "abort"]);
    // EMERG ignores both inputs: not read; the lamp toggles from low; enable off.
    assert_eq!(
        io.writes[io.writes.len() - 2..],
        [(0, b(false)), (1, b(false))]
    );
    assert_eq!(io.reads, [0, 1]); // only the cycle in RUN read them
}

/// A trigger on the handle by a "higher-priority interrupt" in the middle of a cycle (here:
/// while an input is read, after the pending events were taken) is neither lost nor applied
/// in that cycle; the next cycle resolves it against the level entered meanwhile.
#[test]
fn a_trigger_during_the_cycle_waits_for_the_next_one() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    safety.cycle(&mut io, &NoSequences); // OFF
    H.trigger(START);
    io.on_read = Some((&H, GO)); // raised during the cycle that enters READY
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, H.pending_events()), (READY, 1 << GO.id().index()));
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(
        r.change,
        Some(LevelChange {
            from: Some(READY),
            to: RUN
        })
    );
    assert_eq!(H.pending_events(), 0);
}

/// EEROS resolves an event when it is triggered, against the level current *then*
/// (`SafetySystem::triggerEvent` looks up `currentLevel`, which `run()` updates only after
/// the exit action). rtseq resolves it in the next cycle against the level *that* cycle
/// starts in. An event raised by a higher-priority interrupt while READY's exit action runs
/// (the handle still publishes READY) is valid in READY (DISARM -> OFF), but rtseq resolves
/// it in RUN, where it has no row: counted as unknown, the level stays RUN. (EEROS: OFF.)
/// docs/semantics.md ("Where EEROS differs") says so.
#[test]
fn an_event_valid_in_the_level_seen_when_triggered_is_resolved_against_the_next_level() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io {
        handle: Some(&H),
        ..Io::default()
    };
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    safety.cycle(&mut io, &NoSequences); // OFF
    H.trigger(START);
    safety.cycle(&mut io, &NoSequences); // READY
    io.log.clear();
    H.trigger(GO);
    io.on_exit = Some((&H, DISARM));
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(r.level, RUN);
    // The exit action sees the old level published, the entry action the new one.
    assert_eq!(
        io.log[..2],
        [
            "exit (handle level 2)".to_string(),
            "entry 3 (activations 1, cycles 0, handle level 3)".to_string()
        ]
    );
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.change, r.unknown_events), (RUN, None, 1));
    assert_eq!(
        safety.last_unknown_event(),
        Some(UnknownEvent {
            event: DISARM.id(),
            level: RUN
        })
    );
}

/// An entry action's event in the very first cycle, and a handle event triggered before it:
/// both wait for the second cycle and are resolved against the entry level there.
#[test]
fn entry_action_event_of_the_first_cycle_and_early_handle_events_meet_in_the_second() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io {
        entry_trigger: Some(START),
        ..Io::default()
    };
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    H.trigger(RESET); // no row from OFF
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.unknown_events), (OFF, 0));
    assert_eq!(H.pending_events(), 1 << RESET.id().index());
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(
        r.change,
        Some(LevelChange {
            from: Some(OFF),
            to: READY
        })
    );
    assert_eq!(r.unknown_events, 1);
    assert_eq!(
        safety.last_unknown_event(),
        Some(UnknownEvent {
            event: RESET.id(),
            level: OFF
        })
    );
}

/// The event a level's entry action raises is resolved against that level, in the next
/// cycle; a chain of entries walks one level per cycle (never two in one cycle).
#[test]
fn entry_action_chains_move_one_level_per_cycle() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    safety.cycle(&mut io, &NoSequences); // OFF
    H.trigger(START);
    io.entry_trigger = Some(GO); // READY's entry raises GO
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(r.level, READY);
    io.entry_trigger = Some(STOP); // RUN's entry raises STOP
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(r.level, RUN);
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!(r.level, READY);
    assert_eq!(
        safety.stats(READY).unwrap(),
        LevelStats {
            activations: 2,
            cycles: 2
        }
    );
    assert_eq!(
        safety.stats(RUN).unwrap(),
        LevelStats {
            activations: 1,
            cycles: 1
        }
    );
}

// ---------------------------------------------------------------------------------------
// Outputs: set every cycle, leave never, toggle from low on entry.
// ---------------------------------------------------------------------------------------

#[test]
fn outputs_exact_writes_per_cycle_leave_keeps_the_old_value() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    let mut cycle = |io: &mut Io, e: Option<PublicEvent>| {
        if let Some(e) = e {
            H.trigger(e);
        }
        io.writes.clear();
        safety.cycle(io, &NoSequences);
        io.writes.clone()
    };
    assert_eq!(cycle(&mut io, None), [(0, b(false)), (1, b(false))]); // OFF
                                                                      // READY: enable is `leave` (never written), the lamp toggles low, high, low ...
    assert_eq!(cycle(&mut io, Some(START)), [(1, b(false))]);
    assert_eq!(cycle(&mut io, None), [(1, b(true))]);
    // a "stay" event that wins is no change: the toggle goes on with its phase
    assert_eq!(cycle(&mut io, Some(PING)), [(1, b(false))]);
    assert_eq!(cycle(&mut io, None), [(1, b(true))]);
    // RUN sets both every cycle
    assert_eq!(cycle(&mut io, Some(GO)), [(0, b(true)), (1, b(true))]);
    assert_eq!(cycle(&mut io, None), [(0, b(true)), (1, b(true))]);
    // back to READY: the enable line keeps RUN's `true` (not written); the toggle restarts
    // low (EEROS's ToggleOutputAction keeps its phase across re-entries of the level:
    // docs/semantics.md, "Outputs").
    assert_eq!(cycle(&mut io, Some(STOP)), [(1, b(false))]);
    assert_eq!(cycle(&mut io, None), [(1, b(true))]);
    assert_eq!(
        safety.stats(READY).unwrap(),
        LevelStats {
            activations: 2,
            cycles: 6
        }
    );
}

// ---------------------------------------------------------------------------------------
// Inputs: trips, firing across levels, range bounds.
// ---------------------------------------------------------------------------------------

/// An estop pressed in READY: trips, EMERG (which ignores it) ends its firing; a RESET while
/// it is still pressed leaves EMERG for one cycle of OFF (entry action, outputs), where the
/// input trips again, and the next cycle is back in EMERG, aborting again. The "a reset
/// cannot leave the emergency level before the button is released" of semantics.md holds
/// only when the emergency level *checks* the button (the docs' second example does not).
#[test]
fn reset_while_the_estop_is_pressed_in_an_emergency_level_that_ignores_it() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let told = Told::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    safety.cycle(&mut io, &told); // OFF
    io.estop = true;
    let r = safety.cycle(&mut io, &told);
    assert_eq!(r.input_events, 0b01);
    let r = safety.cycle(&mut io, &told);
    assert_eq!((r.level, r.input_events, r.aborted), (EMERG, 0, true));
    H.trigger(RESET);
    let r = safety.cycle(&mut io, &told);
    assert_eq!((r.level, r.input_events, r.aborted), (OFF, 0b01, false));
    let r = safety.cycle(&mut io, &told);
    assert_eq!((r.level, r.aborted), (EMERG, true));
    assert_eq!(
        told.take(),
        ["level 1", "trip 0", "level 0", "abort", "level 1", "trip 0", "level 0", "abort"]
    );
    assert_eq!(safety.stats(EMERG).unwrap().activations, 2);
    assert_eq!(safety.stats(OFF).unwrap().activations, 2);
}

/// An input that keeps firing across a level change in which it is still checked is one
/// trip; its event repeats every cycle. The range is inclusive at both ends.
#[test]
fn range_input_bounds_and_one_trip_across_a_level_change() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let told = Told::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    to_run(&mut safety, &H, &mut io);
    for (current, fired) in [(8, 0), (-8, 0), (9, 0b10), (i32::MIN, 0b10)] {
        io.current = current;
        // each firing takes RUN to READY next cycle: come back with GO each time
        let r = safety.cycle(&mut io, &told);
        assert_eq!((r.level, r.input_events), (RUN, fired), "{current}");
        if fired != 0 {
            io.current = 0;
            let r = safety.cycle(&mut io, &told);
            assert_eq!(r.level, READY);
            H.trigger(GO);
            let r = safety.cycle(&mut io, &told);
            assert_eq!(r.level, RUN);
        }
    }
    // 9 and i32::MIN each tripped once: the firing of 9 ended while READY ignored the input
    // (and 0 was read when RUN was re-entered).
    let trips = told.take().iter().filter(|s| s.starts_with("trip")).count();
    assert_eq!(trips, 2);
}

// ---------------------------------------------------------------------------------------
// Counters.
// ---------------------------------------------------------------------------------------

#[test]
fn counters_exact_after_a_walk() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    to_run(&mut safety, &H, &mut io);
    safety.cycle(&mut io, &NoSequences);
    assert_eq!(io.log, ["action 3 (cycles 2)"]);
    H.trigger(HALT);
    io.log.clear();
    safety.cycle(&mut io, &NoSequences);
    assert_eq!(
        io.log,
        [
            "exit (handle level -)",
            "entry 0 (activations 1, cycles 0, handle level -)"
        ]
    );
    H.trigger(RESET);
    safety.cycle(&mut io, &NoSequences);
    assert_eq!(H.cycles(), 6);
    assert_eq!(
        safety.stats(OFF).unwrap(),
        LevelStats {
            activations: 2,
            cycles: 2
        }
    );
    assert_eq!(
        safety.stats(READY).unwrap(),
        LevelStats {
            activations: 1,
            cycles: 1
        }
    );
    assert_eq!(
        safety.stats(RUN).unwrap(),
        LevelStats {
            activations: 1,
            cycles: 2
        }
    );
    assert_eq!(
        safety.stats(EMERG).unwrap(),
        LevelStats {
            activations: 1,
            cycles: 1
        }
    );
}

// ---------------------------------------------------------------------------------------
// Range rows: the open end, the highest and the lowest level.
// ---------------------------------------------------------------------------------------

/// A public HALT from every level (`on_level_and_above(0)`, open to 255) reaches EMERG from
/// the highest (RUN) and "stays" in the lowest (no change, no second abort).
#[test]
fn open_ended_row_from_the_highest_and_the_lowest_level() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let told = Told::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    to_run(&mut safety, &H, &mut io);
    H.trigger(HALT);
    let r = safety.cycle(&mut io, &told);
    assert_eq!((r.level, r.aborted), (EMERG, true));
    H.trigger(HALT);
    let r = safety.cycle(&mut io, &told);
    assert_eq!(
        (r.level, r.change, r.aborted, r.unknown_events),
        (EMERG, None, false, 0)
    );
    assert_eq!(safety.stats(EMERG).unwrap().activations, 1);
    assert_eq!(told.take(), ["level 0", "abort"]);
}

/// A row covering levels that do not exist (up to 255) and an id >= 32 next to a valid
/// event: the valid one applies, the out-of-range one is counted, named last.
#[test]
fn an_out_of_range_event_beside_a_valid_one() {
    static H: SafetyHandle = SafetyHandle::new();
    let mut io = Io::default();
    let mut safety = SafetySystem::new_validated(&PROPS, &H).unwrap();
    safety.cycle(&mut io, &NoSequences);
    H.trigger(PublicEvent::new(40));
    H.trigger(START);
    H.trigger(PublicEvent::new(40));
    let r = safety.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.unknown_events), (READY, 2));
    assert_eq!(
        safety.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::public(40),
            level: OFF
        })
    );
}

// ---------------------------------------------------------------------------------------
// With the sequencer in the simulator: exact times and the trace.
// ---------------------------------------------------------------------------------------

#[derive(Default)]
struct Machine {
    estop: Cell<bool>,
    current: Cell<i32>,
    handle: Cell<Option<&'static SafetyHandle>>,
    hooks: Cell<u32>,
}

/// The IO of the simulated cycles: reads the machine, drops writes.
struct SimIo<'m>(&'m Machine);
impl SafetyIo for SimIo<'_> {
    fn read_input(&mut self, input: InputId) -> IoValue {
        if input == ESTOP_IN.id() {
            self.0.estop.get().into()
        } else {
            IoValue::Int(self.0.current.get())
        }
    }
    fn write_output(&mut self, _: OutputId, _: IoValue) {}
}

/// Triggers `event` at its start (if any), then runs until stopped.
struct Trigger(Option<PublicEvent>);
impl Sequence<Machine> for Trigger {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        if let Some(e) = self.0 {
            cx.safety_system().expect("bound").trigger(e);
        }
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// A cleanup hook that raises RESET (EMERG -> OFF) through the sequencer's handle.
fn reset_on_abort(m: &Machine) {
    m.hooks.set(m.hooks.get() + 1);
    if let Some(h) = m.handle.get() {
        h.trigger(RESET);
    }
}

const WHILE_TRANSITIONS: &[LevelTransition] = &[
    LevelTransition::on(OFF, START, READY),
    LevelTransition::on(READY, HALT, OFF),
];

/// OFF aborts every cycle it is active; READY does not.
static WHILE_PROPS: ValidProperties<'static, SimIo<'static>, 3> = match SafetyProperties::new(
    [
        LevelDef::new(EMERG, "emergency"),
        LevelDef::new(OFF, "off").abort_sequences(AbortPolicy::WhileActive),
        LevelDef::new(READY, "ready"),
    ],
    &[],
    &[],
    WHILE_TRANSITIONS,
    READY,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid"),
};

type SimProps = ValidProperties<'static, SimIo<'static>, 4>;
static SIM_PROPS: SimProps = match SafetyProperties::new(
    [
        LevelDef::new(EMERG, "emergency")
            .inputs(&[ESTOP_IN.ignore(), CURRENT.ignore()])
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(OFF, "off").inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.ignore()]),
        LevelDef::new(READY, "ready").inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.ignore()]),
        LevelDef::new(RUN, "run")
            .inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.range(-8, 8, OVERCUR)]),
    ],
    &[ESTOP_IN.info(), CURRENT.info()],
    &[],
    TRANSITIONS,
    RUN,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid"),
};

/// A sequence raises HALT at 0 ms (before the first cycle): the 1 ms cycle only enters the
/// entry level RUN, the 2 ms cycle enters EMERG and the 2 ms tick aborts the sequence; its
/// cleanup hook raises RESET, which the 3 ms cycle applies (EMERG -> OFF); a sequence
/// started in OFF afterwards runs (OnEntry aborts once).
#[test]
fn sequence_event_and_cleanup_hook_event_exact_times() {
    let seq: &'static Sequencer<Machine, 4> = Box::leak(Box::new(Sequencer::new()));
    let machine: &'static Machine = Box::leak(Box::default());
    machine.handle.set(Some(seq.safety_handle()));
    let halt = seq
        .add(
            SeqConfig::new("halt").on_abort(reset_on_abort),
            Trigger(Some(HALT)),
        )
        .unwrap();
    let later = seq.add(SeqConfig::new("later"), Trigger(None)).unwrap();
    let (halt_id, later_id) = (halt.id(), later.id());
    let mut safety = SafetySystem::new_validated(&SIM_PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(seq, machine, Monitors::<Machine, 1>::new());
    sim.lane(halt);
    sim.lane(later);
    let levels = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let l2 = levels.clone();
    sim.before_tick(move |now, _| {
        let mut io = SimIo(machine);
        let r = safety.cycle(&mut io, seq);
        l2.borrow_mut()
            .push((now.as_ticks() / 1000, r.level.id(), r.aborted));
    });
    sim.start(halt_id).unwrap();
    sim.run_for(Duration::from_millis(3));
    assert_eq!(machine.hooks.get(), 1);
    assert_eq!(
        *levels.borrow(),
        [(1, 3, false), (2, 0, true), (3, 1, false)]
    );
    sim.start(later_id).unwrap();
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(later_id), rtseq::RunningState::Running);
    let names = (seq, SIM_PROPS.properties());
    let got: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        got,
        [
            "0 ms halt: Idle -> Running (start)",
            "1 ms safety level run",
            "2 ms safety level emergency",
            "2 ms abort-all requested by the safety system",
            "2 ms halt: Running -> Aborting (abort-all)",
            "2 ms halt: Aborting -> Aborted (abort-all)",
            "3 ms safety level off",
            "3 ms later: Idle -> Running (start)",
        ]
    );
}

/// A level with `WhileActive`: a sequence started while it is active (after the tick that
/// carried out the cycle's abort-all) runs until the next tick aborts it; the trace records
/// "abort-all requested" only in ticks that have something to abort.
#[test]
fn while_active_aborts_a_sequence_started_in_the_level_at_the_next_tick() {
    let seq: &'static Sequencer<Machine, 2> = Box::leak(Box::new(Sequencer::new()));
    let machine: &'static Machine = Box::leak(Box::default());
    let run = seq.add(SeqConfig::new("run"), Trigger(Some(HALT))).unwrap();
    let id = run.id();
    let mut safety = SafetySystem::new_validated(&WHILE_PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(seq, machine, Monitors::<Machine, 1>::new());
    sim.lane(run);
    sim.before_tick(move |_, _| {
        safety.cycle(&mut SimIo(machine), seq);
    });
    sim.start(id).unwrap(); // raises HALT: READY -> OFF (WhileActive) at 1 ms
    sim.run_for(Duration::from_millis(3));
    sim.start(id).unwrap(); // in OFF, at 3 ms: refused? accepted, aborted at 4 ms
    sim.run_for(Duration::from_millis(2));
    let names = (seq, WHILE_PROPS.properties());
    let got: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        got,
        [
            "0 ms run: Idle -> Running (start)",
            "1 ms safety level ready",
            "2 ms safety level off",
            "2 ms abort-all requested by the safety system",
            "2 ms run: Running -> Aborting (abort-all)",
            "2 ms run: Aborting -> Aborted (abort-all)",
            "3 ms run: Aborted -> Running (start)",
            "4 ms abort-all requested by the safety system",
            "4 ms run: Running -> Aborting (abort-all)",
            "4 ms run: Aborting -> Aborted (abort-all)",
        ]
    );
}

/// A level change and an input trip in the same cycle: the trace records the level, then
/// the trip, then the abort-all (safety.md: "before the abort-all the level asks for").
#[test]
fn level_trip_and_abort_in_one_cycle_are_recorded_in_that_order() {
    let seq: &'static Sequencer<Machine, 2> = Box::leak(Box::new(Sequencer::new()));
    let machine: &'static Machine = Box::leak(Box::default());
    let run = seq.add(SeqConfig::new("run"), Trigger(None)).unwrap();
    let id = run.id();
    let mut safety = SafetySystem::new_validated(&SIM_PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(seq, machine, Monitors::<Machine, 1>::new());
    sim.lane(run);
    sim.before_tick(move |now, _| {
        let m = machine;
        m.current.set(if now.as_ticks() >= 2_000 { 20 } else { 0 });
        m.estop.set(now.as_ticks() >= 3_000);
        safety.cycle(&mut SimIo(m), seq);
    });
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(4));
    let names = (seq, SIM_PROPS.properties());
    let got: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    // 2 ms: current trips in RUN; 3 ms: READY entered (OVERCUR), estop trips in READY;
    // 4 ms: EMERG entered, aborts.
    assert_eq!(
        got,
        [
            "0 ms run: Idle -> Running (start)",
            "1 ms safety level run",
            "2 ms critical input `current` tripped",
            "3 ms safety level ready",
            "3 ms critical input `estop` tripped",
            "4 ms safety level emergency",
            "4 ms abort-all requested by the safety system",
            "4 ms run: Running -> Aborting (abort-all)",
            "4 ms run: Aborting -> Aborted (abort-all)",
        ]
    );
}

static ONE_PROPS: ValidProperties<'static, SimIo<'static>, 1> = match SafetyProperties::new(
    [LevelDef::new(EMERG, "emergency").abort_sequences(AbortPolicy::OnEntry)],
    &[],
    &[],
    &[],
    EMERG,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid"),
};

/// safety.md: dropping the system "releases the handle and resets it to
/// `SafetyHandle::new()`'s state". An abort-all the system posted before it was dropped is
/// not withdrawn: the sequencer's next tick still aborts every run "by the safety system"
/// (and records the level note) although no safety system exists any more. Safe, but the
/// handle is not in `new()`'s state; the doc does not say that a posted abort survives.
#[test]
fn an_abort_all_posted_before_the_drop_is_carried_out_after_it() {
    let seq: &'static Sequencer<Machine, 2> = Box::leak(Box::new(Sequencer::new()));
    let machine: &'static Machine = Box::leak(Box::default());
    let run = seq.add(SeqConfig::new("run"), Trigger(None)).unwrap();
    let id = run.id();
    let mut sim = Sim::new(seq, machine, Monitors::<Machine, 1>::new());
    sim.lane(run);
    sim.start(id).unwrap();
    sim.step(); // 1 ms
    let mut safety = SafetySystem::new_validated(&ONE_PROPS, seq.safety_handle()).unwrap();
    let r = safety.cycle(&mut SimIo(machine), seq);
    assert!(r.aborted);
    drop(safety);
    assert!(!seq.safety_handle().is_bound());
    assert!(seq.safety_system().is_none());
    sim.step(); // 2 ms
    let names = (seq, ONE_PROPS.properties());
    let got: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        got,
        [
            "0 ms run: Idle -> Running (start)",
            "2 ms safety level emergency",
            "2 ms abort-all requested by the safety system",
            "2 ms run: Running -> Aborting (abort-all)",
            "2 ms run: Aborting -> Aborted (abort-all)",
        ]
    );
}
