//! Less-travelled combinations a motor-control firmware writes, checked black-box against
//! docs/semantics.md on exact traces, times and outcomes (an outside probe of session 56):
//! restart limits with exception sequences that fail, are aborted or time out; timeouts
//! changed during runs and due with a monitor; `PauseOwner` holds three levels deep with
//! operator requests and aborts; the safety system's abort-all during exceptions and
//! pauses; failures handed up two levels; polling classes; misuse.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Done, Duration, Error, Failure, Instant, Monitor, Monitors, Outcome, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Step,
};

/// Runs until it is stopped.
struct Forever;
impl Sequence<Ctrl> for Forever {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Waits `ms` of its run's time, then fails with `App(code)`.
struct FailAfter {
    ms: u64,
    code: u16,
}
impl Sequence<Ctrl> for FailAfter {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let ms = self.ms;
        cx.wait_until(move |cx| cx.run_time() >= Duration::from_millis(ms))
            .await;
        Err(Failure::App(self.code))
    }
}

/// Waits `ms` of its run's time, then completes.
struct Dwell(u64);
impl Sequence<Ctrl> for Dwell {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let ms = self.0;
        cx.wait_until(move |cx| cx.run_time() >= Duration::from_millis(ms))
            .await;
        Ok(())
    }
}

/// A step whose action fails at once.
struct FailStep(u16);
impl Step<Ctrl> for FailStep {
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Err(Failure::App(self.0))
    }
}

/// Runs its child blocking and hands its result on with `?`; records what it got.
struct Mid<S: Step<Ctrl>> {
    child: Seq<S>,
}
impl<S: Step<Ctrl>> Sequence<Ctrl> for Mid<S> {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.child).await?;
        Ok(())
    }
}

/// Runs a sequence child blocking with `?`.
struct Top<S: Sequence<Ctrl>> {
    child: Seq<S>,
}
impl<S: Sequence<Ctrl>> Sequence<Ctrl> for Top<S> {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.run(&mut self.child).await?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// Restart budget with exception sequences that fail or are aborted.
// ---------------------------------------------------------------------------------------

/// `RestartOwner` with an exception sequence that fails (`Failure::App`) and
/// `restart_limit(1)`: item 3 says the behaviour is applied however the exception sequence
/// ended (failed included); item 5: the second firing in the same run escalates to
/// `AbortOwner`.
#[test]
fn restart_with_failing_exception_then_escalation() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq
        .add(SeqConfig::new("E"), FailAfter { ms: 2, code: 7 })
        .unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner)
                .exception(ei)
                .restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3 || ms(t) == 10));
    sim.start(oi).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert!(end.is_some());
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k),
            tr(5, ei, Running, Terminated, Cause::Failed),
            tr(6, oi, Running, Restarting, k),
            tr(6, oi, Restarting, Running, Cause::Restart),
            tr(10, ei, Terminated, Running, k),
            tr(12, ei, Running, Terminated, Cause::Failed),
            tr(13, oi, Running, Aborting, k),
            tr(13, oi, Aborting, Aborted, k),
        ],
    );
    assert_eq!(
        sim.handle(oi).unwrap().last_outcome(),
        Some(Outcome::Aborted(k))
    );
    assert_eq!(
        sim.handle(ei).unwrap().last_outcome(),
        Some(Outcome::Failed(Failure::App(7)))
    );
}

/// The exception sequence of a `RestartOwner` monitor is aborted by the operator: the
/// behaviour is applied all the same (item 3: "aborted by a request of it").
#[test]
fn restart_with_exception_aborted_by_operator() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Forever).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(5_500));
    assert!(sim.handle(oi).unwrap().exception_is_active());
    sim.abort(ei).unwrap();
    sim.run_until(Instant::from_ticks(10_000));
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k),
            tr(6, ei, Running, Aborting, Cause::Abort),
            tr(6, ei, Aborting, Aborted, Cause::Abort),
            tr(7, oi, Running, Restarting, k),
            tr(7, oi, Restarting, Running, Cause::Restart),
        ],
    );
    assert_eq!(sim.state(oi), Running);
    assert!(!sim.handle(oi).unwrap().exception_is_active());
}

/// A second monitor (AbortOwner, no exception sequence) whose condition rises while the
/// first monitor's exception sequence (RestartOwner) runs: item 5 says it fires at the first
/// evaluation after the exception ended if its condition still holds. The restart comes
/// first (the behaviour is applied before the monitors are evaluated, item 3); the
/// restarted run's monitors are evaluated from the next tick.
#[test]
fn second_monitor_during_first_exception_fires_after_restart() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Dwell(4)).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut c1 = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let m0 = monitors
        .add(
            oi,
            Monitor::new("restart", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let m1 = monitors
        .add(oi, Monitor::new("abort", &mut c1, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 3);
        c.set(1, ms(t) >= 5);
    });
    sim.start(oi).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let (k0, k1) = (Cause::Monitor(m0), Cause::Monitor(m1));
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k0),
            tr(7, ei, Running, Terminated, Cause::Completed),
            tr(8, oi, Running, Restarting, k0),
            tr(8, oi, Restarting, Running, Cause::Restart),
            // The restarted run is evaluated from the next tick, from "false": m1 fires
            // at its first evaluation after the exception ended.
            tr(9, oi, Running, Aborting, k1),
            tr(9, oi, Aborting, Aborted, k1),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Timeouts: set_timeout between rounds, None mid-run, same tick as a monitor.
