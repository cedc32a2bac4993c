//! Futures combined inside actions, as an application combines them: joins in `join` and
//! `select`, a polled wait leaked, and an action holding every kind of
//! rtseq future (a blocking run, a step, polled waits, joins, a `Scoped`) dropped by its
//! lane or by a restart mid-way. Run under Miri too (`./x miri`, Stacked and Tree
//! Borrows): the dropped actions are self-referential and dropped in place.
//!
//! An action's futures keep no waker of their own: they are woken through their lane, whose
//! run keeps the task's waker. A combinator inside an action must poll every branch when
//! the task is woken (embassy-futures' `join` and `select` do); one that gives each branch
//! a waker of its own and polls only the woken ones (`FuturesUnordered`) misses wake-ups
//! (`Cx` says so). Polled from a condition method, they leave the lane's waker alone, and
//! a blocking run asked for there is refused.

use std::cell::Cell;
use std::future::Future;
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, Ordering::SeqCst};
use std::task::{Context, Poll, Waker};

use embassy_futures::join::join;
use embassy_futures::select::select;
use embassy_futures::yield_now;
use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Error, Failure, Instant, Monitor, Monitors, Outcome, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Wait,
};

#[derive(Default)]
struct Ctrl {
    /// What a join returned, and when (µs).
    got: Cell<Option<(u64, Result<Outcome, Error>)>>,
}

/// Ends at its first poll.
struct Quick;
impl Sequence<Ctrl> for Quick {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }
}

/// Ends after its dwell.
struct Slow(Seq<Wait>);
impl Sequence<Ctrl> for Slow {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

/// What [`j_beside_slow_y`] or [`j_alone`] saw.
struct Seen {
    /// When the simulator came to rest (µs).
    rest: Option<u64>,
    /// When Y and J ended (µs).
    ended: (Option<u64>, Option<u64>),
    /// J's lane polls.
    j_polls: usize,
    /// What J got from its join, and when.
    got: Option<(u64, Result<Outcome, Error>)>,
}

/// Y, which ends after a dwell of `dwell_ms`, and J, made with Y's id, each in a lane
/// (J's registered first, so polled first at a tick); J is started and the simulator
/// runs until it comes to rest (at most 50 ms).
fn j_beside_slow_y<S: Sequence<Ctrl>>(dwell_ms: u64, j: impl FnOnce(SeqId) -> S) -> Seen {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(
            SeqConfig::new("dwell"),
            Wait::new(Duration::from_millis(dwell_ms)),
        )
        .unwrap();
    let y = seq.add(SeqConfig::new("Y"), Slow(dwell)).unwrap();
    let yi = y.id();
    let j = seq.add(SeqConfig::new("J"), j(yi)).unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(j);
    sim.lane(y);
    sim.start(ji).unwrap();
    let rest = sim.run_until_idle(Duration::from_millis(50));
    let ended = |id| {
        sim.trace()
            .iter()
            .find(|t| t.sequence == id && t.to == Terminated)
            .map(|t| t.time.as_ticks())
    };
    Seen {
        rest: rest.map(|t| t.as_ticks()),
        ended: (ended(yi), ended(ji)),
        j_polls: sim.lane_polls()[0],
        got: ctrl.got.take(),
    }
}

/// J alone in its lane: started, then run until the simulator comes to rest (at most 50
/// ms). `ended.0` is `None` (there is no Y).
fn j_alone<S: Sequence<Ctrl>>(j: S) -> Seen {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let j = seq.add(SeqConfig::new("J"), j).unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(j);
    sim.start(ji).unwrap();
    let rest = sim.run_until_idle(Duration::from_millis(50));
    let ended = sim
        .trace()
        .iter()
        .find(|t| t.sequence == ji && t.to == Terminated)
        .map(|t| t.time.as_ticks());
    Seen {
        rest: rest.map(|t| t.as_ticks()),
        ended: (None, ended),
        j_polls: sim.lane_polls()[0],
        got: ctrl.got.take(),
    }
}

/// Waits for Y; beside it, peeks once whether X is over (a `select` of a `yield_now` and
/// a join of X, which the `yield_now` wins and so drops the join).
struct Peek {
    x: SeqId,
    y: SeqId,
}
impl Sequence<Ctrl> for Peek {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.x)?;
        cx.start(self.y)?;
        let (y, _) = join(cx.join(self.y), select(yield_now(), cx.join(self.x))).await;
        cx.control().got.set(Some((cx.now().as_ticks(), y)));
        Ok(())
    }
}

