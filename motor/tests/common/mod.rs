//! Test harness: the application on the host simulator, with or without the safety system.
#![allow(dead_code)]

use rtseq::safety::{SafetyHandle, SafetySystem};
use rtseq::sim::Sim;
use rtseq::{Duration, Instant, Outcome, RunningState, SeqId, Sequencer, Transition};
use rtseq_motor::app::{self, AppConfig, FaultPlan};
use rtseq_motor::control_system::ControlSystem;
use rtseq_motor::controller::DriveLimits;
use rtseq_motor::safety::{self, PROPERTIES};

/// The application's ids, for the tests.
#[allow(unused_imports)]
pub use rtseq_motor::app::monitor_ids::{
    END_STOP, FOLLOWING_ERROR, HOMING_END_STOP, HOMING_FOLLOWING_ERROR, PAUSE, RESUME,
};
pub use rtseq_motor::app::seq_ids::*;

pub const N: usize = app::SEQUENCES;
pub const M: usize = app::MONITORS;
pub type Seqr = Sequencer<ControlSystem, N, 256>;
pub type AppSim = Sim<'static, ControlSystem, N, 256, M, app::AppCondition>;

pub struct World {
    pub sim: AppSim,
    pub seq: &'static Seqr,
    pub cs: &'static ControlSystem,
    pub safety: Option<&'static SafetyHandle>,
}

/// The application for `config` (fault plan `plan`) registered into a leaked sequencer and
/// control system, with its lanes in a host simulation (no tick hook yet).
pub fn app_sim(
    plan: FaultPlan,
    config: AppConfig,
) -> (AppSim, &'static Seqr, &'static ControlSystem) {
    app_sim_with_drive(plan, config, DriveLimits::SIMULATED)
}

/// Like [`app_sim`], with a control system for a drive with the limits `drive`
/// (`ControlSystem::with_drive`).
pub fn app_sim_with_drive(
    plan: FaultPlan,
    config: AppConfig,
    drive: DriveLimits,
) -> (AppSim, &'static Seqr, &'static ControlSystem) {
    let cs = ControlSystem::with_drive(config.start_position, drive);
    let (mut sim, seq, cs, app) = registered_with(plan, config, cs);
    sim.lane(app.main);
    sim.lane(app.status);
    sim.lane(app.safe_stop);
    sim.lane(app.feed_hold);
    sim.lane(app.feed_resume);
    (sim, seq, cs)
}

/// Like [`app_sim`], with the five lanes joined in one task (`App::run`, `rtseq::lanes!`).
pub fn app_sim_joined(
    plan: FaultPlan,
    config: AppConfig,
) -> (AppSim, &'static Seqr, &'static ControlSystem) {
    let (mut sim, seq, cs, app) = registered(plan, config);
    let mut app = app;
    let lanes = async move { app.run(seq, cs).await };
    sim.task_with_priority(lanes, rtseq::sim::DEFAULT_LANE_PRIORITY);
    (sim, seq, cs)
}

/// The application registered into a leaked sequencer and control system, and a simulation
/// of them without lanes.
fn registered(
    plan: FaultPlan,
    config: AppConfig,
) -> (AppSim, &'static Seqr, &'static ControlSystem, app::App) {
    registered_with(plan, config, ControlSystem::new(config.start_position))
}

/// [`registered`] with the control system `cs`.
fn registered_with(
    plan: FaultPlan,
    config: AppConfig,
    cs: ControlSystem,
) -> (AppSim, &'static Seqr, &'static ControlSystem, app::App) {
    let seq: &'static Seqr = Box::leak(Box::new(Sequencer::new()));
    let cs: &'static ControlSystem = Box::leak(Box::new(cs));
    cs.set_fault_plan(plan);
    let monitors: app::AppMonitors<M> = app::monitor_ids::table(&config).unwrap();
    let setup = app::Setup::new(config).unwrap();
    let app = app::register(seq, &setup).unwrap();
    (Sim::new(seq, cs, monitors), seq, cs, app)
}

pub fn ms(t: u64) -> Instant {
    Instant::from_ticks(t * 1000)
}

pub fn to_ms(t: Instant) -> u64 {
    t.as_ticks() / 1000
}

impl World {
    pub fn new(plan: FaultPlan, with_safety: bool) -> World {
        Self::with_config(plan, with_safety, AppConfig::DEFAULT)
    }

    pub fn with_config(plan: FaultPlan, with_safety: bool, config: AppConfig) -> World {
        let (mut sim, seq, cs) = app_sim(plan, config);
        let safety = if with_safety {
            let handle = seq.safety_handle();
            let mut system = SafetySystem::new(&PROPERTIES, handle).unwrap();
            sim.before_tick(move |now, cs: &ControlSystem| {
                cs.inject(now);
                safety::safety_cycle(cs, &mut system, seq);
                cs.control_step(0.001);
            });
            Some(handle)
        } else {
            sim.before_tick(|now, cs: &ControlSystem| cs.control_tick(now, 0.001));
            None
        };
        World {
            sim,
            seq,
            cs,
            safety,
        }
    }

    /// Starts main and runs until everything is idle (at most 15 s); returns the end time.
    pub fn run(&mut self) -> u64 {
        self.run_sampling(|_| {})
    }

    /// Like [`run`](Self::run), calling `sample` after every tick.
    pub fn run_sampling(&mut self, mut sample: impl FnMut(&World)) -> u64 {
        self.sim.start(MAIN).unwrap();
        let limit = ms(15_000);
        while self.sim.any_active() {
            assert!(
                self.sim.now() < limit,
                "the application did not end within 15 s"
            );
            self.sim.step();
            sample(self);
        }
        assert!(!self.sim.stalled());
        assert_eq!(self.sim.lost(), 0);
        to_ms(self.sim.now())
    }

    /// Lets the plant run on for `d` ms after the sequences ended.
    pub fn settle(&mut self, d: u64) {
        self.sim.run_for(Duration::from_millis(d));
    }

    pub fn outcome(&self, id: SeqId) -> Option<Outcome> {
        self.sim.handle(id).unwrap().last_outcome()
    }

    pub fn state(&self, id: SeqId) -> RunningState {
        self.sim.state(id)
    }

    pub fn name(&self, id: SeqId) -> &'static str {
        self.seq.sequence_by_id(id).unwrap().name()
    }

    /// The transitions of one sequence.
    pub fn of(&self, id: SeqId) -> Vec<Transition> {
        self.sim
            .trace()
            .iter()
            .filter(|t| t.sequence == id)
            .copied()
            .collect()
    }

    pub fn show(&self) -> String {
        self.sim
            .trace()
            .iter()
            .map(|t| {
                format!(
                    "{:>6} ms  {:<16} {:?} -> {:?} ({:?})\n",
                    to_ms(t.time),
                    self.name(t.sequence),
                    t.from,
                    t.to,
                    t.cause
                )
            })
            .collect()
    }
}
