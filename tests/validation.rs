//! The configuration is checked before the first tick (`Sequencer::validate`, and the
//! simulator's first start): a monitor or timeout whose exception sequence could not run
//! when it fires is an error naming it, not a silent skip at fire time.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, ConfigError, Duration, Error, Monitor, MonitorId, Monitors, Raiser, SeqConfig,
    SeqId, Sequencer,
};

fn never(_: &Ctrl, _: rtseq::Instant) -> bool {
    false
}

#[test]
fn an_exception_sequence_without_a_lane_is_an_error_at_the_first_start() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let stop = seq
        .add(SeqConfig::new("safe stop"), Node::of(vec![]))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Node::of(vec![])).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut cond = never;
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut cond, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    let want = ConfigError::ExceptionWithoutLane {
        raiser: Raiser::Monitor(jam, "jam"),
        exception: (s, "safe stop"),
    };
    assert_eq!(sim.start(m), Err(Error::InvalidConfig));
    assert_eq!(seq.validate(sim.monitors()), Err(want));
    assert_eq!(
        want.to_string(),
        "the exception sequence `safe stop` of monitor `jam` has no lane \
         (declare one before the first tick)"
    );
    // Nothing started; with the lane declared the same start goes.
    assert_eq!(sim.state(m), rtseq::RunningState::Idle);
    sim.lane(stop);
    assert_eq!(sim.start(m), Ok(()));
}

#[test]
fn unknown_owners_unknown_exceptions_and_self_exceptions_are_named() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let a = seq.register(SeqConfig::new("a")).unwrap();
    let b = seq.register(SeqConfig::new("b")).unwrap();
    seq.sequence_by_id(b).unwrap().declare_lane().unwrap();
    let unknown = SeqId::from_index(3);
    let (mut c0, mut c1, mut c2, mut c3) = (never, never, never, never);
    let check = |m: Monitor<'_, Ctrl>, owner| {
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        monitors.add(owner, m).unwrap();
        seq.validate(&monitors)
    };
    let m0 = MonitorId::from_index(0);
    assert_eq!(
        check(Monitor::new("orphan", &mut c0, Behaviour::Nothing), unknown),
        Err(ConfigError::UnknownOwner {
            monitor: (m0, "orphan"),
            owner: unknown
        })
    );
    assert_eq!(
        check(
            Monitor::new("lost", &mut c1, Behaviour::Nothing).exception(unknown),
            a
        ),
        Err(ConfigError::UnknownException {
            raiser: Raiser::Monitor(m0, "lost"),
            exception: unknown
        })
    );
    assert_eq!(
        check(
            Monitor::new("self", &mut c2, Behaviour::Nothing).exception(b),
            b
        ),
        Err(ConfigError::ExceptionIsOwner {
            raiser: Raiser::Monitor(m0, "self")
        })
    );
    assert_eq!(
        check(
            Monitor::new("ok", &mut c3, Behaviour::Nothing).exception(b),
            a
        ),
        Ok(())
    );
    // Each error's message names them; so does a raiser on its own.
    let lost = Raiser::Monitor(m0, "lost");
    assert_eq!(lost.to_string(), "monitor `lost`");
    assert_eq!(Raiser::Timeout(a, "a").to_string(), "the timeout of `a`");
    let messages = [
        ConfigError::UnknownOwner {
            monitor: (m0, "orphan"),
            owner: unknown,
        },
        ConfigError::UnknownException {
            raiser: lost,
            exception: unknown,
        },
        ConfigError::ExceptionIsOwner { raiser: lost },
        ConfigError::ExceptionWithoutLane {
            raiser: Raiser::Timeout(a, "a"),
            exception: (b, "b"),
        },
    ]
    .map(|e| e.to_string());
    assert_eq!(
        messages,
        [
            "monitor `orphan` is owned by sequence 3, which is not registered",
            "the exception sequence 3 of monitor `lost` is not registered",
            "monitor `lost` names its own owner as its exception sequence",
            "the exception sequence `b` of the timeout of `a` has no lane (declare one before \
             the first tick)",
        ]
    );
}

