//! Homing on the host simulator: move slowly to the negative end stop (with a timeout),
//! set zero, back off. Run with `cargo run --example homing --features std`.
//!
//! The plant is a 1-D axis whose position integrates the commanded velocity every tick; the
//! end stop closes at -50 mm. A second run has a broken end stop: the 5 s timeout fires, the
//! safe-stop exception sequence stops the axis, and homing ends `Aborted`.

use core::cell::Cell;

use rtseq::sim::Sim;
use rtseq::{
    Behaviour, Cx, Duration, Failure, Monitors, Outcome, Seq, SeqConfig, Sequence, Sequencer, Step,
    WithNames,
};

/// The application's control system: what sequences command and conditions read.
#[derive(Default)]
pub struct Axis {
    /// Measured position, mm.
    pub position: Cell<f32>,
    /// Commanded velocity, mm/s.
    pub velocity: Cell<f32>,
    /// Position of the encoder zero, mm.
    pub zero: Cell<f32>,
    /// The end stop is wired (false: broken cable).
    pub end_stop_works: Cell<bool>,
}

impl Axis {
    const END_STOP_MM: f32 = -50.0;

    fn end_stop(&self) -> bool {
        self.end_stop_works.get() && self.position.get() <= Self::END_STOP_MM
    }

    /// Integrates the velocity over one tick (the simulated plant).
    pub fn step(&self, dt_s: f32) {
        let p = self.position.get() + self.velocity.get() * dt_s;
        // The mechanical stop a few millimetres past the switch.
        self.position.set(p.max(Self::END_STOP_MM - 3.0));
    }

    /// Position relative to the homed zero.
    pub fn homed_position(&self) -> f32 {
        self.position.get() - self.zero.get()
    }
}

/// Drive towards the negative end stop until it closes.
pub struct SeekEndStop;
impl Step<Axis> for SeekEndStop {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().velocity.set(-20.0);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
        cx.control().end_stop()
    }
}

/// Stop and take the current position as zero.
pub struct SetZero;
impl Step<Axis> for SetZero {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        let axis = cx.control();
        axis.velocity.set(0.0);
        axis.zero.set(axis.position.get());
        Ok(())
    }
}

/// Move off the switch to +2 mm.
pub struct BackOff;
impl Step<Axis> for BackOff {
    fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().velocity.set(5.0);
        Ok(())
    }
    fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
        let axis = cx.control();
        let done = axis.homed_position() >= 2.0;
        if done {
            axis.velocity.set(0.0);
        }
        done
    }
}

/// The homing sequence: seek, zero, back off.
pub struct Homing {
    seek: Seq<SeekEndStop>,
    zero: Seq<SetZero>,
    back_off: Seq<BackOff>,
}

impl Sequence<Axis> for Homing {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        // `?`: a step aborted (by a monitor of its own, say) or failed ends homing with
        // the same failure, so homing never reads as completed without its zero.
        cx.step(&mut self.seek).await?;
        cx.step(&mut self.zero).await?;
        cx.step(&mut self.back_off).await?;
        Ok(())
    }
}

/// The timeout's exception sequence: stop the axis.
pub struct SafeStop;
impl Sequence<Axis> for SafeStop {
    async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
        cx.control().velocity.set(0.0);
        Ok(())
    }
}

/// What one homing run did.
pub struct Homed {
    /// How homing ended (`None`: it never ran).
    pub outcome: Option<Outcome>,
    /// When the last sequence came to rest, in ms.
    pub end_ms: u64,
    /// The run's records, transitions and events, printed with the sequences' names.
    pub lines: Vec<String>,
    /// The outcome with names, for a person to read.
    pub summary: String,
}

/// Runs homing once.
pub fn run(end_stop_works: bool) -> Homed {
    let seq: Sequencer<Axis, 8> = Sequencer::new();
    let axis = Axis::default();
    axis.end_stop_works.set(end_stop_works);
    let add = |name| SeqConfig::new(name).polling(Duration::from_millis(10));
    let safe_stop = seq.add(add("safe stop"), SafeStop).unwrap();
    let homing = Homing {
        seek: seq.add(add("seek end stop"), SeekEndStop).unwrap(),
        zero: seq.add(add("set zero"), SetZero).unwrap(),
        back_off: seq.add(add("back off"), BackOff).unwrap(),
    };
    let homing = seq
        .add(
            add("homing")
                .timeout(Duration::from_secs(5))
                .timeout_exception(safe_stop.id())
                .timeout_behaviour(Behaviour::AbortOwner),
            homing,
        )
        .unwrap();
    let id = homing.id();
    let mut sim = Sim::new(&seq, &axis, Monitors::<Axis, 1>::new());
    sim.lane(homing);
    sim.lane(safe_stop);
    sim.before_tick(|_, axis| axis.step(0.001));
    sim.start(id).unwrap();
    let end_ms = sim
        .run_until_idle(Duration::from_secs(10))
        .map_or(u64::MAX, |t| t.as_ticks() / 1000);
    let outcome = sim.handle(id).unwrap().last_outcome();
    let summary = match outcome {
        Some(o) => format!("homing {} at {end_ms} ms", o.named(&seq)),
        None => "homing never ran".to_string(),
    };
    Homed {
        outcome,
        end_ms,
        summary,
        lines: sim
            .records()
            .iter()
            .map(|r| r.named(&seq).to_string())
            .collect(),
    }
}

#[allow(dead_code)] // also compiled into the homing test, which has its own main
fn main() {
    for works in [true, false] {
        println!(
            "--- homing, end stop {} ---",
            if works { "wired" } else { "broken" }
        );
        let homed = run(works);
        for line in &homed.lines {
            println!("{line}");
        }
        println!("{}\n", homed.summary);
    }
}
