//! Polled conditions, restarts driven by the lane and `PauseOwner` monitors against lane
//! operations, under both locks, in sequencers of one word and of two.
//!
//! The runs here are real lanes (`lane()`, polled by hand with a counting waker) of a
//! [`Probe`]: an action that waits at a gate (no waker: the test opens it and polls),
//! then either ends (the run's exit condition is polled) or waits in `Cx::wait_until`;
//! every check of the condition is counted. A lane's poll (the end of the action:
//! `clearance`, `set_poll_wait`, the first check; or a due poll: `due_poll`, the check)
//! has the tick inserted before each of its sections, and (portable lock) the lane's poll
//! is inserted before each section of the tick. Semantics 1: the condition is checked
//! right after the action only with the clearance to go on, once per due poll, never while
//! held; a poll that falls due while its sequence is held is skipped. Last, lanes joined
//! in one task, one of which moves to a task of its own during the tick: the lanes the
//! tick remembers for its wake-ups (portable lock).

use super::*;

use core::convert::Infallible;
use core::future::Future;
use core::pin::Pin;
use core::task::Context;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use crate::{lane, Cx, Failure, Seq, Sequence};

/// A sequence whose action waits at `gate`, then (with `wait`) in `Cx::wait_until` for
/// `exit`; without `wait` its exit condition is `exit`. Every check counted in `checks`.
struct Probe {
    gate: &'static AtomicBool,
    exit: &'static AtomicBool,
    checks: &'static AtomicUsize,
    wait: bool,
}

impl Sequence<()> for Probe {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let gate = self.gate;
        core::future::poll_fn(|_| {
            if gate.load(Ordering::Relaxed) {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await;
        if self.wait {
            let (exit, checks) = (self.exit, self.checks);
            cx.wait_until(move |_| {
                checks.fetch_add(1, Ordering::Relaxed);
                exit.load(Ordering::Relaxed)
            })
            .await;
        }
        Ok(())
    }

    fn check_exit_condition(&mut self, _: &Cx<'_, ()>) -> bool {
        if self.wait {
            return true;
        }
        self.checks.fetch_add(1, Ordering::Relaxed);
        self.exit.load(Ordering::Relaxed)
    }
}

/// A lane future polled by hand, with a counting waker; `seen`: the wake-ups when its last
/// poll began.
struct HandLane {
    fut: RefCell<Pin<Box<dyn Future<Output = Infallible>>>>,
    waker: Waker,
    wakes: Arc<Count>,
    seen: Cell<usize>,
}

impl HandLane {
    fn poll(&self) {
        self.seen.set(woken(&self.wakes));
        let mut cx = Context::from_waker(&self.waker);
        let _ = self.fut.borrow_mut().as_mut().poll(&mut cx);
    }

    /// What an executor does: polls again while woken since the last poll began.
    fn settle(&self) {
        let mut n = 0;
        while woken(&self.wakes) > self.seen.get() {
            self.poll();
            n += 1;
            assert!(n < 100, "the lane is woken forever");
        }
    }

    fn wakes(&self) -> usize {
        woken(&self.wakes)
    }
}

/// A world with O, a [`Probe`] with its lane, and O's monitor (the party's) on `flag`.
struct P<L: Lock + 'static, const N: usize, const B: usize> {
    w: World<L, N, B>,
    o: SeqId,
    lane: &'static HandLane,
    flag: &'static AtomicBool,
    gate: &'static AtomicBool,
    exit: &'static AtomicBool,
    checks: &'static AtomicUsize,
}

impl<L: Lock + 'static, const N: usize, const B: usize> Clone for P<L, N, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lock + 'static, const N: usize, const B: usize> Copy for P<L, N, B> {}

impl<L: Lock + 'static, const N: usize, const B: usize> P<L, N, B> {
    fn checks(&self) -> usize {
        self.checks.load(Ordering::Relaxed)
    }
}

/// What the tick (or a request before it) does to O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Party {
    /// O's poll is due, nothing fires.
    Due,
    /// O's `PauseOwner` monitor holds from this tick on.
    Pause,
    /// O's `AbortOwner` monitor fires.
    Abort,
    /// O's `RestartOwner` monitor fires (its condition clears after the tick).
    Restart,
    /// An abort of O is requested, then the tick.
    Request,
    /// An abort-all, then the tick.
    AbortAll,
}

const PARTIES: [Party; 6] = [
    Party::Due,
    Party::Pause,
    Party::Abort,
    Party::Restart,
    Party::Request,
    Party::AbortAll,
];

impl Party {
    fn cause(self) -> Cause {
        match self {
            Party::Request => Cause::Abort,
            Party::AbortAll => Cause::AbortAll,
            _ => M0,
        }
    }

