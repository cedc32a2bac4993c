//! The few semihosting calls the board needs, panic-free (ARM semihosting, `BKPT 0xAB` on
//! M-profile; QEMU implements them with `-semihosting-config enable=on`).

/// `SYS_OPEN`
const SYS_OPEN: usize = 0x01;
/// `SYS_WRITE`
const SYS_WRITE: usize = 0x05;
/// `SYS_GET_CMDLINE`
const SYS_GET_CMDLINE: usize = 0x15;
/// `SYS_EXIT`
const SYS_EXIT: usize = 0x18;
/// `SYS_EXIT_EXTENDED`
const SYS_EXIT_EXTENDED: usize = 0x20;
/// `ADP_Stopped_ApplicationExit`
const ADP_STOPPED_APPLICATION_EXIT: usize = 0x2_0026;
/// `ADP_Stopped_RunTimeErrorUnknown`
const ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN: usize = 0x2_0023;

/// One semihosting call: operation in r0, parameter (usually a block address) in r1.
///
/// # Safety
/// `param` must be what operation `op` expects; memory it points to may be read or written
/// by the host as the operation specifies.
#[inline(always)]
unsafe fn call(op: usize, param: usize) -> isize {
    let ret: isize;
    // SAFETY: the caller guarantees `param` matches `op`.
    unsafe {
        core::arch::asm!(
            "bkpt #0xab",
            inout("r0") op => ret,
            in("r1") param,
            options(nostack, preserves_flags),
        );
    }
    ret
}

/// Opens the host console for writing (`":tt"`, mode "w"); `None` if refused.
pub fn open_stdout() -> Option<usize> {
    static TT: [u8; 4] = *b":tt\0";
    // Block: path, mode (4 = "w"), path length without the NUL.
    let block: [usize; 3] = [TT.as_ptr() as usize, 4, 3];
    // SAFETY: valid SYS_OPEN block; the host only reads it.
    let h = unsafe { call(SYS_OPEN, block.as_ptr() as usize) };
    usize::try_from(h).ok()
}

/// Writes `buf` to `handle`; returns the number of bytes NOT written (0 = all written).
pub fn write(handle: usize, buf: &[u8]) -> usize {
    let block: [usize; 3] = [handle, buf.as_ptr() as usize, buf.len()];
    // SAFETY: valid SYS_WRITE block; the host only reads it and `buf`.
    let r = unsafe { call(SYS_WRITE, block.as_ptr() as usize) };
    usize::try_from(r).unwrap_or(buf.len())
}

/// Reads the command line into `buf`; returns its length, `None` on failure.
pub fn get_cmdline(buf: &mut [u8]) -> Option<usize> {
    // Block: buffer, size (updated to the length of the command line on return).
    let mut block: [usize; 2] = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: valid SYS_GET_CMDLINE block; the host writes at most `buf.len()` bytes into
    // `buf` and the length into `block[1]`.
    let r = unsafe { call(SYS_GET_CMDLINE, block.as_mut_ptr() as usize) };
    // Keep the compiler from assuming `block` is unchanged (the host wrote it).
    let len = unsafe { core::ptr::read_volatile(&block[1]) };
    (r == 0 && len <= buf.len()).then_some(len)
}

/// Ends the emulation with `code` as QEMU's exit status (`SYS_EXIT_EXTENDED`; if the host
/// does not support it, `SYS_EXIT` with success / failure only).
pub fn exit(code: i32) -> ! {
    let block: [usize; 2] = [ADP_STOPPED_APPLICATION_EXIT, code as usize];
    // SAFETY: valid SYS_EXIT_EXTENDED block.
    unsafe { call(SYS_EXIT_EXTENDED, block.as_ptr() as usize) };
    let reason = if code == 0 {
        ADP_STOPPED_APPLICATION_EXIT
    } else {
        ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN
    };
    // SAFETY: on 32-bit ARM, SYS_EXIT takes the reason code itself in r1.
    unsafe { call(SYS_EXIT, reason) };
    // Not under a semihosting host: stop here.
    loop {
        cortex_m::asm::bkpt();
    }
}
