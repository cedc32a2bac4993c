//! Systematic interleavings, second round: where `interleavings.rs` did not look.
//!
//! As there, each test counts the sections of one operation under the test lock
//! [`Interleaved`], then, for every section `k`, builds a fresh sequencer and runs the
//! operation with another party (a tick, a lane of higher priority, a handle) inserted
//! right before section `k`, and asserts the exact outcome the semantics
//! (docs/semantics.md) demand and the invariants of [`World::check`].
//!
//! 1. A lane taking its start (`Port::take_start`) or dropped while it waits
//!    (`Port::abandon_start`), against a tick that fires on or aborts the started run.
//! 2. Pause and resume requests against a tick whose `PauseOwner` monitor holds or lets go,
//!    and the reverse; the run's clock checked by a timeout's exact expiry.
//! 3. Joins against the end, abort and restart of the joined run, one and two joiners,
//!    with counting wakers.
//! 4. Sequencers of two words (the multi-word sets, indexes and `levels` candidates).
//! 5. Exception sequences: the end of E reported to its owner exactly once.
//!
//! Tests marked `#[ignore = "defect: ..."]` fail today; the reason names the defect.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

extern crate std;

use core::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use core::task::{Poll, Waker};
use std::boxed::Box;
use std::cell::RefCell;
use std::format;
use std::rc::Rc;
use std::string::String;
use std::sync::Arc;
use std::task::Wake;
use std::vec::Vec;

use crate::lock::interleaved::{self, Interleaved};
use crate::model::id::RunId;
use crate::sequencer::control_block::flag;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::sequencer::transition::Clearance;
use crate::trace::{Record, Transition};
use crate::{
    Behaviour, Cause, Condition, Duration, Error, Event, Instant, Monitor, MonitorId, Monitors,
    Outcome, RunningState, SeqConfig, SeqId, Sequencer,
};

use RunningState::{Aborted, Aborting, Idle, Paused, Restarting, Running, Terminated};

/// A sequencer under the interleaving lock: `N` sequences in `B` words of 32.
type Sq<const N: usize, const B: usize> = Sequencer<(), N, 256, Interleaved, 8, B>;

/// The first and second monitor of a table.
const M0: Cause = Cause::Monitor(MonitorId(0));
const M1: Cause = Cause::Monitor(MonitorId(1));

/// Where the sequences under test sit.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    /// A sequencer of one word.
    One,
    /// Two words, every sequence under test in the second (32 fillers first).
    Second,
    /// Two words, those registered before [`World::split`] in the first, the others in
    /// the second.
    Split,
}

/// A waker that counts its wake-ups.
struct Count(AtomicUsize);

impl Wake for Count {
    fn wake(self: Arc<Self>) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }
}

/// A counting waker and its count.
fn counting() -> (Waker, Arc<Count>) {
    let count = Arc::new(Count(AtomicUsize::new(0)));
    (Waker::from(count.clone()), count)
}

fn woken(c: &Arc<Count>) -> usize {
    c.0.load(Ordering::Relaxed)
}

/// A sequencer, the monitor table its ticks use and the records drained so far, all
/// `'static` so that a closure run between two sections can tick.
struct World<const N: usize, const B: usize> {
    seq: &'static Sq<N, B>,
    monitors: &'static RefCell<Monitors<'static, (), 4>>,
    log: &'static RefCell<Vec<Record>>,
    layout: Layout,
}

impl<const N: usize, const B: usize> Clone for World<N, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<const N: usize, const B: usize> Copy for World<N, B> {}

impl<const N: usize, const B: usize> World<N, B> {
    fn new(layout: Layout) -> Self {
        assert_eq!(B == 1, layout == Layout::One, "{layout:?} needs B = {B}");
        // Nothing left over from an earlier test on this thread.
        interleaved::at(usize::MAX, || {});
        let w = World {
            seq: Box::leak(Box::new(Sequencer::empty())),
            monitors: Box::leak(Box::new(RefCell::new(Monitors::new()))),
            log: Box::leak(Box::new(RefCell::new(Vec::new()))),
            layout,
        };
        if layout == Layout::Second {
            w.pad();
        }
        w
    }

    /// With [`Layout::Split`]: the sequences registered from now on are in the second
    /// word.
    fn split(&self) {
        if self.layout == Layout::Split {
            self.pad();
        }
    }

    /// Fillers (no lane, never started) up to id 32.
    fn pad(&self) {
        while self.count() < 32 {
            let name: &'static str = Box::leak(format!("filler {}", self.count()).into_boxed_str());
            self.seq.register(SeqConfig::new(name)).unwrap();
        }
    }

    fn count(&self) -> usize {
        self.seq.with(|s| s.count())
    }

    /// Registers `config` and declares its lane.
    fn add(&self, config: SeqConfig<()>) -> SeqId {
        let id = self.seq.register(config).unwrap();
        self.seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        if self.layout == Layout::Second {
            assert!(id.index() >= 32, "{id:?} in the first word");
        }
        id
    }

    /// A sequence polled every millisecond, with a lane.
    fn seq(&self, name: &'static str) -> SeqId {
        self.add(SeqConfig::new(name))
    }

    /// A sequence with a timeout of `ms`, with a lane.
    fn timed(&self, name: &'static str, ms: u64) -> SeqId {
        self.add(SeqConfig::new(name).timeout(Duration::from_millis(ms)))
    }

    /// A monitor of `owner` whose condition is `flag`; its cause.
    fn monitor(
        &self,
        owner: SeqId,
        flag: &'static AtomicBool,
        b: Behaviour,
        e: Option<SeqId>,
    ) -> Cause {
        let condition: &'static mut (dyn Condition<()> + Send) =
            Box::leak(Box::new(move |_: &(), _: Instant| {
                flag.load(Ordering::Relaxed)
            }));
        let mut m = Monitor::new("m", condition, b);
        if let Some(e) = e {
            m = m.exception(e);
        }
        Cause::Monitor(self.monitors.borrow_mut().add(owner, m).unwrap())
    }

    /// The tick at `ms` milliseconds.
    fn tick(&self, ms: u64) {
        let mut monitors = self.monitors.borrow_mut();
        self.seq
            .tick(Instant::from_ticks(ms * 1_000), &(), &mut monitors)
            .unwrap();
    }

    fn state(&self, id: SeqId) -> RunningState {
        self.seq.with(|s| s.state_of(id))
    }

    /// The state and the cause of the last abort or restart.
    fn ended(&self, id: SeqId) -> (RunningState, Cause) {
        self.seq
            .with(|s| (s.state_of(id), s.block(id).unwrap().last_cause))
    }

    fn run(&self, id: SeqId) -> RunId {
        self.seq.with(|s| s.current_run(id))
    }

    fn has(&self, id: SeqId, f: u16) -> bool {
        self.seq.with(|s| s.block(id).unwrap().has(f))
    }

    fn in_set(&self, set: Set, id: SeqId) -> bool {
        self.seq.with(|s| s.sets.has(set, id))
    }

    fn clearance(&self, run: RunId) -> Clearance {
        Port::clearance(self.seq, run, Waker::noop())
    }

