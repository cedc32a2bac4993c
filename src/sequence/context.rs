//! The context every action and condition method receives.

use core::cell::Cell;
use core::task::Poll;

use core::future::Future;

use crate::model::id::RunId;
use crate::sequence::erased::{sequence_run, ErasedBody, StepRun};
use crate::sequence::run::Run;
use crate::sequence::scoped::Scoped;
use crate::sequence::SeqHead;
use crate::sequencer::clearance::Clearance;
use crate::sequencer::port::Port;
use crate::{Done, Duration, Error, Failure, Handle, Instant, Outcome, Seq, SeqId, Sequence, Step};

/// What a running sequence or step sees: its id, the time, typed access to the control
/// system, and the sequencer (start, join and inspect other sequences).
///
/// Its futures ([`run`](Self::run), [`step`](Self::step), [`join`](Self::join),
/// [`wait_until`](Self::wait_until), [`Scoped::join`]) are awaited in the action. They keep
/// no waker of their own: they are woken through their lane, whose waker the lane's run
/// keeps each time it polls the action. So a combinator inside an action must poll every
/// branch when the task is woken, as embassy-futures' `join` and `select` do; one that
/// gives each branch a waker of its own and polls only the woken ones (`FuturesUnordered`)
/// misses wake-ups. A condition looks, an action acts: from a pre- or exit condition, or
/// the condition of a polled wait ([`wait_until`](Self::wait_until)), every start
/// ([`run`](Self::run), [`step`](Self::step), [`start`](Self::start),
/// [`start_scoped`](Self::start_scoped)) is refused with [`Error::OutsideAction`] (a
/// blocking run starts where it is first polled, so its future borrows the context: one
/// first polled in a condition is refused there, wherever it was made). Polled
/// there (`poll_once`), a join still says whether its run is over, and a polled wait only
/// waits; a condition asks a [`Handle`] instead.
///
/// A main sequence that starts a status blinker non-blocking, runs a move blocking, and
/// waits for the blinker:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use core::cell::Cell;
/// use rtseq::sim::Sim;
/// use rtseq::{Cx, Done, Duration, Failure, Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence,
///             Sequencer, Wait};
/// #[derive(Default)]
/// struct Ctrl { blinks: Cell<u32> }
/// struct Blink { dwell: Seq<Wait> }
/// impl Sequence<Ctrl> for Blink {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
///         for _ in 0..3 {
///             let _ = cx.step(&mut self.dwell).await;
///             cx.control().blinks.set(cx.control().blinks.get() + 1);
///         }
///         Ok(())
///     }
/// }
/// struct Main { blink: SeqId, dwell: Seq<Wait> }
/// impl Sequence<Ctrl> for Main {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
///         cx.start(self.blink).unwrap();                       // non-blocking
///         assert_eq!(cx.step(&mut self.dwell).await, Ok(Done::Completed)); // blocking
///         assert_eq!(cx.join(self.blink).await, Ok(Outcome::Completed));
///         assert_eq!(cx.sequence_by_id(self.blink).unwrap().caller(), Some(cx.id()));
///         Ok(())
///     }
/// }
/// let seq: Sequencer<Ctrl, 8> = Sequencer::new();
/// let ms = |n| Wait::new(Duration::from_millis(n));
/// let blink = seq
///     .add(SeqConfig::new("blink"), Blink { dwell: seq.add(SeqConfig::new("on/off"), ms(10)).unwrap() })
///     .unwrap();
/// let main = Main { blink: blink.id(), dwell: seq.add(SeqConfig::new("dwell"), ms(5)).unwrap() };
/// let main = seq.add(SeqConfig::new("main"), main).unwrap();
/// let (ctrl, id) = (Ctrl::default(), main.id());
/// let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
/// sim.lane(main);
/// sim.lane(blink);
/// sim.start(id).unwrap();
/// assert_eq!(sim.run_until_idle(Duration::from_millis(100)).map(|t| t.as_ticks()), Some(30_000));
/// assert_eq!(ctrl.blinks.get(), 3);
/// # }
/// ```
pub struct Cx<'a, C> {
    port: &'a dyn Port<C>,
    control: &'a C,
    id: SeqId,
    /// The run of this sequence the context acts for (its count): set when the run
    /// starts ([`enter`](Self::enter)), fixed while its action runs. Before the first run
    /// it is [`BEFORE_THE_FIRST_RUN`], which nothing reads: a run, its action and its
    /// conditions exist only once it started.
    run: Cell<u16>,
    /// Where its action stands: the count of its polled waits
    /// ([`wait_until`](Self::wait_until)) under way ([`WAIT_COUNT`]), [`ACTING`] and
    /// [`DUE_TAKEN`]; set anew for each round of a run ([`new_round`](Self::new_round)).
    action: Cell<u8>,
}

