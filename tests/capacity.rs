//! 256 sequences: a sequencer whose sets span several words behaves exactly as a small one.
//! The same scenario (a main sequence running a child that runs a step, a monitor of the
//! child firing with an exception sequence, a restart) runs in a sequencer of 8
//! and, spread over the words of its sets (ids 0, 100, 200, 255), in a sequencer of 256:
//! the traces are the same, id for id.

mod common;
use common::*;
use rtseq::lock::CriticalSection;
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Monitor as Mon, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Duration, Error, Monitor, MonitorId, Monitors, SeqConfig, SeqId, Sequencer,
    Transition,
};

/// Ids of the scenario's sequences.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ids {
    main: SeqId,
    child: SeqId,
    step: SeqId,
    exception: SeqId,
}

/// Registers `fill` filler sequences wherever `at` asks for an id beyond the next, then
/// the scenario; runs it for 30 ms and returns its ids and trace.
fn scenario<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    at: Ids,
) -> (Ids, Vec<Transition>) {
    let ctrl = Ctrl::default();
    let names: Vec<&'static str> = (0..N)
        .map(|i| &*Box::leak(format!("filler {i}").into_boxed_str()))
        .collect();
    let fill_to = |id: SeqId| {
        while seq.len() < id.index() {
            seq.register(SeqConfig::new(names[seq.len()])).unwrap();
        }
    };
    fill_to(at.main);
    let main = seq.register(SeqConfig::new("main")).unwrap();
    fill_to(at.child);
    let child = seq.register(SeqConfig::new("child")).unwrap();
    fill_to(at.exception);
    let exception = seq
        .add(SeqConfig::new("exception"), Node::of(vec![]))
        .unwrap();
    fill_to(at.step);
    let step = seq.add(SeqConfig::new("step"), Leaf::until(1)).unwrap();
    let step_id = step.id();
    // The child runs the step, whose exit condition (flag 1) comes at 20 ms.
    let child_seq = seq.bind(child, Node::of(vec![Op::Step(step)])).unwrap();
    let main_seq = seq.bind(main, Node::of(vec![Op::Run(child_seq)])).unwrap();
    // Flag 3 (4 ms .. 6 ms) restarts the child once its exception sequence ran.
    let mut kick = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            child,
            Monitor::new("kick", &mut kick, Behaviour::RestartOwner)
                .exception(exception.id())
                .restart_limit(1),
        )
        .unwrap();
    assert_eq!(m, MonitorId::from_index(0));
    let ids = Ids {
        main,
        child,
        step: step_id,
        exception: exception.id(),
    };
    assert_eq!(ids, at);
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(main_seq);
    sim.lane(exception);
    sim.before_tick(|t, c| {
        c.set(3, (4..6).contains(&ms(t)));
        c.set(1, ms(t) >= 20);
    });
    sim.start(main).unwrap();
    sim.run_for(Duration::from_millis(30));
    (ids, sim.trace().to_vec())
}

