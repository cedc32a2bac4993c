//! The host simulator against its rustdoc, the ready-made conditions, and the edges of the
//! monitor triggers (a cold review, session 57). Black-box, simulated time.

use core::cell::{Cell, RefCell};

use rtseq::sim::Sim;
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Cause, Cx, Duration, Event, Failure, Instant, Monitor, MonitorId, Monitors, Outcome,
    Seq, SeqConfig, SeqId, Sequence, Sequencer, Stable, Toggle, Transition, Trigger, Wait,
};

/// The control system: flags set by the test, a value, and a log of condition calls.
#[derive(Default)]
struct K {
    flags: [Cell<bool>; 8],
    value: Cell<f32>,
    /// (condition index, `now` it was given) for every condition call.
    seen: RefCell<Vec<(usize, u64)>>,
}

impl K {
    fn flag(&self, i: usize) -> bool {
        self.flags[i].get()
    }
    fn set(&self, i: usize, v: bool) {
        self.flags[i].set(v)
    }
}

/// A condition that reads flag `i` and logs the call.
fn watch(i: usize) -> impl FnMut(&K, Instant) -> bool + Send {
    move |k: &K, now: Instant| {
        k.seen.borrow_mut().push((i, now.as_ticks()));
        k.flag(i)
    }
}

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// One blocking dwell.
struct Dwell(Seq<Wait>);
impl<C> Sequence<C> for Dwell {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.0).await;
        Ok(())
    }
}

fn tr(
    ms: u64,
    seq: SeqId,
    from: rtseq::RunningState,
    to: rtseq::RunningState,
    cause: Cause,
) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

fn show(trace: &[Transition]) -> String {
    trace
        .iter()
        .map(|t| {
            format!(
                "{:>8} us  #{} {:?} -> {:?} ({:?})\n",
                t.time.as_ticks(),
                t.sequence.index(),
                t.from,
                t.to,
                t.cause
            )
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// Monitors: first evaluation, time stamps, sampling
// ---------------------------------------------------------------------------------------

/// A condition already true when its owner starts is a rising edge at the first
/// evaluation (monitors start from "false", semantics 5), which comes one polling period
/// after a start into an idle class (semantics 1).
#[test]
fn a_condition_true_at_the_start_fires_at_the_first_evaluation_one_period_later() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq
        .add(
            SeqConfig::new("run").polling(Duration::from_millis(10)),
            Forever,
        )
        .unwrap();
    let id = run.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("hot", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    k.set(0, true);
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(30));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, id, Idle, Running, Cause::Start),
            tr(10, id, Running, Aborting, Cause::Monitor(m)),
            tr(10, id, Aborting, Aborted, Cause::Monitor(m)),
        ],
        "{}",
        show(sim.trace())
    );
    // Asked once, at 10 ms; not before the owner was due, not after it ended.
    assert_eq!(*k.seen.borrow(), [(0, 10_000)]);
}

/// Every condition of a tick is given the tick's time, the same for all; conditions are
/// asked only at their owner's polling period and only while it is monitored.
#[test]
fn the_conditions_of_a_tick_all_get_the_tick_time_at_their_owners_period() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let fast = seq
        .add(
            SeqConfig::new("fast").polling(Duration::from_millis(2)),
            Forever,
        )
        .unwrap();
    let slow = seq
        .add(
            SeqConfig::new("slow").polling(Duration::from_millis(5)),
            Forever,
        )
        .unwrap();
    let never = seq.add(SeqConfig::new("never"), Forever).unwrap();
    let (f, s, n) = (fast.id(), slow.id(), never.id());
    let (mut c0, mut c1, mut c2, mut c3) = (watch(0), watch(1), watch(2), watch(3));
    let mut monitors = Monitors::<K, 4>::new();
    monitors
        .add(f, Monitor::new("f0", &mut c0, Behaviour::Nothing))
        .unwrap();
    monitors
        .add(s, Monitor::new("s1", &mut c1, Behaviour::Nothing))
        .unwrap();
    monitors
        .add(f, Monitor::new("f2", &mut c2, Behaviour::Nothing))
        .unwrap();
    monitors
        .add(n, Monitor::new("n3", &mut c3, Behaviour::Nothing))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(fast);
    sim.lane(slow);
    sim.lane(never);
    sim.start(f).unwrap();
    sim.start(s).unwrap();
    sim.run_for(Duration::from_millis(10));
    let want = vec![
        (0, 2_000),
        (2, 2_000),
        (0, 4_000),
        (2, 4_000),
        (1, 5_000),
        (0, 6_000),
        (2, 6_000),
        (0, 8_000),
        (2, 8_000),
        (0, 10_000),
        (1, 10_000),
        (2, 10_000),
    ];
    assert_eq!(*k.seen.borrow(), want);
}

