//! Conformance with the original specification ("Aufbau des Sequencers", §1.1–1.7), black
//! box (a cold review, session 58): each test quotes the sentence it checks, and aims at
//! rules and combinations the other suites do not cover.

mod common;
use common::*;
use rtseq::sim::Sim;
use rtseq::Cause::{self, Completed, Monitor as Mon, Restart, Start, Timeout};
use rtseq::RunningState::*;
use rtseq::{
    Behaviour, Done, Duration, Failure, Monitor, Monitors, SeqConfig, SeqId, Sequencer, Transition,
};

fn millis(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn aborted(t: u64, seqs: &[SeqId], cause: Cause) -> Vec<Transition> {
    seqs.iter()
        .flat_map(|&s| {
            [
                tr(t, s, Running, Aborting, cause),
                tr(t, s, Aborting, Aborted, cause),
            ]
        })
        .collect()
}

fn returned_to(ctrl: &Ctrl, seq: SeqId) -> Vec<(u64, usize, Result<Done, Failure>)> {
    ctrl.returned
        .borrow()
        .iter()
        .filter(|r| r.seq == seq)
        .map(|r| (r.ms, r.line, r.result))
        .collect()
}

// ---------------------------------------------------------------------------------------
// §1.3.1 runningState: "Folgende Zustände sind möglich: idle, running, paused, aborting,
// aborted, terminated, restarting".
// ---------------------------------------------------------------------------------------

/// Exactly the seven states, no more (an exhaustive match does not compile with an eighth).
#[test]
fn running_state_has_exactly_the_seven_states_of_the_specification() {
    let all = [
        Idle, Running, Paused, Aborting, Aborted, Terminated, Restarting,
    ];
    for s in all {
        let name = match s {
            Idle => "idle",
            Running => "running",
            Paused => "paused",
            Aborting => "aborting",
            Aborted => "aborted",
            Terminated => "terminated",
            Restarting => "restarting",
        };
        assert!(!name.is_empty());
    }
    // A fresh sequence is idle.
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
    assert_eq!(seq.sequence_by_id(s.id()).unwrap().state(), Idle);
}

// ---------------------------------------------------------------------------------------
// §1.3.1 callerSequence / callerStack / callerStackBlocking, the specification's example:
// "Wird im vorherigen Beispiel SeqA1 nicht-blockieren gestartet, SeqA2 aber blockierend,
// dann läuft die Hauptsequenz unabhängig von SeqA1 und SeqA2 weiter. SeqA1 wird aber von
// SeqA2 blockiert und läuft erst weiter, wenn SeqA2 beendet ist."
// ---------------------------------------------------------------------------------------

#[test]
fn the_specification_s_caller_stack_example() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
    let si = s.id();
    let a2 = seq
        .add(SeqConfig::new("SeqA2"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let a2i = a2.id();
    let a1 = seq
        .add(SeqConfig::new("SeqA1"), Node::of(vec![Op::Run(a2)]))
        .unwrap();
    let a1i = a1.id();
    // The main sequence starts SeqA1 non-blocking and then waits for flag 2 itself.
    let main = seq
        .add(
            SeqConfig::new("main"),
            Node::of(vec![Op::Start(a1i)]).until(2),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(a1);
    sim.before_tick(|t, c| {
        c.set(1, ms(t) >= 7);
        c.set(2, ms(t) >= 3);
    });
    sim.start(mi).unwrap();
    sim.run_for(millis(1));
    let h = |id| sim.handle(id).unwrap();
    // "Die callerSequence von der MainSequence ist ein NULL-Pointer."
    assert_eq!(h(mi).caller(), None);
    assert_eq!(h(a2i).caller(), Some(a1i));
    // "callerStack[0] von SeqA2 ein Pointer auf die Hauptsequenz und callerStack[1] ...
    // auf SeqA1 ... aber keinen Pointer auf sich selbst."
    assert_eq!(h(a2i).caller_stack().as_slice(), &[mi, a1i]);
    // "hat der callerStackBlocking von SeqA2 nur einen Eintrag mit einem Pointer auf SeqA1"
    assert_eq!(h(a2i).caller_stack_blocking().as_slice(), &[a1i]);
    assert!(h(a1i).caller_stack_blocking().is_empty());
    sim.run_for(millis(20));
    // main runs on (ends at 3 ms) independently; SeqA1 goes on only once SeqA2 ended (7 ms).
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, a1i, Idle, Running, Start),
            tr(0, a2i, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, mi, Running, Terminated, Completed),
            tr(7, si, Running, Terminated, Completed),
            tr(7, a2i, Running, Terminated, Completed),
            tr(7, a1i, Running, Terminated, Completed),
        ],
    );
    assert_eq!(
        returned_to(&ctrl, a1i),
        [(7, 0, Ok(Done::Completed))],
        "SeqA1's action went on when SeqA2 had ended"
    );
}

