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
//! Handles are [kept](World::kept) as an application keeps them: no section to look one
//! up.
//!
//! Tests marked `#[ignore = "defect: ..."]` fail today; the reason names the defect.

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// Runs a scenario `f::<L, N, B>(layout, args...)` under both locks, in one word and in two.
macro_rules! every_split_world {
    ($f:ident $(, $arg:expr)*) => {{
        $f::<Interleaved, 8, 1>(Layout::One $(, $arg)*);
        $f::<Interleaved, 64, 2>(Layout::Split $(, $arg)*);
        $f::<InterleavedCoarse, 8, 1>(Layout::One $(, $arg)*);
        $f::<InterleavedCoarse, 64, 2>(Layout::Split $(, $arg)*);
    }};
}

impl<L: Lock + 'static, const N: usize, const B: usize> World<L, N, B> {
    /// A world of the sequences `first`, then (in the second word with `Layout::Split`)
    /// `second`, each with a lane, none started.
    fn of<const F: usize, const S: usize>(
        layout: Layout,
        first: [&'static str; F],
        second: [&'static str; S],
    ) -> (Self, [SeqId; F], [SeqId; S]) {
        let w = World::new(layout);
        let first = first.map(|n| w.seq(n));
        w.split();
        let second = second.map(|n| w.seq(n));
        (w, first, second)
    }
}

/// X alone (in the second word with `Layout::Split`): idle, or started by a handle
/// (`start`), and its start taken by its lane (`take`).
fn lone<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    start: bool,
    take: bool,
) -> (World<L, N, B>, SeqId) {
    let (w, [], [x]) = World::of(layout, [], ["X"]);
    if start {
        w.kept(x).start().unwrap();
    }
    if take {
        w.take(x);
    }
    (w, x)
}

/// A scenario's name: its layout, its lock and `rest`.
fn named<L>(layout: Layout, rest: core::fmt::Arguments) -> String {
    let rest = format!("{rest}");
    let sep = if rest.is_empty() { "" } else { ", " };
    format!("{layout:?}, {}{sep}{rest}", core::any::type_name::<L>())
}

/// A lane's counting waker and its count, `'static` so that a scenario stays `Copy`.
fn counter() -> &'static (Waker, Arc<Count>) {
    Box::leak(Box::new(counting()))
}

/// A [`Joiner`] that every copy of a scenario shares (both lanes and the checks).
type Shared = &'static RefCell<Joiner>;

/// [`Joiner::started`], shared.
fn joiner<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    id: SeqId,
) -> Shared {
    Box::leak(Box::new(RefCell::new(Joiner::started(w, id))))
}

/// A joiner: sequence `id`'s joins, its lane's wake-ups counted; unlike [`joiner`] it does
/// not start `id` (the scenario starts it itself).
fn unstarted_joiner(id: SeqId) -> Shared {
    Box::leak(Box::new(RefCell::new(Joiner {
        id,
        run: None,
        wakes: counter().1.clone(),
    })))
}

/// Another join of the same action as `j` (its sequence, its lane's waker), not polled yet.
fn another_join(j: Shared) -> Shared {
    let j = j.borrow();
    Box::leak(Box::new(RefCell::new(Joiner {
        id: j.id,
        run: None,
        wakes: j.wakes.clone(),
    })))
}

/// A join's poll refused as closing a cycle at `id`.
fn cycle(id: SeqId) -> Poll<Result<Outcome, Error>> {
    Poll::Ready(Err(Error::JoinWouldDeadlock(id)))
}

/// Of two joins that closed a cycle, the refused one's run `ended` completes: the other,
/// `waiting`, is released and woken, and gets `Completed`.
fn the_waiting_join_completes<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    ended: SeqId,
    waiting: Shared,
    what: &str,
) {
    let before = wakes(waiting);
    assert!(w.complete(ended), "{what}");
    let got = waiting.borrow_mut().released(w, ended, before, what);
    assert_eq!(got, Ok(Outcome::Completed), "{what}");
    w.check(what);
}

/// The wake-ups of `j`'s lane so far.
fn wakes(j: Shared) -> usize {
    woken(&j.borrow().wakes)
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
    let count = sections_at_least(1, &setup, |s| {
        let _ = op(*s);
    });
    every_k(count + 1, |k| {
        let s = setup();
        let out: Rc<RefCell<Option<Q>>> = Rc::new(RefCell::new(None));
        let into = out.clone();
        interleaved::at(k, move || *into.borrow_mut() = Some(other(s)));
        let r = op(s);
        let after = or_after(k, || *out.borrow_mut() = Some(other(s)));
        let q = out.borrow_mut().take().expect("the other lane ran");
        let what = format!(
            "{name}, k={k}/{count}{}",
            if after { " (after)" } else { "" }
        );
        expect(&what, At { k, after }, r, q, s);
    });
}

/// [`interleave`] of `a` and `b`, one preempting the other: `b` before each section of
/// `a` (`a_first`: `a` is the preempted operation), or `a` before each section of `b`.
/// `expect` gets `a`'s result, then `b`'s, either way.
fn preempting<S: Copy + 'static, R: 'static, Q: 'static>(
    name: &str,
    a_first: bool,
    setup: impl Fn() -> S,
    a: impl Fn(S) -> R + Copy + 'static,
    b: impl Fn(S) -> Q + Copy + 'static,
    expect: impl Fn(&str, At, R, Q, S),
) {
    if a_first {
        interleave(name, setup, a, b, expect);
    } else {
        interleave(name, setup, b, a, |what, at, q, r, s| {
            expect(what, at, r, q, s)
        });
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
            (How::Handle, _) => w.kept(x).start(),
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
        let (w, [p, q], [x]) = World::<L, N, B>::of(layout, ["P", "Q"], ["X"]);
        w.start_taken(p);
        w.start_taken(q);
        (w, [x, p, q])
    };
    interleave(
        &named::<L>(layout, format_args!("A {a:?}, B {b:?}")),
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
            assert_eq!(w.kept(x).counters().runs, 1, "{what}");
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
    use self::How::*;
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
        every_split_world!(two_starts, a, b);
    }
}

