//! Interleavings of lanes of different priorities (and the tick) that the
//! sequencer must survive.

mod common;
use common::*;

use embassy_futures::select::select;
use rtseq::sim::Sim;
use rtseq::Cause::{Abort, Completed, Start};
use rtseq::RunningState::*;
use rtseq::{
    Cause, Cx, Done, Duration, Error, Failure, Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence,
    Sequencer, Wait,
};

/// T dwells 5 ms; a supervisor S of higher priority joins T and starts it again when the
/// join returns. T is aborted at 2 ms: the tick aborts T (and its dwell) and releases S,
/// which runs first (priority 2) and starts T again before T's lane (priority 1) has
/// unwound the aborted run. The aborted run must not run another line of its action
/// (sticky abort, semantics 4): the new run starts from its pre-condition, dwells 5 ms and
/// completes at 7 ms.
#[test]
fn a_restart_by_a_higher_lane_before_the_aborted_lane_unwound_keeps_the_abort_sticky() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let di = dwell.id();
    let t = seq
        .add(SeqConfig::new("T"), Node::of(vec![Op::Wait(dwell)]))
        .unwrap();
    let ti = t.id();
    let s = seq
        .add(
            SeqConfig::new("S"),
            Node::of(vec![Op::Join(ti), Op::Start(ti)]),
        )
        .unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane_with_priority(t, 1);
    sim.lane_with_priority(s, 2);
    sim.start(ti).unwrap();
    sim.start(si).unwrap();
    sim.step(); // 1 ms
    sim.abort(ti).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(50));
    let trace = sim.trace().to_vec();
    let of_t: Vec<_> = trace
        .iter()
        .filter(|r| r.sequence == ti || r.sequence == di)
        .copied()
        .collect();
    drop(sim);
    let returned: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.ms, r.seq, r.line, r.result))
        .collect();
    // S's start of T is accepted: T's new run starts from its pre-condition once T's
    // lane has unwound the aborted run (run counts: the old run's clearance is `Aborted`).
    assert_eq!(
        of_t,
        [
            tr(0, ti, Idle, Running, Start),
            tr(0, di, Idle, Running, Start),
            tr(2, di, Running, Aborting, Abort),
            tr(2, di, Aborting, Aborted, Abort),
            tr(2, ti, Running, Aborting, Abort),
            tr(2, ti, Aborting, Aborted, Abort),
            tr(2, ti, Aborted, Running, Start),
            tr(2, di, Aborted, Running, Start),
            tr(7, di, Running, Terminated, Completed),
            tr(7, ti, Running, Terminated, Completed),
        ],
        "{}",
        show(&trace)
    );
    assert_eq!(idle.map(ms), Some(7));
    // The first run's line 0 at 0 ms, the new run's at 2 ms: the aborted run's action
    // never saw its dwell's result.
    assert_eq!(ctrl.lines_of(ti), [(0, 0), (2, 0), (7, END)]);
    assert_eq!(
        returned,
        [
            (2, si, 0, Err(Failure::Aborted(Abort))),
            (2, si, 1, Ok(Done::Completed)),
            (7, ti, 0, Ok(Done::Completed)),
        ]
    );
}

/// Joins `target`, then runs `starter` (which starts `target` again, non-blocking, and
/// dwells) in a race it loses at once: `starter`'s run is dropped, and the start it made is
/// aborted with it (`Cause::Dropped`) before `target`'s lane took that start.
struct JoinThenStartAndDrop {
    target: SeqId,
    starter: Seq<Node>,
}

impl Sequence<Ctrl> for JoinThenStartAndDrop {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let joined = cx.join(self.target).await;
        cx.control().returned.borrow_mut().push(Returned {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line: 0,
            result: joined.map_err(Failure::from).and_then(Outcome::done),
        });
        let _ = select(Box::pin(cx.run(&mut self.starter)), core::future::ready(())).await;
        Ok(())
    }
}

/// T's run 1 completes at 5 ms and releases its joiners X (priority 3) and J (priority 2).
/// X runs first, starts T again (run 2, in T's lane of priority 1) from a child whose run
/// it then drops: run 2 is aborted (`Dropped`) before T's lane took its start. J, polled
/// next, joined run 1, whose outcome the control block no longer holds: the join is
/// `Err(OutcomeLost)` (semantics 14), never run 2's `Aborted(Dropped)`.
#[test]
fn a_join_never_gets_the_outcome_of_a_later_run_aborted_before_its_lane_took_it() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let t = seq
        .add(SeqConfig::new("T"), Node::of(vec![Op::Wait(dwell)]))
        .unwrap();
    let ti = t.id();
    let long = seq
        .add(SeqConfig::new("long"), Wait::new(Duration::from_millis(50)))
        .unwrap();
    let starter = seq
        .add(
            SeqConfig::new("H"),
            Node::of(vec![Op::Start(ti), Op::Wait(long)]),
        )
        .unwrap();
    let hi = starter.id();
    let x = seq
        .add(
            SeqConfig::new("X"),
            JoinThenStartAndDrop {
                target: ti,
                starter,
            },
        )
        .unwrap();
    let j = seq
        .add(SeqConfig::new("J"), Node::of(vec![Op::Join(ti)]))
        .unwrap();
    let (xi, ji) = (x.id(), j.id());
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane_with_priority(t, 1);
    sim.lane_with_priority(j, 2);
    sim.lane_with_priority(x, 3);
    sim.start(ti).unwrap();
    sim.start(ji).unwrap();
    sim.start(xi).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)).map(ms),
        Some(5)
    );
    let runs_of_t: Vec<_> = sim
        .trace()
        .iter()
        .filter(|r| r.sequence == ti || r.sequence == hi)
        .copied()
        .collect();
    assert_eq!(
        runs_of_t,
        [
            tr(0, ti, Idle, Running, Start),
            tr(5, ti, Running, Terminated, Completed),
            tr(5, hi, Idle, Running, Start),
            tr(5, ti, Terminated, Running, Start),
            tr(5, ti, Running, Aborting, Cause::Dropped),
            tr(5, ti, Aborting, Aborted, Cause::Dropped),
            tr(5, hi, Running, Aborting, Cause::Dropped),
            tr(5, hi, Aborting, Aborted, Cause::Dropped),
        ],
        "{}",
        show(sim.trace())
    );
    drop(sim);
    let joins: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| (r.seq == xi || r.seq == ji) && r.line == 0)
        .map(|r| (r.ms, r.seq, r.result))
        .collect();
    assert_eq!(
        joins,
        [
            (5, xi, Ok(Done::Completed)),
            (5, ji, Err(Failure::NotStarted(Error::OutcomeLost(ti)))),
        ]
    );
}
