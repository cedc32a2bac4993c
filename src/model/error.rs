//! Configuration and start errors. rtseq never panics: every misuse is one of these.

use crate::{ErrorMessage, SeqId};

/// Everything that can go wrong when configuring or commanding the sequencer.
///
/// ```
/// use rtseq::{Error, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 1> = Sequencer::new();
/// seq.register(SeqConfig::new("a")).unwrap();
/// let e = seq.register(SeqConfig::new("b")).unwrap_err();
/// assert_eq!(e, Error::SequenceCapacityExceeded);
/// assert_eq!(e.to_string(), "sequence capacity exceeded");
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A sequence or monitor was registered with an empty name.
    EmptyName,
    /// The name is already registered, to this sequence.
    DuplicateName(SeqId),
    /// The sequencer's capacity (its const generic `N`) is exhausted.
    SequenceCapacityExceeded,
    /// The monitor table's capacity (its const generic `M`) is exhausted.
    MonitorCapacityExceeded,
    /// No sequence with this id is registered here.
    UnknownSequence(SeqId),
    /// The sequence is already running (or paused, aborting, restarting).
    AlreadyRunning(SeqId),
    /// The request needs a sequence under way: running for a pause, and running, paused
    /// or between two rounds (`Restarting`) for an abort; not one idle, ended or
    /// `Aborting` (a pause of one `Restarting` too); or a start by a sequence that may begin
    /// nothing more (its id): the tick stopped it while its action ran on, a teardown has
    /// placed it, its abort is requested or an abort-all waits (a start through a handle
    /// of its context included).
    NotRunning(SeqId),
    /// Resume was requested for a sequence that is not paused (and has no pause pending).
    NotPaused(SeqId),
    /// Starting would nest callers deeper than [`MAX_DEPTH`](crate::MAX_DEPTH).
    CallerDepthExceeded(SeqId),
    /// A non-blocking start of a sequence that has no lane to run in; or, from
    /// [`Sequencer::check_lanes`](crate::Sequencer::check_lanes), a declared lane that no
    /// task has polled.
    NoLane(SeqId),
    /// All `W` lane slots of the sequencer are declared.
    LaneCapacityExceeded(SeqId),
    /// A polling time or timeout of zero, or of 2^31 µs (about 35.8 minutes) or more: the
    /// sequencer compares times by their wrapping difference in 32 bits of µs.
    DurationOutOfRange,
    /// A join on a sequence that was never started.
    NeverStarted(SeqId),
    /// A sequence object is already bound to this id.
    AlreadyBound(SeqId),
    /// More distinct polling periods than
    /// [`MAX_POLLING_CLASSES`](crate::MAX_POLLING_CLASSES) in one sequencer.
    PollingClassesExceeded,
    /// A [`Table`](crate::Table) is installed only into a sequencer with nothing registered.
    NotEmpty,
    /// A join that could never return: a sequence joining itself, a caller it blocks, or
    /// (an exception sequence) the owner held until its end or a blocking child of it,
    /// held with it; or the last join of a cycle of joins. The check follows the waits: a
    /// timeout or monitor that could abort one of them does not make the join wait.
    JoinWouldDeadlock(SeqId),
    /// The configuration cannot work as declared: [`Sequencer::validate`](crate::Sequencer::validate)
    /// says what (a small variant: every `Result` of rtseq carries an `Error`).
    InvalidConfig,
    /// A [`tick`](crate::Sequencer::tick) with a time earlier than the last tick's: time
    /// does not go back, so that tick evaluated nothing (it carried out the requests and
    /// abort-alls made since, at the last tick's time).
    TickBeforeLast,
    /// A timeout with [`Behaviour::PauseOwner`](crate::Behaviour::PauseOwner): a timeout
    /// that has run out stays so, and would hold its sequence for good.
    PauseOnTimeout,
    /// A sequence object ([`Seq`](crate::Seq)) made by another sequencer was started
    /// blocking here (its id names a sequence of this one too). As a lane here it never
    /// runs, so a start of that id says [`NoLane`](Error::NoLane) (or
    /// [`LaneCapacityExceeded`](Error::LaneCapacityExceeded) once every slot is declared).
    ForeignSequence(SeqId),
    /// Resume was requested for a sequence that a [`PauseOwner`](crate::Behaviour::PauseOwner)
    /// monitor holds paused (its condition still holds). The request is refused and takes
    /// nothing back: held by the monitor alone, the sequence resumes when the condition
    /// clears; paused by a pause request as well (or with one pending), it stays paused
    /// then, until a resume request after the release (an operator's resume must come
    /// once the interlock has cleared, as a PLC's cycle start).
    HeldByMonitor(SeqId),
    /// A join whose run ended, and a later run of the same sequence ended too, before the
    /// joiner was polled: a control block keeps one outcome, the later run's, so the
    /// joined run's is lost. (The later run's outcome is
    /// [`Handle::last_outcome`](crate::Handle::last_outcome).)
    OutcomeLost(SeqId),
    /// A monitor table of 256 [`PauseOwner`](crate::Behaviour::PauseOwner) monitors, all
    /// of this one sequence: at most 255 monitors can hold one sequence paused at once.
    PauseOwnerMonitorsExceeded(SeqId),
    /// A [`tick`](crate::Sequencer::tick) while another tick of the same sequencer is under
    /// way (two tasks that tick it, or a tick from a condition, cleanup hook or waker of
    /// that tick): a sequencer has one heartbeat. This tick did nothing; the tick under way
    /// goes on.
    TickInProgress,
    /// A [`tick`](crate::Sequencer::tick) with polls due and a monitor table that is not
    /// this sequencer's: a sequencer is ticked with one table (the first non-empty one a
    /// due tick came with), and a table belongs to one sequencer (a table with an owner
    /// id beyond the sequencer's sets, 32 or more in a sequencer of up to 32, is another
    /// sequencer's, and is never bound). Such a tick evaluated
    /// nothing (it carried out the requests and abort-alls made since, at the last tick's
    /// time); the due polls wait for a tick with the sequencer's table.
    ForeignMonitorTable,
    /// A pause was requested of a sequence that a pause request paused already, with no
    /// resume pending: the request would do nothing. (One held paused by something else,
    /// a `PauseOwner` monitor or the paused caller it blocks, takes the request: it stays
    /// paused when that hold ends.)
    AlreadyPaused(SeqId),
    /// A start of this sequence ([`Cx::run`](crate::Cx::run), [`Cx::step`](crate::Cx::step),
    /// [`Cx::start`](crate::Cx::start) or [`Cx::start_scoped`](crate::Cx::start_scoped))
    /// made outside the action of the sequence whose context it used: from its pre- or
    /// exit condition, or the condition of a polled wait
    /// ([`Cx::wait_until`](crate::Cx::wait_until)), or while its action is dropped (an
    /// abort or restart of it, a `select` that drops its run: a `Drop` of something the
    /// action held). A condition looks; an action acts.
    OutsideAction(SeqId),
}

