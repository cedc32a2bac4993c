//! The cost model: a due tick and a whole due period against the number of running
//! sequences (1, 8, 32, 64, 256) and of monitors per running sequence (0, 1, 4, 8), in one
//! sequencer of 256 registered sequences (instructions under QEMU `-icount shift=0`, as
//! `bench_seq`). `./x bench --scale` prints the grid.
//!
//! The 256 sequences are a forest: 32 lanes, each the head of a chain of 8 sequences, each
//! running the next one blocking (`rtseq_scenarios::Node`). Every sequence waits for an
//! exit condition that stays false and polls every millisecond; the sequencer is ticked
//! every millisecond, so every tick is due. A cell starts `lanes` heads with chains of
//! `depth` running sequences (1 × 1, 8 × 1, 32 × 1, 32 × 2, 32 × 8): the chain stops where
//! a sequence's pre-condition is false (a depth flag), so it is skipped and its caller
//! waits for its own exit condition instead. Each running sequence owns `monitors`
//! rising-edge monitors on a flag that stays false. A monitor table holds at most 256
//! monitors, so the cells with more (64 × 8, 256 × 4, 256 × 8) are printed as `-`.
//!
//! Per cell: `tick` is the most instructions of one due tick (monitor evaluation, polling
//! classes, wake-ups of the due exit-condition polls); `period` the most instructions from
//! the entry of the TIM2 handler to `idle` running again (the tick, the dispatch, and the
//! polls of the lanes: 8 lane futures are joined in each of 4 tasks, so a wake-up of a task
//! polls its 8; a chain's sequences above its last one wait for their child, not for a
//! poll).
#![no_std]
#![no_main]

use rtseq_qemu_f405 as board;

/// Lanes and chain depth of each cell (running = lanes × depth).
const SHAPES: [(usize, usize); 5] = [(1, 1), (8, 1), (32, 1), (32, 2), (32, 8)];
/// Monitors per running sequence in each cell.
const MONITORS: [usize; 4] = [0, 1, 4, 8];
/// The cells: every shape with every number of monitors.
const CELLS: usize = SHAPES.len() * MONITORS.len();

