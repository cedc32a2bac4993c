//! EEROS's own sequencer examples on monitors, exception sequences, behaviours and timeouts
//! (`examples/sequencer/SequencerTest30.cpp` to `36`, `40`, `41` of the EEROS framework),
//! ported to rtseq and checked on exact traces.
//!
//! Mapping, the same in every test:
//! * EEROS seconds are rtseq seconds (`Duration::from_secs` / `from_millis`), one to one.
//! * EEROS polls every sequence and step every 100 ms (`BaseSequence::pollingTime`): every
//!   sequence and step here is configured with `SeqConfig::polling(100 ms)`. The simulator
//!   ticks every 1 ms (its default), so an rtseq time is exact to the millisecond.
//! * An EEROS `Wait` step is rtseq's `Wait` step; a member step called several times
//!   (`stepA(1)` in a loop) is one `Seq<Wait>` stepped several times.
//! * A non-blocking EEROS sequence (`Sequence(name, caller, false)`, a thread) runs in a lane
//!   of its own; `seqS()` is `Cx::start`, `seqS.wait()` is `Cx::join` with the result ignored,
//!   as EEROS ignores it. An exception sequence (a blocking EEROS sequence started by the
//!   monitor in the checking thread) runs in a lane of its own too (rtseq's rule, semantics
//!   item 3); its EEROS `caller` is the monitor's owner, and so is its rtseq caller.
//! * EEROS's behaviours `resume`, `abort`, `restart` are `Behaviour::Nothing`, `AbortOwner`,
//!   `RestartOwner`; the timeout monitor is the one built into every rtseq sequence
//!   (`SeqConfig::timeout`, `timeout_exception`, `timeout_behaviour`).
//! * The return values of steps are ignored, as the EEROS examples ignore them.
//!
//! EEROS's timings quoted below are those of its implementation (read in
//! `src/sequencer/BaseSequence.cpp`, `Sequence.cpp`, `includes/eeros/sequencer/Wait.hpp`,
//! `ConditionTimeout.hpp`) with ideal clocks; its wall-clock comparisons (`>`) and the
//! run time of each poll make the real program a few ms later at each step.

mod common;
use common::{show, tr};

use std::cell::Cell;

use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Restart, Start, Timeout};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Cx, Duration, Failure, Monitor, Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence,
    Sequencer, Transition, Wait,
};

/// The control system of the examples: EEROS's global `int count` (examples 40 and 41) and
/// a log of what the exception sequences did.
#[derive(Default)]
struct Plant {
    count: Cell<u32>,
    /// Runs of the exception sequences (EEROS's `static int count` of examples 33 and 36).
    exceptions: Cell<u32>,
    /// Times (ms) at which an exception sequence asked for what EEROS's `resetTimeout()`
    /// does; rtseq has no such request (see the report of examples 32, 35 and 41).
    reset_timeout_asked: std::cell::RefCell<Vec<u64>>,
}

const POLL: Duration = Duration::from_millis(100);

fn cfg(name: &'static str) -> SeqConfig<Plant> {
    SeqConfig::new(name).polling(POLL)
}

fn secs(s: u64) -> Duration {
    Duration::from_secs(s)
}

fn assert_trace(got: &[Transition], want: &[Transition]) {
    assert_eq!(got, want, "\n got:\n{}\nwant:\n{}", show(got), show(want));
}

fn now_ms(cx: &Cx<'_, Plant>) -> u64 {
    cx.now().as_ticks() / 1000
}

// ---------------------------------------------------------------------------------------
// Sequences of examples 30 to 36: MainSequence, SequenceS, ExceptionSeq.
// ---------------------------------------------------------------------------------------

/// EEROS `MainSequence` (30–36): `stepA(1)` three times, `seqS()` non-blocking, `stepA(1)`
/// three times, `seqS.wait()`.
struct MainSeq {
    step_a: Seq<Wait>,
    seq_s: SeqId,
}

impl Sequence<Plant> for MainSeq {
    async fn action(&mut self, cx: &Cx<'_, Plant>) -> Result<(), Failure> {
        for _ in 0..3 {
            let _ = cx.step(&mut self.step_a).await;
        }
        cx.start(self.seq_s)?;
        for _ in 0..3 {
            let _ = cx.step(&mut self.step_a).await;
        }
        let _ = cx.join(self.seq_s).await;
        Ok(())
    }
}

/// EEROS `SequenceS` (30–36): `stepB(1)` five times.
struct SeqS {
    step_b: Seq<Wait>,
}

impl Sequence<Plant> for SeqS {
    async fn action(&mut self, cx: &Cx<'_, Plant>) -> Result<(), Failure> {
        for _ in 0..5 {
            let _ = cx.step(&mut self.step_b).await;
        }
        Ok(())
    }
}

/// What an exception sequence does after its wait.
#[derive(Clone, Copy)]
enum Then {
    Nothing,
    /// EEROS `caller->resetTimeout()`: rtseq has no such request; noted in the plant.
    ResetTimeout,
    /// EEROS `caller->resetTimeout(); caller->setTimeoutTime(t)`: `Handle::set_timeout`.
    ResetAndSetTimeout(Duration),
    /// EEROS examples 40 and 41: `count = 0` before the wait.
    ZeroCount,
}

