//! One source of truth for the robot: geometry, encoder, rates, limits and gains.
//!
//! Fill a [`RobotConfig`] (plain data, SI units in every name) and turn it into validated
//! [`Params`] with [`Params::new`]. The firmware and the simulator both do exactly that;
//! nothing else in the core takes raw numbers.

use core::f32::consts::TAU;
use core::fmt;

use crate::encoder::MAX_SPEED_WINDOW_STEPS;
use crate::kinematics::{DiffDrive, GeometryError};
use crate::law::{KanayamaGains, LawGains, PaperGains, TrackingGains};
use crate::limits::Limits;
use crate::pid::PidGains;

/// Upper bound of [`Params::max_ticks_per_step`]: 2²⁴, exact in `f32`, and 64 of them fit
/// an `i32` sum.
pub const MAX_TICKS_PER_STEP: i32 = 1 << 24;

/// Continuous-time gains of the per-wheel speed PID. Error in rad/s, output in duty
/// (−1…1 of the supply voltage).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelPidConfig {
    /// K_p, duty per rad/s of wheel-speed error.
    pub kp_duty_per_rad_s: f32,
    /// Integral time T_i, s (0 disables the integral).
    pub ti_s: f32,
    /// Derivative time T_d, s (0 disables the derivative).
    pub td_s: f32,
    /// Time constant of the D-term filter, s (0 for no filter).
    pub d_filter_tau_s: f32,
    /// Feed-forward, duty per rad/s of wheel-speed set-point (≈ 1 / no-load speed at full
    /// duty).
    pub feed_forward_duty_per_rad_s: f32,
}

/// Everything the controller needs to know about the robot, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct RobotConfig {
    /// Wheel radius R, m.
    pub wheel_radius_m: f32,
    /// Track width L (distance between the wheels' contact points), m.
    pub track_width_m: f32,
    /// Encoder lines (pulses per channel) per motor-shaft revolution; ×4 for quadrature.
    pub encoder_lines_per_motor_rev: u32,
    /// Gearbox ratio: motor revolutions per wheel revolution.
    pub gear_ratio: f32,
    /// Rate of the inner (wheel-speed) loop, Hz.
    pub control_rate_hz: u32,
    /// The steering law runs every this many inner steps.
    pub steering_divider: u32,
    /// Steps averaged by the wheel-speed estimate (1…64).
    pub speed_window_steps: u32,
    /// Command limits.
    pub limits: Limits,
    /// Fastest plausible wheel speed, rad/s: a tick delta implying more than this in one
    /// step is an encoder fault (motors stop).
    pub max_plausible_wheel_speed_rad_s: f32,
    /// Wheel-speed PID gains.
    pub wheel_pid: WheelPidConfig,
    /// Steering-law gains.
    pub law: LawGains,
}

impl RobotConfig {
    /// The reference robot: 65 mm wheels, 150 mm track, 12-line encoders on 6 V gear motors
    /// with a 1:30 gearbox (1440 ticks per wheel revolution), 1 kHz wheel loop, 100 Hz
    /// steering, 1 m/s rim-speed cap. Gains tuned in `host-sim` against that robot: the
    /// wheel PID (K_p = 0.15 duty/(rad/s), T_i = 30 ms, feed-forward 1/40 duty/(rad/s))
    /// takes a wheel from 0 to 15 rad/s in 41 ms (10→90 %) with 0.2 % overshoot.
    pub const REFERENCE_ROBOT: RobotConfig = RobotConfig {
        wheel_radius_m: 0.0325,
        track_width_m: 0.15,
        encoder_lines_per_motor_rev: 12,
        gear_ratio: 30.0,
        control_rate_hz: 1000,
        steering_divider: 10,
        speed_window_steps: 20,
        limits: Limits {
            max_rim_speed_m_s: 1.0,
            max_linear_accel_m_s2: 3.0,
            max_angular_accel_rad_s2: 30.0,
        },
        max_plausible_wheel_speed_rad_s: 100.0,
        wheel_pid: WheelPidConfig {
            kp_duty_per_rad_s: 0.15,
            ti_s: 0.03,
            td_s: 0.0,
            d_filter_tau_s: 0.0,
            feed_forward_duty_per_rad_s: 0.025,
        },
        law: LawGains {
            paper: PaperGains {
                gamma: 1.0,
                k: 2.0,
                h: 1.0,
                lambda: 1.0,
            },
            tracking: TrackingGains {
                lambda: 64.0,
                k_x: 3.0,
                k_theta: 4.0,
            },
            kanayama: KanayamaGains {
                k_x: 3.0,
                k_y: 64.0,
                k_theta: 16.0,
            },
        },
    };
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self::REFERENCE_ROBOT
    }
}

