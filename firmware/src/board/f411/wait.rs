//! A wait with a bound in core clock cycles, timed by the DWT cycle counter (enabled at
//! the start of `init`, before the first such wait), so that the bound is a time however
//! fast the polling loop runs.

use cortex_m::peripheral::DWT;

/// Polls `done` until it holds or `cycles` core clock cycles have passed since the call;
/// whether it held. A `done` that holds at once is polled once; the last poll comes after
/// the bound, so a condition that became true just then still counts.
pub fn within_cycles(cycles: u32, mut done: impl FnMut() -> bool) -> bool {
    let started = DWT::cycle_count();
    loop {
        if done() {
            return true;
        }
        // CYCCNT wraps at 2^32; the difference does too.
        if DWT::cycle_count().wrapping_sub(started) >= cycles {
            return done();
        }
    }
}
