//! Pause, resume, abort and abort-all requests made from other tasks, from user code
//! (conditions, cleanup hooks, wakers, actions) and at awkward moments, checked on exact
//! traces and exact simulated times through the public API (a cold review, session 58).

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::pin::Pin;

use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, ConditionFn, Cx, Done, Duration, Error, Event, Failure, Handle, Instant,
    Monitor, MonitorId, Monitors, Outcome, Record, Request, Requester, RunningState, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Transition,
};

/// A request made from user code: the time in ms, what asked, the answer.
type Asked = (u64, &'static str, Result<(), Error>);
/// A request made from a waker: the time in ms, the answer, the state it saw.
type WakerAsked = (u64, Result<(), Error>, RunningState);

type Sq = Sequencer<Ctl, 8>;
type Mons = Monitors<'static, Ctl, 4, ConditionFn<Ctl>>;

/// The control system: flags the test sets, a log of action lines and of the results of
/// requests made from user code, and the sequencer (so that cleanup hooks, plain `fn`s,
/// can reach it).
#[derive(Default)]
struct Ctl {
    seq: Cell<Option<&'static Sq>>,
    flags: [Cell<bool>; 8],
    /// (ms, sequence name, what)
    log: RefCell<Vec<(u64, &'static str, &'static str)>>,
    /// Results of requests made from user code: (ms, what, result).
    asked: RefCell<Vec<Asked>>,
}

impl Ctl {
    fn flag(&self, i: usize) -> bool {
        self.flags[i].get()
    }
    fn set(&self, i: usize, v: bool) {
        self.flags[i].set(v)
    }
    fn seq(&self) -> &'static Sq {
        self.seq.get().unwrap()
    }
    fn h(&self, i: usize) -> Handle<'static, Ctl> {
        self.seq().sequence_by_id(SeqId::from_index(i)).unwrap()
    }
    fn now_ms(&self) -> u64 {
        self.seq().now().as_ticks() / 1000
    }
    fn ask(&self, what: &'static str, r: Result<(), Error>) {
        let ms = self.now_ms();
        self.asked.borrow_mut().push((ms, what, r));
    }
    fn note(&self, ms: u64, name: &'static str, what: &'static str) {
        self.log.borrow_mut().push((ms, name, what));
    }
}

fn new_seq() -> &'static Sq {
    Box::leak(Box::new(Sequencer::new()))
}

type Cond = Box<dyn FnMut(&Cx<'_, Ctl>) -> bool>;

/// A sequence: optional pre- and exit conditions (closures), an action that logs a line
/// and runs an optional blocking child.
struct Probe {
    name: &'static str,
    pre: Option<Cond>,
    exit: Option<Cond>,
    child: Option<Box<Seq<Probe>>>,
}

impl Probe {
    fn new(name: &'static str) -> Self {
        Probe {
            name,
            pre: None,
            exit: None,
            child: None,
        }
    }
    /// Ends once flag `f` is set.
    fn until(mut self, f: usize) -> Self {
        self.exit = Some(Box::new(move |cx| cx.control().flag(f)));
        self
    }
    fn exit(mut self, c: impl FnMut(&Cx<'_, Ctl>) -> bool + 'static) -> Self {
        self.exit = Some(Box::new(c));
        self
    }
    fn pre(mut self, c: impl FnMut(&Cx<'_, Ctl>) -> bool + 'static) -> Self {
        self.pre = Some(Box::new(c));
        self
    }
    fn child(mut self, c: Seq<Probe>) -> Self {
        self.child = Some(Box::new(c));
        self
    }
}

type Boxed<'f> = Pin<Box<dyn Future<Output = Result<Done, Failure>> + 'f>>;

impl Sequence<Ctl> for Probe {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        let ms = cx.now().as_ticks() / 1000;
        cx.control().note(ms, self.name, "action");
        if let Some(c) = self.child.as_mut() {
            let f: Boxed<'_> = Box::pin(cx.run(&mut **c));
            let r = f.await;
            let ms = cx.now().as_ticks() / 1000;
            cx.control().note(
                ms,
                self.name,
                if r.is_ok() { "child ok" } else { "child err" },
            );
            r?;
        }
        Ok(())
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctl>) -> bool {
        match self.pre.as_mut() {
            Some(f) => f(cx),
            None => true,
        }
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctl>) -> bool {
        match self.exit.as_mut() {
            Some(f) => f(cx),
            None => true,
        }
    }
}

fn id(i: usize) -> SeqId {
    SeqId::from_index(i)
}

fn tr(ms: u64, seq: SeqId, from: RunningState, to: RunningState, cause: Cause) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

fn show(trace: &[Transition]) -> String {
    trace
        .iter()
        .map(|t| {
            format!(
                "{:>5} ms  #{} {:?} -> {:?} ({:?})\n",
                t.time.as_ticks() / 1000,
                t.sequence.index(),
                t.from,
                t.to,
                t.cause
            )
        })
        .collect()
}

#[track_caller]
fn assert_trace(got: &[Transition], want: &[Transition]) {
    assert_eq!(got, want, "\n{}", show(got));
}

/// The events of the records, with their times in ms.
fn events(records: &[Record]) -> Vec<(u64, Event)> {
    records
        .iter()
        .filter_map(|r| r.event().map(|e| (r.time.as_ticks() / 1000, e)))
        .collect()
}

fn requested(sequence: SeqId, request: Request, by: Requester) -> Event {
    Event::Requested {
        sequence,
        request,
        by,
    }
}

fn flag0(c: &Ctl, _: Instant) -> bool {
    c.flag(0)
}
fn flag1(c: &Ctl, _: Instant) -> bool {
    c.flag(1)
}

const APP: Requester = Requester::Application;

// ---------------------------------------------------------------------------------------
// Requests against every running state, and their errors.
// ---------------------------------------------------------------------------------------

/// Idle, Terminated and Aborted sequences refuse every request with the documented error,
/// and a refused request leaves no record.
#[test]
fn requests_of_idle_and_ended_sequences_are_refused_and_not_recorded() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    let h = sim.handle(ai).unwrap();
    let refused = |h: &Handle<'_, Ctl>| (h.pause(), h.resume(), h.abort());
    let want = (
        Err(Error::NotRunning(ai)),
        Err(Error::NotPaused(ai)),
        Err(Error::NotRunning(ai)),
    );
    assert_eq!(refused(&h), want, "idle");
    sim.start(ai).unwrap();
    ctl.set(0, true);
    sim.step();
    assert_eq!(h.state(), Terminated);
    assert_eq!(refused(&h), want, "terminated");
    ctl.set(0, false);
    sim.start(ai).unwrap();
    h.abort().unwrap();
    sim.step();
    assert_eq!(h.state(), Aborted);
    assert_eq!(refused(&h), want, "aborted");
    sim.step();
    assert_eq!(
        events(sim.records()),
        [(1, requested(ai, Request::Abort, APP))]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Terminated, Cause::Completed),
            tr(1, ai, Terminated, Running, Cause::Start),
            tr(2, ai, Running, Aborting, Cause::Abort),
            tr(2, ai, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// A pause and a resume before one tick: the later counts (nothing happens), both are
/// recorded; a second resume then has no pause to take back (`NotPaused`), a second pause
/// takes the resume back and the tick pauses.
#[test]
fn pause_then_resume_before_one_tick_then_pause_again() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    let h = sim.handle(ai).unwrap();
    sim.step(); // 1 ms
    assert_eq!(h.pause(), Ok(()));
    assert_eq!(h.resume(), Ok(()));
    assert_eq!(h.resume(), Err(Error::NotPaused(ai)));
    sim.step(); // 2 ms: nothing
    assert_eq!(h.state(), Running);
    assert_eq!(h.resume(), Err(Error::NotPaused(ai)));
    assert_eq!(h.pause(), Ok(()));
    assert_eq!(h.resume(), Ok(()));
    assert_eq!(h.pause(), Ok(()));
    sim.step(); // 3 ms: paused
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(3, ai, Running, Paused, Cause::Pause),
        ],
    );
    assert_eq!(
        events(sim.records()),
        [
            (1, requested(ai, Request::Pause, APP)),
            (1, requested(ai, Request::Resume, APP)),
            (2, requested(ai, Request::Pause, APP)),
            (2, requested(ai, Request::Resume, APP)),
            (2, requested(ai, Request::Pause, APP)),
        ]
    );
}

