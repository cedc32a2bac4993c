//! The motor-controller demo (`boards/qemu-f405/src/bin/demo.rs`, `./x demo`) in QEMU, with
//! no fault and with each fault option, asserted on its decoded log; and the same
//! application with the same fault plan on the host simulator (`rtseq::sim::Sim`), which
//! must give **the same** transition trace and the same `RESULT` values.
//!
//! Why equal, not merely close: both run the identical `rtseq-motor` code at 1 kHz in the
//! same order per tick (fault injection, safety cycle, control step, sequencer tick, lanes),
//! the firmware's time is the tick count (not the host clock), and the plant's `f32`
//! arithmetic is IEEE single precision on both (Cortex-M4 FPv4-SP with subnormals, x86-64
//! SSE; no fused multiply-add, `libm` in software). So every transition time, move time,
//! reaction time and even the final position in µm must match.
//!
//! Run by plain `cargo test` at the repository root. Needs `qemu-system-arm` and the
//! `thumbv7em-none-eabihf` target (`./x setup`); missing tools fail the tests.

mod qemu_harness;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::OnceLock;

use qemu_harness::{expect_exit, require_tools, root, try_build, Config, Echo, Outcome, TARGET};
use rtseq::safety::SafetySystem;
use rtseq::sim::Sim;
use rtseq::{Cause, Instant, Outcome as SeqOutcome, RunningState, SeqId, Sequencer};
use rtseq_motor::app::monitor_ids::{
    END_STOP, FOLLOWING_ERROR, HOMING_END_STOP, HOMING_FOLLOWING_ERROR, PAUSE, RESUME,
};
use rtseq_motor::app::seq_ids::{BLINK, HOMING, MAIN, MOVES};
use rtseq_motor::app::{self, AppConfig, Fault, FaultKind, FaultPlan};
use rtseq_motor::control_system::{ControlSystem, Phase};
use rtseq_motor::safety::{self, PROPERTIES};

const CONFIG: AppConfig = AppConfig::DEMO;

// ---------------------------------------------------------------------------------------
// QEMU side
// ---------------------------------------------------------------------------------------

/// The demo ELF, built once (only this bin) and snapshotted.
fn demo_elf() -> PathBuf {
    require_tools();
    static BUILT: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let r = BUILT.get_or_init(|| {
        try_build("", &["demo"])?;
        let from = root()
            .join("target/firmware")
            .join(TARGET)
            .join("release/demo");
        let dir = root().join("target/firmware/qemu-demo");
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        let to = dir.join("demo");
        std::fs::copy(&from, &to).map_err(|e| format!("copy {}: {e}", from.display()))?;
        Ok(to)
    });
    match r {
        Ok(p) => p.clone(),
        Err(e) => panic!("building the demo firmware failed:\n{e}"),
    }
}

fn run_demo(args: &[&str]) -> Outcome {
    let cfg = Config {
        echo: Echo::None,
        firmware_args: args.iter().map(|s| s.to_string()).collect(),
        ..Config::default()
    };
    eprintln!("--- qemu: demo {}", args.join(" "));
    qemu_run::run(&demo_elf(), &cfg).unwrap_or_else(|e| panic!("running the demo in QEMU: {e}"))
}

/// One state change as the firmware prints it (and the host trace is formatted).
#[derive(Clone, Debug, PartialEq, Eq)]
struct Tr {
    ms: u64,
    name: String,
    from: String,
    to: String,
    cause: String,
}

impl std::fmt::Display for Tr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:>6} ms  {:<14} {} -> {} ({})",
            self.ms, self.name, self.from, self.to, self.cause
        )
    }
}

/// What a demo run printed.
struct Demo {
    out: Outcome,
    trace: Vec<Tr>,
    result: BTreeMap<String, String>,
}

impl Demo {
    fn get(&self, key: &str) -> &str {
        self.result
            .get(key)
            .unwrap_or_else(|| panic!("no RESULT {key}:\n{}", self.out.transcript()))
    }

    fn num(&self, key: &str) -> i64 {
        let v = self.get(key);
        v.parse()
            .unwrap_or_else(|_| panic!("RESULT {key}={v} is not a number"))
    }

    /// Transitions of one sequence.
    fn of(&self, name: &str) -> Vec<&Tr> {
        self.trace.iter().filter(|t| t.name == name).collect()
    }

    fn has_line(&self, needle: &str) -> bool {
        self.out.lines.iter().any(|l| l.message.contains(needle))
    }
}

