//! The time of a sequencer before its first tick, and ticks 2^31 µs or more apart.
//!
//! A sequencer's time is that of its last tick, 0 before the first: a sequence started in
//! `init` (before the first tick) starts at 0, and its run clock counts from there. The
//! polling grids keep 32-bit stamps; a tick 2^31 µs or more after the last one (the first
//! tick after time 0 included) finds them stale: it polls every class at once and starts
//! its grid again from that tick. Found by an outside probe: such a first tick used to
//! evaluate no monitor, timeout or exit condition for 35.7 minutes, silently.
//!
//! The ticks here are made by hand (the simulator's tick period is below 2^31 µs); the
//! lanes are declared and never polled: monitors and timeouts are the tick's work.

mod common;
use common::*;
use rtseq::Cause::{Monitor as Mon, Start, Timeout};
use rtseq::RunningState::*;
use std::cell::RefCell;

use rtseq::{
    Behaviour, ConditionFn, Duration, Instant, Monitor, MonitorId, Monitors, SeqConfig, SeqId,
    Sequencer, Transition,
};

/// 2^31 µs, about 35.8 minutes.
const LONG: u64 = 1 << 31;

/// A sequence S (timeout `timeout`, polling period `period`) with a monitor on flag 2
/// (`AbortOwner`), in a sequencer of its own.
struct Cell {
    seq: Sequencer<Ctrl, 2>,
    ctrl: Ctrl,
    monitors: RefCell<Monitors<'static, Ctrl, 1, ConditionFn<Ctrl>>>,
}

fn fault(c: &Ctrl, _: Instant) -> bool {
    c.flag(2)
}

impl Cell {
    fn new(timeout: Option<Duration>, period: Duration) -> Self {
        let cell = Cell {
            seq: Sequencer::new(),
            ctrl: Ctrl::default(),
            monitors: RefCell::new(Monitors::new()),
        };
        let mut config = SeqConfig::new("S").polling(period);
        if let Some(t) = timeout {
            config = config.timeout(t);
        }
        let s = cell.seq.add(config, Node::of(vec![]).until(1)).unwrap();
        cell.seq
            .sequence_by_id(s.id())
            .unwrap()
            .declare_lane()
            .unwrap();
        let fault = Monitor::with_fn("fault", fault, Behaviour::AbortOwner);
        cell.monitors.borrow_mut().add(S, fault).unwrap();
        cell
    }

    fn start(&self) {
        self.seq.sequence_by_id(S).unwrap().start().unwrap();
    }

    /// Ticks at each of `times` (µs) with the monitor's condition true from `fault` on; the
    /// transitions of S.
    fn tick_at(&self, times: impl IntoIterator<Item = u64>, fault: u64) -> Vec<Transition> {
        let monitors = &mut *self.monitors.borrow_mut();
        for t in times {
            self.ctrl.set(2, t >= fault);
            self.seq
                .tick(Instant::from_ticks(t), &self.ctrl, monitors)
                .unwrap();
        }
        let mut trace = Vec::new();
        self.seq.drain_trace(|t| trace.push(t));
        trace
    }
}

const S: SeqId = SeqId::from_index(0);

/// A transition of S at `us`.
fn at(
    us: u64,
    from: rtseq::RunningState,
    to: rtseq::RunningState,
    cause: rtseq::Cause,
) -> Transition {
    Transition {
        time: Instant::from_ticks(us),
        sequence: S,
        from,
        to,
        cause,
    }
}

/// The monitor's abort of S at `us`.
fn aborted_at(us: u64) -> [Transition; 2] {
    let m = Mon(MonitorId::from_index(0));
    [at(us, Running, Aborting, m), at(us, Aborting, Aborted, m)]
}

/// Every millisecond from `first` for 100 ms.
fn every_ms_from(first: u64) -> impl Iterator<Item = u64> {
    (0..100).map(move |k| first + k * 1_000)
}

/// The first tick 2^31 µs + 5 s after time 0, S started before it: the monitor is
/// evaluated at that tick and every millisecond after, and fires 20 ms later.
#[test]
fn a_first_tick_2_31_us_after_time_0_evaluates_the_monitors() {
    let cell = Cell::new(None, Duration::from_millis(1));
    cell.start();
    let first = LONG + 5_000_000;
    let trace = cell.tick_at(every_ms_from(first), first + 20_000);
    let [aborting, aborted] = aborted_at(first + 20_000);
    assert_eq!(trace, [at(0, Idle, Running, Start), aborting, aborted]);
}

