//! Names everywhere: a run's trace, causes, outcomes and safety levels print with the names
//! of the application's tables (`WithNames`), not numbers; so does the simulator's trace
//! file.

mod common;
use common::*;
use rtseq::safety::{LevelDef, SafetyLevel, SafetyProperties};
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, Duration, Failure, Failures, Monitor, MonitorId, Monitors, Names, Outcome,
    SeqConfig, SeqId, Sequencer, WithNames,
};

#[test]
fn a_trace_prints_with_sequence_and_monitor_names() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("move"), Leaf::until(1)).unwrap();
    let main = seq
        .add(
            SeqConfig::new("cycle").timeout(Duration::from_millis(50)),
            Node::of(vec![Op::Step(step)]),
        )
        .unwrap();
    let id = main.id();
    let mut jam = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(id, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| c.set(2, ms(t) == 3));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(5));
    let names = (&seq, sim.monitors());
    let lines: Vec<String> = sim
        .trace()
        .iter()
        .map(|t| t.named(&names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms cycle: Idle -> Running (start)",
            "0 ms move: Idle -> Running (start)",
            "3 ms move: Running -> Aborting (monitor `jam`)",
            "3 ms move: Aborting -> Aborted (monitor `jam`)",
            "3 ms cycle: Running -> Aborting (monitor `jam`)",
            "3 ms cycle: Aborting -> Aborted (monitor `jam`)",
        ]
    );
    let outcome = seq.sequence_by_id(id).unwrap().last_outcome().unwrap();
    assert_eq!(outcome, Outcome::Aborted(Cause::Monitor(m)));
    assert_eq!(outcome.named(&names).to_string(), "aborted (monitor `jam`)");
    assert_eq!(
        Cause::Timeout(id).named(&names).to_string(),
        "timeout of `cycle`"
    );
    // What no table names prints as a number.
    assert_eq!(
        MonitorId::from_index(5).named(&names).to_string(),
        "monitor #5"
    );
    assert_eq!(SeqId::from_index(3).named(&seq).to_string(), "#3");
}

#[test]
fn safety_levels_print_with_their_names() {
    struct Io;
    const OFF: SafetyLevel = SafetyLevel::new(0);
    const ON: SafetyLevel = SafetyLevel::new(1);
    let props: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
        [LevelDef::new(OFF, "off"), LevelDef::new(ON, "powered")],
        &[],
        &[],
        &[],
        OFF,
    );
    assert_eq!(ON.named(&props).to_string(), "powered");
    assert_eq!(SafetyLevel::new(7).named(&props).to_string(), "level 7");
    // Several sources together: each is asked in turn.
    let seq: Sequencer<(), 1> = Sequencer::new();
    let id = seq.register(SeqConfig::new("main")).unwrap();
    let all = (&seq, &Monitors::<(), 1>::new(), &props);
    assert_eq!(
        format!("{} at {}", id.named(&all), OFF.named(&all)),
        "main at off"
    );
}

/// Failure codes, sequences, monitors, critical inputs and levels are found whichever
/// source of a pair, a triple or a quadruple names them, and a source that does not name
/// a kind leaves it to the others.
#[test]
fn each_kind_of_name_is_found_in_any_source_of_a_tuple() {
    const FAILURES: Failures = Failures(&[(1, "part lost"), (2, "gripper stuck")]);
    let seq: Sequencer<(), 2> = Sequencer::new();
    let main = seq.register(SeqConfig::new("main")).unwrap();
    let mut never = |_: &(), _| false;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let jam = monitors
        .add(main, Monitor::new("jam", &mut never, Behaviour::AbortOwner))
        .unwrap();

    let failure_last = (&seq, &FAILURES);
    let sequence_last = (&monitors, &seq);
    let triple = (&seq, &monitors, &FAILURES);
    let reversed = (&FAILURES, &monitors, &seq);
    assert_eq!(
        Failure::App(2).named(&failure_last).to_string(),
        "gripper stuck"
    );
    assert_eq!(main.named(&sequence_last).to_string(), "main");
    assert_eq!(jam.named(&sequence_last).to_string(), "monitor `jam`");
    for names in [&triple as &dyn Names, &reversed] {
        assert_eq!(Failure::App(1).named(names).to_string(), "part lost");
        assert_eq!(main.named(names).to_string(), "main");
        assert_eq!(jam.named(names).to_string(), "monitor `jam`");
        assert_eq!(Failure::App(9).named(names).to_string(), "failure #9");
    }

    // Critical inputs are named by the safety properties, first, last or in the middle.
    use rtseq::safety::{CriticalInput, CriticalInputInfo};
    use rtseq::Event;
    const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    static INPUTS: [CriticalInputInfo; 1] = [ESTOP.info()];
    let props: SafetyProperties<'static, (), 1> = SafetyProperties::new(
        [LevelDef::new(SafetyLevel::new(0), "off")],
        &INPUTS,
        &[],
        &[],
        SafetyLevel::new(0),
    );
    let tripped = Event::InputTripped { input: ESTOP.id() };
    let input_last = (&seq, &props);
    let input_first = (&props, &seq);
    let input_middle = (&seq, &props, &monitors);
    let input_last_of_three = (&seq, &monitors, &props);
    for names in [
        &input_last as &dyn Names,
        &input_first,
        &input_middle,
        &input_last_of_three,
    ] {
        assert_eq!(
            tripped.named(names).to_string(),
            "critical input `estop` tripped"
        );
    }
    assert_eq!(
        tripped.named(&(&seq, &monitors)).to_string(),
        "critical input #0 tripped"
    );

    // All four kinds of source in one tuple, in any order.
    let four = (&seq, &monitors, &props, &FAILURES);
    let four_reversed = (&FAILURES, &props, &monitors, &seq);
    for names in [&four as &dyn Names, &four_reversed] {
        assert_eq!(main.named(names).to_string(), "main");
        assert_eq!(jam.named(names).to_string(), "monitor `jam`");
        assert_eq!(Failure::App(2).named(names).to_string(), "gripper stuck");
        assert_eq!(
            tripped.named(names).to_string(),
            "critical input `estop` tripped"
        );
        assert_eq!(SafetyLevel::new(0).named(names).to_string(), "off");
    }
}

