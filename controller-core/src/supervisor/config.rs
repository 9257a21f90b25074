//! The supervisor's settings, their validation, and defaults derived from the control rate
//! and from the path.
//!
//! Every time is a count of control steps (1 ms at 1 kHz): the supervisor runs in the
//! control interrupt and counts its own steps, so a simulation or an emulator that runs
//! faster or slower than real time sees the same decisions.

use core::fmt;

use crate::kinematics::{Point, Pose, WheelSpeeds};
use crate::params::Params;
use crate::path::{Path, Segment};
use crate::reference::{Reference, ReferenceMode};

use super::RunMode;

/// Detects a wheel that does not follow its drive, from what the wheel does (its
/// encoder) against what its loop applies, whatever the heading is estimated from:
/// `timeout_steps` steps driven with |u| ≥ `min_volts` while turning slower than
/// `min_speed_rad_s` in the driven direction, with no step in between that saw the wheel
/// turn (a step neither driven nor turning takes one off the count). Catches a stalled or
/// blocked wheel, an unplugged motor or encoder and an encoder or motor wired with the
/// wrong polarity (the loop then runs away to its voltage limit). The count is not reset
/// by a step below `min_volts`: steering by the gyro, the outer loop turns a wheel with a
/// silent encoder down again and again, and the drive dips below any threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct StallCheck {
    /// Smallest |armature voltage| that must move the wheel, V (> 0).
    pub min_volts: f32,
    /// Slowest wheel speed in the driven direction that counts as moving, rad/s (≥ 0).
    pub min_speed_rad_s: f32,
    /// Control steps of "driven but not moving", net of the steps neither driven nor
    /// moving, before the fault (≥ 1).
    pub timeout_steps: u32,
}

/// A wheel loop that keeps hitting its limits: more than `max_fraction` of the last
/// `window_steps` steps with the wheel's PID held at its voltage or current limit. The
/// motor cannot do what the loop asks: swapped or unplugged encoder cables (the loops
/// thrash against their limits while odometry sees a plausible motion), a blocked or
/// overloaded wheel, a supply too weak for the path.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct SaturationCheck {
    /// Length of the window, steps (≥ 1).
    pub window_steps: u32,
    /// Largest fraction of the window a loop may spend saturated, in (0, 1].
    pub max_fraction: f32,
}

/// Missed control ticks (a step that started late and covered more than one period).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct MissedTickCheck {
    /// Length of the counting window, steps (≥ 1).
    pub window_steps: u32,
    /// More missed ticks than this within one window is a fault.
    pub max_per_window: u32,
    /// A single gap of this many periods or more (the loop was blind that long) is a fault
    /// (≥ 2).
    pub max_gap_periods: u32,
}

/// Loss of control: the controller's own tracking error stays above `bound_m` for
/// `persist_steps` once `settle_steps` have passed since arming into path following.
/// Catches a path the limits cannot follow, a motor too weak for the command, and cables
/// that make odometry see the wrong motion.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct DivergenceCheck {
    /// Steps after arming before the check starts (the initial transient), ≥ 0.
    pub settle_steps: u32,
    /// Largest position error the controller may report for long, m (> 0).
    pub bound_m: f32,
    /// Steps the error must stay above the bound before the fault (≥ 1).
    pub persist_steps: u32,
}

/// The battery, judged on the filtered supply measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct BatteryCheck {
    /// Below this the robot warns, V.
    pub warn_v: f32,
    /// Below this (for `debounce_steps`) it faults and stops, V; never below the
    /// bridge's minimum supply.
    pub fault_v: f32,
    /// Steps a low (or too high) supply must last before it counts, so the sag of a hard
    /// acceleration does not trip it (≥ 1).
    pub debounce_steps: u32,
}

