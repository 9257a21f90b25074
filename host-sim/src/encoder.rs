//! Quadrature encoder: the true wheel angle turned into the integer counts a timer sees.
//!
//! The encoder sits on the motor shaft: `lines` pulses per channel per motor turn, ×4
//! edges in quadrature, × the gear ratio N per wheel turn. A timer in encoder mode counts
//! the edges the wheel has passed. An ideal encoder's edge k sits at wheel angle
//! k · 2π / ticks_per_rev, so at angle φ (rad)
//!
//! count = ⌊φ · ticks_per_rev / 2π⌋.
//!
//! **Edge jitter** (the optional noise, in ticks RMS) models code-wheel eccentricity and
//! quadrature phase error: each edge sits off its true place by a fixed offset of its own,
//! uniform in ±√3·σ ticks (RMS σ), the same every time the wheel passes it. The count is
//! a function of the angle alone: a turning wheel reads unevenly spaced ticks, a still
//! wheel a constant count, and a wheel dithering about an edge flickers by one, as a real
//! encoder does. The count never drifts from the true angle by more than a tick — lost
//! counts would be a fault (`ticks-lost`), not noise. σ is at most
//! [`MAX_EDGE_JITTER_TICKS_RMS`], so that every edge stays within a tick of its place
//! (neighbours may swap places; the count, which only counts them, does not notice).
//!
//! [`Encoder::read_delta`] returns the signed ticks since the previous reading, which is
//! exactly what the firmware hands to the controller each step.

use robot_files::scenario::MAX_EDGE_JITTER_TICKS_RMS;

/// ⌊x⌋ as an integer. `f64::floor` is a library call on the baseline x86-64 target (no
/// SSE4.1), and this runs twice per control step; the cast truncates toward zero and
/// saturates (NaN gives 0), so one correction for negative non-integers is enough (itself
/// saturating, for −∞).
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// SplitMix64's output function: 64 well-mixed bits of `z` (Steele, Lea & Flood, 2014).
const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One wheel's quadrature encoder.
#[derive(Clone, Debug)]
pub struct Encoder {
    ticks_per_rad: f64,
    /// Largest edge offset, ticks (√3 · the jitter's RMS; 0 for an ideal encoder).
    max_offset_ticks: f64,
    /// Seeds the edges' offsets: edge k's is a function of `edge_seed` and k alone.
    edge_seed: u64,
    last_count: i64,
}

impl Encoder {
    /// An encoder with `ticks_per_rev` ticks per *wheel* revolution (lines × 4 × N) and
    /// edge jitter of `jitter_ticks_rms` ticks RMS (0 for an ideal encoder; clamped to
    /// [0, [`MAX_EDGE_JITTER_TICKS_RMS`]]) laid out by `edge_seed` (module doc), whose
    /// count is taken at wheel angle `angle_rad` (rad) as the starting reference.
    pub fn new(ticks_per_rev: f64, jitter_ticks_rms: f64, angle_rad: f64, edge_seed: u64) -> Self {
        let mut encoder = Self {
            ticks_per_rad: ticks_per_rev / core::f64::consts::TAU,
            max_offset_ticks: 3f64.sqrt() * jitter_ticks_rms.clamp(0.0, MAX_EDGE_JITTER_TICKS_RMS),
            edge_seed,
            last_count: 0,
        };
        encoder.last_count = encoder.count(angle_rad);
        encoder
    }

