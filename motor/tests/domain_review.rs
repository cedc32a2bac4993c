//! A motor-control engineer's review of the demo application (homing, moves, fault
//! reactions, stopping distances, the real board's current limit), as host tests.
//!
//! Tests marked `// DEFECT:` are `#[ignore]`d: they state what a motor-control engineer
//! expects and fail on the current code (`cargo test -p rtseq-motor --test domain_review
//! -- --ignored` shows the numbers). The unmarked tests confirm behaviour that was checked
//! and found right.

mod common;
use std::cell::Cell;
use std::rc::Rc;

use common::*;
use rtseq_motor::app::{self, AppConfig, Fault, FaultPlan};
use rtseq_motor::control_system::ControlSystem;
use rtseq_motor::controller::Limits;
use rtseq_motor::hardware::Measurements;
use rtseq_motor::plant::{Plant, END_STOP_POS, HARD_STOP_MARGIN, I_MAX};
use rtseq_motor::safety;

/// Milliseconds of a run with |true motor current| at the drive's peak (≥ 97.5 % of I_MAX).
fn ms_at_peak_current(w: &mut World) -> u32 {
    let mut n = 0;
    w.run_sampling(|w| {
        if w.cs.plant().current().abs() >= 0.975 * I_MAX {
            n += 1;
        }
    });
    n
}

// Was a DEFECT (fixed): no supervision of the closed loop during homing. The
// following-error monitor was owned by `move` only, the end-stop monitor by `moves`, and
// the safety levels OFF/POWER_ON ignore both end stops. A jam (or a failed switch and the
// hard stop) during the seek let the jog setpoint run away: the following error grew to
// ~90 mm and the drive pushed at its peak current for ~4.5 s, until the 5 s homing
// timeout. Now homing has its own following-error monitor (safe stop, abort homing):
// the drive is at its peak current for a few tens of ms.
#[test]
fn a_jam_during_homing_is_detected_quickly() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(500) }),
        true,
    );
    let stalled = ms_at_peak_current(&mut w);
    assert!(
        stalled <= 200,
        "the drive pushed at its peak current for {stalled} ms during homing"
    );
    assert_eq!(
        w.outcome(HOMING),
        Some(rtseq::Outcome::Aborted(rtseq::Cause::Monitor(
            HOMING_FOLLOWING_ERROR
        )))
    );
    let r = w.cs.summary().following_error;
    assert!(
        r.latency().unwrap() <= rtseq::Duration::from_millis(150),
        "{r:?}"
    );
    assert_eq!(w.cs.phase(), rtseq_motor::control_system::Phase::Fault);
}

/// The positive end stop while homing seeks the negative one (what a motor wired in
/// reverse gives): homing is aborted at once and the axis stopped, instead of the switch
/// being ignored by the safety levels below `HOMED` and the jog running on into the hard
/// stop.
#[test]
fn the_opposite_end_stop_during_homing_aborts_it() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::EndStop { at: ms(500) }), true);
    w.run();
    assert_eq!(
        w.outcome(HOMING),
        Some(rtseq::Outcome::Aborted(rtseq::Cause::Monitor(
            HOMING_END_STOP
        )))
    );
    let aborted = w
        .of(HOMING)
        .into_iter()
        .find(|t| t.to == rtseq::RunningState::Aborted)
        .unwrap();
    assert_eq!(to_ms(aborted.time), 500);
    assert_eq!(w.outcome(MOVES), None, "the moves never ran");
    assert_eq!(w.cs.phase(), rtseq_motor::control_system::Phase::Fault);
    w.settle(100);
    let p = w.cs.plant();
    assert!(p.velocity().abs() < 1e-6 && !w.cs.status().enabled);
}