fn parse_demo(out: Outcome) -> Demo {
    let mut trace = Vec::new();
    let mut result = BTreeMap::new();
    for l in &out.lines {
        if let Some(rest) = l.message.strip_prefix("seq ") {
            // "seq       NAME<pad> FROM -> TO<pad> (CAUSE)"; the line's time is the tick's
            // (idle prints a tick's transitions within that millisecond).
            let (left, right) = rest.split_once(" -> ").expect("seq line");
            let left = left.trim();
            let (name, from) = left.rsplit_once(' ').expect("seq line: name from");
            let (to, cause) = right.split_once(" (").expect("seq line: to (cause)");
            trace.push(Tr {
                ms: l.time_us.expect("timestamp") / 1000,
                name: name.trim().to_string(),
                from: from.to_string(),
                to: to.trim().to_string(),
                cause: cause.trim_end_matches(')').to_string(),
            });
        } else if let Some(rest) = l.message.strip_prefix("RESULT ") {
            let mut prefix = String::new();
            for kv in rest.split("; ") {
                let (k, v) = kv.split_once('=').expect("RESULT key=value");
                if k == "fault" {
                    prefix = format!("{v}.");
                    continue;
                }
                result.insert(format!("{prefix}{k}"), v.to_string());
            }
        }
    }
    Demo { out, trace, result }
}

// ---------------------------------------------------------------------------------------
// Host side: the same application, the same plan, the same order per tick
// ---------------------------------------------------------------------------------------

type Seqr = Sequencer<ControlSystem, { app::SEQUENCES }, 256>;

struct Host {
    trace: Vec<Tr>,
    result: BTreeMap<String, String>,
}

fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Off => "off",
        Phase::PowerOn => "power on",
        Phase::Homing => "homing",
        Phase::Moving => "moving",
        Phase::Paused => "paused",
        Phase::SafeStop => "safe stop",
        Phase::Done => "done",
        Phase::Fault => "fault",
    }
}

fn monitor_name(m: rtseq::MonitorId) -> &'static str {
    [
        (FOLLOWING_ERROR, "following error"),
        (HOMING_FOLLOWING_ERROR, "homing following error"),
        (HOMING_END_STOP, "homing end stop"),
        (END_STOP, "end stop"),
        (PAUSE, "pause"),
        (RESUME, "resume"),
    ]
    .iter()
    .find(|(id, _)| *id == m)
    .map_or("?", |(_, n)| n)
}

fn cause_text(seq: &Seqr, c: Cause) -> String {
    match c {
        Cause::Start => "start".into(),
        Cause::PreConditionFalse => "pre-condition false".into(),
        Cause::Completed => "completed".into(),
        Cause::Pause => "pause".into(),
        Cause::Resume => "resume".into(),
        Cause::Abort => "abort".into(),
        Cause::AbortAll => "abort all".into(),
        Cause::Monitor(m) => format!("monitor {}", monitor_name(m)),
        Cause::Timeout(s) => format!("timeout of {}", seq.sequence_by_id(s).unwrap().name()),
        Cause::Restart => "restart".into(),
        Cause::Dropped => "dropped".into(),
        Cause::Failed => "failed".into(),
    }
}

fn outcome_text(seq: &Seqr, o: Option<SeqOutcome>) -> String {
    match o {
        None => "none".into(),
        Some(SeqOutcome::Completed) => "completed".into(),
        Some(SeqOutcome::Skipped) => "skipped".into(),
        Some(SeqOutcome::Aborted(c)) => format!("aborted ({})", cause_text(seq, c)),
        Some(SeqOutcome::Failed(_)) => "failed".into(),
    }
}

fn opt_ms(t: Option<Instant>) -> String {
    t.map_or("-".into(), |t| (t.as_ticks() / 1000).to_string())
}

/// Runs the demo application on the host simulator until `end_ms` (the firmware's end).
fn host(plan: FaultPlan, end_ms: u64) -> Host {
    host_shuffled(plan, end_ms, None)
}

