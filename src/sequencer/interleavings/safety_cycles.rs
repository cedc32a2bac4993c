//! The safety system's abort-all against the sequencer under preemption (a cold review of
//! session 56, which found nothing here): an abort-all or a whole safety cycle inserted
//! before every section of a tick that is itself carrying out an abort-all, or recording
//! the safety system's notes.

use super::*;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use crate::safety::{
    AbortPolicy, LevelDef, LevelTransition, NoSequences, PublicEvent, SafetyLevel,
    SafetyProperties, SafetySystem,
};
use crate::sequencer::inbox::abort_all_posted;

/// O and P run (main, taken); an abort-all (A1) is asked for. The tick at 1 ms carries A1
/// out, with a second abort-all (A2) asked for before its section `k` (or after it). A2
/// is the same request as A1 when it came before the tick took the inbox; after that it
/// stays for the next tick (semantics 8: "An abort-all asked for again meanwhile ... stays
/// for the next tick"): Q, started by a handle after the tick at 1 ms, holds and the tick
/// at 2 ms aborts it (`AbortAll`). Either way O and P end `Aborted(AbortAll)` once, and
/// after the tick at 2 ms nothing is posted any more.
fn abort_all_into_abort_all_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let [o, p, q] = ["O", "P", "Q"].map(|n| w.seq(n));
        w.start_taken(o);
        w.start_taken(p);
        w.tick(0);
        w.seq.abort_all();
        (w, o, p, q)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, p, q) = setup();
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        interleaved::at(k, move || w.seq.abort_all());
        w.tick(1);
        let after = or_after(k, || w.seq.abort_all());
        assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}: O");
        assert_eq!(w.ended(p), (Aborted, Cause::AbortAll), "{what}: P");
        // Asked for before the tick took the inbox: one request with A1.
        let merged = k == 0 && !after;
        let posted = abort_all_posted(&w.seq.safety.inbox);
        assert_eq!(posted, !merged, "{what}: A2 kept for the next tick");
        // Q started by a handle before the tick at 2 ms.
        w.handle(q).start().unwrap();
        let taken = w.try_take(q);
        if !merged {
            // Its run holds before its pre-condition.
            if let Some(run) = taken {
                assert_ne!(w.clearance(run), Clearance::Go, "{what}: Q holds");
            }
        }
        w.tick(2);
        if merged {
            assert_eq!(w.state(q), Running, "{what}: Q after a merged abort-all");
        } else {
            assert_eq!(w.ended(q), (Aborted, Cause::AbortAll), "{what}: Q");
        }
        assert!(
            !abort_all_posted(&w.seq.safety.inbox),
            "{what}: left posted"
        );
        assert_eq!(w.moves(o, Aborting, Aborted), 1, "{what}: O once");
        assert_eq!(w.moves(p, Aborting, Aborted), 1, "{what}: P once");
        w.check(&what);
    });
}

#[test]
fn an_abort_all_asked_during_the_ticks_abort_all_stays_for_the_next_tick() {
    every_world!(abort_all_into_abort_all_tick);
}

/// A safety system built on the sequencer's handle: RUN (2) is the entry level, STOP (0,
/// `OnEntry`) is entered on the public event `GO_STOP`.
struct Io;
impl crate::safety::SafetyIo for Io {
    fn read_input(&mut self, _: crate::safety::InputId) -> crate::safety::IoValue {
        crate::safety::IoValue::Bool(false)
    }
    fn write_output(&mut self, _: crate::safety::OutputId, _: crate::safety::IoValue) {}
}
const STOP: SafetyLevel = SafetyLevel::new(0);
const MID: SafetyLevel = SafetyLevel::new(1);
const RUN: SafetyLevel = SafetyLevel::new(2);
const GO_STOP: PublicEvent = PublicEvent::new(0);
const GO_MID: PublicEvent = PublicEvent::new(1);
static PROPS: SafetyProperties<'static, Io, 3> = SafetyProperties::new(
    [
        LevelDef::new(STOP, "stop").abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(MID, "mid"),
        LevelDef::new(RUN, "run"),
    ],
    &[],
    &[],
    &[
        LevelTransition::on_level_and_above(STOP, GO_STOP, STOP),
        LevelTransition::on(RUN, GO_MID, MID),
    ],
    RUN,
);

