//! The application's sequences and steps, built on rtseq's [`Sequence`] and [`Step`].
//!
//! ```text
//! main ─┬─ start (non-blocking) ─ status        blink the LED at the rate of the phase
//!       ├─ step power on                         brake off, drive on, safety SWITCH_ON
//!       ├─ run  homing ─┬─ step seek end stop    jog to the negative end stop (off it
//!       │               │                        first if closed; the control system
//!       │               │                        latches the closing edge) (timeout;
//!       │               │                        monitors: following error, + end stop)
//!       │               ├─ step halt             stop, wait for standstill
//!       │               ├─ step set zero         zero at the latched edge
//!       │               └─ step back off         move to +back-off, in position and settled
//!       ├─ run  moves ──┬─ step move  (× N)      in position and settled
//!       │               └─ step dwell (× N)      monitors: following error, end stop, pause
//!       └─ step power off                        drive off, brake on
//!
//! exception sequences (own lanes):
//!   safe stop  ─ step quick stop                 following error (restart the moves, ≤ 3×;
//!                                                in homing: abort homing), homing timeout
//!   feed hold                                    pause button: hold the profile, pause moves
//!   feed resume                                  pause button again: resume both
//! ```
//!
//! Every step is one command to the [`ControlSystem`] followed by an exit condition read from
//! its measurements. Commands are acknowledged by the next control step, so exit conditions
//! start with [`ControlSystem::commands_done`].

use rtseq::{Cx, Done, Failure, Seq, SeqId, Sequence, Step, Wait};

use crate::app::{FaultKind, Travel, MAX_MOVES, NOT_HOMED, TARGET_OUTSIDE_TRAVEL};
use crate::control_system::{ControlSystem, Phase, POSITION_TOLERANCE};
use crate::safety;

type Ctx<'a> = Cx<'a, ControlSystem>;

fn completed(r: Result<Done, Failure>) -> bool {
    r == Ok(Done::Completed)
}

/// A step's own refusal ([`Failure::App`], e.g. a target outside the soft limits) fails the
/// sequence that ran it with the same code, so the caller sees why; any other end of the
/// step (aborted, timed out) leaves the sequence to its exit condition as before.
fn refused(r: Result<Done, Failure>) -> Result<(), Failure> {
    match r {
        Err(f @ Failure::App(_)) => Err(f),
        _ => Ok(()),
    }
}

/// Step: release the brake, enable the drive, and ask the safety system (if connected) for
/// the power-on level. Ends when the drive is enabled (i.e. also permitted by the safety
/// system's drive-enable output).
pub struct PowerOn;

impl Step<ControlSystem> for PowerOn {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        if let Some(s) = cx.safety_system() {
            s.trigger(safety::SWITCH_ON);
        }
        cx.control().brake(false);
        cx.control().enable(true);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        cx.control().commands_done() && cx.control().status().enabled
    }
}

/// Step: disable the drive and engage the brake; the safety system goes back to off.
pub struct PowerOff;

impl Step<ControlSystem> for PowerOff {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().enable(false);
        cx.control().brake(true);
        if let Some(s) = cx.safety_system() {
            s.trigger(safety::SWITCH_OFF);
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        cx.control().commands_done()
    }
}

/// Step: the homing seek ([`ControlSystem::seek_home`]): towards the negative end stop at
/// `speed` (m/s) until its switch closes — after first jogging off it (+) if it was closed
/// at the start; the control system latches the position of the closing edge.
pub struct SeekEndStop {
    /// Jog speed, m/s (positive; the direction is negative).
    pub speed: f32,
}

impl Step<ControlSystem> for SeekEndStop {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().seek_home(self.speed);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        // A switch closed at the start is not "found": the seek leaves it first.
        let c = cx.control();
        c.commands_done() && c.end_stop_neg() && !c.leaving_end_stop()
    }
}

/// Step: decelerate to a standstill (normal deceleration) and hold.
pub struct Halt;

impl Step<ControlSystem> for Halt {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().stop();
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        cx.control().commands_done() && cx.control().standstill()
    }
}

/// Step: take the home edge the seek latched as zero ([`ControlSystem::set_zero`]).
pub struct SetZero;

impl Step<ControlSystem> for SetZero {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().set_zero();
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        cx.control().commands_done()
    }
}

/// Step: point-to-point move to `target` (m); ends in position and settled.
///
/// Soft travel limits: a target outside `travel` fails the step at once with
/// [`TARGET_OUTSIDE_TRAVEL`] (and on an axis that is not homed with [`NOT_HOMED`]),
/// before anything moves. Without them a mistyped target drove the axis at full speed into
/// the end-stop switch (domain review S2).
pub struct MoveTo {
    /// Target position, m (homed coordinates).
    pub target: f32,
    /// The accepted targets, m (homed coordinates).
    pub travel: Travel,
}