/// X is registered with a lane, not bound to an object yet. A handle starts it (lane A);
/// lane B, of higher priority, binds X's object before section `k` of the start. Both
/// succeed, and X stays bound: a second object for X is `AlreadyBound` whatever `k` (two
/// objects of one id would both drive its run).
fn start_against_bind<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    interleave(
        &named::<L>(layout, format_args!("")),
        move || lone::<L, N, B>(layout, false, false),
        |(w, x)| w.kept(x).start(),
        |(w, x)| w.seq.bind(x, ()).map(|object| object.id()),
        |what, _, started, bound, (w, x)| {
            assert_eq!((started, bound), (Ok(()), Ok(x)), "{what}");
            let again = w.seq.bind(x, ()).map(|object| object.id());
            assert_eq!(again, Err(Error::AlreadyBound(x)), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_bind_during_a_start_of_its_sequence_stays() {
    every_split_world!(start_against_bind);
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
        let (w, [p], [x]) = World::<L, N, B>::of(layout, ["P"], ["X"]);
        let old = w.start_taken(p);
        w.kept(p).abort().unwrap();
        w.tick(1);
        assert_eq!(w.ended(p), (Aborted, Cause::Abort));
        (w, [p, x], old)
    };
    let how = if blocking {
        super::How::Blocking
    } else {
        super::How::InLane
    };
    interleave(
        &named::<L>(layout, format_args!("blocking {blocking}")),
        setup,
        move |(w, [_, x], old)| start_child(&w, old, x, how),
        |(w, [p, _], _)| {
            w.kept(p).start()?;
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
    every_split_world!(start_by_a_replaced_caller, false);
    every_split_world!(start_by_a_replaced_caller, true);
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
        let (w, [p], [x, c]) = World::<L, N, B>::of(layout, ["P"], ["X", "C"]);
        w.start_taken(p);
        (w, [p, x, c])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
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
    every_split_world!(start_while_its_lane_starts_a_child);
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
        let (w, [j], [x]) = World::<L, N, B>::of(layout, ["J"], ["X"]);
        w.start_taken(x);
        let j = joiner(&w, j);
        assert_eq!(j.borrow_mut().poll(&w, x), Poll::Pending);
        (w, x, j, wakes(j))
    };
    preempting(
        &named::<L>(layout, format_args!("end first {end_first}")),
        end_first,
        setup,
        |(w, x, _, _)| w.complete(x),
        |(w, x, _, _)| w.kept(x).start(),
        move |what, at, ended, started, (w, x, j, before)| {
            if !end_first {
                // The start is checked first (X running): only a whole end before it lets
                // it win.
                assert_eq!(
                    started.is_ok(),
                    at.k == 0 && !at.after,
                    "{what}: {started:?}"
                );
            }
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
                j.borrow_mut().released(&w, x, before, what),
                Ok(Outcome::Completed),
                "{what}: J"
            );
            w.check(what);
        },
    );
}

#[test]
fn a_start_against_the_end_of_the_previous_run_wins_only_after_the_end() {
    every_split_world!(start_against_end, true);
    every_split_world!(start_against_end, false);
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
        let (w, [p], [x, c]) = World::<L, N, B>::of(layout, ["P"], ["X", "C"]);
        w.start_taken(p);
        w.in_lane(x, p).unwrap();
        w.take(x);
        (w, [p, x, c])
    };
    preempting(
        &named::<L>(
            layout,
            format_args!("{to_caller:?}, start first {start_first}"),
        ),
        start_first,
        setup,
        |(w, [_, x, c])| w.in_lane(c, x),
        move |(w, [p, _, _])| match to_caller {
            ToCaller::Ends => {
                assert!(w.complete(p));
            }
            ToCaller::Dropped => Port::abandon(w.seq, p, &()),
        },
        move |what, _, started, (), (w, [p, x, c])| {
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
                    // X aborted; C refused or aborted with it.
                    torn_down_with(what, started, &w, x, c, (Aborted, Cause::Dropped));
                    assert!(!w.pending(c), "{what}");
                }
            }
            w.check(what);
        },
    );
}