/// The supervisor's settings. Times are in control steps (1 ms at 1 kHz).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct SupervisorConfig {
    /// Mode the robot is in after a reset (a press held for the mode-select time selects
    /// the next one, see `long_press_steps`).
    pub initial_mode: RunMode,
    /// The path's start pose (world frame, m and rad): where the robot is put down before
    /// a run. The odometry starts there after a reset, a long press while disarmed sets
    /// it there (the pose command, [`super::Supervisor::set_pose`]), and the geofence is
    /// centred on it. Arming never sets the pose.
    pub start_pose: Pose,
    /// Wheel speeds held in [`RunMode::HoldWheelSpeeds`], rad/s.
    pub hold_speeds: WheelSpeeds,
    /// Steps the button level must be stable before a press or release counts (≥ 1).
    pub debounce_steps: u32,
    /// Steps a press must last to count as long (> `debounce_steps`): released after
    /// that while disarmed, it sets the pose to `start_pose`; held
    /// [`super::MODE_SELECT_FACTOR`] times as long, it selects the next run mode instead.
    pub long_press_steps: u32,
    /// Arm by itself this many steps after a power-on or pin reset (`None`: button only).
    /// Happens at most once per boot, never after a watchdog, software or brown-out
    /// reset, and not once the button has been used.
    pub auto_arm_after_steps: Option<u32>,
    /// Disarm after this many steps armed, the step that arms among them (`None`: no
    /// limit).
    pub max_armed_steps: Option<u32>,
    /// This many overrun steps in a row are a fault and stop the watchdog feeding (≥ 1).
    pub max_consecutive_overruns: u32,
    /// Steps without a change of the background heartbeat before the watchdog is starved
    /// (≥ 1).
    pub background_timeout_steps: u32,
    /// Missed-tick limits.
    pub missed_ticks: MissedTickCheck,
    /// Stall / polarity detection.
    pub stall: StallCheck,
    /// Wheel loops stuck at their limits.
    pub saturation: SaturationCheck,
    /// Loss-of-control detection (`None`: off).
    pub divergence: Option<DivergenceCheck>,
    /// Largest distance of the estimated pose from the start pose while armed, m
    /// (`None`: no geofence).
    pub geofence_radius_m: Option<f32>,
    /// Battery thresholds.
    pub battery: BatteryCheck,
    /// When the link armed the robot: disarm after this many steps without a heartbeat
    /// (≥ 1). The button needs none.
    pub heartbeat_timeout_steps: u32,
    /// After disarming or a fault, the bridge short-brakes the motors for this many steps,
    /// then goes to standby (coast).
    pub brake_steps: u32,
}

/// Steps of a `rate_hz` loop in `ms` milliseconds, rounded down, at least 1.
pub const fn ms_to_steps(rate_hz: u32, ms: u32) -> u32 {
    let steps = rate_hz as u64 * ms as u64 / 1000;
    if steps == 0 {
        1
    } else if steps > u32::MAX as u64 {
        u32::MAX
    } else {
        steps as u32
    }
}

impl SupervisorConfig {
    /// Defaults for a loop at `control_rate_hz` (Hz): 20 ms debounce, 1 s long press, no
    /// auto-arm, no run limit, 5 overruns in a row, 500 ms background timeout, missed
    /// ticks: more than 20 in 1 s or a gap of 10 periods, a stall after 400 ms (net) at ≥ 1 V
    /// below 1 rad/s, a wheel loop saturated more than half of a 1 s window, no divergence
    /// check or geofence (they depend on the path: see
    /// [`SupervisorConfig::with_path_checks`]), battery warning at 5.0 V and fault at
    /// 4.6 V after 200 ms (a 4-cell NiMH pack on a TB6612FNG), 500 ms heartbeat timeout
    /// (as ROS's diff_drive_controller), 500 ms of braking. Starts in
    /// [`RunMode::FollowPath`] from `start_pose` (world frame, m and rad); `hold_speeds`
    /// in rad/s.
    pub const fn at_rate(control_rate_hz: u32, start_pose: Pose, hold_speeds: WheelSpeeds) -> Self {
        let debounce_steps = ms_to_steps(control_rate_hz, 20);
        let long_press_steps = ms_to_steps(control_rate_hz, 1000);
        Self {
            initial_mode: RunMode::FollowPath,
            start_pose,
            hold_speeds,
            debounce_steps,
            long_press_steps: if long_press_steps > debounce_steps {
                long_press_steps
            } else {
                debounce_steps + 1
            },
            auto_arm_after_steps: None,
            max_armed_steps: None,
            max_consecutive_overruns: 5,
            background_timeout_steps: ms_to_steps(control_rate_hz, 500),
            missed_ticks: MissedTickCheck {
                window_steps: ms_to_steps(control_rate_hz, 1000),
                max_per_window: 20,
                max_gap_periods: 10,
            },
            // 1 V turns a free wheel of the default motor at (1 − k_s)/k_V ≈ 4 rad/s: a
            // working wheel does not stay below 1 rad/s under it for most of 0.4 s.
            stall: StallCheck {
                min_volts: 1.0,
                min_speed_rad_s: 1.0,
                timeout_steps: ms_to_steps(control_rate_hz, 400),
            },
            saturation: SaturationCheck {
                window_steps: ms_to_steps(control_rate_hz, 1000),
                max_fraction: 0.5,
            },
            divergence: None,
            geofence_radius_m: None,
            battery: BatteryCheck {
                warn_v: 5.0,
                fault_v: 4.6,
                debounce_steps: ms_to_steps(control_rate_hz, 200),
            },
            heartbeat_timeout_steps: ms_to_steps(control_rate_hz, 500),
            brake_steps: ms_to_steps(control_rate_hz, 500),
        }
    }

