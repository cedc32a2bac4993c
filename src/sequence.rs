//! Sequences and steps (seed §1.3–§1.5), and the framework loop that runs them
//! (the seed's `actionFramework`).

use core::cell::Cell;
use core::future::Future;
use core::marker::{PhantomData, PhantomPinned};
use core::mem::offset_of;
use core::pin::Pin;
use core::ptr::{addr_of, addr_of_mut, NonNull};
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
    /// it; `Pending` at rest (set and taken in the same poll). A `Poll`, not an `Option`:
    /// the take is then one whole copy, no `memcpy` of the payload.
    pub(crate) slot: Cell<Poll<Result<Outcome, Error>>>,
}

impl<S> Seq<S> {
    pub(crate) fn new(id: SeqId, body: S) -> Self {
        Seq {
            head: SeqHead {
                id,
                slot: Cell::new(Poll::Pending),
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

// The framework is split so that almost nothing of it is generic over the body type:
//
// * `Frame` (the child's context, the result slot, the blocking caller, the phase) is the
//   seed's `actionFramework` as a state machine over the start (a blocking start, or a
//   lane's wait for a non-blocking one), the gate, the pre-condition, the action, the exit
//   condition, the end of a run and the hand-over of its outcome. It is generic only over
//   the control system `C` and reaches the body through a type-erased reference (`BodyRef`:
//   its conditions and its action), so one copy serves every sequence and step type,
//   started blocking or in a lane. `Frame::poll` is all of a framework that is polled; it
//   also takes a blocking start's result from the slot.
// * A sequence's framework (`Framework`) adds the place of the action's future, which
//   borrows the body and the frame's context. What it has per sequence type is the
//   creation, the poll and the drop of that future (`seq_act`) and a `poll` that hands
//   itself, type-erased, to `Frame::poll`. A lane is this framework (its frame goes back to
//   waiting for a start after each run); a blocking start returns its result.
// * A step's framework (`StepFramework`) is not generic over the step at all: a step's
//   command is a plain call, so a blocking start of a step is one type for every step type
//   and an `.await` of a step is one out-of-line call.
//
// Both are hand-written futures: an `async` block that returns carries a compiler-generated
// "resumed after completion" panic path, and rtseq has none.

/// The methods of one body type, type-erased: one table per type (a promoted constant), so
/// that a call is a load and an indirect call, with no dispatch on which method.
///
/// The context is passed as a pointer to a `Cx<'_, C>`: a table mentioning `C` could not be
/// `'static` unless `C` is (see `BodyRef`).
struct Calls {
    pre: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    exit: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    /// The action, once the gate says go (`go`): a step's command runs and is over (`None`);
    /// a sequence's action future is created at the first call and returned, pinned, to be
    /// polled with `poll`. Without `go`: a sequence's action future is dropped (it completed
    /// or is stopped).
    act: unsafe fn(NonNull<()>, NonNull<()>, bool) -> Action,
    /// A sequence's `<F as Future>::poll` of its action future type `F` itself, called
    /// through this pointer so that it is never inlined into the framework.
    poll: unsafe fn(NonNull<()>, &mut Context<'_>) -> Poll<()>,
}

/// A sequence's running action future, pinned and type-erased (`None`: no action to poll).
type Action = Option<NonNull<()>>;

/// A mutably borrowed step (with its `Seq`) or sequence framework of any type and its
/// `Calls`.
///
/// Hand-made rather than `&'s mut dyn Step<C>`: a trait object mentioning `C` would require
/// `C: 's`, which the signature of [`Cx::step`] does not promise.
pub(crate) struct BodyRef<'s, C> {
    /// A step: the head of its `&'s mut Seq<S>` (its `Calls` find the body from there), so
    /// that one pointer serves both; a sequence: its pinned `Framework`.
    body: NonNull<()>,
    /// `StepCalls::<C>::CALLS` or `Framework::CALLS` of the body's type.
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

/// The body of the `Framework` that `fw` points to.
///
/// # Safety
/// `fw` must point to a live `Framework` of these types whose body nothing else accesses
/// meanwhile (its action is not running: it would borrow the body).
unsafe fn seq_body<'x, C, S, F, M>(fw: NonNull<()>) -> &'x mut S {
    // SAFETY: guaranteed by the caller; `body` is the framework's `&'s mut S`.
    unsafe {
        (*fw.cast::<Framework<'_, '_, C, S, F, M>>().as_ptr())
            .body
            .as_mut()
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
// `step_body` for a step, `seq_body` for a sequence), `cx` points to a live `Cx<'_, C>`.

unsafe fn step_pre<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { step_body::<S>(head).check_pre_condition(context(cx)) }
}

unsafe fn step_exit<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { step_body::<S>(head).check_exit_condition(context(cx)) }
}

unsafe fn step_act<C, S: Step<C>>(head: NonNull<()>, cx: NonNull<()>, go: bool) -> Action {
    if go {
        // SAFETY: see above.
        unsafe { step_body::<S>(head).action(context(cx)) }
    }
    None
}

/// Not called: a step's command is over at once.
unsafe fn no_poll(_: NonNull<()>, _: &mut Context<'_>) -> Poll<()> {
    Poll::Ready(())
}

unsafe fn seq_pre<C, S: Sequence<C>, F, M>(fw: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above (conditions are checked only while no action runs).
    unsafe { seq_body::<C, S, F, M>(fw).check_pre_condition(context(cx)) }
}

unsafe fn seq_exit<C, S: Sequence<C>, F, M>(fw: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above (conditions are checked only while no action runs).
    unsafe { seq_body::<C, S, F, M>(fw).check_exit_condition(context(cx)) }
}

/// A sequence's action: created at the first call with `go`, dropped by the call without.
///
/// # Safety
/// `fw` must point to a pinned `Framework` of these types, with the provenance of the whole
/// framework, of which nothing but its `frame` is borrowed meanwhile (and that only shared);
/// the action returned must be dropped before the next call.
unsafe fn seq_act<'a, 's, C, S, F, M>(fw: NonNull<()>, _: NonNull<()>, go: bool) -> Action
where
    C: 'a,
    S: Sequence<C> + 's,
    F: Future<Output = ()>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    let fw = fw.cast::<Framework<'a, 's, C, S, F, M>>().as_ptr();
    // SAFETY: fields of the pinned framework, reached without borrowing the whole (its frame
    // is borrowed shared by `Frame::poll`). The action borrows the body only while it
    // exists: the conditions, the other users of the body, run only when it is `None`. It
    // borrows the frame's context for `'a`, longer than it lives: the framework is pinned
    // (the action is created in place and never moved), and the action is dropped before
    // the frame (here, or first when the framework is dropped: see its fields).
    unsafe {
        let action = &mut *addr_of_mut!((*fw).action);
        if !go {
            // Dropped in place.
            *action = None;
            return None;
        }
        let action = action
            .get_or_insert_with(|| ((*fw).make)((*fw).body.as_mut(), &*addr_of!((*fw).frame.cx)));
        Some(NonNull::from(action).cast())
    }
}

/// The `Calls` of a step type.
trait StepCalls<C> {
    const CALLS: Calls;
}

impl<C, S: Step<C>> StepCalls<C> for S {
    const CALLS: Calls = Calls {
        pre: step_pre::<C, S>,
        exit: step_exit::<C, S>,
        act: step_act::<C, S>,
        poll: no_poll,
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

    /// The same body, borrowed again for a shorter time.
    fn reborrow(&mut self) -> BodyRef<'_, C> {
        BodyRef {
            body: self.body,
            calls: self.calls,
            _borrow: PhantomData,
            _control: PhantomData,
        }
    }

    // SAFETY (of the three calls below): `body` and `calls` are the pair given to `step` or
    // built by `Framework::poll`; the borrow lives as long as `self` (`_borrow`), and
    // `&mut self` makes this the only access; `cx` is a live context.

    fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.calls.pre)(self.body, NonNull::from(cx).cast()) }
    }

    fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.calls.exit)(self.body, NonNull::from(cx).cast()) }
    }

    fn act(&mut self, cx: &Cx<'_, C>, go: bool) -> Action {
        // SAFETY: see above.
        unsafe { (self.calls.act)(self.body, NonNull::from(cx).cast(), go) }
    }

    /// Polls the action `act` returned (and did not drop since).
    fn poll(&mut self, action: NonNull<()>, w: &mut Context<'_>) -> Poll<()> {
        // SAFETY: see above; `action` is this body's pinned action future, alive.
        unsafe { (self.calls.poll)(action, w) }
    }
}

