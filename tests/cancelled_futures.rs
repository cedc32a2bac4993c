//! An action's futures (polled waits, `Scoped`, blocking runs, joins) dropped,
//! cancelled or held, combined with pause/resume, monitors, restarts and timeouts.
//! Black-box, on the simulator, exact traces.

mod common;

use std::cell::RefCell;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};

use common::*;
use embassy_futures::select::{select, Either};
use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Failure, Monitor, Monitors, Seq, SeqConfig, SeqId, Sequence,
    Sequencer, Transition,
};

fn hook_x(c: &Ctrl) {
    c.hooks.borrow_mut().push("X");
}
fn hook_z(c: &Ctrl) {
    c.hooks.borrow_mut().push("Z");
}
fn hook_a(c: &Ctrl) {
    c.hooks.borrow_mut().push("A");
}
fn hook_c(c: &Ctrl) {
    c.hooks.borrow_mut().push("C");
}

/// Waits until flag `f` (a polled wait).
struct Until(usize);
impl Sequence<Ctrl> for Until {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let f = self.0;
        cx.wait_until(move |cx| cx.control().flag(f)).await;
        Ok(())
    }
}

/// Runs its child blocking and hands its failure on.
struct Runs<S: Sequence<Ctrl>>(Seq<S>);
impl<S: Sequence<Ctrl>> Sequence<Ctrl> for Runs<S> {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.run(&mut self.0).await?;
        Ok(())
    }
}

thread_local! {
    static GOT: RefCell<Vec<(u64, String)>> = const { RefCell::new(Vec::new()) };
}
fn got(cx: &Cx<'_, Ctrl>, what: String) {
    GOT.with(|g| g.borrow_mut().push((cx.now().as_ticks() / 1000, what)));
}
fn take_got() -> Vec<(u64, String)> {
    GOT.with(|g| std::mem::take(&mut *g.borrow_mut()))
}

/// Y: races a blocking run of X against a polled wait of flag `cancel`; when the wait
/// wins (X's future dropped), runs X again at once and records both results.
struct Racer<S: Sequence<Ctrl>> {
    x: Seq<S>,
    cancel: usize,
}
impl<S: Sequence<Ctrl>> Sequence<Ctrl> for Racer<S> {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let f = self.cancel;
        let first = select(
            cx.run(&mut self.x),
            cx.wait_until(move |cx| cx.control().flag(f)),
        )
        .await;
        match first {
            Either::First(r) => got(cx, format!("first run {r:?}")),
            Either::Second(()) => got(cx, "cancelled".into()),
        }
        let again = cx.run(&mut self.x).await;
        got(cx, format!("second run {again:?}"));
        Ok(())
    }
}

fn ids<const N: usize>(i: [usize; N]) -> [SeqId; N] {
    i.map(SeqId::from_index)
}

