//! EEROS's own sequencer examples and tests, ported to rtseq: one test per EEROS program
//! or gtest case, on exact traces, so that anyone can see which EEROS behaviours rtseq
//! reproduces and where (and why) it differs.
//!
//! The EEROS sources are `examples/sequencer/SequencerTest{10..14,20..26}.cpp` and
//! `test/sequencer/SeqTest{1..4}.cpp` of eeros-project/eeros-framework; what EEROS does is
//! read off its implementation (`src/sequencer/BaseSequence.cpp`, `Sequence.cpp`,
//! `includes/eeros/sequencer/{Wait,Step,ConditionTimeout}.hpp`, at commit `e0e8358`), cited
//! by line as `BaseSequence.cpp:52`.
//!
//! How the ports map EEROS:
//!
//! * **Time, one to one.** EEROS's `Wait(1)` is `Wait::new(Duration::from_secs(1))`, its
//!   `setTimeoutTime(2.5)` is `SeqConfig::timeout` of 2.5 s. EEROS polls every 100 ms
//!   (`pollingTime(100)`, `BaseSequence.cpp:14`): every sequence and step here is configured
//!   with `polling(100 ms)`. The simulator ticks every 1 ms, as the firmware's heartbeat.
//! * **Behaviours.** EEROS's `SequenceProp::resume`, `abort`, `restart` are rtseq's
//!   `Behaviour::Nothing`, `AbortOwner`, `RestartOwner`.
//! * **Exception sequences.** EEROS runs one blocking, in the thread of the step whose poll
//!   saw the monitor fire (`BaseSequence.cpp:131`); rtseq runs it in its own lane with the
//!   owner as its caller, the owner and what it blocks held meanwhile (semantics item 3).
//! * **Return values.** EEROS's `int action()` and `getResult()` are, in rtseq, fields of the
//!   sequence or step object, read by its caller after `cx.step(&mut self.x)` /
//!   `cx.run(..)` (`Seq::body`), or written to the control system ([`World`]) where the
//!   EEROS test reads them after `sequencer.wait()`. EEROS's `-1` of a run that did not run
//!   its action is `Done::Skipped` or `Failure::Aborted`.
//!
//! The EEROS times in the comments are the ideal ones. EEROS measures with
//! `steady_clock` and compares strictly (`Wait.hpp:33`, `ConditionTimeout.hpp:18`), so a
//! real EEROS run is a few milliseconds later (its `usleep` loop drifts); rtseq's times
//! are exact.
//!
//! The differences these tests show come from rtseq's documented semantics
//! (`docs/semantics.md`, "item n" below):
//!
//! * the behaviour of a monitor or timeout with an exception sequence is applied by the
//!   tick after the exception sequence ended (item 3): 1 ms after EEROS's time;
//! * a poll of a step that fell due while the step was held by its caller's exception is
//!   skipped, not taken when the hold ends (item 1): a step that EEROS ends right after
//!   the exception (its exit condition was already true) ends one polling period later;
//! * a restarted sequence's steps are polled on the 100 ms grid of their polling class
//!   (item 1), so after a restart 1 ms late its waits end on the grid, 100 ms late;
//! * abort is sticky (item 4): an aborted action never goes on, where EEROS's goes on
//!   calling steps, which run if the monitor's condition has gone false; a sequence whose
//!   abort is requested begins nothing more, and the tick aborts it (item 8);
//! * monitors are evaluated by the tick at the owner's polling period (item 1), not inside
//!   every step's own run loop as in EEROS (`BaseSequence.cpp:37,52`); requests (abort)
//!   are applied by the next tick (item 8);
//! * steps are registered like sequences, under unique names (design-decisions, "every
//!   sequence and step is registered"); EEROS registers only `Sequence`s.
//!
//! What these EEROS programs use and rtseq has not: `resetTimeout()` of a running
//! sequence (examples 13, 22, 25; not needed, a timeout fires once per run, item 6), and a
//! behaviour changed at run time (`setTimeoutBehavior` from the exception sequence in
//! examples 14, 23, 26, ported as a restart limit; `Monitor::setBehavior` between the runs
//! of SeqTest3, ported as one monitor table per behaviour).

mod common;
use common::{show, tr};
use core::cell::{Cell, RefCell};
use rtseq::sim::Sim;
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Cause, Cx, Done, Duration, Entry, Error, Event, Failure, Monitor, MonitorId,
    Monitors, Outcome, Request, Requester, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step,
    Transition, Wait,
};

/// The control system: what EEROS's examples keep in globals (`count`, `eCount`, `limit`
/// of SeqTest3/4, the `static int count` of the exception sequences) or what its gtests
/// read after `sequencer.wait()` (`getResult()`).
#[derive(Default)]
struct World {
    /// SeqTest3/4's global `count`; SeqTest2's `SequenceB::count`.
    count: Cell<i32>,
    /// SeqTest3/4's global `eCount`.
    e_count: Cell<i32>,
    /// SeqTest3's global `limit`.
    limit: Cell<i32>,
    /// The value the EEROS main sequence's `action()` returned (its `getResult()`).
    result: Cell<Option<i32>>,
    /// Runs of the exception sequence (the examples' `static int count`).
    exceptions: Cell<u32>,
    /// What a gtest body read after each run: EEROS's `EXPECT_EQ` operands.
    seen: RefCell<Vec<Seen>>,
}

/// What a gtest body (a driver sequence) saw after running a sequence blocking.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Seen {
    done: Result<Done, Failure>,
    result: Option<i32>,
    count: i32,
    step_count: i32,
}

/// A sequencer of 16 with a trace ring of 256 (SeqTest2 makes 100 transitions in one
/// lane poll).
type Seqr = Sequencer<World, 16, 256>;

/// EEROS's default polling period (`BaseSequence.cpp:14`).
const POLL: Duration = Duration::from_millis(100);

fn cfg(name: &'static str) -> SeqConfig<World> {
    SeqConfig::new(name).polling(POLL)
}

fn wait_s(s: u64) -> Wait {
    Wait::new(Duration::from_secs(s))
}

// ---- trace helpers -------------------------------------------------------------------

fn start(ms: u64, id: SeqId) -> Transition {
    tr(ms, id, Idle, Running, Cause::Start)
}

fn done(ms: u64, id: SeqId) -> Transition {
    tr(ms, id, Running, Terminated, Cause::Completed)
}

/// `n` back-to-back runs of step `id`: the first begins at `times[0]` from state `from`,
/// run `i` ends at `times[i]` and the next begins at once.
fn chain(id: SeqId, from: RunningState, times: &[u64]) -> Vec<Transition> {
    let mut v = vec![tr(times[0], id, from, Running, Cause::Start)];
    for (i, &t) in times.iter().enumerate().skip(1) {
        v.push(done(t, id));
        if i + 1 < times.len() {
            v.push(tr(t, id, Terminated, Running, Cause::Start));
        }
    }
    v
}

/// `ids` aborted at `ms` by `cause`, in this order (innermost first).
fn aborted(ms: u64, ids: &[SeqId], cause: Cause) -> Vec<Transition> {
    ids.iter()
        .flat_map(|&id| {
            [
                tr(ms, id, Running, Aborting, cause),
                tr(ms, id, Aborting, Aborted, cause),
            ]
        })
        .collect()
}

/// `id` restarted at `ms` by `cause`.
fn restarted(ms: u64, id: SeqId, cause: Cause) -> Vec<Transition> {
    vec![
        tr(ms, id, Running, Restarting, cause),
        tr(ms, id, Restarting, Running, Cause::Restart),
    ]
}

