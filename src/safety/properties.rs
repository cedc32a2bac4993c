//! The static description of a safety system: levels, critical inputs and
//! outputs, transitions, entry level — and its validation.

use core::fmt;

use super::bits::bit_of;
use super::error::SafetyError;
use super::event::EventId;
use super::input::{CriticalInputInfo, InputAction, InputCheck};
use super::io::{IoValue, OutputId};
use super::level::SafetyLevel;
use super::level_def::LevelDef;
use super::output::{CriticalOutputInfo, OutputAction, OutputMode};
use super::transition::LevelTransition;
use super::{MAX_INPUTS, MAX_OUTPUTS};

/// The complete, static description of a safety system (EEROS
/// `SafetyProperties`): `L` level definitions, the critical inputs and
/// outputs, the transition table and the entry level.
///
/// Const-constructible, so it can live in a `static` (or `const`) and be
/// checked at compile time with
/// `const _: () = assert!(PROPS.validate().is_ok());`. A
/// [`SafetySystem`](super::SafetySystem) validates it again at
/// construction, so an incomplete table is never silently accepted.
///
/// `IO` is the application's IO / state type handed to the level, entry
/// and exit actions (see [`SafetyIo`](super::SafetyIo)).
///
/// ```
/// use rtseq::safety::*;
/// # struct Io;
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// const ON: SafetyLevel = SafetyLevel::new(1);
/// const SWITCH_ON: PublicEvent = PublicEvent::new(0);
/// const SWITCH_OFF: PublicEvent = PublicEvent::new(1);
/// const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
///
/// const PROPS: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
///     [
///         LevelDef::new(OFF, "off").outputs(&[ENABLE.set(false)]),
///         LevelDef::new(ON, "on").outputs(&[ENABLE.set(true)]),
///     ],
///     &[],              // critical inputs
///     &[ENABLE.info()], // critical outputs
///     &[LevelTransition::on(OFF, SWITCH_ON, ON), LevelTransition::on(ON, SWITCH_OFF, OFF)],
///     OFF,              // entry level
/// );
/// const _: () = assert!(PROPS.validate().is_ok()); // checked by the compiler
/// assert_eq!(PROPS.destination(OFF, SWITCH_ON), Some(ON));
/// assert_eq!(PROPS.destination(ON, SWITCH_ON), None);
/// ```
pub struct SafetyProperties<'a, IO, const L: usize> {
    levels: [LevelDef<'a, IO>; L],
    inputs: &'a [CriticalInputInfo],
    outputs: &'a [CriticalOutputInfo],
    transitions: &'a [LevelTransition],
    entry: SafetyLevel,
}

impl<'a, IO, const L: usize> SafetyProperties<'a, IO, L> {
    /// Collects the description; call [`validate`](Self::validate) (or
    /// build a [`SafetySystem`](super::SafetySystem)) to check it.
    ///
    /// `levels[i]` must define level `i`, `inputs[i]` input `i` and
    /// `outputs[i]` output `i`.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// static PROPS: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert_eq!(PROPS.validate(), Ok(()));
    /// ```
    pub const fn new(
        levels: [LevelDef<'a, IO>; L],
        inputs: &'a [CriticalInputInfo],
        outputs: &'a [CriticalOutputInfo],
        transitions: &'a [LevelTransition],
        entry: SafetyLevel,
    ) -> Self {
        Self {
            levels,
            inputs,
            outputs,
            transitions,
            entry,
        }
    }

    /// The level definitions, in level order.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert_eq!(P.levels()[0].name(), "off");
    /// ```
    pub const fn levels(&self) -> &[LevelDef<'a, IO>; L] {
        &self.levels
    }

    /// The definition of `level`, if defined.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert_eq!(P.level(OFF).map(|d| d.name()), Some("off"));
    /// assert!(P.level(SafetyLevel::new(1)).is_none());
    /// ```
    pub fn level(&self, level: SafetyLevel) -> Option<&LevelDef<'a, IO>> {
        self.levels.get(level.index())
    }

