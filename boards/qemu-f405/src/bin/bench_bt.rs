//! `bench_hand`'s workload as behaviour trees of the `behaviortree` crate (0.8, no_std +
//! `alloc`), measured the same way (QEMU `-icount shift=0`: one TIM2 count = one
//! instruction = 1 ns) and printed under the same labels with the prefix `bench_bt:`
//! (`./x bench` puts them in the `bt=` column of its `compare` lines).
//!
//! # The model
//!
//! One XML document (built at start-up) describes five trees; `BehaviorTreeFactory` makes
//! them; the TIM2 tick task (priority 2, where `bench_hand` runs its timer work) ticks them
//! with `BehaviorTree::tick_once`. Every behaviour here finishes its tick without waiting,
//! so the tick's future is polled once with a no-op waker and must be ready
//! ([`tick_tree`]; a pending tick would be a failure of the benchmark).
//!
//! A "sequence" of `bench_hand` is a `ReactiveSequence` of its monitors and its action:
//!
//! ```xml
//! <ReactiveSequence>
//!   <Monitor flag="8"/> <!-- x 4: Failure at a rising edge of the flag, else Success -->
//!   <WaitExit exit="15"/> <!-- Running until its exit flag holds, then Success -->
//! </ReactiveSequence>
//! ```
//!
//! A reactive sequence ticks its conditions again at every tick; a monitor that fails
//! makes it fail and halt its children, which halts the running action: the action's
//! `on_halt` is the cleanup hook (`AbortOwner`). The trees, as `bench_hand`'s workloads:
//! `W1` one such sequence, ticked every 1 ms; `W8` a `Parallel` over 8 of them, ticked every
//! 2 ms (at odd ticks, as `bench_hand`'s 2 ms sequences are due); `WF` one sequence whose
//! monitor watches the fault flag and whose action stamps the time in its cleanup hook;
//! `WE` a `Fallback` of such a sequence and an `Exception` action (BT's recovery pattern:
//! when the sequence fails, the fallback ticks the exception at once, in the same tick);
//! `Probe` a copy of `W8` whose actions are wrapped in a measuring decorator (the exit
//! poll figure, below). `bench_hand`'s ticks, fault flag and fault timing (set just after
//! tick `FIRE - 1`) are kept; a tree that has finished (`WF`, `WE` after `FIRE`) is not
//! ticked again.
//!
//! # The figures, in this model
//!
//! - `tick 1 x 4 due` / `tick 8 x 4 due` / `tick 1 x 1 due` / `tick 1 monitor fires
//!   AbortOwner`: one `tick_once` of `W1` / `W8` / `WF` (its future made, polled once and
//!   dropped). There are no lanes: the exit conditions are evaluated inside the tick.
//! - `tick nothing due (8 running)`: a tree has no polling periods of its own; the period is
//!   how often the application ticks it. At the even ticks `W8` is not ticked: the figure is
//!   the application's check whether it is due (the tree is not touched).
//! - `period CPU`: as in `bench_hand`, the virtual time from the entry of the TIM2 handler to
//!   the moment `idle` runs again, from tick `SOLO` on where only `W8` is ticked.
//! - `exit poll (one lane, due, condition false)`: there is no per-sequence poll; the
//!   closest equivalent is one tick of a sequence's action leaf (`BehaviorTreeElement::tick`
//!   of `WaitExit`: its pre/post-condition checks, its boxed `async_trait` future, the exit
//!   condition, the state update) as its `ReactiveSequence` ticks it. It is measured in the
//!   `Probe` tree (a `MeasuredPoll` decorator around each action, the poll of the action's
//!   tick future measured), not in `W8`, so that the `W8` figures carry no measurement; at
//!   the odd steady ticks, as `bench_hand` measures its lanes' polls.
//! - `tick entry -> Aborted`: from the entry of the tick handler to `WF`'s cleanup hook;
//!   `tick entry -> exception`: to the first instruction of `WE`'s `Exception` action.
//!
//! # What it leaves out
//!
//! Everything `bench_hand` leaves out (no trace, pause or resume, restart behaviours,
//! blocking sub-sequences, pre-conditions, safety hook, run-time validation, counters), and
//! also: no timeout check (`bench_hand` checks a deadline that is never reached; the trees
//! have none: behaviortree's `Timeout` decorator has no clock without `std`), no
//! per-sequence polling periods (one period per tree), no recording of every edge (a
//! reactive sequence stops at the first monitor that fails), and no exception that holds
//! its owner: in the tree the owner is halted first (its sequence failed), then the
//! exception runs. No Groot2, observer, scripting or blackboard use.
//!
//! `embedded-alloc` (linked-list heap, a static array of [`HEAP_BYTES`]) is the global
//! allocator: the trees, the factory and every tick (each behaviour's tick is a boxed
//! future) allocate. Only this firmware has it (board feature `bt`):
//! `cargo fw-run bench_bt --features bt`.
#![no_std]
#![no_main]

