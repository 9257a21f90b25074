//! One source of truth for the robot: geometry, encoder, rates, limits and gains.
//!
//! Fill a [`RobotConfig`] (plain data, SI units in every name) and turn it into validated
//! [`Params`] with [`Params::new`]. The firmware and the simulator both do exactly that;
//! nothing else in the core takes raw numbers.

use core::f32::consts::TAU;
use core::fmt;
use core::num::NonZeroU32;

use crate::encoder::MAX_SPEED_WINDOW_STEPS;
use crate::gyro::GyroConfig;
use crate::kinematics::DiffDrive;
use crate::law::{KanayamaGains, LawGains, PaperGains, TrackingGains};
use crate::limits::Limits;
use crate::pid::PidGains;
use crate::velocity::VelocityModeConfig;
use crate::wiring::WiringConfig;

/// Upper bound of [`Params::max_ticks_per_step`]: 2²⁴, exact in `f32`, and 64 of them fit
/// an `i32` sum.
pub const MAX_TICKS_PER_STEP: i32 = 1 << 24;

/// One wheel's speed loop, in volts: feed-forward from the motor model plus an incremental
/// PID on the wheel-speed error. The output is an armature voltage; the duty written to
/// the bridge is that voltage divided by the measured supply, so the gains hold from a
/// 4.8 V pack to a 12.6 V one.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelLoopConfig {
    /// Static-friction feed-forward k_S, V: applied as k_S·sgn(ω*) (ramped in over
    /// ±0.5 rad/s of set-point, so a set-point of 0 gets 0 V).
    pub ks_v: f32,
    /// Speed feed-forward k_V, V per rad/s of wheel set-point (back-EMF plus viscous
    /// friction referred to the armature).
    pub kv_v_per_rad_s: f32,
    /// Proportional gain K_p, V per rad/s of wheel-speed error.
    pub kp_v_per_rad_s: f32,
    /// Integral time T_i, s (0 disables the integral).
    pub ti_s: f32,
    /// Derivative time T_d, s (0 disables the derivative).
    pub td_s: f32,
    /// Time constant of the D-term filter, s (0 for no filter).
    pub d_filter_tau_s: f32,
}

/// The motor, as far as the wheel loop's limits need it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct MotorConfig {
    /// Rated armature voltage, V: the loop never applies more, whatever the supply.
    pub rated_voltage_v: f32,
    /// Armature resistance R_a (plus the bridge's switches), Ω.
    pub resistance_ohm: f32,
    /// Largest armature current the loop commands, A: the voltage is kept within
    /// k_V·ω ± I_max·R_a, which also bounds the current when a reversal plugs the motor.
    pub max_current_a: f32,
}

/// The motor driver (H-bridge) and its supply.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct DriveConfig {
    /// Lowest supply the bridge works at, V (TB6612FNG: 4.5 V; DRV8833: 2.7 V).
    pub min_supply_v: f32,
    /// Highest supply the bridge tolerates, V (TB6612FNG: 13.5 V; DRV8833: 10.8 V).
    pub max_supply_v: f32,
    /// Time constant of the low-pass filter on the supply measurement, s (0: none).
    pub supply_filter_tau_s: f32,
    /// Largest change of a wheel's voltage per second, V/s (the output slew limit).
    pub slew_v_per_s: f32,
}