/// [`Cx::run`] before the first run: a context is made with its lane or its blocking run,
/// before the run it acts for is started (and counted).
const BEFORE_THE_FIRST_RUN: u16 = 0;

/// Bits of [`Cx::action`]: the count of polled waits under way. A count that reached its
/// top stays there until the round ends: the run then waits for polls until its end (a
/// spurious poll at most), never stops waiting while a wait is under way.
const WAIT_COUNT: u8 = 0x3F;
/// Bit of [`Cx::action`]: the action is being polled (not one of its conditions), so the
/// context may start sequences, and the polled waits made with it may count themselves
/// and take polls. Polled from a condition, they wait and touch nothing.
const ACTING: u8 = 1 << 6;
/// Bit of [`Cx::action`]: a polled wait took the due poll in the action's current poll.
const DUE_TAKEN: u8 = 1 << 7;

impl<'a, C> Cx<'a, C> {
    pub(crate) fn new(port: &'a dyn Port<C>, control: &'a C, id: SeqId) -> Self {
        Cx {
            port,
            control,
            id,
            run: Cell::new(BEFORE_THE_FIRST_RUN),
            action: Cell::new(0),
        }
    }

    /// A poll of the action begins: no polled wait has taken a due poll in it yet.
    pub(crate) fn begin_action_poll(&self) {
        self.action.set((self.action.get() & !DUE_TAKEN) | ACTING);
    }

    /// The poll of the action is over.
    pub(crate) fn end_action_poll(&self) {
        self.action.set(self.action.get() & !ACTING);
    }

    /// Whether the action is being polled: only then does the context start anything.
    pub(crate) fn acting(&self) -> bool {
        self.action.get() & ACTING != 0
    }

    /// Checks a polled wait's `condition` inside the action's poll: a condition looks, so
    /// the context starts nothing while it runs, as in a condition method.
    fn looking(&self, condition: impl FnOnce() -> bool) -> bool {
        let acting = self.action.get() & ACTING;
        self.action.set(self.action.get() & !ACTING);
        let holds = condition();
        self.action.set(self.action.get() | acting);
        holds
    }

    /// The run this context acts for: every await point and start of its action names
    /// it, so an action whose run is over never acts for a later run of its sequence.
    pub(crate) fn run_id(&self) -> RunId {
        RunId {
            seq: self.id,
            count: self.run.get(),
        }
    }

    /// From now on the context acts for `run` (of its sequence), which just started.
    pub(crate) fn enter(&self, run: RunId) {
        self.run.set(run.count);
        self.new_round();
    }

    /// A run begins (or begins again after a restart): none of its polled waits is under
    /// way. One of an earlier round that was leaked (`mem::forget`) is not counted.
    pub(crate) fn new_round(&self) {
        self.action.set(0);
    }