// ---------------------------------------------------------------------------------------
// §1.2, 4 / §1.3.2 checkExitCondition: "Ist diese Condition nicht definiert, wird die
// Sequenz oder der Step sofort beendet." / "Wird checkExitCondition() nicht überschrieben,
// dann wird eine Sequence sofort nach der action()-Methode ... beendet."
// ---------------------------------------------------------------------------------------

#[test]
fn without_an_exit_condition_steps_and_sequences_end_right_after_their_action() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s1 = seq.add(SeqConfig::new("S1"), Leaf::default()).unwrap();
    let s2 = seq.add(SeqConfig::new("S2"), Leaf::default()).unwrap();
    let (s1i, s2i) = (s1.id(), s2.id());
    let inner = seq
        .add(SeqConfig::new("inner"), Node::of(vec![Op::Step(s2)]))
        .unwrap();
    let ii = inner.id();
    let main = seq
        .add(
            SeqConfig::new("main").polling(millis(10)),
            Node::of(vec![Op::Step(s1), Op::Run(inner)]),
        )
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(mi).unwrap();
    // Everything ends at 0 ms, without waiting for a poll (main polls every 10 ms).
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, s1i, Idle, Running, Start),
            tr(0, s1i, Running, Terminated, Completed),
            tr(0, ii, Idle, Running, Start),
            tr(0, s2i, Idle, Running, Start),
            tr(0, s2i, Running, Terminated, Completed),
            tr(0, ii, Running, Terminated, Completed),
            tr(0, mi, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// §1.3.1 pollingTime: "Nach dem action()-Teil werden in regelmässigen Abständen die
// relevanten Monitore überprüft. Die pollingTime beschreibt in Millisekunden, wie lange
// gewartet wird, bevor alle Monitore erneut überprüft werden." §1.7.1: "Die Condition wird
// regelmässig, abhängig von der pollingTime der Sequence, überprüft."
// ---------------------------------------------------------------------------------------

/// X (polling 10 ms) is started at 3 ms: its exit condition (true from 15 ms) is seen at
/// the poll of 23 ms, its monitor (true from 14 ms) at the same poll, its timeout (25 ms
/// of run time: due at 28 ms) at the poll of 33 ms.
fn polled_x(what: u8) -> Vec<Transition> {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut cfg = SeqConfig::new("X").polling(millis(10));
    if what == 2 {
        cfg = cfg.timeout(millis(25));
    }
    let exit = if what == 0 { 1 } else { 15 };
    let x = seq.add(cfg, Node::of(vec![]).until(exit)).unwrap();
    let xi = x.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    if what == 1 {
        monitors
            .add(xi, Monitor::new("m", &mut c0, Behaviour::AbortOwner))
            .unwrap();
    }
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 14);
        c.set(1, ms(t) >= 15);
    });
    sim.run_for(millis(3));
    sim.start(xi).unwrap();
    sim.run_for(millis(50));
    sim.trace().to_vec()
}

#[test]
fn exit_condition_monitor_and_timeout_are_checked_at_the_polling_time() {
    let x = SeqId::from_index(0);
    assert_trace(
        &polled_x(0),
        &[
            tr(3, x, Idle, Running, Start),
            tr(23, x, Running, Terminated, Completed),
        ],
    );
    let mut want = vec![tr(3, x, Idle, Running, Start)];
    want.extend(aborted(23, &[x], Mon(rtseq::MonitorId::from_index(0))));
    assert_trace(&polled_x(1), &want);
    let mut want = vec![tr(3, x, Idle, Running, Start)];
    want.extend(aborted(33, &[x], Timeout(x)));
    assert_trace(&polled_x(2), &want);
}

// ---------------------------------------------------------------------------------------
// §1.7: "Ein Monitor wird einer Sequence oder einem Step zugewiesen. ... Der Monitor wird
// anschliessend von allen Sequenzen und Steps, welche die Besitzer-Sequenz blockieren,
// überprüft." A monitor is checked while its owner runs (itself or blocked), and by nothing
// else: not while the owner is idle or has ended, nor by a non-blocking child that outlives
// it. §1.7.2: "Sobald die Condition wahr wird, wird die Exception Sequence gestartet."
// ---------------------------------------------------------------------------------------

#[test]
fn a_monitor_is_not_checked_while_its_owner_is_idle_or_ended() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let n = seq
        .add(SeqConfig::new("N"), Node::of(vec![]).until(1))
        .unwrap();
    let ni = n.id();
    let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
    let ei = e.id();
    // O starts N non-blocking and ends at once.
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![Op::Start(ni)]))
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::AbortCallerOfOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(n);
    sim.lane(e);
    // True while O is idle (2 ms), and again after O ended (from 6 ms, N still running).
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 2 || ms(t) >= 6);
        c.set(1, ms(t) >= 10);
    });
    sim.run_for(millis(4));
    sim.start(oi).unwrap();
    sim.run_for(millis(20));
    assert_trace(
        sim.trace(),
        &[
            tr(4, oi, Idle, Running, Start),
            tr(4, ni, Idle, Running, Start),
            tr(4, oi, Running, Terminated, Completed),
            tr(10, ni, Running, Terminated, Completed),
        ],
    );
    assert_eq!(sim.monitors().fired(m), 0);
}

