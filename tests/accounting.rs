//! Accounting: every call rtseq makes into user code (conditions, actions, cleanup hooks,
//! monitor conditions, the safety system's actions and I/O), every operation on a lane's
//! waker (clones, wake calls, drops, the `Arc` count left at the end) and every record,
//! counted on exact simulated times.
//!
//! A lane (or a task of lanes) is wrapped in `Counted`, which polls it with a waker of its
//! own over an `Arc<Counts>` and passes each wake-up on to the executor's waker. The waker
//! is a raw vtable, not `std::task::Wake`, so that its clones and drops are counted too.

use std::cell::{Cell, RefCell};
use std::convert::Infallible;
use std::future::Future;
use std::pin::{pin, Pin};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::SeqCst};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, RawWaker, RawWakerVTable, Waker};

use embassy_futures::select::select;
use rtseq::lock::{Lock, SingleThread};
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Dropped, Start};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Counters, Cx, Duration, Entry, Event, Failure, Instant, Monitor, MonitorId,
    Monitors, Record, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step, Transition,
};

// ---------------------------------------------------------------------------------------
// The control system: a log of every call into user code, with its time.
// ---------------------------------------------------------------------------------------

#[derive(Default)]
struct Ctrl {
    /// The time (µs) of the tick under way, set before each tick: cleanup hooks have no
    /// clock.
    now: Cell<u64>,
    flags: [Cell<bool>; 8],
    /// Every call into user code: (µs, what).
    log: RefCell<Vec<(u64, &'static str)>>,
}

impl Ctrl {
    fn note(&self, us: u64, what: &'static str) {
        self.log.borrow_mut().push((us, what));
    }
    fn flag(&self, i: usize) -> bool {
        self.flags[i].get()
    }
    fn set(&self, i: usize, v: bool) {
        self.flags[i].set(v)
    }
    /// The times (ms) at which `what` was called, in order.
    fn times(&self, what: &str) -> Vec<u64> {
        let log = self.log.borrow();
        let of_what = log.iter().filter(|(_, w)| *w == what);
        of_what.map(|(us, _)| us / 1000).collect()
    }
    /// The calls, one line per millisecond: "30: mon.outer mon.step step.hook".
    fn calls_per_ms(&self) -> Vec<String> {
        let mut lines: Vec<(u64, String)> = Vec::new();
        for &(us, what) in self.log.borrow().iter() {
            match lines.last_mut() {
                Some((ms, line)) if *ms == us / 1000 => *line = format!("{line} {what}"),
                _ => lines.push((us / 1000, format!("{}: {what}", us / 1000))),
            }
        }
        lines.into_iter().map(|(_, line)| line).collect()
    }
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A step whose exit condition is flag `exit`; its calls are logged under `names`
/// (pre-condition, action, exit condition). Its pre-condition holds.
struct Probe {
    exit: usize,
    names: [&'static str; 3],
}
impl Step<Ctrl> for Probe {
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().note(cx.now().as_ticks(), self.names[0]);
        true
    }
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx.now().as_ticks(), self.names[1]);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().note(cx.now().as_ticks(), self.names[2]);
        cx.control().flag(self.exit)
    }
}

const STEP: [&str; 3] = ["step.pre", "step.act", "step.exit"];

/// A sequence that runs its step blocking; its calls are logged as "outer.*".
struct Outer {
    step: Seq<Probe>,
}
impl Sequence<Ctrl> for Outer {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx.now().as_ticks(), "outer.act");
        cx.step(&mut self.step).await?;
        Ok(())
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().note(cx.now().as_ticks(), "outer.pre");
        true
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().note(cx.now().as_ticks(), "outer.exit");
        true
    }
}

/// An `Outer` named `names[0]` over a `Probe` named `names[1]` whose calls are logged under
/// `step`, both polled every `period` ms; the step ends when flag 0 is set.
fn ticker<L: Lock>(
    seq: &Sequencer<Ctrl, 8, 64, L>,
    names: [&'static str; 2],
    period: u64,
    step: [&'static str; 3],
) -> Seq<Outer> {
    let probe = Probe {
        exit: 0,
        names: step,
    };
    let step = seq.add(SeqConfig::new(names[1]).polling(ms(period)), probe);
    let outer = Outer {
        step: step.unwrap(),
    };
    seq.add(SeqConfig::new(names[0]).polling(ms(period)), outer)
        .unwrap()
}

/// An exception sequence that only logs its action.
struct Nop;
impl Sequence<Ctrl> for Nop {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().note(cx.now().as_ticks(), "exc.act");
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// A counting waker over an `Arc<Counts>`, and a lane polled with it.
// ---------------------------------------------------------------------------------------

#[derive(Default)]
struct Counts {
    clones: AtomicUsize,
    wakes: AtomicUsize,
    wake_by_refs: AtomicUsize,
    drops: AtomicUsize,
    /// Polls of the lane by `Counted`.
    polls: AtomicUsize,
    /// Set by a wake-up, cleared by a poll.
    woken: AtomicBool,
    /// The executor's waker, woken with this one.
    executor: Mutex<Option<Waker>>,
}

impl Counts {
    fn wake_calls(&self) -> usize {
        self.wakes.load(SeqCst) + self.wake_by_refs.load(SeqCst)
    }
    fn wake_calls_and_polls(&self) -> [usize; 2] {
        [self.wake_calls(), self.polls.load(SeqCst)]
    }
    fn signal(&self) {
        self.woken.store(true, SeqCst);
        if let Some(w) = self.executor.lock().unwrap().as_ref() {
            w.wake_by_ref();
        }
    }
    /// `[clones, wakes, wake_by_refs, drops]`.
    fn ops(&self) -> [usize; 4] {
        [&self.clones, &self.wakes, &self.wake_by_refs, &self.drops].map(|n| n.load(SeqCst))
    }
    /// Every waker made from these counts (one by `counting_waker`, and its clones) was
    /// consumed exactly once, by `wake` or by a drop.
    fn assert_balanced(&self) {
        let [clones, wakes, _, drops] = self.ops();
        assert_eq!(1 + clones, wakes + drops, "{:?}", self.ops());
    }
}

// Each `RawWaker` of `VTABLE` owns one strong count of an `Arc<Counts>`, whose
// `Arc::into_raw` pointer is its data: `counting_waker` makes the first from a clone of the
// `Arc`, a clone makes a new count, `wake` and `drop` give theirs back. `Counts` holds only
// atomics and a `Mutex`, so it is `Send + Sync`, as a waker must be.
static VTABLE: RawWakerVTable = RawWakerVTable::new(
    clone_counting,
    wake_counting,
    wake_counting_by_ref,
    drop_counting,
);

// SAFETY: called only through `VTABLE`, whose wakers own a strong count of the
// `Arc<Counts>` that `p` points to (see `VTABLE`).
unsafe fn clone_counting(p: *const ()) -> RawWaker {
    // SAFETY: `p` is the `Arc<Counts>` pointer of a live waker, which owns a strong count
    // (`VTABLE`), so the `Counts` is alive; the clone gets a strong count of its own.
    unsafe {
        (*p.cast::<Counts>()).clones.fetch_add(1, SeqCst);
        Arc::increment_strong_count(p.cast::<Counts>());
    }
    RawWaker::new(p, &VTABLE)
}

// SAFETY: called only through `VTABLE`, whose wakers own a strong count of the
// `Arc<Counts>` that `p` points to (see `VTABLE`).
unsafe fn wake_counting(p: *const ()) {
    // SAFETY: `wake` consumes the waker: this `Arc` takes over the strong count it owned
    // (`VTABLE`) and gives it back when it goes.
    let counts = unsafe { Arc::from_raw(p.cast::<Counts>()) };
    counts.wakes.fetch_add(1, SeqCst);
    counts.signal();
}

// SAFETY: called only through `VTABLE`, whose wakers own a strong count of the
// `Arc<Counts>` that `p` points to (see `VTABLE`).
unsafe fn wake_counting_by_ref(p: *const ()) {
    // SAFETY: the borrowed waker owns a strong count (`VTABLE`) for the whole call, so the
    // `Counts` is alive; only a shared reference is made, no count taken or given back.
    let counts = unsafe { &*p.cast::<Counts>() };
    counts.wake_by_refs.fetch_add(1, SeqCst);
    counts.signal();
}

// SAFETY: called only through `VTABLE`, whose wakers own a strong count of the
// `Arc<Counts>` that `p` points to (see `VTABLE`).
unsafe fn drop_counting(p: *const ()) {
    // SAFETY: a dropped waker gives back the strong count it owned (`VTABLE`): this `Arc`
    // takes it over and drops it.
    let counts = unsafe { Arc::from_raw(p.cast::<Counts>()) };
    counts.drops.fetch_add(1, SeqCst);
}

/// A new counting waker (not counted as a clone); it owns one strong count of `counts`.
fn counting_waker(counts: &Arc<Counts>) -> Waker {
    let p = Arc::into_raw(counts.clone()).cast::<()>();
    // SAFETY: `p` owns the strong count just made, as `VTABLE`'s functions expect, and
    // they keep the `RawWaker` contract (see `VTABLE`).
    unsafe { Waker::from_raw(RawWaker::new(p, &VTABLE)) }
}

/// A lane (or a task of lanes) polled with a counting waker of its own; a wake-up of that
/// waker wakes the executor's.
struct Counted<'a> {
    lane: Pin<Box<dyn Future<Output = Infallible> + 'a>>,
    counts: Arc<Counts>,
    waker: Waker,
}

impl<'a> Counted<'a> {
    fn new(lane: impl Future<Output = Infallible> + 'a, counts: &Arc<Counts>) -> Self {
        counts.woken.store(true, SeqCst); // due for its first poll
        Counted {
            lane: Box::pin(lane),
            counts: counts.clone(),
            waker: counting_waker(counts),
        }
    }
}

impl Future for Counted<'_> {
    type Output = Infallible;
    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Infallible> {
        let this = self.get_mut();
        *this.counts.executor.lock().unwrap() = Some(cx.waker().clone());
        this.counts.woken.store(false, SeqCst);
        this.counts.polls.fetch_add(1, SeqCst);
        this.lane
            .as_mut()
            .poll(&mut Context::from_waker(&this.waker))
    }
}

impl Drop for Counted<'_> {
    fn drop(&mut self) {
        // The executor's waker goes with the lane: the `Arc` keeps only wakers of its own.
        self.counts.executor.lock().unwrap().take();
    }
}