    /// These settings with the divergence check and the geofence derived from the path
    /// `reference` follows and the start pose, at `control_rate_hz` (see
    /// [`DivergenceCheck::for_reference`] and [`geofence_radius_m`]).
    pub fn with_path_checks(mut self, reference: &Reference, control_rate_hz: u32) -> Self {
        self.divergence = Some(DivergenceCheck::for_reference(
            reference,
            &self.start_pose,
            control_rate_hz,
        ));
        self.geofence_radius_m = Some(geofence_radius_m(reference.path(), self.start_pose));
        self
    }

    /// Checks every field against itself and against the robot's `params` (the battery
    /// fault must not be below the bridge's minimum supply); the error names the first
    /// bad one.
    pub fn validate(&self, params: &Params) -> Result<(), SupervisorConfigError> {
        use SupervisorConfigError as E;
        if !self.start_pose.is_finite() {
            return Err(E::NonFiniteStartPose);
        }
        if !(self.hold_speeds.left_rad_s.is_finite() && self.hold_speeds.right_rad_s.is_finite()) {
            return Err(E::NonFiniteHoldSpeeds);
        }
        if self.debounce_steps == 0 || self.long_press_steps <= self.debounce_steps {
            return Err(E::BadButtonTiming);
        }
        if self.max_consecutive_overruns == 0 {
            return Err(E::ZeroOverrunLimit);
        }
        if self.background_timeout_steps == 0 {
            return Err(E::ZeroBackgroundTimeout);
        }
        let m = &self.missed_ticks;
        if m.window_steps == 0 || m.max_gap_periods < 2 {
            return Err(E::BadMissedTickCheck);
        }
        let s = &self.stall;
        let volts_ok = s.min_volts > 0.0 && s.min_volts.is_finite();
        let speed_ok = s.min_speed_rad_s >= 0.0 && s.min_speed_rad_s.is_finite();
        if !(volts_ok && speed_ok) || s.timeout_steps == 0 {
            return Err(E::BadStallCheck);
        }
        let sat = &self.saturation;
        if sat.window_steps == 0 || !(sat.max_fraction > 0.0 && sat.max_fraction <= 1.0) {
            return Err(E::BadSaturationCheck);
        }
        if let Some(d) = self.divergence {
            if !(d.bound_m > 0.0 && d.bound_m.is_finite()) || d.persist_steps == 0 {
                return Err(E::BadDivergenceCheck);
            }
        }
        if let Some(r) = self.geofence_radius_m {
            if !(r > 0.0 && r.is_finite()) {
                return Err(E::BadGeofence);
            }
        }
        let b = &self.battery;
        let min_supply_v = params.config().drive.min_supply_v;
        if !(b.fault_v >= min_supply_v && b.warn_v >= b.fault_v && b.warn_v.is_finite()) {
            return Err(E::BadBatteryThresholds {
                warn_v: b.warn_v,
                fault_v: b.fault_v,
                min_supply_v,
            });
        }
        if b.debounce_steps == 0 {
            return Err(E::BadBatteryThresholds {
                warn_v: b.warn_v,
                fault_v: b.fault_v,
                min_supply_v,
            });
        }
        if self.heartbeat_timeout_steps == 0 {
            return Err(E::ZeroHeartbeatTimeout);
        }
        Ok(())
    }
}

