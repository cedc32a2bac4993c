//! Starts and restarts: the checks, the schedule and the commit of a new run.
//!
//! A start is a few steps ([`Sections`]): the checks ([`admit`]), then the schedule of the
//! run (its timeout, its lane, the sets the tick reads, its polling class's grid) and the
//! commit that makes it `Running`. The tick may run between two steps with the portable
//! lock, and a lane of higher priority may make transitions; the commit then sees that the
//! count of changes ([`State::changes`]) moved since the schedule began, and the run is
//! scheduled again. A restart (after `Restarting`) takes the same path with the run's lane,
//! caller and flags as they are.

use core::sync::atomic::AtomicU8;

use crate::lock::Lock;
use crate::model::id::{Link, RunId};
use crate::model::set::SeqSet;
use crate::model::state::RunningStates;
use crate::model::time::Stamp;
use crate::sequencer::callers::cut_and_depth;
use crate::sequencer::clearance::stops_soon;
use crate::sequencer::control_block::{flag, request, ControlBlock};
use crate::sequencer::inbox::abort_all_posted;
use crate::sequencer::lanes::{lane_slot_of, LaneSet};
use crate::sequencer::sections::{in_sections, Sections};
use crate::sequencer::sets::Set;
use crate::sequencer::State;
use crate::trace::StateChange;
use crate::{Cause, Error, RunningState, SeqId, Sequencer, MAX_DEPTH};

/// Where a started run runs, and who started it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Mode {
    /// Inside the future of the run `caller`, which waits. `maker`: the tag of the sequencer
    /// that made the started sequence object (a blocking start is of an object in hand).
    Blocking { caller: RunId, maker: u16 },
    /// A plain non-blocking start: in the sequence's own lane, started by the run `caller`
    /// (none: a main sequence started by the application), which continues.
    NonBlocking { caller: Option<RunId> },
    /// In the sequence's own lane as a main sequence (no caller), started by the run `by`
    /// through a handle of its context: refused as that run's own starts are.
    MainBy { by: RunId },
    /// In the sequence's own lane, as the exception sequence of the run `owner`, which the
    /// exception holds: its end is reported to the tick, which then applies the behaviour.
    Exception { owner: RunId },
    /// In the sequence's own lane, as the exception sequence of a `PauseOwner` monitor of
    /// the run `owner`: it runs beside its paused owner and nothing waits for its end.
    BesidePause { owner: RunId },
}

impl Mode {
    /// The run that starts the new one, its caller.
    const fn caller(self) -> Option<RunId> {
        match self {
            Mode::Blocking { caller, .. }
            | Mode::Exception { owner: caller }
            | Mode::BesidePause { owner: caller } => Some(caller),
            Mode::NonBlocking { caller } => caller,
            Mode::MainBy { .. } => None,
        }
    }

    /// The run that makes the start, which begins nothing more once it is stopped, placed
    /// by a teardown or its abort is requested: its caller, or the run that starts a main
    /// sequence through a handle.
    const fn starter(self) -> Option<RunId> {
        match self {
            Mode::MainBy { by } => Some(by),
            _ => self.caller(),
        }
    }

    /// Whether the tick starts the run (an exception sequence): a start the tick makes
    /// while an abort-all waits is not refused (its run holds, and is aborted with the
    /// rest).
    const fn by_tick(self) -> bool {
        matches!(self, Mode::Exception { .. } | Mode::BesidePause { .. })
    }

    /// The flags the new run starts with.
    const fn flags(self) -> u16 {
        match self {
            Mode::Blocking { .. } => 0,
            Mode::NonBlocking { .. } | Mode::MainBy { .. } | Mode::BesidePause { .. } => {
                flag::START_PENDING
            }
            Mode::Exception { .. } => flag::START_PENDING | flag::HANDLES_EXCEPTION,
        }
    }
}

/// What a start gives its new run.
#[derive(Clone, Copy)]
struct NewRun {
    /// Its sequence.
    seq: SeqId,
    /// Its lane slot.
    lane: u8,
    /// The run of its caller, if any.
    caller: Option<RunId>,
    /// The run that starts it, if any ([`Mode::starter`]).
    starter: Option<RunId>,
    /// Its flags, all of them.
    flags: u16,
    /// The tick starts it (see [`Mode::by_tick`]).
    by_tick: bool,
}

