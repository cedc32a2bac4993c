//! Review of the configuration API from a firmware engineer's point of view, black-box:
//! what a user gets wrong when declaring the tree, and whether rtseq answers with an `Err`
//! (or a compile error) that says what to fix, at the earliest moment, rather than a panic,
//! a hang or a silent acceptance that misbehaves later.
//!
//! Tests marked `// DEFECT:` and `#[ignore = "defect: ..."]` assert the behaviour rtseq
//! should have; they fail today (none is left: the seven the review found are fixed or,
//! where the behaviour is meant, documented and pinned).

use core::cell::Cell;
use rtseq::lock::CriticalSection;
use rtseq::sim::{Sim, SimError};
use rtseq::{
    Behaviour, Cause, ConditionFn, ConfigError, Cx, Duration, Entry, Error, Event, Failure,
    Instant, Monitor, MonitorId, MonitorNames, Monitors, Raiser, Record, RunningState,
    RunningState::*, Seq, SeqConfig, SeqId, Sequence, Sequencer, Table, TableError, Transition,
};

/// Runs until it is stopped.
struct Forever;
impl<C> Sequence<C> for Forever {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.wait_until(|_| false).await;
        Ok(())
    }
}

/// Runs its child blocking and hands its failure on.
struct Runs(Seq<Forever>);
impl<C> Sequence<C> for Runs {
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        cx.run(&mut self.0).await?;
        Ok(())
    }
}

/// Logs the time of every poll of its wait.
struct Polled;
impl Sequence<Cell<Vec<u64>>> for Polled {
    async fn action(&mut self, cx: &Cx<'_, Cell<Vec<u64>>>) -> Result<(), Failure> {
        cx.wait_until(|c| {
            let log = c.control();
            let mut v = log.take();
            v.push(c.now().as_ticks());
            log.set(v);
            false
        })
        .await;
        Ok(())
    }
}

fn id(i: usize) -> SeqId {
    SeqId::from_index(i)
}

fn tr(ms: u64, seq: SeqId, from: RunningState, to: RunningState, cause: Cause) -> Transition {
    Transition::at_millis(ms, seq, from, to, cause)
}

fn transition(ms: u64, sequence: SeqId, from: RunningState, to: RunningState, c: Cause) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1_000),
        entry: Entry::Transition {
            sequence,
            from,
            to,
            cause: c,
        },
    }
}

fn event(ms: u64, e: Event) -> Record {
    Record {
        time: Instant::from_ticks(ms * 1_000),
        entry: Entry::Event(e),
    }
}

fn drained<C, const N: usize>(seq: &Sequencer<C, N>) -> Vec<Record> {
    let mut records = Vec::new();
    seq.drain_records(|r| records.push(r));
    records
}

fn never(_: &(), _: Instant) -> bool {
    false
}

fn always(_: &(), _: Instant) -> bool {
    true
}

// ---------------------------------------------------------------------------------------
// Exception sequences: cycles, the owner's caller, a `…CallerOfOwner` on one.

/// A's timeout exception is B, B's is C, C's is A. `validate` accepts it (EEROS does too);
/// at run time the third exception cannot start (A runs, held) and is counted, and the
/// chain unwinds one tick per level, without a hang.
#[test]
fn a_cycle_of_three_timeout_exceptions_is_accepted_and_unwinds_without_a_hang() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let (a, b, c) = (id(0), id(1), id(2));
    let t = Duration::from_millis(3);
    let sa = seq.add(SeqConfig::new("a").timeout(t).timeout_exception(b), Forever);
    let sb = seq.add(SeqConfig::new("b").timeout(t).timeout_exception(c), Forever);
    let sc = seq.add(SeqConfig::new("c").timeout(t).timeout_exception(a), Forever);
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(sa.unwrap());
    sim.lane(sb.unwrap());
    sim.lane(sc.unwrap());
    assert_eq!(seq.validate(sim.monitors()), Ok(()));
    sim.start(a).unwrap();
    let idle = sim.run_until_idle(Duration::from_millis(100));
    assert_eq!(idle, Some(Instant::from_ticks(11_000)));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, a, Idle, Running, Cause::Start),
            tr(3, b, Idle, Running, Cause::Timeout(a)),
            tr(6, c, Idle, Running, Cause::Timeout(b)),
            tr(9, c, Running, Aborting, Cause::Timeout(c)),
            tr(9, c, Aborting, Aborted, Cause::Timeout(c)),
            tr(10, b, Running, Aborting, Cause::Timeout(b)),
            tr(10, b, Aborting, Aborted, Cause::Timeout(b)),
            tr(11, a, Running, Aborting, Cause::Timeout(a)),
            tr(11, a, Aborting, Aborted, Cause::Timeout(a)),
        ]
    );
    assert_eq!(seq.exceptions_not_run(), 1);
    let not_run = event(
        9,
        Event::ExceptionNotRun {
            exception: a,
            owner: c,
            why: Error::AlreadyRunning(a),
        },
    );
    assert!(sim.records().contains(&not_run), "{:?}", sim.records());
}

