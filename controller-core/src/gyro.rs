//! The gyro's reading as the control step receives it.
//!
//! A board with an IMU reads its z-axis rate and hands the newest reading to the control
//! step as a [`GyroSample`]; a board without one, or a step with no new reading, passes
//! `None` ([`crate::controller::StepInput::gyro`]). The reading is the sensor's own:
//! the core applies the axis sign, the scale factor and the bias estimate.
//!
//! [`HeadingFusion`] turns the readings into a heading: the bias learned while the robot
//! is still, the gyro's rate integrated in the same fixed-point heading as odometry
//! ([`BinaryAngle`]), a failed gyro (absent, stuck, saturated, non-finite) replaced by
//! odometry, and the running disagreement between the gyro's and odometry's yaw rates.

use crate::fixed::{AngleDelta, BinaryAngle};
use crate::math;
use crate::params::{calibration_scale, non_negative, positive, ParamError};

/// One reading of the gyro's yaw axis, as the sensor gave it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct GyroSample {
    /// Angular rate about the sensor's z axis, rad/s, in the sensor's own frame and
    /// scale: before the axis sign, the scale factor and the bias are applied. For a
    /// sensor read faster than the control rate, the mean of the readings since the last
    /// sample handed over.
    pub yaw_rate_radps: f32,
    /// Whole control periods between the end of the interval this reading covers and the
    /// start of the step it is handed to: 0 for a reading taken within the last period.
    pub age_periods: u8,
}

/// Where the controller's heading comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum HeadingSource {
    /// The encoders alone (a robot without an IMU). The fused heading is still computed,
    /// for telemetry and the disagreement check, when a gyro reads.
    #[default]
    Odometry,
    /// The gyro's integrated rate with its bias removed, corrected towards odometry's
    /// heading with [`GyroConfig::odometry_blend_time_constant_s`]; odometry's heading
    /// whenever the gyro has failed.
    Fused,
}

/// What the core knows about the gyro: its calibration and the limits that judge it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct GyroConfig {
    /// The heading the controller uses.
    pub heading_source: HeadingSource,
    /// The sensor's z axis points down (its rate is negated): counter-clockwise seen from
    /// above is positive in the robot's frame.
    pub axis_inverted: bool,
    /// Robot yaw rate per unit of sensor rate (1 for a perfect sensor), from bring-up:
    /// turn through a known angle and divide. In
    /// [`MIN_CALIBRATION_SCALE`](crate::params::MIN_CALIBRATION_SCALE) …
    /// [`MAX_CALIBRATION_SCALE`](crate::params::MAX_CALIBRATION_SCALE).
    pub scale: f32,
    /// The sensor's full scale, rad/s: a reading at or beyond 0.99 of it is saturated.
    pub full_scale_radps: f32,
    /// Time constant of the bias estimate once it has averaged this long, s: before, the
    /// estimate is the plain mean of every still reading since start.
    pub bias_time_constant_s: f32,
    /// Time constant of the correction of the fused heading towards odometry's, s; 0: no
    /// correction (the gyro alone between rests).
    pub odometry_blend_time_constant_s: f32,
    /// A reading older than this many control periods is not used.
    pub max_age_periods: u8,
    /// Consecutive steps without a usable reading after which the gyro has failed.
    pub absent_limit_steps: u16,
    /// Consecutive identical readings after which the gyro is stuck, if odometry turned
    /// by more than [`Self::stuck_turn_rad`] meanwhile (a live sensor's noise changes its
    /// reading within a few samples; an ideal one at rest may repeat it forever).
    pub stuck_limit_steps: u16,
    /// See [`Self::stuck_limit_steps`], rad.
    pub stuck_turn_rad: f32,
    /// Gyro against odometry yaw rate, beyond which (averaged over
    /// [`Self::disagreement_window_s`]) they disagree, rad/s.
    pub disagreement_threshold_radps: f32,
    /// Time constant of the disagreement's running mean, s.
    pub disagreement_window_s: f32,
    /// A disagreement while armed stops the robot (the supervisor latches
    /// `HeadingDisagreement`); false: it is a warning (`Event::GyroDisagrees`) and the
    /// robot drives on. A failed gyro is always a warning (`Event::GyroFailed`): the
    /// heading falls back to odometry, which is what a robot without a gyro steers by.
    pub disagreement_stops: bool,
}

impl GyroConfig {
    /// The ICM-42688-P at ±2000 °/s, axis up, scale uncalibrated (1), heading from
    /// odometry: a robot that reads its gyro but does not steer by it yet.
    pub const ICM42688P: GyroConfig = GyroConfig {
        heading_source: HeadingSource::Odometry,
        axis_inverted: false,
        scale: 1.0,
        full_scale_radps: 34.906_586,
        bias_time_constant_s: 20.0,
        odometry_blend_time_constant_s: 0.0,
        max_age_periods: 4,
        absent_limit_steps: 20,
        stuck_limit_steps: 200,
        stuck_turn_rad: 0.01,
        disagreement_threshold_radps: 0.03,
        disagreement_window_s: 10.0,
        disagreement_stops: false,
    };

    /// Robot yaw rate per unit of sensor rate: the scale, negated for an inverted axis.
    pub fn robot_per_sensor(&self) -> f32 {
        if self.axis_inverted {
            -self.scale
        } else {
            self.scale
        }
    }