/// Paused by a request: a resume then a pause before one tick leave it paused; a third
/// pause, with a pause pending and no resume, is `AlreadyPaused`. A resume then resumes
/// it at the next tick.
#[test]
fn resume_then_pause_of_a_paused_sequence_leaves_it_paused() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    let h = sim.handle(ai).unwrap();
    h.pause().unwrap();
    sim.step(); // 1 ms: paused
    assert_eq!(h.pause(), Err(Error::AlreadyPaused(ai)));
    assert_eq!(h.resume(), Ok(()));
    assert_eq!(h.pause(), Ok(()));
    assert_eq!(h.pause(), Err(Error::AlreadyPaused(ai)));
    sim.step(); // 2 ms: still paused
    assert_eq!(h.state(), Paused);
    h.resume().unwrap();
    sim.step(); // 3 ms
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Paused, Cause::Pause),
            tr(3, ai, Paused, Running, Cause::Resume),
        ],
    );
}

/// Two pauses, then two aborts, before one tick each: accepted, recorded, carried out once.
#[test]
fn a_request_made_twice_is_carried_out_once() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    let h = sim.handle(ai).unwrap();
    assert_eq!((h.pause(), h.pause()), (Ok(()), Ok(())));
    sim.step();
    assert_eq!((h.abort(), h.abort()), (Ok(()), Ok(())));
    sim.step();
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Paused, Cause::Pause),
            tr(2, ai, Paused, Aborting, Cause::Abort),
            tr(2, ai, Aborting, Aborted, Cause::Abort),
        ],
    );
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
}

/// A pause applied in the tick whose poll would end the run: the poll is skipped, the run
/// holds; the resume request, applied before the polls, takes the due poll: the run ends in
/// the resume's tick.
#[test]
fn a_pause_beats_the_end_due_in_its_tick_and_the_resume_takes_the_due_poll() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.pause(ai).unwrap();
    ctl.set(0, true);
    sim.run_for(Duration::from_millis(8)); // to 10 ms
    assert_eq!(sim.state(ai), Paused);
    sim.resume(ai).unwrap();
    sim.step(); // 11 ms
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(3, ai, Running, Paused, Cause::Pause),
            tr(11, ai, Paused, Running, Cause::Resume),
            tr(11, ai, Running, Terminated, Cause::Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Requests made from user code: conditions, cleanup hooks.
// ---------------------------------------------------------------------------------------

/// An exit condition that requests its own sequence's abort and says "done": the run does
/// not end (an accepted abort request ends the run aborted), the exit condition is not
/// asked again, and the next tick aborts it.
#[test]
fn an_exit_condition_that_requests_its_own_abort_ends_aborted_at_the_next_tick() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let asked = std::rc::Rc::new(Cell::new(0u32));
    let n = asked.clone();
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").exit(move |cx| {
                if !cx.control().flag(0) {
                    return false;
                }
                n.set(n.get() + 1);
                let r = cx.sequence_by_id(cx.id()).unwrap().abort();
                cx.control().ask("self abort", r);
                true
            }),
        )
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step(); // 1
    ctl.set(0, true);
    sim.step(); // 2: requests its abort, does not end
    assert_eq!(sim.state(ai), Running);
    sim.step(); // 3: aborted
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(3, ai, Running, Aborting, Cause::Abort),
            tr(3, ai, Aborting, Aborted, Cause::Abort),
        ],
    );
    assert_eq!(*ctl.asked.borrow(), [(2, "self abort", Ok(()))]);
    assert_eq!(asked.get(), 1);
    assert_eq!(
        events(sim.records()),
        [(2, requested(ai, Request::Abort, Requester::Sequence(ai)))]
    );
}

/// An exit condition that requests its own pause and says "done": a pause does not hold
/// an end, the run completes; the pause queued for that run is not carried out on the next
/// run, started before the tick (the request is of the run it was made of).
#[test]
fn a_pause_made_of_run_k_that_ended_is_not_carried_out_on_run_k_plus_1() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").exit(move |cx| {
                if !cx.control().flag(0) {
                    return false;
                }
                cx.control().set(0, false); // the next run does not end here
                let r = cx.sequence_by_id(cx.id()).unwrap().pause();
                cx.control().ask("self pause", r);
                true
            }),
        )
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step(); // 1
    ctl.set(0, true);
    sim.step(); // 2: pause requested, then the run ends
    assert_eq!(sim.state(ai), Terminated);
    sim.start(ai).unwrap(); // run k+1, at 2 ms
    sim.run_for(Duration::from_millis(3)); // 5
    assert_eq!(sim.state(ai), Running);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(2, ai, Running, Terminated, Cause::Completed),
            tr(2, ai, Terminated, Running, Cause::Start),
        ],
    );
    assert_eq!(*ctl.asked.borrow(), [(2, "self pause", Ok(()))]);
}

/// Sequence `a` (polled first in the tick's pass) requests the pause of `b`, whose exit
/// condition holds in the same pass: `b` completes; the pause of that run is not carried
/// out on `b`'s next run, started before the tick.
#[test]
fn a_peer_s_pause_of_a_run_that_ends_in_the_same_pass_misses_the_next_run() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").exit(move |cx| {
                if cx.control().flag(0) {
                    let r = cx.sequence_by_id(id(1)).unwrap().pause();
                    cx.control().ask("pause b", r);
                    return true;
                }
                false
            }),
        )
        .unwrap();
    let b = seq
        .add(SeqConfig::new("b"), Probe::new("b").until(0))
        .unwrap();
    let (ai, bi) = (a.id(), b.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.lane(b);
    sim.start(ai).unwrap();
    sim.start(bi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: a pauses b, both end
    ctl.set(0, false);
    sim.start(bi).unwrap();
    sim.run_for(Duration::from_millis(2)); // 3
    assert_eq!(*ctl.asked.borrow(), [(1, "pause b", Ok(()))]);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(0, bi, Idle, Running, Cause::Start),
            tr(1, ai, Running, Terminated, Cause::Completed),
            tr(1, bi, Running, Terminated, Cause::Completed),
            tr(1, bi, Terminated, Running, Cause::Start),
        ],
    );
}

