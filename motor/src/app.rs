//! The whole application in one registration call, plus fault injection and the run's
//! summary — so the QEMU firmware and the host tests build the *same* application.
//!
//! # Using it
//!
//! ```
//! use rtseq::sim::Sim;
//! use rtseq::{Duration, Sequencer};
//! use rtseq_motor::app::{self, AppConfig, FaultPlan};
//! use rtseq_motor::control_system::{ControlSystem, Phase};
//!
//! let seq: Sequencer<ControlSystem, { app::SEQUENCES }> = Sequencer::new();
//! let cs = ControlSystem::new(AppConfig::DEFAULT.start_position);
//! cs.set_fault_plan(FaultPlan::NONE);
//! let monitors: app::AppMonitors = app::monitor_ids::table(&AppConfig::DEFAULT).unwrap();
//! let mut app = app::register(&seq, &app::Setup::DEFAULT).unwrap();
//!
//! let mut sim = Sim::new(&seq, &cs, monitors);
//! // The five lanes joined in one task, as in the firmware.
//! sim.task_with_priority(app.run(&seq, &cs), rtseq::sim::DEFAULT_LANE_PRIORITY);
//! sim.before_tick(|now, cs| cs.control_tick(now, 0.001)); // the control interrupt
//! sim.start(app::seq_ids::MAIN).unwrap();
//! sim.run_until_idle(Duration::from_secs(10)).unwrap();
//! assert_eq!(cs.phase(), Phase::Done);
//! assert_eq!(usize::from(cs.summary().moves_done), AppConfig::DEFAULT.move_count);
//! ```
//!
//! In RTIC firmware: a `static` [`Sequencer`] and [`ControlSystem`], the monitor table as a
//! `local` resource of the timer task (built at compile time: `const { app::monitor_ids::table(..) }`),
//! [`register`] in `init`, one async task that runs the lanes of [`App`] ([`App::run`]),
//! and in the timer interrupt:
//! `CS.control_tick(now, 0.001); SEQ.tick(now, &CS, monitors)`.

use core::convert::Infallible;

use rtseq::lock::Lock;
use rtseq::{
    Behaviour, Condition, Duration, Instant, Monitor, Monitors, Seq, SeqConfig, Sequencer, Table,
    Toggle, Wait,
};

use crate::control_system::{ControlSystem, Phase};
use crate::sequences::{
    FeedHold, FeedResume, Halt, Homing, Main, MoveLoop, MoveTo, PowerOff, PowerOn, QuickStop,
    SafeStop, SeekEndStop, SetZero, StatusBlink,
};

/// Maximum number of point-to-point moves.
pub const MAX_MOVES: usize = 8;
/// Maximum number of planned faults.
pub const MAX_FAULTS: usize = 4;
/// Sequences and steps [`register`] adds: the minimum sequencer capacity `N`.
pub const SEQUENCES: usize = seq_ids::COUNT;
/// Monitors [`register`] adds: the minimum monitor capacity `M`.
pub const MONITORS: usize = monitor_ids::COUNT;

/// The application's parameters (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AppConfig {
    /// Machine position at power-up, m (the negative end stop is at 0).
    pub start_position: f32,
    /// Homing jog speed, m/s.
    pub homing_speed: f32,
    /// Homing timeout (seek, halt, zero, back off).
    pub homing_timeout: Duration,
    /// Back-off position after zeroing, m.
    pub back_off: f32,
    /// Move targets, m (homed coordinates); the first `move_count` are used.
    pub targets: [f32; MAX_MOVES],
    /// Number of moves (≤ [`MAX_MOVES`]).
    pub move_count: usize,
    /// Dwell after each move.
    pub dwell: Duration,
    /// Timeout of one move (paused time excluded).
    pub move_timeout: Duration,
    /// Following-error limit of the monitor, m.
    pub following_error_limit: f32,
    /// Restart limit of the following-error monitor.
    pub restart_limit: u8,
    /// Soft travel limits, m (homed coordinates): a move whose target lies outside is
    /// refused ([`MoveTo`], [`TARGET_OUTSIDE_TRAVEL`]).
    pub travel: Travel,
}

/// Soft travel limits in homed coordinates, m: `min ≤ target ≤ max`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Travel {
    /// Lowest accepted target, m.
    pub min: f32,
    /// Highest accepted target, m.
    pub max: f32,
}

