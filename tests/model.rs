//! A reference model of the sequencer's documented semantics (docs/semantics.md items 1 and
//! 3-8, docs/firmware-guide.md section 2), written from the documents alone, compared with
//! the simulator on exact traces (times, sequences, states, causes) and on whether each
//! request is taken, over scenarios generated from seeds.
//!
//! Modelled: one main sequence (`MMain`, running 1 to 3 blocking steps in turn, each an
//! `MLeaf` whose exit flag becomes true at a given time, or a `Wait`); polling periods of 1, 2
//! and 5 ms and their grids; timeouts (`Nothing`, `AbortOwner`, `RestartOwner` with a limit)
//! of main and of the steps, with or without an exception sequence; 0 to 2 monitors, owned by
//! main or a step, whose condition is true during a window (`Level`, `RisingEdge`, and with
//! more triggers `FallingEdge` and `Change`), with the behaviours `Nothing`, `AbortOwner`,
//! `RestartOwner` with a limit and `PauseOwner`, each with or without an exception sequence
//! (a `Node` running one `Wait`); pre-conditions false during a window (of the `MLeaf`s, and
//! of main, seen by its restarts) and actions failing during a window (of the `MLeaf`s);
//! pause, resume and abort requests of main or of a step, and abort-alls, made just before
//! given ticks; ticks 1 ms apart, or 1 to 7 ms apart (late ticks: missed polls, timeouts and
//! waits falling due between ticks).
//!
//! With `tree` (session 54c): a sub-sequence (id k, after the steps; main is k + 1) between
//! main and 1 or 2 of the steps, main running a step before and after it or not; it owns
//! monitors and a timeout (with or without an exception sequence) and takes pause, resume
//! and abort requests; pauses, resumes, holds and the lane's advance walk the blocking chain
//! (`child`, `blocking_caller`). With `caller`: `AbortCallerOfOwner` and
//! `RestartCallerOfOwner` (monitors and timeouts), acting on the owner's blocking caller (the
//! owner itself for main), the restart limit judged on the target's run (item 5). `MODEL_BREAK`
//! breaks a named rule for a bite check (`broken`).
//!
//! With `nb` (session 54d): the sub-sequence is not run blocking but started non-blocking in
//! its own lane (`Cx::start`, or `Cx::start_scoped` holding the `Scoped`), after main's steps
//! before it; main's later steps have a `Scoped::join`/`Cx::join`, a drop or a detach of the
//! `Scoped` among them, or none (a `Scoped` dropped at the action's end). Its caller link to
//! main outlives main's run (item 11): aborts, restarts and abort-alls of main take it down
//! (item 4), main's pauses and exceptions do not hold it (items 3, 7), its `…CallerOfOwner`
//! behaviours act on main's run under way, or abort it when main has ended (`Behaviour`);
//! a dropped `Scoped` requests its abort, which holds it until the next tick (items 8, 11);
//! a join waits for the run under way (item 14); the application starts main again
//! (`Handle::start`, `AlreadyRunning` while it runs, taken and held while an abort-all
//! waits); the child may join main after its steps (a cycle of joins, item 14: it found,
//! in session 54, joins after a restart refused as cycles that no run under way closed,
//! `tests/join_after_restart.rs`).
//!
//! With `sub_pre_fail` (session 55): the sub-sequence's pre-condition is false during a
//! window (seen by its starts and restarts, blocking or in its lane), its action and main's
//! fail at their end during a window. Every request's result is compared exactly (`Ok` or
//! which `Error`, from the rustdoc of `Error` and `Handle`), not only whether it was taken.
//!
//! With `prios` (session 55): lanes of RTIC priorities 1 to 3, dispatched as the simulator's
//! module doc says RTIC does (`Model::lanes`).
//!
//! With `exc_requests` (session 55): pause, resume and abort requests of the exception
//! sequences (each pauses or aborts the `Wait` it blocks on with it; an aborted one has
//! ended, item 3).
//!
//! With `set_timeout` (session 55): `Handle::set_timeout` of main, the sub-sequence or a
//! step (a time, or off), at once for a round begun with a timeout, else from the next
//! start or restart (its rustdoc); the behaviour `AbortOwner` unless configured.
//!
//! Every join's result is compared too (at which ms, by whom, `Ok` with the joined run's
//! outcome or which `Error`), with a scenario of its own for `OutcomeLost` (session 55).
//! With `held_joins` (session 56): the child that joins main is paused around the end of
//! main's run, main started again and the child resumed, so the sweeps reach `OutcomeLost`.
//!
//! Not modelled: deeper trees, the safety system, lanes above the tick's priority, events
//! and counters.
//!
//! Every rule the model encodes names its item (or the rustdoc it comes from). It found,
//! in session 54, that the tick applied a sequence's request before the behaviour of
//! another's ended exception sequence when its id was lower (now every behaviour comes
//! first, item 8), and where the documents were silent (the requests of a `Restarting`
//! blocking child, or of a child paused by its caller alone: now in the rustdoc of
//! `Error::NotRunning` and `Error::AlreadyPaused`).
//!
//! Each sweep compares a range of seeds with one combination of the generator's features;
//! two rules the sweeps seldom reach have a scenario of their own. `MODEL_N=n` sweeps `n`
//! seeds per test instead of 2000; `MODEL_SEED=s` runs seed `s` only, in the test whose range
//! holds it (a failure names its seeds and the command):
//! `MODEL_SEED=400017 cargo test --test model with_everything`.

mod common;
use common::*;
use rtseq::lock::CriticalSection;
use rtseq::sim::{Sim, DEFAULT_LANE_PRIORITY};
use rtseq::RunningState::{self, *};
use rtseq::{
    Behaviour, Cause, ConditionFn, Cx, Done, Duration, Error, Failure, Instant, Monitor, MonitorId,
    Monitors, Outcome, Seq, SeqConfig, SeqId, Sequence, Sequencer, Step, Transition, Trigger, Wait,
};
use std::collections::{BTreeMap, BTreeSet};

// ---------------------------------------------------------------- scenario

#[derive(Clone, Copy, Debug, PartialEq)]
enum Beh {
    Nothing,
    Abort,
    /// `RestartOwner` with this restart limit.
    Restart(u8),
    Pause,
    /// `AbortCallerOfOwner`.
    CallerAbort,
    /// `RestartCallerOfOwner` with this restart limit.
    CallerRestart(u8),
}

#[derive(Clone, Copy, Debug)]
enum Exit {
    /// A `Leaf` whose exit flag is true from this time (ms) on.
    Flag(u64),
    /// A `Wait` of this many ms.
    Wait(u64),
}

#[derive(Clone, Debug)]
struct StepCfg {
    period: u64,
    exit: Exit,
    /// (ms, behaviour).
    timeout: Option<(u64, Beh)>,
    /// The timeout's exception sequence: a `Node` running a `Wait` of this many ms.
    timeout_exc: Option<u64>,
    /// The pre-condition is false for `from <= t < to` (a `Flag` step only).
    pre_false: Option<(u64, u64)>,
    /// The action fails (`Err`) when it runs at `from <= t < to` (a `Flag` step only).
    fail: Option<(u64, u64)>,
}

/// The sub-sequence (a `Node`-like `MMain` with no pre-condition) between main and the
/// steps `first..first + len`: main runs the steps before `first`, then the sub-sequence, then
/// the steps after it. Its id is k (after the steps), main's k + 1.
#[derive(Clone, Debug)]
struct SubCfg {
    period: u64,
    first: usize,
    len: usize,
    timeout: Option<(u64, Beh)>,
    timeout_exc: Option<u64>,
    /// With `sub_pre_fail`: the pre-condition is false for `from <= t < to` (seen by its
    /// starts and restarts), and the action fails (`Err`) when it ends (after its ops) at
    /// `from <= t < to`.
    pre_false: Option<(u64, u64)>,
    fail: Option<(u64, u64)>,
    /// With `nb` (session 54d): not run blocking but started non-blocking in its own lane
    /// (`Cx::start`, or `Cx::start_scoped` if `scoped`); main's ops are then `main_ops`.
    nb: Option<bool>,
}

/// Main's ops with a non-blocking sub-sequence (`SubCfg::nb`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum MainOp {
    /// Step i, blocking.
    Step(usize),
    /// `Cx::start` of the sub-sequence (`Cx::start_scoped` if it is scoped).
    Start,
    /// `Scoped::join` (`Cx::join` if the start was refused or not scoped).
    Join,
    /// The `Scoped` dropped (nothing if none is held).
    Drop,
    /// `Scoped::detach`.
    Detach,
}

#[derive(Clone, Debug)]
struct MonCfg {
    /// The owner's id: 0..k a step, then the sub-sequence (if any), then main.
    owner: usize,
    /// The condition is true for `from <= t < to`.
    from: u64,
    to: u64,
    trigger: Trigger,
    beh: Beh,
    /// An exception sequence: a `Node` running a `Wait` of this many ms.
    exception: Option<u64>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Req {
    Pause,
    Resume,
    Abort,
    /// `Sequencer::abort_all` (its target is ignored).
    AbortAll,
    /// `Handle::start` of main by the application (its target is ignored).
    Start,
    /// `Handle::set_timeout` (ms), at once.
    SetTimeout(Option<u64>),
}

#[derive(Clone, Debug)]
struct Scenario {
    steps: Vec<StepCfg>,
    sub: Option<SubCfg>,
    /// Main's ops when the sub-sequence is non-blocking.
    main_ops: Vec<MainOp>,
    /// The non-blocking sub-sequence joins main (`Cx::join`) after its steps.
    bg_joins_main: bool,
    main_period: u64,
    main_timeout: Option<(u64, Beh)>,
    main_timeout_exc: Option<u64>,
    /// Main's pre-condition is false for `from <= t < to` (seen by its restarts).
    main_pre_false: Option<(u64, u64)>,
    /// With `sub_pre_fail`: main's action fails (`Err`) when it ends at `from <= t < to`.
    main_fail: Option<(u64, u64)>,
    monitors: Vec<MonCfg>,
    /// (time, target, request): the target is a sequence id (as a monitor's owner); made
    /// just before the first tick at or after `time`.
    requests: Vec<(u64, usize, Req)>,
    /// The ticks' times (ms), increasing; main starts at 0.
    ticks: Vec<u64>,
    /// With `prios`: the RTIC priority of each lane in the order they are added (main's,
    /// the non-blocking sub-sequence's, the exception sequences'); empty: all of
    /// `DEFAULT_LANE_PRIORITY`.
    prios: Vec<u8>,
}

/// Bite checks: `MODEL_BREAK=name` breaks the rule the model names so (see the final report
/// of session 54c); the sweeps that reach the rule must then fail.
fn broken(name: &str) -> bool {
    static B: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    B.get_or_init(|| std::env::var("MODEL_BREAK").unwrap_or_default()) == name
}

/// A lane of the model: main's, the non-blocking sub-sequence's, or exception sequence x's.
#[derive(Clone, Copy, Debug)]
enum Lane {
    Main,
    Bg,
    Exc(usize),
}

/// Main's non-blocking ops in the model's `ops` (above every sequence id).
const OP_START: usize = usize::MAX;
const OP_JOIN: usize = usize::MAX - 1;
const OP_DROP: usize = usize::MAX - 2;
const OP_DETACH: usize = usize::MAX - 3;
/// The non-blocking sub-sequence's join of main.
const OP_JOIN_MAIN: usize = usize::MAX - 4;

fn exit_flag(t: u64, at: u64) -> bool {
    t >= at
}

fn cond(m: &MonCfg, t: u64) -> bool {
    m.from <= t && t < m.to
}

fn within(w: Option<(u64, u64)>, t: u64) -> bool {
    w.is_some_and(|(a, b)| a <= t && t < b)
}

// ---------------------------------------------------------------- model

/// Where an exception comes from: a monitor or a sequence's timeout.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Src {
    Mon(usize),
    Timeout(usize),
}

/// An exception sequence (a `Node` running one `Wait`) of a monitor or a timeout.
#[derive(Clone, Copy, Debug)]
struct ExcDef {
    src: Src,
    owner: usize,
    /// The `Node` and its `Wait`.
    e: usize,
    w: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Step,
    /// The sub-sequence: runs steps, blocking, and blocks main.
    Sub,
    /// The non-blocking sub-sequence: runs steps, blocking, in its own lane; main is its
    /// caller (item 11), which it does not block.
    Bg,
    Main,
    /// Exception sequence x (`Model::excs`).
    Exc(usize),
    /// The `Wait` of exception sequence x.
    ExcWait(usize),
}

#[derive(Clone, Debug)]
struct MSeq {
    kind: Kind,
    state: RunningState,
    period: u64,
    /// As configured: its time and behaviour.
    timeout: Option<(u64, Beh)>,
    /// Its time now (`Handle::set_timeout`), and whether the round began with one (armed).
    timeout_ms: Option<u64>,
    armed: bool,
    exit: Option<Exit>,
    /// The start of the round (the run's start or its last restart).
    round_start: u64,
    paused_total: u64,
    paused_since: Option<u64>,
    timeout_fired: bool,
    /// Restarts monitors and timeouts made of this run.
    restarts: u8,
    /// `PauseOwner` monitors holding it.
    holds: u32,
    /// The exception (with an exception sequence) being handled.
    exc: Option<Src>,
    /// That exception sequence ended: the next tick applies the behaviour.
    exc_ended: bool,
    /// A pause request holds it (item 7), and the requests queued for the next tick (8).
    pause_req: bool,
    pending_pause: bool,
    pending_resume: bool,
    pending_abort: bool,
}

impl MSeq {
    fn new(kind: Kind, period: u64, timeout: Option<(u64, Beh)>, exit: Option<Exit>) -> Self {
        MSeq {
            kind,
            state: Idle,
            period,
            timeout,
            timeout_ms: timeout.map(|t| t.0),
            armed: false,
            exit,
            round_start: 0,
            paused_total: 0,
            paused_since: None,
            timeout_fired: false,
            restarts: 0,
            holds: 0,
            exc: None,
            exc_ended: false,
            pause_req: false,
            pending_pause: false,
            pending_resume: false,
            pending_abort: false,
        }
    }

    fn active(&self) -> bool {
        matches!(self.state, Running | Paused | Restarting | Aborting)
    }

    /// The run's clock (items 6, 7): from the round's start, paused time excluded.
    fn run_time(&self, t: u64) -> u64 {
        let p = self.paused_since.map_or(0, |s| t - s);
        t - self.round_start - self.paused_total - p
    }
}

