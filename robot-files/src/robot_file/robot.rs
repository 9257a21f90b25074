//! `[robot]`: what the controller believes about the robot, over a base configuration.

use controller_core::law::{KanayamaGains, LawGains, PaperGains, TrackingGains};
use controller_core::params::{DriveConfig, MotorConfig, Params, RobotConfig, WheelLoopConfig};
use controller_core::tune::TuneResult;
use controller_core::velocity::AxisLimits;
use controller_core::wiring::WiringConfig;
use serde::{Deserialize, Serialize};

use super::gyro::GyroSection;
use super::{param_error, set, SectionError};

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

/// `[robot.velocity.linear_x]`, `[robot.velocity.angular_z]`: one axis of the velocity
/// mode (`diff_drive_controller`'s `linear.x.*`, `angular.z.*`), in the axis's units
/// (m/s, m/s², m/s³; rad/s, rad/s², rad/s³).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisSection {
    /// Largest |velocity|.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_velocity: Option<f32>,
    /// Largest |acceleration|.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_acceleration: Option<f32>,
    /// Largest |jerk|.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_jerk: Option<f32>,
}

impl AxisSection {
    fn apply(&self, axis: &mut AxisLimits) {
        set(&mut axis.max_velocity, self.max_velocity);
        set(&mut axis.max_acceleration, self.max_acceleration);
        set(&mut axis.max_jerk, self.max_jerk);
    }

    fn of(axis: &AxisLimits) -> Self {
        Self {
            max_velocity: Some(axis.max_velocity),
            max_acceleration: Some(axis.max_acceleration),
            max_jerk: Some(axis.max_jerk),
        }
    }
}

/// `[robot.velocity]`: the velocity mode's limits and command timeout.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocitySection {
    /// Forward speed's limits.
    #[serde(default)]
    pub linear_x: AxisSection,
    /// Yaw rate's limits.
    #[serde(default)]
    pub angular_z: AxisSection,
    /// `cmd_vel_timeout`, control steps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_vel_timeout_steps: Option<u32>,
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

/// `[robot.wiring]`: the wiring corrections (`controller_core::wiring`), which
/// `station bringup` finds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WiringSection {
    /// The left motor turns its wheel backward for a positive duty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_motor_inverted: Option<bool>,
    /// The right motor turns its wheel backward for a positive duty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub right_motor_inverted: Option<bool>,
    /// The motors are on each other's board outputs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motors_swapped: Option<bool>,
    /// The left encoder counts down when its wheel turns forward.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_encoder_inverted: Option<bool>,
    /// The right encoder counts down when its wheel turns forward.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub right_encoder_inverted: Option<bool>,
    /// The encoders are on each other's board inputs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub encoders_swapped: Option<bool>,
    /// True supply over the board's reading of it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supply_scale: Option<f32>,
}

impl WiringSection {
    fn apply(&self, w: &mut WiringConfig) {
        set(&mut w.left_motor_inverted, self.left_motor_inverted);
        set(&mut w.right_motor_inverted, self.right_motor_inverted);
        set(&mut w.motors_swapped, self.motors_swapped);
        set(&mut w.left_encoder_inverted, self.left_encoder_inverted);
        set(&mut w.right_encoder_inverted, self.right_encoder_inverted);
        set(&mut w.encoders_swapped, self.encoders_swapped);
        set(&mut w.supply_scale, self.supply_scale);
    }

    fn of(w: &WiringConfig) -> Self {
        Self {
            left_motor_inverted: Some(w.left_motor_inverted),
            right_motor_inverted: Some(w.right_motor_inverted),
            motors_swapped: Some(w.motors_swapped),
            left_encoder_inverted: Some(w.left_encoder_inverted),
            right_encoder_inverted: Some(w.right_encoder_inverted),
            encoders_swapped: Some(w.encoders_swapped),
            supply_scale: Some(w.supply_scale),
        }
    }
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
    /// The velocity mode.
    #[serde(default)]
    pub velocity: VelocitySection,
    /// Wiring corrections.
    #[serde(default)]
    pub wiring: WiringSection,
    /// The gyro.
    #[serde(default)]
    pub gyro: GyroSection,
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
        self.velocity.linear_x.apply(&mut c.velocity.linear_x);
        self.velocity.angular_z.apply(&mut c.velocity.angular_z);
        set(
            &mut c.velocity.cmd_vel_timeout_steps,
            self.velocity.cmd_vel_timeout_steps,
        );
        self.wiring.apply(&mut c.wiring);
        self.gyro.apply(&mut c.gyro);
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
            velocity: VelocitySection {
                linear_x: AxisSection::of(&config.velocity.linear_x),
                angular_z: AxisSection::of(&config.velocity.angular_z),
                cmd_vel_timeout_steps: Some(config.velocity.cmd_vel_timeout_steps),
            },
            wiring: WiringSection::of(&config.wiring),
            gyro: GyroSection::of(&config.gyro),
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

/// The tuned wheel loops of `result` as robot-file sections (`[robot.left_wheel]`,
/// `[robot.right_wheel]`; gains in V, V per rad/s and s), ready to paste into a robot
/// file's `[robot]` part.
pub fn tuned_wheel_sections(result: &TuneResult) -> String {
    let mut out = String::new();
    for (name, w) in ["left_wheel", "right_wheel"].iter().zip(result.loops) {
        out.push_str(&format!(
            "[robot.{name}]\nks_v = {}\nkv_v_per_rad_s = {}\nkp_v_per_rad_s = {}\nti_s = {}\n\
td_s = {}\nd_filter_tau_s = {}\n",
            w.ks_v, w.kv_v_per_rad_s, w.kp_v_per_rad_s, w.ti_s, w.td_s, w.d_filter_tau_s
        ));
    }
    out
}
