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
//! - **Output bounds with anti-windup**: every step gets its own bounds (the wheel loop's
//!   voltage, current and slew limits change with the supply and the wheel speed). While
//!   the output is held at a bound, an integral increment K_i·e that pushes further into
//!   it is dropped (conditional integration), so the integrator cannot wind up while the
//!   motor is saturated; the proportional and derivative increments are kept. The stored
//!   m(k−1) is therefore the positional PID's P + I + D with I frozen, which may lie
//!   beyond the bound by the P and D parts. (The velocity form's usual anti-windup,
//!   storing the bounded output, also throws away the proportional action of a set-point
//!   step that saturates: after a 15 rad/s step of the reference wheel the output then
//!   falls back to the feed-forward within a few steps, and only the integral brings the
//!   speed up, which tied the integral time to the rise time instead of to the margins.)
//!   When a limit *after* the PID changes the output, [`IncrementalPid::apply_output`]
//!   tells it (back calculation, as ArduPilot's `AC_PID` is told when an actuator
//!   saturates).
//! - **Feed-forward** u = m + u_ff: the motor model's voltage for the set-point, so the
//!   PID only corrects the model's error. The bounds apply to the sum.
//! - **First-order filter on the D term**: d(k) = α d(k−1) + (1−α) K_d Δe(k); the
//!   increment then uses d(k) − d(k−1). With α = 0 it is exactly K_d Δ²e(k).
//! - **Late samples**: a sample that covers n periods (missed ticks) integrates n·K_i·e
//!   and differentiates over n·T.
//! - **Bumpless reset and retune**: the state is the last output, so changing gains or
//!   restarting from a known output does not jump the command.
//!
//! ## The parts, for telemetry
//!
//! The velocity form stores only m(k−1), so "the I term" is not a state of its own. The
//! parts are defined so that they add up to the output the PID asked for, before its
//! bounds: P = K_p·e(k), D = d(k) (the filtered derivative term), FF = u_ff, and
//! I = m(k) − P − D: what the integrator holds ([`PidParts`]). Unless the output was
//! held at a bound, that is the output.

use crate::math;

/// Discrete PID gains for one sample period, plus the D filter.
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
}

impl PidGains {
    /// Discrete gains for sample period `period_s` (s) from continuous ones: proportional
    /// `kp`, integral time `ti_s` (s; 0 or ∞ disables I), derivative time `td_s` (s),
    /// D-filter time constant `d_filter_tau_s` (s; 0 disables the filter).
    pub fn from_continuous(
        kp: f32,
        ti_s: f32,
        td_s: f32,
        d_filter_tau_s: f32,
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
            && self.d_filter_alpha >= 0.0
            && self.d_filter_alpha < 1.0
    }
}

/// Lower and upper bound of one output sample (same unit as the output, e.g. V).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest output allowed.
    pub min: f32,
    /// Largest output allowed (≥ `min`).
    pub max: f32,
}

impl Bounds {
    /// Symmetric bounds ±`limit` (|`limit`| is used).
    pub fn symmetric(limit: f32) -> Self {
        let limit = math::abs(limit);
        Self {
            min: -limit,
            max: limit,
        }
    }

    /// `x` clamped into the bounds (NaN passes through).
    pub fn clamp(&self, x: f32) -> f32 {
        math::clamp(x, self.min, self.max)
    }
}

/// The output split into its parts, which add up to it (see the module doc), in output
/// units (V for a wheel loop).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct PidParts {
    /// Proportional part K_p·e(k).
    pub p: f32,
    /// Integral part: what the PID asked for minus P, D and FF (the integrator).
    pub i: f32,
    /// Derivative part d(k) (filtered).
    pub d: f32,
    /// Feed-forward part.
    pub ff: f32,
}

/// Incremental PID state for one wheel (see the module doc).
#[derive(Clone, Copy, Debug)]
pub struct IncrementalPid {
    gains: PidGains,
    /// Feedback part of the last (bounded) output, m(k−1).
    feedback: f32,
    /// e(k−1).
    error_1: f32,
    /// Filtered derivative term d(k−1).
    derivative: f32,
    /// Feed-forward of the last output.
    feed_forward: f32,
    /// The last output was held at one of its bounds.
    clamped: bool,
}