/// A condition that is true only between two evaluations of its owner is not seen: the
/// monitor samples at the owner's polling period (expected; kept as a regression test).
/// A rise seen by a slow owner fires at that owner's poll, not at a tick in between.
#[test]
fn monitors_of_owners_with_different_periods_in_one_group_fire_at_their_own_polls() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let fast = seq
        .add(
            SeqConfig::new("fast").polling(Duration::from_millis(1)),
            Forever,
        )
        .unwrap();
    let slow = seq
        .add(
            SeqConfig::new("slow").polling(Duration::from_millis(5)),
            Forever,
        )
        .unwrap();
    let (f, s) = (fast.id(), slow.id());
    let (mut c0, mut c1, mut c2, mut c3) = (watch(0), watch(1), watch(2), watch(3));
    let mut monitors = Monitors::<K, 4>::new();
    // One group: f rising, s rising (a blip between its polls), s level, s falling.
    let m0 = monitors
        .add(f, Monitor::new("f rise", &mut c0, Behaviour::Nothing))
        .unwrap();
    let m1 = monitors
        .add(s, Monitor::new("s blip", &mut c1, Behaviour::Nothing))
        .unwrap();
    let m2 = monitors
        .add(
            s,
            Monitor::new("s level", &mut c2, Behaviour::Nothing).trigger(Trigger::Level),
        )
        .unwrap();
    let m3 = monitors
        .add(
            s,
            Monitor::new("s fall", &mut c3, Behaviour::Nothing).trigger(Trigger::FallingEdge),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(fast);
    sim.lane(slow);
    sim.before_tick(|t, k| {
        let ms = t.as_ticks() / 1000;
        k.set(0, ms >= 2);
        k.set(1, (6..9).contains(&ms)); // between the polls at 5 and 10
        k.set(2, (2..12).contains(&ms)); // seen at 5 and 10
        k.set(3, ms < 7); // true at 5, false at 10
    });
    sim.start(f).unwrap();
    sim.start(s).unwrap();
    sim.run_for(Duration::from_millis(20));
    let fired: Vec<(u64, MonitorId)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired {
                cause: Cause::Monitor(m),
                ..
            }) => Some((r.time.as_ticks() / 1000, m)),
            _ => None,
        })
        .collect();
    assert_eq!(fired, [(2, m0), (5, m2), (10, m2), (10, m3)]);
    assert_eq!(sim.monitors().fired(m1), 0);
}

/// 33 monitors of one owner (two groups) whose conditions rise in the same tick all fire,
/// in table order (semantics 3), each once.
#[test]
fn thirty_three_monitors_rising_together_fire_once_each_in_table_order() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut conds: Vec<_> = (0..33).map(|_| |k: &K, _: Instant| k.flag(0)).collect();
    let mut monitors = Monitors::<K, 40>::new();
    let mut ids = Vec::new();
    for c in conds.iter_mut() {
        ids.push(
            monitors
                .add(id, Monitor::new("m", c, Behaviour::Nothing))
                .unwrap(),
        );
    }
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, t.as_ticks() >= 3_000));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    let fired: Vec<(u64, MonitorId)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired {
                cause: Cause::Monitor(m),
                ..
            }) => Some((r.time.as_ticks(), m)),
            _ => None,
        })
        .collect();
    let want: Vec<(u64, MonitorId)> = ids.iter().map(|&m| (3_000, m)).collect();
    assert_eq!(fired, want);
    for &m in &ids {
        assert_eq!(sim.monitors().fired(m), 1);
    }
}