#[test]
fn a_timeout_exception_is_checked_like_a_monitors() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let stop = seq.register(SeqConfig::new("stop")).unwrap();
    let homing = seq
        .register(
            SeqConfig::new("homing")
                .timeout(Duration::from_secs(5))
                .timeout_exception(stop),
        )
        .unwrap();
    let monitors: Monitors<Ctrl, 1> = Monitors::new();
    assert_eq!(
        seq.validate(&monitors),
        Err(ConfigError::ExceptionWithoutLane {
            raiser: Raiser::Timeout(homing, "homing"),
            exception: (stop, "stop")
        })
    );
    seq.sequence_by_id(stop).unwrap().declare_lane().unwrap();
    assert_eq!(seq.validate(&monitors), Ok(()));
    // A timeout that names its own sequence, or one never registered.
    let own = seq
        .register(
            SeqConfig::new("own")
                .timeout(Duration::from_secs(1))
                .timeout_exception(SeqId::from_index(2)),
        )
        .unwrap();
    assert_eq!(
        seq.validate(&monitors),
        Err(ConfigError::ExceptionIsOwner {
            raiser: Raiser::Timeout(own, "own")
        })
    );
}

/// `Table::validate` (the compiler's check, with the lanes a table declares) finds exactly
/// what `Sequencer::validate` finds once the table is installed.
mod at_compile_time {
    use super::*;
    use rtseq::{OwnedMonitor, Table};

    type Cond = rtseq::ConditionFn<Ctrl>;
    const NEVER: Cond = never;
    const MOVES: SeqId = SeqId::from_index(0);
    const STOP: SeqId = SeqId::from_index(1);
    const HOMING: SeqId = SeqId::from_index(2);
    const UNKNOWN: SeqId = SeqId::from_index(7);
    const JAM: MonitorId = MonitorId::from_index(0);

    /// `moves`, `stop` (in a lane when `stop_lane`), `homing` (timeout exception `stop`).
    const fn table(stop_lane: bool) -> Table<Ctrl, 3> {
        let stop = SeqConfig::new("stop");
        let stop = if stop_lane { stop.in_lane() } else { stop };
        let homing = SeqConfig::new("homing")
            .timeout(Duration::from_secs(5))
            .timeout_exception(STOP);
        match Table::new([SeqConfig::new("moves").in_lane(), stop, homing]) {
            Ok(t) => t,
            Err(_) => panic!("the test table"),
        }
    }

    const fn jam(owner: SeqId, exception: SeqId) -> OwnedMonitor<'static, Ctrl, Cond> {
        Monitor::with_condition("jam", NEVER, Behaviour::AbortOwner)
            .exception(exception)
            .owned_by(owner)
    }

    /// Both checks of one configuration: (the table's, the sequencer's).
    fn both(
        stop_lane: bool,
        owner: SeqId,
        exception: SeqId,
    ) -> (Result<(), ConfigError>, Result<(), ConfigError>) {
        let table = table(stop_lane);
        let seq: Sequencer<Ctrl, 4> = Sequencer::new();
        seq.install(&table).unwrap();
        let monitors: Monitors<'static, Ctrl, 1, Cond> =
            Monitors::table([jam(owner, exception)]).unwrap();
        (
            table.validate(&[jam(owner, exception)]),
            seq.validate(&monitors),
        )
    }

    #[test]
    fn every_error_is_the_sequencer_s() {
        let cases = [
            (
                (true, UNKNOWN, STOP),
                Err(ConfigError::UnknownOwner {
                    monitor: (JAM, "jam"),
                    owner: UNKNOWN,
                }),
            ),
            (
                (true, MOVES, UNKNOWN),
                Err(ConfigError::UnknownException {
                    raiser: Raiser::Monitor(JAM, "jam"),
                    exception: UNKNOWN,
                }),
            ),
            (
                (true, STOP, STOP),
                Err(ConfigError::ExceptionIsOwner {
                    raiser: Raiser::Monitor(JAM, "jam"),
                }),
            ),
            (
                (false, MOVES, STOP),
                Err(ConfigError::ExceptionWithoutLane {
                    raiser: Raiser::Monitor(JAM, "jam"),
                    exception: (STOP, "stop"),
                }),
            ),
            // The monitor is fine; the homing's timeout exception has no lane.
            (
                (false, STOP, MOVES),
                Err(ConfigError::ExceptionWithoutLane {
                    raiser: Raiser::Timeout(HOMING, "homing"),
                    exception: (STOP, "stop"),
                }),
            ),
            ((true, MOVES, STOP), Ok(())),
        ];
        for ((stop_lane, owner, exception), want) in cases {
            assert_eq!(
                both(stop_lane, owner, exception),
                (want, want),
                "stop in a lane: {stop_lane}, owner {owner:?}, exception {exception:?}"
            );
        }
    }

    /// The error names the monitor by its place in the table, as `Monitors::table` numbers
    /// them: a fine first monitor, then one owned by an unknown sequence.
    #[test]
    fn the_error_names_the_monitor_by_its_place() {
        let seq: Sequencer<Ctrl, 4> = Sequencer::new();
        seq.install(&table(true)).unwrap();
        let monitors = [jam(MOVES, STOP), jam(UNKNOWN, STOP)];
        let want = Err(ConfigError::UnknownOwner {
            monitor: (MonitorId::from_index(1), "jam"),
            owner: UNKNOWN,
        });
        assert_eq!(table(true).validate(&monitors), want);
        let monitors: Monitors<'static, Ctrl, 2, Cond> = Monitors::table(monitors).unwrap();
        assert_eq!(seq.validate(&monitors), want);
    }

    /// Evaluated by the compiler: the result is a constant.
    #[test]
    fn the_compiler_evaluates_the_check() {
        const WITHOUT_LANE: Result<(), ConfigError> = table(false).validate(&[jam(MOVES, STOP)]);
        const WITH_LANE: Result<(), ConfigError> = table(true).validate(&[jam(MOVES, STOP)]);
        assert_eq!(
            WITHOUT_LANE.map_err(|e| e.to_string()),
            Err(
                "the exception sequence `stop` of monitor `jam` has no lane \
                 (declare one before the first tick)"
                    .to_owned()
            )
        );
        assert_eq!(WITH_LANE, Ok(()));
        assert_eq!(
            WITHOUT_LANE.map_err(|e| e.reason()),
            Err("an exception sequence has no lane")
        );
        // What a `const` item's compile error says (`panic!("{}", e.message().as_str())`):
        // the `Display` form, names included, made by the compiler.
        const MESSAGE: Option<rtseq::ErrorMessage> = match WITHOUT_LANE {
            Err(e) => Some(e.message()),
            Ok(()) => None,
        };
        assert_eq!(
            MESSAGE.map(|m| m.as_str().to_owned()),
            Some(WITHOUT_LANE.unwrap_err().to_string())
        );
    }
}

