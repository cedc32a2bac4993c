//! Systematic interleavings of the tick and the lanes, under the portable lock and under a
//! coarse one.
//!
//! With the portable lock (`CriticalSection`) every multi-step operation is several short
//! sections, and any task may call anything: the tick (a timer interrupt) preempts a lane
//! between two sections of a start, an end, a restart, a request, a join or a dropped
//! run's teardown, and a lane of higher priority than the tick runs between two sections of
//! the tick. With RTIC's priority ceiling (`PriorityCeiling` below the top priority,
//! `Lock::COARSE`: the path production firmware runs) each operation's steps run in one
//! section (`in_sections!`), and the tick runs at the ceiling: no lane runs during the
//! tick, but the tick may preempt a lane's operation between two of its sections (the two
//! sections of `Sequencer::begin`, a teardown's `leave` and its cleanup hook, a join's
//! registration and its look, ...). Above the ceiling only `abort_all` (an atomic) is
//! called, at any time.
//!
//! Each test runs one operation once under a test lock ([`Interleaved`], or its coarse
//! twin [`InterleavedCoarse`]) to count its sections, then, for every section `k` (and,
//! where it says so, after the last one), builds a fresh sequencer and runs the operation
//! with another party (a tick that fires a monitor or a timeout or applies a request; a
//! lane's start, end, request or join; a handle; `abort_all`) inserted right before
//! section `k`, and asserts the exact outcome the semantics (docs/semantics.md) demand
//! whatever `k` is: states and causes, the result of the operation, and the invariants of
//! [`World::check`] that hold after every interleaving: nothing active below an aborted
//! caller (semantics 4 and 9), a consistent transition trace (every record's `from` is the
//! previous `to`, an allowed change, nothing lost), no exception sequence refused.
//!
//! - [`fine`]: the tick and the lanes under the portable lock, in a sequencer of one word.
//! - [`more`]: where `fine` did not look: a lane taking its start or dropped while it
//!   waits, pause and resume requests against a `PauseOwner` monitor, joins, sequencers of
//!   two words (the multi-word sets, indexes and `by_depth` candidates), the end of an
//!   exception sequence reported once.
//! - [`coarse`]: the scenarios of both that a coarse lock allows, in sequencers of one
//!   word and of two, and `abort_all` inserted anywhere.
//! - [`lanes`]: a lane of higher priority preempting another lane's operation (no tick in
//!   between), under both locks, in sequencers of one word and of two.
//! - [`polls`]: polled conditions (real lanes polled by hand: the check right after the
//!   action, due polls, their wake-ups), restarts driven by the lane, a child's end against
//!   a `PauseOwner` monitor, under both locks, in one word and two.
//!
//! This module holds what they share: the [`World`] (generic over the lock and the
//! sequencer's size), the loops over `k` ([`sections`], [`every_k`]) and the set-ups and
//! scenarios more than one of them runs.
//!
//! Tests marked `#[ignore = "defect: ..."]` fail today; the reason names the defect.
//!
//! [`Interleaved`]: crate::lock::interleaved::Interleaved
//! [`InterleavedCoarse`]: crate::lock::interleaved::InterleavedCoarse
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

extern crate std;

/// Runs a scenario `f::<L, N, B>(layout, args...)` under both locks, in one word and with
/// the sequences under test in the second; fails naming every world that failed.
macro_rules! every_world {
    ($f:ident $(, $arg:expr)*) => {{
        let mut failed: Vec<String> = Vec::new();
        let mut one = |world: &str, r: std::thread::Result<()>| {
            if let Err(e) = r {
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .unwrap_or_default();
                failed.push(format!("[{world}] {msg}"));
            }
        };
        let run = |f: &dyn Fn()| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
        one("fine, one word", run(&|| $f::<Interleaved, 8, 1>(Layout::One $(, $arg)*)));
        one("fine, two words", run(&|| $f::<Interleaved, 64, 2>(Layout::Second $(, $arg)*)));
        one("coarse, one word", run(&|| $f::<InterleavedCoarse, 8, 1>(Layout::One $(, $arg)*)));
        one("coarse, two words", run(&|| $f::<InterleavedCoarse, 64, 2>(Layout::Second $(, $arg)*)));
        assert!(failed.is_empty(), "{}", failed.join("\n"));
    }};
}

/// A poll of a join as the `Join` future makes it: the run joined is taken at the first
/// poll (`run` keeps its count for the later ones), then the join proper.
fn port_join<C, P: Port<C> + ?Sized>(
    port: &P,
    joiner: SeqId,
    target: SeqId,
    run: &mut Option<u16>,
) -> Poll<Result<Outcome, Error>> {
    let joined = match *run {
        Some(count) => RunId { seq: target, count },
        None => match port.join_run(target) {
            Ok(joined) => joined,
            Err(e) => return Poll::Ready(Err(e)),
        },
    };
    *run = Some(joined.count);
    port.join(joiner, joined)
}

/// The name of a world and a case, for failure messages.
fn name<L>(layout: Layout, rest: core::fmt::Arguments) -> String {
    format!("{layout:?}, {}, {rest}", core::any::type_name::<L>())
}

mod begin_run;
mod changes_during_the_tick;
mod coarse;
mod drops;
mod exception_marks;
mod exception_marks_of_callers;
mod exception_marks_once_stopped;
mod exceptions_gone_with_their_run;
mod fine;
mod grids;
mod holds;
mod lanes;
mod long_gap;
mod more;
mod polls;
mod random;
mod replaced_runs;
mod rounds;
mod safety_cycles;

use core::cell::Cell;
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

use crate::lock::interleaved;
use crate::lock::Lock;
use crate::model::id::RunId;
use crate::sequencer::clearance::Clearance;
use crate::sequencer::control_block::flag;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::trace::{Entry, Record, Transition};
use crate::{
    Behaviour, Cause, Condition, Duration, Error, Event, Instant, Monitor, MonitorId, Monitors,
    Outcome, RunningState, SeqConfig, SeqId, Sequencer,
};

