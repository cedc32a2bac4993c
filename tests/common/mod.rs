//! Test harness: a control system of flags, a generic step and a generic sequence tree,
//! and a log of every action line with the state it ran in.
#![allow(dead_code)]

use std::boxed::Box;
use std::cell::{Cell, RefCell};
use std::future::Future;
use std::pin::Pin;

use rtseq::{
    Cause, Cx, Done, Entry, Event, Failure, Instant, Outcome, Record, RunningState, Seq, SeqId,
    Sequence, Step, Transition, Wait,
};

/// One executed line of action code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub ms: u64,
    pub seq: SeqId,
    pub line: usize,
    pub state: RunningState,
    pub held: bool,
}

/// What a started child returned to its caller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Returned {
    pub ms: u64,
    pub seq: SeqId,
    pub line: usize,
    pub result: Result<Done, Failure>,
}

/// What a join returned: at which ms, to which sequence.
pub type Joined = (u64, SeqId, Result<Outcome, rtseq::Error>);

pub const END: usize = usize::MAX;

#[derive(Default)]
pub struct Ctrl {
    pub flags: [Cell<bool>; 20],
    pub lines: RefCell<Vec<Line>>,
    pub returned: RefCell<Vec<Returned>>,
    /// Names recorded by cleanup hooks (`SeqConfig::on_abort`), in call order.
    pub hooks: RefCell<Vec<&'static str>>,
    /// What joins returned, in order: at which ms, to which sequence.
    pub joins: RefCell<Vec<Joined>>,
}

impl Ctrl {
    pub fn flag(&self, i: usize) -> bool {
        self.flags[i].get()
    }
    pub fn set(&self, i: usize, v: bool) {
        self.flags[i].set(v)
    }
    fn line(&self, cx: &Cx<'_, Ctrl>, line: usize) {
        let h = cx.sequence_by_id(cx.id()).unwrap();
        self.lines.borrow_mut().push(Line {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line,
            state: h.state(),
            held: h.exception_is_active(),
        });
    }
    fn returned(&self, cx: &Cx<'_, Ctrl>, line: usize, result: Result<Done, Failure>) {
        self.returned.borrow_mut().push(Returned {
            ms: cx.now().as_ticks() / 1000,
            seq: cx.id(),
            line,
            result,
        });
    }
    pub fn joined(&self, cx: &Cx<'_, Ctrl>, result: Result<Outcome, rtseq::Error>) {
        let ms = cx.now().as_ticks() / 1000;
        self.joins.borrow_mut().push((ms, cx.id(), result));
    }
    pub fn lines_of(&self, seq: SeqId) -> Vec<(u64, usize)> {
        self.lines
            .borrow()
            .iter()
            .filter(|l| l.seq == seq)
            .map(|l| (l.ms, l.line))
            .collect()
    }
}

/// A step whose pre- and exit conditions are flags (none = true).
#[derive(Default)]
pub struct Leaf {
    pub pre: Option<usize>,
    pub exit: Option<usize>,
}

impl Leaf {
    pub fn until(flag: usize) -> Self {
        Leaf {
            pre: None,
            exit: Some(flag),
        }
    }
}

impl Step<Ctrl> for Leaf {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.control().line(cx, 0);
        Ok(())
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.pre.is_none_or(|f| cx.control().flag(f))
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.exit.is_none_or(|f| cx.control().flag(f))
    }
}

/// One line of a [`Node`]'s action.
pub enum Op {
    Step(Seq<Leaf>),
    Wait(Seq<Wait>),
    Run(Seq<Node>),
    Start(SeqId),
    Join(SeqId),
}

/// A sequence whose action runs its ops in order, logging each line and result.
#[derive(Default)]
pub struct Node {
    pub ops: Vec<Op>,
    pub pre: Option<usize>,
    pub exit: Option<usize>,
}

impl Node {
    pub fn of(ops: Vec<Op>) -> Self {
        Node {
            ops,
            pre: None,
            exit: None,
        }
    }

    /// This node, ending only once flag `flag` is set (its exit condition).
    pub fn until(self, flag: usize) -> Self {
        Node {
            exit: Some(flag),
            ..self
        }
    }
}

type Boxed<'f> = Pin<Box<dyn Future<Output = Result<Done, Failure>> + 'f>>;

impl Sequence<Ctrl> for Node {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        for (i, op) in self.ops.iter_mut().enumerate() {
            cx.control().line(cx, i);
            let r = match op {
                Op::Step(s) => cx.step(s).await,
                Op::Wait(s) => cx.step(s).await,
                Op::Run(s) => {
                    // Boxed: a `Node` may run a `Node` (the tree is recursive in type).
                    let f: Boxed<'_> = Box::pin(cx.run(s));
                    f.await
                }
                // A refused start or join: `NotStarted`, as a refused blocking start.
                Op::Start(id) => cx
                    .start(*id)
                    .map(|()| Done::Completed)
                    .map_err(Failure::from),
                // The joined run's outcome as a blocking caller would receive it.
                Op::Join(id) => cx
                    .join(*id)
                    .await
                    .map_err(Failure::from)
                    .and_then(Outcome::done),
            };
            cx.control().returned(cx, i, r);
        }
        cx.control().line(cx, END);
        Ok(())
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.pre.is_none_or(|f| cx.control().flag(f))
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        self.exit.is_none_or(|f| cx.control().flag(f))
    }
}

/// `Transition::at_millis`, shorter.
pub fn tr(ms: u64, seq: SeqId, from: RunningState, to: RunningState, cause: Cause) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

pub fn ms(t: Instant) -> u64 {
    t.as_ticks() / 1000
}

/// Every line ran while its sequence was running and not held by an exception.
pub fn assert_lines_ran_live(ctrl: &Ctrl) {
    for l in ctrl.lines.borrow().iter() {
        assert_eq!(
            (l.state, l.held),
            (RunningState::Running, false),
            "action line ran while not live: {l:?}"
        );
    }
}

/// Pretty trace for failure messages.
pub fn show(trace: &[Transition]) -> String {
    trace
        .iter()
        .map(|t| {
            format!(
                "{:>5} ms  #{} {:?} -> {:?} ({:?})\n",
                t.time.as_ticks() / 1000,
                t.sequence.index(),
                t.from,
                t.to,
                t.cause
            )
        })
        .collect()
}

/// Asserts a trace, showing it whole when it differs.
pub fn assert_trace(got: &[Transition], want: &[Transition]) {
    assert_eq!(got, want, "\n{}", show(got));
}

/// The record of a transition at `ms` of the sequence with index `id`.
pub fn transition_at(
    ms: u64,
    id: usize,
    from: RunningState,
    to: RunningState,
    cause: Cause,
) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1000),
        entry: Entry::Transition {
            sequence: SeqId::from_index(id),
            from,
            to,
            cause,
        },
    }
}

/// The record of `event` at `ms`.
pub fn event_at(ms: u64, event: Event) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1000),
        entry: Entry::Event(event),
    }
}

/// Records equal, or both printed a line each.
pub fn assert_records(got: &[Record], want: &[Record]) {
    let show = |r: &[Record]| {
        r.iter()
            .map(|r| format!("{:>6} {:?}\n", r.time.as_ticks(), r.entry))
            .collect::<String>()
    };
    assert_eq!(got, want, "\n got:\n{}want:\n{}", show(got), show(want));
}
