//! Steps and sequences of the scenarios, without heap, recursion or `async fn`.

use core::future::Future;
use core::marker::PhantomData;
use core::mem::{align_of, size_of, MaybeUninit};
use core::pin::Pin;
use core::ptr::NonNull;
use core::task::{Context, Poll};

use rtseq::{Cx, Done, Failure, Outcome, Seq, SeqId, Sequence, Step, Wait};

use crate::{Ctrl, ScenarioError};

/// A step whose pre- and exit conditions are flags (`None` = true). Its action records
/// line 0.
#[derive(Clone, Copy, Debug, Default)]
pub struct Leaf {
    /// Flag that must be set for the step to run (`None`: always runs).
    pub pre: Option<u8>,
    /// Flag that ends the step (`None`: ends at once).
    pub exit: Option<u8>,
    /// The code its action fails with (`None`: it does not fail).
    pub fail: Option<u16>,
}

impl Leaf {
    /// A step that runs until flag `flag` is set.
    pub const fn until(flag: u8) -> Self {
        Leaf {
            pre: None,
            exit: Some(flag),
            fail: None,
        }
    }

    /// A step whose action fails with `Failure::App(code)`.
    pub const fn failing(code: u16) -> Self {
        Leaf {
            pre: None,
            exit: None,
            fail: Some(code),
        }
    }
}

impl Step<Ctrl> for Leaf {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().line(cx, 0);
        match self.fail {
            Some(code) => Err(Failure::App(code)),
            None => Ok(()),
        }
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.pre.is_none_or(|f| cx.control().flag(f))
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.exit.is_none_or(|f| cx.control().flag(f))
    }
}

/// One line of a [`Node`]'s action.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Op {
    /// Run the first step blocking.
    Step0,
    /// Run the second step blocking.
    Step1,
    /// Run the wait step blocking.
    Wait,
    /// Run the child sequence blocking.
    Run,
    /// Start a sequence non-blocking in its lane.
    Start(SeqId),
    /// Wait for the join target to end.
    Join,
}

/// Most ops in one [`Node`].
pub const MAX_OPS: usize = 4;

/// A sequence whose action runs its ops in order, recording each line (`0..`, then
/// `u32::MAX` at the end) and each outcome in the [`Ctrl`] digest.
///
/// The ops are fixed: up to two [`Leaf`] steps, one [`Wait`] step, one blocking child, any
/// number of non-blocking starts and one join, at most `MAX_OPS` (4) in all. Every depth of
/// a tree is this one type (one copy of its code): a node holds its blocking child by
/// reference, in an [`Arena`] slot that also has the room for the future that runs it, so
/// there is neither heap nor recursion.
pub struct Node<'t> {
    ops: [Option<Op>; MAX_OPS],
    step0: Option<Seq<Leaf>>,
    step1: Option<Seq<Leaf>>,
    wait: Option<Seq<Wait>>,
    child: Option<&'t mut Child<'t>>,
    join: Option<SeqId>,
    /// Pre-condition flag (`None`: true).
    pub pre: Option<u8>,
    /// Exit-condition flag (`None`: true).
    pub exit: Option<u8>,
}