/// Y → X → Z (X a blocking caller itself). Y's polled wait of flag 0 wins at 3 ms: X's
/// future is dropped with Z's run inside it: both aborted at once, innermost first,
/// `Dropped`, each hook once; Y runs X again at once, and the new runs complete when flag
/// 1 rises (5 ms).
#[test]
fn a_dropped_run_whose_child_is_a_blocking_caller_ends_both_and_can_run_again() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let z = seq
        .add(SeqConfig::new("Z").on_abort(hook_z), Until(1))
        .unwrap();
    let x = seq
        .add(SeqConfig::new("X").on_abort(hook_x), Runs(z))
        .unwrap();
    let y = seq
        .add(SeqConfig::new("Y"), Racer { x, cancel: 0 })
        .unwrap();
    let [zi, xi, yi] = ids([0, 1, 2]);
    assert_eq!(y.id(), yi);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 5);
    });
    sim.start(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    assert_trace(
        sim.trace(),
        &[
            tr(0, yi, Idle, Running, Cause::Start),
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, zi, Idle, Running, Cause::Start),
            tr(3, zi, Running, Aborting, Cause::Dropped),
            tr(3, zi, Aborting, Aborted, Cause::Dropped),
            tr(3, xi, Running, Aborting, Cause::Dropped),
            tr(3, xi, Aborting, Aborted, Cause::Dropped),
            tr(3, xi, Aborted, Running, Cause::Start),
            tr(3, zi, Aborted, Running, Cause::Start),
            tr(5, zi, Running, Terminated, Cause::Completed),
            tr(5, xi, Running, Terminated, Cause::Completed),
            tr(5, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(*ctrl.hooks.borrow(), ["Z", "X"]);
    assert_eq!(
        take_got(),
        [
            (3, "cancelled".to_string()),
            (5, "second run Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(5));
}

fn racer_tree(seq: &Sequencer<Ctrl, 8>) -> (Seq<Racer<Runs<Until>>>, [SeqId; 3]) {
    let z = seq
        .add(SeqConfig::new("Z").on_abort(hook_z), Until(1))
        .unwrap();
    let x = seq
        .add(SeqConfig::new("X").on_abort(hook_x), Runs(z))
        .unwrap();
    let y = seq
        .add(SeqConfig::new("Y"), Racer { x, cancel: 0 })
        .unwrap();
    (y, ids([0, 1, 2]))
}

fn dump(records: &[rtseq::Record]) {
    for r in records {
        eprintln!("{:>6} {:?}", r.time.as_ticks(), r.entry);
    }
}

/// X (and Z below it) paused by a pause request of X at 1 ms (the tick at 2 ms); Y is not
/// paused, so its polled wait wins at 4 ms and drops X's future while X is paused: X and
/// Z end aborted, `Dropped`, at once. The new run of X that Y starts right away is a new
/// run: the pause request was of the old one, so it runs unpaused and completes at 6 ms.
#[test]
fn a_run_dropped_while_it_is_paused_by_a_request_ends_and_its_new_run_runs() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (y, [zi, xi, yi]) = racer_tree(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 4);
        c.set(1, ms(t) >= 6);
    });
    sim.start(yi).unwrap();
    sim.step();
    sim.pause(xi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_trace(
        sim.trace(),
        &[
            tr(0, yi, Idle, Running, Cause::Start),
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, zi, Idle, Running, Cause::Start),
            tr(2, xi, Running, Paused, Cause::Pause),
            tr(2, zi, Running, Paused, Cause::Pause),
            tr(4, zi, Paused, Aborting, Cause::Dropped),
            tr(4, zi, Aborting, Aborted, Cause::Dropped),
            tr(4, xi, Paused, Aborting, Cause::Dropped),
            tr(4, xi, Aborting, Aborted, Cause::Dropped),
            tr(4, xi, Aborted, Running, Cause::Start),
            tr(4, zi, Aborted, Running, Cause::Start),
            tr(6, zi, Running, Terminated, Cause::Completed),
            tr(6, xi, Running, Terminated, Cause::Completed),
            tr(6, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(*ctrl.hooks.borrow(), ["Z", "X"]);
    assert_eq!(idle, Some(6));
}

/// Y itself paused (request at 1 ms, tick 2) while it races X against its polled wait;
/// flag 0 rises at 3 ms, during the pause: the wait does not return while Y is paused.
/// Resumed by a request at 5 ms (the tick at 6 ms applies it before the polls and takes
/// the poll due then, item 1): the wait returns at 6 ms, X's future is dropped then.
#[test]
fn a_polled_wait_beside_a_blocking_run_waits_out_its_caller_s_pause() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (y, [zi, xi, yi]) = racer_tree(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 8);
    });
    sim.start(yi).unwrap();
    sim.step();
    sim.pause(yi).unwrap();
    sim.run_for(Duration::from_millis(4));
    assert_eq!([yi, xi, zi].map(|i| sim.state(i)), [Paused; 3]);
    sim.resume(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    let got = take_got();
    assert_eq!(got[0], (6, "cancelled".to_string()));
    assert_eq!(idle, Some(8));
}

/// O: starts C scoped, then waits until flag `until` and returns (dropping the `Scoped`).
struct ScopedThenWait {
    c: SeqId,
    until: usize,
}
impl Sequence<Ctrl> for ScopedThenWait {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _c = cx.start_scoped(self.c)?;
        let f = self.until;
        cx.wait_until(move |cx| cx.control().flag(f)).await;
        Ok(())
    }
}

/// O starts C scoped and returns at 4 ms (dropping the `Scoped`); C's `RestartOwner`
/// monitor fires at `fault_ms`. Returns the trace and the cleanup hooks that ran.
fn scoped_child_restarted_at(fault_ms: u64) -> (Vec<Transition>, Vec<&'static str>) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O"),
            ScopedThenWait {
                c: SeqId::from_index(1),
                until: 0,
            },
        )
        .unwrap();
    let c = seq
        .add(SeqConfig::new("C").on_abort(hook_c), Until(9))
        .unwrap();
    let [_, ci] = ids([0, 1]);
    let mut fault = |c: &Ctrl, _| c.flag(1);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            ci,
            Monitor::new("fault", &mut fault, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(c);
    sim.before_tick(move |t, c| {
        c.set(0, ms(t) >= 4);
        c.set(1, ms(t) == fault_ms);
    });
    sim.start(SeqId::from_index(0)).unwrap();
    sim.run_for(Duration::from_millis(8));
    dump(sim.records());
    let hooks = ctrl.hooks.borrow().clone();
    (sim.trace().to_vec(), hooks)
}

/// C (scoped child of O) restarted by its own `RestartOwner` monitor at 2 ms; O returns
/// at 4 ms: the run, restarts included, is aborted by the tick at 5 ms (item 11: "The run
/// includes its restarts").
#[test]
fn a_dropped_scoped_aborts_its_child_after_the_child_restarted() {
    let [oi, ci] = ids([0, 1]);
    let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
    let (trace, _) = scoped_child_restarted_at(2);
    assert_trace(
        &trace,
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(2, ci, Running, Restarting, m0),
            tr(2, ci, Restarting, Running, Cause::Restart),
            tr(4, oi, Running, Terminated, Cause::Completed),
            tr(5, ci, Running, Aborting, Cause::Abort),
            tr(5, ci, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// C (scoped child of O, C's lane added after O's) restarted by its monitor in the tick at
/// 4 ms, in which O returns: O's lane comes first, so the `Scoped`'s abort is requested
/// while C is `Restarting`, before C's lane takes the restart up. Item 8: "a restart its
/// lane has not taken up yet is not begun (the run is aborted from `Restarting`)".
#[test]
fn a_scoped_dropped_while_its_child_is_restarting_aborts_it_from_restarting() {
    let [oi, ci] = ids([0, 1]);
    let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
    let (trace, hooks) = scoped_child_restarted_at(4);
    assert_trace(
        &trace,
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(4, ci, Running, Restarting, m0),
            tr(4, oi, Running, Terminated, Cause::Completed),
            tr(5, ci, Restarting, Aborting, Cause::Abort),
            tr(5, ci, Aborting, Aborted, Cause::Abort),
        ],
    );
    assert_eq!(
        hooks,
        ["C", "C"],
        "one hook per move into Restarting/Aborting"
    );
}

/// O starts C scoped (run 1), joins it, starts it scoped again (run 2), then drops the
/// first `Scoped`: run 2 is never asked (item 11), and its join gets `Completed`.
struct TwoScoped(SeqId);
impl Sequence<Ctrl> for TwoScoped {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let s1 = cx.start_scoped(self.0)?;
        let r1 = s1.join().await;
        got(cx, format!("run 1 {r1:?}"));
        cx.wait_until(|cx| cx.control().flag(2)).await;
        let s2 = cx.start_scoped(self.0)?;
        drop(s1);
        let r2 = s2.join().await;
        got(cx, format!("run 2 {r2:?}"));
        Ok(())
    }
}

#[test]
fn an_old_scoped_dropped_after_a_new_scoped_start_leaves_the_new_run_alone() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), TwoScoped(SeqId::from_index(1)))
        .unwrap();
    let c = seq.add(SeqConfig::new("C"), Until(0)).unwrap();
    let [oi, ci] = ids([0, 1]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.lane(c);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 3 || ms(t) == 6);
        c.set(2, ms(t) >= 4);
    });
    sim.start(oi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_eq!(
        take_got(),
        [
            (3, "run 1 Ok(Completed)".to_string()),
            (6, "run 2 Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(6));
    assert!(sim.trace().iter().all(|t| t.cause != Cause::Abort));
    let _ = ci;
}

/// X (a blocking child of Y) starts C scoped and waits; Y's polled wait drops X's future
/// at 3 ms: C's run goes down at once with X (`Dropped`, after the `Scoped`'s request was
/// recorded, item 11). Y starts C again at once (non-blocking); the recorded request of
/// the old run never aborts the new one, which completes at 6 ms.
struct XScoped(SeqId);
impl Sequence<Ctrl> for XScoped {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _c = cx.start_scoped(self.0)?;
        cx.wait_until(|_| false).await;
        Ok(())
    }
}
struct YDropsX {
    x: Seq<XScoped>,
    c: SeqId,
}
impl Sequence<Ctrl> for YDropsX {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _ = select(
            cx.run(&mut self.x),
            cx.wait_until(|cx| cx.control().flag(0)),
        )
        .await;
        let again = cx.start(self.c);
        got(cx, format!("start again {again:?}"));
        let joined = cx.join(self.c).await;
        got(cx, format!("joined {joined:?}"));
        Ok(())
    }
}

#[test]
fn a_scoped_child_of_a_dropped_blocking_run_goes_down_with_it_and_a_new_start_runs_on() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let c = seq
        .add(SeqConfig::new("C").on_abort(hook_c), Until(1))
        .unwrap();
    let x = seq
        .add(
            SeqConfig::new("X").on_abort(hook_x),
            XScoped(SeqId::from_index(0)),
        )
        .unwrap();
    let y = seq
        .add(
            SeqConfig::new("Y"),
            YDropsX {
                x,
                c: SeqId::from_index(0),
            },
        )
        .unwrap();
    let [ci, xi, yi] = ids([0, 1, 2]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.lane(c);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 6);
    });
    sim.start(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_trace(
        sim.trace(),
        &[
            tr(0, yi, Idle, Running, Cause::Start),
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(3, ci, Running, Aborting, Cause::Dropped),
            tr(3, ci, Aborting, Aborted, Cause::Dropped),
            tr(3, xi, Running, Aborting, Cause::Dropped),
            tr(3, xi, Aborting, Aborted, Cause::Dropped),
            tr(3, ci, Aborted, Running, Cause::Start),
            tr(6, ci, Running, Terminated, Cause::Completed),
            tr(6, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(
        take_got(),
        [
            (3, "start again Ok(())".to_string()),
            (6, "joined Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(6));
}

/// Y races a blocking run of X (which waits for flag 1) against its polled wait of flag
/// 0; when the wait wins, it starts X again at once and records the new run's result.
/// X's monitor (`behaviour`, exception sequence E, which waits for flag 2) fires at 2 ms.
fn exception_of_dropped_run(
    behaviour: Behaviour,
    flags: fn(u64, &Ctrl),
    e_first: bool,
) -> DroppedRun {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X").on_abort(hook_x), Until(1))
        .unwrap();
    let e = seq
        .add(SeqConfig::new("E").on_abort(hook_a), Until(2))
        .unwrap();
    let y = seq
        .add(SeqConfig::new("Y"), Racer { x, cancel: 0 })
        .unwrap();
    let [xi, ei, _yi] = ids([0, 1, 2]);
    let mut fault = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            xi,
            Monitor::new("fault", &mut fault, behaviour).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    if e_first {
        sim.lane(e);
        sim.lane(y);
    } else {
        sim.lane(y);
        sim.lane(e);
    }
    sim.before_tick(move |t, c| flags(ms(t), c));
    sim.start(SeqId::from_index(2)).unwrap();
    sim.run_for(Duration::from_millis(10));
    dump(sim.records());
    let hooks = ctrl.hooks.borrow().clone();
    DroppedRun {
        trace: sim.trace().to_vec(),
        got: take_got(),
        not_run: seq.exceptions_not_run(),
        hooks,
    }
}

/// What [`exception_of_dropped_run`] saw.
struct DroppedRun {
    trace: Vec<Transition>,
    /// The results Y recorded, with their times (ms).
    got: Vec<(u64, String)>,
    /// `Sequencer::exceptions_not_run` at the end.
    not_run: u16,
    /// The cleanup hooks, in order.
    hooks: Vec<&'static str>,
}

/// E ends at 3 ms in its lane (polled before Y's); in the same pass Y's wait wins and
/// drops X's run, whose exception E served, and starts X again. The tick at 4 ms reports
/// E's end: its behaviour (`AbortOwner`, `RestartOwner`) is of the dropped run, never of
/// the new run (item 3: "nor is a later run or round of the owner [credited with this
/// end], whose own exception waits for its own exception sequence"; item 9: what the tick
/// decides on a run is carried out on that run only). The new run completes at 6 ms.
#[test]
fn an_exception_end_of_a_dropped_run_leaves_the_owner_s_new_run_alone() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        let DroppedRun {
            trace,
            got,
            not_run,
            ..
        } = exception_of_dropped_run(
            behaviour,
            |t, c| {
                c.set(0, t >= 3);
                c.set(1, t >= 6);
                c.set(2, t >= 3);
                c.set(3, t == 2);
            },
            true,
        );
        let [xi, ei, yi] = ids([0, 1, 2]);
        let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
        assert_trace(
            &trace,
            &[
                tr(0, yi, Idle, Running, Cause::Start),
                tr(0, xi, Idle, Running, Cause::Start),
                tr(2, ei, Idle, Running, m0),
                tr(3, ei, Running, Terminated, Cause::Completed),
                tr(3, xi, Running, Aborting, Cause::Dropped),
                tr(3, xi, Aborting, Aborted, Cause::Dropped),
                tr(3, xi, Aborted, Running, Cause::Start),
                tr(6, xi, Running, Terminated, Cause::Completed),
                tr(6, yi, Running, Terminated, Cause::Completed),
            ],
        );
        assert_eq!(
            got,
            [
                (3, "cancelled".to_string()),
                (6, "second run Ok(Completed)".to_string())
            ],
            "{behaviour:?}"
        );
        assert_eq!(not_run, 0, "{behaviour:?}");
    }
}

/// X handles an exception (E running, its `AbortOwner` pending) when Y's wait wins at 3
/// ms: X's run is dropped with E below it (item 4: an abort reaches running exception
/// sequences; item 13: the run and its sub-sequences, at once, innermost first). The new
/// run of X, started at once, is not held by the old exception and completes at 6 ms; E
/// ending never comes, no behaviour is applied, nothing counts as not run.
#[test]
fn a_run_dropped_while_its_exception_sequence_runs_takes_it_down_and_the_new_run_is_free() {
    let DroppedRun {
        trace,
        got,
        not_run,
        hooks,
    } = exception_of_dropped_run(
        Behaviour::AbortOwner,
        |t, c| {
            c.set(0, t >= 3);
            c.set(1, t >= 6);
            c.set(2, t >= 8);
            c.set(3, t == 2);
        },
        false,
    );
    let [xi, ei, yi] = ids([0, 1, 2]);
    let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
    assert_trace(
        &trace,
        &[
            tr(0, yi, Idle, Running, Cause::Start),
            tr(0, xi, Idle, Running, Cause::Start),
            tr(2, ei, Idle, Running, m0),
            tr(3, ei, Running, Aborting, Cause::Dropped),
            tr(3, ei, Aborting, Aborted, Cause::Dropped),
            tr(3, xi, Running, Aborting, Cause::Dropped),
            tr(3, xi, Aborting, Aborted, Cause::Dropped),
            tr(3, xi, Aborted, Running, Cause::Start),
            tr(6, xi, Running, Terminated, Cause::Completed),
            tr(6, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(
        got,
        [
            (3, "cancelled".to_string()),
            (6, "second run Ok(Completed)".to_string())
        ]
    );
    assert_eq!(not_run, 0);
    assert_eq!(hooks, ["A", "X"]);
}

/// Y → X → Z; Z's `PauseOwner` monitor (curtain 2..5 ms, exception sequence A, which
/// waits for flag 9) pauses Z at 2 ms and starts A. Y's wait wins at 3 ms: X's run is
/// dropped with Z (paused by the monitor) and A below Z. Y runs X → Z again at once: the
/// new run of Z starts unpaused, its monitor from "false" (item 5): the curtain, still
/// there at 4 ms, pauses it again (and starts A again); it clears at 5 ms and releases Z;
/// Z completes at its poll at 7 ms (flag 1).
#[test]
fn a_run_dropped_while_a_pause_owner_monitor_holds_its_grandchild_leaves_the_new_run_free() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (y, [zi, xi, yi]) = racer_tree(&seq);
    let a = seq
        .add(SeqConfig::new("A").on_abort(hook_a), Until(1))
        .unwrap();
    let ai = a.id();
    let mut curtain = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            zi,
            Monitor::new("curtain", &mut curtain, Behaviour::PauseOwner).exception(ai),
        )
        .unwrap();
    let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(y);
    sim.lane(a);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 7);
        c.set(3, (2..5).contains(&ms(t)));
    });
    sim.start(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_eq!(
        take_got(),
        [
            (3, "cancelled".to_string()),
            (7, "second run Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(7));
    let z_moves: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == zi)
        .cloned()
        .collect();
    assert_trace(
        &z_moves,
        &[
            tr(0, zi, Idle, Running, Cause::Start),
            tr(2, zi, Running, Paused, m0),
            tr(3, zi, Paused, Aborting, Cause::Dropped),
            tr(3, zi, Aborting, Aborted, Cause::Dropped),
            tr(3, zi, Aborted, Running, Cause::Start),
            tr(4, zi, Running, Paused, m0),
            tr(5, zi, Paused, Running, m0),
            tr(7, zi, Running, Terminated, Cause::Completed),
        ],
    );
    let _ = xi;
}

/// Y is held by its own `PauseOwner` monitor (curtain 2..6 ms) while it races X against
/// its polled wait; flag 0 rises at 3 ms. Item 1: "A `PauseOwner` release comes with the
/// monitor evaluation, after the tick took its polls: the poll due in the release tick
/// was taken while held and is skipped, so the next check comes one polling period
/// later": the wait returns, and drops X, at 7 ms.
#[test]
fn a_polled_wait_beside_a_blocking_run_returns_one_period_after_a_pause_owner_release() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (y, [zi, xi, yi]) = racer_tree(&seq);
    let mut curtain = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            yi,
            Monitor::new("curtain", &mut curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 9);
        c.set(3, (2..6).contains(&ms(t)));
    });
    sim.start(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_eq!(take_got()[0], (7, "cancelled".to_string()));
    assert_eq!(idle, Some(9));
    let _ = (xi, zi);
}

/// C (scoped child of O) handles an exception of its `RestartOwner` monitor (E running,
/// waiting for flag 2) when O returns at 3 ms: the `Scoped`'s abort request is carried
/// out by the tick at 4 ms, which aborts C and E below it; E had not ended, so the
/// behaviour goes with the run (item 10): C is not restarted, nothing counts as not run.
#[test]
fn a_scoped_dropped_while_its_child_handles_an_exception_aborts_both_and_the_behaviour_goes() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O"),
            ScopedThenWait {
                c: SeqId::from_index(1),
                until: 0,
            },
        )
        .unwrap();
    let c = seq
        .add(SeqConfig::new("C").on_abort(hook_c), Until(9))
        .unwrap();
    let e = seq
        .add(SeqConfig::new("E").on_abort(hook_a), Until(2))
        .unwrap();
    let [oi, ci, ei] = ids([0, 1, 2]);
    let mut fault = |c: &Ctrl, _| c.flag(1);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            ci,
            Monitor::new("fault", &mut fault, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let m0 = Cause::Monitor(rtseq::MonitorId::from_index(0));
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(c);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) == 2);
        c.set(2, ms(t) >= 6);
    });
    sim.start(oi).unwrap();
    sim.run_for(Duration::from_millis(10));
    dump(sim.records());
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(2, ei, Idle, Running, m0),
            tr(3, oi, Running, Terminated, Cause::Completed),
            tr(4, ei, Running, Aborting, Cause::Abort),
            tr(4, ei, Aborting, Aborted, Cause::Abort),
            tr(4, ci, Running, Aborting, Cause::Abort),
            tr(4, ci, Aborting, Aborted, Cause::Abort),
        ],
    );
    assert_eq!(seq.exceptions_not_run(), 0);
}

