//! Critical inputs and the per-level input actions.

use core::marker::PhantomData;

use super::event::{EventId, EventVisibility, SafetyEvent};
use super::io::{InputId, IoKind, IoType, IoValue};

/// A critical input of type `T` (`bool`, `i32` or `f32`): an index plus a
/// name. Declared as a constant; its typed methods build the per-level
/// [`InputAction`]s, so an action's values always match the input's type.
///
/// ```
/// use rtseq::safety::{CriticalInput, PrivateEvent};
/// const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "emergency stop (NC)");
/// const CURRENT: CriticalInput<f32> = CriticalInput::new(1, "motor current [A]");
/// const FAULT: PrivateEvent = PrivateEvent::new(0);
/// let _a = ESTOP_IN.check(true, FAULT);      // fires when the NC contact opens
/// let _b = CURRENT.range(-10.0, 10.0, FAULT); // fires outside [-10, 10]
/// ```
pub struct CriticalInput<T> {
    id: InputId,
    name: &'static str,
    _type: PhantomData<fn() -> T>,
}

impl<T> Clone for CriticalInput<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for CriticalInput<T> {}
impl<T> core::fmt::Debug for CriticalInput<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("CriticalInput")
            .field("id", &self.id)
            .field("name", &self.name)
            .finish()
    }
}

impl<T: IoType> CriticalInput<T> {
    /// Declares critical input `index` (`0..32`, its position in the
    /// properties' input list) with a name for diagnostics.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(2, "door closed");
    /// assert_eq!(DOOR.name(), "door closed");
    /// ```
    pub const fn new(index: u8, name: &'static str) -> Self {
        Self {
            id: InputId(index),
            name,
            _type: PhantomData,
        }
    }

    /// The input's id.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// assert_eq!(CriticalInput::<bool>::new(2, "door").id().index(), 2);
    /// ```
    pub const fn id(self) -> InputId {
        self.id
    }

    /// The input's name.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// assert_eq!(CriticalInput::<i32>::new(0, "adc0").name(), "adc0");
    /// ```
    pub const fn name(self) -> &'static str {
        self.name
    }

    /// The type-erased declaration for
    /// [`SafetyProperties::new`](super::SafetyProperties::new).
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, CriticalInputInfo, IoKind};
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
    /// const INPUTS: [CriticalInputInfo; 1] = [DOOR.info()];
    /// assert_eq!(INPUTS[0].kind(), IoKind::Bool);
    /// ```
    pub const fn info(self) -> CriticalInputInfo {
        CriticalInputInfo {
            id: self.id,
            name: self.name,
            kind: T::KIND,
        }
    }

    /// Input action: do not read the input in this level.
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, InputCheck};
    /// const DOOR: CriticalInput<bool> = CriticalInput::new(0, "door");
    /// assert_eq!(DOOR.ignore().check(), InputCheck::Ignore);
    /// ```
    pub const fn ignore(self) -> InputAction {
        InputAction::new(self.id, T::KIND, InputCheck::Ignore)
    }
}

macro_rules! check_method {
    ($t:ty, $variant:ident, $example:literal) => {
        impl CriticalInput<$t> {
            /// Input action: trigger `event` in every cycle the input does
            /// **not** equal `expected`.
            ///
            /// ```
            /// use rtseq::safety::*;
            #[doc = $example]
            /// const FAULT: PrivateEvent = PrivateEvent::new(0);
            /// let action = IN.check(EXPECTED, FAULT);
            /// assert_eq!(action.check(), InputCheck::Check {
            ///     expected: EXPECTED.into(),
            ///     event: FAULT.id(),
            /// });
            /// ```
            pub const fn check<K: EventVisibility>(
                self,
                expected: $t,
                event: SafetyEvent<K>,
            ) -> InputAction {
                InputAction::new(
                    self.id,
                    <$t as IoType>::KIND,
                    InputCheck::Check {
                        expected: IoValue::$variant(expected),
                        event: event.id(),
                    },
                )
            }
        }
    };
}

