//! A teardown's target and what begins after it moved, under both locks, in sequencers of
//! one word and of two: a party above the tick before each section of a tick that tears
//! the target down.
//!
//! A teardown moves its target once, last: what begins after the target moved is not the
//! torn-down run's (a restarted target's new round, a new run started by a supervisor)
//! and is left alone. And a monitor fires only on the run its evaluation saw: a round begun
//! during the tick is evaluated from the next tick. All three were found by the random
//! preemption test (`random.rs`): a lane that took up its restart and started a child
//! during the walk had its target restarted again, up to `2 N` times in one tick; a new
//! run started during an abort's walk was aborted too; a `PauseOwner` monitor held a
//! round begun in its tick twice, and one release left it paused for good. A fourth, found
//! by the last test here: a new run of a sequence below the target, begun by a caller
//! outside the tree after the teardown had looked at its old run, was aborted too. The
//! next one checks the same of the target: a firing aborts only the run it was raised on.
//! Another (found by the random test's liveness check): a start that looked at its
//! polling class before a member started there keeps that member's grid. The last one
//! (found by the random test's settled-world check): a restart taken up while the tick
//! paused its caller is paused with it. And (found by a cold review in session 52): the
//! end of an exception sequence that a restart of its owner took down leaves the
//! restarted round alone, though its lane ran the restart between the tick's sections.

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// O (its `RestartOwner` monitor M0 holds) runs C blocking; D is registered (C and D in
/// the second word with `Layout::Split`). Returns the world, O, C and D.
fn restart_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    w.split();
    let [c, d] = ["C", "D"].map(|n| w.seq(n));
    w.monitor(o, flag_of(true), Behaviour::RestartOwner, None);
    w.start_taken(o);
    w.blocking(c, o).unwrap();
    (w, o, c, d)
}

/// The tick at 1 ms restarts O (and aborts C); O's lane, above the tick, before each
/// section of that tick (or after it): once O is `Restarting`, it takes the restart up
/// (`Sequencer::restart`) and O's new round starts D blocking. O is restarted once, C
/// aborted once, and D, begun by the new round, runs on below O.
fn restart_taken_up_during_its_walk<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let count = sections(|| restart_setup::<L, N, B>(layout), |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, c, d) = restart_setup::<L, N, B>(layout);
        let run = w.run(o);
        let lane = move || {
            if w.state(o) == Restarting {
                w.seq.restart(run);
                w.blocking(d, o).unwrap();
            }
        };
        interleaved::at(k, lane);
        w.tick(1);
        // Before the restart was made the lane found nothing to do: it runs again now.
        interleaved::at(usize::MAX, || {});
        lane();
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(
            w.moves(o, Running, Restarting),
            1,
            "{what}: O restarted once"
        );
        assert_eq!(w.moves(o, Restarting, Running), 1, "{what}");
        assert_eq!(w.ended(c), (Aborted, M0), "{what}: C");
        assert_eq!(w.moves(c, Aborting, Aborted), 1, "{what}");
        assert_eq!([w.state(o), w.state(d)], [Running, Running], "{what}");
        assert_eq!(w.caller(d), Some(o), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_restart_taken_up_by_a_lane_above_the_tick_during_its_walk_restarts_once() {
    every_world!(restart_taken_up_during_its_walk);
}

/// T runs, its `AbortOwner` monitor M0 holds; C is registered (in the second word with
/// `Layout::Split`). Returns the world, T and C.
fn monitored_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let t = w.seq("T");
    w.split();
    let c = w.seq("C");
    w.monitor(t, flag_of(true), Behaviour::AbortOwner, None);
    w.start_taken(t);
    (w, t, c)
}

/// As [`monitored_setup`], and T runs C blocking.
fn abort_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId) {
    let (w, t, c) = monitored_setup::<L, N, B>(layout);
    w.blocking(c, t).unwrap();
    (w, t, c)
}