/// The simulator's trace file names the safety levels and critical inputs it was given
/// (`Sim::name_safety`) and numbers the others.
#[test]
fn the_trace_file_names_safety_levels_and_inputs() {
    use rtseq::safety::{CriticalInput, Sequences};
    const OFF: SafetyLevel = SafetyLevel::new(0);
    const ON: SafetyLevel = SafetyLevel::new(1);
    const UNNAMED: SafetyLevel = SafetyLevel::new(4);
    const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    const DOOR: CriticalInput<bool> = CriticalInput::new(1, "door \"left\"");
    static PROPS: SafetyProperties<'static, (), 2> = SafetyProperties::new(
        [LevelDef::new(OFF, "off"), LevelDef::new(ON, "powered")],
        &[ESTOP.info(), DOOR.info()],
        &[],
        &[],
        OFF,
    );
    let record = |named: bool| {
        let seq: Sequencer<(), 2> = Sequencer::new();
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
        if named {
            sim.name_safety(&PROPS);
        }
        seq.level_entered(ON);
        seq.input_tripped(DOOR.id());
        seq.input_tripped(CriticalInput::<bool>::new(7, "none").id());
        seq.level_entered(UNNAMED);
        sim.step();
        let mut file = Vec::new();
        sim.write_trace(&mut file).unwrap();
        String::from_utf8(file).unwrap()
    };
    let lines = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.contains("\"level\"") || l.contains("\"input\""))
            .map(String::from)
            .collect()
    };
    assert_eq!(
        lines(&record(true)),
        [
            r#"{"t":1000,"level":"powered","id":1}"#,
            r#"{"t":1000,"event":"input","input":1,"name":"door \"left\"","text":"critical input 'door \"left\"' tripped"}"#,
            r#"{"t":1000,"event":"input","input":7,"name":"input 7","text":"critical input 'input 7' tripped"}"#,
            r#"{"t":1000,"level":"level 4","id":4}"#,
        ]
    );
    assert_eq!(
        lines(&record(false)),
        [
            r#"{"t":1000,"level":"level 1","id":1}"#,
            r#"{"t":1000,"event":"input","input":1,"name":"input 1","text":"critical input 'input 1' tripped"}"#,
            r#"{"t":1000,"event":"input","input":7,"name":"input 7","text":"critical input 'input 7' tripped"}"#,
            r#"{"t":1000,"level":"level 4","id":4}"#,
        ]
    );
}