// DEFECT (left, documented): the over-current trip (safety.rs, 6 A) lies above the
// simulated drive's current limit (plant.rs I_MAX = 4 A), and there is no I²t / stall
// supervision: no physical condition of the simulated machine can trip it, only the
// injected sensor offset of +12 A. The 6 A trip is a sensor-plausibility check (safety.rs
// says so now). With homing supervised (S1) a jam while the setpoint moves is caught by
// the following-error monitors within ~0.1 s; what is left is a jam at rest within the
// following-error limit: jammed 24 µm short of the back-off target (1119 ms), the servo's
// integrator winds up to I_MAX and the drive stalls at its peak current for ~1.4 s until the
// 5 s homing timeout. Expected: a trip/foldback on i²·t (or on |i| ≥ I_peak for more than
// a few hundred ms at standstill), which this stall would exceed.
#[test]
#[ignore = "defect: a multi-second stall at peak current (jam at rest, within the following-error limit) never trips the safety system"]
fn a_long_stall_at_peak_current_trips_the_safety_system() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(1119) }),
        true,
    );
    let mut emergency = false;
    let mut peak_ms = 0;
    w.run_sampling(|w| {
        if w.cs.plant().current().abs() >= 0.975 * I_MAX {
            peak_ms += 1;
        }
        emergency |= w.safety.unwrap().level() == safety::EMERGENCY;
    });
    assert!(peak_ms > 1000, "precondition: a long stall ({peak_ms} ms)");
    assert!(emergency, "{peak_ms} ms at peak current, no trip");
}

/// Where the homed zero lies in machine coordinates, for a start position.
fn homed_zero(start: f32) -> f32 {
    let config = AppConfig {
        start_position: start,
        ..AppConfig::DEFAULT
    };
    let mut w = World::with_config(FaultPlan::NONE, false, config);
    let mut zero = None;
    w.run_sampling(|w| {
        if zero.is_none() && w.cs.status().homed {
            zero = Some(w.cs.plant().position() - w.cs.position());
        }
    });
    zero.unwrap()
}

// Was a DEFECT (fixed): the homing zero was the position where the axis came to rest
// after `Halt`, not a latched switch edge, and a switch already closed at the start was
// taken as "found" at once (SeekEndStop's exit condition). Started between the switch and
// the hard stop (2.5 mm past the switch, e.g. after an over-travel or a manual move), the
// machine was zeroed 2.5 mm off; even from a normal start the zero depended on the
// approach speed (≈ 0.12 mm of stopping travel from 20 mm/s) — 6× the 20 µm in-position
// window. Now the seek (`ControlSystem::seek_home`) first jogs off a closed switch (+)
// until it opens, then approaches it, and the control system latches the encoder position
// of the control period in which the switch input changes to closed; `SetZero` takes that
// edge. Tolerance: the sampled edge lies up to one control period's travel at the approach
// speed beyond the true one (20 mm/s × 1 ms = 20 µm), plus one encoder count (1.25 µm);
// a timer's input capture on the real board would remove the sampling error.
#[test]
fn the_homed_zero_does_not_depend_on_where_the_axis_started() {
    let config = AppConfig::DEFAULT;
    let tolerance = config.homing_speed * 0.001 + rtseq_motor::plant::M_PER_COUNT;
    // Normal, on the switch (between it and the hard stop), exactly at the switch, just
    // off it (the approach still accelerating), farther away (within the 5 s timeout).
    let starts = [0.020, -0.0025, 0.0, 0.0005, 0.060];
    let zeros: Vec<f32> = starts.iter().map(|&s| homed_zero(s)).collect();
    for (s, z) in starts.iter().zip(&zeros) {
        // The switch closes at END_STOP_NEG (0): the zero lies on it or up to the
        // tolerance beyond it (in the approach direction).
        assert!(
            *z <= 1e-6 && *z >= -tolerance,
            "start {:.1} mm: zero at {:.4} mm, the switch edge at 0",
            s * 1e3,
            z * 1e3
        );
    }
    let spread = zeros.iter().fold(f32::MIN, |a, &b| a.max(b))
        - zeros.iter().fold(f32::MAX, |a, &b| a.min(b));
    assert!(
        spread <= tolerance,
        "zeros {:?} mm (starts {starts:?} m): spread {:.4} mm",
        zeros.iter().map(|z| z * 1e3).collect::<Vec<_>>(),
        spread * 1e3
    );
}

