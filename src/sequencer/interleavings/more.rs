//! Systematic interleavings, second round: where [`fine`](super::fine) did not look,
//! under the portable lock ([`Interleaved`]).
//!
//! 1. A lane taking its start (`Port::take_start`) or dropped while it waits
//!    (`Port::abandon_start`), against a tick that fires on or aborts the started run.
//! 2. Pause and resume requests against a tick whose `PauseOwner` monitor holds or lets go,
//!    and the reverse; the run's clock checked by a timeout's exact expiry.
//! 3. Joins against the end, abort and restart of the joined run, one and two joiners,
//!    with counting wakers.
//! 4. Sequencers of two words (the multi-word sets, indexes and `by_depth` candidates).
//! 5. Exception sequences: the end of E reported to its owner exactly once.
//!
//! [`Interleaved`]: crate::lock::interleaved::Interleaved

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use crate::sequencer::inbox::abort_all_posted;

/// The world every test here uses: the portable interleaving lock, `N` sequences in `B`
/// words.
type World<const N: usize, const B: usize> = super::World<Interleaved, N, B>;

// =======================================================================================
// 1. A lane taking its start, or dropped while it waits, against the tick.
// =======================================================================================

/// O's lane takes its start while the tick aborts O (monitor, timeout, request,
/// abort-all), restarts it, pauses it, or holds it for its exception sequence.
#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone() {
    for tick in TICKS {
        take_during_tick::<Interleaved, 8, 1>(Layout::One, tick);
    }
}

/// The same in a sequencer of two words, O in the second (E in the first or second).
#[test]
fn a_start_taken_while_the_tick_stops_the_run_is_taken_once_or_gone_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for tick in TICKS {
            take_during_tick::<Interleaved, 64, 2>(layout, tick);
        }
    }
}

#[test]
fn a_lane_dropped_while_the_tick_fires_on_its_pending_start_leaves_nothing_under_way() {
    for tick in TICKS {
        abandon_during_tick::<Interleaved, 8, 1>(Layout::One, tick);
        abandon_during_tick::<Interleaved, 64, 2>(Layout::Second, tick);
        abandon_during_tick::<Interleaved, 64, 2>(Layout::Split, tick);
    }
}

/// O's monitor fired at 1 ms and started its exception sequence E (`AbortOwner`), whose
/// start E's lane has not taken. The tick at 2 ms aborts O (a request, or an abort-all),
/// and so E below it; E's lane takes its start before each section of that tick. The
/// lane takes E's run and finds it aborted, or finds nothing; O and E are aborted by the
/// request (or abort-all), the tick at 3 ms reports E's end to the aborted O and changes
/// nothing, and E may be started again.
#[test]
fn an_exception_sequences_start_taken_while_the_tick_aborts_its_owner() {
    for all in [false, true] {
        let setup = move || exception_pending_owner_aborted::<Interleaved, 8, 1>(Layout::One, all);
        let count = sections(setup, |(w, _, _)| w.tick(2));
        every_k(count, |k| {
            let (w, o, e) = setup();
            let what = format!("abort-all {all}, k={k}");
            let taken = Rc::new(RefCell::new(None));
            let out = taken.clone();
            interleaved::at(k, move || {
                *out.borrow_mut() = Some(Port::take_start(w.seq, e, w.tag, Waker::noop()));
            });
            w.tick(2);
            let cause = if all { Cause::AbortAll } else { Cause::Abort };
            let taken = taken.borrow().expect("the lane ran");
            exception_aborted_with_owner(&what, &w, o, e, taken, cause);
        });
    }
}

// =======================================================================================
// 2. Pause and resume requests against a tick whose `PauseOwner` monitor holds or lets go.
// =======================================================================================

/// Who is inserted into whom.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Into {
    /// The request (a lane of higher priority) before section `k` of the tick.
    RequestIntoTick,
    /// The tick before section `k` of the request.
    TickIntoRequest,
}