impl Travel {
    /// The simulated axis' soft limits: the switches' span (homing zeroes at the negative
    /// switch, the positive one is [`END_STOP_POS`](crate::plant::END_STOP_POS) −
    /// [`END_STOP_NEG`](crate::plant::END_STOP_NEG) further) minus 4 mm at each end, at
    /// least the [`STOPPING_DISTANCE`](crate::controller::STOPPING_DISTANCE) from full
    /// speed (3.53 mm): a healthy axis never reaches a switch, and an axis that does
    /// (run away, a lost zero) still stops before the hard stop.
    pub const AXIS: Travel = Travel {
        min: SOFT_LIMIT_INSET,
        max: crate::plant::END_STOP_POS - crate::plant::END_STOP_NEG - SOFT_LIMIT_INSET,
    };

    /// True if `target` lies within the limits (NaN does not).
    pub fn contains(&self, target: f32) -> bool {
        target >= self.min && target <= self.max
    }
}

/// Distance of the soft travel limits inside the end-stop switches, m.
const SOFT_LIMIT_INSET: f32 = 0.004;
const _: () = assert!(SOFT_LIMIT_INSET >= crate::controller::STOPPING_DISTANCE);

/// [`rtseq::Failure::App`] code of a [`MoveTo`] whose target lies outside the soft travel
/// limits ([`AppConfig::travel`]): the step fails at once, nothing moves.
pub const TARGET_OUTSIDE_TRAVEL: u16 = 1;
/// [`rtseq::Failure::App`] code of a [`MoveTo`] on an axis that is not homed: its targets
/// are in homed coordinates, so the soft limits mean nothing yet.
pub const NOT_HOMED: u16 = 2;

impl AppConfig {
    /// 20 mm from the end stop; homing at 20 mm/s (5 s timeout), back off to 5 mm; three
    /// moves to 100, 50 and 150 mm with 100 ms dwell; 2 mm following-error limit, three
    /// restarts. A fault-free run lasts about 3.7 s.
    pub const DEFAULT: AppConfig = AppConfig {
        start_position: 0.020,
        homing_speed: 0.020,
        homing_timeout: Duration::from_secs(5),
        back_off: 0.005,
        targets: [0.100, 0.050, 0.150, 0.0, 0.0, 0.0, 0.0, 0.0],
        move_count: 3,
        dwell: Duration::from_millis(100),
        move_timeout: Duration::from_secs(3),
        following_error_limit: 0.002,
        restart_limit: 3,
        travel: Travel::AXIS,
    };

    /// The QEMU demo's program (`./x demo`): [`DEFAULT`](Self::DEFAULT) with eight moves
    /// (100, 50, 150, 30, 120, 80, 160, 10 mm), so the fault-free run lasts about 6.5 s and
    /// faults or a pause at 2…6 s hit the moves. The host tests of the demo use it too.
    pub const DEMO: AppConfig = AppConfig {
        targets: [0.100, 0.050, 0.150, 0.030, 0.120, 0.080, 0.160, 0.010],
        move_count: MAX_MOVES,
        ..AppConfig::DEFAULT
    };
}

/// A fault to inject at a virtual time (see [`ControlSystem::inject`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// The axis jams at `at` (and stays jammed): a following error.
    FollowingError {
        /// Injection time.
        at: Instant,
    },
    /// The current sensor reads [`OVERCURRENT_OFFSET`](crate::control_system::OVERCURRENT_OFFSET)
    /// A high from `at`: an over-current for the safety system.
    OverCurrent {
        /// Injection time.
        at: Instant,
    },
    /// The positive end-stop switch closes at `at` (and stays closed).
    EndStop {
        /// Injection time.
        at: Instant,
    },
    /// The emergency-stop button is pressed at `at` (and stays pressed).
    EStop {
        /// Injection time.
        at: Instant,
    },
}

/// The kind of a [`Fault`], without its time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultKind {
    /// [`Fault::FollowingError`].
    FollowingError,
    /// [`Fault::OverCurrent`].
    OverCurrent,
    /// [`Fault::EndStop`].
    EndStop,
    /// [`Fault::EStop`].
    EStop,
}

impl Fault {
    /// The injection time.
    pub const fn at(self) -> Instant {
        match self {
            Fault::FollowingError { at }
            | Fault::OverCurrent { at }
            | Fault::EndStop { at }
            | Fault::EStop { at } => at,
        }
    }

