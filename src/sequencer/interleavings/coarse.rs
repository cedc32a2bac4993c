//! Systematic interleavings under a coarse lock: the path production firmware runs.
//!
//! With RTIC's priority ceiling each operation's steps run in one section, and the tick
//! runs at the ceiling: no lane runs during the tick, but the tick may preempt a lane's
//! operation between two of its sections. Above the ceiling only `abort_all` (an atomic)
//! is called, at any time. The tests here count the sections of one lane operation under
//! [`InterleavedCoarse`] (the coarse twin of `Interleaved`), then, for every section `k`
//! (and, where it says so, after the last one), run the operation with the tick inserted
//! right before section `k`; or insert `abort_all` before section `k` of a tick. The
//! scenarios are those of [`fine`](super::fine) and [`more`](super::more) that a coarse
//! lock allows, in sequencers of one word and of two.
//!
//! [`InterleavedCoarse`]: crate::lock::interleaved::InterleavedCoarse

use super::*;

use crate::lock::interleaved::InterleavedCoarse;
use crate::Failure;
use std::cell::RefCell;

/// The world every test here uses: the coarse interleaving lock.
type Cw<const N: usize, const B: usize> = World<InterleavedCoarse, N, B>;

#[test]
fn the_coarse_lock_takes_a_start_in_two_sections_and_a_wake_up() {
    let w = Cw::<8, 1>::new(Layout::One);
    let [o, c] = ["O", "C"].map(|n| w.seq(n));
    w.start_taken(o);
    let by = w.run(o);
    interleaved::at(usize::MAX, || {});
    Port::start_child(w.seq, c, by).unwrap();
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

/// O starts C (in C's lane, or blocking) while the tick aborts O (its `AbortOwner` monitor,
/// its timeout, an abort request, or its monitor after its exception sequence E ended):
/// the start is refused (`NotRunning(O)`) or C is aborted with O (semantics 9).
#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it() {
    starts_by_an_aborted_sequence::<InterleavedCoarse, 8, 1>(Layout::One);
}

#[test]
fn a_start_by_a_sequence_the_tick_aborts_never_outlives_it_in_two_words() {
    starts_by_an_aborted_sequence::<InterleavedCoarse, 64, 2>(Layout::Split);
    starts_by_an_aborted_sequence::<InterleavedCoarse, 64, 2>(Layout::Second);
}

/// O starts C while the tick restarts O (`RestartOwner`): C is refused or aborted with the
/// monitor's cause; O is `Restarting`.
#[test]
fn a_start_by_a_sequence_the_tick_restarts_is_torn_down_by_the_restart() {
    starts_by_a_restarted_sequence::<InterleavedCoarse, 8, 1>(Layout::One);
    starts_by_a_restarted_sequence::<InterleavedCoarse, 64, 2>(Layout::Split);
}

/// O starts C in C's own lane while the tick pauses O (`PauseOwner`): the start succeeds
/// and C runs; O is paused.
#[test]
fn a_non_blocking_start_by_a_sequence_the_tick_pauses_runs() {
    non_blocking_start_paused::<InterleavedCoarse, 8, 1>(Layout::One);
    non_blocking_start_paused::<InterleavedCoarse, 64, 2>(Layout::Split);
}

/// O starts C blocking while the tick pauses O (`PauseOwner`, its condition stays true):
/// C ends up `Paused` with O, and its 5 ms timeout does not run out while O stays paused
/// for 10 ms (semantics 7).
#[test]
fn a_blocking_start_by_a_sequence_the_tick_pauses_is_paused_with_it() {
    blocking_start_paused::<InterleavedCoarse, 8, 1>(Layout::One);
    blocking_start_paused::<InterleavedCoarse, 64, 2>(Layout::Split);
}

/// A main sequence C is started by a handle while the tick aborts another sequence O (its
/// monitor): C runs whatever section the tick preempts.
#[test]
fn a_handle_start_during_an_unrelated_abort_runs() {
    let setup = || owner_and_child::<InterleavedCoarse, 8, 1>(Layout::One, Fire::Abort);
    let count = sections(setup, |(w, _, c, _, _)| {
        Port::start_main(w.seq, *c).unwrap();
    });
    every_k(count, |k| {
        let (w, o, c, _, _) = setup();
        interleaved::at(k, move || w.tick(1));
        assert_eq!(Port::start_main(w.seq, c).map(drop), Ok(()), "k={k}");
        assert_eq!((w.ended(o), w.state(c)), ((Aborted, M0), Running), "k={k}");
        w.check(&format!("k={k}"));
    });
}