/// "Sobald die Condition wahr wird": a condition already true when the owner starts is
/// taken as becoming true in that run (the edge restarts with every run): the monitor fires
/// at the owner's first poll and starts its exception sequence there.
#[test]
fn a_condition_true_before_the_start_fires_at_the_first_poll_of_the_run() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(
            SeqConfig::new("X").polling(millis(5)),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let xi = x.id();
    let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    ctrl.set(0, true);
    sim.run_for(millis(2));
    sim.start(xi).unwrap();
    sim.run_for(millis(20));
    let mut want = vec![
        tr(2, xi, Idle, Running, Start),
        tr(7, ei, Idle, Running, Mon(m)),
        tr(7, ei, Running, Terminated, Completed),
    ];
    want.extend(aborted(8, &[xi], Mon(m)));
    assert_trace(sim.trace(), &want);
}

// ---------------------------------------------------------------------------------------
// §1.3.2 checkPreCondition: "Werden die definierten Bedingungen nicht erfüllt, wird die
// Sequenz übersprungen." A skipped sequence never runs, so its monitors and its timeout are
// never checked and its exception sequence never starts.
// ---------------------------------------------------------------------------------------

#[test]
fn a_skipped_sequence_s_monitors_and_timeout_are_never_checked() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let mut node = Node::of(vec![]).until(15);
    node.pre = Some(2);
    let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
    let ei = e.id();
    let x = seq
        .add(
            SeqConfig::new("X").timeout(millis(1)).timeout_exception(ei),
            node,
        )
        .unwrap();
    let xi = x.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Run(x)]).until(3))
        .unwrap();
    let mi = main.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(main);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(3, ms(t) >= 5));
    ctrl.set(0, true);
    sim.start(mi).unwrap();
    sim.run_for(millis(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, mi, Idle, Running, Start),
            tr(0, xi, Idle, Running, Start),
            tr(0, xi, Running, Terminated, Cause::PreConditionFalse),
            tr(5, mi, Running, Terminated, Completed),
        ],
    );
    assert_eq!(sim.monitors().fired(m), 0);
    assert_eq!(returned_to(&ctrl, mi), [(0, 0, Ok(Done::Skipped))]);
}

// ---------------------------------------------------------------------------------------
// §1.7.3, 3. restartOwner: "Die Besitzer-Sequenz wird abgebrochen und neu gestartet."
// Together with 2.: "Die Besitzer-Sequenz des Monitors, und alle Unter-Sequenzen ...":
// the restarted owner's sub-sequences, non-blocking ones too, are aborted, and the
// repeated action (§1.3.3 "Wenn erforderlich, wird action() mehrmals aufgerufen") starts
// them again.
// ---------------------------------------------------------------------------------------

#[test]
fn restart_owner_aborts_its_non_blocking_children_and_the_repeated_action_starts_them_again() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let n = seq
        .add(SeqConfig::new("N"), Node::of(vec![]).until(1))
        .unwrap();
    let ni = n.id();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(1)).unwrap();
    let si = s.id();
    let o = seq
        .add(
            SeqConfig::new("O"),
            Node::of(vec![Op::Start(ni), Op::Step(s)]),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.lane(n);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 4);
        c.set(1, ms(t) >= 9);
    });
    sim.start(oi).unwrap();
    sim.run_for(millis(20));
    let mut want = vec![
        tr(0, oi, Idle, Running, Start),
        tr(0, ni, Idle, Running, Start),
        tr(0, si, Idle, Running, Start),
    ];
    want.extend(aborted(4, &[ni, si], Mon(m)));
    want.extend([
        tr(4, oi, Running, Restarting, Mon(m)),
        tr(4, oi, Restarting, Running, Restart),
        tr(4, ni, Aborted, Running, Start),
        tr(4, si, Aborted, Running, Start),
        // O's lane first (its step S, then O), then N's lane.
        tr(9, si, Running, Terminated, Completed),
        tr(9, oi, Running, Terminated, Completed),
        tr(9, ni, Running, Terminated, Completed),
    ]);
    assert_trace(sim.trace(), &want);
    assert_eq!(
        ctrl.lines_of(oi),
        [(0, 0), (0, 1), (4, 0), (4, 1), (9, END)]
    );
}

// ---------------------------------------------------------------------------------------
// §1.7.3, 4. abortCallerofOwner: "Die callerSequence, und damit natürlich auch die
// Besitzer-Sequenz, wird abgebrochen." The owner here is a non-blocking child of a caller
// that still runs (waits at its exit condition): both are aborted.
// ---------------------------------------------------------------------------------------

#[test]
fn abort_caller_of_owner_of_a_non_blocking_owner_aborts_the_running_caller_and_the_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(1))
        .unwrap();
    let oi = o.id();
    let c = seq
        .add(SeqConfig::new("C"), Node::of(vec![Op::Start(oi)]).until(1))
        .unwrap();
    let ci = c.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(c);
    sim.lane(o);
    sim.before_tick(|t, c| c.set(0, ms(t) == 4));
    sim.start(ci).unwrap();
    sim.run_for(millis(20));
    let mut want = vec![
        tr(0, ci, Idle, Running, Start),
        tr(0, oi, Idle, Running, Start),
    ];
    want.extend(aborted(4, &[oi, ci], Mon(m)));
    assert_trace(sim.trace(), &want);
}

