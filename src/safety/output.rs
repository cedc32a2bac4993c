//! Critical outputs and the per-level output actions.

use core::marker::PhantomData;

use super::io::{IoKind, IoType, IoValue, OutputId};

/// A critical output of type `T` (`bool`, `i32` or `f32`): an index plus a
/// name. Declared as a constant; its typed methods build the per-level
/// [`OutputAction`]s.
///
/// ```
/// use rtseq::safety::CriticalOutput;
/// const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
/// const DUTY: CriticalOutput<i32> = CriticalOutput::new(1, "pwm duty");
/// let _off = [ENABLE.set(false), DUTY.set(0)];
/// ```
pub struct CriticalOutput<T> {
    id: OutputId,
    name: &'static str,
    _type: PhantomData<fn() -> T>,
}

impl<T> Clone for CriticalOutput<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for CriticalOutput<T> {}
impl<T> core::fmt::Debug for CriticalOutput<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("CriticalOutput")
            .field("id", &self.id)
            .field("name", &self.name)
            .finish()
    }
}

impl<T: IoType> CriticalOutput<T> {
    /// Declares critical output `index` (`0..32`, its position in the
    /// properties' output list) with a name for diagnostics.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// const BRAKE: CriticalOutput<bool> = CriticalOutput::new(0, "brake released");
    /// assert_eq!(BRAKE.name(), "brake released");
    /// ```
    pub const fn new(index: u8, name: &'static str) -> Self {
        Self {
            id: OutputId(index),
            name,
            _type: PhantomData,
        }
    }

    /// The output's id.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// assert_eq!(CriticalOutput::<bool>::new(3, "x").id().index(), 3);
    /// ```
    pub const fn id(self) -> OutputId {
        self.id
    }

    /// The output's name.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// assert_eq!(CriticalOutput::<f32>::new(0, "dac").name(), "dac");
    /// ```
    pub const fn name(self) -> &'static str {
        self.name
    }

    /// The type-erased declaration for
    /// [`SafetyProperties::new`](super::SafetyProperties::new).
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, CriticalOutputInfo, IoKind};
    /// const LED: CriticalOutput<bool> = CriticalOutput::new(0, "led");
    /// const OUTPUTS: [CriticalOutputInfo; 1] = [LED.info()];
    /// assert_eq!(OUTPUTS[0].kind(), IoKind::Bool);
    /// ```
    pub const fn info(self) -> CriticalOutputInfo {
        CriticalOutputInfo {
            id: self.id,
            name: self.name,
            kind: T::KIND,
        }
    }

    /// Output action: do not write the output in this level (it keeps
    /// whatever it was last set to).
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, OutputMode};
    /// const LED: CriticalOutput<bool> = CriticalOutput::new(0, "led");
    /// assert_eq!(LED.leave().mode(), OutputMode::Leave);
    /// ```
    pub const fn leave(self) -> OutputAction {
        OutputAction::new(self.id, T::KIND, OutputMode::Leave)
    }
}

macro_rules! set_method {
    ($t:ty, $variant:ident, $example:literal) => {
        impl CriticalOutput<$t> {
            /// Output action: write `value` in every cycle of the level.
            ///
            /// ```
            /// use rtseq::safety::*;
            #[doc = $example]
            /// assert_eq!(OUT.set(VALUE).mode(), OutputMode::Set(VALUE.into()));
            /// ```
            pub const fn set(self, value: $t) -> OutputAction {
                OutputAction::new(
                    self.id,
                    <$t as IoType>::KIND,
                    OutputMode::Set(IoValue::$variant(value)),
                )
            }
        }
    };
}

set_method!(
    bool,
    Bool,
    "const OUT: CriticalOutput<bool> = CriticalOutput::new(0, \"enable\"); const VALUE: bool = false;"
);
set_method!(
    i32,
    Int,
    "const OUT: CriticalOutput<i32> = CriticalOutput::new(0, \"duty\"); const VALUE: i32 = 0;"
);
set_method!(
    f32,
    Float,
    "const OUT: CriticalOutput<f32> = CriticalOutput::new(0, \"torque limit\"); const VALUE: f32 = 0.0;"
);

impl CriticalOutput<bool> {
    /// Output action: write `false`, `true`, `false`, ... in consecutive
    /// cycles of the level, starting with `false` in the cycle the level
    /// is entered (a blinking status lamp, a watchdog line).
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, IoValue, OutputMode};
    /// const LAMP: CriticalOutput<bool> = CriticalOutput::new(0, "lamp");
    /// assert_eq!(LAMP.toggle().mode(), OutputMode::Toggle {
    ///     low: IoValue::Bool(false), high: IoValue::Bool(true),
    /// });
    /// ```
    pub const fn toggle(self) -> OutputAction {
        OutputAction::new(
            self.id,
            IoKind::Bool,
            OutputMode::Toggle {
                low: IoValue::Bool(false),
                high: IoValue::Bool(true),
            },
        )
    }
}

macro_rules! toggle_method {
    ($t:ty, $variant:ident, $example:literal) => {
        impl CriticalOutput<$t> {
            /// Output action: write `low`, `high`, `low`, ... in
            /// consecutive cycles of the level, starting with `low` in the
            /// cycle the level is entered.
            ///
            /// ```
            /// use rtseq::safety::*;
            #[doc = $example]
            /// assert_eq!(OUT.toggle(LOW, HIGH).mode(), OutputMode::Toggle {
            ///     low: LOW.into(), high: HIGH.into(),
            /// });
            /// ```
            pub const fn toggle(self, low: $t, high: $t) -> OutputAction {
                OutputAction::new(
                    self.id,
                    <$t as IoType>::KIND,
                    OutputMode::Toggle {
                        low: IoValue::$variant(low),
                        high: IoValue::$variant(high),
                    },
                )
            }
        }
    };
}

