//! The hand-written baseline of `bench_seq`: the same workload in plain RTIC 2, without
//! rtseq, the way an RTIC user would write it, measured the same way (QEMU
//! `-icount shift=0`: one TIM2 count = one instruction = 1 ns).
//!
//! A timer task (TIM2, priority 2) checks, for every running "sequence" whose polling
//! period is due, its monitors (rising edges of `Ctrl` flags) and its timeout; when nothing
//! fires it marks the sequence's exit condition due and wakes its task through the waker
//! the task registered. Each sequence is an async function in a task at priority 1 that
//! waits for its start, then for each due poll evaluates its exit condition. A firing
//! `AbortOwner` monitor stops its sequence and calls its cleanup hook in the timer task; a
//! monitor with an exception holds its sequence and spawns the exception task, which aborts
//! the owner when it is done.
//!
//! The workloads mirror `bench_seq`'s four sequencers: `W1` 1 sequence × 4 monitors, 1 ms;
//! `W8` 8 sequences × 4 monitors, 2 ms (its 8 tasks joined in one RTIC task, like
//! `bench_seq`'s lanes); `WF` 1 sequence with an `AbortOwner` monitor and a cleanup hook that
//! fires at tick `FIRE`; `WE` 1 sequence with a monitor whose exception task runs at `FIRE`.
//! The ticks, the fault's timing and the figures are `bench_seq`'s (same labels).
//!
//! What it leaves out (rtseq has it): no trace of transitions, no pause or resume, no
//! restart behaviours or restart limits, no blocking sub-sequences and no teardown of a
//! tree of them, no pre-conditions, no safety system hook, no run-time configuration or
//! validation, no counters. `cargo fw-run bench_hand`.
#![no_std]
#![no_main]

use core::cell::Cell;
use core::future::{poll_fn, Future};
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering::Relaxed};
use core::task::{Poll, Waker};

use critical_section::Mutex;
use rtseq_qemu_f405 as board;
use rtseq_scenarios::Ctrl;

static CTRL: Ctrl = Ctrl::new();

/// Timestamps (TIM2 counts = ns of virtual time) of the latency measurement.
static FAULT_AT: AtomicU32 = AtomicU32::new(0);
static ABORTED_AT: AtomicU32 = AtomicU32::new(0);
static EXCEPTION_AT: AtomicU32 = AtomicU32::new(0);

/// A sequence's states, as far as the timer and its task need them.
const IDLE: u8 = 0;
const RUNNING: u8 = 1;
/// Held while its exception task runs (no exit polls).
const HELD: u8 = 2;
const DONE: u8 = 3;
const ABORTED: u8 = 4;

/// What the timer task and one sequence's task share.
pub struct Lane {
    state: AtomicU8,
    /// Set by the timer when the exit condition is due, taken by the task.
    due: AtomicBool,
    waker: Mutex<Cell<Option<Waker>>>,
}

impl Lane {
    const fn new() -> Self {
        Lane {
            state: AtomicU8::new(IDLE),
            due: AtomicBool::new(false),
            waker: Mutex::new(Cell::new(None)),
        }
    }

    fn state(&self) -> u8 {
        self.state.load(Relaxed)
    }

    /// Timer side: wakes the task (its waker stays registered).
    fn wake(&self) {
        critical_section::with(|cs| {
            let slot = self.waker.borrow(cs);
            if let Some(w) = slot.take() {
                w.wake_by_ref();
                slot.set(Some(w));
            }
        });
    }

    /// Task side: registers the task's waker (cloned only when it changed).
    fn register(&self, w: &Waker) {
        critical_section::with(|cs| {
            let slot = self.waker.borrow(cs);
            let keep = match slot.take() {
                Some(old) if old.will_wake(w) => old,
                _ => w.clone(),
            };
            slot.set(Some(keep));
        });
    }

    /// Timer side: the sequence runs from now on.
    fn start(&self) {
        self.state.store(RUNNING, Relaxed);
        self.wake();
    }

    /// Timer side: its exit condition is due.
    fn poll_due(&self) {
        self.due.store(true, Relaxed);
        self.wake();
    }

    /// Stops the sequence (`AbortOwner`): its cleanup hook, then its task ends the run.
    fn abort(&self, cleanup: fn(&Ctrl)) {
        self.state.store(ABORTED, Relaxed);
        cleanup(&CTRL);
        self.wake();
    }

