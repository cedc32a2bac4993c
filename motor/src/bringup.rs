//! Bring-up of a real drive: an open-loop jog that checks the motor's direction and which
//! shunt measures the motor current, with what sign, before the first closed loop.
//!
//! A current loop with a wrong current sign is positive feedback, and a position loop
//! with a reversed motor runs away: both must be right before the application drives the
//! motor. The jog needs no loop: it applies a small voltage one way, switches the bridge
//! off, applies it the other way, switches off again, and compares what the encoder and
//! the two leg shunts read with what a correctly wired sign-magnitude bridge gives:
//!
//! | duty | switching leg | idle leg (low side on throughout) | reading expected |
//! |---|---|---|---|
//! | positive | U (IN1) | V | shunt V positive; encoder counting up |
//! | negative | V (IN2) | U | shunt U positive; encoder counting down |
//!
//! The idle leg's shunt is the one the current loop reads (the board's sensors take V for
//! a positive duty, U reversed for a negative one), so the verdict rests on it. The
//! switching leg's shunt reads nothing during the on-time and, its low side conducting the
//! freewheeling current in the off-time, the current reversed then; a sample taken once per
//! control period falls at a fixed point of the PWM period (both timers run from one
//! clock), so it reads either. That makes swapped current inputs and inverted amplifiers
//! look alike when the sample falls in the off-time ([`Legs::SwappedOrInverted`]).
//!
//! [`Jog::step`] is called once per control period with that period's [`JogSample`] and
//! returns what to apply ([`JogStep`]); the safety system stays in charge throughout (the
//! firmware withdraws nothing from it: a tripped e-stop or over-current ends the jog as
//! [`JogStop::PermitWithdrawn`]).
//!
//! ```
//! use rtseq_motor::bringup::{Direction, Jog, JogConfig, JogSample, JogStep, Shunts};
//!
//! let mut jog = Jog::new(JogConfig::DEFAULT);
//! let (mut counts, mut report) = (0, None);
//! for _ in 0..10_000 {
//!     // A correctly wired drive: the current returns through V's shunt for a positive
//!     // duty and through U's for a negative one; the motor turns with the duty.
//!     let last = jog.duty();
//!     counts += (last * 100.0) as i32;
//!     let shunts = if last > 0.0 {
//!         Shunts { u: 0.0, v: 0.4 }
//!     } else if last < 0.0 {
//!         Shunts { u: 0.4, v: 0.0 }
//!     } else {
//!         Shunts { u: 0.0, v: 0.0 }
//!     };
//!     let sample = JogSample { counts, shunts, supply_v: 12.0, permit: true };
//!     if let JogStep::Done(r) = jog.step(&sample) {
//!         report = Some(r);
//!         break;
//!     }
//! }
//! let report = report.unwrap();
//! assert_eq!(report.direction(), Direction::Correct);
//! assert!(report.is_correct());
//! ```

/// What the jog applies and for how long, and what it takes as a reading.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JogConfig {
    /// The voltage applied to the motor, V (the duty is this over the measured supply).
    pub volts: f32,
    /// Control periods of each drive phase.
    pub drive_periods: u32,
    /// Control periods of each coast phase (bridge off, motor running down).
    pub coast_periods: u32,
    /// Control periods to wait for the drive permit after the jog asks for it.
    pub permit_periods: u32,
    /// The least encoder travel of a phase, counts, that counts as the motor turning.
    pub min_counts: u32,
    /// The least mean shunt current, A, that counts as current flowing in a leg.
    pub min_amps: f32,
    /// The first and the last period of a drive phase (from 1) whose shunt readings are
    /// averaged: early in the phase, where a voltage-driven motor's current is largest (it
    /// starts near V/R and falls as the motor speeds up), after it has risen.
    pub average: (u32, u32),
    /// The jog's own current limit, A: a shunt reading above it stops the jog at once.
    /// The safety system's over-current check reads the one leg the loop uses, which
    /// wrongly wired inputs may not be.
    pub trip_amps: f32,
    /// The lowest supply voltage the jog drives at, V.
    pub min_supply_v: f32,
}

