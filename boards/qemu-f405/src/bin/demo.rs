//! The motor-controller demo: the application of `rtseq-motor` (simulated DC servo axis,
//! cascaded position controller, homing and point-to-point moves, monitors, safety levels)
//! under RTIC 2 on the emulated STM32F405, with fault injection from the command line and
//! readable logs. `./x demo [OPTIONS]` runs it; `./x demo --help` lists the options.
//!
//! ```text
//! priority 3  safety       SafetySystem::cycle on the drive's critical inputs/outputs,
//!                          woken by the tick right after the fault injection
//! priority 2  tick (TIM2)  1 kHz: inject faults -> safety cycle -> control step ->
//!                          SEQ.tick (monitors, timeouts, wakes the lanes)
//! priority 1  lanes        main, status, safe stop, feed hold, feed resume (rtseq::lane)
//! idle        log + wfi    drains the transition trace and the event queue, prints them,
//!                          samples the axis every 250 ms, checks the outcome, exits
//! ```
//!
//! The lanes, the tick and idle share `SEQ` under RTIC's Stack Resource Policy (the
//! priority-ceiling lock: a section raises BASEPRI to the tick's priority), so the safety
//! task is never held off by rtseq; it reaches the sequencer only through `abort_all`, an
//! atomic request.
//!
//! The order inside one tick (inject, safety cycle, control step, sequencer tick) is the
//! host simulator's (`tests/qemu_demo.rs` runs the same application with the same fault
//! plan in `rtseq::sim::Sim` and compares the traces): both are 1 kHz deterministic.
//!
//! The run ends by itself `SETTLE_MS` after the later of "main ended" and "the last planned
//! fault or pause press", prints a summary, parseable `RESULT` lines and checks the
//! outcome expected for the options (see `Expect`): exit 0 if it is the expected one, 1
//! otherwise; bad options print an error line and the usage and exit 1.
#![no_std]
#![no_main]

use core::cell::UnsafeCell;

use rtseq::safety::{InputId, SafetyLevel};
use rtseq::{
    Behaviour, Cause, Entry, Failure, Instant, MonitorId, Outcome, Request, Requester,
    RunningState, SeqId, Sequencer, Transition,
};
use rtseq_motor::app::monitor_ids::{
    END_STOP, FOLLOWING_ERROR, HOMING_END_STOP, HOMING_FOLLOWING_ERROR, PAUSE, RESUME,
};
use rtseq_motor::app::seq_ids::{
    BLINK, FEED_HOLD, FEED_RESUME, HOMING, MAIN, MOVE, MOVES, POWER_OFF, SAFE_STOP, STATUS,
};
use rtseq_motor::app::{self, AppConfig, Fault, FaultKind, FaultPlan, MAX_FAULTS};
use rtseq_motor::control_system::{ControlSystem, Phase, POSITION_TOLERANCE};
use rtseq_motor::safety;
use rtseq_qemu_f405 as board;

/// The demo's program: eight moves (see [`AppConfig::DEMO`]).
const CONFIG: AppConfig = AppConfig::DEMO;
/// Its sequence and monitor tables, checked whole by the compiler (`Setup::validate`: every
/// exception sequence exists and has a lane, every owner is registered): `init` only copies
/// them in.
static SETUP: app::Setup = app::Setup::DEMO;
/// Control period, s (the tick).
const DT: f32 = 0.001;
/// The run ends this long after main ended and the last planned event passed, ms.
const SETTLE_MS: u64 = 300;
/// Hard limit of a run (virtual time), ms: a run still going then is a failure.
const LIMIT_MS: u64 = 20_000;
/// Latest time accepted for a fault or pause press, ms.
const MAX_EVENT_MS: u64 = 15_000;
/// The fault-free run (virtual time, ms; `tests/qemu_demo.rs` checks both against the host
/// simulator): homing ends and the moves start in the tick of `HOMED_MS`; the last move is
/// done in the tick of `LAST_MOVE_DONE_MS`. A pause window's first press must come in
/// between, while a move is left to hold.
const HOMED_MS: u64 = 1140;
/// See [`HOMED_MS`].
const LAST_MOVE_DONE_MS: u64 = 6437;
/// Interval of the axis status lines, ms.
const STATUS_EVERY_MS: u64 = 250;
/// "Motor stopped" at the end: |true velocity| (m/s) and |true current| (A) below these.
const STOP_VELOCITY: f32 = 1e-4;
/// See [`STOP_VELOCITY`].
const STOP_CURRENT: f32 = 0.05;

/// The sequencer's lock: RTIC's Stack Resource Policy, a section raises BASEPRI to the
/// tick's priority (2), so the safety task (3) preempts rtseq at any instruction.
type Lock = rtseq::lock::PriorityCeiling<2>;
/// The sequencer (default trace buffer: 64 transitions, drained by idle every tick).
// SAFETY: every user of SEQ runs at RTIC priority 2 (the tick) or below (lanes at 1, idle
// at 0); the safety task (3) only calls the sequencer's `Sequences` methods (abort-all, the
// level and tripped-input notes), which are atomic and take no lock.
static SEQ: Sequencer<ControlSystem, { app::SEQUENCES }, 64, Lock> =
    unsafe { Sequencer::with_priority_ceiling() };
/// The control system: plant, controller, fault injection, summary.
static CS: ControlSystem = ControlSystem::new(CONFIG.start_position);
/// Events for the log, from the tick and the safety task to idle.
static EVENTS: EventQueue = EventQueue::new();

// ---------------------------------------------------------------------------------------
// Command line
// ---------------------------------------------------------------------------------------

/// What the command line asked for.
#[derive(Clone, Copy)]
struct Options {
    plan: FaultPlan,
    help: bool,
}

/// A command-line error: the message and the argument it is about.
struct ArgError<'a> {
    msg: &'static str,
    arg: &'a str,
}

fn arg_err<'a, T>(msg: &'static str, arg: &'a str) -> Result<T, ArgError<'a>> {
    Err(ArgError { msg, arg })
}

/// Parses `3s`, `2.5s`, `250ms` into milliseconds.
fn parse_time(s: &str) -> Option<u64> {
    if let Some(ms) = s.strip_suffix("ms") {
        return ms.parse::<u64>().ok();
    }
    let secs = s.strip_suffix('s')?;
    let (int, frac) = secs.split_once('.').unwrap_or((secs, ""));
    let int: u64 = if int.is_empty() && !frac.is_empty() {
        0
    } else {
        int.parse().ok()?
    };
    let scale = match frac.len() {
        0 => 0,
        1 => 100,
        2 => 10,
        3 => 1,
        _ => return None,
    };
    if !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let frac: u64 = if frac.is_empty() {
        0
    } else {
        frac.parse().ok()?
    };
    int.checked_mul(1000)?.checked_add(frac.checked_mul(scale)?)
}

fn ms(t: u64) -> Instant {
    Instant::from_ticks(t.saturating_mul(1000))
}

fn to_ms(t: Instant) -> u64 {
    t.as_ticks() / 1000
}

