//! Systematic interleavings of the tick and the lanes under the portable lock.
//!
//! With `CriticalSection` every multi-step operation is several short sections, and any
//! task may call anything: the tick (a timer interrupt) preempts a lane between two
//! sections of a start, an end, a restart, a request, a join or a dropped run's teardown,
//! and a lane of higher priority than the tick runs between two sections of the tick.
//!
//! Each test here runs one operation once under the test lock [`Interleaved`] to count its
//! sections, then, for every section `k`, builds a fresh sequencer, runs the operation with
//! the other party (a tick that fires a monitor or a timeout or applies a request; or a
//! lane's start, end, request) inserted right before section `k`, and asserts the outcome
//! the semantics (docs/semantics.md) demand whatever `k` is: exact states and causes, the
//! result of the operation, and invariants that hold after every interleaving: nothing
//! active below an aborted caller (semantics 4 and 9), a consistent transition trace (every
//! record's `from` is the previous `to`, an allowed change, nothing lost).
//!
//! Tests marked `#[ignore = "defect: ..."]` fail today; the reason names the defect.
#![allow(clippy::unwrap_used, clippy::panic, clippy::indexing_slicing)]

extern crate std;

use core::sync::atomic::{AtomicBool, Ordering};
use std::boxed::Box;
use std::cell::RefCell;
use std::format;
use std::rc::Rc;
use std::vec::Vec;

use crate::lock::interleaved::{self, Interleaved};
use crate::model::id::RunId;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::trace::Record;
use crate::{
    Behaviour, Cause, Condition, Duration, Error, Event, Instant, Monitor, MonitorId, Monitors,
    Outcome, RunningState, SeqConfig, SeqId, Sequencer,
};

use RunningState::{Aborted, Idle, Paused, Restarting, Running, Terminated};

/// A sequencer under the interleaving lock, with a trace that no scenario overflows.
type Sq = Sequencer<(), 8, 256, Interleaved, 8, 1>;

/// The first monitor of a table.
const M0: Cause = Cause::Monitor(MonitorId(0));

/// A sequencer and the monitor table its ticks use, both `'static` so that a closure run
/// between two sections can tick.
#[derive(Clone, Copy)]
struct World {
    seq: &'static Sq,
    monitors: &'static RefCell<Monitors<'static, (), 4>>,
}

impl World {
    fn new() -> World {
        // Nothing left over from an earlier test on this thread.
        interleaved::at(usize::MAX, || {});
        World {
            seq: Box::leak(Box::new(Sequencer::empty())),
            monitors: Box::leak(Box::new(RefCell::new(Monitors::new()))),
        }
    }

    /// Registers `config` and declares its lane.
    fn add(&self, config: SeqConfig<()>) -> SeqId {
        let id = self.seq.register(config).unwrap();
        self.seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        id
    }

    /// A sequence polled every millisecond, with a lane.
    fn seq(&self, name: &'static str) -> SeqId {
        self.add(SeqConfig::new(name))
    }

