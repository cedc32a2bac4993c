//! Per-sequence configuration given at registration.

use crate::{Behaviour, Duration, SeqId};

/// Default polling period: 1 ms, one tick of a 1 kHz heartbeat.
pub(crate) const DEFAULT_POLLING_MICROS: u32 = 1_000;

/// Configuration of a sequence or step: name, polling period, timeout monitor, cleanup hook.
///
/// ```
/// use rtseq::{Behaviour, Duration, SeqConfig, Sequencer};
/// struct Motor;
/// fn stop(_m: &Motor) {}
/// let seq: Sequencer<Motor, 4> = Sequencer::new();
/// let safe_stop = seq.register(SeqConfig::new("safe stop")).unwrap();
/// let homing = seq
///     .register(
///         SeqConfig::new("homing")
///             .polling(Duration::from_millis(10))
///             .timeout(Duration::from_secs(5))
///             .timeout_exception(safe_stop)
///             .timeout_behaviour(Behaviour::AbortOwner)
///             .on_abort(stop),
///     )
///     .unwrap();
/// assert_eq!(seq.sequence_by_name("homing").unwrap().id(), homing);
/// ```
pub struct SeqConfig<C> {
    pub(crate) name: &'static str,
    pub(crate) polling: Duration,
    pub(crate) timeout: Option<Duration>,
    pub(crate) timeout_exception: Option<SeqId>,
    pub(crate) timeout_behaviour: Behaviour,
    pub(crate) timeout_restart_limit: u8,
    pub(crate) on_abort: Option<fn(&C)>,
    pub(crate) in_lane: bool,
}

impl<C> SeqConfig<C> {
    /// A sequence polled every 1 ms, without timeout.
    ///
    /// ```
    /// use rtseq::{Error, SeqConfig, SeqId, Sequencer};
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// assert!(seq.register(SeqConfig::new("homing")).is_ok());
    /// assert_eq!(seq.register(SeqConfig::new("")), Err(Error::EmptyName));
    /// assert_eq!(seq.register(SeqConfig::new("homing")), Err(Error::DuplicateName(SeqId::from_index(0))));
    /// ```
    // Out of line: applications build many configurations; one copy of the literal.
    #[inline(never)]
    pub const fn new(name: &'static str) -> Self {
        SeqConfig {
            name,
            polling: Duration::from_ticks(DEFAULT_POLLING_MICROS as u64),
            timeout: None,
            timeout_exception: None,
            timeout_behaviour: Behaviour::AbortOwner,
            timeout_restart_limit: crate::monitor::DEFAULT_RESTART_LIMIT,
            on_abort: None,
            in_lane: false,
        }
    }

    /// The seed's `pollingTime`: how often monitors, timeout and exit condition are checked.
    ///
    /// A period is more than zero and under 2^31 µs (about 35.8 minutes); registration
    /// refuses others with [`Error::DurationOutOfRange`](crate::Error::DurationOutOfRange).
    /// A 3 ms dwell polled every 10 ms ends at the first poll after it passed; a zero
    /// period is refused:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Error, Failure, Monitors, Seq, SeqConfig, Sequence,
    ///             Sequencer, Wait};
    /// struct Main(Seq<Wait>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let zero = SeqConfig::new("never").polling(Duration::from_ticks(0));
    /// assert_eq!(seq.register(zero), Err(Error::DurationOutOfRange));
    /// let slow = SeqConfig::new("dwell").polling(Duration::from_millis(10));
    /// let dwell = seq.add(slow, Wait::new(Duration::from_millis(3))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(dwell)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_secs(1)).map(|t| t.as_ticks()), Some(10_000));
    /// # }
    /// ```
    pub const fn polling(mut self, period: Duration) -> Self {
        self.polling = period;
        self
    }

