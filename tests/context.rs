//! What an action sees and does through its context `Cx`: polled conditions
//! (`Cx::wait_until`), their timing against the polling grid, pauses and restarts around
//! them (found by a review of the context and the polls).

mod common;
use common::*;

use embassy_futures::join::join;
use rtseq::sim::Sim;
use rtseq::{Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Sequencer};

/// Two polled conditions awaited at once in one action (`join`): each is checked at
/// the sequence's polls, and the action goes on once both hold.
struct Both;
impl Sequence<Ctrl> for Both {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        join(
            cx.wait_until(|cx| cx.control().flag(0)),
            cx.wait_until(|cx| cx.control().flag(1)),
        )
        .await;
        cx.control().set(2, true);
        Ok(())
    }
}

#[test]
fn two_polled_conditions_awaited_at_once_both_end() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let both = seq.add(SeqConfig::new("both"), Both).unwrap();
    let id = both.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(both);
    // Flag 1 (the second condition) from 3 ms, flag 0 (the first) from 5 ms.
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 3);
        c.set(0, ms(t) >= 5);
    });
    sim.start(id).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(done.map(ms), Some(5), "{}", show(sim.trace()));
    assert!(ctrl.flag(2));
}

/// Both conditions hold from the same poll (5 ms): the first wait takes the due poll and
/// ends; the second checks its condition at that poll too and ends with it.
#[test]
fn two_polled_conditions_that_hold_at_the_same_poll_end_together() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let both = seq.add(SeqConfig::new("both"), Both).unwrap();
    let id = both.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(both);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 5);
        c.set(1, ms(t) >= 5);
    });
    sim.start(id).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(done.map(ms), Some(5), "{}", show(sim.trace()));
}

/// A polled wait (X) beside a step followed by a second polled wait (Y), in one action
/// (`join`). The sequence polls every 10 ms; the step ends at 13 ms and wakes the lane off
/// the grid, where Y, new and already true, ends at once. X's condition holds from 12 ms,
/// but X is checked only at the sequence's polls: it ends at 20 ms, not with Y at 13.
struct OffGrid {
    step: rtseq::Seq<Leaf>,
}
impl Sequence<Ctrl> for OffGrid {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let step_then_y = async {
            let _ = cx.step(&mut self.step).await;
            cx.wait_until(|_| true).await;
        };
        let x = async {
            cx.wait_until(|cx| cx.control().flag(1)).await;
            cx.control().set(2, true);
        };
        join(step_then_y, x).await;
        Ok(())
    }
}

#[test]
fn a_new_polled_wait_ending_off_the_grid_does_not_take_the_others_off_it() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("C"), Leaf::until(0)).unwrap();
    let off = seq
        .add(
            SeqConfig::new("off grid").polling(Duration::from_millis(10)),
            OffGrid { step },
        )
        .unwrap();
    let id = off.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(off);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 13);
        c.set(1, ms(t) >= 12);
    });
    sim.start(id).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(19_000));
    assert!(!ctrl.flag(2), "X ended off its grid: {}", show(sim.trace()));
    let done = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(done.map(ms), Some(20), "{}", show(sim.trace()));
    assert!(ctrl.flag(2));
}

/// A step S (polled every 10 ms, grid 10, 20, ...) has a monitor (flag 0, rising at
/// 10 ms, `Behaviour::Nothing`) whose exception sequence E waits 3 ms. S's exit
/// condition (flag 1) holds from 12 ms. The tick at 10 ms marked S's poll due before the
/// monitor fired and then did not wake S for it (held). E ends at 13 ms, the tick at 14
/// ms clears the exception and wakes S's lane: S must wait for its next poll on its grid
/// (20 ms, semantics 1: "polls keep the grid of their polling class"), not use the poll
/// of 10 ms it never took, at 14 ms.
#[test]
fn a_poll_held_by_an_exception_is_not_taken_off_the_grid_when_it_clears() {
    // With the portable lock (short sections) and a coarse one (one section).
    let locked: Sequencer<Ctrl, 8, 64> = Sequencer::new();
    held_poll(&locked);
    let single: Sequencer<Ctrl, 8, 64, rtseq::lock::SingleThread> = Sequencer::single_thread();
    held_poll(&single);
}

