//! The `[robot]` and `[supervisor]` TOML sections: one schema, parsed by this module for
//! host-sim's scenarios and for the ground station's `params get` / `params set`, so a
//! robot file tuned in the simulator is the robot file the real robot takes.
//!
//! ```toml
//! [robot]                      # every key optional; the rest from RobotConfig::REFERENCE_ROBOT
//! wheel_radius_m = 0.0325      # both wheels; or wheel_radius_left_m / wheel_radius_right_m
//! track_width_m = 0.15
//! encoder_lines_per_motor_rev = 12
//! gear_ratio = 30.0
//! control_rate_hz = 1000
//! steering_divider = 10
//! speed_window_steps = 20
//! max_plausible_wheel_speed_rad_s = 100.0
//! [robot.limits]               # max_rim_speed_m_s, max_linear_accel_m_s2, max_angular_accel_rad_s2
//! [robot.motor]                # rated_voltage_v, resistance_ohm, max_current_a
//! [robot.drive]                # min_supply_v, max_supply_v, supply_filter_tau_s, slew_v_per_s
//! [robot.wheels]               # both wheel loops: ks_v, kv_v_per_rad_s, kp_v_per_rad_s,
//!                              #   ti_s, td_s, d_filter_tau_s
//! [robot.left_wheel]           # … and per wheel, over [robot.wheels]
//! [robot.right_wheel]
//! [robot.law.paper]            # gamma, k, h, lambda
//! [robot.law.tracking]         # lambda, k_x, k_theta
//! [robot.law.kanayama]         # k_x, k_y, k_theta
//!
//! [supervisor]                 # times in seconds; the supervisor counts control steps
//! run_time_limit_s = 120.0     # or "none" (the default: a soak can run for a day)
//! auto_arm_after_s = "none"
//! debounce_s = 0.02
//! long_press_s = 1.0
//! heartbeat_timeout_s = 0.5
//! brake_s = 0.5
//! max_consecutive_overruns = 5
//! background_timeout_s = 0.5
//! battery_warn_v = 5.0
//! battery_fault_v = 4.6
//! battery_debounce_s = 0.2
//! hold_speeds_rad_s = [5.0, 5.0]
//! [supervisor.missed_ticks]    # window_s, max_per_window, max_gap_periods
//! [supervisor.stall]           # min_volts, min_speed_rad_s, timeout_s
//! [supervisor.saturation]      # window_s, max_fraction
//! [supervisor.divergence]      # "auto" (from the path; the default), "off", or
//!                              #   settle_s, bound_m, persist_s
//! geofence_radius_m = "auto"   # "auto" (from the path), "off", or a radius in m
//! ```
//!
//! A bad value gets an error naming the key, e.g. `robot.motor.max_current_a must be > 0,
//! got -1`: the core's own validation ([`Params::new`], [`SupervisorConfig::validate`])
//! decides, and its field name is turned into the TOML key.

use std::fmt;

use controller_core::law::{KanayamaGains, LawGains, PaperGains, TrackingGains};
use controller_core::params::{
    DriveConfig, MotorConfig, ParamError, Params, RobotConfig, WheelLoopConfig,
};
use controller_core::prelude::{Pose, Reference, WheelSpeeds};
use controller_core::supervisor::{
    DivergenceCheck, MissedTickCheck, StallCheck, SupervisorConfig, SupervisorConfigError,
};
use serde::{Deserialize, Serialize};

/// A value that may be a number, or a keyword (`"none"`, `"off"`, `"auto"`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NumberOr {
    /// A number.
    Number(f64),
    /// A keyword.
    Keyword(Keyword),
}

/// The keywords a [`NumberOr`] accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Keyword {
    /// No limit.
    None,
    /// Switched off.
    Off,
    /// Derived from the path.
    Auto,
}

/// Why a robot or supervisor section was rejected. `Display` names the TOML key.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key} {problem}")]
pub struct SectionError {
    /// Dotted TOML key, e.g. `robot.motor.max_current_a`.
    pub key: String,
    /// What is wrong with it, with the value.
    pub problem: String,
}

impl SectionError {
    fn new(key: impl Into<String>, problem: impl fmt::Display) -> Self {
        Self {
            key: key.into(),
            problem: problem.to_string(),
        }
    }
}