/// EEROS `ExceptionSeq`: `wait(t)`, then `then`.
struct ExceptionSeq {
    wait: Seq<Wait>,
    owner: SeqId,
    then: Then,
}

impl Sequence<Plant> for ExceptionSeq {
    async fn action(&mut self, cx: &Cx<'_, Plant>) -> Result<(), Failure> {
        let plant = cx.control();
        plant.exceptions.set(plant.exceptions.get() + 1);
        if let Then::ZeroCount = self.then {
            plant.count.set(0);
        }
        let _ = cx.step(&mut self.wait).await;
        match self.then {
            Then::Nothing | Then::ZeroCount => {}
            Then::ResetTimeout => plant.reset_timeout_asked.borrow_mut().push(now_ms(cx)),
            Then::ResetAndSetTimeout(t) => {
                plant.reset_timeout_asked.borrow_mut().push(now_ms(cx));
                let owner = cx.sequence_by_id(self.owner).ok_or(Failure::App(1))?;
                owner.set_timeout(Some(t))?;
            }
        }
        Ok(())
    }
}

/// Which sequence of examples 30–36 carries the timeout.
#[derive(Clone, Copy, PartialEq)]
enum On {
    Main,
    SeqS,
}

/// The timeout of examples 31–36.
#[derive(Clone, Copy)]
struct TimeoutSpec {
    on: On,
    after: Duration,
    behaviour: Behaviour,
    /// Restarts before a restarting timeout escalates to an abort (examples 33 and 36).
    restart_limit: u8,
    /// The exception sequence's wait and what it does after it.
    exception_wait: Duration,
    then: Then,
}

/// The ids of examples 30–36 (registration order).
#[derive(Clone, Copy, Debug)]
struct Ids {
    /// The exception sequence's `wait` step.
    ew: SeqId,
    /// The exception sequence.
    e: SeqId,
    step_b: SeqId,
    seq_s: SeqId,
    step_a: SeqId,
    main: SeqId,
}

/// The result of one run of examples 30–36.
struct Run {
    trace: Vec<Transition>,
    ids: Ids,
    end_ms: Option<u64>,
    main_outcome: Option<Outcome>,
    seq_s_outcome: Option<Outcome>,
    exceptions: u32,
    reset_timeout_asked: Vec<u64>,
}

/// Runs EEROS's examples 30 (no timeout) to 36 (a timeout as `spec`).
fn run_30_to_36(spec: Option<TimeoutSpec>) -> Run {
    let seq: Sequencer<Plant, 8> = Sequencer::new();
    let plant = Plant::default();
    let ew = seq.add(cfg("wait"), Wait::new(secs(3))).unwrap();
    let ids_e = SeqId::from_index(1);
    let ids_seq_s = SeqId::from_index(3);
    let ids_main = SeqId::from_index(5);
    let timeout = |c: SeqConfig<Plant>, on: On| match spec {
        Some(s) if s.on == on => c
            .timeout(s.after)
            .timeout_exception(ids_e)
            .timeout_behaviour(s.behaviour)
            .timeout_restart_limit(s.restart_limit),
        _ => c,
    };
    let (owner, wait, then) = match spec {
        Some(s) => (
            if s.on == On::Main {
                ids_main
            } else {
                ids_seq_s
            },
            s.exception_wait,
            s.then,
        ),
        None => (ids_main, secs(3), Then::Nothing),
    };
    let mut ew = ew;
    ew.body_mut().set_duration(wait);
    let ew_id = ew.id();
    let e = seq
        .add(
            cfg("exception sequence"),
            ExceptionSeq {
                wait: ew,
                owner,
                then,
            },
        )
        .unwrap();
    let step_b = seq.add(cfg("step B"), Wait::new(secs(1))).unwrap();
    let step_b_id = step_b.id();
    let seq_s = seq
        .add(timeout(cfg("seq S"), On::SeqS), SeqS { step_b })
        .unwrap();
    let step_a = seq.add(cfg("step A"), Wait::new(secs(1))).unwrap();
    let step_a_id = step_a.id();
    let main = seq
        .add(
            timeout(cfg("Main Sequence"), On::Main),
            MainSeq {
                step_a,
                seq_s: ids_seq_s,
            },
        )
        .unwrap();
    let ids = Ids {
        ew: ew_id,
        e: e.id(),
        step_b: step_b_id,
        seq_s: seq_s.id(),
        step_a: step_a_id,
        main: main.id(),
    };
    assert_eq!((ids.e, ids.seq_s, ids.main), (ids_e, ids_seq_s, ids_main));
    let mut sim = Sim::new(&seq, &plant, Monitors::<Plant, 1>::new());
    sim.lane(main);
    sim.lane(seq_s);
    sim.lane(e);
    sim.start(ids.main).unwrap();
    let end_ms = sim.run_until_idle(secs(60)).map(common::ms);
    let main_outcome = sim.handle(ids.main).unwrap().last_outcome();
    let seq_s_outcome = sim.handle(ids.seq_s).unwrap().last_outcome();
    let trace = sim.take_trace();
    drop(sim);
    Run {
        trace,
        ids,
        end_ms,
        main_outcome,
        seq_s_outcome,
        exceptions: plant.exceptions.get(),
        reset_timeout_asked: plant.reset_timeout_asked.take(),
    }
}

