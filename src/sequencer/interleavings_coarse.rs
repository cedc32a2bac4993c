//! Systematic interleavings under a coarse lock: the path production firmware runs.
//!
//! With RTIC's priority ceiling (`PriorityCeiling` below the top priority, `Lock::COARSE`)
//! each operation's steps run in one section (`in_sections!`), and the tick runs at the
//! ceiling: no lane runs during the tick, but the tick may preempt a lane's operation
//! between two of its sections (the two sections of `Sequencer::begin`, a teardown's
//! `leave` and its cleanup hook, a join's registration and its look, ...). Above the
//! ceiling only `abort_all` (an atomic) is called, at any time.
//!
//! Each test counts the sections of one lane operation under the test lock
//! [`InterleavedCoarse`] (the coarse twin of `Interleaved`), then, for every section `k`
//! (and, where it says so, after the last one), builds a fresh sequencer and runs the
//! operation with the tick inserted right before section `k`; or inserts `abort_all`
//! before section `k` of a tick. It asserts the exact outcome the semantics
//! (docs/semantics.md) demand and the invariants of [`World::check`]. The scenarios are
//! those of `interleavings.rs` and `interleavings_more.rs` that a coarse lock allows, in
//! sequencers of one word and of two.
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
use std::string::String;
use std::sync::Arc;
use std::task::Wake;
use std::vec::Vec;

use crate::lock::interleaved::{self, InterleavedCoarse};
use crate::lock::Lock;
use crate::model::id::RunId;
use crate::sequencer::control_block::flag;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::sequencer::transition::Clearance;
use crate::trace::{Record, Transition};
use crate::{
    Behaviour, Cause, Condition, Duration, Error, Event, Failure, Instant, Monitor, MonitorId,
    Monitors, Outcome, RunningState, SeqConfig, SeqId, Sequencer,
};

use RunningState::{Aborted, Aborting, Idle, Paused, Restarting, Running, Terminated};

/// A sequencer under lock `L`: `N` sequences in `B` words of 32, a trace no scenario
/// overflows.
type Sq<L, const N: usize, const B: usize> = Sequencer<(), N, 256, L, 8, B>;

/// The world every test here uses: the coarse interleaving lock.
type Cw<const N: usize, const B: usize> = World<InterleavedCoarse, N, B>;

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

/// A sequencer under lock `L`, the monitor table its ticks use and the records drained so
/// far, all `'static` so that a closure run between two sections can tick.
struct World<L: Lock + 'static, const N: usize, const B: usize> {
    seq: &'static Sq<L, N, B>,
    monitors: &'static RefCell<Monitors<'static, (), 4>>,
    log: &'static RefCell<Vec<Record>>,
    layout: Layout,
}

impl<L: Lock + 'static, const N: usize, const B: usize> Clone for World<L, N, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lock + 'static, const N: usize, const B: usize> Copy for World<L, N, B> {}

