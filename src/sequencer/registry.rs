//! Registration (one sequence at a time, or a whole [`Table`]), binding sequence objects to
//! their ids, and the seed's look-ups by id and by name.

use core::cell::Cell;

use crate::lock::Lock;
use crate::model::table::CheckedConfig;
use crate::sequence::SeqHead;
use crate::sequencer::control_block::NO_LANE;
use crate::sequencer::port::Port;
use crate::sequencer::sets::Set;
use crate::tick::schedule::Classes;
use crate::{Error, Handle, Seq, SeqConfig, SeqId, Sequencer, Table};

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Registers a sequence or step. Errors on an empty or duplicate name, an out-of-range
    /// duration, when all `N` slots are taken, when a sequence in a lane of its own finds
    /// all `W` lane slots taken (`LaneCapacityExceeded`), or when its polling period would
    /// be a ninth distinct one (`PollingClassesExceeded`).
    ///
    /// ```
    /// use rtseq::{Duration, Error, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let homing = seq.register(SeqConfig::new("homing").polling(Duration::from_millis(2)));
    /// assert_eq!(homing.map(|id| id.index()), Ok(0));
    /// assert_eq!(seq.register(SeqConfig::new("")), Err(Error::EmptyName));
    /// ```
    pub fn register(&self, config: SeqConfig<C>) -> Result<SeqId, Error> {
        let mut checked = CheckedConfig::checked(&config)?;
        self.take_tag();
        self.with(|s| {
            if let Some(first) = s.registered().position(|b| b.name == Some(config.name)) {
                return Err(Error::DuplicateName(SeqId::from_index(first)));
            }
            let id = SeqId::from_index(s.count());
            if s.count() >= N {
                return Err(Error::SequenceCapacityExceeded);
            }
            let own_lane = if checked.in_lane {
                let next = s.lanes_declared;
                if usize::from(next) >= W {
                    return Err(Error::LaneCapacityExceeded(id));
                }
                next
            } else {
                NO_LANE
            };
            checked.class = s.polling.classes.join(id, checked.polling)?;
            let id = s.push_block(checked.to_control_block(own_lane), checked.on_abort())?;
            if own_lane != NO_LANE {
                s.lanes_declared = own_lane.saturating_add(1);
            }
            Ok(id)
        })
    }

    /// Installs a [`Table`] checked at compile time into this empty sequencer: sequence
    /// `i` of the table gets the id `SeqId::from_index(i)`. Bind the sequence objects with
    /// [`bind`](Self::bind) afterwards. A table larger than `N` does not compile.
    ///
    /// One short section per entry, and one that copies the polling classes and makes
    /// everything visible at once (its length grows with the number of classes); errors
    /// (without a visible change) when anything is registered already.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer, Table};
    /// static TABLE: Table<(), 2> = match Table::new([SeqConfig::new("a"), SeqConfig::new("b")]) {
    ///     Ok(t) => t,
    ///     Err(e) => panic!("{}", e.message().as_str()),
    /// };
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// seq.install(&TABLE).unwrap();
    /// assert_eq!(seq.len(), 2);
    /// ```
    pub fn install<const K: usize>(&self, table: &Table<C, K>) -> Result<(), Error> {
        const {
            assert!(
                K <= N,
                "the table holds more sequences than the sequencer's N"
            )
        };
        self.install_configs(&table.configs, &table.classes.resized())
    }

    /// The part of [`install`](Self::install) that does not depend on the table's size.
    fn install_configs(
        &self,
        configs: &[CheckedConfig<C>],
        classes: &Classes<B>,
    ) -> Result<(), Error> {
        self.take_tag();
        // The lanes of the table take the first slots, in table order.
        let mut lanes: u8 = 0;
        for (i, config) in configs.iter().enumerate() {
            let id = SeqId::from_index(i);
            let own_lane = if config.in_lane {
                let slot = lanes;
                if usize::from(slot) >= W {
                    return Err(Error::LaneCapacityExceeded(id));
                }
                lanes = slot + 1;
                slot
            } else {
                NO_LANE
            };
            self.with(|s| {
                if s.count() != 0 {
                    return Err(Error::NotEmpty);
                }
                s.prepare_block(id, config.to_control_block(own_lane), config.on_abort());
                Ok(())
            })?;
        }
        self.with(|s| {
            if s.count() != 0 {
                return Err(Error::NotEmpty);
            }
            s.polling.classes.copy_used(classes);
            s.lanes_declared = lanes;
            s.commit_count(configs.len());
            Ok(())
        })
    }

    /// Binds the sequence or step object `body` to a registered id; each id binds once.
    ///
    /// ```
    /// use rtseq::{Error, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("a")).unwrap();
    /// let a = seq.bind(id, ()).unwrap();
    /// assert_eq!(a.id(), id);
    /// assert_eq!(seq.bind(id, ()).err(), Some(Error::AlreadyBound(id)));
    /// ```
    #[inline]
    pub fn bind<S>(&self, id: SeqId, body: S) -> Result<Seq<S>, Error> {
        let head = self.claim(id)?;
        Ok(Seq { body, head })
    }

    /// [`register`](Self::register) and [`bind`](Self::bind) in one.
    ///
    /// ```
    /// use rtseq::{Cx, Failure, SeqConfig, Sequencer, Step};
    /// struct Enable;
    /// impl Step<()> for Enable {
    ///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let enable = seq.add(SeqConfig::new("enable"), Enable).unwrap();
    /// assert_eq!(seq.sequence_by_id(enable.id()).unwrap().name(), "enable");
    /// ```
    #[inline]
    pub fn add<S>(&self, config: SeqConfig<C>, body: S) -> Result<Seq<S>, Error> {
        let head = self.register_bound(config)?;
        Ok(Seq { body, head })
    }

    /// The part of [`add`](Self::add) that does not depend on the body type.
    #[inline(never)]
    fn register_bound(&self, config: SeqConfig<C>) -> Result<SeqHead, Error> {
        let id = self.register(config)?;
        self.claim(id)
    }

    /// The part of [`bind`](Self::bind) that does not depend on the body type: marks `id`
    /// bound and makes its object's head, which carries this sequencer's tag.
    #[inline(never)]
    fn claim(&self, id: SeqId) -> Result<SeqHead, Error> {
        // A registered id: the sequencer has its tag.
        let maker = self.with(|s| {
            s.block(id).ok_or(Error::UnknownSequence(id))?;
            if s.sets.has(Set::Bound, id) {
                return Err(Error::AlreadyBound(id));
            }
            s.sets.insert(Set::Bound, id);
            Ok(s.tag)
        })?;
        Ok(SeqHead { id, maker })
    }

    /// Gives this sequencer its tag, if it has none yet (at its first registration): the
    /// identity its sequence objects and its monitor table know it by, which moves with
    /// it. Taken outside the section: the tag counter's critical section is the platform's
    /// code.
    pub(crate) fn take_tag(&self) {
        if self.with(|s| s.tag) != 0 {
            return;
        }
        let tag = next_tag();
        self.with(|s| {
            if s.tag == 0 {
                s.tag = tag;
            }
        });
    }

    /// The seed's `getSequenceByID`.
    ///
    /// ```
    /// use rtseq::{SeqConfig, SeqId, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("homing")).unwrap();
    /// assert_eq!(seq.sequence_by_id(id).map(|h| h.name()), Some("homing"));
    /// assert!(seq.sequence_by_id(SeqId::from_index(1)).is_none());
    /// ```
    pub fn sequence_by_id(&self, id: SeqId) -> Option<Handle<'_, C>> {
        let known = self.with(|s| s.block(id).is_some());
        known.then(|| Handle::new(self, id))
    }

    /// The seed's `getSequenceByName`.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("homing")).unwrap();
    /// assert_eq!(seq.sequence_by_name("homing").map(|h| h.id()), Some(id));
    /// assert!(seq.sequence_by_name("moves").is_none());
    /// ```
    pub fn sequence_by_name(&self, name: &str) -> Option<Handle<'_, C>> {
        let port: &dyn Port<C> = self;
        port.find(name).map(|id| Handle::new(self, id))
    }

    /// Number of registered sequences and steps.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.register(SeqConfig::new("a")).unwrap();
    /// assert_eq!(seq.len(), 1);
    /// ```
    pub fn len(&self) -> usize {
        self.with(|s| s.count())
    }

    /// True when nothing is registered.
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// assert!(Sequencer::<(), 2>::new().is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The last tag handed to a sequencer (see [`State::tag`](crate::sequencer::state::State)).
static LAST_TAG: critical_section::Mutex<Cell<u16>> = critical_section::Mutex::new(Cell::new(0));

/// The next sequencer's tag (never 0, which means "none yet"; repeats after 65 535).
fn next_tag() -> u16 {
    critical_section::with(|cs| {
        let last = LAST_TAG.borrow(cs);
        let tag = last.get().wrapping_add(1).max(1);
        last.set(tag);
        tag
    })
}
