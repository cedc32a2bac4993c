//! A cold review of the documents' statements written or rewritten in sessions 55 to 58
//! (docs/semantics.md items 3, 4, 5, 7 and 16 and its safety section, docs/design-decisions.md,
//! docs/firmware-guide.md, the README, the CHANGELOG's migration notes, the rustdoc of
//! `Handle::pause`/`resume`, `Error::HeldByMonitor`, `Cause::is_exception`,
//! `MonitorNames`), each checked on exact traces, states and simulated times through the
//! public API. Each test quotes the statement it checks; what `tests/doc_statements*.rs`
//! and the session-58 review files already check is not repeated.

mod common;
use common::*;
use std::cell::{Cell, OnceCell, RefCell};
use std::future::Future;

use rtseq::sim::{Sim, SimError};
use rtseq::Cause::{self, Completed, Monitor as Mon, Pause, Restart, Resume, Start};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, ConditionFn, Cx, Done, Duration, Entry, Error, Event, Failure, Instant, Monitor,
    MonitorId, MonitorNames, Monitors, Names, Outcome, Seq, SeqConfig, SeqId, Sequence, Sequencer,
    Step, Trigger, Wait, WithNames,
};

type Seqr = Sequencer<Ctrl, 16>;

fn millis(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn at(n: u64) -> Instant {
    Instant::from_ticks(n * 1000)
}

fn hook_of(name: &'static str) -> fn(&Ctrl) {
    match name {
        "s" => |c: &Ctrl| c.hooks.borrow_mut().push("s"),
        "main" => |c: &Ctrl| c.hooks.borrow_mut().push("main"),
        "caller" => |c: &Ctrl| c.hooks.borrow_mut().push("caller"),
        _ => unreachable!(),
    }
}

// ---------------------------------------------------------------------------------------
// semantics.md 7: the table of three holds.
// ---------------------------------------------------------------------------------------

/// semantics.md 7: "Three things hold a run paused, and each is lifted on its own" (a
/// pause request, a `PauseOwner` monitor, the paused caller), and "A run moves back to
/// `Running` only when none of its holds is left". Step S, blocking child of X, carries all
/// three at once: X paused by request (1 ms), S's own `PauseOwner` monitor (true from 4 to
/// 10 ms), S's own pause request (5 ms, taken although S is paused: "A sequence held paused
/// by something else ... takes a pause request"). Lifted one by one: X's resume (7 ms,
/// applied at 8: X runs, S stays), the monitor's release (10 ms: S stays), S's resume (12
/// ms, applied at 13: S runs). Table row 3, "recorded cause: the caller's": S's pause at 2
/// ms is recorded `(pause)`, the cause of X's hold.
#[test]
fn three_holds_on_one_child_are_lifted_each_on_its_own() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let xi = x.id();
    let mut hold = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(si, Monitor::new("hold", &mut hold, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| {
        c.set(1, (4..10).contains(&ms(t)));
        c.set(15, ms(t) >= 20);
    });
    sim.start(xi).unwrap();
    sim.run_until(at(1));
    sim.pause(xi).unwrap(); // applied at 2 ms
    sim.run_until(at(5));
    assert_eq!(sim.state(si), Paused);
    assert_eq!(
        sim.pause(si),
        Ok(()),
        "a sequence held by something else takes a pause"
    );
    sim.run_until(at(7));
    sim.resume(xi).unwrap(); // applied at 8 ms
    sim.run_until(at(9));
    assert_eq!((sim.state(xi), sim.state(si)), (Running, Paused));
    assert_eq!(sim.resume(si), Err(Error::HeldByMonitor(si)));
    sim.run_until(at(12));
    assert_eq!(
        sim.state(si),
        Paused,
        "the request's hold outlasts the monitor's"
    );
    sim.resume(si).unwrap(); // applied at 13 ms
    assert_eq!(sim.run_until_idle(millis(50)), Some(at(20)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(2, xi, Running, Paused, Pause),
            tr(2, si, Running, Paused, Pause),
            tr(8, xi, Paused, Running, Resume),
            tr(13, si, Paused, Running, Resume),
            tr(20, si, Running, Terminated, Completed),
            tr(20, xi, Running, Terminated, Completed),
        ],
    );
    // The monitor's firing at 4 ms, while S was paused already, is recorded as fired.
    assert!(sim.records().iter().any(|r| matches!(
        r.entry,
        Entry::Event(Event::Fired { owner, cause: Mon(mm), .. }) if owner == si && mm == m
    )));
}

/// semantics.md 7, table row 2: "a `PauseOwner` monitor | ... | pauses the owner and its
/// blocking children | lifted by the condition clearing | recorded cause `(monitor …)` both
/// ways"; row 3: the blocking child's cause is "the caller's". Two levels down: X runs Y,
/// Y runs step S; X's monitor holds from 3 to 6 ms. All three move with the monitor as
/// cause, in both directions, outermost first.
#[test]
fn a_pause_owner_hold_moves_its_grandchild_with_the_monitor_as_cause() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let y = seq
        .add(SeqConfig::new("Y"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let yi = y.id();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![Op::Run(y)]))
        .unwrap();
    let xi = x.id();
    let mut hold = |c: &Ctrl, _: Instant| c.flag(1);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(xi, Monitor::new("hold", &mut hold, Behaviour::PauseOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| {
        c.set(1, (3..6).contains(&ms(t)));
        c.set(15, ms(t) >= 10);
    });
    sim.start(xi).unwrap();
    assert_eq!(sim.run_until_idle(millis(50)), Some(at(10)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(0, yi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, xi, Running, Paused, Mon(m)),
            tr(3, yi, Running, Paused, Mon(m)),
            tr(3, si, Running, Paused, Mon(m)),
            tr(6, xi, Paused, Running, Mon(m)),
            tr(6, yi, Paused, Running, Mon(m)),
            tr(6, si, Paused, Running, Mon(m)),
            tr(10, si, Running, Terminated, Completed),
            tr(10, yi, Running, Terminated, Completed),
            tr(10, xi, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// semantics.md 3: the exception mark of the caller a `…CallerOfOwner` behaviour stops.
// ---------------------------------------------------------------------------------------

/// What a hook saw: (hook of, caller's state, caller marked, owner's state, owner marked).
type Seen = (&'static str, RunningState, bool, RunningState, bool);

/// A control system whose cleanup hooks read the sequencer (a `static` in firmware).
#[derive(Default)]
struct Marks {
    seq: OnceCell<&'static Sequencer<Marks, 8>>,
    ids: Cell<Option<(SeqId, SeqId)>>,
    stop_flag: Cell<bool>,
    seen: RefCell<Vec<Seen>>,
}

impl Marks {
    fn look(&self, who: &'static str) {
        let seq = self.seq.get().unwrap();
        let (caller, owner) = self.ids.get().unwrap();
        let (hc, ho) = (
            seq.sequence_by_id(caller).unwrap(),
            seq.sequence_by_id(owner).unwrap(),
        );
        self.seen.borrow_mut().push((
            who,
            hc.state(),
            hc.exception_is_active(),
            ho.state(),
            ho.exception_is_active(),
        ));
    }
}

struct Stuck;
impl Step<Marks> for Stuck {
    fn action(&mut self, _cx: &Cx<'_, Marks>) -> Result<(), Failure> {
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, Marks>) -> bool {
        false
    }
}

struct RunsStuck(Seq<Stuck>);
impl Sequence<Marks> for RunsStuck {
    async fn action(&mut self, cx: &Cx<'_, Marks>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

/// semantics.md 3: "The caller a `…CallerOfOwner` behaviour aborts or restarts is marked
/// too, right after its cleanup hook, before the lanes its stop wakes run ... and names the
/// monitor"; `Handle::exception_is_active`: "while the exception sequence runs only the
/// owner's is set". Step S (run by A) has an `AbortCallerOfOwner` monitor firing at 3 ms.
/// S's hook (S stopped first, innermost first) and A's hook both read A `Aborting` and
/// not yet marked, S marked (the owner, from the firing); after the tick A is marked and
/// names the monitor.
#[test]
fn the_caller_s_cleanup_hook_reads_it_stopped_and_not_yet_marked() {
    let seq: &'static Sequencer<Marks, 8> = Box::leak(Box::new(Sequencer::new()));
    let ctrl = Marks::default();
    ctrl.seq.set(seq).ok().unwrap();
    let s = seq
        .add(SeqConfig::new("S").on_abort(|c: &Marks| c.look("S")), Stuck)
        .unwrap();
    let si = s.id();
    let a = seq
        .add(
            SeqConfig::new("A").on_abort(|c: &Marks| c.look("A")),
            RunsStuck(s),
        )
        .unwrap();
    let ai = a.id();
    ctrl.ids.set(Some((ai, si)));
    let mut cond = |c: &Marks, _: Instant| c.stop_flag.get();
    let mut monitors = Monitors::<Marks, 1>::new();
    let m = monitors
        .add(
            si,
            Monitor::new("jam", &mut cond, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.stop_flag.set(ms(t) >= 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(5));
    assert_eq!(
        *ctrl.seen.borrow(),
        vec![
            ("S", Running, false, Aborting, true),
            ("A", Aborting, false, Aborted, true),
        ]
    );
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.state(), ha.exception_is_active(), ha.active_exception()),
        (Aborted, true, Some(Mon(m)))
    );
}

/// `Cause::is_exception`: "An exception: a monitor or a timeout fired (`Monitor`,
/// `Timeout`)" — every other cause is not (tests/exception_marks.rs leaves out
/// `PreConditionFalse`, `Pause`, `Resume` and `Failed`).
#[test]
fn is_exception_is_true_for_monitors_and_timeouts_only() {
    let all = [
        Start,
        Cause::PreConditionFalse,
        Completed,
        Pause,
        Resume,
        Cause::Abort,
        Cause::AbortAll,
        Mon(MonitorId::from_index(3)),
        Cause::Timeout(SeqId::from_index(2)),
        Restart,
        Cause::Dropped,
        Cause::Failed,
    ];
    let exceptions: Vec<Cause> = all.into_iter().filter(|c| c.is_exception()).collect();
    assert_eq!(
        exceptions,
        vec![
            Mon(MonitorId::from_index(3)),
            Cause::Timeout(SeqId::from_index(2))
        ]
    );
}

/// design-decisions.md: `exceptionIsActive` "**differs on purpose**: also from the firing
/// until the exception is handled, whatever the behaviour (`Nothing` with an exception
/// sequence included) ...; cleared when a `Nothing` exception ends". S's `Nothing` monitor
/// fires at 3 ms with exception sequence E (a 4 ms wait): S is marked from 3 ms while E
/// runs, until the tick after E's end (7 ms: reported at 8), then unmarked, still naming
/// the monitor.
#[test]
fn a_nothing_exception_with_an_exception_sequence_marks_the_owner_until_it_ends() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq.add(SeqConfig::new("w"), Wait::new(millis(4))).unwrap();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let ei = e.id();
    let s = seq
        .add(SeqConfig::new("S"), Node::of(vec![]).until(15))
        .unwrap();
    let si = s.id();
    let mut c2 = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            si,
            Monitor::new("warn", &mut c2, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(s);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(2, ms(t) >= 3));
    sim.start(si).unwrap();
    let mut marks = Vec::new();
    for _ in 0..10 {
        sim.step();
        let h = sim.handle(si).unwrap();
        marks.push((ms(sim.now()), h.exception_is_active(), sim.state(ei)));
    }
    let marked: Vec<u64> = marks.iter().filter(|m| m.1).map(|m| m.0).collect();
    assert_eq!(marked, vec![3, 4, 5, 6, 7], "{marks:?}");
    assert_eq!(sim.state(ei), Terminated);
    assert_eq!(sim.state(si), Running);
    assert_eq!(sim.handle(si).unwrap().active_exception(), Some(Mon(m)));
}

// ---------------------------------------------------------------------------------------
// semantics.md 4: cleanup hooks on restart.
// ---------------------------------------------------------------------------------------

/// semantics.md 4: "a restarted sequence runs its hook too, in the move to `Restarting`
/// (there is no `Aborting` step), once per restart, after those of the sequences below
/// it". A `Level` `RestartOwner` monitor (limit 2) true from 3 ms restarts main at 3 and 4
/// ms and aborts it at 5 ms (escalated): the hooks are s, main three times, and main's
/// restarts never pass through `Aborting`.
#[test]
fn a_restarted_sequence_runs_its_hook_once_per_restart_after_its_child() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("s").on_abort(hook_of("s")), Leaf::until(15))
        .unwrap();
    let si = s.id();
    let main = seq
        .add(
            SeqConfig::new("main").on_abort(hook_of("main")),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let mi = main.id();
    let mut c2 = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("again", &mut c2, Behaviour::RestartOwner)
                .trigger(Trigger::Level)
                .restart_limit(2),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| c.set(2, ms(t) >= 3));
    sim.start(mi).unwrap();
    sim.run_for(millis(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, si, Running, Aborting, Mon(m)),
            tr(3, si, Aborting, Aborted, Mon(m)),
            tr(3, mi, Running, Restarting, Mon(m)),
            tr(3, mi, Restarting, Running, Restart),
            tr(3, si, Aborted, Running, Start),
            tr(4, si, Running, Aborting, Mon(m)),
            tr(4, si, Aborting, Aborted, Mon(m)),
            tr(4, mi, Running, Restarting, Mon(m)),
            tr(4, mi, Restarting, Running, Restart),
            tr(4, si, Aborted, Running, Start),
            tr(5, si, Running, Aborting, Mon(m)),
            tr(5, si, Aborting, Aborted, Mon(m)),
            tr(5, mi, Running, Aborting, Mon(m)),
            tr(5, mi, Aborting, Aborted, Mon(m)),
        ],
    );
    assert_eq!(
        *ctrl.hooks.borrow(),
        vec!["s", "main", "s", "main", "s", "main"]
    );
}

// ---------------------------------------------------------------------------------------
// semantics.md 16: failures and cleanup.
// ---------------------------------------------------------------------------------------

#[derive(Default)]
struct Pump {
    on: Cell<bool>,
    log: RefCell<Vec<(u64, &'static str)>>,
    /// The dose's action fails with `Failure::App(7)`.
    fail: Cell<bool>,
}

struct Dose;
impl Step<Pump> for Dose {
    fn action(&mut self, cx: &Cx<'_, Pump>) -> Result<(), Failure> {
        cx.control().on.set(true);
        cx.control()
            .log
            .borrow_mut()
            .push((ms(cx.now()), "pump on"));
        if cx.control().fail.get() {
            return Err(Failure::App(7));
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, Pump>) -> bool {
        false
    }
}

struct Glue {
    dose: Seq<Dose>,
}
impl Sequence<Pump> for Glue {
    async fn action(&mut self, cx: &Cx<'_, Pump>) -> Result<(), Failure> {
        // semantics.md 16's pattern: match the child's result instead of `?`, clean up,
        // then return the failure.
        let r = cx.step(&mut self.dose).await;
        cx.control().on.set(false);
        cx.control()
            .log
            .borrow_mut()
            .push((ms(cx.now()), "pump off"));
        r?;
        Ok(())
    }
}

fn pump_off(p: &Pump) {
    p.on.set(false);
    p.log.borrow_mut().push((99, "hook"));
}

/// semantics.md 16: "A failure is not an abort: no behaviour, no cleanup hook, no restart
/// ...: what must happen on every end (a pump off ...) is the failing action's own last
/// step before its `Err`, or the caller's after it (match the child's result instead of
/// `?`, clean up, then return the failure), plus a cleanup hook for aborts." The dose
/// fails at once: the caller's lines switch the pump off and its run fails with the
/// dose's failure; no hook runs. The dose aborted by its timeout (3 ms): the caller gets
/// `Failure::Aborted` and switches the pump off too. The caller itself aborted: its lines
/// after the await never run (sticky abort), its hook does.
#[test]
fn a_caller_that_matches_the_child_s_result_cleans_up_and_fails_with_it() {
    fn set_up(
        fail: bool,
        dose_timeout: Option<u64>,
        abort_caller_at: Option<u64>,
    ) -> (Vec<(u64, &'static str)>, bool, Option<Outcome>) {
        let seq: Sequencer<Pump, 4> = Sequencer::new();
        let pump = Pump::default();
        pump.fail.set(fail);
        let mut cfg = SeqConfig::new("dose").on_abort(pump_off);
        if let Some(t) = dose_timeout {
            cfg = cfg.timeout(millis(t));
        }
        let dose = seq.add(cfg, Dose).unwrap();
        let glue = seq
            .add(SeqConfig::new("glue").on_abort(pump_off), Glue { dose })
            .unwrap();
        let gi = glue.id();
        let mut sim = Sim::new(&seq, &pump, Monitors::<Pump, 1>::new());
        sim.lane(glue);
        sim.start(gi).unwrap();
        if let Some(t) = abort_caller_at {
            sim.run_until(at(t));
            sim.abort(gi).unwrap();
        }
        sim.run_for(millis(10));
        let out = sim.handle(gi).unwrap().last_outcome();
        let log = pump.log.borrow().clone();
        (log, pump.on.get(), out)
    }
    // The dose fails: the caller cleans up and fails with the same failure; no hook.
    assert_eq!(
        set_up(true, None, None),
        (
            vec![(0, "pump on"), (0, "pump off")],
            false,
            Some(Outcome::Failed(Failure::App(7)))
        )
    );
    // The dose is aborted by its timeout: its hook, then the caller's cleanup lines.
    assert_eq!(
        set_up(false, Some(3), None),
        (
            vec![(0, "pump on"), (99, "hook"), (3, "pump off")],
            false,
            Some(Outcome::Failed(Failure::Aborted(Cause::Timeout(
                SeqId::from_index(0)
            ))))
        )
    );
    // The caller is aborted (request at 2 ms, carried out at 3): the hooks only.
    assert_eq!(
        set_up(false, None, Some(2)),
        (
            vec![(0, "pump on"), (99, "hook"), (99, "hook")],
            false,
            Some(Outcome::Aborted(Cause::Abort))
        )
    );
}

/// semantics.md 16: "`?` on `Cx::start`'s `Err`, returned at once, gives the same
/// failure, through `From<Error>`" — a start of a sequence already running.
#[test]
fn question_mark_on_a_refused_non_blocking_start_fails_with_not_started() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let busy = seq
        .add(SeqConfig::new("busy"), Node::of(vec![]).until(15))
        .unwrap();
    let bi = busy.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Start(bi)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(busy);
    sim.lane(main);
    sim.start(bi).unwrap();
    sim.start(mi).unwrap();
    sim.run_for(millis(3));
    let failure = Failure::NotStarted(Error::AlreadyRunning(bi));
    assert_eq!(Failure::from(Error::AlreadyRunning(bi)), failure);
    let want = Err(failure);
    let r = ctrl.returned.borrow()[0];
    assert_eq!((r.ms, r.seq, r.result), (0, mi, want));
}

// ---------------------------------------------------------------------------------------
// Printing records: MonitorNames (rustdoc, firmware-guide 5, README).
// ---------------------------------------------------------------------------------------

fn never(_: &Ctrl, _: Instant) -> bool {
    false
}
fn jam(c: &Ctrl, _: Instant) -> bool {
    c.flag(2)
}

/// `MonitorNames`: "The names of `monitors`, in table order (monitor `i` is the table's
/// entry `i`)"; firmware-guide.md's `supervise`: "`defmt::info!("{}",
/// record.named(&(seq, &MONITOR_NAMES)))` (the names of `monitors!`'s `names`, since the
/// tick's task owns the table)". A record of the second monitor's firing, printed with the
/// sequencer and the names alone (the table moved into the simulator), names it; an id
/// past the names has none.
#[test]
fn records_print_with_the_sequencer_and_monitor_names_apart_from_the_table() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("move"), Node::of(vec![]).until(15))
        .unwrap();
    let si = s.id();
    let table = [
        Monitor::with_fn("idle check", never, Behaviour::Nothing).owned_by(si),
        Monitor::with_fn("jam", jam, Behaviour::AbortOwner).owned_by(si),
    ];
    let names: MonitorNames<2> = MonitorNames::of(&table);
    assert_eq!(names, MonitorNames(["idle check", "jam"]));
    assert_eq!(names.monitor(MonitorId::from_index(2)), None);
    let monitors: Monitors<Ctrl, 2, ConditionFn<Ctrl>> = Monitors::table(table).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(s);
    sim.before_tick(|t, c| c.set(2, ms(t) >= 3));
    sim.start(si).unwrap();
    sim.run_for(millis(5));
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&(&seq, &names)).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms move: Idle -> Running (start)",
            "3 ms monitor `jam` of `move` fired: AbortOwner",
            "3 ms move: Running -> Aborting (monitor `jam`)",
            "3 ms move: Aborting -> Aborted (monitor `jam`)",
        ]
    );
}

// ---------------------------------------------------------------------------------------
// The safety system: START after STOP (semantics.md, safety section).
// ---------------------------------------------------------------------------------------

mod start_after_stop {
    use rtseq::safety::*;

    pub const IDLE: SafetyLevel = SafetyLevel::new(0);
    pub const RUN: SafetyLevel = SafetyLevel::new(1);
    pub const START: PublicEvent = PublicEvent::new(0);
    pub const STOP: PublicEvent = PublicEvent::new(1);

    pub struct NoIo;
    impl SafetyIo for NoIo {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }

    const PLAIN: &[LevelTransition] = &[
        LevelTransition::on(IDLE, START, RUN),
        LevelTransition::on(RUN, STOP, IDLE),
    ];
    const WITH_STAY: &[LevelTransition] = &[
        LevelTransition::on(IDLE, START, RUN),
        LevelTransition::on(RUN, STOP, IDLE),
        LevelTransition::on(RUN, START, RUN),
    ];

    pub static PLAIN_PROPS: ValidProperties<'static, NoIo, 2> = match SafetyProperties::new(
        [LevelDef::new(IDLE, "idle"), LevelDef::new(RUN, "run")],
        &[],
        &[],
        PLAIN,
        IDLE,
    )
    .validated()
    {
        Ok(v) => v,
        Err(_) => panic!("invalid"),
    };
    pub static STAY_PROPS: ValidProperties<'static, NoIo, 2> = match SafetyProperties::new(
        [LevelDef::new(IDLE, "idle"), LevelDef::new(RUN, "run")],
        &[],
        &[],
        WITH_STAY,
        IDLE,
    )
    .validated()
    {
        Ok(v) => v,
        Err(_) => panic!("invalid"),
    };
}

