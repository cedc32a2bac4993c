//! A two-axis gluing cell, as a newcomer built it from the user docs only (README, firmware
//! guide, semantics, safety, the homing example, rustdoc; a cold review, session 58): a
//! normal cycle, faults, the door's hold, the e-stop and reruns, on exact traces and times.
//!
//! Plant: per axis a commanded position `cmd` that integrates the commanded velocity (or
//! moves towards a target at a fixed speed) every 1 ms tick while the drives are enabled and
//! the door is closed, and a measured position `pos` that follows `cmd` unless the axis is
//! jammed. The end-stop switch closes at `pos <= 0` (unless broken). Units: µm, µm per tick.
//!
//! Tree:
//! main (lane) ── power on (step) ─ run (step) ─ start home x / home y ─ join both
//!             ── pump (seq, may fail) ─ glue path (seq: move 1..4, steps with timeouts)
//!             ── pump off (step) ─ power down (step)
//! home x / home y (lanes, 1 s timeout, exception stop x / stop y): seek, back off, zero
//! monitors: following error x / y (owner glue path, RestartOwner, limit 2, exception
//! stop x / stop y), door (owner main, PauseOwner)
//! safety: emergency < off < ready < running; e-stop input; abort-all on entering emergency.

use core::cell::Cell;

use rtseq::safety::*;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Error, Failure, Failures, Instant, Monitor, MonitorId,
    Monitors, Outcome, RunningState, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step, WithNames,
};

// ---------------------------------------------------------------------------------------
// Safety system
// ---------------------------------------------------------------------------------------

const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
const OFF: SafetyLevel = SafetyLevel::new(1);
const READY: SafetyLevel = SafetyLevel::new(2);
const RUNNING: SafetyLevel = SafetyLevel::new(3);

const POWER_ON: PublicEvent = PublicEvent::new(0);
const START: PublicEvent = PublicEvent::new(1);
const STOP: PublicEvent = PublicEvent::new(2);
const RESET: PublicEvent = PublicEvent::new(3);
const ESTOP: PrivateEvent = PrivateEvent::new(0);

const ESTOP_IN: CriticalInput<bool> = CriticalInput::new(0, "e-stop");
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "drive enable");

struct Io {
    estop: bool,
    enable: bool,
}
impl SafetyIo for Io {
    fn read_input(&mut self, _: InputId) -> IoValue {
        self.estop.into()
    }
    fn write_output(&mut self, _: OutputId, value: IoValue) {
        self.enable = value == IoValue::Bool(true);
    }
}

static PROPS: ValidProperties<'static, Io, 4> = match SafetyProperties::new(
    [
        LevelDef::new(EMERGENCY, "emergency")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(false)])
            .abort_sequences(AbortPolicy::OnEntry),
        LevelDef::new(OFF, "off")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(false)]),
        LevelDef::new(READY, "ready")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(true)]),
        LevelDef::new(RUNNING, "running")
            .inputs(&[ESTOP_IN.check(false, ESTOP)])
            .outputs(&[ENABLE.set(true)]),
    ],
    &[ESTOP_IN.info()],
    &[ENABLE.info()],
    &[
        LevelTransition::on_level_and_above(EMERGENCY, ESTOP, EMERGENCY),
        LevelTransition::on(EMERGENCY, RESET, OFF),
        LevelTransition::on(OFF, POWER_ON, READY),
        LevelTransition::on(READY, START, RUNNING),
        LevelTransition::on(RUNNING, STOP, READY),
    ],
    OFF,
)
.validated()
{
    Ok(valid) => valid,
    Err(_) => panic!("invalid safety properties"),
};

// ---------------------------------------------------------------------------------------
// The machine (control system + simulated plant)
// ---------------------------------------------------------------------------------------

const SEEK_SPEED: i32 = -20; // µm per tick
const BACK_OFF_SPEED: i32 = 10;
const BACK_OFF_UM: i32 = 500;
const MOVE_SPEED: i32 = 50;
const HARD_STOP: i32 = -300;
const FE_LIMIT: i32 = 100;
const PRESSURE_OK: u32 = 50;

#[derive(Default)]
struct AxisPlant {
    cmd: Cell<i32>,
    pos: Cell<i32>,
    vel: Cell<i32>,
    target: Cell<Option<i32>>,
    zero: Cell<i32>,
    switch_broken: Cell<bool>,
    jammed: Cell<bool>,
    slipping: Cell<bool>,
}

impl AxisPlant {
    fn at(p: i32) -> Self {
        let a = Self::default();
        a.cmd.set(p);
        a.pos.set(p);
        a
    }
    fn step(&self, moving: bool) {
        if moving {
            let cmd = self.cmd.get();
            let next = match self.target.get() {
                Some(t) => cmd + (t - cmd).clamp(-MOVE_SPEED, MOVE_SPEED),
                None => cmd + self.vel.get(),
            };
            self.cmd.set(next);
        }
        if self.slipping.get() {
            self.pos.set(self.pos.get() - 60);
        } else if !self.jammed.get() {
            self.pos.set(self.cmd.get().max(HARD_STOP));
        }
    }
    fn switch(&self) -> bool {
        !self.switch_broken.get() && self.pos.get() <= 0
    }
    fn halt(&self) {
        self.target.set(None);
        self.vel.set(0);
        self.cmd.set(self.pos.get()); // the drive's following-error reset
    }
    fn following_error(&self) -> i32 {
        (self.cmd.get() - self.pos.get()).abs()
    }
    fn rel(&self) -> i32 {
        self.pos.get() - self.zero.get()
    }
}

