//! Safety events: public and private, distinguished by type.
//!
//! EEROS marks an *event* as public or private where it is added to a
//! level's transition table and checks at run time whether the caller
//! holds the private context. rtseq makes the distinction part of the
//! event's type instead: [`PublicEvent`] and [`PrivateEvent`] are two
//! different types, the lock-free [`SafetyHandle`](super::SafetyHandle)
//! only accepts the former, and only a
//! [`SafetyContext`](super::SafetyContext) (which nothing outside the
//! safety system can construct) accepts both. Public and private events
//! have separate id spaces, so a private event cannot be forged from a
//! public one either.

use core::fmt;
use core::marker::PhantomData;

use super::MAX_EVENTS;

mod sealed {
    pub trait Sealed {}
}

/// Whether an event is public or private (the run-time view of the
/// [`Public`] / [`Private`] marker types).
///
/// ```
/// use rtseq::safety::{EventKind, PrivateEvent, PublicEvent};
/// assert_eq!(PublicEvent::new(1).id().kind(), EventKind::Public);
/// assert_eq!(PrivateEvent::new(1).id().kind(), EventKind::Private);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EventKind {
    /// Any sequence (any priority) may trigger it through the
    /// [`SafetyHandle`](super::SafetyHandle).
    Public,
    /// Only the safety system itself may trigger it: entry actions,
    /// level actions and input actions.
    Private,
}

/// Marker trait for the two event visibilities; sealed, implemented by
/// [`Public`] and [`Private`] only.
///
/// ```
/// use rtseq::safety::{EventKind, EventVisibility, Private, Public};
/// assert_eq!(<Public as EventVisibility>::KIND, EventKind::Public);
/// assert_eq!(<Private as EventVisibility>::KIND, EventKind::Private);
/// ```
pub trait EventVisibility: sealed::Sealed {
    /// The run-time kind of events with this visibility.
    const KIND: EventKind;
}

/// Marker type of public events, see [`PublicEvent`].
///
/// ```
/// use rtseq::safety::{Public, SafetyEvent};
/// const START: SafetyEvent<Public> = SafetyEvent::new(0);
/// # let _ = START;
/// ```
#[derive(Debug)]
pub enum Public {}

/// Marker type of private events, see [`PrivateEvent`].
///
/// ```
/// use rtseq::safety::{Private, SafetyEvent};
/// const FAULT: SafetyEvent<Private> = SafetyEvent::new(0);
/// # let _ = FAULT;
/// ```
#[derive(Debug)]
pub enum Private {}

impl sealed::Sealed for Public {}
impl sealed::Sealed for Private {}
impl EventVisibility for Public {
    const KIND: EventKind = EventKind::Public;
}
impl EventVisibility for Private {
    const KIND: EventKind = EventKind::Private;
}

/// A safety event with visibility `K` ([`Public`] or [`Private`]).
///
/// Events are small `Copy` ids, declared as constants. Ids are
/// `0..MAX_EVENTS` (32) per visibility; an id outside that range is
/// rejected by [`SafetyProperties::validate`](super::SafetyProperties::validate)
/// when used in a table and counted as an unknown event when triggered.
///
/// ```
/// use rtseq::safety::{PrivateEvent, PublicEvent};
/// const START_MOVING: PublicEvent = PublicEvent::new(0);
/// const OVERCURRENT: PrivateEvent = PrivateEvent::new(0); // separate id space
/// assert_ne!(START_MOVING.id(), OVERCURRENT.id());
/// ```
pub struct SafetyEvent<K> {
    index: u8,
    _kind: PhantomData<fn() -> K>,
}

/// An event any sequence may trigger through the lock-free
/// [`SafetyHandle`](super::SafetyHandle).
///
/// ```
/// use rtseq::safety::{PublicEvent, SafetyHandle};
/// const START: PublicEvent = PublicEvent::new(3);
/// static HANDLE: SafetyHandle = SafetyHandle::new();
/// HANDLE.trigger(START);
/// ```
pub type PublicEvent = SafetyEvent<Public>;

/// An event only the safety system itself can trigger (level, entry and
/// input actions, through a [`SafetyContext`](super::SafetyContext)).
///
/// ```
/// use rtseq::safety::{CriticalInput, PrivateEvent};
/// const EMERGENCY: PrivateEvent = PrivateEvent::new(0);
/// const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "emergency stop");
/// let _rule = ESTOP_IN.check(false, EMERGENCY); // fine: input actions may use it
/// ```
pub type PrivateEvent = SafetyEvent<Private>;