/// Everything the controller needs to know about the robot, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct RobotConfig {
    /// Left wheel radius R_l, m.
    pub wheel_radius_left_m: f32,
    /// Right wheel radius R_r, m.
    pub wheel_radius_right_m: f32,
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
    /// Steps averaged by the wheel-speed estimate (1…64). One tick per window must be at
    /// most [`MAX_SPEED_QUANTUM_FRACTION`] of the wheel's top speed.
    pub speed_window_steps: u32,
    /// Command limits.
    pub limits: Limits,
    /// Fastest plausible wheel speed, rad/s: a tick delta implying more than this in one
    /// step is an encoder fault (motors stop).
    pub max_plausible_wheel_speed_rad_s: f32,
    /// The motor (rated voltage, resistance, current limit).
    pub motor: MotorConfig,
    /// The bridge and its supply.
    pub drive: DriveConfig,
    /// Left wheel's speed loop.
    pub left_wheel: WheelLoopConfig,
    /// Right wheel's speed loop.
    pub right_wheel: WheelLoopConfig,
    /// Steering-law gains.
    pub law: LawGains,
    /// The velocity mode's limits and command timeout (`diff_drive_controller`'s
    /// `linear.x.*`, `angular.z.*` and `cmd_vel_timeout`).
    pub velocity: VelocityModeConfig,
    /// How the board's motor outputs and encoder inputs reach the wheels, and the scale
    /// of its supply reading ([`crate::wiring`]; robot-app applies them at the board).
    pub wiring: WiringConfig,
    /// The gyro: the heading the controller uses, the axis sign and scale from
    /// bring-up, and the limits that judge the sensor ([`crate::gyro`]). A robot without
    /// one passes no readings and steers by odometry whatever this says.
    pub gyro: GyroConfig,
}

/// The wheel loop of the reference robot's motors (see [`RobotConfig::REFERENCE_ROBOT`]).
pub const REFERENCE_WHEEL_LOOP: WheelLoopConfig = WheelLoopConfig {
    ks_v: 0.33,
    kv_v_per_rad_s: 0.157,
    kp_v_per_rad_s: 0.6,
    ti_s: 0.09,
    td_s: 0.0,
    d_filter_tau_s: 0.0,
};

/// Most one encoder tick per speed window may be, as a fraction of the wheel's top speed:
/// a coarser estimate makes the wheel loop bang between its limits.
pub const MAX_SPEED_QUANTUM_FRACTION: f32 = 0.02;

impl RobotConfig {
    /// The reference robot: 65 mm wheels, 150 mm track, 12-line encoders on 6 V gear motors
    /// with a 1:30 gearbox (1440 ticks per wheel revolution), R_a = 4 Ω, 1.2 A current
    /// limit (the TB6612FNG's average rating), 1 kHz wheel loop, 100 Hz steering, 1 m/s
    /// rim-speed cap. The feed-forward is the motor model's (k_S = 0.33 V of static
    /// friction, k_V = 0.157 V per rad/s). The PID (K_p = 0.6 V per rad/s, T_i = 90 ms) was
    /// chosen in `host-sim` for the margins: `host-sim margins` computes gain margins 5.2
    /// driving straight and 4.0 turning, phase margins 65° and 62°, and at least 2.5 and
    /// 45° while braking; `host-sim param-sweep` checks it from 4.8 to 12.6 V and against
    /// motors ±30 % off.
    pub const REFERENCE_ROBOT: RobotConfig = RobotConfig {
        wheel_radius_left_m: 0.0325,
        wheel_radius_right_m: 0.0325,
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
        motor: MotorConfig {
            rated_voltage_v: 6.0,
            resistance_ohm: 4.0,
            max_current_a: 1.2,
        },
        drive: DriveConfig {
            min_supply_v: 4.5,
            max_supply_v: 13.5,
            supply_filter_tau_s: 0.02,
            slew_v_per_s: 1200.0,
        },
        left_wheel: REFERENCE_WHEEL_LOOP,
        right_wheel: REFERENCE_WHEEL_LOOP,
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
        velocity: VelocityModeConfig::at_rate(1000),
        wiring: WiringConfig::AS_BUILT,
        gyro: GyroConfig::ICM42688P,
    };
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self::REFERENCE_ROBOT
    }
}