impl DivergenceCheck {
    /// Defaults for following `reference` from `start` (world frame) at `control_rate_hz`:
    /// the bound is 0.25 m plus the look-ahead plus one second of reference travel (0.5 m
    /// at the paper's 0.25 m/s; the paper's own law trails by ≈ v_r/γ = 0.25 m), the error
    /// must persist for 1 s, and the check starts once the robot has had 3 s plus twice
    /// the time to cover its initial distance to the path at the reference speed (a day
    /// or more of that, from a start far from a slow path, means never: `u32::MAX`).
    pub fn for_reference(reference: &Reference, start: &Pose, control_rate_hz: u32) -> Self {
        let speed = reference.speed_m_s();
        let lookahead = match reference.mode() {
            ReferenceMode::PathFollowing { lookahead_m } => lookahead_m,
            ReferenceMode::TimeIndexed { .. } => 0.0,
        };
        let path = reference.path();
        let nearest =
            path.sample(path.project(start.position(), 0.0, f32::INFINITY, f32::INFINITY));
        let initial_m = start.position().distance_to(nearest.point);
        let settle_s = 3.0 + 2.0 * initial_m / speed;
        let settle_steps = if settle_s.is_finite() && settle_s < 86_400.0 {
            (settle_s * control_rate_hz as f32) as u32
        } else {
            u32::MAX
        };
        Self {
            settle_steps,
            bound_m: 0.25 + lookahead + speed,
            persist_steps: ms_to_steps(control_rate_hz, 1000),
        }
    }
}

/// Default geofence radius for a robot starting at `start` on `path`: the farthest point
/// of the path from the start, plus 1 m, m.
pub fn geofence_radius_m(path: &Path, start: Pose) -> f32 {
    let origin = start.position();
    let farthest = path
        .segments()
        .iter()
        .map(|segment| farthest_distance_m(segment, origin))
        .fold(0.0f32, |a, b| if b > a { b } else { a });
    farthest + 1.0
}

/// Largest distance from `p` to any point of `segment`, m.
fn farthest_distance_m(segment: &Segment, p: Point) -> f32 {
    match *segment {
        Segment::Line {
            start,
            heading_rad,
            length_m,
        } => {
            let (s, c) = crate::math::sin_cos(heading_rad);
            let end = Point::new(start.x_m + length_m * c, start.y_m + length_m * s);
            max(p.distance_to(start), p.distance_to(end))
        }
        Segment::Arc {
            center,
            radius_m,
            start_angle_rad,
            sweep_rad,
        } => {
            let at = |a: f32| {
                let (s, c) = crate::math::sin_cos(a);
                Point::new(center.x_m + radius_m * c, center.y_m + radius_m * s)
            };
            let ends = max(
                p.distance_to(at(start_angle_rad)),
                p.distance_to(at(start_angle_rad + sweep_rad)),
            );
            // The farthest point of the full circle is opposite p; it counts if the arc
            // sweeps over it.
            let away = crate::math::atan2(center.y_m - p.y_m, center.x_m - p.x_m);
            let offset = crate::math::wrap_angle(away - start_angle_rad);
            let swept = if sweep_rad >= 0.0 {
                let o = if offset < 0.0 {
                    offset + core::f32::consts::TAU
                } else {
                    offset
                };
                o <= sweep_rad
            } else {
                let o = if offset > 0.0 {
                    offset - core::f32::consts::TAU
                } else {
                    offset
                };
                o >= sweep_rad
            };
            if swept {
                max(ends, p.distance_to(center) + radius_m)
            } else {
                ends
            }
        }
    }
}

fn max(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// Why a [`SupervisorConfig`] was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum SupervisorConfigError {
    /// `start_pose` has a NaN or infinite field.
    NonFiniteStartPose,
    /// `hold_speeds` has a NaN or infinite field.
    NonFiniteHoldSpeeds,
    /// `debounce_steps` was 0 or `long_press_steps` ≤ `debounce_steps`.
    BadButtonTiming,
    /// `max_consecutive_overruns` was 0.
    ZeroOverrunLimit,
    /// `background_timeout_steps` was 0.
    ZeroBackgroundTimeout,
    /// `missed_ticks.window_steps` was 0 or `missed_ticks.max_gap_periods` < 2.
    BadMissedTickCheck,
    /// `stall.min_volts` ≤ 0 or not finite, `stall.min_speed_rad_s` < 0 or not finite, or
    /// `stall.timeout_steps` 0.
    BadStallCheck,
    /// `saturation.window_steps` 0 or `saturation.max_fraction` outside (0, 1].
    BadSaturationCheck,
    /// `divergence.bound_m` ≤ 0 or not finite, or `divergence.persist_steps` 0.
    BadDivergenceCheck,
    /// `geofence_radius_m` ≤ 0 or not finite.
    BadGeofence,
    /// The battery thresholds are out of order: the bridge's minimum ≤ `fault_v` ≤
    /// `warn_v` is required (and `battery.debounce_steps` ≥ 1).
    BadBatteryThresholds {
        /// `battery.warn_v`, V.
        warn_v: f32,
        /// `battery.fault_v`, V.
        fault_v: f32,
        /// The bridge's `drive.min_supply_v`, V.
        min_supply_v: f32,
    },
    /// `heartbeat_timeout_steps` was 0.
    ZeroHeartbeatTimeout,
}

