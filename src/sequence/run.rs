//! A run of a sequence or step: the seed's `actionFramework` as a state machine.
//!
//! ```text
//!                                      first polled in a condition: Begin ──► Done, Err
//!                                      (polled in a condition later: it does not move)
//!   lane:  Idle ──take_start──┐        blocking:  Begin ──start_blocking──┐  (refused: HandOver)
//!                             ▼                                           ▼
//!                 ┌──► PreCondition ◄──────────────────── restart ─────────────────┐
//!                 │      │ clearance Go, pre-condition true                         │
//!                 │      ▼                                                          │
//!                 │    Action  ── clearance Go: advance the action ──┐              │
//!                 │      │ the action completed       │ (Pending)    │              │
//!                 │      │             the action failed ──► Ending ── end(Failed)
//!                 │      ▼                                                          │
//!                 │    ActionDone ── set_poll_wait ──► ExitCondition ◄──────┐       │
//!                 │                                      │ false            │ Go    │
//!                 │                                      ▼                  │       │
//!                 │                                    AwaitPoll ── due_poll┘       │
//!                 │                                                                 │
//!                 │  pre-condition false: end(Skipped); exit condition true:        │
//!                 │  end(Completed) (refused while held: Ending keeps the outcome); │
//!                 │  clearance Aborted at any await point ──► Ended                 │
//!                 │  clearance Restart at any await point ──────────────────────────┘
//!                 │
//!   lane: ◄─ Idle ◄── Ended (finished: outcome, joiners) ──► HandOver ──► Done
//!                                                   blocking: the caller's clearance Go,
//!                                                   then the result is handed over
//! ```
//!
//! | transition | function |
//! |---|---|
//! | Idle → PreCondition | [`Port::take_start`] |
//! | Begin → PreCondition / HandOver (refused) | [`Port::start_blocking`] |
//! | Begin → Done | none: first polled from a condition ([`Cx::acting`]), refused ([`Run::looked_at`]) |
//! | PreCondition → Action | [`Port::clearance`], the body's pre-condition |
//! | Action → ActionDone | [`Port::clearance`], the body's action (`Ok`) |
//! | Action → Ending | [`Port::clearance`], the body's action (`Err`) |
//! | PreCondition / ExitCondition → Ending | [`Port::end`] refused while the run holds (paused, or held with a caller) |
//! | Ending → Ended | [`Port::clearance`] `Go`, then [`Port::end`] with the kept outcome |
//! | ActionDone → ExitCondition | [`Port::set_poll_wait`], then [`Port::clearance`] |
//! | ExitCondition → AwaitPoll | the body's exit condition (false) |
//! | AwaitPoll → ExitCondition | [`Port::due_poll`] |
//! | … → Ended | [`Port::end`] (completed, skipped, failed), or a clearance `Aborted` |
//! | … → PreCondition | a clearance `Restart`, then [`Port::restart`] |
//! | Ended → Idle / HandOver | [`Port::finished`] |
//! | HandOver → Done | [`Port::clearance_of`] the caller |
//!
//! A lane keeps the waker it is polled with at each of its await points
//! ([`Port::take_start`], [`Port::clearance`], [`Port::due_poll`]): the lane's wake-ups go
//! there. A blocking run, and every future of an action's [`Cx`], is polled inside that
//! poll, after the lane kept its waker, and only reads ([`Port::clearance_of`],
//! [`Port::due_poll_of`]): a future polled elsewhere with another waker (from a condition
//! method) cannot take the lane's wake-ups.
//!
//! A held sequence (paused, or handling an exception) stays at its await point; an aborted
//! one never runs another line of its action (sticky abort). A run whose future is dropped
//! before it ended is abandoned ([`Port::abandon`]): aborted with its sub-sequences; a lane
//! dropped in `Idle` gives up a start made but not taken ([`Port::abandon_start`]).
//!
//! Every port call of a run names the run it drives (a [`RunId`], taken at its start and
//! kept in its [`Cx`]): a lane of higher priority may start the sequence again after an
//! abort, before this future has unwound the aborted run, and the old run must neither
//! go on under the new run's clearance nor end or restart the new run.

use core::cell::Cell;
use core::task::{Context, Poll};

use crate::model::id::RunId;
use crate::sequence::erased::ErasedBody;
use crate::sequence::SeqHead;
use crate::sequencer::clearance::Clearance;
use crate::sequencer::port::Port;
use crate::{Cx, Done, Error, Failure, Outcome};

