//! A reference model of the safety system's documented semantics (what one
//! `SafetySystem::cycle` does: docs/semantics.md, "The safety system", and the rustdoc of
//! `rtseq::safety`), written from the documents alone, compared cycle by cycle with
//! `SafetySystem::cycle` over property tables and input / trigger traces generated from
//! seeds. Each rule the model encodes names the document line it comes from.
//!
//! Compared after every cycle: the report; the level (system and handle); the ordered log
//! of input reads, output writes, exit / entry / level actions (with the level, counters,
//! handle level and handle cycle count they see) and `Sequences` calls; every level's
//! counters; the unknown-event count and the last unknown event; the handle's cycle count
//! and pending events.
//!
//! Generated: 2 to 8 levels; 0 to 4 critical inputs and outputs (now and then 28 to 32) of
//! every kind, each level with its own order of them; `check`, `range`, `off_range` and
//! `ignore` (NaN, infinities, the extreme integers, readings of the wrong kind); `set`,
//! `leave` and `toggle`; every abort policy; rows of all four forms (`on`, `between`,
//! `and_above`, `and_below`) with public and private events, "stay" rows among them; entry,
//! exit and level actions, the entry and level actions triggering events (in range with and
//! without a row, and out of range) by their counters; triggers from the handle between
//! cycles, repeated now and then, out-of-range ids among them.
//!
//! Not modelled: saturation of the counters and wrapping of the handle's cycle count, the
//! handle's binding and release, the sequencer behind `Sequences` (a recorder stands in for
//! it).
//!
//! The sweep compares seeds 1 to 3000; `MODEL_N=n` compares `n` seeds, `MODEL_FROM=s`
//! starts at seed `s`, `MODEL_SEED=s` compares seed `s` only (a failure names its seeds and
//! the command): `MODEL_SEED=17 cargo test --test safety_model the_model_matches_rtseq`.
//! `the_sweep_reaches_every_rule_the_model_covers` checks that the sweep meets every rule;
//! out-of-range events of the handle and of the system's actions in one cycle, which it
//! meets least often (in a few dozen of the 3000 seeds), have tests of their own.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::rc::Rc;

use rtseq::safety::*;

// ---------------------------------------------------------------------------------------
// The plain description, shared by the model and the builder of rtseq's properties.
// ---------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
enum Val {
    B(bool),
    I(i32),
    F(f32),
}