/// X ends at once, which wakes J (its join of X is pending beside the join of Y); J's
/// join of X is then dropped by the `select`. That drop must not take the join of Y's
/// wait with it: Y's end at 5 ms wakes J, whose join returns then.
#[test]
fn a_dropped_join_leaves_a_pending_join_of_the_same_action_waiting() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq.add(SeqConfig::new("X"), Quick).unwrap();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let y = seq.add(SeqConfig::new("Y"), Slow(dwell)).unwrap();
    let (xi, yi) = (x.id(), y.id());
    let j = seq.add(SeqConfig::new("J"), Peek { x: xi, y: yi }).unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(j);
    sim.lane(x);
    sim.lane(y);
    sim.start(ji).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(Instant::from_ticks(5_000))
    );
    assert_eq!((sim.state(xi), sim.state(yi)), (Terminated, Terminated));
    assert_eq!(sim.state(ji), Terminated);
    assert_eq!(ctrl.got.get(), Some((5_000, Ok(Outcome::Completed))));
}

/// Joins Y; beside it, a join of Y with a timeout (a `select` of a second join of Y
/// against a polled wait, which the wait wins at 2 ms).
struct TimedJoin {
    y: SeqId,
}
impl Sequence<Ctrl> for TimedJoin {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.y)?;
        let timed = select(
            cx.join(self.y),
            cx.wait_until(|cx| cx.now().as_ticks() >= 2_000),
        );
        let (y, _) = join(cx.join(self.y), timed).await;
        cx.control().got.set(Some((cx.now().as_ticks(), y)));
        Ok(())
    }
}

/// The join with a timeout gives up at 2 ms; its drop leaves the other join of the same
/// run waiting, and Y's end at 5 ms returns it.
#[test]
fn a_timed_out_join_leaves_another_join_of_the_same_run_waiting() {
    let seen = j_beside_slow_y(5, |y| TimedJoin { y });
    assert_eq!(seen.rest, Some(5_000));
    assert_eq!(seen.ended, (Some(5_000), Some(5_000)));
    assert_eq!(seen.got, Some((5_000, Ok(Outcome::Completed))));
}

/// Joins `target`, from `from` µs on; records what it got.
struct JoinFrom {
    target: SeqId,
    from: u64,
}
impl Sequence<Ctrl> for JoinFrom {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let from = self.from;
        cx.wait_until(move |cx| cx.now().as_ticks() >= from).await;
        let r = cx.join(self.target).await;
        if cx.id() == SeqId::from_index(1) {
            cx.control().got.set(Some((cx.now().as_ticks(), r)));
        }
        Ok(())
    }
}

/// A (id 0) joins B (id 1). A's abort, requested at 2 ms, is carried out by the tick at 3
/// ms; in that tick B, in a lane above A's (so A's future has not unwound its join yet),
/// joins A. A's join ended with its run: B's join is no cycle, and returns A's outcome.
#[test]
fn a_join_of_a_run_the_tick_just_aborted_is_no_cycle() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let b_id = SeqId::from_index(1);
    let a = seq
        .add(
            SeqConfig::new("A"),
            JoinFrom {
                target: b_id,
                from: 0,
            },
        )
        .unwrap();
    let ai = a.id();
    let b = seq
        .add(
            SeqConfig::new("B"),
            JoinFrom {
                target: ai,
                from: 3_000,
            },
        )
        .unwrap();
    assert_eq!(b.id(), b_id);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane_with_priority(a, 1);
    sim.lane_with_priority(b, 2);
    sim.start(b_id).unwrap();
    sim.start(ai).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.abort(ai).unwrap();
    sim.run_for(Duration::from_millis(6));
    assert_eq!((sim.state(ai), sim.state(b_id)), (Aborted, Terminated));
    assert_eq!(
        ctrl.got.get(),
        Some((3_000, Ok(Outcome::Aborted(Cause::Abort))))
    );
}

