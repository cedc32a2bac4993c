//! Each sequence's run clock: the time its current run has run, not counting the time it
//! was paused. Its timeout and [`Cx::run_time`](crate::Cx::run_time) (and so `Wait`) count
//! it. A start or restart sets it to 0; a pause stops it, a resume lets it run on.
//!
//! The clocks are kept beside the control blocks, one [`Micros48`] per sequence (48 bits:
//! a run's time is exact for 8.9 years, whatever held it unpolled); whether a clock is
//! stopped is its control block's mark [`flag::CLOCK_STOPPED`]. While stopped, a clock
//! holds the time run so far; while it runs, the time from which it counts (the run's
//! start moved on by its pauses).

use crate::model::time::Micros48;
use crate::sequencer::control_block::{flag, ControlBlock};
use crate::sequencer::State;
use crate::SeqId;

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// The unpaused time of `id`'s current run at the last tick (µs; 0 for an id not
    /// registered).
    #[inline]
    pub(crate) fn run_time(&self, id: SeqId) -> u64 {
        self.block(id).map_or(0, |b| self.run_time_of(id, b))
    }

    /// As [`run_time`](Self::run_time), with `id`'s control block `b` at hand.
    #[inline]
    fn run_time_of(&self, id: SeqId, b: &ControlBlock) -> u64 {
        let Some(clock) = self.clocks.get(id.index()) else {
            return 0;
        };
        if b.has(flag::CLOCK_STOPPED) {
            clock.get()
        } else {
            clock.until(self.now)
        }
    }

    /// Whether `id`'s armed timeout has run out at the last tick (paused time not counted).
    #[inline]
    pub(crate) fn timed_out(&self, id: SeqId) -> bool {
        self.run_out_timeout(id).is_some()
    }

    /// `id`'s timeout (µs) if it has run out at the last tick: a mark compares it with
    /// the timeout it then finds, so that one changed in between marks nothing.
    #[inline]
    pub(crate) fn run_out_timeout(&self, id: SeqId) -> Option<u32> {
        // Switched off during the run (`Handle::set_timeout(None)`): never.
        self.block(id)
            .filter(|b| b.timeout != 0 && self.run_time_of(id, b) >= u64::from(b.timeout))
            .map(|b| b.timeout)
    }

    /// Starts `id`'s clock at the last tick, running (a start or restart).
    #[inline]
    pub(crate) fn start_clock(&mut self, id: SeqId) {
        let now = Micros48::new(self.now.as_ticks());
        let Some(b) = self.block_mut(id) else {
            return;
        };
        b.set(flag::CLOCK_STOPPED, false);
        if let Some(clock) = self.clocks.get_mut(id.index()) {
            *clock = now;
        }
    }

    /// At a pause: the clock keeps the run's unpaused time so far. A stopped clock stays as
    /// it is.
    #[inline]
    pub(crate) fn stop_clock(&mut self, id: SeqId) {
        let now = self.now;
        let Some(b) = self.block_mut(id).filter(|b| !b.has(flag::CLOCK_STOPPED)) else {
            return;
        };
        b.set(flag::CLOCK_STOPPED, true);
        if let Some(clock) = self.clocks.get_mut(id.index()) {
            *clock = Micros48::new(clock.until(now));
        }
    }

    /// At a resume: the clock counts again, from the time that makes its run time what it
    /// was (the last tick minus the time run so far). A running clock stays as it is.
    #[inline]
    pub(crate) fn run_clock(&mut self, id: SeqId) {
        let now = self.now.as_ticks();
        let Some(b) = self.block_mut(id).filter(|b| b.has(flag::CLOCK_STOPPED)) else {
            return;
        };
        b.set(flag::CLOCK_STOPPED, false);
        if let Some(clock) = self.clocks.get_mut(id.index()) {
            *clock = Micros48::new(now.wrapping_sub(clock.get()));
        }
    }
}