/// The tick at 1 ms aborts T (and C); a supervisor above the tick, before each section of
/// that tick (or after it): once T is `Aborted`, it starts T again. The new run is left
/// alone: `Running`, its start pending for T's lane; T and C aborted once.
fn new_run_during_its_abort<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let count = sections(|| abort_setup::<L, N, B>(layout), |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, t, c) = abort_setup::<L, N, B>(layout);
        let supervisor = move || {
            if w.state(t) == Aborted {
                w.kept(t).start().unwrap();
            }
        };
        interleaved::at(k, supervisor);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        if w.state(t) == Aborted {
            supervisor();
        }
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(w.moves(t, Running, Aborting), 1, "{what}: T aborted once");
        assert_eq!(w.moves(c, Aborting, Aborted), 1, "{what}: C aborted once");
        assert_eq!(w.ended(c), (Aborted, M0), "{what}");
        assert_eq!(w.state(t), Running, "{what}: T's new run");
        assert!(w.pending(t), "{what}: for T's lane");
        assert_eq!(w.runs(t), 2, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_run_started_by_a_supervisor_above_the_tick_during_an_abort_is_left_alone() {
    every_world!(new_run_during_its_abort);
}

/// O with a `RestartOwner` monitor M0 (condition `restart`) and a `PauseOwner` monitor M1
/// (condition `pause`), both true, started; returns the world, O and both flags.
fn restart_then_hold_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (
    World<L, N, B>,
    SeqId,
    &'static AtomicBool,
    &'static AtomicBool,
) {
    let w = World::<L, N, B>::new(layout);
    w.split();
    let o = w.seq("O");
    let (restart, pause) = (flag_of(true), flag_of(true));
    w.monitor(o, restart, Behaviour::RestartOwner, None);
    w.monitor(o, pause, Behaviour::PauseOwner, None);
    w.start_taken(o);
    (w, o, restart, pause)
}

/// The tick at 1 ms fires M0 (O restarted) and then M1; O's lane, above the tick, takes
/// the restart up before each section of that tick (or after it). M1's evaluation saw the
/// old round: it holds O's new round only from the next tick, once, so O runs again when
/// M1's condition clears. (Found by `random.rs`: M1 held the new round in the tick that
/// restarted it and again in the next, which evaluates a new round from "false"; the one
/// release left O paused for good.)
fn hold_of_a_round_begun_in_the_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || restart_then_hold_setup::<L, N, B>(layout);
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, restart, pause) = setup();
        let run = w.run(o);
        let lane = move || {
            if w.state(o) == Restarting {
                w.seq.restart(run);
            }
        };
        interleaved::at(k, lane);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        lane();
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(w.moves(o, Running, Restarting), 1, "{what}");
        restart.store(false, Ordering::Relaxed);
        w.tick(2);
        assert_eq!(w.state(o), Paused, "{what}: held by M1 at 2 ms");
        pause.store(false, Ordering::Relaxed);
        w.tick(3);
        assert_eq!(w.state(o), Running, "{what}: let go at 3 ms");
        let holds = w.seq.with(|s| s.block(o).unwrap().monitor_holds);
        assert_eq!(holds, 0, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_pause_owner_monitor_holds_a_round_begun_in_its_tick_once() {
    every_world!(hold_of_a_round_begun_in_the_tick);
}

/// A party above the tick that begins a run of an unrelated sequence U before every
/// section of the tick (U's lane takes the start and ends the run, then U is started
/// again), while the tick at 1 ms aborts T and its blocking child C: every pass of the
/// teardown is disturbed. The walk still ends, with T and C aborted once.
fn teardown_disturbed_every_time<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let (w, t, c) = abort_setup::<L, N, B>(layout);
    let u = w.seq("U");
    fn again<L: Lock + 'static, const N: usize, const B: usize>(
        w: World<L, N, B>,
        u: SeqId,
        begun: &'static AtomicUsize,
    ) {
        if w.state(u) == Running {
            w.take(u);
            assert!(w.complete(u));
        }
        w.kept(u).start().unwrap();
        begun.fetch_add(1, Ordering::Relaxed);
        // Drained before the trace ring fills.
        w.records();
        interleaved::at(0, move || again(w, u, begun));
    }
    let begun: &'static AtomicUsize = Box::leak(Box::new(AtomicUsize::new(0)));
    interleaved::at(0, move || again(w, u, begun));
    w.tick(1);
    interleaved::at(usize::MAX, || {});
    let what = name::<L>(layout, format_args!(""));
    assert!(
        begun.load(Ordering::Relaxed) > 2 * N,
        "{what}: every pass disturbed"
    );
    assert_eq!(w.ended(t), (Aborted, M0), "{what}");
    assert_eq!(w.ended(c), (Aborted, M0), "{what}");
    assert_eq!(w.moves(t, Running, Aborting), 1, "{what}");
    assert_eq!(w.moves(c, Running, Aborting), 1, "{what}");
    w.check(&what);
}

