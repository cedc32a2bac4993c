//! Sequences and steps (seed §1.3–§1.5), and the framework loop that runs them
//! (the seed's `actionFramework`).

use core::cell::Cell;
use core::convert::Infallible;
use core::future::{poll_fn, Future};
use core::marker::PhantomData;
use core::mem::offset_of;
use core::pin::{pin, Pin};
use core::ptr::NonNull;
use core::task::{Context, Poll};

use crate::sequencer::{Gate, Mode};
use crate::{Cx, Error, Outcome, SeqId};

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
// `repr(C)`, body first: of the layouts measured, the one with the least code in the
// applications that build and move whole `Seq` trees (the framework works with any: it finds
// the head with `offset_of!`).
#[repr(C)]
pub struct Seq<S> {
    pub(crate) body: S,
    pub(crate) head: SeqHead,
}

/// The part of a [`Seq`] that does not depend on the body type.
pub(crate) struct SeqHead {
    pub(crate) id: SeqId,
    /// Where the framework leaves the result of a blocking run for the future that started
    /// it; `None` at rest (set and taken in the same poll).
    pub(crate) slot: Cell<Option<Result<Outcome, Error>>>,
}

impl<S> Seq<S> {
    pub(crate) fn new(id: SeqId, body: S) -> Self {
        Seq {
            head: SeqHead {
                id,
                slot: Cell::new(None),
            },
            body,
        }
    }

    /// The registered id.
    pub fn id(&self) -> SeqId {
        self.head.id
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

// The framework is split so that almost nothing of it is generic over the sequence type:
//
// * `Frame` (the child's context, the result slot, the blocking caller, the phase) is the
//   seed's `actionFramework` as a state machine over the start (a blocking start, or a
//   lane's wait for a non-blocking one), the gate, the pre- and exit conditions, the end of
//   a run and the hand-over of its outcome. It is generic only over the control system `C`
//   and reaches the body through a type-erased reference (`BodyRef`: its conditions, and a
//   step's command) and a pinned `dyn Future` for a running action, so one copy serves every
//   sequence and step type, started blocking or in a lane.
// * A sequence's framework (`framework`) is a thin `async` block: it only has to keep the
//   action's future (which borrows the body and the context) in place while it runs. A lane
//   is nothing but this block (its frame goes back to waiting for a start after each run);
//   a blocking start wraps it in `Run`, which only takes the result from the slot.
// * A step's framework (`StepFramework`) is not generic over the step at all: the step is
//   type-erased (`BodyRef`), its command runs inside `Frame::step`; a blocking start of a
//   step is one type for every step type, and `Frame::step` also takes the result from the
//   slot, so an `.await` of a step is one out-of-line call.
//
// A sequence's framework never returns: a returning `async` block carries a
// compiler-generated "resumed after completion" panic path, and rtseq has none. A blocking
// run leaves its result in the `Seq`'s slot and its framework stays pending; its owner drops
// it. (The step's framework is a hand-written future: it returns, and has no such path.)

/// The methods of one body type, type-erased: one table per type (a promoted constant), so
/// that a call is a load and an indirect call, with no dispatch on which method.
///
/// The context is passed as a pointer to a `Cx<'_, C>`: a table mentioning `C` could not be
/// `'static` unless `C` is (see `BodyRef`).
struct Calls {
    pre: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    exit: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    /// A step's command (a sequence's action is `async`: its framework runs it).
    action: unsafe fn(NonNull<()>, NonNull<()>),
}

/// A mutably borrowed step (with its `Seq`) or sequence of any type and its `Calls`.
///
/// Hand-made rather than `&'s mut dyn Step<C>`: a trait object mentioning `C` would require
/// `C: 's`, which the signature of [`Cx::step`] does not promise.
pub(crate) struct BodyRef<'s, C> {
    /// A step: the head of its `&'s mut Seq<S>` (its `Calls` find the body from there), so
    /// that one pointer serves both; a sequence: the `&'s mut S`.
    body: NonNull<()>,
    /// `StepCalls::<C>::CALLS` or `SeqCalls::<C>::CALLS` of the body's type.
    calls: &'static Calls,
    _borrow: PhantomData<&'s mut ()>,
    /// `C` without `C: 's` (see above).
    _control: PhantomData<fn(C)>,
}

/// The body of the `Seq<S>` whose head `head` points to.
///
/// # Safety
/// `head` must point to the head of a live `Seq<S>`, with the provenance of the whole `Seq`,
/// whose body nothing else accesses meanwhile (the head may be borrowed elsewhere, see
/// `BodyRef::head`: this borrows the body only).
unsafe fn step_body<'s, S>(head: NonNull<()>) -> &'s mut S {
    // SAFETY: guaranteed by the caller.
    unsafe {
        let seq = head.byte_sub(offset_of!(Seq<S>, head)).cast::<Seq<S>>();
        &mut (*seq.as_ptr()).body
    }
}

/// The context behind a `Calls` argument.
///
/// # Safety
/// `cx` must point to a live `Cx<'_, C>`.
unsafe fn context<'x, C>(cx: NonNull<()>) -> &'x Cx<'x, C> {
    // SAFETY: guaranteed by the caller.
    unsafe { cx.cast::<Cx<'x, C>>().as_ref() }
}

// The table entries. Safety of each: `body` as for the `BodyRef` built with the table (see
// `step_body` for a step; a sequence: a live `S` that nothing else accesses meanwhile), `cx`
// points to a live `Cx<'_, C>`.

unsafe fn step_pre<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { step_body::<S>(head).check_pre_condition(context(cx)) }
}

