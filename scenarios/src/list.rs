//! The scenarios: the trees, monitors and fault scripts of rtseq's core host tests
//! (`tests/behaviours.rs`, `tests/scenarios.rs`), in the same registration order.

use rtseq::{Behaviour, Duration, Monitor, Seq, SeqConfig, SeqId, Table, Trigger, Wait};

use crate::{Conds, Ctrl, Lanes, Leaf, Mons, Root, Scenario, ScenarioError, Seqr, N0, N1, N2, N3};

type R = Result<Lanes, ScenarioError>;

fn cfg(name: &'static str) -> SeqConfig<Ctrl> {
    SeqConfig::new(name)
}

fn lanes<const K: usize>(lanes: [Seq<Root>; K], start: &[SeqId]) -> R {
    let mut out = Lanes {
        lanes: heapless::Vec::new(),
        start: heapless::Vec::new(),
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

/// main ─run→ P ─run→ A ─step→ S (exit: flag 1). Monitor on A watches flag 0 (pulse at
/// 5 ms), behaviour `B`; with `EXC` its exception sequence E waits 2 ms.
fn behaviours<'a, const B: u8, const EXC: bool>(
    seq: &Seqr,
    mons: &mut Mons<'a>,
    conds: &'a mut Conds,
) -> R {
    let s = seq.register(cfg("S"))?;
    let a = seq.register(cfg("A"))?;
    let p = seq.register(cfg("P"))?;
    let main = seq.register(cfg("main"))?;
    let w = seq.add(cfg("W"), Wait::new(Duration::from_millis(2)))?;
    let e = seq.register(cfg("E"))?;
    let s = seq.bind(s, Leaf::until(1))?;
    let a_node = seq.bind(a, N0::new().step(s)?)?;
    let p = seq.bind(p, N1::new().run(a_node)?)?;
    let main = seq.bind(main, Root::from(N2::new().run(p)?))?;
    let e = seq.bind(e, Root::from(N0::new().wait(w)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    let mut def = Monitor::new("m", c0, behaviour(B));
    if EXC {
        def = def.exception(e.id());
    }
    mons.add(a, def)?;
    let m = main.id();
    lanes([main, e], &[m])
}

fn behaviours_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(1, ms >= 10);
}

// --- tests/scenarios.rs ------------------------------------------------------------------

/// main ─run→ X1 ─run→ X2 ─run→ X3 ─step→ S; `AbortOwner` monitor on X1 (flag 0 at 5 ms).
fn outermost<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let x3 = seq.add(cfg("X3"), N0::new().step(s)?)?;
    let x2 = seq.add(cfg("X2"), N1::new().run(x3)?)?;
    let x1 = seq.add(cfg("X1"), N2::new().run(x2)?)?;
    let x1i = x1.id();
    let main = seq.add(cfg("main"), Root::from(N3::new().run(x1)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    mons.add(x1i, Monitor::new("outer", c0, Behaviour::AbortOwner))?;
    let m = main.id();
    lanes([main], &[m])
}

fn pulse0_at5(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
}

/// main ─run→ A ─step→ S (never ends); a 3 ms timeout on S (`ON_STEP`) or on A. Set up
/// from a compile-time-checked table (`Sequencer::install`), the others by registration.
fn timeout<'a, const ON_STEP: bool>(seq: &Seqr, _: &mut Mons<'a>, _: &'a mut Conds) -> R {
    seq.install(if ON_STEP {
        &TIMEOUT_ON_STEP
    } else {
        &TIMEOUT_ON_CALLER
    })?;
    let s = seq.bind(SeqId::from_index(0), Leaf::until(1))?;
    let a = seq.bind(SeqId::from_index(1), N0::new().step(s)?)?;
    let main = seq.bind(SeqId::from_index(2), Root::from(N1::new().run(a)?))?;
    let m = main.id();
    lanes([main], &[m])
}

/// S, A, main with a 3 ms timeout on S or on A.
const fn timeout_table(on_step: bool) -> Result<Table<Ctrl, 3>, rtseq::Error> {
    let three = Duration::from_millis(3);
    let (s, a) = (SeqConfig::new("S"), SeqConfig::new("A"));
    let (s, a) = if on_step {
        (s.timeout(three), a)
    } else {
        (s, a.timeout(three))
    };
    Table::new([s, a, SeqConfig::new("main")])
}

// `static` items: a panic here is a compile error, never a run-time path.
#[allow(clippy::panic)]
static TIMEOUT_ON_STEP: Table<Ctrl, 3> = match timeout_table(true) {
    Ok(t) => t,
    Err(e) => panic!("{}", e.reason()),
};
#[allow(clippy::panic)]
static TIMEOUT_ON_CALLER: Table<Ctrl, 3> = match timeout_table(false) {
    Ok(t) => t,
    Err(e) => panic!("{}", e.reason()),
};

fn quiet(_: u32, _: &Ctrl, _: &Seqr) {}

/// main ─run→ A ─step→ S; `RestartOwner` monitor on A (limit 3), fault from 5 ms on.
fn restart_limit<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let a = seq.add(cfg("A"), N0::new().step(s)?)?;
    let ai = a.id();
    let main = seq.add(cfg("main"), Root::from(N1::new().run(a)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    mons.add(
        ai,
        Monitor::new("stuck", c0, Behaviour::RestartOwner).restart_limit(3),
    )?;
    let m = main.id();
    lanes([main], &[m])
}

fn fault_from5(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms >= 5);
}

/// A (lane) ─step→ S; a `Nothing` monitor with exception sequence E, condition true from
/// 5 to 9 ms; edge (`LEVEL` false) or level trigger.
fn storm<'a, const LEVEL: bool>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let a = seq.add(cfg("A"), Root::from(N0::new().step(s)?))?;
    let e = seq.add(cfg("E"), Root::from(N0::new()))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    let trigger = if LEVEL {
        Trigger::Level
    } else {
        Trigger::RisingEdge
    };
    mons.add(
        a.id(),
        Monitor::new("m", c0, Behaviour::Nothing)
            .exception(e.id())
            .trigger(trigger),
    )?;
    let ai = a.id();
    lanes([a, e], &[ai])
}

fn storm_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, (5..=9).contains(&ms));
    c.set(1, ms >= 15);
}

