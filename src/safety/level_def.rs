//! A level's definition: its input and output actions, level / entry / exit actions and
//! abort policy.

use core::fmt;

use super::context::SafetyContext;
use super::input::InputAction;
use super::level::SafetyLevel;
use super::output::OutputAction;

/// Whether entering (or staying in) a level aborts all running sequences
/// through [`Sequences`](super::Sequences).
///
/// ```
/// use rtseq::safety::{AbortPolicy, LevelDef, SafetyLevel};
/// # struct Io;
/// const EMERGENCY: LevelDef<'static, Io> =
///     LevelDef::new(SafetyLevel::new(0), "emergency").abort_sequences(AbortPolicy::WhileActive);
/// assert_eq!(EMERGENCY.abort_policy(), AbortPolicy::WhileActive);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AbortPolicy {
    /// Sequences keep running (default).
    #[default]
    Never,
    /// `abort_all` is called once, in the cycle the level is entered
    /// (right after its entry action).
    OnEntry,
    /// `abort_all` is called in the entering cycle and in every further
    /// cycle spent in the level, so a sequence started while the level is
    /// active is aborted within one safety cycle too.
    WhileActive,
}

/// Level action and entry action: may trigger public and private events
/// through the [`SafetyContext`] and gets the application's IO / state.
///
/// ```
/// use rtseq::safety::{LevelFn, SafetyContext};
/// struct Io { homed: bool }
/// fn wait_homed(_ctx: &mut SafetyContext<'_>, io: &mut Io) { let _ = io.homed; }
/// const F: LevelFn<Io> = wait_homed;
/// # let _ = F;
/// ```
pub type LevelFn<IO> = for<'c, 'io> fn(&mut SafetyContext<'c>, &'io mut IO);

/// Exit action: gets the application's IO / state; it cannot trigger
/// events (as in EEROS, whose exit actions get no context).
///
/// ```
/// use rtseq::safety::ExitFn;
/// struct Io { brake: bool }
/// fn engage_brake(io: &mut Io) { io.brake = true; }
/// const F: ExitFn<Io> = engage_brake;
/// # let _ = F;
/// ```
pub type ExitFn<IO> = fn(&mut IO);

/// The definition of one level: name, input actions, output actions,
/// level / entry / exit actions and the abort policy. Const-constructible
/// with a builder chain.
///
/// Every level must list exactly one [`InputAction`] per critical input
/// and one [`OutputAction`] per critical output;
/// [`SafetyProperties::validate`](super::SafetyProperties::validate)
/// returns an error naming the level and the input / output otherwise.
/// The actions are evaluated in the order they are listed.
///
/// ```
/// use rtseq::safety::*;
/// # struct Io;
/// const READY: SafetyLevel = SafetyLevel::new(2);
/// const ESTOP: PrivateEvent = PrivateEvent::new(0);
/// const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop");
/// const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "motor current");
/// const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
/// const LED: CriticalOutput<bool> = CriticalOutput::new(1, "led");
/// fn on_ready(_ctx: &mut SafetyContext<'_>, _io: &mut Io) {}
///
/// const READY_DEF: LevelDef<'static, Io> = LevelDef::new(READY, "ready")
///     .inputs(&[ESTOP_IN.check(false, ESTOP), CURRENT.range(-2.0, 2.0, ESTOP)])
///     .outputs(&[ENABLE.set(true), LED.toggle()])
///     .on_entry(on_ready);
/// assert_eq!(READY_DEF.name(), "ready");
/// ```
pub struct LevelDef<'a, IO> {
    level: SafetyLevel,
    name: &'static str,
    inputs: &'a [InputAction],
    outputs: &'a [OutputAction],
    action: Option<LevelFn<IO>>,
    entry: Option<LevelFn<IO>>,
    exit: Option<ExitFn<IO>>,
    abort: AbortPolicy,
}

impl<'a, IO> LevelDef<'a, IO> {
    /// A level with no input / output actions (to be added with
    /// [`inputs`](Self::inputs) / [`outputs`](Self::outputs)), no level,
    /// entry or exit action and [`AbortPolicy::Never`].
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// # struct Io;
    /// const OFF: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(0), "off");
    /// assert_eq!(OFF.level(), SafetyLevel::new(0));
    /// ```
    pub const fn new(level: SafetyLevel, name: &'static str) -> Self {
        Self {
            level,
            name,
            inputs: &[],
            outputs: &[],
            action: None,
            entry: None,
            exit: None,
            abort: AbortPolicy::Never,
        }
    }