#[test]
fn a_sequencer_of_256_runs_as_one_of_8_across_the_words_of_its_sets() {
    let small: Sequencer<Ctrl, 8> = Sequencer::new();
    let packed = Ids {
        main: SeqId::from_index(0),
        child: SeqId::from_index(1),
        exception: SeqId::from_index(2),
        step: SeqId::from_index(3),
    };
    let (_, expected) = scenario(&small, packed);
    let big: Sequencer<Ctrl, 256, 64, CriticalSection, 8, 8> = Sequencer::new();
    let spread = Ids {
        main: SeqId::from_index(0),
        child: SeqId::from_index(100),
        exception: SeqId::from_index(200),
        step: SeqId::from_index(255),
    };
    let (ids, trace) = scenario(&big, spread);
    assert_eq!(big.len(), 256);
    let renamed = |id: SeqId| match id {
        i if i == packed.child => ids.child,
        i if i == packed.exception => ids.exception,
        i if i == packed.step => ids.step,
        i => i,
    };
    let expected: Vec<Transition> = expected
        .iter()
        .map(|t| {
            let cause = match t.cause {
                Cause::Timeout(i) => Cause::Timeout(renamed(i)),
                c => c,
            };
            Transition {
                sequence: renamed(t.sequence),
                cause,
                ..*t
            }
        })
        .collect();
    assert_eq!(show(&trace), show(&expected));
    // And the scenario itself, spelled out.
    let (m, c, e, s) = (ids.main, ids.child, ids.exception, ids.step);
    let k = MonitorId::from_index(0);
    assert_eq!(
        trace,
        vec![
            tr(0, m, Idle, Running, Cause::Start),
            tr(0, c, Idle, Running, Cause::Start),
            tr(0, s, Idle, Running, Cause::Start),
            // Flag 3 at 4 ms: the exception sequence runs (and ends at once) ...
            tr(4, e, Idle, Running, Mon(k)),
            tr(4, e, Running, Terminated, Cause::Completed),
            // ... and the next tick applies the behaviour: the child restarts, the step
            // it was running is aborted first and runs again.
            tr(5, s, Running, Aborting, Mon(k)),
            tr(5, s, Aborting, Aborted, Mon(k)),
            tr(5, c, Running, Restarting, Mon(k)),
            tr(5, c, Restarting, Running, Cause::Restart),
            tr(5, s, Aborted, Running, Cause::Start),
            tr(20, s, Running, Terminated, Cause::Completed),
            tr(20, c, Running, Terminated, Cause::Completed),
            tr(20, m, Running, Terminated, Cause::Completed),
        ],
        "{}",
        show(&trace)
    );
}

#[test]
fn the_257th_sequence_is_an_error() {
    let seq: Sequencer<(), 256, 64, CriticalSection, 8, 8> = Sequencer::new();
    for i in 0..256 {
        let name: &'static str = Box::leak(format!("s{i}").into_boxed_str());
        assert_eq!(seq.register(SeqConfig::new(name)), Ok(SeqId::from_index(i)));
    }
    assert_eq!(
        seq.register(SeqConfig::new("one too many")),
        Err(Error::SequenceCapacityExceeded)
    );
    assert_eq!(
        seq.sequence_by_name("s255").map(|h| h.id()),
        Some(SeqId::from_index(255))
    );
}

