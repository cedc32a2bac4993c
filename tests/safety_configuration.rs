//! Cold review: configuring and wiring the safety system, from a user's point of view.
//!
//! The project's rule: "Bad configuration or misuse gets a clear error at compile time or
//! as an `Err`, never a panic, a hang or silence." Each test tries one mistake a
//! motor-control engineer makes and asserts the exact outcome (error, message, level,
//! records). Tests marked `// DEFECT:` assert the correct behaviour and are ignored; tests
//! marked `// GAP:` pin down a behaviour the docs do not state (no error where one might be
//! expected) so that a change is noticed.
//!
//! The specification (`/work/shared/000_…txt`) has no chapter on the safety system; it
//! names it twice: "Die Methode *getSafetySystem()* gibt einen Pointer auf das
//! *SafetySystem* zurück." (1.1) and "Bei einem *Step* kann es nur ein einzelner Befehl an
//! das *ControlSystem* oder an das *SafetySystem* sein." (1.2, item 3). The rest
//! (levels, events, transitions, inputs, outputs) is EEROS's safety system as
//! docs/safety.md maps it.

use std::cell::{Cell, RefCell};

use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::{Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Sequencer, WithNames};

// ---------------------------------------------------------------------------------------
// A small machine: four levels, two inputs, two outputs
// ---------------------------------------------------------------------------------------

const EMERG: SafetyLevel = SafetyLevel::new(0);
const OFF: SafetyLevel = SafetyLevel::new(1);
const READY: SafetyLevel = SafetyLevel::new(2);
const RUN: SafetyLevel = SafetyLevel::new(3);

const START: PublicEvent = PublicEvent::new(0);
const STOP: PublicEvent = PublicEvent::new(1);
const RESET: PublicEvent = PublicEvent::new(2);
const ESTOP: PrivateEvent = PrivateEvent::new(0);

const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop");
const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "current");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
const LIMIT: CriticalOutput<f32> = CriticalOutput::new(1, "torque limit");

const INS: [CriticalInputInfo; 2] = [ESTOP_IN.info(), CURRENT.info()];
const OUTS: [CriticalOutputInfo; 2] = [ENABLE.info(), LIMIT.info()];

const WATCH: [InputAction; 2] = [
    ESTOP_IN.check(false, ESTOP),
    CURRENT.range(-8.0, 8.0, ESTOP),
];
const IGNORE: [InputAction; 2] = [ESTOP_IN.ignore(), CURRENT.ignore()];
const SAFE: [OutputAction; 2] = [ENABLE.set(false), LIMIT.set(0.0)];
const DRIVE: [OutputAction; 2] = [ENABLE.set(true), LIMIT.set(5.0)];

/// The board: input readings by id, and every write.
#[derive(Default)]
struct Io {
    estop: bool,
    current: f32,
    writes: Vec<(usize, IoValue)>,
}

impl SafetyIo for Io {
    fn read_input(&mut self, input: InputId) -> IoValue {
        if input == ESTOP_IN.id() {
            self.estop.into()
        } else {
            self.current.into()
        }
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        self.writes.push((output.index(), value));
    }
}

type P<const L: usize> = SafetyProperties<'static, Io, L>;

const fn emerg() -> LevelDef<'static, Io> {
    LevelDef::new(EMERG, "emergency")
        .inputs(&IGNORE)
        .outputs(&SAFE)
        .abort_sequences(AbortPolicy::OnEntry)
}
const fn off() -> LevelDef<'static, Io> {
    LevelDef::new(OFF, "off").inputs(&WATCH).outputs(&SAFE)
}
const fn ready() -> LevelDef<'static, Io> {
    LevelDef::new(READY, "ready").inputs(&WATCH).outputs(&SAFE)
}
const fn run() -> LevelDef<'static, Io> {
    LevelDef::new(RUN, "run").inputs(&WATCH).outputs(&DRIVE)
}

const ROWS: [LevelTransition; 4] = [
    LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
    LevelTransition::on(EMERG, RESET, OFF),
    LevelTransition::on_levels_between(OFF, READY, START, RUN),
    LevelTransition::on(RUN, STOP, READY),
];

/// The valid reference machine.
const GOOD: P<4> = P::new([emerg(), off(), ready(), run()], &INS, &OUTS, &ROWS, OFF);
const _: () = assert!(GOOD.validate().is_ok());

// ---------------------------------------------------------------------------------------
// Transitions
// ---------------------------------------------------------------------------------------

/// A row leading to a level that does not exist (a typo, or a level removed from the list
/// but not from the table) is refused by `validate` and by `SafetySystem::new` before the
/// handle is touched: not bound, no level published, its pending event kept.
#[test]
fn a_transition_to_an_undefined_level_is_an_err_and_binds_nothing() {
    const BAD: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(RUN, STOP, SafetyLevel::new(9)),
        ],
        OFF,
    );
    let expected = SafetyError::UndefinedTransitionLevel {
        index: 1,
        level: SafetyLevel::new(9),
    };
    assert_eq!(BAD.validate(), Err(expected));
    let handle = SafetyHandle::new();
    handle.trigger(START);
    assert_eq!(SafetySystem::new(&BAD, &handle).err(), Some(expected));
    assert!(!handle.is_bound());
    assert_eq!(handle.level(), SafetyLevel::SAFEST);
    assert_eq!(handle.pending_events(), 1 << START.id().index());
    assert!(matches!(BAD.validated(), Err(e) if e == expected));
}

