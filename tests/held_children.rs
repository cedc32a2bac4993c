//! An exception holds its owner and the owner's blocking children at their next await
//! point (semantics item 3). Only the owner is marked; its children are held because the
//! owner's action is not polled. The tick preempts the lanes, though, so the poll in which
//! it marked the exception runs on: to a blocking start the owner's action makes next, or
//! to the next await point of a child under way. Those must hold too.

use std::cell::{Cell, RefCell};

use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Start, Timeout};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Failure, Instant, Monitor, Monitors, RunningState, Seq,
    SeqConfig, SeqId, Sequence, Sequencer, Step,
};

/// The commands given, with when (µs).
#[derive(Default)]
struct Log {
    commands: RefCell<Vec<(u64, &'static str)>>,
    /// The sequencer, for a step that ticks it from its command as the timer would.
    seq: Cell<Option<&'static Sequencer<Log, 4>>>,
    /// The tick at 1 ms came.
    ticked: Cell<bool>,
    /// Flags the exit conditions of [`a_hold_leaves_the_due_polls_of_its_owners_siblings`]
    /// read.
    flags: [Cell<bool>; 2],
    /// How often a one-shot "in position" message was read.
    reads: Cell<u32>,
}

impl Log {
    fn command(&self, cx: &Cx<'_, Log>, what: &'static str) {
        self.commands.borrow_mut().push((cx.now().as_ticks(), what));
    }

    /// The timer interrupt preempts the lane here: the tick at 1 ms (once).
    fn tick_at_1_ms(&self) {
        if self.ticked.replace(true) {
            return;
        }
        if let Some(seq) = self.seq.get() {
            let ticked = seq.tick(
                Instant::from_ticks(1_000),
                self,
                &mut Monitors::<Log, 1>::new(),
            );
            assert_eq!(ticked, Ok(()));
        }
    }
}

/// A move: its command, then done.
struct Move;
impl Step<Log> for Move {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "move");
        Ok(())
    }
}

/// A move whose command is preempted by the tick at 1 ms; done at its first exit check.
struct PreemptedMove;
impl Step<Log> for PreemptedMove {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "preempted move");
        cx.control().tick_at_1_ms();
        Ok(())
    }
}

/// A move whose exit check the tick at 1 ms preempts; the check holds.
struct PreemptedCheck;
impl Step<Log> for PreemptedCheck {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "move");
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        cx.control().tick_at_1_ms();
        true
    }
}

/// Waits until a condition the tick at 1 ms preempts (it holds), then gives its next
/// command.
struct WaitsThenMoves;
impl Sequence<Log> for WaitsThenMoves {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.wait_until(|cx| {
            cx.control().tick_at_1_ms();
            true
        })
        .await;
        cx.control().command(cx, "next move");
        Ok(())
    }
}

/// The safe stop: its command, then it holds until 3 ms.
struct SafeStop;
impl Sequence<Log> for SafeStop {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "safe stop");
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        cx.now().as_ticks() >= 3_000
    }
}

