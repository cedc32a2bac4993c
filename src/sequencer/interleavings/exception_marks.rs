//! `exception_is_active` of a run stopped during its exception (a cold review of session
//! 56's fixes, the last one): restarted or aborted for another exception (a child's
//! `…CallerOfOwner` monitor), the mark names that one; for its own (an escalated restart,
//! a caller behaviour of its own monitor), it stays. The caller a `…CallerOfOwner`
//! behaviour stops is marked too (the specification's 1.3.1, as EEROS's
//! `setActiveException`; session 58). And a refused join beside another join of the same
//! action.

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// O (its monitor M0, `AbortOwner`, with exception sequence E) runs C blocking; C's
/// monitor M1 (`RestartCallerOfOwner`, no exception sequence) is armed by `c_fault`.
/// The tick at 1 ms fires M0: E is started and taken, O is held. Returns the world, O, C,
/// E, C's flag, M1's cause.
#[allow(clippy::type_complexity)]
fn owner_excepting_child_restarts<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    c_behaviour: Behaviour,
) -> (
    World<L, N, B>,
    SeqId,
    SeqId,
    SeqId,
    &'static AtomicBool,
    Cause,
) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let c = w.seq("C");
    let e = w.seq("E");
    let o_fault = flag_of(true);
    let c_fault = flag_of(false);
    w.monitor(o, o_fault, Behaviour::AbortOwner, Some(e));
    let m1 = w.monitor(c, c_fault, c_behaviour, None);
    w.start_taken(o);
    w.blocking(c, o).unwrap();
    w.tick(1);
    o_fault.store(false, Ordering::Relaxed);
    let _ = w.try_take(e);
    assert_eq!(w.state(e), Running, "E runs");
    assert!(w.handle(o).exception_is_active(), "O excepting");
    (w, o, c, e, c_fault, m1)
}

/// C's monitor restarts O (C's caller) while O's own exception (M0) is handled. O is
/// `Restarting` for C's monitor, not for its own exception, and M0 is no longer handled
/// (E went down with O's round, or its end no longer applies anything): O's active
/// exception is M1, which restarts it (`Handle::exception_is_active`: the caller a
/// `…CallerOfOwner` behaviour restarts is marked).
fn restarted_for_another_cause<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let (w, o, c, _e, c_fault, m1) =
        owner_excepting_child_restarts::<L, N, B>(layout, Behaviour::RestartCallerOfOwner);
    c_fault.store(true, Ordering::Relaxed);
    w.tick(2);
    let h = w.handle(o);
    let what = name::<L>(layout, format_args!("restart for C's monitor"));
    assert_eq!(w.state(o), Restarting, "{what}: O restarting");
    assert_ne!(w.ended(o).1, M0, "{what}: O restarted for C's monitor");
    assert!(
        h.exception_is_active(),
        "{what}: O is Restarting for C's monitor (E {:?})",
        w.state(_e),
    );
    assert_eq!(h.active_exception(), Some(m1), "{what}");
    let _ = c;
}

#[test]
fn a_run_restarted_by_a_child_s_monitor_during_its_exception_names_that_one() {
    every_world!(restarted_for_another_cause);
}

/// The same with C's monitor aborting O (`AbortCallerOfOwner`): O `Aborted` for M1, its
/// active exception M1.
fn aborted_for_another_cause<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let (w, o, _c, _e, c_fault, m1) =
        owner_excepting_child_restarts::<L, N, B>(layout, Behaviour::AbortCallerOfOwner);
    c_fault.store(true, Ordering::Relaxed);
    w.tick(2);
    let h = w.handle(o);
    let what = name::<L>(layout, format_args!("abort for C's monitor"));
    assert_eq!(w.state(o), Aborted, "{what}");
    assert!(h.exception_is_active(), "{what}");
    assert_eq!(h.active_exception(), Some(m1), "{what}");
    w.check(&what);
}

#[test]
fn a_run_aborted_by_a_child_s_monitor_during_its_exception_names_that_one() {
    every_world!(aborted_for_another_cause);
}

/// O's `RestartOwner` monitor (limit 0: escalates at once) with exception sequence E:
/// after E's end, O is aborted by the escalated restart, for its own exception:
/// `exception_is_active` stays (semantics 3).
fn escalated_restart<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let e = w.seq("E");
    let fault = flag_of(true);
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(move |_: &(), _: Instant| {
            fault.load(Ordering::Relaxed)
        }));
    let m = Monitor::new("m", condition, Behaviour::RestartOwner)
        .exception(e)
        .restart_limit(0);
    let cause = Cause::Monitor(w.monitors.borrow_mut().add(o, m).unwrap());
    w.start_taken(o);
    w.tick(1);
    fault.store(false, Ordering::Relaxed);
    w.take(e);
    assert!(w.complete(e));
    w.tick(2);
    let what = name::<L>(layout, format_args!("escalated"));
    assert_eq!(w.ended(o), (Aborted, cause), "{what}");
    assert!(w.handle(o).exception_is_active(), "{what}");
    assert_eq!(w.handle(o).active_exception(), Some(cause), "{what}");
    w.check(&what);
}

