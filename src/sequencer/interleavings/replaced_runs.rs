//! A section of the tick reads a run (or a state), a later one acts on it, and a lane of
//! higher priority than the tick ends, drops, replaces or asks to abort that run in
//! between (each window found by an outside audit in session 51). Wherever it lands,
//! nothing is left stuck, and an exception sequence refused for a run that is over (or
//! whose stop has begun) is not counted as an exception not run: the exception went with
//! its run.

use super::*;
use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use crate::Request;

/// What a lane of higher priority than the tick does to O.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Party {
    /// O's lane drops O's run and a handle starts O again (its lane takes run 2).
    Replace,
    /// O's lane ends O's run, completed (refused if O may not end), and nothing else.
    End,
}

fn act<L: Lock + 'static, const N: usize, const B: usize>(w: World<L, N, B>, o: SeqId, p: Party) {
    match p {
        Party::Replace => w.replace_run(o),
        Party::End => {
            let _ = w.complete(o);
        }
    }
}

/// E's lane takes a pending start of E, if any, and runs it to its end.
fn run_e<L: Lock + 'static, const N: usize, const B: usize>(w: &World<L, N, B>, e: SeqId) {
    if w.try_take(e).is_some() {
        let _ = w.complete(e);
    }
}

// =======================================================================================
// A `PauseOwner` monitor's hold (tick/hold.rs `hold`): section 1 reads O's run, then
// the exception sequence starts for it and `pause_tree` pauses it.
// =======================================================================================

/// O runs with a `PauseOwner` monitor (exception sequence E with `with_e`) whose condition
/// holds from 1 ms. A lane of higher priority `party`s O before section `k` of the tick at
/// 1 ms that holds O. Wherever it lands: no exception is counted as not run (E is started
/// for the run the hold saw, or the run was over: nothing to hold), and while the
/// condition holds O's run under way ends paused; once it clears, O runs.
fn hold_raced<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    with_e: bool,
    party: Party,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        let on = flag_of(true);
        w.monitor(o, on, Behaviour::PauseOwner, with_e.then_some(e));
        w.start_taken(o);
        (w, o, e, on)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, e, on) = setup();
        interleaved::at(k, move || act(w, o, party));
        w.tick(1);
        or_after(k, || act(w, o, party));
        let what = name::<L>(layout, format_args!("E {with_e}, {party:?}, k={k}"));
        assert_eq!(
            w.seq.exceptions_not_run(),
            0,
            "{what}: an exception counted as not run; records {:?}",
            w.records()
        );
        for ms in 2..=4 {
            run_e(&w, e);
            w.tick(ms);
        }
        if [Running, Paused].contains(&w.state(o)) {
            assert_eq!(
                w.state(o),
                Paused,
                "{what}: not held: {:?}",
                w.transitions(o)
            );
        }
        on.store(false, Ordering::Relaxed);
        for ms in 5..=6 {
            run_e(&w, e);
            w.tick(ms);
        }
        if [Running, Paused].contains(&w.state(o)) {
            assert_eq!(
                w.state(o),
                Running,
                "{what}: left paused: {:?}",
                w.transitions(o)
            );
        }
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_during_a_pause_owner_hold_without_exception_sequence_stays_unstuck() {
    every_world!(hold_raced, false, Party::Replace);
}

#[test]
fn a_run_ended_during_a_pause_owner_hold_without_exception_sequence_stays_unstuck() {
    every_world!(hold_raced, false, Party::End);
}

/// Until session 51 (fine lock k = 6..16 of 32; coarse k = 4, 5 of 17), `hold` counted and
/// recorded `ExceptionNotRun` (`NotRunning(O)`) for a run that ended before E's start.
#[test]
fn a_run_replaced_during_a_pause_owner_hold_counts_no_exception_not_run() {
    every_world!(hold_raced, true, Party::Replace);
}

#[test]
fn a_run_ended_during_a_pause_owner_hold_counts_no_exception_not_run() {
    every_world!(hold_raced, true, Party::End);
}

// =======================================================================================
// A `PauseOwner` monitor's release (`release`: reads O's run, then `resume_tree`).
// =======================================================================================