extern crate alloc;

use alloc::string::String;
use core::fmt::Write as _;
use core::future::{poll_fn, Future};
use core::pin::pin;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use core::task::{Context, Poll, Waker};

use behaviortree::prelude::*;
use board::measure::measure_with;
use embedded_alloc::LlffHeap;
use rtseq_qemu_f405 as board;
use rtseq_scenarios::Ctrl;

#[global_allocator]
static HEAP: LlffHeap = LlffHeap::empty();

/// The heap's size.
const HEAP_BYTES: usize = 64 * 1024;

static CTRL: Ctrl = Ctrl::new();

/// Timestamps (TIM2 counts = ns of virtual time) of the latency measurement.
static FAULT_AT: AtomicU32 = AtomicU32::new(0);
static ABORTED_AT: AtomicU32 = AtomicU32::new(0);
static EXCEPTION_AT: AtomicU32 = AtomicU32::new(0);

/// Flag of the firing monitors; flag 8 stays false (the quiet monitors).
const FAULT: u8 = 7;
const QUIET: u8 = 8;
/// Never set: the actions wait for it.
const NEVER: u8 = 15;

/// Port names.
const FLAG: &str = "flag";
const EXIT: &str = "exit";

/// A monitor: `Failure` at a rising edge of its flag (port `flag`), `Success` otherwise.
/// The edge detector starts from "false" whenever the monitor starts (as `bench_hand`'s
/// monitors do when their sequence starts).
#[derive(Condition, Debug)]
pub struct Monitor {
    flag: u8,
    last: bool,
    #[behavior(portlist)]
    portlist: PortArray<1>,
}

#[async_trait::async_trait]
impl Behavior for Monitor {
    fn on_start(
        &mut self,
        _behavior: &mut BehaviorData,
        _children: &mut BehaviorTreeElementList,
        _runtime: &SharedRuntime,
    ) -> Result<(), BehaviorError> {
        self.flag = self.portlist.get::<u8>(FLAG)?;
        self.last = false;
        Ok(())
    }

    async fn tick(
        &mut self,
        _behavior: &mut BehaviorData,
        _children: &mut BehaviorTreeElementList,
        _runtime: &SharedRuntime,
    ) -> BehaviorResult {
        let v = CTRL.flag(self.flag);
        let rose = v && !self.last;
        self.last = v;
        Ok(if rose {
            BehaviorState::Failure
        } else {
            BehaviorState::Success
        })
    }
}

impl Monitor {
    port_array_init! {1, create_inbound_entry_parseable!(FLAG, u8)}
}

/// A sequence's action: `Running` until its exit flag (port `exit`) holds, then `Success`.
/// Halted while running (its sequence aborted), it calls its cleanup hook.
#[derive(Action, Debug)]
#[behavior(no_register)]
pub struct WaitExit {
    #[behavior(parameter)]
    cleanup: fn(&Ctrl),
    exit: u8,
    running: bool,
    #[behavior(portlist)]
    portlist: PortArray<1>,
}

