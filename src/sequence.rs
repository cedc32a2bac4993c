//! Sequences and steps (seed §1.3–§1.5), and the framework loop that runs them
//! (the seed's `actionFramework`).

use core::cell::Cell;
use core::convert::Infallible;
use core::future::{poll_fn, Future};
use core::pin::{pin, Pin};
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
///
/// # Panic-free actions
///
/// rtseq itself has no panic path (the board's no-panic build proves it), but every
/// `async fn` that returns carries a compiler-generated "`async fn` resumed after completion"
/// panic path of its own. Firmware that must be provably panic-free implements `action` as a
/// plain function returning a hand-written future (the futures of [`Cx::run`] and
/// [`Cx::step`] borrow only the child, not the context, so they can be stored in it):
///
/// ```
/// use core::future::Future;
/// use core::pin::Pin;
/// use core::task::{Context, Poll};
/// use rtseq::{Cx, Seq, Sequence, Step};
/// struct Enable;
/// impl Step<()> for Enable { fn action(&mut self, _cx: &Cx<'_, ()>) {} }
/// struct PowerOn { enable: Seq<Enable> }
/// impl Sequence<()> for PowerOn {
///     fn action<'a, 'b, 'c>(&'a mut self, cx: &'b Cx<'c, ()>)
///         -> impl Future<Output = ()> + use<'a, 'b, 'c>
///     {
///         // Drop the outcome: a future adapter that cannot panic.
///         struct Ignore<F>(F);
///         impl<F: Future> Future for Ignore<F> {
///             type Output = ();
///             fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<()> {
///                 // SAFETY: `0` is structurally pinned, never moved out.
///                 unsafe { self.map_unchecked_mut(|s| &mut s.0) }.poll(w).map(|_| ())
///             }
///         }
///         Ignore(cx.step(&mut self.enable))
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
///
/// ```
/// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let mut dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
/// dwell.body_mut().set_duration(Duration::from_millis(8)); // configure before the next run
/// assert_eq!(seq.sequence_by_id(dwell.id()).unwrap().name(), "dwell");
/// ```
pub struct Seq<S> {
    pub(crate) id: SeqId,
    pub(crate) body: S,
    /// Where the framework leaves the outcome of a run for the future that started it.
    pub(crate) slot: Cell<Option<Outcome>>,
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
    fn act<'s>(&'s mut self, cx: &'s Cx<'_, C>) -> impl Future<Output = ()>;
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool;
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool;
}

pub(crate) struct SeqBody<'s, S>(pub(crate) &'s mut S);
pub(crate) struct StepBody<'s, S>(pub(crate) &'s mut S);

impl<C, S: Sequence<C>> Body<C> for SeqBody<'_, S> {
    fn act<'s>(&'s mut self, cx: &'s Cx<'_, C>) -> impl Future<Output = ()> {
        self.0.action(cx)
    }
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_pre_condition(cx)
    }
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_exit_condition(cx)
    }
}

impl<C, S: Step<C>> Body<C> for StepBody<'_, S> {
    fn act<'s>(&'s mut self, cx: &'s Cx<'_, C>) -> impl Future<Output = ()> {
        // The command runs at the first poll, i.e. only once the gate said go.
        let step = &mut *self.0;
        poll_fn(move |_| {
            step.action(cx);
            Poll::Ready(())
        })
    }
    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_pre_condition(cx)
    }
    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        self.0.check_exit_condition(cx)
    }
}

// The futures below are `poll_fn`s or `async fn`s that never return: a returning `async fn`
// carries a compiler-generated "resumed after completion" panic path, and rtseq has none.

/// Waits at an await point until the gate opens; never yields `Hold`.
pub(crate) fn gate<C>(engine: &dyn Engine<C>, id: SeqId) -> impl Future<Output = Gate> + '_ {
    poll_fn(move |w| match engine.gate(id, w.waker()) {
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
}

/// Polls `fut` only while the gate of `id` is open: a held sequence does not advance, an
/// aborted or restarting one never runs another line of it.
fn guarded<'f, C, F: Future<Output = ()>>(
    engine: &'f dyn Engine<C>,
    id: SeqId,
    mut fut: Pin<&'f mut F>,
) -> impl Future<Output = Gate> + 'f {
    poll_fn(move |w| match engine.gate(id, w.waker()) {
        Gate::Go => fut.as_mut().poll(w).map(|()| Gate::Go),
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
}

/// Waits for the next due poll of a polled condition.
pub(crate) fn poll_due<C>(engine: &dyn Engine<C>, id: SeqId) -> impl Future<Output = Gate> + '_ {
    poll_fn(move |w| match engine.poll_due(id, w.waker()) {
        Gate::Hold => Poll::Pending,
        other => Poll::Ready(other),
    })
}

/// The seed's `actionFramework`: exceptions → pre-condition → action → exit condition every
/// polling period, repeated from the pre-condition on restart. It leaves the outcome in
/// `slot` and then never completes (see above); its owner drops it.
pub(crate) async fn framework<C, B: Body<C>>(
    engine: &dyn Engine<C>,
    control: &C,
    id: SeqId,
    mut body: B,
    slot: &Cell<Option<Outcome>>,
) -> Infallible {
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
        {
            let act = pin!(body.act(&cx));
            on!(guarded(engine, id, act).await);
        }
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
    slot.set(Some(outcome));
    core::future::pending::<Infallible>().await
}