/// Fault windows, in ms of simulated time (start inclusive, end exclusive).
#[derive(Default)]
struct Faults {
    door_open: Cell<Option<(u64, u64)>>,
    jam_x: Cell<Option<(u64, u64)>>,
    estop: Cell<Option<(u64, u64)>>,
    /// The x encoder slips back 60 µm per tick (a following error without motion).
    slip_x: Cell<Option<(u64, u64)>>,
}

struct Machine {
    x: AxisPlant,
    y: AxisPlant,
    door_open: Cell<bool>,
    estop: Cell<bool>,
    enable: Cell<bool>,
    pump_on: Cell<bool>,
    pump_broken: Cell<bool>,
    pressure: Cell<u32>,
    faults: Faults,
}

impl Machine {
    fn new() -> Self {
        Machine {
            x: AxisPlant::at(2_000),
            y: AxisPlant::at(3_000),
            door_open: Cell::new(false),
            estop: Cell::new(false),
            enable: Cell::new(false),
            pump_on: Cell::new(false),
            pump_broken: Cell::new(false),
            pressure: Cell::new(0),
            faults: Faults::default(),
        }
    }
    fn axis(&self, a: Ax) -> &AxisPlant {
        match a {
            Ax::X => &self.x,
            Ax::Y => &self.y,
        }
    }
    /// Fault injection: the windows are applied for the tick at `ms`.
    fn inject(&self, ms: u64) {
        let within = |w: Option<(u64, u64)>| w.is_some_and(|(a, b)| (a..b).contains(&ms));
        self.door_open.set(within(self.faults.door_open.get()));
        self.x.jammed.set(within(self.faults.jam_x.get()));
        self.x.slipping.set(within(self.faults.slip_x.get()));
        self.estop.set(within(self.faults.estop.get()));
    }
    /// The plant, one 1 ms tick. The door is a hardware interlock: no motion while open.
    fn plant(&self) {
        let moving = self.enable.get() && !self.door_open.get();
        self.x.step(moving);
        self.y.step(moving);
        let p = self.pressure.get();
        self.pressure
            .set(if self.pump_on.get() && !self.pump_broken.get() {
                (p + 10).min(100)
            } else {
                0
            });
    }
}

fn halt_x(m: &Machine) {
    m.x.halt();
}
fn halt_y(m: &Machine) {
    m.y.halt();
}
fn halt_all(m: &Machine) {
    m.x.halt();
    m.y.halt();
    m.pump_on.set(false);
}

#[derive(Clone, Copy)]
enum Ax {
    X,
    Y,
}

// ---------------------------------------------------------------------------------------
// Steps and sequences
// ---------------------------------------------------------------------------------------

const NO_SAFETY: u16 = 1;
const HOMING_FAILED: u16 = 2;
const PRESSURE: u16 = 3;
const NOT_RESET: u16 = 4;
const FAILURES: Failures = Failures(&[
    (NO_SAFETY, "no safety system"),
    (HOMING_FAILED, "homing failed"),
    (PRESSURE, "glue pressure not reached"),
    (NOT_RESET, "emergency not reset"),
]);

fn level(cx: &Cx<'_, Machine>) -> SafetyLevel {
    cx.safety_system().map_or(EMERGENCY, |s| s.level())
}

/// Asks the safety system for a level (through a public event) and waits until it is there;
/// skipped if the level is reached already.
struct GoToLevel {
    event: PublicEvent,
    level: SafetyLevel,
}
impl Step<Machine> for GoToLevel {
    fn check_pre_condition(&mut self, cx: &Cx<'_, Machine>) -> bool {
        level(cx) != self.level
    }
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        cx.safety_system()
            .ok_or(Failure::App(NO_SAFETY))?
            .trigger(self.event);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Machine>) -> bool {
        level(cx) == self.level
    }
}

struct Seek(Ax);
impl Step<Machine> for Seek {
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        let a = cx.control().axis(self.0);
        a.target.set(None);
        a.vel.set(SEEK_SPEED);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Machine>) -> bool {
        cx.control().axis(self.0).switch()
    }
}

struct BackOff(Ax);
impl Step<Machine> for BackOff {
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        cx.control().axis(self.0).vel.set(BACK_OFF_SPEED);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Machine>) -> bool {
        let a = cx.control().axis(self.0);
        let done = a.pos.get() >= BACK_OFF_UM;
        if done {
            a.vel.set(0);
        }
        done
    }
}

struct SetZero(Ax);
impl Step<Machine> for SetZero {
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        let a = cx.control().axis(self.0);
        a.vel.set(0);
        a.zero.set(a.pos.get());
        Ok(())
    }
}

