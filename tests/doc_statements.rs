//! The documents' statements (docs/semantics.md, docs/firmware-guide.md, the rustdoc),
//! each checked on exact traces and simulated times: the test's comment quotes the
//! statement it checks. Written by an outside audit of the documents in session 53, which
//! found a restart that moved its polling class's grid (now fixed) and three statements
//! that were not true (now corrected).

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Pause, Resume, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cx, Duration, Error, Event, Failure, Instant, Monitor, Monitors, Outcome, SeqConfig,
    SeqId, Sequence, Sequencer, Transition, Wait,
};

type Seqr = Sequencer<Ctrl, 16>;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}
fn at(n: u64) -> Instant {
    Instant::from_ticks(n * 1000)
}

fn assert_trace(got: &[Transition], want: &[Transition]) {
    assert_eq!(got, want, "\n got:\n{}\nwant:\n{}", show(got), show(want));
}

/// Sets flag `flag` from `from_ms` on (before each tick).
fn from(flag: usize, from_ms: u64) -> impl FnMut(Instant, &Ctrl) {
    move |t, c| {
        if t.as_ticks() / 1000 >= from_ms {
            c.set(flag, true)
        }
    }
}

/// Flag `flag` true in `[a, b)` ms.
fn during(flag: usize, a: u64, b: u64) -> impl FnMut(Instant, &Ctrl) {
    move |t, c| {
        let m = t.as_ticks() / 1000;
        c.set(flag, (a..b).contains(&m))
    }
}

// ---------------------------------------------------------------------------------------
// semantics.md item 1: polls keep the grid of their polling class.

