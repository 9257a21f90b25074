//! Run metrics: settle time, final and windowed errors, peaks.
//!
//! Errors are sampled at every steering update (100 Hz by default), when the reference
//! is fresh: sampling between updates would measure the reference's staleness (up to
//! v_r·T_s = 2.5 mm at 0.25 m/s and 10 ms), which is a quarter of the 1 cm threshold.

use serde::Serialize;

/// Position threshold of the settle criterion, m.
pub const SETTLE_POSITION_M: f64 = 0.01;
/// Heading threshold of the settle criterion, rad (1°).
pub const SETTLE_HEADING_RAD: f64 = core::f64::consts::PI / 180.0;
/// Length of the final window of the RMS and max statistics, s.
pub const FINAL_WINDOW_S: f64 = 10.0;

/// One error sample: time (s), position error (m, ≥ 0) and heading error (rad, signed,
/// in (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorSample {
    /// Time since the start, s.
    pub t_s: f64,
    /// Distance to the reference (or to the path, when path-following), m.
    pub position_m: f64,
    /// Heading error θ_r − θ, rad.
    pub heading_rad: f64,
}

/// Error statistics of one run, against one pose (true or estimated).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ErrorMetrics {
    /// First time after which position error < [`SETTLE_POSITION_M`] and |heading error| <
    /// [`SETTLE_HEADING_RAD`] hold to the end, s; `None` if they do not hold at the end.
    pub settle_time_s: Option<f64>,
    /// Position error at the last sample, m.
    pub final_position_error_m: f64,
    /// Heading error θ_r − θ at the last sample, rad (signed).
    pub final_heading_error_rad: f64,
    /// RMS position error over the last [`FINAL_WINDOW_S`], m.
    pub rms_position_error_m: f64,
    /// Largest position error over the last [`FINAL_WINDOW_S`], m.
    pub max_position_error_m: f64,
}

impl ErrorMetrics {
    /// Statistics of `samples` (in time order). Empty input gives zeros and no settle time.
    pub fn from_samples(samples: &[ErrorSample]) -> Self {
        let Some(last) = samples.last() else {
            return Self::default();
        };
        let settled = |s: &ErrorSample| {
            s.position_m < SETTLE_POSITION_M && s.heading_rad.abs() < SETTLE_HEADING_RAD
        };
        // The sample after the last violation; all samples if there is none.
        let settle_time_s = match samples.iter().rposition(|s| !settled(s)) {
            None => Some(samples[0].t_s),
            Some(i) => samples.get(i + 1).map(|s| s.t_s),
        };
        let from = last.t_s - FINAL_WINDOW_S;
        let (mut sum2, mut n, mut max) = (0.0, 0usize, 0.0f64);
        for s in samples.iter().filter(|s| s.t_s >= from) {
            sum2 += s.position_m * s.position_m;
            n += 1;
            max = max.max(s.position_m);
        }
        Self {
            settle_time_s,
            final_position_error_m: last.position_m,
            final_heading_error_rad: last.heading_rad,
            rms_position_error_m: (sum2 / n.max(1) as f64).sqrt(),
            max_position_error_m: max,
        }
    }
}

/// The run summary written as `summary.json`: exactly these fields. Errors are of the
/// **true** pose (what a ruler on the floor would measure), see [`crate::run`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Steering law name (`paper`, `tracking` or `kanayama`).
    pub law: String,
    /// See [`ErrorMetrics::settle_time_s`], s (null if not settled).
    pub settle_time_s: Option<f64>,
    /// Position error at the end, m.
    pub final_position_error_m: f64,
    /// Heading error θ_r − θ at the end, rad (signed).
    pub final_heading_error_rad: f64,
    /// RMS position error over the last 10 s, m.
    pub rms_position_error_m: f64,
    /// Largest position error over the last 10 s, m.
    pub max_position_error_m: f64,
    /// Largest true wheel speed of either wheel, rad/s.
    pub max_wheel_speed_rad_s: f64,
    /// Largest |duty| the controller commanded, in [0, 1].
    pub max_duty: f64,
    /// Simulated time, s.
    pub sim_time_s: f64,
    /// Wall-clock time of the simulation loop, s.
    pub wall_time_s: f64,
    /// Control steps simulated.
    pub steps: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(t: f64, p: f64, h: f64) -> ErrorSample {
        ErrorSample {
            t_s: t,
            position_m: p,
            heading_rad: h,
        }
    }

    #[test]
    fn settle_time_is_after_the_last_violation() {
        let samples = [
            s(0.0, 0.5, 0.0),
            s(1.0, 0.005, 0.0),
            s(2.0, 0.02, 0.0),
            s(3.0, 0.005, 0.001),
            s(4.0, 0.001, -0.001),
        ];
        let m = ErrorMetrics::from_samples(&samples);
        assert_eq!(m.settle_time_s, Some(3.0));
        assert_eq!(m.final_position_error_m, 0.001);
        // Window = last 10 s = everything: max 0.5.
        assert_eq!(m.max_position_error_m, 0.5);
    }

    #[test]
    fn unsettled_end_gives_none_and_settled_start_gives_zero() {
        let m = ErrorMetrics::from_samples(&[s(0.0, 0.0, 0.0), s(1.0, 0.0, 0.1)]);
        assert_eq!(m.settle_time_s, None);
        let m = ErrorMetrics::from_samples(&[s(0.0, 0.0, 0.0), s(1.0, 0.0, 0.0)]);
        assert_eq!(m.settle_time_s, Some(0.0));
        assert_eq!(ErrorMetrics::from_samples(&[]).settle_time_s, None);
    }
}