// ---------------------------------------------------------------------------------------
// Examples 40 and 41: a counting main sequence, a monitor on the count, a timeout.
// ---------------------------------------------------------------------------------------

/// EEROS `MainSequence` of 40 and 41: `count = 0`, then ten times `stepA(2); count++`.
struct Counting {
    step_a: Seq<Wait>,
}

impl Sequence<Plant> for Counting {
    async fn action(&mut self, cx: &Cx<'_, Plant>) -> Result<(), Failure> {
        let plant = cx.control();
        plant.count.set(0);
        for _ in 0..10 {
            let _ = cx.step(&mut self.step_a).await;
            plant.count.set(plant.count.get() + 1);
        }
        Ok(())
    }
}

/// The ids of examples 40 and 41 (registration order).
#[derive(Clone, Copy, Debug)]
struct CountIds {
    /// The counter exception sequence (`eSeq` of 40, `eSeq1` of 41) and its wait.
    w1: SeqId,
    e1: SeqId,
    /// The timeout exception sequence of 41 (`eSeq2`) and its wait; 40 uses `e1`.
    w2: SeqId,
    e2: SeqId,
    step_a: SeqId,
    main: SeqId,
}

struct CountRun {
    trace: Vec<Transition>,
    ids: CountIds,
    end_ms: Option<u64>,
    main_outcome: Option<Outcome>,
    exceptions: u32,
    reset_timeout_asked: Vec<u64>,
}

/// Example 40 (`own_timeout_exception` false: the timeout uses the counter's exception
/// sequence, behaviour abort) or 41 (true: a second exception sequence that "resets the
/// timeout", behaviour resume).
fn run_40_41(example_41: bool) -> CountRun {
    let seq: Sequencer<Plant, 8> = Sequencer::new();
    let plant = Plant::default();
    let half = Duration::from_millis(500);
    let w1 = seq.add(cfg("wait"), Wait::new(half)).unwrap();
    let main_id = SeqId::from_index(5);
    let w1_id = w1.id();
    let e1 = seq
        .add(
            cfg("counter exception sequence"),
            ExceptionSeq {
                wait: w1,
                owner: main_id,
                then: Then::ZeroCount,
            },
        )
        .unwrap();
    let w2 = seq.add(cfg("wait 2"), Wait::new(half)).unwrap();
    let w2_id = w2.id();
    let e2 = seq
        .add(
            cfg("timeout exception sequence"),
            ExceptionSeq {
                wait: w2,
                owner: main_id,
                then: Then::ResetTimeout,
            },
        )
        .unwrap();
    let step_a = seq.add(cfg("step A"), Wait::new(secs(2))).unwrap();
    let step_a_id = step_a.id();
    let main_cfg = cfg("Main Sequence").timeout(secs(10));
    let main_cfg = if example_41 {
        main_cfg
            .timeout_exception(e2.id())
            .timeout_behaviour(Behaviour::Nothing)
    } else {
        main_cfg
            .timeout_exception(e1.id())
            .timeout_behaviour(Behaviour::AbortOwner)
    };
    let main = seq.add(main_cfg, Counting { step_a }).unwrap();
    let ids = CountIds {
        w1: w1_id,
        e1: e1.id(),
        w2: w2_id,
        e2: e2.id(),
        step_a: step_a_id,
        main: main.id(),
    };
    assert_eq!(ids.main, main_id);
    let mut count_above_2 = |p: &Plant, _| p.count.get() > 2;
    let mut monitors: Monitors<Plant, 1> = Monitors::new();
    monitors
        .add(
            ids.main,
            Monitor::new("myMonitor", &mut count_above_2, Behaviour::Nothing).exception(ids.e1),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &plant, monitors);
    sim.lane(main);
    sim.lane(e1);
    sim.lane(e2);
    sim.start(ids.main).unwrap();
    let end_ms = sim.run_until_idle(secs(60)).map(common::ms);
    let main_outcome = sim.handle(ids.main).unwrap().last_outcome();
    let trace = sim.take_trace();
    drop(sim);
    CountRun {
        trace,
        ids,
        end_ms,
        main_outcome,
        exceptions: plant.exceptions.get(),
        reset_timeout_asked: plant.reset_timeout_asked.take(),
    }
}

// ---------------------------------------------------------------------------------------
// Expected traces.
// ---------------------------------------------------------------------------------------

/// An expected trace, built in trace order.
#[derive(Default)]
struct Want(Vec<Transition>);