    /// The kind.
    pub const fn kind(self) -> FaultKind {
        match self {
            Fault::FollowingError { .. } => FaultKind::FollowingError,
            Fault::OverCurrent { .. } => FaultKind::OverCurrent,
            Fault::EndStop { .. } => FaultKind::EndStop,
            Fault::EStop { .. } => FaultKind::EStop,
        }
    }
}

/// A pause window: the pause button is pressed at `start` (pause) and again at `end`
/// (resume).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PauseWindow {
    /// First press.
    pub start: Instant,
    /// Second press.
    pub end: Instant,
}

/// What to inject during a run.
///
/// ```
/// use rtseq::Instant;
/// use rtseq_motor::app::{Fault, FaultPlan};
/// let ms = |m: u64| Instant::from_ticks(m * 1000);
/// let plan = FaultPlan::NONE
///     .with(Fault::FollowingError { at: ms(2000) })
///     .with_pause(ms(1600), ms(2100));
/// assert_eq!(plan.faults[0], Some(Fault::FollowingError { at: ms(2000) }));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultPlan {
    /// Faults, each at its time.
    pub faults: [Option<Fault>; MAX_FAULTS],
    /// The pause window.
    pub pause: Option<PauseWindow>,
}

impl FaultPlan {
    /// No fault, no pause.
    pub const NONE: FaultPlan = FaultPlan {
        faults: [None; MAX_FAULTS],
        pause: None,
    };

    /// Adds a fault (ignored when [`MAX_FAULTS`] are planned already).
    pub const fn with(mut self, fault: Fault) -> Self {
        let f = Some(fault);
        let [a, b, c, d] = self.faults;
        self.faults = match (a, b, c, d) {
            (None, ..) => [f, b, c, d],
            (_, None, ..) => [a, f, c, d],
            (_, _, None, _) => [a, b, f, d],
            (_, _, _, None) => [a, b, c, f],
            _ => [a, b, c, d],
        };
        self
    }

    /// Sets the pause window.
    pub const fn with_pause(mut self, start: Instant, end: Instant) -> Self {
        self.pause = Some(PauseWindow { start, end });
        self
    }
}

/// The reaction to one kind of injected fault, in virtual time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reaction {
    /// When the fault was injected.
    pub injected: Option<Instant>,
    /// When the application reacted: the safe stop started (following error), the moves
    /// were aborted (end stop), the safety system tripped to emergency, which withdraws
    /// the drive permit (over-current, e-stop).
    pub reacted: Option<Instant>,
    /// When the motor was first stopped after the reaction (|v| ≤ 5 mm/s, |i| ≤ 0.3 A).
    pub stopped: Option<Instant>,
}

impl Reaction {
    /// Nothing injected.
    pub const NONE: Reaction = Reaction {
        injected: None,
        reacted: None,
        stopped: None,
    };

    /// Injection → reaction.
    pub fn latency(&self) -> Option<Duration> {
        self.reacted?.checked_duration_since(self.injected?)
    }

    /// Injection → motor stopped.
    pub fn stop_latency(&self) -> Option<Duration> {
        self.stopped?.checked_duration_since(self.injected?)
    }
}

/// The run's summary, filled during the run ([`ControlSystem::summary`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Summary {
    /// Homing completed.
    pub homed_at: Option<Instant>,
    /// Moves completed (over all runs of the move loop).
    pub moves_done: u16,
    /// When move `i` completed (in position and settled).
    pub move_done_at: [Option<Instant>; MAX_MOVES],
    /// Safe stops run.
    pub safe_stops: u16,
    /// First feed hold.
    pub paused_at: Option<Instant>,
    /// First feed resume.
    pub resumed_at: Option<Instant>,
    /// Following-error fault.
    pub following_error: Reaction,
    /// Over-current fault.
    pub over_current: Reaction,
    /// End-stop fault.
    pub end_stop: Reaction,
    /// Emergency-stop fault.
    pub estop: Reaction,
    /// The main sequence ended.
    pub finished_at: Option<Instant>,
}

impl Summary {
    /// Nothing happened yet.
    pub const EMPTY: Summary = Summary {
        homed_at: None,
        moves_done: 0,
        move_done_at: [None; MAX_MOVES],
        safe_stops: 0,
        paused_at: None,
        resumed_at: None,
        following_error: Reaction::NONE,
        over_current: Reaction::NONE,
        end_stop: Reaction::NONE,
        estop: Reaction::NONE,
        finished_at: None,
    };