// Was a DEFECT (fixed): no software travel limits. `MoveTo` accepted any target; a
// target beyond the travel (here 350 mm on a 300 mm axis) was driven at full speed into
// the positive limit switch, and the quick stop after the end-stop monitor fired (6 m/s²
// from 0.2 m/s: 3.3 mm, plus detection) needed more than the 3 mm between switch and hard
// stop: the carriage hit the hard stop at ~73 mm/s. Now `MoveTo` refuses a target outside
// `AppConfig::travel` (the switches' span minus 4 mm at each end) with
// `Failure::App(TARGET_OUTSIDE_TRAVEL)` before anything moves, and main stops in phase
// fault.
#[test]
fn a_target_beyond_the_travel_never_reaches_the_hard_stop() {
    let mut targets = [0.0; 8];
    targets[0] = 0.350;
    let config = AppConfig {
        targets,
        move_count: 1,
        ..AppConfig::DEFAULT
    };
    let mut w = World::with_config(FaultPlan::NONE, true, config);
    let mut max_x: f32 = 0.0;
    w.run_sampling(|w| max_x = max_x.max(w.cs.plant().position()));
    assert!(
        max_x < END_STOP_POS + HARD_STOP_MARGIN - 1e-6,
        "the carriage reached the hard stop at {:.3} mm",
        max_x * 1e3
    );
    // Refused by the soft limit: nothing moved towards it, not even to the switch.
    assert!(max_x < 0.03, "moved to {:.3} mm", max_x * 1e3);
    assert_eq!(
        w.outcome(MOVE),
        Some(rtseq::Outcome::Failed(rtseq::Failure::App(
            app::TARGET_OUTSIDE_TRAVEL
        )))
    );
    assert_eq!(w.cs.phase(), rtseq_motor::control_system::Phase::Fault);
}

/// The soft limits' edges: the first and the last target accepted, with the axis stopping
/// in position there and never touching a switch.
#[test]
fn targets_at_the_soft_limits_are_accepted() {
    let travel = app::Travel::AXIS;
    let mut targets = [0.0; 8];
    targets[0] = travel.max;
    targets[1] = travel.min;
    let config = AppConfig {
        targets,
        move_count: 2,
        ..AppConfig::DEFAULT
    };
    let mut w = World::with_config(FaultPlan::NONE, true, config);
    let mut switch = false;
    w.run_sampling(|w| {
        let s = w.cs.status();
        switch |= w.cs.summary().homed_at.is_some() && (s.end_stop_pos || s.end_stop_neg);
    });
    assert_eq!(w.cs.summary().moves_done, 2);
    assert!(!switch, "a switch closed after homing");
    assert!(!travel.contains(travel.max + 1e-4) && !travel.contains(f32::NAN));
}

// Was a DEFECT (fixed, same root cause as above, on the mechanics' side): the stopping
// distance of the application's own end-stop reaction at v_max (3.53 mm) exceeded the
// 3 mm over-travel margin; the margin is 5 mm now.
#[test]
fn the_end_stop_reaction_stops_within_the_overtravel_margin() {
    let v = Limits::MOVE.v_max;
    let detect = 0.001; // one tick
    let distance = v * v / (2.0 * Limits::QUICK_STOP_DECEL) + v * detect;
    assert!((distance - rtseq_motor::controller::STOPPING_DISTANCE).abs() < 1e-6);
    assert!(
        distance <= HARD_STOP_MARGIN,
        "stopping distance {:.2} mm > margin {:.2} mm",
        distance * 1e3,
        HARD_STOP_MARGIN * 1e3
    );
}

// DEFECT: `RestartCallerOfOwner` with a restart limit of 3 (app.rs:438-441) re-runs the
// moves automatically after a following-error safe stop: with a jammed axis (a collision,
// a trapped object) the drive re-applies its peak current into the obstacle four times in
// all, with no operator action. A following error is a fault that must be latched and
// acknowledged before motion resumes (IEC 60204-1 §7.5/§9.2.5.4 restart only by a
// deliberate action; ISO 14118 unexpected start-up). Expected: one push, then stop and
// wait for an acknowledge; automatic retries only for documented transient causes and
// never with the full torque limit.
//
// Decision (kept, documented): the demo exists to show the EEROS sequencer's behaviours,
// and a monitor whose behaviour restarts the caller within a restart limit is one of
// them. The retries stay, bounded and documented as a demonstration (app.rs monitor
// table, README): a production drive latches the following error and waits for an
// acknowledge. The test below (`following_error_retries_are_bounded_and_start_from_rest`)
// holds what the retries must keep to; this one stays ignored as the statement of the
// production requirement.
#[test]
#[ignore = "by design in the demo: the EEROS restart behaviour retries up to restart_limit (3) times; a production drive latches (README)"]
fn after_a_following_error_the_drive_does_not_push_again_without_an_acknowledge() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) }),
        false,
    );
    let (mut episodes, mut high) = (0, false);
    w.run_sampling(|w| {
        let now_high = w.cs.plant().current().abs() >= 0.975 * I_MAX;
        if now_high && !high {
            episodes += 1;
        }
        high = now_high;
    });
    assert_eq!(
        episodes, 1,
        "{episodes} pushes at peak current into the jam"
    );
}

