//! Handles: inspect and command a registered sequence from anywhere.

use crate::model::id::RunId;
use crate::sequencer::port::Port;
#[cfg(feature = "counters")]
use crate::Counters;
use crate::{
    Cause, Duration, Error, Outcome, Request, Requester, RunningState, SeqId, Sequencer, MAX_DEPTH,
};

/// A callers list (`callerStack` or `callerStackBlocking`), outermost first.
///
/// A `heapless::Vec` of [`MAX_DEPTH`] ids: no allocation, and room for
/// every caller chain the sequencer accepts.
///
/// ```
/// use rtseq::{CallerStack, SeqConfig, Sequencer, MAX_DEPTH};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let main = seq.sequence_by_id(seq.register(SeqConfig::new("main")).unwrap()).unwrap();
/// let callers: CallerStack = main.caller_stack();
/// assert!(callers.is_empty()); // a main sequence has no caller
/// assert_eq!(callers.capacity(), MAX_DEPTH);
/// ```
pub type CallerStack = heapless::Vec<SeqId, MAX_DEPTH>;

/// A handle to one registered sequence: state, callers, exceptions, counters; start, pause,
/// resume, abort.
///
/// Commands that stop or hold a sequence (pause, resume, abort) are requests applied by the
/// next tick, so every such transition happens in one place at a well-defined time.
///
/// ```
/// use rtseq::{RunningState, SeqConfig, Sequencer};
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let id = seq.register(SeqConfig::new("homing")).unwrap();
/// let h = seq.sequence_by_id(id).unwrap();
/// assert_eq!(h.name(), "homing");
/// assert_eq!(h.state(), RunningState::Idle);
/// assert!(h.caller().is_none());
/// assert!(h.pause().is_err()); // not running
/// ```
#[derive(Clone, Copy)]
pub struct Handle<'a, C> {
    port: &'a dyn Port<C>,
    id: SeqId,
    /// Who makes this handle's starts and requests.
    user: User,
}

/// Who uses a [`Handle`].
#[derive(Clone, Copy)]
enum User {
    /// The application (a handle from the sequencer).
    Application,
    /// A run of a sequence, through a handle from its context: its starts are refused
    /// when its own would be.
    Run(RunId),
}

impl User {
    /// Who makes the requests, as the trace records it.
    fn requester(self) -> Requester {
        match self {
            User::Application => Requester::Application,
            User::Run(run) => Requester::Sequence(run.seq),
        }
    }
}

impl<'a, C> Handle<'a, C> {
    pub(crate) fn new<
        const N: usize,
        const T: usize,
        L: crate::lock::Lock,
        const W: usize,
        const B: usize,
    >(
        seq: &'a Sequencer<C, N, T, L, W, B>,
        id: SeqId,
    ) -> Self {
        Handle {
            port: seq,
            id,
            user: User::Application,
        }
    }

    /// A handle of sequence `id` for the run `by` (from its context).
    pub(crate) fn for_run(port: &'a dyn Port<C>, id: SeqId, by: RunId) -> Self {
        Handle {
            port,
            id,
            user: User::Run(by),
        }
    }

    /// The sequence's id.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let homing = seq.register(SeqConfig::new("homing")).unwrap();
    /// assert_eq!(seq.sequence_by_name("homing").unwrap().id(), homing);
    /// ```
    pub fn id(&self) -> SeqId {
        self.id
    }