struct Homing {
    seek: Seq<Seek>,
    back_off: Seq<BackOff>,
    zero: Seq<SetZero>,
}
impl Sequence<Machine> for Homing {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        cx.step(&mut self.seek).await?;
        cx.step(&mut self.back_off).await?;
        cx.step(&mut self.zero).await?;
        Ok(())
    }
}

/// Both axes to a point relative to their zero; ends in position.
struct MoveTo(i32, i32);
impl Step<Machine> for MoveTo {
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        let m = cx.control();
        m.x.target.set(Some(m.x.zero.get() + self.0));
        m.y.target.set(Some(m.y.zero.get() + self.1));
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Machine>) -> bool {
        let m = cx.control();
        (m.x.rel() - self.0).abs() <= 5 && (m.y.rel() - self.1).abs() <= 5
    }
}

struct GluePath {
    moves: [Seq<MoveTo>; 4],
}
impl Sequence<Machine> for GluePath {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        for m in &mut self.moves {
            cx.step(m).await?;
        }
        Ok(())
    }
}

/// Pump on, glue pressure within 50 ms of run time, else a failure.
struct Pump;
impl Sequence<Machine> for Pump {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        let m = cx.control();
        m.pump_on.set(true);
        let deadline = cx.run_time() + Duration::from_millis(50);
        let ok = |cx: &Cx<'_, Machine>| cx.control().pressure.get() >= PRESSURE_OK;
        cx.wait_until(move |cx| ok(cx) || cx.run_time() >= deadline)
            .await;
        if !ok(cx) {
            m.pump_on.set(false);
            return Err(Failure::App(PRESSURE));
        }
        Ok(())
    }
}

struct PumpOff;
impl Step<Machine> for PumpOff {
    fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        cx.control().pump_on.set(false);
        Ok(())
    }
}

/// The safe stop of one axis (exception sequence).
struct StopAxis(Ax);
impl Sequence<Machine> for StopAxis {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        cx.control().axis(self.0).halt();
        Ok(())
    }
}