struct Model<'s> {
    sc: &'s Scenario,
    /// Main's index (k, or k + 1 with a sub-sequence).
    k: usize,
    seqs: Vec<MSeq>,
    /// The exception sequences: the monitors' in table order, then the timeouts' by owner.
    excs: Vec<ExcDef>,
    /// What each sequence runs, blocking, in turn (main and the sub-sequence; empty for the
    /// others), and the op its action is at.
    ops: Vec<Vec<usize>>,
    pcs: Vec<usize>,
    /// The next grid point of each polling class that has one.
    grid: BTreeMap<u64, u64>,
    /// Each monitor's last value.
    last: Vec<bool>,
    /// Each `PauseOwner` monitor holds its owner.
    holding: Vec<bool>,
    /// An abort-all was asked for (item 8).
    pending_abort_all: bool,
    /// Started, its lane has not taken it up yet (main, the non-blocking sub-sequence).
    fresh: Vec<bool>,
    /// Runs of each sequence (starts, not restarts).
    runs: Vec<u32>,
    /// The run each sequence's join waits for (main's of the sub-sequence, the
    /// sub-sequence's of main), set when the join begins to wait.
    joined_run: Vec<u32>,
    /// The outcome of each sequence's last ended run (what its control block keeps).
    outcome: Vec<Option<Outcome>>,
    /// What each join returned: at which ms, to which sequence.
    joins: Joins,
    /// The run of the non-blocking sub-sequence main holds a `Scoped` of.
    scoped: Option<u32>,
    /// The non-blocking sub-sequence's id.
    bg: Option<usize>,
    trace: Vec<Transition>,
    /// Whether each request was taken.
    req_ok: Vec<Result<(), Error>>,
    /// How often each rare case came (`the_sweeps_reach_the_caller_cases`).
    reached: BTreeMap<&'static str, usize>,
    t: u64,
}

impl<'s> Model<'s> {
    fn new(sc: &'s Scenario) -> Self {
        let ns = sc.steps.len();
        let mut seqs: Vec<MSeq> = sc
            .steps
            .iter()
            .map(|s| MSeq::new(Kind::Step, s.period, s.timeout, Some(s.exit)))
            .collect();
        let mut main_ops: Vec<usize> = (0..ns).collect();
        let mut sub_ops = vec![];
        let mut bg = None;
        if let Some(sub) = &sc.sub {
            let kind = if sub.nb.is_some() {
                Kind::Bg
            } else {
                Kind::Sub
            };
            seqs.push(MSeq::new(kind, sub.period, sub.timeout, None));
            sub_ops = (sub.first..sub.first + sub.len).collect();
            main_ops = (0..sub.first)
                .chain([ns])
                .chain(sub.first + sub.len..ns)
                .collect();
            if sub.nb.is_some() {
                bg = Some(ns);
                if sc.bg_joins_main {
                    sub_ops.push(OP_JOIN_MAIN);
                }
                main_ops = sc
                    .main_ops
                    .iter()
                    .map(|o| match *o {
                        MainOp::Step(i) => i,
                        MainOp::Start => OP_START,
                        MainOp::Join => OP_JOIN,
                        MainOp::Drop => OP_DROP,
                        MainOp::Detach => OP_DETACH,
                    })
                    .collect();
            }
        }
        let k = seqs.len();
        seqs.push(MSeq::new(Kind::Main, sc.main_period, sc.main_timeout, None));
        let mut ops = vec![vec![]; k + 1];
        ops[k] = main_ops;
        if sc.sub.is_some() {
            ops[ns] = sub_ops;
        }
        // Added W, then E (as `run_rtseq` does): the monitors', then the timeouts'.
        let mut wanted: Vec<(Src, usize, u64)> = vec![];
        for (j, mc) in sc.monitors.iter().enumerate() {
            if let Some(d) = mc.exception {
                wanted.push((Src::Mon(j), mc.owner, d));
            }
        }
        for (i, d) in timeout_excs(sc) {
            wanted.push((Src::Timeout(i), i, d));
        }
        let mut excs = vec![];
        for (src, owner, d) in wanted {
            let x = excs.len();
            let w = seqs.len();
            seqs.push(MSeq::new(Kind::ExcWait(x), 1, None, Some(Exit::Wait(d))));
            let e = seqs.len();
            seqs.push(MSeq::new(Kind::Exc(x), 1, None, None));
            excs.push(ExcDef { src, owner, e, w });
        }
        let n = sc.monitors.len();
        ops.resize(seqs.len(), vec![]);
        let pcs = vec![0; seqs.len()];
        let (fresh, runs) = (vec![false; seqs.len()], vec![0; seqs.len()]);
        Model {
            sc,
            k,
            seqs,
            excs,
            ops,
            pcs,
            grid: BTreeMap::new(),
            last: vec![false; n],
            holding: vec![false; n],
            pending_abort_all: false,
            fresh,
            joined_run: runs.clone(),
            outcome: vec![None; runs.len()],
            joins: vec![],
            runs,
            scoped: None,
            bg,
            trace: vec![],
            req_ok: vec![],
            reached: BTreeMap::new(),
            t: 0,
        }
    }

    fn hit(&mut self, what: &'static str) {
        *self.reached.entry(what).or_default() += 1;
    }

    fn mon_cause(j: usize) -> Cause {
        Cause::Monitor(MonitorId::from_index(j))
    }

    fn src_cause(src: Src) -> Cause {
        match src {
            Src::Mon(j) => Self::mon_cause(j),
            Src::Timeout(i) => Cause::Timeout(SeqId::from_index(i)),
        }
    }

    /// `SeqConfig::timeout_behaviour`: `AbortOwner` unless configured.
    fn timeout_beh(&self, i: usize) -> Beh {
        self.seqs[i].timeout.map_or(Beh::Abort, |t| t.1)
    }

    fn src_beh(&self, src: Src) -> Beh {
        match src {
            Src::Mon(j) => self.sc.monitors[j].beh,
            Src::Timeout(i) => self.timeout_beh(i),
        }
    }

    /// Item 2: every transition is recorded as (time, sequence, from, to, cause).
    fn mv(&mut self, i: usize, to: RunningState, cause: Cause) {
        let from = self.seqs[i].state;
        self.trace
            .push(tr(self.t, SeqId::from_index(i), from, to, cause));
        let t = self.t;
        let s = &mut self.seqs[i];
        // Item 7: the run's clock stops while it is paused.
        if to == Paused && from != Paused {
            s.paused_since = Some(t);
        }
        if from == Paused && to != Paused {
            if let Some(p) = s.paused_since.take() {
                s.paused_total += t - p;
            }
        }
        s.state = to;
        // `Outcome`: the end of a run (main's and the sub-sequence's failures are
        // `Failure::App(2)`, the steps' `App(1)`).
        let fail = if self.seqs[i].kind == Kind::Step {
            1
        } else {
            2
        };
        let ended = match (to, cause) {
            (Terminated, Cause::Completed) => Some(Outcome::Completed),
            (Terminated, Cause::PreConditionFalse) => Some(Outcome::Skipped),
            (Terminated, Cause::Failed) => Some(Outcome::Failed(Failure::App(fail))),
            (Aborted, c) => Some(Outcome::Aborted(c)),
            _ => None,
        };
        if ended.is_some() {
            self.outcome[i] = ended;
        }
    }

    /// A join by `c` returns `r` now.
    fn joined(&mut self, c: usize, r: Result<Outcome, Error>) {
        self.joins.push((self.t, SeqId::from_index(c), r));
    }

    /// Item 14: what a join of `target`'s run `run` gets once that run is no longer the one
    /// under way: its outcome while it is the last run, ended, or the one before the run
    /// under way; else `OutcomeLost` (a control block keeps one outcome).
    fn outcome_of(&self, target: usize, run: u32) -> Result<Outcome, Error> {
        let kept = match self.runs[target] - run {
            0 => !self.seqs[target].active(),
            1 => self.seqs[target].active(),
            _ => false,
        };
        if kept || broken("outcome_lost") {
            Ok(self.outcome[target].expect("an ended run has an outcome"))
        } else {
            Err(Error::OutcomeLost(SeqId::from_index(target)))
        }
    }

    fn main(&self) -> usize {
        self.k
    }

    /// The sequence `c` (main, the sub-sequence or an exception sequence) blocks on, if it
    /// is active.
    fn child(&self, c: usize) -> Option<usize> {
        if let Kind::Exc(x) = self.seqs[c].kind {
            let w = self.excs[x].w;
            return self.seqs[w].active().then_some(w);
        }
        let ch = *self.ops[c].get(self.pcs[c])?;
        (ch < OP_JOIN_MAIN && self.seqs[ch].active()).then_some(ch)
    }

    /// The blocking caller of a step or of the sub-sequence.
    fn blocking_caller(&self, i: usize) -> Option<usize> {
        match self.seqs[i].kind {
            Kind::Step | Kind::Sub => (0..self.seqs.len()).find(|&c| self.ops[c].contains(&i)),
            _ => None,
        }
    }

    /// Item 3: an exception sequence runs with its owner as its caller.
    fn caller(&self, i: usize) -> Option<usize> {
        match self.seqs[i].kind {
            Kind::Main => None,
            // Item 11: links are of sequences: main, ended or not.
            Kind::Bg => Some(self.main()),
            Kind::Step | Kind::Sub => self.blocking_caller(i),
            Kind::Exc(x) => Some(self.excs[x].owner),
            Kind::ExcWait(x) => Some(self.excs[x].e),
        }
    }

    fn depth(&self, i: usize) -> usize {
        self.caller(i).map_or(0, |c| self.depth(c) + 1)
    }

    fn below(&self, i: usize, root: usize) -> bool {
        let mut x = i;
        loop {
            if x == root {
                return true;
            }
            match self.caller(x) {
                Some(c) => x = c,
                None => return false,
            }
        }
    }

    /// Item 7: held by a pause (a request or a `PauseOwner` monitor), its own or that of the
    /// caller it blocks; exception sequences are not blocking children.
    fn paused_hold(&self, i: usize) -> bool {
        let own = self.seqs[i].pause_req || self.seqs[i].holds > 0;
        match self.seqs[i].kind {
            // Items 7, 11: a paused caller does not pause a non-blocking child.
            Kind::Main => own,
            Kind::Bg => {
                own || broken("bg_paused_with_main") && {
                    let m = self.main();
                    self.seqs[m].pause_req || self.seqs[m].holds > 0
                }
            }
            Kind::Step | Kind::Sub => {
                own || self.blocking_caller(i).is_some_and(|c| {
                    if broken("pause_chain") {
                        self.seqs[c].pause_req || self.seqs[c].holds > 0
                    } else {
                        self.paused_hold(c)
                    }
                })
            }
            // Item 7: the `Wait` an exception sequence blocks on is paused with it.
            Kind::Exc(_) => own,
            Kind::ExcWait(x) => own || self.paused_hold(self.excs[x].e),
        }
    }

    /// Items 1, 3, 7: may not advance: paused, or handling an exception, or blocking a caller
    /// that is (item 3: the hold is the owner's and that of its blocking children).
    fn held(&self, i: usize) -> bool {
        match self.seqs[i].kind {
            Kind::Main | Kind::Step | Kind::Sub | Kind::Bg => {
                self.paused_hold(i) || {
                    let mut x = Some(i);
                    let mut exc = false;
                    let mut up = 0;
                    if broken("bg_held_by_main_exc") && self.seqs[i].kind == Kind::Bg {
                        exc |= self.seqs[self.main()].exc.is_some();
                    }
                    while let Some(c) = x {
                        exc |= self.seqs[c].exc.is_some();
                        // Item 8: from an abort request to the tick that carries it out the
                        // run's await points hold (a `Scoped` dropped between ticks).
                        exc |= self.seqs[c].pending_abort && !broken("abort_request_hold");
                        x = self.blocking_caller(c);
                        up += 1;
                        if broken("exc_hold_chain") && up == 2 {
                            break;
                        }
                    }
                    exc
                }
            }
            // Items 7, 8: an exception sequence (and the `Wait` it blocks on) holds while
            // paused, and from an abort request to the tick that carries it out.
            Kind::Exc(x) | Kind::ExcWait(x) => {
                let e = self.excs[x].e;
                self.paused_hold(i) || self.seqs[e].pending_abort
            }
        }
    }

    /// Items 1, 6: a start or a restart begins a round with a fresh clock and timeout.
    fn reset_round(&mut self, i: usize) {
        let t = self.t;
        let s = &mut self.seqs[i];
        s.round_start = t;
        s.paused_total = 0;
        s.paused_since = None;
        s.timeout_fired = false;
        // `Handle::set_timeout`: a round begun with a timeout is armed.
        s.armed = s.timeout_ms.is_some();
    }

    /// Items 5, 7: the monitors of a run or a restart start again from "false", holding
    /// nothing, with no exception under way.
    fn reset_monitors(&mut self, i: usize) {
        for j in 0..self.sc.monitors.len() {
            if self.sc.monitors[j].owner == i {
                self.last[j] = false;
                self.holding[j] = false;
            }
        }
        self.seqs[i].holds = 0;
        self.seqs[i].exc = None;
        self.seqs[i].exc_ended = false;
    }

    fn start(&mut self, i: usize, cause: Cause) {
        // Item 1: a start into a class with no active member polls one period after the
        // start; a start into a busy class joins its grid.
        let p = self.seqs[i].period;
        let busy = (0..self.seqs.len())
            .any(|o| o != i && self.seqs[o].period == p && self.seqs[o].active());
        if !busy {
            self.grid.insert(p, self.t + p);
        }
        self.mv(i, Running, cause);
        self.runs[i] += 1;
        self.reset_round(i);
        // Item 5: a new run begins with no restarts (bite check: not the sub-sequence's).
        if !(broken("new_run_count") && self.seqs[i].kind == Kind::Sub) {
            self.seqs[i].restarts = 0;
        }
        self.reset_monitors(i);
    }

    fn exit_true(&self, i: usize) -> bool {
        match self.seqs[i].exit {
            Some(Exit::Flag(at)) => exit_flag(self.t, at),
            Some(Exit::Wait(d)) => self.seqs[i].run_time(self.t) >= d,
            None => true,
        }
    }