/// Floats compare by their bits: a write of NaN or -0.0 is seen as written.
impl PartialEq for Val {
    fn eq(&self, o: &Val) -> bool {
        match (self, o) {
            (Val::B(a), Val::B(b)) => a == b,
            (Val::I(a), Val::I(b)) => a == b,
            (Val::F(a), Val::F(b)) => a.to_bits() == b.to_bits(),
            _ => false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    B,
    I,
    F,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Ev {
    Pub(u8),
    Priv(u8),
}

#[derive(Clone, Copy, Debug)]
enum Chk {
    Ignore,
    Check(Val, Ev),
    Range(Val, Val, Ev),
    OffRange(Val, Val, Ev),
}

#[derive(Clone, Copy, Debug)]
enum Out {
    Set(Val),
    Leave,
    /// (low, high).
    Toggle(Val, Val),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ab {
    Never,
    OnEntry,
    WhileActive,
}

#[derive(Clone, Copy, Debug)]
struct Row {
    low: u8,
    high: u8,
    ev: Ev,
    to: u8,
    /// 0 `on`, 1 `on_levels_between`, 2 `on_level_and_above`, 3 `on_level_and_below`.
    form: u8,
}

#[derive(Clone, Debug)]
struct LevelSpec {
    /// (input, action), in the level's order.
    inputs: Vec<(usize, Chk)>,
    /// (output, action), in the level's order.
    outputs: Vec<(usize, Out)>,
    action: bool,
    entry: bool,
    exit: bool,
    abort: Ab,
}

/// (level, modulus, residue, event): the level's action (entry action) triggers `event`
/// when its `cycles` (`activations`) % modulus == residue; one entry per trigger.
type Script = Vec<(u8, u32, u32, Ev)>;

#[derive(Clone, Debug)]
struct Spec {
    levels: Vec<LevelSpec>,
    in_kinds: Vec<Kind>,
    out_kinds: Vec<Kind>,
    rows: Vec<Row>,
    entry: u8,
    action_script: Script,
    entry_script: Script,
}

/// One cycle's input: the public event ids triggered on the handle before it, in order,
/// and the inputs' readings.
#[derive(Clone, Debug)]
struct Step {
    triggers: Vec<u8>,
    inputs: Vec<Val>,
}

// ---------------------------------------------------------------------------------------
// Observations
// ---------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq)]
enum Obs {
    Read(usize),
    Write(usize, Val),
    /// Owner level; the handle's level and cycle count seen inside the action.
    Exit(u8, u8, u32),
    /// Owner level; the context's level, activations and cycles; the handle's level and
    /// cycle count.
    Entry(u8, u8, u32, u32, u8, u32),
    Action(u8, u8, u32, u32, u8, u32),
    LevelEntered(u8),
    Abort,
    Tripped(usize),
}

/// Everything seen in and after one cycle.
#[derive(Clone, Debug, PartialEq)]
struct CycleObs {
    log: Vec<Obs>,
    level: u8,
    change: Option<(Option<u8>, u8)>,
    input_events: u32,
    aborted: bool,
    unknown: u32,
    sys_level: u8,
    handle_level: u8,
    handle_cycles: u32,
    handle_pending: u32,
    /// (activations, cycles) of every level.
    stats: Vec<(u32, u32)>,
    unknown_total: u32,
    last_unknown: Option<(Ev, u8)>,
}

// ---------------------------------------------------------------------------------------
// The model (from the documents only)
// ---------------------------------------------------------------------------------------

/// How often the model met each situation its rules are about (counted in the model, which
/// the sweep compares with rtseq).
#[derive(Clone, Copy, Debug, Default)]
struct Reached {
    cycles: u64,
    level_changes: u64,
    /// A cycle whose events lead to two or more destinations.
    several_destinations: u64,
    /// A "stay" row wins ...
    stay_wins: u64,
    /// ... in a level with a toggle output,
    stay_wins_toggling: u64,
    /// ... in a level with an entry or exit action or `OnEntry`.
    stay_wins_with_entry_work: u64,
    unknown_in_range: u64,
    /// Two or more out-of-range triggers from the handle resolved in one cycle.
    out_of_range_repeated_by_handle: u64,
    /// Two or more out-of-range triggers of the system's actions resolved in one cycle.
    out_of_range_repeated_by_system: u64,
    /// Out-of-range triggers of both resolved in one cycle.
    out_of_range_from_both: u64,
    input_fires: u64,
    wrong_kind_or_nan_fires: u64,
    trips: u64,
    /// Two or more trips in a cycle whose level reads them out of id order.
    trips_read_out_of_id_order: u64,
    /// An input that fired before a level change goes on firing under the new level.
    firing_across_a_change: u64,
    /// An input whose firing an `ignore`d cycle ended trips again.
    trips_after_an_ignore: u64,
    level_action_events: u64,
    entry_action_events: u64,
    toggle_writes: u64,
    aborts: u64,
    /// `OnEntry` abort in a cycle that entered a level with an entry action.
    on_entry_abort_after_an_entry_action: u64,
}

impl Reached {
    fn add(&mut self, o: &Reached) {
        for (a, b) in self.counts_mut().into_iter().zip(o.counts()) {
            *a.1 += b.1;
        }
    }
    fn counts(&self) -> Vec<(&'static str, u64)> {
        let mut c = *self;
        c.counts_mut().into_iter().map(|(n, v)| (n, *v)).collect()
    }
    fn counts_mut(&mut self) -> Vec<(&'static str, &mut u64)> {
        vec![
            ("cycles", &mut self.cycles),
            ("level_changes", &mut self.level_changes),
            ("several_destinations", &mut self.several_destinations),
            ("stay_wins", &mut self.stay_wins),
            ("stay_wins_toggling", &mut self.stay_wins_toggling),
            (
                "stay_wins_with_entry_work",
                &mut self.stay_wins_with_entry_work,
            ),
            ("unknown_in_range", &mut self.unknown_in_range),
            (
                "out_of_range_repeated_by_handle",
                &mut self.out_of_range_repeated_by_handle,
            ),
            (
                "out_of_range_repeated_by_system",
                &mut self.out_of_range_repeated_by_system,
            ),
            ("out_of_range_from_both", &mut self.out_of_range_from_both),
            ("input_fires", &mut self.input_fires),
            ("wrong_kind_or_nan_fires", &mut self.wrong_kind_or_nan_fires),
            ("trips", &mut self.trips),
            (
                "trips_read_out_of_id_order",
                &mut self.trips_read_out_of_id_order,
            ),
            ("firing_across_a_change", &mut self.firing_across_a_change),
            ("trips_after_an_ignore", &mut self.trips_after_an_ignore),
            ("level_action_events", &mut self.level_action_events),
            ("entry_action_events", &mut self.entry_action_events),
            ("toggle_writes", &mut self.toggle_writes),
            ("aborts", &mut self.aborts),
            (
                "on_entry_abort_after_an_entry_action",
                &mut self.on_entry_abort_after_an_entry_action,
            ),
        ]
    }
}

/// semantics.md, "Inputs": "`check(expected)` fires while the input differs; `range(min,
/// max)` fires outside `[min, max]` (bounds inclusive); `off_range(min, max)` fires strictly
/// inside `(min, max)`. NaN and readings of the wrong kind fire (fail-safe)."
fn fires(chk: &Chk, v: Val) -> bool {
    match *chk {
        Chk::Ignore => false,
        Chk::Check(e, _) => !match (v, e) {
            (Val::B(a), Val::B(b)) => a == b,
            (Val::I(a), Val::I(b)) => a == b,
            (Val::F(a), Val::F(b)) => a == b,
            _ => false,
        },
        Chk::Range(lo, hi, _) => !match (v, lo, hi) {
            (Val::I(x), Val::I(a), Val::I(b)) => a <= x && x <= b,
            (Val::F(x), Val::F(a), Val::F(b)) => !x.is_nan() && a <= x && x <= b,
            _ => false,
        },
        Chk::OffRange(lo, hi, _) => !match (v, lo, hi) {
            (Val::I(x), Val::I(a), Val::I(b)) => x <= a || x >= b,
            (Val::F(x), Val::F(a), Val::F(b)) => !x.is_nan() && (x <= a || x >= b),
            _ => false,
        },
    }
}

fn chk_event(chk: &Chk) -> Option<Ev> {
    match *chk {
        Chk::Ignore => None,
        Chk::Check(_, e) | Chk::Range(_, _, e) | Chk::OffRange(_, _, e) => Some(e),
    }
}

fn is_wrong_kind_or_nan(v: Val, k: Kind) -> bool {
    match (v, k) {
        (Val::F(x), Kind::F) => x.is_nan(),
        (Val::B(_), Kind::B) | (Val::I(_), Kind::I) => false,
        _ => true,
    }
}

struct Model<'s> {
    spec: &'s Spec,
    started: bool,
    level: u8,
    /// (activations, cycles) of every level.
    stats: Vec<(u32, u32)>,
    /// Cycles run since the level was entered: the toggles' phase.
    since_entry: u32,
    /// Public ids below 32 triggered on the handle (one bit each).
    handle_pub: BTreeSet<u8>,
    /// Out-of-range ids triggered on the handle, each trigger in order.
    handle_oor: Vec<Ev>,
    /// Events triggered inside the system (input, entry and level actions), likewise.
    own_pub: BTreeSet<u8>,
    own_priv: BTreeSet<u8>,
    own_oor: Vec<Ev>,
    /// The inputs whose check fired in the last cycle.
    firing: u32,
    /// Inputs that were firing when a level ignored them, until read again (`reached`).
    ended_by_ignore: u32,
    unknown_total: u32,
    last_unknown: Option<(Ev, u8)>,
    handle_level: u8,
    handle_cycles: u32,
    reached: Reached,
}

impl<'s> Model<'s> {
    fn new(spec: &'s Spec) -> Self {
        Model {
            spec,
            started: false,
            level: spec.entry,
            // semantics.md, "Counters": "zero for every level at construction".
            stats: vec![(0, 0); spec.levels.len()],
            since_entry: 0,
            handle_pub: BTreeSet::new(),
            handle_oor: Vec::new(),
            own_pub: BTreeSet::new(),
            own_priv: BTreeSet::new(),
            own_oor: Vec::new(),
            firing: 0,
            ended_by_ignore: 0,
            unknown_total: 0,
            last_unknown: None,
            // `SafetySystem::new`: "publishes the entry level on it".
            handle_level: spec.entry,
            handle_cycles: 0,
            reached: Reached::default(),
        }
    }

    /// semantics.md, "Several events in one cycle": "Triggering the same event several times
    /// between two cycles counts once (an id below 32: the pending events are one bit
    /// each)"; "Unknown events": "An id ≥ 32 has no bit to keep: each trigger of it counts".
    fn trigger_from_handle(&mut self, id: u8) {
        if id < 32 {
            self.handle_pub.insert(id);
        } else {
            self.handle_oor.push(Ev::Pub(id));
        }
    }

    /// As [`trigger_from_handle`](Self::trigger_from_handle), for the system's own events.
    fn trigger_inside(&mut self, ev: Ev) {
        match ev {
            Ev::Pub(i) if i < 32 => {
                self.own_pub.insert(i);
            }
            Ev::Priv(i) if i < 32 => {
                self.own_priv.insert(i);
            }
            _ => self.own_oor.push(ev),
        }
    }

    /// The destination of `ev` in `level`, if a row covers them (validated tables have at
    /// most one: semantics.md, "Completeness", `ConflictingTransition`).
    fn dest(&self, level: u8, ev: Ev) -> Option<u8> {
        self.spec
            .rows
            .iter()
            .find(|r| r.ev == ev && r.low <= level && level <= r.high)
            .map(|r| r.to)
    }

    /// semantics.md, "One cycle" (1): "publish the new level on the handle, count the
    /// activation, entry action of the new level".
    fn enter(&mut self, to: u8, log: &mut Vec<Obs>) {
        self.level = to;
        self.handle_level = to;
        self.stats[to as usize].0 += 1;
        // semantics.md, "Outputs": toggles start "with `low` in the cycle the level is
        // entered".
        self.since_entry = 0;
        if self.spec.levels[to as usize].entry {
            // semantics.md, "Counters": "an entry action's count its own entry and the
            // cycles before it".
            let (act, cyc) = self.stats[to as usize];
            log.push(Obs::Entry(
                to,
                to,
                act,
                cyc,
                self.handle_level,
                self.handle_cycles,
            ));
            for &(l, m, r, ev) in &self.spec.entry_script {
                if l == to && act % m == r {
                    self.reached.entry_action_events += 1;
                    self.trigger_inside(ev);
                }
            }
        }
    }

    /// Step (1) of a cycle after the first: resolves the pending events, changes the level.
    /// Returns the unknown count and the change.
    fn resolve(&mut self, log: &mut Vec<Obs>) -> (u32, Option<(Option<u8>, u8)>) {
        // semantics.md, "Several events in one cycle": "every one is resolved against the
        // level the cycle starts in".
        let level = self.level;
        let handle_oor = std::mem::take(&mut self.handle_oor);
        let own_oor = std::mem::take(&mut self.own_oor);
        self.reached.out_of_range_repeated_by_handle += u64::from(handle_oor.len() > 1);
        self.reached.out_of_range_repeated_by_system += u64::from(own_oor.len() > 1);
        self.reached.out_of_range_from_both +=
            u64::from(!handle_oor.is_empty() && !own_oor.is_empty());
        // semantics.md, "One cycle" (1): "public ones from the handle, public and private
        // ones triggered inside the system in the previous cycle".
        let mut public = std::mem::take(&mut self.handle_pub);
        public.extend(std::mem::take(&mut self.own_pub));
        let private = std::mem::take(&mut self.own_priv);
        // `SafetySystem::last_unknown_event`: "events are resolved public ones by ascending
        // id, then private ones by ascending id, then out-of-range ones"; semantics.md,
        // "Unknown events": "the handle's before those of the system's own actions".
        let events = public
            .iter()
            .map(|&i| Ev::Pub(i))
            .chain(private.iter().map(|&i| Ev::Priv(i)))
            .chain(handle_oor)
            .chain(own_oor);
        let mut unknown = 0;
        let mut best: Option<u8> = None;
        let mut dests = BTreeSet::new();
        for ev in events {
            match self.dest(level, ev) {
                // semantics.md, "One cycle" (1): "the safest (lowest) destination wins".
                Some(to) => {
                    dests.insert(to);
                    best = Some(best.map_or(to, |b| b.min(to)));
                }
                // semantics.md, "Unknown events": "no transition from the current level, or
                // an id ≥ 32"; `last_unknown_event()` "names the last one and the level".
                None => {
                    unknown += 1;
                    self.last_unknown = Some((ev, level));
                    self.reached.unknown_in_range +=
                        u64::from(matches!(ev, Ev::Pub(i) | Ev::Priv(i) if i < 32));
                }
            }
        }
        self.unknown_total += unknown;
        self.reached.several_destinations += u64::from(dests.len() > 1);
        let ls = &self.spec.levels[level as usize];
        match best {
            // semantics.md, "Several events in one cycle": "A "stay" row that wins is no
            // change: no exit or entry action, no activation counted, no `level_entered`, no
            // `abort_all` of `OnEntry`, and toggles go on with their phase."
            Some(to) if to == level => {
                self.reached.stay_wins += 1;
                self.reached.stay_wins_toggling +=
                    u64::from(ls.outputs.iter().any(|(_, o)| matches!(o, Out::Toggle(..))));
                self.reached.stay_wins_with_entry_work +=
                    u64::from(ls.entry || ls.exit || ls.abort == Ab::OnEntry);
                (unknown, None)
            }
            // semantics.md, "One cycle" (1): "if it differs from the current level: exit
            // action of the old level, publish the new level ...".
            Some(to) => {
                if ls.exit {
                    log.push(Obs::Exit(level, self.handle_level, self.handle_cycles));
                }
                self.enter(to, log);
                (unknown, Some((Some(level), to)))
            }
            None => (unknown, None),
        }
    }

    fn cycle(&mut self, inputs: &[Val]) -> CycleObs {
        let mut log = Vec::new();
        let (unknown, change) = if self.started {
            self.resolve(&mut log)
        } else {
            // semantics.md, "One cycle": "The first cycle enters the entry level (entry
            // action, no exit action)"; "Timing": "events triggered before it are resolved in
            // the second".
            self.started = true;
            self.enter(self.spec.entry, &mut log);
            (0, Some((None, self.spec.entry)))
        };
        let level = self.level;
        let ls = &self.spec.levels[level as usize];
        let entered = change.is_some();
        self.reached.level_changes += u64::from(matches!(change, Some((Some(_), _))));
        // `SafetySystem::cycle` (1): "A new level is told to `sequences`
        // ([`Sequences::level_entered`])"; semantics.md, "Abort": `OnEntry` comes "after the
        // entry action and `Sequences::level_entered`".
        if entered {
            log.push(Obs::LevelEntered(level));
        }
        // semantics.md, "Abort": "`AbortPolicy::OnEntry` calls `Sequences::abort_all` once, in
        // the entering cycle ...; `AbortPolicy::WhileActive` calls it in every cycle in the
        // level".
        let aborted = match ls.abort {
            Ab::Never => false,
            Ab::OnEntry => entered,
            Ab::WhileActive => true,
        };
        if aborted {
            log.push(Obs::Abort);
            self.reached.aborts += 1;
            self.reached.on_entry_abort_after_an_entry_action +=
                u64::from(ls.abort == Ab::OnEntry && ls.entry);
        }
        // semantics.md, "Counters": `cycles` "cycles run in the level"; "a level action's
        // [count] its own cycle".
        self.stats[level as usize].1 += 1;
        // semantics.md, "One cycle" (3): "input actions in the level's order"; "Inputs":
        // "`ignore`d inputs are not read".
        let mut fired = 0u32;
        let mut read_tripping = Vec::new();
        for &(i, chk) in &ls.inputs {
            let bit = 1u32 << i;
            if let Chk::Ignore = chk {
                if self.firing & bit != 0 {
                    self.ended_by_ignore |= bit;
                }
                continue;
            }
            log.push(Obs::Read(i));
            if fires(&chk, inputs[i]) {
                self.reached.input_fires += 1;
                self.reached.wrong_kind_or_nan_fires +=
                    u64::from(is_wrong_kind_or_nan(inputs[i], self.spec.in_kinds[i]));
                // semantics.md, "Inputs": "`CycleReport::input_events` has one bit per
                // input"; "Timing": an event "by an input ... in cycle n − 1" changes the
                // level in cycle n.
                fired |= bit;
                self.trigger_inside(chk_event(&chk).unwrap());
                if self.firing & bit == 0 {
                    read_tripping.push(i);
                    self.reached.trips_after_an_ignore +=
                        u64::from(self.ended_by_ignore & bit != 0);
                } else if matches!(change, Some((Some(_), _))) {
                    self.reached.firing_across_a_change += 1;
                }
            }
            self.ended_by_ignore &= !bit;
        }
        // semantics.md, "Inputs": "An input *trips* (`Sequences::input_tripped`) in the
        // cycle its check fires and did not in the cycle before, whatever the level then:
        // ... a cycle in which it is `ignore`d ends its firing. The trips are reported after
        // every input is read, by ascending input id."
        let tripped = fired & !self.firing;
        self.firing = fired;
        self.reached.trips += u64::from(tripped.count_ones());
        self.reached.trips_read_out_of_id_order +=
            u64::from(read_tripping.windows(2).any(|w| w[0] > w[1]));
        for i in 0..32 {
            if tripped & (1 << i) != 0 {
                log.push(Obs::Tripped(i));
            }
        }
        // semantics.md, "One cycle" (4): "the level action".
        if ls.action {
            let (act, cyc) = self.stats[level as usize];
            log.push(Obs::Action(
                level,
                level,
                act,
                cyc,
                self.handle_level,
                self.handle_cycles,
            ));
            for &(l, m, r, ev) in &self.spec.action_script {
                if l == level && cyc % m == r {
                    self.reached.level_action_events += 1;
                    self.trigger_inside(ev);
                }
            }
        }
        // semantics.md, "One cycle" (5): "the output actions"; "Outputs": "`set(v)` writes
        // every cycle, `leave` never writes, `toggle` writes `low, high, low, …` starting
        // with `low` in the cycle the level is entered".
        for &(o, out) in &ls.outputs {
            match out {
                Out::Set(v) => log.push(Obs::Write(o, v)),
                Out::Leave => {}
                Out::Toggle(lo, hi) => {
                    self.reached.toggle_writes += 1;
                    let v = if self.since_entry % 2 == 1 { hi } else { lo };
                    log.push(Obs::Write(o, v));
                }
            }
        }
        self.since_entry += 1;
        // semantics.md, "Counters": "`SafetyHandle::cycles()` counts all cycles, at the end
        // of each (after the outputs): an action of cycle `n` (from 1) reads `n - 1`".
        self.handle_cycles += 1;
        self.reached.cycles += 1;
        CycleObs {
            log,
            // `CycleReport::level`: "The level whose inputs, action and outputs ran in this
            // cycle"; `change`: "The transition applied at the start of this cycle".
            level,
            change,
            input_events: fired,
            aborted,
            // `CycleReport::unknown_events`: "Number of unknown events found at the start of
            // this cycle".
            unknown,
            sys_level: self.level,
            handle_level: self.handle_level,
            handle_cycles: self.handle_cycles,
            // `SafetyHandle::pending_events`: "Public events triggered but not yet consumed
            // by a cycle".
            handle_pending: self.handle_pub.iter().fold(0, |m, &i| m | (1 << i)),
            stats: self.stats.clone(),
            unknown_total: self.unknown_total,
            last_unknown: self.last_unknown,
        }
    }
}

fn run_model(spec: &Spec, trace: &[Step]) -> (Vec<CycleObs>, Reached) {
    let mut m = Model::new(spec);
    let mut out = Vec::new();
    for step in trace {
        for &t in &step.triggers {
            m.trigger_from_handle(t);
        }
        out.push(m.cycle(&step.inputs));
    }
    (out, m.reached)
}

// ---------------------------------------------------------------------------------------
// rtseq
// ---------------------------------------------------------------------------------------

type Log = Rc<RefCell<Vec<Obs>>>;

/// The IO and the actions' state: the readings of the cycle, the log, the scripts.
struct Io {
    handle: Rc<SafetyHandle>,
    inputs: Vec<Val>,
    log: Log,
    action_script: Script,
    entry_script: Script,
}

fn to_io(v: Val) -> IoValue {
    match v {
        Val::B(b) => IoValue::Bool(b),
        Val::I(i) => IoValue::Int(i),
        Val::F(f) => IoValue::Float(f),
    }
}

fn from_io(v: IoValue) -> Val {
    match v {
        IoValue::Bool(b) => Val::B(b),
        IoValue::Int(i) => Val::I(i),
        IoValue::Float(f) => Val::F(f),
    }
}

impl SafetyIo for Io {
    fn read_input(&mut self, input: InputId) -> IoValue {
        self.log.borrow_mut().push(Obs::Read(input.index()));
        to_io(self.inputs[input.index()])
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        self.log
            .borrow_mut()
            .push(Obs::Write(output.index(), from_io(value)));
    }
}

fn trig(ctx: &mut SafetyContext<'_>, ev: Ev) {
    match ev {
        Ev::Pub(i) => ctx.trigger(PublicEvent::new(i)),
        Ev::Priv(i) => ctx.trigger(PrivateEvent::new(i)),
    }
}

fn act<const N: u8>(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    let s = ctx.stats();
    let (hl, hc) = (io.handle.level().id(), io.handle.cycles());
    let seen = Obs::Action(N, ctx.level().id(), s.activations, s.cycles, hl, hc);
    io.log.borrow_mut().push(seen);
    for &(l, m, r, ev) in &io.action_script {
        if l == N && s.cycles % m == r {
            trig(ctx, ev);
        }
    }
}

fn ent<const N: u8>(ctx: &mut SafetyContext<'_>, io: &mut Io) {
    let s = ctx.stats();
    let (hl, hc) = (io.handle.level().id(), io.handle.cycles());
    let seen = Obs::Entry(N, ctx.level().id(), s.activations, s.cycles, hl, hc);
    io.log.borrow_mut().push(seen);
    for &(l, m, r, ev) in &io.entry_script {
        if l == N && s.activations % m == r {
            trig(ctx, ev);
        }
    }
}

fn ext<const N: u8>(io: &mut Io) {
    let (hl, hc) = (io.handle.level().id(), io.handle.cycles());
    io.log.borrow_mut().push(Obs::Exit(N, hl, hc));
}

const ACTS: [LevelFn<Io>; 8] = [
    act::<0>, act::<1>, act::<2>, act::<3>, act::<4>, act::<5>, act::<6>, act::<7>,
];
const ENTS: [LevelFn<Io>; 8] = [
    ent::<0>, ent::<1>, ent::<2>, ent::<3>, ent::<4>, ent::<5>, ent::<6>, ent::<7>,
];
const EXTS: [ExitFn<Io>; 8] = [
    ext::<0>, ext::<1>, ext::<2>, ext::<3>, ext::<4>, ext::<5>, ext::<6>, ext::<7>,
];
const NAMES: [&str; 8] = ["l0", "l1", "l2", "l3", "l4", "l5", "l6", "l7"];

/// `Sequences` that logs every call.
struct Rec(Log);

impl Sequences for Rec {
    fn abort_all(&self) {
        self.0.borrow_mut().push(Obs::Abort);
    }
    fn level_entered(&self, level: SafetyLevel) {
        self.0.borrow_mut().push(Obs::LevelEntered(level.id()));
    }
    fn input_tripped(&self, input: InputId) {
        self.0.borrow_mut().push(Obs::Tripped(input.index()));
    }
}

fn input_action_ev<K: EventVisibility>(
    i: u8,
    kind: Kind,
    chk: &Chk,
    e: SafetyEvent<K>,
) -> InputAction {
    match (kind, *chk) {
        (Kind::B, Chk::Check(Val::B(v), _)) => CriticalInput::<bool>::new(i, "in").check(v, e),
        (Kind::I, Chk::Check(Val::I(v), _)) => CriticalInput::<i32>::new(i, "in").check(v, e),
        (Kind::F, Chk::Check(Val::F(v), _)) => CriticalInput::<f32>::new(i, "in").check(v, e),
        (Kind::I, Chk::Range(Val::I(a), Val::I(b), _)) => {
            CriticalInput::<i32>::new(i, "in").range(a, b, e)
        }
        (Kind::F, Chk::Range(Val::F(a), Val::F(b), _)) => {
            CriticalInput::<f32>::new(i, "in").range(a, b, e)
        }
        (Kind::I, Chk::OffRange(Val::I(a), Val::I(b), _)) => {
            CriticalInput::<i32>::new(i, "in").off_range(a, b, e)
        }
        (Kind::F, Chk::OffRange(Val::F(a), Val::F(b), _)) => {
            CriticalInput::<f32>::new(i, "in").off_range(a, b, e)
        }
        other => panic!("bad input action {other:?}"),
    }
}

fn input_action(i: usize, kind: Kind, chk: &Chk) -> InputAction {
    let i = i as u8;
    match chk_event(chk) {
        None => match kind {
            Kind::B => CriticalInput::<bool>::new(i, "in").ignore(),
            Kind::I => CriticalInput::<i32>::new(i, "in").ignore(),
            Kind::F => CriticalInput::<f32>::new(i, "in").ignore(),
        },
        Some(Ev::Pub(e)) => input_action_ev(i, kind, chk, PublicEvent::new(e)),
        Some(Ev::Priv(e)) => input_action_ev(i, kind, chk, PrivateEvent::new(e)),
    }
}

fn output_action(o: usize, kind: Kind, out: &Out) -> OutputAction {
    let o = o as u8;
    match (kind, *out) {
        (Kind::B, Out::Set(Val::B(v))) => CriticalOutput::<bool>::new(o, "out").set(v),
        (Kind::I, Out::Set(Val::I(v))) => CriticalOutput::<i32>::new(o, "out").set(v),
        (Kind::F, Out::Set(Val::F(v))) => CriticalOutput::<f32>::new(o, "out").set(v),
        (Kind::B, Out::Leave) => CriticalOutput::<bool>::new(o, "out").leave(),
        (Kind::I, Out::Leave) => CriticalOutput::<i32>::new(o, "out").leave(),
        (Kind::F, Out::Leave) => CriticalOutput::<f32>::new(o, "out").leave(),
        (Kind::B, Out::Toggle(Val::B(false), Val::B(true))) => {
            CriticalOutput::<bool>::new(o, "out").toggle()
        }
        (Kind::I, Out::Toggle(Val::I(a), Val::I(b))) => {
            CriticalOutput::<i32>::new(o, "out").toggle(a, b)
        }
        (Kind::F, Out::Toggle(Val::F(a), Val::F(b))) => {
            CriticalOutput::<f32>::new(o, "out").toggle(a, b)
        }
        other => panic!("bad output action {other:?}"),
    }
}

fn row(r: &Row) -> LevelTransition {
    fn mk<K: EventVisibility>(r: &Row, e: SafetyEvent<K>) -> LevelTransition {
        let (lo, hi) = (SafetyLevel::new(r.low), SafetyLevel::new(r.high));
        let to = SafetyLevel::new(r.to);
        match r.form {
            0 => LevelTransition::on(lo, e, to),
            1 => LevelTransition::on_levels_between(lo, hi, e, to),
            2 => LevelTransition::on_level_and_above(lo, e, to),
            _ => LevelTransition::on_level_and_below(hi, e, to),
        }
    }
    match r.ev {
        Ev::Pub(i) => mk(r, PublicEvent::new(i)),
        Ev::Priv(i) => mk(r, PrivateEvent::new(i)),
    }
}

fn run_rtseq<const L: usize>(spec: &Spec, trace: &[Step]) -> Vec<CycleObs> {
    let in_actions: Vec<Vec<InputAction>> = spec
        .levels
        .iter()
        .map(|l| {
            l.inputs
                .iter()
                .map(|(i, c)| input_action(*i, spec.in_kinds[*i], c))
                .collect()
        })
        .collect();
    let out_actions: Vec<Vec<OutputAction>> = spec
        .levels
        .iter()
        .map(|l| {
            l.outputs
                .iter()
                .map(|(o, a)| output_action(*o, spec.out_kinds[*o], a))
                .collect()
        })
        .collect();
    let in_infos: Vec<CriticalInputInfo> = (spec.in_kinds.iter().enumerate())
        .map(|(i, k)| match k {
            Kind::B => CriticalInput::<bool>::new(i as u8, "in").info(),
            Kind::I => CriticalInput::<i32>::new(i as u8, "in").info(),
            Kind::F => CriticalInput::<f32>::new(i as u8, "in").info(),
        })
        .collect();
    let out_infos: Vec<CriticalOutputInfo> = (spec.out_kinds.iter().enumerate())
        .map(|(i, k)| match k {
            Kind::B => CriticalOutput::<bool>::new(i as u8, "out").info(),
            Kind::I => CriticalOutput::<i32>::new(i as u8, "out").info(),
            Kind::F => CriticalOutput::<f32>::new(i as u8, "out").info(),
        })
        .collect();
    let rows: Vec<LevelTransition> = spec.rows.iter().map(row).collect();
    let levels: [LevelDef<'_, Io>; L] = core::array::from_fn(|i| {
        let ls = &spec.levels[i];
        let abort = match ls.abort {
            Ab::Never => AbortPolicy::Never,
            Ab::OnEntry => AbortPolicy::OnEntry,
            Ab::WhileActive => AbortPolicy::WhileActive,
        };
        let mut d = LevelDef::new(SafetyLevel::new(i as u8), NAMES[i])
            .inputs(&in_actions[i])
            .outputs(&out_actions[i])
            .abort_sequences(abort);
        if ls.action {
            d = d.level_action(ACTS[i]);
        }
        if ls.entry {
            d = d.on_entry(ENTS[i]);
        }
        if ls.exit {
            d = d.on_exit(EXTS[i]);
        }
        d
    });
    let entry = SafetyLevel::new(spec.entry);
    let props = SafetyProperties::new(levels, &in_infos, &out_infos, &rows, entry);
    let handle = Rc::new(SafetyHandle::new());
    let mut sys = match SafetySystem::new(&props, &handle) {
        Ok(sys) => sys,
        Err(e) => panic!("invalid properties: {e:?}\n{spec:#?}"),
    };
    let log: Log = Rc::new(RefCell::new(Vec::new()));
    let rec = Rec(log.clone());
    let mut io = Io {
        handle: handle.clone(),
        inputs: Vec::new(),
        log: log.clone(),
        action_script: spec.action_script.clone(),
        entry_script: spec.entry_script.clone(),
    };
    let ev = |e: EventId| match e.kind() {
        EventKind::Public => Ev::Pub(e.index()),
        EventKind::Private => Ev::Priv(e.index()),
    };
    let mut out = Vec::new();
    for step in trace {
        for &t in &step.triggers {
            handle.trigger(PublicEvent::new(t));
        }
        io.inputs.clone_from(&step.inputs);
        log.borrow_mut().clear();
        let r = sys.cycle(&mut io, &rec);
        out.push(CycleObs {
            log: log.borrow().clone(),
            level: r.level.id(),
            change: r.change.map(|c| (c.from.map(|f| f.id()), c.to.id())),
            input_events: r.input_events,
            aborted: r.aborted,
            unknown: r.unknown_events,
            sys_level: sys.level().id(),
            handle_level: handle.level().id(),
            handle_cycles: handle.cycles(),
            handle_pending: handle.pending_events(),
            stats: (0..L as u8)
                .map(|l| {
                    let s = sys.stats(SafetyLevel::new(l)).unwrap();
                    (s.activations, s.cycles)
                })
                .collect(),
            unknown_total: sys.unknown_events(),
            last_unknown: sys
                .last_unknown_event()
                .map(|u| (ev(u.event), u.level.id())),
        });
    }
    out
}

fn run_rtseq_any(spec: &Spec, trace: &[Step]) -> Vec<CycleObs> {
    match spec.levels.len() {
        2 => run_rtseq::<2>(spec, trace),
        3 => run_rtseq::<3>(spec, trace),
        4 => run_rtseq::<4>(spec, trace),
        5 => run_rtseq::<5>(spec, trace),
        6 => run_rtseq::<6>(spec, trace),
        7 => run_rtseq::<7>(spec, trace),
        8 => run_rtseq::<8>(spec, trace),
        n => panic!("{n} levels"),
    }
}

/// rtseq's observations, or the first cycle in which they differ from the model's, printed
/// with the spec.
fn compare(spec: &Spec, trace: &[Step]) -> Result<Vec<CycleObs>, String> {
    let (want, _) = run_model(spec, trace);
    let got = run_rtseq_any(spec, trace);
    for (c, (w, g)) in want.iter().zip(&got).enumerate() {
        if w != g {
            return Err(format!(
                "cycle {} (from 1)\n step {:?}\n model {w:?}\n rtseq {g:?}\n{spec:#?}",
                c + 1,
                trace[c]
            ));
        }
    }
    assert_eq!(want.len(), got.len());
    Ok(got)
}

// ---------------------------------------------------------------------------------------
// The generator
// ---------------------------------------------------------------------------------------

/// xorshift64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn chance(&mut self, pct: u64) -> bool {
        self.below(100) < pct
    }
    fn pick<T: Copy>(&mut self, v: &[T]) -> T {
        v[self.below(v.len() as u64) as usize]
    }
}