/// §1.7.3, 5. restartCallerofOwner: "Die callerSequence wird abgebrochen und neu gestartet."
/// The non-blocking owner goes down with its caller and the caller's repeated action starts
/// it again.
#[test]
fn restart_caller_of_owner_of_a_non_blocking_owner_restarts_the_caller_which_starts_it_again() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let o = seq
        .add(SeqConfig::new("O"), Node::of(vec![]).until(1))
        .unwrap();
    let oi = o.id();
    let c = seq
        .add(SeqConfig::new("C"), Node::of(vec![Op::Start(oi)]).until(1))
        .unwrap();
    let ci = c.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            oi,
            Monitor::new("m", &mut c0, Behaviour::RestartCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(c);
    sim.lane(o);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 4);
        c.set(1, ms(t) >= 9);
    });
    sim.start(ci).unwrap();
    sim.run_for(millis(20));
    let mut want = vec![
        tr(0, ci, Idle, Running, Start),
        tr(0, oi, Idle, Running, Start),
    ];
    want.extend(aborted(4, &[oi], Mon(m)));
    want.extend([
        tr(4, ci, Running, Restarting, Mon(m)),
        tr(4, ci, Restarting, Running, Restart),
        tr(4, oi, Aborted, Running, Start),
        tr(9, ci, Running, Terminated, Completed),
        tr(9, oi, Running, Terminated, Completed),
    ]);
    assert_trace(sim.trace(), &want);
}

/// The specification leaves `…CallerofOwner` of a main sequence ("Die callerSequence von der
/// MainSequence ist ein NULL-Pointer") open; rtseq's rustdoc of `Behaviour` says it acts on
/// the owner itself.
#[test]
fn caller_behaviours_of_a_main_sequence_act_on_the_owner_itself() {
    for behaviour in [
        Behaviour::AbortCallerOfOwner,
        Behaviour::RestartCallerOfOwner,
    ] {
        let seq: Sequencer<Ctrl, 2> = Sequencer::new();
        let ctrl = Ctrl::default();
        let x = seq
            .add(SeqConfig::new("X"), Node::of(vec![]).until(1))
            .unwrap();
        let xi = x.id();
        let mut c0 = |c: &Ctrl, _| c.flag(0);
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        let m = monitors
            .add(xi, Monitor::new("m", &mut c0, behaviour))
            .unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.lane(x);
        sim.before_tick(|t, c| {
            c.set(0, ms(t) == 4);
            c.set(1, ms(t) >= 9);
        });
        sim.start(xi).unwrap();
        sim.run_for(millis(20));
        let mut want = vec![tr(0, xi, Idle, Running, Start)];
        if behaviour == Behaviour::AbortCallerOfOwner {
            want.extend(aborted(4, &[xi], Mon(m)));
        } else {
            want.extend([
                tr(4, xi, Running, Restarting, Mon(m)),
                tr(4, xi, Restarting, Running, Restart),
                tr(9, xi, Running, Terminated, Completed),
            ]);
        }
        assert_trace(sim.trace(), &want);
    }
}

// ---------------------------------------------------------------------------------------
// §1.7.4 Timeout Monitor: "Der Monitor besitzt bereits eine spezialisierte Condition. Die
// Exception Sequence und das Behavior können aber wie bei jedem anderen Monitor gesetzt
// werden." A step's timeout with an exception sequence and restartCallerofOwner: every
// round the exception sequence runs, then the caller is restarted (its step with a fresh
// timeout); rtseq bounds the restarts (documented deviation: default 3, then the matching
// abort).
// ---------------------------------------------------------------------------------------

#[test]
fn a_step_s_timeout_with_exception_sequence_and_restart_caller_of_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
    let ei = e.id();
    let s = seq
        .add(
            SeqConfig::new("S")
                .timeout(millis(3))
                .timeout_exception(ei)
                .timeout_behaviour(Behaviour::RestartCallerOfOwner),
            Leaf::until(15),
        )
        .unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let main = seq
        .add(SeqConfig::new("main"), Node::of(vec![Op::Run(a)]))
        .unwrap();
    let mi = main.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(e);
    sim.start(mi).unwrap();
    sim.run_for(millis(40));
    let to = Timeout(si);
    let mut want = vec![
        tr(0, mi, Idle, Running, Start),
        tr(0, ai, Idle, Running, Start),
        tr(0, si, Idle, Running, Start),
    ];
    // Rounds at 0, 4, 8, 12 ms: the timeout fires 3 ms into each, E runs and ends in that
    // tick, its behaviour comes at the next tick (1 ms later). The fourth firing is past
    // the limit of 3 restarts: the matching abort.
    let mut t = 0;
    for round in 0..4 {
        let from = if round == 0 { Idle } else { Terminated };
        want.push(tr(t + 3, ei, from, Running, to));
        want.push(tr(t + 3, ei, Running, Terminated, Completed));
        if round < 3 {
            want.extend(aborted(t + 4, &[si], to));
            want.push(tr(t + 4, ai, Running, Restarting, to));
            want.push(tr(t + 4, ai, Restarting, Running, Restart));
            want.push(tr(t + 4, si, Aborted, Running, Start));
        } else {
            want.extend(aborted(t + 4, &[si, ai], to));
            want.push(tr(t + 4, mi, Running, Terminated, Completed));
        }
        t += 4;
    }
    assert_trace(sim.trace(), &want);
    assert_eq!(returned_to(&ctrl, mi), [(16, 0, Err(Failure::Aborted(to)))]);
}