    /// The action of `c` (main or the sub-sequence) from its op `pcs[c]` on: starts its
    /// children in turn; item 1: a step's exit condition is checked right after its action,
    /// so one that holds at once ends it, and so does that of `c` (always true) once its
    /// last child ended. True if `c` ended.
    fn begin_steps(&mut self, c: usize) -> bool {
        loop {
            let Some(&s) = self.ops[c].get(self.pcs[c]) else {
                // Item 16: an action's `Err` ends its run at once, `Failed`; item 1: `Ok`
                // and the exit condition (always true here) end it `Completed`.
                let end = if within(self.fail_window(c), self.t) && !broken("sub_fail") {
                    Cause::Failed
                } else {
                    Cause::Completed
                };
                self.mv(c, Terminated, end);
                if c == self.main() && self.bg.is_some_and(|b| self.seqs[b].active()) {
                    self.hit("nb: the child outlives its caller");
                }
                if c == self.main() {
                    // Item 11: the action returns: its `Scoped` is dropped.
                    self.drop_scoped();
                }
                return true;
            };
            if s >= OP_JOIN_MAIN {
                let bg = self.bg.unwrap();
                match s {
                    OP_JOIN_MAIN => {
                        let m = self.main();
                        if self.seqs[m].active() {
                            if self.waits_in(m, OP_JOIN) && !broken("join_cycle") {
                                // Item 14: a join that closes a cycle of waits is
                                // `JoinWouldDeadlock`, returned at once.
                                self.hit("nb: join cycle refused");
                                self.joined(c, Err(Error::JoinWouldDeadlock(SeqId::from_index(m))));
                            } else {
                                self.joined_run[c] = self.runs[m];
                                return false;
                            }
                        } else {
                            self.joined(c, self.outcome_of(m, self.runs[m]));
                        }
                    }
                    OP_START => {
                        // Item 9: a start of a running sequence is `AlreadyRunning`.
                        if self.seqs[bg].active() {
                            self.hit("nb: start refused, AlreadyRunning");
                        }
                        if !self.seqs[bg].active() || broken("start_running") {
                            self.start(bg, Cause::Start);
                            self.fresh[bg] = true;
                            self.scoped = (self.sc.sub.as_ref().unwrap().nb == Some(true))
                                .then_some(self.runs[bg]);
                        }
                    }
                    // Item 14: the join waits for the run under way (or returns the last one's
                    // outcome).
                    OP_JOIN => {
                        let cycle = self.waits_in(bg, OP_JOIN_MAIN) && !broken("join_cycle");
                        if cycle {
                            self.hit("nb: join cycle refused");
                        }
                        if self.seqs[bg].active() && !broken("join_returns_at_once") && !cycle {
                            self.hit("nb: join waits");
                            self.joined_run[c] = self.runs[bg];
                            return false;
                        }
                        let r = if cycle {
                            Err(Error::JoinWouldDeadlock(SeqId::from_index(bg)))
                        } else {
                            self.outcome_of(bg, self.runs[bg])
                        };
                        self.joined(c, r);
                    }
                    OP_DROP => self.drop_scoped(),
                    _ => self.scoped = None,
                }
                self.pcs[c] += 1;
                continue;
            }
            self.start(s, Cause::Start);
            if self.child_round(s) {
                self.pcs[c] += 1;
            } else {
                return false;
            }
        }
    }

    /// A round of a child (a step, or the sub-sequence from its pre-condition and first
    /// op); true if it ended.
    fn child_round(&mut self, s: usize) -> bool {
        if self.seqs[s].kind == Kind::Sub {
            // Item 1: a round begins with the pre-condition; false, the run ends.
            if within(self.pre_window(s), self.t) && !broken("sub_pre") {
                self.mv(s, Terminated, Cause::PreConditionFalse);
                return true;
            }
            self.pcs[s] = 0;
            self.begin_steps(s)
        } else {
            self.step_round(s)
        }
    }

    /// Item 1: a step's round from its pre-condition (false: skipped) through its action
    /// (item 16: `Err` ends the run at once, `Failed`) to the exit condition checked right
    /// after the action; true if the run ended.
    fn step_round(&mut self, s: usize) -> bool {
        let t = self.t;
        let cfg = &self.sc.steps[s];
        let end = if within(cfg.pre_false, t) {
            Cause::PreConditionFalse
        } else if within(cfg.fail, t) {
            Cause::Failed
        } else if self.exit_true(s) {
            Cause::Completed
        } else {
            return false;
        };
        self.mv(s, Terminated, end);
        true
    }

    /// Item 8: an abort-all aborts every active sequence, innermost first (item 4); every
    /// sequence here is below main.
    fn abort_all(&mut self) {
        let m = self.main();
        self.abort_below(m, true, Cause::AbortAll);
    }

    /// Item 4: aborts the active sequences below `root` (and `root` too if `with_root`),
    /// innermost first: by depth, and within a depth by id.
    fn abort_below(&mut self, root: usize, with_root: bool, cause: Cause) {
        let mut v: Vec<usize> = (0..self.seqs.len())
            .filter(|&x| self.seqs[x].active() && self.below(x, root) && (with_root || x != root))
            .collect();
        if broken("innermost") {
            v.sort_by_key(|&x| (std::cmp::Reverse(self.depth(x).min(2)), x));
        } else {
            v.sort_by_key(|&x| (std::cmp::Reverse(self.depth(x)), x));
        }
        for x in v {
            self.mv(x, Aborting, cause);
            self.mv(x, Aborted, cause);
            self.reset_monitors(x);
            // Item 7: the end of the run lifts a pause request.
            self.seqs[x].pause_req = false;
        }
    }

    fn apply(&mut self, i: usize, beh: Beh, cause: Cause) {
        // `Behaviour::AbortCallerOfOwner`/`RestartCallerOfOwner`: like `AbortOwner`/
        // `RestartOwner`, one level up: the owner's caller (the owner itself for a main
        // sequence); item 5: the limit is judged on the target's run.
        let owner = i;
        let caller_beh = matches!(beh, Beh::CallerAbort | Beh::CallerRestart(_));
        let target = if broken("caller_target") {
            i
        } else if broken("caller_main")
            && self.seqs[i].kind == Kind::Main
            && matches!(beh, Beh::CallerAbort | Beh::CallerRestart(_))
        {
            return;
        } else if self.seqs[i].kind == Kind::Bg {
            // `Behaviour::AbortCallerOfOwner`: a non-blocking owner whose caller has ended is
            // aborted itself; a caller started again since is acted on in its run under way.
            let m = self.main();
            if matches!(beh, Beh::CallerAbort | Beh::CallerRestart(_)) {
                if !self.seqs[m].active() {
                    self.hit("nb: caller behaviour, caller ended");
                } else if self.runs[m] > 1 {
                    self.hit("nb: caller behaviour on the caller started again");
                }
            }
            if self.seqs[m].active() || broken("bg_caller_ended") {
                m
            } else {
                i
            }
        } else {
            self.blocking_caller(i).unwrap_or(i)
        };
        let (i, beh) = match beh {
            Beh::CallerAbort => (target, Beh::Abort),
            // `Behaviour::RestartCallerOfOwner`: one whose caller has ended is aborted.
            Beh::CallerRestart(_) if target == owner && self.seqs[owner].kind == Kind::Bg => {
                (owner, Beh::Abort)
            }
            Beh::CallerRestart(l) => (target, Beh::Restart(l)),
            b => (i, b),
        };
        // Bite check: the limit judged on the owner's run instead of the target's.
        let judged = if broken("caller_limit") { owner } else { i };
        if i != owner {
            let mut hit = |k| *self.reached.entry(k).or_default() += 1;
            hit("caller behaviour");
            if self.seqs[i].exc.is_some() {
                hit("caller behaviour on a target handling its own exception");
            }
            if self.seqs[i].pause_req || self.seqs[i].holds > 0 {
                hit("caller behaviour on a paused target");
            }
            if let Beh::Restart(l) = beh {
                if self.seqs[i].restarts >= l {
                    hit("caller restart escalated");
                }
                if (self.seqs[i].restarts >= l) != (self.seqs[owner].restarts >= l) {
                    hit("caller restart: target and owner budgets judge differently");
                }
            }
            if self.seqs[i].kind == Kind::Sub {
                hit("caller behaviour on the sub-sequence");
            }
        } else if caller_beh {
            *self.reached.entry("caller behaviour of main").or_default() += 1;
        }
        match beh {
            Beh::Nothing | Beh::Pause | Beh::CallerAbort | Beh::CallerRestart(_) => {}
            Beh::Abort => self.abort_below(i, true, cause),
            Beh::Restart(limit) => {
                // Item 5: a restart whose limit the run's count has reached is an abort.
                if self.seqs[judged].restarts >= limit {
                    self.abort_below(i, true, cause);
                    return;
                }
                self.seqs[i].restarts += 1;
                self.abort_below(i, false, cause);
                // Items 4, 7: a pause ends with the round, carried out or not: a restart
                // runs unpaused, and a pause asked for just before the tick that applies an
                // exception sequence's restart is never seen.
                self.seqs[i].pause_req = false;
                self.seqs[i].pending_pause = false;
                self.mv(i, Restarting, cause);
                self.reset_monitors(i);
            }
        }
    }

    /// Item 7: pauses `i` and what it blocks, at their next await point (a `Restarting`
    /// sequence is passed over).
    fn pause_tree(&mut self, i: usize, cause: Cause) {
        if self.seqs[i].state == Running {
            self.mv(i, Paused, cause);
        }
        if let Some(c) = self.child(i) {
            if broken("pause_tree_chain") {
                if self.seqs[c].state == Running {
                    self.mv(c, Paused, cause);
                }
            } else {
                self.pause_tree(c, cause);
            }
        }
    }

    /// Item 7: resumes `i` if nothing holds it, and its blocking child if nothing holds that.
    fn resume_tree(&mut self, i: usize, cause: Cause) {
        if self.paused_hold(i) {
            return;
        }
        if self.seqs[i].state == Paused {
            self.mv(i, Running, cause);
        }
        if let Some(c) = self.child(i) {
            if broken("resume_chain") {
                if self.seqs[c].state == Paused && !self.paused_hold(c) {
                    self.mv(c, Running, cause);
                }
            } else {
                self.resume_tree(c, cause);
            }
        }
    }

    /// A request of sequence `i` made before the tick at `t` (the state is that after the
    /// tick before); item 8: the next tick applies it.
    fn request(&mut self, i: usize, r: Req) {
        // `Handle::pause`'s rustdoc: a pause needs a running or paused sequence, not one
        // between two rounds (`Restarting`: a blocking child held below a caller that handles
        // an exception or is paused); a resume too (`Error::NotPaused`). An abort of a
        // `Restarting` run is taken (item 4: a restart keeps the requests made of its run;
        // `Error::NotRunning`).
        if r == Req::Start {
            // `Handle::start`: of a running sequence `AlreadyRunning` (item 9); while an
            // abort-all waits it is taken and holds before its pre-condition (item 8).
            let m = self.main();
            let ok = !self.seqs[m].active();
            if ok && self.bg.is_some_and(|b| self.seqs[b].active()) {
                self.hit("nb: caller started again below which the child runs");
            }
            if ok && self.pending_abort_all {
                self.hit("nb: start while an abort-all waits");
            }
            if ok {
                self.start(m, Cause::Start);
                self.fresh[m] = true;
                self.lanes(&vec![false; self.seqs.len()]);
            }
            let id = SeqId::from_index(m);
            self.req_ok.push(if ok {
                Ok(())
            } else {
                Err(Error::AlreadyRunning(id))
            });
            return;
        }
        if let Req::SetTimeout(to) = r {
            self.seqs[i].timeout_ms = to;
            self.req_ok.push(Ok(()));
            return;
        }
        let active = match r {
            Req::Abort => self.seqs[i].active(),
            _ => matches!(self.seqs[i].state, Running | Paused),
        };
        let s = &mut self.seqs[i];
        let id = SeqId::from_index(i);
        let res = match r {
            Req::Start | Req::SetTimeout(_) => unreachable!(),
            // Item 8: an abort-all is a flag, carried out by the next tick.
            Req::AbortAll => {
                self.pending_abort_all = true;
                Ok(())
            }
            // Item 8: an abort of a run under way is taken; of one that ended, `NotRunning`.
            Req::Abort => {
                if active {
                    s.pending_abort = true;
                    Ok(())
                } else {
                    Err(Error::NotRunning(id))
                }
            }
            // Item 7: a pause of a sequence paused by a request, with no resume pending, is
            // `AlreadyPaused`; of a pause and a resume before one tick the later counts.
            Req::Pause => {
                if !active {
                    Err(Error::NotRunning(id))
                } else if s.pause_req && !s.pending_resume {
                    Err(Error::AlreadyPaused(id))
                } else {
                    s.pending_pause = true;
                    s.pending_resume = false;
                    Ok(())
                }
            }
            // Item 7: a resume while a monitor of its own holds is `HeldByMonitor`; `Error`'s
            // rustdoc: of a sequence not paused (and with no pause pending), `NotPaused`. One
            // paused only by the caller it blocks is paused: the resume is taken, and it
            // resumes with that caller (item 7).
            Req::Resume => {
                // Of a resume, pause, resume before one tick the last counts: the resume
                // cancels the pending pause and lifts the request's earlier pause.
                let paused = s.state == Paused || s.pending_pause || s.pause_req;
                if active && s.holds > 0 {
                    Err(Error::HeldByMonitor(id))
                } else if !active || !paused {
                    Err(Error::NotPaused(id))
                } else {
                    s.pending_pause = false;
                    s.pending_resume = s.pause_req;
                    Ok(())
                }
            }
        };
        self.req_ok.push(res);
    }

    /// Starts the exception sequence of `src`; false if there is none or it cannot start
    /// (item 3: it is another owner's, `AlreadyRunning`).
    fn start_exception(&mut self, src: Src) -> bool {
        let Some(x) = self.excs.iter().position(|d| d.src == src) else {
            return false;
        };
        let e = self.excs[x].e;
        if self.seqs[e].active() {
            return false;
        }
        self.start(e, Self::src_cause(src));
        true
    }

