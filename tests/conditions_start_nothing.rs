//! A condition looks, an action acts: every start made with a context from a pre- or
//! exit condition, or a polled wait's condition (`Cx::run`, `Cx::step`, `Cx::start`,
//! `Cx::start_scoped`), is refused with `Error::OutsideAction`, and the sequence it names
//! never starts. The same starts from the action go ahead; a start from the `Drop` of
//! something the action held goes ahead only where the action ends in its poll.

use std::cell::RefCell;
use std::pin::pin;
use std::task::Poll;

use embassy_futures::poll_once;
use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Done, Duration, Error, Failure, Instant, Monitor, Monitors, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Step, Wait,
};

/// A start's result: when (µs), where it was made, and what it returned.
type Got = (u64, &'static str, Result<(), Failure>);

/// What each start returned.
#[derive(Default)]
struct Ctrl {
    got: RefCell<Vec<Got>>,
}

impl Ctrl {
    fn note<T, E: Into<Failure>>(
        &self,
        cx: &Cx<'_, Ctrl>,
        what: &'static str,
        result: Result<T, E>,
    ) {
        self.got.borrow_mut().push((
            cx.now().as_ticks(),
            what,
            result.map(|_| ()).map_err(Into::into),
        ));
    }
}

/// What a blocking run's first poll gave: `Ok` while it runs.
fn started(polled: Poll<Result<Done, Failure>>) -> Result<Done, Failure> {
    match polled {
        Poll::Ready(done) => done,
        Poll::Pending => Ok(Done::Completed),
    }
}

/// What a run of a sequence around a 2 ms dwell step gave ([`around_a_dwell`]).
struct AroundADwell {
    /// When the simulator went idle (µs).
    idle: Option<u64>,
    /// What the starts gave.
    got: Vec<Got>,
    /// The dwell step's id and its transitions: (µs, state, cause).
    dwell: SeqId,
    dwell_trace: Vec<(u64, rtseq::RunningState, Cause)>,
    /// The sequence's state at the end.
    state: rtseq::RunningState,
}

/// Runs the sequence `make` builds around a 2 ms dwell step, in its lane, until idle.
fn around_a_dwell<S: Sequence<Ctrl> + 'static>(make: impl FnOnce(Seq<Wait>) -> S) -> AroundADwell {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let di = dwell.id();
    let outer = seq.add(SeqConfig::new("outer"), make(dwell)).unwrap();
    let id = outer.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(outer);
    sim.start(id).unwrap();
    let idle = sim
        .run_until_idle(Duration::from_millis(50))
        .map(|t| t.as_ticks());
    let dwell_trace = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == di)
        .map(|t| (t.time.as_ticks(), t.to, t.cause))
        .collect();
    let state = sim.state(id);
    drop(sim);
    AroundADwell {
        idle,
        got: ctrl.got.take(),
        dwell: di,
        dwell_trace,
        state,
    }
}

/// Ends at once.
struct Quick;
impl Sequence<Ctrl> for Quick {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }
}

/// Tries every kind of start in its pre-condition (which then holds) and its exit
/// condition (which holds from 1 ms); its action starts `lane` non-blocking and runs
/// `dwell` blocking.
struct Tries {
    lane: SeqId,
    dwell: Seq<Wait>,
    quick: Seq<Quick>,
}

impl Tries {
    fn try_all(&mut self, cx: &Cx<'_, Ctrl>, at: &'static str) {
        let c = cx.control();
        c.note(cx, at, cx.start(self.lane));
        c.note(cx, at, cx.start_scoped(self.lane));
        c.note(cx, at, started(poll_once(cx.step(&mut self.dwell))));
        c.note(cx, at, started(poll_once(cx.run(&mut self.quick))));
    }
}

impl Sequence<Ctrl> for Tries {
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.try_all(cx, "pre");
        true
    }

    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx, "action", cx.start(self.lane));
        let done = cx.step(&mut self.dwell).await;
        cx.control().note(cx, "action", done);
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.try_all(cx, "exit");
        cx.now().as_ticks() >= 3_000
    }
}