use RunningState::{Aborted, Aborting, Idle, Paused, Restarting, Running, Terminated};

/// A sequencer under lock `L`: `N` sequences in `B` words of 32, a trace no scenario
/// overflows.
type Sq<L, const N: usize, const B: usize> = Sequencer<(), N, 256, L, 8, B>;

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

std::thread_local! {
    /// Whether the last world built on this thread is under a coarse lock (see
    /// [`sections`]).
    static COARSE: Cell<bool> = const { Cell::new(false) };
}

/// A sequencer under lock `L`, the monitor table its ticks use and the records drained so
/// far, all `'static` so that a closure run between two sections can tick.
struct World<L: Lock + 'static, const N: usize, const B: usize> {
    seq: &'static Sq<L, N, B>,
    monitors: &'static RefCell<Monitors<'static, (), 4>>,
    log: &'static RefCell<Vec<Record>>,
    layout: Layout,
    /// The sequencer's tag, given before any operation: the lanes' and blocking starts'
    /// maker, passed without a section of its own.
    tag: u16,
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
        COARSE.with(|c| c.set(L::COARSE));
        let seq: &'static Sq<L, N, B> = Box::leak(Box::new(Sequencer::empty()));
        seq.take_tag();
        let w = World {
            seq,
            monitors: Box::leak(Box::new(RefCell::new(Monitors::new()))),
            log: Box::leak(Box::new(RefCell::new(Vec::new()))),
            layout,
            tag: seq.tag(),
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

    /// How many runs `id` has had (its current run's count).
    fn runs(&self, id: SeqId) -> u16 {
        self.run(id).count
    }

    fn caller(&self, id: SeqId) -> Option<SeqId> {
        self.seq.with(|s| s.block(id).unwrap().caller.get())
    }

    /// Whether a start of `id` is pending for its lane.
    fn pending(&self, id: SeqId) -> bool {
        self.has(id, flag::START_PENDING)
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

    /// A handle of `id`, as an application keeps one: no section to look it up (unlike
    /// [`World::handle`]).
    fn kept(&self, id: SeqId) -> crate::Handle<'static, ()> {
        crate::Handle::new(self.seq, id)
    }

    /// Starts `id` by a handle (a main sequence) and lets its lane take the start.
    fn start_taken(&self, id: SeqId) -> RunId {
        self.handle(id).start().unwrap();
        self.take(id)
    }

    /// `id`'s lane drops its run (`Port::abandon`: aborted, `Dropped`), and a handle starts
    /// `id` again, its lane taking the start; unless the start is refused (a teardown has
    /// `id` `Aborting`).
    fn replace_run(&self, id: SeqId) {
        Port::abandon(self.seq, id, &());
        if self.handle(id).start().is_ok() {
            self.take(id);
        }
    }

    /// `id`'s lane takes its pending start.
    fn take(&self, id: SeqId) -> RunId {
        self.try_take(id).unwrap()
    }

    /// `id`'s lane takes its pending start, if any.
    fn try_take(&self, id: SeqId) -> Option<RunId> {
        Port::take_start(self.seq, id, self.tag, Waker::noop())
    }

    /// `id` started blocking by `caller`'s current run (in `caller`'s lane).
    fn blocking(&self, id: SeqId, caller: SeqId) -> Result<(), Error> {
        start_child(self, self.run(caller), id, How::Blocking)
    }

    /// `id` started in its own lane by `caller`'s current run.
    fn in_lane(&self, id: SeqId, caller: SeqId) -> Result<(), Error> {
        start_child(self, self.run(caller), id, How::InLane)
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

    /// `id`'s lane ends its current run completed and reports it over.
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

    /// The `Fired` records of `owner`, whatever the cause.
    fn fired_any(&self, owner: SeqId) -> usize {
        self.records()
            .iter()
            .filter(|r| matches!(r.event(), Some(Event::Fired { owner: o, .. }) if o == owner))
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
    /// 11, never one that was aborted); no start left pending on a sequence that is not
    /// under way; the trace's transitions chain (each `from` is the
    /// sequence's last `to`, from `Idle`), are allowed changes and end in each sequence's
    /// current state; no exception sequence refused. `what` names the interleaving.
    fn check(&self, what: &str) {
        self.check_tree(what);
        assert_eq!(
            self.seq.exceptions_not_run(),
            0,
            "{what}: an exception not run"
        );
    }

    /// The invariants of [`check`](Self::check) but the last: an exception sequence may
    /// have been refused (still handling an earlier exception).
    fn check_tree(&self, what: &str) {
        let count = self.count();
        for i in 0..count {
            let id = SeqId::from_index(i);
            let state = self.state(id);
            if self.pending(id) {
                assert!(
                    [Running, Paused, Restarting].contains(&state),
                    "{what}: {id:?} {state:?} with a start pending"
                );
            }
            if ![Running, Paused, Restarting].contains(&state) {
                continue;
            }
            // An exception marked on a run under way ends: its behaviour waits for an
            // exception sequence handling it (or for the tick to report that one's end),
            // its stop has begun or is requested, or a restart will begin the run again
            // without it. Else the run is held for good.
            if state != Restarting && self.in_set(Set::Excepting, id) {
                let handled = self.seq.with(|s| {
                    let b = s.block(id).unwrap();
                    (b.has(flag::EXCEPTION_DONE) && b.pending().is_some())
                        || (b.has(crate::sequencer::control_block::request::ABORT)
                            && s.sets.has(Set::Requested, id))
                        || (b.pending().is_some()
                            && (0..count).any(|e| {
                                let e = s.block(SeqId::from_index(e)).unwrap();
                                e.has(flag::HANDLES_EXCEPTION) && e.caller.get() == Some(id)
                            }))
                });
                assert!(
                    handled,
                    "{what}: {id:?} {state:?} held by an exception that nothing handles"
                );
            }
            // A behaviour waits only for an exception that holds its run.
            if state != Restarting {
                let pending = self.seq.with(|s| s.block(id).unwrap().pending());
                assert!(
                    pending.is_none() || self.in_set(Set::Excepting, id),
                    "{what}: {id:?} {state:?} with {pending:?} pending and no exception"
                );
            }
            // A teardown that placed a sequence moves it before it returns.
            if state != Restarting {
                assert!(
                    !self.has(id, flag::STOPPING),
                    "{what}: {id:?} {state:?} placed by a teardown that is over"
                );
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

/// The sections `op` takes, undisturbed, on a fresh world from `setup`: at least two
/// under the portable lock; with a coarse lock an operation may take a single one.
fn sections<S>(setup: impl Fn() -> S, op: impl Fn(&S)) -> usize {
    let n = sections_at_least(1, setup, op);
    // The lock of the world `setup` built.
    let least = if COARSE.with(Cell::get) { 1 } else { 2 };
    assert!(n >= least, "{n} sections");
    n
}

/// The sections `op` takes, undisturbed, on a fresh world from `setup`: at least `least`
/// (one for an operation that may be refused at its first look, under either lock).
fn sections_at_least<S>(least: usize, setup: impl Fn() -> S, op: impl Fn(&S)) -> usize {
    let s = setup();
    interleaved::at(usize::MAX, || {});
    op(&s);
    let n = interleaved::taken();
    assert!(n >= least, "{n} sections");
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

/// O (main, polled every ms) runs, started at 0, with a monitor `b` whose condition holds
/// (no exception sequence). Returns the world and O.
fn watched<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
) -> (World<L, N, B>, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    w.monitor(o, flag_of(true), b, None);
    w.start_taken(o);
    (w, o)
}

/// [`watched`] by a `RestartOwner` monitor that restarted O at 1 ms (its condition stays
/// true). Returns the world, O and O's run, to be restarted by O's lane.
fn restarting<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, RunId) {
    let (w, o) = watched::<L, N, B>(layout, Behaviour::RestartOwner);
    w.tick(1);
    assert_eq!(w.state(o), Restarting);
    (w, o, w.run(o))
}

/// O (polled every ms) with a `RestartOwner` monitor whose condition was true at 1 ms: O
/// is `Restarting`, the condition cleared. Returns the world, O and O's run, to be
/// restarted by O's lane.
fn restarted_once<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let fault = flag_of(true);
    w.monitor(o, fault, Behaviour::RestartOwner, None);
    w.start_taken(o);
    w.tick(1);
    assert_eq!(w.state(o), Restarting);
    fault.store(false, Ordering::Relaxed);
    (w, o, w.run(o))
}

/// As [`restarted_once`], and an abort of O (a request with `by_request`, else an
/// abort-all) is pending.
fn restarting_then_aborted<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    by_request: bool,
) -> (World<L, N, B>, SeqId, RunId) {
    let (w, o, run) = restarted_once(layout);
    if by_request {
        w.handle(o).abort().unwrap();
    } else {
        w.seq.abort_all();
    }
    (w, o, run)
}

/// O's lane obeys `Restart` (`Sequencer::restart`) on a world from
/// [`restarting_then_aborted`]; the tick at 2 ms, which carries the abort out, comes
/// before each section of the restart (and, `and_after`, after it). The abort stands
/// whatever `k`: O ends `Aborted` (the request's or the abort-all's cause) and is never
/// `Running` again without a new start.
fn abort_during_restart<L: Lock + 'static, const N: usize, const B: usize>(and_after: bool) {
    for by_request in [false, true] {
        let setup = move || restarting_then_aborted::<L, N, B>(Layout::One, by_request);
        let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
        every_k(count + usize::from(and_after), |k| {
            let (w, o, run) = setup();
            interleaved::at(k, move || w.tick(2));
            w.seq.restart(run);
            if and_after {
                or_after(k, || w.tick(2));
            }
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

// =======================================================================================
// The tick inserted into a start (in the child's lane, or blocking).
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
    /// `Port::start_child(C, O's run)`: non-blocking, in C's own lane.
    InLane,
    /// `Sequencer::begin(C, O's run, Mode::Blocking)`: in O's lane (`Cx::run`).
    Blocking,
}

/// O (a main sequence, polled every ms) runs, started at 0; `fire` set up for the tick at
/// 1 ms. C (timeout 5 ms) and E are registered (in the second word with
/// `Layout::Split`). Returns the world, O, C, E and O's run.
fn owner_and_child<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    fire: Fire,
) -> (World<L, N, B>, SeqId, SeqId, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
    let o = match fire {
        Fire::Timeout => w.timed("O", 1),
        _ => w.seq("O"),
    };
    w.split();
    let c = w.timed("C", 5);
    let e = w.seq("E");
    let on = flag_of(true);
    let b = match fire {
        Fire::Abort | Fire::AbortAfterE => Some(Behaviour::AbortOwner),
        Fire::Restart => Some(Behaviour::RestartOwner),
        Fire::Pause => Some(Behaviour::PauseOwner),
        Fire::Timeout | Fire::AbortRequest => None,
    };
    if let Some(b) = b {
        w.monitor(o, on, b, (fire == Fire::AbortAfterE).then_some(e));
    }
    let run = w.start_taken(o);
    if fire == Fire::AbortRequest {
        w.handle(o).abort().unwrap();
    }
    (w, o, c, e, run)
}

/// The start of C by O's run `by`, `how`.
fn start_child<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    by: RunId,
    c: SeqId,
    how: How,
) -> Result<(), Error> {
    match how {
        How::InLane => Port::start_child(w.seq, c, by).map(drop),
        How::Blocking => w
            .seq
            .begin(
                c,
                Mode::Blocking {
                    caller: by,
                    maker: w.tag,
                },
                Cause::Start,
            )
            .map(|_| ()),
    }
}

/// For every section `k` of a start of C by O (`how`), the tick at 1 ms (doing `fire` to
/// O) before section `k`, then what `fire` leads to (E ends, the next tick). Checks the
/// outcome with `expect(what, start result, w, o, c)` and the invariants.
fn tick_into_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    fire: Fire,
    how: How,
    expect: impl Fn(&str, Result<(), Error>, &World<L, N, B>, SeqId, SeqId),
) {
    let count = sections(
        || owner_and_child::<L, N, B>(layout, fire),
        |(w, _, c, _, run)| {
            let _ = start_child(w, *run, *c, how);
        },
    );
    every_k(count, |k| {
        let (w, o, c, e, run) = owner_and_child::<L, N, B>(layout, fire);
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
fn torn_down_with<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    started: Result<(), Error>,
    w: &World<L, N, B>,
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

/// O starts C (in C's lane, or blocking) while the tick aborts O (its `AbortOwner`
/// monitor, its timeout, an abort request, or its monitor after its exception sequence E
/// ended): the start is refused (`NotRunning(O)`) and C never ran, or C is aborted with
/// O, with O's cause.
fn starts_by_an_aborted_sequence<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    for how in [How::InLane, How::Blocking] {
        for fire in [
            Fire::Abort,
            Fire::AbortAfterE,
            Fire::Timeout,
            Fire::AbortRequest,
        ] {
            tick_into_start::<L, N, B>(layout, fire, how, |what, started, w, o, c| {
                let cause = match fire {
                    Fire::Timeout => Cause::Timeout(o),
                    Fire::AbortRequest => Cause::Abort,
                    _ => M0,
                };
                torn_down_with(what, started, w, o, c, (Aborted, cause));
            });
        }
    }
}

/// O starts C (either way) while the tick restarts O (`RestartOwner`): C is refused or
/// aborted with the monitor's cause; O is `Restarting`.
fn starts_by_a_restarted_sequence<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    for how in [How::InLane, How::Blocking] {
        tick_into_start::<L, N, B>(layout, Fire::Restart, how, |what, r, w, o, c| {
            torn_down_with(what, r, w, o, c, (Restarting, M0));
        });
    }
}

/// O starts C in C's own lane while the tick pauses O (`PauseOwner`): the start succeeds
/// and C runs; O is paused.
fn non_blocking_start_paused<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    tick_into_start::<L, N, B>(
        layout,
        Fire::Pause,
        How::InLane,
        |what, started, w, o, c| {
            assert_eq!(started, Ok(()), "{what}");
            assert_eq!((w.state(o), w.state(c)), (Paused, Running), "{what}");
        },
    );
}

/// O starts C blocking while the tick pauses O (`PauseOwner`, its condition stays true):
/// C ends up `Paused` with O, and its 5 ms timeout does not run out while O stays paused
/// for 10 ms (semantics 7).
fn blocking_start_paused<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    tick_into_start::<L, N, B>(
        layout,
        Fire::Pause,
        How::Blocking,
        |what, started, w, o, c| {
            assert_eq!(started, Ok(()), "{what}");
            for ms in 2..=11 {
                w.tick(ms);
            }
            assert_eq!(
                (w.state(o), w.ended(c)),
                (Paused, (Paused, Cause::Start)),
                "{what}: after 10 ms"
            );
        },
    );
}

// =======================================================================================
// A lane of higher priority inserted into the tick's teardown.
// =======================================================================================

/// How the tick is made to tear R's tree down.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Teardown {
    /// An abort request of R.
    Request,
    /// An abort-all.
    AbortAll,
    /// R's `AbortOwner` monitor, no exception sequence.
    Monitor,
}

