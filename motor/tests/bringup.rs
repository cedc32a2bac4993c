//! Cold review of the open-loop bring-up jog (`rtseq_motor::bringup`, commit 2ebe463):
//! exact phase lengths, the permit and supply checks at their boundaries, the averaging
//! window, wrapping counts, the verdicts' thresholds, and the physics of the L6230's
//! sign-magnitude PWM (synchronous rectification: the switching leg's low side is on for
//! the off-time of every PWM period, so its shunt carries the motor current too, upwards).
//!
//! The three defects it found (the verdict taken from the leg reading more, the current
//! averaged where it is smallest, `volts` not checked) are fixed; their tests fail without
//! the fixes.

#![allow(clippy::float_cmp, clippy::panic, clippy::arithmetic_side_effects)]

use rtseq_motor::bringup::{
    Direction, Jog, JogConfig, JogReport, JogSample, JogStep, JogStop, Legs, Shunts,
};

/// What the rig sees in one period: `duty` is the duty the jog applied in the last period
/// (`Jog::duty`, 0 while waiting or coasting), `k` the number of periods driven at that
/// duty so far (1 for the first period's effect), `n` the period's index from the start.
struct Period {
    n: u32,
    duty: f32,
    k: u32,
}

/// A jog run to its end against a rig: the steps (collapsed into runs), the last step, and
/// the jog (to step it again).
struct Run {
    runs: Vec<(&'static str, u32)>,
    last: JogStep,
    jog: Jog,
}

fn name(step: JogStep) -> &'static str {
    match step {
        JogStep::AskPermit => "ask",
        JogStep::Drive(d) if d > 0.0 => "drive+",
        JogStep::Drive(d) if d < 0.0 => "drive-",
        JogStep::Drive(_) => "drive0",
        JogStep::Coast => "coast",
        JogStep::Done(_) => "done",
        JogStep::Stopped(_) => "stopped",
    }
}