/// O paused by its `PauseOwner` monitor at 1 ms, the condition clear from 2 ms; O's lane
/// drops O's run and starts O again before section `k` of the tick at 2 ms. O's run under
/// way ends running.
fn release_raced<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || paused_then_released::<L, N, B>(layout);
    let count = sections(setup, |(w, ..)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o, _) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(2);
        or_after(k, || w.replace_run(o));
        w.tick(3);
        w.tick(4);
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(
            (w.state(o), w.runs(o)),
            (Running, 2),
            "{what}: {:?}",
            w.transitions(o)
        );
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_during_a_pause_owner_release_runs() {
    every_world!(release_raced);
}

// =======================================================================================
// Requests (tick/requests.rs `apply_requests`: reads O's run and takes its request, then
// tears it down, pauses or resumes it).
// =======================================================================================

/// A request of O (`req`) made before the tick at 2 ms (a resume of O paused by request at
/// 1 ms); O's lane drops O's run and starts O again before section `k` of that tick. The
/// request was of run 1: run 2 is left alone (running, never paused), and nothing is stuck.
fn request_raced<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout, req: Request) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.timed("O", 50);
        w.start_taken(o);
        if req == Request::Resume {
            w.handle(o).pause().unwrap();
            w.tick(1);
            assert_eq!(w.state(o), Paused);
        }
        let h = w.handle(o);
        match req {
            Request::Pause => h.pause().unwrap(),
            Request::Resume => h.resume().unwrap(),
            Request::Abort => h.abort().unwrap(),
        }
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(2);
        or_after(k, || w.replace_run(o));
        w.tick(3);
        w.tick(4);
        let what = name::<L>(layout, format_args!("{req:?}, k={k}"));
        if w.runs(o) == 1 {
            // The lane came while the abort's teardown had run 1 `Aborting`: its start was
            // refused.
            assert_eq!(req, Request::Abort, "{what}");
            assert_eq!(w.ended(o), (Aborted, Cause::Abort), "{what}");
            w.check(&what);
            return;
        }
        assert_eq!(
            (w.state(o), w.runs(o)),
            (Running, 2),
            "{what}: {:?}",
            w.transitions(o)
        );
        let t = w.transitions(o);
        let begun = t
            .iter()
            .rposition(|t| t.to == Running && t.cause == Cause::Start)
            .unwrap();
        assert!(
            t[begun..].iter().all(|t| t.to != Paused),
            "{what}: run 2 paused by run 1's request: {t:?}"
        );
        w.check(&what);
    });
}

#[test]
fn a_request_of_a_run_replaced_during_its_tick_leaves_the_new_run_alone() {
    for req in [Request::Pause, Request::Resume, Request::Abort] {
        every_world!(request_raced, req);
    }
}

// =======================================================================================
// The timeout (tick/mod.rs `tick_word`: the scan finds it expired, `raise` marks it).
// =======================================================================================

