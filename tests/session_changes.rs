//! Cold review of one session's library changes (`git diff 5ca0a80 HEAD -- src/`):
//! safety-table validation (undefined transition levels, NaN values, empty `off_range`
//! bands, input events out of range), monitor tables whose owners lie beyond the
//! sequencer's set words, lane futures refused for want of a slot, the simulator's
//! re-validation, and the new messages.
//!
//! Each test asserts exact behaviour (four defects the review found are fixed; their tests
//! fail without the fixes).

use core::cell::Cell;

use rtseq::lock::CriticalSection;
use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, ConfigError, Cx, Duration, Entry, Error, Event, Failure, Instant, Monitor,
    Monitors, Record, RunningState::*, SeqConfig, SeqId, Sequence, Sequencer, WithNames,
};

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

fn id(i: usize) -> SeqId {
    SeqId::from_index(i)
}

fn ms(n: u64) -> Instant {
    Instant::from_ticks(n * 1_000)
}

fn transition(
    ms: u64,
    sequence: SeqId,
    from: rtseq::RunningState,
    to: rtseq::RunningState,
    cause: Cause,
) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1_000),
        entry: Entry::Transition {
            sequence,
            from,
            to,
            cause,
        },
    }
}

fn event(ms: u64, e: Event) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1_000),
        entry: Entry::Event(e),
    }
}

fn always(_: &Cell<u32>, _: Instant) -> bool {
    true
}

/// A name for sequence `i` (names are `&'static str`).
fn name(i: usize) -> &'static str {
    Box::leak(format!("s{i}").into_boxed_str())
}

// =======================================================================================
// Safety properties
// =======================================================================================

struct Io;

const E0: PrivateEvent = PrivateEvent::new(0);
const E1: PublicEvent = PublicEvent::new(1);
const L0: SafetyLevel = SafetyLevel::new(0);
const L1: SafetyLevel = SafetyLevel::new(1);

fn levels<const L: usize>() -> [LevelDef<'static, Io>; L] {
    core::array::from_fn(|i| LevelDef::new(SafetyLevel::new(i as u8), "l"))
}

fn props<const L: usize>(rows: &'static [LevelTransition]) -> SafetyProperties<'static, Io, L> {
    SafetyProperties::new(levels::<L>(), &[], &[], rows, L0)
}

/// 256 levels (every `SafetyLevel` defined): `on_level_and_above`'s open end 255 is then a
/// defined level too, a row to level 255 is valid, and a row on level 255 alone conflicts
/// with an open-ended row of the same event, at level 255.
#[test]
fn with_256_levels_level_255_is_defined_and_the_open_end_conflicts_there() {
    static ROWS: [LevelTransition; 2] = [
        LevelTransition::on_level_and_above(SafetyLevel::new(254), E0, SafetyLevel::new(255)),
        LevelTransition::on(SafetyLevel::new(255), E1, L0),
    ];
    assert_eq!(props::<256>(&ROWS).validate(), Ok(()));
    static CLASH: [LevelTransition; 2] = [
        LevelTransition::on_level_and_above(SafetyLevel::new(254), E0, L0),
        LevelTransition::on(SafetyLevel::new(255), E0, L1),
    ];
    assert_eq!(
        props::<256>(&CLASH).validate(),
        Err(SafetyError::ConflictingTransition {
            level: SafetyLevel::new(255),
            event: E0.id(),
        })
    );
}

/// With 255 levels (0..=254), 255 is the open end only as a row's upper end: as its lower
/// end (`on_level_and_above(255)`) or its destination it is an undefined level, named.
#[test]
fn with_255_levels_level_255_is_undefined_except_as_the_open_end() {
    static OPEN: [LevelTransition; 1] = [LevelTransition::on_level_and_above(
        SafetyLevel::new(254),
        E0,
        L0,
    )];
    assert_eq!(props::<255>(&OPEN).validate(), Ok(()));
    static FROM_255: [LevelTransition; 1] = [LevelTransition::on_level_and_above(
        SafetyLevel::new(255),
        E0,
        L0,
    )];
    let err = props::<255>(&FROM_255).validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::UndefinedTransitionLevel {
            index: 0,
            level: SafetyLevel::new(255),
        }
    );
    assert_eq!(
        err.to_string(),
        "transition row 0 names level 255, which is not defined"
    );
    static TO_255: [LevelTransition; 2] = [
        LevelTransition::on(L0, E1, L1),
        LevelTransition::on_level_and_above(L1, E0, SafetyLevel::new(255)),
    ];
    assert_eq!(
        props::<255>(&TO_255).validate(),
        Err(SafetyError::UndefinedTransitionLevel {
            index: 1,
            level: SafetyLevel::new(255),
        })
    );
}

