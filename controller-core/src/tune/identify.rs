//! The fits behind the tune: a straight line through a voltage ramp, a first-order plus
//! dead-time model from a voltage step, and the SIMC rule. Running sums only, no sample
//! is stored; everything is `f32` through [`crate::math`].
//!
//! ## The step: FOPDT from its Laplace transform
//!
//! A voltage step Δu at t = 0 on a wheel turning steadily at ω₁ gives, for the model
//! K e^(−θs)/(τs + 1), the speed ω₁ + Δω (1 − e^(−(t−θ)/τ)) after θ, Δω = K Δu. The
//! controller sees it through its speed estimate, a moving average over the last W
//! periods: a known filter, MA(s) = (1 − e^(−sWT))/(sWT). With y(t) = ω̂(t) − ω₁ and its
//! Laplace transform Y(s), the FOPDT gives
//!
//! ```text
//! Q(s) = s Y(s) / (Δω MA(s)) = e^(−θs) / (1 + τs),   g(s) = −ln Q(s) = θ s + ln(1 + τ s).
//! ```
//!
//! Y(s) is a weighted sum of the samples, Σ y_j e^(−s jT) T (trapezoidal from y = 0 at
//! the step, with the tail after the last sample taken as settled), accumulated for a
//! bank of s = 0.5, 1, 2, … 1024
//! s⁻¹ (brackets for τ from about 2 ms to 1 s). The weight e^(−st) makes the late, noisy samples count little, which is what makes
//! this better than the method of moments, whose t-weighted integrals amplify the encoder's
//! quantisation in the tail. Two bank values bracketing the response (Q ≈ 0.6 and
//! Q ≈ 0.35) give two equations; θ cancels from g(s)/s = θ + ln(1 + τs)/s, τ follows by
//! bisection (the difference is monotonic in τ), then θ. K = Δω/Δu from the steady states.
//!
//! ## The ramp: feed-forward k_S and k_V
//!
//! On a slow voltage ramp u(t) at rate ṙ, after its transient, the wheel lags the static
//! curve u = k_S + k_V ω by a constant: the plant's lag τ + θ, the estimate's window
//! W T / 2 and the zero-order hold's T / 2, so with the samples (u[k], ω̂[k])
//!
//! ```text
//! u[k] = k_S + k_V ω̂[k] + ṙ (τ + θ + (W + 1) T / 2).
//! ```
//!
//! A straight-line fit gives k_V (the slope) and an intercept from which, with τ and θ
//! from the step, k_S follows. The fit is Welford's running mean and co-moments, stable
//! in `f32` over thousands of samples.
//!
//! ## SIMC (Skogestad 2003)
//!
//! For K e^(−θs)/(τs + 1) under a PI, K_c = τ / (K (τ_c + θ_e)), and here T_i = max(τ, 4
//! (τ_c + θ_e)): Skogestad's T_i = min(τ, 4 (τ_c + θ_e)) cancels the plant's pole, which
//! on a wheel faster than its loop's delay (τ of 18 ms against θ_e of 11.5 ms) leaves an
//! integral that, behind the feed-forward, overshoots a large step by over 20 %; the
//! integral is never faster than 4 (τ_c + θ_e), the lag-dominant form. The loop's effective dead time θ_e is the plant's θ plus what the controller
//! adds: the speed estimate's window (W T / 2) and sampling (T / 2, Skogestad's rule for
//! digital control). τ_c is the closed-loop time constant asked for, a multiple of θ_e
//! ([`super::TuneConfig::tau_c_per_dead_time`]).

use crate::math;

/// Number of Laplace variables in the bank: s = 0.5, 1, 2, … 2^(BANK − 2) s⁻¹.
pub(crate) const BANK: usize = 12;

/// The bank's s values, s⁻¹.
pub(crate) fn bank_s(k: usize) -> f32 {
    0.5 * (1u32 << k.min(30)) as f32
}

/// Running straight-line fit y = c + slope·x (Welford).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LineFit {
    n: u32,
    mean_x: f32,
    mean_y: f32,
    /// Σ (x − x̄)², Σ (x − x̄)(y − ȳ).
    cxx: f32,
    cxy: f32,
}

