//! The host simulator (feature `std`): lanes and ticks in simulated time, deterministic,
//! with the full transition trace.
//!
//! It is the same code that runs on the chip: the simulator only replaces the RTIC
//! executor and the timer interrupt (it calls [`Sequencer::tick`] every `period` of
//! simulated time).
//!
//! A simulator drives a sequencer with any lock. A sequencer made with
//! [`Sequencer::single_thread`] (no lock, [`SingleThread`](crate::lock::SingleThread))
//! gives the same traces faster than the default's critical sections, which on the host
//! are a global mutex (`./x bench` prints both rates).
//!
//! # The order of the lanes
//!
//! Each lane has an RTIC priority ([`Sim::lane_with_priority`]; [`Sim::lane`] gives
//! [`DEFAULT_LANE_PRIORITY`]). The simulator polls woken lanes the way RTIC 2 dispatches
//! software tasks (read in `rtic-macros` 2.4.0, `codegen/async_dispatchers.rs`, and
//! `rtic` 2.4.0, `export/executor.rs`):
//!
//! - Each priority level has one dispatcher. It runs while any lane of a higher level is
//!   woken only after those have run: the highest woken level goes first.
//! - One run of a dispatcher (a *pass*) visits the lanes of its level in a fixed order and
//!   polls each one that is woken at that moment, once. A lane woken during the pass is
//!   polled in the same pass if it comes later in the order, else in the next pass.
//!   RTIC's fixed order is the alphabetical order of the task names (the tasks of a level
//!   are a `BTreeSet` of identifiers), **not** the order they became ready; the simulator
//!   uses the order the lanes were added, so add them in the order of their RTIC task
//!   names to mirror a firmware exactly.
//! - A lane that wakes a lane of a higher priority is preempted: the higher lane runs
//!   before the pass goes on. On the chip it runs at the wake-up itself, inside the
//!   waker's poll; the simulator cannot split a poll and runs it right after the poll that
//!   woke it (the waker's trace up to its next await point comes first).
//! - The tick (the timer interrupt) is above every lane, as in RTIC where the lanes run at
//!   or below the sequencer lock's ceiling, the tick's priority.
//!
//! [`Sim::shuffle_equal_priorities`] replaces the fixed order of each pass by a random one
//! (deterministic per seed), to find applications that depend on the order of lanes of
//! equal priority woken in the same tick.

extern crate std;

use std::boxed::Box;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Context, Wake, Waker};
use std::vec::Vec;

use core::convert::Infallible;
use core::future::Future;

use crate::lock::Lock;

use crate::{
    lane, Duration, Error, Handle, Instant, Monitors, Record, RunningState, Seq, SeqId, Sequence,
    Sequencer, Transition,
};

/// Upper bound of lane polls in one settle, to turn a livelock into a visible stop.
const MAX_POLLS_PER_SETTLE: usize = 100_000;

/// The priority of a lane added with [`Sim::lane`]: 1, the lowest RTIC priority of a
/// dispatched software task (the demo firmware's lanes all run at 1).
///
/// ```
/// use rtseq::sim::{Sim, DEFAULT_LANE_PRIORITY};
/// use rtseq::{Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
/// struct Blink;
/// impl Sequence<()> for Blink {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let (a, b) = (seq.add(SeqConfig::new("a"), Blink), seq.add(SeqConfig::new("b"), Blink));
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(a.unwrap());
/// sim.lane_with_priority(b.unwrap(), DEFAULT_LANE_PRIORITY); // the same as `sim.lane(b)`
/// assert_eq!(sim.lane_priorities(), [1, 1]);
/// ```
pub const DEFAULT_LANE_PRIORITY: u8 = 1;

/// A misuse of the simulator's set-up.
///
/// ```
/// use rtseq::sim::{Sim, SimError};
/// use rtseq::{Duration, Monitors, Sequencer};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new()).with_period(Duration::from_ticks(0));
/// assert_eq!(sim.err(), Some(SimError::ZeroPeriod));
/// assert_eq!(SimError::ZeroPeriod.to_string(), "the tick period must be longer than 0");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SimError {
    /// A tick period of 0: simulated time would never advance and `run_for` would never
    /// end.
    ZeroPeriod,
    /// A tick period of 2^31 µs (about 35.8 minutes) or more: the sequencer compares times
    /// by their wrapping difference in 32 bits of µs, so polls and timeouts would come
    /// late (see [`Sequencer::tick`]).
    PeriodTooLong,
    /// A start time earlier than the sequencer's (it was ticked before): time does not go
    /// back.
    StartBeforeSequencerTime,
    /// A start time set while a sequence is under way: it was started at the sequencer's
    /// time then, and its run clock counts from there; set the start time first.
    SequenceUnderWay,
}

impl core::fmt::Display for SimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SimError::ZeroPeriod => "the tick period must be longer than 0",
            SimError::PeriodTooLong => "the tick period must be shorter than 2^31 us (35.8 min)",
            SimError::StartBeforeSequencerTime => {
                "the simulator cannot start before its sequencer's time"
            }
            SimError::SequenceUnderWay => {
                "the simulator's start time is set before any sequence starts"
            }
        })
    }
}

impl std::error::Error for SimError {}

/// SplitMix64 (Steele, Lea, Flood 2014): a small generator that takes any seed, 0
/// included. Enough to shuffle a few lanes; not for anything else.
struct Shuffle(u64);

impl Shuffle {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (`n` > 0; the bias of the remainder is negligible for a few lanes).
    fn below(&mut self, n: usize) -> usize {
        let n64 = u64::try_from(n).unwrap_or(u64::MAX).max(1);
        usize::try_from(self.next() % n64).unwrap_or(0)
    }

    /// Fisher-Yates.
    fn shuffle(&mut self, v: &mut [usize]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i.saturating_add(1));
            v.swap(i, j);
        }
    }
}

struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
}

struct SimLane<'a> {
    future: Pin<Box<dyn Future<Output = Infallible> + 'a>>,
    flag: Arc<Flag>,
    waker: Waker,
    polls: usize,
    priority: u8,
}

type BeforeTick<'a, C> = Box<dyn FnMut(Instant, &C) + 'a>;