    pub(crate) fn port(&self) -> &'a dyn Port<C> {
        self.port
    }

    /// The id of the sequence this context belongs to.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, SeqId, Sequence, Sequencer};
    /// struct WhoAmI;
    /// impl Sequence<Cell<Option<SeqId>>> for WhoAmI {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<Option<SeqId>>>) -> Result<(), Failure> {
    ///         cx.control().set(Some(cx.id()));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<Option<SeqId>>, 2> = Sequencer::new();
    /// let who = seq.add(SeqConfig::new("who"), WhoAmI).unwrap();
    /// let (id, seen) = (who.id(), Cell::new(None));
    /// let mut sim = Sim::new(&seq, &seen, Monitors::<_, 1>::new());
    /// sim.lane(who);
    /// sim.start(id).unwrap();
    /// assert_eq!(seen.get(), Some(id));
    /// # }
    /// ```
    pub fn id(&self) -> SeqId {
        self.id
    }

    /// The application's control system.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::sync::atomic::{AtomicI32, Ordering::Relaxed};
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer, Step};
    /// struct Axis { setpoint: AtomicI32 }
    /// struct MoveTo(i32);
    /// impl Step<Axis> for MoveTo {
    ///     fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
    ///         cx.control().setpoint.store(self.0, Relaxed);
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(Seq<MoveTo>);
    /// impl Sequence<Axis> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Axis, 2> = Sequencer::new();
    /// let move_to = seq.add(SeqConfig::new("move to"), MoveTo(250)).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(move_to)).unwrap();
    /// let (id, axis) = (main.id(), Axis { setpoint: AtomicI32::new(0) });
    /// let mut sim = Sim::new(&seq, &axis, Monitors::<Axis, 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(axis.setpoint.load(Relaxed), 250);
    /// # }
    /// ```
    pub fn control(&self) -> &'a C {
        self.control
    }

    /// The sequencer time (the last tick's time).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Instant, Monitors, Seq, SeqConfig, Sequence,
    ///             Sequencer, Wait};
    /// struct Stamp(Seq<Wait>);
    /// impl Sequence<Cell<Instant>> for Stamp {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<Instant>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         cx.control().set(cx.now());
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<Instant>, 2> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3))).unwrap();
    /// let stamp = seq.add(SeqConfig::new("stamp"), Stamp(wait)).unwrap();
    /// let (id, done) = (stamp.id(), Cell::new(Instant::from_ticks(0)));
    /// let mut sim = Sim::new(&seq, &done, Monitors::<_, 1>::new());
    /// sim.lane(stamp);
    /// sim.run_for(Duration::from_millis(10));
    /// sim.start(id).unwrap(); // at 10 ms
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(done.get(), Instant::from_ticks(13_000));
    /// # }
    /// ```
    pub fn now(&self) -> Instant {
        self.port.now()
    }

    /// How long this run has run, not counting the time it was paused: the time its
    /// timeout counts, and what [`Wait`](crate::Wait) waits for. A start and a restart
    /// begin at zero. As sequencer time (the last tick's), exact for runs of up to 2^48 µs
    /// (about 8.9 years).
    ///
    /// A step that records its run time whenever its exit condition is checked; its caller
    /// is paused and resumed (the ticks at 3 ms and 6 ms apply the requests), and the step
    /// with it:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use std::cell::RefCell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Step};
    /// struct Log;
    /// impl Step<RefCell<Vec<u64>>> for Log {
    ///     fn action(&mut self, _: &Cx<'_, RefCell<Vec<u64>>>) -> Result<(), Failure> { Ok(()) }
    ///     fn check_exit_condition(&mut self, cx: &Cx<'_, RefCell<Vec<u64>>>) -> bool {
    ///         cx.control().borrow_mut().push(cx.run_time().as_millis());
    ///         cx.now().duration_since_epoch().as_millis() >= 7
    ///     }
    /// }
    /// struct Main(Seq<Log>);
    /// impl Sequence<RefCell<Vec<u64>>> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, RefCell<Vec<u64>>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<RefCell<Vec<u64>>, 2> = Sequencer::new();
    /// let log = seq.add(SeqConfig::new("log"), Log).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(log)).unwrap();
    /// let (id, times) = (main.id(), RefCell::new(Vec::new()));
    /// let mut sim = Sim::new(&seq, &times, Monitors::<_, 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// let h = seq.sequence_by_id(id).unwrap();
    /// sim.run_for(Duration::from_millis(2));
    /// h.pause().unwrap();
    /// sim.run_for(Duration::from_millis(3));
    /// h.resume().unwrap();
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// // Checked at 0, 1, 2, then 6 and 7 ms of sequencer time.
    /// assert_eq!(*times.borrow(), [0, 1, 2, 3, 4]);
    /// # }
    /// ```
    pub fn run_time(&self) -> Duration {
        Duration::from_ticks(self.port.run_time(self.id))
    }

    /// Starts `child` **blocking**: it runs inside this sequence's future and this sequence
    /// waits for its outcome. The start is made at the future's first poll: errors if
    /// `child` is already running, and with [`Error::OutsideAction`] when that poll comes
    /// from a condition (a pre- or exit condition, a polled wait's), wherever the future
    /// was made; polled again, the future gives the same result. Once started, the run
    /// advances only where the action polls it: polled from a condition, it does not move
    /// (it would run the child's action there). Refused because
    /// this sequence may not go on (the tick stopped it while its action ran on, its
    /// abort is requested or an abort-all waits: [`Error::NotRunning`], as
    /// [`start`](Self::start)), the refusal is handed over as an end is, only when the
    /// action may advance: an action aborted meanwhile never sees it.
    ///
    /// If this sequence is aborted or paused meanwhile, or handles an exception, the call
    /// does not return into the action until it may advance again (sticky abort: an
    /// aborted action never resumes); the child holds with it.
    ///
    /// The returned future borrows `child` and this context (its first poll asks the
    /// context whether the action is being polled), so a hand-written action future that
    /// holds it borrows the context too.
    ///
    /// Main runs `axis` (a 4 ms dwell) blocking and gets its outcome when it ended:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Done, Duration, Failure, Monitors, Seq, SeqConfig, Sequence,
    ///             Sequencer, Wait};
    /// type Got = Cell<Option<(Result<Done, Failure>, u64)>>;
    /// struct Axis(Seq<Wait>);
    /// impl Sequence<Got> for Axis {
    ///     async fn action(&mut self, cx: &Cx<'_, Got>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(Seq<Axis>);
    /// impl Sequence<Got> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Got>) -> Result<(), Failure> {
    ///         let outcome = cx.run(&mut self.0).await;
    ///         cx.control().set(Some((outcome, cx.now().as_ticks())));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Got, 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(4))).unwrap();
    /// let axis = seq.add(SeqConfig::new("axis"), Axis(wait)).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(axis)).unwrap();
    /// let (id, got) = (main.id(), Got::default());
    /// let mut sim = Sim::new(&seq, &got, Monitors::<Got, 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(got.get(), Some((Ok(Done::Completed), 4_000)));
    /// # }
    /// ```
    pub fn run<'c, 's, S: Sequence<C>>(
        &'c self,
        child: &'s mut Seq<S>,
    ) -> impl Future<Output = Result<Done, Failure>> + use<'a, 'c, 's, C, S> {
        sequence_run(self.blocking_run(child.head.id), child)
    }

    /// Starts `step` (always blocking): its command, then its exit condition every polling
    /// period. Started at the future's first poll, as [`run`](Self::run) is.
    ///
    /// A step whose pre-condition is false is skipped: its action does not run.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Done, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Step};
    /// #[derive(Default)]
    /// struct Drive { enabled: Cell<bool>, ran: Cell<bool>, got: Cell<Option<Done>> }
    /// struct Spin;
    /// impl Step<Drive> for Spin {
    ///     fn check_pre_condition(&mut self, cx: &Cx<'_, Drive>) -> bool {
    ///         cx.control().enabled.get()
    ///     }
    ///     fn action(&mut self, cx: &Cx<'_, Drive>) -> Result<(), Failure> {
    ///         cx.control().ran.set(true);
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(Seq<Spin>);
    /// impl Sequence<Drive> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Drive>) -> Result<(), Failure> {
    ///         cx.control().got.set(cx.step(&mut self.0).await.ok());
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Drive, 2> = Sequencer::new();
    /// let spin = seq.add(SeqConfig::new("spin"), Spin).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(spin)).unwrap();
    /// let (id, drive) = (main.id(), Drive::default());
    /// let mut sim = Sim::new(&seq, &drive, Monitors::<Drive, 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!((drive.got.get(), drive.ran.get()), (Some(Done::Skipped), false));
    /// drive.enabled.set(true);
    /// sim.start(id).unwrap();
    /// assert_eq!((drive.got.get(), drive.ran.get()), (Some(Done::Completed), true));
    /// # }
    /// ```
    pub fn step<'c, 's, S: Step<C>>(
        &'c self,
        step: &'s mut Seq<S>,
    ) -> impl Future<Output = Result<Done, Failure>> + use<'a, 'c, 's, C, S> {
        let Seq { head, body } = step;
        self.step_run(head, ErasedBody::of_step(body))
    }

    /// A blocking run of a step of any type: one future type, one copy of its code.
    fn step_run<'c, 's>(
        &'c self,
        head: &'s SeqHead,
        step: ErasedBody<'s, C>,
    ) -> StepRun<'c, 's, C> {
        StepRun {
            run: self.blocking_run(head.id),
            head,
            step,
        }
    }

    /// A blocking run, by this sequence, of the sequence or step `id`; one first polled
    /// outside the action's poll (from a condition) is refused there.
    fn blocking_run<'c>(&'c self, id: SeqId) -> Run<'c, C> {
        Run::blocking(Cx::new(self.port, self.control, id), self)
    }

    /// Starts sequence `id` **non-blocking** in its lane; this sequence continues. Errors if
    /// it is already running or has no lane, and with [`Error::NotRunning`] (this
    /// sequence's id) if the tick stopped this sequence while its action ran on (a tick
    /// preempts the lanes), or its abort is requested or an abort-all waits (the tick has
    /// not carried it out yet): nothing an action starts outlives its abort. From a
    /// condition (a pre- or exit condition, a polled wait's) it is [`Error::OutsideAction`]
    /// (with `id`, the sequence whose start was refused). It does outlive this sequence's
    /// end, a failure through `?` included: to end it with the action, start it with
    /// [`start_scoped`](Self::start_scoped).
    ///
    /// `blink` has a lane, `fan` has none:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Error, Failure, Monitors, SeqConfig, SeqId, Sequence, Sequencer};
    /// type Got = Cell<Option<[Result<(), Error>; 2]>>;
    /// struct Blink;
    /// impl Sequence<Got> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, Got>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// struct Main { blink: SeqId, fan: SeqId }
    /// impl Sequence<Got> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Got>) -> Result<(), Failure> {
    ///         cx.control().set(Some([cx.start(self.blink), cx.start(self.fan)]));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Got, 4> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let fan = seq.register(SeqConfig::new("fan")).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main { blink: blink.id(), fan }).unwrap();
    /// let (id, blink_id, got) = (main.id(), blink.id(), Got::default());
    /// let mut sim = Sim::new(&seq, &got, Monitors::<Got, 1>::new());
    /// sim.lane(main);
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// assert_eq!(got.get(), Some([Ok(()), Err(Error::NoLane(fan))]));
    /// assert_eq!(sim.handle(blink_id).unwrap().caller(), Some(id));
    /// # }
    /// ```
    pub fn start(&self, id: SeqId) -> Result<(), Error> {
        if !self.acting() {
            return Err(Error::OutsideAction(id));
        }
        self.port.start_child(id, self.run_id()).map(|_| ())
    }

    /// Starts sequence `id` **non-blocking** in its lane, as [`start`](Self::start) does,
    /// bound to the returned [`Scoped`]: when the action drops it (it returns, or fails
    /// through `?`) the next tick aborts the started run, if it has not ended; an abort or
    /// restart of this sequence takes it down as every child. [`Scoped::join`] waits for
    /// its end; [`Scoped::detach`] lets it run on. Bind the `Scoped` to a name
    /// (`let _conveyor = ...`): `let _ = ...` drops it at once. A [`Step`]'s action (a
    /// `fn`) drops it when it returns, before the exit condition is polled: a child that
    /// must live through a step is started by a sequence around it.
    ///
    /// A conveyor that runs while `main` works, and stops when `main` fails:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cause, Cx, Failure, Monitors, Outcome, RunningState, Seq, SeqConfig,
    ///             SeqId, Sequence, Sequencer, Step};
    /// struct Conveyor;
    /// impl Step<()> for Conveyor {
    ///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    ///     fn check_exit_condition(&mut self, _cx: &Cx<'_, ()>) -> bool { false }
    /// }
    /// struct Grip;
    /// impl Step<()> for Grip {
    ///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         Err(Failure::App(1)) // no part
    ///     }
    /// }
    /// struct Main { conveyor: SeqId, grip: Seq<Grip> }
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _conveyor = cx.start_scoped(self.conveyor)?;
    ///         cx.step(&mut self.grip).await?; // fails: `_conveyor` is dropped
    ///         Ok(())
    ///     }
    /// }
    /// struct Lane(Seq<Conveyor>);
    /// impl Sequence<()> for Lane {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         cx.step(&mut self.0).await?;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let belt = seq.add(SeqConfig::new("belt"), Conveyor).unwrap();
    /// let conveyor = seq.add(SeqConfig::new("conveyor"), Lane(belt)).unwrap();
    /// let grip = seq.add(SeqConfig::new("grip"), Grip).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main { conveyor: conveyor.id(), grip }).unwrap();
    /// let (id, c) = (main.id(), conveyor.id());
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.lane(conveyor);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.state(id), RunningState::Terminated); // failed
    /// assert_eq!(sim.state(c), RunningState::Running);     // until the next tick
    /// sim.step();
    /// assert_eq!(sim.state(c), RunningState::Aborted);
    /// assert_eq!(sim.handle(c).unwrap().last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    /// # }
    /// ```
    pub fn start_scoped(&self, id: SeqId) -> Result<Scoped<'a, C>, Error> {
        if !self.acting() {
            return Err(Error::OutsideAction(id));
        }
        let run = self.port.start_child(id, self.run_id())?;
        Ok(Scoped::new(self.port, self.run_id(), run))
    }

    /// Waits until non-blocking sequence `id` has ended and returns its outcome: that of
    /// the run under way at the first poll (or of the last run, if none is). If `id` is
    /// started again before this sequence is polled, the join still gets the joined run's
    /// outcome. If that new run has ended too (a lane of higher priority ran it), the
    /// control block, which keeps one outcome, holds the new run's: the join is then
    /// [`Error::OutcomeLost`], never the other run's outcome.
    ///
    /// Joins fail at once where they could never return: a join of a sequence never
    /// started ([`Error::NeverStarted`]), and one that would wait for itself
    /// ([`Error::JoinWouldDeadlock`]): a join of oneself, of a caller one blocks, of an
    /// exception sequence's owner or a blocking child of it (the exception holds them), or
    /// one that closes a cycle of joins (A joins B while B joins A, or through a blocking
    /// child), even if a timeout or monitor could abort one of them. A join dropped before it returned (the loser
    /// of a `select`) no longer waits:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Error, Failure, Monitors, Outcome, SeqConfig, SeqId, Sequence,
    ///             Sequencer};
    /// type Got = Cell<Option<[Result<Outcome, Error>; 3]>>;
    /// struct Blink;
    /// impl Sequence<Got> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, Got>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// struct Main { blink: SeqId }
    /// impl Sequence<Got> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Got>) -> Result<(), Failure> {
    ///         let never = cx.join(self.blink).await; // not started yet
    ///         let _ = cx.start(self.blink);
    ///         let joined = cx.join(self.blink).await;
    ///         let itself = cx.join(cx.id()).await;
    ///         cx.control().set(Some([never, joined, itself]));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Got, 4> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let b = blink.id();
    /// let main = seq.add(SeqConfig::new("main"), Main { blink: b }).unwrap();
    /// let (id, got) = (main.id(), Got::default());
    /// let mut sim = Sim::new(&seq, &got, Monitors::<Got, 1>::new());
    /// sim.lane(main);
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// assert_eq!(got.get(), Some([
    ///     Err(Error::NeverStarted(b)),
    ///     Ok(Outcome::Completed),
    ///     Err(Error::JoinWouldDeadlock(id)),
    /// ]));
    /// # }
    /// ```
    pub fn join(&self, id: SeqId) -> impl Future<Output = Result<Outcome, Error>> + use<'a, C> {
        Join {
            port: self.port,
            me: self.run_id(),
            joined: Joined::CurrentRunOf(id),
            waiting: false,
        }
    }

    /// Waits, without a control block of its own, until `condition` holds; it is checked now
    /// and then at this sequence's polling period. Prefer a [`Step`] with an exit condition
    /// where the wait deserves its own timeout or monitors.
    ///
    /// Wait for a limit switch that the plant model closes at 4 ms:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// #[derive(Default)]
    /// struct Ctrl { switch: Cell<bool>, at: Cell<u64> }
    /// struct Approach;
    /// impl Sequence<Ctrl> for Approach {
    ///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
    ///         cx.wait_until(|cx| cx.control().switch.get()).await;
    ///         cx.control().at.set(cx.now().as_ticks());
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    /// let approach = seq.add(SeqConfig::new("approach"), Approach).unwrap();
    /// let (id, ctrl) = (approach.id(), Ctrl::default());
    /// let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    /// sim.lane(approach);
    /// sim.before_tick(|t, c| c.switch.set(t.as_ticks() >= 4_000));
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(ctrl.at.get(), 4_000);
    /// # }
    /// ```
    ///
    /// Several polled waits of one action may be awaited at once (`select`, `join`): each
    /// checks its condition at every due poll.
    pub fn wait_until<'s, F: FnMut(&Self) -> bool + 's>(
        &'s self,
        condition: F,
    ) -> impl Future<Output = ()> + use<'s, 'a, C, F> {
        WaitUntil {
            cx: self,
            condition,
            stage: WaitStage::New,
        }
    }

    /// The seed's `getSafetySystem()`: trigger public events, read the level.
    ///
    /// The handle of the safety system built on the sequencer's
    /// [`safety_handle`](crate::Sequencer::safety_handle). `None`: no safety system is built
    /// on it (a firmware without one, or a system built on a handle of its own); an action
    /// that must reach the safety system fails then rather than go on:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::safety::*;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// static PROPS: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// const START_MOTORS: PublicEvent = PublicEvent::new(1);
    /// const NO_SAFETY_SYSTEM: u16 = 1; // the application's failure code
    /// struct PowerUp;
    /// impl Sequence<()> for PowerUp {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let safety = cx.safety_system().ok_or(Failure::App(NO_SAFETY_SYSTEM))?;
    ///         safety.trigger(START_MOTORS);
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let safety = SafetySystem::new(&PROPS, seq.safety_handle()).unwrap();
    /// let power_up = seq.add(SeqConfig::new("power up"), PowerUp).unwrap();
    /// let id = power_up.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(power_up);
    /// sim.start(id).unwrap();
    /// // The safety task's next cycle takes it.
    /// assert_eq!(seq.safety_handle().pending_events(), 1 << 1);
    /// # drop(safety);
    /// # }
    /// ```
    ///
    /// To go on once the safety system has taken the event, a step waits for the level it
    /// leads to in its exit condition (`cx.safety_system().is_some_and(|s| s.level() ==
    /// READY)`): the next safety cycle applies the event. A cleanup hook, which has no
    /// `Cx`, reaches the handle through the control system
    /// ([`Sequencer::safety_handle`](crate::Sequencer::safety_handle) is a `const fn`).
    pub fn safety_system(&self) -> Option<&'a crate::safety::SafetyHandle> {
        self.port.safety_system()
    }

    /// A handle to any registered sequence (the seed's `getSequenceByID`).
    ///
    /// Main starts `blink` non-blocking and reads its state:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig, SeqId,
    ///             Sequence, Sequencer, Wait};
    /// type Seen = Cell<Option<RunningState>>;
    /// struct Blink(Seq<Wait>);
    /// impl Sequence<Seen> for Blink {
    ///     async fn action(&mut self, cx: &Cx<'_, Seen>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(SeqId);
    /// impl Sequence<Seen> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Seen>) -> Result<(), Failure> {
    ///         let _ = cx.start(self.0);
    ///         cx.control().set(cx.sequence_by_id(self.0).map(|h| h.state()));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Seen, 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink(wait)).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(blink.id())).unwrap();
    /// let (id, seen) = (main.id(), Seen::default());
    /// let mut sim = Sim::new(&seq, &seen, Monitors::<Seen, 1>::new());
    /// sim.lane(main);
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// assert_eq!(seen.get(), Some(RunningState::Running));
    /// # }
    /// ```
    pub fn sequence_by_id(&self, id: SeqId) -> Option<Handle<'a, C>> {
        self.port
            .info(id)
            .map(|_| Handle::for_run(self.port, id, self.run_id()))
    }

    /// A handle to any registered sequence (the seed's `getSequenceByName`).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::sim::Sim;
    /// use rtseq::{Cx, Duration, Failure, Monitors, SeqConfig, SeqId, Sequence, Sequencer};
    /// struct Lookup;
    /// impl Sequence<Cell<Option<(SeqId, SeqId, bool)>>> for Lookup {
    ///     async fn action(
    ///         &mut self,
    ///         cx: &Cx<'_, Cell<Option<(SeqId, SeqId, bool)>>>,
    ///     ) -> Result<(), Failure> {
    ///         let id = |name| cx.sequence_by_name(name).map(|h| h.id());
    ///         if let (Some(me), Some(other)) = (id("lookup"), id("other")) {
    ///             cx.control().set(Some((me, other, id("nope").is_none())));
    ///         }
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<Option<(SeqId, SeqId, bool)>>, 4> = Sequencer::new();
    /// let other = seq.register(SeqConfig::new("other")).unwrap();
    /// let lookup = seq.add(SeqConfig::new("lookup"), Lookup).unwrap();
    /// let (found, id) = (Cell::new(None), lookup.id());
    /// let mut sim = Sim::new(&seq, &found, Monitors::<_, 1>::new());
    /// sim.lane(lookup);
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(found.get(), Some((id, other, true)));
    /// # }
    /// ```
    pub fn sequence_by_name(&self, name: &str) -> Option<Handle<'a, C>> {
        let id = self.port.find(name)?;
        Some(Handle::for_run(self.port, id, self.run_id()))
    }
}

