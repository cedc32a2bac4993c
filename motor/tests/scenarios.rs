//! The motor-controller application on the host simulator: no fault, each fault, a pause.
//! Assertions are on the transition trace, the outcomes, the summary and the plant state.

mod common;
use common::*;
use rtseq::Cause::{self, AbortAll, Monitor, Pause, Restart, Resume, Start};
use rtseq::RunningState::*;
use rtseq::{Duration, Outcome, Transition};
use rtseq_motor::app::{AppConfig, Fault, FaultPlan};
use rtseq_motor::control_system::{ControlSystem, Phase, POSITION_TOLERANCE, STANDSTILL_VELOCITY};
use rtseq_motor::safety;

fn tr(
    ms: u64,
    seq: rtseq::SeqId,
    from: rtseq::RunningState,
    to: rtseq::RunningState,
    cause: Cause,
) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

/// Runs the fault-free application, recording (time, position) at each completed move.
fn fault_free(with_safety: bool) -> (World, Vec<(u64, f32)>) {
    let mut w = World::new(FaultPlan::NONE, with_safety);
    let mut done = Vec::new();
    w.run_sampling(|w| {
        let s = w.cs.summary();
        if usize::from(s.moves_done) > done.len() {
            done.push((to_ms(w.sim.now()), w.cs.position()));
        }
    });
    (w, done)
}

fn assert_motor_stopped(w: &World) {
    let s = w.cs.status();
    let p = w.cs.plant();
    assert!(p.velocity().abs() < 1e-6, "still moving: {s:?}");
    assert!(s.velocity.abs() <= STANDSTILL_VELOCITY, "{s:?}");
    assert!(p.current().abs() < 0.01, "current flows: {s:?}");
    assert!(!s.enabled && s.brake, "{s:?}");
}

#[test]
fn no_fault_homes_then_completes_every_move_in_position() {
    let (w, done) = fault_free(false);
    let cfg = AppConfig::DEFAULT;
    // Outcomes.
    for id in [
        MAIN, POWER_ON, HOMING, SEEK, HALT, SET_ZERO, BACK_OFF, MOVES, MOVE, DWELL, POWER_OFF,
        STATUS,
    ] {
        assert_eq!(
            w.outcome(id),
            Some(Outcome::Completed),
            "{}\n{}",
            w.name(id),
            w.show()
        );
    }
    for id in [SAFE_STOP, FEED_HOLD, FEED_RESUME, MAIN_HALT] {
        assert_eq!(w.state(id), Idle, "{} ran", w.name(id));
    }
    // Homing: seek (20 mm at 20 mm/s ≈ 1 s), halt, zero, back off; then the moves.
    let homed = to_ms(w.cs.summary().homed_at.unwrap());
    assert!((1050..1250).contains(&homed), "homed at {homed} ms");
    let moves = w.of(MOVES);
    assert_eq!(moves.len(), 2);
    assert_eq!(moves[0], tr(homed, MOVES, Idle, Running, Start));
    // Every move ends in position and settled at its target.
    assert_eq!(done.len(), cfg.move_count);
    for (i, &(_, pos)) in done.iter().enumerate() {
        assert!(
            (pos - cfg.targets[i]).abs() <= POSITION_TOLERANCE,
            "move {i}: {pos}"
        );
    }
    // Move durations match the trapezoidal profile (+ settling ≤ 60 ms).
    let starts: Vec<u64> = w
        .of(MOVE)
        .iter()
        .filter(|t| t.to == Running)
        .map(|t| to_ms(t.time))
        .collect();
    let profile_ms = [595, 350, 600]; // 95 mm, 50 mm, 100 mm at 0.2 m/s, 2 m/s²
    for i in 0..3 {
        let took = done[i].0 - starts[i];
        assert!(
            took >= profile_ms[i] && took <= profile_ms[i] + 60,
            "move {i} took {took} ms"
        );
    }
    let summary = w.cs.summary();
    assert_eq!(summary.moves_done, 3);
    assert_eq!(summary.safe_stops, 0);
    assert_eq!(w.cs.phase(), Phase::Done);
    assert!(w.cs.led(), "the LED stays on when done");
    // The LED blinked: power-on/homing at 4 Hz, moving at 2 Hz (blink = half period).
    let blinks = w.sim.handle(BLINK).unwrap().counters().runs;
    assert!(blinks >= 15, "{blinks}");
    let final_pos = w.cs.position();
    assert!((final_pos - 0.150).abs() <= POSITION_TOLERANCE);
    assert_motor_stopped(&w);
}

