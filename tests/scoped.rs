//! Non-blocking children bound to their caller's action (`Cx::start_scoped`): a child is
//! aborted by the tick after its `Scoped` is dropped, never a later run of its sequence;
//! `join` waits for it, `detach` lets it run on.

mod common;
use std::cell::Cell;
use std::rc::Rc;

use common::transition_at as t;
use common::*;
use embassy_futures::select::{select, Either};
use rtseq::sim::Sim;
use rtseq::Cause::{Abort, Completed, Failed, Start};
use rtseq::RunningState::*;
use rtseq::{
    Cx, Duration, Error, Event, Failure, Instant, Monitors, Outcome, Record, Request, Requester,
    Seq, SeqConfig, SeqId, Sequence, Sequencer, Wait,
};

/// What the main sequence does with its scoped child once its own dwell is over.
#[derive(Clone, Copy)]
enum Then {
    /// Returns `Ok`.
    Return,
    /// Fails (`Err(Failure::App(7))`).
    Fail,
    /// Joins the child through its `Scoped`.
    Join,
    /// Detaches the child, then returns.
    Detach,
    /// Joins the child by id, starts it again (not scoped), then drops the `Scoped`.
    StartAgain,
    /// Races the child's join against a second dwell, which wins; then a third dwell.
    RaceJoin,
}

type Joined = Rc<Cell<Option<Result<Outcome, Error>>>>;

struct Main {
    child: SeqId,
    then: Then,
    dwell: Seq<Wait>,
    joined: Joined,
}

impl Sequence<Ctrl> for Main {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let child = cx.start_scoped(self.child)?;
        assert_eq!(child.id(), self.child);
        cx.step(&mut self.dwell).await?;
        match self.then {
            Then::Return => Ok(()),
            Then::Fail => Err(Failure::App(7)),
            Then::Join => {
                self.joined.set(Some(child.join().await));
                Ok(())
            }
            Then::Detach => {
                child.detach();
                Ok(())
            }
            Then::StartAgain => {
                self.joined.set(Some(cx.join(self.child).await));
                cx.start(self.child)?;
                drop(child);
                Ok(())
            }
            Then::RaceJoin => {
                match select(child.join(), cx.step(&mut self.dwell)).await {
                    Either::First(joined) => self.joined.set(Some(joined)),
                    Either::Second(dwell) => assert_eq!(dwell, Ok(rtseq::Done::Completed)),
                }
                cx.step(&mut self.dwell).await?;
                Ok(())
            }
        }
    }
}

/// The child: a dwell of `child_ms` in a sequence of its own lane.
struct Child(Seq<Wait>);

impl Sequence<Ctrl> for Child {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

/// Ids of the tree, in registration order: main's dwell 0, main 1, the child's dwell 2,
/// the child 3.
const DWELL: usize = 0;
const MAIN: usize = 1;
const CHILD_DWELL: usize = 2;
const CHILD: usize = 3;

/// The tree in `seq`: main (a dwell of `main_ms`, then `then`) and its scoped child (a
/// dwell of `child_ms` in a sequence of its own lane), both in a simulator, main started.
/// What a join of main's returns is left in `joined`.
fn started_tree<'a>(
    seq: &'a Sequencer<Ctrl, 4>,
    ctrl: &'a Ctrl,
    then: Then,
    [main_ms, child_ms]: [u64; 2],
    joined: &Joined,
) -> Sim<'a, Ctrl, 4, 64, 1> {
    let ms = |n| Wait::new(Duration::from_millis(n));
    let dwell = seq.add(SeqConfig::new("dwell"), ms(main_ms)).unwrap();
    let main = Main {
        child: SeqId::from_index(CHILD),
        then,
        dwell,
        joined: joined.clone(),
    };
    let main = seq.add(SeqConfig::new("main"), main).unwrap();
    let child_dwell = seq.add(SeqConfig::new("child dwell"), ms(child_ms));
    let child = seq
        .add(SeqConfig::new("child"), Child(child_dwell.unwrap()))
        .unwrap();
    assert_eq!(
        [main.id(), child.id()],
        [MAIN, CHILD].map(SeqId::from_index)
    );
    let mut sim = Sim::new(seq, ctrl, Monitors::<Ctrl, 1>::new());
    let id = main.id();
    sim.lane(main);
    sim.lane(child);
    sim.start(id).unwrap();
    sim
}

