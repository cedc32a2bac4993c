//! `exception_is_active` / `active_exception` of the caller a `…CallerOfOwner` behaviour
//! (or a timeout with one) aborts or restarts, black box, and the claims of the docs that
//! change touched (a cold review of session 58's change). Race-dependent cases are in
//! `src/sequencer/interleavings/exception_marks_of_callers.rs`.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Restart, Start, Timeout};
use rtseq::RunningState::*;
use rtseq::{Behaviour, Duration, Error, Monitor, Monitors, SeqConfig, SeqId, Sequencer};

fn millis(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn has(trace: &[rtseq::Transition], want: rtseq::Transition) -> bool {
    trace.contains(&want)
}

// ---------------------------------------------------------------------------------------
// The caller a `…CallerOfOwner` behaviour stops is marked.
// ---------------------------------------------------------------------------------------

/// A step S (timeout 3 ms, `timeout_behaviour(AbortCallerOfOwner)`) run by A: A is aborted
/// because of S's timeout, and marked with it (`Cause::is_exception` covers timeouts).
#[test]
fn a_timeout_s_abort_caller_of_owner_marks_the_caller_with_the_timeout() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            SeqConfig::new("S")
                .timeout(millis(3))
                .timeout_behaviour(Behaviour::AbortCallerOfOwner),
            Leaf::until(15),
        )
        .unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.run_for(millis(10));
    assert_eq!((sim.state(si), sim.state(ai)), (Aborted, Aborted));
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (true, Some(Timeout(si)))
    );
    let hs = sim.handle(si).unwrap();
    assert_eq!(
        (hs.exception_is_active(), hs.active_exception()),
        (true, Some(Timeout(si)))
    );
    assert!(Timeout(si).is_exception() && Mon(rtseq::MonitorId::from_index(0)).is_exception());
    for c in [
        Start,
        Completed,
        Restart,
        Cause::Abort,
        Cause::AbortAll,
        Cause::Dropped,
    ] {
        assert!(!c.is_exception(), "{c:?}");
    }
}

/// A runs step S; S's `RestartCallerOfOwner` monitor fires at 3 ms. Semantics item 5: "A
/// restart aborts what the target runs and runs the target's action again (`Running ->
/// Restarting (monitor …)`, `Restarting -> Running (restart)`); the children the new round
/// starts begin new runs (`Aborted -> Running (start)`)". And the restarted round begins
/// without the mark, seen from inside A's action (each logged line records
/// `exception_is_active`), while `active_exception` keeps naming the monitor.
#[test]
fn a_restarted_caller_s_new_round_begins_unmarked_seen_from_its_action() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::RestartCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(ai).unwrap();
    // The simulator's lanes take the restart up in the tick's step.
    sim.run_for(millis(8));
    assert_eq!((sim.state(ai), sim.state(si)), (Running, Running));
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (false, Some(Mon(m)))
    );
    let a_lines: Vec<_> = ctrl
        .lines
        .borrow()
        .iter()
        .filter(|l| l.seq == ai)
        .copied()
        .collect();
    assert_eq!(a_lines.len(), 2, "{a_lines:?}");
    assert!(a_lines.iter().all(|l| !l.held), "{a_lines:?}");
    let trace = sim.trace();
    assert!(
        has(trace, tr(3, ai, Running, Restarting, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(3, si, Aborting, Aborted, Mon(m))),
        "{}",
        show(trace)
    );
    let restart = trace
        .iter()
        .find(|t| t.sequence == ai && t.from == Restarting)
        .copied()
        .unwrap();
    assert_eq!(
        (restart.to, restart.cause),
        (Running, Restart),
        "{}",
        show(trace)
    );
    let again = trace
        .iter()
        .find(|t| t.sequence == si && t.from == Aborted)
        .copied()
        .unwrap();
    assert_eq!((again.to, again.cause), (Running, Start), "{}", show(trace));
}

/// `RestartCallerOfOwner` with `restart_limit(0)` escalates to `AbortCallerOfOwner`: the
/// caller is aborted because of the exception, and marked (an escalated restart).
#[test]
fn an_escalated_restart_caller_of_owner_marks_the_aborted_caller() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::RestartCallerOfOwner).restart_limit(0),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(6));
    assert_eq!((sim.state(si), sim.state(ai)), (Aborted, Aborted));
    for id in [si, ai] {
        let h = sim.handle(id).unwrap();
        assert_eq!(
            (h.exception_is_active(), h.active_exception()),
            (true, Some(Mon(m)))
        );
    }
}

/// The caller of a caller behaviour that is aborted by an abort-all while the owner's
/// exception sequence runs (before the behaviour applied) is not marked: the behaviour never
/// acted on it.
#[test]
fn a_caller_aborted_by_an_abort_all_before_the_caller_behaviour_applied_is_not_marked() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::AbortCallerOfOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(4));
    sim.abort_all();
    sim.run_for(millis(3));
    assert_eq!(sim.state(ai), Aborted);
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (false, None)
    );
}

