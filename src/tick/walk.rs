//! The walk over a subtree that teardowns and pauses share: which sequences are a target
//! or below it, by depth, and how a pass over them ended.

use crate::lock::Lock;
use crate::model::id::Link;
use crate::model::set::SeqSet;
use crate::model::state::RunningStates;
use crate::sequencer::sections::{in_sections, Sections};
use crate::sequencer::sets::Set;
use crate::{SeqId, Sequencer, MAX_DEPTH};

/// The depths a sequence can have (0 to `MAX_DEPTH` callers).
const DEPTHS: usize = MAX_DEPTH + 1;

/// The sequences a pass moves, by depth (its number of callers: outermost first, ids
/// ascending in each row), and the deepest row that has one.
pub(super) struct Depths<const B: usize> {
    rows: [SeqSet<B>; DEPTHS],
    deepest: usize,
}

impl<const B: usize> Depths<B> {
    /// The sequences at depth `depth`.
    pub(super) fn at(&self, depth: usize) -> SeqSet<B> {
        self.rows.get(depth).copied().unwrap_or_default()
    }

    /// The deepest row that has a sequence (0 when none has).
    pub(super) fn deepest(&self) -> usize {
        self.deepest
    }
}

/// How a pass of a teardown or a pause ended.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Pass {
    /// Everything it placed moved, and nothing it should have placed began meanwhile.
    Done,
    /// A move lost a race to another transition, or a run began that the pass did not
    /// place: walk again.
    Again,
}

impl Pass {
    pub(super) fn of(done: bool) -> Pass {
        if done {
            Pass::Done
        } else {
            Pass::Again
        }
    }
}

/// Which sequences a walk places.
#[derive(Clone, Copy)]
pub(super) enum Scope {
    /// Every sequence whose run may be under way (an abort-all).
    Everything,
    /// A target and the sequences below it (a teardown).
    Subtree(SeqId),
    /// A target and the sequences below it that run in `lane`, the target's: its blocking
    /// children (a pause or resume).
    InLane { target: SeqId, lane: u8 },
}

impl Scope {
    /// The sequence the walk is over the subtree of (none: every sequence).
    fn target(self) -> Option<SeqId> {
        match self {
            Scope::Everything => None,
            Scope::Subtree(t) | Scope::InLane { target: t, .. } => Some(t),
        }
    }

    /// Whether a sequence that runs in `lane` may be placed.
    fn takes_lane(self, lane: u8) -> bool {
        match self {
            Scope::InLane { lane: l, .. } => l == lane,
            Scope::Everything | Scope::Subtree(_) => true,
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// The sequences in `scope` whose state is in `states` and that `keep` keeps (given the
    /// count of the run looked at), by depth.
    ///
    /// Only the sequences that can qualify are visited: below a target, the target and
    /// those with a caller link (`Called`; a sequence below another one has one); for
    /// every sequence, every one whose run may be under way (with several words `Live` as
    /// of the last fold and those `Changed` since, else every registered one). Each is
    /// placed by walking its caller links up (a non-blocking child may outlive its caller
    /// and still link to it): with a coarse lock in one section, else one short section
    /// per step. The tree may change meanwhile: each change made from the rows is
    /// re-checked where it is made, and a run begun meanwhile makes the walk pass again.
    pub(super) fn by_depth(
        &self,
        scope: Scope,
        states: RunningStates,
        keep: &mut dyn FnMut(SeqId, u16) -> bool,
    ) -> Depths<B> {
        let candidates = self.with(|s| match scope.target() {
            Some(t) => s.sets.members(Set::Called).with(t),
            None => s.maybe_under_way(),
        });
        let mut rows = [SeqSet::EMPTY; DEPTHS];
        let mut deepest = 0;
        for id in candidates {
            let found = in_sections!(self, |s| depth_below(s, id, scope, states));
            let Some((depth, runs)) = found else {
                continue;
            };
            if let (Some(row), true) = (rows.get_mut(depth), keep(id, runs)) {
                row.insert(id);
                deepest = deepest.max(depth);
            }
        }
        Depths { rows, deepest }
    }
}

/// Where [`Sequencer::by_depth`] places `id`: its depth (its number of callers, at most
/// `MAX_DEPTH`) when its state is in `states` and it is in `scope`, with the count of the
/// run looked at; else `None`.
fn depth_below<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    scope: Scope,
    states: RunningStates,
) -> Option<(usize, u16)> {
    let (mut up, runs) = s.section(|s| {
        let b = s.block(id)?;
        let ok = states.has(b.state) && scope.takes_lane(b.lane);
        ok.then_some((b.caller, b.runs))
    })?;
    let target = scope.target();
    let mut below = target.is_none_or(|t| t == id);
    let mut depth = 0;
    while let Some(at) = up.get() {
        if depth == MAX_DEPTH {
            break;
        }
        below |= target == Some(at);
        depth += 1;
        up = s.section(|s| s.block(at).map_or(Link::NONE, |b| b.caller));
    }
    below.then_some((depth, runs))
}
