//! Attempts to reach undefined behaviour, or a broken invariant, from the safe public API
//! (a cold review of soundness, session 57): leaked futures, re-entrant wakers under both
//! kinds of lock, panics in user code caught by the application, threads sharing a
//! sequencer of a control system that is not `Sync`, a sequencer moved between ticks,
//! nested polls from a cleanup hook and from a step's action. `./x miri` runs them under
//! Stacked and Tree Borrows (with `-Zmiri-ignore-leaks`: the `leak_` tests forget pinned,
//! boxed futures on purpose).

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::SeqCst};
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use rtseq::lock::SingleThread;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cx, Duration, Error, Failure, Instant, Monitor, Monitors, Seq, SeqConfig, SeqId,
    Sequence, Sequencer, Step,
};

fn at_ms(ms: u64) -> Instant {
    Instant::from_ticks(ms * 1_000)
}

/// A waker that counts its wake-ups.
#[derive(Default)]
struct Count(AtomicUsize);
impl Wake for Count {
    fn wake(self: Arc<Self>) {
        self.0.fetch_add(1, SeqCst);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.fetch_add(1, SeqCst);
    }
}

fn poll_once<F: Future + ?Sized>(f: Pin<&mut F>, w: &Waker) -> Poll<F::Output> {
    f.poll(&mut Context::from_waker(w))
}

/// A step whose exit condition reads a flag of the control system.
struct Until;
impl Step<Flags> for Until {
    fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        cx.control().acted.set(cx.control().acted.get() + 1);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Flags>) -> bool {
        cx.control().done.get()
    }
}

#[derive(Default)]
struct Flags {
    done: Cell<bool>,
    acted: Cell<u32>,
    /// The action of `Parent` writes here what its second blocking start returned.
    second: Cell<Option<Result<rtseq::Done, Failure>>>,
    /// A payload the child's body carries (checked after a leak).
    payload: RefCell<Vec<u32>>,
}

/// A sequence that runs its step child once.
struct Runs(Seq<Until>);
impl Sequence<Flags> for Runs {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// 1. Leaks: a pinned future forgotten (boxed, so its memory stays) while the sequencer
//    still counts its run as under way. The object it borrowed is free again for the
//    borrow checker: it is dropped, moved, bound to a new lane.
// ---------------------------------------------------------------------------------------

/// A lane future mid-run, boxed, polled and forgotten: its `Seq` is then moved into a new
/// lane (and the old one is dropped with it). Nothing in the sequencer may point at the
/// old lane or its object: the tick wakes the forgotten lane's waker (an `Arc`, fine) and
/// the sequence stays `Running` with no one to drive it.
#[test]
fn leak_lane_future_mid_run_then_its_seq_moves_into_a_new_lane() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let until = seq.add(SeqConfig::new("until"), Until).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Runs(until)).unwrap();
    let id = main.id();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let count = Arc::new(Count::default());
    let waker = Waker::from(count.clone());
    {
        let mut lane = Box::pin(rtseq::lane(&seq, &ctrl, &mut main));
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.sequence_by_id(id).unwrap().start().unwrap();
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        assert_eq!(ctrl.acted.get(), 1);
        std::mem::forget(lane);
    }
    // The borrow of `main` ended with the forgotten box: move it.
    let mut moved = main;
    seq.tick(at_ms(1), &ctrl, &mut monitors).unwrap();
    seq.tick(at_ms(2), &ctrl, &mut monitors).unwrap();
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Running);
    // A second lane for the moved object.
    let count2 = Arc::new(Count::default());
    let waker2 = Waker::from(count2.clone());
    {
        let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut moved));
        assert!(poll_once(lane.as_mut(), &waker2).is_pending());
        // The old run is still "under way": a new start is refused.
        assert_eq!(
            seq.sequence_by_id(id).unwrap().start(),
            Err(Error::AlreadyRunning(id))
        );
        // Abort it: the tick tears the run down with nobody driving it.
        seq.sequence_by_id(id).unwrap().abort().unwrap();
        seq.tick(at_ms(3), &ctrl, &mut monitors).unwrap();
        assert!(poll_once(lane.as_mut(), &waker2).is_pending());
        assert_eq!(seq.sequence_by_id(id).unwrap().state(), Aborted);
        // Start again: the new lane runs it.
        ctrl.done.set(true);
        assert_eq!(seq.sequence_by_id(id).unwrap().start(), Ok(()));
        for ms in 4..8 {
            assert!(poll_once(lane.as_mut(), &waker2).is_pending());
            seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
        }
        assert!(poll_once(lane.as_mut(), &waker2).is_pending());
        assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
        assert_eq!(ctrl.acted.get(), 2, "the new lane ran the new run's step");
    }
    let _ = moved;
    // The sequencer outlives everything; tick once more with nothing left.
    seq.tick(at_ms(20), &ctrl, &mut monitors).unwrap();
}

