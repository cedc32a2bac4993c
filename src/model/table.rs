//! A sequence tree's configuration, checked and laid out at compile time.
//!
//! [`Sequencer::register`](crate::Sequencer::register) checks each configuration when the
//! firmware runs, so its checks are code in flash. A [`Table`] is built by a `const fn`:
//! in a `static` or `const` item the same checks run in the compiler (a bad table is a
//! compile error) and the firmware only copies the result in
//! ([`Sequencer::install`](crate::Sequencer::install)). Like a PLC's configuration, the
//! tree is fixed before the program runs.

use crate::model::id::Link;
use crate::model::set::WORDS_MAX;
use crate::sequencer::control_block::ControlBlock;
use crate::tick::schedule::Classes;
use crate::{Behaviour, Error, SeqConfig, SeqId, TableError};

/// One checked configuration: what a control block takes from it.
pub(crate) struct CheckedConfig<C> {
    pub(crate) name: &'static str,
    /// Polling period (µs, non-zero, below 2^31).
    pub(crate) polling: u32,
    /// Timeout (µs; 0 = off).
    timeout: u32,
    on_abort: Option<fn(&C)>,
    pub(crate) timeout_exception: Link,
    timeout_behaviour: Behaviour,
    timeout_restart_limit: u8,
    /// The polling class (set when the entry joins one).
    pub(crate) class: u8,
    /// Runs in a lane of its own ([`SeqConfig::in_lane`]).
    pub(crate) in_lane: bool,
}

// Not derived: a derive would require `C: Copy`.
impl<C> Clone for CheckedConfig<C> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<C> Copy for CheckedConfig<C> {}

impl<C> CheckedConfig<C> {
    /// Checks `config` on its own (name, durations); the polling class is joined later.
    pub(crate) const fn checked(config: &SeqConfig<C>) -> Result<Self, Error> {
        if config.name.is_empty() {
            return Err(Error::EmptyName);
        }
        let Some(polling) = crate::model::time::to_interval(config.polling) else {
            return Err(Error::DurationOutOfRange);
        };
        if matches!(config.timeout_behaviour, Behaviour::PauseOwner) {
            return Err(Error::PauseOnTimeout);
        }
        let timeout = match config.timeout {
            Some(t) => match crate::model::time::to_interval(t) {
                Some(us) => us,
                None => return Err(Error::DurationOutOfRange),
            },
            None => 0,
        };
        Ok(CheckedConfig {
            name: config.name,
            polling,
            timeout,
            on_abort: config.on_abort,
            timeout_exception: Link::to(config.timeout_exception),
            timeout_behaviour: config.timeout_behaviour,
            timeout_restart_limit: config.timeout_restart_limit,
            class: 0,
            in_lane: config.in_lane,
        })
    }

    /// The control block of a registered sequence that never ran.
    pub(crate) const fn to_control_block(self, own_lane: u8) -> ControlBlock {
        ControlBlock {
            own_lane,
            name: Some(self.name),
            timeout: self.timeout,
            timeout_behaviour: self.timeout_behaviour,
            timeout_exception: self.timeout_exception,
            timeout_restart_limit: self.timeout_restart_limit,
            class: self.class,
            ..ControlBlock::IDLE
        }
    }

    /// The cleanup hook.
    pub(crate) const fn on_abort(&self) -> Option<fn(&C)> {
        self.on_abort
    }
}

/// The configurations of a whole sequence tree, checked and laid out by a `const fn`.
///
/// Sequence `i` of the table gets the id `SeqId::from_index(i)`, so references between
/// entries (a timeout exception) are positions; [`id`](Table::id) finds a position by
/// name. Build the table in a `static` or `const` item: then the checks run in the
/// compiler, an invalid table is a compile error, and none of the checking code is in the
/// firmware. [`Sequencer::install`](crate::Sequencer::install) copies it in; each sequence
/// object is then bound to its id with [`Sequencer::bind`](crate::Sequencer::bind).
///
/// ```
/// use rtseq::{Behaviour, Cx, Duration, Failure, SeqConfig, SeqId, Sequencer, Step, Table};
/// const SAFE_STOP: SeqId = SeqId::from_index(0);
/// const HOMING: SeqId = SeqId::from_index(1);
/// static TABLE: Table<(), 2> = match Table::new([
///     SeqConfig::new("safe stop"),
///     SeqConfig::new("homing")
///         .timeout(Duration::from_secs(5))
///         .timeout_exception(SAFE_STOP)
///         .timeout_behaviour(Behaviour::AbortOwner),
/// ]) {
///     Ok(table) => table,
///     Err(e) => panic!("{}", e.message().as_str()), // a compile error, never a run-time panic
/// };
/// // The ids the code uses are the ones the names say.
/// const _: () = assert!(matches!(TABLE.id("homing"), Some(id) if id.index() == HOMING.index()));
///
/// struct Stop;
/// impl Step<()> for Stop {
///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// seq.install(&TABLE).unwrap();
/// let stop = seq.bind(SAFE_STOP, Stop).unwrap();
/// assert_eq!(seq.sequence_by_name("homing").unwrap().id(), HOMING);
/// assert_eq!(seq.sequence_by_id(stop.id()).unwrap().name(), "safe stop");
/// ```
///
/// A duplicate name does not compile:
///
/// ```compile_fail,E0080
/// use rtseq::{SeqConfig, Table};
/// static TABLE: Table<(), 2> =
///     match Table::new([SeqConfig::new("move"), SeqConfig::new("move")]) {
///         Ok(table) => table,
///         Err(e) => panic!("{}", e.message().as_str()),
///     };
/// ```
pub struct Table<C, const N: usize> {
    pub(crate) configs: [CheckedConfig<C>; N],
    pub(crate) classes: Classes<WORDS_MAX>,
}