fn parse_fault(v: &str) -> Result<Fault, ArgError<'_>> {
    let Some((kind, time)) = v.split_once('@') else {
        return arg_err("--fault needs KIND@TIME, e.g. --fault overcurrent@5s", v);
    };
    let Some(t) = parse_time(time) else {
        return arg_err("bad time (use e.g. 3s, 2.5s or 1500ms)", time);
    };
    if t > MAX_EVENT_MS {
        return arg_err("fault times must be at most 15s", time);
    }
    let at = ms(t);
    Ok(match kind {
        "following-error" | "following_error" | "fe" => Fault::FollowingError { at },
        "overcurrent" | "over-current" | "oc" => Fault::OverCurrent { at },
        "endstop" | "end-stop" => Fault::EndStop { at },
        "estop" | "e-stop" | "emergency-stop" => Fault::EStop { at },
        _ => {
            return arg_err(
                "unknown fault (following-error, overcurrent, endstop, estop)",
                kind,
            )
        }
    })
}

fn parse_pause(v: &str) -> Result<(Instant, Instant), ArgError<'_>> {
    let Some((a, b)) = v.split_once("..") else {
        return arg_err("--pause needs START..END, e.g. --pause 4s..6s", v);
    };
    // `4s...6s` would split into `4s` and `.6s` (0.6 s): not a window that ends too early.
    if a.is_empty() || b.is_empty() || a.ends_with('.') || b.starts_with('.') {
        return arg_err(
            "bad pause window: START..END is two times with two dots between, e.g. 4s..6s",
            v,
        );
    }
    let (Some(a), Some(b)) = (parse_time(a), parse_time(b)) else {
        return arg_err("bad pause window (use e.g. 4s..6s or 4500ms..5s)", v);
    };
    if b <= a {
        return arg_err("the pause must end after it starts", v);
    }
    if b > MAX_EVENT_MS {
        return arg_err("pause times must be at most 15s", v);
    }
    // The button is held for 20 ms: the two presses must not overlap.
    if b.saturating_sub(a) < 50 {
        return arg_err("the pause must last at least 50ms", v);
    }
    if a <= HOMED_MS {
        return arg_err(
            "the pause window must start after homing: the moves run from 1.141s to 6.436s",
            v,
        );
    }
    if a >= LAST_MOVE_DONE_MS {
        return arg_err(
            "the pause window must start before the run's last move is done: the moves run from 1.141s to 6.436s",
            v,
        );
    }
    Ok((ms(a), ms(b)))
}

/// Parses the arguments after the program name.
fn parse_args<'a>(args: impl Iterator<Item = &'a str>) -> Result<Options, ArgError<'a>> {
    let mut o = Options {
        plan: FaultPlan::NONE,
        help: false,
    };
    let mut args = args;
    let mut faults = 0usize;
    let mut pause_arg: Option<&'a str> = None;
    while let Some(a) = args.next() {
        let (opt, inline) = match a.split_once('=') {
            Some((k, v)) if k.starts_with("--") => (k, Some(v)),
            _ => (a, None),
        };
        match opt {
            "--help" | "-h" => o.help = true,
            "--fault" | "--pause" => {
                let Some(v) = inline.or_else(|| args.next()) else {
                    return arg_err("option needs a value", opt);
                };
                if opt == "--fault" {
                    let f = parse_fault(v)?;
                    if o.plan.faults.iter().flatten().any(|g| g.kind() == f.kind()) {
                        return arg_err("each fault kind can be injected once", v);
                    }
                    if faults >= MAX_FAULTS {
                        return arg_err("at most 4 faults", v);
                    }
                    faults = faults.saturating_add(1);
                    o.plan = o.plan.with(f);
                } else {
                    if o.plan.pause.is_some() {
                        return arg_err("one pause window only", v);
                    }
                    let (s, e) = parse_pause(v)?;
                    o.plan = o.plan.with_pause(s, e);
                    pause_arg = Some(v);
                }
            }
            _ => return arg_err("unknown option (try --help)", a),
        }
    }
    // A fault ends the move program (emergency, abort, restarts then abort): a pause
    // pressed at or after it would find no move to hold.
    if let (Some(w), Some(v)) = (o.plan.pause, pause_arg) {
        if o.plan.faults.iter().flatten().any(|f| f.at() <= w.start) {
            return arg_err(
                "the pause window must start before the first fault (a fault ends the moves)",
                v,
            );
        }
    }
    Ok(o)
}

fn usage() {
    defmt::info!("usage: ./x demo [--fault KIND@TIME]... [--pause START..END]");
    defmt::info!(
        "  KIND: following-error  the axis jams: safe stop, the moves restart (3x), then abort"
    );
    defmt::info!("        overcurrent      the current sensor reads +12 A: safety level emergency, all sequences aborted");
    defmt::info!("        endstop          the + end-stop switch closes: the moves are aborted");
    defmt::info!(
        "        estop            the emergency-stop button is pressed: emergency, all aborted"
    );
    defmt::info!(
        "  --pause START..END     the pause button is pressed at START and END: feed hold, resume"
    );
    defmt::info!("  times: 3s, 2.5s, 1500ms (virtual time since reset, at most 15s); the fault-free run lasts about 6.6 s");
    defmt::info!(
        "  a pause window starts while the moves run (1.141s to 6.436s) and before any fault"
    );
    defmt::info!("  e.g. ./x demo --fault following-error@3s   ./x demo --fault overcurrent@5s   ./x demo --pause 4s..6s");
}

// ---------------------------------------------------------------------------------------
// Events: tick and safety task -> idle
// ---------------------------------------------------------------------------------------

/// The application's state when a fault or a pause press was injected (sampled in the
/// tick, before the safety cycle, the control step and the sequencer's tick of that
/// millisecond).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Snapshot {
    main_active: bool,
    main_started: bool,
    /// Main's last step, power off, runs: its commands are applied by this tick's control
    /// step, so main ends in this tick.
    powering_off: bool,
    /// Homing completed.
    homed: bool,
    /// Homing set the zero (its last step, the back off, runs or is done).
    zeroed: bool,
    /// Measured position, m (homed coordinates once zeroed).
    position: f32,
    moves_state: RunningState,
    moves_done: u16,
    /// Safe stops started (one per firing of the following-error monitor).
    safe_stops: u16,
    safe_stop_active: bool,
}

#[derive(Clone, Copy)]
enum Event {
    /// A planned fault was switched on.
    Fault {
        kind: FaultKind,
        at: u64,
        snap: Snapshot,
    },
    /// The pause button was pressed (`second`: the end of the window).
    Pause { second: bool, snap: Snapshot },
}

const QUEUE: usize = 32;

/// A bounded multi-producer queue (critical sections; producers at priorities 2 and 3,
/// consumer idle). Overflow drops the event and counts it.
struct EventQueue {
    inner: critical_section::Mutex<UnsafeCell<(heapless::Deque<Event, QUEUE>, u32)>>,
}

// SAFETY: the contents are only accessed inside `critical_section::with` (single core).
unsafe impl Sync for EventQueue {}

impl EventQueue {
    const fn new() -> Self {
        Self {
            inner: critical_section::Mutex::new(UnsafeCell::new((heapless::Deque::new(), 0))),
        }
    }

    fn push(&self, e: Event) {
        critical_section::with(|cs| {
            // SAFETY: exclusive inside the critical section.
            let (q, lost) = unsafe { &mut *self.inner.borrow(cs).get() };
            if q.push_back(e).is_err() {
                *lost = lost.saturating_add(1);
            }
        });
    }

    fn pop(&self) -> Option<Event> {
        critical_section::with(|cs| {
            // SAFETY: exclusive inside the critical section.
            let (q, _) = unsafe { &mut *self.inner.borrow(cs).get() };
            q.pop_front()
        })
    }

    fn is_empty(&self) -> bool {
        critical_section::with(|cs| {
            // SAFETY: exclusive inside the critical section.
            unsafe { (*self.inner.borrow(cs).get()).0.is_empty() }
        })
    }

