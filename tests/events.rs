//! The events of the trace, in exact order among the transitions they explain.

mod common;
use common::{assert_records, event_at as e, transition_at as t};

use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Failed, Monitor as Mon, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cx, Error, Event, Failure, Instant, Monitor, MonitorId, Monitors, Record, Request,
    Requester, SeqConfig, SeqId, Sequence, Sequencer,
};

fn id(i: usize) -> SeqId {
    SeqId::from_index(i)
}

fn scenario(name: &str) -> Vec<Record> {
    let sc = rtseq_scenarios::find(name).expect("a scenario");
    rtseq_scenarios::host::run(sc).expect("registers").records
}

/// Two monitors share the exception sequence E (id 3) and fire in the same tick: E starts
/// for the first (owner A, id 4); for the second (owner B, id 5) it is running already, so
/// B's behaviour is applied at once, after the record of why.
#[test]
fn an_exception_sequence_that_cannot_run_is_recorded_with_its_reason() {
    let m0 = Mon(MonitorId::from_index(0));
    let m1 = Mon(MonitorId::from_index(1));
    assert_records(
        &scenario("exception_busy"),
        &[
            t(0, 4, Idle, Running, Start),
            t(0, 5, Idle, Running, Start),
            t(0, 0, Idle, Running, Start),
            t(0, 1, Idle, Running, Start),
            e(
                5,
                Event::Fired {
                    owner: id(4),
                    cause: m0,
                    behaviour: Behaviour::AbortOwner,
                },
            ),
            t(5, 3, Idle, Running, m0),
            e(
                5,
                Event::Fired {
                    owner: id(5),
                    cause: m1,
                    behaviour: Behaviour::AbortOwner,
                },
            ),
            e(
                5,
                Event::ExceptionNotRun {
                    exception: id(3),
                    owner: id(5),
                    why: Error::AlreadyRunning(id(3)),
                },
            ),
            t(5, 1, Running, Aborting, m1),
            t(5, 1, Aborting, Aborted, m1),
            t(5, 5, Running, Aborting, m1),
            t(5, 5, Aborting, Aborted, m1),
            t(5, 2, Idle, Running, Start),
            t(8, 2, Running, Terminated, Completed),
            t(8, 3, Running, Terminated, Completed),
            t(9, 0, Running, Aborting, m0),
            t(9, 0, Aborting, Aborted, m0),
            t(9, 4, Running, Aborting, m0),
            t(9, 4, Aborting, Aborted, m0),
        ],
    );
}

/// A step's action fails: its transition says when, the event what it returned.
#[test]
fn a_failure_is_recorded_after_the_transition_that_ends_the_run() {
    assert_records(
        &scenario("failure"),
        &[
            t(0, 2, Idle, Running, Start),
            t(0, 0, Idle, Running, Start),
            t(0, 0, Running, Terminated, Failed),
            e(
                0,
                Event::Failed {
                    sequence: id(0),
                    failure: Failure::App(7),
                },
            ),
            t(0, 1, Idle, Running, Start),
        ],
    );
}

/// Waits until flag `n` of the control is set.
struct Hold(usize);

impl Sequence<[core::cell::Cell<bool>; 2]> for Hold {
    async fn action(&mut self, cx: &Cx<'_, [core::cell::Cell<bool>; 2]>) -> Result<(), Failure> {
        let n = self.0;
        cx.wait_until(move |cx| cx.control()[n].get()).await;
        Ok(())
    }
}

/// Pauses sequence `target` through its handle, then ends.
struct Pauser {
    target: SeqId,
}

impl Sequence<[core::cell::Cell<bool>; 2]> for Pauser {
    async fn action(&mut self, cx: &Cx<'_, [core::cell::Cell<bool>; 2]>) -> Result<(), Failure> {
        cx.sequence_by_id(self.target)
            .ok_or(Error::UnknownSequence(self.target))?
            .pause()?;
        Ok(())
    }
}

/// A request made by a sequence names it; a `PauseOwner` monitor's firing is recorded
/// before the pause it makes, and its clearing resumes without a record of its own.
#[test]
fn requests_name_their_requester_and_pause_owner_firings_are_recorded() {
    type Flags = [core::cell::Cell<bool>; 2];
    let seq: Sequencer<Flags, 4> = Sequencer::new();
    let work = seq.add(SeqConfig::new("work"), Hold(0)).unwrap();
    let other = seq.add(SeqConfig::new("other"), Hold(0)).unwrap();
    let (work_id, other_id) = (work.id(), other.id());
    let pauser = seq
        .add(SeqConfig::new("pauser"), Pauser { target: other_id })
        .unwrap();
    let pauser_id = pauser.id();
    let mut curtain = |c: &Flags, _: Instant| c[1].get();
    let mut monitors: Monitors<Flags, 1> = Monitors::new();
    let m = monitors
        .add(
            work_id,
            Monitor::new("curtain", &mut curtain, Behaviour::PauseOwner),
        )
        .unwrap();
    let flags: Flags = Default::default();
    let mut sim = Sim::new(&seq, &flags, monitors);
    sim.lane(work);
    sim.lane(other);
    sim.lane(pauser);
    sim.start(work_id).unwrap();
    sim.start(other_id).unwrap();
    sim.run_for(rtseq::Duration::from_millis(2));
    sim.start(pauser_id).unwrap();
    sim.run_for(rtseq::Duration::from_millis(2));
    flags[1].set(true);
    sim.run_for(rtseq::Duration::from_millis(2));
    flags[1].set(false);
    sim.run_for(rtseq::Duration::from_millis(2));
    let mon = Mon(m);
    let (w, o, p) = (work_id.index(), other_id.index(), pauser_id.index());
    assert_records(
        sim.records(),
        &[
            t(0, w, Idle, Running, Start),
            t(0, o, Idle, Running, Start),
            t(2, p, Idle, Running, Start),
            e(
                2,
                Event::Requested {
                    sequence: other_id,
                    request: Request::Pause,
                    by: Requester::Sequence(pauser_id),
                },
            ),
            t(2, p, Running, Terminated, Completed),
            t(3, o, Running, Paused, Cause::Pause),
            e(
                5,
                Event::Fired {
                    owner: work_id,
                    cause: mon,
                    behaviour: Behaviour::PauseOwner,
                },
            ),
            t(5, w, Running, Paused, mon),
            t(7, w, Paused, Running, mon),
        ],
    );
}