// =======================================================================================
// 2. The tick inserted into an end.
// =======================================================================================

/// O's lane ends O's run (`outcome`; `Port::end`, then `Port::finished`), and the tick at
/// 1 ms in which `firing` fires on O comes before section `k` of it (or after it). Either
/// the end comes first (O `Terminated` with the outcome, nothing fired, E never started,
/// a failure recorded once), or the firing does: the end is refused; with E, E runs to
/// its end and the next tick applies O's behaviour, once.
fn tick_into_end<const N: usize, const B: usize>(layout: Layout, firing: Firing, outcome: Outcome) {
    let setup = move || firing_on::<InterleavedCoarse, N, B>(layout, firing);
    let count = sections(setup, |(w, _, _, run)| {
        assert!(w.end_run(*run, outcome));
    });
    every_k(count + 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, {firing:?}, {outcome:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        let ended = w.end_run(run, outcome);
        or_after(k, || w.tick(1));
        let cause = firing.cause(o);
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
        firing_carried_out(&what, &w, firing, o, e, || w.end_run(run, outcome));
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
        let (w, o) = watched::<InterleavedCoarse, 8, 1>(Layout::One, Behaviour::RestartOwner);
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
        let (w, o) = watched::<InterleavedCoarse, 8, 1>(Layout::One, Behaviour::AbortOwner);
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
/// monitor; refused (`AlreadyPaused`), O resumes at 2 ms.
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
                assert_eq!(e, Error::AlreadyPaused(o), "k={k}");
                assert_eq!(w.state(o), Running, "k={k}: released");
            }
        }
        w.check(&format!("k={k}"));
    });
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
        || paused_then_held::<InterleavedCoarse, N, B>(layout),
        Ask::Resume,
        2,
        resumed_around_holding_tick,
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
        || paused_then_released::<InterleavedCoarse, N, B>(layout),
        Ask::Resume,
        2,
        |what, asked, w, o, _| {
            assert!(
                [Err(Error::HeldByMonitor(o)), Err(Error::NotPaused(o))].contains(&asked),
                "{what}: {asked:?}"
            );
            resumed_around_releasing_tick(what, w, o);
        },
    );
}

