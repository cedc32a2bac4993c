//! A join after a restart, refused as a cycle that no run under way closed (found in
//! session 54 by the reference model's non-blocking extension, `tests/model.rs`, seed
//! 1 500 091): the end of a sequence's aborted run, unwound after the sequence was started
//! again, released the new run's joiners, and a join made meanwhile missed a cycle. It
//! depended on the order of the lanes: with the child's lane polled before its caller's in
//! the tick of the restart, it passed. A join's wait now names its run (CHANGELOG).
mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, ConditionFn, Done, Error, Failure, Instant, Monitor, Monitors, SeqConfig, SeqId,
    Sequencer,
};

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
