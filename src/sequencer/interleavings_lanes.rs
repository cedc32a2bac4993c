//! Systematic interleavings of two lanes: a lane of higher priority preempting another
//! lane's operation (no tick in between), under both locks.
//!
//! Under RTIC, lanes (async tasks) may have different priorities below the tick: a lane
//! of higher priority runs between two sections of a lower lane's operation. With the
//! portable lock (`Interleaved`) every step of an operation is a section; with a coarse
//! lock (`InterleavedCoarse`, RTIC's priority ceiling) an operation's steps share one
//! section, but an operation may still have several (`Sequencer::begin` has two, a
//! teardown one or two per sequence, a join three).
//!
//! Each test counts the sections of one lane's operation (`op`), then for every section
//! `k`, and once after the last one, builds a fresh sequencer and runs `op` with the other
//! lane's operation (`other`) inserted right before section `k`. Then it ticks when
//! requests or ends must be carried out, and asserts the exact outcome the semantics
//! (docs/semantics.md) demand and the invariants of [`World::check`]. Every scenario runs
//! with both locks, in a sequencer of one word and of two words (the related sequences
//! split over both words).
//!
//! Tests marked `#[ignore = "defect: ..."]` fail today; the reason names the defect.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

extern crate std;

use core::cell::Cell;
use core::fmt::Debug;
use core::sync::atomic::{AtomicUsize, Ordering};
use core::task::{Poll, Waker};
use std::boxed::Box;
use std::cell::RefCell;
use std::format;
use std::rc::Rc;
use std::string::String;
use std::sync::Arc;
use std::task::Wake;
use std::vec::Vec;

use crate::lock::interleaved::{self, Interleaved, InterleavedCoarse};
use crate::lock::Lock;
use crate::model::id::RunId;
use crate::sequencer::control_block::flag;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::sequencer::transition::Clearance;
use crate::trace::{Record, Transition};
use crate::{Cause, Error, Instant, Monitors, Outcome, RunningState, SeqConfig, SeqId, Sequencer};

use RunningState::{Aborted, Aborting, Idle, Paused, Restarting, Running, Terminated};

/// A sequencer under lock `L`: `N` sequences in `B` words of 32, a trace no scenario
/// overflows.
type Sq<L, const N: usize, const B: usize> = Sequencer<(), N, 256, L, 8, B>;

/// Where the sequences under test sit.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    /// A sequencer of one word.
    One,
    /// Two words: those registered before [`World::split`] in the first, the others in
    /// the second.
    Split,
}

