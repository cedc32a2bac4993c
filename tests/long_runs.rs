//! A motor controller runs for days: sequencer time over a long life. Polling classes
//! keep 32-bit µs stamps (they wrap every 2^32 µs, about 71.6 min, and compare by wrapping
//! difference below 2^31 µs); a run's clock keeps 48 bits, so a run's time, its timeout
//! and a `Wait` are exact however long the run was held by an exception (its clock runs
//! on, unpolled: the 32-bit clock lost 2^32 µs there).
//!
//! Each scenario is a function of its start time (and of a few lengths), so that its trace,
//! with times relative to the start, can be compared between a run that never wraps and one
//! that does. Times in the expectations are ms relative to the scenario's start.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Start, Timeout};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Duration, Instant, Monitor, Monitors, Seq, SeqConfig, SeqId, Sequencer, Transition,
    Trigger, Wait,
};

type Seqr = Sequencer<Ctrl, 8>;

const MIN: u64 = 60_000; // ms
const WRAP: u64 = 1 << 32; // µs
const HALF: u64 = 1 << 31; // µs

/// A trace with times relative to `base` (µs), in ms.
type Rel = Vec<(u64, SeqId, RunningState, RunningState, Cause)>;

fn rel(trace: &[Transition], base: Instant) -> Rel {
    trace
        .iter()
        .map(|t| {
            let d = t.time.as_ticks() - base.as_ticks();
            assert_eq!(d % 1_000, 0, "transition off the ms grid: {t:?}");
            (d / 1_000, t.sequence, t.from, t.to, t.cause)
        })
        .collect()
}

fn ms10() -> Duration {
    Duration::from_millis(10)
}

fn cfg(name: &'static str) -> SeqConfig<Ctrl> {
    SeqConfig::new(name).polling(ms10())
}

/// Ms since `base`.
fn since(t: Instant, base: Instant) -> u64 {
    (t.as_ticks() - base.as_ticks()) / 1_000
}

// ---------------------------------------------------------------------------------------
// 1. A timeout that falls due while its owner handles an exception fires at the first
//    tick after that exception ended (semantics 6) — also when the exception lasted long.
// ---------------------------------------------------------------------------------------

