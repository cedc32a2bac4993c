//! A cold review of session 57's changes: `Condition::begin_run` once before each run's or
//! round's first evaluation, a sequencer's monitor table known by its tag (moved
//! sequencers, swapped ones, tables made anew), simulators of one sequencer dropped while
//! another lives, and the safety validation of a range's upper end.

use std::cell::Cell;
use std::sync::{Arc, Mutex};

use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Condition, Cx, Duration, Error, Failure, Instant, Monitor, MonitorId,
    Monitors, RunningState, Seq, SeqConfig, SeqId, Sequence, Sequencer, Transition, Trigger, Wait,
};

// ---------------------------------------------------------------------------------------
// A counting condition
// ---------------------------------------------------------------------------------------

#[derive(Default)]
struct K {
    flags: [Cell<bool>; 8],
}

impl K {
    fn set(&self, i: usize, v: bool) {
        self.flags[i].set(v)
    }
    fn flag(&self, i: usize) -> bool {
        self.flags[i].get()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ev {
    /// `begin_run`.
    B,
    /// `validate` at this ms.
    V(u64),
}

type Log = Arc<Mutex<Vec<Ev>>>;

/// Logs every `begin_run` and `validate` (with its time in ms); true while flag `i` is.
struct Counting {
    log: Log,
    flag: usize,
}

impl Counting {
    fn new(flag: usize) -> (Self, Log) {
        let log = Log::default();
        (
            Counting {
                log: log.clone(),
                flag,
            },
            log,
        )
    }
}

impl Condition<K> for Counting {
    fn validate(&mut self, c: &K, now: Instant) -> bool {
        self.log.lock().unwrap().push(Ev::V(now.as_ticks() / 1000));
        c.flag(self.flag)
    }
    fn begin_run(&mut self) {
        self.log.lock().unwrap().push(Ev::B);
    }
}

fn log_of(log: &Log) -> Vec<Ev> {
    log.lock().unwrap().clone()
}

/// The times (ms) at which `id` began a run or a round: its transitions into `Running`
/// that are not a resume.
fn rounds(trace: &[Transition], id: SeqId) -> Vec<u64> {
    trace
        .iter()
        .filter(|t| t.sequence == id && t.to == Running && t.from != Paused)
        .map(|t| t.time.as_ticks() / 1000)
        .collect()
}

/// What semantics 5 and `begin_run`'s rustdoc promise for the evaluations `log` holds: each
/// run or round that is evaluated is told once, right before its first evaluation, and
/// never otherwise. An evaluation at `t` is of the last round begun before `t` (a round
/// begun at `t` is begun after the tick at `t`, by a lane, or by a start between ticks).
fn expected(log: &[Ev], rounds: &[u64]) -> Vec<Ev> {
    let mut out = Vec::new();
    let mut last_round = None;
    for e in log {
        let Ev::V(t) = *e else { continue };
        let round = rounds.iter().rposition(|&r| r < t);
        if round != last_round {
            out.push(Ev::B);
            last_round = round;
        }
        out.push(Ev::V(t));
    }
    out
}

fn show(trace: &[Transition]) -> String {
    trace
        .iter()
        .map(|t| {
            format!(
                "{:>8} us  #{} {:?} -> {:?} ({:?})\n",
                t.time.as_ticks(),
                t.sequence.index(),
                t.from,
                t.to,
                t.cause
            )
        })
        .collect()
}

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Ends at once.
struct Quick;
impl<C> Sequence<C> for Quick {
    async fn action(&mut self, _cx: &Cx<'_, C>) -> Result<(), Failure> {
        Ok(())
    }
}

/// One blocking step of a child, then runs until stopped.
struct Calls(Seq<Forever>);
impl<C> Sequence<C> for Calls {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        let _ = cx.run(&mut self.0).await;
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// A dwell of one blocking `Wait`.
struct Dwell(Seq<Wait>);
impl<C> Sequence<C> for Dwell {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// 1. begin_run: once per run or round, right before its first evaluation
// ---------------------------------------------------------------------------------------

/// Two runs of one owner (aborted by hand between them): one `begin_run` each.
#[test]
fn begin_run_once_per_run() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(id, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    sim.abort(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    let got = log_of(&log);
    assert_eq!(
        got,
        expected(&got, &rounds(sim.trace(), id)),
        "{}",
        show(sim.trace())
    );
    assert_eq!(got.iter().filter(|e| **e == Ev::B).count(), 2, "{got:?}");
}

/// A level `RestartOwner` monitor (the counting one itself) with a limit of 2: three
/// rounds (the third's firing escalates to an abort), each told once.
#[test]
fn begin_run_once_per_restart_round_and_escalation() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(
            id,
            Monitor::new("count", &mut c, Behaviour::RestartOwner)
                .trigger(Trigger::Level)
                .restart_limit(2),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    k.set(0, true);
    sim.run_for(Duration::from_millis(10));
    assert_eq!(sim.state(id), Aborted, "{}", show(sim.trace()));
    let got = log_of(&log);
    let r = rounds(sim.trace(), id);
    assert_eq!(r.len(), 3, "{}", show(sim.trace()));
    assert_eq!(got, expected(&got, &r), "{}", show(sim.trace()));
}

/// `RestartCallerOfOwner`: a child's monitor restarts its caller, whose own (counting)
/// monitor begins each of the caller's rounds.
#[test]
fn begin_run_of_a_caller_restarted_by_its_child_s_monitor() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let child = seq.add(SeqConfig::new("child"), Forever).unwrap();
    let cid = child.id();
    let parent = seq.add(SeqConfig::new("parent"), Calls(child)).unwrap();
    let pid = parent.id();
    let (mut c, log) = Counting::new(0);
    let mut restart = |k: &K, _: Instant| k.flag(1);
    let mut monitors = Monitors::<K, 2>::new();
    monitors
        .add(pid, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(
            cid,
            Monitor::new(
                "restart caller",
                &mut restart,
                Behaviour::RestartCallerOfOwner,
            )
            .trigger(Trigger::Level)
            .restart_limit(2),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(parent);
    sim.start(pid).unwrap();
    sim.run_for(Duration::from_millis(3));
    k.set(1, true);
    sim.run_for(Duration::from_millis(10));
    let got = log_of(&log);
    let r = rounds(sim.trace(), pid);
    assert!(r.len() >= 3, "{}", show(sim.trace()));
    assert_eq!(got, expected(&got, &r), "{}", show(sim.trace()));
}

/// A firing the owner could not take (it handles another exception, whose exception
/// sequence ends with `RestartOwner`): the kept edge goes with the round; the new round's
/// first evaluation is told first and, from "false", fires.
#[test]
fn a_firing_not_taken_then_a_restart_round_is_told_and_fires_from_false() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let handler = seq.add(SeqConfig::new("handler"), Dwell(wait)).unwrap();
    let hid = handler.id();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut warn = |k: &K, _: Instant| k.flag(1);
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 2>::new();
    monitors
        .add(
            id,
            Monitor::new("warn", &mut warn, Behaviour::RestartOwner).exception(hid),
        )
        .unwrap();
    let counted = monitors
        .add(id, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.lane(handler);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    k.set(1, true);
    sim.step(); // 3 ms: warn fires, the handler runs 5 ms
    k.set(1, false);
    sim.step();
    k.set(0, true); // during the exception: not taken
    sim.run_for(Duration::from_millis(15));
    let got = log_of(&log);
    let r = rounds(sim.trace(), id);
    assert_eq!(got, expected(&got, &r), "{}", show(sim.trace()));
    assert_eq!(sim.state(id), Aborted, "{}", show(sim.trace()));
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(rtseq::Outcome::Aborted(Cause::Monitor(counted)))
    );
}

/// A `PauseOwner` monitor (counting) holds its owner; a `RestartOwner` monitor then
/// restarts it: the round runs unpaused and is told once; the pause comes again at the
/// round's first evaluation (from "false").
#[test]
fn pause_owner_across_a_restart_is_told_once_per_round() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c, log) = Counting::new(0);
    let mut restart = |k: &K, _: Instant| k.flag(1);
    let mut monitors = Monitors::<K, 2>::new();
    monitors
        .add(id, Monitor::new("hold", &mut c, Behaviour::PauseOwner))
        .unwrap();
    monitors
        .add(
            id,
            Monitor::new("restart", &mut restart, Behaviour::RestartOwner),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    k.set(0, true);
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(id), Paused, "{}", show(sim.trace()));
    k.set(1, true);
    sim.step();
    k.set(1, false);
    sim.run_for(Duration::from_millis(4));
    assert_eq!(sim.state(id), Paused, "{}", show(sim.trace()));
    let got = log_of(&log);
    let r = rounds(sim.trace(), id);
    assert!(r.len() >= 2, "{}", show(sim.trace()));
    assert_eq!(got, expected(&got, &r), "{}", show(sim.trace()));
}

/// An owner paused (by a request) before its run's first evaluation: its monitors are
/// evaluated while paused, and the first of them is told first.
#[test]
fn an_owner_paused_at_its_first_evaluation_is_told() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(id, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.pause(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    assert_eq!(sim.state(id), Paused);
    sim.resume(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    let got = log_of(&log);
    assert_eq!(got.first(), Some(&Ev::B), "{got:?}");
    assert_eq!(got.iter().filter(|e| **e == Ev::B).count(), 1, "{got:?}");
}

/// A run that ends before its first evaluation, and a new run started before the next
/// tick: one `begin_run`, before the new run's first evaluation.
#[test]
fn a_run_ended_before_its_first_evaluation_and_a_new_one() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let quick = seq.add(SeqConfig::new("quick"), Quick).unwrap();
    let qid = quick.id();
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(qid, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(quick);
    sim.run_for(Duration::from_millis(2));
    sim.start(qid).unwrap();
    assert_eq!(sim.state(qid), Terminated);
    sim.start(qid).unwrap();
    sim.run_for(Duration::from_millis(3));
    // Never evaluated: both runs ended before a tick.
    assert_eq!(log_of(&log), []);
}

/// Three monitors of one owner, each its own counting condition (one type): each told once
/// per run, in a group with a monitor of another owner.
#[test]
fn several_monitors_of_one_owner_each_told_once_per_run() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let other = seq.add(SeqConfig::new("other"), Forever).unwrap();
    let oid = other.id();
    let (mut a, la) = Counting::new(0);
    let (mut b, lb) = Counting::new(0);
    let (mut o, lo) = Counting::new(0);
    let (mut d, ld) = Counting::new(0);
    let mut monitors = Monitors::<K, 4>::new();
    monitors
        .add(id, Monitor::new("a", &mut a, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(oid, Monitor::new("o", &mut o, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(id, Monitor::new("b", &mut b, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(id, Monitor::new("d", &mut d, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.lane(other);
    sim.start(oid).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    sim.abort(id).unwrap();
    sim.step();
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(3));
    let r = rounds(sim.trace(), id);
    for log in [&la, &lb, &ld] {
        let got = log_of(log);
        assert_eq!(got, expected(&got, &r), "{}", show(sim.trace()));
    }
    let got = log_of(&lo);
    assert_eq!(got, expected(&got, &rounds(sim.trace(), oid)));
    assert_eq!(got.iter().filter(|e| **e == Ev::B).count(), 1);
}

/// A sequencer of two words (`B = 2`): one group holds monitors of owners in both words
/// (ids 0 and 33); each owner's rounds are told once.
#[test]
fn a_group_across_two_words_tells_each_owner_once_per_run() {
    let seq: Sequencer<K, 40, 64, rtseq::lock::CriticalSection, 8, 2> = Sequencer::new();
    let low = seq.add(SeqConfig::new("low"), Forever).unwrap();
    let lid = low.id();
    for i in 1..33 {
        let name: &'static str = Box::leak(format!("filler {i}").into_boxed_str());
        seq.register(SeqConfig::new(name)).unwrap();
    }
    let high = seq.add(SeqConfig::new("high"), Forever).unwrap();
    let hid = high.id();
    assert_eq!(hid.index(), 33);
    let (mut a, la) = Counting::new(0);
    let (mut b, lb) = Counting::new(0);
    let mut monitors = Monitors::<K, 2>::new();
    monitors
        .add(lid, Monitor::new("a", &mut a, Behaviour::AbortOwner))
        .unwrap();
    monitors
        .add(hid, Monitor::new("b", &mut b, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(low);
    sim.lane(high);
    sim.start(lid).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.start(hid).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.abort(lid).unwrap();
    sim.step();
    sim.start(lid).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.abort(hid).unwrap();
    sim.step();
    sim.start(hid).unwrap();
    sim.run_for(Duration::from_millis(2));
    for (log, id) in [(&la, lid), (&lb, hid)] {
        let got = log_of(log);
        assert_eq!(got.iter().filter(|e| **e == Ev::B).count(), 2, "{got:?}");
        assert_eq!(
            got,
            expected(&got, &rounds(sim.trace(), id)),
            "{}",
            show(sim.trace())
        );
    }
}

/// `begin_run`'s rustdoc: "A table the sequencer takes up while the run is under way (its
/// first due tick with a non-empty table) evaluates it from then on without this call: its
/// conditions are new." The first due tick comes with an empty table (no table bound yet:
/// the tick takes the due polls, evaluates nothing), the next ones with the real table.
#[test]
fn a_table_taken_up_while_the_run_is_under_way_is_not_told() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let id = seq.register(SeqConfig::new("run")).unwrap();
    seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
    let (mut c, log) = Counting::new(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(id, Monitor::new("count", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    seq.sequence_by_id(id).unwrap().start().unwrap();
    let mut empty = Monitors::<K, 1>::new();
    let ms = |n: u64| Instant::from_ticks(n * 1_000);
    seq.tick(ms(1), &k, &mut empty).unwrap();
    seq.tick(ms(2), &k, &mut monitors).unwrap();
    seq.tick(ms(3), &k, &mut monitors).unwrap();
    assert_eq!(log_of(&log), [Ev::V(2), Ev::V(3)]);
}

/// Semantics 5: a condition's own state of the run starts again with it, but "a `Toggle`
/// is the operator's latch and carries over": a press in the first run leaves it on, and
/// the second run, with no press, is aborted at its first evaluation (5 ms).
#[test]
fn a_toggle_s_state_carries_over_to_the_next_run() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut stop = rtseq::Toggle::new(|k: &K| k.flag(0));
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("stop", &mut stop, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    k.set(0, true);
    sim.step(); // pressed: on, the run is aborted
    k.set(0, false);
    sim.step();
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(rtseq::Outcome::Aborted(Cause::Monitor(m)))
    );
    let second = sim.now().as_ticks() / 1000;
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(5));
    assert_eq!(sim.state(id), Aborted, "{}", show(sim.trace()));
    let end = sim.trace().last().unwrap();
    assert_eq!(
        (end.time.as_ticks() / 1000, end.cause),
        (second + 1, Cause::Monitor(m)),
        "{}",
        show(sim.trace())
    );
}

#[allow(dead_code)]
fn _unused(_: MonitorId, _: RunningState, _: Error) {}

// ---------------------------------------------------------------------------------------
// 2. A monitor table and a moved sequencer
// ---------------------------------------------------------------------------------------

use rtseq::ConditionFn;
use std::sync::atomic::{AtomicBool, Ordering::SeqCst};

fn ms(n: u64) -> Instant {
    Instant::from_ticks(n * 1_000)
}

type Plain = Sequencer<(), 2>;
type FnTable = Monitors<'static, (), 1, ConditionFn<()>>;

/// A sequencer with one sequence (id 0) under way (a declared lane is enough to start it):
/// its polling class is due at every tick.
fn running() -> Plain {
    let seq: Plain = Sequencer::new();
    let id = seq.register(SeqConfig::new("run")).unwrap();
    seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
    seq.sequence_by_id(id).unwrap().start().unwrap();
    seq
}

static TRIP_A: AtomicBool = AtomicBool::new(false);
fn trip_a(_: &(), _: Instant) -> bool {
    TRIP_A.load(SeqCst)
}
static NEVER: AtomicBool = AtomicBool::new(false);
fn never(_: &(), _: Instant) -> bool {
    NEVER.load(SeqCst)
}

fn table(f: ConditionFn<()>) -> FnTable {
    let mut t = FnTable::new();
    t.add(
        SeqId::from_index(0),
        Monitor::with_fn("m", f, Behaviour::AbortOwner),
    )
    .unwrap();
    t
}

/// Two sequencers swap places (`mem::swap`: both moved) after A bound its table: B, now at
/// A's old address, is given A's table. The docs: "A tick with polls due and another
/// table, or with the table of another sequencer, [...] returns
/// `Error::ForeignMonitorTable` and evaluates nothing"; design-decisions: "the table keeps
/// the sequencer's address (a table is one sequencer's: its owners are that sequencer's
/// ids)". Today B takes A's table (it reads its own address in it), and then A's monitor
/// aborts B's sequence, while A (moved) takes the table too.
#[test]
fn a_sequencer_at_another_s_old_place_is_refused_its_table() {
    let mut a = running();
    let mut b = running();
    let mut ta = table(trip_a);
    assert_eq!(a.tick(ms(1), &(), &mut ta), Ok(()));
    std::mem::swap(&mut a, &mut b);
    // `a` is now sequencer B, at A's old address; `b` is A.
    let b_seq = &a;
    let a_seq = &b;
    TRIP_A.store(true, SeqCst);
    let by_b = b_seq.tick(ms(2), &(), &mut ta);
    let by_b_again = b_seq.tick(ms(3), &(), &mut ta);
    let b_state = b_seq.sequence_by_id(SeqId::from_index(0)).unwrap().state();
    TRIP_A.store(false, SeqCst);
    // A, moved, still takes its own table.
    let by_a = a_seq.tick(ms(2), &(), &mut ta);
    assert_eq!(
        (by_b, by_b_again, b_state, by_a),
        (
            Err(Error::ForeignMonitorTable),
            Err(Error::ForeignMonitorTable),
            Running,
            Ok(())
        ),
        "B took A's table, and A's monitor acted on B's sequence"
    );
}

/// A table made anew in the place of a sequencer's table is bound again by the first
/// sequencer that ticks it (`Sequencer::tick`): here the second, and the first is then
/// refused it (the table knows its sequencer by its tag).
#[test]
fn a_table_made_anew_and_bound_by_another_sequencer_is_refused_to_the_first() {
    let a = running();
    let b = running();
    let mut slot = table(never);
    assert_eq!(a.tick(ms(1), &(), &mut slot), Ok(()));
    slot = table(never); // made anew in place
    assert_eq!(b.tick(ms(1), &(), &mut slot), Ok(()), "B binds it");
    assert_eq!(
        a.tick(ms(2), &(), &mut slot),
        Err(Error::ForeignMonitorTable),
        "B's table now"
    );
    assert_eq!(b.tick(ms(2), &(), &mut slot), Ok(()));
}

/// The sequencer's own table after every kind of move (Box, Vec, a thread): taken; another
/// table, empty or not, refused; a table of another sequencer refused.
#[test]
fn a_moved_sequencer_keeps_its_table_and_refuses_others() {
    let a = running();
    let mut ta = Box::new(table(never));
    assert_eq!(a.tick(ms(1), &(), &mut ta), Ok(()));
    let a = Box::new(a);
    assert_eq!(a.tick(ms(2), &(), &mut ta), Ok(()));
    let mut v = vec![*a];
    v.reserve(100);
    let a = v.pop().unwrap();
    assert_eq!(a.tick(ms(3), &(), &mut ta), Ok(()));
    let (a, mut ta) = std::thread::spawn(move || {
        let r = a.tick(ms(4), &(), &mut ta);
        assert_eq!(r, Ok(()));
        (a, ta)
    })
    .join()
    .unwrap();
    assert_eq!(a.tick(ms(5), &(), &mut ta), Ok(()));
    let mut other = table(never);
    assert_eq!(
        a.tick(ms(6), &(), &mut other),
        Err(Error::ForeignMonitorTable)
    );
    let mut empty = FnTable::new();
    assert_eq!(
        a.tick(ms(7), &(), &mut empty),
        Err(Error::ForeignMonitorTable)
    );
    // Another sequencer is refused A's table, and A another's.
    let b = running();
    assert_eq!(b.tick(ms(1), &(), &mut ta), Err(Error::ForeignMonitorTable));
    let mut tb = table(never);
    assert_eq!(b.tick(ms(2), &(), &mut tb), Ok(()));
    assert_eq!(a.tick(ms(8), &(), &mut tb), Err(Error::ForeignMonitorTable));
    let b = Box::new(b);
    assert_eq!(b.tick(ms(3), &(), &mut tb), Ok(()));
    assert_eq!(b.tick(ms(4), &(), &mut ta), Err(Error::ForeignMonitorTable));
    assert_eq!(a.tick(ms(9), &(), &mut ta), Ok(()));
}

/// Empty tables before the binding bind nothing; the first non-empty one is bound.
#[test]
fn empty_tables_then_a_non_empty_one() {
    let a = running();
    let mut e1 = FnTable::new();
    let mut e2 = FnTable::new();
    assert_eq!(a.tick(ms(1), &(), &mut e1), Ok(()));
    assert_eq!(a.tick(ms(2), &(), &mut e2), Ok(()));
    let mut t = table(never);
    assert_eq!(a.tick(ms(3), &(), &mut t), Ok(()));
    assert_eq!(a.tick(ms(4), &(), &mut e1), Err(Error::ForeignMonitorTable));
}

/// Simulators of two sequencers, each dropped and made again, interleaved: each one's
/// table is its own.
#[test]
fn simulators_of_two_sequencers_take_turns() {
    let sa: Sequencer<K, 2> = Sequencer::new();
    let sb: Sequencer<K, 2> = Sequencer::new();
    let k = K::default();
    for round in 0..3 {
        let ra = sa.add(SeqConfig::new(if round == 0 { "a" } else { "" }), Forever);
        let _ = ra;
        let mut ca = |_: &K, _: Instant| false;
        let mut cb = |_: &K, _: Instant| false;
        let mut ta = Monitors::<K, 1>::new();
        ta.add(
            SeqId::from_index(0),
            Monitor::new("a", &mut ca, Behaviour::AbortOwner),
        )
        .unwrap();
        let mut tb = Monitors::<K, 1>::new();
        tb.add(
            SeqId::from_index(0),
            Monitor::new("b", &mut cb, Behaviour::AbortOwner),
        )
        .unwrap();
        let mut sim_a = Sim::new(&sa, &k, ta);
        sim_a.step();
        let mut sim_b = Sim::new(&sb, &k, tb);
        sim_b.step();
        assert_eq!(
            (sim_a.tick_error(), sim_b.tick_error()),
            (None, None),
            "round {round}"
        );
        drop(sim_a);
        drop(sim_b);
    }
}

// ---------------------------------------------------------------------------------------
// 3. A dropped simulator drains the sequencer's records
// ---------------------------------------------------------------------------------------

/// Two simulators of one sequencer alive at once (allowed: neither table is bound while
/// both are empty). The second's sequence is started through a handle; the first is
/// dropped before the second's next step: the start's transition, made while the second
/// simulator was alive and about a lane it runs, is gone from its trace. The docs say a
/// dropped simulator takes "the teardowns of their runs (aborted, `Dropped`)", "records
/// the dropped simulator takes with it, not the next one's trace" — not a living
/// simulator's records.
#[test]
fn dropping_one_simulator_takes_another_living_one_s_records() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let bid = b.id();
    let k = K::default();
    let mut sim1 = Sim::new(&seq, &k, Monitors::<K, 1>::new());
    sim1.lane(a);
    let mut sim2 = Sim::new(&seq, &k, Monitors::<K, 1>::new());
    sim2.lane(b);
    sim1.step();
    sim2.handle(bid).unwrap().start().unwrap();
    drop(sim1);
    sim2.step();
    assert_eq!(sim2.state(bid), Running);
    assert_eq!(
        rounds(sim2.trace(), bid),
        [1],
        "the start of b is missing from sim2's trace: {}",
        show(sim2.trace())
    );
}

/// The control of the test above: the first simulator dropped after the second's step,
/// the start is in the second's trace (passes).
#[test]
fn the_other_simulator_dropped_after_the_step_leaves_the_start() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let bid = b.id();
    let k = K::default();
    let mut sim1 = Sim::new(&seq, &k, Monitors::<K, 1>::new());
    sim1.lane(a);
    let mut sim2 = Sim::new(&seq, &k, Monitors::<K, 1>::new());
    sim2.lane(b);
    sim1.step();
    sim2.handle(bid).unwrap().start().unwrap();
    sim2.step();
    drop(sim1);
    assert_eq!(rounds(sim2.trace(), bid), [1], "{}", show(sim2.trace()));
}

// ---------------------------------------------------------------------------------------
// 4. Safety validation: a range's upper end
// ---------------------------------------------------------------------------------------

mod safety_ranges {
    use rtseq::safety::*;

    pub struct Io;
    impl SafetyIo for Io {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }

    const LOW: SafetyLevel = SafetyLevel::new(0);
    const HIGH: SafetyLevel = SafetyLevel::new(1);
    const TOP: SafetyLevel = SafetyLevel::new(255);
    const GO: PublicEvent = PublicEvent::new(0);

    fn two(rows: &[LevelTransition]) -> Result<(), SafetyError> {
        SafetyProperties::<Io, 2>::new(
            [LevelDef::new(LOW, "low"), LevelDef::new(HIGH, "high")],
            &[],
            &[],
            rows,
            LOW,
        )
        .validate()
    }

    /// SafetyError::UndefinedTransitionLevel: an undefined upper end is refused "unless it is 255,
    /// the open end of every level above": `on_level_and_below(SafetyLevel::new(255), ..)`
    /// covers every level, as `on_level_and_above(LOW)` does.
    #[test]
    fn on_level_and_below_255_is_every_level() {
        let rows = [LevelTransition::on_level_and_below(TOP, GO, LOW)];
        assert_eq!(two(&rows), Ok(()));
        let below_2 = [LevelTransition::on_level_and_below(
            SafetyLevel::new(2),
            GO,
            LOW,
        )];
        assert_eq!(
            two(&below_2),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: SafetyLevel::new(2)
            })
        );
    }

    /// `on_levels_between(low, 255)` is the same row as `on_level_and_above(low)` (equal
    /// values), so it is accepted the same: not a defect, a statement.
    #[test]
    fn on_levels_between_up_to_255_is_on_level_and_above() {
        let between = LevelTransition::on_levels_between(HIGH, TOP, GO, LOW);
        assert_eq!(between, LevelTransition::on_level_and_above(HIGH, GO, LOW));
        assert_eq!(two(&[between]), Ok(()));
        let past = LevelTransition::on_levels_between(HIGH, SafetyLevel::new(254), GO, LOW);
        assert_eq!(
            two(&[past]),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: SafetyLevel::new(254)
            })
        );
    }

    /// 256 levels: every level up to 255 is defined; every kind of range is accepted.
    #[test]
    fn all_256_levels() {
        let levels: [LevelDef<'static, Io>; 256] = core::array::from_fn(|i| {
            LevelDef::new(SafetyLevel::new(u8::try_from(i).unwrap()), "level")
        });
        let rows = [
            LevelTransition::on_levels_between(SafetyLevel::new(3), TOP, GO, LOW),
            LevelTransition::on_level_and_below(SafetyLevel::new(2), GO, TOP),
        ];
        let p = SafetyProperties::<Io, 256>::new(levels, &[], &[], &rows, LOW);
        assert_eq!(p.validate(), Ok(()));
        let rows = [LevelTransition::on(TOP, GO, LOW)];
        let p = SafetyProperties::<Io, 256>::new(levels, &[], &[], &rows, LOW);
        assert_eq!(p.validate(), Ok(()));
    }

    /// One level: `on_level_and_above(0)` is accepted, a range to 1 is not.
    #[test]
    fn one_level() {
        let one = |rows: &[LevelTransition]| {
            SafetyProperties::<Io, 1>::new([LevelDef::new(LOW, "only")], &[], &[], rows, LOW)
                .validate()
        };
        assert_eq!(
            one(&[LevelTransition::on_level_and_above(LOW, GO, LOW)]),
            Ok(())
        );
        assert_eq!(
            one(&[LevelTransition::on_levels_between(LOW, HIGH, GO, LOW)]),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: HIGH
            })
        );
        assert_eq!(
            one(&[LevelTransition::on_level_and_below(HIGH, GO, LOW)]),
            Err(SafetyError::UndefinedTransitionLevel {
                index: 0,
                level: HIGH
            })
        );
    }
}