/// Rows are checked one by one before conflicts are looked for: a conflict between rows 0
/// and 1 loses to an undefined level in row 2, and to an event out of range in row 2.
/// Within one row the order is: event, `from_low > from_high`, lower end, upper end,
/// destination.
#[test]
fn every_row_is_checked_before_any_conflict_and_each_row_in_a_fixed_order() {
    static UNDEFINED_LATER: [LevelTransition; 3] = [
        LevelTransition::on(L0, E0, L1),
        LevelTransition::on(L0, E0, L0),
        LevelTransition::on(L1, E1, SafetyLevel::new(7)),
    ];
    assert_eq!(
        props::<2>(&UNDEFINED_LATER).validate(),
        Err(SafetyError::UndefinedTransitionLevel {
            index: 2,
            level: SafetyLevel::new(7),
        })
    );
    static EVENT_LATER: [LevelTransition; 3] = [
        LevelTransition::on(L0, E0, L1),
        LevelTransition::on(L0, E0, L0),
        LevelTransition::on(L1, PublicEvent::new(32), L0),
    ];
    assert_eq!(
        props::<2>(&EVENT_LATER).validate(),
        Err(SafetyError::EventOutOfRange {
            event: PublicEvent::new(32).id(),
        })
    );
    // One row, everything wrong: the event first.
    static ALL_WRONG: [LevelTransition; 1] = [LevelTransition::on_levels_between(
        SafetyLevel::new(9),
        SafetyLevel::new(8),
        PrivateEvent::new(40),
        SafetyLevel::new(9),
    )];
    assert_eq!(
        props::<2>(&ALL_WRONG).validate(),
        Err(SafetyError::EventOutOfRange {
            event: PrivateEvent::new(40).id(),
        })
    );
    // An inverted range of undefined levels: inverted first (it covers no level at all).
    static INVERTED: [LevelTransition; 1] = [LevelTransition::on_levels_between(
        SafetyLevel::new(9),
        SafetyLevel::new(8),
        E0,
        SafetyLevel::new(9),
    )];
    let err = props::<2>(&INVERTED).validate().unwrap_err();
    assert_eq!(err, SafetyError::InvalidTransition { index: 0 });
    assert_eq!(
        err.to_string(),
        "transition row 0 covers no level (from_low > from_high)"
    );
    // Lower end, then upper end, then destination.
    static BOTH_ENDS: [LevelTransition; 1] = [LevelTransition::on_levels_between(
        SafetyLevel::new(5),
        SafetyLevel::new(6),
        E0,
        SafetyLevel::new(7),
    )];
    assert_eq!(
        props::<2>(&BOTH_ENDS).validate(),
        Err(SafetyError::UndefinedTransitionLevel {
            index: 0,
            level: SafetyLevel::new(5),
        })
    );
    static UPPER: [LevelTransition; 1] = [LevelTransition::on_levels_between(
        L1,
        SafetyLevel::new(6),
        E0,
        SafetyLevel::new(7),
    )];
    assert_eq!(
        props::<2>(&UPPER).validate(),
        Err(SafetyError::UndefinedTransitionLevel {
            index: 0,
            level: SafetyLevel::new(6),
        })
    );
    // `on_levels_between(x, 255)` is the same row as `on_level_and_above(x)`: accepted.
    static EXPLICIT_255: [LevelTransition; 1] = [LevelTransition::on_levels_between(
        L1,
        SafetyLevel::new(255),
        E0,
        L0,
    )];
    assert_eq!(props::<2>(&EXPLICIT_255).validate(), Ok(()));
}

// A machine with inputs and outputs for the per-level checks.

const POS: CriticalInput<i32> = CriticalInput::new(0, "position");
const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "current");
const LIMIT: CriticalOutput<f32> = CriticalOutput::new(0, "torque limit");
const DUTY: CriticalOutput<i32> = CriticalOutput::new(1, "duty");
const INS: [CriticalInputInfo; 2] = [POS.info(), CURRENT.info()];
const OUTS: [CriticalOutputInfo; 2] = [LIMIT.info(), DUTY.info()];
const STAY: [LevelTransition; 2] = [
    LevelTransition::on_level_and_above(L0, E0, L0),
    LevelTransition::on_level_and_above(L0, E1, L0),
];
const QUIET: [InputAction; 2] = [POS.ignore(), CURRENT.ignore()];
const SAFE: [OutputAction; 2] = [LIMIT.set(0.0), DUTY.set(0)];