/// Polls each lane of `lanes` that was woken, with a waker that does nothing (the lanes'
/// own counting wakers are the ones rtseq keeps).
fn poll_woken(lanes: &mut [Counted<'_>]) {
    for lane in lanes {
        if lane.counts.woken.load(SeqCst) {
            let _ = Pin::new(lane).poll(&mut Context::from_waker(Waker::noop()));
        }
    }
}

/// The wake calls and polls of counted lanes, noted after each tick (or request) that
/// changed them: "30: 2/1 0/0" is two wake calls and one poll of the first lane at 30 (ms,
/// unless a test says µs), nothing of the second.
struct Tally<'a> {
    lanes: Vec<&'a Counts>,
    last: Vec<[usize; 2]>,
    changes: Vec<String>,
}

impl<'a> Tally<'a> {
    fn new(lanes: &[&'a Counts]) -> Self {
        let last = lanes.iter().map(|c| c.wake_calls_and_polls()).collect();
        let lanes = lanes.to_vec();
        let changes = Vec::new();
        Tally {
            lanes,
            last,
            changes,
        }
    }
    fn note(&mut self, at: u64) {
        let now: Vec<_> = self
            .lanes
            .iter()
            .map(|c| c.wake_calls_and_polls())
            .collect();
        if now != self.last {
            let lanes: Vec<String> = (now.iter().zip(&self.last))
                .map(|(n, l)| format!("{}/{}", n[0] - l[0], n[1] - l[1]))
                .collect();
            self.changes.push(format!("{at}: {}", lanes.join(" ")));
        }
        self.last = now;
    }
    fn text(&self) -> String {
        self.changes.join(", ")
    }
}

/// The trace as `(ms, sequence index, from, to, cause)`.
type Move = (u64, usize, RunningState, RunningState, Cause);
fn moves(trace: &[Transition]) -> Vec<Move> {
    let ms = |t: &Transition| t.time.as_ticks() / 1000;
    let each = |t: &Transition| (ms(t), t.sequence.index(), t.from, t.to, t.cause);
    trace.iter().map(each).collect()
}

// ---------------------------------------------------------------------------------------
// One tree under every behaviour: calls, wake-ups and records.
// ---------------------------------------------------------------------------------------

fn hook_outer(c: &Ctrl) {
    c.note(c.now.get(), "outer.hook");
}
fn hook_step(c: &Ctrl) {
    c.note(c.now.get(), "step.hook");
}
fn mon_outer(c: &Ctrl, t: Instant) -> bool {
    c.note(t.as_ticks(), "mon.outer");
    c.flag(1)
}
fn mon_step(c: &Ctrl, t: Instant) -> bool {
    c.note(t.as_ticks(), "mon.step");
    c.flag(2)
}

/// A request the application makes of `outer` after a tick.
#[derive(Clone, Copy)]
enum Request {
    Pause,
    Resume,
    Abort,
    Start,
    AbortAll,
}

/// `outer` (id 1) runs `step` (id 0) blocking, both polled every 10 ms, with cleanup hooks;
/// the step's exit condition holds from 70 ms. Monitor 0, on `outer`, has `behaviour` (and,
/// with `exception`, the exception sequence `exc`, id 2, in a lane of its own), its
/// condition true in `alarm` (ms, `[from, to)`); monitor 1, on `step`, does `Nothing` and
/// its condition is true in `step_alarms`. With `timeout`, `outer` times out with
/// `behaviour`. `requests` are made after the tick of their time (ms).
#[derive(Clone, Copy)]
struct Case {
    behaviour: Behaviour,
    exception: bool,
    timeout: Option<u64>,
    alarm: (u64, u64),
    step_alarms: &'static [(u64, u64)],
    requests: &'static [(u64, Request)],
}

/// `behaviour` on a monitor whose condition holds from 25 to 45 ms.
fn case(behaviour: Behaviour) -> Case {
    let (exception, timeout, alarm) = (false, None, (25, 45));
    let (step_alarms, requests) = (&[][..], &[][..]);
    Case {
        behaviour,
        exception,
        timeout,
        alarm,
        step_alarms,
        requests,
    }
}

impl Case {
    fn exception(mut self) -> Self {
        self.exception = true;
        self
    }
    /// A 25 ms timeout with the case's behaviour; the monitor never fires.
    fn timeout(mut self) -> Self {
        (self.timeout, self.alarm) = (Some(25), (0, 0));
        self
    }
    /// No monitor fires; the application makes `requests`.
    fn requests(mut self, requests: &'static [(u64, Request)]) -> Self {
        (self.alarm, self.requests) = ((0, 0), requests);
        self
    }
}

/// What a case did.
struct Run {
    /// The calls, `Ctrl::calls_per_ms`.
    calls: Vec<String>,
    /// `Tally::text` of `outer`'s lane and `exc`'s.
    wakes: String,
    trace: Vec<Transition>,
    records: Vec<Record>,
    counters: Vec<Counters>,
    fired: [u16; 2],
    /// `Counts::ops` of the two lanes' wakers once the lanes are gone.
    ops: [[usize; 4]; 2],
    /// `Arc::strong_count` of the two lanes' counts while the lanes live, and at the end.
    strong: [[usize; 2]; 2],
}

fn run(case: &Case, run_ms: u64) -> Run {
    let within = |t: u64, (from, to): (u64, u64)| (from..to).contains(&t);
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step_cfg = SeqConfig::new("step").polling(ms(10)).on_abort(hook_step);
    let step = seq
        .add(
            step_cfg,
            Probe {
                exit: 0,
                names: STEP,
            },
        )
        .unwrap();
    let mut outer_cfg = SeqConfig::new("outer").polling(ms(10)).on_abort(hook_outer);
    if let Some(t) = case.timeout {
        outer_cfg = outer_cfg.timeout(ms(t)).timeout_behaviour(case.behaviour);
    }
    let mut outer = seq.add(outer_cfg, Outer { step }).unwrap();
    let mut exc = seq.add(SeqConfig::new("exc"), Nop).unwrap();
    let (o, e) = (outer.id(), exc.id());
    let (mut m1, mut m2) = (mon_outer, mon_step);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let mut mo = Monitor::new("mo", &mut m1, case.behaviour);
    if case.exception {
        mo = mo.exception(e);
    }
    monitors.add(o, mo).unwrap();
    let ms_monitor = Monitor::new("ms", &mut m2, Behaviour::Nothing);
    monitors.add(SeqId::from_index(0), ms_monitor).unwrap();
    let (co, ce) = (Arc::new(Counts::default()), Arc::new(Counts::default()));
    let strong = || [Arc::strong_count(&co), Arc::strong_count(&ce)];
    let (trace, records, counters, fired, strong_live, wakes);
    {
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut outer), &co), 1);
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut exc), &ce), 1);
        let mut tally = Tally::new(&[&co, &ce]);
        sim.before_tick(|t, c| {
            let now = t.as_ticks() / 1000;
            c.now.set(t.as_ticks());
            c.set(0, now >= 70);
            c.set(1, within(now, case.alarm));
            c.set(2, case.step_alarms.iter().any(|&a| within(now, a)));
        });
        sim.start(o).unwrap();
        tally.note(0);
        for t in 1..=run_ms {
            for &(_, request) in case.requests.iter().filter(|(at, _)| *at == t - 1) {
                match request {
                    Request::Pause => sim.pause(o).unwrap(),
                    Request::Resume => sim.resume(o).unwrap(),
                    Request::Abort => sim.abort(o).unwrap(),
                    Request::Start => sim.start(o).unwrap(),
                    Request::AbortAll => sim.abort_all(),
                }
                tally.note(t - 1);
            }
            sim.step();
            tally.note(t);
        }
        (strong_live, wakes) = (strong(), tally.text());
        (trace, records) = (sim.trace().to_vec(), sim.records().to_vec());
        let handle = |i| sim.handle(SeqId::from_index(i)).unwrap();
        counters = (0..3).map(|i| handle(i).counters()).collect();
        fired = [0, 1].map(|i| sim.monitors().fired(MonitorId::from_index(i)));
    }
    let (calls, ops) = (ctrl.calls_per_ms(), [co.ops(), ce.ops()]);
    let strong = [strong_live, strong()];
    Run {
        calls,
        wakes,
        trace,
        records,
        counters,
        fired,
        ops,
        strong,
    }
}

