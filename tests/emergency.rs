//! Emergency scenario on the host (issue 4): the safety system runs in the simulator's
//! before-tick hook — the order the RTIC priorities give on the chip, where the safety
//! task (highest priority) is woken first by the tick interrupt and runs before the
//! sequencer's tick at the same instant — with the `Sequencer` as its `Sequences`.
//!
//! A sequence tree with blocking and non-blocking sequences powers the machine up through
//! the safety system (a step triggers public events through `cx.safety_system()` and its
//! exit condition waits for the level), then an emergency arrives while everything runs:
//!
//! * the emergency-stop input (a private event raised by the input check), or
//! * a public event triggered by a sequence.
//!
//! Proven with the exact sequencer trace and the exact safety cycle reports: the cycle that
//! enters the emergency level drives the safe outputs and requests abort-all, and the tick
//! at the same instant aborts every running sequence, innermost first.

mod common;

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use common::{ms, show, tr};
use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::Cause::{AbortAll, Completed, Start};
use rtseq::RunningState::{Aborted, Aborting, Idle, Running, Terminated};
use rtseq::{
    Cx, Event, Failure, Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step,
    WithNames,
};
use rtseq_scenarios::emergency::{
    self, Machine, EMERGENCY, ENABLE, ESTOP_IN, FAULT, MOVING, OFF, POWERING, READY, START_MOVING,
    SWITCH_ON,
};

// ---------------------------------------------------------------------------------------
// The control system and the safety system's I/O; the safety system itself is shared
// with the firmware (`rtseq_scenarios::emergency`).
// ---------------------------------------------------------------------------------------

/// The control system: the machine's IO (shared with the safety system) and a log of what
/// the sequences' action lines saw.
#[derive(Default)]
struct Ctrl {
    estop: Cell<bool>,
    fault: Cell<bool>,
    enable: Cell<bool>,
    lamp: Cell<bool>,
    powering_cycles: Cell<u32>,
    log: RefCell<Vec<String>>,
}

impl Ctrl {
    fn note(&self, cx: &Cx<'_, Ctrl>, what: &str) {
        self.log
            .borrow_mut()
            .push(format!("{} ms #{}: {what}", ms(cx.now()), cx.id().index()));
    }
}

/// The safety system's IO is the control system itself (cells), so the sequences see the
/// outputs the safety system drives.
type Io = &'static Ctrl;

impl SafetyIo for &'static Ctrl {
    fn read_input(&mut self, _input: InputId) -> IoValue {
        self.estop.get().into()
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        let on = value == IoValue::Bool(true);
        if output == ENABLE.id() {
            self.enable.set(on);
        } else {
            self.lamp.set(on);
        }
    }
}

impl Machine for &'static Ctrl {
    fn powering_cycles(&self) -> u32 {
        self.powering_cycles.get()
    }
    fn set_powering_cycles(&mut self, n: u32) {
        self.powering_cycles.set(n);
    }
}

static PROPS: ValidProperties<'static, Io, 5> = match emergency::properties() {
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

// ---------------------------------------------------------------------------------------
// The sequences.
// ---------------------------------------------------------------------------------------

/// A step that triggers a public event through the sequencer's safety system
/// (`cx.safety_system()`, the seed's `getSafetySystem()`) and is done when the safety level
/// has become `until`: a level change observed by a sequence's exit condition.
struct Request {
    event: PublicEvent,
    until: SafetyLevel,
}

impl Step<Ctrl> for Request {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let safety = cx.safety_system().expect("safety system connected");
        safety.trigger(self.event);
        cx.control().note(cx, "trigger");
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.safety_system()
            .is_some_and(|safety| safety.level() == self.until)
    }
}

/// A long motion that never ends by itself; with `watch_fault`, it ends when the axis
/// detects a fault (the control system's `fault` flag).
struct Travel {
    watch_fault: bool,
}

impl Step<Ctrl> for Travel {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx, "travel");
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.watch_fault && cx.control().fault.get()
    }
}

/// Blocking child of `main`: request MOVING, then travel.
struct MoveA {
    start: Seq<Request>,
    travel: Seq<Travel>,
}

