//! Running a scenario on the host in [`rtseq::sim::Sim`] (feature `std`).

extern crate std;

use std::vec::Vec;

use rtseq::sim::Sim;
use rtseq::{Duration, Record, Transition};

use crate::{Arena, Ctrl, Scenario, ScenarioError, Seqr, Summary, CHILDREN};

/// What a host run produced.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Every transition, in order.
    pub trace: Vec<Transition>,
    /// Every record (transitions and events), in order.
    pub records: Vec<Record>,
    /// What the actions did.
    pub summary: Summary,
    /// Transitions lost to trace overflow (0).
    pub lost: u32,
}

/// Runs `scenario` exactly as the firmware does: set up, declare lanes (in order), start
/// at time 0, then `ticks` ticks of 1 ms, the script before each.
///
/// ```
/// let sc = rtseq_scenarios::find("abort_request").unwrap();
/// let run = rtseq_scenarios::host::run(sc).unwrap();
/// assert_eq!(run.trace.len(), 6); // main and S start, both aborted at 2 ms
/// assert_eq!(run.summary.dead_lines, 0);
/// ```
pub fn run(scenario: &Scenario) -> Result<Run, ScenarioError> {
    let seq = Seqr::new();
    let ctrl = Ctrl::new();
    let mut children = [const { None }; CHILDREN];
    let setup = (scenario.register)(&seq, Arena::new(&mut children))?;
    let mut sim = Sim::new(&seq, &ctrl, setup.monitors);
    for lane in setup.lanes {
        sim.lane(lane);
    }
    // All starts first, then let the lanes run once: what the firmware's `init` does.
    let mut start = setup.start.iter().peekable();
    while let Some(&id) = start.next() {
        if start.peek().is_some() {
            seq.sequence_by_id(id)
                .ok_or(rtseq::Error::UnknownSequence(id))?
                .start()?;
        } else {
            sim.start(id)?;
        }
    }
    let script = scenario.script;
    let s = &seq;
    sim.before_tick(move |t, c| {
        let ms = u32::try_from(t.as_ticks() / 1_000).unwrap_or(u32::MAX);
        script(ms, c, s)
    });
    sim.run_for(Duration::from_millis(u64::from(scenario.ticks)));
    let records = sim.records().to_vec();
    let trace = sim.take_trace();
    let lost = sim.lost();
    drop(sim);
    Ok(Run {
        trace,
        records,
        summary: ctrl.summary(),
        lost,
    })
}