fn held_poll<L: rtseq::lock::Lock>(seq: &Sequencer<Ctrl, 8, 64, L>) {
    use rtseq::{Behaviour, Monitor, Wait};
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            SeqConfig::new("S").polling(Duration::from_millis(10)),
            Leaf::until(1),
        )
        .unwrap();
    let si = s.id();
    let m = seq
        .add(SeqConfig::new("M"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let (mi, ei) = (m.id(), e.id());
    let mut fault = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            si,
            Monitor::new("fault", &mut fault, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(m);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 10);
        c.set(1, ms(t) >= 12);
    });
    sim.start(mi).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(30_000));
    let ended = |id| {
        sim.trace()
            .iter()
            .filter(|t| t.sequence == id && t.to == rtseq::RunningState::Terminated)
            .map(|t| ms(t.time))
            .collect::<Vec<_>>()
    };
    assert_eq!(ended(ei), vec![13], "{}", show(sim.trace()));
    assert_eq!(ended(si), vec![20], "{}", show(sim.trace()));
}

/// M (1 ms) runs A (10 ms class, alone in it: grid 10, 20, ...) and then B (10 ms class).
/// A runs a step C (1 ms) that ends at 13 ms, so A's action returns at 13 ms and A ends
/// there (no exit condition), off its grid; M starts B at once, before any tick. The 10 ms
/// class has no active member then: B's start starts a new grid, its first poll one period
/// after the start (semantics 1), at 23 ms. B's exit condition (flag 1) holds from 14 ms.
#[test]
fn a_start_into_a_class_whose_last_member_just_ended_starts_a_new_grid() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let slow = Duration::from_millis(10);
    let c = seq.add(SeqConfig::new("C"), Leaf::until(0)).unwrap();
    let a = seq
        .add(
            SeqConfig::new("A").polling(slow),
            Node::of(vec![Op::Step(c)]),
        )
        .unwrap();
    let b = seq
        .add(SeqConfig::new("B").polling(slow), Leaf::until(1))
        .unwrap();
    let (ai, bi) = (a.id(), b.id());
    let m = seq
        .add(SeqConfig::new("M"), Node::of(vec![Op::Run(a), Op::Step(b)]))
        .unwrap();
    let mi = m.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(m);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 13);
        c.set(1, ms(t) >= 14);
    });
    sim.start(mi).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(40_000));
    let ended = |id| {
        sim.trace()
            .iter()
            .filter(|t| t.sequence == id && t.to == rtseq::RunningState::Terminated)
            .map(|t| ms(t.time))
            .collect::<Vec<_>>()
    };
    assert_eq!(ended(ai), vec![13], "{}", show(sim.trace()));
    assert_eq!(ended(bi), vec![23], "{}", show(sim.trace()));
}

/// A guard that never holds raced against the condition awaited (`select`): the second
/// is checked at every poll too, and the action goes on at 4 ms.
struct Guarded;
impl Sequence<Ctrl> for Guarded {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _ = embassy_futures::select::select(
            cx.wait_until(|cx| cx.control().flag(3)),
            cx.wait_until(|cx| cx.control().flag(0)),
        )
        .await;
        Ok(())
    }
}

#[test]
fn a_polled_condition_raced_against_one_that_never_holds_ends() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let guarded = seq.add(SeqConfig::new("guarded"), Guarded).unwrap();
    let id = guarded.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(guarded);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 4));
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)).map(ms),
        Some(4)
    );
}

static EXIT_CHECKS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A step whose action is preempted by a tick that aborts everything (here the action
/// ticks the sequencer itself after an abort-all, as the timer interrupt would).
struct Preempted(&'static Sequencer<(), 4>);
impl rtseq::Step<()> for Preempted {
    fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        self.0.abort_all();
        let tick = self.0.tick(
            rtseq::Instant::from_ticks(1_000),
            &(),
            &mut Monitors::<(), 1>::new(),
        );
        assert_eq!(tick, Ok(()));
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, ()>) -> bool {
        EXIT_CHECKS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        true
    }
}

/// The step is aborted while its action runs: its exit condition is not checked
/// afterwards (semantics 4: nothing of an aborted run advances).
#[test]
fn an_exit_condition_is_not_checked_after_an_abort_during_the_action() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    let step = SEQ.add(SeqConfig::new("step"), Preempted(&SEQ)).unwrap();
    let id = step.id();
    struct Main(rtseq::Seq<Preempted>);
    impl Sequence<()> for Main {
        async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
            let _ = cx.step(&mut self.0).await;
            Ok(())
        }
    }
    let main = SEQ.add(SeqConfig::new("main"), Main(step)).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&SEQ, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(sim.state(id), rtseq::RunningState::Aborted);
    assert_eq!(EXIT_CHECKS.load(std::sync::atomic::Ordering::SeqCst), 0);
}

