//! Identifiers of registered sequences and monitors.

/// Identifies a registered sequence or step (the seed's `getSequenceByID`).
///
/// Ids are handed out in registration order, starting at 0, by
/// [`Sequencer::register`](crate::Sequencer::register).
///
/// ```
/// use rtseq::{Sequencer, SeqConfig};
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("main")).unwrap();
/// assert_eq!(id.index(), 0);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeqId(pub(crate) u8);

impl SeqId {
    /// The position of this sequence in the sequencer's registry.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let ids = ["a", "b", "c"].map(|name| seq.register(SeqConfig::new(name)).unwrap());
    /// assert_eq!(ids.map(|id| id.index()), [0, 1, 2]);
    /// ```
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The id at registry position `index` (ids are handed out in registration order),
    /// for positions known to be below 256, as the ids of a [`Table`](crate::Table) are
    /// at compile time. It saturates at 255, which is the last id of a sequencer of 256:
    /// an index computed at run time (from a bus, a file, a loop) takes
    /// [`try_from_index`](Self::try_from_index).
    ///
    /// ```
    /// use rtseq::{SeqConfig, SeqId, Sequencer};
    /// const HOMING: SeqId = SeqId::from_index(1);
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// seq.register(SeqConfig::new("safe stop")).unwrap();
    /// assert_eq!(seq.register(SeqConfig::new("homing")), Ok(HOMING));
    /// assert_eq!(SeqId::from_index(1_000).index(), 255); // saturates
    /// ```
    pub const fn from_index(index: usize) -> Self {
        SeqId(if index > 255 { 255 } else { index as u8 })
    }

    /// The id at registry position `index`, or `None` when no sequencer has that
    /// position (256 and above). Whether the id is registered is the sequencer's to say
    /// ([`Sequencer::sequence_by_id`](crate::Sequencer::sequence_by_id)).
    ///
    /// ```
    /// use rtseq::SeqId;
    /// assert_eq!(SeqId::try_from_index(255).map(SeqId::index), Some(255));
    /// assert_eq!(SeqId::try_from_index(256), None);
    /// ```
    pub const fn try_from_index(index: usize) -> Option<Self> {
        if index > 255 {
            None
        } else {
            Some(SeqId(index as u8))
        }
    }
}

/// Identifies a monitor registered in a [`Monitors`](crate::Monitors) table.
///
/// ```
/// use rtseq::{Behaviour, Monitor, Monitors, Sequencer, SeqConfig};
/// let seq: Sequencer<u32, 4> = Sequencer::new();
/// let owner = seq.register(SeqConfig::new("move")).unwrap();
/// let mut cond = |c: &u32, _now: rtseq::Instant| *c > 10;
/// let mut monitors: Monitors<u32, 2> = Monitors::new();
/// let id = monitors.add(owner, Monitor::new("over", &mut cond, Behaviour::AbortOwner)).unwrap();
/// assert_eq!(id.index(), 0);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorId(pub(crate) u8);

impl MonitorId {
    /// The position of this monitor in its table.
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqId};
    /// let (mut a, mut b) = (|_: &(), _: Instant| false, |_: &(), _: Instant| true);
    /// let mut monitors: Monitors<(), 2> = Monitors::new();
    /// let owner = SeqId::from_index(0);
    /// monitors.add(owner, Monitor::new("a", &mut a, Behaviour::Nothing)).unwrap();
    /// let b = monitors.add(owner, Monitor::new("b", &mut b, Behaviour::Nothing)).unwrap();
    /// assert_eq!(b.index(), 1);
    /// ```
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The id at table position `index` (ids are handed out in order), for positions
    /// known to be below 256. It saturates at 255, the last id of a table of 256: an
    /// index computed at run time takes [`try_from_index`](Self::try_from_index).
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, MonitorId, Monitors, SeqId};
    /// let mut a = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 2> = Monitors::new();
    /// monitors.add(SeqId::from_index(0), Monitor::new("a", &mut a, Behaviour::Nothing)).unwrap();
    /// assert_eq!(monitors.name(MonitorId::from_index(0)), Some("a"));
    /// assert_eq!(MonitorId::from_index(300).index(), 255); // saturates
    /// ```
    pub const fn from_index(index: usize) -> Self {
        MonitorId(if index > 255 { 255 } else { index as u8 })
    }

    /// The id at table position `index`, or `None` when no table has that position (256
    /// and above).
    ///
    /// ```
    /// use rtseq::MonitorId;
    /// assert_eq!(MonitorId::try_from_index(255).map(MonitorId::index), Some(255));
    /// assert_eq!(MonitorId::try_from_index(256), None);
    /// ```
    pub const fn try_from_index(index: usize) -> Option<Self> {
        if index > 255 {
            None
        } else {
            Some(MonitorId(index as u8))
        }
    }
}

/// An optional sequence id: the id plus one, 0 = none, so that an empty sequencer is all
/// zeros (see `ControlBlock::UNREGISTERED`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct Link(u16);

impl Link {
    pub(crate) const NONE: Link = Link(0);

    pub(crate) const fn to(id: Option<SeqId>) -> Link {
        match id {
            Some(i) => Link(i.0 as u16 + 1),
            None => Link::NONE,
        }
    }

    pub(crate) const fn get(self) -> Option<SeqId> {
        // At most 256 - 1: fits a byte.
        match self.0.checked_sub(1) {
            Some(i) => Some(SeqId(i as u8)),
            None => None,
        }
    }
}

/// One run of a sequence: its id and its run count (`ControlBlock::runs`, counted when a
/// start commits). A sequence may be started again while the future that drove its last
/// run is still unwinding (a lane of higher priority restarts it after an abort): the
/// future names the run it drives, and the sequencer treats a run that is not the current
/// one as over (aborted), so it never acts for the new run.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct RunId {
    pub(crate) seq: SeqId,
    pub(crate) count: u16,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions 0 to 255 are ids, 256 and above none; `from_index` saturates there.
    #[test]
    fn ids_from_positions_stop_at_255() {
        for i in [0, 1, 254, 255] {
            assert_eq!(SeqId::try_from_index(i), Some(SeqId(i as u8)));
            assert_eq!(MonitorId::try_from_index(i), Some(MonitorId(i as u8)));
            assert_eq!(SeqId::from_index(i), SeqId(i as u8));
        }
        for i in [256, 257, usize::MAX] {
            assert_eq!(SeqId::try_from_index(i), None);
            assert_eq!(MonitorId::try_from_index(i), None);
            assert_eq!(SeqId::from_index(i), SeqId(255));
            assert_eq!(MonitorId::from_index(i), MonitorId(255));
        }
    }

    #[test]
    fn links_round_trip_and_none_is_zero() {
        assert_eq!(Link::NONE, Link(0));
        assert_eq!(Link::to(None), Link::NONE);
        assert_eq!(Link::NONE.get(), None);
        for id in [0u8, 1, 31, 254, 255] {
            assert_eq!(Link::to(Some(SeqId(id))).get(), Some(SeqId(id)));
        }
    }
}
