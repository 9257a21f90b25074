//! A Lyapunov tracking law that reaches **zero** steady error on a moving reference.
//!
//! ## Why the paper's law cannot, and what changes
//!
//! The paper's V (30) measures the error in polar coordinates (r_e, α, β) about a *fixed*
//! target. Two things break when the target moves:
//!
//! 1. (27)–(29) miss the reference's own motion, so (35) no longer holds; the only
//!    equilibrium of (33) with v = v_r has r_e = v_r/(γ cos α) > 0: the robot trails.
//! 2. Adding feed-forward of (v_r, ω_r) can drive r_e to 0, but α and β are the direction
//!    of a zero-length vector there: the heading is left uncontrolled (a few degrees off).
//!
//! So this law keeps the paper's *design* — a quadratic Lyapunov function of distance and
//! angle, a sin θ/θ factor chosen to cancel the cross term, and V̇ = −(quadratic) ≤ 0 as in
//! (35) — but writes it in the coordinates that stay defined at zero error: the
//! robot-frame error (x_e, y_e, θ_e) of eq. (9), whose dynamics (10) include the reference
//! velocity (v_r, ω_r).
//!
//! ## The law and its proof
//!
//! V = ½λ(x_e² + y_e²) + ½θ_e²   (the analogue of (30), with r_e² = x_e² + y_e²)
//!
//! Along (10), V̇ = λ[−x_e v + x_e v_r cos θ_e + y_e v_r sin θ_e] + θ_e(ω_r − ω)
//! (the ω x_e y_e terms cancel). Choose
//!
//! - v = v_r cos θ_e + k_x x_e,
//! - ω = ω_r + λ v_r y_e (sin θ_e / θ_e) + k_θ θ_e,
//!
//! then V̇ = −λ k_x x_e² − k_θ θ_e² ≤ 0, the analogue of (35). V is bounded below and
//! non-increasing, so the errors stay bounded and, by Barbalat's lemma (V̈ is bounded for
//! bounded v_r, ω_r and their rates), x_e → 0 and θ_e → 0. Then θ̇_e → 0 forces
//! ω − ω_r = λ v_r y_e (sin θ_e/θ_e) → 0, so y_e → 0 whenever the reference keeps moving
//! (v_r does not tend to 0). All three errors reach zero: position *and* heading.
//!
//! This is the quadratic-heading member of the family of Kanayama et al. (1990), whose
//! V uses (1 − cos θ_e)/K_y instead of ½θ_e²; the quadratic form is the one the paper uses.

use crate::kinematics::{tracking_error, BodyVelocity, Pose, TrackingError};
use crate::law::LawOutput;
use crate::math;
use crate::reference::ReferenceState;

/// Gains of the tracking law (all > 0).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TrackingGains {
    /// λ, 1/m²: weight of the position error against the heading error in V.
    pub lambda: f32,
    /// k_x, 1/s: forward speed per metre of along-track error.
    pub k_x: f32,
    /// k_θ, 1/s: yaw rate per radian of heading error.
    pub k_theta: f32,
}

/// The tracking law for a robot at `robot` and a moving `reference`, with V and V̇.
pub fn steer(gains: &TrackingGains, robot: &Pose, reference: &ReferenceState) -> LawOutput {
    from_error(gains, tracking_error(robot, &reference.pose), reference)
}

