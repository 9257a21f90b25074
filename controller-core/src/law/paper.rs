//! The paper's steering law, eqs. (27)–(35), exactly as published.
//!
//! This is the polar-coordinate law of Aicardi, Casalino, Bicchi and Balestrino (1995).
//! With ψ the direction of the line of sight from the robot to the reference point,
//!
//! - r_e = ‖p_r − p‖ (the paper's r_e; Aicardi's e), m,
//! - α = wrap(ψ − θ), the line of sight seen from the robot (the paper's θ_e in 27–35), rad,
//! - β = wrap(ψ − θ_r), the line of sight seen from the reference heading (the paper's θ_r
//!   in 27–35), rad,
//!
//! and for a **fixed** reference pose: ṙ_e = −v cos α (27), α̇ = −ω + v sin α / r_e (28),
//! β̇ = v sin α / r_e (29). With V = ½λr_e² + ½(α² + hβ²) (30), the law
//!
//! - (33) v = γ r_e cos α,
//! - (34) ω = k α + γ (cos α sin α / α)(α + hβ)
//!
//! gives V̇ = −λγ (r_e cos α)² − k α² ≤ 0 (35). The factor sin α / α is evaluated with
//! [`math::sinc`], so α = 0 is not a division by zero.
//!
//! **Limitation**, shown in the simulator: (33) is a regulation law. Chasing a reference
//! that moves at v_r, it can only produce v = v_r while r_e = v_r/(γ cos α) > 0, so the
//! robot trails the reference by ≈ v_r/γ forever.

use crate::kinematics::{tracking_error, BodyVelocity, Pose, TrackingError};
use crate::law::LawOutput;
use crate::math;

/// Gains of the paper's law (all > 0).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct PaperGains {
    /// γ in (33)–(34), 1/s: forward speed per metre of distance.
    pub gamma: f32,
    /// k in (34), 1/s: yaw rate per radian of α.
    pub k: f32,
    /// h in (30)/(34), dimensionless: weight of β against α.
    pub h: f32,
    /// λ in (30), 1/m²: weight of distance in V (does not enter the law itself).
    pub lambda: f32,
}

/// The polar error coordinates of the paper's law.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct PolarError {
    /// Distance r_e from robot to reference point, m.
    pub r_e_m: f32,
    /// α = ψ − θ, the line of sight seen from the robot heading, rad, in (−π, π].
    pub alpha_rad: f32,
    /// β = ψ − θ_r, the line of sight seen from the reference heading, rad, in (−π, π].
    pub beta_rad: f32,
}

/// The polar error of `robot` with respect to the reference pose `target` (world frame).
pub fn polar_error(robot: &Pose, target: &Pose) -> PolarError {
    let dx = target.x_m - robot.x_m;
    let dy = target.y_m - robot.y_m;
    let line_of_sight = math::atan2(dy, dx);
    PolarError {
        r_e_m: math::hypot(dx, dy),
        alpha_rad: math::wrap_angle(line_of_sight - robot.theta_rad),
        beta_rad: math::wrap_angle(line_of_sight - target.theta_rad),
    }
}

/// Eq. (30): V = ½λr_e² + ½(α² + hβ²).
pub fn lyapunov(gains: &PaperGains, e: &PolarError) -> f32 {
    0.5 * gains.lambda * e.r_e_m * e.r_e_m
        + 0.5 * (e.alpha_rad * e.alpha_rad + gains.h * e.beta_rad * e.beta_rad)
}

/// Eqs. (27)–(29): the rates (ṙ_e m/s, α̇ rad/s, β̇ rad/s) of the polar error when the
/// robot moves at `command` and the reference pose is **fixed**. Undefined at r_e = 0;
/// there the rates of α and β are returned as 0.
pub fn polar_error_rate(e: &PolarError, command: BodyVelocity) -> PolarError {
    let (sin_a, cos_a) = math::sin_cos(e.alpha_rad);
    let bearing_rate = if e.r_e_m > 0.0 {
        command.v_m_s * sin_a / e.r_e_m
    } else {
        0.0
    };
    PolarError {
        r_e_m: -command.v_m_s * cos_a,
        alpha_rad: -command.omega_rad_s + bearing_rate,
        beta_rad: bearing_rate,
    }
}

/// Eq. (32): V̇ for *any* command (v, ω) and a fixed reference,
/// V̇ = −λ r_e v cos α + α [−ω + v (sin α / (r_e α)) (α + hβ)].
/// Under the law (33)–(34) it reduces to (35).
pub fn lyapunov_rate(gains: &PaperGains, e: &PolarError, command: BodyVelocity) -> f32 {
    let cos_a = math::cos(e.alpha_rad);
    let bearing = if e.r_e_m > 0.0 {
        command.v_m_s * math::sinc(e.alpha_rad) / e.r_e_m
    } else {
        0.0
    };
    -gains.lambda * e.r_e_m * command.v_m_s * cos_a
        + e.alpha_rad * (-command.omega_rad_s + bearing * (e.alpha_rad + gains.h * e.beta_rad))
}