    /// A monitor of `owner` whose condition is `flag`.
    fn monitor(&self, owner: SeqId, flag: &'static AtomicBool, b: Behaviour, e: Option<SeqId>) {
        let condition: &'static mut (dyn Condition<()> + Send) =
            Box::leak(Box::new(move |_: &(), _: Instant| {
                flag.load(Ordering::Relaxed)
            }));
        let mut m = Monitor::new("m", condition, b);
        if let Some(e) = e {
            m = m.exception(e);
        }
        self.monitors.borrow_mut().add(owner, m).unwrap();
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

    /// Starts `id` by a handle (a main sequence) and lets its lane take the start.
    fn start_taken(&self, id: SeqId) -> RunId {
        self.seq.sequence_by_id(id).unwrap().start().unwrap();
        self.take(id)
    }

    /// `id`'s lane takes its pending start.
    fn take(&self, id: SeqId) -> RunId {
        Port::take_start(self.seq, id, 0, core::task::Waker::noop()).unwrap()
    }

    /// `id`'s lane ends its current run completed and reports it over.
    fn complete(&self, id: SeqId) -> bool {
        let run = self.run(id);
        let ended = Port::end(self.seq, run, Outcome::Completed);
        if ended {
            Port::finished(self.seq, run);
        }
        ended
    }

    fn records(&self) -> Vec<Record> {
        let mut out = Vec::new();
        assert_eq!(self.seq.drain_records(|r| out.push(r)), 0, "records lost");
        out
    }

    /// The invariants of every interleaving: no sequence under way (running, paused,
    /// restarting) has an aborted caller up its caller links; the trace's transitions
    /// chain (each `from` is the sequence's last `to`, from `Idle`) and are allowed
    /// changes. `what` names the interleaving.
    fn check(&self, what: &str) {
        let count = self.seq.with(|s| s.count());
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
        let mut last = [Idle; 8];
        for r in self.records() {
            if let Some(t) = r.transition() {
                let prev = &mut last[t.sequence.index()];
                assert_eq!(t.from, *prev, "{what}: {t:?} after {prev:?}");
                assert!(t.from.can_transition_to(t.to), "{what}: {t:?}");
                *prev = t.to;
            }
        }
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
                    e.downcast_ref::<std::string::String>()
                        .cloned()
                        .or_else(|| {
                            e.downcast_ref::<&str>()
                                .map(|s| std::string::String::from(*s))
                        })
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
fn flag(on: bool) -> &'static AtomicBool {
    Box::leak(Box::new(AtomicBool::new(on)))
}

// ---------------------------------------------------------------------------------------
// 1. The tick inserted into a start.
// ---------------------------------------------------------------------------------------

/// What the tick inserted into a start does to the starting sequence O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fire {
    /// O's monitor fires, `AbortOwner`, no exception sequence.
    Abort,
    /// O's monitor fires, `AbortOwner`, exception sequence E (ended by its lane later).
    AbortAfterException,
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

/// O (a main sequence, polled every ms) runs, started at 0; `fire` set up for the tick at
/// 1 ms. C (timeout 5 ms) and E are registered. Returns the world and O, C, E.
fn owner_and_child(fire: Fire) -> (World, SeqId, SeqId, SeqId) {
    let w = World::new();
    let o = match fire {
        Fire::Timeout => w.add(SeqConfig::new("O").timeout(Duration::from_millis(1))),
        _ => w.seq("O"),
    };
    let c = w.add(SeqConfig::new("C").timeout(Duration::from_millis(5)));
    let e = w.seq("E");
    let on = flag(true);
    match fire {
        Fire::Abort => w.monitor(o, on, Behaviour::AbortOwner, None),
        Fire::AbortAfterException => w.monitor(o, on, Behaviour::AbortOwner, Some(e)),
        Fire::Restart => w.monitor(o, on, Behaviour::RestartOwner, None),
        Fire::Pause => w.monitor(o, on, Behaviour::PauseOwner, None),
        Fire::Timeout | Fire::AbortRequest => {}
    }
    w.start_taken(o);
    if fire == Fire::AbortRequest {
        w.seq.sequence_by_id(o).unwrap().abort().unwrap();
    }
    (w, o, c, e)
}

/// The start of C by O's run, `how`.
fn start_child(w: &World, o: SeqId, c: SeqId, how: How) -> Result<(), Error> {
    let by = Some(w.run(o));
    match how {
        How::InLane => Port::start_in_lane(w.seq, c, by),
        How::Blocking => w
            .seq
            .begin(c, by, Mode::Blocking { maker: 0 }, Cause::Start, 0)
            .map(|_| ()),
    }
}

/// For every section `k` of a start of C by O (`how`), the tick at 1 ms (doing `fire` to
/// O) before section `k`, then what `fire` leads to (E ends, the next tick). Checks the
/// outcome with `expect(k, start result, w, o, c)` and the invariants.
fn tick_into_start(
    fire: Fire,
    how: How,
    expect: impl Fn(usize, Result<(), Error>, &World, SeqId, SeqId),
) {
    let count = sections(
        || owner_and_child(fire),
        |(w, o, c, _)| {
            let _ = start_child(w, *o, *c, how);
        },
    );
    every_k(count, |k| {
        let (w, o, c, e) = owner_and_child(fire);
        interleaved::at(k, move || w.tick(1));
        let started = start_child(&w, o, c, how);
        assert!(interleaved::taken() > k, "the tick ran");
        if fire == Fire::AbortAfterException {
            // O is held while E runs; E's lane runs it to its end; the next tick applies
            // O's behaviour.
            assert_eq!((w.state(o), w.state(e)), (Running, Running), "k={k}");
            w.take(e);
            assert!(w.complete(e));
            w.tick(2);
        }
        expect(k, started, &w, o, c);
        w.check(&format!("{fire:?}, {how:?}, k={k}"));
    });
}

/// The outcome when O is aborted (or restarted) by `cause`: the start was refused
/// (`NotRunning(O)`, C never ran), or C started and was torn down with O.
fn torn_down_with(
    k: usize,
    started: Result<(), Error>,
    w: &World,
    o: SeqId,
    c: SeqId,
    owner: (RunningState, Cause),
) {
    let cause = owner.1;
    assert_eq!(w.ended(o), owner, "k={k}");
    match started {
        Ok(()) => assert_eq!(w.ended(c), (Aborted, cause), "k={k}"),
        Err(e) => {
            assert_eq!(e, Error::NotRunning(o), "k={k}");
            assert_eq!(w.state(c), Idle, "k={k}");
        }
    }
}

/// O starts C (in C's lane, or blocking) while the tick aborts O (its `AbortOwner` monitor,
/// its timeout, an abort request, or its monitor after its exception sequence E ended).
/// Wherever the tick lands, nothing O started outlives O (semantics 9): either the start is
/// refused (`NotRunning(O)`) and C never ran, or C is aborted with O, with O's cause.
#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it() {
    for how in [How::InLane, How::Blocking] {
        for (fire, cause) in [
            (Fire::Abort, M0),
            (Fire::AbortAfterException, M0),
            (Fire::Timeout, Cause::Timeout(SeqId(0))),
            (Fire::AbortRequest, Cause::Abort),
        ] {
            tick_into_start(fire, how, |k, started, w, o, c| {
                torn_down_with(k, started, w, o, c, (Aborted, cause));
            });
        }
    }
}

/// O starts C while the tick restarts O (`RestartOwner`): a restart aborts everything below
/// its target, so C is refused or aborted (cause the monitor), never left running below the
/// restarted run; O is `Restarting`.
#[test]
fn a_start_by_a_sequence_the_tick_restarts_is_torn_down_by_the_restart() {
    for how in [How::InLane, How::Blocking] {
        tick_into_start(Fire::Restart, how, |k, started, w, o, c| {
            torn_down_with(k, started, w, o, c, (Restarting, M0));
        });
    }
}

/// O starts C in C's own lane while the tick pauses O (`PauseOwner`): a pause holds O and
/// the sequences it blocks in its lane, not a non-blocking child: the start succeeds and C
/// runs; O is paused.
#[test]
fn a_non_blocking_start_by_a_sequence_the_tick_pauses_runs() {
    tick_into_start(Fire::Pause, How::InLane, |k, started, w, o, c| {
        assert_eq!(started, Ok(()), "k={k}");
        assert_eq!((w.state(o), w.state(c)), (Paused, Running), "k={k}");
    });
}

/// O starts C blocking (in O's lane) while the tick pauses O (`PauseOwner`, its condition
/// stays true). A pause holds the sequences O blocks in its lane, and their clocks stop
/// (semantics 7): wherever the tick lands, C ends up `Paused` with O, and its 5 ms timeout
/// does not run out while O stays paused for 10 ms. When the condition clears, both resume.
#[test]
fn a_blocking_start_by_a_sequence_the_tick_pauses_is_paused_with_it() {
    let count = sections(
        || owner_and_child(Fire::Pause),
        |(w, o, c, _)| {
            let _ = start_child(w, *o, *c, How::Blocking);
        },
    );
    every_k(count, |k| {
        let (w, o, c, _) = owner_and_child(Fire::Pause);
        interleaved::at(k, move || w.tick(1));
        assert_eq!(start_child(&w, o, c, How::Blocking), Ok(()), "k={k}");
        for ms in 2..=11 {
            w.tick(ms);
        }
        assert_eq!(
            (w.state(o), w.ended(c)),
            (Paused, (Paused, Cause::Start)),
            "k={k} after 10 ms"
        );
        w.check(&format!("k={k}"));
    });
}

/// A main sequence C is started by a handle while the tick aborts another sequence O (its
/// monitor): C is not O's, so it runs whatever section the tick preempts.
#[test]
fn a_handle_start_during_an_unrelated_abort_runs() {
    let count = sections(
        || owner_and_child(Fire::Abort),
        |(w, _, c, _)| w.seq.sequence_by_id(*c).unwrap().start().unwrap(),
    );
    every_k(count, |k| {
        let (w, o, c, _) = owner_and_child(Fire::Abort);
        interleaved::at(k, move || w.tick(1));
        assert_eq!(w.seq.sequence_by_id(c).unwrap().start(), Ok(()), "k={k}");
        assert_eq!((w.ended(o), w.state(c)), ((Aborted, M0), Running), "k={k}");
        w.check(&format!("k={k}"));
    });
}

// ---------------------------------------------------------------------------------------
// 2. A lane of higher priority inserted into the tick's teardown.
// ---------------------------------------------------------------------------------------

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

/// R (main) started Y non-blocking, Y runs X blocking (in Y's lane); G is registered.
/// With `deep` false only R runs (nothing has a caller link: the walk's shortcut). The
/// teardown `how` is set up for the tick at 1 ms. Returns the world, R, Y, X, G.
fn tree(how: Teardown, deep: bool) -> (World, [SeqId; 4]) {
    let w = World::new();
    let [r, y, x, g] = ["R", "Y", "X", "G"].map(|n| w.seq(n));
    if how == Teardown::Monitor {
        w.monitor(r, flag(true), Behaviour::AbortOwner, None);
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
    // A tick before the one under test folds the tree into the active sets: the class is
    // busy, so a start made during the tick at 1 ms keeps its grid.
    w.tick(0);
    match how {
        Teardown::Request => w.seq.sequence_by_id(r).unwrap().abort().unwrap(),
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
fn lane_start_into_teardown(how: Teardown, deep: bool) {
    let count = sections(|| tree(how, deep), |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, [r, y, x, g]) = tree(how, deep);
        let starter = if deep { y } else { r };
        let result = Rc::new(RefCell::new(None));
        let out = result.clone();
        interleaved::at(k, move || {
            let by = Some(w.run(starter));
            *out.borrow_mut() = Some(Port::start_in_lane(w.seq, g, by));
        });
        w.tick(1);
        let what = format!("{how:?}, deep {deep}, k={k}");
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

/// The tick aborts R, Y (non-blocking child of R) and X (blocking in Y) for an abort
/// request of R, innermost first. After X's stop Y's lane, of higher priority than the
/// tick, runs: Y, still running, starts a fallback G. G must be torn down with Y (as the
/// dropped run's teardown does, walking again), or refused.
#[test]
fn a_start_below_a_caller_the_tick_has_not_aborted_yet_is_torn_down_for_a_request() {
    lane_start_into_teardown(Teardown::Request, true);
}

/// As above for an abort-all (the safety system's emergency stop): every sequence,
/// including one a lane of higher priority started during the walk, is aborted by the
/// tick that carries the abort-all out.
#[test]
fn a_start_during_an_abort_all_is_torn_down() {
    lane_start_into_teardown(Teardown::AbortAll, true);
}

/// As above for R's `AbortOwner` monitor (no exception sequence): the behaviour's walk
/// tears down G too.
#[test]
fn a_start_during_a_monitors_abort_is_torn_down() {
    lane_start_into_teardown(Teardown::Monitor, true);
}

/// R runs alone (nothing has a caller link): the tick's walk of an abort request takes its
/// shortcut (one section to see that nothing is linked, then R's stop). R's lane, of higher
/// priority, starts G between the two: G must be torn down with R, or refused.
#[test]
fn a_start_during_the_shortcut_walk_of_a_request_is_torn_down() {
    lane_start_into_teardown(Teardown::Request, false);
}

/// As above, the abort-all.
#[test]
fn a_start_during_the_shortcut_walk_of_an_abort_all_is_torn_down() {
    lane_start_into_teardown(Teardown::AbortAll, false);
}

// ---------------------------------------------------------------------------------------
// 3. A lane's start inserted into the tick's first sections: the grid.
// ---------------------------------------------------------------------------------------

/// R (polled every ms, a 1 ms timeout) is started at 0, before any tick: its first poll is
/// at 1 ms (one period after a start into an idle class, semantics 1), where its timeout
/// has run out. A lane of higher priority starts G (same class, 1 ms timeout) before
/// section `k` of the tick at 1 ms. R's first poll stays at 1 ms: R is aborted by its
/// timeout in that tick, whatever `k`. G's first poll is one period after its own start:
/// at 1 ms for a start before the tick (`k` = 0, time 0), else at 2 ms.
#[test]
fn a_start_during_the_ticks_first_sections_keeps_the_first_poll_of_a_member_started_since_the_fold()
{
    let setup = || {
        let w = World::new();
        let timed = |n| SeqConfig::new(n).timeout(Duration::from_millis(1));
        let [r, g] = ["R", "G"].map(|n| w.add(timed(n)));
        w.start_taken(r);
        (w, r, g)
    };
    let count = sections(setup, |(w, _, _)| w.tick(1));
    every_k(count, |k| {
        let (w, r, g) = setup();
        interleaved::at(k, move || w.seq.sequence_by_id(g).unwrap().start().unwrap());
        w.tick(1);
        assert_eq!(w.ended(r), (Aborted, Cause::Timeout(r)), "k={k}: R at 1 ms");
        let g_at_1 = if k == 0 { Aborted } else { Running };
        assert_eq!(w.state(g), g_at_1, "k={k}: G at 1 ms");
        w.tick(2);
        assert_eq!(w.ended(g), (Aborted, Cause::Timeout(g)), "k={k}: G at 2 ms");
        w.check(&format!("k={k}"));
    });
}

// ---------------------------------------------------------------------------------------
// 4. A lane's end inserted into a firing tick.
// ---------------------------------------------------------------------------------------

/// What fires on O in the tick at 1 ms.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Firing {
    /// A monitor, `AbortOwner`, exception sequence E.
    AbortAfterE,
    /// A monitor, `RestartOwner`.
    Restart,
    /// O's 1 ms timeout (`AbortOwner`).
    Timeout,
}

/// O's lane, of higher priority than the tick, ends O's run (completed) before section `k`
/// of the tick at 1 ms in which `firing` fires on O. Either the end comes first: O is
/// `Terminated` (completed), and nothing fires for the ended run (no `Fired` record, no
/// exception sequence refused, E never started, no exception counted); or the firing comes
/// first: the end is refused (O holds, or is restarting or aborted), and the firing takes
/// its course: E ends and the next tick aborts O; the restart leaves O `Restarting`; the
/// timeout aborts O.
fn end_into_firing_tick(firing: Firing) {
    let setup = move || {
        let w = World::new();
        let o = match firing {
            Firing::Timeout => w.add(SeqConfig::new("O").timeout(Duration::from_millis(1))),
            _ => w.seq("O"),
        };
        let e = w.seq("E");
        match firing {
            Firing::AbortAfterE => w.monitor(o, flag(true), Behaviour::AbortOwner, Some(e)),
            Firing::Restart => w.monitor(o, flag(true), Behaviour::RestartOwner, None),
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
        let what = format!("{firing:?}, k={k}");
        let ended = ended.borrow().expect("the lane ran");
        let fired = |w: &World| {
            w.records()
                .iter()
                .filter(|r| matches!(r.event(), Some(Event::Fired { owner, .. }) if owner == o))
                .count()
        };
        if ended {
            assert_eq!(w.ended(o).0, Terminated, "{what}");
            assert_eq!(
                w.seq.with(|s| s.block(o).unwrap().outcome),
                Some(Outcome::Completed)
            );
            assert_eq!(w.state(e), Idle, "{what}: E");
            assert_eq!(w.seq.exceptions_not_run(), 0, "{what}");
            #[cfg(feature = "counters")]
            assert_eq!(
                w.seq.sequence_by_id(o).unwrap().counters().exceptions,
                0,
                "{what}"
            );
            assert_eq!(fired(&w), 0, "{what}: a firing recorded for an ended run");
            return;
        }
        match firing {
            Firing::AbortAfterE => {
                assert_eq!((w.state(o), w.state(e)), (Running, Running), "{what}");
                w.take(e);
                assert!(w.complete(e));
                w.tick(2);
                assert_eq!(w.ended(o), (Aborted, M0), "{what}");
            }
            Firing::Restart => assert_eq!(w.ended(o), (Restarting, M0), "{what}"),
            Firing::Timeout => assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}"),
        }
        w.check(&what);
    });
}

/// `end_into_firing_tick` for a monitor with an exception sequence (`AbortOwner`).
#[test]
fn an_end_during_a_firing_with_an_exception_sequence_is_either_first_or_refused() {
    end_into_firing_tick(Firing::AbortAfterE);
}

/// `end_into_firing_tick` for a `RestartOwner` monitor.
#[test]
fn an_end_during_a_restarting_firing_is_either_first_or_refused() {
    end_into_firing_tick(Firing::Restart);
}

/// `end_into_firing_tick` for a timeout.
#[test]
fn an_end_during_a_timeout_is_either_first_or_refused() {
    end_into_firing_tick(Firing::Timeout);
}

// ---------------------------------------------------------------------------------------
// 5. The tick inserted into requests, restarts, joins and dropped runs.
// ---------------------------------------------------------------------------------------

/// An abort of O is requested (by a handle) while the tick at 1 ms restarts O (its
/// `RestartOwner` monitor); the tick is inserted before each section of the request. A
/// `Restarting` sequence may be aborted, so the request is accepted whatever `k`, and a
/// restart does not end the run it was made of: the tick at 2 ms aborts O (cause `Abort`),
/// whether or not O's lane has run it again in between.
#[test]
fn an_abort_requested_while_the_tick_restarts_the_sequence_is_carried_out() {
    let setup = || {
        let w = World::new();
        let o = w.seq("O");
        w.monitor(o, flag(true), Behaviour::RestartOwner, None);
        w.start_taken(o);
        (w, o)
    };
    let abort = |w: &World, o| w.seq.sequence_by_id(o).unwrap().abort();
    let count = sections(setup, |(w, o)| abort(w, *o).unwrap());
    for relaunched in [false, true] {
        every_k(count, |k| {
            let (w, o) = setup();
            interleaved::at(k, move || w.tick(1));
            assert_eq!(abort(&w, o), Ok(()), "k={k}");
            if relaunched && w.state(o) == Restarting {
                // O's lane obeys the clearance `Restart`.
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
/// monitor). Either the request comes first (accepted; it is applied before the monitors
/// when the tick sees it, else it finds O aborted) or it is refused (`NotRunning`); O is
/// aborted once, by the request or by the monitor, and stays so after the next tick.
#[test]
fn an_abort_requested_while_the_tick_aborts_the_sequence_aborts_it_once() {
    let setup = || {
        let w = World::new();
        let o = w.seq("O");
        w.monitor(o, flag(true), Behaviour::AbortOwner, None);
        w.start_taken(o);
        (w, o)
    };
    let count = sections(setup, |(w, o)| {
        let h = w.seq.sequence_by_id(*o).unwrap();
        interleaved::at(usize::MAX, || {});
        h.abort().unwrap();
    });
    every_k(count, |k| {
        let (w, o) = setup();
        let h = w.seq.sequence_by_id(o).unwrap();
        interleaved::at(k, move || w.tick(1));
        let asked = h.abort();
        assert_eq!(w.ended(o), (Aborted, M0), "k={k}: the tick came first");
        if k == 0 {
            assert_eq!(asked, Err(Error::NotRunning(o)));
        } else {
            assert_eq!(asked, Ok(()), "k={k}");
        }
        w.tick(2);
        assert_eq!(w.ended(o), (Aborted, M0), "k={k}");
        w.check(&format!("k={k}"));
    });
}

/// A pause of O is requested while the tick at 1 ms pauses O (its `PauseOwner` monitor,
/// condition true at 1 ms, false from 2 ms), inserted before each section of the request.
/// If the request was accepted (O still running when it was checked), O stays paused when
/// the monitor lets go (only a resume request lifts a request's pause, semantics 7); if it
/// was refused (`NotRunning`: the monitor paused O first), O resumes at 2 ms.
#[test]
fn a_pause_requested_while_the_tick_pauses_the_sequence_outlasts_the_monitor_iff_accepted() {
    let setup = || {
        let w = World::new();
        let o = w.seq("O");
        let holds = flag(true);
        w.monitor(o, holds, Behaviour::PauseOwner, None);
        w.start_taken(o);
        (w, o, holds)
    };
    let pause = |w: &World, o| w.seq.sequence_by_id(o).unwrap().pause();
    let count = sections(setup, |(w, o, _)| pause(w, *o).unwrap());
    every_k(count, |k| {
        let (w, o, holds) = setup();
        interleaved::at(k, move || w.tick(1));
        let asked = pause(&w, o);
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

/// O's lane obeys `Restart` (`Sequencer::restart`) after O's `RestartOwner` monitor fired
/// at 1 ms; the tick at 2 ms, with an abort-all (the safety system) or an abort request of
/// O pending, comes before section `k` of the restart. The abort stands whatever `k`: O
/// ends `Aborted` and is never `Running` again without a new start.
#[test]
fn an_abort_during_a_restart_stands() {
    for by_request in [false, true] {
        let setup = move || {
            let w = World::new();
            let o = w.seq("O");
            let fault = flag(true);
            w.monitor(o, fault, Behaviour::RestartOwner, None);
            w.start_taken(o);
            w.tick(1);
            assert_eq!(w.state(o), Restarting);
            fault.store(false, Ordering::Relaxed);
            if by_request {
                w.seq.sequence_by_id(o).unwrap().abort().unwrap();
            } else {
                w.seq.abort_all();
            }
            (w, o, w.run(o))
        };
        let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
        every_k(count, |k| {
            let (w, o, run) = setup();
            interleaved::at(k, move || w.tick(2));
            w.seq.restart(run);
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

/// O's lane obeys `Restart` (`Sequencer::restart`) after O's `RestartOwner` monitor fired
/// at 1 ms (its condition stays true); the tick at 2 ms comes before each section of the
/// restart. The restart commits once, after the tick (O `Running`, one `Restarting →
/// Running` record), and the restarted run's monitors start again from "false": the tick
/// at 3 ms restarts O again (its second restart, within the limit).
#[test]
fn a_restart_preempted_by_the_tick_runs_again_once() {
    let setup = || {
        let w = World::new();
        let o = w.seq("O");
        w.monitor(o, flag(true), Behaviour::RestartOwner, None);
        w.start_taken(o);
        w.tick(1);
        assert_eq!(w.state(o), Restarting);
        (w, o, w.run(o))
    };
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    every_k(count, |k| {
        let (w, o, run) = setup();
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        // A tick before the commit makes it schedule again: it commits after the tick.
        assert_eq!(w.state(o), Running, "k={k}");
        w.tick(3);
        assert_eq!(w.ended(o), (Restarting, M0), "k={k}: fired again at 3 ms");
        let restarts = w
            .records()
            .iter()
            .filter_map(Record::transition)
            .filter(|t| t.sequence == o && t.from == Restarting && t.to == Running)
            .count();
        assert_eq!(restarts, 1, "k={k}");
    });
}

/// J joins O's run (`Port::join`) while the tick at 1 ms aborts O (its `AbortOwner`
/// monitor), inserted before each section of the join's first poll. J gets O's outcome,
/// `Aborted(monitor)`: at once, or, when the first poll is pending, at the next poll, and
/// then it was released (no longer waiting in a join: the end woke its lane).
#[test]
fn a_join_during_the_abort_of_the_joined_run_gets_its_outcome() {
    let setup = || {
        let w = World::new();
        let [o, j] = ["O", "J"].map(|n| w.seq(n));
        w.monitor(o, flag(true), Behaviour::AbortOwner, None);
        w.start_taken(o);
        w.start_taken(j);
        (w, o, j)
    };
    let count = sections(setup, |(w, o, j)| {
        let _ = Port::join(w.seq, *j, *o, &mut None);
    });
    every_k(count, |k| {
        let (w, o, j) = setup();
        interleaved::at(k, move || w.tick(1));
        let mut run = None;
        let first = Port::join(w.seq, j, o, &mut run);
        let outcome = match first {
            core::task::Poll::Ready(r) => r,
            core::task::Poll::Pending => {
                assert!(
                    !w.seq.with(|s| s.sets.has(Set::Joining, j)),
                    "k={k}: released"
                );
                match Port::join(w.seq, j, o, &mut run) {
                    core::task::Poll::Ready(r) => r,
                    core::task::Poll::Pending => panic!("k={k}: still pending"),
                }
            }
        };
        assert_eq!(outcome, Ok(Outcome::Aborted(M0)), "k={k}");
        assert!(!w.seq.with(|s| s.sets.has(Set::Joining, j)), "k={k}");
        w.check(&format!("k={k}"));
    });
}

/// R runs X blocking; X's monitor (`behaviour`, exception sequence E for `AbortOwner`)
/// holds from 1 ms. R's run is dropped (`Port::abandon`) while the tick at 1 ms fires X's
/// monitor, inserted before each section of the teardown. Everything is torn down
/// (semantics 13): R and X aborted (`Dropped`), E not left under way (never started, or
/// aborted with X), and nothing is under way after the next tick either (an exception
/// sequence's end reported to an aborted owner applies nothing). Only a tick before the
/// teardown's first stop, with `AbortCallerOfOwner`, aborts R and X itself (the monitor's
/// cause); the teardown then finds nothing.
#[test]
fn a_dropped_run_during_a_firing_below_it_leaves_nothing_under_way() {
    for behaviour in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        let setup = move || {
            let w = World::new();
            let [r, x, e] = ["R", "X", "E"].map(|n| w.seq(n));
            let e_of = (behaviour == Behaviour::AbortOwner).then_some(e);
            w.monitor(x, flag(true), behaviour, e_of);
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
        every_k(count, |k| {
            let (w, [r, x, e]) = setup();
            interleaved::at(k, move || w.tick(1));
            Port::abandon(w.seq, r, &());
            let what = format!("{behaviour:?}, k={k}");
            // A tick before the teardown's first stop, with `AbortCallerOfOwner`,
            // aborts R and X itself: then both with the monitor's cause.
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
                    "{what}"
                );
            }
            w.check(&what);
        });
    }
}

/// The tick at 1 ms restarts O (its `RestartOwner` monitor); an abort of O is requested by
/// a lane of higher priority before section `k` of that tick. The request is accepted
/// (O is running or restarting, both may be aborted) and a restart does not end the run it
/// was made of, so it is carried out: after the tick at 2 ms O is `Aborted` (cause
/// `Abort`), whether or not O's lane ran it again in between.
#[test]
fn an_abort_requested_during_a_restarting_tick_is_carried_out() {
    let setup = || {
        let w = World::new();
        let o = w.seq("O");
        w.monitor(o, flag(true), Behaviour::RestartOwner, None);
        w.start_taken(o);
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(1));
    for relaunched in [false, true] {
        every_k(count, |k| {
            let (w, o) = setup();
            let h = w.seq.sequence_by_id(o).unwrap();
            let asked = Rc::new(RefCell::new(None));
            let out = asked.clone();
            interleaved::at(k, move || *out.borrow_mut() = Some(h.abort()));
            w.tick(1);
            let what = format!("relaunched {relaunched}, k={k}");
            assert_eq!(*asked.borrow(), Some(Ok(())), "{what}");
            if relaunched && w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
            w.tick(2);
            assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}");
            w.check(&what);
        });
    }
}