/// R's run starts Y non-blocking (Y's lane takes it), and Y runs X blocking (in Y's lane).
fn chain<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    r: SeqId,
    y: SeqId,
    x: SeqId,
) {
    Port::start_child(w.seq, y, w.run(r)).unwrap();
    w.take(y);
    w.seq
        .begin(
            x,
            Mode::Blocking {
                caller: w.run(y),
                maker: w.tag,
            },
            Cause::Start,
        )
        .unwrap();
}

/// R (main, in the first word with `Layout::Split`) started Y non-blocking, Y runs X
/// blocking (in Y's lane); G is registered; Y, X, G in the second word (with
/// `Layout::Second` all are). With `deep` false only R runs (nothing has a caller link:
/// the walk's shortcut). The teardown `how` is set up for the tick at 1 ms. Returns the
/// world, R, Y, X, G.
fn tree<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    how: Teardown,
    deep: bool,
) -> (World<L, N, B>, [SeqId; 4]) {
    let w = World::<L, N, B>::new(layout);
    let r = w.seq("R");
    w.split();
    let [y, x, g] = ["Y", "X", "G"].map(|n| w.seq(n));
    if how == Teardown::Monitor {
        w.monitor(r, flag_of(true), Behaviour::AbortOwner, None);
    }
    w.start_taken(r);
    if deep {
        chain(&w, r, y, x);
    }
    // A tick before the one under test folds the tree into the monitored set: the class is
    // busy, so a start made during the tick at 1 ms keeps its grid.
    w.tick(0);
    match how {
        Teardown::Request => w.handle(r).abort().unwrap(),
        Teardown::AbortAll => w.seq.abort_all(),
        Teardown::Monitor => {}
    }
    (w, [r, y, x, g])
}