unsafe fn step_exit<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { step_body::<S>(head).check_exit_condition(context(cx)) }
}

unsafe fn step_action<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>) {
    // SAFETY: see above.
    unsafe { step_body::<S>(head).action(context(cx)) }
}

unsafe fn seq_pre<C, S: Sequence<C>>(seq: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { seq.cast::<S>().as_mut().check_pre_condition(context(cx)) }
}

unsafe fn seq_exit<C, S: Sequence<C>>(seq: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { seq.cast::<S>().as_mut().check_exit_condition(context(cx)) }
}

/// Not called: a sequence's action is run by its framework.
unsafe fn no_action(_: NonNull<()>, _: NonNull<()>) {}

/// The `Calls` of a step type.
trait StepCalls<C> {
    const CALLS: Calls;
}

impl<C, S: Step<C>> StepCalls<C> for S {
    const CALLS: Calls = Calls {
        pre: step_pre::<C, S>,
        exit: step_exit::<C, S>,
        action: step_action::<C, S>,
    };
}

/// The `Calls` of a sequence type.
trait SeqCalls<C> {
    const CALLS: Calls;
}

impl<C, S: Sequence<C>> SeqCalls<C> for S {
    const CALLS: Calls = Calls {
        pre: seq_pre::<C, S>,
        exit: seq_exit::<C, S>,
        action: no_action,
    };
}

impl<'s, C> BodyRef<'s, C> {
    pub(crate) fn step<S: Step<C>>(step: &'s mut Seq<S>) -> Self {
        BodyRef {
            // SAFETY: the head is a field of the `Seq` the pointer comes from (in bounds);
            // derived from the pointer to the whole `Seq`, it keeps the provenance that
            // `step_body` needs to step back.
            body: unsafe { NonNull::from(step).byte_add(offset_of!(Seq<S>, head)) }.cast(),
            calls: &<S as StepCalls<C>>::CALLS,
            _borrow: PhantomData,
            _control: PhantomData,
        }
    }

    /// The head of a step's `Seq` (only for a `BodyRef::step`).
    pub(crate) fn head(&self) -> &'s SeqHead {
        // SAFETY: `body` points to the head of the `&'s mut Seq<S>` given to `step`. The head
        // is only ever shared: `step_body` borrows the body only.
        unsafe { self.body.cast::<SeqHead>().as_ref() }
    }

    fn seq<S: Sequence<C>>(seq: &'s mut S) -> Self {
        BodyRef {
            body: NonNull::from(seq).cast(),
            calls: &<S as SeqCalls<C>>::CALLS,
            _borrow: PhantomData,
            _control: PhantomData,
        }
    }

    // SAFETY (of the three calls below): `body` is the `&'s mut S` given to `step` or `seq`
    // and `calls` that type's table; the borrow lives as long as `self` (`_borrow`), and
    // `&mut self` makes this the only access; `cx` is a live context.

    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.calls.pre)(self.body, NonNull::from(cx).cast()) }
    }

    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.calls.exit)(self.body, NonNull::from(cx).cast()) }
    }

    fn action(&mut self, cx: &Cx<'_, C>) {
        // SAFETY: see above.
        unsafe { (self.calls.action)(self.body, NonNull::from(cx).cast()) }
    }
}

/// A step's command as a future: it runs at the first poll, i.e. only once the gate said go.
struct StepAct<'r, 's, 'c, 'a, C> {
    step: &'r mut BodyRef<'s, C>,
    cx: &'c Cx<'a, C>,
}