impl IncrementalPid {
    /// A PID with `gains`, starting from output 0.
    pub fn new(gains: PidGains) -> Self {
        Self {
            gains,
            feedback: 0.0,
            error_1: 0.0,
            derivative: 0.0,
            feed_forward: 0.0,
            clamped: false,
        }
    }

    /// The gains in use.
    pub const fn gains(&self) -> PidGains {
        self.gains
    }

    /// One sample of error `error` (set-point − measurement) covering `periods` sample
    /// periods (1 on time; more when samples were missed), with `feed_forward` added.
    /// Returns m(k) + `feed_forward` clamped into `bounds`.
    ///
    /// A non-finite error or feed-forward leaves the state untouched and returns 0
    /// clamped into `bounds`.
    pub fn step(&mut self, error: f32, feed_forward: f32, bounds: Bounds, periods: f32) -> f32 {
        // One check covers both: NaN + x is NaN, and ±∞ + finite is not finite.
        if !(error + feed_forward).is_finite() {
            return bounds.clamp(0.0);
        }
        let g = &self.gains;
        let delta_error = error - self.error_1;
        // Eq. (37): Δm = K_p Δe + K_i e + Δ(D term); with α = 0 and one period, eq. (38).
        let mut proportional_derivative = g.kp * delta_error;
        let integral = g.ki * periods * error;
        if g.kd != 0.0 {
            let derivative = g.d_filter_alpha * self.derivative
                + (1.0 - g.d_filter_alpha) * g.kd * delta_error / periods;
            proportional_derivative += derivative - self.derivative;
            self.derivative = derivative;
        }
        let held = self.feedback + proportional_derivative;
        let wanted = held + integral + feed_forward;
        let output = bounds.clamp(wanted);
        self.clamped = output != wanted;
        // Anti-windup by conditional integration: an integral increment that pushes the
        // output further into the bound it is held at is dropped.
        self.feedback = if self.clamped && integral * (wanted - output) > 0.0 {
            held
        } else {
            held + integral
        };
        self.feed_forward = feed_forward;
        self.error_1 = error;
        output
    }

    /// True when the last output was held at one of its bounds (the loop asked for more
    /// than it may have: a saturated actuator).
    pub const fn clamped(&self) -> bool {
        self.clamped
    }

    /// Tells the PID that `output` was applied instead of what [`IncrementalPid::step`]
    /// returned (a limit downstream changed it): the next increment continues from it.
    pub fn apply_output(&mut self, output: f32) {
        if output.is_finite() {
            self.feedback = output - self.feed_forward;
        }
    }

    /// The last output split into P, I, D and FF.
    pub fn parts(&self) -> PidParts {
        let p = self.gains.kp * self.error_1;
        PidParts {
            p,
            i: self.feedback - p - self.derivative,
            d: self.derivative,
            ff: self.feed_forward,
        }
    }