/// Why a [`RobotConfig`] was rejected. Each variant carries the offending value;
/// [`ParamError::field`] names the field (its path in [`RobotConfig`]) and `Display` prints
/// both, e.g. `wheel_radius_m must be > 0, got -0.03`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// `wheel_radius_m` was ≤ 0 or not finite.
    NonPositiveWheelRadius(f32),
    /// `track_width_m` was ≤ 0 or not finite.
    NonPositiveTrackWidth(f32),
    /// `encoder_lines_per_motor_rev` was 0.
    NonPositiveCountsPerRev,
    /// `gear_ratio` was ≤ 0 or not finite.
    NonPositiveGearRatio(f32),
    /// `control_rate_hz` was 0.
    ZeroControlRate,
    /// `steering_divider` was 0.
    ZeroSteeringDivider,
    /// `speed_window_steps` was outside 1…64.
    SpeedWindowOutOfRange(u32),
    /// A limit was ≤ 0 or not finite.
    NonPositiveLimit {
        /// The field, e.g. `limits.max_rim_speed_m_s`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A gain or a PID time was NaN or infinite.
    NonFiniteGain {
        /// The field, e.g. `law.tracking.k_theta`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A steering-law gain was ≤ 0.
    NonPositiveGain {
        /// The field, e.g. `law.paper.gamma`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A PID time constant was < 0.
    NegativeTime {
        /// The field, e.g. `wheel_pid.ti_s`.
        field: &'static str,
        /// Its value, s.
        value: f32,
    },
}

impl ParamError {
    /// The offending field's path in [`RobotConfig`], e.g. `law.paper.gamma`.
    pub const fn field(&self) -> &'static str {
        match self {
            ParamError::NonPositiveWheelRadius(_) => "wheel_radius_m",
            ParamError::NonPositiveTrackWidth(_) => "track_width_m",
            ParamError::NonPositiveCountsPerRev => "encoder_lines_per_motor_rev",
            ParamError::NonPositiveGearRatio(_) => "gear_ratio",
            ParamError::ZeroControlRate => "control_rate_hz",
            ParamError::ZeroSteeringDivider => "steering_divider",
            ParamError::SpeedWindowOutOfRange(_) => "speed_window_steps",
            ParamError::NonPositiveLimit { field, .. }
            | ParamError::NonFiniteGain { field, .. }
            | ParamError::NonPositiveGain { field, .. }
            | ParamError::NegativeTime { field, .. } => field,
        }
    }

    /// What the field must satisfy, e.g. `must be > 0`.
    pub const fn requirement(&self) -> &'static str {
        match self {
            ParamError::NonFiniteGain { .. } => "must be finite",
            ParamError::NegativeTime { .. } => "must be ≥ 0",
            ParamError::SpeedWindowOutOfRange(_) => "must be in 1..=64",
            _ => "must be > 0",
        }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}, got ", self.field(), self.requirement())?;
        match *self {
            ParamError::NonPositiveWheelRadius(v)
            | ParamError::NonPositiveTrackWidth(v)
            | ParamError::NonPositiveGearRatio(v)
            | ParamError::NonPositiveLimit { value: v, .. }
            | ParamError::NonFiniteGain { value: v, .. }
            | ParamError::NonPositiveGain { value: v, .. }
            | ParamError::NegativeTime { value: v, .. } => write!(f, "{v}"),
            ParamError::SpeedWindowOutOfRange(v) => write!(f, "{v}"),
            ParamError::NonPositiveCountsPerRev
            | ParamError::ZeroControlRate
            | ParamError::ZeroSteeringDivider => f.write_str("0"),
        }
    }
}

/// A validated [`RobotConfig`] with the quantities derived from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    config: RobotConfig,
    geometry: DiffDrive,
    rad_per_tick: f32,
    period_s: f32,
    wheel_pid: PidGains,
    max_ticks_per_step: i32,
}

fn positive_limit(value: f32, field: &'static str) -> Result<(), ParamError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonPositiveLimit { field, value })
    }
}

fn finite_gain(value: f32, field: &'static str) -> Result<(), ParamError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonFiniteGain { field, value })
    }
}

fn time_constant(value: f32, field: &'static str) -> Result<(), ParamError> {
    finite_gain(value, field)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::NegativeTime { field, value })
    }
}