/// In RUN, STOP then START before one cycle:
/// * with a "stay" row for START in RUN, STOP's IDLE wins and START is dropped: no count,
///   no record (the sequencer's records show the level IDLE only), the level stays IDLE;
/// * without a row for START in RUN (the natural table), START is an unknown event of RUN
///   and counted as one (the "Unknown events" rule), IDLE entered too.
///
/// Waiting until the handle shows IDLE, the START of the next cycle enters RUN.
///
/// docs/semantics.md (safety): "A losing event with a row from the level is dropped
/// without a record or a count (one without a row is unknown, below): ... its `START` loses
/// to the `STOP` of the same cycle, or is counted unknown there; either way it has no
/// effect." (The review found the first wording, "the losing events are dropped without a
/// record or a count", true only with a "stay" row.)
#[test]
fn a_start_right_after_a_stop_is_lost_unless_it_waits_for_the_stop_s_level() {
    use rtseq::safety::*;
    use start_after_stop::*;
    for (props, unknown) in [(&STAY_PROPS, 0), (&PLAIN_PROPS, 1)] {
        let seq: Sequencer<(), 2> = Sequencer::new();
        let mut safety = SafetySystem::new_validated(props, seq.safety_handle()).unwrap();
        let h = seq.safety_handle();
        let mut io = NoIo;
        safety.cycle(&mut io, &seq); // IDLE entered
        h.trigger(START);
        safety.cycle(&mut io, &seq); // RUN
        assert_eq!(h.level(), RUN);
        h.trigger(STOP);
        h.trigger(START);
        let r = safety.cycle(&mut io, &seq);
        assert_eq!(
            (
                r.level,
                r.unknown_events,
                safety.unknown_events(),
                h.level()
            ),
            (IDLE, unknown, unknown, IDLE)
        );
        // The pattern: START once the handle shows STOP's level.
        h.trigger(START);
        let r = safety.cycle(&mut io, &seq);
        assert_eq!((r.level, safety.unknown_events()), (RUN, unknown));
        // The sequencer's records: the levels entered, nothing of the lost START.
        seq.tick(
            Instant::from_ticks(1000),
            &(),
            &mut Monitors::<(), 1>::new(),
        )
        .unwrap();
        let mut levels = Vec::new();
        seq.drain_records(|r| levels.push(r.entry));
        assert_eq!(
            levels,
            [IDLE, RUN, IDLE, RUN]
                .map(|level| Entry::Event(Event::SafetyLevel { level }))
                .to_vec()
        );
    }
}

