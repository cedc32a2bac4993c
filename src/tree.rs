//! The caller tree, walked from 1-byte caller links.
//!
//! Each control block stores only its `callerSequence`. The seed's `callerStack`, its depth
//! and its blocking part (`callerStackBlocking`) are derived by walking the links, at most
//! [`MAX_DEPTH`] steps: 1 byte per sequence instead of a copied stack, and the walks happen
//! only on starts, stops and inspection, never in the tick's hot path.

use crate::control_block::Link;
use crate::sequencer::Inner;
use crate::{SeqId, MAX_DEPTH};

/// The callers of `id` in a copy of the caller links (`links[i]`: the caller of sequence
/// `i`), innermost first, at most [`MAX_DEPTH`].
pub(crate) fn ancestors(links: &[Link], id: SeqId) -> impl Iterator<Item = SeqId> + '_ {
    let up = move |x: SeqId| links.get(x.index()).and_then(|l| l.get());
    core::iter::successors(up(id), move |&c| up(c)).take(MAX_DEPTH)
}

/// Number of callers of `id` (0 for a main sequence) in a copy of the caller links.
pub(crate) fn depth(links: &[Link], id: SeqId) -> u8 {
    // At most MAX_DEPTH (8) callers: the count fits.
    u8::try_from(ancestors(links, id).count()).unwrap_or(u8::MAX)
}

/// True when `ancestor` is in the caller stack of `id`, in a copy of the caller links.
pub(crate) fn descends_from(links: &[Link], id: SeqId, ancestor: SeqId) -> bool {
    ancestors(links, id).any(|c| c == ancestor)
}

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
    /// The innermost callers of `id` that it blocks: those in its own lane
    /// (`callerStackBlocking` is that many of the stack's innermost entries), innermost
    /// first. One block lookup per caller (the tick walks this in its wake-ups).
    pub(crate) fn blocking_callers(&self, id: SeqId) -> Blocking<'_, C, N, T, W> {
        let (up, lane) = self
            .block(id)
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
        let b = self.inner.block(c).ok()?;
        if b.lane != self.lane {
            return None;
        }
        self.up = b.caller;
        Some(c)
    }
}
