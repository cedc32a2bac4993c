//! An error's message, written by a `const fn`: a configuration checked in a `const` item
//! fails to compile with a panic, and a compile-time panic takes a `&str` but cannot
//! format. The message names what is wrong as the error's `Display` form does (which is
//! written from the same message).

use core::fmt;

/// Room for a message: two names of a usual length and the words around them. A longer
/// message is cut at a character boundary.
const CAPACITY: usize = 240;

/// An error's message, built at compile time or at run time, without formatting.
///
/// ```
/// use rtseq::{ConfigError, ErrorMessage, MonitorId, Raiser, SeqId};
/// const E: ConfigError = ConfigError::ExceptionWithoutLane {
///     raiser: Raiser::Monitor(MonitorId::from_index(0), "over-current"),
///     exception: (SeqId::from_index(2), "safe stop"),
/// };
/// // Made by the compiler: a compile-time panic can say it
/// // (`panic!("{}", E.message().as_str())`).
/// const MESSAGE: ErrorMessage = E.message();
/// assert_eq!(
///     MESSAGE.as_str(),
///     "the exception sequence `safe stop` of monitor `over-current` has no lane \
///      (declare one before the first tick)"
/// );
/// ```
#[derive(Clone, Copy)]
pub struct ErrorMessage {
    bytes: [u8; CAPACITY],
    len: usize,
}

impl ErrorMessage {
    /// An empty message.
    pub(crate) const fn new() -> Self {
        ErrorMessage {
            bytes: [0; CAPACITY],
            len: 0,
        }
    }

    /// The message with `text` added (as much of it as fits).
    pub(crate) const fn with(mut self, text: &str) -> Self {
        let mut rest = text.as_bytes();
        while let Some((&byte, tail)) = rest.split_first() {
            let Some((_, free)) = self.bytes.split_at_mut_checked(self.len) else {
                break;
            };
            let Some((slot, _)) = free.split_first_mut() else {
                break;
            };
            *slot = byte;
            self.len = self.len.saturating_add(1);
            rest = tail;
        }
        self
    }

    /// The message with the decimal digits of `n` added.
    pub(crate) const fn with_number(self, n: usize) -> Self {
        let m = if n >= 10 {
            self.with_number(n / 10)
        } else {
            self
        };
        let digit = [b'0'.saturating_add((n % 10) as u8)];
        match core::str::from_utf8(&digit) {
            Ok(text) => m.with(text),
            Err(_) => m,
        }
    }

    /// The message (cut at the last whole character if it did not fit).
    ///
    /// The message of a refused start, for a log that cannot format:
    ///
    /// ```
    /// use rtseq::{SeqConfig, Sequencer};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let id = seq.register(SeqConfig::new("press")).unwrap();
    /// let press = seq.sequence_by_id(id).unwrap();
    /// press.declare_lane().unwrap();
    /// press.start().unwrap();
    /// let refused = press.start().unwrap_err();
    /// assert_eq!(refused.message().as_str(), "sequence 0 is already running");
    /// ```
    pub const fn as_str(&self) -> &str {
        let Some((written, _)) = self.bytes.split_at_checked(self.len) else {
            return "";
        };
        match core::str::from_utf8(written) {
            Ok(text) => text,
            Err(cut) => match written.split_at_checked(cut.valid_up_to()) {
                Some((whole, _)) => match core::str::from_utf8(whole) {
                    Ok(text) => text,
                    Err(_) => "",
                },
                None => "",
            },
        }
    }
}

impl fmt::Display for ErrorMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for ErrorMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::format;

    use super::*;

    #[test]
    fn words_and_numbers_are_joined() {
        let m = ErrorMessage::new()
            .with("sequence ")
            .with_number(0)
            .with(", monitor ")
            .with_number(255)
            .with(", ")
            .with_number(usize::MAX);
        assert_eq!(m.as_str(), "sequence 0, monitor 255, 18446744073709551615");
    }

    #[test]
    fn a_message_prints_as_its_text() {
        let m = ErrorMessage::new().with("sequence `a\"b` ").with_number(7);
        assert_eq!(format!("{m}"), "sequence `a\"b` 7");
        assert_eq!(format!("{m:?}"), "\"sequence `a\\\"b` 7\"");
    }

    #[test]
    fn a_message_too_long_is_cut_at_a_character_boundary() {
        // 239 bytes, then a 3-byte character of which only 1 byte fits.
        let m = ErrorMessage::new()
            .with(&"a".repeat(239))
            .with("€ and more");
        assert_eq!(m.as_str().len(), 239);
        let m = ErrorMessage::new()
            .with(&"a".repeat(237))
            .with("€ and more");
        assert_eq!(m.as_str(), format!("{}€", "a".repeat(237)));
    }
}
