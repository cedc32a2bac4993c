//! Monitor evaluation: the conditions of the monitors whose owner is due, in groups of up
//! to 32 that share one due test, their edges and triggers as word operations, and the
//! firings (the rare, out-of-line path).

use crate::lock::Lock;
use crate::model::set::{SetWord, Words};
use crate::monitor::{Group, OwnedMonitor};
use crate::tick::exception::Reaction;
use crate::tick::Polls;
use crate::{Behaviour, Cause, Instant, MonitorId, Monitors, Sequencer};

/// The conditions of those `members` (a group, bits as in [`Group`]) whose owner is due;
/// the others keep their `last` values. The monitors of fresh owners (all due) begin their
/// owner's run: their conditions are told ([`Condition::begin_run`]) and their edge
/// detection starts again from "false" (their bits of `last` are cleared). Returns the
/// values and the bits evaluated.
///
/// [`Condition::begin_run`]: crate::Condition::begin_run
#[inline(never)]
fn evaluate_due<C, K: crate::Condition<C>, const B: usize>(
    members: &mut [OwnedMonitor<'_, C, K>],
    last: &mut u32,
    polls: &Polls<B>,
    control: &C,
    now: Instant,
) -> (u32, u32) {
    let (due, fresh) = (polls.due(), polls.fresh());
    let mut values = 0u32;
    let mut evaluated = 0u32;
    let mut renewed = 0u32;
    let mut bit = 1u32 << (members.len().saturating_sub(1) & 31);
    for m in members.iter_mut() {
        if due.has(m.owner) {
            evaluated |= bit;
            if fresh.has(m.owner) {
                renewed |= bit;
                m.def.condition.begin_run();
            }
            if m.def.condition.validate(control, now) {
                values |= bit;
            }
        }
        bit >>= 1;
    }
    *last &= !renewed;
    (values | (*last & !evaluated), evaluated)
}

/// What the evaluation of one word's monitors found.
pub(super) struct Evaluation {
    /// A monitor fired.
    pub(super) fired: bool,
    /// A `PauseOwner` monitor's condition cleared: its owner is to be released.
    pub(super) releasing: bool,
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Evaluates the monitors of the due owners and raises the exceptions of those that
    /// fire. A `PauseOwner` monitor whose condition cleared is marked: the tick releases
    /// its owner once the monitors of every word are evaluated ([`release_pending`]).
    ///
    /// [`release_pending`]: Self::release_pending
    ///
    /// The hot loop, one group of up to 32 monitors at a time: when all their owners are
    /// due (the common case), their conditions are shifted into a bit set in one flat
    /// loop; edges and triggers are a few word operations per group.
    #[inline(always)]
    pub(super) fn evaluate_monitors<const M: usize, K: crate::Condition<C>>(
        &self,
        polls: &Polls<B>,
        monitors: &mut Monitors<'_, C, M, K>,
        control: &C,
        now: Instant,
    ) -> Evaluation {
        let mut fired = false;
        // A `PauseOwner` monitor's condition cleared: its release waits for the end of
        // the evaluation, so that another monitor of the same owner that holds from now
        // on (later in the table, or in a later word) keeps the owner paused rather than
        // paused again.
        let mut releasing = false;
        let due = polls.due();
        let w = due.index();
        // Due owners whose monitors keep their edge state: a group of only these, all in
        // this word, takes the flat loop.
        let steady = due.minus(polls.fresh());
        let this_word = Words::single(w);
        let entries = monitors.entries.as_mut_slice();
        let used = usize::from(monitors.groups.used);
        for g in monitors.groups.list.iter_mut().take(used) {
            // All its owners in this word (the common case), or some.
            let one_word = B == 1 || g.owner_words == this_word;
            if !one_word && !g.owner_words.meets(this_word) {
                continue;
            }
            // Exactly the owners in this word when they are all in it; else a superset,
            // and the per-monitor path tests each owner.
            let owners = SetWord::new(w, g.owner_bits);
            if !owners.meets(due) {
                continue;
            }
            let start = usize::from(g.start);
            let Some(members) = entries.get_mut(start..start + usize::from(g.len)) else {
                break;
            };
            // A monitor of a fresh owner starts its edge detection from "false", and one
            // of an owner in another word is not due here: the per-monitor path.
            let (values, evaluated) = if one_word && owners.within(steady) {
                let mut values = 0u32;
                for m in members.iter_mut() {
                    values = (values << 1) | u32::from(m.def.condition.validate(control, now));
                }
                (values, u32::MAX)
            } else {
                evaluate_due(members, &mut g.last, polls, control, now)
            };
            // The common case, nothing changed and no level monitor true, is one test.
            if (values ^ g.last) | (values & g.level) != 0 {
                let firing = g.firing(values) & evaluated;
                let before = g.last;
                g.last = values;
                if firing != 0 {
                    let outcome = self.fire_group(g, members, firing, control);
                    releasing |= outcome.releasing;
                    // A firing the owner could not take (it was handling another
                    // exception) is not used up: its edge is seen again at the next
                    // evaluation, so it fires once the owner can take it, if its
                    // condition still says so.
                    g.last = (values & !outcome.not_taken) | (before & outcome.not_taken);
                    fired = true;
                }
            }
        }
        Evaluation { fired, releasing }
    }

    /// Releases the owners of the `PauseOwner` monitors whose condition cleared in this
    /// tick's evaluation, in table order (out of the hot loop: only after such a monitor
    /// fired).
    #[inline(never)]
    pub(super) fn release_pending<K>(&self, entries: &mut [OwnedMonitor<'_, C, K>]) {
        for (i, m) in entries.iter_mut().enumerate() {
            if m.releasing {
                m.releasing = false;
                self.release(m.owner, Cause::Monitor(MonitorId::from_index(i)));
            }
        }
    }

    /// Monitors of `group` triggered (`firing`, bits as in [`Group`]; the group's `last`
    /// holds this evaluation's values): raise their exceptions in table order (out of the
    /// hot loop; it visits only the monitors that fired, not the whole group). A
    /// `PauseOwner` monitor whose condition cleared is marked `releasing` instead.
    #[inline(never)]
    fn fire_group<K>(
        &self,
        group: &Group,
        members: &mut [OwnedMonitor<'_, C, K>],
        firing: u32,
        control: &C,
    ) -> GroupFiring {
        let mut outcome = GroupFiring {
            releasing: false,
            not_taken: 0,
        };
        // Only the monitors that fired, highest bit first: the group's first monitor holds
        // its highest bit, so this is table order.
        let mut rest = firing;
        while rest != 0 {
            let position = 31 - rest.leading_zeros();
            let bit = 1u32 << position;
            rest &= !bit;
            let index = group.index_of(position);
            let Some(monitor) = members.get_mut(usize::from(index)) else {
                break;
            };
            let id = MonitorId(group.start.wrapping_add(index));
            let holds = group.last & bit != 0;
            match (monitor.def.behaviour, holds) {
                (Behaviour::PauseOwner, true) => self.hold_owner(monitor, id),
                (Behaviour::PauseOwner, false) => {
                    monitor.releasing = true;
                    outcome.releasing = true;
                }
                _ => {
                    if !self.fire(monitor, id, control) {
                        outcome.not_taken |= bit;
                    }
                }
            }
        }
        outcome
    }

    /// A `PauseOwner` monitor's condition now holds: hold its owner (its release, once the
    /// condition clears, is made by `release_pending`).
    fn hold_owner<K>(&self, monitor: &mut OwnedMonitor<'_, C, K>, id: MonitorId) {
        let (owner, cause) = (monitor.owner, Cause::Monitor(id));
        if self.hold(owner, cause, monitor.def.exception) {
            monitor.fired = monitor.fired.saturating_add(1);
        }
    }

    /// A monitor (not `PauseOwner`) triggered: raise its exception. False when its owner
    /// could not take it (see [`raise`](Self::raise)).
    fn fire<K>(&self, monitor: &mut OwnedMonitor<'_, C, K>, id: MonitorId, control: &C) -> bool {
        let reaction = Reaction {
            behaviour: monitor.def.behaviour,
            exception: monitor.def.exception,
            limit: monitor.def.restart_limit,
        };
        let raised = self.raise(control, monitor.owner, Cause::Monitor(id), &reaction);
        if raised {
            monitor.fired = monitor.fired.saturating_add(1);
        }
        raised
    }
}

/// What the firings of one group came to.
struct GroupFiring {
    /// A `PauseOwner` monitor's condition cleared: its release is pending.
    releasing: bool,
    /// The monitors (bits as in [`Group`]) whose owner could not take their exception.
    not_taken: u32,
}