/// A child with a payload, run blocking by `Parent`.
struct Payload(Vec<u32>);
impl Sequence<Flags> for Payload {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        self.0.push(1);
        // Wait until told: the future holds `&mut self` across the await.
        cx.wait_until(|cx| cx.control().done.get()).await;
        self.0.push(2);
        cx.control().payload.borrow_mut().extend_from_slice(&self.0);
        Ok(())
    }
}

/// Starts its child blocking in a boxed future, polls it once, forgets it, then replaces
/// the child's body (dropping the old body, which the forgotten future's action borrowed)
/// and starts the child again.
struct Parent(Seq<Payload>);
impl Sequence<Flags> for Parent {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        {
            let mut run = Box::pin(cx.run(&mut self.0));
            let polled = std::future::poll_fn(|w| Poll::Ready(run.as_mut().poll(w))).await;
            assert!(polled.is_pending());
            std::mem::forget(run);
        }
        // The body the forgotten action future holds `&mut` to: dropped and replaced.
        *self.0.body_mut() = Payload(vec![100; 4]);
        let second = cx.run(&mut self.0).await;
        cx.control().second.set(Some(second));
        Ok(())
    }
}

#[test]
fn leak_blocking_run_future_then_child_body_replaced_and_run_again() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let child = seq.add(SeqConfig::new("child"), Payload(vec![7])).unwrap();
    let c = child.id();
    let mut parent = seq.add(SeqConfig::new("parent"), Parent(child)).unwrap();
    let p = parent.id();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let waker = Waker::from(Arc::new(Count::default()));
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut parent));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(p).unwrap().start().unwrap();
    for ms in 1..6 {
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
    }
    ctrl.done.set(true);
    for ms in 6..10 {
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
    }
    eprintln!(
        "parent {:?} child {:?} second {:?} payload {:?}",
        seq.sequence_by_id(p).unwrap().state(),
        seq.sequence_by_id(c).unwrap().state(),
        ctrl.second.get(),
        ctrl.payload.borrow()
    );
    // The forgotten run's child never ran on: its second start was refused.
    assert_eq!(
        ctrl.second.get(),
        Some(Err(Failure::NotStarted(Error::AlreadyRunning(c))))
    );
    assert!(ctrl.payload.borrow().is_empty());
}

// ---------------------------------------------------------------------------------------
// 2. Re-entrancy: wakers (written with `std::task::Wake`, safe code) whose `wake`,
//    `wake_by_ref` and `Drop` call back into the sequencer — ticks, starts, aborts, trace
//    drains, look-ups — and even poll the lane future itself inside the wake-up (an
//    executor that polls in `wake`). With `SingleThread` (a coarse lock: no lock at all,
//    one section for a whole operation, wake-ups inside it) and with the default lock.
// ---------------------------------------------------------------------------------------

/// Waits for polls until the control's flag says done: its lane parks at every await point.
struct Spin;
impl Step<()> for Spin {
    fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, ()>) -> bool {
        SPIN_DONE.with(Cell::get)
    }
}

