//! `Behaviour::PauseOwner`: a light curtain that pauses the cycle while it is broken, next to
//! a following-error monitor on the same owner (which it must not mask).
//!
//! Tree: cycle ─step→ move (exit: flag 1, at 20 ms). Monitors of `cycle`: `curtain`
//! (`PauseOwner`, flag 2, exception `alarm`) and `following error` (`RestartOwner`, flag 3,
//! exception `safe stop`, a 2 ms wait).

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Monitor as Mon, Restart, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Duration, Error, Monitor, MonitorId, Monitors, SeqConfig, SeqId, Sequencer,
    Transition, Trigger, Wait,
};

struct Run {
    trace: Vec<Transition>,
    cycle: SeqId,
    step: SeqId,
    alarm: SeqId,
    stop: SeqId,
    wait: SeqId,
    fired: [u16; 2],
}

/// The cell, with the curtain broken while `curtain(ms)` and a following error at the
/// ticks where `error(ms)`.
fn run(curtain: fn(u64) -> bool, error: fn(u64) -> bool) -> Run {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("move"), Leaf::until(1)).unwrap();
    let step_id = step.id();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let alarm = seq.add(SeqConfig::new("alarm"), Node::of(vec![])).unwrap();
    let wait = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let wait_id = wait.id();
    let stop = seq
        .add(SeqConfig::new("safe stop"), Node::of(vec![Op::Wait(wait)]))
        .unwrap();
    let (ci, ai, si) = (cycle.id(), alarm.id(), stop.id());
    let mut broken = |c: &Ctrl, _| c.flag(2);
    let mut lagging = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let m0 = monitors
        .add(
            ci,
            Monitor::new("curtain", &mut broken, Behaviour::PauseOwner)
                .exception(ai)
                // Ignored: a `PauseOwner` monitor watches both edges.
                .trigger(Trigger::Level),
        )
        .unwrap();
    let m1 = monitors
        .add(
            ci,
            Monitor::new("following error", &mut lagging, Behaviour::RestartOwner).exception(si),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.lane(alarm);
    sim.lane(stop);
    sim.before_tick(move |t, c| {
        c.set(1, ms(t) >= 20);
        c.set(2, curtain(ms(t)));
        c.set(3, error(ms(t)));
    });
    sim.start(ci).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let fired = [m0, m1].map(|m| sim.monitors().fired(m));
    Run {
        trace: sim.take_trace(),
        cycle: ci,
        step: step_id,
        alarm: ai,
        stop: si,
        wait: wait_id,
        fired,
    }
}

#[test]
fn a_broken_curtain_pauses_the_cycle_until_it_clears() {
    let r = run(|ms| (5..9).contains(&ms), |_| false);
    let (c, s, a) = (r.cycle, r.step, r.alarm);
    let k = Mon(MonitorId::from_index(0));
    assert_eq!(
        r.trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            // Broken at 5 ms: the alarm starts, the cycle and its move are paused.
            tr(5, a, Idle, Running, k),
            tr(5, c, Running, Paused, k),
            tr(5, s, Running, Paused, k),
            tr(5, a, Running, Terminated, Completed),
            // Clear at 9 ms: both resume where they were.
            tr(9, c, Paused, Running, k),
            tr(9, s, Paused, Running, k),
            tr(20, s, Running, Terminated, Completed),
            tr(20, c, Running, Terminated, Completed),
        ],
        "{}",
        show(&r.trace)
    );
    assert_eq!(r.fired, [1, 0]);
}