/// A gap of 2^31 µs + 5 s between two ticks: the tick after it polls at once (the fault
/// that came in the gap fires there), and its grid (3 ms) starts again from that tick.
#[test]
fn a_tick_after_a_gap_of_2_31_us_polls_at_once_and_restarts_the_grid() {
    for (fault_after_gap, fires_after_gap) in [(0, 0), (1_000, 3_000), (4_000, 6_000)] {
        let cell = Cell::new(None, Duration::from_millis(3));
        cell.start();
        let late = 10_000 + LONG + 5_000_000;
        let times = (1..=10).map(|ms| ms * 1_000).chain(every_ms_from(late));
        let trace = cell.tick_at(times, late + fault_after_gap);
        let [aborting, aborted] = aborted_at(late + fires_after_gap);
        assert_eq!(
            trace,
            [at(0, Idle, Running, Start), aborting, aborted],
            "fault {fault_after_gap} µs after the gap"
        );
    }
}

/// A gap of 2^32 µs (and of 2^32 µs + 1 ms) after a tick at 10 ms, S polled every 3 ms:
/// its stale grid point (12 ms) reads as 2 ms (1 ms) ahead, a poll in a moment; the tick
/// after the gap polls at once all the same (the fault came in the gap), and so does a
/// 50 ms timeout that ran out in it fire at once. Found by a cold review (session 52):
/// the first fix kept a grid point that read as within one period.
#[test]
fn a_gap_close_to_2_32_us_polls_at_once() {
    for extra in [0, 1_000] {
        let late = 10_000 + (1 << 32) + extra;
        let times = || (1..=10).map(|ms| ms * 1_000).chain(every_ms_from(late));
        let cell = Cell::new(None, Duration::from_millis(3));
        cell.start();
        let [aborting, aborted] = aborted_at(late);
        let trace = cell.tick_at(times(), late);
        assert_eq!(
            trace,
            [at(0, Idle, Running, Start), aborting, aborted],
            "+{extra} µs"
        );
        let cell = Cell::new(Some(Duration::from_millis(50)), Duration::from_millis(3));
        cell.start();
        assert_eq!(
            cell.tick_at(times(), u64::MAX),
            [
                at(0, Idle, Running, Start),
                at(late, Running, Aborting, Timeout(S)),
                at(late, Aborting, Aborted, Timeout(S)),
            ],
            "timeout, +{extra} µs"
        );
    }
}

/// A gap of 2^31 - 1 µs is not a long gap: the tick after it polls (its grid point has
/// passed) and the grid (3 ms, from the start at 0) goes on on its own points, not from
/// that tick: the fault that comes right after it is found at the next grid point.
#[test]
fn a_gap_just_below_2_31_us_keeps_the_grid() {
    let cell = Cell::new(None, Duration::from_millis(3));
    cell.start();
    let late = 3_000 + LONG - 1;
    // The grid's first point after `late`, 353 µs after it.
    let grid = (late / 3_000 + 1) * 3_000;
    assert!(grid < late + 3_000);
    let times = [1_000, 2_000, 3_000, late, grid, late + 3_000];
    let [aborting, aborted] = aborted_at(grid);
    let trace = cell.tick_at(times, late + 1);
    assert_eq!(trace, [at(0, Idle, Running, Start), aborting, aborted]);
}

/// A tick earlier than the last, near the end of `u64`'s µs: late (the time does not go
/// back), not a step forward across the end. Found by a cold review (session 52).
#[test]
fn a_tick_earlier_than_the_last_near_the_end_of_u64_is_late() {
    let cell = Cell::new(None, Duration::from_millis(1));
    let last = u64::MAX - 10;
    assert_eq!(cell.tick_at([last], u64::MAX), []);
    let monitors = &mut *cell.monitors.borrow_mut();
    let early = cell.seq.tick(Instant::from_ticks(5), &cell.ctrl, monitors);
    assert_eq!(early, Err(rtseq::Error::TickBeforeLast));
    assert_eq!(cell.seq.now(), Instant::from_ticks(last));
}

/// A sequence started before a first tick at 5 s is timed from the sequencer's time 0:
/// its 50 ms timeout has run out at that first tick.
#[test]
fn a_start_before_the_first_tick_is_timed_from_time_0() {
    let cell = Cell::new(Some(Duration::from_millis(50)), Duration::from_millis(1));
    cell.start();
    let first = 5_000_000;
    let trace = cell.tick_at(every_ms_from(first), first + 20_000);
    assert_eq!(
        trace,
        [
            at(0, Idle, Running, Start),
            at(first, Running, Aborting, Timeout(S)),
            at(first, Aborting, Aborted, Timeout(S)),
        ]
    );
}