/// J starts A and B, then waits in a join of A beside a `select` of a join of B against
/// its polled wait of flag 0. At 3 ms the wait wins (J's join of B dropped: J's waits are
/// cleared and its lane woken to register again), and in the same pass A's wait of flag
/// 0 returns and A joins J. J waits for A and A for J: item 14, "Of two joins that close
/// a cycle at the same moment ..., exactly one is the error, also when the other is
/// dropped and made again". Exactly one of the two gets `JoinWouldDeadlock`; nothing
/// stays waiting for good.
struct JoinsAandB {
    a: SeqId,
    b: SeqId,
}
impl Sequence<Ctrl> for JoinsAandB {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.a)?;
        cx.start(self.b)?;
        let (ja, _) = embassy_futures::join::join(
            cx.join(self.a),
            select(cx.join(self.b), cx.wait_until(|cx| cx.control().flag(0))),
        )
        .await;
        got(cx, format!("J joined A: {ja:?}"));
        Ok(())
    }
}
struct JoinsBack(SeqId);
impl Sequence<Ctrl> for JoinsBack {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.wait_until(|cx| cx.control().flag(0)).await;
        let j = cx.join(self.0).await;
        got(cx, format!("A joined J: {j:?}"));
        Ok(())
    }
}

#[test]
fn a_join_dropped_beside_another_then_a_crossing_join_exactly_one_is_refused() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let j = seq
        .add(
            SeqConfig::new("J"),
            JoinsAandB {
                a: SeqId::from_index(1),
                b: SeqId::from_index(2),
            },
        )
        .unwrap();
    let a = seq
        .add(SeqConfig::new("A"), JoinsBack(SeqId::from_index(0)))
        .unwrap();
    let b = seq.add(SeqConfig::new("B"), Until(9)).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(j);
    sim.lane(a);
    sim.lane(b);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 3));
    sim.start(SeqId::from_index(0)).unwrap();
    sim.run_for(Duration::from_millis(10));
    dump(sim.records());
    let got = take_got();
    eprintln!("{got:?}");
    let refused = got
        .iter()
        .filter(|(_, s)| s.contains("JoinWouldDeadlock"))
        .count();
    assert_eq!(refused, 1, "{got:?}");
    assert_eq!(got.len(), 2, "both joins returned: {got:?}");
}

