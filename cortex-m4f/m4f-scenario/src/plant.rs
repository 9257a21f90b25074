//! A small deterministic differential-drive robot: two first-order motors, exact-enough
//! pose integration and quadrature encoders quantised to whole ticks.
//!
//! Per wheel, with duty d ∈ [−1, 1]:  ω̇ = (ω_max·d − ω) / τ  (explicit Euler, `substeps`
//! per control period). The wheel's angle is kept as a whole tick count plus a fraction of
//! a tick, so quantisation is exact however long the run. The body moves as a unicycle,
//! v = R(ω_r + ω_l)/2, ω = R(ω_r − ω_l)/L, integrated at the mid-point heading.
//!
//! This is not `host-sim`'s plant (no DC-motor model, friction, dead-band, coupled inertia,
//! noise or slip): its only job is to close the loop with the core's own arithmetic,
//! identically on host and target.

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::kinematics::Pose;
use controller_core::math;
use controller_core::params::Params;

/// The plant's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantConfig {
    /// No-load speed of the left wheel at full duty, rad/s.
    pub left_max_speed_rad_s: f32,
    /// No-load speed of the right wheel at full duty, rad/s (differs from the left one so
    /// the wheel PIDs have something to correct).
    pub right_max_speed_rad_s: f32,
    /// Mechanical time constant τ of each wheel, s.
    pub time_constant_s: f32,
    /// Euler substeps per control period (≥ 1).
    pub substeps: u32,
}

impl PlantConfig {
    /// Matches the reference robot's feed-forward (1/0.025 = 40 rad/s at full duty), with
    /// the right motor 5 % weaker and τ = 40 ms, four substeps per period.
    pub const REFERENCE: PlantConfig = PlantConfig {
        left_max_speed_rad_s: 40.0,
        right_max_speed_rad_s: 38.0,
        time_constant_s: 0.04,
        substeps: 4,
    };
}

/// One wheel: speed and the encoder's sub-tick phase.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Wheel {
    /// ω, rad/s.
    speed_rad_s: f32,
    /// Rotation since the last whole tick was reported, in ticks, in [0, 1) after each
    /// control period.
    phase_ticks: f32,
}

impl Wheel {
    /// Advances by `dt_s` under `duty`, returning the rotation in rad during `dt_s`.
    fn advance(&mut self, duty: f32, max_speed_rad_s: f32, dt_over_tau: f32, dt_s: f32) -> f32 {
        let target = max_speed_rad_s * math::clamp(duty, -1.0, 1.0);
        self.speed_rad_s += (target - self.speed_rad_s) * dt_over_tau;
        self.speed_rad_s * dt_s
    }

    /// Takes the whole ticks accumulated in the phase (floor), leaving a phase in [0, 1).
    fn take_ticks(&mut self) -> i32 {
        let whole = floor_to_i32(self.phase_ticks);
        self.phase_ticks -= whole as f32;
        whole
    }
}

/// ⌊x⌋ for |x| < 2³¹, without `f32::floor` (which is `std`-only).
fn floor_to_i32(x: f32) -> i32 {
    let truncated = x as i32;
    if (truncated as f32) > x {
        truncated - 1
    } else {
        truncated
    }
}

/// The simulated robot (see the module doc).
#[derive(Clone, Debug)]
pub struct Plant {
    config: PlantConfig,
    wheel_radius_m: f32,
    track_width_m: f32,
    ticks_per_rad: f32,
    /// Length of one substep, s.
    dt_s: f32,
    pose: Pose,
    wheels: [Wheel; 2],
}

impl Plant {
    /// A robot at rest at `start` (world frame), built like `params` describes (same
    /// wheel radius, track width and encoder resolution), stepped every `params` period.
    pub fn new(config: PlantConfig, params: &Params, start: Pose) -> Self {
        let substeps = config.substeps.max(1);
        Self {
            config: PlantConfig { substeps, ..config },
            wheel_radius_m: params.geometry().wheel_radius_left_m(),
            track_width_m: params.geometry().track_width_m(),
            ticks_per_rad: 1.0 / params.rad_per_tick(),
            dt_s: params.period_s() / substeps as f32,
            pose: start,
            wheels: [Wheel::default(); 2],
        }
    }