/// Runs a scenario `f::<L, N, B>(layout, args...)` under both locks, in one word and in two.
macro_rules! every_world {
    ($f:ident $(, $arg:expr)*) => {{
        $f::<Interleaved, 8, 1>(Layout::One $(, $arg)*);
        $f::<Interleaved, 64, 2>(Layout::Split $(, $arg)*);
        $f::<InterleavedCoarse, 8, 1>(Layout::One $(, $arg)*);
        $f::<InterleavedCoarse, 64, 2>(Layout::Split $(, $arg)*);
    }};
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

/// A lane's counting waker, `'static` so that a scenario stays `Copy`.
#[derive(Clone, Copy)]
struct Counter(&'static Arc<Count>);

impl Counter {
    fn new() -> Counter {
        Counter(Box::leak(Box::new(Arc::new(Count(AtomicUsize::new(0))))))
    }
    fn waker(self) -> Waker {
        Waker::from(self.0.clone())
    }
    fn woken(self) -> usize {
        self.0 .0.load(Ordering::Relaxed)
    }
}

/// A sequencer under lock `L`, the monitor table its ticks use and the records drained so
/// far, all `'static` so that a closure run between two sections can use them.
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
        interleaved::at(usize::MAX, || {});
        World {
            seq: Box::leak(Box::new(Sequencer::empty())),
            monitors: Box::leak(Box::new(RefCell::new(Monitors::new()))),
            log: Box::leak(Box::new(RefCell::new(Vec::new()))),
            layout,
        }
    }

    /// With [`Layout::Split`]: the sequences registered from now on are in the second
    /// word (fillers, never started and without a lane, up to id 32).
    fn split(&self) {
        if self.layout == Layout::Split {
            while self.count() < 32 {
                let name: &'static str =
                    Box::leak(format!("filler {}", self.count()).into_boxed_str());
                self.seq.register(SeqConfig::new(name)).unwrap();
            }
        }
    }

    fn count(&self) -> usize {
        self.seq.with(|s| s.count())
    }

    /// A sequence polled every millisecond, with a lane.
    fn seq(&self, name: &'static str) -> SeqId {
        let id = self.seq.register(SeqConfig::new(name)).unwrap();
        self.handle(id).declare_lane().unwrap();
        id
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

    fn runs(&self, id: SeqId) -> u16 {
        self.run(id).count
    }

    fn caller(&self, id: SeqId) -> Option<SeqId> {
        self.seq.with(|s| s.block(id).unwrap().caller.get())
    }

    fn pending(&self, id: SeqId) -> bool {
        self.seq
            .with(|s| s.block(id).unwrap().has(flag::START_PENDING))
    }

    fn in_set(&self, set: Set, id: SeqId) -> bool {
        self.seq.with(|s| s.sets.has(set, id))
    }

    fn clearance(&self, run: RunId) -> Clearance {
        Port::clearance(self.seq, run, Waker::noop())
    }

    /// A handle of `id`, as an application keeps one (no section to look it up).
    fn handle(&self, id: SeqId) -> crate::Handle<'static, ()> {
        crate::Handle::new(self.seq, id)
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

    /// `id`'s lane takes its pending start, if any.
    fn try_take(&self, id: SeqId) -> Option<RunId> {
        Port::take_start(self.seq, id, 0, Waker::noop())
    }

    /// `id`'s current run ends with `outcome` and reports it over (its lane).
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

    /// `id` started blocking by `caller`'s current run.
    fn blocking(&self, id: SeqId, caller: SeqId) -> Result<(), Error> {
        self.seq
            .begin(
                id,
                Some(self.run(caller)),
                Mode::Blocking { maker: 0 },
                Cause::Start,
                0,
            )
            .map(|_| ())
    }

    /// `id` started in its lane by `caller`'s current run.
    fn in_lane(&self, id: SeqId, caller: SeqId) -> Result<(), Error> {
        Port::start_in_lane(self.seq, id, Some(self.run(caller)))
    }

    fn records(&self) -> Vec<Record> {
        let mut log = self.log.borrow_mut();
        assert_eq!(self.seq.drain_records(|r| log.push(r)), 0, "records lost");
        log.clone()
    }

    fn transitions(&self, id: SeqId) -> Vec<Transition> {
        self.records()
            .iter()
            .filter_map(Record::transition)
            .filter(|t| t.sequence == id)
            .collect()
    }

    fn moves(&self, id: SeqId, from: RunningState, to: RunningState) -> usize {
        self.transitions(id)
            .iter()
            .filter(|t| t.from == from && t.to == to)
            .count()
    }

    /// The invariants of every interleaving: nothing under way (running, paused,
    /// restarting) below an aborted caller, nor blocking in a terminated direct caller (a
    /// non-blocking child may outlive a caller that ended, semantics 11); no start left
    /// pending on a sequence that is not under way; the trace's transitions chain (each
    /// `from` the sequence's last `to`, from `Idle`), are allowed, and end in each
    /// sequence's current state; no exception sequence refused.
    fn check(&self, what: &str) {
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
            let blocking = self.seq.with(|s| {
                let b = s.block(id).unwrap();
                b.caller
                    .get()
                    .is_some_and(|c| s.block(c).unwrap().lane == b.lane)
            });
            let mut at = self.caller(id);
            let mut first = true;
            for _ in 0..crate::MAX_DEPTH {
                let Some(c) = at else { break };
                assert_ne!(
                    self.state(c),
                    Aborted,
                    "{what}: {id:?} is {state:?} below aborted {c:?}"
                );
                if first && blocking {
                    assert_ne!(
                        self.state(c),
                        Terminated,
                        "{what}: {id:?} is {state:?} blocking in terminated {c:?}"
                    );
                }
                first = false;
                at = self.caller(c);
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
        for (i, last) in last.iter().enumerate() {
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
    interleaved::at(usize::MAX, || {});
    assert!(
        failed.is_empty(),
        "failed before sections {failed:?} of {count}; first: {}",
        first.unwrap_or_default()
    );
}

/// Where the other lane came.
#[derive(Clone, Copy, Debug, PartialEq)]
struct At {
    /// Before section `k` of `op` (or after `op`, when `k` is its count).
    k: usize,
    /// After `op`: `op` took fewer than `k + 1` sections.
    after: bool,
}

/// Lane A runs `op` on a scenario from `setup`; lane B, of higher priority, runs `other`
/// before section `k` of it, for every `k`, and once after `op`. Then `expect(what, at, op's
/// result, other's result, scenario)`.
fn interleave<S: Copy + 'static, R, Q: 'static>(
    name: &str,
    setup: impl Fn() -> S,
    op: impl Fn(S) -> R,
    other: impl Fn(S) -> Q + Copy + 'static,
    expect: impl Fn(&str, At, R, Q, S),
) {
    let count = {
        let s = setup();
        interleaved::at(usize::MAX, || {});
        let _ = op(s);
        interleaved::taken()
    };
    assert!(count >= 1, "{name}: {count} sections");
    every_k(count + 1, |k| {
        let s = setup();
        let out: Rc<RefCell<Option<Q>>> = Rc::new(RefCell::new(None));
        let into = out.clone();
        interleaved::at(k, move || *into.borrow_mut() = Some(other(s)));
        let r = op(s);
        let after = interleaved::taken() <= k;
        if after {
            interleaved::at(usize::MAX, || {});
            *out.borrow_mut() = Some(other(s));
        }
        let q = out.borrow_mut().take().expect("the other lane ran");
        let what = format!(
            "{name}, k={k}/{count}{}",
            if after { " (after)" } else { "" }
        );
        expect(&what, At { k, after }, r, q, s);
    });
}

/// A joiner: its sequence, the run it joined (set at its first poll), its lane's waker.
#[derive(Clone, Copy)]
struct Joiner {
    id: SeqId,
    run: &'static Cell<Option<u16>>,
    wakes: Counter,
}

impl Joiner {
    /// `id` is started and its lane takes the start with a counting waker.
    fn started<L: Lock + 'static, const N: usize, const B: usize>(
        w: &World<L, N, B>,
        id: SeqId,
    ) -> Joiner {
        let wakes = Counter::new();
        w.handle(id).start().unwrap();
        Port::take_start(w.seq, id, 0, &wakes.waker()).unwrap();
        Joiner {
            id,
            run: Box::leak(Box::new(Cell::new(None))),
            wakes,
        }
    }

    fn poll<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
        target: SeqId,
    ) -> Poll<Result<Outcome, Error>> {
        let mut run = self.run.get();
        let r = Port::join(w.seq, self.id, target, &mut run);
        self.run.set(run);
        r
    }

    fn joining<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
    ) -> bool {
        w.in_set(Set::Joining, self.id)
    }

    /// A poll that began at `before` wake-ups and gave `polled`: polled again (as an
    /// executor does) while it is pending and was woken meanwhile.
    fn repoll<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
        target: SeqId,
        mut before: usize,
        mut polled: Poll<Result<Outcome, Error>>,
    ) -> Poll<Result<Outcome, Error>> {
        while polled.is_pending() && self.wakes.woken() > before {
            before = self.wakes.woken();
            polled = self.poll(w, target);
        }
        polled
    }

    /// After a pending poll at `before` wake-ups: the joined run ended since, so the
    /// joiner was released and woken, and its next poll is ready.
    fn released<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
        target: SeqId,
        before: usize,
        what: &str,
    ) -> Result<Outcome, Error> {
        assert!(!self.joining(w), "{what}: {:?} not released", self.id);
        assert!(
            self.wakes.woken() > before,
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

    /// The outcome of a join whose last poll gave `polled` at `before` wake-ups, once the
    /// joined run is over.
    fn outcome<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
        target: SeqId,
        before: usize,
        polled: Poll<Result<Outcome, Error>>,
        what: &str,
    ) -> Result<Outcome, Error> {
        match polled {
            Poll::Ready(r) => r,
            Poll::Pending => self.released(w, target, before, what),
        }
    }
}

// =======================================================================================
// 1. Two starts of the same sequence; a start while another lane starts its caller or a
//    child of it.
// =======================================================================================

/// How X is started.
#[derive(Clone, Copy, Debug, PartialEq)]
enum How {
    /// A handle: a main sequence, in X's lane.
    Handle,
    /// In X's lane by P's run.
    InLaneByP,
    /// In X's lane by Q's run.
    InLaneByQ,
    /// Blocking, in P's lane, by P's run.
    BlockingByP,
    /// Blocking, in Q's lane, by Q's run.
    BlockingByQ,
}

impl How {
    fn caller(self, p: SeqId, q: SeqId) -> Option<SeqId> {
        match self {
            How::Handle => None,
            How::InLaneByP | How::BlockingByP => Some(p),
            How::InLaneByQ | How::BlockingByQ => Some(q),
        }
    }

    fn in_lane(self) -> bool {
        matches!(self, How::Handle | How::InLaneByP | How::InLaneByQ)
    }

    fn start<L: Lock + 'static, const N: usize, const B: usize>(
        self,
        w: &World<L, N, B>,
        x: SeqId,
        p: SeqId,
        q: SeqId,
    ) -> Result<(), Error> {
        match (self, self.caller(p, q)) {
            (How::Handle, _) => w.handle(x).start(),
            (How::InLaneByP | How::InLaneByQ, Some(c)) => w.in_lane(x, c),
            (_, Some(c)) => w.blocking(x, c),
            (_, None) => unreachable!(),
        }
    }
}