check_method!(
    bool,
    Bool,
    "const IN: CriticalInput<bool> = CriticalInput::new(0, \"estop\"); const EXPECTED: bool = false;"
);
check_method!(
    i32,
    Int,
    "const IN: CriticalInput<i32> = CriticalInput::new(0, \"mode switch\"); const EXPECTED: i32 = 2;"
);
check_method!(
    f32,
    Float,
    "const IN: CriticalInput<f32> = CriticalInput::new(0, \"supply [V]\"); const EXPECTED: f32 = 24.0;"
);

macro_rules! range_methods {
    ($t:ty, $variant:ident, $example:literal) => {
        impl CriticalInput<$t> {
            /// Input action: trigger `event` in every cycle the input is
            /// **outside** `[min, max]` (bounds inclusive; a NaN reading
            /// also triggers).
            ///
            /// ```
            /// use rtseq::safety::*;
            #[doc = $example]
            /// const OVER: PrivateEvent = PrivateEvent::new(0);
            /// let action = IN.range(MIN, MAX, OVER);
            /// assert_eq!(action.check(), InputCheck::Range {
            ///     min: MIN.into(), max: MAX.into(), event: OVER.id(),
            /// });
            /// ```
            pub const fn range<K: EventVisibility>(
                self,
                min: $t,
                max: $t,
                event: SafetyEvent<K>,
            ) -> InputAction {
                InputAction::new(
                    self.id,
                    <$t as IoType>::KIND,
                    InputCheck::Range {
                        min: IoValue::$variant(min),
                        max: IoValue::$variant(max),
                        event: event.id(),
                    },
                )
            }

            /// Input action (EEROS `range(..., offRange = true)`): trigger
            /// `event` in every cycle the input is strictly **inside**
            /// `(min, max)` (a NaN reading also triggers). Typical use: a
            /// dead band that must be left, e.g. a speed that must not
            /// stall.
            ///
            /// ```
            /// use rtseq::safety::*;
            #[doc = $example]
            /// const STALL: PublicEvent = PublicEvent::new(0);
            /// let action = IN.off_range(MIN, MAX, STALL);
            /// assert_eq!(action.check(), InputCheck::OffRange {
            ///     min: MIN.into(), max: MAX.into(), event: STALL.id(),
            /// });
            /// ```
            pub const fn off_range<K: EventVisibility>(
                self,
                min: $t,
                max: $t,
                event: SafetyEvent<K>,
            ) -> InputAction {
                InputAction::new(
                    self.id,
                    <$t as IoType>::KIND,
                    InputCheck::OffRange {
                        min: IoValue::$variant(min),
                        max: IoValue::$variant(max),
                        event: event.id(),
                    },
                )
            }
        }
    };
}

range_methods!(
    i32,
    Int,
    "const IN: CriticalInput<i32> = CriticalInput::new(0, \"adc\"); const MIN: i32 = 100; const MAX: i32 = 3900;"
);
range_methods!(
    f32,
    Float,
    "const IN: CriticalInput<f32> = CriticalInput::new(0, \"current\"); const MIN: f32 = -5.0; const MAX: f32 = 5.0;"
);

/// Type-erased declaration of a critical input (id, name, kind), as
/// listed in [`SafetyProperties::new`](super::SafetyProperties::new).
///
/// ```
/// use rtseq::safety::CriticalInput;
/// let info = CriticalInput::<i32>::new(3, "adc3").info();
/// assert_eq!((info.id().index(), info.name()), (3, "adc3"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CriticalInputInfo {
    id: InputId,
    name: &'static str,
    kind: IoKind,
}

impl CriticalInputInfo {
    /// The input's id.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// assert_eq!(CriticalInput::<bool>::new(1, "x").info().id().index(), 1);
    /// ```
    pub const fn id(&self) -> InputId {
        self.id
    }

    /// The input's name.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// assert_eq!(CriticalInput::<bool>::new(1, "x").info().name(), "x");
    /// ```
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// The input's kind.
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, IoKind};
    /// assert_eq!(CriticalInput::<i32>::new(1, "x").info().kind(), IoKind::Int);
    /// ```
    pub const fn kind(&self) -> IoKind {
        self.kind
    }
}