/// An action finds sequences by name through its context, itself included.
struct Lookup;
impl Sequence<Ctrl> for Lookup {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let own = cx.sequence_by_name("lookup").map(|h| h.id());
        cx.control().set(3, own == Some(cx.id()));
        cx.control().set(4, cx.sequence_by_name("nope").is_none());
        Ok(())
    }
}

#[test]
fn an_action_finds_sequences_by_name() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let lookup = seq.add(SeqConfig::new("lookup"), Lookup).unwrap();
    let id = lookup.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(lookup);
    sim.start(id).unwrap();
    assert_eq!((ctrl.flag(3), ctrl.flag(4)), (true, true));
}

/// A dwell whose duration the action changes between two runs of it: 2 ms, then 5 ms.
struct Dwells {
    dwell: rtseq::Seq<rtseq::Wait>,
}
impl Sequence<Ctrl> for Dwells {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.dwell)
            .await
            .map_err(|_| Failure::App(1))?;
        self.dwell.body_mut().set_duration(Duration::from_millis(5));
        cx.step(&mut self.dwell)
            .await
            .map_err(|_| Failure::App(2))?;
        Ok(())
    }
}

#[test]
fn a_dwell_changed_between_runs_waits_its_new_duration() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(
            SeqConfig::new("dwell"),
            rtseq::Wait::new(Duration::from_millis(2)),
        )
        .unwrap();
    let d = dwell.id();
    let main = seq.add(SeqConfig::new("main"), Dwells { dwell }).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(done.map(ms), Some(7), "{}", show(sim.trace()));
    let ends: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == d && t.to == rtseq::RunningState::Terminated)
        .map(|t| ms(t.time))
        .collect();
    assert_eq!(ends, [2, 7]);
}

/// Settles within 5 ms of its run's time (flag 0: in position), else fails with code 1:
/// the firmware guide's wait with a deadline (section 4).
struct Settle;
impl Sequence<Ctrl> for Settle {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let deadline = cx.run_time() + Duration::from_millis(5);
        cx.wait_until(move |cx| cx.control().flag(0) || cx.run_time() >= deadline)
            .await;
        if !cx.control().flag(0) {
            return Err(Failure::App(1));
        }
        Ok(())
    }
}

/// The wait with a deadline ends when its condition holds, or fails at the deadline of its
/// run's time, which a pause puts off: paused from 2 to 4 ms, the 5 ms window ends at 7 ms.
#[test]
fn a_wait_with_a_deadline_in_its_condition_ends_in_position_or_at_the_deadline_of_run_time() {
    use rtseq::{Outcome, RunningState::*};
    for (in_position_at, pause, ends) in [(Some(3), false, 3), (None, false, 5), (None, true, 7)] {
        let seq: Sequencer<Ctrl, 2> = Sequencer::new();
        let ctrl = Ctrl::default();
        let settle = seq.add(SeqConfig::new("settle"), Settle).unwrap();
        let id = settle.id();
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.lane(settle);
        sim.before_tick(move |t, c| c.set(0, in_position_at.is_some_and(|at| ms(t) >= at)));
        sim.start(id).unwrap();
        if pause {
            sim.run_for(Duration::from_millis(2));
            sim.pause(id).unwrap();
            sim.run_for(Duration::from_millis(2));
            sim.resume(id).unwrap();
        }
        sim.run_until_idle(Duration::from_millis(20)).unwrap();
        let end = sim.trace().last().copied().unwrap();
        let outcome = sim.handle(id).unwrap().last_outcome();
        let want = match in_position_at {
            Some(_) => Outcome::Completed,
            None => Outcome::Failed(Failure::App(1)),
        };
        assert_eq!(
            (ms(end.time), end.to, outcome),
            (ends, Terminated, Some(want)),
            "{}",
            show(sim.trace())
        );
    }
}
