//! Each of the five behaviours, and `PauseOwner`, with and without an exception sequence, on
//! exact traces.
//!
//! Tree: main ─run→ P ─run→ A ─step→ S (exit: flag 1). Monitor `m` on A watches flag 0,
//! which pulses at 5 ms; flag 1 comes at 10 ms. The exception sequence E waits 2 ms.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Monitor as Mon, Restart, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Done, Duration, Failure, Monitor, MonitorId, Monitors, SeqConfig, SeqId, Sequencer,
    Transition, Trigger, Wait,
};

struct Ids {
    main: SeqId,
    p: SeqId,
    a: SeqId,
    s: SeqId,
    e: SeqId,
    w: SeqId,
}

fn run(behaviour: Behaviour, with_exception: bool) -> (Vec<Transition>, Ids, MonitorId, Ctrl) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
    let a = seq.add(SeqConfig::new("A"), Node::of(vec![])).unwrap();
    let p = seq.add(SeqConfig::new("P"), Node::of(vec![])).unwrap();
    let main = seq.add(SeqConfig::new("main"), Node::of(vec![])).unwrap();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let ids = Ids {
        main: main.id(),
        p: p.id(),
        a: a.id(),
        s: s.id(),
        e: SeqId::from_index(5),
        w: w.id(),
    };
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    assert_eq!(e.id(), ids.e);
    let (mut a, mut p, mut main) = (a, p, main);
    a.body_mut().ops.push(Op::Step(s));
    p.body_mut().ops.push(Op::Run(a));
    main.body_mut().ops.push(Op::Run(p));

    let mut flag0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let mut def = Monitor::new("m", &mut flag0, behaviour);
    if with_exception {
        def = def.exception(ids.e);
    }
    let m = monitors.add(ids.a, def).unwrap();
    let trace = {
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.lane(main);
        sim.lane(e);
        sim.before_tick(|t, c| {
            c.set(0, ms(t) == 5);
            c.set(1, ms(t) >= 10);
        });
        sim.start(ids.main).unwrap();
        assert_eq!(
            sim.run_until_idle(Duration::from_millis(50)).map(ms),
            Some(10)
                .filter(|_| {
                    !(matches!(
                        behaviour,
                        Behaviour::AbortOwner | Behaviour::AbortCallerOfOwner
                    ))
                })
                .or(Some(if with_exception { 8 } else { 5 }))
        );
        assert_eq!(sim.lost(), 0);
        sim.take_trace()
    };
    (trace, ids, m, ctrl)
}

/// The prefix every scenario shares: everything starts at 0 ms.
fn start(i: &Ids) -> Vec<Transition> {
    vec![
        tr(0, i.main, Idle, Running, Start),
        tr(0, i.p, Idle, Running, Start),
        tr(0, i.a, Idle, Running, Start),
        tr(0, i.s, Idle, Running, Start),
    ]
}

/// The exception sequence E runs from 5 to 7 ms; its behaviour applies at the next tick.
fn exception(i: &Ids, m: MonitorId) -> Vec<Transition> {
    vec![
        tr(5, i.e, Idle, Running, Mon(m)),
        tr(5, i.w, Idle, Running, Start),
        tr(7, i.w, Running, Terminated, Completed),
        tr(7, i.e, Running, Terminated, Completed),
    ]
}

fn aborted(t: u64, seqs: &[SeqId], cause: rtseq::Cause) -> Vec<Transition> {
    seqs.iter()
        .flat_map(|&s| {
            [
                tr(t, s, Running, Aborting, cause),
                tr(t, s, Aborting, Aborted, cause),
            ]
        })
        .collect()
}

fn completed(t: u64, seqs: &[SeqId]) -> Vec<Transition> {
    seqs.iter()
        .map(|&s| tr(t, s, Running, Terminated, Completed))
        .collect()
}

