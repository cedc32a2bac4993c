//! The simulator polls lanes in RTIC 2's order: the highest woken priority first, a lane of
//! higher priority woken by a poll before the pass of the lower level goes on (preemption),
//! lanes of equal priority in a fixed order per pass, or shuffled per seed
//! (`Sim::shuffle_equal_priorities`). And the simulator's limits: a tick period of 0, or of
//! 2^31 µs or more, is an error, not a hang or late timeouts; `run_until_idle` never runs
//! past its limit; a full trace buffer counts what it lost; a lane that wakes itself forever
//! stops at the poll bound; simulators of one sequencer take turns, a second one alive is
//! refused.

use rtseq::sim::{Sim, SimError, DEFAULT_LANE_PRIORITY};
use rtseq::Cause::{Completed, Start};
use rtseq::RunningState::{Idle, Running, Terminated};
use rtseq::{
    Cx, Duration, Failure, Instant, Monitors, Seq, SeqConfig, SeqId, Sequence, Sequencer,
    Transition, Wait,
};

/// Waits for its dwell.
struct Dwell(Seq<Wait>);

impl Sequence<()> for Dwell {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

/// Waits for its dwell, then starts `then` non-blocking (it runs in its own lane).
struct DwellThenStart {
    wait: Seq<Wait>,
    then: SeqId,
}

impl Sequence<()> for DwellThenStart {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.wait).await;
        let _ = cx.start(self.then);
        Ok(())
    }
}

/// Ends at once.
struct Blink;

impl Sequence<()> for Blink {
    async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        Ok(())
    }
}

const WA: SeqId = SeqId::from_index(0);
const WB: SeqId = SeqId::from_index(1);
const H: SeqId = SeqId::from_index(2);
const A: SeqId = SeqId::from_index(3);
const B: SeqId = SeqId::from_index(4);

fn done(id: SeqId) -> Transition {
    Transition::at_millis(2, id, Running, Terminated, Completed)
}

/// `a` (lane 1) and `b` (lane 2) each wait 2 ms; when its dwell ends, `a` starts `h` in
/// lane 3. The lanes get the priorities `prio`; returns the transitions at 2 ms.
fn preemption_run(prio: [Option<u8>; 3], seed: Option<u64>) -> Vec<Transition> {
    let seq: Sequencer<(), 8> = Sequencer::new();
    let two = || Wait::new(Duration::from_millis(2));
    let wa = seq.add(SeqConfig::new("wa"), two()).unwrap();
    let wb = seq.add(SeqConfig::new("wb"), two()).unwrap();
    let h = seq.add(SeqConfig::new("h"), Blink).unwrap();
    let a = seq
        .add(SeqConfig::new("a"), DwellThenStart { wait: wa, then: H })
        .unwrap();
    let b = seq.add(SeqConfig::new("b"), Dwell(wb)).unwrap();
    assert_eq!([a.id(), b.id(), h.id()], [A, B, H]);
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    if let Some(seed) = seed {
        sim = sim.shuffle_equal_priorities(seed);
    }
    let [pa, pb, ph] = prio;
    match pa {
        Some(p) => sim.lane_with_priority(a, p),
        None => sim.lane(a),
    }
    match pb {
        Some(p) => sim.lane_with_priority(b, p),
        None => sim.lane(b),
    }
    match ph {
        Some(p) => sim.lane_with_priority(h, p),
        None => sim.lane(h),
    }
    sim.start(A).unwrap();
    sim.start(B).unwrap();
    sim.run_for(Duration::from_millis(1));
    let before = sim.take_trace();
    assert_eq!(before.len(), 4, "{before:?}"); // a, wa, b, wb started at 0 ms
    sim.run_for(Duration::from_millis(1));
    assert!(!sim.stalled());
    sim.take_trace()
}

/// `a` then `h` (which `a` started) then `b`: `h` preempts the pass of priority 1.
fn a_h_b() -> Vec<Transition> {
    vec![
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(H),
        done(WB),
        done(B),
    ]
}

#[test]
fn a_lane_of_higher_priority_woken_by_a_poll_runs_before_the_pass_goes_on() {
    // RTIC: `h` (priority 2) preempts the dispatcher of priority 1 as soon as `a` wakes it.
    assert_eq!(preemption_run([Some(1), Some(1), Some(2)], None), a_h_b());
}