/// [`host`]; with a `seed`, a task per lane (all of priority 1), in a random order per pass.
fn host_shuffled(plan: FaultPlan, end_ms: u64, seed: Option<u64>) -> Host {
    let seq: &'static Seqr = Box::leak(Box::new(Sequencer::new()));
    let cs: &'static ControlSystem = Box::leak(Box::new(ControlSystem::new(CONFIG.start_position)));
    cs.set_fault_plan(plan);
    let monitors: app::AppMonitors = app::monitor_ids::table(&CONFIG).unwrap();
    let app = app::register(seq, &app::Setup::DEMO).unwrap();
    let mut system = SafetySystem::new(&PROPERTIES, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(seq, cs, monitors);
    if let Some(seed) = seed {
        // A task per lane, polled in a random order per pass: exposes same-tick races.
        sim = sim.shuffle_equal_priorities(seed);
        sim.lane(app.main);
        sim.lane(app.status);
        sim.lane(app.safe_stop);
        sim.lane(app.feed_hold);
        sim.lane(app.feed_resume);
    } else {
        // As the firmware: the five lanes joined in one task (`App::run`).
        let mut app = app;
        let lanes = async move { app.run(seq, cs).await };
        sim.task_with_priority(lanes, rtseq::sim::DEFAULT_LANE_PRIORITY);
    }
    // The firmware's tick: inject, safety cycle (priority 3), control step; then the
    // sequencer tick (done by `step`).
    sim.before_tick(move |now, cs: &ControlSystem| {
        cs.inject(now);
        safety::safety_cycle(cs, &mut system, seq);
        cs.control_step(0.001);
    });
    sim.start(MAIN).unwrap();
    while sim.now().as_ticks() / 1000 < end_ms {
        sim.step();
    }
    assert_eq!(sim.lost(), 0);

    let name = |id: SeqId| seq.sequence_by_id(id).unwrap().name().to_string();
    let state = |s: RunningState| format!("{s:?}");
    let mut blinks = 0;
    let mut trace = Vec::new();
    for t in sim.trace() {
        if t.sequence == BLINK && matches!(t.cause, Cause::Start | Cause::Completed) {
            if t.to == RunningState::Running {
                blinks += 1;
            }
            continue;
        }
        trace.push(Tr {
            ms: t.time.as_ticks() / 1000,
            name: name(t.sequence),
            from: state(t.from),
            to: state(t.to),
            cause: cause_text(seq, t.cause),
        });
    }
    let s = cs.summary();
    let st = cs.status();
    let plant = cs.plant();
    let outcome = |id| outcome_text(seq, sim.handle(id).unwrap().last_outcome());
    let m = sim.monitors();
    let mut r = BTreeMap::new();
    let mut put = |k: &str, v: String| {
        r.insert(k.to_string(), v);
    };
    put("end_ms", end_ms.to_string());
    put(
        "level",
        PROPERTIES
            .level(seq.safety_handle().level())
            .unwrap()
            .name()
            .into(),
    );
    put("phase", phase_name(cs.phase()).into());
    put("main", outcome(MAIN));
    put("homing", outcome(HOMING));
    put("moves", outcome(MOVES));
    put("moves_done", s.moves_done.to_string());
    put("safe_stops", s.safe_stops.to_string());
    put("homed_ms", opt_ms(s.homed_at));
    put("finished_ms", opt_ms(s.finished_at));
    put("paused_ms", opt_ms(s.paused_at));
    put("resumed_ms", opt_ms(s.resumed_at));
    put("blinks", blinks.to_string());
    put(
        "move_done_ms",
        s.move_done_at
            .iter()
            .map(|t| opt_ms(*t))
            .collect::<Vec<_>>()
            .join(","),
    );
    put("fired_fe", m.fired(FOLLOWING_ERROR).to_string());
    put("fired_es", m.fired(END_STOP).to_string());
    put("fired_pause", m.fired(PAUSE).to_string());
    put("fired_resume", m.fired(RESUME).to_string());
    for (k, key) in [
        (FaultKind::FollowingError, "fe"),
        (FaultKind::OverCurrent, "oc"),
        (FaultKind::EndStop, "es"),
        (FaultKind::EStop, "estop"),
    ] {
        let x = s.reaction(k);
        put(&format!("{key}.injected_ms"), opt_ms(x.injected));
        put(&format!("{key}.reacted_ms"), opt_ms(x.reacted));
        put(&format!("{key}.stopped_ms"), opt_ms(x.stopped));
    }
    put("pos_um", ((st.position * 1e6) as i32).to_string());
    put("vel_um_s", ((plant.velocity() * 1e6) as i32).to_string());
    put("current_ma", ((plant.current() * 1e3) as i32).to_string());
    put("enabled", st.enabled.to_string());
    put("brake", st.brake.to_string());
    put("permit", cs.drive_permit().to_string());
    Host { trace, result: r }
}

fn ms(t: u64) -> Instant {
    Instant::from_ticks(t * 1000)
}

/// Runs the demo in QEMU with `args`, expects exit 0, and checks it against the host run
/// of `plan`: identical traces and RESULT values. Returns the QEMU run.
fn demo_equals_host(args: &[&str], plan: FaultPlan) -> Demo {
    let d = parse_demo(run_demo(args));
    expect_exit(&d.out, 0);
    assert_eq!(d.out.malformed, 0, "{}", d.out.transcript());
    assert!(d.has_line("outcome as expected: exit 0"));
    assert!(!d.trace.is_empty(), "{}", d.out.transcript());
    assert_stack_within_its_ceiling(&d);
    let end = d.num("end_ms") as u64;
    let h = host(plan, end);
    if d.trace != h.trace {
        let show = |t: &[Tr]| t.iter().map(|x| format!("{x}\n")).collect::<String>();
        panic!(
            "QEMU and host traces differ for {args:?}\n--- qemu\n{}--- host\n{}",
            show(&d.trace),
            show(&h.trace)
        );
    }
    assert_eq!(
        d.result, h.result,
        "QEMU and host RESULT values differ for {args:?}"
    );
    d
}

/// The deepest the firmware's one stack went in the run (the paint below the deepest frame
/// is intact: `board::stack::peak`), held to a ceiling (docs/footprint.md, "Stack"). The
/// deepest nesting is idle, the tick, the safety task and the application's own code.
fn assert_stack_within_its_ceiling(d: &Demo) {
    let prefix = "demo      stack: ";
    let line = d
        .out
        .lines
        .iter()
        .find(|l| l.message.starts_with(prefix))
        .unwrap_or_else(|| panic!("no stack line:\n{}", d.out.transcript()));
    let bytes: u64 = line.message[prefix.len()..]
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .expect("a number of bytes");
    eprintln!("figure: demo stack at the deepest [bytes] = {bytes}");
    assert!((1..=4_096).contains(&bytes), "demo stack: {bytes} B");
}

/// The motor stands still without current and the drive is off, at the end.
fn assert_motor_stopped(d: &Demo) {
    assert_eq!(d.num("vel_um_s"), 0, "velocity");
    assert!(d.num("current_ma").abs() < 50, "current");
    assert_eq!(d.get("enabled"), "false");
    assert_eq!(d.get("brake"), "true");
}

/// No sequence is still active: every sequence's last transition ends in Terminated or
/// Aborted (or Idle for never-started ones).
fn assert_all_ended(d: &Demo) {
    let mut last: BTreeMap<&str, &Tr> = BTreeMap::new();
    for t in &d.trace {
        last.insert(&t.name, t);
    }
    for (name, t) in last {
        assert!(
            t.to == "Terminated" || t.to == "Aborted",
            "{name} still {} at the end",
            t.to
        );
    }
}

// ---------------------------------------------------------------------------------------
// Scenarios
// ---------------------------------------------------------------------------------------

#[test]
fn demo_without_fault_completes_every_move() {
    let d = demo_equals_host(&[], FaultPlan::NONE);
    assert_eq!(d.get("phase"), "done");
    assert_eq!(d.get("level"), "off");
    assert_eq!(d.get("main"), "completed");
    assert_eq!(d.get("moves"), "completed");
    assert_eq!(d.num("moves_done"), CONFIG.move_count as i64);
    assert_eq!(d.num("safe_stops"), 0);
    assert!(
        !d.get("move_done_ms").contains('-'),
        "{}",
        d.get("move_done_ms")
    );
    // At the last target (10 mm) within the position tolerance (20 µm).
    assert!(
        (d.num("pos_um") - 10_000).abs() <= 20,
        "{}",
        d.get("pos_um")
    );
    assert_motor_stopped(&d);
    assert_all_ended(&d);
    // The safety levels went off -> power on -> homed -> off.
    for l in [
        "safety    level off -> power on",
        "safety    level power on -> homed",
        "safety    level homed -> off",
    ] {
        assert!(d.has_line(l), "{l}\n{}", d.out.transcript());
    }
    // A readable log: periodic axis lines and one line per completed move.
    assert!(
        d.out
            .lines
            .iter()
            .filter(|l| l.message.starts_with("axis "))
            .count()
            >= 25
    );
    assert!(d.has_line("move      8/8 done: in position at"));
}

#[test]
fn demo_following_error_restarts_three_times_then_aborts() {
    let d = demo_equals_host(
        &["--fault", "following-error@3s"],
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(3000) }),
    );
    let moves: Vec<(&str, &str, &str)> = d
        .of("moves")
        .iter()
        .map(|t| (t.from.as_str(), t.to.as_str(), t.cause.as_str()))
        .collect();
    let fe = "monitor following error";
    assert_eq!(
        moves,
        vec![
            ("Idle", "Running", "start"),
            ("Running", "Restarting", fe),
            ("Restarting", "Running", "restart"),
            ("Running", "Restarting", fe),
            ("Restarting", "Running", "restart"),
            ("Running", "Restarting", fe),
            ("Restarting", "Running", "restart"),
            ("Running", "Aborting", fe),
            ("Aborting", "Aborted", fe),
        ]
    );
    // One safe stop per firing, each started by the monitor.
    let safe: Vec<&Tr> = d
        .of("safe stop")
        .into_iter()
        .filter(|t| t.to == "Running")
        .collect();
    assert_eq!(safe.len(), 4);
    assert!(safe.iter().all(|t| t.cause == fe));
    assert_eq!(d.num("fired_fe"), 4);
    assert_eq!(d.num("safe_stops"), 4);
    assert_eq!(d.get("moves"), "aborted (monitor following error)");
    // Main stops the axis, powers off and ends normally, in phase fault.
    assert_eq!(d.get("main"), "completed");
    assert_eq!(d.get("phase"), "fault");
    assert_eq!(d.get("level"), "off");
    assert_eq!(d.num("moves_done"), 3);
    // The jam at 3.000 s hits the axis standing in the dwell after move 3: the following
    // error shows 45 ms after the next move starts (2 mm at 2 m/s² from standstill).
    let next_move = d
        .of("move")
        .into_iter()
        .find(|t| t.to == "Running" && t.ms >= 3000)
        .unwrap()
        .ms;
    let reacted = d.num("fe.reacted_ms") as u64;
    assert!(
        reacted > next_move && reacted - next_move <= 60,
        "{next_move} {reacted}"
    );
    assert!(d.num("fe.stopped_ms") as u64 - reacted <= 25);
    assert_motor_stopped(&d);
    assert_all_ended(&d);
}