/// A step's monitor names the step's blocking caller as its exception sequence: no check
/// can see that before it fires (the tree is in the code); at the firing the caller runs,
/// so the exception is not run, recorded as a warning, and the behaviour is applied at once.
#[test]
fn a_monitor_whose_exception_sequence_is_its_owners_caller_is_warned_at_fire_time() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let child = seq.add(SeqConfig::new("child"), Forever).unwrap();
    let c = child.id();
    let main = seq.add(SeqConfig::new("main"), Runs(child)).unwrap();
    let m = main.id();
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut monitors = Monitors::<(), 1>::new();
    let jam = monitors
        .add(
            c,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(m),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    assert_eq!(sim.start(m), Ok(()));
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(2_000))
    );
    let fired = Cause::Monitor(jam);
    assert_eq!(
        sim.records(),
        &[
            transition(0, m, Idle, Running, Cause::Start),
            transition(0, c, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: c,
                    cause: fired,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: m,
                    owner: c,
                    why: Error::AlreadyRunning(m)
                }
            ),
            transition(2, c, Running, Aborting, fired),
            transition(2, c, Aborting, Aborted, fired),
            transition(2, m, Running, Terminated, Cause::Failed),
            event(
                2,
                Event::Failed {
                    sequence: m,
                    failure: Failure::Aborted(fired)
                }
            ),
        ]
    );
}

/// The exception sequence runs with its owner as caller: an `AbortCallerOfOwner` monitor of
/// the safe stop aborts the owner it serves, innermost (the safe stop) first.
#[test]
fn abort_caller_of_owner_on_an_exception_sequence_aborts_the_owner_it_serves() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("stop"), Forever).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let (s, m) = (stop.id(), main.id());
    let mut f1 = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut f2 = |_: &(), t: Instant| t.as_ticks() >= 4_000;
    let mut monitors = Monitors::<(), 2>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut f1, Behaviour::Nothing).exception(s),
        )
        .unwrap();
    let hung = monitors
        .add(
            s,
            Monitor::new("hung", &mut f2, Behaviour::AbortCallerOfOwner),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.lane(stop);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(4_000))
    );
    let h = Cause::Monitor(hung);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Cause::Start),
            tr(2, s, Idle, Running, Cause::Monitor(jam)),
            tr(4, s, Running, Aborting, h),
            tr(4, s, Aborting, Aborted, h),
            tr(4, m, Running, Aborting, h),
            tr(4, m, Aborting, Aborted, h),
        ]
    );
}

/// `RestartCallerOfOwner` with a restart limit of 0 on a blocking child: the first firing
/// escalates to `AbortCallerOfOwner` and aborts the caller (and the child with it).
#[test]
fn restart_caller_of_owner_with_limit_zero_on_a_child_aborts_the_caller_at_once() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let child = seq.add(SeqConfig::new("child"), Forever).unwrap();
    let c = child.id();
    let main = seq.add(SeqConfig::new("main"), Runs(child)).unwrap();
    let m = main.id();
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut monitors = Monitors::<(), 1>::new();
    let stall = monitors
        .add(
            c,
            Monitor::new("stall", &mut fault, Behaviour::RestartCallerOfOwner).restart_limit(0),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(50)),
        Some(Instant::from_ticks(2_000))
    );
    let k = Cause::Monitor(stall);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Cause::Start),
            tr(0, c, Idle, Running, Cause::Start),
            tr(2, c, Running, Aborting, k),
            tr(2, c, Aborting, Aborted, k),
            tr(2, m, Running, Aborting, k),
            tr(2, m, Aborting, Aborted, k),
        ]
    );
    assert_eq!(
        sim.handle(m).unwrap().last_outcome(),
        Some(rtseq::Outcome::Aborted(k))
    );
}

