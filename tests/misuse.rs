//! Misuse that safe code can commit, and what rtseq must do about it: wakers that call back
//! into the sequencer, runs whose future is dropped (`select`, timeouts), several joiners of
//! one run, and joins that could never return.
//!
//! The re-entrant waker tests are run under Miri (Stacked and Tree Borrows) by `./x miri`:
//! a sequencer that calls a waker while its state is borrowed is undefined behaviour there.

mod common;
use common::*;

use std::cell::RefCell;
use std::future::Future;
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering::SeqCst};
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use embassy_futures::join::join;
use embassy_futures::select::{select, Either};
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Dropped, Start};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Cx, Done, Duration, Error, Failure, Instant, Monitor, Monitors, Outcome, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Step, Wait,
};

// ---------------------------------------------------------------------------------------
// 1. Wakers are foreign code: rtseq calls them only while its state is not borrowed.
// ---------------------------------------------------------------------------------------

/// A step that is done after its first exit-condition poll.
struct Once;
impl Step<()> for Once {
    fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        Ok(())
    }
}

/// Runs `Once` twice, so that its lane waits for polls and starts.
struct Twice {
    once: Seq<Once>,
}
impl Sequence<()> for Twice {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.once).await;
        let _ = cx.step(&mut self.once).await;
        Ok(())
    }
}

/// A waker written in safe Rust whose `wake`, `wake_by_ref` and `Drop` read and write the
/// sequencer it belongs to.
struct Meddler {
    seq: &'static Sequencer<(), 4>,
    calls: &'static AtomicUsize,
}

impl Meddler {
    fn meddle(&self) {
        self.calls.fetch_add(1, SeqCst);
        // Reads (a state, the name look-up) and a write (a timeout).
        let main = self.seq.sequence_by_name("main").map(|h| h.id());
        if let Some(h) = main.and_then(|id| self.seq.sequence_by_id(id)) {
            let _ = h.state();
            let _ = h.set_timeout(None);
        }
    }
}

impl Wake for Meddler {
    fn wake(self: Arc<Self>) {
        self.meddle();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.meddle();
    }
}

impl Drop for Meddler {
    fn drop(&mut self) {
        self.meddle();
    }
}

#[test]
fn a_waker_that_calls_back_into_the_sequencer_is_never_called_while_its_state_is_borrowed() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let (seq, calls) = (&SEQ, &CALLS);
    let once = seq.add(SeqConfig::new("once"), Once).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Twice { once }).unwrap();
    let id = main.id();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let mut lane = pin!(rtseq::lane(seq, &(), &mut main));
    // A new waker at every poll: the sequencer drops the one it kept (its `Drop` meddles).
    let mut poll = || {
        let waker = Waker::from(Arc::new(Meddler { seq, calls }));
        let r = lane.as_mut().poll(&mut Context::from_waker(&waker));
        assert!(r.is_pending(), "a lane never ends");
    };
    poll();
    seq.sequence_by_id(id).unwrap().start().unwrap(); // wakes the lane
    for ms in 1..=4u64 {
        poll();
        seq.tick(Instant::from_ticks(ms * 1_000), &(), &mut monitors)
            .unwrap(); // wakes due polls
    }
    poll();
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
    assert!(calls.load(SeqCst) >= 4, "the wakers ran: {calls:?}");
}

/// A lane dropped (the loser of a `select`) while its slot keeps a waker that calls back
/// into the sequencer from its `Drop`: closing the lane drops that waker once the state's
/// borrow has ended.
#[test]
fn a_dropped_lane_drops_its_waker_while_the_state_is_not_borrowed() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let (seq, calls) = (&SEQ, &CALLS);
    let once = seq.add(SeqConfig::new("once"), Once).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Twice { once }).unwrap();
    let id = main.id();
    {
        let mut lane = pin!(rtseq::lane(seq, &(), &mut main));
        let waker = Waker::from(Arc::new(Meddler { seq, calls }));
        assert!(lane
            .as_mut()
            .poll(&mut Context::from_waker(&waker))
            .is_pending());
        // The slot's clone is the last one.
        drop(waker);
        assert_eq!(calls.load(SeqCst), 0);
    }
    assert_eq!(calls.load(SeqCst), 1);
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(id)));
}

#[test]
fn a_waker_that_aborts_its_own_sequence_when_woken_takes_effect_at_the_next_tick() {
    struct Aborter(&'static Sequencer<(), 4>);
    impl Wake for Aborter {
        fn wake(self: Arc<Self>) {
            self.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            if let Some(h) = self.0.sequence_by_name("main") {
                let _ = h.abort();
            }
        }
    }
    struct Forever;
    impl Step<()> for Forever {
        fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
            Ok(())
        }
        fn check_exit_condition(&mut self, _cx: &Cx<'_, ()>) -> bool {
            false
        }
    }
    struct Main(Seq<Forever>);
    impl Sequence<()> for Main {
        async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
            let _ = cx.step(&mut self.0).await;
            Ok(())
        }
    }
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    let seq = &SEQ;
    let step = seq.add(SeqConfig::new("forever"), Forever).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Main(step)).unwrap();
    let id = main.id();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let waker = Waker::from(Arc::new(Aborter(seq)));
    let mut lane = pin!(rtseq::lane(seq, &(), &mut main));
    let _ = lane.as_mut().poll(&mut Context::from_waker(&waker));
    seq.sequence_by_id(id).unwrap().start().unwrap(); // wakes: the waker requests the abort
    let _ = lane.as_mut().poll(&mut Context::from_waker(&waker));
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Running);
    seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
        .unwrap();
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Aborted);
    assert_eq!(
        seq.sequence_by_id(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(rtseq::Cause::Abort))
    );
}

/// A waker whose every wake-up changes its own lane's state again (a start, an abort, and
/// a tick that carries the abort out), each of which wakes the lane while the waker is
/// being called: the lane is not polled meanwhile, so the poll its wake-up asked for is
/// still to come, and the wake returns.
#[test]
fn a_waker_whose_wake_up_wakes_its_own_lane_again_is_not_called_for_ever() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    struct Restarts;
    impl Wake for Restarts {
        fn wake(self: Arc<Self>) {
            self.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            if CALLS.fetch_add(1, SeqCst) > 100 {
                return;
            }
            let h = SEQ.sequence_by_name("main").unwrap();
            let _ = h.start();
            let _ = h.abort();
            let mut none: Monitors<(), 1> = Monitors::new();
            let _ = SEQ.tick(SEQ.now(), &(), &mut none);
        }
    }
    let seq = &SEQ;
    let once = seq.add(SeqConfig::new("once"), Once).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Twice { once }).unwrap();
    let id = main.id();
    let mut lane = pin!(rtseq::lane(seq, &(), &mut main));
    let waker = Waker::from(Arc::new(Restarts));
    assert!(lane
        .as_mut()
        .poll(&mut Context::from_waker(&waker))
        .is_pending());
    seq.sequence_by_id(id).unwrap().start().unwrap();
    // The first call may be repeated once: the lane was polled before it.
    assert!(CALLS.load(SeqCst) <= 2, "called {CALLS:?} times");
}

/// An executor of the lane tasks of one thread whose waker polls every ready task inside
/// the wake-up (unless a run further up the stack is under way, which picks it up): the
/// waker calls back into the sequencer while its slot's wake holds it.
mod inline_executor {
    use std::cell::{Cell, RefCell};
    use std::convert::Infallible;
    use std::future::Future;
    use std::pin::Pin;
    use std::sync::Arc;
    use std::task::{Context, Wake, Waker};

    pub type Task = Pin<Box<dyn Future<Output = Infallible>>>;

    thread_local! {
        static TASKS: [RefCell<Option<Task>>; 2] = const { [RefCell::new(None), RefCell::new(None)] };
        static READY: [Cell<bool>; 2] = const { [Cell::new(false), Cell::new(false)] };
        static RUNNING: Cell<bool> = const { Cell::new(false) };
        /// One waker per task, kept: the same identity at every poll.
        static WAKERS: [Waker; 2] = [Waker::from(Arc::new(Inline(0))), Waker::from(Arc::new(Inline(1)))];
    }

    struct Inline(usize);
    impl Wake for Inline {
        fn wake(self: Arc<Self>) {
            self.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            READY.with(|r| r[self.0].set(true));
            run();
        }
    }

    /// Makes `tasks` the executor's tasks, each ready.
    pub fn spawn(tasks: [Task; 2]) {
        for (i, task) in tasks.into_iter().enumerate() {
            TASKS.with(|t| *t[i].borrow_mut() = Some(task));
            READY.with(|r| r[i].set(true));
        }
    }

    /// Drops the tasks.
    pub fn clear() {
        for i in 0..2 {
            let task = TASKS.with(|t| t[i].borrow_mut().take());
            drop(task);
        }
    }

    /// Polls ready tasks until none is.
    pub fn run() {
        if RUNNING.with(|r| r.replace(true)) {
            return;
        }
        while let Some(i) = READY.with(|r| (0..2).find(|&i| r[i].replace(false))) {
            let mut task = TASKS.with(|t| t[i].borrow_mut().take()).expect("a task");
            let waker = WAKERS.with(|w| w[i].clone());
            let _ = task.as_mut().poll(&mut Context::from_waker(&waker));
            TASKS.with(|t| *t[i].borrow_mut() = Some(task));
        }
        RUNNING.with(|r| r.set(false));
    }
}