/// `[robot.limits]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSection {
    /// Largest rim speed, m/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rim_speed_m_s: Option<f32>,
    /// Largest forward acceleration, m/s².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_linear_accel_m_s2: Option<f32>,
    /// Largest yaw acceleration, rad/s².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_angular_accel_rad_s2: Option<f32>,
}

/// `[robot.motor]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorSection {
    /// Rated armature voltage, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rated_voltage_v: Option<f32>,
    /// Armature (plus bridge) resistance, Ω.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resistance_ohm: Option<f32>,
    /// Current limit, A.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_current_a: Option<f32>,
}

/// `[robot.drive]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveSection {
    /// The bridge's minimum supply, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_supply_v: Option<f32>,
    /// The bridge's maximum supply, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_supply_v: Option<f32>,
    /// Supply filter time constant, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supply_filter_tau_s: Option<f32>,
    /// Output slew limit, V/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slew_v_per_s: Option<f32>,
}

/// `[robot.wheels]`, `[robot.left_wheel]`, `[robot.right_wheel]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelSection {
    /// Static-friction feed-forward, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ks_v: Option<f32>,
    /// Speed feed-forward, V per rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kv_v_per_rad_s: Option<f32>,
    /// PID K_p, V per rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kp_v_per_rad_s: Option<f32>,
    /// Integral time, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ti_s: Option<f32>,
    /// Derivative time, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub td_s: Option<f32>,
    /// D-filter time constant, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub d_filter_tau_s: Option<f32>,
}

/// `[robot.law.paper]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperSection {
    /// γ, 1/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gamma: Option<f32>,
    /// k, 1/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k: Option<f32>,
    /// h.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub h: Option<f32>,
    /// λ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f32>,
}

/// `[robot.law.tracking]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingSection {
    /// λ, 1/m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f32>,
    /// k_x, 1/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_x: Option<f32>,
    /// k_θ, 1/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_theta: Option<f32>,
}

/// `[robot.law.kanayama]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KanayamaSection {
    /// K_x, 1/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_x: Option<f32>,
    /// K_y, 1/m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_y: Option<f32>,
    /// K_θ, 1/m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_theta: Option<f32>,
}

/// `[robot.law]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LawSection {
    /// The paper's law.
    #[serde(default)]
    pub paper: PaperSection,
    /// The tracking law.
    #[serde(default)]
    pub tracking: TrackingSection,
    /// Kanayama's law.
    #[serde(default)]
    pub kanayama: KanayamaSection,
}

/// `[robot]`: overrides of [`RobotConfig::REFERENCE_ROBOT`] (module doc).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSection {
    /// Both wheel radii, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_radius_m: Option<f32>,
    /// Left wheel radius, m (over `wheel_radius_m`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_radius_left_m: Option<f32>,
    /// Right wheel radius, m (over `wheel_radius_m`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_radius_right_m: Option<f32>,
    /// Track width, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub track_width_m: Option<f32>,
    /// Encoder lines per motor turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub encoder_lines_per_motor_rev: Option<u32>,
    /// Gear ratio.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear_ratio: Option<f32>,
    /// Wheel-loop rate, Hz.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub control_rate_hz: Option<u32>,
    /// Steering every this many steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steering_divider: Option<u32>,
    /// Speed-estimate window, steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_window_steps: Option<u32>,
    /// Encoder-jump threshold, rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_plausible_wheel_speed_rad_s: Option<f32>,
    /// Command limits.
    #[serde(default)]
    pub limits: LimitsSection,
    /// The motor.
    #[serde(default)]
    pub motor: MotorSection,
    /// The bridge.
    #[serde(default)]
    pub drive: DriveSection,
    /// Both wheel loops.
    #[serde(default)]
    pub wheels: WheelSection,
    /// The left wheel loop, over `wheels`.
    #[serde(default)]
    pub left_wheel: WheelSection,
    /// The right wheel loop, over `wheels`.
    #[serde(default)]
    pub right_wheel: WheelSection,
    /// Law gains.
    #[serde(default)]
    pub law: LawSection,
}

/// True when `section` sets the wheel-loop field `name`.
fn section_sets(section: &WheelSection, name: &str) -> bool {
    match name {
        "ks_v" => section.ks_v.is_some(),
        "kv_v_per_rad_s" => section.kv_v_per_rad_s.is_some(),
        "kp_v_per_rad_s" => section.kp_v_per_rad_s.is_some(),
        "ti_s" => section.ti_s.is_some(),
        "td_s" => section.td_s.is_some(),
        "d_filter_tau_s" => section.d_filter_tau_s.is_some(),
        _ => false,
    }
}