/// The exception sequence `e` (first run from `from`) with its 3 s wait `w`, from `ms`.
fn exception(ms: u64, e: SeqId, w: SeqId, from: RunningState, cause: Cause) -> Vec<Transition> {
    vec![
        tr(ms, e, from, Running, cause),
        tr(ms, w, from, Running, Cause::Start),
        done(ms + 3000, w),
        done(ms + 3000, e),
    ]
}

fn assert_trace(got: &[Transition], want: &[Transition]) {
    assert_eq!(got, want, "\n got:\n{}\nwant:\n{}", show(got), show(want));
}

// ---- the examples' sequences ---------------------------------------------------------

/// `for (int i = 0; i < n; i++) step(1);` — EEROS ignores the step's return value, and so
/// does the port (an aborted step does not end the loop; abort of the caller does, item 4).
struct Waits {
    step: Seq<Wait>,
    n: u32,
}
impl Sequence<World> for Waits {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        for _ in 0..self.n {
            let _ = cx.step(&mut self.step).await;
        }
        Ok(())
    }
}

/// Examples 20–26's main sequence: three waits of 1 s, the blocking sequence S (five waits
/// of 1 s), three waits of 1 s. EEROS ignores `seqS()`'s return value: so does the port,
/// which goes on after an aborted S as EEROS does.
struct MainWithS {
    step_a: Seq<Wait>,
    seq_s: Seq<Waits>,
}
impl Sequence<World> for MainWithS {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        for _ in 0..3 {
            let _ = cx.step(&mut self.step_a).await;
        }
        let _ = cx.run(&mut self.seq_s).await;
        for _ in 0..3 {
            let _ = cx.step(&mut self.step_a).await;
        }
        Ok(())
    }
}

/// The examples' `ExceptionSeq`: `wait(3)`, counted in [`World::exceptions`].
struct ExceptionSeq {
    wait: Seq<Wait>,
}
impl Sequence<World> for ExceptionSeq {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.wait).await;
        let w = cx.control();
        w.exceptions.set(w.exceptions.get() + 1);
        Ok(())
    }
}

/// The timeout of the examples: `setTimeoutTime`, `setTimeoutBehavior`,
/// `setTimeoutExceptionSequence`.
#[derive(Clone, Copy)]
struct Timeout {
    ms: u64,
    behaviour: Behaviour,
    exception: bool,
}

fn arm(c: SeqConfig<World>, t: Option<Timeout>, e: SeqId) -> SeqConfig<World> {
    match t {
        None => c,
        Some(t) => {
            // Examples 14, 23, 26: the exception sequence switches its owner's timeout
            // behaviour to abort at its third run (`if (count++ == 2)
            // caller->setTimeoutBehavior(SequenceProp::abort)`): two restarts, then an
            // abort, which is rtseq's restart limit of 2 (rtseq has no run-time change of
            // a behaviour).
            let c = c
                .timeout(Duration::from_millis(t.ms))
                .timeout_behaviour(t.behaviour)
                .timeout_restart_limit(2);
            if t.exception {
                c.timeout_exception(e)
            } else {
                c
            }
        }
    }
}

/// Ids of examples 10–14: step A, the exception sequence's wait, the exception sequence,
/// the main sequence.
struct Ids1x {
    a: SeqId,
    w: SeqId,
    e: SeqId,
    main: SeqId,
}

/// Examples 10–14: the main sequence waits 1 s five times, with the timeout `t`. Returns
/// the trace, the ids, the end time, the main sequence's counters and the exception
/// sequence's runs.
fn example_1x(t: Option<Timeout>) -> (Vec<Transition>, Ids1x, u64, rtseq::Counters, u32) {
    let seq = Seqr::new();
    let world = World::default();
    let step_a = seq.add(cfg("step A"), wait_s(1)).unwrap();
    let wait = seq.add(cfg("wait"), wait_s(3)).unwrap();
    let e = seq
        .add(cfg("exception sequence"), ExceptionSeq { wait })
        .unwrap();
    let ids = Ids1x {
        a: step_a.id(),
        w: SeqId::from_index(1),
        e: e.id(),
        main: SeqId::from_index(3),
    };
    let main = seq
        .add(
            arm(cfg("Main Sequence"), t, ids.e),
            Waits { step: step_a, n: 5 },
        )
        .unwrap();
    assert_eq!(main.id(), ids.main);
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(main);
    sim.lane(e);
    sim.start(ids.main).unwrap();
    let end = sim.run_until_idle(Duration::from_secs(60)).unwrap();
    assert_eq!(sim.lost(), 0);
    let counters = sim.handle(ids.main).unwrap().counters();
    let trace = sim.take_trace();
    drop(sim);
    (
        trace,
        ids,
        end.as_ticks() / 1000,
        counters,
        world.exceptions.get(),
    )
}

/// EEROS `examples/sequencer/SequencerTest10.cpp`: the main sequence (non-blocking, its own
/// thread) calls the step `Wait stepA` five times with 1 s; `sequencer.wait()` returns
/// when it has ended. EEROS: step A runs 0–1, 1–2, …, 4–5 s, the main sequence ends at
/// 5 s. rtseq: the same, exactly.
#[test]
fn sequencer_test_10_five_waits_of_one_second_end_at_5_s() {
    let (trace, i, end, c, _) = example_1x(None);
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000, 3000, 4000, 5000]));
    want.push(done(5000, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 5000);
    assert_eq!((c.runs, c.completed, c.exceptions), (1, 1, 0));
}

/// EEROS `examples/sequencer/SequencerTest11.cpp`: as example 10, with a 2.5 s timeout
/// (`setTimeoutTime(2.5)`, behaviour abort, no exception sequence). EEROS: the timeout
/// monitor of the main sequence is checked in step A's poll loop (the step's caller
/// stack holds the main sequence, `BaseSequence.cpp:15-18,88`); at 2.5 s (third wait) it
/// fires, puts the main sequence and the step into `aborting` (`:138`, `:104`); the main
/// sequence's action goes on calling step A twice, and each is aborted before its action
/// (the condition is still true, `:37-38`); the main sequence ends at 2.5 s. rtseq: the
/// step and the main sequence are aborted at 2.5 s, innermost first, and the action goes
/// no further (item 4); no step runs after the abort in either.
#[test]
fn sequencer_test_11_timeout_aborts_main_and_its_wait_at_2_5_s() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::AbortOwner,
        exception: false,
    };
    let (trace, i, end, c, _) = example_1x(Some(t));
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000]));
    want.push(tr(2000, i.a, Terminated, Running, Cause::Start));
    want.extend(aborted(2500, &[i.a, i.main], Cause::Timeout(i.main)));
    assert_trace(&trace, &want);
    assert_eq!(end, 2500);
    assert_eq!((c.runs, c.aborts, c.exceptions), (1, 1, 1));
}

/// EEROS `examples/sequencer/SequencerTest12.cpp`: as example 11, with a timeout exception
/// sequence that waits 3 s. EEROS: at 2.5 s the timeout fires in step A's poll; the
/// exception sequence runs blocking in that thread, 2.5–5.5 s (`BaseSequence.cpp:131`);
/// then the main sequence and the step are aborted (5.5 s). rtseq: the exception sequence
/// runs 2.5–5.5 s in its lane while the main sequence and its step are held; the abort
/// is applied by the next tick, 5.501 s (item 3).
#[test]
fn sequencer_test_12_timeout_exception_sequence_then_abort() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::AbortOwner,
        exception: true,
    };
    let (trace, i, end, c, runs) = example_1x(Some(t));
    let cause = Cause::Timeout(i.main);
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000]));
    want.push(tr(2000, i.a, Terminated, Running, Cause::Start));
    want.extend(exception(2500, i.e, i.w, Idle, cause));
    want.extend(aborted(5501, &[i.a, i.main], cause));
    assert_trace(&trace, &want);
    assert_eq!(end, 5501);
    assert_eq!((c.aborts, c.exceptions, runs), (1, 1, 1));
}