    /// The party at `ms`.
    fn act<L: Lock + 'static, const N: usize, const B: usize>(self, p: P<L, N, B>, ms: u64) {
        match self {
            Party::Pause | Party::Abort | Party::Restart => p.flag.store(true, Ordering::Relaxed),
            Party::Request => {
                let _ = p.w.kept(p.o).abort();
            }
            Party::AbortAll => p.w.seq.abort_all(),
            Party::Due => {}
        }
        p.w.tick(ms);
        if self == Party::Restart {
            p.flag.store(false, Ordering::Relaxed);
        }
    }
}

/// O (a [`Probe`], polled every ms, started at 0 by a handle; in the second word with
/// `Layout::Second`) with the party's monitor (condition false for now); its lane has
/// polled once: with `gate` open the action is done and the first check made, else the
/// action waits at the gate.
fn probed<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    party: Party,
    wait: bool,
    gate: bool,
) -> P<L, N, B> {
    let w = World::<L, N, B>::new(layout);
    let (flag, gate, exit) = (flag_of(false), flag_of(gate), flag_of(false));
    let checks: &'static AtomicUsize = Box::leak(Box::new(AtomicUsize::new(0)));
    let probe = Probe {
        gate,
        exit,
        checks,
        wait,
    };
    let seq: &'static mut Seq<Probe> =
        Box::leak(Box::new(w.seq.add(SeqConfig::new("O"), probe).unwrap()));
    let o = seq.id();
    w.handle(o).declare_lane().unwrap();
    if layout == Layout::Second {
        assert!(o.index() >= 32);
    }
    let b = match party {
        Party::Pause => Some(Behaviour::PauseOwner),
        Party::Abort => Some(Behaviour::AbortOwner),
        Party::Restart => Some(Behaviour::RestartOwner),
        _ => None,
    };
    if let Some(b) = b {
        w.monitor(o, flag, b, None);
    }
    let (waker, wakes) = counting();
    let fut: Pin<Box<dyn Future<Output = Infallible>>> = Box::pin(lane(w.seq, &(), seq));
    let lane: &'static HandLane = Box::leak(Box::new(HandLane {
        fut: RefCell::new(fut),
        waker,
        wakes,
        seen: Cell::new(0),
    }));
    w.handle(o).start().unwrap();
    lane.settle();
    lane.poll();
    assert_eq!(w.state(o), Running);
    P {
        w,
        o,
        lane,
        flag,
        gate,
        exit,
        checks,
    }
}

// =======================================================================================
// 1. The tick before each section of the lane's poll that ends the action: the check
//    right after the action.
// =======================================================================================

/// O's action is done at its gate's opening; its lane's poll (`clearance`,
/// `set_poll_wait`, the check right after the action; with `wait` the wait's
/// `set_poll_wait`, `clearance`, check) has the tick at 1 ms (O's first due poll, doing
/// `party`) before each section, or after it. The check right after the action runs only
/// if no tick that stopped, paused or restarted O came before it (semantics 1 and 4): a
/// stop leaves no check; a restart one, after the action ran again; a pause none until
/// the release. A due tick wakes the lane exactly when O waited for the poll then, and that
/// poll is checked once.
fn tick_into_the_end_of_the_action<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    party: Party,
    wait: bool,
) {
    let setup = move || {
        let p = probed::<L, N, B>(layout, party, wait, false);
        p.gate.store(true, Ordering::Relaxed);
        p
    };
    let count = sections(setup, |p| p.lane.poll());
    every_k(count + 1, |k| {
        let p = setup();
        let what = name::<L>(layout, format_args!("{party:?}, wait {wait}, k={k}"));
        // Checks made before the tick, and whether O waited for a poll then.
        let at_tick: Rc<Cell<Option<(usize, bool)>>> = Rc::new(Cell::new(None));
        let into = at_tick.clone();
        let wakes0 = p.lane.wakes();
        interleaved::at(k, move || {
            into.set(Some((p.checks(), p.w.in_set(Set::PollWait, p.o))));
            party.act(p, 1);
        });
        p.lane.poll();
        let after = or_after(k, || {
            at_tick.set(Some((p.checks(), p.w.in_set(Set::PollWait, p.o))));
            party.act(p, 1);
        });
        let (before, waiting) = at_tick.get().unwrap();
        let woken_by_tick = p.lane.wakes() - wakes0;
        p.lane.settle();
        let n = p.checks();
        match party {
            Party::Due => {
                assert_eq!(p.w.state(p.o), Running, "{what}");
                assert_eq!(woken_by_tick, usize::from(waiting), "{what}: wake-ups");
                assert_eq!(n, 1 + usize::from(waiting), "{what}: checks");
            }
            Party::Pause => {
                assert_eq!(p.w.state(p.o), Paused, "{what}");
                assert!(
                    woken_by_tick <= 1,
                    "{what}: the pause woke the lane {woken_by_tick} times"
                );
                assert_eq!(n, before, "{what}: checked while paused");
                // The release at 2 ms: the poll at 2 fell due while held (skipped); the
                // check right after the action, if not made, is made now (with `wait`, a
                // wait held before its first check waits for the next due poll).
                p.flag.store(false, Ordering::Relaxed);
                p.w.tick(2);
                p.lane.settle();
                assert_eq!(p.w.state(p.o), Running, "{what}");
                let at_release = p.checks() - n;
                if wait {
                    assert!(at_release <= 1 - n.min(1), "{what}: at the release");
                } else {
                    assert_eq!(at_release, 1 - n.min(1), "{what}: at the release");
                }
                for ms in 3..6 {
                    let c = p.checks();
                    p.w.tick(ms);
                    p.lane.settle();
                    assert_eq!(p.checks(), c + 1, "{what}: the poll at {ms} ms");
                }
            }
            Party::Restart => {
                assert_eq!(p.w.ended(p.o), (Running, M0), "{what}");
                // Before the tick, or after the restart.
                assert_eq!(n, before + 1, "{what}: checks");
                assert!(!after || before == 1, "{what}");
            }
            _ => {
                assert_eq!(p.w.ended(p.o), (Aborted, party.cause()), "{what}");
                assert_eq!(n, before, "{what}: checked after the abort");
            }
        }
        let _ = after;
        p.w.check(&what);
    });
}