/// O (exit: never, timeout 10 min) has a monitor (flag 0, from 1 min on, rising edge,
/// `Nothing`) with an exception sequence E that ends once flag 2 is set, at `exc_end_ms`.
/// O's timeout is due at 10 min, while E runs; it must fire right after E ended.
fn timeout_after_long_exception(base: Instant, exc_end_ms: u64) -> (Rel, [SeqId; 2]) {
    let seq = Seqr::new();
    let o = seq
        .add(
            cfg("O").timeout(Duration::from_millis(10 * MIN)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let (trace, ei) = with_a_long_exception(&seq, o, base, exc_end_ms, exc_end_ms + 40 * MIN);
    (trace, [oi, ei])
}

/// Runs `owner` (in its lane) from `base` with a warning monitor of it (flag 0, set from
/// 1 min on; `Nothing`) whose exception sequence E ends once flag 2 is set, at
/// `exc_end_ms`, until idle or `limit_ms`. Returns the trace (ms from `base`) and E's id.
fn with_a_long_exception(
    seq: &Seqr,
    owner: Seq<Node>,
    base: Instant,
    exc_end_ms: u64,
    limit_ms: u64,
) -> (Rel, SeqId) {
    let ctrl = Ctrl::default();
    let e = seq.add(cfg("E"), Node::of(vec![]).until(2)).unwrap();
    let (oi, ei) = (owner.id(), e.id());
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            oi,
            Monitor::new("warn", &mut c0, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(seq, &ctrl, monitors)
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(owner);
    sim.lane(e);
    sim.before_tick(move |t, c| {
        let m = since(t, base);
        c.set(0, m >= MIN);
        c.set(2, m >= exc_end_ms);
    });
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(limit_ms));
    (rel(sim.trace(), base), ei)
}

fn timeout_after_exception_want(exc_end_ms: u64, [oi, ei]: [SeqId; 2]) -> Rel {
    // The monitor's class polls every 10 ms from the start: first poll at/after 1 min is
    // 60 000 ms; E's exit condition sees flag 2 at `exc_end_ms`; the next tick (10 ms
    // later) reports E's end, and O's timeout, due long ago, fires there.
    let m = rtseq::MonitorId::from_index(0);
    vec![
        (0, oi, Idle, Running, Start),
        (MIN, ei, Idle, Running, Mon(m)),
        (exc_end_ms, ei, Running, Terminated, Completed),
        (exc_end_ms + 10, oi, Running, Aborting, Timeout(oi)),
        (exc_end_ms + 10, oi, Aborting, Aborted, Timeout(oi)),
    ]
}

/// An exception of 20 min, and one that ends 76 min after O's start, when O's run time
/// has passed 2^32 µs (71.58 min): the timeout fires in the tick after E ended (the 32-bit
/// clock of session 49 fired it once the run time modulo 2^32 µs reached 10 min again,
/// at 81.6 min).
#[test]
fn a_timeout_due_during_an_exception_fires_right_after_it_however_long_it_was() {
    for end in [21 * MIN, 76 * MIN] {
        let (got, ids) = timeout_after_long_exception(Instant::from_ticks(0), end);
        assert_eq!(got, timeout_after_exception_want(end, ids), "{got:#?}");
    }
}

// ---------------------------------------------------------------------------------------
// 2. A `Wait` held (its caller handles an exception) keeps counting: "A held child's clock
//    runs on" (semantics 3).
// ---------------------------------------------------------------------------------------

/// main ─step→ W (Wait 100 min). A monitor of main (flag 0 from 1 min, `Nothing`) has an
/// exception sequence E that ends at `exc_end_ms`: main and W are held meanwhile, W's
/// clock runs on. W should end when its run time reaches 100 min.
fn wait_held_by_long_exception(base: Instant, exc_end_ms: u64) -> (Rel, [SeqId; 3]) {
    let seq = Seqr::new();
    let w = seq
        .add(cfg("W"), Wait::new(Duration::from_millis(100 * MIN)))
        .unwrap();
    let wi = w.id();
    let main = seq.add(cfg("main"), Node::of(vec![Op::Wait(w)])).unwrap();
    let mi = main.id();
    let (trace, ei) = with_a_long_exception(&seq, main, base, exc_end_ms, 200 * MIN);
    (trace, [mi, wi, ei])
}

fn wait_held_want(exc_end_ms: u64, [mi, wi, ei]: [SeqId; 3]) -> Rel {
    let m = rtseq::MonitorId::from_index(0);
    vec![
        (0, mi, Idle, Running, Start),
        (0, wi, Idle, Running, Start),
        (MIN, ei, Idle, Running, Mon(m)),
        (exc_end_ms, ei, Running, Terminated, Completed),
        (100 * MIN, wi, Running, Terminated, Completed),
        (100 * MIN, mi, Running, Terminated, Completed),
    ]
}

/// Held 20 min, and held 75 min (more than 2^32 µs), the 100 min wait ends at 100 min
/// (the 32-bit clock of session 49 lost 2^32 µs: 171.6 min).
#[test]
fn a_held_wait_ends_on_time_however_long_it_was_held() {
    for end in [21 * MIN, 76 * MIN] {
        let (got, ids) = wait_held_by_long_exception(Instant::from_ticks(0), end);
        assert_eq!(got, wait_held_want(end, ids), "{got:#?}");
    }
}

// ---------------------------------------------------------------------------------------
// 3. Long pauses, long waits, an idle sequencer, joins, monitors after hours, timeouts
//    near the bounds, a polling period of 2^31 - 1 µs.
// ---------------------------------------------------------------------------------------

/// main ─step→ S (exit never, timeout 10 min); main paused at 1 min for `pause_ms`. The
/// timeout keeps its remaining 9 min: it fires 9 min after the resume.
fn long_pause(base: Instant, pause_ms: u64) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(
            cfg("S").timeout(Duration::from_millis(10 * MIN)),
            Leaf::until(1),
        )
        .unwrap();
    let main = seq.add(cfg("main"), Node::of(vec![Op::Step(s)])).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(main);
    sim.start(mi).unwrap();
    sim.run_until(base + Duration::from_millis(MIN - 10));
    sim.pause(mi).unwrap(); // applied at 1 min
    sim.run_until(base + Duration::from_millis(MIN - 10 + pause_ms));
    sim.resume(mi).unwrap(); // applied at 1 min + pause
    sim.run_until_idle(Duration::from_millis(60 * MIN));
    rel(sim.trace(), base)
}

#[test]
fn a_pause_of_2_hours_keeps_the_remaining_timeout() {
    let short = long_pause(Instant::from_ticks(0), 5 * MIN);
    let shift = |r: Rel, d: u64| -> Rel {
        r.into_iter()
            .map(|(t, s, f, to, c)| (if t > MIN { t + d } else { t }, s, f, to, c))
            .collect()
    };
    assert_eq!(short.last().unwrap().0, MIN + 5 * MIN + 9 * MIN);
    for (pause, base) in [
        (120 * MIN, 0),
        (80 * MIN, WRAP - 30 * MIN * 1_000),
        (72 * MIN, 3 * WRAP - 2_000),
        (40 * MIN, HALF - 500_000),
    ] {
        let got = long_pause(Instant::from_ticks(base), pause);
        assert_eq!(
            got,
            shift(short.clone(), pause - 5 * MIN),
            "pause {pause} base {base}"
        );
    }
}

/// A `Wait` of 2 h 30 min, paused for 80 min in the middle: ends at 3 h 50 min.
fn long_wait(base: Instant, pause: Option<(u64, u64)>) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let w = seq
        .add(cfg("W"), Wait::new(Duration::from_millis(150 * MIN)))
        .unwrap();
    let main = seq.add(cfg("main"), Node::of(vec![Op::Wait(w)])).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(main);
    sim.start(mi).unwrap();
    if let Some((at, len)) = pause {
        sim.run_until(base + Duration::from_millis(at - 10));
        sim.pause(mi).unwrap();
        sim.run_until(base + Duration::from_millis(at - 10 + len));
        sim.resume(mi).unwrap();
    }
    sim.run_until_idle(Duration::from_millis(300 * MIN));
    rel(sim.trace(), base)
}

