//! A motor controller runs for months: the library's counts at and past their wrap (or
//! where they stop), from the public API. The 16-bit count of a sequence's starts tells
//! its runs apart (semantics 11, 14); restarts are counted in the target's run; the field
//! counts stop at 65 535.

use std::cell::Cell;

use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Error, Event, Failure, Instant, Monitor, MonitorId, Monitors,
    Outcome, Request, RunningState, SeqConfig, SeqId, Sequence, Sequencer, Transition, Trigger,
};

/// The control system: flags the sequences wait for.
#[derive(Default)]
struct Ctl {
    /// A `Quick` run completes once this is set (at once if it is set at its start).
    done: Cell<bool>,
    /// A monitor's condition.
    fault: Cell<bool>,
    /// How far `Parent` may go.
    phase: Cell<u8>,
    /// What `Parent`'s join returned.
    joined: Cell<Option<Result<Outcome, Error>>>,
}

/// Waits until `done`, then completes: with `done` set at its start it completes in the
/// lane poll of its start, without a tick.
struct Quick;
impl Sequence<Ctl> for Quick {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        cx.wait_until(|cx| cx.control().done.get()).await;
        Ok(())
    }
}

/// Starts `child` scoped, then, phase by phase: (1) starts `child` again, not scoped (only
/// if `restart_child`), (2) drops the `Scoped`, or joins it (`join`), (3) returns.
struct Parent {
    child: SeqId,
    restart_child: bool,
    join: bool,
}
impl Sequence<Ctl> for Parent {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        let scoped = cx.start_scoped(self.child)?;
        cx.wait_until(|cx| cx.control().phase.get() >= 1).await;
        if self.restart_child {
            cx.start(self.child)?;
        }
        cx.wait_until(|cx| cx.control().phase.get() >= 2).await;
        if self.join {
            let joined = scoped.join().await;
            cx.control().joined.set(Some(joined));
        } else {
            drop(scoped);
        }
        cx.wait_until(|cx| cx.control().phase.get() >= 3).await;
        Ok(())
    }
}

type Seqr = Sequencer<Ctl, 4>;

fn ms(t: Instant) -> u64 {
    t.as_ticks() / 1_000
}

/// Starts `id` (a `Quick`, with `done` set) `n` times from the application; each run
/// completes in its start. The simulator's trace is emptied now and then.
fn quick_runs<const M: usize>(sim: &mut Sim<'_, Ctl, 4, 64, M>, id: SeqId, n: u32) {
    sim.control().done.set(true);
    for i in 0..n {
        assert_eq!(sim.start(id), Ok(()), "start {i}");
        assert_eq!(sim.state(id), Terminated, "start {i}");
        if i % 4096 == 0 {
            sim.take_trace();
        }
    }
    sim.take_trace();
}

/// Semantics item 11: a dropped `Scoped` names its run by the 16-bit count and the
/// caller, so a later run meets it when the caller's own start brings the count round,
/// after 65 536 starts of the sequence in all: here the application makes 65 535 of them
/// and the caller one, and the drop asks for the abort of that new run.
#[test]
fn a_scoped_drop_meets_a_later_run_of_its_caller_once_65536_starts_bring_the_count_round() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let child = seq.add(SeqConfig::new("child"), Quick).unwrap();
    let c = child.id();
    let parent = Parent {
        child: c,
        restart_child: true,
        join: false,
    };
    let parent = seq.add(SeqConfig::new("parent"), parent).unwrap();
    let p = parent.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(child);
    sim.lane(parent);
    ctl.done.set(true);
    sim.start(p).unwrap(); // the scoped run of `child` (its run 1) completes at once
    assert_eq!(sim.state(c), Terminated);
    assert_eq!(sim.state(p), Running);
    // The application starts `child` 65 535 times: runs 2 ..= 65 536.
    quick_runs(&mut sim, c, 65_535);
    // The parent starts `child` once (run 65 537, count 1 again, caller `parent`); it runs on.
    ctl.done.set(false);
    ctl.phase.set(1);
    sim.run_for(Duration::from_millis(3));
    assert_eq!(sim.state(c), Running);
    assert_eq!(sim.handle(c).unwrap().caller(), Some(p));
    sim.take_trace();
    // The parent drops its `Scoped` (of run 1, long over).
    ctl.phase.set(2);
    sim.run_for(Duration::from_millis(3));
    // The request names the run by its count (1 again) and its caller (the same).
    let requests: Vec<Event> = sim
        .records()
        .iter()
        .filter_map(|r| r.event())
        .filter(|e| matches!(e, Event::Requested { .. }))
        .collect();
    assert_eq!(
        requests,
        [Event::Requested {
            sequence: c,
            request: Request::Abort,
            by: rtseq::Requester::Sequence(p),
        }]
    );
    assert_eq!(
        sim.handle(c).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Abort))
    );
}

