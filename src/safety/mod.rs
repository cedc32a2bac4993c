//! The safety system (EEROS `SafetySystem`): safety levels, events,
//! transitions, critical inputs and outputs, run in the highest-priority
//! task.
//!
//! # Concepts
//!
//! * [`SafetyLevel`]s are ordered ids, **lower = safer**; each has a
//!   [`LevelDef`] with one [`InputAction`] per critical input, one
//!   [`OutputAction`] per critical output, and optional level / entry /
//!   exit actions and an [`AbortPolicy`].
//! * Events are [`PublicEvent`]s (any sequence may trigger them through
//!   the lock-free [`SafetyHandle`]) or [`PrivateEvent`]s (only the
//!   safety system itself: input actions and level / entry actions,
//!   through the [`SafetyContext`] that only it can create). The
//!   distinction is a type, not a run-time check.
//! * The [`LevelTransition`] table maps (level, event) to a level; rows may
//!   cover a band of levels ("this event on every level from A up to B").
//! * [`CriticalInput`]s are checked per level (`ignore`, `check`, `range`,
//!   `off_range`), [`CriticalOutput`]s are driven per level (`set`,
//!   `leave`, `toggle`) every cycle, through the application's
//!   [`SafetyIo`].
//! * [`SafetyProperties`] holds the whole description (const, so it can be
//!   a `static` and checked at compile time); [`SafetySystem`] is the
//!   owned, running part; [`SafetySystem::cycle`] is one safety period.
//! * A level can demand "abort all sequences" through [`Sequences`].
//! * With a sequencer, the system is built on the handle the sequencer holds
//!   ([`Sequencer::safety_handle`](crate::Sequencer::safety_handle)), so its
//!   sequences reach it ([`Cx::safety_system`](crate::Cx::safety_system)); a
//!   `static` handle of its own serves a safety system without a sequencer.
//!
//! Everything is `no_std`, heap-free and panic-free; see
//! [`SafetySystem::cycle`] for the exact order of a cycle.
//!
//! # Private events cannot be triggered from outside
//!
//! A sequence only has the [`SafetyHandle`], whose
//! [`trigger`](SafetyHandle::trigger) accepts [`PublicEvent`]s only:
//!
//! ```compile_fail,E0308
//! use rtseq::safety::{PrivateEvent, SafetyHandle};
//! static SAFETY: SafetyHandle = SafetyHandle::new();
//! const EMERGENCY: PrivateEvent = PrivateEvent::new(0);
//! fn some_sequence_step() {
//!     SAFETY.trigger(EMERGENCY); // error[E0308]: mismatched types
//! }
//! ```
//!
//! and the same call with a public event compiles:
//!
//! ```
//! use rtseq::safety::{PublicEvent, SafetyHandle};
//! static SAFETY: SafetyHandle = SafetyHandle::new();
//! const STOP: PublicEvent = PublicEvent::new(0);
//! fn some_sequence_step() {
//!     SAFETY.trigger(STOP);
//! }
//! # some_sequence_step();
//! ```
//!
//! A private event cannot be turned into a public one either (the id
//! spaces are separate and there is no conversion):
//!
//! ```compile_fail,E0308
//! use rtseq::safety::{PrivateEvent, PublicEvent};
//! const EMERGENCY: PrivateEvent = PrivateEvent::new(0);
//! let forged: PublicEvent = EMERGENCY;
//! ```
//!
//! # Example
//!
//! Five levels, an emergency stop input, a motor-current input, an
//! enable output and a blinking lamp:
//!
//! ```
//! use rtseq::safety::*;
//!
//! const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
//! const OFF: SafetyLevel = SafetyLevel::new(1);
//! const HOMING: SafetyLevel = SafetyLevel::new(2);
//! const READY: SafetyLevel = SafetyLevel::new(3);
//! const MOVING: SafetyLevel = SafetyLevel::new(4);
//!
//! const SWITCH_ON: PublicEvent = PublicEvent::new(0);
//! const START_MOVING: PublicEvent = PublicEvent::new(1);
//! const STOP_MOVING: PublicEvent = PublicEvent::new(2);
//! const RESET: PublicEvent = PublicEvent::new(3);
//! const ESTOP: PrivateEvent = PrivateEvent::new(0);
//! const HOMED: PrivateEvent = PrivateEvent::new(1);
//!
//! const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
//! const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "motor current [A]");
//! const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
//! const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "status lamp");
//!
//! struct Board { estop: bool, current: f32, enable: bool, lamp: bool, homed: bool }
//! impl SafetyIo for Board {
//!     fn read_input(&mut self, input: InputId) -> IoValue {
//!         if input == ESTOP_IN.id() { self.estop.into() } else { self.current.into() }
//!     }
//!     fn write_output(&mut self, output: OutputId, value: IoValue) {
//!         let on = value == IoValue::Bool(true);
//!         if output == ENABLE.id() { self.enable = on } else { self.lamp = on }
//!     }
//! }
//! fn homing(ctx: &mut SafetyContext<'_>, board: &mut Board) {
//!     if board.homed { ctx.trigger(HOMED) }
//! }
//!
//! const WATCH: [InputAction; 2] = [ESTOP_IN.check(false, ESTOP), CURRENT.range(-8.0, 8.0, ESTOP)];
//! static PROPS: SafetyProperties<'static, Board, 5> = SafetyProperties::new(
//!     [
//!         LevelDef::new(EMERGENCY, "emergency")
//!             .inputs(&[ESTOP_IN.ignore(), CURRENT.ignore()])
//!             .outputs(&[ENABLE.set(false), LAMP.toggle()])
//!             .abort_sequences(AbortPolicy::WhileActive),
//!         LevelDef::new(OFF, "off")
//!             .inputs(&WATCH)
//!             .outputs(&[ENABLE.set(false), LAMP.set(false)]),
//!         LevelDef::new(HOMING, "homing")
//!             .inputs(&WATCH)
//!             .outputs(&[ENABLE.set(true), LAMP.set(true)])
//!             .level_action(homing),
//!         LevelDef::new(READY, "ready").inputs(&WATCH).outputs(&[ENABLE.set(true), LAMP.set(true)]),
//!         LevelDef::new(MOVING, "moving").inputs(&WATCH).outputs(&[ENABLE.set(true), LAMP.set(true)]),
//!     ],
//!     &[ESTOP_IN.info(), CURRENT.info()],
//!     &[ENABLE.info(), LAMP.info()],
//!     &[
//!         LevelTransition::on_level_and_above(OFF, ESTOP, EMERGENCY),
//!         LevelTransition::on(EMERGENCY, RESET, OFF),
//!         LevelTransition::on(OFF, SWITCH_ON, HOMING),
//!         LevelTransition::on(HOMING, HOMED, READY),
//!         LevelTransition::on(READY, START_MOVING, MOVING),
//!         LevelTransition::on(MOVING, STOP_MOVING, READY),
//!     ],
//!     OFF,
//! );
//! const _: () = assert!(PROPS.validate().is_ok()); // completeness, at compile time
//! static SAFETY: SafetyHandle = SafetyHandle::new();
//!
//! let mut safety = SafetySystem::new(&PROPS, &SAFETY)?;
//! let mut board = Board { estop: false, current: 0.0, enable: false, lamp: false, homed: false };
//! safety.cycle(&mut board, &NoSequences);
//! SAFETY.trigger(SWITCH_ON);
//! safety.cycle(&mut board, &NoSequences);
//! assert_eq!(SAFETY.level(), HOMING);
//! board.homed = true;
//! safety.cycle(&mut board, &NoSequences); // level action triggers HOMED
//! safety.cycle(&mut board, &NoSequences);
//! assert_eq!(SAFETY.level(), READY);
//! board.current = 9.5;                    // overcurrent
//! safety.cycle(&mut board, &NoSequences);
//! let report = safety.cycle(&mut board, &NoSequences);
//! assert_eq!(report.change, Some(LevelChange { from: Some(READY), to: EMERGENCY }));
//! assert!(report.aborted && !board.enable);
//! # Ok::<(), SafetyError>(())
//! ```

