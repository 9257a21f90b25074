//! The chassis coupling: the wheels' inertia matrix and the torques on them.
//!
//! Contract: [`inertia_matrix_kg_m2`] is the matrix the whole plant integrates with
//! (`Plant::new` refuses one that is not positive definite); `torques_without_friction`
//! is every torque on the wheels but Coulomb/static friction, which `friction` decides;
//! `accel` is the full model, M⁻¹ (τ + Q) with the friction of the step.
//!
//! ## Dynamics
//!
//! With no slip, the chassis' forward speed v and yaw rate Ω follow from the wheel speeds
//! (eq. (4) of the paper): v = R (ω_l + ω_r)/2, Ω = R (ω_r − ω_l)/L. The chassis has mass
//! m, its centre of mass a distance d ahead of the wheel axle on the centre line
//! ([`BodyParams::com_ahead_of_axle_m`](robot_files::plant::BodyParams::com_ahead_of_axle_m), default 0), and yaw inertia I **about the vertical
//! axis through the axle's midpoint** (I = I_com + m d²); each wheel side adds J_w = wheel
//! inertia + rotor inertia × N². Its kinetic energy, ½ m v² + ½ I Ω² + ½ J_w (ω_l² + ω_r²),
//! gives a symmetric 2 × 2 inertia matrix on (ω_l, ω_r):
//!
//! ```text
//! ⎡a b⎤ ⎡ω̇_l⎤   ⎡τ_l + Q_l⎤      a = J_w + m R²/4 + I R²/L²
//! ⎣b a⎦ ⎣ω̇_r⎦ = ⎣τ_r + Q_r⎦,     b = m R²/4 − I R²/L²
//! ```
//!
//! with τ the net wheel torques of [`crate::plant::motor`] and Q the centre-of-mass terms. The
//! no-side-slip constraint acts at the axle, so a centre of mass off the axle adds the
//! standard differential-drive terms m v̇ − m d Ω² = F and I Ω̇ + m d v Ω = T (F, T the
//! wheels' force and yaw torque on the chassis), which in wheel coordinates are
//!
//! ```text
//! Q_l = (R/2) m d Ω² + (R/L) m d v Ω,     Q_r = (R/2) m d Ω² − (R/L) m d v Ω.
//! ```
//!
//! They do no work (Q · ω = m d Ω² v − m d v Ω² = 0): turning on the spot with the centre
//! of mass ahead of the axle pulls the robot forward. With d = 0 (the default) they vanish
//! and the dynamics are affine between regime changes. Driving one wheel drags the other
//! through b ≠ 0; forward motion sees a + b and turning a − b. R is the mean of the two true
//! wheel radii. Slip does not change the inertia seen by the motors (a wheel slipping on a
//! slippery floor would see less of the chassis): a small, stated approximation.
//!
//! ## Lifted wheels
//!
//! [`Load::Lifted`] puts the robot on a stand: M = diag(J_w, J_w), no coupling, no
//! centre-of-mass terms, and the true pose stays where it is. Wheel loops tuned this way
//! see a third of the driving inertia (the default robot: τ 26 ms lifted, 89 ms driving
//! straight), which is why a tune on a stand must be corrected before it drives.
//!
//! ## Static friction (Karnopp, with the coupling)
//!
//! A wheel at rest (ω_i = 0 exactly) stays at rest only if its static friction (τ_c, at
//! most) can supply the constraint torque that holds it there, given the other wheel's
//! pull through b: a strongly driven wheel drags an unpowered one along once
//! |b| (τ_j − τ_c)/a exceeds τ_c. The derivation and the rules are in `friction`.

use super::super::friction::Grip;
use super::{Plant, PlantParams};
use robot_files::plant::Load;

/// The inertia matrix [a, b] of `params` (see [`Plant::inertia_kg_m2`]), kg·m².
pub(super) fn inertia_matrix_kg_m2(params: &PlantParams) -> [f64; 2] {
    let body = &params.body;
    let g = &params.geometry;
    let j_w =
        body.wheel_inertia_kg_m2 + params.motor.rotor_inertia_kg_m2 * params.gear_ratio.powi(2);
    match params.load {
        Load::Ground => {
            let r = 0.5 * (g.wheel_radius_left_m + g.wheel_radius_right_m);
            let translational = body.mass_kg * r * r / 4.0;
            let rotational = body.yaw_inertia_kg_m2 * r * r / (g.track_width_m * g.track_width_m);
            [j_w + translational + rotational, translational - rotational]
        }
        Load::Lifted => [j_w, 0.0],
    }
}

impl Plant {
    /// The inertia matrix on the wheel speeds (ω_l, ω_r), [a, b] for M = [[a, b], [b, a]],
    /// kg·m² (module doc): a + b is what each wheel sees driving straight, a − b turning on
    /// the spot; lifted, b = 0 and a is the wheel's own inertia.
    pub fn inertia_kg_m2(&self) -> [f64; 2] {
        [self.friction.inertia.a, self.friction.inertia.b]
    }

    /// Wheel torques [left, right] at speeds `w`, N·m, everything but Coulomb/static
    /// friction: electrical torque, viscous friction and the centre-of-mass terms.
    pub(super) fn torques_without_friction(&self, w: [f64; 2]) -> [f64; 2] {
        let mut tau = [0.0; 2];
        for (i, t) in tau.iter_mut().enumerate() {
            let electrical = if self.coasting[i] {
                0.0
            } else {
                self.drives[i].electrical_torque_nm(self.volts[i], w[i])
            };
            *t = electrical - self.drives[i].viscous_nm_s_per_rad * w[i];
        }
        if self.mass_com != 0.0 {
            let v = 0.5 * self.radius_m * (w[0] + w[1]);
            let yaw = self.radius_m * (w[1] - w[0]) / self.track_m;
            let forward = 0.5 * self.radius_m * self.mass_com * yaw * yaw;
            let turning = self.radius_m / self.track_m * self.mass_com * v * yaw;
            tau[0] += forward + turning;
            tau[1] += forward - turning;
        }
        tau
    }

    /// Wheel accelerations [left, right], rad/s², at wheel speeds `w` with friction
    /// `grip`: the full model.
    #[inline]
    pub(super) fn accel(&self, w: [f64; 2], grip: [Grip; 2]) -> [f64; 2] {
        self.friction
            .inertia
            .accel(self.torques_without_friction(w), grip)
    }
}
