//! Random preemption of real lanes, under both locks, in sequencers of one word and of two
//! (the tree in the second word, or across both).
//!
//! A small tree runs in real lanes (`lane()`, polled by a scheduler written here): a main
//! sequence M runs a blocking child A twice, each time followed by a non-blocking child B
//! (its own lane) that M joins, the second time started scoped (`Cx::start_scoped`) and
//! joined through its `Scoped`, whose drop (M aborted or restarted meanwhile) asks for
//! B's abort; the second time, A's run races a `Cx::wait_until` of a
//! cancel flag in `embassy_futures::select`, which drops A's run when the flag wins. A runs
//! A2 blocking (handing A2's failure on, or not), which, when its pre-condition holds,
//! runs a dwell step W, may fail, and then polls its exit condition; so does A. B waits in
//! `Cx::wait_until`. A supervisor J, in a lane of its own, makes a request of A or M (a
//! pause, resume, abort or new timeout, through `Cx::sequence_by_id`), then joins B (a
//! second joiner beside M) and M. A and A2 have a monitor of a random behaviour each (with
//! the exception sequence E, its own lane, or without), A maybe a timeout; so has M (its
//! exception sequence E2); A's timeout has a random behaviour. The cleanup hooks of A and
//! A2 start J or B, ask for a pause or resume of M, or abort all. The lanes run in tasks of one lane or several joined (sharing
//! the task's waker, as `embassy_futures::join` in one RTIC task). The application flips the conditions (monitors, exit and
//! pre-conditions, failures), starts M and J again and asks for pauses, resumes, aborts
//! and new timeouts at random. A second task (priority 3) ticks the sequencer too, with a
//! monitor table of its own (a monitor of A2), at the time of the last tick or the next:
//! refused (`Error::TickInProgress`) while the tick runs, refused
//! (`Error::ForeignMonitorTable`) when polls are due, a tick that evaluates nothing
//! otherwise. Half the runs begin 20 ms before the sequencer's 32-bit µs
//! stamps wrap. With `RTSEQ_LONG_GAPS` set (a sweep's option, not the default run), one
//! tick in twelve comes after a gap of 2^31 µs or more, some close to a multiple of
//! 2^32 µs, which the liveness watches count as one millisecond.
//!
//! The scheduler follows RTIC's rules for the parties: the application (priority 0), the
//! lanes (priorities 1 and 3, drawn per lane), the tick (2) and the safety system's
//! abort-all (4). Before a random section of whatever runs, a party of higher priority
//! (a woken lane, the next tick, an abort-all) may run to its end, preempted in turn
//! by one still higher; parties of equal priority never preempt each other. After each
//! millisecond the interleaving invariants hold ([`World::check_tree`]), and those of a
//! settled world ([`check_settled`]: a blocked child is paused with a paused caller);
//! after every tick and millisecond, timeouts, `Level` monitors and `PauseOwner` holds
//! act, and polled conditions are taken, within a polling period ([`Liveness`]); then
//! every
//! condition is let go and everything resumed, and within 100 ms everything must come to
//! rest: nothing under way, no start pending, no lane woken.

use super::*;

use core::convert::Infallible;
use core::future::Future;
use core::pin::Pin;
use core::task::Context;

use embassy_futures::select::select;

use crate::lock::interleaved::{Interleaved, InterleavedCoarse};
use crate::model::time::Stamp;
use crate::sequencer::inbox::abort_all_posted;
use crate::{lane, Cx, Failure, Seq, Sequence, Trigger, Wait};

/// The tick's priority.
const TICK: u8 = 2;
/// The priority of a second task that ticks the sequencer (misuse, refused while the
/// tick runs).
const SECOND_TICK: u8 = 3;
/// The safety system's priority (its abort-all).
const SAFETY: u8 = 4;

/// M: A blocking (the second time against `cancel`), then B in its lane, joined (the
/// second time scoped); twice.
struct Main {
    a: Seq<Middle>,
    b: SeqId,
    cancel: &'static AtomicBool,
}

impl Sequence<()> for Main {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        for round in 0..2 {
            if round == 0 {
                let _ = cx.run(&mut self.a).await;
            } else {
                let cancel = self.cancel;
                let cancelled = cx.wait_until(move |_| cancel.load(Ordering::Relaxed));
                let _ = select(cx.run(&mut self.a), cancelled).await;
            }
            if round == 0 {
                if cx.start(self.b).is_ok() {
                    let _ = cx.join(self.b).await;
                }
            } else if let Ok(b) = cx.start_scoped(self.b) {
                let _ = b.join().await;
            }
        }
        Ok(())
    }
}

/// A: runs A2 blocking, handing its failure on while `hand_on` holds, then the exit
/// condition `exit`, polled.
struct Middle {
    inner: Seq<Child>,
    exit: &'static AtomicBool,
    hand_on: &'static AtomicBool,
}

impl Sequence<()> for Middle {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let done = cx.run(&mut self.inner).await;
        if self.hand_on.load(Ordering::Relaxed) {
            done?;
        }
        Ok(())
    }

    fn check_exit_condition(&mut self, _: &Cx<'_, ()>) -> bool {
        self.exit.load(Ordering::Relaxed)
    }
}

/// A2, E and E2: when `pre` holds, a blocking dwell step, then a failure while `fail`
/// holds, then the exit condition `exit`, polled.
struct Child {
    dwell: Seq<Wait>,
    pre: &'static AtomicBool,
    fail: &'static AtomicBool,
    exit: &'static AtomicBool,
}