/// A due tick before or after the end of the action.
#[test]
fn the_check_right_after_the_action_and_a_due_tick() {
    every_world!(tick_into_the_end_of_the_action, Party::Due, false);
}

/// The tick pauses (aborts, restarts, carries out an abort request or an abort-all) O
/// before each section of the lane's poll in which O's action ends: the exit condition is
/// checked right after the action only with the clearance to go on (semantics 1), never
/// while paused or after the abort. Before its fix, a tick between `ActionDone`'s
/// clearance and its `set_poll_wait` (two sections, under both locks) let the check run.
#[test]
fn the_check_right_after_the_action_comes_only_with_the_clearance_pause() {
    every_world!(tick_into_the_end_of_the_action, Party::Pause, false);
}

/// As [`the_check_right_after_the_action_comes_only_with_the_clearance_pause`].
#[test]
fn the_check_right_after_the_action_comes_only_with_the_clearance_abort() {
    every_world!(tick_into_the_end_of_the_action, Party::Abort, false);
}

/// As [`the_check_right_after_the_action_comes_only_with_the_clearance_pause`].
#[test]
fn the_check_right_after_the_action_comes_only_with_the_clearance_restart() {
    every_world!(tick_into_the_end_of_the_action, Party::Restart, false);
}

/// As [`the_check_right_after_the_action_comes_only_with_the_clearance_pause`].
#[test]
fn the_check_right_after_the_action_comes_only_with_the_clearance_request() {
    every_world!(tick_into_the_end_of_the_action, Party::Request, false);
}

/// As [`the_check_right_after_the_action_comes_only_with_the_clearance_pause`].
#[test]
fn the_check_right_after_the_action_comes_only_with_the_clearance_abort_all() {
    every_world!(tick_into_the_end_of_the_action, Party::AbortAll, false);
}

#[test]
fn the_first_check_of_a_wait_until_comes_only_with_the_clearance() {
    for party in PARTIES {
        every_world!(tick_into_the_end_of_the_action, party, true);
    }
}

// =======================================================================================
// 2. The tick before each section of the lane's due poll.
// =======================================================================================