/// Why a [`RobotConfig`] was rejected. Each variant carries the offending value;
/// [`ParamError::field`] names the field (its path in [`RobotConfig`]) and `Display` prints
/// both, e.g. `wheel_radius_left_m must be > 0, got -0.03`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// `encoder_lines_per_motor_rev` was 0.
    NonPositiveCountsPerRev,
    /// `control_rate_hz` was 0.
    ZeroControlRate,
    /// `steering_divider` was 0.
    ZeroSteeringDivider,
    /// `speed_window_steps` was outside 1…64.
    SpeedWindowOutOfRange(u32),
    /// One tick per speed window is more than [`MAX_SPEED_QUANTUM_FRACTION`] of the top
    /// wheel speed (the window is too short for the encoder and control rate).
    SpeedQuantumTooCoarse {
        /// One tick per window, rad/s.
        quantum_rad_s: f32,
        /// The fastest wheel's top speed at the rated voltage, rad/s.
        top_speed_rad_s: f32,
    },
    /// A value that must be > 0 (and finite) was not.
    NonPositive {
        /// The field, e.g. `limits.max_rim_speed_m_s`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A value that must be ≥ 0 (and finite) was not.
    Negative {
        /// The field, e.g. `left_wheel.ti_s`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A gain was NaN or infinite.
    NonFinite {
        /// The field, e.g. `law.tracking.k_theta`.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// `drive.max_supply_v` was not above `drive.min_supply_v`.
    SupplyRangeEmpty {
        /// `drive.min_supply_v`, V.
        min_v: f32,
        /// `drive.max_supply_v`, V.
        max_v: f32,
    },
    /// A calibration's scale factor (`wiring.supply_scale`, `gyro.scale`) was not finite
    /// or outside [`MIN_CALIBRATION_SCALE`] … [`MAX_CALIBRATION_SCALE`].
    ScaleOutOfRange {
        /// The field's path in [`RobotConfig`].
        field: &'static str,
        /// The value given.
        value: f32,
    },
}

impl ParamError {
    /// The offending field's path in [`RobotConfig`], e.g. `law.paper.gamma`.
    pub const fn field(&self) -> &'static str {
        match self {
            ParamError::NonPositiveCountsPerRev => "encoder_lines_per_motor_rev",
            ParamError::ZeroControlRate => "control_rate_hz",
            ParamError::ZeroSteeringDivider => "steering_divider",
            ParamError::SpeedWindowOutOfRange(_) | ParamError::SpeedQuantumTooCoarse { .. } => {
                "speed_window_steps"
            }
            ParamError::SupplyRangeEmpty { .. } => "drive.max_supply_v",
            ParamError::NonPositive { field, .. }
            | ParamError::ScaleOutOfRange { field, .. }
            | ParamError::Negative { field, .. }
            | ParamError::NonFinite { field, .. } => field,
        }
    }
}

impl ParamError {
    /// What the field must satisfy, without the value, e.g. `must be > 0` (for messages
    /// that cannot afford to format a float).
    pub const fn requirement(&self) -> &'static str {
        match self {
            ParamError::NonPositiveCountsPerRev
            | ParamError::ZeroControlRate
            | ParamError::ZeroSteeringDivider
            | ParamError::NonPositive { .. } => "must be > 0",
            ParamError::SpeedWindowOutOfRange(_) => "must be in 1..=64",
            ParamError::SpeedQuantumTooCoarse { .. } => {
                "is too short: one encoder tick is over 2 % of the top speed"
            }
            ParamError::Negative { .. } => "must be ≥ 0",
            ParamError::NonFinite { .. } => "must be finite",
            ParamError::SupplyRangeEmpty { .. } => "must be > drive.min_supply_v",
            ParamError::ScaleOutOfRange { .. } => "must be in 0.5..=2",
        }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let field = self.field();
        match *self {
            ParamError::NonPositiveCountsPerRev
            | ParamError::ZeroControlRate
            | ParamError::ZeroSteeringDivider => write!(f, "{field} must be > 0, got 0"),
            ParamError::SpeedWindowOutOfRange(v) => {
                write!(f, "{field} must be in 1..=64, got {v}")
            }
            ParamError::SpeedQuantumTooCoarse {
                quantum_rad_s,
                top_speed_rad_s,
            } => write!(
                f,
                "{field} is too short: one encoder tick per window is {quantum_rad_s} rad/s, \
                 more than 2 % of the top wheel speed ({top_speed_rad_s} rad/s); lengthen \
                 the window or lower control_rate_hz"
            ),
            ParamError::NonPositive { value, .. } => write!(f, "{field} must be > 0, got {value}"),
            ParamError::Negative { value, .. } => write!(f, "{field} must be ≥ 0, got {value}"),
            ParamError::NonFinite { value, .. } => {
                write!(f, "{field} must be finite, got {value}")
            }
            ParamError::SupplyRangeEmpty { min_v, max_v } => write!(
                f,
                "{field} must be > drive.min_supply_v ({min_v} V), got {max_v}"
            ),
            ParamError::ScaleOutOfRange { value, .. } => write!(
                f,
                "{field} must be in {MIN_CALIBRATION_SCALE}..={MAX_CALIBRATION_SCALE}, got {value}"
            ),
        }
    }
}

