//! Configuration and the declarative/public API at their limits, black-box on the
//! simulator. Each test states what the docs promise.

use core::cell::Cell;
use rtseq::lock::CriticalSection;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, ConfigError, Cx, Duration, Error, Failure, Instant, Monitor, Monitors,
    Outcome, Raiser, Seq, SeqConfig, SeqId, Sequence, Sequencer, Table, TableError, Wait,
};

/// A sequence that runs a blocking `Wait` of `ms` and completes.
struct Dwell(Seq<Wait>);
impl<C> Sequence<C> for Dwell {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Completes at once.
struct Nop;
impl<C> Sequence<C> for Nop {
    async fn action(&mut self, _cx: &Cx<'_, C>) -> Result<(), Failure> {
        Ok(())
    }
}

const MAX_US: u64 = 0x7FFF_FFFF; // 2^31 - 1

// ---------------------------------------------------------------------------------------
// Durations: "more than zero and under 2^31 µs" (SeqConfig::polling, ::timeout,
// Handle::set_timeout, Error::DurationOutOfRange).

#[test]
fn durations_at_the_documented_limits() {
    let seq: Sequencer<(), 8> = Sequencer::new();
    let longest = Duration::from_ticks(MAX_US);
    let too_long = Duration::from_ticks(MAX_US + 1);
    assert!(seq.register(SeqConfig::new("p").polling(longest)).is_ok());
    assert_eq!(
        seq.register(SeqConfig::new("p2").polling(too_long)),
        Err(Error::DurationOutOfRange)
    );
    assert!(seq.register(SeqConfig::new("t").timeout(longest)).is_ok());
    assert_eq!(
        seq.register(SeqConfig::new("t2").timeout(too_long)),
        Err(Error::DurationOutOfRange)
    );
    assert_eq!(
        seq.register(SeqConfig::new("t3").timeout(Duration::from_ticks(0))),
        Err(Error::DurationOutOfRange)
    );
    let h = seq.sequence_by_name("t").unwrap();
    assert_eq!(h.set_timeout(Some(longest)), Ok(()));
    assert_eq!(
        h.set_timeout(Some(too_long)),
        Err(Error::DurationOutOfRange)
    );
    assert_eq!(h.set_timeout(None), Ok(()));
    // The same limits in a table.
    assert!(Table::<(), 1>::new([SeqConfig::new("a").polling(longest)]).is_ok());
    assert_eq!(
        Table::<(), 1>::new([SeqConfig::new("a").polling(too_long)]).err(),
        Some(TableError {
            entry: 0,
            name: "a",
            error: Error::DurationOutOfRange
        })
    );
}

#[test]
fn sim_period_at_the_documented_limit() {
    use rtseq::sim::SimError;
    let seq: Sequencer<(), 2> = Sequencer::new();
    let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    assert!(sim.with_period(Duration::from_ticks(MAX_US)).is_ok());
    let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    assert_eq!(
        sim.with_period(Duration::from_ticks(MAX_US + 1)).err(),
        Some(SimError::PeriodTooLong)
    );
}

// ---------------------------------------------------------------------------------------
// Polling classes: "at most 8 distinct polling periods per sequencer".

#[test]
fn the_ninth_polling_period_is_refused_and_leaves_nothing_behind() {
    let seq: Sequencer<(), 16> = Sequencer::new();
    let names = ["0", "1", "2", "3", "4", "5", "6", "7"];
    for (i, n) in names.iter().enumerate() {
        let cfg = SeqConfig::new(n).polling(Duration::from_millis(i as u64 + 1));
        assert!(seq.register(cfg).is_ok(), "period {}", i + 1);
    }
    let ninth = SeqConfig::new("ninth").polling(Duration::from_millis(9));
    assert_eq!(seq.register(ninth), Err(Error::PollingClassesExceeded));
    // In a lane too: the lane slot is not taken by the refused registration.
    let ninth = SeqConfig::new("ninth")
        .polling(Duration::from_millis(9))
        .in_lane();
    assert_eq!(seq.register(ninth), Err(Error::PollingClassesExceeded));
    assert_eq!(seq.len(), 8);
    // An existing period still joins; the name "ninth" is free.
    let ok = SeqConfig::new("ninth").polling(Duration::from_millis(3));
    assert_eq!(seq.register(ok).map(|id| id.index()), Ok(8));
}

// ---------------------------------------------------------------------------------------
// Capacity: N, M, W exactly at their limits.

#[test]
fn a_table_of_256_installs_and_its_last_entry_is_found() {
    let configs: [SeqConfig<()>; 256] = core::array::from_fn(|i| SeqConfig::new(NAMES[i]));
    let table = Table::<(), 256>::new(configs).unwrap();
    assert_eq!(table.id(NAMES[255]), Some(SeqId::from_index(255)));
    let seq: Sequencer<(), 256, 64, CriticalSection, 8, 8> = Sequencer::new();
    seq.install(&table).unwrap();
    assert_eq!(seq.len(), 256);
    assert_eq!(
        seq.sequence_by_name(NAMES[255]).map(|h| h.id()),
        Some(SeqId::from_index(255))
    );
    assert_eq!(
        seq.register(SeqConfig::new("more")),
        Err(Error::SequenceCapacityExceeded)
    );
    let h = seq.sequence_by_id(SeqId::from_index(255)).unwrap();
    assert_eq!(h.name(), NAMES[255]);
    assert_eq!(seq.validate(&Monitors::<(), 1>::new()), Ok(()));
}

/// Names s000..s255.
const NAMES: [&str; 256] = [
    "s000", "s001", "s002", "s003", "s004", "s005", "s006", "s007", "s008", "s009", "s010", "s011",
    "s012", "s013", "s014", "s015", "s016", "s017", "s018", "s019", "s020", "s021", "s022", "s023",
    "s024", "s025", "s026", "s027", "s028", "s029", "s030", "s031", "s032", "s033", "s034", "s035",
    "s036", "s037", "s038", "s039", "s040", "s041", "s042", "s043", "s044", "s045", "s046", "s047",
    "s048", "s049", "s050", "s051", "s052", "s053", "s054", "s055", "s056", "s057", "s058", "s059",
    "s060", "s061", "s062", "s063", "s064", "s065", "s066", "s067", "s068", "s069", "s070", "s071",
    "s072", "s073", "s074", "s075", "s076", "s077", "s078", "s079", "s080", "s081", "s082", "s083",
    "s084", "s085", "s086", "s087", "s088", "s089", "s090", "s091", "s092", "s093", "s094", "s095",
    "s096", "s097", "s098", "s099", "s100", "s101", "s102", "s103", "s104", "s105", "s106", "s107",
    "s108", "s109", "s110", "s111", "s112", "s113", "s114", "s115", "s116", "s117", "s118", "s119",
    "s120", "s121", "s122", "s123", "s124", "s125", "s126", "s127", "s128", "s129", "s130", "s131",
    "s132", "s133", "s134", "s135", "s136", "s137", "s138", "s139", "s140", "s141", "s142", "s143",
    "s144", "s145", "s146", "s147", "s148", "s149", "s150", "s151", "s152", "s153", "s154", "s155",
    "s156", "s157", "s158", "s159", "s160", "s161", "s162", "s163", "s164", "s165", "s166", "s167",
    "s168", "s169", "s170", "s171", "s172", "s173", "s174", "s175", "s176", "s177", "s178", "s179",
    "s180", "s181", "s182", "s183", "s184", "s185", "s186", "s187", "s188", "s189", "s190", "s191",
    "s192", "s193", "s194", "s195", "s196", "s197", "s198", "s199", "s200", "s201", "s202", "s203",
    "s204", "s205", "s206", "s207", "s208", "s209", "s210", "s211", "s212", "s213", "s214", "s215",
    "s216", "s217", "s218", "s219", "s220", "s221", "s222", "s223", "s224", "s225", "s226", "s227",
    "s228", "s229", "s230", "s231", "s232", "s233", "s234", "s235", "s236", "s237", "s238", "s239",
    "s240", "s241", "s242", "s243", "s244", "s245", "s246", "s247", "s248", "s249", "s250", "s251",
    "s252", "s253", "s254", "s255",
];

#[test]
fn a_monitor_table_of_256_is_full_at_the_257th() {
    fn never(_: &(), _: Instant) -> bool {
        false
    }
    let mut monitors: Monitors<'static, (), 256, rtseq::ConditionFn<()>> = Monitors::new();
    for i in 0..256 {
        let owner = SeqId::from_index(i % 3);
        let m = Monitor::with_fn("m", never, Behaviour::Nothing);
        assert_eq!(
            monitors.add(owner, m).map(|m| m.index()),
            Ok(i),
            "monitor {i}"
        );
    }
    let m = Monitor::with_fn("m", never, Behaviour::Nothing);
    assert_eq!(
        monitors.add(SeqId::from_index(0), m),
        Err(Error::MonitorCapacityExceeded)
    );
    assert_eq!(monitors.len(), 256);
}

#[test]
fn thirty_two_lanes_fit_and_the_33rd_is_refused() {
    let seq: Sequencer<(), 64, 64, CriticalSection, 32, 2> = Sequencer::new();
    for (i, name) in NAMES.iter().take(32).enumerate() {
        assert!(
            seq.register(SeqConfig::new(name).in_lane()).is_ok(),
            "lane {i}"
        );
    }
    let id = SeqId::from_index(32);
    assert_eq!(
        seq.register(SeqConfig::new("x").in_lane()),
        Err(Error::LaneCapacityExceeded(id))
    );
    // The refused registration registered nothing.
    assert_eq!(seq.len(), 32);
    let plain = seq.register(SeqConfig::new("x")).unwrap();
    assert_eq!(plain, id);
    assert_eq!(
        seq.sequence_by_id(plain).unwrap().declare_lane(),
        Err(Error::LaneCapacityExceeded(plain))
    );
}

// ---------------------------------------------------------------------------------------
// Restart limits: "a monitor (or timeout) whose limit (`restart_limit`, default 3) that
// count has reached escalates its restarting behaviour to the matching abort"
// (semantics item 5).

fn restarts_of(sim_trace: &[rtseq::Transition], id: SeqId) -> usize {
    sim_trace
        .iter()
        .filter(|t| t.sequence == id && t.cause == Cause::Restart)
        .count()
}

fn restart_limit_run(
    limit: u8,
    behaviour: Behaviour,
) -> (usize, Option<Outcome>, rtseq::MonitorId) {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut always = |_: &(), _: Instant| true;
    let mut monitors = Monitors::<(), 1>::new();
    let m = monitors
        .add(
            id,
            Monitor::new("stuck", &mut always, behaviour).restart_limit(limit),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_until_idle(Duration::from_secs(5))
        .expect("goes idle");
    (
        restarts_of(sim.trace(), id),
        sim.handle(id).unwrap().last_outcome(),
        m,
    )
}

#[test]
fn a_restart_limit_of_zero_aborts_at_the_first_firing() {
    let (restarts, outcome, m) = restart_limit_run(0, Behaviour::RestartOwner);
    assert_eq!(restarts, 0);
    assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
}

#[test]
fn a_restart_limit_of_255_allows_255_restarts() {
    let (restarts, outcome, m) = restart_limit_run(255, Behaviour::RestartOwner);
    assert_eq!(restarts, 255);
    assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
}

#[test]
fn restart_caller_of_owner_on_a_main_sequence_restarts_the_owner_within_its_limit() {
    // "the owner's caller (the owner itself for a main sequence)"
    let (restarts, outcome, m) = restart_limit_run(2, Behaviour::RestartCallerOfOwner);
    assert_eq!(restarts, 2);
    assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
}

#[test]
fn a_timeout_restart_limit_of_zero_aborts_at_the_first_timeout() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let cfg = SeqConfig::new("main")
        .timeout(Duration::from_millis(4))
        .timeout_behaviour(Behaviour::RestartOwner)
        .timeout_restart_limit(0);
    let main = seq.add(cfg, Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_secs(1))
            .map(|t| t.as_ticks()),
        Some(4_000)
    );
    assert_eq!(restarts_of(sim.trace(), id), 0);
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Timeout(id)))
    );
}