/// O waits for its condition (checked once right after the action); the tick at 1 ms marked
/// its due poll and woke the lane. The lane's poll (`due_poll`, the check) has the tick at
/// 2 ms (`party`) before each section, or after it. Each due poll is checked once at most:
/// a tick before the lane took the mark adds none (the lane checks once for both, as a late
/// tick skips a poll); after it, the tick's own poll is checked (a due tick wakes the lane
/// once). A stop, pause or restart before the check leaves no check of the old run (a
/// restart: one right after the action ran again); a pause drops the mark, and the poll
/// at the release (3 ms) is skipped: the next check is at 4 ms.
fn tick_into_a_due_poll<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    party: Party,
    wait: bool,
) {
    let setup = move || {
        let p = probed::<L, N, B>(layout, party, wait, true);
        assert_eq!(p.checks(), 1);
        let w0 = p.lane.wakes();
        p.w.tick(1);
        assert_eq!(p.lane.wakes(), w0 + 1, "the due poll woke the lane");
        p
    };
    let count = sections(setup, |p| p.lane.poll());
    every_k(count + 1, |k| {
        let p = setup();
        let what = name::<L>(layout, format_args!("{party:?}, wait {wait}, k={k}"));
        let at_tick: Rc<Cell<Option<usize>>> = Rc::new(Cell::new(None));
        let into = at_tick.clone();
        let wakes0 = p.lane.wakes();
        interleaved::at(k, move || {
            into.set(Some(p.checks()));
            party.act(p, 2);
        });
        p.lane.poll();
        or_after(k, || {
            at_tick.set(Some(p.checks()));
            party.act(p, 2);
        });
        let before = at_tick.get().unwrap();
        let woken_by_tick = p.lane.wakes() - wakes0;
        p.lane.settle();
        let n = p.checks();
        // Whether the lane took the mark of 1 ms before the tick.
        let took = before == 2;
        match party {
            Party::Due => {
                assert_eq!(woken_by_tick, 1, "{what}: wake-ups");
                assert_eq!(n, 2 + usize::from(took), "{what}: checks");
                // Steady: one check per due poll from now on.
                for ms in 3..6 {
                    let c = p.checks();
                    p.w.tick(ms);
                    p.lane.settle();
                    assert_eq!(p.checks(), c + 1, "{what}: the poll at {ms} ms");
                }
            }
            Party::Pause => {
                assert_eq!(p.w.state(p.o), Paused, "{what}");
                assert!(
                    woken_by_tick <= 1,
                    "{what}: the pause woke the lane {woken_by_tick} times"
                );
                assert_eq!(n, before, "{what}: checked while paused");
                p.flag.store(false, Ordering::Relaxed);
                p.w.tick(3);
                p.lane.settle();
                assert_eq!(p.w.state(p.o), Running, "{what}");
                assert_eq!(p.checks(), n, "{what}: the poll at the release is skipped");
                for ms in 4..7 {
                    let c = p.checks();
                    p.w.tick(ms);
                    p.lane.settle();
                    assert_eq!(p.checks(), c + 1, "{what}: the poll at {ms} ms");
                }
            }
            Party::Restart => {
                assert_eq!(p.w.ended(p.o), (Running, M0), "{what}");
                assert_eq!(n, before + 1, "{what}: checks");
            }
            _ => {
                assert_eq!(p.w.ended(p.o), (Aborted, party.cause()), "{what}");
                assert_eq!(n, before, "{what}: checked after the abort");
            }
        }
        p.w.check(&what);
    });
}

#[test]
fn a_due_poll_is_checked_once_and_never_after_a_stop_or_pause() {
    for party in PARTIES {
        every_world!(tick_into_a_due_poll, party, false);
    }
}

#[test]
fn a_due_poll_of_a_wait_until_is_checked_once_and_never_after_a_stop_or_pause() {
    for party in PARTIES {
        every_world!(tick_into_a_due_poll, party, true);
    }
}

// =======================================================================================
// 3. The lane's poll before each section of the tick (portable lock).
// =======================================================================================

