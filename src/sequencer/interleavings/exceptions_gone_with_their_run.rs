//! The rules of session 51's fixes, probed by its cold review: a run whose abort is
//! requested takes no exception; an exception sequence refused (for any reason) once
//! its owner's run is over goes with the run, counted nowhere and followed by no
//! behaviour; an owner started again after its caller's teardown is left alone.

use super::*;
use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use std::cell::Cell;

/// Semantics 10: "A run whose abort is requested takes no exception, as one a teardown has
/// placed (9)". A handle requests O's abort before section `k` of the firing tick: no
/// exception of O is marked after the request. (The mark records its `Fired` in the
/// section after the marking: a request that lands between the two is recorded before
/// it, for an exception taken before the request.)
fn no_exception_taken_after_an_abort_request<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    with_e: bool,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let c = w.seq("C");
        let e = w.seq("E");
        let o = w.seq("O");
        w.monitor(
            o,
            flag_of(true),
            Behaviour::AbortCallerOfOwner,
            with_e.then_some(e),
        );
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, _c, o) = setup();
        // Whether O was marked when the request came.
        let marked = Rc::new(Cell::new(false));
        let seen = marked.clone();
        let party = move || {
            seen.set(w.in_set(Set::Excepting, o));
            let _ = w.kept(o).abort();
        };
        interleaved::at(k, party.clone());
        w.tick(1);
        or_after(k, party);
        let what = name::<L>(layout, format_args!("E {with_e}, k={k} of {count}"));
        let events: Vec<Event> = w.records().iter().filter_map(|r| r.event()).collect();
        let requested = events
            .iter()
            .position(|e| matches!(e, Event::Requested { sequence, .. } if *sequence == o));
        let fired = events
            .iter()
            .position(|e| matches!(e, Event::Fired { owner, .. } if *owner == o));
        if let (Some(r), Some(f)) = (requested, fired) {
            assert!(
                f < r || marked.get(),
                "{what}: O took an exception after its abort was requested: {events:?}"
            );
        }
    });
}

/// Runs `f` for each of `cases`, every one even after a failure; fails naming each failed
/// case with the first lines of its message.
fn each_case<T: Copy + core::fmt::Debug>(cases: &[T], f: impl Fn(T)) {
    let mut failed = Vec::new();
    for &case in cases {
        if let Err(e) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(case))) {
            let msg = e.downcast_ref::<String>().cloned().unwrap_or_default();
            let head = msg.lines().take(5).collect::<Vec<_>>().join("\n");
            failed.push(format!("{case:?}:\n{head}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn a_run_whose_abort_is_requested_takes_no_exception() {
    each_case(&[false, true], |with_e| {
        every_world!(no_exception_taken_after_an_abort_request, with_e);
    });
}

/// C (main) started O non-blocking; O's monitor (`b`, a caller behaviour, exception
/// sequence E) fires in the tick at 1 ms, but E is already running (started by a handle):
/// its start is refused `AlreadyRunning(E)`, which `check_start` finds before
/// `open_start` looks at O's run. O's lane drops O's run (a handle starts O again, a main
/// sequence now) before section `k` of that tick. Semantics 10: once O's run is over the
/// exception went with it (not counted, no behaviour): C is left alone (as 7acc994's
/// `current` check ensured).
fn drop_owner_while_its_exception_sequence_is_busy<
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
        let e = w.seq("E");
        let o = w.seq("O");
        w.monitor(o, flag_of(true), b, Some(e));
        w.start_taken(c);
        w.start_taken(e);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, o) = setup();
        // Only a drop after the mark is of interest: before it, nothing fires for run 1.
        // The count when the drop came: the refusal counted while the run was under way
        // is recorded in the section after, which the drop may precede.
        let counted = Rc::new(Cell::new(0));
        let seen = counted.clone();
        let party = move || {
            seen.set(w.seq.exceptions_not_run());
            w.replace_run(o);
        };
        interleaved::at(k, party.clone());
        w.tick(1);
        let late = or_after(k, party);
        for ms in 2..=3 {
            w.tick(ms);
        }
        let what = name::<L>(
            layout,
            format_args!("{b:?}, k={k} of {count}, after {late}"),
        );
        if late {
            return;
        }
        let events = || {
            w.records()
                .iter()
                .filter_map(|r| r.event())
                .collect::<Vec<_>>()
        };
        // The exception sequence refused (and the behaviour applied at once) after O's run
        // was over: the order of the trace says it.
        let records = w.records();
        let dropped = records.iter().position(|r| {
            matches!(r.entry, crate::trace::Entry::Transition { sequence, cause: Cause::Dropped, .. } if sequence == o)
        });
        let not_run = records.iter().position(
            |r| matches!(r.event(), Some(Event::ExceptionNotRun { owner, .. }) if owner == o),
        );
        let fired = records
            .iter()
            .position(|r| matches!(r.event(), Some(Event::Fired { owner, .. }) if owner == o));
        // Only run 1's firing (the tick at 1 ms); run 2 fires at 2 ms, legitimately counted.
        let not_run = not_run.filter(|&n| records[n].time == records[fired.unwrap_or(0)].time);
        // Run 1 fired (before the drop), then was counted after its drop.
        if let (Some(f), Some(d), Some(n)) = (fired, dropped, not_run) {
            assert!(
                !(f < d && d < n) || counted.get() > 0,
                "{what}: counted, and applied at once, for a run that was over: C {:?}; events {:?}",
                w.transitions(c),
                events()
            );
        }
        let _ = c;
        w.check_tree(&what);
    });
}