#[test]
fn lanes_of_equal_priority_keep_the_order_they_were_added_in() {
    // All at the default priority (the simulator before priorities, and `Sim::lane`): one
    // pass of priority 1 polls a, b, then h, woken by a during the pass and later in the
    // order, in the same pass.
    let all_equal = vec![
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(WB),
        done(B),
        done(H),
    ];
    assert_eq!(preemption_run([None, None, None], None), all_equal);
    let explicit = Some(DEFAULT_LANE_PRIORITY);
    assert_eq!(
        preemption_run([explicit, explicit, explicit], None),
        all_equal
    );
}

#[test]
fn the_highest_woken_priority_runs_first_whatever_the_order_of_adding() {
    // b at priority 3: the tick wakes a and b, b's dispatcher runs first; then a (1), which
    // wakes h (2): h preempts nothing left at level 1 and runs right after a.
    let b_first = vec![
        done(WB),
        done(B),
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(H),
    ];
    assert_eq!(preemption_run([Some(1), Some(3), Some(2)], None), b_first);
    // h below a: a and b (2) first, then h (1).
    let h_last = vec![
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(WB),
        done(B),
        done(H),
    ];
    assert_eq!(preemption_run([Some(2), Some(2), Some(1)], None), h_last);
}

/// `b` then `a` then `h`.
fn b_a_h() -> Vec<Transition> {
    vec![
        done(WB),
        done(B),
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(H),
    ]
}

#[test]
fn shuffled_lanes_of_equal_priority_take_both_orders_and_preemption_stays() {
    // Seeds 1 and 3 give the two orders of a and b (h, priority 2, always preempts right
    // after a woke it).
    assert_eq!(
        preemption_run([Some(1), Some(1), Some(2)], Some(1)),
        a_h_b()
    );
    assert_eq!(
        preemption_run([Some(1), Some(1), Some(2)], Some(3)),
        b_a_h()
    );
    // The same seed gives the same run; every seed gives one of the two orders.
    let mut seen = [0; 2];
    for seed in 0..32 {
        let run = preemption_run([Some(1), Some(1), Some(2)], Some(seed));
        assert_eq!(
            run,
            preemption_run([Some(1), Some(1), Some(2)], Some(seed)),
            "seed {seed}"
        );
        if run == a_h_b() {
            seen[0] += 1;
        } else {
            assert_eq!(run, b_a_h(), "seed {seed}");
            seen[1] += 1;
        }
    }
    assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
}

#[test]
fn shuffling_does_not_reorder_different_priorities() {
    // a (3) and b (2) are never shuffled against each other: a, then h (1) only after b.
    let want = vec![
        done(WA),
        Transition::at_millis(2, H, Idle, Running, Start),
        done(A),
        done(WB),
        done(B),
        done(H),
    ];
    for seed in 0..16 {
        assert_eq!(
            preemption_run([Some(3), Some(2), Some(1)], Some(seed)),
            want,
            "seed {seed}"
        );
    }
}

#[test]
fn a_tick_period_of_zero_is_an_error() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new()).with_period(Duration::from_ticks(0));
    assert_eq!(sim.err(), Some(SimError::ZeroPeriod));
    assert_eq!(
        SimError::ZeroPeriod.to_string(),
        "the tick period must be longer than 0"
    );
    // The shortest period, 1 µs, works and ends.
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
        .with_period(Duration::from_ticks(1))
        .unwrap();
    sim.run_for(Duration::from_ticks(3));
    assert_eq!(sim.now(), Instant::from_ticks(3));
}

/// A task of the application's own that wakes itself by value (a consumed clone of its
/// waker, as a hand-written yield does) is polled again in the same settle.
#[test]
fn a_task_that_wakes_itself_by_value_is_polled_again() {
    use core::convert::Infallible;
    use core::future::Future;
    use core::pin::Pin;
    use core::task::{Context, Poll};
    use std::cell::Cell;

    /// Yields `left` times, each time by waking a clone of its waker, then pends for good.
    struct YieldByValue<'a> {
        left: u32,
        polls: &'a Cell<u32>,
    }
    impl Future for YieldByValue<'_> {
        type Output = Infallible;
        fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Infallible> {
            self.polls.set(self.polls.get() + 1);
            if self.left > 0 {
                self.left -= 1;
                // By value on purpose: the simulator's waker must handle a consumed clone.
                #[allow(clippy::waker_clone_wake)]
                cx.waker().clone().wake();
            }
            Poll::Pending
        }
    }

    let polls = Cell::new(0);
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.task_with_priority(
        YieldByValue {
            left: 2,
            polls: &polls,
        },
        DEFAULT_LANE_PRIORITY,
    );
    assert_eq!(polls.get(), 3);
    assert_eq!(sim.lane_polls(), [3]);
    sim.step();
    assert_eq!(polls.get(), 3, "not woken again, not polled again");
    assert!(!sim.stalled());
}