/// EEROS `examples/sequencer/SequencerTest13.cpp`: as example 12, behaviour resume; the
/// exception sequence resets its owner's timeout after its wait (`caller->resetTimeout()`).
/// EEROS: exception 2.5–5.5 s; the main sequence resumes (`BaseSequence.cpp:137`) and,
/// in the same poll, step A's exit condition (3.5 s waited) ends the third wait at 5.5 s
/// (`:54`); waits 4 and 5 run 5.5–7.5 s; the timeout, reset at 5.5 s, would fire at 8 s:
/// the main sequence completes at 7.5 s. Without the reset the still-true condition would
/// fire again at the next poll. rtseq: a timeout fires once per run (item 6), so the port
/// needs no reset (rtseq has none: a missing concept, not needed here). The third wait's
/// poll at 5.5 s fell due while it was held and is skipped (item 1): it ends at 5.6 s,
/// the main sequence completes at 7.6 s.
#[test]
fn sequencer_test_13_timeout_exception_sequence_then_resume() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::Nothing,
        exception: true,
    };
    let (trace, i, end, c, runs) = example_1x(Some(t));
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000]));
    want.push(tr(2000, i.a, Terminated, Running, Cause::Start));
    want.extend(exception(2500, i.e, i.w, Idle, Cause::Timeout(i.main)));
    // The third wait, running since 2 s, ends at 5.6 s; waits 4 and 5 follow.
    want.extend(
        chain(i.a, Running, &[5600, 5600, 6600, 7600])
            .into_iter()
            .skip(1),
    );
    want.push(done(7600, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 7600);
    assert_eq!((c.completed, c.aborts, c.exceptions, runs), (1, 0, 1, 1));
}

/// EEROS `examples/sequencer/SequencerTest14.cpp`: as example 12, behaviour restart; the
/// exception sequence switches the behaviour to abort at its third run. EEROS: timeout at
/// 2.5 s, exception 2.5–5.5 s, restart at 5.5 s (step A aborted, the remaining steps of
/// the old run aborted before their action, `BaseSequence.cpp:37,139`, then `:65-70`: a
/// fresh timeout); timeout at 8.0 s, exception 8.0–11.0 s, restart; timeout at 13.5 s,
/// exception 13.5–16.5 s, abort at 16.5 s. rtseq: `timeout_restart_limit(2)` (two
/// restarts, then the abort). Each behaviour comes 1 ms after the exception's end
/// (item 3), and the restarted run's waits end on the 100 ms grid of the polling class
/// (item 1): restart at 5.501 s, waits end at 6.6 and 7.6 s, timeout 2.5 s after the
/// restart, at the poll of 8.1 s; exception 8.1–11.1 s, restart 11.101 s; timeout at
/// 13.7 s, exception 13.7–16.7 s, abort at 16.701 s.
#[test]
fn sequencer_test_14_timeout_restarts_twice_then_aborts() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::RestartOwner,
        exception: true,
    };
    let (trace, i, end, c, runs) = example_1x(Some(t));
    let cause = Cause::Timeout(i.main);
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000]));
    want.push(tr(2000, i.a, Terminated, Running, Cause::Start));
    want.extend(exception(2500, i.e, i.w, Idle, cause));
    for (restart, fired) in [(5501, 8100), (11101, 13700)] {
        want.extend(aborted(restart, &[i.a], cause));
        want.extend(restarted(restart, i.main, cause));
        want.extend(chain(
            i.a,
            Aborted,
            &[restart, restart + 1099, restart + 2099],
        ));
        want.push(tr(restart + 2099, i.a, Terminated, Running, Cause::Start));
        want.extend(exception(fired, i.e, i.w, Terminated, cause));
    }
    want.extend(aborted(16701, &[i.a, i.main], cause));
    assert_trace(&trace, &want);
    assert_eq!(end, 16701);
    assert_eq!((c.runs, c.restarts, c.aborts, runs), (1, 2, 1, 3));
}

/// Ids of examples 20–26.
struct Ids2x {
    a: SeqId,
    b: SeqId,
    w: SeqId,
    e: SeqId,
    s: SeqId,
    main: SeqId,
}

/// Examples 20–26: main = 3 × wait A, blocking S (5 × wait B), 3 × wait A; the timeout
/// `t` on the main sequence (`on_main`) or on S.
fn example_2x(
    on_main: bool,
    t: Option<Timeout>,
) -> (Vec<Transition>, Ids2x, u64, [rtseq::Counters; 2], u32) {
    let seq = Seqr::new();
    let world = World::default();
    let step_a = seq.add(cfg("step A"), wait_s(1)).unwrap();
    let step_b = seq.add(cfg("step B"), wait_s(1)).unwrap();
    let wait = seq.add(cfg("wait"), wait_s(3)).unwrap();
    let e = seq
        .add(cfg("exception sequence"), ExceptionSeq { wait })
        .unwrap();
    let ids = Ids2x {
        a: step_a.id(),
        b: step_b.id(),
        w: SeqId::from_index(2),
        e: e.id(),
        s: SeqId::from_index(4),
        main: SeqId::from_index(5),
    };
    let (t_main, t_s) = if on_main { (t, None) } else { (None, t) };
    let seq_s = seq
        .add(arm(cfg("seq S"), t_s, ids.e), Waits { step: step_b, n: 5 })
        .unwrap();
    let main = seq
        .add(
            arm(cfg("Main Sequence"), t_main, ids.e),
            MainWithS { step_a, seq_s },
        )
        .unwrap();
    assert_eq!(main.id(), ids.main);
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(main);
    sim.lane(e);
    sim.start(ids.main).unwrap();
    let end = sim.run_until_idle(Duration::from_secs(60)).unwrap();
    assert_eq!(sim.lost(), 0);
    let counters = [ids.main, ids.s].map(|id| sim.handle(id).unwrap().counters());
    let trace = sim.take_trace();
    drop(sim);
    (
        trace,
        ids,
        end.as_ticks() / 1000,
        counters,
        world.exceptions.get(),
    )
}

/// The start of examples 20–26 up to S's third wait (B from 5 s): waits A at 0, 1, 2 s,
/// S and its waits B at 3, 4 s.
fn until_b3(i: &Ids2x) -> Vec<Transition> {
    let mut want = vec![start(0, i.main)];
    want.extend(chain(i.a, Idle, &[0, 1000, 2000, 3000]));
    want.push(start(3000, i.s));
    want.extend(chain(i.b, Idle, &[3000, 4000, 5000]));
    want.push(tr(5000, i.b, Terminated, Running, Cause::Start));
    want
}