    /// The registered name.
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("homing")).unwrap();
    /// assert_eq!(seq.sequence_by_id(id).unwrap().name(), "homing");
    /// ```
    pub fn name(&self) -> &'static str {
        self.port.info(self.id).map_or("", |i| i.name)
    }

    /// The current running state.
    ///
    /// A sequence that runs a 5 ms dwell, on the host simulator:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// assert_eq!(h.state(), RunningState::Idle);
    /// sim.start(h.id()).unwrap();
    /// assert_eq!(h.state(), RunningState::Running);
    /// sim.run_for(Duration::from_millis(5));
    /// assert_eq!(h.state(), RunningState::Terminated);
    /// # }
    /// ```
    pub fn state(&self) -> RunningState {
        self.port
            .info(self.id)
            .map_or(RunningState::Idle, |i| i.state)
    }

    /// `callerSequence`: who started the current (or last) run; `None` for a main sequence.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let w = wait.id();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let m = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(m).unwrap();
    /// assert_eq!(sim.handle(w).unwrap().caller(), Some(m));
    /// assert_eq!(sim.handle(m).unwrap().caller(), None); // started by a handle: a main sequence
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(sim.handle(w).unwrap().caller(), Some(m)); // the last run's caller
    /// # }
    /// ```
    pub fn caller(&self) -> Option<SeqId> {
        self.port.info(self.id).and_then(|i| i.caller)
    }

    /// `callerStack`: all callers up to the main sequence, outermost first, not itself.
    ///
    /// Main runs `axis` blocking, which steps `settle`:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Axis(Seq<Wait>);
    /// impl Sequence<()> for Axis {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(Seq<Axis>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.run(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let settle = Wait::new(Duration::from_millis(5));
    /// let settle = seq.add(SeqConfig::new("settle"), settle).unwrap();
    /// let s = settle.id();
    /// let axis = seq.add(SeqConfig::new("axis"), Axis(settle)).unwrap();
    /// let a = axis.id();
    /// let main = seq.add(SeqConfig::new("main"), Main(axis)).unwrap();
    /// let m = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(m).unwrap();
    /// assert_eq!(sim.handle(s).unwrap().caller_stack(), [m, a]);
    /// assert_eq!(sim.handle(a).unwrap().caller_stack(), [m]);
    /// # }
    /// ```
    pub fn caller_stack(&self) -> CallerStack {
        self.callers().0
    }

    /// `callerStackBlocking`: the callers this sequence blocks (up to the first
    /// non-blocking start), outermost first.
    ///
    /// Main starts `blink` non-blocking (in its own lane) and joins it; `blink` steps `on`. `on`
    /// blocks `blink`, but not `main`:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, SeqId, Sequence,
    ///             Sequencer, Wait};
    /// struct Blink(Seq<Wait>);
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(SeqId);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         if cx.start(self.0).is_ok() {
    ///             let _ = cx.join(self.0).await;
    ///         }
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let on = seq.add(SeqConfig::new("on"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let o = on.id();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink(on)).unwrap();
    /// let b = blink.id();
    /// let main = seq.add(SeqConfig::new("main"), Main(b)).unwrap();
    /// let m = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.lane(blink);
    /// sim.start(m).unwrap();
    /// let on = sim.handle(o).unwrap();
    /// assert_eq!(on.caller_stack(), [m, b]);
    /// assert_eq!(on.caller_stack_blocking(), [b]);
    /// assert!(sim.handle(b).unwrap().caller_stack_blocking().is_empty());
    /// # }
    /// ```
    pub fn caller_stack_blocking(&self) -> CallerStack {
        let (stack, blocking) = self.callers();
        let skip = stack.len().saturating_sub(usize::from(blocking));
        stack.iter().skip(skip).copied().collect()
    }

    /// The caller stack, outermost first, and how many of its innermost callers this
    /// sequence blocks (those in its lane). One short section per caller: a stack the tick
    /// relinks meanwhile may mix old and new links.
    fn callers(&self) -> (CallerStack, u8) {
        let mut stack = CallerStack::new();
        let Some(me) = self.port.info(self.id) else {
            return (stack, 0);
        };
        // Innermost first; the blocking callers are the innermost ones in this lane.
        let (mut up, mut blocking, mut blocked) = (me.caller, true, 0u8);
        for _ in 0..MAX_DEPTH {
            let Some(c) = up else { break };
            // At most MAX_DEPTH pushes: every one fits.
            let _ = stack.push(c);
            let (next, lane) = self
                .port
                .info(c)
                .map_or((None, None), |i| (i.caller, Some(i.lane)));
            blocking &= lane == Some(me.lane);
            if blocking {
                blocked = blocked.saturating_add(1);
            }
            up = next;
        }
        stack.reverse();
        (stack, blocked)
    }

    /// `exceptionIsActive`: a monitor of this sequence fired and is being handled, or this
    /// sequence was aborted, or is being restarted, because of it: the owner of the monitor,
    /// and its caller when the behaviour is one of the `…CallerOfOwner` (once stopped,
    /// right after its cleanup hook, before the lanes its stop wakes run: a lane of
    /// higher priority than the tick that runs during the hook reads it stopped and not
    /// yet marked; while the exception sequence runs only the owner's is set; sequences
    /// below the behaviour's target are aborted by the teardown from above, not marked). The restarted run begins
    /// without it (it is not held), and so does a new start (not one refused); an abort
    /// for another cause during the exception (an abort-all, an abort request, a teardown
    /// from above) ends it too. [`active_exception`] keeps naming the last exception until
    /// a new start.
    ///
    /// [`active_exception`]: Handle::active_exception
    ///
    /// A sequence whose 3 ms timeout fires during a 10 ms dwell (the timeout's default behaviour
    /// aborts it):
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let cfg = SeqConfig::new("main").timeout(Duration::from_millis(3));
    /// let main = seq.add(cfg, Dwell(wait)).unwrap();
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(h.id()).unwrap();
    /// assert!(!h.exception_is_active());
    /// sim.run_for(Duration::from_millis(3));
    /// assert_eq!(h.state(), RunningState::Aborted);
    /// assert!(h.exception_is_active());
    /// # }
    /// ```
    pub fn exception_is_active(&self) -> bool {
        self.port.info(self.id).is_some_and(|i| i.exception_active)
    }

    /// `activeException`: the monitor or timeout of the active (or last) exception.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence,
    ///             Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let cfg = SeqConfig::new("main").timeout(Duration::from_millis(3));
    /// let main = seq.add(cfg, Dwell(wait)).unwrap();
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(h.id()).unwrap();
    /// assert_eq!(h.active_exception(), None);
    /// sim.run_for(Duration::from_millis(3));
    /// assert_eq!(h.active_exception(), Some(Cause::Timeout(h.id())));
    /// # }
    /// ```
    pub fn active_exception(&self) -> Option<Cause> {
        self.port.info(self.id).and_then(|i| i.active_exception)
    }

    /// Runs, completions, skips, failures, aborts, restarts, exceptions (feature
    /// `counters`).
    ///
    /// A sequence guarded by a pre-condition, started once with it false and once with it true:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// struct Guarded;
    /// impl Sequence<Cell<bool>> for Guarded {
    ///     async fn action(&mut self, _cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> { Ok(()) }
    ///     fn check_pre_condition(&mut self, cx: &Cx<'_, Cell<bool>>) -> bool {
    ///         cx.control().get()
    ///     }
    /// }
    /// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
    /// let guarded = seq.add(SeqConfig::new("guarded"), Guarded).unwrap();
    /// let h = seq.sequence_by_id(guarded.id()).unwrap();
    /// let ready = Cell::new(false);
    /// let mut sim = Sim::new(&seq, &ready, Monitors::<Cell<bool>, 1>::new());
    /// sim.lane(guarded);
    /// sim.start(h.id()).unwrap();
    /// ready.set(true);
    /// sim.start(h.id()).unwrap();
    /// let c = h.counters();
    /// assert_eq!((c.runs, c.skipped, c.completed, c.aborts), (2, 1, 1, 0));
    /// # }
    /// ```
    #[cfg_attr(docsrs, doc(cfg(feature = "counters")))]
    #[cfg(feature = "counters")]
    pub fn counters(&self) -> Counters {
        self.port
            .info(self.id)
            .map(|i| i.counters)
            .unwrap_or_default()
    }

    /// The outcome of the last finished run.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, Outcome, SeqConfig, Sequence, Sequencer};
    /// struct Guarded;
    /// impl Sequence<Cell<bool>> for Guarded {
    ///     async fn action(&mut self, _cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> { Ok(()) }
    ///     fn check_pre_condition(&mut self, cx: &Cx<'_, Cell<bool>>) -> bool {
    ///         cx.control().get()
    ///     }
    /// }
    /// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
    /// let guarded = seq.add(SeqConfig::new("guarded"), Guarded).unwrap();
    /// let h = seq.sequence_by_id(guarded.id()).unwrap();
    /// let ready = Cell::new(false);
    /// let mut sim = Sim::new(&seq, &ready, Monitors::<Cell<bool>, 1>::new());
    /// sim.lane(guarded);
    /// assert_eq!(h.last_outcome(), None); // never ran
    /// sim.start(h.id()).unwrap();
    /// assert_eq!(h.last_outcome(), Some(Outcome::Skipped)); // pre-condition false
    /// ready.set(true);
    /// sim.start(h.id()).unwrap();
    /// assert_eq!(h.last_outcome(), Some(Outcome::Completed));
    /// # }
    /// ```
    pub fn last_outcome(&self) -> Option<Outcome> {
        self.port.info(self.id).and_then(|i| i.outcome)
    }

    /// Starts the sequence non-blocking in its lane, as a main sequence (no caller).
    /// Through the application's handle, while an abort-all waits for the tick, the start
    /// is taken and its run holds before its pre-condition until the tick aborts it with
    /// the rest. Through a handle of a context
    /// ([`Cx::sequence_by_id`](crate::Cx::sequence_by_id),
    /// [`Cx::sequence_by_name`](crate::Cx::sequence_by_name)) the start is the context's
    /// sequence's own: refused with [`Error::NotRunning`] (the context's id) as its
    /// starts are, once the tick stopped its run, its abort is requested or an abort-all
    /// waits. Only that run is checked: the main sequence is not below it (an abort of it,
    /// or of its callers, does not take the main sequence down), and a condition's
    /// handle may start it (it runs in its own lane).
    ///
    /// A start needs a lane to run the sequence (here declared, as RTIC's `init` would before
    /// the lane tasks run):
    ///
    /// ```
    /// use rtseq::{Error, RunningState, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("blink")).unwrap();
    /// let h = seq.sequence_by_id(id).unwrap();
    /// assert_eq!(h.start(), Err(Error::NoLane(id)));
    /// h.declare_lane().unwrap();
    /// assert_eq!(h.start(), Ok(()));
    /// assert_eq!(h.state(), RunningState::Running);
    /// assert_eq!(h.start(), Err(Error::AlreadyRunning(id)));
    /// ```
    pub fn start(&self) -> Result<(), Error> {
        match self.user {
            User::Application => self.port.start_main(self.id),
            User::Run(by) => self.port.start_main_by(self.id, by),
        }
        .map(|_| ())
    }

    /// Requests a pause of the sequence and its blocking children (next tick). Of a pause
    /// and a resume requested before the same tick, the later counts: a pause while a
    /// resume is pending takes it back (but a resume while a `PauseOwner` monitor holds
    /// the sequence is refused, [`Error::HeldByMonitor`], and takes back nothing). A
    /// sequence paused by a pause request already, with no resume pending, gives
    /// [`Error::AlreadyPaused`]. One held paused by something else
    /// (a `PauseOwner` monitor, the paused caller it blocks) takes the request: it stays
    /// paused when that hold ends, until a resume request. A sequence that is not running
    /// or paused (idle, ended, or between two rounds: `Restarting`, `Aborting`) gives
    /// [`Error::NotRunning`]; a `Restarting` blocking child below a paused caller begins
    /// its next round paused anyway.
    ///
    /// A pause is of the round it was asked in: one accepted while the sequence handles an
    /// exception whose behaviour then restarts it goes with that round, and the restarted
    /// round runs unpaused (the trace shows the request and no pause; a resume then gives
    /// [`Error::NotPaused`]). To hold a sequence across its restarts, ask again once it
    /// runs, or hold it with a `PauseOwner` monitor, which evaluates every round.
    ///
    /// A pause holds the sequences, not the machine: their actions stop at their next
    /// await point, but what their steps commanded goes on (a speed, a trajectory). A feed
    /// hold holds the motion in the control system too, before the pause: the motor demo's
    /// `feed hold` exception sequence has the control system decelerate the move and keep
    /// it, then pauses the moves; `feed resume` continues the move, then resumes them. A
    /// `PauseOwner` monitor's exception sequence can hold it the same way
    /// ([`Behaviour::PauseOwner`](crate::Behaviour::PauseOwner)). A stop the machine must
    /// make whatever the sequences do belongs to the safety system (a safety event).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Error, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let w = wait.id();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// assert_eq!(h.pause(), Err(Error::NotRunning(h.id())));
    /// sim.start(h.id()).unwrap();
    /// h.pause().unwrap();
    /// assert_eq!(h.state(), RunningState::Running); // until the next tick
    /// sim.step();
    /// assert_eq!(h.state(), RunningState::Paused);
    /// // With the step it blocks:
    /// assert_eq!(seq.sequence_by_id(w).unwrap().state(), RunningState::Paused);
    /// # }
    /// ```
    pub fn pause(&self) -> Result<(), Error> {
        self.port
            .request(self.id, Request::Pause, self.user.requester())
    }

    /// Requests that a paused sequence resume where it stopped (next tick). A resume while a
    /// pause is pending takes the pause back (the sequence does not pause). While a
    /// `PauseOwner` monitor holds the sequence a resume is refused
    /// ([`Error::HeldByMonitor`]) and takes back nothing, not even a pending pause: a
    /// pause requested before keeps the sequence paused after the release, until a resume
    /// then.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Error, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
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
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(h.id()).unwrap();
    /// assert_eq!(h.resume(), Err(Error::NotPaused(h.id())));
    /// h.pause().unwrap();
    /// sim.step(); // 1 ms: paused
    /// h.resume().unwrap();
    /// sim.step(); // 2 ms: running again
    /// assert_eq!(h.state(), RunningState::Running);
    /// # }
    /// ```
    pub fn resume(&self) -> Result<(), Error> {
        self.port
            .request(self.id, Request::Resume, self.user.requester())
    }

    /// Requests an abort of the sequence and all its sub-sequences (next tick). Until the
    /// tick carries it out, the sequence begins nothing more (a start it makes is refused,
    /// with [`Error::NotRunning`] if nothing else refuses it; a blocking start holds its
    /// action instead of returning) and its run does not end: it is aborted (semantics
    /// item 8 in docs/semantics.md).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, Outcome, RunningState, Seq,
    ///             SeqConfig, Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let w = wait.id();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let h = seq.sequence_by_id(main.id()).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(h.id()).unwrap();
    /// h.abort().unwrap();
    /// sim.step();
    /// assert_eq!(h.state(), RunningState::Aborted);
    /// assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    /// assert_eq!(seq.sequence_by_id(w).unwrap().state(), RunningState::Aborted); // with its step
    /// # }
    /// ```
    pub fn abort(&self) -> Result<(), Error> {
        self.port
            .request(self.id, Request::Abort, self.user.requester())
    }

    /// Sets (or with `None` switches off) the timeout monitor, like EEROS's
    /// `setTimeoutTime`: at once for a run under way whose timeout is armed (measured from
    /// its start, paused time not counted; `None` switches it off for that run too),
    /// otherwise from the next start or restart. The limits are
    /// [`SeqConfig::timeout`](crate::SeqConfig::timeout)'s.
    ///
    /// ```
    /// use rtseq::{Duration, Error, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let h = seq.sequence_by_id(seq.register(SeqConfig::new("move")).unwrap()).unwrap();
    /// assert_eq!(h.set_timeout(Some(Duration::from_secs(2))), Ok(()));
    /// assert_eq!(h.set_timeout(Some(Duration::from_ticks(0))), Err(Error::DurationOutOfRange));
    /// ```
    pub fn set_timeout(&self, timeout: Option<Duration>) -> Result<(), Error> {
        let micros = match timeout {
            Some(t) => crate::model::time::to_interval(t).ok_or(Error::DurationOutOfRange)?,
            None => 0,
        };
        self.port.set_timeout(self.id, micros)
    }

    /// Declares that a lane runs this sequence, so it can be started non-blocking before the
    /// lane first ran (e.g. from RTIC `init`). [`lane`](fn@crate::lane) declares it too.
    ///
    /// A sequencer with one lane slot (`W` = 1):
    ///
    /// ```
    /// use rtseq::{lock::CriticalSection, Error, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    /// let blink = seq.register(SeqConfig::new("blink")).unwrap();
    /// let fan = seq.register(SeqConfig::new("fan")).unwrap();
    /// let h = seq.sequence_by_id(blink).unwrap();
    /// assert_eq!(h.declare_lane(), Ok(()));
    /// assert_eq!(h.declare_lane(), Ok(())); // already has the slot
    /// let fan_lane = seq.sequence_by_id(fan).unwrap().declare_lane();
    /// assert_eq!(fan_lane, Err(Error::LaneCapacityExceeded(fan)));
    /// ```
    pub fn declare_lane(&self) -> Result<(), Error> {
        self.port.declare_lane(self.id).map(|_| ())
    }
}