struct Twice(Seq<Spin>);
impl Sequence<()> for Twice {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        let _ = cx.start(SeqId::from_index(2)); // "other", if it has a lane
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

struct Blink;
impl Sequence<()> for Blink {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        cx.wait_until(|_| SPIN_DONE.with(Cell::get)).await;
        Ok(())
    }
}

type LaneFuture = Pin<Box<dyn Future<Output = core::convert::Infallible>>>;

thread_local! {
    static SPIN_DONE: Cell<bool> = const { Cell::new(false) };
    static DEPTH: Cell<u32> = const { Cell::new(0) };
    static MEDDLES: Cell<u32> = const { Cell::new(0) };
    /// What a meddling waker reaches: the sequencer (either lock) and the lane futures.
    static REENTRY: RefCell<Option<Box<dyn Fn()>>> = const { RefCell::new(None) };
    static LANES: RefCell<Vec<LaneFuture>> = const { RefCell::new(Vec::new()) };
}

/// A waker that calls back into the sequencer (through `REENTRY`) from `wake`,
/// `wake_by_ref` and `Drop`, a few levels deep at most.
struct Meddler;
impl Meddler {
    fn meddle() {
        let depth = DEPTH.with(|d| d.get());
        if depth >= 3 {
            return;
        }
        DEPTH.with(|d| d.set(depth + 1));
        MEDDLES.with(|m| m.set(m.get() + 1));
        // A `Fn` behind a `RefCell` borrowed shared: nested meddles may run it again.
        REENTRY.with(|r| {
            if let Ok(f) = r.try_borrow() {
                if let Some(f) = f.as_ref() {
                    f();
                }
            }
        });
        DEPTH.with(|d| d.set(depth));
    }
}
impl Wake for Meddler {
    fn wake(self: Arc<Self>) {
        Meddler::meddle();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        Meddler::meddle();
    }
}
impl Drop for Meddler {
    fn drop(&mut self) {
        Meddler::meddle();
    }
}

fn meddler() -> Waker {
    Waker::from(Arc::new(Meddler))
}

/// Polls every lane future in `LANES` that is not being polled further up (an executor
/// that polls inside a wake-up), each with a fresh meddling waker.
fn poll_lanes() {
    LANES.with(|l| {
        if let Ok(mut lanes) = l.try_borrow_mut() {
            for lane in lanes.iter_mut() {
                let _ = poll_once(lane.as_mut(), &meddler());
            }
        }
    });
}

macro_rules! reentrant_wakers_scenario {
    ($name:ident, $seq:expr) => {
        #[test]
        fn $name() {
            SPIN_DONE.with(|d| d.set(false));
            let seq = $seq;
            let spin = seq.add(SeqConfig::new("spin"), Spin).unwrap();
            let main = Box::leak(Box::new(
                seq.add(SeqConfig::new("main"), Twice(spin)).unwrap(),
            ));
            let other = Box::leak(Box::new(seq.add(SeqConfig::new("other"), Blink).unwrap()));
            let (m, o) = (main.id(), other.id());
            assert_eq!(o, SeqId::from_index(2));
            LANES.with(|l| {
                l.borrow_mut().push(Box::pin(rtseq::lane(seq, &(), main)));
                l.borrow_mut().push(Box::pin(rtseq::lane(seq, &(), other)));
            });
            // Every meddle: look-ups, a trace drain, a tick at the current time (refused
            // when inside a tick), an abort/start of `other`, and a poll of the lanes.
            let reentry = move || {
                let _ = seq.sequence_by_name("main").map(|h| h.state());
                let _ = seq.check_lanes();
                let _ = seq.drain_records(|_| {});
                let mut empty: Monitors<(), 1> = Monitors::new();
                let _ = seq.tick(seq.now(), &(), &mut empty);
                if let Some(h) = seq.sequence_by_id(o) {
                    if h.state() == Running {
                        let _ = h.abort();
                    } else {
                        let _ = h.start();
                    }
                    let _ = h.set_timeout(Some(Duration::from_millis(50)));
                }
                poll_lanes();
            };
            REENTRY.with(|r| *r.borrow_mut() = Some(Box::new(reentry)));
            poll_lanes();
            seq.sequence_by_id(m).unwrap().start().unwrap();
            let mut monitors: Monitors<(), 1> = Monitors::new();
            for ms in 1..=12u64 {
                if ms == 6 {
                    SPIN_DONE.with(|d| d.set(true));
                }
                poll_lanes();
                let _ = seq.tick(at_ms(ms), &(), &mut monitors);
            }
            poll_lanes();
            // Dropping the lanes drops their wakers, which meddle once more.
            let lanes = LANES.with(|l| std::mem::take(&mut *l.borrow_mut()));
            drop(lanes);
            REENTRY.with(|r| r.borrow_mut().take());
            assert!(MEDDLES.with(Cell::get) > 10, "the wakers ran");
            eprintln!(
                "main {:?}, other {:?}, meddles {}",
                seq.sequence_by_id(m).unwrap().state(),
                seq.sequence_by_id(o).unwrap().state(),
                MEDDLES.with(Cell::get)
            );
        }
    };
}

