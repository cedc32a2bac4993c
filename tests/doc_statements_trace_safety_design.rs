//! The statements of docs/trace-format.md, docs/safety.md, docs/design-decisions.md and the
//! README's prose that no other test pins, each checked on exact values: the test's
//! comment quotes the statement it checks (tests/doc_statements.rs does the same for
//! docs/semantics.md, the firmware guide and the rustdoc). Written by an outside audit of
//! the documents in session 54; statements pinned elsewhere, or by the documents' own
//! doctests (README.md and docs/safety.md are doctests), have none here.

use core::cell::Cell;

use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Error, Failure, Instant, Monitor, Monitors, RunningState,
    SeqConfig, SeqId, Sequence, Sequencer, Table, Transition, Trigger, WithNames,
};
use RunningState::*;

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Fails at once with `App(code)`.
struct Fails(u16);
impl<C> Sequence<C> for Fails {
    async fn action(&mut self, _cx: &Cx<'_, C>) -> Result<(), Failure> {
        Err(Failure::App(self.0))
    }
}

/// Its pre-condition is false.
struct NeverReady;
impl<C> Sequence<C> for NeverReady {
    async fn action(&mut self, _cx: &Cx<'_, C>) -> Result<(), Failure> {
        Ok(())
    }
    fn check_pre_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        false
    }
}

/// Asks for the pause of sequence `0` through a handle of its own context, then waits.
struct Pauser(SeqId);
impl<C> Sequence<C> for Pauser {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.sequence_by_id(self.0).unwrap().pause()?;
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// The lines of a simulator's trace file.
fn file_lines<const N: usize, const M: usize>(sim: &Sim<'_, (), N, 64, M>) -> Vec<String> {
    let mut out = Vec::new();
    sim.write_trace(&mut out).unwrap();
    String::from_utf8(out)
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

// ---------------------------------------------------------------------------------------
// docs/trace-format.md

/// trace-format.md:54 (the `exception_not_run` example: `"sequence":3,"owner":5,"name":"E",
/// "text":"exception sequence 'E' of 'B' not run: sequence 3 is already running"`) and
/// trace-format.md:63: "`ExceptionNotRun`: the exception sequence could not start while its
/// owner's run was under way, so the behaviour was applied at once ... fields `sequence`
/// (the exception sequence), `owner`".
#[test]
fn an_exception_not_run_is_a_record_with_the_exception_and_its_owner() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let e = seq.add(SeqConfig::new("E"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("B"), Forever).unwrap();
    let (ei, bi) = (e.id(), b.id());
    let mut jam = |_: &(), now: Instant| now.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let m = monitors
        .add(
            bi,
            Monitor::new("jam", &mut jam, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(e);
    sim.lane(b);
    sim.start(ei).unwrap();
    sim.start(bi).unwrap();
    sim.run_for(ms(3));
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(3).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":2000,"event":"monitor","owner":1,"behaviour":"AbortOwner","monitor":0,"text":"monitor 'jam' of 'B' fired: AbortOwner"}"#,
            r#"{"t":2000,"event":"exception_not_run","sequence":0,"owner":1,"name":"E","text":"exception sequence 'E' of 'B' not run: sequence 0 is already running"}"#,
            r#"{"t":2000,"seq":1,"from":"Running","to":"Aborting","cause":"monitor","monitor":0}"#,
            r#"{"t":2000,"seq":1,"from":"Aborting","to":"Aborted","cause":"monitor","monitor":0}"#,
        ]
    );
    assert_eq!(sim.state(bi), Aborted);
    assert_eq!(m.index(), 0);
}

/// trace-format.md:63: "(a `PauseOwner` hold pauses without it)": a `PauseOwner` monitor
/// whose exception sequence cannot start still pauses its owner, and the refusal is
/// recorded.
#[test]
fn a_pause_owner_hold_pauses_without_its_exception_sequence() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let e = seq.add(SeqConfig::new("E"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("B"), Forever).unwrap();
    let (ei, bi) = (e.id(), b.id());
    let mut hold = |_: &(), now: Instant| now.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(
            bi,
            Monitor::new("hold", &mut hold, Behaviour::PauseOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(e);
    sim.lane(b);
    sim.start(ei).unwrap();
    sim.start(bi).unwrap();
    sim.run_for(ms(3));
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(3).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":2000,"event":"monitor","owner":1,"behaviour":"PauseOwner","monitor":0,"text":"monitor 'hold' of 'B' fired: PauseOwner"}"#,
            r#"{"t":2000,"event":"exception_not_run","sequence":0,"owner":1,"name":"E","text":"exception sequence 'E' of 'B' not run: sequence 0 is already running"}"#,
            r#"{"t":2000,"seq":1,"from":"Running","to":"Paused","cause":"monitor","monitor":0}"#,
        ]
    );
}

/// trace-format.md:55 (the `request` example: `"request":"pause","by":"sequence","by_seq":2,
/// "name":"pause s","text":"Pause of 'S' requested by Sequence(SeqId(2))"`) and
/// trace-format.md:64: "`Requested` (pause, resume, abort; recorded when made, before the
/// tick that carries it out) ... `by`: `sequence` (with `by_seq`)".
#[test]
fn a_request_by_a_sequence_is_recorded_when_made_with_its_requester() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let s = seq.add(SeqConfig::new("S"), Forever).unwrap();
    let si = s.id();
    let p = seq.add(SeqConfig::new("P"), Pauser(si)).unwrap();
    let pi = p.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(s);
    sim.lane(p);
    sim.start(si).unwrap();
    sim.run_for(ms(2));
    sim.start(pi).unwrap();
    sim.run_for(ms(1));
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(2).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":2000,"seq":1,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":2000,"event":"request","sequence":0,"request":"pause","by":"sequence","by_seq":1,"name":"pause s","text":"Pause of 'S' requested by Sequence(SeqId(1))"}"#,
            r#"{"t":3000,"seq":0,"from":"Running","to":"Paused","cause":"pause"}"#,
        ]
    );
}