/// `a` starts `b` and joins it. With an executor that polls inside the wake-up, lane a is
/// polled inside its start's wake-up, and lane b, polled inside the same wake-up, ends `b`
/// and wakes lane a for the join while that wake still holds lane a's waker: the wake-up
/// reaches lane a once the call returns.
#[test]
fn a_wake_up_of_a_lane_whose_waker_is_being_called_is_not_lost() {
    struct StartsAndJoins(SeqId, &'static AtomicBool);
    impl Sequence<()> for StartsAndJoins {
        async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
            cx.start(self.0)?;
            let joined = cx.join(self.0).await;
            assert_eq!(joined, Ok(Outcome::Completed));
            self.1.store(true, SeqCst);
            Ok(())
        }
    }
    struct Quick;
    impl Sequence<()> for Quick {
        async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
            Ok(())
        }
    }
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    static JOINED: AtomicBool = AtomicBool::new(false);
    let seq = &SEQ;
    let mut b = seq.add(SeqConfig::new("b"), Quick).unwrap();
    let b_id = b.id();
    let mut a = seq
        .add(SeqConfig::new("a"), StartsAndJoins(b_id, &JOINED))
        .unwrap();
    let a_id = a.id();
    inline_executor::spawn([
        Box::pin(async move { rtseq::lane(seq, &(), &mut a).await }),
        Box::pin(async move { rtseq::lane(seq, &(), &mut b).await }),
    ]);
    inline_executor::run();
    assert_eq!(seq.check_lanes(), Ok(()));
    // Wakes lane a, which runs inside the wake-up, and lane b inside that.
    seq.sequence_by_id(a_id).unwrap().start().unwrap();
    let state = |id| seq.sequence_by_id(id).unwrap().state();
    assert_eq!(state(b_id), Terminated);
    assert!(JOINED.load(SeqCst), "a's join never returned");
    assert_eq!(state(a_id), Terminated);
    inline_executor::clear();
}

/// A waker whose wake-up drops the lane future it belongs to (an executor that cancels
/// the task when woken): the lane is closed inside the wake, and its slot lets go of the
/// waker once the call returns.
#[test]
fn a_lane_dropped_by_its_own_wake_up_lets_go_of_its_waker() {
    type Lane = Pin<Box<dyn Future<Output = std::convert::Infallible>>>;
    thread_local! {
        static LANE: RefCell<Option<Lane>> = const { RefCell::new(None) };
    }
    struct Cancels;
    impl Wake for Cancels {
        fn wake(self: Arc<Self>) {
            self.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            let lane = LANE.with(|l| l.borrow_mut().take());
            drop(lane);
        }
    }
    struct Quick;
    impl Sequence<()> for Quick {
        async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
            Ok(())
        }
    }
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    let seq = &SEQ;
    let mut main = seq.add(SeqConfig::new("main"), Quick).unwrap();
    let id = main.id();
    let lane: Lane = Box::pin(async move { rtseq::lane(seq, &(), &mut main).await });
    LANE.with(|l| *l.borrow_mut() = Some(lane));
    let cancels = Arc::new(Cancels);
    let waker = Waker::from(cancels.clone());
    LANE.with(|l| {
        let mut lane = l.borrow_mut();
        let lane = lane.as_mut().unwrap().as_mut();
        assert!(lane.poll(&mut Context::from_waker(&waker)).is_pending());
    });
    drop(waker);
    assert_eq!(Arc::strong_count(&cancels), 2, "ours and the slot's");
    // The start wakes the lane, and the wake-up drops it: the start is aborted.
    seq.sequence_by_id(id).unwrap().start().unwrap();
    assert!(LANE.with(|l| l.borrow().is_none()));
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(id)));
    assert_eq!(
        seq.sequence_by_id(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(Dropped))
    );
    assert_eq!(
        Arc::strong_count(&cancels),
        1,
        "the closed lane's slot kept the waker"
    );
}

// ---------------------------------------------------------------------------------------
// 3. A run whose future is dropped ends, aborted with `Cause::Dropped`.
// ---------------------------------------------------------------------------------------

fn hook_slow(c: &Ctrl) {
    c.hooks.borrow_mut().push("slow");
}
fn hook_inner(c: &Ctrl) {
    c.hooks.borrow_mut().push("inner");
}

/// What loses the race: a step, or a sequence.
enum Slow {
    Step(Seq<Leaf>),
    Sequence(Seq<Node>),
}

/// Races `slow` against a 5 ms wait with `embassy_futures::select`.
struct Race {
    slow: Slow,
    quick: Seq<Wait>,
}

impl Sequence<Ctrl> for Race {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let quick = cx.step(&mut self.quick);
        let slow_won = match &mut self.slow {
            Slow::Step(step) => matches!(select(cx.step(step), quick).await, Either::First(_)),
            Slow::Sequence(sequence) => matches!(
                select(Box::pin(cx.run(sequence)), quick).await,
                Either::First(_)
            ),
        };
        assert!(!slow_won);
        Ok(())
    }
}

/// Registers the 5 ms wait and the race of `slow` against it, starts the race and runs it
/// until everything is idle, which must be at 5 ms. Returns the simulation and the ids of
/// the race and the wait.
fn race<'a>(
    seq: &'a Sequencer<Ctrl, 8>,
    ctrl: &'a Ctrl,
    slow: Slow,
) -> (Sim<'a, Ctrl, 8, 64, 1>, SeqId, SeqId) {
    let quick = seq
        .add(SeqConfig::new("quick"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let q = quick.id();
    let main = seq
        .add(SeqConfig::new("main"), Race { slow, quick })
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(seq, ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(ms_at(5))
    );
    (sim, m, q)
}

#[test]
fn a_step_that_loses_a_select_is_aborted_through_its_cleanup_and_can_run_again() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let slow = seq
        .add(SeqConfig::new("slow").on_abort(hook_slow), Leaf::until(0))
        .unwrap();
    let s = slow.id();
    let (mut sim, m, q) = race(&seq, &ctrl, Slow::Step(slow));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(0, q, Idle, Running, Start),
            tr(5, q, Running, Terminated, Completed),
            tr(5, s, Running, Aborting, Dropped),
            tr(5, s, Aborting, Aborted, Dropped),
            tr(5, m, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(*ctrl.hooks.borrow(), ["slow"]);
    let h = sim.handle(s).unwrap();
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Dropped)));
    // Nothing is left running: the main sequence can run the race again.
    sim.take_trace();
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(ms_at(10))
    );
    assert_eq!(sim.trace().len(), 7, "{}", show(sim.trace()));
}

#[test]
fn a_sequence_that_loses_a_select_is_torn_down_innermost_first() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let inner = seq
        .add(SeqConfig::new("inner").on_abort(hook_inner), Leaf::until(0))
        .unwrap();
    let i = inner.id();
    let slow = seq
        .add(
            SeqConfig::new("slow").on_abort(hook_slow),
            Node::of(vec![Op::Step(inner)]),
        )
        .unwrap();
    let s = slow.id();
    let (sim, m, q) = race(&seq, &ctrl, Slow::Sequence(slow));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(0, i, Idle, Running, Start),
            tr(0, q, Idle, Running, Start),
            tr(5, q, Running, Terminated, Completed),
            tr(5, i, Running, Aborting, Dropped),
            tr(5, i, Aborting, Aborted, Dropped),
            tr(5, s, Running, Aborting, Dropped),
            tr(5, s, Aborting, Aborted, Dropped),
            tr(5, m, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(*ctrl.hooks.borrow(), ["inner", "slow"]);
}

/// A hand-written timeout around a run: gives up (and drops the run) after `polls` polls.
struct GiveUp<F> {
    run: Pin<Box<F>>,
    polls: u32,
}

impl<F: Future<Output = Result<Done, Failure>>> Future for GiveUp<F> {
    type Output = Option<Result<Done, Failure>>;
    fn poll(mut self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        if let Poll::Ready(r) = self.run.as_mut().poll(w) {
            return Poll::Ready(Some(r));
        }
        if self.polls == 0 {
            return Poll::Ready(None);
        }
        self.polls -= 1;
        Poll::Pending
    }
}