impl core::error::Error for ParamError {}

/// A validated [`RobotConfig`] with the quantities derived from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    config: RobotConfig,
    geometry: DiffDrive,
    rad_per_tick: f32,
    ticks_per_rev: f32,
    period_s: f32,
    control_rate: NonZeroU32,
    steering_divider: NonZeroU32,
    wheel_pid: [PidGains; 2],
    max_ticks_per_step: i32,
}

/// Smallest scale factor a calibration may set (`wiring.supply_scale`, `gyro.scale`):
/// a sensor read by half or less of its true value is miswired or misconfigured, not
/// uncalibrated.
pub const MIN_CALIBRATION_SCALE: f32 = 0.5;
/// Largest scale factor a calibration may set (see [`MIN_CALIBRATION_SCALE`]).
pub const MAX_CALIBRATION_SCALE: f32 = 2.0;

/// `Ok` if `value` is a usable calibration scale factor for `field`: finite and in
/// [`MIN_CALIBRATION_SCALE`] … [`MAX_CALIBRATION_SCALE`].
pub(crate) fn calibration_scale(value: f32, field: &'static str) -> Result<(), ParamError> {
    if (MIN_CALIBRATION_SCALE..=MAX_CALIBRATION_SCALE).contains(&value) {
        Ok(())
    } else {
        Err(ParamError::ScaleOutOfRange { field, value })
    }
}

/// `value` > 0 and finite, or the error naming `field`.
pub(crate) fn positive(value: f32, field: &'static str) -> Result<(), ParamError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonPositive { field, value })
    }
}

/// `value` finite, or the error naming `field`.
pub(crate) fn finite(value: f32, field: &'static str) -> Result<(), ParamError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NonFinite { field, value })
    }
}

/// `value` ≥ 0 and finite, or the error naming `field`.
pub(crate) fn non_negative(value: f32, field: &'static str) -> Result<(), ParamError> {
    finite(value, field)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::Negative { field, value })
    }
}

/// Field names of one wheel loop, so both wheels are checked by one function.
struct WheelLoopFields {
    ks_v: &'static str,
    kv_v_per_rad_s: &'static str,
    kp_v_per_rad_s: &'static str,
    ti_s: &'static str,
    td_s: &'static str,
    d_filter_tau_s: &'static str,
}

const LEFT_WHEEL_FIELDS: WheelLoopFields = WheelLoopFields {
    ks_v: "left_wheel.ks_v",
    kv_v_per_rad_s: "left_wheel.kv_v_per_rad_s",
    kp_v_per_rad_s: "left_wheel.kp_v_per_rad_s",
    ti_s: "left_wheel.ti_s",
    td_s: "left_wheel.td_s",
    d_filter_tau_s: "left_wheel.d_filter_tau_s",
};

