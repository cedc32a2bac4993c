//! The `Wait` step.

use crate::{Cx, Duration, Instant, Step};

/// A step that ends once `duration` has passed since its action (a dwell time).
///
/// Time is sequencer time; a pause does not extend the wait.
///
/// ```
/// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
/// let seq: Sequencer<(), 4> = Sequencer::new();
/// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(200))).unwrap();
/// assert_eq!(dwell.body().duration(), Duration::from_millis(200));
/// ```
pub struct Wait {
    duration: Duration,
    until: Instant,
}

impl Wait {
    /// A wait of `duration`.
    pub const fn new(duration: Duration) -> Self {
        Wait {
            duration,
            until: Instant::from_ticks(0),
        }
    }

    /// The configured duration.
    pub const fn duration(&self) -> Duration {
        self.duration
    }

    /// Changes the duration for the next run.
    pub fn set_duration(&mut self, duration: Duration) {
        self.duration = duration;
    }
}

impl<C> Step<C> for Wait {
    fn action(&mut self, cx: &Cx<'_, C>) {
        self.until = cx
            .now()
            .checked_add_duration(self.duration)
            .unwrap_or(Instant::from_ticks(u64::MAX));
    }

    fn check_exit_condition(&mut self, cx: &Cx<'_, C>) -> bool {
        cx.now() >= self.until
    }
}