/// Sequence `a` (polled first) requests the abort of `b`, whose exit condition holds in the
/// same pass: `b` does not end; the next tick aborts it (`Cause::Abort`).
#[test]
fn a_peer_s_abort_holds_the_end_due_in_the_same_pass() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").exit(move |cx| {
                if cx.control().flag(0) {
                    let r = cx.sequence_by_id(id(1)).unwrap().abort();
                    cx.control().ask("abort b", r);
                    return true;
                }
                false
            }),
        )
        .unwrap();
    let b = seq
        .add(SeqConfig::new("b"), Probe::new("b").until(0))
        .unwrap();
    let (ai, bi) = (a.id(), b.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.lane(b);
    sim.start(ai).unwrap();
    sim.start(bi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1
    assert_eq!(sim.state(bi), Running);
    sim.step(); // 2
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(0, bi, Idle, Running, Cause::Start),
            tr(1, ai, Running, Terminated, Cause::Completed),
            tr(2, bi, Running, Aborting, Cause::Abort),
            tr(2, bi, Aborting, Aborted, Cause::Abort),
        ],
    );
    assert_eq!(
        sim.handle(bi).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Abort))
    );
}

/// A pre-condition that requests its own sequence's abort and says "go": the run begins
/// nothing more until the tick aborts it, so its action's first line does not run.
#[test]
fn a_pre_condition_that_requests_its_own_abort_runs_no_action() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").until(7).pre(|cx| {
                let r = cx.sequence_by_id(cx.id()).unwrap().abort();
                cx.control().ask("self abort", r);
                true
            }),
        )
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step();
    assert_eq!(*ctl.asked.borrow(), [(0, "self abort", Ok(()))]);
    assert_eq!(
        *ctl.log.borrow(),
        [],
        "the action ran after its abort was requested"
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Aborting, Cause::Abort),
            tr(1, ai, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// An exit condition that posts abort-all and then starts another sequence through its
/// context's handle: the start is refused (`NotRunning` of the condition's sequence, an
/// abort-all waits), and its own run does not end: the next tick aborts it (`AbortAll`).
#[test]
fn an_exit_condition_that_posts_abort_all_cannot_start_and_does_not_end() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").exit(move |cx| {
                if cx.control().flag(0) {
                    cx.control().seq().abort_all();
                    let r = cx.sequence_by_id(id(1)).unwrap().start();
                    cx.control().ask("start b", r);
                    return true;
                }
                false
            }),
        )
        .unwrap();
    let b = seq
        .add(SeqConfig::new("b"), Probe::new("b").until(0))
        .unwrap();
    let (ai, _bi) = (a.id(), b.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.lane(b);
    sim.start(ai).unwrap();
    ctl.set(0, true);
    sim.step(); // 1
    sim.step(); // 2
    assert_eq!(
        *ctl.asked.borrow(),
        [(1, "start b", Err(Error::NotRunning(ai)))]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(2, ai, Running, Aborting, Cause::AbortAll),
            tr(2, ai, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert_eq!(events(sim.records()), [(2, Event::AbortAll { by: APP })]);
}

/// Abort-all, then an application's start in the same tick period: the start is taken, its
/// run holds before its pre-condition and is aborted by the next tick; a start after that
/// tick runs normally.
#[test]
fn a_start_right_after_abort_all_is_aborted_by_the_next_tick_without_its_pre_condition() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let pre_calls = std::rc::Rc::new(Cell::new(0u32));
    let n = pre_calls.clone();
    let a = seq
        .add(
            SeqConfig::new("a"),
            Probe::new("a").until(0).pre(move |_| {
                n.set(n.get() + 1);
                true
            }),
        )
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.step(); // 1
    sim.abort_all();
    assert_eq!(sim.start(ai), Ok(()));
    assert_eq!(pre_calls.get(), 0);
    assert_eq!(sim.state(ai), Running);
    sim.step(); // 2: aborted
    assert_eq!(pre_calls.get(), 0);
    sim.start(ai).unwrap(); // 2: runs
    assert_eq!(pre_calls.get(), 1);
    sim.step(); // 3
    assert_trace(
        sim.trace(),
        &[
            tr(1, ai, Idle, Running, Cause::Start),
            tr(2, ai, Running, Aborting, Cause::AbortAll),
            tr(2, ai, Aborting, Aborted, Cause::AbortAll),
            tr(2, ai, Aborted, Running, Cause::Start),
        ],
    );
    assert_eq!(
        *ctl.log.borrow(),
        [(2, "a", "action")],
        "only the second run's action ran"
    );
}

// Cleanup hooks that make requests. Ids: 0 = x (hook asks), 1 = y (target).
fn hook_aborts_y_and_itself(c: &Ctl) {
    c.ask("hook: abort y", c.h(1).abort());
    c.ask("hook: abort self", c.h(0).abort());
    c.ask("hook: pause self", c.h(0).pause());
}

/// A cleanup hook (running in the tick, its sequence `Aborting`) requests the abort of
/// another running sequence and of its own: the other is aborted by the following tick;
/// its own (`Aborting`) is refused with `NotRunning`.
#[test]
fn a_cleanup_hook_s_abort_request_is_carried_out_by_the_following_tick() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let x = seq
        .add(
            SeqConfig::new("x").on_abort(hook_aborts_y_and_itself),
            Probe::new("x").until(7),
        )
        .unwrap();
    let y = seq
        .add(SeqConfig::new("y"), Probe::new("y").until(7))
        .unwrap();
    let (xi, yi) = (x.id(), y.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(x);
    sim.lane(y);
    sim.start(xi).unwrap();
    sim.start(yi).unwrap();
    sim.abort(xi).unwrap();
    sim.step(); // 1
    sim.step(); // 2
    assert_eq!(
        *ctl.asked.borrow(),
        [
            (1, "hook: abort y", Ok(())),
            (1, "hook: abort self", Err(Error::NotRunning(xi))),
            (1, "hook: pause self", Err(Error::NotRunning(xi))),
        ]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, yi, Idle, Running, Cause::Start),
            tr(1, xi, Running, Aborting, Cause::Abort),
            tr(1, xi, Aborting, Aborted, Cause::Abort),
            tr(2, yi, Running, Aborting, Cause::Abort),
            tr(2, yi, Aborting, Aborted, Cause::Abort),
        ],
    );
}

fn hook_posts_abort_all(c: &Ctl) {
    c.seq().abort_all();
    c.ask("hook: abort_all", Ok(()));
}