#[test]
fn demo_following_error_while_moving_reacts_within_20_ms() {
    let d = demo_equals_host(
        &["--fault", "following-error@2.5s"],
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(2500) }),
    );
    assert_eq!(d.get("moves"), "aborted (monitor following error)");
    let latency = d.num("fe.reacted_ms") - 2500;
    assert!((0..=20).contains(&latency), "{latency}");
    assert_motor_stopped(&d);
}

#[test]
fn demo_overcurrent_enters_emergency_and_aborts_everything() {
    let d = demo_equals_host(
        &["--fault", "overcurrent@5s"],
        FaultPlan::NONE.with(Fault::OverCurrent { at: ms(5000) }),
    );
    assert_eq!(d.get("level"), "emergency");
    assert!(d.has_line("safety    level homed -> emergency"));
    assert!(d.has_line("safety    critical input: over-current"));
    // Detected in the cycle of 5000 ms, level emergency from the next cycle: every running
    // sequence aborted (abort all) at 5001 ms, innermost first.
    let aborted: Vec<(&str, &str)> = d
        .trace
        .iter()
        .filter(|t| t.cause == "abort all" && t.to == "Aborted")
        .map(|t| {
            assert_eq!(t.ms, 5001, "{t}");
            (t.name.as_str(), t.to.as_str())
        })
        .collect();
    for name in ["main", "moves", "move", "status"] {
        assert!(
            aborted.iter().any(|(n, _)| *n == name),
            "{name}: {aborted:?}"
        );
    }
    assert_eq!(d.get("main"), "aborted (abort all)");
    // Main's cleanup hook ends the application in phase fault.
    assert_eq!(d.get("phase"), "fault");
    assert_eq!(d.num("oc.reacted_ms"), 5001);
    assert!(d.num("oc.stopped_ms") - 5000 <= 30);
    assert_eq!(d.get("permit"), "false");
    assert_motor_stopped(&d);
    assert_all_ended(&d);
}