const RIGHT_WHEEL_FIELDS: WheelLoopFields = WheelLoopFields {
    ks_v: "right_wheel.ks_v",
    kv_v_per_rad_s: "right_wheel.kv_v_per_rad_s",
    kp_v_per_rad_s: "right_wheel.kp_v_per_rad_s",
    ti_s: "right_wheel.ti_s",
    td_s: "right_wheel.td_s",
    d_filter_tau_s: "right_wheel.d_filter_tau_s",
};

impl WheelLoopConfig {
    /// Checks every field; the error names the first bad one as `names` spells it.
    fn validate(&self, names: &WheelLoopFields) -> Result<(), ParamError> {
        non_negative(self.ks_v, names.ks_v)?;
        positive(self.kv_v_per_rad_s, names.kv_v_per_rad_s)?;
        non_negative(self.kp_v_per_rad_s, names.kp_v_per_rad_s)?;
        non_negative(self.ti_s, names.ti_s)?;
        non_negative(self.td_s, names.td_s)?;
        non_negative(self.d_filter_tau_s, names.d_filter_tau_s)
    }

    /// Top wheel speed at `volts` (V) with no load but the motor's own friction, rad/s
    /// (0 when `volts` is below the static-friction voltage).
    pub fn speed_at_volts(&self, volts: f32) -> f32 {
        let speed = (volts - self.ks_v) / self.kv_v_per_rad_s;
        if speed > 0.0 {
            speed
        } else {
            0.0
        }
    }

    /// Discrete PID gains for the sample period `period_s` (s).
    pub fn pid_gains(&self, period_s: f32) -> PidGains {
        PidGains::from_continuous(
            self.kp_v_per_rad_s,
            self.ti_s,
            self.td_s,
            self.d_filter_tau_s,
            period_s,
        )
    }
}