/// Eqs. (33)–(34) for a robot at `robot` and the reference pose `target`, with V (30) and
/// V̇ (35).
pub fn steer(gains: &PaperGains, robot: &Pose, target: &Pose) -> LawOutput {
    with_tracking_error(gains, robot, target, tracking_error(robot, target))
}

/// Eqs. (33)–(34) as [`steer`], with the tracking error (9) of `robot` against `target`
/// already computed (`error`; it is reported, the law itself uses the polar error).
pub fn with_tracking_error(
    gains: &PaperGains,
    robot: &Pose,
    target: &Pose,
    error: TrackingError,
) -> LawOutput {
    let e = polar_error(robot, target);
    let (sin_a, cos_a) = math::sin_cos(e.alpha_rad);
    let v = gains.gamma * e.r_e_m * cos_a;
    let omega = gains.k * e.alpha_rad
        + gains.gamma
            * cos_a
            * math::sinc_with_sin(e.alpha_rad, sin_a)
            * (e.alpha_rad + gains.h * e.beta_rad);
    let radial = e.r_e_m * cos_a;
    LawOutput {
        command: BodyVelocity::new(v, omega),
        lyapunov: lyapunov(gains, &e),
        lyapunov_rate: -gains.lambda * gains.gamma * radial * radial
            - gains.k * e.alpha_rad * e.alpha_rad,
        error,
        polar: Some(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::pose_rate;
    use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    use proptest::prelude::*;

    const GAINS: PaperGains = PaperGains {
        gamma: 1.0,
        k: 2.0,
        h: 1.5,
        lambda: 1.0,
    };

    #[test]
    fn polar_error_hand_values() {
        // Robot at origin heading +y; target at (1, 1) heading +x.
        // ψ = π/4, α = π/4 − π/2 = −π/4, β = π/4 − 0 = π/4, r = √2.
        let e = polar_error(&Pose::new(0.0, 0.0, FRAC_PI_2), &Pose::new(1.0, 1.0, 0.0));
        assert!((e.r_e_m - 2f32.sqrt()).abs() < 1e-6);
        assert!((e.alpha_rad + FRAC_PI_4).abs() < 1e-6);
        assert!((e.beta_rad - FRAC_PI_4).abs() < 1e-6);
    }

    #[test]
    fn law_hand_values() {
        // Same geometry: v = γ r cos α = √2·cos(π/4) = 1, and
        // ω = kα + γ cos α (sin α/α)(α + hβ) with α = −π/4, β = π/4.
        let out = steer(
            &GAINS,
            &Pose::new(0.0, 0.0, FRAC_PI_2),
            &Pose::new(1.0, 1.0, 0.0),
        );
        let a = -FRAC_PI_4;
        let b = FRAC_PI_4;
        let expected_w = 2.0 * a + a.cos() * (a.sin() / a) * (a + 1.5 * b);
        assert!((out.command.v_m_s - 1.0).abs() < 1e-6);
        assert!((out.command.omega_rad_s - expected_w).abs() < 1e-6);
        // V = ½·2 + ½(π²/16 + 1.5π²/16).
        let expected_v = 1.0 + 0.5 * (PI * PI / 16.0) * 2.5;
        assert!((out.lyapunov - expected_v).abs() < 1e-5);
        // V̇ = −λγ(r cos α)² − kα² = −1 − 2π²/16.
        assert!((out.lyapunov_rate - (-1.0 - PI * PI / 8.0)).abs() < 1e-5);
    }

    #[test]
    fn singularity_at_zero_alpha_is_finite() {
        // Robot looking straight at the target: α = 0, sin α / α must be 1, not NaN.
        let out = steer(&GAINS, &Pose::new(0.0, 0.0, 0.0), &Pose::new(2.0, 0.0, 0.5));
        assert!(out.command.omega_rad_s.is_finite());
        assert!((out.command.v_m_s - 2.0).abs() < 1e-6);
        // β = −0.5: ω = γ·1·1·(0 + h·β) = −0.75.
        assert!((out.command.omega_rad_s + 0.75).abs() < 1e-6);
        // On the target itself: r = 0 gives a finite, zero speed.
        let at = steer(&GAINS, &Pose::new(1.0, 1.0, 0.3), &Pose::new(1.0, 1.0, 0.3));
        assert_eq!(at.command.v_m_s, 0.0);
        assert!(at.command.omega_rad_s.is_finite());
    }

    #[test]
    fn rates_on_the_target_are_finite() {
        // r_e = 0: the bearing is undefined, its rate is taken as 0 (no division by 0).
        let on_target = PolarError {
            r_e_m: 0.0,
            alpha_rad: 0.4,
            beta_rad: -0.2,
        };
        let command = BodyVelocity::new(0.3, 0.5);
        let rate = polar_error_rate(&on_target, command);
        assert_eq!(rate.alpha_rad, -0.5);
        assert_eq!(rate.beta_rad, 0.0);
        assert!((rate.r_e_m + 0.3 * 0.4f32.cos()).abs() < 1e-6);
        // (32) there: only the −αω term is left.
        assert!((lyapunov_rate(&GAINS, &on_target, command) - 0.4 * -0.5).abs() < 1e-6);
        // Just off the target the rates are large but finite and follow (28)–(29).
        let near = PolarError {
            r_e_m: 1e-3,
            ..on_target
        };
        let rate = polar_error_rate(&near, command);
        let bearing = 0.3 * 0.4f32.sin() / 1e-3;
        assert!((rate.beta_rad - bearing).abs() < 1e-3 * bearing);
        assert!((rate.alpha_rad - (bearing - 0.5)).abs() < 1e-3 * bearing);
    }

    #[test]
    fn polar_rates_match_finite_differences_for_a_fixed_target() {
        // Eqs. (27)–(29) against a central difference of the polar error along (5).
        let robot = Pose::new(0.3, -0.2, 0.4);
        let target = Pose::new(1.5, 0.8, -0.7);
        let command = BodyVelocity::new(0.35, -0.6);
        let rate = pose_rate(&robot, command);
        let dt = 1e-3f32;
        let moved = |h: f32| {
            let p = Pose::new(
                robot.x_m + rate.x_dot_m_s * h,
                robot.y_m + rate.y_dot_m_s * h,
                robot.theta_rad + rate.theta_dot_rad_s * h,
            );
            polar_error(&p, &target)
        };
        let (ahead, behind) = (moved(dt), moved(-dt));
        let e = polar_error(&robot, &target);
        let predicted = polar_error_rate(&e, command);
        assert!(((ahead.r_e_m - behind.r_e_m) / (2.0 * dt) - predicted.r_e_m).abs() < 1e-3);
        assert!(
            ((ahead.alpha_rad - behind.alpha_rad) / (2.0 * dt) - predicted.alpha_rad).abs() < 1e-3
        );
        assert!(
            ((ahead.beta_rad - behind.beta_rad) / (2.0 * dt) - predicted.beta_rad).abs() < 1e-3
        );
        // (31) from these rates equals (32).
        let v31 = GAINS.lambda * e.r_e_m * predicted.r_e_m
            + e.alpha_rad * predicted.alpha_rad
            + GAINS.h * e.beta_rad * predicted.beta_rad;
        assert!((v31 - lyapunov_rate(&GAINS, &e, command)).abs() < 1e-5);
    }

    proptest! {
        /// Under the law, (32) reduces to (35).
        #[test]
        fn eq_32_reduces_to_eq_35_under_the_law(
            x in -3.0f32..3.0, y in -3.0f32..3.0, th in -3.1f32..3.1, tth in -3.1f32..3.1,
        ) {
            let robot = Pose::new(x, y, th);
            let target = Pose::new(0.0, 0.0, tth);
            let out = steer(&GAINS, &robot, &target);
            let general = lyapunov_rate(&GAINS, &polar_error(&robot, &target), out.command);
            prop_assert!((general - out.lyapunov_rate).abs() < 1e-3 * (1.0 + general.abs()));
        }

        /// For a fixed reference, V̇ from (35) is ≤ 0 and agrees with the finite-difference
        /// V̇ along one small unicycle step under the law's own command.
        #[test]
        fn lyapunov_rate_is_negative_and_matches_finite_difference(
            x in -3.0f32..3.0, y in -3.0f32..3.0, th in -3.1f32..3.1,
            tx in -3.0f32..3.0, ty in -3.0f32..3.0, tth in -3.1f32..3.1,
        ) {
            let robot = Pose::new(x, y, th);
            let target = Pose::new(tx, ty, tth);
            let e = polar_error(&robot, &target);
            // Away from the places where the polar coordinates are not differentiable:
            // r_e = 0 and the ±π wrap of α and β.
            prop_assume!(e.r_e_m > 0.2);
            prop_assume!(e.alpha_rad.abs() < 3.0 && e.beta_rad.abs() < 3.0);
            let out = steer(&GAINS, &robot, &target);
            prop_assert!(out.lyapunov_rate <= 0.0);
            // Central difference along the unicycle (5) under the law's own command.
            let dt = 1e-3f32;
            let rate = pose_rate(&robot, out.command);
            let moved = |h: f32| Pose::new(
                robot.x_m + rate.x_dot_m_s * h,
                robot.y_m + rate.y_dot_m_s * h,
                robot.theta_rad + rate.theta_dot_rad_s * h,
            );
            let v_ahead = lyapunov(&GAINS, &polar_error(&moved(dt), &target));
            let v_behind = lyapunov(&GAINS, &polar_error(&moved(-dt), &target));
            let finite_difference = (v_ahead - v_behind) / (2.0 * dt);
            let scale = 1.0 + out.lyapunov_rate.abs();
            prop_assert!(
                (finite_difference - out.lyapunov_rate).abs() < 0.05 * scale,
                "fd {} vs (35) {}", finite_difference, out.lyapunov_rate
            );
        }
    }
}