impl Params {
    /// Validates `config` and derives ticks per revolution, the period and discrete gains.
    pub fn new(config: RobotConfig) -> Result<Self, ParamError> {
        let geometry =
            DiffDrive::new(config.wheel_radius_m, config.track_width_m).map_err(|e| match e {
                GeometryError::NonPositiveWheelRadius => {
                    ParamError::NonPositiveWheelRadius(config.wheel_radius_m)
                }
                GeometryError::NonPositiveTrackWidth => {
                    ParamError::NonPositiveTrackWidth(config.track_width_m)
                }
            })?;
        if config.encoder_lines_per_motor_rev == 0 {
            return Err(ParamError::NonPositiveCountsPerRev);
        }
        if !(config.gear_ratio > 0.0 && config.gear_ratio.is_finite()) {
            return Err(ParamError::NonPositiveGearRatio(config.gear_ratio));
        }
        if config.control_rate_hz == 0 {
            return Err(ParamError::ZeroControlRate);
        }
        if config.steering_divider == 0 {
            return Err(ParamError::ZeroSteeringDivider);
        }
        if config.speed_window_steps == 0
            || config.speed_window_steps as usize > MAX_SPEED_WINDOW_STEPS
        {
            return Err(ParamError::SpeedWindowOutOfRange(config.speed_window_steps));
        }
        let l = &config.limits;
        positive_limit(l.max_rim_speed_m_s, "limits.max_rim_speed_m_s")?;
        positive_limit(l.max_linear_accel_m_s2, "limits.max_linear_accel_m_s2")?;
        positive_limit(
            l.max_angular_accel_rad_s2,
            "limits.max_angular_accel_rad_s2",
        )?;
        positive_limit(
            config.max_plausible_wheel_speed_rad_s,
            "max_plausible_wheel_speed_rad_s",
        )?;
        let p = &config.wheel_pid;
        finite_gain(p.kp_duty_per_rad_s, "wheel_pid.kp_duty_per_rad_s")?;
        finite_gain(
            p.feed_forward_duty_per_rad_s,
            "wheel_pid.feed_forward_duty_per_rad_s",
        )?;
        time_constant(p.ti_s, "wheel_pid.ti_s")?;
        time_constant(p.td_s, "wheel_pid.td_s")?;
        time_constant(p.d_filter_tau_s, "wheel_pid.d_filter_tau_s")?;
        config.law.validate()?;

        let ticks_per_rev = config.encoder_lines_per_motor_rev as f32 * 4.0 * config.gear_ratio;
        let rad_per_tick = TAU / ticks_per_rev;
        let period_s = 1.0 / config.control_rate_hz as f32;
        let wheel_pid = PidGains::from_continuous(
            p.kp_duty_per_rad_s,
            p.ti_s,
            p.td_s,
            p.d_filter_tau_s,
            p.feed_forward_duty_per_rad_s,
            period_s,
        );
        // Finite continuous gains can still overflow when discretised (huge K_p·T_d/T).
        finite_gain(wheel_pid.ki, "wheel_pid.ti_s")?;
        finite_gain(wheel_pid.kd, "wheel_pid.td_s")?;
        // Ticks in one step at the fastest plausible speed, with a factor-2 margin, at
        // least 2 so a single noisy edge is never a fault.
        let max_ticks = 2.0 * config.max_plausible_wheel_speed_rad_s * period_s / rad_per_tick;
        // Capped at 2²⁴ so that tick sums stay exact in i32 and in f32.
        let max_ticks_per_step = if max_ticks >= MAX_TICKS_PER_STEP as f32 {
            MAX_TICKS_PER_STEP
        } else {
            (max_ticks as i32).max(2)
        };
        Ok(Self {
            config,
            geometry,
            rad_per_tick,
            period_s,
            wheel_pid,
            max_ticks_per_step,
        })
    }

    /// The configuration these parameters were built from.
    pub const fn config(&self) -> &RobotConfig {
        &self.config
    }

    /// Robot geometry (R, L).
    pub const fn geometry(&self) -> DiffDrive {
        self.geometry
    }

    /// Wheel rotation per encoder tick, rad (2π / (lines × 4 × gear)).
    pub const fn rad_per_tick(&self) -> f32 {
        self.rad_per_tick
    }

    /// Encoder ticks per wheel revolution (lines × 4 × gear).
    pub fn ticks_per_wheel_rev(&self) -> f32 {
        TAU / self.rad_per_tick
    }

