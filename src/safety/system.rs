//! The owned part of the safety system and its cycle.

use core::fmt;

use super::bits::bit_of;
use super::context::{OutOfRange, PendingEvents, SafetyContext};
use super::error::SafetyError;
use super::event::{EventId, EventKind};
use super::handle::SafetyHandle;
use super::io::{InputId, SafetyIo};
use super::level::SafetyLevel;
use super::level_def::{AbortPolicy, LevelStats};
use super::properties::{SafetyProperties, ValidProperties};
use super::transition::LevelTransition;

/// What the safety system sees of the sequences (the rtseq `Sequencer` implements it): it
/// can abort them all, and it tells them what it did, so that the sequencer's trace shows
/// the safety levels and tripped inputs between its own records. Called from the safety
/// cycle, at the highest priority: an implementation must only *note* what it is told (set
/// flags, queue a record) and return in bounded time.
///
/// Only [`abort_all`](Self::abort_all) must be written; the others do nothing unless
/// overridden. The sequencer whose [`safety_handle`](crate::Sequencer::safety_handle) the
/// system is built on is aborted through that handle whatever `Sequences` the cycle is
/// given; passing it here also puts the levels and tripped inputs in its trace.
///
/// ```
/// use core::sync::atomic::{AtomicU32, Ordering};
/// use rtseq::safety::Sequences;
/// struct AbortCounter(AtomicU32);
/// impl Sequences for AbortCounter {
///     fn abort_all(&self) { self.0.fetch_add(1, Ordering::Relaxed); }
/// }
/// let c = AbortCounter(AtomicU32::new(0));
/// c.abort_all();
/// assert_eq!(c.0.load(Ordering::Relaxed), 1);
/// ```
pub trait Sequences {
    /// Requests that every running sequence be aborted.
    fn abort_all(&self);

    /// The safety system entered `level` (in the first cycle, the entry level). Called in
    /// the cycle that changes the level, after the old level's exit action and the new
    /// level's entry action, before [`abort_all`](Self::abort_all) of the same cycle.
    fn level_entered(&self, level: SafetyLevel) {
        let _ = level;
    }

    /// Critical input `input` tripped: the check of the current level fired in this cycle
    /// and did not in the cycle before. Called after the level change of the same cycle.
    fn input_tripped(&self, input: InputId) {
        let _ = input;
    }
}

impl<T: Sequences + ?Sized> Sequences for &T {
    fn abort_all(&self) {
        (**self).abort_all();
    }

    fn level_entered(&self, level: SafetyLevel) {
        (**self).level_entered(level);
    }

    fn input_tripped(&self, input: InputId) {
        (**self).input_tripped(input);
    }
}

/// [`Sequences`] for applications without a sequencer (or tests): does nothing. (A
/// sequencer whose handle the system is built on is still aborted through the handle, but
/// its trace shows no safety levels: pass the sequencer instead.)
///
/// ```
/// use rtseq::safety::{NoSequences, Sequences};
/// NoSequences.abort_all();
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoSequences;

impl Sequences for NoSequences {
    fn abort_all(&self) {}
}

/// A level change applied at the start of a cycle.
///
/// ```
/// use rtseq::safety::{LevelChange, SafetyLevel};
/// let first = LevelChange { from: None, to: SafetyLevel::new(1) }; // entering the entry level
/// # let _ = first;
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelChange {
    /// The level left (`None` in the very first cycle).
    pub from: Option<SafetyLevel>,
    /// The level entered.
    pub to: SafetyLevel,
}

/// An event that had no transition from the level it was resolved in.
///
/// ```
/// use rtseq::safety::{EventId, SafetyLevel, UnknownEvent};
/// let u = UnknownEvent { event: EventId::public(3), level: SafetyLevel::new(1) };
/// # let _ = u;
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UnknownEvent {
    /// The event.
    pub event: EventId,
    /// The level it was resolved in.
    pub level: SafetyLevel,
}