/// The cases whose calls (`CALLS`) and wake-ups (`WAKES`) are pinned.
fn cases() -> [(&'static str, Case); 12] {
    use Behaviour::*;
    use Request::*;
    [
        ("no firing", case(Nothing).requests(&[])),
        ("abort", case(AbortOwner)),
        ("abort, exception sequence", case(AbortOwner).exception()),
        ("restart", case(RestartOwner)),
        (
            "restart, exception sequence",
            case(RestartOwner).exception(),
        ),
        ("nothing", case(Nothing)),
        ("nothing, exception sequence", case(Nothing).exception()),
        ("timeout, abort", case(AbortOwner).timeout()),
        ("timeout, restart", case(RestartOwner).timeout()),
        ("timeout, nothing", case(Nothing).timeout()),
        (
            "abort, start",
            case(Nothing).requests(&[(25, Abort), (35, Start)]),
        ),
        ("abort-all", case(Nothing).requests(&[(25, AbortAll)])),
    ]
}

/// The calls of the first 20 ms, the same in every case.
const STEADY_CALLS: [&str; 3] = [
    "0: outer.pre outer.act step.pre step.act step.exit",
    "10: mon.outer mon.step step.exit",
    "20: mon.outer mon.step step.exit",
];

/// The wake-ups of the first 20 ms, the same in every case (left out: each lane's poll when
/// it is registered).
const STEADY_WAKES: &str = "0: 1/1 0/0, 10: 1/1 0/0, 20: 1/1 0/0";

/// Runs `case` for 90 ms; checks its first 20 ms against `STEADY_CALLS` and `STEADY_WAKES`,
/// and returns the rest: the calls and the wake-ups.
fn after_20_ms(name: &str, case: &Case) -> (Vec<String>, String, Run) {
    let run = run(case, 90);
    assert_eq!(run.calls[..3], STEADY_CALLS, "{name}");
    let wakes = run.wakes.strip_prefix(STEADY_WAKES).expect(name);
    let wakes = wakes.trim_start_matches(", ").to_string();
    (run.calls[3..].to_vec(), wakes, run)
}

/// The calls of each case of `cases` from 21 ms on, under its name.
const CALLS: &str = "\
no firing
    30: mon.outer mon.step step.exit
    40: mon.outer mon.step step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
abort
    30: mon.outer mon.step step.hook outer.hook
abort, exception sequence
    30: mon.outer mon.step exc.act
    31: step.hook outer.hook
restart
    30: mon.outer mon.step step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    40: mon.outer mon.step step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
restart, exception sequence
    30: mon.outer mon.step exc.act
    31: step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    40: mon.outer mon.step exc.act
    41: step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
nothing
    30: mon.outer mon.step step.exit
    40: mon.outer mon.step step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
nothing, exception sequence
    30: mon.outer mon.step exc.act
    40: mon.outer mon.step step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
timeout, abort
    30: mon.outer mon.step step.hook outer.hook
timeout, restart
    30: mon.outer mon.step step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    40: mon.outer mon.step step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.hook outer.hook outer.pre outer.act step.pre step.act step.exit
    70: mon.outer mon.step step.exit outer.exit
timeout, nothing
    30: mon.outer mon.step step.exit
    40: mon.outer mon.step step.exit
    50: mon.outer mon.step step.exit
    60: mon.outer mon.step step.exit
    70: mon.outer mon.step step.exit outer.exit
abort, start
    26: step.hook outer.hook
    35: outer.pre outer.act step.pre step.act step.exit
    45: mon.outer mon.step step.exit
    55: mon.outer mon.step step.exit
    65: mon.outer mon.step step.exit
    75: mon.outer mon.step step.exit outer.exit
abort-all
    26: step.hook outer.hook
";

/// The wake-ups of each case of `cases` from 21 ms on (`Tally::text` of `outer`'s lane and
/// `exc`'s), under its name.
const WAKES: &str = "\
no firing
    30: 1/1 0/0, 40: 1/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
abort
    30: 2/1 0/0
abort, exception sequence
    30: 0/0 1/1, 31: 2/1 0/0
restart
    30: 2/1 0/0, 40: 2/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
restart, exception sequence
    30: 0/0 1/1, 31: 2/1 0/0, 40: 0/0 1/1, 41: 2/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
nothing
    30: 2/1 0/0, 40: 1/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
nothing, exception sequence
    30: 0/0 1/1, 31: 1/1 0/0, 40: 1/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
timeout, abort
    30: 2/1 0/0
timeout, restart
    30: 2/1 0/0, 40: 1/1 0/0, 50: 1/1 0/0, 60: 2/1 0/0, 70: 1/1 0/0
timeout, nothing
    30: 2/1 0/0, 40: 1/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0
abort, start
    26: 2/1 0/0, 35: 1/1 0/0, 45: 1/1 0/0, 55: 1/1 0/0, 65: 1/1 0/0, 75: 1/1 0/0
abort-all
    26: 2/1 0/0
";

/// Each case calls user code once per due poll and once per transition that asks for it:
/// "monitors and timeout are evaluated by the tick at the owner's polling period [...]
/// before the exit condition of the same tick", the exit condition is "checked right after
/// the action and then at every poll", and "`Restarting` repeats from the pre-condition"
/// (docs/semantics.md item 1); a poll due while the owner is held by its exception is
/// skipped (item 1), and the behaviour is applied by the tick after the exception
/// sequence's end (item 3); a teardown calls each cleanup hook once, innermost first
/// (item 4); a monitor's edge restarts with every restart of its owner (item 5: "restart"
/// restarts again at 40 ms); a start after an abort begins a new grid (item 1).
#[test]
fn each_case_calls_user_code_once_per_due_poll() {
    let mut text = String::new();
    for (name, case) in cases() {
        let calls = after_20_ms(name, &case).0;
        text += &format!(
            "{name}\n{}",
            calls
                .iter()
                .map(|l| format!("    {l}\n"))
                .collect::<String>()
        );
    }
    assert_eq!(text, CALLS);
}

/// The tick calls a lane's waker once for each of its sequences it moves (an abort of a
/// sequence and its blocking child: two calls), and once more for a due poll of a sequence
/// it did not move; an executor polls the task once (docs/semantics.md item 15). A firing
/// that waits for its exception sequence wakes only that sequence's lane. Applying
/// `Behaviour::Nothing` wakes the owner's lane though nothing moves ("`Nothing` clears the
/// exception and wakes the owner's lane", docs/architecture.md, "A monitor firing"): two
/// calls at 30 ms in "nothing" and "timeout, nothing", one at 31 ms in "nothing, exception
/// sequence", whose poll calls nothing. "A lane keeps one waker, the one its run is polled
/// with" (item 15): rtseq clones each lane's waker once, calls it only by reference, and
/// drops its clone with the lane.
#[test]
fn a_tick_calls_a_lanes_waker_once_per_sequence_it_moves() {
    let mut text = String::new();
    for (name, case) in cases() {
        let (_, wakes, run) = after_20_ms(name, &case);
        text += &format!("{name}\n    {wakes}\n");
        for [clones, wake_calls_by_value, _, drops] in run.ops {
            assert_eq!([clones, wake_calls_by_value, drops], [1, 0, 2], "{name}");
        }
        assert_eq!(
            run.strong,
            [[4, 4], [1, 1]],
            "{name}: the test, `Counted` (2), rtseq"
        );
    }
    assert_eq!(text, WAKES);
}

/// A pause request pauses the sequence and its blocking child in the next tick (26 ms)
/// without waking their lane, which has nothing to do: "A pause wakes no lane: the paused
/// run waits at its await point until its resume wakes it" (docs/semantics.md item 15).
/// The resume (46 ms) wakes the lane once per sequence it moves, and that poll calls
/// nothing: the polls due while paused (30 and 40 ms) are skipped, not taken when the pause
/// ends, so the step's exit condition is next asked at 50 ms (item 1); the monitors stay
/// active (item 7).
#[test]
fn a_pause_wakes_no_lane() {
    use Request::*;
    let case = case(Behaviour::Nothing).requests(&[(25, Pause), (45, Resume)]);
    let (calls, wakes, run) = after_20_ms("pause", &case);
    let want = "\
30: mon.outer mon.step
40: mon.outer mon.step
50: mon.outer mon.step step.exit
60: mon.outer mon.step step.exit
70: mon.outer mon.step step.exit outer.exit";
    assert_eq!(calls.join("\n"), want);
    assert_eq!(wakes, "46: 2/1 0/0, 50: 1/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0");
    assert_eq!(
        moves(&run.trace)[2..6],
        [
            (26, 1, Running, Paused, Cause::Pause),
            (26, 0, Running, Paused, Cause::Pause),
            (46, 1, Paused, Running, Cause::Resume),
            (46, 0, Paused, Running, Cause::Resume),
        ]
    );
}

/// A `PauseOwner` hold (its condition true from 25 ms, seen at the 30 ms poll) pauses the
/// owner and its blocking child without waking their lane (docs/semantics.md item 15: "A
/// pause wakes no lane"); with an exception sequence, only that sequence's lane is woken,
/// to run it. The release (50 ms) wakes the lane once per sequence it moves; its poll calls
/// nothing: "the poll due in the release tick was taken while held and is skipped, so the
/// next check comes one polling period later" (item 1).
#[test]
fn a_pause_owner_hold_wakes_no_lane() {
    let mon = Cause::Monitor(MonitorId::from_index(0));
    for (exception, exc_act, woken_at_30) in [(false, "", ""), (true, " exc.act", "30: 0/0 1/1, ")]
    {
        let mut case = case(Behaviour::PauseOwner);
        case.exception = exception;
        let (calls, wakes, run) = after_20_ms("pause owner", &case);
        let want = format!(
            "30: mon.outer mon.step{exc_act}
40: mon.outer mon.step
50: mon.outer mon.step
60: mon.outer mon.step step.exit
70: mon.outer mon.step step.exit outer.exit"
        );
        assert_eq!(calls.join("\n"), want);
        let release = "50: 2/1 0/0, 60: 1/1 0/0, 70: 1/1 0/0";
        assert_eq!(wakes, format!("{woken_at_30}{release}"));
        let outer_and_step: Vec<Move> =
            moves(&run.trace).into_iter().filter(|m| m.1 != 2).collect();
        assert_eq!(
            outer_and_step[2..6],
            [
                (30, 1, Running, Paused, mon),
                (30, 0, Running, Paused, mon),
                (50, 1, Paused, Running, mon),
                (50, 0, Paused, Running, mon),
            ]
        );
    }
}

/// The records, the trace and the counters of every case say the same (docs/semantics.md
/// item 12: "the records say the same: the transitions, and an `Event::Fired` for each
/// exception (a `PauseOwner` monitor's hold is recorded as fired too, but marks no
/// exception and is not counted)"): the records' transitions are the trace; times never go
/// back; each transition's `from` is its sequence's last `to` (item 2); each sequence's
/// counters count its starts (not restarts nor resumes), aborts, restarts and completions
/// in the trace, and `exceptions` its `Fired` records other than `PauseOwner` ones;
/// `Monitors::fired` counts each monitor's `Fired` records.
#[test]
fn records_match_trace_and_counters() {
    use Behaviour::*;
    use Request::*;
    let mut bases = Vec::new();
    for b in [
        AbortOwner,
        RestartOwner,
        Nothing,
        PauseOwner,
        AbortCallerOfOwner,
        RestartCallerOfOwner,
    ] {
        bases.extend([case(b), case(b).exception()]);
    }
    bases.extend([AbortOwner, RestartOwner, Nothing].map(|b| case(b).timeout()));
    let step_alarms = &[(15, 17), (52, 58)];
    let mut cases: Vec<Case> = (bases.iter())
        .flat_map(|c| {
            [(25, 45), (25, 200), (5, 9)].map(|alarm| Case {
                alarm,
                step_alarms,
                ..*c
            })
        })
        .collect();
    cases.push(case(Nothing).requests(&[(25, Pause), (45, Resume), (80, Start)]));
    cases.push(case(Nothing).requests(&[(25, Abort), (35, Start)]));
    let mut totals = [0; 5];
    for (n, case) in cases.iter().enumerate() {
        let counts = assert_records_agree(&format!("case {n}"), &run(case, 120));
        for (total, count) in totals.iter_mut().zip(counts) {
            *total += count;
        }
    }
    // (runs, aborts, restarts, completions, exceptions) of all cases.
    assert_eq!(totals, [146, 62, 28, 80, 53]);
}

/// Checks `run` as `records_match_trace_and_counters` says; returns the counters summed
/// over its sequences: (runs, aborts, restarts, completions, exceptions).
fn assert_records_agree(name: &str, run: &Run) -> [usize; 5] {
    let from_records: Vec<Transition> = run.records.iter().filter_map(|r| r.transition()).collect();
    assert_eq!(from_records, run.trace, "{name}");
    assert!(
        run.records.windows(2).all(|p| p[0].time <= p[1].time),
        "{name}"
    );
    let mut last = [Idle; 3];
    for t in &run.trace {
        assert_eq!(t.from, last[t.sequence.index()], "{name}: {t:?}");
        last[t.sequence.index()] = t.to;
    }
    let fired = |pred: &dyn Fn(SeqId, Behaviour, Cause) -> bool| {
        let fired = |r: &&Record| matches!(r.entry, Entry::Event(Event::Fired { owner, behaviour, cause }) if pred(owner, behaviour, cause));
        run.records.iter().filter(fired).count()
    };
    let mut sum = [0; 5];
    for (i, c) in run.counters.iter().enumerate() {
        let id = SeqId::from_index(i);
        let to = |to, keep: &dyn Fn(&Transition) -> bool| {
            let of = |t: &&Transition| t.sequence == id && t.to == to && keep(t);
            run.trace.iter().filter(of).count()
        };
        let want = [
            to(Running, &|t| t.from != Paused && t.cause != Cause::Restart),
            to(Aborted, &|_| true),
            to(Restarting, &|_| true),
            to(Terminated, &|t| t.cause == Completed),
            fired(&|o, b, _| o == id && b != Behaviour::PauseOwner),
        ];
        let got = [c.runs, c.aborts, c.restarts, c.completed, c.exceptions].map(usize::from);
        assert_eq!(got, want, "{name}: sequence {i}");
        for (s, g) in sum.iter_mut().zip(got) {
            *s += g;
        }
    }
    for m in 0..2 {
        let mid = Cause::Monitor(MonitorId::from_index(m));
        let records = fired(&|_, _, cause| cause == mid);
        assert_eq!(usize::from(run.fired[m]), records, "{name}: monitor {m}");
    }
    sum
}

/// Two polling classes (3 ms and 5 ms), ticked by hand every ms to 10 ms, then late at
/// 23 ms, then at 24, 25 and 26.5 ms: each class's monitor and exit condition are called
/// once per due poll, its lane woken and polled once; "a late tick skips missed polls
/// instead of replaying them" (docs/semantics.md item 1): 23 ms takes one poll of each
/// class, and the grids go on from there (3 ms: 24; 5 ms: 25); a tick with nothing due
/// calls nothing and wakes nothing.
#[test]
fn late_ticks_and_two_classes_count_once_per_poll() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut o3 = ticker(&seq, ["o3", "s3"], 3, ["s3.pre", "s3.act", "s3.exit"]);
    let mut o5 = ticker(&seq, ["o5", "s5"], 5, ["s5.pre", "s5.act", "s5.exit"]);
    let (i3, i5) = (o3.id(), o5.id());
    let quiet = |what| {
        move |c: &Ctrl, t: Instant| {
            c.note(t.as_ticks(), what);
            false
        }
    };
    let (mut m3, mut m5) = (quiet("m3"), quiet("m5"));
    let mut monitors = Monitors::<Ctrl, 2>::new();
    monitors
        .add(i3, Monitor::new("m3", &mut m3, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(i5, Monitor::new("m5", &mut m5, Behaviour::AbortOwner))
        .unwrap();
    let (c3, c5) = (Arc::new(Counts::default()), Arc::new(Counts::default()));
    let mut lanes = [
        Counted::new(rtseq::lane(&seq, &ctrl, &mut o3), &c3),
        Counted::new(rtseq::lane(&seq, &ctrl, &mut o5), &c5),
    ];
    poll_woken(&mut lanes);
    for id in [i3, i5] {
        seq.sequence_by_id(id).unwrap().start().unwrap();
    }
    poll_woken(&mut lanes);
    ctrl.log.borrow_mut().clear();
    let mut tally = Tally::new(&[&c3, &c5]);
    for us in (1..=10)
        .map(|t| t * 1000)
        .chain([23_000, 24_000, 25_000, 26_500])
    {
        seq.tick(Instant::from_ticks(us), &ctrl, &mut monitors)
            .unwrap();
        poll_woken(&mut lanes);
        tally.note(us);
    }
    let calls = "3: m3 s3.exit, 5: m5 s5.exit, 6: m3 s3.exit, 9: m3 s3.exit, 10: m5 s5.exit, \
                 23: m3 m5 s3.exit s5.exit, 24: m3 s3.exit, 25: m5 s5.exit";
    assert_eq!(ctrl.calls_per_ms().join(", "), calls);
    let wakes = "3000: 1/1 0/0, 5000: 0/0 1/1, 6000: 1/1 0/0, 9000: 1/1 0/0, \
                 10000: 0/0 1/1, 23000: 1/1 1/1, 24000: 1/1 0/0, 25000: 0/0 1/1";
    assert_eq!(tally.text(), wakes, "o3's lane and o5's, per tick (µs)");
    drop(lanes);
    assert_eq!([Arc::strong_count(&c3), Arc::strong_count(&c5)], [1, 1]);
}

mod safety_io {
    use rtseq::safety::*;
    use std::cell::RefCell;

    /// Input `a` (the value of `a`) and `b`, output `o`; every call is logged.
    #[derive(Default)]
    pub struct Io {
        pub a: bool,
        pub log: Vec<String>,
    }
    impl SafetyIo for Io {
        fn read_input(&mut self, input: InputId) -> IoValue {
            self.log.push(format!("read {}", input.index()));
            IoValue::Bool(input.index() == 0 && self.a)
        }
        fn write_output(&mut self, output: OutputId, v: IoValue) {
            self.log.push(format!("write {} {v:?}", output.index()));
        }
    }
    const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
    const RUN: SafetyLevel = SafetyLevel::new(1);
    const TRIP: PrivateEvent = PrivateEvent::new(0);
    const A: CriticalInput<bool> = CriticalInput::new(0, "a");
    const B: CriticalInput<bool> = CriticalInput::new(1, "b");
    const O: CriticalOutput<bool> = CriticalOutput::new(0, "o");
    /// `run` checks `a` (false, else `TRIP` to `emergency`) and ignores `b`; `emergency`
    /// ignores both and aborts the sequences on entry.
    pub static PROPS: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
        [
            LevelDef::new(EMERGENCY, "emergency")
                .inputs(&[A.ignore(), B.ignore()])
                .outputs(&[O.set(false)])
                .level_action(|_, io: &mut Io| io.log.push("em.level".into()))
                .on_entry(|_, io: &mut Io| io.log.push("em.entry".into()))
                .abort_sequences(AbortPolicy::OnEntry),
            LevelDef::new(RUN, "run")
                .inputs(&[A.check(false, TRIP), B.ignore()])
                .outputs(&[O.set(true)])
                .level_action(|_, io: &mut Io| io.log.push("run.level".into()))
                .on_entry(|_, io: &mut Io| io.log.push("run.entry".into()))
                .on_exit(|io: &mut Io| io.log.push("run.exit".into())),
        ],
        &[A.info(), B.info()],
        &[O.info()],
        &[LevelTransition::on(RUN, TRIP, EMERGENCY)],
        RUN,
    );

    /// The sequencer's side: its calls, logged.
    #[derive(Default)]
    pub struct Seqs(pub RefCell<Vec<String>>);
    impl Sequences for Seqs {
        fn abort_all(&self) {
            self.0.borrow_mut().push("abort_all".into());
        }
        fn level_entered(&self, level: SafetyLevel) {
            self.0.borrow_mut().push(format!("entered {}", level.id()));
        }
        fn input_tripped(&self, input: InputId) {
            let tripped = format!("tripped {}", input.index());
            self.0.borrow_mut().push(tripped);
        }
    }
}

/// A safety cycle calls each action once, in the documented order: "(1) resolve every
/// pending event [...] exit action of the old level, [...] entry action of the new level;
/// (2) `abort_all` if the level demands it; (3) input actions in the level's order; (4) the
/// level action; (5) the output actions" (docs/semantics.md, "One cycle"); `ignore`d inputs
/// are not read; "`AbortPolicy::OnEntry` calls `Sequences::abort_all` once, in the entering
/// cycle". Input `a` trips in cycle 3; the emergency level is entered in cycle 4. Per
/// cycle: the calls of the I/O and the actions, then the calls into the sequencer.
#[test]
fn safety_cycle_calls_per_cycle() {
    use rtseq::safety::{SafetyHandle, SafetySystem};
    use safety_io::*;
    static H: SafetyHandle = SafetyHandle::new();
    let mut sys = SafetySystem::new(&PROPS, &H).unwrap();
    let (mut io, seqs) = (Io::default(), Seqs::default());
    let mut text = String::new();
    for cycle in 1..=6 {
        io.a = cycle >= 3;
        sys.cycle(&mut io, &seqs);
        let (io_calls, seqs_calls) = (io.log.join(", "), seqs.0.take().join(", "));
        text += &format!("{cycle}: [{io_calls}] [{seqs_calls}]\n");
        io.log.clear();
    }
    let calls = "\
1: [run.entry, read 0, run.level, write 0 Bool(true)] [entered 1]
2: [read 0, run.level, write 0 Bool(true)] []
3: [read 0, run.level, write 0 Bool(true)] [tripped 0]
4: [run.exit, em.entry, em.level, write 0 Bool(false)] [entered 0, abort_all]
5: [em.level, write 0 Bool(false)] []
6: [em.level, write 0 Bool(false)] []
";
    assert_eq!(text, calls);
}

// ---------------------------------------------------------------------------------------
// Lanes: joined, joining, dropped.
// ---------------------------------------------------------------------------------------

/// Three lanes due at the same ticks: `a` and `c` joined in one task (`lanes!`), `b` (whose
/// ids lie between theirs) in a task of its own. Each due tick wakes the joined task once
/// and polls it once, and `b`'s task once: "lanes joined in one task, `lanes!`, share a
/// waker and are woken once" (docs/semantics.md item 15), whatever the order of their ids.
/// With the portable lock (the lanes found in short sections) and a coarse one (in one).
#[test]
fn lanes_joined_in_one_task_are_woken_once_per_tick_whatever_their_ids() {
    joined_lanes_woken_once(Sequencer::<Ctrl, 8>::new());
    joined_lanes_woken_once(Sequencer::<Ctrl, 8, 64, SingleThread>::single_thread());
}

fn joined_lanes_woken_once<L: Lock>(seq: Sequencer<Ctrl, 8, 64, L>) {
    let ctrl = Ctrl::default();
    // ids: a.step 0, a 1, b.step 2, b 3, c.step 4, c 5
    let mut a = ticker(&seq, ["a", "a.step"], 10, STEP);
    let mut b = ticker(&seq, ["b", "b.step"], 10, STEP);
    let mut c = ticker(&seq, ["c", "c.step"], 10, STEP);
    let ids = [a.id(), b.id(), c.id()];
    let (cj, cb) = (Arc::new(Counts::default()), Arc::new(Counts::default()));
    {
        let (s, ctl, aa, cc) = (&seq, &ctrl, &mut a, &mut c);
        let joined = async move { rtseq::lanes!(s, ctl, aa, cc).await };
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.task_with_priority(Counted::new(joined, &cj), 1);
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut b), &cb), 1);
        for id in ids {
            sim.start(id).unwrap();
        }
        let mut tally = Tally::new(&[&cj, &cb]);
        for t in 1..=30 {
            sim.step();
            tally.note(t);
        }
        assert_eq!(tally.text(), "10: 1/1 1/1, 20: 1/1 1/1, 30: 1/1 1/1");
    }
    assert_eq!([Arc::strong_count(&cj), Arc::strong_count(&cb)], [1, 1]);
}