impl<C> Future for StepAct<'_, '_, '_, '_, C> {
    type Output = ();
    fn poll(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<()> {
        let this = self.get_mut();
        this.step.action(this.cx);
        Poll::Ready(())
    }
}

/// Where a run's framework stands. Without payload (the outcome has a cell of its own): a
/// phase change is a one-byte store.
#[derive(Clone, Copy)]
enum Phase {
    /// A lane's first poll: declare the lane.
    Declare,
    /// A lane between runs: wait for a non-blocking start.
    Idle,
    /// A blocking start's first poll: start the child.
    Begin,
    /// At the await point before the pre-condition: the start, or after a restart.
    Gate,
    /// The action runs (polled through `Frame::act`).
    Act,
    /// The action completed and its future is gone: start polling the exit condition.
    Acted,
    /// Check the exit condition now.
    Exit,
    /// Wait for the next due poll of the exit condition.
    Due,
    /// The run ended with `Frame::outcome` (the action's future is gone): report it.
    End,
    /// A blocking run ended: wait until the caller may advance to hand the outcome over.
    Returning,
    /// The result is in the slot (or was taken); pending forever.
    Done,
}

/// The body-independent part of a run's framework (see above): the sequence's context, the
/// slot for its result, who waits for it and where the run stands.
pub(crate) struct Frame<'a, 's, C> {
    pub(crate) cx: Cx<'a, C>,
    slot: &'s Cell<Option<Result<Outcome, Error>>>,
    /// The blocking caller; `None`: the sequence's lane.
    caller: Option<SeqId>,
    phase: Cell<Phase>,
    /// The outcome, once the run has ended.
    outcome: Cell<Outcome>,
}

impl<'a, 's, C> Frame<'a, 's, C> {
    /// A blocking start of `cx`'s sequence by `caller`, starting it at the first poll.
    pub(crate) fn blocking(
        cx: Cx<'a, C>,
        slot: &'s Cell<Option<Result<Outcome, Error>>>,
        caller: SeqId,
    ) -> Self {
        Frame {
            cx,
            slot,
            caller: Some(caller),
            phase: Cell::new(Phase::Begin),
            outcome: Cell::new(Outcome::Completed),
        }
    }

    /// The lane of `cx`'s sequence: runs it every time it is started non-blocking.
    pub(crate) fn lane(cx: Cx<'a, C>, slot: &'s Cell<Option<Result<Outcome, Error>>>) -> Self {
        Frame {
            cx,
            slot,
            caller: None,
            phase: Cell::new(Phase::Declare),
            outcome: Cell::new(Outcome::Completed),
        }
    }

    /// The run ended with `outcome`.
    fn end(&self, outcome: Outcome) {
        self.outcome.set(outcome);
        self.phase.set(Phase::End);
    }

    /// Applies a gate that is not `Go`/`Hold` (the seed's exceptions): `true` if the run goes
    /// on where it is.
    fn on(&self, gate: Gate) -> bool {
        match gate {
            Gate::Go | Gate::Hold => true,
            Gate::Aborted(cause) => {
                self.end(Outcome::Aborted(cause));
                false
            }
            Gate::Restart => {
                self.cx.engine().restarted(self.cx.id());
                self.phase.set(Phase::Gate);
                false
            }
        }
    }

    /// Runs the framework up to the start of the action (`Ready`: create and poll it now), or
    /// until it must wait (`Pending`). Never `Ready` once a blocking run has ended.
    #[inline(never)]
    fn drive(&self, w: &mut Context<'_>, body: &mut BodyRef<'_, C>) -> Poll<()> {
        let (cx, engine, id) = (&self.cx, self.cx.engine(), self.cx.id());
        loop {
            // The arms that do not `continue` or return ask to end the run with this outcome
            // (one call site for both): refused (an exception is being handled), the run
            // stays at the phase set before.
            let ending = match self.phase.get() {
                Phase::Declare => {
                    // The id is ours by construction (`Seq` exists once per id), so this
                    // cannot fail.
                    let _ = engine.declare_lane(id);
                    self.phase.set(Phase::Idle);
                    continue;
                }
                Phase::Idle => {
                    if !engine.take_start(id, w.waker()) {
                        return Poll::Pending;
                    }
                    self.phase.set(Phase::Gate);
                    continue;
                }
                Phase::Begin => {
                    match engine.begin(id, self.caller, Mode::Blocking) {
                        Ok(()) => self.phase.set(Phase::Gate),
                        Err(e) => {
                            self.slot.set(Some(Err(e)));
                            self.phase.set(Phase::Done);
                        }
                    }
                    continue;
                }
                Phase::Gate => match engine.gate(id, w.waker()) {
                    Gate::Hold => return Poll::Pending,
                    gate => {
                        if !self.on(gate) {
                            continue;
                        }
                        if body.pre(cx) {
                            self.phase.set(Phase::Act);
                            return Poll::Ready(());
                        }
                        // Refused: back to the gate (the phase is `Gate`).
                        Outcome::Skipped
                    }
                },
                // Not reached: the action is polled by `act`.
                Phase::Act => return Poll::Ready(()),
                Phase::Acted => {
                    engine.poll_wait(id, true);
                    self.phase.set(Phase::Exit);
                    continue;
                }
                Phase::Exit => {
                    // Not true yet, or refused: on to the next due poll.
                    self.phase.set(Phase::Due);
                    if !body.exit(cx) {
                        continue;
                    }
                    Outcome::Completed
                }
                Phase::Due => match engine.poll_due(id, w.waker()) {
                    Gate::Hold => return Poll::Pending,
                    gate => {
                        if self.on(gate) {
                            self.phase.set(Phase::Exit);
                        }
                        continue;
                    }
                },
                Phase::End => {
                    engine.poll_wait(id, false);
                    engine.finished(id, self.outcome.get());
                    self.phase.set(match self.caller {
                        Some(_) => Phase::Returning,
                        None => Phase::Idle,
                    });
                    continue;
                }
                // Returns only when the caller may advance: once the caller is aborted or
                // restarting it stays pending and the caller's guard drops it (sticky abort).
                Phase::Returning => {
                    if let Some(caller) = self.caller {
                        if engine.gate(caller, w.waker()) == Gate::Go {
                            self.slot.set(Some(Ok(self.outcome.get())));
                            self.phase.set(Phase::Done);
                        }
                    }
                    return Poll::Pending;
                }
                Phase::Done => return Poll::Pending,
            };
            match engine.end(id, ending) {
                Ok(outcome) => self.end(outcome),
                Err(gate) => {
                    self.on(gate);
                }
            }
        }
    }