/// Its first run leaks a polled wait (`mem::forget`, safe code) after one poll; its
/// second run waits 3 ms in a polled wait.
struct Leaks {
    runs: u32,
}
impl Sequence<Ctrl> for Leaks {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        self.runs += 1;
        if self.runs == 1 {
            let mut w = cx.wait_until(|_| false);
            std::future::poll_fn(|c| {
                let _ = Pin::new(&mut w).poll(c);
                Poll::Ready(())
            })
            .await;
            std::mem::forget(w);
            return Ok(());
        }
        let start = cx.now().as_ticks();
        cx.wait_until(move |c| c.now().as_ticks() >= start + 3_000)
            .await;
        Ok(())
    }
}

/// The wait leaked in the first run is not counted in the second: the second run's
/// polled wait is polled, and the run ends 3 ms after its start.
#[test]
fn a_polled_wait_leaked_in_one_run_does_not_stall_the_next() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let l = seq.add(SeqConfig::new("leaks"), Leaks { runs: 0 }).unwrap();
    let li = l.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(l);
    sim.start(li).unwrap();
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(li), Terminated);
    sim.start(li).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(Instant::from_ticks(5_000))
    );
    assert_eq!(sim.state(li), Terminated);
}

/// Runs a dwell step beside a polled wait that never holds.
struct Inner(Seq<Wait>);
impl Sequence<Ctrl> for Inner {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _ = join(cx.step(&mut self.0), cx.wait_until(|_| false)).await;
        Ok(())
    }
}

/// Holds every kind of rtseq future at once: a blocking run (whose action holds a step
/// and a polled wait), a polled wait, a `Scoped`'s join and a join.
struct Outer {
    inner: Seq<Inner>,
    other: SeqId,
}
impl Sequence<Ctrl> for Outer {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let scoped = cx.start_scoped(self.other)?;
        let _ = join(
            join(cx.run(&mut self.inner), cx.wait_until(|_| false)),
            join(scoped.join(), cx.join(self.other)),
        )
        .await;
        Ok(())
    }
}

/// Outer's lane future is dropped at 3 ms, mid-action: Outer, its blocking child and the
/// scoped child are aborted (`Dropped`), and the scoped child's own lane goes on.
#[test]
fn a_lane_dropped_mid_action_with_every_kind_of_future_aborts_its_runs() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let long = seq
        .add(SeqConfig::new("long"), Wait::new(Duration::from_millis(50)))
        .unwrap();
    let long2 = seq
        .add(
            SeqConfig::new("long2"),
            Wait::new(Duration::from_millis(50)),
        )
        .unwrap();
    let mut other = seq.add(SeqConfig::new("other"), Slow(long2)).unwrap();
    let oi = other.id();
    let inner = seq.add(SeqConfig::new("inner"), Inner(long)).unwrap();
    let ii = inner.id();
    let mut outer = seq
        .add(SeqConfig::new("outer"), Outer { inner, other: oi })
        .unwrap();
    let id = outer.id();
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let mut cx = Context::from_waker(Waker::noop());
    let mut other_lane = pin!(rtseq::lane(&seq, &ctrl, &mut other));
    assert!(other_lane.as_mut().poll(&mut cx).is_pending());
    {
        let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut outer));
        assert!(lane.as_mut().poll(&mut cx).is_pending());
        seq.sequence_by_id(id).unwrap().start().unwrap();
        for ms in 1..=3u64 {
            assert!(lane.as_mut().poll(&mut cx).is_pending());
            assert!(other_lane.as_mut().poll(&mut cx).is_pending());
            seq.tick(Instant::from_ticks(ms * 1_000), &ctrl, &mut monitors)
                .unwrap();
        }
        assert!(lane.as_mut().poll(&mut cx).is_pending());
        assert_eq!(seq.sequence_by_id(ii).unwrap().state(), Running);
    }
    for i in [id, ii, oi] {
        let h = seq.sequence_by_id(i).unwrap();
        assert_eq!(
            (h.state(), h.last_outcome()),
            (Aborted, Some(Outcome::Aborted(Cause::Dropped))),
            "{i:?}"
        );
    }
    assert!(other_lane.as_mut().poll(&mut cx).is_pending());
}

