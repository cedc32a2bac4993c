//! The drive's sensors, sampled once per control period into a
//! [`Measurements`]: the encoder timer's count, the two leg currents (ADC1, one-shot
//! conversions), the bus voltage and the switches (embedded-hal 1.0 [`InputPin`]s). The
//! L6230's fault line belongs to the bridge (it is also a disable output): see
//! [`Bridge::driver_fault`](crate::drive::Bridge::driver_fault).

use core::convert::Infallible;

use embedded_hal::digital::InputPin;
use rtseq_motor::bringup::Shunts;
use rtseq_motor::hardware::Measurements;
use rtseq_motor::plant::M_PER_COUNT;
use stm32f4xx_hal::adc::config::SampleTime;
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::pac::ADC1;
use stm32f4xx_hal::prelude::*;

use crate::pins::{
    Button, CurrentU, CurrentV, EStop, Encoder, EndStopNeg, EndStopPos, Vbus,
    SWITCHES_NORMALLY_CLOSED,
};

/// Travel per encoder count, m: the application's axis (5 mm lead, 1000-line encoder,
/// quadrature). Change it for your mechanics (and the application's targets with it).
pub const METRES_PER_COUNT: f32 = M_PER_COUNT;
/// Count direction: `-1` if the encoder counts down when the motor turns forwards
/// (positive duty).
pub const ENCODER_SIGN: i32 = 1;
/// Shunt amplifier: 0.33 Ω × gain 1.53 ≈ 0.505 V/A, at a 3.3 V / 12-bit ADC ≈ 626 counts
/// per ampere (IHM07M1, three-shunt configuration).
pub const COUNTS_PER_AMP: f32 = 0.33 * 1.53 / 3.3 * 4096.0;
/// Polarity of the amplifiers: `-1.0` if the reading falls with a current flowing down
/// through the shunt (check at the first power-up: a positive duty must read a positive
/// current).
pub const CURRENT_SIGN: f32 = 1.0;
/// Bus-voltage divider on PA1: the fraction of the J1 supply the ADC sees. 9.31 kΩ over
/// 169 kΩ + 9.31 kΩ is an **unconfirmed** value: UM1943 (the IHM07M1's manual, which has the
/// schematic) could not be consulted when this was written. Step 4 of the bring-up checklist
/// compares the logged VBUS with a multimeter on J1; correct this constant if they differ.
pub const VBUS_DIVIDER: f32 = 9.31 / (169.0 + 9.31);
/// ADC counts to volts on J1 (3.3 V reference, 12 bits).
const VBUS_VOLTS_PER_COUNT: f32 = 3.3 / 4096.0 / VBUS_DIVIDER;
/// ADC samples averaged for the zero-current offset at start-up (bridge off).
pub const OFFSET_SAMPLES: u32 = 64;
/// How far a zero-current offset may lie from mid-scale (2048 counts, 1.65 V), in counts
/// (about 0.3 A): farther, the amplifier is not in the three-shunt configuration (J5/J6) or
/// is faulty, and the current the control loop and the safety system read is not the
/// motor's.
pub const OFFSET_TOLERANCE: f32 = 200.0;

/// The least current the amplifiers measure before the ADC clips, A: half the scale
/// (2048 counts) less the farthest plausible offset ([`OFFSET_TOLERANCE`]), about 2.9 A.
pub const MEASURABLE_AMPS: f32 = (2048.0 - OFFSET_TOLERANCE) / COUNTS_PER_AMP;
/// The software over-current trip of this board, A: above the command limit
/// ([`I_LIMIT`](crate::drive::I_LIMIT), 1.4 A) with room for the current loop's overshoot,
/// and below [`MEASURABLE_AMPS`], so a current the ADC clips at trips too. (The motor
/// application's 6 A trip is its simulated sensor's; this sensor never reads 6 A.)
pub const CURRENT_TRIP: f32 = 2.0;
const _: () = assert!(CURRENT_TRIP > crate::drive::I_LIMIT && CURRENT_TRIP < MEASURABLE_AMPS);

/// Whether both measured offsets are plausible (see [`OFFSET_TOLERANCE`]).
pub fn offsets_plausible(u: f32, v: f32) -> bool {
    (u - 2048.0).abs() <= OFFSET_TOLERANCE && (v - 2048.0).abs() <= OFFSET_TOLERANCE
}
/// ADC sample time: 28 cycles + 12 at 21 MHz ≈ 1.9 µs per conversion.
const SAMPLE_TIME: SampleTime = SampleTime::Cycles_28;

/// What the switches read, for the log (active = reached / pressed / fault).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct Switches {
    /// Negative end stop reached.
    pub end_neg: bool,
    /// Positive end stop reached.
    pub end_pos: bool,
    /// E-stop pressed.
    pub estop: bool,
    /// The L6230 signals a fault (DIAG/EN low).
    pub driver_fault: bool,
    /// User button pressed.
    pub button: bool,
}