#[test]
fn demo_estop_enters_emergency_and_aborts_everything() {
    let d = demo_equals_host(
        &["--fault", "estop@2s"],
        FaultPlan::NONE.with(Fault::EStop { at: ms(2000) }),
    );
    assert_eq!(d.get("level"), "emergency");
    assert_eq!(d.get("main"), "aborted (abort all)");
    assert_eq!(d.num("estop.reacted_ms"), 2001);
    assert!(d.num("estop.stopped_ms") - 2000 <= 30);
    assert_motor_stopped(&d);
    assert_all_ended(&d);
}

#[test]
fn demo_end_stop_aborts_the_moves() {
    let d = demo_equals_host(
        &["--fault", "endstop@2s"],
        FaultPlan::NONE.with(Fault::EndStop { at: ms(2000) }),
    );
    // Detected in the tick the switch closed: move and moves aborted at once.
    let es = "monitor end stop";
    let aborted: Vec<String> = d
        .trace
        .iter()
        .filter(|t| t.cause == es)
        .map(|t| format!("{} {} {}->{}", t.ms, t.name, t.from, t.to))
        .collect();
    assert_eq!(
        aborted,
        vec![
            "2000 move Running->Aborting",
            "2000 move Aborting->Aborted",
            "2000 moves Running->Aborting",
            "2000 moves Aborting->Aborted",
        ]
    );
    assert_eq!(d.get("moves"), "aborted (monitor end stop)");
    assert_eq!(d.get("main"), "completed");
    assert_eq!(d.get("phase"), "fault");
    assert_eq!(d.num("es.reacted_ms"), 2000);
    // Quick stop from 0.2 m/s at 6 m/s²: about 35 ms.
    assert!(d.num("es.stopped_ms") - 2000 <= 60);
    // The safety system saw the switch too (homed -> power on), then power off.
    assert!(d.has_line("safety    level homed -> power on"));
    assert_eq!(d.get("level"), "off");
    assert_motor_stopped(&d);
    assert_all_ended(&d);
}