impl SupervisorConfigError {
    /// The offending field's path in [`SupervisorConfig`].
    pub const fn field(&self) -> &'static str {
        use SupervisorConfigError as E;
        match self {
            E::NonFiniteStartPose => "start_pose",
            E::NonFiniteHoldSpeeds => "hold_speeds",
            E::BadButtonTiming => "long_press_steps",
            E::ZeroOverrunLimit => "max_consecutive_overruns",
            E::ZeroBackgroundTimeout => "background_timeout_steps",
            E::BadMissedTickCheck => "missed_ticks",
            E::BadStallCheck => "stall",
            E::BadSaturationCheck => "saturation",
            E::BadDivergenceCheck => "divergence",
            E::BadGeofence => "geofence_radius_m",
            E::BadBatteryThresholds { .. } => "battery",
            E::ZeroHeartbeatTimeout => "heartbeat_timeout_steps",
        }
    }

    /// What the field must satisfy, without its value (for a refusal that carries no
    /// formatted numbers, e.g. over the runtime link).
    pub const fn requirement(&self) -> &'static str {
        use SupervisorConfigError as E;
        match self {
            E::NonFiniteStartPose | E::NonFiniteHoldSpeeds => "must be finite",
            E::BadButtonTiming => "must exceed debounce_steps (≥ 1)",
            E::ZeroOverrunLimit | E::ZeroBackgroundTimeout | E::ZeroHeartbeatTimeout => {
                "must be ≥ 1"
            }
            E::BadMissedTickCheck => "needs window_steps ≥ 1, max_gap_periods ≥ 2",
            E::BadStallCheck => "needs min_volts > 0, speed ≥ 0, timeout ≥ 1",
            E::BadSaturationCheck => "needs window_steps ≥ 1, max_fraction in (0, 1]",
            E::BadDivergenceCheck => "needs bound_m > 0 and persist_steps ≥ 1",
            E::BadGeofence => "must be > 0",
            E::BadBatteryThresholds { .. } => "needs min supply ≤ fault_v ≤ warn_v",
        }
    }
}

impl fmt::Display for SupervisorConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use SupervisorConfigError as E;
        let field = self.field();
        match *self {
            E::NonFiniteStartPose | E::NonFiniteHoldSpeeds => {
                write!(f, "{field} must be finite")
            }
            E::BadButtonTiming => write!(
                f,
                "debounce_steps must be ≥ 1 and {field} longer than debounce_steps"
            ),
            E::ZeroOverrunLimit | E::ZeroBackgroundTimeout | E::ZeroHeartbeatTimeout => {
                write!(f, "{field} must be ≥ 1")
            }
            E::BadMissedTickCheck => write!(
                f,
                "{field}.window_steps must be ≥ 1 and {field}.max_gap_periods ≥ 2"
            ),
            E::BadStallCheck => write!(
                f,
                "{field}.min_volts must be > 0, {field}.min_speed_rad_s ≥ 0 and \
                 {field}.timeout_steps ≥ 1"
            ),
            E::BadSaturationCheck => write!(
                f,
                "{field}.window_steps must be ≥ 1 and {field}.max_fraction in (0, 1]"
            ),
            E::BadDivergenceCheck => write!(
                f,
                "{field}.bound_m must be > 0 and {field}.persist_steps ≥ 1"
            ),
            E::BadGeofence => write!(f, "{field} must be > 0"),
            E::BadBatteryThresholds {
                warn_v,
                fault_v,
                min_supply_v,
            } => write!(
                f,
                "{field} thresholds must satisfy {min_supply_v} V (the bridge's minimum) ≤ \
                 fault_v ≤ warn_v, got fault_v = {fault_v} V, warn_v = {warn_v} V"
            ),
        }
    }
}