/// What the schedule of a run saw, for its commit.
struct Scheduled {
    /// The state the run starts from.
    from: RunningState,
    /// Its timeout monitor is on.
    armed: bool,
}

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// The read-only checks of a start of `id`: blocking, of an object made here; not
    /// active (nor an ended exception sequence not reported yet).
    fn check_start(&self, id: SeqId, mode: Mode) -> Result<(), Error> {
        if matches!(mode, Mode::Blocking { maker, .. } if maker != self.tag) {
            return Err(Error::ForeignSequence(id));
        }
        let b = self.block(id).ok_or(Error::UnknownSequence(id))?;
        if !b.may_start() {
            return Err(Error::AlreadyRunning(id));
        }
        Ok(())
    }

    /// Opens the schedule of the new run `run`: the count of changes that its commit
    /// compares with ([`State::changes`]), if the run that starts it (if any: its caller,
    /// or the run that starts a main sequence through a handle, [`Mode::starter`]) may
    /// still start a run. The tick can stop a sequence while its action runs on to its
    /// next await point (the tick preempts the lanes), and a lane of higher priority start
    /// it again; a start the stopped run makes meanwhile is refused ([`Error::NotRunning`]
    /// with the starter's id), so nothing outlives its starter's stop; so is a start by a
    /// starter that a teardown is stopping ([`flag::STOPPING`]), whose abort is requested,
    /// or, unless it is the tick's start of an exception sequence, while an abort-all
    /// waits in the inbox (`abort_all_posted`): it begins nothing more. A start in a lane whose lane future
    /// was dropped since the start's checks is [`Error::NoLane`]: the close counts as a
    /// change, so a start that opened before it schedules again and finds the lane closed.
    fn open_start(&self, run: &NewRun, abort_all_posted: bool) -> Result<u32, Error> {
        if run.flags & flag::START_PENDING != 0 && !self.lane_open(run.lane) {
            return Err(Error::NoLane(run.seq));
        }
        match run.starter {
            Some(c)
                if self.block(c.seq).is_none_or(|b| {
                    b.runs != c.count
                        || !RunningStates::RUNNING_OR_PAUSED.has(b.state)
                        || b.has(flag::STOPPING | request::ABORT)
                        || (!run.by_tick && abort_all_posted)
                }) =>
            {
                Err(Error::NotRunning(c.seq))
            }
            _ => Ok(self.changes),
        }
    }

    /// Schedules a new run of `id` from now, before its commit: its clock (and timeout), its
    /// lane, no pause in force (the outcome stays the last finished run's, which a join of
    /// that run may still collect, and so does its last exception until the commit: a
    /// start refused after this leaves it). Only for a sequence that may
    /// start ([`ControlBlock::may_start`]; else [`Error::AlreadyRunning`]): the tick
    /// neither scans it nor walks through these fields, and the caller link, flags and
    /// state, which it does read, change in the commit. The checks of the start came
    /// sections before: meanwhile the tick may have started the sequence as an exception
    /// sequence, and its lane ended it.
    fn schedule_new(&mut self, id: SeqId, lane: u8) -> Result<Scheduled, Error> {
        let b = self.block_mut(id).ok_or(Error::UnknownSequence(id))?;
        if !b.may_start() {
            return Err(Error::AlreadyRunning(id));
        }
        let from = b.state;
        let armed = b.timeout != 0;
        b.lane = lane;
        b.lift_pauses();
        b.restarts_made = 0;
        self.start_clock(id);
        // Its lane may be another one now.
        self.polling.forget_woken();
        Ok(Scheduled { from, armed })
    }

    /// Schedules a restart of `run` from now: its clock (and timeout) starts again, with no
    /// pause in force. `None` unless `run` is its sequence's current run and `Restarting`
    /// (a later run restarts in its own time), and the tick is not to abort it (its abort
    /// requested, an abort-all posted: a restart its lane has not taken up is not begun,
    /// semantics 8).
    fn schedule_restart(&mut self, run: RunId, abort_all_posted: bool) -> Option<Scheduled> {
        let b = self.block_mut(run.seq).filter(|b| {
            b.runs == run.count
                && b.state == RunningState::Restarting
                && !stops_soon(b, abort_all_posted)
        })?;
        b.lift_pauses();
        let armed = b.timeout != 0;
        self.start_clock(run.seq);
        Some(Scheduled {
            from: RunningState::Restarting,
            armed,
        })
    }

    /// After the schedule, before the commit, for a sequence that is not monitored
    /// (else nothing): the sets the tick reads of a monitored sequence (fresh, no exception,
    /// not waiting for a poll, the timeout `armed` or not). The mark of an exception is of
    /// a run under way: a stopped run's `exception_is_active` comes from its last cause.
    fn prepare(&mut self, id: SeqId, armed: bool) {
        if RunningStates::RUNNING_OR_PAUSED.has(self.state_of(id)) {
            return;
        }
        self.sets.put(Set::Fresh, id, true);
        self.sets.put(Set::Armed, id, armed);
        self.sets.put(Set::Excepting, id, false);
        // A stale `poll_due` is cleared when the run first waits for a poll.
        self.sets.put(Set::PollWait, id, false);
    }

    /// For [`class_busy`]: whether a member of `id`'s polling class whose run was under way
    /// at the tick's last fold (`Restarting` too: the restart of the class's only member
    /// keeps its grid) has not changed since (then its run is still under way and the
    /// class keeps its grid), and, if none, the members that changed since the fold, whose
    /// states must be looked at.
    fn class_activity(&self, id: SeqId) -> ClassActivity<B> {
        let class = self.block(id).map_or(0, |b| b.class);
        let members = self.polling.classes.members(class);
        let mut changed = SeqSet::EMPTY;
        let words = self
            .sets
            .words(Set::Live)
            .with(self.sets.words(Set::Changed));
        for w in words {
            let live = self.sets.word(Set::Live, w).and(members.word(w));
            let since = self.sets.word(Set::Changed, w);
            if !live.minus(since).is_empty() {
                return ClassActivity::UnderWay;
            }
            changed.insert_all(members.word(w).and(since));
        }
        ClassActivity::Changed(changed)
    }

    /// After the schedule, before the commit, for a start into a busy class (see
    /// [`class_busy`]): the tick scans by the first poll of `id`'s run, the class's next
    /// poll. Only if nothing changed since the start opened when the count of changes was
    /// `seen`: else the class's activity may be stale (a member started meanwhile, on the
    /// grid a new one would move back), and the commit, which compares the same count,
    /// fails and schedules again.
    fn join_grid(&mut self, id: SeqId, seen: u32) {
        if self.changes != seen {
            return;
        }
        let now = Stamp::of(self.now);
        let class = self.block(id).map_or(0, |b| b.class);
        let next = self.polling.classes.next_poll(class, now);
        self.polling.next_due = now.first_of(next, self.polling.next_due);
    }

    /// As [`join_grid`](Self::join_grid), for a start into an idle class: the class starts
    /// its grid, the first poll one period from now.
    fn start_grid(&mut self, id: SeqId, seen: u32) {
        if self.changes != seen {
            return;
        }
        let now = Stamp::of(self.now);
        let class = self.block(id).map_or(0, |b| b.class);
        let next = self.polling.classes.start_grid(class, now);
        self.polling.stale &= !(1 << (class & 7));
        self.polling.next_due = now.first_of(next, self.polling.next_due);
    }

    /// The commit of a new run: `change` (validated and scheduled when the count of changes
    /// was `seen`) with the run's caller and flags, which also clear the requests and the
    /// pending behaviour, and the run counted: the new run's id. A run's future, a join and
    /// a request name the run they act for by this count, so only a committed run counts.
    /// `None`: a tick or a transition came since (it may have moved the time, rescanned
    /// without the new run, or stopped the run's caller), nothing changed, schedule again.
    #[inline]
    fn commit_new(&mut self, change: &StateChange, seen: u32, run: &NewRun) -> Option<RunId> {
        if self.changes != seen {
            return None;
        }
        let b = self.transition(change)?;
        b.caller = Link::to(run.caller.map(|c| c.seq));
        b.flags = run.flags;
        b.runs = b.runs.wrapping_add(1);
        // The last run's exception is named until here, not only until the schedule: a
        // start refused after its schedule leaves `active_exception` as it was.
        b.active_exception = None;
        Some(RunId {
            seq: change.sequence,
            count: b.runs,
        })
    }

    /// After the commit of `run`, begun blocking by `caller`: if the caller is paused (the
    /// tick paused it while its action ran on to this start), the run is paused with it,
    /// its clock stopped, as the pause would have done to a run begun before it; the
    /// caller's resume resumes it.
    fn pause_with_caller(&mut self, run: RunId, caller: SeqId) {
        if self.state_of(caller) != RunningState::Paused
            || self.block(run.seq).is_none_or(|b| b.runs != run.count)
        {
            return;
        }
        let change = StateChange::new(
            run.seq,
            RunningState::Running,
            RunningState::Paused,
            Cause::Pause,
        );
        if self.transition(&change).is_some() {
            self.stop_clock(run.seq);
        }
    }

    /// After the commit of a restart of `run`: if the caller it blocks (in the same lane)
    /// is paused, the run is paused with it, as [`pause_with_caller`](Self::pause_with_caller)
    /// pauses a run begun blocking by a paused caller. A pause walk passes over a
    /// `Restarting` sequence, and its lane takes the restart up below its paused caller.
    fn pause_with_blocking_caller(&mut self, run: RunId) {
        let Some(b) = self.block(run.seq) else {
            return;
        };
        let (lane, caller) = (b.lane, b.caller.get());
        if let Some(c) = caller.filter(|&c| self.block(c).is_some_and(|c| c.lane == lane)) {
            self.pause_with_caller(run, c);
        }
    }

    /// The commit of a restart: as [`commit_new`](Self::commit_new), keeping the run's
    /// caller and flags; the behaviour it was waiting to apply is dropped, with a credit of
    /// its exception sequence's end, and its mark (`ControlBlock::end_round`).
    #[inline(never)]
    fn commit_restart(&mut self, change: &StateChange, seen: u32) -> bool {
        if self.changes != seen {
            return false;
        }
        let Some(b) = self.transition(change) else {
            return false;
        };
        b.end_round();
        true
    }
}