fn check(behaviour: Behaviour, with_exception: bool) {
    let (trace, i, m, ctrl) = run(behaviour, with_exception);
    let mut want = start(&i);
    let t = if with_exception {
        want.extend(exception(&i, m));
        8
    } else {
        5
    };
    let cause = Mon(m);
    match behaviour {
        Behaviour::Nothing => want.extend(completed(10, &[i.s, i.a, i.p, i.main])),
        Behaviour::AbortOwner => {
            want.extend(aborted(t, &[i.s, i.a], cause));
            want.extend(completed(t, &[i.p, i.main]));
        }
        Behaviour::AbortCallerOfOwner => {
            want.extend(aborted(t, &[i.s, i.a, i.p], cause));
            want.extend(completed(t, &[i.main]));
        }
        Behaviour::RestartOwner => {
            want.extend(aborted(t, &[i.s], cause));
            want.push(tr(t, i.a, Running, Restarting, cause));
            want.push(tr(t, i.a, Restarting, Running, Restart));
            want.push(tr(t, i.s, Aborted, Running, Start));
            want.extend(completed(10, &[i.s, i.a, i.p, i.main]));
        }
        Behaviour::RestartCallerOfOwner => {
            want.extend(aborted(t, &[i.s, i.a], cause));
            want.push(tr(t, i.p, Running, Restarting, cause));
            want.push(tr(t, i.p, Restarting, Running, Restart));
            want.push(tr(t, i.a, Aborted, Running, Start));
            want.push(tr(t, i.s, Aborted, Running, Start));
            want.extend(completed(10, &[i.s, i.a, i.p, i.main]));
        }
        Behaviour::PauseOwner => {
            // The owner and its step are held while the pulse lasts (5 ms); the exception
            // sequence starts on entry and runs meanwhile, holding nothing.
            want = start(&i);
            let held = [
                tr(5, i.a, Running, Paused, cause),
                tr(5, i.s, Running, Paused, cause),
            ];
            if with_exception {
                want.push(tr(5, i.e, Idle, Running, cause));
                want.extend(held);
                want.push(tr(5, i.w, Idle, Running, Start));
            } else {
                want.extend(held);
            }
            want.push(tr(6, i.a, Paused, Running, cause));
            want.push(tr(6, i.s, Paused, Running, cause));
            if with_exception {
                want.extend(exception(&i, m).split_off(2));
            }
            want.extend(completed(10, &[i.s, i.a, i.p, i.main]));
        }
    }
    assert_eq!(
        trace,
        want,
        "\n got:\n{}\nwant:\n{}",
        show(&trace),
        show(&want)
    );
    assert_lines_ran_live(&ctrl);
    // What the owner's caller got back.
    let returned_to_p: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == i.p)
        .map(|r| (r.ms, r.result))
        .collect();
    let expected_p = match behaviour {
        Behaviour::AbortOwner => vec![(t, Err(Failure::Aborted(cause)))],
        Behaviour::AbortCallerOfOwner => vec![],
        _ => vec![(10, Ok(Done::Completed))],
    };
    assert_eq!(returned_to_p, expected_p);
}

#[test]
fn nothing_without_exception_sequence() {
    check(Behaviour::Nothing, false);
}
#[test]
fn nothing_with_exception_sequence() {
    check(Behaviour::Nothing, true);
}
#[test]
fn abort_owner_without_exception_sequence() {
    check(Behaviour::AbortOwner, false);
}
#[test]
fn abort_owner_with_exception_sequence() {
    check(Behaviour::AbortOwner, true);
}
#[test]
fn restart_owner_without_exception_sequence() {
    check(Behaviour::RestartOwner, false);
}
#[test]
fn restart_owner_with_exception_sequence() {
    check(Behaviour::RestartOwner, true);
}
#[test]
fn abort_caller_of_owner_without_exception_sequence() {
    check(Behaviour::AbortCallerOfOwner, false);
}
#[test]
fn abort_caller_of_owner_with_exception_sequence() {
    check(Behaviour::AbortCallerOfOwner, true);
}
#[test]
fn restart_caller_of_owner_without_exception_sequence() {
    check(Behaviour::RestartCallerOfOwner, false);
}
#[test]
fn restart_caller_of_owner_with_exception_sequence() {
    check(Behaviour::RestartCallerOfOwner, true);
}
#[test]
fn pause_owner_without_exception_sequence() {
    check(Behaviour::PauseOwner, false);
}
#[test]
fn pause_owner_with_exception_sequence() {
    check(Behaviour::PauseOwner, true);
}