/// The simulator's trace file (`docs/trace-format.md`): the header with the sequences, their
/// callers and the monitors, then every record in order, names quoted as JSON strings.
#[test]
fn the_trace_file_holds_the_run_with_its_names() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq
        .add(SeqConfig::new("move \"fast\""), Leaf::until(1))
        .unwrap();
    let main = seq
        .add(SeqConfig::new("cycle\\1"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let id = main.id();
    let mut jam = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(id, Monitor::new("jam\t1", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| c.set(2, ms(t) == 2));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    let mut file = Vec::new();
    sim.write_trace(&mut file).unwrap();
    let text = String::from_utf8(file).unwrap();
    assert_eq!(
        text.lines().collect::<Vec<_>>(),
        [
            concat!(
                r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":3000,"lost":0,"#,
                r#""sequences":[{"id":0,"name":"move \"fast\"","caller":1},"#,
                r#"{"id":1,"name":"cycle\\1","caller":null}],"#,
                r#""monitors":[{"id":0,"name":"jam\u00091","owner":1}]}"#
            ),
            r#"{"t":0,"seq":1,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
            concat!(
                r#"{"t":2000,"event":"monitor","owner":1,"behaviour":"AbortOwner","monitor":0,"#,
                r#""text":"monitor 'jam\u00091' of 'cycle\\1' fired: AbortOwner"}"#
            ),
            r#"{"t":2000,"seq":0,"from":"Running","to":"Aborting","cause":"monitor","monitor":0}"#,
            r#"{"t":2000,"seq":0,"from":"Aborting","to":"Aborted","cause":"monitor","monitor":0}"#,
            r#"{"t":2000,"seq":1,"from":"Running","to":"Aborting","cause":"monitor","monitor":0}"#,
            r#"{"t":2000,"seq":1,"from":"Aborting","to":"Aborted","cause":"monitor","monitor":0}"#,
        ]
    );
    let path = std::env::temp_dir().join(format!("rtseq-names-{}.jsonl", std::process::id()));
    sim.save_trace(&path).unwrap();
    let saved = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(saved, text);
}

/// A run's records, transitions and events alike, print as lines of the run with names: the
/// requests and who made them, the monitor that fired, the transitions they explain.
#[test]
fn records_print_with_names_as_the_run_reads() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("move"), Leaf::until(1)).unwrap();
    let main = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let id = main.id();
    let mut jam = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(id, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| c.set(2, ms(t) == 4));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(1));
    sim.pause(id).unwrap();
    sim.run_for(Duration::from_millis(1));
    sim.resume(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    let names = (&seq, sim.monitors());
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms cycle: Idle -> Running (start)",
            "0 ms move: Idle -> Running (start)",
            "1 ms pause of `cycle` requested by the application",
            "2 ms cycle: Running -> Paused (pause)",
            "2 ms move: Running -> Paused (pause)",
            "2 ms resume of `cycle` requested by the application",
            "3 ms cycle: Paused -> Running (resume)",
            "3 ms move: Paused -> Running (resume)",
            "4 ms monitor `jam` of `cycle` fired: AbortOwner",
            "4 ms move: Running -> Aborting (monitor `jam`)",
            "4 ms move: Aborting -> Aborted (monitor `jam`)",
            "4 ms cycle: Running -> Aborting (monitor `jam`)",
            "4 ms cycle: Aborting -> Aborted (monitor `jam`)",
        ]
    );
}

/// Every kind of event prints with the names of its tables, and with numbers where no
/// table names it.
#[test]
fn every_event_prints_with_names_or_numbers() {
    use rtseq::safety::CriticalInput;
    use rtseq::{Entry, Error, Event, Instant, Record, Request, Requester};
    const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    const CURRENT: CriticalInput<f32> = CriticalInput::new(3, "current");
    static INPUTS: [rtseq::safety::CriticalInputInfo; 1] = [ESTOP.info()];
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let stop = seq.register(SeqConfig::new("safe stop")).unwrap();
    let main = seq.register(SeqConfig::new("main")).unwrap();
    let mut never = |_: &Ctrl, _| false;
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let jam = monitors
        .add(main, Monitor::new("jam", &mut never, Behaviour::AbortOwner))
        .unwrap();
    let levels: SafetyProperties<'static, (), 2> = SafetyProperties::new(
        [
            LevelDef::new(SafetyLevel::new(0), "off"),
            LevelDef::new(SafetyLevel::new(1), "powered"),
        ],
        &INPUTS,
        &[],
        &[],
        SafetyLevel::new(0),
    );
    let failures = Failures(&[(1, "part lost")]);
    let names = (&seq, &monitors, (&failures, &levels));
    let events = [
        Event::Fired {
            owner: main,
            cause: Cause::Monitor(jam),
            behaviour: Behaviour::AbortOwner,
        },
        Event::Fired {
            owner: main,
            cause: Cause::Timeout(main),
            behaviour: Behaviour::RestartOwner,
        },
        Event::ExceptionNotRun {
            exception: stop,
            owner: main,
            why: Error::NoLane(stop),
        },
        Event::Requested {
            sequence: main,
            request: Request::Abort,
            by: Requester::Sequence(stop),
        },
        Event::AbortAll {
            by: Requester::SafetySystem,
        },
        Event::Failed {
            sequence: main,
            failure: Failure::App(1),
        },
        Event::SafetyLevel {
            level: SafetyLevel::new(1),
        },
        Event::InputTripped { input: ESTOP.id() },
        Event::InputTripped {
            input: CURRENT.id(),
        },
        Event::Failed {
            sequence: SeqId::from_index(9),
            failure: Failure::App(7),
        },
    ];
    let lines: Vec<String> = events.iter().map(|e| e.named(&names).to_string()).collect();
    assert_eq!(
        lines,
        [
            "monitor `jam` of `main` fired: AbortOwner",
            "timeout of `main` ran out: RestartOwner",
            "exception sequence `safe stop` of `main` not run: sequence `safe stop` has no lane that a task polls",
            "abort of `main` requested by `safe stop`",
            "abort-all requested by the safety system",
            "`main` failed: part lost",
            "safety level powered",
            "critical input `estop` tripped",
            "critical input #3 tripped",
            "`#9` failed: failure #7",
        ]
    );
    let record = Record {
        time: Instant::from_ticks(12_500),
        entry: Entry::Event(Event::AbortAll {
            by: Requester::Application,
        }),
    };
    assert_eq!(
        record.named(&names).to_string(),
        "12.500 ms abort-all requested by the application"
    );
}