/// Runs `ask` of O and the tick at `ms` interleaved as `into` for every `k`, on worlds from
/// `setup`; then `expect(k, result, w, o, flag)`.
fn around_tick<const N: usize, const B: usize>(
    setup: impl Fn() -> (World<N, B>, SeqId, &'static AtomicBool),
    a: Ask,
    ms: u64,
    into: Into,
    expect: impl Fn(&str, Result<(), Error>, &World<N, B>, SeqId, &'static AtomicBool),
) {
    let count = match into {
        Into::RequestIntoTick => sections(&setup, |(w, _, _)| w.tick(ms)),
        // An accepted request takes three sections (check, record, queue); a refused one
        // one, and then the tick comes after it.
        Into::TickIntoRequest => 3,
    };
    every_k(count, |k| {
        let (w, o, on) = setup();
        let what = format!("{:?}, {a:?}, {into:?}, k={k}", w.layout);
        let h = w.handle(o);
        let result = match into {
            Into::RequestIntoTick => {
                let asked = Rc::new(RefCell::new(None));
                let out = asked.clone();
                interleaved::at(k, move || {
                    *out.borrow_mut() = Some(match a {
                        Ask::Pause => h.pause(),
                        Ask::Resume => h.resume(),
                    })
                });
                w.tick(ms);
                let r = asked.borrow().expect("the lane ran");
                r
            }
            Into::TickIntoRequest => {
                interleaved::at(k, move || w.tick(ms));
                let r = match a {
                    Ask::Pause => h.pause(),
                    Ask::Resume => h.resume(),
                };
                if !inserted(k) {
                    interleaved::at(usize::MAX, || {});
                    w.tick(ms);
                }
                r
            }
        };
        expect(&what, result, &w, o, on);
        w.check(&what);
    });
}

/// O's `PauseOwner` monitor holds from 1 ms; a pause of O is requested by a lane of
/// higher priority before each section of that tick. Accepted (O still running when
/// checked), the request's pause outlasts the monitor: O stays paused when the condition
/// clears (2 ms) until a resume request (applied at 4 ms); refused (`AlreadyPaused`: the
/// monitor paused O first), O resumes when the condition clears. While the monitor holds,
/// a resume request is `HeldByMonitor`. O's clock stops while paused: its 5 ms timeout,
/// 1 ms used at the pause, runs out 4 ms after the resume, at exactly 8 ms or 6 ms.
fn pause_request_into_holding_tick<const N: usize, const B: usize>(layout: Layout) {
    around_tick(
        || pausable::<Interleaved, N, B>(layout, true, false, false),
        Ask::Pause,
        1,
        Into::RequestIntoTick,
        |what, asked, w, o, on| {
            assert_eq!(w.state(o), Paused, "{what}");
            assert_eq!(
                ask(w, o, Ask::Resume),
                Err(Error::HeldByMonitor(o)),
                "{what}"
            );
            on.store(false, Ordering::Relaxed);
            w.tick(2);
            w.tick(3);
            match asked {
                Ok(()) => {
                    assert_eq!(w.state(o), Paused, "{what}: the request's pause");
                    assert_eq!(ask(w, o, Ask::Resume), Ok(()), "{what}");
                    w.tick(4);
                    assert_eq!(w.state(o), Running, "{what}: resumed");
                    assert_eq!(w.runs_until(o, 5, 20), 8, "{what}: the timeout");
                }
                Err(e) => {
                    assert_eq!(e, Error::AlreadyPaused(o), "{what}");
                    assert_eq!(w.state(o), Running, "{what}: released");
                    assert_eq!(w.runs_until(o, 4, 20), 6, "{what}: the timeout");
                }
            }
            assert_eq!(w.ended(o), (Aborted, Cause::Timeout(o)), "{what}");
            assert_eq!(w.moves(o, Running, Paused), 1, "{what}");
            assert_eq!(w.moves(o, Paused, Running), 1, "{what}");
        },
    );
}

#[test]
fn a_pause_requested_during_a_holding_tick_outlasts_the_monitor_iff_accepted() {
    pause_request_into_holding_tick::<8, 1>(Layout::One);
    pause_request_into_holding_tick::<64, 2>(Layout::Second);
}

/// O was paused by a request at 1 ms; its `PauseOwner` monitor's condition holds from
/// 2 ms. A resume of O is requested while the tick at 2 ms evaluates the monitor (`into`
/// either way). Refused (`HeldByMonitor`: the monitor held first), the request's pause
/// stays: O stays paused after the condition clears (4 ms) until a resume request
/// (applied at 6 ms). Accepted, it lifts the request's pause (carried out now or when the
/// monitor lets go): O resumes when the condition clears, at 4 ms. O's clock: 1 ms used,
/// O was paused by a request at 1 ms; its `PauseOwner` monitor's condition holds from
/// 2 ms. A resume of O is requested while the tick at 2 ms evaluates the monitor (`into`
/// either way): see [`resumed_around_holding_tick`].
fn resume_request_around_holding_tick<const N: usize, const B: usize>(layout: Layout, into: Into) {
    around_tick(
        || paused_then_held::<Interleaved, N, B>(layout),
        Ask::Resume,
        2,
        into,
        resumed_around_holding_tick,
    );
}

#[test]
fn a_resume_requested_during_a_holding_tick_lifts_the_requests_pause_iff_accepted() {
    resume_request_around_holding_tick::<8, 1>(Layout::One, Into::RequestIntoTick);
    resume_request_around_holding_tick::<64, 2>(Layout::Second, Into::RequestIntoTick);
}

#[test]
fn a_holding_tick_during_a_resume_request_lifts_the_requests_pause_iff_accepted() {
    resume_request_around_holding_tick::<8, 1>(Layout::One, Into::TickIntoRequest);
    resume_request_around_holding_tick::<64, 2>(Layout::Second, Into::TickIntoRequest);
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A
/// resume of O is requested around that tick (`into`): `HeldByMonitor` (before the
/// release), accepted (between the release's count and its move) or `NotPaused` (after
/// it). Whatever it was, O runs from 2 ms, resumed once; a resume carried out later finds
/// it running. Its timeout (1 ms used) runs out at exactly 6 ms.
fn resume_request_around_releasing_tick<const N: usize, const B: usize>(
    layout: Layout,
    into: Into,
) {
    around_tick(
        || paused_then_released::<Interleaved, N, B>(layout),
        Ask::Resume,
        2,
        into,
        |what, asked, w, o, _| {
            assert!(
                [
                    Ok(()),
                    Err(Error::HeldByMonitor(o)),
                    Err(Error::NotPaused(o))
                ]
                .contains(&asked),
                "{what}: {asked:?}"
            );
            resumed_around_releasing_tick(what, w, o);
        },
    );
}

#[test]
fn a_resume_requested_during_a_releasing_tick_resumes_once() {
    for into in [Into::RequestIntoTick, Into::TickIntoRequest] {
        resume_request_around_releasing_tick::<8, 1>(Layout::One, into);
        resume_request_around_releasing_tick::<64, 2>(Layout::Second, into);
    }
}

/// O was paused by its `PauseOwner` monitor at 1 ms; the condition clears at 2 ms. A pause
/// of O is requested around that tick (`into`), accepted either way: it keeps O paused or
/// pauses it again: see [`paused_around_releasing_tick`].
fn pause_request_around_releasing_tick<const N: usize, const B: usize>(layout: Layout, into: Into) {
    around_tick(
        || paused_then_released::<Interleaved, N, B>(layout),
        Ask::Pause,
        2,
        into,
        paused_around_releasing_tick,
    );
}

#[test]
fn a_pause_requested_around_a_releasing_tick_is_kept() {
    for into in [Into::RequestIntoTick, Into::TickIntoRequest] {
        pause_request_around_releasing_tick::<8, 1>(Layout::One, into);
        pause_request_around_releasing_tick::<64, 2>(Layout::Second, into);
    }
}

// =======================================================================================
// 3. Joins against the end, abort and restart of the joined run.
// =======================================================================================

/// What O's lane (of higher priority) does, inserted into a join.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Then {
    /// Ends O's run (completed).
    End,
    /// Ends it, and O is started again by a handle (run 2, not taken yet).
    EndAndStart,
    /// Ends it, O is started again and run 2 ends too (skipped).
    EndTwice,
}

fn end_and_then<const N: usize, const B: usize>(w: &World<N, B>, o: SeqId, then: Then) {
    assert!(w.complete(o));
    if then != Then::End {
        w.handle(o).start().unwrap();
    }
    if then == Then::EndTwice {
        w.take(o);
        assert!(w.end(o, Outcome::Skipped));
    }
}

/// O runs (run 1); J2 (with `two`) has joined run 1 (pending). J1's first poll of its join
/// of O comes with O's lane doing `then` before section `k`. J1 joins the run current at
/// the first section of its first poll (semantics 14: never a later one): run 1, ended
/// (`Completed`, also when run 2 is under way; `OutcomeLost` once run 2 has ended too), or,
/// with O's lane before that section, run 2, under way (pending, then `Skipped` once it
/// ends: J1 is released and woken) or ended (`Skipped`). J2, woken by run 1's end, gets run 1's outcome while run 1 is the last run
/// or the one before the run under way, else `OutcomeLost` (run 2 ended before J2 was
/// polled). With `k` = the count, the end comes after J1's pending first poll: J1 is as J2.
fn join_during_end<const N: usize, const B: usize>(layout: Layout, two: bool, then: Then) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let j2 = w.seq("J2");
        w.split();
        let [o, j1] = ["O", "J1"].map(|n| w.seq(n));
        w.start_taken(o);
        let mut joiners = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        if two {
            assert_eq!(joiners[1].poll(&w, o), Poll::Pending);
        }
        (w, o, joiners)
    };
    // The sections of J1's first poll.
    let count = {
        let (w, o, mut js) = setup();
        interleaved::at(usize::MAX, || {});
        assert_eq!(js[0].poll(&w, o), Poll::Pending);
        interleaved::taken()
    };
    every_k(count + 1, |k| {
        let (w, o, [mut j1, mut j2]) = setup();
        let what = format!("{layout:?}, two {two}, {then:?}, k={k}");
        let j2_wakes = woken(&j2.wakes);
        interleaved::at(k, move || end_and_then(&w, o, then));
        let j1_wakes = woken(&j1.wakes);
        let first = j1.poll(&w, o);
        let after = !inserted(k);
        if after {
            interleaved::at(usize::MAX, || {});
        }
        // A release during the poll (of run 1, before the look found run 2) wakes J1: its
        // executor polls it again.
        let first = j1.repoll(&w, o, j1_wakes, first);
        let lost_or = |outcome| match then {
            Then::EndTwice => Err(Error::OutcomeLost(o)),
            _ => Ok(outcome),
        };
        // J2, woken by run 1's end, is polled once O's lane is done.
        let mut j2_check = |w: &World<N, B>| {
            if two {
                let r = j2.released(w, o, j2_wakes, &what);
                assert_eq!(r, lost_or(Outcome::Completed), "{what}: J2");
            }
        };
        if !after {
            j2_check(&w);
        }
        if after {
            assert_eq!(first, Poll::Pending, "{what}");
            let before = woken(&j1.wakes);
            end_and_then(&w, o, then);
            assert_eq!(
                j1.released(&w, o, before, &what),
                lost_or(Outcome::Completed),
                "{what}: J1"
            );
            j2_check(&w);
        } else {
            // J1 joins the run current at its registration, the first section of its first
            // poll: run 2 only if O's lane came before it.
            let joins_run_2 = k == 0;
            match then {
                Then::End => assert_eq!(first, Poll::Ready(Ok(Outcome::Completed)), "{what}"),
                Then::EndTwice if joins_run_2 => {
                    assert_eq!(first, Poll::Ready(Ok(Outcome::Skipped)), "{what}")
                }
                Then::EndTwice => {
                    assert_eq!(first, Poll::Ready(Err(Error::OutcomeLost(o))), "{what}")
                }
                Then::EndAndStart if !joins_run_2 => {
                    assert_eq!(first, Poll::Ready(Ok(Outcome::Completed)), "{what}")
                }
                Then::EndAndStart => {
                    assert_eq!(first, Poll::Pending, "{what}: J1 joined run 2");
                    assert_eq!(j1.run, Some(2), "{what}");
                    let before = woken(&j1.wakes);
                    w.take(o);
                    assert!(w.end(o, Outcome::Skipped));
                    assert_eq!(
                        j1.released(&w, o, before, &what),
                        Ok(Outcome::Skipped),
                        "{what}: J1"
                    );
                }
            }
            assert!(!j1.joining(&w), "{what}");
        }
        w.check(&what);
    });
}

