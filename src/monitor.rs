//! Monitors: a condition, an optional exception sequence and a behaviour (seed §1.7).

use core::marker::PhantomData;
use core::mem::ManuallyDrop;

use crate::model::set::Words;
use crate::{Condition, Error, MonitorId, SeqId, TableError};

/// What happens after a monitor fired and its exception sequence (if any) ended.
///
/// `AbortOwner` on a blocking sub-sequence: `move` is aborted when a fault appears at 3 ms,
/// and `main`, which ran it, gets the outcome and goes on:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use core::cell::Cell;
/// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Done, Duration, Failure, Instant, Monitor, Monitors,
///             RunningState, Seq, SeqConfig, Sequence, Sequencer, Wait};
/// #[derive(Default)]
/// struct Ctrl { fault: Cell<bool>, got: Cell<Option<Result<Done, Failure>>> }
/// struct Move(Seq<Wait>);
/// impl Sequence<Ctrl> for Move {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
///         let _ = cx.step(&mut self.0).await;
///         Ok(())
///     }
/// }
/// struct Main(Seq<Move>);
/// impl Sequence<Ctrl> for Main {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
///         let outcome = cx.run(&mut self.0).await;
///         cx.control().got.set(Some(outcome));
///         Ok(())
///     }
/// }
/// let seq: Sequencer<Ctrl, 4> = Sequencer::new();
/// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
/// let mv = seq.add(SeqConfig::new("move"), Move(wait)).unwrap();
/// let mv_id = mv.id();
/// let main = seq.add(SeqConfig::new("main"), Main(mv)).unwrap();
/// let id = main.id();
/// let mut fault = |c: &Ctrl, _: Instant| c.fault.get();
/// let mut monitors = Monitors::<Ctrl, 1>::new();
/// let m = monitors.add(mv_id, Monitor::new("fault", &mut fault, Behaviour::AbortOwner)).unwrap();
/// let ctrl = Ctrl::default();
/// let mut sim = Sim::new(&seq, &ctrl, monitors);
/// sim.lane(main);
/// sim.before_tick(|t, c| c.fault.set(t.as_ticks() >= 3_000));
/// sim.start(id).unwrap();
/// assert_eq!(sim.run_until_idle(Duration::from_millis(20)).map(|t| t.as_ticks()), Some(3_000));
/// assert_eq!(ctrl.got.get(), Some(Err(Failure::Aborted(Cause::Monitor(m)))));
/// assert_eq!(sim.state(mv_id), RunningState::Aborted);
/// assert_eq!(sim.state(id), RunningState::Terminated);
/// # }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Behaviour {
    /// The owner continues where it was: at once without an exception sequence; with one,
    /// once it ended (the owner is held meanwhile, as in EEROS, where the exception
    /// sequence runs to its end before the owner goes on).
    Nothing,
    /// The owner and all its sub-sequences (blocking and non-blocking) are aborted; the
    /// owner's blocking caller gets [`Failure::Aborted`](crate::Failure::Aborted) and continues.
    AbortOwner,
    /// The owner's sub-sequences are aborted and the owner runs again from its pre-condition.
    RestartOwner,
    /// Like `AbortOwner`, one level up: the owner's caller (the owner itself for a main
    /// sequence). A non-blocking owner whose caller has ended is aborted itself. The
    /// caller is a sequence (the seed's `callerSequence`), not a run: one that ended and
    /// was started again is aborted in its run under way, the owner with it.
    AbortCallerOfOwner,
    /// Like `RestartOwner`, one level up: the owner's caller (the owner itself for a main
    /// sequence). A non-blocking owner whose caller has ended cannot be restarted by it:
    /// the owner is aborted. A caller started again since restarts its run under way, as
    /// for `AbortCallerOfOwner`.
    RestartCallerOfOwner,
    /// While the condition holds, the owner and its blocking children are paused; when it
    /// clears, they resume (a PLC's feed hold). The exception sequence, if any, is started
    /// on entry and runs in its lane while the owner is paused. Not one of the seed's five:
    /// it marks no exception, so the owner's other monitors keep firing (a following-error
    /// monitor still restarts a paused owner; the restarted owner pauses again at once if
    /// the condition still holds). A `PauseOwner` monitor watches both edges, whatever its
    /// [`Trigger`]; it is not a timeout behaviour (`register` refuses it there).
    ///
    /// A pause holds the sequences, not the machine (see
    /// [`Handle::pause`](crate::Handle::pause)). To hold the motion too, give the monitor
    /// an exception sequence that holds it in the control system, waits until the
    /// condition clears ([`Cx::wait_until`](crate::Cx::wait_until)) and lets it go; it
    /// runs in its lane from the firing tick on, the owner already paused. Nothing runs
    /// when the condition clears but that wait, so let the hold go in its cleanup hook
    /// ([`SeqConfig::on_abort`](crate::SeqConfig::on_abort)) too, for an abort that comes
    /// while the condition holds. To act at the release before the owner goes on (issue
    /// the held move again, re-enable a drive), add a second monitor of the same condition
    /// with [`Trigger::FallingEdge`], `Nothing` and an exception sequence: the owner,
    /// resumed in that tick, is held until the exception sequence has ended
    /// (`a_falling_edge_monitor_with_an_exception_sequence_acts_at_the_release` in
    /// `tests/pause_owner.rs`).
    PauseOwner,
}

impl Behaviour {
    /// True for the two restarting behaviours, which the restart limit bounds.
    ///
    /// ```
    /// use rtseq::Behaviour;
    /// assert!(Behaviour::RestartOwner.is_restart());
    /// assert!(Behaviour::RestartCallerOfOwner.is_restart());
    /// assert!(!Behaviour::AbortOwner.is_restart());
    /// ```
    pub const fn is_restart(self) -> bool {
        matches!(
            self,
            Behaviour::RestartOwner | Behaviour::RestartCallerOfOwner
        )
    }

    /// The abort behaviour a restart escalates to once the restart limit is reached.
    ///
    /// ```
    /// use rtseq::Behaviour;
    /// assert_eq!(Behaviour::RestartOwner.escalated(), Behaviour::AbortOwner);
    /// assert_eq!(Behaviour::RestartCallerOfOwner.escalated(), Behaviour::AbortCallerOfOwner);
    /// assert_eq!(Behaviour::Nothing.escalated(), Behaviour::Nothing);
    /// ```
    pub const fn escalated(self) -> Behaviour {
        match self {
            Behaviour::RestartOwner => Behaviour::AbortOwner,
            Behaviour::RestartCallerOfOwner => Behaviour::AbortCallerOfOwner,
            other => other,
        }
    }