/// main ─run→ A ─step→ S (10 ms timeout, `Nothing` monitor on flag 2 at 12 ms); A paused at
/// 4 ms, S and A resumed at 21 ms.
fn pause<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S").timeout(Duration::from_millis(10)), Leaf::until(1))?;
    let si = s.id();
    let a = seq.add(cfg("A"), N0::new().step(s)?)?;
    let main = seq.add(cfg("main"), Root::from(N1::new().run(a)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 2;
    mons.add(si, Monitor::new("while paused", c0, Behaviour::Nothing))?;
    let m = main.id();
    lanes([main], &[m])
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
fn non_blocking<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s2 = seq.add(cfg("S2"), Leaf::until(2))?;
    let q = seq.add(cfg("Q"), Root::from(N0::new().step(s2)?))?;
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let p = seq.add(cfg("P"), N0::new().start(q.id())?.step(s)?)?;
    let pi = p.id();
    let main = seq.add(cfg("main"), Root::from(N1::new().run(p)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    mons.add(pi, Monitor::new("m", c0, Behaviour::AbortOwner))?;
    let m = main.id();
    lanes([main, q], &[m])
}

/// main ─run→ A ─step→ S; m1 on A (flag 0 at 5 ms) runs E ─step→ SE; m2 on E (flag 2 at
/// 7 ms) aborts E.
fn exception_monitor<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let a = seq.add(cfg("A"), N0::new().step(s)?)?;
    let ai = a.id();
    let se = seq.add(cfg("SE"), Leaf::until(3))?;
    let e = seq.add(cfg("E"), Root::from(N0::new().step(se)?))?;
    let ei = e.id();
    let main = seq.add(cfg("main"), Root::from(N1::new().run(a)?))?;
    let [c0, c2, ..] = conds.each();
    c0.flag = 0;
    c2.flag = 2;
    mons.add(
        ai,
        Monitor::new("m1", c0, Behaviour::AbortOwner).exception(ei),
    )?;
    mons.add(ei, Monitor::new("m2", c2, Behaviour::AbortOwner))?;
    let m = main.id();
    lanes([main, e], &[m])
}

fn exception_monitor_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(2, ms == 7);
}

/// main steps S and runs B; both have a false pre-condition (flag 5).
fn pre_false<'a>(seq: &Seqr, _: &mut Mons<'a>, _: &'a mut Conds) -> R {
    let s = seq.add(
        cfg("S"),
        Leaf {
            pre: Some(5),
            exit: None,
        },
    )?;
    let b = seq.add(cfg("B"), N0::new().pre(5))?;
    let main = seq.add(cfg("main"), Root::from(N1::new().step(s)?.run(b)?))?;
    let m = main.id();
    lanes([main], &[m])
}