const INTS: [i32; 9] = [i32::MIN, -5, -1, 0, 1, 2, 5, 100, i32::MAX];
const FLOATS: [f32; 10] = [
    f32::NEG_INFINITY,
    -2.5,
    -1.0,
    -0.0,
    0.0,
    0.5,
    1.0,
    2.5,
    1e30,
    f32::INFINITY,
];

fn gen_val(rng: &mut Rng, k: Kind) -> Val {
    match k {
        Kind::B => Val::B(rng.chance(50)),
        Kind::I => Val::I(rng.pick(&INTS)),
        Kind::F => Val::F(rng.pick(&FLOATS)),
    }
}

fn gen_reading(rng: &mut Rng, k: Kind) -> Val {
    if rng.chance(4) {
        let other = match k {
            Kind::B => Kind::I,
            Kind::I => Kind::F,
            Kind::F => Kind::B,
        };
        return gen_val(rng, other);
    }
    if k == Kind::F && rng.chance(5) {
        return Val::F(f32::NAN);
    }
    if k == Kind::I && rng.chance(30) {
        return Val::I(rng.below(9) as i32 - 3);
    }
    gen_val(rng, k)
}

fn gen_check(rng: &mut Rng, k: Kind, ev: Ev) -> Chk {
    match (k, rng.below(3)) {
        // (A NaN expected value is refused by validation: `check` never gets one.)
        (Kind::B, _) | (_, 0) => Chk::Check(gen_val(rng, k), ev),
        (_, m) => {
            let (mut a, mut b) = (gen_val(rng, k), gen_val(rng, k));
            let swap = match (a, b) {
                (Val::I(x), Val::I(y)) => x > y,
                (Val::F(x), Val::F(y)) => x > y,
                _ => false,
            };
            if swap {
                std::mem::swap(&mut a, &mut b);
            }
            // An `off_range` band with no value inside is refused by validation.
            let has_inside = match (a, b) {
                (Val::I(x), Val::I(y)) => i64::from(y) - i64::from(x) >= 2,
                (Val::F(x), Val::F(y)) => x < y,
                _ => false,
            };
            if m == 1 || !has_inside {
                Chk::Range(a, b, ev)
            } else {
                Chk::OffRange(a, b, ev)
            }
        }
    }
}