#[test]
fn a_teardown_disturbed_in_every_pass_still_moves_its_target() {
    every_world!(teardown_disturbed_every_time);
}

/// As [`abort_setup`], but T has started C in C's own lane (non-blocking).
fn non_blocking_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId) {
    let (w, t, c) = monitored_setup::<L, N, B>(layout);
    w.in_lane(c, t).unwrap();
    w.take(c);
    (w, t, c)
}

/// The tick at 1 ms aborts T and C, which T started; before each section of that tick (or
/// after it), once: C's lane, above the tick, ends C's run, and a supervisor starts C
/// again, with no caller. That new run is not below T: it is left alone, `Running`,
/// whether the walk had not placed C yet or had looked at C's old run and was about to
/// move it. T is aborted once.
fn new_run_of_a_placed_child<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let count = sections(
        || non_blocking_setup::<L, N, B>(layout),
        |(w, ..)| w.tick(1),
    );
    every_k(count + 1, |k| {
        let (w, t, c) = non_blocking_setup::<L, N, B>(layout);
        let restarted: &'static AtomicBool = flag_of(false);
        let party = move || {
            if w.state(c) == Running && w.runs(c) == 1 {
                assert!(w.complete(c));
                w.kept(c).start().unwrap();
                restarted.store(true, Ordering::Relaxed);
            }
        };
        interleaved::at(k, party);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(w.ended(t), (Aborted, M0), "{what}: T");
        assert_eq!(w.moves(t, Running, Aborting), 1, "{what}");
        if restarted.load(Ordering::Relaxed) {
            assert_eq!(w.state(c), Running, "{what}: C's new run");
            assert_eq!(w.caller(c), None, "{what}");
            assert_eq!(w.runs(c), 2, "{what}");
        } else {
            assert_eq!(w.ended(c), (Aborted, M0), "{what}: C");
        }
        w.check(&what);
    });
}

#[test]
fn a_new_run_of_a_child_the_walk_had_looked_at_is_left_alone() {
    every_world!(new_run_of_a_placed_child);
}

/// The tick at 1 ms aborts T (its monitor M0 holds); before each section of that tick (or
/// after it), once: T's lane, above the tick, ends T's run, and a supervisor starts T
/// again. A firing aborts only the run it was raised on: the second run is aborted only by
/// a firing recorded after it began (begun before the tick's scan, M0 evaluates it from
/// "false" and fires on it), else it is left alone in this tick.
fn new_run_of_the_target<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let count = sections(|| monitored_setup::<L, N, B>(layout), |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, t, _) = monitored_setup::<L, N, B>(layout);
        let restarted: &'static AtomicBool = flag_of(false);
        let party = move || {
            // Once the tick has marked the exception, the run's end loses to its abort.
            if w.state(t) == Running && w.runs(t) == 1 && w.complete(t) {
                w.kept(t).start().unwrap();
                restarted.store(true, Ordering::Relaxed);
            }
        };
        interleaved::at(k, party);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        let what = name::<L>(layout, format_args!("k={k}"));
        if restarted.load(Ordering::Relaxed) {
            assert_eq!(w.runs(t), 2, "{what}");
            let records = w.records();
            let began = records.iter().rposition(|r| {
                r.transition()
                    .is_some_and(|tr| tr.sequence == t && tr.to == Running)
            });
            let fired = records
                .iter()
                .rposition(|r| matches!(r.event(), Some(Event::Fired { owner, .. }) if owner == t));
            if w.state(t) != Running {
                assert_eq!(w.ended(t), (Aborted, M0), "{what}: T's new run");
                assert!(
                    fired > began,
                    "{what}: T's new run aborted by a firing before it began"
                );
            }
        } else {
            assert_eq!(w.ended(t), (Aborted, M0), "{what}: T");
        }
        w.check(&what);
    });
}

#[test]
fn a_new_run_of_the_target_begun_before_it_moved_is_left_alone() {
    every_world!(new_run_of_the_target);
}

