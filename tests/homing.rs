//! The README's homing example, checked.

#[path = "../examples/homing.rs"]
mod homing;

use rtseq::{Cause, Outcome, RunningState::*, SeqId};

#[test]
fn homing_reaches_the_end_stop_sets_zero_and_backs_off() {
    let (outcome, end, trace, names) = homing::run(true);
    assert_eq!(outcome, Some(Outcome::Completed));
    // 50 mm at 20 mm/s, polled every 10 ms: the switch is seen at 2.5 s; backing off 2 mm at
    // 5 mm/s takes 0.4 s more.
    assert_eq!(end, 2_900);
    let ends: Vec<_> = trace
        .iter()
        .filter(|t| t.to == Terminated)
        .map(|t| (t.time.as_ticks() / 1000, names[t.sequence.index()]))
        .collect();
    assert_eq!(
        ends,
        vec![
            (2_500, "seek end stop"),
            (2_500, "set zero"),
            (2_900, "back off"),
            (2_900, "homing")
        ]
    );
}

#[test]
fn broken_end_stop_times_out_and_stops_the_axis() {
    let (outcome, end, trace, names) = homing::run(false);
    let homing = SeqId::from_index(names.iter().position(|&n| n == "homing").unwrap());
    assert_eq!(outcome, Some(Outcome::Aborted(Cause::Timeout(homing))));
    // The timeout fires at 5 s; the safe stop runs and ends at once; its behaviour (abort)
    // is applied by the next tick.
    assert_eq!(end, 5_001);
    let aborted: Vec<_> = trace
        .iter()
        .filter(|t| t.to == Aborted)
        .map(|t| (t.time.as_ticks() / 1000, names[t.sequence.index()]))
        .collect();
    assert_eq!(aborted, vec![(5_001, "seek end stop"), (5_001, "homing")]);
}