/// The curtain is broken from 5 ms to 12 ms; the axis lags at 7 ms, while the cycle is
/// paused. The following-error monitor still fires (the pause marked no exception): the
/// safe stop runs, and when it ended the cycle restarts. The restarted cycle's monitors
/// start from "false", so the curtain, still broken, pauses it again at its next poll.
#[test]
fn a_following_error_while_paused_still_restarts_the_cycle_which_pauses_again() {
    let r = run(|ms| (5..12).contains(&ms), |ms| ms == 7);
    let (c, s, a, e, w) = (r.cycle, r.step, r.alarm, r.stop, r.wait);
    let (k0, k1) = (Mon(MonitorId::from_index(0)), Mon(MonitorId::from_index(1)));
    assert_eq!(
        r.trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(5, a, Idle, Running, k0),
            tr(5, c, Running, Paused, k0),
            tr(5, s, Running, Paused, k0),
            tr(5, a, Running, Terminated, Completed),
            // The following error, not masked by the pause: the safe stop (a 2 ms dwell).
            tr(7, e, Idle, Running, k1),
            tr(7, w, Idle, Running, Start),
            tr(9, w, Running, Terminated, Completed),
            tr(9, e, Running, Terminated, Completed),
            // The next tick restarts the paused cycle; its move is aborted and runs again.
            tr(10, s, Paused, Aborting, k1),
            tr(10, s, Aborting, Aborted, k1),
            tr(10, c, Paused, Restarting, k1),
            tr(10, c, Restarting, Running, Restart),
            tr(10, s, Aborted, Running, Start),
            // The curtain is still broken: paused again at the next poll, until it clears.
            tr(11, a, Terminated, Running, k0),
            tr(11, c, Running, Paused, k0),
            tr(11, s, Running, Paused, k0),
            tr(11, a, Running, Terminated, Completed),
            tr(12, c, Paused, Running, k0),
            tr(12, s, Paused, Running, k0),
            tr(20, s, Running, Terminated, Completed),
            tr(20, c, Running, Terminated, Completed),
        ],
        "{}",
        show(&r.trace)
    );
    assert_eq!(r.fired, [2, 1]);
}

#[test]
fn a_timeout_cannot_pause_its_sequence() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let config = || {
        SeqConfig::new("homing")
            .timeout(Duration::from_secs(1))
            .timeout_behaviour(Behaviour::PauseOwner)
    };
    assert_eq!(seq.register(config()), Err(Error::PauseOnTimeout));
    assert_eq!(
        rtseq::Table::<Ctrl, 1>::new([config()])
            .err()
            .map(|e| e.error),
        Some(Error::PauseOnTimeout)
    );
    assert_eq!(
        Error::PauseOnTimeout.to_string(),
        "a timeout cannot pause its sequence (PauseOwner is a monitor behaviour)"
    );
}

/// What the operator does to the cycle.
#[derive(Clone, Copy)]
enum Operator {
    Pause,
    Resume,
    /// A resume that is refused while a curtain holds.
    ResumeRefused,
}

/// A cycle with two light curtains (`PauseOwner` monitors 0 and 1), broken while `a(ms)`
/// and `b(ms)`, run to 30 ms; the operator acts on the cycle at the given times.
fn curtains(
    a: fn(u64) -> bool,
    b: fn(u64) -> bool,
    operator: &[(u64, Operator)],
) -> (Vec<Transition>, SeqId) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![]).until(1))
        .unwrap();
    let c = cycle.id();
    let mut on_a = |c: &Ctrl, _| c.flag(2);
    let mut on_b = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(
            c,
            Monitor::new("curtain A", &mut on_a, Behaviour::PauseOwner),
        )
        .unwrap();
    monitors
        .add(
            c,
            Monitor::new("curtain B", &mut on_b, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(move |t, ctrl| {
        ctrl.set(2, a(ms(t)));
        ctrl.set(3, b(ms(t)));
    });
    sim.start(c).unwrap();
    for &(at, act) in operator {
        sim.run_until(rtseq::Instant::from_ticks(at * 1_000));
        match act {
            Operator::Pause => assert_eq!(sim.pause(c), Ok(())),
            Operator::Resume => assert_eq!(sim.resume(c), Ok(())),
            Operator::ResumeRefused => {
                assert_eq!(sim.resume(c), Err(Error::HeldByMonitor(c)))
            }
        }
    }
    sim.run_until(rtseq::Instant::from_ticks(30_000));
    (sim.trace().to_vec(), c)
}

/// The cycle stays paused while either curtain is broken: A from 5 to 10 ms, B from 7 to
/// 20 ms; it resumes when the last one clears, for that monitor.
#[test]
fn with_two_curtains_the_owner_resumes_when_the_last_one_clears() {
    let (trace, c) = curtains(|t| (5..10).contains(&t), |t| (7..20).contains(&t), &[]);
    let (a, b) = (Mon(MonitorId::from_index(0)), Mon(MonitorId::from_index(1)));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(5, c, Running, Paused, a),
            tr(20, c, Paused, Running, b),
        ]
    );
}