/// A and B share a polling class of 2 ms; A has an `AbortOwner` monitor whose condition
/// holds (it fires at A's first poll). The application starts B at 0 ms; before each
/// section of that start (or after it) a party of higher priority starts A (taken) and
/// the tick at 1 ms runs. A was started at 0 into an idle class, so its first poll is at
/// 2 ms, and B's start, whatever it found, must not move that grid: A is aborted by its
/// monitor at the tick at 2 ms. Found by the random preemption test's liveness check: a
/// start that found the class idle, preempted before it scheduled its first poll, started
/// the grid again from its later time, and A's first poll came a period late.
fn start_with_a_stale_class_look<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let every_2_ms = |name| SeqConfig::new(name).polling(Duration::from_millis(2));
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        w.split();
        let (a, b) = (w.add(every_2_ms("A")), w.add(every_2_ms("B")));
        let cause = w.monitor(a, flag_of(true), Behaviour::AbortOwner, None);
        (w, a, b, cause)
    };
    let count = sections(setup, |(w, _, b, _)| {
        w.handle(*b).start().unwrap();
    });
    every_k(count + 1, |k| {
        let (w, a, b, cause) = setup();
        let what = name::<L>(layout, format_args!("k={k}"));
        let party = move || {
            w.start_taken(a);
            w.tick(1);
        };
        interleaved::at(k, party);
        assert_eq!(w.handle(b).start(), Ok(()), "{what}");
        or_after(k, party);
        assert_eq!(w.state(a), Running, "{what}");
        w.tick(2);
        assert_eq!(
            w.ended(a),
            (Aborted, cause),
            "{what}: A's first poll at 2 ms"
        );
        w.check(&what);
    });
}

#[test]
fn a_start_that_looked_at_its_class_before_a_member_started_keeps_the_members_grid() {
    every_world!(start_with_a_stale_class_look);
}

/// M runs A blocking (A in the second word with `Layout::Split`); A's `RestartOwner`
/// monitor M0 fired at 1 ms, so A is `Restarting`, its lane has not taken the restart up,
/// and a pause of M is requested. Returns the world, M and A.
fn restart_under_a_pause_setup<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let m = w.seq("M");
    w.split();
    let a = w.seq("A");
    let fault = flag_of(true);
    w.monitor(a, fault, Behaviour::RestartOwner, None);
    w.start_taken(m);
    w.blocking(a, m).unwrap();
    w.tick(1);
    fault.store(false, Ordering::Relaxed);
    assert_eq!(w.state(a), Restarting);
    w.handle(m).pause().unwrap();
    (w, m, a)
}

/// The tick at 2 ms pauses M and what M blocks; M's lane, above the tick, before each
/// section of that tick (or after it): A takes its restart up. However the two
/// interleave, A ends paused with M: a pause walk that passed over A while it was
/// `Restarting` walks again once A's new round began (a restart counts in
/// `State::runs_begun`), and a restart taken up below a caller already paused begins
/// paused. Found by the random preemption test: A ran on below its paused caller.
fn restart_taken_up_during_a_pause<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = || restart_under_a_pause_setup::<L, N, B>(layout);
    let count = sections(setup, |(w, ..)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, m, a) = setup();
        let run = w.run(a);
        let lane = move || {
            if w.state(a) == Restarting {
                w.seq.restart(run);
            }
        };
        interleaved::at(k, lane);
        w.tick(2);
        interleaved::at(usize::MAX, || {});
        lane();
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!([w.state(m), w.state(a)], [Paused, Paused], "{what}");
        assert_eq!(
            w.moves(a, Restarting, Running),
            1,
            "{what}: A restarted once"
        );
        w.check(&what);
    });
}

#[test]
fn a_restart_taken_up_during_a_pause_of_its_caller_is_paused_with_it() {
    every_world!(restart_taken_up_during_a_pause);
}

/// O (main) has a monitor (`b`, exception sequence E) that fires at 1 ms: E runs, the
/// behaviour waits for E's end. O started X non-blocking; X's `RestartCallerOfOwner`
/// monitor (no exception sequence) fires at 2 ms and restarts O, taking X and E down.
/// The tick at 3 ms reports E's (aborted) end to O. O's lane, of higher priority than the
/// tick, runs O's restart (`Sequencer::restart`) before section `k` of that tick, or
/// after it. The restart dropped the behaviour that waited for E (`commit_restart`), and
/// the restarted round begins without the exception: it is left alone, running, whatever
/// `k` (semantics 4, `Handle::exception_is_active`).
fn restarted_round_under_a_stale_exception_end<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
    b: Behaviour,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let c = w.seq("C");
        let o = w.seq("O");
        let e = w.seq("E");
        let x = w.seq("X");
        let fo = flag_of(true);
        w.monitor(o, fo, b, Some(e));
        let fx = flag_of(false);
        w.monitor(x, fx, Behaviour::RestartCallerOfOwner, None);
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        w.in_lane(x, o).unwrap();
        w.take(x);
        w.tick(1);
        fo.store(false, Ordering::Relaxed);
        w.take(e);
        assert!(w.in_set(Set::Excepting, o));
        fx.store(true, Ordering::Relaxed);
        w.tick(2);
        assert_eq!(
            [w.state(o), w.state(e), w.state(x)],
            [Restarting, Aborted, Aborted],
            "set-up"
        );
        (w, c, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(3));
    every_k(count + 1, |k| {
        let (w, c, o) = setup();
        let relaunch = move || {
            if w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
        };
        interleaved::at(k, relaunch);
        w.tick(3);
        or_after(k, relaunch);
        for ms in 4..=5 {
            w.tick(ms);
        }
        let what = name::<L>(layout, format_args!("{b:?}, k={k} of {count}"));
        assert_eq!(
            (w.state(c), w.state(o)),
            (Running, Running),
            "{what}: C {:?}, O {:?}",
            w.transitions(c),
            w.transitions(o)
        );
        w.check(&what);
    });
}