/// Each start from a condition is refused, naming the sequence it asked for; nothing it
/// named runs then. The action's start of the lane and its blocking run go ahead: the
/// lane runs at 0 ms, the dwell from 0 to 2 ms. The exit condition is checked at 2 ms
/// (refused four times) and 3 ms (again), when it holds.
#[test]
fn starts_from_conditions_are_refused_and_start_nothing() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let lane = seq.add(SeqConfig::new("lane"), Quick).unwrap();
    let li = lane.id();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let di = dwell.id();
    let quick = seq.add(SeqConfig::new("quick"), Quick).unwrap();
    let qi = quick.id();
    let tries = Tries {
        lane: li,
        dwell,
        quick,
    };
    let t = seq.add(SeqConfig::new("tries"), tries).unwrap();
    let ti = t.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(t);
    sim.lane(lane);
    sim.start(ti).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(3_000))
    );
    let refused = |at, what| {
        [
            (at, what, Err(Failure::NotStarted(Error::OutsideAction(li)))),
            (at, what, Err(Failure::NotStarted(Error::OutsideAction(li)))),
            (at, what, Err(Failure::NotStarted(Error::OutsideAction(di)))),
            (at, what, Err(Failure::NotStarted(Error::OutsideAction(qi)))),
        ]
    };
    let mut expected = refused(0, "pre").to_vec();
    expected.extend([(0, "action", Ok(())), (2_000, "action", Ok(()))]);
    expected.extend(refused(2_000, "exit"));
    expected.extend(refused(3_000, "exit"));
    assert_eq!(*ctrl.got.borrow(), expected);
    let of = |id| -> Vec<_> {
        sim.trace()
            .iter()
            .filter(|t| t.sequence == id)
            .map(|t| (t.time.as_ticks(), t.to, t.cause))
            .collect()
    };
    assert_eq!(
        of(li),
        [
            (0, Running, Cause::Start),
            (0, Terminated, Cause::Completed)
        ]
    );
    assert_eq!(
        of(di),
        [
            (0, Running, Cause::Start),
            (2_000, Terminated, Cause::Completed)
        ]
    );
    assert!(of(qi).is_empty());
    assert_eq!(Error::OutsideAction(li).reason(), "start outside an action");
    assert_eq!(
        of(ti),
        [
            (0, Running, Cause::Start),
            (3_000, Terminated, Cause::Completed)
        ]
    );
}

/// Asks for a blocking run of its step in its pre-condition and drops it unpolled; its
/// action then runs the same step.
struct AsksAndDrops(Seq<Wait>);
impl Sequence<Ctrl> for AsksAndDrops {
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        drop(cx.step(&mut self.0));
        true
    }

    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let done = cx.step(&mut self.0).await;
        cx.control().note(cx, "action", done);
        Ok(())
    }
}

/// A refused blocking run never polled leaves nothing behind: the action's run of the same
/// step waits its 2 ms and completes.
#[test]
fn a_refused_run_never_polled_leaves_the_next_run_alone() {
    let ran = around_a_dwell(AsksAndDrops);
    assert_eq!(ran.idle, Some(2_000));
    assert_eq!(ran.got, [(2_000, "action", Ok(()))]);
    assert_eq!(ran.state, Terminated);
}

/// Waits in its action until 2 ms with a polled wait whose condition tries a blocking run
/// of `step` and a start of `lane` at each check.
struct TriesInAWait {
    lane: SeqId,
    step: Seq<Wait>,
}
impl Sequence<Ctrl> for TriesInAWait {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let (lane, step) = (self.lane, &mut self.step);
        cx.wait_until(|cx| {
            cx.control().note(cx, "wait", cx.start(lane));
            cx.control()
                .note(cx, "wait", started(poll_once(cx.step(&mut *step))));
            cx.now().as_ticks() >= 2_000
        })
        .await;
        cx.control().note(cx, "action", cx.start(lane));
        Ok(())
    }
}