/// Starts `y` (with `starts_y`), then waits for it: in a join (with `join`), or in a polled
/// wait for flag 0, which is set when `y` ends. Its exit condition holds.
struct Waiter {
    y: SeqId,
    starts_y: bool,
    join: bool,
}
impl Sequence<Ctrl> for Waiter {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        if self.starts_y {
            cx.start(self.y)?;
        }
        if self.join {
            cx.join(self.y).await?;
        } else {
            let ended = |cx: &Cx<'_, Ctrl>| {
                cx.control().note(cx.now().as_ticks(), "j.wait");
                cx.control().flag(0)
            };
            cx.wait_until(ended).await;
        }
        cx.control().note(cx.now().as_ticks(), "j.done");
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().note(cx.now().as_ticks(), "j.exit");
        true
    }
}

/// J (polled every `period` ms) waits for Y (a `ticker`, which ends at 30 ms) as `Waiter`
/// says; the application starts Y first unless J does. Returns the `Tally` of J's lane and
/// Y's from 0 ms, and the calls.
fn wait_for_y(starts_y: bool, join: bool, period: u64) -> (String, Ctrl) {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut y = ticker(&seq, ["y", "y.step"], 10, STEP);
    let iy = y.id();
    let waiter = Waiter {
        y: iy,
        starts_y,
        join,
    };
    let mut j = seq
        .add(SeqConfig::new("j").polling(ms(period)), waiter)
        .unwrap();
    let ij = j.id();
    let (cj, cy) = (Arc::new(Counts::default()), Arc::new(Counts::default()));
    let wakes;
    {
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut j), &cj), 1);
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut y), &cy), 1);
        sim.before_tick(|t, c| {
            c.now.set(t.as_ticks());
            c.set(0, t.as_ticks() >= 30_000);
        });
        let mut tally = Tally::new(&[&cj, &cy]);
        if !starts_y {
            sim.start(iy).unwrap();
        }
        sim.start(ij).unwrap();
        tally.note(0);
        for t in 1..=40 {
            sim.step();
            tally.note(t);
        }
        assert_eq!(sim.state(ij), Terminated);
        wakes = tally.text();
    }
    assert_eq!([Arc::strong_count(&cj), Arc::strong_count(&cy)], [1, 1]);
    (wakes, ctrl)
}