    /// The reaction record of a fault kind.
    pub fn reaction(&self, kind: FaultKind) -> Reaction {
        match kind {
            FaultKind::FollowingError => self.following_error,
            FaultKind::OverCurrent => self.over_current,
            FaultKind::EndStop => self.end_stop,
            FaultKind::EStop => self.estop,
        }
    }

    pub(crate) fn reaction_mut(&mut self, kind: FaultKind) -> &mut Reaction {
        match kind {
            FaultKind::FollowingError => &mut self.following_error,
            FaultKind::OverCurrent => &mut self.over_current,
            FaultKind::EndStop => &mut self.end_stop,
            FaultKind::EStop => &mut self.estop,
        }
    }

    pub(crate) fn reactions_mut(&mut self) -> [&mut Reaction; 4] {
        [
            &mut self.following_error,
            &mut self.over_current,
            &mut self.end_stop,
            &mut self.estop,
        ]
    }
}

impl Default for Summary {
    fn default() -> Self {
        Summary::EMPTY
    }
}

/// Monitor condition: |following error| above a limit (m).
pub struct FollowingErrorAbove {
    /// The limit, m.
    pub limit: f32,
}

impl Condition<ControlSystem> for FollowingErrorAbove {
    fn validate(&mut self, cs: &ControlSystem, _now: Instant) -> bool {
        cs.following_error().abs() > self.limit
    }
}

/// Monitor condition: an end-stop switch is closed.
pub struct EndStopHit;

/// Monitor condition of homing: the **positive** end-stop switch is closed. Homing seeks
/// the negative one; reaching the other end means the axis moved the wrong way (a motor or
/// encoder wired in reverse, a wrong sign in the configuration) or started beyond it.
pub struct PositiveEndStopHit;

impl Condition<ControlSystem> for PositiveEndStopHit {
    fn validate(&mut self, cs: &ControlSystem, _now: Instant) -> bool {
        cs.status().end_stop_pos
    }
}

impl Condition<ControlSystem> for EndStopHit {
    fn validate(&mut self, cs: &ControlSystem, _now: Instant) -> bool {
        cs.any_end_stop()
    }
}

/// The raw pause button, as a `fn` pointer (nameable, so conditions can be `static`).
pub type Button = fn(&ControlSystem) -> bool;

/// The pause toggle: on after the first press of the pause button, off after the next.
pub type PauseToggle = Toggle<Button>;

/// Monitor condition of the resume monitor: the pause toggle is off again while the moves
/// are paused. It keeps its own copy of the toggle, which sees exactly the same presses as
/// the pause monitor's (both monitors belong to the moves sequence, so both are evaluated
/// at the same polls).
pub struct ResumePressed {
    toggle: PauseToggle,
}

impl Condition<ControlSystem> for ResumePressed {
    fn validate(&mut self, cs: &ControlSystem, now: Instant) -> bool {
        let on = self.toggle.validate(cs, now);
        !on && cs.phase() == Phase::Paused
    }
}

/// The monitor conditions, one type (they keep state; the monitor table owns them), so that
/// the tick calls them without a `dyn` call and a `const fn` builds the table
/// ([`monitor_ids`]).
pub enum AppCondition {
    /// The following-error monitor's.
    FollowingError(FollowingErrorAbove),
    /// The end-stop monitor's.
    EndStop(EndStopHit),
    /// The homing end-stop monitor's.
    PositiveEndStop(PositiveEndStopHit),
    /// The pause monitor's.
    Pause(PauseToggle),
    /// The resume monitor's.
    Resume(ResumePressed),
}

impl Condition<ControlSystem> for AppCondition {
    fn validate(&mut self, cs: &ControlSystem, now: Instant) -> bool {
        match self {
            AppCondition::FollowingError(c) => c.validate(cs, now),
            AppCondition::EndStop(c) => c.validate(cs, now),
            AppCondition::PositiveEndStop(c) => c.validate(cs, now),
            AppCondition::Pause(c) => c.validate(cs, now),
            AppCondition::Resume(c) => c.validate(cs, now),
        }
    }
}

/// The application's monitor table (capacity `M`, at least [`MONITORS`]).
pub type AppMonitors<const M: usize = MONITORS> = Monitors<'static, ControlSystem, M, AppCondition>;

const BUTTON: Button = ControlSystem::pause_button;