// ---------------------------------------------------------------------------------------

/// A restarting timeout of 10 ms, shortened to 4 ms by `set_timeout` at 2 ms: it runs out
/// at once-changed 4 ms (item 6: "changes an armed run's timeout at once"). The restart's
/// fresh clock: `Handle::set_timeout` says "otherwise from the next start or restart", as
/// EEROS's `setTimeoutTime` (a lasting setting), so the next rounds have 4 ms too; with
/// `timeout_restart_limit(2)` the third run-out aborts.
#[test]
fn set_timeout_shortened_holds_for_the_restarts() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O")
                .timeout(Duration::from_millis(10))
                .timeout_behaviour(Behaviour::RestartOwner)
                .timeout_restart_limit(2),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let oi = o.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(2_000));
    sim.handle(oi)
        .unwrap()
        .set_timeout(Some(Duration::from_millis(4)))
        .unwrap();
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let t = Cause::Timeout(oi);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(4, oi, Running, Restarting, t),
            tr(4, oi, Restarting, Running, Cause::Restart),
            tr(8, oi, Running, Restarting, t),
            tr(8, oi, Restarting, Running, Cause::Restart),
            tr(12, oi, Running, Aborting, t),
            tr(12, oi, Aborting, Aborted, t),
        ],
    );
}

/// `set_timeout(None)` mid-run switches the run's timeout off (item 6). A monitor then
/// restarts the run: does the restart's "fresh timeout" arm it again? `Handle::set_timeout`:
/// "`None` switches it off for that run too ... otherwise from the next start or restart":
/// the restart is a round of the same run, switched off.
#[test]
fn set_timeout_none_mid_run_then_restart() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O").timeout(Duration::from_millis(10)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 5);
        c.set(9, ms(t) >= 40);
    });
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(2_000));
    sim.handle(oi).unwrap().set_timeout(None).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(5, oi, Running, Restarting, Cause::Monitor(m)),
            tr(5, oi, Restarting, Running, Cause::Restart),
            tr(40, oi, Running, Terminated, Cause::Completed),
        ],
    );
}

/// A timeout (5 ms, AbortOwner) runs out in the tick in which a `Nothing` monitor with a
/// 3 ms exception sequence fires. Monitors come before the timeout (item 6); the timeout
/// falls due while the exception is handled, so it fires at the owner's first poll after
/// the exception ended (item 6).
#[test]
fn timeout_in_the_tick_a_monitor_fires_waits_for_the_exception() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O").timeout(Duration::from_millis(5)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Dwell(3)).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("warn", &mut c0, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 5));
    sim.start(oi).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let t = Cause::Timeout(oi);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(5, ei, Idle, Running, Cause::Monitor(m)),
            tr(8, ei, Running, Terminated, Cause::Completed),
            tr(9, oi, Running, Aborting, t),
            tr(9, oi, Aborting, Aborted, t),
        ],
    );
}

/// A monitor (AbortOwner, no exception sequence) and the timeout both due in one tick:
/// the monitor comes first, the owner ends aborted by the monitor.
#[test]
fn timeout_and_abort_monitor_in_one_tick_the_monitor_wins() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O").timeout(Duration::from_millis(5)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.before_tick(|t, c| c.set(0, ms(t) == 5));
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(5, oi, Running, Aborting, Cause::Monitor(m)),
            tr(5, oi, Aborting, Aborted, Cause::Monitor(m)),
        ],
    );
}

/// The timeout of a paused sequence: paused at 3 ms by a request, while a `set_timeout`
/// at 4 ms shortens it from 10 ms to 2 ms (already run out on the run's clock, 3 ms).
/// A paused run's timeout is not checked (item 6); it fires at the first poll after the
/// resume (resume requested before the tick at 8 ms).
#[test]
fn timeout_shortened_while_paused_fires_after_resume() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O").timeout(Duration::from_millis(10)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let oi = o.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(2_000));
    sim.pause(oi).unwrap();
    sim.run_until(Instant::from_ticks(4_000));
    assert_eq!(sim.state(oi), Paused);
    sim.handle(oi)
        .unwrap()
        .set_timeout(Some(Duration::from_millis(2)))
        .unwrap();
    sim.run_until(Instant::from_ticks(7_000));
    assert_eq!(sim.state(oi), Paused);
    sim.resume(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    let t = Cause::Timeout(oi);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, oi, Running, Paused, Cause::Pause),
            tr(8, oi, Paused, Running, Cause::Resume),
            tr(8, oi, Running, Aborting, t),
            tr(8, oi, Aborting, Aborted, t),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// PauseOwner with operator requests, three levels of blocking children.