    fn handle(&self, id: SeqId) -> crate::Handle<'static, ()> {
        self.seq.sequence_by_id(id).unwrap()
    }

    /// Starts `id` by a handle (a main sequence) and lets its lane take the start.
    fn start_taken(&self, id: SeqId) -> RunId {
        self.handle(id).start().unwrap();
        self.take(id)
    }

    /// `id`'s lane takes its pending start.
    fn take(&self, id: SeqId) -> RunId {
        Port::take_start(self.seq, id, 0, Waker::noop()).unwrap()
    }

    /// `id`'s lane ends its current run with `outcome` and reports it over.
    fn end(&self, id: SeqId, outcome: Outcome) -> bool {
        let run = self.run(id);
        let ended = Port::end(self.seq, run, outcome);
        if ended {
            Port::finished(self.seq, run);
        }
        ended
    }

    fn complete(&self, id: SeqId) -> bool {
        self.end(id, Outcome::Completed)
    }

    /// Every record so far (drained into the log).
    fn records(&self) -> Vec<Record> {
        let mut log = self.log.borrow_mut();
        assert_eq!(self.seq.drain_records(|r| log.push(r)), 0, "records lost");
        log.clone()
    }

    /// The transitions of `id` so far, with their times.
    fn transitions(&self, id: SeqId) -> Vec<Transition> {
        self.records()
            .iter()
            .filter_map(|r| {
                let mut t = r.transition()?;
                t.time = r.time;
                Some(t)
            })
            .filter(|t| t.sequence == id)
            .collect()
    }

    /// How many transitions of `id` from `from` to `to` there were.
    fn moves(&self, id: SeqId, from: RunningState, to: RunningState) -> usize {
        self.transitions(id)
            .iter()
            .filter(|t| t.from == from && t.to == to)
            .count()
    }

    /// The `Fired` records of `owner`'s `cause`.
    fn fired(&self, owner: SeqId, cause: Cause) -> usize {
        self.records()
            .iter()
            .filter(|r| {
                matches!(r.event(), Some(Event::Fired { owner: o, cause: c, .. })
                    if o == owner && c == cause)
            })
            .count()
    }

    /// The invariants of every interleaving: no sequence under way (running, paused,
    /// restarting) has an aborted caller up its caller links; the trace's transitions
    /// chain (each `from` is the sequence's last `to`, from `Idle`) and are allowed
    /// changes; no exception sequence refused. `what` names the interleaving.
    fn check(&self, what: &str) {
        let count = self.count();
        for i in 0..count {
            let id = SeqId::from_index(i);
            if ![Running, Paused, Restarting].contains(&self.state(id)) {
                continue;
            }
            let mut at = self.seq.with(|s| s.block(id).unwrap().caller.get());
            for _ in 0..crate::MAX_DEPTH {
                let Some(c) = at else { break };
                assert_ne!(
                    self.state(c),
                    Aborted,
                    "{what}: {id:?} is {:?} below aborted {c:?}",
                    self.state(id)
                );
                at = self.seq.with(|s| s.block(c).unwrap().caller.get());
            }
        }
        let mut last = std::vec![Idle; count];
        for r in self.records() {
            if let Some(t) = r.transition() {
                let prev = &mut last[t.sequence.index()];
                assert_eq!(t.from, *prev, "{what}: {t:?} after {prev:?}");
                assert!(t.from.can_transition_to(t.to), "{what}: {t:?}");
                *prev = t.to;
            }
        }
        for (i, last) in last.iter().enumerate().take(count) {
            let id = SeqId::from_index(i);
            assert_eq!(
                *last,
                self.state(id),
                "{what}: {id:?}'s trace ends elsewhere"
            );
        }
        assert_eq!(
            self.seq.exceptions_not_run(),
            0,
            "{what}: an exception not run"
        );
    }

    /// Ticks from `from` ms on and returns the first tick at which `id` is no longer
    /// `Running` (at most `to`).
    fn runs_until(&self, id: SeqId, from: u64, to: u64) -> u64 {
        for ms in from..=to {
            self.tick(ms);
            if self.state(id) != Running {
                return ms;
            }
        }
        panic!("{id:?} still running at {to} ms");
    }
}

/// The sections `op` takes, undisturbed, on a fresh world from `setup`.
fn sections<S>(setup: impl Fn() -> S, op: impl Fn(&S)) -> usize {
    let s = setup();
    interleaved::at(usize::MAX, || {});
    op(&s);
    let n = interleaved::taken();
    assert!(n > 1, "{n} sections");
    n
}

/// Runs `f(k)` for every `k` in `0..count`, each on its own; fails listing the `k` that
/// failed and the first failure's message.
fn every_k(count: usize, f: impl Fn(usize)) {
    let mut failed = Vec::new();
    let mut first = None;
    for k in 0..count {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(k)));
        if let Err(e) = r {
            failed.push(k);
            if first.is_none() {
                first = Some(
                    e.downcast_ref::<String>()
                        .cloned()
                        .or_else(|| e.downcast_ref::<&str>().map(|s| String::from(*s)))
                        .unwrap_or_default(),
                );
            }
        }
    }
    assert!(
        failed.is_empty(),
        "failed before sections {failed:?} of {count}; first: {}",
        first.unwrap_or_default()
    );
}

/// A flag for a monitor's condition.
fn flag_of(on: bool) -> &'static AtomicBool {
    Box::leak(Box::new(AtomicBool::new(on)))
}

/// Whether the closure inserted before section `k` ran.
fn inserted(k: usize) -> bool {
    interleaved::taken() > k
}

// =======================================================================================
// 1. A lane taking its start, or dropped while it waits, against the tick.
// =======================================================================================

/// What the tick at 1 ms does to O, whose start is pending (not taken by its lane).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tick {
    /// O's monitor, `AbortOwner`, no exception sequence.
    Abort,
    /// O's monitor, `AbortOwner`, exception sequence E.
    AbortAfterE,
    /// O's 1 ms timeout (`AbortOwner`).
    Timeout,
    /// An abort request of O made before.
    Request,
    /// An abort-all made before.
    AbortAll,
    /// O's monitor, `RestartOwner`.
    Restart,
    /// O's `PauseOwner` monitor (its condition true at 1 ms, false from 2 ms); O has a
    /// 5 ms timeout.
    Pause,
}

impl Tick {
    /// The cause of O's abort (or restart, or pause) by the tick.
    fn cause(self, o: SeqId) -> Cause {
        match self {
            Tick::Abort | Tick::AbortAfterE | Tick::Restart | Tick::Pause => M0,
            Tick::Timeout => Cause::Timeout(o),
            Tick::Request => Cause::Abort,
            Tick::AbortAll => Cause::AbortAll,
        }
    }
}

/// O (started by a handle at 0, its start not taken) and E, `tick` set up for the tick at
/// 1 ms. Returns the world, O, E and the pause monitor's flag.
fn pending_start<const N: usize, const B: usize>(
    layout: Layout,
    tick: Tick,
) -> (World<N, B>, SeqId, SeqId, &'static AtomicBool) {
    let w = World::<N, B>::new(layout);
    let e = w.seq("E");
    w.split();
    let o = match tick {
        Tick::Timeout => w.timed("O", 1),
        Tick::Pause => w.timed("O", 5),
        _ => w.seq("O"),
    };
    let on = flag_of(true);
    match tick {
        Tick::Abort => {
            w.monitor(o, on, Behaviour::AbortOwner, None);
        }
        Tick::AbortAfterE => {
            w.monitor(o, on, Behaviour::AbortOwner, Some(e));
        }
        Tick::Restart => {
            w.monitor(o, on, Behaviour::RestartOwner, None);
        }
        Tick::Pause => {
            w.monitor(o, on, Behaviour::PauseOwner, None);
        }
        Tick::Timeout | Tick::Request | Tick::AbortAll => {}
    }
    w.handle(o).start().unwrap();
    match tick {
        Tick::Request => w.handle(o).abort().unwrap(),
        Tick::AbortAll => w.seq.abort_all(),
        _ => {}
    }
    (w, o, e, on)
}

