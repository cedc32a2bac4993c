//! Rules of the specification that its audit (session 51) found implemented but pinned by
//! no test, and one where rtseq departs from it on purpose (docs/design-decisions.md,
//! "The specification, term by term").

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Start, Timeout};
use rtseq::RunningState::*;
use rtseq::{Behaviour, Duration, Error, Failure, Monitor, Monitors, SeqConfig, Sequencer};

/// Owner X (polling `x_ms`) runs its blocking step S (polling `s_ms`); X's monitor
/// (`AbortOwner`) becomes true at 5 ms. Returns when X was aborted (ms).
fn monitor_of_a_blocked_owner_fires_at(x_ms: u64, s_ms: u64) -> u64 {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            SeqConfig::new("S").polling(Duration::from_millis(s_ms)),
            Leaf::until(15),
        )
        .unwrap();
    let si = s.id();
    let x = seq
        .add(
            SeqConfig::new("X").polling(Duration::from_millis(x_ms)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let xi = x.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(xi, Monitor::new("m", &mut c0, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 5));
    sim.start(xi).unwrap();
    sim.run_for(Duration::from_millis(250));
    let at = ms(sim.trace()[2].time);
    assert_eq!(
        sim.trace(),
        [
            tr(0, xi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(at, si, Running, Aborting, Mon(m)),
            tr(at, si, Aborting, Aborted, Mon(m)),
            tr(at, xi, Running, Aborting, Mon(m)),
            tr(at, xi, Aborting, Aborted, Mon(m)),
        ]
    );
    at
}

/// The specification has a monitor checked by every sequence and step that blocks its
/// owner, each at its own polling time (EEROS: the innermost running one checks the
/// monitors of its blocking callers). rtseq's tick checks a monitor at its owner's
/// polling period, whichever child runs: its rate and reaction bound are the owner's
/// setting. A slow owner above a fast step fires at the owner's next poll (100 ms, where
/// EEROS would react within the step's 1 ms), a fast owner above a slow step within a
/// millisecond (where EEROS would wait for the step's 100 ms).
#[test]
fn a_monitor_is_checked_at_its_owner_s_polling_period_whichever_child_runs() {
    assert_eq!(monitor_of_a_blocked_owner_fires_at(100, 1), 100);
    assert_eq!(monitor_of_a_blocked_owner_fires_at(1, 100), 5);
}

/// `exceptionIsActive` (seed §1.3): true once a monitor fired, while its exception is
/// handled and after the sequence was aborted because of it; a restart clears it (the
/// restarted run is not held; EEROS's restart clears its fired monitor too), and so does a
/// new start. `activeException` names the last exception until a new start.
#[test]
fn exception_is_active_while_handled_and_after_an_abort_a_restart_and_a_start_clear_it() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(15))
        .unwrap();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(5))
        .unwrap();
    let (xi, ei) = (x.id(), e.id());
    let (mut c0, mut c1) = (|c: &Ctrl, _| c.flag(0), |c: &Ctrl, _| c.flag(1));
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let restart = monitors
        .add(
            xi,
            Monitor::new("restart", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let stop = monitors
        .add(xi, Monitor::new("stop", &mut c1, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    let marks = |sim: &Sim<'_, Ctrl, 4, 64, 2>| {
        let h = sim.handle(xi).unwrap();
        (sim.state(xi), h.exception_is_active(), h.active_exception())
    };
    sim.start(xi).unwrap();
    assert_eq!(marks(&sim), (Running, false, None));
    ctrl.set(0, true);
    sim.step();
    ctrl.set(0, false);
    // E handles the exception: X is held.
    assert_eq!(sim.state(ei), Running);
    assert_eq!(marks(&sim), (Running, true, Some(Mon(restart))));
    ctrl.set(5, true);
    sim.run_for(Duration::from_millis(3));
    ctrl.set(5, false);
    // E ended, X was restarted: its new iteration runs without the exception.
    assert_eq!(
        moves_of(sim.trace(), xi),
        [(Running, Restarting), (Restarting, Running)]
    );
    assert_eq!(marks(&sim), (Running, false, Some(Mon(restart))));
    ctrl.set(1, true);
    sim.step();
    ctrl.set(1, false);
    assert_eq!(marks(&sim), (Aborted, true, Some(Mon(stop))));
    sim.start(xi).unwrap();
    assert_eq!(marks(&sim), (Running, false, None));
}

/// `exceptionIsActive` after a run that an exception held ended otherwise: an abort-all or
/// an operator's abort during the exception sequence aborts the owner for its own cause,
/// not because of the monitor, and no exception is handled any more (found by an outside
/// probe in session 56: the mark stayed until the next start).
#[test]
fn an_abort_for_another_cause_during_an_exception_ends_exception_is_active() {
    for by_operator in [false, true] {
        let seq: Sequencer<Ctrl, 4> = Sequencer::new();
        let ctrl = Ctrl::default();
        let x = seq
            .add(SeqConfig::new("X"), Node::of(vec![]).until(15))
            .unwrap();
        let e = seq
            .add(SeqConfig::new("E"), Node::of(vec![]).until(15))
            .unwrap();
        let (xi, ei) = (x.id(), e.id());
        let mut c0 = |c: &Ctrl, _| c.flag(0);
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        let restart = monitors
            .add(
                xi,
                Monitor::new("restart", &mut c0, Behaviour::RestartOwner).exception(ei),
            )
            .unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.lane(x);
        sim.lane(e);
        sim.before_tick(|t, c| c.set(0, ms(t) == 3));
        sim.start(xi).unwrap();
        sim.run_for(Duration::from_millis(4));
        let h = sim.handle(xi).unwrap();
        assert_eq!((sim.state(ei), h.exception_is_active()), (Running, true));
        let cause = if by_operator {
            h.abort().unwrap();
            Cause::Abort
        } else {
            sim.abort_all();
            Cause::AbortAll
        };
        sim.run_for(Duration::from_millis(2));
        let h = sim.handle(xi).unwrap();
        assert_eq!(
            (sim.state(xi), h.exception_is_active(), h.active_exception()),
            (Aborted, false, Some(Mon(restart))),
            "aborted by {cause:?}"
        );
        assert_eq!(h.last_outcome(), Some(rtseq::Outcome::Aborted(cause)));
    }
}

/// A sequence's transitions other than its starts, as (from, to).
fn moves_of(
    trace: &[rtseq::Transition],
    id: rtseq::SeqId,
) -> Vec<(rtseq::RunningState, rtseq::RunningState)> {
    trace
        .iter()
        .filter(|t| t.sequence == id && t.cause != Start)
        .map(|t| (t.from, t.to))
        .collect()
}

/// Seed §1.2, 5: "restarting" repeats the run from the pre-condition. X's pre-condition
/// (flag 2) has turned false by the time its monitor restarts it: the restart skips it.
#[test]
fn a_restart_checks_the_pre_condition_again() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut node = Node::of(vec![]).until(15);
    node.pre = Some(2);
    let x = seq.add(SeqConfig::new("X"), node).unwrap();
    let xi = x.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(xi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 3);
        c.set(2, ms(t) < 2);
    });
    ctrl.set(2, true);
    sim.start(xi).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(
        sim.trace(),
        [
            tr(0, xi, Idle, Running, Start),
            tr(3, xi, Running, Restarting, Mon(m)),
            tr(3, xi, Restarting, Running, Cause::Restart),
            tr(3, xi, Running, Terminated, Cause::PreConditionFalse),
        ]
    );
}