impl Error {
    /// What went wrong, without the name or id: for a `const` item's compile error
    /// (`panic!("{}", e.message().as_str())`), where no formatting is available.
    ///
    /// ```
    /// use rtseq::Error;
    /// const E: Error = Error::AlreadyRunning(rtseq::SeqId::from_index(3));
    /// const REASON: &str = E.reason(); // `const`: usable in a compile-time panic
    /// assert_eq!(REASON, "sequence already running");
    /// assert_eq!(E.to_string(), "sequence 3 is already running"); // `Display` says which
    /// ```
    pub const fn reason(&self) -> &'static str {
        match self {
            Error::EmptyName => "empty name",
            Error::DuplicateName(_) => "duplicate name",
            Error::SequenceCapacityExceeded => "sequence capacity exceeded",
            Error::MonitorCapacityExceeded => "monitor capacity exceeded",
            Error::UnknownSequence(_) => "unknown sequence",
            Error::AlreadyRunning(_) => "sequence already running",
            Error::NotRunning(_) => "sequence not running",
            Error::NotPaused(_) => "sequence not paused",
            Error::CallerDepthExceeded(_) => "caller depth exceeded",
            Error::NoLane(_) => "sequence has no lane a task polls",
            Error::LaneCapacityExceeded(_) => "lane capacity exceeded",
            Error::DurationOutOfRange => "duration is zero or too long",
            Error::NeverStarted(_) => "sequence never started",
            Error::AlreadyBound(_) => "sequence already bound",
            Error::PollingClassesExceeded => "too many distinct polling periods",
            Error::NotEmpty => "sequencer not empty",
            Error::JoinWouldDeadlock(_) => "join would deadlock",
            Error::InvalidConfig => "invalid configuration",
            Error::TickBeforeLast => "tick earlier than the last",
            Error::PauseOnTimeout => "a timeout cannot pause its sequence",
            Error::ForeignSequence(_) => "sequence object of another sequencer",
            Error::HeldByMonitor(_) => "sequence held paused by a monitor",
            Error::OutcomeLost(_) => "joined run's outcome lost to a later run",
            Error::TickInProgress => "another tick is under way",
            Error::ForeignMonitorTable => "monitor table of another sequencer or tick",
            Error::PauseOwnerMonitorsExceeded(_) => {
                "more than 255 PauseOwner monitors of one sequence"
            }
            Error::AlreadyPaused(_) => "sequence already paused",
            Error::OutsideAction(_) => "start outside an action",
        }
    }
}