/// A polled wait's condition is a condition too: checked inside the action's poll, it
/// starts nothing (0, 1 and 2 ms), and the action's start after the wait goes ahead.
#[test]
fn a_polled_wait_condition_starts_nothing() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let lane = seq.add(SeqConfig::new("lane"), Quick).unwrap();
    let li = lane.id();
    let step = seq
        .add(SeqConfig::new("step"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let si = step.id();
    let a = seq
        .add(SeqConfig::new("A"), TriesInAWait { lane: li, step })
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.lane(lane);
    sim.start(ai).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(2_000))
    );
    let refused = |at| {
        [
            (
                at,
                "wait",
                Err(Failure::NotStarted(Error::OutsideAction(li))),
            ),
            (
                at,
                "wait",
                Err(Failure::NotStarted(Error::OutsideAction(si))),
            ),
        ]
    };
    let mut expected = [refused(0), refused(1_000), refused(2_000)].concat();
    expected.push((2_000, "action", Ok(())));
    assert_eq!(*ctrl.got.borrow(), expected);
    assert!(sim.trace().iter().all(|t| t.sequence != si));
    assert_eq!(sim.state(li), Terminated);
}

/// Makes a blocking run of its step in its action and polls it first from a polled wait's
/// condition; then makes one in a polled wait's condition and awaits it in its action.
struct MadeHerePolledThere(Seq<Wait>);
impl Sequence<Ctrl> for MadeHerePolledThere {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        {
            let mut run = pin!(cx.step(&mut self.0));
            cx.wait_until(|cx| {
                let polled = started(poll_once(run.as_mut()));
                cx.control().note(cx, "made in the action", polled);
                true
            })
            .await;
        }
        let (mut step, mut made) = (Some(&mut self.0), None);
        cx.wait_until(|_| {
            made = step.take().map(|s| cx.step(s));
            true
        })
        .await;
        if let Some(run) = made {
            let done = run.await;
            cx.control().note(cx, "made in a wait", done);
        }
        Ok(())
    }
}

/// A blocking run starts where it is first polled: made in the action and first polled
/// from a polled wait's condition, it is refused there and its step does not start; made
/// in a condition and awaited in the action, it runs (0 to 2 ms). (Before session 48 a run
/// was judged where it was made: the first started inside the condition and was aborted
/// when it was dropped, the second was refused.)
#[test]
fn a_blocking_run_starts_where_it_is_first_polled() {
    let ran = around_a_dwell(MadeHerePolledThere);
    assert_eq!(ran.idle, Some(2_000));
    let refused = Err(Failure::NotStarted(Error::OutsideAction(ran.dwell)));
    assert_eq!(
        ran.got,
        [
            (0, "made in the action", refused),
            (2_000, "made in a wait", Ok(())),
        ]
    );
    assert_eq!(
        ran.dwell_trace,
        [
            (0, Running, Cause::Start),
            (2_000, Terminated, Cause::Completed)
        ]
    );
    assert_eq!(ran.state, Terminated);
}

/// Polls a blocking run of its step first from a polled wait's condition (refused), then
/// awaits the same future in its action.
struct RefusedThenAwaited(Seq<Wait>);
impl Sequence<Ctrl> for RefusedThenAwaited {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let mut run = pin!(cx.step(&mut self.0));
        cx.wait_until(|cx| {
            let polled = started(poll_once(run.as_mut()));
            cx.control().note(cx, "wait", polled);
            true
        })
        .await;
        let again = run.await;
        cx.control().note(cx, "action", again);
        Ok(())
    }
}

/// A refused run polled again gives its refusal again: the action goes on with it at
/// 0 ms, and the step never starts. (Before session 48 a second poll waited for good.)
#[test]
fn a_refused_run_polled_again_gives_its_refusal_again() {
    let ran = around_a_dwell(RefusedThenAwaited);
    assert_eq!(ran.idle, Some(0));
    let refused = Err(Failure::NotStarted(Error::OutsideAction(ran.dwell)));
    assert_eq!(ran.got, [(0, "wait", refused), (0, "action", refused)]);
    assert!(ran.dwell_trace.is_empty());
    assert_eq!(ran.state, Terminated);
}