rtseq::monitors! {
    /// The monitor ids and the monitor table: `monitor_ids::table(&config)`, a `const fn`
    /// (in firmware evaluate it at compile time, `const { ... }`, so no set-up code for
    /// monitors is linked). `M` < [`MONITORS`] does not compile.
    ///
    /// | monitor | owner | condition | exception | behaviour |
    /// |---|---|---|---|---|
    /// | `homing following error` | `homing` | \|setpoint − position\| > limit | `safe stop` | `AbortOwner` |
    /// | `homing end stop` | `homing` | the positive end-stop switch closed | — | `AbortOwner` |
    /// | `following error` | `move` | \|setpoint − position\| > limit | `safe stop` | `RestartCallerOfOwner`, limit `restart_limit` |
    /// | `end stop` | `moves` | an end-stop switch closed | — | `AbortOwner` |
    /// | `pause` | `moves` | [`Toggle`] of the pause button | `feed hold` | `Nothing` |
    /// | `resume` | `moves` | toggle off again while paused | `feed resume` | `Nothing` |
    ///
    /// The following-error monitor of the moves restarts them (`RestartCallerOfOwner`,
    /// at most `restart_limit` times, then the moves are aborted): the demo shows EEROS'
    /// restart behaviour with it. Each retry starts only after the safe stop has brought
    /// the axis to a standstill, with the setpoint re-synchronised (no following error)
    /// and the integrator emptied, so each push into a jam lasts tens of ms. An automatic
    /// retry is acceptable only for a cause known to be transient (a momentary overload)
    /// on a machine nobody can reach while it runs (guarded, interlocked). A production
    /// drive latches a following error and waits for an operator's acknowledge before
    /// any motion (IEC 60204-1 restart, ISO 14118 unexpected start-up): there, use
    /// `AbortOwner` and a reset sequence started by the acknowledge (domain review S3).
    ///
    /// The end-stop monitor belongs to the whole move loop, not to one move: hitting a limit
    /// must end the motion program (the moves and the move in progress are aborted, main gets
    /// `Aborted` and powers off), which `AbortOwner` on `moves` expresses directly.
    ///
    /// Homing is supervised too: the closed loop runs during the seek, the halt and the
    /// back off, and a jam (or a switch that never closes and the hard stop) would
    /// otherwise let the jog setpoint run away with the drive at its current limit until
    /// the homing timeout. Its own following-error monitor stops the axis and aborts
    /// homing (no retry: homing has not established the machine's position yet); the
    /// positive end stop while homing (the axis went the wrong way) aborts it too. The
    /// negative end stop is the one homing seeks, so only the positive one is a fault.
    pub mod monitor_ids(config: &AppConfig) for ControlSystem, AppCondition {
        /// Following error during homing.
        HOMING_FOLLOWING_ERROR = Monitor::with_condition(
            "homing following error",
            AppCondition::FollowingError(FollowingErrorAbove {
                limit: config.following_error_limit,
            }),
            Behaviour::AbortOwner,
        )
        .exception(seq_ids::SAFE_STOP)
        .owned_by(seq_ids::HOMING),
        /// The positive end stop during homing.
        HOMING_END_STOP = Monitor::with_condition(
            "homing end stop",
            AppCondition::PositiveEndStop(PositiveEndStopHit),
            Behaviour::AbortOwner,
        )
        .owned_by(seq_ids::HOMING),
        /// Following error.
        FOLLOWING_ERROR = Monitor::with_condition(
            "following error",
            AppCondition::FollowingError(FollowingErrorAbove {
                limit: config.following_error_limit,
            }),
            Behaviour::RestartCallerOfOwner,
        )
        .exception(seq_ids::SAFE_STOP)
        .restart_limit(config.restart_limit)
        .owned_by(seq_ids::MOVE),
        /// End stop.
        END_STOP = Monitor::with_condition(
            "end stop",
            AppCondition::EndStop(EndStopHit),
            Behaviour::AbortOwner,
        )
        .owned_by(seq_ids::MOVES),
        /// Pause.
        PAUSE = Monitor::with_condition(
            "pause",
            AppCondition::Pause(Toggle::new(BUTTON)),
            Behaviour::Nothing,
        )
        .exception(seq_ids::FEED_HOLD)
        .owned_by(seq_ids::MOVES),
        /// Resume.
        RESUME = Monitor::with_condition(
            "resume",
            AppCondition::Resume(ResumePressed {
                toggle: Toggle::new(BUTTON),
            }),
            Behaviour::Nothing,
        )
        .exception(seq_ids::FEED_RESUME)
        .owned_by(seq_ids::MOVES),
    }
}

