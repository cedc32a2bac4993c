//! The host simulator (feature `std`): lanes and ticks in simulated time, deterministic,
//! with the full transition trace.
//!
//! It is the same code that runs on the chip: the simulator only replaces the RTIC
//! executor (it polls woken lanes in declaration order) and the timer interrupt (it calls
//! [`Sequencer::tick`] every `period` of simulated time).

extern crate std;

use std::boxed::Box;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Context, Wake, Waker};
use std::vec::Vec;

use core::convert::Infallible;
use core::future::Future;

use crate::{
    lane, Duration, Error, Handle, Instant, Monitors, RunningState, Seq, SeqId, Sequence,
    Sequencer, Transition,
};

/// Upper bound of lane polls in one settle, to turn a livelock into a visible stop.
const MAX_POLLS_PER_SETTLE: usize = 100_000;

struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
}

struct SimLane<'a> {
    future: Pin<Box<dyn Future<Output = Infallible> + 'a>>,
    flag: Arc<Flag>,
    waker: Waker,
    polls: usize,
}

type BeforeTick<'a, C> = Box<dyn FnMut(Instant, &C) + 'a>;

/// A deterministic simulation of an rtseq application on the host.
///
/// ```
/// use rtseq::sim::Sim;
/// use rtseq::{Cause, Cx, Duration, Monitors, Outcome, RunningState::*, SeqConfig, Sequence,
///             Sequencer, Transition, Wait};
/// struct Main { dwell: rtseq::Seq<Wait> }
/// impl Sequence<()> for Main {
///     async fn action(&mut self, cx: &Cx<'_, ()>) {
///         let _ = cx.step(&mut self.dwell).await;
///     }
/// }
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(3))).unwrap();
/// let (w, main) = (dwell.id(), seq.add(SeqConfig::new("main"), Main { dwell }).unwrap());
/// let m = main.id();
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// sim.lane(main);
/// sim.start(m).unwrap();
/// sim.run_for(Duration::from_millis(5));
/// assert_eq!(sim.trace(), &[
///     Transition::at_millis(0, m, Idle, Running, Cause::Start),
///     Transition::at_millis(0, w, Idle, Running, Cause::Start),
///     Transition::at_millis(3, w, Running, Terminated, Cause::Completed),
///     Transition::at_millis(3, m, Running, Terminated, Cause::Completed),
/// ]);
/// ```
pub struct Sim<
    'a,
    C,
    const N: usize,
    const T: usize,
    const M: usize,
    K = crate::DynCondition<'a, C>,
    const W: usize = 8,
> {
    sequencer: &'a Sequencer<C, N, T, crate::lock::CriticalSection, W>,
    control: &'a C,
    monitors: Monitors<'a, C, M, K>,
    lanes: Vec<SimLane<'a>>,
    period: Duration,
    now: Instant,
    trace: Vec<Transition>,
    lost: u32,
    stalled: bool,
    before_tick: Option<BeforeTick<'a, C>>,
}