// ---------------------------------------------------------------------------------------

type Three = (
    SeqId, // top
    SeqId, // mid
    SeqId, // leaf
    Seq<Top<Mid<Leaf>>>,
);

fn three_levels(seq: &Sequencer<Ctrl, 8>) -> Three {
    let leaf = seq.add(SeqConfig::new("leaf"), Leaf::until(9)).unwrap();
    let li = leaf.id();
    let mid = seq.add(SeqConfig::new("mid"), Mid { child: leaf }).unwrap();
    let mi = mid.id();
    let top = seq.add(SeqConfig::new("top"), Top { child: mid }).unwrap();
    (top.id(), mi, li, top)
}

/// A curtain (`PauseOwner`) holds top, mid and leaf from 5 ms to 10 ms. The operator pauses
/// top during the hold (accepted, item 7), a resume during the hold is `HeldByMonitor`; when
/// the curtain clears at 10 ms all three stay paused (the pause request's) until the
/// operator's resume before the tick at 13 ms. Leaf completes at 20 ms.
#[test]
fn curtain_hold_with_operator_pause_three_levels() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (ti, mi, li, top) = three_levels(&seq);
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(ti, Monitor::new("curtain", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(top);
    sim.before_tick(|t, c| {
        c.set(0, (5..10).contains(&ms(t)));
        c.set(9, ms(t) >= 20);
    });
    sim.start(ti).unwrap();
    sim.run_until(Instant::from_ticks(6_000));
    let h = sim.handle(ti).unwrap();
    assert_eq!(h.pause(), Ok(()));
    sim.run_until(Instant::from_ticks(7_000));
    assert_eq!(h.resume(), Err(Error::HeldByMonitor(ti)));
    sim.run_until(Instant::from_ticks(12_000));
    assert_eq!([ti, mi, li].map(|i| sim.state(i)), [Paused; 3]);
    assert_eq!(h.resume(), Ok(()));
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ti, Idle, Running, Cause::Start),
            tr(0, mi, Idle, Running, Cause::Start),
            tr(0, li, Idle, Running, Cause::Start),
            tr(5, ti, Running, Paused, k),
            tr(5, mi, Running, Paused, k),
            tr(5, li, Running, Paused, k),
            tr(13, ti, Paused, Running, Cause::Resume),
            tr(13, mi, Paused, Running, Cause::Resume),
            tr(13, li, Paused, Running, Cause::Resume),
            tr(20, li, Running, Terminated, Cause::Completed),
            tr(20, mi, Running, Terminated, Cause::Completed),
            tr(20, ti, Running, Terminated, Cause::Completed),
        ],
    );
}

/// An operator pause of the middle sequence while the curtain holds the top: when the
/// curtain clears, top resumes, mid and leaf stay paused (item 7: "A resume of a sequence
/// resumes its blocking children only when nothing else holds them (their own ... pause
/// request)"); the operator's resume of mid lets them go on.
#[test]
fn curtain_release_leaves_an_operator_paused_child_paused() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (ti, mi, li, top) = three_levels(&seq);
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(ti, Monitor::new("curtain", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(top);
    sim.before_tick(|t, c| {
        c.set(0, (5..10).contains(&ms(t)));
        c.set(9, ms(t) >= 20);
    });
    sim.start(ti).unwrap();
    sim.run_until(Instant::from_ticks(6_000));
    assert_eq!(sim.handle(mi).unwrap().pause(), Ok(()));
    sim.run_until(Instant::from_ticks(12_000));
    assert_eq!(
        [ti, mi, li].map(|i| sim.state(i)),
        [Running, Paused, Paused],
        "{}",
        show(sim.trace())
    );
    assert_eq!(sim.handle(mi).unwrap().resume(), Ok(()));
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ti, Idle, Running, Cause::Start),
            tr(0, mi, Idle, Running, Cause::Start),
            tr(0, li, Idle, Running, Cause::Start),
            tr(5, ti, Running, Paused, k),
            tr(5, mi, Running, Paused, k),
            tr(5, li, Running, Paused, k),
            tr(10, ti, Paused, Running, k),
            tr(13, mi, Paused, Running, Cause::Resume),
            tr(13, li, Paused, Running, Cause::Resume),
            tr(20, li, Running, Terminated, Cause::Completed),
            tr(20, mi, Running, Terminated, Cause::Completed),
            tr(20, ti, Running, Terminated, Cause::Completed),
        ],
    );
}

fn hook_top(c: &Ctrl) {
    c.hooks.borrow_mut().push("top");
}
fn hook_mid(c: &Ctrl) {
    c.hooks.borrow_mut().push("mid");
}
fn hook_leaf(c: &Ctrl) {
    c.hooks.borrow_mut().push("leaf");
}