/// O's lane takes O's pending start (`Port::take_start`, a counting waker) while the tick
/// at 1 ms does `tick` to O, before each section of the take, or after it (`k` = the
/// count). The lane takes the run it was started for, or nothing when the tick aborted
/// it first (an abort leaves no start to take); the clearance of a taken run says what
/// the tick did: `Aborted(cause)`, `Restart`, `Hold`. After the take, a tick that changed
/// the run woke the lane. An aborted O can be started and taken again (run 2); a restarted
/// one runs again; a paused one resumes when the monitor lets go, its clock stopped in
/// between (its 5 ms timeout, 1 ms of it used at the pause, runs out at exactly 6 ms).
fn take_during_tick<const N: usize, const B: usize>(layout: Layout, tick: Tick) {
    let count = sections(
        || pending_start::<N, B>(layout, tick),
        |(w, o, _, _)| {
            Port::take_start(w.seq, *o, 0, Waker::noop());
        },
    );
    every_k(count + 1, |k| {
        let (w, o, e, on) = pending_start::<N, B>(layout, tick);
        let what = format!("{layout:?}, {tick:?}, k={k}");
        let (waker, wakes) = counting();
        interleaved::at(k, move || w.tick(1));
        let taken = Port::take_start(w.seq, o, 0, &waker);
        let after = !inserted(k);
        if after {
            interleaved::at(usize::MAX, || {});
            assert_eq!(woken(&wakes), 0, "{what}");
            w.tick(1);
        }
        let first = RunId { seq: o, count: 1 };
        let cause = tick.cause(o);
        match tick {
            Tick::Abort | Tick::Timeout | Tick::Request | Tick::AbortAll => {
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                assert!(!w.has(o, flag::START_PENDING), "{what}: a start left");
                match taken {
                    Some(run) => {
                        assert_eq!(run, first, "{what}");
                        assert_eq!(w.clearance(run), Clearance::Aborted(cause), "{what}");
                    }
                    None => assert!(!after, "{what}: the start was there"),
                }
                if after {
                    assert_eq!(woken(&wakes), 1, "{what}: the abort woke the lane");
                }
                Port::finished(w.seq, first);
                w.handle(o).start().unwrap();
                assert_eq!(w.take(o), RunId { seq: o, count: 2 }, "{what}");
                assert_eq!(w.state(o), Running, "{what}");
            }
            Tick::AbortAfterE => {
                // O holds while E runs; E's lane runs it to its end; the next tick aborts O.
                assert_eq!(taken, Some(first), "{what}");
                assert_eq!(w.clearance(first), Clearance::Hold, "{what}");
                assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
                w.take(e);
                assert!(w.complete(e), "{what}");
                if after {
                    assert_eq!(woken(&wakes), 0, "{what}: a hold wakes no one");
                }
                w.tick(2);
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                assert_eq!(w.clearance(first), Clearance::Aborted(cause), "{what}");
                assert_eq!(w.fired(o, M0), 1, "{what}");
            }
            Tick::Restart => {
                assert_eq!(taken, Some(first), "{what}");
                assert_eq!(w.ended(o), (Restarting, cause), "{what}");
                assert_eq!(w.clearance(first), Clearance::Restart, "{what}");
                if after {
                    assert_eq!(woken(&wakes), 1, "{what}: the restart woke the lane");
                }
                w.seq.restart(first);
                assert_eq!(w.state(o), Running, "{what}");
                assert_eq!(w.clearance(first), Clearance::Go, "{what}");
            }
            Tick::Pause => {
                assert_eq!(taken, Some(first), "{what}");
                assert_eq!(w.state(o), Paused, "{what}");
                assert_eq!(w.clearance(first), Clearance::Hold, "{what}");
                on.store(false, Ordering::Relaxed);
                w.tick(2);
                assert_eq!(w.state(o), Running, "{what}");
                assert_eq!(w.clearance(first), Clearance::Go, "{what}");
                assert_eq!(w.runs_until(o, 3, 20), 6, "{what}: the timeout's expiry");
                assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}");
            }
        }
        w.check(&what);
    });
}

/// O's lane takes its start while the tick aborts O (monitor, timeout, request,
/// abort-all), restarts it, pauses it, or holds it for its exception sequence.
#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone() {
    for tick in [
        Tick::Abort,
        Tick::AbortAfterE,
        Tick::Timeout,
        Tick::Request,
        Tick::AbortAll,
        Tick::Restart,
        Tick::Pause,
    ] {
        take_during_tick::<8, 1>(Layout::One, tick);
    }
}

/// The same in a sequencer of two words, O in the second (E in the first or second).
#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for tick in [
            Tick::Abort,
            Tick::AbortAfterE,
            Tick::Timeout,
            Tick::Request,
            Tick::AbortAll,
            Tick::Restart,
            Tick::Pause,
        ] {
            take_during_tick::<64, 2>(layout, tick);
        }
    }
}