/// Where a run's framework stands. Without payload (the outcome has a cell of its own): a
/// phase change is a one-byte store.
#[derive(Clone, Copy)]
enum Phase {
    /// A lane between runs (or before its first): declare the lane and wait for a
    /// non-blocking start.
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
    slot: &'s Cell<Poll<Result<Outcome, Error>>>,
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
        slot: &'s Cell<Poll<Result<Outcome, Error>>>,
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
    pub(crate) fn lane(cx: Cx<'a, C>, slot: &'s Cell<Poll<Result<Outcome, Error>>>) -> Self {
        Frame {
            cx,
            slot,
            caller: None,
            phase: Cell::new(Phase::Idle),
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
    // Inlined into `poll`, its only caller (as `act`): one prologue less per poll.
    #[inline(always)]
    fn drive(&self, w: &mut Context<'_>, body: &mut BodyRef<'_, C>) -> Poll<()> {
        let (cx, engine, id) = (&self.cx, self.cx.engine(), self.cx.id());
        loop {
            // The arms that do not `continue` or return ask to end the run with this outcome
            // (one call site for both): refused (an exception is being handled), the run
            // stays at the phase set before.
            let ending = match self.phase.get() {
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
                            self.slot.set(Poll::Ready(Err(e)));
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
                            self.slot.set(Poll::Ready(Ok(self.outcome.get())));
                            self.phase.set(Phase::Done);
                        }
                    }
                    return Poll::Pending;
                }
                Phase::Done => return Poll::Pending,
            };
            if engine.end(id, ending) {
                self.end(ending);
            } else {
                // Refused: the gate says why.
                self.on(engine.gate(id, w.waker()));
            }
        }
    }

    /// Polls the running action only while the gate is open: a held sequence does not
    /// advance, an aborted or restarting one never runs another line of it. `Ready`: the
    /// action is over (completed, or aborted or restarting, and then dropped); `drive` next.
    #[inline(always)]
    fn act(&self, w: &mut Context<'_>, body: &mut BodyRef<'_, C>) -> Poll<()> {
        match self.cx.engine().gate(self.cx.id(), w.waker()) {
            Gate::Go => {
                // A step's command has run; a sequence's action is polled (not inlined here:
                // a call through its vtable).
                if let Some(action) = body.act(&self.cx, true) {
                    if body.poll(action, w).is_pending() {
                        return Poll::Pending;
                    }
                    let _ = body.act(&self.cx, false);
                }
                self.phase.set(Phase::Acted);
                Poll::Ready(())
            }
            Gate::Hold => Poll::Pending,
            gate => {
                self.on(gate);
                let _ = body.act(&self.cx, false);
                Poll::Ready(())
            }
        }
    }

    /// A framework's whole poll, and the take of a blocking start's result from the slot:
    /// one copy for every step and sequence type (one call at each `.await` of a step).
    #[inline(never)]
    fn poll(&self, w: &mut Context<'_>, mut body: BodyRef<'_, C>) -> Poll<Result<Outcome, Error>> {
        loop {
            let ready = if let Phase::Act = self.phase.get() {
                self.act(w, &mut body)
            } else {
                self.drive(w, &mut body)
            };
            if ready.is_pending() {
                break;
            }
        }
        self.slot.replace(Poll::Pending)
    }
}

