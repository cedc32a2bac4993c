//! Sequencers of several words: the scenarios the small-sequencer suites pin (behaviours,
//! pauses, `PauseOwner` holds, restarts and their budget, caller behaviours, timeouts,
//! polling classes, joins, abort-all) run in a sequencer of 256 with each participant in a
//! word of its own, and give, id for id, what they give in a sequencer of one word: the
//! same records (transitions and events), action lines, results handed to callers, final
//! states and outcomes, monitor counts and request results.
//!
//! A scenario names its participants by role; [`across_words`] runs it once with the
//! roles packed at ids 0, 1, 2, … of a sequencer of 16 and once per layout in a sequencer
//! of 256, with filler sequences registered so that role `i` gets the id `at[i]`, and
//! compares the observations with the packed ids renamed. [`across_time`] runs them from
//! times around the wrap of the sequencer's 32-bit deadlines (and of its 48-bit run
//! clocks) and compares them with the run from 0.

mod common;
use common::*;
use rtseq::lock::CriticalSection;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Duration, Instant, Monitor, Monitors, SeqConfig, SeqId, Sequencer, Trigger, Wait,
};

/// The sequencers compared: one word (`B = 1`) and eight.
type Seqr<const N: usize, const B: usize> = Sequencer<Ctrl, N, 256, CriticalSection, 16, B>;

/// One participant per role; [`Scenario::run`] gets their ids.
trait Scenario {
    /// The configurations of the roles, given the ids they will have (a timeout's
    /// exception sequence names one).
    fn configs(&self, ids: &[SeqId]) -> Vec<SeqConfig<Ctrl>>;
    /// Runs the scenario on `seq`, whose roles are registered (not bound) at `ids`, from
    /// the time `base` on, and returns what it observed (see [`observe`]), times from
    /// `base`.
    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String>;
}

/// Registers the roles at the ids `at` (fillers in between), runs the scenario.
fn run_at<S: Scenario, const N: usize, const B: usize>(
    scenario: &S,
    seq: &Seqr<N, B>,
    at: &[usize],
    base: Instant,
) -> Vec<String> {
    let ids: Vec<SeqId> = at.iter().map(|&i| SeqId::from_index(i)).collect();
    let mut configs: Vec<Option<SeqConfig<Ctrl>>> =
        scenario.configs(&ids).into_iter().map(Some).collect();
    assert_eq!(configs.len(), at.len());
    let mut order: Vec<usize> = (0..at.len()).collect();
    order.sort_by_key(|&role| at[role]);
    for role in order {
        fill_to(seq, at[role]);
        let config = configs[role].take().unwrap();
        assert_eq!(seq.register(config), Ok(ids[role]));
    }
    scenario.run(seq, &ids, base)
}

/// Registers filler sequences until the next id is `index`.
fn fill_to<const N: usize, const B: usize>(seq: &Seqr<N, B>, index: usize) {
    while seq.len() < index {
        let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
        seq.register(SeqConfig::new(name)).unwrap();
    }
}

/// Runs `scenario` packed in one word and in each layout of `layouts` over eight words;
/// asserts the observations are the same (packed ids renamed). Returns the packed one.
fn across_words<S: Scenario>(scenario: &S, layouts: &[&[usize]]) -> Vec<String> {
    let roles = layouts[0].len();
    let packed: Vec<usize> = (0..roles).collect();
    let small: Seqr<16, 1> = Sequencer::new();
    let want = run_at(scenario, &small, &packed, Instant::from_ticks(0));
    for at in layouts {
        assert_eq!(at.len(), roles);
        let big: Seqr<256, 8> = Sequencer::new();
        let got = run_at(scenario, &big, at, Instant::from_ticks(0));
        let renamed = rename(&want, at);
        assert_eq!(
            got.join("\n"),
            renamed.join("\n"),
            "layout {at:?} differs from one word"
        );
    }
    want
}

/// Ms from `base` to `t`.
fn since(t: Instant, base: Instant) -> u64 {
    (t.as_ticks() - base.as_ticks()) / 1000
}

/// `lines` with every `SeqId(i)` of a role's packed id `i` written `SeqId(at[i])`.
fn rename(lines: &[String], at: &[usize]) -> Vec<String> {
    const TAG: &str = "SeqId(";
    lines
        .iter()
        .map(|line| {
            let mut out = String::new();
            let mut rest = line.as_str();
            while let Some(p) = rest.find(TAG) {
                out.push_str(&rest[..p + TAG.len()]);
                rest = &rest[p + TAG.len()..];
                let end = rest.find(')').unwrap();
                let i: usize = rest[..end].parse().unwrap();
                out.push_str(&at.get(i).copied().unwrap_or(i).to_string());
                rest = &rest[end..];
            }
            out.push_str(rest);
            out
        })
        .collect()
}

/// What a run showed: every record (µs from `base`), the action lines and the results
/// handed to callers (ms from `base`), each role's final state and outcome, the monitors'
/// firing counts, and `extra` (results of requests, ...).
fn observe<const N: usize, const T: usize, const M: usize, K, const W: usize, const B: usize>(
    sim: &Sim<'_, Ctrl, N, T, M, K, W, B>,
    ctrl: &Ctrl,
    ids: &[SeqId],
    base: Instant,
    extra: Vec<String>,
) -> Vec<String>
where
    K: rtseq::Condition<Ctrl>,
{
    assert_eq!(sim.lost(), 0);
    assert_eq!(sim.tick_error(), None);
    let base_ms = base.as_ticks() / 1000;
    let mut seen: Vec<String> = sim
        .records()
        .iter()
        .map(|r| format!("{:>8} {:?}", r.time.as_ticks() - base.as_ticks(), r.entry))
        .collect();
    for l in ctrl.lines.borrow().iter() {
        seen.push(format!(
            "line {} {:?}",
            l.ms - base_ms,
            Line { ms: 0, ..*l }
        ));
    }
    for r in ctrl.returned.borrow().iter() {
        seen.push(format!(
            "returned {} {:?}",
            r.ms - base_ms,
            Returned { ms: 0, ..*r }
        ));
    }
    seen.extend(ctrl.hooks.borrow().iter().map(|h| format!("hook {h}")));
    for &id in ids {
        let h = sim.handle(id).unwrap();
        seen.push(format!(
            "{id:?}: {:?} {:?} callers {:?}",
            h.state(),
            h.last_outcome(),
            h.caller_stack().iter().collect::<Vec<_>>()
        ));
    }
    seen.extend(extra);
    seen.push(format!("now {}", sim.now().as_ticks() - base.as_ticks()));
    seen
}