/// P and Q run (main sequences, their lanes took their starts); X is idle. Lane A starts X
/// (`a`); lane B, of higher priority, starts X (`b`) before section `k` of it. Exactly one
/// start wins (semantics 9: never a race): the other is `AlreadyRunning(X)`. X runs once
/// (run 1, one `Idle → Running`), with the winner's caller link, the winner's lane, and a
/// start pending for its lane iff the winner started it in its lane (which its lane then
/// takes: run 1).
fn two_starts<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout, a: How, b: How) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [p, q] = ["P", "Q"].map(|n| w.seq(n));
        w.split();
        let x = w.seq("X");
        w.start_taken(p);
        w.start_taken(q);
        (w, [x, p, q])
    };
    interleave(
        &format!(
            "{layout:?}, {}, A {a:?}, B {b:?}",
            core::any::type_name::<L>()
        ),
        setup,
        move |(w, [x, p, q])| a.start(&w, x, p, q),
        move |(w, [x, p, q])| b.start(&w, x, p, q),
        |what, _, ra, rb, (w, [x, p, q])| {
            assert!(ra.is_ok() != rb.is_ok(), "{what}: A {ra:?}, B {rb:?}");
            let (winner, lost) = if ra.is_ok() { (a, rb) } else { (b, ra) };
            assert_eq!(lost, Err(Error::AlreadyRunning(x)), "{what}");
            assert_eq!((w.state(x), w.runs(x)), (Running, 1), "{what}");
            assert_eq!(w.moves(x, Idle, Running), 1, "{what}");
            assert_eq!(w.transitions(x).len(), 1, "{what}");
            #[cfg(feature = "counters")]
            assert_eq!(w.handle(x).counters().runs, 1, "{what}");
            let caller = winner.caller(p, q);
            assert_eq!(w.caller(x), caller, "{what}: the winner's link");
            assert_eq!(w.in_set(Set::Called, x), caller.is_some(), "{what}: Called");
            let lane = w.seq.with(|s| {
                let b = s.block(x).unwrap();
                (b.lane, b.own_lane)
            });
            let expected_lane = match caller {
                Some(c) if !winner.in_lane() => w.seq.with(|s| s.block(c).unwrap().lane),
                _ => lane.1,
            };
            assert_eq!(lane.0, expected_lane, "{what}: the winner's lane");
            assert_eq!(w.pending(x), winner.in_lane(), "{what}: pending");
            if winner.in_lane() {
                assert_eq!(w.try_take(x), Some(RunId { seq: x, count: 1 }), "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn two_starts_of_the_same_sequence_in_two_lanes_one_wins() {
    use How::*;
    for (a, b) in [
        (Handle, Handle),
        (InLaneByP, Handle),
        (Handle, InLaneByP),
        (InLaneByP, InLaneByQ),
        (BlockingByP, Handle),
        (Handle, BlockingByP),
        (BlockingByP, InLaneByQ),
        (InLaneByQ, BlockingByP),
        (BlockingByP, BlockingByQ),
    ] {
        every_world!(two_starts, a, b);
    }
}

/// P's run 1 was aborted (a request, applied at 1 ms); its action runs on to its next
/// await point and starts X (in X's lane, or blocking) by run 1, lane A. Lane B, of higher
/// priority, starts P again (a handle; P's lane takes run 2) before section `k` of it. A
/// start by an aborted run is refused whatever `k` (semantics 9, `NotRunning(P)`), also when
/// its caller's sequence runs again meanwhile (the start names run 1); X never runs.
fn start_by_a_replaced_caller<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    blocking: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        w.split();
        let x = w.seq("X");
        let old = w.start_taken(p);
        w.handle(p).abort().unwrap();
        w.tick(1);
        assert_eq!(w.ended(p), (Aborted, Cause::Abort));
        (w, [p, x], old)
    };
    interleave(
        &format!(
            "{layout:?}, {}, blocking {blocking}",
            core::any::type_name::<L>()
        ),
        setup,
        move |(w, [_, x], old)| {
            if blocking {
                w.seq
                    .begin(x, Some(old), Mode::Blocking { maker: 0 }, Cause::Start, 0)
                    .map(|_| ())
            } else {
                Port::start_in_lane(w.seq, x, Some(old))
            }
        },
        |(w, [p, _], _)| {
            w.handle(p).start()?;
            Ok::<_, Error>(w.take(p))
        },
        |what, _, ra, rb, (w, [p, x], _)| {
            assert_eq!(ra, Err(Error::NotRunning(p)), "{what}");
            assert_eq!(rb, Ok(RunId { seq: p, count: 2 }), "{what}");
            assert_eq!((w.state(p), w.state(x)), (Running, Idle), "{what}");
            assert!(!w.pending(x), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_start_by_a_caller_started_again_meanwhile_is_refused() {
    every_world!(start_by_a_replaced_caller, false);
    every_world!(start_by_a_replaced_caller, true);
}

/// P runs; lane A (P's) starts X in X's lane. X's lane, of higher priority, runs before
/// section `k` of that start: it takes X's start if there is one, and X's run starts C in
/// C's lane. The start of X succeeds; X's lane takes run 1 iff it was committed (else it
/// takes it later: nothing is left pending); C starts iff X was running (else
/// `NotRunning(X)`), then below X.
fn start_while_its_lane_starts_a_child<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        w.split();
        let [x, c] = ["X", "C"].map(|n| w.seq(n));
        w.start_taken(p);
        (w, [p, x, c])
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, [p, x, _])| w.in_lane(x, p),
        |(w, [_, x, c])| {
            let taken = w.try_take(x);
            let child = w.in_lane(c, x);
            (taken, child)
        },
        |what, _, ra, (taken, child), (w, [p, x, c])| {
            assert_eq!(ra, Ok(()), "{what}");
            assert_eq!(
                (w.state(x), w.runs(x), w.caller(x)),
                (Running, 1, Some(p)),
                "{what}"
            );
            match taken {
                Some(run) => {
                    assert_eq!(run, RunId { seq: x, count: 1 }, "{what}");
                    assert!(!w.pending(x), "{what}");
                }
                None => assert_eq!(w.try_take(x), Some(RunId { seq: x, count: 1 }), "{what}"),
            }
            match child {
                Ok(()) => {
                    assert!(taken.is_some(), "{what}: C started by an untaken run");
                    assert_eq!((w.state(c), w.caller(c)), (Running, Some(x)), "{what}");
                }
                Err(e) => {
                    assert_eq!(e, Error::NotRunning(x), "{what}");
                    assert_eq!(w.state(c), Idle, "{what}");
                }
            }
            w.check(what);
        },
    );
}

#[test]
fn a_start_while_its_lane_takes_it_and_starts_a_child_is_taken_once() {
    every_world!(start_while_its_lane_starts_a_child);
}

// =======================================================================================
// 2. A start against the end of the same sequence's previous run, or of its caller.
// =======================================================================================

/// X runs (run 1), J has joined run 1 (pending). One lane ends X's run 1 (end and
/// finished), the other starts X by a handle, either preempting the other (`end_first`:
/// the end is the preempted operation). The start wins only after the end's commit (else
/// `AlreadyRunning(X)`); then run 2 is pending for X's lane. J, joined to run 1, is
/// released and woken and gets run 1's outcome (`Completed`), whatever came first.
fn start_against_end<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    end_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let j = w.seq("J");
        w.split();
        let x = w.seq("X");
        w.start_taken(x);
        let j = Joiner::started(&w, j);
        assert_eq!(j.poll(&w, x), Poll::Pending);
        (w, x, j, j.wakes.woken())
    };
    let end = |(w, x, _, _): (World<L, N, B>, SeqId, Joiner, usize)| w.complete(x);
    let start = |(w, x, _, _): (World<L, N, B>, SeqId, Joiner, usize)| w.handle(x).start();
    let expect = |what: &str,
                  ended: bool,
                  started: Result<(), Error>,
                  s: (World<L, N, B>, SeqId, Joiner, usize)| {
        let (w, x, j, before) = s;
        assert!(ended, "{what}: the end of run 1");
        match started {
            Ok(()) => {
                assert_eq!((w.state(x), w.runs(x)), (Running, 2), "{what}");
                assert_eq!(w.try_take(x), Some(RunId { seq: x, count: 2 }), "{what}");
            }
            Err(e) => {
                assert_eq!(e, Error::AlreadyRunning(x), "{what}");
                assert_eq!((w.state(x), w.runs(x)), (Terminated, 1), "{what}");
            }
        }
        assert_eq!(
            j.released(&w, x, before, what),
            Ok(Outcome::Completed),
            "{what}: J"
        );
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, end first {end_first}",
        core::any::type_name::<L>()
    );
    if end_first {
        interleave(&name, setup, end, start, |what, _, e, s, sc| {
            expect(what, e, s, sc)
        });
    } else {
        interleave(&name, setup, start, end, |what, at, s, e, sc| {
            // The start is checked first (X running): only a whole end before it lets it win.
            assert_eq!(s.is_ok(), at.k == 0 && !at.after, "{what}: {s:?}");
            expect(what, e, s, sc)
        });
    }
}

