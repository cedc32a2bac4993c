//! All type erasure of the sequence module, and so all its `unsafe` code.
//!
//! A [`Run`] is generic only over the control system `C`; it reaches the body (a step or a
//! sequence of any type) through an [`ErasedBody`]: a pointer and a table of the body
//! type's operations. A sequence's run ([`SequenceRun`]) also holds the place of the
//! action's future, which borrows the body and the run's own context: it is
//! self-referential, and so pinned. The run keeps no pointer into the sequence object:
//! the future that borrows the object passes its head to every poll, beside the body.
//!
//! Invariants every `unsafe` block below relies on:
//!
//! 1. An `ErasedBody<'s, C>` is built only by [`ErasedBody::of_step`] (from a `&'s mut S`
//!    of a step type `S`, with `S`'s table), by `SequenceRun::poll` (from the pinned
//!    `SequenceRun` itself, with that type's table) or by `ErasedBody::reborrow` (a copy
//!    of an existing one for a shorter borrow): pointer and table always belong together,
//!    and the borrow lasts `'s`.
//! 2. `ErasedBody` methods take `&mut self`: one call at a time, nothing else touches the
//!    body meanwhile.
//! 3. A sequence's body is borrowed by its action future while that exists, and by its
//!    conditions only while it does not: the run checks conditions only outside the stage
//!    `Action`, and the action is dropped (`drop_action`) before the run leaves `Action`
//!    any other way than by completing (a completed action is dropped by `advance`).
//! 4. The action future borrows the run's context for `'a`, longer than it lives: a
//!    `SequenceRun` is pinned before its first poll (the action is created in place and
//!    never moved), and the action is dropped before the run (field order, and
//!    `drop_action`).
//! 5. The context passed to a table's function is a live `Cx<'_, C>`.
//! 6. A `SequenceRun` reaches the object's body and head through one pointer, each by its
//!    own field (`addr_of_mut!`): the head is borrowed shared for a poll while the action
//!    may hold the body, and neither borrow covers the other.

use core::future::Future;
use core::marker::{PhantomData, PhantomPinned};
use core::pin::Pin;
use core::ptr::{addr_of, addr_of_mut, NonNull};
use core::task::{Context, Poll};

use crate::sequence::run::Run;
use crate::sequence::{Seq, SeqHead};
use crate::{Cx, Done, Failure, Sequence, Step};

/// How far an action got: `Ready` with the action's result once it is over.
type Progress = Poll<Result<(), Failure>>;

/// The operations of one body type, type-erased: one table per type (a promoted constant).
///
/// The context is passed as a pointer to a `Cx<'_, C>`: a table mentioning `C` could not be
/// `'static` unless `C` is.
struct BodyTable {
    pre: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    exit: unsafe fn(NonNull<()>, NonNull<()>) -> bool,
    /// Advances the action: a step's command runs and is over; a sequence's action future
    /// is created at its first call and polled, and dropped once it completes. `Ready`
    /// with the action's result.
    advance: unsafe fn(NonNull<()>, NonNull<()>, &mut Context<'_>) -> Progress,
    /// Drops a sequence's unfinished action future (a step has none).
    drop_action: unsafe fn(NonNull<()>),
}

/// A mutably borrowed step or sequence run of any type, with its table.
///
/// Hand-made rather than `&'s mut dyn Step<C>`: a trait object mentioning `C` would require
/// `C: 's`, which the signature of [`Cx::step`] does not promise.
pub(crate) struct ErasedBody<'s, C> {
    /// A step's body, or a sequence's pinned `SequenceRun`.
    body: NonNull<()>,
    table: &'static BodyTable,
    _borrow: PhantomData<&'s mut ()>,
    /// `C` without `C: 's` (see above).
    _control: PhantomData<fn(C)>,
}

/// The context behind a table's argument.
///
/// # Safety
/// `cx` points to a live `Cx<'_, C>` (invariant 5).
unsafe fn context<'x, C>(cx: NonNull<()>) -> &'x Cx<'x, C> {
    // SAFETY: guaranteed by the caller.
    unsafe { cx.cast::<Cx<'x, C>>().as_ref() }
}

// A step's table. Safety of each: `body` is the `&'s mut S` of `ErasedBody::of_step`
// (invariants 1, 2), `cx` a live context (5).

unsafe fn step_pre<C, S: Step<C>>(body: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { body.cast::<S>().as_mut().check_pre_condition(context(cx)) }
}

unsafe fn step_exit<C, S: Step<C>>(body: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above.
    unsafe { body.cast::<S>().as_mut().check_exit_condition(context(cx)) }
}

unsafe fn step_advance<C, S: Step<C>>(
    body: NonNull<()>,
    cx: NonNull<()>,
    _: &mut Context<'_>,
) -> Progress {
    // SAFETY: see above.
    Poll::Ready(unsafe { body.cast::<S>().as_mut().action(context(cx)) })
}

