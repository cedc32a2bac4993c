//! Pauses and resumes: a sequence and its blocking children (in its lane) are paused or
//! resumed, outermost first, in sections (with the portable lock, one short section per
//! step). A paused run's clock (and its
//! timeout) stops, its monitors stay active.

use crate::lock::Lock;
use crate::model::id::RunId;
use crate::model::state::RunningStates;
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::tick::skip_untaken_polls;
use crate::tick::walk::{Pass, Scope};
use crate::trace::StateChange;
use crate::{Cause, RunningState, Sequencer};

/// A pause or a resume.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pausing {
    /// `Running` → `Paused`.
    Pause,
    /// `Paused` → `Running`.
    Resume,
}

impl Pausing {
    /// The state its sequences leave.
    const fn from(self) -> RunningState {
        match self {
            Pausing::Pause => RunningState::Running,
            Pausing::Resume => RunningState::Paused,
        }
    }

    /// The state its sequences enter.
    const fn to(self) -> RunningState {
        match self {
            Pausing::Pause => RunningState::Paused,
            Pausing::Resume => RunningState::Running,
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Pauses the running run `target` and its blocking children (in its lane), outermost
    /// first, for `cause` (a pause request, a `PauseOwner` monitor). Nothing once `target`
    /// is no longer its sequence's run (a lane of higher priority may end it and start the
    /// sequence again before the pause's first section).
    pub(crate) fn pause_tree(&self, target: RunId, cause: Cause) {
        self.pausing(target, Pausing::Pause, cause);
    }

    /// Resumes the paused run `target` and its blocking children (in its lane), outermost
    /// first, unless something else holds them: one kept paused keeps those below it.
    /// Nothing once `target` is no longer its sequence's run.
    pub(crate) fn resume_tree(&self, target: RunId, cause: Cause) {
        self.pausing(target, Pausing::Resume, cause);
    }

    /// The passes of a pause or resume of `target` (made by the tick). Between two
    /// sections a lane of higher priority may start a run below a sequence the pass has not
    /// reached yet: the pass is then made again, for what began below the target, which is
    /// found in the state it entered.
    fn pausing(&self, target: RunId, how: Pausing, cause: Cause) {
        let mut target_in = how.from();
        for _ in 0..=2 * N {
            let begun = self.with(|s| s.runs_begun);
            if self.pausing_pass(target, how, cause, begun, target_in) == Pass::Done {
                return;
            }
            target_in = how.to();
        }
    }

    /// One pass of a pause or resume of `target`, in state `target_in` (else the pass is
    /// done), begun when [`State::runs_begun`](crate::sequencer::State::runs_begun) was
    /// `begun`.
    #[inline(never)]
    fn pausing_pass(
        &self,
        run: RunId,
        how: Pausing,
        cause: Cause,
        begun: u32,
        target_in: RunningState,
    ) -> Pass {
        let target = run.seq;
        let Some(lane) = self.with(|s| {
            s.block(target)
                .filter(|b| b.state == target_in && b.runs == run.count)
                .map(|b| b.lane)
        }) else {
            return Pass::Done;
        };
        let states = RunningStates::of(how.from());
        if how == Pausing::Pause {
            // The target is paused first and its blocking children after it.
            in_sections!(self, |s| {
                let due = s.section(|s| s.sets.words(Set::PollDue));
                skip_untaken_polls(s, target, lane, due);
            });
        }
        let scope = Scope::InLane { target, lane };
        let rows = self.by_depth(scope, states, &mut |_, _| true);
        for depth in 0..=rows.deepest() {
            for id in rows.at(depth) {
                if id == target {
                    self.pause_one(run, cause, how);
                    continue;
                }
                // A blocking child is moved whatever run it is in, as long as the target
                // runs the run this pause is of: what is below a later run of the target
                // is not this pause's, and the pause is over. A resume of the target
                // resumes its blocking children unless something else holds them.
                let kept = how == Pausing::Resume && self.with(|s| s.stays_paused(id));
                if !kept {
                    let child =
                        self.with(|s| (s.current_run(target) == run).then(|| s.current_run(id)));
                    let Some(child) = child else {
                        return Pass::Done;
                    };
                    self.pause_one(child, cause, how);
                }
            }
        }
        // A run begun during the pass (a blocking start below a sequence not paused yet, a
        // restart taken up below the target, which the look passed over while it was
        // `Restarting`, a child ended and begun again) is found by the next. A move that
        // lost its race needs no pass of its own: a run leaves `Running` or `Paused` and
        // comes back only through a restart, which only the tick (this one) begins; so one
        // that left its state between the look and the move ended or is being torn down.
        // A new run of the target is not this pause's: `leave_for_pause` moves only the
        // run it names.
        Pass::of(self.with(|s| s.runs_begun) == begun)
    }

    /// Pauses or resumes the run `run` (`how`: from `Running` to `Paused`, or back); a
    /// resume wakes its lane. A paused run stays at its await point, where its lane
    /// already waits (a poll of it would find the run held and wait again): only the
    /// resume gives the lane something to do.
    fn pause_one(&self, run: RunId, cause: Cause, how: Pausing) {
        let moved = in_sections!(self, |s| leave_for_pause(s, run, cause, how));
        if moved && how == Pausing::Resume {
            in_sections_then_wake!(self, |s| s.section(|s| s.lane_of(run.seq)));
        }
    }
}

/// The steps of [`Sequencer::pause_one`] before the wake-up: the run `run` leaves the state
/// `how` leaves for the one it enters; its clock (and its timeout) stops or goes on. False
/// when it was not in that state, is over, or left it for another transition before the
/// move.
fn leave_for_pause<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    run: RunId,
    cause: Cause,
    how: Pausing,
) -> bool {
    let change = StateChange::new(run.seq, how.from(), how.to(), cause);
    // A pause keeps a teardown's mark: the teardown still moves the paused run.
    if !s.section(|s| s.transition_if(&change, |b| b.runs == run.count).is_some()) {
        return false;
    }
    // Then its clock stops or runs on (the clock's mark says which, so the run time read
    // in between is the running clock's), and a due poll its lane has not taken yet is
    // skipped, not taken when the pause ends (semantics 1): unless the run was moved
    // again meanwhile.
    s.section(|s| {
        let to = how.to();
        if s.block(run.seq)
            .is_none_or(|b| b.runs != run.count || b.state != to)
        {
            return;
        }
        match how {
            Pausing::Pause => {
                s.stop_clock(run.seq);
                s.sets.remove(Set::PollDue, run.seq);
            }
            Pausing::Resume => s.run_clock(run.seq),
        }
    });
    true
}
