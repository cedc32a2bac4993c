//! The caller tree, walked from 1-byte caller links.
//!
//! Each control block stores only its `callerSequence`. The seed's `callerStack`, its depth
//! and its blocking part (`callerStackBlocking`) are derived by walking the links, at most
//! [`MAX_DEPTH`] steps: 1 byte per sequence instead of a copied stack, and the walks happen
//! only on starts, stops and inspection, never in the tick's hot path.

use crate::sequencer::Inner;
use crate::{SeqId, MAX_DEPTH};

/// A caller stack, outermost caller first.
pub(crate) type Stack = heapless::Vec<SeqId, MAX_DEPTH>;

impl<C, const N: usize, const T: usize, const W: usize> Inner<C, N, T, W> {
    /// `callerSequence` of `id`.
    pub(crate) fn caller_of(&self, id: SeqId) -> Option<SeqId> {
        self.block(id).ok().and_then(|b| b.caller.get())
    }

    /// The callers of `id`, innermost first.
    pub(crate) fn ancestors(&self, id: SeqId) -> impl Iterator<Item = SeqId> + '_ {
        core::iter::successors(self.caller_of(id), |&c| self.caller_of(c)).take(MAX_DEPTH)
    }

    /// Number of callers of `id` (0 for a main sequence).
    pub(crate) fn depth(&self, id: SeqId) -> u8 {
        // At most MAX_DEPTH (8) callers: the count fits.
        u8::try_from(self.ancestors(id).count()).unwrap_or(u8::MAX)
    }

    /// True when `ancestor` is in the caller stack of `id`.
    pub(crate) fn descends_from(&self, id: SeqId, ancestor: SeqId) -> bool {
        self.ancestors(id).any(|c| c == ancestor)
    }

    /// `callerStack` of `id`, outermost first.
    pub(crate) fn caller_stack(&self, id: SeqId) -> Stack {
        let mut stack = Stack::new();
        for c in self.ancestors(id) {
            // `ancestors` yields at most MAX_DEPTH ids: every push fits. (`collect` would
            // bring heapless's overflow panic.)
            let _ = stack.push(c);
        }
        stack.reverse();
        stack
    }

    /// The innermost callers of `id` that it blocks: those in its own lane
    /// (`callerStackBlocking` is that many of the stack's innermost entries).
    pub(crate) fn blocking_callers(&self, id: SeqId) -> impl Iterator<Item = SeqId> + '_ {
        let lane = self
            .block(id)
            .map_or(crate::control_block::NO_LANE, |b| b.lane);
        self.ancestors(id)
            .take_while(move |&c| self.block(c).is_ok_and(|b| b.lane == lane))
    }

    /// Before `id` is started by `caller`: if `id` is itself a (finished) caller of
    /// `caller`, the link to its old run is cut, so the links never form a cycle.
    pub(crate) fn cut_old_links_to(&mut self, id: SeqId, caller: SeqId) {
        let mut at = caller;
        for _ in 0..MAX_DEPTH {
            let Ok(b) = self.block_mut(at) else { return };
            match b.caller.get() {
                Some(c) if c == id => {
                    b.caller = crate::control_block::Link::NONE;
                    return;
                }
                Some(c) => at = c,
                None => return,
            }
        }
    }
}