#[test]
fn a_restarted_round_is_left_alone_by_the_end_of_the_exception_sequence_its_restart_took_down() {
    for b in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        every_world!(restarted_round_under_a_stale_exception_end, b);
    }
}

// A pause request of one round meets the restart that ends the round (found by a cold
// review of pauses in session 56): a pause ends with its round, carried out or not, and a
// restarted run runs unpaused (semantics 4, 7). Three windows: a lane above the tick asks
// the pause during the tick that restarts the run; the tick restarts the run between a
// request's check and its queueing; a lane above the tick takes up the restart of an
// ended exception sequence's behaviour before the tick's requests.

/// O (polled every ms) runs, started at 0, with a `RestartOwner` monitor whose condition
/// (the returned flag) is true: the tick at 1 ms restarts O.
fn to_be_restarted<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, &'static AtomicBool) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let fault = flag_of(false);
    w.monitor(o, fault, Behaviour::RestartOwner, None);
    w.start_taken(o);
    fault.store(true, Ordering::Relaxed);
    (w, o, fault)
}

/// After the tick at 1 ms restarted O (the fault cleared): O's lane takes the restart up,
/// then the tick at 2 ms. The pause asked for during round 1 ends with that round: O runs
/// (round 2, never paused) and a resume is `NotPaused`.
fn round_two_runs_unpaused<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    o: SeqId,
    asked: Result<(), Error>,
) {
    assert!(
        matches!(asked, Ok(()) | Err(Error::NotRunning(_))),
        "{what}: asked {asked:?}"
    );
    assert_eq!(w.ended(o), (Restarting, M0), "{what}");
    w.seq.restart(w.run(o));
    assert_eq!(w.state(o), Running, "{what}: restarted");
    w.tick(2);
    assert_eq!(
        w.state(o),
        Running,
        "{what}: round 2 paused by round 1's pause request"
    );
    assert_eq!(w.moves(o, Restarting, Running), 1, "{what}");
    assert_eq!(w.kept(o).resume(), Err(Error::NotPaused(o)), "{what}");
    w.check(what);
}

/// A lane above the tick asks a pause of O before each section of the tick at 1 ms that
/// restarts O (or after it).
fn pause_asked_into_restarting_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    // Under a priority ceiling no lane runs during the tick.
    if L::COARSE {
        return;
    }
    let setup = move || to_be_restarted::<L, N, B>(layout);
    let count = sections(setup, |(w, _, _)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, fault) = setup();
        let what = name::<L>(
            layout,
            format_args!("pause into restarting tick, k={k}/{count}"),
        );
        let asked: Rc<Cell<Option<Result<(), Error>>>> = Rc::new(Cell::new(None));
        let into = asked.clone();
        let act = move || into.set(Some(w.kept(o).pause()));
        interleaved::at(k, act.clone());
        w.tick(1);
        or_after(k, act);
        fault.store(false, Ordering::Relaxed);
        round_two_runs_unpaused(&what, &w, o, asked.get().unwrap());
    });
}

#[test]
fn a_pause_asked_during_the_tick_that_restarts_the_run_ends_with_the_round() {
    every_world!(pause_asked_into_restarting_tick);
}