/// O (timeout 2 ms) started at 0; its timeout runs out in the tick at 2 ms. O's lane drops
/// O's run and starts O again (at 2 ms) before section `k` of that tick. Run 2's own
/// timeout runs out 2 ms later: O ends aborted by its timeout by 4 ms (or 5, a poll late).
fn timeout_raced<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.timed("O", 2);
        w.start_taken(o);
        w.tick(1);
        (w, o)
    };
    let count = sections(setup, |(w, _)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(2);
        or_after(k, || w.replace_run(o));
        let what = name::<L>(layout, format_args!("k={k}"));
        for ms in 3..=5 {
            w.tick(ms);
        }
        // No run 2 only when the lane came while the teardown had run 1 `Aborting`
        // (its start refused): run 1 then ended by its timeout.
        assert_eq!(
            w.ended(o),
            (Aborted, Cause::Timeout(o)),
            "{what}: run 2's timeout: {:?}",
            w.transitions(o)
        );
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_while_its_timeout_is_raised_has_its_own_timeout() {
    every_world!(timeout_raced);
}

// =======================================================================================
// An exception sequence's end (tick/mod.rs `fold_changed` reports it, `apply_requests`
// takes the pending behaviour and applies it).
// =======================================================================================

/// O's monitor (`b`, exception sequence E) fired at 1 ms (its condition clears after);
/// E ran to its end. O's lane drops O's run and starts O again before section `k` of the
/// tick at 2 ms that reports E's end and applies `b`. Run 2 is left alone: running, not
/// held, nothing pending; run 1 got its behaviour or was dropped.
fn exception_end_raced<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        let fault = flag_of(true);
        w.monitor(o, fault, b, Some(e));
        w.start_taken(o);
        w.tick(1);
        fault.store(false, Ordering::Relaxed);
        w.take(e);
        assert!(w.complete(e));
        (w, o, e)
    };
    let count = sections(setup, |(w, ..)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        interleaved::at(k, move || w.replace_run(o));
        w.tick(2);
        or_after(k, || w.replace_run(o));
        let what = name::<L>(layout, format_args!("{b:?}, k={k}"));
        for ms in 3..=4 {
            run_e(&w, e);
            w.tick(ms);
        }
        let run_2 = w.runs(o) == 2;
        if run_2 {
            assert_eq!(w.state(o), Running, "{what}: run 2: {:?}", w.transitions(o));
            assert!(!w.in_set(Set::Excepting, o), "{what}: run 2 held");
            assert_eq!(
                w.seq.with(|s| s.block(o).unwrap().pending()),
                None,
                "{what}"
            );
        }
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_while_its_exception_sequences_end_is_applied_is_left_alone() {
    for b in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::Nothing,
    ] {
        every_world!(exception_end_raced, b);
    }
}

// =======================================================================================
// A caller behaviour (a monitor's or a timeout's), with the caller or the owner replaced
// during the tick that applies it (the window of 4cd4e6e, and its neighbours).
// =======================================================================================

/// Who a lane of higher priority replaces during the tick that applies O's caller
/// behaviour.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Replaced {
    /// C's lane ends C's run (completed) and a handle starts C again.
    Caller,
    /// O's lane drops O's run and a handle starts O again (a main sequence now).
    Owner,
}

/// C (main) started O non-blocking. O's monitor (or, `timeout`, its 1 ms timeout) reacts
/// with the caller behaviour `b`, with exception sequence E or without; with E, the tick
/// at 1 ms started E and E has completed, so the next tick applies `b`. Returns the world,
/// C, O and E.
fn caller_behaviour_set_up<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
    with_e: bool,
    timeout: bool,
) -> (World<L, N, B>, SeqId, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let c = w.seq("C");
    let e = w.seq("E");
    let o = if timeout {
        let mut config = SeqConfig::new("O")
            .timeout(Duration::from_millis(1))
            .timeout_behaviour(b);
        if with_e {
            config = config.timeout_exception(e);
        }
        w.add(config)
    } else {
        let o = w.seq("O");
        w.monitor(o, flag_of(true), b, with_e.then_some(e));
        o
    };
    w.start_taken(c);
    w.in_lane(o, c).unwrap();
    w.take(o);
    if with_e {
        w.tick(1);
        w.take(e);
        assert!(w.complete(e));
    }
    (w, c, o, e)
}

/// The tick (ms) that applies the caller behaviour of [`caller_behaviour_set_up`].
fn applying_tick(with_e: bool) -> u64 {
    if with_e {
        2
    } else {
        1
    }
}

/// C (main) started O non-blocking. O's monitor (or, `timeout`, its 1 ms timeout) reacts
/// with the caller behaviour `b`, with exception sequence E or without. Before section `k`
/// of the tick that applies `b` (or after it), `who` is replaced. Nothing is left held.
fn caller_behaviour_raced<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
    with_e: bool,
    timeout: bool,
    who: Replaced,
) {
    let setup = move || caller_behaviour_set_up::<L, N, B>(layout, b, with_e, timeout);
    let applying = applying_tick(with_e);
    let count = sections(setup, |(w, ..)| w.tick(applying));
    every_k(count + 1, |k| {
        let (w, c, o, e) = setup();
        let replace = move || match who {
            Replaced::Caller => {
                if w.complete(c) {
                    w.start_taken(c);
                }
            }
            Replaced::Owner => w.replace_run(o),
        };
        interleaved::at(k, replace);
        w.tick(applying);
        or_after(k, replace);
        for ms in applying + 1..=applying + 3 {
            run_e(&w, e);
            w.tick(ms);
        }
        let what = name::<L>(
            layout,
            format_args!("{b:?}, E {with_e}, timeout {timeout}, {who:?} replaced, k={k}"),
        );
        for id in [c, o] {
            assert!(
                w.state(id) != Running || !w.in_set(Set::Excepting, id),
                "{what}: {id:?} left held: O {:?}, C {:?}",
                w.transitions(o),
                w.transitions(c)
            );
        }
        if with_e {
            assert!(w.fired_any(o) >= 1, "{what}: nothing fired");
        }
        w.check(&what);
    });
}