struct Main {
    power_on: Seq<GoToLevel>,
    run: Seq<GoToLevel>,
    home_x: SeqId,
    home_y: SeqId,
    pump: Seq<Pump>,
    glue: Seq<GluePath>,
    pump_off: Seq<PumpOff>,
    power_down: Seq<GoToLevel>,
}
impl Sequence<Machine> for Main {
    async fn action(&mut self, cx: &Cx<'_, Machine>) -> Result<(), Failure> {
        if level(cx) == EMERGENCY {
            return Err(Failure::App(NOT_RESET));
        }
        if level(cx) < READY {
            cx.step(&mut self.power_on).await?;
        }
        cx.step(&mut self.run).await?;
        // Both axes home in parallel, each in its lane.
        cx.start(self.home_x)?;
        cx.start(self.home_y)?;
        let x = cx.join(self.home_x).await?;
        let y = cx.join(self.home_y).await?;
        if x != Outcome::Completed || y != Outcome::Completed {
            return Err(Failure::App(HOMING_FAILED));
        }
        cx.run(&mut self.pump).await?;
        cx.run(&mut self.glue).await?;
        cx.step(&mut self.pump_off).await?;
        cx.step(&mut self.power_down).await?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// The cell on the simulator
// ---------------------------------------------------------------------------------------

const N: usize = 32;
type Seqr = Sequencer<Machine, N>;

#[allow(dead_code)]
#[derive(Clone, Copy)]
struct Ids {
    main: SeqId,
    power_on: SeqId,
    run: SeqId,
    power_down: SeqId,
    home_x: SeqId,
    home_y: SeqId,
    seek_x: SeqId,
    back_x: SeqId,
    zero_x: SeqId,
    seek_y: SeqId,
    back_y: SeqId,
    zero_y: SeqId,
    pump: SeqId,
    pump_off: SeqId,
    glue: SeqId,
    moves: [SeqId; 4],
    stop_x: SeqId,
    stop_y: SeqId,
    fe_x: MonitorId,
    fe_y: MonitorId,
    door: MonitorId,
}

type CellSim<'a> = Sim<'a, Machine, N, 64, 4>;

fn ms(t: u64) -> Instant {
    Instant::from_ticks(t * 1_000)
}

/// Builds the cell and hands the simulator to `body`; `setup` configures the machine's
/// faults before anything runs.
fn with_cell<R>(
    setup: impl FnOnce(&Machine),
    body: impl FnOnce(&mut CellSim<'_>, &Seqr, &Ids, &Machine) -> R,
) -> R {
    let seq: Seqr = Sequencer::new();
    let machine = Machine::new();
    setup(&machine);
    let cfg = |name| SeqConfig::<Machine>::new(name).polling(Duration::from_millis(1));

    let stop_x = seq.add(cfg("stop x"), StopAxis(Ax::X)).unwrap();
    let stop_y = seq.add(cfg("stop y"), StopAxis(Ax::Y)).unwrap();
    let homing = |ax: Ax, names: [&'static str; 4], stop: SeqId, halt: fn(&Machine)| {
        let seek = seq.add(cfg(names[0]).on_abort(halt), Seek(ax)).unwrap();
        let back_off = seq.add(cfg(names[1]).on_abort(halt), BackOff(ax)).unwrap();
        let zero = seq.add(cfg(names[2]), SetZero(ax)).unwrap();
        let (s, b, z) = (seek.id(), back_off.id(), zero.id());
        let home = seq
            .add(
                cfg(names[3])
                    .timeout(Duration::from_secs(1))
                    .timeout_exception(stop)
                    .timeout_behaviour(Behaviour::AbortOwner),
                Homing {
                    seek,
                    back_off,
                    zero,
                },
            )
            .unwrap();
        (home, s, b, z)
    };
    let (home_x, seek_x, back_x, zero_x) = homing(
        Ax::X,
        ["seek x", "back off x", "zero x", "home x"],
        stop_x.id(),
        halt_x,
    );
    let (home_y, seek_y, back_y, zero_y) = homing(
        Ax::Y,
        ["seek y", "back off y", "zero y", "home y"],
        stop_y.id(),
        halt_y,
    );

    let level_step = |name, event, level| seq.add(cfg(name), GoToLevel { event, level }).unwrap();
    let power_on = level_step("power on", POWER_ON, READY);
    let run = level_step("run", START, RUNNING);
    let power_down = level_step("power down", STOP, READY);
    let pump = seq.add(cfg("pump"), Pump).unwrap();
    let pump_off = seq.add(cfg("pump off"), PumpOff).unwrap();
    let path = [(2_000, 1_000), (2_000, 3_000), (0, 3_000), (0, 1_000)];
    let names = ["move 1", "move 2", "move 3", "move 4"];
    let moves = [0, 1, 2, 3].map(|i| {
        let c = cfg(names[i])
            .timeout(Duration::from_millis(200))
            .on_abort(halt_all);
        seq.add(c, MoveTo(path[i].0, path[i].1)).unwrap()
    });
    let move_ids = moves.each_ref().map(|m| m.id());
    let glue = seq
        .add(cfg("glue path").on_abort(halt_all), GluePath { moves })
        .unwrap();
    let ids_partial = (
        power_on.id(),
        run.id(),
        power_down.id(),
        pump.id(),
        pump_off.id(),
        glue.id(),
    );
    let main = seq
        .add(
            cfg("main").on_abort(halt_all),
            Main {
                power_on,
                run,
                home_x: home_x.id(),
                home_y: home_y.id(),
                pump,
                glue,
                pump_off,
                power_down,
            },
        )
        .unwrap();

    let mut fe_x = |m: &Machine, _: Instant| m.x.following_error() > FE_LIMIT;
    let mut fe_y = |m: &Machine, _: Instant| m.y.following_error() > FE_LIMIT;
    let mut door = |m: &Machine, _: Instant| m.door_open.get();
    let mut monitors = Monitors::<Machine, 4>::new();
    let fe = |name, c, stop| {
        Monitor::new(name, c, Behaviour::RestartOwner)
            .exception(stop)
            .restart_limit(2)
    };
    let fe_x = monitors
        .add(
            ids_partial.5,
            fe("following error x", &mut fe_x, stop_x.id()),
        )
        .unwrap();
    let fe_y = monitors
        .add(
            ids_partial.5,
            fe("following error y", &mut fe_y, stop_y.id()),
        )
        .unwrap();
    let door = monitors
        .add(
            main.id(),
            Monitor::new("door open", &mut door, Behaviour::PauseOwner),
        )
        .unwrap();

    let ids = Ids {
        main: main.id(),
        power_on: ids_partial.0,
        run: ids_partial.1,
        power_down: ids_partial.2,
        home_x: home_x.id(),
        home_y: home_y.id(),
        seek_x,
        back_x,
        zero_x,
        seek_y,
        back_y,
        zero_y,
        pump: ids_partial.3,
        pump_off: ids_partial.4,
        glue: ids_partial.5,
        moves: move_ids,
        stop_x: stop_x.id(),
        stop_y: stop_y.id(),
        fe_x,
        fe_y,
        door,
    };

    let mut safety = SafetySystem::new_validated(&PROPS, seq.safety_handle()).unwrap();
    let mut sim: CellSim<'_> = Sim::new(&seq, &machine, monitors);
    sim.lane(main);
    sim.lane(home_x);
    sim.lane(home_y);
    sim.lane(stop_x);
    sim.lane(stop_y);
    sim.name_safety(PROPS.properties());
    // As on the chip: faults (the world), the safety cycle, then the control step (plant).
    sim.before_tick(|now, m| m.inject(now.as_ticks() / 1_000));
    let sequences = &seq;
    sim.before_tick(move |_, m| {
        let mut io = Io {
            estop: m.estop.get(),
            enable: m.enable.get(),
        };
        safety.cycle(&mut io, sequences);
        m.enable.set(io.enable);
    });
    sim.before_tick(|_, m| m.plant());
    body(&mut sim, &seq, &ids, &machine)
}

fn lines(sim: &CellSim<'_>, seq: &Seqr) -> Vec<String> {
    let names = (seq, sim.monitors(), PROPS.properties(), &FAILURES);
    sim.records()
        .iter()
        .map(|r| r.named(&names).to_string())
        .collect()
}

/// Lines from (and including) the first that starts with `from`.
fn lines_from(all: &[String], from: &str) -> Vec<String> {
    let i = all.iter().position(|l| l.starts_with(from)).expect(from);
    all[i..].to_vec()
}

fn states(sim: &CellSim<'_>, id: SeqId) -> Vec<(u64, RunningState)> {
    sim.trace()
        .iter()
        .filter(|t| t.sequence == id)
        .map(|t| (t.time.as_ticks() / 1_000, t.to))
        .collect()
}

fn outcome(sim: &CellSim<'_>, id: SeqId) -> Option<Outcome> {
    sim.handle(id).unwrap().last_outcome()
}

// ---------------------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------------------

/// Prints the lines as Rust literals (to write expectations; not a test of its own).
#[allow(dead_code)]
fn literal(lines: &[String]) {
    for l in lines {
        println!("        {l:?},");
    }
}

// ---------------------------------------------------------------------------------------
// Tests. Key times were predicted by hand from the docs before the first run (plant: seek
// 2 000 µm at 20 µm/ms = 100 ms, back off 50 ms, pump 5 ms, each move 40 ms); the full line
// lists were then taken from the run and checked against those predictions.
// ---------------------------------------------------------------------------------------

fn start_and_run(sim: &mut CellSim<'_>, ids: &Ids) -> Option<u64> {
    sim.start(ids.main).unwrap();
    sim.run_until_idle(Duration::from_secs(5))
        .map(|t| t.as_ticks() / 1_000)
}

#[test]
fn a_normal_cycle_powers_up_homes_both_axes_in_parallel_glues_and_powers_down() {
    with_cell(
        |_| {},
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(369));
            assert_eq!(
                lines(sim, seq),
                [
                    "0 ms main: Idle -> Running (start)",
                    "0 ms power on: Idle -> Running (start)",
                    "1 ms safety level off",
                    "2 ms safety level ready",
                    "2 ms power on: Running -> Terminated (completed)",
                    "2 ms run: Idle -> Running (start)",
                    "3 ms safety level running",
                    "3 ms run: Running -> Terminated (completed)",
                    "3 ms home x: Idle -> Running (start)",
                    "3 ms home y: Idle -> Running (start)",
                    "3 ms seek x: Idle -> Running (start)",
                    "3 ms seek y: Idle -> Running (start)",
                    "103 ms seek x: Running -> Terminated (completed)",
                    "103 ms back off x: Idle -> Running (start)",
                    "153 ms back off x: Running -> Terminated (completed)",
                    "153 ms zero x: Idle -> Running (start)",
                    "153 ms zero x: Running -> Terminated (completed)",
                    "153 ms home x: Running -> Terminated (completed)",
                    "153 ms seek y: Running -> Terminated (completed)",
                    "153 ms back off y: Idle -> Running (start)",
                    "203 ms back off y: Running -> Terminated (completed)",
                    "203 ms zero y: Idle -> Running (start)",
                    "203 ms zero y: Running -> Terminated (completed)",
                    "203 ms home y: Running -> Terminated (completed)",
                    "203 ms pump: Idle -> Running (start)",
                    "208 ms pump: Running -> Terminated (completed)",
                    "208 ms glue path: Idle -> Running (start)",
                    "208 ms move 1: Idle -> Running (start)",
                    "248 ms move 1: Running -> Terminated (completed)",
                    "248 ms move 2: Idle -> Running (start)",
                    "288 ms move 2: Running -> Terminated (completed)",
                    "288 ms move 3: Idle -> Running (start)",
                    "328 ms move 3: Running -> Terminated (completed)",
                    "328 ms move 4: Idle -> Running (start)",
                    "368 ms move 4: Running -> Terminated (completed)",
                    "368 ms glue path: Running -> Terminated (completed)",
                    "368 ms pump off: Idle -> Running (start)",
                    "368 ms pump off: Running -> Terminated (completed)",
                    "368 ms power down: Idle -> Running (start)",
                    "369 ms safety level ready",
                    "369 ms power down: Running -> Terminated (completed)",
                    "369 ms main: Running -> Terminated (completed)",
                ]
            );
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
            assert_eq!((m.x.rel(), m.y.rel(), m.pump_on.get()), (0, 1_000, false));
            assert_eq!(seq.safety_handle().level(), READY);
            use RunningState::*;
            assert_eq!(states(sim, ids.glue), [(208, Running), (368, Terminated)]);
        },
    );
}

#[test]
fn a_homing_timeout_stops_the_axis_aborts_its_homing_and_fails_main() {
    with_cell(
        |m| m.y.switch_broken.set(true),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(1_004));
            // X homed meanwhile (153 ms); Y's 1 s timeout (from its start at 3 ms) runs out.
            assert_eq!(
                lines_from(&lines(sim, seq), "1003 ms"),
                [
                    "1003 ms timeout of `home y` ran out: AbortOwner",
                    "1003 ms stop y: Idle -> Running (timeout of `home y`)",
                    "1003 ms stop y: Running -> Terminated (completed)",
                    "1004 ms seek y: Running -> Aborting (timeout of `home y`)",
                    "1004 ms seek y: Aborting -> Aborted (timeout of `home y`)",
                    "1004 ms home y: Running -> Aborting (timeout of `home y`)",
                    "1004 ms home y: Aborting -> Aborted (timeout of `home y`)",
                    "1004 ms main: Running -> Terminated (failed)",
                    "1004 ms `main` failed: homing failed",
                ]
            );
            assert_eq!(outcome(sim, ids.home_x), Some(Outcome::Completed));
            assert_eq!(
                outcome(sim, ids.home_y),
                Some(Outcome::Aborted(Cause::Timeout(ids.home_y)))
            );
            assert_eq!(
                outcome(sim, ids.main),
                Some(Outcome::Failed(Failure::App(HOMING_FAILED)))
            );
            // The safe stop and the cleanup hook stopped Y at the hard stop.
            assert_eq!(
                (m.y.pos.get(), m.y.vel.get(), m.y.following_error()),
                (HARD_STOP, 0, 0)
            );
        },
    );
}

