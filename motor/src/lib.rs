//! # rtseq-motor — the motor-controller application of rtseq
//!
//! The application logic of rtseq's motor-controller demo as a reusable `no_std`, heap-free
//! crate: the same code runs in the host simulator (`rtseq::sim`, feature `std`) and in
//! the QEMU / STM32 firmware.
//!
//! | module | concept |
//! |---|---|
//! | [`plant`] | the simulated machine: DC servo motor, lead screw, carriage; encoder, current sensor, end stops, e-stop; fault hooks |
//! | [`controller`] | trapezoidal setpoint generator; cascaded P → PI (anti-windup) → current servo |
//! | [`bringup`] | an open-loop jog that checks a real drive's motor direction and current legs before the first closed loop |
//! | [`hardware`] | the hardware boundary: [`Measurements`](hardware::Measurements) in, [`DriveCommand`](hardware::DriveCommand) out — the simulated plant or a real drive |
//! | [`control_system`] | [`ControlSystem`](control_system::ControlSystem): the `C` of the sequencer, shared by the control interrupt, the safety task, the tick and the lanes |
//! | [`sequences`] | main (power on → homing → moves → power off), status LED, safe stop, feed hold / resume |
//! | [`safety`] | safety levels, critical inputs and outputs for [`rtseq::safety`] |
//! | [`app`] | [`app::register`]: everything into a sequencer and a monitor table; fault plan; summary |
//!
//! See [`app`] for a complete run on the host simulator.
#![no_std]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects
)]

pub mod app;
pub mod bringup;
pub mod control_system;
pub mod controller;
pub mod hardware;
pub mod plant;
pub mod safety;
pub mod sequences;