/// What a level does with one critical input in every cycle.
///
/// ```
/// use rtseq::safety::{CriticalInput, InputCheck, PrivateEvent};
/// const IN: CriticalInput<i32> = CriticalInput::new(0, "adc");
/// const E: PrivateEvent = PrivateEvent::new(0);
/// assert!(matches!(IN.range(0, 10, E).check(), InputCheck::Range { .. }));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InputCheck {
    /// The input is not read.
    Ignore,
    /// `event` fires while the input differs from `expected`.
    Check {
        /// The expected (healthy) value.
        expected: IoValue,
        /// The event triggered on a mismatch.
        event: EventId,
    },
    /// `event` fires while the input is outside `[min, max]`.
    Range {
        /// Lower healthy bound (inclusive).
        min: IoValue,
        /// Upper healthy bound (inclusive).
        max: IoValue,
        /// The event triggered outside the bounds.
        event: EventId,
    },
    /// `event` fires while the input is strictly inside `(min, max)`.
    OffRange {
        /// Lower bound of the forbidden band (exclusive).
        min: IoValue,
        /// Upper bound of the forbidden band (exclusive).
        max: IoValue,
        /// The event triggered inside the band.
        event: EventId,
    },
}

impl InputCheck {
    /// The event this check triggers for the reading `value`, if any.
    /// Readings of the wrong kind and NaN readings fail every check
    /// except `Ignore` (fail-safe).
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, IoValue, PrivateEvent};
    /// const IN: CriticalInput<f32> = CriticalInput::new(0, "current");
    /// const OVER: PrivateEvent = PrivateEvent::new(0);
    /// let c = IN.range(-1.0, 1.0, OVER).check();
    /// assert_eq!(c.evaluate(IoValue::Float(0.5)), None);
    /// assert_eq!(c.evaluate(IoValue::Float(1.5)), Some(OVER.id()));
    /// assert_eq!(c.evaluate(IoValue::Float(f32::NAN)), Some(OVER.id()));
    /// ```
    pub fn evaluate(&self, value: IoValue) -> Option<EventId> {
        match *self {
            InputCheck::Ignore => None,
            InputCheck::Check { expected, event } => (!value.same_as(expected)).then_some(event),
            InputCheck::Range { min, max, event } => (!value.within(min, max)).then_some(event),
            InputCheck::OffRange { min, max, event } => {
                (!value.outside_open(min, max)).then_some(event)
            }
        }
    }

    /// The event this check can trigger (`None` for `Ignore`).
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, PrivateEvent};
    /// const IN: CriticalInput<bool> = CriticalInput::new(0, "estop");
    /// assert_eq!(IN.check(false, PrivateEvent::new(1)).check().event(), Some(PrivateEvent::new(1).id()));
    /// assert_eq!(IN.ignore().check().event(), None);
    /// ```
    pub const fn event(&self) -> Option<EventId> {
        match *self {
            InputCheck::Ignore => None,
            InputCheck::Check { event, .. }
            | InputCheck::Range { event, .. }
            | InputCheck::OffRange { event, .. } => Some(event),
        }
    }
}

/// One level's action for one critical input: the input plus an
/// [`InputCheck`]. Built with the typed methods of [`CriticalInput`]
/// (`ignore`, `check`, `range`, `off_range`).
///
/// ```
/// use rtseq::safety::{CriticalInput, PublicEvent};
/// const ADC: CriticalInput<i32> = CriticalInput::new(4, "adc4");
/// let a = ADC.range(0, 4095, PublicEvent::new(0));
/// assert_eq!(a.input(), ADC.id());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InputAction {
    input: InputId,
    kind: IoKind,
    /// Which readings can pass.
    pass: Pass,
    /// The event (`EventId::public(0)`, unused, for `Ignore`).
    event: EventId,
    /// The healthy readings are the keys (see [`key`]) from `low` up to
    /// `low + span`, wrapping from `i32::MAX` to `i32::MIN`: one compare
    /// for every check.
    low: i32,
    span: u32,
    /// The check as it was written (for [`check`](Self::check)).
    check: InputCheck,
}

/// Which readings can pass a compiled check: those of one kind (the
/// variants in the order of [`IoValue`]'s, so the test is one compare with
/// the reading's tag), none, or the input is not read at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Pass {
    Bool,
    Int,
    Float,
    /// No reading passes (a range whose bounds are out of order).
    Nothing,
    /// `ignore`: the input is not read.
    Unread,
}