// ---------------------------------------------------------------------------------------
// §1.3.1 exceptionIsActive: "wird true gesetzt, wenn die Sequenz wegen einer Exception
// abgebrochen oder neu gestartet wird. Eine solche Exception wird von einem Monitor
// ausgelöst." With abortCallerofOwner, the caller is the sequence aborted because of the
// exception ("Die callerSequence ... wird abgebrochen").
// ---------------------------------------------------------------------------------------

/// Step S, run blocking by A (a main sequence), owns a monitor that aborts A at 3 ms.
fn caller_aborted_by_a_child_s_monitor() -> (bool, bool, Option<Cause>, Option<Cause>, Cause) {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(5));
    assert_eq!((sim.state(si), sim.state(ai)), (Aborted, Aborted));
    let (hs, ha) = (sim.handle(si).unwrap(), sim.handle(ai).unwrap());
    (
        hs.exception_is_active(),
        ha.exception_is_active(),
        hs.active_exception(),
        ha.active_exception(),
        Mon(m),
    )
}

#[test]
fn exception_is_active_of_the_owner_after_abort_caller_of_owner() {
    let (owner, _, owner_exc, _, m) = caller_aborted_by_a_child_s_monitor();
    assert_eq!((owner, owner_exc), (true, Some(m)));
}

// The caller aborted by abortCallerofOwner is "die Sequenz", die "wegen einer Exception
// abgebrochen ... wird" (its last outcome is Aborted(Monitor(m))): marked, as EEROS's
// `setActiveException` marks the owner's caller for the `…CallerOfOwner` behaviours.
#[test]
fn exception_is_active_of_the_caller_aborted_by_abort_caller_of_owner() {
    let (_, caller, _, caller_exc, m) = caller_aborted_by_a_child_s_monitor();
    assert_eq!((caller, caller_exc), (true, Some(m)));
}

/// With `nothing` the sequence is neither aborted nor restarted: once the exception
/// sequence ended and the owner goes on ("Die Sequenz wird ganz normal weitergeführt"),
/// no exception is active any more.
#[test]
fn after_nothing_the_owner_goes_on_without_an_active_exception() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(1))
        .unwrap();
    let xi = x.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 2);
        c.set(2, ms(t) >= 4);
        c.set(1, ms(t) >= 8);
    });
    sim.start(xi).unwrap();
    sim.run_for(millis(3));
    let h = sim.handle(xi).unwrap();
    assert_eq!(
        (h.exception_is_active(), h.active_exception()),
        (true, Some(Mon(m)))
    );
    sim.run_for(millis(3));
    let h = sim.handle(xi).unwrap();
    assert_eq!(
        (sim.state(xi), h.exception_is_active(), h.active_exception()),
        (Running, false, Some(Mon(m)))
    );
    sim.run_for(millis(5));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(2, ei, Idle, Running, Mon(m)),
            tr(4, ei, Running, Terminated, Completed),
            tr(8, xi, Running, Terminated, Completed),
        ],
    );
}

// ---------------------------------------------------------------------------------------
// §1.6 / §1.3.1 sequencer access: "Mit den Methoden getSequenceByID(int ID) und
// getSequenceByName(...) können Pointer auf andere Sequenzen, auch parallel Laufende,
// geholt werden."
// ---------------------------------------------------------------------------------------

#[test]
fn a_sequence_finds_a_parallel_running_sequence_by_name_and_by_id() {
    use rtseq::{Cx, Sequence};
    struct Look(SeqId);
    impl Sequence<Ctrl> for Look {
        async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
            let by_name = cx.sequence_by_name("P").ok_or(Failure::App(1))?;
            let by_id = cx.sequence_by_id(self.0).ok_or(Failure::App(2))?;
            let ok =
                by_name.id() == self.0 && by_id.state() == Running && by_name.state() == Running;
            cx.control().set(9, ok);
            Ok(())
        }
    }
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let p = seq
        .add(SeqConfig::new("P"), Node::of(vec![]).until(1))
        .unwrap();
    let pi = p.id();
    let l = seq.add(SeqConfig::new("L"), Look(pi)).unwrap();
    let li = l.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(p);
    sim.lane(l);
    sim.start(pi).unwrap();
    sim.start(li).unwrap();
    sim.run_for(millis(2));
    assert!(ctrl.flag(9));
    assert_eq!(sim.state(li), Terminated);
}