#[test]
fn a_start_against_the_end_of_the_previous_run_wins_only_after_the_end() {
    every_world!(start_against_end, true);
    every_world!(start_against_end, false);
}

/// What P's lane does while X's run starts C (or the other way round).
#[derive(Clone, Copy, Debug, PartialEq)]
enum ToCaller {
    /// P's run ends (completed).
    Ends,
    /// P's run is dropped (`Port::abandon`): P and what is below it are aborted.
    Dropped,
}

/// P runs and started X in X's lane (X runs below P); X's run starts C in C's lane, and P's
/// lane ends P or drops its run, one preempting the other (`start_first`: the start is the
/// preempted operation). A non-blocking child outlives its caller's end (semantics 11): C
/// starts and runs below the terminated P. A dropped P tears down X and whatever began
/// below it (semantics 13): C's start is refused (`NotRunning(X)`) or C is aborted with X
/// (`Dropped`).
fn start_against_caller<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    to_caller: ToCaller,
    start_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        w.split();
        let [x, c] = ["X", "C"].map(|n| w.seq(n));
        w.start_taken(p);
        w.in_lane(x, p).unwrap();
        w.take(x);
        (w, [p, x, c])
    };
    type S<L, const N: usize, const B: usize> = (World<L, N, B>, [SeqId; 3]);
    let start = |(w, [_, x, c]): S<L, N, B>| w.in_lane(c, x);
    let caller = move |(w, [p, _, _]): S<L, N, B>| match to_caller {
        ToCaller::Ends => {
            assert!(w.complete(p));
        }
        ToCaller::Dropped => Port::abandon(w.seq, p, &()),
    };
    let expect = move |what: &str, started: Result<(), Error>, (w, [p, x, c]): S<L, N, B>| {
        match to_caller {
            ToCaller::Ends => {
                assert_eq!(started, Ok(()), "{what}");
                assert_eq!(
                    (w.state(p), w.state(x), w.state(c)),
                    (Terminated, Running, Running),
                    "{what}"
                );
                assert_eq!(w.caller(c), Some(x), "{what}");
                assert_eq!(w.try_take(c), Some(RunId { seq: c, count: 1 }), "{what}");
            }
            ToCaller::Dropped => {
                assert_eq!(w.ended(p), (Aborted, Cause::Dropped), "{what}: P");
                assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}: X");
                match started {
                    Ok(()) => assert_eq!(w.ended(c), (Aborted, Cause::Dropped), "{what}: C"),
                    Err(e) => {
                        assert_eq!(e, Error::NotRunning(x), "{what}");
                        assert_eq!(w.state(c), Idle, "{what}");
                    }
                }
                assert!(!w.pending(c), "{what}");
            }
        }
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, {to_caller:?}, start first {start_first}",
        core::any::type_name::<L>()
    );
    if start_first {
        interleave(&name, setup, start, caller, |what, _, r, (), s| {
            expect(what, r, s)
        });
    } else {
        interleave(&name, setup, caller, start, |what, _, (), r, s| {
            expect(what, r, s)
        });
    }
}

#[test]
fn a_start_below_a_caller_that_ends_runs_and_below_a_dropped_one_is_torn_down() {
    for to_caller in [ToCaller::Ends, ToCaller::Dropped] {
        for start_first in [true, false] {
            every_world!(start_against_caller, to_caller, start_first);
        }
    }
}

// =======================================================================================
// 3. Joins against the end, a new start and a dropped run of the joined sequence; two
//    joiners.
// =======================================================================================

/// What X's lane (or a handle) does, inserted into a join.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Then {
    /// Ends X's run 1 (completed).
    End,
    /// Ends it, and X is started again by a handle (run 2, not taken yet).
    EndAndStart,
    /// Ends it, X is started again and run 2 ends too (skipped).
    EndTwice,
}

fn end_and_then<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    x: SeqId,
    then: Then,
) {
    assert!(w.complete(x));
    if then != Then::End {
        w.handle(x).start().unwrap();
    }
    if then == Then::EndTwice {
        w.take(x);
        assert!(w.end(x, Outcome::Skipped));
    }
}