impl<L: Lock + 'static, const N: usize, const B: usize> World<L, N, B> {
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

    /// `run`'s lane ends it with `outcome` and reports it over.
    fn end_run(&self, run: RunId, outcome: Outcome) -> bool {
        let ended = Port::end(self.seq, run, outcome);
        if ended {
            Port::finished(self.seq, run);
        }
        ended
    }

    /// `id`'s lane ends its current run with `outcome` and reports it over.
    fn end(&self, id: SeqId, outcome: Outcome) -> bool {
        self.end_run(self.run(id), outcome)
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

    /// The transitions of `id` so far.
    fn transitions(&self, id: SeqId) -> Vec<Transition> {
        self.records()
            .iter()
            .filter_map(Record::transition)
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

    /// The `AbortAll` records.
    fn aborts_all(&self) -> usize {
        self.records()
            .iter()
            .filter(|r| matches!(r.event(), Some(Event::AbortAll { .. })))
            .count()
    }

    /// The invariants of every interleaving: no sequence under way (running, paused,
    /// restarting) has an aborted caller up its caller links, nor a terminated direct
    /// caller it blocks (a non-blocking child may outlive a caller that ended, semantics
    /// 11, never one that was aborted); the trace's transitions chain (each `from` is the
    /// sequence's last `to`, from `Idle`), are allowed changes and end in each sequence's
    /// current state; no exception sequence refused. `what` names the interleaving.
    fn check(&self, what: &str) {
        let count = self.count();
        for i in 0..count {
            let id = SeqId::from_index(i);
            if ![Running, Paused, Restarting].contains(&self.state(id)) {
                continue;
            }
            let blocking = self.seq.with(|s| s.block(id).unwrap().lane)
                == self.seq.with(|s| {
                    let c = s.block(id).unwrap().caller.get();
                    c.map_or(u8::MAX, |c| s.block(c).unwrap().lane)
                });
            let mut at = self.seq.with(|s| s.block(id).unwrap().caller.get());
            let mut first = true;
            for _ in 0..crate::MAX_DEPTH {
                let Some(c) = at else { break };
                assert_ne!(
                    self.state(c),
                    Aborted,
                    "{what}: {id:?} is {:?} below aborted {c:?}",
                    self.state(id)
                );
                if first && blocking {
                    assert_ne!(
                        self.state(c),
                        Terminated,
                        "{what}: {id:?} is {:?} blocking in terminated {c:?}",
                        self.state(id)
                    );
                }
                first = false;
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

/// The sections `op` takes, undisturbed, on a fresh world from `setup` (with a coarse
/// lock an operation may take a single one).
fn sections<S>(setup: impl Fn() -> S, op: impl Fn(&S)) -> usize {
    let s = setup();
    interleaved::at(usize::MAX, || {});
    op(&s);
    let n = interleaved::taken();
    assert!(n >= 1, "{n} sections");
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
    // Nothing left for the next test on this thread.
    interleaved::at(usize::MAX, || {});
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

/// After an operation with something inserted before section `k`: if the operation took
/// fewer sections, the insertion is disarmed and runs now (after the operation). Returns
/// whether it came after.
fn or_after(k: usize, then: impl FnOnce()) -> bool {
    if inserted(k) {
        return false;
    }
    interleaved::at(usize::MAX, || {});
    then();
    true
}

#[test]
fn the_coarse_lock_takes_a_start_in_two_sections_and_a_wake_up() {
    let w = Cw::<8, 1>::new(Layout::One);
    let [o, c] = ["O", "C"].map(|n| w.seq(n));
    w.start_taken(o);
    let by = Some(w.run(o));
    interleaved::at(usize::MAX, || {});
    Port::start_in_lane(w.seq, c, by).unwrap();
    // admit, launch, the lane's wake-up.
    assert_eq!(interleaved::taken(), 3);
    let run = w.run(c);
    interleaved::at(usize::MAX, || {});
    assert!(w.end_run(run, Outcome::Completed));
    // The end, the joiners' release.
    assert_eq!(interleaved::taken(), 2);
}

// =======================================================================================
// 1. The tick inserted into a start (in the child's lane, or blocking).
// =======================================================================================

/// What the tick inserted into a start does to the starting sequence O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fire {
    /// O's monitor fires, `AbortOwner`, no exception sequence.
    Abort,
    /// O's monitor fires, `AbortOwner`, exception sequence E (ended by its lane later).
    AbortAfterE,
    /// O's monitor fires, `RestartOwner`.
    Restart,
    /// O's `PauseOwner` monitor's condition holds.
    Pause,
    /// O's 1 ms timeout runs out (`AbortOwner`).
    Timeout,
    /// An abort of O was requested before.
    AbortRequest,
}

/// How the child C is started by O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum How {
    /// `Port::start_in_lane(C, O's run)`: non-blocking, in C's own lane.
    InLane,
    /// `Sequencer::begin(C, O's run, Mode::Blocking)`: in O's lane (`Cx::run`).
    Blocking,
}

/// O (polled every ms) runs, started at 0; `fire` set up for the tick at 1 ms. C (timeout
/// 5 ms) and E are registered (in the second word with `Layout::Split`). Returns the
/// world, O, C, E and O's run.
fn owner_and_child<const N: usize, const B: usize>(
    layout: Layout,
    fire: Fire,
) -> (Cw<N, B>, SeqId, SeqId, SeqId, RunId) {
    let w = Cw::<N, B>::new(layout);
    let o = match fire {
        Fire::Timeout => w.timed("O", 1),
        _ => w.seq("O"),
    };
    w.split();
    let c = w.timed("C", 5);
    let e = w.seq("E");
    let on = flag_of(true);
    match fire {
        Fire::Abort => {
            w.monitor(o, on, Behaviour::AbortOwner, None);
        }
        Fire::AbortAfterE => {
            w.monitor(o, on, Behaviour::AbortOwner, Some(e));
        }
        Fire::Restart => {
            w.monitor(o, on, Behaviour::RestartOwner, None);
        }
        Fire::Pause => {
            w.monitor(o, on, Behaviour::PauseOwner, None);
        }
        Fire::Timeout | Fire::AbortRequest => {}
    }
    let run = w.start_taken(o);
    if fire == Fire::AbortRequest {
        w.handle(o).abort().unwrap();
    }
    (w, o, c, e, run)
}

/// The start of C by O's run `by`, `how`.
fn start_child<const N: usize, const B: usize>(
    w: &Cw<N, B>,
    by: RunId,
    c: SeqId,
    how: How,
) -> Result<(), Error> {
    match how {
        How::InLane => Port::start_in_lane(w.seq, c, Some(by)),
        How::Blocking => w
            .seq
            .begin(c, Some(by), Mode::Blocking { maker: 0 }, Cause::Start, 0)
            .map(|_| ()),
    }
}

/// For every section `k` of a start of C by O (`how`), the tick at 1 ms (doing `fire` to
/// O) before section `k`, then what `fire` leads to (E ends, the next tick). Checks the
/// outcome with `expect(what, start result, w, o, c)` and the invariants.
fn tick_into_start<const N: usize, const B: usize>(
    layout: Layout,
    fire: Fire,
    how: How,
    expect: impl Fn(&str, Result<(), Error>, &Cw<N, B>, SeqId, SeqId),
) {
    let count = sections(
        || owner_and_child::<N, B>(layout, fire),
        |(w, _, c, _, run)| {
            let _ = start_child(w, *run, *c, how);
        },
    );
    every_k(count, |k| {
        let (w, o, c, e, run) = owner_and_child::<N, B>(layout, fire);
        let what = format!("{layout:?}, {fire:?}, {how:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        let started = start_child(&w, run, c, how);
        assert!(inserted(k), "{what}: the tick ran");
        if fire == Fire::AbortAfterE {
            // O is held while E runs; E's lane runs it to its end; the next tick applies
            // O's behaviour.
            assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
            w.take(e);
            assert!(w.complete(e), "{what}");
            w.tick(2);
            assert_eq!(w.fired(o, M0), 1, "{what}");
        }
        expect(&what, started, &w, o, c);
        w.check(&what);
    });
}

/// The outcome when O is aborted (or restarted) by `cause`: the start was refused
/// (`NotRunning(O)`, C never ran), or C started and was torn down with O.
fn torn_down_with<const N: usize, const B: usize>(
    what: &str,
    started: Result<(), Error>,
    w: &Cw<N, B>,
    o: SeqId,
    c: SeqId,
    owner: (RunningState, Cause),
) {
    assert_eq!(w.ended(o), owner, "{what}");
    match started {
        Ok(()) => assert_eq!(w.ended(c), (Aborted, owner.1), "{what}"),
        Err(e) => {
            assert_eq!(e, Error::NotRunning(o), "{what}");
            assert_eq!(w.state(c), Idle, "{what}");
        }
    }
}

fn starts_by_an_aborted_sequence<const N: usize, const B: usize>(layout: Layout) {
    for how in [How::InLane, How::Blocking] {
        for (fire, cause) in [
            (Fire::Abort, M0),
            (Fire::AbortAfterE, M0),
            (Fire::Timeout, Cause::Timeout(SeqId(0))),
            (Fire::AbortRequest, Cause::Abort),
        ] {
            tick_into_start::<N, B>(layout, fire, how, |what, started, w, o, c| {
                let cause = match cause {
                    Cause::Timeout(_) => Cause::Timeout(o),
                    c => c,
                };
                torn_down_with(what, started, w, o, c, (Aborted, cause));
            });
        }
    }
}

/// O starts C (in C's lane, or blocking) while the tick aborts O (its `AbortOwner` monitor,
/// its timeout, an abort request, or its monitor after its exception sequence E ended):
/// the start is refused (`NotRunning(O)`) or C is aborted with O (semantics 9).
#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it() {
    starts_by_an_aborted_sequence::<8, 1>(Layout::One);
}

#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it_in_two_words() {
    starts_by_an_aborted_sequence::<64, 2>(Layout::Split);
    starts_by_an_aborted_sequence::<64, 2>(Layout::Second);
}

/// O starts C while the tick restarts O (`RestartOwner`): C is refused or aborted with the
/// monitor's cause; O is `Restarting`.
#[test]
fn a_start_by_a_sequence_the_tick_restarts_is_torn_down_by_the_restart() {
    for how in [How::InLane, How::Blocking] {
        tick_into_start::<8, 1>(Layout::One, Fire::Restart, how, |what, r, w, o, c| {
            torn_down_with(what, r, w, o, c, (Restarting, M0));
        });
        tick_into_start::<64, 2>(Layout::Split, Fire::Restart, how, |what, r, w, o, c| {
            torn_down_with(what, r, w, o, c, (Restarting, M0));
        });
    }
}

/// O starts C in C's own lane while the tick pauses O (`PauseOwner`): the start succeeds
/// and C runs; O is paused.
#[test]
fn a_non_blocking_start_by_a_sequence_the_tick_pauses_runs() {
    let expect = |what: &str, started, w: &Cw<8, 1>, o, c| {
        assert_eq!(started, Ok(()), "{what}");
        assert_eq!((w.state(o), w.state(c)), (Paused, Running), "{what}");
    };
    tick_into_start::<8, 1>(Layout::One, Fire::Pause, How::InLane, expect);
    let expect = |what: &str, started, w: &Cw<64, 2>, o, c| {
        assert_eq!(started, Ok(()), "{what}");
        assert_eq!((w.state(o), w.state(c)), (Paused, Running), "{what}");
    };
    tick_into_start::<64, 2>(Layout::Split, Fire::Pause, How::InLane, expect);
}

fn blocking_start_paused<const N: usize, const B: usize>(layout: Layout) {
    tick_into_start::<N, B>(
        layout,
        Fire::Pause,
        How::Blocking,
        |what, started, w, o, c| {
            assert_eq!(started, Ok(()), "{what}");
            for ms in 2..=11 {
                w.tick(ms);
            }
            assert_eq!(
                (w.state(o), w.state(c)),
                (Paused, Paused),
                "{what}: after 10 ms"
            );
        },
    );
}

/// O starts C blocking while the tick pauses O (`PauseOwner`, its condition stays true):
/// C ends up `Paused` with O, and its 5 ms timeout does not run out while O stays paused
/// for 10 ms (semantics 7).
#[test]
fn a_blocking_start_by_a_sequence_the_tick_pauses_is_paused_with_it() {
    blocking_start_paused::<8, 1>(Layout::One);
    blocking_start_paused::<64, 2>(Layout::Split);
}

/// A main sequence C is started by a handle while the tick aborts another sequence O (its
/// monitor): C runs whatever section the tick preempts.
#[test]
fn a_handle_start_during_an_unrelated_abort_runs() {
    let setup = || owner_and_child::<8, 1>(Layout::One, Fire::Abort);
    let count = sections(setup, |(w, _, c, _, _)| {
        Port::start_in_lane(w.seq, *c, None).unwrap()
    });
    every_k(count, |k| {
        let (w, o, c, _, _) = setup();
        interleaved::at(k, move || w.tick(1));
        assert_eq!(Port::start_in_lane(w.seq, c, None), Ok(()), "k={k}");
        assert_eq!((w.ended(o), w.state(c)), ((Aborted, M0), Running), "k={k}");
        w.check(&format!("k={k}"));
    });
}

// =======================================================================================
// 2. The tick inserted into an end.
// =======================================================================================

/// What fires on O in the tick at 1 ms.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Firing {
    /// A monitor, `AbortOwner`, no exception sequence.
    Abort,
    /// A monitor, `AbortOwner`, exception sequence E.
    AbortAfterE,
    /// A monitor, `RestartOwner`, exception sequence E.
    RestartAfterE,
    /// A monitor, `RestartOwner`.
    Restart,
    /// O's 1 ms timeout (`AbortOwner`).
    Timeout,
}

/// O's lane ends O's run (`outcome`; `Port::end`, then `Port::finished`), and the tick at
/// 1 ms in which `firing` fires on O comes before section `k` of it (or after it). Either
/// the end comes first (O `Terminated` with the outcome, nothing fired, E never started,
/// a failure recorded once), or the firing does: the end is refused; with E, E runs to
/// its end and the next tick applies O's behaviour, once.
fn tick_into_end<const N: usize, const B: usize>(layout: Layout, firing: Firing, outcome: Outcome) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let e = w.seq("E");
        w.split();
        let o = match firing {
            Firing::Timeout => w.timed("O", 1),
            _ => w.seq("O"),
        };
        let b = match firing {
            Firing::Abort | Firing::AbortAfterE => Behaviour::AbortOwner,
            Firing::Restart | Firing::RestartAfterE => Behaviour::RestartOwner,
            Firing::Timeout => Behaviour::Nothing,
        };
        let e_of = matches!(firing, Firing::AbortAfterE | Firing::RestartAfterE).then_some(e);
        if firing != Firing::Timeout {
            w.monitor(o, flag_of(true), b, e_of);
        }
        let run = w.start_taken(o);
        (w, o, e, run)
    };
    let count = sections(setup, |(w, _, _, run)| {
        assert!(w.end_run(*run, outcome));
    });
    every_k(count + 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, {firing:?}, {outcome:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        let ended = w.end_run(run, outcome);
        or_after(k, || w.tick(1));
        let cause = match firing {
            Firing::Timeout => Cause::Timeout(o),
            _ => M0,
        };
        let failures = w
            .records()
            .iter()
            .filter(|r| matches!(r.event(), Some(Event::Failed { sequence, .. }) if sequence == o))
            .count();
        if ended {
            assert!(k > 0, "{what}: ended after the firing");
            assert_eq!(w.state(o), Terminated, "{what}");
            assert_eq!(w.seq.with(|s| s.block(o).unwrap().outcome), Some(outcome));
            assert_eq!(w.state(e), Idle, "{what}: E");
            assert_eq!(w.fired(o, cause), 0, "{what}");
            let failed = usize::from(matches!(outcome, Outcome::Failed(_)));
            assert_eq!(failures, failed, "{what}: the failure recorded");
            w.tick(2);
            assert_eq!(w.state(o), Terminated, "{what}: after");
            w.check(&what);
            return;
        }
        assert_eq!(k, 0, "{what}: refused");
        assert_eq!(failures, 0, "{what}");
        if matches!(firing, Firing::AbortAfterE | Firing::RestartAfterE) {
            assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
            assert!(!w.end_run(run, outcome), "{what}: O holds");
            w.take(e);
            assert!(w.complete(e), "{what}");
            w.tick(2);
        }
        let (to, n) = match firing {
            Firing::Abort | Firing::AbortAfterE | Firing::Timeout => {
                (Aborted, w.moves(o, Aborting, Aborted))
            }
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
fn an_end_during_a_firing_tick_is_either_first_or_refused() {
    for firing in [
        Firing::Abort,
        Firing::AbortAfterE,
        Firing::RestartAfterE,
        Firing::Restart,
        Firing::Timeout,
    ] {
        for outcome in [Outcome::Completed, Outcome::Failed(Failure::App(3))] {
            tick_into_end::<8, 1>(Layout::One, firing, outcome);
            tick_into_end::<64, 2>(Layout::Split, firing, outcome);
        }
    }
}

// =======================================================================================
// 3. The tick inserted into requests.
// =======================================================================================

/// An abort of O is requested (by a handle) while the tick at 1 ms restarts O (its
/// `RestartOwner` monitor), before or after the request's section. The request is
/// accepted whatever `k` and carried out: O ends `Aborted` (cause `Abort`), whether or
/// not O's lane ran it again in between.
#[test]
fn an_abort_requested_while_the_tick_restarts_the_sequence_is_carried_out() {
    let setup = || {
        let w = Cw::<8, 1>::new(Layout::One);
        let o = w.seq("O");
        w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
        w.start_taken(o);
        (w, o, w.handle(o))
    };
    let count = sections(setup, |(_, _, h)| h.abort().unwrap());
    for relaunched in [false, true] {
        every_k(count + 1, |k| {
            let (w, o, h) = setup();
            interleaved::at(k, move || w.tick(1));
            assert_eq!(h.abort(), Ok(()), "k={k}");
            or_after(k, || w.tick(1));
            if relaunched && w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
            w.tick(2);
            let what = format!("relaunched {relaunched}, k={k}");
            assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}");
            w.check(&what);
        });
    }
}

/// The abort of O is requested while the tick at 1 ms aborts O itself (its `AbortOwner`
/// monitor). With the tick before the request's one section, the request is refused
/// (`NotRunning`) and O is aborted by the monitor; with the tick after it, the tick
/// applies the request before the monitors: O is aborted by the request, and the monitor
/// does not fire. Either way once.
#[test]
fn an_abort_requested_while_the_tick_aborts_the_sequence_aborts_it_once() {
    let setup = || {
        let w = Cw::<8, 1>::new(Layout::One);
        let o = w.seq("O");
        w.monitor(o, flag_of(true), Behaviour::AbortOwner, None);
        w.start_taken(o);
        (w, o, w.handle(o))
    };
    let count = sections(setup, |(_, _, h)| h.abort().unwrap());
    every_k(count + 1, |k| {
        let (w, o, h) = setup();
        interleaved::at(k, move || w.tick(1));
        let asked = h.abort();
        let after = or_after(k, || w.tick(1));
        let what = format!("k={k}");
        if after {
            assert_eq!(asked, Ok(()), "{what}");
            assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}");
            assert_eq!(w.fired(o, M0), 0, "{what}");
        } else {
            assert_eq!(asked, Err(Error::NotRunning(o)), "{what}");
            assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        }
        let cause = w.ended(o).1;
        w.tick(2);
        assert_eq!(w.ended(o), (Aborted, cause), "{what}");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

/// A pause of O is requested while the tick at 1 ms pauses O (its `PauseOwner` monitor,
/// condition true at 1 ms, false from 2 ms). Accepted, the request's pause outlasts the
/// monitor; refused (`NotRunning`), O resumes at 2 ms.
#[test]
fn a_pause_requested_while_the_tick_pauses_the_sequence_outlasts_the_monitor_iff_accepted() {
    let setup = || {
        let w = Cw::<8, 1>::new(Layout::One);
        let o = w.seq("O");
        let holds = flag_of(true);
        w.monitor(o, holds, Behaviour::PauseOwner, None);
        w.start_taken(o);
        (w, o, holds, w.handle(o))
    };
    let count = sections(setup, |(_, _, _, h)| h.pause().unwrap());
    every_k(count + 1, |k| {
        let (w, o, holds, h) = setup();
        interleaved::at(k, move || w.tick(1));
        let asked = h.pause();
        or_after(k, || w.tick(1));
        assert_eq!(w.state(o), Paused, "k={k}");
        holds.store(false, Ordering::Relaxed);
        w.tick(2);
        w.tick(3);
        match asked {
            Ok(()) => assert_eq!(w.state(o), Paused, "k={k}: the request's pause"),
            Err(e) => {
                assert_eq!(e, Error::NotRunning(o), "k={k}");
                assert_eq!(w.state(o), Running, "k={k}: released");
            }
        }
        w.check(&format!("k={k}"));
    });
}

/// A request of O, by a handle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ask {
    Pause,
    Resume,
}

fn ask<const N: usize, const B: usize>(w: &Cw<N, B>, o: SeqId, a: Ask) -> Result<(), Error> {
    match a {
        Ask::Pause => w.handle(o).pause(),
        Ask::Resume => w.handle(o).resume(),
    }
}

/// O (5 ms timeout, started at 0) with a `PauseOwner` monitor whose condition is the
/// returned flag, set to `holds`; with `paused_by_request`, O's pause was requested. With
/// `tick`, the tick at 1 ms has paused O.
fn pausable<const N: usize, const B: usize>(
    layout: Layout,
    holds: bool,
    paused_by_request: bool,
    tick: bool,
) -> (Cw<N, B>, SeqId, &'static AtomicBool) {
    let w = Cw::<N, B>::new(layout);
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

/// The tick at `ms` before each section of `a` of O (or after it), on worlds from
/// `setup`; then `expect(what, result, w, o, flag)`.
fn tick_into_request<const N: usize, const B: usize>(
    setup: impl Fn() -> (Cw<N, B>, SeqId, &'static AtomicBool),
    a: Ask,
    ms: u64,
    expect: impl Fn(&str, Result<(), Error>, &Cw<N, B>, SeqId, &'static AtomicBool),
) {
    let count = 1;
    every_k(count + 1, |k| {
        let (w, o, on) = setup();
        let what = format!("{:?}, {a:?}, k={k}", w.layout);
        let h = w.handle(o);
        interleaved::at(k, move || w.tick(ms));
        let r = match a {
            Ask::Pause => h.pause(),
            Ask::Resume => h.resume(),
        };
        or_after(k, || w.tick(ms));
        expect(&what, r, &w, o, on);
        w.check(&what);
    });
}

/// O was paused by a request at 1 ms; its `PauseOwner` monitor's condition holds from
/// 2 ms. A resume of O is requested, the tick at 2 ms before or after it. Refused
/// (`HeldByMonitor`), the request's pause stays after the condition clears (4 ms) until a
/// resume request (applied at 6 ms); accepted, O resumes when the condition clears. O's
/// timeout runs out at exactly 8 ms or 10 ms.
fn resume_request_around_holding_tick<const N: usize, const B: usize>(layout: Layout) {
    tick_into_request(
        || {
            let (w, o, on) = pausable::<N, B>(layout, false, true, true);
            on.store(true, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Resume,
        2,
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
fn a_holding_tick_during_a_resume_request_lifts_the_requests_pause_iff_accepted() {
    resume_request_around_holding_tick::<8, 1>(Layout::One);
    resume_request_around_holding_tick::<64, 2>(Layout::Second);
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A
/// resume of O is requested, the tick at 2 ms before or after it: `HeldByMonitor` or
/// `NotPaused`, never lost. O runs from 2 ms, resumed once; its timeout runs out at 6 ms.
fn resume_request_around_releasing_tick<const N: usize, const B: usize>(layout: Layout) {
    tick_into_request(
        || {
            let (w, o, on) = pausable::<N, B>(layout, true, false, true);
            on.store(false, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Resume,
        2,
        |what, asked, w, o, _| {
            assert!(
                [Err(Error::HeldByMonitor(o)), Err(Error::NotPaused(o))].contains(&asked),
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
    resume_request_around_releasing_tick::<8, 1>(Layout::One);
    resume_request_around_releasing_tick::<64, 2>(Layout::Second);
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A pause
/// of O is requested, the tick at 2 ms before it (accepted: O paused at 3 ms until a
/// resume request applied at 5 ms, timeout at 8 ms) or after it (refused, `NotRunning`:
/// timeout at 6 ms).
fn pause_request_around_releasing_tick<const N: usize, const B: usize>(layout: Layout) {
    tick_into_request(
        || {
            let (w, o, on) = pausable::<N, B>(layout, true, false, true);
            on.store(false, Ordering::Relaxed);
            (w, o, on)
        },
        Ask::Pause,
        2,
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
    pause_request_around_releasing_tick::<8, 1>(Layout::One);
    pause_request_around_releasing_tick::<64, 2>(Layout::Second);
}

// =======================================================================================
// 4. The tick inserted into restarts.
// =======================================================================================

/// O's lane obeys `Restart` after O's `RestartOwner` monitor fired at 1 ms; the tick at
/// 2 ms, with an abort-all or an abort request of O pending, comes before (or after) the
/// restart's section. The abort stands: O ends `Aborted`.
#[test]
fn an_abort_during_a_restart_stands() {
    for by_request in [false, true] {
        let setup = move || {
            let w = Cw::<8, 1>::new(Layout::One);
            let o = w.seq("O");
            let fault = flag_of(true);
            w.monitor(o, fault, Behaviour::RestartOwner, None);
            w.start_taken(o);
            w.tick(1);
            assert_eq!(w.state(o), Restarting);
            fault.store(false, Ordering::Relaxed);
            if by_request {
                w.handle(o).abort().unwrap();
            } else {
                w.seq.abort_all();
            }
            (w, o, w.run(o))
        };
        let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
        every_k(count + 1, |k| {
            let (w, o, run) = setup();
            interleaved::at(k, move || w.tick(2));
            w.seq.restart(run);
            or_after(k, || w.tick(2));
            let cause = if by_request {
                Cause::Abort
            } else {
                Cause::AbortAll
            };
            let what = format!("by request {by_request}, k={k}");
            assert_eq!(w.ended(o), (Aborted, cause), "{what}");
            w.tick(3);
            assert_eq!(w.ended(o), (Aborted, cause), "{what}");
            w.check(&what);
        });
    }
}

/// O's lane obeys `Restart` after O's `RestartOwner` monitor fired at 1 ms (its condition
/// stays true); the tick at 2 ms comes before (or after) the restart. The restart commits
/// once, and the restarted run's monitors start again from "false": O is restarted again
/// by 3 ms, one `Restarting → Running` record.
#[test]
fn a_restart_preempted_by_the_tick_runs_again_once() {
    let setup = || {
        let w = Cw::<8, 1>::new(Layout::One);
        let o = w.seq("O");
        w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
        w.start_taken(o);
        w.tick(1);
        assert_eq!(w.state(o), Restarting);
        (w, o, w.run(o))
    };
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    every_k(count + 1, |k| {
        let (w, o, run) = setup();
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        let after = or_after(k, || w.tick(2));
        if !after {
            assert_eq!(w.state(o), Running, "k={k}");
        }
        w.tick(3);
        assert_eq!(w.ended(o), (Restarting, M0), "k={k}: fired again");
        assert_eq!(w.moves(o, Restarting, Running), 1, "k={k}");
        assert_eq!(w.fired(o, M0), 2, "k={k}");
        w.check(&format!("k={k}"));
    });
}

/// O's `RestartOwner` monitor M0 restarted O at 1 ms; its `AbortOwner` monitor M1 with
/// exception sequence E holds from 2 ms. O's lane obeys `Restart` with the tick at 2 ms
/// before (or after) it. M1 fires once, on the restarted run (at 3 ms, or at 2 ms when the
/// restart came first), E runs once for O, and once E's end is folded O is aborted by M1,
/// once.
fn restart_into_firing_tick<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
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
    every_k(count + 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        let after = or_after(k, || w.tick(2));
        assert_eq!(w.state(o), Running, "{what}");
        let ms = if after {
            2
        } else {
            assert_eq!(w.state(e), Idle, "{what}");
            w.tick(3);
            3
        };
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

// =======================================================================================
// 5. The tick inserted into joins.
// =======================================================================================

/// A joiner: its sequence, the run it joined (set at its first poll), its lane's counting
/// waker.
struct Joiner {
    id: SeqId,
    run: Option<u16>,
    wakes: Arc<Count>,
}

impl Joiner {
    fn started<const N: usize, const B: usize>(w: &Cw<N, B>, id: SeqId) -> Joiner {
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
        w: &Cw<N, B>,
        target: SeqId,
    ) -> Poll<Result<Outcome, Error>> {
        Port::join(w.seq, self.id, target, &mut self.run)
    }

    fn joining<const N: usize, const B: usize>(&self, w: &Cw<N, B>) -> bool {
        w.in_set(Set::Joining, self.id)
    }

    /// After a `Pending` poll: the joined run ended since (`wakes_before` wake-ups then),
    /// so the joiner was released and woken; its next poll is ready.
    fn released<const N: usize, const B: usize>(
        &mut self,
        w: &Cw<N, B>,
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

/// O runs; J2 has joined O's run (pending). J1 polls its join of O with the tick at 1 ms
/// before section `k` of the poll (or after it). Every joiner gets the outcome of the run
/// it joined, never hangs: an abort's `Aborted(cause)` (at once, or released and woken,
/// then ready); a restart does not end the run: both wait, and get `Completed` when O's
/// lane, having restarted it, completes it.
fn tick_into_join<const N: usize, const B: usize>(layout: Layout, tick: JoinTick) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
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
    let count = sections(setup, |(w, o, js)| {
        let mut run = None;
        let _ = Port::join(w.seq, js[0].id, *o, &mut run);
    });
    every_k(count + 1, |k| {
        let (w, o, [mut j1, mut j2]) = setup();
        let what = format!("{layout:?}, {tick:?}, k={k}");
        let (j1_wakes, j2_wakes) = (woken(&j1.wakes), woken(&j2.wakes));
        interleaved::at(k, move || w.tick(1));
        let first = j1.poll(&w, o);
        let after = or_after(k, || w.tick(1));
        let cause = match tick {
            JoinTick::Abort | JoinTick::Restart => M0,
            JoinTick::Request => Cause::Abort,
        };
        match tick {
            JoinTick::Abort | JoinTick::Request => {
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                let expected = Ok(Outcome::Aborted(cause));
                match first {
                    Poll::Ready(r) => {
                        assert!(!after, "{what}: ready before the abort");
                        assert_eq!(r, expected, "{what}: J1");
                    }
                    Poll::Pending => {
                        let r = j1.released(&w, o, j1_wakes, &what);
                        assert_eq!(r, expected, "{what}: J1");
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
                let (j1_wakes, j2_wakes) = (woken(&j1.wakes), woken(&j2.wakes));
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
fn a_join_during_a_tick_that_ends_or_restarts_the_joined_run_gets_its_outcome() {
    for tick in [JoinTick::Abort, JoinTick::Request, JoinTick::Restart] {
        tick_into_join::<8, 1>(Layout::One, tick);
        tick_into_join::<64, 2>(Layout::Split, tick);
    }
}

// =======================================================================================
// 6. The tick inserted into a dropped run's teardown.
// =======================================================================================

/// R runs X blocking; X's monitor (`behaviour`, exception sequence E for `AbortOwner`)
/// holds from 1 ms. R's run is dropped (`Port::abandon`) with the tick at 1 ms, which
/// fires X's monitor, before section `k` of the teardown (or after it). Everything is torn
/// down (semantics 13): R and X aborted (`Dropped`; the monitor's cause only when the
/// tick's `AbortCallerOfOwner` came first), E not left under way, nothing under way after
/// the next tick either.
fn tick_into_dropped_run<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let r = w.seq("R");
        w.split();
        let [x, e] = ["X", "E"].map(|n| w.seq(n));
        let e_of = (behaviour == Behaviour::AbortOwner).then_some(e);
        w.monitor(x, flag_of(true), behaviour, e_of);
        w.start_taken(r);
        w.seq
            .begin(
                x,
                Some(w.run(r)),
                Mode::Blocking { maker: 0 },
                Cause::Start,
                0,
            )
            .unwrap();
        (w, [r, x, e])
    };
    let count = sections(setup, |(w, [r, ..])| Port::abandon(w.seq, *r, &()));
    every_k(count + 1, |k| {
        let (w, [r, x, e]) = setup();
        interleaved::at(k, move || w.tick(1));
        Port::abandon(w.seq, r, &());
        or_after(k, || w.tick(1));
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        let cause = w.ended(r).1;
        let allowed: &[Cause] = match behaviour {
            Behaviour::AbortCallerOfOwner => &[Cause::Dropped, M0],
            _ => &[Cause::Dropped],
        };
        assert!(allowed.contains(&cause), "{what}: {cause:?}");
        for id in [r, x] {
            assert_eq!(w.ended(id), (Aborted, cause), "{what}: {id:?}");
        }
        assert!(
            [Idle, Aborted].contains(&w.state(e)),
            "{what}: E {:?}",
            w.state(e)
        );
        w.tick(2);
        for id in [r, x, e] {
            assert!(
                ![Running, Paused, Restarting].contains(&w.state(id)),
                "{what}: {id:?}"
            );
        }
        assert_eq!(w.moves(r, Aborting, Aborted), 1, "{what}");
        assert_eq!(w.moves(x, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_dropped_run_during_a_firing_below_it_leaves_nothing_under_way() {
    for behaviour in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        tick_into_dropped_run::<8, 1>(Layout::One, behaviour);
        tick_into_dropped_run::<64, 2>(Layout::Split, behaviour);
    }
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E ran to its end. O's
/// run is dropped (`Port::abandon`) with the tick at 2 ms, which reports E's end to O and
/// applies the behaviour, before section `k` of the teardown (or after it). O is aborted
/// once: by the drop (`Dropped`), or, when the tick's abort came first, by the monitor; a
/// restart by the tick is followed by the drop's abort. E's end is reported once.
fn tick_into_dropped_owner<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
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
    let count = sections(setup, |(w, o, _)| Port::abandon(w.seq, *o, &()));
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        Port::abandon(w.seq, o, &());
        let after = or_after(k, || w.tick(2));
        let (state, cause) = w.ended(o);
        assert_eq!(state, Aborted, "{what}");
        // The tick's abort comes first when it lands before the teardown's `leave`.
        let allowed: &[Cause] = match behaviour {
            Behaviour::AbortOwner if !after => &[Cause::Dropped, M0],
            _ => &[Cause::Dropped],
        };
        assert!(
            allowed.contains(&cause),
            "{what}: {cause:?} (after {after})"
        );
        w.tick(3);
        assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        assert_eq!(w.fired(o, M0), 1, "{what}");
        assert_eq!(w.state(e), Terminated, "{what}");
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        assert!(!w.has(o, flag::EXCEPTION_DONE), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_dropped_owner_during_the_report_of_its_exception_sequences_end_is_aborted_once() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        tick_into_dropped_owner::<8, 1>(Layout::One, behaviour);
        tick_into_dropped_owner::<64, 2>(Layout::Split, behaviour);
    }
}

// =======================================================================================
// 7. The tick inserted into a lane taking its start, or dropped while it waits.
// =======================================================================================

/// What the tick at 1 ms does to O, whose start is pending (not taken by its lane).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tick {
    Abort,
    AbortAfterE,
    Timeout,
    Request,
    AbortAll,
    Restart,
    /// O's `PauseOwner` monitor (true at 1 ms, false from 2 ms); O has a 5 ms timeout.
    Pause,
}

const TICKS: [Tick; 7] = [
    Tick::Abort,
    Tick::AbortAfterE,
    Tick::Timeout,
    Tick::Request,
    Tick::AbortAll,
    Tick::Restart,
    Tick::Pause,
];

impl Tick {
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
) -> (Cw<N, B>, SeqId, SeqId, &'static AtomicBool) {
    let w = Cw::<N, B>::new(layout);
    let e = w.seq("E");
    w.split();
    let o = match tick {
        Tick::Timeout => w.timed("O", 1),
        Tick::Pause => w.timed("O", 5),
        _ => w.seq("O"),
    };
    let on = flag_of(true);
    let b = match tick {
        Tick::Abort | Tick::AbortAfterE => Some(Behaviour::AbortOwner),
        Tick::Restart => Some(Behaviour::RestartOwner),
        Tick::Pause => Some(Behaviour::PauseOwner),
        _ => None,
    };
    if let Some(b) = b {
        w.monitor(o, on, b, (tick == Tick::AbortAfterE).then_some(e));
    }
    w.handle(o).start().unwrap();
    match tick {
        Tick::Request => w.handle(o).abort().unwrap(),
        Tick::AbortAll => w.seq.abort_all(),
        _ => {}
    }
    (w, o, e, on)
}

/// O's lane takes O's pending start (`Port::take_start`, a counting waker) with the tick
/// at 1 ms doing `tick` to O before section `k` of the take, or after it. As in
/// `interleavings_more.rs`: the lane takes the run it was started for, or nothing when the
/// tick aborted it first; the clearance says what the tick did; a change after the take
/// woke the lane.
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

#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone() {
    for tick in TICKS {
        take_during_tick::<8, 1>(Layout::One, tick);
        take_during_tick::<64, 2>(Layout::Second, tick);
        take_during_tick::<64, 2>(Layout::Split, tick);
    }
}

/// O's lane is dropped while it waits for O's pending start (`Port::abandon_start`), with
/// the tick at 1 ms doing `tick` to O before section `k`. O ends `Aborted`, by the drop
/// (`Dropped`) or by the tick when the tick aborted it first; never left under way; E (if
/// the tick started it below O) torn down with O; the ticks after change nothing.
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
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_lane_dropped_while_the_tick_fires_on_its_pending_start_leaves_nothing_under_way() {
    for tick in TICKS {
        abandon_during_tick::<8, 1>(Layout::One, tick);
        abandon_during_tick::<64, 2>(Layout::Second, tick);
        abandon_during_tick::<64, 2>(Layout::Split, tick);
    }
}

// =======================================================================================
// 8. The tick inserted into the end of an exception sequence.
// =======================================================================================

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E runs (taken), and an
/// abort of E was requested. E's lane ends E (completed) with the tick at 2 ms, which
/// carries the abort out, before section `k` of the end (or after it). E ends once
/// (completed, or aborted by the request), its end is reported to O once, and O's
/// behaviour is applied once, by the tick at 3 ms at the latest; E is free again.
fn tick_into_end_of_e<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let e = w.seq("E");
        w.monitor(o, flag_of(true), behaviour, Some(e));
        w.start_taken(o);
        w.tick(1);
        assert_eq!((w.state(o), w.state(e)), (Running, Running));
        let run = w.take(e);
        w.handle(e).abort().unwrap();
        (w, o, e, run)
    };
    let count = sections(setup, |(w, _, _, run)| {
        assert!(w.end_run(*run, Outcome::Completed));
    });
    every_k(count + 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        let ended = w.end_run(run, Outcome::Completed);
        or_after(k, || w.tick(2));
        if ended {
            assert_eq!(w.state(e), Terminated, "{what}");
        } else {
            assert_eq!(k, 0, "{what}");
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
        assert_eq!(
            w.moves(e, Running, Terminated) + w.moves(e, Aborting, Aborted),
            1,
            "{what}: E ended once"
        );
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
        tick_into_end_of_e::<8, 1>(Layout::One, behaviour);
        tick_into_end_of_e::<64, 2>(Layout::Second, behaviour);
        tick_into_end_of_e::<64, 2>(Layout::Split, behaviour);
    }
}

// =======================================================================================
// 9. `abort_all` inserted anywhere: into the tick, into a lane's operation, into a tick
//    that preempts a lane's operation.
// =======================================================================================

/// R (main) started Y non-blocking; Y runs X blocking (in Y's lane). X's monitor
/// (`behaviour`; exception sequence E with `AbortOwner`) holds from 1 ms. A tick at 0
/// folded the tree. Returns the world, R, Y, X, E.
fn firing_tree<const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) -> (Cw<N, B>, [SeqId; 4]) {
    let w = Cw::<N, B>::new(layout);
    let r = w.seq("R");
    w.split();
    let [y, x, e] = ["Y", "X", "E"].map(|n| w.seq(n));
    let e_of = (behaviour == Behaviour::AbortOwner).then_some(e);
    w.monitor(x, flag_of(true), behaviour, e_of);
    w.start_taken(r);
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
    w.tick(0);
    (w, [r, y, x, e])
}

/// `abort_all` (the safety task, above the ceiling) before section `k` of the tick at
/// 1 ms, which fires X's monitor (`behaviour`). The abort-all is carried out by that tick
/// when it comes before its first section (the inbox is read right after it), else by the
/// tick at 2 ms. Afterwards nothing is under way: R, Y, X (and E, if it began) aborted;
/// a sequence still under way when the abort-all is carried out has the cause `AbortAll`;
/// X's monitor fired at most once (never when the abort-all came first); an abort-all is
/// recorded iff something was under way.
fn abort_all_into_firing_tick<const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) {
    let count = sections(
        || firing_tree::<N, B>(layout, behaviour),
        |(w, _)| w.tick(1),
    );
    every_k(count, |k| {
        let (w, [r, y, x, e]) = firing_tree::<N, B>(layout, behaviour);
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || w.seq.abort_all());
        w.tick(1);
        assert!(inserted(k), "{what}");
        let first = k == 0;
        if first {
            for id in [r, y, x] {
                assert_eq!(w.ended(id), (Aborted, Cause::AbortAll), "{what}: {id:?}");
            }
            assert_eq!(w.fired(x, M0), 0, "{what}");
        } else {
            assert_eq!(w.fired(x, M0), 1, "{what}");
        }
        w.tick(2);
        w.tick(3);
        // Only `AbortCallerOfOwner` at 1 ms stops Y and X itself (E holds X, a restart
        // or a pause leaves X under way for the abort-all).
        let below = if !first && behaviour == Behaviour::AbortCallerOfOwner {
            M0
        } else {
            Cause::AbortAll
        };
        let (y_cause, x_cause) = (below, below);
        assert_eq!(w.ended(r), (Aborted, Cause::AbortAll), "{what}: R");
        assert_eq!(w.ended(y), (Aborted, y_cause), "{what}: Y");
        assert_eq!(w.ended(x), (Aborted, x_cause), "{what}: X");
        let e_state = w.ended(e);
        assert!(
            e_state.0 == Idle || e_state == (Aborted, Cause::AbortAll),
            "{what}: E {e_state:?}"
        );
        assert_eq!(w.aborts_all(), 1, "{what}: one abort-all recorded");
        for id in [r, y, x] {
            assert_eq!(w.moves(id, Aborting, Aborted), 1, "{what}: {id:?}");
        }
        w.check(&what);
    });
}

#[test]
fn an_abort_all_anywhere_in_a_firing_tick_leaves_nothing_under_way() {
    for behaviour in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        abort_all_into_firing_tick::<8, 1>(Layout::One, behaviour);
        abort_all_into_firing_tick::<64, 2>(Layout::Split, behaviour);
    }
}

/// O starts C (in C's lane, or blocking); before section `k` of the start the tick at 1 ms
/// runs, with `abort_all` before its section `j` (for every `j`, and once after it). O has
/// an `AbortOwner` monitor with exception sequence E. After the ticks at 2 and 3 ms
/// nothing is under way: O aborted by the abort-all, C refused (`NotRunning(O)`) or
/// aborted, E (if it began) aborted; the abort-all recorded once.
fn abort_all_into_tick_into_start<const N: usize, const B: usize>(layout: Layout, how: How) {
    let setup = || owner_and_child::<N, B>(layout, Fire::AbortAfterE);
    let count = sections(setup, |(w, _, c, _, run)| {
        let _ = start_child(w, *run, *c, how);
    });
    let ticks = sections(setup, |(w, _, _, _, _)| w.tick(1));
    for j in 0..=ticks {
        every_k(count, |k| {
            let (w, o, c, e, run) = setup();
            let what = format!("{layout:?}, {how:?}, k={k}, j={j}");
            let (tick, ran) = tick_with_abort_all(w, 1, j);
            interleaved::at(k, tick);
            let started = start_child(&w, run, c, how);
            assert!(ran.get(), "{what}: the tick ran");
            w.tick(2);
            w.tick(3);
            assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}: O");
            match started {
                Ok(()) => assert_eq!(w.ended(c), (Aborted, Cause::AbortAll), "{what}: C"),
                Err(err) => {
                    assert_eq!(err, Error::NotRunning(o), "{what}");
                    assert_eq!(w.state(c), Idle, "{what}: C");
                }
            }
            let e_state = w.ended(e);
            assert!(
                e_state.0 == Idle || e_state == (Aborted, Cause::AbortAll),
                "{what}: E {e_state:?}"
            );
            assert_eq!(w.aborts_all(), 1, "{what}");
            assert!(w.fired(o, M0) <= 1, "{what}");
            w.check(&what);
        });
    }
}

#[test]
fn an_abort_all_anywhere_in_a_tick_that_preempts_a_start_leaves_nothing_under_way() {
    for how in [How::InLane, How::Blocking] {
        abort_all_into_tick_into_start::<8, 1>(Layout::One, how);
        abort_all_into_tick_into_start::<64, 2>(Layout::Split, how);
    }
}

/// `abort_all` before section `k` of a lane's operation (a start of C by O, O's end, a
/// dropped run's teardown): a flag for the next tick, which aborts whatever is under way
/// then (`AbortAll`), once.
#[test]
fn an_abort_all_anywhere_in_a_lanes_operation_is_carried_out_by_the_next_tick() {
    for how in [How::InLane, How::Blocking] {
        let setup = || owner_and_child::<8, 1>(Layout::One, Fire::AbortAfterE);
        let count = sections(setup, |(w, _, c, _, run)| {
            let _ = start_child(w, *run, *c, how);
        });
        every_k(count, |k| {
            let (w, o, c, _, run) = setup();
            let what = format!("start {how:?}, k={k}");
            interleaved::at(k, move || w.seq.abort_all());
            assert_eq!(start_child(&w, run, c, how), Ok(()), "{what}");
            w.tick(1);
            for id in [o, c] {
                assert_eq!(w.ended(id), (Aborted, Cause::AbortAll), "{what}: {id:?}");
            }
            assert_eq!(w.fired(o, M0), 0, "{what}");
            w.check(&what);
        });
    }
    // The end of O (C runs below it, non-blocking): C is aborted, O ended.
    let setup = || {
        let (w, o, c, e, run) = owner_and_child::<8, 1>(Layout::One, Fire::Timeout);
        start_child(&w, run, c, How::InLane).unwrap();
        (w, o, c, e, run)
    };
    let count = sections(setup, |(w, _, _, _, run)| {
        assert!(w.end_run(*run, Outcome::Completed));
    });
    every_k(count, |k| {
        let (w, o, c, _, run) = setup();
        let what = format!("end, k={k}");
        interleaved::at(k, move || w.seq.abort_all());
        assert!(w.end_run(run, Outcome::Completed), "{what}");
        w.tick(1);
        assert_eq!(w.state(o), Terminated, "{what}");
        assert_eq!(w.ended(c), (Aborted, Cause::AbortAll), "{what}");
        w.check(&what);
    });
    // A dropped run's teardown (R runs X blocking): the drop's abort comes first.
    let setup = || {
        let (w, [r, y, x, _]) = firing_tree::<8, 1>(Layout::One, Behaviour::PauseOwner);
        (w, r, y, x)
    };
    let count = sections(setup, |(w, r, _, _)| Port::abandon(w.seq, *r, &()));
    every_k(count, |k| {
        let (w, r, y, x) = setup();
        let what = format!("drop, k={k}");
        interleaved::at(k, move || w.seq.abort_all());
        Port::abandon(w.seq, r, &());
        w.tick(1);
        for id in [r, y, x] {
            assert_eq!(w.ended(id), (Aborted, Cause::Dropped), "{what}: {id:?}");
        }
        assert_eq!(w.aborts_all(), 0, "{what}: nothing left to abort");
        w.check(&what);
    });
}

/// The tick at `ms` with `abort_all` (the safety task) before its section `j`, or after
/// it when it takes fewer: a closure to insert into a lane's operation, and whether it ran
/// (the tick counts its sections afresh, so `inserted` no longer tells).
fn tick_with_abort_all<const N: usize, const B: usize>(
    w: Cw<N, B>,
    ms: u64,
    j: usize,
) -> (impl FnOnce() + 'static, std::rc::Rc<core::cell::Cell<bool>>) {
    let ran = std::rc::Rc::new(core::cell::Cell::new(false));
    let out = ran.clone();
    let tick = move || {
        out.set(true);
        interleaved::at(j, move || w.seq.abort_all());
        w.tick(ms);
        or_after(j, || w.seq.abort_all());
    };
    (tick, ran)
}

/// `tick_into_dropped_run` with an abort-all anywhere in the tick: R's run is dropped with
/// the tick at 1 ms (firing X's monitor, `behaviour`) before section `k` of the teardown,
/// and `abort_all` before section `j` of that tick. After the tick at 2 ms nothing is
/// under way, R and X were aborted once each (by the drop, the abort-all, or with
/// `AbortCallerOfOwner` the monitor), E is idle or aborted, one abort-all at most.
fn abort_all_into_tick_into_dropped_run<const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let r = w.seq("R");
        w.split();
        let [x, e] = ["X", "E"].map(|n| w.seq(n));
        let e_of = (behaviour == Behaviour::AbortOwner).then_some(e);
        w.monitor(x, flag_of(true), behaviour, e_of);
        w.start_taken(r);
        w.seq
            .begin(
                x,
                Some(w.run(r)),
                Mode::Blocking { maker: 0 },
                Cause::Start,
                0,
            )
            .unwrap();
        (w, [r, x, e])
    };
    let count = sections(setup, |(w, [r, ..])| Port::abandon(w.seq, *r, &()));
    let ticks = sections(setup, |(w, _)| w.tick(1));
    for j in 0..=ticks {
        every_k(count, |k| {
            let (w, [r, x, e]) = setup();
            let what = format!("{layout:?}, {behaviour:?}, k={k}, j={j}");
            let (tick, ran) = tick_with_abort_all(w, 1, j);
            interleaved::at(k, tick);
            Port::abandon(w.seq, r, &());
            assert!(ran.get(), "{what}: the tick ran");
            w.tick(2);
            w.tick(3);
            let allowed: &[Cause] = match behaviour {
                Behaviour::AbortCallerOfOwner => &[Cause::Dropped, Cause::AbortAll, M0],
                _ => &[Cause::Dropped, Cause::AbortAll],
            };
            for id in [r, x] {
                let (state, cause) = w.ended(id);
                assert_eq!(state, Aborted, "{what}: {id:?}");
                assert!(allowed.contains(&cause), "{what}: {id:?} {cause:?}");
                assert_eq!(w.moves(id, Aborting, Aborted), 1, "{what}: {id:?}");
            }
            let e_state = w.ended(e);
            assert!(
                e_state.0 == Idle || e_state.0 == Aborted,
                "{what}: E {e_state:?}"
            );
            assert!(w.aborts_all() <= 1, "{what}");
            assert!(w.fired(x, M0) <= 1, "{what}");
            w.check(&what);
        });
    }
}

#[test]
fn an_abort_all_anywhere_in_a_tick_that_preempts_a_dropped_runs_teardown_leaves_nothing_under_way()
{
    for behaviour in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        abort_all_into_tick_into_dropped_run::<8, 1>(Layout::One, behaviour);
        abort_all_into_tick_into_dropped_run::<64, 2>(Layout::Split, behaviour);
    }
}

/// O's monitor fired at 1 ms and started its exception sequence E (`AbortOwner`), whose
/// start E's lane has not taken; an abort of O (a request, or an abort-all) is pending.
/// E's lane takes its start with the tick at 2 ms, which aborts O and E below it, before
/// section `k` of the take (or after it). The lane takes E's run (its clearance then says
/// `Aborted`), or nothing when the tick came first; O and E are aborted by the request
/// (abort-all); E's end reported to the aborted O changes nothing; E may be started again.
fn tick_into_exception_take<const N: usize, const B: usize>(layout: Layout, all: bool) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let e = w.seq("E");
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
    let count = sections(setup, |(w, _, e)| {
        Port::take_start(w.seq, *e, 0, Waker::noop());
    });
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, abort-all {all}, k={k}");
        let (waker, wakes) = counting();
        interleaved::at(k, move || w.tick(2));
        let taken = Port::take_start(w.seq, e, 0, &waker);
        let after = or_after(k, || w.tick(2));
        let cause = if all { Cause::AbortAll } else { Cause::Abort };
        assert_eq!(w.ended(o), (Aborted, cause), "{what}");
        assert_eq!(w.ended(e), (Aborted, cause), "{what}");
        match taken {
            Some(run) => {
                assert_eq!(run, RunId { seq: e, count: 1 }, "{what}");
                assert_eq!(w.clearance(run), Clearance::Aborted(cause), "{what}");
                if after {
                    assert_eq!(woken(&wakes), 1, "{what}: the abort woke E's lane");
                }
            }
            None => assert!(!after, "{what}: the start was there"),
        }
        w.tick(3);
        assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
        assert_eq!(w.fired(o, M0), 1, "{what}");
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
        assert_eq!(w.handle(e).start(), Ok(()), "{what}: E is free");
        w.check(&what);
    });
}

#[test]
fn an_exception_sequences_start_taken_while_the_tick_aborts_its_owner() {
    for all in [false, true] {
        tick_into_exception_take::<8, 1>(Layout::One, all);
        tick_into_exception_take::<64, 2>(Layout::Split, all);
    }
}

/// R (1 ms timeout, polled every ms) runs, started at 0 before any tick (its first poll at
/// 1 ms). G (same class, 1 ms timeout) is started by a handle with the tick at 1 ms before
/// section `k` of the start (or after it). R is aborted by its timeout at 1 ms whatever
/// `k`. G's first poll is one period after its own start: at 1 ms when the start
/// committed before the tick (at 0), else at 2 ms (started at 1 ms into a class the
/// tick emptied).
fn tick_into_a_start_in_a_polled_class<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = Cw::<N, B>::new(layout);
        let r = w.timed("R", 1);
        w.split();
        let g = w.timed("G", 1);
        w.start_taken(r);
        (w, r, g)
    };
    let count = sections(setup, |(w, _, g)| {
        Port::start_in_lane(w.seq, *g, None).unwrap()
    });
    every_k(count + 1, |k| {
        let (w, r, g) = setup();
        let what = format!("{layout:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        assert_eq!(Port::start_in_lane(w.seq, g, None), Ok(()), "{what}");
        or_after(k, || w.tick(1));
        assert_eq!(
            w.ended(r),
            (Aborted, Cause::Timeout(r)),
            "{what}: R at 1 ms"
        );
        // The start commits in its second section.
        let committed_before = k >= 2;
        let g_at_1 = if committed_before { Aborted } else { Running };
        assert_eq!(w.state(g), g_at_1, "{what}: G at 1 ms");
        w.tick(2);
        assert_eq!(
            w.ended(g),
            (Aborted, Cause::Timeout(g)),
            "{what}: G at 2 ms"
        );
        w.check(&what);
    });
}

#[test]
fn a_start_preempted_by_the_tick_polls_one_period_after_it_commits() {
    tick_into_a_start_in_a_polled_class::<8, 1>(Layout::One);
    tick_into_a_start_in_a_polled_class::<64, 2>(Layout::Split);
    tick_into_a_start_in_a_polled_class::<64, 2>(Layout::Second);
}