/// Where a run stands; once its outcome is decided, with the outcome.
#[derive(Clone, Copy, Debug)]
enum Stage {
    /// A lane between runs (or before its first): wait for a non-blocking start.
    Idle,
    /// A blocking start's first poll: start the child, if the poll is the caller's
    /// action's (else refused: [`Error::OutsideAction`]).
    Begin,
    /// At the await point before the pre-condition: the start, or after a restart.
    PreCondition,
    /// The action runs.
    Action,
    /// The action completed: start polling the exit condition.
    ActionDone,
    /// The run's outcome is decided (its action returned `Err`; or its pre- or exit
    /// condition decided while the run held, so its end was refused): end the run with it
    /// once it may go on, without asking the condition again.
    Ending(Outcome),
    /// Check the exit condition now.
    ExitCondition,
    /// Wait for the next due poll of the exit condition.
    AwaitPoll,
    /// The run ended with this outcome: report it.
    Ended(Outcome),
    /// A blocking run ended, or its start was refused (`Failed(NotStarted)`, which its
    /// caller gets as it would a failed child's): wait until the caller may advance to
    /// hand the outcome over.
    HandOver(Outcome),
    /// The result was handed over (or the start refused); a poll after that gets it again.
    Done(Outcome),
}

/// Where [`Run::drive`] left the run.
enum Driven {
    /// At the action: advance it now.
    Act,
    /// It must wait for a wake-up.
    Wait,
    /// A blocking run is done: its result, in its stage, goes to the caller's action that
    /// awaits it.
    Done,
}

/// The body-independent part of a run: the sequence's context, what drives the run (a
/// lane, or the caller that waits for its result) and where the run stands. Generic only
/// over the control system `C`: one copy serves every sequence and step type, started
/// blocking or in a lane.
pub(crate) struct Run<'a, C> {
    pub(crate) cx: Cx<'a, C>,
    driver: Driver<'a, C>,
    stage: Cell<Stage>,
}

/// What drives a run: the sequence's lane, or the future of a blocking start.
enum Driver<'a, C> {
    /// The lane: takes every non-blocking start, runs it, then waits for the next.
    Lane,
    /// A blocking start by the caller whose context this is, which waits for the outcome.
    Blocking { caller: &'a Cx<'a, C> },
}

impl<'a, C> Run<'a, C> {
    /// A blocking start of `cx`'s sequence by `caller`, starting it at the first poll.
    pub(crate) fn blocking(cx: Cx<'a, C>, caller: &'a Cx<'a, C>) -> Self {
        Run {
            cx,
            driver: Driver::Blocking { caller },
            stage: Cell::new(Stage::Begin),
        }
    }

    /// The lane of `cx`'s sequence: runs it every time it is started non-blocking.
    pub(crate) fn lane(cx: Cx<'a, C>) -> Self {
        Run {
            cx,
            driver: Driver::Lane,
            stage: Cell::new(Stage::Idle),
        }
    }