/// trace-format.md:56 (`{"event":"request","request":"abort_all","by":"safety_system",
/// "name":"abort all","text":"abort all, requested by SafetySystem"}`) and
/// trace-format.md:64: "`AbortAll` (recorded by the tick that aborts, once there is
/// anything to abort)": an abort-all with nothing under way records nothing.
#[test]
fn an_abort_all_is_recorded_only_when_there_is_something_to_abort() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let s = seq.add(SeqConfig::new("S"), Forever).unwrap();
    let si = s.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(s);
    sim.abort_all();
    sim.run_for(ms(1));
    assert!(sim.records().is_empty());
    sim.start(si).unwrap();
    sim.run_for(ms(1));
    sim.abort_all();
    sim.run_for(ms(1));
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":1000,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":3000,"event":"request","request":"abort_all","by":"application","name":"abort all","text":"abort all, requested by Application"}"#,
            r#"{"t":3000,"seq":0,"from":"Running","to":"Aborting","cause":"abort_all"}"#,
            r#"{"t":3000,"seq":0,"from":"Aborting","to":"Aborted","cause":"abort_all"}"#,
        ]
    );
}

/// trace-format.md:57 (`{"t":0,"event":"failed","sequence":0,"name":"F","text":"'F' failed:
/// App(7)"}`), trace-format.md:42 (`failed` (the action returned `Err`)) and
/// trace-format.md:65: "recorded after its `Running → Terminated (failed)`".
#[test]
fn a_failure_is_recorded_after_its_terminated_transition() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let f = seq.add(SeqConfig::new("F"), Fails(7)).unwrap();
    let fi = f.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(f);
    sim.start(fi).unwrap();
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":0,"seq":0,"from":"Running","to":"Terminated","cause":"failed"}"#,
            r#"{"t":0,"event":"failed","sequence":0,"name":"F","text":"'F' failed: App(7)"}"#,
        ]
    );
}