fn set<T: Copy>(dst: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *dst = v;
    }
}

impl WheelSection {
    fn apply(&self, w: &mut WheelLoopConfig) {
        set(&mut w.ks_v, self.ks_v);
        set(&mut w.kv_v_per_rad_s, self.kv_v_per_rad_s);
        set(&mut w.kp_v_per_rad_s, self.kp_v_per_rad_s);
        set(&mut w.ti_s, self.ti_s);
        set(&mut w.td_s, self.td_s);
        set(&mut w.d_filter_tau_s, self.d_filter_tau_s);
    }

    fn of(w: &WheelLoopConfig) -> Self {
        Self {
            ks_v: Some(w.ks_v),
            kv_v_per_rad_s: Some(w.kv_v_per_rad_s),
            kp_v_per_rad_s: Some(w.kp_v_per_rad_s),
            ti_s: Some(w.ti_s),
            td_s: Some(w.td_s),
            d_filter_tau_s: Some(w.d_filter_tau_s),
        }
    }
}

impl RobotSection {
    /// `base` with this section's values over it (not yet validated: see
    /// [`RobotSection::params`]).
    pub fn apply(&self, base: RobotConfig) -> RobotConfig {
        let mut c = base;
        set(&mut c.wheel_radius_left_m, self.wheel_radius_m);
        set(&mut c.wheel_radius_right_m, self.wheel_radius_m);
        set(&mut c.wheel_radius_left_m, self.wheel_radius_left_m);
        set(&mut c.wheel_radius_right_m, self.wheel_radius_right_m);
        set(&mut c.track_width_m, self.track_width_m);
        set(
            &mut c.encoder_lines_per_motor_rev,
            self.encoder_lines_per_motor_rev,
        );
        set(&mut c.gear_ratio, self.gear_ratio);
        set(&mut c.control_rate_hz, self.control_rate_hz);
        set(&mut c.steering_divider, self.steering_divider);
        set(&mut c.speed_window_steps, self.speed_window_steps);
        set(
            &mut c.max_plausible_wheel_speed_rad_s,
            self.max_plausible_wheel_speed_rad_s,
        );
        let l = &self.limits;
        set(&mut c.limits.max_rim_speed_m_s, l.max_rim_speed_m_s);
        set(&mut c.limits.max_linear_accel_m_s2, l.max_linear_accel_m_s2);
        set(
            &mut c.limits.max_angular_accel_rad_s2,
            l.max_angular_accel_rad_s2,
        );
        let m = &self.motor;
        set(&mut c.motor.rated_voltage_v, m.rated_voltage_v);
        set(&mut c.motor.resistance_ohm, m.resistance_ohm);
        set(&mut c.motor.max_current_a, m.max_current_a);
        let d = &self.drive;
        set(&mut c.drive.min_supply_v, d.min_supply_v);
        set(&mut c.drive.max_supply_v, d.max_supply_v);
        set(&mut c.drive.supply_filter_tau_s, d.supply_filter_tau_s);
        set(&mut c.drive.slew_v_per_s, d.slew_v_per_s);
        self.wheels.apply(&mut c.left_wheel);
        self.wheels.apply(&mut c.right_wheel);
        self.left_wheel.apply(&mut c.left_wheel);
        self.right_wheel.apply(&mut c.right_wheel);
        let law = &self.law;
        let PaperGains {
            gamma,
            k,
            h,
            lambda,
        } = &mut c.law.paper;
        set(gamma, law.paper.gamma);
        set(k, law.paper.k);
        set(h, law.paper.h);
        set(lambda, law.paper.lambda);
        let TrackingGains {
            lambda,
            k_x,
            k_theta,
        } = &mut c.law.tracking;
        set(lambda, law.tracking.lambda);
        set(k_x, law.tracking.k_x);
        set(k_theta, law.tracking.k_theta);
        let KanayamaGains { k_x, k_y, k_theta } = &mut c.law.kanayama;
        set(k_x, law.kanayama.k_x);
        set(k_y, law.kanayama.k_y);
        set(k_theta, law.kanayama.k_theta);
        c
    }