fn shuffle<T>(rng: &mut Rng, v: &mut [T]) {
    for j in (1..v.len()).rev() {
        v.swap(j, rng.below(j as u64 + 1) as usize);
    }
}

fn gen_spec(rng: &mut Rng) -> Spec {
    let n = 2 + rng.below(7) as usize;
    let mut evs: Vec<Ev> = (0..1 + rng.below(4) as u8).map(Ev::Pub).collect();
    evs.extend((0..1 + rng.below(3) as u8).map(Ev::Priv));
    if rng.chance(30) {
        evs.push(Ev::Pub(31));
    }
    if rng.chance(20) {
        evs.push(Ev::Priv(31));
    }
    // Now and then 28 to 32 inputs / outputs (bit 31 of the masks).
    let n_in = if rng.chance(5) {
        28 + rng.below(5)
    } else {
        rng.below(5)
    };
    let n_out = if rng.chance(5) {
        28 + rng.below(5)
    } else {
        rng.below(5)
    };
    let kinds = [Kind::B, Kind::I, Kind::F];
    let in_kinds: Vec<Kind> = (0..n_in).map(|_| rng.pick(&kinds)).collect();
    let out_kinds: Vec<Kind> = (0..n_out).map(|_| rng.pick(&kinds)).collect();
    let covers = |rows: &[Row], ev: Ev, low: u8, high: u8| {
        (rows.iter()).any(|o| o.ev == ev && o.low.max(low) <= o.high.min(high))
    };
    let mut rows: Vec<Row> = Vec::new();
    for _ in 0..(2 + rng.below(2 * n as u64 + 4)) {
        let form = rng.below(4) as u8;
        let a = rng.below(n as u64) as u8;
        let (low, high) = match form {
            0 => (a, a),
            // A range ends at a defined level (validation refuses one past them).
            1 => (a, (a + rng.below(4) as u8).min(n as u8 - 1)),
            2 => (a, u8::MAX),
            _ => (0, a),
        };
        let ev = rng.pick(&evs);
        let to = rng.below(n as u64) as u8;
        if !covers(&rows, ev, low, high) {
            rows.push(Row {
                low,
                high,
                ev,
                to,
                form,
            });
        }
    }
    let mut levels = Vec::new();
    for l in 0..n as u8 {
        let mut inputs = Vec::new();
        for (i, &k) in in_kinds.iter().enumerate() {
            let ev = rng.pick(&evs);
            let chk = if rng.chance(25) {
                Chk::Ignore
            } else {
                gen_check(rng, k, ev)
            };
            // Every event an input action can trigger has a row from its level
            // (`InputEventWithoutTransition`).
            if chk_event(&chk).is_some() && !covers(&rows, ev, l, l) {
                let to = rng.below(n as u64) as u8;
                rows.push(Row {
                    low: l,
                    high: l,
                    ev,
                    to,
                    form: 0,
                });
            }
            inputs.push((i, chk));
        }
        shuffle(rng, &mut inputs);
        let mut outputs = Vec::new();
        for (o, &k) in out_kinds.iter().enumerate() {
            let out = match rng.below(10) {
                0..=4 => Out::Set(gen_val(rng, k)),
                5 | 6 => Out::Leave,
                _ => match k {
                    Kind::B => Out::Toggle(Val::B(false), Val::B(true)),
                    _ => Out::Toggle(gen_val(rng, k), gen_val(rng, k)),
                },
            };
            outputs.push((o, out));
        }
        shuffle(rng, &mut outputs);
        levels.push(LevelSpec {
            inputs,
            outputs,
            action: rng.chance(60),
            entry: rng.chance(50),
            exit: rng.chance(50),
            abort: rng.pick(&[Ab::Never, Ab::Never, Ab::OnEntry, Ab::WhileActive]),
        });
    }
    let some_ev = |rng: &mut Rng| {
        if rng.chance(8) {
            if rng.chance(50) {
                Ev::Pub(32 + rng.below(5) as u8)
            } else {
                Ev::Priv(32 + rng.below(5) as u8)
            }
        } else if rng.chance(10) {
            // In range; no row has it.
            rng.pick(&[Ev::Pub(20), Ev::Priv(20)])
        } else {
            rng.pick(&evs)
        }
    };
    let mut action_script = Vec::new();
    let mut entry_script = Vec::new();
    for l in 0..n as u8 {
        for _ in 0..rng.below(3) {
            let m = 1 + rng.below(6) as u32;
            let r = rng.below(u64::from(m)) as u32;
            let ev = some_ev(rng);
            action_script.push((l, m, r, ev));
            if rng.chance(15) {
                // The same event twice in one action.
                action_script.push((l, m, r, ev));
            }
        }
        for _ in 0..rng.below(2) {
            let m = 1 + rng.below(3) as u32;
            let r = rng.below(u64::from(m)) as u32;
            entry_script.push((l, m, r, some_ev(rng)));
        }
    }
    let entry = rng.below(n as u64) as u8;
    Spec {
        levels,
        in_kinds,
        out_kinds,
        rows,
        entry,
        action_script,
        entry_script,
    }
}