    /// Task side: waits until the sequence runs.
    fn started(&self) -> impl Future<Output = ()> + '_ {
        poll_fn(move |cx| {
            self.register(cx.waker());
            if self.state() == RUNNING {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
    }

    /// Task side: waits for the next due exit-condition poll (`true`) or the end of the run
    /// (`false`).
    fn due(&self) -> impl Future<Output = bool> + '_ {
        poll_fn(move |cx| {
            self.register(cx.waker());
            match self.state() {
                RUNNING if self.due.swap(false, Relaxed) => Poll::Ready(true),
                RUNNING | HELD => Poll::Pending,
                _ => Poll::Ready(false),
            }
        })
    }
}

/// A sequence's task: wait for a start, then poll the exit condition (flag `exit`) each time
/// the timer says it is due, until it holds or the run is aborted; forever.
async fn sequence(lane: &Lane, exit: u8) {
    loop {
        lane.started().await;
        while lane.due().await {
            if CTRL.flag(exit) {
                lane.state.store(DONE, Relaxed);
                break;
            }
        }
    }
}

/// A rising-edge monitor on a flag.
#[derive(Clone, Copy)]
pub struct Edge {
    flag: u8,
    last: bool,
}

/// What the timer keeps for one sequence.
pub struct Watch<const M: usize> {
    lane: &'static Lane,
    /// Polling period, ticks.
    period: u32,
    /// The next tick at which it is due.
    next: u32,
    /// The tick of its timeout (`u32::MAX`: none, as in `bench_seq`).
    deadline: u32,
    monitors: [Edge; M],
}

/// What fired at a due tick.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fired {
    Nothing,
    Monitor(usize),
    Timeout,
}

impl<const M: usize> Watch<M> {
    const fn new(lane: &'static Lane, period: u32, flag: u8) -> Self {
        Watch {
            lane,
            period,
            next: 0,
            deadline: u32::MAX,
            monitors: [Edge { flag, last: false }; M],
        }
    }

    /// Starts the sequence; due first at tick `n`.
    fn start(&mut self, n: u32) {
        self.next = n;
        for m in &mut self.monitors {
            m.last = false;
        }
        self.lane.start();
    }

    /// At tick `n`: when the sequence runs and is due, its monitors (every edge recorded,
    /// the first one fires) and its timeout, then, if nothing fired, its exit-condition poll.
    #[inline(always)]
    fn tick(&mut self, n: u32) -> Fired {
        if n < self.next || self.lane.state() != RUNNING {
            return Fired::Nothing;
        }
        // On the period's grid (a tick skipped does not shift the phase), no burst after a
        // longer gap.
        self.next += self.period;
        if self.next <= n {
            self.next = n + self.period;
        }
        let mut fired = Fired::Nothing;
        for (i, m) in self.monitors.iter_mut().enumerate() {
            let v = CTRL.flag(m.flag);
            if v && !m.last && fired == Fired::Nothing {
                fired = Fired::Monitor(i);
            }
            m.last = v;
        }
        if fired == Fired::Nothing && n >= self.deadline {
            fired = Fired::Timeout;
        }
        if fired == Fired::Nothing {
            self.lane.poll_due();
        }
        fired
    }

    /// [`Watch::tick`], then `AbortOwner` with `cleanup` if something fired.
    #[inline(always)]
    fn tick_abort_owner(&mut self, n: u32, cleanup: fn(&Ctrl)) {
        if self.tick(n) != Fired::Nothing {
            self.lane.abort(cleanup);
        }
    }
}

/// The cleanup hook of `WF`'s sequence: stamps the time of the abort.
fn stamp_aborted(_: &Ctrl) {
    ABORTED_AT.store(board::clock::tim2_count(), Relaxed);
}

/// The cleanup hook of the sequences whose monitors never fire.
fn no_cleanup(_: &Ctrl) {}

