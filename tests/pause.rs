//! Pause reaches waits: a `Wait` counts only unpaused time, as the timeout does, and a run's
//! unpaused time (`Cx::run_time`) is what both count.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{Completed, Monitor as Mon, Pause, Restart, Resume, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, ConditionFn, Duration, Error, Instant, Monitor, MonitorId, Monitors, Seq,
    SeqConfig, SeqId, Sequencer, Wait,
};

/// Main runs a 1 s `Wait` blocking; it is paused at 0.3 s and resumed at 2.3 s (each request
/// made just before the tick that applies it).
#[test]
fn a_wait_paused_at_300_ms_for_2_s_ends_at_3_s() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_secs(1)))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    let handle = seq.sequence_by_id(mi).unwrap();
    sim.run_until(Instant::from_ticks(299_000));
    handle.pause().unwrap();
    sim.run_until(Instant::from_ticks(2_299_000));
    handle.resume().unwrap();
    let end = sim.run_until_idle(Duration::from_secs(5)).unwrap();
    assert_eq!(end, Instant::from_ticks(3_000_000));
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(300, mi, Running, Paused, Pause),
            tr(300, wi, Running, Paused, Pause),
            tr(2_300, mi, Paused, Running, Resume),
            tr(2_300, wi, Paused, Running, Resume),
            tr(3_000, wi, Running, Terminated, Completed),
            tr(3_000, mi, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
}

/// A wait longer than 2³² µs (71.6 minutes): two hours, ticked every second.
#[test]
fn a_two_hour_wait_ends_after_two_hours() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let every_s = Duration::from_secs(1);
    let w = seq
        .add(
            SeqConfig::new("W").polling(every_s),
            Wait::new(Duration::from_secs(2 * 3_600)),
        )
        .unwrap();
    let main = seq
        .add(
            SeqConfig::new("main").polling(every_s),
            Node::of(vec![Op::Wait(w)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(every_s)
        .unwrap();
    sim.lane(main);
    sim.start(mi).unwrap();
    let end = sim.run_until_idle(Duration::from_secs(3 * 3_600)).unwrap();
    assert_eq!(end.duration_since_epoch(), Duration::from_secs(2 * 3_600));
}

/// The timeout counts the same clock: a 1 s timeout, paused after 0.5 s for 2 s, runs out at
/// 3 s of sequencer time.
#[test]
fn a_timeout_paused_for_2_s_runs_out_2_s_later() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(Duration::from_secs(1)),
            Node::of(vec![]).until(9),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    let handle = seq.sequence_by_id(mi).unwrap();
    sim.run_until(Instant::from_ticks(499_000));
    handle.pause().unwrap();
    sim.run_until(Instant::from_ticks(2_499_000));
    handle.resume().unwrap();
    sim.run_until(Instant::from_ticks(4_000_000));
    let t = rtseq::Cause::Timeout(mi);
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(500, mi, Running, Paused, Pause),
            tr(2_500, mi, Paused, Running, Resume),
            tr(3_000, mi, Running, Aborting, t),
            tr(3_000, mi, Aborting, Aborted, t),
        ],
        "{}",
        show(sim.trace())
    );
}

/// An operator's "hold" and "continue" handled in one pass of the application, before the
/// tick: the later request counts. A resume takes back a pending pause (the sequence never
/// pauses), a pause takes back a pending resume (it stays paused); both are recorded. A
/// pause of a sequence paused already, with nothing pending, is refused as such.
#[test]
fn of_a_pause_and_a_resume_before_the_same_tick_the_later_counts() {
    use rtseq::{Entry, Error, Event, Request, Requester, WithNames};
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    let h = seq.sequence_by_id(mi).unwrap();
    sim.run_until(Instant::from_ticks(2_000));
    // Hold, then continue, before the tick at 3 ms: it never pauses.
    assert_eq!((h.pause(), h.resume()), (Ok(()), Ok(())));
    sim.run_until(Instant::from_ticks(3_000));
    assert_eq!(h.state(), Running);
    // Hold twice at 4 ms; at 5 ms a continue and a second hold: it stays paused.
    assert_eq!((h.pause(), h.pause()), (Ok(()), Ok(())));
    sim.run_until(Instant::from_ticks(4_000));
    assert_eq!(h.pause(), Err(Error::AlreadyPaused(mi)));
    assert_eq!(
        Error::AlreadyPaused(mi).named(&seq).to_string(),
        "sequence `main` is paused already"
    );
    assert_eq!((h.resume(), h.pause()), (Ok(()), Ok(())));
    sim.run_until(Instant::from_ticks(5_000));
    assert_eq!(h.state(), Paused);
    h.resume().unwrap();
    let end = sim.run_until_idle(Duration::from_secs(1)).unwrap();
    // Paused from 4 to 6 ms: the 10 ms wait ends at 12 ms.
    assert_eq!(end, Instant::from_ticks(12_000));
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(4, mi, Running, Paused, Pause),
            tr(4, wi, Running, Paused, Pause),
            tr(6, mi, Paused, Running, Resume),
            tr(6, wi, Paused, Running, Resume),
            tr(12, wi, Running, Terminated, Completed),
            tr(12, mi, Running, Terminated, Completed),
        ],
        "{}",
        show(sim.trace())
    );
    let requests: Vec<(u64, Request)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.entry {
            Entry::Event(Event::Requested {
                request,
                by: Requester::Application,
                ..
            }) => Some((r.time.duration_since_epoch().as_millis(), request)),
            _ => None,
        })
        .collect();
    assert_eq!(
        requests,
        [
            (2, Request::Pause),
            (2, Request::Resume),
            (3, Request::Pause),
            (3, Request::Pause),
            (4, Request::Resume),
            (4, Request::Pause),
            (5, Request::Resume),
        ]
    );
}