impl Sequence<()> for Child {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.step(&mut self.dwell).await;
        if self.fail.load(Ordering::Relaxed) {
            return Err(Failure::App(7));
        }
        Ok(())
    }

    fn check_pre_condition(&mut self, _: &Cx<'_, ()>) -> bool {
        self.pre.load(Ordering::Relaxed)
    }

    fn check_exit_condition(&mut self, _: &Cx<'_, ()>) -> bool {
        self.exit.load(Ordering::Relaxed)
    }
}

/// J: makes the request `order` says of A or M (from its lane, as a supervisor would),
/// then joins B, then M: a second joiner of B's runs beside M, in another lane.
struct Joiner {
    a: SeqId,
    b: SeqId,
    m: SeqId,
    order: &'static AtomicUsize,
}

impl Sequence<()> for Joiner {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let order = self.order.load(Ordering::Relaxed);
        let target = if order.is_multiple_of(2) {
            self.a
        } else {
            self.m
        };
        if let Some(h) = cx.sequence_by_id(target) {
            let _ = match order / 2 {
                0 => h.pause(),
                1 => h.resume(),
                2 => h.abort(),
                3 => h.set_timeout(Some(Duration::from_millis(3))),
                4 => h.set_timeout(None),
                _ => Ok(()),
            };
        }
        let _ = cx.join(self.b).await;
        let _ = cx.join(self.m).await;
        Ok(())
    }
}

/// B: waits in `Cx::wait_until` for `go`.
struct Waiter {
    go: &'static AtomicBool,
}

impl Sequence<()> for Waiter {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let go = self.go;
        cx.wait_until(move |_| go.load(Ordering::Relaxed)).await;
        Ok(())
    }
}

/// A lane's future, boxed.
type LaneFuture = Pin<Box<dyn Future<Output = Infallible>>>;

/// `seq`'s lane, declared.
fn lane_of<S: Sequence<()> + 'static, L: Lock + 'static, const N: usize, const B: usize>(
    w: World<L, N, B>,
    seq: Seq<S>,
) -> LaneFuture {
    let seq: &'static mut Seq<S> = Box::leak(Box::new(seq));
    w.handle(seq.id()).declare_lane().unwrap();
    Box::pin(lane(w.seq, &(), seq))
}

/// A task of a priority that runs one lane or several joined (as `embassy_futures::join`
/// does: each poll of the task polls every lane, and they share the task's waker), with a
/// counting waker; `seen`: the wake-ups when its last poll began.
struct RandomLane {
    futs: RefCell<Vec<LaneFuture>>,
    waker: Waker,
    wakes: Arc<Count>,
    seen: Cell<usize>,
    priority: u8,
}

impl RandomLane {
    fn new(futs: Vec<LaneFuture>, priority: u8) -> &'static RandomLane {
        let (waker, wakes) = counting();
        Box::leak(Box::new(RandomLane {
            futs: RefCell::new(futs),
            waker,
            wakes,
            seen: Cell::new(0),
            priority,
        }))
    }

    fn woken(&self) -> bool {
        woken(&self.wakes) > self.seen.get()
    }

    /// Polls the task's lanes (a poll while it is being polled fails the test: a harness
    /// error).
    fn poll(&self) {
        self.seen.set(woken(&self.wakes));
        let mut cx = Context::from_waker(&self.waker);
        for fut in self.futs.borrow_mut().iter_mut() {
            let _ = fut.as_mut().poll(&mut cx);
        }
    }
}

/// The scheduler and the tree: everything `'static` and shared, so that a closure run
/// before a section can run another party.
struct Sched<L: Lock + 'static, const N: usize, const B: usize> {
    w: World<L, N, B>,
    lanes: &'static [&'static RandomLane],
    /// The priorities of the parties under way, innermost last.
    running: &'static RefCell<Vec<u8>>,
    rng: &'static Cell<u64>,
    /// The time of the last tick (ms).
    now: &'static Cell<u64>,
    /// The monitor table of the second task that ticks the sequencer.
    second: &'static RefCell<Monitors<'static, (), 4>>,
    /// The liveness checks' memory, and the run's description for their failures.
    live: &'static RefCell<Liveness>,
    /// The priority of each lane slot's task.
    slot_priority: &'static [u8],
    what: &'static Cell<&'static str>,
}

impl<L: Lock + 'static, const N: usize, const B: usize> Clone for Sched<L, N, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<L: Lock + 'static, const N: usize, const B: usize> Copy for Sched<L, N, B> {}