#[async_trait::async_trait]
impl Behavior for WaitExit {
    fn on_start(
        &mut self,
        _behavior: &mut BehaviorData,
        _children: &mut BehaviorTreeElementList,
        _runtime: &SharedRuntime,
    ) -> Result<(), BehaviorError> {
        self.exit = self.portlist.get::<u8>(EXIT)?;
        Ok(())
    }

    async fn tick(
        &mut self,
        _behavior: &mut BehaviorData,
        _children: &mut BehaviorTreeElementList,
        _runtime: &SharedRuntime,
    ) -> BehaviorResult {
        self.running = !CTRL.flag(self.exit);
        Ok(if self.running {
            BehaviorState::Running
        } else {
            BehaviorState::Success
        })
    }

    fn on_halt(&mut self) -> Result<(), BehaviorError> {
        if core::mem::take(&mut self.running) {
            (self.cleanup)(&CTRL);
        }
        Ok(())
    }
}

impl WaitExit {
    port_array_init! {1, create_inbound_entry_parseable!(EXIT, u8)}
}

/// `WE`'s exception: stamps the time of its first instruction and succeeds.
#[derive(Action, Debug)]
pub struct Exception;

#[async_trait::async_trait]
impl Behavior for Exception {
    async fn tick(
        &mut self,
        _behavior: &mut BehaviorData,
        _children: &mut BehaviorTreeElementList,
        _runtime: &SharedRuntime,
    ) -> BehaviorResult {
        EXCEPTION_AT.store(board::clock::tim2_count(), Relaxed);
        Ok(BehaviorState::Success)
    }
}

/// Instruction counts of the exit polls measured by [`MeasuredPoll`].
struct ExitPolls {
    on: AtomicBool,
    sum: AtomicU32,
    count: AtomicU32,
    max: AtomicU32,
}

static EXIT_POLLS: ExitPolls = ExitPolls {
    on: AtomicBool::new(false),
    sum: AtomicU32::new(0),
    count: AtomicU32::new(0),
    max: AtomicU32::new(0),
};

impl ExitPolls {
    fn add(&self, n: u32) {
        self.sum.fetch_add(n, Relaxed);
        self.count.fetch_add(1, Relaxed);
        self.max.fetch_max(n, Relaxed);
    }

    fn mean(&self) -> u32 {
        self.sum
            .load(Relaxed)
            .checked_div(self.count.load(Relaxed))
            .unwrap_or(0)
    }
}

/// The `Probe` tree's decorator: ticks its one child and, while [`EXIT_POLLS`] is on,
/// measures each poll of the child's tick future (the whole `BehaviorTreeElement::tick`).
#[derive(Decorator, Debug)]
pub struct MeasuredPoll;

#[async_trait::async_trait]
impl Behavior for MeasuredPoll {
    async fn tick(
        &mut self,
        _behavior: &mut BehaviorData,
        children: &mut BehaviorTreeElementList,
        runtime: &SharedRuntime,
    ) -> BehaviorResult {
        let Some(child) = children.first_mut() else {
            return Err(BehaviorError::Composition {
                txt: "MeasuredPoll needs a child".into(),
            });
        };
        let mut fut = pin!(child.tick(runtime));
        poll_fn(|cx| {
            if EXIT_POLLS.on.load(Relaxed) {
                let (n, p) = measure_with(|| fut.as_mut().poll(cx));
                EXIT_POLLS.add(n);
                p
            } else {
                fut.as_mut().poll(cx)
            }
        })
        .await
    }
}

/// The cleanup hook of `WF`'s action: stamps the time of the abort.
fn stamp_aborted(_: &Ctrl) {
    ABORTED_AT.store(board::clock::tim2_count(), Relaxed);
}

/// The cleanup hook of the actions whose monitors never fire.
fn no_cleanup(_: &Ctrl) {}

/// Why a tree's tick failed.
enum TickError {
    /// `tick_once` returned an error.
    Tree(BehaviorError),
    /// `tick_once` did not complete in one poll.
    Pending,
}