/// Awaits a blocking run of its step, then polls the same future from a polled wait's
/// condition.
struct AwaitsThenLooks(Seq<Wait>);
impl Sequence<Ctrl> for AwaitsThenLooks {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let mut run = pin!(cx.step(&mut self.0));
        let done = run.as_mut().await;
        cx.control().note(cx, "action", done);
        cx.wait_until(|cx| {
            if let Poll::Ready(again) = poll_once(run.as_mut()) {
                cx.control().note(cx, "wait", again);
            }
            true
        })
        .await;
        Ok(())
    }
}

/// A run that gave its result gives it again when a condition polls it (it does not move
/// there, but it has nothing left to do).
#[test]
fn a_run_polled_from_a_condition_after_its_result_gives_it_again() {
    let ran = around_a_dwell(AwaitsThenLooks);
    assert_eq!(ran.idle, Some(2_000));
    assert_eq!(
        ran.got,
        [(2_000, "action", Ok(())), (2_000, "wait", Ok(()))]
    );
    assert_eq!(ran.state, Terminated);
}

/// A step that records its command; its exit condition holds from 4 ms.
struct Commands;
impl Step<Ctrl> for Commands {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx, "command", Ok::<(), Failure>(()));
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.now().as_ticks() >= 4_000
    }
}

/// Starts a blocking run of its step in its action, polls it from a polled wait's
/// condition until 3 ms, then awaits it in its action.
struct PollsFromAWait(Seq<Commands>);
impl Sequence<Ctrl> for PollsFromAWait {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let mut run = pin!(cx.step(&mut self.0));
        let first = poll_once(run.as_mut());
        cx.control().note(cx, "action", started(first));
        cx.wait_until(|cx| {
            if let Poll::Ready(done) = poll_once(run.as_mut()) {
                cx.control().note(cx, "wait", done);
            }
            cx.now().as_ticks() >= 3_000
        })
        .await;
        let done = run.await;
        cx.control().note(cx, "action", done);
        Ok(())
    }
}

/// A blocking run polled from a condition after it started does not advance there (what
/// it would run, its step's command, would run inside the condition): restarted by its
/// monitor at 2 ms, the step takes up the restart and gives its command again only at
/// 3 ms, when the action awaits it, and ends at 4 ms. (Until session 48 the command ran
/// at 2 ms, inside the wait's condition.)
#[test]
fn a_run_polled_from_a_condition_after_it_started_does_not_advance_there() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("step"), Commands).unwrap();
    let si = step.id();
    let p = seq.add(SeqConfig::new("P"), PollsFromAWait(step)).unwrap();
    let pi = p.id();
    let mut kick = |_: &Ctrl, t: Instant| t.as_ticks() == 2_000;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(si, Monitor::new("kick", &mut kick, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(p);
    sim.start(pi).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(4_000))
    );
    assert_eq!(
        *ctrl.got.borrow(),
        [
            (0, "command", Ok(())),
            (0, "action", Ok(())),
            (3_000, "command", Ok(())),
            (4_000, "action", Ok(()))
        ]
    );
    let trace: Vec<_> = sim
        .trace()
        .iter()
        .map(|t| (t.time.as_ticks(), t.sequence, t.to, t.cause))
        .collect();
    assert_eq!(
        trace,
        [
            (0, pi, Running, Cause::Start),
            (0, si, Running, Cause::Start),
            (2_000, si, Restarting, Cause::Monitor(m)),
            (3_000, si, Running, Cause::Restart),
            (4_000, si, Terminated, Cause::Completed),
            (4_000, pi, Terminated, Cause::Completed),
        ]
    );
}

/// Dwells 1 ms, then runs its command step blocking.
struct DwellsThenCommands {
    dwell: Seq<Wait>,
    command: Seq<Commands>,
}
impl Sequence<Ctrl> for DwellsThenCommands {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.dwell).await?;
        cx.step(&mut self.command).await?;
        Ok(())
    }
}