reentrant_wakers_scenario!(
    reentrant_wakers_single_thread,
    &*Box::leak(Box::new(
        Sequencer::<(), 4, 64, SingleThread>::single_thread()
    ))
);
reentrant_wakers_scenario!(
    reentrant_wakers_critical_section,
    &*Box::leak(Box::new(Sequencer::<(), 4>::new()))
);

// ---------------------------------------------------------------------------------------
// 3. Panics in user code, caught with `catch_unwind`, then the same sequencer used again.
// ---------------------------------------------------------------------------------------

/// A waker whose first `wake_by_ref` panics; it counts the calls that did not.
#[derive(Default)]
struct PanicsOnce {
    panicked: AtomicBool,
    wakes: AtomicUsize,
}
impl Wake for PanicsOnce {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        if !self.panicked.swap(true, SeqCst) {
            panic!("waker panics once");
        }
        self.wakes.fetch_add(1, SeqCst);
    }
}

/// A waker that panics inside the sequencer's wake-up (caught by the application, out
/// through `Handle::start`): memory-safe (Miri), the start happened, and the lane is
/// usable again from a fresh waker (firmware-guide.md: what a panic in user code leaves).
#[test]
fn a_waker_that_panics_leaves_the_lane_usable_from_a_fresh_waker() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let until = seq.add(SeqConfig::new("until"), Until).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Runs(until)).unwrap();
    let id = main.id();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let w = Arc::new(PanicsOnce::default());
    let waker = Waker::from(w.clone());
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut main));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    let started = catch_unwind(AssertUnwindSafe(|| seq.sequence_by_id(id).unwrap().start()));
    assert!(started.is_err(), "the waker's panic came through start()");
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Running);
    // The executor polls the lane anyway, with the same waker, while ticks come.
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    assert_eq!(ctrl.acted.get(), 1, "the step's action ran");
    for ms in 1..=3 {
        seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
    }
    // A fresh waker (the task's waker changed): registered, and woken by the next tick
    // that has a poll for the lane.
    let fresh = Arc::new(Count::default());
    let fresh_waker = Waker::from(fresh.clone());
    assert!(poll_once(lane.as_mut(), &fresh_waker).is_pending());
    ctrl.done.set(true);
    seq.tick(at_ms(4), &ctrl, &mut monitors).unwrap();
    assert!(fresh.0.load(SeqCst) >= 1, "the fresh waker is woken");
    assert!(poll_once(lane.as_mut(), &fresh_waker).is_pending());
    seq.tick(at_ms(5), &ctrl, &mut monitors).unwrap();
    assert!(poll_once(lane.as_mut(), &fresh_waker).is_pending());
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
}

