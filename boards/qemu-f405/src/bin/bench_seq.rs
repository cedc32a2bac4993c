//! rtseq benchmarks in instructions and virtual time (QEMU `-icount shift=0`: one TIM2
//! count = one instruction = 1 ns).
//!
//! Four independent sequencers, ticked one after the other in the TIM2 interrupt, each tick
//! measured with `board::measure`:
//!
//! | sequencer | what | figure |
//! |---|---|---|
//! | `SEQ1` | 1 running sequence × 4 monitors, 1 ms polling | tick, all due, nothing firing |
//! | `SEQ8` | 8 running sequences × 4 monitors each, 2 ms polling | tick with all 8 × 4 due (odd ticks), tick with nothing due (even ticks) |
//! | `SEQF` | 1 running sequence, an `AbortOwner` monitor that fires at tick `FIRE` | tick in which one monitor fires; latency to `Aborted` |
//! | `SEQE` | 1 running sequence, a monitor with an exception sequence, firing at `FIRE` | latency to the exception sequence's first instruction |
//!
//! The fault flag is set in the tick handler right *after* the sequencers' tick `FIRE - 1`,
//! i.e. just after the monitors saw it false: the worst case of the reaction latency (a
//! whole polling period). Every running sequence waits for its exit condition in its lane,
//! so the due ticks include waking the lanes.
//!
//! Two figures cover the lanes too (the comparison with the hand-written baseline
//! `bench_hand`, `./x bench`): in the steady ticks where `SEQ8` is due, each poll of one of
//! its 8 lane futures is measured (`exit poll`: the lane's due exit-condition poll, the
//! condition false); from tick `SOLO` on only `SEQ8` is ticked (the others are finished or
//! left alone), with nothing measured inside its lanes, and `period CPU` is the virtual time
//! from the entry of a due tick's handler to the moment `idle` runs again: the tick, the
//! dispatch and every lane poll.
//!
//! Also prints `size_of` of the pieces (control block, trace record, monitor entry, lane
//! futures). `cargo fw-run bench_seq`; `tests/qemu_scenarios.rs` asserts the budgets.
#![no_std]
#![no_main]

use core::future::Future;
use core::sync::atomic::{AtomicU32, Ordering};

use rtseq::{Cx, Failure, Sequence};
use rtseq_qemu_f405 as board;
use rtseq_scenarios::{AtOnce, Ctrl};

/// Timestamps (TIM2 counts = ns of virtual time) of the latency measurement.
static FAULT_AT: AtomicU32 = AtomicU32::new(0);
static ABORTED_AT: AtomicU32 = AtomicU32::new(0);
static EXCEPTION_AT: AtomicU32 = AtomicU32::new(0);

/// The `on_abort` hook of `SEQF`'s owner: runs in `Aborting`, right before `Aborted`.
fn stamp_aborted(_: &Ctrl) {
    ABORTED_AT.store(board::clock::tim2_count(), Ordering::Relaxed);
}

/// `SEQE`'s exception sequence: its action stamps the time at its first instruction.
struct Stamp;

impl Sequence<Ctrl> for Stamp {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> impl Future<Output = Result<(), Failure>> {
        EXCEPTION_AT.store(board::clock::tim2_count(), Ordering::Relaxed);
        AtOnce
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{board, stamp_aborted, Stamp, ABORTED_AT, EXCEPTION_AT, FAULT_AT};
    use board::clock::TickTimer;
    use board::measure::{join_measured, measure_with, PollCosts};
    use core::future::Future;
    use core::mem::{size_of, size_of_val};
    use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
    use rtseq::{Behaviour, Duration, Monitor, Monitors, Seq, SeqConfig, Sequencer, Transition};
    use rtseq_scenarios::{Child, Ctrl, FlagCond, Node};

    /// Rtseq ticks measured.
    const TICKS: usize = 15;
    /// The tick at which the `SEQF`/`SEQE` monitors fire (fault set after tick FIRE - 1).
    const FIRE: usize = 9;
    /// From this tick on only `SEQ8` is ticked (the period CPU figure).
    const SOLO: usize = FIRE + 2;
    /// Flag of the firing monitors; flags 8.. stay false (the quiet monitors).
    const FAULT: u8 = 7;
    const QUIET: u8 = 8;
    /// Never set: the running sequences wait for it.
    const NEVER: u8 = 15;

