//! The size side of the comparison with the hand-written baseline: `bench_hand`'s
//! workloads in rtseq the way an application would write them, for the `flash` and
//! `ram_without_trace` figures of `./x bench`.
//!
//! `bench_seq` measures instructions: it keeps four sequencers of three capacities (the
//! tick monomorphised for each), monitor tables of two condition types and the scenarios'
//! `Node` interpreter as its sequence type, all of which count in its size and none of
//! which `bench_hand` has. Here the same workloads share one sequencer and one monitor
//! table: one sequence × 4 quiet monitors at 1 ms, 8 × 4 at 2 ms, one sequence whose
//! monitor fires `AbortOwner` with a cleanup hook, one whose monitor starts an exception
//! sequence; every sequence but the exception waits for an exit condition that stays
//! false (one small sequence type), each in its lane, the waiting ones joined in one task. The
//! fault flag is set after tick `FIRE - 1`, as in `bench_hand`; after `TICKS` ticks the
//! firmware checks that both reactions happened and exits. It prints its trace buffer's
//! size, which `./x bench` subtracts from its RAM.
#![no_std]
#![no_main]

use core::future::Future;
use core::sync::atomic::{AtomicBool, Ordering};

use rtseq::{Cx, Failure, Sequence};
use rtseq_qemu_f405 as board;
use rtseq_scenarios::{AtOnce, Ctrl};

/// Never set: the running sequences wait for it.
const NEVER: u8 = 15;

static HOOK_RAN: AtomicBool = AtomicBool::new(false);
static EXCEPTION_RAN: AtomicBool = AtomicBool::new(false);

/// The cleanup hook of the firing sequence.
fn aborted(_: &Ctrl) {
    HOOK_RAN.store(true, Ordering::Relaxed);
}

/// A sequence that runs until its exit condition holds (never, here).
struct Waiting;

impl Sequence<Ctrl> for Waiting {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> impl Future<Output = Result<(), Failure>> {
        AtOnce
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(NEVER)
    }
}

/// The exception sequence: notes that it ran.
struct Exception;

impl Sequence<Ctrl> for Exception {
    #[allow(clippy::manual_async_fn)]
    fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> impl Future<Output = Result<(), Failure>> {
        EXCEPTION_RAN.store(true, Ordering::Relaxed);
        AtOnce
    }
}

#[rtic::app(device = rtseq_qemu_f405::pac, dispatchers = [CAN1_TX])]
mod app {
    use super::{aborted, board, Exception, Waiting, EXCEPTION_RAN, HOOK_RAN};
    use board::clock::TickTimer;
    use board::measure::{join_measured, PollCosts};
    use core::mem::size_of;
    use core::sync::atomic::Ordering;
    use rtseq::{Behaviour, Duration, Monitor, Monitors, Seq, SeqConfig, Sequencer, Transition};
    use rtseq_scenarios::{Ctrl, FlagCond};

    /// Ticks run, and the tick at which the fault monitors fire.
    const TICKS: u32 = 15;
    const FIRE: u32 = 9;
    /// The fault flag; flag 8 stays false (the quiet monitors).
    const FAULT: u8 = 7;
    const QUIET: u8 = 8;
    /// Sequences waiting in lanes: 1 + 8 + the firing one + the exception's owner.
    const WAITING: usize = 11;
    const MONITORS: usize = 4 + 32 + 1 + 1;
    const TRACE: usize = 64;

    static CTRL: Ctrl = Ctrl::new();