#[test]
fn a_resume_requested_during_a_releasing_tick_resumes_once() {
    resume_request_around_releasing_tick::<8, 1>(Layout::One);
    resume_request_around_releasing_tick::<64, 2>(Layout::Second);
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A pause
/// of O is requested, the tick at 2 ms before it (O paused at 3 ms) or after it (O kept
/// paused when released), accepted either way: see [`paused_around_releasing_tick`].
fn pause_request_around_releasing_tick<const N: usize, const B: usize>(layout: Layout) {
    tick_into_request(
        || paused_then_released::<InterleavedCoarse, N, B>(layout),
        Ask::Pause,
        2,
        paused_around_releasing_tick,
    );
}

#[test]
fn a_pause_requested_around_a_releasing_tick_is_kept() {
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
    abort_during_restart::<InterleavedCoarse, 8, 1>(true);
}

/// O's lane obeys `Restart` after O's `RestartOwner` monitor fired at 1 ms (its condition
/// stays true); the tick at 2 ms comes before (or after) the restart. The restart commits
/// once, and the restarted run's monitors start again from "false": O is restarted again
/// by 3 ms, one `Restarting → Running` record.
#[test]
fn a_restart_preempted_by_the_tick_runs_again_once() {
    let setup = || restarting::<InterleavedCoarse, 8, 1>(Layout::One);
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
    let setup = move || restarting_before_a_firing::<InterleavedCoarse, N, B>(layout);
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
        aborted_after_e_once(&what, &w, o, e, ms);
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

/// O runs; J2 has joined O's run (pending). J1 polls its join of O with the tick at 1 ms
/// before section `k` of the poll (or after it). Every joiner gets the outcome of the run
/// it joined, never hangs: an abort's `Aborted(cause)` (at once, or released and woken,
/// then ready); a restart does not end the run: both wait, and get `Completed` when O's
/// lane, having restarted it, completes it.
fn tick_into_join<const N: usize, const B: usize>(layout: Layout, tick: JoinTick) {
    let setup = move || joined::<InterleavedCoarse, N, B>(layout, tick);
    let count = sections(setup, |(w, o, js)| {
        let mut run = None;
        let _ = port_join(w.seq, js[0].id, *o, &mut run);
    });
    every_k(count + 1, |k| {
        let (w, o, [mut j1, mut j2]) = setup();
        let what = format!("{layout:?}, {tick:?}, k={k}");
        let (j1_wakes, j2_wakes) = (woken(&j1.wakes), woken(&j2.wakes));
        interleaved::at(k, move || w.tick(1));
        let first = j1.poll(&w, o);
        let after = or_after(k, || w.tick(1));
        let cause = tick.cause();
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
                joined_through_a_restart(&what, &w, o, [&mut j1, &mut j2], first);
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

/// `tick_into_dropped_run`, the tick also after the teardown.
#[test]
fn a_dropped_run_during_a_firing_below_it_leaves_nothing_under_way() {
    for behaviour in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
        Behaviour::AbortCallerOfOwner,
    ] {
        tick_into_dropped_run::<InterleavedCoarse, 8, 1>(Layout::One, behaviour, true);
        tick_into_dropped_run::<InterleavedCoarse, 64, 2>(Layout::Split, behaviour, true);
    }
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E ran to its end. O's
/// run is dropped (`Port::abandon`) with the tick at 2 ms, which reports E's end to O and
/// applies the behaviour, before section `k` of the teardown (or after it). O is aborted
/// once: by the drop (`Dropped`), or, when the tick's abort came first, by the monitor; a
/// restart by the tick is followed by the drop's abort. E's end is reported once.
fn tick_into_dropped_owner<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || exception_ended::<InterleavedCoarse, N, B>(layout, behaviour);
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
        dropped_owner_once(&what, &w, o, e, cause);
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

#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone() {
    for tick in TICKS {
        take_during_tick::<InterleavedCoarse, 8, 1>(Layout::One, tick);
        take_during_tick::<InterleavedCoarse, 64, 2>(Layout::Second, tick);
        take_during_tick::<InterleavedCoarse, 64, 2>(Layout::Split, tick);
    }
}

#[test]
fn a_lane_dropped_while_the_tick_fires_on_its_pending_start_leaves_nothing_under_way() {
    for tick in TICKS {
        abandon_during_tick::<InterleavedCoarse, 8, 1>(Layout::One, tick);
        abandon_during_tick::<InterleavedCoarse, 64, 2>(Layout::Second, tick);
        abandon_during_tick::<InterleavedCoarse, 64, 2>(Layout::Split, tick);
    }
}

// =======================================================================================
// 8. The tick inserted into the end of an exception sequence.
// =======================================================================================

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E runs (taken), and an
/// abort of E was requested. E's lane tries to end E (completed) with the tick at 2 ms,
/// which carries the abort out, before section `k` of the end (or after it). The request
/// holds E: its end is refused whatever `k` is, and the tick aborts it. E ends once, its
/// end is reported to O once, and O's behaviour is applied once, by the tick at 3 ms at
/// the latest; E is free again.
fn tick_into_end_of_e<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || exception_to_abort::<InterleavedCoarse, N, B>(layout, behaviour);
    let count = sections(setup, |(w, _, _, run)| {
        assert!(!w.end_run(*run, Outcome::Completed));
    });
    every_k(count + 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        let ended = w.end_run(run, Outcome::Completed);
        or_after(k, || w.tick(2));
        assert!(!ended, "{what}");
        assert_eq!(w.ended(e), (Aborted, Cause::Abort), "{what}");
        behaviour_applied_once(&what, &w, o, e, behaviour);
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
    chain(&w, r, y, x);
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
    let setup = || owner_and_child::<InterleavedCoarse, N, B>(layout, Fire::AbortAfterE);
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
            child_aborted_all_or_refused(&w, o, c, started, &what);
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
/// then (`AbortAll`), once. Until then O begins nothing more (semantics item 8): a start
/// or an end that the abort-all came before is refused, so O ends aborted either way.
#[test]
fn an_abort_all_anywhere_in_a_lanes_operation_is_carried_out_by_the_next_tick() {
    for how in [How::InLane, How::Blocking] {
        let setup = || owner_and_child::<InterleavedCoarse, 8, 1>(Layout::One, Fire::AbortAfterE);
        let count = sections(setup, |(w, _, c, _, run)| {
            let _ = start_child(w, *run, *c, how);
        });
        let accepted = RefCell::new(Vec::new());
        every_k(count, |k| {
            let (w, o, c, _, run) = setup();
            let what = format!("start {how:?}, k={k}");
            interleaved::at(k, move || w.seq.abort_all());
            let started = start_child(&w, run, c, how);
            w.tick(1);
            assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}: O");
            child_aborted_all_or_refused(&w, o, c, started, &what);
            assert_eq!(w.fired(o, M0), 0, "{what}");
            w.check(&what);
            accepted.borrow_mut().push(started.is_ok());
        });
        // With the coarse lock the checks take one section and the schedule and commit
        // another; a start in a lane wakes the lane in a third.
        let expected: &[bool] = match how {
            How::InLane => &[false, false, true],
            How::Blocking => &[false, false],
        };
        assert_eq!(accepted.into_inner(), expected, "start {how:?}");
    }
    // The end of O (C runs below it, non-blocking): C is aborted; O ended, or (the
    // abort-all came first) aborted.
    let setup = || {
        let (w, o, c, e, run) =
            owner_and_child::<InterleavedCoarse, 8, 1>(Layout::One, Fire::Timeout);
        start_child(&w, run, c, How::InLane).unwrap();
        (w, o, c, e, run)
    };
    let count = sections(setup, |(w, _, _, _, run)| {
        assert!(w.end_run(*run, Outcome::Completed));
    });
    let accepted = RefCell::new(Vec::new());
    every_k(count, |k| {
        let (w, o, c, _, run) = setup();
        let what = format!("end, k={k}");
        interleaved::at(k, move || w.seq.abort_all());
        let ended = w.end_run(run, Outcome::Completed);
        w.tick(1);
        if ended {
            assert_eq!(w.state(o), Terminated, "{what}");
        } else {
            assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}");
        }
        assert_eq!(w.ended(c), (Aborted, Cause::AbortAll), "{what}");
        w.check(&what);
        accepted.borrow_mut().push(ended);
    });
    // The end opens and commits in one section; the report of its end takes another.
    assert_eq!(accepted.into_inner(), [false, true], "end");
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
    let setup = move || caller_and_blocked::<InterleavedCoarse, N, B>(layout, behaviour);
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
    let setup = move || exception_pending_owner_aborted::<InterleavedCoarse, N, B>(layout, all);
    let count = sections(setup, |(w, _, e)| {
        Port::take_start(w.seq, *e, w.tag, Waker::noop());
    });
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, abort-all {all}, k={k}");
        let (waker, wakes) = counting();
        interleaved::at(k, move || w.tick(2));
        let taken = Port::take_start(w.seq, e, w.tag, &waker);
        let after = or_after(k, || w.tick(2));
        let cause = if all { Cause::AbortAll } else { Cause::Abort };
        match taken {
            Some(_) if after => {
                assert_eq!(woken(&wakes), 1, "{what}: the abort woke E's lane");
            }
            Some(_) => {}
            None => assert!(!after, "{what}: the start was there"),
        }
        exception_aborted_with_owner(&what, &w, o, e, taken, cause);
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
        Port::start_main(w.seq, *g).unwrap();
    });
    every_k(count + 1, |k| {
        let (w, r, g) = setup();
        let what = format!("{layout:?}, k={k}");
        interleaved::at(k, move || w.tick(1));
        assert_eq!(Port::start_main(w.seq, g).map(drop), Ok(()), "{what}");
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

/// After an abort-all: C, started by O (`started`), was aborted with the rest, or its start
/// was refused (O begins nothing more) and C never ran.
fn child_aborted_all_or_refused<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
    o: SeqId,
    c: SeqId,
    started: Result<(), Error>,
    what: &str,
) {
    match started {
        Ok(()) => assert_eq!(w.ended(c), (Aborted, Cause::AbortAll), "{what}: C"),
        Err(err) => {
            assert_eq!(err, Error::NotRunning(o), "{what}");
            assert_eq!(w.state(c), Idle, "{what}: C");
        }
    }
}
