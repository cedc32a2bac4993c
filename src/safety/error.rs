//! Construction errors of the safety system.

use core::fmt;

use super::event::EventId;
use super::io::{InputId, OutputId};
use super::level::SafetyLevel;

/// Why a set of [`SafetyProperties`](super::SafetyProperties) is not
/// valid, or why a [`SafetySystem`](super::SafetySystem) could not be
/// built. Every variant about one level names the level (id and name) and
/// the input / output concerned.
///
/// ```
/// use rtseq::safety::*;
/// # struct Io;
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
/// const PROPS: SafetyProperties<'static, Io, 1> = SafetyProperties::new(
///     [LevelDef::new(OFF, "off")], // no action for DOOR
///     &[DOOR.info()], &[], &[], OFF);
/// assert_eq!(PROPS.validate(), Err(SafetyError::MissingInputAction {
///     level: OFF, level_name: "off", input: DOOR.id(), input_name: "door",
/// }));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SafetyError {
    /// The level array is empty.
    NoLevels,
    /// `levels[index]` is defined for another level; levels must be
    /// listed in id order `0, 1, 2, ...`.
    LevelOutOfOrder {
        /// Position in the level array.
        index: usize,
        /// The level defined there.
        level: SafetyLevel,
    },
    /// The entry level is not one of the defined levels.
    UnknownEntryLevel {
        /// The entry level given.
        level: SafetyLevel,
    },
    /// More than 32 critical inputs.
    TooManyInputs {
        /// Number of inputs declared.
        count: usize,
    },
    /// More than 32 critical outputs.
    TooManyOutputs {
        /// Number of outputs declared.
        count: usize,
    },
    /// `inputs[index]` declares another input id; inputs must be listed in
    /// id order `0, 1, 2, ...`.
    InputOutOfOrder {
        /// Position in the input list.
        index: usize,
        /// The id declared there.
        input: InputId,
    },
    /// `outputs[index]` declares another output id; outputs must be listed
    /// in id order `0, 1, 2, ...`.
    OutputOutOfOrder {
        /// Position in the output list.
        index: usize,
        /// The id declared there.
        output: OutputId,
    },
    /// A level has no action for a critical input.
    MissingInputAction {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input without an action.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
    },
    /// A level has two actions for the same critical input.
    DuplicateInputAction {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input with two actions.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
    },
    /// A level has an action for an input that is not declared.
    UnknownInput {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The undeclared input.
        input: InputId,
    },
    /// A level's input action was built for an input of another type than
    /// the declared one (two `CriticalInput` constants with the same id).
    InputKindMismatch {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
    },
    /// A `range` action with `min > max` or a NaN bound, an `off_range` action whose band
    /// `(min, max)` holds no value (it would catch only NaN readings) or has a NaN bound,
    /// or a `check` whose expected value is NaN (no reading equals it: it would fire in
    /// every cycle).
    InvalidRange {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
    },
    /// A level's input action triggers an event that has no transition
    /// from that level, so it could only ever be an unknown event. Add a
    /// transition (possibly to the level itself) or `ignore` the input.
    InputEventWithoutTransition {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
        /// The event without transition.
        event: EventId,
    },
    /// A level's input action triggers an event whose id is `>= 32`.
    InputEventOutOfRange {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The input.
        input: InputId,
        /// The input's name.
        input_name: &'static str,
        /// The event.
        event: EventId,
    },
    /// A level has no action for a critical output.
    MissingOutputAction {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The output without an action.
        output: OutputId,
        /// The output's name.
        output_name: &'static str,
    },
    /// A level has two actions for the same critical output.
    DuplicateOutputAction {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The output with two actions.
        output: OutputId,
        /// The output's name.
        output_name: &'static str,
    },
    /// A level has an action for an output that is not declared.
    UnknownOutput {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The undeclared output.
        output: OutputId,
    },
    /// A level's output action was built for an output of another type
    /// than the declared one.
    OutputKindMismatch {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The output.
        output: OutputId,
        /// The output's name.
        output_name: &'static str,
    },
    /// A level's output action writes NaN (`set`, or either value of a `toggle`).
    NanOutputValue {
        /// The level.
        level: SafetyLevel,
        /// The level's name.
        level_name: &'static str,
        /// The output.
        output: OutputId,
        /// The output's name.
        output_name: &'static str,
    },
    /// The event of transition row `index` has an id `>= 32` (does not fit the
    /// pending-event bitmask).
    EventOutOfRange {
        /// The event.
        event: EventId,
    },
    /// LevelTransition row `index` has `from_low > from_high`: it covers no level.
    InvalidTransition {
        /// Position in the transition table.
        index: usize,
    },
    /// LevelTransition row `index` names a level that is not defined: as its source
    /// range's lower or upper end (unless that is 255, the open end of every level above,
    /// as in [`LevelTransition::on_level_and_above`](super::LevelTransition::on_level_and_above)),
    /// or as its destination.
    UndefinedTransitionLevel {
        /// Position in the transition table.
        index: usize,
        /// The undefined level.
        level: SafetyLevel,
    },
    /// Two transition rows cover the same event in the same level.
    ConflictingTransition {
        /// A level covered by both rows.
        level: SafetyLevel,
        /// The event.
        event: EventId,
    },
    /// The [`SafetyHandle`](super::SafetyHandle) is already bound to
    /// another [`SafetySystem`](super::SafetySystem), which is still alive
    /// (dropping it releases the handle).
    HandleInUse,
}

