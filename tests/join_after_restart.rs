//! Joins and their cycle check (semantics 14). A join after a restart, refused as a cycle
//! that no run under way closed (found in session 54 by the reference model's non-blocking
//! extension, `tests/model.rs`, seed 1 500 091): the end of a sequence's aborted run,
//! unwound after the sequence was started again, released the new run's joiners, and a
//! join made meanwhile missed a cycle; a join's wait now names its run (CHANGELOG). And a
//! join not refused for a sequence that waits on another run (a mutant of the check that
//! session 54's mutation testing found unseen). And a join of a run that had ended, whose
//! sequence ran again and joined back, refused as a cycle although it never waits (found by
//! session 55's cold review; with it, in `sequencer/interleavings/lanes.rs`, a cycle missed
//! when the target started again between a join's check and its first look, and a join of
//! a run 128 starts back read as one of the run under way).
mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, ConditionFn, Cx, Done, Error, Failure, Instant, Monitor, Monitors, Outcome,
    SeqConfig, SeqId, Sequence, Sequencer,
};
use std::cell::{Cell, RefCell};

fn restart_cond(c: &Ctrl, _: Instant) -> bool {
    c.flag(1)
}

/// Semantics 14: "A join that closes a cycle of waits (A joins B while B joins A ...) is
/// `Err(Error::JoinWouldDeadlock(id))`", and of two joins the later is the error. Main (#1)
/// starts B (#0, non-blocking, ending once flag 2 is set, at 5 ms) and joins it; B joins
/// main, closing the cycle: refused at 0 ms. At 3 ms a `RestartCallerOfOwner` monitor of
/// B restarts main (B aborted below it); main's new round starts B again and joins it,
/// before B's lane has unwound B's aborted run. Main's join closes no cycle and waits; B's
/// new run's join of main closes it and is the error; B ends at 5 ms, and main's join
/// returns.
#[test]
fn a_join_after_a_restart_waits_while_the_aborted_run_of_its_target_unwinds() {
    let seq: Sequencer<Ctrl, 8, 64> = Sequencer::new();
    let ctrl = Ctrl::default();
    let main_id = SeqId::from_index(1);
    let b_seq = seq
        .add(
            SeqConfig::new("b"),
            Node::of(vec![Op::Join(main_id)]).until(2),
        )
        .unwrap();
    let b = b_seq.id();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(b), Op::Join(b)]),
        )
        .unwrap();
    assert_eq!(main.id(), main_id);
    let mut mons: Monitors<Ctrl, 1, ConditionFn<Ctrl>> = Monitors::new();
    mons.add(
        b,
        Monitor::with_fn(
            "m",
            restart_cond as ConditionFn<Ctrl>,
            Behaviour::RestartCallerOfOwner,
        ),
    )
    .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, mons);
    sim.lane(main);
    sim.lane(b_seq);
    sim.before_tick(|now, c: &Ctrl| {
        let t = ms(now);
        c.set(1, t == 3);
        c.set(2, t >= 5);
    });
    sim.start(main_id).unwrap();
    for _ in 0..6 {
        sim.step();
    }
    let got: Vec<(u64, SeqId, usize, Result<Done, Failure>)> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.ms, r.seq, r.line, r.result))
        .collect();
    let deadlock = |id| Err(Failure::NotStarted(Error::JoinWouldDeadlock(id)));
    let want = vec![
        (0, main_id, 0, Ok(Done::Completed)),
        (0, b, 0, deadlock(main_id)),
        (3, main_id, 0, Ok(Done::Completed)),
        // B's new run: its join of main closes the cycle.
        (3, b, 0, deadlock(main_id)),
        // B ends at 5 ms: main's join returns.
        (5, main_id, 1, Ok(Done::Completed)),
    ];
    assert_eq!(got, want, "\n{}", show(&sim.take_trace()));
}

/// A join is refused only for a cycle of waits: main joins B while B's blocking child C
/// waits in a join of D, which runs on its own. Nothing waits for main, so main's join waits
/// (the cycle check follows only the joiners of the runs it meets), and returns B's end,
/// at 5 ms, when D ends.
#[test]
fn a_join_of_a_sequence_whose_child_joins_another_waits() {
    let seq: Sequencer<Ctrl, 8, 64> = Sequencer::new();
    let ctrl = Ctrl::default();
    let d = seq
        .add(SeqConfig::new("d"), Node::of(vec![]).until(2))
        .unwrap();
    let di = d.id();
    let c = seq
        .add(SeqConfig::new("c"), Node::of(vec![Op::Join(di)]))
        .unwrap();
    let b = seq
        .add(SeqConfig::new("b"), Node::of(vec![Op::Run(c)]))
        .unwrap();
    let bi = b.id();
    let w = seq
        .add(
            SeqConfig::new("w"),
            rtseq::Wait::new(rtseq::Duration::from_millis(2)),
        )
        .unwrap();
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![
                Op::Start(di),
                Op::Start(bi),
                Op::Wait(w),
                Op::Join(bi),
            ]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(d);
    sim.lane(b);
    sim.before_tick(|now, c: &Ctrl| c.set(2, ms(now) >= 5));
    sim.start(mi).unwrap();
    for _ in 0..8 {
        sim.step();
    }
    let joined: Vec<(u64, Result<Done, Failure>)> = ctrl
        .returned
        .borrow()
        .iter()
        .filter(|r| r.seq == mi && r.line == 3)
        .map(|r| (r.ms, r.result))
        .collect();
    assert_eq!(
        joined,
        [(5, Ok(Done::Completed))],
        "\n{}",
        show(sim.trace())
    );
}