/// What one [`SafetySystem::cycle`] did — enough for a trace.
///
/// ```
/// use rtseq::safety::*;
/// # struct Io;
/// # impl SafetyIo for Io {
/// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
/// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
/// # }
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// static PROPS: SafetyProperties<'static, Io, 1> =
///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
/// static HANDLE: SafetyHandle = SafetyHandle::new();
/// let mut safety = SafetySystem::new(&PROPS, &HANDLE)?;
/// let report = safety.cycle(&mut Io, &NoSequences);
/// assert_eq!(report.change, Some(LevelChange { from: None, to: OFF }));
/// assert_eq!(report.level, OFF);
/// # Ok::<(), SafetyError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CycleReport {
    /// The level whose inputs, action and outputs ran in this cycle.
    pub level: SafetyLevel,
    /// The transition applied at the start of this cycle, if any.
    pub change: Option<LevelChange>,
    /// Bit `i` set: the action of critical input `i` fired (triggered its
    /// event) in this cycle.
    pub input_events: u32,
    /// Whether [`Sequences::abort_all`] was called in this cycle.
    pub aborted: bool,
    /// Number of unknown events found at the start of this cycle.
    pub unknown_events: u32,
}

/// The owned part of the safety system (EEROS `SafetySystem`): the
/// current level, the counters, the events triggered inside the system.
/// Owned by the highest-priority task, which calls
/// [`cycle`](Self::cycle) at the safety period; everyone else uses the
/// shared [`SafetyHandle`].
///
/// Heap-free and panic-free; its size is 8 bytes of counters per level
/// plus a few words (see the README section for figures).
///
/// ```
/// use rtseq::safety::*;
///
/// const OFF: SafetyLevel = SafetyLevel::new(0);
/// const ON: SafetyLevel = SafetyLevel::new(1);
/// const START: PublicEvent = PublicEvent::new(0);
/// const ESTOP: PrivateEvent = PrivateEvent::new(0);
/// const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop pressed");
/// const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");
///
/// struct Io { estop_pressed: bool, enable: bool }
/// impl SafetyIo for Io {
///     fn read_input(&mut self, _input: InputId) -> IoValue { self.estop_pressed.into() }
///     fn write_output(&mut self, _output: OutputId, value: IoValue) {
///         self.enable = value == IoValue::Bool(true);
///     }
/// }
///
/// static PROPS: SafetyProperties<'static, Io, 2> = SafetyProperties::new(
///     [
///         LevelDef::new(OFF, "off").inputs(&[ESTOP_IN.ignore()]).outputs(&[ENABLE.set(false)]),
///         LevelDef::new(ON, "on").inputs(&[ESTOP_IN.check(false, ESTOP)]).outputs(&[ENABLE.set(true)]),
///     ],
///     &[ESTOP_IN.info()],
///     &[ENABLE.info()],
///     &[LevelTransition::on(OFF, START, ON), LevelTransition::on(ON, ESTOP, OFF)],
///     OFF,
/// );
/// static SAFETY: SafetyHandle = SafetyHandle::new();
///
/// let mut safety = SafetySystem::new(&PROPS, &SAFETY)?;
/// let mut io = Io { estop_pressed: false, enable: false };
/// safety.cycle(&mut io, &NoSequences); // enters OFF
/// SAFETY.trigger(START);               // from a sequence
/// safety.cycle(&mut io, &NoSequences);
/// assert_eq!((SAFETY.level(), io.enable), (ON, true));
/// io.estop_pressed = true;
/// safety.cycle(&mut io, &NoSequences); // the input check fires ESTOP ...
/// safety.cycle(&mut io, &NoSequences); // ... which is applied here
/// assert_eq!((SAFETY.level(), io.enable), (OFF, false));
/// # Ok::<(), SafetyError>(())
/// ```
pub struct SafetySystem<'a, IO, const L: usize> {
    props: &'a SafetyProperties<'a, IO, L>,
    handle: &'a SafetyHandle,
    current: SafetyLevel,
    started: bool,
    stats: [LevelStats; L],
    toggle: u32,
    pending: PendingEvents,
    /// The critical inputs whose check fired in the last cycle (bit `i` = input `i`): a
    /// check that goes on firing is one trip.
    firing: u32,
    unknown_count: u32,
    last_unknown: Option<UnknownEvent>,
}