// ---------------------------------------------------------------------------------------
// Exception sequences: monitored themselves, in a cycle, started normally.

#[test]
fn an_exception_sequence_aborted_by_its_own_monitor_still_lets_the_owners_behaviour_follow() {
    // Semantics item 3: "when it has ended, the next tick applies the behaviour ... However
    // it ended: completed, skipped, failed, or aborted".
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("safe stop"), Forever).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut stuck = |_: &(), t: Instant| t.as_ticks() >= 6_000;
    let mut monitors = Monitors::<(), 2>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let hung = monitors
        .add(
            s,
            Monitor::new("stop hung", &mut stuck, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(m).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert!(end.is_some(), "goes idle");
    assert_eq!(
        sim.handle(s).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(hung)))
    );
    assert_eq!(
        sim.handle(m).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(jam)))
    );
}

#[test]
fn two_sequences_that_are_each_others_exception_sequences_do_not_hang() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let (ia, ib) = (a.id(), b.id());
    let mut fa = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut fb = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut monitors = Monitors::<(), 2>::new();
    let ma = monitors
        .add(
            ia,
            Monitor::new("a fault", &mut fa, Behaviour::AbortOwner).exception(ib),
        )
        .unwrap();
    let mb = monitors
        .add(
            ib,
            Monitor::new("b fault", &mut fb, Behaviour::AbortOwner).exception(ia),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(a);
    sim.lane(b);
    sim.start(ia).unwrap();
    assert!(
        sim.run_until_idle(Duration::from_millis(100)).is_some(),
        "goes idle"
    );
    assert_eq!(
        sim.handle(ia).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(ma)))
    );
    assert_eq!(
        sim.handle(ib).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(mb)))
    );
}

