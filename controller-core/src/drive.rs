//! The wheel loop in volts: set-point and measured wheel speed in, bridge duty out.
//!
//! Per wheel and per control step:
//!
//! 1. **Feed-forward** from the motor model, u_ff = k_S·sgn(ω*) + k_V·ω* (V), with the
//!    sign ramped in over ±[`FF_SIGN_RAMP_RAD_S`] so a set-point near 0 does not chatter.
//! 2. **Bounds** on the armature voltage u:
//!    - the **voltage cap** |u| ≤ min(V_supply, V_rated): a 6 V motor on a 12.6 V pack
//!      never sees more than 6 V;
//!    - the **current limit** |u − k_V·ω| ≤ I_max·R_a, around the back-EMF of the
//!      measured speed. It bounds the stall current on a start and the plugging current
//!      when the motor is reversed against its back-EMF;
//!    - the **slew limit**: u moves by at most S·T per period (S in V/s). The current and
//!      voltage limits win when the two disagree.
//! 3. **PID** (incremental, [`crate::pid`]) on the speed error with u_ff added, clamped
//!    into the voltage and current bounds, so its anti-windup sees the physical limits.
//!    The slew limit is applied after it and not fed back: it acts for a few periods
//!    (0 → 6 V in 5 ms), and feeding it back would make the velocity form forget the
//!    feed-forward it was slewing towards.
//! 4. **Reversal through zero**: a wheel never goes from driving one way to driving the
//!    other in one step: the step where the sign would flip applies 0 V (short brake on a
//!    slow-decay bridge) and the PID is told. Together with the slew limit this means the
//!    direction pins of a TB6612 only change while the compare register holds ~0.
//! 5. **Duty** = u / V_supply (the filtered measurement), clamped to [−1, 1]. The loop's
//!    gain is in volts, so it is the same on any battery.
//!
//! ## Coordinated saturation
//!
//! When one wheel cannot reach its set-point (its output sat at a bound, pushing the way
//! the error asks, in the previous step) and the other can, the other wheel's set-point is
//! scaled by the saturated wheel's achieved fraction ω/ω* of its own. The curvature,
//! which depends only on the ratio of the wheel speeds, is kept: the robot slows down on
//! its arc instead of turning off it. The scaled set-point is what the unsaturated PID
//! sees, so its anti-windup is consistent; the saturated PID's integrator is held by its
//! bounds.
//!
//! ## The supply-derived speed cap
//!
//! [`WheelDrive::top_speed_rad_s`] is the wheel speed the motor model reaches with
//! [`SPEED_HEADROOM`] of the available voltage; the controller turns it into the
//! rim-speed cap of [`crate::limits`], so the body command asks only for what the battery
//! can deliver.

use crate::controller::MotorCommand;
use crate::kinematics::WheelSpeeds;
use crate::math;
use crate::params::{Params, WheelLoopConfig};
use crate::pid::{Bounds, IncrementalPid, PidParts};

/// Half-width of the set-point band over which the static-friction feed-forward ramps
/// from −k_S to +k_S, rad/s.
pub const FF_SIGN_RAMP_RAD_S: f32 = 0.5;

/// Fraction of the available voltage the speed cap plans for; the rest is the PID's
/// margin to correct disturbances at top speed.
pub const SPEED_HEADROOM: f32 = 0.85;

/// A voltage per wheel, V (positive drives the robot forward).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelVolts {
    /// Left armature voltage, V.
    pub left_v: f32,
    /// Right armature voltage, V.
    pub right_v: f32,
}

/// What the wheel loop did in one step, per wheel [left, right]. The PIDs' parts are read
/// on demand ([`WheelDrive::pid_parts`]): computing them every step for nobody costs the
/// Cortex-M4F more than it is worth.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelLoopReport {
    /// Armature voltages applied, V.
    pub volts: WheelVolts,
    /// The PID's output was held at one of its bounds (it asked for more than the motor can
    /// be given).
    pub saturated: [bool; 2],
    /// The set-points the PIDs used after coordinated saturation, rad/s.
    pub setpoint: WheelSpeeds,
}