/// O waits for its due poll (its condition checked twice: after the action, at 1 ms). The
/// lane, of higher priority than the tick, polls before each section of the tick at 2 ms
/// (`party`), or after it; with `ends` O's condition holds from 2 ms. The poll at 2 ms is
/// checked exactly once for a due tick (the lane takes the mark, or is woken for it),
/// once at most otherwise, and never once O is paused, stopped or restarting (semantics
/// 1); with `ends` O completes once (nothing fires for the ended run) or is stopped.
fn lane_into_the_tick<const N: usize, const B: usize>(
    layout: Layout,
    party: Party,
    wait: bool,
    ends: bool,
) {
    type L = Interleaved;
    let setup = move || {
        let p = probed::<L, N, B>(layout, party, wait, true);
        p.w.tick(1);
        p.lane.settle();
        assert_eq!(p.checks(), 2);
        p
    };
    let count = sections(setup, |p| party.act(*p, 2));
    every_k(count + 1, |k| {
        let p = setup();
        if ends {
            p.exit.store(true, Ordering::Relaxed);
        }
        let what = name::<L>(
            layout,
            format_args!("{party:?}, wait {wait}, ends {ends}, k={k}"),
        );
        // O's state and mark when the lane polled, and the checks it made.
        let seen: Rc<Cell<Option<(RunningState, bool, usize)>>> = Rc::new(Cell::new(None));
        let into = seen.clone();
        let lane_poll = move || {
            let due = p.w.in_set(Set::PollDue, p.o) && !p.w.in_set(Set::Excepting, p.o);
            let state = p.w.state(p.o);
            let c = p.checks();
            p.lane.poll();
            into.set(Some((state, due, p.checks() - c)));
        };
        interleaved::at(k, lane_poll.clone());
        party.act(p, 2);
        let after = or_after(k, lane_poll);
        let (state, due, made) = seen.get().unwrap();
        p.lane.settle();
        let n = p.checks() - 2;
        if state == Restarting {
            assert_eq!(
                made, 1,
                "{what}: the check right after the action ran again"
            );
        } else if state == Running && due {
            assert_eq!(made, 1, "{what}: the lane took the mark");
        } else {
            assert_eq!(made, 0, "{what}: checked without a mark, or held");
        }
        match party {
            Party::Due => {
                assert_eq!(n, 1, "{what}: the poll at 2 ms checked once");
                if ends {
                    assert_eq!(p.w.state(p.o), Terminated, "{what}");
                }
            }
            Party::Pause => {
                assert!(n <= 1, "{what}");
                assert_eq!(n, made, "{what}: checked while paused");
                if !(ends && n == 1) {
                    assert_eq!(p.w.state(p.o), Paused, "{what}");
                }
            }
            Party::Restart => {
                // The check right after the action ran again, and the lane's, if it came
                // before the restart.
                let again = state == Running && !(ends && made == 1);
                assert_eq!(n, made + usize::from(again), "{what}");
            }
            _ => {
                assert_eq!(n, made, "{what}: checked after the abort");
                if ends && made == 1 {
                    assert_eq!(p.w.state(p.o), Terminated, "{what}");
                    assert_eq!(p.w.fired_any(p.o), 0, "{what}");
                } else {
                    assert_eq!(p.w.ended(p.o), (Aborted, party.cause()), "{what}");
                }
            }
        }
        let _ = after;
        p.w.check(&what);
    });
}

#[test]
fn a_lane_polling_during_the_tick_checks_the_due_poll_once() {
    for party in PARTIES {
        for wait in [false, true] {
            for ends in [false, true] {
                lane_into_the_tick::<8, 1>(Layout::One, party, wait, ends);
                lane_into_the_tick::<64, 2>(Layout::Second, party, wait, ends);
            }
        }
    }
}

/// O's action waits at its gate; the lane, of higher priority than the tick, opens it and
/// polls (the end of the action: `clearance`, `set_poll_wait`, the first check) before each
/// section of the tick at 1 ms (`party`, O's first due poll). The first check is made only
/// while O may go on; a due tick that found O waiting wakes the lane and its poll is checked
/// once more; nothing else is checked.
fn action_end_into_the_tick<const N: usize, const B: usize>(
    layout: Layout,
    party: Party,
    wait: bool,
) {
    type L = Interleaved;
    let setup = move || probed::<L, N, B>(layout, party, wait, false);
    let count = sections(setup, |p| party.act(*p, 1));
    every_k(count + 1, |k| {
        let p = setup();
        let what = name::<L>(layout, format_args!("{party:?}, wait {wait}, k={k}"));
        let seen: Rc<Cell<Option<(RunningState, usize)>>> = Rc::new(Cell::new(None));
        let into = seen.clone();
        let lane_poll = move || {
            p.gate.store(true, Ordering::Relaxed);
            let state = p.w.state(p.o);
            p.lane.poll();
            into.set(Some((state, p.checks())));
        };
        interleaved::at(k, lane_poll.clone());
        party.act(p, 1);
        or_after(k, lane_poll);
        let (state, made) = seen.get().unwrap();
        p.lane.settle();
        let n = p.checks();
        if state == Restarting {
            assert_eq!(
                made, 1,
                "{what}: the check right after the action ran again"
            );
        } else if state != Running {
            assert_eq!(made, 0, "{what}: checked while {state:?}");
        }
        match party {
            Party::Due => assert!((1..=2).contains(&n), "{what}: {n} checks"),
            Party::Pause => assert_eq!(n, made, "{what}: checked while paused"),
            Party::Restart => assert_eq!(n, made + usize::from(state == Running), "{what}"),
            _ => assert_eq!(n, made, "{what}: checked after the abort"),
        }
        p.w.check(&what);
    });
}

#[test]
fn the_end_of_an_action_during_the_tick_is_checked_only_while_it_may_go_on() {
    for party in PARTIES {
        for wait in [false, true] {
            action_end_into_the_tick::<8, 1>(Layout::One, party, wait);
            action_end_into_the_tick::<64, 2>(Layout::Second, party, wait);
        }
    }
}

// =======================================================================================
// 4. Restarts driven by the lane against the tick.
// =======================================================================================