#[test]
fn an_exception_sequence_already_running_is_counted_and_the_behaviour_applied_at_once() {
    // Semantics item 10.
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("safe stop"), Forever).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut monitors = Monitors::<(), 1>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(s).unwrap();
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(5));
    assert_eq!(seq.exceptions_not_run(), 1);
    assert_eq!(
        sim.handle(m).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(jam)))
    );
    assert_eq!(sim.state(s), rtseq::RunningState::Running);
}

// ---------------------------------------------------------------------------------------
// Validation before the first start.

#[test]
fn the_simulators_first_start_refuses_a_monitor_on_an_unregistered_sequence() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Nop).unwrap();
    let m = main.id();
    let ghost = SeqId::from_index(3);
    let mut never = |_: &(), _: Instant| false;
    let mut monitors = Monitors::<(), 1>::new();
    let g = monitors
        .add(
            ghost,
            Monitor::new("ghost", &mut never, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(
        seq.validate(&monitors),
        Err(ConfigError::UnknownOwner {
            monitor: (g, "ghost"),
            owner: ghost
        })
    );
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    assert_eq!(sim.start(m), Err(Error::InvalidConfig));
}

#[test]
fn a_timeout_exception_that_is_its_own_sequence_is_named_as_the_timeouts() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let me = SeqId::from_index(0);
    let main = seq
        .add(
            SeqConfig::new("main")
                .in_lane()
                .timeout(Duration::from_millis(5))
                .timeout_exception(me),
            Nop,
        )
        .unwrap();
    assert_eq!(main.id(), me);
    assert_eq!(
        seq.validate(&Monitors::<(), 1>::new()),
        Err(ConfigError::ExceptionIsOwner {
            raiser: Raiser::Timeout(me, "main")
        })
    );
}

