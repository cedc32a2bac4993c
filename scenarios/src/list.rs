//! The scenarios: the trees, monitors and fault scripts of rtseq's core host tests
//! (`tests/behaviours.rs`, `tests/scenarios.rs`), in the same registration order.
//!
//! Each set-up is data checked by the compiler: a [`Table`] of its sequences (in id order)
//! and a monitor table ([`Monitors::table`](rtseq::Monitors::table)), both `const`; at run
//! time it only installs the table and binds the bodies, bottom-up.

use rtseq::{
    Behaviour, Duration, Monitor, Monitors, OwnedMonitor, Seq, SeqConfig, SeqId, Table, Trigger,
    Wait,
};

use crate::{Arena, Ctrl, FlagCond, Leaf, Mons, Node, Scenario, ScenarioError, Seqr, Setup};

type R<'t> = Result<Setup<'t>, ScenarioError>;

const fn cfg(name: &'static str) -> SeqConfig<Ctrl> {
    SeqConfig::new(name)
}

/// The table of `configs` (sequence `i` gets id `i`). Only for `const` items: an invalid
/// table fails the build, so the panic is never a run-time path.
#[allow(clippy::panic)]
const fn table<const K: usize>(configs: [SeqConfig<Ctrl>; K]) -> Table<Ctrl, K> {
    match Table::new(configs) {
        Ok(t) => t,
        Err(e) => panic!("{}", e.message().as_str()),
    }
}

/// The id of the sequence called `name` in `table`. Only for `const` items: an unknown
/// name fails the build.
#[allow(clippy::panic)]
const fn id<const K: usize>(table: &Table<Ctrl, K>, name: &str) -> SeqId {
    match table.id(name) {
        Some(id) => id,
        None => panic!("no sequence of that name in the table"),
    }
}

/// The ids of a table of `K` sequences, in table order (for destructuring).
fn ids<const K: usize>() -> [SeqId; K] {
    core::array::from_fn(SeqId::from_index)
}

/// A monitor of the condition "flag `flag` is set".
const fn on_flag(name: &'static str, flag: u8, b: Behaviour) -> Monitor<'static, Ctrl, FlagCond> {
    Monitor::with_condition(name, FlagCond { flag }, b)
}

/// The monitor table of `monitors`. Only for `const` items: an invalid table fails the
/// build.
#[allow(clippy::panic)]
const fn monitors<const L: usize>(monitors: [OwnedMonitor<'static, Ctrl, FlagCond>; L]) -> Mons {
    match Monitors::table(monitors) {
        Ok(t) => t,
        Err(e) => panic!("{}", e.message().as_str()),
    }
}

/// No monitors.
const NO_MONITORS: Mons = Monitors::new();

/// Installs `table` into the empty sequencer. Out of line, one copy per table size: the
/// call's set-up is rtseq's code, written once instead of in every scenario.
#[inline(never)]
fn install<const K: usize>(seq: &Seqr, table: &'static Table<Ctrl, K>) -> Result<(), rtseq::Error> {
    seq.install(table)
}

/// Binds `body` to `id`. Out of line, one copy per body type: moving a body into its
/// `Seq` is rtseq's code, and here it is written once instead of at every call site.
#[inline(never)]
fn bind<S>(seq: &Seqr, id: SeqId, body: S) -> Result<Seq<S>, ScenarioError> {
    Ok(seq.bind(id, body)?)
}

/// The set-up's result: `lanes` (in poll order), the sequences started at time 0 (in this
/// order) and the monitors.
fn setup<'t, const K: usize>(lanes: [Seq<Node<'t>>; K], start: &[SeqId], monitors: Mons) -> R<'t> {
    let mut out = Setup {
        lanes: heapless::Vec::new(),
        start: heapless::Vec::new(),
        monitors,
    };
    for l in lanes {
        out.lanes.push(l).map_err(|_| ScenarioError::Capacity)?;
    }
    for &s in start {
        out.start.push(s).map_err(|_| ScenarioError::Capacity)?;
    }
    Ok(out)
}

/// Requests a pause, resume or abort of the sequence called `name` (errors ignored: the
/// trace shows what happened).
fn request(seq: &Seqr, name: &str, what: Request) {
    if let Some(h) = seq.sequence_by_name(name) {
        let _ = match what {
            Request::Pause => h.pause(),
            Request::Resume => h.resume(),
            Request::Abort => h.abort(),
        };
    }
}