/// trace-format.md:62: "`Fired`: a monitor fired (or, with `"name":"timeout of X"` instead
/// of `monitor`, a timeout ran out)"; trace-format.md:44: "`timeout` (with `"of": SEQUENCE
/// ID`)"; design-decisions.md:40: the timeout's "default behaviour `AbortOwner`".
#[test]
fn a_timeout_is_a_monitor_record_named_after_its_sequence() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let t = seq
        .add(SeqConfig::new("T").timeout(ms(3)), Forever)
        .unwrap();
    let ti = t.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(t);
    sim.start(ti).unwrap();
    sim.run_for(ms(4));
    let lines = file_lines(&sim);
    let tail: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
    assert_eq!(
        tail,
        [
            r#"{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
            r#"{"t":3000,"event":"monitor","owner":0,"behaviour":"AbortOwner","name":"timeout of T","text":"timeout of 'T' ran out: AbortOwner"}"#,
            r#"{"t":3000,"seq":0,"from":"Running","to":"Aborting","cause":"timeout","of":0}"#,
            r#"{"t":3000,"seq":0,"from":"Aborting","to":"Aborted","cause":"timeout","of":0}"#,
        ]
    );
}

/// trace-format.md:41-43: "`cause` is one of `start`, `pre_condition_false`, `completed`,
/// `pause`, `resume`, `abort`, `abort_all`, `restart`, ...": the causes a handle's requests
/// and a skipped run give, and a restart's.
#[test]
fn the_causes_of_requests_restarts_and_skips_are_written_by_these_names() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let s = seq.add(SeqConfig::new("S"), Forever).unwrap();
    let n = seq.add(SeqConfig::new("N"), NeverReady).unwrap();
    let r = seq.add(SeqConfig::new("R"), Forever).unwrap();
    let (si, ni, ri) = (s.id(), n.id(), r.id());
    let mut kick = |_: &(), now: Instant| now.as_ticks() == 6_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(ri, Monitor::new("kick", &mut kick, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(s);
    sim.lane(n);
    sim.lane(r);
    sim.start(si).unwrap();
    sim.start(ni).unwrap();
    sim.start(ri).unwrap();
    sim.run_for(ms(1));
    sim.pause(si).unwrap();
    sim.run_for(ms(1));
    sim.resume(si).unwrap();
    sim.run_for(ms(1));
    sim.abort(si).unwrap();
    sim.run_for(ms(4));
    let causes: Vec<String> = file_lines(&sim)
        .iter()
        .filter(|l| l.contains("\"from\""))
        .map(|l| l.split("\"to\":").nth(1).unwrap().to_string())
        .collect();
    assert_eq!(
        causes,
        [
            r#""Running","cause":"start"}"#,
            r#""Running","cause":"start"}"#,
            r#""Terminated","cause":"pre_condition_false"}"#,
            r#""Running","cause":"start"}"#,
            r#""Paused","cause":"pause"}"#,
            r#""Running","cause":"resume"}"#,
            r#""Aborting","cause":"abort"}"#,
            r#""Aborted","cause":"abort"}"#,
            r#""Restarting","cause":"monitor","monitor":0}"#,
            r#""Running","cause":"restart"}"#,
        ]
    );
}

/// trace-format.md:27: "`lost` | records the sequencer's trace ring overwrote before they
/// were read (... written by `Sim::save_trace`): a count"; safety.md:106: "The sequencer
/// queues them without a lock (room for 8 between two ticks; more are counted as lost)".
#[test]
fn notes_past_the_eighth_between_two_ticks_are_counted_as_lost_in_the_header() {
    use rtseq::safety::Sequences;
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    for level in 0..10 {
        seq.level_entered(SafetyLevel::new(level));
    }
    sim.step();
    let lines = file_lines(&sim);
    assert_eq!(
        lines[0],
        r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":1000,"lost":2,"sequences":[],"monitors":[]}"#
    );
    let levels: Vec<&str> = lines[1..].iter().map(String::as_str).collect();
    let want: Vec<String> = (0..8)
        .map(|i| format!(r#"{{"t":1000,"level":"level {i}","id":{i}}}"#))
        .collect();
    assert_eq!(levels, want);
    assert_eq!(sim.lost(), 2);
}

/// trace-format.md:28: "`caller` — the id of the sequence that started its last run
/// (`Handle::caller`), `null` for a main sequence, one never run, or unknown. An exception
/// sequence's caller is the owner of its monitor."
#[test]
fn the_header_gives_an_exception_sequence_its_owner_as_caller() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let e = seq.add(SeqConfig::new("E"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("B"), Forever).unwrap();
    let idle = seq.add(SeqConfig::new("idle"), Forever).unwrap();
    let (ei, bi) = (e.id(), b.id());
    let mut jam = |_: &(), now: Instant| now.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(
            bi,
            Monitor::new("jam", &mut jam, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(e);
    sim.lane(b);
    sim.lane(idle);
    sim.start(bi).unwrap();
    sim.run_for(ms(3));
    assert_eq!(sim.state(ei), Running);
    assert_eq!(
        file_lines(&sim)[0],
        concat!(
            r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":3000,"lost":0,"#,
            r#""sequences":[{"id":0,"name":"E","caller":1},{"id":1,"name":"B","caller":null},"#,
            r#"{"id":2,"name":"idle","caller":null}],"monitors":[{"id":0,"name":"jam","owner":1}]}"#
        )
    );
}

// ---------------------------------------------------------------------------------------
// docs/safety.md

/// safety.md:8: "`SafetyLevel` (a `u8` id, `Ord`)", EEROS's "ordered, lower = safer".
#[test]
fn safety_levels_are_ordered_by_their_u8_id() {
    let (emergency, off, running) = (
        SafetyLevel::new(0),
        SafetyLevel::new(1),
        SafetyLevel::new(2),
    );
    assert!(emergency < off && off < running);
    assert_eq!(running.id(), 2u8);
    let mut levels = [running, emergency, off];
    levels.sort();
    assert_eq!(levels, [emergency, off, running]);
}

const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
const RUNNING: SafetyLevel = SafetyLevel::new(1);
const ESTOP: PrivateEvent = PrivateEvent::new(0);
const STOP: PublicEvent = PublicEvent::new(0);
const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "estop");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");

struct Io {
    estop: bool,
}
impl SafetyIo for Io {
    fn read_input(&mut self, _: InputId) -> IoValue {
        self.estop.into()
    }
    fn write_output(&mut self, _: OutputId, _: IoValue) {}
}

/// Running (entry level), where the estop input's check fires `ESTOP`, which keeps running
/// in running (so it keeps firing without a change of level);
/// public `STOP` goes from running to emergency, which aborts all sequences on entry.
static PROPS: ValidProperties<'static, Io, 2> = match SafetyProperties::new(
    [
        LevelDef::new(EMERGENCY, "emergency")
            .inputs(&[ESTOP_IN.ignore()])
            .outputs(&[ENABLE.set(false)])
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(RUNNING, "running")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(true)]),
    ],
    &[ESTOP_IN.info()],
    &[ENABLE.info()],
    &[
        LevelTransition::on(EMERGENCY, ESTOP, EMERGENCY),
        LevelTransition::on(RUNNING, ESTOP, RUNNING),
        LevelTransition::on(RUNNING, STOP, EMERGENCY),
    ],
    RUNNING,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

/// safety.md:104-105: "the cycle also tells the sequencer ... each critical input that
/// trips (its check starts firing; one trip while it goes on firing)".
#[test]
fn an_input_that_keeps_firing_trips_once_and_again_after_it_stopped() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    let sequences = &seq;
    sim.before_tick(move |now, _| {
        let t = now.as_ticks() / 1000;
        let mut io = Io {
            estop: (3..6).contains(&t) || t >= 8,
        };
        safety.cycle(&mut io, sequences);
    });
    sim.run_for(ms(10));
    let names = (&seq, PROPS.properties());
    let lines: Vec<String> = sim
        .records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect();
    assert_eq!(
        lines,
        [
            "1 ms safety level running",
            "3 ms critical input `estop` tripped",
            "8 ms critical input `estop` tripped",
        ]
    );
}

/// safety.md:97-98: "The abort-all a level demands reaches that sequencer through the
/// handle too, even from a cycle given `NoSequences`".
#[test]
fn a_cycle_given_no_sequences_still_aborts_the_sequencer_s_runs() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let s = seq.add(SeqConfig::new("S"), Forever).unwrap();
    let si = s.id();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let handle = seq.safety_handle();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(s);
    sim.before_tick(move |now, _| {
        if now.as_ticks() == 3_000 {
            handle.trigger(STOP);
        }
        safety.cycle(&mut Io { estop: false }, &NoSequences);
    });
    sim.start(si).unwrap();
    sim.run_for(ms(4));
    assert_eq!(
        sim.trace(),
        [
            Transition::at_millis(0, si, Idle, Running, Cause::Start),
            Transition::at_millis(3, si, Running, Aborting, Cause::AbortAll),
            Transition::at_millis(3, si, Aborting, Aborted, Cause::AbortAll),
        ]
    );
}