/// semantics.md 1: "a start into a class with no active member ... polls one period after
/// the start"; firmware-guide 2: "each polling period has its own grid, which starts one
/// period after a start into an idle class".
#[test]
fn first_poll_of_an_idle_class_comes_one_period_after_the_start() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("s").polling(ms(10)), Leaf::until(1))
        .unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.before_tick(from(1, 5));
    sim.run_for(ms(3));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    assert_trace(
        sim.trace(),
        &[
            tr(3, mi, Idle, Running, Start),
            tr(3, si, Idle, Running, Start),
            tr(13, si, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 1: "a start into a busy class joins its grid (first poll within one
/// period)".
#[test]
fn a_start_into_a_busy_class_joins_its_grid() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let busy = seq
        .add(
            SeqConfig::new("busy").polling(ms(10)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let bi = busy.id();
    let s = seq
        .add(SeqConfig::new("s").polling(ms(10)), Leaf::until(1))
        .unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(busy);
    sim.lane(main);
    sim.before_tick(from(1, 5));
    sim.start(bi).unwrap(); // grid 10, 20, ...
    sim.run_for(ms(3));
    sim.start(mi).unwrap();
    sim.run_for(ms(20));
    assert_trace(
        sim.trace(),
        &[
            tr(0, bi, Idle, Running, Start),
            tr(3, mi, Idle, Running, Start),
            tr(3, si, Idle, Running, Start),
            tr(10, si, Running, Terminated, Completed),
            tr(10, mi, Running, Terminated, Completed),
        ],
    );
}

/// Cx::wait_until: "checked now and then at this sequence's polling period" (with the
/// grid rule of semantics.md 1: the first poll one period after a start into an idle
/// class).
#[test]
fn wait_until_is_checked_now_and_then_at_the_polling_period() {
    struct Waits;
    impl Sequence<Ctrl> for Waits {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.wait_until(|cx| {
                let c = cx.control();
                c.lines.borrow_mut().push(Line {
                    ms: cx.now().as_ticks() / 1000,
                    seq: cx.id(),
                    line: 0,
                    state: Running,
                    held: false,
                });
                c.flag(1)
            })
            .await;
            Ok(())
        }
    }
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w").polling(ms(10)), Waits).unwrap();
    let wi = w.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(w);
    sim.before_tick(from(1, 25));
    sim.run_for(ms(3));
    sim.start(wi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(33)));
    assert_eq!(ctrl.lines_of(wi), vec![(3, 0), (13, 0), (23, 0), (33, 0)]);
}

/// firmware-guide 2: "a monitor reacts within one polling period": a 10 ms monitor whose
/// condition comes true at 11 ms fires at the grid point 20 ms.
#[test]
fn a_monitor_fires_at_its_owners_next_grid_point() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(
            SeqConfig::new("main").polling(ms(10)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let mi = main.id();
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("m", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(from(2, 11));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(20)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(20, mi, Running, Aborting, Mon(m)),
            tr(20, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// semantics.md 1: held polls; a resume request takes the poll of its tick, a PauseOwner
// release does not.

fn paused_step(resume_after_ms: u64) -> (Vec<Transition>, SeqId, SeqId) {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("s").polling(ms(10)), Leaf::until(1))
        .unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.before_tick(from(1, 5));
    sim.start(mi).unwrap(); // s's grid: 10, 20, ...
    sim.pause(mi).unwrap(); // applied at 1 ms
    sim.run_for(ms(resume_after_ms));
    sim.resume(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    (sim.trace().to_vec(), mi, si)
}

/// semantics.md 1: "a resume request, applied before the polls, takes it" (the poll due
/// in the resume tick).
#[test]
fn a_resume_request_takes_the_poll_due_in_its_tick() {
    let (trace, mi, si) = paused_step(9);
    assert_trace(
        &trace,
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(1, mi, Running, Paused, Pause),
            tr(1, si, Running, Paused, Pause),
            tr(10, mi, Paused, Running, Resume),
            tr(10, si, Paused, Running, Resume),
            tr(10, si, Running, Terminated, Completed),
            tr(10, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 1: "a poll that falls due while its sequence is held ... is skipped, not
/// taken when the hold ends".
#[test]
fn a_poll_due_while_paused_is_not_taken_at_the_resume() {
    let (trace, mi, si) = paused_step(10);
    assert_trace(
        &trace,
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(1, mi, Running, Paused, Pause),
            tr(1, si, Running, Paused, Pause),
            tr(11, mi, Paused, Running, Resume),
            tr(11, si, Paused, Running, Resume),
            tr(20, si, Running, Terminated, Completed),
            tr(20, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 1: "A PauseOwner release comes with the monitor evaluation, after the tick
/// took its polls: the poll due in the release tick was taken while held and is skipped,
/// so the next check comes one polling period later".
#[test]
fn a_pause_owner_release_skips_the_poll_of_its_tick() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            SeqConfig::new("s").polling(ms(10)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let si = s.id();
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(si, Monitor::new("hold", &mut c, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(s);
    sim.before_tick(from(1, 5));
    sim.before_tick(during(2, 5, 15));
    sim.start(si).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(30)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, si, Idle, Running, Start),
            tr(10, si, Running, Paused, Mon(m)),
            tr(20, si, Paused, Running, Mon(m)),
            tr(30, si, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Restarts (semantics.md 5, Monitor::restart_limit, DEFAULT_RESTART_LIMIT).

fn restarted_by_an_always_true_monitor(
    limit: Option<u8>,
) -> (Vec<Transition>, SeqId, rtseq::MonitorId) {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    let mut always = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let mut def = Monitor::new("stuck", &mut always, Behaviour::RestartOwner);
    if let Some(l) = limit {
        def = def.restart_limit(l);
    }
    let m = monitors.add(mi, def).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    let main_only = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == mi)
        .collect();
    (main_only, mi, m)
}

/// semantics.md 5 + DEFAULT_RESTART_LIMIT: a condition that stays true restarts the owner
/// 3 times (the edge restarts with every restart, the grid is kept), then aborts it.
#[test]
fn default_restart_limit_restarts_at_each_poll_then_aborts() {
    let (trace, mi, m) = restarted_by_an_always_true_monitor(None);
    let mut want = vec![tr(0, mi, Idle, Running, Start)];
    for t in 1..=3 {
        want.push(tr(t, mi, Running, Restarting, Mon(m)));
        want.push(tr(t, mi, Restarting, Running, Cause::Restart));
    }
    want.push(tr(4, mi, Running, Aborting, Mon(m)));
    want.push(tr(4, mi, Aborting, Aborted, Mon(m)));
    assert_trace(&trace, &want);
}

/// Monitor::restart_limit / semantics.md 5: "a monitor ... whose limit that count has
/// reached escalates its restarting behaviour": with a limit of 0 the first firing aborts.
#[test]
fn restart_limit_0_aborts_at_the_first_firing() {
    let (trace, mi, m) = restarted_by_an_always_true_monitor(Some(0));
    assert_trace(
        &trace,
        &[
            tr(0, mi, Idle, Running, Start),
            tr(1, mi, Running, Aborting, Mon(m)),
            tr(1, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Pause / resume requests (semantics.md 7, Handle::pause, Handle::resume).

fn dwell_main(seq: &Seqr) -> (rtseq::Seq<Node>, SeqId, SeqId) {
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    (main, mi, wi)
}

/// Handle::pause: "A sequence paused by a pause request already, with no resume pending,
/// gives Error::AlreadyPaused"; "a pause while a resume is pending takes it back".
#[test]
fn pause_requests_on_a_paused_sequence() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    let h = seq.sequence_by_id(mi).unwrap();
    assert_eq!(h.pause(), Ok(()));
    sim.step();
    assert_eq!(h.state(), Paused);
    assert_eq!(h.pause(), Err(Error::AlreadyPaused(mi)));
    assert_eq!(h.resume(), Ok(()));
    assert_eq!(h.pause(), Ok(())); // takes the resume back
    assert_eq!(h.pause(), Err(Error::AlreadyPaused(mi))); // no resume pending again
    sim.step();
    assert_eq!(h.state(), Paused);
}

/// Handle::resume: "A resume while a pause is pending takes the pause back (the sequence
/// does not pause)"; semantics.md 7: "Of a pause and a resume requested before the same
/// tick the later counts".
#[test]
fn a_resume_takes_back_a_pending_pause() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    let h = seq.sequence_by_id(mi).unwrap();
    assert_eq!(h.pause(), Ok(()));
    assert_eq!(h.resume(), Ok(()));
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(10, wi, Running, Terminated, Completed),
            tr(10, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 7 / Handle::pause: "One held paused by something else (... the paused
/// caller it blocks) takes the request: it stays paused when that hold ends, until a resume
/// request."
#[test]
fn a_child_paused_by_its_caller_takes_its_own_pause_and_outlasts_the_callers() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    sim.step(); // 1 ms
    assert_eq!(sim.state(wi), Paused);
    assert_eq!(sim.pause(wi), Ok(()));
    sim.step(); // 2 ms
    sim.resume(mi).unwrap();
    sim.step(); // 3 ms
    assert_eq!((sim.state(mi), sim.state(wi)), (Running, Paused));
    sim.resume(wi).unwrap();
    sim.step(); // 4 ms
    assert_eq!((sim.state(mi), sim.state(wi)), (Running, Running));
    // The dwell counted 0..1 and 4..: 10 ms of unpaused time end at 13 ms.
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
}

/// semantics.md 7 / 11: "non-blocking children are not held"; "A paused caller does not
/// pause it (a non-blocking child, 7)".
#[test]
fn a_pause_leaves_non_blocking_children_running() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(1))
        .unwrap();
    let ci = child.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(ci)]).until(2),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(child);
    sim.before_tick(from(1, 5));
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    sim.run_for(ms(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(1, mi, Running, Paused, Pause),
            tr(5, ci, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Abort order and cleanup hooks (semantics.md 4).

fn hook_of(name: &'static str) -> fn(&Ctrl) {
    match name {
        "main" => |c: &Ctrl| c.hooks.borrow_mut().push("main"),
        "ax1" => |c: &Ctrl| c.hooks.borrow_mut().push("ax1"),
        "ax2" => |c: &Ctrl| c.hooks.borrow_mut().push("ax2"),
        "s1" => |c: &Ctrl| c.hooks.borrow_mut().push("s1"),
        "s2" => |c: &Ctrl| c.hooks.borrow_mut().push("s2"),
        _ => unreachable!(),
    }
}

/// semantics.md 4: "torn down innermost first (by depth over the whole subtree: every
/// sequence of the deepest level, then those one level up, so two homing axes' steps go
/// before either axis), each through Aborting (optional bounded cleanup hook) to Aborted".
/// Two axes started non-blocking by main, each homing with a step.
#[test]
fn an_abort_tears_down_two_axes_by_depth_with_their_hooks() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s1 = seq
        .add(SeqConfig::new("s1").on_abort(hook_of("s1")), Leaf::until(1))
        .unwrap();
    let s2 = seq
        .add(SeqConfig::new("s2").on_abort(hook_of("s2")), Leaf::until(1))
        .unwrap();
    let (s1i, s2i) = (s1.id(), s2.id());
    let ax1 = seq
        .add(
            SeqConfig::new("ax1").on_abort(hook_of("ax1")),
            Node::of(vec![Op::Step(s1)]),
        )
        .unwrap();
    let ax2 = seq
        .add(
            SeqConfig::new("ax2").on_abort(hook_of("ax2")),
            Node::of(vec![Op::Step(s2)]),
        )
        .unwrap();
    let (a1, a2) = (ax1.id(), ax2.id());
    let main = seq
        .add(
            SeqConfig::new("main").on_abort(hook_of("main")),
            Node::of(vec![Op::Start(a1), Op::Start(a2)]).until(2),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(ax1);
    sim.lane(ax2);
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.abort(mi).unwrap();
    sim.step();
    let ab = |s| {
        [
            tr(3, s, Running, Aborting, Cause::Abort),
            tr(3, s, Aborting, Aborted, Cause::Abort),
        ]
    };
    let got: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.time == at(3))
        .collect();
    let want: Vec<Transition> = [s1i, s2i, a1, a2, mi].into_iter().flat_map(ab).collect();
    assert_trace(&got, &want);
    assert_eq!(*ctrl.hooks.borrow(), vec!["s1", "s2", "ax1", "ax2", "main"]);
}

// ---------------------------------------------------------------------------------------
// Exception sequences (semantics.md 3).

/// semantics.md 3: "the exception sequence, if any, runs in its lane with the owner as its
/// caller ... until then the exception sequence is its owner's, and a start of it is
/// Err(Error::AlreadyRunning)"; "when it has ended, the next tick applies the behaviour".
#[test]
fn an_exception_sequence_runs_with_its_owner_as_caller() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![]).until(15))
        .unwrap();
    let mi = main.id();
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("m", &mut c, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.before_tick(from(3, 5));
    sim.start(mi).unwrap();
    sim.run_for(ms(3));
    let h = sim.handle(ei).unwrap();
    assert_eq!(h.caller(), Some(mi));
    assert_eq!(sim.start(ei), Err(Error::AlreadyRunning(ei)));
    assert!(sim.handle(mi).unwrap().exception_is_active());
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(6)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(5, ei, Running, Terminated, Completed),
            tr(6, mi, Running, Aborting, Mon(m)),
            tr(6, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// firmware-guide 1: the trace ring.

/// firmware-guide 1: "A start is one record; an abort is two per sequence it stops
/// (Aborting, Aborted) plus the firing or request that caused it."; "an abort-all of a
/// tree of k running sequences is about 2k + 1 records".
#[test]
fn records_per_start_abort_and_abort_all() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    assert_eq!(sim.records().len(), 2); // two starts (main and its wait)
    sim.abort(mi).unwrap();
    sim.step();
    assert_eq!(sim.records().len(), 2 + 1 + 4, "{:#?}", sim.records());
    sim.start(mi).unwrap();
    let before = sim.records().len();
    sim.abort_all();
    sim.step();
    assert_eq!(
        sim.records().len() - before,
        2 * 2 + 1,
        "{:#?}",
        &sim.records()[before..]
    );
}

/// firmware-guide 1: "If you never drain, set T = 0: no RAM is spent, and every record
/// counts as lost."
#[test]
fn a_ring_of_0_records_counts_every_record_as_lost() {
    let seq: Sequencer<(), 4, 0> = Sequencer::new();
    let id = seq.register(SeqConfig::new("cycle")).unwrap();
    let h = seq.sequence_by_id(id).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap(); // one record
    h.abort().unwrap(); // one more (the request)
    let mut seen = 0;
    let lost = seq.drain_records(|_| seen += 1);
    assert_eq!((seen, lost), (0, 2));
}

// ---------------------------------------------------------------------------------------
// Timeouts (semantics.md 6, SeqConfig::timeout, Handle::set_timeout).

/// Handle::set_timeout: "at once for a run under way whose timeout is armed ... otherwise
/// from the next start or restart": a run started without a timeout is not timed out by a
/// timeout set during it; its next run is.
#[test]
fn set_timeout_on_an_unarmed_run_applies_from_the_next_start() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.handle(mi).unwrap().set_timeout(Some(ms(4))).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(10)));
    assert_eq!(
        sim.handle(mi).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
    sim.start(mi).unwrap(); // at 10 ms
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(14)));
    assert_eq!(
        sim.handle(mi).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Timeout(mi)))
    );
}

/// semantics.md 6: "it fires once per run": a timeout with Behaviour::Nothing fires once,
/// the run goes on and completes.
#[test]
fn a_timeout_with_nothing_fires_once_per_run() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main")
                .timeout(ms(2))
                .timeout_behaviour(Behaviour::Nothing),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(10)));
    let fired: Vec<(u64, Event)> = sim
        .records()
        .iter()
        .filter_map(|r| r.event().map(|e| (r.time.as_ticks() / 1000, e)))
        .filter(|(_, e)| matches!(e, Event::Fired { .. }))
        .collect();
    assert_eq!(
        fired,
        vec![(
            2,
            Event::Fired {
                owner: mi,
                cause: Cause::Timeout(mi),
                behaviour: Behaviour::Nothing
            }
        )]
    );
    assert_eq!(
        sim.handle(mi).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
}

// ---------------------------------------------------------------------------------------
// More statements, in the order the audit took them up.

/// A chain `s0 → s1 → … → s8` of blocking runs, `s8` waiting for flag 15 (never set).
fn chain(seq: &Seqr) -> (rtseq::Seq<Node>, Vec<SeqId>) {
    let mut inner = seq
        .add(SeqConfig::new("s8"), Node::of(vec![]).until(15))
        .unwrap();
    let mut ids = vec![inner.id()];
    let names = ["s7", "s6", "s5", "s4", "s3", "s2", "s1", "s0"];
    for name in names {
        inner = seq
            .add(SeqConfig::new(name), Node::of(vec![Op::Run(inner)]))
            .unwrap();
        ids.push(inner.id());
    }
    ids.reverse(); // s0 first
    (inner, ids)
}

/// firmware-guide 5: exceptions_not_run counts exception sequences that "would have nested
/// deeper than 8"; semantics.md 10: "the behaviour is applied at once". The owner `s8` has
/// 8 callers; its exception sequence, with the owner as its caller, would have 9.
#[test]
fn an_exception_sequence_too_deep_is_not_run_and_the_behaviour_is_applied_at_once() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (s0, ids) = chain(&seq);
    let stop = seq.add(SeqConfig::new("stop"), Node::of(vec![])).unwrap();
    let ei = stop.id();
    let s8 = ids[8];
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            s8,
            Monitor::new("m", &mut c, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(s0);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.start(ids[0]).unwrap();
    assert_eq!(sim.handle(s8).unwrap().caller_stack().len(), 8);
    sim.run_for(ms(2));
    assert_eq!(seq.exceptions_not_run(), 1);
    assert!(sim.records().iter().any(|r| r.event()
        == Some(Event::ExceptionNotRun {
            exception: ei,
            owner: s8,
            why: Error::CallerDepthExceeded(ei)
        })));
    assert_eq!(sim.state(ei), Idle);
    assert_eq!(
        sim.handle(s8).unwrap().last_outcome(),
        Some(Outcome::Aborted(Mon(m)))
    );
}

/// semantics.md 3: "A held child's clock runs on, so its own timeout may fire during the
/// hold." The owner's monitor fires at 2 ms (exception sequence until 12 ms); the child's
/// 4 ms timeout fires at 4 ms, during the hold.
#[test]
fn a_held_childs_timeout_fires_during_the_hold() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(SeqConfig::new("w").timeout(ms(4)), Wait::new(ms(20)))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("warn", &mut c, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.before_tick(from(3, 12));
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(4, wi, Running, Aborting, Cause::Timeout(wi)),
            tr(4, wi, Aborting, Aborted, Cause::Timeout(wi)),
            tr(12, ei, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
    assert_eq!(
        ctrl.returned.borrow().first().map(|r| (r.ms, r.result)),
        Some((13, Err(Failure::Aborted(Cause::Timeout(wi)))))
    );
}

/// Handle::start / semantics.md 8: "A start by an application's handle [while an
/// abort-all waits] ... is taken: its run holds before its pre-condition and is aborted
/// with the rest".
#[test]
fn a_handle_start_while_an_abort_all_waits_is_taken_and_aborted() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.step(); // 1 ms
    seq.abort_all();
    assert_eq!(sim.start(mi), Ok(()));
    assert_eq!(sim.state(mi), Running);
    assert_eq!(sim.state(wi), Idle); // held before its pre-condition: its action did not run
    sim.step(); // 2 ms
    assert_trace(
        sim.trace(),
        &[
            tr(1, mi, Idle, Running, Start),
            tr(2, mi, Running, Aborting, Cause::AbortAll),
            tr(2, mi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert!(ctrl.lines_of(mi).is_empty());
}

/// Handle::pause: "A sequence that is not running or paused (idle, ended, ...) gives
/// Error::NotRunning"; semantics.md 9: "Starting a running sequence is
/// Err(Error::AlreadyRunning(id))" — a paused one too.
#[test]
fn requests_of_an_ended_or_paused_sequence() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    sim.step();
    assert_eq!(sim.state(mi), Paused);
    assert_eq!(sim.start(mi), Err(Error::AlreadyRunning(mi)));
    sim.resume(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    assert_eq!(sim.state(mi), Terminated);
    assert_eq!(sim.pause(mi), Err(Error::NotRunning(mi)));
    assert_eq!(sim.resume(mi), Err(Error::NotPaused(mi)));
    assert_eq!(sim.abort(mi), Err(Error::NotRunning(mi)));
}

/// semantics.md 3: "Monitors are active while their owner is running, also while it is
/// ... paused"; firmware-guide 4: "A monitor is evaluated only while its owner is Running
/// or Paused". A paused owner is aborted by its monitor, with its blocking child.
#[test]
fn a_monitor_aborts_a_paused_owner() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut c = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("m", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(from(2, 4));
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(4)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(1, mi, Running, Paused, Pause),
            tr(1, wi, Running, Paused, Pause),
            tr(4, wi, Paused, Aborting, Mon(m)),
            tr(4, wi, Aborting, Aborted, Mon(m)),
            tr(4, mi, Paused, Aborting, Mon(m)),
            tr(4, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

/// firmware-guide 5: "drain_records returns the number of records lost since the last
/// call: ... or more than 8 safety notes came between two ticks".
#[test]
fn more_than_8_safety_notes_between_two_ticks_are_counted_lost() {
    use rtseq::safety::{SafetyLevel, Sequences};
    let seq: Sequencer<(), 4> = Sequencer::new();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    for i in 0..9u8 {
        seq.level_entered(SafetyLevel::new(i));
    }
    seq.tick(at(1), &(), &mut monitors).unwrap();
    let mut n = 0;
    let lost = seq.drain_records(|_| n += 1);
    assert_eq!((n, lost), (8, 1));
}

/// firmware-guide 2: "Polling periods and timeouts are non-zero and below 2^31 µs".
#[test]
fn a_zero_timeout_is_refused_at_registration() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    assert_eq!(
        seq.register(SeqConfig::new("t").timeout(Duration::from_ticks(0))),
        Err(Error::DurationOutOfRange)
    );
    assert_eq!(
        seq.register(SeqConfig::new("t").timeout(Duration::from_ticks(1 << 31))),
        Err(Error::DurationOutOfRange)
    );
    assert!(seq
        .register(SeqConfig::new("t").timeout(Duration::from_ticks((1 << 31) - 1)))
        .is_ok());
}

/// semantics.md 7: "when the condition clears, they resume, once no other PauseOwner
/// monitor of the owner holds".
#[test]
fn two_pause_owner_monitors_release_when_the_last_clears() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut b = |c: &Ctrl, _: Instant| c.flag(3);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let ma = monitors
        .add(mi, Monitor::new("a", &mut a, Behaviour::PauseOwner))
        .unwrap();
    let mb = monitors
        .add(mi, Monitor::new("b", &mut b, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 2, 5));
    sim.before_tick(during(3, 4, 8));
    sim.start(mi).unwrap();
    // Paused 2..8: 6 ms, so the 10 ms dwell ends at 16 ms.
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(16)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, mi, Running, Paused, Mon(ma)),
            tr(2, wi, Running, Paused, Mon(ma)),
            tr(8, mi, Paused, Running, Mon(mb)),
            tr(8, wi, Paused, Running, Mon(mb)),
            tr(16, wi, Running, Terminated, Completed),
            tr(16, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 12: counters "cost 14 bytes per sequence".
#[test]
fn counters_are_14_bytes() {
    assert_eq!(core::mem::size_of::<rtseq::Counters>(), 14);
}

// ---------------------------------------------------------------------------------------
// More statements, in the order the audit took them up.

/// A sequence that runs a step, then reports; used to end a 10 ms-class member off its
/// grid inside the lane poll that starts another member.
struct RunThenStep {
    first: rtseq::Seq<Node>,
    then: rtseq::Seq<Leaf>,
}
impl Sequence<Ctrl> for RunThenStep {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let r = cx.run(&mut self.first).await;
        cx.control().returned.borrow_mut().push(Returned {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line: 0,
            result: r,
        });
        let r = cx.step(&mut self.then).await;
        cx.control().returned.borrow_mut().push(Returned {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line: 1,
            result: r,
        });
        Ok(())
    }
}

/// semantics.md 1: "a start into a class with no active member (a member that ended in the
/// same lane poll as the start no longer counts) polls one period after the start". `a`
/// (10 ms class, started at 0: grid 10, 20, ...) ends at 3 ms when its 1 ms step ends; main
/// then starts step `b` (10 ms class) in the same lane poll: b's first poll is at 13 ms, not
/// at a's grid point 10 ms.
#[test]
fn a_member_that_ended_in_the_same_lane_poll_does_not_keep_the_grid() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("s"), Leaf::until(1)).unwrap();
    let a = seq
        .add(
            SeqConfig::new("a").polling(ms(10)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let ai = a.id();
    let b = seq
        .add(SeqConfig::new("b").polling(ms(10)), Leaf::until(2))
        .unwrap();
    let bi = b.id();
    let main = seq
        .add(SeqConfig::new("main"), RunThenStep { first: a, then: b })
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.before_tick(from(1, 3));
    sim.before_tick(from(2, 4));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    let ends: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == ai || t.sequence == bi)
        .collect();
    assert_trace(
        &ends,
        &[
            tr(0, ai, Idle, Running, Start),
            tr(3, ai, Running, Terminated, Completed),
            tr(3, bi, Idle, Running, Start),
            tr(13, bi, Running, Terminated, Completed),
        ],
    );
}

/// Behaviour::PauseOwner: "A PauseOwner monitor watches both edges, whatever its Trigger".
#[test]
fn a_pause_owner_monitor_with_a_falling_edge_trigger_pauses_on_the_rising_edge() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::PauseOwner).trigger(rtseq::Trigger::FallingEdge),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 2, 5));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, mi, Running, Paused, Mon(m)),
            tr(2, wi, Running, Paused, Mon(m)),
            tr(5, mi, Paused, Running, Mon(m)),
            tr(5, wi, Paused, Running, Mon(m)),
            tr(13, wi, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
}

/// Behaviour::PauseOwner: "it marks no exception"; "when it clears, they resume"; the
/// exception sequence "runs in its lane while the owner is paused". Reading: the owner
/// resumes when the condition clears, whether or not the exception sequence still runs.
#[test]
fn a_pause_owner_release_does_not_wait_for_its_exception_sequence() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let hold = seq
        .add(SeqConfig::new("hold"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = hold.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::PauseOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(hold);
    sim.before_tick(during(2, 2, 5));
    sim.before_tick(from(3, 20));
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(2, mi, Running, Paused, Mon(m)),
            tr(2, wi, Running, Paused, Mon(m)),
            tr(5, mi, Paused, Running, Mon(m)),
            tr(5, wi, Paused, Running, Mon(m)),
            tr(13, wi, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
            tr(20, ei, Running, Terminated, Completed),
        ],
    );
}

/// firmware-guide 5: an exception sequence that could not run: "The behaviour ... was
/// applied at once, without the exception sequence (a PauseOwner hold pauses without it)".
#[test]
fn a_pause_owner_whose_exception_sequence_is_busy_still_pauses() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let hold = seq
        .add(SeqConfig::new("hold"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = hold.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::PauseOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(hold);
    sim.before_tick(during(2, 2, 5));
    sim.start(ei).unwrap(); // busy
    sim.start(mi).unwrap();
    sim.run_for(ms(3));
    assert_eq!((sim.state(mi), sim.state(wi)), (Paused, Paused));
    assert_eq!(seq.exceptions_not_run(), 1);
    assert!(sim.records().iter().any(|r| r.event()
        == Some(Event::ExceptionNotRun {
            exception: ei,
            owner: mi,
            why: Error::AlreadyRunning(ei)
        })));
    let _ = m;
    sim.run_for(ms(3));
    assert_eq!((sim.state(mi), sim.state(wi)), (Running, Running));
}

/// Handle::set_timeout: "at once for a run under way whose timeout is armed (measured from
/// its start, paused time not counted...)". A 20 ms timeout, paused 1..3 ms, set to 6 ms at
/// 5 ms: it runs out at 8 ms.
#[test]
fn set_timeout_during_a_run_counts_from_its_start_without_paused_time() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(30))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(ms(20)),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap(); // at 1 ms
    sim.run_for(ms(2));
    sim.resume(mi).unwrap(); // at 3 ms
    sim.run_for(ms(3)); // 5 ms
    sim.handle(mi).unwrap().set_timeout(Some(ms(6))).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(8)));
    assert_eq!(
        sim.handle(mi).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Timeout(mi)))
    );
}

