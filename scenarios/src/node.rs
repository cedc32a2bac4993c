//! Steps and sequences of the scenarios, without heap, recursion or `async fn`.

use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

use rtseq::{Cx, Outcome, Seq, SeqId, Sequence, Step, Wait};

use crate::{Ctrl, ScenarioError};

/// A step whose pre- and exit conditions are flags (`None` = true). Its action records
/// line 0.
#[derive(Clone, Copy, Debug, Default)]
pub struct Leaf {
    /// Flag that must be set for the step to run (`None`: always runs).
    pub pre: Option<u8>,
    /// Flag that ends the step (`None`: ends at once).
    pub exit: Option<u8>,
}

impl Leaf {
    /// A step that runs until flag `flag` is set.
    pub const fn until(flag: u8) -> Self {
        Leaf {
            pre: None,
            exit: Some(flag),
        }
    }
}

impl Step<Ctrl> for Leaf {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) {
        cx.control().line(cx, 0);
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
/// The ops are fixed: up to two [`Leaf`] steps, one [`Wait`] step, one blocking child of
/// type `Child`, any number of non-blocking starts and one join, at most `MAX_OPS` (4) in all.
/// Nesting the type gives the depth of the tree ([`N0`] … [`N3`]), so there is neither heap
/// nor recursion.
pub struct Node<Child> {
    ops: [Option<Op>; MAX_OPS],
    step0: Option<Seq<Leaf>>,
    step1: Option<Seq<Leaf>>,
    wait: Option<Seq<Wait>>,
    child: Option<Seq<Child>>,
    join: Option<SeqId>,
    /// Pre-condition flag (`None`: true).
    pub pre: Option<u8>,
    /// Exit-condition flag (`None`: true).
    pub exit: Option<u8>,
}

/// The child type of a [`Node`] that has no child sequence.
pub enum Never {}

/// A node without a child sequence.
pub type N0 = Node<Never>;
/// A node whose child is an [`N0`].
pub type N1 = Node<N0>;
/// A node whose child is an [`N1`].
pub type N2 = Node<N1>;
/// A node whose child is an [`N2`].
pub type N3 = Node<N2>;

impl<Child> Default for Node<Child> {
    fn default() -> Self {
        Self::new()
    }
}

impl<Child> Node<Child> {
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