// ---------------------------------------------------------------------------------------
// CHANGELOG.md, "Migrating from 0.1": code written as the notes say.
// ---------------------------------------------------------------------------------------

/// Migration 9: "A helper that returns one names the context's borrow too: `fn later<'c,
/// 'a, 's>(cx: &'c Cx<'a, C>, step: &'s mut Seq<S>) -> impl Future<…> + use<'c, 'a, 's, C,
/// S>`". Written so, it compiles, and the step it returns runs where the action awaits it.
fn later<'c, 'a, 's, C, S: Step<C>>(
    cx: &'c Cx<'a, C>,
    step: &'s mut Seq<S>,
) -> impl Future<Output = Result<Done, Failure>> + use<'c, 'a, 's, C, S> {
    cx.step(step)
}

struct Later(Seq<Leaf>);
impl Sequence<Ctrl> for Later {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let f = later(cx, &mut self.0);
        f.await?;
        Ok(())
    }
}

#[test]
fn migration_9_a_helper_returning_a_step_s_future_compiles_and_runs() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("s"), Leaf::until(15)).unwrap();
    let si = s.id();
    let main = seq.add(SeqConfig::new("main"), Later(s)).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.before_tick(|t, c| c.set(15, ms(t) >= 4));
    sim.start(mi).unwrap();
    assert_eq!(sim.run_until_idle(millis(20)), Some(at(4)));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(4, si, Running, Terminated, Completed),
            tr(4, mi, Running, Terminated, Completed),
        ],
    );
}