    fn tick(&mut self, t: u64) {
        self.t = t;
        let n = self.seqs.len();
        // Item 8: an abort-all, before the requests.
        if std::mem::take(&mut self.pending_abort_all) {
            self.abort_all();
        }
        // Item 3: the behaviours of the exception sequences that ended before this tick,
        // before any monitor, in the order of their owners' ids; item 8: every one of
        // them before every request.
        for i in 0..n {
            if let (Some(src), true) = (self.seqs[i].exc, self.seqs[i].exc_ended) {
                self.seqs[i].exc = None;
                self.seqs[i].exc_ended = false;
                if matches!(self.src_beh(src), Beh::CallerAbort | Beh::CallerRestart(_)) {
                    *self
                        .reached
                        .entry("caller behaviour at its exception sequence's end")
                        .or_default() += 1;
                }
                self.apply(i, self.src_beh(src), Self::src_cause(src));
            }
        }
        for i in 0..n {
            let s = &mut self.seqs[i];
            let (abort, pause, resume) = (
                std::mem::take(&mut s.pending_abort),
                std::mem::take(&mut s.pending_pause),
                std::mem::take(&mut s.pending_resume),
            );
            if !s.active() {
                continue;
            }
            if abort {
                self.abort_below(i, true, Cause::Abort);
                // Item 3: an exception sequence ended (aborted here): the next tick applies
                // its owner's behaviour.
                if let Kind::Exc(x) = self.seqs[i].kind {
                    let ExcDef { src, owner, .. } = self.excs[x];
                    if self.seqs[owner].exc == Some(src) && !broken("exc_abort_ends") {
                        self.hit("exc: aborted by a request, the behaviour follows");
                        self.seqs[owner].exc_ended = true;
                    }
                }
            } else if pause {
                self.seqs[i].pause_req = true;
                self.pause_tree(i, Cause::Pause);
            } else if resume {
                self.seqs[i].pause_req = false;
                self.resume_tree(i, Cause::Resume);
            }
        }
        // Item 1: the classes due: those with an active member whose grid point has come.
        let mut due_class: BTreeSet<u64> = BTreeSet::new();
        let periods: Vec<u64> = self.grid.keys().copied().collect();
        for p in periods {
            let any = (0..n).any(|i| self.seqs[i].period == p && self.seqs[i].active());
            let mut g = self.grid[&p];
            if any && g <= t {
                while g <= t {
                    g += p;
                }
                self.grid.insert(p, g);
                due_class.insert(p);
            }
        }
        let seq_due: Vec<bool> = self
            .seqs
            .iter()
            .map(|s| due_class.contains(&s.period) && s.active())
            .collect();
        // Item 1: a poll that falls due while its sequence is held is skipped.
        let poll_taken: Vec<bool> = (0..n).map(|i| seq_due[i] && !self.held(i)).collect();
        // Items 1, 3: at the owner's polling period, while it runs or is paused, the
        // conditions first, then the firings in table order.
        let nm = self.sc.monitors.len();
        let values: Vec<Option<bool>> = (0..nm)
            .map(|j| {
                let mc = &self.sc.monitors[j];
                let o = &self.seqs[mc.owner];
                let on = seq_due[mc.owner] && matches!(o.state, Running | Paused);
                on.then(|| cond(mc, t))
            })
            .collect();
        let mut releases = vec![];
        for (j, v) in values.into_iter().enumerate() {
            let Some(v) = v else { continue };
            let mc = self.sc.monitors[j].clone();
            let o = mc.owner;
            if !matches!(self.seqs[o].state, Running | Paused) {
                continue;
            }
            let cause = Self::mon_cause(j);
            let last = self.last[j];
            if mc.beh == Beh::Pause {
                // Item 7: a `PauseOwner` monitor pauses its owner and what it blocks in the
                // firing tick, starts its exception sequence (if any) also while the owner
                // is paused, marks no exception; it releases when the condition clears.
                self.last[j] = v;
                if v && !last && !self.holding[j] {
                    self.start_exception(Src::Mon(j));
                    self.holding[j] = true;
                    self.seqs[o].holds += 1;
                    self.pause_tree(o, cause);
                } else if !v && last && self.holding[j] {
                    releases.push(j);
                }
                continue;
            }
            if self.seqs[o].exc.is_some() {
                // Item 5: while an exception of the owner is handled its other monitors do
                // not fire; an evaluation that would fire leaves the last value as it was,
                // one that would not updates it.
                if !mc.trigger.fires(last, v) {
                    self.last[j] = v;
                }
                continue;
            }
            self.last[j] = v;
            if mc.trigger.fires(last, v) {
                // Items 1, 3: with an exception sequence that starts, the owner handles the
                // exception until it ends; else the behaviour is applied in the firing tick.
                if self.start_exception(Src::Mon(j)) {
                    self.seqs[o].exc = Some(Src::Mon(j));
                } else {
                    self.apply(o, mc.beh, cause);
                }
            }
        }
        // Item 6: the timeouts, by sequence id, after the monitors: at the owner's polls, at
        // most once per round, not while its run is paused (its clock stands) nor while it
        // handles an exception (it fires at the first poll after).
        for (i, due) in seq_due.into_iter().enumerate() {
            // `Handle::set_timeout`: a time set during the round counts at once if the
            // round is armed (`None`: off), else from the next start or restart.
            let (Some(to), beh) = (self.seqs[i].timeout_ms, self.timeout_beh(i)) else {
                continue;
            };
            if !due || self.seqs[i].state != Running || self.seqs[i].exc.is_some() {
                continue;
            }
            let armed = self.seqs[i].armed || broken("set_timeout_arms");
            if !armed || self.seqs[i].timeout_fired || self.seqs[i].run_time(t) < to {
                continue;
            }
            self.seqs[i].timeout_fired = true;
            // Item 3 (and `SeqConfig::timeout_exception`): as a monitor's.
            if self.start_exception(Src::Timeout(i)) {
                self.seqs[i].exc = Some(Src::Timeout(i));
            } else {
                self.apply(i, beh, Cause::Timeout(SeqId::from_index(i)));
            }
        }
        // Item 7: `PauseOwner` releases, once the monitors and timeouts are evaluated; the
        // owner resumes once no other hold (a monitor, a pause request) remains.
        for j in releases {
            let o = self.sc.monitors[j].owner;
            if !self.holding[j] {
                continue;
            }
            self.holding[j] = false;
            self.seqs[o].holds -= 1;
            let cause = Self::mon_cause(j);
            self.resume_tree(o, cause);
        }
        self.lanes(&poll_taken);
    }

    /// Item 8: runs end in their lanes, as RTIC dispatches them (`sim`'s module doc, "The
    /// order of the lanes"): the highest priority first; in a dispatcher's pass, the lanes
    /// of its priority in the order they were added, each polled if it can move (a lane
    /// that can move and is not woken would be a lost wake-up: the comparison finds it);
    /// a pass again while one moved; a lane that moves lets the lanes above it run first
    /// (it woke them: preemption).
    fn lanes(&mut self, poll_taken: &[bool]) {
        // Item 8: while an abort-all waits, every await point holds.
        if self.pending_abort_all {
            return;
        }
        let mut levels: Vec<u8> = self.lane_list().iter().map(|l| l.0).collect();
        levels.sort_unstable_by(|a, b| b.cmp(a));
        levels.dedup();
        for p in levels {
            self.dispatch(p, poll_taken);
        }
    }

    /// The lanes with their priorities, in the order they were added.
    fn lane_list(&self) -> Vec<(u8, Lane)> {
        let mut lanes = vec![Lane::Main];
        lanes.extend(self.bg.map(|_| Lane::Bg));
        lanes.extend((0..self.excs.len()).map(Lane::Exc));
        let prio = |i: usize| match self.sc.prios.get(i) {
            Some(&p) if !broken("lane_priorities") => p,
            _ => DEFAULT_LANE_PRIORITY,
        };
        lanes
            .into_iter()
            .enumerate()
            .map(|(i, l)| (prio(i), l))
            .collect()
    }

    /// The dispatcher of priority `p`: passes until none of its lanes moves.
    fn dispatch(&mut self, p: u8, poll_taken: &[bool]) {
        loop {
            let mut moved = false;
            for (q, lane) in self.lane_list() {
                if q != p || self.pending_abort_all {
                    continue;
                }
                let n = self.trace.len();
                match lane {
                    Lane::Main => self.lane(self.main(), poll_taken),
                    Lane::Bg => self.lane(self.bg.unwrap(), poll_taken),
                    Lane::Exc(x) => self.exc_lane(x, poll_taken),
                }
                if self.trace.len() != n {
                    moved = true;
                    if broken("preemption") {
                        continue;
                    }
                    // Preemption: the lanes above it that it woke run now.
                    let mut above: Vec<u8> = self
                        .lane_list()
                        .iter()
                        .map(|l| l.0)
                        .filter(|&h| h > p)
                        .collect();
                    above.sort_unstable_by(|a, b| b.cmp(a));
                    above.dedup();
                    let before = self.trace.len();
                    for h in above {
                        self.dispatch(h, poll_taken);
                    }
                    if self.trace.len() != before {
                        self.hit("lanes: a lane above preempts");
                    }
                }
            }
            if !moved {
                return;
            }
        }
    }

    /// The window in which the pre-condition of main or the sub-sequence `c` is false.
    fn pre_window(&self, c: usize) -> Option<(u64, u64)> {
        if c == self.main() {
            self.sc.main_pre_false
        } else {
            self.sc.sub.as_ref().and_then(|s| s.pre_false)
        }
    }

    /// The window in which the action of main or the sub-sequence `c` fails at its end.
    fn fail_window(&self, c: usize) -> Option<(u64, u64)> {
        if c == self.main() {
            self.sc.main_fail
        } else {
            self.sc.sub.as_ref().and_then(|s| s.fail)
        }
    }

    /// Item 14: `i` waits in its join `op` (its action is at it, the future not dropped by a
    /// restart), for a run still under way: a join whose run ended waits no more, though its
    /// joiner, paused or held, has not returned from it yet.
    fn waits_in(&self, i: usize, op: usize) -> bool {
        let target = if op == OP_JOIN {
            self.bg.unwrap()
        } else {
            self.main()
        };
        matches!(self.seqs[i].state, Running | Paused)
            && !self.fresh[i]
            && self.ops[i].get(self.pcs[i]) == Some(&op)
            && (self.seqs[target].active() && self.runs[target] == self.joined_run[i]
                || broken("join_of_an_ended_run"))
    }

    /// Item 11: a dropped `Scoped` requests the abort of its run, if it has not ended; the
    /// next tick carries it out (8).
    fn drop_scoped(&mut self) {
        if let (Some(run), Some(bg)) = (self.scoped.take(), self.bg) {
            if self.seqs[bg].active() && self.runs[bg] == run && !broken("scoped_drop") {
                self.hit("nb: scoped drop requests an abort");
                self.seqs[bg].pending_abort = true;
            }
        }
    }

    /// Exception sequence x: starts its `Wait` and ends with it; item 3: the next tick
    /// applies the behaviour.
    fn exc_lane(&mut self, x: usize, poll_taken: &[bool]) {
        let ExcDef {
            src,
            owner: o,
            e,
            w,
        } = self.excs[x];
        if self.seqs[e].state != Running || self.held(e) {
            return;
        }
        let started = self.seqs[w].active() && self.seqs[w].round_start >= self.seqs[e].round_start;
        if !started {
            self.start(w, Cause::Start);
            if !self.exit_true(w) {
                return;
            }
        } else if !(self.seqs[w].state == Running
            && poll_taken[w]
            && !self.held(w)
            && self.exit_true(w))
        {
            return;
        }
        self.mv(w, Terminated, Cause::Completed);
        self.mv(e, Terminated, Cause::Completed);
        if self.seqs[o].exc == Some(src) {
            self.seqs[o].exc_ended = true;
        }
    }

    /// The lane of main or of the non-blocking sub-sequence: nothing advances while held
    /// (items 3, 7).
    fn lane(&mut self, m: usize, poll_taken: &[bool]) {
        if !self.seqs[m].active() || self.held(m) {
            return;
        }
        let pre_false = within(self.pre_window(m), self.t) && !broken("sub_pre");
        if std::mem::take(&mut self.fresh[m]) {
            if self.seqs[m].state != Running {
                return;
            }
            self.pcs[m] = 0;
            if m == self.main() {
                self.scoped = None;
            }
            if pre_false {
                self.mv(m, Terminated, Cause::PreConditionFalse);
            } else {
                self.begin_steps(m);
            }
            return;
        }
        // Item 1: `Restarting` repeats from the pre-condition, with a fresh timeout.
        if self.seqs[m].state == Restarting {
            self.mv(m, Running, Cause::Restart);
            self.reset_round(m);
            self.pcs[m] = 0;
            if m == self.main() {
                self.scoped = None;
            }
            if pre_false {
                self.mv(m, Terminated, Cause::PreConditionFalse);
            } else {
                self.begin_steps(m);
            }
            return;
        }
        self.advance(m, poll_taken);
    }

    /// The action of `c` (running, not held) at its blocking child; true if `c` ended.
    fn advance(&mut self, c: usize, poll_taken: &[bool]) -> bool {
        let Some(&s) = self.ops[c].get(self.pcs[c]) else {
            return false;
        };
        if s == OP_JOIN || s == OP_JOIN_MAIN {
            // Item 14: the join returns at the end of the joined run.
            let target = if s == OP_JOIN {
                self.bg.unwrap()
            } else {
                self.main()
            };
            if self.seqs[target].active()
                && (self.runs[target] == self.joined_run[c] || broken("join_of_an_ended_run"))
            {
                return false;
            }
            if self.runs[target] - self.joined_run[c] > 1
                || self.runs[target] != self.joined_run[c] && !self.seqs[target].active()
            {
                self.hit("nb: a join's outcome lost");
            }
            self.joined(c, self.outcome_of(target, self.joined_run[c]));
            self.pcs[c] += 1;
            return self.begin_steps(c);
        }
        let sub = self.seqs[s].kind == Kind::Sub;
        let ended = match self.seqs[s].state {
            // Item 7: a blocking child's restart waits while its caller's lane is held.
            Restarting => {
                if self.held(s) {
                    return false;
                }
                self.mv(s, Running, Cause::Restart);
                self.reset_round(s);
                self.child_round(s)
            }
            // Item 4: the aborted child's caller gets `Err` and goes on (`MMain` ignores it).
            Aborted => true,
            // Item 1: the exit condition is polled at the step's polls it takes.
            Running if !sub => {
                poll_taken[s] && !self.held(s) && self.exit_true(s) && {
                    self.mv(s, Terminated, Cause::Completed);
                    true
                }
            }
            Running if sub => !self.held(s) && self.advance(s, poll_taken),
            _ => false,
        };
        if ended {
            self.pcs[c] += 1;
            self.begin_steps(c)
        } else {
            false
        }
    }