impl Params {
    /// Validates `config` and derives ticks per revolution, the period and discrete gains.
    pub fn new(config: RobotConfig) -> Result<Self, ParamError> {
        positive(config.wheel_radius_left_m, "wheel_radius_left_m")?;
        positive(config.wheel_radius_right_m, "wheel_radius_right_m")?;
        positive(config.track_width_m, "track_width_m")?;
        let geometry = DiffDrive::with_wheel_radii(
            config.wheel_radius_left_m,
            config.wheel_radius_right_m,
            config.track_width_m,
        )
        .map_err(|_| ParamError::NonPositive {
            field: "track_width_m",
            value: config.track_width_m,
        })?;
        if config.encoder_lines_per_motor_rev == 0 {
            return Err(ParamError::NonPositiveCountsPerRev);
        }
        positive(config.gear_ratio, "gear_ratio")?;
        let control_rate =
            NonZeroU32::new(config.control_rate_hz).ok_or(ParamError::ZeroControlRate)?;
        let steering_divider =
            NonZeroU32::new(config.steering_divider).ok_or(ParamError::ZeroSteeringDivider)?;
        if config.speed_window_steps == 0
            || config.speed_window_steps as usize > MAX_SPEED_WINDOW_STEPS
        {
            return Err(ParamError::SpeedWindowOutOfRange(config.speed_window_steps));
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
        let m = &config.motor;
        positive(m.rated_voltage_v, "motor.rated_voltage_v")?;
        positive(m.resistance_ohm, "motor.resistance_ohm")?;
        positive(m.max_current_a, "motor.max_current_a")?;
        let d = &config.drive;
        positive(d.min_supply_v, "drive.min_supply_v")?;
        positive(d.max_supply_v, "drive.max_supply_v")?;
        if d.max_supply_v <= d.min_supply_v {
            return Err(ParamError::SupplyRangeEmpty {
                min_v: d.min_supply_v,
                max_v: d.max_supply_v,
            });
        }
        non_negative(d.supply_filter_tau_s, "drive.supply_filter_tau_s")?;
        positive(d.slew_v_per_s, "drive.slew_v_per_s")?;
        config.left_wheel.validate(&LEFT_WHEEL_FIELDS)?;
        config.right_wheel.validate(&RIGHT_WHEEL_FIELDS)?;
        config.law.validate()?;
        config.velocity.validate()?;
        config.gyro.validate()?;
        calibration_scale(config.wiring.supply_scale, "wiring.supply_scale")?;

        let ticks_per_rev = config.encoder_lines_per_motor_rev as f32 * 4.0 * config.gear_ratio;
        let rad_per_tick = TAU / ticks_per_rev;
        let period_s = 1.0 / config.control_rate_hz as f32;
        // One tick per window must be a fine fraction of the top speed.
        let top_speed_rad_s = config
            .left_wheel
            .speed_at_volts(m.rated_voltage_v)
            .max(config.right_wheel.speed_at_volts(m.rated_voltage_v));
        let quantum_rad_s = rad_per_tick / (config.speed_window_steps as f32 * period_s);
        let fine_enough = quantum_rad_s <= MAX_SPEED_QUANTUM_FRACTION * top_speed_rad_s;
        if !fine_enough {
            return Err(ParamError::SpeedQuantumTooCoarse {
                quantum_rad_s,
                top_speed_rad_s,
            });
        }
        let wheel_pid = [
            config.left_wheel.pid_gains(period_s),
            config.right_wheel.pid_gains(period_s),
        ];
        // Finite continuous gains can still overflow when discretised (huge K_p·T_d/T).
        for (gains, names) in wheel_pid
            .iter()
            .zip([&LEFT_WHEEL_FIELDS, &RIGHT_WHEEL_FIELDS])
        {
            finite(gains.ki, names.ti_s)?;
            finite(gains.kd, names.td_s)?;
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
            ticks_per_rev,
            period_s,
            control_rate,
            steering_divider,
            wheel_pid,
            max_ticks_per_step,
        })
    }

    /// The configuration these parameters were built from.
    pub const fn config(&self) -> &RobotConfig {
        &self.config
    }

    /// Robot geometry (R_l, R_r, L).
    pub const fn geometry(&self) -> DiffDrive {
        self.geometry
    }

    /// Wheel rotation per encoder tick, rad (2π / (lines × 4 × gear)).
    pub const fn rad_per_tick(&self) -> f32 {
        self.rad_per_tick
    }

    /// Encoder ticks per wheel revolution (lines × 4 × gear).
    pub const fn ticks_per_wheel_rev(&self) -> f32 {
        self.ticks_per_rev
    }

    /// Period T of the inner loop, s.
    pub const fn period_s(&self) -> f32 {
        self.period_s
    }

    /// Rate of the inner loop, Hz (non-zero by type).
    pub const fn control_rate(&self) -> NonZeroU32 {
        self.control_rate
    }

    /// The steering law runs every this many inner steps (non-zero by type).
    pub const fn steering_divider(&self) -> NonZeroU32 {
        self.steering_divider
    }

    /// Period of the steering loop, s.
    pub fn steering_period_s(&self) -> f32 {
        self.period_s * self.config.steering_divider as f32
    }

    /// Discrete wheel PID gains for the inner period, [left, right].
    pub const fn wheel_pid(&self) -> [PidGains; 2] {
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
        assert_eq!(p.steering_divider().get(), 10);
        assert_eq!(p.control_rate().get(), 1000);
        // K_i = K_p T / T_i = 0.6 · 0.001 / 0.09.
        assert!((p.wheel_pid()[0].ki - 0.6 * 0.001 / 0.09).abs() < 1e-8);
        assert_eq!(p.wheel_pid()[0], p.wheel_pid()[1]);
        // 2 × 100 rad/s × 1 ms / (2π/1440) = 45.8 ticks.
        assert_eq!(p.max_ticks_per_step(), 45);
    }