impl Want {
    fn t(mut self, ms: u64, s: SeqId, from: RunningState, to: RunningState, c: Cause) -> Self {
        self.0.push(tr(ms, s, from, to, c));
        self
    }
    /// `Idle → Running (start)`: the first run.
    fn go(self, ms: u64, s: SeqId) -> Self {
        self.t(ms, s, Idle, Running, Start)
    }
    /// `Terminated → Running (start)`: a run after a completed one.
    fn again(self, ms: u64, s: SeqId) -> Self {
        self.t(ms, s, Terminated, Running, Start)
    }
    /// `Running → Terminated (completed)`.
    fn done(self, ms: u64, s: SeqId) -> Self {
        self.t(ms, s, Running, Terminated, Completed)
    }
    /// `Running → Aborting → Aborted`, both for `c`.
    fn abort(self, ms: u64, s: SeqId, c: Cause) -> Self {
        self.t(ms, s, Running, Aborting, c)
            .t(ms, s, Aborting, Aborted, c)
    }
    /// `Running → Restarting (c) → Running (restart)`.
    fn restart(self, ms: u64, s: SeqId, c: Cause) -> Self {
        self.t(ms, s, Running, Restarting, c)
            .t(ms, s, Restarting, Running, Restart)
    }
    /// An exception sequence `e` (first run: `first`) started for `c` at `ms`, with its
    /// wait step `w`.
    fn exception(self, ms: u64, e: SeqId, w: SeqId, c: Cause, first: bool) -> Self {
        let from = if first { Idle } else { Terminated };
        self.t(ms, e, from, Running, c)
            .t(ms, w, from, Running, Start)
    }
    /// The exception sequence `e` and its wait step `w` end at `ms`.
    fn exception_done(self, ms: u64, e: SeqId, w: SeqId) -> Self {
        self.done(ms, w).done(ms, e)
    }
}

/// Examples 30–36 up to 4 s, the same in all: step A at 0, 1, 2 and 3 s, seq S and its
/// step B started at 3 s, step A's and step B's ends at 4 s.
fn first_four_seconds(i: Ids) -> Want {
    Want::default()
        .go(0, i.main)
        .go(0, i.step_a)
        .done(1000, i.step_a)
        .again(1000, i.step_a)
        .done(2000, i.step_a)
        .again(2000, i.step_a)
        .done(3000, i.step_a)
        .go(3000, i.seq_s)
        .again(3000, i.step_a)
        .go(3000, i.step_b)
        .done(4000, i.step_a)
        .again(4000, i.step_a)
        .done(4000, i.step_b)
        .again(4000, i.step_b)
}

const MS_4500: Duration = Duration::from_millis(4500);
const MS_1500: Duration = Duration::from_millis(1500);

// ---------------------------------------------------------------------------------------
// The examples.
// ---------------------------------------------------------------------------------------

/// EEROS examples/sequencer/SequencerTest30.cpp: no monitor, no timeout. `Main Sequence`
/// runs `stepA(1)` three times (0–3 s), starts `seq S` non-blocking (its own thread:
/// `stepB(1)` five times, 3–8 s), runs `stepA(1)` three more times (3–6 s) and waits for
/// `seq S` (`seqS.wait()`, until 8 s); EEROS ends the main sequence at 8 s, when its action
/// returns and its default exit condition (true) is checked.
///
/// rtseq: the same tree (seq S in a lane, `Cx::start` and `Cx::join`), every end at the
/// same time as in EEROS: step A at 1, 2, 3, 4, 5, 6 s, step B at 4, 5, 6, 7, 8 s, seq S
/// and main at 8 s. Passes, exactly.
#[test]
fn eeros_30_non_blocking_child_runs_beside_main_which_waits_for_it() {
    let r = run_30_to_36(None);
    let i = r.ids;
    let want = first_four_seconds(i)
        .done(5000, i.step_a)
        .again(5000, i.step_a)
        .done(5000, i.step_b)
        .again(5000, i.step_b)
        .done(6000, i.step_a)
        .done(6000, i.step_b)
        .again(6000, i.step_b)
        .done(7000, i.step_b)
        .again(7000, i.step_b)
        .done(8000, i.step_b)
        .done(8000, i.seq_s)
        .done(8000, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(8000));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Completed));
    assert_eq!(r.exceptions, 0);
}

/// EEROS examples/sequencer/SequencerTest31.cpp: example 30 with a timeout of 4.5 s on
/// `Main Sequence`, the exception sequence `exception sequence` (`wait(3)`) and the
/// behaviour `abort`. EEROS: step A's poll at 4.5 s finds main's timeout expired
/// (`BaseSequence::checkMonitors`, BaseSequence.cpp 86–110, from the step's `running` state,
/// line 52) and runs the exception sequence blocking, in step A's thread (line 131):
/// 4.5–7.5 s. Then main is put into `aborting` (line 138) and so is step A (lines 99–107);
/// step A ends at 7.5 s, main's action goes on: its last `stepA(1)` ends at once (the fired
/// monitor still marks main, lines 36–38), `seqS.wait()` waits for seq S, which EEROS
/// does not abort (a non-blocking sequence is not in main's caller stack, lines 15–18) and
/// which completes its five steps at 8 s; main ends at 8 s (`aborting → terminated`,
/// line 62).
///
/// rtseq: the timeout fires at 4.5 s, the exception sequence runs 4.5–7.5 s in its lane
/// while main and step A are held, and the tick after its end (7.501 s) aborts main and
/// everything it started, innermost first: step B, seq S, step A, main. Deliberate
/// differences: semantics item 4 (abort is sticky — main's action runs no further line —
/// and reaches every sub-sequence, blocking and non-blocking, so seq S is aborted instead
/// of completing at 8 s), and item 3 (the behaviour is applied by the next tick after
/// the exception sequence ended: 1 ms, the simulator's tick, after 7.5 s).
#[test]
fn eeros_31_main_timeout_abort_runs_the_exception_then_aborts_main_and_its_children() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::Main,
        after: MS_4500,
        behaviour: Behaviour::AbortOwner,
        restart_limit: 3,
        exception_wait: secs(3),
        then: Then::Nothing,
    }));
    let i = r.ids;
    let to = Timeout(i.main);
    let want = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_b)
        .again(5000, i.step_b)
        .done(6000, i.step_b)
        .again(6000, i.step_b)
        .done(7000, i.step_b)
        .again(7000, i.step_b)
        .exception_done(7500, i.e, i.ew)
        .abort(7501, i.step_b, to)
        .abort(7501, i.seq_s, to)
        .abort(7501, i.step_a, to)
        .abort(7501, i.main, to);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(7501));
    assert_eq!(r.main_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.exceptions, 1);
}