    fn lost(&self) -> u32 {
        critical_section::with(|cs| {
            // SAFETY: exclusive inside the critical section.
            unsafe { (*self.inner.borrow(cs).get()).1 }
        })
    }
}

fn state_of(id: SeqId) -> RunningState {
    SEQ.sequence_by_id(id)
        .map_or(RunningState::Idle, |h| h.state())
}

fn outcome_of(id: SeqId) -> Option<Outcome> {
    SEQ.sequence_by_id(id).and_then(|h| h.last_outcome())
}

fn snapshot() -> Snapshot {
    let main = state_of(MAIN);
    let (summary, status) = (CS.summary(), CS.status());
    Snapshot {
        main_active: main.is_active(),
        main_started: main != RunningState::Idle,
        powering_off: state_of(POWER_OFF).is_active(),
        homed: summary.homed_at.is_some(),
        zeroed: status.homed,
        position: status.position,
        moves_state: state_of(MOVES),
        moves_done: summary.moves_done,
        safe_stops: summary.safe_stops,
        safe_stop_active: state_of(SAFE_STOP).is_active(),
    }
}

/// The tick's bookkeeping of which planned events were announced.
struct Injections {
    faults: [bool; MAX_FAULTS],
    presses: [bool; 2],
}

impl Injections {
    const fn new() -> Self {
        Self {
            faults: [false; MAX_FAULTS],
            presses: [false; 2],
        }
    }

    /// Announces the planned faults and pause presses whose time has come.
    fn check(&mut self, now: Instant, plan: &FaultPlan) {
        let at = to_ms(now);
        for (done, fault) in self.faults.iter_mut().zip(plan.faults.iter()) {
            if let Some(f) = fault {
                if !*done && now >= f.at() {
                    *done = true;
                    EVENTS.push(Event::Fault {
                        kind: f.kind(),
                        at,
                        snap: snapshot(),
                    });
                }
            }
        }
        if let Some(w) = plan.pause {
            for (i, (done, t)) in self.presses.iter_mut().zip([w.start, w.end]).enumerate() {
                if !*done && now >= t {
                    *done = true;
                    EVENTS.push(Event::Pause {
                        second: i == 1,
                        snap: snapshot(),
                    });
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Formatting
// ---------------------------------------------------------------------------------------

const SPACES: &str = "                                        ";

/// Spaces that pad a text of `len` characters to `width`.
fn pad(len: usize, width: usize) -> &'static str {
    SPACES
        .get(..width.saturating_sub(len).min(SPACES.len()))
        .unwrap_or("")
}

/// A fixed-point number `value / 10^decimals`, right-aligned to `width` characters.
struct Fixed {
    value: i32,
    decimals: u8,
    width: u8,
}

impl Fixed {
    /// `x * 10^decimals` rounded (saturating, NaN -> 0).
    fn new(x: f32, decimals: u8, width: u8) -> Self {
        let scale = match decimals {
            0 => 1.0,
            1 => 10.0,
            2 => 100.0,
            _ => 1000.0,
        };
        let v = x * scale;
        let v = if v >= 0.0 { v + 0.5 } else { v - 0.5 };
        Fixed {
            value: v as i32,
            decimals: decimals.min(3),
            width,
        }
    }
}

fn digits(mut n: u32) -> usize {
    let mut d = 1;
    while n >= 10 {
        n /= 10;
        d += 1;
    }
    d
}

impl defmt::Format for Fixed {
    fn format(&self, f: defmt::Formatter) {
        let neg = self.value < 0;
        let a = self.value.unsigned_abs();
        let (int, frac, div) = match self.decimals {
            0 => (a, 0, 1),
            1 => (a / 10, a % 10, 10),
            2 => (a / 100, a % 100, 100),
            _ => (a / 1000, a % 1000, 1000),
        };
        let len = digits(int)
            + usize::from(neg)
            + if div > 1 {
                usize::from(self.decimals) + 1
            } else {
                0
            };
        let p = pad(len, usize::from(self.width));
        let sign = if neg { "-" } else { "" };
        match self.decimals {
            0 => defmt::write!(f, "{=str}{=str}{=u32}", p, sign, int),
            1 => defmt::write!(f, "{=str}{=str}{=u32}.{=u32:01}", p, sign, int, frac),
            2 => defmt::write!(f, "{=str}{=str}{=u32}.{=u32:02}", p, sign, int, frac),
            _ => defmt::write!(f, "{=str}{=str}{=u32}.{=u32:03}", p, sign, int, frac),
        }
    }
}

/// Metres as millimetres with 3 decimals.
fn mm(x: f32, width: u8) -> Fixed {
    Fixed::new(x * 1000.0, 3, width)
}

/// A time in ms, printed as seconds (`1.250`).
struct Secs(u64);

impl defmt::Format for Secs {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=u64}.{=u64:03}", self.0 / 1000, self.0 % 1000);
    }
}

/// An optional time in ms for the RESULT line (`-` when absent).
struct OptMs(Option<Instant>);

impl defmt::Format for OptMs {
    fn format(&self, f: defmt::Formatter) {
        match self.0 {
            Some(t) => defmt::write!(f, "{=u64}", to_ms(t)),
            None => defmt::write!(f, "-"),
        }
    }
}

fn state_name(s: RunningState) -> &'static str {
    match s {
        RunningState::Idle => "Idle",
        RunningState::Running => "Running",
        RunningState::Paused => "Paused",
        RunningState::Aborting => "Aborting",
        RunningState::Aborted => "Aborted",
        RunningState::Terminated => "Terminated",
        RunningState::Restarting => "Restarting",
    }
}

fn seq_name(id: SeqId) -> &'static str {
    SEQ.sequence_by_id(id).map_or("?", |h| h.name())
}

fn monitor_name(m: MonitorId) -> &'static str {
    if m == FOLLOWING_ERROR {
        "following error"
    } else if m == HOMING_FOLLOWING_ERROR {
        "homing following error"
    } else if m == HOMING_END_STOP {
        "homing end stop"
    } else if m == END_STOP {
        "end stop"
    } else if m == PAUSE {
        "pause"
    } else if m == RESUME {
        "resume"
    } else {
        "?"
    }
}

/// What a monitor's firing does (for the log).
fn monitor_effect(m: MonitorId) -> &'static str {
    if m == FOLLOWING_ERROR {
        "safe stop, then restart the moves (at most 3 times, then abort)"
    } else if m == HOMING_FOLLOWING_ERROR {
        "safe stop, abort homing"
    } else if m == HOMING_END_STOP {
        "abort homing (the wrong end stop)"
    } else if m == END_STOP {
        "abort the moves"
    } else if m == PAUSE {
        "feed hold: pause the moves"
    } else if m == RESUME {
        "feed resume: resume the moves"
    } else {
        "?"
    }
}