#[test]
fn a_caller_or_owner_replaced_while_a_caller_behaviour_is_applied_leaves_nothing_held() {
    for b in [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        for with_e in [false, true] {
            for timeout in [false, true] {
                for who in [Replaced::Caller, Replaced::Owner] {
                    every_world!(caller_behaviour_raced, b, with_e, timeout, who);
                }
            }
        }
    }
}

// =======================================================================================
// A firing with an exception sequence (tick/exception.rs `raise`): the mark, then E's
// start for the marked run, then the check that the run is still current.
// =======================================================================================

/// What O's lane does during the firing tick.
#[derive(Clone, Copy, Debug, PartialEq)]
enum DropHow {
    /// Drops O's run (`Port::abandon`: aborted, `Dropped`), no new start.
    Only,
    /// Drops it and a handle starts O again.
    AndStart,
}

/// O's monitor (`b`, exception sequence E; or O's 1 ms timeout with E) fires in the tick
/// at 1 ms; O's lane drops O's run (and maybe starts O again) before section `k`. No
/// exception is counted as not run: E started for the marked run, or that run was over.
fn drop_into_firing_with_e<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
    timeout: bool,
    drop: DropHow,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let e = w.seq("E");
        let o = if timeout {
            w.add(
                SeqConfig::new("O")
                    .timeout(Duration::from_millis(1))
                    .timeout_behaviour(b)
                    .timeout_exception(e),
            )
        } else {
            let o = w.seq("O");
            w.monitor(o, flag_of(true), b, Some(e));
            o
        };
        w.start_taken(o);
        (w, o, e)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        let party = move || match drop {
            DropHow::Only => Port::abandon(w.seq, o, &()),
            DropHow::AndStart => w.replace_run(o),
        };
        interleaved::at(k, party);
        w.tick(1);
        or_after(k, party);
        let what = name::<L>(
            layout,
            format_args!("{b:?}, timeout {timeout}, {drop:?}, k={k}"),
        );
        assert_eq!(
            w.seq.exceptions_not_run(),
            0,
            "{what}: an exception counted as not run: {:?}",
            w.records()
                .iter()
                .filter_map(|r| r.event())
                .collect::<Vec<_>>()
        );
        for ms in 2..=3 {
            run_e(&w, e);
            w.tick(ms);
        }
        w.check(&what);
    });
}

#[test]
fn a_run_dropped_during_a_firing_with_an_exception_sequence_counts_no_exception_not_run() {
    let mut failed = Vec::new();
    for b in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::Nothing,
    ] {
        for timeout in [false, true] {
            for drop in [DropHow::Only, DropHow::AndStart] {
                let r = std::panic::catch_unwind(|| {
                    every_world!(drop_into_firing_with_e, b, timeout, drop);
                });
                if let Err(e) = r {
                    let msg = e.downcast_ref::<String>().cloned().unwrap_or_default();
                    failed.push(format!("{b:?}, timeout {timeout}, {drop:?}:\n{msg}"));
                }
            }
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// C (main) started O non-blocking; O's monitor (`b`, a caller behaviour, exception
/// sequence E) fires in the tick at 1 ms; O's lane drops O's run before section `k`. Once O's run
/// is over, the exception went with it: C is not torn down for it (the same wherever the
/// drop lands: before the mark nothing fires; once E started, E is aborted with O and its
/// end applies nothing to an owner that is over).
fn drop_owner_of_a_caller_behaviour<L: Lock + 'static, const N: usize, const B: usize>(
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
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o, e)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, o, e) = setup();
        let party = move || Port::abandon(w.seq, o, &());
        interleaved::at(k, party);
        w.tick(1);
        or_after(k, party);
        for ms in 2..=3 {
            run_e(&w, e);
            w.tick(ms);
        }
        let what = name::<L>(layout, format_args!("{b:?}, k={k}"));
        assert_eq!(w.ended(o), (Aborted, Cause::Dropped), "{what}");
        assert_eq!(
            (w.state(c), w.runs(c)),
            (Running, 1),
            "{what}: C torn down for an exception of a run that was over: {:?}",
            w.transitions(c)
        );
        w.check_tree(&what);
    });
}