/// Preempted by the tick at 1 ms, then runs its move (a blocking start made after the
/// tick marked its timeout).
struct ThenMoves(Seq<Move>);
impl Sequence<Log> for ThenMoves {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().tick_at_1_ms();
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

/// Runs a move whose command the tick at 1 ms preempts.
struct Moves<S>(Seq<S>);
impl<S: Step<Log>> Sequence<Log> for Moves<S> {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

/// What a run of a mover with a 1 ms timeout (exception: the safe stop, then
/// `behaviour`) gave: the commands, the trace `(µs, sequence, state, cause)` and the
/// mover's id (its timeout's cause names it).
type Seen = (
    Vec<(u64, &'static str)>,
    Vec<(u64, &'static str, RunningState, Cause)>,
    SeqId,
);

/// Runs the mover `make` makes (with its move) until idle, which must come at `idle_ms`.
fn run_mover<S: Sequence<Log> + 'static>(
    make: impl FnOnce(&'static Sequencer<Log, 4>) -> S,
    behaviour: Behaviour,
    idle_ms: u64,
) -> Seen {
    let seq: &'static Sequencer<Log, 4> = Box::leak(Box::new(Sequencer::new()));
    let log: &'static Log = Box::leak(Box::default());
    log.seq.set(Some(seq));
    let mover = make(seq);
    let stop = seq.add(SeqConfig::new("safe stop"), SafeStop).unwrap();
    let config = SeqConfig::new("mover")
        .timeout(Duration::from_millis(1))
        .timeout_exception(stop.id())
        .timeout_behaviour(behaviour);
    let mover = seq.add(config, mover).unwrap();
    let id = mover.id();
    let mut sim = Sim::new(seq, log, Monitors::<Log, 1>::new());
    sim.lane(mover);
    sim.lane(stop);
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(idle_ms * 1_000))
    );
    let name = |s: SeqId| seq.sequence_by_id(s).map_or("?", |h| h.name());
    let trace = sim
        .trace()
        .iter()
        .map(|t| (t.time.as_ticks(), name(t.sequence), t.to, t.cause))
        .collect();
    let commands = log.commands.take();
    (commands, trace, id)
}

const MOVE: &str = "move";
const STOP: &str = "safe stop";
const MOVER: &str = "mover";

/// The mover's timeout fires while its action runs on to its move: the move begins held
/// (`Running`, at its pre-condition), gives no command during the safe stop (1 to 3 ms),
/// and is aborted with the mover when the next tick (4 ms) applies `AbortOwner`. (Before
/// session 48 the move commanded at 1 ms, after the safe stop had begun.)
#[test]
fn a_blocking_start_made_after_the_exception_was_marked_begins_held() {
    let (commands, trace, mover) = run_mover(
        |seq| ThenMoves(seq.add(SeqConfig::new("move"), Move).unwrap()),
        Behaviour::AbortOwner,
        4,
    );
    assert_eq!(commands, [(1_000, "safe stop")]);
    let timeout = Timeout(mover);
    assert_eq!(
        trace,
        [
            (0, MOVER, Running, Start),
            (1_000, STOP, Running, timeout),
            (1_000, MOVE, Running, Start),
            (3_000, STOP, Terminated, Completed),
            (4_000, MOVE, Aborting, timeout),
            (4_000, MOVE, Aborted, timeout),
            (4_000, MOVER, Aborting, timeout),
            (4_000, MOVER, Aborted, timeout),
        ]
    );
}

/// The same with `Behaviour::Nothing`: the move is held until the tick (4 ms) reports the
/// safe stop's end and lets the mover go on, then gives its command.
#[test]
fn a_child_begun_held_goes_on_when_the_exception_ends() {
    let (commands, trace, mover) = run_mover(
        |seq| ThenMoves(seq.add(SeqConfig::new("move"), Move).unwrap()),
        Behaviour::Nothing,
        4,
    );
    assert_eq!(commands, [(1_000, "safe stop"), (4_000, "move")]);
    assert_eq!(
        trace,
        [
            (0, MOVER, Running, Start),
            (1_000, STOP, Running, Timeout(mover)),
            (1_000, MOVE, Running, Start),
            (3_000, STOP, Terminated, Completed),
            (4_000, MOVE, Terminated, Completed),
            (4_000, MOVER, Terminated, Completed),
        ]
    );
}

/// The trace of a mover whose move, begun at 0 ms, is held from the tick at 1 ms through
/// the safe stop and aborted with the mover at 4 ms.
fn move_held_then_aborted(mover: SeqId) -> Vec<(u64, &'static str, RunningState, Cause)> {
    let timeout = Timeout(mover);
    vec![
        (0, MOVER, Running, Start),
        (0, MOVE, Running, Start),
        (1_000, STOP, Running, timeout),
        (3_000, STOP, Terminated, Completed),
        (4_000, MOVE, Aborting, timeout),
        (4_000, MOVE, Aborted, timeout),
        (4_000, MOVER, Aborting, timeout),
        (4_000, MOVER, Aborted, timeout),
    ]
}

/// The tick marks the mover's timeout while its move's command runs: the move holds at
/// its next await point (it does not end during the safe stop) and is aborted with the
/// mover at 4 ms. (Before session 48 it ended at 1 ms, under a held owner.)
#[test]
fn a_child_under_way_holds_at_its_next_await_point() {
    let (commands, trace, mover) = run_mover(
        |seq| Moves(seq.add(SeqConfig::new("move"), PreemptedMove).unwrap()),
        Behaviour::AbortOwner,
        4,
    );
    assert_eq!(commands, [(0, "preempted move"), (1_000, "safe stop")]);
    assert_eq!(trace, move_held_then_aborted(mover));
}

/// The tick marks the mover's timeout while its move checks its exit condition, which
/// holds: the move does not end under its held owner (its end is refused, as its await
/// points hold) and is aborted with it at 4 ms. (Before session 48 it ended at 1 ms.)
#[test]
fn a_child_whose_exit_check_the_tick_preempts_does_not_end() {
    let (commands, trace, mover) = run_mover(
        |seq| Moves(seq.add(SeqConfig::new("move"), PreemptedCheck).unwrap()),
        Behaviour::AbortOwner,
        4,
    );
    assert_eq!(commands, [(0, "move"), (1_000, "safe stop")]);
    assert_eq!(trace, move_held_then_aborted(mover));
}

/// The tick marks the mover's timeout while its polled wait checks its condition, which
/// holds: the wait does not return into the held action; it returns, and the next move
/// comes, once the exception is over (4 ms). (Before session 48 the next move came at 1 ms,
/// during the safe stop.)
#[test]
fn a_polled_wait_whose_condition_the_tick_preempts_returns_only_once_the_hold_ends() {
    let (commands, trace, mover) = run_mover(|_| WaitsThenMoves, Behaviour::Nothing, 4);
    assert_eq!(commands, [(1_000, "safe stop"), (4_000, "next move")]);
    assert_eq!(
        trace,
        [
            (0, MOVER, Running, Start),
            (1_000, STOP, Running, Timeout(mover)),
            (3_000, STOP, Terminated, Completed),
            (4_000, MOVER, Terminated, Completed),
        ]
    );
}

/// The same with `AbortOwner` and no safe stop: the tick aborts the mover at 1 ms, inside
/// the condition; no line of the aborted action runs after it (sticky abort).
#[test]
fn a_polled_wait_whose_condition_the_tick_preempts_does_not_return_into_an_aborted_action() {
    let seq: &'static Sequencer<Log, 4> = Box::leak(Box::new(Sequencer::new()));
    let log: &'static Log = Box::leak(Box::default());
    log.seq.set(Some(seq));
    let config = SeqConfig::new("mover")
        .timeout(Duration::from_millis(1))
        .timeout_behaviour(Behaviour::AbortOwner);
    let mover = seq.add(config, WaitsThenMoves).unwrap();
    let id = mover.id();
    let mut sim = Sim::new(seq, log, Monitors::<Log, 1>::new());
    sim.lane(mover);
    sim.start(id).unwrap();
    // Idle after the lane's first poll: the simulator's clock is still at 0.
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(0))
    );
    assert_eq!(log.commands.take(), []);
    assert_eq!(sim.state(id), Aborted);
}