/// Logs an event of the trace; a monitor's firing is counted in `fired`.
fn log_event(e: rtseq::Event, seen: &mut Seen) {
    use rtseq::Event;
    let fired = &mut seen.fired;
    match e {
        Event::Fired {
            cause: Cause::Monitor(m),
            ..
        } => {
            let n = fired.get_mut(m.index()).map_or(0, |n| {
                *n = n.saturating_add(1);
                *n
            });
            defmt::info!(
                "monitor   '{=str}' fired ({=u16}): {=str}",
                monitor_name(m),
                n,
                monitor_effect(m)
            );
        }
        Event::Fired {
            owner, behaviour, ..
        } => defmt::info!(
            "timeout   of '{=str}' ran out: {=str}",
            seq_name(owner),
            behaviour_name(behaviour)
        ),
        Event::ExceptionNotRun {
            exception,
            owner,
            why,
        } => defmt::warn!(
            "exception '{=str}' of '{=str}' not run: {=str}",
            seq_name(exception),
            seq_name(owner),
            why.reason()
        ),
        Event::Requested {
            sequence,
            request,
            by,
        } => defmt::info!(
            "request   {=str} '{=str}' by {=str}{=str}",
            match request {
                Request::Pause => "pause",
                Request::Resume => "resume",
                Request::Abort => "abort",
            },
            seq_name(sequence),
            requester_name(by),
            match by {
                Requester::Sequence(id) => seq_name(id),
                _ => "",
            }
        ),
        Event::AbortAll { by } => {
            defmt::info!("request   abort all by {=str}", requester_name(by))
        }
        Event::Failed { sequence, failure } => {
            defmt::warn!(
                "failed    '{=str}': {}",
                seq_name(sequence),
                FailureText(failure)
            )
        }
        Event::SafetyLevel { level } => {
            match seen.level {
                Some(from) => defmt::info!(
                    "safety    level {=str} -> {=str}",
                    level_name(from),
                    level_name(level)
                ),
                None => defmt::info!("safety    level {=str} (entry level)", level_name(level)),
            }
            seen.level = Some(level);
            seen.emergency |= level == safety::EMERGENCY;
        }
        Event::InputTripped { input } => {
            defmt::info!("safety    critical input: {=str}", input_name(input))
        }
    }
}

/// What the log learnt from the trace's events.
#[derive(Clone, Copy)]
struct Seen {
    /// Monitor fire counts.
    fired: [u16; app::MONITORS],
    /// The safety level last entered.
    level: Option<SafetyLevel>,
    /// Whether the safety system entered EMERGENCY.
    emergency: bool,
}

/// A critical input's name, for the log.
fn input_name(input: InputId) -> &'static str {
    match input {
        i if i == safety::ESTOP_IN.id() => "e-stop pressed",
        i if i == safety::CURRENT_IN.id() => "over-current (|i| > 6 A)",
        i if i == safety::END_NEG_IN.id() => "end stop - closed",
        i if i == safety::END_POS_IN.id() => "end stop + closed",
        _ => "?",
    }
}

/// A behaviour's name, for the log.
fn behaviour_name(b: Behaviour) -> &'static str {
    match b {
        Behaviour::Nothing => "nothing",
        Behaviour::AbortOwner => "abort the owner",
        Behaviour::RestartOwner => "restart the owner",
        Behaviour::AbortCallerOfOwner => "abort the owner's caller",
        Behaviour::RestartCallerOfOwner => "restart the owner's caller",
        Behaviour::PauseOwner => "pause the owner",
    }
}

/// A failure as text.
struct FailureText(Failure);

impl defmt::Format for FailureText {
    fn format(&self, f: defmt::Formatter) {
        match self.0 {
            Failure::App(code) => defmt::write!(f, "application code {=u16}", code),
            Failure::Aborted(c) => {
                defmt::write!(f, "a sub-sequence was aborted ({})", CauseText(c))
            }
            Failure::NotStarted(e) => defmt::write!(f, "not started: {=str}", e.reason()),
        }
    }
}

/// Who made a request, for the log (a sequence's name follows).
fn requester_name(by: Requester) -> &'static str {
    match by {
        Requester::Sequence(_) => "sequence ",
        Requester::Application => "the application",
        Requester::SafetySystem => "the safety system",
    }
}

/// A cause as text (`tests/qemu_demo.rs` formats the host trace the same way).
struct CauseText(Cause);

impl defmt::Format for CauseText {
    fn format(&self, f: defmt::Formatter) {
        match self.0 {
            Cause::Start => defmt::write!(f, "start"),
            Cause::PreConditionFalse => defmt::write!(f, "pre-condition false"),
            Cause::Completed => defmt::write!(f, "completed"),
            Cause::Pause => defmt::write!(f, "pause"),
            Cause::Resume => defmt::write!(f, "resume"),
            Cause::Abort => defmt::write!(f, "abort"),
            Cause::AbortAll => defmt::write!(f, "abort all"),
            Cause::Monitor(m) => defmt::write!(f, "monitor {=str}", monitor_name(m)),
            Cause::Timeout(s) => defmt::write!(f, "timeout of {=str}", seq_name(s)),
            Cause::Restart => defmt::write!(f, "restart"),
            Cause::Dropped => defmt::write!(f, "dropped"),
            Cause::Failed => defmt::write!(f, "failed"),
        }
    }
}

/// An outcome as text.
struct OutcomeText(Option<Outcome>);

impl defmt::Format for OutcomeText {
    fn format(&self, f: defmt::Formatter) {
        match self.0 {
            None => defmt::write!(f, "none"),
            Some(Outcome::Completed) => defmt::write!(f, "completed"),
            Some(Outcome::Skipped) => defmt::write!(f, "skipped"),
            Some(Outcome::Aborted(c)) => defmt::write!(f, "aborted ({})", CauseText(c)),
            // The demo's actions do not fail.
            Some(Outcome::Failed(_)) => defmt::write!(f, "failed"),
        }
    }
}

// Out of line: one copy of the table look-up for the log's five call sites.
#[inline(never)]
fn level_name(l: SafetyLevel) -> &'static str {
    safety::PROPERTIES.level(l).map_or("?", |d| d.name())
}

fn fault_name(k: FaultKind) -> &'static str {
    match k {
        FaultKind::FollowingError => "following error",
        FaultKind::OverCurrent => "over-current",
        FaultKind::EndStop => "end stop",
        FaultKind::EStop => "e-stop",
    }
}

fn fault_what(k: FaultKind) -> &'static str {
    match k {
        FaultKind::FollowingError => "the axis jams",
        FaultKind::OverCurrent => "the current sensor reads +12 A",
        FaultKind::EndStop => "the + end-stop switch closes",
        FaultKind::EStop => "the emergency-stop button is pressed",
    }
}

fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Off => "off",
        Phase::PowerOn => "power on",
        Phase::Homing => "homing",
        Phase::Moving => "moving",
        Phase::Paused => "paused",
        Phase::SafeStop => "safe stop",
        Phase::Done => "done",
        Phase::Fault => "fault",
    }
}

const FAULT_KINDS: [FaultKind; 4] = [
    FaultKind::FollowingError,
    FaultKind::OverCurrent,
    FaultKind::EndStop,
    FaultKind::EStop,
];

/// Short key of a fault kind for the RESULT line.
fn fault_key(k: FaultKind) -> &'static str {
    match k {
        FaultKind::FollowingError => "fe",
        FaultKind::OverCurrent => "oc",
        FaultKind::EndStop => "es",
        FaultKind::EStop => "estop",
    }
}

// ---------------------------------------------------------------------------------------
// Expectations
// ---------------------------------------------------------------------------------------