/// Registered by hand and ticked by hand without `validate` (on the chip): a timeout
/// exception id that was never registered does not panic; the firing records a warning
/// naming the reason and the behaviour is applied at once.
#[test]
fn an_unregistered_exception_id_is_warned_at_fire_time_when_validate_is_skipped() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let ghost = id(200);
    let a = seq
        .register(
            SeqConfig::new("a")
                .timeout(Duration::from_millis(2))
                .timeout_exception(ghost),
        )
        .unwrap();
    let h = seq.sequence_by_id(a).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap();
    let mut monitors: Monitors<(), 1> = Monitors::new();
    for ms in 1..=3 {
        assert_eq!(
            seq.tick(Instant::from_ticks(ms * 1_000), &(), &mut monitors),
            Ok(())
        );
    }
    assert_eq!(h.state(), Aborted);
    assert_eq!(seq.exceptions_not_run(), 1);
    let t = Cause::Timeout(a);
    assert_eq!(
        drained(&seq),
        [
            transition(0, a, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: a,
                    cause: t,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: ghost,
                    owner: a,
                    why: Error::UnknownSequence(ghost)
                }
            ),
            transition(2, a, Running, Aborting, t),
            transition(2, a, Aborting, Aborted, t),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// Monitors on unregistered or out-of-range ids; tables built for another sequencer size.

/// A monitor table written for a 64-sequence firmware (owner 40) checked against a
/// sequencer of 16: `validate` names the monitor and the owner, and the simulator's first
/// start refuses it.
#[test]
fn a_monitor_on_an_id_beyond_the_sequencer_is_refused_by_validate() {
    let seq: Sequencer<(), 16> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    let mut cond = never;
    let mut monitors: Monitors<(), 1> = Monitors::new();
    let ghost = monitors
        .add(
            id(40),
            Monitor::new("ghost", &mut cond, Behaviour::AbortOwner),
        )
        .unwrap();
    let want = ConfigError::UnknownOwner {
        monitor: (ghost, "ghost"),
        owner: id(40),
    };
    assert_eq!(seq.validate(&monitors), Err(want));
    assert_eq!(
        want.to_string(),
        "monitor `ghost` is owned by sequence 40, which is not registered"
    );
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    assert_eq!(sim.start(m), Err(Error::InvalidConfig));
    assert_eq!(sim.state(m), Idle);
}

/// Without `validate` (ticked by hand), a monitor owned by id 40 in a sequencer of 16 (one
/// word of sets) would read as owned by sequence 8 (40 mod 32), which is running: its
/// condition asked at every poll of 8, with its side effects (a debounce counts). The
/// table is refused as another sequencer's, and the condition never runs.
#[test]
fn a_monitor_on_an_id_beyond_a_one_word_sequencer_is_never_evaluated() {
    let seq: Sequencer<Cell<u32>, 16> = Sequencer::new();
    for name in ["s0", "s1", "s2", "s3", "s4", "s5", "s6", "s7", "s8"] {
        seq.register(SeqConfig::new(name)).unwrap();
    }
    let s8 = seq.sequence_by_id(id(8)).unwrap();
    s8.declare_lane().unwrap();
    s8.start().unwrap();
    let mut counting = |calls: &Cell<u32>, _: Instant| {
        calls.set(calls.get() + 1);
        true
    };
    let mut monitors: Monitors<Cell<u32>, 1> = Monitors::new();
    let ghost = monitors
        .add(
            id(40),
            Monitor::new("ghost", &mut counting, Behaviour::AbortOwner),
        )
        .unwrap();
    let calls = Cell::new(0);
    for ms in 1..=5 {
        // Not this sequencer's table: its owner is no id of a sequencer of one word.
        assert_eq!(
            seq.tick(Instant::from_ticks(ms * 1_000), &calls, &mut monitors),
            Err(Error::ForeignMonitorTable)
        );
    }
    assert_eq!(monitors.fired(ghost), 0);
    assert_eq!(s8.state(), Running);
    assert_eq!(
        calls.get(),
        0,
        "the condition of an owner that does not exist ran"
    );
}

rtseq::sequences! {
    /// A small tree: 3 sequences.
    mod small for () {
        S_MAIN = SeqConfig::new("main"),
        S_STOP = SeqConfig::new("stop").in_lane(),
        S_AUX = SeqConfig::new("aux"),
    }
}

rtseq::monitors! {
    /// Monitors written for a bigger tree: owner 5.
    mod big_monitors for (), ConditionFn<()> {
        FAR = Monitor::with_fn("far", never, Behaviour::AbortOwner)
            .exception(small::S_STOP)
            .owned_by(SeqId::from_index(5)),
    }
}

/// The compiler's check of a monitor table written for a bigger tree: the owner is not an
/// entry of the sequence table, an `Err` (a compile error in a `const` item) naming both.
#[test]
fn a_monitor_table_for_a_bigger_tree_fails_the_compile_time_check() {
    const CHECK: Result<(), ConfigError> = match small::table() {
        Ok(t) => big_monitors::validate(&t),
        Err(_) => Ok(()),
    };
    let want = ConfigError::UnknownOwner {
        monitor: (big_monitors::FAR, "far"),
        owner: id(5),
    };
    assert_eq!(CHECK, Err(want));
    const MESSAGE: Option<rtseq::ErrorMessage> = match CHECK {
        Err(e) => Some(e.message()),
        Ok(()) => None,
    };
    assert_eq!(
        MESSAGE.map(|m| m.as_str().to_owned()),
        Some("monitor `far` is owned by sequence 5, which is not registered".to_owned())
    );
}

// ---------------------------------------------------------------------------------------
// Capacities.

#[test]
fn zero_capacities_refuse_the_first_entry() {
    let mut cond = never;
    let mut monitors: Monitors<(), 0> = Monitors::new();
    assert_eq!(
        monitors.add(id(0), Monitor::new("a", &mut cond, Behaviour::Nothing)),
        Err(Error::MonitorCapacityExceeded)
    );
    assert!(monitors.is_empty());
    let seq: Sequencer<(), 0> = Sequencer::new();
    assert_eq!(
        seq.register(SeqConfig::new("a")),
        Err(Error::SequenceCapacityExceeded)
    );
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.step();
    assert_eq!(sim.start(id(0)), Err(Error::UnknownSequence(id(0))));
    assert_eq!(
        Error::MonitorCapacityExceeded.to_string(),
        "monitor capacity exceeded"
    );
}

/// A lane given to the simulator when all `W` lane slots are taken never runs. The
/// simulator's first start (`check_lanes`) names it with the capacity, and so does a
/// start of its sequence: the error says what to fix.
#[test]
fn a_lane_beyond_the_lane_slots_is_an_error_naming_the_capacity() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let (ia, ib) = (a.id(), b.id());
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(a);
    sim.lane(b);
    assert_eq!(sim.start(ia), Err(Error::LaneCapacityExceeded(ib)));
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(ib)));
    assert_eq!(seq.sequence_by_id(ia).unwrap().start(), Ok(()));
    assert_eq!(
        seq.sequence_by_id(ib).unwrap().start(),
        Err(Error::LaneCapacityExceeded(ib))
    );
    assert_eq!(
        Error::LaneCapacityExceeded(ib).to_string(),
        "no lane slot left for sequence 1"
    );
}