/// Layouts of up to ten roles over the eight words. Each role in a word of its own:
const SPREAD: &[usize] = &[0, 40, 70, 100, 130, 170, 200, 230, 250, 255];
/// On the words' boundaries:
const EDGES: &[usize] = &[31, 32, 63, 64, 95, 96, 127, 128, 159, 160];
/// At the same bit (5) of each word, then the last ids:
const SAME_BIT: &[usize] = &[5, 37, 69, 101, 133, 165, 197, 229, 254, 255];

/// In the opposite order of the roles, each in a word of its own:
const REVERSED: &[usize] = &[255, 200, 160, 130, 100, 64, 63, 32, 31, 1];

/// The first `n` ids of each layout.
fn layouts(n: usize) -> [&'static [usize]; 4] {
    [&SPREAD[..n], &EDGES[..n], &SAME_BIT[..n], &REVERSED[..n]]
}

/// The first `n` ids of each layout that keeps the order of the roles' ids (a teardown
/// takes a depth of its tree in the order of the ids: two siblings whose ids are in the
/// other order go the other way round).
fn ordered_layouts(n: usize) -> [&'static [usize]; 3] {
    [&SPREAD[..n], &EDGES[..n], &SAME_BIT[..n]]
}

// ---------------------------------------------------------------------------------------
// The behaviours (tests/behaviours.rs)

/// main ─run→ P ─run→ A ─step→ S (exit: flag 1, from 10 ms). A monitor of A on flag 0
/// (true at 5 ms only) with `behaviour`, and, `with_exception`, the exception sequence E
/// (a step of W, a 2 ms wait). Roles: main, P, A, S, E, W.
struct Behaviours {
    behaviour: Behaviour,
    with_exception: bool,
}

impl Scenario for Behaviours {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        ["main", "P", "A", "S", "E", "W"].map(SeqConfig::new).into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[main, p, a, s, e, w] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let s = seq.bind(s, Leaf::until(1)).unwrap();
        let a = seq.bind(a, Node::of(vec![Op::Step(s)])).unwrap();
        let p = seq.bind(p, Node::of(vec![Op::Run(a)])).unwrap();
        let main_seq = seq.bind(main, Node::of(vec![Op::Run(p)])).unwrap();
        let w = seq.bind(w, Wait::new(Duration::from_millis(2))).unwrap();
        let e_seq = seq.bind(e, Node::of(vec![Op::Wait(w)])).unwrap();
        let mut flag0 = |c: &Ctrl, _| c.flag(0);
        let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
        let mut def = Monitor::new("m", &mut flag0, self.behaviour);
        if self.with_exception {
            def = def.exception(e);
        }
        monitors.add(ids[2], def).unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(main_seq);
        sim.lane(e_seq);
        sim.before_tick(move |t, c| {
            c.set(0, since(t, base) == 5);
            c.set(1, since(t, base) >= 10);
        });
        sim.start(main).unwrap();
        let idle = sim
            .run_until_idle(Duration::from_millis(50))
            .map(|t| since(t, base));
        let fired = sim.monitors().fired(rtseq::MonitorId::from_index(0));
        observe(
            &sim,
            &ctrl,
            ids,
            base,
            vec![format!("idle {idle:?} fired {fired}")],
        )
    }
}

/// Each behaviour, with and without an exception sequence, gives the same records, lines,
/// results and outcomes with its participants in different words, in either order of ids.
#[test]
fn every_behaviour_acts_the_same_across_words() {
    use Behaviour::*;
    for behaviour in [
        Nothing,
        AbortOwner,
        RestartOwner,
        AbortCallerOfOwner,
        RestartCallerOfOwner,
        PauseOwner,
    ] {
        for with_exception in [false, true] {
            let scenario = Behaviours {
                behaviour,
                with_exception,
            };
            let seen = across_words(&scenario, &layouts(6));
            assert!(seen.iter().any(|l| l.contains("Transition")));
        }
    }
}

// ---------------------------------------------------------------------------------------
// Pause and resume requests (tests/pause.rs, tests/scenarios.rs)

/// What the operator asks of a sequence at a time (ms).
#[derive(Clone, Copy, Debug)]
enum Ask {
    Pause,
    Resume,
    Abort,
    AbortAll,
    Start,
}

/// Runs `sim` to each time of `asks` and makes the request of the role; returns each
/// request's result, then runs to `end_ms`.
fn operate<const N: usize, const T: usize, const M: usize, K, const W: usize, const B: usize>(
    sim: &mut Sim<'_, Ctrl, N, T, M, K, W, B>,
    ids: &[SeqId],
    base: Instant,
    asks: &[(u64, Ask, usize)],
    end_ms: u64,
) -> Vec<String>
where
    K: rtseq::Condition<Ctrl>,
{
    let at = |t: u64| Instant::from_ticks(base.as_ticks() + t * 1000);
    let mut results = Vec::new();
    for &(t, ask, role) in asks {
        sim.run_until(at(t));
        let id = ids[role];
        let result = match ask {
            Ask::Pause => sim.pause(id),
            Ask::Resume => sim.resume(id),
            Ask::Abort => sim.abort(id),
            Ask::Start => sim.start(id),
            Ask::AbortAll => {
                sim.abort_all();
                Ok(())
            }
        };
        results.push(format!("{t} ms {ask:?} {id:?}: {result:?}"));
    }
    sim.run_until(at(end_ms));
    results
}