/// Largest supply measurement taken as a reading, V; above it (or NaN, or negative) the
/// measurement is ignored.
const MAX_SUPPLY_READING_V: f32 = 1000.0;

/// Low-pass filter of the supply measurement, V.
#[derive(Clone, Copy, Debug)]
pub struct SupplyFilter {
    /// Weight of a new sample, T/(τ + T) (1: no filtering).
    alpha: f32,
    /// Weight of the next sample: 1 until the first valid one (taken as it is), then α.
    weight: f32,
    /// Filtered supply, V (0 before the first valid sample).
    filtered_v: f32,
}

impl SupplyFilter {
    /// A first-order filter of time constant `tau_s` (s) sampled every `period_s` (s).
    pub fn new(tau_s: f32, period_s: f32) -> Self {
        let alpha = period_s / (tau_s + period_s);
        Self {
            alpha: if alpha > 0.0 && alpha <= 1.0 {
                alpha
            } else {
                1.0
            },
            weight: 1.0,
            filtered_v: 0.0,
        }
    }

    /// Adds a measurement `supply_v` (V) and returns the filtered supply, V (0 until a
    /// valid measurement arrives). A NaN, negative or absurd (≥ 1 kV) measurement is
    /// ignored: the filter holds its value and the caller's range checks judge it.
    pub fn update(&mut self, supply_v: f32) -> f32 {
        // NaN fails both comparisons; no battery reads a kilovolt. (Written as two float
        // compares: a test against infinity compiles to a 20-instruction bit
        // classification on the Cortex-M4F.)
        #[allow(clippy::manual_range_contains)]
        let valid = supply_v >= 0.0 && supply_v < MAX_SUPPLY_READING_V;
        if valid {
            self.filtered_v += self.weight * (supply_v - self.filtered_v);
            self.weight = self.alpha;
        }
        self.filtered_v
    }

    /// The filtered supply, V (0 before the first valid measurement).
    pub fn value_v(&self) -> f32 {
        self.filtered_v
    }
}

/// One wheel's loop state.
#[derive(Clone, Copy, Debug)]
struct WheelLoop {
    config: WheelLoopConfig,
    /// [`SPEED_HEADROOM`]/k_V and k_S/k_V: the top speed at V volts is
    /// `speed_per_volt`·V − `speed_offset` (rad/s), with no division in the loop.
    speed_per_volt: f32,
    speed_offset_rad_s: f32,
    pid: IncrementalPid,
    /// Voltage applied in the last step, V.
    volts: f32,
    /// The last output sat at a bound in the error's direction.
    saturated: bool,
}

/// 1 / [`FF_SIGN_RAMP_RAD_S`], s/rad (a multiplication is cheaper than a division).
const FF_SIGN_RAMP_PER_RAD_S: f32 = 1.0 / FF_SIGN_RAMP_RAD_S;

impl WheelLoop {
    fn feed_forward(&self, setpoint: f32) -> f32 {
        let sign = math::clamp(setpoint * FF_SIGN_RAMP_PER_RAD_S, -1.0, 1.0);
        self.config.ks_v * sign + self.config.kv_v_per_rad_s * setpoint
    }
}

/// The two wheels' voltage loops (see the module doc).
#[derive(Clone, Copy, Debug)]
pub struct WheelDrive {
    wheels: [WheelLoop; 2],
    rated_voltage_v: f32,
    /// I_max·R_a, V.
    current_window_v: f32,
    /// Slew limit per control period, V.
    slew_per_period_v: f32,
}