/// The registered application: the sequence objects that run in lanes (the ids are
/// [`seq_ids`] and [`monitor_ids`]).
pub struct App {
    /// The main sequence (start it with its handle or `Sim::start`).
    pub main: Seq<Main>,
    /// The status sequence (started by main).
    pub status: Seq<StatusBlink>,
    /// The safe-stop exception sequence.
    pub safe_stop: Seq<SafeStop>,
    /// The feed-hold exception sequence.
    pub feed_hold: Seq<FeedHold>,
    /// The feed-resume exception sequence.
    pub feed_resume: Seq<FeedResume>,
}

impl App {
    /// The five lanes joined in one future (one RTIC task, with [`rtseq::lanes!`]): never
    /// returns. Each wake polls the lanes in this order; a lane with nothing to do returns
    /// `Pending` at once.
    pub async fn run<const N: usize, const T: usize, L: Lock, const W: usize>(
        &mut self,
        seq: &Sequencer<ControlSystem, N, T, L, W>,
        cs: &ControlSystem,
    ) -> Infallible {
        let App {
            main,
            status,
            safe_stop,
            feed_hold,
            feed_resume,
        } = self;
        rtseq::lanes!(seq, cs, main, status, safe_stop, feed_hold, feed_resume).await
    }
}

rtseq::sequences! {
    /// The ids of the sequences and steps and their table, `seq_ids::table(&config)`:
    /// polling 1 ms unless noted; `status` and its `blink` 5 ms; `homing` with timeout
    /// `homing_timeout`, exception `safe stop`, `AbortOwner`; `move` with timeout
    /// `move_timeout`; `homing`, `moves` and `move` stop the axis when aborted
    /// ([`ControlSystem::abort_hook`]); aborted `main` ends in phase fault
    /// ([`Main::aborted`]), aborted `status` switches the LED off ([`StatusBlink::aborted`]).
    /// Errors if a duration is out of range.
    pub mod seq_ids(config: &AppConfig) for ControlSystem {
        /// Quick stop (step of safe stop).
        QUICK_STOP = SeqConfig::new("quick stop"),
        /// Safe stop.
        SAFE_STOP = SeqConfig::new("safe stop").in_lane(),
        /// Blink wait (step of status).
        BLINK = SeqConfig::new("blink").polling(Duration::from_millis(5)),
        /// Status.
        STATUS = SeqConfig::new("status")
            .polling(Duration::from_millis(5))
            .in_lane()
            .on_abort(StatusBlink::aborted),
        /// Power on.
        POWER_ON = SeqConfig::new("power on"),
        /// Seek end stop.
        SEEK = SeqConfig::new("seek end stop"),
        /// Halt (step of homing).
        HALT = SeqConfig::new("halt"),
        /// Set zero.
        SET_ZERO = SeqConfig::new("set zero"),
        /// Back off.
        BACK_OFF = SeqConfig::new("back off"),
        /// Homing.
        HOMING = SeqConfig::new("homing")
            .timeout(config.homing_timeout)
            .timeout_exception(SAFE_STOP)
            .timeout_behaviour(Behaviour::AbortOwner)
            .on_abort(ControlSystem::abort_hook),
        /// Move.
        MOVE = SeqConfig::new("move")
            .timeout(config.move_timeout)
            .on_abort(ControlSystem::abort_hook),
        /// Dwell.
        DWELL = SeqConfig::new("dwell"),
        /// Moves.
        MOVES = SeqConfig::new("moves").on_abort(ControlSystem::abort_hook),
        /// Feed hold.
        FEED_HOLD = SeqConfig::new("feed hold").in_lane(),
        /// Feed resume.
        FEED_RESUME = SeqConfig::new("feed resume").in_lane(),
        /// Main halt.
        MAIN_HALT = SeqConfig::new("main halt"),
        /// Power off.
        POWER_OFF = SeqConfig::new("power off"),
        /// Main.
        MAIN = SeqConfig::new("main").in_lane().on_abort(Main::aborted),
    }
}