/// An abort of the top while the curtain holds all three: torn down innermost first, from
/// `Paused`, each through its cleanup hook (item 4); outcomes `Aborted(Abort)`, the
/// callers' via `?` are aborted too (sticky) — item 4: "a caller that is itself aborted
/// ends Aborted".
#[test]
fn abort_during_a_curtain_hold_three_levels() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let leaf = seq
        .add(SeqConfig::new("leaf").on_abort(hook_leaf), Leaf::until(9))
        .unwrap();
    let li = leaf.id();
    let mid = seq
        .add(
            SeqConfig::new("mid").on_abort(hook_mid),
            Mid { child: leaf },
        )
        .unwrap();
    let mi = mid.id();
    let top = seq
        .add(SeqConfig::new("top").on_abort(hook_top), Top { child: mid })
        .unwrap();
    let ti = top.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(ti, Monitor::new("curtain", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(top);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 5));
    sim.start(ti).unwrap();
    sim.run_until(Instant::from_ticks(7_000));
    sim.abort(ti).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(100));
    assert!(end.is_some(), "{}", show(sim.trace()));
    let k = Cause::Monitor(m);
    let a = Cause::Abort;
    assert_trace(
        sim.trace(),
        &[
            tr(0, ti, Idle, Running, Cause::Start),
            tr(0, mi, Idle, Running, Cause::Start),
            tr(0, li, Idle, Running, Cause::Start),
            tr(5, ti, Running, Paused, k),
            tr(5, mi, Running, Paused, k),
            tr(5, li, Running, Paused, k),
            tr(8, li, Paused, Aborting, a),
            tr(8, li, Aborting, Aborted, a),
            tr(8, mi, Paused, Aborting, a),
            tr(8, mi, Aborting, Aborted, a),
            tr(8, ti, Paused, Aborting, a),
            tr(8, ti, Aborting, Aborted, a),
        ],
    );
    assert_eq!(*ctrl.hooks.borrow(), ["leaf", "mid", "top"]);
    for i in [ti, mi, li] {
        assert_eq!(
            sim.handle(i).unwrap().last_outcome(),
            Some(Outcome::Aborted(a))
        );
    }
    // Started again after the abort, with the curtain still broken: paused at its first
    // evaluation, from "false" (item 5: the edge restarts with every run).
    sim.take_trace();
    sim.start(ti).unwrap();
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(ti), Paused, "{}", show(sim.trace()));
}

// ---------------------------------------------------------------------------------------
// Restart + pause request during the exception sequence.
// ---------------------------------------------------------------------------------------

/// The owner is held by a `RestartOwner` monitor's exception sequence (3 ms..7 ms); the
/// operator pauses it at 5 ms (applied: it is running, held). Item 4: "a pause ends with the
/// round, carried out or not (a restart runs unpaused)": the restart at 8 ms goes from
/// `Paused` through `Restarting` to `Running`, and a resume afterwards is `NotPaused`.
#[test]
fn pause_during_a_restarting_exception_ends_with_the_round() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Dwell(4)).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(4_000));
    sim.pause(oi).unwrap();
    sim.run_until(Instant::from_ticks(10_000));
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k),
            tr(5, oi, Running, Paused, Cause::Pause),
            tr(7, ei, Running, Terminated, Cause::Completed),
            tr(8, oi, Paused, Restarting, k),
            tr(8, oi, Restarting, Running, Cause::Restart),
        ],
    );
    assert_eq!(sim.resume(oi), Err(Error::NotPaused(oi)));
}

/// A `PauseOwner` hold stops the run's clock (item 6/7): a 10 ms timeout, held from 3 ms to
/// 8 ms, runs out at 15 ms.
#[test]
fn curtain_hold_stops_the_timeout_clock() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O").timeout(Duration::from_millis(10)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("curtain", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.before_tick(|t, c| c.set(0, (3..8).contains(&ms(t))));
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    let (k, t) = (Cause::Monitor(m), Cause::Timeout(oi));
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, oi, Running, Paused, k),
            tr(8, oi, Paused, Running, k),
            tr(15, oi, Running, Aborting, t),
            tr(15, oi, Aborting, Aborted, t),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Failures, pre-conditions at restarts, polled waits of different classes.
// ---------------------------------------------------------------------------------------

/// A step's `Failure::App(7)` handed up two levels with `?`: every level ends
/// `Failed(App(7))` (item 16), at once, with no abort and no cleanup hook.
#[test]
fn failure_propagates_two_levels() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let leaf = seq
        .add(SeqConfig::new("leaf").on_abort(hook_leaf), FailStep(7))
        .unwrap();
    let li = leaf.id();
    let mid = seq
        .add(
            SeqConfig::new("mid").on_abort(hook_mid),
            Mid { child: leaf },
        )
        .unwrap();
    let mi = mid.id();
    let top = seq
        .add(SeqConfig::new("top").on_abort(hook_top), Top { child: mid })
        .unwrap();
    let ti = top.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(top);
    sim.start(ti).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ti, Idle, Running, Cause::Start),
            tr(0, mi, Idle, Running, Cause::Start),
            tr(0, li, Idle, Running, Cause::Start),
            tr(0, li, Running, Terminated, Cause::Failed),
            tr(0, mi, Running, Terminated, Cause::Failed),
            tr(0, ti, Running, Terminated, Cause::Failed),
        ],
    );
    for i in [ti, mi, li] {
        assert_eq!(
            sim.handle(i).unwrap().last_outcome(),
            Some(Outcome::Failed(Failure::App(7)))
        );
    }
    assert!(ctrl.hooks.borrow().is_empty());
}