impl<
        'a,
        C,
        const N: usize,
        const T: usize,
        const M: usize,
        K: crate::Condition<C>,
        const W: usize,
    > Sim<'a, C, N, T, M, K, W>
{
    /// A simulation at time 0 with a 1 ms (1 kHz) tick.
    pub fn new(
        sequencer: &'a Sequencer<C, N, T, crate::lock::CriticalSection, W>,
        control: &'a C,
        monitors: Monitors<'a, C, M, K>,
    ) -> Self {
        Sim {
            sequencer,
            control,
            monitors,
            lanes: Vec::new(),
            period: Duration::from_millis(1),
            now: Instant::from_ticks(0),
            trace: Vec::new(),
            lost: 0,
            stalled: false,
            before_tick: None,
        }
    }

    /// Changes the tick period.
    pub fn with_period(mut self, period: Duration) -> Self {
        self.period = period;
        self
    }

    /// Starts the simulated clock at `t` instead of 0 (e.g. to run across the wrap of the
    /// control blocks' 32-bit microsecond times at 2^32 µs ≈ 71.6 min).
    pub fn starting_at(mut self, t: Instant) -> Self {
        self.now = t;
        self.sequencer.with(|s| s.now = t);
        self
    }

    /// Called before every tick with the new time: step the plant, inject faults.
    pub fn before_tick(&mut self, f: impl FnMut(Instant, &C) + 'a) {
        self.before_tick = Some(Box::new(f));
    }

    /// Adds a lane running `seq` whenever it is started non-blocking. Lanes are polled in
    /// the order they were added.
    pub fn lane<S: Sequence<C> + 'a>(&mut self, seq: Seq<S>)
    where
        C: 'a,
    {
        let sequencer = self.sequencer;
        let control = self.control;
        let future = Box::pin(async move {
            let mut seq = seq;
            lane(sequencer, control, &mut seq).await
        });
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        let waker = Waker::from(flag.clone());
        self.lanes.push(SimLane {
            future,
            flag,
            waker,
            polls: 0,
        });
        self.settle();
    }

    /// A handle to a registered sequence.
    pub fn handle(&self, id: SeqId) -> Option<Handle<'a, C>> {
        self.sequencer.sequence_by_id(id)
    }

    /// Starts `id` non-blocking as a main sequence and lets the lanes run at the current time.
    pub fn start(&mut self, id: SeqId) -> Result<(), Error> {
        self.sequencer
            .sequence_by_id(id)
            .ok_or(Error::UnknownSequence(id))?
            .start()?;
        self.settle();
        Ok(())
    }

    /// Requests a pause of `id` (applied by the next tick).
    pub fn pause(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.pause()
    }

    /// Requests a resume of `id` (applied by the next tick).
    pub fn resume(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.resume()
    }

    /// Requests an abort of `id` (applied by the next tick).
    pub fn abort(&mut self, id: SeqId) -> Result<(), Error> {
        self.handle(id).ok_or(Error::UnknownSequence(id))?.abort()
    }

    /// Requests abort-all (applied by the next tick).
    pub fn abort_all(&mut self) {
        self.sequencer.abort_all();
    }

    /// One tick: advance time, run the before-tick hook, tick, let the woken lanes run.
    pub fn step(&mut self) {
        self.now = self.later(self.now, self.period);
        if let Some(f) = self.before_tick.as_mut() {
            f(self.now, self.control);
        }
        self.sequencer
            .tick(self.now, self.control, &mut self.monitors);
        self.settle();
    }

    /// Runs ticks for `d` of simulated time.
    pub fn run_for(&mut self, d: Duration) {
        let end = self.later(self.now, d);
        self.run_until(end);
    }

    /// Runs ticks until the time reaches `t`.
    pub fn run_until(&mut self, t: Instant) {
        while self.later(self.now, self.period) <= t && self.now < t {
            self.step();
        }
    }

    /// Runs ticks until no sequence is active any more or `limit` has passed; returns the
    /// time at which everything was idle.
    pub fn run_until_idle(&mut self, limit: Duration) -> Option<Instant> {
        let end = self.later(self.now, limit);
        loop {
            if !self.any_active() {
                return Some(self.now);
            }
            if self.later(self.now, self.period) > end || self.now >= end {
                return None;
            }
            self.step();
        }
    }

    /// True while any registered sequence is running, paused, aborting or restarting.
    pub fn any_active(&self) -> bool {
        (0..self.sequencer.len())
            .filter_map(|i| u8::try_from(i).ok())
            .filter_map(|i| self.sequencer.sequence_by_id(SeqId(i)))
            .any(|h| h.state().is_active())
    }

    /// The state of `id`.
    pub fn state(&self, id: SeqId) -> RunningState {
        self.handle(id).map_or(RunningState::Idle, |h| h.state())
    }

    /// Simulated time now.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Every transition so far, in order.
    pub fn trace(&self) -> &[Transition] {
        &self.trace
    }

    /// Takes the transitions recorded so far, leaving the trace empty.
    pub fn take_trace(&mut self) -> Vec<Transition> {
        core::mem::take(&mut self.trace)
    }

    /// Transitions lost to overflow of the sequencer's trace buffer (0 unless `T` is tiny).
    pub fn lost(&self) -> u32 {
        self.lost
    }

    /// True if a settle hit its poll bound (a lane that wakes itself forever).
    pub fn stalled(&self) -> bool {
        self.stalled
    }

    /// How often each lane was polled, in the order the lanes were added: the tick wakes only
    /// lanes that must act, so an idle or frozen lane is not polled at all.
    pub fn lane_polls(&self) -> Vec<usize> {
        self.lanes.iter().map(|l| l.polls).collect()
    }

    /// The monitor table (e.g. to read how often a monitor fired).
    pub fn monitors(&self) -> &Monitors<'a, C, M, K> {
        &self.monitors
    }

    /// The control system.
    pub fn control(&self) -> &'a C {
        self.control
    }

    /// `t + d`, saturating at the end of time.
    fn later(&self, t: Instant, d: Duration) -> Instant {
        t.checked_add_duration(d)
            .unwrap_or(Instant::from_ticks(u64::MAX))
    }

    /// Moves the sequencer's buffered transitions into the trace.
    fn drain(&mut self) {
        let trace = &mut self.trace;
        let lost = self.sequencer.drain_trace(|t| trace.push(t));
        self.lost = self.lost.saturating_add(lost);
    }

    /// Polls woken lanes, in declaration order, until none is woken.
    fn settle(&mut self) {
        let mut polls: usize = 0;
        loop {
            let mut any = false;
            for lane in self.lanes.iter_mut() {
                if lane.flag.0.swap(false, Ordering::SeqCst) {
                    any = true;
                    polls = polls.saturating_add(1);
                    lane.polls = lane.polls.saturating_add(1);
                    let mut cx = Context::from_waker(&lane.waker);
                    let _ = lane.future.as_mut().poll(&mut cx);
                    let trace = &mut self.trace;
                    let lost = self.sequencer.drain_trace(|t| trace.push(t));
                    self.lost = self.lost.saturating_add(lost);
                }
            }
            self.drain();
            if !any {
                return;
            }
            if polls > MAX_POLLS_PER_SETTLE {
                self.stalled = true;
                return;
            }
        }
    }
}