/// The same mistake, read by the engineer: the message speaks of a "level range" although
/// the range (`from RUN`) is fine and the destination is the undefined level.
#[test]
fn the_error_for_an_undefined_destination_names_that_level() {
    const BAD: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(RUN, STOP, SafetyLevel::new(9)),
        ],
        OFF,
    );
    let err = BAD.validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::UndefinedTransitionLevel {
            index: 1,
            level: SafetyLevel::new(9)
        }
    );
    assert_eq!(
        err.to_string(),
        "transition row 1 names level 9, which is not defined"
    );
}

/// A band from OFF upwards (open to 255) and a second row for the same event from level 7,
/// which does not exist (4 levels). The error is the undefined source of row 1, not a
/// "conflict" in level 7, a level the machine does not have.
#[test]
fn a_row_from_an_undefined_level_is_invalid_not_a_conflict() {
    const BAD: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(SafetyLevel::new(7), ESTOP, OFF),
        ],
        OFF,
    );
    assert_eq!(
        BAD.validate(),
        Err(SafetyError::UndefinedTransitionLevel {
            index: 1,
            level: SafetyLevel::new(7)
        })
    );
}

/// Two rows of one event from one level: a copy-paste duplicate (same destination) is a
/// conflict too; so are a `below` band against a single row, and two bands that meet in
/// one level. Each error names the lowest level both rows cover.
#[test]
fn two_rows_of_one_event_from_one_level_are_a_conflict_even_with_one_destination() {
    const DUPLICATE: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(READY, START, RUN),
            LevelTransition::on(READY, START, RUN),
        ],
        OFF,
    );
    let err = DUPLICATE.validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::ConflictingTransition {
            level: READY,
            event: START.id()
        }
    );
    assert_eq!(
        err.to_string(),
        "two transitions for public event 0 in level 2"
    );

    const BELOW: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on_level_and_below(READY, RESET, OFF),
            LevelTransition::on(OFF, RESET, READY),
        ],
        OFF,
    );
    assert_eq!(
        BELOW.validate(),
        Err(SafetyError::ConflictingTransition {
            level: OFF,
            event: RESET.id()
        })
    );

    const BANDS: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_levels_between(OFF, READY, ESTOP, EMERG),
            LevelTransition::on_level_and_above(READY, ESTOP, OFF),
        ],
        OFF,
    );
    assert_eq!(
        BANDS.validate(),
        Err(SafetyError::ConflictingTransition {
            level: READY,
            event: ESTOP.id()
        })
    );
}

/// An event id out of range in the transition table: refused, with the id in the message.
#[test]
fn an_out_of_range_event_in_the_table_is_refused() {
    const BAD: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(OFF, PublicEvent::new(32), READY),
        ],
        OFF,
    );
    let err = BAD.validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::EventOutOfRange {
            event: EventId::public(32)
        }
    );
    assert_eq!(err.to_string(), "public event 32: id out of range (max 31)");
}

// ---------------------------------------------------------------------------------------
// Levels
// ---------------------------------------------------------------------------------------

/// Levels are ordered by id, lower = safer (EEROS: ordered levels), and listed in id order:
/// a level listed twice (copy-paste) and a gap in the ids are both refused at the first
/// wrong place, with the level found there.
#[test]
fn a_level_listed_twice_or_a_gap_in_the_ids_is_refused_where_it_occurs() {
    const TWICE: P<4> = P::new(
        [
            emerg(),
            off(),
            LevelDef::new(OFF, "ready").inputs(&WATCH).outputs(&SAFE),
            run(),
        ],
        &INS,
        &OUTS,
        &ROWS,
        OFF,
    );
    let err = TWICE.validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::LevelOutOfOrder {
            index: 2,
            level: OFF
        }
    );
    assert_eq!(
        err.to_string(),
        "levels[2] defines level 1; list levels in id order"
    );

    const GAP: P<3> = P::new(
        [emerg(), off(), run()],
        &INS,
        &OUTS,
        &[LevelTransition::on_level_and_above(OFF, ESTOP, EMERG)],
        OFF,
    );
    assert_eq!(
        GAP.validate(),
        Err(SafetyError::LevelOutOfOrder {
            index: 2,
            level: RUN
        })
    );
    // `validated` in a `static` makes the same mistake a compile error (docs); at run time
    // it is the same `Err`.
    assert!(matches!(
        GAP.validated(),
        Err(SafetyError::LevelOutOfOrder { index: 2, .. })
    ));
}

/// What `validate` does not look at (docs/semantics.md "Completeness" lists what it
/// checks, and none of these): no level aborts the sequences (no "emergency level"), two
/// levels abort them, a level that nothing leads to, a level with no way out that is not
/// the safest, a table row for an event nothing can trigger.
// GAP: none of these is an error; the docs do not say that the shape of the level graph (an emergency level, reachability, dead ends) is the application's to get right.
#[test]
fn the_shape_of_the_level_graph_is_not_checked() {
    const NO_EMERGENCY: P<2> = P::new(
        [
            LevelDef::new(EMERG, "emergency")
                .inputs(&IGNORE)
                .outputs(&SAFE),
            LevelDef::new(OFF, "off").inputs(&WATCH).outputs(&SAFE),
        ],
        &INS,
        &OUTS,
        &[LevelTransition::on(OFF, ESTOP, EMERG)],
        OFF,
    );
    assert_eq!(NO_EMERGENCY.validate(), Ok(()));

    // RUN is unreachable (no row leads to it) and, if it were reached, a dead end for the
    // public events (only ESTOP leaves it); READY aborts too; STOP has no row at all.
    const ODD: P<4> = P::new(
        [
            emerg(),
            off(),
            ready().abort_sequences(AbortPolicy::WhileActive),
            run(),
        ],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(EMERG, RESET, OFF),
            LevelTransition::on(OFF, START, READY),
        ],
        OFF,
    );
    assert_eq!(ODD.validate(), Ok(()));
}