/// With a time base that is not near 0 in `init`, a tick at its time before the start
/// times the run from there: the monitor fires 20 ms after the start, the 50 ms timeout
/// has not run out.
#[test]
fn a_tick_in_init_times_a_start_from_the_time_base() {
    for boot in [5_000_000, LONG + 5_000_000] {
        let cell = Cell::new(Some(Duration::from_millis(50)), Duration::from_millis(1));
        assert_eq!(cell.tick_at([boot], u64::MAX), []);
        cell.start();
        let trace = cell.tick_at(every_ms_from(boot + 1_000), boot + 20_000);
        let [aborting, aborted] = aborted_at(boot + 20_000);
        assert_eq!(
            trace,
            [at(boot, Idle, Running, Start), aborting, aborted],
            "boot at {boot} µs"
        );
    }
}

/// The simulator's start time is set before any sequence starts: one set after a start
/// (made at the sequencer's time 0, its clock counting from there) is refused.
#[test]
fn the_simulator_s_start_time_comes_before_any_start() {
    let cell = Cell::new(None, Duration::from_millis(1));
    let monitors: Monitors<Ctrl, 1> = Monitors::new();
    let later = Instant::from_ticks(LONG + 5_000_000);
    let sim = rtseq::sim::Sim::new(&cell.seq, &cell.ctrl, monitors);
    assert!(sim.starting_at(later).is_ok());
    cell.start();
    let sim = rtseq::sim::Sim::new(&cell.seq, &cell.ctrl, Monitors::<Ctrl, 1>::new());
    assert_eq!(
        sim.starting_at(later).err(),
        Some(rtseq::sim::SimError::SequenceUnderWay)
    );
}

/// Sixteen sequences in eight polling classes, two in each (ids spread over the words of
/// the sets: a class's members in different words), a monitor each on flag 2
/// (`AbortOwner`), a 50 ms timeout each or none.
type Wide<const N: usize, const B: usize> =
    Sequencer<Ctrl, N, 256, rtseq::lock::CriticalSection, 16, B>;

/// The polling periods of the eight classes (µs).
const PERIODS: [u64; rtseq::MAX_POLLING_CLASSES] =
    [1_000, 2_000, 3_000, 5_000, 7_000, 11_000, 13_000, 4_000];

/// Registers the sixteen sequences of [`Wide`] (fillers between them); returns each id
/// with its polling period.
fn wide<const N: usize, const B: usize>(
    seq: &Wide<N, B>,
    timeout: bool,
    monitors: &mut Monitors<'static, Ctrl, 16, ConditionFn<Ctrl>>,
) -> Vec<(SeqId, u64)> {
    let mut placed = Vec::new();
    for j in 0..16 {
        let slot = if N == 16 { j } else { j * N / 16 + j % 3 };
        while seq.len() < slot {
            let name: &'static str = Box::leak(format!("filler {}", seq.len()).into_boxed_str());
            seq.register(SeqConfig::new(name)).unwrap();
        }
        // Class order shuffled: a class's two members are far apart.
        let period = PERIODS[j * 5 % 8];
        let name: &'static str = Box::leak(format!("S{j}").into_boxed_str());
        let mut config = SeqConfig::new(name).polling(Duration::from_ticks(period));
        if timeout {
            config = config.timeout(Duration::from_millis(50));
        }
        let id = seq.register(config).unwrap();
        assert_eq!(id.index(), slot);
        seq.sequence_by_id(id).unwrap().declare_lane().unwrap();
        let fault = Monitor::with_fn("fault", fault, Behaviour::AbortOwner);
        monitors.add(id, fault).unwrap();
        placed.push((id, period));
    }
    placed
}