// ---------------------------------------------------------------------------------------
// Handle::set_timeout: "at once for a run under way whose timeout is armed ..., otherwise
// from the next start or restart".

#[test]
fn a_timeout_set_on_an_unarmed_run_waits_for_the_next_run() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(5));
    let h = sim.handle(id).unwrap();
    h.set_timeout(Some(Duration::from_millis(2))).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(h.state(), rtseq::RunningState::Running);
    h.abort().unwrap();
    sim.step();
    sim.start(id).unwrap();
    let started = sim.now().as_ticks();
    sim.run_for(Duration::from_millis(5));
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Timeout(id))));
    let at = sim.trace().last().unwrap().time.as_ticks();
    assert_eq!(at - started, 2_000);
}

#[test]
fn a_timeout_switched_off_during_a_run_does_not_fire_in_it() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(Duration::from_millis(10)),
            Forever,
        )
        .unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(5));
    sim.handle(id).unwrap().set_timeout(None).unwrap();
    sim.run_for(Duration::from_millis(20));
    assert_eq!(sim.state(id), rtseq::RunningState::Running);
}

#[test]
fn a_timeout_with_abort_caller_of_owner_on_a_main_sequence_aborts_the_sequence() {
    // Behaviour::AbortCallerOfOwner: "the owner's caller (the owner itself for a main
    // sequence)".
    let seq: Sequencer<(), 4> = Sequencer::new();
    let cfg = SeqConfig::new("main")
        .timeout(Duration::from_millis(3))
        .timeout_behaviour(Behaviour::AbortCallerOfOwner);
    let main = seq.add(cfg, Forever).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20))
            .map(|t| t.as_ticks()),
        Some(3_000)
    );
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Timeout(id)))
    );
}

