//! Incremental (velocity-form) PID, paper eqs. (36)–(38), with the typo in (38) fixed.
//!
//! The positional PID (36), m(t) = K_p e + K_i ∫e + K_d de/dt, discretised with period T,
//! is written in increments (37): Δm(k) = K_p Δe(k) + K_i e(k) + K_d Δ²e(k), and (38):
//!
//! Δm(k) = v₀ e(k) + v₁ e(k−1) + v₂ e(k−2), with v₀ = K_p + K_i + K_d, v₁ = −K_p − 2K_d,
//! **v₂ = K_d** (the paper prints 2K_d, which expands to a spurious integrating D term).
//!
//! Here K_i = K_p·T/T_i and K_d = K_p·T_d/T are the *discrete* gains for sample period T:
//! build them from continuous ones with [`PidGains::from_continuous`].
//!
//! Additions a real wheel loop needs, none of which change (38) when switched off:
//!
//! - **Output clamp with anti-windup**: the stored m(k−1) is the clamped output, so the
//!   integrator cannot wind up while the motor is saturated (the velocity form's natural
//!   anti-windup).
//! - **Feed-forward** u = m + K_ff·r: a motor command per unit set-point, so the PID only
//!   corrects the model's error. The clamp applies to the sum.
//! - **First-order filter on the D term**: d(k) = α d(k−1) + (1−α) K_d Δe(k); the
//!   increment then uses d(k) − d(k−1). With α = 0 it is exactly K_d Δ²e(k).
//! - **Bumpless reset and retune**: the state is the last output, so changing gains or
//!   restarting from a known output does not jump the command.

use crate::math;

/// Discrete PID gains for one sample period, plus feed-forward and D filter.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct PidGains {
    /// Proportional gain K_p, output per unit error.
    pub kp: f32,
    /// Discrete integral gain K_i = K_p·T/T_i, output per unit error per step.
    pub ki: f32,
    /// Discrete derivative gain K_d = K_p·T_d/T, output per unit error change per step.
    pub kd: f32,
    /// D-filter pole α in [0, 1): 0 is no filter; α = exp(−T/τ) for a time constant τ.
    pub d_filter_alpha: f32,
    /// Feed-forward K_ff, output per unit set-point.
    pub feed_forward: f32,
}

impl PidGains {
    /// Discrete gains for sample period `period_s` (s) from continuous ones: proportional
    /// `kp`, integral time `ti_s` (s; 0 or ∞ disables I), derivative time `td_s` (s),
    /// D-filter time constant `d_filter_tau_s` (s; 0 disables the filter), feed-forward
    /// `feed_forward` (output per unit set-point).
    pub fn from_continuous(
        kp: f32,
        ti_s: f32,
        td_s: f32,
        d_filter_tau_s: f32,
        feed_forward: f32,
        period_s: f32,
    ) -> Self {
        let ki = if ti_s > 0.0 && ti_s.is_finite() {
            kp * period_s / ti_s
        } else {
            0.0
        };
        let d_filter_alpha = if d_filter_tau_s > 0.0 {
            // exp(−T/τ) by its [1/1] Padé approximant, which is within 1e-3 for T ≤ τ
            // and keeps α in [0, 1) for any T > 0.
            let x = period_s / d_filter_tau_s;
            math::clamp((2.0 - x) / (2.0 + x), 0.0, 0.999)
        } else {
            0.0
        };
        Self {
            kp,
            ki,
            kd: kp * td_s / period_s,
            d_filter_alpha,
            feed_forward,
        }
    }

    /// The coefficients (v₀, v₁, v₂) of eq. (38), corrected: v₂ = K_d.
    pub fn coefficients(&self) -> [f32; 3] {
        [
            self.kp + self.ki + self.kd,
            -self.kp - 2.0 * self.kd,
            self.kd,
        ]
    }

    /// True when every gain is finite and α is in [0, 1).
    pub fn is_valid(&self) -> bool {
        self.kp.is_finite()
            && self.ki.is_finite()
            && self.kd.is_finite()
            && self.feed_forward.is_finite()
            && self.d_filter_alpha >= 0.0
            && self.d_filter_alpha < 1.0
    }
}