/// `Monitors::fired` stops at 65 535, as the other count of the field
/// (`exceptions_not_run`) does: a `Level` warning at a 1 ms polling period gets there in
/// 65.5 s, and a count that wrapped to 0 would read as "never fired" (it did, until
/// session 50).
#[test]
fn a_monitor_s_count_of_firings_stops_at_65535() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let s = seq.add(SeqConfig::new("s"), Quick).unwrap();
    let si = s.id();
    let mut warn = |c: &Ctl, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Ctl, 1>::new();
    let m = monitors
        .add(
            si,
            Monitor::new("warning", &mut warn, Behaviour::Nothing).trigger(Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors);
    sim.lane(s);
    sim.start(si).unwrap();
    ctl.fault.set(true);
    for i in 0..65_536u32 {
        sim.step();
        if i % 4096 == 0 {
            sim.take_trace();
        }
    }
    sim.take_trace();
    assert_eq!(sim.state(si), Running);
    let fired = sim.monitors().fired(m);
    // Every poll fired (1 ms period, 65 536 ticks): the exceptions counter (documented to
    // wrap) agrees that 65 536 firings happened.
    assert_eq!(sim.handle(si).unwrap().counters().exceptions, 0);
    assert_eq!(fired, u16::MAX, "65 536 firings: `fired` reads {fired}");
}

// ---------------------------------------------------------------------------------------
// Documented behaviour at the wrap
// ---------------------------------------------------------------------------------------

/// 65 537 starts: the run count (and `Counters::runs`, documented to wrap) wrap; every
/// start, end and outcome stays right, and the last run's transitions are exact.
#[test]
fn a_sequence_runs_on_past_65536_starts() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let s = seq.add(SeqConfig::new("s"), Quick).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(s);
    quick_runs(&mut sim, si, 65_536);
    let h = sim.handle(si).unwrap();
    let c = h.counters();
    assert_eq!((c.runs, c.completed, c.aborts, c.restarts), (0, 0, 0, 0));
    // Run 65 537 (count 1 again), held, then aborted by a request.
    ctl.done.set(false);
    sim.start(si).unwrap();
    assert_eq!(sim.start(si), Err(Error::AlreadyRunning(si)));
    sim.abort(si).unwrap();
    sim.step();
    assert_eq!(
        sim.trace(),
        &[
            Transition::at_millis(0, si, Terminated, Running, Cause::Start),
            Transition::at_millis(1, si, Running, Aborting, Cause::Abort),
            Transition::at_millis(1, si, Aborting, Aborted, Cause::Abort),
        ]
    );
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    let c = h.counters();
    assert_eq!((c.runs, c.completed, c.aborts), (1, 0, 1));
}