#[test]
fn demo_pause_holds_the_move_and_resumes_it_later() {
    let d = demo_equals_host(
        &["--pause", "4s..6s"],
        FaultPlan::NONE.with_pause(ms(4000), ms(6000)),
    );
    let pr: Vec<String> = d
        .trace
        .iter()
        .filter(|t| t.cause == "pause" || t.cause == "resume")
        .map(|t| format!("{} {} {}->{}", t.ms, t.name, t.from, t.to))
        .collect();
    assert_eq!(
        pr,
        vec![
            "4001 moves Running->Paused",
            "4001 move Running->Paused",
            "6001 moves Paused->Running",
            "6001 move Paused->Running",
        ]
    );
    assert_eq!(d.get("paused_ms"), "4000");
    assert_eq!(d.get("resumed_ms"), "6000");
    assert_eq!(d.num("fired_pause"), 1);
    assert_eq!(d.num("fired_resume"), 1);
    // Everything completes, the moves after the pause exactly 2 s later than without it.
    assert_eq!(d.get("phase"), "done");
    assert_eq!(d.num("moves_done"), 8);
    let free = host(FaultPlan::NONE, 7000);
    let times = |s: &str| -> Vec<i64> { s.split(',').map(|x| x.parse().unwrap()).collect() };
    let (paused, plain) = (
        times(d.get("move_done_ms")),
        times(&free.result["move_done_ms"]),
    );
    for i in 0..8 {
        let shift = paused[i] - plain[i];
        if plain[i] < 4000 {
            assert_eq!(shift, 0, "move {i}");
        } else {
            assert!((1990..=2100).contains(&shift), "move {i}: {shift}");
        }
    }
    assert_motor_stopped(&d);
    assert_all_ended(&d);
}

#[test]
fn demo_end_stop_then_overcurrent_after_the_program_ended() {
    // The end stop ends the program at 2 s; the over-current at 3 s finds nothing running
    // but still trips the safety system (level off watches the current too).
    let d = demo_equals_host(
        &["--fault", "endstop@2s", "--fault=overcurrent@3s"],
        FaultPlan::NONE
            .with(Fault::EndStop { at: ms(2000) })
            .with(Fault::OverCurrent { at: ms(3000) }),
    );
    assert_eq!(d.get("moves"), "aborted (monitor end stop)");
    assert_eq!(d.get("main"), "completed");
    assert_eq!(d.get("level"), "emergency");
    assert!(d.has_line("safety    level off -> emergency"));
    assert_eq!(d.num("end_ms"), 3300);
    assert_motor_stopped(&d);
}

// Review E: runs whose outcome the demo's model once mispredicted (exit 1 for a correct
// run); each must exit 0 and equal the host run.

fn fe(t: u64) -> Fault {
    Fault::FollowingError { at: ms(t) }
}

fn es(t: u64) -> Fault {
    Fault::EndStop { at: ms(t) }
}

#[test]
fn demo_jam_within_the_back_off_tolerance_lets_homing_complete() {
    // A jam in the last ms of homing, within the back off's in-position tolerance: homing
    // completes, the jam shows in the first move (as a jam just after homing does); in the
    // last ms of the back off's approach the axis is 24 µm short and homing times out.
    // (1126 and 1119 ms: 1130 and 1123 ms before homing zeroed at the switch's latched
    // edge, F1; the back off is then ~0.1 mm longer and its axis sticks 15 µm short of the
    // target, not 20 µm, so it settles 3 ms earlier.)
    let d = demo_equals_host(&["--fault", "fe@1126ms"], FaultPlan::NONE.with(fe(1126)));
    assert_eq!(d.get("homing"), "completed");
    assert_eq!(d.get("moves"), "aborted (monitor following error)");
    assert_eq!(d.num("fired_fe"), 4);
    let d = demo_equals_host(&["--fault", "fe@1119ms"], FaultPlan::NONE.with(fe(1119)));
    assert_eq!(d.get("homing"), "aborted (timeout of homing)");
}

#[test]
fn demo_jam_or_wrong_end_stop_while_homing_aborts_homing_at_once() {
    // Domain review S1: homing is supervised. A jam during the seek trips homing's
    // following-error monitor (2 mm at 20 mm/s: ~0.1 s), the positive end stop (the wrong
    // one for homing) its end-stop monitor in the tick it closes; the moves never run.
    let d = demo_equals_host(&["--fault", "fe@500ms"], FaultPlan::NONE.with(fe(500)));
    assert_eq!(d.get("homing"), "aborted (monitor homing following error)");
    assert_eq!(d.get("moves"), "none");
    assert_eq!(d.get("phase"), "fault");
    let latency = d.num("fe.reacted_ms") - 500;
    assert!((0..=150).contains(&latency), "{latency}");
    assert_motor_stopped(&d);
    let d = demo_equals_host(&["--fault", "endstop@500ms"], FaultPlan::NONE.with(es(500)));
    assert_eq!(d.get("homing"), "aborted (monitor homing end stop)");
    assert_eq!(d.get("moves"), "none");
    assert_motor_stopped(&d);
}

#[test]
fn demo_end_stop_in_the_last_dwell_aborts_the_moves() {
    // The end-stop monitor belongs to the moves, dwell included: it aborts them though
    // every move is done.
    let d = demo_equals_host(
        &["--fault", "endstop@6.45s"],
        FaultPlan::NONE.with(es(6450)),
    );
    assert_eq!(d.get("moves"), "aborted (monitor end stop)");
    assert_eq!(d.num("moves_done"), 8);
    assert_eq!(d.get("phase"), "fault");
}

