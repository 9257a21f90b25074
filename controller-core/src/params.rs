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
    /// steering, 1 m/s rim-speed cap. Gains tuned in `host-sim` against that robot.
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
            kp_duty_per_rad_s: 0.05,
            ti_s: 0.1,
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

/// Why a [`RobotConfig`] was rejected. Each names the offending field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// `wheel_radius_m` was ≤ 0 or not finite.
    NonPositiveWheelRadius,
    /// `track_width_m` was ≤ 0 or not finite.
    NonPositiveTrackWidth,
    /// `encoder_lines_per_motor_rev` was 0 or `gear_ratio` ≤ 0 or not finite.
    NonPositiveCountsPerRev,
    /// `control_rate_hz` was 0.
    ZeroControlRate,
    /// `steering_divider` was 0.
    ZeroSteeringDivider,
    /// `speed_window_steps` was outside 1…64.
    SpeedWindowOutOfRange,
    /// The named limit was ≤ 0 or not finite.
    NonPositiveLimit(&'static str),
    /// The named gain was not finite (or, for a law gain, not > 0; for a PID time, < 0).
    NonFiniteGain(&'static str),
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::NonPositiveWheelRadius => f.write_str("wheel_radius_m must be > 0"),
            ParamError::NonPositiveTrackWidth => f.write_str("track_width_m must be > 0"),
            ParamError::NonPositiveCountsPerRev => {
                f.write_str("encoder_lines_per_motor_rev and gear_ratio must be > 0")
            }
            ParamError::ZeroControlRate => f.write_str("control_rate_hz must be > 0"),
            ParamError::ZeroSteeringDivider => f.write_str("steering_divider must be > 0"),
            ParamError::SpeedWindowOutOfRange => {
                write!(
                    f,
                    "speed_window_steps must be in 1..={MAX_SPEED_WINDOW_STEPS}"
                )
            }
            ParamError::NonPositiveLimit(name) => write!(f, "{name} must be > 0 and finite"),
            ParamError::NonFiniteGain(name) => write!(f, "gain {name} is out of range"),
        }
    }
}

impl From<GeometryError> for ParamError {
    fn from(e: GeometryError) -> Self {
        match e {
            GeometryError::NonPositiveWheelRadius => ParamError::NonPositiveWheelRadius,
            GeometryError::NonPositiveTrackWidth => ParamError::NonPositiveTrackWidth,
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

fn positive(value: f32, name: &'static str) -> Result<(), ParamError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonPositiveLimit(name))
    }
}

fn finite_non_negative(value: f32, name: &'static str) -> Result<(), ParamError> {
    if value >= 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonFiniteGain(name))
    }
}

impl Params {
    /// Validates `config` and derives ticks per revolution, the period and discrete gains.
    pub fn new(config: RobotConfig) -> Result<Self, ParamError> {
        let geometry = DiffDrive::new(config.wheel_radius_m, config.track_width_m)?;
        if config.encoder_lines_per_motor_rev == 0
            || !(config.gear_ratio > 0.0 && config.gear_ratio.is_finite())
        {
            return Err(ParamError::NonPositiveCountsPerRev);
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
            return Err(ParamError::SpeedWindowOutOfRange);
        }
        let l = &config.limits;
        positive(l.max_rim_speed_m_s, "limits.max_rim_speed_m_s")?;
        positive(l.max_linear_accel_m_s2, "limits.max_linear_accel_m_s2")?;
        positive(
            l.max_angular_accel_rad_s2,
            "limits.max_angular_accel_rad_s2",
        )?;
        positive(
            config.max_plausible_wheel_speed_rad_s,
            "max_plausible_wheel_speed_rad_s",
        )?;
        let p = &config.wheel_pid;
        if !p.kp_duty_per_rad_s.is_finite() {
            return Err(ParamError::NonFiniteGain("wheel_pid.kp_duty_per_rad_s"));
        }
        if !p.feed_forward_duty_per_rad_s.is_finite() {
            return Err(ParamError::NonFiniteGain(
                "wheel_pid.feed_forward_duty_per_rad_s",
            ));
        }
        finite_non_negative(p.ti_s, "wheel_pid.ti_s")?;
        finite_non_negative(p.td_s, "wheel_pid.td_s")?;
        finite_non_negative(p.d_filter_tau_s, "wheel_pid.d_filter_tau_s")?;
        if let Some(name) = config.law.first_invalid() {
            return Err(ParamError::NonFiniteGain(name));
        }

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
        if !wheel_pid.is_valid() {
            return Err(ParamError::NonFiniteGain("wheel_pid"));
        }
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
        // K_i = K_p T / T_i = 0.05 · 0.001 / 0.1.
        assert!((p.wheel_pid().ki - 5e-4).abs() < 1e-9);
        // 2 × 100 rad/s × 1 ms / (2π/1440) = 45.8 ticks.
        assert_eq!(p.max_ticks_per_step(), 45);
    }

    #[test]
    fn each_bad_field_has_its_own_error() {
        assert_eq!(
            with(|c| c.wheel_radius_m = -0.03),
            Err(ParamError::NonPositiveWheelRadius)
        );
        assert_eq!(
            with(|c| c.track_width_m = 0.0),
            Err(ParamError::NonPositiveTrackWidth)
        );
        assert_eq!(
            with(|c| c.encoder_lines_per_motor_rev = 0),
            Err(ParamError::NonPositiveCountsPerRev)
        );
        assert_eq!(
            with(|c| c.gear_ratio = f32::NAN),
            Err(ParamError::NonPositiveCountsPerRev)
        );
        assert_eq!(
            with(|c| c.control_rate_hz = 0),
            Err(ParamError::ZeroControlRate)
        );
        assert_eq!(
            with(|c| c.steering_divider = 0),
            Err(ParamError::ZeroSteeringDivider)
        );
        assert_eq!(
            with(|c| c.speed_window_steps = 65),
            Err(ParamError::SpeedWindowOutOfRange)
        );
        assert_eq!(
            with(|c| c.limits.max_rim_speed_m_s = f32::INFINITY),
            Err(ParamError::NonPositiveLimit("limits.max_rim_speed_m_s"))
        );
        assert_eq!(
            with(|c| c.wheel_pid.kp_duty_per_rad_s = f32::NAN),
            Err(ParamError::NonFiniteGain("wheel_pid.kp_duty_per_rad_s"))
        );
        assert_eq!(
            with(|c| c.law.tracking.k_theta = f32::INFINITY),
            Err(ParamError::NonFiniteGain("tracking.k_theta"))
        );
        assert_eq!(
            with(|c| c.law.paper.gamma = 0.0),
            Err(ParamError::NonFiniteGain("paper.gamma"))
        );
    }

    #[test]
    fn errors_print_the_field() {
        let text = format!(
            "{}",
            ParamError::NonPositiveLimit("limits.max_rim_speed_m_s")
        );
        assert_eq!(text, "limits.max_rim_speed_m_s must be > 0 and finite");
    }
}