    /// The declared critical inputs.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
    /// const P: SafetyProperties<'static, Io, 1> = SafetyProperties::new(
    ///     [LevelDef::new(OFF, "off").inputs(&[DOOR.ignore()])], &[DOOR.info()], &[], &[], OFF);
    /// assert_eq!(P.inputs().len(), 1);
    /// ```
    pub const fn inputs(&self) -> &'a [CriticalInputInfo] {
        self.inputs
    }

    /// The declared critical outputs.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert!(P.outputs().is_empty());
    /// ```
    pub const fn outputs(&self) -> &'a [CriticalOutputInfo] {
        self.outputs
    }

    /// The transition table.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert!(P.transitions().is_empty());
    /// ```
    pub const fn transitions(&self) -> &'a [LevelTransition] {
        self.transitions
    }

    /// The level entered in the first cycle.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// assert_eq!(P.entry_level(), OFF);
    /// ```
    pub const fn entry_level(&self) -> SafetyLevel {
        self.entry
    }

    /// The level `event` leads to from `level` (the per-level transition
    /// table), `None` if the event is unknown in that level.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const ON: SafetyLevel = SafetyLevel::new(1);
    /// const GO: PublicEvent = PublicEvent::new(0);
    /// const P: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
    ///     [LevelDef::new(OFF, "off"), LevelDef::new(ON, "on")], &[], &[],
    ///     &[LevelTransition::on(OFF, GO, ON)], OFF);
    /// assert_eq!(P.destination(OFF, GO), Some(ON));
    /// assert_eq!(P.destination(ON, GO.id()), None);
    /// ```
    pub fn destination(
        &self,
        level: SafetyLevel,
        event: impl Into<EventId>,
    ) -> Option<SafetyLevel> {
        let event = event.into();
        self.transitions
            .iter()
            .find(|t| t.covers(level, event))
            .map(|t| t.to())
    }

    /// Checks the description: levels, inputs and outputs listed in id
    /// order; every level has exactly one action for every critical input
    /// and output, of the right type; ranges are well-formed; event ids
    /// fit (`< 32`); transitions name defined levels and do not conflict;
    /// every event an input action can trigger has a transition from its
    /// level. The first problem found is returned.
    ///
    /// A `const fn`, so it can run at compile time:
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const EN: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
    /// const PROPS: SafetyProperties<'static, Io, 1> = SafetyProperties::new(
    ///     [LevelDef::new(OFF, "off").outputs(&[EN.set(false)])], &[], &[EN.info()], &[], OFF);
    /// const _: () = assert!(PROPS.validate().is_ok());
    /// ```
    pub const fn validate(&self) -> Result<(), SafetyError> {
        if L == 0 {
            return Err(SafetyError::NoLevels);
        }
        let mut rest: &[LevelDef<'a, IO>] = &self.levels;
        let mut index = 0usize;
        while let [def, tail @ ..] = rest {
            if def.level().index() != index {
                return Err(SafetyError::LevelOutOfOrder {
                    index,
                    level: def.level(),
                });
            }
            index = index.saturating_add(1);
            rest = tail;
        }
        if self.entry.index() >= L {
            return Err(SafetyError::UnknownEntryLevel { level: self.entry });
        }
        if let Err(e) = self.validate_io_lists() {
            return Err(e);
        }
        if let Err(e) = self.validate_transitions() {
            return Err(e);
        }
        let mut rest: &[LevelDef<'a, IO>] = &self.levels;
        while let [def, tail @ ..] = rest {
            if let Err(e) = self.validate_level_inputs(def) {
                return Err(e);
            }
            if let Err(e) = self.validate_level_outputs(def) {
                return Err(e);
            }
            rest = tail;
        }
        Ok(())
    }

    /// [`validate`](Self::validate)s and wraps the properties in a
    /// [`ValidProperties`], the proof that they are valid.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[DOOR.info()], &[], &[], OFF);
    /// assert!(matches!(P.validated(), Err(SafetyError::MissingInputAction { .. })));
    /// ```
    ///
    /// Validated in a `static` (or a `const`), invalid properties are a compile error:
    ///
    /// ```compile_fail,E0080
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
    /// static PROPS: ValidProperties<'static, Io, 1> =
    ///     match SafetyProperties::new([LevelDef::new(OFF, "off")], &[DOOR.info()], &[], &[], OFF)
    ///         .validated()
    ///     {
    ///         Ok(valid) => valid,
    ///         Err(_) => panic!("the door has no input action in level `off`"),
    ///     };
    /// ```
    pub const fn validated(self) -> Result<ValidProperties<'a, IO, L>, SafetyError> {
        match self.validate() {
            Ok(()) => Ok(ValidProperties(self)),
            Err(e) => Err(e),
        }
    }

    const fn validate_io_lists(&self) -> Result<(), SafetyError> {
        if self.inputs.len() > MAX_INPUTS {
            return Err(SafetyError::TooManyInputs {
                count: self.inputs.len(),
            });
        }
        if self.outputs.len() > MAX_OUTPUTS {
            return Err(SafetyError::TooManyOutputs {
                count: self.outputs.len(),
            });
        }
        let mut rest = self.inputs;
        let mut index = 0usize;
        while let [info, tail @ ..] = rest {
            if info.id().index() != index {
                return Err(SafetyError::InputOutOfOrder {
                    index,
                    input: info.id(),
                });
            }
            index = index.saturating_add(1);
            rest = tail;
        }
        let mut rest = self.outputs;
        let mut index = 0usize;
        while let [info, tail @ ..] = rest {
            if info.id().index() != index {
                return Err(SafetyError::OutputOutOfOrder {
                    index,
                    output: info.id(),
                });
            }
            index = index.saturating_add(1);
            rest = tail;
        }
        Ok(())
    }

    const fn validate_transitions(&self) -> Result<(), SafetyError> {
        // Every row on its own first: a conflict is only looked for between valid rows.
        let mut rest = self.transitions;
        let mut index = 0usize;
        while let [t, tail @ ..] = rest {
            if !t.event().is_in_range() {
                return Err(SafetyError::EventOutOfRange { event: t.event() });
            }
            if !t.from_low().le(t.from_high()) {
                return Err(SafetyError::InvalidTransition { index });
            }
            // The upper end is a defined level, or 255: `on_level_and_above`'s open end.
            let open_ended = t.from_high().index() == u8::MAX as usize;
            let undefined = if t.from_low().index() >= L {
                Some(t.from_low())
            } else if t.from_high().index() >= L && !open_ended {
                Some(t.from_high())
            } else if t.to().index() >= L {
                Some(t.to())
            } else {
                None
            };
            if let Some(level) = undefined {
                return Err(SafetyError::UndefinedTransitionLevel { index, level });
            }
            index = index.saturating_add(1);
            rest = tail;
        }
        let mut rest = self.transitions;
        while let [t, tail @ ..] = rest {
            // Conflicts with every later row.
            let mut others = tail;
            while let [u, more @ ..] = others {
                if t.event().same(u.event()) {
                    let low = if t.from_low().le(u.from_low()) {
                        u.from_low()
                    } else {
                        t.from_low()
                    };
                    let high = if t.from_high().le(u.from_high()) {
                        t.from_high()
                    } else {
                        u.from_high()
                    };
                    if low.le(high) {
                        return Err(SafetyError::ConflictingTransition {
                            level: low,
                            event: t.event(),
                        });
                    }
                }
                others = more;
            }
            rest = tail;
        }
        Ok(())
    }

    const fn has_transition(&self, level: SafetyLevel, event: EventId) -> bool {
        let mut rest = self.transitions;
        while let [t, tail @ ..] = rest {
            if t.covers(level, event) {
                return true;
            }
            rest = tail;
        }
        false
    }

    const fn validate_level_inputs(&self, def: &LevelDef<'a, IO>) -> Result<(), SafetyError> {
        let level = def.level();
        let level_name = def.name();
        let mut seen = 0u32;
        let mut rest: &[InputAction] = def.input_actions();
        while let [action, tail @ ..] = rest {
            let input = action.input();
            let info = match nth_input(self.inputs, input.index()) {
                Some(info) => info,
                None => {
                    return Err(SafetyError::UnknownInput {
                        level,
                        level_name,
                        input,
                    })
                }
            };
            let input_name = info.name();
            let bit = bit_of(input.index());
            if seen & bit != 0 {
                return Err(SafetyError::DuplicateInputAction {
                    level,
                    level_name,
                    input,
                    input_name,
                });
            }
            seen |= bit;
            if !info.kind().same(action.kind()) {
                return Err(SafetyError::InputKindMismatch {
                    level,
                    level_name,
                    input,
                    input_name,
                });
            }
            let check = action.check();
            let well_formed = match check {
                InputCheck::Range { min, max, .. } => ordered(min, max),
                // A band with no value inside would catch only NaN readings.
                InputCheck::OffRange { min, max, .. } => has_inside(min, max),
                // A NaN expected value differs from every reading: it would fire always.
                InputCheck::Check { expected, .. } => !is_nan(expected),
                InputCheck::Ignore => true,
            };
            if !well_formed {
                return Err(SafetyError::InvalidRange {
                    level,
                    level_name,
                    input,
                    input_name,
                });
            }
            if let Some(event) = check.event() {
                if !event.is_in_range() {
                    return Err(SafetyError::InputEventOutOfRange {
                        level,
                        level_name,
                        input,
                        input_name,
                        event,
                    });
                }
                if !self.has_transition(level, event) {
                    return Err(SafetyError::InputEventWithoutTransition {
                        level,
                        level_name,
                        input,
                        input_name,
                        event,
                    });
                }
            }
            rest = tail;
        }
        let mut rest = self.inputs;
        while let [info, tail @ ..] = rest {
            if seen & bit_of(info.id().index()) == 0 {
                return Err(SafetyError::MissingInputAction {
                    level,
                    level_name,
                    input: info.id(),
                    input_name: info.name(),
                });
            }
            rest = tail;
        }
        Ok(())
    }

    const fn validate_level_outputs(&self, def: &LevelDef<'a, IO>) -> Result<(), SafetyError> {
        let level = def.level();
        let level_name = def.name();
        let mut seen = 0u32;
        let mut rest: &[OutputAction] = def.output_actions();
        while let [action, tail @ ..] = rest {
            let output: OutputId = action.output();
            let info = match nth_output(self.outputs, output.index()) {
                Some(info) => info,
                None => {
                    return Err(SafetyError::UnknownOutput {
                        level,
                        level_name,
                        output,
                    })
                }
            };
            let output_name = info.name();
            let bit = bit_of(output.index());
            if seen & bit != 0 {
                return Err(SafetyError::DuplicateOutputAction {
                    level,
                    level_name,
                    output,
                    output_name,
                });
            }
            seen |= bit;
            // The typed constructors give an action's values the action's kind.
            if !info.kind().same(action.kind()) {
                return Err(SafetyError::OutputKindMismatch {
                    level,
                    level_name,
                    output,
                    output_name,
                });
            }
            let writes_nan = match action.mode() {
                OutputMode::Set(value) => is_nan(value),
                OutputMode::Toggle { low, high } => is_nan(low) || is_nan(high),
                OutputMode::Leave => false,
            };
            if writes_nan {
                return Err(SafetyError::NanOutputValue {
                    level,
                    level_name,
                    output,
                    output_name,
                });
            }
            rest = tail;
        }
        let mut rest = self.outputs;
        while let [info, tail @ ..] = rest {
            if seen & bit_of(info.id().index()) == 0 {
                return Err(SafetyError::MissingOutputAction {
                    level,
                    level_name,
                    output: info.id(),
                    output_name: info.name(),
                });
            }
            rest = tail;
        }
        Ok(())
    }
}