    /// Main started before the first tick, at 0 (firmware guide, section 2).
    fn start_main(&mut self) {
        self.t = 0;
        let m = self.main();
        self.start(m, Cause::Start);
        self.fresh[m] = true;
        self.lanes(&vec![false; self.seqs.len()]);
    }
}
fn run_model(sc: &Scenario) -> (Vec<Transition>, Vec<Result<(), Error>>) {
    let m = model_of(sc);
    (m.trace, m.req_ok)
}

/// What joins returned.
type Joins = Vec<Joined>;

/// The model after the scenario.
fn model_of(sc: &Scenario) -> Model<'_> {
    let mut m = Model::new(sc);
    m.start_main();
    let mut prev = 0;
    for &t in &sc.ticks {
        for &(rt, i, r) in &sc.requests {
            if prev < rt && rt <= t {
                m.request(i, r);
            }
        }
        m.tick(t);
        prev = t;
    }
    m
}

// ---------------------------------------------------------------- rtseq

fn c_m0(c: &Ctrl, _: Instant) -> bool {
    c.flag(MON)
}

fn c_m1(c: &Ctrl, _: Instant) -> bool {
    c.flag(MON + 1)
}

fn beh(b: Beh) -> Behaviour {
    match b {
        Beh::Nothing => Behaviour::Nothing,
        Beh::Abort => Behaviour::AbortOwner,
        Beh::Restart(_) => Behaviour::RestartOwner,
        Beh::Pause => Behaviour::PauseOwner,
        Beh::CallerAbort => Behaviour::AbortCallerOfOwner,
        Beh::CallerRestart(_) => Behaviour::RestartCallerOfOwner,
    }
}

fn limit(b: Beh) -> u8 {
    match b {
        Beh::Restart(l) | Beh::CallerRestart(l) => l,
        _ => 3,
    }
}

fn cfg(name: &'static str, period: u64, timeout: Option<(u64, Beh)>) -> SeqConfig<Ctrl> {
    let mut c = SeqConfig::new(name).polling(Duration::from_millis(period));
    if let Some((to, b)) = timeout {
        c = c
            .timeout(Duration::from_millis(to))
            .timeout_behaviour(beh(b))
            .timeout_restart_limit(limit(b));
    }
    c
}

/// The flags: the exit flags of the steps are 0..4 (`Leaf`), the monitors' conditions `MON`
/// and `MON + 1` (`c_m0`, `c_m1`); these are the pre-conditions (true: it holds) and the
/// failures.
const PRE: usize = 4;
const FAIL: usize = 8;
const MAIN_PRE: usize = 12;
const MON: usize = 13;
/// The sub-sequence's pre-condition and failure, main's failure (`MMain`).
const SUB_PRE: usize = 15;
const SUB_FAIL: usize = 16;
const MAIN_FAIL: usize = 17;

/// A step whose exit condition is flag `i`, whose pre-condition is flag `PRE + i` and whose
/// action fails while flag `FAIL + i` is set.
struct MLeaf(usize);

impl Step<Ctrl> for MLeaf {
    fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        if cx.control().flag(FAIL + self.0) {
            Err(Failure::App(1))
        } else {
            Ok(())
        }
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(PRE + self.0)
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(self.0)
    }
}

enum MOp {
    Leaf(Seq<MLeaf>),
    Wait(Seq<Wait>),
    /// The sub-sequence, run blocking (`Cx::run`).
    Sub(Seq<MMain>),
    /// `Cx::start` of this sequence, or `Cx::start_scoped` (true).
    Start(SeqId, bool),
    /// `Scoped::join` of the `Scoped` held, else `Cx::join`.
    Join(SeqId),
    /// The `Scoped` held is dropped.
    Drop,
    /// The `Scoped` held is detached.
    Detach,
}

type Boxed<'f> = std::pin::Pin<Box<dyn std::future::Future<Output = Result<Done, Failure>> + 'f>>;

/// Main (pre-condition flag `MAIN_PRE`, failure flag `MAIN_FAIL`) or the sub-sequence
/// (`SUB_PRE`, `SUB_FAIL`): runs its ops in turn, going on whatever each returned, then
/// fails if its failure flag is set.
struct MMain(Vec<MOp>, usize, usize);

impl Sequence<Ctrl> for MMain {
    async fn action(&mut self, cx: &Cx<'_, Ctrl>) -> Result<(), Failure> {
        let mut scoped = None;
        for op in self.0.iter_mut() {
            let _ = match op {
                MOp::Leaf(s) => cx.step(s).await,
                MOp::Wait(s) => cx.step(s).await,
                MOp::Sub(s) => {
                    let f: Boxed<'_> = Box::pin(cx.run(s));
                    f.await
                }
                MOp::Start(id, false) => cx
                    .start(*id)
                    .map(|()| Done::Completed)
                    .map_err(Failure::from),
                MOp::Start(id, true) => match cx.start_scoped(*id) {
                    Ok(s) => {
                        scoped = Some(s);
                        Ok(Done::Completed)
                    }
                    Err(e) => Err(Failure::from(e)),
                },
                MOp::Join(id) => {
                    let r = match &scoped {
                        Some(s) => s.join().await,
                        None => cx.join(*id).await,
                    };
                    cx.control().joined(cx, r);
                    r.map_err(Failure::from).and_then(rtseq::Outcome::done)
                }
                MOp::Drop => {
                    scoped = None;
                    Ok(Done::Completed)
                }
                MOp::Detach => {
                    if let Some(s) = scoped.take() {
                        s.detach();
                    }
                    Ok(Done::Completed)
                }
            };
        }
        if cx.control().flag(self.2) {
            return Err(Failure::App(2));
        }
        Ok(())
    }
    fn check_pre_condition(&mut self, cx: &Cx<'_, Ctrl>) -> bool {
        cx.control().flag(self.1)
    }
}

/// The sequences with a timeout exception sequence (steps, then main) and its `Wait` (ms).
fn timeout_excs(sc: &Scenario) -> Vec<(usize, u64)> {
    let mut v: Vec<(usize, u64)> = sc
        .steps
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.timeout.and(s.timeout_exc).map(|d| (i, d)))
        .collect();
    let mut k = sc.steps.len();
    if let Some(sub) = &sc.sub {
        if let Some(d) = sub.timeout.and(sub.timeout_exc) {
            v.push((k, d));
        }
        k += 1;
    }
    if let Some(d) = sc.main_timeout.and(sc.main_timeout_exc) {
        v.push((k, d));
    }
    v
}

/// The flags at `t`.
fn set_flags(sc: &Scenario, c: &Ctrl, t: u64) {
    for (i, s) in sc.steps.iter().enumerate() {
        if let Exit::Flag(at) = s.exit {
            c.set(i, exit_flag(t, at));
        }
        c.set(PRE + i, !within(s.pre_false, t));
        c.set(FAIL + i, within(s.fail, t));
    }
    c.set(MAIN_PRE, !within(sc.main_pre_false, t));
    c.set(MAIN_FAIL, within(sc.main_fail, t));
    if let Some(sub) = &sc.sub {
        c.set(SUB_PRE, !within(sub.pre_false, t));
        c.set(SUB_FAIL, within(sub.fail, t));
    }
    for (j, m) in sc.monitors.iter().enumerate() {
        c.set(MON + j, cond(m, t));
    }
}

/// Runs the scenario in the simulator: the trace and whether each request was taken.
fn run_rtseq(sc: &Scenario) -> (Vec<Transition>, Vec<Result<(), Error>>, Joins) {
    // Lanes: main's, the non-blocking sub-sequence's and up to 7 exception sequences'.
    let seq: Sequencer<Ctrl, 32, 256, CriticalSection, 16> = Sequencer::new();
    let ctrl = Ctrl::default();
    const NAMES: [&str; 4] = ["s0", "s1", "s2", "s3"];
    const EXC: [(&str, &str); 8] = [
        ("w0", "e0"),
        ("w1", "e1"),
        ("w2", "e2"),
        ("w3", "e3"),
        ("w4", "e4"),
        ("w5", "e5"),
        ("w6", "e6"),
        ("w7", "e7"),
    ];
    // Main's id: after the steps and the sub-sequence.
    let k = sc.steps.len() + sc.sub.is_some() as usize;
    let n_mon_exc = sc.monitors.iter().filter(|m| m.exception.is_some()).count();
    let texcs = timeout_excs(sc);
    // The id of the timeout exception sequence of `i`: added after main and the monitors'.
    let texc_id = |i: usize| {
        texcs
            .iter()
            .position(|&(o, _)| o == i)
            .map(|x| SeqId::from_index(k + 1 + 2 * (n_mon_exc + x) + 1))
    };
    let cfg_of = |name, period, timeout, i| {
        let mut c = cfg(name, period, timeout);
        if let Some(e) = texc_id(i) {
            c = c.timeout_exception(e);
        }
        c
    };
    let mut ops = vec![];
    for (i, s) in sc.steps.iter().enumerate() {
        let c = cfg_of(NAMES[i], s.period, s.timeout, i);
        match s.exit {
            Exit::Flag(_) => ops.push(MOp::Leaf(seq.add(c, MLeaf(i)).unwrap())),
            Exit::Wait(d) => ops.push(MOp::Wait(
                seq.add(c, Wait::new(Duration::from_millis(d))).unwrap(),
            )),
        }
    }
    let mut bg_lane = None;
    if let Some(sub) = sc.sub.as_ref().filter(|s| s.nb.is_some()) {
        let ns = sc.steps.len();
        let mut slots: Vec<Option<MOp>> = ops.drain(..).map(Some).collect();
        let mine = (sub.first..sub.first + sub.len)
            .map(|i| slots[i].take().unwrap())
            .collect();
        let c = cfg_of("sub", sub.period, sub.timeout, ns);
        let mut mine: Vec<MOp> = mine;
        if sc.bg_joins_main {
            mine.push(MOp::Join(SeqId::from_index(k)));
        }
        let s = seq.add(c, MMain(mine, SUB_PRE, SUB_FAIL)).unwrap();
        let b = s.id();
        assert_eq!(b.index(), ns);
        bg_lane = Some(s);
        let scoped = sub.nb == Some(true);
        for o in &sc.main_ops {
            ops.push(match *o {
                MainOp::Step(i) => slots[i].take().unwrap(),
                MainOp::Start => MOp::Start(b, scoped),
                MainOp::Join => MOp::Join(b),
                MainOp::Drop => MOp::Drop,
                MainOp::Detach => MOp::Detach,
            });
        }
    } else if let Some(sub) = &sc.sub {
        let ns = sc.steps.len();
        let mut rest = ops.split_off(sub.first);
        let after = rest.split_off(sub.len);
        let c = cfg_of("sub", sub.period, sub.timeout, ns);
        let s = seq.add(c, MMain(rest, SUB_PRE, SUB_FAIL)).unwrap();
        assert_eq!(s.id().index(), ns);
        ops.push(MOp::Sub(s));
        ops.extend(after);
    }
    let main = seq
        .add(
            cfg_of("main", sc.main_period, sc.main_timeout, k),
            MMain(ops, MAIN_PRE, MAIN_FAIL),
        )
        .unwrap();
    let mi = main.id();
    assert_eq!(mi.index(), k);
    let mut exc_lanes = vec![];
    let mut exc_seq = vec![];
    let mut add_exc = |d: u64| {
        let (wn, en) = EXC[exc_lanes.len()];
        let w = seq
            .add(SeqConfig::new(wn), Wait::new(Duration::from_millis(d)))
            .unwrap();
        let e = seq
            .add(SeqConfig::new(en), Node::of(vec![Op::Wait(w)]))
            .unwrap();
        let id = e.id();
        exc_lanes.push(e);
        id
    };
    for mc in &sc.monitors {
        exc_seq.push(mc.exception.map(&mut add_exc));
    }
    for &(i, d) in &texcs {
        assert_eq!(Some(add_exc(d)), texc_id(i));
    }
    let mut monitors: Monitors<Ctrl, 2, ConditionFn<Ctrl>> = Monitors::new();
    for (j, mc) in sc.monitors.iter().enumerate() {
        let f: ConditionFn<Ctrl> = if j == 0 { c_m0 } else { c_m1 };
        let mut mon = Monitor::with_fn(["m0", "m1"][j], f, beh(mc.beh));
        if let Some(e) = exc_seq[j] {
            mon = mon.exception(e);
        }
        let mon = mon.trigger(mc.trigger).restart_limit(limit(mc.beh));
        let id = monitors.add(SeqId::from_index(mc.owner), mon).unwrap();
        // The model names monitor j by its place in the table.
        assert_eq!(id, MonitorId::from_index(j));
    }
    let mut sim = Sim::new(&seq, &ctrl, monitors);
    let prio = |i: usize| sc.prios.get(i).copied().unwrap_or(DEFAULT_LANE_PRIORITY);
    sim.lane_with_priority(main, prio(0));
    let n_bg = bg_lane.is_some() as usize;
    if let Some(b) = bg_lane {
        sim.lane_with_priority(b, prio(1));
    }
    for (x, e) in exc_lanes.into_iter().enumerate() {
        sim.lane_with_priority(e, prio(1 + n_bg + x));
    }
    let scc = sc.clone();
    sim.before_tick(move |now, c: &Ctrl| set_flags(&scc, c, ms(now)));
    set_flags(sc, &ctrl, 0);
    sim.start(mi).unwrap();
    let mut oks = vec![];
    let mut prev = 0;
    for &t in &sc.ticks {
        for &(rt, i, r) in &sc.requests {
            if prev < rt && rt <= t {
                let id = SeqId::from_index(i);
                let res = match r {
                    Req::Pause => sim.pause(id),
                    Req::Resume => sim.resume(id),
                    Req::Abort => sim.abort(id),
                    Req::AbortAll => {
                        sim.abort_all();
                        Ok(())
                    }
                    Req::Start => sim.start(mi),
                    Req::SetTimeout(to) => seq
                        .sequence_by_id(id)
                        .unwrap()
                        .set_timeout(to.map(Duration::from_millis)),
                };
                oks.push(res);
            }
        }
        // A tick at `t`: the simulator's period is the gap since the last tick.
        sim = sim.with_period(Duration::from_millis(t - prev)).unwrap();
        sim.step();
        assert_eq!(ms(sim.now()), t);
        prev = t;
    }
    assert!(!sim.stalled());
    assert_eq!(sim.tick_error(), None);
    assert_eq!(sim.lost(), 0);
    let trace = sim.take_trace();
    drop(sim);
    (trace, oks, ctrl.joins.take())
}