#[test]
fn a_join_during_the_end_of_the_joined_run_gets_its_outcome_or_outcome_lost() {
    for two in [false, true] {
        for then in [Then::End, Then::EndAndStart, Then::EndTwice] {
            join_during_end::<8, 1>(Layout::One, two, then);
            join_during_end::<64, 2>(Layout::Split, two, then);
        }
    }
}

/// O runs; J2 has joined O's run (pending). J1 polls its join of O and the tick at 1 ms
/// `tick`s O, interleaved `into` either way (the tick before each section of J1's poll; J1's
/// poll, a lane of higher priority, before each section of the tick). Every joiner gets
/// the outcome of the run it joined, never hangs: an abort's `Aborted(cause)` (at once, or
/// released and woken, then ready); a restart does not end the run: both wait, and get
/// `Completed` when O's lane, having restarted it, completes it.
fn join_around_tick<const N: usize, const B: usize>(layout: Layout, tick: JoinTick, into: Into) {
    let setup = move || joined::<Interleaved, N, B>(layout, tick);
    let count = match into {
        Into::TickIntoRequest => sections(setup, |(w, o, js)| {
            let mut run = None;
            let _ = port_join(w.seq, js[0].id, *o, &mut run);
        }),
        Into::RequestIntoTick => sections(setup, |(w, _, _)| w.tick(1)),
    };
    every_k(count, |k| {
        let (w, o, [j1, mut j2]) = setup();
        let what = format!("{layout:?}, {tick:?}, {into:?}, k={k}");
        let j2_wakes = woken(&j2.wakes);
        let j1 = Rc::new(RefCell::new(j1));
        let first = match into {
            Into::TickIntoRequest => {
                interleaved::at(k, move || w.tick(1));
                let first = j1.borrow_mut().poll(&w, o);
                assert!(inserted(k), "{what}");
                first
            }
            Into::RequestIntoTick => {
                let polled = Rc::new(RefCell::new(None));
                let (out, j) = (polled.clone(), j1.clone());
                interleaved::at(k, move || {
                    *out.borrow_mut() = Some(j.borrow_mut().poll(&w, o));
                });
                w.tick(1);
                let first = polled.borrow_mut().take().expect("the lane ran");
                first
            }
        };
        let mut j1 = j1.borrow_mut();
        let cause = tick.cause();
        match tick {
            JoinTick::Abort | JoinTick::Request => {
                assert_eq!(w.ended(o), (Aborted, cause), "{what}");
                let expected = Ok(Outcome::Aborted(cause));
                match first {
                    Poll::Ready(r) => assert_eq!(r, expected, "{what}: J1"),
                    Poll::Pending => {
                        // Pending at a look before the abort: released and woken by it.
                        assert!(!j1.joining(&w), "{what}: J1 not released");
                        let r = j1.poll(&w, o);
                        assert_eq!(r, Poll::Ready(expected), "{what}: J1");
                    }
                }
                let r = j2.released(&w, o, j2_wakes, &what);
                assert_eq!(r, expected, "{what}: J2");
            }
            JoinTick::Restart => {
                joined_through_a_restart(&what, &w, o, [&mut *j1, &mut j2], first);
            }
        }
        w.check(&what);
    });
}