/// O's lane is dropped while it waits for O's pending start (`Port::abandon_start`), and
/// the tick at 1 ms does `tick` to O before each section. The start made but not taken is
/// aborted (semantics 13): O ends `Aborted`, by the drop (`Dropped`), or by the tick when
/// the tick aborted it first (then the drop finds no start); never left under way. A
/// restart or a pause by the tick leaves the start pending: the drop aborts it. With the
/// exception sequence E started by the tick below O, E is torn down with O, and the tick
/// after, which reports E's end, changes nothing.
fn abandon_during_tick<const N: usize, const B: usize>(layout: Layout, tick: Tick) {
    let count = sections(
        || pending_start::<N, B>(layout, tick),
        |(w, o, _, _)| Port::abandon_start(w.seq, *o, 0, &()),
    );
    every_k(count, |k| {
        let (w, o, e, _) = pending_start::<N, B>(layout, tick);
        let what = format!("{layout:?}, {tick:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        Port::abandon_start(w.seq, o, 0, &());
        assert!(inserted(k), "{what}: the tick ran");
        let by_tick = matches!(
            tick,
            Tick::Abort | Tick::Timeout | Tick::Request | Tick::AbortAll
        );
        let (state, cause) = w.ended(o);
        assert_eq!(state, Aborted, "{what}");
        if by_tick && k == 0 {
            assert_eq!(cause, tick.cause(o), "{what}");
        } else if by_tick {
            assert!(
                [tick.cause(o), Cause::Dropped].contains(&cause),
                "{what}: {cause:?}"
            );
        } else {
            assert_eq!(cause, Cause::Dropped, "{what}");
        }
        assert!(!w.has(o, flag::START_PENDING), "{what}");
        let e_state = w.ended(e);
        assert!(
            e_state.0 == Idle || e_state == (Aborted, Cause::Dropped),
            "{what}: E {e_state:?}"
        );
        w.tick(2);
        w.tick(3);
        assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
        assert_eq!(w.ended(e), e_state, "{what}: E after");
        // E is no one's any more.
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_lane_dropped_while_the_tick_fires_on_its_pending_start_leaves_nothing_under_way() {
    for tick in [
        Tick::Abort,
        Tick::AbortAfterE,
        Tick::Timeout,
        Tick::Request,
        Tick::AbortAll,
        Tick::Restart,
        Tick::Pause,
    ] {
        abandon_during_tick::<8, 1>(Layout::One, tick);
        abandon_during_tick::<64, 2>(Layout::Second, tick);
        abandon_during_tick::<64, 2>(Layout::Split, tick);
    }
}

/// O's monitor fired at 1 ms and started its exception sequence E (`AbortOwner`), whose
/// start E's lane has not taken. The tick at 2 ms aborts O (a request, or an abort-all),
/// and so E below it; E's lane takes its start before each section of that tick. The
/// lane takes E's run and finds it aborted, or finds nothing; O and E are aborted by the
/// request (or abort-all), the tick at 3 ms reports E's end to the aborted O and changes
/// nothing, and E may be started again.
#[test]
fn an_exception_sequences_start_taken_while_the_tick_aborts_its_owner() {
    for all in [false, true] {
        let setup = move || {
            let w = World::<8, 1>::new(Layout::One);
            let [o, e] = ["O", "E"].map(|n| w.seq(n));
            w.monitor(o, flag_of(true), Behaviour::AbortOwner, Some(e));
            w.start_taken(o);
            w.tick(1);
            assert_eq!((w.state(o), w.state(e)), (Running, Running));
            if all {
                w.seq.abort_all();
            } else {
                w.handle(o).abort().unwrap();
            }
            (w, o, e)
        };
        let count = sections(setup, |(w, _, _)| w.tick(2));
        every_k(count, |k| {
            let (w, o, e) = setup();
            let what = format!("abort-all {all}, k={k}");
            let taken = Rc::new(RefCell::new(None));
            let out = taken.clone();
            interleaved::at(k, move || {
                *out.borrow_mut() = Some(Port::take_start(w.seq, e, 0, Waker::noop()));
            });
            w.tick(2);
            let cause = if all { Cause::AbortAll } else { Cause::Abort };
            assert_eq!(w.ended(o), (Aborted, cause), "{what}");
            assert_eq!(w.ended(e), (Aborted, cause), "{what}");
            let taken = taken.borrow().expect("the lane ran");
            if let Some(run) = taken {
                assert_eq!(run, RunId { seq: e, count: 1 }, "{what}");
                assert_eq!(w.clearance(run), Clearance::Aborted(cause), "{what}");
            }
            w.tick(3);
            assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
            assert_eq!(w.fired(o, M0), 1, "{what}");
            assert_eq!(w.handle(e).start(), Ok(()), "{what}: E is free");
            w.check(&what);
        });
    }
}

// =======================================================================================
// 2. Pause and resume requests against a tick whose `PauseOwner` monitor holds or lets go.
// =======================================================================================

/// A request of O, by a handle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ask {
    Pause,
    Resume,
}

fn ask<const N: usize, const B: usize>(w: &World<N, B>, o: SeqId, a: Ask) -> Result<(), Error> {
    match a {
        Ask::Pause => w.handle(o).pause(),
        Ask::Resume => w.handle(o).resume(),
    }
}

/// O (5 ms timeout, started at 0) with a `PauseOwner` monitor whose condition is the
/// returned flag, set to `holds`; with `paused_by_request`, O's pause was requested. With
/// `tick`, the tick at 1 ms has paused O (by the request, or the monitor).
fn pausable<const N: usize, const B: usize>(
    layout: Layout,
    holds: bool,
    paused_by_request: bool,
    tick: bool,
) -> (World<N, B>, SeqId, &'static AtomicBool) {
    let w = World::<N, B>::new(layout);
    let o = w.timed("O", 5);
    let on = flag_of(holds);
    w.monitor(o, on, Behaviour::PauseOwner, None);
    w.start_taken(o);
    if paused_by_request {
        w.handle(o).pause().unwrap();
    }
    if tick {
        w.tick(1);
        assert_eq!(w.state(o), Paused);
    }
    (w, o, on)
}

/// Who is inserted into whom.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Into {
    /// The request (a lane of higher priority) before section `k` of the tick.
    RequestIntoTick,
    /// The tick before section `k` of the request.
    TickIntoRequest,
}

/// Runs `ask` of O and the tick at `ms` interleaved as `into` for every `k`, on worlds from
/// `setup`; then `expect(k, result, w, o, flag)`.
fn around_tick<const N: usize, const B: usize>(
    setup: impl Fn() -> (World<N, B>, SeqId, &'static AtomicBool),
    a: Ask,
    ms: u64,
    into: Into,
    expect: impl Fn(&str, Result<(), Error>, &World<N, B>, SeqId, &'static AtomicBool),
) {
    let count = match into {
        Into::RequestIntoTick => sections(&setup, |(w, _, _)| w.tick(ms)),
        // An accepted request takes three sections (check, record, queue); a refused one
        // one, and then the tick comes after it.
        Into::TickIntoRequest => 3,
    };
    every_k(count, |k| {
        let (w, o, on) = setup();
        let what = format!("{:?}, {a:?}, {into:?}, k={k}", w.layout);
        let h = w.handle(o);
        let result = match into {
            Into::RequestIntoTick => {
                let asked = Rc::new(RefCell::new(None));
                let out = asked.clone();
                interleaved::at(k, move || {
                    *out.borrow_mut() = Some(match a {
                        Ask::Pause => h.pause(),
                        Ask::Resume => h.resume(),
                    })
                });
                w.tick(ms);
                let r = asked.borrow().expect("the lane ran");
                r
            }
            Into::TickIntoRequest => {
                interleaved::at(k, move || w.tick(ms));
                let r = match a {
                    Ask::Pause => h.pause(),
                    Ask::Resume => h.resume(),
                };
                if !inserted(k) {
                    interleaved::at(usize::MAX, || {});
                    w.tick(ms);
                }
                r
            }
        };
        expect(&what, result, &w, o, on);
        w.check(&what);
    });
}

/// O's `PauseOwner` monitor holds from 1 ms; a pause of O is requested by a lane of
/// higher priority before each section of that tick. Accepted (O still running when
/// checked), the request's pause outlasts the monitor: O stays paused when the condition
/// clears (2 ms) until a resume request (applied at 4 ms); refused (`NotRunning`: the
/// monitor paused O first), O resumes when the condition clears. While the monitor holds,
/// a resume request is `HeldByMonitor`. O's clock stops while paused: its 5 ms timeout,
/// 1 ms used at the pause, runs out 4 ms after the resume, at exactly 8 ms or 6 ms.
fn pause_request_into_holding_tick<const N: usize, const B: usize>(layout: Layout) {
    around_tick(
        || pausable::<N, B>(layout, true, false, false),
        Ask::Pause,
        1,
        Into::RequestIntoTick,
        |what, asked, w, o, on| {
            assert_eq!(w.state(o), Paused, "{what}");
            assert_eq!(
                ask(w, o, Ask::Resume),
                Err(Error::HeldByMonitor(o)),
                "{what}"
            );
            on.store(false, Ordering::Relaxed);
            w.tick(2);
            w.tick(3);
            match asked {
                Ok(()) => {
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    assert_eq!(ask(w, o, Ask::Resume), Ok(()), "{what}");
                    w.tick(4);
                    assert_eq!(w.state(o), Running, "{what}: resumed");
                    assert_eq!(w.runs_until(o, 5, 20), 8, "{what}: the timeout");
                }
                Err(e) => {
                    assert_eq!(e, Error::NotRunning(o), "{what}");
                    assert_eq!(w.state(o), Running, "{what}: released");
                    assert_eq!(w.runs_until(o, 4, 20), 6, "{what}: the timeout");
                }
            }
            assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}");
            assert_eq!(w.moves(o, Running, Paused), 1, "{what}");
            assert_eq!(w.moves(o, Paused, Running), 1, "{what}");
        },
    );
}

#[test]
fn a_pause_requested_during_a_holding_tick_outlasts_the_monitor_iff_accepted() {
    pause_request_into_holding_tick::<8, 1>(Layout::One);
    pause_request_into_holding_tick::<64, 2>(Layout::Second);
}

/// O was paused by a request at 1 ms; its `PauseOwner` monitor's condition holds from
/// 2 ms. A resume of O is requested while the tick at 2 ms evaluates the monitor (`into`
/// either way). Refused (`HeldByMonitor`: the monitor held first), the request's pause
/// stays: O stays paused after the condition clears (4 ms) until a resume request
/// (applied at 6 ms). Accepted, it lifts the request's pause (carried out now or when the
/// monitor lets go): O resumes when the condition clears, at 4 ms. O's clock: 1 ms used,
/// the timeout runs out 4 ms after the resume: at exactly 8 ms or 10 ms.
fn resume_request_around_holding_tick<const N: usize, const B: usize>(layout: Layout, into: Into) {
    around_tick(
        || {
            let (w, o, on) = pausable::<N, B>(layout, false, true, true);
            on.store(true, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Resume,
        2,
        into,
        |what, asked, w, o, on| {
            assert_eq!(w.state(o), Paused, "{what}: held");
            w.tick(3);
            assert_eq!(w.state(o), Paused, "{what}: held");
            on.store(false, Ordering::Relaxed);
            w.tick(4);
            match asked {
                Ok(()) => {
                    assert_eq!(w.state(o), Running, "{what}: released");
                    assert_eq!(w.runs_until(o, 5, 20), 8, "{what}: the timeout");
                }
                Err(e) => {
                    assert_eq!(e, Error::HeldByMonitor(o), "{what}");
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    w.tick(5);
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    assert_eq!(ask(w, o, Ask::Resume), Ok(()), "{what}");
                    w.tick(6);
                    assert_eq!(w.state(o), Running, "{what}: resumed");
                    assert_eq!(w.runs_until(o, 7, 20), 10, "{what}: the timeout");
                }
            }
            assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}");
        },
    );
}

#[test]
fn a_resume_requested_during_a_holding_tick_lifts_the_requests_pause_iff_accepted() {
    resume_request_around_holding_tick::<8, 1>(Layout::One, Into::RequestIntoTick);
    resume_request_around_holding_tick::<64, 2>(Layout::Second, Into::RequestIntoTick);
}

#[test]
fn a_holding_tick_during_a_resume_request_lifts_the_requests_pause_iff_accepted() {
    resume_request_around_holding_tick::<8, 1>(Layout::One, Into::TickIntoRequest);
    resume_request_around_holding_tick::<64, 2>(Layout::Second, Into::TickIntoRequest);
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A
/// resume of O is requested around that tick (`into`): `HeldByMonitor` (before the
/// release), accepted (between the release's count and its move) or `NotPaused` (after
/// it). Whatever it was, O runs from 2 ms, resumed once; a resume carried out later finds
/// it running. Its timeout (1 ms used) runs out at exactly 6 ms.
fn resume_request_around_releasing_tick<const N: usize, const B: usize>(
    layout: Layout,
    into: Into,
) {
    around_tick(
        || {
            let (w, o, on) = pausable::<N, B>(layout, true, false, true);
            on.store(false, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Resume,
        2,
        into,
        |what, asked, w, o, _| {
            assert!(
                [
                    Ok(()),
                    Err(Error::HeldByMonitor(o)),
                    Err(Error::NotPaused(o))
                ]
                .contains(&asked),
                "{what}: {asked:?}"
            );
            assert_eq!(w.state(o), Running, "{what}: released");
            assert_eq!(w.runs_until(o, 3, 20), 6, "{what}: the timeout");
            assert_eq!(w.moves(o, Paused, Running), 1, "{what}");
        },
    );
}

#[test]
fn a_resume_requested_during_a_releasing_tick_resumes_once() {
    for into in [Into::RequestIntoTick, Into::TickIntoRequest] {
        resume_request_around_releasing_tick::<8, 1>(Layout::One, into);
        resume_request_around_releasing_tick::<64, 2>(Layout::Second, into);
    }
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A pause
/// of O is requested around that tick (`into`): refused (`NotRunning`, O still paused) or
/// accepted (after the release). Accepted, it pauses O at 3 ms (the next tick) until a
/// resume request (applied at 5 ms): the timeout (2 ms used) runs out at exactly 8 ms;
/// refused, O runs from 2 ms and its timeout runs out at 6 ms.
fn pause_request_around_releasing_tick<const N: usize, const B: usize>(layout: Layout, into: Into) {
    around_tick(
        || {
            let (w, o, on) = pausable::<N, B>(layout, true, false, true);
            on.store(false, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Pause,
        2,
        into,
        |what, asked, w, o, _| {
            assert_eq!(w.state(o), Running, "{what}: released");
            match asked {
                Ok(()) => {
                    w.tick(3);
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    w.tick(4);
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    assert_eq!(ask(w, o, Ask::Resume), Ok(()), "{what}");
                    w.tick(5);
                    assert_eq!(w.state(o), Running, "{what}: resumed");
                    assert_eq!(w.runs_until(o, 6, 20), 8, "{what}: the timeout");
                }
                Err(e) => {
                    assert_eq!(e, Error::NotRunning(o), "{what}");
                    assert_eq!(w.runs_until(o, 3, 20), 6, "{what}: the timeout");
                }
            }
            assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}");
        },
    );
}

#[test]
fn a_pause_requested_during_a_releasing_tick_pauses_iff_accepted() {
    for into in [Into::RequestIntoTick, Into::TickIntoRequest] {
        pause_request_around_releasing_tick::<8, 1>(Layout::One, into);
        pause_request_around_releasing_tick::<64, 2>(Layout::Second, into);
    }
}

// =======================================================================================
// 3. Joins against the end, abort and restart of the joined run.
// =======================================================================================

/// A joiner: its sequence, the run it joined (set at its first poll), its lane's counting
/// waker.
struct Joiner {
    id: SeqId,
    run: Option<u16>,
    wakes: Arc<Count>,
}

impl Joiner {
    /// `id` (registered, with a lane) is started and its lane takes the start with a
    /// counting waker: the waker a release wakes.
    fn started<const N: usize, const B: usize>(w: &World<N, B>, id: SeqId) -> Joiner {
        let (waker, wakes) = counting();
        w.handle(id).start().unwrap();
        Port::take_start(w.seq, id, 0, &waker).unwrap();
        Joiner {
            id,
            run: None,
            wakes,
        }
    }

    fn poll<const N: usize, const B: usize>(
        &mut self,
        w: &World<N, B>,
        target: SeqId,
    ) -> Poll<Result<Outcome, Error>> {
        Port::join(w.seq, self.id, target, &mut self.run)
    }

    /// What an executor does after a poll that began at `wakes_before` wake-ups and gave
    /// `polled`: a `Pending` poll during which the waker was woken is polled again (once
    /// more for each wake-up meanwhile).
    fn repoll<const N: usize, const B: usize>(
        &mut self,
        w: &World<N, B>,
        target: SeqId,
        mut wakes_before: usize,
        mut polled: Poll<Result<Outcome, Error>>,
    ) -> Poll<Result<Outcome, Error>> {
        while polled.is_pending() && woken(&self.wakes) > wakes_before {
            wakes_before = woken(&self.wakes);
            polled = self.poll(w, target);
        }
        polled
    }

    fn joining<const N: usize, const B: usize>(&self, w: &World<N, B>) -> bool {
        w.in_set(Set::Joining, self.id)
    }

    /// After a `Pending` poll: the joined run ended since (`wakes_before` wake-ups then),
    /// so the joiner was released and woken; its next poll is ready.
    fn released<const N: usize, const B: usize>(
        &mut self,
        w: &World<N, B>,
        target: SeqId,
        wakes_before: usize,
        what: &str,
    ) -> Result<Outcome, Error> {
        assert!(!self.joining(w), "{what}: {:?} not released", self.id);
        assert!(
            woken(&self.wakes) > wakes_before,
            "{what}: {:?} not woken",
            self.id
        );
        match self.poll(w, target) {
            Poll::Ready(r) => {
                assert!(!self.joining(w), "{what}");
                r
            }
            Poll::Pending => panic!("{what}: {:?} still pending after its release", self.id),
        }
    }
}

/// What O's lane (of higher priority) does, inserted into a join.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Then {
    /// Ends O's run (completed).
    End,
    /// Ends it, and O is started again by a handle (run 2, not taken yet).
    EndAndStart,
    /// Ends it, O is started again and run 2 ends too (skipped).
    EndTwice,
}

fn end_and_then<const N: usize, const B: usize>(w: &World<N, B>, o: SeqId, then: Then) {
    assert!(w.complete(o));
    if then != Then::End {
        w.handle(o).start().unwrap();
    }
    if then == Then::EndTwice {
        w.take(o);
        assert!(w.end(o, Outcome::Skipped));
    }
}

/// O runs (run 1); J2 (with `two`) has joined run 1 (pending). J1's first poll of its join
/// of O comes with O's lane doing `then` before section `k`. J1 joins the run current at
/// its first look (semantics 14: never a later one): run 1, ended (`Completed`), or run 2,
/// under way (pending, then `Skipped` once it ends: J1 is released and woken) or ended
/// (`Skipped`). J2, woken by run 1's end, gets run 1's outcome while run 1 is the last run
/// or the one before the run under way, else `OutcomeLost` (run 2 ended before J2 was
/// polled). With `k` = the count, the end comes after J1's pending first poll: J1 is as J2.
fn join_during_end<const N: usize, const B: usize>(layout: Layout, two: bool, then: Then) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let j2 = w.seq("J2");
        w.split();
        let [o, j1] = ["O", "J1"].map(|n| w.seq(n));
        w.start_taken(o);
        let mut joiners = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        if two {
            assert_eq!(joiners[1].poll(&w, o), Poll::Pending);
        }
        (w, o, joiners)
    };
    // The sections of J1's first poll.
    let count = {
        let (w, o, mut js) = setup();
        interleaved::at(usize::MAX, || {});
        assert_eq!(js[0].poll(&w, o), Poll::Pending);
        interleaved::taken()
    };
    every_k(count + 1, |k| {
        let (w, o, [mut j1, mut j2]) = setup();
        let what = format!("{layout:?}, two {two}, {then:?}, k={k}");
        let j2_wakes = woken(&j2.wakes);
        interleaved::at(k, move || end_and_then(&w, o, then));
        let j1_wakes = woken(&j1.wakes);
        let first = j1.poll(&w, o);
        let after = !inserted(k);
        if after {
            interleaved::at(usize::MAX, || {});
        }
        // A release during the poll (of run 1, before the look found run 2) wakes J1: its
        // executor polls it again.
        let first = j1.repoll(&w, o, j1_wakes, first);
        let lost_or = |outcome| match then {
            Then::EndTwice => Err(Error::OutcomeLost(o)),
            _ => Ok(outcome),
        };
        // J2, woken by run 1's end, is polled once O's lane is done.
        let mut j2_check = |w: &World<N, B>| {
            if two {
                let r = j2.released(w, o, j2_wakes, &what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J2");
            }
        };
        if !after {
            j2_check(&w);
        }
        if after {
            assert_eq!(first, Poll::Pending, "{what}");
            let before = woken(&j1.wakes);
            end_and_then(&w, o, then);
            assert_eq!(
                j1.released(&w, o, before, &what),
                lost_or(Outcome::Completed),
                "{what}: J1"
            );
            j2_check(&w);
        } else {
            match then {
                Then::End => assert_eq!(first, Poll::Ready(Ok(Outcome::Completed)), "{what}"),
                Then::EndTwice => {
                    assert_eq!(first, Poll::Ready(Ok(Outcome::Skipped)), "{what}")
                }
                Then::EndAndStart => {
                    assert_eq!(first, Poll::Pending, "{what}: J1 joined run 2");
                    assert_eq!(j1.run, Some(2), "{what}");
                    let before = woken(&j1.wakes);
                    w.take(o);
                    assert!(w.end(o, Outcome::Skipped));
                    assert_eq!(
                        j1.released(&w, o, before, &what),
                        Ok(Outcome::Skipped),
                        "{what}: J1"
                    );
                }
            }
            assert!(!j1.joining(&w), "{what}");
        }
        w.check(&what);
    });
}

#[test]
fn a_join_during_the_end_of_the_joined_run_gets_its_outcome_or_outcome_lost() {
    for two in [false, true] {
        for then in [Then::End, Then::EndAndStart, Then::EndTwice] {
            join_during_end::<8, 1>(Layout::One, two, then);
            join_during_end::<64, 2>(Layout::Split, two, then);
        }
    }
}

/// What the tick at 1 ms does to the joined run of O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum JoinTick {
    /// O's `AbortOwner` monitor.
    Abort,
    /// An abort request of O.
    Request,
    /// O's `RestartOwner` monitor: the run goes on (O's lane restarts it), then completes.
    Restart,
}

/// O runs; J2 has joined O's run (pending). J1 polls its join of O and the tick at 1 ms
/// `tick`s O, interleaved `into` either way (the tick before each section of J1's poll; J1's
/// poll, a lane of higher priority, before each section of the tick). Every joiner gets
/// the outcome of the run it joined, never hangs: an abort's `Aborted(cause)` (at once, or
/// released and woken, then ready); a restart does not end the run: both wait, and get
/// `Completed` when O's lane, having restarted it, completes it.
fn join_around_tick<const N: usize, const B: usize>(layout: Layout, tick: JoinTick, into: Into) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let [j1, j2] = ["J1", "J2"].map(|n| w.seq(n));
        match tick {
            JoinTick::Abort => {
                w.monitor(o, flag_of(true), Behaviour::AbortOwner, None);
            }
            JoinTick::Restart => {
                w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
            }
            JoinTick::Request => {}
        }
        w.start_taken(o);
        if tick == JoinTick::Request {
            w.handle(o).abort().unwrap();
        }
        let mut joiners = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        assert_eq!(joiners[1].poll(&w, o), Poll::Pending);
        (w, o, joiners)
    };
    let count = match into {
        Into::TickIntoRequest => sections(setup, |(w, o, js)| {
            let mut run = None;
            let _ = Port::join(w.seq, js[0].id, *o, &mut run);
        }),
        Into::RequestIntoTick => sections(setup, |(w, _, _)| w.tick(1)),
    };
    every_k(count, |k| {
        let (w, o, [j1, mut j2]) = setup();
        let what = format!("{layout:?}, {tick:?}, {into:?}, k={k}");
        let j2_wakes = woken(&j2.wakes);
        let j1 = Rc::new(RefCell::new(j1));
        let first = match into {
            Into::TickIntoRequest => {
                interleaved::at(k, move || w.tick(1));
                let first = j1.borrow_mut().poll(&w, o);
                assert!(inserted(k), "{what}");
                first
            }
            Into::RequestIntoTick => {
                let polled = Rc::new(RefCell::new(None));
                let (out, j) = (polled.clone(), j1.clone());
                interleaved::at(k, move || {
                    *out.borrow_mut() = Some(j.borrow_mut().poll(&w, o));
                });
                w.tick(1);
                let first = polled.borrow_mut().take().expect("the lane ran");
                first
            }
        };
        let mut j1 = j1.borrow_mut();
        let j1_wakes = woken(&j1.wakes);
        let cause = match tick {
            JoinTick::Abort => M0,
            JoinTick::Request => Cause::Abort,
            JoinTick::Restart => M0,
        };
        match tick {
            JoinTick::Abort | JoinTick::Request => {
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                let expected = Ok(Outcome::Aborted(cause));
                match first {
                    Poll::Ready(r) => assert_eq!(r, expected, "{what}: J1"),
                    Poll::Pending => {
                        // Pending at a look before the abort: released and woken by it.
                        assert!(!j1.joining(&w), "{what}: J1 not released");
                        let r = j1.poll(&w, o);
                        assert_eq!(r, Poll::Ready(expected), "{what}: J1");
                    }
                }
                let r = j2.released(&w, o, j2_wakes, &what);
                assert_eq!(r, expected, "{what}: J2");
            }
            JoinTick::Restart => {
                assert_eq!(w.ended(o), (Restarting, cause), "{what}");
                assert_eq!(first, Poll::Pending, "{what}: J1");
                assert_eq!(j1.run, Some(1), "{what}");
                // A restart is the same run: both still wait.
                assert!(j1.joining(&w) && j2.joining(&w), "{what}");
                assert_eq!(j2.poll(&w, o), Poll::Pending, "{what}: J2");
                let j2_wakes = woken(&j2.wakes);
                w.seq.restart(w.run(o));
                assert_eq!(w.state(o), Running, "{what}");
                assert!(w.complete(o), "{what}");
                let r = j1.released(&w, o, j1_wakes, &what);
                assert_eq!(r, Ok(Outcome::Completed), "{what}: J1");
                let r = j2.released(&w, o, j2_wakes, &what);
                assert_eq!(r, Ok(Outcome::Completed), "{what}: J2");
            }
        }
        w.check(&what);
    });
}

#[test]
fn a_join_around_a_tick_that_ends_or_restarts_the_joined_run_gets_its_outcome() {
    for tick in [JoinTick::Abort, JoinTick::Request, JoinTick::Restart] {
        for into in [Into::TickIntoRequest, Into::RequestIntoTick] {
            join_around_tick::<8, 1>(Layout::One, tick, into);
            join_around_tick::<64, 2>(Layout::Split, tick, into);
        }
    }
}

/// O runs; J2 has joined O's run (pending). O's run is dropped (`Port::abandon`, its
/// future dropped) while J1 polls its join of O, a lane of higher priority, before each
/// section of the teardown. Both get `Aborted(Dropped)`; a pending one was released and
/// woken.
#[test]
fn a_join_during_a_dropped_runs_teardown_gets_aborted_dropped() {
    let setup = || {
        let w = World::<8, 1>::new(Layout::One);
        let [o, j1, j2] = ["O", "J1", "J2"].map(|n| w.seq(n));
        w.start_taken(o);
        let mut joiners = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        assert_eq!(joiners[1].poll(&w, o), Poll::Pending);
        (w, o, joiners)
    };
    let count = sections(setup, |(w, o, _)| Port::abandon(w.seq, *o, &()));
    every_k(count, |k| {
        let (w, o, [j1, mut j2]) = setup();
        let what = format!("k={k}");
        let j2_wakes = woken(&j2.wakes);
        let j1 = Rc::new(RefCell::new(j1));
        let polled = Rc::new(RefCell::new(None));
        let (out, j) = (polled.clone(), j1.clone());
        interleaved::at(k, move || {
            *out.borrow_mut() = Some(j.borrow_mut().poll(&w, o));
        });
        Port::abandon(w.seq, o, &());
        let first = polled.borrow_mut().take().expect("the lane ran");
        let expected = Ok(Outcome::Aborted(Cause::Dropped));
        let mut j1 = j1.borrow_mut();
        match first {
            Poll::Ready(r) => assert_eq!(r, expected, "{what}"),
            Poll::Pending => {
                assert!(!j1.joining(&w), "{what}: J1 not released");
                assert_eq!(j1.poll(&w, o), Poll::Ready(expected), "{what}");
            }
        }
        assert_eq!(j2.released(&w, o, j2_wakes, &what), expected, "{what}");
        w.check(&what);
    });
}

// =======================================================================================
// 4. Sequencers of two words: the key scenarios of `interleavings.rs` again.
// =======================================================================================

/// An abort-all is requested while nothing runs; G (a main sequence) is started by a lane
/// of higher priority before section `k` of the tick at 1 ms that carries the abort-all
/// out. When G's start commits before the tick has finished looking for what to abort,
/// G runs when it looks: the tick must abort it (`AbortAll`, recorded), as it does a
/// start made during the walk of an abort-all while another sequence runs
/// (`a_start_during_the_shortcut_walk_of_an_abort_all_is_torn_down`). A start after the
/// look runs.
fn start_into_lone_abort_all<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let g = w.seq("G");
        w.seq.abort_all();
        (w, g)
    };
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, g) = setup();
        let what = format!("{layout:?}, k={k}");
        let h = w.handle(g);
        interleaved::at(k, move || h.start().unwrap());
        w.tick(1);
        assert!(inserted(k), "{what}");
        // The tick's first section, then the abort-all's look: one section, one probe per
        // candidate (with one word every registered sequence; with two the live and
        // changed ones: none before G's start), and the count of runs begun read again. A
        // start after the look is a start after the abort-all, and runs.
        let looked = 2 + if B == 1 { w.count() } else { 0 };
        if k <= looked {
            assert_eq!(w.ended(g), (Aborted, Cause::AbortAll), "{what}: G");
        } else {
            assert_eq!(w.state(g), Running, "{what}: G started after the abort-all");
        }
        w.check(&what);
    });
}