/// A warning: a `Level` monitor with `Nothing` and no exception sequence, whose condition
/// holds from 2 ms on, fires at every poll of its owner, a move that ends once flag 1 is
/// set (at 6 ms). The exception is handled at once, so it holds nothing: the move takes
/// its exit-condition poll in the same ticks and ends at 6 ms. (Before the fix each
/// firing skipped the poll due in its tick, and the step never ended.)
#[test]
fn a_level_warning_with_nothing_does_not_hold_its_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq
        .add(SeqConfig::new("move"), Node::of(vec![]).until(1))
        .unwrap();
    let si = step.id();
    let mut hot = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("warning", &mut hot, Behaviour::Nothing).trigger(Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(step);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 6);
        c.set(2, ms(t) >= 2);
    });
    sim.start(si).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(end.map(ms), Some(6), "{}", show(sim.trace()));
    assert_eq!(
        sim.trace(),
        [
            tr(0, si, Idle, Running, Start),
            tr(6, si, Running, Terminated, Completed)
        ]
    );
    // Fired at every poll from 2 ms to 6 ms.
    assert_eq!(sim.monitors().fired(m), 5);
}

/// A move (exit condition flag 1 from `done_ms`, polled every `period`) with a `Level`
/// warning (`Nothing`) on flag 2 from `hot_ms`, whose exception sequence is a log sequence
/// started by hand before the move, which never ends: every firing finds it running.
/// Both are started at 0 ms; `drive` runs the simulator with the move's, the log's and the
/// warning's ids.
fn busy_warning(
    period: Duration,
    done_ms: u64,
    hot_ms: u64,
    drive: impl FnOnce(&mut Sim<'_, Ctrl, 4, 64, 1>, SeqId, SeqId, MonitorId),
) {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq
        .add(
            SeqConfig::new("move").polling(period),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let log = seq
        .add(SeqConfig::new("log"), Node::of(vec![]).until(9))
        .unwrap();
    let (si, li) = (step.id(), log.id());
    let mut hot = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("warning", &mut hot, Behaviour::Nothing)
                .trigger(Trigger::Level)
                .exception(li),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(step);
    sim.lane(log);
    sim.before_tick(move |t, c| {
        c.set(1, ms(t) >= done_ms);
        c.set(2, ms(t) >= hot_ms);
    });
    sim.start(li).unwrap();
    sim.start(si).unwrap();
    drive(&mut sim, si, li, m);
    assert_eq!(seq.exceptions_not_run(), sim.monitors().fired(m));
}

/// The same warning with an exception sequence that is already running (a log sequence
/// started by hand, which never ends): each firing finds it running (the exception is
/// not run), so the exception is handled at once and holds nothing: the move takes its
/// exit-condition poll in the same ticks and ends at 6 ms. (Before the fix each firing's
/// mark skipped the poll due in its tick before the exception sequence's start failed,
/// and the step never ended.)
#[test]
fn a_level_warning_whose_exception_sequence_is_busy_does_not_hold_its_owner() {
    busy_warning(Duration::from_millis(1), 6, 2, |sim, si, li, m| {
        sim.run_for(Duration::from_millis(10));
        assert_eq!(
            sim.trace(),
            [
                tr(0, li, Idle, Running, Start),
                tr(0, si, Idle, Running, Start),
                tr(6, si, Running, Terminated, Completed)
            ],
            "{}",
            show(sim.trace())
        );
        assert_eq!(sim.monitors().fired(m), 5);
    });
}

/// The busy-exception warning of the test above, while its owner is paused: a poll that
/// falls due while its sequence is held is missed, not taken once the hold ends
/// (semantics 1), and the warning handled at once gives the paused owner no poll either.
/// The move polls every 10 ms; it is paused at 5 ms and resumed at 13 ms; the warning
/// fires at its poll at 10 ms (while paused); its exit condition holds from 11 ms. The
/// move checks it next at 20 ms, on its grid, and ends then.
#[test]
fn a_warning_that_fires_while_its_owner_is_paused_gives_it_no_poll_at_the_resume() {
    busy_warning(Duration::from_millis(10), 11, 10, |sim, si, li, m| {
        sim.run_until(rtseq::Instant::from_ticks(4_000));
        sim.pause(si).unwrap();
        sim.run_until(rtseq::Instant::from_ticks(12_000));
        sim.resume(si).unwrap();
        sim.run_for(Duration::from_millis(18));
        assert_eq!(
            sim.trace(),
            [
                tr(0, li, Idle, Running, Start),
                tr(0, si, Idle, Running, Start),
                tr(5, si, Running, Paused, rtseq::Cause::Pause),
                tr(13, si, Paused, Running, rtseq::Cause::Resume),
                tr(20, si, Running, Terminated, Completed)
            ],
            "{}",
            show(sim.trace())
        );
        assert_eq!(sim.monitors().fired(m), 2);
    });
}

/// `RestartCallerOfOwner` on a non-blocking child whose caller has ended: the caller cannot
/// restart (it ran to its end), so the owner is aborted, with the monitor as the cause, and
/// nothing restarts.
#[test]
fn a_caller_behaviour_on_an_owner_whose_caller_has_ended_aborts_the_owner() {
    use rtseq::{Behaviour, Cause, Instant, Monitor, Outcome};
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(0))
        .unwrap();
    let ci = child.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Start(ci)]))
        .unwrap();
    let mi = main.id();
    let mut retry = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            ci,
            Monitor::new("retry", &mut retry, Behaviour::RestartCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(child);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.flags[1].set(true);
    sim.run_for(Duration::from_millis(2));
    let cause = Cause::Monitor(m);
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(0, mi, Running, Terminated, Completed),
            tr(3, ci, Running, Aborting, cause),
            tr(3, ci, Aborting, Aborted, cause),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(
        sim.handle(ci).unwrap().last_outcome(),
        Some(Outcome::Aborted(cause))
    );
}

