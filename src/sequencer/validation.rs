//! The check of a whole configuration before the first tick: every exception sequence (of a
//! monitor or of a timeout) exists, is not its owner, and has a lane to run in; every
//! monitor's owner is registered. What is not caught here would be found only when a
//! monitor fires — for a safe stop, too late.

use core::fmt;

use crate::lock::Lock;
use crate::model::table::CheckedConfig;
use crate::{ErrorMessage, MonitorId, Monitors, OwnedMonitor, SeqId, Sequencer, Table};

/// Who raises an exception: a monitor, or a sequence's timeout.
///
/// ```
/// use rtseq::{MonitorId, Raiser, SeqId};
/// let jam = Raiser::Monitor(MonitorId::from_index(0), "jam");
/// assert_eq!(jam.to_string(), "monitor `jam`");
/// let homing = Raiser::Timeout(SeqId::from_index(2), "homing");
/// assert_eq!(homing.to_string(), "the timeout of `homing`");
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Raiser {
    /// The monitor with this id and name.
    Monitor(MonitorId, &'static str),
    /// The timeout monitor of this sequence (and its name).
    Timeout(SeqId, &'static str),
}

/// A configuration that cannot work as declared ([`Sequencer::validate`]).
///
/// ```
/// use rtseq::{ConfigError, MonitorId, Raiser, SeqId};
/// let e = ConfigError::ExceptionIsOwner {
///     raiser: Raiser::Monitor(MonitorId::from_index(1), "following error"),
/// };
/// assert_eq!(
///     e.to_string(),
///     "monitor `following error` names its own owner as its exception sequence"
/// );
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ConfigError {
    /// A monitor's owner is not a registered sequence.
    UnknownOwner {
        /// The monitor's id and name.
        monitor: (MonitorId, &'static str),
        /// The owner it names.
        owner: SeqId,
    },
    /// An exception sequence is not registered.
    UnknownException {
        /// Whose exception sequence it is.
        raiser: Raiser,
        /// The id it names.
        exception: SeqId,
    },
    /// An exception sequence is its owner itself: it could never run while its owner is
    /// held.
    ExceptionIsOwner {
        /// Whose exception sequence it is.
        raiser: Raiser,
    },
    /// An exception sequence has no lane: it could not run when its monitor fires.
    ExceptionWithoutLane {
        /// Whose exception sequence it is.
        raiser: Raiser,
        /// The exception sequence and its name.
        exception: (SeqId, &'static str),
    },
}

impl ConfigError {
    /// A short description without the names.
    ///
    /// ```
    /// use rtseq::{ConfigError, MonitorId, Raiser};
    /// let e = ConfigError::ExceptionIsOwner { raiser: Raiser::Monitor(MonitorId::from_index(0), "jam") };
    /// assert_eq!(e.reason(), "an exception sequence is its own owner");
    /// ```
    pub const fn reason(&self) -> &'static str {
        match self {
            ConfigError::UnknownOwner { .. } => "a monitor's owner is not registered",
            ConfigError::UnknownException { .. } => "an exception sequence is not registered",
            ConfigError::ExceptionIsOwner { .. } => "an exception sequence is its own owner",
            ConfigError::ExceptionWithoutLane { .. } => "an exception sequence has no lane",
        }
    }

    /// What is wrong, naming the monitor and the sequences: the `Display` form, made by a
    /// `const fn`, so that a configuration checked in a `const` item fails to compile
    /// with it (`Err(e) => panic!("{}", e.message().as_str())`).
    ///
    /// ```
    /// use rtseq::{ConfigError, MonitorId, Raiser, SeqId};
    /// let e = ConfigError::UnknownException {
    ///     raiser: Raiser::Timeout(SeqId::from_index(1), "homing"),
    ///     exception: SeqId::from_index(7),
    /// };
    /// assert_eq!(
    ///     e.message().as_str(),
    ///     "the exception sequence 7 of the timeout of `homing` is not registered"
    /// );
    /// assert_eq!(e.to_string(), e.message().as_str());
    /// ```
    pub const fn message(&self) -> ErrorMessage {
        let m = ErrorMessage::new();
        match *self {
            ConfigError::UnknownOwner { monitor, owner } => m
                .with("monitor `")
                .with(monitor.1)
                .with("` is owned by sequence ")
                .with_number(owner.index())
                .with(", which is not registered"),
            ConfigError::UnknownException { raiser, exception } => raiser
                .named_in(
                    m.with("the exception sequence ")
                        .with_number(exception.index())
                        .with(" of "),
                )
                .with(" is not registered"),
            ConfigError::ExceptionIsOwner { raiser } => raiser
                .named_in(m)
                .with(" names its own owner as its exception sequence"),
            ConfigError::ExceptionWithoutLane { raiser, exception } => raiser
                .named_in(
                    m.with("the exception sequence `")
                        .with(exception.1)
                        .with("` of "),
                )
                .with(" has no lane (declare one before the first tick)"),
        }
    }
}

impl Raiser {
    /// `m` with this raiser's `Display` form added.
    const fn named_in(self, m: ErrorMessage) -> ErrorMessage {
        match self {
            Raiser::Monitor(_, name) => m.with("monitor `").with(name).with("`"),
            Raiser::Timeout(_, name) => m.with("the timeout of `").with(name).with("`"),
        }
    }
}

impl fmt::Display for Raiser {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.named_in(ErrorMessage::new()).as_str())
    }
}

impl core::error::Error for ConfigError {}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message().as_str())
    }
}