/// A joiner's lane has nothing to do until the run it joins ends: it is woken once, by that
/// end (30 ms), whatever its own polling period and whoever started the run; "the end of
/// each joined run wakes it" (docs/semantics.md item 14). Its exit condition is then
/// checked once, right after the action (item 1).
#[test]
fn a_joiner_is_woken_only_by_the_end_it_waits_for() {
    for (starts_y, period) in [(true, 1), (false, 1), (true, 5)] {
        let (wakes, ctrl) = wait_for_y(starts_y, true, period);
        let case = format!("J starts Y: {starts_y}, J's period {period} ms");
        assert_eq!(
            wakes, "0: 1/1 1/1, 10: 0/0 1/1, 20: 0/0 1/1, 30: 1/1 1/1",
            "{case}"
        );
        assert_eq!(ctrl.times("j.done"), [30], "{case}");
        assert_eq!(ctrl.times("j.exit"), [30], "{case}");
    }
}

/// A polled wait (`Cx::wait_until`) is checked at every due poll of its sequence, its lane
/// woken and polled once for each: "a due poll of a polled condition wakes its lane once"
/// (docs/semantics.md item 15).
#[test]
fn a_polled_wait_is_woken_at_every_due_poll() {
    for (starts_y, period) in [(true, 1), (false, 1), (true, 5)] {
        let (wakes, ctrl) = wait_for_y(starts_y, false, period);
        let case = format!("J starts Y: {starts_y}, J's period {period} ms");
        let due: Vec<u64> = (0..=30).step_by(period as usize).collect();
        let y_woken = |t: u64| if t.is_multiple_of(10) { "1/1" } else { "0/0" };
        let each_poll: Vec<String> = due
            .iter()
            .map(|&t| format!("{t}: 1/1 {}", y_woken(t)))
            .collect();
        assert_eq!(wakes, each_poll.join(", "), "{case}");
        assert_eq!(ctrl.times("j.wait"), due, "{case}");
        assert_eq!(ctrl.times("j.done"), [30], "{case}");
    }
}