/// The checks of a start of `id` (blocking in its caller's lane, or in its own lane) in
/// the order a start in one piece would fail them, and the cut of a link to an old run of
/// `id` among the caller's callers. Returns the new run's lane, caller and flags. The
/// cut comes after every check the start's open makes ([`State::open_start`]: a starter
/// that may start nothing more, a closed lane, an abort-all): a start refused for what
/// was so at its checks cuts nothing. (One refused for what changed between its checks
/// and its commit, by a tick or a lane of higher priority, has cut it.)
fn admit<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    mode: Mode,
    inbox: &AtomicU8,
) -> Result<NewRun, Error> {
    s.section(|s| s.check_start(id, mode))?;
    let lane = match mode {
        // A blocking run runs in its caller's lane.
        Mode::Blocking { caller, .. } => s.section(|s| s.lane_slot(caller.seq)),
        // A sequence has a lane once one was declared for it (`rtseq::lane`,
        // `Handle::declare_lane`).
        Mode::NonBlocking { .. }
        | Mode::MainBy { .. }
        | Mode::Exception { .. }
        | Mode::BesidePause { .. } => match lane_slot_of(s, id) {
            Some(lane) => lane,
            None => return Err(s.section(|s| s.no_lane(id))),
        },
    };
    let run = NewRun {
        seq: id,
        lane,
        caller: mode.caller(),
        starter: mode.starter(),
        flags: mode.flags(),
        by_tick: mode.by_tick(),
    };
    let posted = abort_all_posted(inbox);
    s.section(|s| s.open_start(&run, posted))?;
    // `caller` is the starting sequence itself (a context's or an exception's owner):
    // registered by construction.
    if let Some(c) = run.caller {
        if usize::from(cut_and_depth(s, id, c.seq)) >= MAX_DEPTH {
            return Err(Error::CallerDepthExceeded(id));
        }
    }
    Ok(run)
}

