//! `Condition::begin_run` against a lane above the tick that starts,
//! replaces or restarts the owner between two sections of the tick (portable lock), and
//! before each section of a lane's operation (both locks).

use super::*;

use std::sync::Mutex;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ev {
    B,
    V(u64),
}

type Log = &'static Mutex<Vec<Ev>>;

struct Counting {
    log: Log,
    flag: &'static AtomicBool,
}

impl Condition<()> for Counting {
    fn validate(&mut self, _: &(), now: Instant) -> bool {
        self.log.lock().unwrap().push(Ev::V(now.as_ticks() / 1000));
        self.flag.load(Ordering::Relaxed)
    }
    fn begin_run(&mut self) {
        self.log.lock().unwrap().push(Ev::B);
    }
}

impl<L: Lock + 'static, const N: usize, const B: usize> World<L, N, B> {
    /// A counting monitor of `owner` (behaviour `b`, true while `flag`); its log and cause.
    fn counting(&self, owner: SeqId, flag: &'static AtomicBool, b: Behaviour) -> (Log, Cause) {
        let log: Log = Box::leak(Box::new(Mutex::new(Vec::new())));
        let condition: &'static mut (dyn Condition<()> + Send) =
            Box::leak(Box::new(Counting { log, flag }));
        let id = self
            .monitors
            .borrow_mut()
            .add(owner, Monitor::new("count", condition, b))
            .unwrap();
        (log, Cause::Monitor(id))
    }
}

fn bs(log: &[Ev]) -> usize {
    log.iter().filter(|e| **e == Ev::B).count()
}

/// P keeps the 1 ms class busy; O (same class) has a counting `AbortOwner` monitor, false.
/// O's first run is evaluated at 1 and 2 ms; then its lane drops it and a handle starts it
/// again (`replace_run`) before section `k` of the tick at 3 ms. O's second run is told
/// once, right before its first evaluation (at 3 ms if the tick's scan saw it, else at
/// 4 ms), and never otherwise: the log is B V1 V2 [V3] B V.. with exactly two Bs, the
/// second directly before a V, every V after it of the new run.
fn replaced_during_the_tick<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        let o = w.seq("O");
        let (log, _) = w.counting(o, flag_of(false), Behaviour::AbortOwner);
        w.start_taken(p);
        w.start_taken(o);
        w.tick(1);
        w.tick(2);
        (w, o, log)
    };
    let count = sections(setup, |(w, _, _)| w.tick(3));
    every_k(count + 1, |k| {
        let (w, o, log) = setup();
        let what = name::<L>(
            layout,
            format_args!("replaced before section {k} of {count}"),
        );
        interleaved::at(k, move || w.replace_run(o));
        w.tick(3);
        or_after(k, || w.replace_run(o));
        for ms in 4..=6 {
            w.tick(ms);
        }
        let got = log.lock().unwrap().clone();
        assert_eq!(&got[..3], &[Ev::B, Ev::V(1), Ev::V(2)], "{what}: {got:?}");
        assert_eq!(bs(&got), 2, "{what}: {got:?}");
        let second = got.iter().rposition(|e| *e == Ev::B).unwrap();
        let after: Vec<Ev> = got[second + 1..].to_vec();
        assert!(after.len() >= 3, "{what}: {got:?}");
        assert_eq!(after.last(), Some(&Ev::V(6)), "{what}: {got:?}");
        assert!(
            matches!(after.first(), Some(Ev::V(3) | Ev::V(4))),
            "{what}: {got:?}"
        );
        assert_eq!(w.state(o), Running, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_during_the_tick_is_told_once_before_its_first_evaluation() {
    every_world!(replaced_during_the_tick);
}

/// The same with O's condition true from the replacement on: the new run is aborted by the
/// monitor exactly once (from "false": a rising edge at its first evaluation), told once
/// before that evaluation.
fn replaced_and_true<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        let o = w.seq("O");
        let flag = flag_of(false);
        let (log, cause) = w.counting(o, flag, Behaviour::AbortOwner);
        w.start_taken(p);
        w.start_taken(o);
        w.tick(1);
        w.tick(2);
        (w, o, log, cause, flag)
    };
    let count = sections(setup, |(w, ..)| w.tick(3));
    every_k(count + 1, |k| {
        let (w, o, log, cause, flag) = setup();
        let what = name::<L>(
            layout,
            format_args!("replaced before section {k} of {count}"),
        );
        let go = move || {
            w.replace_run(o);
            flag.store(true, Ordering::Relaxed);
        };
        interleaved::at(k, go);
        w.tick(3);
        or_after(k, go);
        for ms in 4..=6 {
            w.tick(ms);
        }
        let got = log.lock().unwrap().clone();
        assert_eq!(w.ended(o), (Aborted, cause), "{what}: {got:?}");
        assert_eq!(w.fired(o, cause), 1, "{what}: {got:?}");
        assert_eq!(bs(&got), 2, "{what}: {got:?}");
        let second = got.iter().rposition(|e| *e == Ev::B).unwrap();
        assert!(
            matches!(got.get(second + 1), Some(Ev::V(_))),
            "{what}: {got:?}"
        );
        w.check(&what);
    });
}

#[test]
fn a_run_replaced_during_the_tick_with_its_condition_true_fires_once() {
    every_world!(replaced_and_true);
}

/// O, restarted by its `RestartOwner` monitor at 1 ms (its condition then cleared), takes
/// the restart up (`Sequencer::restart`) while the tick at 2 ms runs (before each of its
/// sections, or after it). O's counting monitor: told once for the first run, once for
/// the round.
fn restart_taken_during_the_tick<L: Lock + 'static, const N: usize, const B: usize>(
    layout: Layout,
) {
    let setup = || {
        let w = World::<L, N, B>::new(layout);
        let p = w.seq("P");
        let o = w.seq("O");
        let fault = flag_of(true);
        w.monitor(o, fault, Behaviour::RestartOwner, None);
        let (log, _) = w.counting(o, flag_of(false), Behaviour::AbortOwner);
        w.start_taken(p);
        w.start_taken(o);
        w.tick(1);
        assert_eq!(w.state(o), Restarting);
        fault.store(false, Ordering::Relaxed);
        (w, o, log, w.run(o))
    };
    let count = sections(setup, |(w, ..)| w.tick(2));
    every_k(count + 1, |k| {
        let (w, o, log, run) = setup();
        let what = name::<L>(
            layout,
            format_args!("restart taken before section {k} of {count}"),
        );
        let take = move || w.seq.restart(run);
        interleaved::at(k, take);
        w.tick(2);
        or_after(k, take);
        for ms in 3..=5 {
            w.tick(ms);
        }
        let got = log.lock().unwrap().clone();
        assert_eq!(&got[..2], &[Ev::B, Ev::V(1)], "{what}: {got:?}");
        assert_eq!(bs(&got), 2, "{what}: {got:?}");
        assert_eq!(got[2], Ev::B, "{what}: {got:?}");
        assert_eq!(got.last(), Some(&Ev::V(5)), "{what}: {got:?}");
        assert_eq!(w.state(o), Running, "{what}");
        w.check(&what);
    });
}

#[test]
fn a_restart_taken_during_the_tick_is_told_once() {
    every_world!(restart_taken_during_the_tick);
}