/// semantics.md 4: "An abort reaches every active sub-sequence, blocking and non-blocking
/// (and running exception sequences), torn down innermost first".
#[test]
fn an_abort_reaches_the_owners_running_exception_sequence_first() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("warn", &mut a, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.start(mi).unwrap();
    sim.run_for(ms(3));
    sim.abort(mi).unwrap();
    sim.step(); // 4 ms
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(4, wi, Running, Aborting, Cause::Abort),
            tr(4, wi, Aborting, Aborted, Cause::Abort),
            tr(4, ei, Running, Aborting, Cause::Abort),
            tr(4, ei, Aborting, Aborted, Cause::Abort),
            tr(4, mi, Running, Aborting, Cause::Abort),
            tr(4, mi, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// Behaviour::RestartCallerOfOwner / AbortCallerOfOwner: "the owner's caller (the owner
/// itself for a main sequence)".
#[test]
fn caller_behaviours_act_on_a_main_owner_itself() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut a = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::RestartCallerOfOwner).restart_limit(1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    let got: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == mi)
        .collect();
    assert_trace(
        &got,
        &[
            tr(0, mi, Idle, Running, Start),
            tr(1, mi, Running, Restarting, Mon(m)),
            tr(1, mi, Restarting, Running, Cause::Restart),
            tr(2, mi, Running, Aborting, Mon(m)),
            tr(2, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

/// semantics.md 1: "a late tick skips missed polls instead of replaying them": a Level
/// monitor polled every 1 ms, ticked every 3 ms, fires once per tick.
#[test]
fn a_late_tick_takes_one_poll_not_the_missed_ones() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![]).until(15))
        .unwrap();
    let mi = main.id();
    let mut a = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::Nothing).trigger(rtseq::Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors).with_period(ms(3)).unwrap();
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(ms(30));
    assert_eq!(sim.monitors().fired(m), 10);
}