#[test]
fn a_caller_behaviour_of_a_run_dropped_while_its_exception_sequence_is_busy_leaves_the_caller_alone(
) {
    let behaviours = [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ];
    each_case(&behaviours, |b| {
        every_world!(drop_owner_while_its_exception_sequence_is_busy, b);
    });
}

/// As `hold_raced` (replaced_runs.rs) with E already running: O's `PauseOwner` monitor
/// holds from 1 ms; O's lane drops O's run (and a handle starts O again) before section
/// `k` of that tick. An `ExceptionNotRun` of the hold recorded after O's run was dropped
/// counts a safe stop "not run" for a run that was over (semantics 10).
fn hold_of_a_dropped_run_with_busy_exception_sequence<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        w.monitor(o, flag_of(true), Behaviour::PauseOwner, Some(e));
        w.start_taken(e);
        w.start_taken(o);
        (w, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        // As above: the count when the drop came.
        let counted = Rc::new(Cell::new(0));
        let seen = counted.clone();
        let party = move || {
            seen.set(w.seq.exceptions_not_run());
            w.replace_run(o);
        };
        interleaved::at(k, party.clone());
        w.tick(1);
        or_after(k, party);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let records = w.records();
        let fired = records
            .iter()
            .position(|r| matches!(r.event(), Some(Event::Fired { owner, .. }) if owner == o));
        let dropped = records.iter().position(|r| {
            matches!(r.entry, crate::trace::Entry::Transition { sequence, cause: Cause::Dropped, .. } if sequence == o)
        });
        let not_run = records.iter().position(
            |r| matches!(r.event(), Some(Event::ExceptionNotRun { owner, .. }) if owner == o),
        );
        if let (Some(f), Some(d), Some(n)) = (fired, dropped, not_run) {
            assert!(
                !(f < d && d < n) || counted.get() > 0,
                "{what}: counted for a run that was over"
            );
        }
    });
}

#[test]
fn a_hold_of_a_run_dropped_while_its_exception_sequence_is_busy_counts_nothing() {
    every_world!(hold_of_a_dropped_run_with_busy_exception_sequence);
}

/// C (main) started O non-blocking; O's monitor `b` (a caller behaviour, no exception
/// sequence) fires at 1 ms and C's teardown takes O down. A handle (lane above the tick)
/// starts O again as soon as it is over, before section `k` of that tick: the new run is
/// not the owner `end_if_still_held` names, and is left alone (semantics 9).
fn owner_started_again_after_its_callers_teardown<
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
        let on = flag_of(true);
        w.monitor(o, on, b, None);
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o, on)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, _c, o, on) = setup();
        let party = move || {
            if w.state(o) == Aborted && w.handle(o).start().is_ok() {
                on.store(false, Ordering::Relaxed);
                w.take(o);
            }
        };
        interleaved::at(k, party);
        w.tick(1);
        or_after(k, party);
        w.tick(2);
        let what = name::<L>(layout, format_args!("{b:?}, k={k} of {count}"));
        if w.runs(o) == 2 {
            SEEN.fetch_add(1, Ordering::Relaxed);
            assert_eq!(
                w.state(o),
                Running,
                "{what}: O's new run {:?}",
                w.transitions(o)
            );
        }
        w.check(&what);
    });
}