/// Migration 5: "`Error::DuplicateName` now carries the `SeqId` that already has the name
/// (0.1: the name), which keeps `Outcome` at 4 bytes. `Counters` (feature `counters`) has a
/// new field, `failed` ... (failed runs were counted in `completed`)."
#[test]
fn migration_5_duplicate_name_names_the_first_and_failed_runs_count_as_failed() {
    assert_eq!(core::mem::size_of::<Outcome>(), 4);
    let seq: Sequencer<Pump, 4> = Sequencer::new();
    let pump = Pump::default();
    pump.fail.set(true);
    let dose = seq.add(SeqConfig::new("dose"), Dose).unwrap();
    let first = dose.id();
    assert_eq!(
        seq.add(SeqConfig::new("dose"), Dose).map(|s| s.id()),
        Err(Error::DuplicateName(first))
    );
    let glue = seq.add(SeqConfig::new("glue"), Glue { dose }).unwrap();
    let gi = glue.id();
    let mut sim = Sim::new(&seq, &pump, Monitors::<Pump, 1>::new());
    sim.lane(glue);
    sim.start(gi).unwrap();
    sim.run_for(millis(2));
    #[cfg(feature = "counters")]
    {
        let c = sim.handle(first).unwrap().counters();
        assert_eq!((c.runs, c.completed, c.failed), (1, 0, 1));
        let c = sim.handle(gi).unwrap().counters();
        assert_eq!((c.runs, c.completed, c.failed), (1, 0, 1));
    }
    assert_eq!(
        sim.handle(gi).unwrap().last_outcome(),
        Some(Outcome::Failed(Failure::App(7)))
    );
}