/// O (in the second word with `Layout::Second`) with a `RestartOwner` monitor on `fault`
/// (restart limit `limit`), restarted by it at 1 ms. Returns the world, O and its run.
fn restarted_once<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    fault: &'static AtomicBool,
    limit: u8,
) -> (World<L, N, B>, SeqId, RunId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(move |_: &(), _: Instant| {
            fault.load(Ordering::Relaxed)
        }));
    let m = Monitor::new("fault", condition, Behaviour::RestartOwner).restart_limit(limit);
    assert_eq!(
        Cause::Monitor(w.monitors.borrow_mut().add(o, m).unwrap()),
        M0
    );
    w.start_taken(o);
    w.tick(1);
    assert_eq!(w.ended(o), (Restarting, M0));
    (w, o, w.run(o))
}

/// O's lane restarts O (`Sequencer::restart`) while the tick at 2 ms comes before each
/// section (or after): the fault holds, so the monitor fires again at O's first poll after
/// each restart (the edge starts from "false"). The lane restarts O whenever it is
/// `Restarting`; the restart limit (2) is counted exactly (semantics 5): two restarts, the
/// third firing escalates to an abort (cause the monitor), whatever `k`.
fn restart_limit_against_the_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || restarted_once::<L, N, B>(layout, flag_of(true), 2);
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    every_k(count + 1, |k| {
        let (w, o, run) = setup();
        let what = name::<L>(layout, format_args!("k={k}"));
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        or_after(k, || w.tick(2));
        for ms in 3..12 {
            if w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
            if w.state(o) == Aborted {
                break;
            }
            w.tick(ms);
        }
        assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        assert_eq!(w.moves(o, Running, Restarting), 2, "{what}: restarts");
        assert_eq!(w.moves(o, Restarting, Running), 2, "{what}: runs again");
        assert_eq!(w.fired(o, M0), 3, "{what}: firings");
        #[cfg(feature = "counters")]
        assert_eq!(w.handle(o).counters().restarts, 2, "{what}");
        w.check(&what);
    });
}

#[test]
fn the_restart_limit_is_counted_exactly_whatever_the_tick_preempts() {
    every_world!(restart_limit_against_the_tick);
}

/// What preempts the lane's restart.
#[derive(Clone, Copy, Debug, PartialEq)]
enum AtRestart {
    /// A pause request of O (a handle).
    Pause,
    /// An abort request of O, then the tick at 2 ms.
    Abort,
    /// An abort-all, then the tick at 2 ms.
    AbortAll,
}

/// O's lane restarts O (the fault cleared after the restart at 1 ms) while `party` comes
/// before each section (or after). A pause request is refused while O is `Restarting`
/// (`NotRunning`) and O runs on; accepted once the restart committed, and the tick at 2 ms
/// pauses O. An abort (request or abort-all) stands whatever `k` (semantics 4: a restart
/// keeps the requests made of its run), in both words' layouts.
fn requests_against_the_restart<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    party: AtRestart,
) {
    let setup = move || {
        let fault = flag_of(true);
        let s = restarted_once::<L, N, B>(layout, fault, 3);
        fault.store(false, Ordering::Relaxed);
        s
    };
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    every_k(count + 1, |k| {
        let (w, o, run) = setup();
        let what = name::<L>(layout, format_args!("{party:?}, k={k}"));
        let asked: Rc<Cell<Option<Result<(), Error>>>> = Rc::new(Cell::new(None));
        let into = asked.clone();
        let act = move || match party {
            AtRestart::Pause => into.set(Some(w.kept(o).pause())),
            AtRestart::Abort => {
                into.set(Some(w.kept(o).abort()));
                w.tick(2);
            }
            AtRestart::AbortAll => {
                w.seq.abort_all();
                into.set(Some(Ok(())));
                w.tick(2);
            }
        };
        interleaved::at(k, act.clone());
        w.seq.restart(run);
        or_after(k, act);
        let asked = asked.get().unwrap();
        match party {
            AtRestart::Pause => {
                w.tick(2);
                match asked {
                    Ok(()) => assert_eq!(w.state(o), Paused, "{what}"),
                    Err(e) => {
                        assert_eq!(e, Error::NotRunning(o), "{what}");
                        assert_eq!(w.state(o), Running, "{what}");
                    }
                }
            }
            AtRestart::Abort | AtRestart::AbortAll => {
                assert_eq!(asked, Ok(()), "{what}");
                let cause = if party == AtRestart::Abort {
                    Cause::Abort
                } else {
                    Cause::AbortAll
                };
                w.tick(3);
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}");
            }
        }
        w.tick(4);
        w.check(&what);
    });
}