static L1: Lane = Lane::new();
static L8: [Lane; 8] = [const { Lane::new() }; 8];
static LF: Lane = Lane::new();
static LO: Lane = Lane::new();

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{
        board, no_cleanup, sequence, stamp_aborted, Fired, Lane, Watch, ABORTED_AT, CTRL,
        EXCEPTION_AT, FAULT_AT, L1, L8, LF, LO,
    };
    use board::clock::TickTimer;
    use board::measure::{join_measured, measure, PollCosts};
    use core::mem::size_of;
    use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

    /// Ticks measured, as in `bench_seq`.
    const TICKS: usize = 15;
    /// The tick at which the `WF`/`WE` monitors fire (fault set after tick FIRE - 1).
    const FIRE: usize = 9;
    /// From this tick on only `W8` is checked (the period CPU figure).
    const SOLO: usize = FIRE + 2;
    /// Flag of the firing monitors; flag 8 stays false (the quiet monitors).
    const FAULT: u8 = 7;
    const QUIET: u8 = 8;
    /// Never set: the running sequences wait for it.
    const NEVER: u8 = 15;

    /// Instructions per tick: [W1, W8, WF] × tick.
    static COST: [[AtomicU32; 3]; TICKS] = [const { [const { AtomicU32::new(0) }; 3] }; TICKS];
    static ENTRY: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    static IDLE_AT: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    static CURRENT: AtomicUsize = AtomicUsize::new(0);
    static POLLS: PollCosts = PollCosts::new();
    static DONE: AtomicBool = AtomicBool::new(false);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        w1: Watch<4>,
        w8: [Watch<4>; 8],
        wf: Watch<1>,
        we: Watch<1>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let w8 = core::array::from_fn(|i| Watch::new(&L8[i], 2, QUIET));
        lane1::spawn().ok();
        lanes8::spawn().ok();
        lane_fire::spawn().ok();
        lane_owner::spawn().ok();
        (
            Shared {},
            Local {
                timer: TickTimer::start(cx.device.TIM2, &cx.device.RCC),
                w1: Watch::new(&L1, 1, QUIET),
                w8,
                wf: Watch::new(&LF, 1, FAULT),
                we: Watch::new(&LO, 1, FAULT),
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::interrupt::disable();
            if DONE.load(Ordering::Relaxed) {
                report();
            }
            cortex_m::asm::wfi();
            // SAFETY: not inside a critical section of ours; RTIC uses BASEPRI, not PRIMASK.
            unsafe { cortex_m::interrupt::enable() };
            // The pending tick and every task it woke have run.
            let now = board::clock::tim2_count();
            if let Some(a) = IDLE_AT.get(CURRENT.load(Ordering::Relaxed)) {
                a.store(now, Ordering::Relaxed);
            }
        }
    }

    fn cost(tick: usize, which: usize) -> u32 {
        COST.get(tick)
            .and_then(|t| t.get(which))
            .map_or(0, |c| c.load(Ordering::Relaxed))
    }

    fn max_cost(ticks: impl Iterator<Item = usize>, which: usize) -> u32 {
        ticks.map(|t| cost(t, which)).max().unwrap_or(0)
    }

    fn report() -> ! {
        let steady = 2..FIRE;
        defmt::info!(
            "bench_hand: tick 1 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone(), 0)
        );
        defmt::info!(
            "bench_hand: tick 8 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 1), 1)
        );
        defmt::info!(
            "bench_hand: tick nothing due (8 running) = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 0), 1)
        );
        defmt::info!(
            "bench_hand: tick 1 x 1 due, nothing firing = {=u32} instructions",
            max_cost(steady, 2)
        );
        defmt::info!(
            "bench_hand: tick 1 monitor fires AbortOwner = {=u32} instructions",
            cost(FIRE, 2)
        );
        let entry = |i: usize| ENTRY.get(i).map_or(0, |e| e.load(Ordering::Relaxed));
        let busy = |i: usize| {
            IDLE_AT
                .get(i)
                .map_or(0, |e| e.load(Ordering::Relaxed))
                .wrapping_sub(entry(i))
        };
        defmt::info!(
            "bench_hand: period CPU 8 x 4 due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 1)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        defmt::info!(
            "bench_hand: period CPU nothing due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 0)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        defmt::info!(
            "bench_hand: exit poll (one lane, due, condition false) = {=u32} instructions (max {=u32}, {=u32} polls)",
            POLLS.mean(),
            POLLS.max(),
            POLLS.count()
        );
        let fault = FAULT_AT.load(Ordering::Relaxed);
        let (aborted, exception) = (
            ABORTED_AT.load(Ordering::Relaxed),
            EXCEPTION_AT.load(Ordering::Relaxed),
        );
        defmt::info!(
            "bench_hand: tick period = {=u32} ns, condition true -> next tick = {=u32} ns",
            entry(FIRE).wrapping_sub(entry(FIRE - 1)),
            entry(FIRE).wrapping_sub(fault)
        );
        defmt::info!(
            "bench_hand: latency condition true -> owner Aborted = {=u32} ns (tick entry -> Aborted = {=u32} ns)",
            aborted.wrapping_sub(fault),
            aborted.wrapping_sub(entry(FIRE))
        );
        defmt::info!(
            "bench_hand: latency condition true -> exception sequence first instruction = {=u32} ns (tick entry -> exception = {=u32} ns)",
            exception.wrapping_sub(fault),
            exception.wrapping_sub(entry(FIRE))
        );
        defmt::info!(
            "bench_hand: size Lane = {=usize} bytes, Watch<4> = {=usize} bytes",
            size_of::<Lane>(),
            size_of::<Watch<4>>()
        );
        // The quiet sequences still run; the two that fired were aborted.
        let ok = L8.iter().chain([&L1]).all(|l| l.state() == super::RUNNING)
            && LF.state() == super::ABORTED
            && LO.state() == super::ABORTED;
        if !ok {
            defmt::error!("bench_hand: unexpected end states");
            board::exit_failure();
        }
        board::exit_success();
    }

    /// The timer task: time, then each workload's monitors, timeouts and wake-ups.
    #[task(binds = TIM2, priority = 2, local = [timer, w1, w8, wf, we, n: usize = 0, started: bool = false])]
    fn tick(cx: tick::Context) {
        let entry = board::clock::tim2_count();
        let _ = cx.local.timer.on_interrupt();
        if let Some(e) = ENTRY.get(*cx.local.n + 1) {
            e.store(entry, Ordering::Relaxed);
        }
        CURRENT.store(*cx.local.n + 1, Ordering::Relaxed);
        let (w1, w8, wf, we) = (cx.local.w1, cx.local.w8, cx.local.wf, cx.local.we);
        if !*cx.local.started {
            // First tick: the tasks are waiting; start everything, due first at tick 1.
            *cx.local.started = true;
            w1.start(1);
            for w in w8.iter_mut() {
                w.start(1);
            }
            wf.start(1);
            we.start(1);
            return;
        }
        let n = *cx.local.n + 1;
        *cx.local.n = n;
        let t = n as u32;
        POLLS.enable((2..FIRE).contains(&n) && n % 2 == 1);
        // The firing workloads first, as in bench_seq; at the firing tick W1 and W8 are not
        // checked; from SOLO on, W8 alone.
        let solo = n >= SOLO;
        let cf = if solo {
            0
        } else {
            let cf = measure(|| wf.tick_abort_owner(t, stamp_aborted));
            if we.tick(t) != Fired::Nothing {
                // The exception first; the exception task applies AbortOwner when done.
                we.lane.state.store(super::HELD, Ordering::Relaxed);
                exception::spawn().ok();
            }
            cf
        };
        let c1 = if solo || n == FIRE {
            0
        } else {
            measure(|| w1.tick_abort_owner(t, no_cleanup))
        };
        let c8 = if n == FIRE {
            0
        } else {
            measure(|| {
                for w in w8.iter_mut() {
                    w.tick_abort_owner(t, no_cleanup);
                }
            })
        };
        if let Some(slot) = COST.get(n) {
            for (s, v) in slot.iter().zip([c1, c8, cf]) {
                s.store(v, Ordering::Relaxed);
            }
        }
        if n + 1 >= TICKS {
            cx.local.timer.stop();
            DONE.store(true, Ordering::Relaxed);
        }
        if n + 1 == FIRE {
            // Just after this tick's evaluation: the worst phase for the reaction.
            CTRL.set(FAULT, true);
            FAULT_AT.store(board::clock::tim2_count(), Ordering::Relaxed);
        }
    }

    #[task(priority = 1)]
    async fn lane1(_: lane1::Context) {
        sequence(&L1, NEVER).await;
    }

    #[task(priority = 1)]
    async fn lanes8(_: lanes8::Context) {
        let futs: [_; 8] = core::array::from_fn(|i| sequence(&L8[i], NEVER));
        join_measured(futs, &POLLS).await
    }

    #[task(priority = 1)]
    async fn lane_fire(_: lane_fire::Context) {
        sequence(&LF, NEVER).await;
    }

    #[task(priority = 1)]
    async fn lane_owner(_: lane_owner::Context) {
        sequence(&LO, NEVER).await;
    }

    /// The exception task of `WE`'s monitor: stamps its first instruction, then applies the
    /// monitor's behaviour (AbortOwner).
    #[task(priority = 1)]
    async fn exception(_: exception::Context) {
        EXCEPTION_AT.store(board::clock::tim2_count(), Ordering::Relaxed);
        LO.abort(no_cleanup);
    }
}