/// X runs (run 1); J2 (with `two`) has joined run 1 (pending). J1's first poll of its join
/// of X (lane A) with X's lane doing `then` before section `k`. J1 joins the run current at
/// its first look (semantics 14): run 1 (`Completed`), or run 2, under way (pending, then
/// `Skipped` once it ends: released and woken) or ended (`Skipped`). J2 gets run 1's
/// outcome while run 1 is the last run or the one before the run under way, else
/// `OutcomeLost`. After the poll (`k` = the count), J1 is as J2.
fn join_against_end<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    two: bool,
    then: Then,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let j2 = w.seq("J2");
        w.split();
        let [x, j1] = ["X", "J1"].map(|n| w.seq(n));
        w.start_taken(x);
        let js = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        if two {
            assert_eq!(js[1].poll(&w, x), Poll::Pending);
        }
        (w, x, js, [js[0].wakes.woken(), js[1].wakes.woken()])
    };
    interleave(
        &format!(
            "{layout:?}, {}, two {two}, {then:?}",
            core::any::type_name::<L>()
        ),
        setup,
        |(w, x, [j1, _], [b1, _])| {
            let first = j1.poll(&w, x);
            j1.repoll(&w, x, b1, first)
        },
        move |(w, x, _, _)| end_and_then(&w, x, then),
        |what, at, first, (), (w, x, [j1, j2], [_, b2])| {
            let lost_or = |o| match then {
                Then::EndTwice => Err(Error::OutcomeLost(x)),
                _ => Ok(o),
            };
            if two {
                let r = j2.released(&w, x, b2, what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J2");
            }
            if at.after {
                // J1 joined run 1 before the end: as J2.
                assert_eq!(first, Poll::Pending, "{what}");
                let r = j1.released(&w, x, 0, what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J1");
            } else {
                match (first, j1.run.get()) {
                    (Poll::Ready(r), Some(1)) => {
                        assert_eq!(r, lost_or(Outcome::Completed), "{what}")
                    }
                    (Poll::Ready(r), Some(2)) => {
                        assert_eq!(then, Then::EndTwice, "{what}");
                        assert_eq!(r, Ok(Outcome::Skipped), "{what}");
                    }
                    (Poll::Pending, Some(2)) => {
                        assert_eq!(then, Then::EndAndStart, "{what}");
                        let before = j1.wakes.woken();
                        w.take(x);
                        assert!(w.end(x, Outcome::Skipped));
                        let r = j1.released(&w, x, before, what);
                        assert_eq!(r, Ok(Outcome::Skipped), "{what}: J1");
                    }
                    other => panic!("{what}: J1 {other:?}"),
                }
            }
            assert!(!j1.joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_against_the_end_of_the_joined_run_gets_its_outcome_or_outcome_lost() {
    for two in [false, true] {
        for then in [Then::End, Then::EndAndStart, Then::EndTwice] {
            every_world!(join_against_end, two, then);
        }
    }
}

/// R runs X blocking; J runs. J's first poll of its join of X and R's dropped run
/// (`Port::abandon(R)`: R and X aborted, `Dropped`) preempt one another (`join_first`: the
/// join is the preempted operation). J gets `Aborted(Dropped)`: at once, or released and
/// woken by X's teardown.
fn join_against_drop<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    join_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [r, x] = ["R", "X"].map(|n| w.seq(n));
        w.split();
        let j = w.seq("J");
        w.start_taken(r);
        w.blocking(x, r).unwrap();
        let j = Joiner::started(&w, j);
        (w, [r, x], j)
    };
    type S<L, const N: usize, const B: usize> = (World<L, N, B>, [SeqId; 2], Joiner);
    let join = |(w, [_, x], j): S<L, N, B>| {
        let before = j.wakes.woken();
        let first = j.poll(&w, x);
        (before, j.repoll(&w, x, before, first))
    };
    let drop = |(w, [r, _], _): S<L, N, B>| Port::abandon(w.seq, r, &());
    let expect = |what: &str,
                  (before, polled): (usize, Poll<Result<Outcome, Error>>),
                  (w, [r, x], j): S<L, N, B>| {
        for id in [r, x] {
            assert_eq!(w.ended(id), (Aborted, Cause::Dropped), "{what}: {id:?}");
        }
        let r = j.outcome(&w, x, before, polled, what);
        assert_eq!(r, Ok(Outcome::Aborted(Cause::Dropped)), "{what}");
        assert!(!j.joining(&w), "{what}");
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, join first {join_first}",
        core::any::type_name::<L>()
    );
    if join_first {
        interleave(&name, setup, join, drop, |what, _, p, (), s| {
            expect(what, p, s)
        });
    } else {
        interleave(&name, setup, drop, join, |what, _, (), p, s| {
            expect(what, p, s)
        });
    }
}

#[test]
fn a_join_against_a_dropped_run_gets_aborted_dropped() {
    every_world!(join_against_drop, true);
    every_world!(join_against_drop, false);
}

/// X runs; J1's first poll of its join of X, with J2's first poll of its own join of X
/// before section `k`; then X ends. Both are released and woken and get `Completed`.
fn two_joiners<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [x, j1] = ["X", "J1"].map(|n| w.seq(n));
        w.split();
        let j2 = w.seq("J2");
        w.start_taken(x);
        let js = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        (w, x, js)
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, x, [j1, _])| j1.poll(&w, x),
        |(w, x, [_, j2])| j2.poll(&w, x),
        |what, _, p1, p2, (w, x, [j1, j2])| {
            assert_eq!((p1, p2), (Poll::Pending, Poll::Pending), "{what}");
            let before = [j1.wakes.woken(), j2.wakes.woken()];
            assert!(w.complete(x));
            for (j, b) in [(j1, before[0]), (j2, before[1])] {
                assert_eq!(j.released(&w, x, b, what), Ok(Outcome::Completed), "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn two_joiners_preempting_one_another_are_both_released() {
    every_world!(two_joiners);
}

/// X's run 1 ended (`Completed`). J's first poll of its join of X, with a handle start of
/// X (run 2, taken by X's lane) before section `k`. J joins the run current at its look:
/// run 1 (`Completed` at once) or run 2 (pending; when run 2 ends, skipped, J is released
/// and woken and gets `Skipped`).
fn join_against_new_start<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let x = w.seq("X");
        w.split();
        let j = w.seq("J");
        w.start_taken(x);
        assert!(w.complete(x));
        let j = Joiner::started(&w, j);
        (w, x, j)
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, x, j)| j.poll(&w, x),
        |(w, x, _)| {
            w.start_taken(x);
        },
        |what, _, polled, (), (w, x, j)| {
            match (polled, j.run.get()) {
                (Poll::Ready(r), Some(1)) => assert_eq!(r, Ok(Outcome::Completed), "{what}"),
                (Poll::Pending, Some(2)) => {
                    let before = j.wakes.woken();
                    assert!(w.end(x, Outcome::Skipped));
                    assert_eq!(
                        j.released(&w, x, before, what),
                        Ok(Outcome::Skipped),
                        "{what}"
                    );
                }
                other => panic!("{what}: {other:?}"),
            }
            assert!(!j.joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_against_a_new_start_joins_the_run_current_at_its_look() {
    every_world!(join_against_new_start);
}

// =======================================================================================
// 4. A dropped run's teardown against a start below it, a start of it again, the end of a
//    child.
// =======================================================================================

/// What a lane of higher priority does during R's teardown.
#[derive(Clone, Copy, Debug, PartialEq)]
enum During {
    /// C's lane ends C (completed).
    ChildEnds,
    /// C's run starts D in D's lane.
    ChildStarts,
    /// A handle starts R again.
    StartAgain,
}

/// R runs X blocking; X's run started C in C's lane (taken). R's run is dropped
/// (`Port::abandon(R)`, lane A); lane B does `during` before section `k` of the teardown.
/// R and X end `Aborted(Dropped)`. C's end either came first (C `Terminated`) or is
/// refused (C `Aborted(Dropped)`); D's start by C is refused (`NotRunning(C)`) or D is torn
/// down with C (semantics 13: the walk goes again over what began meanwhile); a start of R
/// during its teardown is refused (`AlreadyRunning`) or torn down too (a later run of the
/// dropped sequence, started in its lane and not taken: `Port::abandon`), leaving no start
/// pending; after the teardown it runs (pending for R's lane).
fn drop_against<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout, during: During) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [r, x] = ["R", "X"].map(|n| w.seq(n));
        w.split();
        let [c, d] = ["C", "D"].map(|n| w.seq(n));
        w.start_taken(r);
        w.blocking(x, r).unwrap();
        w.in_lane(c, x).unwrap();
        w.take(c);
        (w, [r, x, c, d])
    };
    interleave(
        &format!("{layout:?}, {}, {during:?}", core::any::type_name::<L>()),
        setup,
        |(w, [r, ..])| Port::abandon(w.seq, r, &()),
        move |(w, [r, _, c, d])| match during {
            During::ChildEnds => Ok(w.complete(c)),
            During::ChildStarts => w.in_lane(d, c).map(|()| true),
            During::StartAgain => w.handle(r).start().map(|()| true),
        },
        move |what, at, (), got, (w, [r, x, c, d])| {
            assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}: X");
            match during {
                During::ChildEnds => {
                    assert_eq!(w.ended(r), (Aborted, Cause::Dropped), "{what}: R");
                    match got {
                        Ok(true) => assert_eq!(w.state(c), Terminated, "{what}"),
                        Ok(false) => assert_eq!(w.ended(c), (Aborted, Cause::Dropped), "{what}"),
                        Err(e) => panic!("{what}: {e:?}"),
                    }
                }
                During::ChildStarts => {
                    assert_eq!(w.ended(r), (Aborted, Cause::Dropped), "{what}: R");
                    assert_eq!(w.ended(c), (Aborted, Cause::Dropped), "{what}: C");
                    match got {
                        Ok(_) => assert_eq!(w.ended(d), (Aborted, Cause::Dropped), "{what}: D"),
                        Err(e) => {
                            assert_eq!(e, Error::NotRunning(c), "{what}");
                            assert_eq!(w.state(d), Idle, "{what}");
                        }
                    }
                    assert!(!w.pending(d), "{what}");
                }
                During::StartAgain => {
                    assert_eq!(w.ended(c), (Aborted, Cause::Dropped), "{what}: C");
                    if at.after {
                        assert_eq!(got, Ok(true), "{what}");
                        assert_eq!((w.state(r), w.runs(r)), (Running, 2), "{what}");
                        assert_eq!(w.try_take(r), Some(RunId { seq: r, count: 2 }), "{what}");
                    } else {
                        assert!(
                            got == Ok(true) || got == Err(Error::AlreadyRunning(r)),
                            "{what}: {got:?}"
                        );
                        assert_eq!(w.ended(r), (Aborted, Cause::Dropped), "{what}: R");
                        assert!(!w.pending(r), "{what}: a start nobody takes");
                    }
                }
            }
            w.check(what);
        },
    );
}

#[test]
fn a_dropped_runs_teardown_against_a_lane_below_it_leaves_nothing_under_way() {
    for during in [During::ChildEnds, During::ChildStarts, During::StartAgain] {
        every_world!(drop_against, during);
    }
}

// =======================================================================================
// 5. Requests against starts and ends of the same sequence (semantics 8: a request is
//    queued for the run it was made of).
// =======================================================================================

/// A request by a handle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ask {
    Abort,
    Pause,
    Resume,
}