/// A refused lane is named until its own lane future is dropped, and no other drop forgets
/// it: a firmware engineer who removes the extra lane task sees the error go, and one who
/// stops another lane still sees the shortage of slots named, not that other lane.
#[test]
fn a_refusal_is_forgotten_with_its_own_lane_future_and_no_other() {
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    let mut a = seq.add(SeqConfig::new("a"), Forever).unwrap();
    let mut b = seq.add(SeqConfig::new("b"), Forever).unwrap();
    let (ia, ib) = (a.id(), b.id());
    let mut a_lane = Box::pin(rtseq::lane(&seq, &(), &mut a));
    poll_once(a_lane.as_mut());
    {
        // The only slot is `a`'s: `b`'s lane is refused, then dropped.
        let mut b_lane = Box::pin(rtseq::lane(&seq, &(), &mut b));
        poll_once(b_lane.as_mut());
        assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(ib)));
    }
    assert_eq!(seq.check_lanes(), Ok(()));
    // Refused again; then `a`'s lane is dropped: the refusal is still the first thing named.
    let mut b_lane = Box::pin(rtseq::lane(&seq, &(), &mut b));
    poll_once(b_lane.as_mut());
    drop(a_lane);
    assert_eq!(seq.check_lanes(), Err(Error::LaneCapacityExceeded(ib)));
    assert_eq!(
        seq.sequence_by_id(ia).unwrap().start(),
        Err(Error::NoLane(ia))
    );
    drop(b_lane);
    assert_eq!(seq.check_lanes(), Err(Error::NoLane(ia)));
}

/// Polls a lane future once, as its task's first run does (a lane never ends).
fn poll_once(
    lane: core::pin::Pin<&mut dyn core::future::Future<Output = core::convert::Infallible>>,
) {
    let waker = core::task::Waker::noop();
    assert!(lane
        .poll(&mut core::task::Context::from_waker(waker))
        .is_pending());
}

// ---------------------------------------------------------------------------------------
// Names.

rtseq::monitors! {
    /// Two lines with the same name (a copy-paste of a line).
    mod twice for (), ConditionFn<()> {
        FIRST = Monitor::with_fn("jam", never, Behaviour::AbortOwner).owned_by(small::S_MAIN),
        SECOND = Monitor::with_fn("jam", never, Behaviour::RestartOwner).owned_by(small::S_AUX),
    }
}

/// Sequences refuse a duplicate name (`DuplicateName`: a name looks a sequence up);
/// monitors need not have unique names (`Monitors::add`: a firing's record names its owner
/// too, "monitor `jam` of `main`"), so a copy-pasted line is taken as it is.
#[test]
fn duplicate_monitor_names_are_accepted() {
    assert_eq!(twice::names(), MonitorNames(["jam", "jam"]));
    let table: Monitors<'static, (), 2, ConditionFn<()>> = twice::table().unwrap();
    assert_eq!(table.name(twice::FIRST), table.name(twice::SECOND));
    assert_eq!(small::table().map(|t| twice::validate(&t)), Ok(Ok(())));
}