    /// Polls the running action only while the gate is open: a held sequence does not
    /// advance, an aborted or restarting one never runs another line of it. `Ready`: the
    /// action is over (completed, aborted or restarting); drop its future, then `drive`.
    #[inline(never)]
    fn act(&self, w: &mut Context<'_>, action: Pin<&mut dyn Future<Output = ()>>) -> Poll<()> {
        match self.cx.engine().gate(self.cx.id(), w.waker()) {
            Gate::Go => match action.poll(w) {
                Poll::Ready(()) => {
                    self.phase.set(Phase::Acted);
                    Poll::Ready(())
                }
                Poll::Pending => Poll::Pending,
            },
            Gate::Hold => Poll::Pending,
            gate => {
                self.on(gate);
                Poll::Ready(())
            }
        }
    }

    /// A step's whole framework, and the take of its result from the slot: all of a step's
    /// blocking start that is polled, out of line (one call at each `.await` of a step).
    #[inline(never)]
    fn step(&self, w: &mut Context<'_>, step: &mut BodyRef<'_, C>) -> Poll<Result<Outcome, Error>> {
        loop {
            let ready = if let Phase::Act = self.phase.get() {
                let mut action = StepAct {
                    step: &mut *step,
                    cx: &self.cx,
                };
                let action = Pin::new(&mut action);
                self.act(w, action)
            } else {
                self.drive(w, step)
            };
            if ready.is_pending() {
                break;
            }
        }
        match self.slot.take() {
            Some(result) => Poll::Ready(result),
            None => Poll::Pending,
        }
    }
}

/// A blocking start of a step: the frame and the type-erased step. Unlike a sequence's
/// framework it takes its result itself (see `Frame::step`).
pub(crate) struct StepFramework<'a, 's, C> {
    pub(crate) frame: Frame<'a, 's, C>,
    pub(crate) step: BodyRef<'s, C>,
}

impl<C> Future for StepFramework<'_, '_, C> {
    type Output = Result<Outcome, Error>;
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        let this = self.get_mut();
        this.frame.step(w, &mut this.step)
    }
}

/// The seed's `actionFramework` for a sequence: exceptions → pre-condition → action → exit
/// condition every polling period, repeated from the pre-condition on restart. Its frame
/// says how it starts and what it does after a run (see `Frame`); it never completes (see
/// above).
///
/// An `async` block rather than an `async fn`: the block uses its captured arguments in
/// place, where an `async fn` first copies them into its body's locals (one more copy of
/// the frame per sequence type, about 40 bytes of flash each).
#[allow(clippy::manual_async_fn)]
pub(crate) fn framework<'a, 's, 'b, C, S: Sequence<C>>(
    frame: Frame<'a, 's, C>,
    body: &'b mut S,
) -> impl Future<Output = Infallible> + use<'a, 's, 'b, C, S> {
    async move {
        loop {
            poll_fn(|w| frame.drive(w, &mut BodyRef::seq(&mut *body))).await;
            let mut action = pin!(body.action(&frame.cx));
            poll_fn(|w| frame.act(w, action.as_mut())).await;
        }
    }
}