/// A step whose command is logged and whose exit condition is flag `i`.
struct Until(&'static str, usize);
impl Step<Log> for Until {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, self.0);
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        cx.control().flags[self.1].get()
    }
}

/// Runs two moves at once.
struct Both(Seq<Until>, Seq<Until>);
impl Sequence<Log> for Both {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        let _ = embassy_futures::join::join(cx.step(&mut self.0), cx.step(&mut self.1)).await;
        Ok(())
    }
}

/// L runs moves a and b at once on a 10 ms grid. At 10 ms a's end stop fires (`Nothing`;
/// the safe stop's exit condition holds at once) and b reaches its target. b is a's
/// sibling, not held: its poll at 10 ms stands and it ends then. (Before session 48 the
/// hold skipped the due polls of every called sequence in the lane: b ended at 20 ms.)
#[test]
fn a_hold_leaves_the_due_polls_of_its_owners_siblings() {
    let seq: &'static Sequencer<Log, 4> = Box::leak(Box::new(Sequencer::new()));
    let log: &'static Log = Box::leak(Box::default());
    let every_10_ms = |name| SeqConfig::new(name).polling(Duration::from_millis(10));
    let stop = seq.add(SeqConfig::new("safe stop"), SafeStop).unwrap();
    let a = seq.add(every_10_ms("a"), Until("move a", 0)).unwrap();
    let b = seq.add(every_10_ms("b"), Until("move b", 1)).unwrap();
    let ai = a.id();
    let l = seq.add(every_10_ms("L"), Both(a, b)).unwrap();
    let id = l.id();
    let mut end_stop = |_: &Log, t: Instant| t.as_ticks() == 10_000;
    let mut monitors = Monitors::<Log, 1>::new();
    let monitor =
        Monitor::new("end stop a", &mut end_stop, Behaviour::Nothing).exception(stop.id());
    monitors.add(ai, monitor).unwrap();
    let mut sim = Sim::new(seq, log, monitors);
    sim.lane(l);
    sim.lane(stop);
    sim.before_tick(|t, log| log.flags[1].set(t.as_ticks() >= 10_000));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(30));
    let name = |s: SeqId| seq.sequence_by_id(s).map_or("?", |h| h.name());
    let ends: Vec<_> = sim
        .trace()
        .iter()
        .filter(|t| t.to == Terminated)
        .map(|t| (t.time.as_ticks(), name(t.sequence)))
        .collect();
    assert_eq!(ends, [(10_000, "b"), (10_000, "safe stop")]);
    assert_eq!(
        log.commands.take(),
        [(0, "move a"), (0, "move b"), (10_000, "safe stop")]
    );
}

