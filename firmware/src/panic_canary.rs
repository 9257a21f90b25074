//! Test only (feature `panic-canary`): one panic path that the control task always
//! reaches, so that `cargo xtask panic-check` shows on every CI run that it finds a panic
//! path when there is one. Never build it for a robot.
//!
//! Nothing panics at run time (the index is 0, in range), but the optimiser cannot know
//! that, so the bounds check and its call of `core::panicking::panic_bounds_check` stay.

/// Entry 0 of a two-entry table, read through an index hidden from the optimiser.
/// Never inlined: the check looks for the panic path in this function by its name.
#[inline(never)]
pub fn index() -> u8 {
    const TABLE: [u8; 2] = [0x5a, 0xa5];
    TABLE[core::hint::black_box(0)]
}