    #[test]
    fn each_bad_field_has_its_own_error() {
        use ParamError::*;
        let np = |field, value| NonPositive { field, value };
        assert_eq!(
            with(|c| c.wheel_radius_left_m = -0.03),
            Err(np("wheel_radius_left_m", -0.03))
        );
        assert_eq!(
            with(|c| c.wheel_radius_right_m = 0.0),
            Err(np("wheel_radius_right_m", 0.0))
        );
        assert_eq!(
            with(|c| c.track_width_m = 0.0),
            Err(np("track_width_m", 0.0))
        );
        assert_eq!(
            with(|c| c.encoder_lines_per_motor_rev = 0),
            Err(NonPositiveCountsPerRev)
        );
        assert_eq!(with(|c| c.gear_ratio = -30.0), Err(np("gear_ratio", -30.0)));
        assert_eq!(with(|c| c.control_rate_hz = 0), Err(ZeroControlRate));
        assert_eq!(with(|c| c.steering_divider = 0), Err(ZeroSteeringDivider));
        assert_eq!(
            with(|c| c.speed_window_steps = 65),
            Err(SpeedWindowOutOfRange(65))
        );
        assert_eq!(
            with(|c| c.limits.max_rim_speed_m_s = f32::INFINITY),
            Err(np("limits.max_rim_speed_m_s", f32::INFINITY))
        );
        assert_eq!(
            with(|c| c.motor.max_current_a = 0.0),
            Err(np("motor.max_current_a", 0.0))
        );
        assert_eq!(
            with(|c| c.drive.slew_v_per_s = -1.0),
            Err(np("drive.slew_v_per_s", -1.0))
        );
        assert_eq!(
            with(|c| c.drive.max_supply_v = 4.0),
            Err(SupplyRangeEmpty {
                min_v: 4.5,
                max_v: 4.0
            })
        );
        assert_eq!(
            with(|c| c.right_wheel.ti_s = -1.0),
            Err(Negative {
                field: "right_wheel.ti_s",
                value: -1.0
            })
        );
        assert_eq!(
            with(|c| c.left_wheel.kv_v_per_rad_s = 0.0),
            Err(np("left_wheel.kv_v_per_rad_s", 0.0))
        );
        assert_eq!(
            with(|c| c.law.tracking.k_theta = f32::INFINITY),
            Err(NonFinite {
                field: "law.tracking.k_theta",
                value: f32::INFINITY
            })
        );
        assert_eq!(
            with(|c| c.law.paper.gamma = 0.0),
            Err(np("law.paper.gamma", 0.0))
        );
        // NaN compares unequal, so check the variant and field.
        let nan = with(|c| c.left_wheel.kp_v_per_rad_s = f32::NAN).unwrap_err();
        assert!(matches!(nan, NonFinite { .. }));
        assert_eq!(nan.field(), "left_wheel.kp_v_per_rad_s");
        assert_eq!(
            with(|c| c.gear_ratio = f32::NAN).unwrap_err().field(),
            "gear_ratio"
        );
    }

    #[test]
    fn a_speed_window_too_short_for_the_rate_is_refused() {
        // 100 kHz with a 20-step window: one tick per window is 2π/1440 / 0.2 ms = 21.8 rad/s,
        // 60 % of the 36 rad/s top speed. The loop would bang between its limits.
        let e = with(|c| c.control_rate_hz = 100_000).unwrap_err();
        let ParamError::SpeedQuantumTooCoarse {
            quantum_rad_s,
            top_speed_rad_s,
        } = e
        else {
            panic!("{e:?}");
        };
        assert!((quantum_rad_s - 21.82).abs() < 0.01, "{quantum_rad_s}");
        assert!((top_speed_rad_s - 36.11).abs() < 0.01, "{top_speed_rad_s}");
        assert_eq!(e.field(), "speed_window_steps");
        // At 1 kHz the quantum is 0.22 rad/s (0.6 %): accepted. At 10 kHz with the
        // 64-step maximum window it is 0.68 rad/s (1.9 %): still accepted, just.
        assert!(with(|c| {
            c.control_rate_hz = 10_000;
            c.speed_window_steps = 64;
        })
        .is_ok());
        assert!(with(|c| c.control_rate_hz = 10_000).is_err());
    }