/// Migration 6: "`drain_trace` still hands out the transitions alone (it drops the
/// events); `drain_records` hands out both." Two requests (events) and the tick's pause
/// (a transition): `drain_trace` gives the transition alone and drops the events, after
/// which `drain_records` has nothing; the same again drained by `drain_records` gives all
/// three.
#[test]
fn migration_6_drain_trace_drops_the_events_drain_records_keeps_them() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("s"), Node::of(vec![]).until(15))
        .unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(s);
    sim.start(si).unwrap();
    sim.step();
    let h = seq.sequence_by_id(si).unwrap();
    let mut monitors = Monitors::<Ctrl, 1>::new();
    // Round 1: drained as a trace.
    h.pause().unwrap();
    seq.tick(at(5), &ctrl, &mut monitors).unwrap();
    let mut trace = Vec::new();
    assert_eq!(seq.drain_trace(|t| trace.push(t)), 0);
    assert_eq!(trace, [tr(5, si, Running, Paused, Pause)]);
    let mut rest = 0;
    seq.drain_records(|_| rest += 1);
    assert_eq!(rest, 0, "drain_trace dropped the request's event");
    // Round 2: drained as records.
    h.resume().unwrap();
    seq.tick(at(6), &ctrl, &mut monitors).unwrap();
    let mut records = Vec::new();
    seq.drain_records(|r| records.push(r.entry));
    assert!(
        matches!(
            records[..],
            [
                Entry::Event(Event::Requested { .. }),
                Entry::Transition {
                    from: Paused,
                    to: Running,
                    cause: Resume,
                    ..
                }
            ]
        ),
        "{records:?}"
    );
}