/// Runs main (a 3 ms dwell, then `then`) with a child that dwells `child_ms`, for 20 ms.
/// Returns the records and what a join returned.
fn run(then: Then, child_ms: u64) -> (Vec<Record>, Option<Result<Outcome, Error>>) {
    let (seq, ctrl, joined) = (Sequencer::new(), Ctrl::default(), Joined::default());
    let mut sim = started_tree(&seq, &ctrl, then, [3, child_ms], &joined);
    sim.run_for(Duration::from_millis(20));
    (sim.records().to_vec(), joined.get())
}

/// Main's request to abort its child.
fn main_aborts_child(ms: u64) -> Record {
    event_at(
        ms,
        Event::Requested {
            sequence: SeqId::from_index(CHILD),
            request: Request::Abort,
            by: Requester::Sequence(SeqId::from_index(MAIN)),
        },
    )
}

/// The child and its dwell aborted by a request, innermost first, at `ms`.
fn child_aborted(ms: u64) -> [Record; 4] {
    [
        t(ms, CHILD_DWELL, Running, Aborting, Abort),
        t(ms, CHILD_DWELL, Aborting, Aborted, Abort),
        t(ms, CHILD, Running, Aborting, Abort),
        t(ms, CHILD, Aborting, Aborted, Abort),
    ]
}

/// The first records of every run: main starts its child (in the child's lane), then
/// its dwell; the child's lane then starts the child's dwell.
fn starts() -> Vec<Record> {
    vec![
        t(0, MAIN, Idle, Running, Start),
        t(0, CHILD, Idle, Running, Start),
        t(0, DWELL, Idle, Running, Start),
        t(0, CHILD_DWELL, Idle, Running, Start),
    ]
}

/// Main's 3 ms dwell ends.
fn dwell_done() -> Record {
    t(3, DWELL, Running, Terminated, Completed)
}

/// The child and its dwell end at `ms`.
fn child_completed(ms: u64) -> [Record; 2] {
    [
        t(ms, CHILD_DWELL, Running, Terminated, Completed),
        t(ms, CHILD, Running, Terminated, Completed),
    ]
}

#[test]
fn a_scoped_child_is_aborted_by_the_tick_after_its_caller_failed() {
    let (records, _) = run(Then::Fail, 100);
    let mut want = starts();
    want.push(dwell_done());
    want.extend([
        main_aborts_child(3),
        t(3, MAIN, Running, Terminated, Failed),
        event_at(
            3,
            Event::Failed {
                sequence: SeqId::from_index(MAIN),
                failure: Failure::App(7),
            },
        ),
    ]);
    want.extend(child_aborted(4));
    assert_records(&records, &want);
}

#[test]
fn a_scoped_child_is_aborted_by_the_tick_after_its_caller_completed() {
    let (records, _) = run(Then::Return, 100);
    let mut want = starts();
    want.push(dwell_done());
    want.extend([
        main_aborts_child(3),
        t(3, MAIN, Running, Terminated, Completed),
    ]);
    want.extend(child_aborted(4));
    assert_records(&records, &want);
}

#[test]
fn a_scoped_child_that_ended_is_not_asked_to_abort() {
    let (records, _) = run(Then::Return, 2);
    let mut want = starts();
    want.extend([
        child_completed(2)[0],
        child_completed(2)[1],
        dwell_done(),
        t(3, MAIN, Running, Terminated, Completed),
    ]);
    assert_records(&records, &want);
}

