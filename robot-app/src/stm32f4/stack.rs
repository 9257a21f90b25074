//! The stack's high-water mark from a painted stack.
//!
//! With cortex-m-rt's `paint-stack` feature the reset handler fills the whole stack
//! region, from `_stack_end` (its lowest address) up to `_stack_start`, with
//! [`PAINT`] before `main`. The stack grows down from `_stack_start`; whatever it ever
//! used no longer holds the paint (or, rarely, holds the paint value by chance, which
//! can only make the mark low by the words that happen to match). Counting the painted
//! words from the bottom up to the first word that is not gives the untouched part; the
//! rest is the high-water mark.

/// The value cortex-m-rt paints the stack with (`cortex_m_rt::STACK_PAINT_VALUE`).
pub const PAINT: u32 = 0xCCCC_CCCC;

/// Bytes of the stack ever used, given its `words` from the lowest address up (the
/// whole region from `_stack_end` to `_stack_start`).
pub fn high_water_bytes(words: impl IntoIterator<Item = u32>) -> u32 {
    let mut untouched = 0u32;
    let mut total = 0u32;
    let mut scrubbed = false;
    for word in words {
        total = total.saturating_add(1);
        if !scrubbed && word == PAINT {
            untouched = untouched.saturating_add(1);
        } else {
            scrubbed = true;
        }
    }
    total.saturating_sub(untouched).saturating_mul(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mark_is_everything_above_the_last_painted_word_from_the_bottom() {
        // 8 words, the top 3 used.
        let mut stack = [PAINT; 8];
        stack[5] = 0;
        stack[7] = 0x2000_1000;
        assert_eq!(high_water_bytes(stack), 12);
        // A word deep down that a frame skipped (still painted) does not hide the use
        // below it: the first scrubbed word from the bottom counts.
        stack[2] = 1;
        assert_eq!(high_water_bytes(stack), 24);
        assert_eq!(high_water_bytes([PAINT; 4]), 0);
        assert_eq!(high_water_bytes([0u32; 4]), 16);
        assert_eq!(high_water_bytes([]), 0);
    }
}
