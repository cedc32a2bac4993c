//! What a caller gets from a blocking run and a join, polled once or again: the result
//! kept in the run's stage, the run a join takes at its first poll; the safety system's
//! count of out-of-range events; the names `monitors!` declares beside the user's own.
//! (First written as a cold review of session 60's changes.)

use std::cell::RefCell;
use std::pin::pin;
use std::task::Poll;

use embassy_futures::poll_once;
use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cx, Done, Duration, Error, Failure, Instant, Monitor, Outcome, Seq, SeqConfig,
    SeqId, Sequence, Sequencer, Wait,
};

/// What the sequences of these tests saw, in order.
#[derive(Default)]
struct Ctrl {
    seen: RefCell<Vec<(&'static str, String)>>,
}

impl Ctrl {
    fn note(&self, what: &'static str, value: impl core::fmt::Debug) {
        self.seen.borrow_mut().push((what, format!("{value:?}")));
    }
}

fn seen(ctrl: &Ctrl) -> Vec<(&'static str, String)> {
    ctrl.seen.borrow().clone()
}

fn dbg(v: impl core::fmt::Debug) -> String {
    format!("{v:?}")
}

struct Quick;
impl Sequence<Ctrl> for Quick {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Ok(())
    }
}

/// Steps its dwell.
struct Dwells(Seq<Wait>);
impl Sequence<Ctrl> for Dwells {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        cx.step(&mut self.0).await?;
        Ok(())
    }
}

struct Fails;
impl Sequence<Ctrl> for Fails {
    async fn action(&mut self, _cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        Err(Failure::App(3))
    }
}

// ---------------------------------------------------------------------------------------
// 1. A blocking run's result, read from its stage.
// ---------------------------------------------------------------------------------------

/// Runs `quick`, `fails` and a 1 ms dwell blocking, awaits each, then polls each future
/// again (a misuse of a future): the same result again, not `Pending`.
struct RunsThenRepolls {
    quick: Seq<Quick>,
    fails: Seq<Fails>,
    dwell: Seq<Wait>,
    foreign: Seq<Quick>,
}

impl Sequence<Ctrl> for RunsThenRepolls {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let c = cx.control();
        {
            let mut f = pin!(cx.run(&mut self.quick));
            c.note("quick", f.as_mut().await);
            c.note("quick again", poll_once(f.as_mut()));
        }
        {
            let mut f = pin!(cx.run(&mut self.fails));
            c.note("fails", f.as_mut().await);
            c.note("fails again", poll_once(f.as_mut()));
        }
        {
            let mut f = pin!(cx.step(&mut self.dwell));
            c.note("dwell", f.as_mut().await);
            c.note("dwell again", poll_once(f.as_mut()));
        }
        {
            // Another sequencer's object: refused at the first poll (HandOver of the
            // refusal), then the same refusal again.
            let mut f = pin!(cx.run(&mut self.foreign));
            let first = f.as_mut().await;
            c.note(
                "foreign is refused",
                matches!(first, Err(Failure::NotStarted(_))),
            );
            c.note("foreign again", poll_once(f.as_mut()) == Poll::Ready(first));
        }
        Ok(())
    }
}

