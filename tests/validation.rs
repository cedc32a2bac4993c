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