fn ask<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    x: SeqId,
    a: Ask,
) -> Result<(), Error> {
    let h = w.handle(x);
    match a {
        Ask::Abort => h.abort(),
        Ask::Pause => h.pause(),
        Ask::Resume => h.resume(),
    }
}

/// X runs (run 1). Lane A requests `a` (abort or pause) of X; lane B, before section `k`,
/// ends X's run 1, starts X again and X's lane takes run 2. Then the tick at 1 ms. The
/// request is made of the run current at its check: of run 2 only when B came before it
/// (`k` = 0), then carried out (run 2 aborted, cause `Abort`, or paused); else of run 1,
/// which had ended: run 2 runs on (a request is never carried out on a later run).
fn request_against_end_and_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    a: Ask,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        w.start_taken(x);
        (w, x)
    };
    interleave(
        &format!("{layout:?}, {}, {a:?}", core::any::type_name::<L>()),
        setup,
        move |(w, x)| ask(&w, x, a),
        |(w, x)| {
            assert!(w.complete(x));
            w.start_taken(x)
        },
        move |what, at, asked, run2, (w, x)| {
            assert_eq!(asked, Ok(()), "{what}");
            assert_eq!(run2.count, 2, "{what}");
            w.tick(1);
            w.tick(2);
            let of_run_2 = at.k == 0 && !at.after;
            let expected = match (of_run_2, a) {
                (false, _) => Running,
                (true, Ask::Abort) => Aborted,
                (true, _) => Paused,
            };
            assert_eq!((w.state(x), w.runs(x)), (expected, 2), "{what}");
            if expected == Aborted {
                assert_eq!(w.ended(x).1, Cause::Abort, "{what}");
                assert_eq!(
                    w.clearance(run2),
                    Clearance::Aborted(Cause::Abort),
                    "{what}"
                );
            }
            w.check(what);
        },
    );
}

#[test]
fn a_request_against_an_end_and_a_new_start_is_carried_out_on_its_own_run_only() {
    every_world!(request_against_end_and_start, Ask::Abort);
    every_world!(request_against_end_and_start, Ask::Pause);
}

/// X runs; its lane ends it (completed) and a handle requests an abort (or pause) of it,
/// one preempting the other (`end_first`: the end is preempted). The end stands whatever
/// came first (a request waits for the tick; semantics 8): X `Terminated` after the ticks,
/// never aborted or paused. The request is accepted iff made before the end's commit.
fn end_against_request<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    a: Ask,
    end_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        w.start_taken(x);
        (w, x)
    };
    let expect = move |what: &str,
                       ended: bool,
                       asked: Result<(), Error>,
                       (w, x): (World<L, N, B>, SeqId)| {
        assert!(ended, "{what}");
        assert!(
            asked == Ok(()) || asked == Err(Error::NotRunning(x)),
            "{what}: {asked:?}"
        );
        w.tick(1);
        w.tick(2);
        assert_eq!((w.state(x), w.runs(x)), (Terminated, 1), "{what}");
        assert_eq!(
            w.moves(x, Running, Aborting) + w.moves(x, Running, Paused),
            0,
            "{what}"
        );
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, {a:?}, end first {end_first}",
        core::any::type_name::<L>()
    );
    if end_first {
        interleave(
            &name,
            setup,
            |(w, x)| w.complete(x),
            move |(w, x)| ask(&w, x, a),
            |what, _, e, r, s| expect(what, e, r, s),
        );
    } else {
        interleave(
            &name,
            setup,
            move |(w, x)| ask(&w, x, a),
            |(w, x)| w.complete(x),
            |what, _, r, e, s| expect(what, e, r, s),
        );
    }
}

#[test]
fn an_end_against_a_request_stands() {
    for a in [Ask::Abort, Ask::Pause] {
        for end_first in [true, false] {
            every_world!(end_against_request, a, end_first);
        }
    }
}