#[test]
fn a_start_during_a_tick_that_carries_out_an_abort_all_with_nothing_running_is_aborted() {
    start_into_lone_abort_all::<64, 2>(Layout::Second);
    start_into_lone_abort_all::<8, 1>(Layout::One);
}

/// How the tick is made to tear R's tree down.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Teardown {
    Request,
    AbortAll,
    Monitor,
}

/// R (main, in the first word with `Layout::Split`) started Y non-blocking, Y runs X
/// blocking (in Y's lane); G is registered; Y, X, G in the second word (with
/// `Layout::Second` all are). With `deep` false only R runs. A tick folds the tree; the
/// teardown `how` is set up for the tick at 1 ms.
fn tree<const N: usize, const B: usize>(
    layout: Layout,
    how: Teardown,
    deep: bool,
) -> (World<N, B>, [SeqId; 4]) {
    let w = World::<N, B>::new(layout);
    let r = w.seq("R");
    w.split();
    let [y, x, g] = ["Y", "X", "G"].map(|n| w.seq(n));
    if how == Teardown::Monitor {
        w.monitor(r, flag_of(true), Behaviour::AbortOwner, None);
    }
    w.start_taken(r);
    if deep {
        Port::start_in_lane(w.seq, y, Some(w.run(r))).unwrap();
        w.take(y);
        w.seq
            .begin(
                x,
                Some(w.run(y)),
                Mode::Blocking { maker: 0 },
                Cause::Start,
                0,
            )
            .unwrap();
    }
    w.tick(0);
    match how {
        Teardown::Request => w.handle(r).abort().unwrap(),
        Teardown::AbortAll => w.seq.abort_all(),
        Teardown::Monitor => {}
    }
    (w, [r, y, x, g])
}