/// A deterministic simulation of an rtseq application on the host.
///
/// ```
/// use rtseq::sim::Sim;
/// use rtseq::{Cause, Cx, Duration, Failure, Monitors, RunningState::*, SeqConfig, Sequence,
///             Sequencer, Transition, Wait};
/// struct Main { dwell: rtseq::Seq<Wait> }
/// impl Sequence<()> for Main {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         let _ = cx.step(&mut self.dwell).await;
///         Ok(())
///     }
/// }
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(3))).unwrap();
/// let (w, main) = (dwell.id(), seq.add(SeqConfig::new("main"), Main { dwell }).unwrap());
/// let m = main.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(main);
/// sim.start(m).unwrap();
/// sim.run_for(Duration::from_millis(5));
/// assert_eq!(sim.trace(), &[
///     Transition::at_millis(0, m, Idle, Running, Cause::Start),
///     Transition::at_millis(0, w, Idle, Running, Cause::Start),
///     Transition::at_millis(3, w, Running, Terminated, Cause::Completed),
///     Transition::at_millis(3, m, Running, Terminated, Cause::Completed),
/// ]);
/// ```
pub struct Sim<
    'a,
    C,
    const N: usize,
    const T: usize,
    const M: usize,
    K = crate::DynCondition<'a, C>,
    const W: usize = 8,
    const B: usize = 1,
    L: Lock = crate::lock::CriticalSection,
> {
    sequencer: &'a Sequencer<C, N, T, L, W, B>,
    control: &'a C,
    /// Boxed: a sequencer is ticked with its table at one place
    /// ([`Sequencer::tick`]), and a simulator may be moved.
    monitors: Box<Monitors<'a, C, M, K>>,
    lanes: Vec<SimLane<'a>>,
    period: Duration,
    now: Instant,
    trace: Vec<Transition>,
    /// Every record, transitions and events, in order.
    records: Vec<Record>,
    lost: u32,
    stalled: bool,
    /// The first error a tick returned (the sequencer was ticked past the simulator).
    tick_error: Option<Error>,
    /// The numbers of sequences, monitors and declared lanes the configuration was last
    /// validated with (none before the first start): a start after registrations or lane
    /// declarations validates again.
    validated: Option<(usize, usize, u8)>,
    /// The before-tick hooks, in the order they were added.
    before_tick: Vec<BeforeTick<'a, C>>,
    /// Shuffles the order of each pass (`shuffle_equal_priorities`).
    shuffle: Option<Shuffle>,
    /// Names of the safety levels and critical inputs for the trace file (`name_safety`).
    safety_names: SafetyNames,
}

/// The names of a safety system's levels and critical inputs, by id.
#[derive(Default)]
struct SafetyNames {
    levels: Vec<(u8, std::string::String)>,
    inputs: Vec<(u8, std::string::String)>,
}

impl SafetyNames {
    fn find(names: &[(u8, std::string::String)], id: u8) -> Option<&str> {
        names
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, n)| n.as_str())
    }
}