    /// The validated parameters of this section over `base`; the error names the TOML
    /// key under `prefix` (e.g. `robot`).
    pub fn params(&self, base: RobotConfig, prefix: &str) -> Result<Params, SectionError> {
        Params::new(self.apply(base)).map_err(|e| {
            let mut error = param_error(e, prefix);
            // Name the key as it was written: a shared key for a per-wheel field.
            let field = e.field();
            let written = |specific: bool| !specific;
            let shared = if (field == "wheel_radius_left_m"
                && written(self.wheel_radius_left_m.is_some()))
                || (field == "wheel_radius_right_m" && written(self.wheel_radius_right_m.is_some()))
            {
                self.wheel_radius_m.map(|_| "wheel_radius_m".to_string())
            } else {
                let (side, name) = field.split_once('.').unwrap_or(("", field));
                let specific = match side {
                    "left_wheel" => &self.left_wheel,
                    "right_wheel" => &self.right_wheel,
                    _ => return error,
                };
                (self.wheels != WheelSection::default()
                    && !section_sets(specific, name)
                    && section_sets(&self.wheels, name))
                .then(|| format!("wheels.{name}"))
            };
            if let Some(key) = shared {
                error.key = format!("{prefix}.{key}");
            }
            error
        })
    }

    /// Every field of `config`, for writing a complete robot file.
    pub fn of(config: &RobotConfig) -> Self {
        let equal = config.wheel_radius_left_m == config.wheel_radius_right_m;
        Self {
            wheel_radius_m: equal.then_some(config.wheel_radius_left_m),
            wheel_radius_left_m: (!equal).then_some(config.wheel_radius_left_m),
            wheel_radius_right_m: (!equal).then_some(config.wheel_radius_right_m),
            track_width_m: Some(config.track_width_m),
            encoder_lines_per_motor_rev: Some(config.encoder_lines_per_motor_rev),
            gear_ratio: Some(config.gear_ratio),
            control_rate_hz: Some(config.control_rate_hz),
            steering_divider: Some(config.steering_divider),
            speed_window_steps: Some(config.speed_window_steps),
            max_plausible_wheel_speed_rad_s: Some(config.max_plausible_wheel_speed_rad_s),
            limits: LimitsSection {
                max_rim_speed_m_s: Some(config.limits.max_rim_speed_m_s),
                max_linear_accel_m_s2: Some(config.limits.max_linear_accel_m_s2),
                max_angular_accel_rad_s2: Some(config.limits.max_angular_accel_rad_s2),
            },
            motor: motor_section(&config.motor),
            drive: drive_section(&config.drive),
            wheels: WheelSection::default(),
            left_wheel: WheelSection::of(&config.left_wheel),
            right_wheel: WheelSection::of(&config.right_wheel),
            law: law_section(&config.law),
        }
    }
}

fn motor_section(m: &MotorConfig) -> MotorSection {
    MotorSection {
        rated_voltage_v: Some(m.rated_voltage_v),
        resistance_ohm: Some(m.resistance_ohm),
        max_current_a: Some(m.max_current_a),
    }
}

fn drive_section(d: &DriveConfig) -> DriveSection {
    DriveSection {
        min_supply_v: Some(d.min_supply_v),
        max_supply_v: Some(d.max_supply_v),
        supply_filter_tau_s: Some(d.supply_filter_tau_s),
        slew_v_per_s: Some(d.slew_v_per_s),
    }
}

fn law_section(l: &LawGains) -> LawSection {
    LawSection {
        paper: PaperSection {
            gamma: Some(l.paper.gamma),
            k: Some(l.paper.k),
            h: Some(l.paper.h),
            lambda: Some(l.paper.lambda),
        },
        tracking: TrackingSection {
            lambda: Some(l.tracking.lambda),
            k_x: Some(l.tracking.k_x),
            k_theta: Some(l.tracking.k_theta),
        },
        kanayama: KanayamaSection {
            k_x: Some(l.kanayama.k_x),
            k_y: Some(l.kanayama.k_y),
            k_theta: Some(l.kanayama.k_theta),
        },
    }
}

/// The core's [`ParamError`] as an error naming the TOML key under `prefix`: the core
/// names the field by its path in `RobotConfig`, which is the key under `[robot]`.
pub fn param_error(e: ParamError, prefix: &str) -> SectionError {
    keyed_error(&e, e.field(), prefix)
}