#[test]
fn a_join_around_a_tick_that_ends_or_restarts_the_joined_run_gets_its_outcome() {
    for tick in [JoinTick::Abort, JoinTick::Request, JoinTick::Restart] {
        for into in [Into::TickIntoRequest, Into::RequestIntoTick] {
            join_around_tick::<8, 1>(Layout::One, tick, into);
            join_around_tick::<64, 2>(Layout::Split, tick, into);
        }
    }
}

/// O and Y run, O's run waiting in a join of Y; the tick at 1 ms aborts O (a request).
/// Before each section of the tick, once the tick has aborted O, a handle above the tick
/// starts O again, and (`unwound`) O's lane, above the tick, unwinds the aborted run (its
/// join dropped, `Port::finished`), takes the start, and O's new run joins Y (pending).
/// The teardown ends the aborted run's wait, and leaves the new run's alone: when Y ends,
/// O's new run is released and woken, and gets `Completed` (found by session 55's cold
/// review of joins: the teardown forgot O's wait, and released the joiners of O's run
/// current at a look taken after the abort's section, the new run).
fn join_of_a_new_run_during_the_teardown_of_the_old<const N: usize, const B: usize>(
    layout: Layout,
    unwound: bool,
) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let y = w.seq("Y");
        w.start_taken(y);
        let old = w.start_taken(o);
        assert_eq!(port_join(w.seq, o, y, &mut None), Poll::Pending);
        w.handle(o).abort().unwrap();
        let (waker, wakes) = counting();
        (w, o, y, old, waker, wakes)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count, |k| {
        let (w, o, y, old, waker, wakes) = setup();
        let what = format!("{layout:?}, unwound: {unwound}, k={k}");
        let joined = Rc::new(RefCell::new(None));
        let out = joined.clone();
        let lane = waker.clone();
        interleaved::at(k, move || {
            if w.state(o) != Aborted {
                return;
            }
            w.kept(o).start().unwrap();
            let mut run = None;
            if unwound {
                Port::stop_join(w.seq, o);
                Port::finished(w.seq, old);
                Port::take_start(w.seq, o, w.tag, &lane).unwrap();
                assert_eq!(port_join(w.seq, o, y, &mut run), Poll::Pending);
            }
            *out.borrow_mut() = Some(run);
        });
        w.tick(1);
        let Some(mut run) = joined.borrow_mut().take() else {
            // The lane came before the abort: nothing to unwind yet.
            assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}");
            assert!(
                !w.in_set(Set::Joining, o),
                "{what}: the aborted run still waits"
            );
            return;
        };
        if !unwound {
            // The aborted run's wait is over; the new run has not begun.
            assert!(
                !w.in_set(Set::Joining, o),
                "{what}: the aborted run still waits"
            );
            Port::stop_join(w.seq, o);
            Port::finished(w.seq, old);
            Port::take_start(w.seq, o, w.tag, &waker).unwrap();
            assert_eq!(port_join(w.seq, o, y, &mut run), Poll::Pending, "{what}");
        }
        assert_eq!(w.state(o), Running, "{what}");
        assert!(
            w.in_set(Set::Joining, o),
            "{what}: O's new run no longer waits for Y"
        );
        let before = woken(&wakes);
        assert!(w.complete(y), "{what}");
        assert!(
            woken(&wakes) > before,
            "{what}: O's lane not woken by Y's end"
        );
        assert_eq!(
            port_join(w.seq, o, y, &mut run),
            Poll::Ready(Ok(Outcome::Completed)),
            "{what}"
        );
        w.check(&what);
    });
}