impl<C, const N: usize> Table<C, N> {
    /// Checks `configs` as [`register`](crate::Sequencer::register) would one after the
    /// other (empty or duplicate names, durations, distinct polling periods), plus what
    /// only a whole table can show: the table fits a sequencer (at most
    /// [`MAX_SEQUENCES`](crate::MAX_SEQUENCES)) and every timeout exception is one of its
    /// entries. An error is a [`TableError`]: the entry refused, by position and name, and
    /// the [`Error`] `register` would give. How the entries relate (a timeout exception that is its own entry or has no
    /// lane) is [`validate`](Self::validate)'s to check, with the monitors: call it in a
    /// `const` too, with `&[]` when there are none.
    ///
    /// Every timeout exception must be an entry of the table:
    ///
    /// ```
    /// use rtseq::{Error, SeqConfig, SeqId, Table, TableError};
    /// let outside = SeqId::from_index(5);
    /// let table = Table::<(), 1>::new([SeqConfig::new("main").timeout_exception(outside)]);
    /// assert!(matches!(
    ///     table,
    ///     Err(TableError { entry: 0, name: "main", error: Error::UnknownSequence(id) }) if id == outside
    /// ));
    /// ```
    pub const fn new(configs: [SeqConfig<C>; N]) -> Result<Self, TableError> {
        // The first entry beyond the capacity is the one refused.
        if let Some((_, beyond)) = configs.split_at_checked(crate::MAX_SEQUENCES) {
            if let Some(first) = beyond.first() {
                return Err(TableError {
                    entry: crate::MAX_SEQUENCES,
                    name: first.name,
                    error: Error::SequenceCapacityExceeded,
                });
            }
        }
        let mut table = Table {
            configs: [const { CheckedConfig::UNUSED }; N],
            classes: Classes::new(),
        };
        let mut entries: &mut [CheckedConfig<C>] = &mut table.configs;
        let mut rest: &[SeqConfig<C>] = &configs;
        let mut id: u8 = 0;
        while let (Some((slot, more_slots)), Some((config, more))) =
            (entries.split_first_mut(), rest.split_first())
        {
            *slot = match entry_of(&configs, config, SeqId(id), &mut table.classes) {
                Ok(entry) => entry,
                Err(error) => {
                    return Err(TableError {
                        entry: id as usize,
                        name: config.name,
                        error,
                    })
                }
            };
            entries = more_slots;
            rest = more;
            id = id.saturating_add(1);
        }
        Ok(table)
    }

    /// The id of the entry named `name`.
    ///
    /// ```
    /// use rtseq::{SeqConfig, SeqId, Table};
    /// const TABLE: Table<(), 2> = match Table::new([SeqConfig::new("a"), SeqConfig::new("go")]) {
    ///     Ok(table) => table,
    ///     Err(e) => panic!("{}", e.message().as_str()),
    /// };
    /// const GO: SeqId = match TABLE.id("go") { Some(id) => id, None => panic!("no such entry") };
    /// assert_eq!(GO.index(), 1);
    /// assert_eq!(TABLE.id("missing"), None);
    /// ```
    pub const fn id(&self, name: &str) -> Option<SeqId> {
        let mut rest: &[CheckedConfig<C>] = &self.configs;
        let mut id: u8 = 0;
        while let Some((entry, more)) = rest.split_first() {
            if str_eq(entry.name, name) {
                return Some(SeqId(id));
            }
            rest = more;
            id = id.saturating_add(1);
        }
        None
    }

    /// The number of sequences and steps in the table (`N`).
    ///
    /// ```
    /// use rtseq::{SeqConfig, Table};
    /// let table = Table::<(), 2>::new([SeqConfig::new("a"), SeqConfig::new("b")]).unwrap();
    /// assert_eq!(table.len(), 2);
    /// ```
    pub const fn len(&self) -> usize {
        N
    }

    /// True for a table of no sequences.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Table};
    /// assert!(Table::<(), 0>::new([]).unwrap().is_empty());
    /// assert!(!Table::<(), 1>::new([SeqConfig::new("a")]).unwrap().is_empty());
    /// ```
    pub const fn is_empty(&self) -> bool {
        N == 0
    }
}

