//! The seven running states and the transition table.

/// The seven running states of a sequence or step (the seed's `runningStateEnum`).
///
/// A sequence's states through a start and a pause, on the host simulator:
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState::*, Seq, SeqConfig,
///             Sequence, Sequencer, Wait};
/// struct Main(Seq<Wait>);
/// impl Sequence<()> for Main {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         let _ = cx.step(&mut self.0).await;
///         Ok(())
///     }
/// }
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(3))).unwrap();
/// let main = seq.add(SeqConfig::new("main"), Main(dwell)).unwrap();
/// let id = main.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(main);
/// let mut states = vec![sim.state(id)];
/// sim.start(id).unwrap();
/// states.push(sim.state(id));
/// sim.pause(id).unwrap();
/// sim.step();
/// states.push(sim.state(id));
/// sim.resume(id).unwrap();
/// sim.run_until_idle(Duration::from_millis(10)).unwrap();
/// states.push(sim.state(id));
/// assert_eq!(states, [Idle, Running, Paused, Terminated]);
/// # }
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RunningState {
    /// Registered, never started.
    Idle,
    /// Started and advancing (or blocked by a blocking child).
    Running,
    /// Paused by a pause request, a `PauseOwner` monitor, or with the paused caller it
    /// blocks: stops at its next await point, monitors stay active.
    Paused,
    /// Being aborted: the cleanup hook runs in this state.
    Aborting,
    /// Aborted by a monitor, the timeout, a request or abort-all. Sticky until started again.
    Aborted,
    /// Ended normally (exit condition true) or skipped (pre-condition false).
    Terminated,
    /// Aborted for a restart; runs again from the pre-condition at its lane's next poll.
    Restarting,
}

impl RunningState {
    /// True while the sequence occupies its control block: `Running`, `Paused`, `Aborting`
    /// or `Restarting`. Starting an active sequence is an error.
    ///
    /// ```
    /// use rtseq::RunningState;
    /// assert!(RunningState::Paused.is_active());
    /// assert!(!RunningState::Terminated.is_active());
    /// ```
    pub const fn is_active(self) -> bool {
        matches!(
            self,
            RunningState::Running
                | RunningState::Paused
                | RunningState::Aborting
                | RunningState::Restarting
        )
    }

    /// The transition table: whether `self → to` is a legal transition.
    ///
    /// | from | to |
    /// |---|---|
    /// | `Idle`, `Terminated`, `Aborted` | `Running` (start) |
    /// | `Running` | `Paused`, `Aborting`, `Restarting`, `Terminated` |
    /// | `Paused` | `Running` (resume), `Aborting`, `Restarting` |
    /// | `Restarting` | `Running`, `Aborting` |
    /// | `Aborting` | `Aborted` |
    ///
    /// ```
    /// use rtseq::RunningState::*;
    /// assert!(Running.can_transition_to(Paused));
    /// assert!(!Aborted.can_transition_to(Terminated));
    /// ```
    pub const fn can_transition_to(self, to: RunningState) -> bool {
        use RunningState::*;
        matches!(
            (self, to),
            (Idle | Terminated | Aborted, Running)
                | (Running, Paused | Aborting | Restarting | Terminated)
                | (Paused, Running | Aborting | Restarting)
                | (Restarting, Running | Aborting)
                | (Aborting, Aborted)
        )
    }

    /// All seven states, for exhaustive checks.
    ///
    /// ```
    /// use rtseq::RunningState;
    /// let active = RunningState::ALL.iter().filter(|s| s.is_active()).count();
    /// assert_eq!(active, 4); // Running, Paused, Aborting, Restarting
    /// // Every state but `Idle` can be entered, and only `Running` from `Idle`:
    /// for s in RunningState::ALL {
    ///     let entered = RunningState::ALL.iter().any(|from| from.can_transition_to(s));
    ///     assert_eq!(entered, s != RunningState::Idle, "{s:?}");
    /// }
    /// ```
    pub const ALL: [RunningState; 7] = [
        RunningState::Idle,
        RunningState::Running,
        RunningState::Paused,
        RunningState::Aborting,
        RunningState::Aborted,
        RunningState::Terminated,
        RunningState::Restarting,
    ];
}

/// A set of running states (bit `s as u8` = state `s`): the transition table as sets, for
/// checks inside short sections.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct RunningStates(u8);

impl RunningStates {
    /// `Running` or `Paused`: the states in which monitors are evaluated.
    pub(crate) const RUNNING_OR_PAUSED: RunningStates =
        RunningStates::of(RunningState::Running).with(RunningState::Paused);

    /// A run is under way: every state but `Idle` and the ends (`Terminated`, `Aborted`).
    pub(crate) const LIVE: RunningStates = RunningStates::RUNNING_OR_PAUSED
        .with(RunningState::Restarting)
        .with(RunningState::Aborting);

    /// The states a teardown leaves a run in: being aborted, aborted, or between two
    /// rounds.
    pub(crate) const STOPPED_BY_TEARDOWN: RunningStates = RunningStates::of(RunningState::Aborting)
        .with(RunningState::Aborted)
        .with(RunningState::Restarting);

    /// The states a start may leave (`Idle`, `Terminated`, `Aborted`: not active).
    pub(crate) const STARTABLE: RunningStates = RunningStates::of(RunningState::Idle)
        .with(RunningState::Terminated)
        .with(RunningState::Aborted);

    /// The set of `s` alone.
    pub(crate) const fn of(s: RunningState) -> RunningStates {
        RunningStates(1 << s as u8)
    }

    /// This set with `s` in.
    pub(crate) const fn with(self, s: RunningState) -> RunningStates {
        RunningStates(self.0 | RunningStates::of(s).0)
    }

    /// Whether `s` is in the set.
    pub(crate) const fn has(self, s: RunningState) -> bool {
        self.0 & RunningStates::of(s).0 != 0
    }

    /// The states from which `to` may be entered: [`RunningState::can_transition_to`] as
    /// a set.
    pub(crate) const fn entering(to: RunningState) -> RunningStates {
        use RunningState::*;
        match to {
            Running => RunningStates::STARTABLE.with(Paused).with(Restarting),
            Paused | Terminated => RunningStates::of(Running),
            Restarting => RunningStates::RUNNING_OR_PAUSED,
            Aborting => RunningStates::RUNNING_OR_PAUSED.with(Restarting),
            Aborted => RunningStates::of(Aborting),
            Idle => RunningStates(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_state_sets_are_the_transition_table() {
        for from in RunningState::ALL {
            for to in RunningState::ALL {
                assert_eq!(
                    RunningStates::entering(to).has(from),
                    from.can_transition_to(to),
                    "{from:?} -> {to:?}"
                );
            }
            assert_eq!(RunningStates::STARTABLE.has(from), !from.is_active());
        }
    }
}