    static CTRL: Ctrl = Ctrl::new();

    /// The lock under test: RTIC's priority ceiling (the tick's priority 2), or with the
    /// board feature `critical-section-lock` the portable default.
    #[cfg(not(feature = "critical-section-lock"))]
    type Lk = rtseq::lock::PriorityCeiling<2>;
    #[cfg(feature = "critical-section-lock")]
    type Lk = rtseq::lock::CriticalSection;
    type Seqr<const N: usize> = Sequencer<Ctrl, N, 64, Lk>;

    /// The condition holder of the measured monitor tables: `FlagCond` itself (static
    /// dispatch, the condition inlines into the tick), or with the board feature
    /// `dyn-conditions` the default `&mut dyn Condition`.
    #[cfg(not(feature = "dyn-conditions"))]
    type Cond = FlagCond;
    #[cfg(feature = "dyn-conditions")]
    type Cond = rtseq::DynCondition<'static, Ctrl>;

    /// A monitor that never fires.
    fn quiet(c: &'static mut FlagCond) -> Monitor<'static, Ctrl, Cond> {
        #[cfg(not(feature = "dyn-conditions"))]
        let c = *c;
        Monitor::with_condition("quiet", c, Behaviour::AbortOwner)
    }
    #[cfg(not(feature = "critical-section-lock"))]
    macro_rules! sequencer {
        // SAFETY: every user of these sequencers runs at RTIC priority 2 (the tick) or
        // below (the lanes at 1, idle at 0).
        () => {
            unsafe { Seqr::with_priority_ceiling() }
        };
    }
    #[cfg(feature = "critical-section-lock")]
    macro_rules! sequencer {
        () => {
            Seqr::new()
        };
    }
    static SEQ1: Seqr<1> = sequencer!();
    static SEQ8: Seqr<8> = sequencer!();
    static SEQF: Seqr<1> = sequencer!();
    static SEQE: Seqr<2> = sequencer!();

    /// Instructions per tick: [SEQ1, SEQ8, SEQF] × tick.
    static COST: [[AtomicU32; 3]; TICKS] = [const { [const { AtomicU32::new(0) }; 3] }; TICKS];
    /// TIM2 count at the entry of each tick handler.
    static ENTRY: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    /// TIM2 count when `idle` ran again after each tick (the tick and every task done).
    static IDLE_AT: [AtomicU32; TICKS] = [const { AtomicU32::new(0) }; TICKS];
    /// The last tick counted (`IDLE_AT`'s index).
    static CURRENT: AtomicUsize = AtomicUsize::new(0);
    /// The polls of `SEQ8`'s lane futures, measured in the steady ticks where they are due.
    static POLLS: PollCosts = PollCosts::new();
    static DONE: AtomicBool = AtomicBool::new(false);
    static LANE_NODE_BYTES: AtomicUsize = AtomicUsize::new(0);
    static LANE_STAMP_BYTES: AtomicUsize = AtomicUsize::new(0);
    static LANES8_BYTES: AtomicUsize = AtomicUsize::new(0);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        m1: Monitors<'static, Ctrl, 4, Cond>,
        m8: Monitors<'static, Ctrl, 32, Cond>,
        mf: Monitors<'static, Ctrl, 1>,
        me: Monitors<'static, Ctrl, 1>,
        one: Seq<Node<'static>>,
        eight: [Seq<Node<'static>>; 8],
        fire: Seq<Node<'static>>,
        owner: Seq<Node<'static>>,
        exc: Seq<Stamp>,
    }

    fn waiting() -> Node<'static> {
        Node::new().exit(NEVER)
    }