impl LineFit {
    /// Adds the point (`x`, `y`).
    pub(crate) fn push(&mut self, x: f32, y: f32) {
        self.n = self.n.saturating_add(1);
        let n = self.n as f32;
        let dx = x - self.mean_x;
        self.mean_x += dx / n;
        self.mean_y += (y - self.mean_y) / n;
        // With the updated x̄ and the old ȳ's residual: Welford's co-moment update.
        let dy_new = y - self.mean_y;
        self.cxx += dx * (x - self.mean_x);
        self.cxy += dx * dy_new;
    }

    /// (intercept, slope), or `None` with fewer than 3 points or no spread in x.
    pub(crate) fn line(&self) -> Option<(f32, f32)> {
        if self.n < 3 || self.cxx <= 0.0 {
            return None;
        }
        let slope = self.cxy / self.cxx;
        let intercept = self.mean_y - slope * self.mean_x;
        (slope.is_finite() && intercept.is_finite()).then_some((intercept, slope))
    }
}

/// A first-order plus dead-time model, K e^(−θs)/(τs + 1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Fopdt {
    /// K, rad/s per V.
    pub(crate) gain: f32,
    /// τ, s.
    pub(crate) tau: f32,
    /// θ, s (may come out slightly negative from noise when the plant has none).
    pub(crate) theta: f32,
}

/// The bank's per-step decay factors e^(−s_k T), shared by both wheels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Bank {
    /// e^(−s_k T).
    decay: [f32; BANK],
    /// e^(−s_k j T) at the present sample j.
    weight: [f32; BANK],
}

impl Bank {
    /// The bank for control period `period_s` (s).
    pub(crate) fn new(period_s: f32) -> Self {
        let mut decay = [0.0; BANK];
        for (k, d) in decay.iter_mut().enumerate() {
            *d = math::exp(-bank_s(k) * period_s);
        }
        Self {
            decay,
            weight: [1.0; BANK],
        }
    }

    /// Back to j = 0.
    pub(crate) fn restart(&mut self) {
        self.weight = [1.0; BANK];
    }

    /// The same bank back at j = 0.
    pub(crate) fn restarted(mut self) -> Self {
        self.restart();
        self
    }

    /// The weights of the present sample.
    pub(crate) const fn weights(&self) -> &[f32; BANK] {
        &self.weight
    }

    /// On to the next sample.
    pub(crate) fn advance(&mut self) {
        for (w, d) in self.weight.iter_mut().zip(self.decay) {
            *w *= d;
        }
    }
}

/// One wheel's step response, accumulated sample by sample (module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct StepSums {
    /// Σ y_j e^(−s_k jT) per bank value.
    weighted: [f32; BANK],
    /// The latest y.
    last: f32,
    samples: u32,
    /// The settled tail: Σ y and count over the final part of the hold.
    tail_sum: f32,
    tail_n: u32,
}

impl StepSums {
    /// Adds sample `y` (rad/s above the pre-step speed) with the bank's present weights;
    /// `in_tail` marks samples of the settled end, whose mean is Δω.
    pub(crate) fn push(&mut self, y: f32, weights: &[f32; BANK], in_tail: bool) {
        self.samples = self.samples.saturating_add(1);
        self.last = y;
        for (sum, w) in self.weighted.iter_mut().zip(weights) {
            *sum += y * w;
        }
        if in_tail {
            self.tail_sum += y;
            self.tail_n = self.tail_n.saturating_add(1);
        }
    }

    /// Forgets the tail (a new, later tail follows); the response sums are kept.
    pub(crate) fn restart_tail(&mut self) {
        self.tail_sum = 0.0;
        self.tail_n = 0;
    }

    /// The settled speed change Δω, rad/s (0 before any tail sample).
    pub(crate) fn delta(&self) -> f32 {
        if self.tail_n == 0 {
            0.0
        } else {
            self.tail_sum / self.tail_n as f32
        }
    }

