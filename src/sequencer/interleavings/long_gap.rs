//! A tick 2^31 µs or more after the last one, under both locks, in sequencers of one word
//! and of two: it moves the time and marks every polling grid stale, restarts the stale
//! ones one class per section, and opens again. A start made by a lane of higher priority
//! in any of its sections keeps the grid its time gives it.

use super::*;

use crate::model::time::Stamp;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

/// The tick after the gap, in ms: 2^31 µs and 5 s after the tick at 3 ms.
const LATE: u64 = 3 + 2_147_484 + 5_000;

/// The tick after a gap of 2^32 µs and 704 µs after the tick at 3 ms: O's stale grid
/// point (4 ms) reads as 296 µs ahead, a poll in a moment.
const LATE_BY_A_WRAP: u64 = 3 + 4_294_968;

/// O (polled every ms) runs from 0 with a monitor (`AbortOwner`) whose condition holds from
/// the tick after the gap on; P (polled every 3 ms, a class of its own, idle) has one that
/// holds from its start. A lane of higher priority starts P before section `k` of that
/// tick, or after it. O is aborted at that tick, whatever `k`; P's monitor is first
/// checked on its grid: at that tick when P started at the time before the gap (its first
/// poll fell due in the gap), else one period after its start.
fn start_during_the_tick_after_a_long_gap<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
    late: u64,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let p = w.add(SeqConfig::new("P").polling(Duration::from_millis(3)));
        let fo = flag_of(false);
        w.monitor(o, fo, Behaviour::AbortOwner, None);
        w.monitor(p, flag_of(true), Behaviour::AbortOwner, None);
        w.start_taken(o);
        for ms in 1..=3 {
            w.tick(ms);
        }
        fo.store(true, Ordering::Relaxed);
        (w, o, p)
    };
    let count = sections(setup, |(w, ..)| w.tick(late));
    every_k(count + 1, |k| {
        let (w, o, p) = setup();
        let start = move || {
            w.start_taken(p);
        };
        interleaved::at(k, start);
        w.tick(late);
        or_after(k, start);
        for ms in late + 1..=late + 4 {
            w.tick(ms);
        }
        let what = name::<L>(layout, format_args!("k={k} of {count}"));
        assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        let [o_end, ..] = w.transitions(o)[1..] else {
            panic!("{what}: O {:?}", w.transitions(o));
        };
        assert_eq!(o_end.time, Instant::from_ticks(late * 1_000), "{what}");
        let p_moves = w.transitions(p);
        let [started, aborting, _] = p_moves[..] else {
            panic!("{what}: P {p_moves:?}");
        };
        let first_poll = (started.time + Duration::from_millis(3)).max(o_end.time);
        assert_eq!(
            (aborting.to, aborting.time),
            (Aborting, first_poll),
            "{what}"
        );
        w.check(&what);
    });
}

