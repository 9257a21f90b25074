//! Limits between the steering law and the wheels.
//!
//! 1. **Acceleration**: per control step of period T, v may change by at most a·T and ω by
//!    α·T. The limiter runs at the inner (wheel-loop) rate and ramps towards the steering
//!    law's latest command, so the wheel set-points move in steps of a·T (0.003 m/s at
//!    3 m/s² and 1 kHz) rather than jumping by a·T_s every steering period.
//! 2. **Rim-speed cap**: if either wheel's rim speed |v ± ωL/2| would exceed the cap, v and
//!    ω are scaled down *together* by the same factor. The ratio ω/v, the curvature of the
//!    commanded arc, is kept, so a saturated robot slows down on the path instead of
//!    leaving it. The cap is the smaller of the configured one and what the motors can
//!    reach on the measured supply (see [`crate::drive`]).

use crate::kinematics::BodyVelocity;
use crate::math;

/// Limits on the body command, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Limits {
    /// Largest rim speed of either wheel, m/s (the supply may lower it further).
    pub max_rim_speed_m_s: f32,
    /// Largest change of forward speed, m/s².
    pub max_linear_accel_m_s2: f32,
    /// Largest change of yaw rate, rad/s².
    pub max_angular_accel_rad_s2: f32,
}

/// What the limiter did to the last command.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct LimitFlags {
    /// The rim-speed cap scaled the command down.
    pub rim_speed_capped: bool,
    /// The acceleration limit held the command back.
    pub accel_limited: bool,
}

/// Scales `command` so that neither rim speed exceeds `max_rim_speed_m_s`, keeping ω/v.
/// `track_width_m` is L. Returns the command and whether it was scaled.
pub fn cap_rim_speed(
    command: BodyVelocity,
    track_width_m: f32,
    max_rim_speed_m_s: f32,
) -> (BodyVelocity, bool) {
    let half_turn = 0.5 * command.omega_rad_s * track_width_m;
    let fastest = math::abs(command.v_m_s) + math::abs(half_turn);
    if fastest <= max_rim_speed_m_s {
        return (command, false);
    }
    let scale = max_rim_speed_m_s / fastest;
    (
        BodyVelocity::new(command.v_m_s * scale, command.omega_rad_s * scale),
        true,
    )
}

/// Acceleration limiting plus rim-speed cap, with memory of the last command.
#[derive(Clone, Copy, Debug)]
pub struct CommandLimiter {
    limits: Limits,
    previous: BodyVelocity,
}

impl CommandLimiter {
    /// A limiter for `limits`, starting from a standstill.
    pub const fn new(limits: Limits) -> Self {
        Self {
            limits,
            previous: BodyVelocity::new(0.0, 0.0),
        }
    }

    /// Restarts from `current` (for example the measured body velocity).
    pub fn reset(&mut self, current: BodyVelocity) {
        self.previous = current;
    }

    /// The last command the limiter produced.
    pub const fn command(&self) -> BodyVelocity {
        self.previous
    }

    /// Moves towards `desired` over `period_s` (s) of time on a robot of track width
    /// `track_width_m` (m), keeping both rim speeds within `max_rim_speed_m_s` (m/s; the
    /// smaller of the configured cap and what the supply allows).
    pub fn apply(
        &mut self,
        desired: BodyVelocity,
        period_s: f32,
        track_width_m: f32,
        max_rim_speed_m_s: f32,
    ) -> (BodyVelocity, LimitFlags) {
        let dv = self.limits.max_linear_accel_m_s2 * period_s;
        let dw = self.limits.max_angular_accel_rad_s2 * period_s;
        let v = math::clamp(
            desired.v_m_s,
            self.previous.v_m_s - dv,
            self.previous.v_m_s + dv,
        );
        let w = math::clamp(
            desired.omega_rad_s,
            self.previous.omega_rad_s - dw,
            self.previous.omega_rad_s + dw,
        );
        let accel_limited = v != desired.v_m_s || w != desired.omega_rad_s;
        let (command, rim_speed_capped) =
            cap_rim_speed(BodyVelocity::new(v, w), track_width_m, max_rim_speed_m_s);
        self.previous = command;
        (
            command,
            LimitFlags {
                rim_speed_capped,
                accel_limited,
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: Limits = Limits {
        max_rim_speed_m_s: 1.0,
        max_linear_accel_m_s2: 2.0,
        max_angular_accel_rad_s2: 10.0,
    };

    #[test]
    fn cap_keeps_curvature() {
        // v = 1.5, ω = 10, L = 0.2: rim speeds 0.5 and 2.5 m/s; scale 1/2.5.
        let (c, capped) = cap_rim_speed(BodyVelocity::new(1.5, 10.0), 0.2, 1.0);
        assert!(capped);
        assert!((c.v_m_s - 0.6).abs() < 1e-6 && (c.omega_rad_s - 4.0).abs() < 1e-6);
        assert!((c.omega_rad_s / c.v_m_s - 10.0 / 1.5).abs() < 1e-5);
        let (same, capped) = cap_rim_speed(BodyVelocity::new(0.3, 1.0), 0.2, 1.0);
        assert!(!capped);
        assert_eq!(same, BodyVelocity::new(0.3, 1.0));
    }

    #[test]
    fn acceleration_is_limited_per_period() {
        let mut l = CommandLimiter::new(LIMITS);
        let (c, flags) = l.apply(BodyVelocity::new(0.5, -3.0), 0.01, 0.2, 1.0);
        assert!(flags.accel_limited);
        assert!((c.v_m_s - 0.02).abs() < 1e-7 && (c.omega_rad_s + 0.1).abs() < 1e-7);
        let (c, _) = l.apply(BodyVelocity::new(0.5, -3.0), 0.01, 0.2, 1.0);
        assert!((c.v_m_s - 0.04).abs() < 1e-7);
        assert_eq!(l.command(), c);
        // A reachable command is passed through unflagged.
        let (c, flags) = l.apply(BodyVelocity::new(0.05, -0.25), 0.01, 0.2, 1.0);
        assert_eq!(c, BodyVelocity::new(0.05, -0.25));
        assert_eq!(flags, LimitFlags::default());
        // Reset starts the ramp from where it is told.
        l.reset(BodyVelocity::new(0.4, 0.0));
        let (c, _) = l.apply(BodyVelocity::new(0.4, 0.0), 0.01, 0.2, 1.0);
        assert_eq!(c, BodyVelocity::new(0.4, 0.0));
    }

    #[test]
    fn the_cap_passed_in_wins_over_the_configured_one() {
        let mut l = CommandLimiter::new(LIMITS);
        l.reset(BodyVelocity::new(0.8, 0.0));
        let (c, flags) = l.apply(BodyVelocity::new(0.8, 0.0), 0.01, 0.2, 0.5);
        assert!(flags.rim_speed_capped);
        assert!((c.v_m_s - 0.5).abs() < 1e-7);
    }
}