    /// Sized to the application: 12 sequences, 12 lanes.
    type Seqr = Sequencer<Ctrl, 12, TRACE, rtseq::lock::PriorityCeiling<2>, 12>;
    // SAFETY: every user of this sequencer runs at RTIC priority 2 (the tick) or below (the
    // lanes at 1, idle at 0).
    static SEQ: Seqr = unsafe { Seqr::with_priority_ceiling() };

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        timer: TickTimer,
        monitors: Monitors<'static, Ctrl, MONITORS, FlagCond>,
        waiting: [Seq<Waiting>; WAITING],
        exception: Seq<Exception>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let setup = || -> Result<Local, rtseq::Error> {
            let (one_ms, two_ms) = (Duration::from_millis(1), Duration::from_millis(2));
            let quiet = || {
                Monitor::with_condition("quiet", FlagCond { flag: QUIET }, Behaviour::AbortOwner)
            };
            let fault = || {
                Monitor::with_condition("fault", FlagCond { flag: FAULT }, Behaviour::AbortOwner)
            };
            const NAMES: [&str; WAITING] = [
                "one", "s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "fire", "owner",
            ];
            let mut monitors = Monitors::new();
            let mut waiting = [const { None }; WAITING];
            for (i, (slot, name)) in waiting.iter_mut().zip(NAMES).enumerate() {
                let config = match i {
                    1..=8 => SeqConfig::new(name).polling(two_ms),
                    9 => SeqConfig::new(name).polling(one_ms).on_abort(aborted),
                    _ => SeqConfig::new(name).polling(one_ms),
                };
                *slot = Some(SEQ.add(config, Waiting)?);
            }
            let exception = SEQ.add(SeqConfig::new("exception"), Exception)?;
            for (i, s) in waiting.iter().enumerate() {
                let Some(s) = s else { continue };
                match i {
                    0..=8 => {
                        for _ in 0..4 {
                            monitors.add(s.id(), quiet())?;
                        }
                    }
                    9 => {
                        monitors.add(s.id(), fault())?;
                    }
                    _ => {
                        monitors.add(s.id(), fault().exception(exception.id()))?;
                    }
                }
            }
            let waiting = waiting.map(|s| s.ok_or(rtseq::Error::SequenceCapacityExceeded));
            let [a, b, c, d, e, f, g, h, i, j, k] = waiting;
            Ok(Local {
                timer: TickTimer::start(cx.device.TIM2, &cx.device.RCC),
                monitors,
                waiting: [a?, b?, c?, d?, e?, f?, g?, h?, i?, j?, k?],
                exception,
            })
        };
        match setup() {
            Ok(local) => {
                lanes::spawn().ok();
                exception_lane::spawn().ok();
                (Shared {}, local)
            }
            Err(e) => {
                defmt::error!("bench_size: setup failed: {}", e);
                board::exit_failure();
            }
        }
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[task(binds = TIM2, priority = 2, local = [timer, monitors, n: u32 = 0])]
    fn tick(cx: tick::Context) {
        let now = cx.local.timer.on_interrupt();
        let n = *cx.local.n;
        *cx.local.n = n + 1;
        if n == 0 {
            // The lanes have declared themselves: start every waiting sequence.
            for i in 0..WAITING {
                if let Some(Err(e)) = SEQ
                    .sequence_by_id(rtseq::SeqId::from_index(i))
                    .map(|h| h.start())
                {
                    defmt::error!("bench_size: start: {}", e);
                    board::exit_failure();
                }
            }
            return;
        }
        if let Err(e) = SEQ.tick(now, &CTRL, cx.local.monitors) {
            defmt::error!("bench_size: tick: {}", e);
            board::exit_failure();
        }
        if n + 1 == FIRE {
            CTRL.set(FAULT, true);
        }
        if n == TICKS {
            cx.local.timer.stop();
            let reacted = HOOK_RAN.load(Ordering::Relaxed) && EXCEPTION_RAN.load(Ordering::Relaxed);
            defmt::info!(
                "bench_size: size trace buffer ({=usize} records) = {=usize} bytes",
                TRACE,
                TRACE * size_of::<Transition>()
            );
            if reacted {
                defmt::info!("bench_size: the cleanup hook and the exception sequence ran");
                board::exit_success();
            }
            defmt::error!("bench_size: a reaction did not happen");
            board::exit_failure();
        }
    }

    /// Not enabled: the lanes' polls are not measured here.
    static POLLS: PollCosts = PollCosts::new();

    #[task(priority = 1, local = [waiting])]
    async fn lanes(cx: lanes::Context) {
        let waiting = cx
            .local
            .waiting
            .each_mut()
            .map(|s| rtseq::lane(&SEQ, &CTRL, s));
        join_measured(waiting, &POLLS).await
    }

    #[task(priority = 1, local = [exception])]
    async fn exception_lane(cx: exception_lane::Context) {
        match rtseq::lane(&SEQ, &CTRL, cx.local.exception).await {}
    }
}