/// What the trace says of the safety system and abort-alls, in order: `L<id>` a level,
/// A safety system of `PROPS` built on `w`'s sequencer's handle, shared by every copy of a
/// scenario.
fn safety_system_of<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
) -> &'static RefCell<SafetySystem<'static, Io, 3>> {
    Box::leak(Box::new(RefCell::new(
        SafetySystem::new(&PROPS, &w.seq.safety).unwrap(),
    )))
}

/// `A` an abort-all.
fn safety_records<L: Lock + 'static, const N: usize, const B: usize>(
    w: &World<L, N, B>,
) -> Vec<String> {
    w.records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::SafetyLevel { level }) => Some(format!("L{}", level.id())),
            Some(Event::AbortAll { .. }) => Some(String::from("A")),
            _ => None,
        })
        .collect()
}

/// O runs. The safety system entered RUN (its note recorded by the tick at 0), then MID
/// was asked for (`GO_MID`) and entered by a cycle before the tick at 1 ms (its note
/// waits in the inbox); `GO_STOP` is pending. The cycle that enters STOP (`OnEntry`)
/// runs before section `k` of the tick at 1 ms (or after it). The trace has each level
/// once, in the order entered, and the abort-all after STOP's record; O is
/// `Aborted(AbortAll)` by the tick at 2 ms, at the latest, and never before the cycle.
fn cycle_into_tick<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        w.start_taken(o);
        let safety = safety_system_of(&w);
        safety.borrow_mut().cycle(&mut Io, w.seq);
        w.tick(0);
        w.seq.safety.trigger(GO_MID);
        safety.borrow_mut().cycle(&mut Io, w.seq);
        w.seq.safety.trigger(GO_STOP);
        (w, o, safety)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, safety) = setup();
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let cycle = move || {
            let report = safety.borrow_mut().cycle(&mut Io, w.seq);
            assert_eq!(report.level, STOP);
            assert!(report.aborted);
        };
        interleaved::at(k, cycle);
        w.tick(1);
        or_after(k, cycle);
        w.tick(2);
        assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}: O");
        assert_eq!(
            safety_records(&w),
            ["L2", "L1", "L0", "A"],
            "{what}: the levels and the abort-all"
        );
        assert!(
            !abort_all_posted(&w.seq.safety.inbox),
            "{what}: left posted"
        );
        w.check(&what);
    });
}

#[test]
fn a_safety_cycle_anywhere_in_a_tick_keeps_the_levels_and_the_abort_all_in_order() {
    every_world!(cycle_into_tick);
}

/// The safety system without `Sequences` (`NoSequences`) still reaches the sequencer
/// whose handle it is built on: the cycle before section `k` of a tick, O aborted by the
/// tick at 2 ms at the latest; no level in the trace.
fn cycle_without_sequences_into_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        w.start_taken(o);
        let safety = safety_system_of(&w);
        safety.borrow_mut().cycle(&mut Io, &NoSequences);
        w.tick(0);
        w.seq.safety.trigger(GO_STOP);
        (w, o, safety)
    };
    let count = sections(setup, |(w, ..)| w.tick(1));
    every_k(count + 1, |k| {
        let (w, o, safety) = setup();
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        let cycle = move || {
            safety.borrow_mut().cycle(&mut Io, &NoSequences);
        };
        interleaved::at(k, cycle);
        w.tick(1);
        or_after(k, cycle);
        w.tick(2);
        assert_eq!(w.ended(o), (Aborted, Cause::AbortAll), "{what}: O");
        assert_eq!(safety_records(&w), ["A"], "{what}");
        w.check(&what);
    });
}

#[test]
fn a_safety_cycle_without_sequences_anywhere_in_a_tick_aborts_by_the_next() {
    every_world!(cycle_without_sequences_into_tick);
}