impl<L: Lock + 'static, const N: usize, const B: usize> Sched<L, N, B> {
    fn below(self, n: u64) -> u64 {
        below(self.rng, n)
    }

    fn chance(self, one_in: u64) -> bool {
        self.below(one_in) == 0
    }

    /// A preemption before a random one of the next sections.
    fn arm(self) {
        let k = self.below(12) as usize;
        interleaved::at(k, move || self.preempt());
    }

    fn disarm(self) {
        interleaved::at(usize::MAX, || {});
    }

    /// Runs `party` at `priority`, preemptible by any of higher priority.
    fn run_as(self, priority: u8, party: impl FnOnce()) {
        self.running.borrow_mut().push(priority);
        self.arm();
        party();
        self.running.borrow_mut().pop();
    }

    /// Before a section: maybe a party of higher priority than the one under way runs;
    /// then the next preemption is armed.
    fn preempt(self) {
        let current = self.running.borrow().last().copied().unwrap_or(0);
        let woken: Vec<&'static RandomLane> = self
            .lanes
            .iter()
            .copied()
            .filter(|l| l.priority > current && l.woken())
            .collect();
        // Once the world's table is the sequencer's (its first due tick binds it; a second
        // table that came first would be the sequencer's instead).
        let bound = self.w.seq.with(|s| s.monitor_table != 0);
        if SECOND_TICK > current && bound && self.chance(5) {
            // A second task that ticks the sequencer (misuse): refused while the tick is
            // under way, which it preempts; else a tick at the time of the last one.
            // The tick holds its turn from its first section on.
            let held = self.w.seq.ticking.load(Ordering::Relaxed);
            assert!(
                !held || self.running.borrow().contains(&TICK),
                "a tick's turn is held with no tick under way"
            );
            // At the time of the tick's last call, or of its next (unless the tick is
            // under way: the world's clock is then already its time): with polls due
            // there, the second table is refused (the sequencer is ticked with the
            // world's).
            let at = if self.running.borrow().contains(&TICK) || self.chance(2) {
                self.w.seq.now()
            } else {
                Instant::from_ticks((self.now.get() + 1) * 1_000)
            };
            self.run_as(SECOND_TICK, || {
                let due = self
                    .w
                    .seq
                    .with(|s| Stamp::of(at).reached(s.polling.next_due));
                let r = self.w.seq.tick(at, &(), &mut self.second.borrow_mut());
                if r.is_ok() {
                    self.observe();
                }
                let expected = if held {
                    Err(Error::TickInProgress)
                } else if due {
                    Err(Error::ForeignMonitorTable)
                } else {
                    Ok(())
                };
                assert_eq!(r, expected, "the second task's tick at {at}");
            });
        }
        let mut parties = woken.len() as u64;
        let tick = TICK > current && self.chance(4);
        let abort_all = SAFETY > current && self.chance(40);
        parties += u64::from(tick) + u64::from(abort_all);
        if parties > 0 {
            let pick = self.below(parties) as usize;
            if let Some(lane) = woken.get(pick) {
                self.run_as(lane.priority, || lane.poll());
            } else if tick && (pick == woken.len() || !abort_all) {
                self.tick();
            } else {
                self.run_as(SAFETY, || self.w.seq.abort_all());
            }
        }
        self.arm();
    }

    /// The next tick, 1 ms after the last.
    fn tick(self) {
        // With RTSEQ_LONG_GAPS: one tick in twelve comes after a gap of 2^31 µs or more
        // (some close to a multiple of 2^32 µs); the liveness watches count it as one ms.
        let gap = if std::env::var("RTSEQ_LONG_GAPS").is_ok() && self.chance(12) {
            const GAPS: [u64; 8] = [
                2_147_484, 2_147_485, 3_000_000, 4_294_966, 4_294_967, 4_294_968, 6_442_451,
                8_589_934,
            ];
            GAPS[self.below(8) as usize]
        } else {
            0
        };
        if gap > 0 {
            let mut live = self.live.borrow_mut();
            for w in live.timeouts.iter_mut().flatten() {
                w.since += gap;
            }
            for m in &mut live.levels {
                if let Some(w) = m.watch.as_mut() {
                    w.0 += gap;
                }
            }
            for p in &mut live.polls {
                if let Some(since) = p.since.as_mut() {
                    *since += gap;
                }
            }
        }
        let ms = self.now.get() + 1 + gap;
        self.now.set(ms);
        self.run_as(TICK, || self.w.tick(ms));
        self.observe();
        if !cfg!(miri) {
            let busy = self.running.borrow().iter().copied().max().unwrap_or(0);
            self.live
                .borrow_mut()
                .starved(self.w, busy, self.slot_priority);
        }
    }

    /// The liveness checks after a tick (no preemption meanwhile; the party under way
    /// arms the next).
    fn observe(self) {
        self.disarm();
        // Under Miri the run is there for its unsafe code: the checks' many sections
        // only slow it down.
        if cfg!(miri) {
            return;
        }
        let what = format!(
            "{}, after the tick at {} ms",
            self.what.get(),
            self.now.get()
        );
        let mut live = self.live.borrow_mut();
        live.observe(self.w, &what, self.now.get());
        live.watch_polls(self.w, self.now.get());
    }

    /// Polls the woken lanes, the highest priority first, until none is woken.
    fn settle(self, what: &str) {
        for _ in 0..1_000 {
            let next = self
                .lanes
                .iter()
                .copied()
                .filter(|l| l.woken())
                .max_by_key(|l| l.priority);
            let Some(lane) = next else {
                return;
            };
            self.run_as(lane.priority, || lane.poll());
        }
        panic!("{what}: the lanes are woken forever");
    }
}

/// Since when (ms) a sequence has been seen running, armed, not handling an exception,
/// with the same run and timeout, at every observation (see [`Liveness`]).
#[derive(Clone, Copy, PartialEq)]
struct Watch {
    since: u64,
    runs: u16,
    timeout: u32,
}

/// A `Level` or `PauseOwner` monitor of the main table, for [`Liveness`].
struct LevelMonitor {
    id: MonitorId,
    owner: SeqId,
    flag: &'static AtomicBool,
    /// A `PauseOwner` monitor: while its condition holds, its owner is paused.
    pause: bool,
    /// Since when (ms) its condition has been seen true at every observation, its owner
    /// running the same round (by the start of its clock) and not handling an exception,
    /// with this many firings.
    watch: Option<(u64, u64, u16)>,
}

