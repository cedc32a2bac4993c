//! The sequencer's trace ring and records, as the simulator
//! collects them — losses counted, order kept, times monotonic, each sequence's records a
//! chain of the state diagram.

use rtseq::safety::{SafetyLevel, Sequences};
use rtseq::sim::Sim;
use rtseq::{
    Cx, Duration, Entry, Event, Failure, Monitors, Record, RunningState, Seq, SeqConfig, SeqId,
    Sequence, Sequencer,
};

/// Completes at once.
struct Blink;
impl Sequence<()> for Blink {
    async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> {
        Ok(())
    }
}

/// Steps its three children one after the other (all in one poll: they complete at once).
struct Three(Seq<Blink>, Seq<Blink>, Seq<Blink>);
impl Sequence<()> for Three {
    async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
        let _ = cx.run(&mut self.0).await;
        let _ = cx.run(&mut self.1).await;
        let _ = cx.run(&mut self.2).await;
        Ok(())
    }
}

/// The records of `runs` runs of `Three` on a sequencer with a trace ring of `T` records,
/// and how many were lost.
fn three_runs<const T: usize>(runs: usize) -> (Vec<Record>, u32) {
    let seq: Sequencer<(), 4, T> = Sequencer::new();
    let a = seq.add(SeqConfig::new("a"), Blink).unwrap();
    let b = seq.add(SeqConfig::new("b"), Blink).unwrap();
    let c = seq.add(SeqConfig::new("c"), Blink).unwrap();
    let main = seq.add(SeqConfig::new("main"), Three(a, b, c)).unwrap();
    let m = main.id();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    sim.lane(main);
    for _ in 0..runs {
        sim.start(m).unwrap();
        sim.pause(m).ok();
        sim.run_for(Duration::from_millis(1));
    }
    (sim.records().to_vec(), sim.lost())
}

/// With a ring too small for one poll's records, what was kept plus what was counted lost
/// is what a large ring records, and the kept records are the large ring's in order (a
/// subsequence): losses are counted exactly and order is preserved.
#[test]
fn lost_plus_kept_is_everything_and_kept_keep_their_order() {
    let (all, lost_all) = three_runs::<256>(5);
    assert_eq!(lost_all, 0);
    assert!(all.len() > 20, "{}", all.len());
    for (kept, lost) in [three_runs::<1>(5), three_runs::<2>(5), three_runs::<4>(5)] {
        assert!(lost > 0);
        assert_eq!(kept.len() + lost as usize, all.len(), "kept {kept:?}");
        // A subsequence of `all`, in order.
        let mut it = all.iter();
        for r in &kept {
            assert!(it.any(|x| x == r), "{r:?} out of order or not recorded");
        }
    }
}

/// `T` = 0: nothing kept, every record counted lost ("If you never drain, set `T = 0`: no
/// RAM is spent, and every record counts as lost").
#[test]
fn zero_capacity_counts_every_record() {
    let (all, _) = three_runs::<256>(3);
    let (kept, lost) = three_runs::<0>(3);
    assert!(kept.is_empty());
    assert_eq!(lost as usize, all.len());
}

/// `drain_records` returns the losses since the last call, once.
#[test]
fn drain_reports_a_loss_once() {
    let seq: Sequencer<(), 2, 2> = Sequencer::new();
    let id = seq.register(SeqConfig::new("x")).unwrap();
    let h = seq.sequence_by_id(id).unwrap();
    h.declare_lane().unwrap();
    h.start().unwrap(); // 1
    h.pause().unwrap(); // 2
    h.abort().unwrap(); // 3: the start is overwritten
    let mut got = Vec::new();
    assert_eq!(seq.drain_records(|r| got.push(r)), 1);
    assert_eq!(got.len(), 2);
    assert!(matches!(
        got[0].entry,
        Entry::Event(Event::Requested {
            request: rtseq::Request::Pause,
            ..
        })
    ));
    assert_eq!(seq.drain_records(|r| got.push(r)), 0);
    assert_eq!(got.len(), 2);
}

/// More than 8 safety notes between two ticks: the ones dropped are counted as lost
/// (firmware guide: "or more than 8 safety notes came between two ticks").
#[test]
fn safety_notes_beyond_eight_are_counted_lost() {
    let seq: Sequencer<(), 2> = Sequencer::new();
    let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    for l in 0..10u8 {
        seq.level_entered(SafetyLevel::new(l));
    }
    sim.step();
    let levels: Vec<u8> = sim
        .records()
        .iter()
        .filter_map(|r| match r.event() {
            Some(Event::SafetyLevel { level }) => Some(level.id()),
            _ => None,
        })
        .collect();
    assert_eq!(levels.len() + sim.lost() as usize, 10, "{levels:?}");
    // In the order entered.
    assert!(levels.windows(2).all(|w| w[0] < w[1]), "{levels:?}");
}

/// Every shared scenario (requests, monitors, exceptions, timeouts, restarts, pauses,
/// lanes of several priorities): times never go back; each sequence's transitions form a
/// chain (`from` = the previous `to`, from `Idle`) of allowed changes; nothing is lost.
#[test]
fn every_scenario_records_a_consistent_chain() {
    let mut failed = Vec::new();
    for sc in rtseq_scenarios::SCENARIOS {
        let run = rtseq_scenarios::host::run(sc).expect("registers");
        if run.lost != 0 {
            failed.push(format!("{}: {} lost", sc.name, run.lost));
        }
        let mut last = 0;
        let mut state = std::collections::HashMap::<SeqId, RunningState>::new();
        for r in &run.records {
            let t = r.time.as_ticks();
            if t < last {
                failed.push(format!("{}: time goes back at {r:?}", sc.name));
            }
            last = t;
            if let Some(tr) = r.transition() {
                let before = state
                    .insert(tr.sequence, tr.to)
                    .unwrap_or(RunningState::Idle);
                if before != tr.from || !tr.from.can_transition_to(tr.to) {
                    failed.push(format!("{}: {tr:?} after {before:?}", sc.name));
                }
            }
        }
        // The trace is the records' transitions.
        let trs: Vec<_> = run.records.iter().filter_map(Record::transition).collect();
        if trs != run.trace {
            failed.push(format!("{}: trace differs from records", sc.name));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}