/// Runs a jog with `config`; `sample` answers each period.
fn run(config: JogConfig, mut sample: impl FnMut(&Period) -> JogSample) -> Run {
    let mut jog = Jog::new(config);
    let mut runs: Vec<(&'static str, u32)> = Vec::new();
    let (mut last_duty, mut k) = (0.0f32, 0u32);
    for n in 0..100_000u32 {
        let duty = jog.duty();
        k = if duty != 0.0 && duty == last_duty {
            k + 1
        } else if duty != 0.0 {
            1
        } else {
            0
        };
        last_duty = duty;
        let step = jog.step(&sample(&Period { n, duty, k }));
        if let JogStep::Done(_) | JogStep::Stopped(_) = step {
            return Run {
                runs,
                last: step,
                jog,
            };
        }
        match runs.last_mut() {
            Some((r, c)) if *r == name(step) => *c += 1,
            _ => runs.push((name(step), 1)),
        }
    }
    panic!("the jog did not end");
}

fn report(step: JogStep) -> JogReport {
    match step {
        JogStep::Done(r) => r,
        other => panic!("not done: {other:?}"),
    }
}

/// The idealised shunts of the module's table: the current in the idle leg only.
fn table_shunts(duty: f32, amps: f32) -> Shunts {
    if duty > 0.0 {
        Shunts { u: 0.0, v: amps }
    } else if duty < 0.0 {
        Shunts { u: amps, v: 0.0 }
    } else {
        Shunts::default()
    }
}

/// A rig: the permit from period `permit_from`, 12 V, the encoder moving `counts_per_duty`
/// per period and unit duty, the shunts from `shunts(duty, k)`.
fn rig(
    permit_from: u32,
    counts_per_duty: f32,
    shunts: impl Fn(f32, u32) -> Shunts,
) -> impl FnMut(&Period) -> JogSample {
    let mut counts = 0i32;
    move |p: &Period| {
        counts = counts.wrapping_add((p.duty * counts_per_duty) as i32);
        JogSample {
            counts,
            shunts: shunts(p.duty, p.k),
            supply_v: 12.0,
            permit: p.n >= permit_from,
        }
    }
}

fn correct(duty: f32, _k: u32) -> Shunts {
    table_shunts(duty, 0.25)
}

// ---------------------------------------------------------------------------------------
// The state machine
// ---------------------------------------------------------------------------------------

/// With the permit already there, the first step drives: 300 + 300 + 300 + 300 periods,
/// then `Done`, and the jog keeps returning that `Done`, its duty 0.
#[test]
fn a_permit_at_once_drives_at_once_and_done_is_kept() {
    let mut r = run(JogConfig::DEFAULT, rig(0, 200.0, correct));
    assert_eq!(
        r.runs,
        [
            ("drive+", 300),
            ("coast", 300),
            ("drive-", 300),
            ("coast", 300)
        ]
    );
    let done = r.last;
    let rep = report(done);
    assert_eq!(rep.forward.duty, 0.125);
    assert_eq!(rep.backward.duty, -0.125);
    assert!(rep.is_correct());
    let any = JogSample {
        counts: 123,
        shunts: Shunts { u: 5.0, v: 5.0 },
        supply_v: 48.0,
        permit: false,
    };
    for _ in 0..3 {
        assert_eq!(r.jog.step(&any), done);
        assert_eq!(r.jog.duty(), 0.0);
    }
}

/// `permit_periods` = 100: 100 `AskPermit`s; a permit in the 101st period still starts
/// the drive, none there stops the jog as `NoPermit` (and that end is kept).
#[test]
fn the_permit_wait_is_exactly_permit_periods() {
    let r = run(JogConfig::DEFAULT, rig(100, 200.0, correct));
    assert_eq!(r.runs[0], ("ask", 100));
    assert_eq!(r.runs[1], ("drive+", 300));
    assert!(report(r.last).is_correct());

    let mut r = run(JogConfig::DEFAULT, rig(101, 200.0, correct));
    assert_eq!(r.runs, [("ask", 100)]);
    assert_eq!(r.last, JogStep::Stopped(JogStop::NoPermit));
    let granted = JogSample {
        counts: 0,
        shunts: Shunts::default(),
        supply_v: 12.0,
        permit: true,
    };
    // A permit that comes after the end does not restart the jog.
    assert_eq!(r.jog.step(&granted), JogStep::Stopped(JogStop::NoPermit));
    assert_eq!(r.jog.duty(), 0.0);
}

/// A permit withdrawn while coasting (bridge off) ends the jog too, at that period.
#[test]
fn a_permit_withdrawn_while_coasting_stops_the_jog() {
    // Period 0 drives; 1..=300 drive-phase samples (the 300th returns the first Coast);
    // the withdrawal is seen at period 400, the coast's 100th sample.
    let mut inner = rig(0, 200.0, correct);
    let r = run(JogConfig::DEFAULT, move |p| {
        let mut s = inner(p);
        s.permit = p.n < 400;
        s
    });
    assert_eq!(r.runs, [("drive+", 300), ("coast", 100)]);
    assert_eq!(r.last, JogStep::Stopped(JogStop::PermitWithdrawn));
}

/// The supply is read at each drive phase's start: the duty is fixed for the phase
/// (a supply change during it does not change it), the backward phase takes its own.
#[test]
fn each_drive_phase_takes_its_duty_from_the_supply_at_its_start() {
    let mut inner = rig(0, 200.0, correct);
    let mut duties = Vec::new();
    let mut jog = Jog::new(JogConfig::DEFAULT);
    let mut last = JogStep::AskPermit;
    for n in 0..=1200u32 {
        let duty = jog.duty();
        let mut s = inner(&Period { n, duty, k: 0 });
        // 12 V at the forward start, 15 V during it; 24 V at the backward start (n = 600).
        s.supply_v = match n {
            0 => 12.0,
            1..=599 => 15.0,
            _ => 24.0,
        };
        last = jog.step(&s);
        if let JogStep::Drive(d) = last {
            if duties.last() != Some(&d) {
                duties.push(d);
            }
        }
    }
    assert_eq!(duties, [0.125, -0.0625]);
    let rep = report(last);
    assert_eq!((rep.forward.duty, rep.backward.duty), (0.125, -0.0625));
}

/// The minimum supply is inclusive; NaN, infinities and negative readings are refused.
#[test]
fn the_supply_check_boundaries() {
    let at = |supply_v: f32| {
        Jog::new(JogConfig::DEFAULT).step(&JogSample {
            counts: 0,
            shunts: Shunts::default(),
            supply_v,
            permit: true,
        })
    };
    assert_eq!(at(8.0), JogStep::Drive(0.1875));
    assert_eq!(at(48.0), JogStep::Drive(0.03125));
    for bad in [
        7.999,
        0.0,
        -12.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ] {
        assert_eq!(at(bad), JogStep::Stopped(JogStop::SupplyTooLow), "{bad}");
    }
}

/// A supply that falls below the minimum between the phases stops the jog at the backward
/// phase's start, after the whole forward coast (bridge off throughout).
#[test]
fn a_supply_lost_between_the_phases_stops_before_the_backward_drive() {
    let mut inner = rig(0, 200.0, correct);
    let r = run(JogConfig::DEFAULT, move |p| {
        let mut s = inner(p);
        if p.n >= 300 {
            s.supply_v = 7.5;
        }
        s
    });
    assert_eq!(r.runs, [("drive+", 300), ("coast", 300)]);
    assert_eq!(r.last, JogStep::Stopped(JogStop::SupplyTooLow));
}

/// The shunts are averaged over exactly the drive phase's samples 3 … 50 (the effects of
/// its drive steps 3 … 50, `JogConfig::average`): not the sample before the first drive,
/// not samples 1, 2 or 51, not the coast's samples.
#[test]
fn the_averaging_window_is_samples_3_to_50_of_the_drive() {
    let mean_v_with = |marked: &'static [u32], in_coast: bool| {
        let mut counts = 0;
        let r = run(JogConfig::DEFAULT, move |p| {
            counts += (p.duty * 200.0) as i32;
            let mark = (p.duty > 0.0 && marked.contains(&p.k))
                || (p.n == 0 && marked.contains(&0))
                || (in_coast && p.duty == 0.0 && p.n > 0 && p.n < 600);
            JogSample {
                counts,
                shunts: Shunts {
                    u: if p.duty < 0.0 { 0.25 } else { 0.0 },
                    // 48 samples averaged: 0.75 A in one of them is a mean of 1/64 A.
                    v: if mark { 0.75 } else { 0.0 },
                },
                supply_v: 12.0,
                permit: true,
            }
        });
        report(r.last).forward.shunts.v
    };
    assert_eq!(mean_v_with(&[3], false), 0.015625);
    assert_eq!(mean_v_with(&[50], false), 0.015625);
    assert_eq!(mean_v_with(&[3, 50], false), 0.03125);
    assert_eq!(mean_v_with(&[0, 1, 2, 51], false), 0.0);
    assert_eq!(mean_v_with(&[], true), 0.0);
}