impl fmt::Display for SafetyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            SafetyError::NoLevels => write!(f, "no safety levels defined"),
            SafetyError::LevelOutOfOrder { index, level } => {
                write!(f, "levels[{index}] defines {level}; list levels in id order")
            }
            SafetyError::UnknownEntryLevel { level } => {
                write!(f, "entry level {} is not defined", level.id())
            }
            SafetyError::TooManyInputs { count } => {
                write!(f, "{count} critical inputs declared, at most 32 allowed")
            }
            SafetyError::TooManyOutputs { count } => {
                write!(f, "{count} critical outputs declared, at most 32 allowed")
            }
            SafetyError::InputOutOfOrder { index, input } => write!(
                f,
                "inputs[{index}] declares input {}; list inputs in id order",
                input.index()
            ),
            SafetyError::OutputOutOfOrder { index, output } => write!(
                f,
                "outputs[{index}] declares output {}; list outputs in id order",
                output.index()
            ),
            SafetyError::MissingInputAction {
                level_name,
                input_name,
                ..
            } => write!(
                f,
                "level '{level_name}' has no action for critical input '{input_name}'"
            ),
            SafetyError::DuplicateInputAction {
                level_name,
                input_name,
                ..
            } => write!(
                f,
                "level '{level_name}' has two actions for critical input '{input_name}'"
            ),
            SafetyError::UnknownInput {
                level_name, input, ..
            } => write!(
                f,
                "level '{level_name}' has an action for undeclared input {}",
                input.index()
            ),
            SafetyError::InputKindMismatch {
                level_name,
                input_name,
                ..
            } => write!(
                f,
                "level '{level_name}': action for input '{input_name}' has the wrong type"
            ),
            SafetyError::InvalidRange {
                level_name,
                input_name,
                ..
            } => write!(
                f,
                "level '{level_name}': the check of input '{input_name}' has min > max, an empty band or a NaN value"
            ),
            SafetyError::InputEventOutOfRange {
                level_name,
                input_name,
                event,
                ..
            } => write!(
                f,
                "level '{level_name}': input '{input_name}' triggers {event}, whose id is out of range (max 31)"
            ),
            SafetyError::InputEventWithoutTransition {
                level_name,
                input_name,
                event,
                ..
            } => write!(
                f,
                "level '{level_name}': input '{input_name}' triggers {event}, which has no transition from this level"
            ),
            SafetyError::MissingOutputAction {
                level_name,
                output_name,
                ..
            } => write!(
                f,
                "level '{level_name}' has no action for critical output '{output_name}'"
            ),
            SafetyError::DuplicateOutputAction {
                level_name,
                output_name,
                ..
            } => write!(
                f,
                "level '{level_name}' has two actions for critical output '{output_name}'"
            ),
            SafetyError::UnknownOutput {
                level_name, output, ..
            } => write!(
                f,
                "level '{level_name}' has an action for undeclared output {}",
                output.index()
            ),
            SafetyError::OutputKindMismatch {
                level_name,
                output_name,
                ..
            } => write!(
                f,
                "level '{level_name}': action for output '{output_name}' has the wrong type"
            ),
            SafetyError::NanOutputValue {
                level_name,
                output_name,
                ..
            } => write!(
                f,
                "level '{level_name}': action for critical output '{output_name}' writes NaN"
            ),
            SafetyError::EventOutOfRange { event } => {
                write!(f, "{event}: id out of range (max 31)")
            }
            SafetyError::InvalidTransition { index } => {
                write!(f, "transition row {index} covers no level (from_low > from_high)")
            }
            SafetyError::UndefinedTransitionLevel { index, level } => write!(
                f,
                "transition row {index} names level {}, which is not defined",
                level.id()
            ),
            SafetyError::ConflictingTransition { level, event } => {
                write!(f, "two transitions for {event} in {level}")
            }
            SafetyError::HandleInUse => write!(
                f,
                "safety handle already bound to a live safety system (drop it first)"
            ),
        }
    }
}

impl core::error::Error for SafetyError {}