/// What keeps the demo's automatic retries honest: each retry starts only after the safe
/// stop has brought the axis to a standstill with the current off its limit and the
/// following error cleared (the quick stop re-synchronises the setpoint with the axis),
/// each push into the jam lasts a few tens of ms, and there are at most `restart_limit`
/// retries before the moves are aborted for good.
#[test]
fn following_error_retries_are_bounded_and_start_from_rest() {
    let config = AppConfig::DEFAULT;
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) }),
        false,
    );
    let (mut episodes, mut high, mut longest, mut run) = (0, false, 0, 0);
    let mut at_restart = Vec::new();
    let mut seen = 0;
    w.run_sampling(|w| {
        let now_high = w.cs.plant().current().abs() >= 0.975 * I_MAX;
        if now_high && !high {
            episodes += 1;
        }
        run = if now_high { run + 1 } else { 0 };
        longest = longest.max(run);
        high = now_high;
        let restarts = w
            .of(MOVES)
            .iter()
            .filter(|t| t.to == rtseq::RunningState::Restarting)
            .count();
        if restarts > seen {
            seen = restarts;
            // The state the restart found (this tick's control step ran before it).
            let s = w.cs.status();
            at_restart.push((s.velocity, s.following_error, s.current_command));
        }
    });
    assert_eq!(episodes, usize::from(config.restart_limit) + 1);
    assert!(longest <= 60, "a push lasted {longest} ms");
    assert_eq!(at_restart.len(), usize::from(config.restart_limit));
    for (v, fe, i) in at_restart {
        assert!(v.abs() <= 5e-3, "restarted at {v} m/s");
        assert!(
            fe.abs() <= config.following_error_limit / 10.0,
            "restarted with {fe} m following error"
        );
        assert!(i.abs() < 0.5 * I_MAX, "restarted at {i} A");
    }
}