/// An error whose message starts with its `field`, as an error naming the TOML key
/// `prefix.field` and the rest of the message as the problem.
fn keyed_error(e: &impl std::fmt::Display, field: &str, prefix: &str) -> SectionError {
    let full = e.to_string();
    let problem = full
        .strip_prefix(field)
        .map_or(full.as_str(), str::trim_start)
        .to_string();
    SectionError::new(format!("{prefix}.{field}"), problem)
}

/// `[supervisor.missed_ticks]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissedTicksSection {
    /// Counting window, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_s: Option<f64>,
    /// Most missed ticks per window.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_per_window: Option<u32>,
    /// A gap of this many periods is a fault.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_gap_periods: Option<u32>,
}

/// `[supervisor.stall]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StallSection {
    /// Smallest armature voltage that must move the wheel, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_volts: Option<f32>,
    /// Slowest speed that counts as moving, rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_speed_rad_s: Option<f32>,
    /// How long before the fault, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timeout_s: Option<f64>,
}

/// `[supervisor.saturation]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SaturationSection {
    /// Window, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_s: Option<f64>,
    /// Largest fraction of the window a wheel loop may spend at its limits.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_fraction: Option<f32>,
}

/// `[supervisor.divergence]`: explicit settings (the key may also be "auto" or "off").
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DivergenceSection {
    /// Settling window after arming, s.
    pub settle_s: f64,
    /// Largest lasting tracking error, m.
    pub bound_m: f32,
    /// How long above the bound before the fault, s.
    pub persist_s: f64,
}

/// `[supervisor] divergence = …`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DivergenceSetting {
    /// `"auto"` or `"off"`.
    Keyword(Keyword),
    /// Explicit settings.
    Explicit(DivergenceSection),
}

/// `[supervisor]`: overrides of the supervisor's defaults (module doc).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupervisorSection {
    /// Disarm after this long armed, s, or "none".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub run_time_limit_s: Option<NumberOr>,
    /// Arm by itself this long after a power-on or pin reset, s, or "none".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_arm_after_s: Option<NumberOr>,
    /// Button debounce, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub debounce_s: Option<f64>,
    /// Long press, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub long_press_s: Option<f64>,
    /// Link heartbeat timeout, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heartbeat_timeout_s: Option<f64>,
    /// Braking time after disarming or a fault, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub brake_s: Option<f64>,
    /// Overruns in a row that are a fault.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_consecutive_overruns: Option<u32>,
    /// Background starvation timeout, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_timeout_s: Option<f64>,
    /// Low-battery warning, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub battery_warn_v: Option<f32>,
    /// Low-battery fault, V.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub battery_fault_v: Option<f32>,
    /// Battery debounce, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub battery_debounce_s: Option<f64>,
    /// Hold-mode wheel speeds [left, right], rad/s (exactly two numbers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hold_speeds_rad_s: Option<Vec<f32>>,
    /// Missed-tick limits.
    #[serde(default, skip_serializing_if = "is_default")]
    pub missed_ticks: MissedTicksSection,
    /// Stall detection.
    #[serde(default, skip_serializing_if = "is_default")]
    pub stall: StallSection,
    /// Saturated wheel loops.
    #[serde(default, skip_serializing_if = "is_default")]
    pub saturation: SaturationSection,
    /// Loss-of-control detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub divergence: Option<DivergenceSetting>,
    /// Geofence radius, m, or "auto" / "off".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub geofence_radius_m: Option<NumberOr>,
}

fn is_default<T: Default + PartialEq>(value: &T) -> bool {
    *value == T::default()
}

/// Seconds as control steps at `rate_hz`, rounded, at least 1; an error naming `key`
/// unless finite and ≥ 0.
fn steps(key: &str, seconds: f64, rate_hz: u32) -> Result<u32, SectionError> {
    if !(seconds.is_finite() && seconds >= 0.0) {
        return Err(SectionError::new(
            key,
            format_args!("must be ≥ 0 s, got {seconds}"),
        ));
    }
    let steps = (seconds * f64::from(rate_hz)).round();
    if steps > f64::from(u32::MAX) {
        return Err(SectionError::new(
            key,
            format_args!("is more than 2³² control steps, got {seconds} s"),
        ));
    }
    Ok((steps as u32).max(1))
}