/// What a fault must lead to, decided from the state at its injection.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Expect {
    /// No effect on the sequences (nothing moves any more, or an earlier fault is handled).
    Nothing,
    /// Jammed, or the positive end stop closed, before homing completed: homing is
    /// aborted, by its following-error monitor (jammed while the setpoint moves), its
    /// end-stop monitor (the positive switch) or its timeout (jammed at rest).
    HomingAborted,
    /// Jammed with moves left: safe stop and restart of the moves 3 times, then abort.
    FollowingErrorAbort,
    /// End stop while the moves sequence has not ended (a move or a dwell runs, the last
    /// dwell too, or the moves are still to come): the end-stop monitor aborts the moves;
    /// `moves_done` were done at the injection.
    EndStopAbort { moves_done: u16 },
    /// Over-current / e-stop: the safety system enters emergency (aborting every sequence
    /// if main still runs at the trip, one safety cycle after the injection).
    Emergency { main_active: bool },
}

/// What the pause window must lead to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum PauseExpect {
    /// No pause planned, or pressed when nothing moved any more.
    Nothing,
    /// Pressed while moves were left: paused at the first press, resumed at the second.
    PauseResume,
}

fn expectation(kind: FaultKind, s: &Snapshot, config: &AppConfig) -> Expect {
    let moves_ahead = !matches!(
        s.moves_state,
        RunningState::Terminated | RunningState::Aborted
    );
    let moves_left = usize::from(s.moves_done) < config.move_count && moves_ahead;
    // Jammed within the back off's in-position tolerance of its target, the axis settles
    // where it stands: homing completes and the jam shows in the first move.
    let homing_completes = s.zeroed && (s.position - config.back_off).abs() <= POSITION_TOLERANCE;
    // The following-error monitor's last firing (restart limit reached) aborts the moves
    // once its safe stop has ended: at the start of this tick, before the end-stop monitor.
    let fe_abort_due = s.safe_stops > u16::from(config.restart_limit) && !s.safe_stop_active;
    match kind {
        FaultKind::OverCurrent | FaultKind::EStop => Expect::Emergency {
            main_active: (s.main_active && !s.powering_off) || !s.main_started,
        },
        _ if s.main_started && !s.main_active => Expect::Nothing,
        FaultKind::FollowingError if !s.homed && !homing_completes => Expect::HomingAborted,
        FaultKind::EndStop if !s.homed => Expect::HomingAborted,
        FaultKind::FollowingError if moves_left => Expect::FollowingErrorAbort,
        FaultKind::EndStop if moves_ahead && !fe_abort_due => Expect::EndStopAbort {
            moves_done: s.moves_done,
        },
        _ => Expect::Nothing,
    }
}

/// Whether `later` decides the run instead of `earlier`, decided by an earlier fault that
/// is still acting.
fn overtakes(earlier: Option<Expect>, later: Expect) -> bool {
    match (earlier, later) {
        (None, _) => true,
        // The end stop aborts the moves at once; the following error's restarts run them
        // again.
        (Some(Expect::FollowingErrorAbort), Expect::EndStopAbort { .. }) => true,
        _ => false,
    }
}

// ---------------------------------------------------------------------------------------
// The log (idle)
// ---------------------------------------------------------------------------------------

/// Idle's state: what was printed, what is expected.
struct Log {
    plan: FaultPlan,
    expect: [Option<(FaultKind, u64, Expect)>; MAX_FAULTS],
    pause: PauseExpect,
    next_status: u64,
    moves_done: u16,
    main_end: Option<u64>,
    /// Last start of the move step, ms.
    move_start: Option<u64>,
    /// When the jam could first show as a following error: the injection, or the next
    /// move start if the axis stood still then, ms.
    fe_visible: Option<u64>,
    /// What the trace's events told.
    seen: Seen,
    blinks: u32,
    /// Restarts of the moves sequence, counted from the transition trace.
    moves_restarts: u16,
    /// Aborts of the move step, counted from the transition trace.
    move_step_aborts: u16,
    trace_lost: u32,
    reacted: [bool; 4],
    stopped: [bool; 4],
}

impl Log {
    fn new(plan: FaultPlan) -> Self {
        Log {
            plan,
            expect: [None; MAX_FAULTS],
            pause: PauseExpect::Nothing,
            next_status: STATUS_EVERY_MS,
            moves_done: 0,
            main_end: None,
            move_start: None,
            seen: Seen {
                fired: [0; app::MONITORS],
                level: None,
                emergency: false,
            },
            fe_visible: None,
            blinks: 0,
            moves_restarts: 0,
            move_step_aborts: 0,
            trace_lost: 0,
            reacted: [false; 4],
            stopped: [false; 4],
        }
    }

    fn drain_trace(&mut self) {
        let mut main_end = self.main_end;
        let mut blinks = self.blinks;
        let mut move_start = self.move_start;
        let mut moves_restarts = self.moves_restarts;
        let mut move_step_aborts = self.move_step_aborts;
        let mut seen = self.seen;
        let lost = SEQ.drain_records(|r| {
            let t = match r.entry {
                Entry::Transition {
                    sequence,
                    from,
                    to,
                    cause,
                } => Transition {
                    time: r.time,
                    sequence,
                    from,
                    to,
                    cause,
                },
                Entry::Event(e) => return log_event(e, &mut seen),
            };
            if t.sequence == MOVE && t.to == RunningState::Running {
                move_start = Some(to_ms(t.time));
            }
            if t.sequence == MOVES && t.to == RunningState::Restarting {
                moves_restarts = moves_restarts.saturating_add(1);
            }
            if t.sequence == MOVE && t.to == RunningState::Aborted {
                move_step_aborts = move_step_aborts.saturating_add(1);
            }
            if t.sequence == BLINK && matches!(t.cause, Cause::Start | Cause::Completed) {
                if t.to == RunningState::Running {
                    blinks = blinks.saturating_add(1);
                }
            } else {
                let name = seq_name(t.sequence);
                let (from, to) = (state_name(t.from), state_name(t.to));
                defmt::info!(
                    "seq       {=str}{=str} {=str} -> {=str}{=str} ({})",
                    name,
                    pad(name.len(), 14),
                    from,
                    to,
                    pad(from.len() + to.len(), 22),
                    CauseText(t.cause)
                );
            }
            if t.sequence == MAIN
                && matches!(t.to, RunningState::Terminated | RunningState::Aborted)
            {
                main_end = Some(to_ms(t.time));
            }
        });
        self.main_end = main_end;
        self.move_start = move_start;
        self.moves_restarts = moves_restarts;
        self.move_step_aborts = move_step_aborts;
        self.blinks = blinks;
        self.seen = seen;
        self.trace_lost = self.trace_lost.saturating_add(lost);
    }

    fn drain_events(&mut self) {
        while let Some(e) = EVENTS.pop() {
            match e {
                Event::Fault { kind, at, snap } => {
                    let exp = expectation(kind, &snap, &CONFIG);
                    defmt::info!(
                        "FAULT     {=str} injected: {=str}",
                        fault_name(kind),
                        fault_what(kind)
                    );
                    if let Some(slot) = self.expect.iter_mut().find(|s| s.is_none()) {
                        *slot = Some((kind, at, exp));
                    }
                }
                Event::Pause { second, snap } => {
                    defmt::info!(
                        "BUTTON    pause button pressed ({=str})",
                        if second { "resume" } else { "pause" }
                    );
                    if !second {
                        let moves_running = matches!(
                            snap.moves_state,
                            RunningState::Running | RunningState::Paused | RunningState::Restarting
                        );
                        // (Argument parsing puts the first press after homing.)
                        self.pause = if snap.main_active
                            && moves_running
                            && usize::from(snap.moves_done) < CONFIG.move_count
                        {
                            PauseExpect::PauseResume
                        } else {
                            PauseExpect::Nothing
                        };
                    }
                }
            }
        }
    }