impl<
        'a,
        C,
        const N: usize,
        const T: usize,
        const M: usize,
        K: crate::Condition<C>,
        const W: usize,
        const B: usize,
        L: Lock,
    > Sim<'a, C, N, T, M, K, W, B, L>
{
    /// A simulation with a 1 ms (1 kHz) tick, from the sequencer's time (0 for a sequencer
    /// never ticked).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Instant, Monitors, SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// seq.register(SeqConfig::new("main")).unwrap();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// assert_eq!(sim.now(), Instant::from_ticks(0));
    /// sim.step();
    /// assert_eq!(sim.now().as_ticks(), 1_000); // µs
    /// assert!(!sim.any_active());
    /// ```
    pub fn new(
        sequencer: &'a Sequencer<C, N, T, L, W, B>,
        control: &'a C,
        monitors: Monitors<'a, C, M, K>,
    ) -> Self {
        Sim {
            sequencer,
            control,
            monitors: Box::new(monitors),
            lanes: Vec::new(),
            period: Duration::from_millis(1),
            now: sequencer.now(),
            trace: Vec::new(),
            records: Vec::new(),
            lost: 0,
            stalled: false,
            tick_error: None,
            validated: None,
            before_tick: Vec::new(),
            shuffle: None,
            safety_names: SafetyNames::default(),
        }
    }

    /// Takes the names of the safety levels and critical inputs of `properties`, so that
    /// the trace file ([`save_trace`](Self::save_trace)) names them in its safety events
    /// (else they are "level 3", "input 0").
    ///
    /// ```
    /// use rtseq::safety::*;
    /// use rtseq::{sim::Sim, Monitors, Sequencer};
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// const ESTOP: CriticalInput<bool> = CriticalInput::new(0, "estop");
    /// static PROPS: SafetyProperties<'static, (), 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[ESTOP.info()], &[], &[], OFF);
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.name_safety(&PROPS);
    /// // What a safety cycle tells the sequencer is recorded by the next tick.
    /// seq.level_entered(OFF);
    /// seq.input_tripped(ESTOP.id());
    /// sim.step();
    /// let mut file = Vec::new();
    /// sim.write_trace(&mut file).unwrap();
    /// let text = String::from_utf8(file).unwrap();
    /// assert!(text.contains(r#"{"t":1000,"level":"off","id":0}"#));
    /// assert!(text.contains(r#"{"t":1000,"event":"input","input":0,"name":"estop","#));
    /// ```
    pub fn name_safety<IO, const LV: usize>(
        &mut self,
        properties: &crate::safety::SafetyProperties<'_, IO, LV>,
    ) {
        use std::string::ToString;
        self.safety_names = SafetyNames {
            levels: properties
                .levels()
                .iter()
                .map(|d| (d.level().id(), d.name().to_string()))
                .collect(),
            inputs: properties
                .inputs()
                .iter()
                .filter_map(|i| Some((u8::try_from(i.id().index()).ok()?, i.name().to_string())))
                .collect(),
        };
    }

    /// Changes the tick period; a period of 0 is an `Err(SimError::ZeroPeriod)` (simulated
    /// time would stand still), one of 2^31 µs or more `Err(SimError::PeriodTooLong)`.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Duration, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
    ///     .with_period(Duration::from_millis(10))?;
    /// sim.step();
    /// sim.step();
    /// assert_eq!(sim.now().duration_since_epoch(), Duration::from_millis(20));
    /// # Ok::<(), rtseq::sim::SimError>(())
    /// ```
    pub fn with_period(mut self, period: Duration) -> Result<Self, SimError> {
        if period.as_ticks() == 0 {
            return Err(SimError::ZeroPeriod);
        }
        if period.as_ticks() >= 1 << 31 {
            return Err(SimError::PeriodTooLong);
        }
        self.period = period;
        Ok(self)
    }

    /// Polls the woken lanes of equal priority in a random order, a new one for every pass
    /// (see [the order of the lanes](self#the-order-of-the-lanes)), drawn from `seed`: the
    /// same seed gives the same run. Lanes of different priorities keep RTIC's order.
    ///
    /// Two lanes of equal priority whose dwells end in the same tick: with the declaration
    /// order `a` ends first; the seeds 1 and 3 give the two possible orders.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, SeqId, Sequence,
    ///             Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// fn first_to_end(seed: Option<u64>) -> SeqId {
    ///     let seq: Sequencer<(), 4> = Sequencer::new();
    ///     let ms = |n| Wait::new(Duration::from_millis(n));
    ///     let (wa, wb) = (seq.add(SeqConfig::new("wa"), ms(2)), seq.add(SeqConfig::new("wb"), ms(2)));
    ///     let a = seq.add(SeqConfig::new("a"), Dwell(wa.unwrap())).unwrap();
    ///     let b = seq.add(SeqConfig::new("b"), Dwell(wb.unwrap())).unwrap();
    ///     let ids = [a.id(), b.id()];
    ///     let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    ///     if let Some(seed) = seed {
    ///         sim = sim.shuffle_equal_priorities(seed);
    ///     }
    ///     sim.lane(a);
    ///     sim.lane(b);
    ///     for id in ids {
    ///         sim.start(id).unwrap();
    ///     }
    ///     sim.run_for(Duration::from_millis(2));
    ///     let ends = sim.trace().iter().filter(|t| ids.contains(&t.sequence) && t.time.as_ticks() == 2_000);
    ///     ends.map(|t| t.sequence).next().unwrap()
    /// }
    /// let (a, b) = (SeqId::from_index(2), SeqId::from_index(3));
    /// assert_eq!(first_to_end(None), a);
    /// assert_eq!(first_to_end(Some(1)), a);
    /// assert_eq!(first_to_end(Some(3)), b);
    /// ```
    pub fn shuffle_equal_priorities(mut self, seed: u64) -> Self {
        self.shuffle = Some(Shuffle(seed));
        self
    }

    /// Starts the simulated clock at `t` instead of the sequencer's time (0 for a sequencer
    /// never ticked), e.g. to run across the wrap of the polling classes' 32-bit
    /// microsecond times at 2^32 µs ≈ 71.6 min. A time earlier than the sequencer's is
    /// `Err(SimError::StartBeforeSequencerTime)`; one set while a sequence is under way
    /// (started at the sequencer's time before, its run clock counting from there) is
    /// `Err(SimError::SequenceUnderWay)`.
    ///
    /// A 5 ms dwell across the wrap:
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Instant, Monitors, Seq, SeqConfig, Sequence,
    ///             Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let start = Instant::from_ticks((1 << 32) - 2_000); // 2 ms before the wrap
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new()).starting_at(start)?;
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// let done = sim.run_until_idle(Duration::from_millis(10)).unwrap();
    /// assert_eq!(done - start, Duration::from_millis(5));
    /// # Ok::<(), rtseq::sim::SimError>(())
    /// ```
    pub fn starting_at(mut self, t: Instant) -> Result<Self, SimError> {
        if t < self.sequencer.now() {
            return Err(SimError::StartBeforeSequencerTime);
        }
        if self.any_active() {
            return Err(SimError::SequenceUnderWay);
        }
        self.now = t;
        self.sequencer.with(|s| s.now = t);
        Ok(self)
    }

    /// Called before every tick with the new time: step the plant, inject faults. Each call
    /// adds a hook; the hooks run in the order they were added (a plant model, then a
    /// fault injector, say, or the safety system's cycle).
    ///
    /// A heater model: each tick raises the temperature by one degree, and a step waits for 30°:
    ///
    /// ```
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Seq, Sequencer,
    ///             Step};
    /// struct Heat;
    /// impl Step<Cell<u32>> for Heat {
    ///     fn action(&mut self, _cx: &Cx<'_, Cell<u32>>) -> Result<(), Failure> { Ok(()) }
    ///     fn check_exit_condition(&mut self, cx: &Cx<'_, Cell<u32>>) -> bool {
    ///         cx.control().get() >= 30
    ///     }
    /// }
    /// struct Main(Seq<Heat>);
    /// impl Sequence<Cell<u32>> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<u32>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<u32>, 2> = Sequencer::new();
    /// let heat = seq.add(SeqConfig::new("heat"), Heat).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(heat)).unwrap();
    /// let (id, temperature) = (main.id(), Cell::new(20));
    /// let mut sim = Sim::new(&seq, &temperature, Monitors::<Cell<u32>, 1>::new());
    /// sim.lane(main);
    /// sim.before_tick(|_now, t| t.set(t.get() + 1));
    /// sim.start(id).unwrap();
    /// let done = sim.run_until_idle(Duration::from_millis(100)).unwrap();
    /// assert_eq!(done.duration_since_epoch(), Duration::from_millis(10));
    /// assert_eq!(temperature.get(), 30);
    /// ```
    pub fn before_tick(&mut self, f: impl FnMut(Instant, &C) + 'a) {
        self.before_tick.push(Box::new(f));
    }

    /// Adds a lane running `seq` whenever it is started non-blocking, at
    /// [`DEFAULT_LANE_PRIORITY`]. Lanes of equal priority are polled in the order they were
    /// added ([`lane_with_priority`](Self::lane_with_priority) has the whole order).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Error, Failure, Monitors, RunningState, SeqConfig, Sequence,
    ///             Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// assert_eq!(sim.start(id), Err(Error::NoLane(id)));
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.state(id), RunningState::Terminated); // ran at once, in its lane
    /// ```
    pub fn lane<S: Sequence<C> + 'a>(&mut self, seq: Seq<S>)
    where
        C: 'a,
    {
        self.lane_with_priority(seq, DEFAULT_LANE_PRIORITY);
    }

    /// Adds a lane running `seq` as an RTIC task of `priority` (higher runs first; see
    /// [the order of the lanes](self#the-order-of-the-lanes)). Lanes of equal priority are
    /// polled in the order they were added.
    ///
    /// Two dwells of 2 ms end in the same tick: the lane of priority 2, added last, runs
    /// first.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, RunningState::*, Seq,
    ///             SeqConfig, Sequence, Sequencer, Transition, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let ms = |n| Wait::new(Duration::from_millis(n));
    /// let (wl, wh) = (seq.add(SeqConfig::new("wl"), ms(2)), seq.add(SeqConfig::new("wh"), ms(2)));
    /// let low = seq.add(SeqConfig::new("low"), Dwell(wl.unwrap())).unwrap();
    /// let high = seq.add(SeqConfig::new("high"), Dwell(wh.unwrap())).unwrap();
    /// let [wl, wh, l, h] = [0, 1, 2, 3].map(rtseq::SeqId::from_index);
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane_with_priority(low, 1);
    /// sim.lane_with_priority(high, 2);
    /// sim.start(l).unwrap();
    /// sim.start(h).unwrap();
    /// sim.take_trace();
    /// sim.run_for(Duration::from_millis(2));
    /// assert_eq!(sim.trace(), &[
    ///     Transition::at_millis(2, wh, Running, Terminated, Cause::Completed),
    ///     Transition::at_millis(2, h, Running, Terminated, Cause::Completed),
    ///     Transition::at_millis(2, wl, Running, Terminated, Cause::Completed),
    ///     Transition::at_millis(2, l, Running, Terminated, Cause::Completed),
    /// ]);
    /// ```
    pub fn lane_with_priority<S: Sequence<C> + 'a>(&mut self, seq: Seq<S>, priority: u8)
    where
        C: 'a,
    {
        let sequencer = self.sequencer;
        let control = self.control;
        self.task_with_priority(
            async move {
                let mut seq = seq;
                lane(sequencer, control, &mut seq).await
            },
            priority,
        );
    }

    /// Adds an RTIC async task of `priority` that never returns: for example several lanes
    /// joined in one task with [`lanes!`](crate::lanes). It is polled like a lane: when its
    /// waker was woken, in the order of priorities.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, RunningState, SeqConfig, Sequence,
    ///             Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut a = seq.add(SeqConfig::new("a"), Blink).unwrap();
    /// let mut b = seq.add(SeqConfig::new("b"), Blink).unwrap();
    /// let (ia, ib) = (a.id(), b.id());
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// let s = &seq;
    /// sim.task_with_priority(
    ///     async move {
    ///         let (a, b) = (&mut a, &mut b);
    ///         rtseq::lanes!(s, &(), a, b).await
    ///     },
    ///     1,
    /// );
    /// sim.start(ib).unwrap();
    /// assert_eq!(sim.state(ib), RunningState::Terminated);
    /// assert_eq!(sim.state(ia), RunningState::Idle);
    /// ```
    pub fn task_with_priority(
        &mut self,
        future: impl Future<Output = Infallible> + 'a,
        priority: u8,
    ) {
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        let waker = Waker::from(flag.clone());
        self.lanes.push(SimLane {
            future: Box::pin(future),
            flag,
            waker,
            polls: 0,
            priority,
        });
        self.settle();
    }

    /// The priority of each lane, in the order the lanes were added.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let (a, b) = (seq.add(SeqConfig::new("a"), Blink), seq.add(SeqConfig::new("b"), Blink));
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane_with_priority(a.unwrap(), 2);
    /// sim.lane(b.unwrap());
    /// assert_eq!(sim.lane_priorities(), [2, 1]);
    /// ```
    pub fn lane_priorities(&self) -> Vec<u8> {
        self.lanes.iter().map(|l| l.priority).collect()
    }

    /// A handle to a registered sequence.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Monitors, SeqConfig, SeqId, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("main")).unwrap();
    /// let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// assert_eq!(sim.handle(id).unwrap().name(), "main");
    /// assert!(sim.handle(SeqId::from_index(1)).is_none()); // not registered
    /// ```
    pub fn handle(&self, id: SeqId) -> Option<Handle<'a, C>> {
        self.sequencer.sequence_by_id(id)
    }

    /// Starts `id` non-blocking as a main sequence and lets the lanes run at the current time.
    ///
    /// The first start validates the configuration ([`Sequencer::validate`]), and so does a
    /// start after sequences or lanes were added since (a start through a
    /// [`Handle`] does not): an exception
    /// sequence without a lane, for example, is an `Err(Error::InvalidConfig)` here, and
    /// `seq.validate(sim.monitors())` ([`Sequencer::validate`]) names the monitor and the
    /// reason. It also checks that every declared lane ([`SeqConfig::in_lane`](crate::SeqConfig::in_lane),
    /// [`Handle::declare_lane`](crate::Handle::declare_lane)) was given to the simulator
    /// ([`lane`](Self::lane), or a task that runs it): a sequence whose lane nothing runs
    /// is an `Err(Error::NoLane(id))` here; on the chip its starts would wait for good.
    /// And that no other simulator's monitor table, still alive, is the sequencer's
    /// (`Err(Error::ForeignMonitorTable)`): this one's ticks would evaluate nothing. A
    /// simulator's table goes with it, so simulators of one sequencer can take turns; the
    /// lanes go with it too (a lane given by value is closed when its simulator drops it,
    /// and a run still under way in it is aborted, `Dropped`: records left in the
    /// sequencer, which `Sequencer::drain_records` reads, or else the next simulator's
    /// first step, at the head of its trace), so a later simulator is given
    /// every declared lane again: keep the `Seq`s and give
    /// [`task_with_priority`](Self::task_with_priority) an [`rtseq::lane`](crate::lane()) of
    /// each.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Error, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let w = wait.id();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.state(w), RunningState::Running); // the lane already ran up to the step
    /// assert_eq!(sim.start(id), Err(Error::AlreadyRunning(id)));
    /// ```
    pub fn start(&mut self, id: SeqId) -> Result<(), Error> {
        let counts = (
            self.sequencer.len(),
            self.monitors.len(),
            self.sequencer.with(|s| s.lanes_declared),
        );
        if self.validated != Some(counts) {
            self.sequencer
                .validate(&self.monitors)
                .map_err(|_| Error::InvalidConfig)?;
            // Every lane added has run up to its first wait (`task_with_priority` settles):
            // a declared lane without one would take no start, silently.
            self.sequencer.check_lanes()?;
            // Another simulator's table, alive, is the sequencer's: this one's due ticks
            // would evaluate nothing.
            if self.sequencer.is_foreign_table(&self.monitors) {
                return Err(Error::ForeignMonitorTable);
            }
            self.validated = Some(counts);
        }
        self.sequencer
            .sequence_by_id(id)
            .ok_or(Error::UnknownSequence(id))?
            .start()?;
        self.settle();
        Ok(())
    }

    /// Requests a pause of `id` (applied by the next tick).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.pause(id).unwrap();
    /// sim.run_for(Duration::from_millis(20));
    /// assert_eq!(sim.state(id), RunningState::Paused); // held: the dwell cannot end
    /// ```
    pub fn pause(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.pause()
    }

    /// Requests a resume of `id` (applied by the next tick).
    ///
    /// A pause holds the dwell (a [`Wait`](crate::Wait) counts only unpaused time): paused by
    /// the tick at 1 ms and resumed by the one at 21 ms, a 5 ms dwell ends at 25 ms.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.pause(id).unwrap();
    /// sim.run_for(Duration::from_millis(20));
    /// sim.resume(id).unwrap();
    /// let done = sim.run_until_idle(Duration::from_millis(20)).unwrap();
    /// assert_eq!(done.duration_since_epoch(), Duration::from_millis(25));
    /// assert_eq!(sim.state(id), RunningState::Terminated);
    /// ```
    pub fn resume(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.resume()
    }

    /// Requests an abort of `id` (applied by the next tick).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, Outcome, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.run_for(Duration::from_millis(2));
    /// sim.abort(id).unwrap();
    /// let idle = sim.run_until_idle(Duration::from_millis(10));
    /// assert_eq!(idle.map(|t| t.as_ticks()), Some(3_000));
    /// assert_eq!(sim.handle(id).unwrap().last_outcome(), Some(Outcome::Aborted(Cause::Abort)));
    /// ```
    pub fn abort(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.abort()
    }

    /// Requests abort-all (applied by the next tick).
    ///
    /// Two main sequences, each in its lane:
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cause, Cx, Duration, Failure, Monitors, Outcome, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let ms = |n| Wait::new(Duration::from_millis(n));
    /// let (wa, wb) = (seq.add(SeqConfig::new("wa"), ms(5)), seq.add(SeqConfig::new("wb"), ms(8)));
    /// let a = seq.add(SeqConfig::new("a"), Dwell(wa.unwrap())).unwrap();
    /// let b = seq.add(SeqConfig::new("b"), Dwell(wb.unwrap())).unwrap();
    /// let ids = [a.id(), b.id()];
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(a);
    /// sim.lane(b);
    /// for id in ids {
    ///     sim.start(id).unwrap();
    /// }
    /// sim.abort_all();
    /// sim.step();
    /// assert!(!sim.any_active());
    /// for id in ids {
    ///     let outcome = sim.handle(id).unwrap().last_outcome();
    ///     assert_eq!(outcome, Some(Outcome::Aborted(Cause::AbortAll)));
    /// }
    /// ```
    pub fn abort_all(&mut self) {
        self.sequencer.abort_all();
    }

    /// One tick: advance time, run the before-tick hook, tick, let the woken lanes run.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, RunningState, Seq, SeqConfig,
    ///             Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(2))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// sim.step(); // 1 ms
    /// assert_eq!(sim.state(id), RunningState::Running);
    /// sim.step(); // 2 ms: the dwell has passed
    /// assert_eq!(sim.state(id), RunningState::Terminated);
    /// assert_eq!(sim.now().as_ticks(), 2_000);
    /// ```
    pub fn step(&mut self) {
        self.now = self.later(self.now, self.period);
        for f in &mut self.before_tick {
            f(self.now, self.control);
        }
        if let Err(e) = self
            .sequencer
            .tick(self.now, self.control, &mut *self.monitors)
        {
            self.tick_error.get_or_insert(e);
        }
        self.settle();
    }

    /// Runs ticks for `d` of simulated time.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Duration, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.run_for(Duration::from_millis(5));
    /// sim.run_for(Duration::from_millis(5));
    /// assert_eq!(sim.now().duration_since_epoch(), Duration::from_millis(10));
    /// ```
    pub fn run_for(&mut self, d: Duration) {
        let end = self.later(self.now, d);
        self.run_until(end);
    }

    /// Runs ticks until the time reaches `t`.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Duration, Instant, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
    ///     .with_period(Duration::from_millis(2))?;
    /// sim.run_until(Instant::from_ticks(7_000));
    /// assert_eq!(sim.now().as_ticks(), 6_000); // no tick falls between 6 and 7 ms
    /// sim.run_until(Instant::from_ticks(8_000));
    /// assert_eq!(sim.now().as_ticks(), 8_000);
    /// # Ok::<(), rtseq::sim::SimError>(())
    /// ```
    pub fn run_until(&mut self, t: Instant) {
        while self.later(self.now, self.period) <= t && self.now < t {
            self.step();
        }
    }

    /// Runs ticks until no sequence is active any more or `limit` has passed; returns the
    /// time at which everything was idle.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(30))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.run_until_idle(Duration::from_millis(10)), None); // still running at 10 ms
    /// let idle = sim.run_until_idle(Duration::from_millis(100));
    /// assert_eq!(idle.map(|t| t.as_ticks()), Some(30_000));
    /// ```
    pub fn run_until_idle(&mut self, limit: Duration) -> Option<Instant> {
        let end = self.later(self.now, limit);
        loop {
            if !self.any_active() {
                return Some(self.now);
            }
            if self.later(self.now, self.period) > end || self.now >= end {
                return None;
            }
            self.step();
        }
    }

    /// True while any registered sequence is running, paused, aborting or restarting.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// assert!(!sim.any_active());
    /// sim.start(id).unwrap();
    /// assert!(sim.any_active());
    /// sim.run_for(Duration::from_millis(3));
    /// assert!(!sim.any_active());
    /// ```
    pub fn any_active(&self) -> bool {
        (0..self.sequencer.len())
            .filter_map(|i| u8::try_from(i).ok())
            .filter_map(|i| self.sequencer.sequence_by_id(SeqId(i)))
            .any(|h| h.state().is_active())
    }

    /// The state of `id`.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, RunningState, SeqConfig, SeqId, Sequence,
    ///             Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(blink);
    /// assert_eq!(sim.state(id), RunningState::Idle);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.state(id), RunningState::Terminated);
    /// assert_eq!(sim.state(SeqId::from_index(1)), RunningState::Idle); // unknown id
    /// ```
    pub fn state(&self, id: SeqId) -> RunningState {
        self.handle(id).map_or(RunningState::Idle, |h| h.state())
    }

    /// Simulated time now.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Duration, Instant, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.run_for(Duration::from_millis(3));
    /// assert_eq!(sim.now(), Instant::from_ticks(3_000));
    /// assert_eq!(seq.now(), sim.now()); // the sequencer's time is the last tick's
    /// ```
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Every transition so far, in order. The simulator reads them by draining its
    /// sequencer's records: records drained by anyone else (`Sequencer::drain_records` in
    /// a condition or a lane) are not in it.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cause, Cx, Failure, Monitors, RunningState::*, SeqConfig, Sequence,
    ///             Sequencer, Transition};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(blink);
    /// sim.run_for(rtseq::Duration::from_millis(2));
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.trace(), &[
    ///     Transition::at_millis(2, id, Idle, Running, Cause::Start),
    ///     Transition::at_millis(2, id, Running, Terminated, Cause::Completed),
    /// ]);
    /// ```
    pub fn trace(&self) -> &[Transition] {
        &self.trace
    }

    /// Takes the transitions recorded so far, leaving the trace (and the
    /// [records](Self::records)) empty.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cause, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// let first = sim.take_trace();
    /// let causes: Vec<Cause> = first.iter().map(|t| t.cause).collect();
    /// assert_eq!(causes, [Cause::Start, Cause::Completed]);
    /// assert!(sim.trace().is_empty());
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.trace().len(), 2); // the second run only
    /// ```
    pub fn take_trace(&mut self) -> Vec<Transition> {
        self.records.clear();
        core::mem::take(&mut self.trace)
    }

    /// Every record so far, transitions and [`Event`](crate::Event)s, in the order the
    /// sequencer made them (see [`Sequencer::drain_records`]). Each event comes with the time
    /// of the tick it happened in.
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Event, Failure, Monitors, SeqConfig,
    ///             Sequence, Sequencer};
    /// struct Jam;
    /// impl Sequence<()> for Jam {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         Err(Failure::App(7))
    ///     }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let jam = seq.add(SeqConfig::new("jam"), Jam).unwrap();
    /// let id = jam.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(jam);
    /// sim.start(id).unwrap();
    /// let failed = sim.records().iter().find_map(|r| r.event());
    /// assert_eq!(failed, Some(Event::Failed { sequence: id, failure: Failure::App(7) }));
    /// ```
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Records (transitions and events) lost to overflow of the sequencer's trace buffer.
    /// The simulator drains the buffer after every lane poll, so a record is lost only
    /// when more than `T` (64 by default) are made in between: in one poll of a lane
    /// whose action runs many steps that end at once (each step's run makes two
    /// transitions), or in a tick that tears down a large tree and the poll after it. Choose `T` for the busiest poll when
    /// the trace matters; [`save_trace`](Self::save_trace) writes the count, and
    /// `rtseq-trace` shows a trace with losses as incomplete.
    ///
    /// A trace buffer of one record (`T` = 1), while a start records two transitions before the
    /// simulator drains it:
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4, 1> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// assert_eq!(sim.lost(), 1);
    /// assert_eq!(sim.trace().len(), 1);
    /// ```
    pub fn lost(&self) -> u32 {
        self.lost
    }

    /// The first error a tick of the simulator returned: [`Error::TickBeforeLast`] when
    /// the sequencer was ticked by hand past the simulator's time, or
    /// [`Error::ForeignMonitorTable`] when it was ticked by hand with a table of monitors
    /// first (those ticks evaluated nothing).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Error, Instant, Monitors, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// let mut none = Monitors::<(), 1>::new();
    /// seq.tick(Instant::from_ticks(5_000), &(), &mut none).unwrap();
    /// sim.run_until(Instant::from_ticks(3_000));
    /// assert_eq!(sim.tick_error(), Some(Error::TickBeforeLast));
    /// ```
    pub fn tick_error(&self) -> Option<Error> {
        self.tick_error
    }

    /// True if a settle hit its poll bound (a lane that wakes itself forever).
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// sim.run_for(rtseq::Duration::from_millis(10));
    /// assert!(!sim.stalled()); // every settle ended with no lane woken
    /// ```
    pub fn stalled(&self) -> bool {
        self.stalled
    }

    /// How often each lane was polled, in the order the lanes were added: the tick wakes only
    /// lanes that must act, so an idle or frozen lane is not polled at all.
    ///
    /// Lane `a` is polled when added, when started, and when its dwell's exit condition is due
    /// (at 1, 2 and 3 ms), then not in the 97 ticks after; lane `b`, never started, only when
    /// added:
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<()> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// let ms = |n| Wait::new(Duration::from_millis(n));
    /// let (wa, wb) = (seq.add(SeqConfig::new("wa"), ms(3)), seq.add(SeqConfig::new("wb"), ms(3)));
    /// let a = seq.add(SeqConfig::new("a"), Dwell(wa.unwrap())).unwrap();
    /// let b = seq.add(SeqConfig::new("b"), Dwell(wb.unwrap())).unwrap();
    /// let id = a.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(a);
    /// sim.lane(b);
    /// sim.start(id).unwrap();
    /// sim.run_for(Duration::from_millis(100));
    /// assert_eq!(sim.lane_polls(), [5, 1]);
    /// ```
    pub fn lane_polls(&self) -> Vec<usize> {
        self.lanes.iter().map(|l| l.polls).collect()
    }

    /// The monitor table (e.g. to read how often a monitor fired).
    ///
    /// A monitor on `main` fires once on the rising edge of an over-temperature flag that the
    /// plant model raises at 4 ms (behaviour `Nothing`: `main` goes on):
    ///
    /// ```
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Behaviour, Cx, Duration, Failure, Instant, Monitor, Monitors, Seq,
    ///             SeqConfig, Sequence, Sequencer, Wait};
    /// struct Dwell(Seq<Wait>);
    /// impl Sequence<Cell<bool>> for Dwell {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<bool>>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<bool>, 4> = Sequencer::new();
    /// let wait = seq.add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(10))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    /// let id = main.id();
    /// let mut hot = |c: &Cell<bool>, _: Instant| c.get();
    /// let mut monitors = Monitors::<Cell<bool>, 1>::new();
    /// let m = monitors.add(id, Monitor::new("hot", &mut hot, Behaviour::Nothing)).unwrap();
    /// let flag = Cell::new(false);
    /// let mut sim = Sim::new(&seq, &flag, monitors);
    /// sim.lane(main);
    /// sim.before_tick(|t, c| c.set(t.as_ticks() >= 4_000));
    /// sim.start(id).unwrap();
    /// sim.run_until_idle(Duration::from_millis(20)).unwrap();
    /// assert_eq!(sim.monitors().fired(m), 1);
    /// assert_eq!(sim.monitors().name(m), Some("hot"));
    /// ```
    pub fn monitors(&self) -> &Monitors<'a, C, M, K> {
        &self.monitors
    }

    /// The control system.
    ///
    /// ```
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Duration, Monitors, Sequencer};
    /// let seq: Sequencer<Cell<u32>, 2> = Sequencer::new();
    /// let ticks = Cell::new(0);
    /// let mut sim = Sim::new(&seq, &ticks, Monitors::<Cell<u32>, 1>::new());
    /// sim.before_tick(|_, n| n.set(n.get() + 1));
    /// sim.run_for(Duration::from_millis(4));
    /// assert_eq!(sim.control().get(), 4);
    /// ```
    pub fn control(&self) -> &'a C {
        self.control
    }

    /// `t + d`, saturating at the end of time.
    fn later(&self, t: Instant, d: Duration) -> Instant {
        t.checked_add_duration(d)
            .unwrap_or(Instant::from_ticks(u64::MAX))
    }

    /// Moves the sequencer's buffered records into the trace.
    fn drain(&mut self) {
        let (trace, records) = (&mut self.trace, &mut self.records);
        let lost = self.sequencer.drain_records(|r| {
            if let Some(t) = r.transition() {
                trace.push(t);
            }
            records.push(r);
        });
        self.lost = self.lost.saturating_add(lost);
    }

    /// Polls woken lanes in RTIC's order until none is woken (see
    /// [the order of the lanes](self#the-order-of-the-lanes)): the dispatcher of the
    /// highest woken priority makes a pass, again and again.
    fn settle(&mut self) {
        let mut polls: usize = 0;
        while let Some(level) = self.highest_woken(None) {
            let bounded = self.pass(level, &mut polls);
            self.drain();
            if !bounded || polls > MAX_POLLS_PER_SETTLE {
                self.stalled = true;
                return;
            }
        }
        self.drain();
    }

    /// The highest priority of a woken lane (above `above`, if given).
    fn highest_woken(&self, above: Option<u8>) -> Option<u8> {
        self.lanes
            .iter()
            .filter(|l| above.is_none_or(|a| l.priority > a))
            .filter(|l| l.flag.0.load(Ordering::SeqCst))
            .map(|l| l.priority)
            .max()
    }

    /// One pass of the dispatcher of `level`: every lane of the level that is woken when the
    /// pass reaches it, once, in the order they were added (or shuffled); after each poll,
    /// the lanes of higher priorities it woke run first (they preempt). False if the poll
    /// bound was hit.
    fn pass(&mut self, level: u8, polls: &mut usize) -> bool {
        // In the order the lanes were added, unless shuffled (only then is the order kept
        // in a list of its own).
        let lanes = &self.lanes;
        let shuffled = self.shuffle.as_mut().map(|shuffle| {
            let mut order: Vec<usize> = (0..lanes.len())
                .filter(|&i| lanes.get(i).is_some_and(|l| l.priority == level))
                .collect();
            shuffle.shuffle(&mut order);
            order
        });
        for k in 0..self.lanes.len() {
            let i = shuffled
                .as_ref()
                .map_or(Some(k), |order| order.get(k).copied());
            let Some(lane) = i.and_then(|i| self.lanes.get_mut(i)) else {
                continue;
            };
            if lane.priority != level || !lane.flag.0.swap(false, Ordering::SeqCst) {
                continue;
            }
            *polls = polls.saturating_add(1);
            lane.polls = lane.polls.saturating_add(1);
            let mut cx = Context::from_waker(&lane.waker);
            let _ = lane.future.as_mut().poll(&mut cx);
            self.drain();
            while let Some(higher) = self.highest_woken(Some(level)) {
                if !self.pass(higher, polls) || *polls > MAX_POLLS_PER_SETTLE {
                    return false;
                }
            }
        }
        true
    }
}