#[test]
fn a_wait_of_2_5_hours_ends_on_time_also_when_paused_80_min() {
    for base in [0, WRAP - 3_000, 2 * WRAP - 77_000, HALF - 1_000] {
        let got = long_wait(Instant::from_ticks(base), None);
        assert_eq!(got.last().unwrap().0, 150 * MIN, "base {base}: {got:?}");
        let got = long_wait(Instant::from_ticks(base), Some((30 * MIN, 80 * MIN)));
        assert_eq!(got.last().unwrap().0, 230 * MIN, "base {base}: {got:?}");
    }
}

/// An idle sequencer ticked for `idle_ms`, then a start: S (exit flag 1, timeout 30 ms,
/// polling 10 ms) times out exactly as on a fresh sequencer.
fn idle_then_start(base: Instant, idle_ms: u64) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(cfg("S").timeout(Duration::from_millis(35)), Leaf::until(1))
        .unwrap();
    let main = seq.add(cfg("main"), Node::of(vec![Op::Step(s)])).unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(main);
    sim.run_for(Duration::from_millis(idle_ms));
    let b = sim.now();
    sim.start(mi).unwrap();
    sim.run_until_idle(Duration::from_millis(MIN));
    rel(sim.trace(), b)
}

#[test]
fn a_start_after_3_hours_idle_runs_as_on_a_fresh_sequencer() {
    let reference = idle_then_start(Instant::from_ticks(0), 0);
    assert_eq!(reference.last().unwrap().0, 40);
    for (base, idle) in [
        (0, 180 * MIN),
        (WRAP - 5_000, 180 * MIN),
        (HALF + 7_000, 36 * MIN),
        (0, 71 * MIN + 35_000),
        (3 * WRAP - 10_000, 250 * MIN),
    ] {
        assert_eq!(
            idle_then_start(Instant::from_ticks(base), idle),
            reference,
            "base {base} idle {idle}"
        );
    }
}