/// Where a [`Cx::wait_until`] stands.
#[derive(Clone, Copy, PartialEq, Eq)]
enum WaitStage {
    /// Not polled yet.
    New,
    /// Counted among its context's polled waits.
    Waiting,
    /// Its condition held at a check the tick preempted, which stopped, paused or held
    /// the run meanwhile: it returns once the run may go on, without asking again.
    Held,
    /// Its condition held, or it was dropped.
    Done,
}

/// The future of [`Cx::wait_until`]. The run waits for polls while any of its action's
/// polled waits does (counted in [`Cx::action`]): the first one to start sets that, the
/// last one to end or be dropped clears it.
struct WaitUntil<'s, 'a, C, F> {
    cx: &'s Cx<'a, C>,
    condition: F,
    stage: WaitStage,
}

// Nothing of it is pinned: the condition is only called through `&mut`.
impl<C, F> Unpin for WaitUntil<'_, '_, C, F> {}

impl<C, F> WaitUntil<'_, '_, C, F> {
    /// It no longer waits: the last polled wait of the run to end stops the polls.
    fn finish(&mut self) {
        let cx = self.cx;
        let waits = cx.action.get();
        let count = waits & WAIT_COUNT;
        let counted = matches!(self.stage, WaitStage::Waiting | WaitStage::Held);
        if counted && count != WAIT_COUNT {
            let left = count.saturating_sub(1);
            cx.action.set((waits & !WAIT_COUNT) | left);
            if left == 0 {
                cx.port.set_poll_wait(cx.run_id(), false);
            }
        }
        self.stage = WaitStage::Done;
    }
}