fn machine(
    inputs: &'static [InputAction],
    outputs: &'static [OutputAction],
) -> SafetyProperties<'static, Io, 2> {
    SafetyProperties::new(
        [
            LevelDef::new(L0, "off").inputs(&QUIET).outputs(&SAFE),
            LevelDef::new(L1, "run").inputs(inputs).outputs(outputs),
        ],
        &INS,
        &OUTS,
        &STAY,
        L0,
    )
}

fn invalid_range(input: InputId, input_name: &'static str) -> Result<(), SafetyError> {
    Err(SafetyError::InvalidRange {
        level: L1,
        level_name: "run",
        input,
        input_name,
    })
}

/// Integer bands at the ends of `i32` (the width `max - min` computed without overflow):
/// `(MIN, MIN + 2)` holds `MIN + 1` and is accepted, `(MAX - 1, MAX)` holds nothing, and
/// `(MAX, MIN)` is inverted; `range(MIN, MAX)` and `range(MAX, MAX)` are valid.
#[test]
fn integer_bands_at_the_ends_of_i32() {
    macro_rules! int {
        ($check:expr) => {{
            static INPUTS: [InputAction; 2] = [$check, CURRENT.ignore()];
            machine(&INPUTS, &SAFE).validate()
        }};
    }
    assert_eq!(int!(POS.off_range(i32::MIN, i32::MIN + 2, E0)), Ok(()));
    assert_eq!(int!(POS.off_range(i32::MAX - 2, i32::MAX, E0)), Ok(()));
    assert_eq!(
        int!(POS.off_range(i32::MAX - 1, i32::MAX, E0)),
        invalid_range(POS.id(), "position")
    );
    assert_eq!(
        int!(POS.off_range(i32::MAX, i32::MIN, E0)),
        invalid_range(POS.id(), "position")
    );
    assert_eq!(int!(POS.range(i32::MIN, i32::MAX, E0)), Ok(()));
    assert_eq!(int!(POS.range(i32::MAX, i32::MAX, E0)), Ok(()));
    assert_eq!(
        int!(POS.range(i32::MAX, i32::MIN, E0)),
        invalid_range(POS.id(), "position")
    );
    // The accepted band at the bottom fires on exactly the one value inside.
    let band = POS.off_range(i32::MIN, i32::MIN + 2, E0).check();
    assert_eq!(band.evaluate(IoValue::Int(i32::MIN)), None);
    assert_eq!(band.evaluate(IoValue::Int(i32::MIN + 1)), Some(E0.id()));
    assert_eq!(band.evaluate(IoValue::Int(i32::MIN + 2)), None);
    assert_eq!(band.evaluate(IoValue::Int(i32::MAX)), None);
}

/// A float band between two neighbouring floats, `(1.0, 1.0 + ε)` or `(f32::MAX, +inf)`,
/// holds no value either: like `(1.0, 1.0)` it catches only NaN readings.
#[test]
fn a_float_band_between_adjacent_floats_is_refused() {
    const ONE_UP: f32 = f32::from_bits(1.0f32.to_bits() + 1);
    // Nothing lies inside: every non-NaN reading passes.
    let band = CURRENT.off_range(1.0, ONE_UP, E0).check();
    for v in [f32::NEG_INFINITY, 0.0, 1.0, ONE_UP, 2.0, f32::INFINITY] {
        assert_eq!(band.evaluate(IoValue::Float(v)), None, "{v}");
    }
    assert_eq!(band.evaluate(IoValue::Float(f32::NAN)), Some(E0.id()));
    macro_rules! float {
        ($check:expr) => {{
            static INPUTS: [InputAction; 2] = [POS.ignore(), $check];
            machine(&INPUTS, &SAFE).validate()
        }};
    }
    assert_eq!(
        float!(CURRENT.off_range(1.0, ONE_UP, E0)),
        invalid_range(CURRENT.id(), "current")
    );
    assert_eq!(
        float!(CURRENT.off_range(f32::MAX, f32::INFINITY, E0)),
        invalid_range(CURRENT.id(), "current")
    );
}