fn at(ms: u64) -> Instant {
    Instant::from_ticks(ms * 1000)
}

/// Runs until nothing is left to do, which must be when `id` has completed, at `ms`.
fn assert_ends_at(sim: &mut Sim<'_, Ctrl, 4, 64, 1>, id: SeqId, ms: u64) {
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(sim.state(id), Terminated, "{}", show(sim.trace()));
    assert_eq!(end, Some(at(ms)), "{}", show(sim.trace()));
}

/// Main, which runs a 5 ms `Wait` blocking: main, its id and the wait's.
fn waits_5_ms(seq: &Sequencer<Ctrl, 4>) -> (Seq<Node>, SeqId, SeqId) {
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    (main, mi, wi)
}

/// A pause wakes no lane (semantics 15): a run paused before its lane took its start, or
/// while it waits, waits for its resume, which wakes it. Each ends the time its unpaused
/// wait took after the resume.
///
/// Started through a handle (the lane has not taken the start) and paused at once.
#[test]
fn a_pause_before_the_lane_took_its_start() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = waits_5_ms(&seq);
    let other = seq.add(SeqConfig::new("other"), Node::of(vec![])).unwrap();
    let oi = other.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(other);
    sim.start(oi).unwrap(); // validates
    let h = seq.sequence_by_id(mi).unwrap();
    h.start().unwrap();
    h.pause().unwrap();
    sim.run_until(at(10));
    assert_eq!(sim.state(mi), Paused, "{}", show(sim.trace()));
    h.resume().unwrap();
    assert_ends_at(&mut sim, mi, 16);
}

/// A blocking child paused alone (its caller runs on), then resumed.
#[test]
fn a_blocking_child_paused_alone() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (main, mi, wi) = waits_5_ms(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_until(at(1));
    sim.pause(wi).unwrap();
    sim.run_until(at(10));
    assert_eq!(sim.state(wi), Paused, "{}", show(sim.trace()));
    assert_eq!(sim.state(mi), Running, "{}", show(sim.trace()));
    sim.resume(wi).unwrap();
    assert_ends_at(&mut sim, mi, 14);
}

/// Paused, then aborted while paused; started again at once.
#[test]
fn an_abort_during_a_pause() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = waits_5_ms(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_until(at(1));
    sim.pause(mi).unwrap();
    sim.run_until(at(4));
    sim.abort(mi).unwrap();
    sim.run_until(at(6));
    assert_eq!(sim.state(mi), Aborted, "{}", show(sim.trace()));
    sim.start(mi).unwrap();
    assert_ends_at(&mut sim, mi, 11);
}

/// J (its own lane) joins main; main is paused and resumed; J gets main's end.
#[test]
fn a_joiner_of_a_paused_run() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = waits_5_ms(&seq);
    let j = seq
        .add(SeqConfig::new("J"), Node::of(vec![Op::Join(mi)]))
        .unwrap();
    let ji = j.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(j);
    sim.start(mi).unwrap();
    sim.start(ji).unwrap();
    sim.run_until(at(1));
    sim.pause(mi).unwrap();
    sim.run_until(at(10));
    sim.resume(mi).unwrap();
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(
        (sim.state(mi), sim.state(ji)),
        (Terminated, Terminated),
        "{}",
        show(sim.trace())
    );
    assert_eq!(end, Some(at(14)), "{}", show(sim.trace()));
}