/// Incremental PID state for one wheel (see the module doc). Output in [−limit, limit].
#[derive(Clone, Copy, Debug)]
pub struct IncrementalPid {
    gains: PidGains,
    output_limit: f32,
    /// Feedback part of the last (clamped) output, m(k−1).
    feedback: f32,
    /// e(k−1).
    error_1: f32,
    /// Filtered derivative term d(k−1).
    derivative: f32,
}

impl IncrementalPid {
    /// A PID with `gains`, output clamped to ±`output_limit` (use 1 for a duty cycle),
    /// starting from output 0.
    pub fn new(gains: PidGains, output_limit: f32) -> Self {
        Self {
            gains,
            output_limit: math::abs(output_limit),
            feedback: 0.0,
            error_1: 0.0,
            derivative: 0.0,
        }
    }

    /// The gains in use.
    pub const fn gains(&self) -> PidGains {
        self.gains
    }

    /// One sample: set-point `setpoint` and measurement `measured` (same unit, e.g. rad/s).
    /// Returns the clamped output m(k) + K_ff·setpoint.
    ///
    /// A non-finite input leaves the state untouched and returns 0.
    pub fn step(&mut self, setpoint: f32, measured: f32) -> f32 {
        let error = setpoint - measured;
        if !error.is_finite() {
            return 0.0;
        }
        let g = &self.gains;
        let delta_error = error - self.error_1;
        let derivative =
            g.d_filter_alpha * self.derivative + (1.0 - g.d_filter_alpha) * g.kd * delta_error;
        // Eq. (37): Δm = K_p Δe + K_i e + Δ(D term); with α = 0 this is eq. (38).
        let increment = g.kp * delta_error + g.ki * error + (derivative - self.derivative);
        let feed_forward = g.feed_forward * setpoint;
        let output = math::clamp(
            self.feedback + increment + feed_forward,
            -self.output_limit,
            self.output_limit,
        );
        // Anti-windup: remember the clamped output, not the unclamped sum.
        self.feedback = output - feed_forward;
        self.error_1 = error;
        self.derivative = derivative;
        output
    }

    /// Restarts so that the feedback part of the output is `feedback` (0 for a standstill):
    /// the next output continues from there without a jump, and the error history is
    /// cleared so Δe does not kick.
    pub fn reset(&mut self, feedback: f32) {
        self.feedback = math::clamp(feedback, -self.output_limit, self.output_limit);
        self.error_1 = 0.0;
        self.derivative = 0.0;
    }

    /// Changes gains without a bump: the last output is kept; the stored derivative term is
    /// rescaled to the new K_d so the next increment does not jump.
    pub fn set_gains(&mut self, gains: PidGains) {
        if self.gains.kd != 0.0 {
            self.derivative *= gains.kd / self.gains.kd;
        } else {
            self.derivative = 0.0;
        }
        self.gains = gains;
    }