/// A handle asks a pause of O (three sections) while the tick at 1 ms that restarts O
/// comes before each of them (or after).
fn restarting_tick_into_pause_request<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || to_be_restarted::<L, N, B>(layout);
    let count = sections(setup, |(w, o, _)| {
        let _ = w.kept(*o).pause();
    });
    every_k(count + 1, |k| {
        let (w, o, fault) = setup();
        let what = name::<L>(
            layout,
            format_args!("restarting tick into pause, k={k}/{count}"),
        );
        interleaved::at(k, move || w.tick(1));
        let asked = w.kept(o).pause();
        or_after(k, || w.tick(1));
        fault.store(false, Ordering::Relaxed);
        round_two_runs_unpaused(&what, &w, o, asked);
    });
}

#[test]
fn a_pause_request_crossing_the_tick_that_restarts_the_run_ends_with_the_round() {
    every_world!(restarting_tick_into_pause_request);
}

/// O's `RestartOwner` monitor fired at 1 ms with exception sequence E, which its lane ran
/// to its end; then a handle asked a pause of O. The tick at 2 ms applies E's behaviour
/// (the restart of O, before the requests, semantics 8) and O's lane, above the tick,
/// takes the restart up before each section of that tick (or after it). The pause asked
/// for just before that tick is never seen (semantics 4): O runs round 2, never paused,
/// and a resume is `NotPaused`.
fn relaunch_into_tick_applying_restart<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    // Under a priority ceiling no lane runs during the tick.
    if L::COARSE {
        return;
    }
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        let fault = flag_of(false);
        w.monitor(o, fault, Behaviour::RestartOwner, Some(e));
        w.start_taken(o);
        fault.store(true, Ordering::Relaxed);
        w.tick(1);
        fault.store(false, Ordering::Relaxed);
        w.take(e);
        assert!(w.complete(e));
        assert_eq!(w.kept(o).pause(), Ok(()));
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        let what = name::<L>(layout, format_args!("relaunch into tick, k={k}/{count}"));
        let relaunch = move || {
            if w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
        };
        interleaved::at(k, relaunch);
        w.tick(2);
        or_after(k, relaunch);
        // Inserted before the restart, it found nothing to take up: the lane does after.
        relaunch();
        assert_eq!(
            w.ended(o),
            (Running, M0),
            "{what}: round 2 (restarted once) paused by round 1's pause request"
        );
        assert_eq!(w.moves(o, Restarting, Running), 1, "{what}");
        w.tick(3);
        assert_eq!(
            w.state(o),
            Running,
            "{what}: round 2 paused by round 1's pause request"
        );
        assert_eq!(w.moves(o, Running, Paused), 0, "{what}");
        assert_eq!(w.kept(o).resume(), Err(Error::NotPaused(o)), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_pause_asked_before_the_tick_applying_a_restart_is_unseen_whatever_the_relaunch() {
    every_world!(relaunch_into_tick_applying_restart);
}

// Requests against a restart the lane takes up, and against the caller's restart (found
// by a cold review of requests in session 56: an abort asked while the lane took up its
// restart let the restart begin; the others held).

/// O's lane got the clearance `Restart` and takes the restart up (`Sequencer::restart`);
/// a lane of higher priority asks O's abort (a handle), or an abort-all is posted (any
/// priority), before each section of the restart up to its commit. Semantics 8: from the
/// request to the tick that carries it out, "a restart its lane has not taken up yet is
/// not begun (the run is aborted from `Restarting`)". An abort request moves the count of
/// changes, so any made before the commit stands; an abort-all is read in the schedule's
/// section (the second; the only one with a coarse lock), and one posted after it comes
/// after the restart, as one posted during an end's last section comes after the end: the
/// tick aborts the restarted round.
fn abort_into_restart<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    all: bool,
) {
    let setup = move || restarted_once::<L, N, B>(layout);
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    // The restart's last section comes after its commit (the count of runs begun, the
    // pause with a paused caller): the sections before it are those before the commit.
    let before_commit = if L::COARSE { count } else { count - 1 };
    every_k(before_commit, |k| {
        let (w, o, run) = setup();
        let what = name::<L>(layout, format_args!("abort-all {all}, k={k}/{count}"));
        assert_eq!(w.clearance(run), Clearance::Restart, "{what}");
        let asked: Rc<Cell<Option<Result<(), Error>>>> = Rc::new(Cell::new(None));
        let into = asked.clone();
        interleaved::at(k, move || {
            if all {
                w.seq.abort_all();
                into.set(Some(Ok(())));
            } else {
                into.set(Some(w.kept(o).abort()));
            }
        });
        w.seq.restart(run);
        assert_eq!(asked.get(), Some(Ok(())), "{what}: asked");
        let begun = w.moves(o, Restarting, Running);
        w.tick(2);
        let cause = if all { Cause::AbortAll } else { Cause::Abort };
        assert_eq!(w.ended(o), (Aborted, cause), "{what}");
        let schedule = if L::COARSE { 0 } else { 1 };
        assert_eq!(
            begun,
            usize::from(all && k > schedule),
            "{what}: the restart begun, or not, against its abort: {:?}",
            w.transitions(o)
        );
        w.check(&what);
    });
}