#[test]
fn requests_against_a_restart_by_the_lane() {
    for party in [AtRestart::Pause, AtRestart::Abort, AtRestart::AbortAll] {
        every_world!(requests_against_the_restart, party);
    }
}

// =======================================================================================
// 5. `PauseOwner` monitors against a child's end.
// =======================================================================================

/// O runs C blocking (both in the second word with `Layout::Second`); O has
/// a `PauseOwner` monitor on the returned flag; with `held`, the tick at 1 ms paused O and
/// C and the flag is clear again. Returns the world, O, C and the flag.
fn paused_owner_and_child<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    held: bool,
) -> (World<L, N, B>, SeqId, SeqId, &'static AtomicBool) {
    let w = World::<L, N, B>::new(layout);
    let [o, c] = ["O", "C"].map(|n| w.seq(n));
    let on = flag_of(held);
    w.monitor(o, on, Behaviour::PauseOwner, None);
    w.start_taken(o);
    w.blocking(c, o).unwrap();
    if held {
        w.tick(1);
        assert_eq!((w.state(o), w.state(c)), (Paused, Paused));
        on.store(false, Ordering::Relaxed);
    }
    (w, o, c, on)
}

/// C's lane ends C (completed; `end` and `finished`) while the tick at `ms` holds O
/// (`held` false: the flag rises) or releases it (`held`: O and C were paused at 1 ms),
/// before each section or after. The end is made only while C may go on: C ends
/// `Terminated` once (now, or once released, the lane trying again), never while paused;
/// O is paused with C, or resumes with it; nothing else moves.
fn child_end_against_pause_owner<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    held: bool,
) {
    let setup = move || paused_owner_and_child::<L, N, B>(layout, held);
    let ms = if held { 2 } else { 1 };
    let count = sections_at_least(1, setup, |(w, _, c, _)| {
        w.complete(*c);
    });
    every_k(count + 1, |k| {
        let (w, o, c, on) = setup();
        let what = name::<L>(layout, format_args!("held {held}, k={k}"));
        let tick = move || {
            if !held {
                on.store(true, Ordering::Relaxed);
            }
            w.tick(ms);
        };
        interleaved::at(k, tick);
        let ended = w.complete(c);
        or_after(k, tick);
        if held {
            // Released at 2 ms: both run; a refused end is tried again and made.
            assert_eq!(w.state(o), Running, "{what}");
            if !ended {
                assert_eq!(w.state(c), Running, "{what}");
                assert!(w.complete(c), "{what}: once released");
            }
        } else {
            assert_eq!(w.state(o), Paused, "{what}");
            if !ended {
                assert_eq!(w.state(c), Paused, "{what}: paused with O");
                on.store(false, Ordering::Relaxed);
                w.tick(ms + 1);
                assert_eq!((w.state(o), w.state(c)), (Running, Running), "{what}");
                assert!(w.complete(c), "{what}: once released");
            }
        }
        assert_eq!(w.state(c), Terminated, "{what}");
        assert_eq!(w.moves(c, Running, Terminated), 1, "{what}");
        assert_eq!(w.moves(c, Paused, Terminated), 0, "{what}");
        w.tick(5);
        w.check(&what);
    });
}

#[test]
fn a_child_ends_only_while_the_pause_owner_monitor_lets_it() {
    for held in [false, true] {
        every_world!(child_end_against_pause_owner, held);
    }
}

// =======================================================================================
// 5. Lanes joined in one task: the lanes remembered for the tick's wake-ups.
// =======================================================================================

/// A lane future of a [`Probe`] that starts out joined with others in one task (their
/// shared waker) and may move to a task of its own (another waker).
struct TaskLane {
    fut: RefCell<Pin<Box<dyn Future<Output = Infallible>>>>,
    checks: &'static AtomicUsize,
}

impl TaskLane {
    fn poll(&self, waker: &Waker) {
        let mut cx = Context::from_waker(waker);
        let _ = self.fut.borrow_mut().as_mut().poll(&mut cx);
    }

    fn checks(&self) -> usize {
        self.checks.load(Ordering::Relaxed)
    }
}

/// A started [`Probe`] (gate open, exit condition false, polled every ms) with its lane,
/// not polled yet.
fn task_lane<L: Lock + 'static, const N: usize, const B: usize>(
    w: World<L, N, B>,
    name: &'static str,
) -> (SeqId, &'static TaskLane) {
    let checks: &'static AtomicUsize = Box::leak(Box::new(AtomicUsize::new(0)));
    let probe = Probe {
        gate: flag_of(true),
        exit: flag_of(false),
        checks,
        wait: false,
    };
    let seq: &'static mut Seq<Probe> =
        Box::leak(Box::new(w.seq.add(SeqConfig::new(name), probe).unwrap()));
    let id = seq.id();
    w.handle(id).declare_lane().unwrap();
    let fut: Pin<Box<dyn Future<Output = Infallible>>> = Box::pin(lane(w.seq, &(), seq));
    w.handle(id).start().unwrap();
    (
        id,
        Box::leak(Box::new(TaskLane {
            fut: RefCell::new(fut),
            checks,
        })),
    )
}