/// For every section `k` of the tick at 1 ms that tears R's tree down (`how`), a lane of
/// higher priority than the tick runs before section `k`: `starter`'s action (Y's when
/// `deep`, else R's) starts G in G's lane. Wherever it lands, the tick leaves nothing
/// under way: G is refused (`NotRunning`) or aborted with the tree (semantics 4: an abort
/// reaches every active sub-sequence; 9: nothing an action starts outlives its abort).
fn lane_start_into_teardown<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    how: Teardown,
    deep: bool,
) {
    let count = sections(|| tree::<L, N, B>(layout, how, deep), |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, [r, y, x, g]) = tree::<L, N, B>(layout, how, deep);
        let starter = if deep { y } else { r };
        let result = Rc::new(RefCell::new(None));
        let out = result.clone();
        interleaved::at(k, move || {
            let by = w.run(starter);
            *out.borrow_mut() = Some(Port::start_child(w.seq, g, by).map(drop));
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

// =======================================================================================
// A lane's end and a firing tick.
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

impl Firing {
    /// Whether O has an exception sequence E.
    fn with_e(self) -> bool {
        matches!(self, Firing::AbortAfterE | Firing::RestartAfterE)
    }

    /// The cause of what fires on O.
    fn cause(self, o: SeqId) -> Cause {
        match self {
            Firing::Timeout => Cause::Timeout(o),
            _ => M0,
        }
    }
}

/// E and O (polled every ms; in the second word with `Layout::Split`), O running, started
/// at 0, with `firing` set up for the tick at 1 ms. Returns the world, O, E and O's run.
fn firing_on<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    firing: Firing,
) -> (World<L, N, B>, SeqId, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
    let e = w.seq("E");
    w.split();
    let o = match firing {
        Firing::Timeout => w.timed("O", 1),
        _ => w.seq("O"),
    };
    let b = match firing {
        Firing::Abort | Firing::AbortAfterE => Some(Behaviour::AbortOwner),
        Firing::Restart | Firing::RestartAfterE => Some(Behaviour::RestartOwner),
        Firing::Timeout => None,
    };
    if let Some(b) = b {
        w.monitor(o, flag_of(true), b, firing.with_e().then_some(e));
    }
    let run = w.start_taken(o);
    (w, o, e, run)
}

/// After the firing on O came first (the end refused): with E, E runs to its end and the
/// next tick applies O's behaviour; O ends aborted (or restarting), once (one `Fired`, one
/// transition to the behaviour's state), and stays so after the next tick.
fn firing_carried_out<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    firing: Firing,
    o: SeqId,
    e: SeqId,
    end: impl Fn() -> bool,
) {
    if firing.with_e() {
        assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
        assert!(!end(), "{what}: O holds");
        w.take(e);
        assert!(w.complete(e), "{what}");
        w.tick(2);
    }
    let cause = firing.cause(o);
    let (to, n) = match firing {
        Firing::Abort | Firing::AbortAfterE | Firing::Timeout => {
            (Aborted, w.moves(o, Aborting, Aborted))
        }
        Firing::RestartAfterE | Firing::Restart => (Restarting, w.moves(o, Running, Restarting)),
    };
    assert_eq!(w.ended(o), (to, cause), "{what}");
    assert_eq!((n, w.fired(o, cause)), (1, 1), "{what}: once");
    w.tick(3);
    assert_eq!(w.ended(o), (to, cause), "{what}: after");
}

/// O's lane, of higher priority than the tick, ends O's run (completed) before section `k`
/// of the tick at 1 ms in which `firing` fires on O. Either the end comes first: O is
/// `Terminated` (completed), and nothing fires for the ended run (no `Fired` record, no
/// exception sequence refused, E never started, no exception counted); or the firing comes
/// first: the end is refused (O holds, or is restarting or aborted), and the firing takes
/// its course ([`firing_carried_out`]).
fn end_into_firing_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    firing: Firing,
) {
    let setup = move || firing_on::<L, N, B>(layout, firing);
    let count = sections(setup, |(w, _, _, _)| w.tick(1));
    every_k(count, |k| {
        let (w, o, e, _) = setup();
        let ended = Rc::new(RefCell::new(None));
        let out = ended.clone();
        interleaved::at(k, move || *out.borrow_mut() = Some(w.complete(o)));
        w.tick(1);
        let what = format!("{layout:?}, {firing:?}, k={k}");
        let ended = ended.borrow().expect("the lane ran");
        if ended {
            assert_eq!(w.state(o), Terminated, "{what}");
            assert_eq!(
                w.seq.with(|s| s.block(o).unwrap().outcome),
                Some(Outcome::Completed),
                "{what}"
            );
            assert_eq!(w.state(e), Idle, "{what}: E");
            assert_eq!(w.seq.exceptions_not_run(), 0, "{what}");
            #[cfg(feature = "counters")]
            assert_eq!(w.handle(o).counters().exceptions, 0, "{what}");
            assert_eq!(w.fired(o, firing.cause(o)), 0, "{what}");
            assert_eq!(
                w.fired_any(o),
                0,
                "{what}: a firing recorded for an ended run"
            );
            w.check(&what);
            return;
        }
        firing_carried_out(&what, &w, firing, o, e, || w.complete(o));
        w.check(&what);
    });
}