    /// The same with `source` as the heading.
    #[must_use]
    pub const fn with_heading(mut self, source: HeadingSource) -> Self {
        self.heading_source = source;
        self
    }

    /// Every value usable: the scale a calibration's (0.5 … 2), the full scale, bias time
    /// constant and the disagreement's threshold and window finite and > 0 (the stuck
    /// turn and the blend time constant ≥ 0, 0 meaning none), and the absent and stuck
    /// limits at least one step; otherwise the first field that is not, named as in
    /// [`crate::params`].
    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        calibration_scale(self.scale, "gyro.scale")?;
        positive(self.full_scale_radps, "gyro.full_scale_radps")?;
        positive(self.bias_time_constant_s, "gyro.bias_time_constant_s")?;
        non_negative(
            self.odometry_blend_time_constant_s,
            "gyro.odometry_blend_time_constant_s",
        )?;
        if self.absent_limit_steps == 0 {
            return Err(ParamError::NonPositive {
                field: "gyro.absent_limit_steps",
                value: 0.0,
            });
        }
        if self.stuck_limit_steps == 0 {
            return Err(ParamError::NonPositive {
                field: "gyro.stuck_limit_steps",
                value: 0.0,
            });
        }
        non_negative(self.stuck_turn_rad, "gyro.stuck_turn_rad")?;
        positive(
            self.disagreement_threshold_radps,
            "gyro.disagreement_threshold_radps",
        )?;
        positive(self.disagreement_window_s, "gyro.disagreement_window_s")
    }
}

/// Why the gyro is not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum GyroFailure {
    /// No usable reading for [`GyroConfig::absent_limit_steps`].
    Absent,
    /// A reading that is NaN or infinite.
    NonFinite,
    /// A reading at the sensor's full scale.
    Saturated,
    /// The same reading [`GyroConfig::stuck_limit_steps`] times in a row.
    Stuck,
}

/// The gyro's state as the fusion sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum GyroHealth {
    /// No gyro has read since start (a robot without an IMU).
    #[default]
    None,
    /// Reading and used.
    Reading,
    /// Failed: the heading follows odometry until the supervisor's faults are next
    /// cleared (a fault, acknowledged) or the robot restarts.
    Failed(GyroFailure),
}

/// What the fusion computed in one step, for telemetry.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct GyroReport {
    /// The gyro's yaw rate, robot frame, counter-clockwise positive, bias removed, rad/s.
    pub yaw_rate_radps: f32,
    /// The bias estimate, robot frame, rad/s.
    pub bias_radps: f32,
    /// Running mean of gyro minus odometry yaw rate, rad/s.
    pub disagreement_radps: f32,
    /// |disagreement| went beyond [`GyroConfig::disagreement_threshold_radps`] and has not
    /// since fallen below [`DISAGREEMENT_CLEAR_FRACTION`] of it (hysteresis, so that a
    /// mean hovering at the threshold is one spell, not a warning each crossing).
    pub disagrees: bool,
    /// The gyro's state.
    pub health: GyroHealth,
}

/// A disagreement spell ends once |the running mean| falls below this fraction of
/// [`GyroConfig::disagreement_threshold_radps`].
pub const DISAGREEMENT_CLEAR_FRACTION: f32 = 0.8;

/// A still reading further than this from the bias estimate, rad/s, is a turn the
/// encoders do not see (a robot lifted and turned, turned slower than its encoders' rest
/// threshold, or the first moments of a turn by hand before its wheels count) and is not
/// learned: 0.57 °/s, about nine times the ICM-42688-P's noise at 1 kHz. The turn-on
/// offset, which may be larger, is learned before the gate applies, and an offset that
/// moved by more is learned again ([`BIAS_RELEARN_AFTER_STEADY`]).
pub const BIAS_GATE_RADPS: f32 = 0.01;

/// The gate applies once this many still readings are averaged (0.2 s at 1 kHz), or the
/// bias time constant's count if that is fewer, so that any turn-on offset is learned
/// from the first readings.
pub const BIAS_GATE_AFTER_SAMPLES: u32 = 200;

/// Still readings that have stayed within [`BIAS_STEADY_BAND_RADPS`] of their own mean
/// this many in a row (1 s at 1 kHz) are a still sensor: a reading the gate leaves out
/// after them says the estimate has the offset wrong (learned while the robot was turned
/// unseen, or the offset moved), and the estimate takes their mean. A robot turned by hand
/// or carried with its wheels still does not hold its rate that steady for that long, so
/// its turn is never learned.
pub const BIAS_RELEARN_AFTER_STEADY: u16 = 1000;

/// See [`BIAS_RELEARN_AFTER_STEADY`], rad/s: 0.29 °/s, about four and a half times the
/// ICM-42688-P's noise at 1 kHz.
pub const BIAS_STEADY_BAND_RADPS: f32 = 0.005;

