//! The context every action and condition method receives.

use core::future::poll_fn;
use core::task::Poll;

use core::future::Future;

use crate::sequence::erased::{sequence_run, ErasedBody, StepRun};
use crate::sequence::run::Run;
use crate::sequence::SeqHead;
use crate::sequencer::port::Port;
use crate::sequencer::transition::Clearance;
use crate::{Error, Handle, Instant, Outcome, Seq, SeqId, Sequence, Step};

/// What a running sequence or step sees: its id, the time, typed access to the control
/// system, and the sequencer (start, join and inspect other sequences).
///
/// A main sequence that starts a status blinker non-blocking, runs a move blocking, and
/// waits for the blinker:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use core::cell::Cell;
/// use rtseq::sim::Sim;
/// use rtseq::{Cx, Duration, Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence, Sequencer, Wait};
/// #[derive(Default)]
/// struct Ctrl { blinks: Cell<u32> }
/// struct Blink { dwell: Seq<Wait> }
/// impl Sequence<Ctrl> for Blink {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) {
///         for _ in 0..3 {
///             let _ = cx.step(&mut self.dwell).await;
///             cx.control().blinks.set(cx.control().blinks.get() + 1);
///         }
///     }
/// }
/// struct Main { blink: SeqId, dwell: Seq<Wait> }
/// impl Sequence<Ctrl> for Main {
///     async fn action(&mut self, cx: &Cx<'_, Ctrl>) {
///         cx.start(self.blink).unwrap();                          // non-blocking
///         assert_eq!(cx.step(&mut self.dwell).await, Ok(Outcome::Completed)); // blocking
///         assert_eq!(cx.join(self.blink).await, Ok(Outcome::Completed));
///         assert_eq!(cx.sequence_by_id(self.blink).unwrap().caller(), Some(cx.id()));
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
}

impl<'a, C> Cx<'a, C> {
    pub(crate) fn new(port: &'a dyn Port<C>, control: &'a C, id: SeqId) -> Self {
        Cx { port, control, id }
    }

    pub(crate) fn port(&self) -> &'a dyn Port<C> {
        self.port
    }

    /// The id of the sequence this context belongs to.
    pub fn id(&self) -> SeqId {
        self.id
    }

    /// The application's control system.
    pub fn control(&self) -> &'a C {
        self.control
    }

    /// The sequencer time (the last tick's time).
    pub fn now(&self) -> Instant {
        self.port.now()
    }

    /// Starts `child` **blocking**: it runs inside this sequence's future and this sequence
    /// waits for its outcome. Errors if `child` is already running.
    ///
    /// If this sequence is aborted or paused meanwhile, the call does not return into the
    /// action until it may advance again (sticky abort: an aborted action never resumes).
    ///
    /// The returned future borrows `child` but not this context (it copies what it needs),
    /// so a hand-written action future can hold it.
    pub fn run<'s, S: Sequence<C>>(
        &self,
        child: &'s mut Seq<S>,
    ) -> impl Future<Output = Result<Outcome, Error>> + use<'a, 's, C, S> {
        let Seq { head, body } = child;
        sequence_run(self.blocking_run(head), body)
    }

    /// Starts `step` (always blocking): its command, then its exit condition every polling
    /// period.
    pub fn step<'s, S: Step<C>>(
        &self,
        step: &'s mut Seq<S>,
    ) -> impl Future<Output = Result<Outcome, Error>> + use<'a, 's, C, S> {
        let Seq { head, body } = step;
        self.step_run(head, ErasedBody::of_step(body))
    }

    /// A blocking run of a step of any type: one future type, one copy of its code.
    fn step_run<'s>(&self, head: &'s SeqHead, step: ErasedBody<'s, C>) -> StepRun<'a, 's, C> {
        StepRun {
            run: self.blocking_run(head),
            step,
        }
    }

    /// A blocking run, by this sequence, of the sequence or step whose head is `head`.
    fn blocking_run<'s>(&self, head: &'s SeqHead) -> Run<'a, 's, C> {
        Run::blocking(
            Cx::new(self.port, self.control, head.id),
            &head.result,
            self.id,
        )
    }

    /// Starts sequence `id` **non-blocking** in its lane; this sequence continues. Errors if
    /// it is already running or has no lane.
    pub fn start(&self, id: SeqId) -> Result<(), Error> {
        self.port.start_in_lane(id, Some(self.id))
    }

    /// Waits until non-blocking sequence `id` has ended and returns its outcome.
    pub fn join(&self, id: SeqId) -> impl Future<Output = Result<Outcome, Error>> + use<'a, C> {
        let (port, me) = (self.port, self.id);
        poll_fn(move |w| {
            // Only while this sequence may advance: an aborted joiner never resumes.
            if port.clearance(me, w.waker()) != Clearance::Go {
                return Poll::Pending;
            }
            port.join(me, id)
        })
    }

    /// Waits, without a control block of its own, until `condition` holds; it is checked now
    /// and then at this sequence's polling period. Prefer a [`Step`] with an exit condition
    /// where the wait deserves its own timeout or monitors.
    pub fn wait_until<'s, F: FnMut(&Self) -> bool + 's>(
        &'s self,
        mut condition: F,
    ) -> impl Future<Output = ()> + use<'s, 'a, C, F> {
        let mut first = true;
        poll_fn(move |w| {
            let go = if core::mem::take(&mut first) {
                self.port.set_poll_wait(self.id, true);
                self.port.clearance(self.id, w.waker()) == Clearance::Go
            } else {
                self.port.due_poll(self.id, w.waker()) == Clearance::Go
            };
            if go && condition(self) {
                self.port.set_poll_wait(self.id, false);
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
    }

    /// The seed's `getSafetySystem()`: trigger public events, read the level.
    pub fn safety_system(&self) -> Option<&'static crate::safety::SafetyHandle> {
        self.port.safety()
    }

    /// A handle to any registered sequence (the seed's `getSequenceByID`).
    pub fn sequence_by_id(&self, id: SeqId) -> Option<Handle<'a, C>> {
        self.port.info(id).map(|_| Handle::from_port(self.port, id))
    }

    /// A handle to any registered sequence (the seed's `getSequenceByName`).
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::sim::Sim;
    /// use rtseq::{Cx, Duration, Monitors, SeqConfig, SeqId, Sequence, Sequencer};
    /// struct Lookup;
    /// impl Sequence<Cell<Option<(SeqId, SeqId, bool)>>> for Lookup {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<Option<(SeqId, SeqId, bool)>>>) {
    ///         let id = |name| cx.sequence_by_name(name).map(|h| h.id());
    ///         if let (Some(me), Some(other)) = (id("lookup"), id("other")) {
    ///             cx.control().set(Some((me, other, id("nope").is_none())));
    ///         }
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
        Some(Handle::from_port(self.port, id))
    }
}
