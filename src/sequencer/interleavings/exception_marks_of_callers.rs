//! The caller a `…CallerOfOwner` behaviour stops is marked `exception_is_active` (session
//! 58), under a cold review: the races between the teardown's placing of its target and the
//! move, a caller's own pending behaviour once a child's caller behaviour overwrote its
//! `active_exception`, and a mark left over from a restart that a later teardown from above
//! reads.

use super::*;
use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// C (main) started O non-blocking and runs on; O's monitor M (`behaviour`, a caller
/// behaviour, no exception sequence) fires in the tick at 1 ms and tears C down. A lane of
/// higher priority than the tick ends C's run (completed) before section `k` of that tick
/// (or after it), without starting it again. Where C's run completed, no exception acted
/// on it: `exception_is_active` false and `active_exception` None (as before the change,
/// and as the rustdoc says: "`active_exception` keeps naming the last exception", and C
/// had none).
fn caller_completed_between_mark_and_move<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let (c, o) = (w.seq("C"), w.seq("O"));
        let m = w.monitor(o, flag_of(true), behaviour, None);
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o, m)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, o, m) = setup();
        let end = move || {
            let _ = w.complete(c);
        };
        interleaved::at(k, end);
        w.tick(1);
        or_after(k, end);
        w.tick(2);
        let what = name::<L>(layout, format_args!("{behaviour:?}, k={k} of {count}"));
        let h = w.handle(c);
        if w.state(c) == Terminated {
            assert_eq!(
                w.handle(c).last_outcome(),
                Some(Outcome::Completed),
                "{what}"
            );
            // The teardown lost its race to the caller's own end: no exception acted on
            // that run, and none is named (the mark comes with the move; a first form of
            // the change marked it when the teardown placed it).
            assert_eq!(
                (h.exception_is_active(), h.active_exception()),
                (false, None),
                "{what}: C completed, its trace {:?}; O {:?}",
                w.transitions(c),
                w.transitions(o)
            );
        } else {
            assert_eq!(w.ended(c).1, m, "{what}");
            assert!(h.exception_is_active(), "{what}");
            assert_eq!(h.active_exception(), Some(m), "{what}");
        }
        w.check_tree(&what);
    });
}

fn caller_completed_abort<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    caller_completed_between_mark_and_move::<L, N, B>(layout, Behaviour::AbortCallerOfOwner);
}

fn caller_completed_restart<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    caller_completed_between_mark_and_move::<L, N, B>(layout, Behaviour::RestartCallerOfOwner);
}

/// Under the portable lock only: with a coarse lock (the tick at the ceiling) no lane runs
/// during the tick.
macro_rules! fine_worlds {
    ($f:ident) => {{
        $f::<Interleaved, 8, 1>(Layout::One);
        $f::<Interleaved, 64, 2>(Layout::Second);
    }};
}

#[test]
fn a_caller_that_completes_before_an_abort_caller_of_owner_moves_it_names_no_exception() {
    fine_worlds!(caller_completed_abort);
}

#[test]
fn a_caller_that_completes_before_a_restart_caller_of_owner_moves_it_names_no_exception() {
    fine_worlds!(caller_completed_restart);
}

/// The same race, C's run dropped by its lane (`Port::abandon`: aborted, `Dropped`) before
/// section `k`: C aborted for `Dropped` (not the exception) reads `exception_is_active`
/// false; its `active_exception`, for a run no exception acted on, None.
fn caller_dropped_between_mark_and_move<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let (c, o) = (w.seq("C"), w.seq("O"));
        let m = w.monitor(o, flag_of(true), Behaviour::AbortCallerOfOwner, None);
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o, m)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, _o, m) = setup();
        let drop_run = move || Port::abandon(w.seq, c, &());
        interleaved::at(k, drop_run);
        w.tick(1);
        or_after(k, drop_run);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let h = w.handle(c);
        let (state, cause) = w.ended(c);
        assert_eq!(state, Aborted, "{what}");
        if cause == Cause::Dropped {
            assert!(!h.exception_is_active(), "{what}");
            // As above: the run dropped, not aborted by M, does not name M.
            assert_eq!(
                h.active_exception(),
                None,
                "{what}: C aborted for Dropped names {:?}",
                h.active_exception()
            );
        } else {
            assert_eq!(cause, m, "{what}");
            assert!(h.exception_is_active(), "{what}");
        }
        w.check_tree(&what);
    });
}

#[test]
fn a_caller_dropped_before_an_abort_caller_of_owner_moves_it_names_no_exception() {
    fine_worlds!(caller_dropped_between_mark_and_move);
}