#[test]
fn following_error_safe_stop_restarts_the_moves_three_times_then_aborts() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) }),
        false,
    );
    w.run();
    let fe = Monitor(FOLLOWING_ERROR);
    // The moves: restarted three times by the monitor, then aborted (restart limit).
    let moves: Vec<(rtseq::RunningState, rtseq::RunningState, Cause)> = w
        .of(MOVES)
        .iter()
        .map(|t| (t.from, t.to, t.cause))
        .collect();
    assert_eq!(
        moves,
        vec![
            (Idle, Running, Start),
            (Running, Restarting, fe),
            (Restarting, Running, Restart),
            (Running, Restarting, fe),
            (Restarting, Running, Restart),
            (Running, Restarting, fe),
            (Restarting, Running, Restart),
            (Running, Aborting, fe),
            (Aborting, Aborted, fe),
        ],
        "\n{}",
        w.show()
    );
    let c = w.sim.handle(MOVES).unwrap().counters();
    assert_eq!((c.runs, c.restarts, c.aborts), (1, 3, 1));
    assert_eq!(w.outcome(MOVES), Some(Outcome::Aborted(fe)));
    assert_eq!(w.outcome(MOVE), Some(Outcome::Aborted(fe)));
    // The safe stop ran once per firing (4), each started by the monitor, each before the
    // behaviour was applied (the move is aborted one tick after the safe stop started).
    let safe_starts: Vec<u64> = w
        .of(SAFE_STOP)
        .iter()
        .filter(|t| t.to == Running)
        .map(|t| {
            assert_eq!(t.cause, fe);
            to_ms(t.time)
        })
        .collect();
    let move_aborts: Vec<u64> = w
        .of(MOVE)
        .iter()
        .filter(|t| t.to == Aborted)
        .map(|t| to_ms(t.time))
        .collect();
    assert_eq!(safe_starts.len(), 4);
    assert_eq!(move_aborts.len(), 4);
    for (s, a) in safe_starts.iter().zip(&move_aborts) {
        assert!(a > s && a - s <= 3, "safe stop at {s}, abort at {a}");
    }
    assert_eq!(w.sim.handle(SAFE_STOP).unwrap().counters().completed, 4);
    assert_eq!(w.sim.monitors().fired(FOLLOWING_ERROR), 4);
    // Main stops the axis, powers off and ends.
    assert_eq!(w.outcome(MAIN_HALT), Some(Outcome::Completed));
    assert_eq!(w.outcome(MAIN), Some(Outcome::Completed));
    assert_eq!(w.cs.phase(), Phase::Fault);
    let s = w.cs.summary();
    assert_eq!((s.moves_done, s.safe_stops), (0, 4));
    let r = s.following_error;
    assert_eq!(r.injected, Some(ms(1500)));
    let latency = r.latency().unwrap();
    assert!(latency <= Duration::from_millis(20), "{latency}");
    assert!(r.stop_latency().unwrap() <= Duration::from_millis(25));
    w.settle(100);
    assert_motor_stopped(&w);
}

#[test]
fn end_stop_during_a_move_aborts_the_moves() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::EndStop { at: ms(1500) }), false);
    w.run();
    let es = Monitor(END_STOP);
    // Detected in the tick at which the switch closed: move and moves aborted at 1500 ms,
    // innermost first.
    let aborted: Vec<Transition> = w
        .sim
        .trace()
        .iter()
        .filter(|t| t.cause == es)
        .copied()
        .collect();
    assert_eq!(
        aborted,
        vec![
            tr(1500, MOVE, Running, Aborting, es),
            tr(1500, MOVE, Aborting, Aborted, es),
            tr(1500, MOVES, Running, Aborting, es),
            tr(1500, MOVES, Aborting, Aborted, es),
        ]
    );
    assert_eq!(w.outcome(MOVES), Some(Outcome::Aborted(es)));
    assert_eq!(w.outcome(MAIN), Some(Outcome::Completed));
    assert_eq!(w.state(SAFE_STOP), Idle);
    assert_eq!(w.cs.phase(), Phase::Fault);
    let s = w.cs.summary();
    assert_eq!(s.moves_done, 0);
    assert_eq!(s.end_stop.latency(), Some(Duration::from_millis(0)));
    // Quick stop from 0.2 m/s at 6 m/s²: about 35 ms.
    let stop = s.end_stop.stop_latency().unwrap();
    assert!(stop <= Duration::from_millis(60), "{stop}");
    w.settle(100);
    assert_motor_stopped(&w);
}

