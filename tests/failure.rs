//! Actions that fail: a step or sequence whose action returns `Err` ends `Terminated` with
//! the cause `Failed` and the outcome `Failed(..)`, without polling its exit condition; a
//! blocking caller gets the failure as its `Err`, and `?` hands a child's abort or failure
//! on. Aborts stay sticky: a caller that is itself aborted ends `Aborted`, not `Failed`.

use std::cell::{Cell, RefCell};

use rtseq::sim::Sim;
use rtseq::Cause::{Abort, Completed, Failed, Monitor, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Done, Error, Failure, Failures, Instant, Monitor as M, Monitors, Outcome,
    RunningState, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step, Transition, WithNames,
};

/// The plant of these tests: flags the steps and monitors read, and what the sequences saw.
#[derive(Default)]
struct Cell_ {
    /// The gripper reports "closed".
    closed: Cell<bool>,
    /// The part is still in the gripper.
    part: Cell<bool>,
    /// The jam monitor's condition.
    jam: Cell<bool>,
    /// The exit condition of `Grip` was checked (how many times).
    grip_exit_checks: Cell<u32>,
    /// What the callers got from their children, in order.
    got: RefCell<Vec<Result<Done, Failure>>>,
    /// Set by `Cycle` after the grip returned (it went on).
    went_on: Cell<bool>,
}

/// The application's failure codes.
#[derive(Clone, Copy, Debug)]
enum CellFault {
    PartLost = 1,
    PartDropped = 2,
}

impl From<CellFault> for Failure {
    fn from(fault: CellFault) -> Self {
        Failure::App(fault as u16)
    }
}

const FAILURES: Failures = Failures(&[(1, "part lost"), (2, "part dropped")]);

/// Step: close the gripper; fails at once when there is no part; ends when closed.
struct Grip;

impl Step<Cell_> for Grip {
    fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
        if !cx.control().part.get() {
            return Err(CellFault::PartLost.into());
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Cell_>) -> bool {
        let c = cx.control();
        c.grip_exit_checks.set(c.grip_exit_checks.get() + 1);
        c.closed.get()
    }
}

/// Sequence: grip with `?` (every failure of the grip is the cycle's), then go on.
struct Cycle {
    grip: Seq<Grip>,
}

impl Sequence<Cell_> for Cycle {
    async fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
        cx.step(&mut self.grip).await?;
        cx.control().went_on.set(true);
        if !cx.control().part.get() {
            return Err(CellFault::PartDropped.into());
        }
        Ok(())
    }
}

/// Sequence: runs the cycle and records what it got, then ends normally.
struct Main {
    cycle: Seq<Cycle>,
}

impl Sequence<Cell_> for Main {
    async fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
        let got = cx.run(&mut self.cycle).await;
        cx.control().got.borrow_mut().push(got);
        Ok(())
    }
}

struct Setup<'a> {
    seq: &'a Sequencer<Cell_, 4>,
    grip: SeqId,
    cycle: SeqId,
    main: SeqId,
}

fn set_up(seq: &Sequencer<Cell_, 4>) -> (Setup<'_>, Seq<Main>) {
    let grip = seq.add(SeqConfig::new("grip"), Grip).unwrap();
    let cycle = seq.add(SeqConfig::new("cycle"), Cycle { grip }).unwrap();
    let (grip, cycle_id) = (cycle.body().grip.id(), cycle.id());
    let main = seq.add(SeqConfig::new("main"), Main { cycle }).unwrap();
    let setup = Setup {
        seq,
        grip,
        cycle: cycle_id,
        main: main.id(),
    };
    (setup, main)
}

fn tr(ms: u64, seq: SeqId, from: RunningState, to: RunningState, cause: Cause) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

fn last_outcome(s: &Setup<'_>, id: SeqId) -> Option<Outcome> {
    s.seq.sequence_by_id(id).and_then(|h| h.last_outcome())
}