// ---------------------------------------------------------------------------------------
// Polling of each sequence, monitors during exceptions and pauses, hooks on restart.
// ---------------------------------------------------------------------------------------

/// §1.3.1 pollingTime is each sequence's own: a step's exit condition is checked at the
/// step's polling time, not its caller's. Caller A (polling 10 ms) steps S (polling 2 ms)
/// whose exit condition is true from 3 ms: S ends at its poll of 4 ms and A, with no exit
/// condition of its own, right after it.
#[test]
fn a_step_s_exit_condition_is_checked_at_the_step_s_own_polling_time() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("S").polling(millis(2)), Leaf::until(1))
        .unwrap();
    let si = s.id();
    let a = seq
        .add(
            SeqConfig::new("A").polling(millis(10)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let ai = a.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(a);
    sim.before_tick(|t, c| c.set(1, ms(t) >= 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(20));
    assert_trace(
        sim.trace(),
        &[
            tr(0, ai, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(4, si, Running, Terminated, Completed),
            tr(4, ai, Running, Terminated, Completed),
        ],
    );
}

/// §1.7.3 1. nothing: "Die Sequenz wird ganz normal weitergeführt." Two monitors of one
/// owner true at the same poll: `nothing` without an exception sequence is handled at once
/// and holds nothing, so the second (abortOwner) fires in the same poll.
#[test]
fn a_nothing_monitor_does_not_shadow_another_monitor_of_the_same_poll() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![]).until(15))
        .unwrap();
    let xi = x.id();
    let (mut c0, mut c1) = (|c: &Ctrl, _| c.flag(0), |c: &Ctrl, _| c.flag(0));
    let mut monitors: Monitors<Ctrl, 2> = Monitors::new();
    let warn = monitors
        .add(xi, Monitor::new("warn", &mut c0, Behaviour::Nothing))
        .unwrap();
    let stop = monitors
        .add(xi, Monitor::new("stop", &mut c1, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.before_tick(|t, c| c.set(0, ms(t) >= 4));
    sim.start(xi).unwrap();
    sim.run_for(millis(10));
    let mut want = vec![tr(0, xi, Idle, Running, Start)];
    want.extend(aborted(4, &[xi], Mon(stop)));
    assert_trace(sim.trace(), &want);
    assert_eq!(
        (sim.monitors().fired(warn), sim.monitors().fired(stop)),
        (1, 1)
    );
}

/// §1.7.3 1. nothing with an exception sequence: the owner goes on once the exception
/// sequence ended; its exit condition, true meanwhile, ends it at its next poll.
/// X polls every 5 ms; the monitor fires at 5 ms, E runs 5–7 ms, X's exit condition is true
/// from 6 ms.
#[test]
fn after_nothing_s_exception_sequence_the_owner_s_exit_condition_is_checked_at_its_next_poll() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(
            SeqConfig::new("X").polling(millis(5)),
            Node::of(vec![]).until(1),
        )
        .unwrap();
    let xi = x.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::Nothing).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 3);
        c.set(1, ms(t) >= 6);
        c.set(2, ms(t) >= 7);
    });
    sim.start(xi).unwrap();
    sim.run_for(millis(20));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(5, ei, Idle, Running, Mon(m)),
            tr(7, ei, Running, Terminated, Completed),
            tr(10, xi, Running, Terminated, Completed),
        ],
    );
}

/// §1.7: monitors watch "permanent"; paused is one of the states. A paused owner's
/// abortOwner monitor starts its exception sequence, and the owner (paused) is aborted
/// when it ended.
#[test]
fn an_abort_owner_monitor_fires_on_a_paused_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let x = seq
        .add(SeqConfig::new("X"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let xi = x.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            xi,
            Monitor::new("m", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(x);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) >= 5);
        c.set(2, ms(t) >= 7);
    });
    sim.start(xi).unwrap();
    sim.run_for(millis(2));
    sim.pause(xi).unwrap();
    sim.run_for(millis(10));
    assert_trace(
        sim.trace(),
        &[
            tr(0, xi, Idle, Running, Start),
            tr(0, si, Idle, Running, Start),
            tr(3, xi, Running, Paused, Cause::Pause),
            tr(3, si, Running, Paused, Cause::Pause),
            tr(5, ei, Idle, Running, Mon(m)),
            tr(7, ei, Running, Terminated, Completed),
            tr(8, si, Paused, Aborting, Mon(m)),
            tr(8, si, Aborting, Aborted, Mon(m)),
            tr(8, xi, Paused, Aborting, Mon(m)),
            tr(8, xi, Aborting, Aborted, Mon(m)),
        ],
    );
    assert!(sim.handle(xi).unwrap().exception_is_active());
}