impl<K: EventVisibility> SafetyEvent<K> {
    /// Declares the event with the given id (`0..32`, unique per
    /// visibility).
    ///
    /// ```
    /// use rtseq::safety::PublicEvent;
    /// const HOMING_DONE: PublicEvent = PublicEvent::new(1);
    /// assert_eq!(HOMING_DONE.id().index(), 1);
    /// ```
    pub const fn new(index: u8) -> Self {
        Self {
            index,
            _kind: PhantomData,
        }
    }

    /// The type-erased id (kind and index) used in tables and reports.
    ///
    /// ```
    /// use rtseq::safety::{EventId, PrivateEvent};
    /// assert_eq!(PrivateEvent::new(2).id(), EventId::private(2));
    /// ```
    pub const fn id(self) -> EventId {
        EventId {
            kind: K::KIND,
            index: self.index,
        }
    }
}

impl<K> Clone for SafetyEvent<K> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<K> Copy for SafetyEvent<K> {}
impl<K> PartialEq for SafetyEvent<K> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index
    }
}
impl<K> Eq for SafetyEvent<K> {}
impl<K: EventVisibility> fmt::Debug for SafetyEvent<K> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.id(), f)
    }
}
#[cfg(feature = "defmt")]
impl<K: EventVisibility> defmt::Format for SafetyEvent<K> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::Format::format(&self.id(), f)
    }
}
impl<K: EventVisibility> From<SafetyEvent<K>> for EventId {
    fn from(event: SafetyEvent<K>) -> Self {
        event.id()
    }
}

/// Type-erased event id: kind plus index. Used in the transition table
/// and in reports (e.g. the last unknown event); it cannot be triggered.
///
/// ```
/// use rtseq::safety::{EventId, EventKind, PublicEvent};
/// let id: EventId = PublicEvent::new(4).into();
/// assert_eq!((id.kind(), id.index()), (EventKind::Public, 4));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EventId {
    kind: EventKind,
    index: u8,
}

impl EventId {
    /// The id of public event `index`.
    ///
    /// ```
    /// use rtseq::safety::{EventId, PublicEvent};
    /// assert_eq!(EventId::public(0), PublicEvent::new(0).id());
    /// ```
    pub const fn public(index: u8) -> Self {
        Self {
            kind: EventKind::Public,
            index,
        }
    }

    /// The id of private event `index`.
    ///
    /// ```
    /// use rtseq::safety::{EventId, PrivateEvent};
    /// assert_eq!(EventId::private(0), PrivateEvent::new(0).id());
    /// ```
    pub const fn private(index: u8) -> Self {
        Self {
            kind: EventKind::Private,
            index,
        }
    }

    /// The id of event `index` of `kind`.
    pub(crate) const fn new(kind: EventKind, index: u8) -> Self {
        Self { kind, index }
    }

    /// Public or private.
    ///
    /// ```
    /// use rtseq::safety::{EventId, EventKind};
    /// assert_eq!(EventId::private(1).kind(), EventKind::Private);
    /// ```
    pub const fn kind(self) -> EventKind {
        self.kind
    }

    /// The index within its kind.
    ///
    /// ```
    /// use rtseq::safety::EventId;
    /// assert_eq!(EventId::public(7).index(), 7);
    /// ```
    pub const fn index(self) -> u8 {
        self.index
    }

    /// Whether the index fits the pending-event bitmask (`< 32`).
    ///
    /// ```
    /// use rtseq::safety::EventId;
    /// assert!(EventId::public(31).is_in_range());
    /// assert!(!EventId::public(32).is_in_range());
    /// ```
    pub const fn is_in_range(self) -> bool {
        (self.index as usize) < MAX_EVENTS
    }

    /// Const equality (for validation in `const` contexts).
    pub(crate) const fn same(self, other: Self) -> bool {
        self.index == other.index
            && matches!(
                (self.kind, other.kind),
                (EventKind::Public, EventKind::Public) | (EventKind::Private, EventKind::Private)
            )
    }
}

impl fmt::Display for EventId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            EventKind::Public => write!(f, "public event {}", self.index),
            EventKind::Private => write!(f, "private event {}", self.index),
        }
    }
}