/// safety.md:96: "Sequences reach the handle through the sequencer (`Cx::safety_system`,
/// `None` while no system is built on it)".
#[test]
fn a_context_reaches_the_safety_system_only_once_one_is_built_on_the_handle() {
    struct Look;
    impl Sequence<Cell<Option<bool>>> for Look {
        async fn action(&mut self, cx: &Cx<'_, Cell<Option<bool>>>) -> Result<(), Failure> {
            cx.control().set(Some(cx.safety_system().is_some()));
            Ok(())
        }
    }
    let seen = Cell::new(None);
    let seq: Sequencer<Cell<Option<bool>>, 2> = Sequencer::new();
    let look = seq.add(SeqConfig::new("look"), Look).unwrap();
    let id = look.id();
    let mut sim = Sim::new(&seq, &seen, Monitors::<Cell<Option<bool>>, 1>::new());
    sim.lane(look);
    sim.start(id).unwrap();
    assert_eq!(seen.get(), Some(false));
    let safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    sim.run_for(ms(1));
    sim.start(id).unwrap();
    sim.run_for(ms(1));
    assert_eq!(seen.get(), Some(true));
    drop(safety);
}

/// safety.md:216-217: "A test that drops the `Sim` (and with it the safety system in its
/// hook) releases the handle, which then reads level 0"; safety.md:113: "Dropping the
/// system releases the handle".
#[test]
fn dropping_the_sim_releases_the_handle_of_the_system_in_its_hook() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    {
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
        sim.before_tick(move |_, _| {
            safety.cycle(&mut Io { estop: false }, &NoSequences);
        });
        sim.run_for(ms(2));
        assert_eq!(seq.safety_handle().level(), RUNNING);
        assert!(seq.safety_system().is_some());
    }
    assert_eq!(seq.safety_handle().level(), SafetyLevel::new(0));
    assert!(seq.safety_system().is_none());
    assert!(SafetySystem::new_validated(&PROPS, seq.safety_handle()).is_ok());
}

