//! What the controller shows after an emergency (a cold review of the demo, session 57):
//! the phase is final, the status LED off, and the over-current and e-stop reactions are
//! timed from the safety system's trip, not from another withdrawal of the drive permit.
//! Each test quotes the promise it checks. The demo's expected-outcome model is checked
//! by the QEMU suite (`tests/qemu_demo.rs`).

mod common;
use common::*;
use rtseq::Duration;
use rtseq_motor::app::{Fault, FaultPlan};
use rtseq_motor::control_system::Phase;
use rtseq_motor::safety;

/// `Phase::Fault` is documented as "Ended after a fault (moves or homing aborted)" and
/// `Phase::is_final` as "True when the application has ended". After an over-current
/// emergency (every sequence aborted by the safety system) the application has ended, but
/// nothing sets a final phase: it stays `Moving` for good (the QEMU demo prints
/// `RESULT ... level=emergency; phase=moving` for `./x demo --fault overcurrent@5s`).
#[test]
fn after_an_over_current_emergency_the_phase_is_final() {
    let mut w = World::new(
        FaultPlan::NONE.with(Fault::OverCurrent { at: ms(1500) }),
        true,
    );
    w.run();
    w.settle(100);
    assert_eq!(w.safety.unwrap().level(), safety::EMERGENCY);
    assert!(!w.sim.any_active(), "every sequence ended");
    assert!(
        w.cs.phase().is_final(),
        "the application ended (emergency, all aborted) but its phase is {:?}",
        w.cs.phase()
    );
}

/// `StatusBlink` (sequences.rs): "toggles the status LED ... until the application has
/// ended (LED steady on when done, off after a fault)". An e-stop at power-up aborts the
/// status sequence in the middle of its first blink: the LED stays on after the fault
/// (the QEMU demo's `./x demo --fault estop@0s` / `overcurrent@0s` end with "LED on").
#[test]
fn after_an_emergency_the_status_led_is_off() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::EStop { at: ms(0) }), true);
    w.run();
    w.settle(500);
    assert_eq!(w.safety.unwrap().level(), safety::EMERGENCY);
    assert!(!w.cs.led(), "LED still on after the e-stop fault");
}

/// `Reaction::reacted` is "When the application reacted: ... the safety system withdrew
/// the drive permit (over-current, e-stop)", and the safety module says the over-current
/// check "trigger[s] the private `EMERGENCY_STOP` event, applied in the next safety
/// cycle": the trip cannot withdraw the permit in the cycle that detects it. An
/// over-current injected in the tick where the power-off step's `SWITCH_OFF` takes the
/// permit away is recorded as a 0 ms reaction: `set_drive_permit` counts *any* withdrawal
/// (here the normal power off) as the reaction to an injected over-current or e-stop. The
/// QEMU demo prints "reaction  over-current: drive permit withdrawn by the safety system
/// 0 ms after the fault" for `./x demo --fault overcurrent@6541ms`.
#[test]
fn an_over_current_at_the_power_off_tick_is_not_a_zero_latency_trip() {
    let mut plain = World::new(FaultPlan::NONE, true);
    plain.run();
    let off = plain.cs.summary().finished_at.expect("main finished");
    assert_eq!(plain.cs.phase(), Phase::Done);

    let mut w = World::new(FaultPlan::NONE.with(Fault::OverCurrent { at: off }), true);
    w.run();
    w.settle(10);
    assert_eq!(w.safety.unwrap().level(), safety::EMERGENCY);
    let r = w.cs.summary().over_current;
    let latency = r.latency().expect("a reaction was recorded");
    assert!(
        latency >= Duration::from_millis(1),
        "over-current reaction recorded {latency} after the fault: the permit was withdrawn \
         by the power off, not by the trip (which takes one safety cycle)"
    );
}

/// The control system starts with the drive permitted (no safety system yet); the safety
/// system's first cycle enters level off and withdraws the permit. An over-current from
/// power-up is detected in that cycle and trips in the next: the reaction is the trip, not
/// the start-up's withdrawal (the QEMU demo printed a 1 ms reaction for
/// `./x demo --fault overcurrent@0s`, whose `level off -> emergency` comes at 2 ms).
#[test]
fn an_over_current_at_power_up_is_timed_from_the_trip() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::OverCurrent { at: ms(0) }), true);
    let mut tripped = None;
    w.run_sampling(|w| {
        if tripped.is_none() && w.safety.unwrap().level() == safety::EMERGENCY {
            tripped = Some(w.sim.now());
        }
    });
    let r = w.cs.summary().over_current;
    assert!(tripped.is_some());
    assert_eq!(r.reacted, tripped, "the reaction is the trip to emergency");
}