/// One `tick_once` of `tree`: its future polled once with a no-op waker (every behaviour
/// here completes without waiting, so the tick is ready at once).
fn tick_tree(tree: &mut BehaviorTree) -> Result<BehaviorState, TickError> {
    let mut fut = pin!(tree.tick_once());
    match fut.as_mut().poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(r) => r.map_err(TickError::Tree),
        Poll::Pending => Err(TickError::Pending),
    }
}

/// Appends one sequence: `monitors` monitors on `flag`, then the action `action` waiting for
/// `NEVER`, wrapped in `MeasuredPoll` if `probe`.
fn sequence(xml: &mut String, name: &str, flag: u8, monitors: usize, action: &str, probe: bool) {
    let _ = write!(xml, "<ReactiveSequence name=\"{name}\">");
    for _ in 0..monitors {
        let _ = write!(xml, "<Monitor flag=\"{flag}\"/>");
    }
    let action = alloc::format!("<{action} exit=\"{NEVER}\"/>");
    if probe {
        let _ = write!(xml, "<MeasuredPoll>{action}</MeasuredPoll>");
    } else {
        xml.push_str(&action);
    }
    xml.push_str("</ReactiveSequence>");
}

/// The XML document of the five trees.
fn document() -> String {
    let mut xml = String::from("<root BTCPP_format=\"4\">");
    xml.push_str("<BehaviorTree ID=\"W1\">");
    sequence(&mut xml, "one", QUIET, 4, "WaitExit", false);
    xml.push_str("</BehaviorTree>");
    for (id, probe) in [("W8", false), ("Probe", true)] {
        let _ = write!(xml, "<BehaviorTree ID=\"{id}\"><Parallel>");
        for i in 0..8 {
            sequence(
                &mut xml,
                &alloc::format!("s{i}"),
                QUIET,
                4,
                "WaitExit",
                probe,
            );
        }
        xml.push_str("</Parallel></BehaviorTree>");
    }
    xml.push_str("<BehaviorTree ID=\"WF\">");
    sequence(&mut xml, "fire", FAULT, 1, "StampOnAbort", false);
    xml.push_str("</BehaviorTree>");
    xml.push_str("<BehaviorTree ID=\"WE\"><Fallback>");
    sequence(&mut xml, "owner", FAULT, 1, "WaitExit", false);
    xml.push_str("<Exception/></Fallback></BehaviorTree>");
    xml.push_str("</root>");
    xml
}

/// The trees of the benchmark.
pub struct Trees {
    w1: BehaviorTree,
    w8: BehaviorTree,
    wf: BehaviorTree,
    we: BehaviorTree,
    probe: BehaviorTree,
}

