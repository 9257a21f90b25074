//! Kanayama, Kimura, Miyazaki and Noguchi (1990), "A stable tracking control method for an
//! autonomous mobile robot": the classic tracking baseline.
//!
//! - v = v_r cos θ_e + K_x x_e,
//! - ω = ω_r + v_r (K_y y_e + K_θ sin θ_e),
//!
//! with the robot-frame error (x_e, y_e, θ_e) of eq. (9). Its Lyapunov function is
//! V = ½(x_e² + y_e²) + (1 − cos θ_e)/K_y, with V̇ = −K_x x_e² − v_r K_θ sin²θ_e / K_y ≤ 0.

use crate::kinematics::{tracking_error, BodyVelocity, Pose, TrackingError};
use crate::law::LawOutput;
use crate::math;
use crate::reference::ReferenceState;

/// Gains of Kanayama's law (all > 0).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct KanayamaGains {
    /// K_x, 1/s: forward speed per metre of along-track error.
    pub k_x: f32,
    /// K_y, 1/m²: yaw rate per (m/s of v_r × m of cross-track error).
    pub k_y: f32,
    /// K_θ, 1/m: yaw rate per (m/s of v_r × sin θ_e).
    pub k_theta: f32,
}

/// Kanayama's law for a robot at `robot` and a moving `reference`, with V and V̇.
pub fn steer(gains: &KanayamaGains, robot: &Pose, reference: &ReferenceState) -> LawOutput {
    from_error(gains, tracking_error(robot, &reference.pose), reference)
}

/// Kanayama's law from the tracking error `e` (eq. (9), robot frame) of the robot against
/// the moving `reference`.
pub fn from_error(
    gains: &KanayamaGains,
    e: TrackingError,
    reference: &ReferenceState,
) -> LawOutput {
    let (sin_e, cos_e) = math::sin_cos(e.theta_e_rad);
    let v = reference.v_m_s * cos_e + gains.k_x * e.x_e_m;
    let omega =
        reference.omega_rad_s + reference.v_m_s * (gains.k_y * e.y_e_m + gains.k_theta * sin_e);
    LawOutput {
        command: BodyVelocity::new(v, omega),
        lyapunov: 0.5 * (e.x_e_m * e.x_e_m + e.y_e_m * e.y_e_m) + (1.0 - cos_e) / gains.k_y,
        lyapunov_rate: -gains.k_x * e.x_e_m * e.x_e_m
            - reference.v_m_s * gains.k_theta * sin_e * sin_e / gains.k_y,
        error: e,
        polar: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tracking_error_rate;
    use proptest::prelude::*;

    const GAINS: KanayamaGains = KanayamaGains {
        k_x: 2.0,
        k_y: 20.0,
        k_theta: 6.0,
    };

    #[test]
    fn hand_values() {
        // Robot at origin facing +x; reference (0.1, 0.2, 0.5 rad), v_r = 0.2, ω_r = 0.1.
        let r = ReferenceState {
            pose: Pose::new(0.1, 0.2, 0.5),
            v_m_s: 0.2,
            omega_rad_s: 0.1,
            ..ReferenceState::default()
        };
        let out = steer(&GAINS, &Pose::default(), &r);
        assert!((out.command.v_m_s - (0.2 * 0.5f32.cos() + 0.2)).abs() < 1e-6);
        let w = 0.1 + 0.2 * (20.0 * 0.2 + 6.0 * 0.5f32.sin());
        assert!((out.command.omega_rad_s - w).abs() < 1e-6);
        // V = ½(x_e² + y_e²) + (1 − cos θ_e)/K_y, V̇ = −K_x x_e² − v_r K_θ sin²θ_e / K_y.
        let v = 0.5 * (0.01 + 0.04) + (1.0 - 0.5f32.cos()) / 20.0;
        assert!((out.lyapunov - v).abs() < 1e-6);
        let v_dot = -2.0 * 0.01 - 0.2 * 6.0 * 0.5f32.sin().powi(2) / 20.0;
        assert!((out.lyapunov_rate - v_dot).abs() < 1e-6);
        assert_eq!(out.error, tracking_error(&Pose::default(), &r.pose));
        assert_eq!(out.polar, None);
    }

    proptest! {
        /// The closed-form V̇ equals V̇ computed from the error dynamics (10).
        #[test]
        fn lyapunov_rate_matches_error_dynamics(
            x in -2.0f32..2.0, y in -2.0f32..2.0, th in -3.1f32..3.1,
            tth in -3.1f32..3.1, v_r in 0.0f32..1.0, w_r in -1.0f32..1.0,
        ) {
            let r = ReferenceState {
                pose: Pose::new(0.0, 0.0, tth),
                v_m_s: v_r,
                omega_rad_s: w_r,
                ..ReferenceState::default()
            };
            let robot = Pose::new(x, y, th);
            let out = steer(&GAINS, &robot, &r);
            let e = tracking_error(&robot, &r.pose);
            let rate = tracking_error_rate(&e, out.command, r.velocity());
            let v_dot = e.x_e_m * rate.x_e_m + e.y_e_m * rate.y_e_m
                + math::sin(e.theta_e_rad) * rate.theta_e_rad / GAINS.k_y;
            prop_assert!(out.lyapunov_rate <= 0.0);
            prop_assert!((v_dot - out.lyapunov_rate).abs() < 1e-3 * (1.0 + v_dot.abs()));
        }
    }
}