/// Two levels that abort the sequences each do it on their own terms: `OnEntry` once when
/// entered, `WhileActive` in every cycle in the level, whichever is entered first.
#[test]
fn two_aborting_levels_each_abort_by_their_own_policy() {
    const TWO: P<4> = P::new(
        [
            emerg(),
            off(),
            ready().abort_sequences(AbortPolicy::WhileActive),
            run(),
        ],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(EMERG, RESET, OFF),
            LevelTransition::on(OFF, START, READY),
            LevelTransition::on(READY, START, RUN),
        ],
        OFF,
    );
    let handle = SafetyHandle::new();
    let mut s = SafetySystem::new(&TWO, &handle).unwrap();
    let mut io = Io::default();
    let mut aborted = Vec::new();
    let mut cycle = |s: &mut SafetySystem<'_, Io, 4>, io: &mut Io| {
        let r = s.cycle(io, &NoSequences);
        aborted.push((r.level.id(), r.aborted));
    };
    cycle(&mut s, &mut io); // OFF
    handle.trigger(START);
    cycle(&mut s, &mut io); // READY
    cycle(&mut s, &mut io); // READY
    io.estop = true;
    cycle(&mut s, &mut io); // READY, ESTOP raised
    cycle(&mut s, &mut io); // EMERG
    cycle(&mut s, &mut io); // EMERG
    assert_eq!(
        aborted,
        [
            (1, false),
            (2, true),
            (2, true),
            (2, true),
            (0, true),
            (0, false)
        ]
    );
}

// ---------------------------------------------------------------------------------------
// Inputs and outputs
// ---------------------------------------------------------------------------------------

/// Inverted and NaN limits on both number types and both range kinds are refused with the
/// level and input named; infinite limits are a valid range.
#[test]
fn inverted_and_nan_limits_are_refused_for_every_range_kind() {
    const POS: CriticalInput<i32> = CriticalInput::new(1, "position");
    const I_INS: [CriticalInputInfo; 2] = [ESTOP_IN.info(), POS.info()];
    const ROW: [LevelTransition; 1] = [LevelTransition::on_level_and_above(EMERG, ESTOP, EMERG)];
    const fn one(inputs: &'static [InputAction]) -> P<1> {
        P::new(
            [LevelDef::new(EMERG, "emergency")
                .inputs(inputs)
                .outputs(&SAFE)],
            &I_INS,
            &OUTS,
            &ROW,
            EMERG,
        )
    }
    let error = SafetyError::InvalidRange {
        level: EMERG,
        level_name: "emergency",
        input: POS.id(),
        input_name: "position",
    };
    let invalid = Err(error);
    const INT_INVERTED: P<1> = one(&[ESTOP_IN.ignore(), POS.range(100, -100, ESTOP)]);
    const INT_OFF_INVERTED: P<1> = one(&[ESTOP_IN.ignore(), POS.off_range(1, 0, ESTOP)]);
    assert_eq!(INT_INVERTED.validate(), invalid);
    assert_eq!(INT_OFF_INVERTED.validate(), invalid);
    assert_eq!(
        error.to_string(),
        "level 'emergency': the check of input 'position' has min > max, an empty band or a NaN value"
    );
    // An extreme but ordered integer range is valid.
    const INT_FULL: P<1> = one(&[ESTOP_IN.ignore(), POS.range(i32::MIN, i32::MAX, ESTOP)]);
    assert_eq!(INT_FULL.validate(), Ok(()));

    const F_INS: [CriticalInputInfo; 2] = INS;
    let float_invalid = Err(SafetyError::InvalidRange {
        level: EMERG,
        level_name: "emergency",
        input: CURRENT.id(),
        input_name: "current",
    });
    const fn onef(inputs: &'static [InputAction]) -> P<1> {
        P::new(
            [LevelDef::new(EMERG, "emergency")
                .inputs(inputs)
                .outputs(&SAFE)],
            &F_INS,
            &OUTS,
            &ROW,
            EMERG,
        )
    }
    const NAN_MAX: P<1> = onef(&[ESTOP_IN.ignore(), CURRENT.range(0.0, f32::NAN, ESTOP)]);
    const NAN_BOTH: P<1> = onef(&[
        ESTOP_IN.ignore(),
        CURRENT.off_range(f32::NAN, f32::NAN, ESTOP),
    ]);
    const INF_INVERTED: P<1> = onef(&[
        ESTOP_IN.ignore(),
        CURRENT.range(f32::INFINITY, f32::NEG_INFINITY, ESTOP),
    ]);
    assert_eq!(NAN_MAX.validate(), float_invalid);
    assert_eq!(NAN_BOTH.validate(), float_invalid);
    assert_eq!(INF_INVERTED.validate(), float_invalid);
    const INF: P<1> = onef(&[
        ESTOP_IN.ignore(),
        CURRENT.range(f32::NEG_INFINITY, f32::INFINITY, ESTOP),
    ]);
    assert_eq!(INF.validate(), Ok(()));
}