impl JogConfig {
    /// 1.5 V for 0.3 s each way at a 1 kHz control rate, the bridge off for 0.3 s after
    /// each: a small motor turns slowly (one of 2 Ω draws at most 0.75 A; lower `volts`
    /// for one of less); a reading counts from 20 encoder counts and 0.05 A, averaged over
    /// periods 3 to 50 of a drive; the jog stops above 1.4 A in either shunt.
    pub const DEFAULT: JogConfig = JogConfig {
        volts: 1.5,
        drive_periods: 300,
        coast_periods: 300,
        permit_periods: 100,
        min_counts: 20,
        min_amps: 0.05,
        average: (3, 50),
        trip_amps: 1.4,
        min_supply_v: 8.0,
    };
}

/// The two leg shunts' currents, A, each positive for a current flowing down through its
/// shunt (the sign the board's amplifier convention gives).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Shunts {
    /// Leg U (the leg a positive duty switches).
    pub u: f32,
    /// Leg V (the leg a negative duty switches).
    pub v: f32,
}

/// One control period's readings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JogSample {
    /// The encoder count.
    pub counts: i32,
    /// The leg currents.
    pub shunts: Shunts,
    /// The motor supply, V.
    pub supply_v: f32,
    /// The safety system permits driving.
    pub permit: bool,
}

/// What to apply in the coming control period.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JogStep {
    /// Ask the safety system for the drive permit and keep the bridge off.
    AskPermit,
    /// Drive the bridge at this duty (−1 … 1, sign-magnitude).
    Drive(f32),
    /// Bridge off (the motor runs down; a holding brake, if there is one, engages).
    Coast,
    /// The jog is over: bridge off, give the permit back; what it found.
    Done(JogReport),
    /// The jog stopped early: bridge off, give the permit back.
    Stopped(JogStop),
}

/// Why a jog stopped early.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JogStop {
    /// The permit did not come within [`JogConfig::permit_periods`].
    NoPermit,
    /// The safety system withdrew the permit (e-stop, over-current, driver fault).
    PermitWithdrawn,
    /// The supply is below [`JogConfig::min_supply_v`].
    SupplyTooLow,
    /// A shunt read more than [`JogConfig::trip_amps`].
    OverCurrent,
    /// [`JogConfig::volts`] is not a positive, finite voltage: nothing is driven.
    InvalidVolts,
}

/// What one drive phase and the coast after it read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PhaseReading {
    /// The duty applied.
    pub duty: f32,
    /// Encoder travel from the drive's start to the coast's end, counts.
    pub counts: i32,
    /// Mean shunt currents over [`JogConfig::average`]'s periods of the drive.
    pub shunts: Shunts,
}

/// The motor's direction against the duty's sign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Counts up for a positive duty, down for a negative one.
    Correct,
    /// The other way round: swap the motor wires on OUT1 / OUT2 (the encoder's own sign
    /// was checked by hand, before the jog).
    Reversed,
    /// Too little travel either way: the motor did not turn (brake, wiring, too few volts).
    NoMotion,
    /// Neither of the above (one way only, or the same way twice): check the mechanics.
    Inconsistent,
}

/// What the idle legs (V for a positive duty, U for a negative one: the legs the current
/// loop reads) measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Legs {
    /// Both idle legs read the current, positive.
    Correct,
    /// Both idle legs read it negative while the switching legs read nothing: the
    /// amplifiers' polarity is the other one (`CURRENT_SIGN = -1`).
    SignInverted,
    /// The idle legs read nothing while the switching legs read the current: the two
    /// current inputs are swapped.
    Swapped,
    /// Both idle legs read the current negative and the switching legs positive: the
    /// inputs are swapped, or the amplifiers inverted, and a sample in the switching leg's
    /// off-time cannot tell which (check the order of the inputs against the board's
    /// manual, then jog again).
    SwappedOrInverted,
    /// In a drive phase no leg read the least current: the motor circuit is open, or the
    /// shunt amplifiers are not configured (three-shunt jumpers).
    NoCurrent,
    /// None of the above (one amplifier inverted, the same leg both ways): check the
    /// jumpers and the amplifiers.
    Inconsistent,
}

/// What a jog found.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JogReport {
    /// The positive drive phase.
    pub forward: PhaseReading,
    /// The negative drive phase.
    pub backward: PhaseReading,
    min_counts: u32,
    min_amps: f32,
}