    /// Period T of the inner loop, s.
    pub const fn period_s(&self) -> f32 {
        self.period_s
    }

    /// Period of the steering loop, s.
    pub fn steering_period_s(&self) -> f32 {
        self.period_s * self.config.steering_divider as f32
    }

    /// Discrete wheel PID gains for the inner period.
    pub const fn wheel_pid(&self) -> PidGains {
        self.wheel_pid
    }

    /// Largest |tick delta| per step accepted before an encoder fault.
    pub const fn max_ticks_per_step(&self) -> i32 {
        self.max_ticks_per_step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(f: impl FnOnce(&mut RobotConfig)) -> Result<Params, ParamError> {
        let mut c = RobotConfig::REFERENCE_ROBOT;
        f(&mut c);
        Params::new(c)
    }

    #[test]
    fn reference_robot_is_valid_with_expected_derived_values() {
        let p = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        assert!((p.ticks_per_wheel_rev() - 1440.0).abs() < 1e-3);
        assert!((p.period_s() - 1e-3).abs() < 1e-9);
        assert!((p.steering_period_s() - 1e-2).abs() < 1e-8);
        // K_i = K_p T / T_i = 0.15 · 0.001 / 0.03.
        assert!((p.wheel_pid().ki - 5e-3).abs() < 1e-8);
        // 2 × 100 rad/s × 1 ms / (2π/1440) = 45.8 ticks.
        assert_eq!(p.max_ticks_per_step(), 45);
    }

    #[test]
    fn each_bad_field_has_its_own_error() {
        use ParamError::*;
        assert_eq!(
            with(|c| c.wheel_radius_m = -0.03),
            Err(NonPositiveWheelRadius(-0.03))
        );
        assert_eq!(
            with(|c| c.track_width_m = 0.0),
            Err(NonPositiveTrackWidth(0.0))
        );
        assert_eq!(
            with(|c| c.encoder_lines_per_motor_rev = 0),
            Err(NonPositiveCountsPerRev)
        );
        assert_eq!(
            with(|c| c.gear_ratio = -30.0),
            Err(NonPositiveGearRatio(-30.0))
        );
        assert_eq!(with(|c| c.control_rate_hz = 0), Err(ZeroControlRate));
        assert_eq!(with(|c| c.steering_divider = 0), Err(ZeroSteeringDivider));
        assert_eq!(
            with(|c| c.speed_window_steps = 65),
            Err(SpeedWindowOutOfRange(65))
        );
        assert_eq!(
            with(|c| c.limits.max_rim_speed_m_s = f32::INFINITY),
            Err(NonPositiveLimit {
                field: "limits.max_rim_speed_m_s",
                value: f32::INFINITY
            })
        );
        assert_eq!(
            with(|c| c.wheel_pid.ti_s = -1.0),
            Err(NegativeTime {
                field: "wheel_pid.ti_s",
                value: -1.0
            })
        );
        assert_eq!(
            with(|c| c.law.tracking.k_theta = f32::INFINITY),
            Err(NonFiniteGain {
                field: "law.tracking.k_theta",
                value: f32::INFINITY
            })
        );
        assert_eq!(
            with(|c| c.law.paper.gamma = 0.0),
            Err(NonPositiveGain {
                field: "law.paper.gamma",
                value: 0.0
            })
        );
        // NaN compares unequal, so check the variant and field.
        let nan = with(|c| c.wheel_pid.kp_duty_per_rad_s = f32::NAN).unwrap_err();
        assert!(matches!(nan, NonFiniteGain { .. }));
        assert_eq!(nan.field(), "wheel_pid.kp_duty_per_rad_s");
        assert_eq!(
            with(|c| c.gear_ratio = f32::NAN).unwrap_err().field(),
            "gear_ratio"
        );
    }

    #[test]
    fn errors_print_the_field_the_rule_and_the_value() {
        let e = with(|c| c.wheel_radius_m = -0.03).unwrap_err();
        assert_eq!(format!("{e}"), "wheel_radius_m must be > 0, got -0.03");
        let e = with(|c| c.speed_window_steps = 0).unwrap_err();
        assert_eq!(
            format!("{e}"),
            "speed_window_steps must be in 1..=64, got 0"
        );
        let e = with(|c| c.law.kanayama.k_y = -2.0).unwrap_err();
        assert_eq!(format!("{e}"), "law.kanayama.k_y must be > 0, got -2");
    }
}