/// An action that panics at its second poll.
struct Panicky;
impl Sequence<Flags> for Panicky {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        cx.control().acted.set(cx.control().acted.get() + 1);
        cx.wait_until(|cx| cx.control().done.get()).await;
        if cx.control().acted.get() == 1 {
            panic!("action panics");
        }
        Ok(())
    }
}

/// A lane whose action panicked (caught by the executor) is polled again: the stage is
/// still `Action` and the panicked `async fn` future is still in place; an abort drops it
/// without polling it, and the next start makes a new action.
#[test]
fn an_action_that_panicked_is_dropped_by_an_abort_and_the_lane_runs_again() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let mut main = seq.add(SeqConfig::new("main"), Panicky).unwrap();
    let id = main.id();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let waker = Waker::from(Arc::new(Count::default()));
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut main));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(id).unwrap().start().unwrap();
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    ctrl.done.set(true);
    seq.tick(at_ms(1), &ctrl, &mut monitors).unwrap();
    let r = catch_unwind(AssertUnwindSafe(|| poll_once(lane.as_mut(), &waker)));
    assert!(r.is_err(), "the action panicked");
    // Polled again without an abort: the `async fn` panics again ("resumed after panicking").
    let again = catch_unwind(AssertUnwindSafe(|| poll_once(lane.as_mut(), &waker)));
    assert!(
        again.is_err(),
        "polled again, the panicked action panics again"
    );
    seq.sequence_by_id(id).unwrap().abort().unwrap();
    seq.tick(at_ms(2), &ctrl, &mut monitors).unwrap();
    let r = catch_unwind(AssertUnwindSafe(|| poll_once(lane.as_mut(), &waker)));
    assert!(
        r.is_ok(),
        "the abort drops the panicked action without polling it"
    );
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Aborted);
    seq.sequence_by_id(id).unwrap().start().unwrap();
    for ms in 3..6 {
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
    }
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
    assert_eq!(ctrl.acted.get(), 2);
}

fn panicking_hook(c: &Flags) {
    c.acted.set(c.acted.get() + 100);
    if !c.done.get() {
        panic!("cleanup hook panics");
    }
}

/// A cleanup hook that panics inside the tick's teardown (caught by the application):
/// memory-safe (Miri), the tick's turn is given back (the next ticks are not
/// `TickInProgress`), and, as firmware-guide.md says, the torn-down child stays where the
/// panic left it: `Aborting`, its caller `Running`.
#[test]
fn a_cleanup_hook_that_panics_in_the_tick_gives_the_tick_back() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let until = seq
        .add(SeqConfig::new("until").on_abort(panicking_hook), Until)
        .unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Runs(until)).unwrap();
    let (u, id) = (SeqId::from_index(0), main.id());
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let waker = Waker::from(Arc::new(Count::default()));
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut main));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(id).unwrap().start().unwrap();
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(id).unwrap().abort().unwrap();
    let r = catch_unwind(AssertUnwindSafe(|| {
        seq.tick(at_ms(1), &ctrl, &mut monitors)
    }));
    assert!(r.is_err(), "the hook panicked through the tick");
    assert_eq!(ctrl.acted.get(), 101, "the action ran once, the hook once");
    let states = || {
        (
            seq.sequence_by_id(id).unwrap().state(),
            seq.sequence_by_id(u).unwrap().state(),
        )
    };
    ctrl.done.set(true);
    for ms in 2..6 {
        assert_eq!(seq.tick(at_ms(ms), &ctrl, &mut monitors), Ok(()));
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
    }
    assert_eq!(states(), (Running, Aborting));
}