impl WheelDrive {
    /// The wheel loops of `params`, at rest with 0 V applied.
    pub fn new(params: &Params) -> Self {
        let c = params.config();
        let gains = params.wheel_pid();
        let wheel = |config: WheelLoopConfig, index: usize| WheelLoop {
            config,
            speed_per_volt: SPEED_HEADROOM / config.kv_v_per_rad_s,
            speed_offset_rad_s: config.ks_v / config.kv_v_per_rad_s,
            pid: IncrementalPid::new(gains[index]),
            volts: 0.0,
            saturated: false,
        };
        Self {
            wheels: [wheel(c.left_wheel, 0), wheel(c.right_wheel, 1)],
            rated_voltage_v: c.motor.rated_voltage_v,
            current_window_v: c.motor.max_current_a * c.motor.resistance_ohm,
            slew_per_period_v: c.drive.slew_v_per_s * params.period_s(),
        }
    }

    /// Each PID's last output split into P, I, D and FF, V, [left, right].
    pub fn pid_parts(&self) -> [PidParts; 2] {
        [self.wheels[0].pid.parts(), self.wheels[1].pid.parts()]
    }

    /// The voltages applied in the last step, V.
    pub fn volts(&self) -> WheelVolts {
        WheelVolts {
            left_v: self.wheels[0].volts,
            right_v: self.wheels[1].volts,
        }
    }

    /// The fastest wheel speed both wheels can hold on `supply_v` (V), with
    /// [`SPEED_HEADROOM`] of the voltage left to the PID, rad/s.
    pub fn top_speed_rad_s(&self, supply_v: f32) -> f32 {
        let volts = min(supply_v, self.rated_voltage_v);
        let [left, right] = self
            .wheels
            .map(|w| w.speed_per_volt * volts - w.speed_offset_rad_s);
        let top = min(left, right);
        if top > 0.0 {
            top
        } else {
            0.0
        }
    }

    /// Restarts both loops for new `setpoint`s at `measured` wheel speeds (rad/s). With
    /// `keep_output` (a mode change while driving) each PID continues from the voltage it
    /// applied, so nothing jumps; without it (leaving a standstill) it starts from the
    /// feed-forward plus the proportional action on the error: a set-point step from rest
    /// gets the PID's full response, within the current limit.
    pub fn restart(&mut self, setpoint: WheelSpeeds, measured: WheelSpeeds, keep_output: bool) {
        let sp = [setpoint.left_rad_s, setpoint.right_rad_s];
        let ms = [measured.left_rad_s, measured.right_rad_s];
        // Zipped, not indexed: no bounds check at any opt-level (the control interrupt
        // must have no panic path, `cargo xtask panic-check`).
        for ((wheel, sp), ms) in self.wheels.iter_mut().zip(sp).zip(ms) {
            let error = if keep_output {
                wheel.pid.reset(wheel.volts - wheel.feed_forward(sp));
                sp - ms
            } else {
                wheel.volts = 0.0;
                wheel.pid.reset(0.0);
                0.0
            };
            wheel.pid.prime(error);
            wheel.saturated = false;
        }
    }

    /// Forgets the applied voltages (the bridge was off): the next step slews from 0 V.
    pub fn stop(&mut self) {
        for wheel in &mut self.wheels {
            wheel.volts = 0.0;
            wheel.saturated = false;
        }
    }

    /// Installs new PID gains without a bump ([`IncrementalPid::set_gains`]).
    pub fn set_gains(&mut self, params: &Params) {
        let gains = params.wheel_pid();
        let configs = [params.config().left_wheel, params.config().right_wheel];
        for (i, wheel) in self.wheels.iter_mut().enumerate() {
            wheel.pid.set_gains(gains[i]);
            wheel.config = configs[i];
            wheel.speed_per_volt = SPEED_HEADROOM / configs[i].kv_v_per_rad_s;
            wheel.speed_offset_rad_s = configs[i].ks_v / configs[i].kv_v_per_rad_s;
        }
    }