impl Sequence<Ctrl> for MoveA {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let r = cx.step(&mut self.start).await;
        cx.control().note(cx, &format!("start -> {r:?}"));
        let r = cx.step(&mut self.travel).await;
        cx.control().note(cx, &format!("travel -> {r:?}"));
        Ok(())
    }
}

/// Non-blocking (own lane): travel; if the axis reports a fault, trigger the public `FAULT`
/// event and wait for the emergency level.
struct AxisB {
    travel: Seq<Travel>,
    report: Seq<Request>,
}

impl Sequence<Ctrl> for AxisB {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let r = cx.step(&mut self.travel).await;
        cx.control().note(cx, &format!("travel -> {r:?}"));
        let r = cx.step(&mut self.report).await;
        cx.control().note(cx, &format!("report -> {r:?}"));
        Ok(())
    }
}

/// The main sequence: power on (blocking step), start axis B (non-blocking), run axis A
/// (blocking).
struct Main {
    power_on: Seq<Request>,
    axis_b: SeqId,
    move_a: Seq<MoveA>,
}

impl Sequence<Ctrl> for Main {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let r = cx.step(&mut self.power_on).await;
        cx.control().note(cx, &format!("power on -> {r:?}"));
        let r = cx.start(self.axis_b);
        cx.control().note(cx, &format!("start axis B -> {r:?}"));
        let r = cx.run(&mut self.move_a).await;
        cx.control().note(cx, &format!("move A -> {r:?}"));
        Ok(())
    }
}

type Seqr = Sequencer<Ctrl, 16>;

/// Ids of the tree, in registration order.
#[derive(Clone, Copy, Debug)]
struct Ids {
    power_on: SeqId,
    start: SeqId,
    travel_a: SeqId,
    move_a: SeqId,
    travel_b: SeqId,
    report: SeqId,
    axis_b: SeqId,
    main: SeqId,
}

/// One safety cycle as recorded by the hook: time, report, outputs after the cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cycle {
    ms: u64,
    report: CycleReport,
    enable: bool,
    lamp: bool,
}

fn cycle(ms: u64, level: SafetyLevel, change: Option<(Option<SafetyLevel>, SafetyLevel)>) -> Cycle {
    let (enable, lamp) = match level {
        READY | MOVING => (true, true),
        _ => (false, false),
    };
    Cycle {
        ms,
        report: CycleReport {
            level,
            change: change.map(|(from, to)| LevelChange { from, to }),
            input_events: 0,
            aborted: level == EMERGENCY,
            unknown_events: 0,
        },
        enable,
        lamp,
    }
}

/// What an emergency test sees.
struct World {
    trace: Vec<rtseq::Transition>,
    /// The events of the trace, with their times in ms.
    events: Vec<(u64, rtseq::Event)>,
    cycles: Vec<Cycle>,
    log: Vec<String>,
    ids: Ids,
    states: Vec<(SeqId, rtseq::RunningState, Option<Outcome>)>,
    any_active: bool,
    /// The safety level at the end of the run.
    level: SafetyLevel,
}