/// Paused and resumed twice in a row.
#[test]
fn pause_resume_pause_resume() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let (main, mi, _) = waits_5_ms(&seq);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    for k in 0..2u64 {
        sim.run_until(at(1 + 4 * k));
        sim.pause(mi).unwrap();
        sim.run_until(at(3 + 4 * k));
        sim.resume(mi).unwrap();
    }
    let end = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(sim.state(mi), Terminated, "{}", show(sim.trace()));
    assert!(!sim.stalled());
    assert_eq!(end, Some(at(9)), "{}", show(sim.trace()));
}

/// A pause requested of a run just before the tick that restarts it (the end of its
/// `RestartOwner` monitor's exception sequence: that behaviour comes before the requests,
/// semantics 8) ends with the round, as a pause request's pause does when the restart
/// comes after it: "a restart runs unpaused" (semantics 4 and 7). Main runs a 10 ms `Wait`;
/// its monitor fires at 3 ms, its exception sequence E runs a 2 ms wait, and the tick at
/// 6 ms restarts main. The pause asked for at 5 ms is recorded and `Ok`, main is never
/// paused, and a resume afterwards is `Err(NotPaused)`: the restarted round runs its full
/// 10 ms wait, from 6 ms.
#[test]
fn a_pause_requested_just_before_a_restart_ends_with_the_round() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(SeqConfig::new("W"), Wait::new(Duration::from_millis(10)))
        .unwrap();
    let wi = w.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let mi = main.id();
    let ew = seq
        .add(SeqConfig::new("EW"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let ewi = ew.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![Op::Wait(ew)]))
        .unwrap();
    let ei = e.id();
    let mut fault = |c: &Ctrl, _: Instant| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            mi,
            Monitor::new("m", &mut fault, Behaviour::RestartOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(mi).unwrap();
    sim.run_until(at(5));
    let h = sim.handle(mi).unwrap();
    assert_eq!(h.pause(), Ok(()));
    sim.step();
    assert_eq!(sim.state(mi), Running);
    assert_eq!(h.resume(), Err(Error::NotPaused(mi)));
    assert_eq!(sim.run_until_idle(Duration::from_millis(30)), Some(at(16)));
    assert_eq!(
        sim.trace(),
        [
            tr(0, mi, Idle, Running, Start),
            tr(0, wi, Idle, Running, Start),
            tr(3, ei, Idle, Running, Mon(m)),
            tr(3, ewi, Idle, Running, Start),
            tr(5, ewi, Running, Terminated, Completed),
            tr(5, ei, Running, Terminated, Completed),
            tr(6, wi, Running, Aborting, Mon(m)),
            tr(6, wi, Aborting, Aborted, Mon(m)),
            tr(6, mi, Running, Restarting, Mon(m)),
            tr(6, mi, Restarting, Running, Restart),
            tr(6, wi, Aborted, Running, Start),
            tr(16, wi, Running, Terminated, Completed),
            tr(16, mi, Running, Terminated, Completed),
        ],
        "\n{}",
        show(sim.trace())
    );
}

fn c8(c: &Ctrl, _: Instant) -> bool {
    c.flag(8)
}