/// A child, started non-blocking by main's first run, which then ended; main started
/// again (a run that starts nothing and waits for flag 3) at 2 ms. The child's monitor
/// (`behaviour`, flag 1) fires at 5 ms. Returns the trace, the child's and main's ids and
/// the monitor's cause.
fn caller_behaviour_on_a_later_run(
    behaviour: Behaviour,
) -> (Vec<Transition>, SeqId, SeqId, rtseq::Cause) {
    use rtseq::Instant;
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(0))
        .unwrap();
    let ci = child.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(ci)]).until(3),
        )
        .unwrap();
    let mi = main.id();
    let mut jam = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(ci, Monitor::new("jam", &mut jam, behaviour))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(child);
    ctrl.flags[3].set(true);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.flags[3].set(false);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.flags[1].set(true);
    sim.run_for(Duration::from_millis(1));
    ctrl.flags[1].set(false);
    sim.run_for(Duration::from_millis(2));
    (sim.trace().to_vec(), ci, mi, rtseq::Cause::Monitor(m))
}

/// `AbortCallerOfOwner` on a non-blocking child whose caller has ended and then started
/// again: caller links are of sequences (the tree the specification's `callerSequence`
/// describes), so the behaviour acts on the caller's run under way, though that run did
/// not start the owner, and tears it down with the owner, innermost first. (A caller that
/// has ended and not started again is the test above.)
#[test]
fn a_caller_behaviour_acts_on_the_callers_run_under_way() {
    let (trace, ci, mi, cause) = caller_behaviour_on_a_later_run(Behaviour::AbortCallerOfOwner);
    assert_eq!(
        trace,
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(0, mi, Running, Terminated, Completed),
            tr(2, mi, Terminated, Running, Start),
            tr(5, ci, Running, Aborting, cause),
            tr(5, ci, Aborting, Aborted, cause),
            tr(5, mi, Running, Aborting, cause),
            tr(5, mi, Aborting, Aborted, cause),
        ],
        "{}",
        show(&trace)
    );
}