/// Seed §1.7.4: the timeout monitor's behaviour is set "wie bei jedem anderen Monitor".
/// Step S's 3 ms timeout with `AbortCallerOfOwner` aborts S and its caller A; main, which
/// ran A blocking, goes on and completes.
#[test]
fn a_step_s_timeout_with_abort_caller_of_owner_aborts_its_caller() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            SeqConfig::new("S")
                .timeout(Duration::from_millis(3))
                .timeout_behaviour(Behaviour::AbortCallerOfOwner),
            Leaf::until(15),
        )
        .unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Run(a)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(20));
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, ai, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, si, Running, Aborting, Timeout(si)),
            tr(3, si, Aborting, Aborted, Timeout(si)),
            tr(3, ai, Running, Aborting, Timeout(si)),
            tr(3, ai, Aborting, Aborted, Timeout(si)),
            tr(3, mi, Running, Terminated, Completed),
        ]
    );
}

/// Seed §1.7: a monitor may be owned by a step. Its `RestartOwner` runs the step's action
/// again; past its limit of 1 it aborts the step, and the caller goes on.
#[test]
fn a_monitor_owned_by_a_step_restarts_it_then_aborts_it() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let mi = main.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3 || ms(t) == 6));
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(20));
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, si, Running, Restarting, Mon(m)),
            tr(3, si, Restarting, Running, Cause::Restart),
            tr(6, si, Running, Aborting, Mon(m)),
            tr(6, si, Aborting, Aborted, Mon(m)),
            tr(6, mi, Running, Terminated, Completed),
        ]
    );
    // The step's action ran once per run: "action() mehrmals".
    assert_eq!(ctrl.lines_of(si).len(), 2);
}

/// Seed §1.5: a step "wird mit start() immer blockierend gestartet": it has no lane, so a
/// non-blocking start of it, from a handle or from an action, is refused and it stays idle.
#[test]
fn a_step_cannot_be_started_non_blocking() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Start(si)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    assert_eq!(sim.handle(si).unwrap().start(), Err(Error::NoLane(si)));
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(3));
    assert_eq!(
        ctrl.returned
            .borrow()
            .iter()
            .map(|r| (r.seq, r.result))
            .collect::<Vec<_>>(),
        [(mi, Err(Failure::NotStarted(Error::NoLane(si))))]
    );
    assert_eq!(sim.state(si), Idle);
}