/// X is idle; a handle starts X (lane A) and another requests an abort of X (lane B)
/// before section `k` of the start; then the tick. The request is accepted iff X was
/// running at its check, and then carried out: X `Aborted(Abort)` and no start left for
/// its lane to take; else (`NotRunning(X)`) X runs and its lane takes run 1.
fn start_against_abort_request<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        (w, x)
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, x)| w.handle(x).start(),
        |(w, x)| ask(&w, x, Ask::Abort),
        |what, _, started, asked, (w, x)| {
            assert_eq!(started, Ok(()), "{what}");
            w.tick(1);
            match asked {
                Ok(()) => {
                    assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}");
                    assert_eq!(w.try_take(x), None, "{what}");
                }
                Err(e) => {
                    assert_eq!(e, Error::NotRunning(x), "{what}");
                    assert_eq!(w.state(x), Running, "{what}");
                    assert_eq!(w.try_take(x), Some(RunId { seq: x, count: 1 }), "{what}");
                }
            }
            w.check(what);
        },
    );
}

#[test]
fn an_abort_requested_during_a_start_is_carried_out_iff_accepted() {
    every_world!(start_against_abort_request);
}

/// P runs. P's lane starts X blocking (lane A) while a handle requests a pause of P
/// (lane B, before section `k`), or the other way round; then the tick at 1 ms. The pause
/// holds P and what it blocks in its lane (semantics 7): P and X end up `Paused`; after a
/// resume request (2 ms) both run.
fn blocking_start_against_pause<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    start_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        w.split();
        let x = w.seq("X");
        w.start_taken(p);
        (w, [p, x])
    };
    let expect = |what: &str,
                  started: Result<(), Error>,
                  asked: Result<(), Error>,
                  (w, [p, x]): (World<L, N, B>, [SeqId; 2])| {
        assert_eq!((started, asked), (Ok(()), Ok(())), "{what}");
        w.tick(1);
        assert_eq!((w.state(p), w.state(x)), (Paused, Paused), "{what}");
        ask(&w, p, Ask::Resume).unwrap();
        w.tick(2);
        assert_eq!((w.state(p), w.state(x)), (Running, Running), "{what}");
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, start first {start_first}",
        core::any::type_name::<L>()
    );
    let start = |(w, [p, x]): (World<L, N, B>, [SeqId; 2])| w.blocking(x, p);
    let pause = |(w, [p, _]): (World<L, N, B>, [SeqId; 2])| ask(&w, p, Ask::Pause);
    if start_first {
        interleave(&name, setup, start, pause, |what, _, s, a, sc| {
            expect(what, s, a, sc)
        });
    } else {
        interleave(&name, setup, pause, start, |what, _, a, s, sc| {
            expect(what, s, a, sc)
        });
    }
}

#[test]
fn a_blocking_start_against_a_pause_request_of_its_caller_is_paused_with_it() {
    every_world!(blocking_start_against_pause, true);
    every_world!(blocking_start_against_pause, false);
}

/// X was paused by a request (1 ms). A handle requests a resume (or an abort) of X while
/// X's run is dropped (`Port::abandon`), one preempting the other (`drop_first`: the
/// teardown is preempted); then the tick at 2 ms. X ends `Aborted(Dropped)` and stays so:
/// the request is refused or dropped with the run it was made of.
fn request_against_drop<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    a: Ask,
    drop_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        w.start_taken(x);
        ask(&w, x, Ask::Pause).unwrap();
        w.tick(1);
        assert_eq!(w.state(x), Paused);
        (w, x)
    };
    let expect = move |what: &str, asked: Result<(), Error>, (w, x): (World<L, N, B>, SeqId)| {
        let refused = match a {
            Ask::Resume => Error::NotPaused(x),
            _ => Error::NotRunning(x),
        };
        assert!(
            asked == Ok(()) || asked == Err(refused),
            "{what}: {asked:?}"
        );
        assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}");
        w.tick(2);
        assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}");
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, {a:?}, drop first {drop_first}",
        core::any::type_name::<L>()
    );
    let drop = |(w, x): (World<L, N, B>, SeqId)| Port::abandon(w.seq, x, &());
    let req = move |(w, x): (World<L, N, B>, SeqId)| ask(&w, x, a);
    if drop_first {
        interleave(&name, setup, drop, req, |what, _, (), r, s| {
            expect(what, r, s)
        });
    } else {
        interleave(&name, setup, req, drop, |what, _, r, (), s| {
            expect(what, r, s)
        });
    }
}

#[test]
fn a_request_against_a_dropped_run_leaves_it_aborted_dropped() {
    for a in [Ask::Resume, Ask::Abort] {
        for drop_first in [true, false] {
            every_world!(request_against_drop, a, drop_first);
        }
    }
}

// =======================================================================================
// 6. A lane taking or giving up its start against a handle start, a handle abort, another
//    take.
// =======================================================================================

/// X is idle; X's lane waits for a start (`Port::take_start`, a counting waker, lane A)
/// while a handle starts X (lane B, before section `k`), or the other way round. The lane
/// takes run 1 at once, or finds nothing and is woken by the start, and takes run 1 at its
/// next poll: no start is left that nobody will take.
fn take_against_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    take_first: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        (w, x, Counter::new())
    };
    type S<L, const N: usize, const B: usize> = (World<L, N, B>, SeqId, Counter);
    let take = |(w, x, c): S<L, N, B>| Port::take_start(w.seq, x, 0, &c.waker());
    let start = |(w, x, _): S<L, N, B>| w.handle(x).start();
    let expect = |what: &str,
                  at: At,
                  taken: Option<RunId>,
                  started: Result<(), Error>,
                  (w, x, c): S<L, N, B>| {
        assert_eq!(started, Ok(()), "{what}");
        let run = RunId { seq: x, count: 1 };
        match taken {
            Some(r) => assert_eq!(r, run, "{what}"),
            None => {
                // Taken before the start: the lane's waker is known to the start only if
                // the lane parked before it.
                if take_first || !at.after {
                    assert!(c.woken() > 0, "{what}: the lane not woken");
                }
                assert_eq!(
                    Port::take_start(w.seq, x, 0, &c.waker()),
                    Some(run),
                    "{what}"
                );
            }
        }
        assert!(!w.pending(x), "{what}");
        assert_eq!(w.clearance(run), Clearance::Go, "{what}");
        w.check(what);
    };
    let name = format!(
        "{layout:?}, {}, take first {take_first}",
        core::any::type_name::<L>()
    );
    if take_first {
        interleave(&name, setup, take, start, |what, at, t, s, sc| {
            expect(what, at, t, s, sc)
        });
    } else {
        interleave(&name, setup, start, take, |what, at, s, t, sc| {
            // A take before the start found nothing; one after it, before its lane was
            // woken, takes the run.
            expect(what, at, t, s, sc)
        });
    }
}

#[test]
fn a_take_against_a_handle_start_takes_the_run_once() {
    every_world!(take_against_start, true);
    every_world!(take_against_start, false);
}