/// EEROS examples/sequencer/SequencerTest32.cpp: example 31 with the behaviour `resume`;
/// the exception sequence, after its `wait(3)`, calls `caller->resetTimeout()`. EEROS: the
/// timeout fires at 4.5 s, the exception sequence runs 4.5–7.5 s in step A's thread and
/// restarts main's timeout clock at 7.5 s; `resume` puts main back to `running`
/// (BaseSequence.cpp 137) and step A, whose wall-clock exit condition has long been true,
/// ends in the same loop pass (line 54) at 7.5 s; the last step A runs 7.5–8.5 s; seq S
/// completed at 8 s; main ends at 8.5 s (its reset timeout would only fire at 12 s).
///
/// rtseq: `Behaviour::Nothing`. The timeout fires at 4.5 s, the exception sequence runs
/// 4.5–7.5 s while main and step A are held, and main goes on. Step A's poll due at 7.5 s
/// fell due while it was held and is skipped, so step A ends at its next poll, 7.6 s, and
/// the last step A runs 7.6–8.6 s; main ends at 8.6 s (seq S, not held, at 8 s as in
/// EEROS). Deliberate differences: semantics item 1 (a poll that falls due while its
/// sequence is held is skipped, not taken when the hold ends: +100 ms) and item 3 (the
/// behaviour is applied by the tick after the exception sequence's end). rtseq has no
/// `resetTimeout` (reported): its timeout fires once per run (item 6), so the request the
/// exception sequence would make (noted at 7.5 s) changes nothing in this run, as in EEROS.
#[test]
fn eeros_32_main_timeout_resume_runs_the_exception_then_main_goes_on() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::Main,
        after: MS_4500,
        behaviour: Behaviour::Nothing,
        restart_limit: 3,
        exception_wait: secs(3),
        then: Then::ResetTimeout,
    }));
    let i = r.ids;
    let to = Timeout(i.main);
    let want = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_b)
        .again(5000, i.step_b)
        .done(6000, i.step_b)
        .again(6000, i.step_b)
        .done(7000, i.step_b)
        .again(7000, i.step_b)
        .exception_done(7500, i.e, i.ew)
        .done(7600, i.step_a)
        .again(7600, i.step_a)
        .done(8000, i.step_b)
        .done(8000, i.seq_s)
        .done(8600, i.step_a)
        .done(8600, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(8600));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Completed));
    assert_eq!((r.exceptions, r.reset_timeout_asked), (1, vec![7500]));
}