/// The operator's pause (feed hold at 2 ms) outlasts a curtain broken from 5 to 8 ms: only
/// the operator's resume (at 12 ms) lifts it.
#[test]
fn a_curtain_that_clears_keeps_the_operators_pause() {
    let (trace, c) = curtains(
        |t| (5..8).contains(&t),
        |_| false,
        &[(2, Operator::Pause), (12, Operator::Resume)],
    );
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(3, c, Running, Paused, rtseq::Cause::Pause),
            tr(13, c, Paused, Running, rtseq::Cause::Resume),
        ]
    );
}

/// The operator's pause made while a curtain holds the cycle (broken from 5 to 10 ms,
/// the pause at 7 ms) is kept: the cycle stays paused when the curtain clears, until the
/// operator's resume (at 15 ms). A second pause is then `AlreadyPaused`.
#[test]
fn an_operators_pause_made_while_a_curtain_holds_outlasts_the_curtain() {
    let (trace, c) = curtains(
        |t| (5..10).contains(&t),
        |_| false,
        &[(7, Operator::Pause), (15, Operator::Resume)],
    );
    let a = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(5, c, Running, Paused, a),
            tr(16, c, Paused, Running, rtseq::Cause::Resume),
        ]
    );
}

/// While a curtain holds the cycle (broken from 5 to 20 ms), a resume request is refused
/// with `HeldByMonitor`; the cycle resumes when the curtain clears.
#[test]
fn a_resume_request_is_refused_while_a_curtain_holds() {
    let (trace, c) = curtains(
        |t| (5..20).contains(&t),
        |_| false,
        &[(8, Operator::ResumeRefused)],
    );
    let a = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(5, c, Running, Paused, a),
            tr(20, c, Paused, Running, a),
        ]
    );
    assert_eq!(
        Error::HeldByMonitor(c).to_string(),
        "sequence 0 is held paused by a monitor whose condition holds"
    );
}