/// A `Level` monitor with `Nothing` and no exception sequence fires at every evaluation
/// while its condition holds ("At every evaluation while the condition is true and no
/// exception of the owner is active").
#[test]
fn a_level_monitor_fires_at_every_evaluation_while_true() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq
        .add(
            SeqConfig::new("run").polling(Duration::from_millis(2)),
            Forever,
        )
        .unwrap();
    let id = run.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(
            id,
            Monitor::new("lvl", &mut c, Behaviour::Nothing).trigger(Trigger::Level),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, (3_000..=9_000).contains(&t.as_ticks())));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(20));
    // Evaluations at 2, 4, 6, 8, 10 ...: true at 4, 6, 8.
    assert_eq!(sim.monitors().fired(m), 3);
    assert_eq!(sim.state(id), Running);
}

/// A falling-edge monitor: a condition true at the start and false later fires; a
/// condition false from the start never does (the edge detection starts from "false").
#[test]
fn a_falling_edge_monitor_fires_only_after_it_saw_the_condition_true() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c0, mut c1) = (watch(0), watch(1));
    let mut monitors = Monitors::<K, 2>::new();
    let m0 = monitors
        .add(
            id,
            Monitor::new("released", &mut c0, Behaviour::Nothing).trigger(Trigger::FallingEdge),
        )
        .unwrap();
    let m1 = monitors
        .add(
            id,
            Monitor::new("never", &mut c1, Behaviour::Nothing).trigger(Trigger::FallingEdge),
        )
        .unwrap();
    let k = K::default();
    k.set(0, true);
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, t.as_ticks() < 4_000));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    let fired: Vec<(u64, MonitorId)> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired {
                cause: Cause::Monitor(m),
                ..
            }) => Some((r.time.as_ticks(), m)),
            _ => None,
        })
        .collect();
    assert_eq!(fired, [(4_000, m0)]);
    assert_eq!(sim.monitors().fired(m1), 0);
}

// ---------------------------------------------------------------------------------------
// Time: the 32-bit µs wrap, the 48-bit run clocks, the end of u64
// ---------------------------------------------------------------------------------------

/// A 5 ms dwell started at `start`: how long after `start` everything was idle.
fn dwell_from(start: u64) -> Option<u64> {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
        .starting_at(Instant::from_ticks(start))
        .unwrap();
    sim.lane(main);
    sim.start(id).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(50));
    assert_eq!(sim.tick_error(), None);
    done.map(|t| t.as_ticks() - start)
}

/// `Instant` is "a monotonic 64-bit count of µs" (firmware guide 2); the run clocks "keep
/// 48 bits of µs", i.e. a run's length, not the absolute time. A dwell across 2^48 µs
/// (8.9 years of uptime) and one near the end of u64 take their 5 ms as one across 2^32.
#[test]
fn a_dwell_across_2_pow_48_us_and_near_the_end_of_u64_takes_its_time() {
    assert_eq!(dwell_from((1 << 32) - 2_000), Some(5_000));
    assert_eq!(dwell_from((1 << 48) - 2_000), Some(5_000));
    assert_eq!(dwell_from((1 << 63) - 2_000), Some(5_000));
    assert_eq!(dwell_from(u64::MAX - 20_000_000), Some(5_000));
}

/// A 5 ms timeout started 2 ms before 2^48 µs fires 5 ms after the start.
#[test]
fn a_timeout_across_2_pow_48_us_fires_on_time() {
    for start in [(1u64 << 32) - 2_000, (1 << 48) - 2_000] {
        let seq: Sequencer<(), 2> = Sequencer::new();
        let run = seq
            .add(
                SeqConfig::new("run").timeout(Duration::from_millis(5)),
                Forever,
            )
            .unwrap();
        let id = run.id();
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
            .starting_at(Instant::from_ticks(start))
            .unwrap();
        sim.lane(run);
        sim.start(id).unwrap();
        let done = sim.run_until_idle(Duration::from_millis(50));
        assert_eq!(
            done.map(|t| t.as_ticks() - start),
            Some(5_000),
            "start {start}"
        );
        assert_eq!(
            sim.handle(id).unwrap().last_outcome(),
            Some(Outcome::Aborted(Cause::Timeout(id)))
        );
    }
}