    /// True for the behaviours that act on the owner's caller.
    ///
    /// ```
    /// use rtseq::Behaviour;
    /// assert!(Behaviour::AbortCallerOfOwner.targets_caller());
    /// assert!(!Behaviour::RestartOwner.targets_caller());
    /// ```
    pub const fn targets_caller(self) -> bool {
        matches!(
            self,
            Behaviour::AbortCallerOfOwner | Behaviour::RestartCallerOfOwner
        )
    }

    /// What this behaviour does to an owner without a caller (a main sequence): a
    /// `…CallerOfOwner` acts on the owner itself.
    pub(crate) const fn on_owner(self) -> Behaviour {
        match self {
            Behaviour::AbortCallerOfOwner => Behaviour::AbortOwner,
            Behaviour::RestartCallerOfOwner => Behaviour::RestartOwner,
            other => other,
        }
    }

    /// The sequence this behaviour acts on for `owner` whose caller is `caller`: the
    /// caller for a `…CallerOfOwner` behaviour of an owner that has one, else the owner.
    pub(crate) const fn target(self, owner: SeqId, caller: Option<SeqId>) -> SeqId {
        match caller {
            Some(c) if self.targets_caller() => c,
            _ => owner,
        }
    }
}

/// When a monitor fires.
///
/// What each trigger makes of a condition's changes (`fires(last, value)`):
///
/// ```
/// use rtseq::Trigger;
/// let changes = [(false, true), (true, true), (true, false), (false, false)];
/// let fires = |t: Trigger| changes.map(|(last, value)| t.fires(last, value));
/// assert_eq!(fires(Trigger::RisingEdge), [true, false, false, false]);
/// assert_eq!(fires(Trigger::FallingEdge), [false, false, true, false]);
/// assert_eq!(fires(Trigger::Change), [true, false, true, false]);
/// assert_eq!(fires(Trigger::Level), [true, true, false, false]);
/// ```
// The discriminants are the tick's bit sets: 1 = rising edge, 2 = falling edge, 4 = level.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Trigger {
    /// On the rising edge of the condition (default): no exception storm while it stays true.
    RisingEdge = 1,
    /// On the falling edge of the condition (e.g. a button released, a fault cleared).
    FallingEdge = 2,
    /// On every change of the condition (e.g. a toggle switched on and off again).
    Change = 3,
    /// At every evaluation while the condition is true and no exception of the owner is active.
    Level = 4,
}

impl Trigger {
    /// Whether a condition going from `last` to `value` fires a monitor with this trigger.
    ///
    /// ```
    /// use rtseq::Trigger;
    /// assert!(Trigger::RisingEdge.fires(false, true));
    /// assert!(!Trigger::RisingEdge.fires(true, true));
    /// assert!(Trigger::Level.fires(true, true));
    /// ```
    #[inline]
    pub const fn fires(self, last: bool, value: bool) -> bool {
        match self {
            Trigger::RisingEdge => value && !last,
            Trigger::FallingEdge => !value && last,
            Trigger::Change => value != last,
            Trigger::Level => value,
        }
    }
}

/// Default number of restarts a monitor may cause per run of its target before escalating.
///
/// A monitor whose condition stays true restarts its owner this often, then aborts it:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Duration, Failure, Instant, Monitor, Monitors,
///             Outcome, Seq, SeqConfig, Sequence, Sequencer, Wait, DEFAULT_RESTART_LIMIT};
/// struct Dwell(Seq<Wait>);
/// impl Sequence<()> for Dwell {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         let _ = cx.step(&mut self.0).await;
///         Ok(())
///     }
/// }
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
/// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
/// let id = main.id();
/// let mut always = |_: &(), _: Instant| true;
/// let mut monitors = Monitors::<(), 1>::new();
/// let m = monitors.add(id, Monitor::new("stuck", &mut always, Behaviour::RestartOwner)).unwrap();
/// let mut sim = Sim::new(&seq, &(), monitors);
/// sim.lane(main);
/// sim.start(id).unwrap();
/// sim.run_until_idle(Duration::from_millis(50)).unwrap();
/// let restarts = sim.trace().iter().filter(|t| t.sequence == id && t.cause == Cause::Restart);
/// assert_eq!(restarts.count(), usize::from(DEFAULT_RESTART_LIMIT));
/// let outcome = sim.handle(id).unwrap().last_outcome();
/// assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
/// # }
/// ```
pub const DEFAULT_RESTART_LIMIT: u8 = 3;

/// A monitor definition: build it, then add it to a [`Monitors`] table.
///
/// ```
/// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqConfig, Sequencer, Trigger};
/// struct Ctrl { following_error: f32 }
/// let seq: Sequencer<Ctrl, 4> = Sequencer::new();
/// let moving = seq.register(SeqConfig::new("move")).unwrap();
/// let safe_stop = seq.register(SeqConfig::new("safe stop")).unwrap();
/// let mut too_far = |c: &Ctrl, _: Instant| c.following_error > 0.05;
/// let mut monitors: Monitors<Ctrl, 4> = Monitors::new();
/// monitors
///     .add(
///         moving,
///         Monitor::new("following error", &mut too_far, Behaviour::RestartCallerOfOwner)
///             .exception(safe_stop)
///             .restart_limit(3)
///             .trigger(Trigger::RisingEdge),
///     )
///     .unwrap();
/// ```
pub struct Monitor<'a, C, K = DynCondition<'a, C>> {
    pub(crate) name: &'static str,
    pub(crate) condition: K,
    _borrow: PhantomData<Borrows<'a, C>>,
    pub(crate) behaviour: Behaviour,
    pub(crate) exception: Option<SeqId>,
    pub(crate) trigger: Trigger,
    pub(crate) restart_limit: u8,
}

impl<C, K> Monitor<'_, C, K> {
    /// The edges the tick watches for this monitor: a `PauseOwner` monitor needs both (it
    /// pauses on the rising edge and resumes on the falling one).
    const fn watched(&self) -> Trigger {
        match self.behaviour {
            Behaviour::PauseOwner => Trigger::Change,
            _ => self.trigger,
        }
    }
}