fn gen_trace(rng: &mut Rng, spec: &Spec) -> Vec<Step> {
    // Triggers from the handle: the public ids of the rows, one more, and now and then an
    // out-of-range one.
    let max_pub = (spec.rows.iter())
        .filter_map(|r| match r.ev {
            Ev::Pub(i) => Some(i),
            Ev::Priv(_) => None,
        })
        .max()
        .unwrap_or(0)
        .min(31);
    let mut cur: Vec<Val> = (spec.in_kinds.iter())
        .map(|&k| gen_reading(rng, k))
        .collect();
    (0..(10 + rng.below(50)))
        .map(|_| {
            for (i, &k) in spec.in_kinds.iter().enumerate() {
                if rng.chance(30) {
                    cur[i] = gen_reading(rng, k);
                }
            }
            let mut triggers = Vec::new();
            for _ in 0..rng.below(4) {
                if rng.chance(70) {
                    continue;
                }
                let id = if rng.chance(7) {
                    32 + rng.below(4) as u8
                } else {
                    rng.below(u64::from(max_pub) + 1) as u8
                };
                triggers.push(id);
                if rng.chance(20) {
                    triggers.push(id);
                }
            }
            Step {
                triggers,
                inputs: cur.clone(),
            }
        })
        .collect()
}