/// Float edge cases that are right today: a band across both zeros is empty (`-0.0 ==
/// 0.0`); the smallest band around zero holds ±0; an infinite `range` and a `check` of
/// an infinity are valid; NaN anywhere in a check is `InvalidRange`, before the event is
/// looked at (a NaN check of event 40 is `InvalidRange`, not `InputEventOutOfRange`).
#[test]
fn float_checks_at_zero_infinity_and_nan() {
    macro_rules! float {
        ($check:expr) => {{
            static INPUTS: [InputAction; 2] = [POS.ignore(), $check];
            machine(&INPUTS, &SAFE).validate()
        }};
    }
    let bad = invalid_range(CURRENT.id(), "current");
    assert_eq!(float!(CURRENT.off_range(-0.0, 0.0, E0)), bad);
    assert_eq!(float!(CURRENT.off_range(0.0, -0.0, E0)), bad);
    const TINY: f32 = f32::from_bits(1);
    assert_eq!(float!(CURRENT.off_range(-TINY, TINY, E0)), Ok(()));
    let band = CURRENT.off_range(-TINY, TINY, E0).check();
    assert_eq!(band.evaluate(IoValue::Float(-0.0)), Some(E0.id()));
    assert_eq!(band.evaluate(IoValue::Float(0.0)), Some(E0.id()));
    assert_eq!(band.evaluate(IoValue::Float(TINY)), None);
    assert_eq!(
        float!(CURRENT.range(f32::NEG_INFINITY, f32::INFINITY, E0)),
        Ok(())
    );
    assert_eq!(float!(CURRENT.check(f32::INFINITY, E0)), Ok(()));
    assert_eq!(float!(CURRENT.check(-0.0, E0)), Ok(()));
    assert_eq!(float!(CURRENT.check(f32::NAN, E0)), bad);
    assert_eq!(float!(CURRENT.range(f32::NAN, 1.0, E0)), bad);
    assert_eq!(float!(CURRENT.off_range(0.0, f32::NAN, E0)), bad);
    assert_eq!(float!(CURRENT.check(f32::NAN, PrivateEvent::new(40))), bad);
    assert_eq!(
        bad.unwrap_err().to_string(),
        "level 'run': the check of input 'current' has min > max, an empty band or a NaN value"
    );
}

/// NaN in a `toggle`'s low phase, its high phase or both, and in a `set`: each is
/// `NanOutputValue`, naming the level and output; an `i32` toggle and a `leave` are fine.
#[test]
fn nan_in_either_phase_of_a_toggle_is_refused() {
    macro_rules! out {
        ($limit:expr) => {{
            static OUTPUTS: [OutputAction; 2] = [$limit, DUTY.toggle(i32::MIN, i32::MAX)];
            machine(&QUIET, &OUTPUTS).validate()
        }};
    }
    let nan = Err(SafetyError::NanOutputValue {
        level: L1,
        level_name: "run",
        output: LIMIT.id(),
        output_name: "torque limit",
    });
    assert_eq!(out!(LIMIT.toggle(f32::NAN, 1.0)), nan);
    assert_eq!(out!(LIMIT.toggle(1.0, f32::NAN)), nan);
    assert_eq!(out!(LIMIT.toggle(f32::NAN, f32::NAN)), nan);
    assert_eq!(out!(LIMIT.set(-f32::NAN)), nan);
    assert_eq!(out!(LIMIT.toggle(f32::NEG_INFINITY, f32::INFINITY)), Ok(()));
    assert_eq!(out!(LIMIT.leave()), Ok(()));
    // Inputs of the level are checked before its outputs.
    static BOTH: [InputAction; 2] = [POS.ignore(), CURRENT.check(f32::NAN, E0)];
    static NAN_OUT: [OutputAction; 2] = [LIMIT.set(f32::NAN), DUTY.set(0)];
    assert_eq!(
        machine(&BOTH, &NAN_OUT).validate(),
        invalid_range(CURRENT.id(), "current")
    );
}

/// An input's event id ≥ 32: the error names level, input and event, with its exact
/// message; the table's own `EventOutOfRange` keeps its message.
#[test]
fn an_input_event_out_of_range_has_an_exact_message() {
    static INPUTS: [InputAction; 2] = [POS.range(0, 10, PublicEvent::new(33)), CURRENT.ignore()];
    let err = machine(&INPUTS, &SAFE).validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::InputEventOutOfRange {
            level: L1,
            level_name: "run",
            input: POS.id(),
            input_name: "position",
            event: PublicEvent::new(33).id(),
        }
    );
    assert_eq!(
        err.to_string(),
        format!(
            "level 'run': input 'position' triggers {}, whose id is out of range (max 31)",
            PublicEvent::new(33).id()
        )
    );
    assert_eq!(
        SafetyError::EventOutOfRange {
            event: PublicEvent::new(33).id()
        }
        .to_string(),
        format!("{}: id out of range (max 31)", PublicEvent::new(33).id())
    );
}

// =======================================================================================
// Monitor tables with owners beyond the sequencer's set words
// =======================================================================================