#[test]
fn demo_end_stop_overtakes_a_following_error_s_restarts() {
    // An end stop during a following error's restarts aborts the moves at once...
    for (t, fired) in [(2510, 0), (2530, 1), (2654, 4)] {
        let arg = format!("endstop@{t}ms");
        let d = demo_equals_host(
            &["--fault", "fe@2.5s", "--fault", &arg],
            FaultPlan::NONE.with(fe(2500)).with(es(t)),
        );
        assert_eq!(d.get("moves"), "aborted (monitor end stop)", "{arg}");
        assert_eq!(d.num("fired_fe"), fired, "{arg}");
    }
    // ... unless the restart limit's abort is due in its tick (the last safe stop ended).
    let d = demo_equals_host(
        &["--fault", "fe@2.5s", "--fault", "endstop@2655ms"],
        FaultPlan::NONE.with(fe(2500)).with(es(2655)),
    );
    assert_eq!(d.get("moves"), "aborted (monitor following error)");
    assert_eq!(d.num("fired_es"), 0);
    // Both in one tick, either order on the command line: the end stop decides.
    for args in [
        ["--fault", "fe@3s", "--fault", "endstop@3s"],
        ["--fault", "endstop@3s", "--fault", "fe@3s"],
    ] {
        let d = demo_equals_host(&args, FaultPlan::NONE.with(fe(3000)).with(es(3000)));
        assert_eq!(d.get("moves"), "aborted (monitor end stop)", "{args:?}");
    }
}

#[test]
fn demo_overcurrent_in_the_power_off_tick_finds_main_ended() {
    // Main completes in the power-off tick; the trip comes one safety cycle later and is
    // the reaction (not the power off's withdrawal of the permit). Nothing is left to
    // abort but the status sequence, which switches the LED off.
    let d = demo_equals_host(
        &["--fault", "oc@6541ms"],
        FaultPlan::NONE.with(Fault::OverCurrent { at: ms(6541) }),
    );
    assert_eq!(d.get("main"), "completed");
    assert_eq!(d.get("phase"), "done");
    assert_eq!(d.get("level"), "emergency");
    assert_eq!(d.num("oc.reacted_ms"), 6542);
    assert!(d.has_line("| done, level emergency, LED off"));
}

#[test]
fn demo_overcurrent_at_power_up_reacts_at_the_trip() {
    // The first safety cycle withdraws the permit the control system starts with; the
    // reaction is the trip in the second. Main's and status's cleanup hooks: phase fault,
    // LED off.
    let d = demo_equals_host(
        &["--fault", "oc@0s"],
        FaultPlan::NONE.with(Fault::OverCurrent { at: ms(0) }),
    );
    assert_eq!(d.num("oc.reacted_ms"), 2);
    assert_eq!(d.get("phase"), "fault");
    assert!(d.has_line("| fault, level emergency, LED off"));
}

#[test]
fn demo_rejects_bad_options_with_a_clear_error() {
    for (args, msg) in [
        (&["--fault", "bogus@3s"][..], "demo: unknown fault"),
        (&["--fault", "overcurrent@5"][..], "demo: bad time"),
        (
            &["--pause", "6s..4s"][..],
            "demo: the pause must end after it starts",
        ),
        (&["--speed", "2"][..], "demo: unknown option"),
        (&["--fault"][..], "demo: option needs a value"),
        // Three dots: not read as the window 4 s .. 0.6 s.
        (
            &["--pause", "4s...6s"][..],
            "demo: bad pause window: START..END is two times with two dots between, e.g. 4s..6s: '4s...6s'",
        ),
        (&["--pause", "..6s"][..], "demo: bad pause window: START..END"),
        // During homing (the moves start in the tick of 1140 ms) or after the last move
        // (done in the tick of 6437 ms): nothing to hold.
        (
            &["--pause", "0.5s..2s"][..],
            "demo: the pause window must start after homing: the moves run from 1.141s to 6.436s: '0.5s..2s'",
        ),
        (
            &["--pause", "1140ms..2s"][..],
            "demo: the pause window must start after homing",
        ),
        (
            &["--pause", "7s..8s"][..],
            "demo: the pause window must start before the run's last move is done: the moves run from 1.141s to 6.436s: '7s..8s'",
        ),
        (
            &["--pause", "6437ms..7s"][..],
            "demo: the pause window must start before the run's last move is done",
        ),
        // After a fault (in either order on the command line).
        (
            &["--fault", "estop@2s", "--pause", "4s..6s"][..],
            "demo: the pause window must start before the first fault (a fault ends the moves): '4s..6s'",
        ),
        (
            &["--pause", "4s..6s", "--fault=endstop@4s"][..],
            "demo: the pause window must start before the first fault",
        ),
    ] {
        let d = parse_demo(run_demo(args));
        expect_exit(&d.out, 1);
        let l = d
            .out
            .find(msg)
            .unwrap_or_else(|| panic!("{args:?}: no {msg:?}\n{}", d.out.transcript()));
        assert_eq!(l.level, Some("ERROR"));
        assert!(d.trace.is_empty(), "{args:?} ran the application");
    }
    let help = parse_demo(run_demo(&["--help"]));
    expect_exit(&help.out, 0);
    assert!(help.out.find("usage: ./x demo").is_some());
}