    #[test]
    fn errors_print_the_field_the_rule_and_the_value() {
        let e = with(|c| c.wheel_radius_left_m = -0.03).unwrap_err();
        assert_eq!(format!("{e}"), "wheel_radius_left_m must be > 0, got -0.03");
        let e = with(|c| c.speed_window_steps = 0).unwrap_err();
        assert_eq!(
            format!("{e}"),
            "speed_window_steps must be in 1..=64, got 0"
        );
        let e = with(|c| c.law.kanayama.k_y = -2.0).unwrap_err();
        assert_eq!(format!("{e}"), "law.kanayama.k_y must be > 0, got -2");
        let e = with(|c| c.left_wheel.td_s = -0.5).unwrap_err();
        assert_eq!(format!("{e}"), "left_wheel.td_s must be ≥ 0, got -0.5");
        let e = with(|c| c.law.paper.k = f32::NAN).unwrap_err();
        assert_eq!(format!("{e}"), "law.paper.k must be finite, got NaN");
        let e = with(|c| c.steering_divider = 0).unwrap_err();
        assert_eq!(format!("{e}"), "steering_divider must be > 0, got 0");
        let e = with(|c| c.drive.max_supply_v = 3.0).unwrap_err();
        assert_eq!(
            format!("{e}"),
            "drive.max_supply_v must be > drive.min_supply_v (4.5 V), got 3"
        );
        let e = with(|c| c.control_rate_hz = 100_000).unwrap_err();
        assert!(format!("{e}").starts_with("speed_window_steps is too short"));
    }

    #[test]
    fn every_error_states_its_requirement_without_the_value() {
        use ParamError::*;
        let cases = [
            (NonPositiveCountsPerRev, "must be > 0"),
            (ZeroControlRate, "must be > 0"),
            (ZeroSteeringDivider, "must be > 0"),
            (
                NonPositive {
                    field: "f",
                    value: 0.0,
                },
                "must be > 0",
            ),
            (SpeedWindowOutOfRange(0), "must be in 1..=64"),
            (
                Negative {
                    field: "f",
                    value: -1.0,
                },
                "must be ≥ 0",
            ),
            (
                NonFinite {
                    field: "f",
                    value: f32::NAN,
                },
                "must be finite",
            ),
            (
                SupplyRangeEmpty {
                    min_v: 5.0,
                    max_v: 4.0,
                },
                "must be > drive.min_supply_v",
            ),
            // The message formats the range's constants: the static text must match.
            (
                ScaleOutOfRange {
                    field: "gyro.scale",
                    value: 3.0,
                },
                "must be in 0.5..=2",
            ),
        ];
        for (e, requirement) in cases {
            assert_eq!(e.requirement(), requirement, "{e:?}");
            assert!(format!("{e}").contains(requirement), "{e}");
        }
        let coarse = SpeedQuantumTooCoarse {
            quantum_rad_s: 20.0,
            top_speed_rad_s: 36.0,
        };
        assert!(coarse.requirement().starts_with("is too short"));
    }

    #[test]
    fn top_speed_follows_the_feed_forward_model() {
        let w = REFERENCE_WHEEL_LOOP;
        assert!((w.speed_at_volts(6.0) - (6.0 - 0.33) / 0.157).abs() < 1e-4);
        assert_eq!(w.speed_at_volts(0.2), 0.0);
    }
}