#[test]
fn a_start_below_a_caller_that_ends_runs_and_below_a_dropped_one_is_torn_down() {
    for to_caller in [ToCaller::Ends, ToCaller::Dropped] {
        for start_first in [true, false] {
            every_split_world!(start_against_caller, to_caller, start_first);
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
        w.kept(x).start().unwrap();
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
        let (w, [j2], [x, j1]) = World::<L, N, B>::of(layout, ["J2"], ["X", "J1"]);
        w.start_taken(x);
        let js = [joiner(&w, j1), joiner(&w, j2)];
        if two {
            assert_eq!(js[1].borrow_mut().poll(&w, x), Poll::Pending);
        }
        (w, x, js, js.map(wakes))
    };
    interleave(
        &named::<L>(layout, format_args!("two {two}, {then:?}")),
        setup,
        |(w, x, [j1, _], [b1, _])| {
            let mut j1 = j1.borrow_mut();
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
                let r = j2.borrow_mut().released(&w, x, b2, what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J2");
            }
            if at.after {
                // J1 joined run 1 before the end: as J2.
                assert_eq!(first, Poll::Pending, "{what}");
                let r = j1.borrow_mut().released(&w, x, 0, what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J1");
            } else {
                let run = j1.borrow().run;
                match (first, run) {
                    (Poll::Ready(r), Some(1)) => {
                        assert_eq!(r, lost_or(Outcome::Completed), "{what}")
                    }
                    (Poll::Ready(r), Some(2)) => {
                        assert_eq!(then, Then::EndTwice, "{what}");
                        assert_eq!(r, Ok(Outcome::Skipped), "{what}");
                    }
                    (Poll::Pending, Some(2)) => {
                        assert_eq!(then, Then::EndAndStart, "{what}");
                        let before = wakes(j1);
                        w.take(x);
                        assert!(w.end(x, Outcome::Skipped));
                        let r = j1.borrow_mut().released(&w, x, before, what);
                        assert_eq!(r, Ok(Outcome::Skipped), "{what}: J1");
                    }
                    other => panic!("{what}: J1 {other:?}"),
                }
            }
            assert!(!j1.borrow().joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_against_the_end_of_the_joined_run_gets_its_outcome_or_outcome_lost() {
    for two in [false, true] {
        for then in [Then::End, Then::EndAndStart, Then::EndTwice] {
            every_split_world!(join_against_end, two, then);
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
        let (w, [r, x], [j]) = World::<L, N, B>::of(layout, ["R", "X"], ["J"]);
        w.start_taken(r);
        w.blocking(x, r).unwrap();
        (w, [r, x], joiner(&w, j))
    };
    preempting(
        &named::<L>(layout, format_args!("join first {join_first}")),
        join_first,
        setup,
        |(w, [_, x], j)| {
            let mut j = j.borrow_mut();
            let before = woken(&j.wakes);
            let first = j.poll(&w, x);
            (before, j.repoll(&w, x, before, first))
        },
        |(w, [r, _], _)| Port::abandon(w.seq, r, &()),
        |what, _, (before, polled), (), (w, [r, x], j)| {
            for id in [r, x] {
                assert_eq!(w.ended(id), (Aborted, Cause::Dropped), "{what}: {id:?}");
            }
            let r = j.borrow_mut().outcome(&w, x, before, polled, what);
            assert_eq!(r, Ok(Outcome::Aborted(Cause::Dropped)), "{what}");
            assert!(!j.borrow().joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_against_a_dropped_run_gets_aborted_dropped() {
    every_split_world!(join_against_drop, true);
    every_split_world!(join_against_drop, false);
}

/// X runs; J1's first poll of its join of X, with J2's first poll of its own join of X
/// before section `k`; then X ends. Both are released and woken and get `Completed`.
fn two_joiners<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let (w, [x, j1], [j2]) = World::<L, N, B>::of(layout, ["X", "J1"], ["J2"]);
        w.start_taken(x);
        let js = [joiner(&w, j1), joiner(&w, j2)];
        (w, x, js)
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, x, [j1, _])| j1.borrow_mut().poll(&w, x),
        |(w, x, [_, j2])| j2.borrow_mut().poll(&w, x),
        |what, _, p1, p2, (w, x, js)| {
            assert_eq!((p1, p2), (Poll::Pending, Poll::Pending), "{what}");
            let before = js.map(wakes);
            assert!(w.complete(x));
            for (j, b) in js.into_iter().zip(before) {
                let r = j.borrow_mut().released(&w, x, b, what);
                assert_eq!(r, Ok(Outcome::Completed), "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn two_joiners_preempting_one_another_are_both_released() {
    every_split_world!(two_joiners);
}

/// A and B run. A's first poll of its join of B, with B's first poll of its join of A
/// before section `k`: the two joins close a cycle, so exactly one of them is
/// `JoinWouldDeadlock` and leaves nothing registered, whichever comes first; the other
/// waits, and gets the outcome when the run it joined completes.
fn crossing_joins<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let (w, [a], [b]) = World::<L, N, B>::of(layout, ["A"], ["B"]);
        (w, [a, b], [joiner(&w, a), joiner(&w, b)])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [_, b], [ja, _])| ja.borrow_mut().poll(&w, b),
        |(w, [a, _], [_, jb])| jb.borrow_mut().poll(&w, a),
        |what, _, pa, pb, (w, [a, b], [ja, jb])| {
            // The refused one's run, and the joiner that waits for it.
            let (ended, waiting) = match (pa, pb) {
                (p, Poll::Pending) if p == cycle(b) => (a, jb),
                (Poll::Pending, p) if p == cycle(a) => (b, ja),
                other => panic!("{what}: {other:?}"),
            };
            assert!(!w.in_set(Set::Joining, ended), "{what}: left joining");
            the_waiting_join_completes(&w, ended, waiting, what);
        },
    );
}

#[test]
fn of_two_joins_that_close_a_cycle_exactly_one_is_refused() {
    every_split_world!(crossing_joins);
}

/// A and B run; B's run waits in a join of A's run (pending). A's first poll of its join of
/// B (lane A) is refused: B waits for A (semantics 14). Before section `k` of that poll, B's
/// lane (higher priority) drops its join of A (the loser of a `select`, a timer won) and
/// joins A again (a new `Cx::join`). A's join and B's second join are two joins that close
/// a cycle at the same moment: exactly one of them is `JoinWouldDeadlock`, the other
/// waits and gets `Completed` when the run it joined completes. (B's first join, dropped,
/// no longer waits.)
fn refused_join_against_a_rejoin<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [a], [b]) = World::<L, N, B>::of(layout, ["A"], ["B"]);
        let (ja, jb) = (joiner(&w, a), joiner(&w, b));
        assert_eq!(jb.borrow_mut().poll(&w, a), Poll::Pending);
        let jb2 = another_join(jb);
        (w, [a, b], [ja, jb, jb2])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [_, b], [ja, _, _])| ja.borrow_mut().poll(&w, b),
        |(w, [a, b], [_, _, jb2])| {
            Port::stop_join(w.seq, b);
            jb2.borrow_mut().poll(&w, a)
        },
        |what, _, pa, pb, (w, [a, b], [ja, _, jb2])| {
            let pa = ja.borrow_mut().repoll(&w, b, 0, pa);
            let pb = jb2.borrow_mut().repoll(&w, a, 0, pb);
            let (ended, waiting) = match (&pa, &pb) {
                (p, Poll::Pending) if *p == cycle(b) => (a, jb2),
                (Poll::Pending, p) if *p == cycle(a) => (b, ja),
                _ => panic!(
                    "{what}: A's join {pa:?}, B's second join {pb:?}; A joining {}, B joining {}",
                    w.in_set(Set::Joining, a),
                    w.in_set(Set::Joining, b)
                ),
            };
            the_waiting_join_completes(&w, ended, waiting, what);
        },
    );
}

#[test]
fn a_join_refused_as_a_cycle_is_no_wait_for_a_join_made_again_before_it_returns() {
    every_split_world!(refused_join_against_a_rejoin);
}

/// O runs with an `AbortOwner` monitor whose exception sequence E runs (fired at 1 ms, E's
/// start taken); J runs. J joins O while E joins J (`e_lower`: E's join is the preempted
/// poll, J's comes before each of its sections; else the other way round). The two close
/// a cycle (J waits for O, which E's exception holds until E's end; E waits for J):
/// exactly one is `JoinWouldDeadlock` (semantics 14), the other waits. If E's was refused,
/// E ends, the tick at 2 ms reports it and aborts O: J gets `Aborted(M0)`. If J's was
/// refused, J completes and E gets `Completed`.
fn crossing_joins_through_an_exception<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    e_lower: bool,
) {
    let setup = move || {
        let (w, [o], [e, j]) = World::<L, N, B>::of(layout, ["O"], ["E", "J"]);
        w.monitor(o, flag_of(true), Behaviour::AbortOwner, Some(e));
        w.start_taken(o);
        w.tick(1);
        // E's lane takes its start with the waker whose wake-ups E's joins count.
        let (waker, wakes) = counter();
        Port::take_start(w.seq, e, w.tag, waker).unwrap();
        let je: Shared = Box::leak(Box::new(RefCell::new(Joiner {
            id: e,
            run: None,
            wakes: wakes.clone(),
        })));
        assert_eq!((w.state(o), w.state(e)), (Running, Running));
        (w, [o, e, j], [joiner(&w, j), je])
    };
    let join_j = |(w, [o, _, _], [jj, _]): (World<L, N, B>, [SeqId; 3], [Shared; 2])| {
        jj.borrow_mut().poll(&w, o)
    };
    let join_e = |(w, [_, _, j], [_, je]): (World<L, N, B>, [SeqId; 3], [Shared; 2])| {
        je.borrow_mut().poll(&w, j)
    };
    let expect =
        |what: &str,
         pj: Poll<Result<Outcome, Error>>,
         pe: Poll<Result<Outcome, Error>>,
         (w, [o, e, j], [jj, je]): (World<L, N, B>, [SeqId; 3], [Shared; 2])| {
            let pj = jj.borrow_mut().repoll(&w, o, 0, pj);
            let pe = je.borrow_mut().repoll(&w, j, 0, pe);
            if pj == cycle(o) && pe == Poll::Pending {
                let before = wakes(je);
                assert!(w.complete(j), "{what}");
                let got = je.borrow_mut().released(&w, j, before, what);
                assert_eq!(got, Ok(Outcome::Completed), "{what}: E");
            } else if pj == Poll::Pending && pe == cycle(j) {
                let before = wakes(jj);
                assert!(w.complete(e), "{what}");
                w.tick(2);
                assert_eq!(w.ended(o), (Aborted, M0), "{what}");
                let got = jj.borrow_mut().released(&w, o, before, what);
                assert_eq!(got, Ok(Outcome::Aborted(M0)), "{what}: J");
            } else {
                panic!("{what}: J's join of O {pj:?}, E's join of J {pe:?}");
            }
            w.check_tree(what);
        };
    let name = named::<L>(layout, format_args!("E lower {e_lower}"));
    if e_lower {
        interleave(&name, setup, join_e, join_j, |what, _, pe, pj, s| {
            expect(what, pj, pe, s)
        });
    } else {
        interleave(&name, setup, join_j, join_e, |what, _, pj, pe, s| {
            expect(what, pj, pe, s)
        });
    }
}

#[test]
fn crossing_joins_through_an_exceptions_hold_are_one_refusal() {
    every_split_world!(crossing_joins_through_an_exception, true);
    every_split_world!(crossing_joins_through_an_exception, false);
}

/// X's run 1 ended (`Completed`). J's first poll of its join of X, with a handle start of
/// X (run 2, taken by X's lane) before section `k`. J joins the run current at its look:
/// run 1 (`Completed` at once) or run 2 (pending; when run 2 ends, skipped, J is released
/// and woken and gets `Skipped`).
fn join_against_new_start<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let (w, [x], [j]) = World::<L, N, B>::of(layout, ["X"], ["J"]);
        w.start_taken(x);
        assert!(w.complete(x));
        (w, x, joiner(&w, j))
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, x, j)| j.borrow_mut().poll(&w, x),
        |(w, x, _)| {
            w.kept(x).start().unwrap();
            w.take(x);
        },
        |what, _, polled, (), (w, x, j)| {
            let run = j.borrow().run;
            match (polled, run) {
                (Poll::Ready(r), Some(1)) => assert_eq!(r, Ok(Outcome::Completed), "{what}"),
                (Poll::Pending, Some(2)) => {
                    let before = wakes(j);
                    assert!(w.end(x, Outcome::Skipped));
                    assert_eq!(
                        j.borrow_mut().released(&w, x, before, what),
                        Ok(Outcome::Skipped),
                        "{what}"
                    );
                }
                other => panic!("{what}: {other:?}"),
            }
            assert!(!j.borrow().joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_against_a_new_start_joins_the_run_current_at_its_look() {
    every_split_world!(join_against_new_start);
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
        let (w, [r, x], [c, d]) = World::<L, N, B>::of(layout, ["R", "X"], ["C", "D"]);
        w.start_taken(r);
        w.blocking(x, r).unwrap();
        w.in_lane(c, x).unwrap();
        w.take(c);
        (w, [r, x, c, d])
    };
    interleave(
        &named::<L>(layout, format_args!("{during:?}")),
        setup,
        |(w, [r, ..])| Port::abandon(w.seq, r, &()),
        move |(w, [r, _, c, d])| match during {
            During::ChildEnds => Ok(w.complete(c)),
            During::ChildStarts => w.in_lane(d, c).map(|()| true),
            During::StartAgain => w.kept(r).start().map(|()| true),
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
                    // C aborted; D refused or aborted with it.
                    let started = got.map(|_| ());
                    torn_down_with(what, started, &w, c, d, (Aborted, Cause::Dropped));
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
        every_split_world!(drop_against, during);
    }
}

// =======================================================================================
// 5. Requests against starts and ends of the same sequence (semantics 8: a request is
//    queued for the run it was made of).
// =======================================================================================

/// A request by a handle: the shared [`super::Ask`] and an abort.
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
    let h = w.kept(x);
    match a {
        Ask::Abort => h.abort(),
        Ask::Pause => h.pause(),
        Ask::Resume => h.resume(),
    }
}

/// Ends `x`'s run (completed) and, if it ended, starts `x` again; its lane takes the new
/// run.
fn end_and_start_again<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    x: SeqId,
    again: impl FnOnce() -> Result<(), Error>,
) -> Option<RunId> {
    if !w.complete(x) {
        return None;
    }
    again().unwrap();
    Some(w.take(x))
}

/// X runs (run 1). Lane A requests `a` (abort or pause) of X; lane B, before section `k`,
/// ends X's run 1, starts X again and X's lane takes run 2. Then the tick at 1 ms. The
/// request is made of the run current at its check: of run 2 only when B came before it
/// (`k` = 0), then carried out (run 2 aborted, cause `Abort`, or paused); else of run 1:
/// when B came after the request was queued, an abort holds run 1 (its end is refused, B
/// starts nothing) and the tick aborts it; otherwise run 1 had ended and run 2 runs on (a
/// request is never carried out on a later run).
fn request_against_end_and_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    a: Ask,
) {
    interleave(
        &named::<L>(layout, format_args!("{a:?}")),
        move || lone::<L, N, B>(layout, true, true),
        move |(w, x)| ask(&w, x, a),
        |(w, x)| end_and_start_again(&w, x, || w.kept(x).start()),
        move |what, at, asked, run2, (w, x)| {
            assert_eq!(asked, Ok(()), "{what}");
            w.tick(1);
            w.tick(2);
            if a == Ask::Abort && at.after {
                assert_eq!(run2, None, "{what}");
                assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}");
                assert_eq!(w.runs(x), 1, "{what}");
                w.check(what);
                return;
            }
            let run2 = run2.expect("run 1 ended");
            assert_eq!(run2.count, 2, "{what}");
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
    every_split_world!(request_against_end_and_start, Ask::Abort);
    every_split_world!(request_against_end_and_start, Ask::Pause);
}

/// X runs (run 1), started by P. Lane A asks for the abort of X's run 1 (`abort_child`,
/// what a dropped `Scoped` of P does); lane B, before section `k`, ends run 1, has P start X
/// again (in X's lane: P is the caller of both runs) and X's lane takes run 2. Then the
/// ticks. The abort is refused (`NotRunning(X)`) when B came before its check, else
/// accepted for run 1. When B came after it was queued, run 1 holds (its end is refused,
/// B starts nothing) and the tick aborts it; otherwise run 1 had ended and run 2 runs on:
/// never aborted.
fn abort_of_a_run_against_end_and_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    interleave(
        &named::<L>(layout, format_args!("")),
        move || {
            let (w, [p], [x]) = World::<L, N, B>::of(layout, ["P"], ["X"]);
            w.start_taken(p);
            w.in_lane(x, p).unwrap();
            let run1 = w.take(x);
            (w, p, x, run1)
        },
        |(w, p, _, run1)| Port::abort_child(w.seq, run1, p),
        |(w, p, x, _)| end_and_start_again(&w, x, || w.in_lane(x, p)),
        |what, at, asked, run2, (w, _, x, _)| {
            if at.after {
                assert_eq!((asked, run2), (Ok(()), None), "{what}");
                w.tick(1);
                assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}");
                assert_eq!(w.runs(x), 1, "{what}");
                w.check(what);
                return;
            }
            let run2 = run2.expect("run 1 ended");
            assert_eq!(run2.count, 2, "{what}");
            let before_check = at.k == 0 && !at.after;
            let expected = if before_check {
                Err(Error::NotRunning(x))
            } else {
                Ok(())
            };
            assert_eq!(asked, expected, "{what}");
            w.tick(1);
            w.tick(2);
            assert_eq!((w.state(x), w.runs(x)), (Running, 2), "{what}");
            assert_eq!(w.moves(x, Running, Aborting), 0, "{what}");
            w.check(what);
        },
    );
}

#[test]
fn an_abort_of_a_run_is_never_carried_out_on_a_later_run() {
    every_split_world!(abort_of_a_run_against_end_and_start);
}

/// X runs; its lane ends it (completed) and a handle requests an abort (or pause) of it,
/// one preempting the other (`end_first`: the end is preempted). A pause request waits
/// for the tick, so the end stands whatever came first (semantics 8): X `Terminated`,
/// never paused. An abort request queued before the end's commit holds the run: the end is
/// refused (also when it was opened before the request) and the tick aborts X; queued
/// after it, it finds X ended. The request is accepted iff made before the end's commit.
fn end_against_request<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    a: Ask,
    end_first: bool,
) {
    preempting(
        &named::<L>(layout, format_args!("{a:?}, end first {end_first}")),
        end_first,
        move || lone::<L, N, B>(layout, true, true),
        |(w, x)| w.complete(x),
        move |(w, x)| ask(&w, x, a),
        |what, _, ended, asked, (w, x)| {
            assert!(
                asked == Ok(()) || asked == Err(Error::NotRunning(x)),
                "{what}: {asked:?}"
            );
            if a == Ask::Abort && end_first {
                // The whole request came before one of the end's sections: accepted, it
                // was queued before the commit, which it refuses.
                assert_eq!(ended, asked.is_err(), "{what}");
            }
            w.tick(1);
            w.tick(2);
            if ended {
                assert_eq!((w.state(x), w.runs(x)), (Terminated, 1), "{what}");
                assert_eq!(
                    w.moves(x, Running, Aborting) + w.moves(x, Running, Paused),
                    0,
                    "{what}"
                );
            } else {
                assert_eq!((a, asked), (Ask::Abort, Ok(())), "{what}");
                assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}");
                assert_eq!(w.runs(x), 1, "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn an_end_against_a_request_stands_unless_an_abort_came_first() {
    for a in [Ask::Abort, Ask::Pause] {
        for end_first in [true, false] {
            every_split_world!(end_against_request, a, end_first);
        }
    }
}

/// X is idle; a handle starts X (lane A) and another requests an abort of X (lane B)
/// before section `k` of the start; then the tick. The request is accepted iff X was
/// running at its check, and then carried out: X `Aborted(Abort)` and no start left for
/// its lane to take; else (`NotRunning(X)`) X runs and its lane takes run 1.
fn start_against_abort_request<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    interleave(
        &named::<L>(layout, format_args!("")),
        move || lone::<L, N, B>(layout, false, false),
        |(w, x)| w.kept(x).start(),
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
    every_split_world!(start_against_abort_request);
}

/// P runs (its lane took the start), X is registered (in the second word with a split
/// layout). Returns the world and `[P, X]`.
fn p_running_x_registered<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, [SeqId; 2]) {
    let (w, [p], [x]) = World::<L, N, B>::of(layout, ["P"], ["X"]);
    w.start_taken(p);
    (w, [p, x])
}

/// P runs. P's lane starts X blocking (lane A) while a handle requests a pause of P
/// (lane B, before section `k`), or the other way round; then the tick at 1 ms. The pause
/// holds P and its blocking children in its lane (semantics 7): P and X end up `Paused`; after a
/// resume request (2 ms) both run.
fn blocking_start_against_pause<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    start_first: bool,
) {
    let setup = move || p_running_x_registered::<L, N, B>(layout);
    preempting(
        &named::<L>(layout, format_args!("start first {start_first}")),
        start_first,
        setup,
        |(w, [p, x])| w.blocking(x, p),
        |(w, [p, _])| ask(&w, p, Ask::Pause),
        |what, _, started, asked, (w, [p, x])| {
            assert_eq!((started, asked), (Ok(()), Ok(())), "{what}");
            w.tick(1);
            assert_eq!((w.state(p), w.state(x)), (Paused, Paused), "{what}");
            ask(&w, p, Ask::Resume).unwrap();
            w.tick(2);
            assert_eq!((w.state(p), w.state(x)), (Running, Running), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_blocking_start_against_a_pause_request_of_its_caller_is_paused_with_it() {
    every_split_world!(blocking_start_against_pause, true);
    every_split_world!(blocking_start_against_pause, false);
}

/// P runs. P's lane starts X blocking (lane A) while a handle requests an abort of P
/// (lane B), one preempting the other; then the tick at 1 ms. The abort is accepted
/// (P runs at its check). A start that opens after the request was queued is refused
/// (`NotRunning(P)`: a sequence whose abort is requested begins nothing, semantics 8);
/// one that opened before it starts X. Either way the tick aborts P, and X with it.
fn blocking_start_against_abort<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    start_first: bool,
) {
    let setup = move || p_running_x_registered::<L, N, B>(layout);
    preempting(
        &named::<L>(layout, format_args!("start first {start_first}")),
        start_first,
        setup,
        |(w, [p, x])| w.blocking(x, p),
        |(w, [p, _])| ask(&w, p, Ask::Abort),
        |what, _, started, asked, (w, [p, x])| {
            assert_eq!(asked, Ok(()), "{what}");
            w.tick(1);
            assert_eq!(w.ended(p), (Aborted, Cause::Abort), "{what}");
            match started {
                Ok(()) => assert_eq!(w.ended(x), (Aborted, Cause::Abort), "{what}"),
                Err(e) => {
                    assert_eq!(e, Error::NotRunning(p), "{what}");
                    assert_eq!(w.state(x), Idle, "{what}");
                }
            }
            w.check(what);
        },
    );
}

#[test]
fn a_blocking_start_against_an_abort_request_of_its_caller_is_refused_or_aborted_with_it() {
    every_split_world!(blocking_start_against_abort, true);
    every_split_world!(blocking_start_against_abort, false);
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
        let (w, x) = lone::<L, N, B>(layout, true, true);
        ask(&w, x, Ask::Pause).unwrap();
        w.tick(1);
        assert_eq!(w.state(x), Paused);
        (w, x)
    };
    preempting(
        &named::<L>(layout, format_args!("{a:?}, drop first {drop_first}")),
        drop_first,
        setup,
        |(w, x)| Port::abandon(w.seq, x, &()),
        move |(w, x)| ask(&w, x, a),
        move |what, _, (), asked, (w, x)| {
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
        },
    );
}

#[test]
fn a_request_against_a_dropped_run_leaves_it_aborted_dropped() {
    for a in [Ask::Resume, Ask::Abort] {
        for drop_first in [true, false] {
            every_split_world!(request_against_drop, a, drop_first);
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
        let (w, x) = lone::<L, N, B>(layout, false, false);
        (w, x, counter())
    };
    preempting(
        &named::<L>(layout, format_args!("take first {take_first}")),
        take_first,
        setup,
        |(w, x, (waker, _))| Port::take_start(w.seq, x, w.tag, waker),
        |(w, x, _)| w.kept(x).start(),
        move |what, at, taken, started, (w, x, (waker, count))| {
            assert_eq!(started, Ok(()), "{what}");
            let run = RunId { seq: x, count: 1 };
            match taken {
                Some(r) => assert_eq!(r, run, "{what}"),
                None => {
                    // Taken before the start: the lane's waker is known to the start only
                    // if the lane parked before it. (A take after the start, before its
                    // lane was woken, takes the run.)
                    if take_first || !at.after {
                        assert!(woken(count) > 0, "{what}: the lane not woken");
                    }
                    assert_eq!(
                        Port::take_start(w.seq, x, w.tag, waker),
                        Some(run),
                        "{what}"
                    );
                }
            }
            assert!(!w.pending(x), "{what}");
            assert_eq!(w.clearance(run), Clearance::Go, "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_take_against_a_handle_start_takes_the_run_once() {
    every_split_world!(take_against_start, true);
    every_split_world!(take_against_start, false);
}

/// X was started by a handle (pending). X's lane takes the start (lane A) while a handle
/// requests an abort of X (lane B, before section `k`); then the tick at 1 ms. The lane
/// takes run 1 (the start was pending), the request is accepted and carried out: run 1's
/// clearance is `Aborted(Abort)`, nothing left pending.
fn take_against_abort<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    interleave(
        &named::<L>(layout, format_args!("")),
        move || lone::<L, N, B>(layout, true, false),
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
    every_split_world!(take_against_abort);
}

/// X was started by a handle (pending). Two lane futures of X take the start, one
/// preempting the other: exactly one takes run 1.
fn two_takes<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    interleave(
        &named::<L>(layout, format_args!("")),
        move || lone::<L, N, B>(layout, true, false),
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
    every_split_world!(two_takes);
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
    interleave(
        &named::<L>(layout, format_args!("pending {pending}")),
        move || lone::<L, N, B>(layout, pending, false),
        |(w, x)| Port::abandon_start(w.seq, x, w.tag, &()),
        |(w, x)| w.kept(x).start(),
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

/// X's lane future is dropped while it waits for a start (`Run::drop_lane`: its lane
/// closed, then `Port::abandon_start`), and a handle starts X; each preempts the other
/// before every section (`drop_first`: the drop is the preempted operation). With
/// `pending`, a start was made before. No start is left pending in the closed lane, which
/// no future would ever take: the handle's start is refused (`NoLane` once the lane is
/// closed, `AlreadyRunning` while the earlier start is pending), or its run is aborted
/// (`Dropped`) with what was pending.
fn drop_lane_against_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    pending: bool,
    drop_first: bool,
) {
    preempting(
        &named::<L>(
            layout,
            format_args!("pending {pending}, drop first {drop_first}"),
        ),
        drop_first,
        move || lone::<L, N, B>(layout, pending, false),
        |(w, x)| {
            Port::close_lane(w.seq, x, w.tag);
            Port::abandon_start(w.seq, x, w.tag, &());
        },
        |(w, x)| w.kept(x).start(),
        move |what, _, (), started, (w, x)| {
            assert!(
                !w.pending(x),
                "{what}: {started:?}, a start pending in a closed lane"
            );
            match started {
                Ok(()) => assert!(!pending, "{what}"),
                Err(Error::NoLane(id) | Error::AlreadyRunning(id)) => assert_eq!(id, x, "{what}"),
                Err(e) => panic!("{what}: {e:?}"),
            }
            if pending || started.is_ok() {
                assert_eq!(w.ended(x), (Aborted, Cause::Dropped), "{what}");
            } else {
                assert_eq!(w.state(x), Idle, "{what}");
            }
            w.check(what);
        },
    );
}

#[test]
fn a_lane_dropped_while_it_waits_leaves_no_start_it_would_have_taken() {
    for (pending, drop_first) in [(false, true), (false, false), (true, true), (true, false)] {
        every_split_world!(drop_lane_against_start, pending, drop_first);
    }
}

#[test]
fn a_lane_dropped_against_a_handle_start_aborts_what_it_would_have_taken() {
    every_split_world!(abandon_start_against_start, true);
    every_split_world!(abandon_start_against_start, false);
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
        let (w, [x], [y, j]) = World::<L, N, B>::of(layout, ["X"], ["Y", "J"]);
        w.start_taken(x);
        w.start_taken(y);
        let jx = joiner(&w, j);
        // The same action, its own join: one lane, one waker.
        let jy: Shared = Box::leak(Box::new(RefCell::new(Joiner {
            id: j,
            run: None,
            wakes: jx.borrow().wakes.clone(),
        })));
        assert_eq!(jx.borrow_mut().poll(&w, x), Poll::Pending);
        (w, [x, y], [jx, jy], wakes(jx))
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [_, y], [_, jy], _)| jy.borrow_mut().poll(&w, y),
        |(w, [x, _], _, _)| assert!(w.complete(x)),
        |what, _, first, (), (w, [x, y], [jx, jy], before)| {
            assert_eq!(first, Poll::Pending, "{what}: Y runs");
            assert!(wakes(jx) > before, "{what}: not woken by X's end");
            // The executor polls both joins again.
            assert_eq!(
                jx.borrow_mut().poll(&w, x),
                Poll::Ready(Ok(Outcome::Completed)),
                "{what}"
            );
            assert_eq!(jy.borrow_mut().poll(&w, y), Poll::Pending, "{what}");
            let before = wakes(jy);
            assert!(w.complete(y));
            assert!(wakes(jy) > before, "{what}: not woken by Y's end");
            assert_eq!(
                jy.borrow_mut().poll(&w, y),
                Poll::Ready(Ok(Outcome::Completed)),
                "{what}"
            );
            w.check(what);
        },
    );
}

#[test]
fn an_action_in_two_joins_is_woken_by_each_end() {
    every_split_world!(joins_in_a_select);
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
        let (w, [o], [e]) = World::<L, N, B>::of(layout, ["O"], ["E"]);
        let on = flag_of(true);
        let cause = w.monitor(o, on, Behaviour::AbortOwner, Some(e));
        w.start_taken(o);
        w.tick(1);
        assert_eq!((w.state(o), w.state(e)), (Running, Running));
        on.store(false, Ordering::Relaxed);
        (w, [o, e], cause)
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [_, e], _)| w.kept(e).start(),
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
            assert_eq!(w.kept(e).start(), Ok(()), "{what}: E free again");
            w.take(e);
            w.check(what);
        },
    );
}

#[test]
fn a_start_of_an_exception_sequence_against_its_end_is_refused_until_reported() {
    every_split_world!(start_of_an_exception_sequence_against_its_end);
}

/// Joins whose target is started again between the join's registration and its first
/// look (found by session 55's cold review of joins).
///
/// X's run 1 ended (`Completed`); J runs. J's first poll of its join of X (lane A), with
/// X's lane (of higher priority) before section `k`: a handle starts X again (run 2, taken
/// by X's lane) and X's new run joins J. Semantics 14: J joins the run current at its
/// first poll's first section; if that is run 2, the two joins close a cycle (J waits for
/// X's run 2, X's run 2 waits for J), so exactly one of them is `JoinWouldDeadlock`; if it
/// is run 1, J gets its outcome, never `JoinWouldDeadlock` ("a join of a run before the
/// one under way never waits, so it closes no cycle"; the second review found it refused
/// when X started again between J's registration and its check). Never both pending.
fn join_against_new_start_that_joins_back<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [x], [j]) = World::<L, N, B>::of(layout, ["X"], ["J"]);
        w.start_taken(x);
        assert!(w.complete(x));
        let jx = unstarted_joiner(x);
        (w, [x, j], [joiner(&w, j), jx])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [x, _], [jj, _])| jj.borrow_mut().poll(&w, x),
        |(w, [x, j], [_, jx])| {
            w.kept(x).start().unwrap();
            w.take(x);
            jx.borrow_mut().poll(&w, j)
        },
        |what, _, pj, px, (w, [x, j], [jj, jx])| {
            // Let each lane poll again for any wake-up it got.
            let pj = jj.borrow_mut().repoll(&w, x, 0, pj);
            let px = jx.borrow_mut().repoll(&w, j, 0, px);
            let jrun = jj.borrow().run;
            match (&pj, &px, jrun) {
                // J joined run 1 (ended): its outcome, never a cycle; X's join of J waits.
                (Poll::Ready(Ok(Outcome::Completed)), Poll::Pending, Some(1)) => {}
                (Poll::Ready(Err(Error::JoinWouldDeadlock(t))), Poll::Pending, Some(2))
                    if *t == x => {}
                (Poll::Pending, Poll::Ready(Err(Error::JoinWouldDeadlock(t))), Some(2))
                    if *t == j => {}
                other => panic!(
                    "{what}: J {pj:?} (run {jrun:?}), X {px:?}: {other:?}; J joining {}, X joining {}",
                    jj.borrow().joining(&w),
                    jx.borrow().joining(&w)
                ),
            }
            w.check(what);
        },
    );
}