#[test]
fn an_abort_caller_behaviour_of_a_run_dropped_during_its_firing_leaves_the_caller_alone() {
    every_world!(
        drop_owner_of_a_caller_behaviour,
        Behaviour::AbortCallerOfOwner
    );
}

#[test]
fn a_restart_caller_behaviour_of_a_run_dropped_during_its_firing_leaves_the_caller_alone() {
    every_world!(
        drop_owner_of_a_caller_behaviour,
        Behaviour::RestartCallerOfOwner
    );
}

// =======================================================================================
// The tick preempting a dropped run's teardown (in O's lane, `abort_dropped`): the
// teardown has marked O (`STOPPING`) and not moved it yet when the tick's monitors fire.
// =======================================================================================

/// O runs with a monitor `b` (exception sequence E) whose condition holds from 1 ms. O's
/// lane drops O's run (`Port::abandon`); the tick at 1 ms comes before section `k` of that
/// teardown (or after it). O ends `Aborted(Dropped)`, and no exception is counted as not
/// run: a run its teardown has placed takes no exception (semantics 9), and a `PauseOwner`
/// hold of it starts no exception sequence that is then refused.
fn tick_into_drop_of_monitored<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    b: Behaviour,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let e = w.seq("E");
        w.monitor(o, flag_of(true), b, Some(e));
        w.start_taken(o);
        (w, o, e)
    };
    let count = sections(setup, |(w, o, _)| Port::abandon(w.seq, *o, &()));
    every_k(count + 1, |k| {
        let (w, o, e) = setup();
        interleaved::at(k, move || w.tick(1));
        Port::abandon(w.seq, o, &());
        or_after(k, || w.tick(1));
        let what = name::<L>(layout, format_args!("{b:?}, k={k}"));
        assert_eq!(
            w.seq.exceptions_not_run(),
            0,
            "{what}: an exception counted as not run: {:?}",
            w.records()
                .iter()
                .filter_map(|r| r.event())
                .collect::<Vec<_>>()
        );
        for ms in 2..=3 {
            run_e(&w, e);
            w.tick(ms);
        }
        assert_eq!(w.ended(o), (Aborted, Cause::Dropped), "{what}");
        w.check(&what);
    });
}

/// Until session 51 `hold` took a run its teardown had placed (`mark` did not).
#[test]
fn a_pause_owner_hold_during_a_dropped_runs_teardown_counts_no_exception_not_run() {
    every_world!(tick_into_drop_of_monitored, Behaviour::PauseOwner);
}

#[test]
fn a_firing_during_a_dropped_runs_teardown_counts_no_exception_not_run() {
    for b in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::Nothing,
        Behaviour::AbortCallerOfOwner,
    ] {
        every_world!(tick_into_drop_of_monitored, b);
    }
}

// =======================================================================================
// An abort request of the owner made during its firing tick (a handle in a lane of higher
// priority than the tick): the request holds the run (it begins nothing more), so the
// exception sequence's start for it is refused (`open_start`).
// =======================================================================================