/// `run_until_idle` runs whole ticks up to its limit, never past it: idle exactly at the
/// limit counts, and a limit between two ticks stops at the tick before it.
#[test]
fn run_until_idle_stops_at_its_limit_never_past_it() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(30)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    assert_eq!(sim.run_until_idle(Duration::from_micros(2_500)), None);
    assert_eq!(sim.now(), Instant::from_ticks(2_000));
    assert_eq!(sim.run_until_idle(Duration::from_millis(8)), None);
    assert_eq!(sim.now(), Instant::from_ticks(10_000));
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(Instant::from_ticks(30_000))
    );
    assert_eq!(sim.now(), Instant::from_ticks(30_000));
    // Already idle: no tick.
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(Instant::from_ticks(30_000))
    );
}

/// At the end of simulated time `run_until` ends: the clock saturates, it does not hang.
#[test]
fn run_until_the_end_of_time_ends() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let start = Instant::from_ticks(u64::MAX - 1_500);
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
        .starting_at(start)
        .unwrap();
    sim.run_until(Instant::from_ticks(u64::MAX));
    assert_eq!(sim.now(), Instant::from_ticks(u64::MAX));
}

/// Transitions that do not fit the sequencer's trace buffer between two drains are
/// counted, not silently dropped: the buffer keeps the newest.
#[test]
fn transitions_beyond_the_trace_buffer_are_counted_as_lost() {
    let seq: Sequencer<(), 4, 1> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let wait_id = wait.id();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    // main's start and the wait's, in one settle: the ring keeps the newest.
    assert_eq!(sim.lost(), 1);
    assert_eq!(
        sim.trace(),
        [Transition::at_millis(0, wait_id, Idle, Running, Start)]
    );
}

/// A tick of the sequencer made by hand past the simulator's time makes the simulator's
/// ticks fail, and the simulator says so.
#[test]
fn a_tick_by_hand_past_the_simulators_time_is_reported() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.run_for(Duration::from_millis(2));
    assert_eq!(sim.tick_error(), None);
    let mut none = Monitors::<(), 1>::new();
    seq.tick(Instant::from_ticks(5_000), &(), &mut none)
        .unwrap();
    sim.run_until(Instant::from_ticks(3_000));
    assert_eq!(sim.tick_error(), Some(rtseq::Error::TickBeforeLast));
}

/// A task that wakes itself forever.
struct Spin<'a> {
    polls: &'a std::cell::Cell<u32>,
}

impl core::future::Future for Spin<'_> {
    type Output = core::convert::Infallible;
    fn poll(
        self: core::pin::Pin<&mut Self>,
        cx: &mut core::task::Context<'_>,
    ) -> core::task::Poll<Self::Output> {
        self.polls.set(self.polls.get() + 1);
        cx.waker().wake_by_ref();
        core::task::Poll::Pending
    }
}