impl Default for Node<'_> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'t> Node<'t> {
    /// A node without ops (its action ends at once).
    pub const fn new() -> Self {
        Node {
            ops: [None; MAX_OPS],
            step0: None,
            step1: None,
            wait: None,
            child: None,
            join: None,
            pre: None,
            exit: None,
        }
    }

    fn push(mut self, op: Op) -> Result<Self, ScenarioError> {
        let slot = self
            .ops
            .iter_mut()
            .find(|o| o.is_none())
            .ok_or(ScenarioError::Capacity)?;
        *slot = Some(op);
        Ok(self)
    }

    /// Adds "run step `s`" (at most two steps).
    pub fn step(mut self, s: Seq<Leaf>) -> Result<Self, ScenarioError> {
        let op = if self.step0.is_none() {
            self.step0 = Some(s);
            Op::Step0
        } else if self.step1.is_none() {
            self.step1 = Some(s);
            Op::Step1
        } else {
            return Err(ScenarioError::Capacity);
        };
        self.push(op)
    }

    /// Adds "run the wait step `w`" (at most one).
    pub fn wait(mut self, w: Seq<Wait>) -> Result<Self, ScenarioError> {
        if self.wait.replace(w).is_some() {
            return Err(ScenarioError::Capacity);
        }
        self.push(Op::Wait)
    }

    /// Adds "run `child` blocking" (at most one); the child is in an [`Arena`].
    pub fn run(mut self, child: &'t mut Child<'t>) -> Result<Self, ScenarioError> {
        if self.child.replace(child).is_some() {
            return Err(ScenarioError::Capacity);
        }
        self.push(Op::Run)
    }

    /// Adds "start `id` non-blocking".
    pub fn start(self, id: SeqId) -> Result<Self, ScenarioError> {
        self.push(Op::Start(id))
    }

    /// Adds "join `id`" (at most one join).
    pub fn join(mut self, id: SeqId) -> Result<Self, ScenarioError> {
        if self.join.replace(id).is_some() {
            return Err(ScenarioError::Capacity);
        }
        self.push(Op::Join)
    }

    /// Sets the pre-condition flag.
    pub fn pre(mut self, flag: u8) -> Self {
        self.pre = Some(flag);
        self
    }

    /// Sets the exit-condition flag.
    pub fn exit(mut self, flag: u8) -> Self {
        self.exit = Some(flag);
        self
    }
}

/// Bytes of a `Room`: the future of a blocking run of a [`Node`] (its framework and its
/// [`NodeAction`]) fits, on the chip and on a 64-bit host (checked at compile time).
const ROOM: usize = 56 * size_of::<usize>();

/// Room for the future that runs a [`Node`] blocking. A [`NodeAction`] cannot hold that
/// future itself: it contains the child's `NodeAction`, which would contain itself.
#[repr(C, align(8))]
struct Room(MaybeUninit<[u8; ROOM]>);

/// A blocking child of a [`Node`] and the room for the future that runs it (an [`Arena`]
/// slot).
pub struct Child<'t> {
    seq: Seq<Node<'t>>,
    room: Room,
}

/// Where a set-up keeps the blocking children of its nodes: slots lent for the set-up's
/// life (a `static` on the chip, a local on the host).
pub struct Arena<'t> {
    free: &'t mut [Option<Child<'t>>],
}

impl<'t> Arena<'t> {
    /// An arena of the (empty) `slots`.
    pub fn new(slots: &'t mut [Option<Child<'t>>]) -> Self {
        Arena { free: slots }
    }

    /// Moves `seq` into a free slot, to be run blocking by one [`Node`] ([`Node::run`]).
    pub fn child(&mut self, seq: Seq<Node<'t>>) -> Result<&'t mut Child<'t>, ScenarioError> {
        let (slot, rest) = core::mem::take(&mut self.free)
            .split_first_mut()
            .ok_or(ScenarioError::Capacity)?;
        self.free = rest;
        Ok(slot.insert(Child {
            seq,
            room: Room(MaybeUninit::uninit()),
        }))
    }
}

type OpResult = Result<Done, Failure>;

/// A future of one type `F`, moved into a [`Room`] and known by its poll function only (a
/// hand-made `Pin<&mut dyn Future>` that owns its value). Dropping it drops the future in
/// place. (Leaked, it would leave the future in the room undropped: harmless here, rtseq's
/// run futures hold references and cells only, nothing that relies on its drop.)
struct Placed<'r> {
    fut: NonNull<()>,
    poll: unsafe fn(NonNull<()>, &mut Context<'_>) -> Poll<OpResult>,
    drop: unsafe fn(NonNull<()>),
    /// The room is borrowed while the future lives in it.
    _room: PhantomData<&'r mut Room>,
}

