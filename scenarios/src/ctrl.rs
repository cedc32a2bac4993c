//! The scenarios' control system: atomic flags and a digest of what the actions did.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use rtseq::{Condition, Cx, Done, Failure, Instant, RunningState};

/// Number of flags of [`Ctrl`].
pub const FLAGS: usize = 16;

/// The control system of every scenario: flags set by the script and read by conditions,
/// plus counters and a digest of every action line and every outcome a caller got back.
///
/// `Sync` and `const`-constructible, so a firmware keeps it in a `static`.
pub struct Ctrl {
    flags: [AtomicBool; FLAGS],
    lines: AtomicU32,
    dead_lines: AtomicU32,
    returns: AtomicU32,
    digest: AtomicU32,
}

/// What the actions of a run did, comparable between host and target.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Summary {
    /// Action lines executed.
    pub lines: u32,
    /// Action lines executed while their sequence was not `Running` or was held by an
    /// exception (must be 0: sticky abort, holds).
    pub dead_lines: u32,
    /// Outcomes returned to callers (blocking runs, steps, starts, joins).
    pub returns: u32,
    /// FNV-1a digest of every line `(ms, seq, line)` and every return `(ms, seq, line,
    /// outcome)`, in order.
    pub digest: u32,
}

const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

impl Default for Ctrl {
    fn default() -> Self {
        Self::new()
    }
}

impl Ctrl {
    /// All flags false, nothing recorded.
    pub const fn new() -> Self {
        Ctrl {
            flags: [const { AtomicBool::new(false) }; FLAGS],
            lines: AtomicU32::new(0),
            dead_lines: AtomicU32::new(0),
            returns: AtomicU32::new(0),
            digest: AtomicU32::new(FNV_OFFSET),
        }
    }

    /// Flag `i` modulo [`FLAGS`] (a monitor condition: a mask and one load, like a
    /// firmware's read of a status bit).
    pub fn flag(&self, i: u8) -> bool {
        const { assert!(FLAGS.is_power_of_two()) };
        self.flags
            .get(usize::from(i) & (FLAGS - 1))
            .is_some_and(|f| f.load(Relaxed))
    }

    /// Sets flag `i` (ignored when out of range).
    pub fn set(&self, i: u8, v: bool) {
        if let Some(f) = self.flags.get(usize::from(i)) {
            f.store(v, Relaxed);
        }
    }

    /// What the actions did so far.
    pub fn summary(&self) -> Summary {
        Summary {
            lines: self.lines.load(Relaxed),
            dead_lines: self.dead_lines.load(Relaxed),
            returns: self.returns.load(Relaxed),
            digest: self.digest.load(Relaxed),
        }
    }

    fn mix(&self, words: &[u32]) {
        let mut d = self.digest.load(Relaxed);
        for w in words {
            for b in w.to_le_bytes() {
                d = (d ^ u32::from(b)).wrapping_mul(FNV_PRIME);
            }
        }
        self.digest.store(d, Relaxed);
    }

    /// Records one executed action line `line` of the sequence of `cx`.
    pub(crate) fn line(&self, cx: &Cx<'_, Ctrl>, line: u32) {
        let live = cx
            .sequence_by_id(cx.id())
            .is_some_and(|h| h.state() == RunningState::Running && !h.exception_is_active());
        self.lines.fetch_add(1, Relaxed);
        if !live {
            self.dead_lines.fetch_add(1, Relaxed);
        }
        self.mix(&[1, ms(cx.now()), id_word(cx), line]);
    }

    /// Records what a started child returned to the sequence of `cx` at line `line`.
    pub(crate) fn returned(&self, cx: &Cx<'_, Ctrl>, line: u32, r: Result<Done, Failure>) {
        self.returns.fetch_add(1, Relaxed);
        self.mix(&[2, ms(cx.now()), id_word(cx), line, crate::outcome_code(r)]);
    }
}

fn ms(t: Instant) -> u32 {
    u32::try_from(t.as_ticks() / 1_000).unwrap_or(u32::MAX)
}

fn id_word(cx: &Cx<'_, Ctrl>) -> u32 {
    u32::try_from(cx.id().index()).unwrap_or(u32::MAX)
}

/// A monitor condition: "flag `flag` is set".
#[derive(Clone, Copy, Debug, Default)]
pub struct FlagCond {
    /// The flag watched.
    pub flag: u8,
}

impl Condition<Ctrl> for FlagCond {
    fn validate(&mut self, control: &Ctrl, _now: Instant) -> bool {
        control.flag(self.flag)
    }
}