#[test]
fn a_join_whose_target_starts_again_and_joins_back_before_the_look_is_one_refusal() {
    every_split_world!(join_against_new_start_that_joins_back);
}

/// X's run 129 runs (runs 1 to 128 completed); J runs, and joins X's run 1 (a `Scoped`
/// kept over 128 starts of X: `Join::of_run`). J's first poll of its join (lane A), with
/// X's lane (of higher priority) joining J before section `k`. Semantics 14: runs are told
/// apart by their 16-bit count; J's join is `OutcomeLost` (run 1's outcome is gone) and
/// waits for nothing, so X's join of J closes no cycle and waits (it is not
/// `JoinWouldDeadlock`).
fn a_join_of_a_run_128_starts_back<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [x], [j]) = World::<L, N, B>::of(layout, ["X"], ["J"]);
        for _ in 0..128 {
            w.start_taken(x);
            assert!(w.complete(x));
            let _ = w.records(); // drained as they come: the trace keeps 64
        }
        w.start_taken(x);
        assert_eq!(w.runs(x), 129);
        let jj = joiner(&w, j);
        jj.borrow_mut().run = Some(1);
        let jx = unstarted_joiner(x);
        (w, [x, j], [jj, jx])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [x, _], [jj, _])| jj.borrow_mut().poll(&w, x),
        |(w, [_, j], [_, jx])| jx.borrow_mut().poll(&w, j),
        |what, _, pj, px, (w, [x, _], [jj, _])| {
            assert_eq!(pj, Poll::Ready(Err(Error::OutcomeLost(x))), "{what}");
            assert_eq!(px, Poll::Pending, "{what}: X's join of J");
            assert!(!jj.borrow().joining(&w), "{what}");
            w.check(what);
        },
    );
}