// ---------------------------------------------------------------- generator

/// SplitMix64.
struct Rng(u64);

impl Rng {
    fn word(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.word() % n
    }

    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.below(hi - lo + 1)
    }

    fn chance(&mut self, pct: u64) -> bool {
        self.below(100) < pct
    }

    fn period(&mut self) -> u64 {
        [1, 2, 5][self.below(3) as usize]
    }
}

/// What the generator may use besides steps, timeouts and monitors without exception
/// sequences.
#[derive(Clone, Copy, Debug)]
struct Features {
    /// Falling-edge and change triggers, a second pause and resume.
    more: bool,
    pause_owner: bool,
    exceptions: bool,
    requests: bool,
    /// Ticks 1 to 7 ms apart.
    late: bool,
    /// Pre-conditions that are false (of the `Flag` steps and of main's restarts) and
    /// actions that fail (of the `Flag` steps).
    pre_fail: bool,
    /// Pause, resume and abort requests of the steps, and abort-alls.
    step_requests: bool,
    /// Exception sequences of the timeouts.
    timeout_exc: bool,
    /// A sub-sequence between main and 1 or 2 of the steps (main may run a step before and
    /// after it), owning monitors and a timeout, and a target of requests.
    tree: bool,
    /// The caller behaviours `AbortCallerOfOwner` and `RestartCallerOfOwner`.
    caller: bool,
    /// With `tree`: the sub-sequence started non-blocking (`Cx::start` or
    /// `Cx::start_scoped`), joined, dropped or detached, or left to outlive main; starts of
    /// main by the application.
    nb: bool,
    /// With `tree`: the sub-sequence's pre-condition false and its action failing (at its
    /// end) during windows, and main's action failing at its end.
    sub_pre_fail: bool,
    /// Lanes of RTIC priorities 1 to 3 (`Sim::lane_with_priority`).
    prios: bool,
    /// Pause, resume and abort requests of the exception sequences.
    exc_requests: bool,
    /// `Handle::set_timeout` of main, the sub-sequence or a step.
    set_timeout: bool,
    /// With `nb` and a child that joins main: the child paused around the end of main's
    /// run, main started again, the child resumed (a join that may find the outcome of the
    /// run it joined replaced, `OutcomeLost`).
    held_joins: bool,
}

fn gen_beh(r: &mut Rng, timeout: bool, f: &Features) -> Beh {
    if f.caller && r.chance(45) {
        return if r.chance(40) {
            Beh::CallerAbort
        } else {
            Beh::CallerRestart(r.below(4) as u8)
        };
    }
    // Item 6: a timeout cannot have `PauseOwner`.
    let n = if timeout || !f.pause_owner { 3 } else { 4 };
    match r.below(n) {
        0 => Beh::Nothing,
        1 => Beh::Abort,
        2 => Beh::Restart(r.below(4) as u8),
        _ => Beh::Pause,
    }
}

/// A window `from <= t < to` within the first 40 ms, or none.
fn gen_window(r: &mut Rng, on: bool, pct: u64) -> Option<(u64, u64)> {
    if on && r.chance(pct) {
        let a = r.range(1, 30);
        Some((a, a + r.range(1, 12)))
    } else {
        None
    }
}

/// A timeout exception sequence's `Wait` (ms), or none.
fn gen_texc(r: &mut Rng, timeout: bool, f: &Features) -> Option<u64> {
    (timeout && f.timeout_exc && r.chance(60)).then(|| r.range(1, 6))
}

fn generate(seed: u64, f: &Features) -> Scenario {
    let mut r = Rng(seed);
    // With a sub-sequence: a step before it, 1 or 2 steps in it, a step after it.
    let layout = f.tree.then(|| {
        let before = r.chance(40) as usize;
        let len = r.range(1, 2) as usize;
        (before, len, before + len + r.chance(40) as usize)
    });
    let k = match layout {
        Some((_, _, k)) => k,
        None => r.range(1, 3) as usize,
    };
    let steps: Vec<StepCfg> = (0..k)
        .map(|_| {
            let period = r.period();
            let exit = if r.chance(50) {
                Exit::Flag(r.range(1, 25))
            } else {
                Exit::Wait(r.range(1, 12))
            };
            let pct = if f.timeout_exc { 40 } else { 25 };
            let timeout = if r.chance(pct) {
                Some((r.range(2, 15), gen_beh(&mut r, true, f)))
            } else {
                None
            };
            let flag = matches!(exit, Exit::Flag(_)) && f.pre_fail;
            StepCfg {
                period,
                exit,
                timeout,
                timeout_exc: gen_texc(&mut r, timeout.is_some(), f),
                pre_false: gen_window(&mut r, flag, 35),
                fail: gen_window(&mut r, flag, 35),
            }
        })
        .collect();
    let sub = layout.map(|(first, len, _)| {
        let period = r.period();
        let timeout = r
            .chance(if f.timeout_exc { 45 } else { 35 })
            .then(|| (r.range(2, 20), gen_beh(&mut r, true, f)));
        SubCfg {
            period,
            first,
            len,
            timeout,
            timeout_exc: gen_texc(&mut r, timeout.is_some(), f),
            pre_false: gen_window(&mut r, f.sub_pre_fail, 35),
            fail: gen_window(&mut r, f.sub_pre_fail, 35),
            nb: None,
        }
    });
    let mut sub = sub;
    let mut main_ops = vec![];
    let mut bg_joins_main = false;
    if let (true, Some(s)) = (f.nb, sub.as_mut()) {
        let scoped = r.chance(50);
        s.nb = Some(scoped);
        // Main: the steps before, the start, the steps after with a join, a drop or a
        // detach among them (or none: a `Scoped` dropped at the action's end).
        main_ops.extend((0..s.first).map(MainOp::Step));
        main_ops.push(MainOp::Start);
        // The child joins main after its steps: a cycle of joins (item 14).
        bg_joins_main = r.chance(35);
        let after: Vec<usize> = (s.first + s.len..k).collect();
        let end = match r.below(if scoped { 4 } else { 2 }) {
            0 => None,
            1 => Some(MainOp::Join),
            2 => Some(MainOp::Drop),
            _ => Some(MainOp::Detach),
        };
        let at = r.below(after.len() as u64 + 1) as usize;
        for (j, &i) in after.iter().enumerate() {
            if j == at {
                main_ops.extend(end);
            }
            main_ops.push(MainOp::Step(i));
        }
        if at == after.len() {
            main_ops.extend(end);
        }
    }
    // The sequences that may own monitors or take requests: the steps, the sub-sequence, main.
    let n_tree = k + sub.is_some() as usize + 1;
    let main_period = r.period();
    let pct = if f.timeout_exc { 40 } else { 20 };
    let main_timeout = if r.chance(pct) {
        Some((r.range(3, 30), gen_beh(&mut r, true, f)))
    } else {
        None
    };
    let main_timeout_exc = gen_texc(&mut r, main_timeout.is_some(), f);
    let main_pre_false = gen_window(&mut r, f.pre_fail, 50);
    let main_fail = gen_window(&mut r, f.sub_pre_fail, 35);
    let nm = r.below(3) as usize;
    let monitors = (0..nm)
        .map(|_| {
            let from = r.range(1, 25);
            MonCfg {
                owner: r.below(n_tree as u64) as usize,
                from,
                to: from + r.range(1, 10),
                trigger: if f.more {
                    [
                        Trigger::Level,
                        Trigger::RisingEdge,
                        Trigger::FallingEdge,
                        Trigger::Change,
                    ][r.below(4) as usize]
                } else if r.chance(50) {
                    Trigger::Level
                } else {
                    Trigger::RisingEdge
                },
                beh: gen_beh(&mut r, false, f),
                exception: if f.exceptions && r.chance(50) {
                    Some(r.range(1, 6))
                } else {
                    None
                },
            }
        })
        .collect();
    let mut requests = vec![];
    if f.requests {
        // Of main, or with `step_requests` of any of the k + 1.
        let target = |r: &mut Rng| {
            if f.step_requests {
                r.below(n_tree as u64) as usize
            } else if f.tree && r.chance(60) {
                // The sub-sequence.
                k
            } else {
                n_tree - 1
            }
        };
        if r.chance(40) {
            let p = r.range(1, 20);
            let who = target(&mut r);
            requests.push((p, who, Req::Pause));
            if r.chance(75) {
                let q = p + r.range(1, 10);
                requests.push((q, who, Req::Resume));
                if f.more && r.chance(50) {
                    let p2 = q + r.range(1, 8);
                    let who = target(&mut r);
                    requests.push((p2, who, Req::Pause));
                    if r.chance(70) {
                        requests.push((p2 + r.range(1, 8), who, Req::Resume));
                    }
                }
            }
        }
        if r.chance(20) {
            let a = r.range(1, 35);
            let who = target(&mut r);
            if !requests.iter().any(|&(t, _, _)| t == a) {
                requests.push((a, who, Req::Abort));
            }
        }
        if f.step_requests && r.chance(15) {
            requests.push((r.range(1, 40), n_tree - 1, Req::AbortAll));
        }
        if f.nb && r.chance(40) {
            let a = r.range(5, 50);
            if !requests.iter().any(|&(t, _, _)| t == a) {
                requests.push((a, n_tree - 1, Req::Start));
            }
        }
        requests.sort_by_key(|&(t, _, _)| t);
    }
    let mut ticks = vec![];
    let mut t = 0;
    while t < 80 {
        t += if f.late && r.chance(50) {
            r.range(2, 7)
        } else {
            1
        };
        ticks.push(t);
    }
    let mut sc = Scenario {
        steps,
        sub,
        main_ops,
        bg_joins_main,
        main_period,
        main_timeout,
        main_timeout_exc,
        main_pre_false,
        main_fail,
        monitors,
        requests,
        ticks,
        prios: vec![],
    };
    let excs =
        sc.monitors.iter().filter(|m| m.exception.is_some()).count() + timeout_excs(&sc).len();
    if f.exc_requests && excs > 0 {
        // Exception sequence x is added after main and its `Wait`: main + 2 + 2x.
        let main = sc.steps.len() + sc.sub.is_some() as usize;
        for _ in 0..r.range(1, 3) {
            let e = main + 2 + 2 * r.below(excs as u64) as usize;
            let req = match r.below(3) {
                0 => Req::Pause,
                1 => Req::Resume,
                _ => Req::Abort,
            };
            sc.requests.push((r.range(1, 40), e, req));
        }
        sc.requests.sort_by_key(|&(t, _, _)| t);
    }
    if f.set_timeout {
        // Of main, the sub-sequence or a step: a time, or off.
        let n_tree = sc.steps.len() + sc.sub.is_some() as usize + 1;
        for _ in 0..r.range(1, 3) {
            let to = (!r.chance(30)).then(|| r.range(1, 20));
            let who = r.below(n_tree as u64) as usize;
            sc.requests.push((r.range(1, 40), who, Req::SetTimeout(to)));
        }
        sc.requests.sort_by_key(|&(t, _, _)| t);
    }
    if f.held_joins && sc.bg_joins_main {
        // The child (id k) paused, main (id k + 1) started again, the child resumed, each
        // at a time no other request has.
        let k = sc.steps.len();
        let pause = r.range(1, 20);
        let start = pause + r.range(1, 20);
        let resume = start + r.range(1, 10);
        for (t, who, req) in [
            (pause, k, Req::Pause),
            (start, k + 1, Req::Start),
            (resume, k, Req::Resume),
        ] {
            if !sc.requests.iter().any(|&(u, _, _)| u == t) {
                sc.requests.push((t, who, req));
            }
        }
        sc.requests.sort_by_key(|&(t, _, _)| t);
    }
    if f.prios {
        // Main's lane, the non-blocking sub-sequence's, the exception sequences'.
        let bg = sc.sub.as_ref().is_some_and(|s| s.nb.is_some()) as usize;
        sc.prios = (0..1 + bg + excs).map(|_| r.range(1, 3) as u8).collect();
    }
    sc
}

// ---------------------------------------------------------------- sweeps

/// Seeds per sweep unless `MODEL_N` says otherwise.
const SEEDS: u64 = 2000;

/// The feature combinations the tests sweep, each with the first seed of its range.
const NONE: (u64, Features) = (0, feat(false, false, false, false));
const REQUESTS: (u64, Features) = (100_000, feat(false, false, false, true));
const PAUSE_OWNER: (u64, Features) = (200_000, feat(false, true, false, true));
const EXCEPTIONS: (u64, Features) = (300_000, feat(false, false, true, false));
const EVERYTHING: (u64, Features) = (400_000, feat(false, true, true, true));
const MORE: (u64, Features) = (500_000, feat(true, true, true, true));

const fn feat(more: bool, pause_owner: bool, exceptions: bool, requests: bool) -> Features {
    Features {
        more,
        pause_owner,
        exceptions,
        requests,
        late: false,
        pre_fail: false,
        step_requests: false,
        timeout_exc: false,
        tree: false,
        caller: false,
        nb: false,
        sub_pre_fail: false,
        prios: false,
        exc_requests: false,
        set_timeout: false,
        held_joins: false,
    }
}

/// The extensions, each on `MORE` (everything before), then all together.
const LATE: (u64, Features) = (
    600_000,
    Features {
        late: true,
        ..MORE.1
    },
);
const PRE_FAIL: (u64, Features) = (
    700_000,
    Features {
        pre_fail: true,
        ..MORE.1
    },
);
const STEP_REQUESTS: (u64, Features) = (
    800_000,
    Features {
        step_requests: true,
        ..MORE.1
    },
);
const TIMEOUT_EXC: (u64, Features) = (
    900_000,
    Features {
        timeout_exc: true,
        ..MORE.1
    },
);
const ALL: (u64, Features) = (
    1_000_000,
    Features {
        late: true,
        pre_fail: true,
        step_requests: true,
        timeout_exc: true,
        ..MORE.1
    },
);

fn env(name: &str) -> Option<u64> {
    let v = std::env::var(name).ok()?;
    Some(
        v.parse()
            .unwrap_or_else(|_| panic!("{name}={v}: not a number")),
    )
}