    /// The true pose, world frame.
    pub const fn pose(&self) -> Pose {
        self.pose
    }

    /// Applies `duty` for one control period; returns the encoder ticks counted in it.
    pub fn advance(&mut self, duty: MotorCommand) -> TickDeltas {
        let c = self.config;
        let dt_over_tau = self.dt_s / c.time_constant_s;
        for _ in 0..c.substeps {
            let [left, right] = &mut self.wheels;
            let dl = left.advance(duty.left, c.left_max_speed_rad_s, dt_over_tau, self.dt_s);
            let dr = right.advance(duty.right, c.right_max_speed_rad_s, dt_over_tau, self.dt_s);
            left.phase_ticks += dl * self.ticks_per_rad;
            right.phase_ticks += dr * self.ticks_per_rad;

            let ds = 0.5 * self.wheel_radius_m * (dr + dl);
            let dtheta = self.wheel_radius_m * (dr - dl) / self.track_width_m;
            let (sin_mid, cos_mid) = math::sin_cos(self.pose.theta_rad + 0.5 * dtheta);
            self.pose = Pose {
                x_m: self.pose.x_m + ds * cos_mid,
                y_m: self.pose.y_m + ds * sin_mid,
                theta_rad: math::wrap_angle(self.pose.theta_rad + dtheta),
            };
        }
        TickDeltas {
            left: self.wheels[0].take_ticks(),
            right: self.wheels[1].take_ticks(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::params::RobotConfig;

    fn plant() -> Plant {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        Plant::new(PlantConfig::REFERENCE, &params, Pose::default())
    }

    #[test]
    fn floor_rounds_down_on_both_sides_of_zero() {
        assert_eq!(floor_to_i32(0.0), 0);
        assert_eq!(floor_to_i32(0.999), 0);
        assert_eq!(floor_to_i32(1.0), 1);
        assert_eq!(floor_to_i32(-0.001), -1);
        assert_eq!(floor_to_i32(-1.0), -1);
        assert_eq!(floor_to_i32(-1.5), -2);
    }

    #[test]
    fn full_duty_approaches_no_load_speed_and_counts_ticks() {
        let mut p = plant();
        let full = MotorCommand {
            left: 1.0,
            right: 1.0,
        };
        let mut ticks = (0i64, 0i64);
        // 1 s = 25 τ: the wheels are at no-load speed.
        for _ in 0..1000 {
            let t = p.advance(full);
            ticks.0 += i64::from(t.left);
            ticks.1 += i64::from(t.right);
        }
        assert!((p.wheels[0].speed_rad_s - 40.0).abs() < 1e-3);
        assert!((p.wheels[1].speed_rad_s - 38.0).abs() < 1e-3);
        // ≈ 40 rad/s for 1 s less the τ lag, at 1440/2π ticks per rad.
        let expected_left = (40.0 * (1.0 - 0.04)) * 1440.0 / core::f64::consts::TAU;
        assert!((ticks.0 as f64 - expected_left).abs() < 3.0, "{ticks:?}");
        assert!(ticks.1 < ticks.0);
        // The weaker right wheel turns the robot clockwise.
        assert!(p.pose().theta_rad < 0.0 && p.pose().x_m > 1.0);
    }

    #[test]
    fn reverse_duty_counts_negative_ticks() {
        let mut p = plant();
        let back = MotorCommand {
            left: -0.5,
            right: -0.5,
        };
        let total: i32 = (0..500).map(|_| p.advance(back).left).sum();
        assert!(total < -100);
        assert!(p.pose().x_m < 0.0);
    }
}