#[test]
fn a_following_error_restarts_the_glue_path_twice_then_it_recovers() {
    with_cell(
        |m| m.faults.jam_x.set(Some((220, 228))),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(377));
            assert_eq!(
                lines_from(&lines(sim, seq), "222 ms")[..16],
                [
                    "222 ms monitor `following error x` of `glue path` fired: RestartOwner",
                    "222 ms stop x: Idle -> Running (monitor `following error x`)",
                    "222 ms stop x: Running -> Terminated (completed)",
                    "223 ms move 1: Running -> Aborting (monitor `following error x`)",
                    "223 ms move 1: Aborting -> Aborted (monitor `following error x`)",
                    "223 ms glue path: Running -> Restarting (monitor `following error x`)",
                    "223 ms glue path: Restarting -> Running (restart)",
                    "223 ms move 1: Aborted -> Running (start)",
                    "226 ms monitor `following error x` of `glue path` fired: RestartOwner",
                    "226 ms stop x: Terminated -> Running (monitor `following error x`)",
                    "226 ms stop x: Running -> Terminated (completed)",
                    "227 ms move 1: Running -> Aborting (monitor `following error x`)",
                    "227 ms move 1: Aborting -> Aborted (monitor `following error x`)",
                    "227 ms glue path: Running -> Restarting (monitor `following error x`)",
                    "227 ms glue path: Restarting -> Running (restart)",
                    "227 ms move 1: Aborted -> Running (start)",
                ]
            );
            assert_eq!(sim.monitors().fired(ids.fe_x), 2);
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
            use RunningState::*;
            assert_eq!(
                states(sim, ids.glue),
                [
                    (208, Running),
                    (223, Restarting),
                    (223, Running),
                    (227, Restarting),
                    (227, Running),
                    (376, Terminated),
                ]
            );
            assert_eq!((m.x.rel(), m.y.rel()), (0, 1_000));
        },
    );
}

