//! Sequencer time: microsecond instants and durations from the heartbeat tick, and the
//! compact form control blocks and polling classes keep.
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

/// The longest interval (polling period, timeout) in µs: below 2^31 µs (35 min), so that
/// [`Stamp`]s compare correctly by wrapping difference.
pub(crate) const MAX_INTERVAL: u64 = 0x7FFF_FFFF;

/// A polling period or timeout in the compact form of control blocks and polling classes:
/// µs, non-zero, at most [`MAX_INTERVAL`]. `None` outside that range.
pub(crate) const fn to_interval(d: Duration) -> Option<u32> {
    match d.as_ticks() {
        // In range, so the cast keeps the value.
        us @ 1..=MAX_INTERVAL => Some(us as u32),
        _ => None,
    }
}

/// A point in sequencer time as the low 32 bits of its microseconds: what control blocks
/// and polling classes store (half the RAM of an [`Instant`], cheaper on a 32-bit core).
///
/// Two stamps compare by their wrapping difference, which is right while every interval
/// between them is below 2^31 µs: registration keeps polling periods and timeouts there,
/// and the tick looks at every monitored sequence at least once per interval.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub(crate) struct Stamp(pub(crate) u32);

impl Stamp {
    /// The stamp of `t`.
    #[inline]
    pub(crate) fn of(t: Instant) -> Stamp {
        // Truncation is the point: the low 32 bits.
        Stamp(t.as_ticks() as u32)
    }

    /// `micros` after this stamp.
    #[inline]
    pub(crate) const fn plus(self, micros: u32) -> Stamp {
        Stamp(self.0.wrapping_add(micros))
    }

    /// Whether this stamp (now) has reached `at`.
    #[inline]
    pub(crate) const fn reached(self, at: Stamp) -> bool {
        self.0.wrapping_sub(at.0) <= MAX_INTERVAL as u32
    }

    /// The µs from this stamp (now) to `later`; for a stamp already reached, the time
    /// since reads as a long way ahead.
    #[inline]
    pub(crate) const fn until(self, later: Stamp) -> u32 {
        later.0.wrapping_sub(self.0)
    }

    /// Whichever of `a` and `b` comes first after this stamp (now).
    #[inline]
    pub(crate) const fn first_of(self, a: Stamp, b: Stamp) -> Stamp {
        if self.until(a) <= self.until(b) {
            a
        } else {
            b
        }
    }
}

/// The horizon of "nothing to poll": the tick looks again after this long at the latest.
pub(crate) const NEVER_AHEAD: u32 = MAX_INTERVAL as u32;

/// A count of µs modulo 2^48 (about 8.9 years): what a run's clock keeps, a stamp while
/// it runs, the time run so far while it is stopped. A run's time must be exact however
/// long the run lasts: a run held by an exception is not polled, and its clock runs on
/// (a [`Stamp`]'s 32 bits wrap after 71.6 minutes, which an operator's acknowledgement can
/// outlast). Packed to two-byte alignment: six bytes per sequence, not eight.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
#[repr(C, packed(2))]
pub(crate) struct Micros48 {
    low: u32,
    high: u16,
}

impl Micros48 {
    const MASK: u64 = (1 << 48) - 1;

    /// Zero.
    pub(crate) const ZERO: Micros48 = Micros48 { low: 0, high: 0 };

    /// `us` modulo 2^48.
    #[inline]
    pub(crate) const fn new(us: u64) -> Micros48 {
        // Truncation is the point: the low 48 bits.
        Micros48 {
            low: us as u32,
            high: (us >> 32) as u16,
        }
    }

    /// The count (below 2^48).
    #[inline]
    pub(crate) const fn get(self) -> u64 {
        (self.high as u64) << 32 | self.low as u64
    }

    /// The µs from this stamp to `now`, modulo 2^48.
    #[inline]
    pub(crate) const fn until(self, now: Instant) -> u64 {
        now.as_ticks().wrapping_sub(self.get()) & Self::MASK
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_compare_across_the_wrap() {
        let s = |n| Stamp(n);
        assert!(s(5).reached(s(5)));
        assert!(s(3).reached(s(u32::MAX - 2)));
        assert!(!s(u32::MAX - 2).reached(s(3)));
        assert_eq!(
            Stamp::of(Instant::from_ticks(u64::from(u32::MAX) + 3)),
            s(2)
        );
        assert_eq!(s(u32::MAX).plus(2), s(1));
        assert_eq!(s(10).first_of(s(12), s(11)), s(11));
        assert_eq!(s(u32::MAX - 1).first_of(s(1), s(u32::MAX)), s(u32::MAX));
    }

    #[test]
    fn micros48_keep_48_bits_and_count_across_their_wrap() {
        let m = Micros48::new(0x1234_5678_9ABC_DEF0);
        assert_eq!(m.get(), 0x5678_9ABC_DEF0);
        let at = |us: u64| Instant::from_ticks(us);
        assert_eq!(Micros48::new(5).until(at(7)), 2);
        // Past 2^32 µs: exact (a Stamp's difference would have wrapped).
        assert_eq!(Micros48::new(10).until(at((1 << 32) + 30)), (1 << 32) + 20);
        // Across the wrap of 48 bits, and of the instant's own 2^48.
        assert_eq!(Micros48::new((1 << 48) - 3).until(at(1 << 48)), 3);
        assert_eq!(Micros48::new((1 << 48) - 3).until(at(2)), 5);
        assert_eq!(Micros48::ZERO.get(), 0);
    }

    #[test]
    fn intervals_are_non_zero_and_below_2_pow_31_micros() {
        assert_eq!(to_interval(Duration::from_ticks(0)), None);
        assert_eq!(to_interval(Duration::from_ticks(1)), Some(1));
        assert_eq!(
            to_interval(Duration::from_ticks(0x7FFF_FFFF)),
            Some(0x7FFF_FFFF)
        );
        assert_eq!(to_interval(Duration::from_ticks(0x8000_0000)), None);
    }
}
