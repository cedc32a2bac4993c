//! Scenario firmware: runs one scenario of `rtseq-scenarios` under RTIC and prints its
//! transition trace, for `tests/qemu_scenarios.rs` to compare with the host simulator.
//!
//! `cargo fw-run scenarios -- NAME` (NAME from `rtseq_scenarios::SCENARIOS`).
//!
//! With the board feature `critical-section-lock` the sequencer uses the portable
//! `critical-section` lock instead of RTIC's priority ceiling.
//!
//! - `init`: looks the scenario up by the command line, installs its table into the
//!   `static` sequencer and binds its bodies (blocking children into `init`'s arena),
//!   declares the lanes, starts the main sequences at time 0, starts TIM2.
//! - `tick` (TIM2, 1 kHz, priority 2): the scenario's script, then `SEQ.tick`. After the
//!   scenario's last tick it stops the timer.
//! - `lane0..2` (priority 1): `rtseq::lane(&SEQ, &CTRL, seq)`, in the host's lane order.
//! - `idle`: drains the trace (`SEQ.drain_records`) and prints each record as integers
//!   (`T time_us seq from to cause_kind cause_arg` for a transition, `E time_us kind a b c d`
//!   for an event, see `rtseq_scenarios::encode`); after the
//!   last tick prints the action summary and exits 0 (1 if transitions were lost).
#![no_std]
#![no_main]

use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

use rtseq_qemu_f405 as board;

/// A lane's future, polled out of line: the three lane tasks (one future type) share one
/// copy of the framework's code instead of each inlining it.
struct Lane<F>(F);

impl<F: Future> Future for Lane<F> {
    type Output = F::Output;
    #[inline(never)]
    fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<F::Output> {
        // SAFETY: structural pinning of the only field: it is never moved out.
        unsafe { self.map_unchecked_mut(|l| &mut l.0) }.poll(w)
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{board, Lane};
    use board::clock::TickTimer;
    use core::sync::atomic::{AtomicBool, Ordering};
    use rtseq::Seq;
    use rtseq_scenarios::{
        encode_record, Arena, Child, Ctrl, Mons, Node, Scenario, Seqr, CHILDREN, SCENARIOS,
    };

    /// The sequencer, shared by the tick and the lanes.
    // SAFETY: every user of SEQ runs at RTIC priority 2 (the tick) or below (lanes at 1,
    // idle draining the trace at 0); nothing above priority 2 calls it.
    #[cfg(not(feature = "critical-section-lock"))]
    static SEQ: Seqr = unsafe { Seqr::with_priority_ceiling() };
    /// The sequencer with the portable lock (board feature `critical-section-lock`): its
    /// sections mask interrupts, which `tests/qemu_scenarios.rs` measures.
    #[cfg(feature = "critical-section-lock")]
    static SEQ: Seqr = Seqr::new();
    /// The control system the scenario's script and conditions use.
    static CTRL: Ctrl = Ctrl::new();
    /// Set by the tick after the scenario's last tick.
    static DONE: AtomicBool = AtomicBool::new(false);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        scenario: &'static Scenario,
        monitors: Mons,
        lane0: Option<Seq<Node<'static>>>,
        lane1: Option<Seq<Node<'static>>>,
        lane2: Option<Seq<Node<'static>>>,
    }