fn generate(seed: u64) -> (Spec, Vec<Step>) {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let spec = gen_spec(&mut rng);
    let trace = gen_trace(&mut rng, &spec);
    (spec, trace)
}

// ---------------------------------------------------------------------------------------
// The sweep
// ---------------------------------------------------------------------------------------

const SEEDS: u64 = 3000;

fn env(name: &str) -> Option<u64> {
    let v = std::env::var(name).ok()?;
    Some(
        v.parse()
            .unwrap_or_else(|_| panic!("{name}={v}: not a number")),
    )
}

/// The seeds to compare: `MODEL_SEED` alone, or `MODEL_N` (3000) from `MODEL_FROM` (1).
fn seeds() -> std::ops::Range<u64> {
    if let Some(s) = env("MODEL_SEED") {
        return s..s + 1;
    }
    let from = env("MODEL_FROM").unwrap_or(1);
    from..from + env("MODEL_N").unwrap_or(SEEDS)
}

/// The model and rtseq see the same in every cycle of every seed (`MODEL_N`, `MODEL_FROM`,
/// `MODEL_SEED`): the first difference is printed in full, the others by seed.
#[test]
fn the_model_matches_rtseq() {
    let range = seeds();
    let mut fails = vec![];
    let mut first = String::new();
    for seed in range.clone() {
        let (spec, trace) = generate(seed);
        if let Err(e) = compare(&spec, &trace) {
            if fails.is_empty() {
                first = e;
            }
            fails.push(seed);
        }
    }
    assert!(
        fails.is_empty(),
        "{} of the seeds {range:?} differ: {:?}\nseed {} (MODEL_SEED={} cargo test --test \
         safety_model the_model_matches_rtseq):\n{first}",
        fails.len(),
        &fails[..fails.len().min(40)],
        fails[0],
        fails[0],
    );
}

