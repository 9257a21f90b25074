//! The words of the tune: its settings and their errors, the load the wheels turn, what
//! it asks for each step, and how it ends ([`TuneResult`] or [`TuneAbort`]).

use core::fmt;

use crate::drive::WheelVolts;
use crate::params::{Params, RobotConfig, WheelLoopConfig};

/// One of the two wheels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Side {
    /// The left wheel.
    Left,
    /// The right wheel.
    Right,
}

impl Side {
    pub(super) const BOTH: [Side; 2] = [Side::Left, Side::Right];
}

/// What the wheels turn during the tune.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum TuneLoad {
    /// The robot on the floor: the identified plant is the driving plant. The tune drives
    /// up to 90 % of [`TuneConfig::max_distance_m`] forward and back (about 0.7 m, the
    /// reference robot).
    Ground,
    /// The robot on a stand: the identified τ is multiplied by `ground_inertia_factor`
    /// (the driving inertia over the lifted one, ≥ 1 and < 1 000) before the PI is set.
    Lifted {
        /// (J_w + m R²/2) / J_w, see [`TuneLoad::lifted`].
        ground_inertia_factor: f32,
    },
}

impl TuneLoad {
    /// The lifted load of a robot of mass `chassis_mass_kg` (kg) on wheels of radius
    /// `wheel_radius_m` (m) whose own inertia, rotor reflected through the gearbox
    /// included, is `wheel_inertia_kg_m2` (kg·m²): factor 1 + m R² / (2 J_w). The
    /// reference robot: 0.5 kg, 32.5 mm, 1.1e-4 kg·m², factor 3.4.
    pub fn lifted(chassis_mass_kg: f32, wheel_radius_m: f32, wheel_inertia_kg_m2: f32) -> Self {
        TuneLoad::Lifted {
            ground_inertia_factor: 1.0
                + chassis_mass_kg * wheel_radius_m * wheel_radius_m / (2.0 * wheel_inertia_kg_m2),
        }
    }
}

/// How the tune drives the wheels (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TuneConfig {
    /// The largest voltage the experiments apply, V (≤ the motor's rated voltage): the
    /// breakaway ramp's ceiling and the step's; the step's level u_hi is planned below
    /// it from the hold (the module doc).
    pub experiment_volts_v: f32,
    /// Rate of the breakaway ramp, V/s (> 0 and < 1 000).
    pub breakaway_ramp_v_per_s: f32,
    /// The longest hold before the step, and the longest step, s (0.1 to 10 s, and at
    /// least 50 control periods). Their lengths follow the wheel's own time constant
    /// up to this; a step cut short by it is reported
    /// ([`TuneWarnings::step_not_settled`]).
    pub max_hold_s: f32,
    /// A wheel faster than this stops the tune, rad/s (> 0 and < 10⁴).
    pub max_speed_rad_s: f32,
    /// On the ground, the odometry farther than this from where the tune began stops it,
    /// m (> 0 and < 1 000).
    pub max_distance_m: f32,
    /// SIMC's closed-loop time constant over the loop's effective dead time (1 is
    /// Skogestad's "tight" setting; larger is slower and more robust; > 0 and < 100).
    pub tau_c_per_dead_time: f32,
    /// On the ground or lifted.
    pub load: TuneLoad,
}

impl TuneConfig {
    /// The defaults for `robot`: at most 80 % of the rated voltage (4.8 V: the breakaway
    /// of a motor with three times the reference's friction, 40 % less torque constant
    /// and 40 % more resistance is 2.5 V), breakaway ramp 0.5 V/s, holds and steps of
    /// at most 4 s (8 τ of that motor with 40 % more inertia), 75 % of the rated top
    /// speed, 1.5 m, τ_c = 1.2 θ_e, on the ground.
    pub fn for_robot(robot: &RobotConfig) -> Self {
        let rated = robot.motor.rated_voltage_v;
        let top = robot.left_wheel.speed_at_volts(rated);
        Self {
            experiment_volts_v: 0.8 * rated,
            breakaway_ramp_v_per_s: 0.5,
            max_hold_s: 4.0,
            max_speed_rad_s: 0.75 * top,
            max_distance_m: 1.5,
            tau_c_per_dead_time: 2.0,
            load: TuneLoad::Ground,
        }
    }