impl<'a, C, F: FnMut(&Cx<'a, C>) -> bool> Future for WaitUntil<'_, 'a, C, F> {
    type Output = ();

    fn poll(self: core::pin::Pin<&mut Self>, _: &mut core::task::Context<'_>) -> Poll<()> {
        let this = self.get_mut();
        let cx = this.cx;
        let (port, run) = (cx.port, cx.run_id());
        let go = match this.stage {
            WaitStage::Done => return Poll::Ready(()),
            // Not the action's wait (polled from a condition method): counting it would
            // end the poll wait that the run's exit condition relies on.
            _ if cx.action.get() & ACTING == 0 => return Poll::Pending,
            WaitStage::Held => {
                if port.clearance_of(run) != Clearance::Go {
                    return Poll::Pending;
                }
                this.finish();
                return Poll::Ready(());
            }
            WaitStage::New => {
                this.stage = WaitStage::Waiting;
                let waits = cx.action.get();
                let count = waits & WAIT_COUNT;
                let more = count.saturating_add(1).min(WAIT_COUNT);
                cx.action.set((waits & !WAIT_COUNT) | more);
                if count == 0 {
                    port.set_poll_wait(run, true);
                }
                port.clearance_of(run) == Clearance::Go
            }
            // Another polled wait took this poll: check at it too.
            WaitStage::Waiting if cx.action.get() & DUE_TAKEN != 0 => {
                port.clearance_of(run) == Clearance::Go
            }
            WaitStage::Waiting => {
                let due = port.due_poll_of(run) == Clearance::Go;
                if due {
                    cx.action.set(cx.action.get() | DUE_TAKEN);
                }
                due
            }
        };
        if !go || !cx.looking(|| (this.condition)(cx)) {
            return Poll::Pending;
        }
        // Returns only with the clearance to advance after the condition, too: the tick may
        // preempt the condition and stop, pause or hold the run (as a run's end is
        // refused then). It keeps what the condition said.
        if port.clearance_of(run) != Clearance::Go {
            this.stage = WaitStage::Held;
            return Poll::Pending;
        }
        this.finish();
        Poll::Ready(())
    }
}