// ---------------------------------------------------------------------------------------
// design-decisions.md: "An exception sequence that ends at once still puts the behaviour
// one tick later".
// ---------------------------------------------------------------------------------------

#[test]
fn an_exception_sequence_that_ends_at_once_puts_the_behaviour_one_tick_later() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(1))
        .unwrap();
    let xi = x.id();
    let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 3));
    sim.start(xi).unwrap();
    sim.run_for(millis(8));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(3, ei, Idle, Running, Mon(m)),
            tr(3, ei, Running, Terminated, Completed),
            tr(4, xi, Running, Aborting, Mon(m)),
            tr(4, xi, Aborting, Aborted, Mon(m)),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// semantics.md item 7, `PauseOwner`: "not its non-blocking children: their monitors and
// timeouts go on; both moves record the monitor as their cause, `Paused -> Running
// (monitor …)`, where a resume request records `(resume)`".
// ---------------------------------------------------------------------------------------

#[test]
fn pause_owner_leaves_non_blocking_children_running_and_records_the_monitor_both_ways() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let n = seq
        .add(
            SeqConfig::new("N").timeout(millis(4)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let ni = n.id();
    let x = seq
        .add(
            SeqConfig::new("X"),
            Node::of(vec![Op::Start(ni), Op::Step(s)]),
        )
        .unwrap();
    let xi = x.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(xi, Monitor::new("hold", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(n);
    sim.before_tick(|t, c| c.set(0, (2..=7).contains(&ms(t))));
    sim.start(xi).unwrap();
    sim.run_for(millis(10));
    let trace = sim.trace();
    assert!(
        has(trace, tr(2, xi, Running, Paused, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(2, si, Running, Paused, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        !trace.iter().any(|t| t.sequence == ni && t.to == Paused),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(4, ni, Running, Aborting, Timeout(ni))),
        "N's timeout ran out during the hold: {}",
        show(trace)
    );
    assert!(
        has(trace, tr(8, xi, Paused, Running, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(8, si, Paused, Running, Mon(m))),
        "{}",
        show(trace)
    );
    // The hold marks no exception.
    assert_eq!(sim.handle(xi).unwrap().active_exception(), None);
}

#[test]
fn a_resume_request_records_resume() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(15))
        .unwrap();
    let xi = x.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(x);
    sim.start(xi).unwrap();
    sim.run_for(millis(2));
    sim.pause(xi).unwrap();
    sim.run_for(millis(2));
    sim.resume(xi).unwrap();
    sim.run_for(millis(2));
    let trace = sim.trace();
    let back = trace
        .iter()
        .find(|t| t.sequence == xi && t.from == Paused)
        .copied()
        .unwrap();
    assert_eq!(
        (back.to, back.cause),
        (Running, Cause::Resume),
        "{}",
        show(trace)
    );
}

/// semantics item 7 / `Handle::resume`: "While a `PauseOwner` monitor holds the sequence a
/// resume is refused (`HeldByMonitor`) and takes back nothing, not even a pending pause: a
/// pause requested before keeps the sequence paused after the release, until a resume
/// then."
#[test]
fn a_refused_resume_during_a_hold_takes_back_no_pending_pause() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(15))
        .unwrap();
    let xi = x.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(xi, Monitor::new("hold", &mut c0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| c.set(0, (2..=5).contains(&ms(t))));
    sim.start(xi).unwrap();
    sim.run_for(millis(3));
    assert_eq!(sim.state(xi), Paused);
    // A pause requested and, before the next tick, a resume: the resume is refused and the
    // pause stays pending.
    sim.pause(xi).unwrap();
    assert_eq!(sim.resume(xi), Err(Error::HeldByMonitor(xi)));
    sim.run_for(millis(6));
    assert_eq!(sim.state(xi), Paused, "{}", show(sim.trace()));
    sim.resume(xi).unwrap();
    sim.run_for(millis(2));
    assert_eq!(sim.state(xi), Running, "{}", show(sim.trace()));
}

/// firmware-guide.md: `Sim<'_, C, N, T, M, …>` names the sequencer's `T` (64 unless
/// chosen): a helper naming its simulator's type compiles with it.
#[test]
fn a_helper_names_the_simulator_s_type_with_t_written_out() {
    fn run(sim: &mut Sim<'_, Ctrl, 2, 64, 1>, id: SeqId) {
        sim.start(id).unwrap();
        sim.run_for(millis(2));
    }
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq.add(SeqConfig::new("X"), Node::of(vec![])).unwrap();
    let xi = x.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(x);
    run(&mut sim, xi);
    assert_eq!(sim.state(xi), Terminated);
}

// ---------------------------------------------------------------------------------------
// design-decisions.md: "`Cx::wait_until` and `Cx::join` wait inside an action; the tick
// keeps evaluating the monitors and the timeout meanwhile".
// ---------------------------------------------------------------------------------------

struct WaitsForFlag(usize);
impl rtseq::Sequence<Ctrl> for WaitsForFlag {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), rtseq::Failure> {
        let f = self.0;
        cx.wait_until(|cx| cx.control().flag(f)).await;
        Ok(())
    }
}

/// A monitor fires and a timeout runs out while an action waits in `wait_until`.
#[test]
fn monitors_and_the_timeout_act_while_an_action_waits_in_wait_until() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq.add(SeqConfig::new("X"), WaitsForFlag(15)).unwrap();
    let xi = x.id();
    let y = seq
        .add(SeqConfig::new("Y").timeout(millis(5)), WaitsForFlag(15))
        .unwrap();
    let yi = y.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(xi, Monitor::new("m", &mut c0, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(y);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 3));
    sim.start(xi).unwrap();
    sim.start(yi).unwrap();
    sim.run_for(millis(10));
    let trace = sim.trace();
    assert!(
        has(trace, tr(3, xi, Aborting, Aborted, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(5, yi, Aborting, Aborted, Timeout(yi))),
        "{}",
        show(trace)
    );
}

// ---------------------------------------------------------------------------------------
// A mark left over from a restart, read by a later teardown from above.
// ---------------------------------------------------------------------------------------

/// P: starts O (non-blocking) in its first round only, then waits.
struct StartsOnce(SeqId);
impl rtseq::Sequence<Ctrl> for StartsOnce {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), rtseq::Failure> {
        if !cx.control().flag(10) {
            cx.control().set(10, true);
            cx.start(self.0)?;
        }
        cx.wait_until(|cx| cx.control().flag(15)).await;
        Ok(())
    }
}

/// Q: in its first round starts P, then O at flag 6; then waits.
struct Supervisor(SeqId, SeqId);
impl rtseq::Sequence<Ctrl> for Supervisor {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), rtseq::Failure> {
        if !cx.control().flag(11) {
            cx.control().set(11, true);
            cx.start(self.0)?;
            cx.wait_until(|cx| cx.control().flag(6)).await;
            cx.start(self.1)?;
        }
        cx.wait_until(|cx| cx.control().flag(15)).await;
        Ok(())
    }
}

