//! The hardware boundary (`ControlSystem::control_step_measured`): the application driven
//! through `Measurements` in / `DriveCommand` out, with the simulated plant outside the
//! control system as the "real" machine, gives exactly the run of the built-in plant path
//! (`control_step`): the same transition trace, the same measurements every tick, the same
//! summary. Also: the real pause button, and a drive whose sensors are sampled only once per
//! control period.

mod common;
use std::cell::Cell;
use std::rc::Rc;

use common::*;
use rtseq::safety::SafetySystem;
use rtseq::{Duration, Transition};
use rtseq_motor::app::{AppConfig, Fault, FaultPlan, Reaction, Summary};
use rtseq_motor::control_system::{ControlSystem, Phase, Status, STANDSTILL_VELOCITY};
use rtseq_motor::hardware::{DriveCommand, Measurements};
use rtseq_motor::plant::Plant;
use rtseq_motor::safety::{self, PROPERTIES};

/// How the machine in the loop reports its state.
#[derive(Clone, Copy, PartialEq)]
enum Sampling {
    /// Like the built-in plant path: the state at the end of the period is reported at once
    /// (`update_measurements` after the plant step).
    EndOfPeriod,
    /// Like a real board: one sample at the start of each control period.
    StartOfPeriod,
}

/// The application on the host simulator with the plant outside the control system, in the
/// loop of `control_step_measured`. Returns the world and the machine.
fn measured_world(
    plan: FaultPlan,
    with_safety: bool,
    sampling: Sampling,
    button: Rc<Cell<bool>>,
) -> (World, Rc<Cell<Plant>>) {
    let config = AppConfig::DEFAULT;
    let (mut sim, seq, cs) = app_sim(plan, config);
    let mut system =
        with_safety.then(|| SafetySystem::new(&PROPERTIES, seq.safety_handle()).unwrap());
    let safety = with_safety.then(|| seq.safety_handle());
    let plant = Rc::new(Cell::new(Plant::new(config.start_position)));
    let machine = plant.clone();
    let sample = move |p: &Plant| Measurements {
        pause_button: button.get(),
        ..Measurements::of_plant(p)
    };
    sim.before_tick(move |now, cs: &ControlSystem| {
        cs.inject(now);
        if let Some(system) = system.as_mut() {
            safety::safety_cycle(cs, system, seq);
        }
        let mut p = machine.get();
        // The machine simulates what a machine can do (a jam); the control system applies
        // the sensor faults of the plan to the samples.
        *p.faults_mut() = cs.injected_faults().mechanical();
        let cmd: DriveCommand = cs.control_step_measured(&sample(&p), 0.001);
        p.set_enabled(cmd.enable);
        p.set_brake(cmd.brake);
        p.step(cmd.current, 0.001);
        if sampling == Sampling::EndOfPeriod {
            cs.update_measurements(&sample(&p));
        }
        machine.set(p);
    });
    let w = World {
        sim,
        seq,
        cs,
        safety,
    };
    (w, plant)
}

/// Everything observable of one run.
struct Run {
    trace: Vec<Transition>,
    status: Vec<Status>,
    summary: Summary,
    end_ms: u64,
    machine: Plant,
}

fn run(mut w: World, machine: Option<Rc<Cell<Plant>>>) -> Run {
    let mut status = Vec::new();
    let end_ms = w.run_sampling(|w| status.push(w.cs.status()));
    w.settle(200);
    status.push(w.cs.status());
    Run {
        trace: w.sim.trace().to_vec(),
        status,
        summary: w.cs.summary(),
        end_ms,
        machine: machine.map_or_else(|| w.cs.plant(), |m| m.get()),
    }
}

/// The summary without the "motor stopped" times (the plant path takes them from the
/// simulation's truth, the measured path from the measurements).
fn without_stopped(mut s: Summary) -> Summary {
    for r in [
        &mut s.following_error,
        &mut s.over_current,
        &mut s.end_stop,
        &mut s.estop,
    ] {
        r.stopped = None;
    }
    s
}

fn stop_times(s: &Summary) -> [Option<u64>; 4] {
    let at = |r: Reaction| r.stopped.map(to_ms);
    [
        at(s.following_error),
        at(s.over_current),
        at(s.end_stop),
        at(s.estop),
    ]
}

fn plans() -> Vec<(&'static str, FaultPlan, bool)> {
    vec![
        ("no fault", FaultPlan::NONE, false),
        ("no fault, safety system", FaultPlan::NONE, true),
        (
            "following error",
            FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) }),
            true,
        ),
        (
            "end stop",
            FaultPlan::NONE.with(Fault::EndStop { at: ms(1500) }),
            true,
        ),
        (
            "over-current",
            FaultPlan::NONE.with(Fault::OverCurrent { at: ms(1500) }),
            true,
        ),
        (
            "e-stop",
            FaultPlan::NONE.with(Fault::EStop { at: ms(2000) }),
            true,
        ),
        (
            "pause",
            FaultPlan::NONE.with_pause(ms(1500), ms(2000)),
            false,
        ),
    ]
}