#[test]
fn an_abort_asked_before_the_commit_of_the_lanes_restart_is_not_begun() {
    every_world!(abort_into_restart, false);
}

#[test]
fn an_abort_all_posted_before_the_lanes_restart_is_scheduled_is_not_begun() {
    every_world!(abort_into_restart, true);
}

/// O's lane takes the restart up while a lane of higher priority asks a pause of O before
/// each section of the restart (or after it). A pause accepted (`Ok`) of the new round
/// (the restart committed before the check) is not lost: the tick at 2 ms pauses O. One
/// refused is `NotRunning` (O `Restarting`). Either way no pause of the old round.
fn pause_into_restart<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || restarted_once::<L, N, B>(layout);
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    every_k(count + 1, |k| {
        let (w, o, run) = setup();
        let what = name::<L>(layout, format_args!("pause into restart, k={k}/{count}"));
        // The pause's result, and O's state when it was asked.
        type Asked = Option<(Result<(), Error>, RunningState)>;
        let asked: Rc<Cell<Asked>> = Rc::new(Cell::new(None));
        let into = asked.clone();
        let act = move || {
            let before = w.state(o);
            into.set(Some((w.kept(o).pause(), before)));
        };
        interleaved::at(k, act.clone());
        w.seq.restart(run);
        or_after(k, act);
        let (asked, before) = asked.get().unwrap();
        assert_eq!(w.state(o), Running, "{what}");
        w.tick(2);
        match asked {
            Ok(()) => {
                assert_eq!(before, Running, "{what}");
                assert_eq!(
                    w.state(o),
                    Paused,
                    "{what}: an accepted pause of round 2 lost"
                );
                assert_eq!(w.kept(o).pause(), Err(Error::AlreadyPaused(o)), "{what}");
                w.kept(o).resume().unwrap();
                w.tick(3);
                assert_eq!(w.state(o), Running, "{what}");
            }
            Err(e) => {
                assert_eq!(e, Error::NotRunning(o), "{what}");
                assert_eq!(w.state(o), Running, "{what}");
            }
        }
        w.check(&what);
    });
}

#[test]
fn a_pause_asked_during_the_lanes_restart_is_of_the_round_it_was_checked_in() {
    every_world!(pause_into_restart);
}