/// A `Table` installed, then sequences registered by hand: the names are checked across
/// both, the lanes follow the table's, and the table cannot be installed again or into a
/// sequencer that has registrations.
#[test]
fn a_table_and_registrations_mixed() {
    static TABLE: Table<(), 2> =
        match Table::new([SeqConfig::new("a").in_lane(), SeqConfig::new("b")]) {
            Ok(t) => t,
            Err(e) => panic!("{}", e.message().as_str()),
        };
    let seq: Sequencer<(), 4, 64, CriticalSection, 1> = Sequencer::new();
    seq.install(&TABLE).unwrap();
    let dup = seq.register(SeqConfig::new("b"));
    assert_eq!(dup, Err(Error::DuplicateName(id(1))));
    assert_eq!(
        dup.unwrap_err().to_string(),
        "duplicate name: sequence 1 has it"
    );
    // The table's lane took the only slot.
    assert_eq!(
        seq.register(SeqConfig::new("c").in_lane()),
        Err(Error::LaneCapacityExceeded(id(2)))
    );
    assert_eq!(seq.register(SeqConfig::new("c")), Ok(id(2)));
    let again = seq.install(&TABLE);
    assert_eq!(again, Err(Error::NotEmpty));
    assert_eq!(
        again.unwrap_err().to_string(),
        "a table needs an empty sequencer"
    );
    assert_eq!(seq.len(), 3);
    assert_eq!(
        seq.bind(id(3), ()).err(),
        Some(Error::UnknownSequence(id(3)))
    );
    let other: Sequencer<(), 4> = Sequencer::new();
    other.register(SeqConfig::new("x")).unwrap();
    assert_eq!(other.install(&TABLE), Err(Error::NotEmpty));
    assert_eq!(other.len(), 1);
    assert!(other.sequence_by_name("a").is_none());
}

// ---------------------------------------------------------------------------------------
// Durations: zero, tiny against the polling period, the simulator's period.

#[test]
fn zero_durations_are_refused_wherever_they_are_given() {
    let zero = Duration::from_ticks(0);
    let seq: Sequencer<(), 4> = Sequencer::new();
    assert_eq!(
        seq.register(SeqConfig::new("p").polling(zero)),
        Err(Error::DurationOutOfRange)
    );
    assert_eq!(
        Table::<(), 1>::new([SeqConfig::new("t").timeout(zero)])
            .err()
            .map(|e| e.error),
        Some(Error::DurationOutOfRange)
    );
    let a = seq.register(SeqConfig::new("a")).unwrap();
    let h = seq.sequence_by_id(a).unwrap();
    assert_eq!(h.set_timeout(Some(zero)), Err(Error::DurationOutOfRange));
    assert_eq!(
        Error::DurationOutOfRange.to_string(),
        "duration is zero or too long"
    );
    let sim = Sim::new(&seq, &(), Monitors::<(), 1>::new()).with_period(zero);
    let e = sim.err();
    assert_eq!(e, Some(SimError::ZeroPeriod));
    assert_eq!(
        e.map(|e| e.to_string()),
        Some("the tick period must be longer than 0".to_owned())
    );
}

/// A timeout of 1 µs under a polling period of 10 ms is accepted and fires at the first
/// poll (the timeout is evaluated at the owner's polling period).
#[test]
fn a_timeout_shorter_than_the_polling_period_fires_at_the_first_poll() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let cfg = SeqConfig::new("main")
        .polling(Duration::from_millis(10))
        .timeout(Duration::from_micros(1));
    let main = seq.add(cfg, Forever).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(30));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Cause::Start),
            tr(10, m, Running, Aborting, Cause::Timeout(m)),
            tr(10, m, Aborting, Aborted, Cause::Timeout(m)),
        ]
    );
}

/// A simulator ticking every 7 ms with a 3 ms timeout: the timeout fires at the first tick
/// after it ran out.
#[test]
fn a_simulator_period_longer_than_a_timeout_fires_it_at_the_next_tick() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq
        .add(
            SeqConfig::new("main").timeout(Duration::from_millis(3)),
            Forever,
        )
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new())
        .with_period(Duration::from_millis(7))
        .unwrap();
    sim.lane(main);
    assert_eq!(sim.start(id(3)), Err(Error::UnknownSequence(id(3))));
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(30));
    assert_eq!(
        sim.trace(),
        &[
            tr(0, m, Idle, Running, Cause::Start),
            tr(7, m, Running, Aborting, Cause::Timeout(m)),
            tr(7, m, Aborting, Aborted, Cause::Timeout(m)),
        ]
    );
    drop(sim);
    let late = Sim::new(&seq, &(), Monitors::<(), 1>::new()).starting_at(Instant::from_ticks(1));
    assert_eq!(late.err(), Some(SimError::StartBeforeSequencerTime));
}

/// A sequence with a new polling period registered after 5 ms of ticks: its class is new
/// and polls one period after its start, on its own grid.
#[test]
fn a_new_polling_period_registered_after_ticks_polls_on_its_own_grid() {
    let seq: Sequencer<Cell<Vec<u64>>, 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Polled).unwrap();
    let m = main.id();
    let log = Cell::new(Vec::new());
    let mut sim = Sim::new(&seq, &log, Monitors::<Cell<Vec<u64>>, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.run_for(Duration::from_millis(5));
    assert_eq!(log.take(), [0, 1_000, 2_000, 3_000, 4_000, 5_000]);
    sim.abort(m).unwrap();
    sim.step();
    let cfg = SeqConfig::new("late").polling(Duration::from_millis(3));
    let late = seq.add(cfg, Polled).unwrap();
    let l = late.id();
    sim.lane(late);
    sim.start(l).unwrap();
    sim.run_for(Duration::from_millis(10));
    assert_eq!(log.take(), [6_000, 9_000, 12_000, 15_000]);
}

