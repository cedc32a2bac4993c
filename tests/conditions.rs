//! The ready-made conditions of the specification (§1.6), a toggle button and "has not
//! moved for a while", on their own and as monitor conditions; `Condition::is_true`.

mod common;
use common::*;

use rtseq::sim::Sim;
use rtseq::Cause::{Monitor as Mon, Start};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Condition, Duration, Instant, Monitor, Monitors, SeqConfig, Sequencer, Stable,
    Toggle, Trigger,
};

fn at(ms: u64) -> Instant {
    Instant::from_ticks(ms * 1_000)
}

#[test]
fn is_true_evaluates_the_condition_now() {
    let mut over = |current: &f32, _: Instant| *current > 2.0;
    assert!(over.is_true(&2.5, at(0)));
    assert!(!over.is_true(&1.5, at(0)));
}

/// Each press (a rising edge of the raw button) flips the toggle; holding the button or
/// releasing it does not.
#[test]
fn a_toggle_flips_at_each_press_only() {
    let mut toggle = Toggle::new(|pressed: &bool| *pressed);
    let button = [
        false, true, true, false, false, true, false, true, true, false,
    ];
    let on: Vec<bool> = button.iter().map(|b| toggle.validate(b, at(0))).collect();
    assert_eq!(
        on,
        [false, true, true, true, true, false, false, true, true, true]
    );
}

/// A stop button as a monitor: the toggle turns on at the first press (3 ms) and off at
/// the second (6 ms); the monitor fires on its falling edge and aborts the run.
#[test]
fn a_toggle_as_a_stop_button_aborts_at_the_second_press() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let run = seq
        .add(SeqConfig::new("run"), Node::of(vec![]).until(15))
        .unwrap();
    let r = run.id();
    let mut stop = Toggle::new(|c: &Ctrl| c.flag(0));
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            r,
            Monitor::new("stop", &mut stop, Behaviour::AbortOwner).trigger(Trigger::FallingEdge),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(run);
    sim.before_tick(|t, c| c.set(0, matches!(ms(t), 3 | 4 | 6)));
    sim.start(r).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, r, Idle, Running, Start),
            tr(6, r, Running, Aborting, Mon(m)),
            tr(6, r, Aborting, Aborted, Mon(m)),
        ],
        "{}",
        show(sim.trace())
    );
}

/// "Not moved for 100 ms", tolerance 0.5: the first reading anchors the window; readings
/// within the tolerance (its edge included, either side) keep it; it holds from 100 ms
/// after the anchor on; a reading outside the tolerance anchors it anew.
#[test]
fn stable_holds_once_the_value_stayed_within_the_tolerance_for_the_window() {
    let mut still = Stable::new(|pos: &f32| *pos, 0.5, Duration::from_millis(100));
    let readings = [
        (0, 10.0, false),  // anchored at 10.0, 0 ms
        (50, 10.5, false), // on the tolerance's edge: within
        (99, 9.5, false),
        (100, 10.0, true), // the whole window
        (150, 9.8, true),
        (160, 10.6, false), // moved: anchored anew at 10.6, 160 ms
        (200, 10.6, false),
        (259, 10.2, false),
        (260, 10.1, true),
    ];
    for (t, pos, want) in readings {
        assert_eq!(still.validate(&pos, at(t)), want, "{pos} at {t} ms");
    }
}

/// A stall monitor: the position, read from the control system, has not moved for 3 ms
/// while the move runs: the move is aborted. It moves (flag 0 flips) until 4 ms.
#[test]
fn stable_as_a_stall_monitor_aborts_a_move_that_stopped_moving() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mv = seq
        .add(SeqConfig::new("move"), Node::of(vec![]).until(15))
        .unwrap();
    let id = mv.id();
    let position = |c: &Ctrl| if c.flag(0) { 1.0 } else { 0.0 };
    let mut stalled = Stable::new(position, 0.1, Duration::from_millis(3));
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            id,
            Monitor::new("stalled", &mut stalled, Behaviour::AbortOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(mv);
    sim.before_tick(|t, c| c.set(0, ms(t) <= 4 && ms(t) % 2 == 1));
    sim.start(id).unwrap();
    sim.run_for(Duration::from_millis(10));
    // Last move at 4 ms (to 0.0), anchored there: still for 3 ms at 7 ms.
    assert_eq!(
        sim.trace(),
        &[
            tr(0, id, Idle, Running, Start),
            tr(7, id, Running, Aborting, Mon(m)),
            tr(7, id, Aborting, Aborted, Mon(m)),
        ],
        "{}",
        show(sim.trace())
    );
}

/// Plain functions as conditions, in a `const` table (`Monitor::with_fn`, no cast): the
/// second monitor's condition rises at 5 ms and aborts the move; the first never holds.
#[test]
fn a_const_table_of_plain_functions_monitors_a_move() {
    fn over_current(c: &Ctrl, _: Instant) -> bool {
        c.flag(1)
    }
    fn end_stop(c: &Ctrl, _: Instant) -> bool {
        c.flag(0)
    }
    const MOVE: rtseq::SeqId = rtseq::SeqId::from_index(0);
    const MONITORS: Monitors<'static, Ctrl, 2, rtseq::ConditionFn<Ctrl>> = match Monitors::table([
        Monitor::with_fn("over-current", over_current, Behaviour::AbortOwner).owned_by(MOVE),
        Monitor::with_fn("end stop", end_stop, Behaviour::AbortOwner).owned_by(MOVE),
    ]) {
        Ok(table) => table,
        Err(_) => panic!("the table is checked by the compiler"),
    };
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mv = seq
        .add(SeqConfig::new("move"), Node::of(vec![]).until(15))
        .unwrap();
    assert_eq!(mv.id(), MOVE);
    let mut sim = Sim::new(&seq, &ctrl, MONITORS);
    sim.lane(mv);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 5));
    sim.start(MOVE).unwrap();
    sim.run_for(Duration::from_millis(10));
    let end_stop = rtseq::MonitorId::from_index(1);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, MOVE, Idle, Running, Start),
            tr(5, MOVE, Running, Aborting, Mon(end_stop)),
            tr(5, MOVE, Aborting, Aborted, Mon(end_stop)),
        ],
        "{}",
        show(sim.trace())
    );
}