/// # Safety
/// `fut` must point to a live, pinned `F`.
unsafe fn poll_placed<F: Future<Output = OpResult>>(
    fut: NonNull<()>,
    w: &mut Context<'_>,
) -> Poll<OpResult> {
    // SAFETY: guaranteed by the caller.
    unsafe { Pin::new_unchecked(fut.cast::<F>().as_mut()) }.poll(w)
}

/// # Safety
/// `fut` must point to a live `F`, which is not used afterwards.
unsafe fn drop_placed<F>(fut: NonNull<()>) {
    // SAFETY: guaranteed by the caller.
    unsafe { fut.cast::<F>().drop_in_place() }
}

impl<'r> Placed<'r> {
    /// Moves `fut` into `room`. A future that does not fit fails the build.
    ///
    /// # Safety
    /// The result must not outlive what `fut` borrows (it is dropped before any of it ends).
    unsafe fn new<F: Future<Output = OpResult>>(room: &'r mut Room, fut: F) -> Self {
        const { assert!(size_of::<F>() <= ROOM && align_of::<F>() <= align_of::<Room>()) };
        let at = NonNull::from(room).cast::<F>();
        // SAFETY: the room is large and aligned enough for `F` (checked above) and borrowed
        // exclusively for `'r`, as long as the result.
        unsafe { at.write(fut) };
        Placed {
            fut: at.cast(),
            poll: poll_placed::<F>,
            drop: drop_placed::<F>,
            _room: PhantomData,
        }
    }

    fn poll(&mut self, w: &mut Context<'_>) -> Poll<OpResult> {
        // SAFETY: `fut` holds the `F` of `poll`, live until `self` drops; it is never moved
        // out of the room (pinned there), and `&mut self` makes this the only access.
        unsafe { (self.poll)(self.fut, w) }
    }
}

impl Drop for Placed<'_> {
    fn drop(&mut self) {
        // SAFETY: `fut` holds the `F` of `drop`, live until now; dropped in place, as its
        // pinning requires, and never used again.
        unsafe { (self.drop)(self.fut) }
    }
}

/// An action future that is ready at once with `Ok(())`, every time it is polled (no
/// "polled after completion" panic, unlike `core::future::Ready`).
pub struct AtOnce;

impl Future for AtOnce {
    type Output = Result<(), Failure>;
    fn poll(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<Self::Output> {
        Poll::Ready(Ok(()))
    }
}

/// Polls the future in `slot` (if any); on completion drops it in place and returns its
/// output. `Ready(None)` for an empty slot.
///
/// # Safety
/// `slot` must be structurally pinned: it must not be moved while it holds a future that
/// has been polled (it is only ever dropped in place, here or with its owner).
unsafe fn poll_slot<F: Future>(
    slot: &mut Option<F>,
    w: &mut Context<'_>,
) -> Poll<Option<F::Output>> {
    let Some(f) = slot.as_mut() else {
        return Poll::Ready(None);
    };
    // SAFETY: guaranteed by the caller (the slot is pinned and never moved).
    let f = unsafe { Pin::new_unchecked(f) };
    match f.poll(w) {
        Poll::Ready(v) => {
            // Dropped in place: allowed for pinned data.
            *slot = None;
            Poll::Ready(Some(v))
        }
        Poll::Pending => Poll::Pending,
    }
}

/// The action future of a [`Node`]: a hand-written state machine over its ops.
///
/// The futures of the ops are created (lazily: they do nothing until polled) when the action
/// starts, because each borrows its child only; the state machine polls them in op order.
/// The blocking child's future is in the child's arena slot ([`Child`]). Polling it again after it
/// finished returns `Ready` again (no panic path).
pub struct NodeAction<'a, 'b, 'c, FS, FW, FJ> {
    cx: &'b Cx<'c, Ctrl>,
    ops: [Option<Op>; MAX_OPS],
    pos: usize,
    entered: bool,
    done: bool,
    step0: Option<FS>,
    step1: Option<FS>,
    wait: Option<FW>,
    run: Option<Placed<'a>>,
    join: Option<FJ>,
}