/// A run whose future is dropped before it ended (the loser of a `select`, a timeout
/// combinator, a lane shut down) does not leave its sequence running with no one to drive
/// it: it is aborted where it is, with its sub-sequences ([`Cause::Dropped`]). A run that
/// ended but has not reported back yet reports now. A sequence's action future is a field
/// before the frame, so the runs it holds are dropped first: innermost first.
///
/// [`Cause::Dropped`]: crate::Cause::Dropped
impl<C> Drop for Frame<'_, '_, C> {
    fn drop(&mut self) {
        let (engine, id) = (self.cx.engine(), self.cx.id());
        match self.phase.get() {
            Phase::Gate | Phase::Act | Phase::Acted | Phase::Exit | Phase::Due => {
                engine.abandon(id, self.cx.control());
            }
            Phase::End => engine.finished(id, self.outcome.get()),
            // Not started, waiting for a start, or over.
            Phase::Idle | Phase::Begin | Phase::Returning | Phase::Done => {}
        }
    }
}

/// A blocking start of a step: the frame and the type-erased step.
pub(crate) struct StepFramework<'a, 's, C> {
    pub(crate) frame: Frame<'a, 's, C>,
    pub(crate) step: BodyRef<'s, C>,
}

impl<C> Future for StepFramework<'_, '_, C> {
    type Output = Result<Outcome, Error>;
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        let this = self.get_mut();
        this.frame.poll(w, this.step.reborrow())
    }
}

