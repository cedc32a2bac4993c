//! The private-event token handed to level, entry and input actions.

use super::bits::bit_of;
use super::event::{EventId, EventKind, EventVisibility, SafetyEvent};
use super::level::SafetyLevel;
use super::level_def::LevelStats;

/// Events triggered inside the safety system during one cycle, resolved
/// at the start of the next cycle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PendingEvents {
    pub(crate) public: u32,
    pub(crate) private: u32,
    /// Events whose id does not fit the bitmask (always unknown).
    pub(crate) out_of_range: Option<OutOfRange>,
}

/// Events triggered with an id that does not fit the bitmask of pending events (always
/// unknown): how many, and the last one.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct OutOfRange {
    pub(crate) count: u32,
    pub(crate) last: EventId,
}

impl PendingEvents {
    pub(crate) const fn new() -> Self {
        Self {
            public: 0,
            private: 0,
            out_of_range: None,
        }
    }

    /// Out of line: called from the input loop only when a check fires.
    #[inline(never)]
    pub(crate) fn add(&mut self, event: EventId) {
        let bit = bit_of(usize::from(event.index()));
        if bit == 0 {
            let before = self.out_of_range.map_or(0, |o| o.count);
            self.out_of_range = Some(OutOfRange {
                count: before.saturating_add(1),
                last: event,
            });
            return;
        }
        match event.kind() {
            EventKind::Public => self.public |= bit,
            EventKind::Private => self.private |= bit,
        }
    }
}

/// The safety system's private context (EEROS `SafetyContext`): the only
/// way to trigger a [`PrivateEvent`](super::PrivateEvent).
///
/// Only the safety system creates it, and only for the duration of a
/// level or entry action; nothing outside this module can construct one,
/// so code that is not running inside the safety system (a sequence, a
/// condition, another task) cannot trigger a private event — this is a
/// compile-time guarantee:
///
/// ```compile_fail,E0451
/// use rtseq::safety::SafetyContext;
/// let ctx = SafetyContext { pending: todo!(), level: todo!(), stats: todo!() }; // private fields
/// ```
///
/// Events triggered here are resolved at the start of the next cycle
/// (like events from the [`SafetyHandle`](super::SafetyHandle)).
///
/// ```
/// use rtseq::safety::*;
/// struct Io { homed: bool }
/// const HOMED: PrivateEvent = PrivateEvent::new(0);
/// fn homing(ctx: &mut SafetyContext<'_>, io: &mut Io) {
///     if io.homed {
///         ctx.trigger(HOMED);
///     }
/// }
/// # let _ = homing;
/// ```
#[derive(Debug)]
pub struct SafetyContext<'c> {
    pending: &'c mut PendingEvents,
    level: SafetyLevel,
    stats: LevelStats,
}

impl<'c> SafetyContext<'c> {
    pub(crate) fn new(
        pending: &'c mut PendingEvents,
        level: SafetyLevel,
        stats: LevelStats,
    ) -> Self {
        Self {
            pending,
            level,
            stats,
        }
    }

    /// Triggers a public or private event; it is resolved against the
    /// current level at the start of the next cycle, together with every
    /// other event of this cycle (the safest resulting level wins).
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const FAULT: PrivateEvent = PrivateEvent::new(3);
    /// const STOP: PublicEvent = PublicEvent::new(1);
    /// fn watchdog(ctx: &mut SafetyContext<'_>, _io: &mut Io) {
    ///     ctx.trigger(FAULT);
    ///     ctx.trigger(STOP);
    /// }
    /// # let _ = watchdog;
    /// ```
    pub fn trigger<K: EventVisibility>(&mut self, event: SafetyEvent<K>) {
        self.pending.add(event.id());
    }

    /// The level whose action is running.
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io { level: u8 }
    /// fn log_level(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    ///     io.level = ctx.level().id();
    /// }
    /// # let _ = log_level;
    /// ```
    pub fn level(&self) -> SafetyLevel {
        self.level
    }

    /// The counters of the level whose action is running, this entry or cycle included:
    /// in an entry action, `activations` counts this entry and `cycles` the cycles run
    /// before it; in a level action, `cycles` counts this cycle (EEROS's
    /// `getNofActivations()`, which level actions use to act after a number of cycles).
    ///
    /// Leave `moving` for `emergency` in its third cycle:
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const GIVE_UP: PrivateEvent = PrivateEvent::new(0);
    /// fn moving(ctx: &mut SafetyContext<'_>, _io: &mut Io) {
    ///     if ctx.stats().cycles > 2 {
    ///         ctx.trigger(GIVE_UP);
    ///     }
    /// }
    /// # let _ = moving;
    /// ```
    pub fn stats(&self) -> LevelStats {
        self.stats
    }
}