/// A cleanup hook that posts abort-all during an abort-all: it stays for the next tick, so
/// an application's start right after the tick is aborted by the next one (as documented:
/// semantics 8, "An abort-all asked for again meanwhile (a cleanup hook's …) stays for the
/// next tick").
#[test]
fn a_cleanup_hook_s_abort_all_during_abort_all_aborts_a_start_made_right_after() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let x = seq
        .add(
            SeqConfig::new("x").on_abort(hook_posts_abort_all),
            Probe::new("x").until(7),
        )
        .unwrap();
    let y = seq
        .add(SeqConfig::new("y"), Probe::new("y").until(7))
        .unwrap();
    let (xi, yi) = (x.id(), y.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(x);
    sim.lane(y);
    sim.start(xi).unwrap();
    sim.abort_all();
    sim.step(); // 1: x aborted, its hook posts abort-all again
    sim.start(yi).unwrap();
    sim.step(); // 2: y aborted
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Cause::Start),
            tr(1, xi, Running, Aborting, Cause::AbortAll),
            tr(1, xi, Aborting, Aborted, Cause::AbortAll),
            tr(1, yi, Idle, Running, Cause::Start),
            tr(2, yi, Running, Aborting, Cause::AbortAll),
            tr(2, yi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert_eq!(
        events(sim.records()),
        [
            (1, Event::AbortAll { by: APP }),
            (2, Event::AbortAll { by: APP })
        ]
    );
}

// ---------------------------------------------------------------------------------------
// Blocking children, pauses by a caller, order within one tick.
// ---------------------------------------------------------------------------------------

/// A child paused with its paused caller takes a pause request of its own (and a resume,
/// which does nothing while the caller is paused); after a pause request it stays paused
/// when the caller resumes, until its own resume.
#[test]
fn a_child_paused_with_its_caller_takes_its_own_pause_and_stays_paused() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(0))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.pause(pi).unwrap();
    sim.step(); // 1: both paused
    let hc = sim.handle(ci).unwrap();
    assert_eq!(hc.state(), Paused);
    assert_eq!(hc.resume(), Ok(()));
    sim.step(); // 2: nothing (the caller holds it)
    assert_eq!(hc.state(), Paused);
    assert_eq!(hc.pause(), Ok(()));
    sim.step(); // 3
    sim.resume(pi).unwrap();
    sim.step(); // 4: p resumes, c stays paused
    assert_eq!((sim.state(pi), hc.state()), (Running, Paused));
    assert_eq!(hc.pause(), Err(Error::AlreadyPaused(ci)));
    hc.resume().unwrap();
    ctl.set(0, true);
    sim.step(); // 5: c resumes and ends, then p
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(1, pi, Running, Paused, Cause::Pause),
            tr(1, ci, Running, Paused, Cause::Pause),
            tr(4, pi, Paused, Running, Cause::Resume),
            tr(5, ci, Paused, Running, Cause::Resume),
            tr(5, ci, Running, Terminated, Cause::Completed),
            tr(5, pi, Running, Terminated, Cause::Completed),
        ],
    );
}

/// In one tick: a pause of a blocking child (lower id) and an abort of its caller. The
/// trace shows what the tick did, in order.
#[test]
fn a_pause_of_a_child_and_an_abort_of_its_caller_in_one_tick() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(0))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.pause(ci).unwrap();
    sim.abort(pi).unwrap();
    sim.step(); // 1
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(1, ci, Running, Paused, Cause::Pause),
            tr(1, ci, Paused, Aborting, Cause::Abort),
            tr(1, ci, Aborting, Aborted, Cause::Abort),
            tr(1, pi, Running, Aborting, Cause::Abort),
            tr(1, pi, Aborting, Aborted, Cause::Abort),
        ],
    );
}

/// Abort-all and a pause request before one tick: the abort-all comes first, the pause
/// finds nothing to pause.
#[test]
fn abort_all_and_a_pause_in_one_tick_pause_nothing() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.pause(ai).unwrap();
    sim.abort_all();
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Aborting, Cause::AbortAll),
            tr(1, ai, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert_eq!(
        events(sim.records()),
        [
            (0, requested(ai, Request::Pause, APP)),
            (1, Event::AbortAll { by: APP }),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// Monitors: PauseOwner holds, exception sequences under way.
// ---------------------------------------------------------------------------------------

/// Held by a `PauseOwner` monitor: a pause request is taken, a resume is `HeldByMonitor`;
/// when the condition clears the sequence stays paused (paused by request), until a resume.
#[test]
fn a_pause_request_of_a_sequence_held_by_a_pause_owner_monitor_outlasts_the_hold() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut mons = Mons::new();
    let m = mons
        .add(ai, Monitor::with_fn("hold", flag0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step(); // 1
    ctl.set(0, true);
    sim.step(); // 2: held
    assert_eq!(sim.state(ai), Paused);
    assert_eq!(sim.resume(ai), Err(Error::HeldByMonitor(ai)));
    assert_eq!(sim.pause(ai), Ok(()));
    assert_eq!(
        sim.pause(ai),
        Ok(()),
        "a pause pending: no resume pending either"
    );
    sim.step(); // 3
    assert_eq!(sim.resume(ai), Err(Error::HeldByMonitor(ai)));
    ctl.set(0, false);
    sim.step(); // 4: the hold ends, the pause request holds it
    assert_eq!(sim.state(ai), Paused);
    assert_eq!(sim.pause(ai), Err(Error::AlreadyPaused(ai)));
    sim.resume(ai).unwrap();
    sim.step(); // 5
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(2, ai, Running, Paused, mc),
            tr(5, ai, Paused, Running, Cause::Resume),
        ],
    );
}

/// Ids: 0 = e (exception sequence, in a lane, ends with flag 1), 1 = o (owner).
fn owner_with_exception(
    seq: &'static Sq,
    behaviour: Behaviour,
) -> (Seq<Probe>, Seq<Probe>, Mons, MonitorId) {
    let e = seq
        .add(SeqConfig::new("e").in_lane(), Probe::new("e").until(1))
        .unwrap();
    let o = seq
        .add(SeqConfig::new("o"), Probe::new("o").until(7))
        .unwrap();
    let mut mons = Mons::new();
    let m = mons
        .add(
            o.id(),
            Monitor::with_fn("fault", flag0, behaviour).exception(e.id()),
        )
        .unwrap();
    (e, o, mons, m)
}

/// An abort request of an owner whose exception sequence runs: the tick aborts the
/// exception sequence (below the owner) and the owner, `Cause::Abort`; the behaviour goes
/// with the run; `exception_is_active` ends (an abort for another cause).
#[test]
fn an_abort_request_of_an_owner_during_its_exception_sequence() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::RestartOwner);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: fires, e starts
    assert_eq!(sim.state(ei), Running);
    let ho = sim.handle(oi).unwrap();
    assert!(ho.exception_is_active());
    ho.abort().unwrap();
    sim.step(); // 2
    sim.step(); // 3
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, Cause::Monitor(m)),
            tr(2, ei, Running, Aborting, Cause::Abort),
            tr(2, ei, Aborting, Aborted, Cause::Abort),
            tr(2, oi, Running, Aborting, Cause::Abort),
            tr(2, oi, Aborting, Aborted, Cause::Abort),
        ],
    );
    let _ = mc;
    assert_eq!(ho.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    assert!(!ho.exception_is_active());
}

