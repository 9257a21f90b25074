//! The simulated gyro: the plant's true yaw rate as an IMU's z axis reports it.
//!
//! Each control step the gyro hands over the mean rate over the period that just ended
//! (the true heading change over the period's length, as a 1 kHz sensor averaged or
//! read once per 1 kHz step gives it), times (1 + scale error), plus the bias (turn-on
//! offset plus a random walk), plus white noise of the datasheet's density over the
//! sample's band, quantised to one count and clipped at full scale; `latency_periods`
//! periods late. The ideal gyro of the oracle heading reports the true mean rate exactly.
//!
//! Its random draws come from a stream of its own, so a run with a gyro draws the same
//! encoder and supply noise as the same run without one.

use std::collections::VecDeque;

use controller_core::gyro::GyroSample;
use robot_files::rng::Rng;
use robot_files::scenario::{GyroSensor, GyroSetup, HeadingChoice};
use robot_files::truth::wrap_angle;

/// Mixed into the scenario's seed for the gyro's own random stream.
const GYRO_STREAM: u64 = 0x6779_726f_5f73_696d;

/// The simulated gyro (module doc).
#[derive(Clone, Debug)]
pub struct SimGyro {
    sensor: GyroSensor,
    ideal: bool,
    rng: Rng,
    /// The bias now, rad/s.
    bias_rad_s: f64,
    /// The true heading at the last reading, rad.
    last_heading_rad: f64,
    /// Readings not yet handed over (the latency).
    pending: VecDeque<f32>,
    /// Control period, s.
    period_s: f64,
}

impl SimGyro {
    /// The gyro of `setup` on a loop of `control_hz`, seeded from `seed`, the robot's
    /// true heading `heading_rad` (rad) at the start.
    pub fn new(setup: &GyroSetup, control_hz: u32, seed: u64, heading_rad: f64) -> Self {
        Self {
            sensor: setup.sensor,
            ideal: setup.heading == HeadingChoice::Oracle,
            rng: Rng::new(seed ^ GYRO_STREAM),
            bias_rad_s: setup.sensor.turn_on_bias_rad_s,
            last_heading_rad: heading_rad,
            pending: VecDeque::new(),
            period_s: 1.0 / f64::from(control_hz),
        }
    }

    /// The sensor's full scale, rad/s (what a saturated reading reports).
    pub fn full_scale_rad_s(&self) -> f64 {
        self.sensor.full_scale_rad_s
    }

    /// The reading of a step covering `periods` control periods that ended with the true
    /// heading `heading_rad` (rad); `None` while the latency's first readings are in
    /// flight.
    pub fn read(&mut self, heading_rad: f64, periods: u32) -> Option<GyroSample> {
        let dt_s = self.period_s * f64::from(periods.max(1));
        let true_rate = wrap_angle(heading_rad - self.last_heading_rad) / dt_s;
        self.last_heading_rad = heading_rad;
        let reading = if self.ideal {
            true_rate
        } else {
            let s = &self.sensor;
            self.bias_rad_s += s.bias_random_walk_rad_s_sqrt_s * dt_s.sqrt() * self.rng.normal();
            // White noise over the band of one 1 kHz sample (Nyquist, 500 Hz), averaged
            // over the step's periods.
            let sigma = s.noise_density_rad_s_sqrt_hz * (0.5 / self.period_s).sqrt()
                / f64::from(periods.max(1)).sqrt();
            let rate = true_rate * (1.0 + s.scale_error_pct / 100.0)
                + self.bias_rad_s
                + sigma * self.rng.normal();
            let counted = if s.lsb_rad_s > 0.0 {
                (rate / s.lsb_rad_s).round() * s.lsb_rad_s
            } else {
                rate
            };
            counted.clamp(-s.full_scale_rad_s, s.full_scale_rad_s)
        };
        self.pending.push_back(reading as f32);
        if self.pending.len() <= usize::from(self.sensor.latency_periods) && !self.ideal {
            return None;
        }
        self.pending.pop_front().map(|yaw_rate_radps| GyroSample {
            yaw_rate_radps,
            age_periods: if self.ideal {
                0
            } else {
                self.sensor.latency_periods
            },
        })
    }
}
