//! The check of a whole configuration before the first tick: every exception sequence (of a
//! monitor or of a timeout) exists, is not its owner, and has a lane to run in; every
//! monitor's owner is registered. What is not caught here would be found only when a
//! monitor fires — for a safe stop, too late.

use core::fmt;

use crate::lock::Lock;
use crate::{MonitorId, Monitors, SeqId, Sequencer};

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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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

impl fmt::Display for Raiser {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Raiser::Monitor(_, name) => write!(f, "monitor `{name}`"),
            Raiser::Timeout(_, name) => write!(f, "the timeout of `{name}`"),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::UnknownOwner { monitor, owner } => write!(
                f,
                "monitor `{}` is owned by sequence {}, which is not registered",
                monitor.1,
                owner.index()
            ),
            ConfigError::UnknownException { raiser, exception } => write!(
                f,
                "the exception sequence {} of {raiser} is not registered",
                exception.index()
            ),
            ConfigError::ExceptionIsOwner { raiser } => {
                write!(f, "{raiser} names its own owner as its exception sequence")
            }
            ConfigError::ExceptionWithoutLane { raiser, exception } => write!(
                f,
                "the exception sequence `{}` of {raiser} has no lane (declare one before the first tick)",
                exception.1
            ),
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Checks the whole configuration before the first tick: every monitor's owner is
    /// registered; every exception sequence of a monitor or of a timeout is registered, is
    /// not its owner and has a lane (declared by [`lane`](crate::lane) or
    /// [`Handle::declare_lane`](crate::Handle::declare_lane)). Returns the first problem,
    /// naming the monitor or sequence.
    ///
    /// Call it once at start-up, after the lanes are declared (in RTIC: in `init`); the
    /// host simulator calls it before its first start.
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
        let Some(name) = self.name_of(exception) else {
            return Err(ConfigError::UnknownException { raiser, exception });
        };
        if exception == owner {
            return Err(ConfigError::ExceptionIsOwner { raiser });
        }
        if !self.has_lane(exception) {
            return Err(ConfigError::ExceptionWithoutLane {
                raiser,
                exception: (exception, name),
            });
        }
        Ok(())
    }
}