/// main starts C non-blocking (C ends on flag 3, set at `end_ms`) and joins it: main
/// completes in the lane poll of C's end.
fn long_join(base: Instant, end_ms: u64) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let c = seq.add(cfg("C"), Node::of(vec![]).until(3)).unwrap();
    let ci = c.id();
    let main = seq
        .add(cfg("main"), Node::of(vec![Op::Start(ci), Op::Join(ci)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(main);
    sim.lane(c);
    sim.before_tick(move |t, c| c.set(3, since(t, base) >= end_ms));
    sim.start(mi).unwrap();
    sim.run_until_idle(Duration::from_millis(end_ms + MIN));
    rel(sim.trace(), base)
}

#[test]
fn a_join_waiting_for_hours_returns_at_the_childs_end() {
    for (base, end) in [
        (0, 130 * MIN),
        (WRAP - 2_000, 150 * MIN),
        (HALF - 3_000, 75 * MIN),
    ] {
        let got = long_join(Instant::from_ticks(base), end);
        let (mi, ci) = (SeqId::from_index(1), SeqId::from_index(0));
        assert_eq!(
            got,
            vec![
                (0, mi, Idle, Running, Start),
                (0, ci, Idle, Running, Start),
                (end, ci, Running, Terminated, Completed),
                (end, mi, Running, Terminated, Completed),
            ],
            "base {base} end {end}"
        );
    }
}

/// A monitor whose condition becomes true after hours: fires at the first poll at or after.
fn late_monitor(base: Instant, at_ms: u64, trigger: Trigger) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            cfg("O").polling(Duration::from_millis(20)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            oi,
            Monitor::new("late", &mut c0, Behaviour::AbortOwner).trigger(trigger),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors)
        .with_period(ms10())
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(o);
    sim.before_tick(move |t, c| c.set(0, since(t, base) >= at_ms));
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_millis(at_ms + MIN));
    rel(sim.trace(), base)
}

#[test]
fn a_monitor_whose_condition_comes_true_after_hours_fires_at_its_poll() {
    let m = rtseq::MonitorId::from_index(0);
    let oi = SeqId::from_index(0);
    for trigger in [Trigger::RisingEdge, Trigger::Level, Trigger::Change] {
        for (base, at) in [
            (0, 190 * MIN + 10),
            (WRAP - 4_000, 100 * MIN),
            (HALF, 36 * MIN),
            (2 * WRAP - 20_000, 72 * MIN + 10),
        ] {
            // Polls every 20 ms from 20 ms: the first poll at or after `at`.
            let fire = at.div_ceil(20) * 20;
            assert_eq!(
                late_monitor(Instant::from_ticks(base), at, trigger),
                vec![
                    (0, oi, Idle, Running, Start),
                    (fire, oi, Running, Aborting, Mon(m)),
                    (fire, oi, Aborting, Aborted, Mon(m)),
                ],
                "{trigger:?} base {base} at {at}"
            );
        }
    }
}

/// A timeout of 2^31 - 1 µs, polled every second (ticks every second): fires at the first
/// poll at or after 2 147.483 647 s, i.e. 2 148 s after the start.
fn longest_timeout(base: Instant) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O")
                .polling(Duration::from_secs(1))
                .timeout(Duration::from_ticks(0x7FFF_FFFF)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(Duration::from_secs(1))
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(o);
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_secs(4_000));
    rel(sim.trace(), base)
}

#[test]
fn the_longest_timeout_fires_on_time_wherever_the_wrap_falls() {
    let oi = SeqId::from_index(0);
    let want = vec![
        (0, oi, Idle, Running, Start),
        (2_148_000, oi, Running, Aborting, Timeout(oi)),
        (2_148_000, oi, Aborting, Aborted, Timeout(oi)),
    ];
    for base in [
        0,
        HALF + 1,                 // the expiry at 2^32 exactly
        WRAP - 2_148_000_000,     // the firing poll at 2^32 exactly
        WRAP - 1,                 // started 1 µs before the wrap
        WRAP - 1_000_000,         // the first poll at the wrap
        HALF - 1,                 // started 1 µs before 2^31
        3 * WRAP - 2_147_483_647, // expiry exactly at 3·2^32
        5 * WRAP + HALF,
    ] {
        assert_eq!(
            longest_timeout(Instant::from_ticks(base)),
            want,
            "base {base}"
        );
    }
}

/// Short timeouts whose expiry falls exactly on the wrap, or that start at wrap − 1 µs.
fn short_timeout(base: Instant, timeout_us: u64, period_us: u64) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O")
                .polling(Duration::from_ticks(period_us))
                .timeout(Duration::from_ticks(timeout_us)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(Duration::from_ticks(period_us))
        .unwrap()
        .starting_at(base)
        .unwrap();
    sim.lane(o);
    sim.start(oi).unwrap();
    sim.run_until_idle(Duration::from_secs(1));
    sim.trace()
        .iter()
        .map(|t| {
            (
                t.time.as_ticks() - base.as_ticks(),
                t.sequence,
                t.from,
                t.to,
                t.cause,
            )
        })
        .collect()
}