/// An `f32` as an `i32` with the same order for every non-NaN value
/// (`-0.0` just below `+0.0`): two's complement from sign and magnitude.
/// A NaN maps above `+inf` (positive sign) or below `-inf` (negative).
#[inline(always)]
const fn float_key(f: f32) -> i32 {
    let b = f.to_bits() as i32;
    b ^ (((b >> 31) as u32) >> 1) as i32
}

/// A reading's ordered key (bools 0 and 1, integers themselves, floats
/// [`float_key`]) and the readings of its kind that pass; `None` for a NaN.
#[inline(always)]
fn key(value: IoValue) -> Option<(Pass, i32)> {
    match value {
        IoValue::Bool(v) => Some((Pass::Bool, i32::from(v))),
        IoValue::Int(v) => Some((Pass::Int, v)),
        IoValue::Float(v) if v.is_nan() => None,
        IoValue::Float(v) => Some((Pass::Float, float_key(v))),
    }
}

/// The key of a lower bound; a float zero takes the key of `-0.0`, so `-0.0` and `+0.0`
/// are both at or above it.
const fn low_bound_key(v: IoValue) -> i32 {
    match v {
        // A float pattern compares with `==`: `0.0` matches `-0.0` too.
        IoValue::Float(0.0) => float_key(-0.0),
        _ => high_bound_key(v),
    }
}

/// The key of an upper bound; a float zero takes the key of `+0.0`, so `-0.0` and `+0.0`
/// are both at or below it.
const fn high_bound_key(v: IoValue) -> i32 {
    match v {
        IoValue::Bool(b) => b as i32,
        IoValue::Int(i) => i,
        IoValue::Float(0.0) => float_key(0.0),
        IoValue::Float(f) => float_key(f),
    }
}

/// The keys from `low` up to `high` (none if `high < low`).
const fn between(pass: Pass, low: i32, high: i32) -> (Pass, i32, u32) {
    if high < low {
        (Pass::Nothing, 0, 0)
    } else {
        (pass, low, high.wrapping_sub(low) as u32)
    }
}

impl InputAction {
    /// Compiles `check` (whose values are of `kind`, as the typed
    /// constructors guarantee) into the range of healthy keys. A zero float
    /// bound takes the key of the zero that keeps `-0.0 == 0.0`.
    const fn new(input: InputId, kind: IoKind, check: InputCheck) -> Self {
        let pass = match kind {
            IoKind::Bool => Pass::Bool,
            IoKind::Int => Pass::Int,
            IoKind::Float => Pass::Float,
        };
        let (pass, low, span) = match check {
            InputCheck::Ignore => (Pass::Unread, 0, 0),
            // (A NaN `expected` leaves only NaN keys, which no reading
            // reaches: NaN readings fire before the compare.)
            InputCheck::Check { expected, .. } => {
                between(pass, low_bound_key(expected), high_bound_key(expected))
            }
            InputCheck::Range { min, max, .. } => {
                between(pass, low_bound_key(min), high_bound_key(max))
            }
            // Healthy: up to `min` and from `max` on, which wraps around
            // from `i32::MAX` to `i32::MIN`; everything if nothing lies
            // strictly between.
            InputCheck::OffRange { min, max, .. } => {
                let up_to = high_bound_key(min);
                let from = low_bound_key(max);
                if from <= up_to.saturating_add(1) {
                    (pass, 0, u32::MAX)
                } else {
                    (pass, from, up_to.wrapping_sub(from) as u32)
                }
            }
        };
        let event = match check.event() {
            Some(event) => event,
            None => EventId::public(0),
        };
        InputAction {
            input,
            kind,
            pass,
            event,
            low,
            span,
            check,
        }
    }

    /// Whether the input is not read at all (`ignore`).
    #[inline(always)]
    pub(crate) fn is_ignored(&self) -> bool {
        self.pass == Pass::Unread
    }

    /// The event of a firing check (meaningless for `Ignore`).
    #[inline(always)]
    pub(crate) fn event(&self) -> EventId {
        self.event
    }