#[test]
fn a_join_of_a_new_run_begun_during_the_teardown_of_the_old_is_kept() {
    for unwound in [false, true] {
        join_of_a_new_run_during_the_teardown_of_the_old::<8, 1>(Layout::One, unwound);
        join_of_a_new_run_during_the_teardown_of_the_old::<64, 2>(Layout::Split, unwound);
    }
}

/// O runs; J2 has joined O's run (pending). O's run is dropped (`Port::abandon`, its
/// future dropped) while J1 polls its join of O, a lane of higher priority, before each
/// section of the teardown. Both get `Aborted(Dropped)`; a pending one was released and
/// woken.
#[test]
fn a_join_during_a_dropped_runs_teardown_gets_aborted_dropped() {
    let setup = || {
        let w = World::<8, 1>::new(Layout::One);
        let [o, j1, j2] = ["O", "J1", "J2"].map(|n| w.seq(n));
        w.start_taken(o);
        let mut joiners = [Joiner::started(&w, j1), Joiner::started(&w, j2)];
        assert_eq!(joiners[1].poll(&w, o), Poll::Pending);
        (w, o, joiners)
    };
    let count = sections(setup, |(w, o, _)| Port::abandon(w.seq, *o, &()));
    every_k(count, |k| {
        let (w, o, [j1, mut j2]) = setup();
        let what = format!("k={k}");
        let j2_wakes = woken(&j2.wakes);
        let j1 = Rc::new(RefCell::new(j1));
        let polled = Rc::new(RefCell::new(None));
        let (out, j) = (polled.clone(), j1.clone());
        interleaved::at(k, move || {
            *out.borrow_mut() = Some(j.borrow_mut().poll(&w, o));
        });
        Port::abandon(w.seq, o, &());
        let first = polled.borrow_mut().take().expect("the lane ran");
        let expected = Ok(Outcome::Aborted(Cause::Dropped));
        let mut j1 = j1.borrow_mut();
        match first {
            Poll::Ready(r) => assert_eq!(r, expected, "{what}"),
            Poll::Pending => {
                assert!(!j1.joining(&w), "{what}: J1 not released");
                assert_eq!(j1.poll(&w, o), Poll::Ready(expected), "{what}");
            }
        }
        assert_eq!(j2.released(&w, o, j2_wakes, &what), expected, "{what}");
        w.check(&what);
    });
}

