//! The transition table: which event leads from which levels to which
//! level.

use super::event::{EventId, EventVisibility, SafetyEvent};
use super::level::SafetyLevel;

/// One row of the transition table: `event` leads from every level in
/// `from_low..=from_high` to level `to`.
///
/// A row can cover one level ([`on`](Self::on)) or a band of levels
/// ([`on_levels_between`](Self::on_levels_between),
/// [`on_level_and_above`](Self::on_level_and_above),
/// [`on_level_and_below`](Self::on_level_and_below), EEROS's
/// `addEventToAllLevelsBetween` / `addEventToLevelAndAbove` /
/// `addEventToLevelAndBelow`), so the per-level tables of EEROS are one
/// flat, const table here. Two rows covering the same level and event
/// are a construction error
/// ([`SafetyError::ConflictingTransition`](super::SafetyError::ConflictingTransition)).
/// A row whose destination is the level itself makes "stay" explicit: the
/// event is then known, but no exit / entry action runs.
///
/// ```
/// use rtseq::safety::*;
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// const READY: SafetyLevel = SafetyLevel::new(1);
/// const MOVING: SafetyLevel = SafetyLevel::new(2);
/// const START: PublicEvent = PublicEvent::new(0);
/// const ESTOP: PrivateEvent = PrivateEvent::new(0);
/// const TABLE: [LevelTransition; 2] = [
///     LevelTransition::on(READY, START, MOVING),
///     LevelTransition::on_level_and_above(READY, ESTOP, OFF),
/// ];
/// assert!(TABLE[1].covers(MOVING, ESTOP.id()));
/// assert!(!TABLE[1].covers(OFF, ESTOP.id()));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelTransition {
    event: EventId,
    from_low: SafetyLevel,
    from_high: SafetyLevel,
    to: SafetyLevel,
}

impl LevelTransition {
    /// `event` in level `from` leads to `to` (EEROS `addEvent`).
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on(SafetyLevel::new(1), PublicEvent::new(0), SafetyLevel::new(2));
    /// assert_eq!(t.to(), SafetyLevel::new(2));
    /// ```
    pub const fn on<K: EventVisibility>(
        from: SafetyLevel,
        event: SafetyEvent<K>,
        to: SafetyLevel,
    ) -> Self {
        Self {
            event: event.id(),
            from_low: from,
            from_high: from,
            to,
        }
    }

    /// `event` in every level from `low` up to `high` (inclusive) leads to
    /// `to`.
    ///
    /// ```
    /// use rtseq::safety::{PrivateEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on_levels_between(
    ///     SafetyLevel::new(2), SafetyLevel::new(4), PrivateEvent::new(0), SafetyLevel::new(1));
    /// assert!(t.covers(SafetyLevel::new(3), PrivateEvent::new(0).id()));
    /// assert!(!t.covers(SafetyLevel::new(5), PrivateEvent::new(0).id()));
    /// ```
    pub const fn on_levels_between<K: EventVisibility>(
        low: SafetyLevel,
        high: SafetyLevel,
        event: SafetyEvent<K>,
        to: SafetyLevel,
    ) -> Self {
        Self {
            event: event.id(),
            from_low: low,
            from_high: high,
            to,
        }
    }

    /// `event` in `level` and every less safe (higher) level leads to
    /// `to` — the usual emergency row.
    ///
    /// ```
    /// use rtseq::safety::{PrivateEvent, SafetyLevel, LevelTransition};
    /// const ESTOP: PrivateEvent = PrivateEvent::new(0);
    /// let t = LevelTransition::on_level_and_above(SafetyLevel::new(1), ESTOP, SafetyLevel::new(0));
    /// assert!(t.covers(SafetyLevel::new(200), ESTOP.id()));
    /// ```
    pub const fn on_level_and_above<K: EventVisibility>(
        level: SafetyLevel,
        event: SafetyEvent<K>,
        to: SafetyLevel,
    ) -> Self {
        Self {
            event: event.id(),
            from_low: level,
            from_high: SafetyLevel::new(u8::MAX),
            to,
        }
    }

    /// `event` in `level` and every safer (lower) level leads to `to`.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// const RESET: PublicEvent = PublicEvent::new(1);
    /// let t = LevelTransition::on_level_and_below(SafetyLevel::new(1), RESET, SafetyLevel::new(2));
    /// assert!(t.covers(SafetyLevel::new(0), RESET.id()));
    /// ```
    pub const fn on_level_and_below<K: EventVisibility>(
        level: SafetyLevel,
        event: SafetyEvent<K>,
        to: SafetyLevel,
    ) -> Self {
        Self {
            event: event.id(),
            from_low: SafetyLevel::SAFEST,
            from_high: level,
            to,
        }
    }

    /// Whether this row applies to `event` in `level`.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// const GO: PublicEvent = PublicEvent::new(0);
    /// let t = LevelTransition::on(SafetyLevel::new(1), GO, SafetyLevel::new(2));
    /// assert!(t.covers(SafetyLevel::new(1), GO.id()));
    /// assert!(!t.covers(SafetyLevel::new(2), GO.id()));
    /// ```
    pub const fn covers(&self, level: SafetyLevel, event: EventId) -> bool {
        self.event.same(event) && self.from_low.le(level) && level.le(self.from_high)
    }

    /// The event of this row.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on(SafetyLevel::new(1), PublicEvent::new(3), SafetyLevel::new(2));
    /// assert_eq!(t.event(), PublicEvent::new(3).id());
    /// ```
    pub const fn event(&self) -> EventId {
        self.event
    }

    /// The lowest level this row applies to.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on_level_and_below(SafetyLevel::new(3), PublicEvent::new(0), SafetyLevel::new(4));
    /// assert_eq!(t.from_low(), SafetyLevel::new(0));
    /// ```
    pub const fn from_low(&self) -> SafetyLevel {
        self.from_low
    }

    /// The highest level this row applies to.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on_level_and_below(SafetyLevel::new(3), PublicEvent::new(0), SafetyLevel::new(4));
    /// assert_eq!(t.from_high(), SafetyLevel::new(3));
    /// ```
    pub const fn from_high(&self) -> SafetyLevel {
        self.from_high
    }

    /// The destination level.
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyLevel, LevelTransition};
    /// let t = LevelTransition::on(SafetyLevel::new(1), PublicEvent::new(0), SafetyLevel::new(0));
    /// assert_eq!(t.to(), SafetyLevel::new(0));
    /// ```
    pub const fn to(&self) -> SafetyLevel {
        self.to
    }
}