#[test]
fn a_run_aborted_by_an_escalated_restart_keeps_its_exception_active() {
    every_world!(escalated_restart);
}

/// P runs O blocking; O's `AbortCallerOfOwner` monitor fires (no exception sequence): P
/// is torn down for O's monitor, O with it as its blocking child, for its own exception:
/// O's `exception_is_active` stays; P, the behaviour's target, is marked with O's monitor
/// (the specification's 1.3.1: aborted because of an exception).
fn caller_of_owner<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let w = World::<L, N, B>::new(layout);
    let p = w.seq("P");
    let o = w.seq("O");
    let cause = w.monitor(o, flag_of(true), Behaviour::AbortCallerOfOwner, None);
    w.start_taken(p);
    w.blocking(o, p).unwrap();
    w.tick(1);
    let what = name::<L>(layout, format_args!("caller of owner"));
    assert_eq!(w.ended(o), (Aborted, cause), "{what}: O");
    assert_eq!(w.ended(p), (Aborted, cause), "{what}: P");
    assert!(w.handle(o).exception_is_active(), "{what}: O");
    assert!(w.handle(p).exception_is_active(), "{what}: P");
    assert_eq!(w.handle(p).active_exception(), Some(cause), "{what}: P");
    w.check(&what);
}

#[test]
fn a_blocking_owner_aborted_with_its_caller_by_its_own_monitor_keeps_its_exception_active() {
    every_world!(caller_of_owner);
}

/// J's action waits in joins of X (pending) and of Y at once (`futures::join!`); Y joins
/// J. J's first poll of its join of Y closes a cycle and is refused (`join_decided`); X's
/// lane, above, joins J before each section `k` of that poll (or after it). Then J's
/// executor polls its join of X again (woken or not: `join!` polls it after the refused
/// one's result). Never a deadlock: X's join of J and J's join of X are not both
/// pending; not both refused either (one cycle, one refusal: semantics 14 refuses the
/// join that closes it).
fn refused_join_beside_another<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [x, y, j] = ["X", "Y", "J"].map(|n| w.seq(n));
        let xj: &'static RefCell<Joiner> =
            Box::leak(Box::new(RefCell::new(Joiner::started(&w, x))));
        let yj: &'static RefCell<Joiner> =
            Box::leak(Box::new(RefCell::new(Joiner::started(&w, y))));
        let jx: &'static RefCell<Joiner> =
            Box::leak(Box::new(RefCell::new(Joiner::started(&w, j))));
        let jy: &'static RefCell<Joiner> = Box::leak(Box::new(RefCell::new(Joiner {
            id: j,
            run: None,
            wakes: jx.borrow().wakes.clone(),
        })));
        assert!(yj.borrow_mut().poll(&w, j).is_pending(), "Y joins J");
        assert!(jx.borrow_mut().poll(&w, x).is_pending(), "J joins X");
        (w, [x, y, j], [xj, jx, jy])
    };
    let count = sections(setup, |(w, [_, y, _], [_, _, jy])| {
        let _ = jy.borrow_mut().poll(w, *y);
    });
    every_k(count + 1, |k| {
        let (w, [x, y, j], [xj, jx, jy]) = setup();
        let x_result: &'static RefCell<Option<Poll<Result<Outcome, Error>>>> =
            Box::leak(Box::new(RefCell::new(None)));
        let lane = move || {
            *x_result.borrow_mut() = Some(xj.borrow_mut().poll(&w, j));
        };
        interleaved::at(k, lane);
        let refused = jy.borrow_mut().poll(&w, y);
        or_after(k, lane);
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(
            refused,
            Poll::Ready(Err(Error::JoinWouldDeadlock(y))),
            "{what}"
        );
        let j_of_x = jx.borrow_mut().poll(&w, x);
        let x_of_j = (*x_result.borrow()).unwrap();
        assert!(
            !(j_of_x.is_pending() && x_of_j.is_pending()),
            "{what}: deadlock: X waits for J and J for X"
        );
        assert!(
            !(j_of_x.is_ready() && x_of_j.is_ready()),
            "{what}: both refused: J of X {j_of_x:?}, X of J {x_of_j:?}"
        );
        w.check(&what);
    });
}

#[test]
fn a_refused_join_beside_another_join_of_the_same_action() {
    every_world!(refused_join_beside_another);
}
