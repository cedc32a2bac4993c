//! The firmware's way of running the application: all lanes joined in one future
//! ([`App::run`]), polled by a minimal executor after every tick — same results as the
//! simulator's one-lane-per-sequence run; and the e-stop through the safety system.

mod common;
use std::future::Future;
use std::pin::pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Context, Wake, Waker};

use common::*;
use rtseq::safety::{SafetyHandle, SafetySystem};
use rtseq::{Cause, Outcome, Sequencer};
use rtseq_motor::app::{self, AppConfig, Fault, FaultPlan};
use rtseq_motor::control_system::{ControlSystem, Phase};
use rtseq_motor::safety::{self, PROPERTIES};

struct Flag(AtomicBool);
impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
}

#[test]
fn joined_lanes_give_the_same_run_as_the_simulator() {
    let (seq, cs): (Seqr, ControlSystem) = (Sequencer::new(), ControlSystem::new(0.02));
    let mut monitors: app::AppMonitors<M> = app::monitor_ids::table(&AppConfig::DEFAULT).unwrap();
    let mut app = app::register(&seq, &app::Setup::DEFAULT).unwrap();
    let main = MAIN;
    let flag = Arc::new(Flag(AtomicBool::new(true)));
    let waker = Waker::from(flag.clone());
    let mut lanes = pin!(app.run(&seq, &cs));
    let mut polls = 0u32;
    macro_rules! poll {
        () => {
            while flag.0.swap(false, Ordering::SeqCst) {
                polls += 1;
                let _ = lanes.as_mut().poll(&mut Context::from_waker(&waker));
            }
        };
    }
    poll!();
    seq.sequence_by_id(main).unwrap().start().unwrap();
    poll!();
    let mut now_ms = 0;
    while cs.phase() != Phase::Done && now_ms < 10_000 {
        now_ms += 1;
        cs.control_tick(ms(now_ms), 0.001);
        seq.tick(ms(now_ms), &cs, &mut monitors).unwrap();
        poll!();
    }
    assert_eq!(cs.phase(), Phase::Done);
    let joined = cs.summary();

    let mut w = World::new(FaultPlan::NONE, false);
    w.run();
    assert_eq!(joined.moves_done, 3);
    assert_eq!(joined.move_done_at, w.cs.summary().move_done_at);
    assert_eq!(joined.homed_at, w.cs.summary().homed_at);
    // About one wake per tick (the move step polls its exit condition every 1 ms).
    assert!(
        polls <= now_ms as u32 + 10,
        "{polls} polls in {now_ms} ticks"
    );
}

#[test]
fn estop_enters_emergency_and_aborts_every_sequence() {
    let mut w = World::new(FaultPlan::NONE.with(Fault::EStop { at: ms(2000) }), true);
    w.run();
    assert_eq!(w.safety.unwrap().level(), safety::EMERGENCY);
    assert_eq!(w.outcome(MAIN), Some(Outcome::Aborted(Cause::AbortAll)));
    w.settle(100);
    let r = w.cs.summary().estop;
    assert_eq!(r.latency(), Some(rtseq::Duration::from_millis(1)));
    assert!(r.stop_latency().unwrap() <= rtseq::Duration::from_millis(30));
    assert!(w.cs.plant().current().abs() < 0.01);
    assert_eq!(w.cs.plant().velocity(), 0.0);
}

#[test]
fn safety_properties_are_complete() {
    assert_eq!(PROPERTIES.validate(), Ok(()));
    let handle: &'static SafetyHandle = Box::leak(Box::new(SafetyHandle::new()));
    assert!(SafetySystem::new(&PROPERTIES, handle).is_ok());
}

/// The table declares the five lanes `App::run` drives: a sequencer with fewer lane slots
/// is an error naming the first lane (in table order) that found none, with nothing
/// installed, and a second registration into the same sequencer is refused.
#[test]
fn register_needs_five_lane_slots_and_an_empty_sequencer() {
    use rtseq::lock::CriticalSection;
    use rtseq::Error;
    let four: Sequencer<ControlSystem, N, 256, CriticalSection, 4> = Sequencer::new();
    assert_eq!(
        app::register(&four, &app::Setup::DEFAULT).err(),
        Some(Error::LaneCapacityExceeded(MAIN))
    );
    assert_eq!(four.len(), 0);
    let five: Sequencer<ControlSystem, N, 256, CriticalSection, 5> = Sequencer::new();
    assert!(app::register(&five, &app::Setup::DEFAULT).is_ok());
    assert_eq!(
        app::register(&five, &app::Setup::DEFAULT).err(),
        Some(Error::NotEmpty)
    );
}

/// The compile-time check of a set-up (`Setup::validate`, which the firmware relies on
/// instead of a check at start-up) finds what the sequencer's own check finds after
/// `register`: nothing for the shipped configurations.
#[test]
fn the_compile_time_check_agrees_with_the_sequencer_s() {
    for setup in [&app::Setup::DEFAULT, &app::Setup::DEMO] {
        let seq: Sequencer<ControlSystem, N> = Sequencer::new();
        app::register(&seq, setup).unwrap();
        let monitors: app::AppMonitors<M> = app::monitor_ids::table(&setup.config).unwrap();
        assert_eq!(setup.validate(), Ok(()));
        assert_eq!(seq.validate(&monitors), setup.validate());
    }
}