/// `interleavings.rs`'s `lane_start_into_teardown` in two words: before section `k` of
/// the tick that tears R's tree down, a lane of higher priority (Y's when `deep`, else
/// R's) starts G in G's lane. G is refused (`NotRunning`) or aborted with the tree.
fn lane_start_into_teardown<const N: usize, const B: usize>(
    layout: Layout,
    how: Teardown,
    deep: bool,
) {
    let count = sections(|| tree::<N, B>(layout, how, deep), |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, [r, y, x, g]) = tree::<N, B>(layout, how, deep);
        let starter = if deep { y } else { r };
        let result = Rc::new(RefCell::new(None));
        let out = result.clone();
        interleaved::at(k, move || {
            let by = Some(w.run(starter));
            *out.borrow_mut() = Some(Port::start_in_lane(w.seq, g, by));
        });
        w.tick(1);
        let what = format!("{layout:?}, {how:?}, deep {deep}, k={k}");
        let cause = match how {
            Teardown::Request => Cause::Abort,
            Teardown::AbortAll => Cause::AbortAll,
            Teardown::Monitor => M0,
        };
        let torn: &[SeqId] = if deep { &[r, y, x] } else { &[r] };
        for &id in torn {
            assert_eq!(w.ended(id), (Aborted, cause), "{what}: {id:?}");
        }
        match *result.borrow() {
            Some(Ok(())) => assert_eq!(w.ended(g), (Aborted, cause), "{what}: G"),
            Some(Err(e)) => {
                assert_eq!(e, Error::NotRunning(starter), "{what}");
                assert_eq!(w.state(g), Idle, "{what}");
            }
            None => panic!("{what}: the lane did not run"),
        }
        w.check(&what);
    });
}

