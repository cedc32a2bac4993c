//! How an operation of several steps takes its sections.
//!
//! With a lock that masks every interrupt (`CriticalSection`, and `PriorityCeiling` at
//! RTIC's highest priority) a section must stay short: each step of an operation is a
//! section of its own, and every step re-checks what an earlier one saw. With a coarse
//! lock (`Lock::COARSE`: RTIC's priority ceiling below the top, or `SingleThread`) a
//! section only holds off the sequencer's own users, so a whole operation runs in the one
//! section its caller took. An operation is written once, generic over [`Sections`], and
//! [`in_sections!`] compiles it for the one case the lock needs.

use crate::lock::Lock;
use crate::sequencer::State;
use crate::Sequencer;

/// The state, one step at a time.
pub(crate) trait Sections<C, const N: usize, const T: usize, const W: usize, const B: usize> {
    /// True when every step runs inside one section: nothing changes between two steps,
    /// so a commit never has to be tried again.
    const ONE_SECTION: bool = false;

    /// Runs `f` on the state: in a section of its own, or inside the caller's.
    fn section<R>(&mut self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> R) -> R;
}

/// Inside the section a coarse lock's caller holds: every step runs at once.
impl<C, const N: usize, const T: usize, const W: usize, const B: usize> Sections<C, N, T, W, B>
    for State<C, N, T, W, B>
{
    const ONE_SECTION: bool = true;

    #[inline(always)]
    fn section<R>(&mut self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> R) -> R {
        f(self)
    }
}

/// With the portable lock: one section per step.
pub(crate) struct EachStep<
    'a,
    C,
    const N: usize,
    const T: usize,
    L: Lock,
    const W: usize,
    const B: usize,
>(pub(crate) &'a Sequencer<C, N, T, L, W, B>);

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sections<C, N, T, W, B> for EachStep<'_, C, N, T, L, W, B>
{
    #[inline(always)]
    fn section<R>(&mut self, f: impl FnOnce(&mut State<C, N, T, W, B>) -> R) -> R {
        self.0.with(f)
    }
}

/// `in_sections!(sequencer, |s| body)` runs `body` with `s` as its [`Sections`]: with a
/// coarse lock (`L::COARSE`, the lock type in scope) inside one section, else with a
/// section per step.
macro_rules! in_sections {
    ($seq:expr, |$s:ident| $body:expr) => {
        if L::COARSE {
            $seq.with(|$s| $body)
        } else {
            let $s = &mut $crate::sequencer::sections::EachStep($seq);
            $body
        }
    };
}
pub(crate) use in_sections;

/// `in_sections_then_wake!(sequencer, |s| body)`: as [`in_sections!`] for a `body` that
/// returns the lanes to wake, which are woken once the state is no longer borrowed (with a
/// coarse lock still inside the one section, see `Sequencer::update_and_wake`).
macro_rules! in_sections_then_wake {
    ($seq:expr, |$s:ident| $body:expr) => {
        if L::COARSE {
            $seq.update_and_wake(|$s| $body)
        } else {
            let lanes = {
                let $s = &mut $crate::sequencer::sections::EachStep($seq);
                $body
            };
            $seq.wake_lanes(lanes)
        }
    };
}
pub(crate) use in_sections_then_wake;

#[cfg(test)]
pub(crate) mod tests {
    use super::Sections;
    use crate::sequencer::control_block::ControlBlock;
    use crate::sequencer::State;
    use crate::trace::StateChange;
    use crate::{Cause, RunningState, SeqId};

    /// A small state for the tests of operations.
    pub(crate) type S = State<(), 4, 8, 1, 1>;

    /// An operation's sections with something in between: before section `at`, `between`
    /// runs on the state, as a tick or a lane of higher priority would with the portable
    /// lock.
    pub(crate) struct Preempted<'a, F> {
        pub(crate) state: &'a mut S,
        pub(crate) taken: usize,
        pub(crate) at: usize,
        pub(crate) between: Option<F>,
    }

    impl<'a, F: FnOnce(&mut S)> Preempted<'a, F> {
        /// The operation's sections on `state`, with `between` before section `at`.
        pub(crate) fn new(state: &'a mut S, at: usize, between: F) -> Self {
            Preempted {
                state,
                taken: 0,
                at,
                between: Some(between),
            }
        }
    }

    /// `count` registered sequences, those of `running` started.
    pub(crate) fn registered(count: usize, running: &[SeqId]) -> S {
        let mut state = S::new();
        for _ in 0..count {
            assert!(state.push_block(ControlBlock::IDLE, None).is_ok());
        }
        for &id in running {
            let start =
                StateChange::new(id, RunningState::Idle, RunningState::Running, Cause::Start);
            assert!(state.transition(&start).is_some());
        }
        state
    }

    impl<F: FnOnce(&mut S)> Sections<(), 4, 8, 1, 1> for Preempted<'_, F> {
        fn section<R>(&mut self, f: impl FnOnce(&mut S) -> R) -> R {
            if self.taken == self.at {
                if let Some(between) = self.between.take() {
                    between(self.state);
                }
            }
            self.taken += 1;
            f(self.state)
        }
    }
}