/// main ─step→ S; at 5 ms S's `AbortOwner` monitor and its exit condition are both true.
fn monitor_and_exit<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let si = s.id();
    let main = seq.add(cfg("main"), Root::from(N0::new().step(s)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    mons.add(si, Monitor::new("m", c0, Behaviour::AbortOwner))?;
    let m = main.id();
    lanes([main], &[m])
}

fn monitor_and_exit_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms == 5);
    c.set(1, ms >= 5);
}

/// A (lane) steps S1 (exit flag 1) then S2; the fault and S1's exit appear before tick K.
fn reaction<'a>(seq: &Seqr, mons: &mut Mons<'a>, conds: &'a mut Conds) -> R {
    let s1 = seq.add(cfg("S1"), Leaf::until(1))?;
    let s2 = seq.add(cfg("S2"), Leaf::default())?;
    let a = seq.add(cfg("A"), Root::from(N0::new().step(s1)?.step(s2)?))?;
    let [c0, ..] = conds.each();
    c0.flag = 0;
    mons.add(a.id(), Monitor::new("m", c0, Behaviour::AbortOwner))?;
    let ai = a.id();
    lanes([a], &[ai])
}

fn reaction_script<const K: u32>(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(0, ms >= K);
    c.set(1, ms >= K);
}

/// main starts Q twice (the second start is an error) and joins it; Q ends at 4 ms.
fn already_running<'a>(seq: &Seqr, _: &mut Mons<'a>, _: &'a mut Conds) -> R {
    let s2 = seq.add(cfg("S2"), Leaf::until(2))?;
    let q = seq.add(cfg("Q"), Root::from(N0::new().step(s2)?))?;
    let qi = q.id();
    let main = seq.add(
        cfg("main"),
        Root::from(N0::new().start(qi)?.start(qi)?.join(qi)?),
    )?;
    let m = main.id();
    lanes([main, q], &[m])
}

fn already_running_script(ms: u32, c: &Ctrl, _: &Seqr) {
    c.set(2, ms >= 4);
}

/// main starts Q (lane) and steps S; abort-all requested before the tick at 4 ms.
fn abort_all<'a>(seq: &Seqr, _: &mut Mons<'a>, _: &'a mut Conds) -> R {
    let s2 = seq.add(cfg("S2"), Leaf::until(2))?;
    let q = seq.add(cfg("Q"), Root::from(N0::new().step(s2)?))?;
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let main = seq.add(cfg("main"), Root::from(N0::new().start(q.id())?.step(s)?))?;
    let m = main.id();
    lanes([main, q], &[m])
}

fn abort_all_script(ms: u32, _: &Ctrl, seq: &Seqr) {
    if ms == 4 {
        seq.abort_all();
    }
}

/// main ─step→ S; an abort request through main's handle before the tick at 2 ms.
fn abort_request<'a>(seq: &Seqr, _: &mut Mons<'a>, _: &'a mut Conds) -> R {
    let s = seq.add(cfg("S"), Leaf::until(1))?;
    let main = seq.add(cfg("main"), Root::from(N0::new().step(s)?))?;
    let m = main.id();
    lanes([main], &[m])
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