    #[init(local = [
        c1: [FlagCond; 4] = [FlagCond { flag: QUIET }; 4],
        c8: [FlagCond; 32] = [FlagCond { flag: QUIET }; 32],
        cf: FlagCond = FlagCond { flag: FAULT },
        ce: FlagCond = FlagCond { flag: FAULT },
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let setup = || -> Result<Local, rtseq::Error> {
            let two = Duration::from_millis(2);
            let one = SEQ1.add(SeqConfig::new("one"), waiting())?;
            let mut m1 = Monitors::new();
            for c in cx.local.c1.iter_mut() {
                m1.add(one.id(), quiet(c))?;
            }
            const NAMES: [&str; 8] = ["s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7"];
            let mut m8 = Monitors::new();
            let mut conds = cx.local.c8.iter_mut();
            let mut eight = [const { None }; 8];
            for (slot, name) in eight.iter_mut().zip(NAMES) {
                let s = SEQ8.add(SeqConfig::new(name).polling(two), waiting())?;
                for c in conds.by_ref().take(4) {
                    m8.add(s.id(), quiet(c))?;
                }
                *slot = Some(s);
            }
            let eight = eight.map(|s| s.ok_or(rtseq::Error::SequenceCapacityExceeded));
            let [a, b, c, d, e, f, g, h] = eight;
            let eight = [a?, b?, c?, d?, e?, f?, g?, h?];
            let fire = SEQF.add(SeqConfig::new("fire").on_abort(stamp_aborted), waiting())?;
            let mut mf = Monitors::new();
            mf.add(
                fire.id(),
                Monitor::new("fault", cx.local.cf, Behaviour::AbortOwner),
            )?;
            let owner = SEQE.add(SeqConfig::new("owner"), waiting())?;
            let exc = SEQE.add(SeqConfig::new("exception"), Stamp)?;
            let mut me = Monitors::new();
            me.add(
                owner.id(),
                Monitor::new("fault", cx.local.ce, Behaviour::AbortOwner).exception(exc.id()),
            )?;
            Ok(Local {
                timer: TickTimer::start(cx.device.TIM2, &cx.device.RCC),
                m1,
                m8,
                mf,
                me,
                one,
                eight,
                fire,
                owner,
                exc,
            })
        };
        let local = match setup() {
            Ok(l) => l,
            Err(e) => {
                defmt::error!("bench_seq: setup failed: {}", e);
                board::exit_failure();
            }
        };
        lane1::spawn().ok();
        lanes8::spawn().ok();
        lane_fire::spawn().ok();
        lanes_exc::spawn().ok();
        (Shared {}, local)
    }

    /// Starts the sequences once every lane is up; prints the figures after the last tick.
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

    /// Max of `which`'s cost over `ticks`.
    fn max_cost(ticks: impl Iterator<Item = usize>, which: usize) -> u32 {
        ticks.map(|t| cost(t, which)).max().unwrap_or(0)
    }

