//! Futures of an action dropped (a blocking run's future, the loser of a `select`, a
//! `Scoped`, a lane with a start not taken) while the tick tears down, restarts or aborts
//! the same subtree, one preempting the other (a cold review of session 56, which found
//! nothing). Cleanup hooks are counted against the trace: one per move.

use super::*;
use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

std::thread_local! {
    static HOOKS: RefCell<[usize; 3]> = const { RefCell::new([0; 3]) };
}

fn hook_y(_: &()) {
    HOOKS.with(|h| h.borrow_mut()[0] += 1);
}
fn hook_x(_: &()) {
    HOOKS.with(|h| h.borrow_mut()[1] += 1);
}
fn hook_z(_: &()) {
    HOOKS.with(|h| h.borrow_mut()[2] += 1);
}
fn hooks() -> [usize; 3] {
    HOOKS.with(|h| *h.borrow())
}

/// What the tick at 1 ms does to the chain Y → X → Z (all blocking, in Y's lane).
#[derive(Clone, Copy, Debug, PartialEq)]
enum TickDoes {
    /// X's `RestartOwner` monitor: X restarts, Z aborted.
    RestartX,
    /// Y's `RestartOwner` monitor: Y restarts, X and Z aborted.
    RestartY,
    /// X's `AbortOwner` monitor.
    AbortX,
    /// Z's `AbortCallerOfOwner` monitor: X (Z's caller) aborted with Z.
    AbortCallerOfZ,
    /// An abort request of Y.
    RequestAbortY,
    /// An abort-all.
    AbortAll,
}

/// Y (main, its lane took its start) runs X blocking, X runs Z blocking; each with a
/// counting cleanup hook; `does` set up for the tick at 1 ms.
fn chain3<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    does: TickDoes,
) -> (World<L, N, B>, [SeqId; 3]) {
    HOOKS.with(|h| *h.borrow_mut() = [0; 3]);
    let w = World::<L, N, B>::new(layout);
    let y = w.add(SeqConfig::new("Y").on_abort(hook_y));
    let x = w.add(SeqConfig::new("X").on_abort(hook_x));
    let z = w.add(SeqConfig::new("Z").on_abort(hook_z));
    match does {
        TickDoes::RestartX => {
            w.monitor(x, flag_of(true), Behaviour::RestartOwner, None);
        }
        TickDoes::RestartY => {
            w.monitor(y, flag_of(true), Behaviour::RestartOwner, None);
        }
        TickDoes::AbortX => {
            w.monitor(x, flag_of(true), Behaviour::AbortOwner, None);
        }
        TickDoes::AbortCallerOfZ => {
            w.monitor(z, flag_of(true), Behaviour::AbortCallerOfOwner, None);
        }
        _ => {}
    }
    w.start_taken(y);
    for (id, caller) in [(x, y), (z, x)] {
        w.seq
            .begin(
                id,
                Mode::Blocking {
                    caller: w.run(caller),
                    maker: w.tag,
                },
                Cause::Start,
            )
            .unwrap();
    }
    w.tick(0);
    match does {
        TickDoes::RequestAbortY => w.handle(y).abort().unwrap(),
        TickDoes::AbortAll => w.seq.abort_all(),
        _ => {}
    }
    assert_eq!([y, x, z].map(|id| w.state(id)), [Running; 3], "set-up");
    (w, [y, x, z])
}

/// After the drop of X's run and the tick at 1 ms in either order: X and Z are over
/// (aborted once each), nothing under way below an aborted sequence, and each cleanup hook
/// ran exactly once for each move into `Aborting` or `Restarting` of its sequence.
fn expect_after<L: Lock + 'static, const N: usize, const B: usize>(
    what: &str,
    w: &World<L, N, B>,
    [y, x, z]: [SeqId; 3],
    does: TickDoes,
) {
    for id in [x, z] {
        assert_eq!(w.state(id), Aborted, "{what}: {id:?} {:?}", w.ended(id));
        assert_eq!(
            w.moves(id, Aborting, Aborted),
            1,
            "{what}: {id:?} aborted once"
        );
    }
    let into = |id: SeqId| {
        w.transitions(id)
            .iter()
            .filter(|t| t.to == Aborting || t.to == Restarting)
            .count()
    };
    let got = hooks();
    assert_eq!(
        got,
        [y, x, z].map(into),
        "{what}: hooks vs moves into Aborting/Restarting"
    );
    let y_state = w.state(y);
    let y_ok: &[RunningState] = match does {
        TickDoes::RestartY => &[Restarting],
        TickDoes::RequestAbortY | TickDoes::AbortAll => &[Aborted],
        _ => &[Running],
    };
    assert!(y_ok.contains(&y_state), "{what}: Y {y_state:?}");
    w.check(what);
    // The next tick changes nothing below Y.
    w.tick(2);
    for id in [x, z] {
        assert_eq!(w.state(id), Aborted, "{what}: {id:?} after the next tick");
    }
    w.check(what);
}