/// A sequence that waits for a polled condition (its exit condition, or `Cx::wait_until`):
/// which flag it polls, for [`Liveness`].
struct PollWatch {
    id: SeqId,
    flag: &'static AtomicBool,
    /// Since when (ms) it has been seen waiting for the flag, which was true, not held.
    since: Option<u64>,
}

/// Timeouts and `Level` monitors fire within a polling period (at most 3 ms here). Observed
/// after every tick and at every settled point (exceptions are marked and cleared only by
/// ticks, so a sequence handling one is seen doing so). A sequence that a teardown has
/// marked (`flag::STOPPING`: a dropped run's teardown in a lane may take several ticks)
/// counts as handling an exception: it takes none until it is moved.
/// - a sequence seen running for 4 ms or more, armed, not handling an exception (which
///   takes no other), with the same run and timeout, has run less than its timeout and
///   4 ms;
/// - a `Level` monitor whose condition was seen true for 4 ms or more, its owner running
///   the same round (a restarted round's monitors are evaluated from its first poll) and
///   not handling an exception, its flag not set meanwhile ([`Liveness::flags_set`]), has
///   fired;
///   a `PauseOwner` monitor seen so has paused its owner (it marks no exception: its
///   owner's own is no excuse).
///
/// And a polled condition is taken within a polling period: a sequence seen at every
/// observation waiting for it (`Set::PollWait`) while it holds, not held (paused, handling
/// an exception, marked by a teardown, or blocking a caller that is paused or handles an
/// exception), for 4 ms or more, its flag not set meanwhile, is over it at the next settled
/// point ([`Liveness::check_polls`]; a lane preempted inside its poll finishes it there).
/// A millisecond whose tick preempted a party of its lane's priority or higher is not
/// counted ([`Liveness::starved`]): its lane could not run then.
#[derive(Default)]
struct Liveness {
    /// By id.
    timeouts: Vec<Option<Watch>>,
    levels: Vec<LevelMonitor>,
    polls: Vec<PollWatch>,
}

impl Liveness {
    fn observe<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: World<L, N, B>,
        what: &str,
        now: u64,
    ) {
        self.timeouts.resize(w.count(), None);
        for (i, watch) in self.timeouts.iter_mut().enumerate() {
            let id = SeqId::from_index(i);
            let (state, armed, excepting, timeout, runs, run_time) = w.seq.with(|s| {
                let b = s.block(id).unwrap();
                (
                    b.state,
                    s.sets.has(Set::Armed, id),
                    // A run whose abort is requested takes no exception (semantics 10).
                    s.sets.has(Set::Excepting, id)
                        || b.has(flag::STOPPING)
                        || b.has(crate::sequencer::control_block::request::ABORT),
                    b.timeout,
                    b.runs,
                    s.run_time(id),
                )
            });
            if !(state == Running && armed && !excepting && timeout != 0) {
                *watch = None;
                continue;
            }
            let since = match *watch {
                Some(seen) if seen.runs == runs && seen.timeout == timeout => seen.since,
                _ => now,
            };
            *watch = Some(Watch {
                since,
                runs,
                timeout,
            });
            assert!(
                now - since < 4 || run_time < u64::from(timeout) + 4_000,
                "{what}: {id:?} runs {run_time} µs with a timeout of {timeout} µs, \
                 watched since {since} ms"
            );
        }
        // Not while the main tick holds its table (the second task's tick preempted it
        // before its first section).
        let Ok(table) = w.monitors.try_borrow() else {
            return;
        };
        for m in &mut self.levels {
            // The round: a new run or a restart starts the clock again (a running round's
            // start stays where it is).
            let (state, round, excepting, stopping) = w.seq.with(|s| {
                let b = s.block(m.owner).unwrap();
                (
                    b.state,
                    s.now.as_ticks().wrapping_sub(s.run_time(m.owner)),
                    s.sets.has(Set::Excepting, m.owner),
                    b.has(flag::STOPPING),
                )
            });
            let fired = table.fired(m.id);
            let excused = (excepting && !m.pause) || stopping;
            if !(state == Running && !excused && m.flag.load(Ordering::Relaxed)) {
                m.watch = None;
                continue;
            }
            // A hold leaves its owner paused: it does not count a firing while it runs.
            let fired = if m.pause { 0 } else { fired };
            let since = match m.watch {
                Some((since, r, f)) if r == round && f == fired => since,
                _ => now,
            };
            m.watch = Some((since, round, fired));
            assert!(
                now - since < 4,
                "{what}: {:?} of {:?} true since {since} ms, not fired (or not holding)",
                m.id,
                m.owner
            );
        }
    }

    /// The application set `flags`: a tick that preempted it may have seen them before.
    fn flags_set(&mut self, flags: &[&'static AtomicBool]) {
        for m in &mut self.levels {
            if flags.iter().any(|f| core::ptr::eq(*f, m.flag)) {
                m.watch = None;
            }
        }
        for p in &mut self.polls {
            if flags.iter().any(|f| core::ptr::eq(*f, p.flag)) {
                p.since = None;
            }
        }
    }

    /// Whether `id` waits for its polled condition, not held (see [`Liveness`]).
    fn waits_unheld<L: Lock + 'static, const N: usize, const B: usize>(
        w: World<L, N, B>,
        id: SeqId,
    ) -> bool {
        // An abort-all asked for holds every run until the tick carries it out.
        let abort_all = abort_all_posted(&w.seq.safety.inbox);
        w.seq.with(|s| {
            let held = |id: SeqId| {
                let b = s.block(id).unwrap();
                b.state == Paused
                    || s.sets.has(Set::Excepting, id)
                    || b.has(flag::STOPPING)
                    || abort_all
            };
            let b = s.block(id).unwrap();
            if b.state != Running || !s.sets.has(Set::PollWait, id) || held(id) {
                return false;
            }
            let mut at = b;
            while let Some(c) = at.caller.get() {
                let cb = s.block(c).unwrap();
                if cb.lane != b.lane {
                    break;
                }
                if held(c) {
                    return false;
                }
                at = cb;
            }
            true
        })
    }

    /// Starts or ends the polled-condition watches at `now` (after a tick, or at a settled
    /// point).
    fn watch_polls<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: World<L, N, B>,
        now: u64,
    ) {
        for p in &mut self.polls {
            if p.flag.load(Ordering::Relaxed) && Self::waits_unheld(w, p.id) {
                p.since.get_or_insert(now);
            } else {
                p.since = None;
            }
        }
    }

    /// After a tick that preempted a party of priority `busy`: a waiting sequence whose
    /// lane's task (`slot_priority`, by lane slot) is of that priority or below cannot run
    /// before the party ends (a task of equal priority runs to its end first), so this
    /// millisecond is not counted against its poll. (The harness may preempt one poll with
    /// several ticks: a lane's poll that takes milliseconds, which starves the others.)
    fn starved<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: World<L, N, B>,
        busy: u8,
        slot_priority: &[u8],
    ) {
        for p in &mut self.polls {
            let Some(since) = p.since.as_mut() else {
                continue;
            };
            let lane = w.seq.with(|s| s.lane_slot(p.id));
            if slot_priority
                .get(usize::from(lane))
                .is_some_and(|&priority| busy >= priority)
            {
                *since += 1;
            }
        }
    }

    /// At a settled point `now`: no sequence still waits for a condition that has held for
    /// 4 ms or more (see [`Liveness`]).
    fn check_polls<L: Lock + 'static, const N: usize, const B: usize>(
        &mut self,
        w: World<L, N, B>,
        what: &str,
        now: u64,
    ) {
        self.watch_polls(w, now);
        for p in &self.polls {
            if let Some(since) = p.since {
                assert!(
                    now.saturating_sub(since) < 4,
                    "{what}: {:?} waits for its polled condition, true since {since} ms",
                    p.id
                );
            }
        }
    }
}