impl Error {
    /// What went wrong, naming the sequence by its id: the `Display` form, made by a
    /// `const fn`, so that a `const` item fails to compile with it
    /// (`Err(e) => panic!("{}", e.message().as_str())`).
    ///
    /// ```
    /// use rtseq::{Error, SeqConfig, Table};
    /// const E: Error = match Table::<(), 2>::new([SeqConfig::new("move"), SeqConfig::new("move")]) {
    ///     Ok(_) => panic!("a duplicate name is refused"),
    ///     Err(e) => e.error,
    /// };
    /// assert_eq!(E.message().as_str(), "duplicate name: sequence 0 has it");
    /// assert_eq!(E.to_string(), E.message().as_str());
    /// ```
    pub const fn message(&self) -> ErrorMessage {
        match self.parts() {
            (before, Some(id), after) => ErrorMessage::new()
                .with(before)
                .with_number(id.index())
                .with(after),
            (text, None, _) => ErrorMessage::new().with(text),
        }
    }

    /// The message in its parts: the text before the sequence it names, that sequence (if
    /// any), the text after it. [`message`](Self::message) writes the sequence's index,
    /// [`WithNames`](crate::WithNames) its name.
    pub(crate) const fn parts(&self) -> (&'static str, Option<SeqId>, &'static str) {
        match *self {
            Error::EmptyName => ("empty name", None, ""),
            Error::DuplicateName(id) => ("duplicate name: sequence ", Some(id), " has it"),
            Error::SequenceCapacityExceeded => ("sequence capacity exceeded", None, ""),
            Error::MonitorCapacityExceeded => ("monitor capacity exceeded", None, ""),
            Error::UnknownSequence(id) => ("unknown sequence ", Some(id), ""),
            Error::AlreadyRunning(id) => ("sequence ", Some(id), " is already running"),
            Error::NotRunning(id) => ("sequence ", Some(id), " is not running"),
            Error::NotPaused(id) => ("sequence ", Some(id), " is not paused"),
            Error::CallerDepthExceeded(id) => ("starting sequence ", Some(id), " exceeds the caller depth"),
            Error::NoLane(id) => ("sequence ", Some(id), " has no lane that a task polls"),
            Error::LaneCapacityExceeded(id) => ("no lane slot left for sequence ", Some(id), ""),
            Error::DurationOutOfRange => ("duration is zero or too long", None, ""),
            Error::NeverStarted(id) => ("sequence ", Some(id), " was never started"),
            Error::AlreadyBound(id) => ("sequence ", Some(id), " is already bound"),
            Error::PollingClassesExceeded => ("too many distinct polling periods", None, ""),
            Error::NotEmpty => ("a table needs an empty sequencer", None, ""),
            Error::InvalidConfig => ("invalid configuration (see Sequencer::validate)", None, ""),
            Error::TickBeforeLast => ("a tick's time is earlier than the last tick's", None, ""),
            Error::PauseOnTimeout => ("a timeout cannot pause its sequence (PauseOwner is a monitor behaviour)", None, ""),
            Error::ForeignSequence(id) => ("the object of sequence ", Some(id), " was made by another sequencer"),
            Error::HeldByMonitor(id) => ("sequence ", Some(id), " is held paused by a monitor whose condition holds"),
            Error::OutcomeLost(id) => ("the joined run of sequence ", Some(id), " ended, and so did a later run, whose outcome replaced it"),
            Error::TickInProgress => ("a tick while another tick of the same sequencer is under way", None, ""),
            Error::ForeignMonitorTable => ("a tick with a monitor table other than the sequencer's own (one table per sequencer)", None, ""),
            Error::PauseOwnerMonitorsExceeded(id) => ("sequence ", Some(id), " has 256 PauseOwner monitors; at most 255 can hold it paused"),
            Error::AlreadyPaused(id) => ("sequence ", Some(id), " is paused already"),
            Error::OutsideAction(id) => ("a start of sequence ", Some(id), " from a condition was refused (only an action starts)"),
            Error::JoinWouldDeadlock(id) => ("joining sequence ", Some(id), " would wait for itself (it is the joiner, a caller it blocks, the owner it handles an exception for or a child that exception holds)"),
        }
    }
}