/// A sequence configured `in_lane` has its lane as soon as it is registered; when the lane
/// slots are taken, the registration is refused and nothing is registered.
#[test]
fn a_sequence_in_a_lane_gets_its_slot_at_registration() {
    use rtseq::lock::CriticalSection;
    let seq: Sequencer<Ctrl, 4, 64, CriticalSection, 1> = Sequencer::new();
    let main = seq.register(SeqConfig::new("main").in_lane()).unwrap();
    let stop = seq.register(SeqConfig::new("stop")).unwrap();
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let mut c = never;
    monitors
        .add(
            stop,
            Monitor::new("jam", &mut c, Behaviour::AbortOwner).exception(main),
        )
        .unwrap();
    assert_eq!(seq.validate(&monitors), Ok(()));
    assert_eq!(seq.sequence_by_id(main).unwrap().start(), Ok(()));
    assert_eq!(
        seq.register(SeqConfig::new("fan").in_lane()),
        Err(Error::LaneCapacityExceeded(SeqId::from_index(2)))
    );
    assert_eq!(seq.len(), 2);
    assert!(seq.sequence_by_name("fan").is_none());
}

/// An installed table's sequences in lanes take the first lane slots, in table order: a
/// table with two of them fits two slots and leaves none for a registration after it, and
/// is refused whole by a sequencer of one slot.
#[test]
fn a_tables_sequences_in_lanes_take_the_first_slots() {
    use rtseq::lock::CriticalSection;
    const TWO_LANES: rtseq::Table<Ctrl, 3> = match rtseq::Table::new([
        SeqConfig::new("main").in_lane(),
        SeqConfig::new("stop"),
        SeqConfig::new("fan").in_lane(),
    ]) {
        Ok(table) => table,
        Err(e) => panic!("{}", e.message().as_str()),
    };
    let two: Sequencer<Ctrl, 4, 64, CriticalSection, 2> = Sequencer::new();
    assert!(two.is_empty());
    assert_eq!(two.install(&TWO_LANES), Ok(()));
    assert!(!two.is_empty());
    assert_eq!(
        two.register(SeqConfig::new("pump").in_lane()),
        Err(Error::LaneCapacityExceeded(SeqId::from_index(3)))
    );
    assert_eq!(
        two.register(SeqConfig::new("pump")),
        Ok(SeqId::from_index(3))
    );
    let one: Sequencer<Ctrl, 4, 64, CriticalSection, 1> = Sequencer::new();
    assert_eq!(
        one.install(&TWO_LANES),
        Err(Error::LaneCapacityExceeded(SeqId::from_index(2)))
    );
    assert!(one.is_empty());
}