/// The two-level tree (a sub-sequence between main and the steps), on `MORE`; with caller
/// behaviours; then with every extension.
const TREE: (u64, Features) = (
    1_100_000,
    Features {
        tree: true,
        ..MORE.1
    },
);
const TREE_CALLER: (u64, Features) = (
    1_200_000,
    Features {
        tree: true,
        caller: true,
        ..MORE.1
    },
);
const TREE_ALL: (u64, Features) = (
    1_300_000,
    Features {
        tree: true,
        caller: true,
        ..ALL.1
    },
);
/// The sub-sequence started non-blocking, on `TREE_CALLER`; then with every extension.
const NB: (u64, Features) = (
    1_500_000,
    Features {
        nb: true,
        ..TREE_CALLER.1
    },
);
const NB_ALL: (u64, Features) = (
    1_600_000,
    Features {
        nb: true,
        ..TREE_ALL.1
    },
);
/// The sub-sequence's false pre-conditions and failures, and main's failures, on
/// `TREE_ALL` and `NB_ALL`.
const SUB_PRE_FAIL: (u64, Features) = (
    1_700_000,
    Features {
        sub_pre_fail: true,
        ..TREE_ALL.1
    },
);
const NB_PRE_FAIL: (u64, Features) = (
    1_800_000,
    Features {
        sub_pre_fail: true,
        ..NB_ALL.1
    },
);
/// Lanes of priorities 1 to 3, on `ALL`, `TREE_ALL`, `NB_PRE_FAIL`.
const PRIOS: (u64, Features) = (
    1_900_000,
    Features {
        prios: true,
        ..ALL.1
    },
);
const TREE_PRIOS: (u64, Features) = (
    2_000_000,
    Features {
        prios: true,
        ..TREE_ALL.1
    },
);
const NB_PRIOS: (u64, Features) = (
    2_100_000,
    Features {
        prios: true,
        ..NB_PRE_FAIL.1
    },
);
/// Requests of the exception sequences, on `ALL`, `TREE_ALL`, `NB_PRIOS`.
const EXC_REQUESTS: (u64, Features) = (
    2_200_000,
    Features {
        exc_requests: true,
        ..ALL.1
    },
);
const TREE_EXC_REQUESTS: (u64, Features) = (
    2_300_000,
    Features {
        exc_requests: true,
        ..TREE_ALL.1
    },
);
const NB_EXC_REQUESTS: (u64, Features) = (
    2_400_000,
    Features {
        exc_requests: true,
        ..NB_PRIOS.1
    },
);
/// `Handle::set_timeout`, on `ALL` and `TREE_EXC_REQUESTS`.
const SET_TIMEOUT: (u64, Features) = (
    2_500_000,
    Features {
        set_timeout: true,
        ..ALL.1
    },
);
const TREE_SET_TIMEOUT: (u64, Features) = (
    2_600_000,
    Features {
        set_timeout: true,
        ..TREE_EXC_REQUESTS.1
    },
);
/// A child held by a pause while main's run it joins ends and main starts again, on
/// `NB_EXC_REQUESTS`.
const HELD_JOINS: (u64, Features) = (
    2_700_000,
    Features {
        held_joins: true,
        ..NB_EXC_REQUESTS.1
    },
);
const CALLER: (u64, Features) = (
    1_400_000,
    Features {
        caller: true,
        ..ALL.1
    },
);

/// The scenario's trace and request results in the simulator and in the model, or both
/// printed.
fn compare(sc: &Scenario) -> Result<(), String> {
    let (got, oks, joins) = run_rtseq(sc);
    let m = model_of(sc);
    let (want, model_oks, model_joins) = (m.trace, m.req_ok, m.joins);
    if got != want || oks != model_oks || joins != model_joins {
        return Err(format!(
            "{sc:#?}\n rtseq:\n{}\n model:\n{}\n requests' results: rtseq {oks:?}, model {model_oks:?}\n joins: rtseq {joins:?}\n model {model_joins:?}",
            show(&got),
            show(&want)
        ));
    }
    Ok(())
}

/// Compares the seeds `from..from + n` (`MODEL_N`, `MODEL_SEED`): the first difference is
/// printed in full, the others by seed.
fn sweep((from, f): (u64, Features), test: &str) {
    let only = env("MODEL_SEED");
    let n = env("MODEL_N").unwrap_or(SEEDS);
    let mut fails = vec![];
    let mut first = String::new();
    for seed in (from..from + n).filter(|&s| only.is_none_or(|o| o == s)) {
        if let Err(e) = compare(&generate(seed, &f)) {
            if fails.is_empty() {
                first = e;
            }
            fails.push(seed);
        }
    }
    assert!(
        fails.is_empty(),
        "{} of {n} seeds differ: {:?}\nseed {} (MODEL_SEED={} cargo test --test model {test}):\n{first}",
        fails.len(),
        &fails[..fails.len().min(40)],
        fails[0],
        fails[0],
    );
}

/// Steps, timeouts and monitors of every behaviour but `PauseOwner`, no exception sequence,
/// no request.
#[test]
fn without_pause() {
    sweep(NONE, "without_pause");
}

/// As `without_pause`, with pause, resume and abort requests of main.
#[test]
fn with_requests() {
    sweep(REQUESTS, "with_requests");
}

/// As `with_requests`, with `PauseOwner` monitors.
#[test]
fn with_pause_owner() {
    sweep(PAUSE_OWNER, "with_pause_owner");
}

/// As `without_pause`, with exception sequences of the monitors.
#[test]
fn with_exceptions() {
    sweep(EXCEPTIONS, "with_exceptions");
}

/// Requests, `PauseOwner` monitors and exception sequences together.
#[test]
fn with_everything() {
    sweep(EVERYTHING, "with_everything");
}

/// As `with_everything`, with falling-edge and change triggers and a second pause and resume.
#[test]
fn with_more_triggers_and_pauses() {
    sweep(MORE, "with_more_triggers_and_pauses");
}

/// As `with_more_triggers_and_pauses`, with ticks 1 to 7 ms apart.
#[test]
fn with_late_ticks() {
    sweep(LATE, "with_late_ticks");
}

/// As `with_more_triggers_and_pauses`, with false pre-conditions and failing actions.
#[test]
fn with_skips_and_failures() {
    sweep(PRE_FAIL, "with_skips_and_failures");
}

/// As `with_more_triggers_and_pauses`, with requests of the steps and abort-alls.
#[test]
fn with_requests_of_steps() {
    sweep(STEP_REQUESTS, "with_requests_of_steps");
}

/// As `with_more_triggers_and_pauses`, with exception sequences of the timeouts.
#[test]
fn with_timeout_exceptions() {
    sweep(TIMEOUT_EXC, "with_timeout_exceptions");
}

/// All of the above together.
#[test]
fn with_all_extensions() {
    sweep(ALL, "with_all_extensions");
}

/// As `with_more_triggers_and_pauses`, with a sub-sequence between main and the steps.
#[test]
fn with_a_sub_sequence() {
    sweep(TREE, "with_a_sub_sequence");
}

/// As `with_a_sub_sequence`, with `AbortCallerOfOwner` and `RestartCallerOfOwner`.
#[test]
fn with_caller_behaviours() {
    sweep(TREE_CALLER, "with_caller_behaviours");
}

/// As `with_all_extensions`, with caller behaviours (one level: main and its steps).
#[test]
fn with_caller_behaviours_one_level() {
    sweep(CALLER, "with_caller_behaviours_one_level");
}

/// Everything together: the sub-sequence, caller behaviours and every extension.
#[test]
fn with_the_tree_and_everything() {
    sweep(TREE_ALL, "with_the_tree_and_everything");
}

/// As `with_caller_behaviours`, with the sub-sequence started non-blocking (scoped or not)
/// and joined, dropped, detached or left running, and starts of main by the application.
#[test]
fn with_a_non_blocking_child() {
    sweep(NB, "with_a_non_blocking_child");
}

/// As `with_the_tree_and_everything`, with the sub-sequence non-blocking.
#[test]
fn with_a_non_blocking_child_and_everything() {
    sweep(NB_ALL, "with_a_non_blocking_child_and_everything");
}

/// As `with_the_tree_and_everything`, with the sub-sequence's pre-condition false and its
/// action failing during windows, and main's action failing.
#[test]
fn with_a_sub_sequence_that_skips_and_fails() {
    sweep(SUB_PRE_FAIL, "with_a_sub_sequence_that_skips_and_fails");
}

/// As `with_a_non_blocking_child_and_everything`, with the same skips and failures.
#[test]
fn with_a_non_blocking_child_that_skips_and_fails() {
    sweep(
        NB_PRE_FAIL,
        "with_a_non_blocking_child_that_skips_and_fails",
    );
}

/// As `with_all_extensions`, with lanes of priorities 1 to 3.
#[test]
fn with_lanes_of_priorities() {
    sweep(PRIOS, "with_lanes_of_priorities");
}

/// As `with_the_tree_and_everything`, with lanes of priorities 1 to 3.
#[test]
fn with_the_tree_and_lanes_of_priorities() {
    sweep(TREE_PRIOS, "with_the_tree_and_lanes_of_priorities");
}

/// As `with_a_non_blocking_child_that_skips_and_fails`, with lanes of priorities 1 to 3.
#[test]
fn with_a_non_blocking_child_and_lanes_of_priorities() {
    sweep(
        NB_PRIOS,
        "with_a_non_blocking_child_and_lanes_of_priorities",
    );
}

/// As `with_all_extensions`, with requests of the exception sequences.
#[test]
fn with_requests_of_exception_sequences() {
    sweep(EXC_REQUESTS, "with_requests_of_exception_sequences");
}

/// As `with_the_tree_and_everything`, with requests of the exception sequences.
#[test]
fn with_the_tree_and_requests_of_exception_sequences() {
    sweep(
        TREE_EXC_REQUESTS,
        "with_the_tree_and_requests_of_exception_sequences",
    );
}

/// As `with_a_non_blocking_child_and_lanes_of_priorities`, with requests of the exception
/// sequences.
#[test]
fn with_a_non_blocking_child_and_requests_of_exception_sequences() {
    sweep(
        NB_EXC_REQUESTS,
        "with_a_non_blocking_child_and_requests_of_exception_sequences",
    );
}

/// As `with_all_extensions`, with timeouts set and switched off during runs.
#[test]
fn with_timeouts_set_during_runs() {
    sweep(SET_TIMEOUT, "with_timeouts_set_during_runs");
}

/// As `with_the_tree_and_requests_of_exception_sequences`, with timeouts set and switched
/// off during runs.
#[test]
fn with_the_tree_and_timeouts_set_during_runs() {
    sweep(
        TREE_SET_TIMEOUT,
        "with_the_tree_and_timeouts_set_during_runs",
    );
}

/// As `with_a_non_blocking_child_and_requests_of_exception_sequences`, with the child that
/// joins main paused around the end of main's run, main started again and the child resumed.
#[test]
fn with_joins_held_while_their_run_ends() {
    sweep(HELD_JOINS, "with_joins_held_while_their_run_ends");
}

/// A transition's kind: who (main, a step, an exception sequence or its `Wait`), from, to and
/// the cause without its monitor or sequence.
fn kind(sc: &Scenario, t: &Transition) -> String {
    let i = t.sequence.index();
    let k = sc.steps.len() + sc.sub.is_some() as usize;
    let who = if i < sc.steps.len() {
        "step"
    } else if i < k {
        "sub"
    } else if i == k {
        "main"
    } else if (i - k) % 2 == 1 {
        // Each exception sequence is added after its `Wait`.
        "wait"
    } else {
        "exc"
    };
    let cause = match t.cause {
        Cause::Monitor(_) => "Monitor".to_string(),
        Cause::Timeout(_) => "Timeout".to_string(),
        c => format!("{c:?}"),
    };
    format!("{who} {:?}->{:?} {cause}", t.from, t.to)
}

/// Every kind of transition the model covers occurs in the first seeds of the sweeps (in the
/// model's traces, which the sweeps compare with the simulator's).
#[test]
fn the_sweeps_reach_every_transition_the_model_covers() {
    const WANT: &[&str] = &[
        "exc Aborted->Running Monitor",
        "exc Aborting->Aborted Abort",
        "exc Aborting->Aborted Monitor",
        "exc Aborting->Aborted Timeout",
        "exc Idle->Running Monitor",
        "exc Idle->Running Timeout",
        "exc Running->Aborting AbortAll",
        "main Running->Aborting AbortAll",
        "main Paused->Aborting AbortAll",
        "main Running->Terminated PreConditionFalse",
        "step Running->Terminated PreConditionFalse",
        "step Running->Terminated Failed",
        "step Running->Aborting AbortAll",
        "wait Running->Aborting AbortAll",
        "exc Running->Aborting Abort",
        "exc Running->Aborting Monitor",
        "exc Running->Aborting Timeout",
        "exc Running->Terminated Completed",
        "exc Terminated->Running Monitor",
        "main Aborting->Aborted Abort",
        "main Aborting->Aborted Monitor",
        "main Aborting->Aborted Timeout",
        "main Idle->Running Start",
        "main Paused->Aborting Abort",
        "main Paused->Aborting Monitor",
        "main Paused->Restarting Monitor",
        "main Paused->Running Monitor",
        "main Paused->Running Resume",
        "main Restarting->Running Restart",
        "main Running->Aborting Abort",
        "main Running->Aborting Monitor",
        "main Running->Aborting Timeout",
        "main Running->Paused Monitor",
        "main Running->Paused Pause",
        "main Running->Restarting Monitor",
        "main Running->Restarting Timeout",
        "main Running->Terminated Completed",
        "step Aborted->Running Start",
        "step Aborting->Aborted Abort",
        "step Aborting->Aborted Monitor",
        "step Aborting->Aborted Timeout",
        "step Idle->Running Start",
        "step Paused->Aborting Abort",
        "step Paused->Aborting Monitor",
        "step Paused->Aborting Timeout",
        "step Paused->Restarting Monitor",
        "step Paused->Running Monitor",
        "step Paused->Running Resume",
        "step Restarting->Aborting Abort",
        "step Restarting->Aborting Monitor",
        "step Restarting->Aborting Timeout",
        "step Restarting->Running Restart",
        "step Running->Aborting Abort",
        "step Running->Aborting Monitor",
        "step Running->Aborting Timeout",
        "step Running->Paused Monitor",
        "step Running->Paused Pause",
        "step Running->Restarting Monitor",
        "step Running->Restarting Timeout",
        "step Running->Terminated Completed",
        "step Terminated->Running Start",
        "wait Aborted->Running Start",
        "wait Aborting->Aborted Abort",
        "wait Aborting->Aborted Monitor",
        "wait Aborting->Aborted Timeout",
        "wait Idle->Running Start",
        "wait Running->Aborting Abort",
        "wait Running->Aborting Monitor",
        "wait Running->Aborting Timeout",
        "wait Running->Terminated Completed",
        "wait Terminated->Running Start",
    ];
    let mut seen = BTreeSet::new();
    for (from, f) in [
        NONE,
        REQUESTS,
        PAUSE_OWNER,
        EXCEPTIONS,
        EVERYTHING,
        MORE,
        ALL,
    ] {
        for seed in from..from + 1000 {
            let sc = generate(seed, &f);
            seen.extend(run_model(&sc).0.iter().map(|t| kind(&sc, t)));
        }
    }
    let missing: Vec<&str> = WANT
        .iter()
        .copied()
        .filter(|w| !seen.contains(*w))
        .collect();
    assert!(
        missing.is_empty(),
        "not reached: {missing:?}\nreached: {seen:#?}"
    );
}

