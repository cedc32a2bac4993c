//! The caller tree, walked from 1-byte caller links.
//!
//! Each control block stores only its `callerSequence`. The seed's `callerStack`, its depth
//! and its blocking part (`callerStackBlocking`) are derived by walking the links, at most
//! [`MAX_DEPTH`] steps: 1 byte per sequence instead of a copied stack, and the walks happen
//! only on starts, stops and inspection, never in the tick's hot path.

use crate::control_block::Link;
use crate::sequencer::Inner;
use crate::{SeqId, MAX_DEPTH};

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
    /// The innermost callers of `id` that it blocks: those in its own lane
    /// (`callerStackBlocking` is that many of the stack's innermost entries), innermost
    /// first. One block lookup per caller (the tick walks this in its wake-ups).
    pub(crate) fn blocking_callers(&self, id: SeqId) -> Blocking<'_, C, N, T, W> {
        let (up, lane) = self
            .fast(id)
            .map_or((Link::NONE, crate::control_block::NO_LANE), |b| {
                (b.caller, b.lane)
            });
        Blocking {
            inner: self,
            up,
            lane,
            left: MAX_DEPTH as u8,
        }
    }

    /// One step of [`Sequencer::cut_and_depth`](crate::Sequencer): the caller of `at`, or
    /// `None` at the top of the stack; a link of `at` to `id` (its old run) is cut instead.
    pub(crate) fn cut_step(&mut self, id: SeqId, at: SeqId) -> Option<SeqId> {
        let b = self.block_mut(at).ok()?;
        let up = b.caller.get()?;
        if up == id {
            b.caller = crate::control_block::Link::NONE;
            return None;
        }
        Some(up)
    }
}

/// The iterator of [`Inner::blocking_callers`].
pub(crate) struct Blocking<'a, C, const N: usize, const T: usize, const W: usize> {
    inner: &'a Inner<C, N, T, W>,
    /// The next caller.
    up: Link,
    /// The lane of the sequence the walk started from.
    lane: u8,
    /// Callers still allowed (the stack holds at most `MAX_DEPTH`).
    left: u8,
}

impl<C, const N: usize, const T: usize, const W: usize> Iterator for Blocking<'_, C, N, T, W> {
    type Item = SeqId;

    fn next(&mut self) -> Option<SeqId> {
        let c = self.up.get()?;
        self.left = self.left.checked_sub(1)?;
        self.up = Link::NONE;
        let b = self.inner.fast(c)?;
        if b.lane != self.lane {
            return None;
        }
        self.up = b.caller;
        Some(c)
    }
}