/// Whether the polling class of `id` has a member whose run is under way: one live
/// (`Running`, `Paused`) at the tick's last fold and unchanged since, or one that changed
/// since (started, or ended in the same lane poll as this start) whose state is under way
/// (`Running`, `Paused`, or between them: `Restarting`, `Aborting`). A start of `id` then
/// joins the class's grid; else the class starts a new one. One section for the members
/// that did not change, then one per member that did; a transition in between makes the
/// commit schedule again.
fn class_busy<
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
    match s.section(|s| s.class_activity(id)) {
        ClassActivity::UnderWay => true,
        ClassActivity::Changed(changed) => changed
            .into_iter()
            .any(|m| s.section(|s| RunningStates::LIVE.has(s.state_of(m)))),
    }
}

/// What a start finds of its polling class's members ([`State::class_activity`]).
enum ClassActivity<const B: usize> {
    /// One live at the tick's last fold has not changed since: its run is under way.
    UnderWay,
    /// None has: these changed since the fold, and their states tell.
    Changed(SeqSet<B>),
}

/// Schedules the first poll of a run of `id` starting now (see [`class_busy`]), if nothing
/// changed since `seen`.
fn schedule_first_poll<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    seen: u32,
) {
    if class_busy(s, id) {
        s.section(|s| s.join_grid(id, seen));
    } else {
        s.section(|s| s.start_grid(id, seen));
    }
}