impl<C, const N: usize> core::fmt::Debug for Table<C, N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut names = f.debug_list();
        for e in &self.configs {
            names.entry(&e.name);
        }
        names.finish()
    }
}

impl<C> CheckedConfig<C> {
    /// An unwritten entry (`Table::new` overwrites all of them).
    const UNUSED: CheckedConfig<C> = CheckedConfig {
        name: "",
        polling: 0,
        timeout: 0,
        on_abort: None,
        timeout_exception: Link::NONE,
        timeout_behaviour: Behaviour::AbortOwner,
        timeout_restart_limit: 0,
        class: 0,
        in_lane: false,
    };
}

/// The first position of `name` in `configs` (`SeqId(u8::MAX)` when absent).
const fn position<C>(configs: &[SeqConfig<C>], name: &str) -> SeqId {
    let mut rest = configs;
    let mut id: u8 = 0;
    while let Some((config, more)) = rest.split_first() {
        if str_eq(config.name, name) {
            return SeqId(id);
        }
        rest = more;
        id = id.saturating_add(1);
    }
    SeqId(u8::MAX)
}

/// `a == b` for a `const fn`.
const fn str_eq(a: &str, b: &str) -> bool {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    while let (Some((x, more_a)), Some((y, more_b))) = (a.split_first(), b.split_first()) {
        if *x != *y {
            return false;
        }
        a = more_a;
        b = more_b;
    }
    true
}

/// `config`, entry `id` of `configs`, checked (as `register` checks a configuration, its
/// timeout exception one of the entries, its name the first of its kind), with its polling
/// class joined in `classes`.
const fn entry_of<C>(
    configs: &[SeqConfig<C>],
    config: &SeqConfig<C>,
    id: SeqId,
    classes: &mut Classes<WORDS_MAX>,
) -> Result<CheckedConfig<C>, Error> {
    let mut entry = match CheckedConfig::checked(config) {
        Ok(entry) => entry,
        Err(e) => return Err(e),
    };
    if let Some(exception) = config.timeout_exception {
        if exception.index() >= configs.len() {
            return Err(Error::UnknownSequence(exception));
        }
    }
    let first = position(configs, config.name);
    if first.0 != id.0 {
        return Err(Error::DuplicateName(first));
    }
    entry.class = match classes.join(id, entry.polling) {
        Ok(class) => class,
        Err(e) => return Err(e),
    };
    Ok(entry)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Duration;

    fn cfg(name: &'static str) -> SeqConfig<()> {
        SeqConfig::new(name)
    }

    #[test]
    fn entries_get_their_positions_and_classes() {
        let table = Table::new([
            cfg("a"),
            cfg("b").polling(Duration::from_millis(5)),
            cfg("c"),
        ]);
        let ids = table.as_ref().map(|t| (t.id("c"), t.id("d")));
        assert_eq!(ids, Ok((Some(SeqId(2)), None)));
        let classes = table.map(|t| (t.configs.map(|e| e.class), t.classes.len()));
        assert_eq!(classes, Ok(([0, 1, 0], 2)));
    }

    #[test]
    fn a_table_shows_its_names() {
        use core::fmt::Write;
        let mut shown: heapless::String<16> = heapless::String::new();
        let table = Table::new([cfg("a"), cfg("b")]);
        assert_eq!(table.map(|t| write!(shown, "{t:?}")), Ok(Ok(())));
        assert_eq!(shown.as_str(), r#"["a", "b"]"#);
    }

    #[test]
    fn a_bad_table_is_the_error_register_would_give_naming_the_entry() {
        let refused = |entry, name, error| Some(TableError { entry, name, error });
        assert_eq!(
            Table::new([cfg("a"), cfg("b"), cfg("a")]).err(),
            refused(2, "a", Error::DuplicateName(SeqId(0)))
        );
        assert_eq!(
            Table::new([cfg("")]).err(),
            refused(0, "", Error::EmptyName)
        );
        assert_eq!(
            Table::new([cfg("a").polling(Duration::from_ticks(0))]).err(),
            refused(0, "a", Error::DurationOutOfRange)
        );
        assert_eq!(
            Table::new([cfg("z"), cfg("a").timeout(Duration::from_secs(3_000))]).err(),
            refused(1, "a", Error::DurationOutOfRange)
        );
        assert_eq!(
            Table::new([cfg("a").timeout_exception(SeqId(1))]).err(),
            refused(0, "a", Error::UnknownSequence(SeqId(1)))
        );
        let names = ["0", "1", "2", "3", "4", "5", "6", "7", "8"];
        let mut period = 0;
        let periods = names.map(|n| {
            period += 1;
            cfg(n).polling(Duration::from_ticks(period))
        });
        assert_eq!(
            Table::new(periods).err(),
            refused(8, "8", Error::PollingClassesExceeded)
        );
        let too_many: Result<Table<(), 257>, _> = Table::new([const { SeqConfig::new("x") }; 257]);
        assert_eq!(
            too_many.err(),
            refused(256, "x", Error::SequenceCapacityExceeded)
        );
    }
}