/// A pause request of an owner whose exception sequence (behaviour `Nothing`) runs: the
/// owner pauses; the exception sequence ends, `Nothing` is applied, the owner stays paused
/// (paused by request) until its resume.
#[test]
fn a_pause_of_an_owner_during_its_exception_outlasts_the_exception() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::Nothing);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: fires, e starts
    sim.pause(oi).unwrap();
    sim.step(); // 2: o paused
    ctl.set(1, true);
    sim.step(); // 3: e ends
    sim.step(); // 4: Nothing applied; o stays paused
    assert_eq!(sim.state(oi), Paused);
    assert!(!sim.handle(oi).unwrap().exception_is_active());
    sim.resume(oi).unwrap();
    ctl.set(7, true);
    sim.step(); // 5: resumes and ends
    let _ = m;
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, Cause::Monitor(m)),
            tr(2, oi, Running, Paused, Cause::Pause),
            tr(3, ei, Running, Terminated, Cause::Completed),
            tr(5, oi, Paused, Running, Cause::Resume),
            tr(5, oi, Running, Terminated, Cause::Completed),
        ],
    );
}

/// Abort-all while an exception sequence runs for an `AbortOwner` monitor: both are
/// aborted by abort-all; the owner's outcome is `Aborted(AbortAll)` and its exception is
/// no longer active.
#[test]
fn abort_all_during_an_exception_sequence_drops_its_behaviour() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::AbortOwner);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1
    sim.abort_all();
    sim.step(); // 2
    sim.step(); // 3
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, Cause::Monitor(m)),
            tr(2, ei, Running, Aborting, Cause::AbortAll),
            tr(2, ei, Aborting, Aborted, Cause::AbortAll),
            tr(2, oi, Running, Aborting, Cause::AbortAll),
            tr(2, oi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    let ho = sim.handle(oi).unwrap();
    assert_eq!(ho.last_outcome(), Some(Outcome::Aborted(Cause::AbortAll)));
    assert!(!ho.exception_is_active());
    assert_eq!(
        events(sim.records()),
        [
            (
                1,
                Event::Fired {
                    owner: oi,
                    cause: Cause::Monitor(m),
                    behaviour: Behaviour::AbortOwner
                }
            ),
            (2, Event::AbortAll { by: APP }),
        ]
    );
}

/// A `Restarting` blocking child below a paused caller (its restart monitor fired while
/// both were paused): a pause of it is `NotRunning`, a resume `NotPaused`, an abort is
/// taken and aborts it from `Restarting` at the next tick.
#[test]
fn requests_of_a_restarting_child_below_a_paused_caller() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(7))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut mons = Mons::new();
    let m = mons
        .add(
            ci,
            Monitor::with_fn("retry", flag1, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.pause(pi).unwrap();
    sim.step(); // 1: both paused
    ctl.set(1, true);
    sim.step(); // 2: the child's monitor restarts it: Restarting, its caller paused
    let hc = sim.handle(ci).unwrap();
    assert_eq!(hc.state(), Restarting, "\n{}", show(sim.trace()));
    assert_eq!(hc.pause(), Err(Error::NotRunning(ci)));
    assert_eq!(hc.resume(), Err(Error::NotPaused(ci)));
    assert_eq!(hc.abort(), Ok(()));
    sim.step(); // 3
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(1, pi, Running, Paused, Cause::Pause),
            tr(1, ci, Running, Paused, Cause::Pause),
            tr(2, ci, Paused, Restarting, mc),
            tr(3, ci, Restarting, Aborting, Cause::Abort),
            tr(3, ci, Aborting, Aborted, Cause::Abort),
        ],
    );
    // The caller, still paused, learns of it when it resumes.
    sim.resume(pi).unwrap();
    sim.step(); // 4
    assert_eq!(
        ctl.log.borrow().last(),
        Some(&(4, "p", "child err")),
        "{:?}",
        ctl.log.borrow()
    );
}

/// A tick earlier than the last one still carries out the requests made since, at the
/// last tick's time (docs/firmware-guide.md section 2 and 5).
#[test]
fn a_tick_before_the_last_still_carries_out_requests_at_the_last_tick_s_time() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.run_for(Duration::from_millis(5));
    sim.pause(ai).unwrap();
    let mut mons = Mons::new();
    let r = seq.tick(Instant::from_ticks(3_000), &ctl, &mut mons);
    assert_eq!(r, Err(Error::TickBeforeLast));
    assert_eq!(seq.sequence_by_id(ai).unwrap().state(), Paused);
    let mut got = Vec::new();
    seq.drain_records(|r| {
        if let Some(t) = r.transition() {
            got.push(t)
        }
    });
    assert_trace(&got, &[tr(5, ai, Running, Paused, Cause::Pause)]);
    drop(sim);
}

// ---------------------------------------------------------------------------------------
// Second batch: restarts, monitors that make requests, hooks that start, safety.
// ---------------------------------------------------------------------------------------

/// An owner paused by request while its exception sequence (behaviour `RestartOwner`)
/// runs: the restart ends the round and its pause ("a restart runs unpaused"); a resume
/// afterwards is `NotPaused`.
#[test]
fn a_restart_applied_to_an_owner_paused_by_request_runs_unpaused() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::RestartOwner);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: fires, e starts
    sim.pause(oi).unwrap();
    sim.step(); // 2: o paused
    ctl.set(1, true);
    sim.step(); // 3: e ends
    sim.step(); // 4: the restart
    let mc = Cause::Monitor(m);
    assert_eq!(sim.state(oi), Running, "\n{}", show(sim.trace()));
    assert_eq!(sim.resume(oi), Err(Error::NotPaused(oi)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, mc),
            tr(2, oi, Running, Paused, Cause::Pause),
            tr(3, ei, Running, Terminated, Cause::Completed),
            tr(4, oi, Paused, Restarting, mc),
            tr(4, oi, Restarting, Running, Cause::Restart),
        ],
    );
}

/// A child paused by its own request, then its caller paused: a resume of the child is
/// taken and does nothing while the caller is paused; the caller's resume resumes both
/// (semantics 7: "a sequence … that is asked to resume, while the caller it blocks is
/// paused resumes with that caller").
#[test]
fn a_child_asked_to_resume_under_a_paused_caller_resumes_with_it() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(0))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.pause(ci).unwrap();
    sim.step(); // 1: c paused
    sim.pause(pi).unwrap();
    sim.step(); // 2: p paused
    sim.resume(ci).unwrap();
    sim.step(); // 3: nothing
    assert_eq!(sim.state(ci), Paused);
    sim.resume(pi).unwrap();
    sim.step(); // 4: both
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(1, ci, Running, Paused, Cause::Pause),
            tr(2, pi, Running, Paused, Cause::Pause),
            tr(4, pi, Paused, Running, Cause::Resume),
            tr(4, ci, Paused, Running, Cause::Resume),
        ],
    );
}