/// O (registered first: the lower id) runs blocking in P (main). P's own monitor M0
/// (`AbortOwner`, exception sequence EP) fires at 1 ms; O's monitor M1
/// (`RestartCallerOfOwner`, exception sequence EO) at 2 ms (O is held, its monitors still
/// watch). EP and EO both end before the tick at 3 ms, which applies the behaviours in the
/// order of their owners' ids: O's first restarts P (marking P with M1, EP aborted with
/// P's round), then P's own pending `AbortOwner` must not be applied (it went with the
/// round), nor with M1 as its cause. P's lane, above the tick, takes the restart up before
/// section `k` of that tick (or after it). Whatever `k`: P runs its new round, never
/// aborted, unmarked; its active exception names M1.
fn own_pending_behaviour_after_a_child_s_restart<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let p = w.seq("P");
        let ep = w.seq("EP");
        let eo = w.seq("EO");
        let p_fault = flag_of(true);
        let o_fault = flag_of(false);
        let m0 = w.monitor(p, p_fault, Behaviour::AbortOwner, Some(ep));
        let m1 = w.monitor(o, o_fault, Behaviour::RestartCallerOfOwner, Some(eo));
        assert_eq!((m0, m1), (M0, M1));
        w.start_taken(p);
        w.blocking(o, p).unwrap();
        w.tick(1);
        w.take(ep);
        assert!(w.handle(p).exception_is_active());
        o_fault.store(true, Ordering::Relaxed);
        w.tick(2);
        w.take(eo);
        assert!(w.handle(o).exception_is_active(), "O's M1 fired");
        // Both conditions clear: the new round's monitors fire no more.
        p_fault.store(false, Ordering::Relaxed);
        o_fault.store(false, Ordering::Relaxed);
        assert!(w.complete(eo));
        assert!(w.complete(ep));
        (w, o, p)
    };
    let count = sections(setup, |(w, ..)| w.tick(3));
    every_k(count + 1, |k| {
        let (w, o, p) = setup();
        let take_up = move || {
            if w.state(p) == Restarting {
                w.seq.restart(w.run(p));
            }
        };
        interleaved::at(k, take_up);
        w.tick(3);
        or_after(k, take_up);
        take_up();
        w.tick(4);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        assert_eq!(w.state(p), Running, "{what}: P {:?}", w.transitions(p));
        assert_eq!(w.moves(p, Running, Aborting), 0, "{what}");
        assert_eq!(w.moves(p, Running, Restarting), 1, "{what}");
        assert_eq!(w.ended(p).1, M1, "{what}: the restart's cause");
        let h = w.handle(p);
        assert!(!h.exception_is_active(), "{what}");
        assert_eq!(h.active_exception(), Some(M1), "{what}");
        assert_eq!(w.ended(o), (Aborted, M1), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_caller_s_own_pending_behaviour_goes_with_the_round_a_child_s_monitor_restarted() {
    every_world!(own_pending_behaviour_after_a_child_s_restart);
}

/// Q (main) started P non-blocking; P runs O blocking. O's monitor M
/// (`RestartCallerOfOwner`, no exception sequence) restarts P at 1 ms: P is marked with M
/// (`Restarting`), and its new round runs unmarked (`exception_is_active` false) but
/// keeps `active_exception` = M. P's new round leaves O alone; Q starts O non-blocking
/// (O's caller is now Q), and M fires again at 4 ms: it restarts Q, and P, below Q, is
/// aborted by that teardown from above (rustdoc of `exception_is_active`: "sequences below
/// the behaviour's target are aborted by the teardown from above, not marked").
fn stale_mark_read_by_a_teardown_from_above<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let w = World::<L, N, B>::new(layout);
    let q = w.seq("Q");
    let p = w.seq("P");
    let o = w.seq("O");
    let fault = flag_of(false);
    let m = w.monitor(o, fault, Behaviour::RestartCallerOfOwner, None);
    w.start_taken(q);
    w.in_lane(p, q).unwrap();
    w.take(p);
    w.blocking(o, p).unwrap();
    w.tick(1);
    fault.store(true, Ordering::Relaxed);
    w.tick(2);
    let what = name::<L>(layout, format_args!("stale mark"));
    assert_eq!(w.ended(p), (Restarting, m), "{what}");
    assert!(
        w.handle(p).exception_is_active(),
        "{what}: restarting for M"
    );
    assert_eq!(w.ended(o), (Aborted, m), "{what}");
    fault.store(false, Ordering::Relaxed);
    w.seq.restart(w.run(p));
    assert_eq!(w.state(p), Running, "{what}");
    assert!(
        !w.handle(p).exception_is_active(),
        "{what}: new round unmarked"
    );
    w.tick(3);
    // Q starts O in O's lane: O's caller is Q.
    w.in_lane(o, q).unwrap();
    w.take(o);
    assert_eq!(w.caller(o), Some(q), "{what}");
    w.tick(4);
    fault.store(true, Ordering::Relaxed);
    w.tick(5);
    assert_eq!(w.ended(q), (Restarting, m), "{what}: Q restarted by M");
    assert_eq!(w.ended(p), (Aborted, m), "{what}: P aborted from above");
    // P, aborted by the teardown of Q from above, is not marked: its `active_exception`
    // still names M from the restart of its earlier round, but that round's mark went
    // with it (`ControlBlock::end_round`).
    assert!(
        !w.handle(p).exception_is_active(),
        "{what}: P, aborted from above, reads exception_is_active (active {:?})",
        w.handle(p).active_exception()
    );
    w.check(&what);
}

#[test]
fn a_run_aborted_from_above_by_the_monitor_that_restarted_it_before_is_not_marked() {
    every_world!(stale_mark_read_by_a_teardown_from_above);
}