/// A monitor condition that panics in the middle of the tick's evaluation (caught): the
/// next ticks go on, and the monitor fires later.
#[test]
fn a_monitor_condition_that_panics_in_the_tick_leaves_the_sequencer_usable() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let until = seq.add(SeqConfig::new("until"), Until).unwrap();
    let mut main = seq.add(SeqConfig::new("main"), Runs(until)).unwrap();
    let id = main.id();
    // `Monitor::new` wants `dyn Condition + Send`: the count is an atomic.
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let mut cond = |_: &Flags, now: Instant| {
        CALLS.fetch_add(1, SeqCst);
        if now == at_ms(2) {
            panic!("condition panics");
        }
        now >= at_ms(5)
    };
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    monitors
        .add(id, Monitor::new("late", &mut cond, Behaviour::AbortOwner))
        .unwrap();
    let waker = Waker::from(Arc::new(Count::default()));
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut main));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(id).unwrap().start().unwrap();
    for ms in 1..8 {
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        let r = catch_unwind(AssertUnwindSafe(|| {
            seq.tick(at_ms(ms), &ctrl, &mut monitors)
        }));
        assert_eq!(r.is_err(), ms == 2, "tick {ms}: {r:?}");
    }
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Aborted);
    assert!(CALLS.load(SeqCst) >= 5);
}

// ---------------------------------------------------------------------------------------
// 4. Sharing and moving the sequencer.
// ---------------------------------------------------------------------------------------

/// The default-lock sequencer is `Sync` for every `C`, also one that is not (`Cell`): two
/// threads share it, each with its own control system. Thread B runs the lane, thread A
/// ticks and requests; Miri's data-race detector watches the wakers' cells and the state.
#[test]
fn threads_share_a_sequencer_of_a_non_sync_control_system() {
    static DONE: AtomicBool = AtomicBool::new(false);
    static STOP: AtomicBool = AtomicBool::new(false);
    fn hook(c: &Cell<u32>) {
        c.set(c.get() + 1000);
    }
    struct Go;
    impl Step<Cell<u32>> for Go {
        fn action(&mut self, cx: &Cx<'_, Cell<u32>>) -> Result<(), Failure> {
            cx.control().set(cx.control().get() + 1);
            Ok(())
        }
        fn check_exit_condition(&mut self, _: &Cx<'_, Cell<u32>>) -> bool {
            DONE.load(SeqCst)
        }
    }
    struct Loop(Seq<Go>);
    impl Sequence<Cell<u32>> for Loop {
        async fn action(&mut self, cx: &Cx<'_, Cell<u32>>) -> Result<(), Failure> {
            loop {
                cx.step(&mut self.0).await?;
            }
        }
    }
    let seq: Sequencer<Cell<u32>, 4> = Sequencer::new();
    let go = seq.add(SeqConfig::new("go").on_abort(hook), Go).unwrap();
    let mut main = seq
        .add(SeqConfig::new("main").on_abort(hook), Loop(go))
        .unwrap();
    let id = main.id();
    seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
    let seq = &seq;
    std::thread::scope(|s| {
        s.spawn(move || {
            let ctrl_b = Cell::new(0u32);
            let flag = Arc::new(Count::default());
            let waker = Waker::from(flag.clone());
            let mut lane = pin!(rtseq::lane(seq, &ctrl_b, &mut main));
            let mut seen = 0;
            while !STOP.load(SeqCst) {
                let now = flag.0.load(SeqCst);
                if now != seen || seen == 0 {
                    seen = now.max(1);
                    assert!(poll_once(lane.as_mut(), &waker).is_pending());
                }
                std::thread::yield_now();
            }
            // Dropped here, on B: its run, if any, is abandoned with B's control system.
        });
        let ctrl_a = Cell::new(0u32);
        let mut monitors: Monitors<Cell<u32>, 1> = Monitors::new();
        let h = seq.sequence_by_id(id).unwrap();
        for ms in 1..=30u64 {
            match ms {
                3 => {
                    let _ = h.start();
                }
                12 => DONE.store(true, SeqCst),
                20 => {
                    let _ = h.abort();
                }
                _ => {}
            }
            let _ = seq.tick(at_ms(ms), &ctrl_a, &mut monitors);
            std::thread::yield_now();
        }
        STOP.store(true, SeqCst);
        eprintln!("A's hooks ran {} (x1000)", ctrl_a.get() / 1000);
    });
    eprintln!("main {:?}", seq.sequence_by_id(id).unwrap().state());
}

