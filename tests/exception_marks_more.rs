//! The exception marks of callers (session 58), black box, from a cold review of their
//! second form: the caller a `…CallerOfOwner` behaviour stops with its own exception pending, from
//! `Paused`, read by a joiner; `MonitorNames` at its edges and `names()` with parameters.
//! Race-dependent cases are in `src/sequencer/interleavings/exception_marks_once_stopped.rs`.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Monitor as Mon};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, ConditionFn, Duration, Monitor, MonitorId, MonitorNames, Monitors, Names, Outcome,
    OwnedMonitor, SeqConfig, SeqId, Sequencer,
};

/// What the joiner read: its join's result, the caller's `exception_is_active` and
/// `active_exception`.
type JoinerRead = (Result<Outcome, rtseq::Error>, bool, Option<Cause>);
use std::cell::RefCell;

fn millis(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A (its lane) runs step S (until flag 15). A's own monitor MA (`AbortOwner`, exception
/// sequence E until flag 2) fires at 2 ms: A is held, marked with MA. S's monitor M
/// (`AbortCallerOfOwner`, no exception sequence) fires at 4 ms: it aborts A (cutting A's
/// own exception short). A reads `(true, M)`: aborted because of M (both flags: its own
/// mark from MA, and the target's). E, below A, aborted from above, is not marked.
#[test]
fn a_caller_handling_its_own_exception_aborted_by_a_child_s_caller_behaviour_names_the_child_s() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut c1 = |c: &Ctrl, _| c.flag(1);
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let ma = monitors
        .add(
            ai,
            Monitor::new("ma", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c1, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 2);
        c.set(1, ms(t) == 4);
    });
    sim.start(ai).unwrap();
    sim.run_for(millis(3));
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (true, Some(Mon(ma)))
    );
    sim.run_for(millis(3));
    let trace = sim.trace();
    assert_eq!(
        (sim.state(ai), sim.state(si), sim.state(ei)),
        (Aborted, Aborted, Aborted),
        "{}",
        show(trace)
    );
    assert!(
        trace.contains(&tr(4, ai, Aborting, Aborted, Mon(m))),
        "{}",
        show(trace)
    );
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (true, Some(Mon(m)))
    );
    let he = sim.handle(ei).unwrap();
    assert!(!he.exception_is_active());
    let hs = sim.handle(si).unwrap();
    assert_eq!(
        (hs.exception_is_active(), hs.active_exception()),
        (true, Some(Mon(m)))
    );
}

/// A paused by a request at 2 ms (S with it); S's monitors still watch. S's
/// `behaviour` monitor M fires at 4 ms: A leaves `Paused` for M. Abort: `(true, M)`;
/// restart: the new round (once resumed or taken up) reads `(false, M)`.
fn paused_target(behaviour: Behaviour) -> (bool, Option<Cause>, Cause, Vec<rtseq::Transition>) {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]).until(15))
        .unwrap();
    let ai = a.id();
    let mut c1 = |c: &Ctrl, _| c.flag(1);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(si, Monitor::new("m", &mut c1, behaviour))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(1, ms(t) == 4));
    sim.start(ai).unwrap();
    sim.run_for(millis(2));
    sim.pause(ai).unwrap();
    sim.run_for(millis(6));
    let ha = sim.handle(ai).unwrap();
    (
        ha.exception_is_active(),
        ha.active_exception(),
        Mon(m),
        sim.trace().to_vec(),
    )
}

#[test]
fn a_paused_caller_aborted_by_a_child_s_caller_behaviour_is_marked() {
    let (active, named, m, trace) = paused_target(Behaviour::AbortCallerOfOwner);
    assert!(
        trace
            .iter()
            .any(|t| t.from == Paused && t.to == Aborting && t.cause == m),
        "{}",
        show(&trace)
    );
    assert_eq!((active, named), (true, Some(m)), "{}", show(&trace));
}

#[test]
fn a_paused_caller_restarted_by_a_child_s_caller_behaviour_names_it_in_its_new_round() {
    let (active, named, m, trace) = paused_target(Behaviour::RestartCallerOfOwner);
    assert!(
        trace
            .iter()
            .any(|t| t.from == Paused && t.to == Restarting && t.cause == m),
        "{}",
        show(&trace)
    );
    assert_eq!((active, named), (false, Some(m)), "{}", show(&trace));
}