/// EEROS `examples/sequencer/SequencerTest20.cpp`: main sequence = wait A three times
/// (1 s each), the blocking sequence S (wait B five times), wait A three times. EEROS:
/// A 0–3 s, S 3–8 s, A 8–11 s; the main sequence ends at 11 s. rtseq: the same, exactly.
#[test]
fn sequencer_test_20_blocking_sequence_between_steps_ends_at_11_s() {
    let (trace, i, end, [cm, cs], _) = example_2x(true, None);
    let mut want = until_b3(&i);
    want.extend(
        chain(i.b, Running, &[5000, 6000, 7000, 8000])
            .into_iter()
            .skip(1),
    );
    want.push(done(8000, i.s));
    want.extend(chain(i.a, Terminated, &[8000, 9000, 10000, 11000]));
    want.push(done(11000, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 11000);
    assert_eq!((cm.completed, cs.completed), (1, 1));
}

/// EEROS `examples/sequencer/SequencerTest21.cpp`: example 20 with a 5.5 s timeout on the
/// main sequence, exception sequence (wait 3 s), behaviour abort. EEROS: the main
/// sequence's timeout is checked in wait B's poll (B's caller stack holds S and the main
/// sequence, S being blocking) and fires at 5.5 s; exception 5.5–8.5 s; then wait B, S and
/// the main sequence are put into `aborting` (`BaseSequence.cpp:99-107`), the rest of S's
/// and of the main sequence's steps are aborted before their action; all end at 8.5 s.
/// rtseq: the same three aborted at 8.501 s (item 3), innermost first (item 4).
#[test]
fn sequencer_test_21_main_timeout_in_blocking_sequence_aborts_all_three() {
    let t = Timeout {
        ms: 5500,
        behaviour: Behaviour::AbortOwner,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(true, Some(t));
    let cause = Cause::Timeout(i.main);
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, cause));
    want.extend(aborted(8501, &[i.b, i.s, i.main], cause));
    assert_trace(&trace, &want);
    assert_eq!(end, 8501);
    assert_eq!((cm.aborts, cm.exceptions, cs.aborts, runs), (1, 1, 1, 1));
}

/// EEROS `examples/sequencer/SequencerTest22.cpp`: example 21 with behaviour resume, the
/// exception sequence resetting the main sequence's timeout. EEROS: exception 5.5–8.5 s,
/// the third wait B ends at 8.5 s in the poll that resumed (`BaseSequence.cpp:137,54`),
/// B 8.5–10.5 s, S ends at 10.5 s, A 10.5–13.5 s, the main sequence completes at 13.5 s
/// (the reset timeout would fire at 14 s). rtseq: no reset needed (item 6); the third
/// wait B's poll at 8.5 s was due while held and is skipped (item 1): every later time
/// is 100 ms later, the main sequence completes at 13.6 s.
#[test]
fn sequencer_test_22_main_timeout_resume_in_blocking_sequence() {
    let t = Timeout {
        ms: 5500,
        behaviour: Behaviour::Nothing,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(true, Some(t));
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, Cause::Timeout(i.main)));
    want.extend(
        chain(i.b, Running, &[8600, 8600, 9600, 10600])
            .into_iter()
            .skip(1),
    );
    want.push(done(10600, i.s));
    want.extend(chain(i.a, Terminated, &[10600, 11600, 12600, 13600]));
    want.push(done(13600, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 13600);
    assert_eq!(
        (cm.completed, cm.exceptions, cs.completed, runs),
        (1, 1, 1, 1)
    );
}

/// EEROS `examples/sequencer/SequencerTest23.cpp`: example 21 with behaviour restart, the
/// third exception switching to abort. EEROS: timeout 5.5 s, exception 5.5–8.5 s, restart
/// of the main sequence at 8.5 s (B and S aborted); A 8.5–11.5 s, S from 11.5 s, timeout at
/// 14.0 s, exception 14.0–17.0 s, restart at 17.0 s; timeout at 22.5 s, exception
/// 22.5–25.5 s, abort at 25.5 s. rtseq (restart limit 2, see [`arm`]): each behaviour 1 ms
/// after the exception (item 3), waits on the grid after a restart (item 1): restart at
/// 8.501 s, A ends 9.6, 10.6, 11.6 s, timeout at 14.1 s, exception to 17.1 s, restart at
/// 17.101 s, timeout at 22.7 s, exception to 25.7 s, abort at 25.701 s.
#[test]
fn sequencer_test_23_main_timeout_restart_in_blocking_sequence() {
    let t = Timeout {
        ms: 5500,
        behaviour: Behaviour::RestartOwner,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(true, Some(t));
    let cause = Cause::Timeout(i.main);
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, cause));
    for (restart, fired) in [(8501, 14100), (17101, 22700)] {
        want.extend(aborted(restart, &[i.b, i.s], cause));
        want.extend(restarted(restart, i.main, cause));
        let a = [restart, restart + 1099, restart + 2099, restart + 3099];
        want.extend(chain(i.a, Terminated, &a));
        want.push(tr(a[3], i.s, Aborted, Running, Cause::Start));
        want.extend(chain(i.b, Aborted, &[a[3], a[3] + 1000, a[3] + 2000]));
        want.push(tr(a[3] + 2000, i.b, Terminated, Running, Cause::Start));
        want.extend(exception(fired, i.e, i.w, Terminated, cause));
    }
    want.extend(aborted(25701, &[i.b, i.s, i.main], cause));
    assert_trace(&trace, &want);
    assert_eq!(end, 25701);
    assert_eq!((cm.restarts, cm.aborts, cs.aborts, runs), (2, 1, 3, 3));
}

/// EEROS `examples/sequencer/SequencerTest24.cpp`: example 20 with a 2.5 s timeout on S
/// (exception sequence waiting 3 s, behaviour abort), none on the main sequence. EEROS: S
/// starts at 3 s, its timeout fires at 5.5 s in wait B's poll; exception 5.5–8.5 s; B and
/// S are aborted (the caller stack walk stops at S, whose monitor fired,
/// `BaseSequence.cpp:101,107`), `seqS()` returns to the main sequence, which ignores its
/// result and waits A 8.5–11.5 s: completed at 11.5 s. rtseq: S and B aborted at 8.501 s
/// (item 3); the main sequence gets `Err(Failure::Aborted)` from `cx.run`, ignores it as
/// EEROS does, and its waits end on the grid (item 1): 9.6, 10.6, 11.6 s.
#[test]
fn sequencer_test_24_sequence_timeout_aborts_only_that_sequence() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::AbortOwner,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(false, Some(t));
    let cause = Cause::Timeout(i.s);
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, cause));
    want.extend(aborted(8501, &[i.b, i.s], cause));
    want.extend(chain(i.a, Terminated, &[8501, 9600, 10600, 11600]));
    want.push(done(11600, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 11600);
    assert_eq!((cm.completed, cs.aborts, cs.exceptions, runs), (1, 1, 1, 1));
}

/// EEROS `examples/sequencer/SequencerTest25.cpp`: example 24 with behaviour resume, the
/// exception sequence resetting S's timeout. EEROS: exception 5.5–8.5 s; the third wait B
/// ends at 8.5 s, B 8.5–10.5 s, S completes at 10.5 s (its reset timeout would fire at
/// 11 s), A 10.5–13.5 s: completed at 13.5 s. rtseq: no reset needed (item 6); the wait's
/// poll at 8.5 s was held and is skipped (item 1): everything 100 ms later, 13.6 s.
#[test]
fn sequencer_test_25_sequence_timeout_resume() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::Nothing,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(false, Some(t));
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, Cause::Timeout(i.s)));
    want.extend(
        chain(i.b, Running, &[8600, 8600, 9600, 10600])
            .into_iter()
            .skip(1),
    );
    want.push(done(10600, i.s));
    want.extend(chain(i.a, Terminated, &[10600, 11600, 12600, 13600]));
    want.push(done(13600, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 13600);
    assert_eq!(
        (cm.completed, cs.completed, cs.exceptions, runs),
        (1, 1, 1, 1)
    );
}

