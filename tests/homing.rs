//! The README's homing example, checked.

#[path = "../examples/homing.rs"]
mod homing;

use rtseq::{Cause, Outcome, SeqId};

#[test]
fn homing_reaches_the_end_stop_sets_zero_and_backs_off() {
    let homed = homing::run(true);
    assert_eq!(homed.outcome, Some(Outcome::Completed));
    // 50 mm at 20 mm/s, polled every 10 ms: the switch is seen at 2.5 s; backing off 2 mm at
    // 5 mm/s takes 0.4 s more.
    assert_eq!(homed.end_ms, 2_900);
    assert_eq!(
        homed.lines,
        [
            "0 ms homing: Idle -> Running (start)",
            "0 ms seek end stop: Idle -> Running (start)",
            "2500 ms seek end stop: Running -> Terminated (completed)",
            "2500 ms set zero: Idle -> Running (start)",
            "2500 ms set zero: Running -> Terminated (completed)",
            "2500 ms back off: Idle -> Running (start)",
            "2900 ms back off: Running -> Terminated (completed)",
            "2900 ms homing: Running -> Terminated (completed)",
        ]
    );
    assert_eq!(homed.summary, "homing completed at 2900 ms");
}

#[test]
fn broken_end_stop_times_out_and_stops_the_axis() {
    let homed = homing::run(false);
    // Registered fifth, after the safe stop and the three steps.
    let homing = SeqId::from_index(4);
    assert_eq!(
        homed.outcome,
        Some(Outcome::Aborted(Cause::Timeout(homing)))
    );
    // The timeout fires at 5 s; the safe stop runs and ends at once; its behaviour (abort)
    // is applied by the next tick.
    assert_eq!(homed.end_ms, 5_001);
    assert_eq!(
        homed.lines,
        [
            "0 ms homing: Idle -> Running (start)",
            "0 ms seek end stop: Idle -> Running (start)",
            "5000 ms timeout of `homing` ran out: AbortOwner",
            "5000 ms safe stop: Idle -> Running (timeout of `homing`)",
            "5000 ms safe stop: Running -> Terminated (completed)",
            "5001 ms seek end stop: Running -> Aborting (timeout of `homing`)",
            "5001 ms seek end stop: Aborting -> Aborted (timeout of `homing`)",
            "5001 ms homing: Running -> Aborting (timeout of `homing`)",
            "5001 ms homing: Aborting -> Aborted (timeout of `homing`)",
        ]
    );
    assert_eq!(
        homed.summary,
        "homing aborted (timeout of `homing`) at 5001 ms"
    );
}