/// X was started by a handle (pending). X's lane takes the start (lane A) while a handle
/// requests an abort of X (lane B, before section `k`); then the tick at 1 ms. The lane
/// takes run 1 (the start was pending), the request is accepted and carried out: run 1's
/// clearance is `Aborted(Abort)`, nothing left pending.
fn take_against_abort<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        w.handle(x).start().unwrap();
        (w, x)
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, x)| w.try_take(x),
        |(w, x)| ask(&w, x, Ask::Abort),
        |what, _, taken, asked, (w, x)| {
            let run = RunId { seq: x, count: 1 };
            assert_eq!((taken, asked), (Some(run), Ok(())), "{what}");
            w.tick(1);
            assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}");
            assert_eq!(w.clearance(run), Clearance::Aborted(Cause::Abort), "{what}");
            assert!(!w.pending(x), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_take_against_an_abort_request_takes_the_run_and_is_aborted() {
    every_world!(take_against_abort);
}

/// X was started by a handle (pending). Two lane futures of X take the start, one
/// preempting the other: exactly one takes run 1.
fn two_takes<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        w.handle(x).start().unwrap();
        (w, x)
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, x)| w.try_take(x),
        |(w, x)| w.try_take(x),
        |what, _, a, b, (w, x)| {
            let run = Some(RunId { seq: x, count: 1 });
            assert!((a == run) != (b == run), "{what}: {a:?} {b:?}");
            assert!(a.is_none() || b.is_none(), "{what}");
            assert!(!w.pending(x), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn two_takes_of_one_start_take_it_once() {
    every_world!(two_takes);
}

/// X's lane is dropped while it waits for a start (`Port::abandon_start`, lane A), and a
/// handle starts X (lane B, before section `k`). With `pending`, a start was made before:
/// the drop aborts it (`Dropped`), and a start during the drop is refused
/// (`AlreadyRunning`) or torn down too: nothing pending is left. Without, a start before
/// the drop's look is aborted; one after it (the lane is gone) stays pending: the lane
/// gave up before it was made (semantics 13 aborts only a start made but not taken).
fn abandon_start_against_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    pending: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let x = w.seq("X");
        if pending {
            w.handle(x).start().unwrap();
        }
        (w, x)
    };
    interleave(
        &format!(
            "{layout:?}, {}, pending {pending}",
            core::any::type_name::<L>()
        ),
        setup,
        |(w, x)| Port::abandon_start(w.seq, x, 0, &()),
        |(w, x)| w.handle(x).start(),
        move |what, at, (), started, (w, x)| {
            let before_look = at.k == 0 && !at.after;
            if pending || before_look {
                if pending && (at.after || before_look) {
                    // After the drop: a new run; before its look: refused (X running).
                    if at.after {
                        assert_eq!(started, Ok(()), "{what}");
                        assert_eq!((w.state(x), w.runs(x)), (Running, 2), "{what}");
                    } else {
                        assert_eq!(started, Err(Error::AlreadyRunning(x)), "{what}");
                        assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}");
                    }
                } else {
                    assert!(
                        started.is_ok() || started == Err(Error::AlreadyRunning(x)),
                        "{what}: {started:?}"
                    );
                    assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}");
                    assert!(!w.pending(x), "{what}");
                }
            } else {
                assert_eq!(started, Ok(()), "{what}");
                assert_eq!((w.state(x), w.runs(x)), (Running, 1), "{what}");
                assert!(w.pending(x), "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn a_lane_dropped_against_a_handle_start_aborts_what_it_would_have_taken() {
    every_world!(abandon_start_against_start, true);
    every_world!(abandon_start_against_start, false);
}

// =======================================================================================
// 7. One action waiting in two joins (`select`), and a start of an exception sequence.
// =======================================================================================

/// J's action waits in joins of X and of Y at once (a `select`): its join of X is pending;
/// its first poll of its join of Y (lane A) with X's lane ending X before section `k`. J
/// is woken by X's end, gets `Completed` for X at its next poll, stays waiting for Y, and
/// is released and woken by Y's end (`Completed`).
fn joins_in_a_select<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let x = w.seq("X");
        w.split();
        let [y, j] = ["Y", "J"].map(|n| w.seq(n));
        w.start_taken(x);
        w.start_taken(y);
        let jx = Joiner::started(&w, j);
        let jy = Joiner {
            run: Box::leak(Box::new(Cell::new(None))),
            ..jx
        };
        assert_eq!(jx.poll(&w, x), Poll::Pending);
        (w, [x, y], [jx, jy], jx.wakes.woken())
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, [_, y], [_, jy], _)| jy.poll(&w, y),
        |(w, [x, _], _, _)| assert!(w.complete(x)),
        |what, _, first, (), (w, [x, y], [jx, jy], before)| {
            assert_eq!(first, Poll::Pending, "{what}: Y runs");
            assert!(jx.wakes.woken() > before, "{what}: not woken by X's end");
            // The executor polls both joins again.
            assert_eq!(
                jx.poll(&w, x),
                Poll::Ready(Ok(Outcome::Completed)),
                "{what}"
            );
            assert_eq!(jy.poll(&w, y), Poll::Pending, "{what}");
            let before = jy.wakes.woken();
            assert!(w.complete(y));
            assert!(jy.wakes.woken() > before, "{what}: not woken by Y's end");
            assert_eq!(
                jy.poll(&w, y),
                Poll::Ready(Ok(Outcome::Completed)),
                "{what}"
            );
            w.check(what);
        },
    );
}

#[test]
fn an_action_in_two_joins_is_woken_by_each_end() {
    every_world!(joins_in_a_select);
}

/// O's `AbortOwner` monitor fired at 1 ms and started its exception sequence E (pending
/// for E's lane). A handle starts E (lane A) while E's lane takes E's run and ends it
/// (lane B, before section `k`). E is O's until the tick has reported its end: the start
/// is `AlreadyRunning(E)` whatever `k`; the tick at 2 ms reports E's end and aborts O
/// (the monitor's cause); then E can be started again.
fn start_of_an_exception_sequence_against_its_end<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let e = w.seq("E");
        let on: &'static core::sync::atomic::AtomicBool =
            Box::leak(Box::new(core::sync::atomic::AtomicBool::new(true)));
        let condition: &'static mut (dyn crate::Condition<()> + Send) =
            Box::leak(Box::new(move |_: &(), _: Instant| {
                on.load(Ordering::Relaxed)
            }));
        let m = crate::Monitor::new("m", condition, crate::Behaviour::AbortOwner).exception(e);
        let id = w.monitors.borrow_mut().add(o, m).unwrap();
        w.start_taken(o);
        w.tick(1);
        assert_eq!((w.state(o), w.state(e)), (Running, Running));
        on.store(false, Ordering::Relaxed);
        (w, [o, e], Cause::Monitor(id))
    };
    interleave(
        &format!("{layout:?}, {}", core::any::type_name::<L>()),
        setup,
        |(w, [_, e], _)| w.handle(e).start(),
        |(w, [_, e], _)| {
            w.take(e);
            w.complete(e)
        },
        |what, _, started, ended, (w, [o, e], cause)| {
            assert!(ended, "{what}");
            assert_eq!(started, Err(Error::AlreadyRunning(e)), "{what}");
            assert_eq!(w.state(e), Terminated, "{what}");
            w.tick(2);
            assert_eq!(w.ended(o), (Aborted, cause), "{what}");
            assert_eq!(w.handle(e).start(), Ok(()), "{what}: E free again");
            w.take(e);
            w.check(what);
        },
    );
}

#[test]
fn a_start_of_an_exception_sequence_against_its_end_is_refused_until_reported() {
    every_world!(start_of_an_exception_sequence_against_its_end);
}