/// Semantics item 5: restarts are counted in the target's run, and a new run begins at 0,
/// also the one whose 16-bit count meets the old run's again: with `restart_limit(1)`,
/// 65 535 and 65 536 starts after a run that was restarted once, the first firing
/// restarts the new run (until session 50 the monitor's book, which kept the count alone,
/// found the old run's restart 65 536 starts later and aborted it at once).
fn restarts_after(later: u32) -> (Vec<Transition>, Option<Event>) {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let s = seq.add(SeqConfig::new("s"), Quick).unwrap();
    let si = s.id();
    let mut fault = |c: &Ctl, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Ctl, 1>::new();
    let m = monitors
        .add(
            si,
            Monitor::new("fault", &mut fault, Behaviour::RestartOwner).restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors);
    sim.lane(s);
    // Run 1: one restart, then it completes.
    sim.start(si).unwrap();
    ctl.fault.set(true);
    sim.step();
    ctl.fault.set(false);
    ctl.done.set(true);
    sim.run_for(Duration::from_millis(3));
    assert_eq!(sim.state(si), Terminated);
    assert_eq!(
        sim.trace()
            .iter()
            .filter(|t| t.cause == Cause::Restart)
            .count(),
        1
    );
    // `later - 1` runs without a firing.
    quick_runs(&mut sim, si, later - 1);
    // The run `later` starts after run 1, and its first firing.
    ctl.done.set(false);
    sim.run_for(Duration::from_millis(1));
    let t0 = ms(sim.now());
    sim.start(si).unwrap();
    ctl.fault.set(true);
    sim.step();
    let trace: Vec<Transition> = sim
        .trace()
        .iter()
        .map(|t| Transition {
            time: Instant::from_ticks(t.time.as_ticks() - t0 * 1_000),
            ..*t
        })
        .collect();
    let fired = sim
        .records()
        .iter()
        .filter_map(|r| r.event())
        .find(|e| matches!(e, Event::Fired { .. }));
    assert_eq!(m, MonitorId::from_index(0));
    (trace, fired)
}

#[test]
fn a_new_run_has_its_own_restarts_also_65536_starts_later() {
    let si = SeqId::from_index(0);
    let m = MonitorId::from_index(0);
    for later in [65_535, 65_536] {
        let (trace, fired) = restarts_after(later);
        assert_eq!(
            trace,
            [
                Transition::at_millis(0, si, Terminated, Running, Cause::Start),
                Transition::at_millis(1, si, Running, Restarting, Cause::Monitor(m)),
                Transition::at_millis(1, si, Restarting, Running, Cause::Restart),
            ],
            "{later} starts later"
        );
        assert!(matches!(
            fired,
            Some(Event::Fired {
                behaviour: Behaviour::RestartOwner,
                ..
            })
        ));
    }
}

/// The same for a timeout (`timeout_restart_limit`).
fn timeout_restarts_after(later: u32) -> Vec<Transition> {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let cfg = SeqConfig::new("s")
        .timeout(Duration::from_millis(3))
        .timeout_behaviour(Behaviour::RestartOwner)
        .timeout_restart_limit(1);
    let s = seq.add(cfg, Quick).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(s);
    sim.start(si).unwrap();
    sim.run_for(Duration::from_millis(3)); // the timeout restarts it at 3 ms
    ctl.done.set(true);
    sim.run_for(Duration::from_millis(1));
    assert_eq!(sim.state(si), Terminated);
    assert_eq!(
        sim.trace()
            .iter()
            .filter(|t| t.cause == Cause::Restart)
            .count(),
        1
    );
    quick_runs(&mut sim, si, later - 1);
    ctl.done.set(false);
    sim.run_for(Duration::from_millis(1));
    let t0 = ms(sim.now());
    sim.start(si).unwrap();
    sim.run_for(Duration::from_millis(3));
    sim.trace()
        .iter()
        .map(|t| Transition {
            time: Instant::from_ticks(t.time.as_ticks() - t0 * 1_000),
            ..*t
        })
        .collect()
}