#[test]
fn a_run_dropped_by_a_hand_written_timeout_ends_and_the_sequencer_goes_idle() {
    struct Main {
        slow: Seq<Leaf>,
    }
    impl Sequence<Ctrl> for Main {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            let r = GiveUp {
                run: Box::pin(cx.step(&mut self.slow)),
                polls: 3,
            }
            .await;
            assert!(r.is_none());
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let slow = seq
        .add(SeqConfig::new("slow").on_abort(hook_slow), Leaf::until(0))
        .unwrap();
    let s = slow.id();
    let main = seq.add(SeqConfig::new("main"), Main { slow }).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    // Polled at 0 (start), 1, 2 (due exit-condition polls): given up at 3.
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(ms_at(3))
    );
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(3, s, Running, Aborting, Dropped),
            tr(3, s, Aborting, Aborted, Dropped),
            tr(3, m, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(*ctrl.hooks.borrow(), ["slow"]);
}

/// A request made of a run that is then dropped is dropped with it: the next run of the
/// same step, started before the next tick, is not paused by it.
#[test]
fn a_request_of_a_dropped_run_does_not_reach_the_next_run() {
    struct Main {
        slow: Seq<Leaf>,
        quick: Seq<Wait>,
    }
    impl Sequence<Ctrl> for Main {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            let s = self.slow.id();
            let quick = cx.step(&mut self.quick);
            // The quick wait wins; before the select drops the slow step's run, the step
            // is asked to pause (the request waits for the next tick).
            let paused_then_won = async {
                let r = quick.await;
                assert_eq!(cx.sequence_by_id(s).unwrap().pause(), Ok(()));
                r
            };
            let first = select(cx.step(&mut self.slow), paused_then_won).await;
            assert!(matches!(first, Either::Second(Ok(Done::Completed))));
            // The next run of the step, in the same poll.
            assert_eq!(cx.step(&mut self.slow).await, Ok(Done::Completed));
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let slow = seq
        .add(SeqConfig::new("slow").on_abort(hook_slow), Leaf::until(0))
        .unwrap();
    let s = slow.id();
    let quick = seq
        .add(SeqConfig::new("quick"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let q = quick.id();
    let main = seq
        .add(SeqConfig::new("main"), Main { slow, quick })
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.run_until(ms_at(4));
    ctrl.set(0, true);
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(ms_at(5))
    );
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Start),
            tr(0, s, Idle, Running, Start),
            tr(0, q, Idle, Running, Start),
            tr(2, q, Running, Terminated, Completed),
            tr(2, s, Running, Aborting, Dropped),
            tr(2, s, Aborting, Aborted, Dropped),
            tr(2, s, Aborted, Running, Start),
            tr(5, s, Running, Terminated, Completed),
            tr(5, m, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(*ctrl.hooks.borrow(), ["slow"]);
}

fn hook_main(c: &Ctrl) {
    c.hooks.borrow_mut().push("main");
}

/// A lane dropped while its run waits (a host executor shutting down: here the simulator,
/// which owns the lanes): the run and the step it waits in end `Aborted` with
/// `Cause::Dropped`, innermost first, through their cleanup hooks, at the sequencer's time.
#[test]
fn a_lane_dropped_mid_run_aborts_its_runs_innermost_first() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let slow = seq
        .add(SeqConfig::new("slow").on_abort(hook_slow), Leaf::until(0))
        .unwrap();
    let s = slow.id();
    let main = seq
        .add(
            SeqConfig::new("main").on_abort(hook_main),
            Node::of(vec![Op::Step(slow)]),
        )
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(3));
    assert_eq!(
        sim.take_trace(),
        [
            tr(0, m, Idle, Running, Start),
            tr(0, s, Idle, Running, Start)
        ]
    );
    drop(sim);
    let mut after = Vec::new();
    assert_eq!(seq.drain_trace(|t| after.push(t)), 0);
    assert_eq!(
        after,
        [
            tr(3, s, Running, Aborting, Dropped),
            tr(3, s, Aborting, Aborted, Dropped),
            tr(3, m, Running, Aborting, Dropped),
            tr(3, m, Aborting, Aborted, Dropped),
        ],
        "{}",
        show(&after)
    );
    assert_eq!(*ctrl.hooks.borrow(), ["slow", "main"]);
    for id in [s, m] {
        let h = seq.sequence_by_id(id).unwrap();
        assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Dropped)));
    }
}

// ---------------------------------------------------------------------------------------
// 4. Every joiner of a run gets its outcome.
// ---------------------------------------------------------------------------------------

/// main starts B and C, B joins C, main joins C (and with `third`, D joins C too).
fn joiners(third: bool) -> (Vec<Returned>, [SeqId; 4], Option<Instant>) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let c = seq
        .add(SeqConfig::new("C"), Node::of(vec![Op::Wait(dwell)]))
        .unwrap();
    let ci = c.id();
    let b = seq
        .add(SeqConfig::new("B"), Node::of(vec![Op::Join(ci)]))
        .unwrap();
    let d = seq
        .add(SeqConfig::new("D"), Node::of(vec![Op::Join(ci)]))
        .unwrap();
    let (bi, di) = (b.id(), d.id());
    let mut ops = vec![Op::Start(bi), Op::Start(ci)];
    if third {
        ops.push(Op::Start(di));
    }
    ops.push(Op::Join(ci));
    let main = seq.add(SeqConfig::new("main"), Node::of(ops)).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(b);
    sim.lane(c);
    sim.lane(d);
    sim.start(m).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(50));
    drop(sim);
    let returned = ctrl.returned.borrow().clone();
    (returned, [m, bi, ci, di], idle)
}

#[test]
fn two_joiners_of_one_run_both_get_its_outcome() {
    let (returned, [m, b, _, _], idle) = joiners(false);
    assert_eq!(idle, Some(ms_at(5)));
    let joins: Vec<_> = returned
        .iter()
        .filter(|r| (r.seq == m && r.line == 2) || (r.seq == b && r.line == 0))
        .map(|r| (r.ms, r.seq, r.result))
        .collect();
    // Lanes are polled in declaration order: main's first.
    assert_eq!(
        joins,
        [(5, m, Ok(Done::Completed)), (5, b, Ok(Done::Completed))]
    );
}

#[test]
fn three_joiners_of_one_run_all_get_its_outcome() {
    let (returned, [m, b, _, d], idle) = joiners(true);
    assert_eq!(idle, Some(ms_at(5)));
    let joins: Vec<_> = returned
        .iter()
        .filter(|r| (r.seq == m && r.line == 3) || ((r.seq == b || r.seq == d) && r.line == 0))
        .map(|r| (r.ms, r.seq, r.result))
        .collect();
    assert_eq!(
        joins,
        // C ends in its lane's poll; the simulator goes on polling woken lanes in
        // declaration order from there (D after C), then from the first again.
        [
            (5, d, Ok(Done::Completed)),
            (5, m, Ok(Done::Completed)),
            (5, b, Ok(Done::Completed)),
        ]
    );
}

/// Records what a join written by hand (not an `Op::Join`) returned, as `line` of `cx`'s
/// sequence.
fn record_join(cx: &Cx<'_, Ctrl>, line: usize, r: Result<Outcome, Error>) {
    cx.control().returned.borrow_mut().push(Returned {
        ms: cx.now().as_ticks() / 1000,
        seq: cx.id(),
        line,
        result: r.map_err(Failure::from).and_then(Outcome::done),
    });
}

/// Two joiners in one lane: main joins C while it runs B blocking, and B joins C too. C's
/// end names main's lane once for each joiner; the lane is woken, and both joins return
/// (then B ends, then main).
#[test]
fn a_caller_and_its_blocking_child_joining_one_run_both_get_its_outcome() {
    struct JoinBesideChild {
        c: SeqId,
        b: Seq<Node>,
    }
    impl Sequence<Ctrl> for JoinBesideChild {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.start(self.c)?;
            let (joined, ran) = join(cx.join(self.c), cx.run(&mut self.b)).await;
            record_join(cx, 1, joined);
            ran.map(|_| ())
        }
    }
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let di = dwell.id();
    let c = seq
        .add(SeqConfig::new("C"), Node::of(vec![Op::Wait(dwell)]))
        .unwrap();
    let ci = c.id();
    let b = seq
        .add(SeqConfig::new("B"), Node::of(vec![Op::Join(ci)]))
        .unwrap();
    let bi = b.id();
    let main = seq
        .add(SeqConfig::new("main"), JoinBesideChild { c: ci, b })
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(c);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(ms_at(5))
    );
    let trace = sim.take_trace();
    drop(sim);
    let joins: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == m || r.seq == bi)
        .map(|r| (r.ms, r.seq, r.line, r.result))
        .collect();
    assert_eq!(
        joins,
        [
            (5, bi, 0, Ok(Done::Completed)),
            (5, m, 1, Ok(Done::Completed))
        ]
    );
    assert_eq!(
        trace,
        [
            tr(0, m, Idle, Running, Start),
            tr(0, ci, Idle, Running, Start),
            tr(0, bi, Idle, Running, Start),
            tr(0, di, Idle, Running, Start),
            tr(5, di, Running, Terminated, Completed),
            tr(5, ci, Running, Terminated, Completed),
            tr(5, bi, Running, Terminated, Completed),
            tr(5, m, Running, Terminated, Completed),
        ],
        "{}",
        show(&trace)
    );
}

/// A joiner's lane is woken by the end of the run it joined, not by other ends: main
/// starts B (ends at 1 ms) and C (ends at 5 ms) and joins C.
#[test]
fn a_joiner_is_woken_by_the_end_of_the_run_it_joined_only() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let short = seq
        .add(SeqConfig::new("short"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let long = seq
        .add(SeqConfig::new("long"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let b = seq
        .add(SeqConfig::new("B"), Node::of(vec![Op::Wait(short)]))
        .unwrap();
    let c = seq
        .add(SeqConfig::new("C"), Node::of(vec![Op::Wait(long)]))
        .unwrap();
    let (bi, ci) = (b.id(), c.id());
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(bi), Op::Start(ci), Op::Join(ci)]),
        )
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(b);
    sim.lane(c);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(ms_at(5))
    );
    // main's lane: parked once, then its start (up to the join), then C's end.
    assert_eq!(sim.lane_polls()[0], 3);
    let joined: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == m && r.line == 2)
        .map(|r| (r.ms, r.result))
        .collect();
    assert_eq!(joined, [(5, Ok(Done::Completed))]);
}

/// What a race of joiners and a new start left: T's transitions, X's and J's join results
/// (time, joiner, result), and the time the simulator went idle.
struct Rejoined {
    t: SeqId,
    x: SeqId,
    j: SeqId,
    runs_of_t: Vec<rtseq::Transition>,
    joins: Vec<(u64, SeqId, Result<Done, Failure>)>,
    idle: Option<Instant>,
    /// T's last outcome, as its handle reports it.
    last_outcome: Option<Outcome>,
}