/// §1.3.1 exceptionIsActive with restartCallerofOwner: while the exception sequence runs,
/// rtseq marks the owner (held) and not yet the caller it will restart; the restart names
/// the monitor as the caller's active exception, and its new round begins without it.
#[test]
fn exception_is_active_while_a_caller_behaviour_waits_for_its_exception_sequence() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::RestartCallerOfOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.lane(e);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 3);
        c.set(2, ms(t) >= 6);
    });
    sim.start(ai).unwrap();
    sim.run_for(millis(4));
    let (hs, ha) = (sim.handle(si).unwrap(), sim.handle(ai).unwrap());
    assert_eq!(
        (hs.exception_is_active(), ha.exception_is_active()),
        (true, false),
        "owner marked, caller not"
    );
    assert_eq!(sim.state(ei), Running);
    assert_eq!(ha.active_exception(), None);
    sim.run_for(millis(4));
    assert_eq!((sim.state(ei), sim.state(ai)), (Terminated, Running));
    let ha = sim.handle(ai).unwrap();
    assert_eq!(
        (ha.exception_is_active(), ha.active_exception()),
        (false, Some(Mon(m)))
    );
}

fn hook_o(c: &Ctrl) {
    c.hooks.borrow_mut().push("O");
}
fn hook_s(c: &Ctrl) {
    c.hooks.borrow_mut().push("S");
}

/// §1.7.3 3. restartOwner: "Die Besitzer-Sequenz wird abgebrochen und neu gestartet."
/// "abgebrochen": the owner's cleanup hook runs (`SeqConfig::on_abort`: "while the
/// sequence is Aborting (or restarting)"), after its step's (innermost first), once, in
/// the restart's tick; and its action runs again from the start.
#[test]
fn restart_owner_runs_the_cleanup_hooks_of_the_step_and_of_the_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq
        .add(SeqConfig::new("S").on_abort(hook_s), Leaf::until(1))
        .unwrap();
    let si = s.id();
    let o = seq
        .add(
            SeqConfig::new("O").on_abort(hook_o),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let oi = o.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(oi, Monitor::new("m", &mut c0, Behaviour::RestartOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(o);
    sim.before_tick(|t, c| {
        c.set(0, ms(t) == 4);
        c.set(1, ms(t) >= 9);
    });
    sim.start(oi).unwrap();
    sim.run_for(millis(4));
    assert_eq!(*ctrl.hooks.borrow(), ["S", "O"]);
    sim.run_for(millis(10));
    assert_eq!(*ctrl.hooks.borrow(), ["S", "O"]);
    let mut want = vec![
        tr(0, oi, Idle, Running, Start),
        tr(0, si, Idle, Running, Start),
    ];
    want.extend(aborted(4, &[si], Mon(m)));
    want.extend([
        tr(4, oi, Running, Restarting, Mon(m)),
        tr(4, oi, Restarting, Running, Restart),
        tr(4, si, Aborted, Running, Start),
        tr(9, si, Running, Terminated, Completed),
        tr(9, oi, Running, Terminated, Completed),
    ]);
    assert_trace(sim.trace(), &want);
}

/// §1.2, 5 "Wenn der RunningState = restarting, dann wird die Sequenz wiederholt" with
/// §1.7.4 (every sequence's timeout monitor): a caller restarted by its step's
/// restartCallerofOwner monitor repeats with a fresh timeout. A's timeout is 10 ms; S's
/// monitor restarts A at 6 ms; A's timeout then runs out at 16 ms, not 10 ms.
#[test]
fn a_caller_restarted_by_its_child_s_monitor_gets_a_fresh_timeout() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(
            SeqConfig::new("A").timeout(millis(10)),
            Node::of(vec![Op::Step(s)]),
        )
        .unwrap();
    let ai = a.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::RestartCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(0, ms(t) == 6));
    sim.start(ai).unwrap();
    sim.run_for(millis(30));
    let mut want = vec![
        tr(0, ai, Idle, Running, Start),
        tr(0, si, Idle, Running, Start),
    ];
    want.extend(aborted(6, &[si], Mon(m)));
    want.extend([
        tr(6, ai, Running, Restarting, Mon(m)),
        tr(6, ai, Restarting, Running, Restart),
        tr(6, si, Aborted, Running, Start),
    ]);
    want.extend(aborted(16, &[si, ai], Timeout(ai)));
    assert_trace(sim.trace(), &want);
}

/// §1.7 monitors of a step run blocking by a paused caller stay active ("permanent
/// überwachen"): the step's abortOwner monitor aborts the (paused) step; the caller stays
/// paused, and after its resume its action receives the abort and goes on.
#[test]
fn a_blocking_child_s_monitor_aborts_it_while_its_caller_is_paused() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    let m = monitors
        .add(si, Monitor::new("m", &mut c0, Behaviour::AbortOwner))
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.before_tick(|t, c| c.set(0, ms(t) == 5));
    sim.start(ai).unwrap();
    sim.run_for(millis(2));
    sim.pause(ai).unwrap();
    sim.run_for(millis(6));
    assert_eq!(sim.state(ai), Paused);
    sim.resume(ai).unwrap();
    sim.run_for(millis(5));
    let mut want = vec![
        tr(0, ai, Idle, Running, Start),
        tr(0, si, Idle, Running, Start),
        tr(3, ai, Running, Paused, Cause::Pause),
        tr(3, si, Running, Paused, Cause::Pause),
        tr(5, si, Paused, Aborting, Mon(m)),
        tr(5, si, Aborting, Aborted, Mon(m)),
        tr(9, ai, Paused, Running, Cause::Resume),
        tr(9, ai, Running, Terminated, Completed),
    ];
    want.dedup();
    assert_trace(sim.trace(), &want);
    assert_eq!(
        returned_to(&ctrl, ai),
        [(9, 0, Err(Failure::Aborted(Mon(m))))]
    );
}