// ---------------------------------------------------------------------------------------
// More statements, in the order the audit took them up.

/// SeqConfig::on_abort: "A bounded cleanup run while the sequence is Aborting (or
/// restarting)"; Behaviour::RestartOwner: "The owner's sub-sequences are aborted and the
/// owner runs again". The hooks of the restarted owner and of its aborted child.
#[test]
fn cleanup_hooks_run_at_a_restart_too() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(
            SeqConfig::new("w").on_abort(hook_of("s1")),
            Wait::new(ms(10)),
        )
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(
            SeqConfig::new("main").on_abort(hook_of("main")),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 3, 4));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(3, wi, Running, Aborting, Mon(m)),
            tr(3, wi, Aborting, Aborted, Mon(m)),
            tr(3, mi, Running, Restarting, Mon(m)),
            tr(3, mi, Restarting, Running, Cause::Restart),
            tr(3, wi, Aborted, Running, Start),
            tr(13, wi, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
    assert_eq!(*ctrl.hooks.borrow(), vec!["s1", "main"]);
}

/// firmware-guide 5: "drain_records returns the number of records lost since the last call:
/// the ring (T) overflowed between two drains and the oldest records were overwritten".
#[test]
fn an_overflowing_ring_keeps_the_newest_and_counts_the_oldest_lost() {
    let seq: Sequencer<(), 4, 4> = Sequencer::new();
    let id = seq.register(SeqConfig::new("cycle")).unwrap();
    let h = seq.sequence_by_id(id).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap(); // 1: transition
    h.pause().unwrap(); // 2: request
    h.resume().unwrap(); // 3: request
    h.pause().unwrap(); // 4: request
    h.abort().unwrap(); // 5: request
    let mut got = Vec::new();
    let lost = seq.drain_records(|r| got.push(r));
    assert_eq!(lost, 1);
    assert_eq!(got.len(), 4);
    assert!(
        got[0].transition().is_none(),
        "the oldest (the start) is the one lost"
    );
    assert_eq!(seq.drain_records(|_| ()), 0);
}

/// firmware-guide 1: "A lane future polled when all slots are taken never runs: starts of
/// its sequence and `check_lanes` give `Error::LaneCapacityExceeded`".
#[test]
fn a_lane_without_a_slot_never_runs_and_its_starts_say_so() {
    let seq: Sequencer<Ctrl, 4, 64, rtseq::lock::CriticalSection, 1> = Sequencer::new();
    let ctrl = Ctrl::default();
    let a = seq
        .add(SeqConfig::new("a").in_lane(), Node::of(vec![]))
        .unwrap();
    let b = seq.add(SeqConfig::new("b"), Node::of(vec![])).unwrap();
    let (ai, bi) = (a.id(), b.id());
    assert_eq!(
        seq.sequence_by_id(bi).unwrap().declare_lane(),
        Err(Error::LaneCapacityExceeded(bi))
    );
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.lane(b);
    // The simulator's first start checks the lanes.
    assert_eq!(sim.start(ai), Err(Error::LaneCapacityExceeded(bi)));
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(bi)));
    assert_eq!(sim.handle(ai).unwrap().start(), Ok(()));
    assert_eq!(
        sim.handle(bi).unwrap().start(),
        Err(Error::LaneCapacityExceeded(bi))
    );
}

/// Sequencer::tick: "The first non-empty table that comes with a due tick becomes the
/// sequencer's": an empty table before it binds nothing.
#[test]
fn an_empty_table_does_not_bind_the_sequencer() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let run = seq.register(SeqConfig::new("run")).unwrap();
    seq.sequence_by_id(run).unwrap().declare_lane().unwrap();
    seq.sequence_by_id(run).unwrap().start().unwrap();
    let (mut jam, mut also) = (|_: &(), _: Instant| false, |_: &(), _: Instant| false);
    let mut empty: Monitors<(), 1> = Monitors::new();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(run, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut other: Monitors<(), 1> = Monitors::new();
    other
        .add(run, Monitor::new("jam", &mut also, Behaviour::AbortOwner))
        .unwrap();
    assert_eq!(seq.tick(at(1), &(), &mut empty), Ok(()));
    assert_eq!(seq.tick(at(2), &(), &mut monitors), Ok(()));
    assert_eq!(
        seq.tick(at(3), &(), &mut other),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(
        seq.tick(at(4), &(), &mut empty),
        Err(Error::ForeignMonitorTable)
    );
}

// ---------------------------------------------------------------------------------------
// More statements, in the order the audit took them up.

/// semantics.md 6: a timeout "fires at most once per round, the run's start or one of its
/// restarts": a restarting timeout fires 3 times in one run (a start and two restarts).
/// (Until session 53 it said "once per run", which items 5 and 11 define to include the
/// restarts.)
#[test]
fn a_restarting_timeout_fires_once_per_round() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main")
                .timeout(ms(4))
                .timeout_behaviour(Behaviour::RestartOwner)
                .timeout_restart_limit(2),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(12)));
    let fired: Vec<u64> = sim
        .records()
        .iter()
        .filter(|r| {
            matches!(
                r.event(),
                Some(Event::Fired {
                    cause: Cause::Timeout(_),
                    ..
                })
            )
        })
        .map(|r| r.time.as_ticks() / 1000)
        .collect();
    assert_eq!(fired, vec![4, 8, 12]);
    let c = sim.handle(mi).unwrap().counters();
    // One run (one start), restarted twice: the timeout fired three times in it.
    assert_eq!((c.runs, c.restarts), (1, 2));
}

/// Handle::set_timeout: "otherwise from the next start or restart": set on a run without a
/// timeout, it is armed by the run's restart (a monitor's), 4 ms after it.
#[test]
fn set_timeout_on_an_unarmed_run_is_armed_by_its_restart() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(mi, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 3, 4));
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.handle(mi).unwrap().set_timeout(Some(ms(4))).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(7)));
    assert_eq!(
        sim.handle(mi).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Timeout(mi)))
    );
}