#[test]
fn a_new_run_has_its_own_timeout_restarts_also_65536_starts_later() {
    let si = SeqId::from_index(0);
    for later in [65_535, 65_536] {
        assert_eq!(
            timeout_restarts_after(later),
            [
                Transition::at_millis(0, si, Terminated, Running, Cause::Start),
                Transition::at_millis(3, si, Running, Restarting, Cause::Timeout(si)),
                Transition::at_millis(3, si, Restarting, Running, Cause::Restart),
            ],
            "{later} starts later"
        );
    }
}

/// Semantics item 11: with the application making the start that brings the count round
/// (caller link `None`), the later run is left alone.
#[test]
fn scoped_drop_leaves_a_later_run_of_another_starter_alone_even_at_the_same_count() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let child = seq.add(SeqConfig::new("child"), Quick).unwrap();
    let c = child.id();
    let parent = Parent {
        child: c,
        restart_child: false,
        join: false,
    };
    let parent = seq.add(SeqConfig::new("parent"), parent).unwrap();
    let p = parent.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(child);
    sim.lane(parent);
    ctl.done.set(true);
    sim.start(p).unwrap();
    quick_runs(&mut sim, c, 65_535);
    ctl.done.set(false);
    sim.start(c).unwrap(); // run 65 537: count 1, by the application
    ctl.phase.set(2);
    sim.run_for(Duration::from_millis(3));
    assert_eq!(sim.state(c), Running);
    assert!(sim
        .records()
        .iter()
        .filter_map(|r| r.event())
        .all(|e| !matches!(
            e,
            Event::Requested {
                request: Request::Abort,
                ..
            }
        )));
    // The parent's action went past its `start_scoped` and the drop: it completes.
    ctl.phase.set(3);
    sim.run_for(Duration::from_millis(3));
    assert_eq!(
        sim.handle(p).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
    assert_eq!(sim.state(c), Running);
}

/// Semantics item 14 and `Scoped::join`: the join names the scoped run by its count. After
/// 65 535 more starts (the last one ended) it is `OutcomeLost`; after 65 536 more, with the
/// last run under way, it waits for that run and returns its outcome ("meets its count
/// again").
fn scoped_join_after(more: u32) -> (Option<Result<Outcome, Error>>, RunningStateAt) {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let child = seq.add(SeqConfig::new("child"), Quick).unwrap();
    let c = child.id();
    let parent = Parent {
        child: c,
        restart_child: false,
        join: true,
    };
    let parent = seq.add(SeqConfig::new("parent"), parent).unwrap();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(child);
    sim.lane(parent);
    ctl.done.set(true);
    sim.start(parent_id(&seq)).unwrap();
    quick_runs(&mut sim, c, more - 1);
    ctl.done.set(false);
    sim.start(c).unwrap(); // the last of `more` starts, under way
    ctl.phase.set(2);
    sim.run_for(Duration::from_millis(3));
    let before = ctl.joined.take();
    ctl.done.set(true);
    sim.run_for(Duration::from_millis(3));
    (before, RunningStateAt(ctl.joined.take()))
}

#[derive(Debug, PartialEq)]
struct RunningStateAt(Option<Result<Outcome, Error>>);

fn parent_id(seq: &Seqr) -> SeqId {
    seq.sequence_by_name("parent").unwrap().id()
}

#[test]
fn scoped_join_tells_runs_apart_by_their_16_bit_count_as_documented() {
    let c = SeqId::from_index(0);
    // 65 535 more starts: another count, the join's run is over and its outcome gone. The
    // run under way is one after the joined one + 65 535: OutcomeLost at once.
    assert_eq!(
        scoped_join_after(65_535),
        (Some(Err(Error::OutcomeLost(c))), RunningStateAt(None))
    );
    // 65 536 more: the join meets its count again and waits for the new run.
    assert_eq!(
        scoped_join_after(65_536),
        (None, RunningStateAt(Some(Ok(Outcome::Completed))))
    );
}

