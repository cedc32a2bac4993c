//! Conditions: predicates over the control-system state and the current time.

use crate::{Duration, Instant};

/// A condition evaluated against the application's control system `C` and the sequencer time
/// (the seed's `Condition::validate`).
///
/// A condition may keep its own state between evaluations: a toggle button, "not moved for
/// 5 s". Monitors evaluate their condition in the tick at the owner's polling period.
/// Closures `FnMut(&C, Instant) -> bool` are conditions too.
///
/// ```
/// use rtseq::{Condition, Instant};
/// struct OverCurrent { limit: f32 }
/// impl Condition<f32> for OverCurrent {
///     fn validate(&mut self, current: &f32, _now: Instant) -> bool { *current > self.limit }
/// }
/// let mut c = OverCurrent { limit: 2.0 };
/// assert!(c.is_true(&2.5, Instant::from_ticks(0)));
/// ```
pub trait Condition<C> {
    /// Evaluates the condition. Must be short and must not block: it runs in the tick.
    fn validate(&mut self, control: &C, now: Instant) -> bool;

    /// A monitor's condition: its owner begins a run (a start, or a round of a restart),
    /// and this is called right before the run's first evaluation, as the monitor's edge
    /// detection starts again from "false". A condition that keeps state of its own for
    /// the run (a window, a count) starts it again here, so that what it saw in one run
    /// does not fire in the next ([`Stable`] does; [`Toggle`], an operator's latch, does
    /// not). Nothing by default. A table the sequencer takes up while the run is under way
    /// (its first due tick with a non-empty table) evaluates it from then on without this
    /// call: its conditions are new.
    ///
    /// ```
    /// use rtseq::{Condition, Instant};
    /// /// True at the third evaluation of a run.
    /// struct Third(u8);
    /// impl Condition<()> for Third {
    ///     fn validate(&mut self, _: &(), _: Instant) -> bool {
    ///         self.0 = self.0.saturating_add(1);
    ///         self.0 >= 3
    ///     }
    ///     fn begin_run(&mut self) {
    ///         self.0 = 0;
    ///     }
    /// }
    /// let mut third = Third(0);
    /// let t = Instant::from_ticks(0);
    /// assert!(!third.validate(&(), t) && !third.validate(&(), t) && third.validate(&(), t));
    /// third.begin_run();
    /// assert!(!third.validate(&(), t));
    /// ```
    fn begin_run(&mut self) {}

    /// The seed's `isTrue()`: evaluates the condition now.
    ///
    /// Not callable on a bare `dyn Condition` (call it on the `&mut dyn Condition`, which is
    /// a condition too), so that it is no entry of the trait objects' tables: the tick calls
    /// `validate`, and a table entry would link a copy of this method for every condition type.
    ///
    /// ```
    /// use rtseq::{Condition, Instant};
    /// let mut high = |v: &f32, _: Instant| *v > 1.0;
    /// let mut any: &mut (dyn Condition<f32> + Send) = &mut high;
    /// assert!(Condition::is_true(&mut any, &2.0, Instant::from_ticks(0)));
    /// assert!(any.validate(&2.0, Instant::from_ticks(0)));
    /// ```
    fn is_true(&mut self, control: &C, now: Instant) -> bool
    where
        Self: Sized,
    {
        self.validate(control, now)
    }
}

impl<C, F> Condition<C> for F
where
    F: FnMut(&C, Instant) -> bool,
{
    fn validate(&mut self, control: &C, now: Instant) -> bool {
        self(control, now)
    }
}

/// A toggle-button condition (seed §1.6): true after the first press, false after the next.
///
/// `pressed` reads the raw button; a press is a rising edge of it. Its state is the
/// operator's latch, not a run's: as a monitor's condition it carries over from one run of
/// the owner to the next (it keeps [`Condition::begin_run`]'s default), so a feed hold
/// switched on stays on when the owner starts again.
///
/// ```
/// use rtseq::{Condition, Instant, Toggle};
/// let mut t = Toggle::new(|b: &bool| *b);
/// let now = Instant::from_ticks(0);
/// assert!(!t.validate(&false, now));
/// assert!(t.validate(&true, now));   // pressed: on
/// assert!(t.validate(&false, now));  // released: stays on
/// assert!(!t.validate(&true, now));  // pressed again: off
/// ```
pub struct Toggle<F> {
    pressed: F,
    last: bool,
    on: bool,
}