/// Across the 32-bit µs wrap, a monitor's condition is asked at every polling period with
/// the tick's full 64-bit time, and "not moved for 3 ms" (`Stable`) fires 3 ms after its
/// anchor, the first evaluation.
#[test]
fn stable_as_a_monitor_across_the_32_bit_wrap() {
    let start = (1u64 << 32) - 3_000;
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq
        .add(
            SeqConfig::new("run").polling(Duration::from_millis(1)),
            Forever,
        )
        .unwrap();
    let id = run.id();
    let mut still = Stable::new(
        |k: &K| {
            k.seen.borrow_mut().push((0, 0));
            k.value.get()
        },
        0.1,
        Duration::from_millis(3),
    );
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("still", &mut still, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors)
        .starting_at(Instant::from_ticks(start))
        .unwrap();
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    let t = |ms: u64| Instant::from_ticks(start + ms * 1_000);
    assert_eq!(
        sim.trace(),
        &[
            Transition {
                time: t(0),
                sequence: id,
                from: Idle,
                to: Running,
                cause: Cause::Start
            },
            Transition {
                time: t(4),
                sequence: id,
                from: Running,
                to: Aborting,
                cause: Cause::Monitor(m)
            },
            Transition {
                time: t(4),
                sequence: id,
                from: Aborting,
                to: Aborted,
                cause: Cause::Monitor(m)
            },
        ],
        "{}",
        show(sim.trace())
    );
}

/// Polls on a 2 ms grid across the 32-bit wrap: the condition is asked every 2 ms, with
/// increasing times, none skipped or doubled.
#[test]
fn a_polling_grid_across_the_32_bit_wrap_keeps_its_period() {
    let start = (1u64 << 32) - 3_000;
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq
        .add(
            SeqConfig::new("run").polling(Duration::from_millis(2)),
            Forever,
        )
        .unwrap();
    let id = run.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(id, Monitor::new("c", &mut c, Behaviour::Nothing))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors)
        .starting_at(Instant::from_ticks(start))
        .unwrap();
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    let want: Vec<(usize, u64)> = (1..=5).map(|i| (0, start + i * 2_000)).collect();
    assert_eq!(*k.seen.borrow(), want);
}

// ---------------------------------------------------------------------------------------
// Simulator helpers
// ---------------------------------------------------------------------------------------

/// "Of a pause and a resume requested before the same tick the later counts": through the
/// simulator's helpers both are taken and the sequence runs on.
#[test]
fn a_pause_and_a_resume_before_the_same_tick_leave_it_running() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(1));
    assert_eq!(sim.pause(id), Ok(()));
    assert_eq!(sim.resume(id), Ok(()));
    let done = sim.run_until_idle(Duration::from_millis(20));
    assert_eq!(done, Some(Instant::from_ticks(5_000)));
    assert!(
        sim.trace().iter().all(|t| t.to != Paused),
        "{}",
        show(sim.trace())
    );
}

/// `before_tick` hooks see the new tick's time, which is `now()` after the step; with a
/// period of 3 ms, `run_for(10 ms)` ticks at 3, 6, 9.
#[test]
fn before_tick_sees_the_time_of_the_tick_it_precedes() {
    let seq: Sequencer<RefCell<Vec<u64>>, 2> = Sequencer::new();
    let log = RefCell::new(Vec::new());
    let mut sim = Sim::new(&seq, &log, Monitors::<RefCell<Vec<u64>>, 1>::new())
        .with_period(Duration::from_millis(3))
        .unwrap();
    sim.before_tick(|t, l| l.borrow_mut().push(t.as_ticks()));
    sim.run_for(Duration::from_millis(10));
    assert_eq!(*log.borrow(), [3_000, 6_000, 9_000]);
    assert_eq!(sim.now().as_ticks(), 9_000);
    assert_eq!(seq.now().as_ticks(), 9_000);
}

// ---------------------------------------------------------------------------------------
// Monitors: restarts, pauses, edge memory
// ---------------------------------------------------------------------------------------

fn fired_events(sim_records: &[rtseq::Record]) -> Vec<(u64, MonitorId, Behaviour)> {
    sim_records
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::Fired {
                cause: Cause::Monitor(m),
                behaviour,
                ..
            }) => Some((r.time.as_ticks() / 1000, m, behaviour)),
            _ => None,
        })
        .collect()
}