/// [`SafetyProperties`] proven valid: only
/// [`SafetyProperties::validated`] creates it. Build it in a `static`
/// (the check then runs in the compiler, an invalid table is a compile
/// error) and start the system with
/// [`SafetySystem::new_validated`](super::SafetySystem::new_validated),
/// which skips the run-time validation — and its ~0.9 KiB of code on
/// Cortex-M.
///
/// ```
/// use rtseq::safety::*;
/// # struct Io;
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// static PROPS: ValidProperties<'static, Io, 1> =
///     match SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF).validated() {
///         Ok(valid) => valid,
///         Err(_) => panic!("invalid safety properties"), // a compile error, never a run-time panic
///     };
/// assert_eq!(PROPS.properties().entry_level(), OFF);
/// assert_eq!(PROPS.entry_level(), OFF); // through `Deref`
/// ```
pub struct ValidProperties<'a, IO, const L: usize>(SafetyProperties<'a, IO, L>);

impl<'a, IO, const L: usize> ValidProperties<'a, IO, L> {
    /// The validated properties.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const P: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// let valid = P.validated().unwrap();
    /// assert_eq!(valid.properties().levels().len(), 1);
    /// ```
    pub const fn properties(&self) -> &SafetyProperties<'a, IO, L> {
        &self.0
    }
}