// The defmt forms read as the `Display` forms: a firmware's log says what is wrong in the
// same words as a host test.
#[cfg(feature = "defmt")]
impl defmt::Format for Raiser {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Raiser::Monitor(_, name) => defmt::write!(f, "monitor `{=str}`", name),
            Raiser::Timeout(_, name) => defmt::write!(f, "the timeout of `{=str}`", name),
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ConfigError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            ConfigError::UnknownOwner { monitor, owner } => defmt::write!(
                f,
                "monitor `{=str}` is owned by sequence {=usize}, which is not registered",
                monitor.1,
                owner.index()
            ),
            ConfigError::UnknownException { raiser, exception } => defmt::write!(
                f,
                "the exception sequence {=usize} of {} is not registered",
                exception.index(),
                raiser
            ),
            ConfigError::ExceptionIsOwner { raiser } => {
                defmt::write!(f, "{} names its own owner as its exception sequence", raiser)
            }
            ConfigError::ExceptionWithoutLane { raiser, exception } => defmt::write!(
                f,
                "the exception sequence `{=str}` of {} has no lane (declare one before the first tick)",
                exception.1,
                raiser
            ),
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Checks the whole configuration before the first tick: every monitor's owner is
    /// registered; every exception sequence of a monitor or of a timeout is registered, is
    /// not its owner and has a lane (declared by [`lane`](fn@crate::lane) or
    /// [`Handle::declare_lane`](crate::Handle::declare_lane)). Returns the first problem,
    /// naming the monitor or sequence.
    ///
    /// Call it once at start-up, after the lanes are declared (in RTIC: in `init`); the
    /// host simulator calls it before its first start (and again after sequences or lanes
    /// were added). Once the lane tasks have run,
    /// [`check_lanes`](Self::check_lanes) checks that a task polls each declared lane.
    ///
    /// ```
    /// use rtseq::{Behaviour, ConfigError, Instant, Monitor, Monitors, Raiser, SeqConfig,
    ///             Sequencer};
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let moves = seq.register(SeqConfig::new("moves")).unwrap();
    /// let safe_stop = seq.register(SeqConfig::new("safe stop")).unwrap();
    /// let mut jammed = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 1> = Monitors::new();
    /// let m = monitors
    ///     .add(moves, Monitor::new("jammed", &mut jammed, Behaviour::AbortOwner).exception(safe_stop))
    ///     .unwrap();
    /// // The safe stop has no lane yet: it could not run when `jammed` fires.
    /// assert_eq!(
    ///     seq.validate(&monitors),
    ///     Err(ConfigError::ExceptionWithoutLane {
    ///         raiser: Raiser::Monitor(m, "jammed"),
    ///         exception: (safe_stop, "safe stop"),
    ///     })
    /// );
    /// seq.sequence_by_id(safe_stop).unwrap().declare_lane().unwrap();
    /// assert_eq!(seq.validate(&monitors), Ok(()));
    /// ```
    pub fn validate<const M: usize, K>(
        &self,
        monitors: &Monitors<'_, C, M, K>,
    ) -> Result<(), ConfigError> {
        for (i, m) in monitors.entries.iter().enumerate() {
            let id = MonitorId::from_index(i);
            let name = m.def.name;
            if self.name_of(m.owner).is_none() {
                return Err(ConfigError::UnknownOwner {
                    monitor: (id, name),
                    owner: m.owner,
                });
            }
            if let Some(e) = m.def.exception {
                self.check_exception(Raiser::Monitor(id, name), m.owner, e)?;
            }
        }
        let count = self.len();
        for owner in (0..count).map(SeqId::from_index) {
            let (name, exception) = self.with(|s| {
                s.block(owner)
                    .map(|b| (b.name(), b.timeout_exception.get()))
                    .unwrap_or(("", None))
            });
            if let Some(e) = exception {
                self.check_exception(Raiser::Timeout(owner, name), owner, e)?;
            }
        }
        Ok(())
    }