fn optional_steps(key: &str, value: NumberOr, rate_hz: u32) -> Result<Option<u32>, SectionError> {
    match value {
        NumberOr::Number(s) => steps(key, s, rate_hz).map(Some),
        NumberOr::Keyword(Keyword::None | Keyword::Off) => Ok(None),
        NumberOr::Keyword(Keyword::Auto) => Err(SectionError::new(
            key,
            "takes a time in s or \"none\", not \"auto\"",
        )),
    }
}

/// Where the supervisor's path-derived checks come from: the reference the robot will
/// follow and where it starts.
#[derive(Clone, Copy, Debug)]
pub struct PathContext<'a> {
    /// The reference (path, speed, mode).
    pub reference: &'a Reference,
    /// The start pose, world frame.
    pub start: Pose,
}

impl SupervisorSection {
    /// The supervisor's settings for a robot with `params`: the defaults at its control
    /// rate, the path checks derived from `path` (when given and not overridden), then
    /// this section's values; validated. Errors name the TOML key under `prefix`.
    pub fn config(
        &self,
        params: &Params,
        path: Option<PathContext<'_>>,
        prefix: &str,
    ) -> Result<SupervisorConfig, SectionError> {
        let rate = params.config().control_rate_hz;
        let key = |k: &str| format!("{prefix}.{k}");
        let start = path.map_or(Pose::default(), |p| p.start);
        let mut c = SupervisorConfig::at_rate(rate, start, WheelSpeeds::new(5.0, 5.0));
        if let Some(p) = path {
            c = c.with_path_checks(p.reference, rate);
        }
        if let Some(v) = self.run_time_limit_s {
            c.max_armed_steps = optional_steps(&key("run_time_limit_s"), v, rate)?;
        }
        if let Some(v) = self.auto_arm_after_s {
            c.auto_arm_after_steps = optional_steps(&key("auto_arm_after_s"), v, rate)?;
        }
        if let Some(s) = self.debounce_s {
            c.debounce_steps = steps(&key("debounce_s"), s, rate)?;
        }
        if let Some(s) = self.long_press_s {
            c.long_press_steps = steps(&key("long_press_s"), s, rate)?;
        }
        if let Some(s) = self.heartbeat_timeout_s {
            c.heartbeat_timeout_steps = steps(&key("heartbeat_timeout_s"), s, rate)?;
        }
        if let Some(s) = self.brake_s {
            c.brake_steps = steps(&key("brake_s"), s, rate)?;
        }
        set(
            &mut c.max_consecutive_overruns,
            self.max_consecutive_overruns,
        );
        if let Some(s) = self.background_timeout_s {
            c.background_timeout_steps = steps(&key("background_timeout_s"), s, rate)?;
        }
        set(&mut c.battery.warn_v, self.battery_warn_v);
        set(&mut c.battery.fault_v, self.battery_fault_v);
        if let Some(s) = self.battery_debounce_s {
            c.battery.debounce_steps = steps(&key("battery_debounce_s"), s, rate)?;
        }
        if let Some(speeds) = &self.hold_speeds_rad_s {
            let [l, r] = speeds[..] else {
                return Err(SectionError::new(
                    key("hold_speeds_rad_s"),
                    format_args!("must have exactly 2 numbers, got {}", speeds.len()),
                ));
            };
            c.hold_speeds = WheelSpeeds::new(l, r);
        }
        let m = &self.missed_ticks;
        if let Some(s) = m.window_s {
            c.missed_ticks.window_steps = steps(&key("missed_ticks.window_s"), s, rate)?;
        }
        set(&mut c.missed_ticks.max_per_window, m.max_per_window);
        set(&mut c.missed_ticks.max_gap_periods, m.max_gap_periods);
        let s = &self.stall;
        set(&mut c.stall.min_volts, s.min_volts);
        set(&mut c.stall.min_speed_rad_s, s.min_speed_rad_s);
        if let Some(t) = s.timeout_s {
            c.stall.timeout_steps = steps(&key("stall.timeout_s"), t, rate)?;
        }
        let sat = &self.saturation;
        if let Some(w) = sat.window_s {
            c.saturation.window_steps = steps(&key("saturation.window_s"), w, rate)?;
        }
        set(&mut c.saturation.max_fraction, sat.max_fraction);
        c.divergence = match &self.divergence {
            None | Some(DivergenceSetting::Keyword(Keyword::Auto)) => c.divergence,
            Some(DivergenceSetting::Keyword(Keyword::Off | Keyword::None)) => None,
            Some(DivergenceSetting::Explicit(d)) => Some(DivergenceCheck {
                settle_steps: steps(&key("divergence.settle_s"), d.settle_s, rate)?,
                bound_m: d.bound_m,
                persist_steps: steps(&key("divergence.persist_s"), d.persist_s, rate)?,
            }),
        };
        c.geofence_radius_m = match self.geofence_radius_m {
            None | Some(NumberOr::Keyword(Keyword::Auto)) => c.geofence_radius_m,
            Some(NumberOr::Keyword(Keyword::Off | Keyword::None)) => None,
            Some(NumberOr::Number(r)) => Some(r as f32),
        };
        c.validate(params)
            .map_err(|e| supervisor_error(e, prefix))?;
        Ok(c)
    }