/// Saving the trace in the `rtseq-trace` tool's format (JSON lines, `docs/trace-format.md`).
impl<
        'a,
        C,
        const N: usize,
        const T: usize,
        const M: usize,
        K: crate::Condition<C>,
        const W: usize,
    > Sim<'a, C, N, T, M, K, W>
{
    /// Writes the trace to `path` in the format of the `rtseq-trace` tool
    /// (`docs/trace-format.md`): a header with the sequences (id, name, caller of the last
    /// run) and the monitors (id, name, owner), then one line per transition. A failing
    /// test can leave a run to look at: `rtseq-trace render run.jsonl --html run.html`.
    ///
    /// ```
    /// use rtseq::sim::Sim;
    /// use rtseq::{Cx, Duration, Monitors, SeqConfig, Sequence, Sequencer, Wait};
    /// struct Main { dwell: rtseq::Seq<Wait> }
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) {
    ///         let _ = cx.step(&mut self.dwell).await;
    ///     }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(3))).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main { dwell }).unwrap();
    /// let m = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(m).unwrap();
    /// sim.run_for(Duration::from_millis(5));
    /// let path = std::env::temp_dir().join("rtseq-doc-trace.jsonl");
    /// sim.save_trace(&path).unwrap();
    /// let text = std::fs::read_to_string(&path).unwrap();
    /// assert!(text.starts_with(r#"{"format":"rtseq-trace","version":1,"#));
    /// // dwell (id 0) was started by main (id 1); main is a main sequence.
    /// assert!(text.contains(r#"{"id":0,"name":"dwell","caller":1}"#));
    /// assert!(text.contains(r#"{"t":3000,"seq":0,"from":"Running","to":"Terminated","cause":"completed"}"#));
    /// ```
    pub fn save_trace(&self, path: impl AsRef<std::path::Path>) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        let mut out = std::io::BufWriter::new(file);
        self.write_trace(&mut out)?;
        std::io::Write::flush(&mut out)
    }

    /// Writes the trace in the format of [`save_trace`](Self::save_trace) to `out`.
    pub fn write_trace(&self, out: &mut impl std::io::Write) -> std::io::Result<()> {
        use crate::{Cause, MonitorId};
        use std::string::String;
        fn quoted(s: &str) -> String {
            let mut q = String::from("\"");
            for c in s.chars() {
                match c {
                    '"' => q.push_str("\\\""),
                    '\\' => q.push_str("\\\\"),
                    c if u32::from(c) < 0x20 => {
                        q.push_str(&std::format!("\\u{:04x}", u32::from(c)))
                    }
                    c => q.push(c),
                }
            }
            q.push('"');
            q
        }
        let opt = |id: Option<usize>| id.map_or(String::from("null"), |i| std::format!("{i}"));
        let mut head = std::format!(
            "{{\"format\":\"rtseq-trace\",\"version\":1,\"time_unit\":\"us\",\"end\":{},\"lost\":{},\"sequences\":[",
            self.now.as_ticks(),
            self.lost
        );
        for i in 0..self.sequencer.len() {
            let id = SeqId::from_index(i);
            let (name, caller) = self
                .handle(id)
                .map_or(("", None), |h| (h.name(), h.caller().map(SeqId::index)));
            let sep = if i == 0 { "" } else { "," };
            head.push_str(&std::format!(
                "{sep}{{\"id\":{i},\"name\":{},\"caller\":{}}}",
                quoted(name),
                opt(caller)
            ));
        }
        head.push_str("],\"monitors\":[");
        for i in 0..self.monitors.len() {
            let m = MonitorId::from_index(i);
            let name = self.monitors.name(m).unwrap_or("");
            let owner = self.monitors.owner(m).map(SeqId::index);
            let sep = if i == 0 { "" } else { "," };
            head.push_str(&std::format!(
                "{sep}{{\"id\":{i},\"name\":{},\"owner\":{}}}",
                quoted(name),
                opt(owner)
            ));
        }
        head.push_str("]}");
        std::writeln!(out, "{head}")?;
        for t in &self.trace {
            let cause = match t.cause {
                Cause::Start => String::from("\"start\""),
                Cause::PreConditionFalse => String::from("\"pre_condition_false\""),
                Cause::Completed => String::from("\"completed\""),
                Cause::Pause => String::from("\"pause\""),
                Cause::Resume => String::from("\"resume\""),
                Cause::Abort => String::from("\"abort\""),
                Cause::AbortAll => String::from("\"abort_all\""),
                Cause::Monitor(m) => std::format!("\"monitor\",\"monitor\":{}", m.index()),
                Cause::Timeout(s) => std::format!("\"timeout\",\"of\":{}", s.index()),
                Cause::Restart => String::from("\"restart\""),
                Cause::Dropped => String::from("\"dropped\""),
            };
            std::writeln!(
                out,
                "{{\"t\":{},\"seq\":{},\"from\":\"{:?}\",\"to\":\"{:?}\",\"cause\":{cause}}}",
                t.time.as_ticks(),
                t.sequence.index(),
                t.from,
                t.to
            )?;
        }
        Ok(())
    }
}
