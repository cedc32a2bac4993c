//! Review 28: interleavings of lanes of different priorities (and the tick) that the
//! sequencer must survive.

mod common;
use common::*;

use rtseq::sim::Sim;
use rtseq::Cause::{Abort, Completed, Start};
use rtseq::RunningState::*;
use rtseq::{Done, Duration, Error, Failure, Monitors, SeqConfig, Sequencer, Wait};

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
    // Either fix is exact: S's start of T is accepted and T's new run starts from its
    // pre-condition (T is `Aborted`, which may be started), or it is refused until T's lane
    // has unwound the aborted run. In neither may the aborted action run on.
    let restarted = returned.contains(&(2, si, 1, Ok(Done::Completed)));
    if restarted {
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
    } else {
        assert_eq!(
            of_t,
            [
                tr(0, ti, Idle, Running, Start),
                tr(0, di, Idle, Running, Start),
                tr(2, di, Running, Aborting, Abort),
                tr(2, di, Aborting, Aborted, Abort),
                tr(2, ti, Running, Aborting, Abort),
                tr(2, ti, Aborting, Aborted, Abort),
            ],
            "{}",
            show(&trace)
        );
        assert_eq!(idle.map(ms), Some(2));
        assert_eq!(ctrl.lines_of(ti), [(0, 0)]);
        assert_eq!(
            returned,
            [
                (2, si, 0, Err(Failure::Aborted(Abort))),
                (
                    2,
                    si,
                    1,
                    Err(Failure::NotStarted(Error::AlreadyRunning(ti)))
                ),
            ]
        );
    }
}