/// The travel is the wrapping difference of the counts: a 32-bit counter passing
/// i32::MAX gives the true travel.
#[test]
fn counts_wrapping_past_i32_max_give_the_true_travel() {
    let mut counts = i32::MAX - 100;
    let r = run(JogConfig::DEFAULT, move |p| {
        counts = counts.wrapping_add((p.duty * 200.0) as i32);
        JogSample {
            counts,
            shunts: correct(p.duty, 0),
            supply_v: 12.0,
            permit: true,
        }
    });
    let rep = report(r.last);
    assert_eq!(rep.forward.counts, 7500);
    assert_eq!(rep.backward.counts, -7500);
    assert_eq!(rep.direction(), Direction::Correct);
}

// ---------------------------------------------------------------------------------------
// The verdicts
// ---------------------------------------------------------------------------------------

/// A jog whose forward phase travels `f` counts and backward `b`, with `shunts`.
fn jog_with(config: JogConfig, f: i32, b: i32, shunts: impl Fn(f32, u32) -> Shunts) -> JogReport {
    let mut counts = 0i32;
    let r = run(config, move |p| {
        // All the travel in the phase's first driven period.
        if p.k == 1 {
            counts = counts.wrapping_add(if p.duty > 0.0 { f } else { b });
        }
        JogSample {
            counts,
            shunts: shunts(p.duty, p.k),
            supply_v: 12.0,
            permit: true,
        }
    });
    report(r.last)
}

