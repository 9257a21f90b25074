//! Run metrics computed as the run goes, in fixed memory: settle time, final error, and
//! the RMS and largest position error over the final window.
//!
//! The robot computes them on its own estimate at every steering update (it knows nothing
//! else), the virtual robot and the simulator also on the true pose; all with this code,
//! so a summary recorded from a robot over the link and one written by the simulator
//! mean the same thing. Nothing here grows with the run's length: a day-long soak keeps
//! [`FINAL_WINDOW_BUCKETS`] one-second buckets.
//!
//! ## Definitions
//!
//! - **Settled** at a sample when the position error is below [`SETTLE_POSITION_M`] and
//!   the heading error's magnitude below [`SETTLE_HEADING_RAD`]. The **settle time** is
//!   the time of the first sample after which every sample is settled (the first sample's
//!   time if all are); none if the last sample is not settled.
//! - The **final window** is the last [`FINAL_WINDOW_BUCKETS`] whole seconds of the run
//!   (samples are binned by the whole second of their time): over a 30 s run sampled every
//!   10 ms it holds exactly the samples of [20 s, 30 s).

/// Position threshold of the settle criterion, m.
pub const SETTLE_POSITION_M: f32 = 0.01;
/// Heading threshold of the settle criterion, rad (1°).
pub const SETTLE_HEADING_RAD: f32 = core::f32::consts::PI / 180.0;
/// Length of the final window, in one-second buckets.
pub const FINAL_WINDOW_BUCKETS: usize = 10;

use core::num::NonZeroU32;

/// One error sample: time (control periods since the start of the run), position error
/// (m, ≥ 0) and heading error (rad, signed, in (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorSample {
    /// Control periods since the start of the run.
    pub step: u32,
    /// Distance to the reference (or to the path, when path-following), m.
    pub position_m: f32,
    /// Heading error θ_r − θ, rad.
    pub heading_rad: f32,
}

/// What a run's errors amounted to: the link's type, so what the robot sends is what it
/// computed (fields in m, rad and s; see the module doc).
pub use link::ErrorSummary;

/// One second's worth of samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Bucket {
    /// The whole second this bucket holds (`u32::MAX`: empty).
    second: u32,
    sum_squares_m2: f32,
    count: u32,
    max_m: f32,
}

const EMPTY: Bucket = Bucket {
    second: u32::MAX,
    sum_squares_m2: 0.0,
    count: 0,
    max_m: 0.0,
};

/// The streaming accumulator (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    /// Control periods per second.
    rate_hz: NonZeroU32,
    /// Step of the first sample after the last unsettled one.
    settled_since: Option<u32>,
    last: ErrorSample,
    samples: u32,
    /// Ring of the last seconds, indexed by second modulo the length.
    buckets: [Bucket; FINAL_WINDOW_BUCKETS],
    /// Second of the newest sample.
    newest_second: u32,
}

impl ErrorStats {
    /// No samples yet, for a loop of `rate_hz` control periods per second.
    pub const fn new(rate_hz: NonZeroU32) -> Self {
        Self {
            rate_hz,
            settled_since: None,
            last: ErrorSample {
                step: 0,
                position_m: 0.0,
                heading_rad: 0.0,
            },
            samples: 0,
            buckets: [EMPTY; FINAL_WINDOW_BUCKETS],
            newest_second: 0,
        }
    }

    /// Back to no samples, in place, for the same loop rate: what [`ErrorStats::new`]
    /// gives. Assigning a new value instead builds it and copies it in (about 200 bytes,
    /// two `memcpy` calls, about 320 instructions on the Cortex-M4F in the control step
    /// that arms).
    pub fn restart(&mut self) {
        self.settled_since = None;
        self.last = ErrorSample::default();
        self.samples = 0;
        for bucket in &mut self.buckets {
            *bucket = EMPTY;
        }
        self.newest_second = 0;
    }

    /// Adds `sample` (samples come in time order). A non-finite error counts as not
    /// settled and as an infinite error.
    pub fn push(&mut self, sample: ErrorSample) {
        let settled = sample.position_m < SETTLE_POSITION_M
            && sample.heading_rad < SETTLE_HEADING_RAD
            && sample.heading_rad > -SETTLE_HEADING_RAD;
        if !settled {
            self.settled_since = None;
        } else if self.settled_since.is_none() {
            self.settled_since = Some(sample.step);
        }
        self.last = sample;
        self.samples = self.samples.saturating_add(1);

        let second = sample.step / self.rate_hz;
        self.newest_second = second;
        let bucket = &mut self.buckets[second as usize % FINAL_WINDOW_BUCKETS];
        if bucket.second != second {
            *bucket = Bucket { second, ..EMPTY };
        }
        let error = if sample.position_m.is_finite() {
            sample.position_m
        } else {
            f32::INFINITY
        };
        bucket.sum_squares_m2 += error * error;
        bucket.count += 1;
        if error > bucket.max_m {
            bucket.max_m = error;
        }
    }

