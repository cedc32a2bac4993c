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
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The id at registry position `index` (ids are handed out in registration order).
    /// Saturates at 255, which is never a valid id of a smaller sequencer.
    pub const fn from_index(index: usize) -> Self {
        SeqId(if index > 255 { 255 } else { index as u8 })
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
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The id at table position `index` (ids are handed out in order). Saturates at 255.
    pub const fn from_index(index: usize) -> Self {
        MonitorId(if index > 255 { 255 } else { index as u8 })
    }
}