impl Step<ControlSystem> for MoveTo {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        if !cx.control().status().homed {
            return Err(Failure::App(NOT_HOMED));
        }
        if !self.travel.contains(self.target) {
            return Err(Failure::App(TARGET_OUTSIDE_TRAVEL));
        }
        cx.control().move_to(self.target);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        // In position at *this* target: a move the mailbox dropped for a pending stop
        // leaves the axis in position elsewhere.
        let c = cx.control();
        c.commands_done()
            && c.in_position()
            && (c.status().setpoint - self.target).abs() <= POSITION_TOLERANCE
    }
}

/// Step: quick stop (setpoint re-synchronised with the axis, integrator emptied); ends at
/// standstill.
pub struct QuickStop;

impl Step<ControlSystem> for QuickStop {
    fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().quick_stop();
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        cx.control().commands_done() && cx.control().standstill()
    }
}

/// Sequence: seek the negative end stop, halt, set zero, back off.
pub struct Homing {
    /// Jog to the end stop.
    pub seek: Seq<SeekEndStop>,
    /// Stop on the switch.
    pub halt: Seq<Halt>,
    /// Zero at the switch's latched edge.
    pub zero: Seq<SetZero>,
    /// Move off the switch.
    pub back_off: Seq<MoveTo>,
}

impl Sequence<ControlSystem> for Homing {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        if !completed(cx.step(&mut self.seek).await) {
            return Ok(());
        }
        if !completed(cx.step(&mut self.halt).await) {
            return Ok(());
        }
        if !completed(cx.step(&mut self.zero).await) {
            return Ok(());
        }
        refused(cx.step(&mut self.back_off).await)
    }
    fn check_exit_condition(&mut self, cx: &Ctx<'_>) -> bool {
        // Completed only when the axis really is homed and off the switch.
        let s = cx.control().status();
        s.homed && s.in_position && !s.end_stop_neg
    }
}

/// Sequence: the point-to-point moves, each followed by a dwell.
///
/// Restart-safe: the index of the next move is kept in the sequence object, so a restart
/// (after a following-error safe stop) repeats the interrupted move, not the whole list;
/// [`rewind`](Self::rewind) starts the list over (the main sequence does it before each
/// run).
pub struct MoveLoop {
    /// The move step (its target is set before each run).
    pub step: Seq<MoveTo>,
    /// The dwell after each move.
    pub dwell: Seq<Wait>,
    /// The targets, m (homed coordinates); the first `count` are used.
    pub targets: [f32; MAX_MOVES],
    /// Number of moves.
    pub count: usize,
    next: usize,
}

impl MoveLoop {
    /// A loop over `targets[..count]` (at most [`MAX_MOVES`]).
    pub fn new(
        step: Seq<MoveTo>,
        dwell: Seq<Wait>,
        targets: [f32; MAX_MOVES],
        count: usize,
    ) -> Self {
        MoveLoop {
            step,
            dwell,
            targets,
            count: count.min(MAX_MOVES),
            next: 0,
        }
    }

    /// Starts the list over at the next run.
    pub fn rewind(&mut self) {
        self.next = 0;
    }

    /// Number of moves completed in this run.
    pub fn done(&self) -> usize {
        self.next
    }
}

impl Sequence<ControlSystem> for MoveLoop {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        cx.control().set_phase(Phase::Moving);
        while self.next < self.count {
            let Some(&target) = self.targets.get(self.next) else {
                return Ok(());
            };
            self.step.body_mut().target = target;
            let r = cx.step(&mut self.step).await;
            if !completed(r) {
                return refused(r);
            }
            cx.control().record_move_done(self.next);
            self.next = self.next.saturating_add(1);
            let _ = cx.step(&mut self.dwell).await;
        }
        Ok(())
    }
    fn check_exit_condition(&mut self, _cx: &Ctx<'_>) -> bool {
        self.next >= self.count
    }
}

/// Exception sequence of the following-error monitor (and of the homing timeout): quick
/// stop, wait for standstill.
pub struct SafeStop {
    /// The quick-stop step.
    pub stop: Seq<QuickStop>,
}

impl Sequence<ControlSystem> for SafeStop {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        let c = cx.control();
        c.set_phase(Phase::SafeStop);
        c.record_reaction(FaultKind::FollowingError);
        c.update_summary(|s, _| s.safe_stops = s.safe_stops.saturating_add(1));
        let _ = cx.step(&mut self.stop).await;
        Ok(())
    }
}

/// Exception sequence of the pause monitor: feed hold (the profile decelerates and keeps
/// its move) and a pause request for the moves sequence.
pub struct FeedHold {
    /// The sequence to pause.
    pub moves: SeqId,
}