/// The heading fusion: the gyro's bias learned at rest, the gyro's rate integrated into a
/// fixed-point heading, the gyro judged, its disagreement with odometry measured.
///
/// Contract: with no gyro reading ever, it changes nothing (the heading is odometry's,
/// bit for bit). The fused heading is a [`BinaryAngle`] advanced by the gyro's turn each
/// step; while the gyro is failed or absent it advances by odometry's turn, so it stays
/// continuous. The bias is learned only in steps the supervisor judges still.
#[derive(Clone, Copy, Debug)]
pub struct HeadingFusion {
    config: GyroConfig,
    report: GyroReport,
    fused: BinaryAngle,
    odometry: BinaryAngle,
    /// The last reading's bits, how many times in a row it came, and odometry's turn
    /// meanwhile.
    last_bits: u32,
    same_count: u16,
    turn_while_same: AngleDelta,
    /// Steps since the last usable reading.
    absent_steps: u16,
    /// The last usable rate, robot frame, bias removed, rad/s (held over a step with no
    /// new reading).
    held_rate_radps: f32,
    /// Still readings averaged into the bias (saturates at the time constant's count).
    bias_samples: u32,
    /// Still readings in a row within [`BIAS_STEADY_BAND_RADPS`] of their mean
    /// (saturating), and that mean, rad/s (robot frame).
    steady_count: u16,
    steady_mean_radps: f32,
    /// Control period, s.
    period_s: f32,
}

impl HeadingFusion {
    /// A fusion with `config` on a loop of period `period_s` (s), at `heading`.
    pub fn new(config: GyroConfig, period_s: f32, heading: BinaryAngle) -> Self {
        Self {
            config,
            report: GyroReport::default(),
            fused: heading,
            odometry: heading,
            last_bits: 0,
            same_count: 0,
            turn_while_same: AngleDelta::default(),
            absent_steps: 0,
            held_rate_radps: 0.0,
            bias_samples: 0,
            steady_count: 0,
            steady_mean_radps: 0.0,
            period_s,
        }
    }

    /// The configuration in use.
    pub const fn config(&self) -> &GyroConfig {
        &self.config
    }

    /// Replaces the configuration, keeping the headings, the health and the bias: the
    /// bias is the sensor's, so when the axis sign or the scale changes (a bring-up's
    /// calibration) its estimate, kept in the robot's frame, is converted to the new one
    /// rather than learned again. `config` is a validated one, as
    /// [`crate::params::Params::new`] checks it: a scale of 0 would make the bias
    /// non-finite.
    pub fn set_config(&mut self, config: GyroConfig) {
        self.report.bias_radps *= config.robot_per_sensor() / self.config.robot_per_sensor();
        // A steady spell's readings were in the old frame.
        self.steady_count = 0;
        self.config = config;
    }

    /// Starts again on a loop of period `period_s` (s) at `heading` (new parameters):
    /// the bias, its averaging and the gyro's health stay.
    pub fn restart(&mut self, period_s: f32, heading: BinaryAngle) {
        self.period_s = period_s;
        self.set_heading(heading);
    }

    /// The last step's report.
    pub const fn report(&self) -> &GyroReport {
        &self.report
    }

    /// Both headings set to `heading` (the pose command); the bias is the sensor's and
    /// stays.
    pub fn set_heading(&mut self, heading: BinaryAngle) {
        self.fused = heading;
        self.odometry = heading;
        self.report.disagreement_radps = 0.0;
        self.report.disagrees = false;
    }

    /// A failed gyro is tried again (the supervisor's faults were cleared).
    pub fn clear_failure(&mut self) {
        if let GyroHealth::Failed(_) = self.report.health {
            self.report.health = GyroHealth::None;
            self.absent_steps = 0;
            self.same_count = 0;
        }
        self.report.disagreement_radps = 0.0;
        self.report.disagrees = false;
    }

    /// True when the controller should steer by the fused heading in this step.
    pub fn steers(&self) -> bool {
        self.config.heading_source == HeadingSource::Fused
            && self.report.health == GyroHealth::Reading
    }

    /// One step of `periods` control periods in which odometry turned by `odometry_turn`,
    /// with the gyro's `sample`; `still` when the bias may be learned. Returns the fused
    /// heading's turn in this step (odometry's while the gyro is not read).
    pub fn step(
        &mut self,
        sample: Option<GyroSample>,
        odometry_turn: AngleDelta,
        periods: u32,
        still: bool,
    ) -> AngleDelta {
        self.odometry = self.odometry.add(odometry_turn);
        if sample.is_none() && self.report.health == GyroHealth::None {
            // No gyro (yet): the fused heading is odometry's.
            self.fused = self.fused.add(odometry_turn);
            return odometry_turn;
        }
        let dt_s = self.period_s * periods as f32;
        let rate = self.judge(sample, odometry_turn, still);
        let turn = match (self.report.health, rate) {
            (GyroHealth::Reading, Some(rate)) => {
                self.held_rate_radps = rate;
                self.gyro_turn(rate, dt_s)
            }
            (GyroHealth::Reading, None) => self.gyro_turn(self.held_rate_radps, dt_s),
            _ => odometry_turn,
        };
        self.fused = self.fused.add(turn);
        if self.report.health == GyroHealth::Reading {
            self.check_disagreement(odometry_turn, turn, dt_s);
        }
        turn
    }

    /// The fused heading, world frame, wrapped to (−π, π], rad.
    pub fn fused_heading_rad(&self) -> f32 {
        self.fused.to_rad()
    }

    /// The heading from the encoders alone, world frame, wrapped to (−π, π], rad.
    pub fn odometry_heading_rad(&self) -> f32 {
        self.odometry.to_rad()
    }