#[test]
fn a_join_of_a_run_128_starts_back_is_no_joiner_of_the_run_under_way() {
    every_split_world!(a_join_of_a_run_128_starts_back);
}

// Joins whose target ends or starts during the join's first poll (found by session 55's
// second cold review of joins).

/// X's run 1 runs; J runs. J's first poll of its join of X (lane A), with X's lane (of
/// higher priority) before section `k`: X's run 1 completes, a handle starts X again (run
/// 2, taken by X's lane) and X's new run joins J. When J joined run 1 it gets `Completed`
/// (pending first, if its look came before the end: then released and woken): run 1 never
/// waited for J, so no cycle was ever closed. When J joined run 2, exactly one is the
/// error.
fn join_of_run_that_ends_and_whose_successor_joins_back<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [x], [j]) = World::<L, N, B>::of(layout, ["X"], ["J"]);
        w.start_taken(x);
        let jx = unstarted_joiner(x);
        (w, [x, j], [joiner(&w, j), jx])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [x, _], [jj, _])| jj.borrow_mut().poll(&w, x),
        |(w, [x, j], [_, jx])| {
            assert!(w.complete(x));
            w.kept(x).start().unwrap();
            w.take(x);
            jx.borrow_mut().poll(&w, j)
        },
        |what, _, pj, px, (w, [x, j], [jj, jx])| {
            let pj = jj.borrow_mut().repoll(&w, x, 0, pj);
            let px = jx.borrow_mut().repoll(&w, j, 0, px);
            let jrun = jj.borrow().run;
            match (&pj, &px, jrun) {
                (Poll::Ready(Ok(Outcome::Completed)), Poll::Pending, Some(1)) => {}
                (Poll::Ready(Err(Error::JoinWouldDeadlock(t))), Poll::Pending, Some(2))
                    if *t == x => {}
                (Poll::Pending, Poll::Ready(Err(Error::JoinWouldDeadlock(t))), Some(2))
                    if *t == j => {}
                other => panic!("{what}: J {pj:?} (run {jrun:?}), X {px:?}: {other:?}"),
            }
            w.check(what);
        },
    );
}