/// A step has no action future to drop.
unsafe fn step_drop_action(_: NonNull<()>) {}

/// The table of a step type.
trait StepTable<C> {
    const TABLE: BodyTable;
}

impl<C, S: Step<C>> StepTable<C> for S {
    const TABLE: BodyTable = BodyTable {
        pre: step_pre::<C, S>,
        exit: step_exit::<C, S>,
        advance: step_advance::<C, S>,
        drop_action: step_drop_action,
    };
}

impl<'s, C> ErasedBody<'s, C> {
    /// A step's body.
    pub(crate) fn of_step<S: Step<C>>(step: &'s mut S) -> Self {
        ErasedBody {
            body: NonNull::from(step).cast(),
            table: &<S as StepTable<C>>::TABLE,
            _borrow: PhantomData,
            _control: PhantomData,
        }
    }

    /// The same body, borrowed again for a shorter time.
    pub(crate) fn reborrow(&mut self) -> ErasedBody<'_, C> {
        ErasedBody {
            body: self.body,
            table: self.table,
            _borrow: PhantomData,
            _control: PhantomData,
        }
    }

    // SAFETY (of the four calls below): `body` and `table` belong together and the borrow
    // is live (invariant 1), `&mut self` makes this the only access (2), the run calls
    // the conditions only outside its action (3), `cx` is a live context (5).

    pub(crate) fn pre(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.table.pre)(self.body, NonNull::from(cx).cast()) }
    }

    pub(crate) fn exit(&mut self, cx: &Cx<'_, C>) -> bool {
        // SAFETY: see above.
        unsafe { (self.table.exit)(self.body, NonNull::from(cx).cast()) }
    }

    pub(crate) fn advance(&mut self, cx: &Cx<'_, C>, w: &mut Context<'_>) -> Progress {
        // SAFETY: see above.
        unsafe { (self.table.advance)(self.body, NonNull::from(cx).cast(), w) }
    }

    pub(crate) fn drop_action(&mut self) {
        // SAFETY: see above.
        unsafe { (self.table.drop_action)(self.body) }
    }
}

/// A blocking start of a step: the run and the type-erased step.
pub(crate) struct StepRun<'a, 's, C> {
    pub(crate) run: Run<'a, C>,
    pub(crate) head: &'s SeqHead,
    pub(crate) step: ErasedBody<'s, C>,
}

impl<C> Future for StepRun<'_, '_, C> {
    type Output = Result<Done, Failure>;
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // A `StepRun` is `Unpin`: it holds no self-reference.
        let this = self.get_mut();
        this.run.poll(w, this.head, this.step.reborrow())
    }
}

/// A sequence's run: its [`Run`] and the place of its action's future. A blocking start's
/// completes with the run's result; a lane's never completes.
pub(crate) struct SequenceRun<'a, 's, C, S, F, M> {
    /// The running action (`None` outside the stage `Action`). It borrows `body` and
    /// `run.cx`, so it comes first: dropped before them (invariant 4).
    action: Option<F>,
    run: Run<'a, C>,
    /// The `&'s mut Seq<S>`. Its body is used by the action while that exists, else by
    /// the conditions; its head by the run. One pointer for both keeps a lane small.
    seq: NonNull<Seq<S>>,
    /// Creates the action's future: `S::action`, zero-sized.
    make: M,
    _seq: PhantomData<&'s mut S>,
    /// The action borrows `run.cx`: the run never moves once polled.
    _pinned: PhantomPinned,
}

/// A sequence's run of `body` (see [`SequenceRun`]).
pub(crate) fn sequence_run<'a, 's, C, S: Sequence<C>>(
    run: Run<'a, C>,
    seq: &'s mut Seq<S>,
) -> impl Future<Output = Result<Done, Failure>> + use<'a, 's, C, S> {
    SequenceRun::<'a, 's, C, S, _, _> {
        action: None,
        run,
        seq: NonNull::from(seq),
        make: <S as Sequence<C>>::action,
        _seq: PhantomData,
        _pinned: PhantomPinned,
    }
}

// A sequence's table. Safety of each: `fw` points to a pinned `SequenceRun` of these types
// with the provenance of the whole run (invariant 1), of which nothing but its `run` is
// borrowed meanwhile, and that only shared (`SequenceRun::poll`).

unsafe fn seq_pre<C, S: Sequence<C>, F, M>(fw: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above; the conditions run only while no action borrows the body (3).
    unsafe { body_of::<C, S, F, M>(fw).check_pre_condition(context(cx)) }
}

unsafe fn seq_exit<C, S: Sequence<C>, F, M>(fw: NonNull<()>, cx: NonNull<()>) -> bool {
    // SAFETY: see above; the conditions run only while no action borrows the body (3).
    unsafe { body_of::<C, S, F, M>(fw).check_exit_condition(context(cx)) }
}