thread_local! {
    static TIMER: RefCell<(bool, Option<std::task::Waker>)> = const { RefCell::new((false, None)) };
}
/// A timer with a waker of its own (as embassy-time's): ready once `fire_timer` ran.
struct Timer;
impl Future for Timer {
    type Output = ();
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<()> {
        TIMER.with(|t| {
            let mut t = t.borrow_mut();
            if t.0 {
                Poll::Ready(())
            } else {
                t.1 = Some(w.waker().clone());
                Poll::Pending
            }
        })
    }
}
fn fire_timer() {
    let w = TIMER.with(|t| {
        let mut t = t.borrow_mut();
        t.0 = true;
        t.1.take()
    });
    if let Some(w) = w {
        w.wake();
    }
}

/// Y: a blocking run of X raced against a timer (a timeout combinator with a waker of its
/// own), then X again.
struct TimedOut {
    x: Seq<Runs<Until>>,
}
impl Sequence<Ctrl> for TimedOut {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        match select(cx.run(&mut self.x), Timer).await {
            Either::First(r) => got(cx, format!("first run {r:?}")),
            Either::Second(()) => got(cx, "timed out".into()),
        }
        let again = cx.run(&mut self.x).await;
        got(cx, format!("second run {again:?}"));
        Ok(())
    }
}