impl<'a, IO, const L: usize> SafetySystem<'a, IO, L> {
    /// Validates `props`, binds `handle` (a handle serves one system at a
    /// time, until that system is dropped) and publishes the entry level on
    /// it. The entry level is entered (entry action, activation) in the
    /// first [`cycle`](Self::cycle).
    ///
    /// Errors: every [`SafetyError`] of
    /// [`SafetyProperties::validate`], or [`SafetyError::HandleInUse`].
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// static PROPS: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let first = SafetySystem::new(&PROPS, &HANDLE);
    /// assert!(first.is_ok());
    /// assert_eq!(SafetySystem::new(&PROPS, &HANDLE).err(), Some(SafetyError::HandleInUse));
    /// drop(first); // releases HANDLE
    /// assert!(SafetySystem::new(&PROPS, &HANDLE).is_ok());
    /// ```
    pub fn new(
        props: &'a SafetyProperties<'a, IO, L>,
        handle: &'a SafetyHandle,
    ) -> Result<Self, SafetyError> {
        props.validate()?;
        Self::bind(props, handle)
    }

    /// Like [`new`](Self::new) for properties already proven valid (at
    /// compile time, see [`ValidProperties`]): no run-time validation, so
    /// the validation code is not linked. Only fails with
    /// [`SafetyError::HandleInUse`].
    ///
    /// ```
    /// use rtseq::safety::*;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// static PROPS: ValidProperties<'static, Io, 1> =
    ///     match SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF).validated() {
    ///         Ok(valid) => valid,
    ///         Err(_) => panic!("invalid safety properties"),
    ///     };
    /// static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new_validated(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.level(), OFF);
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn new_validated(
        props: &'a ValidProperties<'a, IO, L>,
        handle: &'a SafetyHandle,
    ) -> Result<Self, SafetyError> {
        Self::bind(props.properties(), handle)
    }

    fn bind(
        props: &'a SafetyProperties<'a, IO, L>,
        handle: &'a SafetyHandle,
    ) -> Result<Self, SafetyError> {
        if !handle.bind() {
            return Err(SafetyError::HandleInUse);
        }
        let entry = props.entry_level();
        handle.publish_level(entry);
        Ok(Self {
            props,
            handle,
            current: entry,
            started: false,
            stats: [LevelStats::ZERO; L],
            toggle: 0,
            pending: PendingEvents::new(),
            firing: 0,
            unknown_count: 0,
            last_unknown: None,
        })
    }