#[test]
fn restarts_exhausted_escalate_to_an_abort_of_the_glue_path_and_main_fails() {
    with_cell(
        |m| m.faults.jam_x.set(Some((220, 10_000))),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(231));
            assert_eq!(
                lines_from(&lines(sim, seq), "222 ms"),
                [
                    "222 ms monitor `following error x` of `glue path` fired: RestartOwner",
                    "222 ms stop x: Idle -> Running (monitor `following error x`)",
                    "222 ms stop x: Running -> Terminated (completed)",
                    "223 ms move 1: Running -> Aborting (monitor `following error x`)",
                    "223 ms move 1: Aborting -> Aborted (monitor `following error x`)",
                    "223 ms glue path: Running -> Restarting (monitor `following error x`)",
                    "223 ms glue path: Restarting -> Running (restart)",
                    "223 ms move 1: Aborted -> Running (start)",
                    "226 ms monitor `following error x` of `glue path` fired: RestartOwner",
                    "226 ms stop x: Terminated -> Running (monitor `following error x`)",
                    "226 ms stop x: Running -> Terminated (completed)",
                    "227 ms move 1: Running -> Aborting (monitor `following error x`)",
                    "227 ms move 1: Aborting -> Aborted (monitor `following error x`)",
                    "227 ms glue path: Running -> Restarting (monitor `following error x`)",
                    "227 ms glue path: Restarting -> Running (restart)",
                    "227 ms move 1: Aborted -> Running (start)",
                    "230 ms monitor `following error x` of `glue path` fired: AbortOwner",
                    "230 ms stop x: Terminated -> Running (monitor `following error x`)",
                    "230 ms stop x: Running -> Terminated (completed)",
                    "231 ms move 1: Running -> Aborting (monitor `following error x`)",
                    "231 ms move 1: Aborting -> Aborted (monitor `following error x`)",
                    "231 ms glue path: Running -> Aborting (monitor `following error x`)",
                    "231 ms glue path: Aborting -> Aborted (monitor `following error x`)",
                    "231 ms main: Running -> Terminated (failed)",
                    "231 ms `main` failed: aborted (monitor `following error x`)",
                ]
            );
            let fe = Cause::Monitor(ids.fe_x);
            assert_eq!(outcome(sim, ids.glue), Some(Outcome::Aborted(fe)));
            assert_eq!(
                outcome(sim, ids.main),
                Some(Outcome::Failed(Failure::Aborted(fe)))
            );
            // semantics.md item 3: exceptionIsActive stays after an abort the exception caused.
            let glue = sim.handle(ids.glue).unwrap();
            assert!(glue.exception_is_active());
            assert_eq!(glue.active_exception(), Some(fe));
            // The glue path's cleanup hook: pump off, axes halted.
            assert_eq!(
                (m.pump_on.get(), m.x.target.get(), m.y.target.get()),
                (false, None, None)
            );
        },
    );
}