/// EEROS `examples/sequencer/SequencerTest26.cpp`: example 24 with behaviour restart, the
/// third exception switching to abort. EEROS: S's timeout at 5.5 s, exception 5.5–8.5 s,
/// S restarts at 8.5 s (fresh timeout), timeout at 11.0 s, exception 11.0–14.0 s, restart
/// at 14.0 s, timeout at 16.5 s, exception 16.5–19.5 s, S aborted at 19.5 s; the main
/// sequence waits A 19.5–22.5 s and completes. rtseq (restart limit 2, see [`arm`]):
/// restart at 8.501 s, the restarted S's waits on the grid (item 1), timeout at the poll
/// of 11.1 s, exception to 14.1 s, restart at 14.101 s, timeout at 16.7 s, exception to
/// 19.7 s, abort at 19.701 s; A ends 20.8, 21.8, 22.8 s.
#[test]
fn sequencer_test_26_sequence_timeout_restart_then_abort_main_goes_on() {
    let t = Timeout {
        ms: 2500,
        behaviour: Behaviour::RestartOwner,
        exception: true,
    };
    let (trace, i, end, [cm, cs], runs) = example_2x(false, Some(t));
    let cause = Cause::Timeout(i.s);
    let mut want = until_b3(&i);
    want.extend(exception(5500, i.e, i.w, Idle, cause));
    for (restart, fired) in [(8501, 11100), (14101, 16700)] {
        want.extend(aborted(restart, &[i.b], cause));
        want.extend(restarted(restart, i.s, cause));
        want.extend(chain(
            i.b,
            Aborted,
            &[restart, restart + 1099, restart + 2099],
        ));
        want.push(tr(restart + 2099, i.b, Terminated, Running, Cause::Start));
        want.extend(exception(fired, i.e, i.w, Terminated, cause));
    }
    want.extend(aborted(19701, &[i.b, i.s], cause));
    want.extend(chain(i.a, Terminated, &[19701, 20800, 21800, 22800]));
    want.push(done(22800, i.main));
    assert_trace(&trace, &want);
    assert_eq!(end, 22800);
    assert_eq!((cm.completed, cs.restarts, cs.aborts, runs), (1, 2, 1, 3));
}

// ---- SeqTest1 and SeqTest2 -----------------------------------------------------------

/// EEROS's `int` return of a blocking start: the value of the action when it ran, else
/// the `-1` `BaseSequence::action` starts with (`BaseSequence.cpp:24`).
fn returned(r: Result<Done, Failure>, value: i32) -> i32 {
    if r == Ok(Done::Completed) {
        value
    } else {
        -1
    }
}

/// SeqTest1/2's `Step1`: `action() {count++; return count;}`. Its return value is its
/// `count`, which the caller reads after the step (`Seq::body`). SeqTest1's
/// `operator()(int val) {count += val; ...}` is the caller's `body_mut().count += val`.
#[derive(Default)]
struct Step1 {
    count: i32,
}
impl Step<World> for Step1 {
    fn action(&mut self, _cx: &Cx<'_, World>) -> Result<(), Failure> {
        self.count += 1;
        Ok(())
    }
}

/// SeqTest1's and SeqTest2's `MainSequence`: `count = step()` `n` times, return `count`
/// (into [`World::result`]); SeqTest2's raises its abort when `count == 3` (EEROS:
/// `kill(getpid(), SIGINT)`, whose handler calls `Sequencer::abort()`).
struct Stepping {
    step: Seq<Step1>,
    n: u32,
    abort_at_3: bool,
}
impl Sequence<World> for Stepping {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let mut count = 0;
        for _ in 0..self.n {
            let r = cx.step(&mut self.step).await;
            count = returned(r, self.step.body().count);
            if self.abort_at_3 && count == 3 {
                cx.sequence_by_id(cx.id())
                    .ok_or(Error::UnknownSequence(cx.id()))?
                    .abort()?;
            }
        }
        cx.control().result.set(Some(count));
        Ok(())
    }
}

/// EEROS `test/sequencer/SeqTest1.cpp`, `TEST(seqTest1, stepping)`: the main sequence
/// calls `Step1` five times (`count = step()`), each returning its incremented count, and
/// returns the last; `EXPECT_EQ(mainSeq.getResult(), 5)`. EEROS: the steps end at once
/// (default exit condition true, `BaseSequence.cpp:158`). rtseq: the same, all at 0 ms in
/// one run of the lane; the result 5 is the step's `count` read after the fifth
/// `cx.step`, and the step's counters say five runs.
#[test]
fn seq_test_1_stepping_returns_the_fifth_step_value() {
    let seq = Seqr::new();
    let world = World::default();
    let step = seq.add(cfg("step"), Step1::default()).unwrap();
    let si = step.id();
    let main = Stepping {
        step,
        n: 5,
        abort_at_3: false,
    };
    let main = seq.add(cfg("Main Sequence"), main).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_secs(1)),
        Some(rtseq::Instant::from_ticks(0))
    );
    let mut want = vec![start(0, mi)];
    want.extend(chain(si, Idle, &[0; 6]));
    want.push(done(0, mi));
    assert_trace(sim.trace(), &want);
    assert_eq!(world.result.get(), Some(5));
    let c = sim.handle(si).unwrap().counters();
    assert_eq!((c.runs, c.completed), (5, 5));
}

/// EEROS `test/sequencer/SeqTest1.cpp`, `TEST(seqTest1, list)`: registration. EEROS: a
/// sequence without a name throws "all sequences must have a name"; one is registered
/// with id 0; `getSequenceByName("Main")` is null, `"Main Sequence"` finds it; a second
/// "Main Sequence" throws "all sequences must have different names" and is not
/// registered; "Main Sequence1" gets id 1. rtseq: the same through `register`
/// (`Error::EmptyName`, `Error::DuplicateName` naming the holder), `sequence_by_name`,
/// `sequence_by_id`, `len`. One difference (design-decisions, "every sequence and step is
/// registered"): EEROS registers only `Sequence`s, rtseq steps too, so a step counts in
/// `len` and its name must be unique: EEROS's two `MainSequence`s each have a step named
/// "step", rtseq's second "step" is a `DuplicateName`.
#[test]
fn seq_test_1_list_registers_names_and_ids() {
    let seq = Seqr::new();
    assert_eq!(seq.len(), 0);
    assert_eq!(seq.register(cfg("")), Err(Error::EmptyName));
    let main = seq.register(cfg("Main Sequence")).unwrap();
    assert_eq!(seq.len(), 1);
    assert!(seq.sequence_by_name("Main").is_none());
    assert_eq!(
        seq.sequence_by_name("Main Sequence").map(|h| h.id()),
        Some(main)
    );
    assert_eq!(
        seq.register(cfg("Main Sequence")),
        Err(Error::DuplicateName(main))
    );
    assert_eq!(seq.len(), 1);
    let main1 = seq.register(cfg("Main Sequence1")).unwrap();
    assert_eq!(seq.len(), 2);
    assert_eq!(
        seq.sequence_by_id(SeqId::from_index(0)).map(|h| h.id()),
        Some(main)
    );
    assert_eq!(
        seq.sequence_by_id(SeqId::from_index(1)).map(|h| h.id()),
        Some(main1)
    );
    assert_eq!(
        seq.sequence_by_id(main1).map(|h| h.name()),
        Some("Main Sequence1")
    );
    // The difference: steps are registered, under unique names.
    let step = seq.add(cfg("step"), Step1::default()).unwrap();
    assert_eq!(seq.len(), 3);
    assert_eq!(
        seq.add(cfg("step"), Step1::default()).map(|s| s.id()),
        Err(Error::DuplicateName(step.id()))
    );
    assert_eq!(seq.len(), 3);
}