/// O's lane, of higher priority than the tick, drops O's run (`Port::abandon`: aborted,
/// `Dropped`) and starts O again (a handle; the lane takes run 2) before section `k` of the
/// tick at 1 ms in which `firing` fires on O. A firing recorded before run 2 began is run
/// 1's and never reaches run 2: after the tick, run 2 is `Running` and holds no exception
/// and no behaviour waiting for E, and E, if it started for run 1, was aborted with it. (A run 2 begun before the tick's
/// scan is due in it, and its own firing takes its course; one begun after it is evaluated
/// from the next tick, semantics 3.)
fn replaced_during_firing_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    firing: Firing,
) {
    let setup = move || firing_on::<L, N, B>(layout, firing);
    let count = sections(setup, |(w, _, _, _)| w.tick(1));
    every_k(count, |k| {
        let (w, o, e, _) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(1);
        let what = format!("{layout:?}, {firing:?}, k={k}");
        let records = w.records();
        let run_2_began = records.iter().rposition(|r| {
            matches!(r.entry, Entry::Transition { sequence, to: Running, cause: Cause::Start, .. }
                if sequence == o)
        });
        let fired = records
            .iter()
            .position(|r| matches!(r.event(), Some(Event::Fired { owner, .. }) if owner == o));
        if fired > run_2_began || w.runs(o) == 1 {
            // Run 2's own firing, or no run 2.
            w.check(&what);
            return;
        }
        assert_eq!((w.state(o), w.runs(o)), (Running, 2), "{what}");
        assert!(
            !w.in_set(Set::Excepting, o),
            "{what}: run 2 holds run 1's exception"
        );
        let pending = w.seq.with(|s| s.block(o).unwrap().pending());
        assert_eq!(pending, None, "{what}: run 2 waits with run 1's behaviour");
        assert!(
            matches!(w.state(e), Idle | Aborted),
            "{what}: E {:?}",
            w.state(e)
        );
        w.check(&what);
    });
}