/// An `off_range` whose band is empty — `(1.0, 1.0)`, or `(4, 5)` for an integer input —
/// would never fire on a finite reading (only NaN is "inside"): a check written to catch a
/// stall that can never catch it. Refused as `InvalidRange`; a band with one value inside
/// is accepted.
#[test]
fn an_empty_off_range_band_is_refused() {
    const POS: CriticalInput<i32> = CriticalInput::new(1, "position");
    const POS_INS: [CriticalInputInfo; 2] = [ESTOP_IN.info(), POS.info()];
    const ROW: [LevelTransition; 1] = [LevelTransition::on(EMERG, ESTOP, EMERG)];
    fn props(inputs: &'static [InputAction], infos: &'static [CriticalInputInfo]) -> P<1> {
        P::new(
            [LevelDef::new(EMERG, "emergency")
                .inputs(inputs)
                .outputs(&SAFE)],
            infos,
            &OUTS,
            &ROW,
            EMERG,
        )
    }
    macro_rules! float {
        ($min:expr, $max:expr) => {{
            static INPUTS: [InputAction; 2] =
                [ESTOP_IN.ignore(), CURRENT.off_range($min, $max, ESTOP)];
            props(&INPUTS, &INS)
        }};
    }
    macro_rules! int {
        ($min:expr, $max:expr) => {{
            static INPUTS: [InputAction; 2] = [ESTOP_IN.ignore(), POS.off_range($min, $max, ESTOP)];
            props(&INPUTS, &POS_INS)
        }};
    }
    let invalid = |input: InputId, input_name| {
        Err(SafetyError::InvalidRange {
            level: EMERG,
            level_name: "emergency",
            input,
            input_name,
        })
    };
    assert_eq!(
        float!(1.0, 1.0).validate(),
        invalid(CURRENT.id(), "current")
    );
    assert_eq!(int!(4, 5).validate(), invalid(POS.id(), "position"));
    assert_eq!(
        int!(i32::MAX, i32::MAX).validate(),
        invalid(POS.id(), "position")
    );
    assert_eq!(float!(1.0, 1.001).validate(), Ok(()));
    assert_eq!(int!(4, 6).validate(), Ok(()));
    assert_eq!(int!(i32::MIN, i32::MAX).validate(), Ok(()));
    // Why: such a band lets every finite reading pass.
    let band = CURRENT.off_range(1.0, 1.0, ESTOP).check();
    for v in [f32::NEG_INFINITY, -1.0, 0.999, 1.0, 1.001, f32::INFINITY] {
        assert_eq!(band.evaluate(IoValue::Float(v)), None, "{v}");
    }
    assert_eq!(band.evaluate(IoValue::Float(f32::NAN)), Some(ESTOP.id()));
    let band = POS.off_range(4, 5, ESTOP).check();
    for v in [i32::MIN, 3, 4, 5, 6, i32::MAX] {
        assert_eq!(band.evaluate(IoValue::Int(v)), None, "{v}");
    }
}

/// A NaN limit in a `range` is refused, and so is a NaN *expected value* in a `check` of
/// an `f32` input: since NaN equals nothing, that check would fire in every cycle of its
/// level from the first, whatever the input reads, and the level could never be held.
#[test]
fn a_nan_expected_value_is_refused_like_a_nan_limit() {
    const BAD: P<4> = P::new(
        [
            emerg(),
            off(),
            ready(),
            run().inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.check(f32::NAN, ESTOP)]),
        ],
        &INS,
        &OUTS,
        &ROWS,
        OFF,
    );
    assert_eq!(
        BAD.validate(),
        Err(SafetyError::InvalidRange {
            level: RUN,
            level_name: "run",
            input: CURRENT.id(),
            input_name: "current",
        })
    );
}

/// A critical output set to NaN (an uninitialised limit constant, `0.0 / 0.0`) or toggled
/// with a NaN phase would write NaN to the actuator in every cycle of the level: refused,
/// as NaN range limits are.
#[test]
fn a_nan_output_value_is_refused() {
    const NAN_SET: P<4> = P::new(
        [
            emerg(),
            off(),
            ready(),
            run().outputs(&[ENABLE.set(true), LIMIT.set(f32::NAN)]),
        ],
        &INS,
        &OUTS,
        &ROWS,
        OFF,
    );
    const NAN_TOGGLE: P<4> = P::new(
        [
            emerg(),
            off(),
            ready(),
            run().outputs(&[ENABLE.set(true), LIMIT.toggle(0.0, f32::NAN)]),
        ],
        &INS,
        &OUTS,
        &ROWS,
        OFF,
    );
    for bad in [NAN_SET, NAN_TOGGLE] {
        let err = bad.validate().unwrap_err();
        assert_eq!(
            err,
            SafetyError::NanOutputValue {
                level: RUN,
                level_name: "run",
                output: LIMIT.id(),
                output_name: LIMIT.name(),
            }
        );
        assert_eq!(
            err.to_string(),
            format!(
                "level 'run': action for critical output '{}' writes NaN",
                LIMIT.name()
            )
        );
    }
    let handle = SafetyHandle::new();
    assert!(SafetySystem::new(&NAN_SET, &handle).is_err());
    assert!(!handle.is_bound());
}