/// Two words (ids 0..64): an owner at 63, the last id of the last word, is the
/// sequencer's: its monitor is evaluated. A table with an owner at 64 (a third word) is
/// refused, and nothing of it runs.
#[test]
fn an_owner_at_the_last_id_of_the_last_word_is_taken_and_one_beyond_is_not() {
    let seq: Sequencer<Cell<u32>, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    for i in 0..64 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let last = seq.sequence_by_id(id(63)).unwrap();
    last.declare_lane().unwrap();
    last.start().unwrap();
    let calls = Cell::new(0);
    let mut counting = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        true
    };
    let mut ok: Monitors<Cell<u32>, 1> = Monitors::new();
    let jam = ok
        .add(
            id(63),
            Monitor::new("jam", &mut counting, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.validate(&ok), Ok(()));
    assert_eq!(seq.tick(ms(1), &calls, &mut ok), Ok(()));
    assert_eq!(calls.get(), 1);
    assert_eq!(last.state(), Aborted);
    assert_eq!(ok.fired(jam), 1);

    let seq2: Sequencer<Cell<u32>, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    seq2.register(SeqConfig::new("a")).unwrap();
    let calls2 = Cell::new(0);
    let mut counting2 = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        true
    };
    let mut beyond: Monitors<Cell<u32>, 1> = Monitors::new();
    beyond
        .add(
            id(64),
            Monitor::new("far", &mut counting2, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(
        seq2.tick(ms(1), &calls2, &mut beyond),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(calls2.get(), 0);
}

/// `B = 8`, ids up to 255: an owner at 255 is in the last word, the table is bound and
/// its monitor fires on sequence 255.
#[test]
fn eight_words_take_an_owner_at_255() {
    let seq: Sequencer<Cell<u32>, 256, 64, CriticalSection, 8, 8> = Sequencer::new();
    for i in 0..256 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let top = seq.sequence_by_id(id(255)).unwrap();
    top.declare_lane().unwrap();
    top.start().unwrap();
    let mut fires = always;
    let mut monitors: Monitors<Cell<u32>, 1> = Monitors::new();
    let m = monitors
        .add(
            id(255),
            Monitor::new("top", &mut fires, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.validate(&monitors), Ok(()));
    assert_eq!(seq.tick(ms(1), &Cell::new(0), &mut monitors), Ok(()));
    assert_eq!(top.state(), Aborted);
    assert_eq!(monitors.fired(m), 1);
}

/// A sequencer with more words than it needs (`N = 16`, `B = 2`): an owner at 40 lies in
/// its sets (word 1, no alias of a lower id), so the table is bound; no sequence 40
/// exists, so nothing is due and its condition never runs, while sequence 8 is untouched.
#[test]
fn a_sequencer_with_spare_words_binds_a_table_of_an_owner_in_them_without_aliasing() {
    let seq: Sequencer<Cell<u32>, 16, 64, CriticalSection, 8, 2> = Sequencer::new();
    for i in 0..9 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let s8 = seq.sequence_by_id(id(8)).unwrap();
    s8.declare_lane().unwrap();
    s8.start().unwrap();
    let calls = Cell::new(0);
    let mut counting = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        true
    };
    let mut monitors: Monitors<Cell<u32>, 1> = Monitors::new();
    let ghost = monitors
        .add(
            id(40),
            Monitor::new("ghost", &mut counting, Behaviour::AbortOwner),
        )
        .unwrap();
    for t in 1..=3 {
        assert_eq!(seq.tick(ms(t), &calls, &mut monitors), Ok(()));
    }
    assert_eq!(calls.get(), 0);
    assert_eq!(monitors.fired(ghost), 0);
    assert_eq!(s8.state(), Running);
}

/// A table made anew in the place of the bound one is bound again, unless an owner lies
/// beyond the sets: refused (nothing evaluated), and the good table made again in that
/// place afterwards is taken.
#[test]
fn a_table_remade_in_place_with_a_foreign_owner_is_refused_and_a_good_one_taken_again() {
    let seq: Sequencer<Cell<u32>, 16> = Sequencer::new();
    for i in 0..9 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let s8 = seq.sequence_by_id(id(8)).unwrap();
    s8.declare_lane().unwrap();
    s8.start().unwrap();
    let calls = Cell::new(0);
    let mut counting = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        false
    };
    let mut monitors: Monitors<Cell<u32>, 1> = Monitors::new();
    monitors
        .add(
            id(8),
            Monitor::new("own", &mut counting, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.tick(ms(1), &calls, &mut monitors), Ok(()));
    assert_eq!(calls.get(), 1);
    let mut counting2 = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 100);
        true
    };
    monitors = Monitors::new();
    monitors
        .add(
            id(40),
            Monitor::new("ghost", &mut counting2, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(
        seq.tick(ms(2), &calls, &mut monitors),
        Err(Error::ForeignMonitorTable)
    );
    assert_eq!(calls.get(), 1);
    assert_eq!(s8.state(), Running);
    let mut counting3 = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        false
    };
    monitors = Monitors::new();
    monitors
        .add(
            id(8),
            Monitor::new("own", &mut counting3, Behaviour::AbortOwner),
        )
        .unwrap();
    assert_eq!(seq.tick(ms(3), &calls, &mut monitors), Ok(()));
    assert_eq!(calls.get(), 2);
}

/// A table bound to a one-word sequencer, to which a monitor of owner 40 is added after
/// binding (the tick task owns the table and may add). Today owner 40 reads as sequence
/// 8 (40 mod 32), which is running: the ticks return `Ok` and the condition runs at every
/// poll of 8, with its side effects (it never fires: 40 has no run).
#[test]
fn a_foreign_owner_added_to_a_bound_table_is_never_evaluated() {
    let seq: Sequencer<Cell<u32>, 16> = Sequencer::new();
    for i in 0..9 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let s8 = seq.sequence_by_id(id(8)).unwrap();
    s8.declare_lane().unwrap();
    s8.start().unwrap();
    let calls = Cell::new(0);
    let mut quiet = |_: &Cell<u32>, _: Instant| false;
    let mut counting = |c: &Cell<u32>, _: Instant| {
        c.set(c.get() + 1);
        true
    };
    let mut monitors: Monitors<Cell<u32>, 2> = Monitors::new();
    monitors
        .add(id(8), Monitor::new("own", &mut quiet, Behaviour::Nothing))
        .unwrap();
    assert_eq!(seq.tick(ms(1), &calls, &mut monitors), Ok(()));
    let ghost = monitors
        .add(
            id(40),
            Monitor::new("ghost", &mut counting, Behaviour::AbortOwner),
        )
        .unwrap();
    for t in 2..=4 {
        assert_eq!(
            seq.tick(ms(t), &calls, &mut monitors),
            Err(Error::ForeignMonitorTable)
        );
    }
    assert_eq!(
        calls.get(),
        0,
        "the condition of owner 40 ran at the polls of 8"
    );
    assert_eq!(monitors.fired(ghost), 0);
    assert_eq!(s8.state(), Running);
}

// =======================================================================================
// Lanes refused for want of a slot
// =======================================================================================

/// `W = 1`: main takes the slot; the lane of `stop`, a monitor's exception sequence, is
/// refused. `validate` names the exception without a lane; started through a handle, the monitor fires and its record says why `stop` did not run:
/// `LaneCapacityExceeded(stop)`, counted in `exceptions_not_run`; the behaviour applies.
#[test]
fn an_exception_sequence_whose_lane_was_refused_is_recorded_with_lane_capacity_exceeded() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let stop = seq.add(SeqConfig::new("stop"), Forever).unwrap();
    let (m, s) = (main.id(), stop.id());
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(s)));
    // `validate` comes first: `stop` has no lane slot.
    assert_eq!(
        seq.validate(sim.monitors()),
        Err(ConfigError::ExceptionWithoutLane {
            raiser: rtseq::Raiser::Monitor(jam, "jam"),
            exception: (s, "stop"),
        })
    );
    assert_eq!(sim.start(m), Err(Error::InvalidConfig));
    assert_eq!(sim.handle(m).unwrap().start(), Ok(()));
    sim.run_for(Duration::from_millis(3));
    let j = Cause::Monitor(jam);
    assert_eq!(
        sim.records(),
        &[
            transition(0, m, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: m,
                    cause: j,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: s,
                    owner: m,
                    why: Error::LaneCapacityExceeded(s)
                }
            ),
            transition(2, m, Running, Aborting, j),
            transition(2, m, Aborting, Aborted, j),
        ]
    );
    assert_eq!(seq.exceptions_not_run(), 1);
    assert_eq!(sim.state(s), Idle);
}