    /// Moves done, reactions, periodic status.
    fn watch(&mut self, now: u64) {
        let s = CS.summary();
        while self.moves_done < s.moves_done {
            self.moves_done = self.moves_done.saturating_add(1);
            let i = usize::from(self.moves_done).saturating_sub(1);
            let target = CONFIG.targets.get(i).copied().unwrap_or(0.0);
            defmt::info!(
                "move      {=usize}/{=usize} done: in position at {} mm (target {} mm)",
                i.saturating_add(1),
                CONFIG.move_count,
                mm(CS.position(), 0),
                mm(target, 0)
            );
        }
        for (i, k) in FAULT_KINDS.iter().enumerate() {
            let r = s.reaction(*k);
            if let (Some(flag), Some(_), Some(lat)) =
                (self.reacted.get_mut(i), r.reacted, r.latency())
            {
                if !*flag {
                    *flag = true;
                    defmt::info!(
                        "reaction  {=str}: {=str} {=u64} ms after the fault",
                        fault_name(*k),
                        reaction_text(*k),
                        lat.as_millis()
                    );
                    // A jam of a standing axis shows only when the next move starts.
                    let (inj, react) = (r.injected.map_or(0, to_ms), r.reacted.map_or(0, to_ms));
                    match self.move_start {
                        Some(m) if *k == FaultKind::FollowingError && m > inj && m <= react => {
                            self.fe_visible = Some(m);
                            defmt::info!(
                                "reaction  (the axis stood still when it jammed: the following error built up in the {=u64} ms after the next move started)",
                                react.saturating_sub(m)
                            );
                        }
                        _ if *k == FaultKind::FollowingError => self.fe_visible = Some(inj),
                        _ => {}
                    }
                }
            }
            if let (Some(flag), Some(_), Some(lat)) =
                (self.stopped.get_mut(i), r.stopped, r.stop_latency())
            {
                if !*flag {
                    *flag = true;
                    defmt::info!(
                        "reaction  {=str}: motor stopped {=u64} ms after the fault (at {} mm)",
                        fault_name(*k),
                        lat.as_millis(),
                        mm(CS.position(), 0)
                    );
                }
            }
        }
        if now >= self.next_status {
            self.next_status = self.next_status.saturating_add(STATUS_EVERY_MS);
            status_line();
        }
    }
}

fn reaction_text(k: FaultKind) -> &'static str {
    match k {
        FaultKind::FollowingError => "safe stop started",
        FaultKind::OverCurrent | FaultKind::EStop => {
            "the safety system tripped (level emergency, drive permit off)"
        }
        FaultKind::EndStop => "moves aborted, quick stop",
    }
}

/// One line of axis status.
fn status_line() {
    let st = CS.status();
    defmt::info!(
        "axis      x {} mm  v {} mm/s  i {} A  | {=str}, level {=str}, LED {=str}",
        mm(st.position, 8),
        Fixed::new(st.velocity * 1000.0, 1, 6),
        Fixed::new(st.true_current, 2, 5),
        phase_name(CS.phase()),
        level_name(SEQ.safety_handle().level()),
        if CS.led() { "on" } else { "off" }
    );
}

/// Prints a check; returns whether it held.
fn check(ok: bool, what: &str) -> bool {
    if ok {
        defmt::info!("check     ok    {=str}", what);
    } else {
        defmt::error!("check     FAIL  {=str}", what);
    }
    ok
}