/// C (main) started O non-blocking; O's monitor (`b`, exception sequence E) fires in the
/// tick at 1 ms; a handle (in a lane of higher priority than the tick) requests O's abort
/// before section `k` of that tick (or after it). E's lane takes E but E does not end
/// before the tick at 2 ms, which carries the abort out: O ends aborted, E with it (E is
/// below O). No exception is counted as not run (the tick's own start of E is not O's
/// start, as under an abort-all, semantics 8), and C is left alone, as it is wherever the
/// request lands once E has started.
fn abort_request_into_firing_with_e<L: Lock + 'static, const N: usize, const B: usize>(
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
        w.in_lane(o, c).unwrap();
        w.take(o);
        (w, c, o, e)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, c, o, e) = setup();
        let party = move || {
            let _ = w.kept(o).abort();
        };
        interleaved::at(k, party);
        w.tick(1);
        or_after(k, party);
        let what = name::<L>(layout, format_args!("{b:?}, k={k}"));
        let events = || {
            w.records()
                .iter()
                .filter_map(|r| r.event())
                .collect::<Vec<_>>()
        };
        assert_eq!(
            w.seq.exceptions_not_run(),
            0,
            "{what}: an exception counted as not run: {:?}",
            events()
        );
        let _ = w.try_take(e);
        for ms in 2..=3 {
            w.tick(ms);
        }
        assert_eq!(w.state(o), Aborted, "{what}");
        if b.targets_caller() {
            assert_eq!(
                (w.state(c), w.runs(c)),
                (Running, 1),
                "{what}: C torn down: {:?}",
                w.transitions(c)
            );
        }
        w.check(&what);
    });
}

#[test]
fn an_abort_request_during_a_firing_with_an_exception_sequence_counts_no_exception_not_run() {
    let mut failed = Vec::new();
    for b in [
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::Nothing,
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        let r = std::panic::catch_unwind(|| {
            every_world!(abort_request_into_firing_with_e, b);
        });
        if let Err(e) = r {
            let msg = e.downcast_ref::<String>().cloned().unwrap_or_default();
            failed.push(format!("{b:?}:\n{msg}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// What a lane of higher priority does to C during the tick that applies O's caller
/// behaviour.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ToCaller {
    DropAndStart,
    Drop,
    Complete,
    AbortRequest,
    Pause,
}

/// C (main) started O non-blocking; O's caller behaviour `b` (exception sequence E
/// or not); `to_c` done to C before section `k` of the applying tick. Nothing is left held,
/// and the strengthened invariants hold.
fn caller_behaviour_against_a_party_on_the_caller<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
    b: Behaviour,
    with_e: bool,
    to_c: ToCaller,
) {
    let setup = move || caller_behaviour_set_up::<L, N, B>(layout, b, with_e, false);
    let applying = applying_tick(with_e);
    let count = sections(setup, |(w, ..)| w.tick(applying));
    every_k(count + 1, |k| {
        let (w, c, o, e) = setup();
        let party = move || match to_c {
            ToCaller::DropAndStart => w.replace_run(c),
            ToCaller::Drop => Port::abandon(w.seq, c, &()),
            ToCaller::Complete => {
                let _ = w.complete(c);
            }
            ToCaller::AbortRequest => {
                let _ = w.kept(c).abort();
            }
            ToCaller::Pause => {
                let _ = w.kept(c).pause();
            }
        };
        interleaved::at(k, party);
        w.tick(applying);
        or_after(k, party);
        for ms in applying + 1..=applying + 3 {
            if w.try_take(e).is_some() {
                let _ = w.complete(e);
            }
            w.tick(ms);
        }
        let what = name::<L>(layout, format_args!("{b:?}, E {with_e}, {to_c:?}, k={k}"));
        for id in [c, o] {
            assert!(
                w.state(id) != Running || !w.in_set(Set::Excepting, id),
                "{what}: {id:?} left held"
            );
        }
        w.check(&what);
    });
}

#[test]
fn a_caller_behaviour_leaves_no_run_held_whatever_a_lane_does_to_the_caller_meanwhile() {
    for b in [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        for with_e in [false, true] {
            for to_c in [
                ToCaller::DropAndStart,
                ToCaller::Drop,
                ToCaller::Complete,
                ToCaller::AbortRequest,
                ToCaller::Pause,
            ] {
                every_world!(
                    caller_behaviour_against_a_party_on_the_caller,
                    b,
                    with_e,
                    to_c
                );
            }
        }
    }
}

// Teardowns after session 56's changes (a cold review): a start refused after its schedule
// must leave the aborted run's exception as it was; the restart budget with the lane above
// the tick taking the restart up held.

/// O (main) was aborted at 1 ms by its own `AbortOwner` monitor M0: the exception caused
/// the abort, so `exception_is_active` stays and `active_exception` names M0 (semantics
/// 3). P (main) runs. Returns the world, O and P.
fn aborted_by_its_exception<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let p = w.seq("P");
    w.monitor(o, flag_of(true), Behaviour::AbortOwner, None);
    w.start_taken(o);
    w.start_taken(p);
    w.tick(1);
    assert_eq!(w.ended(o), (Aborted, M0));
    assert!(w.kept(o).exception_is_active());
    assert_eq!(w.kept(o).active_exception(), Some(M0));
    assert_eq!(w.state(p), Running);
    (w, o, p)
}

/// P starts O in O's lane (`Port::start_child`); before each section of that start a party
/// above P's lane asks P's abort (a handle of higher priority). A start that is refused
/// (`NotRunning(P)`) is no new start: O's aborted run keeps its exception, both
/// `exception_is_active` and `active_exception` (semantics 3; `Handle::exception_is_active`:
/// "ends with a restart, a new start, or an abort for another cause";
/// `active_exception` "keeps naming the last exception until a new start").
fn refused_start_keeps_the_exception<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || aborted_by_its_exception::<L, N, B>(layout);
    let count = sections(setup, |(w, o, p)| {
        let _ = Port::start_child(w.seq, *o, w.run(*p));
    });
    every_k(count, |k| {
        let (w, o, p) = setup();
        let what = name::<L>(layout, format_args!("k={k}/{count}"));
        interleaved::at(k, move || {
            let _ = w.kept(p).abort();
        });
        let started = Port::start_child(w.seq, o, w.run(p));
        assert!(inserted(k), "{what}: the party ran");
        match started {
            Ok(_) => {
                assert_eq!(w.state(o), Running, "{what}");
                assert!(!w.kept(o).exception_is_active(), "{what}");
            }
            Err(e) => {
                assert_eq!(e, Error::NotRunning(p), "{what}");
                assert_eq!(w.ended(o), (Aborted, M0), "{what}");
                assert_eq!(
                    (
                        w.kept(o).exception_is_active(),
                        w.kept(o).active_exception()
                    ),
                    (true, Some(M0)),
                    "{what}: a refused start cleared the aborted run's exception"
                );
            }
        }
        w.tick(2);
        w.check(&what);
    });
}

#[test]
fn a_refused_start_leaves_the_exception_of_the_aborted_run() {
    every_world!(refused_start_keeps_the_exception);
}

/// O (main) with a `RestartOwner` monitor M0 of restart limit 2 whose condition stays
/// true. Returns the world and O.
fn budgeted<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) -> (World<L, N, B>, SeqId) {
    let w = World::<L, N, B>::new(layout);
    let o = w.seq("O");
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(|_: &(), _: Instant| true));
    w.monitors
        .borrow_mut()
        .add(
            o,
            Monitor::new("m", condition, Behaviour::RestartOwner).restart_limit(2),
        )
        .unwrap();
    w.start_taken(o);
    (w, o)
}