    /// The name of registered sequence `id`.
    fn name_of(&self, id: SeqId) -> Option<&'static str> {
        self.with(|s| s.block(id).map(|b| b.name()))
    }

    /// `exception`, raised by `raiser` for `owner`, exists, is not the owner, and has a
    /// lane.
    fn check_exception(
        &self,
        raiser: Raiser,
        owner: SeqId,
        exception: SeqId,
    ) -> Result<(), ConfigError> {
        let found = self.name_of(exception).map(|name| Found {
            name,
            in_lane: self.has_lane(exception),
        });
        judge_exception(raiser, owner, exception, found)
    }
}

/// What a check found of a registered exception sequence.
#[derive(Clone, Copy)]
struct Found {
    name: &'static str,
    in_lane: bool,
}

/// The verdict on `exception`, raised by `raiser` for `owner`, from what the check found of
/// it (`None`: it is not registered). Shared by the run-time and the compile-time check.
const fn judge_exception(
    raiser: Raiser,
    owner: SeqId,
    exception: SeqId,
    found: Option<Found>,
) -> Result<(), ConfigError> {
    let Some(found) = found else {
        return Err(ConfigError::UnknownException { raiser, exception });
    };
    if exception.index() == owner.index() {
        return Err(ConfigError::ExceptionIsOwner { raiser });
    }
    if !found.in_lane {
        return Err(ConfigError::ExceptionWithoutLane {
            raiser,
            exception: (exception, found.name),
        });
    }
    Ok(())
}