impl Log {
    /// The end of the run: summary, RESULT line, checks. Returns whether all held.
    fn finish(&mut self, now: u64) -> bool {
        let s = CS.summary();
        let st = CS.status();
        let plant = CS.plant();
        let fired = self.seen.fired;
        let fired_of = |m: MonitorId| fired.get(m.index()).copied().unwrap_or(0);
        let level = SEQ.safety_handle().level();
        status_line();
        defmt::info!("---------------------------------------- summary");
        defmt::info!(
            "summary   moves {=u16} of {=usize} done; homed at {=str}{}; main ended {=str}{} ({})",
            s.moves_done,
            CONFIG.move_count,
            if s.homed_at.is_some() { "" } else { "never" },
            OptSecs(s.homed_at),
            if self.main_end.is_some() {
                "at "
            } else {
                "never"
            },
            OptSecs(self.main_end.map(ms)),
            OutcomeText(outcome_of(MAIN))
        );
        defmt::info!(
            "summary   homing {}, moves {}, safe stops {=u16}, monitors fired: following error {=u16}, end stop {=u16}, pause {=u16}, resume {=u16}",
            OutcomeText(outcome_of(HOMING)),
            OutcomeText(outcome_of(MOVES)),
            s.safe_stops,
            fired_of(FOLLOWING_ERROR),
            fired_of(END_STOP),
            fired_of(PAUSE),
            fired_of(RESUME)
        );
        for k in FAULT_KINDS {
            let r = s.reaction(k);
            if let Some(inj) = r.injected {
                defmt::info!(
                    "summary   {=str} at {} s: {}",
                    fault_name(k),
                    Secs(to_ms(inj)),
                    ReactionText(r)
                );
            }
        }
        if let Some(w) = self.plan.pause {
            defmt::info!(
                "summary   pause window {}..{}: paused at {}, resumed at {}",
                Secs(to_ms(w.start)),
                Secs(to_ms(w.end)),
                OptSecs(s.paused_at),
                OptSecs(s.resumed_at)
            );
        }
        defmt::info!(
            "summary   axis at {} mm, {} mm/s, {} A; drive {=str}, brake {=str}; safety level {=str}; LED blinked {=u32} times",
            mm(st.position, 0),
            Fixed::new(plant.velocity() * 1000.0, 3, 0),
            Fixed::new(plant.current(), 3, 0),
            if st.enabled { "on" } else { "off" },
            if st.brake { "on" } else { "off" },
            level_name(level),
            self.blinks
        );
        // The parseable line (tests/qemu_demo.rs).
        defmt::info!(
            "RESULT end_ms={=u64}; level={=str}; phase={=str}; main={}; homing={}; moves={}; moves_done={=u16}; safe_stops={=u16}; homed_ms={}; finished_ms={}; paused_ms={}; resumed_ms={}; blinks={=u32}",
            now,
            level_name(level),
            phase_name(CS.phase()),
            OutcomeText(outcome_of(MAIN)),
            OutcomeText(outcome_of(HOMING)),
            OutcomeText(outcome_of(MOVES)),
            s.moves_done,
            s.safe_stops,
            OptMs(s.homed_at),
            OptMs(s.finished_at),
            OptMs(s.paused_at),
            OptMs(s.resumed_at),
            self.blinks
        );
        defmt::info!(
            "RESULT move_done_ms={}; fired_fe={=u16}; fired_es={=u16}; fired_pause={=u16}; fired_resume={=u16}",
            MoveTimes(s.move_done_at),
            fired_of(FOLLOWING_ERROR),
            fired_of(END_STOP),
            fired_of(PAUSE),
            fired_of(RESUME)
        );
        for k in FAULT_KINDS {
            let r = s.reaction(k);
            defmt::info!(
                "RESULT fault={=str}; injected_ms={}; reacted_ms={}; stopped_ms={}",
                fault_key(k),
                OptMs(r.injected),
                OptMs(r.reacted),
                OptMs(r.stopped)
            );
        }
        defmt::info!(
            "RESULT pos_um={=i32}; vel_um_s={=i32}; current_ma={=i32}; enabled={=bool}; brake={=bool}; permit={=bool}",
            (st.position * 1e6) as i32,
            (plant.velocity() * 1e6) as i32,
            (plant.current() * 1e3) as i32,
            st.enabled,
            st.brake,
            CS.drive_permit()
        );

        defmt::info!("---------------------------------------- checks");
        let mut ok = true;
        ok &= check(
            self.trace_lost == 0 && EVENTS.lost() == 0,
            "no trace record or event lost",
        );
        ok &= check(
            SEQ.exceptions_not_run() == 0,
            "every exception sequence ran",
        );
        ok &= check(!state_of(MAIN).is_active(), "main has ended");
        let all_idle = [
            MAIN,
            STATUS,
            HOMING,
            MOVES,
            MOVE,
            SAFE_STOP,
            FEED_HOLD,
            FEED_RESUME,
        ]
        .iter()
        .all(|&id| !state_of(id).is_active());
        ok &= check(all_idle, "no sequence is still active");
        ok &= check(
            plant.velocity().abs() < STOP_VELOCITY && plant.current().abs() < STOP_CURRENT,
            "the motor stands still without current (|v| < 0.1 mm/s, |i| < 50 mA)",
        );
        ok &= check(!st.enabled && st.brake, "drive disabled, brake engaged");

        // The faults: an emergency while main ran decides everything; otherwise the first
        // fault with an effect, unless a later one overtakes it (`overtakes`); faults that
        // find nothing running expect nothing.
        let emergency = self
            .expect
            .iter()
            .flatten()
            .any(|(_, _, e)| *e == Expect::Emergency { main_active: true });
        let mut decisive: Option<(FaultKind, Expect)> = None;
        let mut any_effect = false;
        for (kind, _, e) in self.expect.iter().flatten().copied() {
            match e {
                Expect::Emergency { main_active } => {
                    any_effect = true;
                    let r = s.reaction(kind);
                    ok &= check(
                        self.seen.emergency && level == safety::EMERGENCY,
                        "the safety system entered and stays in level emergency",
                    );
                    ok &= check(!CS.drive_permit(), "the drive permit is withdrawn");
                    if main_active {
                        ok &= check(
                            r.latency().is_some_and(|l| l.as_millis() <= 2),
                            "the safety system withdrew the drive permit within 2 ms",
                        );
                        ok &= check(
                            outcome_of(MAIN) == Some(Outcome::Aborted(Cause::AbortAll)),
                            "every sequence was aborted (main: abort all)",
                        );
                    }
                }
                Expect::Nothing => {}
                _ => {
                    any_effect = true;
                    if overtakes(decisive.map(|(_, d)| d), e) {
                        decisive = Some((kind, e));
                    }
                }
            }
        }
        let decided = decisive.filter(|_| !emergency);
        if let Some((kind, e)) = decided {
            let r = s.reaction(kind);
            match e {
                Expect::HomingAborted => {
                    ok &= check(
                        matches!(
                            outcome_of(HOMING),
                            Some(Outcome::Aborted(Cause::Timeout(HOMING)))
                        ) || outcome_of(HOMING)
                            == Some(Outcome::Aborted(Cause::Monitor(HOMING_FOLLOWING_ERROR)))
                            || outcome_of(HOMING)
                                == Some(Outcome::Aborted(Cause::Monitor(HOMING_END_STOP))),
                        "fault while homing: homing was aborted (its monitors or its timeout)",
                    );
                    ok &= check(
                        CS.phase() == Phase::Fault,
                        "the application ended in phase fault",
                    );
                }
                Expect::FollowingErrorAbort => {
                    let n = u16::from(CONFIG.restart_limit).saturating_add(1);
                    ok &= check(
                        fired_of(FOLLOWING_ERROR) == n && s.safe_stops == n,
                        "the following-error monitor fired 4 times, each with a safe stop",
                    );
                    ok &= check(
                        self.moves_restarts == u16::from(CONFIG.restart_limit),
                        "the moves were restarted 3 times",
                    );
                    ok &= check(
                        outcome_of(MOVES)
                            == Some(Outcome::Aborted(Cause::Monitor(FOLLOWING_ERROR))),
                        "then the moves were aborted (restart limit)",
                    );
                    ok &= check(
                        r.reacted.map(to_ms).zip(self.fe_visible).is_some_and(|(t, v)| t.saturating_sub(v) <= 60),
                        "the safe stop started within 60 ms of the jam (of the next move start if the axis stood still)",
                    );
                    ok &= check(
                        CS.phase() == Phase::Fault && outcome_of(MAIN) == Some(Outcome::Completed),
                        "main stopped the axis and powered off (phase fault)",
                    );
                }
                Expect::EndStopAbort { moves_done } => {
                    ok &= check(
                        outcome_of(MOVES) == Some(Outcome::Aborted(Cause::Monitor(END_STOP))),
                        "the end-stop monitor aborted the moves",
                    );
                    ok &= check(
                        s.moves_done == moves_done,
                        "no move was completed after the end stop",
                    );
                    ok &= check(
                        r.stop_latency().is_some(),
                        "the motor stopped after the reaction",
                    );
                    ok &= check(
                        CS.phase() == Phase::Fault && outcome_of(MAIN) == Some(Outcome::Completed),
                        "main stopped the axis and powered off (phase fault)",
                    );
                }
                Expect::Nothing | Expect::Emergency { .. } => {}
            }
        }
        if let (Some(w), false) = (self.plan.pause, emergency || decided.is_some()) {
            match self.pause {
                PauseExpect::PauseResume => {
                    let inside = |t: Option<Instant>, want: Instant| {
                        t.is_some_and(|t| t >= want && to_ms(t) <= to_ms(want) + 1)
                    };
                    ok &= check(
                        inside(s.paused_at, w.start),
                        "the moves were paused at the first press (feed hold)",
                    );
                    ok &= check(
                        inside(s.resumed_at, w.end),
                        "and resumed at the second press (feed resume)",
                    );
                    ok &= check(
                        self.move_step_aborts == 0,
                        "the paused move was not aborted (paused time does not count for its timeout)",
                    );
                }
                PauseExpect::Nothing => {}
            }
        }
        if !any_effect {
            ok &= check(
                CS.phase() == Phase::Done && usize::from(s.moves_done) == CONFIG.move_count,
                "all moves done, phase done",
            );
            ok &= check(
                level == safety::OFF,
                "the safety system is back in level off",
            );
            let pos = st.position;
            let last = CONFIG
                .targets
                .get(CONFIG.move_count.saturating_sub(1))
                .copied()
                .unwrap_or(0.0);
            ok &= check(
                (pos - last).abs() <= 20e-6,
                "the axis is at the last target (within 20 um)",
            );
        }
        ok
    }
}

/// An optional time printed as seconds (nothing when absent).
struct OptSecs(Option<Instant>);

impl defmt::Format for OptSecs {
    fn format(&self, f: defmt::Formatter) {
        if let Some(t) = self.0 {
            defmt::write!(f, "{} s", Secs(to_ms(t)));
        }
    }
}

/// A reaction record for the summary.
struct ReactionText(rtseq_motor::app::Reaction);

impl defmt::Format for ReactionText {
    fn format(&self, f: defmt::Formatter) {
        match (self.0.latency(), self.0.stop_latency()) {
            (Some(r), Some(s)) => defmt::write!(
                f,
                "reaction after {=u64} ms, motor stopped after {=u64} ms",
                r.as_millis(),
                s.as_millis()
            ),
            (Some(r), None) => defmt::write!(f, "reaction after {=u64} ms", r.as_millis()),
            _ => defmt::write!(f, "no reaction needed (the axis was not moving)"),
        }
    }
}