/// Polls `inner` with a waker of its own, not the one it is polled with (as a
/// `FuturesUnordered`-like combinator does).
struct Foreign<'c, F> {
    inner: Pin<&'c mut F>,
    waker: Waker,
}
impl<F: Future> Future for Foreign<'_, F> {
    type Output = F::Output;
    fn poll(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<F::Output> {
        let this = self.get_mut();
        this.inner
            .as_mut()
            .poll(&mut Context::from_waker(&this.waker))
    }
}

/// `inner` polled with a new counting waker of `counts`.
fn foreign<'c, F>(inner: Pin<&'c mut F>, counts: &Arc<Counts>) -> Foreign<'c, F> {
    let waker = counting_waker(counts);
    Foreign { inner, waker }
}

/// Starts `y`, then polls a join of it, a polled wait (flag 3) and a blocking step, each
/// with a foreign counting waker.
struct ForeignUser {
    y: SeqId,
    step: Seq<Probe>,
    counts: Arc<Counts>,
}
impl Sequence<Ctrl> for ForeignUser {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.start(self.y)?;
        let counts = &self.counts;
        foreign(pin!(cx.join(self.y)), counts).await?;
        foreign(pin!(cx.wait_until(|cx| cx.control().flag(3))), counts).await;
        foreign(pin!(cx.step(&mut self.step)), counts).await?;
        Ok(())
    }
}