/// Schedules and commits a new run of `id` from a state that is not active; again if a
/// tick ran in between (it may have rescanned without the new run, or changed its state
/// or its caller's: the commit re-checks them). Returns the new run; `Err` (nothing
/// changed) when the states do not allow it.
fn launch<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    id: SeqId,
    run: NewRun,
    cause: Cause,
    inbox: &AtomicU8,
) -> Result<RunId, Error> {
    loop {
        let posted = abort_all_posted(inbox);
        let seen = s.section(|s| s.open_start(&run, posted))?;
        let at = s.section(|s| s.schedule_new(id, run.lane))?;
        s.section(|s| s.prepare(id, at.armed));
        schedule_first_poll(s, id, seen);
        // Before the link is set: a teardown in between visits one sequence too many
        // (it is not active yet), never one too few. Not over a start that won meanwhile.
        s.section(|s| {
            if s.block(id).is_some_and(ControlBlock::may_start) {
                s.sets.put(Set::Called, id, run.caller.is_some());
            }
        });
        let change = StateChange::new(id, at.from, RunningState::Running, cause);
        if let Some(new) = s.section(|s| s.commit_new(&change, seen, &run)) {
            // Counted for the teardowns that may walk meanwhile (`State::runs_begun`). One
            // that walks between the commit and the count places the new run already: it
            // is committed, with its caller link.
            s.section(|s| s.runs_begun = s.runs_begun.wrapping_add(1));
            return Ok(new);
        }
        // In one section the loop never repeats (nothing changes between the checks and
        // the commit).
        if S::ONE_SECTION {
            return Err(Error::AlreadyRunning(id));
        }
    }
}

/// Schedules and commits a `Restarting` sequence's run again, in its lane with its caller
/// and flags as they are. Only from `Restarting`, in the same run, and not while the tick
/// is to abort it: an abort requested or an abort-all posted since the lane saw its
/// clearance stands (an abort request moves the count of changes, so a commit it came
/// before is scheduled again, and refused; an abort-all posted after the schedule's
/// section comes after the restart, as one posted during an end's last section comes
/// after the end).
fn relaunch<
    C,
    S: Sections<C, N, T, W, B>,
    const N: usize,
    const T: usize,
    const W: usize,
    const B: usize,