    /// The current level (the entry level before the first cycle).
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.level(), OFF);
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn level(&self) -> SafetyLevel {
        self.current
    }

    /// The name of the current level.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.level_name(), "off");
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn level_name(&self) -> &'static str {
        self.props.level(self.current).map_or("", |d| d.name())
    }

    /// Whether the first cycle has run.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # impl SafetyIo for Io {
    /// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
    /// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
    /// # }
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let mut safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert!(!safety.is_started());
    /// safety.cycle(&mut Io, &NoSequences);
    /// assert!(safety.is_started());
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn is_started(&self) -> bool {
        self.started
    }

    /// The counters of `level` (`None` if not defined).
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # impl SafetyIo for Io {
    /// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
    /// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
    /// # }
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let mut safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.stats(OFF), Some(LevelStats { activations: 0, cycles: 0 }));
    /// safety.cycle(&mut Io, &NoSequences);
    /// safety.cycle(&mut Io, &NoSequences);
    /// assert_eq!(safety.stats(OFF), Some(LevelStats { activations: 1, cycles: 2 }));
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn stats(&self, level: SafetyLevel) -> Option<LevelStats> {
        self.stats.get(level.index()).copied()
    }

    /// Number of events that had no transition from the level they were
    /// resolved in (saturating).
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # impl SafetyIo for Io {
    /// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
    /// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
    /// # }
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let mut safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// safety.cycle(&mut Io, &NoSequences);
    /// HANDLE.trigger(PublicEvent::new(5)); // no transition anywhere
    /// safety.cycle(&mut Io, &NoSequences);
    /// assert_eq!(safety.unknown_events(), 1);
    /// assert_eq!(safety.last_unknown_event(),
    ///            Some(UnknownEvent { event: EventId::public(5), level: OFF }));
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn unknown_events(&self) -> u32 {
        self.unknown_count
    }

    /// The last event without a transition (within one cycle, events are
    /// resolved public ones by ascending id, then private ones by
    /// ascending id, then out-of-range ones). See
    /// [`unknown_events`](Self::unknown_events) for an example.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.last_unknown_event(), None);
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn last_unknown_event(&self) -> Option<UnknownEvent> {
        self.last_unknown
    }

    /// The shared handle this system is bound to.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert!(core::ptr::eq(safety.handle(), &HANDLE));
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn handle(&self) -> &'a SafetyHandle {
        self.handle
    }

    /// The properties this system runs.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> =
    /// #     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// assert_eq!(safety.properties().entry_level(), OFF);
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn properties(&self) -> &'a SafetyProperties<'a, IO, L> {
        self.props
    }

    /// Whether events wait for the next cycle (a few loads; nothing is
    /// taken).
    #[inline(always)]
    fn events_pending(&self) -> bool {
        self.handle.has_pending()
            | self.handle.has_out_of_range()
            | (self.pending.public | self.pending.private != 0)
            | self.pending.out_of_range.is_some()
    }

    /// Resolves every pending event against the current level; returns
    /// the safest destination and counts the unknown events in `unknown`.
    fn resolve_events(&mut self, unknown: &mut u32) -> Option<SafetyLevel> {
        let public = self.handle.take_pending();
        let public = public | core::mem::take(&mut self.pending.public);
        let private = core::mem::take(&mut self.pending.private);
        let level = self.current;
        let mut found = Resolution {
            rows: self.props.transitions(),
            level,
            best: u16::MAX,
            unknown: 0,
            last_unknown: None,
        };
        found.resolve(EventKind::Public, public);
        found.resolve(EventKind::Private, private);
        if let Some(OutOfRange { count, last }) = self.handle.take_out_of_range() {
            found.add_unknown(count, last);
        }
        if let Some(OutOfRange { count, last }) = self.pending.out_of_range.take() {
            found.add_unknown(count, last);
        }
        if let Some(event) = found.last_unknown {
            self.unknown_count = self.unknown_count.saturating_add(found.unknown);
            *unknown = found.unknown;
            self.last_unknown = Some(UnknownEvent { event, level });
        }
        u8::try_from(found.best).ok().map(SafetyLevel::new)
    }
}

/// Resolving one cycle's events: the table and level they are resolved
/// against, and what was found.
struct Resolution<'t> {
    rows: &'t [LevelTransition],
    level: SafetyLevel,
    /// The id of the safest destination, `u16::MAX` for none.
    best: u16,
    /// Number of events without a transition.
    unknown: u32,
    /// The last of them, in resolution order.
    last_unknown: Option<EventId>,
}

impl Resolution<'_> {
    /// Resolves the events of `mask` (ids of `kind`, ascending).
    #[inline(never)]
    fn resolve(&mut self, kind: EventKind, mask: u32) {
        let mut pending = mask;
        while pending != 0 {
            let event = EventId::new(kind, pending.trailing_zeros() as u8);
            pending &= pending.wrapping_sub(1);
            match self.rows.iter().find(|row| row.covers(self.level, event)) {
                Some(row) => self.best = self.best.min(u16::from(row.to().id())),
                None => self.add_unknown(1, event),
            }
        }
    }

    /// Counts `count` events without a transition, `last` the last of them.
    fn add_unknown(&mut self, count: u32, last: EventId) {
        self.unknown = self.unknown.saturating_add(count);
        self.last_unknown = Some(last);
    }
}