/// A restart runs the cycle again unpaused: the operator pauses it (at 2 ms), a following
/// error restarts it (at 6 ms), and a curtain broken from 10 to 15 ms pauses it and, when
/// it clears, resumes it (the operator's pause ended with the run it paused).
#[test]
fn a_restart_ends_the_operators_pause_and_a_later_curtain_resumes_the_cycle() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![]).until(1))
        .unwrap();
    let c = cycle.id();
    let mut curtain = |c: &Ctrl, _| c.flag(2);
    let mut error = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(
            c,
            Monitor::new("curtain", &mut curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    monitors
        .add(
            c,
            Monitor::new("following error", &mut error, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(|t, ctrl| {
        ctrl.set(2, (10..15).contains(&ms(t)));
        ctrl.set(3, ms(t) == 6);
    });
    sim.start(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(2_000));
    sim.pause(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(30_000));
    let (curtain, error) = (Mon(MonitorId::from_index(0)), Mon(MonitorId::from_index(1)));
    assert_eq!(
        sim.trace(),
        [
            tr(0, c, Idle, Running, Start),
            tr(3, c, Running, Paused, rtseq::Cause::Pause),
            tr(6, c, Paused, Restarting, error),
            tr(6, c, Restarting, Running, Restart),
            tr(10, c, Running, Paused, curtain),
            tr(15, c, Paused, Running, curtain),
        ]
    );
}

/// A cycle that blocks on a feed (its blocking child), each with a `PauseOwner` monitor:
/// the cycle's curtain (monitor 0, broken while `curtain(ms)`) and the feed's own hold
/// (monitor 1, while `feed(ms)`); `operator` pauses or resumes the feed at the given times.
/// Returns the trace to 30 ms, the cycle's and the feed's ids.
fn cycle_and_feed(
    curtain: fn(u64) -> bool,
    feed: fn(u64) -> bool,
    operator: &[(u64, Operator)],
) -> (Vec<Transition>, SeqId, SeqId) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let f = seq
        .add(SeqConfig::new("feed"), Node::of(vec![]).until(1))
        .unwrap();
    let fi = f.id();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![Op::Run(f)]))
        .unwrap();
    let c = cycle.id();
    let mut on_curtain = |c: &Ctrl, _| c.flag(2);
    let mut on_feed = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(
            c,
            Monitor::new("curtain", &mut on_curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    monitors
        .add(
            fi,
            Monitor::new("feed hold", &mut on_feed, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(move |t, ctrl| {
        ctrl.set(2, curtain(ms(t)));
        ctrl.set(3, feed(ms(t)));
    });
    sim.start(c).unwrap();
    for &(at, act) in operator {
        sim.run_until(rtseq::Instant::from_ticks(at * 1_000));
        match act {
            Operator::Pause => assert_eq!(sim.pause(fi), Ok(())),
            Operator::Resume => assert_eq!(sim.resume(fi), Ok(())),
            Operator::ResumeRefused => {
                assert_eq!(sim.resume(fi), Err(Error::HeldByMonitor(fi)))
            }
        }
    }
    sim.run_until(rtseq::Instant::from_ticks(30_000));
    (sim.trace().to_vec(), c, fi)
}

/// The operator pauses the feed (at 2 ms); the cycle's curtain, broken from 5 to 10 ms,
/// pauses and resumes the cycle but leaves the feed paused until the operator resumes it
/// (at 15 ms).
#[test]
fn a_curtain_of_the_caller_keeps_the_operators_pause_of_the_feed() {
    let (trace, c, f) = cycle_and_feed(
        |t| (5..10).contains(&t),
        |_| false,
        &[(2, Operator::Pause), (15, Operator::Resume)],
    );
    let curtain = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(3, f, Running, Paused, rtseq::Cause::Pause),
            tr(5, c, Running, Paused, curtain),
            tr(10, c, Paused, Running, curtain),
            tr(16, f, Paused, Running, rtseq::Cause::Resume),
        ]
    );
}

/// The feed's own hold (5 to 20 ms) outlasts the cycle's curtain (8 to 12 ms): the feed
/// stays paused when the cycle resumes, until its own monitor clears.
#[test]
fn a_curtain_of_the_caller_keeps_the_feeds_own_hold() {
    let (trace, c, f) = cycle_and_feed(|t| (8..12).contains(&t), |t| (5..20).contains(&t), &[]);
    let (curtain, hold) = (Mon(MonitorId::from_index(0)), Mon(MonitorId::from_index(1)));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(5, f, Running, Paused, hold),
            tr(8, c, Running, Paused, curtain),
            tr(12, c, Paused, Running, curtain),
            tr(20, f, Paused, Running, hold),
        ]
    );
}

/// The feed's own hold (8 to 12 ms) clears while the cycle's curtain (5 to 20 ms) still
/// holds the cycle: the feed, frozen by its caller, stays paused (its clock stopped) and
/// resumes with the cycle.
#[test]
fn a_feed_whose_caller_is_paused_resumes_with_its_caller() {
    let (trace, c, f) = cycle_and_feed(|t| (5..20).contains(&t), |t| (8..12).contains(&t), &[]);
    let curtain = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(5, c, Running, Paused, curtain),
            tr(5, f, Running, Paused, curtain),
            tr(20, c, Paused, Running, curtain),
            tr(20, f, Paused, Running, curtain),
        ]
    );
}