// =======================================================================================
// 4. Sequencers of two words: the key scenarios of `fine` again.
// =======================================================================================

/// An abort-all is requested while nothing runs; G (a main sequence) is started by a lane
/// of higher priority before section `k` of the tick at 1 ms that carries the abort-all
/// out, and G's lane takes the start and polls its run, which holds for the abort-all.
/// When G's start commits before the tick has finished looking for what to abort, G runs
/// when it looks: the tick must abort it (`AbortAll`, recorded), as it does a start made
/// during the walk of an abort-all while another sequence runs
/// (`a_start_during_the_shortcut_walk_of_an_abort_all_is_torn_down`). A start after the
/// look runs: the tick wakes its lane once the abort-all is lifted, and it goes on.
fn start_into_lone_abort_all<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let g = w.seq("G");
        w.seq.abort_all();
        (w, g)
    };
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, g) = setup();
        let what = format!("{layout:?}, k={k}");
        let h = w.handle(g);
        let seq = w.seq;
        let (waker, wakes) = counting();
        let polled = Arc::new(std::sync::Mutex::new(None));
        let first_poll = polled.clone();
        interleaved::at(k, move || {
            h.start().unwrap();
            let run = Port::take_start(seq, g, seq.tag(), &waker).unwrap();
            let held = Port::clearance(seq, run, &waker);
            *first_poll.lock().unwrap() = Some((run, held, woken(&wakes), wakes));
        });
        w.tick(1);
        assert!(inserted(k), "{what}");
        let (run, held, wakes_then, wakes) = polled.lock().unwrap().take().unwrap();

        // The tick's first section, then the abort-all's count of runs begun and its look:
        // one section, one probe per candidate (with one word every registered sequence;
        // with two the live and changed ones: none before G's start), and the count of
        // runs begun read again. A start after the look is a start after the abort-all,
        // and runs; until the section that lifts the abort-all it holds for it, and that
        // section finds a run begun and wakes the lanes.
        let looked = 3 + if B == 1 { w.count() } else { 0 };
        let lifted = looked + 1;
        let expected = if k <= lifted {
            Clearance::Hold
        } else {
            Clearance::Go
        };
        assert_eq!(held, expected, "{what}: G's first poll");
        if k <= looked {
            assert_eq!(w.ended(g), (Aborted, Cause::AbortAll), "{what}: G");
        } else {
            assert_eq!(w.state(g), Running, "{what}: G started after the abort-all");
            if k == lifted {
                assert_eq!(woken(&wakes), wakes_then + 1, "{what}: G's lane is woken");
            }
            assert_eq!(w.clearance(run), Clearance::Go, "{what}: G goes on");
        }
        w.check(&what);
    });
}

/// G runs and an abort-all is asked for; it is asked for again (the same requester)
/// before section `k` of the tick at 1 ms that carries the first out. Asked before the
/// tick took the inbox (before its first section is over), the two are one; asked after,
/// the second stays for the next tick, which aborts what was started meanwhile (G again):
/// an abort-all is never lost to the one being carried out.
fn abort_all_asked_again_during_one<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<N, B>::new(layout);
        let g = w.seq("G");
        w.start_taken(g);
        w.seq.abort_all();
        (w, g)
    };
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count, |k| {
        let (w, g) = setup();
        let what = format!("{layout:?}, k={k}");
        let seq = w.seq;
        interleaved::at(k, move || seq.abort_all());
        w.tick(1);
        assert!(inserted(k), "{what}");
        assert_eq!(w.ended(g), (Aborted, Cause::AbortAll), "{what}");
        let again = k > 0;
        assert_eq!(abort_all_posted(&w.seq.safety.inbox), again, "{what}");
        w.kept(g).start().unwrap();
        w.tick(2);
        if again {
            assert_eq!(w.ended(g), (Aborted, Cause::AbortAll), "{what}: G again");
            assert_eq!(w.aborts_all(), 2, "{what}");
        } else {
            assert_eq!(w.state(g), Running, "{what}: G again");
            assert_eq!(w.aborts_all(), 1, "{what}");
        }
        w.check(&what);
    });
}

#[test]
fn an_abort_all_asked_again_while_one_is_carried_out_stays_for_the_next_tick() {
    abort_all_asked_again_during_one::<64, 2>(Layout::Second);
    abort_all_asked_again_during_one::<8, 1>(Layout::One);
}

#[test]
fn a_start_during_a_tick_that_carries_out_an_abort_all_with_nothing_running_is_aborted() {
    start_into_lone_abort_all::<64, 2>(Layout::Second);
    start_into_lone_abort_all::<8, 1>(Layout::One);
}

#[test]
fn a_start_below_a_caller_the_tick_tears_down_is_torn_down_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for how in [Teardown::Request, Teardown::AbortAll, Teardown::Monitor] {
            for deep in [true, false] {
                lane_start_into_teardown::<Interleaved, 64, 2>(layout, how, deep);
            }
        }
    }
}