/// The invariants of a settled world (the tick done, every woken lane polled), beyond
/// [`World::check_tree`]: a sequence under way that its caller blocks (same lane) has a
/// caller that is running or paused (a caller's restart, end or abort takes its blocking children
/// with it), and a paused caller's blocked child is paused too (a pause walks what the
/// target blocks; a blocking start or a restart below a paused caller begins paused).
fn check_settled<L: Lock + 'static, const N: usize, const B: usize>(w: World<L, N, B>, what: &str) {
    for i in 0..w.count() {
        let id = SeqId::from_index(i);
        let state = w.state(id);
        if ![Running, Paused, Restarting].contains(&state) {
            continue;
        }
        let (caller, blocking) = w.seq.with(|s| {
            let b = s.block(id).unwrap();
            let caller = b.caller.get();
            let lane = b.lane;
            (
                caller,
                caller.is_some_and(|c| s.block(c).unwrap().lane == lane),
            )
        });
        let (Some(c), true) = (caller, blocking) else {
            continue;
        };
        let caller_state = w.state(c);
        assert!(
            [Running, Paused].contains(&caller_state),
            "{what}: {id:?} is {state:?}, blocked by {c:?}, which is {caller_state:?}"
        );
        if caller_state == Paused && state != Restarting {
            assert_eq!(
                state, Paused,
                "{what}: {id:?} is {state:?}, blocked by paused {c:?}"
            );
        }
    }
}

/// A number in `0..n` from `rng` (xorshift64*).
fn below(rng: &Cell<u64>, n: u64) -> u64 {
    let mut x = rng.get();
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    rng.set(x);
    x.wrapping_mul(0x2545_f491_4f6c_dd1d) % n
}

/// The last whole millisecond before 2^32 µs, where the sequencer's 32-bit stamps wrap.
const WRAP_MS: u64 = (1 << 32) / 1_000;

/// The monitors' behaviours drawn from.
const BEHAVIOURS: [Behaviour; 6] = [
    Behaviour::Nothing,
    Behaviour::AbortOwner,
    Behaviour::RestartOwner,
    Behaviour::AbortCallerOfOwner,
    Behaviour::RestartCallerOfOwner,
    Behaviour::PauseOwner,
];

/// The behaviours of A's timeout drawn from.
const TIMEOUT_BEHAVIOURS: [Behaviour; 4] = [
    Behaviour::AbortOwner,
    Behaviour::RestartOwner,
    Behaviour::AbortCallerOfOwner,
    Behaviour::RestartCallerOfOwner,
];

std::thread_local! {
    /// What the cleanup hooks of the run under way do.
    static HOOK: RefCell<Option<Box<dyn Fn()>>> = RefCell::new(None);
}

/// The cleanup hook of A and A2: [`HOOK`].
fn cleanup_hook(_: &()) {
    HOOK.with(|h| {
        if let Some(f) = h.borrow().as_ref() {
            f();
        }
    });
}