/// A livelock (a lane that wakes itself forever) stops at the settle's bound of 100 000
/// polls and is reported, at the lane's own priority and when it preempts another.
#[test]
fn a_lane_that_wakes_itself_forever_stops_at_the_poll_bound() {
    let polls = std::cell::Cell::new(0);
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    assert!(!sim.stalled());
    sim.task_with_priority(Spin { polls: &polls }, 1);
    assert!(sim.stalled());
    assert_eq!(polls.get(), 100_001);

    // The spinning lane preempts a lane of lower priority, which woke it.
    struct WakeOther<'a>(&'a std::cell::RefCell<Option<core::task::Waker>>);
    impl core::future::Future for WakeOther<'_> {
        type Output = core::convert::Infallible;
        fn poll(
            self: core::pin::Pin<&mut Self>,
            _: &mut core::task::Context<'_>,
        ) -> core::task::Poll<Self::Output> {
            if let Some(w) = self.0.borrow_mut().take() {
                w.wake();
            }
            core::task::Poll::Pending
        }
    }
    /// Parks its waker on the first poll; spins from the second on.
    struct SpinOnceWoken<'a> {
        waker: &'a std::cell::RefCell<Option<core::task::Waker>>,
        spin: Spin<'a>,
    }
    impl core::future::Future for SpinOnceWoken<'_> {
        type Output = core::convert::Infallible;
        fn poll(
            mut self: core::pin::Pin<&mut Self>,
            cx: &mut core::task::Context<'_>,
        ) -> core::task::Poll<Self::Output> {
            if self.spin.polls.get() == 0 {
                self.spin.polls.set(1);
                *self.waker.borrow_mut() = Some(cx.waker().clone());
                return core::task::Poll::Pending;
            }
            core::pin::Pin::new(&mut self.spin).poll(cx)
        }
    }
    let (high_polls, waker) = (std::cell::Cell::new(0), std::cell::RefCell::new(None));
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.task_with_priority(
        SpinOnceWoken {
            waker: &waker,
            spin: Spin { polls: &high_polls },
        },
        2,
    );
    assert!(!sim.stalled());
    sim.task_with_priority(WakeOther(&waker), 1);
    assert!(sim.stalled());
    // The settle's 100 001 polls: the waking lane's one and the spinning lane's 100 000,
    // after its first.
    assert_eq!(high_polls.get(), 1 + 100_000);
    assert_eq!(sim.lane_polls(), [100_001, 1]);
}

/// A sequence declared in a lane (`in_lane`) whose lane was never given to the simulator
/// would take no start: the monitor's exception sequence would stay `Running` without
/// running and hold its owner for good, with no error. The first start says so instead,
/// naming it; once its lane is added, the same start is taken.
#[test]
fn a_declared_lane_that_nothing_runs_is_an_error_at_the_first_start() {
    use rtseq::{Behaviour, Error, Monitor};
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let stop = seq
        .add(SeqConfig::new("safe stop").in_lane(), Blink)
        .unwrap();
    let (m, s) = (main.id(), stop.id());
    let mut hot = |_: &(), now: Instant| now.as_ticks() >= 2_000;
    let mut monitors = Monitors::<(), 1>::new();
    monitors
        .add(
            m,
            Monitor::new("hot", &mut hot, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    assert_eq!(sim.start(m), Err(Error::NoLane(s)));
    assert_eq!(sim.state(m), Idle);
    sim.lane(stop);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(3));
    let ran: Vec<_> = sim
        .trace()
        .iter()
        .map(|t| (t.time, t.sequence, t.to))
        .collect();
    let ms = |n: u64| Instant::from_ticks(n * 1_000);
    use rtseq::RunningState::{Aborted, Aborting};
    assert_eq!(
        ran,
        [
            (ms(0), m, Running),
            (ms(0), SeqId::from_index(0), Running),
            (ms(2), s, Running),
            (ms(2), s, Terminated),
            // The next tick applies `AbortOwner`: innermost first.
            (ms(3), SeqId::from_index(0), Aborting),
            (ms(3), SeqId::from_index(0), Aborted),
            (ms(3), m, Aborting),
            (ms(3), m, Aborted),
        ]
    );
}

/// Each `before_tick` adds a hook; they run before every tick in the order they were added
/// (a second one used to replace the first, silently).
#[test]
fn before_tick_hooks_run_in_the_order_they_were_added() {
    use core::cell::Cell;
    let seq: Sequencer<Cell<u32>, 1> = Sequencer::new();
    let plant = Cell::new(1);
    let mut sim = Sim::new(&seq, &plant, Monitors::<Cell<u32>, 1>::new());
    sim.before_tick(|_, p| p.set(p.get() + 1));
    sim.before_tick(|now, p| p.set(p.get() * 10 + u32::try_from(now.as_ticks() / 1_000).unwrap()));
    sim.run_for(Duration::from_millis(2));
    // Tick 1 ms: (1 + 1) * 10 + 1 = 21; tick 2 ms: (21 + 1) * 10 + 2 = 222.
    assert_eq!(plant.get(), 222);
}

/// A tick period the sequencer's 32-bit wrapping times cannot take (2^31 µs or more) is an
/// error, as a polling period or timeout of that length is; just below it is accepted.
#[test]
fn a_tick_period_of_2_pow_31_us_or_more_is_an_error() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let sim = || Sim::new(&seq, &(), Monitors::<(), 1>::new());
    let too_long = sim().with_period(Duration::from_ticks(1 << 31));
    assert_eq!(too_long.err(), Some(SimError::PeriodTooLong));
    assert_eq!(
        SimError::PeriodTooLong.to_string(),
        "the tick period must be shorter than 2^31 us (35.8 min)"
    );
    let longest = sim().with_period(Duration::from_ticks((1 << 31) - 1));
    assert!(longest.is_ok());
}

