//! Safety levels: ordered ids, lower is safer.

use core::fmt;

/// A safety level: an ordered id, **lower = safer**.
///
/// Levels are numbered `0..L` without gaps; level `0` is the safest.
/// When several events arrive in one cycle, the lowest resulting level
/// wins.
///
/// ```
/// use rtseq::safety::SafetyLevel;
/// const EMERGENCY: SafetyLevel = SafetyLevel::new(0);
/// const MOVING: SafetyLevel = SafetyLevel::new(4);
/// assert!(EMERGENCY < MOVING);
/// assert_eq!(MOVING.id(), 4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafetyLevel(u8);

impl SafetyLevel {
    /// The safest possible level, id 0.
    ///
    /// ```
    /// use rtseq::safety::SafetyLevel;
    /// assert_eq!(SafetyLevel::SAFEST, SafetyLevel::new(0));
    /// ```
    pub const SAFEST: Self = Self(0);

    /// Declares level `id` (its position in the level array).
    ///
    /// ```
    /// use rtseq::safety::SafetyLevel;
    /// const READY: SafetyLevel = SafetyLevel::new(2);
    /// # let _ = READY;
    /// ```
    pub const fn new(id: u8) -> Self {
        Self(id)
    }

    /// The numeric id.
    ///
    /// ```
    /// use rtseq::safety::SafetyLevel;
    /// assert_eq!(SafetyLevel::new(3).id(), 3);
    /// ```
    pub const fn id(self) -> u8 {
        self.0
    }

    /// The id as an array index.
    ///
    /// ```
    /// use rtseq::safety::SafetyLevel;
    /// assert_eq!(SafetyLevel::new(3).index(), 3usize);
    /// ```
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// Const `<=` (for `const` validation).
    pub(crate) const fn le(self, other: Self) -> bool {
        self.0 <= other.0
    }
}

impl fmt::Display for SafetyLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "level {}", self.0)
    }
}