/// The command line (program name `demo`, the arguments, one space between each, and the
/// final NUL) must fit the firmware's 256-byte buffer; a longer one is an error, not a run
/// without its options. `--fault estop@2s` padded with spaces to `len` bytes.
fn padded_estop(len: usize) -> Vec<String> {
    let head = "demo --fault estop@2s ".len();
    vec![
        "--fault".to_string(),
        "estop@2s".to_string(),
        " ".repeat(len - head),
    ]
}

#[test]
fn demo_rejects_a_command_line_longer_than_its_buffer() {
    for len in [256, 322] {
        let args = padded_estop(len);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let d = parse_demo(run_demo(&args));
        expect_exit(&d.out, 1);
        let msg = "demo: the command line is longer than the firmware's 256-byte buffer (program name, arguments and spaces): nothing was run";
        let l = d
            .out
            .find(msg)
            .unwrap_or_else(|| panic!("{len}: no {msg:?}\n{}", d.out.transcript()));
        assert_eq!(l.level, Some("ERROR"));
        assert!(d.trace.is_empty(), "{len}: ran the application");
        assert!(!d.has_line("FAULT"), "{len}");
    }
    // 255 bytes and the NUL fit: the e-stop is injected (the spaces are no arguments).
    let args = padded_estop(255);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let d = demo_equals_host(&args, FaultPlan::NONE.with(Fault::EStop { at: ms(2000) }));
    assert_eq!(d.get("level"), "emergency");
    assert_eq!(d.num("estop.reacted_ms"), 2001);
}

#[test]
fn the_demo_s_pause_limits_are_the_fault_free_run_s() {
    // demo.rs's HOMED_MS and LAST_MOVE_DONE_MS.
    let h = host(FaultPlan::NONE, 7000);
    assert_eq!(h.result["homed_ms"], "1140");
    assert_eq!(
        h.result["move_done_ms"].rsplit(',').next(),
        Some("6437"),
        "{}",
        h.result["move_done_ms"]
    );
}

#[test]
fn demo_pause_windows_at_the_limits_hold_a_move() {
    // The first and the last millisecond accepted for the first press.
    for (args, start, end) in [
        (["--pause", "1141ms..1300ms"], 1141, 1300),
        (["--pause", "6436ms..6600ms"], 6436, 6600),
    ] {
        let d = demo_equals_host(&args, FaultPlan::NONE.with_pause(ms(start), ms(end)));
        assert_eq!(d.num("paused_ms"), start as i64, "{args:?}");
        assert_eq!(d.num("resumed_ms"), end as i64, "{args:?}");
        assert_eq!(d.num("moves_done"), 8, "{args:?}");
        assert_eq!(d.get("phase"), "done", "{args:?}");
    }
}

#[test]
fn the_demo_depends_on_the_order_of_its_lanes_only_for_the_status_blinks() {
    // Lanes woken in the same tick, polled in a random order per pass: the same traces and
    // results as in RTIC's order, for the fault-free run, a pause and each kind of fault,
    // except the number of status blinks with a pause (35 or 36, found by this test; the
    // cause is not analysed yet: some lanes woken in the same tick decide it by their order).
    let plans = [
        (FaultPlan::NONE, 7000, &[32][..]),
        (
            FaultPlan::NONE.with_pause(ms(4000), ms(6000)),
            9000,
            &[35, 36][..],
        ),
        (
            FaultPlan::NONE.with(Fault::FollowingError { at: ms(3000) }),
            7000,
            &[18][..],
        ),
        (
            FaultPlan::NONE.with(Fault::EndStop { at: ms(2000) }),
            3000,
            &[14][..],
        ),
        (
            FaultPlan::NONE.with(Fault::EStop { at: ms(2000) }),
            3000,
            &[14][..],
        ),
    ];
    for (plan, end, blinks) in plans {
        let fixed = host(plan, end);
        let mut seen = std::collections::BTreeSet::new();
        for seed in 0..8 {
            let mut shuffled = host_shuffled(plan, end, Some(seed));
            assert_eq!(shuffled.trace, fixed.trace, "end {end}, seed {seed}");
            seen.insert(shuffled.result.remove("blinks").unwrap());
            shuffled
                .result
                .insert("blinks".into(), fixed.result["blinks"].clone());
            assert_eq!(shuffled.result, fixed.result, "end {end}, seed {seed}");
        }
        seen.insert(fixed.result["blinks"].clone());
        let want: std::collections::BTreeSet<String> =
            blinks.iter().map(|b| b.to_string()).collect();
        assert_eq!(seen, want, "end {end}");
    }
}