    /// The fused heading's turn at gyro rate `rate` (rad/s) over `dt_s`, with the
    /// correction towards odometry (at most the whole gap in one step: a time constant
    /// shorter than the step would otherwise overshoot and oscillate).
    fn gyro_turn(&self, rate_radps: f32, dt_s: f32) -> AngleDelta {
        let turn = AngleDelta::from_rad(rate_radps * dt_s);
        let tau = self.config.odometry_blend_time_constant_s;
        if tau > 0.0 {
            let gap = self.odometry.minus(self.fused).to_rad();
            turn.plus(AngleDelta::from_rad(gap * (dt_s / tau).min(1.0)))
        } else {
            turn
        }
    }

    /// The running mean of gyro minus odometry yaw rate, and whether it is beyond the
    /// threshold.
    fn check_disagreement(&mut self, odometry_turn: AngleDelta, gyro_turn: AngleDelta, dt_s: f32) {
        let difference_radps = gyro_turn.minus(odometry_turn).to_rad() / dt_s;
        let window = self.config.disagreement_window_s;
        let k = if window > dt_s { dt_s / window } else { 1.0 };
        let r = &mut self.report;
        r.disagreement_radps += k * (difference_radps - r.disagreement_radps);
        let threshold = self.config.disagreement_threshold_radps;
        let magnitude = math::abs(r.disagreement_radps);
        r.disagrees = if r.disagrees {
            magnitude >= DISAGREEMENT_CLEAR_FRACTION * threshold
        } else {
            magnitude > threshold
        };
    }

    /// Judges `sample` (health, bias) and returns its rate, robot frame, bias removed
    /// (rad/s), if it is usable.
    fn judge(
        &mut self,
        sample: Option<GyroSample>,
        odometry_turn: AngleDelta,
        still: bool,
    ) -> Option<f32> {
        if let GyroHealth::Failed(_) = self.report.health {
            return None;
        }
        let usable = sample.filter(|s| s.age_periods <= self.config.max_age_periods);
        let Some(sample) = usable else {
            if self.report.health == GyroHealth::Reading {
                self.absent_steps = self.absent_steps.saturating_add(1);
                if self.absent_steps >= self.config.absent_limit_steps {
                    self.fail(GyroFailure::Absent);
                }
            }
            return None;
        };
        self.absent_steps = 0;
        let raw = sample.yaw_rate_radps;
        if !raw.is_finite() {
            self.fail(GyroFailure::NonFinite);
            return None;
        }
        if math::abs(raw) >= 0.99 * self.config.full_scale_radps {
            self.fail(GyroFailure::Saturated);
            return None;
        }
        if raw.to_bits() == self.last_bits {
            self.same_count = self.same_count.saturating_add(1);
            self.turn_while_same = self.turn_while_same.plus(odometry_turn);
            if self.same_count >= self.config.stuck_limit_steps
                && math::abs(self.turn_while_same.to_rad()) > self.config.stuck_turn_rad
            {
                self.fail(GyroFailure::Stuck);
                return None;
            }
        } else {
            self.same_count = 0;
            self.turn_while_same = AngleDelta::default();
            self.last_bits = raw.to_bits();
        }
        self.report.health = GyroHealth::Reading;
        let rate = raw * self.config.robot_per_sensor();
        if still {
            self.learn_bias(rate);
        } else {
            self.steady_count = 0;
        }
        let corrected = rate - self.report.bias_radps;
        self.report.yaw_rate_radps = corrected;
        Some(corrected)
    }

    /// One still reading `rate` (robot frame, rad/s) into the bias: the mean of all still
    /// readings so far, then a low-pass of the bias time constant. Once the gate applies
    /// (after [`BIAS_GATE_AFTER_SAMPLES`], or the time constant's count if fewer), a
    /// reading beyond [`BIAS_GATE_RADPS`] of the estimate is left out; one that comes
    /// after [`BIAS_RELEARN_AFTER_STEADY`] steady readings makes their mean the estimate.
    fn learn_bias(&mut self, rate_radps: f32) {
        // The steady spell counts every still reading, inside the gate or not: an offset
        // that moved just past the gate has readings on both sides of it.
        if math::abs(rate_radps - self.steady_mean_radps) <= BIAS_STEADY_BAND_RADPS {
            self.steady_count = self.steady_count.saturating_add(1);
            self.steady_mean_radps +=
                (rate_radps - self.steady_mean_radps) / f32::from(self.steady_count);
        } else {
            self.steady_count = 1;
            self.steady_mean_radps = rate_radps;
        }
        let cap = ((self.config.bias_time_constant_s / self.period_s) as u32).max(1);
        if self.bias_samples >= BIAS_GATE_AFTER_SAMPLES.min(cap)
            && math::abs(rate_radps - self.report.bias_radps) > BIAS_GATE_RADPS
        {
            if self.steady_count >= BIAS_RELEARN_AFTER_STEADY {
                self.report.bias_radps = self.steady_mean_radps;
                self.bias_samples = u32::from(self.steady_count).min(cap);
            }
            return;
        }
        if self.bias_samples < cap {
            self.bias_samples += 1;
        }
        let k = 1.0 / self.bias_samples as f32;
        self.report.bias_radps += k * (rate_radps - self.report.bias_radps);
    }