/// O's lane, above the tick, takes up O's restart before each section of the tick at
/// 1 ms that restarts O (or after it). The budget is per run (semantics 5): O restarts
/// twice (ticks 1 and 2, each restart counted once) and the third firing escalates to an
/// abort: `Aborted(M0)` by the tick at 3 ms, with two restarts and no more.
fn restart_budget_with_the_lane_above<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    if L::COARSE {
        return;
    }
    let setup = move || budgeted::<L, N, B>(layout);
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o) = setup();
        let what = name::<L>(layout, format_args!("k={k}/{count}"));
        let lane = move || {
            if w.state(o) == Restarting {
                w.seq.restart(w.run(o));
            }
        };
        interleaved::at(k, lane);
        w.tick(1);
        interleaved::at(usize::MAX, || {});
        lane();
        assert_eq!(w.state(o), Running, "{what}");
        for ms in 2..=4 {
            w.tick(ms);
            lane();
        }
        assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        assert_eq!(w.moves(o, Running, Restarting), 2, "{what}: restarts");
        assert!(w.kept(o).exception_is_active(), "{what}");
        w.check(&what);
    });
}

#[test]
fn a_restart_budget_is_spent_once_per_restart_with_the_lane_above_the_tick() {
    every_world!(restart_budget_with_the_lane_above);
}