impl core::error::Error for Error {}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message().as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every `Result` of rtseq carries an `Error`, and a failed run's outcome (kept in its
    /// control block) can hold one: an id and a tag.
    #[test]
    fn an_error_is_an_id_and_a_tag() {
        assert_eq!(core::mem::size_of::<Error>(), 2);
        assert_eq!(core::mem::size_of::<crate::Outcome>(), 4);
    }
}

/// Why a table refused one of its entries ([`Table::new`](crate::Table::new),
/// [`Monitors::table`](crate::Monitors::table), and the `table()` of
/// [`sequences!`](crate::sequences) and [`monitors!`](crate::monitors)): which entry, by
/// position and name, and what is wrong with it. Its message says both, so a `const` item
/// that fails to compile with it names the line to fix.
///
/// ```
/// use rtseq::{Duration, Error, SeqConfig, Table, TableError};
/// const E: TableError = match Table::<(), 3>::new([
///     SeqConfig::new("power on"),
///     SeqConfig::new("homing").timeout(Duration::from_ticks(0)),
///     SeqConfig::new("move"),
/// ]) {
///     Ok(_) => panic!("a zero timeout is refused"),
///     Err(e) => e,
/// };
/// assert_eq!(E, TableError { entry: 1, name: "homing", error: Error::DurationOutOfRange });
/// assert_eq!(E.message().as_str(), "entry 1 (`homing`): duration is zero or too long");
/// assert_eq!(E.to_string(), E.message().as_str());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TableError {
    /// The entry's position in the table: the index of its id.
    pub entry: usize,
    /// The entry's name (empty when that is what is wrong).
    pub name: &'static str,
    /// What is wrong with it.
    pub error: Error,
}

impl TableError {
    /// What went wrong, and where: "entry 1 (`homing`): duration is zero or too long"
    /// ("entry 1: empty name" for an entry without a name), made by a `const fn` like
    /// [`Error::message`].
    ///
    /// ```
    /// use rtseq::{Error, TableError};
    /// const E: TableError = TableError { entry: 4, name: "", error: Error::EmptyName };
    /// const MESSAGE: rtseq::ErrorMessage = E.message();
    /// assert_eq!(MESSAGE.as_str(), "entry 4: empty name");
    /// ```
    pub const fn message(&self) -> ErrorMessage {
        let error = self.error.message();
        let entry = ErrorMessage::new().with("entry ").with_number(self.entry);
        let named = if self.name.is_empty() {
            entry
        } else {
            entry.with(" (`").with(self.name).with("`)")
        };
        named.with(": ").with(error.as_str())
    }
}

impl core::error::Error for TableError {}

impl core::fmt::Display for TableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message().as_str())
    }
}