/// With the portable lock the tick remembers the lanes it woke for a set of due polls, and
/// wakes one task once: lanes A and B, joined in one task, are woken through A's slot
/// alone. B moves to a task of its own (its next poll comes with another waker) before
/// each section of the first due tick (1 ms), or after it. The tick at 1 ms wakes the
/// joined task once; the tick at 2 ms wakes both tasks once, whatever it remembered: both
/// conditions are checked at 1 ms and at 2 ms. Before
/// the tick remembered only what no waker changed during its look, a move during the look
/// left B's task asleep from 2 ms on.
fn a_lane_moved_to_its_own_task<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<Interleaved, N, B>::new(layout);
        let (a, lane_a) = task_lane(w, "A");
        let (b, lane_b) = task_lane(w, "B");
        let (joined, joined_wakes) = counting();
        let (own, own_wakes) = counting();
        // The action, then the check right after it.
        lane_a.poll(&joined);
        lane_b.poll(&joined);
        assert_eq!((w.state(a), w.state(b)), (Running, Running));
        assert_eq!((lane_a.checks(), lane_b.checks()), (1, 1));
        (
            w,
            [lane_a, lane_b],
            [joined, own],
            [joined_wakes, own_wakes],
        )
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, [lane_a, lane_b], [joined, own], [joined_wakes, own_wakes]) = setup();
        let what = name::<Interleaved>(layout, format_args!("k={k}"));
        // Each task polls its lanes when woken since its last poll.
        let seen = Cell::new([0, 0]);
        let moved = Rc::new(Cell::new(false));
        let run_tasks = || {
            let [j, o] = [woken(&joined_wakes), woken(&own_wakes)];
            let [sj, so] = seen.get();
            seen.set([j, o]);
            if j > sj {
                lane_a.poll(&joined);
                if !moved.get() {
                    lane_b.poll(&joined);
                }
            }
            if o > so {
                lane_b.poll(&own);
            }
        };
        let into = moved.clone();
        let own_b = own.clone();
        let move_b = move || {
            into.set(true);
            lane_b.poll(&own_b);
        };
        let wakes = || [woken(&joined_wakes), woken(&own_wakes)];
        interleaved::at(k, move_b.clone());
        w.tick(1);
        // One wake-up per task woken: a task polls all its lanes.
        let [j, o] = wakes();
        assert!(j == 1 && o <= 1, "{what}: woken {j} and {o} times at 1 ms");
        or_after(k, move_b);
        run_tasks();
        assert_eq!(
            (lane_a.checks(), lane_b.checks()),
            (2, 2),
            "{what}: the polls at 1 ms"
        );
        w.tick(2);
        assert_eq!(wakes(), [j + 1, o + 1], "{what}: both tasks woken at 2 ms");
        run_tasks();
        assert_eq!(
            (lane_a.checks(), lane_b.checks()),
            (3, 3),
            "{what}: the polls at 2 ms"
        );
        w.check(&what);
    });
}

#[test]
fn a_lane_that_moves_to_its_own_task_during_the_tick_is_woken_by_the_next() {
    a_lane_moved_to_its_own_task::<8, 1>(Layout::One);
    a_lane_moved_to_its_own_task::<64, 2>(Layout::Second);
}

/// Lanes joined in one task share a waker: each tick with both their polls due wakes the
/// task once, under either lock (the portable lock's walk in short sections and the coarse
/// lock's one section each skip the waker just found).
fn joined_lanes<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let w = World::<L, N, B>::new(layout);
    let (_, lane_a) = task_lane(w, "A");
    let (_, lane_b) = task_lane(w, "B");
    let (joined, wakes) = counting();
    let poll_task = || {
        lane_a.poll(&joined);
        lane_b.poll(&joined);
    };
    poll_task();
    for ms in 1..=3 {
        w.tick(ms);
        assert_eq!(
            woken(&wakes),
            ms as usize,
            "{layout:?}: woken once at {ms} ms"
        );
        poll_task();
        let checks = ms as usize + 1;
        assert_eq!((lane_a.checks(), lane_b.checks()), (checks, checks));
    }
    w.check(&format!("{layout:?}"));
}

#[test]
fn lanes_joined_in_one_task_are_woken_once_per_tick() {
    every_world!(joined_lanes);
}