/// The application's parameters with its sequence table, checked by a `const fn`.
///
/// In firmware build it in a `static` (as [`Setup::DEMO`]): then the table is checked by
/// the compiler and [`register`] only copies it into the sequencer. Host tests build one
/// for any [`AppConfig`] with [`Setup::new`].
pub struct Setup {
    /// The parameters.
    pub config: AppConfig,
    /// The table of [`seq_ids`].
    pub table: Table<ControlSystem, SEQUENCES>,
}

impl Setup {
    /// The set-up of [`AppConfig::DEFAULT`].
    // A `const` item: the panic is a compile error, never a run-time path.
    #[allow(clippy::panic)]
    pub const DEFAULT: Setup = match Setup::new(AppConfig::DEFAULT) {
        Ok(setup) => match setup.validate() {
            Ok(()) => setup,
            Err(e) => panic!("{}", e.message().as_str()),
        },
        Err(e) => panic!("{}", e.message().as_str()),
    };
    /// The set-up of [`AppConfig::DEMO`].
    #[allow(clippy::panic)]
    pub const DEMO: Setup = match Setup::new(AppConfig::DEMO) {
        Ok(setup) => match setup.validate() {
            Ok(()) => setup,
            Err(e) => panic!("{}", e.message().as_str()),
        },
        Err(e) => panic!("{}", e.message().as_str()),
    };

    /// The set-up of `config`: its table is [`seq_ids::table`].
    pub const fn new(config: AppConfig) -> Result<Setup, rtseq::TableError> {
        match seq_ids::table(&config) {
            Ok(table) => Ok(Setup { config, table }),
            Err(e) => Err(e),
        }
    }

    /// The whole configuration, sequences and monitors, checked as
    /// [`Sequencer::validate`](rtseq::Sequencer::validate) would after [`register`]: in a
    /// `const` item by the compiler ([`Setup::DEMO`] is), so the firmware needs no check
    /// of its own at start-up.
    pub const fn validate(&self) -> Result<(), rtseq::ConfigError> {
        monitor_ids::validate(&self.table, &self.config)
    }
}

/// Registers the whole application into `sequencer`: installs `setup`'s table (see
/// [`Setup::new`]; the table declares the lanes of [`App`]) and binds the sequence objects,
/// so that main can be started at once (from RTIC `init`, before the lanes first ran). The monitors
/// are a table of their own ([`monitor_ids`]).
///
/// Errors: the sequencer is not empty, or has fewer than five lane slots. `N` <
/// [`SEQUENCES`] does not compile.
pub fn register<const N: usize, const T: usize, L: Lock, const W: usize>(
    sequencer: &Sequencer<ControlSystem, N, T, L, W>,
    setup: &Setup,
) -> Result<App, rtseq::Error> {
    use seq_ids::*;
    let (s, config) = (sequencer, &setup.config);
    s.install(&setup.table)?;
    let quick_stop = s.bind(QUICK_STOP, QuickStop)?;
    let blink = s.bind(BLINK, Wait::new(Duration::from_millis(125)))?;
    let speed = config.homing_speed;
    let homing = Homing {
        seek: s.bind(SEEK, SeekEndStop { speed })?,
        halt: s.bind(HALT, Halt)?,
        zero: s.bind(SET_ZERO, SetZero)?,
        back_off: s.bind(
            BACK_OFF,
            MoveTo {
                target: config.back_off,
                travel: config.travel,
            },
        )?,
    };
    let move_step = s.bind(
        MOVE,
        MoveTo {
            target: 0.0,
            travel: config.travel,
        },
    )?;
    let dwell = s.bind(DWELL, Wait::new(config.dwell))?;
    let moves = MoveLoop::new(move_step, dwell, config.targets, config.move_count);
    let main = Main {
        status: STATUS,
        power_on: s.bind(POWER_ON, PowerOn)?,
        homing: s.bind(HOMING, homing)?,
        moves: s.bind(MOVES, moves)?,
        halt: s.bind(MAIN_HALT, QuickStop)?,
        power_off: s.bind(POWER_OFF, PowerOff)?,
    };
    let app = App {
        main: s.bind(MAIN, main)?,
        status: s.bind(STATUS, StatusBlink { blink })?,
        safe_stop: s.bind(SAFE_STOP, SafeStop { stop: quick_stop })?,
        feed_hold: s.bind(FEED_HOLD, FeedHold { moves: MOVES })?,
        feed_resume: s.bind(FEED_RESUME, FeedResume { moves: MOVES })?,
    };
    Ok(app)
}