/// Registers the behaviours, reads the document and makes the trees (the factory is
/// dropped afterwards).
fn build() -> Result<Trees, behaviortree::Error> {
    let mut factory = BehaviorTreeFactory::new()?;
    Monitor::register(&mut factory, "Monitor")?;
    WaitExit::register_with(&mut factory, "WaitExit", no_cleanup)?;
    WaitExit::register_with(&mut factory, "StampOnAbort", stamp_aborted)?;
    Exception::register(&mut factory, "Exception")?;
    MeasuredPoll::register(&mut factory, "MeasuredPoll")?;
    factory.register_behavior_tree_from_text(&document())?;
    Ok(Trees {
        w1: factory.create_tree("W1")?,
        w8: factory.create_tree("W8")?,
        wf: factory.create_tree("WF")?,
        we: factory.create_tree("WE")?,
        probe: factory.create_tree("Probe")?,
    })
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{
        board, build, tick_tree, BehaviorState, TickError, Trees, ABORTED_AT, CTRL, EXCEPTION_AT,
        EXIT_POLLS, FAULT, FAULT_AT, HEAP, HEAP_BYTES,
    };
    use board::clock::TickTimer;
    use board::measure::measure_with;
    use core::mem::MaybeUninit;
    use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

    /// Ticks measured, as in `bench_hand`.
    const TICKS: usize = 15;
    /// The tick at which the `WF`/`WE` monitors fire (fault set after tick FIRE - 1).
    const FIRE: usize = 9;
    /// From this tick on only `W8` is ticked (the period CPU figure).
    const SOLO: usize = FIRE + 2;

    /// Instructions per tick: [W1, W8, WF] × tick.
    static COST: [[AtomicU32; 3]; TICKS] = [const { [const { AtomicU32::new(0) }; 3] }; TICKS];
    static ENTRY: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    static IDLE_AT: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    static CURRENT: AtomicUsize = AtomicUsize::new(0);
    static DONE: AtomicBool = AtomicBool::new(false);
    /// Heap in use once the trees are built (the factory dropped).
    static HEAP_TREES: AtomicUsize = AtomicUsize::new(0);
    /// Instructions of [`build`] (XML document, factory, the five trees).
    static BUILD_COST: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        trees: Trees,
    }

    #[init(local = [heap: [MaybeUninit<u8>; HEAP_BYTES] = [MaybeUninit::uninit(); HEAP_BYTES]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // SAFETY: `init` runs once, before anything allocates, and is the only place the
        // heap is initialised; the buffer is a `'static` local of `init` that nothing else
        // can reach, handed to the allocator for the rest of the run.
        unsafe { HEAP.init(cx.local.heap.as_mut_ptr() as usize, HEAP_BYTES) };
        // The timer starts before the trees are built (its first update is taken when `init`
        // returns, the "started" tick). Measured in QEMU 7.2: started after the build (some
        // million instructions), its period came out at 2.48 ms instead of about 1 ms; this
        // way 1.07 ms (bench_hand: 1.002 ms). Only the printed tick period and the "condition
        // true ->" latencies depend on it, not the instruction counts.
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        let (cost, built) = measure_with(build);
        BUILD_COST.store(cost, Ordering::Relaxed);
        let trees = match built {
            Ok(t) => t,
            Err(e) => {
                defmt::error!(
                    "bench_bt: building the trees failed: {}",
                    defmt::Display2Format(&e)
                );
                board::exit_failure();
            }
        };
        HEAP_TREES.store(HEAP.used(), Ordering::Relaxed);
        (Shared {}, Local { timer, trees })
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
            // The pending tick has run.
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
            "bench_bt: tick 1 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone(), 0)
        );
        defmt::info!(
            "bench_bt: tick 8 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 1), 1)
        );
        // W8 is not ticked at even ticks: the application's "is it due?" check.
        defmt::info!(
            "bench_bt: tick nothing due (8 running) = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 0), 1)
        );
        defmt::info!(
            "bench_bt: tick 1 x 1 due, nothing firing = {=u32} instructions",
            max_cost(steady, 2)
        );
        defmt::info!(
            "bench_bt: tick 1 monitor fires AbortOwner = {=u32} instructions",
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
            "bench_bt: period CPU 8 x 4 due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 1)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        defmt::info!(
            "bench_bt: period CPU nothing due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 0)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        // No lanes: one tick of a sequence's action leaf inside the tree tick (module docs).
        defmt::info!(
            "bench_bt: exit poll (one lane, due, condition false) = {=u32} instructions (max {=u32}, {=u32} polls; one tick of the action leaf)",
            EXIT_POLLS.mean(),
            EXIT_POLLS.max.load(Ordering::Relaxed),
            EXIT_POLLS.count.load(Ordering::Relaxed)
        );
        let fault = FAULT_AT.load(Ordering::Relaxed);
        let (aborted, exception) = (
            ABORTED_AT.load(Ordering::Relaxed),
            EXCEPTION_AT.load(Ordering::Relaxed),
        );
        defmt::info!(
            "bench_bt: tick period = {=u32} ns, condition true -> next tick = {=u32} ns",
            entry(FIRE).wrapping_sub(entry(FIRE - 1)),
            entry(FIRE).wrapping_sub(fault)
        );
        defmt::info!(
            "bench_bt: latency condition true -> owner Aborted = {=u32} ns (tick entry -> Aborted = {=u32} ns)",
            aborted.wrapping_sub(fault),
            aborted.wrapping_sub(entry(FIRE))
        );
        defmt::info!(
            "bench_bt: latency condition true -> exception sequence first instruction = {=u32} ns (tick entry -> exception = {=u32} ns)",
            exception.wrapping_sub(fault),
            exception.wrapping_sub(entry(FIRE))
        );
        defmt::info!(
            "bench_bt: size heap = {=usize} bytes, in use with the 5 trees built = {=usize} bytes, at the end = {=usize} bytes",
            HEAP_BYTES,
            HEAP_TREES.load(Ordering::Relaxed),
            HEAP.used()
        );
        defmt::info!(
            "bench_bt: build (XML document, factory, 5 trees) = {=u32} instructions",
            BUILD_COST.load(Ordering::Relaxed)
        );
        // Every tick's result was checked in `tick`; the hook and the exception ran.
        if aborted == 0 || exception == 0 {
            defmt::error!("bench_bt: the cleanup hook or the exception did not run");
            board::exit_failure();
        }
        board::exit_success();
    }

    /// A tree's tick result against the state expected.
    fn check(name: &str, ticked: Result<BehaviorState, TickError>, expected: BehaviorState) {
        match ticked {
            Ok(s) if s == expected => {}
            Ok(s) => {
                defmt::error!(
                    "bench_bt: {=str} ticked {=str}, expected {=str}",
                    name,
                    s.as_str(),
                    expected.as_str()
                );
                board::exit_failure();
            }
            Err(TickError::Tree(e)) => {
                defmt::error!("bench_bt: {=str}: {}", name, defmt::Display2Format(&e));
                board::exit_failure();
            }
            Err(TickError::Pending) => {
                defmt::error!("bench_bt: {=str}: tick_once did not complete", name);
                board::exit_failure();
            }
        }
    }

    /// The timer task: time, then the trees due at this tick.
    #[task(binds = TIM2, priority = 2, local = [timer, trees, n: usize = 0, started: bool = false])]
    fn tick(cx: tick::Context) {
        let entry = board::clock::tim2_count();
        let _ = cx.local.timer.on_interrupt();
        if let Some(e) = ENTRY.get(*cx.local.n + 1) {
            e.store(entry, Ordering::Relaxed);
        }
        CURRENT.store(*cx.local.n + 1, Ordering::Relaxed);
        let t = &mut *cx.local.trees;
        if !*cx.local.started {
            // First tick: as in bench_hand, where it starts the sequences (due first at
            // tick 1). A tree starts with its first tick, at tick 1.
            *cx.local.started = true;
            return;
        }
        let n = *cx.local.n + 1;
        *cx.local.n = n;
        // The firing trees first, as in bench_hand; at the firing tick W1 and W8 are not
        // ticked; from SOLO on, W8 alone. WF and WE finish at FIRE and are not ticked after.
        let cf = if n > FIRE {
            0
        } else {
            let (fired, survived) = if n == FIRE {
                (BehaviorState::Failure, BehaviorState::Success)
            } else {
                (BehaviorState::Running, BehaviorState::Running)
            };
            let (cf, ticked) = measure_with(|| tick_tree(&mut t.wf));
            check("WF", ticked, fired);
            check("WE", tick_tree(&mut t.we), survived);
            cf
        };
        let c1 = if n >= SOLO || n == FIRE {
            0
        } else {
            let (c1, ticked) = measure_with(|| tick_tree(&mut t.w1));
            check("W1", ticked, BehaviorState::Running);
            c1
        };
        let c8 = if n == FIRE {
            0
        } else {
            // W8's period is 2 ticks: due at the odd ticks.
            let (c8, ticked) = measure_with(|| (n % 2 == 1).then(|| tick_tree(&mut t.w8)));
            if let Some(ticked) = ticked {
                check("W8", ticked, BehaviorState::Running);
            }
            c8
        };
        if n < FIRE && n % 2 == 1 {
            // The exit polls, in the copy of W8, measured where W8 is due in the steady
            // state (tick 1 starts it).
            EXIT_POLLS.on.store(n >= 2, Ordering::Relaxed);
            check("Probe", tick_tree(&mut t.probe), BehaviorState::Running);
            EXIT_POLLS.on.store(false, Ordering::Relaxed);
        }
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
}