/// `exceptions_not_run` stops at 65 535 (firmware guide section 5); `Counters::exceptions`
/// wraps (documented).
#[test]
fn exceptions_not_run_saturates_at_65535() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let e = seq.add(SeqConfig::new("e"), Quick).unwrap();
    let ei = e.id();
    let s = seq.add(SeqConfig::new("s"), Quick).unwrap();
    let si = s.id();
    let mut warn = |c: &Ctl, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Ctl, 1>::new();
    monitors
        .add(
            si,
            Monitor::new("warning", &mut warn, Behaviour::Nothing)
                .trigger(Trigger::Level)
                .exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors);
    sim.lane(e);
    sim.lane(s);
    sim.start(ei).unwrap(); // runs for good: the exception sequence is already running
    sim.start(si).unwrap();
    ctl.fault.set(true);
    for i in 0..65_537u32 {
        sim.step();
        if i % 4096 == 0 {
            sim.take_trace();
        }
    }
    assert_eq!(seq.exceptions_not_run(), u16::MAX);
    assert_eq!(sim.handle(si).unwrap().counters().exceptions, 1);
    assert_eq!((sim.state(si), sim.state(ei)), (Running, Running));
}

/// Requests after the wrap: a pause/resume/abort of the current run is carried out (the
/// request names the run by its count, which is 0 at the 65 536th start).
#[test]
fn requests_of_run_65536_whose_count_is_zero_are_carried_out() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let s = seq.add(SeqConfig::new("s"), Quick).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(s);
    quick_runs(&mut sim, si, 65_535);
    ctl.done.set(false);
    sim.start(si).unwrap(); // run 65 536: count 0
    sim.pause(si).unwrap();
    sim.step();
    assert_eq!(sim.state(si), Paused);
    sim.resume(si).unwrap();
    sim.step();
    assert_eq!(sim.state(si), Running);
    ctl.done.set(true);
    sim.step();
    assert_eq!(sim.state(si), Terminated);
    assert_eq!(
        sim.handle(si).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
}

/// Starts `s` non-blocking (it is then `s`'s caller), then waits for `done`.
struct Starter {
    s: SeqId,
}
impl Sequence<Ctl> for Starter {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        cx.start(self.s)?;
        cx.wait_until(|cx| cx.control().done.get()).await;
        Ok(())
    }
}

/// Semantics item 5: restarts are bounded per run of the target.
///
/// With `RestartCallerOfOwner` the target is the owner's caller of the moment: `move` is
/// started by `homing` (run 1) and later by `jog` (run 1, never restarted).
/// `restart_limit(1)`: the firing in homing's run 1 restarts homing; the first firing in
/// jog's run 1 restarts jog, since restarts are counted in the target's run
/// (until session 50 it kept the count alone, found 1 there, and aborted jog at once).
#[test]
fn a_restart_budget_spent_on_one_caller_is_not_charged_to_another_with_the_same_run_count() {
    let seq: Sequencer<Ctl, 4> = Sequencer::new();
    let ctl = Ctl::default();
    let mv = seq.add(SeqConfig::new("move"), Quick).unwrap();
    let mi = mv.id();
    let homing = seq
        .add(SeqConfig::new("homing"), Starter { s: mi })
        .unwrap();
    let hi = homing.id();
    let jog = seq.add(SeqConfig::new("jog"), Starter { s: mi }).unwrap();
    let ji = jog.id();
    let mut fault = |c: &Ctl, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Ctl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new(
                "following error",
                &mut fault,
                Behaviour::RestartCallerOfOwner,
            )
            .restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors);
    sim.lane(mv);
    sim.lane(homing);
    sim.lane(jog);
    // homing's run 1: the following error restarts homing once, then all completes.
    sim.start(hi).unwrap();
    assert_eq!(sim.handle(mi).unwrap().caller(), Some(hi));
    ctl.fault.set(true);
    sim.step();
    ctl.fault.set(false);
    assert!(sim.trace().contains(&Transition::at_millis(
        1,
        hi,
        Running,
        Restarting,
        Cause::Monitor(m)
    )));
    ctl.done.set(true);
    sim.run_for(Duration::from_millis(3));
    assert_eq!((sim.state(hi), sim.state(mi)), (Terminated, Terminated));
    ctl.done.set(false);
    sim.take_trace();
    // jog's run 1, its first following error.
    sim.start(ji).unwrap();
    assert_eq!(sim.handle(mi).unwrap().caller(), Some(ji));
    ctl.fault.set(true);
    sim.step();
    let fired = sim
        .records()
        .iter()
        .filter_map(|r| r.event())
        .find(|e| matches!(e, Event::Fired { .. }));
    assert_eq!(
        fired,
        Some(Event::Fired {
            owner: mi,
            cause: Cause::Monitor(m),
            behaviour: Behaviour::RestartCallerOfOwner,
        }),
        "jog's first restart was refused: {:?}",
        sim.trace()
    );
    assert!(sim.trace().contains(&Transition::at_millis(
        5,
        ji,
        Running,
        Restarting,
        Cause::Monitor(m)
    )));
}