    /// Adds "run `child` blocking" (at most one).
    pub fn run(mut self, child: Seq<Child>) -> Result<Self, ScenarioError> {
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

/// A future that is ready at once, every time it is polled (no "polled after completion"
/// panic, unlike `core::future::Ready`).
pub struct Done;

impl Future for Done {
    type Output = ();
    fn poll(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<()> {
        Poll::Ready(())
    }
}

impl Sequence<Ctrl> for Never {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> impl Future<Output = ()> {
        // `Never` has no values: this is never called.
        Done
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
/// Polling it again after it finished returns `Ready` again (no panic path).
pub struct NodeAction<'b, 'c, FS, FW, FR, FJ> {
    cx: &'b Cx<'c, Ctrl>,
    ops: [Option<Op>; MAX_OPS],
    pos: usize,
    entered: bool,
    done: bool,
    step0: Option<FS>,
    step1: Option<FS>,
    wait: Option<FW>,
    run: Option<FR>,
    join: Option<FJ>,
}

type OpResult = Result<Outcome, rtseq::Error>;

impl<FS, FW, FR, FJ> Future for NodeAction<'_, '_, FS, FW, FR, FJ>
where
    FS: Future<Output = OpResult>,
    FW: Future<Output = OpResult>,
    FR: Future<Output = OpResult>,
    FJ: Future<Output = OpResult>,
{
    type Output = ();

    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<()> {
        // SAFETY: the op futures are structurally pinned: nothing below moves them out of
        // `this`; they are polled in place and dropped in place (`poll_slot`).
        let this = unsafe { self.get_unchecked_mut() };
        loop {
            if this.done {
                return Poll::Ready(());
            }
            let line = u32::try_from(this.pos).unwrap_or(u32::MAX);
            let Some(op) = this.ops.get(this.pos).copied().flatten() else {
                this.cx.control().line(this.cx, u32::MAX);
                this.done = true;
                return Poll::Ready(());
            };
            if !this.entered {
                this.entered = true;
                this.cx.control().line(this.cx, line);
            }
            // SAFETY (all `poll_slot` calls): the slots are fields of the pinned `this`.
            let r = match op {
                Op::Start(id) => Some(this.cx.start(id).map(|()| Outcome::Completed)),
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
                Op::Run => match unsafe { poll_slot(&mut this.run, w) } {
                    Poll::Ready(r) => r,
                    Poll::Pending => return Poll::Pending,
                },
                Op::Join => match unsafe { poll_slot(&mut this.join, w) } {
                    Poll::Ready(r) => r,
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

impl<Child: Sequence<Ctrl>> Sequence<Ctrl> for Node<Child> {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> impl Future<Output = ()> {
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
            run: child.as_mut().map(|s| cx.run(s)),
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

/// The root of a lane: one of the node depths. Every lane has the same type `Seq<Root>`.
pub enum Root {
    /// Depth 0 (steps, waits, starts, joins only).
    D0(N0),
    /// One level of blocking children.
    D1(N1),
    /// Two levels.
    D2(N2),
    /// Three levels.
    D3(N3),
}

/// The action future of a [`Root`]: the action future of its variant.
pub enum RootAction<A, B, C, D> {
    /// Of [`Root::D0`].
    D0(A),
    /// Of [`Root::D1`].
    D1(B),
    /// Of [`Root::D2`].
    D2(C),
    /// Of [`Root::D3`].
    D3(D),
}

impl<A, B, C, D> Future for RootAction<A, B, C, D>
where
    A: Future<Output = ()>,
    B: Future<Output = ()>,
    C: Future<Output = ()>,
    D: Future<Output = ()>,
{
    type Output = ();
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<()> {
        // SAFETY: structural pinning of the variant's field; never moved out.
        unsafe {
            match self.get_unchecked_mut() {
                RootAction::D0(f) => Pin::new_unchecked(f).poll(w),
                RootAction::D1(f) => Pin::new_unchecked(f).poll(w),
                RootAction::D2(f) => Pin::new_unchecked(f).poll(w),
                RootAction::D3(f) => Pin::new_unchecked(f).poll(w),
            }
        }
    }
}

impl Sequence<Ctrl> for Root {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> impl Future<Output = ()> {
        match self {
            Root::D0(n) => RootAction::D0(n.action(cx)),
            Root::D1(n) => RootAction::D1(n.action(cx)),
            Root::D2(n) => RootAction::D2(n.action(cx)),
            Root::D3(n) => RootAction::D3(n.action(cx)),
        }
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        match self {
            Root::D0(n) => n.check_pre_condition(cx),
            Root::D1(n) => n.check_pre_condition(cx),
            Root::D2(n) => n.check_pre_condition(cx),
            Root::D3(n) => n.check_pre_condition(cx),
        }
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        match self {
            Root::D0(n) => n.check_exit_condition(cx),
            Root::D1(n) => n.check_exit_condition(cx),
            Root::D2(n) => n.check_exit_condition(cx),
            Root::D3(n) => n.check_exit_condition(cx),
        }
    }
}

impl From<N0> for Root {
    fn from(n: N0) -> Self {
        Root::D0(n)
    }
}
impl From<N1> for Root {
    fn from(n: N1) -> Self {
        Root::D1(n)
    }
}
impl From<N2> for Root {
    fn from(n: N2) -> Self {
        Root::D2(n)
    }
}
impl From<N3> for Root {
    fn from(n: N3) -> Self {
        Root::D3(n)
    }
}