    /// Primes the error history with `setpoint − measured` so that a fresh loop starts
    /// without a proportional kick.
    pub fn prime(&mut self, setpoint: f32, measured: f32) {
        let e = setpoint - measured;
        if e.is_finite() {
            self.error_1 = e;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gains(kp: f32, ki: f32, kd: f32) -> PidGains {
        PidGains {
            kp,
            ki,
            kd,
            d_filter_alpha: 0.0,
            feed_forward: 0.0,
        }
    }

    #[test]
    fn coefficients_are_the_corrected_eq_38() {
        let g = gains(2.0, 0.5, 0.25);
        assert_eq!(g.coefficients(), [2.75, -2.5, 0.25]);
    }

    #[test]
    fn from_continuous_hand_values() {
        // K_p = 0.1, T_i = 0.05 s, T_d = 0.002 s, T = 1 ms: K_i = 0.002, K_d = 0.2.
        let g = PidGains::from_continuous(0.1, 0.05, 0.002, 0.0, 0.03, 0.001);
        assert!((g.ki - 0.002).abs() < 1e-9);
        assert!((g.kd - 0.2).abs() < 1e-7);
        assert_eq!(g.d_filter_alpha, 0.0);
        assert_eq!(
            PidGains::from_continuous(0.1, 0.0, 0.0, 0.0, 0.0, 0.001).ki,
            0.0
        );
        let f = PidGains::from_continuous(0.1, 0.0, 0.0, 0.01, 0.0, 0.001);
        assert!((f.d_filter_alpha - (-0.1f32).exp()).abs() < 1e-3);
    }

    /// Positional PID (36) discretised: rectangle integral, backward-difference derivative.
    fn positional(g: PidGains, errors: &[f32]) -> Vec<f32> {
        let mut integral = 0.0;
        let mut previous = 0.0;
        errors
            .iter()
            .map(|&e| {
                integral += e;
                let m = g.kp * e + g.ki * integral + g.kd * (e - previous);
                previous = e;
                m
            })
            .collect()
    }

    #[test]
    fn unsaturated_incremental_equals_positional_and_eq_38() {
        let g = gains(0.8, 0.05, 0.3);
        let errors: Vec<f32> = (0..200).map(|k| (k as f32 * 0.37).sin() * 0.4).collect();
        let mut pid = IncrementalPid::new(g, 1e6);
        let [v0, v1, v2] = g.coefficients();
        let (mut e1, mut e2, mut m38) = (0.0, 0.0, 0.0);
        for (k, (&e, expected)) in errors.iter().zip(positional(g, &errors)).enumerate() {
            let m = pid.step(e, 0.0);
            assert!((m - expected).abs() < 1e-4, "k = {k}: {m} vs {expected}");
            // The same sequence through the three-coefficient form (38).
            m38 += v0 * e + v1 * e1 + v2 * e2;
            (e2, e1) = (e1, e);
            assert!((m - m38).abs() < 1e-4, "k = {k}: {m} vs (38) {m38}");
        }
    }

    #[test]
    fn recovers_from_saturation_without_windup() {
        // Pure I controller against a large error saturates at 1 for 1000 steps. When the
        // error changes sign the output must leave the limit at once: a wound-up integrator
        // would stay at 1 for hundreds of steps.
        let mut pid = IncrementalPid::new(gains(0.0, 0.01, 0.0), 1.0);
        let saturated: Vec<f32> = (0..1000).map(|_| pid.step(10.0, 0.0)).collect();
        assert!(saturated[10..].iter().all(|&m| m == 1.0));
        let after = pid.step(-10.0, 0.0);
        assert!(after < 1.0 && after > 0.85, "{after}");
        let mut steps = 1;
        while pid.step(-10.0, 0.0) > 0.0 {
            steps += 1;
        }
        assert!(steps <= 11, "left saturation in {steps} steps");
    }

    #[test]
    fn feed_forward_and_clamp_share_the_limit() {
        let mut pid = IncrementalPid::new(
            PidGains {
                feed_forward: 0.1,
                ..gains(0.0, 0.0, 0.0)
            },
            1.0,
        );
        assert!((pid.step(5.0, 5.0) - 0.5).abs() < 1e-7);
        assert_eq!(pid.step(20.0, 20.0), 1.0);
        assert_eq!(pid.step(-20.0, -20.0), -1.0);
    }

    #[test]
    fn d_filter_smooths_a_step() {
        let raw = gains(0.0, 0.0, 1.0);
        let filtered = PidGains {
            d_filter_alpha: 0.5,
            ..raw
        };
        let mut a = IncrementalPid::new(raw, 10.0);
        let mut b = IncrementalPid::new(filtered, 10.0);
        assert_eq!(a.step(1.0, 0.0), 1.0);
        assert_eq!(b.step(1.0, 0.0), 0.5);
        assert_eq!(a.step(1.0, 0.0), 0.0);
        assert_eq!(b.step(1.0, 0.0), 0.25);
    }

    #[test]
    fn reset_and_retune_are_bumpless() {
        let mut pid = IncrementalPid::new(gains(0.5, 0.02, 0.0), 1.0);
        for _ in 0..50 {
            pid.step(1.0, 0.5);
        }
        let before = pid.step(1.0, 0.5);
        pid.set_gains(gains(0.9, 0.02, 0.0));
        let after = pid.step(1.0, 0.5);
        // Same error: only the integral increment K_i·e is added, no jump from the new K_p.
        assert!((after - before - 0.01).abs() < 1e-6);
        pid.reset(0.3);
        pid.prime(1.0, 1.0);
        assert!((pid.step(1.0, 1.0) - 0.3).abs() < 1e-7);
    }

    #[test]
    fn non_finite_input_gives_zero() {
        let mut pid = IncrementalPid::new(gains(1.0, 0.1, 0.1), 1.0);
        assert_eq!(pid.step(f32::NAN, 0.0), 0.0);
        assert_eq!(pid.step(0.0, f32::INFINITY), 0.0);
        assert!(pid.step(0.1, 0.0).is_finite());
    }
}