/// Handle::set_timeout on a run whose timeout already fired (behaviour Nothing): is that
/// run's timeout still "armed"? The docs do not say; this test records what happens.
#[test]
fn set_timeout_after_the_timeout_fired_with_nothing() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(20))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main")
                .timeout(ms(2))
                .timeout_behaviour(Behaviour::Nothing),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(ms(5));
    sim.handle(mi).unwrap().set_timeout(Some(ms(8))).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    let fired: Vec<u64> = sim
        .records()
        .iter()
        .filter(|r| matches!(r.event(), Some(Event::Fired { .. })))
        .map(|r| r.time.as_ticks() / 1000)
        .collect();
    // Once per run: no second firing at 8 ms.
    assert_eq!(fired, vec![2]);
}

/// semantics.md 8: an abort request ends `Aborted(Cause::Abort)` "unless another abort of
/// it comes first — an abort-all, which the tick carries out before the requests".
#[test]
fn an_abort_all_in_the_tick_of_an_abort_request_comes_first() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.abort(mi).unwrap();
    sim.abort_all();
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(1, wi, Running, Aborting, Cause::AbortAll),
            tr(1, wi, Aborting, Aborted, Cause::AbortAll),
            tr(1, mi, Running, Aborting, Cause::AbortAll),
            tr(1, mi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
}

/// semantics.md 8: "from the request to the tick that carries it out, the run begins
/// nothing more ... an accepted abort request ends the run aborted"; a pause asked for
/// after the abort: records what the tick does with both.
#[test]
fn a_pause_requested_after_an_abort_request() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.abort(mi).unwrap();
    let paused = sim.pause(mi);
    sim.step();
    assert_eq!(paused, Ok(()));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(1, wi, Running, Aborting, Cause::Abort),
            tr(1, wi, Aborting, Aborted, Cause::Abort),
            tr(1, mi, Running, Aborting, Cause::Abort),
            tr(1, mi, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// semantics.md 3: "Non-blocking sequences it started run on while the exception is
/// handled".
#[test]
fn non_blocking_children_run_on_during_an_exception() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(1))
        .unwrap();
    let ci = child.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(ci)]).until(4),
        )
        .unwrap();
    let mi = main.id();
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("warn", &mut a, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(child);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.before_tick(from(1, 5));
    sim.before_tick(from(3, 8));
    sim.run_for(ms(0));
    sim.start(mi).unwrap();
    sim.run_for(ms(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(5, ci, Running, Terminated, Completed),
            tr(8, ei, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// More statements, in the order the audit took them up.

/// A step that starts `child` scoped in its action and ends at flag 1.
struct ScopedInStep {
    child: SeqId,
}
impl rtseq::Step<Ctrl> for ScopedInStep {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _child = cx.start_scoped(self.child)?;
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(1)
    }
}

/// Cx::start_scoped: "A Step's action (a fn) drops it when it returns, before the exit
/// condition is polled: a child that must live through a step is started by a sequence
/// around it." The child is aborted by the next tick, by the step's request, while the step
/// still waits.
#[test]
fn a_scoped_child_of_a_step_is_aborted_at_the_next_tick() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(15))
        .unwrap();
    let ci = child.id();
    let st = seq
        .add(SeqConfig::new("st"), ScopedInStep { child: ci })
        .unwrap();
    let sti = st.id();
    struct RunStep(rtseq::Seq<ScopedInStep>);
    impl Sequence<Ctrl> for RunStep {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.step(&mut self.0).await?;
            Ok(())
        }
    }
    let main = seq.add(SeqConfig::new("main"), RunStep(st)).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(child);
    sim.before_tick(from(1, 5));
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(20)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, sti, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(1, ci, Running, Aborting, Cause::Abort),
            tr(1, ci, Aborting, Aborted, Cause::Abort),
            tr(5, sti, Running, Terminated, Completed),
            tr(5, mi, Running, Terminated, Completed),
        ],
    );
    assert!(sim.records().iter().any(|r| r.event()
        == Some(Event::Requested {
            sequence: ci,
            request: rtseq::Request::Abort,
            by: rtseq::Requester::Sequence(sti)
        })));
}

/// semantics.md 3: "when it [the exception sequence] has ended, the next tick applies the
/// behaviour" — also when it ended aborted (by its own timeout).
#[test]
fn a_behaviour_follows_an_exception_sequence_aborted_by_its_timeout() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let stop = seq
        .add(
            SeqConfig::new("stop").timeout(ms(3)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let ei = stop.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(6)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(5, ei, Running, Aborting, Cause::Timeout(ei)),
            tr(5, ei, Aborting, Aborted, Cause::Timeout(ei)),
            tr(6, wi, Running, Aborting, Mon(m)),
            tr(6, wi, Aborting, Aborted, Mon(m)),
            tr(6, mi, Running, Aborting, Mon(m)),
            tr(6, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

/// A sequence whose action fails at once.
struct Fails;
impl Sequence<Ctrl> for Fails {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Err(Failure::App(7))
    }
}

/// semantics.md 3: the behaviour follows an exception sequence that ended failed, at the
/// next tick.
#[test]
fn a_behaviour_follows_an_exception_sequence_that_failed() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let stop = seq.add(SeqConfig::new("stop"), Fails).unwrap();
    let ei = stop.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(during(2, 2, 3));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(2, ei, Running, Terminated, Cause::Failed),
            tr(3, wi, Running, Aborting, Mon(m)),
            tr(3, wi, Aborting, Aborted, Mon(m)),
            tr(3, mi, Running, Restarting, Mon(m)),
            tr(3, mi, Restarting, Running, Cause::Restart),
            tr(3, wi, Aborted, Running, Start),
            tr(13, wi, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 5: "the run counts the restarts monitors and timeouts made of it, and a
/// monitor (or timeout) whose limit ... that count has reached escalates": a monitor's
/// restart uses up a timeout's limit of 1.
#[test]
fn a_monitor_restart_counts_against_the_timeouts_limit() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(20))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main")
                .timeout(ms(5))
                .timeout_behaviour(Behaviour::RestartOwner)
                .timeout_restart_limit(1),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 2, 3));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(7)));
    let got: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == mi)
        .collect();
    assert_trace(
        &got,
        &[
            tr(0, mi, Idle, Running, Start),
            tr(2, mi, Running, Restarting, Mon(m)),
            tr(2, mi, Restarting, Running, Cause::Restart),
            tr(7, mi, Running, Aborting, Cause::Timeout(mi)),
            tr(7, mi, Aborting, Aborted, Cause::Timeout(mi)),
        ],
    );
}

/// Trigger::Change: "On every change of the condition".
#[test]
fn a_change_trigger_fires_on_both_edges() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![]).until(15))
        .unwrap();
    let mi = main.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::Nothing).trigger(rtseq::Trigger::Change),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 2, 5));
    sim.start(mi).unwrap();
    sim.run_for(ms(10));
    let fired: Vec<u64> = sim
        .records()
        .iter()
        .filter(|r| matches!(r.event(), Some(Event::Fired { .. })))
        .map(|r| r.time.as_ticks() / 1000)
        .collect();
    assert_eq!(fired, vec![2, 5]);
    assert_eq!(sim.monitors().fired(m), 2);
}

// ---------------------------------------------------------------------------------------
// Counters, then more statements.

/// Handle::counters / Counters::exceptions: "Exceptions raised by this sequence's monitors
/// and timeout"; Behaviour::PauseOwner "marks no exception". Records which firings count.
#[test]
fn which_firings_count_as_exceptions() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(20))).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main")
                .timeout(ms(15))
                .timeout_behaviour(Behaviour::Nothing),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut p = |c: &Ctrl, _: Instant| c.flag(2);
    let mut n = |c: &Ctrl, _: Instant| c.flag(3);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    monitors
        .add(mi, Monitor::new("p", &mut p, Behaviour::PauseOwner))
        .unwrap();
    monitors
        .add(mi, Monitor::new("n", &mut n, Behaviour::Nothing))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 2, 4));
    sim.before_tick(during(3, 6, 7));
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    let c = sim.handle(mi).unwrap().counters();
    // PauseOwner (1 firing), Nothing (1), timeout (1).
    assert_eq!(
        (c.runs, c.completed, c.exceptions),
        (1, 1, 2),
        "PauseOwner firing counted as an exception? {c:?}"
    );
}

/// Times of the Fired events of monitor `m` in the records.
fn fired_ms(sim: &Sim<'_, Ctrl, 16, 64, 1>) -> Vec<u64> {
    sim.records()
        .iter()
        .filter(|r| matches!(r.event(), Some(Event::Fired { .. })))
        .map(|r| r.time.as_ticks() / 1000)
        .collect()
}