/// A polled wait dropped before its condition held (the loser of a `select`) no longer
/// waits.
impl<C, F> Drop for WaitUntil<'_, '_, C, F> {
    fn drop(&mut self) {
        self.finish();
    }
}

/// The future of [`Cx::join`]. While it waits its sequence is marked as joining the
/// target (what the deadlock check of a later join follows); dropped before it returned
/// (the loser of a `select`, an action aborted or restarted), it no longer waits.
pub(crate) struct Join<'a, C> {
    port: &'a dyn Port<C>,
    me: RunId,
    joined: Joined,
    /// The last poll left the sequence marked as joining.
    waiting: bool,
}

/// What a join waits for.
#[derive(Clone, Copy)]
enum Joined {
    /// The run of this sequence that is current at the join's first poll (or its last,
    /// if it ended): [`Cx::join`].
    CurrentRunOf(SeqId),
    /// This run.
    Run(RunId),
}

impl<'a, C> Join<'a, C> {
    /// The join by `me` of the run `target` (not of a later run of its sequence).
    pub(crate) fn of_run(port: &'a dyn Port<C>, me: RunId, target: RunId) -> Self {
        Join {
            port,
            me,
            joined: Joined::Run(target),
            waiting: false,
        }
    }
}

impl<C> Future for Join<'_, C> {
    type Output = Result<Outcome, Error>;

    fn poll(
        mut self: core::pin::Pin<&mut Self>,
        _: &mut core::task::Context<'_>,
    ) -> Poll<Self::Output> {
        // Only while this run may advance: an aborted joiner never resumes.
        if self.port.clearance_of(self.me) != Clearance::Go {
            return Poll::Pending;
        }
        let run = match self.joined {
            Joined::Run(run) => run,
            Joined::CurrentRunOf(target) => match self.port.join_run(target) {
                Ok(run) => run,
                Err(e) => return Poll::Ready(Err(e)),
            },
        };
        self.joined = Joined::Run(run);
        let result = self.port.join(self.me.seq, run);
        self.waiting = result.is_pending();
        result
    }
}

impl<C> Drop for Join<'_, C> {
    fn drop(&mut self) {
        if self.waiting {
            self.port.stop_join(self.me.seq);
        }
    }
}
