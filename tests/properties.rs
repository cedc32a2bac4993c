//! Property test: random trees (depth up to 4, up to 12 sequences and steps), random
//! condition flips, monitors (every behaviour, `PauseOwner` included), timeouts, pauses and
//! aborts; invariants checked on the trace. Then every condition is let go (monitors clear,
//! exit conditions hold) and everything resumed: every sequence must come to rest.

mod common;
use common::*;
use proptest::prelude::*;
use rtseq::sim::Sim;
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Cause, Duration, Instant, Monitor, MonitorId, Monitors, SeqConfig, SeqId, Sequencer,
    Transition, Trigger, Wait,
};

#[derive(Clone, Debug)]
struct NodePlan {
    parent_pick: usize,
    is_step: bool,
    non_blocking: bool,
    join: bool,
    exit_flag: Option<usize>,
    pre_flag: Option<usize>,
    timeout_ms: Option<u64>,
}

#[derive(Clone, Debug)]
struct MonPlan {
    owner_pick: usize,
    flag: usize,
    behaviour: usize,
    level: bool,
    exception_ms: Option<u64>,
    limit: u8,
}

#[derive(Clone, Debug)]
enum Event {
    Flip(usize, bool),
    Pause(usize),
    Resume(usize),
    Abort(usize),
    AbortAll,
}

#[derive(Clone, Debug)]
struct Plan {
    nodes: Vec<NodePlan>,
    monitors: Vec<MonPlan>,
    events: Vec<(u64, Event)>,
}

const BEHAVIOURS: [Behaviour; 6] = [
    Behaviour::Nothing,
    Behaviour::AbortOwner,
    Behaviour::RestartOwner,
    Behaviour::AbortCallerOfOwner,
    Behaviour::RestartCallerOfOwner,
    Behaviour::PauseOwner,
];

fn node_plan() -> impl Strategy<Value = NodePlan> {
    (
        any::<usize>(),
        prop::bool::weighted(0.5),
        prop::bool::weighted(0.3),
        any::<bool>(),
        prop::option::weighted(0.7, 0usize..8),
        prop::option::weighted(0.1, 0usize..8),
        prop::option::weighted(0.2, 5u64..40),
    )
        .prop_map(
            |(parent_pick, is_step, non_blocking, join, exit_flag, pre_flag, timeout_ms)| {
                NodePlan {
                    parent_pick,
                    is_step,
                    non_blocking,
                    join,
                    exit_flag,
                    pre_flag,
                    timeout_ms,
                }
            },
        )
}

fn mon_plan() -> impl Strategy<Value = MonPlan> {
    (
        any::<usize>(),
        8usize..12,
        0usize..BEHAVIOURS.len(),
        prop::bool::weighted(0.2),
        prop::option::weighted(0.5, 0u64..4),
        0u8..4,
    )
        .prop_map(
            |(owner_pick, flag, behaviour, level, exception_ms, limit)| MonPlan {
                owner_pick,
                flag,
                behaviour,
                level,
                exception_ms,
                limit,
            },
        )
}

fn event() -> impl Strategy<Value = (u64, Event)> {
    let kind = prop_oneof![
        8 => (0usize..12, any::<bool>()).prop_map(|(f, v)| Event::Flip(f, v)),
        1 => any::<usize>().prop_map(Event::Pause),
        1 => any::<usize>().prop_map(Event::Resume),
        1 => any::<usize>().prop_map(Event::Abort),
        1 => Just(Event::AbortAll),
    ];
    (0u64..100, kind)
}

fn plan() -> impl Strategy<Value = Plan> {
    (
        prop::collection::vec(node_plan(), 1..12),
        prop::collection::vec(mon_plan(), 0..5),
        prop::collection::vec(event(), 0..40),
    )
        .prop_map(|(nodes, monitors, mut events)| {
            events.sort_by_key(|e| e.0);
            Plan {
                nodes,
                monitors,
                events,
            }
        })
}

/// The typed objects of one tree node before they are assembled.
enum Built {
    Step(rtseq::Seq<Leaf>),
    Node(rtseq::Seq<Node>),
}

struct Outcome {
    trace: Vec<Transition>,
    lines_ok: Result<(), String>,
    fired: Vec<u16>,
    exception_of: Vec<Option<SeqId>>,
    behaviours: Vec<(Behaviour, u8, SeqId)>,
    parent: Vec<Option<SeqId>>,
    stalled: bool,
    lost: u32,
    not_run: u16,
    /// The sequences not at rest (idle, terminated or aborted) once everything was let go.
    restless: Vec<(SeqId, RunningState)>,
}