/// EEROS examples/sequencer/SequencerTest33.cpp: example 31 with the behaviour `restart`;
/// the exception sequence counts its runs (`static int count`) and at the end of its third
/// run sets its caller's timeout behaviour to `abort`. EEROS: round 1 — timeout at 4.5 s,
/// exception 4.5–7.5 s, main marked `restarting` (BaseSequence.cpp 139), step A ends at
/// 7.5 s, the last step A at once, `seqS.wait()` until seq S completes (8 s), then main
/// restarts (lines 65–70, with a fresh timeout clock) at 8 s; round 2 — steps A 8–11 s,
/// seq S started again 11–16 s, timeout 12.5 s, exception 12.5–15.5 s, restart at 16 s;
/// round 3 — timeout 20.5 s, exception 20.5–23.5 s switches the behaviour to `abort`,
/// which `checkMonitor` reads after the exception sequence (line 134): main ends at 24 s,
/// after seq S's third run. Three exception runs.
///
/// rtseq: `Behaviour::RestartOwner` with `timeout_restart_limit(2)`: two restarts, and the
/// third firing escalates to the abort (semantics item 5), which is EEROS's switch at the
/// third exception run; rtseq has no call that changes a behaviour at run time (reported).
/// Round 1: timeout 4.5 s, exception 4.5–7.5 s, at 7.501 s step B, seq S and step A are
/// aborted and main restarts at once; round 2 from 7.501 s: step A ends on its 100 ms grid
/// at 8.6, 9.6, 10.6 s, seq S started at 10.6 s, timeout at 12.001 s taken at main's poll
/// at 12.1 s, exception 12.1–15.1 s, restart at 15.101 s; round 3: timeout at 19.7 s,
/// exception 19.7–22.7 s, abort at 22.701 s. Deliberate differences: semantics item 4 (a
/// restart aborts the whole subtree, seq S included, and main's action goes no further, so
/// no round waits for seq S), item 1 (polls keep the grid of their polling class) and
/// item 3 (the next tick applies the behaviour).
#[test]
fn eeros_33_main_timeout_restart_twice_then_abort() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::Main,
        after: MS_4500,
        behaviour: Behaviour::RestartOwner,
        restart_limit: 2,
        exception_wait: secs(3),
        then: Then::Nothing,
    }));
    let i = r.ids;
    let to = Timeout(i.main);
    // One restarted round of main from `t0` (ms), its steps on the 100 ms grid: step A at
    // t0 + 1.1, 2.1, 3.1 s, seq S and step B from t0 + 3.1 s, the timeout at t0 + 4.6 s
    // (main's poll after t0 + 4.5 s), the exception for 3 s, the behaviour 1 ms later.
    let round = |w: Want, t0: u64, last: bool| {
        let (a, b) = (t0 + 1099, t0 + 4599);
        let w = w
            .t(t0, i.step_a, Aborted, Running, Start)
            .done(a, i.step_a)
            .again(a, i.step_a)
            .done(a + 1000, i.step_a)
            .again(a + 1000, i.step_a)
            .done(a + 2000, i.step_a)
            .t(a + 2000, i.seq_s, Aborted, Running, Start)
            .again(a + 2000, i.step_a)
            .t(a + 2000, i.step_b, Aborted, Running, Start)
            .done(a + 3000, i.step_a)
            .again(a + 3000, i.step_a)
            .done(a + 3000, i.step_b)
            .again(a + 3000, i.step_b)
            .exception(b, i.e, i.ew, to, false)
            .done(a + 4000, i.step_b)
            .again(a + 4000, i.step_b)
            .done(a + 5000, i.step_b)
            .again(a + 5000, i.step_b)
            .done(a + 6000, i.step_b)
            .again(a + 6000, i.step_b)
            .exception_done(b + 3000, i.e, i.ew)
            .abort(b + 3001, i.step_b, to)
            .abort(b + 3001, i.seq_s, to)
            .abort(b + 3001, i.step_a, to);
        if last {
            w.abort(b + 3001, i.main, to)
        } else {
            w.restart(b + 3001, i.main, to)
        }
    };
    let first = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_b)
        .again(5000, i.step_b)
        .done(6000, i.step_b)
        .again(6000, i.step_b)
        .done(7000, i.step_b)
        .again(7000, i.step_b)
        .exception_done(7500, i.e, i.ew)
        .abort(7501, i.step_b, to)
        .abort(7501, i.seq_s, to)
        .abort(7501, i.step_a, to)
        .restart(7501, i.main, to);
    let want = round(round(first, 7501, false), 15101, true);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(22701));
    assert_eq!(r.main_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.exceptions, 3);
}

/// EEROS examples/sequencer/SequencerTest34.cpp: the timeout (1.5 s, exception sequence
/// `wait(3)`, behaviour `abort`) sits on `seq S`, the non-blocking child. EEROS: seq S
/// starts at 3 s (`Sequence::start` resets its timeout, Sequence.cpp 45); step B's poll at
/// 4.5 s fires it; the exception sequence runs in seq S's thread 4.5–7.5 s; seq S and step B
/// are put into `aborting`, step B ends at 7.5 s, seq S's remaining `stepB(1)` end at once,
/// seq S ends at 7.5 s. Main, untouched (seq S's monitors do not reach its caller), runs its
/// steps A until 6 s, waits for seq S until 7.5 s and ends then.
///
/// rtseq: the timeout fires at 4.5 s, the exception sequence runs 4.5–7.5 s, the next tick
/// (7.501 s) aborts step B and seq S; main's join returns and main completes in the same
/// tick. Passes, with the 1 ms of semantics item 3 (the behaviour is applied by the tick
/// after the exception sequence's end).
#[test]
fn eeros_34_child_timeout_abort_aborts_the_child_only() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::SeqS,
        after: MS_1500,
        behaviour: Behaviour::AbortOwner,
        restart_limit: 3,
        exception_wait: secs(3),
        then: Then::Nothing,
    }));
    let i = r.ids;
    let to = Timeout(i.seq_s);
    let want = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_a)
        .again(5000, i.step_a)
        .done(6000, i.step_a)
        .exception_done(7500, i.e, i.ew)
        .abort(7501, i.step_b, to)
        .abort(7501, i.seq_s, to)
        .done(7501, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(7501));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.exceptions, 1);
}