// ---------------------------------------------------------------------------------------
// The safety system's configuration (semantics.md "Completeness").

mod safety_config {
    use rtseq::safety::*;

    pub struct Io;
    impl SafetyIo for Io {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }

    pub const LOW: SafetyLevel = SafetyLevel::new(0);
    pub const HIGH: SafetyLevel = SafetyLevel::new(1);
    pub const GO: PublicEvent = PublicEvent::new(0);
    pub const STOP: PrivateEvent = PrivateEvent::new(0);

    pub fn props(rows: &'static [LevelTransition]) -> SafetyProperties<'static, Io, 2> {
        SafetyProperties::new(
            [LevelDef::new(LOW, "low"), LevelDef::new(HIGH, "high")],
            &[],
            &[],
            rows,
            LOW,
        )
    }

    #[test]
    fn a_row_from_an_undefined_level_is_refused() {
        static ROWS: [LevelTransition; 1] = [LevelTransition::on(SafetyLevel::new(2), GO, LOW)];
        assert_eq!(
            props(&ROWS).validate(),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: SafetyLevel::new(2)
            })
        );
    }

    /// semantics.md, Completeness: "transitions between defined levels". A range of
    /// levels that reaches past the defined ones (not the open-ended
    /// `on_level_and_above`, whose upper end is 255 by design) is refused: a mistyped
    /// upper end would otherwise pass unnoticed.
    #[test]
    fn a_range_of_levels_past_the_defined_ones_is_refused() {
        static ROWS: [LevelTransition; 1] = [LevelTransition::on_levels_between(
            LOW,
            SafetyLevel::new(5),
            GO,
            LOW,
        )];
        assert_eq!(
            props(&ROWS).validate(),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: SafetyLevel::new(5)
            })
        );
        static UP_TO_THE_LAST: [LevelTransition; 1] =
            [LevelTransition::on_levels_between(LOW, HIGH, GO, LOW)];
        assert!(props(&UP_TO_THE_LAST).validate().is_ok());
        static OPEN_ENDED: [LevelTransition; 1] =
            [LevelTransition::on_level_and_above(LOW, GO, LOW)];
        assert!(props(&OPEN_ENDED).validate().is_ok());
    }

    #[test]
    fn an_empty_range_of_levels_is_refused() {
        static ROWS: [LevelTransition; 1] =
            [LevelTransition::on_levels_between(HIGH, LOW, GO, LOW)];
        assert!(matches!(
            props(&ROWS).validate(),
            Err(SafetyError::InvalidTransition { index: 0 })
        ));
    }

    #[test]
    fn two_rows_for_one_level_and_event_conflict_but_public_and_private_ids_do_not() {
        static ROWS: [LevelTransition; 2] = [
            LevelTransition::on(HIGH, GO, LOW),
            LevelTransition::on_level_and_above(LOW, GO, LOW),
        ];
        assert!(matches!(
            props(&ROWS).validate(),
            Err(SafetyError::ConflictingTransition { level, .. }) if level == HIGH
        ));
        static OK: [LevelTransition; 2] = [
            LevelTransition::on(HIGH, GO, LOW),
            LevelTransition::on(HIGH, STOP, LOW),
        ];
        assert!(props(&OK).validate().is_ok());
    }

    #[test]
    fn an_event_id_of_32_is_refused() {
        static ROWS: [LevelTransition; 1] = [LevelTransition::on(HIGH, PublicEvent::new(32), LOW)];
        assert!(matches!(
            props(&ROWS).validate(),
            Err(SafetyError::EventOutOfRange { .. })
        ));
        static OK: [LevelTransition; 1] = [LevelTransition::on(HIGH, PublicEvent::new(31), LOW)];
        assert!(props(&OK).validate().is_ok());
    }

    #[test]
    fn a_handle_serves_one_system_at_a_time() {
        static ROWS: [LevelTransition; 0] = [];
        static HANDLE: SafetyHandle = SafetyHandle::new();
        let p = props(&ROWS);
        let first = SafetySystem::new(&p, &HANDLE);
        assert!(first.is_ok());
        let second = SafetySystem::new(&p, &HANDLE);
        assert!(matches!(second, Err(SafetyError::HandleInUse)));
        drop(first);
        assert!(SafetySystem::new(&p, &HANDLE).is_ok());
    }
}

