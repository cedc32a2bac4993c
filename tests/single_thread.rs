//! A sequencer without a lock (`SingleThread`, for one thread alone: host tests and the
//! simulator) behaves exactly as one with the default lock: the same scenario, the same
//! trace. Run under Miri by `./x miri` (its sections borrow the state with no lock at all).

mod common;
use common::*;
use rtseq::lock::{CriticalSection, Lock, SingleThread};
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Monitor as Mon, Restart, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Duration, Monitor, MonitorId, Monitors, SeqConfig, Sequencer, Transition, Wait,
};

/// `cycle` runs a 4 ms `Wait` and a step (until flag 1, at 12 ms); a monitor on flag 2
/// (at 2 ms) runs `safe stop` and restarts the cycle.
fn scenario<L: Lock>(seq: &Sequencer<Ctrl, 8, 64, L>) -> Vec<Transition> {
    let ctrl = Ctrl::default();
    let wait = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(4)))
        .unwrap();
    let step = seq.add(SeqConfig::new("move"), Leaf::until(1)).unwrap();
    let cycle = seq
        .add(
            SeqConfig::new("cycle"),
            Node::of(vec![Op::Wait(wait), Op::Step(step)]),
        )
        .unwrap();
    let stop = seq
        .add(SeqConfig::new("safe stop"), Node::of(vec![]))
        .unwrap();
    let (ci, si) = (cycle.id(), stop.id());
    let mut fault = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            ci,
            Monitor::new("fault", &mut fault, Behaviour::RestartOwner).exception(si),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.lane(stop);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 12);
        c.set(2, ms(t) == 2);
    });
    sim.start(ci).unwrap();
    sim.run_until_idle(Duration::from_millis(50)).unwrap();
    sim.take_trace()
}

#[test]
fn a_single_thread_sequencer_runs_as_one_with_the_default_lock() {
    let locked: Sequencer<Ctrl, 8, 64, CriticalSection> = Sequencer::new();
    let single: Sequencer<Ctrl, 8, 64, SingleThread> = Sequencer::single_thread();
    let trace = scenario(&single);
    assert_eq!(trace, scenario(&locked));
    let [w, s, c, e] = [0, 1, 2, 3].map(rtseq::SeqId::from_index);
    let k = Mon(MonitorId::from_index(0));
    assert_eq!(
        trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, w, Idle, Running, Start),
            tr(2, e, Idle, Running, k),
            tr(2, e, Running, Terminated, Completed),
            tr(3, w, Running, Aborting, k),
            tr(3, w, Aborting, Aborted, k),
            tr(3, c, Running, Restarting, k),
            tr(3, c, Restarting, Running, Restart),
            tr(3, w, Aborted, Running, Start),
            tr(7, w, Running, Terminated, Completed),
            tr(7, s, Idle, Running, Start),
            tr(12, s, Running, Terminated, Completed),
            tr(12, c, Running, Terminated, Completed),
        ],
        "{}",
        show(&trace)
    );
}

/// A sequencer is `Send` with every lock: one made on one thread (a test's fixture, an
/// application's start-up) runs on another, with the same trace.
#[test]
fn a_sequencer_moves_to_another_thread_with_every_lock() {
    let here = scenario(&Sequencer::<Ctrl, 8, 64, CriticalSection>::new());
    let locked: Sequencer<Ctrl, 8, 64, CriticalSection> = Sequencer::new();
    let single: Sequencer<Ctrl, 8, 64, SingleThread> = Sequencer::single_thread();
    let moved = std::thread::spawn(move || (scenario(&locked), scenario(&single)));
    let (locked_trace, single_trace) = moved.join().unwrap();
    assert_eq!(locked_trace, here);
    assert_eq!(single_trace, here);
    assert_eq!(here.len(), 13, "{}", show(&here));
}
