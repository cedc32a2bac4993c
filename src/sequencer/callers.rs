//! The caller tree, walked from the caller links (`Link`: an optional id).
//!
//! Each control block stores only its `callerSequence`. The seed's `callerStack`, its depth
//! and its blocking part (`callerStackBlocking`: the callers in the same lane) are derived
//! by walking the links, at most [`MAX_DEPTH`] steps, one section per step with the
//! portable lock. The walks happen on starts, joins, stops and inspection; in the tick
//! only while something is held; and at a lane's await points and ends only while some
//! exception is handled (`clearance_in_lane`, `end_run`).

use crate::model::id::Link;
use crate::model::set::SeqSet;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::flag;
use crate::sequencer::sections::Sections;
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::{RunningState, SeqId, MAX_DEPTH};

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// One step of [`cut_and_depth`]: the caller of `at`, or `None` at the top of the
    /// stack; a link of `at` to `id` (its old run) is cut instead.
    fn cut_step(&mut self, id: SeqId, at: SeqId) -> Option<SeqId> {
        let b = self.block_mut(at)?;
        let up = b.caller.get()?;
        if up == id {
            b.caller = Link::NONE;
            self.sets.remove(Set::Called, at);
            return None;
        }
        Some(up)
    }

    /// Whether a resume leaves `id` paused: something else holds it. A `PauseOwner`
    /// monitor of its own holds, a pause request paused it, or the caller it blocks (in
    /// its lane) is paused; a resume of that caller (outermost first) resumes it later.
    pub(crate) fn stays_paused(&self, id: SeqId) -> bool {
        let Some(b) = self.block(id) else {
            return false;
        };
        let caller_paused = b
            .caller
            .get()
            .and_then(|c| self.block(c))
            .is_some_and(|c| c.lane == b.lane && c.state == RunningState::Paused);
        b.monitor_holds > 0 || b.has(flag::PAUSED_BY_REQUEST) || caller_paused
    }

    /// One step of [`join_would_deadlock`]: the caller that `at` (in `lane`) holds up:
    /// its caller in `lane` (which it blocks), or, when `at` is an exception sequence
    /// whose end is not reported yet, its owner (held until then).
    fn caller_held_up(&self, at: SeqId, lane: u8) -> Option<CallerHeldUp> {
        let b = self.block(at)?;
        let c = b.caller.get()?;
        let up = self.lane_slot(c);
        let exception = b.has(flag::HANDLES_EXCEPTION);
        (up == lane || exception).then_some(CallerHeldUp {
            id: c,
            lane: up,
            owner: exception,
        })
    }

    /// The caller of `at` in `at`'s lane (which `at` blocks), and whether it handles an
    /// exception; `None` at the top of the lane.
    fn caller_in_lane(&self, at: SeqId) -> Option<(SeqId, bool)> {
        let b = self.block(at)?;
        let c = b.caller.get()?;
        (self.lane_slot(c) == b.lane).then(|| (c, self.sets.has(Set::Excepting, c)))
    }

    /// The caller that a run under way `at` blocks, if `at` runs in `lane`.
    fn blocking_caller_in(&self, at: SeqId, lane: u8) -> Option<SeqId> {
        let b = self.block(at)?;
        let c = b.caller.get()?;
        (b.lane == lane && self.lane_slot(c) == lane && RunningStates::LIVE.has(b.state))
            .then_some(c)
    }

    /// One step of the held check of a due wake-up ([`held`]): whether `at` holds its
    /// callees (not running, or handling an exception), else its caller in `lane` to check
    /// next, if any. A run the tick is to abort (its abort requested, an abort-all
    /// waiting) holds too, but is not checked here: it is never let go, so its due poll
    /// needs no skipping, and its wake-up finds it holding.
    pub(crate) fn held_step(&self, at: SeqId, lane: u8) -> HeldStep {
        let Some(b) = self.block(at) else {
            return HeldStep::Holds;
        };
        if b.state != RunningState::Running || self.sets.has(Set::Excepting, at) {
            return HeldStep::Holds;
        }
        match b.caller.get() {
            Some(c) if self.lane_slot(c) == lane => HeldStep::Up(c),
            _ => HeldStep::Top,
        }
    }
}

/// A caller that a sequence holds up ([`State::caller_held_up`]).
struct CallerHeldUp {
    id: SeqId,
    /// The lane it runs in.
    lane: u8,
    /// It is the owner whose exception the sequence handles: its blocking children are
    /// held with it ([`held_below`]).
    owner: bool,
}

/// Before `id` is started by `caller`: walks `caller`'s caller links, one step per link,
/// and returns its depth (its number of callers, at most `MAX_DEPTH`). If `id` is itself a
/// (finished) caller of `caller`, the link to its old run is cut there, so the links never
/// form a cycle.
pub(crate) fn cut_and_depth<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    caller: SeqId,
) -> u8 {
    let mut at = caller;
    let mut depth: u8 = 0;
    for _ in 0..MAX_DEPTH {
        match s.section(|s| s.cut_step(id, at)) {
            Some(up) => {
                at = up;
                depth = depth.saturating_add(1);
            }
            None => break,
        }
    }
    depth
}