/// The step fails in its action: it ends at once (its exit condition is never checked),
/// the cycle's `?` fails the cycle with the same failure, and main gets it as its `Err`.
#[test]
fn a_failing_step_fails_its_caller_through_the_question_mark() {
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    let (s, main) = set_up(&seq);
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(main);
    sim.start(s.main).unwrap();
    assert_eq!(
        sim.trace(),
        [
            tr(0, s.main, Idle, Running, Start),
            tr(0, s.cycle, Idle, Running, Start),
            tr(0, s.grip, Idle, Running, Start),
            tr(0, s.grip, Running, Terminated, Failed),
            tr(0, s.cycle, Running, Terminated, Failed),
            tr(0, s.main, Running, Terminated, Completed),
        ]
    );
    let lost = Failure::App(CellFault::PartLost as u16);
    assert_eq!(*plant.got.borrow(), [Err(lost)]);
    assert_eq!(plant.grip_exit_checks.get(), 0);
    assert!(!plant.went_on.get());
    assert_eq!(last_outcome(&s, s.grip), Some(Outcome::Failed(lost)));
    assert_eq!(last_outcome(&s, s.cycle), Some(Outcome::Failed(lost)));
    assert_eq!(last_outcome(&s, s.main), Some(Outcome::Completed));
    assert_eq!(
        Outcome::Failed(lost).named(&FAILURES).to_string(),
        "failed (part lost)"
    );
}

/// With a part, the grip waits for "closed" (at 3 ms) and completes; the cycle goes on and
/// completes. A cycle whose own check fails after a completed grip fails with its own code.
#[test]
fn a_completed_step_lets_the_caller_go_on_and_fail_for_its_own_reason() {
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    plant.part.set(true);
    let (s, main) = set_up(&seq);
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(main);
    sim.before_tick(|t, c: &Cell_| c.closed.set(t.as_ticks() >= 3_000));
    sim.start(s.main).unwrap();
    sim.run_until_idle(rtseq::Duration::from_millis(10))
        .unwrap();
    assert_eq!(
        sim.trace(),
        [
            tr(0, s.main, Idle, Running, Start),
            tr(0, s.cycle, Idle, Running, Start),
            tr(0, s.grip, Idle, Running, Start),
            tr(3, s.grip, Running, Terminated, Completed),
            tr(3, s.cycle, Running, Terminated, Completed),
            tr(3, s.main, Running, Terminated, Completed),
        ]
    );
    assert_eq!(*plant.got.borrow(), [Ok(Done::Completed)]);
    assert!(plant.went_on.get());

    // The part slips out as the gripper closes (at 8 ms): the grip completes (its exit
    // condition saw "closed"), the cycle checks the part and fails with its own code.
    plant.got.borrow_mut().clear();
    plant.closed.set(false);
    sim.before_tick(|t, c: &Cell_| {
        c.closed.set(t.as_ticks() >= 8_000);
        c.part.set(t.as_ticks() < 8_000);
    });
    let from = sim.trace().len();
    sim.start(s.main).unwrap();
    sim.run_until_idle(rtseq::Duration::from_millis(10))
        .unwrap();
    assert_eq!(
        sim.trace()[from..],
        [
            tr(3, s.main, Terminated, Running, Start),
            tr(3, s.cycle, Terminated, Running, Start),
            tr(3, s.grip, Terminated, Running, Start),
            tr(8, s.grip, Running, Terminated, Completed),
            tr(8, s.cycle, Running, Terminated, Failed),
            tr(8, s.main, Running, Terminated, Completed),
        ]
    );
    let dropped = Failure::App(CellFault::PartDropped as u16);
    assert_eq!(*plant.got.borrow(), [Err(dropped)]);
    assert_eq!(last_outcome(&s, s.cycle), Some(Outcome::Failed(dropped)));
    assert_eq!(
        dropped.named(&FAILURES).to_string(),
        "part dropped",
        "the application's names print"
    );
}