/// SeqTest1's `SequenceA`: `action() {return step(count);}` with a parameter `count`
/// (100, or what `operator()(int val)` set) that the step adds to its own count.
struct SequenceA {
    step: Seq<Step1>,
    count: i32,
    result: Option<i32>,
}
impl Sequence<World> for SequenceA {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        self.step.body_mut().count += self.count;
        let r = cx.step(&mut self.step).await;
        self.result = Some(returned(r, self.step.body().count));
        Ok(())
    }
}

/// SeqTest1's `SequenceB`: `action() {return 20;}`, never started.
struct SequenceB;
impl Sequence<World> for SequenceB {
    async fn action(&mut self, _cx: &Cx<'_, World>) -> Result<(), Failure> {
        Ok(())
    }
}

/// EEROS `test/sequencer/SeqTest1.cpp`, `TEST(seqTest1, waiting)`: the main sequence
/// (id 0), `seqA` (blocking, caller main, id 1) and `seqB` (non-blocking, caller main,
/// id 2) are created; only the main sequence runs; `sequencer.wait()` returns when it
/// has ended, result 5. rtseq: the three registered first (ids 0, 1, 2, by
/// `register` then `bind`, so their steps come after), the main sequence run in its lane,
/// result 5; `seqA` and `seqB` never ran. EEROS's list has 3 entries, rtseq's 5 (the
/// steps of the main sequence and of `seqA` are registered, see the `list` port).
#[test]
fn seq_test_1_waiting_runs_only_the_started_sequence() {
    let seq = Seqr::new();
    let world = World::default();
    let ids = ["Main Sequence", "seqA", "seqB"].map(|n| seq.register(cfg(n)).unwrap());
    assert_eq!(ids.map(|id| id.index()), [0, 1, 2]);
    let step = seq.add(cfg("step"), Step1::default()).unwrap();
    let si = step.id();
    let a_step = seq.add(cfg("step of seqA"), Step1::default()).unwrap();
    let main = Stepping {
        step,
        n: 5,
        abort_at_3: false,
    };
    let main = seq.bind(ids[0], main).unwrap();
    let seq_a = SequenceA {
        step: a_step,
        count: 100,
        result: None,
    };
    let _seq_a = seq.bind(ids[1], seq_a).unwrap();
    let seq_b = seq.bind(ids[2], SequenceB).unwrap();
    assert_eq!(seq.len(), 5);
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(main);
    sim.lane(seq_b);
    sim.start(ids[0]).unwrap();
    sim.run_until_idle(Duration::from_secs(1)).unwrap();
    let mut want = vec![start(0, ids[0])];
    want.extend(chain(si, Idle, &[0; 6]));
    want.push(done(0, ids[0]));
    assert_trace(sim.trace(), &want);
    assert_eq!(world.result.get(), Some(5));
    for id in &ids[1..] {
        let h = sim.handle(*id).unwrap();
        assert_eq!((h.state(), h.counters().runs), (Idle, 0));
    }
}

/// SeqTest1's and SeqTest2's gtest bodies, as a sequence: run the sequence blocking
/// (EEROS: start it, `sequencer.wait()`), note what the `EXPECT_EQ`s read, set the
/// parameter of the second run (EEROS: `seqA(1000)`, or `s.count = 5`), run it again.
struct GTest<S> {
    s: Seq<S>,
    read: fn(&S) -> (Option<i32>, i32, i32),
    set: fn(&mut S),
}
impl<S: Sequence<World>> Sequence<World> for GTest<S> {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        for second in [false, true] {
            if second {
                (self.set)(self.s.body_mut());
            }
            let done = cx.run(&mut self.s).await;
            let (result, count, step_count) = (self.read)(self.s.body());
            cx.control().seen.borrow_mut().push(Seen {
                done,
                result,
                count,
                step_count,
            });
        }
        Ok(())
    }
}

/// EEROS `test/sequencer/SeqTest1.cpp`, `TEST(seqTest1, params)`: `seqA()` runs with its
/// parameter 100: the step's count becomes 100 + 1, the result 101, `seqA.count` stays
/// 100; `seqA(1000)` sets the parameter and runs again: the step's count 101 + 1000 + 1
/// = 1102, the result 1102, `seqA.count` 1000. rtseq: the gtest body is a sequence that
/// runs `seqA` blocking twice, setting the parameter through `body_mut` between the runs
/// and reading the result and both counts through `body`: the same values. All at 0 ms.
#[test]
fn seq_test_1_params_reach_the_step_and_the_result() {
    let seq = Seqr::new();
    let world = World::default();
    let step = seq.add(cfg("step"), Step1::default()).unwrap();
    let si = step.id();
    let seq_a = SequenceA {
        step,
        count: 100,
        result: None,
    };
    let seq_a = seq.add(cfg("seqA"), seq_a).unwrap();
    let ai = seq_a.id();
    let gtest = GTest {
        s: seq_a,
        read: |a: &SequenceA| (a.result, a.count, a.step.body().count),
        set: |a| a.count = 1000,
    };
    let gtest = seq.add(cfg("gtest"), gtest).unwrap();
    let gi = gtest.id();
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(gtest);
    sim.start(gi).unwrap();
    sim.run_until_idle(Duration::from_secs(1)).unwrap();
    let mut want = vec![start(0, gi), start(0, ai)];
    want.extend(chain(si, Idle, &[0, 0]));
    want.push(done(0, ai));
    want.push(tr(0, ai, Terminated, Running, Cause::Start));
    want.extend(chain(si, Terminated, &[0, 0]));
    want.extend([done(0, ai), done(0, gi)]);
    assert_trace(sim.trace(), &want);
    let ok = Ok(Done::Completed);
    assert_eq!(
        *world.seen.borrow(),
        [
            Seen {
                done: ok,
                result: Some(101),
                count: 100,
                step_count: 101
            },
            Seen {
                done: ok,
                result: Some(1102),
                count: 1000,
                step_count: 1102
            },
        ]
    );
}