// ---------------------------------------------------------------------------------------
// Error messages: what a compile error (a `const` item's panic) or a log line says.

/// `Table::new` (and `sequences!`'s `table()`, and `Monitors::table`) refuse a bad entry
/// with a message that says which (`TableError`): in a table of 30 lines the compiler
/// points at the `panic!` of the `match`, not at the line, so the message must.
#[test]
fn a_table_error_names_the_entry_it_refuses() {
    let ms = Duration::from_millis;
    let cases: [(Option<TableError>, &str, &str); 3] = [
        (
            Table::<(), 3>::new([
                SeqConfig::new("a"),
                SeqConfig::new("b"),
                SeqConfig::new("c").polling(Duration::from_ticks(0)),
            ])
            .err(),
            "`c`",
            "2",
        ),
        (
            Table::<(), 3>::new([SeqConfig::new("a"), SeqConfig::new(""), SeqConfig::new("c")])
                .err(),
            "",
            "1",
        ),
        (
            Table::<(), 2>::new([
                SeqConfig::new("a"),
                SeqConfig::new("b").timeout_behaviour(Behaviour::PauseOwner),
            ])
            .err(),
            "`b`",
            "1",
        ),
    ];
    // Names the entry: by its name, or by its position.
    let names_entry = |message: &str, name: &str, index: &str| {
        (!name.is_empty() && message.contains(name))
            || ["sequence ", "entry ", "line "]
                .iter()
                .any(|w| message.contains(&format!("{w}{index}")))
    };
    for (e, name, index) in cases {
        let e = e.expect("refused");
        let message = e.to_string();
        assert!(
            names_entry(&message, name, index),
            "{e:?}: `{message}` names neither {name} nor entry {index}"
        );
    }
    let periods = ["0", "1", "2", "3", "4", "5", "6", "7", "ninth"];
    let mut p = 0;
    let nine = periods.map(|n| {
        p += 1;
        SeqConfig::new(n).polling(ms(p))
    });
    let message = Table::<(), 9>::new(nine)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(
        names_entry(&message, "`ninth`", "8"),
        "`{message}` does not say which entry brought the ninth period"
    );
    let nameless: Result<Monitors<'static, (), 2, ConditionFn<()>>, _> = Monitors::table([
        Monitor::with_fn("ok", never, Behaviour::Nothing).owned_by(id(0)),
        Monitor::with_fn("", never, Behaviour::Nothing).owned_by(id(0)),
    ]);
    let message = nameless.map(|_| ()).expect_err("refused").to_string();
    assert!(
        message.contains("monitor 1") || message.contains("entry 1"),
        "`{message}` does not say which monitor"
    );
}