// Was a DEFECT (real board, fixed): the board drove the same controller as the
// simulation — its anti-windup limit was `Gains::DEFAULT.i_max` = 4 A and its quick stop
// decelerated at 6 m/s² — but its bridge is limited to 1.4 A
// (boards/nucleo-f446re-ihm07m1/src/drive.rs, `I_LIMIT`), ≈ 2.6 m/s² on this axis. The
// controller commanded up to 4 A that the bridge clipped (the integrator kept winding), and
// the end-stop quick stop needed ≈ 6.6 mm instead of the ≈ 3.5 mm the setpoint planned.
// Now the drive's limits are part of the control system's construction
// (`ControlSystem::with_drive`, `controller::DriveLimits`): the board sets
// `i_max = I_LIMIT` and the deceleration its bridge holds,
// `DriveLimits::max_quick_stop_decel` = (KF·I_LIMIT − friction)/M_EQ ≈ 2.25 m/s², checked
// at compile time (the board's `main.rs`, `DRIVE`). The stop from 0.2 m/s then takes what
// the setpoint plans, ≈ 9.1 mm: more than the simulated axis' 5 mm between switch and
// hard stop, which this drive cannot shorten — a machine with it needs its hard stops
// that far beyond the switches, or a lower `v_max` (the board README says so).
#[test]
fn on_a_1_4_amp_drive_the_controller_stays_within_the_drive_limit() {
    use rtseq_motor::controller::{DriveLimits, KF, M_EQ};
    use rtseq_motor::plant::{COULOMB, M_PER_RAD};
    const BOARD_I_LIMIT: f32 = 1.4;
    // The board's configuration (boards/nucleo-f446re-ihm07m1/src/main.rs, `DRIVE`).
    let drive = DriveLimits {
        i_max: BOARD_I_LIMIT,
        quick_stop_decel: DriveLimits::max_quick_stop_decel(
            BOARD_I_LIMIT,
            KF,
            M_EQ,
            COULOMB / M_PER_RAD,
        ),
    };
    let plan = FaultPlan::NONE.with(Fault::EndStop { at: ms(1500) });
    let (mut sim, seq, cs) = app_sim_with_drive(plan, AppConfig::DEFAULT, drive);
    assert_eq!(cs.drive_limits(), drive);
    let machine = Rc::new(Cell::new(Plant::new(AppConfig::DEFAULT.start_position)));
    let m = machine.clone();
    sim.before_tick(move |now, cs: &ControlSystem| {
        cs.inject(now);
        let mut p = m.get();
        let cmd = cs.control_step_measured(&Measurements::of_plant(&p), 0.001);
        p.set_enabled(cmd.enable);
        p.set_brake(cmd.brake);
        // The board's bridge (drive.rs): the command clipped to 1.4 A.
        p.step(cmd.current.clamp(-BOARD_I_LIMIT, BOARD_I_LIMIT), 0.001);
        cs.update_measurements(&Measurements::of_plant(&p));
        m.set(p);
    });
    let mut w = World {
        sim,
        seq,
        cs,
        safety: None,
    };
    let (mut max_cmd, mut x_fault, mut x_max) = (0.0f32, None, 0.0f32);
    w.run_sampling(|w| {
        let p = machine.get();
        max_cmd = max_cmd.max(w.cs.status().current_command.abs());
        if to_ms(w.sim.now()) == 1500 {
            x_fault = Some(p.position());
        }
        x_max = x_max.max(p.position());
    });
    let stop = x_max - x_fault.unwrap();
    // What the setpoint plans: full speed, the stop one control period late.
    let planned = drive.stopping_distance(Limits::MOVE.v_max, 0.001);
    assert!(
        max_cmd <= BOARD_I_LIMIT + 1e-3 && stop <= planned,
        "command up to {max_cmd:.2} A on a {BOARD_I_LIMIT} A drive; end-stop stop took {:.2} mm, planned {:.2} mm",
        stop * 1e3,
        planned * 1e3
    );
}

// Was a DEFECT (latent, fixed): the command mailbox held one motion request, last writer
// wins. A stop requested by one context (the abort hook in the tick, the safe-stop lane)
// was silently replaced by a motion requested by another lane before the next control
// step, and both were acknowledged (`commands_done`). Now stop requests have their own
// slot, latched with priority over motion until applied.
#[test]
fn a_pending_quick_stop_is_not_overwritten_by_a_move() {
    let cs = ControlSystem::new(0.02);
    cs.brake(false);
    cs.enable(true);
    cs.control_step(0.001);
    cs.move_to(0.05);
    for _ in 0..100 {
        cs.control_step(0.001);
    }
    let before = cs.status().setpoint;
    cs.quick_stop(); // e.g. the abort hook, in the tick
    cs.move_to(0.2); // another lane, same period
    for _ in 0..100 {
        cs.control_step(0.001);
    }
    assert!(cs.commands_done());
    assert!(
        cs.status().target.is_none() && cs.status().setpoint - before < 0.01,
        "the axis kept moving to {:?}",
        cs.status().target
    );
    // A feed hold after the quick stop does not weaken it; a move after the stop has been
    // applied is obeyed.
    cs.move_to(0.05);
    cs.control_step(0.001);
    cs.quick_stop();
    cs.feed_hold();
    cs.control_step(0.001);
    assert_eq!(cs.status().target, None, "quick stop, not a feed hold");
    cs.move_to(0.03);
    cs.control_step(0.001);
    assert_eq!(cs.status().target, Some(0.03));
}

// ---- confirmed behaviour ----------------------------------------------------------------