    /// The FOPDT of a step of `delta_u` (V) sampled every `period_s` (s) through a
    /// moving average of `window_steps` periods, with the bank's final `weights` (those
    /// of the last sample). `None` when the response does not fit (no change, a bracket
    /// missing from the bank, a non-finite result).
    pub(crate) fn fit(
        &self,
        delta_u: f32,
        period_s: f32,
        window_steps: u32,
        weights: &[f32; BANK],
    ) -> Option<Fopdt> {
        let delta = self.delta();
        if self.samples < 2 || delta <= 0.0 || delta_u <= 0.0 {
            return None;
        }
        let window_s = window_steps as f32 * period_s;
        // Q_k for each bank value.
        let mut q = [0.0f32; BANK];
        for (k, ((qk, sum), w_last)) in q.iter_mut().zip(&self.weighted).zip(weights).enumerate() {
            let s = bank_s(k);
            // Trapezoid from y = 0 at the step (t = 0) over the samples, plus the settled
            // tail after the last one.
            let integral = period_s * (sum - 0.5 * self.last * w_last) + delta * w_last / s;
            let moving_average = (1.0 - math::exp(-s * window_s)) / (s * window_s);
            *qk = s * integral / (delta * moving_average);
        }
        let (a, b) = bracket(&q)?;
        let (qa, qb) = (*q.get(a)?, *q.get(b)?);
        let (sa, sb) = (bank_s(a), bank_s(b));
        // ln(q_a) once, and `solve_tau` out of line: at opt-level "z" LLVM's ARM back end
        // makes three or more calls to one function in a basic block through a register
        // (a shorter encoding), and the firmware's panic check cannot follow those.
        let ln_qa = math::ln(qa);
        let target = -math::ln(qb) / sb + ln_qa / sa;
        let tau = solve_tau(sa, sb, target)?;
        let theta = -ln_qa / sa - math::ln(1.0 + tau * sa) / sa;
        let gain = delta / delta_u;
        (tau.is_finite() && theta.is_finite() && gain.is_finite()).then_some(Fopdt {
            gain,
            tau,
            theta,
        })
    }
}

/// The bank values that bracket the response: the last with Q ≥ 0.6 and the first after
/// it with Q ≤ 0.35 (their indices).
fn bracket(q: &[f32; BANK]) -> Option<(usize, usize)> {
    let a = q.iter().rposition(|&x| x >= 0.6)?;
    let b = a + 1 + q.get(a + 1..)?.iter().position(|&x| x <= 0.35)?;
    Some((a, b))
}