    /// One control step covering `periods` control periods: the wheel loops drive
    /// `measured` (rad/s) towards `setpoint` (rad/s) on a supply of `supply_v` (V,
    /// filtered, > 0 for any output). Returns the duties; what the loops did is written
    /// to `report` (in place: on the Cortex-M4F returning it by value costs as much as
    /// the loops).
    pub fn step(
        &mut self,
        setpoint: WheelSpeeds,
        measured: WheelSpeeds,
        supply_v: f32,
        periods: f32,
        report: &mut WheelLoopReport,
    ) -> MotorCommand {
        let ms = [measured.left_rad_s, measured.right_rad_s];
        let sp = self.coordinate(setpoint, ms);
        let cap = min(supply_v, self.rated_voltage_v);
        let slew = self.slew_per_period_v * periods;
        report.setpoint = WheelSpeeds::new(sp[0], sp[1]);
        for (i, wheel) in self.wheels.iter_mut().enumerate() {
            let limits = physical_limits(wheel, ms[i], self.current_window_v, cap);
            let error = sp[i] - ms[i];
            let ff = wheel.feed_forward(sp[i]);
            // The PID's bounds are the physical limits, so its anti-windup knows them.
            let wanted = wheel.pid.step(error, ff, limits, periods);
            wheel.saturated = wheel.pid.clamped();
            // The slew limit, inside the current and voltage limits. It acts for a few
            // periods at most (0 → 6 V in 5 ms), so it is not fed back to the PID: doing
            // so would make the velocity form forget the feed-forward it was slewing to.
            let mut volts =
                limits.clamp(math::clamp(wanted, wheel.volts - slew, wheel.volts + slew));
            // Never from one direction to the other in one step: pass through 0 V.
            if volts * wheel.volts < 0.0 {
                volts = limits.clamp(0.0);
            }
            wheel.volts = volts;
            report.saturated[i] = wheel.saturated;
        }
        report.volts = self.volts();
        duty_for(report.volts, supply_v)
    }

    /// Open loop, for identification: applies `volts` (V, per wheel) directly, within the
    /// voltage cap and the current limit but with no PID and no slew limit (the tune
    /// routine's own steps must reach the motor as commanded). `measured` (rad/s) sets the
    /// current limit's window; `supply_v` (V, filtered) turns volts into duty. The loops
    /// are left so that [`WheelDrive::restart`] can take over bumplessly.
    pub fn apply_volts(
        &mut self,
        volts: WheelVolts,
        measured: WheelSpeeds,
        supply_v: f32,
        report: &mut WheelLoopReport,
    ) -> MotorCommand {
        let cap = min(supply_v, self.rated_voltage_v);
        let ms = [measured.left_rad_s, measured.right_rad_s];
        let wanted = [volts.left_v, volts.right_v];
        for (i, wheel) in self.wheels.iter_mut().enumerate() {
            let limits = physical_limits(wheel, ms[i], self.current_window_v, cap);
            let applied = limits.clamp(wanted[i]);
            wheel.saturated = applied != wanted[i];
            wheel.volts = applied;
            report.saturated[i] = wheel.saturated;
        }
        report.setpoint = measured;
        report.volts = self.volts();
        duty_for(report.volts, supply_v)
    }

    /// Coordinated saturation (module doc): the set-points the PIDs should chase.
    fn coordinate(&self, setpoint: WheelSpeeds, measured: [f32; 2]) -> [f32; 2] {
        let mut sp = [setpoint.left_rad_s, setpoint.right_rad_s];
        let [left, right] = [self.wheels[0].saturated, self.wheels[1].saturated];
        let (sat, other) = match (left, right) {
            (true, false) => (0, 1),
            (false, true) => (1, 0),
            _ => return sp,
        };
        // The fraction of its set-point the saturated wheel achieves, in [0, 1].
        let achieved = if math::abs(sp[sat]) > FF_SIGN_RAMP_RAD_S {
            math::clamp(measured[sat] / sp[sat], 0.0, 1.0)
        } else {
            1.0
        };
        sp[other] *= achieved;
        sp
    }
}