    /// Checks every field against the robot `params`; the error names the first bad one.
    pub fn validate(&self, params: &Params) -> Result<(), TuneConfigError> {
        let bad = |field, value| Err(TuneConfigError { field, value });
        let rated = params.config().motor.rated_voltage_v;
        let steps = self.max_hold_s * params.control_rate().get() as f32;
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(self.experiment_volts_v > 0.0 && self.experiment_volts_v <= rated) {
            bad("experiment_volts_v", self.experiment_volts_v)
        } else if !(self.breakaway_ramp_v_per_s > 0.0 && self.breakaway_ramp_v_per_s < 1e3) {
            bad("breakaway_ramp_v_per_s", self.breakaway_ramp_v_per_s)
        } else if !(self.max_hold_s >= 0.1 && self.max_hold_s <= 10.0 && steps >= 50.0) {
            bad("max_hold_s", self.max_hold_s)
        } else if !(self.max_speed_rad_s > 0.0 && self.max_speed_rad_s < 1e4) {
            bad("max_speed_rad_s", self.max_speed_rad_s)
        } else if !(self.max_distance_m > 0.0 && self.max_distance_m < 1e3) {
            bad("max_distance_m", self.max_distance_m)
        } else if !(self.tau_c_per_dead_time > 0.0 && self.tau_c_per_dead_time < 100.0) {
            bad("tau_c_per_dead_time", self.tau_c_per_dead_time)
        } else {
            match self.load {
                TuneLoad::Lifted {
                    ground_inertia_factor: f,
                } if !(1.0..1e3).contains(&f) => bad("load.ground_inertia_factor", f),
                _ => Ok(()),
            }
        }
    }
}

/// A [`TuneConfig`] field out of range.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TuneConfigError {
    /// The field, e.g. `hold_s`.
    pub field: &'static str,
    /// Its value.
    pub value: f32,
}

impl fmt::Display for TuneConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "tune.{} is out of range, got {}", self.field, self.value)
    }
}

impl core::error::Error for TuneConfigError {}

/// Why a tune ended without a result.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum TuneAbort {
    /// The supervisor stopped it: a fault, the button, the link or a time limit.
    Stopped,
    /// A wheel was turning when the tune began.
    NotAtRest,
    /// This wheel did not turn at the largest voltage: blocked, disconnected, or
    /// [`TuneConfig::experiment_volts_v`] too low.
    NoBreakaway(Side),
    /// This wheel needed more than 70 % of the largest voltage to break away: raise
    /// [`TuneConfig::experiment_volts_v`].
    BreakawayTooHigh(Side),
    /// This wheel turned against its voltage: motor or encoder wired the wrong way round.
    WrongDirection(Side),
    /// This wheel stopped while driven.
    Stalled(Side),
    /// This wheel exceeded [`TuneConfig::max_speed_rad_s`].
    TooFast(Side),
    /// The robot left [`TuneConfig::max_distance_m`] of where the tune began.
    TooFar,
    /// A control step came late: the data would be skewed.
    LateStep,
    /// The wheels did not come to rest under the brake.
    NotStopped,
    /// This wheel's step response or ramp did not fit a first-order model.
    NoFit(Side),
    /// This wheel's two directions, or its step and ramp, disagree by more than 30 %.
    Inconsistent(Side),
}

