//! Sequencer time: microsecond instants and durations from the heartbeat tick.
//!
//! All sequencer time is the time handed to [`Sequencer::tick`](crate::Sequencer::tick), so a
//! host simulation is exact and deterministic, and on target it is whatever monotonic time
//! base the timer interrupt provides.

/// A point in sequencer time, in microseconds since an arbitrary epoch (usually boot).
///
/// ```
/// use rtseq::Instant;
/// let t = Instant::from_ticks(1_500);
/// assert_eq!(t.duration_since_epoch().as_millis(), 1);
/// ```
pub type Instant = fugit::MonotonicTimerInstantU64<1_000_000>;

/// A span of sequencer time, in microseconds.
///
/// ```
/// use rtseq::Duration;
/// let d = Duration::from_millis(10);
/// assert_eq!(d.as_ticks(), 10_000);
/// ```
pub type Duration = fugit::MicrosDurationU64;

/// Converts a polling period or timeout to the compact microsecond form stored in control
/// blocks: non-zero and below 2^31 µs (35 min), so wrapping comparisons stay correct.
pub(crate) const fn to_interval(d: Duration) -> Option<u32> {
    match d.as_ticks() {
        // In range, so the cast keeps the value.
        us @ 1..0x8000_0000 => Some(us as u32),
        _ => None,
    }
}