/// A refused lane is named before a declared lane no task polls (the order `check_lanes`'
/// doc gives), and only the first refusal is remembered.
#[test]
fn check_lanes_names_the_first_refusal_before_an_unpolled_declared_lane() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let a = seq.register(SeqConfig::new("a").in_lane()).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let c = seq.add(SeqConfig::new("c"), Forever).unwrap();
    let (ib, ic) = (b.id(), c.id());
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(b);
    sim.lane(c);
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(ib)));
    assert_eq!(sim.start(ic), Err(Error::LaneCapacityExceeded(ib)));
    // Without the simulator's check: each start says what it lacks.
    assert_eq!(
        seq.sequence_by_id(ic).unwrap().start(),
        Err(Error::LaneCapacityExceeded(ic))
    );
    // `a` has the slot, but no task polls it: its start is taken and never run.
    assert_eq!(seq.sequence_by_id(a).unwrap().start(), Ok(()));
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(a), Running);
}

/// A sequence that never had a lane future, started when every slot is declared, is told
/// `LaneCapacityExceeded` (declaring one would fail); with a slot free it is `NoLane`; a
/// declared lane closed by its dropped future stays `NoLane` even with all slots taken.
#[test]
fn a_start_without_a_lane_says_capacity_only_when_no_slot_could_be_had() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 2> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let plain = seq.register(SeqConfig::new("plain")).unwrap();
    let ia = a.id();
    let h = seq.sequence_by_id(plain).unwrap();
    assert_eq!(h.start(), Err(Error::NoLane(plain)));
    {
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
        sim.lane(a);
        assert_eq!(h.start(), Err(Error::NoLane(plain)));
        let last = seq.register(SeqConfig::new("last").in_lane()).unwrap();
        assert_eq!(h.start(), Err(Error::LaneCapacityExceeded(plain)));
        assert_eq!(h.declare_lane(), Err(Error::LaneCapacityExceeded(plain)));
        let _ = last;
    }
    // The simulator dropped `a`'s lane future: its lane is closed, not refused.
    assert_eq!(
        seq.sequence_by_id(ia).unwrap().start(),
        Err(Error::NoLane(ia))
    );
    assert_eq!(h.start(), Err(Error::LaneCapacityExceeded(plain)));
}