/// main starts N (non-blocking, ends on flag 2 from 150 ms) and runs C (timeout 100 ms)
/// blocking; C steps W (a 50 ms wait), then S (exit flag 1, never; timeout 20 ms). The
/// operator pauses and resumes as `asks` says. Roles: main, C, W, S, N.
struct Pauses {
    asks: &'static [(u64, Ask, usize)],
}

impl Scenario for Pauses {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        let ms = Duration::from_millis;
        vec![
            SeqConfig::new("main"),
            SeqConfig::new("C").timeout(ms(100)),
            SeqConfig::new("W"),
            SeqConfig::new("S").timeout(ms(20)),
            SeqConfig::new("N"),
        ]
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[main, c, w, s, n] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let w = seq.bind(w, Wait::new(Duration::from_millis(50))).unwrap();
        let s = seq.bind(s, Leaf::until(1)).unwrap();
        let c = seq
            .bind(c, Node::of(vec![Op::Wait(w), Op::Step(s)]))
            .unwrap();
        let main_seq = seq
            .bind(main, Node::of(vec![Op::Start(n), Op::Run(c)]))
            .unwrap();
        let n = seq.bind(n, Node::of(vec![]).until(2)).unwrap();
        let mut sim = Sim::new(seq, &ctrl, Monitors::<Ctrl, 1>::new())
            .starting_at(base)
            .unwrap();
        sim.lane(main_seq);
        sim.lane(n);
        sim.before_tick(move |t, c| c.set(2, since(t, base) >= 150));
        sim.start(main).unwrap();
        let results = operate(&mut sim, ids, base, self.asks, 300);
        observe(&sim, &ctrl, ids, base, results)
    }
}

/// A tree paused at its root, a pause asked twice (`AlreadyPaused`), a pause of a paused
/// caller's child, and the resumes: the wait and the timeouts count unpaused time alike,
/// whichever words the caller, its blocking children and its non-blocking child are in.
#[test]
fn pauses_and_resumes_of_a_tree_across_words_act_as_in_one_word() {
    use Ask::*;
    let seen = across_words(
        &Pauses {
            asks: &[
                (30, Pause, 0),
                (35, Pause, 0),
                (40, Pause, 1),
                (60, Resume, 0),
                (70, Resume, 1),
                (90, Pause, 1),
                (95, Resume, 1),
                (96, Resume, 1),
            ],
        },
        &layouts(5),
    );
    assert!(seen.contains(&"35 ms Pause SeqId(0): Err(AlreadyPaused(SeqId(0)))".to_string()));
}

/// An abort of the root while it is paused, a second abort (`NotRunning`), a start again,
/// an abort-all, starts refused (`AlreadyRunning`, `NoLane`) and a resume of a sequence
/// not paused (`NotPaused`).
#[test]
fn aborts_of_a_paused_tree_across_words_act_as_in_one_word() {
    use Ask::*;
    across_words(
        &Pauses {
            asks: &[
                (30, Pause, 0),
                (40, Abort, 0),
                (41, Abort, 0),
                (45, Start, 0),
                (46, Start, 4),
                (60, AbortAll, 0),
                (61, Start, 1),
                (62, Resume, 1),
            ],
        },
        &ordered_layouts(5),
    );
}

// ---------------------------------------------------------------------------------------
// PauseOwner (tests/pause_owner.rs)

/// cycle ─step→ move (exit flag 1, from 20 ms). Monitors of the cycle: `curtain`
/// (`PauseOwner`, flag 2, exception `alarm`) and `following error` (`RestartOwner`, flag 3,
/// exception `safe stop`, a step of `dwell`, 2 ms). Roles: cycle, move, alarm, safe stop,
/// dwell.
struct Curtain {
    curtain: fn(u64) -> bool,
    error: fn(u64) -> bool,
    asks: &'static [(u64, Ask, usize)],
}

impl Scenario for Curtain {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        ["cycle", "move", "alarm", "safe stop", "dwell"]
            .map(SeqConfig::new)
            .into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[cycle, step, alarm, stop, dwell] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let step = seq.bind(step, Leaf::until(1)).unwrap();
        let cycle_seq = seq.bind(cycle, Node::of(vec![Op::Step(step)])).unwrap();
        let alarm_seq = seq.bind(alarm, Node::of(vec![])).unwrap();
        let dwell = seq
            .bind(dwell, Wait::new(Duration::from_millis(2)))
            .unwrap();
        let stop_seq = seq.bind(stop, Node::of(vec![Op::Wait(dwell)])).unwrap();
        let mut broken = |c: &Ctrl, _| c.flag(2);
        let mut lagging = |c: &Ctrl, _| c.flag(3);
        let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
        monitors
            .add(
                cycle,
                Monitor::new("curtain", &mut broken, Behaviour::PauseOwner).exception(alarm),
            )
            .unwrap();
        monitors
            .add(
                cycle,
                Monitor::new("following error", &mut lagging, Behaviour::RestartOwner)
                    .exception(stop),
            )
            .unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(cycle_seq);
        sim.lane(alarm_seq);
        sim.lane(stop_seq);
        let (curtain, error) = (self.curtain, self.error);
        sim.before_tick(move |t, c| {
            c.set(1, since(t, base) >= 20);
            c.set(2, curtain(since(t, base)));
            c.set(3, error(since(t, base)));
        });
        sim.start(cycle).unwrap();
        let mut results = operate(&mut sim, ids, base, self.asks, 40);
        let fired = [0, 1].map(|i| sim.monitors().fired(rtseq::MonitorId::from_index(i)));
        results.push(format!("fired {fired:?}"));
        observe(&sim, &ctrl, ids, base, results)
    }
}

/// A broken curtain pauses the cycle (alarm, another word), a following error while paused
/// restarts it through its safe stop (another word), an operator's pause outlasts the
/// curtain, a resume while the curtain holds is refused (`HeldByMonitor`).
#[test]
fn a_curtain_and_a_following_error_across_words_act_as_in_one_word() {
    use Ask::*;
    let seen = across_words(
        &Curtain {
            curtain: |t| (3..8).contains(&t) || (12..15).contains(&t),
            error: |t| t == 5,
            asks: &[(13, Resume, 0), (14, Pause, 0), (17, Resume, 0)],
        },
        &layouts(5),
    );
    assert!(seen.contains(&"13 ms Resume SeqId(0): Err(HeldByMonitor(SeqId(0)))".to_string()));
}

