//! `defmt` global logger over semihosting (QEMU writes the frames to its stdout; the host
//! decodes them with `tools/qemu-run`).
//!
//! Why not `defmt-semihosting`: it `panic!`s when the logger is re-entered, so every
//! firmware that logs keeps a panic path and the no-panic proof (feature `no-panic`) could
//! never link. This logger has no panic path: a re-entrant frame (only possible from a
//! fault handler interrupting a frame) is dropped, and write errors are ignored.
//!
//! Frames are encoded (rzCOBS) into a RAM buffer and handed to the host with one
//! semihosting `SYS_WRITE` per frame (or per [`BUF_LEN`] bytes), which keeps the number of
//! (host-expensive) semihosting traps low. The whole frame runs in a critical section, as
//! `defmt` requires of a global logger; its length is bounded by the frame size.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU8, Ordering};

use crate::semihost;

/// Bytes buffered before a semihosting write.
pub const BUF_LEN: usize = 256;

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
        let (Some(out), Some(bytes)) = (self.out, self.buf.get(..len)) else {
            return;
        };
        // A short write is not retried: the host console does not do partial writes.
        let _not_written = semihost::write(out, bytes);
    }
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
