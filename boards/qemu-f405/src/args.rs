//! The firmware's command line (semihosting `SYS_GET_CMDLINE`).
//!
//! `qemu-run FIRMWARE.elf a b` (or `cargo qemu-demo -- a b`) passes `FIRMWARE.elf a b` to
//! QEMU as `-semihosting-config ...,arg=FIRMWARE.elf,arg=a,arg=b`; the firmware reads it
//! here as one space-separated string, program name first. Panic-free.

/// Reads the command line into `buf`; `None` if the host has none or it does not fit.
pub fn cmdline(buf: &mut [u8]) -> Option<&str> {
    let len = crate::semihost::get_cmdline(buf)?;
    core::str::from_utf8(buf.get(..len)?).ok()
}

/// The arguments after the program name, split on spaces.
pub fn args(buf: &mut [u8]) -> impl Iterator<Item = &str> {
    cmdline(buf)
        .unwrap_or("")
        .split(' ')
        .filter(|a| !a.is_empty())
        .skip(1)
}