/// Whether `entries` plus `next` would be [`MAX_MONITORS`] `PauseOwner` monitors of one
/// owner: one more than a sequence's count of holding monitors (a `u8`) can hold. Only a
/// full table of them can be, so this looks at the table's last place only.
const fn holds_overflow<C, K>(
    entries: &[OwnedMonitor<'_, C, K>],
    next: &OwnedMonitor<'_, C, K>,
) -> bool {
    if entries.len() + 1 < MAX_MONITORS || !matches!(next.def.behaviour, Behaviour::PauseOwner) {
        return false;
    }
    let mut rest = entries;
    while let Some((e, tail)) = rest.split_first() {
        if e.owner.index() != next.owner.index()
            || !matches!(e.def.behaviour, Behaviour::PauseOwner)
        {
            return false;
        }
        rest = tail;
    }
    true
}

/// What a monitor definition borrows: the lifetime of a `dyn` condition, the control type.
type Borrows<'a, C> = (&'a (), fn(&C));

/// The default condition holder of a monitor table: any condition, behind a `dyn` call.
///
/// The default table holds any mix of conditions: closures, library conditions, your own
/// types:
///
/// ```
/// use rtseq::{Behaviour, DynCondition, Instant, Monitor, Monitors, SeqConfig, Sequencer,
///             Toggle};
/// struct Drive { current: f32, stop_button: bool }
/// let seq: Sequencer<Drive, 2> = Sequencer::new();
/// let run = seq.register(SeqConfig::new("run")).unwrap();
/// let mut over_current = |d: &Drive, _: Instant| d.current > 5.0;
/// let mut stop = Toggle::new(|d: &Drive| d.stop_button);
/// let mut monitors: Monitors<'_, Drive, 2, DynCondition<'_, Drive>> = Monitors::new();
/// let over_current = Monitor::new("over-current", &mut over_current, Behaviour::AbortOwner);
/// monitors.add(run, over_current).unwrap();
/// monitors.add(run, Monitor::new("stop", &mut stop, Behaviour::AbortOwner)).unwrap();
/// assert_eq!(monitors.len(), 2);
/// ```
pub type DynCondition<'a, C> = &'a mut (dyn Condition<C> + Send);

/// A plain function as a monitor's condition. A table of them needs neither `&mut`
/// borrows nor an enum of the application's conditions, so it can be a `const`; the tick
/// calls each through its pointer. Build its monitors with [`Monitor::with_fn`].
///
/// ```
/// use rtseq::{Behaviour, ConditionFn, Instant, Monitor, Monitors, SeqId};
/// struct Drive { current: f32, end_stop: bool }
/// fn over_current(d: &Drive, _: Instant) -> bool { d.current > 5.0 }
/// fn end_stop(d: &Drive, _: Instant) -> bool { d.end_stop }
/// const MOVE: SeqId = SeqId::from_index(0);
/// const MONITORS: Monitors<'static, Drive, 2, ConditionFn<Drive>> = match Monitors::table([
///     Monitor::with_fn("over-current", over_current, Behaviour::AbortOwner).owned_by(MOVE),
///     Monitor::with_fn("end stop", end_stop, Behaviour::AbortOwner).owned_by(MOVE),
/// ]) {
///     Ok(table) => table,
///     Err(e) => panic!("{}", e.message().as_str()), // a compile error, never a run-time panic
/// };
/// let monitors = MONITORS;
/// assert_eq!(monitors.len(), 2);
/// ```
pub type ConditionFn<C> = fn(&C, crate::Instant) -> bool;

impl<'a, C> Condition<C> for &'a mut (dyn Condition<C> + Send + 'a) {
    #[inline]
    fn validate(&mut self, control: &C, now: crate::Instant) -> bool {
        (**self).validate(control, now)
    }

    #[inline]
    fn begin_run(&mut self) {
        (**self).begin_run();
    }
}

impl<'a, C> Monitor<'a, C> {
    /// A rising-edge monitor with no exception sequence and the default restart limit, in a
    /// table of `dyn` conditions (the default [`Monitors`]).
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<f32, 2> = Sequencer::new();
    /// let heating = seq.register(SeqConfig::new("heating")).unwrap();
    /// let mut too_hot = |t: &f32, _: Instant| *t > 80.0;
    /// let mut monitors: Monitors<f32, 2> = Monitors::new();
    /// let too_hot = Monitor::new("too hot", &mut too_hot, Behaviour::AbortOwner);
    /// let m = monitors.add(heating, too_hot).unwrap();
    /// assert_eq!((monitors.name(m), monitors.owner(m)), (Some("too hot"), Some(heating)));
    /// ```
    #[inline(never)]
    pub fn new(
        name: &'static str,
        condition: &'a mut (dyn Condition<C> + Send),
        behaviour: Behaviour,
    ) -> Self {
        Monitor::with_condition(name, condition, behaviour)
    }
}

impl<C> Monitor<'_, C, ConditionFn<C>> {
    /// Like [`with_condition`](Monitor::with_condition), for a table of plain functions
    /// ([`ConditionFn`]): a function item becomes a pointer here, so the monitors of one
    /// table need no cast to one type.
    ///
    /// ```
    /// use rtseq::{Behaviour, ConditionFn, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// fn too_hot(t: &f32, _: Instant) -> bool { *t > 80.0 }
    /// fn too_cold(t: &f32, _: Instant) -> bool { *t < -20.0 }
    /// let seq: Sequencer<f32, 2> = Sequencer::new();
    /// let heating = seq.register(SeqConfig::new("heating")).unwrap();
    /// let mut monitors: Monitors<f32, 2, ConditionFn<f32>> = Monitors::new();
    /// monitors.add(heating, Monitor::with_fn("too hot", too_hot, Behaviour::AbortOwner)).unwrap();
    /// let cold = monitors.add(heating, Monitor::with_fn("too cold", too_cold, Behaviour::AbortOwner));
    /// assert_eq!(monitors.name(cold.unwrap()), Some("too cold"));
    /// ```
    pub const fn with_fn(
        name: &'static str,
        condition: ConditionFn<C>,
        behaviour: Behaviour,
    ) -> Self {
        Monitor::with_condition(name, condition, behaviour)
    }
}

