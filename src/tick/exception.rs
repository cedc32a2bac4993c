//! A firing (seed §1.7): the exception is marked, the exception sequence runs in its lane
//! while the owner is held, and then the behaviour applies.

use crate::lock::Lock;
use crate::model::id::{Link, RunId};
use crate::model::set::SeqSet;
use crate::model::state::RunningStates;
use crate::sequencer::control_block::{flag, ControlBlock};
use crate::sequencer::sections::{in_sections, in_sections_then_wake, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::start::Mode;
use crate::sequencer::State;
use crate::tick::skip_untaken_polls;
use crate::{Behaviour, Cause, Error, Event, RunningState, SeqId, Sequencer};

/// How an exception of one monitor (or of a sequence's timeout) is handled.
pub(crate) struct Reaction {
    pub(crate) behaviour: Behaviour,
    pub(crate) exception: Option<SeqId>,
    /// How many restarts of a run of the target (by any monitor or timeout) it allows.
    pub(crate) limit: u8,
}

impl ControlBlock {
    /// How this sequence's timeout monitor reacts.
    pub(crate) fn timeout_reaction(&self) -> Reaction {
        Reaction {
            behaviour: self.timeout_behaviour,
            exception: self.timeout_exception.get(),
            limit: self.timeout_restart_limit,
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// A monitor (or `owner`'s timeout, `Cause::Timeout`) of `owner` fired with `reaction`:
    /// mark the exception, then start the exception sequence (the behaviour waits for its
    /// end) or apply the behaviour now. If the marked run is over, or its stop has begun,
    /// by the time the exception sequence's start is refused, the exception went with the
    /// run: nothing more happens. Returns false when the owner could not take an
    /// exception any more, or its timeout is not run out after all (switched off or
    /// changed since the scan): the timeout stays armed and is checked again at its next
    /// poll, unless the mark disarmed it and then found the run ended or its stop begun
    /// (a lane above the tick, between two of the mark's sections): that run's timeout
    /// is of no account. A timeout that fires is disarmed.
    #[inline(never)]
    pub(crate) fn raise(
        &self,
        control: &C,
        owner: SeqId,
        cause: Cause,
        reaction: &Reaction,
    ) -> bool {
        let Some(Marked {
            owner: marked,
            target,
            behaviour,
            skipped,
        }) = in_sections!(self, |s| mark(s, owner, cause, reaction))
        else {
            return false;
        };
        if let Some(e) = reaction.exception {
            // A lane of higher priority may have ended the marked run (and begun
            // another), or begun its stop, since the mark: the exception went with the
            // run it was raised on.
            match self.begin(e, Mode::Exception { owner: marked }, cause) {
                Ok(_) => {
                    // The behaviour waits for the exception sequence's end, kept as what
                    // it does to this owner: one that acts on the caller stays so only
                    // for an owner that has one now. Kept as configured: the limit is
                    // judged again where it is applied, on the target's run then.
                    let pending = if target.seq == owner {
                        reaction.behaviour.on_owner()
                    } else {
                        reaction.behaviour
                    };
                    // Its start found the run under way and not being stopped; unless a
                    // lane of higher priority has ended it (or begun its teardown) since,
                    // the behaviour waits for it. An abort requested since is carried
                    // out by the next tick: after the behaviour if the exception sequence
                    // has ended by then (semantics 3), else it takes the owner and the
                    // exception sequence down, and the behaviour goes with the run.
                    self.with(|s| {
                        if s.block(owner).is_some_and(|b| {
                            b.runs == marked.count
                                && RunningStates::RUNNING_OR_PAUSED.has(b.state)
                                && !b.has(flag::STOPPING)
                        }) {
                            s.set_pending(owner, pending, reaction.limit, e);
                        }
                    });
                    return true;
                }
                // Refused for whatever reason once the marked run was over, or its
                // stop had begun: the exception went with its run. Else it could not
                // run: counted, and the behaviour applies at once.
                Err(why) => {
                    if !self.exception_not_run(marked, e, why) {
                        return true;
                    }
                }
            }
        }
        self.apply(control, marked, behaviour, target, cause);
        if behaviour == Behaviour::Nothing {
            // Handled at once after all (its exception sequence could not start): the
            // owner was not held, so the polls the mark skipped stand.
            in_sections!(self, |s| give_back_polls(s, marked, skipped));
        }
        true
    }

    /// Exception sequence `exception` for the exception of the owner's run `owner` was
    /// refused (`why`). If that run still takes the exception (under way, not being
    /// stopped), it is counted (`exceptions_not_run`) in the section that checks the run,
    /// recorded in the next, and true is returned; else the exception went with its run,
    /// and nothing is.
    pub(super) fn exception_not_run(&self, owner: RunId, exception: SeqId, why: Error) -> bool {
        let taken = self.with(|s| {
            let taken = s.takes_exception(owner);
            if taken {
                s.exceptions_not_run = s.exceptions_not_run.saturating_add(1);
            }
            taken
        });
        if taken {
            self.with(|s| {
                s.record(Event::ExceptionNotRun {
                    exception,
                    owner: owner.seq,
                    why,
                });
            });
        }
        taken
    }

    /// Applies a behaviour after an exception (and its exception sequence) of the owner's
    /// run `owner` to the run `target` (the owner's, or its caller's).
    pub(super) fn apply(
        &self,
        control: &C,
        owner: RunId,
        behaviour: Behaviour,
        target: RunId,
        cause: Cause,
    ) {
        match behaviour {
            Behaviour::Nothing => {
                let id = owner.seq;
                in_sections_then_wake!(self, |s| {
                    s.section(|s| {
                        s.sets.put(Set::Excepting, id, false);
                        if let Some(b) = s.block_mut(id) {
                            b.set(flag::EXCEPTION_MARKED, false);
                        }
                    });
                    s.section(|s| s.lane_of(id))
                });
            }
            Behaviour::AbortOwner | Behaviour::AbortCallerOfOwner => {
                self.tear_down(control, target, cause);
            }
            Behaviour::RestartOwner | Behaviour::RestartCallerOfOwner => {
                self.restart_tree(control, target, cause);
            }
            // Applied once, it pauses (the tick's `hold` also resumes).
            Behaviour::PauseOwner => self.pause_tree(target, cause),
        }
        if target.seq != owner.seq && behaviour.targets_caller() {
            self.end_if_still_held(control, owner, cause);
        }
    }

    /// After a behaviour's teardown of its owner's caller's run: a lane of higher priority
    /// than the tick may have ended that run and begun another before the teardown looked
    /// at it, and a teardown does nothing to a later run (semantics 9). The owner's run
    /// `owner`, below it, still running and marked, would then stay held for good: it is
    /// aborted, as an owner whose caller's run has ended (semantics 11).
    #[inline(never)]
    fn end_if_still_held(&self, control: &C, owner: RunId, cause: Cause) {
        let held = self.with(|s| {
            s.current_run(owner.seq) == owner
                && RunningStates::RUNNING_OR_PAUSED.has(s.state_of(owner.seq))
                && s.sets.has(Set::Excepting, owner.seq)
        });
        if held {
            self.tear_down(control, owner, cause);
        }
    }
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// `behaviour` (with its monitor's restart `limit`) waits for the end of `owner`'s
    /// exception sequence.
    fn set_pending(&mut self, owner: SeqId, behaviour: Behaviour, limit: u8, awaited: SeqId) {
        if let Some(b) = self.block_mut(owner) {
            b.set_pending(Some(behaviour));
            b.awaited = Link::to(Some(awaited));
        }
        if let Some(l) = self.pending_restart_limits.get_mut(owner.index()) {
            *l = limit;
        }
    }

    /// Whether `run` is still its sequence's run, under way (running or paused) and not
    /// being stopped: an exception sequence refused for it was refused for an exception
    /// it still has (counted, and the behaviour applied at once), not one that went with
    /// its run.
    fn takes_exception(&self, run: RunId) -> bool {
        self.block(run.seq).is_some_and(|b| {
            b.runs == run.count
                && RunningStates::RUNNING_OR_PAUSED.has(b.state)
                && !b.being_stopped()
        })
    }
}

/// What `behaviour` does to the target's run `target` (semantics item 5): restarts are
/// bounded per run of the target, counted where the teardown restarts it, so a restart of
/// a run that has made `limit` of them escalates to the matching abort. An ended run is
/// restarted no more: the behaviour acts on the target's next run (a caller started
/// again), which begins at 0. Judged at the mark, and again where a behaviour that waited
/// for its exception sequence is applied: the target's run may have changed meanwhile.
pub(super) fn judged(behaviour: Behaviour, limit: u8, target: &ControlBlock) -> Behaviour {
    let made = if RunningStates::LIVE.has(target.state) {
        target.restarts_made
    } else {
        0
    };
    if behaviour.is_restart() && made >= limit {
        behaviour.escalated()
    } else {
        behaviour
    }
}

/// What [`mark`] did.
struct Marked<const B: usize> {
    /// The owner's run it marked.
    owner: RunId,
    /// The behaviour's target: the owner's run, or its caller's.
    target: RunId,
    /// The behaviour, escalated past the restart limit.
    behaviour: Behaviour,
    /// The sequences whose due poll the mark skipped (the owner, and its blocking children in
    /// its lane), held from the mark on.
    skipped: SeqSet<B>,
}

/// The steps of [`Sequencer::raise`] before the exception sequence: if `owner` can take
/// the exception (monitored; for a timeout, running and the timeout still run out, judged
/// again here; not handling one already; not being stopped), judges the behaviour on the
/// target's run and marks the exception, skipping the due polls it holds.
fn mark<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    owner: SeqId,
    cause: Cause,
    reaction: &Reaction,
) -> Option<Marked<B>> {
    let timeout = matches!(cause, Cause::Timeout(_));
    // Monitored (a paused timeout is frozen), not handling an exception already, not being
    // torn down (its teardown comes first), and the run the evaluation saw: a run begun
    // (or restarted) since this tick's scan is fresh, and its monitors are evaluated from
    // the next tick.
    let states = if timeout {
        RunningStates::of(RunningState::Running)
    } else {
        RunningStates::RUNNING_OR_PAUSED
    };
    // Several sections. With the portable lock a lane of higher priority may end or start
    // the owner in between: the mark is made only if the owner still runs the run the
    // first section saw, in a state that takes it; then it is counted and recorded.
    // A timeout is judged here, not by the scan that listed it: a monitor condition or
    // cleanup hook of this tick (or a lane above it) may have switched it off or
    // lengthened it since, and that applies at once.
    let timeout_judged = if timeout {
        Some(s.section(|s| s.run_out_timeout(owner))?)
    } else {
        None
    };
    let (target, owner_runs, lane) = s.section(|s| {
        let b = s.block(owner)?;
        if !states.has(b.state)
            || s.sets.has(Set::Excepting, owner)
            || b.being_stopped()
            || s.sets.has(Set::Fresh, owner)
        {
            return None;
        }
        let target = reaction.behaviour.target(owner, b.caller.get());
        Some((target, b.runs, b.lane))
    })?;
    let (target_runs, behaviour, due) = s.section(|s| {
        let t = s.block(target)?;
        let behaviour = judged(reaction.behaviour, reaction.limit, t);
        Some((t.runs, behaviour, s.sets.words(Set::PollDue)))
    })?;
    let target_run = RunId {
        seq: target,
        count: target_runs,
    };
    if let Some(judged) = timeout_judged {
        // Still the timeout judged, it is disarmed: from here it is this firing's, and a
        // change made since is the next run's. The run can now only end or be stopped
        // before the mark, and then its timeout is of no account.
        s.section(|s| {
            let b = s.block(owner)?;
            let unchanged = b.runs == owner_runs && b.timeout == judged;
            if unchanged {
                s.sets.put(Set::Armed, owner, false);
            }
            unchanged.then_some(())
        })?;
    }
    // From the mark on, the owner and its blocking children (in its lane) are held; but an
    // exception handled at once (`Nothing`, no exception sequence) holds nothing: their
    // due polls stand, else a monitor that fires at every poll (a `Level` warning) would
    // keep its owner from ever taking one.
    let holds = behaviour != Behaviour::Nothing || reaction.exception.is_some();
    let mut skipped = SeqSet::EMPTY;
    if holds {
        skipped = skip_untaken_polls(s, owner, lane, due);
    }
    // Only the tick marks an exception, and outside the tick only a new run (another run
    // count) clears the mark: the count stands for the first section's `Excepting` test.
    let owner_run = RunId {
        seq: owner,
        count: owner_runs,
    };
    let marked = s.section(|s| {
        let b = s
            .block_mut(owner)
            .filter(|b| states.has(b.state) && b.runs == owner_runs && !b.being_stopped())?;
        b.active_exception = Some(cause);
        b.set(flag::EXCEPTION_MARKED, true);
        s.sets.put(Set::Excepting, owner, true);
        // Held from now on: a due poll its lane has not taken is skipped.
        let skip = holds && s.sets.has(Set::PollDue, owner);
        if skip {
            s.sets.remove(Set::PollDue, owner);
        }
        Some(skip)
    });
    // Not marked after all (a lane above the tick ended the run or began its stop since
    // the skip): nothing is held, so the polls skipped for the hold stand.
    let Some(owner_skipped) = marked else {
        give_back_polls(s, owner_run, skipped);
        return None;
    };
    if owner_skipped {
        skipped.insert(owner);
    }
    s.section(|s| {
        #[cfg(feature = "counters")]
        if let Some(c) = s.counters.get_mut(owner.index()) {
            c.exceptions = c.exceptions.wrapping_add(1);
        }
        s.record(Event::Fired {
            owner,
            cause,
            behaviour,
        });
    });
    Some(Marked {
        owner: owner_run,
        target: target_run,
        behaviour,
        skipped,
    })
}

/// The due polls `skipped` for a hold of the owner's run `owner` that held nothing stand
/// again, while that run is the owner's: a lane of higher priority may have begun
/// another, whose polls are its own. One section per sequence.
fn give_back_polls<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    owner: RunId,
    skipped: SeqSet<B>,
) {
    for id in skipped {
        s.section(|s| {
            if s.current_run(owner.seq) == owner && s.sets.has(Set::PollWait, id) {
                s.sets.put(Set::PollDue, id, true);
            }
        });
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::sequencer::port::Port;
    use crate::{Error, Instant, Monitor, MonitorId, Monitors, Outcome, SeqConfig};

    /// What a monitor of the owner with exception sequence `e` and `AbortOwner` reacts with.
    fn abort_owner_with(e: SeqId) -> Reaction {
        Reaction {
            behaviour: Behaviour::AbortOwner,
            exception: Some(e),
            limit: 3,
        }
    }

    /// Sequences named `names`, each with a lane; the first `running` of them started.
    fn in_lanes<const K: usize>(
        seq: &Sequencer<(), 4>,
        names: [&'static str; K],
        running: usize,
    ) -> [SeqId; K] {
        let ids = names.map(|n| seq.register(SeqConfig::new(n)).unwrap());
        for id in ids {
            seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        }
        for &id in ids.iter().take(running) {
            seq.sequence_by_id(id).unwrap().start().unwrap();
        }
        ids
    }

    /// A tick in which `owner`'s first monitor fires (`AbortOwner`, exception sequence
    /// `e`): `e` starts for `owner`, whose behaviour waits for `e`'s end.
    fn fire_with(seq: &Sequencer<(), 4>, owner: SeqId, e: SeqId) {
        let cause = Cause::Monitor(MonitorId(0));
        // The scan of the tick whose evaluation fires took the owner's fresh mark.
        seq.with(|s| s.sets.put(Set::Fresh, owner, false));
        assert!(seq.raise(&(), owner, cause, &abort_owner_with(e)));
    }

    /// O and O2 share the exception sequence E (both monitors `AbortOwner`). E, handling
    /// O's exception, ends in its lane (`Port::end`); before the lane reports the run over
    /// (`Port::finished`, sections of its own) a tick preempts it, in which O2's monitor
    /// fires. The tick first reports E's end to O (O's behaviour: O aborted), then starts
    /// E again for O2, which stays running and held while E runs for it. The lane's late
    /// report of the old run changes nothing.
    #[test]
    fn an_exception_sequence_started_again_before_its_end_was_reported_ends_the_first_owners_exception(
    ) {
        let seq: Sequencer<(), 4> = Sequencer::new();
        let [o, o2, e] = in_lanes(&seq, ["O", "O2", "E"], 2);
        // A tick: O's monitor fires; E starts for O, O's behaviour waits for E's end.
        fire_with(&seq, o, e);
        assert_eq!(
            seq.with(|s| s.block(e).and_then(|b| b.caller.get())),
            Some(o)
        );
        // E's lane: the run ends ...
        let first = seq.with(|s| s.current_run(e));
        assert!(Port::end(&seq, first, Outcome::Completed));
        // ... a tick preempts it: O2's monitor fires with the same exception sequence.
        let mut fault = |_: &(), _: Instant| true;
        let mut monitors = Monitors::<(), 1>::new();
        monitors
            .add(
                o2,
                Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(e),
            )
            .unwrap();
        seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
            .unwrap();
        // The lane goes on: it reports the run that handled O's exception over.
        Port::finished(&seq, first);
        let pending = |id: SeqId| seq.with(|s| s.block(id).and_then(|b| b.pending()));
        assert_eq!(pending(o), None);
        assert_eq!(
            [o, o2, e].map(|id| seq.state_of_for_test(id)),
            [
                RunningState::Aborted,
                RunningState::Running,
                RunningState::Running
            ]
        );
        // O2 is held by its exception, which E (for O2) handles; its behaviour waits for
        // E's end.
        assert!(seq.with(|s| s.sets.has(Set::Excepting, o2)));
        assert_eq!(pending(o2), Some(Behaviour::AbortOwner));
        assert!(seq.with(|s| s
            .block(e)
            .is_some_and(|b| b.has(flag::HANDLES_EXCEPTION) && b.caller.get() == Some(o2))));
        assert_eq!(seq.exceptions_not_run(), 0);
    }

    /// A start of an exception sequence that ended, before the tick reported its end to
    /// its owner, is refused: until then the sequence is its owner's.
    #[test]
    fn an_exception_sequence_is_its_owners_until_its_end_is_reported() {
        let seq: Sequencer<(), 4> = Sequencer::new();
        let [o, e] = in_lanes(&seq, ["O", "E"], 1);
        fire_with(&seq, o, e);
        let run = seq.with(|s| s.current_run(e));
        assert!(Port::end(&seq, run, Outcome::Completed));
        let handle = seq.sequence_by_id(e).unwrap();
        assert_eq!(handle.start(), Err(Error::AlreadyRunning(e)));
        let mut monitors = Monitors::<(), 1>::new();
        seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
            .unwrap();
        assert_eq!(seq.state_of_for_test(o), RunningState::Aborted);
        assert_eq!(handle.start(), Ok(()));
    }

    /// O's monitor fires with exception sequence E (`AbortOwner`); E is aborted (a request)
    /// before its lane took the start, so no lane ever reports its run. The abort itself
    /// ends O's exception: the tick after it applies O's behaviour.
    #[test]
    fn an_exception_sequence_aborted_before_its_lane_took_it_ends_the_exception() {
        let seq: Sequencer<(), 4> = Sequencer::new();
        let [o, e] = in_lanes(&seq, ["O", "E"], 1);
        fire_with(&seq, o, e);
        seq.sequence_by_id(e).unwrap().abort().unwrap();
        let mut monitors = Monitors::<(), 1>::new();
        let mut states_after_tick = |ms: u64| {
            seq.tick(Instant::from_ticks(ms * 1_000), &(), &mut monitors)
                .unwrap();
            [o, e].map(|id| seq.state_of_for_test(id))
        };
        assert_eq!(
            states_after_tick(1),
            [RunningState::Running, RunningState::Aborted]
        );
        assert_eq!(
            states_after_tick(2),
            [RunningState::Aborted, RunningState::Aborted]
        );
    }

    /// O's monitor restarts it (`RestartOwner`) in a tick; before O's lane has run it again
    /// (a lane starved for a tick), an abort-all comes (the safety system entering an
    /// emergency level). The next tick must abort O: a `Restarting` sequence is under way
    /// (an abort request of it is accepted), and the emergency bound says every sequence
    /// is aborted in that tick. An abort-all that looked only at the active (running or
    /// paused) sequences would find none and do nothing: O's lane would then run it again.
    #[test]
    fn an_abort_all_aborts_a_sequence_whose_lane_has_not_restarted_it_yet() {
        let seq: Sequencer<(), 4> = Sequencer::new();
        let [o] = in_lanes(&seq, ["O"], 1);
        restart_then_abort_all(&seq, o);
        // Its lane, when it runs at last, finds the run over.
        let waker = core::task::Waker::noop();
        let run = Port::take_start(&seq, o, seq.tag(), waker);
        assert_eq!(run, None);
    }

    /// The same in a sequencer of two words, O in the second.
    #[test]
    fn an_abort_all_aborts_a_restarting_sequence_in_a_sequencer_of_two_words() {
        use crate::lock::CriticalSection;
        let seq: Sequencer<(), 64, 64, CriticalSection, 8, 2> = Sequencer::new();
        // Names are unique: 35 before O, so that O is in the second word.
        let pads = [
            "s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "s8", "s9", "s10", "s11", "s12", "s13",
            "s14", "s15", "s16", "s17", "s18", "s19", "s20", "s21", "s22", "s23", "s24", "s25",
            "s26", "s27", "s28", "s29", "s30", "s31", "s32", "s33", "s34",
        ];
        for name in pads {
            seq.register(SeqConfig::new(name)).unwrap();
        }
        let o = seq.register(SeqConfig::new("O")).unwrap();
        let h = seq.sequence_by_id(o).unwrap();
        h.declare_lane().unwrap();
        h.start().unwrap();
        restart_then_abort_all(&seq, o);
    }

    /// Running `o`: its monitor restarts it in a tick at 1 ms; an abort-all before its lane
    /// has run it again is carried out by the tick at 2 ms.
    fn restart_then_abort_all<const N: usize, L: Lock, const W: usize, const B: usize>(
        seq: &Sequencer<(), N, 64, L, W, B>,
        o: SeqId,
    ) {
        let mut fault = |_: &(), _: Instant| true;
        let mut monitors = Monitors::<(), 1>::new();
        monitors
            .add(
                o,
                Monitor::new("fault", &mut fault, Behaviour::RestartOwner),
            )
            .unwrap();
        seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
            .unwrap();
        assert_eq!(seq.state_of_for_test(o), RunningState::Restarting);
        seq.abort_all();
        seq.tick(Instant::from_ticks(2_000), &(), &mut monitors)
            .unwrap();
        assert_eq!(seq.state_of_for_test(o), RunningState::Aborted);
    }

    impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
        Sequencer<C, N, T, L, W, B>
    {
        fn state_of_for_test(&self, id: SeqId) -> RunningState {
            self.with(|s| s.state_of(id))
        }
    }
}