// ---------------------------------------------------------------------------------------
// Odd but allowed shapes: W = 0, T = 0, B larger than N needs.

#[test]
fn a_sequencer_without_lane_slots_refuses_the_start_with_lane_capacity_exceeded() {
    // firmware-guide: "A lane future polled when all slots are taken never runs: starts of
    // its sequence and `check_lanes` give `Error::LaneCapacityExceeded`".
    let seq: Sequencer<(), 2, 64, CriticalSection, 0> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Nop).unwrap();
    let id = main.id();
    assert_eq!(
        seq.register(SeqConfig::new("x").in_lane()),
        Err(Error::LaneCapacityExceeded(SeqId::from_index(1)))
    );
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    assert_eq!(sim.start(id), Err(Error::LaneCapacityExceeded(id)));
    assert_eq!(
        sim.handle(id).unwrap().start(),
        Err(Error::LaneCapacityExceeded(id))
    );
    sim.run_for(Duration::from_millis(3));
    assert_eq!(sim.state(id), rtseq::RunningState::Idle);
}

#[test]
fn a_sequencer_with_more_set_words_than_it_needs_runs_a_monitor_as_usual() {
    let seq: Sequencer<(), 8, 0, CriticalSection, 8, 8> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("stop"), Nop).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut monitors = Monitors::<(), 1>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(m).unwrap();
    assert!(sim.run_until_idle(Duration::from_millis(20)).is_some());
    assert_eq!(
        sim.handle(m).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(jam)))
    );
    assert_eq!(
        sim.handle(s).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
    // T = 0: no trace, every record lost.
    assert!(sim.trace().is_empty());
    assert!(sim.lost() > 0);
}

// ---------------------------------------------------------------------------------------
// install: "errors (without a visible change) when ..." — and the sequencer stays usable.

#[test]
fn a_failed_install_leaves_the_sequencer_usable() {
    static BIG: Table<(), 3> = match Table::new([
        SeqConfig::new("a").in_lane(),
        SeqConfig::new("b")
            .in_lane()
            .polling(Duration::from_millis(7)),
        SeqConfig::new("c").in_lane(),
    ]) {
        Ok(t) => t,
        Err(e) => panic!("{}", e.message().as_str()),
    };
    static SMALL: Table<(), 2> =
        match Table::new([SeqConfig::new("x"), SeqConfig::new("y").in_lane()]) {
            Ok(t) => t,
            Err(e) => panic!("{}", e.message().as_str()),
        };
    let seq: Sequencer<(), 4, 64, CriticalSection, 2> = Sequencer::new();
    assert_eq!(
        seq.install(&BIG),
        Err(Error::LaneCapacityExceeded(SeqId::from_index(2)))
    );
    assert_eq!(seq.len(), 0);
    assert!(seq.sequence_by_name("a").is_none());
    seq.install(&SMALL).unwrap();
    assert_eq!(seq.len(), 2);
    let x = seq.bind(SeqId::from_index(0), Nop).unwrap();
    let y = seq.bind(SeqId::from_index(1), Nop).unwrap();
    // y took lane slot 0, so one slot is left: x's lane future takes it.
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(x);
    sim.lane(y);
    sim.start(SeqId::from_index(0)).unwrap();
    sim.start(SeqId::from_index(1)).unwrap();
    sim.step();
    assert_eq!(
        sim.state(SeqId::from_index(0)),
        rtseq::RunningState::Terminated
    );
    assert_eq!(
        sim.state(SeqId::from_index(1)),
        rtseq::RunningState::Terminated
    );
    // The failed table's polling period did not stay behind: 8 more distinct ones... the
    // sequencer holds 1 ms; 7 more distinct periods fit.
    let z = seq.register(SeqConfig::new("z").polling(Duration::from_millis(7)));
    assert!(z.is_ok());
}