    /// Every field of `config` at `rate_hz`, for writing a complete file.
    pub fn of(config: &SupervisorConfig, rate_hz: u32) -> Self {
        let seconds = |steps: u32| f64::from(steps) / f64::from(rate_hz);
        let optional = |steps: Option<u32>| match steps {
            Some(s) => NumberOr::Number(seconds(s)),
            None => NumberOr::Keyword(Keyword::None),
        };
        Self {
            run_time_limit_s: Some(optional(config.max_armed_steps)),
            auto_arm_after_s: Some(optional(config.auto_arm_after_steps)),
            debounce_s: Some(seconds(config.debounce_steps)),
            long_press_s: Some(seconds(config.long_press_steps)),
            heartbeat_timeout_s: Some(seconds(config.heartbeat_timeout_steps)),
            brake_s: Some(seconds(config.brake_steps)),
            max_consecutive_overruns: Some(config.max_consecutive_overruns),
            background_timeout_s: Some(seconds(config.background_timeout_steps)),
            battery_warn_v: Some(config.battery.warn_v),
            battery_fault_v: Some(config.battery.fault_v),
            battery_debounce_s: Some(seconds(config.battery.debounce_steps)),
            hold_speeds_rad_s: Some(vec![
                config.hold_speeds.left_rad_s,
                config.hold_speeds.right_rad_s,
            ]),
            missed_ticks: missed_section(&config.missed_ticks, rate_hz),
            stall: stall_section(&config.stall, rate_hz),
            saturation: SaturationSection {
                window_s: Some(f64::from(config.saturation.window_steps) / f64::from(rate_hz)),
                max_fraction: Some(config.saturation.max_fraction),
            },
            divergence: Some(match config.divergence {
                None => DivergenceSetting::Keyword(Keyword::Off),
                Some(d) => DivergenceSetting::Explicit(DivergenceSection {
                    settle_s: seconds(d.settle_steps),
                    bound_m: d.bound_m,
                    persist_s: seconds(d.persist_steps),
                }),
            }),
            geofence_radius_m: Some(match config.geofence_radius_m {
                None => NumberOr::Keyword(Keyword::Off),
                Some(r) => NumberOr::Number(f64::from(r)),
            }),
        }
    }
}

fn missed_section(m: &MissedTickCheck, rate_hz: u32) -> MissedTicksSection {
    MissedTicksSection {
        window_s: Some(f64::from(m.window_steps) / f64::from(rate_hz)),
        max_per_window: Some(m.max_per_window),
        max_gap_periods: Some(m.max_gap_periods),
    }
}

fn stall_section(s: &StallCheck, rate_hz: u32) -> StallSection {
    StallSection {
        min_volts: Some(s.min_volts),
        min_speed_rad_s: Some(s.min_speed_rad_s),
        timeout_s: Some(f64::from(s.timeout_steps) / f64::from(rate_hz)),
    }
}

/// The core's [`SupervisorConfigError`] as an error naming the TOML key under `prefix`.
pub fn supervisor_error(e: SupervisorConfigError, prefix: &str) -> SectionError {
    keyed_error(&e, e.field(), prefix)
}

/// A robot file: `[robot]` and `[supervisor]`, what `station params get` writes and
/// `station params set` reads.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotFile {
    /// `[robot]`.
    #[serde(default)]
    pub robot: RobotSection,
    /// `[supervisor]`.
    #[serde(default)]
    pub supervisor: SupervisorSection,
}

impl RobotFile {
    /// Parses a robot file; a syntax error or an unknown key names the line.
    pub fn from_toml(text: &str) -> Result<Self, SectionError> {
        toml::from_str(text).map_err(|e| SectionError::new("file", e.to_string().trim_end()))
    }