#[test]
fn an_end_during_a_firing_is_either_first_or_refused_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for firing in [
            Firing::AbortAfterE,
            Firing::RestartAfterE,
            Firing::Restart,
            Firing::Timeout,
        ] {
            end_into_firing_tick::<Interleaved, 64, 2>(layout, firing);
        }
    }
}

#[test]
fn an_end_during_a_restarting_firing_with_an_exception_sequence_is_either_first_or_refused() {
    end_into_firing_tick::<Interleaved, 8, 1>(Layout::One, Firing::RestartAfterE);
}

/// `fine`'s `tick_into_start` in two words: O (first word with `Layout::Split`) starts C
/// (second word), in C's lane or blocking, while the tick at 1 ms aborts O (its monitor,
/// an abort request) or restarts it. C is refused (`NotRunning(O)`, never ran) or torn
/// down with O.
#[test]
fn a_start_by_a_sequence_the_tick_aborts_or_restarts_never_outlives_it_in_two_words() {
    for layout in [Layout::Second, Layout::Split] {
        for (fire, owner) in [
            (Fire::Abort, (Aborted, M0)),
            (Fire::AbortRequest, (Aborted, Cause::Abort)),
            (Fire::Restart, (Restarting, M0)),
        ] {
            for how in [How::InLane, How::Blocking] {
                tick_into_start::<Interleaved, 64, 2>(layout, fire, how, |what, r, w, o, c| {
                    torn_down_with(what, r, w, o, c, owner);
                });
            }
        }
    }
}

// =======================================================================================
// 5. Exception sequences: the end of E reported to its owner exactly once.
// =======================================================================================

/// O's `RestartOwner` monitor M0 restarted O at 1 ms; its `AbortOwner` monitor M1 with
/// exception sequence E holds from 2 ms. O's lane obeys `Restart` (`Sequencer::restart`)
/// with the tick at 2 ms before section `k`. Wherever the tick lands, the restart commits
/// after it (a `Restarting` O is not evaluated at 2 ms), M1 fires once, at 3 ms, on the
/// restarted run, E runs once for O, and once E's end is folded O is aborted by M1, once.
fn restart_into_firing_tick<const N: usize, const B: usize>(layout: Layout) {
    let setup = move || restarting_before_a_firing::<Interleaved, N, B>(layout);
    let count = sections(setup, |(w, _, _, run)| w.seq.restart(*run));
    // The restart's last section comes after its commit (a paused caller's pause).
    every_k(count - 1, |k| {
        let (w, o, e, run) = setup();
        let what = format!("{layout:?}, k={k}");
        interleaved::at(k, move || w.tick(2));
        w.seq.restart(run);
        assert!(inserted(k), "{what}");
        assert_eq!(w.state(o), Running, "{what}");
        // The tick came before the restart's commit (the count of changes moved: it
        // scheduled again), so it did not evaluate the `Restarting` O: M1 fires at 3 ms.
        assert_eq!(w.state(e), Idle, "{what}");
        let ms = 3;
        w.tick(ms);
        aborted_after_e_once(&what, &w, o, e, ms);
    });
}

#[test]
fn a_restart_during_a_tick_that_fires_an_exception_sequence_is_handled_once() {
    restart_into_firing_tick::<8, 1>(Layout::One);
    restart_into_firing_tick::<64, 2>(Layout::Split);
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E runs (taken). An
/// abort of E was requested; the tick at 2 ms carries it out, and E's lane, of higher
/// priority, tries to end E (completed) before section `k` of that tick. The request holds
/// E: its end is refused and the tick aborts it, once; its end is reported to O once, and
/// O's behaviour is applied once, by the tick at 3 ms at the latest: O aborted (or
/// restarting) by the monitor; E is free again.
fn end_of_e_into_its_abort<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || exception_to_abort::<Interleaved, N, B>(layout, behaviour);
    let count = sections(setup, |(w, _, _, _)| w.tick(2));
    every_k(count, |k| {
        let (w, o, e, _) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        let ended = Rc::new(RefCell::new(None));
        let out = ended.clone();
        interleaved::at(k, move || *out.borrow_mut() = Some(w.complete(e)));
        w.tick(2);
        let ended = ended.borrow().expect("the lane ran");
        assert!(!ended, "{what}");
        assert_eq!(w.ended(e), (Aborted, Cause::Abort), "{what}");
        behaviour_applied_once(&what, &w, o, e, behaviour);
    });
}

#[test]
fn an_exception_sequence_ending_while_the_tick_aborts_it_is_reported_once() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        end_of_e_into_its_abort::<8, 1>(Layout::One, behaviour);
        end_of_e_into_its_abort::<64, 2>(Layout::Second, behaviour);
        end_of_e_into_its_abort::<64, 2>(Layout::Split, behaviour);
    }
}