    /// Restarts so that the feedback part of the output is `feedback` (0 for a standstill):
    /// the next output continues from there without a jump, and the error history is
    /// cleared so Δe does not kick.
    pub fn reset(&mut self, feedback: f32) {
        self.feedback = if feedback.is_finite() { feedback } else { 0.0 };
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

    /// Primes the error history with `error` (set-point − measurement) so that a fresh
    /// loop starts without a proportional kick.
    pub fn prime(&mut self, error: f32) {
        if error.is_finite() {
            self.error_1 = error;
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
        }
    }

    fn wide() -> Bounds {
        Bounds::symmetric(1e6)
    }

    #[test]
    fn coefficients_are_the_corrected_eq_38() {
        let g = gains(2.0, 0.5, 0.25);
        assert_eq!(g.coefficients(), [2.75, -2.5, 0.25]);
    }

    #[test]
    fn from_continuous_hand_values() {
        // K_p = 0.1, T_i = 0.05 s, T_d = 0.002 s, T = 1 ms: K_i = 0.002, K_d = 0.2.
        let g = PidGains::from_continuous(0.1, 0.05, 0.002, 0.0, 0.001);
        assert!((g.ki - 0.002).abs() < 1e-9);
        assert!((g.kd - 0.2).abs() < 1e-7);
        assert_eq!(g.d_filter_alpha, 0.0);
        assert_eq!(PidGains::from_continuous(0.1, 0.0, 0.0, 0.0, 0.001).ki, 0.0);
        assert_eq!(
            PidGains::from_continuous(0.1, f32::INFINITY, 0.0, 0.0, 0.001).ki,
            0.0
        );
        let f = PidGains::from_continuous(0.1, 0.0, 0.0, 0.01, 0.001);
        assert!((f.d_filter_alpha - (-0.1f32).exp()).abs() < 1e-3);
    }

    #[test]
    fn validity_needs_finite_gains_and_a_stable_filter_pole() {
        assert!(gains(1.0, 0.1, 0.0).is_valid());
        assert!(!gains(f32::NAN, 0.1, 0.0).is_valid());
        assert!(!gains(1.0, f32::INFINITY, 0.0).is_valid());
        assert!(!gains(1.0, 0.1, f32::NEG_INFINITY).is_valid());
        let pole = |a| PidGains {
            d_filter_alpha: a,
            ..gains(1.0, 0.0, 0.0)
        };
        assert!(pole(0.0).is_valid() && pole(0.99).is_valid());
        assert!(!pole(1.0).is_valid() && !pole(-0.1).is_valid());
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
    fn unbounded_incremental_equals_positional_and_eq_38() {
        let g = gains(0.8, 0.05, 0.3);
        let errors: Vec<f32> = (0..200).map(|k| (k as f32 * 0.37).sin() * 0.4).collect();
        let mut pid = IncrementalPid::new(g);
        let [v0, v1, v2] = g.coefficients();
        let (mut e1, mut e2, mut m38) = (0.0, 0.0, 0.0);
        for (k, (&e, expected)) in errors.iter().zip(positional(g, &errors)).enumerate() {
            let m = pid.step(e, 0.0, wide(), 1.0);
            assert!((m - expected).abs() < 1e-4, "k = {k}: {m} vs {expected}");
            // The same sequence through the three-coefficient form (38).
            m38 += v0 * e + v1 * e1 + v2 * e2;
            (e2, e1) = (e1, e);
            assert!((m - m38).abs() < 1e-4, "k = {k}: {m} vs (38) {m38}");
            // The parts add up to the output.
            let parts = pid.parts();
            assert!((parts.p + parts.i + parts.d + parts.ff - m).abs() < 1e-4);
        }
    }

    #[test]
    fn recovers_from_saturation_without_windup() {
        // Pure I controller against a large error saturates at 1 for 1000 steps. When the
        // error changes sign the output must leave the limit at once: a wound-up integrator
        // would stay at 1 for hundreds of steps.
        let mut pid = IncrementalPid::new(gains(0.0, 0.01, 0.0));
        let one = Bounds::symmetric(1.0);
        let saturated: Vec<f32> = (0..1000).map(|_| pid.step(10.0, 0.0, one, 1.0)).collect();
        assert!(saturated[10..].iter().all(|&m| m == 1.0));
        let after = pid.step(-10.0, 0.0, one, 1.0);
        assert!(after < 1.0 && after > 0.85, "{after}");
        let mut steps = 1;
        while pid.step(-10.0, 0.0, one, 1.0) > 0.0 {
            steps += 1;
        }
        assert!(steps <= 11, "left saturation in {steps} steps");
    }

    #[test]
    fn no_windup_against_a_bound_that_excludes_zero() {
        // The drive's current limit is a window around the back-EMF, so a bound need not
        // contain 0: here [0.5, 2]. Held at its lower bound by a negative error for
        // 1000 steps, the integral must not wind down, so the output leaves the bound as
        // soon as the error turns positive.
        let mut pid = IncrementalPid::new(gains(0.0, 0.01, 0.0));
        let b = Bounds { min: 0.5, max: 2.0 };
        for _ in 0..1000 {
            assert_eq!(pid.step(-1.0, 0.0, b, 1.0), 0.5);
        }
        let mut steps = 1;
        while pid.step(1.0, 0.0, b, 1.0) <= 0.5 {
            steps += 1;
            assert!(steps < 100, "still held after {steps} steps: wound up");
        }
        assert!(steps <= 51, "left the bound after {steps} steps");
    }

    #[test]
    fn bounds_may_be_asymmetric_and_apply_to_the_sum_with_feed_forward() {
        let mut pid = IncrementalPid::new(gains(0.0, 0.0, 0.0));
        let b = Bounds { min: 0.5, max: 2.0 };
        assert_eq!(pid.step(0.0, 1.2, b, 1.0), 1.2);
        assert!(!pid.clamped());
        assert_eq!(pid.step(0.0, 3.0, b, 1.0), 2.0);
        assert!(pid.clamped());
        assert_eq!(pid.step(0.0, -3.0, b, 1.0), 0.5);
        assert!(pid.clamped());
        // The feed-forward is reported as such, and the parts add up to what was asked.
        let parts = pid.parts();
        assert_eq!(parts.ff, -3.0);
        assert!((parts.p + parts.i + parts.d + parts.ff + 3.0).abs() < 1e-6);
    }

    #[test]
    fn a_saturating_step_keeps_its_proportional_action_and_freezes_the_integral() {
        // A step of 10 asks K_p·e = 5 of a PI bounded at 2: held at 2. As the error then
        // falls, the output stays at the bound while K_p·e still exceeds it, and leaves it
        // at the positional value K_p·e + I, with I frozen at 0 while held.
        let mut pid = IncrementalPid::new(gains(0.5, 0.05, 0.0));
        let b = Bounds::symmetric(2.0);
        assert_eq!(pid.step(10.0, 0.0, b, 1.0), 2.0);
        assert_eq!(pid.step(8.0, 0.0, b, 1.0), 2.0);
        assert_eq!(pid.parts().i, 0.0);
        // e = 2: K_p·e = 1, plus this step's integral 0.1 (no longer held).
        let out = pid.step(2.0, 0.0, b, 1.0);
        assert!((out - 1.1).abs() < 1e-6, "{out}");
        // Storing the bounded output instead would have given 2 − 0.5·8 + 0.1 = −1.9.
        // An integral that pulls back out of the bound is kept while held (here the
        // feed-forward alone is beyond the bound).
        let mut pid = IncrementalPid::new(gains(0.0, 0.05, 0.0));
        assert_eq!(pid.step(-0.1, 5.0, b, 1.0), 2.0);
        assert!(pid.clamped());
        assert!((pid.parts().i + 0.005).abs() < 1e-7, "{:?}", pid.parts());
        // And one that pushes into it is dropped.
        assert_eq!(pid.step(0.1, 5.0, b, 1.0), 2.0);
        assert!((pid.parts().i + 0.005).abs() < 1e-7, "{:?}", pid.parts());
    }

    #[test]
    fn new_gains_rescale_the_derivative_without_a_bump() {
        // A PD with a filtered derivative (α = 0.5) holding a decaying D term: doubling
        // K_d doubles the stored term, so the next increment does not jump.
        let mut pid = IncrementalPid::new(PidGains {
            d_filter_alpha: 0.5,
            ..gains(0.1, 0.0, 0.2)
        });
        pid.step(0.0, 0.0, wide(), 1.0);
        pid.step(1.0, 0.0, wide(), 1.0);
        let before = pid.parts().d;
        assert!(before > 0.0);
        pid.set_gains(PidGains {
            d_filter_alpha: 0.5,
            ..gains(0.1, 0.0, 0.4)
        });
        assert!(
            (pid.parts().d - 2.0 * before).abs() < 1e-6,
            "{before} → {}",
            pid.parts().d
        );
    }

    #[test]
    fn a_downstream_limit_is_fed_back() {
        // The PID asks for 0.6, a slew limit downstream applies 0.2: the next step must
        // continue from 0.2 (plus its increment), not from 0.6.
        let mut pid = IncrementalPid::new(gains(0.0, 0.1, 0.0));
        for _ in 0..6 {
            pid.step(1.0, 0.0, wide(), 1.0);
        }
        pid.apply_output(0.2);
        assert!((pid.step(1.0, 0.0, wide(), 1.0) - 0.3).abs() < 1e-6);
        pid.apply_output(f32::NAN);
        assert!((pid.step(1.0, 0.0, wide(), 1.0) - 0.4).abs() < 1e-6);
        // With a feed-forward the applied output includes it: 0.9 applied with 0.5 of
        // feed-forward leaves 0.4 of feedback, and the next step adds its 0.1.
        pid.step(1.0, 0.5, wide(), 1.0);
        pid.apply_output(0.9);
        assert!((pid.step(1.0, 0.5, wide(), 1.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_late_sample_integrates_the_time_it_covered() {
        let mut on_time = IncrementalPid::new(gains(0.0, 0.1, 0.0));
        let mut late = IncrementalPid::new(gains(0.0, 0.1, 0.0));
        on_time.step(1.0, 0.0, wide(), 1.0);
        let a = on_time.step(1.0, 0.0, wide(), 1.0);
        let b = late.step(1.0, 0.0, wide(), 2.0);
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        // The derivative of a ramp is the same whether it is sampled every period or every
        // other one.
        let d = |periods: f32| {
            let mut pid = IncrementalPid::new(gains(0.0, 0.0, 1.0));
            pid.step(0.0, 0.0, wide(), 1.0);
            pid.step(periods, 0.0, wide(), periods)
        };
        assert!((d(1.0) - d(2.0)).abs() < 1e-6);
    }

    #[test]
    fn d_filter_smooths_a_step() {
        let raw = gains(0.0, 0.0, 1.0);
        let filtered = PidGains {
            d_filter_alpha: 0.5,
            ..raw
        };
        let mut a = IncrementalPid::new(raw);
        let mut b = IncrementalPid::new(filtered);
        let ten = Bounds::symmetric(10.0);
        assert_eq!(a.step(1.0, 0.0, ten, 1.0), 1.0);
        assert_eq!(b.step(1.0, 0.0, ten, 1.0), 0.5);
        assert_eq!(a.step(1.0, 0.0, ten, 1.0), 0.0);
        assert_eq!(b.step(1.0, 0.0, ten, 1.0), 0.25);
    }

    #[test]
    fn retune_is_bumpless() {
        let one = Bounds::symmetric(1.0);
        let mut pid = IncrementalPid::new(gains(0.5, 0.02, 0.0));
        for _ in 0..50 {
            pid.step(0.5, 0.0, one, 1.0);
        }
        let before = pid.step(0.5, 0.0, one, 1.0);
        pid.set_gains(gains(0.9, 0.02, 0.0));
        assert_eq!(pid.gains().kp, 0.9);
        let after = pid.step(0.5, 0.0, one, 1.0);
        // Same error: only the integral increment K_i·e is added, no jump from the new K_p.
        assert!((after - before - 0.01).abs() < 1e-6);
    }

    #[test]
    fn retune_rescales_the_stored_derivative() {
        // A constant-slope error keeps d(k) = K_d·Δe constant; after doubling K_d the
        // increment must not contain the jump (2K_d − K_d)·Δe.
        let mut pid = IncrementalPid::new(gains(0.0, 0.0, 1.0));
        let mut e = 0.0;
        for _ in 0..5 {
            e += 0.1;
            pid.step(e, 0.0, wide(), 1.0);
        }
        let before = pid.parts().d;
        pid.set_gains(gains(0.0, 0.0, 2.0));
        assert!((pid.parts().d - 2.0 * before).abs() < 1e-6);
        let out_before = pid.parts().p + pid.parts().i + pid.parts().d;
        e += 0.1;
        let out_after = pid.step(e, 0.0, wide(), 1.0);
        assert!(
            (out_after - out_before).abs() < 1e-5,
            "{out_before} → {out_after}"
        );
    }

    #[test]
    fn reset_and_prime_start_without_a_kick() {
        let mut pid = IncrementalPid::new(gains(0.5, 0.0, 0.0));
        pid.step(3.0, 0.0, wide(), 1.0);
        pid.reset(0.3);
        pid.prime(1.0);
        // Same error as primed: no proportional kick, the output continues from 0.3.
        assert!((pid.step(1.0, 0.0, wide(), 1.0) - 0.3).abs() < 1e-7);
        // Without priming the same error would kick by K_p·e = 0.5.
        pid.reset(0.3);
        assert!((pid.step(1.0, 0.0, wide(), 1.0) - 0.8).abs() < 1e-7);
        pid.reset(f32::NAN);
        pid.prime(f32::NAN);
        assert!(pid.step(0.0, 0.0, wide(), 1.0).is_finite());
    }

    #[test]
    fn non_finite_input_gives_zero_within_bounds() {
        let mut pid = IncrementalPid::new(gains(1.0, 0.1, 0.1));
        assert_eq!(pid.step(f32::NAN, 0.0, Bounds::symmetric(1.0), 1.0), 0.0);
        assert_eq!(
            pid.step(0.0, f32::INFINITY, Bounds::symmetric(1.0), 1.0),
            0.0
        );
        assert_eq!(
            pid.step(f32::NAN, 0.0, Bounds { min: 0.5, max: 1.0 }, 1.0),
            0.5
        );
        assert!(pid.step(0.1, 0.0, Bounds::symmetric(1.0), 1.0).is_finite());
    }
}