#[allow(clippy::needless_range_loop)] // node indices are ids: index loops read best
/// Simulates plan `p` in a sequencer of capacity `N` (sets of `B` words) in which `offset`
/// sequences, never started, come before the tree: with `B > 1` and an offset near 32 the
/// tree spans two words of the sets.
fn simulate<const N: usize, const B: usize>(p: &Plan, offset: usize) -> Outcome {
    // Up to 24 lanes (main, non-blocking children, exception sequences): `W` = 24.
    let seq: Sequencer<Ctrl, N, 256, rtseq::lock::CriticalSection, 24, B> = Sequencer::new();
    let ctrl = Ctrl::default();
    for k in 0..offset {
        let name: &'static str = Box::leak(format!("pad{k}").into_boxed_str());
        seq.register(SeqConfig::new(name)).unwrap();
    }
    // Node `i`'s id.
    let node = |i: usize| SeqId::from_index(offset + i);
    let n = p.nodes.len() + 1; // node 0 is the main sequence
                               // Shape: kinds, parents, depths.
    let mut is_step = vec![false; n];
    let mut parent = vec![None; n];
    let mut depth = vec![0usize; n];
    let mut non_blocking = vec![false; n];
    for (k, np) in p.nodes.iter().enumerate() {
        let i = k + 1;
        let candidates: Vec<usize> = (0..i).filter(|&j| !is_step[j] && depth[j] < 3).collect();
        let par = candidates[np.parent_pick % candidates.len()];
        parent[i] = Some(par);
        depth[i] = depth[par] + 1;
        is_step[i] = np.is_step;
        non_blocking[i] = !np.is_step && np.non_blocking;
    }
    // Register in index order: node `i` is `node(i)`.
    let mut built: Vec<Option<Built>> = Vec::new();
    for i in 0..n {
        let np = if i == 0 { None } else { Some(&p.nodes[i - 1]) };
        let name: &'static str = Box::leak(format!("n{i}").into_boxed_str());
        let mut cfg = SeqConfig::new(name);
        if let Some(t) = np.and_then(|np| np.timeout_ms) {
            cfg = cfg.timeout(Duration::from_millis(t));
        }
        let exit = np.and_then(|np| np.exit_flag);
        let pre = np.and_then(|np| np.pre_flag);
        built.push(Some(if is_step[i] {
            Built::Step(seq.add(cfg, Leaf { pre, exit }).unwrap())
        } else {
            Built::Node(
                seq.add(
                    cfg,
                    Node {
                        ops: vec![],
                        pre,
                        exit,
                    },
                )
                .unwrap(),
            )
        }));
    }
    // Exception sequences: one per monitor that has one (a Wait of 0..4 ms inside a Node).
    let mut exception_ids = Vec::new();
    let mut exception_seqs = Vec::new();
    for (k, mp) in p.monitors.iter().enumerate() {
        if let Some(ms) = mp.exception_ms {
            let wname: &'static str = Box::leak(format!("w{k}").into_boxed_str());
            let ename: &'static str = Box::leak(format!("e{k}").into_boxed_str());
            let w = seq
                .add(SeqConfig::new(wname), Wait::new(Duration::from_millis(ms)))
                .unwrap();
            let e = seq
                .add(SeqConfig::new(ename), Node::of(vec![Op::Wait(w)]))
                .unwrap();
            exception_ids.push(Some(e.id()));
            exception_seqs.push(e);
        } else {
            exception_ids.push(None);
        }
    }
    // Assemble bottom-up: children have larger indices than their parents.
    let mut lanes: Vec<rtseq::Seq<Node>> = Vec::new();
    let mut ops: Vec<Vec<Op>> = (0..n).map(|_| Vec::new()).collect();
    for i in (1..n).rev() {
        let par = parent[i].unwrap();
        let id = node(i);
        let mut child_ops = std::mem::take(&mut ops[i]);
        child_ops.reverse();
        let b = built[i].take().unwrap();
        let mut new_ops = Vec::new();
        match b {
            Built::Step(s) => new_ops.push(Op::Step(s)),
            Built::Node(mut s) => {
                s.body_mut().ops = child_ops;
                if non_blocking[i] {
                    new_ops.push(Op::Start(id));
                    if p.nodes[i - 1].join {
                        // Pushed in reverse: the join comes after the start.
                        new_ops.insert(0, Op::Join(id));
                    }
                    lanes.push(s);
                } else {
                    new_ops.push(Op::Run(s));
                }
            }
        }
        ops[par].extend(new_ops);
    }
    let Some(Built::Node(mut main)) = built[0].take() else {
        unreachable!()
    };
    let mut main_ops = std::mem::take(&mut ops[0]);
    main_ops.reverse();
    main.body_mut().ops = main_ops;

    // Monitors.
    let mut conds: Vec<Box<dyn rtseq::Condition<Ctrl> + Send>> = p
        .monitors
        .iter()
        .map(|mp| {
            let f = mp.flag;
            Box::new(move |c: &Ctrl, _: Instant| c.flag(f))
                as Box<dyn rtseq::Condition<Ctrl> + Send>
        })
        .collect();
    let mut monitors: Monitors<Ctrl, 8> = Monitors::new();
    let mut behaviours = Vec::new();
    for ((mp, cond), exc) in p.monitors.iter().zip(conds.iter_mut()).zip(&exception_ids) {
        let owner = node(mp.owner_pick % n);
        let b = BEHAVIOURS[mp.behaviour];
        let mut m = Monitor::new("m", cond.as_mut(), b)
            .restart_limit(mp.limit)
            .trigger(if mp.level {
                Trigger::Level
            } else {
                Trigger::RisingEdge
            });
        if let Some(e) = exc {
            m = m.exception(*e);
        }
        monitors.add(owner, m).unwrap();
        behaviours.push((b, mp.limit, owner));
    }
    let mid = main.id();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    for l in lanes {
        sim.lane(l);
    }
    for e in exception_seqs {
        sim.lane(e);
    }
    let flips: Vec<(u64, usize, bool)> = p
        .events
        .iter()
        .filter_map(|(t, e)| match e {
            Event::Flip(f, v) => Some((*t, *f, *v)),
            _ => None,
        })
        .collect();
    sim.before_tick(move |t, c| {
        for &(at, f, v) in &flips {
            if at == ms(t) {
                c.set(f, v);
            }
        }
    });
    sim.start(mid).unwrap();
    for (t, e) in &p.events {
        sim.run_until(Instant::from_ticks(t * 1000));
        let pick = |k: usize| node(k % n);
        let _ = match e {
            Event::Pause(k) => sim.pause(pick(*k)),
            Event::Resume(k) => sim.resume(pick(*k)),
            Event::Abort(k) => sim.abort(pick(*k)),
            Event::AbortAll => {
                sim.abort_all();
                Ok(())
            }
            Event::Flip(..) => Ok(()),
        };
    }
    sim.run_until(Instant::from_ticks(150_000));
    // Let go: no monitor condition holds, every exit condition does; once the monitors
    // have seen that (a resume request is refused while a monitor holds), everything is
    // resumed.
    for f in 0..12 {
        ctrl.set(f, f < 8);
    }
    sim.run_until(Instant::from_ticks(200_000));
    for k in 0..seq.len() {
        let _ = sim.resume(SeqId::from_index(k));
    }
    sim.run_until(Instant::from_ticks(450_000));
    let restless = (0..seq.len())
        .map(SeqId::from_index)
        .map(|id| (id, sim.state(id)))
        .filter(|&(_, s)| !matches!(s, Idle | Terminated | Aborted))
        .collect();
    let fired = (0..p.monitors.len())
        .map(|k| sim.monitors().fired(MonitorId::from_index(k)))
        .collect();
    let stalled = sim.stalled();
    let lost = sim.lost();
    let trace = sim.take_trace();
    drop(sim);
    let lines_ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        assert_lines_ran_live(&ctrl)
    }))
    .map_err(|_| "an action line ran while its sequence was not live".to_string());
    // The parent of each sequence, by id.
    let mut parent_ids: Vec<Option<SeqId>> = vec![None; seq.len()];
    for (i, p) in parent.iter().enumerate() {
        parent_ids[offset + i] = p.map(node);
    }
    Outcome {
        trace,
        lines_ok,
        fired,
        exception_of: exception_ids,
        behaviours,
        parent: parent_ids,
        stalled,
        lost,
        not_run: seq.exceptions_not_run(),
        restless,
    }
}