/// The same with `RestartCallerOfOwner`: main's run under way restarts (its child, below
/// it, aborted first), and its new round starts the child again.
#[test]
fn a_restart_caller_behaviour_restarts_the_callers_run_under_way() {
    let (trace, ci, mi, cause) = caller_behaviour_on_a_later_run(Behaviour::RestartCallerOfOwner);
    assert_eq!(
        trace,
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(0, mi, Running, Terminated, Completed),
            tr(2, mi, Terminated, Running, Start),
            tr(5, ci, Running, Aborting, cause),
            tr(5, ci, Aborting, Aborted, cause),
            tr(5, mi, Running, Restarting, cause),
            tr(5, mi, Restarting, Running, Restart),
            tr(5, ci, Aborted, Running, Start),
        ],
        "{}",
        show(&trace)
    );
}

/// A machine cycle: its first run starts the move non-blocking and ends; a later run
/// dwells.
struct Cycle {
    mv: SeqId,
    dwell: rtseq::Seq<Wait>,
    runs: u32,
}
impl rtseq::Sequence<Ctrl> for Cycle {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), Failure> {
        self.runs += 1;
        if self.runs == 1 {
            cx.start(self.mv)?;
        } else {
            cx.step(&mut self.dwell).await?;
        }
        Ok(())
    }
}

/// A recovery that starts the cycle again.
struct Recover(SeqId);
impl rtseq::Sequence<Ctrl> for Recover {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.0)?;
        Ok(())
    }
}

/// The move (a 10 ms dwell), started by a cycle that then ended, has a monitor with
/// `behaviour` whose exception sequence starts the cycle again, so the cycle's start cuts
/// the move's link to its ended run (the links never form a cycle: the cycle is now below
/// the move, through the exception sequence). The behaviour, pending until the exception
/// sequence ends, then finds an owner whose caller has ended: the owner is aborted, with
/// what is below it (the cycle's new run and its dwell), innermost first. (Before session
/// 47, `RestartCallerOfOwner` restarted the move, as if it were a main sequence.)
fn caller_behaviour_after_the_link_is_cut(behaviour: Behaviour) -> Vec<Transition> {
    use rtseq::Instant;
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let ms = |n| Duration::from_millis(n);
    let md = seq
        .add(SeqConfig::new("move dwell"), Wait::new(ms(10)))
        .unwrap();
    let mv = seq
        .add(SeqConfig::new("move"), Node::of(vec![Op::Wait(md)]))
        .unwrap();
    let mi = mv.id();
    let cd = seq
        .add(SeqConfig::new("cycle dwell"), Wait::new(ms(20)))
        .unwrap();
    let cycle = Cycle {
        mv: mi,
        dwell: cd,
        runs: 0,
    };
    let cycle = seq.add(SeqConfig::new("cycle"), cycle).unwrap();
    let ci = cycle.id();
    let recover = seq.add(SeqConfig::new("recover"), Recover(ci)).unwrap();
    let ri = recover.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            mi,
            Monitor::new("fault", &mut fault, behaviour).exception(ri),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(mv);
    sim.lane(cycle);
    sim.lane(recover);
    sim.before_tick(|t, c| c.set(0, t.as_ticks() == 2_000));
    sim.start(ci).unwrap();
    sim.run_until(Instant::from_ticks(4_000));
    sim.trace().to_vec()
}

