//! The context every action and condition method receives.

use core::future::poll_fn;
use core::task::Poll;

use crate::engine::Engine;
use crate::sequence::{framework, poll_due, SeqBody, StepBody};
use crate::sequencer::{Gate, Mode};
use crate::{Error, Handle, Instant, Outcome, Seq, SeqId, Sequence, Step};

/// What a running sequence or step sees: its id, the time, typed access to the control
/// system, and the sequencer (start, join and inspect other sequences).
pub struct Cx<'a, C> {
    engine: &'a dyn Engine<C>,
    control: &'a C,
    id: SeqId,
}

impl<'a, C> Cx<'a, C> {
    pub(crate) fn new(engine: &'a dyn Engine<C>, control: &'a C, id: SeqId) -> Self {
        Cx {
            engine,
            control,
            id,
        }
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
        self.engine.now()
    }

    /// Starts `child` **blocking**: it runs inside this sequence's future and this sequence
    /// waits for its outcome. Errors if `child` is already running.
    ///
    /// If this sequence is aborted or paused meanwhile, the call does not return into the
    /// action until it may advance again (sticky abort: an aborted action never resumes).
    pub async fn run<S: Sequence<C>>(&self, child: &mut Seq<S>) -> Result<Outcome, Error> {
        self.engine.begin(child.id, Some(self.id), Mode::Blocking)?;
        let outcome = framework(
            self.engine,
            self.control,
            child.id,
            &mut SeqBody(&mut child.body),
        )
        .await;
        self.resume_point().await;
        Ok(outcome)
    }

    /// Starts `step` (always blocking): its command, then its exit condition every polling
    /// period.
    pub async fn step<S: Step<C>>(&self, step: &mut Seq<S>) -> Result<Outcome, Error> {
        self.engine.begin(step.id, Some(self.id), Mode::Blocking)?;
        let outcome = framework(
            self.engine,
            self.control,
            step.id,
            &mut StepBody(&mut step.body),
        )
        .await;
        self.resume_point().await;
        Ok(outcome)
    }

    /// Starts sequence `id` **non-blocking** in its lane; this sequence continues. Errors if
    /// it is already running or has no lane.
    pub fn start(&self, id: SeqId) -> Result<(), Error> {
        self.engine.begin(id, Some(self.id), Mode::Lane)
    }

    /// Waits until non-blocking sequence `id` has ended and returns its outcome.
    pub async fn join(&self, id: SeqId) -> Result<Outcome, Error> {
        let r = poll_fn(|w| {
            if self.engine.gate(self.id, w.waker()) != Gate::Go {
                return Poll::Pending;
            }
            self.engine.join(self.id, id)
        })
        .await;
        self.resume_point().await;
        r
    }

    /// Waits, without a control block of its own, until `condition` holds; it is checked now
    /// and then at this sequence's polling period. Prefer a [`Step`] with an exit condition
    /// where the wait deserves its own timeout or monitors.
    pub async fn wait_until(&self, mut condition: impl FnMut(&Self) -> bool) {
        self.engine.poll_wait(self.id, true);
        while !condition(self) {
            if poll_due(self.engine, self.id).await != Gate::Go {
                // Aborted or restarting: park here; the framework's guard drops this future.
                core::future::pending::<()>().await;
            }
        }
        self.engine.poll_wait(self.id, false);
    }

    /// The seed's `getSafetySystem()`: trigger public events, read the level.
    pub fn safety_system(&self) -> Option<&'static crate::safety::SafetyHandle> {
        self.engine.safety()
    }

    /// A handle to any registered sequence (the seed's `getSequenceByID`).
    pub fn sequence_by_id(&self, id: SeqId) -> Option<Handle<'a, C>> {
        self.engine
            .info(id)
            .map(|_| Handle::from_engine(self.engine, id))
    }

    /// A handle to any registered sequence (the seed's `getSequenceByName`).
    pub fn sequence_by_name(&self, name: &str) -> Option<Handle<'a, C>> {
        self.engine
            .find(name)
            .map(|id| Handle::from_engine(self.engine, id))
    }

    /// Returns only when this sequence may advance; pending forever once it is aborted or
    /// restarting (its guard then drops the future that awaits this).
    async fn resume_point(&self) {
        poll_fn(|w| match self.engine.gate(self.id, w.waker()) {
            Gate::Go => Poll::Ready(()),
            _ => Poll::Pending,
        })
        .await
    }
}