impl Sequence<ControlSystem> for FeedHold {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        let c = cx.control();
        c.feed_hold();
        if let Some(h) = cx.sequence_by_id(self.moves) {
            let _ = h.pause();
        }
        c.set_phase(Phase::Paused);
        c.update_summary(|s, now| {
            s.paused_at.get_or_insert(now);
        });
        Ok(())
    }
}

/// Exception sequence of the resume monitor: feed resume and a resume request for the moves
/// sequence.
pub struct FeedResume {
    /// The sequence to resume.
    pub moves: SeqId,
}

impl Sequence<ControlSystem> for FeedResume {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        let c = cx.control();
        c.feed_resume();
        if let Some(h) = cx.sequence_by_id(self.moves) {
            let _ = h.resume();
        }
        c.set_phase(Phase::Moving);
        c.update_summary(|s, now| {
            s.resumed_at.get_or_insert(now);
        });
        Ok(())
    }
}

/// Non-blocking status sequence: toggles the status LED every half period of the current
/// phase ([`StatusBlink::half_period_ms`]), until the application has ended (LED steady on
/// when done, off after a fault; aborted, its cleanup hook [`StatusBlink::aborted`] turns
/// it off).
pub struct StatusBlink {
    /// The wait between two toggles.
    pub blink: Seq<Wait>,
}

impl StatusBlink {
    /// The status sequence's cleanup hook ([`SeqConfig::on_abort`](rtseq::SeqConfig::on_abort)):
    /// only the safety system's abort-all (emergency) aborts it, mid-blink, so the LED is
    /// switched off as after any fault.
    pub fn aborted(cs: &ControlSystem) {
        cs.set_led(false);
    }

    /// Half blink period per phase, ms: power on / homing 4 Hz, moving 2 Hz, paused 1 Hz,
    /// safe stop 10 Hz.
    pub const fn half_period_ms(phase: Phase) -> u64 {
        match phase {
            Phase::Off | Phase::PowerOn | Phase::Homing => 125,
            Phase::Moving => 250,
            Phase::Paused => 500,
            Phase::SafeStop | Phase::Fault | Phase::Done => 50,
        }
    }
}

impl Sequence<ControlSystem> for StatusBlink {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        let c = cx.control();
        loop {
            let phase = c.phase();
            if phase.is_final() {
                c.set_led(phase == Phase::Done);
                return Ok(());
            }
            c.set_led(!c.led());
            let half = rtseq::Duration::from_millis(Self::half_period_ms(phase));
            self.blink.body_mut().set_duration(half);
            if !completed(cx.step(&mut self.blink).await) {
                return Ok(());
            }
        }
    }
}

/// The main sequence: status on, power on, homing, the moves, power off; ends in phase
/// [`Phase::Done`], or [`Phase::Fault`] after a failure or when aborted
/// ([`Main::aborted`]).
pub struct Main {
    /// The status sequence (started non-blocking).
    pub status: SeqId,
    /// Power on.
    pub power_on: Seq<PowerOn>,
    /// Homing.
    pub homing: Seq<Homing>,
    /// The moves.
    pub moves: Seq<MoveLoop>,
    /// Stop the axis after a failure.
    pub halt: Seq<QuickStop>,
    /// Power off at the end.
    pub power_off: Seq<PowerOff>,
}

impl Main {
    /// Main's cleanup hook ([`SeqConfig::on_abort`](rtseq::SeqConfig::on_abort)): only the
    /// safety system's abort-all (emergency) aborts main, which ends the application
    /// before main could set a final phase.
    pub fn aborted(cs: &ControlSystem) {
        cs.set_phase(Phase::Fault);
    }
}

impl Sequence<ControlSystem> for Main {
    async fn action(&mut self, cx: &Ctx<'_>) -> Result<(), Failure> {
        let c = cx.control();
        c.set_phase(Phase::PowerOn);
        let _ = cx.start(self.status);
        let mut ok = completed(cx.step(&mut self.power_on).await);
        if ok {
            c.set_phase(Phase::Homing);
            ok = completed(cx.run(&mut self.homing).await);
        }
        if ok {
            c.update_summary(|s, now| s.homed_at = Some(now));
            if let Some(s) = cx.safety_system() {
                s.trigger(safety::HOMED_EVENT);
            }
            self.moves.body_mut().rewind();
            ok = completed(cx.run(&mut self.moves).await);
        }
        if !ok {
            let _ = cx.step(&mut self.halt).await;
        }
        let _ = cx.step(&mut self.power_off).await;
        c.set_phase(if ok { Phase::Done } else { Phase::Fault });
        c.update_summary(|s, now| s.finished_at = Some(now));
        Ok(())
    }
}