#[test]
fn a_join_of_a_run_that_ends_is_no_cycle_when_the_next_run_joins_back() {
    every_split_world!(join_of_run_that_ends_and_whose_successor_joins_back);
}

/// X was never started; J runs. J's first poll of its join of X (lane A), with X's lane
/// (higher priority) before section `k`: a handle starts X (run 1), its lane takes it.
/// Semantics 14 / `Cx::join`: a join of a sequence never started is `NeverStarted`; the
/// run joined is the one under way at the first poll's first section. So J gets
/// `NeverStarted` (X idle at that section), or joins run 1 (X's lane came first): then it
/// waits registered, and X's end releases and wakes it, and it gets `Completed`. Never
/// pending without a wait (a lost wake-up).
fn join_of_never_started_against_its_first_start<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [x], [j]) = World::<L, N, B>::of(layout, ["X"], ["J"]);
        (w, x, joiner(&w, j))
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, x, jj)| jj.borrow_mut().poll(&w, x),
        |(w, x, _)| {
            w.kept(x).start().unwrap();
            w.take(x);
        },
        |what, _, pj, (), (w, x, jj)| {
            match pj {
                Poll::Ready(Err(Error::NeverStarted(t))) if t == x => {}
                Poll::Pending => {
                    assert!(jj.borrow().joining(&w), "{what}: J pending, not waiting");
                    let before = wakes(jj);
                    assert!(w.complete(x), "{what}");
                    let got = jj.borrow_mut().released(&w, x, before, what);
                    assert_eq!(got, Ok(Outcome::Completed), "{what}");
                }
                other => panic!("{what}: J {other:?} (run {:?})", jj.borrow().run),
            }
            w.check(what);
        },
    );
}