thread_local! {
    static READ: RefCell<Vec<JoinerRead>> =
        const { RefCell::new(Vec::new()) };
}

/// J (its own lane) joins A and, once the join returns, reads A's marks.
struct JoinReads(SeqId);
impl rtseq::Sequence<Ctrl> for JoinReads {
    async fn action(&mut self, cx: &rtseq::Cx<'_, Ctrl>) -> Result<(), rtseq::Failure> {
        let r = cx.join(self.0).await;
        let h = cx.sequence_by_id(self.0).unwrap();
        READ.with(|v| {
            v.borrow_mut()
                .push((r, h.exception_is_active(), h.active_exception()))
        });
        Ok(())
    }
}

/// A joiner of the caller an `AbortCallerOfOwner` aborts (in the simulator the lanes run
/// after the tick) gets `Aborted(M)` and reads A marked, naming M.
#[test]
fn a_joiner_of_the_aborted_caller_reads_it_marked_in_the_simulator() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let j = seq.add(SeqConfig::new("J"), JoinReads(ai)).unwrap();
    let ji = j.id();
    let mut c1 = |c: &Ctrl, _| c.flag(1);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c1, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.lane(j);
    sim.before_tick(|t, c| c.set(1, ms(t) == 3));
    sim.start(ai).unwrap();
    sim.start(ji).unwrap();
    sim.run_for(millis(6));
    assert_eq!(sim.state(ji), Terminated);
    let read = READ.with(|v| v.borrow().clone());
    assert_eq!(
        read,
        vec![(Ok(Outcome::Aborted(Mon(m))), true, Some(Mon(m)))]
    );
}

// ---------------------------------------------------------------------------------------
// MonitorNames and monitors!'s names().
// ---------------------------------------------------------------------------------------

fn never(_: &(), _: rtseq::Instant) -> bool {
    false
}

#[test]
fn monitor_names_of_an_empty_table_name_nothing() {
    const NAMES: MonitorNames<0> = MonitorNames::of::<(), ConditionFn<()>>(&[]);
    assert_eq!(NAMES.monitor(MonitorId::from_index(0)), None);
    assert_eq!(NAMES.monitor(MonitorId::from_index(255)), None);
}

#[test]
#[allow(non_snake_case)]
fn monitor_names_of_256_monitors_name_the_last_by_id_255() {
    let ms: [OwnedMonitor<'static, (), ConditionFn<()>>; 256] = core::array::from_fn(|i| {
        let name = match i {
            0 => "first",
            255 => "last",
            _ => "x",
        };
        Monitor::with_fn(name, never, Behaviour::Nothing).owned_by(SeqId::from_index(0))
    });
    let names = MonitorNames::of(&ms);
    const NAMES_LEN: usize = 256;
    assert_eq!(names.0.len(), NAMES_LEN);
    let NAMES = names;
    assert_eq!(NAMES.monitor(MonitorId::from_index(0)), Some("first"));
    assert_eq!(NAMES.monitor(MonitorId::from_index(254)), Some("x"));
    assert_eq!(NAMES.monitor(MonitorId::from_index(255)), Some("last"));
}

const HOME: SeqId = SeqId::from_index(0);

rtseq::monitors! {
    mod param_monitors(limit: u8) for (), ConditionFn<()> {
        JAM = Monitor::with_fn("jam", never, Behaviour::RestartOwner)
            .restart_limit(limit)
            .owned_by(HOME),
        STALL = Monitor::with_fn("stall", never, Behaviour::AbortOwner).owned_by(HOME),
    }
}

#[test]
fn names_of_a_monitor_module_with_parameters_take_them_and_name_by_id() {
    const NAMES: MonitorNames<{ param_monitors::COUNT }> = param_monitors::names(3);
    assert_eq!(NAMES.monitor(param_monitors::JAM), Some("jam"));
    assert_eq!(NAMES.monitor(param_monitors::STALL), Some("stall"));
    assert_eq!(NAMES.monitor(MonitorId::from_index(2)), None);
    use rtseq::WithNames;
    assert_eq!(
        Mon(param_monitors::STALL).named(&NAMES).to_string(),
        "monitor `stall`"
    );
}