/// What the safety system tells the sequencer (it runs above the sequencer's ceiling, so it
/// only queues notes) is recorded by the next tick, at the tick's time, in the order told,
/// before the abort-all it asked for. More notes than the queue holds (8) between two
/// ticks: the newest are dropped and counted as lost.
#[test]
fn safety_levels_and_tripped_inputs_are_recorded_by_the_next_tick() {
    use rtseq::safety::{InputId, SafetyLevel, Sequences};
    let seq: Sequencer<(), 2> = Sequencer::new();
    let id = seq.register(SeqConfig::new("a")).unwrap();
    let h = seq.sequence_by_id(id).unwrap();
    h.declare_lane().unwrap();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let tick = |ms: u64, monitors: &mut Monitors<(), 1>| {
        seq.tick(Instant::from_ticks(ms * 1000), &(), monitors)
            .unwrap();
    };
    let drain = || {
        let mut records = Vec::new();
        let lost = seq.drain_records(|r| records.push(r));
        (records, lost)
    };
    let level = |id| Event::SafetyLevel {
        level: SafetyLevel::new(id),
    };
    let estop: InputId = rtseq::safety::CriticalInput::<bool>::new(3, "estop").id();

    tick(1, &mut monitors);
    seq.level_entered(SafetyLevel::new(1));
    tick(2, &mut monitors);
    h.start().unwrap();
    seq.input_tripped(estop);
    seq.level_entered(SafetyLevel::new(0));
    Sequences::abort_all(&seq);
    assert_eq!(
        drain(),
        (vec![e(2, level(1)), t(2, 0, Idle, Running, Start)], 0)
    );
    tick(3, &mut monitors);
    let (records, lost) = drain();
    assert_eq!(lost, 0);
    assert_records(
        &records,
        &[
            e(3, Event::InputTripped { input: estop }),
            e(3, level(0)),
            e(
                3,
                Event::AbortAll {
                    by: Requester::SafetySystem,
                },
            ),
            t(3, 0, Running, Aborting, Cause::AbortAll),
            t(3, 0, Aborting, Aborted, Cause::AbortAll),
        ],
    );

    // Ten notes before the next tick: eight are kept, two lost.
    for id in 0..10 {
        seq.level_entered(SafetyLevel::new(id));
    }
    tick(4, &mut monitors);
    let want: Vec<Record> = (0..8).map(|id| e(4, level(id))).collect();
    assert_eq!(drain(), (want, 2));
    tick(5, &mut monitors);
    assert_eq!(drain(), (vec![], 0));
}

/// A drain whose callback makes a record for each record it reads (a pause or resume
/// request) returns: it passes at most the buffer's capacity, here 4, and the records
/// made meanwhile wait for the next call.
#[test]
fn a_drain_whose_callback_makes_records_returns() {
    let seq: Sequencer<(), 2, 4> = Sequencer::new();
    let a = seq.register(SeqConfig::new("a")).unwrap();
    let h = seq.sequence_by_id(a).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap();
    let mut read = Vec::new();
    let ask = |n: usize| {
        if n % 2 == 1 {
            h.pause()
        } else {
            h.resume()
        }
    };
    let lost = seq.drain_records(|r| {
        read.push(r);
        ask(read.len()).unwrap();
    });
    assert_eq!((lost, read.len()), (0, 4));
    // The start, then the requests the callback made while the drain went on.
    assert!(read[0].transition().is_some());
    let requested = |r: &Record| match r.event() {
        Some(Event::Requested { request, .. }) => Some(request),
        _ => None,
    };
    let requests: Vec<_> = read[1..].iter().map(|r| requested(r).unwrap()).collect();
    assert_eq!(requests, [Request::Pause, Request::Resume, Request::Pause]);
    // The next drain passes the one made after those.
    let mut next = Vec::new();
    assert_eq!(seq.drain_records(|r| next.push(r)), 0);
    assert_eq!(
        next.iter()
            .map(|r| requested(r).unwrap())
            .collect::<Vec<_>>(),
        [Request::Resume]
    );
}
