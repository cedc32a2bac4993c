//! The tick and the lanes under the portable lock ([`Interleaved`]: every step of an
//! operation is a section), in a sequencer of one word: the tick inserted into a start, a
//! lane's start inserted into the tick's teardown and into its first sections, a lane's
//! end inserted into a firing tick, and the tick inserted into requests, restarts, joins
//! and dropped runs.
//!
//! [`Interleaved`]: crate::lock::interleaved::Interleaved

use super::*;

use crate::lock::interleaved::Interleaved;
use crate::Request;

/// The world every test here uses: the portable interleaving lock, one word.
type World = super::World<Interleaved, 8, 1>;

// ---------------------------------------------------------------------------------------
// 1. The tick inserted into a start.
// ---------------------------------------------------------------------------------------

/// O starts C (in C's lane, or blocking) while the tick aborts O (its `AbortOwner` monitor,
/// its timeout, an abort request, or its monitor after its exception sequence E ended).
/// Wherever the tick lands, nothing O started outlives O (semantics 9): either the start is
/// refused (`NotRunning(O)`) and C never ran, or C is aborted with O, with O's cause.
#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it() {
    starts_by_an_aborted_sequence::<Interleaved, 8, 1>(Layout::One);
}

/// O starts C while the tick restarts O (`RestartOwner`): a restart aborts everything below
/// its target, so C is refused or aborted (cause the monitor), never left running below the
/// restarted run; O is `Restarting`.
#[test]
fn a_start_by_a_sequence_the_tick_restarts_is_torn_down_by_the_restart() {
    starts_by_a_restarted_sequence::<Interleaved, 8, 1>(Layout::One);
}

/// O starts C in C's own lane while the tick pauses O (`PauseOwner`): a pause holds O and
/// its blocking children (in its lane), not a non-blocking child: the start succeeds and C
/// runs; O is paused.
#[test]
fn a_non_blocking_start_by_a_sequence_the_tick_pauses_runs() {
    non_blocking_start_paused::<Interleaved, 8, 1>(Layout::One);
}

/// O starts C blocking (in O's lane) while the tick pauses O (`PauseOwner`, its condition
/// stays true). A pause holds the sequences O blocks in its lane, and their clocks stop
/// (semantics 7): wherever the tick lands, C ends up `Paused` with O, and its 5 ms timeout
/// does not run out while O stays paused for 10 ms. When the condition clears, both resume.
#[test]
fn a_blocking_start_by_a_sequence_the_tick_pauses_is_paused_with_it() {
    blocking_start_paused::<Interleaved, 8, 1>(Layout::One);
}

/// A main sequence C is started by a handle while the tick aborts another sequence O (its
/// monitor): C is not O's, so it runs whatever section the tick preempts.
#[test]
fn a_handle_start_during_an_unrelated_abort_runs() {
    let setup = || owner_and_child::<Interleaved, 8, 1>(Layout::One, Fire::Abort);
    let count = sections(setup, |(w, _, c, _, _)| w.handle(*c).start().unwrap());
    every_k(count, |k| {
        let (w, o, c, _, _) = setup();
        interleaved::at(k, move || w.tick(1));
        assert_eq!(w.handle(c).start(), Ok(()), "k={k}");
        assert_eq!((w.ended(o), w.state(c)), ((Aborted, M0), Running), "k={k}");
        w.check(&format!("k={k}"));
    });
}

// ---------------------------------------------------------------------------------------
// 2. A lane of higher priority inserted into the tick's teardown.
// ---------------------------------------------------------------------------------------

/// The tick aborts R, Y (non-blocking child of R) and X (blocking in Y) for an abort
/// request of R, innermost first. After X's stop Y's lane, of higher priority than the
/// tick, runs: Y, still running, starts a fallback G. G must be torn down with Y (as the
/// dropped run's teardown does, walking again), or refused.
#[test]
fn a_start_below_a_caller_the_tick_has_not_aborted_yet_is_torn_down_for_a_request() {
    lane_start_into_teardown::<Interleaved, 8, 1>(Layout::One, Teardown::Request, true);
}

/// As above for an abort-all (the safety system's emergency stop): every sequence,
/// including one a lane of higher priority started during the walk, is aborted by the
/// tick that carries the abort-all out.
#[test]
fn a_start_during_an_abort_all_is_torn_down() {
    lane_start_into_teardown::<Interleaved, 8, 1>(Layout::One, Teardown::AbortAll, true);
}