/// §1.7.2: the exception sequence runs for its owner: rtseq makes the owner its caller
/// (semantics.md item 3: "runs in its lane with the owner as its caller").
#[test]
fn the_exception_sequence_s_caller_is_the_monitor_s_owner() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let s = seq.add(SeqConfig::new("S"), Leaf::until(15)).unwrap();
    let si = s.id();
    let a = seq
        .add(SeqConfig::new("A"), Node::of(vec![Op::Step(s)]))
        .unwrap();
    let ai = a.id();
    let e = seq
        .add(SeqConfig::new("E"), Node::of(vec![]).until(2))
        .unwrap();
    let ei = e.id();
    let mut c0 = |c: &Ctrl, _| c.flag(0);
    let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
    monitors
        .add(
            si,
            Monitor::new("m", &mut c0, Behaviour::AbortOwner).exception(ei),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    sim.lane(a);
    sim.lane(e);
    sim.before_tick(|t, c| c.set(0, ms(t) == 3));
    sim.start(ai).unwrap();
    sim.run_for(millis(4));
    let h = sim.handle(ei).unwrap();
    assert_eq!(h.caller(), Some(si));
    assert_eq!(h.caller_stack().as_slice(), &[ai, si]);
    assert!(h.caller_stack_blocking().is_empty());
}

/// §1.7.3: "Das Behavior definiert das Verhalten nachdem die Exception Sequence gestartet
/// wurde." rtseq applies it once the exception sequence has *ended*, at the next tick
/// (semantics.md item 3; EEROS starts it blocking, so its behaviour too comes after the
/// end). Even an exception sequence that ends at once delays an abortOwner by one tick:
/// without one, X is aborted in the firing tick (5 ms); with one, at 6 ms.
#[test]
fn an_exception_sequence_delays_the_behaviour_by_one_tick_after_its_end() {
    for with_exception in [false, true] {
        let seq: Sequencer<Ctrl, 4> = Sequencer::new();
        let ctrl = Ctrl::default();
        let x = seq
            .add(
                SeqConfig::new("X").polling(millis(5)),
                Node::of(vec![]).until(15),
            )
            .unwrap();
        let xi = x.id();
        let e = seq.add(SeqConfig::new("E"), Node::of(vec![])).unwrap();
        let ei = e.id();
        let mut c0 = |c: &Ctrl, _| c.flag(0);
        let mut monitors: Monitors<Ctrl, 1> = Monitors::new();
        let mut def = Monitor::new("m", &mut c0, Behaviour::AbortOwner);
        if with_exception {
            def = def.exception(ei);
        }
        let m = monitors.add(xi, def).unwrap();
        let mut sim = Sim::new(&seq, &ctrl, monitors);
        sim.lane(x);
        sim.lane(e);
        sim.before_tick(|t, c| c.set(0, ms(t) >= 4));
        sim.start(xi).unwrap();
        sim.run_for(millis(20));
        let mut want = vec![tr(0, xi, Idle, Running, Start)];
        if with_exception {
            want.push(tr(5, ei, Idle, Running, Mon(m)));
            want.push(tr(5, ei, Running, Terminated, Completed));
            want.extend(aborted(6, &[xi], Mon(m)));
        } else {
            want.extend(aborted(5, &[xi], Mon(m)));
        }
        assert_trace(sim.trace(), &want);
    }
}

/// §1.7.4 with the Behaviour rustdoc ("the owner itself for a main sequence"): a main
/// sequence's timeout with restartCallerofOwner restarts the main sequence itself, with a
/// fresh timeout each round, until the limit (here 1) escalates it to the abort.
#[test]
fn a_main_sequence_s_timeout_with_restart_caller_of_owner_restarts_itself() {
    let seq: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let x = seq
        .add(
            SeqConfig::new("X")
                .timeout(millis(3))
                .timeout_behaviour(Behaviour::RestartCallerOfOwner)
                .timeout_restart_limit(1),
            Node::of(vec![]).until(15),
        )
        .unwrap();
    let xi = x.id();
    let mut sim = Sim::new(&seq, &ctrl, Monitors::<Ctrl, 1>::new());
    sim.lane(x);
    sim.start(xi).unwrap();
    sim.run_for(millis(20));
    let mut want = vec![
        tr(0, xi, Idle, Running, Start),
        tr(3, xi, Running, Restarting, Timeout(xi)),
        tr(3, xi, Restarting, Running, Restart),
    ];
    want.extend(aborted(6, &[xi], Timeout(xi)));
    assert_trace(sim.trace(), &want);
}