impl JogReport {
    /// The motor's direction.
    pub fn direction(&self) -> Direction {
        let min = i64::from(self.min_counts);
        let up = |counts: i32| i64::from(counts) >= min;
        let down = |counts: i32| i64::from(counts).saturating_neg() >= min;
        let (f, b) = (self.forward.counts, self.backward.counts);
        if up(f) && down(b) {
            Direction::Correct
        } else if down(f) && up(b) {
            Direction::Reversed
        } else if !(up(f) || down(f) || up(b) || down(b)) {
            Direction::NoMotion
        } else {
            Direction::Inconsistent
        }
    }

    /// What the idle legs measured (see [`Legs`]).
    pub fn legs(&self) -> Legs {
        let min = self.min_amps;
        let (f, b) = (self.forward.shunts, self.backward.shunts);
        let moved = |s: Shunts| s.u.abs().max(s.v.abs()) >= min;
        if !moved(f) || !moved(b) {
            return Legs::NoCurrent;
        }
        // Each phase's idle leg and switching leg.
        let (idle_f, switching_f) = (f.v, f.u);
        let (idle_b, switching_b) = (b.u, b.v);
        let positive = |a: f32| a >= min;
        let negative = |a: f32| a <= -min;
        let quiet = |a: f32| a.abs() < min;
        if positive(idle_f) && positive(idle_b) {
            Legs::Correct
        } else if negative(idle_f) && negative(idle_b) {
            if quiet(switching_f) && quiet(switching_b) {
                Legs::SignInverted
            } else if positive(switching_f) && positive(switching_b) {
                Legs::SwappedOrInverted
            } else {
                Legs::Inconsistent
            }
        } else if quiet(idle_f) && quiet(idle_b) {
            Legs::Swapped
        } else {
            Legs::Inconsistent
        }
    }

    /// Both checks passed: the application may close its loops.
    pub fn is_correct(&self) -> bool {
        self.direction() == Direction::Correct && self.legs() == Legs::Correct
    }
}

/// Where a jog is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Waiting for the permit, for this many periods so far.
    Permit(u32),
    /// Driving at the phase's duty.
    Drive,
    /// Coasting after a drive phase.
    Coast,
    /// Done or stopped: this, from now on.
    Over(JogStep),
}

/// The open-loop jog: positive voltage, coast, negative voltage, coast. See the module.
#[derive(Clone, Copy, Debug)]
pub struct Jog {
    config: JogConfig,
    phase: Phase,
    /// Periods spent in the current drive or coast phase.
    periods: u32,
    /// The drive phase under way or just ended: forward first.
    backward: bool,
    /// The duty of the drive phase (fixed at its first period, from the supply then).
    duty: f32,
    /// The encoder count at the drive phase's start.
    start_counts: i32,
    /// Sums of the shunts over the drive phase's second half, and their count.
    sum: Shunts,
    summed: u32,
    forward: PhaseReading,
}

impl Jog {
    /// A jog that has not begun: its first step asks for the permit.
    pub const fn new(config: JogConfig) -> Jog {
        Jog {
            config,
            phase: Phase::Permit(0),
            periods: 0,
            backward: false,
            duty: 0.0,
            start_counts: 0,
            sum: Shunts { u: 0.0, v: 0.0 },
            summed: 0,
            forward: PhaseReading {
                duty: 0.0,
                counts: 0,
                shunts: Shunts { u: 0.0, v: 0.0 },
            },
        }
    }

    /// The duty applied in the last period (0 while waiting or coasting).
    pub fn duty(&self) -> f32 {
        match self.phase {
            Phase::Drive => self.duty,
            Phase::Permit(_) | Phase::Coast | Phase::Over(_) => 0.0,
        }
    }

    /// One control period: `sample` is what this period read (the effect of the last
    /// step); returns what to apply until the next. After `Done` or `Stopped` it keeps
    /// returning the same.
    pub fn step(&mut self, sample: &JogSample) -> JogStep {
        let volts = self.config.volts;
        let step = if !(volts.is_finite() && volts > 0.0) {
            JogStep::Stopped(JogStop::InvalidVolts)
        } else if self.drives() && self.over_current(sample.shunts) {
            JogStep::Stopped(JogStop::OverCurrent)
        } else {
            self.next(sample)
        };
        if let JogStep::Done(_) | JogStep::Stopped(_) = step {
            self.phase = Phase::Over(step);
        }
        step
    }