/// As `Outer`, restarted by its `RestartOwner` monitor at 3 ms (the action dropped in
/// place and made again), then run to its end.
struct Restartable {
    inner: Seq<Inner2>,
    other: SeqId,
    fault: &'static AtomicBool,
}
/// A 4 ms dwell beside a polled wait that holds from 1 ms.
struct Inner2(Seq<Wait>);
impl Sequence<Ctrl> for Inner2 {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _ = join(
            cx.step(&mut self.0),
            cx.wait_until(|c| c.now().as_ticks() >= 1_000),
        )
        .await;
        Ok(())
    }
}
impl Sequence<Ctrl> for Restartable {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let scoped = cx.start_scoped(self.other)?;
        let fault = self.fault;
        let _ = join(
            join(
                cx.run(&mut self.inner),
                cx.wait_until(move |_| !fault.load(SeqCst)),
            ),
            select(scoped.join(), cx.join(self.other)),
        )
        .await;
        Ok(())
    }
}

#[test]
fn a_restart_mid_action_with_every_kind_of_future_runs_the_action_again() {
    static FAULT: AtomicBool = AtomicBool::new(false);
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let w4 = seq
        .add(SeqConfig::new("w4"), Wait::new(Duration::from_millis(4)))
        .unwrap();
    let w2 = seq
        .add(SeqConfig::new("w2"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let other = seq.add(SeqConfig::new("other"), Slow(w2)).unwrap();
    let oi = other.id();
    let inner = seq.add(SeqConfig::new("inner"), Inner2(w4)).unwrap();
    let outer = seq
        .add(
            SeqConfig::new("outer"),
            Restartable {
                inner,
                other: oi,
                fault: &FAULT,
            },
        )
        .unwrap();
    let id = outer.id();
    let mut cond = |_: &Ctrl, t: Instant| t.as_ticks() == 3_000;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(
            id,
            Monitor::new("fault", &mut cond, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(outer);
    sim.lane(other);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(30));
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
    let restarts: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == id && t.cause == Cause::Restart)
        .map(|t| t.time.as_ticks())
        .collect();
    // Restarting at 3 ms, running again at once.
    assert_eq!(restarts.first(), Some(&3_000), "{:?}", sim.trace());
    assert!(restarts.iter().all(|&t| t == 3_000), "{:?}", sim.trace());
}

/// Starts Y; waits in two polled waits at once (the first holds from 1 ms, the second
/// from 2 ms), then joins Y.
struct TwoWaitsThenJoin {
    y: SeqId,
}
impl Sequence<Ctrl> for TwoWaitsThenJoin {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.y)?;
        join(
            cx.wait_until(|cx| cx.now().as_ticks() >= 1_000),
            cx.wait_until(|cx| cx.now().as_ticks() >= 2_000),
        )
        .await;
        let y = cx.join(self.y).await;
        cx.control().got.set(Some((cx.now().as_ticks(), y)));
        Ok(())
    }
}

/// J's run asks for polls while one of its polled waits waits, and only then: J's lane
/// is polled as it waits for the start, at the start, and at the polls of 1 and 2 ms (the
/// second wait's end stops the polls); then not until Y ends at 10 ms, which wakes its
/// join. Five polls.
#[test]
fn the_polls_stop_when_the_last_polled_wait_ends() {
    let seen = j_beside_slow_y(10, |y| TwoWaitsThenJoin { y });
    assert_eq!(seen.rest, Some(10_000));
    assert_eq!(seen.ended, (Some(10_000), Some(10_000)));
    assert_eq!(seen.got, Some((10_000, Ok(Outcome::Completed))));
    assert_eq!(seen.j_polls, 5);
}

/// Starts Y; its exit condition asks whether Y is over by polling a join of Y once (a
/// misuse that `Cx` warns of: its futures are the action's).
struct PeeksInItsCondition {
    y: SeqId,
}
impl Sequence<Ctrl> for PeeksInItsCondition {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.y)?;
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        embassy_futures::poll_once(cx.join(self.y)).is_ready()
    }
}

/// A join polled once from J's exit condition (with a waker of its own, which does
/// nothing) leaves J's lane its waker: J's lane is polled at every due poll, and J ends at
/// the first one after Y's end at 5 ms, at 6 ms (at 5 ms J's lane, registered first, is
/// polled before Y's). Before, the join kept its do-nothing waker for J's lane, and J
/// waited for good.
#[test]
fn a_join_polled_from_a_condition_leaves_the_lane_its_wake_ups() {
    let seen = j_beside_slow_y(5, |y| PeeksInItsCondition { y });
    assert_eq!(seen.rest, Some(6_000));
    assert_eq!(seen.ended, (Some(5_000), Some(6_000)));
}