enum Request {
    Pause,
    Resume,
    Abort,
}

const fn behaviour(b: u8) -> Behaviour {
    match b {
        0 => Behaviour::Nothing,
        1 => Behaviour::AbortOwner,
        2 => Behaviour::RestartOwner,
        3 => Behaviour::AbortCallerOfOwner,
        _ => Behaviour::RestartCallerOfOwner,
    }
}

// --- tests/behaviours.rs -----------------------------------------------------------------

/// S, A, P, main, W, E: the tree of [`behaviours`].
const BEHAVIOURS: Table<Ctrl, 6> = table([
    cfg("S"),
    cfg("A"),
    cfg("P"),
    cfg("main"),
    cfg("W"),
    cfg("E"),
]);

/// main ─run→ P ─run→ A ─step→ S (exit: flag 1). Monitor on A watches flag 0 (pulse at
/// 5 ms), behaviour `B`; with `EXC` its exception sequence E waits 2 ms (W).
fn behaviours<'t, const B: u8, const EXC: bool>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    let monitors = const {
        let m = on_flag("m", 0, behaviour(B));
        let m = if EXC {
            m.exception(id(&BEHAVIOURS, "E"))
        } else {
            m
        };
        monitors([m.owned_by(id(&BEHAVIOURS, "A"))])
    };
    install(seq, &BEHAVIOURS)?;
    let [s, a, p, main, w, e] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let p = bind(seq, p, Node::new().run(arena.child(a)?)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(p)?)?)?;
    let w = bind(seq, w, Wait::new(Duration::from_millis(2)))?;
    let e = bind(seq, e, Node::new().wait(w)?)?;
    let m = main.id();
    setup([main, e], &[m], monitors)
}

fn behaviours_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(1, ms >= 10);
}

// --- tests/scenarios.rs ------------------------------------------------------------------

/// main ─run→ X1 ─run→ X2 ─run→ X3 ─step→ S; `AbortOwner` monitor on X1 (flag 0 at 5 ms).
fn outermost<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 5> = table([cfg("S"), cfg("X3"), cfg("X2"), cfg("X1"), cfg("main")]);
    const MONITORS: Mons =
        monitors([on_flag("outer", 0, Behaviour::AbortOwner).owned_by(id(&TABLE, "X1"))]);
    install(seq, &TABLE)?;
    let [s, x3, x2, x1, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let x3 = bind(seq, x3, Node::new().step(s)?)?;
    let x2 = bind(seq, x2, Node::new().run(arena.child(x3)?)?)?;
    let x1 = bind(seq, x1, Node::new().run(arena.child(x2)?)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(x1)?)?)?;
    let m = main.id();
    setup([main], &[m], MONITORS)
}

fn pulse0_at5(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
}

/// main ─run→ A ─step→ S (never ends); a 3 ms timeout on S (`ON_STEP`) or on A.
fn timeout<'t, const ON_STEP: bool>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const THREE: Duration = Duration::from_millis(3);
    const ON_S: Table<Ctrl, 3> = table([cfg("S").timeout(THREE), cfg("A"), cfg("main")]);
    const ON_A: Table<Ctrl, 3> = table([cfg("S"), cfg("A").timeout(THREE), cfg("main")]);
    install(seq, if ON_STEP { &ON_S } else { &ON_A })?;
    let [s, a, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(a)?)?)?;
    let m = main.id();
    setup([main], &[m], NO_MONITORS)
}

fn quiet(_: u32, _: &Ctrl, _: &Seqr) {}

/// S, A, main: a step in a sequence in a main sequence.
const S_A_MAIN: Table<Ctrl, 3> = table([cfg("S"), cfg("A"), cfg("main")]);

/// main ─run→ A ─step→ S; `RestartOwner` monitor on A (limit 3), fault from 5 ms on.
fn restart_limit<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const MONITORS: Mons = monitors([on_flag("stuck", 0, Behaviour::RestartOwner)
        .restart_limit(3)
        .owned_by(id(&S_A_MAIN, "A"))]);
    install(seq, &S_A_MAIN)?;
    let [s, a, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(a)?)?)?;
    let m = main.id();
    setup([main], &[m], MONITORS)
}

fn fault_from5(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms >= 5);
}