/// An abort request of a blocking child: the child is aborted (`Cause::Abort`); its caller
/// receives `Err(Failure::Aborted(Abort))` and, with `?`, fails with it.
#[test]
fn an_abort_request_of_a_blocking_child_fails_its_caller() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(0))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.step(); // 1
    sim.abort(ci).unwrap();
    sim.step(); // 2
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(2, ci, Running, Aborting, Cause::Abort),
            tr(2, ci, Aborting, Aborted, Cause::Abort),
            tr(2, pi, Running, Terminated, Cause::Failed),
        ],
    );
    assert_eq!(
        sim.handle(pi).unwrap().last_outcome(),
        Some(Outcome::Failed(Failure::Aborted(Cause::Abort)))
    );
    assert_eq!(
        *ctl.log.borrow(),
        [
            (0, "p", "action"),
            (0, "c", "action"),
            (2, "p", "child err")
        ]
    );
}

// A monitor condition (in the tick) that posts abort-all. Ids: 0 = e (exception sequence
// of b's monitor), 1 = a (owner of the abort-all monitor), 2 = b.
fn posts_abort_all(c: &Ctl, _: Instant) -> bool {
    if c.flag(2) {
        c.seq().abort_all();
        c.set(2, false);
    }
    false
}

/// Abort-all posted by a monitor condition during the tick, before another monitor of the
/// same tick fires with an exception sequence: the tick's start of the exception sequence
/// is not refused; it holds (its action does not run) and is aborted with the rest by the
/// next tick.
#[test]
fn an_exception_sequence_started_while_abort_all_waits_holds_and_is_aborted() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let e = seq
        .add(SeqConfig::new("e").in_lane(), Probe::new("e").until(7))
        .unwrap();
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let b = seq
        .add(SeqConfig::new("b"), Probe::new("b").until(7))
        .unwrap();
    let (ei, ai, bi) = (e.id(), a.id(), b.id());
    let mut mons = Mons::new();
    mons.add(
        ai,
        Monitor::with_fn("poster", posts_abort_all, Behaviour::Nothing),
    )
    .unwrap();
    let m = mons
        .add(
            bi,
            Monitor::with_fn("fault", flag0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(a);
    sim.lane(b);
    sim.start(ai).unwrap();
    sim.start(bi).unwrap();
    sim.step(); // 1
    ctl.set(2, true);
    ctl.set(0, true);
    sim.step(); // 2: abort-all posted, then b's monitor fires: e starts, holds
    sim.step(); // 3: abort-all
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(0, bi, Idle, Running, Cause::Start),
            tr(2, ei, Idle, Running, mc),
            tr(3, ei, Running, Aborting, Cause::AbortAll),
            tr(3, ei, Aborting, Aborted, Cause::AbortAll),
            tr(3, ai, Running, Aborting, Cause::AbortAll),
            tr(3, ai, Aborting, Aborted, Cause::AbortAll),
            tr(3, bi, Running, Aborting, Cause::AbortAll),
            tr(3, bi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert!(
        !ctl.log.borrow().iter().any(|l| l.1 == "e"),
        "the exception sequence's action ran while abort-all waited: {:?}",
        ctl.log.borrow()
    );
    assert_eq!(
        sim.handle(bi).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::AbortAll))
    );
}

// A monitor condition that requests its owner's abort and fires (AbortOwner, no exception
// sequence). Ids: 0 = a.
fn aborts_owner_and_fires(c: &Ctl, _: Instant) -> bool {
    if c.flag(0) {
        c.ask("monitor: abort a", c.h(0).abort());
        return true;
    }
    false
}

/// A monitor condition that requests its owner's abort and says "fire": a run whose abort
/// is requested takes no exception (semantics 10), so what the trace shows is one abort.
#[test]
fn a_monitor_condition_that_requests_its_owner_s_abort_and_fires() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut mons = Mons::new();
    let m = mons
        .add(
            ai,
            Monitor::with_fn("m", aborts_owner_and_fires, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step(); // 1
    ctl.set(0, true);
    sim.step(); // 2
    sim.step(); // 3
    assert_eq!(ctl.asked.borrow()[0], (2, "monitor: abort a", Ok(())));
    assert_eq!(
        events(sim.records()),
        [(2, requested(ai, Request::Abort, APP))],
        "a run whose abort is requested takes no exception"
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(3, ai, Running, Aborting, Cause::Abort),
            tr(3, ai, Aborting, Aborted, Cause::Abort),
        ],
    );
    let _ = m;
}

// Ids: 0 = x (hook starts y), 1 = y.
fn hook_starts_y(c: &Ctl) {
    c.ask("hook: start y", c.h(1).start());
    c.ask("hook: start self", c.h(0).start());
}

/// A cleanup hook that starts a main sequence through the application's handle during an
/// abort request's teardown: the main sequence is not below the aborted one and runs on;
/// a start of the hook's own sequence (`Aborting`) is `AlreadyRunning`.
#[test]
fn a_cleanup_hook_s_start_of_a_main_sequence_runs_on() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let x = seq
        .add(
            SeqConfig::new("x").on_abort(hook_starts_y),
            Probe::new("x").until(7),
        )
        .unwrap();
    let y = seq
        .add(SeqConfig::new("y"), Probe::new("y").until(0))
        .unwrap();
    let (xi, yi) = (x.id(), y.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(x);
    sim.lane(y);
    sim.start(xi).unwrap();
    sim.abort(xi).unwrap();
    sim.step(); // 1
    sim.step(); // 2
    ctl.set(0, true);
    sim.step(); // 3: y ends
    assert_eq!(
        *ctl.asked.borrow(),
        [
            (1, "hook: start y", Ok(())),
            (1, "hook: start self", Err(Error::AlreadyRunning(xi))),
        ]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Cause::Start),
            tr(1, xi, Running, Aborting, Cause::Abort),
            tr(1, yi, Idle, Running, Cause::Start),
            tr(1, xi, Aborting, Aborted, Cause::Abort),
            tr(3, yi, Running, Terminated, Cause::Completed),
        ],
    );
    assert_eq!(sim.handle(yi).unwrap().caller(), None);
}

/// Abort-all by the application and by the safety system (through `Sequences`) before one
/// tick: one abort-all, recorded as the safety system's.
#[test]
fn abort_all_by_both_is_recorded_once_as_the_safety_system_s() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    seq.abort_all();
    rtseq::safety::Sequences::abort_all(seq);
    sim.step();
    sim.step();
    assert_eq!(
        events(sim.records()),
        [(
            1,
            Event::AbortAll {
                by: Requester::SafetySystem
            }
        )]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Aborting, Cause::AbortAll),
            tr(1, ai, Aborting, Aborted, Cause::AbortAll),
        ],
    );
}