    /// Edge `k`'s offset from its true place, ticks: uniform in ±`max_offset_ticks`.
    fn edge_offset(&self, k: i64) -> f64 {
        let bits = mix64(self.edge_seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        // 53 bits to [0, 1), then to [−1, 1).
        let unit = (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        self.max_offset_ticks * (2.0 * unit - 1.0)
    }

    /// The raw count at wheel angle `angle_rad` (rad): the edges at or below it.
    pub fn count(&self, angle_rad: f64) -> i64 {
        let x = angle_rad * self.ticks_per_rad;
        let k = floor_i64(x);
        let fraction = x - k as f64;
        // Every edge moves by less than a tick, so the edges up to k − 1 lie below x and
        // those from k + 2 on above it: only edges k and k + 1 are in doubt. (Saturating
        // and wrapping at the i64 range, which only an absurd angle reaches.)
        let edge_k = self.edge_offset(k) <= fraction;
        let edge_next = 1.0 + self.edge_offset(k.wrapping_add(1)) <= fraction;
        k.saturating_add(i64::from(edge_k) + i64::from(edge_next) - 1)
    }

    /// Signed ticks since the previous reading, at wheel angle `angle_rad` (rad).
    /// Saturates at the `i32` range (only reachable with absurd parameters).
    pub fn read_delta(&mut self, angle_rad: f64) -> i32 {
        let count = self.count(angle_rad);
        let delta = count - self.last_count;
        self.last_count = count;
        delta.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::TAU;

    const TICKS_PER_REV: f64 = 1440.0;
    const RAD_PER_TICK: f64 = TAU / TICKS_PER_REV;

    #[test]
    fn ideal_encoder_counts_whole_ticks_without_loss() {
        let mut e = Encoder::new(TICKS_PER_REV, 0.0, 0.0, 1);
        let mut total = 0i64;
        // 0.3 ticks per reading: most readings are 0, a few 1; none lost over a turn and
        // a bit (the sum of deltas is the count at the last angle).
        let step = 0.3 * RAD_PER_TICK;
        for k in 1..=4811 {
            let d = e.read_delta(k as f64 * step);
            assert!(d == 0 || d == 1);
            total += i64::from(d);
        }
        assert_eq!(total, 1443);
        // Backwards is negative.
        assert!(e.read_delta(0.0) < 0);
    }

    #[test]
    fn floor_matches_the_library() {
        for x in [
            -2.5,
            -2.0,
            -0.1,
            -0.0,
            0.0,
            0.1,
            1.0,
            1.9999,
            1e12 + 0.5,
            -1e12 - 0.5,
        ] {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn edge_offsets_have_the_stated_rms_and_stay_within_a_tick() {
        let e = Encoder::new(TICKS_PER_REV, 0.4, 0.0, 7);
        let offsets: Vec<f64> = (-5000..5000).map(|k| e.edge_offset(k)).collect();
        let n = offsets.len() as f64;
        let mean = offsets.iter().sum::<f64>() / n;
        let rms = (offsets.iter().map(|o| o * o).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((rms - 0.4).abs() < 0.01, "rms {rms}");
        let largest = offsets.iter().fold(0.0f64, |m, o| m.max(o.abs()));
        assert!(
            largest <= 3f64.sqrt() * 0.4 && largest > 0.68,
            "largest {largest}"
        );
        // A jitter beyond the model's range is clamped to it.
        let wild = Encoder::new(TICKS_PER_REV, 1e6, 0.0, 7);
        assert!((-5000..5000).all(|k| wild.edge_offset(k).abs() < 1.0));
    }

    #[test]
    fn a_wheel_dithering_about_an_edge_flickers_by_one() {
        let e = Encoder::new(TICKS_PER_REV, MAX_EDGE_JITTER_TICKS_RMS, 0.0, 3);
        for k in -50..50 {
            // Edge k's place, found by its offset; a wheel 0.01 tick either side of it.
            let place = k as f64 + e.edge_offset(k);
            let below = e.count((place - 0.01) * RAD_PER_TICK);
            let above = e.count((place + 0.01) * RAD_PER_TICK);
            assert_eq!(above - below, 1, "edge {k} at {place}");
        }
    }

    #[test]
    fn an_absurd_angle_saturates_instead_of_overflowing() {
        let e = Encoder::new(TICKS_PER_REV, MAX_EDGE_JITTER_TICKS_RMS, 0.0, 3);
        for angle in [f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300, f64::NAN] {
            let _ = e.count(angle);
        }
        assert!(e.count(f64::INFINITY) >= i64::MAX - 1);
    }

    #[test]
    fn the_count_never_goes_back_as_the_wheel_turns_and_stays_within_a_tick() {
        let e = Encoder::new(TICKS_PER_REV, MAX_EDGE_JITTER_TICKS_RMS, 0.0, 11);
        let mut last = e.count(-50.0 * RAD_PER_TICK);
        for i in -5000..5000 {
            let ticks = f64::from(i) * 0.01;
            let count = e.count(ticks * RAD_PER_TICK);
            assert!(
                count == last || count == last + 1,
                "{ticks}: {last} then {count}"
            );
            assert!(
                (count - ticks.floor() as i64).abs() <= 1,
                "{ticks}: {count}"
            );
            last = count;
        }
    }

    #[test]
    fn a_turning_wheel_reads_unevenly_spaced_ticks_that_do_not_accumulate() {
        // One tick per reading: an ideal encoder reads 1 every time.
        let deltas = |jitter: f64| -> Vec<i32> {
            let mut e = Encoder::new(TICKS_PER_REV, jitter, 0.25 * RAD_PER_TICK, 5);
            (1..=10_000)
                .map(|k| e.read_delta((f64::from(k) + 0.25) * RAD_PER_TICK))
                .collect()
        };
        assert!(deltas(0.0).iter().all(|&d| d == 1));
        let jittered = deltas(0.3);
        assert!(jittered.iter().any(|&d| d != 1));
        assert!(jittered.iter().all(|&d| (0..=2).contains(&d)));
        // The sum of the deltas is the count at the last angle: within a tick of it.
        let total: i32 = jittered.iter().sum();
        assert!((total - 10_000).abs() <= 1, "{total}");
    }
}