/// Control of the `Looper`s: whose turn it is (0: nobody), and when `Held` ends.
#[derive(Default)]
struct Turns {
    turn: Cell<u8>,
    fault: Cell<bool>,
    s_done: Cell<bool>,
}

/// Waits for `turn == me`, starts `s` non-blocking (its caller), joins it, gives the turn
/// back; again and again.
struct Looper {
    me: u8,
    s: SeqId,
}
impl Sequence<Turns> for Looper {
    async fn action(&mut self, cx: &Cx<'_, Turns>) -> Result<(), Failure> {
        loop {
            cx.wait_until(|cx| cx.control().turn.get() == self.me).await;
            cx.start(self.s)?;
            let _ = cx.join(self.s).await;
            cx.control().turn.set(0);
        }
    }
}

/// Runs until `s_done`.
struct Held;
impl Sequence<Turns> for Held {
    async fn action(&mut self, cx: &Cx<'_, Turns>) -> Result<(), Failure> {
        cx.wait_until(|cx| cx.control().s_done.get()).await;
        Ok(())
    }
}

/// No storms (semantics item 4): `move` is started in turns by `homing` (run 1
/// throughout) and `jog` (run 2 throughout: started, aborted, started again); its monitor
/// (`RestartCallerOfOwner`, `restart_limit(1)`) fires once in each turn. Homing's run is
/// restarted once, and its second firing aborts it. (Until session 50 a monitor kept one
/// book of the last target it restarted: each caller's firing reset the other's, and
/// homing's single run was restarted in every one of its turns, without bound.)
#[test]
fn callers_in_turns_each_get_their_own_restarts_and_no_more() {
    let seq: Sequencer<Turns, 4> = Sequencer::new();
    let ctl = Turns::default();
    let mv = seq.add(SeqConfig::new("move"), Held).unwrap();
    let mi = mv.id();
    let homing = seq
        .add(SeqConfig::new("homing"), Looper { me: 1, s: mi })
        .unwrap();
    let hi = homing.id();
    let jog = seq
        .add(SeqConfig::new("jog"), Looper { me: 2, s: mi })
        .unwrap();
    let ji = jog.id();
    let mut fault = |c: &Turns, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Turns, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new(
                "following error",
                &mut fault,
                Behaviour::RestartCallerOfOwner,
            )
            .restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors);
    sim.lane(mv);
    sim.lane(homing);
    sim.lane(jog);
    // jog: run 2 from now on.
    sim.start(ji).unwrap();
    sim.abort(ji).unwrap();
    sim.step();
    sim.start(ji).unwrap();
    sim.start(hi).unwrap();
    let mut homing_fate = Vec::new();
    for turn in [1u8, 2, 1, 2, 1] {
        ctl.turn.set(turn);
        sim.run_for(Duration::from_millis(2));
        assert_eq!(sim.state(mi), Running, "turn {turn}");
        ctl.fault.set(true);
        sim.step();
        ctl.fault.set(false);
        sim.step();
        if turn == 1 {
            homing_fate.push(sim.state(hi));
            if sim.state(hi) != Running {
                break;
            }
        }
        ctl.s_done.set(true);
        sim.run_for(Duration::from_millis(2));
        ctl.s_done.set(false);
        assert_eq!(ctl.turn.get(), 0, "turn {turn} given back");
    }
    // homing is still in its first run (a restart is no start).
    assert_eq!(sim.handle(hi).unwrap().counters().runs, 1);
    let homing_restarts = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == hi && t.cause == Cause::Monitor(m) && t.to == Restarting)
        .count();
    assert_eq!(
        (
            homing_restarts,
            homing_fate,
            sim.handle(hi).unwrap().last_outcome()
        ),
        (
            1,
            vec![Running, Aborted],
            Some(Outcome::Aborted(Cause::Monitor(m)))
        ),
        "homing's single run restarted {homing_restarts} times with restart_limit(1)"
    );
}