/// Runs `step` (configured by `config`) blocking and says how it ended.
struct Reports<S>(Seq<S>);
impl<S: Step<Log>> Sequence<Log> for Reports<S> {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        let said = match cx.step(&mut self.0).await {
            Ok(rtseq::Done::Completed) => "move completed",
            Ok(rtseq::Done::Skipped) => "move skipped",
            Err(_) => "move failed",
        };
        cx.control().command(cx, said);
        Ok(())
    }
}

/// The mover (a 1 ms timeout: the safe stop until 3 ms, then `Nothing`) runs `step`,
/// configured by `config`, until idle. Returns what it saw and when the simulator went
/// idle (µs).
fn mover_reports<S: Step<Log> + 'static>(config: SeqConfig<Log>, step: S) -> (Seen, Option<u64>) {
    let seq: &'static Sequencer<Log, 4> = Box::leak(Box::new(Sequencer::new()));
    let log: &'static Log = Box::leak(Box::default());
    log.seq.set(Some(seq));
    let step = seq.add(config, step).unwrap();
    let stop = seq.add(SeqConfig::new("safe stop"), SafeStop).unwrap();
    let mover = SeqConfig::new("mover")
        .timeout(Duration::from_millis(1))
        .timeout_exception(stop.id())
        .timeout_behaviour(Behaviour::Nothing);
    let mover = seq.add(mover, Reports(step)).unwrap();
    let id = mover.id();
    let mut sim = Sim::new(seq, log, Monitors::<Log, 1>::new());
    sim.lane(mover);
    sim.lane(stop);
    sim.start(id).unwrap();
    let idle = sim
        .run_until_idle(Duration::from_millis(100))
        .map(|t| t.as_ticks());
    let name = |s: SeqId| seq.sequence_by_id(s).map_or("?", |h| h.name());
    let trace = sim
        .trace()
        .iter()
        .map(|t| (t.time.as_ticks(), name(t.sequence), t.to, t.cause))
        .collect();
    ((log.commands.take(), trace, id), idle)
}

/// In position at its first exit check (0 ms), which the tick at 1 ms preempts.
struct InPosition;
impl Step<Log> for InPosition {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "move");
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        cx.control().tick_at_1_ms();
        true
    }
}