/// Every situation `Reached` counts occurs in the sweep's seeds (in the model's runs, which
/// the sweep compares with rtseq).
#[test]
fn the_sweep_reaches_every_rule_the_model_covers() {
    let mut reached = Reached::default();
    for seed in 1..1 + SEEDS {
        let (spec, trace) = generate(seed);
        reached.add(&run_model(&spec, &trace).1);
    }
    let counts = reached.counts();
    let missing: Vec<_> = counts.iter().filter(|c| c.1 == 0).collect();
    assert!(missing.is_empty(), "not reached: {missing:?}\n{counts:?}");
}

// ---------------------------------------------------------------------------------------
// Out-of-range events
// ---------------------------------------------------------------------------------------

/// An IO for systems without inputs or outputs.
struct NoIo;

impl SafetyIo for NoIo {
    fn read_input(&mut self, _: InputId) -> IoValue {
        IoValue::Bool(false)
    }
    fn write_output(&mut self, _: OutputId, _: IoValue) {}
}

const OFF: SafetyLevel = SafetyLevel::new(0);

/// semantics.md, "Unknown events": "An id ≥ 32 has no bit to keep: each trigger of it
/// counts"; `SafetyHandle`: "Triggering the same event several times before the next cycle
/// counts once (an id ≥ 32, which has no bit, is an unknown event at each trigger)". An id
/// below 32 without a row, triggered 3 times, counts once; id 40, 3 times, counts 3.
#[test]
fn an_out_of_range_event_triggered_three_times_from_the_handle_counts_three() {
    static PROPS: SafetyProperties<'static, NoIo, 1> =
        SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    let handle = SafetyHandle::new();
    let mut safety = SafetySystem::new(&PROPS, &handle).unwrap();
    safety.cycle(&mut NoIo, &NoSequences);
    for _ in 0..3 {
        handle.trigger(PublicEvent::new(9));
    }
    assert_eq!(safety.cycle(&mut NoIo, &NoSequences).unknown_events, 1);
    for _ in 0..3 {
        handle.trigger(PublicEvent::new(40));
    }
    assert_eq!(handle.pending_events(), 0);
    assert_eq!(safety.cycle(&mut NoIo, &NoSequences).unknown_events, 3);
    assert_eq!(safety.cycle(&mut NoIo, &NoSequences).unknown_events, 0);
    assert_eq!(safety.unknown_events(), 4);
    let last = UnknownEvent {
        event: EventId::public(40),
        level: OFF,
    };
    assert_eq!(safety.last_unknown_event(), Some(last));
}