/// The same for a timeout: the timeout of
/// `move` restarts its caller (`RestartCallerOfOwner`, `timeout_restart_limit(1)`): in
/// homing's run 1 it restarts homing, and in jog's run 1 jog.
#[test]
fn a_timeout_restart_budget_spent_on_one_caller_is_not_charged_to_another() {
    let seq: Sequencer<Ctl, 4> = Sequencer::new();
    let ctl = Ctl::default();
    let cfg = SeqConfig::new("move")
        .timeout(Duration::from_millis(3))
        .timeout_behaviour(Behaviour::RestartCallerOfOwner)
        .timeout_restart_limit(1);
    let mv = seq.add(cfg, Quick).unwrap();
    let mi = mv.id();
    let homing = seq
        .add(SeqConfig::new("homing"), Starter { s: mi })
        .unwrap();
    let hi = homing.id();
    let jog = seq.add(SeqConfig::new("jog"), Starter { s: mi }).unwrap();
    let ji = jog.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(mv);
    sim.lane(homing);
    sim.lane(jog);
    sim.start(hi).unwrap();
    sim.run_for(Duration::from_millis(3));
    assert!(sim.trace().contains(&Transition::at_millis(
        3,
        hi,
        Running,
        Restarting,
        Cause::Timeout(mi)
    )));
    ctl.done.set(true);
    sim.run_for(Duration::from_millis(1));
    assert_eq!((sim.state(hi), sim.state(mi)), (Terminated, Terminated));
    ctl.done.set(false);
    sim.take_trace();
    sim.start(ji).unwrap(); // at 4 ms
    sim.run_for(Duration::from_millis(3));
    let expiry: Vec<Transition> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == ji)
        .copied()
        .collect();
    assert_eq!(
        expiry,
        [
            Transition::at_millis(4, ji, Idle, Running, Cause::Start),
            Transition::at_millis(7, ji, Running, Restarting, Cause::Timeout(mi)),
            Transition::at_millis(7, ji, Restarting, Running, Cause::Restart),
        ],
        "jog's first timeout restart was refused"
    );
}

/// Runs until `phase >= 1` (an operator's acknowledgement).
struct Ack;
impl Sequence<Ctl> for Ack {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        cx.wait_until(|cx| cx.control().phase.get() >= 1).await;
        Ok(())
    }
}

