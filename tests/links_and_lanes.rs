//! The compact bookkeeping behind the 48-byte control block: caller links instead of copied
//! caller stacks, lane slots holding the wakers, a monitor table in registration order, evaluated in groups.

mod common;
use common::*;
use rtseq::lock::CriticalSection;
use rtseq::sim::Sim;
use rtseq::Cause::Monitor as Mon;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Done, Duration, Error, Failure, Monitor, MonitorId, Monitors, SeqConfig, SeqId,
    Sequencer, Wait,
};

/// Monitors registered out of owner order keep their ids (registration order), names and
/// owners, and each fires for its own owner.
#[test]
fn monitor_ids_stay_in_registration_order_while_the_table_groups_by_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    // Both run until flag 15 (never).
    let forever = || Node::of(vec![]).until(15);
    let a_seq = seq.add(SeqConfig::new("A"), forever()).unwrap();
    let b_seq = seq.add(SeqConfig::new("B"), forever()).unwrap();
    let (a, b) = (a_seq.id(), b_seq.id());
    let (mut f0, mut f1, mut f2) = (
        |c: &Ctrl, _| c.flag(0),
        |c: &Ctrl, _| c.flag(1),
        |c: &Ctrl, _| c.flag(2),
    );
    let mut monitors: Monitors<Ctrl, 3> = Monitors::new();
    assert!(monitors.is_empty());
    let m0 = monitors
        .add(b, Monitor::new("b0", &mut f0, Behaviour::Nothing))
        .unwrap();
    let m1 = monitors
        .add(a, Monitor::new("a1", &mut f1, Behaviour::Nothing))
        .unwrap();
    let m2 = monitors
        .add(b, Monitor::new("b2", &mut f2, Behaviour::Nothing))
        .unwrap();
    assert_eq!(
        [m0, m1, m2],
        [0, 1, 2].map(MonitorId::from_index),
        "ids follow registration"
    );
    assert_eq!((monitors.len(), monitors.is_empty()), (3, false));
    assert_eq!(
        [m0, m1, m2].map(|m| (monitors.name(m), monitors.owner(m))),
        [
            (Some("b0"), Some(b)),
            (Some("a1"), Some(a)),
            (Some("b2"), Some(b))
        ]
    );
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a_seq);
    sim.lane(b_seq);
    sim.start(a).unwrap();
    sim.start(b).unwrap();
    sim.before_tick(|t, c| {
        c.set(2, ms(t) >= 3);
        c.set(1, ms(t) >= 5);
    });
    sim.run_until(rtseq::Instant::from_ticks(10_000));
    let m = sim.monitors();
    assert_eq!([m0, m1, m2].map(|id| m.fired(id)), [0, 1, 1]);
    let got: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| matches!(t.cause, Mon(_)))
        .map(|t| t.cause)
        .collect();
    assert!(got.is_empty(), "Nothing changes no state: {got:?}");
    assert_eq!(
        sim.handle(b).unwrap().active_exception(),
        Some(Mon(m2)),
        "B's exception is its own monitor b2"
    );
    assert_eq!(sim.handle(a).unwrap().active_exception(), Some(Mon(m1)));
}

/// A sequencer has `W` lane slots; declaring one more is an error, and a sequence without a
/// lane cannot be started non-blocking.
#[test]
fn lane_slots_are_a_checked_capacity() {
    let seq: Sequencer<(), 4, 8, CriticalSection, 2> = Sequencer::new();
    let ids: Vec<SeqId> = ["a", "b", "c"]
        .iter()
        .map(|n| seq.register(SeqConfig::new(n)).unwrap())
        .collect();
    let h = |i: usize| seq.sequence_by_id(ids[i]).unwrap();
    assert_eq!(h(0).declare_lane(), Ok(()));
    assert_eq!(
        h(0).declare_lane(),
        Ok(()),
        "declaring twice takes one slot"
    );
    assert_eq!(h(1).declare_lane(), Ok(()));
    assert_eq!(
        h(2).declare_lane(),
        Err(Error::LaneCapacityExceeded(ids[2]))
    );
    assert_eq!(h(2).start(), Err(Error::LaneCapacityExceeded(ids[2])));
    assert_eq!(h(0).start(), Ok(()));
}