/// A monitor aborts the grip (`AbortOwner`): the cycle's `?` hands the abort on, the cycle
/// fails with `Aborted(monitor)`, in the same tick.
#[test]
fn an_aborted_child_fails_its_caller_through_the_question_mark() {
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    plant.part.set(true);
    let (s, main) = set_up(&seq);
    let mut jammed = |c: &Cell_, _: Instant| c.jam.get();
    let mut monitors: Monitors<Cell_, 1> = Monitors::new();
    let jam = monitors
        .add(s.grip, M::new("jam", &mut jammed, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &plant, monitors);
    sim.lane(main);
    sim.before_tick(|t, c: &Cell_| c.jam.set(t.as_ticks() >= 2_000));
    sim.start(s.main).unwrap();
    sim.run_until_idle(rtseq::Duration::from_millis(10))
        .unwrap();
    assert_eq!(
        sim.trace(),
        [
            tr(0, s.main, Idle, Running, Start),
            tr(0, s.cycle, Idle, Running, Start),
            tr(0, s.grip, Idle, Running, Start),
            tr(2, s.grip, Running, Aborting, Monitor(jam)),
            tr(2, s.grip, Aborting, Aborted, Monitor(jam)),
            tr(2, s.cycle, Running, Terminated, Failed),
            tr(2, s.main, Running, Terminated, Completed),
        ]
    );
    let aborted = Failure::Aborted(Monitor(jam));
    assert_eq!(*plant.got.borrow(), [Err(aborted)]);
    assert!(!plant.went_on.get());
    assert_eq!(last_outcome(&s, s.cycle), Some(Outcome::Failed(aborted)));
}

/// Sticky abort is unchanged: an abort of the cycle itself aborts the grip under it; the
/// cycle never returns into its action, so it ends `Aborted`, not `Failed`.
#[test]
fn an_aborted_caller_ends_aborted_not_failed() {
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    plant.part.set(true);
    let (s, main) = set_up(&seq);
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(main);
    sim.start(s.main).unwrap();
    sim.run_until(Instant::from_ticks(1_500));
    seq.sequence_by_id(s.cycle).unwrap().abort().unwrap();
    sim.run_until_idle(rtseq::Duration::from_millis(10))
        .unwrap();
    assert_eq!(
        sim.trace(),
        [
            tr(0, s.main, Idle, Running, Start),
            tr(0, s.cycle, Idle, Running, Start),
            tr(0, s.grip, Idle, Running, Start),
            tr(2, s.grip, Running, Aborting, Abort),
            tr(2, s.grip, Aborting, Aborted, Abort),
            tr(2, s.cycle, Running, Aborting, Abort),
            tr(2, s.cycle, Aborting, Aborted, Abort),
            tr(2, s.main, Running, Terminated, Completed),
        ]
    );
    assert_eq!(*plant.got.borrow(), [Err(Failure::Aborted(Abort))]);
    assert!(!plant.went_on.get());
    assert_eq!(last_outcome(&s, s.cycle), Some(Outcome::Aborted(Abort)));
}

/// A start that is refused is a `NotStarted` failure with its error, through `?` too:
/// here a non-blocking start of a sequence that has no lane.
#[test]
fn a_refused_start_is_a_not_started_failure() {
    struct Blink;
    impl Sequence<Cell_> for Blink {
        async fn action(&mut self, _cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            Ok(())
        }
    }
    struct Status {
        blink: SeqId,
    }
    impl Sequence<Cell_> for Status {
        async fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            cx.start(self.blink)?;
            cx.control().went_on.set(true);
            Ok(())
        }
    }
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap().id();
    let status = seq.add(SeqConfig::new("status"), Status { blink }).unwrap();
    let id = status.id();
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(status);
    sim.start(id).unwrap();
    assert_eq!(
        sim.trace(),
        [
            tr(0, id, Idle, Running, Start),
            tr(0, id, Running, Terminated, Failed),
        ]
    );
    assert!(!plant.went_on.get());
    let failure = Failure::NotStarted(Error::NoLane(blink));
    assert_eq!(
        seq.sequence_by_id(id).unwrap().last_outcome(),
        Some(Outcome::Failed(failure))
    );
    // Without a source that names sequences the error says the index; with the sequencer,
    // the name.
    assert_eq!(
        failure.named(&FAILURES).to_string(),
        "not started: sequence 0 has no lane that a task polls"
    );
    assert_eq!(
        failure.named(&(&seq, &FAILURES)).to_string(),
        "not started: sequence `blink` has no lane that a task polls"
    );
}