/// O (polled every ms) runs with a monitor that holds from the tick after the gap on; A
/// runs alone in a class of 3 ms, C alone in one of 2 ms (its monitor holds from 1 ms
/// after that tick); B (3 ms) and D (2 ms) are registered, their monitors holding from
/// their starts (with [`Layout::Split`], O, B and D in the second word). A lane of higher
/// priority, before section `k` of the tick after a long gap (or after it), ends A and
/// starts B (A's class is idle then: a new grid) and D (C's class is busy: D joins its
/// grid). Whatever `k`: no class is left marked stale, and each class with a monitored
/// member polls within one period after that tick; O is aborted at that tick; B is first
/// checked one period after its start, or at that tick if that came in the gap; D is
/// first checked on C's grid, started again from that tick, within one period of its
/// start (at that tick if it came in the gap); C is checked on that grid too.
fn ends_and_starts_in_busy_classes_after_a_long_gap<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
    late: u64,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let a = w.add(SeqConfig::new("A").polling(every(3)));
        let c = w.add(SeqConfig::new("C").polling(every(2)));
        w.split();
        let o = w.seq("O");
        let b = w.add(SeqConfig::new("B").polling(every(3)));
        let d = w.add(SeqConfig::new("D").polling(every(2)));
        let (fo, fc) = (flag_of(false), flag_of(false));
        w.monitor(o, fo, Behaviour::AbortOwner, None);
        w.monitor(c, fc, Behaviour::AbortOwner, None);
        w.monitor(b, flag_of(true), Behaviour::AbortOwner, None);
        w.monitor(d, flag_of(true), Behaviour::AbortOwner, None);
        for id in [o, a, c] {
            w.start_taken(id);
        }
        for ms in 1..=3 {
            w.tick(ms);
        }
        fo.store(true, Ordering::Relaxed);
        (w, [o, a, b, c, d], fc)
    };
    let count = sections(setup, |(w, ..)| w.tick(late));
    every_k(count + 1, |k| {
        let (w, [o, a, b, c, d], fc) = setup();
        let lane = move || {
            assert!(w.complete(a));
            w.start_taken(b);
            w.start_taken(d);
        };
        interleaved::at(k, lane);
        w.tick(late);
        or_after(k, lane);
        let what = name::<L>(layout, format_args!("k={k} of {count}, gap to {late} ms"));
        let class_of = |id: SeqId| w.seq.with(|s| s.block(id).unwrap().class);
        let periods = [(o, 1_000), (a, 3_000), (c, 2_000)].map(|(id, p)| (class_of(id), p));
        let (stale, polls) = w.seq.with(|s| {
            let classes = &s.polling.classes;
            let now = Stamp::of(s.now);
            let busy = |i: u8| {
                let live = |m| s.sets.has(Set::Monitored, m) || s.sets.has(Set::Changed, m);
                classes.members(i).into_iter().any(live)
            };
            let polls: Vec<(u8, u32)> = periods
                .iter()
                .map(|p| p.0)
                .filter(|&i| busy(i))
                .map(|i| (i, now.until(classes.next_poll(i, now))))
                .collect();
            (s.polling.stale, polls)
        });
        assert_eq!(stale, 0, "{what}");
        for (class, ahead) in polls {
            let period = periods.iter().find(|p| p.0 == class).unwrap().1;
            assert!(
                (1..=period).contains(&ahead),
                "{what}: class {class} polls {ahead} µs ahead"
            );
        }
        fc.store(true, Ordering::Relaxed);
        for ms in late + 1..=late + 6 {
            w.tick(ms);
        }
        let at = |ms: u64| Instant::from_ticks(ms * 1_000);
        assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        assert_eq!(w.transitions(o)[1].time, at(late), "{what}");
        assert_eq!(w.state(a), Terminated, "{what}");
        // When `id` started and when its monitor first found its condition.
        let first_check = |id: SeqId| {
            let moves = w.transitions(id);
            let started = moves.iter().find(|t| t.to == Running).unwrap().time;
            let aborting = moves.iter().find(|t| t.to == Aborting);
            let aborting = aborting.unwrap_or_else(|| panic!("{what}: {id:?} {moves:?}"));
            (started, aborting.time)
        };
        let (started, checked) = first_check(b);
        assert_eq!(checked, (started + every(3)).max(at(late)), "{what}: B");
        let (started, checked) = first_check(d);
        assert!(
            [at(late), at(late + 2)].contains(&checked)
                && checked <= (started + every(2)).max(at(late)),
            "{what}: D started at {started}, first checked at {checked}"
        );
        // C's grid starts again from the tick after the gap: its monitor, holding from
        // 1 ms after it, is found 2 ms after it.
        let (_, checked) = first_check(c);
        assert_eq!(checked, at(late + 2), "{what}: C");
        w.check(&what);
    });
}

fn every(ms: u64) -> Duration {
    Duration::from_millis(ms)
}

#[test]
fn ends_and_starts_in_busy_classes_during_the_tick_after_a_long_gap() {
    for late in [LATE, LATE_BY_A_WRAP] {
        every_world!(ends_and_starts_in_busy_classes_after_a_long_gap, late);
        ends_and_starts_in_busy_classes_after_a_long_gap::<Interleaved, 64, 2>(Layout::Split, late);
        ends_and_starts_in_busy_classes_after_a_long_gap::<InterleavedCoarse, 64, 2>(
            Layout::Split,
            late,
        );
    }
}