/// cycle ─run→ feed (exit flag 1 from 20 ms); the cycle's curtain (`PauseOwner`, flag 2),
/// the feed's own hold (`PauseOwner`, flag 3); the operator's requests of the feed.
/// Roles: cycle, feed.
struct CycleAndFeed {
    curtain: fn(u64) -> bool,
    feed: fn(u64) -> bool,
    asks: &'static [(u64, Ask, usize)],
}

impl Scenario for CycleAndFeed {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        vec![
            SeqConfig::new("cycle"),
            SeqConfig::new("feed").timeout(Duration::from_millis(30)),
        ]
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[cycle, feed] = ids else { unreachable!() };
        let ctrl = Ctrl::default();
        let feed_seq = seq.bind(feed, Node::of(vec![]).until(1)).unwrap();
        let cycle_seq = seq.bind(cycle, Node::of(vec![Op::Run(feed_seq)])).unwrap();
        let mut on_curtain = |c: &Ctrl, _| c.flag(2);
        let mut on_feed = |c: &Ctrl, _| c.flag(3);
        let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
        monitors
            .add(
                cycle,
                Monitor::new("curtain", &mut on_curtain, Behaviour::PauseOwner),
            )
            .unwrap();
        monitors
            .add(
                feed,
                Monitor::new("feed hold", &mut on_feed, Behaviour::PauseOwner),
            )
            .unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(cycle_seq);
        let (curtain, hold) = (self.curtain, self.feed);
        sim.before_tick(move |t, c| {
            c.set(1, since(t, base) >= 20);
            c.set(2, curtain(since(t, base)));
            c.set(3, hold(since(t, base)));
        });
        sim.start(cycle).unwrap();
        let results = operate(&mut sim, ids, base, self.asks, 40);
        observe(&sim, &ctrl, ids, base, results)
    }
}

/// The cases of tests/pause_owner.rs for a caller and its blocking child, owners of
/// `PauseOwner` monitors in different words: the operator's pause of the feed under the
/// cycle's curtain, the feed's own hold outlasting the curtain, a feed frozen by its
/// paused caller (a resume request of it taken, its clock stopped), a resume refused while
/// its own hold holds.
#[test]
fn pause_owner_holds_of_a_caller_and_its_child_across_words_act_as_in_one_word() {
    use Ask::*;
    let cases: [CycleAndFeed; 5] = [
        CycleAndFeed {
            curtain: |t| (5..10).contains(&t),
            feed: |_| false,
            asks: &[(2, Pause, 1), (15, Resume, 1)],
        },
        CycleAndFeed {
            curtain: |t| (8..12).contains(&t),
            feed: |t| (5..20).contains(&t),
            asks: &[],
        },
        CycleAndFeed {
            curtain: |t| (5..20).contains(&t),
            feed: |t| (8..12).contains(&t),
            asks: &[(7, Resume, 1)],
        },
        CycleAndFeed {
            curtain: |_| false,
            feed: |t| (5..9).contains(&t),
            asks: &[(7, Resume, 1), (9, Pause, 1), (12, Resume, 1)],
        },
        CycleAndFeed {
            curtain: |t| (2..5).contains(&t) || t == 9,
            feed: |t| (5..9).contains(&t),
            asks: &[(6, Pause, 0), (10, Resume, 0)],
        },
    ];
    for case in &cases {
        across_words(case, &layouts(2));
    }
}

// ---------------------------------------------------------------------------------------
// Restarts, their budget, caller behaviours (tests/restart_budget.rs, tests/behaviours.rs)

/// main ─run→ A ─step→ S (exit flag 1, from 40 ms). A's monitor `jam` (flag 0, true at the
/// ticks of `pulses`, `behaviour`, restart limit 2, exception E when `with_exception`: a
/// step of W, 2 ms); S's monitor `slip` (flag 4, at 30 ms, `RestartCallerOfOwner`,
/// restart limit 1). Roles: main, A, S, E, W.
struct Restarts {
    behaviour: Behaviour,
    with_exception: bool,
    pulses: &'static [u64],
}

impl Scenario for Restarts {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        ["main", "A", "S", "E", "W"].map(SeqConfig::new).into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[main, a, s, e, w] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let s_seq = seq.bind(s, Leaf::until(1)).unwrap();
        let a_seq = seq.bind(a, Node::of(vec![Op::Step(s_seq)])).unwrap();
        let main_seq = seq.bind(main, Node::of(vec![Op::Run(a_seq)])).unwrap();
        let w = seq.bind(w, Wait::new(Duration::from_millis(2))).unwrap();
        let e_seq = seq.bind(e, Node::of(vec![Op::Wait(w)])).unwrap();
        let (mut jam, mut slip) = (|c: &Ctrl, _| c.flag(0), |c: &Ctrl, _| c.flag(4));
        let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
        let mut def = Monitor::new("jam", &mut jam, self.behaviour).restart_limit(2);
        if self.with_exception {
            def = def.exception(e);
        }
        monitors.add(a, def).unwrap();
        monitors
            .add(
                s,
                Monitor::new("slip", &mut slip, Behaviour::RestartCallerOfOwner).restart_limit(1),
            )
            .unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(main_seq);
        sim.lane(e_seq);
        let pulses = self.pulses;
        sim.before_tick(move |t, c| {
            c.set(0, pulses.contains(&since(t, base)));
            c.set(1, since(t, base) >= 40);
            c.set(4, since(t, base) == 30);
        });
        sim.start(main).unwrap();
        let idle = sim
            .run_until_idle(Duration::from_millis(60))
            .map(|t| since(t, base));
        let fired = [0, 1].map(|i| sim.monitors().fired(rtseq::MonitorId::from_index(i)));
        observe(
            &sim,
            &ctrl,
            ids,
            base,
            vec![format!("idle {idle:?} fired {fired:?}")],
        )
    }
}

