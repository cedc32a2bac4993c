//! Sequences and steps (seed §1.3–§1.5), and the framework loop that runs them
//! (the seed's `actionFramework`).

use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Poll;

use crate::engine::Engine;
use crate::sequencer::Gate;
use crate::{Cx, Outcome, SeqId};

/// A sequence: an `async` action made of steps and sub-sequences, plus the optional pre- and
/// exit conditions.
///
/// The action is an `async fn`: the compiler turns it into a statically sized state machine.
/// Started blocking ([`Cx::run`]) it runs inside its caller's future; started non-blocking
/// ([`Cx::start`], [`Handle::start`](crate::Handle::start)) it runs in its lane
/// ([`lane`](crate::lane)). It must not block: wait with steps and their exit conditions.
///
/// ```
/// use rtseq::{Cx, Outcome, Seq, Sequence, Step};
/// struct Enable;
/// impl Step<()> for Enable { fn action(&mut self, _cx: &Cx<'_, ()>) {} }
/// struct PowerOn { enable: Seq<Enable> }
/// impl Sequence<()> for PowerOn {
///     async fn action(&mut self, cx: &Cx<'_, ()>) {
///         if cx.step(&mut self.enable).await != Ok(Outcome::Completed) {
///             return;
///         }
///     }
/// }
/// ```
#[allow(async_fn_in_trait)] // lanes poll on one core: no `Send` bound wanted
pub trait Sequence<C> {
    /// The sequence's work: starts steps and sub-sequences and awaits them.
    async fn action(&mut self, cx: &Cx<'_, C>);

    /// Checked before the action; `false` skips the run (outcome [`Outcome::Skipped`]).
    fn check_pre_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }

    /// Polled after the action at every polling period; the run ends when it is `true`.
    /// Default: ends right after the action.
    fn check_exit_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }
}

/// A step: one command to the control or safety system, then its exit condition is polled.
/// Always started blocking ([`Cx::step`]).
///
/// ```
/// use core::sync::atomic::{AtomicI32, Ordering::Relaxed};
/// use rtseq::{Cx, Step};
/// struct Axis { setpoint: AtomicI32, position: AtomicI32 }
/// struct MoveTo(i32);
/// impl Step<Axis> for MoveTo {
///     fn action(&mut self, cx: &Cx<'_, Axis>) {
///         cx.control().setpoint.store(self.0, Relaxed);
///     }
///     fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
///         (cx.control().position.load(Relaxed) - self.0).abs() <= 2
///     }
/// }
/// ```
pub trait Step<C> {
    /// The single, non-blocking command.
    fn action(&mut self, cx: &Cx<'_, C>);

    /// Checked before the action; `false` skips the step.
    fn check_pre_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }

    /// Polled after the action at every polling period; the step ends when it is `true`.
    fn check_exit_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }
}

/// A sequence or step object bound to its registered id: what callers own and run.
///
/// Created by [`Sequencer::add`](crate::Sequencer::add) or
/// [`Sequencer::bind`](crate::Sequencer::bind), once per id.
pub struct Seq<S> {
    pub(crate) id: SeqId,
    pub(crate) body: S,
}

impl<S> Seq<S> {
    /// The registered id.
    pub fn id(&self) -> SeqId {
        self.id
    }

    /// The sequence object.
    pub fn body(&self) -> &S {
        &self.body
    }

    /// The sequence object, mutably (e.g. to set a target before running it).
    pub fn body_mut(&mut self) -> &mut S {
        &mut self.body
    }
}

/// What the framework needs of a sequence or a step.
pub(crate) trait Body<C> {
    async fn act(&mut self, cx: &Cx<'_, C>);
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool;
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool;
}

pub(crate) struct SeqBody<'s, S>(pub(crate) &'s mut S);
pub(crate) struct StepBody<'s, S>(pub(crate) &'s mut S);

impl<C, S: Sequence<C>> Body<C> for SeqBody<'_, S> {
    async fn act(&mut self, cx: &Cx<'_, C>) {
        self.0.action(cx).await
    }
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_pre_condition(cx)
    }
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_exit_condition(cx)
    }
}

impl<C, S: Step<C>> Body<C> for StepBody<'_, S> {
    async fn act(&mut self, cx: &Cx<'_, C>) {
        self.0.action(cx)
    }
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_pre_condition(cx)
    }
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_exit_condition(cx)
    }
}

/// Waits at an await point until the gate opens; never returns `Hold`.
pub(crate) async fn gate<C>(engine: &dyn Engine<C>, id: SeqId) -> Gate {
    poll_fn(|w| match engine.gate(id, w.waker()) {
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
    .await
}

/// Polls `fut` only while the gate of `id` is open: a held sequence does not advance, an
/// aborted or restarting one never runs another line of it.
async fn guarded<C>(engine: &dyn Engine<C>, id: SeqId, fut: impl Future<Output = ()>) -> Gate {
    let mut fut = pin!(fut);
    poll_fn(|w| match engine.gate(id, w.waker()) {
        Gate::Go => fut.as_mut().poll(w).map(|()| Gate::Go),
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
    .await
}

/// Waits for the next due poll of a polled condition.
pub(crate) async fn poll_due<C>(engine: &dyn Engine<C>, id: SeqId) -> Gate {
    poll_fn(|w| match engine.poll_due(id, w.waker()) {
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
    .await
}

/// The seed's `actionFramework`: exceptions → pre-condition → action → exit condition every
/// polling period, repeated from the pre-condition on restart.
pub(crate) async fn framework<C, B: Body<C>>(
    engine: &dyn Engine<C>,
    control: &C,
    id: SeqId,
    body: &mut B,
) -> Outcome {
    let cx = Cx::new(engine, control, id);
    let outcome = 'run: loop {
        // Each arm that leaves this iteration says how: on with the run, the outcome, or
        // start over after a restart.
        macro_rules! on {
            ($gate:expr) => {
                match $gate {
                    Gate::Go | Gate::Hold => {}
                    Gate::Aborted(cause) => break 'run Outcome::Aborted(cause),
                    Gate::Restart => {
                        engine.restarted(id);
                        continue 'run;
                    }
                }
            };
        }
        on!(gate(engine, id).await);
        if !body.pre(&cx) {
            match engine.end(id, Outcome::Skipped) {
                Ok(o) => break 'run o,
                Err(g) => {
                    on!(g);
                    continue 'run;
                }
            }
        }
        on!(guarded(engine, id, body.act(&cx)).await);
        engine.poll_wait(id, true);
        loop {
            if body.exit(&cx) {
                match engine.end(id, Outcome::Completed) {
                    Ok(o) => break 'run o,
                    Err(g) => on!(g),
                }
            }
            on!(poll_due(engine, id).await);
        }
    };
    engine.poll_wait(id, false);
    engine.finished(id, outcome);
    outcome
}
