//! Board support for rtseq on the emulated STM32F405 (QEMU machine `netduinoplus2`).
//!
//! Everything an RTIC application in `src/bin/*.rs` needs besides its `#[rtic::app]`:
//!
//! - [`clock`]: the 1 kHz sequencer heartbeat on TIM2 (update interrupt) and the
//!   monotonic time derived from it (`fugit` microsecond [`clock::Instant`]s);
//! - [`measure`](mod@measure): instruction counting with TIM2 under `-icount shift=0`;
//! - [`stack`]: stack depth by painting, of a whole run or of one call;
//! - [`signal`]: [`signal::TickSignal`], how the tick interrupt wakes a lane;
//! - [`args`]: the firmware's command line (semihosting), e.g. fault injection options;
//! - [`logger`]: a panic-free `defmt` global logger over semihosting (decoded on the
//!   host by `tools/qemu-run`);
//! - [`exit`]: ending QEMU with an exit code; the panic handler, HardFault and
//!   unexpected-interrupt handlers (non-zero exit codes), and the no-panic proof
//!   (feature `no-panic`).
//!
//! QEMU facts this relies on (see `DESIGN.md` §7): TIM2–5 count at 1 GHz whatever
//! the prescaler says and raise only update interrupts; with `-icount shift=0` one
//! guest instruction takes exactly 1 ns of virtual time, so one TIM2 count is one
//! instruction; there is no RCC model (keep the HSI, never wait for the PLL);
//! DWT.CYCCNT reads 0.
#![no_std]

pub use stm32f4::stm32f405 as pac;

pub mod args;
pub mod clock;
pub mod exit;
pub mod logger;
pub mod measure;
pub mod semihost;
pub mod signal;
pub mod stack;

pub use exit::{exit, exit_failure, exit_success, ExitCode};
pub use measure::{measure, measure_with};

// Every defmt frame carries the virtual time since reset in microseconds (tick time plus
// the position of TIM2 inside the current tick), printed by the decoder as seconds.
defmt::timestamp!("{=u64:us}", clock::now_fine().as_ticks());
