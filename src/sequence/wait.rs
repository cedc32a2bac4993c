//! The `Wait` step.

use crate::{Cx, Duration, Failure, Step};

/// A step that ends once `duration` has passed since its action (a dwell time).
///
/// Time is sequencer time, without the time the step was paused (its
/// [`run_time`](Cx::run_time)): paused at 0.3 s for 2 s, a 1 s wait ends at 3.0 s.
///
/// ```
/// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let dwell = Wait::new(Duration::from_millis(200));
/// let dwell = seq.add(SeqConfig::new("dwell"), dwell).unwrap();
/// assert_eq!(dwell.body().duration(), Duration::from_millis(200));
/// ```
pub struct Wait {
    duration: Duration,
    /// The run time (µs) at the action, from which the wait counts.
    since: u64,
}

impl Wait {
    /// A wait of `duration`.
    ///
    /// A 200 ms dwell, run by a sequence on the host simulator:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use rtseq::{sim::Sim, Cx, Duration, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer,
    ///             Wait};
    /// struct Main(Seq<Wait>);
    /// impl Sequence<()> for Main {
    ///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
    ///         let _ = cx.step(&mut self.0).await;
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let dwell = Wait::new(Duration::from_millis(200));
    /// let dwell = seq.add(SeqConfig::new("dwell"), dwell).unwrap();
    /// let main = seq.add(SeqConfig::new("main"), Main(dwell)).unwrap();
    /// let id = main.id();
    /// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
    /// sim.lane(main);
    /// sim.start(id).unwrap();
    /// let done = sim.run_until_idle(Duration::from_secs(1)).unwrap();
    /// assert_eq!(done.duration_since_epoch(), Duration::from_millis(200));
    /// # }
    /// ```
    pub const fn new(duration: Duration) -> Self {
        Wait { duration, since: 0 }
    }

    /// The configured duration.
    ///
    /// ```
    /// use rtseq::{Duration, Wait};
    /// const SETTLE: Wait = Wait::new(Duration::from_millis(50));
    /// assert_eq!(SETTLE.duration().as_millis(), 50);
    /// ```
    pub const fn duration(&self) -> Duration {
        self.duration
    }

    /// Changes the duration for the next run.
    ///
    /// ```
    /// use rtseq::{Duration, Wait};
    /// let mut dwell = Wait::new(Duration::from_millis(50));
    /// dwell.set_duration(Duration::from_secs(2));
    /// assert_eq!(dwell.duration(), Duration::from_millis(2_000));
    /// ```
    pub fn set_duration(&mut self, duration: Duration) {
        self.duration = duration;
    }
}

impl<C> Step<C> for Wait {
    fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure> {
        self.since = cx.run_time().as_ticks();
        Ok(())
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, C>) -> bool {
        cx.run_time().as_ticks().saturating_sub(self.since) >= self.duration.as_ticks()
    }
}