/// Migration 7: "`Sim::with_period` returns `Result<Sim, SimError>` (a zero period used to
/// make `run_for` spin forever). `Sim::start` checks the configuration on the first start
/// and returns `Err(Error::InvalidConfig)` for one that cannot work (a monitor owner that
/// is not registered, an exception sequence that is its own owner or has no lane)"; the
/// README: "a lane no `sim.lane` runs, is an `Err`" (`NoLane`).
#[test]
fn migration_7_the_first_start_refuses_a_configuration_that_cannot_work() {
    type Mons = Monitors<'static, Ctrl, 1, ConditionFn<Ctrl>>;
    type Case = fn(&Seqr, &mut Mons) -> (SeqId, Option<Seq<Node>>);
    type Want = fn(SeqId) -> Error;
    let cases: [(Case, Want); 4] = [
        // A monitor whose owner is not registered.
        (
            |seq, mons| {
                let s = seq.add(SeqConfig::new("s"), Node::of(vec![])).unwrap();
                mons.add(
                    SeqId::from_index(9),
                    Monitor::with_fn("ghost", never, Behaviour::Nothing),
                )
                .unwrap();
                (s.id(), Some(s))
            },
            |_| Error::InvalidConfig,
        ),
        // An exception sequence that is its own owner.
        (
            |seq, mons| {
                let s = seq.add(SeqConfig::new("s"), Node::of(vec![])).unwrap();
                mons.add(
                    s.id(),
                    Monitor::with_fn("self", never, Behaviour::Nothing).exception(s.id()),
                )
                .unwrap();
                (s.id(), Some(s))
            },
            |_| Error::InvalidConfig,
        ),
        // An exception sequence without a lane.
        (
            |seq, mons| {
                let e = seq.add(SeqConfig::new("e"), Node::of(vec![])).unwrap();
                let s = seq.add(SeqConfig::new("s"), Node::of(vec![])).unwrap();
                mons.add(
                    s.id(),
                    Monitor::with_fn("w", never, Behaviour::Nothing).exception(e.id()),
                )
                .unwrap();
                (s.id(), Some(s))
            },
            |_| Error::InvalidConfig,
        ),
        // A lane declared in the configuration that no `sim.lane` runs.
        (
            |seq, _| {
                let e = seq
                    .add(SeqConfig::new("e").in_lane(), Node::of(vec![]))
                    .unwrap();
                let s = seq.add(SeqConfig::new("s"), Node::of(vec![])).unwrap();
                let _ = e;
                (s.id(), Some(s))
            },
            |_| Error::NoLane(SeqId::from_index(0)),
        ),
    ];
    for (i, (make, want)) in cases.into_iter().enumerate() {
        let seq = Seqr::new();
        let ctrl = Ctrl::default();
        let mut mons = Mons::new();
        let (id, lane) = make(&seq, &mut mons);
        let mut sim = Sim::new(&seq, &ctrl, mons);
        if let Some(l) = lane {
            sim.lane(l);
        }
        assert_eq!(sim.start(id), Err(want(id)), "case {i}");
        assert_eq!(sim.state(id), Idle, "case {i}");
    }
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let zero =
        Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new()).with_period(Duration::from_ticks(0));
    assert!(matches!(zero, Err(SimError::ZeroPeriod)));
}

