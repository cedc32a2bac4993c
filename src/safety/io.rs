//! Values of critical inputs and outputs and the application's IO trait.

use core::fmt;

mod sealed {
    pub trait Sealed {}
    impl Sealed for bool {}
    impl Sealed for i32 {}
    impl Sealed for f32 {}
}

/// The value of a critical input or output: a bool (switch, relay,
/// enable line) or a number (ADC reading, current, temperature, duty).
///
/// ```
/// use rtseq::safety::IoValue;
/// assert_eq!(IoValue::from(true), IoValue::Bool(true));
/// assert_eq!(IoValue::from(-3), IoValue::Int(-3));
/// assert_eq!(IoValue::from(1.5f32), IoValue::Float(1.5));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IoValue {
    /// A digital signal.
    Bool(bool),
    /// An integer signal (raw ADC counts, encoder ticks, milliamps...).
    Int(i32),
    /// A floating-point signal (physical units).
    Float(f32),
}

impl IoValue {
    /// The kind of the value.
    ///
    /// ```
    /// use rtseq::safety::{IoKind, IoValue};
    /// assert_eq!(IoValue::Int(4).kind(), IoKind::Int);
    /// ```
    pub const fn kind(self) -> IoKind {
        match self {
            IoValue::Bool(_) => IoKind::Bool,
            IoValue::Int(_) => IoKind::Int,
            IoValue::Float(_) => IoKind::Float,
        }
    }

    /// The bool, if this is a [`IoValue::Bool`].
    ///
    /// ```
    /// use rtseq::safety::IoValue;
    /// assert_eq!(IoValue::Bool(true).as_bool(), Some(true));
    /// assert_eq!(IoValue::Int(1).as_bool(), None);
    /// ```
    pub const fn as_bool(self) -> Option<bool> {
        match self {
            IoValue::Bool(b) => Some(b),
            _ => None,
        }
    }

    /// The integer, if this is a [`IoValue::Int`].
    ///
    /// ```
    /// use rtseq::safety::IoValue;
    /// assert_eq!(IoValue::Int(7).as_int(), Some(7));
    /// ```
    pub const fn as_int(self) -> Option<i32> {
        match self {
            IoValue::Int(v) => Some(v),
            _ => None,
        }
    }

    /// The float, if this is a [`IoValue::Float`].
    ///
    /// ```
    /// use rtseq::safety::IoValue;
    /// assert_eq!(IoValue::Float(0.5).as_float(), Some(0.5));
    /// ```
    pub const fn as_float(self) -> Option<f32> {
        match self {
            IoValue::Float(v) => Some(v),
            _ => None,
        }
    }

    /// `self == other` for values of the same kind; values of different
    /// kinds are never equal.
    pub(crate) fn same_as(self, other: IoValue) -> bool {
        match (self, other) {
            (IoValue::Bool(a), IoValue::Bool(b)) => a == b,
            (IoValue::Int(a), IoValue::Int(b)) => a == b,
            (IoValue::Float(a), IoValue::Float(b)) => a == b,
            _ => false,
        }
    }

    /// `min <= self <= max` for numbers; false for bools, mismatched kinds
    /// and NaN.
    pub(crate) fn within(self, min: IoValue, max: IoValue) -> bool {
        match (self, min, max) {
            (IoValue::Int(v), IoValue::Int(lo), IoValue::Int(hi)) => lo <= v && v <= hi,
            (IoValue::Float(v), IoValue::Float(lo), IoValue::Float(hi)) => lo <= v && v <= hi,
            _ => false,
        }
    }

    /// `self <= min || self >= max` for numbers; false for bools,
    /// mismatched kinds and NaN.
    pub(crate) fn outside_open(self, min: IoValue, max: IoValue) -> bool {
        match (self, min, max) {
            (IoValue::Int(v), IoValue::Int(lo), IoValue::Int(hi)) => v <= lo || v >= hi,
            (IoValue::Float(v), IoValue::Float(lo), IoValue::Float(hi)) => v <= lo || v >= hi,
            _ => false,
        }
    }
}