/// `"c00d0"` .. `"c31d7"`: lane (chain) and depth.
const NAMES: [[u8; 5]; 256] = {
    let mut names = [[0u8; 5]; 256];
    let mut i = 0;
    while i < 256 {
        let (chain, depth) = (i / 8, i % 8);
        names[i] = [
            b'c',
            b'0' + (chain / 10) as u8,
            b'0' + (chain % 10) as u8,
            b'd',
            b'0' + depth as u8,
        ];
        i += 1;
    }
    names
};

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{board, CELLS, MONITORS, NAMES, SHAPES};
    use board::clock::TickTimer;
    use board::measure::{join_measured, measure_with, PollCosts};
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use rtseq::Sequencer;
    use rtseq::{Behaviour, Duration, Monitor, Monitors, RunningState, Seq, SeqConfig, SeqId};
    use rtseq_scenarios::{Arena, Child, Ctrl, FlagCond, Node};

    /// Most monitors in one table.
    const MAX_MONITORS: usize = 256;
    /// Chains (one per lane) and sequences per chain.
    const CHAINS: usize = 32;
    const DEPTH: usize = 8;
    /// Flag `k - 1` is the pre-condition of every sequence at depth `k` (1..8).
    const DEPTH_FLAGS: u8 = 0;
    /// Stays false: the monitors never fire.
    const QUIET: u8 = 8;
    /// Never set: the running sequences wait for it.
    const NEVER: u8 = 15;
    /// Ticks of a cell before the measured ones (the chains start, edges settle), and the
    /// measured ticks.
    const WARM: u32 = 3;
    const MEASURED: u32 = 6;
    /// Most ticks a cell waits for its runs to end after the abort.
    const DRAIN: u32 = 20;

    static CTRL: Ctrl = Ctrl::new();

    type Lk = rtseq::lock::PriorityCeiling<2>;
    type Seqr = Sequencer<Ctrl, 256, 64, Lk, 32, 8>;
    // SAFETY: every user of this sequencer runs at RTIC priority 2 (the tick) or below (the
    // lanes at 1, idle at 0).
    static SEQ: Seqr = unsafe { Seqr::with_priority_ceiling() };

    /// Per cell: the tick's and the period's most instructions (`u32::MAX`: not measured).
    static TICK: [AtomicU32; CELLS] = [const { AtomicU32::new(u32::MAX) }; CELLS];
    static PERIOD: [AtomicU32; CELLS] = [const { AtomicU32::new(u32::MAX) }; CELLS];
    /// TIM2 count at the entry of the last measured tick, and the most instructions from a
    /// measured tick's entry to `idle` (written by `idle`).
    static ENTRY: AtomicU32 = AtomicU32::new(0);
    static MEASURING: AtomicBool = AtomicBool::new(false);
    static PERIOD_MOST: AtomicU32 = AtomicU32::new(0);
    static DONE: AtomicBool = AtomicBool::new(false);
    /// The lanes' polls are not measured one by one here.
    static POLLS: PollCosts = PollCosts::new();

    #[shared]
    struct Shared {}

    /// Lanes joined in one task (a task per 8 lanes, as an application would group them).
    const PER_TASK: usize = 8;
    type Heads = [Option<Seq<Node<'static>>>; PER_TASK];

    #[local]
    struct Local {
        timer: TickTimer,
        heads0: Heads,
        heads1: Heads,
        heads2: Heads,
        heads3: Heads,
    }

    #[init(local = [slots: [Option<Child<'static>>; CHAINS * (DEPTH - 1)] = [const { None }; CHAINS * (DEPTH - 1)]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut arena = Arena::new(cx.local.slots);
        let mut heads = [const { None }; CHAINS];
        let mut build = || -> Result<(), rtseq::Error> {
            let every_ms = Duration::from_millis(1);
            for name in NAMES.iter() {
                let name = core::str::from_utf8(name).map_err(|_| rtseq::Error::EmptyName)?;
                SEQ.register(SeqConfig::new(name).polling(every_ms))?;
            }
            for (chain, head) in heads.iter_mut().enumerate() {
                // From the end of the chain up: each sequence runs the next one blocking.
                let mut below: Option<&'static mut Child<'static>> = None;
                for depth in (0..DEPTH).rev() {
                    let mut node = Node::new().exit(NEVER);
                    if depth > 0 {
                        node = node.pre(DEPTH_FLAGS + depth as u8 - 1);
                    }
                    if let Some(child) = below.take() {
                        node = node
                            .run(child)
                            .map_err(|_| rtseq::Error::SequenceCapacityExceeded)?;
                    }
                    let seq = SEQ.bind(SeqId::from_index(chain * DEPTH + depth), node)?;
                    if depth == 0 {
                        *head = Some(seq);
                    } else {
                        below = Some(
                            arena
                                .child(seq)
                                .map_err(|_| rtseq::Error::SequenceCapacityExceeded)?,
                        );
                    }
                }
            }
            Ok(())
        };
        if let Err(e) = build() {
            defmt::error!("bench_grid: setup failed: {}", e);
            board::exit_failure();
        }
        let mut heads = heads.into_iter();
        let mut task_heads = || core::array::from_fn(|_| heads.next().flatten());
        let (heads0, heads1, heads2, heads3) =
            (task_heads(), task_heads(), task_heads(), task_heads());
        lanes0::spawn().ok();
        lanes1::spawn().ok();
        lanes2::spawn().ok();
        lanes3::spawn().ok();
        (
            Shared {},
            Local {
                timer: TickTimer::start(cx.device.TIM2, &cx.device.RCC),
                heads0,
                heads1,
                heads2,
                heads3,
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
            if MEASURING.load(Ordering::Relaxed) {
                let took = board::clock::tim2_count().wrapping_sub(ENTRY.load(Ordering::Relaxed));
                PERIOD_MOST.fetch_max(took, Ordering::Relaxed);
            }
        }
    }

    fn report() -> ! {
        defmt::info!(
            "bench_grid: 256 registered, 1 ms polling, every tick due; instructions per due tick / per due period (tick entry -> idle)"
        );
        for (cell, (tick, period)) in TICK.iter().zip(PERIOD.iter()).enumerate() {
            let (lanes, depth) = SHAPES[cell / MONITORS.len()];
            let monitors = MONITORS[cell % MONITORS.len()];
            let (tick, period) = (tick.load(Ordering::Relaxed), period.load(Ordering::Relaxed));
            if tick == u32::MAX {
                defmt::info!(
                    "bench_grid: running {=usize} x monitors {=usize}: - (more than {=usize} monitors in one table)",
                    lanes * depth,
                    monitors,
                    MAX_MONITORS
                );
            } else {
                defmt::info!(
                    "bench_grid: running {=usize} x monitors {=usize}: tick = {=u32}, period = {=u32} instructions",
                    lanes * depth,
                    monitors,
                    tick,
                    period
                );
            }
        }
        board::exit_success();
    }

    /// Where the tick task is in the cells.
    pub struct Progress {
        cell: usize,
        /// Ticks into the cell (0: set it up).
        at: u32,
        monitors: Monitors<'static, Ctrl, MAX_MONITORS, FlagCond>,
    }

    /// Sets up cell `cell`: the depth flags, a monitor table for its running sequences,
    /// and the starts of its heads. False when its monitors do not fit one table.
    fn set_up(cell: usize, monitors: &mut Monitors<'static, Ctrl, MAX_MONITORS, FlagCond>) -> bool {
        let (lanes, depth) = SHAPES[cell / MONITORS.len()];
        let per = MONITORS[cell % MONITORS.len()];
        if lanes * depth * per > MAX_MONITORS {
            return false;
        }
        for k in 1..DEPTH {
            CTRL.set(DEPTH_FLAGS + k as u8 - 1, k < depth);
        }
        *monitors = Monitors::new();
        for chain in 0..lanes {
            for d in 0..depth {
                let owner = SeqId::from_index(chain * DEPTH + d);
                for _ in 0..per {
                    let quiet = FlagCond { flag: QUIET };
                    if monitors
                        .add(
                            owner,
                            Monitor::with_condition("quiet", quiet, Behaviour::AbortOwner),
                        )
                        .is_err()
                    {
                        defmt::error!("bench_grid: monitor table full");
                        board::exit_failure();
                    }
                }
            }
        }
        for chain in 0..lanes {
            let head = SEQ.sequence_by_id(SeqId::from_index(chain * DEPTH));
            if let Some(Err(e)) = head.map(|h| h.start()) {
                defmt::error!("bench_grid: start: {}", e);
                board::exit_failure();
            }
        }
        true
    }

    /// Whether no run is under way any more.
    fn all_ended() -> bool {
        (0..CHAINS * DEPTH).all(|i| {
            SEQ.sequence_by_id(SeqId::from_index(i)).is_none_or(|h| {
                !matches!(
                    h.state(),
                    RunningState::Running
                        | RunningState::Paused
                        | RunningState::Aborting
                        | RunningState::Restarting
                )
            })
        })
    }

    #[task(binds = TIM2, priority = 2, local = [timer, started: bool = false, progress: Progress = Progress { cell: 0, at: 0, monitors: Monitors::new() }])]
    fn tick(cx: tick::Context) {
        let entry = board::clock::tim2_count();
        let now = cx.local.timer.on_interrupt();
        if !*cx.local.started {
            // The first tick: the lanes have declared themselves.
            *cx.local.started = true;
            return;
        }
        let p = cx.local.progress;
        if p.cell == CELLS {
            cx.local.timer.stop();
            DONE.store(true, Ordering::Relaxed);
            return;
        }
        if p.at == 0 && !set_up(p.cell, &mut p.monitors) {
            p.cell += 1;
            return;
        }
        p.at += 1;
        let measured = (WARM + 1..=WARM + MEASURED).contains(&p.at);
        if measured {
            ENTRY.store(entry, Ordering::Relaxed);
        }
        MEASURING.store(measured, Ordering::Relaxed);
        let (cost, ticked) = measure_with(|| SEQ.tick(now, &CTRL, &mut p.monitors));
        if let Err(e) = ticked {
            defmt::error!("bench_grid: tick: {}", e);
            board::exit_failure();
        }
        if measured {
            if let Some(t) = TICK.get(p.cell) {
                let most = t.load(Ordering::Relaxed);
                t.store(
                    if most == u32::MAX {
                        cost
                    } else {
                        most.max(cost)
                    },
                    Ordering::Relaxed,
                );
            }
        }
        if p.at == WARM + MEASURED + 1 {
            // The periods of the measured ticks are in; stop the cell's runs.
            if let Some(slot) = PERIOD.get(p.cell) {
                slot.store(PERIOD_MOST.swap(0, Ordering::Relaxed), Ordering::Relaxed);
            }
            SEQ.abort_all();
        } else if p.at > WARM + MEASURED + 1 && all_ended() {
            p.cell += 1;
            p.at = 0;
        } else if p.at > WARM + MEASURED + 1 + DRAIN {
            defmt::error!("bench_grid: the runs of cell {=usize} did not end", p.cell);
            board::exit_failure();
        }
    }

    /// Runs the lanes of `heads`, joined in one task.
    async fn lanes(heads: &mut Heads) -> ! {
        let futs = heads.each_mut().map(|head| async move {
            match head {
                Some(seq) => match rtseq::lane(&SEQ, &CTRL, seq).await {},
                None => core::future::pending::<()>().await,
            }
        });
        join_measured(futs, &POLLS).await
    }

    #[task(priority = 1, local = [heads0])]
    async fn lanes0(cx: lanes0::Context) {
        lanes(cx.local.heads0).await
    }

    #[task(priority = 1, local = [heads1])]
    async fn lanes1(cx: lanes1::Context) {
        lanes(cx.local.heads1).await
    }

    #[task(priority = 1, local = [heads2])]
    async fn lanes2(cx: lanes2::Context) {
        lanes(cx.local.heads2).await
    }

    #[task(priority = 1, local = [heads3])]
    async fn lanes3(cx: lanes3::Context) {
        lanes(cx.local.heads3).await
    }
}