/// Builds the tree and the safety system, runs the safety cycle every `safety_every` ticks
/// (1 ms period) in the before-tick hook, applies `inject(ms, ctrl)` before each tick's
/// safety cycle, runs for `run_ms`.
fn run(safety_every: u64, run_ms: u64, inject: impl Fn(u64, &Ctrl) + 'static) -> World {
    let ctrl: &'static Ctrl = Box::leak(Box::default());
    let seq = Seqr::new();

    let cfg = SeqConfig::new;
    let request = |event, until| Request { event, until };
    let power_on = seq.add(cfg("power on"), request(SWITCH_ON, READY)).unwrap();
    let start = seq
        .add(cfg("start moving"), request(START_MOVING, MOVING))
        .unwrap();
    let travel_a = seq
        .add(cfg("travel A"), Travel { watch_fault: false })
        .unwrap();
    let ids_a = (power_on.id(), start.id(), travel_a.id());
    let move_a = seq
        .add(
            cfg("move A"),
            MoveA {
                start,
                travel: travel_a,
            },
        )
        .unwrap();
    let travel_b = seq
        .add(cfg("travel B"), Travel { watch_fault: true })
        .unwrap();
    let report = seq
        .add(cfg("report fault"), request(FAULT, EMERGENCY))
        .unwrap();
    let ids_b = (travel_b.id(), report.id());
    let axis_b = seq
        .add(
            cfg("axis B"),
            AxisB {
                travel: travel_b,
                report,
            },
        )
        .unwrap();
    let (move_a_id, axis_b_id) = (move_a.id(), axis_b.id());
    let main = seq
        .add(
            cfg("main"),
            Main {
                power_on,
                axis_b: axis_b_id,
                move_a,
            },
        )
        .unwrap();
    let ids = Ids {
        power_on: ids_a.0,
        start: ids_a.1,
        travel_a: ids_a.2,
        move_a: move_a_id,
        travel_b: ids_b.0,
        report: ids_b.1,
        axis_b: axis_b_id,
        main: main.id(),
    };

    let cycles: Rc<RefCell<Vec<Cycle>>> = Rc::default();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(axis_b);
    {
        let cycles = cycles.clone();
        let sequencer = &seq;
        let mut io: Io = ctrl;
        sim.before_tick(move |now, c| {
            let t = ms(now);
            inject(t, c);
            if t.is_multiple_of(safety_every) {
                let report = safety.cycle(&mut io, sequencer);
                cycles.borrow_mut().push(Cycle {
                    ms: t,
                    report,
                    enable: c.enable.get(),
                    lamp: c.lamp.get(),
                });
            }
        });
    }
    // Let the safety system enter its entry level before anything starts.
    while cycles.borrow().is_empty() {
        sim.step();
    }
    sim.start(ids.main).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(run_ms * 1000));
    let states = (0..seq.len())
        .map(|i| {
            let h = sim.handle(SeqId::from_index(i)).unwrap();
            (h.id(), h.state(), h.last_outcome())
        })
        .collect();
    let any_active = sim.any_active();
    let events = sim
        .records()
        .iter()
        .filter_map(|r| Some((ms(r.time), r.event()?)))
        .collect();
    let trace = sim.take_trace();
    let level = seq.safety_handle().level();
    drop(sim);
    let cycles = cycles.borrow().clone();
    World {
        trace,
        events,
        cycles,
        log: ctrl.log.borrow().clone(),
        ids,
        states,
        any_active,
        level,
    }
}

fn assert_trace(got: &[rtseq::Transition], want: &[rtseq::Transition]) {
    assert_eq!(got, want, "\n got:\n{}\nwant:\n{}", show(got), show(want));
}

/// The trace of powering up and starting both axes (common to every scenario): main starts
/// at 1 ms; the power-on step triggers SWITCH_ON at 1 ms; the safety system goes OFF →
/// POWERING at 2 ms, reports POWERED in its 2nd powering cycle (3 ms) and is READY at 4 ms,
/// when the power-on step's exit condition sees it; main then starts axis B (non-blocking)
/// and runs move A (blocking), whose first step triggers START_MOVING; MOVING at 5 ms.
fn power_up_trace(i: Ids) -> Vec<rtseq::Transition> {
    vec![
        tr(1, i.main, Idle, Running, Start),
        tr(1, i.power_on, Idle, Running, Start),
        tr(4, i.power_on, Running, Terminated, Completed),
        tr(4, i.axis_b, Idle, Running, Start),
        tr(4, i.move_a, Idle, Running, Start),
        tr(4, i.start, Idle, Running, Start),
        tr(4, i.travel_b, Idle, Running, Start),
        tr(5, i.start, Running, Terminated, Completed),
        tr(5, i.travel_a, Idle, Running, Start),
    ]
}

/// The safety cycles of powering up (one per millisecond from 1 to 9 ms).
fn power_up_cycles() -> Vec<Cycle> {
    let mut c = vec![
        cycle(1, OFF, Some((None, OFF))),
        cycle(2, POWERING, Some((Some(OFF), POWERING))),
        cycle(3, POWERING, None),
        cycle(4, READY, Some((Some(POWERING), READY))),
        cycle(5, MOVING, Some((Some(READY), MOVING))),
    ];
    // POWERING toggles the lamp: low in the entering cycle, then high.
    c[2].lamp = true;
    c.extend((6..10).map(|t| cycle(t, MOVING, None)));
    c
}