/// EEROS `test/sequencer/SeqTest2.cpp`, `TEST(seqTest2, aborting)`: the main sequence
/// calls `Step1` up to 50 times; when a step returns 3 it sends itself SIGINT, whose
/// handler calls `Sequencer::abort()` (sets the abort condition of every registered
/// sequence, `Sequencer.cpp:72-78`). EEROS: the fourth step checks its callers' monitors
/// before its action (`BaseSequence.cpp:37`), the main sequence's abort monitor fires,
/// the step is aborted and returns -1, and so are steps 5 to 50: `getResult() == -1`.
/// rtseq: the main sequence requests its own abort after the third step. A sequence whose
/// abort is requested begins nothing more (semantics item 8): the fourth step is refused
/// without running, and the refusal is not handed into the action, which may not go on
/// (sticky abort, item 4): the loop stops there, and the next tick (1 ms) aborts the main
/// sequence. EEROS's result -1 (aborted) is the main sequence's outcome,
/// `Aborted(Abort)`; its action never reaches the line that stores a result. The abort
/// comes 1 ms later, when the tick carries the request out (item 8). (Until session 47
/// each refusal returned into the action, which ran the loop to its end and stored -1.)
#[test]
fn seq_test_2_aborting_stops_the_loop_of_steps() {
    let seq = Seqr::new();
    let world = World::default();
    let step = seq.add(cfg("step"), Step1::default()).unwrap();
    let si = step.id();
    let main = Stepping {
        step,
        n: 50,
        abort_at_3: true,
    };
    let main = seq.add(cfg("Main Sequence"), main).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_for(Duration::from_millis(300));
    assert_eq!(sim.lost(), 0);
    let mut want = vec![start(0, mi)];
    want.extend(chain(si, Idle, &[0; 4]));
    want.push(tr(1, mi, Running, Aborting, Cause::Abort));
    want.push(tr(1, mi, Aborting, Aborted, Cause::Abort));
    assert_trace(sim.trace(), &want);
    let events: Vec<_> = sim
        .records()
        .iter()
        .filter_map(|r| match r.entry {
            Entry::Event(e) => Some((r.time.as_ticks() / 1000, e)),
            Entry::Transition { .. } => None,
        })
        .collect();
    let requested = Event::Requested {
        sequence: mi,
        request: Request::Abort,
        by: Requester::Sequence(mi),
    };
    assert_eq!(events, [(0, requested)]);
    assert_eq!(world.result.get(), None);
    let h = sim.handle(mi).unwrap();
    assert_eq!(h.last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    assert_eq!(sim.handle(si).unwrap().counters().runs, 3);
}

/// SeqTest2's `SequenceA`: pre-condition `count == 5`, `action() {count++; return count;}`.
struct PreCondition {
    count: i32,
    result: Option<i32>,
}
impl Sequence<World> for PreCondition {
    async fn action(&mut self, _cx: &Cx<'_, World>) -> Result<(), Failure> {
        self.count += 1;
        self.result = Some(self.count);
        Ok(())
    }
    fn check_pre_condition(&mut self, _cx: &Cx<'_, World>) -> bool {
        self.count == 5
    }
}

/// EEROS `test/sequencer/SeqTest2.cpp`, `TEST(seqTest2, preCondition)`: a sequence whose
/// pre-condition is `count == 5` runs with `count` 0: skipped, `getResult() == -1`,
/// `count` 0 (`BaseSequence.cpp:42-47`); with `count` set to 5 it runs: result 6,
/// `count` 6. rtseq: the gtest body runs it blocking twice: `Ok(Done::Skipped)` (EEROS's
/// -1), no result, `count` 0, a `PreConditionFalse` end; then `Ok(Done::Completed)`,
/// result 6, `count` 6.
#[test]
fn seq_test_2_pre_condition_skips_then_runs() {
    let seq = Seqr::new();
    let world = World::default();
    let s = PreCondition {
        count: 0,
        result: None,
    };
    let s = seq.add(cfg("s"), s).unwrap();
    let si = s.id();
    let gtest = GTest {
        s,
        read: |s: &PreCondition| (s.result, s.count, 0),
        set: |s| s.count = 5,
    };
    let gtest = seq.add(cfg("gtest"), gtest).unwrap();
    let gi = gtest.id();
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(gtest);
    sim.start(gi).unwrap();
    sim.run_until_idle(Duration::from_secs(1)).unwrap();
    let want = [
        start(0, gi),
        start(0, si),
        tr(0, si, Running, Terminated, Cause::PreConditionFalse),
        tr(0, si, Terminated, Running, Cause::Start),
        done(0, si),
        done(0, gi),
    ];
    assert_trace(sim.trace(), &want);
    assert_eq!(
        *world.seen.borrow(),
        [
            Seen {
                done: Ok(Done::Skipped),
                result: None,
                count: 0,
                step_count: 0
            },
            Seen {
                done: Ok(Done::Completed),
                result: Some(6),
                count: 6,
                step_count: 0
            },
        ]
    );
    let c = sim.handle(si).unwrap().counters();
    assert_eq!((c.runs, c.skipped, c.completed), (2, 1, 1));
}

/// SeqTest2's `SequenceB`: `action() {count++; return count;}`, exit condition
/// `count == 15`; `count` is in [`World`], as the test thread writes it.
struct ExitCondition;
impl Sequence<World> for ExitCondition {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let w = cx.control();
        w.count.set(w.count.get() + 1);
        w.result.set(Some(w.count.get()));
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, World>) -> bool {
        cx.control().count.get() == 15
    }
}

/// EEROS `test/sequencer/SeqTest2.cpp`, `TEST(seqTest2, exitCondition)`: a sequence whose
/// action returns its incremented `count` (1) and whose exit condition is `count == 15`;
/// the test sets `count = 15` 1 ms after the start. EEROS: the exit condition is false
/// right after the action (`BaseSequence.cpp:54`) and true at the next poll, 100 ms:
/// result 1, `count` 15. rtseq: the same (the test's write is a before-tick hook at 1
/// ms): completed at 100 ms, result 1, `count` 15.
#[test]
fn seq_test_2_exit_condition_ends_the_sequence_at_the_next_poll() {
    let seq = Seqr::new();
    let world = World::default();
    let s = seq.add(cfg("s"), ExitCondition).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &world, Monitors::<World, 1>::new());
    sim.lane(s);
    sim.before_tick(|now, w| {
        if now.as_ticks() == 1000 {
            w.count.set(15)
        }
    });
    sim.start(si).unwrap();
    let end = sim.run_until_idle(Duration::from_secs(1)).unwrap();
    assert_eq!(end.as_ticks(), 100_000);
    assert_trace(sim.trace(), &[start(0, si), done(100, si)]);
    assert_eq!((world.result.get(), world.count.get()), (Some(1), 15));
}

// ---- SeqTest3 and SeqTest4 -----------------------------------------------------------

/// SeqTest3's `Step1`: `action() {count++; return count;}` on the global `count`. EEROS
/// checks the owner's monitors inside every step's own run loop, before and right after
/// its action (`BaseSequence.cpp:37,52`), so a step that ends at once still lets the
/// monitor see its count. rtseq evaluates monitors in the tick at the owner's polling
/// period (item 1): a step that ended at once would give the monitor no look at all (the
/// whole action runs at 0 ms). So each step here ends at its first poll, 100 ms after
/// its action: the tick's monitor evaluation comes before that exit condition.
struct PolledStep {
    checks: u32,
}
impl Step<World> for PolledStep {
    fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let w = cx.control();
        w.count.set(w.count.get() + 1);
        self.checks = 0;
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Cx<'_, World>) -> bool {
        self.checks += 1;
        self.checks > 1
    }
}

/// SeqTest3/4's `ExceptionSeq`: `count += 100; eCount++; if (eCount == 3) limit = 2;`.
struct CountingException;
impl Sequence<World> for CountingException {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let w = cx.control();
        w.count.set(w.count.get() + 100);
        w.e_count.set(w.e_count.get() + 1);
        if w.e_count.get() == 3 {
            w.limit.set(2);
        }
        Ok(())
    }
}

/// SeqTest3's `MainSequence`: `count = 0; for (i = 0; i < limit; i++) step(); return
/// count;` (`limit` read at every turn, as EEROS's global).
struct LimitSteps {
    step: Seq<PolledStep>,
}
impl Sequence<World> for LimitSteps {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        let w = cx.control();
        w.count.set(0);
        let mut i = 0;
        while i < w.limit.get() {
            let _ = cx.step(&mut self.step).await;
            i += 1;
        }
        w.result.set(Some(w.count.get()));
        Ok(())
    }
}

/// SeqTest3 with the monitor `mon` (`count > 2 && count < 100`, exception `e1`) of
/// `behaviour`: the trace, ids `[step, e1, main]`, the monitor, `count`, `eCount`.
fn seq_test_3(behaviour: Behaviour) -> (Vec<Transition>, [SeqId; 3], MonitorId, i32, i32) {
    let seq = Seqr::new();
    let world = World::default();
    world.limit.set(5);
    let step = seq.add(cfg("step"), PolledStep { checks: 0 }).unwrap();
    let si = step.id();
    let e1 = seq.add(cfg("e1"), CountingException).unwrap();
    let ei = e1.id();
    let main = seq.add(cfg("Main Sequence"), LimitSteps { step }).unwrap();
    let mi = main.id();
    let mut cond = |w: &World, _| w.count.get() > 2 && w.count.get() < 100;
    let mut monitors = Monitors::<World, 1>::new();
    let m = monitors
        .add(mi, Monitor::new("mon", &mut cond, behaviour).exception(ei))
        .unwrap();
    let mut sim = Sim::new(&seq, &world, monitors);
    sim.lane(main);
    sim.lane(e1);
    sim.start(mi).unwrap();
    sim.run_until_idle(Duration::from_secs(10)).unwrap();
    let trace = sim.take_trace();
    drop(sim);
    (
        trace,
        [si, ei, mi],
        m,
        world.count.get(),
        world.e_count.get(),
    )
}