/// A sequence counts the `PauseOwner` monitors that hold it paused in a byte: a table of 256
/// of them, all of one sequence, is refused (by `add` and by the `const` table), one fewer
/// or one of another owner is not.
#[test]
fn a_table_of_256_pause_owner_monitors_of_one_sequence_is_refused() {
    type Cond = rtseq::ConditionFn<Ctrl>;
    const A: SeqId = SeqId::from_index(0);
    const B: SeqId = SeqId::from_index(1);
    const HOLD_A: rtseq::OwnedMonitor<'static, Ctrl, Cond> =
        Monitor::with_fn("hold", never, Behaviour::PauseOwner).owned_by(A);
    const HOLD_B: rtseq::OwnedMonitor<'static, Ctrl, Cond> =
        Monitor::with_fn("hold", never, Behaviour::PauseOwner).owned_by(B);
    const ABORT_A: rtseq::OwnedMonitor<'static, Ctrl, Cond> =
        Monitor::with_fn("abort", never, Behaviour::AbortOwner).owned_by(A);

    let hold = || Monitor::with_fn("hold", never, Behaviour::PauseOwner);
    let mut monitors: Monitors<Ctrl, 256, Cond> = Monitors::new();
    for _ in 0..255 {
        assert!(monitors.add(A, hold()).is_ok());
    }
    assert_eq!(
        monitors.add(A, hold()).map(|_| ()),
        Err(Error::PauseOwnerMonitorsExceeded(A))
    );
    assert_eq!(monitors.add(B, hold()), Ok(MonitorId::from_index(255)));

    // 256 entries of A's holds, with `first` and `last` in place.
    let table = |first, last| {
        let mut entries = [HOLD_A; 256];
        entries[0] = first;
        entries[255] = last;
        Monitors::<Ctrl, 256, Cond>::table(entries)
            .map(|_| ())
            .map_err(|e| e.error)
    };
    assert_eq!(
        table(HOLD_A, HOLD_A),
        Err(Error::PauseOwnerMonitorsExceeded(A))
    );
    assert_eq!(table(HOLD_A, HOLD_B), Ok(()));
    assert_eq!(table(ABORT_A, HOLD_A), Ok(()));
}

/// A lane declared but never polled takes no start: the safe stop a monitor starts in it
/// would stay `Running` for good. `check_lanes` names the first such sequence until every
/// declared lane has run up to its first wait (`lanes!` polls each of its lanes).
#[test]
fn a_declared_lane_that_no_task_polls_is_named_by_check_lanes() {
    use core::future::Future;
    use core::task::{Context, Poll, Waker};
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut main = seq
        .add(SeqConfig::new("main").in_lane(), Node::of(vec![]))
        .unwrap();
    let mut stop = seq
        .add(SeqConfig::new("safe stop"), Node::of(vec![]))
        .unwrap();
    let _plain = seq.add(SeqConfig::new("plain"), Node::of(vec![])).unwrap();
    let (m, s) = (main.id(), stop.id());
    seq.sequence_by_id(s).unwrap().declare_lane().unwrap();
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(m)));
    assert_eq!(
        Error::NoLane(m).message().as_str(),
        "sequence 0 has no lane that a task polls"
    );
    // What the check prevents: the start is taken, the sequence is `Running`, and no lane
    // runs it.
    seq.sequence_by_id(s).unwrap().start().unwrap();
    assert_eq!(
        seq.sequence_by_id(s).unwrap().state(),
        rtseq::RunningState::Running
    );
    let mut cx = Context::from_waker(Waker::noop());
    {
        let mut task = core::pin::pin!(rtseq::lane(&seq, &ctrl, &mut main));
        assert_eq!(task.as_mut().poll(&mut cx), Poll::Pending);
        // `main`'s lane waited once; `safe stop`'s is still missing.
        assert_eq!(seq.check_lanes(), Err(Error::NoLane(s)));
    }
    let (main, stop) = (&mut main, &mut stop);
    let mut task = core::pin::pin!(rtseq::lanes!(&seq, &ctrl, main, stop));
    assert_eq!(task.as_mut().poll(&mut cx), Poll::Pending);
    assert_eq!(seq.check_lanes(), Ok(()));
    assert_eq!(
        seq.sequence_by_id(s).unwrap().state(),
        rtseq::RunningState::Terminated
    );
}