impl<IO: SafetyIo, const L: usize> SafetySystem<'_, IO, L> {
    /// Step 1 of a cycle that has something to do: the first cycle enters
    /// the entry level, a later one resolves the pending events; a new
    /// level is entered (exit action of the old level, publish, count the
    /// activation, entry action). Out of line: the common cycle has no
    /// events.
    #[cold]
    #[inline(never)]
    fn change_level(&mut self, io: &mut IO, report: &mut CycleReport) {
        let props = self.props;
        let from = self.started.then_some(self.current);
        let to = match from {
            Some(_) => match self.resolve_events(&mut report.unknown_events) {
                Some(to) => to,
                None => return,
            },
            None => props.entry_level(),
        };
        if from == Some(to) {
            return;
        }
        if let Some(exit) = from.and_then(|l| props.level(l)).and_then(|d| d.exit_fn()) {
            exit(io);
        }
        self.current = to;
        self.started = true;
        self.toggle = 0;
        self.handle.publish_level(to);
        report.level = to;
        report.change = Some(LevelChange { from, to });
        // (`to` is always defined in validated properties.)
        if let (Some(stats), Some(def)) = (self.stats.get_mut(to.index()), props.level(to)) {
            stats.activations = stats.activations.saturating_add(1);
            let stats = *stats;
            if let Some(entry) = def.entry_fn() {
                entry(&mut SafetyContext::new(&mut self.pending, to, stats), io);
            }
        }
    }

    /// Runs one safety cycle, in this order:
    ///
    /// 1. resolve every pending event (public ones from the handle, and
    ///    the public and private ones triggered inside the system in the
    ///    previous cycle) against the current level; the **safest**
    ///    (lowest) destination wins, events without a transition are
    ///    counted as unknown. If it differs from the current level: exit
    ///    action of the old level, publish the new level on the handle,
    ///    count the activation, entry action of the new level. (In the
    ///    first cycle: enter the entry level, no exit action.) A new level
    ///    is told to `sequences` ([`Sequences::level_entered`]);
    /// 2. abort all sequences if the level demands it ([`AbortPolicy`]):
    ///    those of the [`Sequencer`](crate::Sequencer) that holds the handle
    ///    (the system is built on its
    ///    [`safety_handle`](crate::Sequencer::safety_handle)), whatever
    ///    `sequences` is, and through `sequences`;
    /// 3. input actions, in the level's order (events they trigger are
    ///    resolved in the next cycle); an input whose check fires now and
    ///    did not in the cycle before is told to `sequences`
    ///    ([`Sequences::input_tripped`]), by ascending id;
    /// 4. the level action;
    /// 5. the output actions.
    ///
    /// So a new level's inputs, action and outputs run in the cycle it is
    /// entered, and an event triggered before cycle *n* (by a sequence, or
    /// by an input or action in cycle *n − 1*) has its level's outputs
    /// applied and its sequences aborted in cycle *n*, for *n* ≥ 2: the
    /// first cycle only enters the entry level, and events triggered
    /// before it wait for the second.
    ///
    /// Bounded: O(levels' inputs + outputs) without events, plus
    /// O(pending events × transition rows) when events are pending. See
    /// [`SafetySystem`] for an example.
    ///
    /// ```
    /// # use rtseq::safety::*;
    /// # struct Io;
    /// # impl SafetyIo for Io {
    /// #     fn read_input(&mut self, _: InputId) -> IoValue { IoValue::Bool(false) }
    /// #     fn write_output(&mut self, _: OutputId, _: IoValue) {}
    /// # }
    /// # const OFF: SafetyLevel = SafetyLevel::new(0);
    /// # static PROPS: SafetyProperties<'static, Io, 1> = SafetyProperties::new(
    /// #     [LevelDef::new(OFF, "off").abort_sequences(AbortPolicy::OnEntry)], &[], &[], &[], OFF);
    /// # static HANDLE: SafetyHandle = SafetyHandle::new();
    /// let mut safety = SafetySystem::new(&PROPS, &HANDLE)?;
    /// let report = safety.cycle(&mut Io, &NoSequences);
    /// assert!(report.aborted); // OFF aborts all sequences on entry
    /// # Ok::<(), SafetyError>(())
    /// ```
    pub fn cycle<A: Sequences + ?Sized>(&mut self, io: &mut IO, sequences: &A) -> CycleReport {
        let mut report = CycleReport {
            level: self.current,
            change: None,
            input_events: 0,
            aborted: false,
            unknown_events: 0,
        };
        // 1. Pending transition.
        if !self.started || self.events_pending() {
            self.change_level(io, &mut report);
        }
        let entered = report.change.is_some();
        let level = self.current;
        if entered {
            sequences.level_entered(level);
        }
        let Some(def) = self.props.level(level) else {
            // Unreachable for validated properties.
            return report;
        };

        // 2. Abort all sequences if the level demands it.
        let abort = match def.abort_policy() {
            AbortPolicy::Never => false,
            AbortPolicy::OnEntry => entered,
            AbortPolicy::WhileActive => true,
        };
        if abort {
            self.handle.request_abort_all();
            sequences.abort_all();
            report.aborted = true;
        }
        // (A validated level always has its counters.)
        let stats = self
            .stats
            .get_mut(level.index())
            .map_or(LevelStats::ZERO, |s| {
                s.cycles = s.cycles.saturating_add(1);
                *s
            });

        // 3. Input actions (bit `i` of `fired` = input `i`, as in the report).
        let mut fired: u32 = 0;
        for action in def.input_actions() {
            let input = action.input();
            if !action.is_ignored() && action.fires(io.read_input(input)) {
                fired |= bit_of(input.index());
                self.pending.add(action.event());
            }
        }
        report.input_events = fired;
        let mut tripped = fired & !self.firing;
        self.firing = fired;
        while tripped != 0 {
            let input = InputId(tripped.trailing_zeros() as u8);
            tripped &= tripped.wrapping_sub(1);
            sequences.input_tripped(input);
        }

        // 4. Level action.
        if let Some(action) = def.action_fn() {
            action(&mut SafetyContext::new(&mut self.pending, level, stats), io);
        }

        // 5. Output actions.
        for action in def.output_actions() {
            action.apply(io, &mut self.toggle);
        }

        self.handle.count_cycle();
        report
    }
}