#[test]
fn short_timeouts_around_the_wrap_fire_on_time() {
    let oi = SeqId::from_index(0);
    for (timeout, period) in [
        (10_000u64, 1_000u64),
        (1, 1),
        (7, 3),
        (10_000, 10_000),
        (2_500, 1_000),
    ] {
        let fire = timeout.div_ceil(period) * period;
        let want = vec![
            (0, oi, Idle, Running, Start),
            (fire, oi, Running, Aborting, Timeout(oi)),
            (fire, oi, Aborting, Aborted, Timeout(oi)),
        ];
        for base in [
            0,
            WRAP - timeout,
            WRAP - 1,
            WRAP - fire,
            WRAP - fire + 1,
            HALF - timeout,
            HALF - 1,
            2 * WRAP - timeout,
            7 * WRAP - 1,
        ] {
            assert_eq!(
                short_timeout(Instant::from_ticks(base), timeout, period),
                want,
                "timeout {timeout} period {period} base {base}"
            );
        }
    }
}

/// A sequence with the longest polling period (2^31 - 1 µs) whose exit condition comes true
/// after 5 hours: its polls keep the grid start + k·P over several wraps.
#[test]
fn the_longest_polling_period_keeps_its_grid_over_hours() {
    for base in [0, WRAP - 1_000_000, HALF, 2 * WRAP - 60_000_000] {
        let seq = Seqr::new();
        let ctrl = Ctrl::default();
        let p: u64 = 0x7FFF_FFFF;
        let o = seq
            .add(
                SeqConfig::new("O").polling(Duration::from_ticks(p)),
                Node::of(vec![]).until(1),
            )
            .unwrap();
        let oi = o.id();
        let polls = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut log = {
            let polls = polls.clone();
            move |_: &Ctrl, t: Instant| {
                polls.lock().unwrap().push(t.as_ticks() - base);
                false
            }
        };
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        monitors
            .add(oi, Monitor::new("log", &mut log, Behaviour::Nothing))
            .unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors)
            .with_period(Duration::from_secs(1))
            .unwrap()
            .starting_at(Instant::from_ticks(base))
            .unwrap();
        sim.lane(o);
        sim.before_tick(move |t, c| c.set(1, t.as_ticks() - base >= 5 * 3_600_000_000));
        sim.start(oi).unwrap();
        sim.run_until_idle(Duration::from_secs(6 * 3600));
        // Ticks every second: the poll k comes at the first whole second ≥ k·P.
        let want: Vec<u64> = (1..=9)
            .map(|k| (k * p).div_ceil(1_000_000) * 1_000_000)
            .collect();
        assert_eq!(*polls.lock().unwrap(), want, "base {base}");
        let end = sim.trace().last().unwrap().time.as_ticks() - base;
        // The exit condition is polled on the same grid: the first poll after 5 h.
        assert_eq!(
            end,
            9 * p / 1_000_000 * 1_000_000 + 1_000_000,
            "base {base}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// 4. `Handle::set_timeout` on a run under way for longer than 2^32 µs.
// ---------------------------------------------------------------------------------------

/// O (exit never) starts with a 10 min timeout, switched off at 1 min (`None`), and set to
/// 10 min again at `set_at_ms`. Returns O's trace.
fn set_timeout_late(set_at_ms: u64) -> Rel {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            cfg("O").timeout(Duration::from_millis(10 * MIN)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let base = Instant::from_ticks(0);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(ms10())
        .unwrap();
    sim.lane(o);
    sim.start(oi).unwrap();
    let h = seq.sequence_by_id(oi).unwrap();
    sim.run_until(base + Duration::from_millis(MIN));
    h.set_timeout(None).unwrap();
    sim.run_until(base + Duration::from_millis(set_at_ms));
    h.set_timeout(Some(Duration::from_millis(10 * MIN)))
        .unwrap();
    sim.run_until_idle(Duration::from_millis(30 * MIN));
    rel(sim.trace(), base)
}

/// Set again at 20 min and at 80 min (run time ≥ 10 min): the run is still armed, and the
/// timeout fires at once, at the next poll (the 32-bit clock of session 49 fired the one
/// set at 80 min at 81.6 min, when the run time modulo 2^32 µs reached 10 min).
#[test]
fn a_timeout_set_again_late_in_a_run_fires_at_once() {
    let oi = SeqId::from_index(0);
    for at in [20 * MIN, 80 * MIN] {
        assert_eq!(
            set_timeout_late(at),
            vec![
                (0, oi, Idle, Running, Start),
                (at + 10, oi, Running, Aborting, Timeout(oi)),
                (at + 10, oi, Aborting, Aborted, Timeout(oi)),
            ],
            "set again at {at} ms"
        );
    }
}

// ---------------------------------------------------------------------------------------
// 5. A `PauseOwner` monitor holding for 2 h: the clock stops, the timeout keeps its rest.
// ---------------------------------------------------------------------------------------

#[test]
fn a_pause_owner_hold_of_2_hours_keeps_the_remaining_timeout() {
    for (base, hold) in [
        (0u64, 5 * MIN),
        (0, 120 * MIN),
        (WRAP - 30 * MIN * 1_000, 80 * MIN),
        (2 * WRAP - 60 * MIN * 1_000, 100 * MIN),
    ] {
        let seq = Seqr::new();
        let ctrl = Ctrl::default();
        let o = seq
            .add(
                cfg("O").timeout(Duration::from_millis(10 * MIN)),
                Node::of(vec![]).until(1),
            )
            .unwrap();
        let oi = o.id();
        let mut c0 = |c: &Ctrl, _| c.flag(0);
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        let m = monitors
            .add(oi, Monitor::new("hold", &mut c0, Behaviour::PauseOwner))
            .unwrap();
        let b = Instant::from_ticks(base);
        let mut sim = Sim::new(&seq, &ctrl, monitors)
            .with_period(ms10())
            .unwrap()
            .starting_at(b)
            .unwrap();
        sim.lane(o);
        sim.before_tick(move |t, c| {
            let s = since(t, b);
            c.set(0, (MIN..MIN + hold).contains(&s));
        });
        sim.start(oi).unwrap();
        sim.run_until_idle(Duration::from_millis(hold + 30 * MIN));
        let end = MIN + hold + 9 * MIN;
        assert_eq!(
            rel(sim.trace(), b),
            vec![
                (0, oi, Idle, Running, Start),
                (MIN, oi, Running, Paused, Mon(m)),
                (MIN + hold, oi, Paused, Running, Mon(m)),
                (end, oi, Running, Aborting, Timeout(oi)),
                (end, oi, Aborting, Aborted, Timeout(oi)),
            ],
            "base {base} hold {hold}"
        );
    }
}

const B48: u64 = 1 << 48;
/// A minute in µs.
const MIN_US: u64 = 60_000_000;

// ---------------------------------------------------------------------------------------
// 6. Across 2^48 µs, where the run clock itself wraps.
// ---------------------------------------------------------------------------------------

/// O (timeout 10 min) is paused at 1 min for `pause` µs and resumed; the trace relative to
/// the start is the same wherever 2^48 µs falls.
fn paused_timeout(
    base: u64,
    pause: u64,
) -> Vec<(u64, SeqId, rtseq::RunningState, rtseq::RunningState, Cause)> {
    let seq = Seqr::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(
            SeqConfig::new("O")
                .polling(Duration::from_millis(10))
                .timeout(Duration::from_ticks(10 * MIN_US)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let oi = o.id();
    let b = Instant::from_ticks(base);
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new())
        .with_period(Duration::from_millis(10))
        .unwrap()
        .starting_at(b)
        .unwrap();
    sim.lane(o);
    sim.start(oi).unwrap();
    sim.run_until(b + Duration::from_ticks(MIN_US - 10_000));
    sim.pause(oi).unwrap();
    sim.run_until(b + Duration::from_ticks(MIN_US - 10_000 + pause));
    sim.resume(oi).unwrap();
    sim.run_until_idle(Duration::from_ticks(60 * MIN_US));
    sim.trace()
        .iter()
        .map(|t| {
            (
                (t.time.as_ticks() - base) / 1_000,
                t.sequence,
                t.from,
                t.to,
                t.cause,
            )
        })
        .collect()
}

#[test]
fn run_clocks_count_across_2_pow_48_micros() {
    let reference = paused_timeout(0, 5 * MIN_US);
    for base in [
        B48 - 30 * MIN_US,
        B48 - MIN_US - 5_000,
        B48 - 6 * MIN_US,
        B48 - 11 * MIN_US,
        3 * B48 - 2 * MIN_US,
    ] {
        assert_eq!(paused_timeout(base, 5 * MIN_US), reference, "base {base}");
    }
}
