//! Ending the emulation: exit codes through semihosting (`SYS_EXIT_EXTENDED`, which QEMU
//! passes through as its own exit status), and the handlers that end it on a failure.
//!
//! | code | meaning |
//! |---|---|
//! | 0   | [`ExitCode::Success`]: the firmware finished what it was built to do |
//! | 1   | [`ExitCode::Failure`]: the firmware detected a failure itself (e.g. a trace mismatch) |
//! | 101 | [`ExitCode::Panic`]: a Rust panic (message logged first) |
//! | 102 | [`ExitCode::HardFault`] |
//! | 103 | [`ExitCode::UnexpectedInterrupt`]: an interrupt without handler fired |
//! | 104 | [`ExitCode::LogLost`]: the firmware ended with success, but the host refused log bytes ([`crate::logger`]) |
//!
//! The host runner (`tools/qemu-run`) adds 124 (time limit hit) and 125 (QEMU could not be
//! started / killed by a signal).
//!
//! # No-panic proof (feature `no-panic`)
//! With `--features no-panic` the panic handler calls
//! `rtseq_no_panic_proof__a_panic_path_survived_optimisation`, an `extern "C"` function
//! that exists nowhere. If any panic path (`unwrap`, failing index, overflow check,
//! `panic!`, ...) survives optimisation in the release build (fat LTO), the link fails
//! with "undefined symbol: rtseq_no_panic_proof__a_panic_path_survived_optimisation".
//! If it links, the firmware provably contains no reachable panic.

/// Exit codes of the firmware (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
#[repr(i32)]
pub enum ExitCode {
    Success = 0,
    Failure = 1,
    Panic = 101,
    HardFault = 102,
    UnexpectedInterrupt = 103,
    LogLost = 104,
}

/// Ends QEMU with `code` as its exit status; with [`ExitCode::LogLost`] instead of
/// [`ExitCode::Success`] if the logger could not hand some bytes to the host (a log that
/// misses lines must not pass for a complete one). Other codes are kept: they fail anyway.
#[inline]
pub fn exit(code: ExitCode) -> ! {
    let lost = crate::logger::lost_bytes();
    if lost == 0 {
        crate::semihost::exit(code as i32)
    }
    // Probably lost as well, but says why if the host takes it.
    defmt::error!("logger: the host refused {=u32} log bytes", lost);
    let code = match code {
        ExitCode::Success => ExitCode::LogLost,
        other => other,
    };
    crate::semihost::exit(code as i32)
}

/// Ends QEMU with status 0.
pub fn exit_success() -> ! {
    exit(ExitCode::Success)
}

/// Ends QEMU with status 1 (a failure the firmware detected itself).
pub fn exit_failure() -> ! {
    exit(ExitCode::Failure)
}

#[cfg(not(feature = "no-panic"))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("PANIC: {}", defmt::Display2Format(info));
    exit(ExitCode::Panic)
}

#[cfg(feature = "no-panic")]
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    extern "C" {
        // Deliberately defined nowhere: see the module docs.
        fn rtseq_no_panic_proof__a_panic_path_survived_optimisation() -> !;
    }
    // SAFETY: never runs: the firmware only links if this call is unreachable.
    unsafe { rtseq_no_panic_proof__a_panic_path_survived_optimisation() }
}

#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    exit(ExitCode::HardFault)
}

#[cortex_m_rt::exception]
unsafe fn DefaultHandler(irqn: i16) {
    defmt::error!("unexpected interrupt/exception {=i16}", irqn);
    exit(ExitCode::UnexpectedInterrupt)
}