/// The sensors and their calibration.
pub struct Sensors {
    encoder: Encoder,
    adc: Adc<ADC1>,
    current_u: CurrentU,
    current_v: CurrentV,
    end_neg: EndStopNeg,
    end_pos: EndStopPos,
    estop: EStop,
    button: Button,
    vbus: Vbus,
    offset_u: f32,
    offset_v: f32,
}

fn high<P: InputPin<Error = Infallible>>(pin: &mut P) -> bool {
    match pin.is_high() {
        Ok(level) => level,
        Err(never) => match never {},
    }
}

/// A normally-closed switch to GND with a pull-up: open (high) = active.
fn switch_active<P: InputPin<Error = Infallible>>(pin: &mut P) -> bool {
    high(pin) == SWITCHES_NORMALLY_CLOSED
}

impl Sensors {
    /// Takes the configured peripherals; [`calibrate`](Self::calibrate) before use.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        encoder: Encoder,
        adc: Adc<ADC1>,
        current_u: CurrentU,
        current_v: CurrentV,
        end_neg: EndStopNeg,
        end_pos: EndStopPos,
        estop: EStop,
        button: Button,
        vbus: Vbus,
    ) -> Self {
        let mid = 2048.0;
        Sensors {
            encoder,
            adc,
            current_u,
            current_v,
            end_neg,
            end_pos,
            estop,
            button,
            vbus,
            offset_u: mid,
            offset_v: mid,
        }
    }

    /// Measures the amplifiers' zero-current offsets (call with the bridge off) and returns
    /// them in ADC counts.
    pub fn calibrate(&mut self) -> (f32, f32) {
        let (mut u, mut v) = (0u32, 0u32);
        for _ in 0..OFFSET_SAMPLES {
            u = u.saturating_add(u32::from(self.adc.convert(&self.current_u, SAMPLE_TIME)));
            v = v.saturating_add(u32::from(self.adc.convert(&self.current_v, SAMPLE_TIME)));
        }
        self.offset_u = u as f32 / OFFSET_SAMPLES as f32;
        self.offset_v = v as f32 / OFFSET_SAMPLES as f32;
        (self.offset_u, self.offset_v)
    }

    /// The encoder count since power-up (TIM2 is 32 bits wide: it wraps after 2³² counts,
    /// i.e. never on this axis).
    pub fn counts(&self) -> i32 {
        (self.encoder.count() as i32).wrapping_mul(ENCODER_SIGN)
    }

    /// The bus voltage on J1, V (one conversion of PA1).
    pub fn vbus(&mut self) -> f32 {
        f32::from(self.adc.convert(&self.vbus, SAMPLE_TIME)) * VBUS_VOLTS_PER_COUNT
    }

    /// The switches; `driver_fault` is the bridge's reading of DIAG/EN.
    pub fn switches(&mut self, driver_fault: bool) -> Switches {
        Switches {
            end_neg: switch_active(&mut self.end_neg),
            end_pos: switch_active(&mut self.end_pos),
            estop: switch_active(&mut self.estop),
            driver_fault,
            button: !high(&mut self.button),
        }
    }

    /// One sample of everything, and both leg currents as read (for the bring-up jog).
    /// `forward`: the bridge's last duty was ≥ 0, so leg V's low side carries the motor
    /// current continuously (otherwise leg U's, reversed). `with_button`: report the user
    /// button as the pause button (not while it still serves as the start button).
    /// `driver_fault`: the bridge's reading of DIAG/EN.
    pub fn sample(
        &mut self,
        forward: bool,
        with_button: bool,
        driver_fault: bool,
    ) -> (Measurements, Switches, Shunts) {
        let counts = self.counts();
        let raw_u = f32::from(self.adc.convert(&self.current_u, SAMPLE_TIME));
        let raw_v = f32::from(self.adc.convert(&self.current_v, SAMPLE_TIME));
        let shunt_u = CURRENT_SIGN * (raw_u - self.offset_u) / COUNTS_PER_AMP;
        let shunt_v = CURRENT_SIGN * (raw_v - self.offset_v) / COUNTS_PER_AMP;
        let current = if forward { shunt_v } else { -shunt_u };
        let sw = self.switches(driver_fault);
        let m = Measurements {
            position: Measurements::counts_to_metres(counts, METRES_PER_COUNT),
            current,
            end_stop_neg: sw.end_neg,
            end_stop_pos: sw.end_pos,
            // A driver fault (over-current, over-temperature) is an emergency like the
            // e-stop: the safety system's e-stop input sees both.
            estop: sw.estop || sw.driver_fault,
            pause_button: with_button && sw.button,
        };
        let shunts = Shunts {
            u: shunt_u,
            v: shunt_v,
        };
        (m, sw, shunts)
    }
}