// ---------------------------------------------------------------------------------------
// docs/design-decisions.md

/// design-decisions.md:22: "`SeqConfig::polling` (default 1 ms): the sequence's own
/// monitors, timeout and exit condition are checked at this period".
#[test]
fn the_default_polling_period_is_one_millisecond() {
    struct Until;
    impl Sequence<Cell<bool>> for Until {
        async fn action(&mut self, _cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
            Ok(())
        }
        fn check_exit_condition(&mut self, cx: &Cx<'_, Cell<bool>>) -> bool {
            cx.control().get()
        }
    }
    let flag = Cell::new(false);
    let seq: Sequencer<Cell<bool>, 2> = Sequencer::new();
    let u = seq.add(SeqConfig::new("u"), Until).unwrap();
    let id = u.id();
    let mut sim = Sim::new(&seq, &flag, Monitors::<Cell<bool>, 1>::new());
    sim.lane(u);
    sim.before_tick(|now, f| f.set(now.as_ticks() >= 3_000));
    sim.start(id).unwrap();
    sim.run_for(ms(5));
    assert_eq!(
        sim.trace(),
        [
            Transition::at_millis(0, id, Idle, Running, Cause::Start),
            Transition::at_millis(3, id, Running, Terminated, Cause::Completed),
        ]
    );
}

/// design-decisions.md:37: "restarts of a run are bounded (`restart_limit`, default 3, at
/// most 255; 0 aborts at once)".
#[test]
fn a_restart_limit_of_zero_aborts_at_the_first_firing() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let r = seq.add(SeqConfig::new("R"), Forever).unwrap();
    let ri = r.id();
    let mut jam = |_: &(), now: Instant| now.as_ticks() >= 2_000;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let m = monitors
        .add(
            ri,
            Monitor::new("jam", &mut jam, Behaviour::RestartOwner)
                .trigger(Trigger::Level)
                .restart_limit(0),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(r);
    sim.start(ri).unwrap();
    sim.run_for(ms(3));
    assert_eq!(
        sim.trace(),
        [
            Transition::at_millis(0, ri, Idle, Running, Cause::Start),
            Transition::at_millis(2, ri, Running, Aborting, Cause::Monitor(m)),
            Transition::at_millis(2, ri, Aborting, Aborted, Cause::Monitor(m)),
        ]
    );
}