/// An abort request and an abort-all before one tick: the abort-all comes first; the
/// run ends `Aborted(AbortAll)` and the request finds nothing more to do.
#[test]
fn abort_request_and_abort_all_in_one_tick_end_aborted_by_abort_all() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.abort(ai).unwrap();
    sim.abort_all();
    sim.step();
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Aborting, Cause::AbortAll),
            tr(1, ai, Aborting, Aborted, Cause::AbortAll),
        ],
    );
    assert_eq!(
        sim.handle(ai).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::AbortAll))
    );
}

/// An abort request of run k, then run k ... cannot end: a start of the sequence before
/// the tick is `AlreadyRunning`, and the tick aborts run k.
#[test]
fn a_start_while_an_abort_is_pending_is_already_running() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(0))
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.abort(ai).unwrap();
    assert_eq!(sim.start(ai), Err(Error::AlreadyRunning(ai)));
    sim.step();
    sim.start(ai).unwrap();
    sim.step();
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Aborting, Cause::Abort),
            tr(1, ai, Aborting, Aborted, Cause::Abort),
            tr(1, ai, Aborted, Running, Cause::Start),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Third batch: wakers, actions and exception sequences that are asked.
// ---------------------------------------------------------------------------------------

use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

thread_local! {
    static WAKER_SEQ: Cell<Option<&'static Sq>> = const { Cell::new(None) };
    /// (ms, result of the waker's pause of sequence 1, state of sequence 0 seen then)
    static WAKER_LOG: RefCell<Vec<WakerAsked>> =
        const { RefCell::new(Vec::new()) };
    static INNER: RefCell<Option<Waker>> = const { RefCell::new(None) };
}

/// A lane's waker that calls back into the sequencer (semantics 15: "a waker may call back
/// into the sequencer (read a handle, request an abort)"), then wakes the simulator's.
struct CallingWaker;
impl Wake for CallingWaker {
    fn wake(self: Arc<Self>) {
        if let Some(seq) = WAKER_SEQ.with(|s| s.get()) {
            let r = seq.sequence_by_id(id(1)).unwrap().pause();
            let st = seq.sequence_by_id(id(0)).unwrap().state();
            let ms = seq.now().as_ticks() / 1000;
            WAKER_LOG.with(|l| l.borrow_mut().push((ms, r, st)));
        }
        INNER.with(|w| {
            if let Some(w) = w.borrow().as_ref() {
                w.wake_by_ref()
            }
        });
    }
}

struct Wrap<F>(Pin<Box<F>>);
impl<F: Future> Future for Wrap<F> {
    type Output = F::Output;
    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<F::Output> {
        INNER.with(|w| *w.borrow_mut() = Some(cx.waker().clone()));
        let waker = Waker::from(Arc::new(CallingWaker));
        let mut c = Context::from_waker(&waker);
        self.0.as_mut().poll(&mut c)
    }
}

/// The lane of `x` (id 0) has a waker that requests a pause of `y` (id 1): the tick that
/// aborts `x` wakes its lane, the waker's request is taken and carried out by the
/// following tick.
#[test]
fn a_waker_called_by_the_tick_may_request_a_pause() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let x = seq
        .add(SeqConfig::new("x"), Probe::new("x").until(7))
        .unwrap();
    let y = seq
        .add(SeqConfig::new("y"), Probe::new("y").until(7))
        .unwrap();
    let (xi, yi) = (x.id(), y.id());
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    let c = &ctl;
    sim.task_with_priority(
        async move {
            let mut x = x;
            Wrap(Box::pin(rtseq::lane(seq, c, &mut x))).await
        },
        1,
    );
    sim.lane(y);
    sim.start(xi).unwrap();
    sim.start(yi).unwrap();
    WAKER_SEQ.with(|s| s.set(Some(seq)));
    sim.abort(xi).unwrap();
    sim.step(); // 1: x aborted, its lane woken: the waker pauses y
    sim.step(); // 2: y paused
    WAKER_SEQ.with(|s| s.set(None));
    let log = WAKER_LOG.with(|l| l.borrow().clone());
    assert_eq!(
        log.first().map(|l| (l.0, l.1)),
        Some((1, Ok(()))),
        "{log:?}"
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Cause::Start),
            tr(0, yi, Idle, Running, Cause::Start),
            tr(1, xi, Running, Aborting, Cause::Abort),
            tr(1, xi, Aborting, Aborted, Cause::Abort),
            tr(2, yi, Running, Paused, Cause::Pause),
        ],
    );
}

/// An action that requests its own abort: from then on it begins nothing more. Its
/// non-blocking start is `NotRunning` of itself; its blocking start holds (the child never
/// runs, the action never returns from it); the next tick aborts it.
struct SelfAbort {
    child: Seq<Probe>,
    other: SeqId,
}
impl Sequence<Ctl> for SelfAbort {
    async fn action(&mut self, cx: &Cx<'_, Ctl>) -> Result<(), Failure> {
        let c = cx.control();
        c.note(0, "s", "action");
        c.ask("self abort", cx.sequence_by_id(cx.id()).unwrap().abort());
        c.ask("start other", cx.start(self.other));
        c.ask(
            "handle start other",
            cx.sequence_by_id(self.other).unwrap().start(),
        );
        c.note(0, "s", "before run");
        let r = cx.run(&mut self.child).await;
        c.note(0, "s", if r.is_ok() { "run ok" } else { "run err" });
        Ok(())
    }
}

#[test]
fn an_action_that_requests_its_own_abort_begins_nothing_more() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let child = seq
        .add(SeqConfig::new("child"), Probe::new("child"))
        .unwrap();
    let other = seq
        .add(SeqConfig::new("other"), Probe::new("other").until(7))
        .unwrap();
    let (ci, oi) = (child.id(), other.id());
    let s = seq
        .add(SeqConfig::new("s"), SelfAbort { child, other: oi })
        .unwrap();
    let si = s.id();
    let mut sim = Sim::new(seq, &ctl, Mons::new());
    sim.lane(other);
    sim.lane(s);
    sim.start(si).unwrap();
    sim.step();
    sim.step();
    assert_eq!(
        *ctl.asked.borrow(),
        [
            (0, "self abort", Ok(())),
            (0, "start other", Err(Error::NotRunning(si))),
            (0, "handle start other", Err(Error::NotRunning(si))),
        ]
    );
    assert_eq!(
        *ctl.log.borrow(),
        [(0, "s", "action"), (0, "s", "before run")]
    );
    assert_trace(
        sim.trace(),
        &[
            tr(0, si, Idle, Running, Cause::Start),
            tr(1, si, Running, Aborting, Cause::Abort),
            tr(1, si, Aborting, Aborted, Cause::Abort),
        ],
    );
    let _ = ci;
}

