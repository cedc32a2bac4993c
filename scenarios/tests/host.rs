//! Every scenario runs on the host simulator with no lost transitions and no action line
//! executed while its sequence was not live; two traces checked exactly against the core
//! tests' expectations (the rest are compared with QEMU by `tests/qemu_scenarios.rs`).

use rtseq::Cause::{self, Completed, Monitor as Mon, Start, Timeout};
use rtseq::RunningState::*;
use rtseq::{MonitorId, SeqId, Transition};
use rtseq_scenarios::{decode, encode, find, host, SCENARIOS};

fn tr(
    ms: u64,
    s: usize,
    from: rtseq::RunningState,
    to: rtseq::RunningState,
    c: Cause,
) -> Transition {
    Transition::at_millis(ms, SeqId::from_index(s), from, to, c)
}

#[test]
fn every_scenario_runs_cleanly_and_encodes_losslessly() {
    let mut names = std::collections::HashSet::new();
    for sc in SCENARIOS {
        assert!(names.insert(sc.name), "duplicate scenario {}", sc.name);
        let run = host::run(sc).unwrap_or_else(|e| panic!("{}: {e:?}", sc.name));
        assert_eq!(run.lost, 0, "{}", sc.name);
        assert_eq!(run.summary.dead_lines, 0, "{}", sc.name);
        assert!(!run.trace.is_empty(), "{}", sc.name);
        for t in &run.trace {
            assert_eq!(decode(&encode(t)), Some(*t), "{}", sc.name);
        }
        // Deterministic: a second run is identical.
        assert_eq!(host::run(sc).ok(), Some(run), "{}", sc.name);
    }
}

#[test]
fn restart_limit_matches_the_core_test() {
    let run = host::run(find("restart_limit").unwrap()).unwrap();
    let m = Mon(MonitorId::from_index(0));
    let (s, a, main) = (0, 1, 2);
    let mut want = vec![
        tr(0, main, Idle, Running, Start),
        tr(0, a, Idle, Running, Start),
        tr(0, s, Idle, Running, Start),
    ];
    for t in 5..=7 {
        want.push(tr(t, s, Running, Aborting, m));
        want.push(tr(t, s, Aborting, Aborted, m));
        want.push(tr(t, a, Running, Restarting, m));
        want.push(tr(t, a, Restarting, Running, Cause::Restart));
        want.push(tr(t, s, Aborted, Running, Start));
    }
    for x in [s, a] {
        want.push(tr(8, x, Running, Aborting, m));
        want.push(tr(8, x, Aborting, Aborted, m));
    }
    want.push(tr(8, main, Running, Terminated, Completed));
    assert_eq!(run.trace, want);
}

#[test]
fn pause_resume_matches_the_core_test() {
    let run = host::run(find("pause_resume").unwrap()).unwrap();
    let (s, a, main) = (0, 1, 2);
    let want = vec![
        tr(0, main, Idle, Running, Start),
        tr(0, a, Idle, Running, Start),
        tr(0, s, Idle, Running, Start),
        tr(4, a, Running, Paused, Cause::Pause),
        tr(4, s, Running, Paused, Cause::Pause),
        // The step, frozen by its paused caller, resumes with it (CHANGELOG 0.2).
        tr(21, a, Paused, Running, Cause::Resume),
        tr(21, s, Paused, Running, Cause::Resume),
        tr(27, s, Running, Aborting, Timeout(SeqId::from_index(s))),
        tr(27, s, Aborting, Aborted, Timeout(SeqId::from_index(s))),
        tr(27, a, Running, Terminated, Completed),
        tr(27, main, Running, Terminated, Completed),
    ];
    assert_eq!(run.trace, want);
}