impl core::error::Error for SupervisorConfigError {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Point;
    use crate::params::RobotConfig;

    fn params() -> Params {
        Params::new(RobotConfig::REFERENCE_ROBOT).unwrap()
    }

    #[test]
    fn ms_to_steps_rounds_down_and_never_returns_zero() {
        assert_eq!(ms_to_steps(1000, 20), 20);
        assert_eq!(ms_to_steps(500, 21), 10);
        assert_eq!(ms_to_steps(1000, 0), 1);
        assert_eq!(ms_to_steps(10, 50), 1);
        assert_eq!(ms_to_steps(u32::MAX, u32::MAX), u32::MAX);
        assert_eq!(ms_to_steps(100_000, 1000), 100_000);
    }

    #[test]
    fn every_bound_is_where_the_doc_says() {
        type Edit = fn(&mut SupervisorConfig);
        const fn divergence(bound_m: f32, persist_steps: u32) -> Option<DivergenceCheck> {
            Some(DivergenceCheck {
                settle_steps: 0,
                bound_m,
                persist_steps,
            })
        }
        // Each rule just inside its bound (accepted) and just outside it (refused, with
        // the field named).
        let cases: &[(Edit, Result<(), &str>)] = &[
            (|c| (c.debounce_steps, c.long_press_steps) = (1, 2), Ok(())),
            (
                |c| c.long_press_steps = c.debounce_steps,
                Err("long_press_steps"),
            ),
            (|c| c.max_consecutive_overruns = 1, Ok(())),
            (|c| c.background_timeout_steps = 1, Ok(())),
            (|c| c.missed_ticks.window_steps = 1, Ok(())),
            (|c| c.missed_ticks.window_steps = 0, Err("missed_ticks")),
            (|c| c.missed_ticks.max_gap_periods = 2, Ok(())),
            (|c| c.missed_ticks.max_gap_periods = 1, Err("missed_ticks")),
            (|c| c.stall.min_volts = f32::MIN_POSITIVE, Ok(())),
            (|c| c.stall.min_volts = f32::INFINITY, Err("stall")),
            (|c| c.stall.min_speed_rad_s = 0.0, Ok(())),
            (|c| c.stall.min_speed_rad_s = f32::NAN, Err("stall")),
            (|c| c.stall.timeout_steps = 1, Ok(())),
            (|c| c.saturation.window_steps = 1, Ok(())),
            (|c| c.saturation.window_steps = 0, Err("saturation")),
            (|c| c.saturation.max_fraction = 1.0, Ok(())),
            (|c| c.saturation.max_fraction = 1.001, Err("saturation")),
            (|c| c.saturation.max_fraction = 1e-6, Ok(())),
            (|c| c.saturation.max_fraction = 0.0, Err("saturation")),
            (|c| c.saturation.max_fraction = f32::NAN, Err("saturation")),
            (|c| c.divergence = divergence(1e-6, 1), Ok(())),
            (|c| c.divergence = divergence(0.0, 1), Err("divergence")),
            (
                |c| c.divergence = divergence(f32::INFINITY, 1),
                Err("divergence"),
            ),
            (|c| c.divergence = divergence(0.5, 0), Err("divergence")),
            (|c| c.geofence_radius_m = Some(1e-6), Ok(())),
            (
                |c| c.geofence_radius_m = Some(0.0),
                Err("geofence_radius_m"),
            ),
            (
                |c| c.geofence_radius_m = Some(f32::INFINITY),
                Err("geofence_radius_m"),
            ),
            // The reference robot's bridge needs 4.5 V.
            (
                |c| (c.battery.fault_v, c.battery.warn_v) = (4.5, 4.5),
                Ok(()),
            ),
            (|c| c.battery.fault_v = 4.49, Err("battery")),
            (
                |c| c.battery.warn_v = c.battery.fault_v - 0.01,
                Err("battery"),
            ),
            (|c| c.battery.warn_v = f32::INFINITY, Err("battery")),
            (|c| c.battery.debounce_steps = 1, Ok(())),
            (|c| c.battery.debounce_steps = 0, Err("battery")),
            (|c| c.heartbeat_timeout_steps = 1, Ok(())),
        ];
        for (i, (edit, expected)) in cases.iter().enumerate() {
            let mut c = SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::default());
            edit(&mut c);
            assert_eq!(
                c.validate(&params()).map_err(|e| e.field()),
                *expected,
                "case {i}: {c:?}"
            );
        }
    }

    #[test]
    fn defaults_are_valid_at_any_rate() {
        for rate in [1, 100, 1000, 20_000] {
            let c = SupervisorConfig::at_rate(rate, Pose::default(), WheelSpeeds::default());
            assert_eq!(c.validate(&params()), Ok(()), "{rate} Hz");
        }
        let c = SupervisorConfig::at_rate(500, Pose::default(), WheelSpeeds::default());
        assert_eq!(c.debounce_steps, 10);
        assert_eq!(c.long_press_steps, 500);
        assert_eq!(c.heartbeat_timeout_steps, 250);
    }

    #[test]
    fn battery_fault_below_the_bridge_minimum_is_refused() {
        let mut c = SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::default());
        c.battery.fault_v = 4.0;
        let e = c.validate(&params()).unwrap_err();
        assert_eq!(e.field(), "battery");
        assert!(
            format!("{e}").contains("4.5 V (the bridge's minimum)"),
            "{e}"
        );
        c.battery.fault_v = 5.5;
        assert!(c.validate(&params()).is_err(), "fault above warn");
    }

    #[test]
    fn geofence_covers_the_whole_path() {
        // The paper's circle r = 1.25 about the origin, robot starting at (−1, −1.2): the
        // farthest point of the circle is diametrically opposite, at 1.562 + 1.25 m.
        let circle = Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap();
        let r = geofence_radius_m(&circle, Pose::new(-1.0, -1.2, 0.0));
        assert!((r - (1.562_05 + 1.25 + 1.0)).abs() < 1e-3, "{r}");
        // A 2 m line from the origin, start at its beginning: 2 m + 1 m.
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).unwrap();
        assert!((geofence_radius_m(&line, Pose::default()) - 3.0).abs() < 1e-5);
    }

    #[test]
    fn the_far_side_of_an_arc_counts_only_if_the_arc_reaches_it() {
        // A quarter arc from angle 0 to π/2 (counter-clockwise) about the origin, r = 1,
        // seen from (−2, 0): the far side of the circle (angle 0, at x = 1) is the arc's
        // start: 3 m. Seen from (2, 0), the far side (angle π) is not on the arc: the
        // farthest point is the end (0, 1), √5 m away.
        let arc = Segment::Arc {
            center: Point::new(0.0, 0.0),
            radius_m: 1.0,
            start_angle_rad: 0.0,
            sweep_rad: core::f32::consts::FRAC_PI_2,
        };
        assert!((farthest_distance_m(&arc, Point::new(-2.0, 0.0)) - 3.0).abs() < 1e-5);
        assert!((farthest_distance_m(&arc, Point::new(2.0, 0.0)) - 5f32.sqrt()).abs() < 1e-5);
        // Swept clockwise from π/2 to 0 (the same quarter), from (−1, −1): the far side
        // at angle π/4 is on it: √2 + 1.
        let cw = Segment::Arc {
            center: Point::new(0.0, 0.0),
            radius_m: 1.0,
            start_angle_rad: core::f32::consts::FRAC_PI_2,
            sweep_rad: -core::f32::consts::FRAC_PI_2,
        };
        let d = farthest_distance_m(&cw, Point::new(-1.0, -1.0));
        assert!((d - (2f32.sqrt() + 1.0)).abs() < 1e-5, "{d}");
    }

    /// The farthest of `n + 1` evenly spaced points along `segment` (its own
    /// `Segment::sample`) from `p`, m.
    fn farthest_sampled_m(segment: &Segment, p: Point, n: u32) -> f64 {
        let length_m = segment.length_m();
        (0..=n)
            .map(|i| {
                let point = segment.sample(length_m * i as f32 / n as f32).point;
                f64::from(point.x_m - p.x_m).hypot(f64::from(point.y_m - p.y_m))
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_farthest_point_of_any_line_or_arc_is_found() {
        // Against a dense sampling, from points all around: never less than the farthest
        // sample, and not more than the sampling's gap (0.6 mm) above it.
        let coordinates = [-3.1, -1.0, -0.3, 0.45, 2.2];
        let points = coordinates
            .iter()
            .flat_map(|x| coordinates.iter().map(|y| Point::new(*x, *y)));
        let mut segments = std::vec::Vec::new();
        for start_angle_rad in [-3.0, -1.2, 0.0, 0.7, 2.5] {
            for sweep_rad in [-6.0, -2.0, -0.5, 0.5, 2.0, 6.0] {
                segments.push(Segment::Arc {
                    center: Point::new(0.5, -0.2),
                    radius_m: 1.3,
                    start_angle_rad,
                    sweep_rad,
                });
            }
            segments.push(Segment::Line {
                start: Point::new(-0.7, 0.9),
                heading_rad: start_angle_rad,
                length_m: 2.4,
            });
        }
        for p in points {
            for segment in &segments {
                let found = f64::from(farthest_distance_m(segment, p));
                let sampled = farthest_sampled_m(segment, p, 20_000);
                assert!(
                    found >= sampled - 1e-5 && found <= sampled + 6e-4,
                    "{segment:?} from {p:?}: {found} vs {sampled}"
                );
            }
        }
    }

    #[test]
    fn the_geofence_reaches_the_farthest_segment() {
        // An L: 2 m east, then 3 m north; from the start the corner is 2 m away and the
        // end √13 m: the radius is that plus 1 m, whichever segment comes first.
        let corners = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 3.0),
        ];
        for points in [corners, [corners[2], corners[1], corners[0]]] {
            let path = Path::polyline(&points, 0.0, false).unwrap();
            let r = geofence_radius_m(&path, Pose::default());
            assert!((r - (13f32.sqrt() + 1.0)).abs() < 1e-5, "{points:?}: {r}");
        }
    }

    #[test]
    fn each_requirement_states_its_bound() {
        use SupervisorConfigError as E;
        let cases = [
            (E::NonFiniteStartPose, "finite"),
            (E::BadButtonTiming, "exceed debounce_steps"),
            (E::ZeroOverrunLimit, "≥ 1"),
            (E::BadMissedTickCheck, "max_gap_periods ≥ 2"),
            (E::BadStallCheck, "min_volts > 0"),
            (E::BadSaturationCheck, "max_fraction in (0, 1]"),
            (E::BadDivergenceCheck, "bound_m > 0"),
            (E::BadGeofence, "> 0"),
            (
                E::BadBatteryThresholds {
                    warn_v: 5.0,
                    fault_v: 6.0,
                    min_supply_v: 4.5,
                },
                "fault_v ≤ warn_v",
            ),
        ];
        for (error, bound) in cases {
            assert!(error.requirement().contains(bound), "{error:?}");
        }
    }

    #[test]
    fn divergence_defaults_follow_the_reference() {
        let circle = Path::circle(Point::new(0.0, 0.0), 1.25, -2.265, true).unwrap();
        let reference = Reference::new(
            circle,
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let d = DivergenceCheck::for_reference(&reference, &Pose::new(-1.0, -1.2, 2.09), 1000);
        assert!((d.bound_m - 0.5).abs() < 1e-6);
        assert_eq!(d.persist_steps, 1000);
        // 0.312 m from the circle at 0.25 m/s: 3 s + 2 · 1.25 s.
        assert!((5400..5600).contains(&d.settle_steps), "{}", d.settle_steps);
        // Following the path with a 0.3 m look-ahead: the bound grows by it.
        let ahead = Reference::new(
            reference.path().clone(),
            0.25,
            ReferenceMode::PathFollowing { lookahead_m: 0.3 },
        )
        .unwrap();
        let d = DivergenceCheck::for_reference(&ahead, &Pose::new(-1.0, -1.2, 2.09), 1000);
        assert!((d.bound_m - 0.8).abs() < 1e-6, "{d:?}");
        // 100 m from a path followed at 1 mm/s: 2·10⁵ s to settle, more than a day.
        let slow = Reference::new(
            Path::line(Point::new(0.0, 0.0), 0.0, 2.0).unwrap(),
            1e-3,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let far = DivergenceCheck::for_reference(&slow, &Pose::new(0.0, 100.0, 0.0), 1000);
        assert_eq!(far.settle_steps, u32::MAX);
        let near = DivergenceCheck::for_reference(&slow, &Pose::new(0.0, 10.0, 0.0), 1000);
        // 3 s + 2·10⁴ s, under a day.
        assert!(
            (near.settle_steps as f32 - 20_003_000.0).abs() < 2_000.0,
            "{near:?}"
        );
    }
}