/// main starts T (made by `make_t` from a 5 ms dwell; its lane of priority `t_priority`),
/// then X and J (priority 1, in that order): X joins T, then starts it again; J only joins
/// T.
fn join_then_start_again<S: Sequence<Ctrl>>(
    make_t: impl FnOnce(Seq<Wait>) -> S,
    t_priority: u8,
) -> Rejoined {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let t = seq.add(SeqConfig::new("T"), make_t(dwell)).unwrap();
    let ti = t.id();
    let x = seq
        .add(
            SeqConfig::new("X"),
            Node::of(vec![Op::Join(ti), Op::Start(ti)]),
        )
        .unwrap();
    let j = seq
        .add(SeqConfig::new("J"), Node::of(vec![Op::Join(ti)]))
        .unwrap();
    let (xi, ji) = (x.id(), j.id());
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(ti), Op::Start(xi), Op::Start(ji)]),
        )
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane_with_priority(t, t_priority);
    sim.lane(x);
    sim.lane(j);
    sim.start(m).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(50));
    let runs_of_t = sim
        .trace()
        .iter()
        .filter(|r| r.sequence == ti)
        .copied()
        .collect();
    let last_outcome = sim.handle(ti).and_then(|h| h.last_outcome());
    drop(sim);
    let joins = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| (r.seq == xi || r.seq == ji) && r.line == 0)
        .map(|r| (r.ms, r.seq, r.result))
        .collect();
    Rejoined {
        t: ti,
        x: xi,
        j: ji,
        runs_of_t,
        joins,
        idle,
        last_outcome,
    }
}

/// A joiner is released by the end of the run it joined; when another lane, polled before
/// it, starts that sequence again, the joiner still gets the joined run's outcome, not the
/// new run's (a supervisor that repeats T would otherwise keep J waiting for ever).
#[test]
fn a_joiner_gets_the_outcome_of_the_run_it_joined_when_a_new_run_starts_first() {
    let r = join_then_start_again(|dwell| Node::of(vec![Op::Wait(dwell)]), 1);
    let (ti, xi, ji) = (r.t, r.x, r.j);
    assert_eq!(r.idle, Some(ms_at(10)));
    assert_eq!(
        r.runs_of_t,
        [
            tr(0, ti, Idle, Running, Start),
            tr(5, ti, Running, Terminated, Completed),
            tr(5, ti, Terminated, Running, Start),
            tr(10, ti, Running, Terminated, Completed),
        ]
    );
    assert_eq!(
        r.joins,
        [(5, xi, Ok(Done::Completed)), (5, ji, Ok(Done::Completed))]
    );
}

/// T's first run dwells; every later run fails at once.
struct DwellThenFail {
    dwell: Seq<Wait>,
    runs: u32,
}
impl Sequence<Ctrl> for DwellThenFail {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        self.runs += 1;
        if self.runs > 1 {
            return Err(Failure::App(7));
        }
        cx.step(&mut self.dwell).await.map(|_| ())
    }
}

/// A control block keeps one outcome. When the joined run ended and a later run ended too
/// before the joiner was polled (here a lane of higher priority runs the later run at
/// once), the joiner is told that the outcome is lost, instead of being given the later
/// run's.
#[test]
fn a_joiner_whose_run_was_followed_by_another_finished_run_is_told_the_outcome_is_lost() {
    let r = join_then_start_again(|dwell| DwellThenFail { dwell, runs: 0 }, 2);
    let (ti, xi, ji) = (r.t, r.x, r.j);
    assert_eq!(r.idle, Some(ms_at(5)));
    assert_eq!(
        r.runs_of_t,
        [
            tr(0, ti, Idle, Running, Start),
            tr(5, ti, Running, Terminated, Completed),
            tr(5, ti, Terminated, Running, Start),
            tr(5, ti, Running, Terminated, rtseq::Cause::Failed),
        ]
    );
    assert_eq!(r.last_outcome, Some(Outcome::Failed(Failure::App(7))));
    assert_eq!(
        r.joins,
        [
            (5, xi, Ok(Done::Completed)),
            (5, ji, Err(Failure::NotStarted(Error::OutcomeLost(ti))))
        ]
    );
}

// ---------------------------------------------------------------------------------------
// 5. A join that could never return is an error.
// ---------------------------------------------------------------------------------------

#[test]
fn joining_oneself_is_an_error_not_a_hang() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let main = seq.add(SeqConfig::new("main"), Node::of(vec![])).unwrap();
    let m = main.id();
    let mut main = main;
    main.body_mut().ops.push(Op::Join(m));
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(0))
    );
    drop(sim);
    assert_eq!(
        ctrl.returned.borrow()[0].result,
        Err(Failure::NotStarted(Error::JoinWouldDeadlock(m)))
    );
}

#[test]
fn joining_ones_blocking_caller_is_an_error_not_a_hang() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    // main runs child blocking; child joins main (and main's caller-less lane never ends
    // while child waits for it).
    let main_id = SeqId::from_index(1);
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![Op::Join(main_id)]))
        .unwrap();
    let c = child.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Run(child)]))
        .unwrap();
    assert_eq!(main.id(), main_id);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(main_id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(0))
    );
    drop(sim);
    assert_eq!(
        join_result(&ctrl, c),
        Some(Err(Failure::NotStarted(Error::JoinWouldDeadlock(main_id))))
    );
}

/// The last result `seq` logged (its join, in the tests that use it).
fn join_result(ctrl: &Ctrl, seq: SeqId) -> Option<Result<Done, Failure>> {
    ctrl.returned
        .borrow()
        .iter()
        .rev()
        .find(|r| r.seq == seq)
        .map(|r| r.result)
}

/// A supervisor starts a worker and joins it; the worker joins the supervisor ("wait until
/// the cycle is over"). The second join closes a cycle of joins: it is an error at once,
/// the worker goes on and ends, and the supervisor's join returns its outcome.
#[test]
fn two_sequences_that_join_each_other_get_an_error_not_a_hang() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let sup = SeqId::from_index(1);
    let worker = seq
        .add(SeqConfig::new("worker"), Node::of(vec![Op::Join(sup)]))
        .unwrap();
    let w = worker.id();
    let supervisor = seq
        .add(
            SeqConfig::new("supervisor"),
            Node::of(vec![Op::Start(w), Op::Join(w)]),
        )
        .unwrap();
    assert_eq!(supervisor.id(), sup);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(supervisor);
    sim.lane(worker);
    sim.start(sup).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(0))
    );
    drop(sim);
    assert_eq!(
        join_result(&ctrl, w),
        Some(Err(Failure::NotStarted(Error::JoinWouldDeadlock(sup))))
    );
    assert_eq!(join_result(&ctrl, sup), Some(Ok(Done::Completed)));
}

/// The cycle through a blocking child: main runs `child` blocking, `child` joins `worker`,
/// and `worker` joins main, which waits for `child`: the worker's join is the error.
#[test]
fn a_cycle_of_joins_through_a_blocking_child_is_an_error_not_a_hang() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (w, m) = (SeqId::from_index(1), SeqId::from_index(3));
    // The worker waits a tick before it joins main, so that the child's join is pending.
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let worker = seq
        .add(
            SeqConfig::new("worker"),
            Node::of(vec![Op::Wait(dwell), Op::Join(m)]),
        )
        .unwrap();
    assert_eq!(worker.id(), w);
    let child = seq
        .add(SeqConfig::new("child"), Node::of(vec![Op::Join(w)]))
        .unwrap();
    let c = child.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(w), Op::Run(child)]),
        )
        .unwrap();
    assert_eq!(main.id(), m);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(worker);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(1))
    );
    drop(sim);
    assert_eq!(
        join_result(&ctrl, w),
        Some(Err(Failure::NotStarted(Error::JoinWouldDeadlock(m))))
    );
    assert_eq!(join_result(&ctrl, c), Some(Ok(Done::Completed)));
}