/// A blocking caller receives a typed result: the child leaves it in its own object, which
/// the caller owns (EEROS's `getResult()`).
#[test]
fn a_blocking_caller_reads_the_typed_result_of_its_child() {
    /// Measures the stroke: the result is the distance.
    struct Probe {
        stroke_mm: Option<u32>,
    }
    impl Sequence<Cell_> for Probe {
        async fn action(&mut self, _cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            self.stroke_mm = Some(42);
            Ok(())
        }
    }
    struct Calibrate {
        probe: Seq<Probe>,
        got: std::rc::Rc<Cell<Option<u32>>>,
    }
    impl Sequence<Cell_> for Calibrate {
        async fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            cx.run(&mut self.probe).await?;
            self.got.set(self.probe.body().stroke_mm);
            Ok(())
        }
    }
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    let probe = seq
        .add(SeqConfig::new("probe"), Probe { stroke_mm: None })
        .unwrap();
    let got = std::rc::Rc::new(Cell::new(None));
    let calibrate = seq
        .add(
            SeqConfig::new("calibrate"),
            Calibrate {
                probe,
                got: got.clone(),
            },
        )
        .unwrap();
    let id = calibrate.id();
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(calibrate);
    sim.start(id).unwrap();
    assert_eq!(got.get(), Some(42));
}

/// A failure is not an abort: a sequence that started a non-blocking conveyor and then
/// fails ends `Terminated` (cause `Failed`) without its cleanup hook, and the conveyor
/// runs on until its own exit condition (closed at 3 ms).
#[test]
fn a_failure_aborts_nothing_and_runs_no_cleanup_hook() {
    use std::sync::atomic::{AtomicU32, Ordering};
    static HOOK_CALLS: AtomicU32 = AtomicU32::new(0);
    fn hook(_: &Cell_) {
        HOOK_CALLS.fetch_add(1, Ordering::SeqCst);
    }
    struct Conveyor;
    impl Sequence<Cell_> for Conveyor {
        async fn action(&mut self, _cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            Ok(())
        }
        fn check_exit_condition(&mut self, cx: &Cx<'_, Cell_>) -> bool {
            cx.control().closed.get()
        }
    }
    struct Loader {
        conveyor: SeqId,
    }
    impl Sequence<Cell_> for Loader {
        async fn action(&mut self, cx: &Cx<'_, Cell_>) -> Result<(), Failure> {
            cx.start(self.conveyor)?;
            Err(CellFault::PartLost.into())
        }
    }
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    let plant = Cell_::default();
    let conveyor = seq.add(SeqConfig::new("conveyor"), Conveyor).unwrap();
    let c = conveyor.id();
    let loader = seq
        .add(
            SeqConfig::new("loader").on_abort(hook),
            Loader { conveyor: c },
        )
        .unwrap();
    let l = loader.id();
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell_, 1>::new());
    sim.lane(loader);
    sim.lane(conveyor);
    sim.before_tick(|t, p: &Cell_| p.closed.set(t.as_ticks() >= 3_000));
    sim.start(l).unwrap();
    assert_eq!(
        sim.run_until_idle(rtseq::Duration::from_millis(10))
            .map(|t| t.as_ticks() / 1000),
        Some(3)
    );
    assert_eq!(
        sim.trace(),
        [
            tr(0, l, Idle, Running, Start),
            tr(0, c, Idle, Running, Start),
            tr(0, l, Running, Terminated, Failed),
            tr(3, c, Running, Terminated, Completed),
        ]
    );
    assert_eq!(HOOK_CALLS.load(Ordering::SeqCst), 0);
    let lost = Failure::App(CellFault::PartLost as u16);
    let outcome = |id| seq.sequence_by_id(id).and_then(|h| h.last_outcome());
    assert_eq!(outcome(l), Some(Outcome::Failed(lost)));
    assert_eq!(outcome(c), Some(Outcome::Completed));
}