    fn port(&self) -> &'a dyn Port<C> {
        self.cx.port()
    }

    /// The run driven now (the last one, between runs).
    fn run(&self) -> RunId {
        self.cx.run_id()
    }

    /// The run ended with `outcome`.
    fn ended(&self, outcome: Outcome) {
        self.stage.set(Stage::Ended(outcome));
    }

    /// Follows a clearance other than `Go` or `Hold` (the seed's exceptions): an abort
    /// ends the run, a restart goes back to the pre-condition.
    fn obey(&self, clearance: Clearance) {
        match clearance {
            Clearance::Go | Clearance::Hold => {}
            Clearance::Aborted(cause) => self.ended(Outcome::Aborted(cause)),
            Clearance::Restart => {
                self.port().restart(self.run());
                self.cx.new_round();
                self.stage.set(Stage::PreCondition);
            }
        }
    }

    /// What this run must do at an await point. A lane keeps the waker it is polled with
    /// first (its wake-ups go there), then reads, so no wake-up in between is lost. A
    /// blocking run is polled inside its caller's action, in the same lane, whose run kept
    /// the waker at the top of this poll: it only reads.
    fn clearance(&self, w: &Context<'_>) -> Clearance {
        match self.driver {
            Driver::Lane => self.port().clearance(self.run(), w.waker()),
            Driver::Blocking { .. } => self.port().clearance_of(self.run()),
        }
    }

    /// As [`clearance`](Self::clearance), for the poll of the exit condition.
    fn due_poll(&self, w: &Context<'_>) -> Clearance {
        match self.driver {
            Driver::Lane => self.port().due_poll(self.run(), w.waker()),
            Driver::Blocking { .. } => self.port().due_poll_of(self.run()),
        }
    }

    /// Ends the run normally with `outcome`; when refused (aborted, restarting or holding
    /// meanwhile) the clearance says what happens instead. A run that holds (paused, or
    /// held with a caller that handles an exception) keeps `outcome` and ends with it once
    /// it may go on ([`Stage::Ending`]): the condition that decided it is not asked
    /// again, so a one-shot event it read is not lost and a skip stays a skip. False when
    /// the outcome is kept for later.
    fn try_end(&self, outcome: Outcome, w: &mut Context<'_>) -> bool {
        if self.port().end(self.run(), outcome) {
            self.ended(outcome);
            return true;
        }
        match self.clearance(w) {
            Clearance::Go | Clearance::Hold => {
                self.stage.set(Stage::Ending(outcome));
                false
            }
            other => {
                self.obey(other);
                true
            }
        }
    }

    /// Runs the stages up to the action, until the run must wait, or until a blocking
    /// run hands its result over.
    fn drive(&self, w: &mut Context<'_>, head: &SeqHead, body: &mut ErasedBody<'_, C>) -> Driven {
        let (port, id) = (self.port(), self.cx.id());
        loop {
            match self.stage.get() {
                Stage::Idle => {
                    let Some(run) = port.take_start(id, head.maker, w.waker()) else {
                        return Driven::Wait;
                    };
                    self.cx.enter(run);
                    self.stage.set(Stage::PreCondition);
                }
                Stage::Begin => match self.driver {
                    Driver::Blocking { caller } => {
                        match port.start_blocking(id, head.maker, caller.run_id()) {
                            Ok(run) => {
                                self.cx.enter(run);
                                self.stage.set(Stage::PreCondition);
                            }
                            // Handed over as an end is: never into an action that may
                            // not advance (a tick that stopped its run preempted it).
                            Err(e) => {
                                let refused = Outcome::Failed(Failure::NotStarted(e));
                                self.stage.set(Stage::HandOver(refused));
                            }
                        }
                    }
                    // Only a blocking run begins; a lane begins in `Idle`.
                    Driver::Lane => self.stage.set(Stage::Idle),
                },
                Stage::PreCondition => match self.clearance(w) {
                    Clearance::Go => {
                        if body.pre(&self.cx) {
                            self.stage.set(Stage::Action);
                            return Driven::Act;
                        }
                        let _ = self.try_end(Outcome::Skipped, w);
                    }
                    Clearance::Hold => return Driven::Wait,
                    other => self.obey(other),
                },
                Stage::Action => return Driven::Act,
                // The tick may have stopped or paused the run while its action ran: the
                // exit condition is checked only with the clearance `Go`.
                Stage::ActionDone => {
                    // The poll wait first, then the clearance (as `Cx::wait_until` does): the
                    // check right after the action follows the clearance with no section in
                    // between, so a tick that stops or pauses the run meanwhile comes first.
                    port.set_poll_wait(self.run(), true);
                    match self.clearance(w) {
                        Clearance::Go => self.stage.set(Stage::ExitCondition),
                        Clearance::Hold => return Driven::Wait,
                        other => self.obey(other),
                    }
                }
                Stage::Ending(outcome) => match self.clearance(w) {
                    // Kept again (the end refused though the clearance said `Go`, a
                    // change between the two): wait for the next wake-up, do not spin.
                    Clearance::Go => {
                        if !self.try_end(outcome, w) {
                            return Driven::Wait;
                        }
                    }
                    Clearance::Hold => return Driven::Wait,
                    other => self.obey(other),
                },
                Stage::ExitCondition => {
                    self.stage.set(Stage::AwaitPoll);
                    if !body.exit(&self.cx) {
                        // The due poll was taken and the waker is kept: the next due poll,
                        // or any change of this run, wakes the lane.
                        return Driven::Wait;
                    }
                    let _ = self.try_end(Outcome::Completed, w);
                }
                Stage::AwaitPoll => match self.due_poll(w) {
                    Clearance::Go => self.stage.set(Stage::ExitCondition),
                    Clearance::Hold => return Driven::Wait,
                    other => self.obey(other),
                },
                Stage::Ended(outcome) => {
                    port.finished(self.run());
                    self.stage.set(match self.driver {
                        Driver::Blocking { .. } => Stage::HandOver(outcome),
                        Driver::Lane => Stage::Idle,
                    });
                }
                // Hands over only when the caller may advance: once the caller is aborted
                // or restarting this stays pending and the caller drops it (sticky abort).
                Stage::HandOver(outcome) => {
                    if let Driver::Blocking { caller } = self.driver {
                        if port.clearance_of(caller.run_id()) == Clearance::Go {
                            self.stage.set(Stage::Done(outcome));
                            return Driven::Done;
                        }
                    }
                    return Driven::Wait;
                }
                // Polled again after it returned its result (a misuse of a future): the
                // same result again, rather than waiting for good.
                Stage::Done(_) => return Driven::Done,
            }
        }
    }

    /// Advances the action only with the clearance `Go`: a held sequence does not
    /// advance, an aborted or restarting one never runs another line of it (its action is
    /// dropped). `Ready`: the action is over; `drive` next.
    fn act(&self, w: &mut Context<'_>, body: &mut ErasedBody<'_, C>) -> Poll<()> {
        match self.clearance(w) {
            Clearance::Go => {
                self.cx.begin_action_poll();
                let advanced = body.advance(&self.cx, w);
                self.cx.end_action_poll();
                match advanced {
                    Poll::Pending => return Poll::Pending,
                    Poll::Ready(Ok(())) => self.stage.set(Stage::ActionDone),
                    Poll::Ready(Err(failure)) => {
                        self.stage.set(Stage::Ending(Outcome::Failed(failure)));
                    }
                }
                Poll::Ready(())
            }
            Clearance::Hold => Poll::Pending,
            other => {
                body.drop_action();
                self.obey(other);
                Poll::Ready(())
            }
        }
    }

    /// A blocking run polled outside its caller's action (from a condition, which looks)
    /// does not advance: what it would run (its child's action, the child's own starts)
    /// would run inside the condition. Its first poll there refuses it
    /// ([`Error::OutsideAction`], nothing started); a run that has given its result
    /// gives it again; else it is pending, and advances where its caller's action polls
    /// it next.
    fn looked_at(&self) -> Poll<Result<Done, Failure>> {
        match self.stage.get() {
            Stage::Begin => {
                let refused = Failure::NotStarted(Error::OutsideAction(self.cx.id()));
                self.stage.set(Stage::Done(Outcome::Failed(refused)));
                Poll::Ready(Err(refused))
            }
            _ => self.result(),
        }
    }

    /// A done run's result (pending in any other stage).
    fn result(&self) -> Poll<Result<Done, Failure>> {
        match self.stage.get() {
            Stage::Done(outcome) => Poll::Ready(outcome.done()),
            _ => Poll::Pending,
        }
    }

    /// The future of a lane is dropped (the loser of a `select`, an executor shut down):
    /// if it waits for a start, a start made but not taken is aborted, as in a dropped run
    /// ([`Port::abandon_start`]), and the lane is closed ([`Port::close_lane`]): a later
    /// start would wait for good. `head`, the object's, says whether the object is this
    /// sequencer's. The rest of a dropped run is `Drop`'s, which has no head.
    pub(crate) fn drop_lane(&self, head: &SeqHead) {
        let Driver::Lane = self.driver else {
            return;
        };
        let port = self.port();
        // Closed first: a start from now on is refused (`NoLane`), and one made before is
        // aborted by the abandon (a start that checked the lane before the close is
        // refused at its commit, which the close makes schedule again).
        port.close_lane(self.cx.id(), head.maker);
        if matches!(self.stage.get(), Stage::Idle) {
            port.abandon_start(self.cx.id(), head.maker, self.cx.control());
        }
    }

    /// A run's whole poll; `Ready` with a blocking run's result once it is handed over.
    /// `head` is the sequence object's head (the tag of the sequencer that made it); the
    /// future that borrows the object passes it with the body, so the run itself keeps no
    /// pointer into the object.
    #[inline(never)]
    pub(crate) fn poll(
        &self,
        w: &mut Context<'_>,
        head: &SeqHead,
        mut body: ErasedBody<'_, C>,
    ) -> Poll<Result<Done, Failure>> {
        if let Driver::Blocking { caller } = self.driver {
            if !caller.acting() {
                return self.looked_at();
            }
        }
        loop {
            if matches!(self.stage.get(), Stage::Action) && self.act(w, &mut body).is_pending() {
                return Poll::Pending;
            }
            match self.drive(w, head, &mut body) {
                Driven::Act => {}
                Driven::Wait => return Poll::Pending,
                Driven::Done => return self.result(),
            }
        }
    }
}

/// A run whose future is dropped before it ended (the loser of a `select`, a timeout
/// combinator, a lane shut down) does not leave its sequence running with no one to drive
/// it: it is aborted where it is, with its sub-sequences ([`Cause::Dropped`]). A run that
/// ended but has not reported back yet reports now. A sequence's action future is dropped
/// before its run (see `SequenceRun`), so the runs it holds go first: innermost first.
///
/// [`Cause::Dropped`]: crate::Cause::Dropped
impl<C> Drop for Run<'_, C> {
    fn drop(&mut self) {
        let port = self.port();
        match self.stage.get() {
            Stage::PreCondition
            | Stage::Action
            | Stage::ActionDone
            | Stage::Ending(_)
            | Stage::ExitCondition
            | Stage::AwaitPoll => port.abandon(self.cx.id(), self.cx.control()),
            Stage::Ended(_) => port.finished(self.run()),
            // Not started or over; a lane waiting for a start is `drop_lane`'s.
            Stage::Idle | Stage::Begin | Stage::HandOver(_) | Stage::Done(_) => {}
        }
    }
}