/// A held end is kept, not decided again: the move, in position at 0 ms, ends when the
/// hold does (4 ms), not at its next due poll (10 ms, where its 5 ms timeout would abort
/// it first). (Found by a probe of session 48's first fix, which dropped the decision.)
#[test]
fn a_held_end_is_kept_for_when_the_hold_ends() {
    let config = SeqConfig::new("move")
        .polling(Duration::from_millis(10))
        .timeout(Duration::from_millis(5));
    let ((commands, trace, mover), idle) = mover_reports(config, InPosition);
    assert_eq!(
        trace,
        [
            (0, MOVER, Running, Start),
            (0, MOVE, Running, Start),
            (1_000, STOP, Running, Timeout(mover)),
            (3_000, STOP, Terminated, Completed),
            (4_000, MOVE, Terminated, Completed),
            (4_000, MOVER, Terminated, Completed),
        ]
    );
    assert_eq!(
        commands,
        [(0, "move"), (1_000, "safe stop"), (4_000, "move completed")]
    );
    assert_eq!(idle, Some(4_000));
}

/// Its exit condition reads a one-shot "in position" message (true at the first read
/// only), in the check the tick at 1 ms preempts.
struct TakesMessage;
impl Step<Log> for TakesMessage {
    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "move");
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        let log = cx.control();
        log.tick_at_1_ms();
        let n = log.reads.get();
        log.reads.set(n + 1);
        n == 0
    }
}

/// The message read in the held check is not lost: the move ends at 4 ms. (With the
/// decision dropped it waited for good.)
#[test]
fn a_one_shot_message_read_in_a_held_check_is_not_lost() {
    let ((commands, _, _), idle) = mover_reports(SeqConfig::new("move"), TakesMessage);
    assert_eq!(idle, Some(4_000));
    assert_eq!(
        commands,
        [(0, "move"), (1_000, "safe stop"), (4_000, "move completed")]
    );
}

/// On the home switch at its pre-condition (0 ms, preempted by the tick at 1 ms), off it
/// from 2 ms.
struct Homing;
impl Step<Log> for Homing {
    fn check_pre_condition(&mut self, cx: &Cx<'_, Log>) -> bool {
        cx.control().tick_at_1_ms();
        cx.now().as_ticks() >= 2_000
    }

    fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.control().command(cx, "homing move");
        Ok(())
    }
}

/// A held skip stays a skip: the homing step, skipped at 0 ms, ends skipped at 4 ms and
/// gives no command. (With the decision dropped its pre-condition was asked again at 4 ms
/// and it moved.)
#[test]
fn a_held_skip_stays_a_skip() {
    let ((commands, _, _), _) = mover_reports(SeqConfig::new("home"), Homing);
    assert_eq!(commands, [(1_000, "safe stop"), (4_000, "move skipped")]);
}

/// Runs `WaitsThenMoves` blocking.
struct RunsAxis(Seq<WaitsThenMoves>);
impl Sequence<Log> for RunsAxis {
    async fn action(&mut self, cx: &Cx<'_, Log>) -> Result<(), Failure> {
        cx.run(&mut self.0).await?;
        Ok(())
    }
}

/// A held wait returns when the hold ends: the axis's wait (10 ms polling), whose
/// condition held at 0 ms, returns at 4 ms, not at its next due poll (10 ms).
#[test]
fn a_held_wait_returns_when_the_hold_ends() {
    let seq: &'static Sequencer<Log, 4> = Box::leak(Box::new(Sequencer::new()));
    let log: &'static Log = Box::leak(Box::default());
    log.seq.set(Some(seq));
    let axis = SeqConfig::new("axis").polling(Duration::from_millis(10));
    let axis = seq.add(axis, WaitsThenMoves).unwrap();
    let stop = seq.add(SeqConfig::new("safe stop"), SafeStop).unwrap();
    let mover = SeqConfig::new("mover")
        .timeout(Duration::from_millis(1))
        .timeout_exception(stop.id())
        .timeout_behaviour(Behaviour::Nothing);
    let mover = seq.add(mover, RunsAxis(axis)).unwrap();
    let id = mover.id();
    let mut sim = Sim::new(seq, log, Monitors::<Log, 1>::new());
    sim.lane(mover);
    sim.lane(stop);
    sim.start(id).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(100)),
        Some(Instant::from_ticks(4_000))
    );
    assert_eq!(
        log.commands.take(),
        [(1_000, "safe stop"), (4_000, "next move")]
    );
}