// =======================================================================================
// Requests of a handle around a tick.
// =======================================================================================

/// A request of O, by a handle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ask {
    Pause,
    Resume,
}

fn ask<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    o: SeqId,
    a: Ask,
) -> Result<(), Error> {
    match a {
        Ask::Pause => w.handle(o).pause(),
        Ask::Resume => w.handle(o).resume(),
    }
}

/// O (5 ms timeout, started at 0) with a `PauseOwner` monitor whose condition is the
/// returned flag, set to `holds`; with `paused_by_request`, O's pause was requested. With
/// `tick`, the tick at 1 ms has paused O (by the request, or the monitor).
fn pausable<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    holds: bool,
    paused_by_request: bool,
    tick: bool,
) -> (World<L, N, B>, SeqId, &'static AtomicBool) {
    let w = World::<L, N, B>::new(layout);
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

/// [`pausable`]: O paused by a request at 1 ms, its monitor's condition holding from 2 ms.
fn paused_then_held<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, &'static AtomicBool) {
    let (w, o, on) = pausable::<L, N, B>(layout, false, true, true);
    on.store(true, Ordering::Relaxed);
    (w, o, on)
}

/// [`pausable`]: O paused by its monitor at 1 ms, the condition clear from 2 ms.
fn paused_then_released<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, &'static AtomicBool) {
    let (w, o, on) = pausable::<L, N, B>(layout, true, false, true);
    on.store(false, Ordering::Relaxed);
    (w, o, on)
}

/// After a resume of O (`asked`) around the tick at 2 ms, on a world from
/// [`paused_then_held`]. Refused (`HeldByMonitor`: the monitor held first), the request's
/// pause stays: O stays paused after the condition clears (4 ms) until a resume request
/// (applied at 6 ms). Accepted, it lifts the request's pause (carried out now or when the
/// monitor lets go): O resumes when the condition clears, at 4 ms. O's clock: 1 ms used,
/// the timeout runs out 4 ms after the resume: at exactly 8 ms or 10 ms.
fn resumed_around_holding_tick<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    asked: Result<(), Error>,
    w: &World<L, N, B>,
    o: SeqId,
    on: &'static AtomicBool,
) {
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
}

/// After a resume of O around the tick at 2 ms, on a world from [`paused_then_released`]:
/// O runs from 2 ms, resumed once; its timeout (1 ms used) runs out at exactly 6 ms.
fn resumed_around_releasing_tick<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
) {
    assert_eq!(w.state(o), Running, "{what}: released");
    assert_eq!(w.runs_until(o, 3, 20), 6, "{what}: the timeout");
    assert_eq!(w.moves(o, Paused, Running), 1, "{what}");
}

/// After a pause of O (`asked`) around the tick at 2 ms, on a world from
/// [`paused_then_released`]: accepted either way. Made while O's monitor still held it,
/// it keeps O paused when the tick releases it (1 ms of the timeout used); made after the
/// release, it pauses O at 3 ms, the next tick (2 ms used). O stays paused until a resume
/// request, applied at 5 ms: the timeout runs out at exactly 9 ms or 8 ms.
fn paused_around_releasing_tick<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    asked: Result<(), Error>,
    w: &World<L, N, B>,
    o: SeqId,
    _: &'static AtomicBool,
) {
    assert_eq!(asked, Ok(()), "{what}");
    let kept_paused = w.state(o) == Paused;
    w.tick(3);
    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
    w.tick(4);
    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
    assert_eq!(ask(w, o, Ask::Resume), Ok(()), "{what}");
    w.tick(5);
    assert_eq!(w.state(o), Running, "{what}: resumed");
    let timeout = if kept_paused { 9 } else { 8 };
    assert_eq!(w.runs_until(o, 6, 20), timeout, "{what}: the timeout");
}