/// The simulator's monitor table goes with it: a later simulator of the same sequencer
/// brings its own.
impl<
        'a,
        C,
        const N: usize,
        const T: usize,
        const M: usize,
        K,
        const W: usize,
        const B: usize,
        L,
    > Drop for Sim<'a, C, N, T, M, K, W, B, L>
where
    L: Lock,
{
    fn drop(&mut self) {
        self.sequencer.release_table(&self.monitors);
    }
}

/// Saving the trace in the `rtseq-trace` tool's format (JSON lines, `docs/trace-format.md`).
impl<
        'a,
        C,
        const N: usize,
        const T: usize,
        const M: usize,
        K: crate::Condition<C>,
        const W: usize,
        const B: usize,
        L: Lock,
    > Sim<'a, C, N, T, M, K, W, B, L>
{
    /// Writes the trace to `path` in the format of the `rtseq-trace` tool
    /// (`docs/trace-format.md`): a header with the sequences (id, name, caller of the last
    /// run) and the monitors (id, name, owner), then one line per transition. A failing
    /// test can leave a run to look at: `rtseq-trace render run.jsonl --html run.html`.
    ///
    /// ```
    /// use rtseq::sim::Sim;
    /// use rtseq::{Cx, Duration, Failure, Monitors, SeqConfig, Sequence, Sequencer, Wait};
    /// struct Main { dwell: rtseq::Seq<Wait> }
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.dwell).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(3))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main { dwell }).unwrap();
    /// let m = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(m).unwrap();
    /// sim.run_for(Duration::from_millis(5));
    /// let path = std::env::temp_dir().join("rtseq-doc-trace.jsonl");
    /// sim.save_trace(&path).unwrap();
    /// let text = std::fs::read_to_string(&path).unwrap();
    /// assert!(text.starts_with(r#"{"format":"rtseq-trace","version":1,"#));
    /// // dwell (id 0) was started by main (id 1); main is a main sequence.
    /// assert!(text.contains(r#"{"id":0,"name":"dwell","caller":1}"#));
    /// assert!(text.contains(r#"{"t":3000,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}"#));
    /// ```
    pub fn save_trace(&self, path: impl AsRef<std::path::Path>) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        let mut out = std::io::BufWriter::new(file);
        self.write_trace(&mut out)?;
        std::io::Write::flush(&mut out)
    }

    /// Writes the trace in the format of [`save_trace`](Self::save_trace) to `out`.
    ///
    /// The trace of one run, in memory:
    ///
    /// ```
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, SeqConfig, Sequence, Sequencer};
    /// struct Blink;
    /// impl Sequence<()> for Blink {
    ///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let blink = seq.add(SeqConfig::new("blink"), Blink).unwrap();
    /// let id = blink.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(blink);
    /// sim.start(id).unwrap();
    /// let mut out = Vec::new();
    /// sim.write_trace(&mut out).unwrap();
    /// let text = String::from_utf8(out).unwrap();
    /// let lines: Vec<&str> = text.lines().collect();
    /// assert_eq!(lines, [
    ///     concat!(r#"{"format":"rtseq-trace","version":1,"time_unit":"us","end":0,"lost":0,"#,
    ///             r#""sequences":[{"id":0,"name":"blink","caller":null}],"monitors":[]}"#),
    ///     r#"{"t":0,"seq":0,"from":"Idle","to":"Running","cause":"start"}"#,
    ///     r#"{"t":0,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}"#,
    /// ]);
    /// ```
    pub fn write_trace(&self, out: &mut impl std::io::Write) -> std::io::Result<()> {
        use crate::{Cause, MonitorId};
        use std::string::String;
        let opt = |id: Option<usize>| id.map_or(String::from("null"), |i| std::format!("{i}"));
        let mut head = std::format!(
            "{{\"format\":\"rtseq-trace\",\"version\":1,\"time_unit\":\"us\",\"end\":{},\"lost\":{},\"sequences\":[",
            self.now.as_ticks(),
            self.lost
        );
        for i in 0..self.sequencer.len() {
            let id = SeqId::from_index(i);
            let (name, caller) = self
                .handle(id)
                .map_or(("", None), |h| (h.name(), h.caller().map(SeqId::index)));
            let sep = if i == 0 { "" } else { "," };
            head.push_str(&std::format!(
                "{sep}{{\"id\":{i},\"name\":{},\"caller\":{}}}",
                quoted(name),
                opt(caller)
            ));
        }
        head.push_str("],\"monitors\":[");
        for i in 0..self.monitors.len() {
            let m = MonitorId::from_index(i);
            let name = self.monitors.name(m).unwrap_or("");
            let owner = self.monitors.owner(m).map(SeqId::index);
            let sep = if i == 0 { "" } else { "," };
            head.push_str(&std::format!(
                "{sep}{{\"id\":{i},\"name\":{},\"owner\":{}}}",
                quoted(name),
                opt(owner)
            ));
        }
        head.push_str("]}");
        std::writeln!(out, "{head}")?;
        for r in &self.records {
            let t = match (r.transition(), r.event()) {
                (Some(t), _) => t,
                (None, Some(event)) => {
                    self.write_event(out, r.time, &event)?;
                    continue;
                }
                (None, None) => continue,
            };
            let cause = match t.cause {
                Cause::Start => String::from("\"start\""),
                Cause::PreConditionFalse => String::from("\"pre_condition_false\""),
                Cause::Completed => String::from("\"completed\""),
                Cause::Pause => String::from("\"pause\""),
                Cause::Resume => String::from("\"resume\""),
                Cause::Abort => String::from("\"abort\""),
                Cause::AbortAll => String::from("\"abort_all\""),
                Cause::Monitor(m) => std::format!("\"monitor\",\"monitor\":{}", m.index()),
                Cause::Timeout(s) => std::format!("\"timeout\",\"of\":{}", s.index()),
                Cause::Restart => String::from("\"restart\""),
                Cause::Dropped => String::from("\"dropped\""),
                Cause::Failed => String::from("\"failed\""),
            };
            std::writeln!(
                out,
                "{{\"t\":{},\"seq\":{},\"from\":\"{:?}\",\"to\":\"{:?}\",\"cause\":{cause}}}",
                t.time.as_ticks(),
                t.sequence.index(),
                t.from,
                t.to
            )?;
        }
        Ok(())
    }

    /// One event as a record of the trace format.
    fn write_event(
        &self,
        out: &mut impl std::io::Write,
        time: Instant,
        event: &crate::Event,
    ) -> std::io::Result<()> {
        use crate::{Cause, Event, Requester};
        use std::format;
        use std::string::String;
        let name = |id: SeqId| self.handle(id).map_or("", |h| h.name());
        let by = |r: Requester| match r {
            Requester::Sequence(id) => format!("\"by\":\"sequence\",\"by_seq\":{}", id.index()),
            Requester::Application => String::from("\"by\":\"application\""),
            Requester::SafetySystem => String::from("\"by\":\"safety_system\""),
        };
        let fields = match *event {
            Event::Fired {
                owner,
                cause,
                behaviour,
            } => {
                let what = match cause {
                    Cause::Monitor(m) => format!(
                        "\"monitor\":{},\"text\":{}",
                        m.index(),
                        quoted(&format!(
                            "monitor '{}' of '{}' fired: {behaviour:?}",
                            self.monitors.name(m).unwrap_or(""),
                            name(owner)
                        ))
                    ),
                    _ => format!(
                        "\"name\":{},\"text\":{}",
                        quoted(&format!("timeout of {}", name(owner))),
                        quoted(&format!("timeout of '{}' ran out: {behaviour:?}", name(owner)))
                    ),
                };
                format!(
                    "\"event\":\"monitor\",\"owner\":{},\"behaviour\":\"{behaviour:?}\",{what}",
                    owner.index()
                )
            }
            Event::ExceptionNotRun {
                exception,
                owner,
                why,
            } => format!(
                "\"event\":\"exception_not_run\",\"sequence\":{},\"owner\":{},\"name\":{},\"text\":{}",
                exception.index(),
                owner.index(),
                quoted(name(exception)),
                quoted(&format!(
                    "exception sequence '{}' of '{}' not run: {why}",
                    name(exception),
                    name(owner)
                ))
            ),
            Event::Requested {
                sequence,
                request,
                by: who,
            } => format!(
                "\"event\":\"request\",\"sequence\":{},\"request\":\"{}\",{},\"name\":{},\"text\":{}",
                sequence.index(),
                format!("{request:?}").to_lowercase(),
                by(who),
                quoted(&format!("{request:?} {}", name(sequence)).to_lowercase()),
                quoted(&format!("{request:?} of '{}' requested by {who:?}", name(sequence)))
            ),
            Event::AbortAll { by: who } => format!(
                "\"event\":\"request\",\"request\":\"abort_all\",{},\"name\":\"abort all\",\"text\":{}",
                by(who),
                quoted(&format!("abort all, requested by {who:?}"))
            ),
            Event::Failed { sequence, failure } => format!(
                "\"event\":\"failed\",\"sequence\":{},\"name\":{},\"text\":{}",
                sequence.index(),
                quoted(name(sequence)),
                quoted(&format!("'{}' failed: {failure:?}", name(sequence)))
            ),
            Event::SafetyLevel { level } => {
                let id = level.id();
                let level_name = SafetyNames::find(&self.safety_names.levels, id)
                    .map_or_else(|| format!("level {id}"), String::from);
                format!("\"level\":{},\"id\":{id}", quoted(&level_name))
            }
            Event::InputTripped { input } => {
                let id = input.index();
                let input_name = u8::try_from(id)
                    .ok()
                    .and_then(|i| SafetyNames::find(&self.safety_names.inputs, i))
                    .map_or_else(|| format!("input {id}"), String::from);
                format!(
                    "\"event\":\"input\",\"input\":{id},\"name\":{},\"text\":{}",
                    quoted(&input_name),
                    quoted(&format!("critical input '{input_name}' tripped"))
                )
            }
        };
        std::writeln!(out, "{{\"t\":{},{fields}}}", time.as_ticks())
    }
}

/// `s` as a JSON string.
fn quoted(s: &str) -> std::string::String {
    let mut q = std::string::String::from("\"");
    for c in s.chars() {
        match c {
            '"' => q.push_str("\\\""),
            '\\' => q.push_str("\\\\"),
            c if u32::from(c) < 0x20 => q.push_str(&std::format!("\\u{:04x}", u32::from(c))),
            c => q.push(c),
        }
    }
    q.push('"');
    q
}