#[test]
fn a_caller_behaviour_whose_link_was_cut_aborts_the_owner() {
    for behaviour in [
        Behaviour::RestartCallerOfOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        let trace = caller_behaviour_after_the_link_is_cut(behaviour);
        // In the order of registration.
        let [md, mv, cd, cycle, recover] = [0, 1, 2, 3, 4].map(SeqId::from_index);
        let fault = Mon(MonitorId::from_index(0));
        assert_eq!(
            trace,
            [
                tr(0, cycle, Idle, Running, Start),
                tr(0, mv, Idle, Running, Start),
                tr(0, cycle, Running, Terminated, Completed),
                tr(0, md, Idle, Running, Start),
                tr(2, recover, Idle, Running, fault),
                tr(2, cycle, Terminated, Running, Start),
                tr(2, recover, Running, Terminated, Completed),
                tr(2, cd, Idle, Running, Start),
                tr(3, cd, Running, Aborting, fault),
                tr(3, cd, Aborting, Aborted, fault),
                tr(3, cycle, Running, Aborting, fault),
                tr(3, cycle, Aborting, Aborted, fault),
                tr(3, md, Running, Aborting, fault),
                tr(3, md, Aborting, Aborted, fault),
                tr(3, mv, Running, Aborting, fault),
                tr(3, mv, Aborting, Aborted, fault),
            ],
            "{behaviour:?}:\n{}",
            show(&trace)
        );
    }
}

/// The records of a run, named, as lines.
fn named_lines(names: &impl rtseq::Names, records: &[rtseq::Record]) -> Vec<String> {
    use rtseq::WithNames;
    records.iter().map(|r| r.named(names).to_string()).collect()
}

/// A monitor whose condition becomes true while its owner handles another monitor's
/// exception is not lost: its edge waits, and it fires at the first evaluation after the
/// exception ended, if its condition still holds. An end stop hit during a warning's
/// exception sequence aborts the move once the warning is handled; one released before
/// then fires no more.
#[test]
fn a_firing_the_owner_cannot_take_during_an_exception_waits_for_its_end() {
    let run = |end_stop_until_ms: u64| {
        let seq: Sequencer<Ctrl, 8> = Sequencer::new();
        let ctrl = Ctrl::default();
        let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
        let w = seq
            .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(5)))
            .unwrap();
        let log = seq
            .add(SeqConfig::new("log").in_lane(), Node::of(vec![Op::Wait(w)]))
            .unwrap();
        let main = seq
            .add(SeqConfig::new("move"), Node::of(vec![Op::Step(s)]))
            .unwrap();
        let (id, log_id) = (main.id(), log.id());
        let mut warn = |c: &Ctrl, _: rtseq::Instant| c.flag(0);
        let mut end_stop = |c: &Ctrl, _: rtseq::Instant| c.flag(2);
        let mut monitors = Monitors::<Ctrl, 2>::new();
        let warning = Monitor::new("warn", &mut warn, Behaviour::Nothing).exception(log_id);
        monitors.add(id, warning).unwrap();
        let stop = Monitor::new("end stop", &mut end_stop, Behaviour::AbortOwner);
        let stop = monitors.add(id, stop).unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.lane(main);
        sim.lane(log);
        sim.before_tick(move |now, c| {
            let ms = now.as_ticks() / 1000;
            c.set(0, ms == 3); // a warning at 3 ms: `log` runs from 3 to 8 ms
            c.set(2, (5..end_stop_until_ms).contains(&ms)); // the end stop from 5 ms
        });
        sim.start(id).unwrap();
        sim.run_for(Duration::from_millis(20));
        let lines = named_lines(&(&seq, sim.monitors()), sim.records());
        (lines, sim.monitors().fired(stop), sim.state(id))
    };

    // The warning and its exception sequence, from 3 to 8 ms.
    let warning = [
        "0 ms move: Idle -> Running (start)",
        "0 ms S: Idle -> Running (start)",
        "3 ms monitor `warn` of `move` fired: Nothing",
        "3 ms log: Idle -> Running (monitor `warn`)",
        "3 ms W: Idle -> Running (start)",
        "8 ms W: Running -> Terminated (completed)",
        "8 ms log: Running -> Terminated (completed)",
    ];

    // Held from 5 ms on: it fires at 9 ms, the first tick after `log` ended at 8 ms.
    let (lines, fired, state) = run(u64::MAX);
    assert_eq!(fired, 1);
    assert_eq!(state, Aborted);
    let end_stop = [
        "9 ms monitor `end stop` of `move` fired: AbortOwner",
        "9 ms S: Running -> Aborting (monitor `end stop`)",
        "9 ms S: Aborting -> Aborted (monitor `end stop`)",
        "9 ms move: Running -> Aborting (monitor `end stop`)",
        "9 ms move: Aborting -> Aborted (monitor `end stop`)",
    ];
    assert_eq!(lines, [&warning[..], &end_stop[..]].concat());

    // Released at 7 ms, before `log` ended: it never fires.
    let (lines, fired, state) = run(7);
    assert_eq!((fired, state), (0, Running));
    assert_eq!(lines, warning);
}