/// The body of the sequence object a `SequenceRun` borrows, reached through its pointer
/// alone: the object's head may be borrowed shared meanwhile.
///
/// # Safety
/// As for the table above, and nothing else borrows the body for `'x`.
unsafe fn body_of<'x, C, S, F, M>(fw: NonNull<()>) -> &'x mut S {
    let fw = fw.cast::<SequenceRun<'_, '_, C, S, F, M>>().as_ptr();
    // SAFETY: guaranteed by the caller; `seq` is the run's `&'s mut Seq<S>`, and only the
    // body's field is borrowed (invariant 6).
    unsafe { &mut *addr_of_mut!((*(*fw).seq.as_ptr()).body) }
}

unsafe fn seq_advance<'a, 's, C, S, F, M>(
    fw: NonNull<()>,
    _: NonNull<()>,
    w: &mut Context<'_>,
) -> Progress
where
    C: 'a,
    S: Sequence<C> + 's,
    F: Future<Output = Result<(), Failure>>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    let fw = fw.cast::<SequenceRun<'a, 's, C, S, F, M>>().as_ptr();
    // SAFETY: fields of the pinned run, reached without borrowing the whole (its `run` is
    // borrowed shared by `Run::poll`). The action borrows the body only while it exists
    // (3) and the run's context for `'a` (4); it is created in place, polled in place
    // (pinned: never moved) and dropped in place.
    unsafe {
        let action = &mut *addr_of_mut!((*fw).action);
        let future = action.get_or_insert_with(|| {
            ((*fw).make)(
                body_of::<C, S, F, M>(NonNull::new_unchecked(fw.cast())),
                &*addr_of!((*fw).run.cx),
            )
        });
        let done = Pin::new_unchecked(future).poll(w);
        if done.is_ready() {
            *action = None;
        }
        done
    }
}

unsafe fn seq_drop_action<C, S, F, M>(fw: NonNull<()>) {
    let fw = fw.cast::<SequenceRun<'_, '_, C, S, F, M>>().as_ptr();
    // SAFETY: see above: the action is dropped in place, never moved.
    unsafe { *addr_of_mut!((*fw).action) = None };
}

impl<'a, 's, C, S, F, M> SequenceRun<'a, 's, C, S, F, M>
where
    S: Sequence<C>,
    F: Future<Output = Result<(), Failure>>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    const TABLE: BodyTable = BodyTable {
        pre: seq_pre::<C, S, F, M>,
        exit: seq_exit::<C, S, F, M>,
        advance: seq_advance::<C, S, F, M>,
        drop_action: seq_drop_action::<C, S, F, M>,
    };
}

impl<'a, 's, C, S, F, M> Future for SequenceRun<'a, 's, C, S, F, M>
where
    S: Sequence<C>,
    F: Future<Output = Result<(), Failure>>,
    M: Fn(&'s mut S, &'a Cx<'a, C>) -> F,
{
    type Output = Result<Done, Failure>;

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: only a pointer is taken, nothing is moved (the action stays in place).
        let fw = NonNull::from(unsafe { self.get_unchecked_mut() });
        let body = ErasedBody {
            body: fw.cast(),
            table: &Self::TABLE,
            _borrow: PhantomData,
            _control: PhantomData,
        };
        // SAFETY: the run is only ever borrowed shared; the table's functions reach the
        // other fields through `body` (see `seq_advance`). The head is a field of the
        // object apart from the body: borrowing it shared leaves the body's borrow alone.
        unsafe {
            let this = fw.as_ptr();
            (*this)
                .run
                .poll(w, &*addr_of!((*(*this).seq.as_ptr()).head), body)
        }
    }
}

/// A lane dropped gives up a start made but not taken and closes its lane: this is where
/// the object's head is at hand (the run's own `Drop` aborts a run under way).
impl<C, S, F, M> Drop for SequenceRun<'_, '_, C, S, F, M> {
    fn drop(&mut self) {
        // SAFETY: `seq` is the run's `&'s mut Seq<S>`, live until the run is dropped, and
        // only its head is borrowed here, shared (invariant 6).
        let head = unsafe { &*addr_of!((*self.seq.as_ptr()).head) };
        self.run.drop_lane(head);
    }
}

/// A lane: a sequence's run that goes back to waiting for a start after each run, forever.
pub(crate) struct LaneRun<F>(pub(crate) F);

impl<F: Future<Output = Result<Done, Failure>>> Future for LaneRun<F> {
    type Output = core::convert::Infallible;

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: the run is structurally pinned: never moved out, only polled in place.
        let run = unsafe { self.map_unchecked_mut(|lane| &mut lane.0) };
        // Never `Ready`: only a blocking start's run leaves a result.
        let _ = run.poll(w);
        Poll::Pending
    }
}