/// A join that lost a `select` against a timeout no longer waits: a later join the other
/// way is no cycle, and waits for the run as usual.
#[test]
fn a_join_dropped_by_a_select_is_no_longer_a_wait() {
    struct Impatient {
        worker: SeqId,
        dwell: Seq<Wait>,
    }
    impl Sequence<Ctrl> for Impatient {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.start(self.worker)?;
            // Gives up on the worker after 2 ms, then dwells 5 ms more.
            let _ = select(cx.join(self.worker), cx.step(&mut self.dwell)).await;
            let _ = cx.step(&mut self.dwell).await;
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let sup = SeqId::from_index(3);
    let until = seq
        .add(SeqConfig::new("until"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let worker = seq
        .add(
            SeqConfig::new("worker"),
            Node::of(vec![Op::Wait(until), Op::Join(sup)]),
        )
        .unwrap();
    let w = worker.id();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let impatient = seq
        .add(SeqConfig::new("supervisor"), Impatient { worker: w, dwell })
        .unwrap();
    assert_eq!(impatient.id(), sup);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(impatient);
    sim.lane(worker);
    sim.start(sup).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(ms_at(4))
    );
    drop(sim);
    // The worker joined at 3 ms, after the supervisor's join was dropped at 2 ms.
    assert_eq!(join_result(&ctrl, w), Some(Ok(Done::Completed)));
}

/// A waits in two joins at once (a `select` of the joins of X and Y, which Y's end wins at
/// 1 ms), then joins B alone; at 3 ms B joins A. After the `select`, A waits in one join
/// again, so B's join closes a cycle that the check follows: it is an error at once, not a
/// wait until some other run's end (X's, at 20 ms) happens to wake A.
#[test]
fn a_cycle_closed_after_a_select_of_two_joins_is_an_error_at_once() {
    struct SelectThenJoin {
        x: SeqId,
        y: SeqId,
        b: SeqId,
    }
    impl Sequence<Ctrl> for SelectThenJoin {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.start(self.x)?;
            cx.start(self.y)?;
            let _ = select(cx.join(self.x), cx.join(self.y)).await;
            record_join(cx, 0, cx.join(self.b).await);
            Ok(())
        }
    }
    /// Joins `a` once flag 0 is set.
    struct JoinOnFlag {
        a: SeqId,
    }
    impl Sequence<Ctrl> for JoinOnFlag {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            cx.wait_until(|cx| cx.control().flag(0)).await;
            record_join(cx, 0, cx.join(self.a).await);
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = |name, ms| {
        seq.add(SeqConfig::new(name), Wait::new(Duration::from_millis(ms)))
            .unwrap()
    };
    let x = seq
        .add(
            SeqConfig::new("X"),
            Node::of(vec![Op::Wait(dwell("x", 20))]),
        )
        .unwrap();
    let y = seq
        .add(SeqConfig::new("Y"), Node::of(vec![Op::Wait(dwell("y", 1))]))
        .unwrap();
    let a = SeqId::from_index(5);
    let b = seq.add(SeqConfig::new("B"), JoinOnFlag { a }).unwrap();
    let (xi, yi, bi) = (x.id(), y.id(), b.id());
    let sel = SelectThenJoin {
        x: xi,
        y: yi,
        b: bi,
    };
    let sel = seq.add(SeqConfig::new("A"), sel).unwrap();
    assert_eq!(sel.id(), a);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    for s in [x, y] {
        sim.lane(s);
    }
    sim.lane(b);
    sim.lane(sel);
    sim.before_tick(|t, c| c.set(0, t.as_ticks() >= 3_000));
    sim.start(bi).unwrap();
    sim.start(a).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(30)),
        Some(ms_at(20))
    );
    drop(sim);
    let joined = |id| {
        let r = ctrl.returned.borrow();
        r.iter()
            .filter(|r| r.seq == id)
            .map(|r| (r.ms, r.result))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        joined(bi),
        [(3, Err(Failure::NotStarted(Error::JoinWouldDeadlock(a))))]
    );
    assert_eq!(joined(a), [(3, Ok(Done::Completed))]);
}

fn ms_at(ms: u64) -> Instant {
    Instant::from_ticks(ms * 1_000)
}

/// A tick with a time earlier than the last one's is an error and moves nothing: the
/// timeout of a running sequence is not moved, and the next on-time tick works as before.
#[test]
fn a_tick_earlier_than_the_last_is_an_error_and_moves_nothing() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(Duration::from_millis(5)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_until(ms_at(3));
    let mut none = Monitors::<Ctrl, 1>::new();
    assert_eq!(
        seq.tick(ms_at(2), &ctrl, &mut none),
        Err(Error::TickBeforeLast)
    );
    assert_eq!(
        Error::TickBeforeLast.to_string(),
        "a tick's time is earlier than the last tick's"
    );
    assert_eq!(seq.now(), ms_at(3));
    assert_eq!(sim.tick_error(), None);
    sim.run_until(ms_at(10));
    let t = rtseq::Cause::Timeout(id);
    assert_eq!(
        sim.trace(),
        [
            tr(0, id, Idle, Running, Start),
            tr(5, id, Running, Aborting, t),
            tr(5, id, Aborting, Aborted, t),
        ]
    );
}

/// A sequencer has one heartbeat. A tick from inside a tick (here a monitor's condition
/// that ticks the same sequencer with a table of its own, as a second task that ticks it
/// would between two sections) is refused with `Error::TickInProgress` and changes nothing:
/// the sequencer's time stays the outer tick's. The tick under way goes on (the timeout
/// still fires at 5 ms), and the ticks after it work.
#[test]
fn a_tick_inside_a_tick_is_refused_and_changes_nothing() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let id = seq
        .register(SeqConfig::new("main").timeout(Duration::from_millis(5)))
        .unwrap();
    seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
    let inner_table = RefCell::new(Monitors::<Ctrl, 1>::new());
    // (the inner tick's result, the sequencer's time right after it), per evaluation
    let seen: RefCell<Vec<(Result<(), Error>, Instant)>> = RefCell::new(Vec::new());
    let reentrant = |c: &Ctrl, now: Instant| {
        let later = now + Duration::from_millis(1);
        let r = seq.tick(later, c, &mut inner_table.borrow_mut());
        seen.borrow_mut().push((r, seq.now()));
        false
    };
    let mut monitors = Monitors::<Ctrl, 1, _>::new();
    monitors
        .add(
            id,
            rtseq::Monitor::with_condition("ticks", reentrant, rtseq::Behaviour::AbortOwner),
        )
        .unwrap();
    seq.tick(ms_at(0), &ctrl, &mut monitors).unwrap();
    seq.sequence_by_id(id).unwrap().start().unwrap();
    for ms in 1..=5 {
        assert_eq!(seq.tick(ms_at(ms), &ctrl, &mut monitors), Ok(()));
    }
    let expected: Vec<_> = (1..=5)
        .map(|ms| (Err(Error::TickInProgress), ms_at(ms)))
        .collect();
    assert_eq!(*seen.borrow(), expected);
    assert_eq!(
        seq.sequence_by_id(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(rtseq::Cause::Timeout(id)))
    );
    assert_eq!(
        Error::TickInProgress.to_string(),
        "a tick while another tick of the same sequencer is under way"
    );
}

/// A tick whose time went back (a time base that lost a carry) evaluates nothing, but still
/// carries out what was asked since the last tick, at the last tick's time: a pause request
/// and, the next time, the safety system's abort-all.
#[test]
fn a_tick_earlier_than_the_last_still_carries_out_requests_and_abort_all() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![]).until(9))
        .unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_until(ms_at(3));
    let mut none = Monitors::<Ctrl, 1>::new();
    sim.handle(id).unwrap().pause().unwrap();
    assert_eq!(
        seq.tick(ms_at(1), &ctrl, &mut none),
        Err(Error::TickBeforeLast)
    );
    seq.abort_all();
    assert_eq!(
        seq.tick(ms_at(2), &ctrl, &mut none),
        Err(Error::TickBeforeLast)
    );
    assert_eq!(seq.now(), ms_at(3));
    // The simulator drained the trace up to its last step; the rest is still in the ring.
    assert_eq!(sim.trace(), [tr(0, id, Idle, Running, Start)]);
    let mut later = Vec::new();
    assert_eq!(seq.drain_trace(|t| later.push(t)), 0);
    assert_eq!(
        later,
        [
            tr(3, id, Running, Paused, rtseq::Cause::Pause),
            tr(3, id, Paused, Aborting, rtseq::Cause::AbortAll),
            tr(3, id, Aborting, Aborted, rtseq::Cause::AbortAll),
        ]
    );
}

/// A sequence object made by one sequencer and used in another is refused: started blocking
/// it is `Err(NotStarted(ForeignSequence))`, and as a lane it never runs there (a start of
/// its id finds no lane), although its id names a sequence in both.
#[test]
fn a_sequence_object_of_another_sequencer_is_refused() {
    let a: Sequencer<Ctrl, 4> = Sequencer::new();
    let b: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    // In `a`: a step at id 0 and a sequence at id 1.
    let a_step = a.add(SeqConfig::new("step"), Leaf::until(1)).unwrap();
    let a_lane = a.add(SeqConfig::new("other"), Node::of(vec![])).unwrap();
    // In `b`: the same ids, and a main that runs `a`'s step object.
    let b_step = b.add(SeqConfig::new("step"), Leaf::until(1)).unwrap();
    let b_other = b.register(SeqConfig::new("other")).unwrap();
    let main = b
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(a_step)]))
        .unwrap();
    assert_eq!(
        (b_step.id(), b_other, a_lane.id()),
        (
            SeqId::from_index(0),
            SeqId::from_index(1),
            SeqId::from_index(1)
        )
    );
    let mi = main.id();
    let mut sim = Sim::new(&b, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(a_lane);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(2));
    let returned: Vec<_> = ctrl.returned.borrow().iter().map(|r| r.result).collect();
    assert_eq!(
        returned,
        [Err(Failure::NotStarted(Error::ForeignSequence(
            SeqId::from_index(0)
        )))]
    );
    // `b`'s own step never ran; main went on and completed.
    assert_eq!(sim.state(b_step.id()), Idle);
    assert_eq!(sim.state(mi), Terminated);
    assert_eq!(
        Error::ForeignSequence(SeqId::from_index(0)).to_string(),
        "the object of sequence 0 was made by another sequencer"
    );
    // `a`'s sequence object in a lane of `b` declared nothing there.
    assert_eq!(sim.start(b_other), Err(Error::NoLane(b_other)));
}

// ---------------------------------------------------------------------------------------
// 6. The tick preempts the lanes: an action the tick stopped starts nothing afterwards.
// ---------------------------------------------------------------------------------------

static DRIVE_ON: AtomicUsize = AtomicUsize::new(0);
static MOTOR_ON: AtomicUsize = AtomicUsize::new(0);

/// Switches the drive on; never done.
struct DriveOn;
impl Step<()> for DriveOn {
    fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        DRIVE_ON.fetch_add(1, SeqCst);
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, ()>) -> bool {
        false
    }
}

