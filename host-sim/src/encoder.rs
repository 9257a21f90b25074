//! Quadrature encoder: the true wheel angle turned into the integer counts a timer sees.
//!
//! The encoder sits on the motor shaft: `lines` pulses per channel per motor turn, ×4
//! edges in quadrature, × the gear ratio N per wheel turn. A timer in encoder mode holds
//!
//! count = ⌊φ · ticks_per_rev / 2π + n⌋
//!
//! for a wheel angle φ (rad). The optional noise n (in ticks, Gaussian, drawn afresh every
//! reading) models edge jitter: code-wheel eccentricity and quadrature phase error move
//! the edges back and forth around their true place. It does **not** accumulate — the
//! count never drifts from the true angle by more than the jitter — which is what a real,
//! working encoder does; lost counts would be a fault, not noise.
//!
//! [`Encoder::read_delta`] returns the signed ticks since the previous reading, which is
//! exactly what the firmware hands to the controller each step.

use robot_files::rng::Rng;

/// ⌊x⌋ as an integer. `f64::floor` is a library call on the baseline x86-64 target (no
/// SSE4.1), and this runs twice per control step; the cast truncates toward zero and
/// saturates (NaN gives 0), so one correction for negative non-integers is enough.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t - 1
    } else {
        t
    }
}

/// One wheel's quadrature encoder.
#[derive(Clone, Debug)]
pub struct Encoder {
    ticks_per_rad: f64,
    noise_rms_ticks: f64,
    last_count: i64,
}

impl Encoder {
    /// An encoder with `ticks_per_rev` ticks per *wheel* revolution (lines × 4 × N) and
    /// edge jitter of `noise_rms_ticks` ticks RMS (0 for an ideal encoder), whose count
    /// is taken at wheel angle `angle_rad` (rad) as the starting reference.
    pub fn new(ticks_per_rev: f64, noise_rms_ticks: f64, angle_rad: f64) -> Self {
        let ticks_per_rad = ticks_per_rev / core::f64::consts::TAU;
        Self {
            ticks_per_rad,
            noise_rms_ticks,
            last_count: floor_i64(angle_rad * ticks_per_rad),
        }
    }

    /// The raw count at wheel angle `angle_rad` (rad), with jitter drawn from `rng`.
    pub fn count(&self, angle_rad: f64, rng: &mut Rng) -> i64 {
        let jitter = if self.noise_rms_ticks > 0.0 {
            self.noise_rms_ticks * rng.normal()
        } else {
            0.0
        };
        floor_i64(angle_rad * self.ticks_per_rad + jitter)
    }

    /// Signed ticks since the previous reading, at wheel angle `angle_rad` (rad).
    /// Saturates at the `i32` range (only reachable with absurd parameters).
    pub fn read_delta(&mut self, angle_rad: f64, rng: &mut Rng) -> i32 {
        let count = self.count(angle_rad, rng);
        let delta = count - self.last_count;
        self.last_count = count;
        delta.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::TAU;

    #[test]
    fn ideal_encoder_counts_whole_ticks_without_loss() {
        let mut e = Encoder::new(1440.0, 0.0, 0.0);
        let mut rng = Rng::new(1);
        let mut total = 0i64;
        // 0.3 ticks per reading: most readings are 0, a few 1; none lost over a turn and
        // a bit (the sum of deltas is the count at the last angle).
        let step = 0.3 * TAU / 1440.0;
        for k in 1..=4811 {
            let d = e.read_delta(k as f64 * step, &mut rng);
            assert!(d == 0 || d == 1);
            total += i64::from(d);
        }
        assert_eq!(total, 1443);
        // Backwards is negative.
        assert!(e.read_delta(0.0, &mut rng) < 0);
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
    fn jitter_does_not_accumulate() {
        let mut e = Encoder::new(1440.0, 0.7, 0.0);
        let mut rng = Rng::new(3);
        let mut total = 0i64;
        for _ in 0..10_000 {
            total += i64::from(e.read_delta(TAU, &mut rng));
        }
        // Sum of deltas = last count − first count: within a few σ of one turn.
        assert!((total - 1440).abs() <= 5, "{total}");
    }
}