impl<'a, C, K> Monitor<'a, C, K> {
    /// Like [`new`](Monitor::new), for a table whose conditions all have the type `K` (e.g.
    /// an enum of the application's conditions): the tick then calls them without a `dyn`
    /// call, and a simple condition inlines into its loop.
    ///
    /// ```
    /// use rtseq::{Behaviour, Condition, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// #[derive(Clone, Copy)]
    /// enum Fault { OverCurrent, EndStop }
    /// struct Drive { current: f32, end_stop: bool }
    /// impl Condition<Drive> for Fault {
    ///     fn validate(&mut self, d: &Drive, _: Instant) -> bool {
    ///         match self { Fault::OverCurrent => d.current > 5.0, Fault::EndStop => d.end_stop }
    ///     }
    /// }
    /// let seq: Sequencer<Drive, 4> = Sequencer::new();
    /// let moving = seq.register(SeqConfig::new("move")).unwrap();
    /// let mut monitors: Monitors<Drive, 2, Fault> = Monitors::new();
    /// monitors
    ///     .add(moving, Monitor::with_condition("end stop", Fault::EndStop, Behaviour::AbortOwner))
    ///     .unwrap();
    /// ```
    // Out of line: set-up code, called once per monitor; one copy serves every call site.
    #[inline(never)]
    pub const fn with_condition(name: &'static str, condition: K, behaviour: Behaviour) -> Self {
        Monitor {
            name,
            condition,
            _borrow: PhantomData,
            behaviour,
            exception: None,
            trigger: Trigger::RisingEdge,
            restart_limit: DEFAULT_RESTART_LIMIT,
        }
    }

    /// The exception sequence to run (in its lane, while the owner is held) when this fires.
    ///
    /// A fault at 2 ms starts the 3 ms exception sequence `safe stop`; `main` is held while it
    /// runs, and aborted (the behaviour) at the next tick after it ended:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Duration, Failure, Instant, Monitor, Monitors,
    ///             Outcome, RunningState::*, Seq, SeqConfig, Sequence, Sequencer, Transition,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<Cell<bool>> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<bool>, 4> = Sequencer::new();
    /// let ms = |n| Wait::new(Duration::from_millis(n));
    /// let (w, s) = (seq.add(SeqConfig::new("w"), ms(10)), seq.add(SeqConfig::new("s"), ms(3)));
    /// let main = seq.add(SeqConfig::new("main"), Dwell(w.unwrap())).unwrap();
    /// let stop = seq.add(SeqConfig::new("safe stop"), Dwell(s.unwrap())).unwrap();
    /// let (id, stop_id) = (main.id(), stop.id());
    /// let mut fault = |c: &Cell<bool>, _: Instant| c.get();
    /// let mut monitors = Monitors::<Cell<bool>, 1>::new();
    /// let m = monitors
    ///     .add(id, Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(stop_id))
    ///     .unwrap();
    /// let flag = Cell::new(false);
    /// let mut sim = Sim::new(&seq, &flag, monitors);
    /// sim.lane(main);
    /// sim.lane(stop); // the exception sequence runs in its own lane
    /// sim.before_tick(|t, c| c.set(t.as_ticks() >= 2_000));
    /// sim.start(id).unwrap();
    /// sim.run_for(Duration::from_millis(2));
    /// let started = Transition::at_millis(2, stop_id, Idle, Running, Cause::Monitor(m));
    /// assert!(sim.trace().contains(&started));
    /// assert!(sim.handle(id).unwrap().exception_is_active());
    /// let idle = sim.run_until_idle(Duration::from_millis(20));
    /// assert_eq!(idle.map(|t| t.as_ticks()), Some(6_000));
    /// let outcome = sim.handle(id).unwrap().last_outcome();
    /// assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
    /// # }
    /// ```
    #[inline(never)]
    pub const fn exception(mut self, sequence: SeqId) -> Self {
        self.exception = Some(sequence);
        self
    }

    /// When the monitor fires: [`Trigger::RisingEdge`] (the default), `FallingEdge`, `Change`
    /// or `Level`.
    ///
    /// A falling-edge monitor: the drive's enable line drops at 4 ms:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Behaviour, Cx, Duration, Failure, Instant, Monitor, Monitors, Seq,
    ///             SeqConfig, Sequence, Sequencer, Trigger, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<Cell<bool>> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<bool>, 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut enabled = |c: &Cell<bool>, _: Instant| c.get();
    /// let mut monitors = Monitors::<Cell<bool>, 1>::new();
    /// let lost = Monitor::new("enable lost", &mut enabled, Behaviour::AbortOwner)
    ///     .trigger(Trigger::FallingEdge);
    /// monitors.add(id, lost).unwrap();
    /// let enable = Cell::new(true);
    /// let mut sim = Sim::new(&seq, &enable, monitors);
    /// sim.lane(main);
    /// sim.before_tick(|t, c| c.set(t.as_ticks() < 4_000));
    /// sim.start(id).unwrap();
    /// let idle = sim.run_until_idle(Duration::from_millis(20));
    /// assert_eq!(idle.map(|t| t.as_ticks()), Some(4_000));
    /// # }
    /// ```
    #[inline(never)]
    pub const fn trigger(mut self, trigger: Trigger) -> Self {
        self.trigger = trigger;
        self
    }

    /// How many restarts of a run of its target this monitor allows: once the run has been
    /// restarted that often (by this monitor, another one or a timeout), a restarting
    /// behaviour escalates to the matching abort. The count is the run's: a new run (not a
    /// restart) begins at 0, whichever sequence the target is (`RestartCallerOfOwner`
    /// restarts the owner's caller of the moment); `docs/semantics.md`, item 5.
    ///
    /// With a limit of 1, a condition that stays true restarts its owner once, then aborts it:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Duration, Failure, Instant, Monitor, Monitors,
    ///             Outcome, Seq, SeqConfig, Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut always = |_: &(), _: Instant| true;
    /// let mut monitors = Monitors::<(), 1>::new();
    /// let stuck = Monitor::new("stuck", &mut always, Behaviour::RestartOwner).restart_limit(1);
    /// let m = monitors.add(id, stuck).unwrap();
    /// let mut sim = Sim::new(&seq, &(), monitors);
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_millis(50)).unwrap();
    /// assert_eq!(sim.trace().iter().filter(|t| t.cause == Cause::Restart).count(), 1);
    /// let outcome = sim.handle(id).unwrap().last_outcome();
    /// assert_eq!(outcome, Some(Outcome::Aborted(Cause::Monitor(m))));
    /// # }
    /// ```
    #[inline(never)]
    pub const fn restart_limit(mut self, limit: u8) -> Self {
        self.restart_limit = limit;
        self
    }

    /// This monitor, owned by `owner`: an entry of [`Monitors::table`] ([`Monitors::add`]
    /// takes the owner as an argument instead).
    ///
    /// ```
    /// use rtseq::{Behaviour, Condition, Instant, Monitor, MonitorId, Monitors, OwnedMonitor,
    ///             SeqId};
    /// struct Stalled;
    /// impl Condition<f32> for Stalled {
    ///     fn validate(&mut self, speed: &f32, _: Instant) -> bool { *speed == 0.0 }
    /// }
    /// const SPIN: SeqId = SeqId::from_index(2);
    /// const ENTRY: OwnedMonitor<'static, f32, Stalled> =
    ///     Monitor::with_condition("stalled", Stalled, Behaviour::RestartOwner).owned_by(SPIN);
    /// let Ok(monitors) = Monitors::<f32, 1, Stalled>::table([ENTRY]) else { unreachable!() };
    /// assert_eq!(monitors.owner(MonitorId::from_index(0)), Some(SPIN));
    /// ```
    pub const fn owned_by(self, owner: SeqId) -> OwnedMonitor<'a, C, K> {
        OwnedMonitor {
            def: self,
            owner,
            fired: 0,
            releasing: false,
        }
    }
}