/// A (lane) ─step→ S; a `Nothing` monitor with exception sequence E, condition true from
/// 5 to 9 ms; edge (`LEVEL` false) or level trigger.
fn storm<'t, const LEVEL: bool>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([cfg("S"), cfg("A"), cfg("E")]);
    let monitors = const {
        let trigger = if LEVEL {
            Trigger::Level
        } else {
            Trigger::RisingEdge
        };
        monitors([on_flag("m", 0, Behaviour::Nothing)
            .exception(id(&TABLE, "E"))
            .trigger(trigger)
            .owned_by(id(&TABLE, "A"))])
    };
    install(seq, &TABLE)?;
    let [s, a, e] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let e = bind(seq, e, Node::new())?;
    let ai = a.id();
    setup([a, e], &[ai], monitors)
}

fn storm_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, (5..=9).contains(&ms));
    c.set(1, ms >= 15);
}

/// main ─run→ A ─step→ S (10 ms timeout, `Nothing` monitor on flag 2 at 12 ms); A paused at
/// 4 ms, S and A resumed at 21 ms.
fn pause<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([
        cfg("S").timeout(Duration::from_millis(10)),
        cfg("A"),
        cfg("main"),
    ]);
    const MONITORS: Mons =
        monitors([on_flag("while paused", 2, Behaviour::Nothing).owned_by(id(&TABLE, "S"))]);
    install(seq, &TABLE)?;
    let [s, a, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(a)?)?)?;
    let m = main.id();
    setup([main], &[m], MONITORS)
}

fn pause_script(ms: u32, c: &Ctrl, seq: &Seqr) {
    c.set(2, ms == 12);
    if ms == 4 {
        request(seq, "A", Request::Pause);
    }
    if ms == 21 {
        request(seq, "S", Request::Resume);
        request(seq, "A", Request::Resume);
    }
}

/// main ─run→ P; P starts Q (lane) non-blocking, then steps S; `AbortOwner` on P at 5 ms.
fn non_blocking<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 5> = table([cfg("S2"), cfg("Q"), cfg("S"), cfg("P"), cfg("main")]);
    const MONITORS: Mons =
        monitors([on_flag("m", 0, Behaviour::AbortOwner).owned_by(id(&TABLE, "P"))]);
    install(seq, &TABLE)?;
    let [s2, q, s, p, main] = ids();
    let s2 = bind(seq, s2, Leaf::until(2))?;
    let q = bind(seq, q, Node::new().step(s2)?)?;
    let s = bind(seq, s, Leaf::until(1))?;
    let p = bind(seq, p, Node::new().start(q.id())?.step(s)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(p)?)?)?;
    let m = main.id();
    setup([main, q], &[m], MONITORS)
}

/// main ─run→ A ─step→ S; m1 on A (flag 0 at 5 ms) runs E ─step→ SE; m2 on E (flag 2 at
/// 7 ms) aborts E.
fn exception_monitor<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 5> = table([cfg("S"), cfg("A"), cfg("SE"), cfg("E"), cfg("main")]);
    const MONITORS: Mons = monitors([
        on_flag("m1", 0, Behaviour::AbortOwner)
            .exception(id(&TABLE, "E"))
            .owned_by(id(&TABLE, "A")),
        on_flag("m2", 2, Behaviour::AbortOwner).owned_by(id(&TABLE, "E")),
    ]);
    install(seq, &TABLE)?;
    let [s, a, se, e, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let a = bind(seq, a, Node::new().step(s)?)?;
    let se = bind(seq, se, Leaf::until(3))?;
    let e = bind(seq, e, Node::new().step(se)?)?;
    let main = bind(seq, main, Node::new().run(arena.child(a)?)?)?;
    let m = main.id();
    setup([main, e], &[m], MONITORS)
}

fn exception_monitor_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(2, ms == 7);
}

/// main steps S and runs B; both have a false pre-condition (flag 5).
fn pre_false<'t>(seq: &Seqr, mut arena: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([cfg("S"), cfg("B"), cfg("main")]);
    install(seq, &TABLE)?;
    let [s, b, main] = ids();
    let s = bind(
        seq,
        s,
        Leaf {
            pre: Some(5),
            exit: None,
            fail: None,
        },
    )?;
    let b = bind(seq, b, Node::new().pre(5))?;
    let main = bind(seq, main, Node::new().step(s)?.run(arena.child(b)?)?)?;
    let m = main.id();
    setup([main], &[m], NO_MONITORS)
}