/// Dropping the system releases its handle and resets it to the state of
/// [`SafetyHandle::new`]: another system can be built on it (see
/// [`SafetyHandle`]'s section on tests).
impl<IO, const L: usize> Drop for SafetySystem<'_, IO, L> {
    fn drop(&mut self) {
        self.handle.release();
    }
}

impl<IO, const L: usize> fmt::Debug for SafetySystem<'_, IO, L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SafetySystem")
            .field("level", &self.current)
            .field("started", &self.started)
            .field("stats", &self.stats)
            .field("unknown_events", &self.unknown_count)
            .field("last_unknown", &self.last_unknown)
            .finish()
    }
}

#[cfg(test)]
#[allow(
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::unwrap_used
)]
mod tests {
    extern crate std;
    use super::*;
    use crate::safety::{LevelDef, LevelTransition, PublicEvent};
    use std::vec::Vec;

    /// A small deterministic generator (xorshift32).
    struct Rng(u32);
    impl Rng {
        fn next(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            self.0
        }
        fn below(&mut self, n: u32) -> u32 {
            self.next() % n
        }
    }

    /// What resolving the pending events must give, computed event by event
    /// in resolution order (public ids ascending, private ids ascending,
    /// then the handle's and the system's out-of-range events), each looked
    /// up in the table: (safest destination, unknown count, last unknown).
    fn reference(
        props: &SafetyProperties<'_, (), 8>,
        level: SafetyLevel,
        public: u32,
        private: u32,
        out_of_range: &[(u32, EventId)],
    ) -> (Option<SafetyLevel>, u32, Option<EventId>) {
        let mut best: Option<SafetyLevel> = None;
        let mut count = 0;
        let mut last = None;
        let masks = [
            (public, EventId::public as fn(u8) -> EventId),
            (private, EventId::private),
        ];
        for (mask, make) in masks {
            for index in 0..32u8 {
                if mask & (1 << index) == 0 {
                    continue;
                }
                let event = make(index);
                match props.destination(level, event) {
                    Some(to) => best = Some(best.map_or(to, |b| b.min(to))),
                    None => {
                        count += 1;
                        last = Some(event);
                    }
                }
            }
        }
        for &(n, event) in out_of_range {
            if n != 0 {
                count += n;
                last = Some(event);
            }
        }
        (best, count, last)
    }

