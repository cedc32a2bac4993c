//! The firmware's command line (semihosting `SYS_GET_CMDLINE`).
//!
//! `qemu-run FIRMWARE.elf a b` (or `cargo qemu-demo -- a b`) passes `FIRMWARE.elf a b` to
//! QEMU as `-semihosting-config ...,arg=FIRMWARE.elf,arg=a,arg=b`; the firmware reads it
//! here as one space-separated string, program name first. Panic-free.
//!
//! A command line that cannot be read is an error, never an empty one: a firmware that ran
//! with none of the options it was given would look like a successful run of other options.

/// Why the command line could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CmdlineError {
    /// The host refused the call: QEMU does so only when the command line (program name,
    /// arguments, separating spaces and the final NUL) is longer than the buffer.
    TooLong {
        /// The buffer's size, bytes.
        buffer: usize,
    },
    /// Not UTF-8.
    NotUtf8,
}

impl defmt::Format for CmdlineError {
    fn format(&self, f: defmt::Formatter) {
        match self {
            CmdlineError::TooLong { buffer } => defmt::write!(
                f,
                "the command line is longer than the firmware's {=usize}-byte buffer (program name, arguments and spaces)",
                buffer
            ),
            CmdlineError::NotUtf8 => defmt::write!(f, "the command line is not UTF-8"),
        }
    }
}

/// Reads the command line into `buf`.
pub fn cmdline(buf: &mut [u8]) -> Result<&str, CmdlineError> {
    let buffer = buf.len();
    let len = crate::semihost::get_cmdline(buf).ok_or(CmdlineError::TooLong { buffer })?;
    let line = buf.get(..len).ok_or(CmdlineError::TooLong { buffer })?;
    core::str::from_utf8(line).map_err(|_| CmdlineError::NotUtf8)
}

/// The arguments after the program name, split on spaces.
pub fn args(buf: &mut [u8]) -> Result<impl Iterator<Item = &str>, CmdlineError> {
    Ok(cmdline(buf)?.split(' ').filter(|a| !a.is_empty()).skip(1))
}