impl<F> Toggle<F> {
    /// A toggle that is off until the first press.
    ///
    /// A start/stop button as a monitor condition (with a `fn`, a `Toggle` is built in a
    /// `const`):
    ///
    /// ```
    /// use rtseq::{Condition, Instant, Toggle};
    /// struct Panel { start_button: bool }
    /// fn start_button(p: &Panel) -> bool { p.start_button }
    /// const RUN: Toggle<fn(&Panel) -> bool> = Toggle::new(start_button);
    /// let mut run = RUN;
    /// let t = Instant::from_ticks(0);
    /// let presses = [false, true, true, false, true]
    ///     .map(|pressed| run.validate(&Panel { start_button: pressed }, t));
    /// assert_eq!(presses, [false, true, true, true, false]);
    /// ```
    pub const fn new(pressed: F) -> Self {
        Toggle {
            pressed,
            last: false,
            on: false,
        }
    }
}

impl<C, F: FnMut(&C) -> bool> Condition<C> for Toggle<F> {
    fn validate(&mut self, control: &C, _now: Instant) -> bool {
        let now_pressed = (self.pressed)(control);
        if now_pressed && !self.last {
            self.on = !self.on;
        }
        self.last = now_pressed;
        self.on
    }
}

/// True once a value has stayed within `tolerance` of where it was for at least `window`
/// (seed §1.6: "the robot has not moved in the last 5 seconds"). As a monitor's condition,
/// the window is of the owner's run: it starts again with each run
/// ([`Condition::begin_run`]), so an axis that stood still between two moves does not
/// read as stalled at the next move's start.
///
/// ```
/// use rtseq::{Condition, Duration, Instant, Stable};
/// let mut still = Stable::new(|pos: &f32| *pos, 0.01, Duration::from_secs(5));
/// assert!(!still.validate(&1.0, Instant::from_ticks(0)));
/// assert!(!still.validate(&1.0, Instant::from_ticks(4_000_000)));
/// assert!(still.validate(&1.0, Instant::from_ticks(5_000_000)));
/// assert!(!still.validate(&2.0, Instant::from_ticks(6_000_000))); // moved: starts over
/// ```
pub struct Stable<F> {
    value: F,
    tolerance: f32,
    window: Duration,
    anchor: Option<(f32, Instant)>,
}

impl<F> Stable<F> {
    /// Watches `value`, which counts as unchanged while within `tolerance` of its anchor.
    ///
    /// Within the tolerance, small changes do not restart the window:
    ///
    /// ```
    /// use rtseq::{Condition, Duration, Instant, Stable};
    /// let mut settled = Stable::new(|pos: &f32| *pos, 0.5, Duration::from_millis(100));
    /// let at = |ms: u64| Instant::from_ticks(ms * 1_000);
    /// assert!(!settled.validate(&10.0, at(0)));
    /// assert!(!settled.validate(&10.4, at(50)));
    /// assert!(settled.validate(&9.6, at(100))); // still within 0.5 of 10.0
    /// ```
    pub const fn new(value: F, tolerance: f32, window: Duration) -> Self {
        Stable {
            value,
            tolerance,
            window,
            anchor: None,
        }
    }
}

impl<C, F: FnMut(&C) -> f32> Condition<C> for Stable<F> {
    fn validate(&mut self, control: &C, now: Instant) -> bool {
        let v = (self.value)(control);
        match self.anchor {
            Some((a, since)) if (v - a).abs() <= self.tolerance => now
                .checked_duration_since(since)
                .is_some_and(|held| held >= self.window),
            _ => {
                self.anchor = Some((v, now));
                false
            }
        }
    }

    fn begin_run(&mut self) {
        self.anchor = None;
    }
}