/// A restart whose pre-condition no longer holds: the new round is skipped (item 1:
/// "`Restarting` repeats from the pre-condition"), the run ends `Skipped`.
#[test]
fn restart_with_a_false_pre_condition_skips() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut node = Node::of(vec![]).until(9);
    node.pre = Some(5);
    let o = seq.add(SeqConfig::new("O"), node).unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    ctrl.set(5, true);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 4);
        c.set(5, ms(t) < 2);
    });
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(4, oi, Running, Restarting, Cause::Monitor(m)),
            tr(4, oi, Restarting, Running, Cause::Restart),
            tr(4, oi, Running, Terminated, Cause::PreConditionFalse),
        ],
    );
    assert_eq!(
        sim.handle(oi).unwrap().last_outcome(),
        Some(Outcome::Skipped)
    );
}

/// A step inside a restarted sequence whose pre-condition went false: in the restarted
/// round the step is skipped, its caller gets `Ok(Done::Skipped)` and goes on.
#[test]
fn step_pre_condition_false_after_restart_is_skipped() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let leaf = seq
        .add(
            SeqConfig::new("leaf"),
            Leaf {
                pre: Some(5),
                exit: Some(9),
            },
        )
        .unwrap();
    let li = leaf.id();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![Op::Step(leaf)]))
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    ctrl.set(5, true);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 4);
        c.set(5, ms(t) < 2);
    });
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(0, li, Idle, Running, Cause::Start),
            tr(4, li, Running, Aborting, k),
            tr(4, li, Aborting, Aborted, k),
            tr(4, oi, Running, Restarting, k),
            tr(4, oi, Restarting, Running, Cause::Restart),
            tr(4, li, Aborted, Running, Cause::Start),
            tr(4, li, Running, Terminated, Cause::PreConditionFalse),
            tr(4, oi, Running, Terminated, Cause::Completed),
        ],
    );
    let ret: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.ms, r.result))
        .collect();
    assert_eq!(ret, [(4, Ok(Done::Skipped))]);
}

/// A sequence of polling 10 ms waits (`Cx::wait_until`) for flag 0 (set at 12 ms): the wait
/// returns at its next poll, 20 ms. It then runs a step of polling 3 ms (an idle class: first
/// poll one period after the start) until flag 1 (set at 25 ms): exit checked at 20 (false),
/// 23, 26. Its own exit condition, flag 2 (set at 27 ms), is checked right after the action
/// (26, false) and then on its 10 ms grid: 30 ms.
struct WaitThenStep {
    leaf: Seq<Leaf>,
    waited: Option<u64>,
}
impl Sequence<Ctrl> for WaitThenStep {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.wait_until(|cx| cx.control().flag(0)).await;
        self.waited = Some(ms(cx.now()));
        cx.control().set(3, true);
        cx.step(&mut self.leaf).await?;
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(2)
    }
}

#[test]
fn polled_wait_and_step_of_different_classes() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let leaf = seq
        .add(
            SeqConfig::new("leaf").polling(Duration::from_millis(3)),
            Leaf::until(1),
        )
        .unwrap();
    let li = leaf.id();
    let main = seq
        .add(
            SeqConfig::new("main").polling(Duration::from_millis(10)),
            WaitThenStep { leaf, waited: None },
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 12);
        c.set(1, ms(t) >= 25);
        c.set(2, ms(t) >= 27);
    });
    sim.start(mi).unwrap();
    sim.run_until_idle(Duration::from_millis(100)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Cause::Start),
            tr(20, li, Idle, Running, Cause::Start),
            tr(26, li, Running, Terminated, Cause::Completed),
            tr(30, mi, Running, Terminated, Cause::Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// The safety system: abort-all while an exception sequence runs and a sequence is paused.
// ---------------------------------------------------------------------------------------

mod safety_levels {
    use super::*;
    use rtseq::safety::*;

    pub const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
    pub const HALT: SafetyLevel = SafetyLevel::new(1);
    pub const RUN: SafetyLevel = SafetyLevel::new(2);
    pub const STOP: PublicEvent = PublicEvent::new(0);
    pub const HALT_EV: PublicEvent = PublicEvent::new(1);
    pub const RESET: PublicEvent = PublicEvent::new(2);

    pub struct Io;
    impl SafetyIo for Io {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }

    pub static PROPS: ValidProperties<'static, Io, 3> = match SafetyProperties::new(
        [
            LevelDef::new(EMERGENCY, "emergency").abort_sequences(AbortPolicy::OnEntry),
            LevelDef::new(HALT, "halt").abort_sequences(AbortPolicy::WhileActive),
            LevelDef::new(RUN, "run"),
        ],
        &[],
        &[],
        &[
            LevelTransition::on(RUN, STOP, EMERGENCY),
            LevelTransition::on(RUN, HALT_EV, HALT),
            LevelTransition::on(EMERGENCY, RESET, RUN),
            LevelTransition::on(HALT, RESET, RUN),
        ],
        RUN,
    )
    .validated()
    {
        Ok(v) => v,
        Err(_) => panic!("invalid safety properties"),
    };

    /// An exception sequence (a safe stop) that raises `STOP` and waits for ever.
    pub struct RaiseStop;
    impl Sequence<Ctrl> for RaiseStop {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.safety_system().ok_or(Failure::App(99))?.trigger(STOP);
            cx.wait_until(|_| false).await;
            Ok(())
        }
    }
}