/// A monitor and its owner ([`Monitor::owned_by`]), plus the bookkeeping the tick keeps
/// for it in a table.
///
/// A whole monitor table as data, built by a `const fn` (see [`Monitors::table`]):
///
/// ```
/// use rtseq::{Behaviour, Condition, Instant, Monitor, MonitorId, Monitors, OwnedMonitor, SeqId,
///             Trigger};
/// #[derive(Clone, Copy)]
/// enum Fault { OverCurrent, Released }
/// impl Condition<(f32, bool)> for Fault {
///     fn validate(&mut self, (amps, pressed): &(f32, bool), _: Instant) -> bool {
///         match self { Fault::OverCurrent => *amps > 5.0, Fault::Released => *pressed }
///     }
/// }
/// const RUN: SeqId = SeqId::from_index(0);
/// const ENTRIES: [OwnedMonitor<'static, (f32, bool), Fault>; 2] = [
///     Monitor::with_condition("over-current", Fault::OverCurrent, Behaviour::AbortOwner)
///         .owned_by(RUN),
///     Monitor::with_condition("released", Fault::Released, Behaviour::AbortOwner)
///         .trigger(Trigger::FallingEdge)
///         .owned_by(RUN),
/// ];
/// let Ok(monitors) = Monitors::<(f32, bool), 2, Fault>::table(ENTRIES) else { unreachable!() };
/// assert_eq!(monitors.name(MonitorId::from_index(1)), Some("released"));
/// ```
pub struct OwnedMonitor<'a, C, K = DynCondition<'a, C>> {
    pub(crate) def: Monitor<'a, C, K>,
    pub(crate) owner: SeqId,
    /// How often this monitor fired.
    pub(crate) fired: u16,
    /// A `PauseOwner` monitor whose condition cleared in the tick under way: its owner is
    /// released once the tick's holds, in every word, are made (`release_pending`).
    pub(crate) releasing: bool,
}

/// Most monitors in one [`Group`] (its bit sets are words).
pub(crate) const GROUP_MAX: u8 = 32;

/// Most monitors in one table.
const MAX_MONITORS: usize = 256;

/// Most groups in one table: twice the fewest that hold the most monitors, so that
/// groups can also end where the owners' word changes.
const MAX_GROUPS: usize = 2 * MAX_MONITORS / GROUP_MAX as usize;

/// Up to [`GROUP_MAX`] consecutively registered monitors, evaluated together: the tick
/// tests once per group whether all their owners are due and keeps the edge state as bit
/// sets, so a group is its conditions plus a handful of word operations.
///
/// The tick visits the sets' words of 32 sequences one at a time, and a group whose
/// owners are all in the word it visits takes the flat loop; so a group also ends where
/// the next monitor's owner is in another word than the group's owners, while enough
/// groups are left for the rest of the table (else it spans words, and the tick takes
/// its per-monitor path in each).
///
/// Bit `len - 1 - j` of each set belongs to the group's `j`-th monitor (the tick shifts
/// each condition's value in from the right, in table order).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Group {
    /// The values of the last evaluation (cleared at every new run of the owner).
    pub(crate) last: u32,
    /// Monitors that fire on a rising edge (`RisingEdge`, `Change`).
    pub(crate) rise: u32,
    /// Monitors that fire on a falling edge (`FallingEdge`, `Change`).
    pub(crate) fall: u32,
    /// Monitors that fire while true (`Level`).
    pub(crate) level: u32,
    /// The owners' bits in their words of 32 ids: exactly the owners when they are all in
    /// one word, else the bits of every word together (a test that may say "due" where no
    /// owner is, never the reverse).
    pub(crate) owner_bits: u32,
    /// The words that hold an owner.
    pub(crate) owner_words: Words,
    /// The group's first entry in the table.
    pub(crate) start: u8,
    /// Its number of entries (1 ..= `GROUP_MAX`).
    pub(crate) len: u8,
}

impl Group {
    /// A group whose first entry is `start`, with no monitor yet.
    const fn starting_at(start: u8) -> Group {
        Group {
            last: 0,
            rise: 0,
            fall: 0,
            level: 0,
            owner_bits: 0,
            owner_words: Words::EMPTY,
            start,
            len: 0,
        }
    }

    /// Appends a monitor of `owner` firing on `trigger` (the group has room).
    const fn push(&mut self, owner: SeqId, trigger: Trigger) {
        let t = trigger as u32;
        self.len = self.len.saturating_add(1);
        self.owner_bits |= 1 << (owner.0 & 31);
        self.owner_words = self.owner_words.with(Words::of(owner));
        self.rise = (self.rise << 1) | (t & 1);
        self.fall = (self.fall << 1) | ((t >> 1) & 1);
        self.level = (self.level << 1) | (t >> 2);
        self.last <<= 1;
    }

    /// The bit sets of the monitors that fire, given this evaluation's values `now` (bit
    /// layout as `last`).
    #[inline]
    pub(crate) fn firing(&self, now: u32) -> u32 {
        let last = self.last;
        let changed = now ^ last;
        (changed & ((now & self.rise) | (last & self.fall))) | (now & self.level)
    }

    /// The index in the group of the monitor at bit `position` (the group's first monitor
    /// holds its highest bit, its last bit 0).
    #[inline]
    pub(crate) fn index_of(&self, position: u32) -> u8 {
        self.len.wrapping_sub(1).wrapping_sub(position as u8)
    }
}