/// An input check whose event id is out of range (`PrivateEvent::new(40)`): refused, and
/// the error names the level and the input it was written in, as `SafetyError`'s doc says "Every variant about one level names the level (id and name)
/// and the input / output concerned".
#[test]
fn an_out_of_range_input_event_names_its_level_and_input() {
    const BAD: P<4> = P::new(
        [
            emerg(),
            off(),
            ready(),
            run().inputs(&[
                ESTOP_IN.check(false, PrivateEvent::new(40)),
                CURRENT.range(-8.0, 8.0, ESTOP),
            ]),
        ],
        &INS,
        &OUTS,
        &ROWS,
        OFF,
    );
    let err = BAD.validate().unwrap_err();
    assert_eq!(
        err,
        SafetyError::InputEventOutOfRange {
            level: RUN,
            level_name: "run",
            input: ESTOP_IN.id(),
            input_name: ESTOP_IN.name(),
            event: EventId::private(40),
        }
    );
    let message = err.to_string();
    assert!(message.contains("'run'"), "{message}");
    assert!(message.contains("'estop'"), "{message}");
}

/// Every per-level completeness mistake, each in a realistic spot of the reference
/// machine, with its exact error and message: an output forgotten on one level, an input
/// listed twice, an undeclared input, an `i32` action on the `f32` input, an input event
/// with no row from its level, an undeclared output, a `bool` action on the `f32` output.
#[test]
fn every_per_level_mistake_has_its_exact_error_and_message() {
    const CURRENT_AS_INT: CriticalInput<i32> = CriticalInput::new(1, "current (int)");
    const LIMIT_AS_BOOL: CriticalOutput<bool> = CriticalOutput::new(1, "limit (bool)");
    const DOOR: CriticalInput<bool> = CriticalInput::new(5, "door");
    const BRAKE: CriticalOutput<bool> = CriticalOutput::new(6, "brake");
    const OVERHEAT: PublicEvent = PublicEvent::new(9);
    const CASES: [(P<4>, SafetyError, &str); 7] = [
        (
            P::new(
                [emerg(), off(), ready().outputs(&[ENABLE.set(false)]), run()],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::MissingOutputAction {
                level: READY,
                level_name: "ready",
                output: LIMIT.id(),
                output_name: "torque limit",
            },
            "level 'ready' has no action for critical output 'torque limit'",
        ),
        (
            P::new(
                [
                    emerg(),
                    off(),
                    ready(),
                    run().inputs(&[
                        ESTOP_IN.check(false, ESTOP),
                        CURRENT.range(-8.0, 8.0, ESTOP),
                        ESTOP_IN.ignore(),
                    ]),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::DuplicateInputAction {
                level: RUN,
                level_name: "run",
                input: ESTOP_IN.id(),
                input_name: "estop",
            },
            "level 'run' has two actions for critical input 'estop'",
        ),
        (
            P::new(
                [
                    emerg(),
                    off().inputs(&[
                        ESTOP_IN.check(false, ESTOP),
                        CURRENT.ignore(),
                        DOOR.ignore(),
                    ]),
                    ready(),
                    run(),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::UnknownInput {
                level: OFF,
                level_name: "off",
                input: DOOR.id(),
            },
            "level 'off' has an action for undeclared input 5",
        ),
        (
            P::new(
                [
                    emerg(),
                    off(),
                    ready(),
                    run().inputs(&[
                        ESTOP_IN.check(false, ESTOP),
                        CURRENT_AS_INT.range(-8, 8, ESTOP),
                    ]),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::InputKindMismatch {
                level: RUN,
                level_name: "run",
                input: CURRENT.id(),
                input_name: "current",
            },
            "level 'run': action for input 'current' has the wrong type",
        ),
        (
            P::new(
                [
                    emerg(),
                    off(),
                    ready(),
                    run().inputs(&[
                        ESTOP_IN.check(false, ESTOP),
                        CURRENT.range(-8.0, 8.0, OVERHEAT),
                    ]),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::InputEventWithoutTransition {
                level: RUN,
                level_name: "run",
                input: CURRENT.id(),
                input_name: "current",
                event: OVERHEAT.id(),
            },
            "level 'run': input 'current' triggers public event 9, which has no transition from this level",
        ),
        (
            P::new(
                [
                    emerg().outputs(&[ENABLE.set(false), LIMIT.set(0.0), BRAKE.set(true)]),
                    off(),
                    ready(),
                    run(),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::UnknownOutput {
                level: EMERG,
                level_name: "emergency",
                output: BRAKE.id(),
            },
            "level 'emergency' has an action for undeclared output 6",
        ),
        (
            P::new(
                [
                    emerg().outputs(&[ENABLE.set(false), LIMIT_AS_BOOL.set(false)]),
                    off(),
                    ready(),
                    run(),
                ],
                &INS,
                &OUTS,
                &ROWS,
                OFF,
            ),
            SafetyError::OutputKindMismatch {
                level: EMERG,
                level_name: "emergency",
                output: LIMIT.id(),
                output_name: "torque limit",
            },
            "level 'emergency': action for output 'torque limit' has the wrong type",
        ),
    ];
    for (props, error, message) in CASES {
        assert_eq!(props.validate(), Err(error));
        assert_eq!(error.to_string(), message);
        let handle = SafetyHandle::new();
        assert_eq!(SafetySystem::new(&props, &handle).err(), Some(error));
        assert!(!handle.is_bound());
    }
}

/// An input check that triggers a *public* event is allowed (it is the safety system's own
/// action); the input of a level whose event is known there but leads to the level itself
/// ("stay") holds the level and is counted as neither a change nor unknown.
#[test]
fn an_input_may_raise_a_public_event_and_a_stay_row_holds_the_level() {
    const HOLD: PublicEvent = PublicEvent::new(5);
    const P2: P<4> = P::new(
        [
            emerg(),
            off(),
            ready().inputs(&[ESTOP_IN.check(false, HOLD), CURRENT.ignore()]),
            run(),
        ],
        &INS,
        &OUTS,
        &[
            LevelTransition::on_level_and_above(OFF, ESTOP, EMERG),
            LevelTransition::on(OFF, START, READY),
            LevelTransition::on(READY, HOLD, READY),
            LevelTransition::on(READY, START, RUN),
        ],
        OFF,
    );
    assert_eq!(P2.validate(), Ok(()));
    let handle = SafetyHandle::new();
    let mut s = SafetySystem::new(&P2, &handle).unwrap();
    let mut io = Io::default();
    s.cycle(&mut io, &NoSequences);
    handle.trigger(START);
    s.cycle(&mut io, &NoSequences); // READY
    io.estop = true;
    s.cycle(&mut io, &NoSequences); // HOLD raised
    handle.trigger(START); // the safer "stay" (READY) beats RUN
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.change, r.unknown_events), (READY, None, 0));
    assert_eq!(s.stats(READY).map(|s| s.activations), Some(1));
}

// ---------------------------------------------------------------------------------------
// Building the system: `new` and `new_validated`, the handle
// ---------------------------------------------------------------------------------------

/// `new` validates, then binds; `new_validated` only binds. On a handle a live system holds:
/// invalid properties give their validation error (validation comes first), valid ones
/// `HandleInUse`, from both constructors — and none of these failed attempts changes the
/// live system's published level, its pending events or its binding.
#[test]
fn failed_constructions_leave_a_live_system_and_its_handle_alone() {
    static VALID: ValidProperties<'static, Io, 4> = match GOOD.validated() {
        Ok(v) => v,
        Err(_) => panic!("GOOD is valid"),
    };
    const OTHER_ENTRY: P<4> = P::new([emerg(), off(), ready(), run()], &INS, &OUTS, &ROWS, EMERG);
    const INVALID: P<4> = P::new(
        [emerg(), off(), ready(), run()],
        &INS,
        &OUTS,
        &ROWS,
        SafetyLevel::new(4),
    );
    let handle = SafetyHandle::new();
    let mut live = SafetySystem::new(&GOOD, &handle).unwrap();
    let mut io = Io::default();
    live.cycle(&mut io, &NoSequences);
    handle.trigger(START);
    live.cycle(&mut io, &NoSequences);
    assert_eq!(handle.level(), RUN);
    handle.trigger(STOP);

    let invalid = SafetySystem::new(&INVALID, &handle).err();
    assert_eq!(
        invalid,
        Some(SafetyError::UnknownEntryLevel {
            level: SafetyLevel::new(4)
        })
    );
    assert_eq!(invalid.unwrap().to_string(), "entry level 4 is not defined");
    assert_eq!(
        SafetySystem::new(&OTHER_ENTRY, &handle).err(),
        Some(SafetyError::HandleInUse)
    );
    assert_eq!(
        SafetySystem::new_validated(&VALID, &handle).err(),
        Some(SafetyError::HandleInUse)
    );
    assert_eq!(
        SafetyError::HandleInUse.to_string(),
        "safety handle already bound to a live safety system (drop it first)"
    );
    assert_eq!(
        handle.level(),
        RUN,
        "the entry level EMERG was not published"
    );
    assert_eq!(handle.pending_events(), 1 << STOP.id().index());
    assert!(handle.is_bound());
    assert_eq!(handle.cycles(), 2);
    let r = live.cycle(&mut io, &NoSequences);
    assert_eq!(
        r.change,
        Some(LevelChange {
            from: Some(RUN),
            to: READY
        })
    );
}

/// `new_validated` publishes the entry level at once, `new` too; neither runs the entry
/// action or counts an activation before the first cycle.
#[test]
fn both_constructors_publish_the_entry_level_and_enter_it_in_the_first_cycle() {
    static VALID: ValidProperties<'static, Io, 4> = match GOOD.validated() {
        Ok(v) => v,
        Err(_) => panic!("GOOD is valid"),
    };
    let handle = SafetyHandle::new();
    for validated in [false, true] {
        let mut s = if validated {
            SafetySystem::new_validated(&VALID, &handle).unwrap()
        } else {
            SafetySystem::new(&GOOD, &handle).unwrap()
        };
        assert_eq!(
            (handle.level(), s.level(), s.is_started()),
            (OFF, OFF, false)
        );
        assert_eq!(s.stats(OFF), Some(LevelStats::ZERO));
        let r = s.cycle(&mut Io::default(), &NoSequences);
        assert_eq!(
            r.change,
            Some(LevelChange {
                from: None,
                to: OFF
            })
        );
        assert_eq!(
            s.stats(OFF),
            Some(LevelStats {
                activations: 1,
                cycles: 1
            })
        );
    }
}

/// An event constant of *another* safety system (B's STOP, id 0) triggered on this one's
/// handle is this system's event 0 (START): events are ids, not tied to a system, so the
/// mix-up starts the drive instead of stopping it, silently.
// GAP: event (and level) constants carry no system identity; nothing in the docs warns that another system's constants are accepted as this one's.
#[test]
fn an_event_of_another_safety_system_is_taken_as_this_ones_by_id() {
    const B_STOP: PublicEvent = PublicEvent::new(0); // "STOP" in system B
    let handle = SafetyHandle::new();
    let mut s = SafetySystem::new(&GOOD, &handle).unwrap();
    let mut io = Io::default();
    s.cycle(&mut io, &NoSequences);
    handle.trigger(B_STOP);
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.unknown_events), (RUN, 0));
    assert_eq!(io.writes.last(), Some(&(1, IoValue::Float(5.0))));
}

// ---------------------------------------------------------------------------------------
// Many events in one cycle
// ---------------------------------------------------------------------------------------

/// All 32 public and all 32 private events pending at once (the public ones from the handle,
/// the private ones raised by a level action), each with its own row from RUN: one cycle
/// resolves all 64, the safest destination (EMERG, from private 31 alone) wins, none is
/// unknown, none is left for the next cycle.
#[test]
fn sixty_four_events_in_one_cycle_the_safest_wins_and_nothing_is_left() {
    fn raise_all_private(ctx: &mut SafetyContext<'_>, io: &mut Io) {
        if io.estop {
            for i in 0..32 {
                ctx.trigger(PrivateEvent::new(i));
            }
        }
    }
    const fn rows() -> [LevelTransition; 64] {
        let mut rows = [LevelTransition::on(RUN, START, RUN); 64];
        let mut i = 0;
        while i < 32 {
            // Public i leads to READY (even i) or stays (odd i); private i to OFF, except 31.
            let public_to = if i % 2 == 0 { READY } else { RUN };
            rows[i] = LevelTransition::on(RUN, PublicEvent::new(i as u8), public_to);
            let private_to = if i == 31 { EMERG } else { OFF };
            rows[32 + i] = LevelTransition::on(RUN, PrivateEvent::new(i as u8), private_to);
            i += 1;
        }
        rows
    }
    static ROWS64: [LevelTransition; 64] = rows();
    static MANY: P<4> = P::new(
        [
            emerg(),
            LevelDef::new(OFF, "off").inputs(&IGNORE).outputs(&SAFE),
            LevelDef::new(READY, "ready").inputs(&IGNORE).outputs(&SAFE),
            LevelDef::new(RUN, "run")
                .inputs(&IGNORE)
                .outputs(&DRIVE)
                .level_action(raise_all_private),
        ],
        &INS,
        &OUTS,
        &ROWS64,
        RUN,
    );
    let handle = SafetyHandle::new();
    let mut s = SafetySystem::new(&MANY, &handle).unwrap();
    let mut io = Io::default();
    s.cycle(&mut io, &NoSequences); // RUN
    io.estop = true;
    s.cycle(&mut io, &NoSequences); // 32 private raised
    for i in 0..32 {
        handle.trigger(PublicEvent::new(i));
    }
    assert_eq!(handle.pending_events(), u32::MAX);
    io.estop = false;
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!(
        (r.level, r.change, r.unknown_events),
        (
            EMERG,
            Some(LevelChange {
                from: Some(RUN),
                to: EMERG
            }),
            0
        )
    );
    assert_eq!(handle.pending_events(), 0);
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.change, r.unknown_events), (EMERG, None, 0));
    assert_eq!(s.unknown_events(), 0);
}

/// Out-of-range public events counted by the handle between two cycles saturate at
/// 2^24 − 1 (a field comment in handle.rs; the public docs say "each trigger of it counts").
// GAP: the saturation of the handle's out-of-range count is not in the public docs (semantics.md "Unknown events", SafetyHandle::trigger).
#[test]
fn out_of_range_triggers_between_two_cycles_saturate_at_two_to_the_24_minus_one() {
    let handle = SafetyHandle::new();
    let mut s = SafetySystem::new(&GOOD, &handle).unwrap();
    let mut io = Io::default();
    s.cycle(&mut io, &NoSequences);
    let over = PublicEvent::new(200);
    for _ in 0..(1u32 << 24) + 3 {
        handle.trigger(over);
    }
    handle.trigger(PublicEvent::new(77));
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!((r.level, r.unknown_events), (OFF, (1 << 24) - 1));
    assert_eq!(
        s.last_unknown_event(),
        Some(UnknownEvent {
            event: EventId::public(77),
            level: OFF
        })
    );
    let r = s.cycle(&mut io, &NoSequences);
    assert_eq!(r.unknown_events, 0);
}

// ---------------------------------------------------------------------------------------
// Wiring to a sequencer
// ---------------------------------------------------------------------------------------

/// The control system of the sequencer tests.
#[derive(Default)]
struct Ctrl {
    seen: RefCell<Vec<String>>,
    estop: Cell<bool>,
}

/// Runs until it is aborted.
struct Forever;
impl Sequence<Ctrl> for Forever {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// A step that is one command to the safety system (spec 1.2 item 3): trigger START through
/// `cx.safety_system()` (spec 1.1, `getSafetySystem()`), then wait for the level.
struct SwitchOn;
impl Sequence<Ctrl> for SwitchOn {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let safety = cx.safety_system().ok_or(Failure::App(1))?;
        safety.trigger(START);
        cx.wait_until(|_| safety.level() == RUN).await;
        cx.control()
            .seen
            .borrow_mut()
            .push(format!("{} ms RUN seen", cx.now().as_ticks() / 1000));
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Spec 1.1: "Die Methode getSafetySystem() gibt einen Pointer auf das SafetySystem
/// zurück." Spec 1.2 item 3: "Bei einem Step kann es nur ein einzelner Befehl an das
/// ControlSystem oder an das SafetySystem sein." A sequence gets the safety system of its
/// sequencer, triggers a public event in one step and sees the new level one safety cycle
/// later; the estop input then leads to EMERG, which aborts it. Exact records.
#[test]
fn spec_a_step_commands_the_safety_system_its_sequencer_gives_it() {
    static PROPS: ValidProperties<'static, Io, 4> = match GOOD.validated() {
        Ok(v) => v,
        Err(_) => panic!("GOOD is valid"),
    };
    let ctrl = Ctrl::default();
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let on = seq.add(SeqConfig::new("switch on"), SwitchOn).unwrap();
    let id = on.id();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(on);
    let sequences = &seq;
    let mut io = Io::default();
    sim.before_tick(move |now, c| {
        io.estop = now.as_ticks() >= 4_000 || c.estop.get();
        safety.cycle(&mut io, sequences);
    });
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(6));
    let names = (&seq, PROPS.properties());
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms switch on: Idle -> Running (start)",
            "1 ms safety level off",
            "2 ms safety level run",
            "4 ms critical input `estop` tripped",
            "5 ms safety level emergency",
            "5 ms abort-all requested by the safety system",
            "5 ms switch on: Running -> Aborting (abort-all)",
            "5 ms switch on: Aborting -> Aborted (abort-all)",
        ]
    );
    assert_eq!(*ctrl.seen.borrow(), ["2 ms RUN seen"]);
}

/// The system built on the handle of one sequencer (4 slots), its cycle given another
/// sequencer (2 slots): no error. The emergency aborts the sequences of both (the first
/// through the handle, the second as the cycle's `Sequences`); the level records go to the
/// second's trace only, and the second's sequences cannot reach the system
/// (`safety_system()` is `None`), although it is told everything.
// GAP: a cycle given a sequencer other than the one whose handle the system is built on is accepted silently; `Sequencer::safety_handle`'s doc asks for "the same sequencer" but nothing checks it.
#[test]
fn a_cycle_given_another_sequencer_than_the_handles_is_accepted_silently() {
    static PROPS: ValidProperties<'static, Io, 4> =
        match P::new([emerg(), off(), ready(), run()], &INS, &OUTS, &ROWS, RUN).validated() {
            Ok(v) => v,
            Err(_) => panic!("valid"),
        };
    let ctrl = Ctrl::default();
    let big: Sequencer<Ctrl, 4> = Sequencer::new();
    let small: Sequencer<Ctrl, 2> = Sequencer::new();
    let a = big.add(SeqConfig::new("a"), Forever).unwrap();
    let b = small.add(SeqConfig::new("b"), Forever).unwrap();
    let (ida, idb) = (a.id(), b.id());
    let mut safety = SafetySystem::new_validated(&PROPS, big.safety_handle()).unwrap();
    assert!(big.safety_system().is_some());
    assert!(small.safety_system().is_none());
    let mut sim_big = Sim::new(&big, &ctrl, Monitors::<Ctrl, 1>::new());
    let mut sim_small = Sim::new(&small, &ctrl, Monitors::<Ctrl, 1>::new());
    sim_big.lane(a);
    sim_small.lane(b);
    sim_big.start(ida).unwrap();
    sim_small.start(idb).unwrap();
    let mut io = Io::default();
    for ms in 1..=3u64 {
        io.estop = ms >= 2;
        safety.cycle(&mut io, &small);
        sim_big.step();
        sim_small.step();
    }
    assert_eq!(safety.level(), EMERG);
    assert_eq!(sim_big.state(ida), rtseq::RunningState::Aborted);
    assert_eq!(sim_small.state(idb), rtseq::RunningState::Aborted);
    let lines = |recs: &[rtseq::Record], names: &dyn rtseq::Names| -> Vec<String> {
        recs.iter()
            .map(|r| r.named(names).to_string())
            .filter(|l| l.contains("safety") || l.contains("critical"))
            .collect()
    };
    let big_names = (&big, PROPS.properties());
    let small_names = (&small, PROPS.properties());
    assert_eq!(
        lines(sim_big.records(), &big_names),
        ["3 ms abort-all requested by the safety system"]
    );
    assert_eq!(
        lines(sim_small.records(), &small_names),
        [
            "1 ms safety level run",
            "2 ms critical input `estop` tripped",
            "3 ms safety level emergency",
            "3 ms abort-all requested by the safety system",
        ]
    );
}

/// After the system is dropped, the sequencer's handle is unbound and reads level 0 (the
/// safest, whatever the entry level was); `safety_system()` is `None`. A *raw* trigger on
/// the handle (as a `static` control system keeps it, `Sequencer::safety_handle`'s second
/// example) is silently kept pending, and the next system built on the handle applies it
/// in its second cycle: a START given to a dead system starts the drive of the new one.
// GAP: `SafetyHandle::trigger` on an unbound handle is silent and the event outlives the system it was meant for; docs/safety.md says the drop resets the handle "no pending events" but not that later triggers are kept for the next system.
#[test]
fn a_raw_trigger_after_the_drop_is_kept_for_the_next_system() {
    static PROPS: ValidProperties<'static, Io, 4> = match GOOD.validated() {
        Ok(v) => v,
        Err(_) => panic!("GOOD is valid"),
    };
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let mut io = Io::default();
    let mut first = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    first.cycle(&mut io, &NoSequences);
    assert_eq!(seq.safety_handle().level(), OFF);
    drop(first);
    assert!(seq.safety_system().is_none());
    assert_eq!(seq.safety_handle().level(), SafetyLevel::SAFEST);
    assert_eq!(
        seq.safety_handle().level(),
        EMERG,
        "reads as the emergency level"
    );

    seq.safety_handle().trigger(START);
    assert_eq!(
        seq.safety_handle().pending_events(),
        1 << START.id().index()
    );

    let mut second = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    assert_eq!(second.cycle(&mut io, &NoSequences).level, OFF);
    assert_eq!(second.cycle(&mut io, &NoSequences).level, RUN);
}