// =======================================================================================
// Joins.
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
    fn started<L: Lock + 'static, const N: usize, const B: usize>(
        w: &World<L, N, B>,
        id: SeqId,
    ) -> Joiner {
        let (waker, wakes) = counting();
        w.handle(id).start().unwrap();
        Port::take_start(w.seq, id, w.tag, &waker).unwrap();
        Joiner {
            id,
            run: None,
            wakes,
        }
    }

    fn poll<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: &World<L, N, B>,
        target: SeqId,
    ) -> Poll<Result<Outcome, Error>> {
        port_join(w.seq, self.id, target, &mut self.run)
    }

    /// What an executor does after a poll that began at `wakes_before` wake-ups and gave
    /// `polled`: a `Pending` poll during which the waker was woken is polled again (once
    /// more for each wake-up meanwhile).
    fn repoll<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: &World<L, N, B>,
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

    fn joining<L: Lock + 'static, const N: usize, const B: usize>(
        &self,
        w: &World<L, N, B>,
    ) -> bool {
        w.in_set(Set::Joining, self.id)
    }

    /// After a `Pending` poll: the joined run ended since (`wakes_before` wake-ups then),
    /// so the joiner was released and woken; its next poll is ready.
    fn released<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: &World<L, N, B>,
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

    /// The outcome of a join whose last poll gave `polled` (at `wakes_before` wake-ups),
    /// once the joined run is over: ready then, or released since.
    fn outcome<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: &World<L, N, B>,
        target: SeqId,
        wakes_before: usize,
        polled: Poll<Result<Outcome, Error>>,
        what: &str,
    ) -> Result<Outcome, Error> {
        match polled {
            Poll::Ready(r) => r,
            Poll::Pending => self.released(w, target, wakes_before, what),
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

impl JoinTick {
    /// The cause of O's abort or restart.
    fn cause(self) -> Cause {
        match self {
            JoinTick::Abort | JoinTick::Restart => M0,
            JoinTick::Request => Cause::Abort,
        }
    }
}

/// O runs (J1 and J2 in the second word with `Layout::Split`), `tick` set up for the tick
/// at 1 ms; J1 and J2 run, and J2 has joined O's run (pending). Returns the world, O and
/// the joiners J1, J2.
fn joined<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    tick: JoinTick,
) -> (World<L, N, B>, SeqId, [Joiner; 2]) {
    let w = World::<L, N, B>::new(layout);
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
}

/// After J1's first poll (`first`) of O's run, restarted by the tick at 1 ms: a restart
/// is the same run, so both joiners still wait; O's lane restarts it and completes it,
/// which releases both: `Completed`.
fn joined_through_a_restart<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    [j1, j2]: [&mut Joiner; 2],
    first: Poll<Result<Outcome, Error>>,
) {
    assert_eq!(w.ended(o), (Restarting, M0), "{what}");
    assert_eq!(first, Poll::Pending, "{what}: J1");
    assert_eq!(j1.run, Some(1), "{what}");
    // A restart is the same run: both still wait.
    assert!(j1.joining(w) && j2.joining(w), "{what}");
    assert_eq!(j2.poll(w, o), Poll::Pending, "{what}: J2");
    let (j1_wakes, j2_wakes) = (woken(&j1.wakes), woken(&j2.wakes));
    w.seq.restart(w.run(o));
    assert_eq!(w.state(o), Running, "{what}");
    assert!(w.complete(o), "{what}");
    let r = j1.released(w, o, j1_wakes, what);
    assert_eq!(r, Ok(Outcome::Completed), "{what}: J1");
    let r = j2.released(w, o, j2_wakes, what);
    assert_eq!(r, Ok(Outcome::Completed), "{what}: J2");
}