/// The groups of a table, tiling its entries in order.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Groups {
    /// The first `used` are in use.
    pub(crate) list: [Group; MAX_GROUPS],
    pub(crate) used: u8,
    /// The words of every owner: a sequencer whose sets have fewer words is not the
    /// table's (`State::takes_polls`).
    pub(crate) owner_words: Words,
}

impl Groups {
    const EMPTY: Groups = Groups {
        list: [Group::starting_at(0); MAX_GROUPS],
        used: 0,
        owner_words: Words::EMPTY,
    };

    /// Appends the monitor at `index` of a table of capacity `capacity`, owned by `owner`
    /// and firing on `trigger`: to the last group, or to a new one when that is full, or
    /// when `owner` is in another word than its owners and the groups left after a new
    /// one still hold the rest of the table.
    const fn push(&mut self, index: u8, owner: SeqId, trigger: Trigger, capacity: usize) {
        let used = self.used as usize;
        let opens = match group_mut(&mut self.list, used.wrapping_sub(1)) {
            None => true,
            Some(last) => {
                let left = (MAX_GROUPS.saturating_sub(used)) * GROUP_MAX as usize;
                let rest = capacity.saturating_sub(index as usize);
                last.len == GROUP_MAX || (!last.owner_words.same(Words::of(owner)) && left >= rest)
            }
        };
        if opens {
            if let Some(g) = group_mut(&mut self.list, used) {
                *g = Group::starting_at(index);
                self.used = self.used.saturating_add(1);
            }
        }
        if let Some(g) = group_mut(&mut self.list, (self.used as usize).wrapping_sub(1)) {
            g.push(owner, trigger);
        }
        self.owner_words = self.owner_words.with(Words::of(owner));
    }
}

/// Group `at` of `list` (a `const` `get_mut`).
const fn group_mut(list: &mut [Group], at: usize) -> Option<&mut Group> {
    let mut rest = list;
    let mut i = 0;
    while let Some((g, tail)) = rest.split_first_mut() {
        if i == at {
            return Some(g);
        }
        rest = tail;
        i += 1;
    }
    None
}

/// The monitors of an application, owned by the tick (the timer interrupt).
///
/// Conditions keep state and are evaluated only by the tick, so this table is not shared:
/// in RTIC it is a `local` resource of the timer task (hence conditions are `Send`: `init`
/// hands the table over). `M` is the capacity. `K` is the condition holder: by default
/// `&mut dyn Condition` (any mix of conditions); a single type such as an enum of the
/// application's conditions avoids the `dyn` call ([`Monitor::with_condition`]), and lets a
/// `const fn` build the whole table ([`Monitors::table`]). A table never drops its
/// conditions (it lives as long as the firmware).
///
/// On the chip the timer interrupt owns the table and passes it to every
/// [`tick`](crate::Sequencer::tick). A table is one sequencer's, and a sequencer is ticked
/// with one table: the first due tick with a non-empty table binds the two, and a due tick
/// with another table is refused ([`Error::ForeignMonitorTable`]). Here two ticks by hand,
/// with the owner started (its lane declared but not run):
///
/// ```
/// use core::cell::Cell;
/// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqConfig, Sequencer};
/// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
/// let run = seq.register(SeqConfig::new("run")).unwrap();
/// let h = seq.sequence_by_id(run).unwrap();
/// h.declare_lane().unwrap();
/// h.start().unwrap();
/// let mut warm = |hot: &Cell<bool>, _: Instant| hot.get();
/// let mut monitors: Monitors<Cell<bool>, 4> = Monitors::new();
/// let m = monitors.add(run, Monitor::new("warm", &mut warm, Behaviour::Nothing)).unwrap();
/// let hot = Cell::new(false);
/// seq.tick(Instant::from_ticks(1_000), &hot, &mut monitors).unwrap();
/// hot.set(true);
/// seq.tick(Instant::from_ticks(2_000), &hot, &mut monitors).unwrap();
/// assert_eq!(monitors.fired(m), 1);
/// ```
pub struct Monitors<'a, C, const M: usize, K = DynCondition<'a, C>> {
    /// In registration order: a `MonitorId` is the index. Never dropped (a table lives as
    /// long as its firmware), so that a `const` item can hold a table ([`Monitors::table`]).
    pub(crate) entries: ManuallyDrop<heapless::Vec<OwnedMonitor<'a, C, K>, M>>,
    /// The groups over `entries`, in table order (room for the most monitors a table
    /// holds: the length cannot follow `M` on stable Rust).
    pub(crate) groups: Groups,
    /// The tag of the sequencer whose due ticks this table takes (0: none yet; a
    /// sequencer's tag is given at its first registration and moves with it). Set by that
    /// sequencer's first due tick with it, if the table is not empty: a sequencer is ticked
    /// with one table, and a table belongs to one sequencer (its owners are that
    /// sequencer's ids). The sequencer keeps the table's address.
    pub(crate) ticked_by: u16,
}