#[test]
fn an_open_door_pauses_main_and_the_move_and_its_timeout_until_it_closes() {
    with_cell(
        |m| m.faults.door_open.set(Some((260, 1_260))),
        |sim, seq, ids, _| {
            // 1 s open, five times the move's 200 ms timeout: paused time does not count.
            assert_eq!(start_and_run(sim, ids), Some(1_369));
            assert_eq!(
                lines_from(&lines(sim, seq), "260 ms")[..7],
                [
                    "260 ms monitor `door open` of `main` fired: PauseOwner",
                    "260 ms main: Running -> Paused (monitor `door open`)",
                    "260 ms glue path: Running -> Paused (monitor `door open`)",
                    "260 ms move 2: Running -> Paused (monitor `door open`)",
                    "1260 ms main: Paused -> Running (monitor `door open`)",
                    "1260 ms glue path: Paused -> Running (monitor `door open`)",
                    "1260 ms move 2: Paused -> Running (monitor `door open`)",
                ]
            );
            assert_eq!(outcome(sim, ids.moves[1]), Some(Outcome::Completed));
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
            assert_eq!(sim.monitors().fired(ids.door), 1);
        },
    );
}

#[test]
fn an_estop_mid_move_enters_emergency_and_aborts_everything_innermost_first() {
    with_cell(
        |m| m.faults.estop.set(Some((300, 400))),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(301));
            assert_eq!(
                lines_from(&lines(sim, seq), "300 ms"),
                [
                    "300 ms critical input `e-stop` tripped",
                    "301 ms safety level emergency",
                    "301 ms abort-all requested by the safety system",
                    "301 ms move 3: Running -> Aborting (abort-all)",
                    "301 ms move 3: Aborting -> Aborted (abort-all)",
                    "301 ms glue path: Running -> Aborting (abort-all)",
                    "301 ms glue path: Aborting -> Aborted (abort-all)",
                    "301 ms main: Running -> Aborting (abort-all)",
                    "301 ms main: Aborting -> Aborted (abort-all)",
                ]
            );
            assert_eq!(seq.safety_handle().level(), EMERGENCY);
            assert!(!m.enable.get());
            assert_eq!(
                outcome(sim, ids.main),
                Some(Outcome::Aborted(Cause::AbortAll))
            );
            assert_eq!(
                (m.pump_on.get(), m.x.target.get(), m.y.target.get()),
                (false, None, None)
            );
        },
    );
}

#[test]
fn a_pump_without_pressure_fails_and_the_failure_is_handed_up_to_main() {
    with_cell(
        |m| m.pump_broken.set(true),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(253));
            assert_eq!(
                lines_from(&lines(sim, seq), "203 ms pump"),
                [
                    "203 ms pump: Idle -> Running (start)",
                    "253 ms pump: Running -> Terminated (failed)",
                    "253 ms `pump` failed: glue pressure not reached",
                    "253 ms main: Running -> Terminated (failed)",
                    "253 ms `main` failed: glue pressure not reached",
                ]
            );
            assert_eq!(
                outcome(sim, ids.pump),
                Some(Outcome::Failed(Failure::App(PRESSURE)))
            );
            assert_eq!(
                outcome(sim, ids.main),
                Some(Outcome::Failed(Failure::App(PRESSURE)))
            );
            assert!(!m.pump_on.get());
            assert_eq!(seq.safety_handle().level(), RUNNING); // a failure aborts nothing
        },
    );
}

#[test]
fn a_following_error_while_the_door_holds_main_restarts_the_glue_path_at_the_resume() {
    let setup = |m: &Machine| {
        m.faults.door_open.set(Some((260, 1_260)));
        m.faults.slip_x.set(Some((300, 303)));
    };
    with_cell(setup, |sim, seq, ids, _| {
        assert_eq!(start_and_run(sim, ids), Some(1_392));
        // semantics.md item 7: a blocking child whose restart comes below a paused caller
        // stays Restarting; its new round begins when the caller resumes.
        assert_eq!(
            lines_from(&lines(sim, seq), "260 ms")[..13],
            [
                "260 ms monitor `door open` of `main` fired: PauseOwner",
                "260 ms main: Running -> Paused (monitor `door open`)",
                "260 ms glue path: Running -> Paused (monitor `door open`)",
                "260 ms move 2: Running -> Paused (monitor `door open`)",
                "301 ms monitor `following error x` of `glue path` fired: RestartOwner",
                "301 ms stop x: Idle -> Running (monitor `following error x`)",
                "301 ms stop x: Running -> Terminated (completed)",
                "302 ms move 2: Paused -> Aborting (monitor `following error x`)",
                "302 ms move 2: Aborting -> Aborted (monitor `following error x`)",
                "302 ms glue path: Paused -> Restarting (monitor `following error x`)",
                "1260 ms main: Paused -> Running (monitor `door open`)",
                "1260 ms glue path: Restarting -> Running (restart)",
                "1260 ms move 1: Terminated -> Running (start)",
            ]
        );
        assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
    });
}