// ---------------------------------------------------------------------------------------
// A restart keeps the grid of its polling class, also when it is the class's only member
// and comes at the end of an exception sequence (found in session 53: the grid started
// again from the restart, one poll was lost and a monitor reacted a period late).
// ---------------------------------------------------------------------------------------

fn millis(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Caller `c` (polled every 10 ms, alone in its class) runs step `s` (every 1 ms); `s`'s
/// monitor `jam` (flag 2, at 13 ms only) restarts `c` (`RestartCallerOfOwner`), with a
/// 3 ms exception sequence or without. `c`'s end-stop monitor (`AbortOwner`, flag 4 from
/// 11 ms) shows when `c` is polled. Returns the trace of `c`.
fn caller_restarted_then_end_stop(with_exception: bool) -> (Vec<Transition>, SeqId, MonitorId) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("s"), Leaf::until(15)).unwrap();
    let si = s.id();
    let c = seq
        .add(
            SeqConfig::new("c").polling(millis(10)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let (ci, ei) = (c.id(), e.id());
    let mut jam = |c: &Ctrl, _: rtseq::Instant| c.flag(2);
    let mut end_stop = |c: &Ctrl, _: rtseq::Instant| c.flag(4);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let mut jam_def = Monitor::new("jam", &mut jam, Behaviour::RestartCallerOfOwner);
    if with_exception {
        jam_def = jam_def.exception(ei);
    }
    monitors.add(si, jam_def).unwrap();
    let x = monitors
        .add(
            ci,
            Monitor::new("end stop", &mut end_stop, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(c);
    sim.lane(e);
    sim.before_tick(|t, c: &Ctrl| {
        c.set(2, ms(t) == 13);
        c.set(3, ms(t) >= 16);
        c.set(4, ms(t) >= 11);
    });
    sim.start(ci).unwrap();
    sim.run_until_idle(millis(60)).unwrap();
    let trace = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == ci)
        .collect();
    (trace, ci, x)
}

/// The end stop comes true at 11 ms; `c` is restarted at 13 ms (in the firing tick) or at
/// 17 ms (the tick after the exception sequence ended). Either way `c` keeps its grid
/// (10, 20, 30 ms) and the end stop aborts it at 20 ms: within one polling period.
#[test]
fn a_restart_at_the_end_of_an_exception_sequence_keeps_the_grid_of_its_class() {
    for (with_exception, restart_at) in [(false, 13), (true, 17)] {
        let (trace, ci, x) = caller_restarted_then_end_stop(with_exception);
        let jam = Mon(MonitorId::from_index(0));
        assert_eq!(
            trace,
            [
                tr(0, ci, Idle, Running, Start),
                tr(restart_at, ci, Running, Restarting, jam),
                tr(restart_at, ci, Restarting, Running, Restart),
                tr(20, ci, Running, Aborting, Mon(x)),
                tr(20, ci, Aborting, Aborted, Mon(x)),
            ],
            "with the exception sequence: {with_exception}"
        );
    }
}