/// An operator's abort of a running exception sequence does not cancel its owner's
/// `AbortOwner` (semantics 3): the exception sequence ends `Aborted(Abort)` in the tick
/// that carries the request out; the next tick applies the behaviour to the owner.
#[test]
fn an_operator_s_abort_of_a_safe_stop_keeps_its_owner_s_behaviour() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::AbortOwner);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: fires, e starts
    sim.abort(ei).unwrap();
    sim.step(); // 2
    sim.step(); // 3
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, mc),
            tr(2, ei, Running, Aborting, Cause::Abort),
            tr(2, ei, Aborting, Aborted, Cause::Abort),
            tr(3, oi, Running, Aborting, mc),
            tr(3, oi, Aborting, Aborted, mc),
        ],
    );
}

/// A pause request of a running exception sequence holds its owner as long: the owner's
/// behaviour (`Nothing`) waits until the exception sequence, resumed, ends.
#[test]
fn a_paused_safe_stop_holds_its_owner_as_long() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let (e, o, mons, m) = owner_with_exception(seq, Behaviour::Nothing);
    let (ei, oi) = (e.id(), o.id());
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(e);
    sim.lane(o);
    sim.start(oi).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: fires, e starts
    sim.pause(ei).unwrap();
    ctl.set(1, true);
    sim.step(); // 2: e paused (its end due here is skipped)
    sim.run_for(Duration::from_millis(3)); // 5
    assert!(sim.handle(oi).unwrap().exception_is_active());
    sim.resume(ei).unwrap();
    sim.step(); // 6: e resumes and ends
    sim.step(); // 7: Nothing applied
    assert!(!sim.handle(oi).unwrap().exception_is_active());
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, oi, Idle, Running, Cause::Start),
            tr(1, ei, Idle, Running, mc),
            tr(2, ei, Running, Paused, Cause::Pause),
            tr(6, ei, Paused, Running, Cause::Resume),
            tr(6, ei, Running, Terminated, Cause::Completed),
        ],
    );
}

/// Abort-all of a `Restarting` blocking child below a paused caller: innermost first, the
/// child from `Restarting`, the caller from `Paused`.
#[test]
fn abort_all_of_a_restarting_child_below_a_paused_caller() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let c = seq
        .add(SeqConfig::new("c"), Probe::new("c").until(7))
        .unwrap();
    let ci = c.id();
    let p = seq
        .add(SeqConfig::new("p"), Probe::new("p").child(c))
        .unwrap();
    let pi = p.id();
    let mut mons = Mons::new();
    let m = mons
        .add(
            ci,
            Monitor::with_fn("retry", flag1, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(p);
    sim.start(pi).unwrap();
    sim.pause(pi).unwrap();
    sim.step(); // 1
    ctl.set(1, true);
    sim.step(); // 2: Restarting
    sim.abort_all();
    sim.step(); // 3
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, pi, Idle, Running, Cause::Start),
            tr(0, ci, Idle, Running, Cause::Start),
            tr(1, pi, Running, Paused, Cause::Pause),
            tr(1, ci, Running, Paused, Cause::Pause),
            tr(2, ci, Paused, Restarting, mc),
            tr(3, ci, Restarting, Aborting, Cause::AbortAll),
            tr(3, ci, Aborting, Aborted, Cause::AbortAll),
            tr(3, pi, Paused, Aborting, Cause::AbortAll),
            tr(3, pi, Aborting, Aborted, Cause::AbortAll),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Fourth batch: a resume refused while a `PauseOwner` monitor holds (`Error::HeldByMonitor`,
// `Handle::resume`, semantics 7: refused, it takes back nothing).
// ---------------------------------------------------------------------------------------

/// A sequence paused by a request, then held by a `PauseOwner` monitor: a resume request
/// is `Err(HeldByMonitor)` and is not kept, so after the release the request's pause keeps
/// it paused until a resume made then (an operator's resume once the interlock cleared).
#[test]
fn a_resume_refused_during_a_hold_leaves_the_request_s_pause_until_a_resume_after_it() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut mons = Mons::new();
    mons.add(ai, Monitor::with_fn("hold", flag0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.pause(ai).unwrap();
    sim.step(); // 1: paused by request
    ctl.set(0, true);
    sim.step(); // 2: the monitor holds too
    assert_eq!(sim.resume(ai), Err(Error::HeldByMonitor(ai)));
    ctl.set(0, false);
    sim.step(); // 3: the condition clears
    sim.step(); // 4
    assert_eq!(sim.state(ai), Paused, "{}", show(sim.trace()));
    sim.resume(ai).unwrap();
    sim.step(); // 5
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Paused, Cause::Pause),
            tr(5, ai, Paused, Running, Cause::Resume),
        ],
    );
}

/// A pause and then a resume before one tick, of a sequence a `PauseOwner` monitor holds:
/// the pause is taken (it outlasts the hold), the resume refused, and it takes the pending
/// pause not back: after the release the sequence stays paused until a resume then.
#[test]
fn a_resume_during_a_hold_takes_a_pending_pause_not_back() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut mons = Mons::new();
    let m = mons
        .add(ai, Monitor::with_fn("hold", flag0, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(a);
    sim.start(ai).unwrap();
    ctl.set(0, true);
    sim.step(); // 1: held by the monitor
    assert_eq!(sim.pause(ai), Ok(()));
    assert_eq!(sim.resume(ai), Err(Error::HeldByMonitor(ai)));
    ctl.set(0, false);
    sim.step(); // 2: release
    sim.step(); // 3
    assert_eq!(sim.state(ai), Paused, "{}", show(sim.trace()));
    sim.resume(ai).unwrap();
    sim.step(); // 4
    let mc = Cause::Monitor(m);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(1, ai, Running, Paused, mc),
            tr(4, ai, Paused, Running, Cause::Resume),
        ],
    );
}

// A monitor condition (in the tick) that requests a pause of its owner (id 0) and does not
// fire.
fn pauses_owner(c: &Ctl, _: Instant) -> bool {
    if c.flag(0) {
        c.set(0, false);
        c.ask("monitor: pause a", c.h(0).pause());
    }
    false
}

/// A pause requested by a monitor condition during the tick is carried out by the
/// following tick (the tick's requests came before its monitors).
#[test]
fn a_pause_requested_by_a_monitor_condition_is_carried_out_by_the_following_tick() {
    let seq = new_seq();
    let ctl = Ctl::default();
    ctl.seq.set(Some(seq));
    let a = seq
        .add(SeqConfig::new("a"), Probe::new("a").until(7))
        .unwrap();
    let ai = a.id();
    let mut mons = Mons::new();
    mons.add(
        ai,
        Monitor::with_fn("asker", pauses_owner, Behaviour::Nothing),
    )
    .unwrap();
    let mut sim = Sim::new(seq, &ctl, mons);
    sim.lane(a);
    sim.start(ai).unwrap();
    sim.step(); // 1
    ctl.set(0, true);
    sim.step(); // 2: asked
    assert_eq!(sim.state(ai), Running);
    sim.step(); // 3: paused
    assert_eq!(*ctl.asked.borrow(), [(2, "monitor: pause a", Ok(()))]);
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Cause::Start),
            tr(3, ai, Running, Paused, Cause::Pause),
        ],
    );
}