/// Two monitors of one owner rise in the same tick: the first restarts the owner (no
/// exception sequence: at once). The second one's firing cannot be taken by the run its
/// evaluation saw (that run is over); "a firing the owner cannot take is not used up" and
/// the restarted owner's monitors start from "false": it fires at the first evaluation of
/// the new round, aborting it.
#[test]
fn a_monitor_rising_in_the_tick_another_restarts_its_owner_fires_on_the_new_round() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let (mut c0, mut c1) = (watch(0), watch(1));
    let mut monitors = Monitors::<K, 2>::new();
    let m0 = monitors
        .add(id, Monitor::new("retry", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let m1 = monitors
        .add(id, Monitor::new("end stop", &mut c1, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| {
        k.set(0, t.as_ticks() == 3_000); // a one-tick pulse
        k.set(1, t.as_ticks() >= 3_000);
    });
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(
        fired_events(sim.records()),
        [
            (3, m0, Behaviour::RestartOwner),
            (4, m1, Behaviour::AbortOwner)
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(m1)))
    );
}

/// A `PauseOwner` monitor whose condition holds at the start pauses the owner at the first
/// evaluation, and the blocking dwell below it counts only unpaused time.
#[test]
fn a_pause_owner_monitor_true_at_the_start_pauses_at_the_first_evaluation() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(5)))
        .unwrap();
    let w = wait.id();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("curtain", &mut c, Behaviour::PauseOwner))
        .unwrap();
    let k = K::default();
    k.set(0, true);
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(main);
    sim.before_tick(|t, k| k.set(0, t.as_ticks() < 4_000));
    sim.start(id).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(30));
    let mon = Cause::Monitor(m);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, id, Idle, Running, Cause::Start),
            tr(0, w, Idle, Running, Cause::Start),
            tr(1, id, Running, Paused, mon),
            tr(1, w, Running, Paused, mon),
            tr(4, id, Paused, Running, mon),
            tr(4, w, Paused, Running, mon),
            tr(8, w, Running, Terminated, Cause::Completed),
            tr(8, id, Running, Terminated, Cause::Completed),
        ],
        "{}",
        show(sim.trace())
    );
    assert_eq!(done, Some(Instant::from_ticks(8_000)));
}

/// Monitors stay active while their owner is paused by a request (semantics 7): a rising
/// edge during the pause aborts the paused owner in that tick.
#[test]
fn a_rising_edge_while_the_owner_is_paused_by_a_request_aborts_it() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("end stop", &mut c, Behaviour::AbortOwner))
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, t.as_ticks() >= 5_000));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(1));
    sim.pause(id).unwrap();
    sim.run_for(Duration::from_millis(9));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, id, Idle, Running, Cause::Start),
            tr(2, id, Running, Paused, Cause::Pause),
            tr(5, id, Paused, Aborting, Cause::Monitor(m)),
            tr(5, id, Aborting, Aborted, Cause::Monitor(m)),
        ],
        "{}",
        show(sim.trace())
    );
}

/// The edge restarts with every run: a condition that stays true across two runs of its
/// owner fires once in each.
#[test]
fn a_condition_true_across_two_runs_fires_once_in_each() {
    let seq: Sequencer<K, 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(id, Monitor::new("warm", &mut c, Behaviour::Nothing))
        .unwrap();
    let k = K::default();
    k.set(0, true);
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(main);
    sim.start(id).unwrap();
    sim.run_until_idle(Duration::from_millis(10)).unwrap();
    sim.run_for(Duration::from_millis(2));
    sim.start(id).unwrap();
    sim.run_until_idle(Duration::from_millis(10)).unwrap();
    assert_eq!(sim.monitors().fired(m), 2);
    let times: Vec<u64> = fired_events(sim.records()).iter().map(|f| f.0).collect();
    assert_eq!(times, [1, 6]);
}

/// A toggle button as a `Change` monitor with `Nothing`: every press fires (on, off, on).
#[test]
fn a_toggle_as_a_change_monitor_fires_at_every_press() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut button = Toggle::new(|k: &K| k.flag(0));
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(
            id,
            Monitor::new("button", &mut button, Behaviour::Nothing).trigger(Trigger::Change),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, matches!(t.as_ticks() / 1000, 2 | 3 | 6 | 9 | 10)));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(12));
    let times: Vec<u64> = fired_events(sim.records()).iter().map(|f| f.0).collect();
    assert_eq!(times, [2, 6, 9]);
    assert_eq!(sim.monitors().fired(m), 3);
}