/// Reads the validated properties (a `ValidProperties` is a proof, not a different table).
impl<'a, IO, const L: usize> core::ops::Deref for ValidProperties<'a, IO, L> {
    type Target = SafetyProperties<'a, IO, L>;
    fn deref(&self) -> &SafetyProperties<'a, IO, L> {
        &self.0
    }
}

impl<IO, const L: usize> fmt::Debug for ValidProperties<'_, IO, L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("ValidProperties").field(&self.0).finish()
    }
}

impl<IO, const L: usize> fmt::Debug for SafetyProperties<'_, IO, L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SafetyProperties")
            .field("levels", &self.levels)
            .field("inputs", &self.inputs)
            .field("outputs", &self.outputs)
            .field("transitions", &self.transitions)
            .field("entry", &self.entry)
            .finish()
    }
}

/// `min <= max` for two numbers of the same kind (false for NaN, bools
/// and mixed kinds).
const fn ordered(min: IoValue, max: IoValue) -> bool {
    match (min, max) {
        (IoValue::Int(a), IoValue::Int(b)) => a <= b,
        (IoValue::Float(a), IoValue::Float(b)) => a <= b,
        _ => false,
    }
}

/// Some value of the kind of `min` and `max` lies strictly between them (false for NaN,
/// bools and mixed kinds).
const fn has_inside(min: IoValue, max: IoValue) -> bool {
    match (min, max) {
        (IoValue::Int(a), IoValue::Int(b)) => (b as i64).saturating_sub(a as i64) >= 2,
        (IoValue::Float(a), IoValue::Float(b)) => a.next_up() < b,
        _ => false,
    }
}

/// A float that is NaN.
const fn is_nan(v: IoValue) -> bool {
    match v {
        IoValue::Float(f) => f.is_nan(),
        IoValue::Bool(_) | IoValue::Int(_) => false,
    }
}

const fn nth_input(list: &[CriticalInputInfo], index: usize) -> Option<&CriticalInputInfo> {
    let mut rest = list;
    let mut i = 0usize;
    while let [first, tail @ ..] = rest {
        if i == index {
            return Some(first);
        }
        i = i.saturating_add(1);
        rest = tail;
    }
    None
}

const fn nth_output(list: &[CriticalOutputInfo], index: usize) -> Option<&CriticalOutputInfo> {
    let mut rest = list;
    let mut i = 0usize;
    while let [first, tail @ ..] = rest {
        if i == index {
            return Some(first);
        }
        i = i.saturating_add(1);
        rest = tail;
    }
    None
}