// =======================================================================================
// A lane taking its start, or dropped while it waits, against the tick.
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
fn pending_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    tick: Tick,
) -> (World<L, N, B>, SeqId, SeqId, &'static AtomicBool) {
    let w = World::<L, N, B>::new(layout);
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

/// O's lane takes O's pending start (`Port::take_start`, a counting waker) while the tick
/// at 1 ms does `tick` to O, before each section of the take, or after it (`k` = the
/// count). The lane takes the run it was started for, or nothing when the tick aborted
/// it first (an abort leaves no start to take); the clearance of a taken run says what
/// the tick did: `Aborted(cause)`, `Restart`, `Hold`. After the take, a tick that changed
/// the run woke the lane. An aborted O can be started and taken again (run 2); a restarted
/// one runs again; a paused one resumes when the monitor lets go, its clock stopped in
/// between (its 5 ms timeout, 1 ms of it used at the pause, runs out at exactly 6 ms).
fn take_during_tick<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout, tick: Tick) {
    let count = sections(
        || pending_start::<L, N, B>(layout, tick),
        |(w, o, _, _)| {
            Port::take_start(w.seq, *o, w.tag, Waker::noop());
        },
    );
    every_k(count + 1, |k| {
        let (w, o, e, on) = pending_start::<L, N, B>(layout, tick);
        let what = format!("{layout:?}, {tick:?}, k={k}");
        let (waker, wakes) = counting();
        interleaved::at(k, move || w.tick(1));
        let taken = Port::take_start(w.seq, o, w.tag, &waker);
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

/// O's lane is dropped while it waits for O's pending start (`Port::abandon_start`), and
/// the tick at 1 ms does `tick` to O before each section. The start made but not taken is
/// aborted (semantics 13): O ends `Aborted` once, by the drop (`Dropped`), or by the tick
/// when the tick aborted it first (then the drop finds no start); never left under way. A
/// restart or a pause by the tick leaves the start pending: the drop aborts it. With the
/// exception sequence E started by the tick below O, E is torn down with O, and the ticks
/// after, which report E's end, change nothing.
fn abandon_during_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    tick: Tick,
) {
    let count = sections(
        || pending_start::<L, N, B>(layout, tick),
        |(w, o, _, _)| Port::abandon_start(w.seq, *o, w.tag, &()),
    );
    every_k(count, |k| {
        let (w, o, e, _) = pending_start::<L, N, B>(layout, tick);
        let what = format!("{layout:?}, {tick:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        Port::abandon_start(w.seq, o, w.tag, &());
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
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

// =======================================================================================
// Restarts, dropped runs and exception sequences.
// =======================================================================================

/// R runs X blocking (X in the second word with `Layout::Split`), E is registered; X's
/// monitor (`behaviour`, exception sequence E for `AbortOwner`) holds from 1 ms. Returns
/// the world, R, X, E.
fn caller_and_blocked<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) -> (World<L, N, B>, [SeqId; 3]) {
    let w = World::<L, N, B>::new(layout);
    let r = w.seq("R");
    w.split();
    let [x, e] = ["X", "E"].map(|n| w.seq(n));
    let e_of = (behaviour == Behaviour::AbortOwner).then_some(e);
    w.monitor(x, flag_of(true), behaviour, e_of);
    w.start_taken(r);
    w.seq
        .begin(
            x,
            Mode::Blocking {
                caller: w.run(r),
                maker: w.tag,
            },
            Cause::Start,
        )
        .unwrap();
    (w, [r, x, e])
}

/// R's run is dropped (`Port::abandon`) while the tick at 1 ms fires X's monitor
/// (`behaviour`), on a world from [`caller_and_blocked`], the tick before each section of
/// the teardown (and, `and_after`, after it). Everything is torn down (semantics 13): R
/// and X aborted once (`Dropped`), E not left under way (never started, or aborted with
/// X), and nothing is under way after the next tick either (an exception sequence's end
/// reported to an aborted owner applies nothing). Only a tick before the teardown's first
/// stop, with `AbortCallerOfOwner`, aborts R and X itself (the monitor's cause); the
/// teardown then finds nothing.
fn tick_into_dropped_run<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
    and_after: bool,
) {
    let setup = move || caller_and_blocked::<L, N, B>(layout, behaviour);
    let count = sections(setup, |(w, [r, ..])| Port::abandon(w.seq, *r, &()));
    every_k(count + usize::from(and_after), |k| {
        let (w, [r, x, e]) = setup();
        interleaved::at(k, move || w.tick(1));
        Port::abandon(w.seq, r, &());
        if and_after {
            or_after(k, || w.tick(1));
        }
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        // A tick before the teardown's first stop, with `AbortCallerOfOwner`, aborts R and
        // X itself: then both with the monitor's cause.
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

/// E and O (in the second word with `Layout::Split`); O's `RestartOwner` monitor M0
/// restarted O at 1 ms; its `AbortOwner` monitor M1 with exception sequence E holds from
/// 2 ms. Returns the world, O, E and O's run, to be restarted by O's lane.
fn restarting_before_a_firing<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
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
}

/// After M1 fired on the restarted run of a world from [`restarting_before_a_firing`] in
/// the tick at `ms`: E runs for O, which holds; E's lane ends E, and once E's end is
/// folded O is aborted by M1, once; E ran once.
fn aborted_after_e_once<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    e: SeqId,
    ms: u64,
) {
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
    w.check(what);
}

/// O and E (in the second word with `Layout::Split`); O's `behaviour` monitor with
/// exception sequence E fired at 1 ms; E runs (taken), and an abort of E was requested.
/// Returns the world, O, E and E's run.
fn exception_to_abort<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) -> (World<L, N, B>, SeqId, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
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
}

/// After E, of a world from [`exception_to_abort`], ended once (aborted by the request):
/// the tick at 3 ms applies O's behaviour, once (O aborted or restarting by
/// the monitor); E is free again.
fn behaviour_applied_once<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    e: SeqId,
    behaviour: Behaviour,
) {
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
    w.check(what);
}

/// E and O (in the second word with `Layout::Split`); O's `behaviour` monitor with
/// exception sequence E fired at 1 ms; E ran to its end. Returns the world, O, E.
fn exception_ended<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) -> (World<L, N, B>, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let e = w.seq("E");
    w.split();
    let o = w.seq("O");
    w.monitor(o, flag_of(true), behaviour, Some(e));
    w.start_taken(o);
    w.tick(1);
    w.take(e);
    assert!(w.complete(e));
    (w, o, e)
}

/// After O's run, of a world from [`exception_ended`], was dropped around the tick at
/// 2 ms that reports E's end: O stays aborted by `cause` after the next tick, aborted
/// once; the monitor fired once; E's end is folded.
fn dropped_owner_once<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    e: SeqId,
    cause: Cause,
) {
    w.tick(3);
    assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
    assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
    assert_eq!(w.fired(o, M0), 1, "{what}");
    assert_eq!(w.state(e), Terminated, "{what}");
    assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
    assert!(!w.has(o, flag::EXCEPTION_DONE), "{what}");
    w.check(what);
}

/// O and E (in the second word with `Layout::Split`); O's `AbortOwner` monitor fired at
/// 1 ms and started E, whose start E's lane has not taken; an abort of O (a request, or
/// with `all` an abort-all) is pending. Returns the world, O, E.
fn exception_pending_owner_aborted<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    all: bool,
) -> (World<L, N, B>, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
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
}

/// After E's lane, of a world from [`exception_pending_owner_aborted`], took its start
/// (`taken`) around the tick at 2 ms that aborts O and E: O and E aborted by `cause`; a
/// taken run is E's first, and its clearance says `Aborted`; the tick at 3 ms reports E's
/// end to the aborted O and changes nothing; E is no one's and may be started again.
fn exception_aborted_with_owner<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    e: SeqId,
    taken: Option<RunId>,
    cause: Cause,
) {
    assert_eq!(w.ended(o), (Aborted, cause), "{what}");
    assert_eq!(w.ended(e), (Aborted, cause), "{what}");
    if let Some(run) = taken {
        assert_eq!(run, RunId { seq: e, count: 1 }, "{what}");
        assert_eq!(w.clearance(run), Clearance::Aborted(cause), "{what}");
    }
    w.tick(3);
    assert_eq!(w.ended(o), (Aborted, cause), "{what}: after");
    assert_eq!(w.fired(o, M0), 1, "{what}");
    assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
    assert!(!w.has(e, flag::HANDLES_EXCEPTION), "{what}");
    assert_eq!(w.handle(e).start(), Ok(()), "{what}: E is free");
    w.check(what);
}