/// Main blocking on one step that ends at 70 ms, all at 1 ms, with monitors from 5 to 30 ms.
fn one_step(monitors: Vec<MonCfg>, requests: Vec<(u64, Req)>) -> Scenario {
    let step = StepCfg {
        period: 1,
        exit: Exit::Flag(70),
        timeout: None,
        timeout_exc: None,
        pre_false: None,
        fail: None,
    };
    Scenario {
        steps: vec![step],
        sub: None,
        main_ops: vec![],
        bg_joins_main: false,
        main_period: 1,
        main_timeout: None,
        main_timeout_exc: None,
        main_pre_false: None,
        main_fail: None,
        monitors,
        // Of main (id 1).
        requests: requests.into_iter().map(|(t, r)| (t, 1, r)).collect(),
        ticks: (1..=80).collect(),
        prios: vec![],
    }
}

/// Monitor of `owner` firing at 5 ms with `beh` and a 3 ms exception sequence.
fn fires_at_5(owner: usize, beh: Beh) -> MonCfg {
    MonCfg {
        owner,
        from: 5,
        to: 30,
        trigger: Trigger::RisingEdge,
        beh,
        exception: Some(3),
    }
}

/// Item 3, which the sweeps seldom reach: the exception sequences of the step (id 0) and of
/// main (id 1) end before the same tick; the step's restart comes first, then main's abort.
#[test]
fn behaviours_of_exception_sequences_ended_together_go_by_owner_id() {
    let sc = one_step(
        vec![fires_at_5(0, Beh::Restart(3)), fires_at_5(1, Beh::Abort)],
        vec![],
    );
    compare(&sc).unwrap();
    let (trace, _) = run_model(&sc);
    let (s, m) = (SeqId::from_index(0), SeqId::from_index(1));
    let (m0, m1) = (Model::mon_cause(0), Model::mon_cause(1));
    let at_9: Vec<_> = trace.iter().filter(|t| ms(t.time) == 9).copied().collect();
    let first = [
        tr(9, s, Running, Restarting, m0),
        tr(9, s, Restarting, Aborting, m1),
        tr(9, s, Aborting, Aborted, m1),
        tr(9, m, Running, Aborting, m1),
        tr(9, m, Aborting, Aborted, m1),
    ];
    assert_eq!(at_9, first, "\n{}", show(&trace));
}

/// Items 4, 7, which the sweeps seldom reach: a pause of main asked for just before the tick
/// that applies its exception sequence's restart is taken and never seen, and a resume
/// afterwards is refused.
#[test]
fn a_pause_asked_for_before_a_restart_ends_with_the_round() {
    let requests = vec![(9, Req::Pause), (10, Req::Resume)];
    let sc = one_step(vec![fires_at_5(1, Beh::Restart(3))], requests);
    compare(&sc).unwrap();
    let (trace, results) = run_model(&sc);
    let m = SeqId::from_index(1);
    assert_eq!(results, [Ok(()), Err(Error::NotPaused(m))]);
    assert!(trace.contains(&tr(9, m, Running, Restarting, Model::mon_cause(0))));
    assert!(trace.iter().all(|t| t.to != Paused), "\n{}", show(&trace));
}

/// The rare cases of the caller behaviours occur in the first seeds of the tree sweeps.
#[test]
fn the_sweeps_reach_the_caller_cases() {
    let mut reached: BTreeMap<&str, usize> = BTreeMap::new();
    for (from, f) in [TREE_CALLER, TREE_ALL] {
        for seed in from..from + 2000 {
            let sc = generate(seed, &f);
            let m = model_of(&sc);
            for (k, v) in m.reached {
                *reached.entry(k).or_default() += v;
            }
        }
    }
    assert_eq!(reached.len(), 8, "{reached:#?}");
}

/// The cases of the non-blocking child occur in the first seeds of its sweeps.
#[test]
fn the_sweeps_reach_the_non_blocking_cases() {
    let mut reached: BTreeMap<&str, usize> = BTreeMap::new();
    for (from, f) in [NB, NB_ALL] {
        for seed in from..from + 1000 {
            let sc = generate(seed, &f);
            let m = model_of(&sc);
            for (k, v) in m.reached {
                if k.starts_with("nb:") {
                    *reached.entry(k).or_default() += v;
                }
            }
        }
    }
    assert_eq!(reached.len(), 9, "{reached:#?}");
}

/// Main (id 2) runs the sub-sequence (id 1), which runs one step (id 0) ending at 70 ms.
fn sub_scenario(monitors: Vec<MonCfg>, requests: Vec<(u64, usize, Req)>) -> Scenario {
    let mut sc = one_step(monitors, vec![]);
    sc.sub = Some(SubCfg {
        period: 1,
        first: 0,
        len: 1,
        timeout: None,
        timeout_exc: None,
        pre_false: None,
        fail: None,
        nb: None,
    });
    sc.requests = requests;
    sc
}

/// Items 3 and 5 say nothing of it (a silence, followed from rtseq): the step's
/// `RestartCallerOfOwner` (no exception sequence) fires at 8 ms while its caller, the
/// sub-sequence, handles an exception of its own (its exception sequence runs 5 to 15 ms): the
/// sub-sequence is restarted at once, its exception sequence aborted below it, and the
/// `RestartOwner` its exception would have applied never comes.
#[test]
fn a_caller_behaviour_cuts_short_its_target_s_own_exception() {
    let mut own = fires_at_5(1, Beh::Restart(3));
    own.exception = Some(10);
    own.to = 6;
    let child = MonCfg {
        owner: 0,
        from: 8,
        to: 9,
        trigger: Trigger::RisingEdge,
        beh: Beh::CallerRestart(3),
        exception: None,
    };
    let sc = sub_scenario(vec![own, child], vec![]);
    compare(&sc).unwrap();
    let (trace, _) = run_model(&sc);
    let (s, sub, w, e) = (
        SeqId::from_index(0),
        SeqId::from_index(1),
        SeqId::from_index(3),
        SeqId::from_index(4),
    );
    let m1 = Model::mon_cause(1);
    let at_8: Vec<_> = trace.iter().filter(|t| ms(t.time) == 8).copied().collect();
    let want = [
        tr(8, w, Running, Aborting, m1),
        tr(8, w, Aborting, Aborted, m1),
        tr(8, s, Running, Aborting, m1),
        tr(8, s, Aborting, Aborted, m1),
        tr(8, e, Running, Aborting, m1),
        tr(8, e, Aborting, Aborted, m1),
        tr(8, sub, Running, Restarting, m1),
        tr(8, sub, Restarting, Running, Cause::Restart),
        tr(8, s, Aborted, Running, Cause::Start),
    ];
    assert_eq!(at_8, want, "\n{}", show(&trace));
    assert!(trace
        .iter()
        .all(|t| ms(t.time) <= 8 || t.cause != Model::mon_cause(0)));
}

/// Every result a request can have in the model occurs in the first seeds of the sweeps
/// with requests, so the comparison of exact results bites on each.
#[test]
fn the_sweeps_reach_every_request_result() {
    let mut reached: BTreeMap<String, usize> = BTreeMap::new();
    for (from, f) in [PAUSE_OWNER, STEP_REQUESTS, TREE_ALL, NB] {
        for seed in from..from + 1000 {
            for r in run_model(&generate(seed, &f)).1 {
                let kind = match r {
                    Ok(()) => "Ok".to_string(),
                    Err(e) => format!("{e:?}").split('(').next().unwrap().to_string(),
                };
                *reached.entry(kind).or_default() += 1;
            }
        }
    }
    let kinds: Vec<&str> = reached.keys().map(|k| k.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "AlreadyPaused",
            "AlreadyRunning",
            "HeldByMonitor",
            "NotPaused",
            "NotRunning",
            "Ok"
        ],
        "{reached:#?}"
    );
}

/// The skips and failures of the sub-sequence (blocking and non-blocking, at a start and at
/// a restart) and main's failures occur in the first seeds of their sweeps.
#[test]
fn the_sweeps_reach_the_skips_and_failures_of_the_tree() {
    const WANT: &[&str] = &[
        "main Running->Terminated Failed",
        "sub Restarting->Running Restart",
        "sub Running->Terminated Failed",
        "sub Running->Terminated PreConditionFalse",
    ];
    for (from, f) in [SUB_PRE_FAIL, NB_PRE_FAIL] {
        let mut seen = BTreeSet::new();
        for seed in from..from + 1000 {
            let sc = generate(seed, &f);
            let trace = run_model(&sc).0;
            seen.extend(trace.iter().map(|t| kind(&sc, t)));
            // A restart whose round the pre-condition ends at once.
            if trace
                .windows(2)
                .any(|w| w[0].cause == Cause::Restart && w[1].cause == Cause::PreConditionFalse)
            {
                seen.insert("a restart skipped".to_string());
            }
        }
        let missing: Vec<&str> = WANT
            .iter()
            .chain(&["a restart skipped"])
            .copied()
            .filter(|w| !seen.contains(*w))
            .collect();
        assert!(missing.is_empty(), "{from}: not reached: {missing:?}");
    }
}

/// A lane of a higher priority woken by a lower lane's poll runs before that lane's pass
/// goes on, in the first seeds of the sweep with a non-blocking child.
#[test]
fn the_sweeps_reach_a_preempting_lane() {
    let (from, f) = NB_PRIOS;
    let reached = (from..from + 1000).any(|seed| {
        let sc = generate(seed, &f);
        model_of(&sc)
            .reached
            .contains_key("lanes: a lane above preempts")
    });
    assert!(reached);
}

/// Pauses, resumes and aborts of exception sequences (and their `Wait`s with them) occur in
/// the first seeds of their sweeps, and an aborted one's behaviour follows.
#[test]
fn the_sweeps_reach_the_requests_of_exception_sequences() {
    const WANT: &[&str] = &[
        "exc Paused->Aborting Abort",
        "exc Paused->Running Resume",
        "exc Running->Paused Pause",
        "wait Paused->Running Resume",
        "wait Running->Paused Pause",
    ];
    for (from, f) in [EXC_REQUESTS, TREE_EXC_REQUESTS, NB_EXC_REQUESTS] {
        let mut seen = BTreeSet::new();
        for seed in from..from + 1000 {
            let sc = generate(seed, &f);
            let m = model_of(&sc);
            seen.extend(m.trace.iter().map(|t| kind(&sc, t)));
            seen.extend(m.reached.keys().map(|k| k.to_string()));
        }
        let missing: Vec<&str> = WANT
            .iter()
            .chain(&["exc: aborted by a request, the behaviour follows"])
            .copied()
            .filter(|w| !seen.contains(*w))
            .collect();
        assert!(missing.is_empty(), "{from}: not reached: {missing:?}");
    }
}

/// Every join result comes in the first seeds of the sweeps with a non-blocking child
/// (`OutcomeLost`, a joiner held while its target runs twice, in those of `HELD_JOINS`).
#[test]
fn the_sweeps_reach_every_join_result() {
    let mut reached: BTreeMap<String, usize> = BTreeMap::new();
    for (from, f) in [
        NB,
        NB_ALL,
        NB_PRE_FAIL,
        NB_PRIOS,
        NB_EXC_REQUESTS,
        HELD_JOINS,
    ] {
        for seed in from..from + 2000 {
            for (_, _, r) in model_of(&generate(seed, &f)).joins {
                let kind = match r {
                    Ok(o) => format!("{o:?}"),
                    Err(e) => format!("{e:?}"),
                };
                let kind = kind.split('(').next().unwrap().to_string();
                *reached.entry(kind).or_default() += 1;
            }
        }
    }
    let kinds: Vec<&str> = reached.keys().map(|k| k.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "Aborted",
            "Completed",
            "Failed",
            "JoinWouldDeadlock",
            "OutcomeLost",
            "Skipped"
        ],
        "{reached:#?}"
    );
}

/// Item 14 and `Error::OutcomeLost`, made on purpose (`HELD_JOINS` sweeps it): the non-blocking child
/// (id 2) runs step 0 until 2 ms, then joins main's run 1 (id 3, which runs step 1 until
/// 10 ms); the child is paused at 4 ms, so it has not returned when main's run 1 ends. The
/// application starts main again at 15 ms; run 2 ends at once (step 1's exit holds). Resumed
/// at 20 ms, the child's join finds run 1's outcome replaced by run 2's: `OutcomeLost`.
#[test]
fn a_join_held_while_its_target_runs_twice_has_lost_the_outcome() {
    let step = |at| StepCfg {
        period: 1,
        exit: Exit::Flag(at),
        timeout: None,
        timeout_exc: None,
        pre_false: None,
        fail: None,
    };
    let mut sc = sub_scenario(vec![], vec![]);
    sc.steps = vec![step(2), step(10)];
    if let Some(sub) = sc.sub.as_mut() {
        sub.nb = Some(false);
    }
    sc.main_ops = vec![MainOp::Start, MainOp::Step(1)];
    sc.bg_joins_main = true;
    sc.requests = vec![
        (4, 2, Req::Pause),
        (15, 3, Req::Start),
        (20, 2, Req::Resume),
    ];
    compare(&sc).unwrap();
    let m = model_of(&sc);
    let main = SeqId::from_index(3);
    assert_eq!(
        m.joins,
        [(20, SeqId::from_index(2), Err(Error::OutcomeLost(main)))],
        "\n{}",
        show(&m.trace)
    );
}