/// `min_counts` (20) is inclusive; 19 either way is no motion.
#[test]
fn the_travel_threshold_is_inclusive() {
    let d = |f, b| jog_with(JogConfig::DEFAULT, f, b, correct).direction();
    assert_eq!(d(20, -20), Direction::Correct);
    assert_eq!(d(-20, 20), Direction::Reversed);
    assert_eq!(d(19, -19), Direction::NoMotion);
    assert_eq!(d(-19, 19), Direction::NoMotion);
    assert_eq!(d(20, -19), Direction::Inconsistent);
    assert_eq!(d(20, 20), Direction::Inconsistent);
    assert_eq!(d(-20, -20), Direction::Inconsistent);
    assert_eq!(d(0, -20), Direction::Inconsistent);
    assert_eq!(d(i32::MIN, i32::MAX), Direction::Reversed);
}

/// `min_amps` is inclusive (0.0625 A, exact in f32); a hair below in either phase is no
/// current.
#[test]
fn the_current_threshold_is_inclusive() {
    let config = JogConfig {
        min_amps: 0.0625,
        ..JogConfig::DEFAULT
    };
    let l = |amps: f32| jog_with(config, 500, -500, move |d, _| table_shunts(d, amps)).legs();
    assert_eq!(l(0.0625), Legs::Correct);
    assert_eq!(l(-0.0625), Legs::SignInverted);
    assert_eq!(l(0.0624), Legs::NoCurrent);
    let backward_low = jog_with(config, 500, -500, |d, _| {
        table_shunts(d, if d > 0.0 { 0.25 } else { 0.0624 })
    });
    assert_eq!(backward_low.legs(), Legs::NoCurrent);
}

/// Verdicts on the module's idealised readings (the switching leg reading zero).
#[test]
fn legs_verdicts_on_idealised_readings() {
    let l = |shunts: fn(f32, u32) -> Shunts| jog_with(JogConfig::DEFAULT, 500, -500, shunts).legs();
    // Both inputs swapped and inverted: read as swapped first (then, after the swap, as
    // inverted: two jogs to the fix).
    assert_eq!(
        l(|d, _| {
            let s = table_shunts(d, 0.25);
            Shunts { u: -s.v, v: -s.u }
        }),
        Legs::Swapped
    );
    assert_eq!(l(|d, _| table_shunts(d, -0.25)), Legs::SignInverted);
    // One amplifier inverted (the right legs, opposite signs): no single fix.
    assert_eq!(
        l(|d, _| {
            let s = table_shunts(d, 0.25);
            Shunts { u: -s.u, v: s.v }
        }),
        Legs::Inconsistent
    );
    // The current in the same leg both ways.
    assert_eq!(
        l(|d, _| Shunts {
            u: 0.0,
            v: 0.25 * d.signum()
        }),
        Legs::Inconsistent
    );
}

/// Sign-magnitude on the L6230 (IN low = low side on): for a positive duty d, V's low side
/// conducts all the time (+I in V's shunt), U's low side during the off-time (1 − d) of each
/// PWM period, carrying the freewheeling current upwards (−I in U's shunt). Sampled at
/// random phases, the means are v = +I and u = −(1 − d)·I. At 12 V (d = 0.125) that is
/// still read as correct.
#[test]
fn a_correct_drive_with_the_freewheel_current_averaged_is_correct_at_12_v() {
    let rep = jog_with(JogConfig::DEFAULT, 500, -500, |d, _| {
        let i = 0.25;
        let off = 1.0 - d.abs();
        if d > 0.0 {
            Shunts { u: -off * i, v: i }
        } else if d < 0.0 {
            Shunts { u: i, v: -off * i }
        } else {
            Shunts::default()
        }
    });
    assert_eq!(rep.legs(), Legs::Correct);
    assert!(rep.is_correct());
}