/// The cycle's curtain (5 to 20 ms) pauses the cycle and the feed it blocks. The operator
/// asks at 7 ms to resume the feed (it has no hold of its own, so the request is taken).
/// The feed is frozen by its paused caller (the caller's run does not poll it), so it must
/// stay paused, its clock stopped, and resume with its caller (semantics 7: a sequence
/// whose own hold ends while the caller it blocks is paused resumes with that caller).
/// With a 10 ms timeout (5 ms used before the curtain) it completes at 22 ms (7 ms of
/// run time). Before session 30 the request resumed the feed alone: its clock ran while it
/// was frozen and its timeout aborted it at 13 ms, under the paused cycle.
#[test]
fn a_resume_request_of_a_feed_frozen_by_its_paused_caller_resumes_it_with_the_caller() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let f = seq
        .add(
            SeqConfig::new("feed").timeout(Duration::from_millis(10)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let fi = f.id();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![Op::Run(f)]))
        .unwrap();
    let c = cycle.id();
    let mut on_curtain = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            c,
            Monitor::new("curtain", &mut on_curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(move |t, ctrl| {
        ctrl.set(1, ms(t) >= 22);
        ctrl.set(2, (5..20).contains(&ms(t)));
    });
    sim.start(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(7_000));
    assert_eq!(sim.resume(fi), Ok(()));
    sim.run_until(rtseq::Instant::from_ticks(30_000));
    let curtain = Mon(MonitorId::from_index(0));
    assert_eq!(
        sim.trace(),
        [
            tr(0, c, Idle, Running, Start),
            tr(0, fi, Idle, Running, Start),
            tr(5, c, Running, Paused, curtain),
            tr(5, fi, Running, Paused, curtain),
            tr(20, c, Paused, Running, curtain),
            tr(20, fi, Paused, Running, curtain),
            tr(22, fi, Running, Terminated, Completed),
            tr(22, c, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
}

/// The operator pauses the cycle (at 2 ms); the curtain, with its alarm as exception
/// sequence, breaks at 5 ms while the cycle is paused. Monitors stay active while their
/// owner is paused (semantics 3), and when a `PauseOwner` monitor's condition becomes
/// true its exception sequence starts (semantics 7): the alarm must run at 5 ms, and the
/// monitor counts as fired. Before session 30 the alarm did not run (the owner was not
/// running).
#[test]
fn a_curtain_broken_while_the_operator_paused_the_cycle_still_sounds_its_alarm() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![]).until(1))
        .unwrap();
    let c = cycle.id();
    let alarm = seq.add(SeqConfig::new("alarm"), Node::of(vec![])).unwrap();
    let a = alarm.id();
    let mut curtain = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            c,
            Monitor::new("curtain", &mut curtain, Behaviour::PauseOwner).exception(a),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.lane(alarm);
    sim.before_tick(|t, ctrl| ctrl.set(2, (5..8).contains(&ms(t))));
    sim.start(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(2_000));
    sim.pause(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(12_000));
    sim.resume(c).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(20_000));
    let k = Mon(MonitorId::from_index(0));
    assert_eq!(
        sim.trace(),
        [
            tr(0, c, Idle, Running, Start),
            tr(3, c, Running, Paused, rtseq::Cause::Pause),
            tr(5, a, Idle, Running, k),
            tr(5, a, Running, Terminated, Completed),
            tr(13, c, Paused, Running, rtseq::Cause::Resume),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(sim.monitors().fired(m), 1);
}

/// Curtain A is broken from 5 to 10 ms, curtain B from 10 to 20 ms: at 10 ms A clears in
/// the same tick as B breaks. The cycle stays paused from 5 to 20 ms: when A clears, B
/// holds (semantics 7: it resumes once no other `PauseOwner` monitor holds). Before
/// session 30 the tick handled A's release before B's hold (table order): the trace
/// showed the cycle resumed and paused again at 10 ms.
#[test]
fn a_curtain_that_clears_in_the_tick_another_breaks_does_not_resume_the_cycle() {
    let (trace, c) = curtains(|t| (5..10).contains(&t), |t| (10..20).contains(&t), &[]);
    let (a, b) = (Mon(MonitorId::from_index(0)), Mon(MonitorId::from_index(1)));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(5, c, Running, Paused, a),
            tr(20, c, Paused, Running, b),
        ],
        "{}",
        show(&trace)
    );
}