/// A lane future of another sequencer's object polled here declares nothing and is not
/// remembered as refused (it is not this sequencer's shortage of slots); nor is it in
/// the other sequencer. A start here of the id it carries (a sequence without a lane
/// here, every slot declared) says `LaneCapacityExceeded`: `ForeignSequence`'s doc says
/// such a start "says `NoLane`", which holds only while a slot is free.
#[test]
fn another_sequencers_object_polled_as_a_lane_here_is_not_a_refusal() {
    let here: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let mine = here.add(SeqConfig::new("mine"), Forever).unwrap();
    let same_id = here.register(SeqConfig::new("plain")).unwrap();
    let other: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    other.register(SeqConfig::new("o")).unwrap();
    let theirs = other.add(SeqConfig::new("x"), Forever).unwrap();
    let t = theirs.id();
    assert_eq!(t, same_id);
    let mut sim = Sim::new(&here, &(), Monitors::<(), 1>::new());
    sim.lane(mine);
    let h = &here;
    sim.task_with_priority(
        async move {
            let mut theirs = theirs;
            rtseq::lane(h, &(), &mut theirs).await
        },
        1,
    );
    assert_eq!(here.check_lanes(), Ok(()));
    assert_eq!(other.check_lanes(), Ok(()));
    assert_eq!(
        here.sequence_by_id(t).unwrap().start(),
        Err(Error::LaneCapacityExceeded(t))
    );
    assert_eq!(
        other.sequence_by_id(t).unwrap().start(),
        Err(Error::NoLane(t))
    );
}

/// A refused lane future later dropped (its simulator dropped) leaves the sequence with
/// no lane, as if it never had one. A second simulator that gives lanes to `a` alone
/// (fitting `W = 1`) is a valid configuration: its start should go.
#[test]
fn a_refusal_is_forgotten_with_its_lane_future() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let mut a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let (ia, ib) = (a.id(), b.id());
    {
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
        let s = &seq;
        let a = &mut a;
        sim.task_with_priority(async move { rtseq::lane(s, &(), a).await }, 1);
        sim.lane(b);
        assert_eq!(sim.start(ia), Err(Error::LaneCapacityExceeded(ib)));
    }
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(a);
    assert_eq!(seq.check_lanes(), Ok(()));
    assert_eq!(sim.start(ia), Ok(()));
    assert_eq!(sim.state(ia), Running);
}

// =======================================================================================
// The simulator's re-validation
// =======================================================================================