static SEEN: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

#[test]
fn an_owner_started_again_after_its_callers_teardown_is_left_alone() {
    for b in [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        every_world!(owner_started_again_after_its_callers_teardown, b);
    }
    assert!(
        SEEN.load(Ordering::Relaxed) > 8,
        "{}",
        SEEN.load(Ordering::Relaxed)
    );
}

/// C (main) started O in O's lane; O's monitor (`AbortCallerOfOwner`, exception sequence
/// E) fires in the tick at 1 ms. A handle requests O's abort before section `k` of that
/// tick, or after it; E's lane then runs E to its end, and the tick at 2 ms comes. Where
/// E started before the request, the behaviour waits for E and is applied, before the
/// request, in the tick that reports E's end (semantics 3; `tests/scenarios.rs`,
/// `a_behaviour_applied_in_the_tick_of_a_requested_abort_comes_first`): C is aborted.
/// Where the request came first, E is not started (the run's stop has begun) and the
/// exception goes with the run: C runs on. O ends aborted either way. (Found by the cold
/// review of session 51: a request made between E's start and the section that makes
/// the behaviour wait dropped it.)
fn abort_requested_while_a_behaviour_waits<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let (c, e, o) = (w.seq("C"), w.seq("E"), w.seq("O"));
        w.monitor(o, flag_of(true), Behaviour::AbortCallerOfOwner, Some(e));
        w.start_taken(c);
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, e, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, e, o) = setup();
        // Whether E had started when the request came.
        let started = Rc::new(Cell::new(false));
        let seen = started.clone();
        let party = move || {
            seen.set(w.has(e, flag::HANDLES_EXCEPTION));
            let _ = w.kept(o).abort();
        };
        interleaved::at(k, party.clone());
        w.tick(1);
        or_after(k, party);
        if w.try_take(e).is_some() || w.state(e) == Running {
            w.complete(e);
        }
        w.tick(2);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let c_state = if started.get() { Aborted } else { Running };
        assert_eq!(w.state(c), c_state, "{what}: C {:?}", w.transitions(c));
        assert_eq!(w.state(o), Aborted, "{what}");
        w.check_tree(&what);
    });
}

#[test]
fn an_abort_requested_after_the_exception_sequence_started_comes_after_its_behaviour() {
    every_world!(abort_requested_while_a_behaviour_waits);
}

/// O (main, waiting for a poll) has a monitor `Nothing` whose exception sequence E is
/// already running: E is refused, counted, and `Nothing` applied at once, which gives back
/// the due poll the mark skipped. A lane of higher priority replaces O's run (the new run
/// waits for a poll too) before section `k` of that tick: the old run's poll is not given
/// to the new run, which polls on its own grid. (Found by the cold review of session 51.)
fn nothing_gives_back_no_poll_to_a_new_run<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let (e, o) = (w.seq("E"), w.seq("O"));
        w.monitor(o, flag_of(true), Behaviour::Nothing, Some(e));
        w.start_taken(e);
        let run = w.start_taken(o);
        Port::set_poll_wait(w.seq, run, true);
        (w, o)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        // Whether O was marked when its run was replaced.
        let marked = Rc::new(Cell::new(false));
        let seen = marked.clone();
        let party = move || {
            seen.set(w.in_set(Set::Excepting, o));
            w.replace_run(o);
            Port::set_poll_wait(w.seq, w.run(o), true);
        };
        interleaved::at(k, party.clone());
        w.tick(1);
        let late = or_after(k, party);
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        if marked.get() && !late && w.seq.exceptions_not_run() == 1 {
            assert!(
                !w.in_set(Set::PollDue, o),
                "{what}: the old run's skipped poll given to O's new run"
            );
        }
        w.check_tree(&what);
    });
}

#[test]
fn nothing_applied_at_once_gives_no_poll_to_a_new_run() {
    every_world!(nothing_gives_back_no_poll_to_a_new_run);
}