/// The trace's events of powering up: the levels entered.
fn power_up_events() -> Vec<(u64, Event)> {
    [(1, OFF), (2, POWERING), (4, READY), (5, MOVING)]
        .map(|(t, level)| (t, Event::SafetyLevel { level }))
        .to_vec()
}

fn aborted(t: u64, seqs: &[SeqId]) -> Vec<rtseq::Transition> {
    seqs.iter()
        .flat_map(|&s| {
            [
                tr(t, s, Running, Aborting, AbortAll),
                tr(t, s, Aborting, Aborted, AbortAll),
            ]
        })
        .collect()
}

/// After an emergency: every sequence that ran is `Aborted` (cause abort-all) or was
/// already `Terminated` before (`completed`) or never started (`idle`); nothing is active.
fn assert_all_stopped(w: &World, completed: &[SeqId], idle: &[SeqId]) {
    assert!(!w.any_active, "{:?}", w.states);
    for &(id, state, outcome) in &w.states {
        if idle.contains(&id) {
            assert_eq!((state, outcome), (Idle, None), "#{}", id.index());
        } else if completed.contains(&id) {
            assert_eq!(
                (state, outcome),
                (Terminated, Some(Outcome::Completed)),
                "#{}",
                id.index()
            );
        } else {
            assert_eq!(
                (state, outcome),
                (Aborted, Some(Outcome::Aborted(AbortAll))),
                "#{}",
                id.index()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Scenarios
// ---------------------------------------------------------------------------------------

/// The emergency-stop input is pressed at 10 ms (before that tick's safety cycle). The
/// input check fires ESTOP in the 10 ms cycle (a private event, resolved in the next
/// cycle); the 11 ms cycle enters EMERGENCY, drives the safe outputs and requests
/// abort-all, and the tick at 11 ms aborts all five running sequences, innermost first.
#[test]
fn estop_input_during_a_running_tree_aborts_everything_within_one_safety_cycle() {
    let w = run(1, 14, |t, c| {
        if t == 10 {
            c.estop.set(true);
        }
    });
    let i = w.ids;

    let mut want = power_up_cycles();
    let mut fired = cycle(10, MOVING, None);
    fired.report.input_events = 1 << ESTOP_IN.id().index();
    want.push(fired);
    // From 11 ms on: EMERGENCY, drive disabled, lamp blinking, abort-all every cycle
    // (`WhileActive`); the pressed button keeps firing ESTOP, which keeps the level.
    for (t, lamp) in [(11, false), (12, true), (13, false), (14, true)] {
        let mut c = cycle(t, EMERGENCY, (t == 11).then_some((Some(MOVING), EMERGENCY)));
        c.report.input_events = 1;
        c.lamp = lamp;
        want.push(c);
    }
    assert_eq!(w.cycles, want);

    let mut trace = power_up_trace(i);
    // Depth 2 (steps) by id, then depth 1 (move A, axis B), then main.
    trace.extend(aborted(
        11,
        &[i.travel_a, i.travel_b, i.move_a, i.axis_b, i.main],
    ));
    assert_trace(&w.trace, &trace);
    // The levels and the tripped input come into the trace at the tick after their safety
    // cycle (the same millisecond here). The pressed button goes on firing in EMERGENCY: one
    // trip. The safety system asks for abort-all in every EMERGENCY cycle; the trace records
    // it once, when there was anything to abort.
    let mut events = power_up_events();
    events.extend([
        (
            10,
            Event::InputTripped {
                input: ESTOP_IN.id(),
            },
        ),
        (11, Event::SafetyLevel { level: EMERGENCY }),
        (
            11,
            Event::AbortAll {
                by: rtseq::Requester::SafetySystem,
            },
        ),
    ]);
    assert_eq!(w.events, events);
    assert_all_stopped(&w, &[i.power_on, i.start], &[i.report]);
    assert_eq!(w.level, EMERGENCY);

    // No action line ran after the abort (sticky): the log ends with the travels' starts.
    assert_eq!(
        w.log,
        [
            format!("1 ms #{}: trigger", i.power_on.index()),
            format!("4 ms #{}: power on -> Ok(Completed)", i.main.index()),
            format!("4 ms #{}: start axis B -> Ok(())", i.main.index()),
            format!("4 ms #{}: trigger", i.start.index()),
            format!("4 ms #{}: travel", i.travel_b.index()),
            format!("5 ms #{}: start -> Ok(Completed)", i.move_a.index()),
            format!("5 ms #{}: travel", i.travel_a.index()),
        ]
    );
}

/// Axis B (a non-blocking sequence) detects a fault at 10 ms and triggers the public FAULT
/// event through `cx.safety_system()` in the same tick. The very next safety cycle (11 ms)
/// enters EMERGENCY and the tick at 11 ms aborts everything: from the event to every
/// sequence `Aborted` is one safety period.
#[test]
fn public_fault_event_from_a_sequence_aborts_everything_in_the_next_safety_cycle() {
    let w = run(1, 12, |t, c| {
        if t == 10 {
            c.fault.set(true);
        }
    });
    let i = w.ids;

    let mut want = power_up_cycles();
    want.push(cycle(10, MOVING, None));
    want.push(cycle(11, EMERGENCY, Some((Some(MOVING), EMERGENCY))));
    let mut c = cycle(12, EMERGENCY, None);
    c.lamp = true;
    want.push(c);
    assert_eq!(w.cycles, want);

    // Axis B's travel sees the fault at 10 ms and its report step triggers FAULT; at 11 ms
    // the five running sequences are aborted, innermost first.
    let mut trace = power_up_trace(i);
    trace.extend([
        tr(10, i.travel_b, Running, Terminated, Completed),
        tr(10, i.report, Idle, Running, Start),
    ]);
    trace.extend(aborted(
        11,
        &[i.travel_a, i.report, i.move_a, i.axis_b, i.main],
    ));
    assert_trace(&w.trace, &trace);
    // No critical input tripped: the level comes from the sequence's event.
    let mut events = power_up_events();
    events.extend([
        (11, Event::SafetyLevel { level: EMERGENCY }),
        (
            11,
            Event::AbortAll {
                by: rtseq::Requester::SafetySystem,
            },
        ),
    ]);
    assert_eq!(w.events, events);
    assert_all_stopped(&w, &[i.power_on, i.start, i.travel_b], &[]);
    let log_tail: Vec<String> = w.log[7..].to_vec();
    assert_eq!(
        log_tail,
        [
            format!("10 ms #{}: travel -> Ok(Completed)", i.axis_b.index()),
            format!("10 ms #{}: trigger", i.report.index()),
        ]
    );
}

/// With the safety cycle every 5 ticks (5 ms) the bound is one *safety* period: axis B
/// triggers FAULT at 42 ms, the next safety cycle (45 ms) enters EMERGENCY and the tick at
/// the same instant (the safety task runs first) aborts everything. Abort-all never lags the
/// safety cycle by a tick here; it would if the safety task ran after the sequencer tick
/// (lower priority, or its own unaligned timer): then the bound is one safety period plus
/// one tick.
#[test]
fn with_a_slower_safety_period_the_bound_is_one_safety_period() {
    let w = run(5, 50, |t, c| {
        if t == 42 {
            c.fault.set(true);
        }
    });
    let i = w.ids;
    let times: Vec<u64> = w.cycles.iter().map(|c| c.ms).collect();
    assert_eq!(times, (1..=10).map(|k| 5 * k).collect::<Vec<_>>());
    let entered: Vec<&Cycle> = w
        .cycles
        .iter()
        .filter(|c| c.report.change.is_some_and(|ch| ch.to == EMERGENCY))
        .collect();
    assert_eq!(entered.len(), 1);
    assert_eq!(entered[0].ms, 45);
    assert_eq!(
        (entered[0].enable, entered[0].report.aborted),
        (false, true)
    );
    assert!(w
        .log
        .contains(&format!("42 ms #{}: trigger", i.report.index())));
    let tail = aborted(45, &[i.travel_a, i.report, i.move_a, i.axis_b, i.main]);
    assert_trace(&w.trace[w.trace.len() - tail.len()..], &tail);
    assert_all_stopped(&w, &[i.power_on, i.start, i.travel_b], &[]);
}

// ---------------------------------------------------------------------------------------
// The sequencer holds its safety system's handle: nothing to connect, nothing to forget.
// ---------------------------------------------------------------------------------------

/// A sequence that needs the safety system: it fails (`Failure::App(1)`) without one.
struct SwitchOn;
impl Sequence<Ctrl> for SwitchOn {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.safety_system()
            .ok_or(Failure::App(1))?
            .trigger(SWITCH_ON);
        Ok(())
    }
}

/// A sequence reaches the safety system built on its sequencer's handle, with no other
/// call. Without one — none built, one built on a handle of its own, one dropped —
/// `cx.safety_system()` is `None` and the action that needs it fails; no event is left
/// pending where no system takes it.
#[test]
fn sequences_reach_the_safety_system_built_on_their_sequencers_handle_and_no_other() {
    static OWN_HANDLE: SafetyHandle = SafetyHandle::new();
    let ctrl: &'static Ctrl = Box::leak(Box::default());
    let mut io: Io = ctrl;
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let switch_on = seq.add(SeqConfig::new("switch on"), SwitchOn).unwrap();
    let id = switch_on.id();
    let mut sim = Sim::new(&seq, ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(switch_on);
    let run_once = |sim: &mut Sim<'_, Ctrl, 2, _, 1>| {
        sim.start(id).unwrap();
        sim.run_until_idle(rtseq::Duration::from_millis(10));
        sim.handle(id).unwrap().last_outcome()
    };
    let without = Some(Outcome::Failed(Failure::App(1)));

    assert!(seq.safety_system().is_none());
    assert_eq!(run_once(&mut sim), without, "no safety system");

    let own = SafetySystem::new_validated(&PROPS, &OWN_HANDLE).unwrap();
    assert!(seq.safety_system().is_none());
    assert_eq!(
        run_once(&mut sim),
        without,
        "a system on a handle of its own"
    );
    assert_eq!(OWN_HANDLE.pending_events(), 0);
    drop(own);

    let mut system = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    system.cycle(&mut io, &seq);
    assert_eq!(seq.safety_system().map(SafetyHandle::level), Some(OFF));
    assert_eq!(run_once(&mut sim), Some(Outcome::Completed));
    assert_eq!(seq.safety_handle().pending_events(), 1 << 0);
    system.cycle(&mut io, &seq);
    assert_eq!(seq.safety_system().map(SafetyHandle::level), Some(POWERING));

    drop(system);
    assert!(seq.safety_system().is_none());
    assert_eq!(run_once(&mut sim), without, "the system dropped");
    assert_eq!(seq.safety_handle().pending_events(), 0);
}

/// A sequence that runs until it is aborted.
struct Forever;
impl Sequence<Ctrl> for Forever {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// The abort-all a level demands reaches the sequencer whose handle the system is built on
/// even when the cycle is given `NoSequences` (as in the safety module's examples, which
/// have no sequencer): it goes through the handle. Only the trace notes of the level need
/// the sequencer as `Sequences`.
#[test]
fn the_safety_abort_reaches_the_sequencer_holding_the_handle_whatever_the_cycle_is_given() {
    let ctrl: &'static Ctrl = Box::leak(Box::default());
    let mut io: Io = ctrl;
    let seq: Sequencer<Ctrl, 1> = Sequencer::new();
    let forever = seq.add(SeqConfig::new("forever"), Forever).unwrap();
    let id = forever.id();
    let mut system = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(forever);
    system.cycle(&mut io, &NoSequences); // enters OFF
    sim.start(id).unwrap();
    sim.run_for(rtseq::Duration::from_millis(2));
    seq.safety_handle().trigger(FAULT);
    let report = system.cycle(&mut io, &NoSequences);
    assert_eq!((report.level, report.aborted), (EMERGENCY, true));
    sim.step();
    let names = (&seq, PROPS.properties());
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms forever: Idle -> Running (start)",
            "3 ms abort-all requested by the safety system",
            "3 ms forever: Running -> Aborting (abort-all)",
            "3 ms forever: Aborting -> Aborted (abort-all)",
        ]
    );
}