/// The operator's pause of the feed made while the cycle's curtain holds both (broken from
/// 5 to 10 ms, the pause at 7 ms) is kept: the cycle resumes when its curtain clears, the
/// feed stays paused until the operator resumes it (at 15 ms).
#[test]
fn an_operators_pause_of_a_feed_frozen_by_its_paused_cycle_outlasts_the_cycles_hold() {
    let (trace, c, f) = cycle_and_feed(
        |t| (5..10).contains(&t),
        |_| false,
        &[(7, Operator::Pause), (15, Operator::Resume)],
    );
    let curtain = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        [
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(5, c, Running, Paused, curtain),
            tr(5, f, Running, Paused, curtain),
            tr(10, c, Paused, Running, curtain),
            tr(16, f, Paused, Running, rtseq::Cause::Resume),
        ]
    );
}

/// Acting at the release (a feed hold's "re-issue the move"): a second monitor on the
/// curtain, `Trigger::FallingEdge`, `Behaviour::Nothing`, with an exception sequence (`re-arm`,
/// a 2 ms dwell). The curtain is broken from 5 ms to 10 ms. At 10 ms the release resumes
/// the cycle and its move, and the falling edge starts `re-arm`, which holds them: the move
/// takes no poll until `re-arm` has ended (12 ms) and its `Nothing` is applied (13 ms).
#[test]
fn a_falling_edge_monitor_with_an_exception_sequence_acts_at_the_release() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("move"), Leaf::until(1)).unwrap();
    let s = step.id();
    let cycle = seq
        .add(SeqConfig::new("cycle"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let c = cycle.id();
    let wait = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let w = wait.id();
    let rearm = seq
        .add(SeqConfig::new("re-arm"), Node::of(vec![Op::Wait(wait)]))
        .unwrap();
    let r = rearm.id();
    let mut broken = |c: &Ctrl, _| c.flag(2);
    let mut cleared = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let m0 = monitors
        .add(
            c,
            Monitor::new("curtain", &mut broken, Behaviour::PauseOwner),
        )
        .unwrap();
    let m1 = monitors
        .add(
            c,
            Monitor::new("curtain cleared", &mut cleared, Behaviour::Nothing)
                .trigger(Trigger::FallingEdge)
                .exception(r),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.lane(rearm);
    sim.before_tick(move |t, c| {
        // The move's exit condition holds from 11 ms: taken at the first poll after the hold.
        c.set(1, ms(t) >= 11);
        c.set(2, (5..10).contains(&ms(t)));
    });
    sim.start(c).unwrap();
    assert!(sim.run_until_idle(Duration::from_millis(100)).is_some());
    let (k0, k1) = (Mon(m0), Mon(m1));
    assert_trace(
        sim.trace(),
        &[
            tr(0, c, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(5, c, Running, Paused, k0),
            tr(5, s, Running, Paused, k0),
            // The tick: the falling edge's exception sequence, then the release; then
            // re-arm's lane runs its dwell.
            tr(10, r, Idle, Running, k1),
            tr(10, c, Paused, Running, k0),
            tr(10, s, Paused, Running, k0),
            tr(10, w, Idle, Running, Start),
            tr(12, w, Running, Terminated, Completed),
            tr(12, r, Running, Terminated, Completed),
            tr(13, s, Running, Terminated, Completed),
            tr(13, c, Running, Terminated, Completed),
        ],
    );
}