/// Starts B blocking in its action, polls it from a polled wait's condition until 3 ms,
/// then awaits it.
struct Outer(Seq<DwellsThenCommands>);
impl Sequence<Ctrl> for Outer {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let mut b = pin!(cx.run(&mut self.0));
        let first = poll_once(b.as_mut());
        cx.control().note(cx, "action", started(first));
        cx.wait_until(|cx| {
            let _ = poll_once(b.as_mut());
            cx.now().as_ticks() >= 3_000
        })
        .await;
        let done = b.await;
        cx.control().note(cx, "action", done);
        Ok(())
    }
}

/// Nor does a nested run: B, polled from A's condition after it started, does not go on
/// from its dwell (over at 1 ms) to its command step until A's action awaits it at 3 ms.
/// (Until session 48 B's action ran inside A's condition and started the step there.)
#[test]
fn a_nested_run_does_not_start_its_step_inside_an_outer_condition() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let command = seq.add(SeqConfig::new("command"), Commands).unwrap();
    let ci = command.id();
    let b = seq
        .add(SeqConfig::new("B"), DwellsThenCommands { dwell, command })
        .unwrap();
    let a = seq.add(SeqConfig::new("A"), Outer(b)).unwrap();
    let ai = a.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(4_000))
    );
    assert_eq!(
        *ctrl.got.borrow(),
        [
            (0, "action", Ok(())),
            (3_000, "command", Ok(())),
            (4_000, "action", Ok(()))
        ]
    );
    let starts: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == ci)
        .map(|t| (t.time.as_ticks(), t.to))
        .collect();
    assert_eq!(starts, [(3_000, Running), (4_000, Terminated)]);
}

/// Starts `safe` from its `Drop`, through the context it holds: a start on the way out.
struct StartOnDrop<'c, 'a> {
    cx: &'c Cx<'a, Ctrl>,
    safe: SeqId,
}
impl Drop for StartOnDrop<'_, '_> {
    fn drop(&mut self) {
        let cx = self.cx;
        cx.control().note(cx, "drop", cx.start(self.safe));
    }
}

/// Holds a [`StartOnDrop`] while it runs its step.
struct Guarded {
    safe: SeqId,
    step: Seq<Wait>,
}
impl Sequence<Ctrl> for Guarded {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _guard = StartOnDrop {
            cx,
            safe: self.safe,
        };
        cx.step(&mut self.step).await?;
        Ok(())
    }
}

/// G holds a guard that starts `safe` when it is dropped, and runs a 3 ms step; it is
/// aborted at 2 ms when `abort`. Returns what the guard's start returned, and safe's
/// state at the end.
fn guard_dropped(abort: bool) -> (Vec<Got>, rtseq::RunningState) {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let safe = seq.add(SeqConfig::new("safe"), Quick).unwrap();
    let si = safe.id();
    let step = seq
        .add(SeqConfig::new("step"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let g = seq
        .add(SeqConfig::new("G"), Guarded { safe: si, step })
        .unwrap();
    let gi = g.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(g);
    sim.lane(safe);
    sim.start(gi).unwrap();
    sim.run_for(Duration::from_millis(2));
    if abort {
        sim.handle(gi).unwrap().abort().unwrap();
    }
    assert!(sim.run_until_idle(Duration::from_millis(50)).is_some());
    let state = sim.state(si);
    drop(sim);
    (ctrl.got.take(), state)
}

/// A `Drop` of something an action held runs where the action is dropped: in its poll
/// when it completes (3 ms: the start goes ahead), outside it when it is aborted (the
/// tick at 3 ms drops it: `OutsideAction`, nothing starts; the abort's cleanup hook is the
/// place for a safe stop).
#[test]
fn a_start_from_a_drop_goes_ahead_only_inside_the_action() {
    let (got, safe) = guard_dropped(false);
    assert_eq!((got, safe), (vec![(3_000, "drop", Ok(()))], Terminated));
    let (got, safe) = guard_dropped(true);
    let refused = Err(Failure::NotStarted(Error::OutsideAction(
        SeqId::from_index(0),
    )));
    assert_eq!((got, safe), (vec![(3_000, "drop", refused)], Idle));
}