/// The voltage cap ±`cap` and the current limit `back-EMF ± window` (V) of `wheel`
/// turning at `measured` (rad/s). min ≤ max holds unless the wheel is back-driven beyond
/// the cap; then the cap, the voltage nearest to the current limit, wins.
fn physical_limits(wheel: &WheelLoop, measured: f32, window: f32, cap: f32) -> Bounds {
    let back_emf = wheel.config.kv_v_per_rad_s * measured;
    let max = min(back_emf + window, cap);
    Bounds {
        min: min(max_of(back_emf - window, -cap), max),
        max,
    }
}

/// The duties for `volts` on a supply of `supply_v` (V): volts / supply, in [−1, 1]; 0
/// without a supply.
fn duty_for(volts: WheelVolts, supply_v: f32) -> MotorCommand {
    let per_volt = if supply_v > 0.0 { 1.0 / supply_v } else { 0.0 };
    MotorCommand {
        left: math::clamp(volts.left_v * per_volt, -1.0, 1.0),
        right: math::clamp(volts.right_v * per_volt, -1.0, 1.0),
    }
}

/// The smaller of `a` and `b`; a NaN `a` passes through (like [`math::clamp`]), so a
/// fault stays visible.
fn min(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

/// The larger of `a` and `b`; a NaN `a` passes through.
fn max_of(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RobotConfig;

    fn params() -> Params {
        Params::new(RobotConfig::REFERENCE_ROBOT).unwrap()
    }

    fn drive() -> WheelDrive {
        WheelDrive::new(&params())
    }

    const STILL: WheelSpeeds = WheelSpeeds {
        left_rad_s: 0.0,
        right_rad_s: 0.0,
    };

    #[test]
    fn duty_is_volts_over_the_supply_so_the_gain_holds_on_any_battery() {
        // The same small error gives the same volts on 6 V and on 12 V, hence half the duty.
        let run = |supply: f32| {
            let mut d = drive();
            d.restart(
                WheelSpeeds::new(10.0, 10.0),
                WheelSpeeds::new(9.0, 9.0),
                false,
            );
            let mut report = WheelLoopReport::default();
            let mut duty = MotorCommand::STOP;
            for _ in 0..20 {
                duty = d.step(
                    WheelSpeeds::new(10.0, 10.0),
                    WheelSpeeds::new(9.0, 9.0),
                    supply,
                    1.0,
                    &mut report,
                );
            }
            (duty, report)
        };
        let (duty6, rep6) = run(6.0);
        let (duty12, rep12) = run(12.0);
        assert!((rep6.volts.left_v - rep12.volts.left_v).abs() < 1e-5);
        assert!((duty6.left - 2.0 * duty12.left).abs() < 1e-5);
        // Leaving a standstill: FF 0.33 + 1.57 V, the proportional action on the 1 rad/s
        // error, 0.6 V, and 20 ms of integral, 0.6·0.02/0.09 = 0.133 V.
        assert!(
            (rep6.volts.left_v - 2.6333).abs() < 1e-4,
            "{}",
            rep6.volts.left_v
        );
    }

    #[test]
    fn a_rated_6_v_motor_never_sees_more_than_6_v() {
        let mut d = drive();
        let mut report = WheelLoopReport::default();
        for k in 0..500 {
            // The wheel accelerates slowly (a heavy load), so the loop asks for all it can.
            let w = k as f32 * 0.05;
            d.step(
                WheelSpeeds::new(30.0, 30.0),
                WheelSpeeds::new(w, w),
                12.6,
                1.0,
                &mut report,
            );
            assert!(report.volts.left_v <= 6.0 + 1e-6);
        }
        assert!((report.volts.left_v - 6.0).abs() < 1e-5);
        assert!(report.saturated[0] && report.saturated[1]);
    }

    #[test]
    fn the_current_limit_bounds_a_start_from_rest() {
        // From rest the back-EMF is 0: u ≤ I_max·R_a = 1.2 A · 4 Ω = 4.8 V, although the
        // 6 V supply and the PID would give more.
        let mut d = drive();
        let mut report = WheelLoopReport::default();
        for _ in 0..50 {
            d.step(WheelSpeeds::new(30.0, 30.0), STILL, 6.0, 1.0, &mut report);
        }
        assert!((report.volts.left_v - 4.8).abs() < 1e-5, "{report:?}");
    }

    #[test]
    fn the_slew_limit_ramps_the_voltage() {
        // 1200 V/s at 1 kHz: 1.2 V per step, so 4.8 V takes 4 steps.
        let mut d = drive();
        let mut volts = Vec::new();
        let mut r = WheelLoopReport::default();
        for _ in 0..5 {
            d.step(WheelSpeeds::new(30.0, 30.0), STILL, 6.0, 1.0, &mut r);
            volts.push(r.volts.left_v);
        }
        for (k, v) in volts.iter().enumerate() {
            let expected = (1.2 * (k + 1) as f32).min(4.8);
            assert!((v - expected).abs() < 1e-5, "step {k}: {v}");
        }
        // A late step (2 periods) may move twice as far.
        let mut late = drive();
        late.step(WheelSpeeds::new(30.0, 30.0), STILL, 6.0, 2.0, &mut r);
        assert!((r.volts.left_v - 2.4).abs() < 1e-5);
    }

    #[test]
    fn a_reversal_passes_through_zero_volts() {
        // Driving forward at 10 rad/s, then asked for −10 rad/s.
        let mut d = drive();
        let forward = WheelSpeeds::new(10.0, 10.0);
        let mut r = WheelLoopReport::default();
        for _ in 0..200 {
            d.step(forward, forward, 6.0, 1.0, &mut r);
        }
        let mut previous = d.volts().left_v;
        assert!(previous > 1.0);
        let mut saw_zero = false;
        for _ in 0..50 {
            d.step(WheelSpeeds::new(-10.0, -10.0), forward, 6.0, 1.0, &mut r);
            let v = r.volts.left_v;
            // Never from > 0 to < 0 in one step.
            assert!(!(previous > 0.0 && v < 0.0), "{previous} → {v}");
            saw_zero |= v == 0.0;
            previous = v;
        }
        assert!(saw_zero);
    }

    #[test]
    fn plugging_current_is_bounded_by_the_current_limit() {
        // At +30 rad/s the back-EMF is 4.7 V; reversing may apply at most 4.8 V below it,
        // i.e. −0.1 V, whatever the PID asks.
        let mut d = drive();
        let fast = WheelSpeeds::new(30.0, 30.0);
        d.restart(fast, fast, false);
        let mut r = WheelLoopReport::default();
        for _ in 0..100 {
            d.step(WheelSpeeds::new(-30.0, -30.0), fast, 12.0, 1.0, &mut r);
            let current = (r.volts.left_v - 0.157 * 30.0) / 4.0;
            assert!(current >= -1.2 - 1e-5, "{current} A");
        }
    }

    #[test]
    fn feed_forward_has_static_friction_and_speed_terms() {
        let d = drive();
        let w = &d.wheels[0];
        assert!((w.feed_forward(10.0) - (0.33 + 1.57)).abs() < 1e-5);
        assert!((w.feed_forward(-10.0) + (0.33 + 1.57)).abs() < 1e-5);
        assert_eq!(w.feed_forward(0.0), 0.0);
        // Ramped in over ±0.5 rad/s.
        assert!((w.feed_forward(0.25) - (0.165 + 0.03925)).abs() < 1e-5);
    }

    #[test]
    fn a_saturated_wheel_slows_the_other_to_keep_the_curvature() {
        // Left wheel saturated and reaching only 15 of its 30 rad/s: the right wheel's
        // 20 rad/s set-point becomes 10, keeping ω_r/ω_l = 2/3.
        let mut d = drive();
        d.wheels[0].saturated = true;
        let sp = d.coordinate(WheelSpeeds::new(30.0, 20.0), [15.0, 20.0]);
        assert_eq!(sp, [30.0, 10.0]);
        // Both saturated, or neither: set-points unchanged.
        d.wheels[1].saturated = true;
        assert_eq!(
            d.coordinate(WheelSpeeds::new(30.0, 20.0), [15.0, 20.0]),
            [30.0, 20.0]
        );
        d.wheels = [d.wheels[0], d.wheels[0]].map(|mut w| {
            w.saturated = false;
            w
        });
        assert_eq!(
            d.coordinate(WheelSpeeds::new(30.0, 20.0), [15.0, 20.0]),
            [30.0, 20.0]
        );
        // The right wheel saturated while turning backwards at half its set-point.
        d.wheels[1].saturated = true;
        assert_eq!(
            d.coordinate(WheelSpeeds::new(8.0, -20.0), [8.0, -10.0]),
            [4.0, -20.0]
        );
    }

    #[test]
    fn a_weak_supply_lowers_the_top_speed() {
        let d = drive();
        // 0.85 · 6 V → (5.1 − 0.33)/0.157 = 30.4 rad/s; on 4.8 V: (4.08 − 0.33)/0.157 = 23.9.
        assert!((d.top_speed_rad_s(12.0) - 30.38).abs() < 0.01);
        assert!((d.top_speed_rad_s(4.8) - 23.89).abs() < 0.01);
        assert_eq!(d.top_speed_rad_s(0.0), 0.0);
    }

    /// Steps `d` `n` times towards `setpoint` at `measured` (rad/s, both wheels) on 6 V and
    /// returns the last report.
    fn run(d: &mut WheelDrive, setpoint: f32, measured: f32, n: usize) -> WheelLoopReport {
        let mut r = WheelLoopReport::default();
        for _ in 0..n {
            d.step(
                WheelSpeeds::new(setpoint, setpoint),
                WheelSpeeds::new(measured, measured),
                6.0,
                1.0,
                &mut r,
            );
        }
        r
    }

    #[test]
    fn backwards_too_the_motor_never_sees_more_than_its_rating() {
        // Turning backwards at 20 rad/s (back-EMF −3.1 V) and asked for −35 rad/s: the
        // current window would allow −3.1 − 4.8 = −7.9 V, the 6 V rating caps it at −6 V.
        let r = run(&mut drive(), -35.0, -20.0, 200);
        assert!(r.volts.left_v >= -6.0 - 1e-5, "{r:?}");
        assert!(r.volts.left_v < -5.9, "{r:?}");
    }

    #[test]
    fn driving_backwards_from_rest_starts_at_once() {
        // From 0 V there is no direction to pass through zero from.
        let r = run(&mut drive(), -10.0, 0.0, 1);
        assert!(r.volts.left_v < -1.0 && r.volts.right_v < -1.0, "{r:?}");
    }

    #[test]
    fn stop_forgets_the_applied_voltage() {
        let mut d = drive();
        let before = run(&mut d, 20.0, 10.0, 50);
        assert!(before.volts.left_v > 2.0, "{before:?}");
        d.stop();
        assert_eq!(d.volts(), WheelVolts::default());
        // The next step slews from 0 V: 1.2 V at 1 200 V/s and 1 kHz.
        let after = run(&mut d, 20.0, 10.0, 1);
        assert!((after.volts.left_v - 1.2).abs() < 1e-5, "{after:?}");
    }

    #[test]
    fn a_restart_while_driving_continues_from_the_applied_voltage() {
        let mut d = drive();
        let steady = run(&mut d, 10.0, 10.0, 300).volts.left_v;
        d.restart(
            WheelSpeeds::new(10.0, 10.0),
            WheelSpeeds::new(10.0, 10.0),
            true,
        );
        let next = run(&mut d, 10.0, 10.0, 1).volts.left_v;
        assert!((next - steady).abs() < 0.05, "{steady} V then {next} V");
        // Leaving a standstill instead: the loops start from 0 V and slew up.
        d.restart(
            WheelSpeeds::new(10.0, 10.0),
            WheelSpeeds::new(10.0, 10.0),
            false,
        );
        let from_rest = run(&mut d, 10.0, 10.0, 1).volts.left_v;
        assert!(
            (from_rest - 1.2).abs() < 1e-5,
            "{steady} V, then {from_rest} V"
        );
    }

    #[test]
    fn new_gains_bring_the_new_motor_model() {
        // A motor model with twice the back-EMF constant halves the reachable speed; the
        // retuned drive must plan with it exactly as a drive built with it would.
        let mut config = RobotConfig::REFERENCE_ROBOT;
        config.left_wheel.kv_v_per_rad_s *= 2.0;
        config.right_wheel.kv_v_per_rad_s *= 2.0;
        config.left_wheel.ks_v *= 1.5;
        config.right_wheel.ks_v *= 1.5;
        let slower = Params::new(config).unwrap();
        let mut d = drive();
        let before = d.top_speed_rad_s(6.0);
        d.set_gains(&slower);
        let expected = WheelDrive::new(&slower).top_speed_rad_s(6.0);
        assert!(d.top_speed_rad_s(6.0) < 0.6 * before);
        assert!((d.top_speed_rad_s(6.0) - expected).abs() < 1e-5);
        // And the feed-forward with it: holding 10 rad/s asks for more volts.
        let mut reference = drive();
        let old = run(&mut reference, 10.0, 10.0, 300).volts.left_v;
        let new = run(&mut d, 10.0, 10.0, 300).volts.left_v;
        assert!(new > 1.5 * old, "{old} V, {new} V");
    }

    #[test]
    fn supply_filter_smooths_and_ignores_garbage() {
        let mut f = SupplyFilter::new(0.02, 0.001);
        assert_eq!(f.value_v(), 0.0);
        assert_eq!(f.update(7.4), 7.4);
        // A step to 6.4 V: after one time constant (20 steps) 63 % of the way.
        let mut v = 0.0;
        for _ in 0..20 {
            v = f.update(6.4);
        }
        assert!((v - (7.4 - 0.632)).abs() < 0.02, "{v}");
        assert_eq!(f.update(f32::NAN), v);
        assert_eq!(f.update(-1.0), v);
        assert_eq!(f.value_v(), v);
        assert_eq!(SupplyFilter::new(0.0, 0.001).update(5.0), 5.0);
    }

    #[test]
    fn open_loop_volts_keep_the_cap_and_the_current_limit_but_not_the_slew() {
        let mut d = drive();
        let mut r = WheelLoopReport::default();
        // 3 V at once from rest (no 1.2 V/step slew), on 12 V: duty 0.25.
        let duty = d.apply_volts(
            WheelVolts {
                left_v: 3.0,
                right_v: -3.0,
            },
            STILL,
            12.0,
            &mut r,
        );
        assert_eq!(
            duty,
            MotorCommand {
                left: 0.25,
                right: -0.25
            }
        );
        assert!(!r.saturated[0]);
        // 9 V from rest: the current limit (4.8 V) and then the rated 6 V cap hold.
        d.apply_volts(
            WheelVolts {
                left_v: 9.0,
                right_v: 9.0,
            },
            STILL,
            12.0,
            &mut r,
        );
        assert_eq!(r.volts.left_v, 4.8);
        assert!(r.saturated[0]);
        d.apply_volts(
            WheelVolts {
                left_v: 9.0,
                right_v: 9.0,
            },
            WheelSpeeds::new(30.0, 30.0),
            12.0,
            &mut r,
        );
        assert_eq!(r.volts.left_v, 6.0);
    }

    #[test]
    fn no_supply_means_no_duty() {
        let mut d = drive();
        let duty = d.step(
            WheelSpeeds::new(10.0, 10.0),
            STILL,
            0.0,
            1.0,
            &mut WheelLoopReport::default(),
        );
        assert_eq!(duty, MotorCommand::STOP);
    }
}