/// Switches the motor on and runs until stopped.
struct MotorOn;
impl Sequence<()> for MotorOn {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        MOTOR_ON.fetch_add(1, SeqCst);
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

type Starts = std::sync::Mutex<Vec<Result<(), Failure>>>;
static STARTS: Starts = Starts::new(Vec::new());

/// Between two await points the tick preempts it (here: the action ticks the sequencer
/// itself, after an abort-all, as the timer interrupt would), then it starts a sequence
/// in its lane and runs a step, and records each result as it gets it.
struct Interrupted {
    seq: &'static Sequencer<(), 4>,
    motor: SeqId,
    drive: Seq<DriveOn>,
}
impl Sequence<()> for Interrupted {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        self.seq.abort_all();
        let preempting = self.seq.tick(ms_at(1), &(), &mut Monitors::<(), 1>::new());
        assert_eq!(preempting, Ok(()));
        let started = cx.start(self.motor).map_err(Failure::from);
        STARTS.lock().unwrap().push(started);
        let stepped = cx.step(&mut self.drive).await.map(|_| ());
        STARTS.lock().unwrap().push(stepped);
        Ok(())
    }
}

#[test]
fn an_action_stopped_by_a_preempting_tick_starts_nothing_afterwards() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    let drive = SEQ.add(SeqConfig::new("drive on"), DriveOn).unwrap();
    let motor = SEQ.add(SeqConfig::new("motor on"), MotorOn).unwrap();
    let (d, m) = (drive.id(), motor.id());
    let main = SEQ
        .add(
            SeqConfig::new("main"),
            Interrupted {
                seq: &SEQ,
                motor: m,
                drive,
            },
        )
        .unwrap();
    let id = main.id();
    let mut sim = Sim::new(&SEQ, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.lane(motor);
    sim.start(id).unwrap();
    // Idle after the lane's first poll (the simulator's clock is still at 0).
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(0))
    );
    // The start in its lane is refused at once; the step is refused too, and the refusal
    // is not handed into the aborted action (sticky abort): no line after the await runs.
    let refused = Err(Failure::NotStarted(Error::NotRunning(id)));
    assert_eq!(*STARTS.lock().unwrap(), [refused]);
    let all = rtseq::Cause::AbortAll;
    assert_eq!(
        sim.trace(),
        [
            tr(0, id, Idle, Running, Start),
            tr(1, id, Running, Aborting, all),
            tr(1, id, Aborting, Aborted, all),
        ]
    );
    assert_eq!((sim.state(m), sim.state(d)), (Idle, Idle));
    assert_eq!((MOTOR_ON.load(SeqCst), DRIVE_ON.load(SeqCst)), (0, 0));
}

/// The speed the drive is commanded to (10 = jogging, 100 = full), which the cleanup hook
/// of [`Restarting`]'s sequence sets to 0.
static SPEED: AtomicUsize = AtomicUsize::new(0);

/// Jogs the drive; the tick preempts it between two await points (as in [`Interrupted`])
/// and carries out an abort-all, whose cleanup hook stops the drive; then it runs a step
/// and commands full speed.
struct Restarting {
    seq: &'static Sequencer<(), 4>,
    drive: Seq<DriveOn>,
}
impl Sequence<()> for Restarting {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        SPEED.store(10, SeqCst);
        self.seq.abort_all();
        assert_eq!(
            self.seq.tick(ms_at(1), &(), &mut Monitors::<(), 1>::new()),
            Ok(())
        );
        assert_eq!(SPEED.load(SeqCst), 0);
        let _ = cx.step(&mut self.drive).await;
        SPEED.store(100, SeqCst);
        Ok(())
    }
}

/// No line of an aborted action runs after a blocking start that its abort refused: the
/// refusal is not handed into the action (sticky abort), so the speed the cleanup hook
/// set stays 0. (Until session 47 the `Err` returned into the action, which commanded
/// full speed after the hook.)
#[test]
fn a_refused_blocking_start_does_not_return_into_an_aborted_action() {
    static SEQ: Sequencer<(), 4> = Sequencer::new();
    let drive = SEQ.add(SeqConfig::new("drive on"), DriveOn).unwrap();
    let d = drive.id();
    let stop = |_: &()| SPEED.store(0, SeqCst);
    let main = Restarting { seq: &SEQ, drive };
    let main = SEQ
        .add(SeqConfig::new("main").on_abort(stop), main)
        .unwrap();
    let id = main.id();
    let mut sim = Sim::new(&SEQ, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(10)),
        Some(ms_at(0))
    );
    assert_eq!(SPEED.load(SeqCst), 0);
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(rtseq::Cause::AbortAll))
    );
    assert_eq!(sim.state(d), Idle);
}

// ---------------------------------------------------------------------------------------
// 7. Joins raced against each other.
// ---------------------------------------------------------------------------------------

/// Joins two sequences at once and records when the first of the two joins returned
/// (`both`: when both returned, with the result of `a`).
struct JoinEither {
    a: SeqId,
    b: SeqId,
    both: bool,
}

impl Sequence<Ctrl> for JoinEither {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let first = if self.both {
            embassy_futures::join::join(cx.join(self.a), cx.join(self.b))
                .await
                .0
        } else {
            match select(cx.join(self.a), cx.join(self.b)).await {
                Either::First(r) | Either::Second(r) => r,
            }
        };
        cx.control().returned.borrow_mut().push(Returned {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line: 0,
            result: first.map_err(Failure::from).and_then(Outcome::done),
        });
        Ok(())
    }
}

/// When J's joins returned (ms), with what.
type Joined = Vec<(u64, Result<Done, Failure>)>;

/// J joins A and B (dwells of `a_ms` and `b_ms`) at once (`both`: waits for both, else
/// for either); returns when J's joins returned (ms) and J's state at 30 ms.
fn join_two(a_ms: u64, b_ms: u64, both: bool) -> (Joined, RunningState) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = |name, ms| {
        seq.add(SeqConfig::new(name), Wait::new(Duration::from_millis(ms)))
            .unwrap()
    };
    let a = seq
        .add(
            SeqConfig::new("A"),
            Node::of(vec![Op::Wait(dwell("a", a_ms))]),
        )
        .unwrap();
    let b = seq
        .add(
            SeqConfig::new("B"),
            Node::of(vec![Op::Wait(dwell("b", b_ms))]),
        )
        .unwrap();
    let (ai, bi) = (a.id(), b.id());
    let j = seq
        .add(SeqConfig::new("J"), JoinEither { a: ai, b: bi, both })
        .unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.lane(b);
    sim.lane(j);
    sim.start(ai).unwrap();
    sim.start(bi).unwrap();
    sim.start(ji).unwrap();
    sim.run_for(Duration::from_millis(30));
    let state = sim.state(ji);
    drop(sim);
    let joined = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == ji)
        .map(|r| (r.ms, r.result))
        .collect();
    (joined, state)
}

/// J waits for both A (20 ms) and B (2 ms), A's join polled first. B's join returns at 2
/// ms while A's still waits: A's end at 20 ms must still wake J.
#[test]
fn a_join_still_pending_when_another_join_returns_is_woken_by_the_end_of_its_run() {
    assert_eq!(
        join_two(20, 2, true),
        (vec![(20, Ok(Done::Completed))], Terminated)
    );
}

/// J races a join of A (a 2 ms dwell) against a join of B (a 20 ms dwell). A's end must
/// wake J's lane: J's first join returns at 2 ms, not when B ends at 20 ms (the second
/// join's registration must not make J miss the end of the run the first one waits for).
#[test]
fn a_join_raced_against_another_join_is_woken_by_the_end_of_its_run() {
    assert_eq!(
        join_two(2, 20, false),
        (vec![(2, Ok(Done::Completed))], Terminated)
    );
}

/// O (a step waiting for flag 1) has an `AbortOwner` monitor on flag 0 whose exception
/// sequence E joins O. O is held until E ends, and E would wait for O's end: the join
/// could never return, so it is `JoinWouldDeadlock`, as a join of a blocking caller is,
/// and E ends, then O is aborted.
#[test]
fn an_exception_sequence_joining_its_owner_is_an_error_not_a_hang() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let wait = seq.add(SeqConfig::new("wait"), Leaf::until(1)).unwrap();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![Op::Step(wait)]))
        .unwrap();
    let oi = o.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Join(oi)]))
        .unwrap();
    let ei = e.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(
            oi,
            rtseq::Monitor::new("fault", &mut fault, rtseq::Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.start(oi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.set(0, true);
    sim.run_for(Duration::from_millis(10));
    let (so, se) = (sim.state(oi), sim.state(ei));
    drop(sim);
    let joined: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == ei)
        .map(|r| r.result)
        .collect();
    assert_eq!(
        joined,
        [Err(Failure::NotStarted(Error::JoinWouldDeadlock(oi)))]
    );
    assert_eq!((so, se), (Aborted, Terminated));
}

/// What E's join got in [`exception_joins_a_held_child`], and what became of the others.
struct HeldChildJoin {
    /// What E's join returned, and when (ms).
    got: Vec<(u64, Result<Done, Failure>)>,
    /// The sequence E joined.
    joined: SeqId,
    /// The states of O, S, the step and E at the end.
    states: [RunningState; 4],
    /// The last outcomes of O and S.
    outcomes: [Option<Outcome>; 2],
    /// O's monitor.
    fault: rtseq::MonitorId,
}

/// O runs S blocking (configured by `s_config`), and S steps `wait` (until flag 1). O has
/// an `AbortOwner` monitor on flag 0 (set at 2 ms) whose exception sequence E joins S, or
/// S's step (`join_step`). O's exception holds its blocking children with it until E
/// ends, and E would wait for one of them: `JoinWouldDeadlock`, as a join of the owner
/// itself is. E ends, then O's tree is aborted. (Before session 47, the cycle check walked
/// up from E to O only, and E waited for good.)
fn exception_joins_a_held_child(join_step: bool, s_config: SeqConfig<Ctrl>) -> HeldChildJoin {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let wait = seq.add(SeqConfig::new("wait"), Leaf::until(1)).unwrap();
    let wi = wait.id();
    let s = seq.add(s_config, Node::of(vec![Op::Step(wait)])).unwrap();
    let si = s.id();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![Op::Run(s)]))
        .unwrap();
    let oi = o.id();
    let joined = if join_step { wi } else { si };
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Join(joined)]))
        .unwrap();
    let ei = e.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(0);
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
    sim.start(oi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.set(0, true);
    sim.run_for(Duration::from_millis(10));
    let states = [oi, si, wi, ei].map(|id| sim.state(id));
    let outcomes = [oi, si].map(|id| sim.handle(id).unwrap().last_outcome());
    drop(sim);
    let got = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == ei)
        .map(|r| (r.ms, r.result))
        .collect();
    HeldChildJoin {
        got,
        joined,
        states,
        outcomes,
        fault: m,
    }
}