// ---------------------------------------------------------------------------------------
// Found by the review, fixed
// ---------------------------------------------------------------------------------------

/// The board samples the shunts once per control period in software; TIM6 (1 kHz) and the
/// PWM timer TIM1 (20 kHz) run from the same 84 MHz clock, so the sample falls at the same
/// phase of the PWM period every time: inside the switching leg's off-time with a
/// probability of 1 − d (87.5 % at 12 V, 97 % at 48 V). Both low sides then conduct the same
/// current: V's shunt reads +I, U's −I (the other way round for a negative duty).
#[test]
fn a_correct_drive_sampled_in_the_off_time_is_correct() {
    for switching in [1.0f32, 1.02] {
        let rep = jog_with(JogConfig::DEFAULT, 500, -500, move |d, _| {
            let i = 0.25;
            if d > 0.0 {
                Shunts {
                    u: -switching * i,
                    v: i,
                }
            } else if d < 0.0 {
                Shunts {
                    u: i,
                    v: -switching * i,
                }
            } else {
                Shunts::default()
            }
        });
        assert_eq!(rep.legs(), Legs::Correct, "switching leg ×{switching}");
        assert!(rep.is_correct());
    }
}

/// Voltage-driven DC motor: the current starts near V/R (0.75 A for 1.5 V on 2 Ω) and decays
/// with the mechanical time constant (J·R/(Kt·Ke) = 16 ms for the documented motor,
/// uncoupled) to the no-load current, which for a small, uncoupled low-friction motor is a
/// few tens of mA. The "settled" current is the smallest of the phase.
#[test]
fn a_turning_low_friction_motor_reads_its_start_current() {
    let rep = jog_with(JogConfig::DEFAULT, 2000, -2000, |d, k| {
        let i = 0.03 + 0.72 * (-(k as f32) / 16.0).exp();
        table_shunts(d, i)
    });
    assert_eq!(rep.direction(), Direction::Correct);
    assert_eq!(rep.legs(), Legs::Correct);
}

#[test]
fn a_non_finite_or_negative_voltage_does_not_drive() {
    for volts in [f32::NAN, f32::INFINITY, -1.5] {
        let mut jog = Jog::new(JogConfig {
            volts,
            ..JogConfig::DEFAULT
        });
        let step = jog.step(&JogSample {
            counts: 0,
            shunts: Shunts::default(),
            supply_v: 48.0,
            permit: true,
        });
        assert!(
            matches!(step, JogStep::Stopped(_)),
            "volts {volts}: {step:?}"
        );
        assert_eq!(jog.duty(), 0.0);
    }
}

/// Swapped current inputs sampled in the switching leg's off-time: the idle legs (the
/// inputs the loop reads, here the switching legs' shunts) read the freewheeling current
/// reversed, the others positive, which inverted amplifiers on the right inputs give too:
/// `SwappedOrInverted`, the one verdict that says the jog cannot tell.
#[test]
fn swapped_inputs_sampled_in_the_off_time_cannot_be_told_from_inverted_amplifiers() {
    let off_time = |d: f32, _: u32| {
        let i = 0.25;
        // Correct wiring in the off-time: idle leg +I, switching leg −I.
        let (u, v) = if d > 0.0 {
            (-i, i)
        } else if d < 0.0 {
            (i, -i)
        } else {
            (0.0, 0.0)
        };
        (u, v)
    };
    let swapped = jog_with(JogConfig::DEFAULT, 500, -500, move |d, k| {
        let (u, v) = off_time(d, k);
        Shunts { u: v, v: u }
    });
    let inverted = jog_with(JogConfig::DEFAULT, 500, -500, move |d, k| {
        let (u, v) = off_time(d, k);
        Shunts { u: -u, v: -v }
    });
    assert_eq!(swapped.legs(), Legs::SwappedOrInverted);
    assert_eq!(inverted.legs(), Legs::SwappedOrInverted);
    assert!(!swapped.is_correct());
}