/// The seed's `actionFramework` for a sequence: exceptions → pre-condition → action → exit
/// condition every polling period, repeated from the pre-condition on restart. Its frame
/// says how it starts and what it does after a run (see `Frame`); a blocking start's
/// framework completes with the run's result, a lane's never completes.
pub(crate) struct Framework<'a, 's, C, S, F, M> {
    /// The running action (`None` outside `Phase::Act`). It borrows `body` and
    /// `frame.cx`, so it comes first: dropped before them.
    action: Option<F>,
    frame: Frame<'a, 's, C>,
    /// The `&'s mut S`, used by the action while it exists, else by the conditions.
    body: NonNull<S>,
    /// Creates the action's future: `S::action`, zero-sized.
    make: M,
    _body: PhantomData<&'s mut S>,
    /// The action borrows `frame.cx`: the framework never moves once polled.
    _pinned: PhantomPinned,
}

/// A sequence's framework (see `Framework`).
pub(crate) fn framework<'a, 's, C, S: Sequence<C>>(
    frame: Frame<'a, 's, C>,
    body: &'s mut S,
) -> impl Future<Output = Result<Outcome, Error>> + use<'a, 's, C, S> {
    Framework {
        action: None,
        frame,
        body: NonNull::from(body),
        make: <S as Sequence<C>>::action,
        _body: PhantomData,
        _pinned: PhantomPinned,
    }
}

impl<'a, 's, C, S, F, M> Framework<'a, 's, C, S, F, M>
where
    S: Sequence<C>,
    F: Future<Output = ()>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    const CALLS: Calls = Calls {
        pre: seq_pre::<C, S, F, M>,
        exit: seq_exit::<C, S, F, M>,
        act: seq_act::<C, S, F, M>,
        // SAFETY: `Pin<&mut F>` and `NonNull<()>` are ABI-compatible (thin pointers, `Pin`
        // transparent), so the poll of `F` may be called through this type; `Frame::act`
        // passes it only the pinned `F` that `seq_act` returned.
        poll: unsafe {
            core::mem::transmute::<
                for<'p, 'w, 'x> fn(Pin<&'p mut F>, &'w mut Context<'x>) -> Poll<()>,
                for<'w, 'x> unsafe fn(NonNull<()>, &'w mut Context<'x>) -> Poll<()>,
            >(<F as Future>::poll)
        },
    };
}

impl<'a, 's, C, S, F, M> Future for Framework<'a, 's, C, S, F, M>
where
    S: Sequence<C>,
    F: Future<Output = ()>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    type Output = Result<Outcome, Error>;

    #[inline]
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: only a pointer is taken, nothing is moved (the action stays in place).
        let fw = NonNull::from(unsafe { self.get_unchecked_mut() });
        let body = BodyRef {
            body: fw.cast(),
            calls: &Self::CALLS,
            _borrow: PhantomData,
            _control: PhantomData,
        };
        // SAFETY: the frame is only ever borrowed shared; `seq_act` and the conditions reach
        // the other fields through `body` (see `seq_act`).
        unsafe { &(*fw.as_ptr()).frame }.poll(w, body)
    }
}