// A join of a run that has ended, whose sequence runs again and joins back (session 55's
// cold review of joins).

/// At which ms, what, and its result.
type Got = (u64, &'static str, Result<Outcome, Error>);

#[derive(Default)]
struct JoinLog {
    got: RefCell<Vec<Got>>,
    x_runs: Cell<u32>,
}

impl JoinLog {
    fn push(&self, cx: &Cx<'_, JoinLog>, what: &'static str, r: Result<Outcome, Error>) {
        self.got
            .borrow_mut()
            .push((cx.now().as_ticks() / 1000, what, r));
    }
}

const X_ID: SeqId = SeqId::from_index(0);
const J_ID: SeqId = SeqId::from_index(1);

/// X: its first run waits until 2 ms; a later run joins J.
struct Xs;
impl Sequence<JoinLog> for Xs {
    async fn action(&mut self, cx: &Cx<'_, JoinLog>) -> Result<(), Failure> {
        let n = cx.control().x_runs.get() + 1;
        cx.control().x_runs.set(n);
        if n == 1 {
            cx.wait_until(|cx| cx.now().as_ticks() >= 2_000).await;
        } else {
            let r = cx.join(J_ID).await;
            cx.control().push(cx, "x joins j", r);
        }
        Ok(())
    }
}

/// J joins X.
struct Js;
impl Sequence<JoinLog> for Js {
    async fn action(&mut self, cx: &Cx<'_, JoinLog>) -> Result<(), Failure> {
        let r = cx.join(X_ID).await;
        cx.control().push(cx, "j joins x", r);
        Ok(())
    }
}

/// S joins X, then starts it again.
struct Ss;
impl Sequence<JoinLog> for Ss {
    async fn action(&mut self, cx: &Cx<'_, JoinLog>) -> Result<(), Failure> {
        let r = cx.join(X_ID).await;
        cx.control().push(cx, "s joins x", r);
        let started = cx.start(X_ID).map(|()| Outcome::Completed);
        cx.control().push(cx, "s starts x", started);
        Ok(())
    }
}

/// Semantics 14 / `Cx::join`: "If `id` is started again before this sequence is polled,
/// the join still gets the joined run's outcome", and `JoinWouldDeadlock` is for a join
/// that "closes a cycle of waits". J (priority 1) and S (priority 3) join X's run 1
/// (priority 2), which completes at 2 ms. S, released first, starts X again; X's run 2
/// (its lane above J's) joins J, which waits for nothing then (released). J's lane then
/// polls its join of X's run 1: it must get run 1's outcome (`Completed`), not
/// `JoinWouldDeadlock(X)` (J's join waits for no run under way: no cycle). J ends; X's
/// join of J returns.
#[test]
fn a_join_of_an_ended_run_whose_sequence_runs_again_and_joins_back_gets_the_outcome() {
    let seq: Sequencer<JoinLog, 4> = Sequencer::new();
    let log = JoinLog::default();
    let x = seq.add(SeqConfig::new("x"), Xs).unwrap();
    let j = seq.add(SeqConfig::new("j"), Js).unwrap();
    let s = seq.add(SeqConfig::new("s"), Ss).unwrap();
    assert_eq!((x.id(), j.id()), (X_ID, J_ID));
    let si = s.id();
    let mut sim = Sim::new(&seq, &log, Monitors::<JoinLog, 1>::new());
    sim.lane_with_priority(x, 2);
    sim.lane_with_priority(j, 1);
    sim.lane_with_priority(s, 3);
    sim.start(X_ID).unwrap();
    sim.start(J_ID).unwrap();
    sim.start(si).unwrap();
    for _ in 0..5 {
        sim.step();
    }
    let got = log.got.borrow().clone();
    assert_eq!(
        got,
        [
            (2, "s joins x", Ok(Outcome::Completed)),
            (2, "s starts x", Ok(Outcome::Completed)),
            (2, "j joins x", Ok(Outcome::Completed)),
            (2, "x joins j", Ok(Outcome::Completed)),
        ]
    );
}
