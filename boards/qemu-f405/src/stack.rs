//! Stack depth, measured by painting: how many bytes of the one Cortex-M main stack a
//! firmware, or one call, really used.
//!
//! [`paint_unused`] fills the stack region below the stack pointer (down to `_stack_end`,
//! the start of RAM under flip-link) with [`PAINT`]. Every push scrubs the paint off, and
//! nothing paints it back, so the lowest word that no longer holds it marks the deepest the
//! stack has been since ([`peak`]). [`deepest`] paints around one call and reads how deep
//! that call went.
//!
//! A firmware paints at the top of `init`, not from reset (cortex-m-rt's `paint-stack`):
//! that would lengthen every firmware's boot, and the timing of the safety firmware's
//! preemption test moved with it.
//!
//! RTIC runs every task and interrupt handler on this one stack, so the firmware's peak is
//! the deepest nesting that happened: `idle`, a lane preempted by the tick, the tick
//! preempted by the safety task. It is what the firmware's RAM must leave free for the
//! stack, for the run that was measured.

use core::hint::black_box;
use core::ptr::{addr_of, read_volatile};

/// The word the stack is painted with (the one cortex-m-rt's `paint-stack` uses).
pub const PAINT: u32 = 0xCCCC_CCCC;

extern "C" {
    /// The stack's top (its first push goes just below).
    static _stack_start: u32;
    /// The stack's lowest address: a push below it faults (flip-link).
    static _stack_end: u32;
}

fn top() -> usize {
    addr_of!(_stack_start) as usize
}

fn bottom() -> usize {
    addr_of!(_stack_end) as usize
}

/// The lowest address below `limit` that no longer holds the paint, or `limit` if all of
/// `bottom()..limit` still does.
fn lowest_scrubbed(limit: usize) -> usize {
    let mut at = bottom();
    while at < limit {
        // SAFETY: `at` is a word-aligned address inside the stack region, which is RAM;
        // a volatile read of it has no effect on the program.
        if unsafe { read_volatile(at as *const u32) } != PAINT {
            return at;
        }
        at += 4;
    }
    limit
}

/// Paints the unused part of the stack, with interrupts masked; [`peak`] then reads how
/// deep the stack goes from here on. Call it first thing in `init`.
pub fn paint_unused() {
    critical_section::with(|_| paint_free());
}

/// Bytes of stack the firmware has used, at the deepest point since [`paint_unused`].
pub fn peak() -> usize {
    top() - lowest_scrubbed(top())
}

/// The size of the stack region (what flip-link left below the statics).
pub fn size() -> usize {
    top() - bottom()
}

/// Paints the stack from its bottom up to the stack pointer. In assembly, so the stack
/// pointer is read where the loop runs: a Rust function may push its frame after reading
/// it, and the paint would then overwrite that frame.
#[inline(always)]
fn paint_free() {
    // SAFETY: the loop writes whole words from the stack's bottom (word-aligned) up to the
    // stack pointer, which is memory no frame holds; the caller masks interrupts, so no
    // frame is pushed there meanwhile. It touches no other memory and the stack pointer
    // not at all.
    unsafe {
        core::arch::asm!(
            "mov {limit}, sp",
            "2:",
            "cmp {at}, {limit}",
            "bhs 3f",
            "str {paint}, [{at}], #4",
            "b 2b",
            "3:",
            at = inout(reg) bottom() => _,
            limit = out(reg) _,
            paint = in(reg) PAINT,
            options(nostack),
        );
    }
}

/// Runs `f` with interrupts masked and returns the bytes of stack it used. `f` is a `dyn`
/// call made opaque to the optimiser, so its frame cannot be folded into the measuring
/// frame above the mark: the figure is `f`'s frames and the few bytes of that call.
#[inline(never)]
pub fn deepest(f: &mut dyn FnMut()) -> usize {
    critical_section::with(|_| {
        let f = black_box(f);
        paint_free();
        let from = cortex_m::register::msp::read() as usize;
        f();
        from - lowest_scrubbed(from)
    })
}
