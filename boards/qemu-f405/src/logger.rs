//! `defmt` global logger over semihosting (QEMU writes the frames to its stdout; the host
//! decodes them with `tools/qemu-run`).
//!
//! Why not `defmt-semihosting`: it `panic!`s when the logger is re-entered, so every
//! firmware that logs keeps a panic path and the no-panic proof (feature `no-panic`) could
//! never link. This logger has no panic path: a re-entrant frame (only possible from a
//! fault handler interrupting a frame) is dropped.
//!
//! No byte is lost silently: `SYS_WRITE` returns the number of bytes the host did NOT
//! write; the logger writes the remainder again until all of it is taken. QEMU writes to
//! its stdout with a blocking `write(2)` and reports an error as "nothing written", so a
//! remainder only comes from a host error: a pipe whose reader has gone (`EPIPE`), a
//! non-blocking stdout that is full (`EAGAIN`), an interrupted write (`EINTR`). After
//! [`MAX_TRIES`] attempts in a row without progress the logger gives up on the frame and
//! counts its bytes in [`lost_bytes`]; later frames get one attempt each until one goes
//! through. [`crate::exit::exit`] turns a successful exit into
//! [`ExitCode::LogLost`](crate::exit::ExitCode::LogLost) (104) when any byte was lost, so
//! a host that checks the exit code notices.
//!
//! Frames are encoded (rzCOBS) into a RAM buffer and handed to the host with one
//! semihosting `SYS_WRITE` per frame (or per [`BUF_LEN`] bytes), which keeps the number of
//! (host-expensive) semihosting traps low. The whole frame runs in a critical section, as
//! `defmt` requires of a global logger; its length is bounded by the frame size.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use crate::semihost;

/// Bytes buffered before a semihosting write.
pub const BUF_LEN: usize = 256;

/// Semihosting writes in a row that take nothing before a frame is given up: about 0.1 s
/// of QEMU's CPU time (a refused write costs it about 1 µs), time for a descheduled reader
/// of a non-blocking stdout to catch up, yet short enough that a host which refuses for
/// good ends the run well within a time limit even on a starved CPU (a tenfold bound took
/// over 60 s of wall time under load); no virtual time passes meanwhile.
pub const MAX_TRIES: u32 = 100_000;

/// Bytes the host did not take (frames given up, see the module docs).
static LOST_BYTES: AtomicU32 = AtomicU32::new(0);

/// How many log bytes the host refused so far (0: every frame reached it whole).
pub fn lost_bytes() -> u32 {
    LOST_BYTES.load(Ordering::Relaxed)
}

struct State {
    restore: critical_section::RestoreState,
    encoder: defmt::Encoder,
    sink: Sink,
}

/// Frame buffer and the semihosting console handle (opened on first use).
struct Sink {
    out: Option<usize>,
    buf: [u8; BUF_LEN],
    len: usize,
    /// The last write was given up: one attempt per write until one goes through.
    refused: bool,
}

struct Cell(UnsafeCell<State>);
// SAFETY: only touched between `acquire` and `release`, i.e. inside a critical section,
// by the (single) owner recorded in `DEPTH`.
unsafe impl Sync for Cell {}

static STATE: Cell = Cell(UnsafeCell::new(State {
    restore: critical_section::RestoreState::invalid(),
    encoder: defmt::Encoder::new(),
    sink: Sink {
        out: None,
        buf: [0; BUF_LEN],
        len: 0,
        refused: false,
    },
}));

/// 0 = free, 1 = a frame is being written, 2 = a nested frame is being dropped.
static DEPTH: AtomicU8 = AtomicU8::new(0);

impl Sink {
    fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.len >= BUF_LEN {
                self.flush();
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
    }

    fn flush(&mut self) {
        let len = self.len.min(BUF_LEN);
        self.len = 0;
        if self.out.is_none() {
            self.out = semihost::open_stdout();
        }
        let Some(mut rest) = self.buf.get(..len) else {
            return;
        };
        let Some(out) = self.out else {
            return count_lost(rest.len());
        };
        let max_tries = if self.refused { 1 } else { MAX_TRIES };
        let mut tries = 0;
        while !rest.is_empty() {
            let not_written = semihost::write(out, rest);
            let written = rest.len().saturating_sub(not_written);
            if written == 0 {
                tries += 1;
                if tries >= max_tries {
                    self.refused = true;
                    return count_lost(rest.len());
                }
            } else {
                tries = 0;
            }
            rest = rest.get(written..).unwrap_or_default();
        }
        self.refused = false;
    }
}

fn count_lost(bytes: usize) {
    let bytes = u32::try_from(bytes).unwrap_or(u32::MAX);
    // Saturating: a wrapped count could read 0 ("nothing lost").
    let _ = LOST_BYTES.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
        Some(n.saturating_add(bytes))
    });
}

#[defmt::global_logger]
struct Logger;

unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: paired with `critical_section::release` in `release`.
        let restore = unsafe { critical_section::acquire() };
        if DEPTH.load(Ordering::Relaxed) != 0 {
            // Re-entered (a fault handler logging in the middle of a frame): drop this frame.
            DEPTH.store(2, Ordering::Relaxed);
            // SAFETY: the outer critical section is still held; releasing the inner one
            // restores "interrupts masked", the state it found.
            unsafe { critical_section::release(restore) };
            return;
        }
        DEPTH.store(1, Ordering::Relaxed);
        // SAFETY: exclusive: inside the critical section and DEPTH was 0.
        let State {
            restore: r,
            encoder,
            sink,
        } = unsafe { &mut *STATE.0.get() };
        *r = restore;
        encoder.start_frame(|b| sink.push(b));
    }

    unsafe fn flush() {}

    unsafe fn release() {
        if DEPTH.load(Ordering::Relaxed) != 1 {
            // End of a dropped nested frame; the outer frame continues (interrupts stay
            // masked) and its bytes are unaffected.
            DEPTH.store(1, Ordering::Relaxed);
            return;
        }
        // SAFETY: we own the logger (DEPTH == 1, critical section held).
        let State {
            restore,
            encoder,
            sink,
        } = unsafe { &mut *STATE.0.get() };
        encoder.end_frame(|b| sink.push(b));
        sink.flush();
        let restore = *restore;
        DEPTH.store(0, Ordering::Relaxed);
        // SAFETY: paired with the `acquire` of this frame.
        unsafe { critical_section::release(restore) };
    }

    unsafe fn write(bytes: &[u8]) {
        if DEPTH.load(Ordering::Relaxed) != 1 {
            return;
        }
        // SAFETY: we own the logger (DEPTH == 1, critical section held).
        let State { encoder, sink, .. } = unsafe { &mut *STATE.0.get() };
        encoder.write(bytes, |b| sink.push(b));
    }
}