/// Restarting behaviours bounded by their limit (the third firing escalates to the
/// matching abort), with and without an exception sequence, a firing during an exception
/// sequence, and a step's `RestartCallerOfOwner` charging its caller's run: the same in
/// every layout.
#[test]
fn restarts_and_their_escalation_across_words_act_as_in_one_word() {
    for behaviour in [Behaviour::RestartOwner, Behaviour::RestartCallerOfOwner] {
        for with_exception in [false, true] {
            for pulses in [&[5, 10, 15, 20][..], &[5, 6, 7, 10][..], &[25][..]] {
                let scenario = Restarts {
                    behaviour,
                    with_exception,
                    pulses,
                };
                across_words(&scenario, &layouts(5));
            }
        }
    }
}

/// child, started non-blocking by main's first run (which then ends); main started again
/// at `again_ms` (if any), a run that waits for flag 3. The child's monitor (`behaviour`,
/// flag 1) fires at 5 ms. Roles: child, main.
struct LaterRun {
    behaviour: Behaviour,
    again_ms: Option<u64>,
}

impl Scenario for LaterRun {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        ["child", "main"].map(SeqConfig::new).into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[child, main] = ids else { unreachable!() };
        let ctrl = Ctrl::default();
        let child_seq = seq.bind(child, Node::of(vec![]).until(0)).unwrap();
        let main_seq = seq
            .bind(main, Node::of(vec![Op::Start(child)]).until(3))
            .unwrap();
        let mut jam = |c: &Ctrl, _| c.flag(1);
        let mut monitors = Monitors::<Ctrl, 1>::new();
        monitors
            .add(child, Monitor::new("jam", &mut jam, self.behaviour))
            .unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(main_seq);
        sim.lane(child_seq);
        let again = self.again_ms;
        sim.before_tick(move |t, c| {
            c.set(1, since(t, base) == 5);
            c.set(3, since(t, base) < 2 || since(t, base) >= 12);
        });
        ctrl.set(3, true);
        sim.start(main).unwrap();
        let asks: Vec<(u64, Ask, usize)> = again.map(|t| (t, Ask::Start, 1)).into_iter().collect();
        let results = operate(&mut sim, ids, base, &asks, 20);
        observe(&sim, &ctrl, ids, base, results)
    }
}