/// design-decisions.md:93-96: "in a `static` the compiler runs registration's checks
/// (empty or duplicate names, durations, more than 8 polling periods, unknown timeout
/// exceptions, ...)"; design-decisions.md:99: "Sequence `i` of the table has id `i`;
/// `Table::id(name)` is a `const fn`".
#[test]
fn a_table_makes_registration_s_checks_and_numbers_by_place() {
    type T<const K: usize> = Result<Table<(), K>, rtseq::TableError>;
    let empty: T<1> = Table::new([SeqConfig::new("")]);
    assert_eq!(empty.err().map(|e| e.error), Some(Error::EmptyName));
    let twice: T<3> = Table::new([
        SeqConfig::new("a"),
        SeqConfig::new("b"),
        SeqConfig::new("a"),
    ]);
    assert_eq!(
        twice.err().map(|e| e.error),
        Some(Error::DuplicateName(SeqId::from_index(0)))
    );
    let zero: T<1> = Table::new([SeqConfig::new("a").polling(Duration::from_micros(0))]);
    assert_eq!(zero.err().map(|e| e.error), Some(Error::DurationOutOfRange));
    let periods: T<9> = Table::new([
        SeqConfig::new("1").polling(ms(1)),
        SeqConfig::new("2").polling(ms(2)),
        SeqConfig::new("3").polling(ms(3)),
        SeqConfig::new("4").polling(ms(4)),
        SeqConfig::new("5").polling(ms(5)),
        SeqConfig::new("6").polling(ms(6)),
        SeqConfig::new("7").polling(ms(7)),
        SeqConfig::new("8").polling(ms(8)),
        SeqConfig::new("9").polling(ms(9)),
    ]);
    assert_eq!(
        periods.err().map(|e| e.error),
        Some(Error::PollingClassesExceeded)
    );
    let unknown: T<1> = Table::new([SeqConfig::new("a")
        .timeout(ms(5))
        .timeout_exception(SeqId::from_index(4))]);
    assert_eq!(
        unknown.err().map(|e| e.error),
        Some(Error::UnknownSequence(SeqId::from_index(4)))
    );
    const TABLE: Table<(), 3> = match Table::new([
        SeqConfig::new("x"),
        SeqConfig::new("y"),
        SeqConfig::new("z"),
    ]) {
        Ok(t) => t,
        Err(_) => panic!("bad table"),
    };
    const Y: Option<SeqId> = TABLE.id("y");
    assert_eq!(Y, Some(SeqId::from_index(1)));
    let seq: Sequencer<(), 4> = Sequencer::new();
    seq.install(&TABLE).unwrap();
    for (i, name) in ["x", "y", "z"].into_iter().enumerate() {
        assert_eq!(
            seq.sequence_by_name(name).unwrap().id(),
            SeqId::from_index(i)
        );
    }
}

/// design-decisions.md:115-117: "`Monitors::table` ... is a `const fn` with
/// `Monitors::add`'s checks (a name, ...)".
#[test]
fn a_monitor_table_refuses_an_empty_name_as_add_does() {
    type Cond = fn(&(), Instant) -> bool;
    fn never(_: &(), _: Instant) -> bool {
        false
    }
    let owner = SeqId::from_index(0);
    let table: Result<Monitors<'static, (), 1, Cond>, rtseq::TableError> = Monitors::table([
        Monitor::with_condition("", never as Cond, Behaviour::AbortOwner).owned_by(owner),
    ]);
    assert_eq!(table.err().map(|e| e.error), Some(Error::EmptyName));
    let mut c = |_: &(), _: Instant| false;
    let mut m: Monitors<(), 1> = Monitors::new();
    assert_eq!(
        m.add(owner, Monitor::new("", &mut c, Behaviour::AbortOwner))
            .err(),
        Some(Error::EmptyName)
    );
}
