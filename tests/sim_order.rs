//! The simulator polls lanes in RTIC 2's order: the highest woken priority first, a lane of
//! higher priority woken by a poll before the pass of the lower level goes on (preemption),
//! lanes of equal priority in a fixed order per pass, or shuffled per seed
//! (`Sim::shuffle_equal_priorities`). And a tick period of 0 is an error, not a hang.

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