/// O1's `RestartOwner` monitor fires at 3 ms; its exception sequence raises the public
/// `STOP` event at once; O2 was paused by the operator at 2 ms. The safety cycle at 4 ms
/// enters EMERGENCY (`OnEntry`), the tick of the same instant aborts everything, innermost
/// first (E below O1), all `Aborted(AbortAll)`; the restart pending on E's end never comes.
/// After a reset, both start again and run.
#[test]
fn safety_stop_raised_by_an_exception_sequence_aborts_all_and_restarts_cleanly() {
    use rtseq::safety::*;
    use safety_levels::*;
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o1 = seq
        .add(SeqConfig::new("O1"), Node::of(vec![]).until(9))
        .unwrap();
    let o2 = seq.add(SeqConfig::new("O2"), Forever).unwrap();
    let e = seq.add(SeqConfig::new("E"), RaiseStop).unwrap();
    let (o1i, o2i, ei) = (o1.id(), o2.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            o1i,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o1);
    sim.lane(o2);
    sim.lane(e);
    let sequences = &seq;
    sim.before_tick(move |t, c| {
        c.set(0, ms(t) == 3 || ms(t) == 12);
        safety.cycle(&mut Io, sequences);
    });
    sim.start(o1i).unwrap();
    sim.start(o2i).unwrap();
    sim.run_until(Instant::from_ticks(1_000));
    sim.pause(o2i).unwrap();
    sim.run_until(Instant::from_ticks(6_000));
    assert_eq!(seq.safety_handle().level(), EMERGENCY);
    let (k, aa) = (Cause::Monitor(m), Cause::AbortAll);
    assert_trace(
        sim.trace(),
        &[
            tr(0, o1i, Idle, Running, Cause::Start),
            tr(0, o2i, Idle, Running, Cause::Start),
            tr(2, o2i, Running, Paused, Cause::Pause),
            tr(3, ei, Idle, Running, k),
            tr(4, ei, Running, Aborting, aa),
            tr(4, ei, Aborting, Aborted, aa),
            tr(4, o1i, Running, Aborting, aa),
            tr(4, o1i, Aborting, Aborted, aa),
            tr(4, o2i, Paused, Aborting, aa),
            tr(4, o2i, Aborting, Aborted, aa),
        ],
    );
    for i in [o1i, o2i, ei] {
        assert_eq!(
            sim.handle(i).unwrap().last_outcome(),
            Some(Outcome::Aborted(aa))
        );
    }
    let active: Vec<_> = [o1i, o2i, ei]
        .iter()
        .map(|&i| {
            let h = sim.handle(i).unwrap();
            (h.exception_is_active(), h.active_exception())
        })
        .collect();
    // The abort-all, not the monitor, aborted O1: its exception is over, and its last one
    // is still named (`Handle::exception_is_active`, `tests/spec_rules.rs`).
    assert_eq!(active, [(false, Some(k)), (false, None), (false, None)]);
    // Reset: back to RUN at the next cycle; both start again.
    seq.safety_handle().trigger(RESET);
    sim.run_until(Instant::from_ticks(8_000));
    assert_eq!(seq.safety_handle().level(), RUN);
    sim.take_trace();
    sim.start(o1i).unwrap();
    sim.start(o2i).unwrap();
    sim.run_until(Instant::from_ticks(11_000));
    assert_eq!((sim.state(o1i), sim.state(o2i)), (Running, Running));
    assert_eq!(sim.resume(o2i), Err(Error::NotPaused(o2i)));
    // The monitor fires again in the new run (from "false"): E raises STOP again.
    sim.run_until(Instant::from_ticks(14_000));
    assert_trace(
        sim.trace(),
        &[
            tr(8, o1i, Aborted, Running, Cause::Start),
            tr(8, o2i, Aborted, Running, Cause::Start),
            tr(12, ei, Aborted, Running, k),
            tr(13, ei, Running, Aborting, aa),
            tr(13, ei, Aborting, Aborted, aa),
            tr(13, o1i, Running, Aborting, aa),
            tr(13, o1i, Aborting, Aborted, aa),
            tr(13, o2i, Running, Aborting, aa),
            tr(13, o2i, Aborting, Aborted, aa),
        ],
    );
}