impl fmt::Display for TuneAbort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TuneAbort::Stopped => f.write_str("stopped by the supervisor (fault, button, link)"),
            TuneAbort::NotAtRest => f.write_str("a wheel was turning at the start"),
            TuneAbort::NoBreakaway(w) => {
                write!(f, "{w:?} wheel did not turn at the largest voltage")
            }
            TuneAbort::BreakawayTooHigh(w) => {
                write!(
                    f,
                    "{w:?} wheel needs over 70 % of the largest voltage to break away"
                )
            }
            TuneAbort::WrongDirection(w) => {
                write!(f, "{w:?} wheel turned against its voltage (wiring)")
            }
            TuneAbort::Stalled(w) => write!(f, "{w:?} wheel stopped while driven"),
            TuneAbort::TooFast(w) => write!(f, "{w:?} wheel exceeded the speed limit"),
            TuneAbort::TooFar => f.write_str("the robot left the allowed distance"),
            TuneAbort::LateStep => f.write_str("a control step came late"),
            TuneAbort::NotStopped => f.write_str("the wheels did not stop under the brake"),
            TuneAbort::NoFit(w) => write!(f, "{w:?} wheel's response did not fit"),
            TuneAbort::Inconsistent(w) => {
                write!(f, "{w:?} wheel's measurements disagree by over 30 %")
            }
        }
    }
}

/// One wheel's identified model (both directions averaged).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelModel {
    /// Static-friction feed-forward k_S, V.
    pub ks_v: f32,
    /// Speed feed-forward k_V, V per rad/s (the ramp's slope).
    pub kv_v_per_rad_s: f32,
    /// Step gain K, rad/s per V.
    pub gain_rad_s_per_v: f32,
    /// Time constant τ as identified (lifted: on the stand), s.
    pub time_constant_s: f32,
    /// Dead time θ, s (the plant's own, the speed estimate's window removed).
    pub dead_time_s: f32,
    /// The τ the PI was designed for (lifted: corrected for the chassis), s.
    pub design_time_constant_s: f32,
}

/// What a tune found: per wheel [left, right], the model and the loop to use, ready for
/// [`RobotConfig::left_wheel`] and [`RobotConfig::right_wheel`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TuneResult {
    /// The identified models.
    pub models: [WheelModel; 2],
    /// Feed-forward k_S, k_V from the models; K_p, T_i by SIMC; no D.
    pub loops: [WheelLoopConfig; 2],
    /// What the tune doubts in these figures.
    pub warnings: TuneWarnings,
}

/// What a tune that gave a result doubts, per wheel [left, right]: each flag set when
/// it happened in either direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TuneWarnings {
    /// The hold before the step reached [`TuneConfig::max_hold_s`] before the wheel's
    /// speed had settled (5 τ + θ of its own fit): the step started from a moving
    /// speed, K may be off.
    pub hold_not_settled: [bool; 2],
    /// The step ended before its response had settled (it lasted under 5 τ + θ of the
    /// step's own fit, cut short by [`TuneConfig::max_hold_s`] or the distance budget):
    /// τ is likely low, and the gains with it.
    pub step_not_settled: [bool; 2],
}

impl TuneWarnings {
    /// True when any flag is set.
    pub fn any(&self) -> bool {
        self.hold_not_settled
            .iter()
            .chain(&self.step_not_settled)
            .any(|w| *w)
    }
}

impl fmt::Display for TuneWarnings {
    /// Each warning as `<wheel> <what>`, separated by `; ` (empty when none).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        let lists = [
            (
                &self.hold_not_settled,
                "hold had not settled (K may be off)",
            ),
            (
                &self.step_not_settled,
                "step had not settled (τ likely low)",
            ),
        ];
        for (flags, what) in lists {
            for (side, set) in Side::BOTH.iter().zip(flags) {
                if *set {
                    if !first {
                        f.write_str("; ")?;
                    }
                    first = false;
                    write!(f, "{side:?} wheel's {what}")?;
                }
            }
        }
        Ok(())
    }
}

impl TuneResult {
    /// `robot` with the tuned wheel loops.
    pub fn apply_to(&self, robot: &RobotConfig) -> RobotConfig {
        let [left, right] = self.loops;
        RobotConfig {
            left_wheel: left,
            right_wheel: right,
            ..*robot
        }
    }
}

/// What the tune asks for the next step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TuneStep {
    /// Apply these voltages (V) in the next step.
    Drive(WheelVolts),
    /// The tune is over: its result or why not. Brake and disarm.
    Finished(Result<TuneResult, TuneAbort>),
}