#[test]
fn a_join_through_the_scoped_child_gets_its_outcome_and_aborts_nothing() {
    let (records, joined) = run(Then::Join, 5);
    let mut want = starts();
    want.push(dwell_done());
    want.extend([
        t(5, CHILD_DWELL, Running, Terminated, Completed),
        t(5, CHILD, Running, Terminated, Completed),
        t(5, MAIN, Running, Terminated, Completed),
    ]);
    assert_records(&records, &want);
    assert_eq!(joined, Some(Ok(Outcome::Completed)));
}

#[test]
fn a_detached_child_outlives_its_caller() {
    let (records, _) = run(Then::Detach, 100);
    let mut want = starts();
    want.push(dwell_done());
    want.push(t(3, MAIN, Running, Terminated, Completed));
    assert_records(&records, &want);
}

#[test]
fn a_scoped_child_never_aborts_a_later_run_of_its_sequence() {
    // The child ends at 2; main joins it at 3, starts it again (not scoped), and drops
    // the `Scoped` of the first run: the second run dwells its 2 ms to the end.
    let (records, joined) = run(Then::StartAgain, 2);
    let mut want = starts();
    want.extend([
        child_completed(2)[0],
        child_completed(2)[1],
        dwell_done(),
        t(3, CHILD, Terminated, Running, Start),
        t(3, MAIN, Running, Terminated, Completed),
        t(3, CHILD_DWELL, Terminated, Running, Start),
        t(5, CHILD_DWELL, Running, Terminated, Completed),
        t(5, CHILD, Running, Terminated, Completed),
    ]);
    assert_records(&records, &want);
    assert_eq!(joined, Some(Ok(Outcome::Completed)));
}

#[test]
fn a_join_that_loses_a_select_only_stops_waiting() {
    // The second dwell (3 to 6 ms) wins the race against the join of a 100 ms child; the
    // child runs on through the third dwell (6 to 9 ms), until main returns.
    let (records, joined) = run(Then::RaceJoin, 100);
    let mut want = starts();
    want.push(dwell_done());
    want.extend([
        t(3, DWELL, Terminated, Running, Start),
        t(6, DWELL, Running, Terminated, Completed),
        t(6, DWELL, Terminated, Running, Start),
        t(9, DWELL, Running, Terminated, Completed),
        main_aborts_child(9),
        t(9, MAIN, Running, Terminated, Completed),
    ]);
    want.extend(child_aborted(10));
    assert_records(&records, &want);
    assert_eq!(joined, None);
}

#[test]
fn an_aborted_caller_takes_its_scoped_child_down_in_the_same_tick_and_asks_nothing_more() {
    let (seq, ctrl, joined) = (Sequencer::new(), Ctrl::default(), Joined::default());
    let mut sim = started_tree(&seq, &ctrl, Then::Return, [10, 100], &joined);
    let id = SeqId::from_index(MAIN);
    sim.run_for(Duration::from_millis(2));
    sim.abort(id).unwrap();
    sim.run_for(Duration::from_millis(5));
    let mut want = starts();
    want.extend([
        event_at(
            2,
            Event::Requested {
                sequence: id,
                request: Request::Abort,
                by: Requester::Application,
            },
        ),
        t(3, CHILD_DWELL, Running, Aborting, Abort),
        t(3, CHILD_DWELL, Aborting, Aborted, Abort),
        t(3, DWELL, Running, Aborting, Abort),
        t(3, DWELL, Aborting, Aborted, Abort),
        t(3, CHILD, Running, Aborting, Abort),
        t(3, CHILD, Aborting, Aborted, Abort),
        t(3, MAIN, Running, Aborting, Abort),
        t(3, MAIN, Aborting, Aborted, Abort),
    ]);
    assert_records(sim.records(), &want);
}