#[test]
fn a_start_during_the_tick_after_a_long_gap_keeps_the_grid_of_its_time() {
    every_world!(start_during_the_tick_after_a_long_gap, LATE);
}

/// Found by a cold review (session 52): after a gap close to a multiple of 2^32 µs a stale
/// grid point read as due in a moment, and the first fix kept it.
#[test]
fn a_start_during_the_tick_after_a_gap_close_to_2_32_us_keeps_the_grid_of_its_time() {
    every_world!(start_during_the_tick_after_a_long_gap, LATE_BY_A_WRAP);
}

/// Found by a third review (session 52): the tick after a long gap gave up its turn
/// between restarting the grids and opening again. O (polled every ms) runs with a
/// monitor that holds from that tick on. A second task that ticks the sequencer (misuse:
/// with a table of its own, a monitor of O) at `second` ms runs before section `k` of
/// that tick (`k` > 0: the tick has begun). It is refused (`Error::TickInProgress`) and
/// changes nothing, whatever `k`; the tick after the gap returns `Ok` and aborts O. Before
/// the fix, before the section that opened again, it was a tick of its own: refused for
/// its table (`Error::ForeignMonitorTable`) after carrying out the requests, and one 2^31
/// µs later moved the time there, so the tick after the gap, now late, evaluated nothing
/// (`Error::TickBeforeLast`).
fn second_tick_during_the_tick_after_a_long_gap<
    L: Lock + 'static,
    const N: usize,
    const B: usize,
>(
    layout: Layout,
    second: u64,
) {
    let setup = move || {
        let w = World::<L, N, B>::new(layout);
        let o = w.seq("O");
        let fo = flag_of(false);
        w.monitor(o, fo, Behaviour::AbortOwner, None);
        let other: &'static RefCell<Monitors<'static, (), 4>> =
            Box::leak(Box::new(RefCell::new(Monitors::new())));
        let never: &'static mut (dyn Condition<()> + Send) =
            Box::leak(Box::new(|_: &(), _: Instant| false));
        let m = Monitor::new("other", never, Behaviour::AbortOwner);
        other.borrow_mut().add(o, m).unwrap();
        w.start_taken(o);
        for ms in 1..=3 {
            w.tick(ms);
        }
        fo.store(true, Ordering::Relaxed);
        (w, o, other)
    };
    let count = sections(setup, |(w, ..)| w.tick(LATE));
    // From section 1 on: before section 0 the tick has not begun.
    every_k(count, |k| {
        if k == 0 {
            return;
        }
        let (w, o, other) = setup();
        let refused: &'static Cell<Option<Result<(), Error>>> =
            Box::leak(Box::new(Cell::new(None)));
        interleaved::at(k, move || {
            let at = Instant::from_ticks(second * 1_000);
            refused.set(Some(w.seq.tick(at, &(), &mut other.borrow_mut())));
        });
        let r = {
            let mut monitors = w.monitors.borrow_mut();
            w.seq
                .tick(Instant::from_ticks(LATE * 1_000), &(), &mut monitors)
        };
        let what = name::<L>(
            layout,
            format_args!("k={k} of {count}, second tick at {second} ms"),
        );
        assert_eq!(
            (r, refused.get()),
            (Ok(()), Some(Err(Error::TickInProgress))),
            "{what}"
        );
        assert_eq!(w.ended(o), (Aborted, M0), "{what}");
        assert_eq!(
            w.transitions(o)[1].time,
            Instant::from_ticks(LATE * 1_000),
            "{what}"
        );
    });
}

#[test]
fn a_second_tick_during_the_tick_after_a_long_gap_is_refused() {
    for second in [LATE + 2_147_484, LATE, LATE + 1] {
        every_world!(second_tick_during_the_tick_after_a_long_gap, second);
    }
}