    fn report() -> ! {
        // Tick 1 is the first tick after the starts (everything due at once); steady
        // state from tick 2. SEQ8 (2 ms polling) is due at odd ticks.
        let steady = 2..FIRE;
        defmt::info!(
            "bench_seq: lock = {=str}",
            if cfg!(feature = "critical-section-lock") {
                "critical sections (critical-section crate)"
            } else {
                "RTIC priority ceiling (BASEPRI)"
            }
        );
        defmt::info!(
            "bench_seq: conditions = {=str}",
            if cfg!(feature = "dyn-conditions") {
                "&mut dyn Condition (default table)"
            } else {
                "one condition type (static dispatch)"
            }
        );
        defmt::info!(
            "bench_seq: tick 1 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone(), 0)
        );
        defmt::info!(
            "bench_seq: tick 8 x 4 due, nothing firing = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 1), 1)
        );
        defmt::info!(
            "bench_seq: tick nothing due (8 running) = {=u32} instructions",
            max_cost(steady.clone().filter(|t| t % 2 == 0), 1)
        );
        defmt::info!(
            "bench_seq: tick 1 x 1 due, nothing firing = {=u32} instructions",
            max_cost(steady, 2)
        );
        defmt::info!(
            "bench_seq: tick 1 monitor fires AbortOwner = {=u32} instructions",
            cost(FIRE, 2)
        );
        defmt::info!(
            "bench_seq: tick nothing running = {=u32} instructions",
            max_cost(FIRE + 1..TICKS, 2)
        );
        let fault = FAULT_AT.load(Ordering::Relaxed);
        let entry = |i: usize| ENTRY.get(i).map_or(0, |e| e.load(Ordering::Relaxed));
        let busy = |i: usize| {
            IDLE_AT
                .get(i)
                .map_or(0, |e| e.load(Ordering::Relaxed))
                .wrapping_sub(entry(i))
        };
        defmt::info!(
            "bench_seq: period CPU 8 x 4 due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 1)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        defmt::info!(
            "bench_seq: period CPU nothing due (tick entry -> idle) = {=u32} instructions",
            (SOLO..TICKS)
                .filter(|t| t % 2 == 0)
                .map(busy)
                .max()
                .unwrap_or(0)
        );
        defmt::info!(
            "bench_seq: exit poll (one lane, due, condition false) = {=u32} instructions (max {=u32}, {=u32} polls)",
            POLLS.mean(),
            POLLS.max(),
            POLLS.count()
        );
        let (aborted, exception) = (
            ABORTED_AT.load(Ordering::Relaxed),
            EXCEPTION_AT.load(Ordering::Relaxed),
        );
        defmt::info!(
            "bench_seq: tick period = {=u32} ns, condition true -> next tick = {=u32} ns",
            entry(FIRE).wrapping_sub(entry(FIRE - 1)),
            entry(FIRE).wrapping_sub(fault)
        );
        defmt::info!(
            "bench_seq: latency condition true -> owner Aborted = {=u32} ns (tick entry -> Aborted = {=u32} ns)",
            aborted.wrapping_sub(fault),
            aborted.wrapping_sub(entry(FIRE))
        );
        defmt::info!(
            "bench_seq: latency condition true -> exception sequence first instruction = {=u32} ns (tick entry -> exception = {=u32} ns)",
            exception.wrapping_sub(fault),
            exception.wrapping_sub(entry(FIRE))
        );
        let b8 = size_of::<Sequencer<Ctrl, 8, 64>>();
        let b16 = size_of::<Sequencer<Ctrl, 16, 64>>();
        let t32 = size_of::<Sequencer<Ctrl, 8, 32>>();
        let m4 = size_of::<Monitors<'static, Ctrl, 4>>();
        let m8 = size_of::<Monitors<'static, Ctrl, 8>>();
        // A sequence's RAM: its control block with its run clock and its exception's restart
        // limit (kept beside it), and its cleanup-hook slot (an array beside).
        let per_sequence = (b16 - b8) / 8;
        let hook_slot = size_of::<Option<fn(&Ctrl)>>();
        defmt::info!(
            "bench_seq: size control block = {=usize} bytes (with its run clock and restart limit; per sequence {=usize}, with its cleanup-hook slot)",
            per_sequence - hook_slot,
            per_sequence
        );
        defmt::info!(
            "bench_seq: size trace record = {=usize} bytes (Transition {=usize})",
            (b8 - t32) / 32,
            size_of::<Transition>()
        );
        defmt::info!(
            "bench_seq: size trace buffers (4 sequencers x 64 records) = {=usize} bytes",
            (b8 - t32) / 32 * 64 * 4
        );
        defmt::info!(
            "bench_seq: size monitor entry = {=usize} bytes",
            (m8 - m4) / 4
        );
        defmt::info!(
            "bench_seq: size Sequencer<Ctrl, 8, 64> = {=usize} bytes, Sequencer<Ctrl, 16, 64> = {=usize} bytes",
            b8,
            b16
        );
        defmt::info!(
            "bench_seq: size lane future (Seq<Node>, scenarios' node) = {=usize} bytes",
            LANE_NODE_BYTES.load(Ordering::Relaxed)
        );
        defmt::info!(
            "bench_seq: size lane future (one-shot sequence) = {=usize} bytes",
            LANE_STAMP_BYTES.load(Ordering::Relaxed)
        );
        defmt::info!(
            "bench_seq: size 8 joined lanes = {=usize} bytes",
            LANES8_BYTES.load(Ordering::Relaxed)
        );
        defmt::info!(
            "bench_seq: size Seq<Node> = {=usize} bytes, arena slot of a blocking child = {=usize} bytes, Ctrl = {=usize} bytes",
            size_of::<Seq<Node>>(),
            size_of::<Option<Child>>(),
            size_of::<Ctrl>()
        );
        board::exit_success();
    }

    /// A tick's result: the benchmark's times only go forward, so an error is a failure.
    fn check(ticked: Result<(), rtseq::Error>) {
        if let Err(e) = ticked {
            defmt::error!("bench_seq: tick: {}", e);
            board::exit_failure();
        }
    }