/// The sixteen sequences of [`Wide`] start at 0; ticks at `before` (µs), then a gap of
/// `gap` µs, then a tick every 500 µs for 30 ms, the fault from `fault_after` µs after the
/// gap on. Each sequence is aborted at the tick after the gap (its timeout, which ran out
/// in the gap, or the fault there), or else on its class's grid started again from that
/// tick: at the first multiple of its period at or after the fault.
fn every_class_after<const N: usize, const B: usize>(
    before: &[u64],
    gap: u64,
    fault_after: u64,
    timeout: bool,
) {
    let seq: Box<Wide<N, B>> = Box::new(Sequencer::new());
    let ctrl = Ctrl::default();
    let mut monitors = Monitors::new();
    let placed = wide(&seq, timeout, &mut monitors);
    for &(id, _) in &placed {
        seq.sequence_by_id(id).unwrap().start().unwrap();
    }
    let last = before.last().copied().unwrap_or(0);
    for &t in before {
        seq.tick(Instant::from_ticks(t), &ctrl, &mut monitors)
            .unwrap();
    }
    let late = last + gap;
    for t in (late..=late + 30_000).step_by(500) {
        ctrl.set(2, t >= late + fault_after);
        seq.tick(Instant::from_ticks(t), &ctrl, &mut monitors)
            .unwrap();
    }
    let mut trace = Vec::new();
    seq.drain_trace(|t| trace.push(t));
    for (id, period) in placed {
        let what = format!(
            "N={N}, ticks at {before:?} then {gap:#x} µs later, fault {fault_after} µs after, \
             timeout {timeout}: {id:?} polled every {period} µs"
        );
        let aborting = trace.iter().find(|t| t.sequence == id && t.to == Aborting);
        let aborting = aborting.unwrap_or_else(|| panic!("{what}: not aborted"));
        // The monitors fire before the timeouts in a tick.
        let (at, timed_out) = if fault_after == 0 {
            (late, false)
        } else if timeout {
            (late, true)
        } else {
            (late + fault_after.div_ceil(period) * period, false)
        };
        assert_eq!(
            (aborting.time, aborting.cause == Timeout(id)),
            (Instant::from_ticks(at), timed_out),
            "{what}: {aborting:?}"
        );
    }
}

/// Gaps of 2^31 µs or more, of every kind of length modulo 2^32 (a stale grid point reads
/// as behind, as a moment ahead, as a period or more ahead), in sequencers of one word,
/// of two (64 sequences) and of eight (256), with all eight polling classes, after ticks
/// that leave the grids at various points: every class with a monitored member polls at
/// the tick after the gap, and its grid starts again from there; a timeout that ran out
/// in the gap fires there.
#[test]
fn every_class_in_every_word_polls_at_the_tick_after_any_long_gap() {
    let histories: [&[u64]; 4] = [
        &[],
        &[1_000, 2_000, 3_000],
        &[500, 1_700, 2_500, 9_100],
        &[(1 << 31) - 1, (1 << 32) - 1_200, (1 << 32) + 100],
    ];
    let remainders = [
        0,
        1,
        499,
        1_000,
        2_999,
        6_500,
        12_999,
        LONG - 1,
        LONG,
        LONG + 1,
        (1 << 32) - 3_000,
        (1 << 32) - 1,
    ];
    for before in histories {
        for gap in (0..3u64).flat_map(|k| remainders.map(|r| (k << 32) + r)) {
            if gap < LONG {
                continue;
            }
            for fault_after in [0, 1, 2_500] {
                for timeout in [false, true] {
                    // The timeout would run out before the gap.
                    if timeout && before.iter().any(|&t| t >= 40_000) {
                        continue;
                    }
                    every_class_after::<16, 1>(before, gap, fault_after, timeout);
                    every_class_after::<64, 2>(before, gap, fault_after, timeout);
                    every_class_after::<256, 8>(before, gap, fault_after, timeout);
                }
            }
        }
    }
}

/// The tick after a long gap comes with another table (polls are due at once): refused,
/// as any due tick with it; but it has moved the time and started the grids again, so
/// the next tick with the sequencer's table, even at the same time, polls at once.
#[test]
fn a_foreign_table_at_the_tick_after_a_long_gap_loses_no_poll() {
    let cell = Cell::new(None, Duration::from_millis(3));
    cell.start();
    assert_eq!(
        cell.tick_at([1_000, 2_000, 3_000], u64::MAX),
        [at(0, Idle, Running, Start)]
    );
    let late = 3_000 + (1 << 32) + 1_000;
    fn never(_: &Ctrl, _: Instant) -> bool {
        false
    }
    let mut other: Monitors<Ctrl, 1, ConditionFn<Ctrl>> = Monitors::new();
    let never = Monitor::with_fn("never", never, Behaviour::AbortOwner);
    other.add(S, never).unwrap();
    let refused = cell
        .seq
        .tick(Instant::from_ticks(late), &cell.ctrl, &mut other);
    assert_eq!(refused, Err(rtseq::Error::ForeignMonitorTable));
    assert_eq!(cell.seq.now(), Instant::from_ticks(late));
    assert_eq!(cell.tick_at([late], late), aborted_at(late));
}