/// "An action's futures (`Cx`) and blocking runs keep none of their own"
/// (docs/semantics.md item 15): a join, a polled wait and a blocking step polled with a
/// foreign waker never clone it, call it or keep it; the run still ends, woken through its
/// lane's waker.
#[test]
fn futures_of_an_action_keep_no_foreign_waker() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let y = ticker(&seq, ["y", "y.step"], 10, STEP); // ids 1 and 0
    let foreign = Arc::new(Counts::default());
    let step = seq.add(
        SeqConfig::new("fstep").polling(ms(10)),
        Probe {
            exit: 4,
            names: STEP,
        },
    );
    let user = ForeignUser {
        y: y.id(),
        step: step.unwrap(),
        counts: foreign.clone(),
    };
    let fu = seq.add(SeqConfig::new("fu").polling(ms(5)), user).unwrap(); // fstep 2, fu 3
    let ifu = fu.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(fu);
    sim.lane(y);
    sim.before_tick(|t, c| {
        c.set(0, t.as_ticks() >= 30_000);
        c.set(3, t.as_ticks() >= 42_000);
        c.set(4, t.as_ticks() >= 61_000);
    });
    sim.start(ifu).unwrap();
    let mut most_held = 0;
    for _ in 0..100 {
        sim.step();
        most_held = most_held.max(Arc::strong_count(&foreign));
    }
    assert_eq!(
        moves(sim.trace())[3..],
        [
            (30, 0, Running, Terminated, Completed),
            (30, 1, Running, Terminated, Completed),
            (45, 2, Idle, Running, Start),
            (65, 2, Running, Terminated, Completed),
            (65, 3, Running, Terminated, Completed),
        ]
    );
    assert_eq!(
        foreign.ops(),
        [0, 0, 0, 3],
        "[clones, wakes, wake_by_refs, drops]"
    );
    assert_eq!(most_held, 3, "the test, `ForeignUser` and one `Foreign`");
}