#[test]
fn a_blocking_run_gives_its_result_and_gives_it_again_when_polled_again() {
    let seq: Sequencer<Ctrl, 8> = Sequencer::new();
    let other: Sequencer<Ctrl, 2> = Sequencer::new();
    let ctrl = Ctrl::default();
    let quick = seq.add(SeqConfig::new("quick"), Quick).unwrap();
    let fails = seq.add(SeqConfig::new("fails"), Fails).unwrap();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let foreign = other.add(SeqConfig::new("foreign"), Quick).unwrap();
    let main = seq
        .add(
            SeqConfig::new("main"),
            RunsThenRepolls {
                quick,
                fails,
                dwell,
                foreign,
            },
        )
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, rtseq::Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.start(m).unwrap();
    assert_eq!(
        sim.run_until_idle(Duration::from_millis(20)),
        Some(Instant::from_ticks(1_000))
    );
    drop(sim);
    let ok: Result<Done, Failure> = Ok(Done::Completed);
    let failed: Result<Done, Failure> = Err(Failure::App(3));
    assert_eq!(
        seen(&ctrl),
        [
            ("quick", dbg(ok)),
            ("quick again", dbg(Poll::Ready(ok))),
            ("fails", dbg(failed)),
            ("fails again", dbg(Poll::Ready(failed))),
            ("dwell", dbg(ok)),
            ("dwell again", dbg(Poll::Ready(ok))),
            ("foreign is refused", dbg(true)),
            ("foreign again", dbg(true)),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// 2. Joins: the run taken at the first poll.
// ---------------------------------------------------------------------------------------

/// Joins `target` before it ever ran (`NeverStarted`), starts it, polls the same join
/// future again (which takes the run now current, as the first poll did before), joins an
/// unknown id, then joins `target` again after its run ended, and polls that join again.
struct Joins {
    target: SeqId,
}

impl Sequence<Ctrl> for Joins {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let c = cx.control();
        let mut j = pin!(cx.join(self.target));
        c.note("before the start", poll_once(j.as_mut()));
        cx.start(self.target)?;
        c.note("after the start", j.as_mut().await);
        c.note("unknown", cx.join(SeqId::from_index(40)).await);
        let mut again = pin!(cx.join(self.target));
        c.note("ended", again.as_mut().await);
        c.note("ended, polled again", poll_once(again.as_mut()));
        // A later run of the target: the join of the ended run is still answered from
        // the kept outcome while the later run is under way.
        cx.start(self.target)?;
        c.note("old join, later run under way", poll_once(again.as_mut()));
        Ok(())
    }
}

#[test]
fn a_join_takes_its_run_at_the_poll_that_finds_one() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(2)))
        .unwrap();
    let target = seq.add(SeqConfig::new("target"), Dwells(dwell)).unwrap();
    let t = target.id();
    let main = seq
        .add(SeqConfig::new("main"), Joins { target: t })
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, rtseq::Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(target);
    sim.start(m).unwrap();
    sim.run_until_idle(Duration::from_millis(20));
    drop(sim);
    let done: Result<Outcome, Error> = Ok(Outcome::Completed);
    assert_eq!(
        seen(&ctrl),
        [
            (
                "before the start",
                dbg(Poll::Ready(Err::<Outcome, Error>(Error::NeverStarted(t))))
            ),
            ("after the start", dbg(done)),
            (
                "unknown",
                dbg(Err::<Outcome, Error>(Error::UnknownSequence(
                    SeqId::from_index(40)
                )))
            ),
            ("ended", dbg(done)),
            ("ended, polled again", dbg(Poll::Ready(done))),
            ("old join, later run under way", dbg(Poll::Ready(done))),
        ]
    );
}

/// A scoped child's join (`Join::of_run`) made after the child's run ended, polled twice.
struct ScopedJoins {
    child: SeqId,
    dwell: Seq<Wait>,
}

impl Sequence<Ctrl> for ScopedJoins {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let c = cx.control();
        let child = cx.start_scoped(self.child)?;
        let mut early = pin!(child.join());
        c.note("scoped, under way", poll_once(early.as_mut()));
        cx.step(&mut self.dwell).await?;
        c.note("scoped, ended", early.as_mut().await);
        let mut late = pin!(child.join());
        c.note("scoped, made after the end", poll_once(late.as_mut()));
        c.note("scoped, again", poll_once(late.as_mut()));
        Ok(())
    }
}

#[test]
fn a_scoped_join_of_an_ended_run_gives_its_outcome_every_poll() {
    let seq: Sequencer<Ctrl, 4> = Sequencer::new();
    let ctrl = Ctrl::default();
    let child = seq.add(SeqConfig::new("child"), Fails).unwrap();
    let ci = child.id();
    let dwell = seq
        .add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(1)))
        .unwrap();
    let main = seq
        .add(SeqConfig::new("main"), ScopedJoins { child: ci, dwell })
        .unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &ctrl, rtseq::Monitors::<Ctrl, 1>::new());
    sim.lane(main);
    sim.lane(child);
    sim.start(m).unwrap();
    sim.run_until_idle(Duration::from_millis(20));
    drop(sim);
    let failed: Result<Outcome, Error> = Ok(Outcome::Failed(Failure::App(3)));
    assert_eq!(
        seen(&ctrl),
        [
            (
                "scoped, under way",
                dbg(Poll::<Result<Outcome, Error>>::Pending)
            ),
            ("scoped, ended", dbg(failed)),
            ("scoped, made after the end", dbg(Poll::Ready(failed))),
            ("scoped, again", dbg(Poll::Ready(failed))),
        ]
    );
}

