//! A non-blocking child bound to a value of its caller's action ([`Cx::start_scoped`]).

use core::future::Future;

use crate::model::id::RunId;
use crate::sequence::context::Join;
use crate::sequencer::port::Port;
use crate::{Error, Outcome, SeqId};

#[cfg(doc)]
use crate::Cx;

/// A sequence started non-blocking by [`Cx::start_scoped`], whose run ends with this value:
/// when it is dropped (the action returns, fails through `?`, or a `select` drops the
/// future that holds it) the next tick aborts the run, unless it has ended. (An abort or
/// restart of the caller takes the run down itself, in its own tick, as it takes every
/// child.) [`join`](Self::join) waits for its end instead, and [`detach`](Self::detach)
/// lets it run on, as [`Cx::start`] does.
///
/// The abort is a request of the calling sequence
/// ([`Requester::Sequence`](crate::Requester::Sequence)) of this run alone, restarts (by
/// its own monitors) included: a later run of the sequence, started after this one ended,
/// is not aborted by it (unless it is the caller's own start that brings the 16-bit run
/// count round to this run's again, after 65 536 starts of the sequence in all). A
/// paused caller does not pause it (it runs in its own lane).
/// The rules, with the corner cases, are item 11 of docs/semantics.md.
///
/// A belt that runs while `load` waits for a part, and stops when `load` returns:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use core::cell::Cell;
/// use rtseq::{sim::Sim, Cause, Cx, Event, Failure, Monitors, Outcome, Record, Request,
///             Requester, RunningState::*, SeqConfig, SeqId, Sequence, Sequencer};
/// struct Belt;
/// impl Sequence<Cell<bool>> for Belt {
///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
///         cx.wait_until(|_| false).await; // runs until stopped
///         Ok(())
///     }
/// }
/// struct Load(SeqId);
/// impl Sequence<Cell<bool>> for Load {
///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
///         let _belt = cx.start_scoped(self.0)?;
///         cx.wait_until(|cx| cx.control().get()).await; // a part arrived
///         Ok(()) // `_belt` dropped: the belt stops
///     }
/// }
/// let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
/// let belt = seq.add(SeqConfig::new("belt"), Belt).unwrap();
/// let b = belt.id();
/// let load = seq.add(SeqConfig::new("load"), Load(b)).unwrap();
/// let l = load.id();
/// let part = Cell::new(false);
/// let mut sim = Sim::new(&seq, &part, Monitors::<Cell<bool>, 1>::new());
/// sim.lane(belt);
/// sim.lane(load);
/// sim.start(l).unwrap();
/// sim.step();
/// assert_eq!((sim.state(l), sim.state(b)), (Running, Running));
/// part.set(true);
/// sim.step(); // `load` returns; the next tick aborts the belt
/// assert_eq!((sim.state(l), sim.state(b)), (Terminated, Running));
/// sim.step();
/// assert_eq!(sim.state(b), Aborted);
/// assert_eq!(sim.handle(b).unwrap().last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
/// let stop = sim.records().iter().filter_map(Record::event).last();
/// assert_eq!(stop, Some(Event::Requested {
///     sequence: b,
///     request: Request::Abort,
///     by: Requester::Sequence(l),
/// }));
/// # }
/// ```
#[must_use = "a `Scoped` dropped at once aborts the sequence it started: keep it in a variable"]
pub struct Scoped<'a, C> {
    port: &'a dyn Port<C>,
    /// The run that started it, which a join waits in.
    caller: RunId,
    /// The started run.
    run: RunId,
}

impl<'a, C> Scoped<'a, C> {
    pub(crate) fn new(port: &'a dyn Port<C>, caller: RunId, run: RunId) -> Self {
        Scoped { port, caller, run }
    }

    /// The id of the started sequence.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, SeqId, Sequence, Sequencer};
    /// type Started = Cell<Option<SeqId>>;
    /// struct Blink;
    /// impl Sequence<Started> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, Started>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// struct Main(SeqId);
    /// impl Sequence<Started> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Started>) -> Result<(), Failure> {
    ///         let blink = cx.start_scoped(self.0)?;
    ///         cx.control().set(Some(blink.id()));
    ///         blink.join().await?.done()?;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Started, 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let b = blink.id();
    /// let main = seq.add(SeqConfig::new("main"), Main(b)).unwrap();
    /// let m = main.id();
    /// let started = Cell::new(None);
    /// let mut sim = Sim::new(&seq, &started, Monitors::<Started, 1>::new());
    /// sim.lane(blink);
    /// sim.lane(main);
    /// sim.start(m).unwrap();
    /// assert_eq!(started.get(), Some(b));
    /// # }
    /// ```
    pub fn id(&self) -> SeqId {
        self.run.seq
    }

    /// Waits until the started run has ended and returns its outcome, as [`Cx::join`]
    /// does: also while a later run of the sequence is under way; once that later run has
    /// ended too, the outcome kept is its own, and the join is [`Error::OutcomeLost`]. The
    /// join borrows nothing: joins of several children may race in a `select`, and one
    /// dropped before it returned only stops waiting (the run goes on while its `Scoped`
    /// lives).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Outcome, RunningState, Seq, SeqConfig,
    ///             SeqId, Sequence, Sequencer, Wait};
    /// struct Fill(Seq<Wait>);
    /// impl Sequence<()> for Fill {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         cx.step(&mut self.0).await?;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(SeqId);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let fill = cx.start_scoped(self.0)?;
    ///         assert_eq!(fill.id(), self.0);
    ///         // (work beside the filling), then wait for it:
    ///         assert_eq!(fill.join().await, Ok(Outcome::Completed));
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let fill = seq.add(SeqConfig::new("fill"), Fill(dwell)).unwrap();
    /// let (f, main) = (fill.id(), seq.add(SeqConfig::new("main"), Main(fill.id())).unwrap());
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.lane(fill);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_millis(20)).map(|t| t.as_ticks()), Some(5_000));
    /// assert_eq!(sim.state(f), RunningState::Terminated);
    /// # }
    /// ```
    pub fn join(&self) -> impl Future<Output = Result<Outcome, Error>> + use<'a, C> {
        Join::of_run(self.port, self.caller, self.run)
    }

    /// Lets the started run outlive this value, as a run started by [`Cx::start`] does.
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Outcome, RunningState, Seq, SeqConfig,
    ///             SeqId, Sequence, Sequencer, Wait};
    /// struct Fill(Seq<Wait>);
    /// impl Sequence<()> for Fill {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         cx.step(&mut self.0).await?;
    ///         Ok(())
    ///     }
    /// }
    /// struct Main(SeqId);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         cx.start_scoped(self.0)?.detach();
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let fill = seq.add(SeqConfig::new("fill"), Fill(dwell)).unwrap();
    /// let (f, main) = (fill.id(), seq.add(SeqConfig::new("main"), Main(fill.id())).unwrap());
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.lane(fill);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.state(id), RunningState::Terminated);
    /// sim.step();
    /// assert_eq!(sim.state(f), RunningState::Running); // not aborted
    /// # }
    /// ```
    pub fn detach(self) {
        core::mem::forget(self);
    }
}

impl<C> Drop for Scoped<'_, C> {
    fn drop(&mut self) {
        // Refused (`NotRunning`) when the run has ended (or its sequence runs again):
        // nothing of this run to abort.
        let _ = self.port.abort_child(self.run, self.caller.seq);
    }
}
