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
        rtseq::Table::<Ctrl, 1>::new([config()]).err(),
        Some(Error::PauseOnTimeout)
    );
    assert_eq!(
        Error::PauseOnTimeout.to_string(),
        "a timeout cannot pause its sequence (PauseOwner is a monitor behaviour)"
    );
}