// ---------------------------------------------------------------------------------------
// 3. The safety system's out-of-range events.
// ---------------------------------------------------------------------------------------

mod safety_counts {
    use rtseq::safety::*;

    pub struct Io;
    impl SafetyIo for Io {
        fn read_input(&mut self, _: InputId) -> IoValue {
            IoValue::Bool(false)
        }
        fn write_output(&mut self, _: OutputId, _: IoValue) {}
    }
    const OFF: SafetyLevel = SafetyLevel::new(0);
    static PROPS: SafetyProperties<'static, Io, 1> =
        SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);

    /// The handle's packed word keeps the count in its high 24 bits: it saturates at
    /// 2^24 - 1, the last event is the last triggered, and the system's total adds up.
    #[test]
    fn out_of_range_triggers_saturate_in_the_handle_and_keep_the_last() {
        let handle = SafetyHandle::new();
        let mut ss = SafetySystem::new(&PROPS, &handle).unwrap();
        ss.cycle(&mut Io, &NoSequences);
        const MAX: u32 = (1 << 24) - 1;
        for _ in 0..MAX + 3 {
            handle.trigger(PublicEvent::new(40));
        }
        handle.trigger(PublicEvent::new(45));
        let r = ss.cycle(&mut Io, &NoSequences);
        assert_eq!(r.unknown_events, MAX);
        assert_eq!(ss.unknown_events(), MAX);
        assert_eq!(ss.last_unknown_event().unwrap().event, EventId::public(45));
        // Nothing pending after: the next cycle counts none.
        assert_eq!(ss.cycle(&mut Io, &NoSequences).unknown_events, 0);
        handle.trigger(PublicEvent::new(255));
        assert_eq!(ss.cycle(&mut Io, &NoSequences).unknown_events, 1);
        assert_eq!(ss.unknown_events(), MAX + 1);
        assert_eq!(ss.last_unknown_event().unwrap().event, EventId::public(255));
    }
}

// ---------------------------------------------------------------------------------------
// 4. `monitors!`'s `MonitorTable` type and the names around the macro.
// ---------------------------------------------------------------------------------------

struct Ctl;
enum Cond {
    Never,
}
impl rtseq::Condition<Ctl> for Cond {
    fn validate(&mut self, _: &Ctl, _: Instant) -> bool {
        false
    }
}
const OWNER: SeqId = SeqId::from_index(0);

/// An explicit import of `rtseq::Monitors` beside a glob of the generated module: the
/// explicit import wins, and the module's own type is reached by its path.
mod explicit_import_and_glob {
    use super::*;
    use rtseq::Monitors;
    rtseq::monitors! {
        mod ids for Ctl, Cond {
            X = Monitor::with_condition("x", Cond::Never, Behaviour::Nothing).owned_by(OWNER),
        }
    }
    #[allow(unused_imports)]
    use ids::*;

    #[test]
    fn rtseqs_monitors_and_the_modules_are_the_same_type() {
        let a: Monitors<'static, Ctl, 3, Cond> = ids::table().unwrap();
        let _: &ids::MonitorTable<3> = &a;
        let b: ids::MonitorTable = ids::table().unwrap();
        assert_eq!(b.name(X), Some("x"));
    }
}

/// A user's own `Monitors` (settings passed to the table, a factory of monitors) is what
/// the macro's lines and parameters see: the module declares `MonitorTable`, not
/// `Monitors`.
mod a_users_own_monitors {
    use super::*;

    /// The application's monitor settings.
    pub struct Monitors {
        pub name: &'static str,
    }

    impl Monitors {
        pub const fn never(&self) -> rtseq::OwnedMonitor<'static, Ctl, Cond> {
            Monitor::with_condition(self.name, Cond::Never, Behaviour::Nothing).owned_by(OWNER)
        }
    }

    rtseq::monitors! {
        mod ids(cfg: &Monitors) for Ctl, Cond {
            X = cfg.never(),
        }
    }

    #[test]
    fn the_lines_and_parameters_see_the_users_monitors() {
        let table: ids::MonitorTable = ids::table(&Monitors { name: "x" }).unwrap();
        assert_eq!(table.name(ids::X), Some("x"));
    }
}