/// Migration 3: "`PriorityCeiling<0x10>` still compiles and now means priority 16, the top
/// priority of a 4-bit part, whose sections disable interrupts"; "A pair RTIC does not
/// accept does not compile, so most old BASEPRI values (`0xE0`, ...) are now build
/// errors"; "`lock::Ceiling::of(priority, bits)` says what a section does".
#[test]
fn migration_3_old_basepri_values_as_priorities() {
    use rtseq::lock::Ceiling;
    assert_eq!(Ceiling::of(0x10, 4), Some(Ceiling::InterruptsDisabled));
    assert_eq!(Ceiling::of(0xE0, 4), None);
    assert_eq!(Ceiling::of(0x20, 4), None);
    assert_eq!(Ceiling::of(2, 3), Some(Ceiling::Basepri(0xC0)));
}

/// Migration 4: "`Transition` → `LevelTransition` (so that glob imports of `rtseq::*` and
/// `rtseq::safety::*` do not clash) and `AbortSequences` → `Sequences`". Both globs in one
/// module: `Transition` is the sequencer's, `LevelTransition` the safety system's, and a
/// `Sequencer` is a `Sequences`.
mod both_globs {
    #[allow(unused_imports)]
    use rtseq::safety::*;
    #[allow(unused_imports)]
    use rtseq::*;

    pub fn names() -> (Transition, LevelTransition) {
        let t = Transition::at_millis(
            1,
            SeqId::from_index(0),
            RunningState::Idle,
            RunningState::Running,
            Cause::Start,
        );
        let l = LevelTransition::on(
            SafetyLevel::new(1),
            PublicEvent::new(0),
            SafetyLevel::new(0),
        );
        (t, l)
    }

    pub fn is_sequences<S: Sequences>(_: &S) {}
}

#[test]
fn migration_4_both_globs_import_without_a_clash() {
    let (t, _) = both_globs::names();
    assert_eq!(t.cause, Cause::Start);
    let seq: Sequencer<(), 2> = Sequencer::new();
    both_globs::is_sequences(&seq);
}

// ---------------------------------------------------------------------------------------
// docs/design-decisions.md: where rtseq differs from the seed and EEROS.
// ---------------------------------------------------------------------------------------