    /// `children`: the arena of the scenario's blocking children (the lanes borrow it).
    #[init(local = [children: [Option<Child<'static>>; CHILDREN] = [const { None }; CHILDREN]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // The run's deepest stack is printed at its end.
        board::stack::paint_unused();
        let mut buf = [0u8; 128];
        let name = first_arg(&mut buf);
        let Some(scenario) = SCENARIOS.iter().find(|s| s.name.as_bytes() == name) else {
            defmt::error!(
                "scenarios: unknown scenario '{=str}'",
                core::str::from_utf8(name).unwrap_or("?")
            );
            for s in SCENARIOS {
                defmt::info!("scenarios: known: {=str}", s.name);
            }
            board::exit_failure();
        };
        let setup = match (scenario.register)(&SEQ, Arena::new(cx.local.children)) {
            Ok(s) => s,
            Err(e) => {
                defmt::error!("scenarios: set-up failed: {=str}", e.reason());
                board::exit_failure();
            }
        };
        for lane in setup.lanes.iter() {
            if let Some(h) = SEQ.sequence_by_id(lane.id()) {
                let _ = h.declare_lane();
            }
        }
        for &id in setup.start.iter() {
            if let Err(e) = SEQ.sequence_by_id(id).map_or(Ok(()), |h| h.start()) {
                defmt::error!("scenarios: start failed: {=str}", e.reason());
                board::exit_failure();
            }
        }
        // `pop` from the back, not `into_iter` (heapless' iterator slices: a panic path).
        let mut v = setup.lanes;
        let monitors = setup.monitors;
        let lane2 = if v.len() > 2 { v.pop() } else { None };
        let lane1 = if v.len() > 1 { v.pop() } else { None };
        let lane0 = v.pop();
        // Spawning from init cannot fail (each task once); `.ok()` keeps the no-panic proof.
        lane0::spawn().ok();
        lane1::spawn().ok();
        lane2::spawn().ok();
        defmt::info!(
            "scenarios: {=str}, {=u32} ticks, {=usize} sequences, {=usize} monitors",
            scenario.name,
            scenario.ticks,
            SEQ.len(),
            monitors.len()
        );
        let timer = TickTimer::start(cx.device.TIM2, &cx.device.RCC);
        (
            Shared {},
            Local {
                timer,
                scenario,
                monitors,
                lane0,
                lane1,
                lane2,
            },
        )
    }

    /// The first argument after the program name. By hand, not with `str::split`, whose
    /// slicing keeps a panic path (the no-panic proof covers this firmware).
    fn first_arg(buf: &mut [u8]) -> &[u8] {
        let line = match board::args::cmdline(buf) {
            Ok(line) => line.as_bytes(),
            Err(e) => {
                defmt::error!("scenarios: {}", e);
                board::exit_failure();
            }
        };
        let start = line
            .iter()
            .position(|&c| c == b' ')
            .map_or(line.len(), |p| p.saturating_add(1));
        let rest = line.get(start..).unwrap_or(&[]);
        let end = rest.iter().position(|&c| c == b' ').unwrap_or(rest.len());
        rest.get(..end).unwrap_or(&[])
    }

    /// Prints the buffered records; returns how many were lost.
    fn drain() -> u32 {
        SEQ.drain_records(|r| {
            let (kind, [a, b, c, d, e, f]) = encode_record(&r);
            defmt::info!(
                "{=char} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32}",
                kind,
                a,
                b,
                c,
                d,
                e,
                f
            );
        })
    }

    /// Lowest priority: drains the trace whenever every lane sleeps; ends the run.
    #[idle]
    fn idle(_: idle::Context) -> ! {
        let mut lost: u32 = 0;
        loop {
            lost = lost.saturating_add(drain());
            // Check and sleep with interrupts masked: a tick between check and WFI still
            // wakes the WFI.
            cortex_m::interrupt::disable();
            if DONE.load(Ordering::Relaxed) {
                // The last tick and its lanes have run (idle runs only when they sleep).
                lost = lost.saturating_add(drain());
                let s = CTRL.summary();
                defmt::info!(
                    "S lines={=u32} dead={=u32} returns={=u32} digest={=u32} lost={=u32}",
                    s.lines,
                    s.dead_lines,
                    s.returns,
                    s.digest,
                    lost
                );
                defmt::info!(
                    "stack: {=usize} B at the deepest, of {=usize} B",
                    board::stack::peak(),
                    board::stack::size()
                );
                if lost == 0 {
                    board::exit_success();
                }
                board::exit_failure();
            }
            cortex_m::asm::wfi();
            // SAFETY: not inside a critical section of ours; RTIC uses BASEPRI, not PRIMASK.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    /// The heartbeat: script, then the sequencer tick.
    #[task(binds = TIM2, priority = 2, local = [timer, scenario, monitors, n: u32 = 0])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        let n = cx.local.n.saturating_add(1);
        *cx.local.n = n;
        let scenario = *cx.local.scenario;
        if n > scenario.ticks {
            return;
        }
        if now.as_ticks() != u64::from(n).wrapping_mul(1_000) {
            // A lost tick would desynchronise the script from the host's.
            defmt::error!("scenarios: tick {=u32} at {=u64} us", n, now.as_ticks());
            board::exit_failure();
        }
        (scenario.script)(n, &CTRL, &SEQ);
        if let Err(e) = SEQ.tick(now, &CTRL, cx.local.monitors) {
            defmt::error!("tick: {}", e);
        }
        if n == scenario.ticks {
            cx.local.timer.stop();
            DONE.store(true, Ordering::Relaxed);
        }
    }

    /// Lane 0 (polled first, as the host simulator's first lane).
    #[task(priority = 1, local = [lane0])]
    async fn lane0(cx: lane0::Context) {
        if let Some(seq) = cx.local.lane0 {
            match Lane(rtseq::lane(&SEQ, &CTRL, seq)).await {}
        }
        loop {
            core::future::pending::<()>().await;
        }
    }

    /// Lane 1.
    #[task(priority = 1, local = [lane1])]
    async fn lane1(cx: lane1::Context) {
        if let Some(seq) = cx.local.lane1 {
            match Lane(rtseq::lane(&SEQ, &CTRL, seq)).await {}
        }
        loop {
            core::future::pending::<()>().await;
        }
    }

    /// Lane 2.
    #[task(priority = 1, local = [lane2])]
    async fn lane2(cx: lane2::Context) {
        if let Some(seq) = cx.local.lane2 {
            match Lane(rtseq::lane(&SEQ, &CTRL, seq)).await {}
        }
        loop {
            core::future::pending::<()>().await;
        }
    }
}
