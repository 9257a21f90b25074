//! `[supervisor]`: the supervisor's settings in seconds, turned into control steps at the
//! robot's rate, with the path-derived checks (`divergence`, `geofence_radius_m`) derived
//! from the path unless set.

use controller_core::params::Params;
use controller_core::prelude::{Pose, Reference, WheelSpeeds};
use controller_core::supervisor::{DivergenceCheck, MissedTickCheck, StallCheck, SupervisorConfig};
use serde::{Deserialize, Serialize};

use super::{set, supervisor_error, Keyword, NumberOr, SectionError};

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