/// EEROS examples/sequencer/SequencerTest35.cpp: example 34 with the behaviour `resume`;
/// after its `wait(3)` the exception sequence calls `caller->resetTimeout()` and
/// `caller->setTimeoutTime(5)`. EEROS: timeout at 4.5 s, exception 4.5–7.5 s, seq S's clock
/// restarted at 7.5 s with 5 s (it would fire at 12.5 s); step B ends at 7.5 s (same loop
/// pass), then 7.5–8.5, 8.5–9.5, 9.5–10.5 s; seq S and main end at 10.5 s.
///
/// rtseq: `Behaviour::Nothing`; the exception sequence calls `Handle::set_timeout(5 s)` on
/// seq S (EEROS's `setTimeoutTime`). The held poll at 7.5 s is skipped, step B ends at
/// 7.6 s, then 7.6–8.6, 8.6–9.6, 9.6–10.6 s; seq S and main end at 10.6 s. The new timeout
/// does not fire (rtseq's timeout fires once per run and `set_timeout` on a run whose
/// timeout has fired applies to the next run; EEROS's reset one would fire at 12.5 s, after
/// the end, too). Deliberate differences: semantics item 1 (the skipped held poll:
/// +100 ms), item 6 (once per run); `resetTimeout` is missing in rtseq (reported).
#[test]
fn eeros_35_child_timeout_resume_lets_the_child_go_on() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::SeqS,
        after: MS_1500,
        behaviour: Behaviour::Nothing,
        restart_limit: 3,
        exception_wait: secs(3),
        then: Then::ResetAndSetTimeout(secs(5)),
    }));
    let i = r.ids;
    let to = Timeout(i.seq_s);
    let want = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_a)
        .again(5000, i.step_a)
        .done(6000, i.step_a)
        .exception_done(7500, i.e, i.ew)
        .done(7600, i.step_b)
        .again(7600, i.step_b)
        .done(8600, i.step_b)
        .again(8600, i.step_b)
        .done(9600, i.step_b)
        .again(9600, i.step_b)
        .done(10600, i.step_b)
        .done(10600, i.seq_s)
        .done(10600, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(10600));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Completed));
    assert_eq!((r.exceptions, r.reset_timeout_asked), (1, vec![7500]));
}

/// EEROS examples/sequencer/SequencerTest36.cpp: example 34 with the behaviour `restart`;
/// the exception sequence switches its caller's timeout behaviour to `abort` at the end of
/// its third run. EEROS: seq S from 3 s, timeout 4.5 s, exception 4.5–7.5 s, seq S's
/// remaining steps end at once and it restarts at 7.5 s (fresh timeout clock); round 2:
/// timeout 9 s, exception 9–12 s, restart 12 s; round 3: timeout 13.5 s, exception
/// 13.5–16.5 s, then `abort`: seq S ends at 16.5 s, and main, which waited for it since
/// 6 s, too.
///
/// rtseq: `Behaviour::RestartOwner` with `timeout_restart_limit(2)` (the third firing
/// escalates to the abort, semantics item 5). Round 1: timeout 4.5 s, exception 4.5–7.5 s,
/// restart at 7.501 s; round 2: step B ends on its grid at 8.6 s, the timeout (due
/// 9.001 s) is taken at seq S's poll at 9.1 s, exception 9.1–12.1 s, restart at 12.101 s;
/// round 3: timeout at 13.7 s, exception 13.7–16.7 s, abort at 16.701 s, main completes in
/// that tick. Deliberate differences: semantics item 1 (polls keep the grid of their
/// class: +100 ms per restarted round) and item 3 (+1 ms for the next tick).
#[test]
fn eeros_36_child_timeout_restart_twice_then_abort() {
    let r = run_30_to_36(Some(TimeoutSpec {
        on: On::SeqS,
        after: MS_1500,
        behaviour: Behaviour::RestartOwner,
        restart_limit: 2,
        exception_wait: secs(3),
        then: Then::Nothing,
    }));
    let i = r.ids;
    let to = Timeout(i.seq_s);
    let round = |w: Want, t0: u64| {
        w.t(t0, i.step_b, Aborted, Running, Start)
            .done(t0 + 1099, i.step_b)
            .again(t0 + 1099, i.step_b)
            .exception(t0 + 1599, i.e, i.ew, to, false)
            .exception_done(t0 + 4599, i.e, i.ew)
            .abort(t0 + 4600, i.step_b, to)
    };
    let first = first_four_seconds(i)
        .exception(4500, i.e, i.ew, to, true)
        .done(5000, i.step_a)
        .again(5000, i.step_a)
        .done(6000, i.step_a)
        .exception_done(7500, i.e, i.ew)
        .abort(7501, i.step_b, to)
        .restart(7501, i.seq_s, to);
    let want = round(first, 7501).restart(12101, i.seq_s, to);
    let want = round(want, 12101)
        .abort(16701, i.seq_s, to)
        .done(16701, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(16701));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!(r.seq_s_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.exceptions, 3);
}