#[test]
fn an_exception_sequence_joining_its_owners_blocking_child_is_an_error_not_a_hang() {
    let j = exception_joins_a_held_child(false, SeqConfig::new("S"));
    let deadlock = Err(Failure::NotStarted(Error::JoinWouldDeadlock(j.joined)));
    assert_eq!(j.got, [(3, deadlock)]);
    assert_eq!(j.states, [Aborted, Aborted, Aborted, Terminated]);
}

#[test]
fn an_exception_sequence_joining_its_owners_step_below_a_child_is_an_error_not_a_hang() {
    let j = exception_joins_a_held_child(true, SeqConfig::new("S"));
    let deadlock = Err(Failure::NotStarted(Error::JoinWouldDeadlock(j.joined)));
    assert_eq!(j.got, [(3, deadlock)]);
    assert_eq!(j.states, [Aborted, Aborted, Aborted, Terminated]);
}

/// The same with S under a 5 ms timeout of its own, which could abort it while O's
/// exception holds it: the check follows the waits, not what might abort them, so the
/// join is `JoinWouldDeadlock` at once (3 ms), as a cycle of joins is whatever timeouts
/// its members have; E ends, and O's tree is aborted by O's monitor before S's timeout.
#[test]
fn a_join_of_a_held_child_with_a_timeout_is_still_an_error() {
    let s = SeqConfig::new("S").timeout(Duration::from_millis(5));
    let j = exception_joins_a_held_child(false, s);
    let deadlock = Err(Failure::NotStarted(Error::JoinWouldDeadlock(j.joined)));
    assert_eq!(j.got, [(3, deadlock)]);
    let by_monitor = Some(Outcome::Aborted(rtseq::Cause::Monitor(j.fault)));
    assert_eq!(j.outcomes, [by_monitor, by_monitor]);
}

/// O starts Z non-blocking (Z ends once flag 2 is set) and steps `wait` (until flag 1);
/// O's `AbortOwner` monitor on flag 0 has exception sequence E, which joins Z. Z is not
/// held by O's exception (a non-blocking child runs on, semantics 3), so the join waits
/// for Z's end (flag 2 set at 5 ms, Z's exit condition true at the 6 ms poll), not
/// an error; then E ends and O's tree is aborted.
#[test]
fn an_exception_sequence_joining_its_owners_non_blocking_child_waits_for_its_end() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let z = seq
        .add(SeqConfig::new("Z"), Node::of(vec![]).until(2))
        .unwrap();
    let zi = z.id();
    let wait = seq.add(SeqConfig::new("wait"), Leaf::until(1)).unwrap();
    let o = seq
        .add(
            SeqConfig::new("O"),
            Node::of(vec![Op::Start(zi), Op::Step(wait)]),
        )
        .unwrap();
    let oi = o.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Join(zi)]))
        .unwrap();
    let ei = e.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    monitors
        .add(
            oi,
            Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(z);
    sim.lane(e);
    sim.start(oi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.set(0, true);
    sim.run_for(Duration::from_millis(3));
    ctrl.set(2, true);
    sim.run_for(Duration::from_millis(5));
    let states = [oi, zi, ei].map(|id| sim.state(id));
    drop(sim);
    let got: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == ei)
        .map(|r| (r.ms, r.result))
        .collect();
    assert_eq!(got, [(6, Ok(Done::Completed))]);
    assert_eq!(states, [Aborted, Terminated, Terminated]);
}

/// A lane dropped while it waits for a start (an executor shutting down) with a start of
/// its sequence made but not taken yet: no future will ever drive that run, so it is
/// aborted (`Dropped`), as the pending start of a lane dropped mid-run is.
#[test]
fn a_start_pending_in_a_lane_dropped_while_idle_does_not_stay_running() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq.add(SeqConfig::new("X"), Node::of(vec![])).unwrap();
    let xi = x.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(x); // polled once: waits for a start
    seq.sequence_by_id(xi).unwrap().start().unwrap();
    drop(sim);
    let x = seq.sequence_by_id(xi).unwrap();
    assert_eq!(
        (x.state(), x.last_outcome()),
        (Aborted, Some(Outcome::Aborted(Dropped)))
    );
}

/// A lane future dropped after it waited (the loser of a `select`, a task that stops its
/// lane) closes its lane: a later start would wait for good, so it is `Err(NoLane)` and
/// `check_lanes` names the lane, until a lane future waits in the slot again.
#[test]
fn a_dropped_lane_takes_no_start_until_a_lane_waits_again() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    // Another lane in slot 0, X's in slot 1.
    let mut other = seq
        .add(SeqConfig::new("other").in_lane(), Node::of(vec![]))
        .unwrap();
    let mut x = seq
        .add(SeqConfig::new("X").in_lane(), Node::of(vec![]))
        .unwrap();
    let xi = x.id();
    let mut cx = Context::from_waker(Waker::noop());
    let mut other_lane = pin!(rtseq::lane(&seq, &ctrl, &mut other));
    assert!(other_lane.as_mut().poll(&mut cx).is_pending());
    {
        let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut x));
        assert!(lane.as_mut().poll(&mut cx).is_pending());
        assert_eq!(seq.check_lanes(), Ok(()));
    }
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(xi)));
    let x_handle = seq.sequence_by_id(xi).unwrap();
    assert_eq!(x_handle.start(), Err(Error::NoLane(xi)));
    assert_eq!(x_handle.state(), Idle);
    // A new lane future waits in the slot: the lane is open again and runs the start.
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut x));
    assert!(lane.as_mut().poll(&mut cx).is_pending());
    assert_eq!(seq.check_lanes(), Ok(()));
    assert_eq!(x_handle.start(), Ok(()));
    assert!(lane.as_mut().poll(&mut cx).is_pending());
    assert_eq!(
        (x_handle.state(), x_handle.last_outcome()),
        (Terminated, Some(Outcome::Completed))
    );
}

/// The safe stop's lane lost a `select` against a shutdown signal. When the jam monitor
/// fires, its exception sequence has no lane: the exception counts as not run, with an
/// event saying why, and the behaviour (`AbortOwner`) is applied in the same tick, instead
/// of the owner being held for good by a safe stop that never runs.
#[test]
fn an_exception_in_a_dropped_lane_is_not_run_and_the_behaviour_is_applied_at_once() {
    use rtseq::{Entry, Event};
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    // Main's lane takes slot 0, the safe stop's slot 1.
    let main = seq
        .add(SeqConfig::new("main").in_lane(), Node::of(vec![]).until(0))
        .unwrap();
    let mut stop = seq
        .add(SeqConfig::new("safe stop").in_lane(), Node::of(vec![]))
        .unwrap();
    let (mi, si) = (main.id(), stop.id());
    let mut jam = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("jam", &mut jam, Behaviour::AbortOwner).exception(si),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    let (s, c) = (&seq, &ctrl);
    sim.task_with_priority(
        async move {
            let shutdown = std::future::ready(());
            let _ = select(rtseq::lane(s, c, &mut stop), shutdown).await;
            std::future::pending::<std::convert::Infallible>().await
        },
        1,
    );
    // The first start validates: the safe stop has no lane any more.
    assert_eq!(sim.start(mi), Err(Error::InvalidConfig));
    assert_eq!(
        seq.validate(sim.monitors()),
        Err(rtseq::ConfigError::ExceptionWithoutLane {
            raiser: rtseq::Raiser::Monitor(m, "jam"),
            exception: (si, "safe stop"),
        })
    );
    // Started all the same (on the chip nothing stops it after `init`'s check):
    seq.sequence_by_id(mi).unwrap().start().unwrap();
    sim.run_for(Duration::from_millis(3));
    ctrl.flags[1].set(true);
    sim.run_for(Duration::from_millis(2));
    let cause = rtseq::Cause::Monitor(m);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(4, mi, Running, Aborting, cause),
            tr(4, mi, Aborting, Aborted, cause),
        ]
    );
    let events: Vec<Event> = sim
        .records()
        .iter()
        .filter_map(|r| match r.entry {
            Entry::Event(e) => Some(e),
            Entry::Transition { .. } => None,
        })
        .collect();
    assert_eq!(
        events,
        [
            Event::Fired {
                owner: mi,
                cause,
                behaviour: Behaviour::AbortOwner
            },
            Event::ExceptionNotRun {
                exception: si,
                owner: mi,
                why: Error::NoLane(si)
            },
        ]
    );
    assert_eq!(seq.exceptions_not_run(), 1);
    assert_eq!(sim.state(si), Idle);
}