/// design-decisions.md: "`Cx::wait_until` and `Cx::join` wait inside an action; the tick
/// keeps evaluating the monitors and the timeout meanwhile" (tests/exception_marks.rs
/// checks `wait_until`; this is the join). Main (timeout 3 ms) starts worker W and joins
/// it: the timeout fires at 3 ms during the join and aborts main and, below it, W
/// (semantics 4: an abort reaches non-blocking sub-sequences too), innermost first. The
/// join never returns into the aborted action.
#[test]
fn the_timeout_fires_while_the_action_waits_in_a_join() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(SeqConfig::new("W"), Node::of(vec![]).until(15))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(millis(3)),
            Node::of(vec![Op::Start(wi), Op::Join(wi)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(w);
    sim.start(mi).unwrap();
    sim.run_for(millis(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(3, wi, Running, Aborting, Cause::Timeout(mi)),
            tr(3, wi, Aborting, Aborted, Cause::Timeout(mi)),
            tr(3, mi, Running, Aborting, Cause::Timeout(mi)),
            tr(3, mi, Aborting, Aborted, Cause::Timeout(mi)),
        ],
    );
    assert!(ctrl.joins.borrow().is_empty(), "{:?}", ctrl.joins.borrow());
    assert_eq!(ctrl.lines_of(mi), vec![(0, 0), (0, 1)]);
}

/// design-decisions.md: "order of a poll: ... monitors and timeout first, then the exit
/// condition of the same tick, as EEROS's code does ...: a fault and the target reached
/// in one poll abort the move". Step S (polling 5 ms) reaches its target at 5 ms, the
/// moment its `AbortOwner` monitor's condition turns true: S is aborted, not completed.
#[test]
fn a_fault_and_the_target_in_one_poll_abort_the_move() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("S").polling(millis(5)), Leaf::until(15))
        .unwrap();
    let si = s.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let mi = main.id();
    let mut c2 = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 1>::new();
    let m = monitors
        .add(si, Monitor::new("fault", &mut c2, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|t, c| {
        c.set(2, ms(t) >= 3);
        c.set(15, ms(t) >= 3);
    });
    sim.start(mi).unwrap();
    sim.run_for(millis(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(5, si, Running, Aborting, Mon(m)),
            tr(5, si, Aborting, Aborted, Mon(m)),
            tr(5, mi, Running, Terminated, Completed),
        ],
    );
    assert_eq!(
        ctrl.returned.borrow()[0].result,
        Err(Failure::Aborted(Mon(m)))
    );
}

/// semantics.md 7, table row 2: a `PauseOwner` monitor pauses the owner "not its
/// non-blocking children (their monitors and timeouts go on)" (tests/exception_marks.rs
/// checks the timeout; this is a monitor). X starts N and runs step S; X's hold from 2 ms;
/// N's `AbortOwner` monitor fires at 4 ms, during X's hold, and aborts N; X and S resume at
/// 7 ms.
#[test]
fn a_non_blocking_child_s_monitor_fires_during_its_caller_s_pause_owner_hold() {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let n = seq
        .add(SeqConfig::new("N"), Node::of(vec![]).until(15))
        .unwrap();
    let ni = n.id();
    let x = seq
        .add(
            SeqConfig::new("X"),
            Node::of(vec![Op::Start(ni), Op::Step(s)]),
        )
        .unwrap();
    let xi = x.id();
    let mut hold = |c: &Ctrl, _: Instant| c.flag(1);
    let mut fault = |c: &Ctrl, _: Instant| c.flag(2);
    let mut monitors = Monitors::<Ctrl, 2>::new();
    let h = monitors
        .add(xi, Monitor::new("hold", &mut hold, Behaviour::PauseOwner))
        .unwrap();
    let f = monitors
        .add(ni, Monitor::new("fault", &mut fault, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(n);
    sim.before_tick(|t, c| {
        c.set(1, (2..7).contains(&ms(t)));
        c.set(2, ms(t) >= 4);
    });
    sim.start(xi).unwrap();
    sim.run_for(millis(8));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(0, ni, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(2, xi, Running, Paused, Mon(h)),
            tr(2, si, Running, Paused, Mon(h)),
            tr(4, ni, Running, Aborting, Mon(f)),
            tr(4, ni, Aborting, Aborted, Mon(f)),
            tr(7, xi, Paused, Running, Mon(h)),
            tr(7, si, Paused, Running, Mon(h)),
        ],
    );
}

/// README: "`record.named(&seq)` prints one as a line (all names: `&(&seq, sim.monitors(),
/// PROPS.properties(), &failures)`". Written so, it compiles and names the failure code.
#[test]
fn the_readme_s_four_names_print_a_failure_by_its_name() {
    use rtseq::Failures;
    const FAILURES: Failures = Failures(&[(7, "pump jammed")]);
    let seq: Sequencer<Pump, 4> = Sequencer::new();
    let pump = Pump::default();
    pump.fail.set(true);
    let dose = seq.add(SeqConfig::new("dose"), Dose).unwrap();
    let glue = seq.add(SeqConfig::new("glue"), Glue { dose }).unwrap();
    let gi = glue.id();
    let mut sim = Sim::new(&seq, &pump, Monitors::<Pump, 1>::new());
    sim.lane(glue);
    sim.start(gi).unwrap();
    let props = start_after_stop::PLAIN_PROPS.properties();
    let names = &(&seq, sim.monitors(), props, &FAILURES);
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "0 ms glue: Idle -> Running (start)",
            "0 ms dose: Idle -> Running (start)",
            "0 ms dose: Running -> Terminated (failed)",
            "0 ms `dose` failed: pump jammed",
            "0 ms glue: Running -> Terminated (failed)",
            "0 ms `glue` failed: pump jammed",
        ]
    );
}