/// Feed hold is a controlled stop (category 2): the drive stays enabled and the profile
/// decelerates at a_max (0.2 m/s → 0 in ≈ 100 ms) instead of dropping the command.
#[test]
fn feed_hold_decelerates_on_the_ramp_with_the_drive_enabled() {
    let mut w = World::new(FaultPlan::NONE.with_pause(ms(1500), ms(2000)), false);
    let mut samples = Vec::new();
    w.run_sampling(|w| {
        let n = to_ms(w.sim.now());
        if (1500..1700).contains(&n) {
            samples.push((n, w.cs.plant().velocity(), w.cs.status().enabled));
        }
    });
    assert!(
        samples.iter().all(|s| s.2),
        "drive stays enabled during the hold"
    );
    let v0 = samples[0].1;
    assert!(v0 > 0.19, "{v0}");
    let stopped = samples.iter().find(|s| s.1.abs() < 1e-3).unwrap().0;
    // 0.2 m/s at 2 m/s² = 100 ms, plus the loop's lag.
    assert!((1590..=1640).contains(&stopped), "stopped at {stopped} ms");
    // Never decelerates faster than the quick stop would.
    for pair in samples.windows(2) {
        let a = (pair[1].1 - pair[0].1) / 0.001;
        assert!(a > -Limits::QUICK_STOP_DECEL, "decel {a} m/s²");
    }
}

/// E-stop: the drive permit is withdrawn one safety cycle after the press; a RESET while the
/// button is still pressed goes to `off` and straight back to `emergency`, and the drive is
/// never re-enabled.
#[test]
fn reset_with_the_estop_still_pressed_does_not_re_enable_the_drive() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::EStop { at: ms(1500) }), true);
    let mut first_disabled = None;
    w.run_sampling(|w| {
        if first_disabled.is_none() && to_ms(w.sim.now()) >= 1500 && !w.cs.status().enabled {
            first_disabled = Some(to_ms(w.sim.now()));
        }
    });
    assert_eq!(first_disabled, Some(1501));
    let h = w.safety.unwrap();
    assert_eq!(h.level(), safety::EMERGENCY);
    h.trigger(safety::RESET);
    let mut ever_enabled = false;
    for _ in 0..20 {
        w.sim.step();
        ever_enabled |= w.cs.status().enabled || w.cs.drive_permit();
    }
    assert!(!ever_enabled);
    assert_eq!(h.level(), safety::EMERGENCY);
}

/// Timing on a real board: the e-stop is a sampled input (the control task samples at the
/// start of its period, the safety task runs before that on the previous sample, and an
/// input check's private event takes effect in the *next* safety cycle). A press that is
/// present from period 1500 on removes the drive enable in the control step of 1502, not
/// 1501 as in the simulated runs (where `status()` shows an injected switch at once). The
/// "drive off within 1 ms" of the README holds for the injected faults only.
#[test]
fn a_sampled_estop_disables_the_drive_two_periods_after_the_press() {
    use rtseq::safety::SafetySystem;
    use rtseq_motor::safety::PROPERTIES;
    let (mut sim, seq, cs) = app_sim(FaultPlan::NONE, AppConfig::DEFAULT);
    let mut system = SafetySystem::new(&PROPERTIES, seq.safety_handle()).unwrap();
    let machine = Rc::new(Cell::new(Plant::new(AppConfig::DEFAULT.start_position)));
    let m = machine.clone();
    sim.before_tick(move |now, cs: &ControlSystem| {
        cs.inject(now);
        safety::safety_cycle(cs, &mut system, seq); // on the previous sample
        let mut p = m.get();
        let sample = Measurements {
            estop: to_ms(now) >= 1500,
            ..Measurements::of_plant(&p)
        };
        let cmd = cs.control_step_measured(&sample, 0.001);
        p.set_enabled(cmd.enable);
        p.set_brake(cmd.brake);
        p.step(cmd.current, 0.001);
        m.set(p);
    });
    let mut w = World {
        sim,
        seq,
        cs,
        safety: Some(seq.safety_handle()),
    };
    let mut off_at = None;
    w.run_sampling(|w| {
        let n = to_ms(w.sim.now());
        if n >= 1500 && off_at.is_none() && !w.cs.drive_command().enable {
            off_at = Some(n);
        }
    });
    assert_eq!(off_at, Some(1502));
}