/// As above for R's `AbortOwner` monitor (no exception sequence): the behaviour's walk
/// tears down G too.
#[test]
fn a_start_during_a_monitors_abort_is_torn_down() {
    lane_start_into_teardown::<Interleaved, 8, 1>(Layout::One, Teardown::Monitor, true);
}

/// R runs alone (nothing has a caller link): the tick's walk of an abort request takes its
/// shortcut (one section to see that nothing is linked, then R's stop). R's lane, of higher
/// priority, starts G between the two: G must be torn down with R, or refused.
#[test]
fn a_start_during_the_shortcut_walk_of_a_request_is_torn_down() {
    lane_start_into_teardown::<Interleaved, 8, 1>(Layout::One, Teardown::Request, false);
}

/// As above, the abort-all.
#[test]
fn a_start_during_the_shortcut_walk_of_an_abort_all_is_torn_down() {
    lane_start_into_teardown::<Interleaved, 8, 1>(Layout::One, Teardown::AbortAll, false);
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
        let w = World::new(Layout::One);
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

/// `end_into_firing_tick` for a monitor with an exception sequence (`AbortOwner`).
#[test]
fn an_end_during_a_firing_with_an_exception_sequence_is_either_first_or_refused() {
    end_into_firing_tick::<Interleaved, 8, 1>(Layout::One, Firing::AbortAfterE);
}

/// `end_into_firing_tick` for a `RestartOwner` monitor.
#[test]
fn an_end_during_a_restarting_firing_is_either_first_or_refused() {
    end_into_firing_tick::<Interleaved, 8, 1>(Layout::One, Firing::Restart);
}

/// `end_into_firing_tick` for a timeout.
#[test]
fn an_end_during_a_timeout_is_either_first_or_refused() {
    end_into_firing_tick::<Interleaved, 8, 1>(Layout::One, Firing::Timeout);
}

/// `replaced_during_firing_tick` for every kind of firing, in one word and in two.
#[test]
fn a_run_replaced_during_a_firing_on_it_leaves_the_new_run_alone() {
    for firing in [
        Firing::Abort,
        Firing::AbortAfterE,
        Firing::Restart,
        Firing::RestartAfterE,
        Firing::Timeout,
    ] {
        replaced_during_firing_tick::<Interleaved, 8, 1>(Layout::One, firing);
        replaced_during_firing_tick::<Interleaved, 64, 2>(Layout::Second, firing);
    }
}

/// O runs, its abort (or pause) is requested; O's lane, of higher priority than the tick,
/// drops O's run and starts O again (a handle; the lane takes run 2) before section `k` of
/// the tick at 1 ms that carries the request out. The request was run 1's (a new run's
/// commit clears it): run 2 runs on, whatever `k`, unless the tick's teardown had O
/// `Aborting` (then the start is refused and there is no run 2).
fn replaced_during_request(request: Request) {
    let setup = move || {
        let w = World::new(Layout::One);
        let o = w.seq("O");
        w.start_taken(o);
        match request {
            Request::Abort => w.handle(o).abort().unwrap(),
            Request::Pause => w.handle(o).pause().unwrap(),
            Request::Resume => unreachable!("not requested here"),
        }
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, o) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(1);
        let what = format!("{request:?}, k={k}");
        match (w.runs(o), request) {
            (2, _) => assert_eq!(w.state(o), Running, "{what}"),
            (_, Request::Abort) => assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}"),
            other => panic!("{what}: {other:?}"),
        }
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_during_the_request_of_it_runs_on() {
    replaced_during_request(Request::Abort);
    replaced_during_request(Request::Pause);
}

/// O's `RestartOwner` monitor restarted O at 1 ms; before O's lane takes the restart up,
/// O's abort is requested (or an abort-all asked for). O's next round is not begun (its
/// action begins nothing more, semantics 8): its clearance holds, and the tick at 2 ms
/// aborts O from `Restarting`, with no `Restarting → Running` in its trace.
#[test]
fn a_restart_not_taken_up_before_an_abort_is_asked_for_is_not_begun() {
    for all in [false, true] {
        let (w, o, run) = restarting::<Interleaved, 8, 1>(Layout::One);
        if all {
            w.seq.abort_all();
        } else {
            w.handle(o).abort().unwrap();
        }
        let what = format!("abort-all {all}");
        let clearance = Port::clearance(w.seq, run, Waker::noop());
        assert_eq!(clearance, Clearance::Hold, "{what}");
        w.tick(2);
        let cause = if all { Cause::AbortAll } else { Cause::Abort };
        assert_eq!(w.ended(o), (Aborted, cause), "{what}");
        let taken_up = w
            .transitions(o)
            .iter()
            .any(|t| t.from == Restarting && t.to == Running);
        assert!(!taken_up, "{what}: {:?}", w.transitions(o));
        w.check(&what);
    }
}

/// P runs (in its lane), its pause requested; X is registered. P's lane, of higher
/// priority than the tick, ends P's run 1 (completed), starts P again (a handle; run 2)
/// and P's run 2 starts X blocking, before section `k` of the tick at 1 ms that carries
/// the pause out (found by the random preemption test, seed 5 493 870). The pause was of
/// run 1: once P runs run 2, nothing below it is paused by it. So either P's run 1 was
/// paused first (its end is then refused, and nothing else happens), or P's run 2 and X
/// run, and nothing is paused below a running caller.
#[test]
fn a_pause_of_a_run_replaced_during_it_pauses_nothing_below_the_new_run() {
    let setup = || {
        let w = World::new(Layout::One);
        let (p, x) = (w.seq("P"), w.seq("X"));
        w.start_taken(p);
        w.handle(p).pause().unwrap();
        (w, p, x)
    };
    let count = sections(setup, |(w, _, _)| w.tick(1));
    every_k(count, |k| {
        let (w, p, x) = setup();
        interleaved::at(k, move || {
            if w.complete(p) {
                w.start_taken(p);
                w.blocking(x, p).unwrap();
            }
        });
        w.tick(1);
        let what = format!("k={k}");
        if w.runs(p) == 1 {
            assert_eq!((w.state(p), w.state(x)), (Paused, Idle), "{what}");
        } else {
            assert_eq!((w.state(p), w.state(x)), (Running, Running), "{what}");
        }
        w.check(&what);
    });
}

/// The same for a teardown (found by the random preemption test, seed 5 833 146, where an
/// abort request was queued on a run that had just ended). P's run 1 has ended; Q runs with
/// Y blocking below it, so P is not alone with a caller link and the teardown of P's run 1
/// walks the tree. Before its section `k`, P's lane starts P again and P's run 2 starts X
/// blocking. The teardown was of run 1, which is over: it aborts nothing, not the new run
/// or X below it, not Q or Y.
#[test]
fn a_teardown_of_an_ended_run_aborts_nothing_of_the_new_run() {
    let setup = || {
        let w = World::new(Layout::One);
        let [p, q, x, y] = ["P", "Q", "X", "Y"].map(|name| w.seq(name));
        w.start_taken(p);
        w.start_taken(q);
        w.blocking(y, q).unwrap();
        let ended = w.run(p);
        assert!(w.complete(p));
        (w, [p, q, x, y], ended)
    };
    let tear_down = |w: &World, ended| w.seq.tear_down(&(), ended, Cause::Abort);
    let count = sections(setup, |(w, _, ended)| tear_down(w, *ended));
    every_k(count, |k| {
        let (w, [p, q, x, y], ended) = setup();
        interleaved::at(k, move || {
            w.start_taken(p);
            w.blocking(x, p).unwrap();
        });
        tear_down(&w, ended);
        let what = format!("k={k}");
        let states = [p, x, q, y].map(|id| w.state(id));
        assert_eq!(states, [Running; 4], "{what}");
        w.check(&what);
    });
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
    let setup = || watched::<Interleaved, 8, 1>(Layout::One, Behaviour::RestartOwner);
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
    let setup = || watched::<Interleaved, 8, 1>(Layout::One, Behaviour::AbortOwner);
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

/// O runs from 0; its pause is requested, and the tick at 3 ms pauses it. A lane of
/// higher priority reads O's run time before each section of that tick: the run time so
/// far, 1 ms (the time of the last tick) or 3 ms, never a paused state with a running
/// clock. Then O is paused with a run time of 3 ms, and it stays 3 ms while paused.
#[test]
fn the_run_time_read_during_a_pause_is_the_time_so_far() {
    let setup = || {
        let w = World::new(Layout::One);
        let o = w.seq("O");
        w.start_taken(o);
        w.tick(1);
        w.seq.sequence_by_id(o).unwrap().pause().unwrap();
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(3));
    every_k(count, |k| {
        let (w, o) = setup();
        let read = Rc::new(Cell::new(None));
        let into = read.clone();
        interleaved::at(k, move || into.set(Some(Port::run_time(w.seq, o))));
        w.tick(3);
        let what = format!("k={k}");
        assert!(
            matches!(read.get(), Some(1_000 | 3_000)),
            "{what}: {read:?}"
        );
        assert_eq!(w.state(o), Paused, "{what}");
        w.tick(5);
        assert_eq!(Port::run_time(w.seq, o), 3_000, "{what}");
        w.check(&what);
    });
}

/// A pause of O is requested while the tick at 1 ms pauses O (its `PauseOwner` monitor,
/// condition true at 1 ms, false from 2 ms), inserted before each section of the request.
/// If the request was accepted (O still running when it was checked), O stays paused when
/// the monitor lets go (only a resume request lifts a request's pause, semantics 7); if it
/// was refused (`AlreadyPaused`: the monitor paused O first), O resumes at 2 ms.
#[test]
fn a_pause_requested_while_the_tick_pauses_the_sequence_outlasts_the_monitor_iff_accepted() {
    let setup = || {
        let w = World::new(Layout::One);
        let o = w.seq("O");
        let holds = flag_of(true);
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
                assert_eq!(e, Error::AlreadyPaused(o), "k={k}");
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
    abort_during_restart::<Interleaved, 8, 1>(false);
}

/// O's lane obeys `Restart` (`Sequencer::restart`) after O's `RestartOwner` monitor fired
/// at 1 ms (its condition stays true); the tick at 2 ms comes before each section of the
/// restart up to its commit. The restart commits once, after the tick (O `Running`, one
/// `Restarting → Running` record), and the restarted run's monitors start again from
/// "false": the tick at 3 ms restarts O again (its second restart, within the limit).
#[test]
fn a_restart_preempted_by_the_tick_runs_again_once() {
    let setup = || restarting::<Interleaved, 8, 1>(Layout::One);
    let count = sections(setup, |(w, _, run)| w.seq.restart(*run));
    // The restart's last section, after its commit, pauses the run with a paused caller it
    // blocks (none here): the sections before it are those before the commit.
    every_k(count - 1, |k| {
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
        let w = World::new(Layout::One);
        let [o, j] = ["O", "J"].map(|n| w.seq(n));
        w.monitor(o, flag_of(true), Behaviour::AbortOwner, None);
        w.start_taken(o);
        w.start_taken(j);
        (w, o, j)
    };
    let count = sections(setup, |(w, o, j)| {
        let _ = port_join(w.seq, *j, *o, &mut None);
    });
    every_k(count, |k| {
        let (w, o, j) = setup();
        interleaved::at(k, move || w.tick(1));
        let mut run = None;
        let first = port_join(w.seq, j, o, &mut run);
        let outcome = match first {
            core::task::Poll::Ready(r) => r,
            core::task::Poll::Pending => {
                assert!(
                    !w.seq.with(|s| s.sets.has(Set::Joining, j)),
                    "k={k}: released"
                );
                match port_join(w.seq, j, o, &mut run) {
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
        tick_into_dropped_run::<Interleaved, 8, 1>(Layout::One, behaviour, false);
    }
}

/// The tick at 1 ms restarts O (its `RestartOwner` monitor); an abort of O is requested by
/// a lane of higher priority before section `k` of that tick. The request is accepted
/// (O is running or restarting, both may be aborted) and a restart does not end the run it
/// was made of, so it is carried out: after the tick at 2 ms O is `Aborted` (cause
/// `Abort`), whether or not O's lane ran it again in between.
#[test]
fn an_abort_requested_during_a_restarting_tick_is_carried_out() {
    let setup = || watched::<Interleaved, 8, 1>(Layout::One, Behaviour::RestartOwner);
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

/// C (a cycle, main) started O (a move) non-blocking and ended. O's monitor
/// (`RestartCallerOfOwner`, exception sequence E) fires in the tick at 1 ms; E's lane, of
/// higher priority than the tick, takes E's start and E starts C again before section `k`
/// of that tick (or after it): C's start cuts O's link to C's ended run, also before the
/// tick made the behaviour pending. Once E has ended, the next tick aborts O, as an owner
/// whose caller has ended, wherever the cut came (semantics 11); before session 47 it
/// restarted O as if it were a main sequence. (Found by a review; the first fix, at the
/// cut, missed a cut before the behaviour was pending, k = 21 to 24.)
#[test]
fn a_caller_behaviour_whose_link_is_cut_during_the_firing_aborts_the_owner() {
    let setup = || {
        let w = World::new(Layout::One);
        let c = w.seq("C");
        let o = w.seq("O");
        let e = w.seq("E");
        let cause = w.monitor(o, flag_of(true), Behaviour::RestartCallerOfOwner, Some(e));
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        assert!(w.complete(c));
        (w, c, o, e, cause)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count, |k| {
        let (w, c, o, e, cause) = setup();
        let during: &'static AtomicBool = flag_of(false);
        interleaved::at(k, move || {
            if w.try_take(e).is_some() {
                w.in_lane(c, e).unwrap();
                during.store(true, Ordering::Relaxed);
            }
        });
        w.tick(1);
        let during = during.load(Ordering::Relaxed);
        if !during {
            interleaved::at(usize::MAX, || {});
            w.take(e);
            w.in_lane(c, e).unwrap();
        }
        w.take(c);
        assert_eq!(w.caller(o), None, "k={k}: the link is cut");
        assert!(w.complete(e), "k={k}");
        w.tick(2);
        let what = format!("k={k} (E's start of C during the tick: {during})");
        assert_eq!(
            w.ended(o),
            (Aborted, cause),
            "{what}: {:?}",
            w.transitions(o)
        );
        w.check(&what);
    });
}

/// C (main) started O non-blocking and runs on. O's monitor (`behaviour`, a caller
/// behaviour; with exception sequence E or without) fired at 1 ms. The tick that applies
/// the behaviour (at 2 ms after E's end, or at 1 ms without E) reads C's run under way and
/// tears it down; a lane of higher priority than the tick ends C's run and a handle starts
/// C again before section `k` of that tick (or after it). Wherever it lands, O's exception
/// ends: the behaviour acts on C's new run when it began before the tick read C's run
/// (semantics 11), and O is torn down with C's old run once the teardown had it; a run
/// replaced between the read and the teardown's first look leaves the teardown nothing,
/// and O is then aborted, as an owner whose caller's run has ended. Before session 51 O
/// stayed running, marked and held, for good. (Found by an outside probe.)
fn caller_run_replaced_while_a_caller_behaviour_is_applied<L: Lock + 'static>(
    behaviour: Behaviour,
    with_exception_sequence: bool,
) {
    let setup = || {
        let w = super::World::<L, 8, 1>::new(Layout::One);
        let (c, o, e) = (w.seq("C"), w.seq("O"), w.seq("E"));
        w.monitor(
            o,
            flag_of(true),
            behaviour,
            with_exception_sequence.then_some(e),
        );
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        if with_exception_sequence {
            w.tick(1);
            w.take(e);
            assert!(w.complete(e));
        }
        (w, c, o)
    };
    let applying = if with_exception_sequence { 2 } else { 1 };
    let count = sections(setup, |(w, ..)| w.tick(applying));
    every_k(count, |k| {
        let (w, c, o) = setup();
        let replace = move || {
            if w.complete(c) {
                w.start_taken(c);
            }
        };
        interleaved::at(k, replace);
        w.tick(applying);
        or_after(k, replace);
        w.tick(applying + 1);
        let what = format!("{behaviour:?}, exception sequence {with_exception_sequence}, k={k}");
        assert!(
            w.state(o) != Running || !w.in_set(Set::Excepting, o),
            "{what}: O left held: O {:?}, C {:?}",
            w.transitions(o),
            w.transitions(c)
        );
        w.check(&what);
    });
}

#[test]
fn a_caller_run_replaced_while_a_caller_behaviour_is_applied_leaves_no_owner_held() {
    for behaviour in [
        Behaviour::RestartCallerOfOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        for with_exception_sequence in [true, false] {
            caller_run_replaced_while_a_caller_behaviour_is_applied::<Interleaved>(
                behaviour,
                with_exception_sequence,
            );
            caller_run_replaced_while_a_caller_behaviour_is_applied::<
                crate::lock::interleaved::InterleavedCoarse,
            >(behaviour, with_exception_sequence);
        }
    }
}
