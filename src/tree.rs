//! The caller tree, walked from 1-byte caller links.
//!
//! Each control block stores only its `callerSequence`. The seed's `callerStack`, its depth
//! and its blocking part (`callerStackBlocking`) are derived by walking the links, at most
//! [`MAX_DEPTH`] steps: 1 byte per sequence instead of a copied stack, and the walks happen
//! only on starts, stops and inspection, never in the tick's hot path.

use crate::sequencer::Inner;
use crate::SeqId;
#[cfg(doc)]
use crate::MAX_DEPTH;

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
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