    /// The heartbeat: ticks the four sequencers, measuring three of them.
    #[task(binds = TIM2, priority = 2, local = [timer, m1, m8, mf, me, n: usize = 0, started: bool = false])]
    fn tick(cx: tick::Context) {
        let entry = board::clock::tim2_count();
        let now = cx.local.timer.on_interrupt();
        if let Some(e) = ENTRY.get(*cx.local.n + 1) {
            e.store(entry, Ordering::Relaxed);
        }
        CURRENT.store(*cx.local.n + 1, Ordering::Relaxed);
        if !*cx.local.started {
            // First tick: the lanes have run (declared themselves); start everything now,
            // at sequencer time 0 (no sequencer has ticked yet).
            *cx.local.started = true;
            for s in [&SEQ1 as &dyn Starter, &SEQ8, &SEQF, &SEQE] {
                s.start_all();
            }
            return;
        }
        let n = *cx.local.n + 1;
        *cx.local.n = n;
        let (m1, m8, mf) = (cx.local.m1, cx.local.m8, cx.local.mf);
        // Exit polls measured where SEQ8 is due in the steady state.
        POLLS.enable((2..FIRE).contains(&n) && n % 2 == 1);
        // The firing sequencers first, so their reaction is measured from the entry of this
        // handler (an application has one sequencer; the others are only benchmarks). At
        // the firing tick SEQ1 and SEQ8 are not ticked (their lanes would be dispatched
        // before the exception sequence's lane).
        // From SOLO on, SEQ8 alone: the period CPU figure.
        let solo = n >= SOLO;
        let cf = if solo {
            0
        } else {
            let (cf, ticked) = measure_with(|| SEQF.tick(now, &CTRL, mf));
            check(ticked);
            check(SEQE.tick(now, &CTRL, cx.local.me));
            cf
        };
        let c1 = if solo || n == FIRE {
            0
        } else {
            let (c1, ticked) = measure_with(|| SEQ1.tick(now, &CTRL, m1));
            check(ticked);
            c1
        };
        let c8 = if n == FIRE {
            0
        } else {
            let (c8, ticked) = measure_with(|| SEQ8.tick(now, &CTRL, m8));
            check(ticked);
            c8
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

    /// Starts every main sequence (every sequence that has a lane) of a sequencer.
    trait Starter {
        fn start_all(&self);
    }
    impl<const N: usize> Starter for Seqr<N> {
        fn start_all(&self) {
            for i in 0..self.len() {
                if let Some(h) = self.sequence_by_id(rtseq::SeqId::from_index(i)) {
                    if h.name() != "exception" {
                        let _ = h.start();
                    }
                }
            }
        }
    }

    #[task(priority = 1, local = [one])]
    async fn lane1(cx: lane1::Context) {
        let fut = rtseq::lane(&SEQ1, &CTRL, cx.local.one);
        LANE_NODE_BYTES.store(size_of_val(&fut), Ordering::Relaxed);
        match fut.await {}
    }

    #[task(priority = 1, local = [eight])]
    async fn lanes8(cx: lanes8::Context) {
        let futs = cx
            .local
            .eight
            .each_mut()
            .map(|s| rtseq::lane(&SEQ8, &CTRL, s));
        let all = join_measured(futs, &POLLS);
        LANES8_BYTES.store(size_of_val(&all), Ordering::Relaxed);
        all.await
    }

    #[task(priority = 1, local = [fire])]
    async fn lane_fire(cx: lane_fire::Context) {
        match rtseq::lane(&SEQF, &CTRL, cx.local.fire).await {}
    }

    #[task(priority = 1, local = [owner, exc])]
    async fn lanes_exc(cx: lanes_exc::Context) {
        let owner = rtseq::lane(&SEQE, &CTRL, cx.local.owner);
        let exc = rtseq::lane(&SEQE, &CTRL, cx.local.exc);
        LANE_STAMP_BYTES.store(size_of_val(&exc), Ordering::Relaxed);
        let mut owner = core::pin::pin!(owner);
        let mut exc = core::pin::pin!(exc);
        core::future::poll_fn(|w| {
            let _ = owner.as_mut().poll(w);
            let _ = exc.as_mut().poll(w);
            core::task::Poll::<()>::Pending
        })
        .await;
    }
}