>(
    s: &mut S,
    run: RunId,
    inbox: &AtomicU8,
) {
    let id = run.seq;
    loop {
        let seen = s.section(|s| s.changes);
        let Some(at) = s.section(|s| s.schedule_restart(run, abort_all_posted(inbox))) else {
            return;
        };
        s.section(|s| s.prepare(id, at.armed));
        schedule_first_poll(s, id, seen);
        let change = StateChange::new(id, at.from, RunningState::Running, Cause::Restart);
        let done = s.section(|s| s.commit_restart(&change, seen));
        if done {
            // Counted like a run begun: a pause walk that passed over the `Restarting`
            // sequence and has not paused its caller yet walks again.
            s.section(|s| {
                s.runs_begun = s.runs_begun.wrapping_add(1);
                s.pause_with_blocking_caller(run);
            });
        }
        if done || S::ONE_SECTION {
            return;
        }
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Starts `id` as `mode` says (blocking in its caller's lane, or in its own lane): the
    /// checks, the schedule and commit and, in its lane, the wake-up. Returns the new run.
    /// With a coarse lock two sections: the checks walk the callers, which grows with the
    /// depth.
    pub(crate) fn begin(&self, id: SeqId, mode: Mode, cause: Cause) -> Result<RunId, Error> {
        let inbox = &self.safety.inbox;
        let run = in_sections!(self, |s| admit(s, id, mode, inbox))?;
        let (new, lane) = in_sections!(self, |s| {
            let new = launch(s, id, run, cause, inbox)?;
            let lane = match mode {
                Mode::NonBlocking { .. }
                | Mode::MainBy { .. }
                | Mode::Exception { .. }
                | Mode::BesidePause { .. } => s.section(|s| s.lane_of(id)),
                Mode::Blocking { caller, .. } => {
                    s.section(|s| s.pause_with_caller(new, caller.seq));
                    LaneSet::EMPTY
                }
            };
            Ok((new, lane))
        })?;
        self.wake_lanes(lane);
        Ok(new)
    }

    /// `run` of a `Restarting` sequence runs again from its pre-condition.
    pub(crate) fn restart(&self, run: RunId) {
        let inbox = &self.safety.inbox;
        in_sections!(self, |s| relaunch(s, run, inbox));
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::sequencer::control_block::NO_LANE;
    use crate::sequencer::port::Port;
    use crate::sequencer::sections::EachStep;
    use crate::{Behaviour, Instant, Monitor, Monitors, Outcome, SeqConfig};

    use crate::sequencer::sections::tests::{registered, Preempted, S};

    /// An inbox without an abort-all.
    static NO_INBOX: AtomicU8 = AtomicU8::new(0);

    /// A start of `id` with no lane, by `caller` (none: a main sequence) in the run
    /// [`registered`] gave it (count 0).
    fn new_run(id: SeqId, caller: Option<SeqId>) -> NewRun {
        let caller = caller.map(|seq| RunId { seq, count: 0 });
        NewRun {
            seq: id,
            lane: NO_LANE,
            caller,
            starter: caller,
            flags: 0,
            by_tick: false,
        }
    }

    /// The first run of `id`.
    fn first_run(id: SeqId) -> RunId {
        RunId { seq: id, count: 1 }
    }

    /// Sequence 0 running, sequence 1 registered; `between` runs before section `at` of a
    /// start of 1 by 0. Returns the start's result, the sections it took, 1's state.
    fn start_preempted(
        at: usize,
        between: impl FnOnce(&mut S),
    ) -> (Result<RunId, Error>, usize, RunningState) {
        let (caller, id) = (SeqId(0), SeqId(1));
        let mut state = registered(2, &[caller]);
        let mut s = Preempted::new(&mut state, at, between);
        let new = new_run(id, Some(caller));
        let result = launch(&mut s, id, new, Cause::Start, &NO_INBOX);
        let taken = s.taken;
        (result, taken, state.state_of(id))
    }

    /// The tick aborts a `Restarting` sequence before its lane runs it again (an abort-all
    /// between the lane's clearance and its restart): the abort stands.
    #[test]
    fn a_restart_after_an_abort_leaves_the_sequence_aborted() {
        let id = SeqId(0);
        let mut state = registered(1, &[id]);
        let restart = StateChange::new(
            id,
            RunningState::Running,
            RunningState::Restarting,
            Cause::Restart,
        );
        assert!(state.transition(&restart).is_some());
        let mut s = Preempted::new(&mut state, 0, |s: &mut S| {
            for (from, to) in [
                (RunningState::Restarting, RunningState::Aborting),
                (RunningState::Aborting, RunningState::Aborted),
            ] {
                let change = StateChange::new(id, from, to, Cause::AbortAll);
                assert!(s.transition(&change).is_some());
            }
        });
        relaunch(&mut s, RunId { seq: id, count: 0 }, &NO_INBOX);
        assert_eq!(state.state_of(id), RunningState::Aborted);
    }

    /// Sequence 0 was aborted and started again by a lane of higher priority (run 1)
    /// before its lane unwound the old run (run 0), which then sees `Restarting`: the old
    /// run's restart leaves the new run alone.
    #[test]
    fn a_restart_by_an_old_run_leaves_the_new_run_alone() {
        let id = SeqId(0);
        let mut state = registered(1, &[id]);
        if let Some(b) = state.block_mut(id) {
            b.runs = 1;
        }
        let restart = StateChange::new(
            id,
            RunningState::Running,
            RunningState::Restarting,
            Cause::Restart,
        );
        assert!(state.transition(&restart).is_some());
        let mut s = Preempted::new(&mut state, usize::MAX, |_: &mut S| {});
        relaunch(&mut s, RunId { seq: id, count: 0 }, &NO_INBOX);
        assert_eq!(state.state_of(id), RunningState::Restarting);
    }

    /// A start of 1 by 0 that wins between the schedule and the link of a start of 1
    /// without a caller (by a lane of higher priority): the loser's link does not erase the
    /// winner's, so a teardown of 0 still finds 1 below it.
    #[test]
    fn a_start_that_loses_leaves_the_winners_link() {
        let (caller, id) = (SeqId(0), SeqId(1));
        let mut state = registered(2, &[caller]);
        let mut s = Preempted::new(&mut state, PASS - 2, |s: &mut S| {
            let won = new_run(id, Some(caller));
            assert_eq!(
                launch(s, id, won, Cause::Start, &NO_INBOX),
                Ok(first_run(id))
            );
        });
        let lost = new_run(id, None);
        assert_eq!(
            launch(&mut s, id, lost, Cause::Start, &NO_INBOX),
            Err(Error::AlreadyRunning(id))
        );
        assert!(state.sets.has(Set::Called, id));
        assert_eq!(
            state.block(id).map(|b| b.caller),
            Some(Link::to(Some(caller)))
        );
    }

    /// Sequence 0 ran and started 1, which started 2, and 0 ended; 2 starts 0 blocking,
    /// and `between` runs before section `at` of the start. Returns the start's result and
    /// the caller links of 1 and 0 after it.
    fn start_of_an_old_caller(
        at: usize,
        between: impl FnOnce(&mut S),
    ) -> (Result<RunId, Error>, Option<SeqId>, Option<SeqId>) {
        let [old, child, caller] = [0, 1, 2].map(SeqId);
        let mut state = registered(3, &[old, child, caller]);
        let end = StateChange::new(
            old,
            RunningState::Running,
            RunningState::Terminated,
            Cause::Completed,
        );
        assert!(state.transition(&end).is_some());
        for (id, up) in [(child, old), (caller, child)] {
            if let Some(b) = state.block_mut(id) {
                b.caller = Link::to(Some(up));
            }
            state.sets.insert(Set::Called, id);
        }
        let mode = Mode::Blocking {
            caller: RunId {
                seq: caller,
                count: 0,
            },
            maker: state.tag,
        };
        let mut s = Preempted::new(&mut state, at, between);
        let result = admit(&mut s, old, mode, &NO_INBOX)
            .and_then(|run| launch(&mut s, old, run, Cause::Start, &NO_INBOX));
        let link = |id: SeqId| state.block(id).and_then(|b| b.caller.get());
        (result, link(child), link(old))
    }

    /// The sections of [`admit`] before its walk of the caller's links: the checks, the
    /// lane, the starter's.
    const CHECKS: usize = 3;

    /// A sequence started again below a child of its old run: the child's link to the old
    /// run is cut, so the links form no cycle.
    #[test]
    fn a_start_below_a_child_of_an_old_run_cuts_the_childs_link() {
        assert_eq!(
            start_of_an_old_caller(usize::MAX, |_| {}),
            (
                Ok(RunId {
                    seq: SeqId(0),
                    count: 1
                }),
                None,
                Some(SeqId(2))
            )
        );
    }

    /// The same start by a caller that was stopped before it (the tick stopped it while
    /// its action ran on to the start): refused, it cuts nothing, so the child's caller
    /// behaviours still act on sequence 0.
    #[test]
    fn a_refused_start_below_a_child_of_an_old_run_leaves_the_childs_link() {
        let abort = StateChange::new(
            SeqId(2),
            RunningState::Running,
            RunningState::Aborting,
            Cause::Dropped,
        );
        assert_eq!(
            start_of_an_old_caller(CHECKS - 1, |s| assert!(s.transition(&abort).is_some())),
            (Err(Error::NotRunning(SeqId(2))), Some(SeqId(0)), None)
        );
    }

    /// Sequences 0, 1, 2 in one polling class, 0 running as of the tick's last fold and
    /// then moved by `then` (`None`: left as it is). Returns whether a start of 1 finds the
    /// class busy, and the sections that took.
    fn class_of_three(then: Option<RunningState>) -> (bool, usize) {
        let mut state = registered(3, &[SeqId(0)]);
        for id in 0..3 {
            assert!(state.polling.classes.join(SeqId(id), 1_000).is_ok());
        }
        while let Some(id) = state.sets.pop(Set::Changed) {
            state.fold(id);
        }
        if let Some(to) = then {
            let change = StateChange::new(SeqId(0), RunningState::Running, to, Cause::Start);
            assert!(state.transition(&change).is_some());
        }
        let mut s = Preempted::new(&mut state, usize::MAX, |_| {});
        let busy = class_busy(&mut s, SeqId(1));
        (busy, s.taken)
    }

    /// A member live at the fold and unchanged since keeps the grid (one section); one
    /// that changed is looked at (a section more): still under way it keeps the grid,
    /// ended (in the same lane poll as the start) it does not.
    #[test]
    fn a_class_is_busy_while_a_member_live_at_the_fold_is_under_way() {
        assert_eq!(class_of_three(None), (true, 1));
        assert_eq!(class_of_three(Some(RunningState::Paused)), (true, 2));
        assert_eq!(class_of_three(Some(RunningState::Restarting)), (true, 2));
        assert_eq!(class_of_three(Some(RunningState::Terminated)), (false, 2));
    }

    /// The sections of one pass: open, schedule, prepare, the class's activity (no member
    /// changed since the fold), due, link, commit.
    const PASS: usize = 7;
    /// After a commit: the section that counts the run begun.
    const COUNTED: usize = 1;

    #[test]
    fn an_undisturbed_start_commits_in_one_pass() {
        let (result, taken, state) = start_preempted(usize::MAX, |_| {});
        assert_eq!(
            (result, taken, state),
            (
                Ok(first_run(SeqId(1))),
                PASS + COUNTED,
                RunningState::Running
            )
        );
    }

    /// A tick at the time of the last one moves no clock, but may have rescanned without
    /// the new run: the commit sees the count of changes move and schedules again.
    #[test]
    fn a_tick_between_the_schedule_and_the_commit_makes_the_start_schedule_again() {
        let (result, taken, state) = start_preempted(PASS - 1, |s| {
            s.changes = s.changes.wrapping_add(1);
        });
        assert_eq!(
            (result, taken, state),
            (
                Ok(first_run(SeqId(1))),
                2 * PASS + COUNTED,
                RunningState::Running
            )
        );
    }

    /// A start scheduled twice is one run: joins and requests pin a run by its count.
    #[test]
    fn a_start_scheduled_again_counts_one_run() {
        let id = SeqId(1);
        let mut state = registered(2, &[]);
        let mut s = Preempted::new(&mut state, PASS - 1, |s: &mut S| {
            s.changes = s.changes.wrapping_add(1);
        });
        let new = new_run(id, None);
        assert_eq!(
            launch(&mut s, id, new, Cause::Start, &NO_INBOX),
            Ok(first_run(id))
        );
        assert_eq!(s.taken, 2 * PASS + COUNTED);
        assert_eq!(state.block(id).map(|b| b.runs), Some(1));
    }

    /// The caller's run (run 0) was aborted and the caller started again (run 1) before
    /// the start (by a lane of higher priority): the old run's action starts nothing.
    #[test]
    fn a_caller_whose_run_was_replaced_starts_nothing() {
        let (result, taken, state) = start_preempted(0, |s| {
            if let Some(b) = s.block_mut(SeqId(0)) {
                b.runs = 1;
            }
        });
        assert_eq!(
            (result, taken, state),
            (Err(Error::NotRunning(SeqId(0))), 1, RunningState::Idle)
        );
    }

    /// The caller is aborted after the start's first look at it (by a lane of higher
    /// priority that dropped a run above it): the start is refused and changes nothing.
    #[test]
    fn a_caller_stopped_before_the_commit_starts_nothing() {
        let (result, taken, state) = start_preempted(PASS - 1, |s| {
            let abort = StateChange::new(
                SeqId(0),
                RunningState::Running,
                RunningState::Aborting,
                Cause::Dropped,
            );
            assert!(s.transition(&abort).is_some());
        });
        assert_eq!(
            (result, taken, state),
            (
                Err(Error::NotRunning(SeqId(0))),
                PASS + 1,
                RunningState::Idle
            )
        );
    }

    /// A lane L (a `Handle` or `Cx::start` of E) checks its start of E while E is idle
    /// (`admit`, its first sections). Before L's schedule and commit (its next sections) the
    /// tick preempts it: O's monitor fires and starts E as O's exception sequence (O's
    /// `AbortOwner` waits for E's end), and E's lane, of higher priority than L, runs E to
    /// its end. L goes on. E is O's until the tick has reported its end: L's
    /// start must be refused (`AlreadyRunning`), and the next tick must report E's end to
    /// O and abort O. (A start of E as a main sequence, without `HANDLES_EXCEPTION`, would
    /// take E from O: its end would never be reported, and O would stay held for good.)
    #[test]
    fn a_start_checked_before_the_tick_ran_the_exception_sequence_does_not_take_it_from_its_owner()
    {
        let seq: Sequencer<(), 4> = Sequencer::new();
        let [o, e] = ["O", "E"].map(|n| seq.register(SeqConfig::new(n)).unwrap());
        for id in [o, e] {
            seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        }
        seq.sequence_by_id(o).unwrap().start().unwrap();
        // L: the checks of its start of E (E idle).
        let checked = admit(
            &mut EachStep(&seq),
            e,
            Mode::NonBlocking { caller: None },
            &seq.safety.inbox,
        )
        .unwrap();
        // The tick preempts L: O's monitor fires, E starts for O.
        let mut fault = |_: &(), _: Instant| true;
        let mut monitors = Monitors::<(), 1>::new();
        monitors
            .add(
                o,
                Monitor::new("fault", &mut fault, Behaviour::AbortOwner).exception(e),
            )
            .unwrap();
        seq.tick(Instant::from_ticks(1_000), &(), &mut monitors)
            .unwrap();
        assert!(seq.with(|s| s
            .block(e)
            .is_some_and(|b| b.has(flag::HANDLES_EXCEPTION) && b.caller.get() == Some(o))));
        // E's lane (above L) takes the start and E completes.
        let waker = core::task::Waker::noop();
        let run = Port::take_start(&seq, e, seq.tag(), waker).unwrap();
        assert!(Port::end(&seq, run, Outcome::Completed));
        Port::finished(&seq, run);
        // L goes on: its schedule and commit.
        let late = launch(
            &mut EachStep(&seq),
            e,
            checked,
            Cause::Start,
            &seq.safety.inbox,
        );
        let state = |id: SeqId| seq.with(|s| s.state_of(id));
        assert_eq!(
            (late, state(e)),
            (Err(Error::AlreadyRunning(e)), RunningState::Terminated)
        );
        // The next tick reports E's end to O: O's behaviour, abort.
        for ms in 2..5 {
            seq.tick(Instant::from_ticks(ms * 1_000), &(), &mut monitors)
                .unwrap();
        }
        assert_eq!(state(o), RunningState::Aborted);
    }
}