/// The tracking law from the tracking error `e` (eq. (9), robot frame) of the robot
/// against the moving `reference`.
pub fn from_error(
    gains: &TrackingGains,
    e: TrackingError,
    reference: &ReferenceState,
) -> LawOutput {
    let (sin_e, cos_e) = math::sin_cos(e.theta_e_rad);
    let v = reference.v_m_s * cos_e + gains.k_x * e.x_e_m;
    let omega = reference.omega_rad_s
        + gains.lambda * reference.v_m_s * e.y_e_m * math::sinc_with_sin(e.theta_e_rad, sin_e)
        + gains.k_theta * e.theta_e_rad;
    LawOutput {
        command: BodyVelocity::new(v, omega),
        lyapunov: 0.5 * gains.lambda * (e.x_e_m * e.x_e_m + e.y_e_m * e.y_e_m)
            + 0.5 * e.theta_e_rad * e.theta_e_rad,
        lyapunov_rate: -gains.lambda * gains.k_x * e.x_e_m * e.x_e_m
            - gains.k_theta * e.theta_e_rad * e.theta_e_rad,
        error: e,
        polar: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tracking_error_rate;
    use proptest::prelude::*;

    const GAINS: TrackingGains = TrackingGains {
        lambda: 4.0,
        k_x: 2.0,
        k_theta: 3.0,
    };

    fn reference(x: f32, y: f32, th: f32, v: f32, w: f32) -> ReferenceState {
        ReferenceState {
            pose: Pose::new(x, y, th),
            v_m_s: v,
            omega_rad_s: w,
            ..ReferenceState::default()
        }
    }

    #[test]
    fn zero_error_gives_pure_feed_forward() {
        let r = reference(1.0, 2.0, 0.3, 0.25, 0.2);
        let out = steer(&GAINS, &Pose::new(1.0, 2.0, 0.3), &r);
        assert!((out.command.v_m_s - 0.25).abs() < 1e-7);
        assert!((out.command.omega_rad_s - 0.2).abs() < 1e-7);
        assert_eq!(out.lyapunov, 0.0);
    }

    #[test]
    fn hand_values() {
        // Robot at origin facing +x; reference at (0.1, 0.2) heading 0.5 rad, v_r = 0.2,
        // ω_r = 0.1. Then x_e = 0.1, y_e = 0.2, θ_e = 0.5.
        let out = steer(
            &GAINS,
            &Pose::new(0.0, 0.0, 0.0),
            &reference(0.1, 0.2, 0.5, 0.2, 0.1),
        );
        let v = 0.2 * 0.5f32.cos() + 2.0 * 0.1;
        let w = 0.1 + 4.0 * 0.2 * 0.2 * (0.5f32.sin() / 0.5) + 3.0 * 0.5;
        assert!((out.command.v_m_s - v).abs() < 1e-6);
        assert!((out.command.omega_rad_s - w).abs() < 1e-6);
        assert!((out.lyapunov_rate - (-4.0 * 2.0 * 0.01 - 3.0 * 0.25)).abs() < 1e-6);
        // V = ½λ(x_e² + y_e²) + ½θ_e².
        assert!((out.lyapunov - (0.5 * 4.0 * 0.05 + 0.5 * 0.25)).abs() < 1e-6);
        assert_eq!(out.polar, None);
        assert!((out.error.y_e_m - 0.2).abs() < 1e-6);
    }

    proptest! {
        /// V̇ computed from the error dynamics (10) under the law equals the closed form
        /// −λk_x x_e² − k_θ θ_e² (the cross terms cancel), for a moving reference.
        #[test]
        fn lyapunov_rate_closed_form_matches_error_dynamics(
            x in -2.0f32..2.0, y in -2.0f32..2.0, th in -3.1f32..3.1,
            tth in -3.1f32..3.1, v_r in 0.0f32..1.0, w_r in -1.0f32..1.0,
        ) {
            let r = reference(0.0, 0.0, tth, v_r, w_r);
            let robot = Pose::new(x, y, th);
            let out = steer(&GAINS, &robot, &r);
            let e = tracking_error(&robot, &r.pose);
            let rate = tracking_error_rate(&e, out.command, r.velocity());
            let v_dot = GAINS.lambda * (e.x_e_m * rate.x_e_m + e.y_e_m * rate.y_e_m)
                + e.theta_e_rad * rate.theta_e_rad;
            prop_assert!(out.lyapunov_rate <= 0.0);
            prop_assert!((v_dot - out.lyapunov_rate).abs() < 1e-3 * (1.0 + v_dot.abs()));
        }
    }
}