/// In a `WhileActive` level every cycle aborts all: a sequence the application starts
/// through its handle is taken (item 8) and aborted at the next tick; a child a restarted
/// main would start never outlives it.
#[test]
fn while_active_level_aborts_each_new_start_at_the_next_tick() {
    use rtseq::safety::*;
    use safety_levels::*;
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let oi = o.id();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    let sequences = &seq;
    sim.before_tick(move |_, _| {
        safety.cycle(&mut Io, sequences);
    });
    sim.run_until(Instant::from_ticks(1_000));
    seq.safety_handle().trigger(HALT_EV);
    sim.run_until(Instant::from_ticks(3_000));
    assert_eq!(seq.safety_handle().level(), HALT);
    sim.start(oi).unwrap();
    assert_eq!(sim.state(oi), Running);
    sim.run_until(Instant::from_ticks(5_000));
    let aa = Cause::AbortAll;
    assert_trace(
        sim.trace(),
        &[
            tr(3, oi, Idle, Running, Cause::Start),
            tr(4, oi, Running, Aborting, aa),
            tr(4, oi, Aborting, Aborted, aa),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Misuse: clear errors.
// ---------------------------------------------------------------------------------------

/// Joins `target`, logging the result.
struct Joiner(SeqId);
impl Sequence<Ctrl> for Joiner {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let r = cx.join(self.0).await;
        cx.control().joined(cx, r);
        Ok(())
    }
}

#[test]
fn misuse_gives_clear_errors() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq.add(SeqConfig::new("O"), Node::of(vec![])).unwrap();
    let oi = o.id();
    let never = seq.add(SeqConfig::new("never"), Node::of(vec![])).unwrap();
    let ni = never.id();
    let j = seq.add(SeqConfig::new("J"), Joiner(ni)).unwrap();
    let ji = j.id();
    let s = seq
        .add(
            SeqConfig::new("S"),
            Node::of(vec![Op::Start(SeqId::from_index(7))]),
        )
        .unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.lane(j);
    sim.lane(s);
    let ghost = SeqId::from_index(7);
    assert_eq!(sim.start(ghost), Err(Error::UnknownSequence(ghost)));
    assert!(seq.sequence_by_id(ghost).is_none());
    // No lane for `never` (not given to the sim).
    assert_eq!(sim.start(ni), Err(Error::NoLane(ni)));
    sim.start(oi).unwrap();
    assert_eq!(sim.state(oi), Terminated);
    let h = sim.handle(oi).unwrap();
    assert_eq!(h.pause(), Err(Error::NotRunning(oi)));
    assert_eq!(h.resume(), Err(Error::NotPaused(oi)));
    assert_eq!(h.abort(), Err(Error::NotRunning(oi)));
    assert_eq!(
        h.set_timeout(Some(Duration::from_micros(1 << 31))),
        Err(Error::DurationOutOfRange)
    );
    assert_eq!(h.set_timeout(Some(Duration::from_millis(5))), Ok(()));
    // A join of a sequence never started.
    sim.start(ji).unwrap();
    assert_eq!(
        *ctrl.joins.borrow(),
        [(0, ji, Err(Error::NeverStarted(ni)))]
    );
    // A start of an unknown id from an action: handed into the action.
    sim.start(si).unwrap();
    let ret: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.seq, r.result))
        .collect();
    assert_eq!(
        ret,
        [(si, Err(Failure::NotStarted(Error::UnknownSequence(ghost))))]
    );
    // A tick earlier than the last.
    sim.run_until(Instant::from_ticks(3_000));
    let mut other: Monitors<Ctrl, 1> = Monitors::new();
    assert_eq!(
        seq.tick(Instant::from_ticks(2_000), &ctrl, &mut other),
        Err(Error::TickBeforeLast)
    );
}

/// A sequencer with one lane slot and two lanes given to the simulator: the second never
/// runs; its start must be a clear `Err` (lane.rs: "starting it is
/// `Err(Error::LaneCapacityExceeded)`", and `check_lanes` names it), not a hang.
#[test]
fn a_lane_beyond_the_slots_is_a_clear_error() {
    use rtseq::lock::CriticalSection;
    let seq: Sequencer<Ctrl, 4, 64, CriticalSection, 1> = Sequencer::new();
    let ctrl = Ctrl::default();
    let a = seq.add(SeqConfig::new("a"), Node::of(vec![])).unwrap();
    let b = seq.add(SeqConfig::new("b"), Node::of(vec![])).unwrap();
    let (ai, bi) = (a.id(), b.id());
    let mut sim: Sim<'_, Ctrl, 4, 64, 1, _, 1> = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.lane(b);
    sim.step();
    assert_eq!(sim.start(ai), Err(Error::LaneCapacityExceeded(bi)));
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(bi)));
    assert_eq!(sim.handle(ai).unwrap().start(), Ok(()));
    assert_eq!(
        sim.handle(bi).unwrap().start(),
        Err(Error::LaneCapacityExceeded(bi))
    );
    assert!(sim.run_until_idle(Duration::from_millis(10)).is_some());
}

