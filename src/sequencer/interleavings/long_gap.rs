//! A tick 2^31 µs or more after the last one, under both locks, in sequencers of one word
//! and of two: it moves the time and marks every polling grid stale, restarts the stale
//! ones one class per section, and opens again. A start made by a lane of higher priority
//! in any of its sections keeps the grid its time gives it.

use super::*;

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