/// firmware-guide 2: "each polling period has its own grid, which starts one period after
/// a start into an idle class, and a poll runs at the first tick at or after its grid
/// point": a 2.5 ms period on a 1 ms tick polls at 3, 5, 8, 10, 13, 15 ms.
#[test]
fn a_poll_runs_at_the_first_tick_at_or_after_its_grid_point() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(
            SeqConfig::new("main").polling(Duration::from_micros(2_500)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let mi = main.id();
    let mut a = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::Nothing).trigger(rtseq::Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(ms(15));
    assert_eq!(fired_ms(&sim), vec![3, 5, 8, 10, 13, 15]);
}

/// Handle::resume: "Requests that a paused sequence resume"; semantics.md 7: "a sequence
/// ... that is asked to resume, while the caller it blocks is paused resumes with that
/// caller". A child paused only by its caller's pause: the resume request is taken and
/// the child stays paused until the caller resumes.
#[test]
fn a_resume_of_a_child_paused_by_its_caller_waits_for_the_caller() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    sim.step(); // 1 ms
    let r = sim.resume(wi);
    sim.step(); // 2 ms
    assert_eq!(r, Ok(()));
    assert_eq!((sim.state(mi), sim.state(wi)), (Paused, Paused));
    sim.resume(mi).unwrap();
    sim.step(); // 3 ms
    assert_eq!((sim.state(mi), sim.state(wi)), (Running, Running));
}

/// Handle::pause: a second pause request before the tick (a pause pending, not applied):
/// the docs name `AlreadyPaused` only for a sequence "paused by a pause request already";
/// records what a pending one gives.
#[test]
fn a_second_pause_request_before_the_tick() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    assert_eq!(sim.pause(mi), Ok(()));
    // Taken again (the sequence is not paused yet): the docs are silent; it is recorded.
    assert_eq!(sim.pause(mi), Ok(()));
    sim.step();
    assert_eq!(sim.state(mi), Paused);
    assert_eq!(sim.pause(mi), Err(Error::AlreadyPaused(mi)));
}

/// semantics.md 3: monitors "are active while their owner is running"; "A held child's
/// clock runs on, so its own timeout may fire during the hold". A held child's own monitor
/// (AbortOwner) fires during its caller's exception hold, as its timeout does.
#[test]
fn a_held_childs_monitor_fires_during_the_hold() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let mut warn = |c: &Ctrl, _: Instant| c.flag(2);
    let mut jam = |c: &Ctrl, _: Instant| c.flag(4);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("warn", &mut warn, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let j = monitors
        .add(wi, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.before_tick(from(2, 2));
    sim.before_tick(from(4, 4));
    sim.before_tick(from(3, 8));
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(4, wi, Running, Aborting, Mon(j)),
            tr(4, wi, Aborting, Aborted, Mon(j)),
            tr(8, ei, Running, Terminated, Completed),
            tr(9, mi, Running, Terminated, Completed),
        ],
    );
}

/// firmware-guide 5 / Sequencer::tick: ForeignMonitorTable is for "a tick with polls due";
/// a tick with another table and nothing due is Ok.
#[test]
fn a_foreign_table_without_due_polls_is_ok() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let run = seq.register(SeqConfig::new("run").polling(ms(10))).unwrap();
    seq.sequence_by_id(run).unwrap().declare_lane().unwrap();
    seq.sequence_by_id(run).unwrap().start().unwrap();
    let (mut jam, mut also) = (|_: &(), _: Instant| false, |_: &(), _: Instant| false);
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(run, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut other: Monitors<(), 1> = Monitors::new();
    other
        .add(run, Monitor::new("jam", &mut also, Behaviour::AbortOwner))
        .unwrap();
    assert_eq!(seq.tick(at(10), &(), &mut monitors), Ok(()));
    assert_eq!(seq.tick(at(11), &(), &mut other), Ok(()));
    assert_eq!(
        seq.tick(at(20), &(), &mut other),
        Err(Error::ForeignMonitorTable)
    );
}

/// Sim::starting_at: "Starts the simulated clock at t instead of the sequencer's time",
/// with semantics.md 1's grid ("a start into a class with no active member ... polls one
/// period after the start"): a 10 ms monitor of a sequence started at t = 1 h first
/// evaluates at t + 10 ms, as from time 0.
#[test]
fn starting_at_an_hour_keeps_the_first_poll_one_period_after_the_start() {
    for base_ms in [0u64, 3_600_000] {
        let seq = Seqr::new();
        let ctrl = Ctrl::default();
        let main = seq
            .add(
                SeqConfig::new("main").polling(ms(10)),
                Node::of(vec![]).until(15),
            )
            .unwrap();
        let mi = main.id();
        let mut a = |_: &Ctrl, _: Instant| true;
        let mut monitors = Monitors::<Ctrl, 1>::new();
        monitors
            .add(
                mi,
                Monitor::new("a", &mut a, Behaviour::Nothing).trigger(rtseq::Trigger::Level),
            )
            .unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors)
            .starting_at(at(base_ms))
            .unwrap();
        sim.lane(main);
        sim.start(mi).unwrap();
        sim.run_for(ms(30));
        let got: Vec<u64> = fired_ms(&sim).into_iter().map(|t| t - base_ms).collect();
        assert_eq!(got, vec![10, 20, 30], "from {base_ms} ms");
    }
}

/// firmware-guide 1: W: "`Error::LaneCapacityExceeded` from `in_lane()` (at
/// `register`/`install`)": the refused registration leaves nothing registered.
#[test]
fn an_in_lane_registration_over_the_lane_slots_is_refused_whole() {
    let seq: Sequencer<(), 4, 8, rtseq::lock::CriticalSection, 1> = Sequencer::new();
    let a = seq.register(SeqConfig::new("a").in_lane()).unwrap();
    let refused = seq.register(SeqConfig::new("b").in_lane());
    assert_eq!(
        refused,
        Err(Error::LaneCapacityExceeded(SeqId::from_index(1)))
    );
    assert_eq!(seq.len(), 1);
    assert!(seq.sequence_by_name("b").is_none());
    assert_eq!(seq.register(SeqConfig::new("b")), Ok(SeqId::from_index(1)));
    let _ = a;
}

/// semantics.md 7: "a pause passes over a Restarting sequence: while the caller's lane is
/// held, the child stays Restarting, and its new round begins when the caller resumes".
/// main is paused in the tick (3 ms) in which its blocking child c's monitor restarts c.
#[test]
fn a_child_restarted_in_its_callers_pause_tick_begins_again_at_the_resume() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let wi = w.id();
    let c = seq
        .add(SeqConfig::new("c"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let ci = c.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Run(c)]))
        .unwrap();
    let mi = main.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(ci, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 3, 4));
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.pause(mi).unwrap(); // applied at 3 ms
    sim.run_for(ms(3));
    sim.resume(mi).unwrap(); // applied at 6 ms
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(3, mi, Running, Paused, Pause),
            tr(3, ci, Running, Paused, Pause),
            tr(3, wi, Running, Paused, Pause),
            tr(3, wi, Paused, Aborting, Mon(m)),
            tr(3, wi, Aborting, Aborted, Mon(m)),
            tr(3, ci, Paused, Restarting, Mon(m)),
            tr(6, mi, Paused, Running, Resume),
            tr(6, ci, Restarting, Running, Cause::Restart),
            tr(6, wi, Aborted, Running, Start),
            tr(16, wi, Running, Terminated, Completed),
            tr(16, ci, Running, Terminated, Completed),
            tr(16, mi, Running, Terminated, Completed),
        ],
    );
}

