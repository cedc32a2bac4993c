//! Shared by the tests: the recorded demo log, the same run on the host simulator.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use rtseq::safety::SafetySystem;
use rtseq::sim::Sim;
use rtseq::{Instant, Sequencer};
use rtseq_motor::app::seq_ids::MAIN;
use rtseq_motor::app::{self, AppConfig, Fault, FaultPlan};
use rtseq_motor::control_system::ControlSystem;
use rtseq_motor::safety::{self, PROPERTIES};
use rtseq_trace::log::{Hints, LogParser};
use rtseq_trace::model::Run;

pub fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `./x demo --fault following-error@2.5s`, decoded, as printed (qemu-run's stdout).
pub fn fixture_text() -> String {
    std::fs::read_to_string(manifest_dir().join("tests/fixtures/demo-following-error.log")).unwrap()
}

/// The callers of the demo's sequences (`demo.tree`, what `./x demo` passes).
pub fn demo_hints() -> Hints {
    Hints::parse(&std::fs::read_to_string(manifest_dir().join("demo.tree")).unwrap()).unwrap()
}

/// The fixture, read with the demo's caller hints.
pub fn fixture_run() -> Run {
    LogParser::parse_all(&fixture_text(), demo_hints())
}

/// A scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("rtseq-trace-{}-{n}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the demo application with the following error at 2.5 s on the host simulator
/// until `end_ms` (as tests/qemu_demo.rs does) and saves its trace; returns the file.
pub fn host_following_error_trace(end_ms: u64) -> PathBuf {
    type Seqr = Sequencer<ControlSystem, { app::SEQUENCES }, 256>;
    let config = AppConfig::DEMO;
    let seq: &'static Seqr = Box::leak(Box::new(Sequencer::new()));
    let cs: &'static ControlSystem = Box::leak(Box::new(ControlSystem::new(config.start_position)));
    cs.set_fault_plan(FaultPlan::NONE.with(Fault::FollowingError {
        at: Instant::from_ticks(2_500_000),
    }));
    let monitors: app::AppMonitors = app::monitor_ids::table(&config).unwrap();
    let app = app::register(seq, &app::Setup::DEMO).unwrap();
    let mut system = SafetySystem::new(&PROPERTIES, seq.safety_handle()).unwrap();
    let mut sim = Sim::new(seq, cs, monitors);
    sim.name_safety(&PROPERTIES);
    sim.lane(app.main);
    sim.lane(app.status);
    sim.lane(app.safe_stop);
    sim.lane(app.feed_hold);
    sim.lane(app.feed_resume);
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
    let path = scratch("host").join("host.jsonl");
    sim.save_trace(&path).unwrap();
    path
}