#[test]
fn pause_button_pauses_the_move_and_resumes_it_later() {
    let (reference, ref_done) = fault_free(false);
    drop(reference);
    // A move timeout shorter than the paused move's wall time: paused time must not count.
    let config = AppConfig {
        move_timeout: Duration::from_millis(800),
        ..AppConfig::DEFAULT
    };
    let mut w = World::with_config(
        FaultPlan::NONE.with_pause(ms(1500), ms(2000)),
        false,
        config,
    );
    let mut held_speed: f32 = 0.0;
    let mut done = Vec::new();
    w.run_sampling(|w| {
        let now = to_ms(w.sim.now());
        if (1700..1990).contains(&now) {
            held_speed = held_speed.max(w.cs.plant().velocity().abs());
        }
        let s = w.cs.summary();
        if usize::from(s.moves_done) > done.len() {
            done.push(now);
        }
    });
    let (pause, resume) = (Monitor(PAUSE), Monitor(RESUME));
    let of = |id| -> Vec<Transition> {
        w.of(id)
            .into_iter()
            .filter(|t| matches!(t.cause, Pause | Resume) || t.cause == pause || t.cause == resume)
            .collect()
    };
    assert_eq!(
        of(FEED_HOLD),
        vec![tr(1500, FEED_HOLD, Idle, Running, pause),]
    );
    assert_eq!(
        of(FEED_RESUME),
        vec![tr(2000, FEED_RESUME, Idle, Running, resume)]
    );
    assert_eq!(
        of(MOVES),
        vec![
            tr(1501, MOVES, Running, Paused, Pause),
            tr(2001, MOVES, Paused, Running, Resume),
        ]
    );
    assert_eq!(
        of(MOVE),
        vec![
            tr(1501, MOVE, Running, Paused, Pause),
            tr(2001, MOVE, Paused, Running, Resume),
        ]
    );
    assert!(
        held_speed < 1e-3,
        "the axis stands still while paused: {held_speed} m/s"
    );
    // Everything completes; the paused move (the first) ends about 500 ms later.
    for id in [MAIN, MOVES, MOVE] {
        assert_eq!(w.outcome(id), Some(Outcome::Completed));
    }
    assert_eq!(w.cs.phase(), Phase::Done);
    assert_eq!(done.len(), 3);
    let delay = done[0] as i64 - ref_done[0].0 as i64;
    assert!((450..=560).contains(&delay), "delay {delay} ms");
    let s = w.cs.summary();
    assert_eq!(
        (s.paused_at, s.resumed_at),
        (Some(ms(1500)), Some(ms(2000)))
    );
    assert_eq!(w.sim.handle(MOVE).unwrap().counters().aborts, 0);
}

#[test]
fn over_current_trips_the_safety_system_which_aborts_every_sequence() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::OverCurrent { at: ms(1500) }),
        true,
    );
    w.run();
    let handle = w.safety.unwrap();
    assert_eq!(handle.level(), safety::EMERGENCY);
    // The input check fires at 1500 ms, the emergency level is entered in the next safety
    // cycle (1501 ms), which aborts every sequence in the tick of the same millisecond.
    for id in [MAIN, MOVES, MOVE, STATUS] {
        assert_eq!(
            w.outcome(id),
            Some(Outcome::Aborted(AbortAll)),
            "{}",
            w.name(id)
        );
        let last = *w.of(id).last().unwrap();
        assert_eq!(last, tr(1501, id, Aborting, Aborted, AbortAll));
    }
    w.settle(100);
    let s = w.cs.summary();
    assert_eq!(s.over_current.latency(), Some(Duration::from_millis(1)));
    let stop = s.over_current.stop_latency().unwrap();
    assert!(stop <= Duration::from_millis(30), "{stop}");
    assert_motor_stopped(&w);
    assert!(!w.cs.drive_permit());
}

#[test]
fn with_the_safety_system_the_fault_free_run_is_the_same() {
    let (plain, plain_done) = fault_free(false);
    let (w, done) = fault_free(true);
    assert_eq!(w.cs.phase(), Phase::Done);
    assert_eq!(done.len(), 3);
    // Power-on waits one safety cycle for the drive permit: everything is 1 ms later.
    for (a, b) in plain_done.iter().zip(&done) {
        assert_eq!(b.0, a.0 + 1);
        assert!((a.1 - b.1).abs() <= POSITION_TOLERANCE);
    }
    assert_eq!(w.safety.unwrap().level(), safety::OFF);
    drop(plain);
}

/// The five lanes joined in one task (`rtseq::lanes!`) run the following-error scenario
/// exactly as five lane tasks do: the same transitions at the same times. Each wake-up of
/// the joined task polls every lane, so it polls more often.
#[test]
fn lanes_joined_in_one_task_give_the_same_run_as_a_task_per_lane() {
    let plan = FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) });
    let mut apart = World::new(plan, false);
    let end = apart.run();
    let (mut sim, _, cs) = app_sim_joined(plan, AppConfig::DEFAULT);
    sim.before_tick(|now, cs: &ControlSystem| cs.control_tick(now, 0.001));
    sim.start(MAIN).unwrap();
    while sim.any_active() {
        sim.step();
    }
    assert_eq!(to_ms(sim.now()), end);
    assert_eq!(sim.trace(), apart.sim.trace());
    assert_eq!(
        apart
            .of(MOVES)
            .iter()
            .filter(|t| t.to == rtseq::RunningState::Restarting)
            .count(),
        3,
        "the run compared is the one with three restarts"
    );
    assert_eq!(cs.summary(), apart.cs.summary());
}