/// Restart off the grid: `main` (10 ms class; exit condition flag 5, set from 15 ms) is
/// restarted at 14 ms, at the tick after its exception sequence (10..13 ms) ended; a Level
/// monitor `l` shows when main's polls come. With `busy`, another member of the class
/// running from 0 ms, or without. Returns the times `l` fired and main's end.
fn restart_off_the_grid(with_busy: bool) -> (Vec<u64>, Option<u64>) {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(
            SeqConfig::new("main").polling(ms(10)),
            Node::of(vec![]).until(5),
        )
        .unwrap();
    let mi = main.id();
    let busy = seq
        .add(
            SeqConfig::new("busy").polling(ms(10)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let bi = busy.id();
    let stop = seq
        .add(SeqConfig::new("stop"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = stop.id();
    let mut r = |c: &Ctrl, _: Instant| c.flag(2);
    let mut l = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let rm = monitors
        .add(
            mi,
            Monitor::new("r", &mut r, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let lm = monitors
        .add(
            mi,
            Monitor::new("l", &mut l, Behaviour::Nothing).trigger(rtseq::Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(busy);
    sim.lane(stop);
    sim.before_tick(during(2, 10, 11));
    sim.before_tick(during(3, 13, 14));
    sim.before_tick(from(5, 15));
    if with_busy {
        sim.start(bi).unwrap();
    }
    sim.start(mi).unwrap();
    sim.run_for(ms(35));
    let mut fired = Vec::new();
    for r in sim.records() {
        if let Some(Event::Fired { cause, .. }) = r.event() {
            let t = r.time.as_ticks() / 1000;
            if cause == Mon(rm) {
                assert_eq!(t, 10);
            } else {
                assert_eq!(cause, Mon(lm));
                fired.push(t);
            }
        }
    }
    let restarts: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == mi && t.cause == Cause::Restart)
        .collect();
    assert_eq!(
        restarts,
        vec![tr(14, mi, Restarting, Running, Cause::Restart)]
    );
    let end = sim
        .trace()
        .iter()
        .find(|t| t.sequence == mi && t.to == Terminated)
        .map(|t| t.time.as_ticks() / 1000);
    (fired, end)
}

/// semantics.md 1: "Polls keep the grid of their polling class ... no start moves the
/// grid of a class with an active member ..., nor does a restart, also of the class's only
/// member". main's restart at 14 ms, off the grid, keeps it (10, 20, 30 ms), whether
/// another member keeps the class busy or not. Until session 53, with main the class's
/// only member, the restart moved the grid to 24, 34 ms.
#[test]
fn a_restart_off_the_grid_keeps_the_grid_of_its_class() {
    assert_eq!(restart_off_the_grid(true), (vec![20], Some(20)));
    assert_eq!(restart_off_the_grid(false), (vec![20], Some(20)));
}

/// semantics.md 6: "A timeout that falls due while an exception of its owner is being
/// handled fires at the owner's first poll after that exception ended"; firmware-guide 2:
/// "a monitor or timeout that comes due fires at the first evaluation after the exception
/// ended". Owner `o` polled every 10 ms (1 ms ticks), 15 ms timeout; a warning (Nothing)
/// at 10 ms runs `e` until 23 ms. (Until session 53 semantics.md said "the first tick
/// after", 24 ms here.)
#[test]
fn a_timeout_due_during_an_exception_fires_at_the_owners_next_poll() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("o").polling(ms(10)).timeout(ms(15)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let oi = o.id();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut warn = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("warn", &mut warn, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(from(2, 10));
    sim.before_tick(from(3, 23));
    sim.start(oi).unwrap();
    sim.run_until_idle(ms(60)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Start),
            tr(10, ei, Idle, Running, Mon(m)),
            tr(23, ei, Running, Terminated, Completed),
            // The first tick after the exception ended is 24 ms; o's next poll is 30 ms.
            tr(30, oi, Running, Aborting, Cause::Timeout(oi)),
            tr(30, oi, Aborting, Aborted, Cause::Timeout(oi)),
        ],
    );
}

/// semantics.md 3: "when it has ended, the next tick applies the behaviour"; Monitor::exception:
/// "aborted (the behaviour) at the next tick after it ended" — also for an owner polled
/// every 10 ms: the exception sequence ends at 23 ms, the owner is aborted at 24 ms.
#[test]
fn a_behaviour_is_applied_at_the_next_tick_whatever_the_owners_period() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("o").polling(ms(10)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let oi = o.id();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(from(2, 10));
    sim.before_tick(from(3, 23));
    sim.start(oi).unwrap();
    sim.run_until_idle(ms(60)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Start),
            tr(10, ei, Idle, Running, Mon(m)),
            tr(23, ei, Running, Terminated, Completed),
            tr(24, oi, Running, Aborting, Mon(m)),
            tr(24, oi, Aborting, Aborted, Mon(m)),
        ],
    );
}

/// semantics.md 4: "torn down innermost first (by depth over the whole subtree: every
/// sequence of the deepest level, then those one level up ...)": an unbalanced tree, main
/// → a → a1 → a2 (blocking) and main → b (non-blocking, no children).
#[test]
fn an_abort_of_an_unbalanced_tree_goes_by_depth() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let a2 = seq.add(SeqConfig::new("a2"), Leaf::until(15)).unwrap();
    let a2i = a2.id();
    let a1 = seq
        .add(SeqConfig::new("a1"), Node::of(vec![Op::Step(a2)]))
        .unwrap();
    let a1i = a1.id();
    let b = seq
        .add(SeqConfig::new("b"), Node::of(vec![]).until(15))
        .unwrap();
    let bi = b.id();
    let a = seq
        .add(SeqConfig::new("a"), Node::of(vec![Op::Run(a1)]))
        .unwrap();
    let ai = a.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(bi), Op::Run(a)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(b);
    sim.start(mi).unwrap();
    sim.abort(mi).unwrap();
    sim.step();
    let got: Vec<SeqId> = sim
        .trace()
        .iter()
        .filter(|t| t.to == Aborted)
        .map(|t| t.sequence)
        .collect();
    let pos = |s| got.iter().position(|&x| x == s).unwrap();
    assert_eq!(got.len(), 5);
    assert_eq!(pos(a2i), 0);
    assert_eq!(pos(a1i), 1);
    assert!(pos(ai) < 4 && pos(bi) < 4);
    assert_eq!(pos(mi), 4);
}

/// A step `s` polled every 1 ms restarts its caller `c` (polled every 10 ms, alone in its
/// class) through `RestartCallerOfOwner`: its condition holds at 13 ms only. With an
/// exception sequence `e` (13..16 ms) the restart comes at 17 ms; without, at 13 ms.
/// Returns when c's Level monitor fired (c's polls) and when the restart came.
fn caller_restarted_by_a_faster_child(with_exception: bool) -> (Vec<u64>, u64) {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("s"), Leaf::until(15)).unwrap();
    let si = s.id();
    let c = seq
        .add(
            SeqConfig::new("c").polling(ms(10)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let ci = c.id();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut jam = |c: &Ctrl, _: Instant| c.flag(2);
    let mut l = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let mut jam_def = Monitor::new("jam", &mut jam, Behaviour::RestartCallerOfOwner);
    if with_exception {
        jam_def = jam_def.exception(ei);
    }
    monitors.add(si, jam_def).unwrap();
    let lm = monitors
        .add(
            ci,
            Monitor::new("l", &mut l, Behaviour::Nothing).trigger(rtseq::Trigger::Level),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(c);
    sim.lane(e);
    sim.before_tick(during(2, 13, 14));
    sim.before_tick(from(3, 16));
    sim.start(ci).unwrap();
    sim.run_for(ms(45));
    let fired = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired { cause, .. }) if cause == Mon(lm) => Some(r.time.as_ticks() / 1000),
            _ => None,
        })
        .collect();
    let restart = sim
        .trace()
        .iter()
        .find(|t| t.sequence == ci && t.cause == Cause::Restart)
        .map(|t| t.time.as_ticks() / 1000)
        .unwrap();
    (fired, restart)
}

/// semantics.md 1: "Polls keep the grid of their polling class ... nor does a restart":
/// the same restart of the same caller keeps c's grid (10, 20, 30, 40 ms) applied in the
/// firing tick (13 ms) or at the end of the exception sequence (17 ms). The exception is
/// s's: c, s's caller, is not held ("its callers ... take theirs"). Until session 53 the
/// second moved the grid to 27, 37 ms, and c's poll at 20 ms was lost.
#[test]
fn a_callers_grid_is_kept_by_its_restart_with_or_without_an_exception_sequence() {
    assert_eq!(
        caller_restarted_by_a_faster_child(false),
        (vec![10, 20, 30, 40], 13)
    );
    assert_eq!(
        caller_restarted_by_a_faster_child(true),
        (vec![10, 20, 30, 40], 17)
    );
}

/// semantics.md 5: "the edge restarts with every run or restart of the owner"; "A firing
/// with an exception sequence keeps its monitor's behaviour and limit until the exception
/// sequence ends, and judges the limit again there". A condition that stays true from 1 ms,
/// RestartOwner with a 3 ms exception sequence, limit 3 (default): fired at 1, 6, 11, 16;
/// restarts at 5, 10, 15; the fourth firing escalates to AbortOwner, applied at 20.
#[test]
fn restarts_through_an_exception_sequence_until_the_limit() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let e = seq.add(SeqConfig::new("e"), Wait::new(ms(3))).unwrap();
    let _ei = e.id();
    struct RunWait(rtseq::Seq<Wait>);
    impl Sequence<Ctrl> for RunWait {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.step(&mut self.0).await?;
            Ok(())
        }
    }
    let stop = seq.add(SeqConfig::new("stop"), RunWait(e)).unwrap();
    let si = stop.id();
    let mut always = |_: &Ctrl, _: Instant| true;
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("r", &mut always, Behaviour::RestartOwner).exception(si),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(mi).unwrap();
    sim.run_until_idle(ms(60)).unwrap();
    let fired: Vec<(u64, Behaviour)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired { behaviour, .. }) => Some((r.time.as_ticks() / 1000, behaviour)),
            _ => None,
        })
        .collect();
    use Behaviour::{AbortOwner, RestartOwner};
    assert_eq!(
        fired,
        vec![
            (1, RestartOwner),
            (6, RestartOwner),
            (11, RestartOwner),
            (16, AbortOwner)
        ]
    );
    let main_tr: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|t| t.sequence == mi && t.from != Idle)
        .collect();
    assert_trace(
        &main_tr,
        &[
            tr(5, mi, Running, Restarting, Mon(m)),
            tr(5, mi, Restarting, Running, Cause::Restart),
            tr(10, mi, Running, Restarting, Mon(m)),
            tr(10, mi, Restarting, Running, Cause::Restart),
            tr(15, mi, Running, Restarting, Mon(m)),
            tr(15, mi, Restarting, Running, Cause::Restart),
            tr(20, mi, Running, Aborting, Mon(m)),
            tr(20, mi, Aborting, Aborted, Mon(m)),
        ],
    );
}