/// O (a move, its own lane) has a stall monitor M (`RestartCallerOfOwner`). At 3 ms it
/// stalls under P, which started it: P is restarted (marked with M; its new round does not
/// start O again). At 6 ms Q (P's caller) starts O itself, and at 9 ms M fires again: it
/// restarts Q, and P, below Q, is aborted by that teardown from above. The rustdoc of
/// `exception_is_active`: "sequences below the behaviour's target are aborted by the
/// teardown from above, not marked"; semantics item 3: it ends with "a teardown from
/// above".
#[test]
fn a_sequence_aborted_from_above_by_the_monitor_that_once_restarted_it_is_not_marked() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(15))
        .unwrap();
    let oi = o.id();
    let p = seq.add(SeqConfig::new("P"), StartsOnce(oi)).unwrap();
    let pi = p.id();
    let q = seq.add(SeqConfig::new("Q"), Supervisor(pi, oi)).unwrap();
    let qi = q.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("stall", &mut c0, Behaviour::RestartCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(p);
    sim.lane(q);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 3 || ms(t) == 9);
        c.set(6, ms(t) >= 6);
    });
    sim.start(qi).unwrap();
    sim.run_for(millis(5));
    let trace = sim.trace().to_vec();
    assert!(
        has(&trace, tr(3, pi, Running, Restarting, Mon(m))),
        "{}",
        show(&trace)
    );
    assert_eq!(sim.state(pi), Running);
    assert!(
        !sim.handle(pi).unwrap().exception_is_active(),
        "new round unmarked"
    );
    sim.run_for(millis(6));
    let trace = sim.trace();
    assert!(
        has(trace, tr(9, qi, Running, Restarting, Mon(m))),
        "{}",
        show(trace)
    );
    assert!(
        has(trace, tr(9, pi, Aborting, Aborted, Mon(m))),
        "{}",
        show(trace)
    );
    assert_eq!(sim.state(pi), Aborted, "{}", show(trace));
    let hp = sim.handle(pi).unwrap();
    // P's `active_exception` still names M from its earlier restart, but that round's mark
    // went with it: P, aborted by the teardown of Q from above, is not marked.
    assert!(
        !hp.exception_is_active(),
        "P aborted from above reads exception_is_active (active {:?})",
        hp.active_exception()
    );
}