/// X's future is dropped in Y's lane (`Port::abandon(X)`); the tick at 1 ms preempts the
/// drop's walk before section `k` (or comes after it).
fn tick_into_drop_of_middle<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    does: TickDoes,
) {
    let setup = move || chain3::<L, N, B>(layout, does);
    let count = sections(setup, |(w, [_, x, _])| Port::abandon(w.seq, *x, &()));
    every_k(count + 1, |k| {
        let (w, ids) = setup();
        interleaved::at(k, move || w.tick(1));
        Port::abandon(w.seq, ids[1], &());
        or_after(k, || w.tick(1));
        let what = name::<L>(
            layout,
            format_args!("{does:?}, tick before drop section k={k}"),
        );
        expect_after(&what, &w, ids, does);
    });
}

/// The tick at 1 ms; Y's lane, above the tick, drops X's future before section `k` of the
/// tick (fine lock only: with a coarse lock no lane runs inside the tick).
fn drop_of_middle_into_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    does: TickDoes,
) {
    if L::COARSE {
        return;
    }
    let setup = move || chain3::<L, N, B>(layout, does);
    let count = sections(setup, |(w, _)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, ids) = setup();
        let x = ids[1];
        interleaved::at(k, move || Port::abandon(w.seq, x, &()));
        w.tick(1);
        or_after(k, || Port::abandon(w.seq, x, &()));
        let what = name::<L>(
            layout,
            format_args!("{does:?}, drop before tick section k={k}"),
        );
        expect_after(&what, &w, ids, does);
    });
}

const ALL: [TickDoes; 6] = [
    TickDoes::RestartX,
    TickDoes::RestartY,
    TickDoes::AbortX,
    TickDoes::AbortCallerOfZ,
    TickDoes::RequestAbortY,
    TickDoes::AbortAll,
];

#[test]
fn tick_into_a_dropped_middle_run() {
    for does in ALL {
        every_world!(tick_into_drop_of_middle, does);
    }
}

#[test]
fn a_dropped_middle_run_into_the_tick() {
    for does in ALL {
        every_world!(drop_of_middle_into_tick, does);
    }
}

/// As a `select` in Y's action drops X's future: X's action future (holding Z's run) goes
/// first (`Port::abandon(Z)`), then X's run (`Port::abandon(X)`); the tick at 1 ms comes
/// before section `k` of the two walks (or after them).
fn tick_into_nested_drop<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    does: TickDoes,
) {
    let setup = move || chain3::<L, N, B>(layout, does);
    let drop_both = |w: &World<L, N, B>, [_, x, z]: [SeqId; 3]| {
        Port::abandon(w.seq, z, &());
        Port::abandon(w.seq, x, &());
    };
    let count = sections(setup, |(w, ids)| drop_both(w, *ids));
    every_k(count + 1, |k| {
        let (w, ids) = setup();
        interleaved::at(k, move || w.tick(1));
        drop_both(&w, ids);
        or_after(k, || w.tick(1));
        let what = name::<L>(layout, format_args!("{does:?}, nested drop, k={k}"));
        expect_after(&what, &w, ids, does);
    });
}

#[test]
fn tick_into_a_nested_drop() {
    for does in ALL {
        every_world!(tick_into_nested_drop, does);
    }
}

/// O runs and started C (in C's lane) by `Cx::start_scoped`. O's action is dropped: the
/// `Scoped` asks for the abort of C's run 1 (`abort_child`), then O's run is dropped
/// (`Port::abandon(O)`, which takes C's run 1 down, `Dropped`). A lane above (a handle)
/// starts C again, and C's lane takes it, before section `k` of the two. A later run of C
/// is never asked (semantics 11): run 2, if its start was accepted, runs on after the
/// ticks at 1 and 2 ms, never aborted.
fn scoped_drop_against_a_new_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        w.split();
        let c = w.seq("C");
        w.start_taken(o);
        w.in_lane(c, o).unwrap();
        let run1 = w.take(c);
        (w, o, c, run1)
    };
    let op = |w: &World<L, N, B>, o: SeqId, run1: RunId| {
        let _ = Port::abort_child(w.seq, run1, o);
        Port::abandon(w.seq, o, &());
    };
    let count = sections(setup, |(w, o, _, run1)| op(w, *o, *run1));
    every_k(count + 1, |k| {
        let (w, o, c, run1) = setup();
        let started: &'static Cell<bool> = Box::leak(Box::new(Cell::new(false)));
        let party = move || {
            if w.handle(c).start().is_ok() {
                started.set(true);
                let _ = w.try_take(c);
            }
        };
        interleaved::at(k, party);
        op(&w, o, run1);
        or_after(k, party);
        let what = name::<L>(layout, format_args!("k={k}, started {}", started.get()));
        assert_eq!(w.ended(o), (Aborted, Cause::Dropped), "{what}");
        w.tick(1);
        w.tick(2);
        if started.get() {
            assert_eq!(
                (w.state(c), w.runs(c)),
                (Running, 2),
                "{what}: {:?}",
                w.ended(c)
            );
        } else {
            assert_eq!(w.state(c), Aborted, "{what}");
        }
        assert_eq!(w.moves(c, Aborting, Aborted), 1, "{what}");
        w.check(&what);
    });
}