#[test]
fn an_open_door_does_not_pause_the_homings_main_started_non_blocking() {
    with_cell(
        |m| m.faults.door_open.set(Some((50, 400))),
        |sim, _, ids, _| {
            assert_eq!(start_and_run(sim, ids), Some(719));
            use RunningState::*;
            assert_eq!(
                states(sim, ids.main),
                [
                    (0, Running),
                    (50, Paused),
                    (400, Running),
                    (719, Terminated)
                ]
            );
            // Homing goes on (the plant's interlock holds the axes): semantics.md item 3/7.
            assert_eq!(states(sim, ids.home_x), [(3, Running), (503, Terminated)]);
        },
    );
}

#[test]
fn an_operator_pause_during_the_door_hold_keeps_main_paused_after_the_door_closes() {
    with_cell(
        |m| m.faults.door_open.set(Some((50, 400))),
        |sim, _, ids, _| {
            sim.start(ids.main).unwrap();
            sim.run_until(ms(100));
            let h = sim.handle(ids.main).unwrap();
            assert_eq!(h.resume(), Err(Error::HeldByMonitor(ids.main)));
            h.pause().unwrap();
            sim.run_until(ms(450));
            assert_eq!(h.state(), RunningState::Paused);
            h.resume().unwrap();
            assert_eq!(
                sim.run_until_idle(Duration::from_secs(5))
                    .map(|t| t.as_ticks() / 1_000),
                Some(719)
            );
            use RunningState::*;
            assert_eq!(
                states(sim, ids.main),
                [
                    (0, Running),
                    (50, Paused),
                    (451, Running),
                    (719, Terminated)
                ]
            );
        },
    );
}

#[test]
fn the_cell_runs_again_after_an_operator_abort() {
    with_cell(
        |_| {},
        |sim, seq, ids, m| {
            sim.start(ids.main).unwrap();
            sim.run_until(ms(270));
            sim.abort(ids.main).unwrap();
            assert_eq!(
                sim.run_until_idle(Duration::from_secs(5))
                    .map(|t| t.as_ticks() / 1_000),
                Some(271)
            );
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Aborted(Cause::Abort)));
            assert_eq!(
                (m.x.target.get(), m.y.target.get(), m.y.rel()),
                (None, None, 2_150)
            );
            sim.take_trace();
            sim.run_until(ms(300));
            // Still `running`: power on and run are skipped (pre-condition), homing from where
            // the axes stand (x at 2 500 µm, y at 2 650 µm from the switch).
            assert_eq!(start_and_run(sim, ids), Some(650));
            let l = lines(sim, seq);
            assert_eq!(
                l[..6],
                [
                    "300 ms main: Aborted -> Running (start)",
                    "300 ms run: Terminated -> Running (start)",
                    "300 ms run: Running -> Terminated (pre-condition false)",
                    "300 ms home x: Terminated -> Running (start)",
                    "300 ms home y: Terminated -> Running (start)",
                    "300 ms seek x: Terminated -> Running (start)",
                ]
            );
            assert_eq!(outcome(sim, ids.run), Some(Outcome::Skipped));
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
            use RunningState::*;
            assert_eq!(states(sim, ids.home_y), [(300, Running), (484, Terminated)]);
            assert_eq!(states(sim, ids.glue), [(489, Running), (649, Terminated)]);
        },
    );
}

#[test]
fn the_cell_runs_again_after_an_estop_once_released_and_reset() {
    with_cell(
        |m| m.faults.estop.set(Some((300, 600))),
        |sim, seq, ids, m| {
            assert_eq!(start_and_run(sim, ids), Some(301));
            // Started in emergency: main refuses (its own check).
            sim.start(ids.main).unwrap();
            assert_eq!(
                outcome(sim, ids.main),
                Some(Outcome::Failed(Failure::App(NOT_RESET)))
            );
            // A reset while the button is pressed: the e-stop row wins (safety.md / semantics).
            seq.safety_handle().trigger(RESET);
            sim.run_until(ms(310));
            assert_eq!(seq.safety_handle().level(), EMERGENCY);
            sim.run_until(ms(700));
            seq.safety_handle().trigger(RESET);
            sim.step(); // 701: reset -> off
            assert_eq!(seq.safety_handle().level(), OFF);
            sim.take_trace();
            // x 1 900 µm, y 3 500 µm from the switch: y homes 703..928, pump 933, moves 40 ms.
            assert_eq!(start_and_run(sim, ids), Some(1_094));
            let l = lines(sim, seq);
            assert_eq!(
                lines_from(&l, "701 ms main")[..4],
                [
                    "701 ms main: Terminated -> Running (start)",
                    "701 ms power on: Terminated -> Running (start)",
                    "702 ms safety level ready",
                    "702 ms power on: Running -> Terminated (completed)",
                ]
            );
            assert_eq!(outcome(sim, ids.main), Some(Outcome::Completed));
            assert_eq!((m.x.rel(), m.y.rel()), (0, 1_000));
        },
    );
}