/// The start of SeqTest3: steps 1 and 2 at 0 and 100 ms, step 3 from 200 ms; at 300 ms the
/// monitor sees `count` 3 and `e1` runs (`count` 103).
fn seq_test_3_until_e1(si: SeqId, ei: SeqId, mi: SeqId, m: MonitorId) -> Vec<Transition> {
    let mut want = vec![start(0, mi)];
    want.extend(chain(si, Idle, &[0, 100, 200]));
    want.push(tr(200, si, Terminated, Running, Cause::Start));
    want.push(tr(300, ei, Idle, Running, Cause::Monitor(m)));
    want.push(done(300, ei));
    want
}

/// EEROS `test/sequencer/SeqTest3.cpp`, `TEST(seqTest3, condition)`, behaviour abort: the
/// monitor fires after the third step's action (`count` 3), `e1` adds 100 (103), the
/// main sequence is aborted. EEROS: the main sequence's action is a plain call that its
/// `aborting` state does not interrupt (`BaseSequence.cpp:45`); steps 4 and 5 check the
/// monitors before their action (`:37`), the condition is false now (103), so they are
/// not aborted and run: `count == 105`, `eCount == 1`. rtseq (a deliberate difference,
/// item 4: abort is sticky): step 3 and the main sequence are aborted at 301 ms
/// (item 3), no step runs after: `count` 103, `eCount` 1.
#[test]
fn seq_test_3_monitor_abort_is_sticky() {
    let (trace, [si, ei, mi], m, count, e_count) = seq_test_3(Behaviour::AbortOwner);
    let mut want = seq_test_3_until_e1(si, ei, mi, m);
    want.extend(aborted(301, &[si, mi], Cause::Monitor(m)));
    assert_trace(&trace, &want);
    assert_eq!((count, e_count), (103, 1));
}

/// EEROS `test/sequencer/SeqTest3.cpp`, `TEST(seqTest3, condition)`, behaviour resume:
/// EEROS: `e1` at `count` 3 (103), the main sequence resumes, steps 4 and 5 run:
/// `count == 105`, `eCount == 1`. rtseq: the same values; step 3, held while `e1` ran,
/// ends at its next poll, 400 ms (item 1), steps 4 and 5 at 500 and 600 ms.
#[test]
fn seq_test_3_monitor_resume_goes_on() {
    let (trace, [si, ei, mi], m, count, e_count) = seq_test_3(Behaviour::Nothing);
    let mut want = seq_test_3_until_e1(si, ei, mi, m);
    want.extend(
        chain(si, Running, &[400, 400, 500, 600])
            .into_iter()
            .skip(1),
    );
    want.push(done(600, mi));
    assert_trace(&trace, &want);
    assert_eq!((count, e_count), (105, 1));
}

/// EEROS `test/sequencer/SeqTest3.cpp`, `TEST(seqTest3, condition)`, behaviour restart:
/// each run reaches `count` 3, `e1` runs, the main sequence restarts (`count = 0`); the
/// third `e1` sets `limit = 2`, so the fourth run makes two steps: `count == 2`,
/// `eCount == 3`. (In the first two runs EEROS runs steps 4 and 5 after the firing, before
/// restarting, the condition being false by then; rtseq restarts at once, item 4; the
/// values agree.)
/// rtseq: restarts at 301, 601 and 901 ms (item 3), three restarts being the default
/// limit (`DEFAULT_RESTART_LIMIT`, item 5: a fourth firing would abort; EEROS has no
/// limit); the last run completes at 1100 ms: `count` 2, `eCount` 3.
#[test]
fn seq_test_3_monitor_restart_until_the_limit_changes() {
    let (trace, [si, ei, mi], m, count, e_count) = seq_test_3(Behaviour::RestartOwner);
    let cause = Cause::Monitor(m);
    let mut want = seq_test_3_until_e1(si, ei, mi, m);
    for restart in [301, 601, 901] {
        want.extend(aborted(restart, &[si], cause));
        want.extend(restarted(restart, mi, cause));
        if restart < 901 {
            want.extend(chain(si, Aborted, &[restart, restart + 99, restart + 199]));
            want.push(tr(restart + 199, si, Terminated, Running, Cause::Start));
            want.push(tr(restart + 299, ei, Terminated, Running, cause));
            want.push(done(restart + 299, ei));
        } else {
            want.extend(chain(si, Aborted, &[901, 1000, 1100]));
        }
    }
    want.push(done(1100, mi));
    assert_trace(&trace, &want);
    assert_eq!((count, e_count), (2, 3));
}

/// SeqTest4's `MainSequence`: `action() {count = 10;}`, exit condition
/// `count++ >= 121` (a side effect at every check).
struct CountingExit;
impl Sequence<World> for CountingExit {
    async fn action(&mut self, cx: &Cx<'_, World>) -> Result<(), Failure> {
        cx.control().count.set(10);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, World>) -> bool {
        let c = &cx.control().count;
        let was = c.get();
        c.set(was + 1);
        was >= 121
    }
}

/// EEROS `test/sequencer/SeqTest4.cpp`, `TEST(seqTest4, condition)`: the main sequence
/// sets `count = 10`; its exit condition increments `count` at every check; its monitor
/// (`count >= 13 && eCount < 1`, abort, exception `e1`: `count += 100`) fires once.
/// EEROS: checks at 0 ms (10 → 11), 100 ms (11 → 12), 200 ms (12 → 13); at 300 ms the
/// monitor fires first (13), `e1` makes it 113, the owner is put into `aborting`, and the
/// exit condition is still evaluated in that poll (`BaseSequence.cpp:52-54`: it runs
/// unless the state is `restarting`): 113 → 114; `count == 114`, `eCount == 1`. rtseq (a
/// deliberate difference, item 1: the poll that falls due while its sequence handles an
/// exception is skipped): same firing at 300 ms, abort at 301 ms (item 3), no exit check
/// after the firing: `count` 113, `eCount` 1.
#[test]
fn seq_test_4_no_exit_check_after_the_monitor_fired() {
    let seq = Seqr::new();
    let world = World::default();
    let e1 = seq.add(cfg("e1"), CountingException).unwrap();
    let ei = e1.id();
    let main = seq.add(cfg("Main Sequence"), CountingExit).unwrap();
    let mi = main.id();
    let mut cond = |w: &World, _| w.count.get() >= 13 && w.e_count.get() < 1;
    let mut monitors = Monitors::<World, 1>::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("mon", &mut cond, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &world, monitors);
    sim.lane(main);
    sim.lane(e1);
    sim.start(mi).unwrap();
    sim.run_until_idle(Duration::from_secs(10)).unwrap();
    let mut want = vec![start(0, mi)];
    want.push(tr(300, ei, Idle, Running, Cause::Monitor(m)));
    want.push(done(300, ei));
    want.extend(aborted(301, &[mi], Cause::Monitor(m)));
    assert_trace(sim.trace(), &want);
    assert_eq!((world.count.get(), world.e_count.get()), (113, 1));
}
