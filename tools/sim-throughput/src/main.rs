//! Host simulator throughput: simulated ticks per second of host time, one thread.
//!
//! * `bench tree`: `bench_seq`'s `SEQ8` on `rtseq::sim::Sim` — 8 running sequences, each
//!   with 4 rising-edge flag monitors that stay false and an exit condition that stays
//!   false, 2 ms polling, 1 ms ticks;
//! * `motor demo`: the motor-controller application (`rtseq-motor`, as its host tests build
//!   it, without the safety system) from the start of `main` until every sequence is idle,
//!   the plant and the control law stepped before each tick, repeated.
//!
//! `cargo run --release --manifest-path tools/sim-throughput/Cargo.toml` (./x bench runs it).
//! Prints `sim_throughput <name> ticks_per_s=<n> ticks=<n> seconds=<s>`.

use std::time::Instant as HostInstant;

use rtseq::lock::{Lock, SingleThread};
use rtseq::sim::Sim;
use rtseq::{Behaviour, Duration, Monitor, Monitors, SeqConfig, Sequencer};
use rtseq_motor::app::seq_ids::MAIN;
use rtseq_motor::app::{self, AppConfig, FaultPlan};
use rtseq_motor::control_system::ControlSystem;
use rtseq_scenarios::{Ctrl, FlagCond, Node};

/// Flag 8 stays false (the monitors), flag 15 too (the exit conditions).
const QUIET: u8 = 8;
const NEVER: u8 = 15;

fn report(name: &str, ticks: u64, secs: f64) {
    println!(
        "sim_throughput {name} ticks_per_s={:.0} ticks={ticks} seconds={secs:.3}",
        ticks as f64 / secs
    );
}

/// The 8 × 4 tree in `seq`, run for `ticks` ticks.
fn bench_tree<L: Lock>(seq: &Sequencer<Ctrl, 8, 64, L>, ticks: u64) -> f64 {
    let ctrl = Ctrl::new();
    let mut monitors: Monitors<'_, Ctrl, 32, FlagCond> = Monitors::new();
    let names = ["s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7"];
    let mut seqs = Vec::new();
    for name in names {
        let s = seq
            .add(
                SeqConfig::new(name).polling(Duration::from_millis(2)),
                Node::new().exit(NEVER),
            )
            .expect("add");
        for _ in 0..4 {
            monitors
                .add(
                    s.id(),
                    Monitor::with_condition(
                        "quiet",
                        FlagCond { flag: QUIET },
                        Behaviour::AbortOwner,
                    ),
                )
                .expect("monitor");
        }
        seqs.push(s);
    }
    let ids: Vec<_> = seqs.iter().map(|s| s.id()).collect();
    let mut sim = Sim::new(seq, &ctrl, monitors);
    for s in seqs {
        sim.lane(s);
    }
    for id in ids {
        sim.start(id).expect("start");
    }
    sim.step();
    let t0 = HostInstant::now();
    for _ in 0..ticks {
        sim.step();
    }
    let secs = t0.elapsed().as_secs_f64();
    assert_eq!(sim.lost(), 0);
    assert!(sim.any_active(), "the 8 sequences still run");
    secs
}

/// One run of the motor demo in `seq` to the end; returns (ticks, seconds).
fn motor_once<L: Lock>(seq: &Sequencer<ControlSystem, { app::SEQUENCES }, 256, L>) -> (u64, f64) {
    let config = AppConfig::DEFAULT;
    let cs: &'static ControlSystem = Box::leak(Box::new(ControlSystem::new(config.start_position)));
    cs.set_fault_plan(FaultPlan::NONE);
    let monitors: app::AppMonitors = app::monitor_ids::table(&config).expect("monitors");
    let setup = app::Setup::new(config).expect("setup");
    let registered = app::register(seq, &setup).expect("register");
    let mut sim = Sim::new(seq, cs, monitors);
    sim.lane(registered.main);
    sim.lane(registered.status);
    sim.lane(registered.safe_stop);
    sim.lane(registered.feed_hold);
    sim.lane(registered.feed_resume);
    sim.before_tick(|now, cs: &ControlSystem| cs.control_tick(now, 0.001));
    sim.start(MAIN).expect("start main");
    let t0 = HostInstant::now();
    let mut ticks = 0;
    while sim.any_active() && ticks < 60_000 {
        sim.step();
        ticks += 1;
    }
    let secs = t0.elapsed().as_secs_f64();
    assert!(!sim.any_active(), "the demo ends");
    (ticks, secs)
}

/// The motor demo, repeated for a second; returns (ticks, seconds).
fn motor<L: Lock>(
    fresh: impl Fn() -> Sequencer<ControlSystem, { app::SEQUENCES }, 256, L>,
) -> (u64, f64) {
    let (mut ticks, mut secs) = (0, 0.0);
    while secs < 1.0 {
        let (t, s) = motor_once(&fresh());
        ticks += t;
        secs += s;
    }
    (ticks, secs)
}

fn main() {
    const TREE_TICKS: u64 = 2_000_000;
    // The default lock (critical sections: on the host, a global mutex), and no lock at all
    // (`SingleThread`: a sequencer one thread uses alone, as a host test does).
    let secs = bench_tree(&Sequencer::<Ctrl, 8, 64>::new(), TREE_TICKS);
    report("bench_tree_8x4", TREE_TICKS, secs);
    let secs = bench_tree(
        &Sequencer::<Ctrl, 8, 64, SingleThread>::single_thread(),
        TREE_TICKS,
    );
    report("bench_tree_8x4_single_thread", TREE_TICKS, secs);
    let (ticks, secs) = motor(Sequencer::new);
    report("motor_demo", ticks, secs);
    let (ticks, secs) = motor(Sequencer::single_thread);
    report("motor_demo_single_thread", ticks, secs);
}