/// Its exit condition polls a polled wait once (a misuse, as above), and holds from 3 ms.
struct WaitsInItsCondition;
impl Sequence<Ctrl> for WaitsInItsCondition {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        let _ = embassy_futures::poll_once(cx.wait_until(|_| false));
        cx.now().as_ticks() >= 3_000
    }
}

/// A polled wait polled from the exit condition is not the action's: it waits and counts
/// nothing, so the run still waits for the polls of its exit condition and ends at 3 ms.
/// Before, the wait's drop ended the run's poll wait, and the run waited for good.
#[test]
fn a_polled_wait_polled_from_a_condition_leaves_the_exit_polls_alone() {
    let seen = j_alone(WaitsInItsCondition);
    assert_eq!((seen.rest, seen.ended.1), (Some(3_000), Some(3_000)));
}

/// Makes a polled wait and drops it unpolled, while another polled wait, which holds from
/// 3 ms, is under way.
struct DropsAnUnpolledWait;
impl Sequence<Ctrl> for DropsAnUnpolledWait {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let made = cx.wait_until(|_| false);
        join(
            cx.wait_until(|cx| cx.now().as_ticks() >= 3_000),
            async move {
                yield_now().await;
                drop(made);
            },
        )
        .await;
        Ok(())
    }
}

/// A polled wait dropped before its first poll was never counted, and its drop counts
/// nothing off: the wait under way still has its polls, and the run ends at 3 ms.
#[test]
fn a_polled_wait_dropped_unpolled_leaves_the_polls_of_another() {
    let seen = j_alone(DropsAnUnpolledWait);
    assert_eq!((seen.rest, seen.ended.1), (Some(3_000), Some(3_000)));
}

/// Its exit condition polls a blocking run of its step once (a misuse, as above), records
/// what it got when it was refused, and holds from 2 ms.
struct RunsInItsCondition(Seq<Wait>);
impl Sequence<Ctrl> for RunsInItsCondition {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        let polled = embassy_futures::poll_once(cx.step(&mut self.0));
        if let Poll::Ready(Err(Failure::NotStarted(e))) = polled {
            cx.control().got.set(Some((cx.now().as_ticks(), Err(e))));
        }
        cx.now().as_ticks() >= 2_000
    }
}

/// A blocking run polled once from J's exit condition is refused at that poll
/// (`OutsideAction`), at each poll of the condition (0, 1 and 2 ms): the step never
/// starts. J's lane keeps its waker, and J ends at 2 ms. (Before session 46 the step's
/// run kept the do-nothing waker as the lane's, and J waited for good; in session 46 the
/// step started and its drop aborted it at each poll.)
#[test]
fn a_blocking_run_polled_from_a_condition_is_refused() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq
        .add(SeqConfig::new("step"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let si = step.id();
    let j = seq
        .add(SeqConfig::new("J"), RunsInItsCondition(step))
        .unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(j);
    sim.start(ji).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(2_000))
    );
    assert!(sim.trace().iter().all(|t| t.sequence != si));
    assert_eq!(sim.state(si), Idle);
    assert_eq!(ctrl.got.get(), Some((2_000, Err(Error::OutsideAction(si)))));
    assert_eq!(sim.state(ji), Terminated);
}

/// Waits in two polled waits at once whose conditions hold already; records when they
/// both returned.
struct TwoWaitsThatHold;
impl Sequence<Ctrl> for TwoWaitsThatHold {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        join(cx.wait_until(|_| true), cx.wait_until(|_| true)).await;
        let now = cx.now().as_ticks();
        cx.control().got.set(Some((now, Ok(Outcome::Completed))));
        Ok(())
    }
}

/// Both polled waits are checked in the action's first poll (the first one's count does
/// not take the action's mark from the second): the action goes on at 0 ms, and the run
/// ends there, after two lane polls (the wait for the start, the start).
#[test]
fn two_polled_waits_that_hold_both_return_in_the_first_poll() {
    let seen = j_alone(TwoWaitsThatHold);
    assert_eq!((seen.rest, seen.ended.1), (Some(0), Some(0)));
    assert_eq!(seen.got, Some((0, Ok(Outcome::Completed))));
    assert_eq!(seen.j_polls, 2);
}
