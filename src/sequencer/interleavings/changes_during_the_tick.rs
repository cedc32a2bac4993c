//! Changes made while the tick is under way, against the tick's reading of them: a
//! timeout switched off by a lane above the tick before the section that marks it (it
//! does not fire: the mark judges it again), and a restart, of its class's only member,
//! taken up by its lane around a tick (the class keeps its grid).

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// A (polled every ms, a 5 ms timeout) runs from 0; the ticks at 1 to 4 ms found nothing.
/// Returns the world and A.
fn timed_a<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let a = w.timed("A", 5);
    w.start_taken(a);
    for ms in 1..=4 {
        w.tick(ms);
    }
    (w, a)
}

/// The tick at 5 ms, where A's timeout runs out; a lane above the tick switches the
/// timeout off with `Handle::set_timeout(None)` before section `k` of that tick (with the
/// portable lock any task may call anything between two sections). `Handle::set_timeout`
/// changes an armed run's timeout at once (semantics 6). The tick decides to fire in the
/// section that disarms the timeout it judged run out: a call before that section (A
/// still `Running` and armed, no exception marked, no `Fired` record) comes first, and A
/// is never aborted by the timeout it switched off; a call after it is the next run's,
/// and A is aborted by its timeout at 5 ms.
fn switched_off_before_its_mark<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = || timed_a::<L, N, B>(layout);
    let count = sections(setup, |(w, _)| w.tick(5));
    every_k(count, |k| {
        let (w, a) = setup();
        let before_any_firing: Rc<Cell<Option<bool>>> = Rc::default();
        let seen = Rc::clone(&before_any_firing);
        interleaved::at(k, move || {
            let decided = w.state(a) != Running
                || !w.in_set(Set::Armed, a)
                || w.in_set(Set::Excepting, a)
                || w.fired(a, Cause::Timeout(a)) > 0;
            assert_eq!(w.kept(a).set_timeout(None), Ok(()));
            seen.set(Some(!decided));
        });
        w.tick(5);
        let what = name::<L>(
            layout,
            format_args!("set_timeout(None) before section {k} of {count}"),
        );
        for ms in 6..=20 {
            w.tick(ms);
        }
        let expected = match before_any_firing.get() {
            Some(true) => (Running, 0),
            _ => (Aborted, 1),
        };
        assert_eq!(
            (w.state(a), w.fired(a, Cause::Timeout(a))),
            expected,
            "{what}"
        );
        w.check(&what);
    });
}

/// Every world (with a coarse lock the raise's steps are one section).
#[test]
fn a_timeout_switched_off_by_a_lane_above_the_tick_before_its_mark_does_not_fire() {
    every_world!(switched_off_before_its_mark);
}

/// R (polled every 10 ms, alone in its class; monitors: `RestartOwner` on `jam`, then
/// `AbortOwner` on `end_stop`) runs from 0, so its grid is 10, 20, 30 ms. `jam` holds at
/// the tick at 10 ms only: R is `Restarting` from 10 ms, and its lane does not take the
/// restart up (the ticks at 11 to 14 ms fold it so). `end_stop` holds from 16 ms on.
fn restarting_alone<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, &'static AtomicBool) {
    let w = World::<L, N, B>::new(layout);
    let r = w.add(SeqConfig::new("R").polling(Duration::from_millis(10)));
    let (jam, end_stop) = (flag_of(true), flag_of(false));
    w.monitor(r, jam, Behaviour::RestartOwner, None);
    w.monitor(r, end_stop, Behaviour::AbortOwner, None);
    w.start_taken(r);
    w.tick(10);
    assert_eq!(w.state(r), Restarting);
    jam.store(false, Ordering::Relaxed);
    for ms in 11..=14 {
        w.tick(ms);
    }
    (w, r, end_stop)
}

/// R's lane takes the restart up (at 14 ms) while the tick at 15 ms preempts it before
/// section `k` of the restart (or comes after it). The restart joins the grid R kept
/// while restarting (semantics 1: no restart moves the grid, also of the class's only
/// member): R's first poll after it is at 20 ms, where the end stop aborts it, whatever
/// `k`.
fn restart_taken_up_around_a_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = || restarting_alone::<L, N, B>(layout);
    let count = sections(setup, |(w, r, _)| w.seq.restart(w.run(*r)));
    every_k(count + 1, |k| {
        let (w, r, end_stop) = setup();
        interleaved::at(k, move || w.tick(15));
        w.seq.restart(w.run(r));
        or_after(k, move || w.tick(15));
        let what = name::<L>(layout, format_args!("tick before section {k} of {count}"));
        assert_eq!(w.state(r), Running, "{what}");
        end_stop.store(true, Ordering::Relaxed);
        let aborted_at = w.runs_until(r, 16, 40);
        assert_eq!((aborted_at, w.ended(r)), (20, (Aborted, M1)), "{what}");
        w.check(&what);
    });
}

/// Every world.
#[test]
fn a_restart_taken_up_during_a_tick_keeps_the_grid_of_its_class() {
    every_world!(restart_taken_up_around_a_tick);
}

/// O (a 5 ms timeout) runs from 0 with its blocking child C (polled every ms, waiting for
/// a polled condition, its lane took every due poll so far). A lane above the tick
/// requests O's abort before section `k` of the tick at 5 ms, where O's timeout runs out.
/// Unless the tick marked O's exception (the hold: semantics 1 and 3, a hold skips the
/// untaken due polls of the held sequence's blocking children), C's poll due at 5 ms
/// stands, as it does when the request comes before the tick.
fn child_poll_beside_an_abort_request_during_the_raise<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let o = w.timed("O", 5);
        let c = w.seq("C");
        w.start_taken(o);
        w.blocking(c, o).unwrap();
        let waits = |w: &World<L, N, B>| {
            let run = w.run(c);
            w.seq.with(|s| s.set_poll_wait(run, true));
        };
        waits(&w);
        for ms in 1..=4 {
            w.tick(ms);
            waits(&w);
        }
        (w, o, c)
    };
    let count = sections(setup, |(w, _, _)| w.tick(5));
    every_k(count + 1, |k| {
        let (w, o, c) = setup();
        interleaved::at(k, move || {
            let _ = w.kept(o).abort();
        });
        w.tick(5);
        or_after(k, move || {
            let _ = w.kept(o).abort();
        });
        let what = name::<L>(layout, format_args!("abort before section {k} of {count}"));
        // O still running, its abort requested for the next tick, and not held by the tick.
        let unheld = w.state(o) == Running && !w.in_set(Set::Excepting, o);
        assert_eq!(
            (unheld, w.in_set(Set::PollDue, c)),
            (unheld, unheld),
            "{what}: fired {}",
            w.fired(o, Cause::Timeout(o))
        );
    });
}

/// Every world.
#[test]
fn a_childs_due_poll_stands_when_its_callers_abort_request_comes_before_the_mark() {
    every_world!(child_poll_beside_an_abort_request_during_the_raise);
}