/// The invariants, in a sequencer of one word and in one whose sets have two words (the
/// tree across ids 28 to 40 at most, its exception sequences after).
fn check(p: &Plan) -> Result<(), TestCaseError> {
    check_outcome(simulate::<24, 1>(p, 0))?;
    check_outcome(simulate::<64, 2>(p, 28))
}

fn check_outcome(o: Outcome) -> Result<(), TestCaseError> {
    prop_assert!(!o.stalled, "a lane livelocked");
    prop_assert_eq!(o.lost, 0);
    prop_assert!(
        o.restless.is_empty(),
        "not at rest after letting go: {:?}",
        o.restless
    );
    // A `PauseOwner` monitor that holds again while its exception sequence (an alarm)
    // still runs from its last hold finds it running: not run, and counted. No other
    // exception sequence is ever refused.
    let pause_owner = |k: usize| o.behaviours[k].0 == Behaviour::PauseOwner;
    let pause_firings: u32 = (0..o.fired.len())
        .filter(|&k| pause_owner(k) && o.exception_of[k].is_some())
        .map(|k| u32::from(o.fired[k]))
        .sum();
    prop_assert!(
        u32::from(o.not_run) <= pause_firings,
        "an exception sequence could not run"
    );
    o.lines_ok.clone().map_err(TestCaseError::fail)?;
    let len = o.parent.len();
    let mut state = vec![Idle; len];
    let mut caller: Vec<Option<SeqId>> = vec![None; len];
    let mut last_time = 0;
    let mut exc_runs = vec![0u16; o.fired.len()];
    // Restarts caused by monitor k in the current run of its target.
    let mut restarts_in_run: Vec<std::collections::HashMap<SeqId, u8>> =
        vec![Default::default(); o.fired.len()];
    for t in &o.trace {
        // Time never goes backwards.
        prop_assert!(
            t.time.as_ticks() >= last_time,
            "time went backwards at {t:?}"
        );
        last_time = t.time.as_ticks();
        let i = t.sequence.index();
        // Only legal transitions, from the state the sequence was really in.
        prop_assert_eq!(state[i], t.from, "{:?}", t);
        prop_assert!(t.from.can_transition_to(t.to), "illegal {:?}", t);
        if t.to == Running && matches!(t.from, Idle | Terminated | Aborted) {
            caller[i] = match t.cause {
                Cause::Monitor(m) => o.behaviours.get(m.index()).map(|b| b.2),
                Cause::Timeout(owner) => Some(owner),
                _ => o.parent[i],
            };
            if let Cause::Monitor(m) = t.cause {
                prop_assert_eq!(o.exception_of[m.index()], Some(t.sequence));
                exc_runs[m.index()] += 1;
            }
            for r in restarts_in_run.iter_mut() {
                r.remove(&t.sequence);
            }
        }
        // Every sub-sequence of an aborted (or restarting) sequence is aborted before it.
        if matches!(t.to, Aborting | Restarting) {
            for d in 0..len {
                if !is_active(state[d]) {
                    continue;
                }
                let mut c = caller[d];
                while let Some(x) = c {
                    prop_assert!(
                        x != t.sequence,
                        "n{} still {:?} when its ancestor n{} went {:?}",
                        d,
                        state[d],
                        i,
                        t.to
                    );
                    c = caller[x.index()];
                }
            }
        }
        if t.to == Restarting {
            if let Cause::Monitor(m) = t.cause {
                let (b, limit, _) = o.behaviours[m.index()];
                prop_assert!(b.is_restart());
                let n = restarts_in_run[m.index()].entry(t.sequence).or_insert(0);
                *n += 1;
                prop_assert!(*n <= limit, "restart limit {} exceeded by {:?}", limit, t);
            }
        }
        state[i] = t.to;
    }
    // Each monitor firing ran its exception sequence exactly once (a `PauseOwner` hold at
    // most once: see above).
    for (k, exc) in o.exception_of.iter().enumerate() {
        if exc.is_some() && pause_owner(k) {
            prop_assert!(
                exc_runs[k] <= o.fired[k],
                "monitor {} ran its alarm more often than it held",
                k
            );
        } else if exc.is_some() {
            prop_assert_eq!(
                exc_runs[k],
                o.fired[k],
                "monitor {} fired vs exception runs",
                k
            );
        }
    }
    Ok(())
}

fn is_active(s: RunningState) -> bool {
    s.is_active()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]
    #[test]
    fn invariants_hold_on_random_trees(p in plan()) {
        check(&p)?;
    }
}