/// What a `const` item's compile error says for those errors (exact).
#[test]
fn table_errors_say_what_and_which() {
    const ZERO: Option<TableError> = match Table::<(), 2>::new([
        SeqConfig::new("a"),
        SeqConfig::new("b").polling(Duration::from_ticks(0)),
    ]) {
        Ok(_) => None,
        Err(e) => Some(e),
    };
    const ZERO_MESSAGE: Option<rtseq::ErrorMessage> = match ZERO {
        Some(e) => Some(e.message()),
        None => None,
    };
    assert_eq!(
        ZERO,
        Some(TableError {
            entry: 1,
            name: "b",
            error: Error::DurationOutOfRange
        })
    );
    assert_eq!(
        ZERO_MESSAGE.map(|m| m.as_str().to_owned()),
        Some("entry 1 (`b`): duration is zero or too long".to_owned())
    );
    let messages = [
        Table::<(), 1>::new([SeqConfig::new("")]).err(),
        Table::<(), 1>::new([SeqConfig::new("a").timeout_behaviour(Behaviour::PauseOwner)]).err(),
    ]
    .map(|e| e.map(|e| e.to_string()));
    assert_eq!(
        messages,
        [
            Some("entry 0: empty name".to_owned()),
            Some(
                "entry 0 (`a`): a timeout cannot pause its sequence (PauseOwner is a monitor behaviour)"
                    .to_owned()
            ),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// `sequences!` and `monitors!` with parameters.

rtseq::sequences! {
    /// Tuned at build time: the homing's polling period and its timeout's restart limit.
    /// The homing names the safe stop, declared on a later line.
    mod tuned(poll: Duration, limit: u8,) for () {
        HOMING = SeqConfig::new("homing")
            .polling(poll)
            .timeout(Duration::from_millis(50))
            .timeout_exception(STOP)
            .timeout_restart_limit(limit),
        STOP = SeqConfig::new("stop").in_lane(),
    }
}

rtseq::monitors! {
    mod tuned_monitors(limit: u8) for (), ConditionFn<()> {
        STUCK = Monitor::with_fn("stuck", always, Behaviour::RestartOwner)
            .restart_limit(limit)
            .owned_by(tuned::HOMING),
        QUIET = Monitor::with_fn("quiet", never, Behaviour::AbortOwner)
            .exception(tuned::STOP)
            .owned_by(tuned::HOMING),
    }
}

/// Parameters reach the tables: a zero polling period given as a parameter is the same
/// compile-time `Err`; a restart limit given as a parameter bounds the restarts.
#[test]
fn sequences_and_monitors_with_parameters_build_checked_tables() {
    const BAD: Option<TableError> = match tuned::table(Duration::from_ticks(0), 1) {
        Ok(_) => None,
        Err(e) => Some(e),
    };
    assert_eq!(BAD.map(|e| e.error), Some(Error::DurationOutOfRange));
    const GOOD: Table<(), { tuned::COUNT }> = match tuned::table(Duration::from_millis(2), 1) {
        Ok(t) => t,
        Err(e) => panic!("{}", e.message().as_str()),
    };
    const CHECKED: Result<(), ConfigError> = tuned_monitors::validate(&GOOD, 1);
    assert_eq!(CHECKED, Ok(()));
    assert_eq!(tuned_monitors::names(1), MonitorNames(["stuck", "quiet"]));
    let seq: tuned::Sequencer = tuned::Sequencer::new();
    seq.install(&GOOD).unwrap();
    let homing = seq.bind(tuned::HOMING, Forever).unwrap();
    let stop = seq.bind(tuned::STOP, Forever).unwrap();
    let monitors: Monitors<'static, (), 2, ConditionFn<()>> = tuned_monitors::table(1).unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(homing);
    sim.lane(stop);
    let h = tuned::HOMING;
    sim.start(h).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(40)),
        Some(Instant::from_ticks(4_000))
    );
    let stuck = Cause::Monitor(tuned_monitors::STUCK);
    assert_eq!(
        sim.trace(),
        &[
            tr(0, h, Idle, Running, Cause::Start),
            tr(2, h, Running, Restarting, stuck),
            tr(2, h, Restarting, Running, Cause::Restart),
            tr(4, h, Running, Aborting, stuck),
            tr(4, h, Aborting, Aborted, stuck),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// Timeouts configured half-way.

/// A timeout exception and behaviour without `.timeout(..)`: accepted by `register` and
/// `validate`, and the timeout never fires (unless `Handle::set_timeout` arms it). A
/// forgotten `.timeout(..)` on a safety timeout passes every check.
#[test]
fn a_timeout_exception_without_a_timeout_is_accepted_and_inert_until_set_timeout() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.add(SeqConfig::new("stop"), Forever).unwrap();
    let s = stop.id();
    let cfg = SeqConfig::new("main")
        .timeout_exception(s)
        .timeout_behaviour(Behaviour::AbortOwner);
    let main = seq.add(cfg, Forever).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.lane(stop);
    assert_eq!(seq.validate(sim.monitors()), Ok(()));
    sim.start(m).unwrap();
    sim.run_for(Duration::from_secs(1));
    assert_eq!(sim.trace(), &[tr(0, m, Idle, Running, Cause::Start)]);
    // Armed at run time, the configured exception and behaviour apply.
    sim.handle(m)
        .unwrap()
        .set_timeout(Some(Duration::from_millis(2)))
        .unwrap();
    sim.abort(m).unwrap();
    sim.step();
    sim.start(m).unwrap();
    let start = sim.now().as_ticks() / 1_000;
    sim.run_for(Duration::from_millis(5));
    let t = Cause::Timeout(m);
    assert!(sim.trace().contains(&tr(start + 2, s, Idle, Running, t)));
}

/// `Table::new` accepts it (it checks each entry and the ids; how entries relate is
/// `validate`'s, as its rustdoc says), and the table's `validate`, in a `const` too, names it.
#[test]
fn a_self_referencing_timeout_exception_is_found_by_the_table_s_validate() {
    const TABLE: Result<Table<(), 1>, TableError> = Table::new([SeqConfig::new("homing")
        .in_lane()
        .timeout(Duration::from_secs(1))
        .timeout_exception(SeqId::from_index(0))]);
    const CHECK: Result<(), ConfigError> = match &TABLE {
        Ok(t) => t.validate::<ConditionFn<()>>(&[]),
        Err(_) => Ok(()),
    };
    assert!(TABLE.is_ok());
    assert_eq!(
        CHECK,
        Err(ConfigError::ExceptionIsOwner {
            raiser: Raiser::Timeout(id(0), "homing")
        })
    );
}

// ---------------------------------------------------------------------------------------
// The checks before the first tick, and what escapes them.

/// The simulator validates at its first `start`, and again at a start after sequences or
/// monitors were added: a sequence registered (and given a lane) afterwards, whose timeout
/// exception has no lane, is refused at its start, as it would have been at the first.
#[test]
fn a_sequence_registered_after_the_simulators_first_start_is_checked_too() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    sim.step();
    let stop = seq.register(SeqConfig::new("stop")).unwrap();
    let cfg = SeqConfig::new("late")
        .timeout(Duration::from_millis(2))
        .timeout_exception(stop);
    let late = seq.add(cfg, Forever).unwrap();
    let l = late.id();
    sim.lane(late);
    assert_eq!(
        seq.validate(sim.monitors()),
        Err(ConfigError::ExceptionWithoutLane {
            raiser: Raiser::Timeout(l, "late"),
            exception: (stop, "stop"),
        })
    );
    assert_eq!(sim.start(l), Err(Error::InvalidConfig));
    assert_eq!(sim.state(l), Idle);
}

/// A start through a handle (`sim.handle(id).start()`, or a handle kept from before) is
/// not the simulator's `start`, which is the one that validates: a monitor's safe stop
/// without a lane is then found only when it fires (a warning record), as on a chip whose
/// firmware skipped `validate`.
#[test]
fn a_start_through_a_handle_skips_the_simulators_check_and_warns_at_fire_time() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let stop = seq.register(SeqConfig::new("stop")).unwrap();
    let main = seq.add(SeqConfig::new("main"), Forever).unwrap();
    let m = main.id();
    let mut fault = |_: &(), t: Instant| t.as_ticks() >= 2_000;
    let mut monitors = Monitors::<(), 1>::new();
    let jam = monitors
        .add(
            m,
            Monitor::new("jam", &mut fault, Behaviour::AbortOwner).exception(stop),
        )
        .unwrap();
    let mut sim = Sim::new(&seq, &(), monitors);
    sim.lane(main);
    assert_eq!(sim.handle(m).unwrap().start(), Ok(()));
    sim.run_for(Duration::from_millis(5));
    let j = Cause::Monitor(jam);
    assert_eq!(
        sim.records(),
        &[
            transition(0, m, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: m,
                    cause: j,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: stop,
                    owner: m,
                    why: Error::NoLane(stop)
                }
            ),
            transition(2, m, Running, Aborting, j),
            transition(2, m, Aborting, Aborted, j),
        ]
    );
    // The simulator's own start would have refused it, pointing at `validate`.
    assert_eq!(
        Error::InvalidConfig.to_string(),
        "invalid configuration (see Sequencer::validate)"
    );
}