/// A and B (lanes) each step a leaf; their monitors share the exception sequence E. At
/// 5 ms both fire: E starts for A's, for B's it is running already, so B is aborted at once
/// (an exception sequence not run). E ends at 8 ms, then A is aborted.
fn exception_busy<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 6> = table([
        cfg("SA"),
        cfg("SB"),
        cfg("SE"),
        cfg("E"),
        cfg("A"),
        cfg("B"),
    ]);
    const MONITORS: Mons = monitors([
        on_flag("ma", 0, Behaviour::AbortOwner)
            .exception(id(&TABLE, "E"))
            .owned_by(id(&TABLE, "A")),
        on_flag("mb", 0, Behaviour::AbortOwner)
            .exception(id(&TABLE, "E"))
            .owned_by(id(&TABLE, "B")),
    ]);
    install(seq, &TABLE)?;
    let [sa, sb, se, e, a, b] = ids();
    let sa = bind(seq, sa, Leaf::until(1))?;
    let sb = bind(seq, sb, Leaf::until(1))?;
    let se = bind(seq, se, Leaf::until(3))?;
    let e = bind(seq, e, Node::new().step(se)?)?;
    let a = bind(seq, a, Node::new().step(sa)?)?;
    let b = bind(seq, b, Node::new().step(sb)?)?;
    let (a_id, b_id) = (a.id(), b.id());
    setup([a, b, e], &[a_id, b_id], MONITORS)
}

fn exception_busy_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(3, ms >= 8);
}

/// main steps F, whose action fails (code 7), then S: main goes on after the failure.
fn failure<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([cfg("F"), cfg("S"), cfg("main")]);
    install(seq, &TABLE)?;
    let [f, s, main] = ids();
    let f = bind(seq, f, Leaf::failing(7))?;
    let s = bind(seq, s, Leaf::until(1))?;
    let main = bind(seq, main, Node::new().step(f)?.step(s)?)?;
    let m = main.id();
    setup([main], &[m], NO_MONITORS)
}

/// S, main: a step in a main sequence.
const S_MAIN: Table<Ctrl, 2> = table([cfg("S"), cfg("main")]);

/// main ─step→ S; at 5 ms S's `AbortOwner` monitor and its exit condition are both true.
fn monitor_and_exit<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const MONITORS: Mons =
        monitors([on_flag("m", 0, Behaviour::AbortOwner).owned_by(id(&S_MAIN, "S"))]);
    install(seq, &S_MAIN)?;
    let [s, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let main = bind(seq, main, Node::new().step(s)?)?;
    let m = main.id();
    setup([main], &[m], MONITORS)
}

fn monitor_and_exit_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(1, ms >= 5);
}

/// A (lane) steps S1 (exit flag 1) then S2; the fault and S1's exit appear before tick K.
fn reaction<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([cfg("S1"), cfg("S2"), cfg("A")]);
    const MONITORS: Mons =
        monitors([on_flag("m", 0, Behaviour::AbortOwner).owned_by(id(&TABLE, "A"))]);
    install(seq, &TABLE)?;
    let [s1, s2, a] = ids();
    let s1 = bind(seq, s1, Leaf::until(1))?;
    let s2 = bind(seq, s2, Leaf::default())?;
    let a = bind(seq, a, Node::new().step(s1)?.step(s2)?)?;
    let ai = a.id();
    setup([a], &[ai], MONITORS)
}

fn reaction_script<const K: u32>(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms >= K);
    c.set(1, ms >= K);
}

/// main starts Q twice (the second start is an error) and joins it; Q ends at 4 ms.
fn already_running<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 3> = table([cfg("S2"), cfg("Q"), cfg("main")]);
    install(seq, &TABLE)?;
    let [s2, q, main] = ids();
    let s2 = bind(seq, s2, Leaf::until(2))?;
    let q = bind(seq, q, Node::new().step(s2)?)?;
    let qi = q.id();
    let main = bind(seq, main, Node::new().start(qi)?.start(qi)?.join(qi)?)?;
    let m = main.id();
    setup([main, q], &[m], NO_MONITORS)
}

fn already_running_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(2, ms >= 4);
}