/// Restart limits with a `Level` trigger: a restart-owner monitor whose condition stays
/// true restarts its owner `limit` times per run, then aborts it.
#[test]
fn a_level_restart_monitor_restarts_limit_times_then_aborts() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let id = run.id();
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(
            id,
            Monitor::new("stuck", &mut c, Behaviour::RestartOwner)
                .trigger(Trigger::Level)
                .restart_limit(2),
        )
        .unwrap();
    let k = K::default();
    k.set(0, true);
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(run);
    sim.start(id).unwrap();
    sim.run_until_idle(Duration::from_millis(20)).unwrap();
    let restarts = sim
        .trace()
        .iter()
        .filter(|t| t.sequence == id && t.cause == Cause::Restart)
        .count();
    assert_eq!(restarts, 2, "{}", show(sim.trace()));
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Aborted(Cause::Monitor(m)))
    );
}

// ---------------------------------------------------------------------------------------
// Simulator: abort-all helper, dropped simulators, trace file
// ---------------------------------------------------------------------------------------

/// `Sim::abort_all` while nothing runs: the next tick carries it out (nothing to abort);
/// a sequence started after that tick runs normally.
#[test]
fn an_abort_all_while_idle_does_not_abort_a_run_started_after_the_next_tick() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let wait = seq
        .add(SeqConfig::new("wait"), Wait::new(Duration::from_millis(3)))
        .unwrap();
    let main = seq.add(SeqConfig::new("main"), Dwell(wait)).unwrap();
    let id = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.abort_all();
    sim.run_for(Duration::from_millis(2));
    sim.start(id).unwrap();
    let done = sim.run_until_idle(Duration::from_millis(10));
    assert_eq!(
        done,
        Some(Instant::from_ticks(5_000)),
        "{}",
        show(sim.trace())
    );
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
}

/// A simulator dropped while its sequence runs: the lane's future is dropped and the run
/// is aborted (`Cause::Dropped`, semantics 13). The teardown's records stay in the
/// sequencer (`Sim::start`): drained there, a second simulator of the sequencer, which
/// starts at the sequencer's time, has a trace of its own; not drained, they head the
/// next simulator's trace.
#[test]
fn a_simulator_dropped_mid_run_and_a_second_one() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let id = seq.register(SeqConfig::new("main").in_lane()).unwrap();
    let mut main = seq.bind(id, Forever).unwrap();
    let run_dropped_after_3_ms = |main: &mut rtseq::Seq<Forever>| {
        let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
        sim.task_with_priority(rtseq::lane(&seq, &(), main), 1);
        sim.start(id).unwrap();
        sim.run_for(Duration::from_millis(3));
    };
    run_dropped_after_3_ms(&mut main);
    assert_eq!(seq.sequence_by_id(id).unwrap().state(), Aborted);
    let mut teardown = Vec::new();
    assert_eq!(seq.drain_trace(|t| teardown.push(t)), 0);
    assert_eq!(
        teardown,
        [
            tr(3, id, Running, Aborting, Cause::Dropped),
            tr(3, id, Aborting, Aborted, Cause::Dropped)
        ]
    );
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    assert_eq!(sim.now(), Instant::from_ticks(3_000));
    sim.task_with_priority(rtseq::lane(&seq, &(), &mut main), 1);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(2));
    assert_eq!(
        sim.trace(),
        &[tr(3, id, Aborted, Running, Cause::Start)],
        "{}",
        show(sim.trace())
    );
    drop(sim);
    // Not drained: the next simulator's first step reads the teardown first.
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.task_with_priority(rtseq::lane(&seq, &(), &mut main), 1);
    sim.run_for(Duration::from_millis(1));
    assert_eq!(
        sim.trace(),
        &[
            tr(5, id, Running, Aborting, Cause::Dropped),
            tr(5, id, Aborting, Aborted, Cause::Dropped)
        ],
        "{}",
        show(sim.trace())
    );
}