impl<FS, FW, FJ> Future for NodeAction<'_, '_, '_, FS, FW, FJ>
where
    FS: Future<Output = OpResult>,
    FW: Future<Output = OpResult>,
    FJ: Future<Output = Result<Outcome, rtseq::Error>>,
{
    type Output = Result<(), Failure>;

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
        // SAFETY: the op futures are structurally pinned: nothing below moves them out of
        // `this`; they are polled in place and dropped in place (`poll_slot`). The child's
        // future is in its room, not here.
        let this = unsafe { self.get_unchecked_mut() };
        loop {
            if this.done {
                return Poll::Ready(Ok(()));
            }
            let line = u32::try_from(this.pos).unwrap_or(u32::MAX);
            let Some(op) = this.ops.get(this.pos).copied().flatten() else {
                this.cx.control().line(this.cx, u32::MAX);
                this.done = true;
                return Poll::Ready(Ok(()));
            };
            if !this.entered {
                this.entered = true;
                this.cx.control().line(this.cx, line);
            }
            // SAFETY (all `poll_slot` calls): the slots are fields of the pinned `this`.
            let r = match op {
                Op::Start(id) => Some(
                    this.cx
                        .start(id)
                        .map(|()| Done::Completed)
                        .map_err(Failure::from),
                ),
                Op::Step0 => match unsafe { poll_slot(&mut this.step0, w) } {
                    Poll::Ready(r) => r,
                    Poll::Pending => return Poll::Pending,
                },
                Op::Step1 => match unsafe { poll_slot(&mut this.step1, w) } {
                    Poll::Ready(r) => r,
                    Poll::Pending => return Poll::Pending,
                },
                Op::Wait => match unsafe { poll_slot(&mut this.wait, w) } {
                    Poll::Ready(r) => r,
                    Poll::Pending => return Poll::Pending,
                },
                Op::Run => match this.run.as_mut().map(|f| f.poll(w)) {
                    Some(Poll::Pending) => return Poll::Pending,
                    Some(Poll::Ready(r)) => {
                        this.run = None;
                        Some(r)
                    }
                    None => None,
                },
                // A join's outcome as a blocking run's result.
                Op::Join => match unsafe { poll_slot(&mut this.join, w) } {
                    Poll::Ready(r) => r.map(|r| r.map_err(Failure::from).and_then(Outcome::done)),
                    Poll::Pending => return Poll::Pending,
                },
            };
            if let Some(r) = r {
                this.cx.control().returned(this.cx, line, r);
            }
            this.pos = this.pos.saturating_add(1);
            this.entered = false;
        }
    }
}

impl Sequence<Ctrl> for Node<'_> {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> impl Future<Output = Result<(), Failure>> {
        let Node {
            ops,
            step0,
            step1,
            wait,
            child,
            join,
            ..
        } = self;
        NodeAction {
            cx,
            ops: *ops,
            pos: 0,
            entered: false,
            done: false,
            step0: step0.as_mut().map(|s| cx.step(s)),
            step1: step1.as_mut().map(|s| cx.step(s)),
            wait: wait.as_mut().map(|s| cx.step(s)),
            // SAFETY: the run's future borrows the child (for the `&mut self` of this call)
            // and the context's engine and control system; the `Placed` is dropped with the
            // returned future, which outlives none of them.
            run: child
                .as_deref_mut()
                .map(|Child { seq, room }| unsafe { Placed::new(room, cx.run(seq)) }),
            join: join.map(|id| cx.join(id)),
        }
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.pre.is_none_or(|f| cx.control().flag(f))
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.exit.is_none_or(|f| cx.control().flag(f))
    }
}