/// The lane of another sequencer's object (a wiring mistake) dropped while a start of the
/// same id waits for its real lane: the start is not its to give up. The real lane takes
/// it afterwards and the run completes.
#[test]
fn a_dropped_lane_of_another_sequencers_object_leaves_the_pending_start_alone() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let other: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X").in_lane(), Node::of(vec![]))
        .unwrap();
    let foreign = other.add(SeqConfig::new("X"), Node::of(vec![])).unwrap();
    let xi = x.id();
    assert_eq!(foreign.id(), xi);
    seq.sequence_by_id(xi).unwrap().start().unwrap();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(foreign); // polled once: takes nothing, never runs here
    drop(sim);
    assert_eq!(seq.sequence_by_id(xi).unwrap().state(), Running);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(x);
    sim.run_for(Duration::from_millis(2));
    assert_eq!(
        (
            sim.state(xi),
            seq.sequence_by_id(xi).unwrap().last_outcome()
        ),
        (Terminated, Some(Outcome::Completed))
    );
}

// ---------------------------------------------------------------------------------------
// 8. A sequencer is ticked with one monitor table; a table belongs to one sequencer.
// ---------------------------------------------------------------------------------------

/// `main`, registered with a lane and started in `seq`, polled every millisecond.
fn running_main(seq: &Sequencer<(), 2>) -> SeqId {
    let id = seq.register(SeqConfig::new("main")).unwrap();
    let h = seq.sequence_by_id(id).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap();
    id
}

/// A second task ticks the sequencer with a table of its own (a monitor of the same
/// sequence). The sequencer's table is the first that came with a due tick. The other
/// table's tick with nothing due does nothing; with polls due it is refused with
/// `Error::ForeignMonitorTable` and evaluates nothing: neither table's monitor, and the
/// time stays. The polls wait for the sequencer's table, whose monitor fires at 2 ms as
/// it would have without the misuse. A refused tick still carries out the safety
/// system's abort-all.
#[test]
fn a_tick_with_a_second_monitor_table_is_refused_and_evaluates_nothing() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let main = running_main(&seq);
    let (hot, looked) = (AtomicBool::new(false), AtomicU32::new(0));
    let mut is_hot = |_: &(), _: Instant| hot.load(SeqCst);
    let mut counts = |_: &(), _: Instant| {
        looked.fetch_add(1, SeqCst);
        false
    };
    let mut table = Monitors::<(), 1>::new();
    let m = table
        .add(
            main,
            Monitor::new("hot", &mut is_hot, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut second = Monitors::<(), 1>::new();
    second
        .add(
            main,
            Monitor::new("counts", &mut counts, Behaviour::Nothing),
        )
        .unwrap();
    assert_eq!(seq.tick(ms_at(1), &(), &mut table), Ok(()));
    // Nothing due at the time of the last tick: nothing to refuse.
    assert_eq!(seq.tick(ms_at(1), &(), &mut second), Ok(()));
    hot.store(true, SeqCst);
    assert_eq!(
        seq.tick(ms_at(2), &(), &mut second),
        Err(Error::ForeignMonitorTable)
    );
    let state = || seq.sequence_by_id(main).unwrap().state();
    assert_eq!(
        (looked.load(SeqCst), table.fired(m), state()),
        (0, 0, Running)
    );
    assert_eq!(seq.now(), ms_at(1));
    assert_eq!(seq.tick(ms_at(2), &(), &mut table), Ok(()));
    assert_eq!(
        (looked.load(SeqCst), table.fired(m), state()),
        (0, 1, Aborted)
    );
    assert_eq!(
        Error::ForeignMonitorTable.to_string(),
        "a tick with a monitor table other than the sequencer's own (one table per sequencer)"
    );

    // A refused tick carries out the abort-all.
    hot.store(false, SeqCst);
    seq.sequence_by_id(main).unwrap().start().unwrap();
    assert_eq!(seq.tick(ms_at(3), &(), &mut table), Ok(()));
    seq.abort_all();
    assert_eq!(
        seq.tick(ms_at(4), &(), &mut second),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(
        seq.sequence_by_id(main).unwrap().last_outcome(),
        Some(Outcome::Aborted(rtseq::Cause::AbortAll))
    );
    assert_eq!(looked.load(SeqCst), 0);
}

/// Two sequencers, each with its own table. An empty table ticks a sequencer that has
/// none yet (it evaluates nothing, and binds nothing). The first sequencer's table, once
/// its own, is refused by the second sequencer: its owners are the first one's ids. Once
/// a sequencer has its table, an empty one is refused too.
#[test]
fn a_monitor_table_of_another_sequencer_is_refused() {
    let (first, second): (Sequencer<(), 2>, Sequencer<(), 2>) =
        (Sequencer::new(), Sequencer::new());
    let (a, b) = (running_main(&first), running_main(&second));
    assert_eq!(a, b);
    let mut never = |_: &(), _: Instant| false;
    let mut table = Monitors::<(), 1>::new();
    table
        .add(a, Monitor::new("never", &mut never, Behaviour::AbortOwner))
        .unwrap();
    let mut empty = Monitors::<(), 1>::new();
    assert_eq!(second.tick(ms_at(1), &(), &mut empty), Ok(()));
    assert_eq!(first.tick(ms_at(1), &(), &mut table), Ok(()));
    assert_eq!(
        second.tick(ms_at(2), &(), &mut table),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(second.now(), ms_at(1));
    assert_eq!(second.tick(ms_at(2), &(), &mut empty), Ok(()));
    assert_eq!(first.tick(ms_at(2), &(), &mut table), Ok(()));
    // The empty table bound nothing: the second sequencer's own table is its table.
    let mut quiet = |_: &(), _: Instant| false;
    let mut own = Monitors::<(), 1>::new();
    own.add(b, Monitor::new("quiet", &mut quiet, Behaviour::AbortOwner))
        .unwrap();
    assert_eq!(second.tick(ms_at(3), &(), &mut own), Ok(()));
    assert_eq!(
        second.tick(ms_at(4), &(), &mut empty),
        Err(Error::ForeignMonitorTable)
    );
    // Once the sequencer has a table, an empty one is refused too: it would take the
    // polls that the table's monitors miss.
    let mut throwaway = Monitors::<(), 1>::new();
    assert_eq!(
        first.tick(ms_at(3), &(), &mut throwaway),
        Err(Error::ForeignMonitorTable)
    );
}

/// A table made anew in the place of the sequencer's table (its monitors changed while
/// their owners do not run) is the sequencer's table, bound to it again; a simulator,
/// which boxes its table, may be moved.
#[test]
fn a_table_made_anew_in_its_place_stays_the_sequencers() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let main = running_main(&seq);
    let mut never = |_: &(), _: Instant| false;
    let mut always = |_: &(), _: Instant| true;
    let mut table = Monitors::<(), 1>::new();
    table
        .add(
            main,
            Monitor::new("never", &mut never, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.tick(ms_at(1), &(), &mut table), Ok(()));
    seq.sequence_by_id(main).unwrap().abort().unwrap();
    assert_eq!(seq.tick(ms_at(2), &(), &mut table), Ok(()));
    table = Monitors::new();
    let m = table
        .add(
            main,
            Monitor::new("always", &mut always, Behaviour::AbortOwner),
        )
        .unwrap();
    seq.sequence_by_id(main).unwrap().start().unwrap();
    assert_eq!(seq.tick(ms_at(3), &(), &mut table), Ok(()));
    assert_eq!(seq.tick(ms_at(4), &(), &mut table), Ok(()));
    assert_eq!(table.fired(m), 1);
    assert_eq!(
        seq.sequence_by_id(main).unwrap().last_outcome(),
        Some(Outcome::Aborted(rtseq::Cause::Monitor(m)))
    );

    // Made anew, the table was bound again: another sequencer may not take it.
    let other: Sequencer<(), 2> = Sequencer::new();
    running_main(&other);
    assert_eq!(
        other.tick(ms_at(1), &(), &mut table),
        Err(Error::ForeignMonitorTable)
    );

    let sim_seq: Sequencer<(), 2> = Sequencer::new();
    let id = running_main(&sim_seq);
    let mut quiet = |_: &(), _: Instant| false;
    let mut monitors = Monitors::<(), 1>::new();
    monitors
        .add(id, Monitor::new("quiet", &mut quiet, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&sim_seq, &(), monitors);
    sim.run_for(Duration::from_millis(2));
    let mut moved = Box::new(sim);
    moved.run_for(Duration::from_millis(2));
    assert_eq!(moved.tick_error(), None);
    assert_eq!(moved.now(), ms_at(4));
}

/// The sequencer knows its table by its place: moved after a due tick made it the
/// sequencer's, the table is another table, though it still names the sequencer it
/// belongs to. The refused tick evaluates nothing.
#[test]
fn a_monitor_table_moved_after_its_first_due_tick_is_another_table() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let main = running_main(&seq);
    let hot = AtomicBool::new(false);
    let mut is_hot = |_: &(), _: Instant| hot.load(SeqCst);
    let mut table = Monitors::<(), 1>::new();
    let m = table
        .add(
            main,
            Monitor::new("hot", &mut is_hot, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.tick(ms_at(1), &(), &mut table), Ok(()));
    hot.store(true, SeqCst);
    let mut moved = Box::new(table);
    assert_eq!(
        seq.tick(ms_at(2), &(), &mut moved),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(seq.now(), ms_at(1));
    let state = seq.sequence_by_id(main).unwrap().state();
    assert_eq!((moved.fired(m), state), (0, Running));
}