/// A monitor added to the table after `validate` and after the first tick (the tick task
/// owns the table and may add): nothing checks it; its safe stop without a lane is found
/// when it fires (a warning), the behaviour applied at once.
#[test]
fn a_monitor_added_after_validation_is_not_checked_and_warns_at_fire_time() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let run = seq.register(SeqConfig::new("run")).unwrap();
    let stop = seq.register(SeqConfig::new("stop")).unwrap();
    let h = seq.sequence_by_id(run).unwrap();
    h.declare_lane().unwrap();
    let (mut quiet, mut fires) = (never, always);
    let mut monitors: Monitors<(), 2> = Monitors::new();
    monitors
        .add(run, Monitor::new("quiet", &mut quiet, Behaviour::Nothing))
        .unwrap();
    assert_eq!(seq.validate(&monitors), Ok(()));
    h.start().unwrap();
    assert_eq!(
        seq.tick(Instant::from_ticks(1_000), &(), &mut monitors),
        Ok(())
    );
    let late = monitors
        .add(
            run,
            Monitor::new("late", &mut fires, Behaviour::AbortOwner).exception(stop),
        )
        .unwrap();
    assert_eq!(
        seq.tick(Instant::from_ticks(2_000), &(), &mut monitors),
        Ok(())
    );
    let l = Cause::Monitor(late);
    assert_eq!(
        drained(&seq),
        [
            transition(0, run, Idle, Running, Cause::Start),
            event(
                2,
                Event::Fired {
                    owner: run,
                    cause: l,
                    behaviour: Behaviour::AbortOwner
                }
            ),
            event(
                2,
                Event::ExceptionNotRun {
                    exception: stop,
                    owner: run,
                    why: Error::NoLane(stop)
                }
            ),
            transition(2, run, Running, Aborting, l),
            transition(2, run, Aborting, Aborted, l),
        ]
    );
    assert_eq!(late, MonitorId::from_index(1));
}

/// A step declared `.in_lane()` by mistake and run blocking by its caller: its `Seq` is the
/// caller's, so no task can poll its lane. The simulator's first start refuses the tree
/// (good), with `NoLane(step)`, whose message says that no task polls its lane (not that
/// it has none: it was declared to have one).
#[test]
fn a_declared_lane_no_task_polls_is_reported_as_such() {
    let seq: Sequencer<(), 4> = Sequencer::new();
    let step = seq.add(SeqConfig::new("step").in_lane(), Forever).unwrap();
    let s = step.id();
    let main = seq.add(SeqConfig::new("main"), Runs(step)).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    let e = sim.start(m);
    assert_eq!(e, Err(Error::NoLane(s)));
    assert_eq!(
        e.unwrap_err().to_string(),
        "sequence 0 has no lane that a task polls"
    );
    assert_eq!(sim.state(m), Idle);
}