#[test]
fn a_start_below_a_caller_the_tick_tears_down_is_torn_down_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for how in [Teardown::Request, Teardown::AbortAll, Teardown::Monitor] {
            for deep in [true, false] {
                lane_start_into_teardown::<64, 2>(layout, how, deep);
            }
        }
    }
}

/// What fires on O in the tick at 1 ms, for `end_into_firing_tick`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Firing {
    /// A monitor, `AbortOwner`, exception sequence E.
    AbortAfterE,
    /// A monitor, `RestartOwner`, exception sequence E.
    RestartAfterE,
    /// A monitor, `RestartOwner`.
    Restart,
    /// O's 1 ms timeout (`AbortOwner`).
    Timeout,
}

/// O's lane, of higher priority than the tick, ends O's run (completed) before section `k`
/// of the tick at 1 ms in which `firing` fires on O. Either the end comes first (O
/// `Terminated`, nothing fired, E never started) or the firing does: the end is refused;
/// with E, E runs to its end and the next tick applies O's behaviour, once (one `Fired`,
/// one transition to the behaviour's state).
fn end_into_firing_tick<const N: usize, const B: usize>(layout: Layout, firing: Firing) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let e = w.seq("E");
        w.split();
        let o = match firing {
            Firing::Timeout => w.timed("O", 1),
            _ => w.seq("O"),
        };
        match firing {
            Firing::AbortAfterE => {
                w.monitor(o, flag_of(true), Behaviour::AbortOwner, Some(e));
            }
            Firing::RestartAfterE => {
                w.monitor(o, flag_of(true), Behaviour::RestartOwner, Some(e));
            }
            Firing::Restart => {
                w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
            }
            Firing::Timeout => {}
        }
        w.start_taken(o);
        (w, o, e)
    };
    let count = sections(setup, |(w, _, _)| w.tick(1));
    every_k(count, |k| {
        let (w, o, e) = setup();
        let ended = Rc::new(RefCell::new(None));
        let out = ended.clone();
        interleaved::at(k, move || *out.borrow_mut() = Some(w.complete(o)));
        w.tick(1);
        let what = format!("{layout:?}, {firing:?}, k={k}");
        let ended = ended.borrow().expect("the lane ran");
        let cause = match firing {
            Firing::Timeout => Cause::Timeout(o),
            _ => M0,
        };
        if ended {
            assert_eq!(w.state(o), Terminated, "{what}");
            assert_eq!(w.state(e), Idle, "{what}: E");
            assert_eq!(w.fired(o, cause), 0, "{what}");
            w.check(&what);
            return;
        }
        if matches!(firing, Firing::AbortAfterE | Firing::RestartAfterE) {
            assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
            assert!(!w.complete(o), "{what}: O holds");
            w.take(e);
            assert!(w.complete(e), "{what}");
            w.tick(2);
        }
        let (to, n) = match firing {
            Firing::AbortAfterE | Firing::Timeout => (Aborted, w.moves(o, Aborting, Aborted)),
            Firing::RestartAfterE | Firing::Restart => {
                (Restarting, w.moves(o, Running, Restarting))
            }
        };
        assert_eq!(w.ended(o), (to, cause), "{what}");
        assert_eq!((n, w.fired(o, cause)), (1, 1), "{what}: once");
        w.tick(3);
        assert_eq!(w.ended(o), (to, cause), "{what}: after");
        w.check(&what);
    });
}

#[test]
fn an_end_during_a_firing_is_either_first_or_refused_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for firing in [
            Firing::AbortAfterE,
            Firing::RestartAfterE,
            Firing::Restart,
            Firing::Timeout,
        ] {
            end_into_firing_tick::<64, 2>(layout, firing);
        }
    }
}

#[test]
fn an_end_during_a_restarting_firing_with_an_exception_sequence_is_either_first_or_refused() {
    end_into_firing_tick::<8, 1>(Layout::One, Firing::RestartAfterE);
}