/// The monitors' triggers drawn from.
const TRIGGERS: [Trigger; 4] = [
    Trigger::RisingEdge,
    Trigger::FallingEdge,
    Trigger::Change,
    Trigger::Level,
];

/// A monitor of `owner` whose condition is `flag`, with `trigger` and `limit` restarts.
fn random_monitor<L: Lock + 'static, const N: usize, const B: usize>(
    w: World<L, N, B>,
    owner: SeqId,
    flag: &'static AtomicBool,
    behaviour: Behaviour,
    exception: Option<SeqId>,
    trigger: Trigger,
    limit: u8,
) -> MonitorId {
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(move |_: &(), _: Instant| {
            flag.load(Ordering::Relaxed)
        }));
    let mut m = Monitor::new("m", condition, behaviour)
        .trigger(trigger)
        .restart_limit(limit);
    if let Some(e) = exception {
        m = m.exception(e);
    }
    w.monitors.borrow_mut().add(owner, m).unwrap()
}

/// One random run from `seed` (see the module's documentation).
fn random_run<L: Lock + 'static, const N: usize, const B: usize>(layout: Layout, seed: u64) {
    let w = World::<L, N, B>::new(layout);
    let what = name::<L>(layout, format_args!("seed {seed}"));
    let rng: &'static Cell<u64> = Box::leak(Box::new(Cell::new(
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1,
    )));
    let draw = |n: u64| below(rng, n);
    // From 0, or 20 ms before the sequencer's 32-bit µs stamps wrap (deadlines and
    // polls compared by wrapping difference across the wrap).
    let start_ms = if draw(2) == 0 { 0 } else { WRAP_MS - 20 };
    let (fa, fm, exit, go) = (flag_of(false), flag_of(false), flag_of(true), flag_of(true));
    let fa2 = flag_of(false);
    let cancel = flag_of(false);
    let always = flag_of(true);
    let never = flag_of(false);
    let (pre, fail, hand_on) = (flag_of(true), flag_of(false), flag_of(false));
    let ms = |n| Wait::new(Duration::from_millis(n));
    let dwell = w.seq.add(SeqConfig::new("W"), ms(2)).unwrap();
    // Polling periods of 1 to 3 ms: several polling classes, their grids started and
    // joined under preemption.
    let polling = |name| SeqConfig::new(name).polling(Duration::from_millis(draw(3) + 1));
    let mut a_config = polling("A").on_abort(cleanup_hook);
    match draw(3) {
        0 => a_config = a_config.timeout(Duration::from_millis(4)),
        1 => a_config = a_config.timeout(Duration::from_millis(7)),
        _ => {}
    }
    let timeout_behaviour = TIMEOUT_BEHAVIOURS[draw(4) as usize];
    a_config = a_config.timeout_behaviour(timeout_behaviour);
    let a2 = w
        .seq
        .add(
            polling("A2").on_abort(cleanup_hook),
            Child {
                dwell,
                pre,
                fail,
                exit,
            },
        )
        .unwrap();
    let ia2 = a2.id();
    let a = w
        .seq
        .add(
            a_config,
            Middle {
                inner: a2,
                exit,
                hand_on,
            },
        )
        .unwrap();
    // With `Layout::Split`, W, A2 and A in the first word, the others in the second.
    w.split();
    let b = w.seq.add(polling("B"), Waiter { go }).unwrap();
    let e_dwell = w.seq.add(SeqConfig::new("EW"), ms(1)).unwrap();
    let e = w
        .seq
        .add(
            SeqConfig::new("E"),
            Child {
                dwell: e_dwell,
                pre: always,
                fail: never,
                exit: always,
            },
        )
        .unwrap();
    let e2_dwell = w.seq.add(SeqConfig::new("E2W"), ms(1)).unwrap();
    let e2 = w
        .seq
        .add(
            SeqConfig::new("E2"),
            Child {
                dwell: e2_dwell,
                pre: always,
                fail: never,
                exit: always,
            },
        )
        .unwrap();
    let (ia, ib, ie, ie2) = (a.id(), b.id(), e.id(), e2.id());
    let mut m_config = SeqConfig::new("M");
    if draw(2) == 0 {
        m_config = m_config.timeout(Duration::from_millis(12));
    }
    let m = w.seq.add(m_config, Main { a, b: ib, cancel }).unwrap();
    let im = m.id();
    let order: &'static AtomicUsize = Box::leak(Box::new(AtomicUsize::new(usize::MAX)));
    let j = w
        .seq
        .add(
            SeqConfig::new("J"),
            Joiner {
                a: ia,
                b: ib,
                m: im,
                order,
            },
        )
        .unwrap();
    let ij = j.id();
    // What the cleanup hooks of A and A2 do (in the tick, or in a lane's teardown of a
    // dropped run, between two sections): a start, a request or an abort-all.
    let hook_action = draw(6);
    HOOK.with(|h| {
        *h.borrow_mut() = Some(Box::new(move || {
            let _ = match hook_action {
                0 => w.kept(ij).start(),
                1 => w.kept(im).pause(),
                2 => w.kept(im).resume(),
                3 => w.kept(ib).start(),
                4 => {
                    w.seq.abort_all();
                    Ok(())
                }
                _ => Ok(()),
            };
        }));
    });
    let behaviour_a = BEHAVIOURS[draw(6) as usize];
    let with_e = behaviour_a != Behaviour::PauseOwner && draw(2) == 0;
    // The main table's `Level` monitors, for the liveness checks.
    let mut levels = Vec::new();
    let mut monitor = |owner, flag, behaviour, e| {
        let trigger = TRIGGERS[draw(4) as usize];
        let limit = draw(4) as u8;
        let id = random_monitor(w, owner, flag, behaviour, e, trigger, limit);
        let pause = behaviour == Behaviour::PauseOwner;
        if trigger == Trigger::Level || pause {
            levels.push(LevelMonitor {
                id,
                owner,
                flag,
                pause,
                watch: None,
            });
        }
        (trigger, limit)
    };
    let mut monitors_drawn = Vec::new();
    // The second task's table: a monitor of A2.
    let fb = flag_of(false);
    let second: &'static RefCell<Monitors<'static, (), 4>> =
        Box::leak(Box::new(RefCell::new(Monitors::new())));
    let condition: &'static mut (dyn Condition<()> + Send) =
        Box::leak(Box::new(move |_: &(), _: Instant| {
            fb.load(Ordering::Relaxed)
        }));
    let behaviour_b2 = BEHAVIOURS[draw(6) as usize];
    let mut m2 = Monitor::new("second", condition, behaviour_b2);
    if behaviour_b2 != Behaviour::PauseOwner && draw(2) == 0 {
        m2 = m2.exception(ie2);
    }
    second.borrow_mut().add(ia2, m2).unwrap();
    monitors_drawn.push(monitor(ia, fa, behaviour_a, with_e.then_some(ie)));
    // A2's monitor shares E (refused while E runs for A: an exception not run).
    let behaviour_a2 = BEHAVIOURS[draw(6) as usize];
    let with_e_a2 = behaviour_a2 != Behaviour::PauseOwner && draw(2) == 0;
    monitors_drawn.push(monitor(ia2, fa2, behaviour_a2, with_e_a2.then_some(ie)));
    let behaviour_m = [
        Behaviour::Nothing,
        Behaviour::AbortOwner,
        Behaviour::RestartOwner,
        Behaviour::PauseOwner,
    ][draw(4) as usize];
    let with_e2 = behaviour_m != Behaviour::PauseOwner && draw(2) == 0;
    monitors_drawn.push(monitor(im, fm, behaviour_m, with_e2.then_some(ie2)));
    // The lanes in tasks: each joins the task before it or begins a new one, of a
    // random priority.
    let mut tasks: Vec<Vec<LaneFuture>> = Vec::new();
    for fut in [
        lane_of(w, m),
        lane_of(w, b),
        lane_of(w, e),
        lane_of(w, e2),
        lane_of(w, j),
    ] {
        match tasks.last_mut() {
            Some(task) if draw(3) == 0 => task.push(fut),
            _ => tasks.push(std::vec![fut]),
        }
    }
    let lanes: &'static [&'static RandomLane] = tasks
        .into_iter()
        .map(|futs| RandomLane::new(futs, if draw(2) == 0 { 1 } else { 3 }))
        .collect::<Vec<_>>()
        .leak();
    // The lanes were declared in the order of their futures, which the tasks keep.
    for (slot, id) in [im, ib, ie, ie2, ij].into_iter().enumerate() {
        assert_eq!(
            w.seq.with(|s| usize::from(s.block(id).unwrap().own_lane)),
            slot
        );
    }
    let slot_priority: &'static [u8] = lanes
        .iter()
        .flat_map(|l| core::iter::repeat_n(l.priority, l.futs.borrow().len()))
        .collect::<Vec<_>>()
        .leak();
    let s = Sched::<L, N, B> {
        w,
        lanes,
        running: Box::leak(Box::new(RefCell::new(Vec::new()))),
        rng,
        now: Box::leak(Box::new(Cell::new(start_ms))),
        second,
        live: Box::leak(Box::new(RefCell::new(Liveness {
            timeouts: Vec::new(),
            levels,
            // What each waits for when it waits for a polled condition.
            polls: [
                (ia, exit),
                (ia2, exit),
                (ie, always),
                (ie2, always),
                (ib, go),
            ]
            .into_iter()
            .map(|(id, flag)| PollWatch {
                id,
                flag,
                since: None,
            })
            .collect(),
        }))),
        what: Box::leak(Box::new(Cell::new(""))),
        slot_priority,
    };
    let what = format!(
        "{what}, from {start_ms} ms, A's monitor {behaviour_a:?} (E: {with_e}), A2's {behaviour_a2:?} (E: {with_e_a2}), M's {behaviour_m:?} (E2: {with_e2}), A2's in the second table {behaviour_b2:?}, A's timeout {timeout_behaviour:?}, the hooks' action {hook_action}, their triggers and restart limits {monitors_drawn:?}, tasks (lanes, priority) {:?}",
        lanes.iter().map(|l| (l.futs.borrow().len(), l.priority)).collect::<Vec<_>>()
    );
    s.what.set(Box::leak(what.clone().into_boxed_str()));
    if start_ms != 0 {
        // The sequencer's time before M starts.
        w.tick(start_ms);
    }
    // Each task is polled once when it is spawned: its lanes wait for a start.
    for l in lanes {
        l.poll();
    }
    s.run_as(0, || {
        w.handle(im).start().unwrap();
    });
    s.disarm();
    s.settle(&what);
    for _ in 0..40 {
        // The flags the application sets in this millisecond: a tick that preempts it
        // may see a flag before or after it is set.
        let mut stored = Vec::new();
        // The application, preemptible by everything.
        for _ in 0..s.below(3) {
            let flag =
                [fa, fa2, fm, exit, go, cancel, pre, fail, hand_on, fb][s.below(10) as usize];
            flag.store(s.chance(2), Ordering::Relaxed);
            stored.push(flag);
            // Mostly M and A; sometimes any other, and a start of any with a lane (B, E
            // or E2 started by hand, J).
            let id = if s.chance(3) {
                [ia2, ib, ie, ie2, ij][s.below(5) as usize]
            } else {
                [im, ia][s.below(2) as usize]
            };
            s.run_as(0, || {
                let h = w.kept(id);
                let _ = match s.below(10) {
                    0 => h.pause(),
                    1 => h.resume(),
                    2 => h.abort(),
                    3 => w.kept(im).start(),
                    6 if [ib, ie, ie2].contains(&id) => h.start(),
                    4 => {
                        order.store(s.below(12) as usize, Ordering::Relaxed);
                        w.kept(ij).start()
                    }
                    5 => h.set_timeout(Some(Duration::from_millis(s.below(9) + 1))),
                    _ => Ok(()),
                };
            });
        }
        s.tick();
        s.settle(&what);
        s.disarm();
        let at = format!("{what}, at {} ms", s.now.get());
        w.check_tree(&at);
        check_settled(w, &at);
        if !cfg!(miri) {
            let mut live = s.live.borrow_mut();
            live.flags_set(&stored);
            live.observe(w, &at, s.now.get());
            live.check_polls(w, &at, s.now.get());
        }
    }
    // Everything let go: it must come to rest.
    for f in [fa, fa2, fm, fb] {
        f.store(false, Ordering::Relaxed);
    }
    for f in [exit, go, pre] {
        f.store(true, Ordering::Relaxed);
    }
    for _ in 0..100 {
        s.run_as(0, || {
            for id in [im, ia, ia2, ib, ie, ie2, ij] {
                let _ = w.kept(id).resume();
            }
        });
        s.tick();
        s.settle(&what);
        s.disarm();
        // Drained before the trace ring fills.
        w.records();
    }
    let what = format!("{what}, at rest at {} ms", s.now.get());
    w.check_tree(&what);
    for id in [im, ia, ia2, ib, ie, ie2, ij] {
        let state = w.state(id);
        assert!(
            ![Running, Paused, Restarting, Aborting].contains(&state),
            "{what}: {id:?} {state:?}"
        );
        assert!(!w.pending(id), "{what}: {id:?} has a start pending");
        // The last run's outcome is the one its last transition says.
        let (outcome, cause) = w.seq.with(|s| {
            let b = s.block(id).unwrap();
            (b.outcome, b.last_cause)
        });
        let agrees = match (state, outcome) {
            (Idle, None) => true,
            (Terminated, Some(Outcome::Completed | Outcome::Skipped | Outcome::Failed(_))) => true,
            (Aborted, Some(Outcome::Aborted(c))) => c == cause,
            _ => false,
        };
        assert!(
            agrees,
            "{what}: {id:?} {state:?} with outcome {outcome:?} ({cause:?})"
        );
    }
    for l in lanes {
        assert!(!l.woken(), "{what}: a lane is woken");
    }
}