/// Semantics item 6: "A timeout that falls due while an exception of its owner is being
/// handled fires at the first tick after that exception ended" (also firmware guide §2).
///
/// `s` has a 30 min timeout; at 29 min a warning monitor (`Nothing`) starts its exception
/// sequence, which waits for an acknowledgement that comes at `ack_min`: ended at 40 min
/// or at 74 min (past 2^32 µs of run time, where a 32-bit clock read 2.4 min), the timeout
/// fires at the first tick after the exception.
fn timeout_after_an_exception_ending_at(ack_min: u64) -> (RunningState, Option<Outcome>, u64) {
    let seq: Sequencer<Ctl, 4> = Sequencer::new();
    let ctl = Ctl::default();
    let sec = Duration::from_secs(1);
    let e = seq
        .add(SeqConfig::new("operator ack").polling(sec), Ack)
        .unwrap();
    let ei = e.id();
    let cfg = SeqConfig::new("s")
        .polling(sec)
        .timeout(Duration::from_secs(30 * 60));
    let s = seq.add(cfg, Quick).unwrap();
    let si = s.id();
    let mut warn = |c: &Ctl, _: Instant| c.fault.get();
    let mut monitors = Monitors::<Ctl, 1>::new();
    monitors
        .add(
            si,
            Monitor::new("warning", &mut warn, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctl, monitors).with_period(sec).unwrap();
    sim.lane(e);
    sim.lane(s);
    sim.start(si).unwrap();
    sim.run_until(Instant::from_ticks(29 * 60_000_000));
    ctl.fault.set(true);
    sim.step();
    assert_eq!(sim.state(ei), Running);
    sim.run_until(Instant::from_ticks(ack_min * 60_000_000));
    assert_eq!(sim.state(si), Running);
    ctl.phase.set(1);
    sim.run_for(Duration::from_secs(10));
    let h = sim.handle(si).unwrap();
    let ended = sim
        .trace()
        .iter()
        .find(|t| t.sequence == si && t.to == Aborted)
        .map_or(0, |t| t.time.as_ticks() / 1_000_000);
    (h.state(), h.last_outcome(), ended)
}

#[test]
fn a_timeout_due_during_a_long_exception_fires_when_the_exception_ends() {
    let si = SeqId::from_index(1);
    // Documented, and so: the exception ends at 40 min (its end is seen at 40 min 1 s).
    let (state, outcome, _) = timeout_after_an_exception_ending_at(40);
    assert_eq!(
        (state, outcome),
        (Aborted, Some(Outcome::Aborted(Cause::Timeout(si))))
    );
    // The exception ends at 74 min: the overdue timeout should fire as well.
    let (state, outcome, at) = timeout_after_an_exception_ending_at(74);
    assert_eq!(
        (state, outcome),
        (Aborted, Some(Outcome::Aborted(Cause::Timeout(si)))),
        "30 min timeout overdue by 44 min not fired after the exception (aborted at {at} s)"
    );
}

/// 70 polled waits of one action awaited at once (the context counts them in 6 bits,
/// saturating at 63): semantics item 1, "Several `Cx::wait_until` of one action awaited
/// at once are each checked at every due poll". Wait `i` holds from tick `i`; each returns
/// in the poll of tick `i`, then the action goes on and completes.
struct ManyWaits;
impl Sequence<Ctl> for ManyWaits {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        let waits: [_; 70] = core::array::from_fn(|i| {
            let i = i as u64;
            async move {
                cx.wait_until(move |cx| cx.now().as_ticks() >= (i + 1) * 1_000)
                    .await;
                assert_eq!(cx.now().as_ticks(), (i + 1) * 1_000, "wait {i}");
            }
        });
        embassy_futures::join::join_array(waits).await;
        // After all 70: one more wait, for `done`, then the end.
        cx.wait_until(|cx| cx.control().done.get()).await;
        Ok(())
    }
}

#[test]
fn seventy_polled_waits_at_once_each_return_at_their_poll() {
    let seq = Seqr::new();
    let ctl = Ctl::default();
    let s = seq.add(SeqConfig::new("many"), ManyWaits).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctl, Monitors::<Ctl, 1>::new());
    sim.lane(s);
    sim.start(si).unwrap();
    sim.run_for(Duration::from_millis(75));
    assert_eq!(sim.state(si), Running);
    ctl.done.set(true);
    sim.step();
    assert_eq!(
        sim.trace().last(),
        Some(&Transition::at_millis(
            76,
            si,
            Running,
            Terminated,
            Cause::Completed
        ))
    );
}