    /// Sets the input actions, one per critical input.
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, LevelDef, SafetyLevel};
    /// # struct Io;
    /// const IN: CriticalInput<bool> = CriticalInput::new(0, "door closed");
    /// const L: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(0), "off").inputs(&[IN.ignore()]);
    /// assert_eq!(L.input_actions().len(), 1);
    /// ```
    pub const fn inputs(mut self, actions: &'a [InputAction]) -> Self {
        self.inputs = actions;
        self
    }

    /// Sets the output actions, one per critical output.
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, LevelDef, SafetyLevel};
    /// # struct Io;
    /// const OUT: CriticalOutput<i32> = CriticalOutput::new(0, "pwm duty");
    /// const L: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(0), "off").outputs(&[OUT.set(0)]);
    /// assert_eq!(L.output_actions().len(), 1);
    /// ```
    pub const fn outputs(mut self, actions: &'a [OutputAction]) -> Self {
        self.outputs = actions;
        self
    }

    /// Sets the level action, run every cycle after the input checks.
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, PrivateEvent, SafetyContext, SafetyLevel};
    /// struct Io { homed: bool }
    /// const HOMED: PrivateEvent = PrivateEvent::new(1);
    /// fn homing(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    ///     if io.homed { ctx.trigger(HOMED); }
    /// }
    /// const L: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(1), "homing").level_action(homing);
    /// # let _ = L;
    /// ```
    pub const fn level_action(mut self, action: LevelFn<IO>) -> Self {
        self.action = Some(action);
        self
    }

    /// Sets the entry action, run once in the cycle the level is entered,
    /// after the exit action of the previous level.
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyContext, SafetyLevel};
    /// struct Io { entered: u32 }
    /// fn count(_ctx: &mut SafetyContext<'_>, io: &mut Io) { io.entered += 1; }
    /// const L: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(0), "off").on_entry(count);
    /// # let _ = L;
    /// ```
    pub const fn on_entry(mut self, action: LevelFn<IO>) -> Self {
        self.entry = Some(action);
        self
    }

    /// Sets the exit action, run once when the level is left (before the
    /// entry action of the next level).
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// struct Io { brake: bool }
    /// fn brake(io: &mut Io) { io.brake = true; }
    /// const L: LevelDef<'static, Io> = LevelDef::new(SafetyLevel::new(3), "moving").on_exit(brake);
    /// # let _ = L;
    /// ```
    pub const fn on_exit(mut self, action: ExitFn<IO>) -> Self {
        self.exit = Some(action);
        self
    }

    /// Makes the level request "abort all sequences", see [`AbortPolicy`].
    ///
    /// ```
    /// use rtseq::safety::{AbortPolicy, LevelDef, SafetyLevel};
    /// # struct Io;
    /// const L: LevelDef<'static, Io> =
    ///     LevelDef::new(SafetyLevel::new(0), "emergency").abort_sequences(AbortPolicy::OnEntry);
    /// # let _ = L;
    /// ```
    pub const fn abort_sequences(mut self, policy: AbortPolicy) -> Self {
        self.abort = policy;
        self
    }

    /// The level this definition belongs to.
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// # struct Io;
    /// assert_eq!(LevelDef::<Io>::new(SafetyLevel::new(1), "x").level().id(), 1);
    /// ```
    pub const fn level(&self) -> SafetyLevel {
        self.level
    }

    /// The level's name (for diagnostics and errors).
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// # struct Io;
    /// assert_eq!(LevelDef::<Io>::new(SafetyLevel::new(1), "homing").name(), "homing");
    /// ```
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// The input actions, in evaluation order.
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// # struct Io;
    /// assert!(LevelDef::<Io>::new(SafetyLevel::new(1), "x").input_actions().is_empty());
    /// ```
    pub const fn input_actions(&self) -> &'a [InputAction] {
        self.inputs
    }

    /// The output actions, in application order.
    ///
    /// ```
    /// use rtseq::safety::{LevelDef, SafetyLevel};
    /// # struct Io;
    /// assert!(LevelDef::<Io>::new(SafetyLevel::new(1), "x").output_actions().is_empty());
    /// ```
    pub const fn output_actions(&self) -> &'a [OutputAction] {
        self.outputs
    }

    /// The abort policy.
    ///
    /// ```
    /// use rtseq::safety::{AbortPolicy, LevelDef, SafetyLevel};
    /// # struct Io;
    /// assert_eq!(LevelDef::<Io>::new(SafetyLevel::new(1), "x").abort_policy(), AbortPolicy::Never);
    /// ```
    pub const fn abort_policy(&self) -> AbortPolicy {
        self.abort
    }

    pub(crate) const fn action_fn(&self) -> Option<LevelFn<IO>> {
        self.action
    }

    pub(crate) const fn entry_fn(&self) -> Option<LevelFn<IO>> {
        self.entry
    }

    pub(crate) const fn exit_fn(&self) -> Option<ExitFn<IO>> {
        self.exit
    }
}

impl<IO> Clone for LevelDef<'_, IO> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<IO> Copy for LevelDef<'_, IO> {}

impl<IO> fmt::Debug for LevelDef<'_, IO> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LevelDef")
            .field("level", &self.level)
            .field("name", &self.name)
            .field("inputs", &self.inputs)
            .field("outputs", &self.outputs)
            .field("action", &self.action.is_some())
            .field("entry", &self.entry.is_some())
            .field("exit", &self.exit.is_some())
            .field("abort", &self.abort)
            .finish()
    }
}

/// Per-level counters, all zero at construction.
///
/// `activations` counts how often the level was entered (the entry level
/// counts its first cycle as an activation); `cycles` counts the safety
/// cycles run in the level (EEROS's `nofActivations`). Both saturate.
///
/// ```
/// use rtseq::safety::LevelStats;
/// let s = LevelStats::default();
/// assert_eq!((s.activations, s.cycles), (0, 0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelStats {
    /// Number of times the level was entered.
    pub activations: u32,
    /// Number of safety cycles run in the level.
    pub cycles: u32,
}

impl LevelStats {
    /// All counters zero (const version of `default()`).
    ///
    /// ```
    /// use rtseq::safety::LevelStats;
    /// assert_eq!(LevelStats::ZERO, LevelStats::default());
    /// ```
    pub const ZERO: Self = Self {
        activations: 0,
        cycles: 0,
    };
}