#![deny(
    missing_docs,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]

mod bits;
mod context;
mod error;
mod event;
mod handle;
mod input;
mod io;
mod level;
mod level_def;
mod output;
mod properties;
mod system;
mod transition;

pub use context::SafetyContext;
pub use error::SafetyError;
pub use event::{
    EventId, EventKind, EventVisibility, Private, PrivateEvent, Public, PublicEvent, SafetyEvent,
};
pub use handle::SafetyHandle;
pub(crate) use handle::ABORT_ALL_BY_SAFETY_SYSTEM;
pub use input::{CriticalInput, CriticalInputInfo, InputAction, InputCheck};
pub use io::{InputId, IoKind, IoType, IoValue, OutputId, SafetyIo};
pub use level::SafetyLevel;
pub use level_def::{AbortPolicy, ExitFn, LevelDef, LevelFn, LevelStats};
pub use output::{CriticalOutput, CriticalOutputInfo, OutputAction, OutputMode};
pub use properties::{SafetyProperties, ValidProperties};
pub use system::{CycleReport, LevelChange, NoSequences, SafetySystem, Sequences, UnknownEvent};
pub use transition::LevelTransition;

/// Maximum number of public events, and of private events (ids `0..32`
/// each): one bit each in a 32-bit pending-event mask.
///
/// ```
/// assert_eq!(rtseq::safety::MAX_EVENTS, 32);
/// ```
pub const MAX_EVENTS: usize = 32;

/// Maximum number of critical inputs.
///
/// ```
/// assert_eq!(rtseq::safety::MAX_INPUTS, 32);
/// ```
pub const MAX_INPUTS: usize = 32;

/// Maximum number of critical outputs.
///
/// ```
/// assert_eq!(rtseq::safety::MAX_OUTPUTS, 32);
/// ```
pub const MAX_OUTPUTS: usize = 32;