    /// Whether `value` fires the check: the same result as
    /// [`InputCheck::evaluate`], with one compare of the reading's key. A
    /// value of another kind than the input's, and NaN, fire (fail-safe);
    /// `ignore` never fires.
    #[inline(always)]
    pub(crate) fn fires(&self, value: IoValue) -> bool {
        match key(value) {
            _ if self.is_ignored() => false,
            Some((pass, key)) => pass != self.pass || key.wrapping_sub(self.low) as u32 > self.span,
            None => true,
        }
    }

    /// The input this action reads.
    ///
    /// ```
    /// use rtseq::safety::CriticalInput;
    /// const IN: CriticalInput<bool> = CriticalInput::new(1, "door");
    /// assert_eq!(IN.ignore().input().index(), 1);
    /// ```
    pub const fn input(&self) -> InputId {
        self.input
    }

    /// The check applied to the reading.
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, InputCheck};
    /// const IN: CriticalInput<bool> = CriticalInput::new(1, "door");
    /// assert_eq!(IN.ignore().check(), InputCheck::Ignore);
    /// ```
    pub const fn check(&self) -> InputCheck {
        self.check
    }

    /// The kind of the input this action was built for.
    ///
    /// ```
    /// use rtseq::safety::{CriticalInput, IoKind};
    /// const IN: CriticalInput<f32> = CriticalInput::new(1, "v");
    /// assert_eq!(IN.ignore().kind(), IoKind::Float);
    /// ```
    pub const fn kind(&self) -> IoKind {
        self.kind
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    extern crate std;
    use super::*;
    use crate::safety::PrivateEvent;
    use std::vec;
    use std::vec::Vec;

    const E: PrivateEvent = PrivateEvent::new(1);

    /// The compiled check (`fires`) agrees with `InputCheck::evaluate` (the
    /// reference semantics) on a grid of values, including ±0, ±inf, NaN,
    /// extreme integers and values of the wrong kind.
    #[test]
    fn compiled_checks_agree_with_the_reference_semantics() {
        const F: CriticalInput<f32> = CriticalInput::new(0, "f");
        const I: CriticalInput<i32> = CriticalInput::new(1, "i");
        const B: CriticalInput<bool> = CriticalInput::new(2, "b");
        let floats = [
            f32::NEG_INFINITY,
            -5.5,
            -1.0,
            -0.0,
            0.0,
            1e-30,
            1.0,
            5.5,
            f32::INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::MIN,
            f32::MAX,
        ];
        let ints = [i32::MIN, -10, -1, 0, 1, 10, i32::MAX];
        let mut values: Vec<IoValue> = floats.iter().map(|&f| IoValue::Float(f)).collect();
        values.extend(ints.iter().map(|&i| IoValue::Int(i)));
        values.extend([IoValue::Bool(false), IoValue::Bool(true)]);
        let mut actions = vec![B.ignore(), B.check(false, E), B.check(true, E)];
        for &a in &floats {
            actions.push(F.check(a, E));
            for &b in &floats {
                if a <= b {
                    actions.push(F.range(a, b, E));
                    actions.push(F.off_range(a, b, E));
                }
            }
        }
        for &a in &ints {
            actions.push(I.check(a, E));
            for &b in &ints {
                if a <= b {
                    actions.push(I.range(a, b, E));
                    actions.push(I.off_range(a, b, E));
                }
            }
        }
        for action in &actions {
            let reference = action.check();
            for &v in &values {
                assert_eq!(
                    action.fires(v),
                    reference.evaluate(v).is_some(),
                    "{reference:?} on {v:?}"
                );
            }
        }
    }

    /// `check()` gives back the check the action was built from.
    #[test]
    fn compiled_checks_round_trip() {
        const F: CriticalInput<f32> = CriticalInput::new(0, "f");
        let a = F.range(-2.5, 7.0, E);
        assert_eq!(
            a.check(),
            InputCheck::Range {
                min: IoValue::Float(-2.5),
                max: IoValue::Float(7.0),
                event: E.id()
            }
        );
        let z = F.off_range(0.0, 0.0, E).check();
        assert_eq!(
            z,
            InputCheck::OffRange {
                min: IoValue::Float(0.0),
                max: IoValue::Float(0.0),
                event: E.id()
            }
        );
    }
}
