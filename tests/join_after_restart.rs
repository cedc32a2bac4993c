//! Joins and their cycle check (semantics 14). A join after a restart, refused as a cycle
//! that no run under way closed (found in session 54 by the reference model's non-blocking
//! extension, `tests/model.rs`, seed 1 500 091): the end of a sequence's aborted run,
//! unwound after the sequence was started again, released the new run's joiners, and a
//! join made meanwhile missed a cycle; a join's wait now names its run (CHANGELOG). And a
//! join not refused for a sequence that waits on another run (a mutant of the check that
//! session 54's mutation testing found unseen).
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