    /// Arms the timeout monitor: measured from the start, reset on restart, paused time
    /// excluded. A timeout is more than zero and under 2^31 µs (about 35.8 minutes), else
    /// registration returns
    /// [`Error::DurationOutOfRange`](crate::Error::DurationOutOfRange); a longer wait
    /// belongs in a step ([`Wait`](crate::Wait) has no such limit).
    ///
    /// A 10 ms dwell under a 4 ms timeout (default behaviour: abort):
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, Outcome, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Main(Seq<Wait>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let cfg = SeqConfig::new("main").timeout(Duration::from_millis(4));
    /// let main = seq.add(cfg, Main(dwell)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_secs(1)).map(|t| t.as_ticks()), Some(4_000));
    /// let outcome = sim.handle(id).unwrap().last_outcome();
    /// assert_eq!(outcome, Some(Outcome::Aborted(Cause::Timeout(id))));
    /// # }
    /// ```
    pub const fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = Some(timeout);
        self
    }

    /// Exception sequence of the timeout monitor. Without a timeout (`.timeout(..)`, or
    /// [`Handle::set_timeout`](crate::Handle::set_timeout) later) it never runs: nothing
    /// checks that a configuration with one has a timeout.
    ///
    /// The timeout starts `recover` (in its lane) while `main` is held:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, RunningState::*, Seq,
    ///             SeqConfig, Sequence, Sequencer, Transition, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let ms = |n| Wait::new(Duration::from_millis(n));
    /// let r_wait = seq.add(SeqConfig::new("r"), ms(2)).unwrap();
    /// let recover = seq.add(SeqConfig::new("recover"), Dwell(r_wait)).unwrap();
    /// let r = recover.id();
    /// let cfg = SeqConfig::new("main").timeout(Duration::from_millis(4)).timeout_exception(r);
    /// let main = seq.add(cfg, Dwell(seq.add(SeqConfig::new("w"), ms(10)).unwrap())).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.lane(recover);
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_secs(1)).unwrap();
    /// let (trace, at) = (sim.trace(), Transition::at_millis);
    /// assert!(trace.contains(&at(4, r, Idle, Running, Cause::Timeout(id))));
    /// assert!(trace.contains(&at(6, r, Running, Terminated, Cause::Completed)));
    /// # }
    /// ```
    pub const fn timeout_exception(mut self, sequence: SeqId) -> Self {
        self.timeout_exception = Some(sequence);
        self
    }

    /// Behaviour of the timeout monitor (default [`Behaviour::AbortOwner`]).
    ///
    /// With [`Behaviour::Nothing`] the timeout is only reported: the sequence completes.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Duration, Failure, Monitors, Outcome, Seq,
    ///             SeqConfig, Sequence, Sequencer, Wait};
    /// struct Main(Seq<Wait>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let cfg = SeqConfig::new("main")
    ///     .timeout(Duration::from_millis(4))
    ///     .timeout_behaviour(Behaviour::Nothing);
    /// let main = seq.add(cfg, Main(dwell)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_secs(1)).map(|t| t.as_ticks()), Some(10_000));
    /// let h = sim.handle(id).unwrap();
    /// assert_eq!(h.last_outcome(), Some(Outcome::Completed));
    /// assert_eq!(h.active_exception(), Some(Cause::Timeout(id)));
    /// # }
    /// ```
    pub const fn timeout_behaviour(mut self, behaviour: Behaviour) -> Self {
        self.timeout_behaviour = behaviour;
        self
    }

    /// Restart limit of the timeout monitor: how many restarts of a run of its target it
    /// allows (counted in the run, as for a monitor:
    /// [`Monitor::restart_limit`](crate::Monitor::restart_limit)).
    ///
    /// A 10 ms dwell under a 4 ms timeout that restarts it at most twice, then aborts it:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Behaviour, Cause, Cx, Duration, Failure, Monitors, Outcome, Seq,
    ///             SeqConfig, Sequence, Sequencer, Wait};
    /// struct Main(Seq<Wait>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let cfg = SeqConfig::new("main")
    ///     .timeout(Duration::from_millis(4))
    ///     .timeout_behaviour(Behaviour::RestartOwner)
    ///     .timeout_restart_limit(2);
    /// let main = seq.add(cfg, Main(dwell)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_secs(1)).map(|t| t.as_ticks()), Some(12_000));
    /// let restarts = sim.trace().iter().filter(|t| t.sequence == id && t.cause == Cause::Restart);
    /// assert_eq!(restarts.count(), 2);
    /// let outcome = sim.handle(id).unwrap().last_outcome();
    /// assert_eq!(outcome, Some(Outcome::Aborted(Cause::Timeout(id))));
    /// # }
    /// ```
    pub const fn timeout_restart_limit(mut self, limit: u8) -> Self {
        self.timeout_restart_limit = limit;
        self
    }

    /// A bounded cleanup run while the sequence is `Aborting` (or restarting), e.g. stop the
    /// motor. It runs in the tick: keep it short.
    ///
    /// The hook gets the control system, not the sequence's object: that object is its
    /// action's, borrowed by the action's future until the lane drops it, after the tick.
    /// What a cleanup needs to know (which axis moves, the last set point) belongs in the
    /// control system; the action's own locals are dropped with its future (a guard's
    /// `Drop` runs then, in the lane, not in the tick).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Step};
    /// struct Motor { speed: Cell<f32> }
    /// fn stop(m: &Motor) { m.speed.set(0.0) }
    /// struct Spin;
    /// impl Step<Motor> for Spin {
    ///     fn action(&mut self, cx: &Cx<'_, Motor>) -> Result<(), Failure> {
    ///         cx.control().speed.set(100.0);
    ///         Ok(())
    ///     }
    ///     // Spins until aborted.
    ///     fn check_exit_condition(&mut self, _cx: &Cx<'_, Motor>) -> bool { false }
    /// }
    /// struct Main(Seq<Spin>);
    /// impl Sequence<Motor> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Motor>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Motor, 2> = Sequencer::new();
    /// let spin = seq.add(SeqConfig::new("spin").on_abort(stop), Spin).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(spin)).unwrap();
    /// let (id, motor) = (main.id(), Motor { speed: Cell::new(0.0) });
    /// let mut sim = Sim::new(&seq, &motor, Monitors::<Motor, 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.run_for(Duration::from_millis(5));
    /// assert_eq!(motor.speed.get(), 100.0);
    /// sim.abort(id).unwrap(); // aborts `spin` too, which runs its hook
    /// sim.step();
    /// assert_eq!(motor.speed.get(), 0.0);
    /// assert_eq!(sim.state(id), RunningState::Aborted);
    /// # }
    /// ```
    pub const fn on_abort(mut self, hook: fn(&C)) -> Self {
        self.on_abort = Some(hook);
        self
    }

    /// The sequence runs in a lane of its own (the seed: a sequence started non-blocking
    /// runs in a thread of its own). [`Sequencer::install`](crate::Sequencer::install) and
    /// [`Sequencer::register`](crate::Sequencer::register) give it its lane slot, as
    /// [`Handle::declare_lane`](crate::Handle::declare_lane) would; its lane future
    /// ([`lane`](fn@crate::lane)) must still be polled by a task. A table whose lanes are
    /// declared here can be checked whole at compile time ([`Table::validate`](crate::Table::validate)).
    ///
    /// ```
    /// use rtseq::{Error, SeqConfig, Sequencer, Table};
    /// static TABLE: Table<(), 2> = match Table::new([
    ///     SeqConfig::new("main").in_lane(),
    ///     SeqConfig::new("safe stop").in_lane(),
    /// ]) {
    ///     Ok(t) => t,
    ///     Err(e) => panic!("{}", e.message().as_str()),
    /// };
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.install(&TABLE).unwrap();
    /// let main = seq.sequence_by_name("main").unwrap();
    /// assert_eq!(main.start(), Ok(())); // it has a lane: a non-blocking start is taken
    /// // With one lane slot, the table does not fit: nothing is installed.
    /// let small: Sequencer<(), 2, 64, rtseq::lock::CriticalSection, 1> = Sequencer::new();
    /// let safe_stop = rtseq::SeqId::from_index(1);
    /// assert_eq!(small.install(&TABLE), Err(Error::LaneCapacityExceeded(safe_stop)));
    /// assert_eq!(small.len(), 0);
    /// ```
    pub const fn in_lane(mut self) -> Self {
        self.in_lane = true;
        self
    }
}