/// DEFECT (or a doc that must change). docs/semantics.md:199 (item 8): an abort of a run
/// comes first when it is "a behaviour the same tick applies before the requests (an
/// exception sequence that ended, 3)", and :89-90 (item 4): the exception sequence's
/// behaviour "comes before the requests, 8". Here main's exception sequence ends at 5 ms;
/// the tick at 6 ms applies its `AbortOwner` and the resume request of main's paused step in
/// the same tick. Per the docs the behaviour comes first: the step is aborted from `Paused`
/// and the resume (of a run that has ended) does nothing. rtseq (`Sequencer::apply_requests`
/// goes by sequence id: each sequence's behaviour, then its request) resumes the step (id 0)
/// before it aborts main (id 1): `Paused -> Running (Resume)`, then `Running -> Aborting`.
/// Every behaviour of an ended exception sequence comes before every request of the tick
/// (semantics 8), whichever ids they are of: main's exception sequence ends at 5 ms, and
/// the tick at 6 ms applies its `AbortOwner` before the resume request of main's step
/// (paused by its own request, a lower id). The step is aborted from `Paused`, never let
/// go for a moment; the resume, of a run that has ended, does nothing. (Until session 54
/// the tick went by id, each sequence's behaviour then its requests, and resumed the step
/// first.)
#[test]
fn a_behaviour_of_an_ended_exception_sequence_comes_before_the_requests_of_other_sequences() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("step"), Leaf::until(0)).unwrap();
    let s = step.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let m = main.id();
    let w = seq
        .add(SeqConfig::new("w"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let wi = w.id();
    let e = seq
        .add(SeqConfig::new("e"), Node::of(vec![Op::Wait(w)]))
        .unwrap();
    let ei = e.id();
    let mut monitors: Monitors<Ctrl, 1, ConditionFn<Ctrl>> = Monitors::new();
    let mon = Monitor::with_fn("m", c8 as ConditionFn<Ctrl>, Behaviour::AbortOwner).exception(ei);
    monitors.add(m, mon).unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(|now, c: &Ctrl| c.set(8, ms(now) >= 2));
    sim.start(m).unwrap();
    sim.pause(s).unwrap(); // carried out at 1 ms
    sim.run_until(Instant::from_ticks(5_000)); // the exception sequence ends at 5 ms
    sim.resume(s).unwrap(); // taken: the step is paused by its own request
    sim.step(); // 6 ms: the behaviour, then (docs) the requests
    let mc = Cause::Monitor(MonitorId::from_index(0));
    let want = [
        tr(0, m, Idle, Running, Cause::Start),
        tr(0, s, Idle, Running, Cause::Start),
        tr(1, s, Running, Paused, Cause::Pause),
        tr(2, ei, Idle, Running, mc),
        tr(2, wi, Idle, Running, Cause::Start),
        tr(5, wi, Running, Terminated, Cause::Completed),
        tr(5, ei, Running, Terminated, Cause::Completed),
        tr(6, s, Paused, Aborting, mc),
        tr(6, s, Aborting, Aborted, mc),
        tr(6, m, Running, Aborting, mc),
        tr(6, m, Aborting, Aborted, mc),
    ];
    assert_eq!(sim.trace(), want, "\n{}", show(sim.trace()));
}

/// A blocking child left `Restarting` below a paused caller takes an abort request (an
/// abort is taken of a run under way, `Restarting` included, and tears it down from
/// there), not a pause (`NotRunning`: it is not running) or a resume (`NotPaused`).
#[test]
fn requests_of_a_restarting_child_below_a_paused_caller() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("step"), Leaf::until(0)).unwrap();
    let s = step.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let m = main.id();
    let mut monitors: Monitors<Ctrl, 1, ConditionFn<Ctrl>> = Monitors::new();
    monitors
        .add(
            s,
            Monitor::with_fn("m", c8 as ConditionFn<Ctrl>, Behaviour::RestartOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.before_tick(|now, c: &Ctrl| c.set(8, ms(now) >= 2));
    sim.start(m).unwrap();
    sim.pause(m).unwrap(); // 1 ms: main and the step paused
    sim.step();
    sim.step(); // 2 ms: the step's monitor restarts it; its lane is held: it stays Restarting
    assert_eq!(sim.state(s), Restarting);
    assert_eq!(sim.pause(s), Err(Error::NotRunning(s)));
    assert_eq!(sim.resume(s), Err(Error::NotPaused(s)));
    assert_eq!(sim.abort(s), Ok(()));
    sim.step();
    let mc = Cause::Monitor(MonitorId::from_index(0));
    assert!(
        sim.trace().ends_with(&[
            tr(2, s, Paused, Restarting, mc),
            tr(3, s, Restarting, Aborting, Cause::Abort),
            tr(3, s, Aborting, Aborted, Cause::Abort),
        ]),
        "\n{}",
        show(sim.trace())
    );
}

/// A step paused only because its caller is paused takes a pause request (semantics 7:
/// "A sequence held paused by something else ... takes a pause request: it stays paused
/// when that hold ends, until a resume request"), and a resume request, which does
/// nothing: it resumes with its caller. Paused by its own request then, it stays paused
/// when its caller resumes.
#[test]
fn requests_of_a_step_paused_by_its_caller_only() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let ctrl = Ctrl::default();
    let step = seq.add(SeqConfig::new("step"), Leaf::until(0)).unwrap();
    let s = step.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Step(step)]))
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.pause(m).unwrap();
    sim.step(); // 1 ms: both paused
    assert_eq!(sim.resume(s), Ok(()));
    sim.step();
    assert_eq!(sim.state(s), Paused);
    assert_eq!(sim.pause(s), Ok(()));
    sim.step();
    sim.resume(m).unwrap();
    sim.step(); // 4 ms: main resumes; the step stays paused by its own request
    assert_eq!((sim.state(m), sim.state(s)), (Running, Paused));
}