toggle_method!(
    i32,
    Int,
    "const OUT: CriticalOutput<i32> = CriticalOutput::new(0, \"duty\"); const LOW: i32 = 0; const HIGH: i32 = 100;"
);
toggle_method!(
    f32,
    Float,
    "const OUT: CriticalOutput<f32> = CriticalOutput::new(0, \"dac\"); const LOW: f32 = 0.0; const HIGH: f32 = 3.3;"
);

/// Type-erased declaration of a critical output (id, name, kind), as
/// listed in [`SafetyProperties::new`](super::SafetyProperties::new).
///
/// ```
/// use rtseq::safety::CriticalOutput;
/// let info = CriticalOutput::<bool>::new(1, "brake").info();
/// assert_eq!((info.id().index(), info.name()), (1, "brake"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CriticalOutputInfo {
    id: OutputId,
    name: &'static str,
    kind: IoKind,
}

impl CriticalOutputInfo {
    /// The output's id.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// assert_eq!(CriticalOutput::<bool>::new(1, "x").info().id().index(), 1);
    /// ```
    pub const fn id(&self) -> OutputId {
        self.id
    }

    /// The output's name.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// assert_eq!(CriticalOutput::<bool>::new(1, "x").info().name(), "x");
    /// ```
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// The output's kind.
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, IoKind};
    /// assert_eq!(CriticalOutput::<f32>::new(1, "x").info().kind(), IoKind::Float);
    /// ```
    pub const fn kind(&self) -> IoKind {
        self.kind
    }
}

/// What a level does with one critical output in every cycle.
///
/// ```
/// use rtseq::safety::{CriticalOutput, IoValue, OutputMode};
/// const EN: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
/// assert_eq!(EN.set(true).mode(), OutputMode::Set(IoValue::Bool(true)));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputMode {
    /// Write this value every cycle.
    Set(IoValue),
    /// Do not write.
    Leave,
    /// Alternate `low` / `high` every cycle, `low` first after entry.
    Toggle {
        /// Written in the entering cycle and every second cycle after.
        low: IoValue,
        /// Written in the other cycles.
        high: IoValue,
    },
}

/// One level's action for one critical output: the output plus an
/// [`OutputMode`]. Built with the typed methods of [`CriticalOutput`]
/// (`set`, `leave`, `toggle`).
///
/// ```
/// use rtseq::safety::CriticalOutput;
/// const EN: CriticalOutput<bool> = CriticalOutput::new(2, "enable");
/// assert_eq!(EN.set(false).output(), EN.id());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutputAction {
    output: OutputId,
    kind: IoKind,
    op: OutputOp,
    /// The `set` value or the toggle's `low`.
    low: IoValue,
    /// The toggle's `high` (equal to `low` otherwise).
    high: IoValue,
}

/// The compiled form of an [`OutputMode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum OutputOp {
    // `Set` first: the common case is one compare with zero.
    Set,
    Leave,
    Toggle,
}

impl OutputAction {
    /// Compiles `mode` (whose values are of `kind`, as the typed
    /// constructors guarantee) into the compact form.
    const fn new(output: OutputId, kind: IoKind, mode: OutputMode) -> Self {
        let (op, low, high) = match mode {
            OutputMode::Set(v) => (OutputOp::Set, v, v),
            OutputMode::Leave => (OutputOp::Leave, IoValue::Bool(false), IoValue::Bool(false)),
            OutputMode::Toggle { low, high } => (OutputOp::Toggle, low, high),
        };
        OutputAction {
            output,
            kind,
            op,
            low,
            high,
        }
    }

    /// Drives the output for one cycle: writes the `set` value, or the
    /// toggle's current value (flipping its bit in `toggles`), or nothing
    /// (`leave`). `set` is the inline fast path.
    #[inline(always)]
    pub(crate) fn apply<IO: super::io::SafetyIo>(&self, io: &mut IO, toggles: &mut u32) {
        if let OutputOp::Set = self.op {
            io.write_output(self.output, self.low);
        } else {
            self.apply_other(io, toggles);
        }
    }

    /// `leave` and `toggle`.
    #[inline(never)]
    fn apply_other<IO: super::io::SafetyIo>(&self, io: &mut IO, toggles: &mut u32) {
        if let OutputOp::Toggle = self.op {
            let bit = super::bits::bit_of(self.output.index());
            let high = *toggles & bit != 0;
            *toggles ^= bit;
            io.write_output(self.output, if high { self.high } else { self.low });
        }
    }

    /// The output this action drives.
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// const EN: CriticalOutput<bool> = CriticalOutput::new(2, "enable");
    /// assert_eq!(EN.leave().output().index(), 2);
    /// ```
    pub const fn output(&self) -> OutputId {
        self.output
    }

    /// How the output is driven.
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, OutputMode};
    /// const EN: CriticalOutput<bool> = CriticalOutput::new(2, "enable");
    /// assert_eq!(EN.leave().mode(), OutputMode::Leave);
    /// ```
    pub const fn mode(&self) -> OutputMode {
        match self.op {
            OutputOp::Set => OutputMode::Set(self.low),
            OutputOp::Leave => OutputMode::Leave,
            OutputOp::Toggle => OutputMode::Toggle {
                low: self.low,
                high: self.high,
            },
        }
    }

    /// The kind of the output this action was built for.
    ///
    /// ```
    /// use rtseq::safety::{CriticalOutput, IoKind};
    /// const D: CriticalOutput<i32> = CriticalOutput::new(0, "duty");
    /// assert_eq!(D.set(5).kind(), IoKind::Int);
    /// ```
    pub const fn kind(&self) -> IoKind {
        self.kind
    }
}