/// Whether `joiner` waiting for `target` could never return: `target` waits, directly or
/// not, for `joiner`. Found outward from `joiner`: the callers it holds up (its callers
/// in its own lane, which it blocks, and, for an exception sequence, its owner and the
/// owner's blocking children, held until its end), the sequences waiting in a join for one
/// of those, and so on. A cycle of joins (A joins B while B joins A, or through a blocking
/// child) is one of them.
pub(crate) fn join_would_deadlock<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    joiner: SeqId,
    target: SeqId,
) -> bool {
    let mut waiting = SeqSet::<B>::EMPTY;
    let mut round = SeqSet::<B>::EMPTY.with(joiner);
    // Each round visits at least one sequence no round visited before.
    for _ in 0..=N {
        let mut next = SeqSet::EMPTY;
        for from in round {
            if holds_up(s, from, target, &mut waiting, &mut next) {
                return true;
            }
        }
        round = next.minus(&waiting);
        if round.is_empty() {
            return false;
        }
    }
    false
}

/// One step of [`join_would_deadlock`]: walks up the callers `from` holds up, marking
/// each `waiting` and collecting in `next` the sequences waiting in a join for one of
/// them, and the blocking children of an owner held for an exception of one of them.
/// True when it meets `target`.
fn holds_up<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    from: SeqId,
    target: SeqId,
    waiting: &mut SeqSet<B>,
    next: &mut SeqSet<B>,
) -> bool {
    let mut lane = s.section(|s| s.lane_slot(from));
    let mut at = from;
    for _ in 0..=MAX_DEPTH {
        if at == target {
            return true;
        }
        if waiting.has(at) {
            return false;
        }
        waiting.insert(at);
        *next = next.union(&s.section(|s| s.joiners_of(at)));
        let Some(up) = s.section(|s| s.caller_held_up(at, lane)) else {
            return false;
        };
        if up.owner {
            *next = next.union(&held_below(s, up.id, up.lane));
        }
        (at, lane) = (up.id, up.lane);
    }
    false
}

/// The runs under way that the exception of `owner` (in `lane`) holds with it: its
/// blocking children in its lane, and theirs. Each is walked up its callers in the lane,
/// one section per step, until it meets `owner` or the top of the lane.
fn held_below<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    owner: SeqId,
    lane: u8,
) -> SeqSet<B> {
    let mut below = SeqSet::EMPTY;
    for id in s.section(|s| s.sets.members(Set::Called)) {
        if blocks_in_lane(s, id, owner, lane) {
            below.insert(id);
        }
    }
    below
}

/// Whether the run under way of `id` blocks `owner`, directly or through the callers it
/// blocks, all in `lane`: `id` is one of `owner`'s blocking children or theirs. Walked up
/// from `id`, one section per step.
pub(crate) fn blocks_in_lane<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    owner: SeqId,
    lane: u8,
) -> bool {
    finds_above(s, id, |s, at| {
        s.blocking_caller_in(at, lane).map(|up| (up, up == owner))
    })
}

/// Walks up the callers from `id`, one section per step, at most [`MAX_DEPTH`] steps:
/// `step` gives the next caller and whether it is what the walk looks for (`None`: the
/// top, nothing found).
fn finds_above<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    step: impl Fn(&State<C, N, T, W, B>, SeqId) -> Option<(SeqId, bool)>,
) -> bool {
    let mut at = id;
    for _ in 0..MAX_DEPTH {
        match s.section(|s| step(s, at)) {
            Some((_, true)) => return true,
            Some((up, false)) => at = up,
            None => return false,
        }
    }
    false
}

/// Whether a caller that `id` blocks (in its lane, at most [`MAX_DEPTH`] up) handles an
/// exception, so `id` is held with it: the hold is the owner's and that of its blocking
/// children (semantics item 3). Only the owner is marked, and its children are held by not
/// being polled, except in the poll in which the tick (which preempts the lanes) marked
/// the exception: that poll runs on to the children's await points, which must hold. A
/// walk up the callers, one section per step.
pub(crate) fn caller_handles_exception<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
) -> bool {
    finds_above(s, id, |s, at| s.caller_in_lane(at))
}

/// What one step of a held check finds ([`State::held_step`]).
pub(crate) enum HeldStep {
    /// The sequence holds its callees: not running, or handling an exception.
    Holds,
    /// It goes on; its caller in the lane is checked next.
    Up(SeqId),
    /// It goes on, and has no caller in the lane: nothing above holds it.
    Top,
}

/// Whether sequence `id` is held, or frozen by a caller it blocks (paused, or holding for
/// an exception): it is woken when it may go on. `step` is one step up its blocking
/// callers ([`State::held_step`]).
pub(crate) fn held(id: SeqId, mut step: impl FnMut(SeqId) -> HeldStep) -> bool {
    let mut at = id;
    // The sequence and at most `MAX_DEPTH` callers.
    for _ in 0..=MAX_DEPTH {
        match step(at) {
            HeldStep::Holds => return true,
            HeldStep::Up(c) => at = c,
            HeldStep::Top => return false,
        }
    }
    false
}