impl From<bool> for IoValue {
    fn from(v: bool) -> Self {
        IoValue::Bool(v)
    }
}
impl From<i32> for IoValue {
    fn from(v: i32) -> Self {
        IoValue::Int(v)
    }
}
impl From<f32> for IoValue {
    fn from(v: f32) -> Self {
        IoValue::Float(v)
    }
}

impl fmt::Display for IoValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IoValue::Bool(v) => write!(f, "{v}"),
            IoValue::Int(v) => write!(f, "{v}"),
            IoValue::Float(v) => write!(f, "{v}"),
        }
    }
}

/// The kind of a critical input or output.
///
/// ```
/// use rtseq::safety::{CriticalInput, IoKind};
/// const T: CriticalInput<f32> = CriticalInput::new(0, "temperature");
/// assert_eq!(T.info().kind(), IoKind::Float);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IoKind {
    /// `bool`
    Bool,
    /// `i32`
    Int,
    /// `f32`
    Float,
}

impl IoKind {
    pub(crate) const fn same(self, other: IoKind) -> bool {
        matches!(
            (self, other),
            (IoKind::Bool, IoKind::Bool)
                | (IoKind::Int, IoKind::Int)
                | (IoKind::Float, IoKind::Float)
        )
    }
}

/// The Rust types a critical input or output may carry: `bool`, `i32`,
/// `f32`. Sealed.
///
/// ```
/// use rtseq::safety::{IoKind, IoType};
/// assert_eq!(<i32 as IoType>::KIND, IoKind::Int);
/// ```
pub trait IoType: sealed::Sealed + Copy + Into<IoValue> {
    /// The matching [`IoKind`].
    const KIND: IoKind;
}
impl IoType for bool {
    const KIND: IoKind = IoKind::Bool;
}
impl IoType for i32 {
    const KIND: IoKind = IoKind::Int;
}
impl IoType for f32 {
    const KIND: IoKind = IoKind::Float;
}

/// Index of a critical input (`0..32`), passed to
/// [`SafetyIo::read_input`].
///
/// ```
/// use rtseq::safety::{CriticalInput, InputId};
/// const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
/// const ESTOP_ID: InputId = ESTOP.id();
/// assert_eq!(ESTOP_ID.index(), 0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InputId(pub(crate) u8);

impl InputId {
    /// The index as `usize` (e.g. into the application's input table).
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// assert_eq!(CriticalInput::<i32>::new(5, "adc").id().index(), 5);
    /// ```
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

/// Index of a critical output (`0..32`), passed to
/// [`SafetyIo::write_output`].
///
/// ```
/// use rtseq::safety::{CriticalOutput, OutputId};
/// const ENABLE: CriticalOutput<bool> = CriticalOutput::new(1, "enable");
/// const ENABLE_ID: OutputId = ENABLE.id();
/// assert_eq!(ENABLE_ID.index(), 1);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutputId(pub(crate) u8);

impl OutputId {
    /// The index as `usize` (e.g. into the application's output table).
    ///
    /// ```
    /// use rtseq::safety::CriticalOutput;
    /// assert_eq!(CriticalOutput::<bool>::new(2, "led").id().index(), 2);
    /// ```
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

/// The application's access to its critical inputs and outputs (GPIO,
/// ADC, PWM on the chip; simulated values on the host).
///
/// The safety system only reads inputs whose action is not `ignore`, and
/// only writes outputs whose action is not `leave`. A read must return a
/// value of the input's declared kind; a value of another kind fails the
/// check (fail-safe), as does a NaN.
///
/// ```
/// use rtseq::safety::{InputId, IoValue, OutputId, SafetyIo};
/// struct SimIo { inputs: [IoValue; 2], outputs: [IoValue; 1] }
/// impl SafetyIo for SimIo {
///     fn read_input(&mut self, input: InputId) -> IoValue {
///         self.inputs.get(input.index()).copied().unwrap_or(IoValue::Bool(false))
///     }
///     fn write_output(&mut self, output: OutputId, value: IoValue) {
///         if let Some(slot) = self.outputs.get_mut(output.index()) { *slot = value; }
///     }
/// }
/// ```
pub trait SafetyIo {
    /// Reads critical input `input` now.
    fn read_input(&mut self, input: InputId) -> IoValue;
    /// Drives critical output `output` to `value`.
    fn write_output(&mut self, output: OutputId, value: IoValue);
}