/// O's `behaviour` monitor with exception sequence E fired at 1 ms; E ran to its end.
/// The tick at 2 ms reports E's end to O and applies the behaviour; O's run is dropped
/// (`Port::abandon`: its future dropped, a lane of higher priority) before section `k` of
/// that tick. O is aborted once: by the drop (`Dropped`), or, when the tick's abort came
/// first, by the monitor; a restart by the tick is followed by the drop's abort.
fn drop_into_report<const N: usize, const B: usize>(layout: Layout, behaviour: Behaviour) {
    let setup = move || exception_ended::<Interleaved, N, B>(layout, behaviour);
    let count = sections(setup, |(w, _, _)| w.tick(2));
    every_k(count, |k| {
        let (w, o, e) = setup();
        let what = format!("{layout:?}, {behaviour:?}, k={k}");
        interleaved::at(k, move || Port::abandon(w.seq, o, &()));
        w.tick(2);
        assert!(inserted(k), "{what}");
        let (state, cause) = w.ended(o);
        assert_eq!(state, Aborted, "{what}");
        let allowed: &[Cause] = match behaviour {
            Behaviour::AbortOwner => &[Cause::Dropped, M0],
            _ => &[Cause::Dropped],
        };
        assert!(allowed.contains(&cause), "{what}: {cause:?}");
        dropped_owner_once(&what, &w, o, e, cause);
    });
}

#[test]
fn a_dropped_owner_during_the_report_of_its_exception_sequences_end_is_aborted_once() {
    for behaviour in [Behaviour::AbortOwner, Behaviour::RestartOwner] {
        drop_into_report::<8, 1>(Layout::One, behaviour);
        drop_into_report::<64, 2>(Layout::Split, behaviour);
    }
}

/// A's run 1 and B run; A's `AbortOwner` monitor holds. A's lane polls its action's join
/// of B (`Cx::join`: the run's clearance, then `Port::join`); before section `k` of that
/// poll, the tick aborts A, and a handle above A's lane starts A again (run 2, its start
/// pending until A's lane has unwound run 1) before that section too (`started_in_the_poll`)
/// or once the poll returned. Run 1 is over, and A's run 2, which has not begun its
/// action, waits for no one (whatever run 1's join registered). Then B's lane
/// joins A's run 2: it waits (no cycle), and when A's run 2 ends B gets its outcome.
/// Found by session 55's audit of decisions re-read by id: the join took the clearance of
/// run 1 and registered, sections later, a wait that the cycle check took for run 2's, so
/// B's join of A was refused as a cycle (`JoinWouldDeadlock`) that no run closed.
fn join_by_a_run_aborted_and_replaced_before_it_registers<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
    started_in_the_poll: bool,
) {
    let setup = move || {
        let w = super::World::<L, N, B>::new(layout);
        let a = w.seq("A");
        w.split();
        let b = w.seq("B");
        w.start_taken(b);
        let old = w.start_taken(a);
        w.monitor(a, flag_of(true), Behaviour::AbortOwner, None);
        (w, a, b, old)
    };
    // A's action's context, acting for run 1, and its join of B, polled once.
    let poll_join = |w: super::World<L, N, B>, a: SeqId, b: SeqId, old: RunId| {
        let cx: &'static crate::Cx<'static, ()> =
            Box::leak(Box::new(crate::Cx::new(w.seq, &(), a)));
        cx.enter(old);
        let mut join = Box::pin(cx.join(b));
        let (waker, _) = counting();
        let polled =
            core::future::Future::poll(join.as_mut(), &mut core::task::Context::from_waker(&waker));
        (polled, join)
    };
    // The poll's sections, not those of the join's drop.
    let count = sections(setup, |&(w, a, b, old)| {
        core::mem::forget(poll_join(w, a, b, old));
    });
    every_k(count, |k| {
        let (w, a, b, old) = setup();
        let what = name::<L>(
            layout,
            format_args!("started in the poll {started_in_the_poll}, k={k} of {count}"),
        );
        interleaved::at(k, move || {
            w.tick(1);
            assert_eq!(w.ended(a), (Aborted, M0));
            if started_in_the_poll {
                w.kept(a).start().unwrap();
            }
        });
        let (polled, join) = poll_join(w, a, b, old);
        assert!(inserted(k), "{what}");
        if !started_in_the_poll {
            w.kept(a).start().unwrap();
        }
        assert_eq!(polled, Poll::Pending, "{what}");
        // Before A's lane unwinds run 1 (B's lane is above it).
        let mut run = None;
        assert_eq!(
            port_join(w.seq, b, a, &mut run),
            Poll::Pending,
            "{what}: B's join of A's run 2"
        );
        // A's lane unwinds run 1 (its join dropped), takes run 2, which completes.
        drop(join);
        w.take(a);
        assert!(w.complete(a), "{what}");
        assert_eq!(
            port_join(w.seq, b, a, &mut run),
            Poll::Ready(Ok(Outcome::Completed)),
            "{what}"
        );
        w.check(&what);
    });
}

#[test]
fn a_join_by_a_run_aborted_and_replaced_before_it_registers_waits_for_nothing() {
    for started_in_the_poll in [true, false] {
        every_world!(
            join_by_a_run_aborted_and_replaced_before_it_registers,
            started_in_the_poll
        );
    }
}