/// The caller stack is walked from caller links. A starts B non-blocking, runs C and ends;
/// B waits 10 ms and starts A again: A's caller is B, and B's link to A's finished run is
/// cut, so the links never form a cycle (which would make every depth "too deep").
#[test]
fn caller_links_follow_the_running_tree_and_never_cycle() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let a = seq.register(SeqConfig::new("A")).unwrap();
    let b = seq.register(SeqConfig::new("B")).unwrap();
    let c = seq.register(SeqConfig::new("C")).unwrap();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let wi = w.id();
    // A: start B, then run C (C ends once flag 2 is set, at 5 ms).
    let c_seq = seq.bind(c, Node::of(vec![]).until(2)).unwrap();
    let a_seq = seq
        .bind(a, Node::of(vec![Op::Start(b), Op::Run(c_seq)]))
        .unwrap();
    // B: wait 10 ms, start A, then run until flag 1 (never).
    let b_seq = seq
        .bind(b, Node::of(vec![Op::Wait(w), Op::Start(a)]).until(1))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a_seq);
    sim.lane(b_seq);
    sim.before_tick(|t, c| c.set(2, ms(t) >= 5));
    sim.start(a).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(8_000));
    {
        let h = |id| sim.handle(id).unwrap();
        assert_eq!(h(a).state(), Terminated);
        assert_eq!(h(b).caller_stack().as_slice(), &[a]);
        assert_eq!(h(wi).caller_stack().as_slice(), &[a, b]);
        assert_eq!(h(wi).caller_stack_blocking().as_slice(), &[b]);
    }
    sim.run_until(rtseq::Instant::from_ticks(20_000));
    let h = |id| sim.handle(id).unwrap();
    assert_eq!(h(a).caller(), Some(b), "A's second run was started by B");
    assert_eq!(h(b).caller(), None, "B's link to A's first run is cut");
    assert!(h(b).caller_stack().is_empty());
    assert_eq!(
        h(c).caller_stack().as_slice(),
        &[b, a],
        "C, run by A's second run"
    );
    let results: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.ms, r.seq, r.line, r.result))
        .collect();
    assert_eq!(
        results,
        vec![
            (0, a, 0, Ok(Done::Completed)),
            (5, a, 1, Ok(Done::Completed)),
            (10, b, 0, Ok(Done::Completed)),
            (10, b, 1, Ok(Done::Completed)),
            (10, a, 0, Err(Failure::NotStarted(Error::AlreadyRunning(b)))),
            (10, a, 1, Ok(Done::Completed)),
        ]
    );
    assert_eq!(h(a).state(), Terminated);
    assert_eq!(h(b).state(), Running);
}

/// Blocking runs nest `MAX_DEPTH` (8) callers deep and no deeper: in a chain `s0` runs `s1`
/// runs … `s9`, `s8` starts with 8 callers (its caller stack is `s0` … `s7`) and its run of
/// `s9`, which would have 9, is refused with `CallerDepthExceeded`; everything else
/// completes.
#[test]
fn callers_nest_max_depth_deep_and_a_deeper_start_is_refused() {
    assert_eq!(rtseq::MAX_DEPTH, 8);
    let seq: Sequencer<Ctrl, 16> = Sequencer::new();
    let ctrl = Ctrl::default();
    // s9 runs until flag 15 (never): were it started, the chain would not end.
    let mut below = seq
        .add(SeqConfig::new("s9"), Node::of(vec![]).until(15))
        .unwrap();
    let s9 = below.id();
    let names = ["s8", "s7", "s6", "s5", "s4", "s3", "s2", "s1", "s0"];
    let mut ids = vec![s9];
    for name in names {
        below = seq
            .add(SeqConfig::new(name), Node::of(vec![Op::Run(below)]))
            .unwrap();
        ids.push(below.id());
    }
    ids.reverse();
    let (s0, s8) = (ids[0], ids[8]);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(below);
    // The whole chain runs in the start: no step waits.
    sim.start(s0).unwrap();
    let results: Vec<_> = ctrl
        .returned
        .borrow()
        .iter()
        .map(|r| (r.seq, r.result))
        .collect();
    let mut want = vec![(s8, Err(Failure::NotStarted(Error::CallerDepthExceeded(s9))))];
    want.extend(ids[..8].iter().rev().map(|&s| (s, Ok(Done::Completed))));
    assert_eq!(results, want);
    // A run that ended keeps its caller link.
    let h = |id| sim.handle(id).unwrap();
    assert_eq!(h(s8).caller_stack().as_slice(), &ids[..8]);
    assert_eq!(h(s8).state(), Terminated);
    assert_eq!(h(s9).state(), Idle);
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(5)),
        Some(rtseq::Instant::from_ticks(0))
    );
}

/// A teardown reaches the deepest nesting: in a chain `s0` runs `s1` runs … `s8` (8
/// callers, `MAX_DEPTH`), which waits, an abort of `s0` aborts all nine, innermost first,
/// each through `Aborting`.
#[test]
fn an_abort_tears_down_a_chain_max_depth_deep_innermost_first() {
    let seq: Sequencer<Ctrl, 16> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut below = seq
        .add(SeqConfig::new("s8"), Node::of(vec![]).until(15))
        .unwrap();
    let mut ids = vec![below.id()];
    for name in ["s7", "s6", "s5", "s4", "s3", "s2", "s1", "s0"] {
        below = seq
            .add(SeqConfig::new(name), Node::of(vec![Op::Run(below)]))
            .unwrap();
        ids.push(below.id());
    }
    let s0 = below.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(below);
    sim.start(s0).unwrap();
    assert_eq!(
        sim.handle(ids[0]).unwrap().caller_stack().len(),
        rtseq::MAX_DEPTH
    );
    sim.run_until(rtseq::Instant::from_ticks(2_000));
    sim.abort(s0).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(3_000));
    let aborts: Vec<rtseq::Transition> = sim
        .trace()
        .iter()
        .filter(|t| ms(t.time) == 3)
        .copied()
        .collect();
    let want: Vec<rtseq::Transition> = ids
        .iter()
        .flat_map(|&s| {
            [
                tr(3, s, Running, Aborting, rtseq::Cause::Abort),
                tr(3, s, Aborting, Aborted, rtseq::Cause::Abort),
            ]
        })
        .collect();
    assert_eq!(aborts, want, "{}", show(sim.trace()));
}