/// One sequencer, simulators one after another (a test helper called twice): each starts
/// at the sequencer's time, and its monitor table is the sequencer's once the one before
/// is dropped. While another simulator's table is alive, the first start says so: its due
/// ticks would evaluate nothing. Starting before the sequencer's time is an error.
#[test]
fn simulators_of_one_sequencer_take_turns_and_a_second_one_alive_is_refused() {
    use rtseq::{Behaviour, Cause, Error, Monitor, RunningState::*};
    struct Forever;
    impl Sequence<()> for Forever {
        async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
            cx.wait_until(|_| false).await;
            Ok(())
        }
    }
    let seq: Sequencer<(), 2> = Sequencer::new();
    let id = seq.register(SeqConfig::new("main").in_lane()).unwrap();
    let mut main = seq.bind(id, Forever).unwrap();
    // A simulator whose jam monitor holds from `jam_from` µs, run for 5 ms.
    let scenario = |main: &mut Seq<Forever>, jam_from: u64| {
        let mut jam = move |_: &(), now: Instant| now.as_ticks() >= jam_from;
        let mut monitors: Monitors<(), 1> = Monitors::new();
        let m = monitors
            .add(id, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
            .unwrap();
        let mut sim = Sim::new(&seq, &(), monitors);
        sim.task_with_priority(rtseq::lane(&seq, &(), main), DEFAULT_LANE_PRIORITY);
        let at = sim.now();
        sim.start(id).unwrap();
        sim.run_for(Duration::from_millis(5));
        (m, at, sim.trace().to_vec(), sim.tick_error())
    };
    let (m, at, trace, err) = scenario(&mut main, 3_000);
    assert_eq!((at, err), (Instant::from_ticks(0), None));
    assert_eq!(
        trace,
        [
            Transition::at_millis(0, id, Idle, Running, Start),
            Transition::at_millis(3, id, Running, Aborting, Cause::Monitor(m)),
            Transition::at_millis(3, id, Aborting, Aborted, Cause::Monitor(m)),
        ]
    );
    // The second simulator goes on from 5 ms, its table is the sequencer's, and its lane
    // future takes the place of the first one's. (The first one's table is gone: a box
    // taken now gets its place, not the second simulator's table.)
    let _elsewhere = Box::new(Monitors::<(), 1>::new());
    let (m, at, trace, err) = scenario(&mut main, 8_000);
    assert_eq!((at, err), (Instant::from_ticks(5_000), None));
    assert_eq!(
        trace,
        [
            Transition::at_millis(5, id, Aborted, Running, Start),
            Transition::at_millis(8, id, Running, Aborting, Cause::Monitor(m)),
            Transition::at_millis(8, id, Aborting, Aborted, Cause::Monitor(m)),
        ]
    );
    // Two simulators at once: the second one's first start is refused.
    let mut jam = |_: &(), _: Instant| false;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    monitors
        .add(id, Monitor::new("jam", &mut jam, Behaviour::AbortOwner))
        .unwrap();
    let mut first = Sim::new(&seq, &(), monitors);
    first.task_with_priority(rtseq::lane(&seq, &(), &mut main), DEFAULT_LANE_PRIORITY);
    first.start(id).unwrap();
    first.step(); // due: its table is the sequencer's
    let mut also_jam = |_: &(), _: Instant| false;
    let mut other: Monitors<(), 1> = Monitors::new();
    other
        .add(
            id,
            Monitor::new("jam", &mut also_jam, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut second = Sim::new(&seq, &(), other);
    assert_eq!(second.start(id), Err(Error::ForeignMonitorTable));
    assert_eq!(
        Sim::new(&seq, &(), Monitors::<(), 1>::new())
            .starting_at(Instant::from_ticks(0))
            .err(),
        Some(SimError::StartBeforeSequencerTime)
    );
}