#[test]
fn measured_path_gives_the_plant_paths_run_bit_for_bit() {
    for (name, plan, with_safety) in plans() {
        let plant_run = run(World::new(plan, with_safety), None);
        let (w, machine) = measured_world(
            plan,
            with_safety,
            Sampling::EndOfPeriod,
            Rc::new(Cell::new(false)),
        );
        let hw_run = run(w, Some(machine));
        assert!(!plant_run.trace.is_empty(), "{name}");
        assert_eq!(plant_run.trace, hw_run.trace, "{name}: transition trace");
        assert_eq!(plant_run.end_ms, hw_run.end_ms, "{name}");
        assert_eq!(plant_run.status.len(), hw_run.status.len(), "{name}");
        for (tick, (a, b)) in plant_run.status.iter().zip(&hw_run.status).enumerate() {
            assert_eq!(a, b, "{name}: status after tick {tick}");
        }
        assert_eq!(
            without_stopped(plant_run.summary),
            without_stopped(hw_run.summary),
            "{name}: summary"
        );
        let state = |p: &Plant| {
            (
                p.position(),
                p.velocity(),
                p.current(),
                p.enabled(),
                p.brake(),
            )
        };
        assert_eq!(
            state(&plant_run.machine),
            state(&hw_run.machine),
            "{name}: machine state"
        );
        // "Motor stopped" from the measurements (encoder velocity, measured current): at
        // most a few periods after the simulation's truth.
        for (a, b) in stop_times(&plant_run.summary)
            .into_iter()
            .zip(stop_times(&hw_run.summary))
        {
            match (a, b) {
                (Some(a), Some(b)) => assert!(b.abs_diff(a) <= 20, "{name}: stopped {a} / {b}"),
                (a, b) => assert_eq!(a, b, "{name}: stopped"),
            }
        }
    }
}

#[test]
fn start_of_period_sampling_runs_the_same_application() {
    // A real board's timing: the sequences see the sample taken at the start of the
    // control period, one period older than the plant path's. Same transitions with the
    // same causes, every move done, the drive safe at the end; times shifted a little.
    for (name, plan, with_safety) in plans() {
        let plant_run = run(World::new(plan, with_safety), None);
        let (w, machine) = measured_world(
            plan,
            with_safety,
            Sampling::StartOfPeriod,
            Rc::new(Cell::new(false)),
        );
        let hw_run = run(w, Some(machine));
        // The status LED blinks on its own clock: leave it out.
        let motion = |r: &Run| -> Vec<Transition> {
            r.trace
                .iter()
                .filter(|t| t.sequence != STATUS && t.sequence != BLINK)
                .copied()
                .collect()
        };
        let outcomes = |r: &Run| {
            motion(r)
                .iter()
                .map(|t| (t.sequence, t.to, t.cause))
                .collect::<Vec<_>>()
        };
        assert_eq!(outcomes(&plant_run), outcomes(&hw_run), "{name}");
        for (a, b) in motion(&plant_run).iter().zip(&motion(&hw_run)) {
            let (a, b) = (to_ms(a.time), to_ms(b.time));
            // The homing ends 1 ms later (the end-stop switch is seen one sample later);
            // the back-off then settles against stiction (20 µm tolerance) ≈ 0.1 s later.
            assert!(b.abs_diff(a) <= 150, "{name}: {a} ms / {b} ms");
        }
        let (a, b) = (plant_run.summary, hw_run.summary);
        assert_eq!(a.moves_done, b.moves_done, "{name}");
        assert_eq!(a.safe_stops, b.safe_stops, "{name}");
        let last = hw_run.status.last().unwrap();
        assert!(!last.enabled && last.brake, "{name}: drive safe at the end");
        assert!(
            hw_run.machine.velocity().abs() < 1e-6,
            "{name}: machine at rest"
        );
    }
}

#[test]
fn the_real_pause_button_pauses_and_resumes_the_moves() {
    let button = Rc::new(Cell::new(false));
    let (mut w, _machine) = measured_world(
        FaultPlan::NONE,
        true,
        Sampling::StartOfPeriod,
        button.clone(),
    );
    w.sim.start(MAIN).unwrap();
    let press = |w: &mut World, b: &Rc<Cell<bool>>| {
        b.set(true);
        w.sim.run_for(Duration::from_millis(30));
        b.set(false);
    };
    w.sim.run_until(ms(1500));
    assert_eq!(w.cs.phase(), Phase::Moving);
    press(&mut w, &button);
    w.sim.run_for(Duration::from_millis(300));
    assert_eq!(w.cs.phase(), Phase::Paused);
    assert!(
        w.cs.velocity().abs() <= STANDSTILL_VELOCITY,
        "held mid-move"
    );
    let paused_at = w.cs.summary().paused_at.unwrap();
    assert!(to_ms(paused_at) >= 1500 && to_ms(paused_at) <= 1510);
    press(&mut w, &button);
    w.sim.run_until_idle(Duration::from_secs(15)).unwrap();
    assert_eq!(w.cs.phase(), Phase::Done);
    assert_eq!(
        usize::from(w.cs.summary().moves_done),
        AppConfig::DEFAULT.move_count
    );
    assert!(w.cs.summary().resumed_at.is_some());
}

#[test]
fn drive_command_follows_the_safety_system() {
    let cs = ControlSystem::new(0.02);
    let m = Measurements {
        position: 0.02,
        ..Measurements::NONE
    };
    assert_eq!(cs.control_step_measured(&m, 0.001), DriveCommand::SAFE);
    cs.brake(false);
    cs.enable(true);
    let cmd = cs.control_step_measured(&m, 0.001);
    assert!(cmd.enable && !cmd.brake);
    assert!(cs.status().enabled);
    // The safety system withdraws the permit: power stage off and brake on at the next step.
    cs.set_drive_permit(false);
    assert_eq!(cs.control_step_measured(&m, 0.001), DriveCommand::SAFE);
    assert_eq!(cs.drive_command(), DriveCommand::SAFE);
    // Measurements are what the control system reports, with injected sensor faults.
    let m = Measurements {
        position: 0.03,
        current: 1.5,
        end_stop_pos: true,
        estop: true,
        ..Measurements::NONE
    };
    cs.update_measurements(&m);
    let s = cs.status();
    assert_eq!(s.position, 0.03);
    assert_eq!(s.current, 1.5);
    assert!(s.end_stop_pos && s.estop && !s.end_stop_neg);
}
