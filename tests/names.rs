//! Names everywhere: a run's trace, causes, outcomes and safety levels print with the names
//! of the application's tables (`WithNames`), not numbers.

mod common;
use common::*;
use rtseq::safety::{LevelDef, SafetyLevel, SafetyProperties};
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, Duration, Monitor, MonitorId, Monitors, Outcome, SeqConfig, SeqId, Sequencer,
    WithNames,
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