/// X (and Z below it) paused by a request at 1 ms; the timer fires just before the tick at
/// 4 ms and wakes Y's lane: Y is not paused, its action runs, the timer wins and X's
/// future is dropped while X is paused (item 13): X and Z aborted at once, `Dropped`; the
/// new run of X runs unpaused and completes at 6 ms.
#[test]
fn a_timeout_combinator_with_its_own_waker_drops_a_paused_blocking_run() {
    take_got();
    TIMER.with(|t| *t.borrow_mut() = (false, None));
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let z = seq
        .add(SeqConfig::new("Z").on_abort(hook_z), Until(1))
        .unwrap();
    let x = seq
        .add(SeqConfig::new("X").on_abort(hook_x), Runs(z))
        .unwrap();
    let y = seq.add(SeqConfig::new("Y"), TimedOut { x }).unwrap();
    let [zi, xi, yi] = ids([0, 1, 2]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 6);
        if ms(t) == 4 {
            fire_timer();
        }
    });
    sim.start(yi).unwrap();
    sim.step();
    sim.pause(xi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_trace(
        sim.trace(),
        &[
            tr(0, yi, Idle, Running, Cause::Start),
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, zi, Idle, Running, Cause::Start),
            tr(2, xi, Running, Paused, Cause::Pause),
            tr(2, zi, Running, Paused, Cause::Pause),
            tr(4, zi, Paused, Aborting, Cause::Dropped),
            tr(4, zi, Aborting, Aborted, Cause::Dropped),
            tr(4, xi, Paused, Aborting, Cause::Dropped),
            tr(4, xi, Aborting, Aborted, Cause::Dropped),
            tr(4, xi, Aborted, Running, Cause::Start),
            tr(4, zi, Aborted, Running, Cause::Start),
            tr(6, zi, Running, Terminated, Cause::Completed),
            tr(6, xi, Running, Terminated, Cause::Completed),
            tr(6, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(
        take_got(),
        [
            (4, "timed out".to_string()),
            (6, "second run Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(6));
}

/// The same timer fires while Y itself is paused (request at 1 ms, tick 2): Y's lane is
/// woken but its action does not advance while paused (item 7: "resume continues at the
/// same point"; item 4: a run checks its clearance before advancing its action). X is
/// dropped only once Y is resumed (request at 5 ms, tick 6 ms).
#[test]
fn a_timeout_combinator_firing_while_the_caller_is_paused_waits_for_the_resume() {
    take_got();
    TIMER.with(|t| *t.borrow_mut() = (false, None));
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let z = seq
        .add(SeqConfig::new("Z").on_abort(hook_z), Until(1))
        .unwrap();
    let x = seq
        .add(SeqConfig::new("X").on_abort(hook_x), Runs(z))
        .unwrap();
    let y = seq.add(SeqConfig::new("Y"), TimedOut { x }).unwrap();
    let [zi, xi, yi] = ids([0, 1, 2]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 8);
        if ms(t) == 4 {
            fire_timer();
        }
    });
    sim.start(yi).unwrap();
    sim.step();
    sim.pause(yi).unwrap();
    sim.run_for(Duration::from_millis(4));
    assert_eq!([yi, xi, zi].map(|i| sim.state(i)), [Paused; 3]);
    sim.resume(yi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    assert_eq!(
        take_got(),
        [
            (6, "timed out".to_string()),
            (8, "second run Ok(Completed)".to_string())
        ]
    );
    assert_eq!(idle, Some(8));
}

/// O starts C scoped and, in a loop, races the `Scoped`'s join against a polled wait that
/// holds every other ms (the join dropped and made again, item 14: "a join dropped before
/// it returned ... no longer waits"). O is paused by a request from 2 to 6 ms (ticks);
/// C completes at 4 ms, during O's pause. After the resume (tick 6 ms) the join gets C's
/// run's outcome, `Completed`, at 6 ms, and nothing is aborted.
struct JoinLoop(SeqId);
impl Sequence<Ctrl> for JoinLoop {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let c = cx.start_scoped(self.0)?;
        loop {
            match select(
                c.join(),
                cx.wait_until(|cx| cx.now().as_ticks() / 1000 % 2 == 1),
            )
            .await
            {
                Either::First(r) => {
                    got(cx, format!("joined {r:?}"));
                    break;
                }
                Either::Second(()) => {
                    cx.wait_until(|cx| cx.now().as_ticks() / 1000 % 2 == 0)
                        .await
                }
            }
        }
        Ok(())
    }
}

#[test]
fn a_scoped_join_dropped_and_made_again_across_the_caller_s_pause_gets_the_outcome() {
    take_got();
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), JoinLoop(SeqId::from_index(1)))
        .unwrap();
    let c = seq.add(SeqConfig::new("C"), Until(0)).unwrap();
    let [oi, ci] = ids([0, 1]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.lane(c);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 4));
    sim.start(oi).unwrap();
    sim.step();
    sim.pause(oi).unwrap();
    sim.run_for(Duration::from_millis(4));
    assert_eq!((sim.state(oi), sim.state(ci)), (Paused, Terminated));
    sim.resume(oi).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(20)).map(ms);
    dump(sim.records());
    let got = take_got();
    assert_eq!(got, [(6, "joined Ok(Completed)".to_string())]);
    assert_eq!(idle, Some(6));
    assert!(sim.trace().iter().all(|t| t.cause != Cause::Abort));
}