#[test]
fn a_scoped_start_is_refused_as_a_start_is() {
    struct Twice(SeqId);
    impl Sequence<Ctrl> for Twice {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            let first = cx.start_scoped(self.0)?;
            let again = cx.start_scoped(self.0).map(|s| s.id());
            assert_eq!(again, Err(Error::AlreadyRunning(self.0)));
            let unknown = SeqId::from_index(CHILD);
            assert_eq!(
                cx.start_scoped(unknown).map(|s| s.id()),
                Err(Error::UnknownSequence(unknown))
            );
            first.detach();
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let child_dwell = seq
        .add(
            SeqConfig::new("child dwell"),
            Wait::new(Duration::from_millis(5)),
        )
        .unwrap();
    let child = seq
        .add(SeqConfig::new("child"), Child(child_dwell))
        .unwrap();
    let twice = seq.add(SeqConfig::new("twice"), Twice(child.id())).unwrap();
    let ctrl = Ctrl::default();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    let (id, c) = (twice.id(), child.id());
    sim.lane(twice);
    sim.lane(child);
    sim.start(id).unwrap();
    assert_eq!(sim.state(id), Terminated);
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(Instant::from_ticks(5_000))
    );
    assert_eq!(
        sim.handle(c).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
}

#[test]
fn a_join_through_the_scoped_child_gets_its_runs_outcome_while_a_later_run_is_under_way() {
    // The child ends at 2; the application starts it again between the ticks of 2 and 3 ms
    // (recorded at 2, the last tick's time; a 2 ms run, caller none); main joins the first
    // run at 3: its outcome, kept while the later run is under way. Main's `Scoped` is then
    // dropped: the later run is not asked to abort.
    let (seq, ctrl, joined) = (Sequencer::new(), Ctrl::default(), Joined::default());
    let mut sim = started_tree(&seq, &ctrl, Then::Join, [3, 2], &joined);
    sim.run_for(Duration::from_micros(2_500));
    let child = SeqId::from_index(CHILD);
    sim.start(child).unwrap();
    sim.run_for(Duration::from_millis(5));
    assert_eq!(joined.get(), Some(Ok(Outcome::Completed)));
    let mut want = starts();
    want.extend(child_completed(2));
    want.extend([
        t(2, CHILD, Terminated, Running, Start),
        t(2, CHILD_DWELL, Terminated, Running, Start),
        dwell_done(),
        t(3, MAIN, Running, Terminated, Completed),
    ]);
    want.extend(child_completed(4));
    assert_records(sim.records(), &want);
}

/// A child that ends at once while flag 1 is set, else runs until it is.
fn until_flag_1() -> Node {
    Node::of(vec![]).until(1)
}

/// Holds a `Scoped` of `child` until flag 0 is set, then returns.
struct Holder {
    child: SeqId,
}

impl Sequence<Ctrl> for Holder {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let _child = cx.start_scoped(self.child)?;
        cx.wait_until(|cx| cx.control().flag(0)).await;
        Ok(())
    }
}

#[test]
#[cfg_attr(miri, ignore = "65 536 starts take too long under Miri")]
fn a_scoped_child_never_aborts_a_run_of_another_caller_even_once_the_run_count_wrapped() {
    // The holder's run of X ends at once; the application then starts X 65 536 times, so
    // the run under way when the holder returns has the holder's run's 16-bit count. Its
    // caller is not the holder: it runs on to its end.
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq.add(SeqConfig::new("x"), until_flag_1()).unwrap();
    let holder = seq.add(SeqConfig::new("holder"), Holder { child: x.id() });
    let (holder, xi) = (holder.unwrap(), x.id());
    let h = holder.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(holder);
    sim.lane(x);
    ctrl.set(1, true);
    sim.start(h).unwrap();
    let held = sim.handle(xi).unwrap();
    assert_eq!((held.state(), held.caller()), (Terminated, Some(h)));
    for _ in 0..65_535 {
        sim.start(xi).unwrap();
    }
    ctrl.set(1, false);
    sim.start(xi).unwrap();
    sim.run_for(Duration::from_millis(2));
    ctrl.set(0, true);
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.state(h), Terminated);
    assert_eq!((held.state(), held.caller()), (Running, None));
    ctrl.set(1, true);
    sim.run_for(Duration::from_millis(2));
    assert_eq!(held.last_outcome(), Some(Outcome::Completed));
}