/// A lane future dropped (the loser of a `select`) aborts its run and gives back rtseq's
/// clone of its waker at once, and that waker is never called again; a new lane future for
/// the sequence (in a new simulator) keeps its own waker, one clone, which it gives back
/// when it goes ("A lane's future dropped [...] closes the lane: until a lane future for
/// the sequence waits again, its start is `Err(Error::NoLane)`", docs/semantics.md item 13).
#[test]
fn a_dropped_and_reopened_lane_holds_exactly_its_current_waker() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut a = ticker(&seq, ["a", "a.step"], 10, STEP);
    let ia = a.id();
    let (c1, c2) = (Arc::new(Counts::default()), Arc::new(Counts::default()));
    let stop = Cell::new(false);
    let wake_calls_after_drop;
    {
        let (s, ctl, aa, stop) = (&seq, &ctrl, &mut a, &stop);
        let first = async move {
            let stopper = std::future::poll_fn(|_| match stop.get() {
                true => Poll::Ready(()),
                false => Poll::Pending,
            });
            select(rtseq::lane(s, ctl, aa), stopper).await;
            std::future::pending().await
        };
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.task_with_priority(Counted::new(first, &c1), 1);
        sim.start(ia).unwrap();
        sim.run_for(ms(15));
        assert_eq!(
            Arc::strong_count(&c1),
            4,
            "the test, `Counted` (2), rtseq (1)"
        );
        stop.set(true);
        c1.signal(); // the executor polls the task: the `select` drops the lane
        sim.step(); // 16 ms
        assert_eq!(sim.state(ia), Aborted);
        assert_eq!(
            Arc::strong_count(&c1),
            3,
            "rtseq still holds the dropped lane's waker"
        );
        assert_eq!(
            seq.sequence_by_id(ia).unwrap().start(),
            Err(rtseq::Error::NoLane(ia))
        );
        wake_calls_after_drop = c1.wake_calls();
    }
    {
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.task_with_priority(Counted::new(rtseq::lane(&seq, &ctrl, &mut a), &c2), 1);
        sim.start(ia).unwrap();
        sim.run_for(ms(25));
        assert_eq!(
            c1.wake_calls(),
            wake_calls_after_drop,
            "the dropped lane's waker"
        );
        assert_eq!([Arc::strong_count(&c1), Arc::strong_count(&c2)], [1, 4]);
    }
    assert_eq!(Arc::strong_count(&c2), 1);
    c1.assert_balanced();
    c2.assert_balanced();
}

/// A lane future leaked (`mem::forget`) leaves its waker in the sequencer's lane slot;
/// dropping the sequencer drops it.
#[test]
fn a_dropped_sequencer_drops_the_wakers_it_kept() {
    let counts = Arc::new(Counts::default());
    {
        let seq: Sequencer<Ctrl, 8> = Sequencer::new();
        let ctrl = Ctrl::default();
        let mut a = ticker(&seq, ["a", "a.step"], 10, STEP);
        let waker = counting_waker(&counts);
        let mut lane = Box::pin(rtseq::lane(&seq, &ctrl, &mut a));
        let _ = lane.as_mut().poll(&mut Context::from_waker(&waker));
        drop(waker);
        assert_eq!(Arc::strong_count(&counts), 2, "the test, the lane slot");
        std::mem::forget(lane);
    }
    assert_eq!(Arc::strong_count(&counts), 1);
    counts.assert_balanced();
}

/// Runs its child blocking against a wait for flag 5 (`select`): the wait wins at 30 ms
/// and drops the child's run; then it waits for flag 6.
struct Racer {
    child: Seq<Outer>,
}
impl Sequence<Ctrl> for Racer {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _ = select(
            cx.run(&mut self.child),
            cx.wait_until(|cx| cx.control().flag(5)),
        )
        .await;
        cx.control().note(cx.now().as_ticks(), "racer.after");
        let flag_6 = |cx: &Cx<'_, Ctrl>| {
            cx.control().note(cx.now().as_ticks(), "racer.wait");
            cx.control().flag(6)
        };
        cx.wait_until(flag_6).await;
        Ok(())
    }
}

/// A run dropped inside its lane's poll wakes that lane once per sequence it tears down;
/// the lane's next poll finds nothing to do (docs/semantics.md item 13). Here the `select`
/// of the racer's 30 ms poll drops its child's run, a sequence and its step: the lane's
/// waker is called three times at 30 ms (the due poll, then two for the teardown) and the
/// lane polled twice, the second poll calling nothing. The run and its step end `Aborted`
/// by `Dropped`, innermost first; the lane keeps one waker and gives it back at its end.
#[test]
fn a_blocking_run_dropped_by_select_wakes_its_lane_once_per_sequence_torn_down() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let child = ticker(&seq, ["child", "c.step"], 10, STEP); // ids: c.step 0, child 1
    let racer = seq.add(SeqConfig::new("racer").polling(ms(10)), Racer { child });
    let mut racer = racer.unwrap();
    let ir = racer.id();
    let counts = Arc::new(Counts::default());
    {
        let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
        sim.task_with_priority(
            Counted::new(rtseq::lane(&seq, &ctrl, &mut racer), &counts),
            1,
        );
        sim.before_tick(|t, c| {
            c.set(5, t.as_ticks() >= 25_000);
            c.set(6, t.as_ticks() >= 60_000);
        });
        sim.start(ir).unwrap();
        let mut tally = Tally::new(&[&counts]);
        for t in 1..=70 {
            sim.step();
            tally.note(t);
        }
        let wakes = "10: 1/1, 20: 1/1, 30: 3/2, 40: 1/1, 50: 1/1, 60: 1/1";
        assert_eq!(tally.text(), wakes);
        assert_eq!(
            moves(sim.trace())[3..],
            [
                (30, 0, Running, Aborting, Dropped),
                (30, 0, Aborting, Aborted, Dropped),
                (30, 1, Running, Aborting, Dropped),
                (30, 1, Aborting, Aborted, Dropped),
                (60, 2, Running, Terminated, Completed),
            ]
        );
    }
    let calls = ctrl.calls_per_ms();
    assert_eq!(calls[3], "30: step.exit racer.after racer.wait");
    assert_eq!(
        calls[4..],
        ["40: racer.wait", "50: racer.wait", "60: racer.wait"]
    );
    assert_eq!(
        counts.ops(),
        [1, 0, 9, 2],
        "[clones, wakes, wake_by_refs, drops]"
    );
    assert_eq!(Arc::strong_count(&counts), 1);
}