#[test]
fn a_join_of_a_sequence_started_during_its_first_poll_is_never_pending_unregistered() {
    every_split_world!(join_of_never_started_against_its_first_start);
}

// Joins whose cycle check reads the waits at different moments (session 55's third cold
// review of joins).

/// X, Y and J run; Y's run 1 waits in a join of J. J's first poll of its join of X (lane
/// A), with a lane of higher priority before section `k`: Y's run 1 is dropped (aborted;
/// its wait is over), a handle starts Y again (run 2, taken), and X joins Y's run 2. At no
/// moment do the waits close a cycle (J waits for X, X for Y's run 2, which waits for
/// nothing; Y's run 1 that waited for J was over before X waited): J's join never is
/// `JoinWouldDeadlock`. Both pend; Y's end releases X, X's end releases J.
fn join_whose_check_meets_a_wait_of_a_run_dropped_meanwhile<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let (w, [x, y], [j]) = World::<L, N, B>::of(layout, ["X", "Y"], ["J"]);
        let (jj, jx, jy) = (joiner(&w, j), joiner(&w, x), joiner(&w, y));
        assert_eq!(jy.borrow_mut().poll(&w, j), Poll::Pending);
        (w, [x, y, j], [jj, jx, jy])
    };
    interleave(
        &named::<L>(layout, format_args!("")),
        setup,
        |(w, [x, _, _], [jj, _, _])| jj.borrow_mut().poll(&w, x),
        |(w, [_, y, _], [_, jx, _])| {
            w.replace_run(y);
            jx.borrow_mut().poll(&w, y)
        },
        |what, _, pj, px, (w, [x, y, _], [jj, jx, _])| {
            let pj = jj.borrow_mut().repoll(&w, x, 0, pj);
            let px = jx.borrow_mut().repoll(&w, y, 0, px);
            assert_eq!(
                (&pj, &px),
                (&Poll::Pending, &Poll::Pending),
                "{what}: J {pj:?}, X {px:?}"
            );
            let before = wakes(jx);
            assert!(w.complete(y), "{what}");
            let got = jx.borrow_mut().released(&w, y, before, what);
            assert_eq!(got, Ok(Outcome::Completed), "{what}");
            let before = wakes(jj);
            assert!(w.complete(x), "{what}");
            let got = jj.borrow_mut().released(&w, x, before, what);
            assert_eq!(got, Ok(Outcome::Completed), "{what}");
            w.check(what);
        },
    );
}

/// Without the check made again when the waits changed during it, this fails at the
/// sections where the check has read Y's old wait and not yet X's new one.
#[test]
fn a_join_whose_check_meets_a_wait_of_a_run_dropped_meanwhile_is_no_cycle() {
    every_split_world!(join_whose_check_meets_a_wait_of_a_run_dropped_meanwhile);
}