/// The trace file's header: "An exception sequence's caller is the owner of its monitor."
#[test]
fn the_trace_file_names_an_exception_sequences_owner_as_its_caller() {
    struct Stop;
    impl Sequence<K> for Stop {
        async fn action(&mut self, _cx: &Cx<'_, K>) -> Result<(), Failure> {
            Ok(())
        }
    }
    let seq: Sequencer<K, 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("stop"), Stop).unwrap();
    let run = seq.add(SeqConfig::new("run"), Forever).unwrap();
    let (s, r) = (stop.id(), run.id());
    let mut c = watch(0);
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(
            r,
            Monitor::new("jam", &mut c, Behaviour::AbortOwner).exception(s),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(stop);
    sim.lane(run);
    sim.before_tick(|t, k| k.set(0, t.as_ticks() >= 2_000));
    sim.start(r).unwrap();
    sim.run_for(Duration::from_millis(5));
    let mut out = Vec::new();
    sim.write_trace(&mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let head = text.lines().next().unwrap();
    assert!(
        head.contains(r#"{"id":0,"name":"stop","caller":1}"#),
        "{head}"
    );
    assert!(
        head.contains(r#""monitors":[{"id":0,"name":"jam","owner":1}]"#),
        "{head}"
    );
    assert!(head.contains(r#""end":5000"#), "{head}");
}

// ---------------------------------------------------------------------------------------
// "Not moved for a while" across runs
// ---------------------------------------------------------------------------------------

/// A stall monitor (`Stable`, 3 ms) on a move, as in tests/conditions.rs. The first move
/// runs 0..6 ms and the axis moves until 5 ms; then it stands still, as axes do between
/// moves. The second move starts at 20 ms and the axis starts moving at 22 ms (1 ms of
/// ramp), within the 3 ms window. `Stable`'s window is of the owner's run
/// (`Condition::begin_run`), as the monitor's edge is: the axis standing still since the
/// first move does not abort the second at its first evaluation.
#[test]
fn a_stall_monitor_does_not_abort_a_new_move_within_its_window() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    struct Move;
    impl Sequence<K> for Move {
        async fn action(&mut self, cx: &Cx<'_, K>) -> Result<(), Failure> {
            cx.wait_until(|c| c.control().flag(7)).await;
            Ok(())
        }
    }
    let mv = seq.add(SeqConfig::new("move"), Move).unwrap();
    let id = mv.id();
    let mut stalled = Stable::new(|k: &K| k.value.get(), 0.1, Duration::from_millis(3));
    let mut monitors = Monitors::<K, 1>::new();
    monitors
        .add(
            id,
            Monitor::new("stalled", &mut stalled, Behaviour::AbortOwner),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(mv);
    sim.before_tick(|t, k| {
        let ms = t.as_ticks() / 1000;
        let moving = ms <= 5 || ms >= 22;
        if moving {
            k.value.set(k.value.get() + 1.0);
        }
        k.set(7, ms == 6);
    });
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(20));
    assert_eq!(
        sim.handle(id).unwrap().last_outcome(),
        Some(Outcome::Completed)
    );
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(sim.state(id), Running, "{}", show(sim.trace()));
}

/// The same monitor on an axis that never moves: each run's window starts at the run's
/// first evaluation (1 ms after its start), so each run is aborted 3 ms later, at 4 ms and
/// at 14 ms, not at the second run's first evaluation.
#[test]
fn a_stall_monitor_fires_a_window_after_each_run_s_first_evaluation() {
    let seq: Sequencer<K, 2> = Sequencer::new();
    let mv = seq.add(SeqConfig::new("move"), Forever).unwrap();
    let id = mv.id();
    let mut stalled = Stable::new(|k: &K| k.value.get(), 0.1, Duration::from_millis(3));
    let mut monitors = Monitors::<K, 1>::new();
    let m = monitors
        .add(
            id,
            Monitor::new("stalled", &mut stalled, Behaviour::AbortOwner),
        )
        .unwrap();
    let k = K::default();
    let mut sim = Sim::new(&seq, &k, monitors);
    sim.lane(mv);
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    let stall = Cause::Monitor(m);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, id, Idle, Running, Cause::Start),
            tr(4, id, Running, Aborting, stall),
            tr(4, id, Aborting, Aborted, stall),
            tr(10, id, Aborted, Running, Cause::Start),
            tr(14, id, Running, Aborting, stall),
            tr(14, id, Aborting, Aborted, stall),
        ],
        "{}",
        show(sim.trace())
    );
}