/// The move completion times, comma-separated ms (`-` for moves not done).
struct MoveTimes([Option<Instant>; app::MAX_MOVES]);

impl defmt::Format for MoveTimes {
    fn format(&self, f: defmt::Formatter) {
        for (i, t) in self.0.iter().enumerate() {
            if i > 0 {
                defmt::write!(f, ",");
            }
            defmt::write!(f, "{}", OptMs(*t));
        }
    }
}

/// Prints the plan at the start.
fn announce(plan: &FaultPlan) {
    defmt::info!(
        "demo      motor controller on the emulated STM32F405: 1 kHz control + sequencer tick (TIM2), safety system at the highest priority, 5 lanes"
    );
    defmt::info!(
        "demo      program: power on, homing (seek the - end stop at 20 mm/s, zero, back off to 5 mm), {=usize} moves, power off",
        CONFIG.move_count
    );
    let mut any = false;
    for f in plan.faults.iter().flatten() {
        any = true;
        defmt::info!(
            "demo      plan: {=str} at {} s ({=str})",
            fault_name(f.kind()),
            Secs(to_ms(f.at())),
            fault_what(f.kind())
        );
    }
    if let Some(w) = plan.pause {
        any = true;
        defmt::info!(
            "demo      plan: pause button pressed at {} s and at {} s",
            Secs(to_ms(w.start)),
            Secs(to_ms(w.end))
        );
    }
    if !any {
        defmt::info!("demo      plan: no fault (try --help for fault injection)");
    }
}

/// When the run ends: `SETTLE_MS` after main ended and after the last planned event.
fn end_time(plan: &FaultPlan, main_end: Option<u64>) -> Option<u64> {
    let mut last = main_end?;
    for f in plan.faults.iter().flatten() {
        last = last.max(to_ms(f.at()));
    }
    if let Some(w) = plan.pause {
        last = last.max(to_ms(w.end));
    }
    Some(last.saturating_add(SETTLE_MS))
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX, CAN1_RX0])]
mod rtic_app {
    use super::*;
    use board::clock::TickTimer;
    use board::signal::TickSignal;
    use rtseq::safety::SafetySystem;
    use rtseq_motor::app::App;

    /// Tick -> safety task.
    static TO_SAFETY: TickSignal = TickSignal::new();

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        monitors: app::AppMonitors,
        system: SafetySystem<'static, safety::DriveIo, 4>,
        plan_tick: FaultPlan,
        log: Log,
        app: App,
    }

    #[init(local = [args: [u8; 256] = [0; 256]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // The run's deepest stack is printed at its end.
        board::stack::paint_unused();
        let args = match board::args::args(cx.local.args) {
            Ok(a) => a,
            Err(e) => {
                defmt::error!("demo: {}: nothing was run", e);
                usage();
                board::exit(board::ExitCode::Failure);
            }
        };
        let opts = match parse_args(args) {
            Ok(o) => o,
            Err(e) => {
                defmt::error!("demo: {=str}: '{=str}'", e.msg, e.arg);
                usage();
                board::exit(board::ExitCode::Failure);
            }
        };
        if opts.help {
            usage();
            board::exit_success();
        }
        let plan = opts.plan;
        announce(&plan);
        CS.set_fault_plan(plan);
        // Built by the compiler: no monitor set-up code in the firmware.
        let monitors = const {
            match app::monitor_ids::table(&CONFIG) {
                Ok(m) => m,
                Err(e) => panic!("{}", e.message().as_str()),
            }
        };
        let app = match app::register(&SEQ, &SETUP) {
            Ok(a) => a,
            Err(e) => {
                // `reason()`: no derived `defmt::Format` of every `rtseq::Error` variant is linked.
                defmt::error!("demo: registration failed: {=str}", e.reason());
                board::exit_failure();
            }
        };
        let Ok(system) = SafetySystem::new_validated(&safety::PROPERTIES, SEQ.safety_handle())
        else {
            defmt::error!("demo: the safety system could not start");
            board::exit_failure();
        };
        if let Some(Err(e)) = SEQ.sequence_by_id(MAIN).map(|h| h.start()) {
            defmt::error!("demo: cannot start main: {=str}", e.reason());
            board::exit_failure();
        }
        // Spawning from init cannot fail (each task once).
        safety_task::spawn().ok();
        lanes::spawn().ok();
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (
            Shared {},
            Local {
                timer,
                monitors,
                system,
                plan_tick: plan,
                log: Log::new(plan),
                app,
            },
        )
    }

    /// Prints what happened, samples the axis, ends the run.
    #[idle(local = [log])]
    fn idle(cx: idle::Context) -> ! {
        // The tasks spawned in `init` have run up to their first wait.
        if let Err(e) = SEQ.check_lanes() {
            defmt::error!("demo: a lane task is missing: {=str}", e.reason());
            board::exit_failure();
        }
        let log = cx.local.log;
        loop {
            log.drain_events();
            log.drain_trace();
            let now = to_ms(CS.now());
            log.watch(now);
            if let Some(end) = end_time(&log.plan, log.main_end) {
                if now >= end {
                    let ok = log.finish(now);
                    defmt::info!(
                        "demo      stack: {=usize} B at the deepest, of {=usize} B",
                        board::stack::peak(),
                        board::stack::size()
                    );
                    if ok {
                        defmt::info!("demo      outcome as expected: exit 0");
                        board::exit_success();
                    }
                    defmt::error!("demo      outcome NOT as expected: exit 1");
                    board::exit_failure();
                }
            }
            if now >= LIMIT_MS {
                let _ = log.finish(now);
                defmt::error!(
                    "demo      the run did not end within {=u64} s: exit 1",
                    LIMIT_MS / 1000
                );
                board::exit_failure();
            }
            // Sleep until the next interrupt; check for news with interrupts masked so a
            // tick between the check and WFI is not slept through.
            cortex_m::interrupt::disable();
            if EVENTS.is_empty() {
                cortex_m::asm::wfi();
            }
            // SAFETY: not inside a critical section of ours; RTIC uses BASEPRI.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    /// The 1 kHz heartbeat: fault injection, safety cycle (priority 3, preempts here),
    /// control step, sequencer tick.
    #[task(binds = TIM2, priority = 2, local = [timer, monitors, plan_tick, injections: Injections = Injections::new()])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        CS.inject(now);
        cx.local.injections.check(now, cx.local.plan_tick);
        TO_SAFETY.signal(now);
        // Make sure the safety task has run before the control step (pended above).
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        CS.control_step(DT);
        if let Err(e) = SEQ.tick(now, &CS, cx.local.monitors) {
            defmt::error!("tick: {}", e);
        }
    }

    /// The safety system: one cycle per tick, highest priority.
    /// The levels it enters and the inputs that trip reach the log through the sequencer's
    /// trace.
    #[task(priority = 3, local = [system])]
    async fn safety_task(cx: safety_task::Context) {
        loop {
            let _now = TO_SAFETY.wait().await;
            safety::safety_cycle(&CS, cx.local.system, &SEQ);
        }
    }

    /// The five lanes of the application, joined (main's start is applied by the first
    /// tick).
    #[task(priority = 1, local = [app])]
    async fn lanes(cx: lanes::Context) {
        match cx.local.app.run(&SEQ, &CS).await {}
    }
}