    /// Whether the bridge was on, or is still running down from it.
    fn drives(&self) -> bool {
        matches!(self.phase, Phase::Drive | Phase::Coast)
    }

    /// A shunt reads more than the jog's limit (or NaN).
    fn over_current(&self, shunts: Shunts) -> bool {
        let within = |a: f32| a.abs() <= self.config.trip_amps;
        !(within(shunts.u) && within(shunts.v))
    }

    /// What `step` returns, the end not yet kept.
    fn next(&mut self, sample: &JogSample) -> JogStep {
        match self.phase {
            Phase::Over(step) => step,
            Phase::Permit(waited) => {
                if !sample.permit {
                    if waited >= self.config.permit_periods {
                        return JogStep::Stopped(JogStop::NoPermit);
                    }
                    self.phase = Phase::Permit(waited.saturating_add(1));
                    return JogStep::AskPermit;
                }
                self.begin_drive(sample)
            }
            Phase::Drive => {
                if !sample.permit {
                    return JogStep::Stopped(JogStop::PermitWithdrawn);
                }
                self.periods = self.periods.saturating_add(1);
                let (first, last) = self.config.average;
                if (first..=last).contains(&self.periods) {
                    self.sum.u += sample.shunts.u;
                    self.sum.v += sample.shunts.v;
                    self.summed = self.summed.saturating_add(1);
                }
                if self.periods >= self.config.drive_periods {
                    self.phase = Phase::Coast;
                    self.periods = 0;
                    return JogStep::Coast;
                }
                JogStep::Drive(self.duty)
            }
            Phase::Coast => {
                if !sample.permit {
                    return JogStep::Stopped(JogStop::PermitWithdrawn);
                }
                self.periods = self.periods.saturating_add(1);
                if self.periods < self.config.coast_periods {
                    return JogStep::Coast;
                }
                let reading = self.reading(sample.counts);
                if self.backward {
                    return JogStep::Done(JogReport {
                        forward: self.forward,
                        backward: reading,
                        min_counts: self.config.min_counts,
                        min_amps: self.config.min_amps,
                    });
                }
                self.forward = reading;
                self.backward = true;
                self.begin_drive(sample)
            }
        }
    }

    /// The first period of a drive phase: its duty from the supply now.
    fn begin_drive(&mut self, sample: &JogSample) -> JogStep {
        let supply = sample.supply_v;
        if !(supply.is_finite() && supply >= self.config.min_supply_v) {
            return JogStep::Stopped(JogStop::SupplyTooLow);
        }
        let magnitude = (self.config.volts / supply).min(1.0);
        self.duty = if self.backward { -magnitude } else { magnitude };
        self.phase = Phase::Drive;
        self.periods = 0;
        self.start_counts = sample.counts;
        self.sum = Shunts::default();
        self.summed = 0;
        JogStep::Drive(self.duty)
    }

    /// What the drive phase just ended and its coast read.
    fn reading(&self, counts: i32) -> PhaseReading {
        let n = self.summed.max(1) as f32;
        PhaseReading {
            duty: self.duty,
            counts: counts.wrapping_sub(self.start_counts),
            shunts: Shunts {
                u: self.sum.u / n,
                v: self.sum.v / n,
            },
        }
    }
}

#[cfg(test)]
#[allow(clippy::panic, clippy::arithmetic_side_effects, clippy::float_cmp)]
mod tests {
    extern crate std;

    use super::*;

    /// A drive, as the bridge and its sensors answer a duty: `counts_per_period` of travel
    /// per unit duty, `amps` in the leg that carries the current (by `legs`).
    struct Drive {
        counts: i32,
        counts_per_duty: f32,
        /// (positive duty, negative duty) → shunts.
        legs: fn(f32) -> Shunts,
        permit_from: u32,
        permit_until: u32,
        supply_v: f32,
    }

    fn correct(duty: f32) -> Shunts {
        match duty {
            d if d > 0.0 => Shunts { u: 0.0, v: 0.25 },
            d if d < 0.0 => Shunts { u: 0.25, v: 0.0 },
            _ => Shunts::default(),
        }
    }

