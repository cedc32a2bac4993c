//! Polling classes under preemption (a cold review of session 56, which found nothing): a
//! start (or an end and a start) made by a lane of higher priority before each section of
//! a due tick keeps every member of a busy class on the class's grid: its monitors are
//! evaluated at the grid's points only, once per point, from the first point after its
//! start on; with two classes, in one word and across two, at time 0 and just before the
//! 32-bit stamps wrap.

use super::*;

use std::sync::Mutex;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// A log of the times (µs) a monitor's condition was asked.
type Log = &'static Mutex<Vec<u64>>;

fn log() -> Log {
    Box::leak(Box::new(Mutex::new(Vec::new())))
}

/// A monitor of `owner` (behaviour `Nothing`, condition false) that logs its evaluations.
fn logged<L: Lock + 'static, const N: usize, const B: usize>(
    w: World<L, N, B>,
    owner: SeqId,
) -> Log {
    let l = log();
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(move |_: &(), now: Instant| {
            l.lock().unwrap().push(now.as_ticks());
            false
        }));
    w.monitors
        .borrow_mut()
        .add(owner, Monitor::new("log", condition, Behaviour::Nothing))
        .unwrap();
    l
}

/// What the lane above the tick does.
#[derive(Clone, Copy, Debug)]
enum Party {
    /// Starts B (A and A2 busy in its class).
    Start,
    /// Ends A, then starts B (A2 keeps the class busy).
    EndThenStart,
    /// Ends A and A2 (the class idle), then starts B: a new grid from the tick's time.
    EndAllThenStart,
}

/// A (word 0 with `Layout::Split`), A2 and B (word 1) poll every 10 ms, Q every 3 ms; all
/// run from `base` but B. Before section `k` of the tick at 10 ms (or after it) a lane
/// above the tick does `party`. Whatever `k`, from then to 40 ms: A2's monitor is asked
/// at 10, 20, 30, 40 ms exactly; B's on the class's grid, once per point, at every point
/// after its start (or, after `EndAllThenStart`, one period after its start).
fn start_into_a_busy_class<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    base: u64,
    party: Party,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let every = |ms| Duration::from_millis(ms);
        let a = w.add(SeqConfig::new("A").polling(every(10)));
        w.split();
        let a2 = w.add(SeqConfig::new("A2").polling(every(10)));
        let b = w.add(SeqConfig::new("B").polling(every(10)));
        let q = w.add(SeqConfig::new("Q").polling(every(3)));
        let (la2, lb) = (logged(w, a2), logged(w, b));
        tick_at(w, base, 0);
        for id in [a, a2, q] {
            w.start_taken(id);
        }
        for ms in 1..10 {
            tick_at(w, base, ms);
        }
        (w, a, a2, b, la2, lb)
    };
    let count = sections(setup, |&(w, ..)| tick_at(w, base, 10));
    every_k(count + 1, |k| {
        let (w, a, a2, b, la2, lb) = setup();
        let act = move || {
            match party {
                Party::Start => {}
                Party::EndThenStart => assert!(w.complete(a)),
                Party::EndAllThenStart => {
                    assert!(w.complete(a));
                    assert!(w.complete(a2));
                }
            }
            w.start_taken(b);
        };
        interleaved::at(k, act);
        tick_at(w, base, 10);
        let after = or_after(k, act);
        let started = w
            .transitions(b)
            .first()
            .map(|t| (t.time.as_ticks() - base) / 1_000)
            .unwrap();
        for ms in 11..=40 {
            tick_at(w, base, ms);
        }
        let what = name::<L>(
            layout,
            format_args!(
                "{party:?}, base {base}, k={k} of {count}{}",
                if after { " (after)" } else { "" }
            ),
        );
        let rel = |l: Log| -> Vec<u64> {
            l.lock()
                .unwrap()
                .iter()
                .map(|t| (t - base) / 1_000)
                .collect()
        };
        if !matches!(party, Party::EndAllThenStart) {
            assert_eq!(rel(la2), std::vec![10, 20, 30, 40], "{what}: A2");
        }
        let got = rel(lb);
        let expected: Vec<u64> = match party {
            Party::EndAllThenStart => (1..=4)
                .map(|i| started + 10 * i)
                .filter(|&t| t <= 40)
                .collect(),
            _ => [10, 20, 30, 40]
                .into_iter()
                .filter(|&t| t > started || (t == started && got.first() == Some(&t)))
                .collect(),
        };
        assert_eq!(got, expected, "{what}: B started at {started} ms");
        w.check(&what);
    });
}

/// The tick at `ms` after `base` µs.
fn tick_at<L: Lock + 'static, const N: usize, const B: usize>(
    w: World<L, N, B>,
    base: u64,
    ms: u64,
) {
    let mut monitors = w.monitors.borrow_mut();
    w.seq
        .tick(Instant::from_ticks(base + ms * 1_000), &(), &mut monitors)
        .unwrap();
}

/// Just before the 32-bit µs stamps wrap: the grid's points 10..40 ms straddle it.
const NEAR_WRAP: u64 = (1 << 32) - 25_000;

fn worlds(base: u64, party: Party) {
    let mut failed: Vec<String> = Vec::new();
    let mut one = |r: std::thread::Result<()>| {
        if let Err(e) = r {
            failed.push(e.downcast_ref::<String>().cloned().unwrap_or_default());
        }
    };
    let run = |f: &dyn Fn()| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    one(run(&|| {
        start_into_a_busy_class::<Interleaved, 8, 1>(Layout::One, base, party)
    }));
    one(run(&|| {
        start_into_a_busy_class::<Interleaved, 64, 2>(Layout::Split, base, party)
    }));
    one(run(&|| {
        start_into_a_busy_class::<InterleavedCoarse, 8, 1>(Layout::One, base, party)
    }));
    one(run(&|| {
        start_into_a_busy_class::<InterleavedCoarse, 64, 2>(Layout::Split, base, party)
    }));
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn a_start_into_a_busy_class_keeps_its_grid() {
    for base in [0, NEAR_WRAP] {
        worlds(base, Party::Start);
    }
}

#[test]
fn an_end_and_a_start_keep_the_grid_of_a_busy_class() {
    for base in [0, NEAR_WRAP] {
        worlds(base, Party::EndThenStart);
    }
}

#[test]
fn a_start_into_a_class_emptied_during_the_tick_starts_a_grid() {
    for base in [0, NEAR_WRAP] {
        worlds(base, Party::EndAllThenStart);
    }
}