/// semantics.md 7: "A sequence held paused by something else ... takes a pause request: it
/// stays paused when that hold ends, until a resume request" — here the hold is an
/// exception (Nothing, exception sequence 2..6 ms): the owner, paused at 3 ms, stays
/// paused after the exception ends, until its resume at 9 ms.
#[test]
fn a_pause_requested_during_an_exception_outlasts_it() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut warn = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("warn", &mut warn, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(during(2, 2, 3));
    sim.before_tick(from(3, 6));
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.pause(mi).unwrap(); // applied at 3 ms
    sim.run_for(ms(6)); // 8 ms
    assert_eq!((sim.state(mi), sim.state(wi)), (Paused, Paused));
    sim.resume(mi).unwrap(); // applied at 9 ms
    sim.run_until_idle(ms(50)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(3, mi, Running, Paused, Pause),
            tr(3, wi, Running, Paused, Pause),
            tr(6, ei, Running, Terminated, Completed),
            tr(9, mi, Paused, Running, Resume),
            tr(9, wi, Paused, Running, Resume),
            // w ran 0..3 and from 9: 10 ms of unpaused time end at 16 ms.
            tr(16, wi, Running, Terminated, Completed),
            tr(16, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 7: a pause request's pause is lifted only by "a resume request ..., or the
/// end of the run: a restart runs unpaused". main, paused by a request at 1 ms, is
/// restarted by its monitor at 3 ms: the new round runs (its wait from 3 ms, 10 ms).
#[test]
fn a_restart_lifts_a_requested_pause() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(during(2, 3, 4));
    sim.start(mi).unwrap();
    sim.pause(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(13)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(1, mi, Running, Paused, Pause),
            tr(1, wi, Running, Paused, Pause),
            tr(3, wi, Paused, Aborting, Mon(m)),
            tr(3, wi, Aborting, Aborted, Mon(m)),
            tr(3, mi, Paused, Restarting, Mon(m)),
            tr(3, mi, Restarting, Running, Cause::Restart),
            tr(3, wi, Aborted, Running, Start),
            tr(13, wi, Running, Terminated, Completed),
            tr(13, mi, Running, Terminated, Completed),
        ],
    );
}

/// A sequence that starts `child` scoped, waits for flag 1, and returns (dropping it).
struct ScopedThenWait {
    child: SeqId,
}
impl Sequence<Ctrl> for ScopedThenWait {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _child = cx.start_scoped(self.child)?;
        cx.wait_until(|cx| cx.control().flag(1)).await;
        Ok(())
    }
}

/// semantics.md 11 / Scoped: the drop requests the abort of "this run alone, restarts (by
/// its own monitors) included": a scoped child restarted by its monitor at 2 ms is still
/// aborted at the tick after its caller returned (5 ms).
#[test]
fn a_scoped_child_restarted_by_its_monitor_is_still_aborted_at_the_drop() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![]).until(15))
        .unwrap();
    let ci = child.id();
    let main = seq
        .add(SeqConfig::new("main"), ScopedThenWait { child: ci })
        .unwrap();
    let mi = main.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(ci, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(child);
    sim.before_tick(during(2, 2, 3));
    sim.before_tick(from(1, 5));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(6)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(2, ci, Running, Restarting, Mon(m)),
            tr(2, ci, Restarting, Running, Cause::Restart),
            tr(5, mi, Running, Terminated, Completed),
            tr(6, ci, Running, Aborting, Cause::Abort),
            tr(6, ci, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// semantics.md 1: "a poll that falls due while its sequence is held (... handling an
/// exception ...) is skipped, not taken when the hold ends": owner `o` (10 ms) whose exit
/// condition holds from 15 ms, held by a warning's exception sequence 10..23 ms, ends at
/// its next grid point 30 ms (the behaviour, Nothing, is applied at 24 ms).
#[test]
fn an_exit_poll_due_during_an_exception_is_taken_at_the_next_grid_point() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("o").polling(ms(10)),
            Node::of(vec![]).until(5),
        )
        .unwrap();
    let oi = o.id();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut warn = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("warn", &mut warn, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.before_tick(during(2, 10, 11));
    sim.before_tick(from(3, 23));
    sim.before_tick(from(5, 15));
    sim.start(oi).unwrap();
    sim.run_until_idle(ms(60)).unwrap();
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Start),
            tr(10, ei, Idle, Running, Mon(m)),
            tr(23, ei, Running, Terminated, Completed),
            tr(30, oi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 7: "a restart runs unpaused" — also a restart applied at the end of an
/// exception sequence to an owner paused by a request meanwhile.
#[test]
fn a_restart_at_an_exception_end_lifts_a_requested_pause() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = dwell_main(&seq);
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(during(2, 2, 3));
    sim.before_tick(from(3, 6));
    sim.start(mi).unwrap();
    sim.run_for(ms(2));
    sim.pause(mi).unwrap(); // applied at 3 ms
    assert_eq!(sim.run_until_idle(ms(50)), Some(at(17)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(3, mi, Running, Paused, Pause),
            tr(3, wi, Running, Paused, Pause),
            tr(6, ei, Running, Terminated, Completed),
            tr(7, wi, Paused, Aborting, Mon(m)),
            tr(7, wi, Aborting, Aborted, Mon(m)),
            tr(7, mi, Paused, Restarting, Mon(m)),
            tr(7, mi, Restarting, Running, Cause::Restart),
            tr(7, wi, Aborted, Running, Start),
            tr(17, wi, Running, Terminated, Completed),
            tr(17, mi, Running, Terminated, Completed),
        ],
    );
}

/// semantics.md 3: "when it has ended, the next tick applies the behaviour (it reports the
/// end before it evaluates any monitor; until then the exception sequence is its owner's,
/// and a start of it is Err(Error::AlreadyRunning) ...)": `e` ended at 5 ms; a start of it
/// before the 6 ms tick is refused although its state is Terminated; after it, taken.
#[test]
fn an_ended_exception_sequence_is_its_owners_until_the_next_tick() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = dwell_main(&seq);
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![]).until(3))
        .unwrap();
    let ei = e.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(
            mi,
            Monitor::new("a", &mut a, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(during(2, 2, 3));
    sim.before_tick(during(3, 5, 6));
    sim.start(mi).unwrap();
    sim.run_for(ms(5));
    assert_eq!(sim.state(ei), Terminated);
    assert_eq!(sim.start(ei), Err(Error::AlreadyRunning(ei)));
    sim.step(); // 6 ms: the end is reported
    assert_eq!(sim.start(ei), Ok(()));
}

/// A sequence whose polled wait, at `at_ms`, requests the abort of `target` and records
/// the request's result in the control's returned log (line 7).
struct AbortAt {
    target: SeqId,
    at_ms: u64,
}
impl Sequence<Ctrl> for AbortAt {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let (target, at_ms) = (self.target, self.at_ms);
        cx.wait_until(move |cx| {
            if cx.now().as_ticks() / 1000 == at_ms {
                let r = cx.sequence_by_id(target).unwrap().abort();
                cx.control().returned.borrow_mut().push(Returned {
                    ms: at_ms,
                    seq: cx.id(),
                    line: 7,
                    result: r.map(|()| rtseq::Done::Completed).map_err(Failure::from),
                });
            }
            false
        })
        .await;
        Ok(())
    }
}

/// semantics.md 8: from an abort request to the tick that carries it out, "a restart its
/// lane has not taken up yet is not begun (the run is aborted from `Restarting`)". `t` is
/// restarted by its monitor at 3 ms; a lane of higher priority, polled first in that
/// tick's pass, requests t's abort: t's new round never begins and the 4 ms tick aborts it
/// from Restarting.
#[test]
fn an_abort_requested_before_the_lane_takes_up_a_restart_aborts_from_restarting() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(ms(10))).unwrap();
    let wi = w.id();
    let t = seq
        .add(SeqConfig::new("t"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let ti = t.id();
    let h = seq
        .add(
            SeqConfig::new("h"),
            AbortAt {
                target: ti,
                at_ms: 3,
            },
        )
        .unwrap();
    let hi = h.id();
    let mut a = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(ti, Monitor::new("a", &mut a, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(t);
    sim.lane_with_priority(h, 2);
    sim.before_tick(during(2, 3, 4));
    sim.start(ti).unwrap();
    sim.start(hi).unwrap();
    sim.run_for(ms(5));
    assert_eq!(
        ctrl.returned
            .borrow()
            .iter()
            .find(|r| r.line == 7)
            .map(|r| r.result),
        Some(Ok(rtseq::Done::Completed)),
        "the abort request of a Restarting sequence is taken"
    );
    let got: Vec<Transition> = sim
        .trace()
        .iter()
        .copied()
        .filter(|x| x.sequence == ti || x.sequence == wi)
        .collect();
    assert_trace(
        &got,
        &[
            tr(0, ti, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(3, wi, Running, Aborting, Mon(m)),
            tr(3, wi, Aborting, Aborted, Mon(m)),
            tr(3, ti, Running, Restarting, Mon(m)),
            tr(4, ti, Restarting, Aborting, Cause::Abort),
            tr(4, ti, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// The grid with a timeout: `o` (10 ms, alone in its class) has a 15 ms timeout that
/// restarts it (limit 1) after its exception sequence `e` (3 ms). The timeout fires at
/// 20 ms (first poll after 15 ms), e runs 20..23, the restart comes at 24 ms; the fresh
/// timeout is due at 39 ms and fires at 40 ms, on the kept grid (until session 53: 44 ms).
#[test]
fn a_timeout_restart_through_its_exception_sequence_keeps_the_grid() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let e = seq.add(SeqConfig::new("e"), Wait::new(ms(3))).unwrap();
    struct RunWait(rtseq::Seq<Wait>);
    impl Sequence<Ctrl> for RunWait {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.step(&mut self.0).await?;
            Ok(())
        }
    }
    let stop = seq.add(SeqConfig::new("stop"), RunWait(e)).unwrap();
    let si = stop.id();
    let o = seq
        .add(
            SeqConfig::new("o")
                .polling(ms(10))
                .timeout(ms(15))
                .timeout_behaviour(Behaviour::RestartOwner)
                .timeout_restart_limit(1)
                .timeout_exception(si),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let oi = o.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(o);
    sim.lane(stop);
    sim.start(oi).unwrap();
    sim.run_until_idle(ms(100)).unwrap();
    let fired: Vec<(u64, Behaviour)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired { behaviour, .. }) => Some((r.time.as_ticks() / 1000, behaviour)),
            _ => None,
        })
        .collect();
    assert_eq!(
        fired,
        vec![(20, Behaviour::RestartOwner), (40, Behaviour::AbortOwner)],
        "{}",
        show(sim.trace())
    );
}