/// Caller behaviours of a non-blocking child whose caller ended (the owner is aborted),
/// or ended and started again (they act on the caller's run under way), across words.
#[test]
fn caller_behaviours_on_an_ended_or_later_caller_run_across_words_act_as_in_one_word() {
    for behaviour in [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        for again_ms in [None, Some(2)] {
            across_words(
                &LaterRun {
                    behaviour,
                    again_ms,
                },
                &layouts(2),
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Timeouts (tests/scenarios.rs)

/// main ─run→ C ─step→ S (exit flag 1, from `exit_ms`); C's timeout of 10 ms with
/// `behaviour` (restart limit 1) and exception TE (a step of W, 3 ms); main's timeout of
/// 60 ms (`AbortOwner`). Roles: main, C, S, TE, W.
struct Timeouts {
    behaviour: Behaviour,
    exit_ms: u64,
}

impl Scenario for Timeouts {
    fn configs(&self, ids: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        let ms = Duration::from_millis;
        vec![
            SeqConfig::new("main").timeout(ms(60)),
            SeqConfig::new("C")
                .timeout(ms(10))
                .timeout_exception(ids[3])
                .timeout_behaviour(self.behaviour)
                .timeout_restart_limit(1),
            SeqConfig::new("S"),
            SeqConfig::new("TE"),
            SeqConfig::new("W"),
        ]
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[main, c, s, te, w] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let s = seq.bind(s, Leaf::until(1)).unwrap();
        let c = seq.bind(c, Node::of(vec![Op::Step(s)])).unwrap();
        let main_seq = seq.bind(main, Node::of(vec![Op::Run(c)])).unwrap();
        let w = seq.bind(w, Wait::new(Duration::from_millis(3))).unwrap();
        let te_seq = seq.bind(te, Node::of(vec![Op::Wait(w)])).unwrap();
        let mut sim = Sim::new(seq, &ctrl, Monitors::<Ctrl, 1>::new())
            .starting_at(base)
            .unwrap();
        sim.lane(main_seq);
        sim.lane(te_seq);
        let exit = self.exit_ms;
        sim.before_tick(move |t, c| c.set(1, since(t, base) >= exit));
        sim.start(main).unwrap();
        let idle = sim
            .run_until_idle(Duration::from_millis(100))
            .map(|t| since(t, base));
        observe(&sim, &ctrl, ids, base, vec![format!("idle {idle:?}")])
    }
}

/// A timeout with an exception sequence in another word, each behaviour, restarts bounded
/// by the timeout's limit, the caller's own timeout: the same in every layout.
#[test]
fn timeouts_with_exception_sequences_across_words_act_as_in_one_word() {
    use Behaviour::*;
    for behaviour in [
        Nothing,
        AbortOwner,
        RestartOwner,
        AbortCallerOfOwner,
        RestartCallerOfOwner,
    ] {
        for exit_ms in [12, 20, 80] {
            across_words(&Timeouts { behaviour, exit_ms }, &layouts(5));
        }
    }
}

// ---------------------------------------------------------------------------------------
// Polling classes

/// Five sequences in three polling classes whose periods do not divide each other (3, 7
/// and 5 ms), started at different times, each ending on a flag set at an odd time, each
/// with a `Level` warning (flag 5, from 9 to 30 ms, `Nothing`) and a `Change` monitor
/// (flag 6, toggled every 4 ms, `Nothing`). Roles: a (3 ms), b (7 ms), c (3 ms), d (7 ms),
/// e (5 ms).
struct Classes {
    tick_us: u64,
}

impl Scenario for Classes {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        let every = Duration::from_millis;
        [("a", 3), ("b", 7), ("c", 3), ("d", 7), ("e", 5)]
            .map(|(name, p)| SeqConfig::new(name).polling(every(p)))
            .into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let ctrl = Ctrl::default();
        let exits = [7, 8, 9, 10, 11];
        let runs: Vec<_> = ids
            .iter()
            .zip(exits)
            .map(|(&id, flag)| seq.bind(id, Node::of(vec![]).until(flag)).unwrap())
            .collect();
        let mut monitors: Monitors<Ctrl, 10, fn(&Ctrl, Instant) -> bool> = Monitors::new();
        let warm: fn(&Ctrl, Instant) -> bool = |c, _| c.flag(5);
        let toggled: fn(&Ctrl, Instant) -> bool = |c, _| c.flag(6);
        for &id in ids {
            monitors
                .add(
                    id,
                    Monitor::with_condition("warm", warm, Behaviour::Nothing)
                        .trigger(Trigger::Level),
                )
                .unwrap();
            monitors
                .add(
                    id,
                    Monitor::with_condition("toggled", toggled, Behaviour::Nothing)
                        .trigger(Trigger::Change),
                )
                .unwrap();
        }
        let mut sim = Sim::new(seq, &ctrl, monitors)
            .starting_at(base)
            .unwrap()
            .with_period(Duration::from_micros(self.tick_us))
            .unwrap()
            .starting_at(base)
            .unwrap();
        for run in runs {
            sim.lane(run);
        }
        sim.before_tick(move |t, c| {
            let m = since(t, base);
            c.set(5, (9..30).contains(&m));
            c.set(6, (m / 4) % 2 == 1);
            for (flag, at) in exits.into_iter().zip([31, 40, 23, 47, 52]) {
                c.set(flag, m >= at);
            }
        });
        let starts = [(0, Ask::Start, 0), (2, Ask::Start, 1), (5, Ask::Start, 2)];
        let mut results = operate(&mut sim, ids, base, &starts, 6);
        results.extend(operate(
            &mut sim,
            ids,
            base,
            &[(6, Ask::Start, 3), (13, Ask::Start, 4), (25, Ask::Abort, 2)],
            70,
        ));
        let fired: Vec<u16> = (0..10)
            .map(|i| sim.monitors().fired(rtseq::MonitorId::from_index(i)))
            .collect();
        results.push(format!("fired {fired:?}"));
        firings_by_tick(observe(&sim, &ctrl, ids, base, results))
    }
}

/// Polling classes whose members are in different words, with periods that do not divide
/// each other, started at different times (into idle and busy classes), ticked every
/// millisecond and every 700 µs (polls at the first tick at or after their grid point):
/// the same polls, firings and ends in every layout.
#[test]
fn polling_classes_with_members_across_words_poll_as_in_one_word() {
    for tick_us in [1_000, 700] {
        across_words(&Classes { tick_us }, &layouts(5));
    }
}

// ---------------------------------------------------------------------------------------
// Joins, exception sequences with monitors of their own

/// main starts X and Y (non-blocking), joins X, runs Z blocking, joins Y. X ends on flag
/// 1 (6 ms), Y on flag 2 (3 ms), Z on flag 3 (12 ms). A monitor of X (flag 4, at 4 ms,
/// `RestartOwner`) with exception E; a monitor of E (flag 5, while 4..8 ms, `AbortOwner`).
/// Roles: main, X, Y, Z, E.
struct Joins;

impl Scenario for Joins {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        ["main", "X", "Y", "Z", "E"].map(SeqConfig::new).into()
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let &[main, x, y, z, e] = ids else {
            unreachable!()
        };
        let ctrl = Ctrl::default();
        let x_seq = seq.bind(x, Node::of(vec![]).until(1)).unwrap();
        let y_seq = seq.bind(y, Node::of(vec![]).until(2)).unwrap();
        let z_seq = seq.bind(z, Node::of(vec![]).until(3)).unwrap();
        let e_seq = seq.bind(e, Node::of(vec![]).until(9)).unwrap();
        let main_seq = seq
            .bind(
                main,
                Node::of(vec![
                    Op::Start(x),
                    Op::Start(y),
                    Op::Join(x),
                    Op::Run(z_seq),
                    Op::Join(y),
                ]),
            )
            .unwrap();
        let (mut kick, mut stuck) = (|c: &Ctrl, _| c.flag(4), |c: &Ctrl, _| c.flag(5));
        let mut monitors = Monitors::<Ctrl, 2>::new();
        monitors
            .add(
                x,
                Monitor::new("kick", &mut kick, Behaviour::RestartOwner).exception(e),
            )
            .unwrap();
        monitors
            .add(e, Monitor::new("stuck", &mut stuck, Behaviour::AbortOwner))
            .unwrap();
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        sim.lane(main_seq);
        sim.lane(x_seq);
        sim.lane(y_seq);
        sim.lane(e_seq);
        sim.before_tick(move |t, c| {
            c.set(1, since(t, base) >= 6);
            c.set(2, since(t, base) >= 3);
            c.set(3, since(t, base) >= 12);
            c.set(4, since(t, base) == 4);
            c.set(5, (6..8).contains(&since(t, base)));
        });
        sim.start(main).unwrap();
        let idle = sim
            .run_until_idle(Duration::from_millis(40))
            .map(|t| since(t, base));
        observe(&sim, &ctrl, ids, base, vec![format!("idle {idle:?}")])
    }
}

/// Joins of non-blocking children in other words, one restarted by its monitor after an
/// exception sequence (another word) that its own monitor aborts: the same in every
/// layout.
#[test]
fn joins_and_an_exception_sequence_with_its_own_monitor_across_words_act_as_in_one_word() {
    across_words(&Joins, &layouts(5));
}

// ---------------------------------------------------------------------------------------
// Across the wrap of the 32-bit deadlines

/// Times to start a scenario at (µs), multiples of 1 000 µs: the 32-bit deadlines wrap
/// 7.296 ms in (2^32), 0.296 ms in, 14.592 ms in (2^33); their wrapping difference to the
/// initial deadline (0) changes sign 5.648 ms in (2^31); the run clocks' 48 bits wrap
/// 10.656 ms in (2^48); and past 2^52.
const BASES: [u64; 6] = [
    4_294_960_000,
    4_294_967_000,
    8_589_920_000,
    2_147_478_000,
    281_474_976_700_000,
    4_503_599_628_000_000,
];
/// Starts right at the wrap and 1 µs before it (not multiples of 1 000 µs).
const AT_THE_WRAP: [u64; 2] = [1 << 32, (1 << 32) - 1];

/// Runs `scenario` in the first layout of `layouts(roles)` over eight words from each
/// base of `bases`, and packed in one word from them; asserts each gives, with times from
/// its base, what the packed scenario gives from 0.
fn across_time<S: Scenario>(scenario: &S, roles: usize, bases: &[u64]) {
    let packed: Vec<usize> = (0..roles).collect();
    let at = layouts(roles)[0];
    let small: Seqr<16, 1> = Sequencer::new();
    let want = run_at(scenario, &small, &packed, Instant::from_ticks(0));
    for &base in bases {
        let small: Seqr<16, 1> = Sequencer::new();
        let got = run_at(scenario, &small, &packed, Instant::from_ticks(base));
        assert_eq!(got.join("\n"), want.join("\n"), "one word from {base} µs");
        let big: Seqr<256, 8> = Sequencer::new();
        let got = run_at(scenario, &big, at, Instant::from_ticks(base));
        let renamed = rename(&want, at);
        assert_eq!(
            got.join("\n"),
            renamed.join("\n"),
            "eight words from {base} µs"
        );
    }
}

/// The behaviours, timeouts, restarts, pauses and `PauseOwner` holds, from each base: the
/// same as from 0.
#[test]
fn scenarios_across_the_wrap_act_as_from_0() {
    let all: Vec<u64> = BASES.iter().chain(&AT_THE_WRAP).copied().collect();
    use Behaviour::*;
    for behaviour in [AbortCallerOfOwner, RestartOwner, PauseOwner] {
        let scenario = Behaviours {
            behaviour,
            with_exception: true,
        };
        across_time(&scenario, 6, &all);
    }
    for behaviour in [RestartOwner, RestartCallerOfOwner] {
        across_time(
            &Timeouts {
                behaviour,
                exit_ms: 20,
            },
            5,
            &all,
        );
    }
    across_time(
        &Restarts {
            behaviour: RestartOwner,
            with_exception: true,
            pulses: &[5, 10, 15, 20],
        },
        5,
        &all,
    );
    use Ask::*;
    let pauses = Pauses {
        asks: &[
            (3, Pause, 0),
            (9, Resume, 0),
            (30, Pause, 1),
            (60, Resume, 1),
        ],
    };
    across_time(&pauses, 5, &all);
    let curtain = Curtain {
        curtain: |t| (3..8).contains(&t) || (12..15).contains(&t),
        error: |t| t == 5,
        asks: &[(13, Resume, 0), (14, Pause, 0), (17, Resume, 0)],
    };
    across_time(&curtain, 5, &all);
    across_time(&Joins, 5, &all);
}

/// Polling classes of 3, 7 and 5 ms, ticked every millisecond and every 700 µs, from each
/// base: the same polls and firings as from 0.
#[test]
fn polling_classes_across_the_wrap_poll_as_from_0() {
    across_time(&Classes { tick_us: 1_000 }, 5, &BASES);
    across_time(&Classes { tick_us: 700 }, 5, &BASES);
}

// ---------------------------------------------------------------------------------------
// A table of many monitors whose groups span words

/// A flag's value at `ms`: flags 2 to 6 square waves of periods 2, 3, 5, 7 and 11 ms.
fn wave(flag: usize, ms: u64) -> bool {
    let period = [2, 3, 5, 7, 11][flag - 2];
    (ms / period) % 2 == 1
}

/// Condition of monitor `i` of [`ManyMonitors`]: one of the flags 2 to 6.
#[derive(Clone, Copy)]
struct OnFlag(usize);

impl rtseq::Condition<Ctrl> for OnFlag {
    fn validate(&mut self, c: &Ctrl, _: Instant) -> bool {
        c.flag(self.0)
    }
}

/// Six sequences (exit flag 1, from 45 ms; A polled every 2 ms, the others every
/// millisecond), each owner of ten monitors, listed in turn (monitor `i` is role
/// `i % 6`'s) in a table of 256: flag `2 + i % 5`, trigger `i % 4` (rising, falling,
/// change, level), `Nothing`, except monitor 40 (role 4: `RestartOwner`, limit 1) and
/// monitor 57 (role 3: `AbortOwner`). Roles: A to F.
struct ManyMonitors;

impl Scenario for ManyMonitors {
    fn configs(&self, _: &[SeqId]) -> Vec<SeqConfig<Ctrl>> {
        let mut configs: Vec<SeqConfig<Ctrl>> =
            ["A", "B", "C", "D", "E", "F"].map(SeqConfig::new).into();
        configs[0] = SeqConfig::new("A").polling(Duration::from_millis(2));
        configs
    }

    fn run<const N: usize, const B: usize>(
        &self,
        seq: &Seqr<N, B>,
        ids: &[SeqId],
        base: Instant,
    ) -> Vec<String> {
        let ctrl = Ctrl::default();
        let runs: Vec<_> = ids
            .iter()
            .map(|&id| seq.bind(id, Node::of(vec![]).until(1)).unwrap())
            .collect();
        let mut monitors: Monitors<Ctrl, 256, OnFlag> = Monitors::new();
        let triggers = [
            Trigger::RisingEdge,
            Trigger::FallingEdge,
            Trigger::Change,
            Trigger::Level,
        ];
        for i in 0..60 {
            let behaviour = match i {
                40 => Behaviour::RestartOwner,
                57 => Behaviour::AbortOwner,
                _ => Behaviour::Nothing,
            };
            let monitor = Monitor::with_condition("m", OnFlag(2 + i % 5), behaviour)
                .trigger(triggers[i % 4])
                .restart_limit(1);
            monitors.add(ids[i % 6], monitor).unwrap();
        }
        let mut sim = Sim::new(seq, &ctrl, monitors).starting_at(base).unwrap();
        for run in runs {
            sim.lane(run);
        }
        sim.before_tick(move |t, c| {
            let m = since(t, base);
            c.set(1, m >= 45);
            for flag in 2..=6 {
                c.set(flag, wave(flag, m));
            }
        });
        let asks: Vec<(u64, Ask, usize)> = (0..6).map(|r| (r as u64, Ask::Start, r)).collect();
        let mut results = operate(&mut sim, ids, base, &asks, 60);
        let fired: Vec<u16> = (0..60)
            .map(|i| sim.monitors().fired(rtseq::MonitorId::from_index(i)))
            .collect();
        results.push(format!("fired {fired:?}"));
        firings_by_tick(observe(&sim, &ctrl, ids, base, results))
    }
}

/// `seen` with the firings (`Fired` events) of each tick taken out of their order and
/// put, in table order, before the tick's other records: a tick of a sequencer of several words
/// raises the monitors word by word, in table order in each word (as documented, and
/// pinned in tests/capacity.rs); which fire is the same.
fn firings_by_tick(seen: Vec<String>) -> Vec<String> {
    let time = |l: &String| l.get(..8).and_then(|t| t.trim().parse::<u64>().ok());
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < seen.len() {
        let Some(t) = time(&seen[i]) else {
            out.push(seen[i].clone());
            i += 1;
            continue;
        };
        let end = (i..seen.len())
            .find(|&j| time(&seen[j]) != Some(t))
            .unwrap_or(seen.len());
        let (mut fired, rest): (Vec<String>, Vec<String>) = seen[i..end]
            .iter()
            .cloned()
            .partition(|l| l.contains("Fired"));
        fired.sort_by_key(|l| monitor_of(l));
        out.extend(fired);
        out.extend(rest);
        i = end;
    }
    out
}

/// The monitor index in a `Fired` event's line.
fn monitor_of(line: &str) -> usize {
    let at = line.find("MonitorId(").unwrap() + "MonitorId(".len();
    let end = at + line[at..].find(')').unwrap();
    line[at..end].parse().unwrap()
}

/// Sixty monitors of six owners in turn: in one word their groups hold owners of one
/// word; spread over six words, the first monitors get a group each and the rest share
/// groups across words. Edges, levels, a restart and an abort: the same firings.
#[test]
fn a_table_whose_groups_span_words_fires_as_in_one_word() {
    let seen = across_words(&ManyMonitors, &layouts(6));
    assert!(seen.iter().any(|l| l.contains("RestartOwner")));
    across_time(&ManyMonitors, 6, &BASES);
}

/// Polls of a run that lasts past 2^32 µs: `a` (id 3, word 0) polls every 3 ms, `b` (id
/// 200, word 6) every 7 ms, neither period dividing 2^32. Ticked every millisecond for
/// 50 ms, every 10 s (late ticks: every one polls, the missed polls are skipped) up to
/// 10 s before 2^32 µs, then every millisecond to 50 ms past it: each then polls on its
/// grid, start + k·P.
#[test]
fn polls_keep_their_grid_past_2_pow_32_us() {
    use std::sync::Mutex;
    let seq: Seqr<256, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let polled: Mutex<Vec<(usize, u64)>> = Mutex::new(Vec::new());
    let mut ids = [SeqId::from_index(0); 2];
    for (i, (name, p, at)) in [("a", 3, 3), ("b", 7, 200)].into_iter().enumerate() {
        fill_to(&seq, at);
        let config = SeqConfig::new(name).polling(Duration::from_millis(p));
        ids[i] = seq.register(config).unwrap();
    }
    let runs = ids.map(|id| seq.bind(id, Node::of(vec![]).until(1)).unwrap());
    let (mut on_a, mut on_b) = (
        |_: &Ctrl, now: Instant| {
            polled.lock().unwrap().push((0, now.as_ticks()));
            false
        },
        |_: &Ctrl, now: Instant| {
            polled.lock().unwrap().push((1, now.as_ticks()));
            false
        },
    );
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    monitors
        .add(ids[0], Monitor::new("a", &mut on_a, Behaviour::Nothing))
        .unwrap();
    monitors
        .add(ids[1], Monitor::new("b", &mut on_b, Behaviour::Nothing))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    let start = 1_000; // µs
    sim.step();
    for run in runs {
        sim.lane(run);
    }
    for id in ids {
        sim.start(id).unwrap();
    }
    sim.run_until(Instant::from_ticks(50_000));
    let mut sim = sim.with_period(Duration::from_secs(10)).unwrap();
    sim.run_until(Instant::from_ticks((1 << 32) - 10_000_000));
    let late = sim.now().as_ticks();
    let mut sim = sim.with_period(Duration::from_millis(1)).unwrap();
    sim.run_until(Instant::from_ticks((1 << 32) + 50_000));
    assert_eq!(sim.state(ids[0]), rtseq::RunningState::Running);
    let periods = [3_000, 7_000];
    let polled = polled.lock().unwrap();
    // The first 50 ms: on the grid.
    for &(who, t) in polled.iter().filter(|(_, t)| *t <= 50_000) {
        assert_eq!((t - start) % periods[who], 0, "poll of {who} at {t} µs");
    }
    // Every late tick polls both.
    let late_ticks = polled
        .iter()
        .filter(|(_, t)| *t > 50_000 && *t <= late)
        .count() as u64;
    assert_eq!(late_ticks, 2 * ((late - 50_000) / 10_000_000));
    // After them, past 2^32 µs: on the grid again, every period.
    for (who, period) in periods.into_iter().enumerate() {
        let after: Vec<u64> = polled
            .iter()
            .filter(|&&(w, t)| w == who && t > late)
            .map(|&(_, t)| t)
            .collect();
        assert!(after.iter().any(|&t| t > 1 << 32));
        for &t in &after {
            assert_eq!((t - start) % period, 0, "poll of {who} at {t} µs");
        }
        for pair in after.windows(2) {
            assert_eq!(pair[1] - pair[0], period);
        }
        assert!(after[0] - late <= period);
    }
}