/// EEROS examples/sequencer/SequencerTest40.cpp: `Main Sequence` sets `count = 0`, then
/// ten times `stepA(2); count++`. Monitor `myMonitor` (condition `count > 2`, behaviour
/// `resume`, exception sequence `exception sequence`: `count = 0; wait(0.5)`); main's timeout
/// 10 s with the same exception sequence and the behaviour `abort`. EEROS: steps A end at
/// 2, 4, 6 s (count 3); the fourth step A checks the monitors before its action (its `idle`
/// state, BaseSequence.cpp 37): the monitor fires at 6 s, the exception sequence runs
/// 6–6.5 s (count 0), `resume`; step A 6.5–8.5 s (count 1), the next from 8.5 s; the
/// timeout fires at 10 s, the exception sequence runs 10–10.5 s, `abort`: step A and main
/// end at 10.5 s (the remaining steps end at once).
///
/// rtseq: the monitor (`Behaviour::Nothing`, rising edge) is evaluated at main's polls: it
/// sees `count > 2` at 6.1 s (at the 6 s tick the lane had not counted yet), the exception
/// sequence runs 6.1–6.6 s while main and the fourth step A (started at 6 s) are held; that
/// step, on its own clock, ends at 8 s; the fifth runs from 8 s; the timeout fires at 10 s
/// (the tick evaluates it before the step's exit condition), the exception sequence runs
/// 10–10.5 s, and the next tick (10.501 s) aborts step A and main. Deliberate differences:
/// semantics item 1 (monitors are evaluated by the tick at the owner's polling period, not
/// at the start of each step: the firing 100 ms later, the fourth step 500 ms earlier) and
/// item 3 (+1 ms). Two exception runs, as in EEROS.
#[test]
fn eeros_40_monitor_resume_and_timeout_abort_share_an_exception_sequence() {
    let r = run_40_41(false);
    let i = r.ids;
    let (m, to) = (Mon(rtseq::MonitorId::from_index(0)), Timeout(i.main));
    let want = Want::default()
        .go(0, i.main)
        .go(0, i.step_a)
        .done(2000, i.step_a)
        .again(2000, i.step_a)
        .done(4000, i.step_a)
        .again(4000, i.step_a)
        .done(6000, i.step_a)
        .again(6000, i.step_a)
        .exception(6100, i.e1, i.w1, m, true)
        .exception_done(6600, i.e1, i.w1)
        .done(8000, i.step_a)
        .again(8000, i.step_a)
        .exception(10000, i.e1, i.w1, to, false)
        .exception_done(10500, i.e1, i.w1)
        .abort(10501, i.step_a, to)
        .abort(10501, i.main, to);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(10501));
    assert_eq!(r.main_outcome, Some(Outcome::Aborted(to)));
    assert_eq!(r.exceptions, 2);
}

/// EEROS examples/sequencer/SequencerTest41.cpp: example 40 with a second exception
/// sequence for the timeout, `timeout exception sequence` (`wait(0.5)`, then
/// `caller->resetTimeout()`), and the timeout behaviour `resume`. EEROS: monitor at 6 s
/// (exception 6–6.5 s, count 0), step A 6.5–8.5 s, 8.5–10.5 s with the timeout at 10 s
/// (exception 10–10.5 s, main's clock restarted at 10.5 s), step A 10.5–12.5 s (count 3),
/// monitor at 12.5 s (12.5–13 s), steps A to 15, 17, 19 s, monitor at 19 s (19–19.5 s),
/// the tenth step A 19.5–21.5 s, in which the reset timeout fires again at 20.5 s (its
/// exception sequence 20.5–21 s); main ends at 21.5 s. Five exception runs: three for the
/// counter, two for the timeout.
///
/// rtseq: `Behaviour::Nothing` for both. Monitor at 6.1 s (exception 6.1–6.6 s), step A
/// 6–8 s, 8–10.6 s with the timeout at 10 s (exception 10–10.5 s; the step's poll at
/// 10.5 s fell due while held and is skipped), step A 10.6–12.6 s, monitor at 12.7 s,
/// steps A to 14.6, 16.6, 18.6 s, monitor at 18.7 s, the tenth step A 18.6–20.6 s; main
/// completes at 20.6 s. The timeout fires once (rtseq's fires once per run, and there is
/// no `resetTimeout` to re-arm it: reported as a missing concept), so four exception runs.
/// Deliberate differences: semantics item 1 (monitors at the owner's polls; the skipped
/// held poll) and item 6 (a timeout fires once per run).
#[test]
fn eeros_41_monitor_resume_and_timeout_resume_with_a_reset_timeout() {
    let r = run_40_41(true);
    let i = r.ids;
    let (m, to) = (Mon(rtseq::MonitorId::from_index(0)), Timeout(i.main));
    let want = Want::default()
        .go(0, i.main)
        .go(0, i.step_a)
        .done(2000, i.step_a)
        .again(2000, i.step_a)
        .done(4000, i.step_a)
        .again(4000, i.step_a)
        .done(6000, i.step_a)
        .again(6000, i.step_a)
        .exception(6100, i.e1, i.w1, m, true)
        .exception_done(6600, i.e1, i.w1)
        .done(8000, i.step_a)
        .again(8000, i.step_a)
        .exception(10000, i.e2, i.w2, to, true)
        .exception_done(10500, i.e2, i.w2)
        .done(10600, i.step_a)
        .again(10600, i.step_a)
        .done(12600, i.step_a)
        .again(12600, i.step_a)
        .exception(12700, i.e1, i.w1, m, false)
        .exception_done(13200, i.e1, i.w1)
        .done(14600, i.step_a)
        .again(14600, i.step_a)
        .done(16600, i.step_a)
        .again(16600, i.step_a)
        .done(18600, i.step_a)
        .again(18600, i.step_a)
        .exception(18700, i.e1, i.w1, m, false)
        .exception_done(19200, i.e1, i.w1)
        .done(20600, i.step_a)
        .done(20600, i.main);
    assert_trace(&r.trace, &want.0);
    assert_eq!(r.end_ms, Some(20600));
    assert_eq!(r.main_outcome, Some(Outcome::Completed));
    assert_eq!((r.exceptions, r.reset_timeout_asked), (4, vec![10500]));
}