impl<C, const N: usize> Table<C, N> {
    /// The check of [`Sequencer::validate`], made by the compiler: `monitors` (the list of a
    /// monitor table, in table order) and this table's timeouts, with the lanes this table
    /// declares ([`SeqConfig::in_lane`](crate::SeqConfig::in_lane)). In a `const` item a
    /// configuration that cannot work is a compile error, and the firmware holds no
    /// validation code. A lane declared only at run time is not seen here: then use
    /// [`Sequencer::validate`]. A [`monitors!`](crate::monitors) module's `validate` calls
    /// this with its list.
    ///
    /// ```
    /// use rtseq::{Behaviour, ConfigError, Instant, Monitor, MonitorId, Raiser, SeqConfig, SeqId,
    ///             Table};
    /// type Cond = fn(&(), Instant) -> bool;
    /// fn jammed(_: &(), _: Instant) -> bool { false }
    /// const MOVES: SeqId = SeqId::from_index(0);
    /// const SAFE_STOP: SeqId = SeqId::from_index(1);
    /// const fn table(safe_stop: SeqConfig<()>) -> Table<(), 2> {
    ///     match Table::new([SeqConfig::new("moves").in_lane(), safe_stop]) {
    ///         Ok(t) => t,
    ///         Err(e) => panic!("{}", e.message().as_str()),
    ///     }
    /// }
    /// const JAM: [rtseq::OwnedMonitor<'static, (), Cond>; 1] = [
    ///     Monitor::with_condition("jam", jammed as Cond, Behaviour::AbortOwner)
    ///         .exception(SAFE_STOP)
    ///         .owned_by(MOVES),
    /// ];
    /// // Checked by the compiler: a bad configuration would not build.
    /// const CHECKED: () = match table(SeqConfig::new("safe stop").in_lane()).validate(&JAM) {
    ///     Ok(()) => (),
    ///     Err(e) => panic!("{}", e.message().as_str()),
    /// };
    /// // The safe stop without a lane could not run when the jam monitor fires.
    /// assert_eq!(
    ///     table(SeqConfig::new("safe stop")).validate(&JAM),
    ///     Err(ConfigError::ExceptionWithoutLane {
    ///         raiser: Raiser::Monitor(MonitorId::from_index(0), "jam"),
    ///         exception: (SAFE_STOP, "safe stop"),
    ///     })
    /// );
    /// ```
    ///
    /// In a `const` item, a configuration that cannot work does not compile:
    ///
    /// ```compile_fail,E0080
    /// use rtseq::{Behaviour, Instant, Monitor, SeqConfig, SeqId, Table};
    /// type Cond = fn(&(), Instant) -> bool;
    /// fn jammed(_: &(), _: Instant) -> bool { false }
    /// const TABLE: Table<(), 2> = match Table::new([
    ///     SeqConfig::new("moves"),
    ///     SeqConfig::new("safe stop"), // no lane
    /// ]) {
    ///     Ok(t) => t,
    ///     Err(e) => panic!("{}", e.message().as_str()),
    /// };
    /// const CHECKED: () = match TABLE.validate(&[
    ///     Monitor::with_condition("jam", jammed as Cond, Behaviour::AbortOwner)
    ///         .exception(SeqId::from_index(1))
    ///         .owned_by(SeqId::from_index(0)),
    /// ]) {
    ///     Ok(()) => (),
    ///     Err(e) => panic!("{}", e.message().as_str()), // error: an exception sequence has no lane
    /// };
    /// ```
    pub const fn validate<K>(
        &self,
        monitors: &[OwnedMonitor<'_, C, K>],
    ) -> Result<(), ConfigError> {
        let mut rest = monitors;
        let mut index = 0;
        while let Some((m, more)) = rest.split_first() {
            let id = MonitorId::from_index(index);
            let name = m.def.name;
            if self.config(m.owner).is_none() {
                return Err(ConfigError::UnknownOwner {
                    monitor: (id, name),
                    owner: m.owner,
                });
            }
            if let Some(e) = m.def.exception {
                if let Err(e) = self.check_exception(Raiser::Monitor(id, name), m.owner, e) {
                    return Err(e);
                }
            }
            rest = more;
            index += 1;
        }
        let mut rest: &[CheckedConfig<C>] = &self.configs;
        let mut index = 0;
        while let Some((config, more)) = rest.split_first() {
            let owner = SeqId::from_index(index);
            if let Some(e) = config.timeout_exception.get() {
                if let Err(e) = self.check_exception(Raiser::Timeout(owner, config.name), owner, e)
                {
                    return Err(e);
                }
            }
            rest = more;
            index += 1;
        }
        Ok(())
    }

    /// The entry of `id`, when the table has one.
    const fn config(&self, id: SeqId) -> Option<&CheckedConfig<C>> {
        match self.configs.split_at_checked(id.index()) {
            Some((_, from_id)) => from_id.first(),
            None => None,
        }
    }

    /// As [`Sequencer::check_exception`], with the table's lanes.
    const fn check_exception(
        &self,
        raiser: Raiser,
        owner: SeqId,
        exception: SeqId,
    ) -> Result<(), ConfigError> {
        let found = match self.config(exception) {
            Some(config) => Some(Found {
                name: config.name,
                in_lane: config.in_lane,
            }),
            None => None,
        };
        judge_exception(raiser, owner, exception, found)
    }
}