    /// Both sections of a complete configuration.
    pub fn of(robot: &RobotConfig, supervisor: &SupervisorConfig) -> Self {
        Self {
            robot: RobotSection::of(robot),
            supervisor: SupervisorSection::of(supervisor, robot.control_rate_hz),
        }
    }

    /// The file as TOML text.
    pub fn to_toml(&self) -> String {
        // Every field is a number, a string keyword, a table or an array: this cannot fail.
        toml::to_string(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::prelude::{Path, Point, ReferenceMode};

    fn reference() -> Reference {
        let path = Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap();
        Reference::new(
            path,
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap()
    }

    #[test]
    fn a_complete_file_round_trips() {
        let mut robot = RobotConfig::REFERENCE_ROBOT;
        robot.wheel_radius_right_m = 0.033;
        robot.left_wheel.kp_v_per_rad_s = 0.7;
        let params = Params::new(robot).unwrap();
        let r = reference();
        let ctx = PathContext {
            reference: &r,
            start: Pose::new(1.0, 2.0, 0.5),
        };
        let mut supervisor = SupervisorSection::default()
            .config(&params, Some(ctx), "supervisor")
            .unwrap();
        supervisor.max_armed_steps = Some(120_000);
        let text = RobotFile::of(&robot, &supervisor).to_toml();
        let back = RobotFile::from_toml(&text).unwrap();
        assert_eq!(back.robot.apply(RobotConfig::REFERENCE_ROBOT), robot);
        let back_sup = back
            .supervisor
            .config(&params, Some(ctx), "supervisor")
            .unwrap();
        assert_eq!(back_sup, supervisor, "{text}");
    }

    #[test]
    fn errors_name_the_key() {
        let file = RobotFile::from_toml("[robot.motor]\nmax_current_a = -1.0\n").unwrap();
        let e = file
            .robot
            .params(RobotConfig::REFERENCE_ROBOT, "robot")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "robot.motor.max_current_a must be > 0, got -1"
        );
        let file = RobotFile::from_toml("[supervisor]\nbattery_fault_v = 3.0\n").unwrap();
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let e = file
            .supervisor
            .config(&params, None, "supervisor")
            .unwrap_err();
        assert!(
            e.to_string().starts_with("supervisor.battery thresholds"),
            "{e}"
        );
        let e = RobotFile::from_toml("[robot]\nwheel_radius = 0.03\n").unwrap_err();
        assert!(e.to_string().contains("wheel_radius"), "{e}");
        let file = RobotFile::from_toml("[supervisor]\nbrake_s = -1.0\n").unwrap();
        let e = file
            .supervisor
            .config(&params, None, "supervisor")
            .unwrap_err();
        assert_eq!(e.to_string(), "supervisor.brake_s must be ≥ 0 s, got -1");
    }

    #[test]
    fn keywords_switch_things_off_or_derive_them() {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let r = reference();
        let ctx = Some(PathContext {
            reference: &r,
            start: Pose::default(),
        });
        let auto = SupervisorSection::default()
            .config(&params, ctx, "supervisor")
            .unwrap();
        assert!(auto.divergence.is_some() && auto.geofence_radius_m.is_some());
        assert_eq!(auto.max_armed_steps, None);
        let file = RobotFile::from_toml(
            "[supervisor]\ndivergence = \"off\"\ngeofence_radius_m = \"off\"\nrun_time_limit_s = 120\n",
        )
        .unwrap();
        let off = file.supervisor.config(&params, ctx, "supervisor").unwrap();
        assert_eq!(off.divergence, None);
        assert_eq!(off.geofence_radius_m, None);
        assert_eq!(off.max_armed_steps, Some(120_000));
    }

    #[test]
    fn per_wheel_sections_override_both_wheels() {
        let file = RobotFile::from_toml(
            "[robot.wheels]\nkp_v_per_rad_s = 0.5\n[robot.right_wheel]\nkp_v_per_rad_s = 0.6\n",
        )
        .unwrap();
        let c = file.robot.apply(RobotConfig::REFERENCE_ROBOT);
        assert_eq!(c.left_wheel.kp_v_per_rad_s, 0.5);
        assert_eq!(c.right_wheel.kp_v_per_rad_s, 0.6);
    }
}
