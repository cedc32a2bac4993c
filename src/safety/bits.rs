//! Bit sets over safety ids (events, inputs, outputs): one `u32` each.

/// `1 << index`, 0 if `index >= 32`.
pub(crate) const fn bit_of(index: usize) -> u32 {
    if index < 32 {
        match 1u32.checked_shl(index as u32) {
            Some(bit) => bit,
            None => 0,
        }
    } else {
        0
    }
}