/// semantics.md, "Unknown events": "An id ≥ 32 has no bit to keep: each trigger of it
/// counts", also from inside: a level action that triggers private event 40 twice in cycle
/// 1 has 2 unknown events in cycle 2, and none kept for cycle 3.
#[test]
fn an_out_of_range_event_triggered_twice_by_a_level_action_counts_two() {
    fn twice(ctx: &mut SafetyContext<'_>, _: &mut NoIo) {
        if ctx.stats().cycles == 1 {
            ctx.trigger(PrivateEvent::new(40));
            ctx.trigger(PrivateEvent::new(40));
        }
    }
    static PROPS: SafetyProperties<'static, NoIo, 1> = SafetyProperties::new(
        [LevelDef::new(OFF, "off").level_action(twice)],
        &[],
        &[],
        &[],
        OFF,
    );
    let handle = SafetyHandle::new();
    let mut safety = SafetySystem::new(&PROPS, &handle).unwrap();
    let counts: Vec<u32> = (0..3)
        .map(|_| safety.cycle(&mut NoIo, &NoSequences).unknown_events)
        .collect();
    assert_eq!(counts, [0, 2, 0]);
    let last = UnknownEvent {
        event: EventId::private(40),
        level: OFF,
    };
    assert_eq!(safety.last_unknown_event(), Some(last));
}

/// semantics.md, "Unknown events": each trigger of an id ≥ 32 counts, "the handle's before
/// those of the system's own actions (so the last one named is the system's when both
/// come)"; `SafetySystem::last_unknown_event`: "public ones by ascending id, then private
/// ones by ascending id, then out-of-range ones". The level action triggers private 33 in
/// cycle 1, the handle then public 40 twice and public 9 (no row): cycle 2 counts 4 and names
/// private 33, triggered first but the system's; with the handle's alone, public 40.
#[test]
fn the_last_unknown_event_named_is_the_systems_when_both_come() {
    fn once(ctx: &mut SafetyContext<'_>, _: &mut NoIo) {
        if ctx.stats().cycles == 1 {
            ctx.trigger(PrivateEvent::new(33));
        }
    }
    static PROPS: SafetyProperties<'static, NoIo, 1> = SafetyProperties::new(
        [LevelDef::new(OFF, "off").level_action(once)],
        &[],
        &[],
        &[],
        OFF,
    );
    let handle = SafetyHandle::new();
    let mut safety = SafetySystem::new(&PROPS, &handle).unwrap();
    safety.cycle(&mut NoIo, &NoSequences);
    handle.trigger(PublicEvent::new(40));
    handle.trigger(PublicEvent::new(40));
    handle.trigger(PublicEvent::new(9));
    assert_eq!(safety.cycle(&mut NoIo, &NoSequences).unknown_events, 4);
    let named = |event| Some(UnknownEvent { event, level: OFF });
    assert_eq!(safety.last_unknown_event(), named(EventId::private(33)));
    handle.trigger(PublicEvent::new(40));
    handle.trigger(PublicEvent::new(9));
    assert_eq!(safety.cycle(&mut NoIo, &NoSequences).unknown_events, 2);
    assert_eq!(safety.last_unknown_event(), named(EventId::public(40)));
}