/// main starts Q (lane) and steps S; abort-all requested before the tick at 4 ms.
fn abort_all<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    const TABLE: Table<Ctrl, 4> = table([cfg("S2"), cfg("Q"), cfg("S"), cfg("main")]);
    install(seq, &TABLE)?;
    let [s2, q, s, main] = ids();
    let s2 = bind(seq, s2, Leaf::until(2))?;
    let q = bind(seq, q, Node::new().step(s2)?)?;
    let s = bind(seq, s, Leaf::until(1))?;
    let main = bind(seq, main, Node::new().start(q.id())?.step(s)?)?;
    let m = main.id();
    setup([main, q], &[m], NO_MONITORS)
}

fn abort_all_script(ms: u32, _: &Ctrl, seq: &Seqr) {
    if ms == 4 {
        seq.abort_all();
    }
}

/// main ─step→ S; an abort request through main's handle before the tick at 2 ms.
fn abort_request<'t>(seq: &Seqr, _: Arena<'t>) -> R<'t> {
    install(seq, &S_MAIN)?;
    let [s, main] = ids();
    let s = bind(seq, s, Leaf::until(1))?;
    let main = bind(seq, main, Node::new().step(s)?)?;
    let m = main.id();
    setup([main], &[m], NO_MONITORS)
}

fn abort_request_script(ms: u32, _: &Ctrl, seq: &Seqr) {
    if ms == 2 {
        request(seq, "main", Request::Abort);
    }
}

/// Every scenario, run on the host and in QEMU by `tests/qemu_scenarios.rs`.
pub static SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "nothing",
        register: behaviours::<0, false>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "nothing_exc",
        register: behaviours::<0, true>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "abort_owner",
        register: behaviours::<1, false>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "abort_owner_exc",
        register: behaviours::<1, true>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "restart_owner",
        register: behaviours::<2, false>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "restart_owner_exc",
        register: behaviours::<2, true>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "abort_caller",
        register: behaviours::<3, false>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "abort_caller_exc",
        register: behaviours::<3, true>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "restart_caller",
        register: behaviours::<4, false>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "restart_caller_exc",
        register: behaviours::<4, true>,
        script: behaviours_script,
        ticks: 14,
    },
    Scenario {
        name: "outermost_of_three",
        register: outermost,
        script: pulse0_at5,
        ticks: 10,
    },
    Scenario {
        name: "timeout_on_step",
        register: timeout::<true>,
        script: quiet,
        ticks: 8,
    },
    Scenario {
        name: "timeout_on_caller",
        register: timeout::<false>,
        script: quiet,
        ticks: 8,
    },
    Scenario {
        name: "restart_limit",
        register: restart_limit,
        script: fault_from5,
        ticks: 12,
    },
    Scenario {
        name: "rising_edge",
        register: storm::<false>,
        script: storm_script,
        ticks: 18,
    },
    Scenario {
        name: "level",
        register: storm::<true>,
        script: storm_script,
        ticks: 18,
    },
    Scenario {
        name: "pause_resume",
        register: pause,
        script: pause_script,
        ticks: 30,
    },
    Scenario {
        name: "non_blocking_abort",
        register: non_blocking,
        script: pulse0_at5,
        ticks: 8,
    },
    Scenario {
        name: "exception_monitor",
        register: exception_monitor,
        script: exception_monitor_script,
        ticks: 12,
    },
    Scenario {
        name: "exception_busy",
        register: exception_busy,
        script: exception_busy_script,
        ticks: 12,
    },
    Scenario {
        name: "failure",
        register: failure,
        script: quiet,
        ticks: 6,
    },
    Scenario {
        name: "pre_condition_false",
        register: pre_false,
        script: quiet,
        ticks: 3,
    },
    Scenario {
        name: "monitor_and_exit",
        register: monitor_and_exit,
        script: monitor_and_exit_script,
        ticks: 8,
    },
    Scenario {
        name: "reaction_1",
        register: reaction,
        script: reaction_script::<1>,
        ticks: 6,
    },
    Scenario {
        name: "reaction_13",
        register: reaction,
        script: reaction_script::<13>,
        ticks: 18,
    },
    Scenario {
        name: "already_running",
        register: already_running,
        script: already_running_script,
        ticks: 8,
    },
    Scenario {
        name: "abort_all",
        register: abort_all,
        script: abort_all_script,
        ticks: 6,
    },
    Scenario {
        name: "abort_request",
        register: abort_request,
        script: abort_request_script,
        ticks: 4,
    },
];