    fn fail(&mut self, why: GyroFailure) {
        self.report.health = GyroHealth::Failed(why);
        self.report.disagrees = false;
        self.report.disagreement_radps = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_unusable_value_is_refused_by_its_field() {
        assert_eq!(GyroConfig::ICM42688P.validate(), Ok(()));
        type Spoil = fn(&mut GyroConfig);
        let cases: [(Spoil, &str); 10] = [
            (|g| g.scale = f32::NAN, "gyro.scale"),
            (|g| g.scale = 2.01, "gyro.scale"),
            (|g| g.full_scale_radps = 0.0, "gyro.full_scale_radps"),
            (
                |g| g.bias_time_constant_s = -1.0,
                "gyro.bias_time_constant_s",
            ),
            (
                |g| g.odometry_blend_time_constant_s = -0.1,
                "gyro.odometry_blend_time_constant_s",
            ),
            (|g| g.absent_limit_steps = 0, "gyro.absent_limit_steps"),
            (|g| g.stuck_limit_steps = 0, "gyro.stuck_limit_steps"),
            (|g| g.stuck_turn_rad = f32::INFINITY, "gyro.stuck_turn_rad"),
            (
                |g| g.disagreement_threshold_radps = 0.0,
                "gyro.disagreement_threshold_radps",
            ),
            (
                |g| g.disagreement_window_s = 0.0,
                "gyro.disagreement_window_s",
            ),
        ];
        for (spoil, field) in cases {
            let mut g = GyroConfig::ICM42688P;
            spoil(&mut g);
            assert_eq!(g.validate().map_err(|e| e.field()), Err(field));
        }
        // None is the blend's "no correction", and no stuck turn is allowed.
        let mut g = GyroConfig::ICM42688P;
        g.odometry_blend_time_constant_s = 0.0;
        g.stuck_turn_rad = 0.0;
        assert_eq!(g.validate(), Ok(()));
    }

    const PERIOD_S: f32 = 0.001;

    fn fusion(source: HeadingSource) -> HeadingFusion {
        HeadingFusion::new(
            GyroConfig::ICM42688P.with_heading(source),
            PERIOD_S,
            BinaryAngle::default(),
        )
    }

    fn sample(rate: f32) -> Option<GyroSample> {
        Some(GyroSample {
            yaw_rate_radps: rate,
            age_periods: 0,
        })
    }

    /// A reading that alternates by one part in a thousand, as a live sensor's noise does.
    fn live(rate: f32, k: u32) -> Option<GyroSample> {
        sample(rate * (1.0 + 1e-3 * (k % 2) as f32))
    }

    /// A fusion that has read `rate` (rad/s, with a live sensor's noise) `readings` times
    /// while still.
    fn still_at(rate: f32, readings: u32) -> HeadingFusion {
        let mut f = fusion(HeadingSource::Fused);
        for k in 0..readings {
            f.step(live(rate, k), AngleDelta::default(), 1, true);
        }
        f
    }

    #[test]
    fn without_a_gyro_the_heading_is_odometrys() {
        let mut f = fusion(HeadingSource::Fused);
        let turn = AngleDelta::from_rad(0.001);
        for _ in 0..1000 {
            assert_eq!(f.step(None, turn, 1, false), turn);
        }
        assert_eq!(f.report().health, GyroHealth::None);
        assert!(!f.steers());
        assert!((f.fused_heading_rad() - 1.0).abs() < 1e-5);
        assert!((f.odometry_heading_rad() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_bias_is_learned_at_rest_and_removed_in_motion() {
        let mut f = fusion(HeadingSource::Fused);
        let bias = 0.5f32.to_radians();
        // 5 s still: the mean of the readings.
        for k in 0..5000 {
            f.step(live(bias, k), AngleDelta::default(), 1, true);
        }
        assert!((f.report().bias_radps - bias).abs() < 1e-5 * bias.max(1.0) + 1e-5);
        // 1 s turning left at 0.2 rad/s, odometry silent (all slip): the fused heading
        // follows the gyro, counter-clockwise positive.
        for _ in 0..1000 {
            f.step(sample(0.2 + bias), AngleDelta::default(), 1, false);
        }
        assert!(f.steers());
        assert!(
            (f.fused_heading_rad() - 0.2).abs() < 1e-3,
            "{}",
            f.fused_heading_rad()
        );
        assert!(f.odometry_heading_rad().abs() < 1e-9);
    }

    #[test]
    fn an_inverted_axis_and_a_scale_are_applied() {
        let mut config = GyroConfig::ICM42688P.with_heading(HeadingSource::Fused);
        config.axis_inverted = true;
        config.scale = 2.0;
        let mut f = HeadingFusion::new(config, PERIOD_S, BinaryAngle::default());
        for k in 0..1000 {
            f.step(live(-0.1, k), AngleDelta::default(), 1, false);
        }
        // −(−0.1) × 2 = +0.2 rad/s for 1 s.
        assert!(
            (f.fused_heading_rad() - 0.2).abs() < 1e-3,
            "{}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn a_step_of_several_periods_turns_by_the_whole_elapsed_time() {
        let mut f = fusion(HeadingSource::Fused);
        // 500 steps of 2 periods each at 0.2 rad/s: 1 s, 0.2 rad.
        for k in 0..500 {
            f.step(live(0.2, k), AngleDelta::default(), 2, false);
        }
        assert!(
            (f.fused_heading_rad() - 0.2).abs() < 1e-3,
            "{}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn a_step_without_a_new_reading_holds_the_last_rate() {
        let mut f = fusion(HeadingSource::Fused);
        // A reading every other step (a sensor slower than the loop): the steps between
        // turn at the last rate, so 1 s at 0.2 rad/s is still 0.2 rad.
        for k in 0..1000 {
            let reading = if k % 2 == 0 { live(0.2, k / 2) } else { None };
            f.step(reading, AngleDelta::default(), 1, false);
        }
        assert_eq!(f.report().health, GyroHealth::Reading);
        assert!(
            (f.fused_heading_rad() - 0.2).abs() < 1e-3,
            "{}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn a_new_configuration_takes_effect_and_keeps_the_heading() {
        let mut f = fusion(HeadingSource::Fused);
        for k in 0..1000 {
            f.step(live(0.1, k), AngleDelta::default(), 1, false);
        }
        let mut config = *f.config();
        config.scale = 2.0;
        f.set_config(config);
        assert_eq!(f.config().scale, 2.0);
        // 0.1 rad from the first second, then 1 s at 0.1 × 2 rad/s.
        for k in 0..1000 {
            f.step(live(0.1, k), AngleDelta::default(), 1, false);
        }
        assert!(
            (f.fused_heading_rad() - 0.3).abs() < 1e-3,
            "{}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn a_turn_the_encoders_do_not_see_is_not_learned_as_bias() {
        let mut f = fusion(HeadingSource::Fused);
        // A turn-on offset beyond the gate, learned from the first readings.
        for k in 0..BIAS_GATE_AFTER_SAMPLES {
            f.step(live(0.08, k), AngleDelta::default(), 1, true);
        }
        let learned = f.report().bias_radps;
        assert!((learned - 0.08).abs() < 1e-4, "{learned}");
        // Lifted and turned at 0.2 rad/s, the wheels still: not the bias.
        for k in 0..100 {
            f.step(live(0.08 + 0.2, k), AngleDelta::default(), 1, true);
        }
        assert_eq!(f.report().bias_radps, learned);
        // A reading just inside the gate is learned.
        f.step(sample(0.08 + 0.009), AngleDelta::default(), 1, true);
        assert!(f.report().bias_radps > learned);
    }

    #[test]
    fn an_estimate_the_gate_keeps_refusing_is_learned_again_from_steady_readings() {
        // Learned while the robot was turned unseen at 0.3 rad/s.
        let mut f = still_at(0.3, 1000);
        // Still now, the sensor steady at 0.01 rad/s: left out for just under a second,
        // then their mean is the estimate.
        let steady = u32::from(BIAS_RELEARN_AFTER_STEADY) - 1;
        for k in 0..steady {
            f.step(live(0.01, k), AngleDelta::default(), 1, true);
        }
        assert!((f.report().bias_radps - 0.3).abs() < 1e-3);
        f.step(sample(0.01), AngleDelta::default(), 1, true);
        let relearned = f.report().bias_radps;
        assert!((relearned - 0.010_005).abs() < 1e-6, "{relearned}");
        // Gated from it at once: a turn now is not learned.
        f.step(sample(0.5), AngleDelta::default(), 1, true);
        assert_eq!(f.report().bias_radps, relearned);
    }

    #[test]
    fn a_robot_carried_and_turned_with_its_wheels_still_never_becomes_the_bias() {
        let mut f = still_at(0.01, 5000);
        let learned = f.report().bias_radps;
        // Five seconds turned by hand at about 0.5 rad/s, wavering by ±0.02 rad/s (a hand
        // holds no rate steadier): each reading is left out.
        for k in 0..5000u32 {
            let waver = 0.02 * math::sin(k as f32 * 0.05);
            f.step(sample(0.5 + waver), AngleDelta::default(), 1, true);
        }
        assert_eq!(f.report().bias_radps, learned);
        // A steady reading just outside the band of the last ones restarts the count.
        let mut g = still_at(0.01, 1000);
        let before = g.report().bias_radps;
        for k in 0..2 * u32::from(BIAS_RELEARN_AFTER_STEADY) {
            let jump = if k % 600 == 599 { 0.006 } else { 0.0 };
            g.step(sample(0.3 + jump), AngleDelta::default(), 1, true);
        }
        assert_eq!(g.report().bias_radps, before);
    }

    #[test]
    fn an_offset_that_moved_just_past_the_gate_is_learned_within_a_second() {
        let mut f = still_at(0.001, 5000);
        // The offset moves by just over the gate; the sensor's noise (±0.0011 rad/s)
        // puts every other reading inside the gate.
        let moved = 0.001 + BIAS_GATE_RADPS + 0.0005;
        for k in 0..1100u32 {
            let noise = if k % 2 == 0 { 0.0011 } else { -0.0011 };
            f.step(sample(moved + noise), AngleDelta::default(), 1, true);
        }
        let bias = f.report().bias_radps;
        assert!((bias - moved).abs() < 2e-4, "{bias}");
    }

    #[test]
    fn a_new_calibration_ends_a_steady_spell() {
        let mut f = still_at(0.3, 1000);
        let half = u32::from(BIAS_RELEARN_AFTER_STEADY) / 2 + 1;
        for _ in 0..half {
            f.step(sample(0.01), AngleDelta::default(), 1, true);
        }
        let mut config = *f.config();
        config.scale = 1.0 + 1e-6;
        f.set_config(config);
        for _ in 0..half {
            f.step(sample(0.01), AngleDelta::default(), 1, true);
        }
        assert!((f.report().bias_radps - 0.3).abs() < 1e-3);
    }

    #[test]
    fn a_step_that_is_not_still_ends_a_steady_spell() {
        let mut f = still_at(0.01, 1000);
        let before = f.report().bias_radps;
        let half = u32::from(BIAS_RELEARN_AFTER_STEADY) / 2 + 1;
        for still in [true, false, true] {
            for _ in 0..half {
                f.step(sample(0.3), AngleDelta::default(), 1, still);
            }
        }
        assert_eq!(f.report().bias_radps, before);
    }

    #[test]
    fn the_gate_applies_from_the_time_constants_count_when_that_is_shorter() {
        // A time constant of 0.1 s: the gate applies after 100 readings, not 200.
        let mut config = GyroConfig::ICM42688P.with_heading(HeadingSource::Fused);
        config.bias_time_constant_s = 0.1;
        let mut f = HeadingFusion::new(config, PERIOD_S, BinaryAngle::default());
        for k in 0..100 {
            f.step(live(0.01, k), AngleDelta::default(), 1, true);
        }
        let learned = f.report().bias_radps;
        f.step(sample(0.5), AngleDelta::default(), 1, true);
        assert_eq!(f.report().bias_radps, learned);
    }

    #[test]
    fn the_bias_averages_at_most_its_time_constant_of_readings() {
        // A time constant of 3 periods: the mean of the first three readings, then a
        // low-pass of gain 1/3.
        let mut config = GyroConfig::ICM42688P.with_heading(HeadingSource::Fused);
        config.bias_time_constant_s = 3.0 * PERIOD_S;
        let mut f = HeadingFusion::new(config, PERIOD_S, BinaryAngle::default());
        for rate in [0.003, 0.0, 0.0] {
            f.step(sample(rate), AngleDelta::default(), 1, true);
        }
        assert!((f.report().bias_radps - 0.001).abs() < 1e-9);
        f.step(sample(0.010), AngleDelta::default(), 1, true);
        assert!(
            (f.report().bias_radps - 0.004).abs() < 1e-7,
            "{}",
            f.report().bias_radps
        );
    }

    #[test]
    fn a_new_calibration_converts_the_bias_to_the_robots_frame() {
        let mut f = fusion(HeadingSource::Fused);
        // A sensor reading 0.01 rad/s at rest: the bias, learned still.
        for k in 0..1000 {
            f.step(live(0.01, k), AngleDelta::default(), 1, true);
        }
        assert!((f.report().bias_radps - 0.01).abs() < 1e-5);
        // Bring-up finds the axis upside down and the scale 2: the same sensor bias is
        // −0.02 rad/s in the robot's frame, so the still sensor still reads no turn.
        let mut config = *f.config();
        config.axis_inverted = true;
        config.scale = 2.0;
        f.set_config(config);
        assert!(
            (f.report().bias_radps + 0.02).abs() < 2e-5,
            "{}",
            f.report().bias_radps
        );
        let before = f.fused_heading_rad();
        for k in 0..1000 {
            f.step(live(0.01, k), AngleDelta::default(), 1, false);
        }
        assert!((f.fused_heading_rad() - before).abs() < 1e-4);
        // And back: the bias is the sensor's again.
        f.set_config(GyroConfig::ICM42688P.with_heading(HeadingSource::Fused));
        assert!(
            (f.report().bias_radps - 0.01).abs() < 1e-5,
            "{}",
            f.report().bias_radps
        );
    }

    #[test]
    fn the_blend_pulls_the_fused_heading_towards_odometrys() {
        let mut config = GyroConfig::ICM42688P.with_heading(HeadingSource::Fused);
        config.odometry_blend_time_constant_s = 1.0;
        let mut f = HeadingFusion::new(config, PERIOD_S, BinaryAngle::default());
        // The gyro reads (almost) no turn while odometry says 0.5 rad at once: 5 time
        // constants later the fused heading has come most of the way (1 − e⁻⁵ ≈ 99 %),
        // never past.
        let mut turn = AngleDelta::from_rad(0.5);
        for k in 0..5000 {
            f.step(sample(1e-6 * (k % 2) as f32), turn, 1, false);
            turn = AngleDelta::default();
            assert!(f.fused_heading_rad() <= 0.5 + 1e-6);
        }
        assert!(
            (f.fused_heading_rad() - 0.5).abs() < 0.01,
            "{}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn a_persistent_disagreement_is_reported_and_agreement_is_not() {
        let mut f = fusion(HeadingSource::Fused);
        let odometry_turn = AngleDelta::from_rad(0.1 * PERIOD_S);
        // Both at 0.1 rad/s for 20 s: no disagreement.
        for k in 0..20_000 {
            f.step(live(0.1, k), odometry_turn, 1, false);
        }
        assert!(!f.report().disagrees, "{}", f.report().disagreement_radps);
        assert!(f.report().disagreement_radps.abs() < 0.01);
        // The gyro at 0.2 rad/s, odometry still at 0.1, for 30 s (three windows):
        // 0.1 rad/s apart, beyond the 0.03 rad/s threshold, gyro above odometry.
        for k in 0..30_000 {
            f.step(live(0.2, k), odometry_turn, 1, false);
        }
        assert!(f.report().disagrees);
        assert!(
            (f.report().disagreement_radps - 0.1).abs() < 0.01,
            "{}",
            f.report().disagreement_radps
        );
        // Agreeing again: the spell lasts while the mean decays to 0.8 × 0.03 rad/s,
        // (0.1 → 0.024 rad/s: 10 s · ln(0.1 / 0.024) ≈ 14.3 s), and not beyond.
        for k in 0..13_000 {
            f.step(live(0.1, k), odometry_turn, 1, false);
        }
        assert!(f.report().disagrees, "{}", f.report().disagreement_radps);
        for k in 0..3_000 {
            f.step(live(0.1, k), odometry_turn, 1, false);
        }
        assert!(!f.report().disagrees, "{}", f.report().disagreement_radps);
    }

    /// The k-th reading of a test's gyro.
    type Reading = fn(u32) -> Option<GyroSample>;

    #[test]
    fn a_failed_gyro_hands_the_heading_back_to_odometry() {
        let turn = AngleDelta::from_rad(1e-4);
        let cases: [(GyroFailure, Reading); 4] = [
            (GyroFailure::NonFinite, |_| sample(f32::NAN)),
            (GyroFailure::Saturated, |_| sample(40.0)),
            (GyroFailure::Stuck, |_| sample(0.3)),
            (GyroFailure::Absent, |_| None),
        ];
        for (failure, reading) in cases {
            let mut f = fusion(HeadingSource::Fused);
            for k in 0..10 {
                f.step(live(0.1, k), turn, 1, false);
            }
            assert!(f.steers());
            // Odometry turns 0.1 rad/s meanwhile: 200 steps turn 0.02 rad, beyond the
            // stuck check's 0.01 rad.
            for k in 0..300 {
                f.step(reading(k), turn, 1, false);
            }
            assert_eq!(f.report().health, GyroHealth::Failed(failure));
            assert!(!f.steers());
            assert_eq!(f.step(reading(0), turn, 1, false), turn, "{failure:?}");
            f.clear_failure();
            f.step(live(0.1, 1), turn, 1, false);
            assert!(
                f.steers(),
                "{failure:?}: tried again after the faults are cleared"
            );
        }
    }

    #[test]
    fn the_blend_comes_1_minus_1_over_e_of_the_way_in_one_time_constant() {
        let mut config = GyroConfig::ICM42688P.with_heading(HeadingSource::Fused);
        config.odometry_blend_time_constant_s = 0.25;
        let mut f = HeadingFusion::new(config, PERIOD_S, BinaryAngle::default());
        let mut turn = AngleDelta::from_rad(0.5);
        for k in 0..250 {
            f.step(sample(1e-6 * (k % 2) as f32), turn, 1, false);
            turn = AngleDelta::default();
        }
        let expected = 0.5 * (1.0 - (-1.0f32).exp());
        assert!(
            (f.fused_heading_rad() - expected).abs() < 0.005,
            "{} vs {expected}",
            f.fused_heading_rad()
        );
    }

    #[test]
    fn saturation_is_judged_at_99_percent_of_full_scale() {
        let full_scale = GyroConfig::ICM42688P.full_scale_radps;
        let mut f = fusion(HeadingSource::Fused);
        f.step(sample(0.985 * full_scale), AngleDelta::default(), 1, false);
        assert_eq!(f.report().health, GyroHealth::Reading);
        f.step(sample(-0.995 * full_scale), AngleDelta::default(), 1, false);
        assert_eq!(
            f.report().health,
            GyroHealth::Failed(GyroFailure::Saturated)
        );
    }

    #[test]
    fn a_gyro_is_stuck_at_exactly_its_limit_of_repeats() {
        let limit = GyroConfig::ICM42688P.stuck_limit_steps;
        let mut f = fusion(HeadingSource::Fused);
        // Odometry turns 0.1 rad a step, far beyond the stuck turn, from the first repeat.
        let turn = AngleDelta::from_rad(0.1);
        f.step(sample(0.3), turn, 1, false);
        for _ in 1..limit {
            f.step(sample(0.3), turn, 1, false);
        }
        assert_eq!(
            f.report().health,
            GyroHealth::Reading,
            "{} repeats",
            limit - 1
        );
        f.step(sample(0.3), turn, 1, false);
        assert_eq!(f.report().health, GyroHealth::Failed(GyroFailure::Stuck));
    }

    #[test]
    fn the_bias_is_the_mean_of_the_still_readings() {
        let mut f = fusion(HeadingSource::Fused);
        for k in 0..1000 {
            let rate = if k % 2 == 0 { 0.015 } else { 0.025 };
            f.step(sample(rate), AngleDelta::default(), 1, true);
        }
        let bias = f.report().bias_radps;
        assert!((bias - 0.02).abs() < 1e-4, "{bias}");
    }

    #[test]
    fn a_stuck_reading_at_rest_is_not_a_failure() {
        let mut f = fusion(HeadingSource::Fused);
        for _ in 0..5000 {
            f.step(sample(0.0), AngleDelta::default(), 1, true);
        }
        assert_eq!(f.report().health, GyroHealth::Reading);
    }

    #[test]
    fn disagreement_is_the_running_mean_of_gyro_minus_odometry() {
        let mut f = fusion(HeadingSource::Odometry);
        // The gyro says 0.2 rad/s, odometry 0.1 rad/s (a wheel slipping), for 30 s: the
        // running mean approaches +0.1 rad/s, beyond the threshold.
        for k in 0..30_000 {
            f.step(live(0.2, k), AngleDelta::from_rad(1e-4), 1, false);
        }
        let r = f.report();
        assert!(
            (r.disagreement_radps - 0.1).abs() < 0.01,
            "{}",
            r.disagreement_radps
        );
        assert!(r.disagrees);
        // The pose command resets it with the heading; the bias stays.
        f.set_heading(BinaryAngle::default());
        assert!(!f.report().disagrees);
    }
}
