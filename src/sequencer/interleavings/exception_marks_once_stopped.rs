//! What a lane of higher priority than the tick sees of the caller a `…CallerOfOwner`
//! behaviour stops, between the target's move and its mark, and what a restarted target
//! whose new round ends before the mark names (a cold review of the second form of the
//! exception marks of callers, session 58: the mark then came after the stop's wake-ups;
//! it now comes right after the cleanup hook, before the rest of the stop).

use super::*;
use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// What a reader above the tick found: C's state and last cause, `exception_is_active`,
/// `active_exception`.
type Read = (RunningState, Cause, bool, Option<Cause>);

/// C (main) started O in O's lane; O's monitor M (`behaviour`, no exception sequence) fires
/// in the tick at 1 ms and stops C. Returns the world, C, O and M.
fn caller_and_owner<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
) -> (World<L, N, B>, SeqId, SeqId, Cause) {
    let w = World::<L, N, B>::new(layout);
    let (c, o) = (w.seq("C"), w.seq("O"));
    let m = w.monitor(o, flag_of(true), behaviour, None);
    w.start_taken(c);
    w.in_lane(o, c).unwrap();
    w.take(o);
    (w, c, o, m)
}

/// A lane of higher priority than the tick reads C's `exception_is_active` /
/// `active_exception` before section `k` of the firing tick. The mark comes in the first
/// section after C's cleanup hook, before the rest of its stop and its wake-ups (C's
/// joiner, its blocking caller): a reader between the move and the mark finds C stopped
/// for M and not yet marked, `window` of them (none finds it `Aborted`: the abort's
/// `Aborting` comes before the mark, its `Aborted` after; one finds it `Restarting`);
/// every other reader that finds C stopped for M, and every lane the stop wakes, reads
/// `(true, Some(M))` (`Handle::exception_is_active`).
fn read_between_move_and_mark<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    behaviour: Behaviour,
    window: usize,
) {
    let count = sections(
        || caller_and_owner::<L, N, B>(layout, behaviour),
        |(w, ..)| w.tick(1),
    );
    let mut seen_unmarked = Vec::new();
    for k in 0..count {
        let (w, c, _o, m) = caller_and_owner::<L, N, B>(layout, behaviour);
        let read: Rc<RefCell<Option<Read>>> = Rc::new(RefCell::new(None));
        let r = read.clone();
        interleaved::at(k, move || {
            let h = w.kept(c);
            let (state, cause) = w.ended(c);
            *r.borrow_mut() = Some((state, cause, h.exception_is_active(), h.active_exception()));
        });
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        let h = w.handle(c);
        assert_eq!(
            (h.exception_is_active(), h.active_exception()),
            (true, Some(m)),
            "k={k}: after the tick"
        );
        let got = *read.borrow();
        if let Some((state, cause, active, named)) = got {
            let stopped = matches!(state, Aborted | Restarting) && cause == m;
            if stopped && (active, named) != (true, Some(m)) {
                seen_unmarked.push((k, state, active, named));
            }
        }
    }
    let what = name::<L>(layout, format_args!("{behaviour:?}, {count} sections"));
    // The window: consecutive sections, the last ones of C's stop.
    assert_eq!(seen_unmarked.len(), window, "{what}: {seen_unmarked:?}");
    let ks: Vec<usize> = seen_unmarked.iter().map(|&(k, ..)| k).collect();
    assert!(
        ks.windows(2).all(|p| p[1] == p[0] + 1),
        "{what}: {seen_unmarked:?}"
    );
    assert!(
        seen_unmarked
            .iter()
            .all(|&(_, _, active, named)| !active && named.is_none()),
        "{what}: {seen_unmarked:?}"
    );
}

fn read_abort<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    read_between_move_and_mark::<L, N, B>(layout, Behaviour::AbortCallerOfOwner, 0);
}

fn read_restart<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    read_between_move_and_mark::<L, N, B>(layout, Behaviour::RestartCallerOfOwner, 1);
}

#[test]
fn a_lane_above_the_tick_finds_the_aborted_caller_marked_once_stopped() {
    read_abort::<Interleaved, 8, 1>(Layout::One);
    read_abort::<Interleaved, 64, 2>(Layout::Second);
}

#[test]
fn a_lane_above_the_tick_finds_the_restarting_caller_marked_once_stopped() {
    read_restart::<Interleaved, 8, 1>(Layout::One);
    read_restart::<Interleaved, 64, 2>(Layout::Second);
}