/// A sequencer is `Send` (a_sequencer_moves_to_another_thread_with_every_lock): moved after
/// its first due tick with a monitor table, it keeps that table (it knows the address it
/// bound it from), whose monitor then fires; another table is still refused, empty or not.
#[test]
fn a_sequencer_moved_after_its_first_due_tick_keeps_its_table() {
    let seq: Sequencer<Flags, 4, 64, SingleThread> = Sequencer::single_thread();
    let ctrl = Flags::default();
    let until = seq.add(SeqConfig::new("until"), Until).unwrap();
    let main = seq.add(SeqConfig::new("main"), Runs(until)).unwrap();
    let id = main.id();
    let mut jammed = |c: &Flags, _: Instant| c.done.get();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    monitors
        .add(id, Monitor::new("jam", &mut jammed, Behaviour::AbortOwner))
        .unwrap();
    // Under way (no lane polled: a declared lane is enough for the start), so its polling
    // class is due at every tick.
    seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
    seq.sequence_by_id(id).unwrap().start().unwrap();
    seq.tick(at_ms(1), &ctrl, &mut monitors).unwrap();
    seq.tick(at_ms(2), &ctrl, &mut monitors).unwrap();
    // Moved (to another variable; could be another thread).
    let moved = Box::new(seq);
    assert_eq!(moved.tick(at_ms(3), &ctrl, &mut monitors), Ok(()));
    let mut fresh: Monitors<Flags, 1> = Monitors::new();
    assert_eq!(
        moved.tick(at_ms(4), &ctrl, &mut fresh),
        Err(Error::ForeignMonitorTable)
    );
    let mut jammed_too = |_: &Flags, _: Instant| true;
    fresh
        .add(
            id,
            Monitor::new("jam too", &mut jammed_too, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(
        moved.tick(at_ms(5), &ctrl, &mut fresh),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(moved.sequence_by_id(id).unwrap().state(), Running);
    // Its own table, bound again to the new place: the monitor fires.
    ctrl.done.set(true);
    assert_eq!(moved.tick(at_ms(6), &ctrl, &mut monitors), Ok(()));
    assert_eq!(moved.tick(at_ms(7), &ctrl, &mut monitors), Ok(()));
    assert_eq!(moved.sequence_by_id(id).unwrap().state(), Aborted);
    let _ = main;
}

// ---------------------------------------------------------------------------------------
// 5. Nested polls from user code the library calls: a cleanup hook that polls another
//    lane (as a higher-priority task would preempt) while a lane future is being dropped
//    and its run abandoned; a step's synchronous action that runs a sequence blocking by
//    polling its future by hand (the caller's context lives in a `StepRun`, which is
//    `Unpin` and re-borrowed `&mut` at every poll).
// ---------------------------------------------------------------------------------------

thread_local! {
    static OTHER_LANE: RefCell<Option<LaneFuture>> = const { RefCell::new(None) };
    static HOOKS: Cell<u32> = const { Cell::new(0) };
}

fn hook_polls_other_lane(_: &()) {
    HOOKS.with(|h| h.set(h.get() + 1));
    OTHER_LANE.with(|l| {
        if let Ok(mut l) = l.try_borrow_mut() {
            if let Some(lane) = l.as_mut() {
                let _ = poll_once(lane.as_mut(), &meddler());
            }
        }
    });
}

/// A sequence that runs its child blocking, with a child that spins.
struct Calls(Seq<Spin>);
impl Sequence<()> for Calls {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.start(SeqId::from_index(2));
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

#[test]
fn a_cleanup_hook_polls_another_lane_while_a_lane_is_dropped() {
    SPIN_DONE.with(|d| d.set(false));
    REENTRY.with(|r| *r.borrow_mut() = None);
    let seq: &'static Sequencer<(), 4> = Box::leak(Box::new(Sequencer::new()));
    let spin = seq
        .add(SeqConfig::new("spin").on_abort(hook_polls_other_lane), Spin)
        .unwrap();
    let mut main = seq
        .add(
            SeqConfig::new("main").on_abort(hook_polls_other_lane),
            Calls(spin),
        )
        .unwrap();
    let other = Box::leak(Box::new(seq.add(SeqConfig::new("other"), Blink).unwrap()));
    let (m, o) = (main.id(), other.id());
    OTHER_LANE.with(|l| *l.borrow_mut() = Some(Box::pin(rtseq::lane(seq, &(), other))));
    hook_polls_other_lane(&());
    let waker = Waker::from(Arc::new(Count::default()));
    let mut monitors: Monitors<(), 1> = Monitors::new();
    {
        let mut lane = Box::pin(rtseq::lane(seq, &(), &mut main));
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.sequence_by_id(m).unwrap().start().unwrap();
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.tick(at_ms(1), &(), &mut monitors).unwrap();
        assert_eq!(seq.sequence_by_id(o).unwrap().state(), Running);
        // Dropped mid-run: `spin` then `main` are abandoned, their hooks poll `other`.
        drop(lane);
    }
    assert!(HOOKS.with(Cell::get) >= 3);
    SPIN_DONE.with(|d| d.set(true));
    seq.tick(at_ms(2), &(), &mut monitors).unwrap();
    hook_polls_other_lane(&());
    eprintln!(
        "main {:?} other {:?} hooks {}",
        seq.sequence_by_id(m).unwrap().state(),
        seq.sequence_by_id(o).unwrap().state(),
        HOOKS.with(Cell::get)
    );
    OTHER_LANE.with(|l| l.borrow_mut().take());
}

/// A step whose synchronous action runs a sequence blocking by polling its future by hand
/// (the child's run keeps `&Cx` of the step, which lives in the `Unpin` `StepRun`).
struct HandPolls(Seq<Blink2>);
impl Step<Flags> for HandPolls {
    fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        let mut run = pin!(cx.run(&mut self.0));
        let w = Waker::noop();
        for _ in 0..3 {
            if let Poll::Ready(r) = poll_once(run.as_mut(), w) {
                cx.control().second.set(Some(r));
                break;
            }
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Flags>) -> bool {
        // The child's object is free again: look at it.
        cx.control()
            .acted
            .set(cx.control().acted.get() + self.0.body().0);
        true
    }
}

struct Blink2(u32);
impl Sequence<Flags> for Blink2 {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        self.0 += 1;
        cx.wait_until(|cx| cx.control().done.get()).await;
        self.0 += 10;
        Ok(())
    }
}

struct RunsHandPolls(Seq<HandPolls>);
impl Sequence<Flags> for RunsHandPolls {
    async fn action(&mut self, cx: &Cx<'_, Flags>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        cx.control().done.set(true);
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

#[test]
fn a_step_action_polls_a_blocking_run_by_hand() {
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let ctrl = Flags::default();
    let child = seq.add(SeqConfig::new("child"), Blink2(0)).unwrap();
    let c = child.id();
    let step = seq.add(SeqConfig::new("step"), HandPolls(child)).unwrap();
    let mut main = seq
        .add(SeqConfig::new("main"), RunsHandPolls(step))
        .unwrap();
    let id = main.id();
    let waker = Waker::from(Arc::new(Count::default()));
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let mut lane = pin!(rtseq::lane(&seq, &ctrl, &mut main));
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    seq.sequence_by_id(id).unwrap().start().unwrap();
    for ms in 1..6 {
        assert!(poll_once(lane.as_mut(), &waker).is_pending());
        seq.tick(at_ms(ms), &ctrl, &mut monitors).unwrap();
    }
    assert!(poll_once(lane.as_mut(), &waker).is_pending());
    eprintln!(
        "main {:?} child {:?} second {:?} acted {}",
        seq.sequence_by_id(id).unwrap().state(),
        seq.sequence_by_id(c).unwrap().state(),
        ctrl.second.get(),
        ctrl.acted.get()
    );
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Terminated);
}