// ---------------------------------------------------------------------------------------
// A full monitor table (M = 256, 16 groups of 32) whose owners alternate between the first
// and the last word of a 256-sequencer: every monitor is still evaluated and fires once.

struct Counted(usize);
struct Calls {
    asked: [Cell<u32>; 256],
}
impl rtseq::Condition<Calls> for Counted {
    fn validate(&mut self, c: &Calls, now: Instant) -> bool {
        c.asked[self.0].set(c.asked[self.0].get() + 1);
        now.as_ticks() >= 5_000
    }
}

#[test]
fn a_full_monitor_table_with_owners_in_two_far_words_evaluates_every_monitor() {
    let seq: Sequencer<Calls, 256, 1024, CriticalSection, 8, 8> = Sequencer::new();
    let mut lanes = Vec::new();
    for (i, name) in NAMES.iter().enumerate() {
        if i == 0 || i == 255 || i == 100 {
            lanes.push(seq.add(SeqConfig::new(name), Forever).unwrap());
        } else {
            seq.register(SeqConfig::new(name)).unwrap();
        }
    }
    let owners = [
        SeqId::from_index(0),
        SeqId::from_index(255),
        SeqId::from_index(100),
    ];
    let mut monitors: Monitors<'static, Calls, 256, Counted> = Monitors::new();
    for i in 0..256 {
        let owner = owners[(i * 7 + i / 5) % 3];
        let m = Monitor::with_condition("m", Counted(i), Behaviour::Nothing);
        monitors.add(owner, m).unwrap();
    }
    let calls = Calls {
        asked: core::array::from_fn(|_| Cell::new(0)),
    };
    let mut sim = Sim::new(&seq, &calls, monitors);
    for l in lanes {
        sim.lane(l);
    }
    for o in owners {
        sim.start(o).unwrap();
    }
    sim.run_for(Duration::from_millis(8));
    let never: Vec<usize> = (0..256).filter(|&i| calls.asked[i].get() == 0).collect();
    assert!(never.is_empty(), "monitors never evaluated: {never:?}");
    let fired: Vec<rtseq::MonitorId> = sim
        .records()
        .iter()
        .filter_map(|r| match r.entry {
            rtseq::Entry::Event(rtseq::Event::Fired {
                cause: Cause::Monitor(m),
                ..
            }) => Some(m),
            _ => None,
        })
        .collect();
    assert_eq!(
        fired.len(),
        256,
        "each monitor fires once on its rising edge"
    );
}

// ---------------------------------------------------------------------------------------
// Handles by name, from outside: semantics item 3, "until then the exception sequence is
// its owner's, and a start of it is `Err(Error::AlreadyRunning)` ... an operator's abort of
// a safe stop does not cancel its owner's `AbortOwner`".

#[test]
fn an_exception_sequence_under_way_is_the_owners_for_handles_by_name() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("safe stop"), Forever).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 3_000;
    let mut monitors = Monitors::<(), 1>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(4));
    let h = seq.sequence_by_name("safe stop").unwrap();
    assert_eq!(h.id(), s);
    assert_eq!(h.state(), rtseq::RunningState::Running);
    assert_eq!(h.start(), Err(Error::AlreadyRunning(s)));
    h.abort().unwrap();
    assert!(sim.run_until_idle(Duration::from_millis(10)).is_some());
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    assert_eq!(
        sim.handle(m).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(jam)))
    );
    assert!(seq.sequence_by_name("safe").is_none());
    assert!(seq.sequence_by_id(SeqId::from_index(2)).is_none());
}