#[test]
fn scoped_and_caller_dropped_against_a_new_start_of_the_child() {
    every_world!(scoped_drop_against_a_new_start);
}

/// O runs (monitored, `does` set up for the tick at 1 ms on O: its own abort or restart)
/// and started X in X's lane; X's lane has not taken the start when its future is dropped
/// (`close_lane`, then `Port::abandon_start`). The tick at 1 ms comes before section `k`.
/// X ends aborted exactly once, its hook once, never running; no start left pending.
fn tick_into_abandon_start<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    restart: bool,
) {
    let setup = move || {
        HOOKS.with(|h| *h.borrow_mut() = [0; 3]);
        let w = World::<L, N, B>::new(layout);
        let o = w.add(SeqConfig::new("O").on_abort(hook_y));
        w.split();
        let x = w.add(SeqConfig::new("X").on_abort(hook_x));
        let b = if restart {
            Behaviour::RestartOwner
        } else {
            Behaviour::AbortOwner
        };
        w.monitor(o, flag_of(true), b, None);
        w.start_taken(o);
        w.in_lane(x, o).unwrap();
        assert!(w.pending(x));
        (w, o, x)
    };
    let op = |w: &World<L, N, B>, x: SeqId| {
        Port::close_lane(w.seq, x, w.tag);
        Port::abandon_start(w.seq, x, w.tag, &());
    };
    let count = sections(setup, |(w, _, x)| op(w, *x));
    every_k(count + 1, |k| {
        let (w, o, x) = setup();
        interleaved::at(k, move || w.tick(1));
        op(&w, x);
        or_after(k, || w.tick(1));
        let what = name::<L>(layout, format_args!("restart {restart}, k={k}"));
        assert_eq!(w.state(x), Aborted, "{what}: {:?}", w.ended(x));
        assert!(!w.pending(x), "{what}: start left pending");
        assert_eq!(w.moves(x, Aborting, Aborted), 1, "{what}");
        let into = |id: SeqId| {
            w.transitions(id)
                .iter()
                .filter(|t| t.to == Aborting || t.to == Restarting)
                .count()
        };
        let h = hooks();
        assert_eq!([h[0], h[1]], [into(o), into(x)], "{what}: hooks");
        w.check(&what);
    });
}

#[test]
fn tick_into_a_dropped_lane_with_a_start_not_taken() {
    every_world!(tick_into_abandon_start, false);
    every_world!(tick_into_abandon_start, true);
}

/// Y (main) runs X blocking; X's `AbortOwner` monitor (exception sequence E) fired at 1 ms
/// and E's lane took E: X is held. Y's `select` drops X's future (`Port::abandon(X)`);
/// before section `k` of that walk, E's lane completes E and the tick at 2 ms reports E's
/// end (applying `AbortOwner` to X). X ends aborted once (`Dropped` or the monitor's), E
/// is over, Y runs on, each hook ran once per move into `Aborting`, nothing counted as an
/// exception not run.
fn exception_end_into_drop_of_held_owner<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = move || {
        HOOKS.with(|h| *h.borrow_mut() = [0; 3]);
        let w = World::<L, N, B>::new(layout);
        let y = w.add(SeqConfig::new("Y").on_abort(hook_y));
        w.split();
        let x = w.add(SeqConfig::new("X").on_abort(hook_x));
        let e = w.add(SeqConfig::new("E").on_abort(hook_z));
        let fault = flag_of(true);
        w.monitor(x, fault, Behaviour::AbortOwner, Some(e));
        w.start_taken(y);
        w.blocking(x, y).unwrap();
        w.tick(1);
        fault.store(false, Ordering::Relaxed);
        w.take(e);
        assert_eq!([y, x, e].map(|id| w.state(id)), [Running; 3], "set-up");
        (w, [y, x, e])
    };
    let count = sections(setup, |(w, [_, x, _])| Port::abandon(w.seq, *x, &()));
    every_k(count + 1, |k| {
        let (w, [y, x, e]) = setup();
        let party = move || {
            let _ = w.complete(e);
            w.tick(2);
        };
        interleaved::at(k, party);
        Port::abandon(w.seq, x, &());
        or_after(k, party);
        w.tick(3);
        let what = name::<L>(layout, format_args!("k={k}"));
        assert_eq!(w.state(x), Aborted, "{what}: X {:?}", w.ended(x));
        assert!(
            [Cause::Dropped, M0].contains(&w.ended(x).1),
            "{what}: X {:?}",
            w.ended(x)
        );
        assert_eq!(w.moves(x, Aborting, Aborted), 1, "{what}");
        assert!(
            [Terminated, Aborted].contains(&w.state(e)),
            "{what}: E {:?}",
            w.state(e)
        );
        assert_eq!(w.state(y), Running, "{what}: Y");
        let into = |id: SeqId| {
            w.transitions(id)
                .iter()
                .filter(|t| t.to == Aborting || t.to == Restarting)
                .count()
        };
        assert_eq!(hooks(), [y, x, e].map(into), "{what}: hooks");
        w.check(&what);
    });
}

#[test]
fn exception_end_into_a_dropped_held_owner() {
    every_world!(exception_end_into_drop_of_held_owner);
}