/// `interleavings.rs`'s `tick_into_start` in two words: O (first word with
/// `Layout::Split`) starts C (second word), in C's lane or blocking, while the tick at
/// 1 ms aborts O (its monitor, an abort request) or restarts it. C is refused
/// (`NotRunning(O)`, never ran) or torn down with O.
fn tick_into_start<const N: usize, const B: usize>(layout: Layout, fire: Teardown, blocking: bool) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let c = w.timed("C", 5);
        match fire {
            Teardown::Monitor => {
                w.monitor(o, flag_of(true), Behaviour::AbortOwner, None);
            }
            Teardown::AbortAll => {
                w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
            }
            Teardown::Request => {}
        }
        w.start_taken(o);
        if fire == Teardown::Request {
            w.handle(o).abort().unwrap();
        }
        (w, o, c)
    };
    let start = move |w: &World<N, B>, o: SeqId, c: SeqId| {
        let by = Some(w.run(o));
        if blocking {
            w.seq
                .begin(c, by, Mode::Blocking { maker: 0 }, Cause::Start, 0)
                .map(|_| ())
        } else {
            Port::start_in_lane(w.seq, c, by)
        }
    };
    let count = sections(setup, |(w, o, c)| {
        let _ = start(w, *o, *c);
    });
    every_k(count, |k| {
        let (w, o, c) = setup();
        interleaved::at(k, move || w.tick(1));
        let started = start(&w, o, c);
        assert!(inserted(k), "the tick ran");
        // `AbortAll` stands for the restart here.
        let owner = match fire {
            Teardown::Monitor => (Aborted, M0),
            Teardown::Request => (Aborted, Cause::Abort),
            Teardown::AbortAll => (Restarting, M0),
        };
        let what = format!("{layout:?}, {fire:?}, blocking {blocking}, k={k}");
        assert_eq!(w.ended(o), owner, "{what}");
        match started {
            Ok(()) => assert_eq!(w.ended(c), (Aborted, owner.1), "{what}"),
            Err(e) => {
                assert_eq!(e, Error::NotRunning(o), "{what}");
                assert_eq!(w.state(c), Idle, "{what}");
            }
        }
        w.check(&what);
    });
}

#[test]
fn a_start_by_a_sequence_the_tick_aborts_or_restarts_never_outlives_it_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for fire in [Teardown::Monitor, Teardown::Request, Teardown::AbortAll] {
            for blocking in [false, true] {
                tick_into_start::<64, 2>(layout, fire, blocking);
            }
        }
    }
}

// =======================================================================================
// 5. Exception sequences: the end of E reported to its owner exactly once.
// =======================================================================================

/// O's `RestartOwner` monitor M0 restarted O at 1 ms; its `AbortOwner` monitor M1 with
/// exception sequence E holds from 2 ms. O's lane obeys `Restart` (`Sequencer::restart`)
/// with the tick at 2 ms before section `k`. Wherever the tick lands, the restart commits
/// after it (a `Restarting` O is not evaluated at 2 ms), M1 fires once, at 3 ms, on the
/// restarted run, E runs once for O, and once E's end is folded O is aborted by M1, once.
fn restart_into_firing_tick<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let e = w.seq("E");
        w.split();
        let o = w.seq("O");
        let (f0, f1) = (flag_of(true), flag_of(false));
        assert_eq!(w.monitor(o, f0, Behaviour::RestartOwner, None), M0);
        assert_eq!(w.monitor(o, f1, Behaviour::AbortOwner, Some(e)), M1);
        w.start_taken(o);
        w.tick(1);
        assert_eq!(w.ended(o), (Restarting, M0));
        f0.store(false, Ordering::Relaxed);
        f1.store(true, Ordering::Relaxed);
        (w, o, e, w.run(o))
    };
    let count = sections(setup, |(w, _, _, run)| w.seq.restart(*run));
    every_k(count, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        assert!(inserted(k), "{what}");
        assert_eq!(w.state(o), Running, "{what}");
        // The tick came before the restart's commit (the count of changes moved: it
        // scheduled again), so it did not evaluate the `Restarting` O: M1 fires at 3 ms.
        assert_eq!(w.state(e), Idle, "{what}");
        let ms = 3;
        w.tick(ms);
        assert_eq!(
            (w.state(o), w.state(e)),
            (Running, Running),
            "{what}: E for O"
        );
        assert_eq!(w.clearance(w.run(o)), Clearance::Hold, "{what}: O holds");
        w.take(e);
        assert!(w.complete(e), "{what}");
        w.tick(ms + 1);
        assert_eq!(w.ended(o), (Aborted, M1), "{what}");
        w.tick(ms + 2);
        assert_eq!(w.ended(o), (Aborted, M1), "{what}");
        assert_eq!(w.fired(o, M1), 1, "{what}");
        assert_eq!(w.moves(e, Idle, Running), 1, "{what}: E ran once");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_restart_during_a_tick_that_fires_an_exception_sequence_is_handled_once() {
    restart_into_firing_tick::<8, 1>(Layout::One);
    restart_into_firing_tick::<64, 2>(Layout::Split);
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E runs (taken). An
/// abort of E was requested; the tick at 2 ms carries it out, and E's lane, of higher
/// priority, ends E (completed) before section `k` of that tick. E ends once (completed,
/// or aborted by the request), its end is reported to O once, and O's behaviour is
/// applied once, by the tick at 3 ms at the latest: O aborted (or restarting) by the
/// monitor; E is free again.
fn end_of_e_into_its_abort<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let e = w.seq("E");
        w.monitor(o, flag_of(true), behaviour, Some(e));
        w.start_taken(o);
        w.tick(1);
        assert_eq!((w.state(o), w.state(e)), (Running, Running));
        w.take(e);
        w.handle(e).abort().unwrap();
        (w, o, e)
    };
    let count = sections(setup, |(w, _, _)| w.tick(2));
    every_k(count, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        let ended = Rc::new(RefCell::new(None));
        let out = ended.clone();
        interleaved::at(k, move || *out.borrow_mut() = Some(w.complete(e)));
        w.tick(2);
        let ended = ended.borrow().expect("the lane ran");
        if ended {
            assert_eq!(w.state(e), Terminated, "{what}");
        } else {
            assert_eq!(w.ended(e), (Aborted, Cause::Abort), "{what}");
        }
        w.tick(3);
        let to = match behaviour {
            Behaviour::RestartOwner => Restarting,
            _ => Aborted,
        };
        assert_eq!(w.ended(o), (to, M0), "{what}");
        assert_eq!(w.fired(o, M0), 1, "{what}");
        let moved = w.moves(o, Running, Restarting) + w.moves(o, Aborting, Aborted);
        assert_eq!(moved, 1, "{what}: the behaviour once");
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        assert!(!w.has(o, flag::EXCEPTION_DONE), "{what}");
        w.tick(4);
        assert_eq!(w.ended(o), (to, M0), "{what}: after");
        assert_eq!(w.handle(e).start(), Ok(()), "{what}: E is free");
        w.check(&what);
    });
}

#[test]
fn an_exception_sequence_ending_while_the_tick_aborts_it_is_reported_once() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        end_of_e_into_its_abort::<8, 1>(Layout::One, behaviour);
        end_of_e_into_its_abort::<64, 2>(Layout::Second, behaviour);
        end_of_e_into_its_abort::<64, 2>(Layout::Split, behaviour);
    }
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E ran to its end.
/// The tick at 2 ms reports E's end to O and applies the behaviour; O's run is dropped
/// (`Port::abandon`: its future dropped, a lane of higher priority) before section `k` of
/// that tick. O is aborted once: by the drop (`Dropped`), or, when the tick's abort came
/// first, by the monitor; a restart by the tick is followed by the drop's abort.
fn drop_into_report<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let e = w.seq("E");
        w.split();
        let o = w.seq("O");
        w.monitor(o, flag_of(true), behaviour, Some(e));
        w.start_taken(o);
        w.tick(1);
        w.take(e);
        assert!(w.complete(e));
        (w, o, e)
    };
    let count = sections(setup, |(w, _, _)| w.tick(2));
    every_k(count, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || Port::abandon(w.seq, o, &()));
        w.tick(2);
        assert!(inserted(k), "{what}");
        let (state, cause) = w.ended(o);
        assert_eq!(state, Aborted, "{what}");
        let allowed: &[Cause] = match behaviour {
            Behaviour::AbortOwner => &[Cause::Dropped, M0],
            _ => &[Cause::Dropped],
        };
        assert!(allowed.contains(&cause), "{what}: {cause:?}");
        w.tick(3);
        assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        assert_eq!(w.state(e), Terminated, "{what}");
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_dropped_owner_during_the_report_of_its_exception_sequences_end_is_aborted_once() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        drop_into_report::<8, 1>(Layout::One, behaviour);
        drop_into_report::<64, 2>(Layout::Split, behaviour);
    }
}