    impl Drive {
        fn new(legs: fn(f32) -> Shunts) -> Drive {
            Drive {
                counts: 0,
                counts_per_duty: 200.0,
                legs,
                permit_from: 3,
                permit_until: u32::MAX,
                supply_v: 12.0,
            }
        }

        /// Runs a jog to its end; the steps it returned, in order, collapsed into runs
        /// (`AskPermit` ×3, `Drive` ×300, ...), and its last.
        fn run(&mut self, config: JogConfig) -> (std::vec::Vec<(&'static str, u32)>, JogStep) {
            let mut jog = Jog::new(config);
            let mut runs: std::vec::Vec<(&'static str, u32)> = std::vec::Vec::new();
            for period in 0..100_000u32 {
                let duty = jog.duty();
                self.counts += (duty * self.counts_per_duty) as i32;
                let sample = JogSample {
                    counts: self.counts,
                    shunts: (self.legs)(duty),
                    supply_v: self.supply_v,
                    permit: period >= self.permit_from && period < self.permit_until,
                };
                let step = jog.step(&sample);
                let name = match step {
                    JogStep::AskPermit => "ask",
                    JogStep::Drive(d) if d > 0.0 => "drive+",
                    JogStep::Drive(_) => "drive-",
                    JogStep::Coast => "coast",
                    JogStep::Done(_) | JogStep::Stopped(_) => return (runs, step),
                };
                match runs.last_mut() {
                    Some((n, c)) if *n == name => *c += 1,
                    _ => runs.push((name, 1)),
                }
            }
            panic!("the jog did not end");
        }
    }

    fn report(step: JogStep) -> JogReport {
        match step {
            JogStep::Done(r) => r,
            other => panic!("not done: {other:?}"),
        }
    }

    #[test]
    fn a_correct_drive_passes_after_the_phases_in_order() {
        let (runs, last) = Drive::new(correct).run(JogConfig::DEFAULT);
        assert_eq!(
            runs,
            [
                ("ask", 3),
                ("drive+", 300),
                ("coast", 300),
                ("drive-", 300),
                ("coast", 300)
            ]
        );
        let r = report(last);
        // 1.5 V of 12 V: duty 0.125, 25 counts per period for 300 periods.
        assert_eq!(r.forward.duty, 0.125);
        assert_eq!(r.forward.counts, 25 * 300);
        assert_eq!(r.backward.counts, -25 * 300);
        assert_eq!(r.forward.shunts, Shunts { u: 0.0, v: 0.25 });
        assert_eq!(r.backward.shunts, Shunts { u: 0.25, v: 0.0 });
        assert_eq!(
            (r.direction(), r.legs()),
            (Direction::Correct, Legs::Correct)
        );
        assert!(r.is_correct());
    }

    #[test]
    fn a_reversed_motor_is_found() {
        let mut d = Drive::new(correct);
        d.counts_per_duty = -200.0;
        let r = report(d.run(JogConfig::DEFAULT).1);
        assert_eq!(
            (r.direction(), r.legs()),
            (Direction::Reversed, Legs::Correct)
        );
        assert!(!r.is_correct());
    }

    #[test]
    fn a_motor_that_does_not_turn_is_found() {
        let mut d = Drive::new(correct);
        d.counts_per_duty = 0.0;
        let r = report(d.run(JogConfig::DEFAULT).1);
        assert_eq!(r.direction(), Direction::NoMotion);
    }

    #[test]
    fn swapped_inverted_and_missing_currents_are_found() {
        fn swapped(duty: f32) -> Shunts {
            let s = correct(duty);
            Shunts { u: s.v, v: s.u }
        }
        fn inverted(duty: f32) -> Shunts {
            let s = correct(duty);
            Shunts { u: -s.u, v: -s.v }
        }
        fn none(_: f32) -> Shunts {
            Shunts { u: 0.01, v: -0.01 }
        }
        fn one_way(duty: f32) -> Shunts {
            Shunts {
                u: 0.0,
                v: 0.25 * duty.signum(),
            }
        }
        for (legs, expected) in [
            (swapped as fn(f32) -> Shunts, Legs::Swapped),
            (inverted, Legs::SignInverted),
            (none, Legs::NoCurrent),
            (one_way, Legs::Inconsistent),
        ] {
            let r = report(Drive::new(legs).run(JogConfig::DEFAULT).1);
            assert_eq!((r.direction(), r.legs()), (Direction::Correct, expected));
        }
    }

    /// A jog in the first period of its forward drive (12 V: duty 0.125), and the sample
    /// that began it.
    fn driving_forward() -> (Jog, JogSample) {
        let mut jog = Jog::new(JogConfig::DEFAULT);
        let sample = JogSample {
            counts: 0,
            shunts: Shunts::default(),
            supply_v: 12.0,
            permit: true,
        };
        assert_eq!(jog.step(&sample), JogStep::Drive(0.125));
        (jog, sample)
    }

    #[test]
    fn periods_3_to_50_of_a_drive_phase_are_averaged() {
        // 0.5 A in periods 3 to 50 (the window), 1 A in periods 1 and 2 (the current still
        // rising: not in it) and 0.25 A after (not in it either).
        let (mut jog, mut sample) = driving_forward();
        for period in 1..=300 {
            sample.shunts.v = match period {
                1 | 2 => 1.0,
                3..=50 => 0.5,
                _ => 0.25,
            };
            sample.counts = period;
            jog.step(&sample);
        }
        sample.shunts = Shunts::default();
        let mut last = JogStep::Coast;
        for _ in 0..300 {
            last = jog.step(&sample);
        }
        // The coast's last period began the backward phase.
        assert_eq!(last, JogStep::Drive(-0.125));
        assert_eq!(jog.forward.shunts, Shunts { u: 0.0, v: 0.5 });
        assert_eq!(jog.forward.counts, 300);
    }

    #[test]
    fn a_shunt_over_the_limit_stops_the_jog_at_once() {
        let (mut jog, mut sample) = driving_forward();
        sample.shunts.u = -1.4;
        assert_eq!(jog.step(&sample), JogStep::Drive(0.125));
        sample.shunts.u = -1.41;
        assert_eq!(jog.step(&sample), JogStep::Stopped(JogStop::OverCurrent));
        assert_eq!(jog.duty(), 0.0);
        sample.shunts.u = 0.0;
        assert_eq!(jog.step(&sample), JogStep::Stopped(JogStop::OverCurrent));
        // A NaN reading too.
        let (mut jog, mut sample) = driving_forward();
        sample.shunts.v = f32::NAN;
        assert_eq!(jog.step(&sample), JogStep::Stopped(JogStop::OverCurrent));
    }

    #[test]
    fn no_permit_a_withdrawn_permit_and_a_low_supply_stop_the_jog() {
        let mut d = Drive::new(correct);
        d.permit_from = u32::MAX;
        let (runs, last) = d.run(JogConfig::DEFAULT);
        assert_eq!(runs, [("ask", 100)]);
        assert_eq!(last, JogStep::Stopped(JogStop::NoPermit));

        // An e-stop during the backward phase.
        let mut d = Drive::new(correct);
        d.permit_until = 3 + 300 + 300 + 50;
        let (runs, last) = d.run(JogConfig::DEFAULT);
        assert_eq!(
            runs,
            [("ask", 3), ("drive+", 300), ("coast", 300), ("drive-", 50)]
        );
        assert_eq!(last, JogStep::Stopped(JogStop::PermitWithdrawn));

        let mut d = Drive::new(correct);
        d.supply_v = 7.9;
        let (runs, last) = d.run(JogConfig::DEFAULT);
        assert_eq!(runs, [("ask", 3)]);
        assert_eq!(last, JogStep::Stopped(JogStop::SupplyTooLow));
    }

    #[test]
    fn an_ended_jog_keeps_its_end() {
        let mut jog = Jog::new(JogConfig {
            permit_periods: 0,
            ..JogConfig::DEFAULT
        });
        let no = JogSample {
            counts: 0,
            shunts: Shunts::default(),
            supply_v: 12.0,
            permit: false,
        };
        assert_eq!(jog.step(&no), JogStep::Stopped(JogStop::NoPermit));
        assert_eq!(jog.step(&no), JogStep::Stopped(JogStop::NoPermit));
    }
}