/// One world's [`random_run`] of a seed.
type RandomRun = fn(u64);

/// Runs `random_run` for `seeds` in every world; fails naming every failed seed.
fn random_runs(seeds: core::ops::Range<u64>) {
    let mut failed = Vec::new();
    for seed in seeds {
        // Ten sequences: 16 in a sequencer of one word.
        let r = std::panic::catch_unwind(|| {
            let mut failed: Vec<String> = Vec::new();
            let worlds: [(&str, RandomRun); 6] = [
                ("fine, one word", |seed| {
                    random_run::<Interleaved, 16, 1>(Layout::One, seed)
                }),
                ("fine, two words", |seed| {
                    random_run::<Interleaved, 64, 2>(Layout::Second, seed)
                }),
                ("coarse, one word", |seed| {
                    random_run::<InterleavedCoarse, 16, 1>(Layout::One, seed)
                }),
                ("coarse, two words", |seed| {
                    random_run::<InterleavedCoarse, 64, 2>(Layout::Second, seed)
                }),
                ("fine, split", |seed| {
                    random_run::<Interleaved, 64, 2>(Layout::Split, seed)
                }),
                ("coarse, split", |seed| {
                    random_run::<InterleavedCoarse, 64, 2>(Layout::Split, seed)
                }),
            ];
            for (world, run) in worlds {
                if let Err(e) = std::panic::catch_unwind(|| run(seed)) {
                    let msg = e.downcast_ref::<String>().cloned().unwrap_or_default();
                    failed.push(format!("[{world}] {msg}"));
                }
            }
            assert!(failed.is_empty(), "{}", failed.join("\n"));
        });
        if let Err(e) = r {
            let msg = e.downcast_ref::<String>().cloned().unwrap_or_default();
            failed.push(format!("seed {seed}: {msg}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// 200 seeds from `RTSEQ_RANDOM_SEED` (0 if unset), each in every world: about 2.5 s
/// (under Miri, which checks the runs' unsafe code under preemption, one seed). A failure
/// names the seed and the world; explore further with other start seeds.
#[test]
fn random_preemption_of_real_lanes_keeps_the_invariants_and_comes_to_rest() {
    let from = std::env::var("RTSEQ_RANDOM_SEED").map_or(0, |s| s.parse().unwrap_or(0));
    let seeds = if cfg!(miri) { 1 } else { 200 };
    random_runs(from..from + seeds);
}