/// τ ≥ 0 with ln(1 + τ s_b)/s_b − ln(1 + τ s_a)/s_a = `target` (s_b > s_a; the left side
/// falls from 0 as τ grows), by bisection; `None` if out of [0, 100 s]. Out of line (see
/// the caller).
#[inline(never)]
fn solve_tau(sa: f32, sb: f32, target: f32) -> Option<f32> {
    let f = |tau: f32| math::ln(1.0 + tau * sb) / sb - math::ln(1.0 + tau * sa) / sa - target;
    let (mut lo, mut hi) = (0.0f32, 100.0f32);
    if !(f(lo) >= 0.0 && f(hi) <= 0.0) {
        return None;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The SIMC PI for `model` with effective dead time `dead_time_s` (s, the loop's: plant
/// plus what the controller adds) and closed-loop time constant `tau_c_s` (s): (K_c in V
/// per rad/s, T_i in s).
pub(crate) fn simc(model: &Fopdt, dead_time_s: f32, tau_c_s: f32) -> (f32, f32) {
    let horizon = tau_c_s + dead_time_s;
    let kc = model.tau / (model.gain * horizon);
    let ti = if model.tau > 4.0 * horizon {
        model.tau
    } else {
        4.0 * horizon
    };
    (kc, ti)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_a_line_through_noise() {
        let mut fit = LineFit::default();
        assert_eq!(fit.line(), None);
        // u = 0.4 + 0.15 ω, ω from 4 to 14, with a ±0.02 V sawtooth.
        for k in 0..2000 {
            let w = 4.0 + 10.0 * k as f32 / 2000.0;
            let noise = 0.02 * ((k % 7) as f32 / 3.0 - 1.0);
            fit.push(w, 0.4 + 0.15 * w + noise);
        }
        let (c, slope) = fit.line().unwrap();
        assert!((slope - 0.15).abs() < 1e-4, "{slope}");
        assert!((c - 0.4).abs() < 2e-3, "{c}");
        // No spread in x: no line.
        let mut flat = LineFit::default();
        for _ in 0..10 {
            flat.push(3.0, 1.0);
        }
        assert_eq!(flat.line(), None);
    }

    #[test]
    fn a_line_needs_three_points_and_a_finite_answer() {
        // Two points define a line but leave no check on it: refused; three are enough.
        let mut fit = LineFit::default();
        fit.push(1.0, 3.0);
        fit.push(2.0, 5.0);
        assert_eq!(fit.line(), None);
        fit.push(3.0, 7.0);
        let (c, slope) = fit.line().unwrap();
        assert!(
            (c - 1.0).abs() < 1e-5 && (slope - 2.0).abs() < 1e-5,
            "{c} {slope}"
        );
        // A slope of 10¹⁰ through points near x = 10³⁰: the intercept overflows f32.
        let steep = LineFit {
            n: 3,
            mean_x: 1e30,
            mean_y: 0.0,
            cxx: 1.0,
            cxy: 1e10,
        };
        assert_eq!(steep.line(), None);
        // A spread in x too small for the slope to be an f32: refused too.
        let vertical = LineFit {
            n: 3,
            mean_x: 0.0,
            mean_y: 0.0,
            cxx: 1e-30,
            cxy: 1e10,
        };
        assert_eq!(vertical.line(), None);
    }

    /// The samples a moving average of `w` periods makes of an FOPDT step response
    /// (exact: the average of the continuous response over the window).
    fn filtered_step(k: f32, tau: f32, theta: f32, du: f32, t: f32, w: u32, n: usize) -> Vec<f32> {
        // ∫ of Δω(1 − e^(−(t−θ)/τ)) from θ: Δω (t − θ − τ (1 − e^(−(t−θ)/τ))).
        let area = |t: f32| {
            let x = t - theta;
            if x <= 0.0 {
                0.0
            } else {
                k * du * (x - tau * (1.0 - math::exp(-x / tau)))
            }
        };
        let window = w as f32 * t;
        (0..n)
            .map(|j| {
                let now = j as f32 * t;
                (area(now) - area(now - window)) / window
            })
            .collect()
    }

    fn fit(samples: &[f32], du: f32, t: f32, w: u32) -> Option<Fopdt> {
        let mut bank = Bank::new(t);
        let mut sums = StepSums::default();
        let tail_from = samples.len() * 4 / 5;
        for (j, y) in samples.iter().enumerate() {
            if j > 0 {
                bank.advance();
            }
            sums.push(*y, bank.weights(), j >= tail_from);
        }
        sums.fit(du, t, w, bank.weights())
    }

    #[test]
    fn a_filtered_fopdt_step_is_recovered() {
        // The reference wheel on the ground, lifted, and a slow one with a dead time.
        for (k, tau, theta) in [(6.35, 0.089, 0.0), (6.35, 0.026, 0.0), (4.0, 0.2, 0.015)] {
            let samples = filtered_step(k, tau, theta, 1.4, 0.001, 20, 1500);
            let m = fit(&samples, 1.4, 0.001, 20).unwrap();
            assert!((m.gain - k).abs() < 0.01 * k, "{m:?}");
            assert!((m.tau - tau).abs() < 0.02 * tau, "{m:?} vs τ {tau}");
            assert!((m.theta - theta).abs() < 2e-3, "{m:?} vs θ {theta}");
        }
    }

    #[test]
    fn the_bracket_is_the_last_q_over_0_6_and_the_first_under_0_35_after_it() {
        let q = [
            1.0, 0.9, 0.61, 0.7, 0.6, 0.5, 0.4, 0.35, 0.3, 0.1, 0.05, 0.02,
        ];
        assert_eq!(bracket(&q), Some((4, 7)));
        // Nothing under 0.35 after the last Q ≥ 0.6, or nothing ≥ 0.6: no bracket.
        let q = [
            1.0, 0.9, 0.3, 0.7, 0.6, 0.5, 0.4, 0.36, 0.36, 0.36, 0.36, 0.36,
        ];
        assert_eq!(bracket(&q), None);
        assert_eq!(bracket(&[0.5; BANK]), None);
    }

    #[test]
    fn tau_is_solved_within_its_range_only() {
        // s_a = 1/s, s_b = 2/s: ln(1 + 2τ)/2 − ln(1 + τ) is −0.1438 s at τ = 1 s and
        // −3.107 s at τ = 1 000 s, beyond the 100 s searched; a positive target has no
        // τ ≥ 0 at all.
        let at = |tau: f32| math::ln(1.0 + 2.0 * tau) / 2.0 - math::ln(1.0 + tau);
        let tau = solve_tau(1.0, 2.0, at(1.0)).unwrap();
        assert!((tau - 1.0).abs() < 1e-4, "{tau}");
        assert_eq!(solve_tau(1.0, 2.0, at(1_000.0)), None);
        assert_eq!(solve_tau(1.0, 2.0, 0.1), None);
    }

    #[test]
    fn exact_samples_fit_to_within_rounding() {
        // The method is exact for the continuous response; on exact samples of a settled
        // one (1.5 s, 17 τ) what is left is the trapezoid's error and f32 rounding: τ to
        // about 10⁻⁵ and θ to a fraction of a microsecond (measured 7·10⁻⁶ and 0.2 µs).
        let samples = filtered_step(6.35, 0.089, 0.0, 1.4, 0.001, 20, 1500);
        let m = fit(&samples, 1.4, 0.001, 20).unwrap();
        assert!((m.tau - 0.089).abs() < 1.2e-5 * 0.089, "{m:?}");
        assert!(m.theta.abs() < 5e-7, "{m:?}");
        assert!((m.gain - 6.35).abs() < 1e-4 * 6.35, "{m:?}");
    }

    #[test]
    fn quantised_samples_still_fit_within_a_few_percent() {
        // The speed estimate moves in steps of 0.218 rad/s (one tick per 20 ms window).
        let q = 0.218;
        let samples: Vec<f32> = filtered_step(6.35, 0.089, 0.0, 1.4, 0.001, 20, 700)
            .iter()
            .map(|y| math::round_to_i32(y / q) as f32 * q)
            .collect();
        let m = fit(&samples, 1.4, 0.001, 20).unwrap();
        assert!((m.tau - 0.089).abs() < 0.05 * 0.089, "{m:?}");
        assert!((m.gain - 6.35).abs() < 0.03 * 6.35, "{m:?}");
    }

    #[test]
    fn no_response_or_a_step_down_does_not_fit() {
        assert_eq!(fit(&[0.0; 500], 1.0, 0.001, 20), None);
        let down: Vec<f32> = filtered_step(6.0, 0.05, 0.0, 1.0, 0.001, 20, 500)
            .iter()
            .map(|y| -y)
            .collect();
        assert_eq!(fit(&down, 1.0, 0.001, 20), None);
        // A response to a step of 10⁻⁴⁰ V: a gain beyond f32, refused.
        let up = filtered_step(6.0, 0.05, 0.0, 1.0, 0.001, 20, 500);
        assert!(fit(&up, 1.0, 0.001, 20).is_some());
        assert_eq!(fit(&up, 1e-40, 0.001, 20), None);
    }

    #[test]
    fn simc_by_the_book() {
        let m = Fopdt {
            gain: 6.0,
            tau: 0.09,
            theta: 0.0,
        };
        // τ_c = θ_e = 10 ms: K_c = 0.09/(6 · 0.02) = 0.75, T_i = max(0.09, 0.08) = τ.
        let (kc, ti) = simc(&m, 0.01, 0.01);
        assert!((kc - 0.75).abs() < 1e-6 && ti == 0.09, "{kc} {ti}");
        // A looser loop: T_i = 4 (τ_c + θ_e) = 0.12 s, never below it.
        let (_, ti) = simc(&m, 0.01, 0.02);
        assert!((ti - 0.12).abs() < 1e-7, "{ti}");
    }
}
