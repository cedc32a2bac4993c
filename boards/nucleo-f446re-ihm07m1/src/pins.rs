//! Every pin of the firmware, in one place: NUCLEO-F446RE (MB1136) with an X-NUCLEO-IHM07M1
//! stacked on its Arduino and ST morpho connectors.
//!
//! # Motor: brushed DC from two half-bridges of the L6230
//!
//! The motor sits between the IHM07M1 outputs **OUT1 (U)** and **OUT2 (V)** of connector J2;
//! **OUT3 (W) stays unconnected** and its half-bridge disabled (EN3 low). Sign-magnitude
//! PWM at 20 kHz: for a positive duty, IN1 switches and IN2 stays low (V's low side on), for a
//! negative duty the other way round. EN1/EN2 low switch both half-bridges off (the motor
//! coasts): that is the power stage's safe state.
//!
//! | function | MCU pin | peripheral | connector | level |
//! |---|---|---|---|---|
//! | IN1 (U high/low side) | PA8 | TIM1_CH1, 20 kHz PWM | CN10-23 / D7 | duty |
//! | IN2 (V high/low side) | PA9 | TIM1_CH2, 20 kHz PWM | CN10-21 / D8 | duty |
//! | IN3 (W, unused) | PA10 | left as input | CN10-33 / D2 | — |
//! | EN1 (U enable) | PC10 | GPIO out | CN7-1 | high = on |
//! | EN2 (V enable) | PC11 | GPIO out | CN7-2 | high = on |
//! | EN3 (W enable) | PC12 | GPIO out, held low | CN7-3 | low |
//! | L6230 DIAG/EN | PA11 | GPIO open-drain out (read back) | CN10-14 | driven low = all half-bridges off (the second disable path); released: low = over-current / over-temperature |
//! | current U (shunt amp.) | PA0 | ADC1_IN0 | CN7-28 / A0 | ≈ 0.5 V/A around the offset |
//! | current V (shunt amp.) | PC1 | ADC1_IN11 | CN7-36 / A4 | ≈ 0.5 V/A around the offset |
//! | bus voltage VBUS (divider) | PA1 | ADC1_IN1 | CN7-30 / A1 | [`VBUS_DIVIDER`](crate::sensors::VBUS_DIVIDER) of the J1 supply |
//! | encoder A | PA15 | TIM2_CH1 (encoder mode) | IHM07M1 J3 "A+/H1" | 3.3 V / 5 V push-pull or open collector |
//! | encoder B | PB3 | TIM2_CH2 (encoder mode) | IHM07M1 J3 "B+/H2" | |
//! | end stop − | PC8 | GPIO in, pull-up | CN10-2 | NC contact to GND: **high = reached** (or wire broken) |
//! | end stop + | PC6 | GPIO in, pull-up | CN10-4 | NC contact to GND: **high = reached** |
//! | e-stop | PC5 | GPIO in, pull-up | CN10-6 | NC contact to GND: **high = pressed** (or wire broken) |
//! | brake release | PB12 | GPIO out | CN10-16 | high = brake released (drive a relay/MOSFET; unpowered = engaged) |
//! | status LED LD2 | PA5 | GPIO out | on the Nucleo | high = on |
//! | user button B1 | PC13 | GPIO in (external pull-up on the Nucleo) | on the Nucleo | **low = pressed**: start, then pause / resume |
//!
//! PA15 and PB3 are JTDI / JTDO-SWO after reset: the firmware uses SWD + RTT only (probe-rs),
//! so remapping them to TIM2 costs nothing but SWO tracing.
//!
//! # IHM07M1 settings (check them against UM1943, the board's user manual)
//!
//! * **Three-shunt current sensing** (J5 and J6 in the three-shunt position; the factory
//!   setting is single shunt): each leg's low side has its own 0.33 Ω shunt and amplifier,
//!   so PA0 and PC1 see the U and V leg currents. ST's pin header for this board
//!   (`x_nucleo_ihm07m1_targets.h` of its HelloWorld_IHM07M1 example) names PA0 `CURR1`, PC1
//!   `CURR2`, PC0 `CURR3` and PA1 `VBUS`; that `CURR1` is leg U (OUT1) and the amplifiers'
//!   polarity are not stated there, and other public ports label the legs the other way
//!   round with an inverted gain: the bring-up checklist (README, step 5) tells which leg is
//!   which and the sign on the bench, before the loop is closed.
//! * **Power**: the motor supply (8–48 V, current-limited bench supply for the first tests)
//!   on J1; the Nucleo from USB (ST-LINK). Only if the Nucleo should take its 5 V from the
//!   IHM07M1 instead, follow UM1943's power-supply section (Nucleo JP5 on E5V and the
//!   IHM07M1's 5 V jumper).
//! * **Encoder** on J3 (A+, B+, GND, 5 V/3.3 V): the IHM07M1 has pull-ups on these lines for
//!   open-collector Hall/encoder outputs; PA15 and PB3 are 5 V tolerant.
//!
//! The switches are all **normally-closed contacts to GND**: a broken wire, an unplugged
//! connector or a pressed e-stop read as "open" (high, through the internal pull-up), which
//! the safety system treats as "end stop reached" / "e-stop pressed": fail-safe wiring.

use stm32f4xx_hal::gpio::{Analog, Input, OpenDrain, Output, PushPull};
use stm32f4xx_hal::gpio::{PA0, PA1, PA11, PA5, PB12, PC1, PC10, PC11, PC12, PC13, PC5, PC6, PC8};
use stm32f4xx_hal::pac::{TIM1, TIM2};
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::timer::PwmChannel;

/// IN1: PWM of half-bridge U (TIM1_CH1 on PA8).
pub type In1 = PwmChannel<TIM1, 0>;
/// IN2: PWM of half-bridge V (TIM1_CH2 on PA9).
pub type In2 = PwmChannel<TIM1, 1>;
/// EN1: enable of half-bridge U.
pub type En1 = PC10<Output<PushPull>>;
/// EN2: enable of half-bridge V.
pub type En2 = PC11<Output<PushPull>>;
/// EN3: enable of half-bridge W (held low: unused by the DC motor).
pub type En3 = PC12<Output<PushPull>>;
/// The L6230's DIAG/EN line, open drain on both sides: the L6230 pulls it low on an
/// over-current or over-temperature; pulled low by the MCU it disables all three
/// half-bridges whatever EN1–EN3 say. The safe state drives it low.
pub type Diag = PA11<Output<OpenDrain>>;
/// The bus-voltage divider's output.
pub type Vbus = PA1<Analog>;
/// Shunt amplifier of leg U.
pub type CurrentU = PA0<Analog>;
/// Shunt amplifier of leg V.
pub type CurrentV = PC1<Analog>;
/// The quadrature encoder on TIM2 (32-bit counter; A = PA15, B = PB3).
pub type Encoder = Qei<TIM2>;
/// Negative end-stop switch.
pub type EndStopNeg = PC8<Input>;
/// Positive end-stop switch.
pub type EndStopPos = PC6<Input>;
/// Emergency-stop button.
pub type EStop = PC5<Input>;
/// Holding-brake release output.
pub type BrakeRelease = PB12<Output<PushPull>>;
/// Status LED LD2.
pub type Led = PA5<Output<PushPull>>;
/// User button B1.
pub type Button = PC13<Input>;

/// Switch inputs read high when open (NC contacts to GND with pull-ups): `true` = the switch
/// is "active" (end stop reached, e-stop pressed). Set to `false` only for normally-open
/// switches, which lose the broken-wire detection.
pub const SWITCHES_NORMALLY_CLOSED: bool = true;