impl<C, const M: usize, K> Default for Monitors<'_, C, M, K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'a, C, const M: usize, K> Monitors<'a, C, M, K> {
    /// An empty table.
    ///
    /// ```
    /// use rtseq::Monitors;
    /// const NONE: Monitors<'static, (), 8> = Monitors::new(); // `const`: no set-up code
    /// let monitors = NONE;
    /// assert!(monitors.is_empty());
    /// ```
    pub const fn new() -> Self {
        const { assert!(M <= MAX_MONITORS, "at most 256 monitors") };
        Monitors {
            entries: ManuallyDrop::new(heapless::Vec::new()),
            groups: Groups::EMPTY,
            ticked_by: 0,
        }
    }

    /// A table of `monitors`, in this order, checked by a `const fn` like
    /// [`Table`](crate::Table): built in a `const` item, its checks run in the compiler
    /// and the firmware holds no set-up code for monitors. Errors like
    /// [`add`](Self::add), as a [`TableError`] naming the entry; more monitors than `M`
    /// does not compile.
    ///
    /// ```
    /// use rtseq::{Behaviour, Condition, Instant, Monitor, MonitorId, Monitors, SeqId};
    /// struct Hot;
    /// impl Condition<f32> for Hot {
    ///     fn validate(&mut self, t: &f32, _: Instant) -> bool { *t > 80.0 }
    /// }
    /// const HEATING: SeqId = SeqId::from_index(0);
    /// const MONITORS: Monitors<'static, f32, 2, Hot> = match Monitors::table([
    ///     Monitor::with_condition("too hot", Hot, Behaviour::AbortOwner).owned_by(HEATING),
    /// ]) {
    ///     Ok(table) => table,
    ///     Err(e) => panic!("{}", e.message().as_str()), // a compile error, never a run-time panic
    /// };
    /// let monitors = MONITORS;
    /// assert_eq!(monitors.owner(MonitorId::from_index(0)), Some(HEATING));
    /// ```
    ///
    /// Two monitors in a table of one: "more monitors than the table's capacity M".
    ///
    /// ```compile_fail,E0080
    /// use rtseq::{Behaviour, Monitor, Monitors, SeqId};
    /// fn never(_: &(), _: rtseq::Instant) -> bool { false }
    /// const S: SeqId = SeqId::from_index(0);
    /// const TWO: Result<Monitors<'static, (), 1, rtseq::ConditionFn<()>>, rtseq::TableError> =
    ///     Monitors::table([
    ///         Monitor::with_condition("a", never as rtseq::ConditionFn<()>, Behaviour::Nothing).owned_by(S),
    ///         Monitor::with_condition("b", never as rtseq::ConditionFn<()>, Behaviour::Nothing).owned_by(S),
    ///     ]);
    /// let _ = TWO;
    /// ```
    pub const fn table<const L: usize>(
        monitors: [OwnedMonitor<'a, C, K>; L],
    ) -> Result<Self, TableError> {
        const { assert!(M <= MAX_MONITORS, "at most 256 monitors") };
        const {
            assert!(
                L <= M,
                "more monitors than the table's capacity M: make M at least their number"
            )
        };
        let overflow = match monitors.split_last() {
            Some((last, before)) if holds_overflow(before, last) => Some(TableError {
                entry: before.len(),
                name: last.def.name,
                error: Error::PauseOwnerMonitorsExceeded(last.owner),
            }),
            _ => None,
        };
        if let Some(refused) = overflow {
            core::mem::forget(monitors);
            return Err(refused);
        }
        let mut groups = Groups::EMPTY;
        let mut rest: &[OwnedMonitor<'a, C, K>] = &monitors;
        let mut at: u8 = 0;
        while let Some((e, tail)) = rest.split_first() {
            if e.def.name.is_empty() {
                // A `const fn` may not drop a `K`.
                core::mem::forget(monitors);
                return Err(TableError {
                    entry: at as usize,
                    name: "",
                    error: Error::EmptyName,
                });
            }
            groups.push(at, e.owner, e.def.watched(), M);
            at = at.wrapping_add(1);
            rest = tail;
        }
        Ok(Monitors {
            entries: ManuallyDrop::new(heapless::Vec::from_array(monitors)),
            groups,
            ticked_by: 0,
        })
    }

    /// Adds a monitor owned by `owner`. Errors on an empty name, a full table, or a 256th
    /// `PauseOwner` monitor of one sequence (at most 255 can hold it paused); that the
    /// owner and the exception sequence are registered is checked by
    /// [`Sequencer::validate`](crate::Sequencer::validate), which a monitor added after it
    /// has not passed. A table a sequencer was ticked with is checked again by its next due
    /// tick (an owner beyond the sequencer's ids is refused there). Names need not be
    /// unique: a firing's record names the monitor's owner too.
    ///
    /// The tick evaluates monitors in this order (the order of their ids), in groups of
    /// 32 that share one due test.
    ///
    /// ```
    /// use rtseq::{Behaviour, Error, Instant, Monitor, MonitorId, Monitors, SeqConfig, SeqId,
    ///             Sequencer};
    /// let seq: Sequencer<u32, 2> = Sequencer::new();
    /// let run = seq.register(SeqConfig::new("run")).unwrap();
    /// let high = |n: &u32, _: Instant| *n > 9;
    /// let (mut a, mut c, mut d) = (high, high, high);
    /// let mut monitors: Monitors<u32, 1> = Monitors::new();
    /// let nameless = monitors.add(run, Monitor::new("", &mut a, Behaviour::Nothing));
    /// assert_eq!(nameless, Err(Error::EmptyName));
    /// let ok = monitors.add(run, Monitor::new("c", &mut c, Behaviour::Nothing));
    /// assert_eq!(ok, Ok(MonitorId::from_index(0)));
    /// let full = monitors.add(run, Monitor::new("d", &mut d, Behaviour::Nothing));
    /// assert_eq!(full, Err(Error::MonitorCapacityExceeded));
    /// ```
    pub fn add(&mut self, owner: SeqId, monitor: Monitor<'a, C, K>) -> Result<MonitorId, Error> {
        if monitor.name.is_empty() {
            return Err(Error::EmptyName);
        }
        let id = u8::try_from(self.entries.len()).map_err(|_| Error::MonitorCapacityExceeded)?;
        let entry = OwnedMonitor {
            def: monitor,
            owner,
            fired: 0,
            releasing: false,
        };
        if holds_overflow(&self.entries, &entry) {
            return Err(Error::PauseOwnerMonitorsExceeded(owner));
        }
        let trigger = entry.def.watched();
        self.entries
            .push(entry)
            .map_err(|_| Error::MonitorCapacityExceeded)?;
        self.groups.push(id, owner, trigger, M);
        // A table bound to a sequencer is bound again, with its owners checked, by the
        // next due tick (`State::takes_polls`): the new owner may not be that sequencer's.
        self.ticked_by = 0;
        Ok(MonitorId(id))
    }

    fn entry(&self, id: MonitorId) -> Option<&OwnedMonitor<'a, C, K>> {
        self.entries.get(usize::from(id.0))
    }

    /// Number of registered monitors.
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqId};
    /// let mut never = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// let owner = SeqId::from_index(0);
    /// monitors.add(owner, Monitor::new("never", &mut never, Behaviour::Nothing)).unwrap();
    /// assert_eq!(monitors.len(), 1);
    /// ```
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no monitor is registered.
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqId};
    /// let mut never = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// assert!(monitors.is_empty());
    /// let owner = SeqId::from_index(0);
    /// monitors.add(owner, Monitor::new("never", &mut never, Behaviour::Nothing)).unwrap();
    /// assert!(!monitors.is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The name a monitor was registered with.
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, MonitorId, Monitors, SeqId};
    /// let mut never = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// let owner = SeqId::from_index(0);
    /// let m = monitors.add(owner, Monitor::new("never", &mut never, Behaviour::Nothing));
    /// assert_eq!(monitors.name(m.unwrap()), Some("never"));
    /// assert_eq!(monitors.name(MonitorId::from_index(1)), None);
    /// ```
    pub fn name(&self, id: MonitorId) -> Option<&'static str> {
        self.entry(id).map(|e| e.def.name)
    }

    /// The owner of a monitor.
    ///
    /// ```
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.register(SeqConfig::new("main")).unwrap();
    /// let axis = seq.register(SeqConfig::new("axis")).unwrap();
    /// let mut never = |_: &(), _: Instant| false;
    /// let mut monitors: Monitors<(), 4> = Monitors::new();
    /// let m = monitors.add(axis, Monitor::new("never", &mut never, Behaviour::Nothing)).unwrap();
    /// assert_eq!(monitors.owner(m), Some(axis));
    /// ```
    pub fn owner(&self, id: MonitorId) -> Option<SeqId> {
        self.entry(id).map(|e| e.owner)
    }

    /// How often a monitor fired; it stops at 65 535 (a `Level` warning polled every
    /// millisecond gets there in 65 s), so a reader that keeps the last value sees no new
    /// firings from then on.
    ///
    /// Two rising edges while the owner runs, ticked by hand:
    ///
    /// ```
    /// use core::cell::Cell;
    /// use rtseq::{Behaviour, Instant, Monitor, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
    /// let run = seq.register(SeqConfig::new("run")).unwrap();
    /// let h = seq.sequence_by_id(run).unwrap();
    /// h.declare_lane().unwrap();
    /// h.start().unwrap();
    /// let mut pressed = |b: &Cell<bool>, _: Instant| b.get();
    /// let mut monitors: Monitors<Cell<bool>, 1> = Monitors::new();
    /// let button = Monitor::new("button", &mut pressed, Behaviour::Nothing);
    /// let m = monitors.add(run, button).unwrap();
    /// let button = Cell::new(false);
    /// for (ms, level) in [(1, true), (2, true), (3, false), (4, true)] {
    ///     button.set(level);
    ///     seq.tick(Instant::from_ticks(ms * 1_000), &button, &mut monitors).unwrap();
    /// }
    /// assert_eq!(monitors.fired(m), 2);
    /// ```
    pub fn fired(&self, id: MonitorId) -> u16 {
        self.entry(id).map_or(0, |e| e.fired)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Never;
    impl Condition<()> for Never {
        fn validate(&mut self, _: &(), _: crate::Instant) -> bool {
            false
        }
    }

    fn monitor(i: usize) -> Monitor<'static, (), Never> {
        let trigger = match i % 3 {
            0 => Trigger::RisingEdge,
            1 => Trigger::FallingEdge,
            _ => Trigger::Level,
        };
        Monitor::with_condition("m", Never, Behaviour::AbortOwner).trigger(trigger)
    }

    #[test]
    fn a_table_has_the_groups_add_builds() {
        let owner = |i: usize| SeqId::from_index(i % 5);
        let table: Result<Monitors<'_, (), 40, Never>, _> =
            Monitors::table(core::array::from_fn::<_, 33, _>(|i| {
                monitor(i).owned_by(owner(i))
            }));
        assert!(table.is_ok());
        let Ok(table) = table else { return };
        let mut added: Monitors<'_, (), 40, Never> = Monitors::new();
        for i in 0..33 {
            assert_eq!(
                added.add(owner(i), monitor(i)),
                Ok(MonitorId::from_index(i))
            );
        }
        assert_eq!((table.groups.used, added.groups.used), (2, 2));
        for (t, a) in table
            .groups
            .list
            .iter()
            .zip(added.groups.list.iter())
            .take(2)
        {
            let fields = |g: &Group| {
                (
                    g.last,
                    g.rise,
                    g.fall,
                    g.level,
                    g.owner_bits,
                    g.owner_words,
                    g.start,
                    g.len,
                )
            };
            assert_eq!(fields(t), fields(a));
        }
        assert_eq!(table.owner(MonitorId::from_index(32)), Some(owner(32)));
    }

    /// The lengths of the groups in use.
    fn lengths<const M: usize>(m: &Monitors<'_, (), M, Never>) -> heapless::Vec<u8, MAX_GROUPS> {
        let used = usize::from(m.groups.used);
        m.groups.list.iter().take(used).map(|g| g.len).collect()
    }

    #[test]
    fn groups_end_where_the_owners_word_changes_while_groups_are_left() {
        // Owners 0..3 (word 0), then 40..43 (word 1), then 1 (word 0) again.
        let owners = [0, 1, 2, 3, 40, 41, 42, 43, 1].map(SeqId::from_index);
        let mut m: Monitors<'_, (), 64, Never> = Monitors::new();
        for (i, &o) in owners.iter().enumerate() {
            assert!(m.add(o, monitor(i)).is_ok());
        }
        assert_eq!(lengths(&m), [4, 4, 1]);
        let first = m.groups.list.first().map(|g| g.owner_words);
        assert_eq!(first, Some(Words::of(SeqId(0))));
        // A table built at compile time groups the same way.
        let table: Result<Monitors<'_, (), 64, Never>, _> = Monitors::table({
            let mut i = 0;
            owners.map(|o| {
                i += 1;
                monitor(i - 1).owned_by(o)
            })
        });
        assert_eq!(
            table.map(|t| lengths(&t)).ok(),
            Some([4, 4, 1].into_iter().collect())
        );
        // Owners alternating between two words fill a table of the most monitors: the
        // groups split while enough are left for the rest, then span both words.
        let mut full: Monitors<'_, (), 256, Never> = Monitors::new();
        for i in 0..256 {
            let owner = SeqId::from_index(i % 2 * 32);
            assert_eq!(full.add(owner, monitor(i)), Ok(MonitorId::from_index(i)));
        }
        let lens = lengths(&full);
        assert_eq!(lens.iter().map(|&l| usize::from(l)).sum::<usize>(), 256);
        assert_eq!(lens.len(), MAX_GROUPS);
        assert_eq!(lens.first(), Some(&1));
        assert_eq!(lens.last(), Some(&32));
    }

    #[test]
    fn a_table_checks_names() {
        let named = Monitor::with_condition("a", Never, Behaviour::Nothing).owned_by(SeqId(0));
        let nameless = Monitor::with_condition("", Never, Behaviour::Nothing).owned_by(SeqId(0));
        let t: Result<Monitors<'_, (), 2, Never>, _> = Monitors::table([named, nameless]);
        assert!(matches!(
            t,
            Err(TableError {
                entry: 1,
                name: "",
                error: Error::EmptyName
            })
        ));
    }
}