/// Three sequences `[x, y, t]` (exit condition flag 9, never set), started at 0 ms: `x`
/// and `y` each with a monitor on flag 2 (set at 3 ms, `AbortOwner`; the table lists
/// `y`'s monitor first), `t` with a 3 ms timeout. Returns the trace from 3 ms on.
fn same_tick<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    ids: [SeqId; 3],
) -> Vec<Transition> {
    let ctrl = Ctrl::default();
    let mut sorted = ids;
    sorted.sort();
    let mut runs = Vec::new();
    for at in sorted {
        while seq.len() < at.index() {
            let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
        let name: &'static str = Box::leak(format!("waits {}", at.index()).into_boxed_str());
        let config = SeqConfig::new(name);
        let config = if at == ids[2] {
            config.timeout(Duration::from_millis(3))
        } else {
            config
        };
        let waits = Node::of(vec![]).until(9);
        let run = seq.add(config, waits).unwrap();
        assert_eq!(run.id(), at);
        runs.push(run);
    }
    let (mut on_x, mut on_y) = (|c: &Ctrl, _| c.flag(2), |c: &Ctrl, _| c.flag(2));
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(ids[1], Monitor::new("y", &mut on_y, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(ids[0], Monitor::new("x", &mut on_x, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    for run in runs {
        sim.lane(run);
    }
    sim.before_tick(|t, c| c.set(2, ms(t) >= 3));
    for id in ids {
        sim.start(id).unwrap();
    }
    sim.run_for(Duration::from_millis(5));
    sim.trace()
        .iter()
        .filter(|t| ms(t.time) >= 3)
        .copied()
        .collect()
}

/// Two monitors and a timeout that trigger in the same tick. A sequencer of one-word sets
/// raises them as the tick documents it: monitors in table order, then timeouts. One of
/// several words visits the words holding active sequences lowest first and does the same
/// in each: here the monitor of `x` in word 0 comes before that of `y` in word 3, which
/// the table lists first, and the timeout of `t` in word 0 before the monitor of word 3.
#[test]
fn in_one_tick_a_sequencer_of_several_words_goes_word_by_word() {
    let (ky, kx) = (MonitorId::from_index(0), MonitorId::from_index(1));
    let small: Sequencer<Ctrl, 8> = Sequencer::new();
    let [x, y, t] = [1, 2, 3].map(SeqId::from_index);
    assert_eq!(
        same_tick(&small, [x, y, t]),
        vec![
            tr(3, y, Running, Aborting, Mon(ky)),
            tr(3, y, Aborting, Aborted, Mon(ky)),
            tr(3, x, Running, Aborting, Mon(kx)),
            tr(3, x, Aborting, Aborted, Mon(kx)),
            tr(3, t, Running, Aborting, Cause::Timeout(t)),
            tr(3, t, Aborting, Aborted, Cause::Timeout(t)),
        ]
    );
    let big: Sequencer<Ctrl, 256, 64, CriticalSection, 8, 8> = Sequencer::new();
    let [x, y, t] = [5, 100, 6].map(SeqId::from_index);
    assert_eq!(
        same_tick(&big, [x, y, t]),
        vec![
            tr(3, x, Running, Aborting, Mon(kx)),
            tr(3, x, Aborting, Aborted, Mon(kx)),
            tr(3, t, Running, Aborting, Cause::Timeout(t)),
            tr(3, t, Aborting, Aborted, Cause::Timeout(t)),
            tr(3, y, Running, Aborting, Mon(ky)),
            tr(3, y, Aborting, Aborted, Mon(ky)),
        ]
    );
}

/// `main` runs `p` blocking; `p` starts `n` non-blocking and ends; `n` outlives it. An abort
/// of `main` reaches `n` through `p`'s link although `p` has ended (a teardown visits only
/// the sequences whose run may be under way, and fetches the links of ended callers).
fn outliving<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    ids: [SeqId; 3],
) -> Vec<Transition> {
    let ctrl = Ctrl::default();
    let fill_to = |at: SeqId| {
        while seq.len() < at.index() {
            let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
    };
    let [main_id, p_id, n_id] = ids;
    fill_to(main_id);
    let main = seq.register(SeqConfig::new("main")).unwrap();
    fill_to(p_id);
    let p = seq.register(SeqConfig::new("p")).unwrap();
    fill_to(n_id);
    let n = seq
        .add(SeqConfig::new("n"), Node::of(vec![]).until(9))
        .unwrap();
    assert_eq!([main, p, n.id()], ids);
    let p = seq.bind(p, Node::of(vec![Op::Start(n_id)])).unwrap();
    let main = seq.bind(main, Node::of(vec![Op::Run(p)]).until(8)).unwrap();
    let mut sim = Sim::new(seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(n);
    sim.start(main_id).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(4_000));
    seq.sequence_by_id(main_id).unwrap().abort().unwrap();
    sim.run_until(rtseq::Instant::from_ticks(10_000));
    sim.trace().to_vec()
}

#[test]
fn an_abort_reaches_a_child_that_outlived_its_caller() {
    for (ids, trace) in [
        {
            let small: Sequencer<Ctrl, 8> = Sequencer::new();
            let ids = [0, 1, 2].map(SeqId::from_index);
            (ids, outliving(&small, ids))
        },
        {
            let big: Sequencer<Ctrl, 256, 64, CriticalSection, 8, 8> = Sequencer::new();
            let ids = [3, 130, 250].map(SeqId::from_index);
            (ids, outliving(&big, ids))
        },
    ] {
        let [m, p, n] = ids;
        let abort = Cause::Abort;
        assert_eq!(
            trace,
            vec![
                tr(0, m, Idle, Running, Start),
                tr(0, p, Idle, Running, Start),
                tr(0, n, Idle, Running, Start),
                tr(0, p, Running, Terminated, Completed),
                // Innermost first: `n` (depth 2, below the ended `p`), then `main`.
                tr(5, n, Running, Aborting, abort),
                tr(5, n, Aborting, Aborted, abort),
                tr(5, m, Running, Aborting, abort),
                tr(5, m, Aborting, Aborted, abort),
            ],
            "{}",
            show(&trace)
        );
    }
}

/// In a sequencer of two words: O (id 0, polled every 10 ms) has a monitor that fires at
/// 10 ms with exception sequence E (id 1, polled every millisecond, an idle class). X (id
/// 40, word 1, polled every 10 ms) runs meanwhile. E's start into its idle class starts
/// the grid: its first poll comes one period after the start (semantics 1), at 11 ms,
/// where its exit condition (flag 2, from 11 ms) ends it. The tick visits word 1 after
/// word 0 started E; that word's scan must not forget E's first poll (the due time it set).
#[test]
fn an_exception_sequence_started_in_an_earlier_word_is_polled_one_period_after_its_start() {
    // With the portable lock (short sections) and a coarse one (one section per scan).
    let locked: Sequencer<Ctrl, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    exception_sequence_in_an_earlier_word(&locked);
    let single: Sequencer<Ctrl, 64, 64, rtseq::lock::SingleThread, 8, 2> =
        Sequencer::single_thread();
    exception_sequence_in_an_earlier_word(&single);
}

fn exception_sequence_in_an_earlier_word<L: rtseq::lock::Lock>(
    seq: &Sequencer<Ctrl, 64, 64, L, 8, 2>,
) {
    let ctrl = Ctrl::default();
    let slow = Duration::from_millis(10);
    let o = seq
        .add(SeqConfig::new("O").polling(slow), Node::of(vec![]).until(1))
        .unwrap();
    let e = seq
        .add(
            SeqConfig::new("E").polling(Duration::from_millis(1)),
            Node::of(vec![]).until(2),
        )
        .unwrap();
    while seq.len() < 40 {
        let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
        seq.register(SeqConfig::new(name)).unwrap();
    }
    let x = seq
        .add(SeqConfig::new("X").polling(slow), Node::of(vec![]).until(1))
        .unwrap();
    let (oi, ei, xi) = (o.id(), e.id(), x.id());
    assert_eq!(xi, SeqId::from_index(40));
    let mut fault = |c: &Ctrl, _| c.flag(3);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            oi,
            Monitor::new("fault", &mut fault, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(e);
    sim.lane(x);
    sim.before_tick(|t, c| {
        c.set(3, ms(t) >= 10);
        c.set(2, ms(t) >= 11);
    });
    sim.start(oi).unwrap();
    sim.start(xi).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(15_000));
    let f = Mon(MonitorId::from_index(0));
    let of_e: Vec<Transition> = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == ei)
        .copied()
        .collect();
    assert_eq!(
        of_e,
        [
            tr(10, ei, Idle, Running, f),
            tr(11, ei, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
}

/// A polling class is due once per tick, in every word that holds one of its active
/// members. In a sequencer of two words, `fast` (id 0) polls every millisecond (the first
/// class); `x` (id 1, word 0) and `y` (id 40, word 1) poll every 2 ms (the second class),
/// on one grid from their start at 0 ms. Their exit condition (flag 3) holds from 3 ms:
/// both take it at their poll at 4 ms, `fast` at 3 ms.
#[test]
fn a_polling_class_with_members_in_two_words_polls_them_together() {
    let locked: Sequencer<Ctrl, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    class_in_two_words(&locked);
    let single: Sequencer<Ctrl, 64, 64, rtseq::lock::SingleThread, 8, 2> =
        Sequencer::single_thread();
    class_in_two_words(&single);
}

fn class_in_two_words<L: rtseq::lock::Lock>(seq: &Sequencer<Ctrl, 64, 64, L, 8, 2>) {
    let ctrl = Ctrl::default();
    let every = |n| Duration::from_millis(n);
    let until = || Node::of(vec![]).until(3);
    let fast = seq
        .add(SeqConfig::new("fast").polling(every(1)), until())
        .unwrap();
    let x = seq
        .add(SeqConfig::new("x").polling(every(2)), until())
        .unwrap();
    while seq.len() < 40 {
        let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
        seq.register(SeqConfig::new(name)).unwrap();
    }
    let y = seq
        .add(SeqConfig::new("y").polling(every(2)), until())
        .unwrap();
    let ids = [fast.id(), x.id(), y.id()];
    assert_eq!(ids.map(SeqId::index), [0, 1, 40]);
    let mut sim = Sim::new(seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(fast);
    sim.lane(x);
    sim.lane(y);
    sim.before_tick(|t, c| c.set(3, ms(t) >= 3));
    for id in ids {
        sim.start(id).unwrap();
    }
    sim.run_until(rtseq::Instant::from_ticks(6_000));
    let [f, x, y] = ids;
    assert_eq!(
        sim.trace(),
        [
            tr(0, f, Idle, Running, Start),
            tr(0, x, Idle, Running, Start),
            tr(0, y, Idle, Running, Start),
            tr(3, f, Running, Terminated, Completed),
            tr(4, x, Running, Terminated, Completed),
            tr(4, y, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
}

/// A condition on flag 2, so that one table holds many monitors of one type.
struct Flag2;

impl rtseq::Condition<Ctrl> for Flag2 {
    fn validate(&mut self, c: &Ctrl, _: rtseq::Instant) -> bool {
        c.flag(2)
    }
}

/// A table evaluates its monitors in at most 16 groups, a group's owners in one word of
/// the sets while enough groups are left for the rest of the table's capacity. Registered
/// alternately for owners in two words, the first monitors of a table of 256 get a group
/// each and the rest share one group across both words, which the tick evaluates in each
/// word for the owners there. `a` (id 5, word 0) and `b` (id 37, word 1: the same bit of
/// its word) each own ten `Level` warnings (`Nothing`) on flag 2, set from 3 ms; `b` is
/// aborted at 4 ms. Each of `a`'s warnings fires at 3, 4 and 5 ms, each of `b`'s at 3 ms.
#[test]
fn a_monitor_group_across_words_is_evaluated_for_the_owners_of_each_word() {
    let seq: Sequencer<Ctrl, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut lanes = Vec::new();
    for at in [5, 37] {
        while seq.len() < at {
            let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
        let name: &'static str = Box::leak(format!("waits {at}").into_boxed_str());
        lanes.push(
            seq.add(SeqConfig::new(name), Node::of(vec![]).until(9))
                .unwrap(),
        );
    }
    let (a, b) = (lanes[0].id(), lanes[1].id());
    assert_eq!((a.index(), b.index()), (5, 37));
    let mut monitors: Monitors<Ctrl, 256, Flag2> = Monitors::new();
    let warnings: Vec<MonitorId> = (0..20)
        .map(|i| {
            let warning = Monitor::with_condition("warning", Flag2, Behaviour::Nothing)
                .trigger(rtseq::Trigger::Level);
            monitors.add([a, b][i % 2], warning).unwrap()
        })
        .collect();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    for lane in lanes {
        sim.lane(lane);
    }
    sim.before_tick(|t, c| c.set(2, ms(t) >= 3));
    sim.start(a).unwrap();
    sim.start(b).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(3_000));
    sim.abort(b).unwrap();
    sim.run_until(rtseq::Instant::from_ticks(5_000));
    let fired: Vec<u16> = warnings.iter().map(|&m| sim.monitors().fired(m)).collect();
    assert_eq!(fired, [3, 1].repeat(10));
    assert_eq!(sim.state(a), Running);
    assert_eq!(sim.state(b), Aborted);
}

/// Registers `cycle` at `at[0]` and `feed` at `at[1]` (fillers before each), the cycle
/// running the feed blocking, the feed ending on flag 1. Returns the cycle.
fn cycle_and_feed<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    at: [SeqId; 2],
) -> rtseq::Seq<Node> {
    let mut sorted = at;
    sorted.sort();
    for id in sorted {
        while seq.len() < id.index() {
            let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
        let name = if id == at[0] { "cycle" } else { "feed" };
        assert_eq!(seq.register(SeqConfig::new(name)), Ok(id));
    }
    let feed = seq.bind(at[1], Node::of(vec![]).until(1)).unwrap();
    seq.bind(at[0], Node::of(vec![Op::Run(feed)])).unwrap()
}

/// A caller (`cycle`) running a blocking child (`feed`, exit condition flag 1 at 20 ms),
/// each with a `PauseOwner` monitor: the cycle's on flag 2 (its light curtain, monitor 0),
/// the feed's on flag 3 (its feed hold, monitor 1), each true over the given milliseconds.
/// `at`: the ids of the cycle and the feed. Returns the trace.
fn curtain_and_feed_hold<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    at: [SeqId; 2],
    curtain: std::ops::Range<u64>,
    feed_hold: std::ops::Range<u64>,
) -> Vec<Transition> {
    let ctrl = Ctrl::default();
    let cycle = cycle_and_feed(seq, at);
    let (mut on_curtain, mut on_hold) = (|c: &Ctrl, _| c.flag(2), |c: &Ctrl, _| c.flag(3));
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(
            at[0],
            Monitor::new("curtain", &mut on_curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    monitors
        .add(
            at[1],
            Monitor::new("feed hold", &mut on_hold, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(move |t, c| {
        c.set(1, ms(t) >= 20);
        c.set(2, curtain.contains(&ms(t)));
        c.set(3, feed_hold.contains(&ms(t)));
    });
    sim.start(at[0]).unwrap();
    sim.run_for(Duration::from_millis(30));
    sim.trace().to_vec()
}

/// A `PauseOwner` release and another monitor's hold in the same tick, of a caller and its
/// blocking child in different words: the release comes once every word's holds are
/// made, as in a sequencer of one word, so the child stays paused (no resume and pause
/// again in the same tick). First the cycle's curtain clears at 5 ms when the feed's own
/// hold begins; then the curtain breaks at 5 ms when the feed's hold ends.
#[test]
fn a_release_comes_after_the_holds_of_every_word() {
    let (k0, k1) = (MonitorId::from_index(0), MonitorId::from_index(1));
    let one_word = |at: [usize; 2], curtain, hold| {
        let small: Sequencer<Ctrl, 8> = Sequencer::new();
        let at = at.map(SeqId::from_index);
        (curtain_and_feed_hold(&small, at, curtain, hold), at)
    };
    let (trace, [c, f]) = one_word([0, 1], 2..5, 5..9);
    assert_eq!(
        trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(2, c, Running, Paused, Mon(k0)),
            tr(2, f, Running, Paused, Mon(k0)),
            tr(5, c, Paused, Running, Mon(k0)),
            tr(9, f, Paused, Running, Mon(k1)),
            tr(20, f, Running, Terminated, Completed),
            tr(20, c, Running, Terminated, Completed),
        ],
        "{}",
        show(&trace)
    );
    let (trace, [c, f]) = one_word([1, 0], 5..9, 2..5);
    assert_eq!(
        trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(2, f, Running, Paused, Mon(k1)),
            tr(5, c, Running, Paused, Mon(k0)),
            tr(9, c, Paused, Running, Mon(k0)),
            tr(9, f, Paused, Running, Mon(k0)),
            tr(20, f, Running, Terminated, Completed),
            tr(20, c, Running, Terminated, Completed),
        ],
        "{}",
        show(&trace)
    );
    // The same in two words, either way round, and in eight.
    for (at, curtain, hold) in [([0, 32], 2..5, 5..9), ([33, 0], 5..9, 2..5)] {
        let small_at = if at[0] < at[1] { [0, 1] } else { [1, 0] };
        let small = one_word(small_at, curtain.clone(), hold.clone()).0;
        // The one-word trace with its ids 0 and 1 moved to the lower and higher of `ids`.
        let moved = |ids: [usize; 2]| -> Vec<Transition> {
            let (low, high) = (ids[0].min(ids[1]), ids[0].max(ids[1]));
            small
                .iter()
                .map(|t| Transition {
                    sequence: SeqId::from_index(if t.sequence.index() == 0 { low } else { high }),
                    ..*t
                })
                .collect()
        };
        let two: Sequencer<Ctrl, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
        let ids = at.map(SeqId::from_index);
        let got = curtain_and_feed_hold(&two, ids, curtain.clone(), hold.clone());
        assert_eq!(show(&got), show(&moved(at)), "two words, at {at:?}");
        let eight: Sequencer<Ctrl, 256, 64, CriticalSection, 8, 8> = Sequencer::new();
        let far = at.map(|i| i * 7);
        let got = curtain_and_feed_hold(&eight, far.map(SeqId::from_index), curtain, hold);
        assert_eq!(show(&got), show(&moved(far)), "eight words, at {far:?}");
    }
}

/// A caller (`cycle`) running a blocking child (`feed`, exit condition flag 1, true at
/// 5 ms only); the cycle's `PauseOwner` monitor on flag 2 holds over 2..5 ms. Returns the
/// trace.
fn feed_under_a_curtain<const N: usize, const B: usize>(
    seq: &Sequencer<Ctrl, N, 64, CriticalSection, 8, B>,
    at: [SeqId; 2],
) -> Vec<Transition> {
    let ctrl = Ctrl::default();
    let cycle = cycle_and_feed(seq, at);
    let mut on_curtain = |c: &Ctrl, _| c.flag(2);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            at[0],
            Monitor::new("curtain", &mut on_curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(cycle);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) == 5);
        c.set(2, (2..5).contains(&ms(t)));
    });
    sim.start(at[0]).unwrap();
    sim.run_for(Duration::from_millis(30));
    sim.trace().to_vec()
}

/// A child paused with its caller in the tick's work in an earlier word misses the poll
/// due in that tick, also when its own word is scanned after the pause: it is not woken
/// for it, and does not take it when the pause ends (its exit condition, true at the
/// release only, is not checked then). As in a sequencer of one word.
#[test]
fn a_child_paused_in_an_earlier_word_of_the_tick_misses_its_poll() {
    let k = MonitorId::from_index(0);
    let (c, f) = (SeqId::from_index(0), SeqId::from_index(1));
    let small: Sequencer<Ctrl, 8> = Sequencer::new();
    let trace = feed_under_a_curtain(&small, [c, f]);
    assert_eq!(
        trace,
        vec![
            tr(0, c, Idle, Running, Start),
            tr(0, f, Idle, Running, Start),
            tr(2, c, Running, Paused, Mon(k)),
            tr(2, f, Running, Paused, Mon(k)),
            tr(5, c, Paused, Running, Mon(k)),
            tr(5, f, Paused, Running, Mon(k)),
        ],
        "{}",
        show(&trace)
    );
    let far = SeqId::from_index(32);
    let two: Sequencer<Ctrl, 64, 64, CriticalSection, 8, 2> = Sequencer::new();
    let moved: Vec<Transition> = trace
        .iter()
        .map(|t| Transition {
            sequence: if t.sequence == f { far } else { t.sequence },
            ..*t
        })
        .collect();
    let got = feed_under_a_curtain(&two, [c, far]);
    assert_eq!(show(&got), show(&moved));
}