/// A tick with a monitor table that is not the sequencer's: `ForeignMonitorTable`, the due
/// polls wait for the right table.
#[test]
fn ticking_with_a_foreign_table_is_refused() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let oi = o.id();
    let mut f = |_: &Ctrl, _: Instant| false;
    let mut mine: Monitors<Ctrl, 1> = Monitors::new();
    mine.add(oi, Monitor::new("m", &mut f, Behaviour::AbortOwner))
        .unwrap();
    let mut g = |_: &Ctrl, _: Instant| false;
    let mut foreign: Monitors<Ctrl, 1> = Monitors::new();
    foreign
        .add(oi, Monitor::new("f", &mut g, Behaviour::AbortOwner))
        .unwrap();
    let h = seq.sequence_by_id(oi).unwrap();
    h.declare_lane().unwrap();
    let _o = o; // its lane is declared; no task polls it here
    h.start().unwrap();
    assert_eq!(
        seq.tick(Instant::from_ticks(1_000), &ctrl, &mut mine),
        Ok(())
    );
    assert_eq!(
        seq.tick(Instant::from_ticks(2_000), &ctrl, &mut foreign),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(
        seq.tick(Instant::from_ticks(3_000), &ctrl, &mut mine),
        Ok(())
    );
}

/// `restart_limit(0)`: the run's count (0) has reached the limit at the first firing, so
/// the restart escalates at once to `AbortOwner` (item 5).
#[test]
fn restart_limit_zero_escalates_at_the_first_firing() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).restart_limit(0),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(50)).unwrap();
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, oi, Running, Aborting, k),
            tr(3, oi, Aborting, Aborted, k),
        ],
    );
}

/// The exception sequence has a 2 ms timeout of its own (AbortOwner): it is aborted by it;
/// the owner's `RestartOwner` is applied at the next tick all the same (item 3: "however it
/// ended").
#[test]
fn exception_sequence_aborted_by_its_own_timeout_still_restarts_the_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq
        .add(
            SeqConfig::new("E").timeout(Duration::from_millis(2)),
            Forever,
        )
        .unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(10_000));
    let (k, te) = (Cause::Monitor(m), Cause::Timeout(ei));
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k),
            tr(5, ei, Running, Aborting, te),
            tr(5, ei, Aborting, Aborted, te),
            tr(6, oi, Running, Restarting, k),
            tr(6, oi, Restarting, Running, Cause::Restart),
        ],
    );
}

/// A `Trigger::Level` warning (`Nothing`) with a 2 ms exception sequence, its condition true
/// from 3 ms on: it fires, the exception runs 3..5, the behaviour is applied at 6, and the
/// level monitor fires again at its first evaluation after the exception ended (item 5),
/// and so on: one exception sequence at a time, no storm within one.
#[test]
fn level_warning_fires_once_per_exception() {
    use rtseq::Trigger;
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Dwell(2)).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("warn", &mut c0, Behaviour::Nothing)
                .exception(ei)
                .trigger(Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, (3..9).contains(&ms(t)));
        c.set(9, ms(t) >= 15);
    });
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(50)).unwrap();
    let k = Cause::Monitor(m);
    let starts: Vec<u64> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == ei && t.to == Running)
        .map(|t| ms(t.time))
        .collect();
    assert_eq!(starts, [3, 6], "{}", show(sim.trace()));
    assert_eq!(sim.monitors().fired(m), 2);
    let _ = k;
    assert_eq!(sim.state(oi), Terminated);
}

/// The operator pauses the exception sequence of a `RestartOwner` monitor: the owner stays
/// held as long (item 3: "a pause of it holds the owner as long"); the dwell counts only
/// unpaused time (item 7), and the restart comes the tick after its end.
#[test]
fn paused_exception_sequence_holds_its_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(9))
        .unwrap();
    let e = seq.add(SeqConfig::new("E"), Dwell(3)).unwrap();
    let (oi, ei) = (o.id(), e.id());
    let mut c0 = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(oi).unwrap();
    sim.run_until(Instant::from_ticks(4_000));
    sim.pause(ei).unwrap();
    sim.run_until(Instant::from_ticks(8_000));
    assert!(sim.handle(oi).unwrap().exception_is_active());
    sim.resume(ei).unwrap();
    sim.run_until(Instant::from_ticks(15_000));
    let k = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(3, ei, Idle, Running, k),
            tr(5, ei, Running, Paused, Cause::Pause),
            tr(9, ei, Paused, Running, Cause::Resume),
            tr(10, ei, Running, Terminated, Cause::Completed),
            tr(11, oi, Running, Restarting, k),
            tr(11, oi, Restarting, Running, Cause::Restart),
        ],
    );
}