/// O, paused by a pause request at 1 ms, has a `RestartOwner` monitor (flag) that fires
/// at 2 ms, while O is paused (monitors stay active). A resume of O is asked by a handle
/// (three sections) while the tick at 2 ms comes before each section (or after). The
/// resume is of round 1: O's round 2 runs unpaused (semantics 4, 7), and no pause
/// request stays in force (a later pause is accepted and pauses O; one more is
/// `AlreadyPaused`).
fn resume_crossing_restart_of_paused<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let fault = flag_of(false);
        w.monitor(o, fault, Behaviour::RestartOwner, None);
        w.start_taken(o);
        w.kept(o).pause().unwrap();
        w.tick(1);
        assert_eq!(w.state(o), Paused);
        fault.store(true, Ordering::Relaxed);
        (w, o, fault)
    };
    let count = sections(setup, |(w, o, _)| {
        let _ = w.kept(*o).resume();
    });
    every_k(count + 1, |k| {
        let (w, o, fault) = setup();
        let what = name::<L>(
            layout,
            format_args!("resume crossing restart, k={k}/{count}"),
        );
        interleaved::at(k, move || w.tick(2));
        let asked = w.kept(o).resume();
        or_after(k, || w.tick(2));
        fault.store(false, Ordering::Relaxed);
        assert!(
            matches!(asked, Ok(()) | Err(Error::NotPaused(_))),
            "{what}: {asked:?}"
        );
        assert_eq!(w.ended(o), (Restarting, M0), "{what}");
        w.seq.restart(w.run(o));
        w.tick(3);
        assert_eq!(w.state(o), Running, "{what}: round 2 paused");
        assert_eq!(w.kept(o).resume(), Err(Error::NotPaused(o)), "{what}");
        w.kept(o).pause().unwrap();
        w.tick(4);
        assert_eq!(w.state(o), Paused, "{what}");
        assert_eq!(w.kept(o).pause(), Err(Error::AlreadyPaused(o)), "{what}");
        w.kept(o).resume().unwrap();
        w.tick(5);
        assert_eq!(w.state(o), Running, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_resume_crossing_a_restart_of_a_paused_run_leaves_round_two_unpaused() {
    every_world!(resume_crossing_restart_of_paused);
}

/// O runs X blocking; O has a `RestartOwner` monitor (flag). A pause of X is asked (three
/// sections); before each section, the tick at 1 ms restarts O (aborting X), O's lane
/// takes the restart up and O's round 2 runs X again blocking. The pause was of X's first
/// run: X's second run is not paused (nor O).
fn child_pause_crossing_caller_restart<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let x = w.seq("X");
        let fault = flag_of(false);
        w.monitor(o, fault, Behaviour::RestartOwner, None);
        w.start_taken(o);
        w.blocking(x, o).unwrap();
        fault.store(true, Ordering::Relaxed);
        (w, o, x, fault)
    };
    let count = sections(setup, |(w, _, x, _)| {
        let _ = w.kept(*x).pause();
    });
    every_k(count + 1, |k| {
        let (w, o, x, fault) = setup();
        let what = name::<L>(
            layout,
            format_args!("child pause vs caller restart, k={k}/{count}"),
        );
        let party = move || {
            w.tick(1);
            fault.store(false, Ordering::Relaxed);
            assert_eq!(w.state(o), Restarting);
            w.seq.restart(w.run(o));
            w.blocking(x, o).unwrap();
        };
        interleaved::at(k, party);
        let asked = w.kept(x).pause();
        or_after(k, party);
        assert!(
            matches!(asked, Ok(()) | Err(Error::NotRunning(_))),
            "{what}: {asked:?}"
        );
        assert_eq!((w.state(o), w.state(x)), (Running, Running), "{what}");
        w.tick(2);
        // Before section 0 the party came before the check: the pause is of X's second
        // run, and pauses it.
        let x_paused = if k == 0 { Paused } else { Running };
        assert_eq!(
            (w.state(o), w.state(x)),
            (Running, x_paused),
            "{what}: X's new run paused by its old run's pause (or a pause of it lost)"
        );
        w.check(&what);
    });
}

#[test]
fn a_childs_pause_crossing_its_callers_restart_pauses_nothing_new() {
    every_world!(child_pause_crossing_caller_restart);
}

/// O runs, its abort asked; the tick at 1 ms restarts O (its `RestartOwner` monitor
/// cannot fire on a run being stopped, so an exception sequence's behaviour does it).
/// Here: O's `RestartOwner` monitor fired with exception sequence E at 1 ms; E ended; an
/// abort of O is asked by a handle (three sections) while the tick at 2 ms (applying E's
/// restart of O before the requests) comes before each section. The abort is of the run:
/// a restart keeps it (semantics 4). If accepted, O ends `Aborted(Abort)`.
fn abort_crossing_restart_by_behaviour<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        let fault = flag_of(true);
        w.monitor(o, fault, Behaviour::RestartOwner, Some(e));
        w.start_taken(o);
        w.tick(1);
        fault.store(false, Ordering::Relaxed);
        w.take(e);
        assert!(w.complete(e));
        (w, o)
    };
    let count = sections(setup, |(w, o)| {
        let _ = w.kept(*o).abort();
    });
    every_k(count + 1, |k| {
        let (w, o) = setup();
        let what = name::<L>(
            layout,
            format_args!("abort crossing restart, k={k}/{count}"),
        );
        let party = move || {
            w.tick(2);
            // O's lane, of higher priority, takes the restart up at once.
            if w.state(o) == Restarting && w.clearance(w.run(o)) == Clearance::Restart {
                w.seq.restart(w.run(o));
            }
        };
        interleaved::at(k, party);
        let asked = w.kept(o).abort();
        or_after(k, party);
        assert_eq!(asked, Ok(()), "{what}");
        w.tick(3);
        assert_eq!(
            w.ended(o),
            (Aborted, Cause::Abort),
            "{what}: {:?}",
            w.transitions(o)
        );
        w.check(&what);
    });
}

#[test]
fn an_abort_crossing_a_restart_is_carried_out() {
    every_world!(abort_crossing_restart_by_behaviour);
}