    /// The summary of what was pushed so far.
    pub fn summary(&self) -> ErrorSummary {
        if self.samples == 0 {
            return ErrorSummary::default();
        }
        let oldest = self
            .newest_second
            .saturating_sub(FINAL_WINDOW_BUCKETS as u32 - 1);
        let (mut sum, mut count, mut max) = (0.0f32, 0u32, 0.0f32);
        for b in &self.buckets {
            if b.second != u32::MAX && b.second >= oldest && b.second <= self.newest_second {
                sum += b.sum_squares_m2;
                count += b.count;
                if b.max_m > max {
                    max = b.max_m;
                }
            }
        }
        let mean_square = if count > 0 { sum / count as f32 } else { 0.0 };
        let rate = self.rate_hz.get() as f32;
        ErrorSummary {
            settle_time_s: self.settled_since.map(|step| step as f32 / rate),
            final_position_error_m: self.last.position_m,
            final_heading_error_rad: self.last.heading_rad,
            rms_position_error_m: controller_core::math::sqrt(mean_square),
            max_position_error_m: max,
            samples: self.samples,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HZ: NonZeroU32 = match NonZeroU32::new(100) {
        Some(r) => r,
        None => NonZeroU32::MIN,
    };

    /// A sample at `t` s (at 100 Hz).
    fn s(t: f32, p: f32, h: f32) -> ErrorSample {
        ErrorSample {
            step: (t * 100.0).round() as u32,
            position_m: p,
            heading_rad: h,
        }
    }

    fn stats(samples: &[ErrorSample]) -> ErrorSummary {
        let mut st = ErrorStats::new(HZ);
        for &x in samples {
            st.push(x);
        }
        st.summary()
    }

    #[test]
    fn restart_is_a_new_accumulator() {
        let mut st = ErrorStats::new(HZ);
        for k in 0..2500 {
            st.push(s(k as f32 * 0.01, 0.02 + (k % 7) as f32 * 0.01, 0.1));
        }
        assert_ne!(st, ErrorStats::new(HZ));
        st.restart();
        assert_eq!(st, ErrorStats::new(HZ));
        assert_eq!(st.summary(), ErrorSummary::default());
    }

    #[test]
    fn settle_time_is_after_the_last_violation() {
        let m = stats(&[
            s(0.0, 0.5, 0.0),
            s(1.0, 0.005, 0.0),
            s(2.0, 0.02, 0.0),
            s(3.0, 0.005, 0.001),
            s(4.0, 0.001, -0.001),
        ]);
        assert_eq!(m.settle_time_s, Some(3.0));
        assert_eq!(m.final_position_error_m, 0.001);
        // All five seconds are in the window: max 0.5.
        assert_eq!(m.max_position_error_m, 0.5);
        assert_eq!(m.samples, 5);
    }

    #[test]
    fn a_heading_error_either_way_unsettles() {
        assert_eq!(
            stats(&[s(0.0, 0.0, 0.0), s(1.0, 0.0, 0.1)]).settle_time_s,
            None
        );
        assert_eq!(
            stats(&[s(0.0, 0.0, 0.0), s(1.0, 0.0, -0.1)]).settle_time_s,
            None
        );
        assert_eq!(
            stats(&[s(0.0, 0.0, 0.0), s(1.0, 0.0, 0.0)]).settle_time_s,
            Some(0.0)
        );
        assert_eq!(stats(&[]).settle_time_s, None);
        assert_eq!(stats(&[s(0.0, f32::NAN, 0.0)]).settle_time_s, None);
    }

    #[test]
    fn the_final_window_is_the_last_ten_whole_seconds() {
        // 30 s at 100 Hz: 1 m of error for t < 20 s, then 0.003 m.
        let samples: Vec<_> = (0..3000)
            .map(|k| {
                let t = k as f32 * 0.01;
                s(t, if t < 20.0 { 1.0 } else { 0.003 }, 0.0)
            })
            .collect();
        let m = stats(&samples);
        assert!((m.rms_position_error_m - 0.003).abs() < 1e-6, "{m:?}");
        assert!((m.max_position_error_m - 0.003).abs() < 1e-6);
        // A sample in the 20th second counts.
        let mut with_spike = samples.clone();
        with_spike[2005].position_m = 0.5;
        assert_eq!(stats(&with_spike).max_position_error_m, 0.5);
        // RMS by hand: errors 3 and 4 in the same second → √((9 + 16)/2).
        let m = stats(&[s(5.2, 3.0, 0.0), s(5.4, 4.0, 0.0)]);
        assert!((m.rms_position_error_m - (12.5f32).sqrt()).abs() < 1e-5);
    }

    #[test]
    fn a_day_long_run_keeps_fixed_memory_and_the_last_window() {
        let mut st = ErrorStats::new(HZ);
        for step in 0..8_640_000u32 {
            st.push(ErrorSample {
                step,
                position_m: if step < 8_639_900 { 0.002 } else { 0.004 },
                heading_rad: 0.0,
            });
        }
        let m = st.summary();
        // The last 10 s: 900 samples at 2 mm, 100 at 4 mm: √((900·4 + 100·16)/1000) mm.
        assert!(
            (m.rms_position_error_m - 0.002_280_35).abs() < 1e-7,
            "{m:?}"
        );
        assert_eq!(m.max_position_error_m, 0.004);
        assert_eq!(m.samples, 8_640_000);
        assert_eq!(m.settle_time_s, Some(0.0));
    }
}