    /// Resolving gives what looking up every pending event on its own in
    /// resolution order gives, on random tables (overlapping rows, ids and
    /// levels out of range included) and random pending events.
    #[test]
    fn resolution_matches_the_per_event_reference() {
        let mut rng = Rng(0x2545_f491);
        let levels: [LevelDef<'static, ()>; 8] =
            core::array::from_fn(|i| LevelDef::new(SafetyLevel::new(i as u8), "level"));
        for _ in 0..20_000 {
            let rows: Vec<LevelTransition> = (0..rng.below(14))
                .map(|_| {
                    let low = SafetyLevel::new(rng.below(10) as u8);
                    let high = SafetyLevel::new(low.id() + rng.below(4) as u8);
                    let to = SafetyLevel::new(rng.below(8) as u8);
                    let index = rng.below(36) as u8;
                    if rng.below(2) == 0 {
                        LevelTransition::on_levels_between(low, high, PublicEvent::new(index), to)
                    } else {
                        LevelTransition::on_levels_between(
                            low,
                            high,
                            crate::safety::PrivateEvent::new(index),
                            to,
                        )
                    }
                })
                .collect();
            let props = SafetyProperties::new(levels, &[], &[], &rows, SafetyLevel::new(0));
            let handle = SafetyHandle::new();
            let mut system = SafetySystem::bind(&props, &handle).unwrap();
            system.current = SafetyLevel::new(rng.below(8) as u8);
            let mut sparse = || (0..=rng.below(5)).fold(u32::MAX, |m, _| m & rng.next());
            let public = sparse();
            let private = sparse();
            for index in 0..32 {
                if public & (1 << index) != 0 {
                    handle.trigger(PublicEvent::new(index));
                }
            }
            system.pending.private = private;
            let mut out_of_range = Vec::new();
            let handle_extra = rng.below(4).saturating_sub(1);
            let mut handle_last = EventId::public(0);
            for _ in 0..handle_extra {
                let index = 32 + rng.below(10) as u8;
                handle.trigger(PublicEvent::new(index));
                handle_last = EventId::public(index);
            }
            out_of_range.push((handle_extra, handle_last));
            let own_extra = rng.below(4).saturating_sub(1);
            for _ in 0..own_extra {
                system
                    .pending
                    .add(EventId::private(32 + rng.below(10) as u8));
            }
            let own_last = system
                .pending
                .out_of_range
                .map_or(EventId::public(0), |o| o.last);
            out_of_range.push((own_extra, own_last));
            let want = reference(&props, system.current, public, private, &out_of_range);

            let mut unknown = 0;
            let best = system.resolve_events(&mut unknown);
            assert_eq!(
                (best, unknown),
                (want.0, want.1),
                "{rows:?} at {:?}",
                system.current
            );
            assert_eq!(system.unknown_events(), want.1);
            let last = system.last_unknown_event().map(|u| u.event);
            assert_eq!(last, want.2, "{rows:?}");
            assert_eq!(system.pending.public | system.pending.private, 0);
            assert_eq!(handle.pending_events(), 0);
        }
    }
}