/// M (`RestartCallerOfOwner`) restarts C; C's lane, above the tick, takes the restart up
/// before section `k` of the firing tick and its new round completes at once (both before
/// `mark_exception_target`). C's trace says `Running -> Restarting (M)`: the rustdoc of
/// `active_exception` says it "keeps naming the last exception until a new start", and
/// `mark_exception_target`'s own comment says a round taken up is named. C, terminated by
/// its own end after the restart M made, should name M (and not be marked).
fn restarted_round_ends_before_the_mark<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || caller_and_owner::<L, N, B>(layout, Behaviour::RestartCallerOfOwner);
    let count = sections(setup, |(w, ..)| w.tick(1));
    let mut wrong = Vec::new();
    for k in 0..count {
        let (w, c, _o, m) = setup();
        let lane = move || {
            if w.state(c) == Restarting {
                w.seq.restart(w.run(c));
                assert!(w.complete(c), "the new round completes");
            }
        };
        interleaved::at(k, lane);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        if w.moves(c, Running, Restarting) == 1 && w.state(c) == Terminated {
            let h = w.handle(c);
            if (h.exception_is_active(), h.active_exception()) != (false, Some(m)) {
                wrong.push((k, h.exception_is_active(), h.active_exception()));
            }
        }
        w.check_tree(&name::<L>(layout, format_args!("k={k}")));
    }
    // The restart M made is named, even when its new round ended before the mark (a first
    // form named only a round still running or paused there).
    assert!(
        wrong.is_empty(),
        "{}: restarted by M, then completed: (k, active, named) {wrong:?}",
        name::<L>(layout, format_args!("{count} sections"))
    );
}

#[test]
fn a_restarted_caller_whose_new_round_ends_before_the_mark_names_the_exception() {
    restarted_round_ends_before_the_mark::<Interleaved, 8, 1>(Layout::One);
    restarted_round_ends_before_the_mark::<Interleaved, 64, 2>(Layout::Second);
}

/// The aborted caller started again by a lane above the tick before the mark: the new run
/// is neither marked nor named (a new start clears them), whatever `k`.
fn new_run_before_the_mark<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || caller_and_owner::<L, N, B>(layout, Behaviour::AbortCallerOfOwner);
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, _o, m) = setup();
        let again = move || {
            if w.state(c) == Aborted && w.handle(c).start().is_ok() {
                w.take(c);
            }
        };
        interleaved::at(k, again);
        w.tick(1);
        or_after(k, again);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let h = w.handle(c);
        if w.runs(c) == 2 {
            assert_eq!(w.state(c), Running, "{what}");
            assert_eq!(
                (h.exception_is_active(), h.active_exception()),
                (false, None),
                "{what}"
            );
        } else {
            assert_eq!(
                (h.exception_is_active(), h.active_exception()),
                (true, Some(m)),
                "{what}"
            );
        }
        w.check_tree(&what);
    });
}

#[test]
fn a_caller_started_again_before_the_mark_begins_unmarked_and_unnamed() {
    every_world!(new_run_before_the_mark);
}

/// P (main) started C in C's lane, C started O in O's. O's monitor M
/// (`RestartCallerOfOwner`) restarts C in the tick at 1 ms; C's lane, above the tick, takes
/// the restart up before section `k` of that tick, if C is restarting then, or else after
/// the tick. Then P starts O again, and
/// in the tick at 2 ms M restarts P, aborting C from above for M. C's new round was never
/// marked, so aborted for M from above it is not marked either: `exception_is_active` is
/// false (`exception_active`: a teardown from above for an exception that marked an
/// earlier round), whatever `k`. A mark made after the new round began would make it true
/// (a mutant of `mark_exception_target` that mutation testing found unpinned, session 64).
fn round_taken_up_before_the_mark_stays_unmarked<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let [p, c, o] = ["P", "C", "O"].map(|n| w.seq(n));
        let m = w.monitor(o, flag_of(true), Behaviour::RestartCallerOfOwner, None);
        w.start_taken(p);
        w.in_lane(c, p).unwrap();
        w.take(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, p, c, o, m)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, p, c, o, m) = setup();
        let take_up = move || {
            if w.state(c) == Restarting {
                w.seq.restart(w.run(c));
            }
        };
        interleaved::at(k, take_up);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        // Before section `k` C may not be restarting yet: its lane takes the restart up
        // after the tick then.
        let during = w.state(c) == Running;
        take_up();
        let what = name::<L>(layout, format_args!("k={k} of {count}, during: {during}"));
        assert_eq!(w.moves(c, Running, Restarting), 1, "{what}");
        assert_eq!(w.state(c), Running, "{what}: the new round");
        assert_eq!(w.ended(o), (Aborted, m), "{what}");
        w.in_lane(o, p).unwrap();
        w.take(o);
        w.tick(2);
        assert_eq!(w.ended(p), (Restarting, m), "{what}");
        assert_eq!(w.ended(c), (Aborted, m), "{what}");
        let h = w.handle(c);
        assert_eq!(
            (h.exception_is_active(), h.active_exception()),
            (false, Some(m)),
            "{what}"
        );
        w.check_tree(&what);
    });
}

#[test]
fn a_round_taken_up_before_the_mark_is_not_marked_when_aborted_from_above() {
    round_taken_up_before_the_mark_stays_unmarked::<Interleaved, 8, 1>(Layout::One);
    round_taken_up_before_the_mark_stays_unmarked::<Interleaved, 64, 2>(Layout::Second);
}