/// A registration that fails (duplicate name) adds nothing: no re-validation, the next
/// start goes. A registration that succeeds is validated at the next start, lanes too:
/// a late sequence declared in a lane the simulator does not run is `NoLane` there.
#[test]
fn a_failed_registration_changes_nothing_and_a_late_unpolled_lane_is_named() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(
        seq.register(SeqConfig::new("main")),
        Err(Error::DuplicateName(m))
    );
    sim.abort(m).unwrap();
    sim.step();
    assert_eq!(sim.start(m), Ok(()));
    let late = seq.register(SeqConfig::new("late").in_lane()).unwrap();
    sim.abort(m).unwrap();
    sim.step();
    assert_eq!(sim.start(m), Err(Error::NoLane(late)));
    assert_eq!(sim.state(m), Aborted);
}

/// After the simulator's first start, `Handle::declare_lane` of a sequence registered
/// before declares a lane no task polls, without a registration: the simulator's start of
/// it should be refused (`NoLane`), as at the first start, rather than taken and never run.
#[test]
fn a_lane_declared_after_the_first_start_is_checked_at_the_next() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    let other = seq.register(SeqConfig::new("other")).unwrap();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    let h = sim.handle(other).unwrap();
    assert_eq!(h.declare_lane(), Ok(()));
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(other)));
    assert_eq!(sim.start(other), Err(Error::NoLane(other)));
    sim.run_for(Duration::from_millis(5));
    assert_eq!(sim.state(other), Idle);
}

// =======================================================================================
// Messages and `core::error::Error`
// =======================================================================================

/// `NoLane`'s message, plain and with names (src/names.rs's module example and
/// `WithNames` example, and tests/names.rs, still expect "... has no lane"), and the
/// `core::error::Error` impls.
#[test]
fn no_lane_messages_and_the_error_trait() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let homing = seq.register(SeqConfig::new("homing")).unwrap();
    assert_eq!(
        Error::NoLane(homing).to_string(),
        "sequence 0 has no lane that a task polls"
    );
    assert_eq!(
        Error::NoLane(homing).named(&seq).to_string(),
        "sequence `homing` has no lane that a task polls"
    );
    assert_eq!(
        Failure::NotStarted(Error::NoLane(homing))
            .named(&seq)
            .to_string(),
        "not started: sequence `homing` has no lane that a task polls"
    );
    let stop = seq.register(SeqConfig::new("safe stop")).unwrap();
    assert_eq!(
        Event::ExceptionNotRun {
            exception: stop,
            owner: homing,
            why: Error::NoLane(stop),
        }
        .named(&seq)
        .to_string(),
        "exception sequence `safe stop` of `homing` not run: sequence `safe stop` has no lane that a task polls"
    );
    assert_eq!(
        Error::NoLane(homing).reason(),
        "sequence has no lane a task polls"
    );
    let e: Box<dyn std::error::Error> = Box::new(Error::LaneCapacityExceeded(homing));
    assert_eq!(e.to_string(), "no lane slot left for sequence 0");
    assert!(e.source().is_none());
    let c: Box<dyn std::error::Error> = Box::new(ConfigError::UnknownOwner {
        monitor: (rtseq::MonitorId::from_index(0), "ghost"),
        owner: id(40),
    });
    assert_eq!(
        c.to_string(),
        "monitor `ghost` is owned by sequence 40, which is not registered"
    );
    fn question_mark() -> Result<(), Box<dyn std::error::Error>> {
        Err(Error::InvalidConfig)?
    }
    assert_eq!(
        question_mark().unwrap_err().to_string(),
        "invalid configuration (see Sequencer::validate)"
    );
}

/// The owner check binds tables by their owners alone; a monitor's *exception* id beyond
/// the sets (40 in a one-word sequencer) does not alias sequence 8: its start is
/// `UnknownSequence(40)`, recorded, and the behaviour applies at once; 8 is untouched.
#[test]
fn an_exception_id_beyond_the_sets_is_unknown_not_an_alias() {
    let seq: Sequencer<(), 16> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    for i in 1..9 {
        seq.register(SeqConfig::new(name(i))).unwrap();
    }
    let s8 = seq.sequence_by_id(id(8)).unwrap();
    s8.declare_lane().unwrap();
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(id(40)),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.handle(m).unwrap().start().unwrap();
    sim.run_for(Duration::from_millis(3));
    let j = Cause::Monitor(jam);
    assert_eq!(
        sim.records(),
        &[
            transition(0, m, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: m,
                    cause: j,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: id(40),
                    owner: m,
                    why: Error::UnknownSequence(id(40))
                }
            ),
            transition(2, m, Running, Aborting, j),
            transition(2, m, Aborting, Aborted, j),
        ]
    );
    assert_eq!(s8.state(), Idle);
    assert_eq!(sim.tick_error(), None);
}
