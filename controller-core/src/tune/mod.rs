//! Self-tuning of the wheel loops: identify each wheel, then set its feed-forward and PI.
//!
//! The paper calls its PID "adaptive, self-tuning" and describes no method. This is one
//! that runs on the robot, in the supervisor's tune mode ([`crate::supervisor::RunMode::Tune`]),
//! one fixed step at a time, with the motors driven open loop in volts
//! ([`crate::controller::Mode::ApplyVolts`]). Both wheels run the same experiment at once,
//! so on the ground the robot drives straight and each wheel is identified with its half
//! of the chassis (the "driving straight" load of the margins). In each direction, forward
//! then backward:
//!
//! 1. **Breakaway**: the voltage rises slowly from 0 until both wheels turn; the larger
//!    breakaway voltage u_b sets the low level u_lo = u_b + 0.07 (u_max − u_b), u_max
//!    being [`TuneConfig::experiment_volts_v`], the largest voltage the tune applies.
//! 2. **Hold** u_lo until steady. The hold is itself a step, from the breakaway to u_lo:
//!    it is fitted (the `identify` submodule) at checkpoints, 0.1 s and then every 3/2
//!    of that, until its response lasted 5 of its own τ + θ (or reached
//!    [`TuneConfig::max_hold_s`]). Its τ + θ and gain are the first estimate, and its
//!    settled tail the pre-step speed ω₁. A change too small to fit (a fast motor's, a
//!    few quanta of the speed estimate) counts as settled once its tail moves by under
//!    2 % between checkpoints; it then bounds τ + θ by a fifth of the hold and gives K
//!    from its tails.
//! 3. **The plan**, from what the hold measured: the step lasts 7 of the hold's τ + θ
//!    (at most [`TuneConfig::max_hold_s`]), and its level u_hi is the highest (up to
//!    u_max) whose step, shortest ramp (5 τ) and brake keep this direction's travel
//!    within 90 % of [`TuneConfig::max_distance_m`] and its speed within half of
//!    [`TuneConfig::max_speed_rad_s`], with the hold's gain. The step is at least as
//!    large as the hold's own; when even that does not fit, the step is shortened to fit.
//! 4. **Step** to u_hi and hold: a first-order-plus-dead-time model (K, τ, θ) per wheel
//!    from the response's Laplace transform. θ counts from the step in which the tune
//!    asks for u_hi, one control period before the controller applies it; the wheel loop
//!    acts in its own step, so its PI is set for that period more dead time than it has.
//!    A step that lasted under 5 of its own τ + θ is reported
//!    ([`TuneWarnings::step_not_settled`]): its τ is likely low.
//! 5. **Ramp** down from u_hi to u_lo over 12 τ (at least 1 s: k_S is corrected by the
//!    ramp's rate × lag), or what the distance budget leaves (at least 5 τ): a straight
//!    line u = c + k_V ω̂ through the samples after its first third gives k_V, and with
//!    τ and θ from the step, k_S.
//! 6. **Brake** (0 V, a short brake) until both wheels are at rest.
//!
//! The voltage never leaves [0, u_max] in the direction of the experiment and only goes
//! to 0 to stop, so a wheel never crosses zero speed; the ramp down is slow enough to keep
//! the gearbox motoring as long as the motor's static friction is worth more than 1/5 of
//! u_hi − u_lo (the decelerating torque it asks for).
//!
//! The result, per wheel, averages the two directions ([`TuneResult`]); the PI comes from
//! the SIMC rule with τ_c = [`TuneConfig::tau_c_per_dead_time`] × the loop's effective
//! dead time θ_e (the plant's θ, the speed estimate's window W T/2 and the sampling T/2),
//! and T_i never below 4 (τ_c + θ_e) (the `identify` submodule). The default τ_c = 2 θ_e
//! with that T_i keeps a 0 → 15 rad/s step within 5 % overshoot over the fast motors of
//! the spread (R_a −40 %, inertia −40 %, K_t +40 %, τ down to 18 ms, under twice θ_e),
//! where Skogestad's "tight" τ_c = θ_e with T_i = τ overshoots by over 20 %: the
//! integral, behind the feed-forward, is what overshoots (`host-sim tune --sweep`).
//!
//! ## Lifted wheels
//!
//! On a stand each wheel turns only its own inertia J_w (with the rotor's, reflected
//! through the gearbox), and τ is that much shorter: gains identified there are about 3×
//! too low for driving. [`TuneLoad::Lifted`] corrects the identified τ for the chassis
//! the wheels will carry: driving straight each wheel sees J_w + m R²/2 (m the robot's
//! mass, R the wheel radius), so τ_ground = τ_lifted (1 + m R² / (2 J_w)) while K, k_S and
//! k_V do not change ([`TuneLoad::lifted`]).
//!
//! ## Safety
//!
//! The supervisor runs the tune like any armed mode: every fault check applies, the button
//! and the link stop it, and then [`Tuner::abort`] ends it with [`TuneAbort::Stopped`]. The
//! tune itself stops (and the supervisor disarms) when a wheel turns the wrong way (motor or
//! encoder inverted), stops turning, exceeds [`TuneConfig::max_speed_rad_s`], when the
//! robot's odometry leaves [`TuneConfig::max_distance_m`] of where it started (on the
//! ground), when a step comes late (the data would be skewed), or when a fit fails.

mod identify;
mod vocabulary;

pub use vocabulary::{
    Side, TuneAbort, TuneConfig, TuneConfigError, TuneLoad, TuneResult, TuneStep, TuneWarnings,
    WheelModel,
};

use crate::controller::Telemetry;
use crate::drive::WheelVolts;
use crate::kinematics::Pose;
use crate::math;
use crate::params::{Params, WheelLoopConfig};

use identify::{simc, Bank, Fopdt, LineFit, StepSums};

/// Wheel speed that counts as turning (breakaway), rad/s: about five quanta of the
/// reference robot's speed estimate.
pub const MOVING_RAD_S: f32 = 1.0;
/// Below this a wheel that should turn has stopped, rad/s.
pub const STALLED_RAD_S: f32 = 0.3;
/// The hold's level: u_lo lies this fraction of the way from the breakaway voltage to
/// the largest voltage allowed ([`TuneConfig::experiment_volts_v`]), a gentle speed.
const LOW_FRACTION: f32 = 0.07;
/// The larger breakaway voltage may be at most this fraction of the largest voltage.
const MAX_BREAKAWAY_FRACTION: f32 = 0.7;
/// The hold's and the step's tail, their last fifth, gives their settled speed.
const BASELINE_FRACTION: u32 = 5;
/// A hold's response that does not fit is steady when its tail moved by less than this
/// fraction, or this speed (rad/s, about half a quantum of the reference robot's
/// estimate), between checkpoints.
const STEADY_FRACTION: f32 = 0.02;
const STEADY_RAD_S: f32 = 0.1;
/// A response counts as settled when it lasted this many of its τ + θ.
const SETTLE_TAUS: f32 = 5.0;
/// The step is planned for this many of the hold's τ + θ (the hold's estimate is rough:
/// the margin keeps the step settled by [`SETTLE_TAUS`] of its own).
const STEP_TAUS: f32 = 7.0;
/// The hold is fitted first after this long, s, then at every 3/2 of its length until
/// its response has settled.
const HOLD_FIRST_S: f32 = 0.1;
/// The ramp lasts at most [`RAMP_TAUS`] and, when the distance budget is short, at least
/// [`RAMP_MIN_TAUS`] (identified) time constants; its first [`RAMP_SKIP_FRACTION`] is its
/// transient and not fitted.
const RAMP_TAUS: f32 = 12.0;
const RAMP_MIN_TAUS: f32 = 5.0;
const RAMP_SKIP_FRACTION: f32 = 1.0 / 3.0;
/// The ramp lasts at least this long, s, budget allowing: k_S is its intercept corrected
/// by rate × lag, and a fast motor's 12 τ would make the rate, and the correction's
/// error, several times larger.
const RAMP_LEAST_S: f32 = 1.0;
/// The plan keeps each direction's travel within this fraction of
/// [`TuneConfig::max_distance_m`].
const DISTANCE_BUDGET_FRACTION: f32 = 0.9;
/// The step's speed stays within this fraction of [`TuneConfig::max_speed_rad_s`].
const STEP_SPEED_FRACTION: f32 = 0.5;
/// Steps both wheels must read 0 rad/s before the next direction.
const REST_STEPS: u32 = 30;
/// Longest the brake may take to stop the wheels, s.
const BRAKE_TIMEOUT_S: f32 = 2.0;
/// Longest the breakaway may sit at the largest voltage with a wheel still not turning, s.
const BREAKAWAY_TIMEOUT_S: f32 = 0.5;
/// Largest relative difference between the two directions, and between the step's gain
/// and the ramp's 1/k_V, accepted as one motor.
const MAX_MISMATCH: f32 = 0.3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    Breakaway,
    Hold,
    Step,
    Ramp,
    Brake,
    Finished,
}

/// One direction's fit of one wheel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct DirectionFit {
    model: Fopdt,
    ks_v: f32,
    kv_v_per_rad_s: f32,
}

/// The tune's state machine (module doc). Call [`Tuner::start`], then [`Tuner::step`] once
/// per control step with the controller's telemetry of that step, and apply what it asks.
#[derive(Clone, Debug)]
pub struct Tuner {
    config: TuneConfig,
    period_s: f32,
    window_steps: u32,
    phase: Phase,
    /// 0 forward, 1 backward.
    direction: usize,
    /// Steps observed in the present phase before this one: 0 at the first step after
    /// the phase was entered.
    steps: u32,
    start: Pose,
    /// Where this direction began, and the latest pose (odometry, world frame).
    direction_start: Pose,
    pose: Pose,
    /// Mean of the two wheel radii, m: turns the plan's wheel angles into distance.
    wheel_radius_m: f32,
    /// The voltage magnitude asked for the next step.
    command: f32,
    breakaway: [Option<f32>; 2],
    low_v: f32,
    /// The step's level, V, and its length, steps: planned from the hold.
    high_v: f32,
    step_steps: u32,
    /// Hold: the speed and applied volts as its response began, per wheel; the step of
    /// the hold it began at; the present checkpoint (steps from there); per wheel the
    /// last checkpoint's Δω (NaN before the first) and, once settled, the steady speed;
    /// its tail's Σ volts and, once settled, their mean.
    entry_speed: [f32; 2],
    entry_volts: [f32; 2],
    hold_origin: u32,
    hold_end: u32,
    hold_speed: [f32; 2],
    hold_volts: [f32; 2],
    /// Samples in the present tail (hold, step), or steps at rest (brake).
    hold_n: u32,
    /// Hold and step: the response sums, Σ applied volts over the tail.
    bank: Bank,
    step_sums: [StepSums; 2],
    step_volts: [f32; 2],
    /// Ramp: rate (V/s), transient to skip (steps), the fits.
    ramp_rate: f32,
    ramp_skip: u32,
    ramp: [LineFit; 2],
    /// Per direction, per wheel.
    fits: [[DirectionFit; 2]; 2],
    warnings: TuneWarnings,
    outcome: Option<Result<TuneResult, TuneAbort>>,
}

impl Tuner {
    /// An idle tuner with `config` for a robot with `params` (control period and speed
    /// window).
    pub fn new(config: TuneConfig, params: &Params) -> Self {
        let period_s = params.period_s();
        let robot = params.config();
        Self::with_bank(
            config,
            period_s,
            robot.speed_window_steps,
            0.5 * (robot.wheel_radius_left_m + robot.wheel_radius_right_m),
            Bank::new(period_s),
        )
    }

    /// An idle tuner for control period `period_s` (s), a speed window of
    /// `window_steps` and wheels of radius `wheel_radius_m` (m), identifying with `bank`
    /// (built for `period_s`). Always inlined:
    /// `*self = Self::with_bank(…)` then builds the tuner in place instead of in a
    /// temporary (measured: 416 B less of the control interrupt's stack when it arms a
    /// tune).
    #[inline(always)]
    fn with_bank(
        config: TuneConfig,
        period_s: f32,
        window_steps: u32,
        wheel_radius_m: f32,
        bank: Bank,
    ) -> Self {
        Self {
            config,
            period_s,
            window_steps,
            phase: Phase::Idle,
            direction: 0,
            steps: 0,
            start: Pose::default(),
            direction_start: Pose::default(),
            pose: Pose::default(),
            wheel_radius_m,
            command: 0.0,
            breakaway: [None; 2],
            low_v: 0.0,
            high_v: 0.0,
            step_steps: 0,
            entry_speed: [0.0; 2],
            entry_volts: [0.0; 2],
            hold_origin: 0,
            hold_end: 0,
            hold_speed: [0.0; 2],
            hold_volts: [0.0; 2],
            hold_n: 0,
            bank,
            step_sums: [StepSums::default(); 2],
            step_volts: [0.0; 2],
            ramp_rate: 0.0,
            ramp_skip: 0,
            ramp: [LineFit::default(); 2],
            fits: [[DirectionFit::default(); 2]; 2],
            warnings: TuneWarnings::default(),
            outcome: None,
        }
    }

    /// The settings.
    pub const fn config(&self) -> &TuneConfig {
        &self.config
    }

    /// The result of the last tune, or why it ended (`None`: none finished yet).
    pub const fn outcome(&self) -> Option<Result<TuneResult, TuneAbort>> {
        self.outcome
    }

    /// True while a tune is running.
    pub fn running(&self) -> bool {
        !matches!(self.phase, Phase::Idle | Phase::Finished)
    }

    /// Starts a tune from `pose` (the odometry's, world frame), forgetting the last
    /// outcome. The first [`Tuner::step`] applies 0 V.
    pub fn start(&mut self, pose: Pose) {
        self.rebuild();
        self.start = pose;
        self.direction_start = pose;
        self.pose = pose;
        self.phase = Phase::Breakaway;
    }

    /// Replaces the settings (takes effect at the next [`Tuner::start`]) and the robot's
    /// timing from `params`; a running tune is stopped. Nothing else changes: the working
    /// values are only read while a tune runs, and [`Tuner::start`] rebuilds them all.
    pub fn set_config(&mut self, config: TuneConfig, params: &Params) {
        self.abort(TuneAbort::Stopped);
        let period_s = params.period_s();
        if period_s != self.period_s {
            self.bank = Bank::new(period_s);
            self.period_s = period_s;
        }
        self.config = config;
        let robot = params.config();
        self.window_steps = robot.speed_window_steps;
        self.wheel_radius_m = 0.5 * (robot.wheel_radius_left_m + robot.wheel_radius_right_m);
    }

    /// Rebuilds the tuner in place (no second tuner on the stack of the control interrupt
    /// that arms a tune) as an idle one for its settings and timing. The bank's decay
    /// factors, twelve exponentials, are the ones
    /// [`Tuner::set_config`] computed for the period, restarted.
    fn rebuild(&mut self) {
        let (config, period_s, window_steps, radius) = (
            self.config,
            self.period_s,
            self.window_steps,
            self.wheel_radius_m,
        );
        let bank = self.bank.restarted();
        *self = Self::with_bank(config, period_s, window_steps, radius, bank);
    }

    /// Ends a running tune with `reason` (the supervisor stopped it).
    pub fn abort(&mut self, reason: TuneAbort) {
        if self.running() {
            self.finish(Err(reason));
        }
    }

    /// One control step: `telemetry` is the controller's for this step (its speeds, the
    /// voltages it applied, its pose), covering `periods` control periods. Returns what to
    /// apply next. Out of line: the tune's working values (a few hundred bytes) belong in
    /// its own frame, not in that of every control step that inlines the supervisor.
    #[inline(never)]
    pub fn step(&mut self, telemetry: &Telemetry, periods: u32) -> TuneStep {
        if !self.running() {
            // Not `unwrap_or`: its default, built whether needed or not, was 100 bytes
            // of the control interrupt's stack.
            return match self.outcome {
                Some(outcome) => TuneStep::Finished(outcome),
                None => TuneStep::Finished(Err(TuneAbort::Stopped)),
            };
        }
        let (phase, direction) = (self.phase, self.direction);
        match self.observe(telemetry, periods) {
            Ok(()) => {
                // A phase entered in this step starts its count at the next one.
                if (self.phase, self.direction) == (phase, direction) {
                    self.steps = self.steps.saturating_add(1);
                }
                let v = self.sign() * self.command;
                TuneStep::Drive(WheelVolts {
                    left_v: v,
                    right_v: v,
                })
            }
            Err(reason) => {
                self.finish(Err(reason));
                TuneStep::Finished(Err(reason))
            }
        }
    }

    /// Records the outcome and goes idle with 0 V.
    fn finish(&mut self, outcome: Result<TuneResult, TuneAbort>) {
        self.outcome = Some(outcome);
        self.phase = Phase::Finished;
        self.command = 0.0;
    }

    fn sign(&self) -> f32 {
        if self.direction == 0 {
            1.0
        } else {
            -1.0
        }
    }

    /// The lag of the speed estimate (a moving average of W periods, W T/2) and of the
    /// sampling (T/2), s.
    fn window_lag_s(&self) -> f32 {
        0.5 * (self.window_steps + 1) as f32 * self.period_s
    }

    /// Steps of `seconds` at the control period, to the nearest (1 s at 1 kHz is 1 000,
    /// though 1/0.001 is 999.99994 in f32).
    fn steps_of(&self, seconds: f32) -> u32 {
        let n = seconds / self.period_s;
        if (1.0..4e9).contains(&n) {
            (n + 0.5) as u32
        } else {
            1
        }
    }

    /// The checks and the phase logic of one step (module doc).
    fn observe(&mut self, t: &Telemetry, periods: u32) -> Result<(), TuneAbort> {
        if periods != 1 {
            return Err(TuneAbort::LateStep);
        }
        let sign = self.sign();
        // Speeds and applied volts in the experiment's direction.
        let speed = [
            sign * t.wheel_speed.left_rad_s,
            sign * t.wheel_speed.right_rad_s,
        ];
        let volts = [
            sign * t.wheel_loop.volts.left_v,
            sign * t.wheel_loop.volts.right_v,
        ];
        for (side, w) in Side::BOTH.iter().zip(speed) {
            if math::abs(w) > self.config.max_speed_rad_s {
                return Err(TuneAbort::TooFast(*side));
            }
            if self.phase != Phase::Brake && w < -MOVING_RAD_S {
                return Err(TuneAbort::WrongDirection(*side));
            }
        }
        self.pose = t.pose;
        if self.config.load == TuneLoad::Ground {
            let d = math::hypot(t.pose.x_m - self.start.x_m, t.pose.y_m - self.start.y_m);
            // Written so that a NaN distance stops the tune too.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(d <= self.config.max_distance_m) {
                return Err(TuneAbort::TooFar);
            }
        }
        match self.phase {
            Phase::Breakaway => self.breakaway(speed, volts),
            Phase::Hold => self.hold(speed, volts),
            Phase::Step => self.step_response(speed, volts),
            Phase::Ramp => self.ramp(speed, volts),
            Phase::Brake => self.brake(speed),
            Phase::Idle | Phase::Finished => Ok(()),
        }
    }

    fn breakaway(&mut self, speed: [f32; 2], volts: [f32; 2]) -> Result<(), TuneAbort> {
        let high = self.config.experiment_volts_v;
        if self.steps == 0 && speed.iter().any(|w| math::abs(*w) >= STALLED_RAD_S) {
            return Err(TuneAbort::NotAtRest);
        }
        for ((u_b, w), u) in self.breakaway.iter_mut().zip(speed).zip(volts) {
            if u_b.is_none() && w >= MOVING_RAD_S {
                *u_b = Some(u);
            }
        }
        match self.breakaway {
            [Some(l), Some(r)] => {
                let (u_b, side) = if l >= r {
                    (l, Side::Left)
                } else {
                    (r, Side::Right)
                };
                if u_b > MAX_BREAKAWAY_FRACTION * high {
                    return Err(TuneAbort::BreakawayTooHigh(side));
                }
                self.low_v = u_b + LOW_FRACTION * (high - u_b);
                self.entry_speed = speed;
                self.entry_volts = volts;
                self.hold_origin = 0;
                self.hold_end = self.steps_of(HOLD_FIRST_S).min(self.max_hold_steps());
                self.bank.restart();
                self.enter(Phase::Hold, self.low_v);
            }
            [left, _] => {
                let ramp = self.config.breakaway_ramp_v_per_s * self.period_s * self.steps as f32;
                if ramp >= high + self.config.breakaway_ramp_v_per_s * BREAKAWAY_TIMEOUT_S {
                    let side = if left.is_none() {
                        Side::Left
                    } else {
                        Side::Right
                    };
                    return Err(TuneAbort::NoBreakaway(side));
                }
                self.command = if ramp < high { ramp } else { high };
            }
        }
        Ok(())
    }

    /// The longest hold or step, steps ([`TuneConfig::max_hold_s`]).
    fn max_hold_steps(&self) -> u32 {
        self.steps_of(self.config.max_hold_s)
    }

    /// The hold: the step from the breakaway to u_lo, fitted at each checkpoint until it
    /// has settled (by [`SETTLE_TAUS`] of its own τ + θ) or the longest hold is reached;
    /// then the identifying step is planned from it.
    fn hold(&mut self, speed: [f32; 2], volts: [f32; 2]) -> Result<(), TuneAbort> {
        let grace = self.steps_of(HOLD_FIRST_S);
        self.check_turning(speed, grace)?;
        if self.steps < grace && speed.contains(&0.0) {
            // A wheel stuck for a moment early in the hold (its estimate reads exactly 0,
            // no tick in the window): its response is no step any more, so the hold's
            // fit starts again from rest, with the next sample.
            self.hold_origin = self.steps.saturating_add(1);
            self.entry_speed = speed;
            self.hold_end = grace.min(self.max_hold_steps());
            self.step_sums = [StepSums::default(); 2];
            self.hold_speed = [f32::NAN; 2];
            self.hold_volts = [0.0; 2];
            self.hold_n = 0;
            self.bank.restart();
            return Ok(());
        }
        // Steps since the hold's response began.
        let k = self.steps.saturating_sub(self.hold_origin);
        let end = self.hold_end;
        self.bank.advance();
        let tail = k >= end - end / BASELINE_FRACTION;
        let weights = self.bank.weights();
        for ((sums, w), base) in self.step_sums.iter_mut().zip(speed).zip(self.entry_speed) {
            sums.push(w - base, weights, tail);
        }
        if tail {
            add(&mut self.hold_volts, volts);
            self.hold_n += 1;
        }
        if k + 1 < end {
            return Ok(());
        }
        let per = 1.0 / self.hold_n.max(1) as f32;
        let length_s = end as f32 * self.period_s;
        let max = self.max_hold_steps();
        let mut models = [None; 2];
        let mut settled = [false; 2];
        for ((((model, ok), sums), (entry, tail_volts)), last) in models
            .iter_mut()
            .zip(settled.iter_mut())
            .zip(&self.step_sums)
            .zip(self.entry_volts.iter().zip(self.hold_volts))
            .zip(self.hold_speed.iter_mut())
        {
            *model = sums
                .fit(
                    tail_volts * per - entry,
                    self.period_s,
                    self.window_steps,
                    weights,
                )
                .filter(|m| m.gain > 0.0 && m.tau > 0.0);
            // A response that does not fit (one that began from a wheel stuck in the hold,
            // or had nothing left to settle after it) counts as settled once its tail
            // moved by less than 2 % (or [`STEADY_RAD_S`]) since the last checkpoint
            // (`last`, the previous tail's Δω; NaN before the first).
            let delta = sums.delta();
            let moved = math::abs(delta - *last);
            let steady = moved <= STEADY_FRACTION * math::abs(delta) || moved <= STEADY_RAD_S;
            *last = delta;
            *ok = match model {
                Some(m) => length_s >= SETTLE_TAUS * settle_scale_s(m),
                None => steady,
            };
        }
        if !(settled[0] && settled[1]) && end < max {
            // On to the next checkpoint, 3/2 as long; its tail starts after this one.
            self.hold_end = (end + end / 2).min(max);
            for sums in &mut self.step_sums {
                sums.restart_tail();
            }
            self.hold_volts = [0.0; 2];
            self.hold_n = 0;
            return Ok(());
        }
        // The first estimate: τ + θ and K of each wheel's fit, or, for a steady response
        // that did not fit (too small a change for the speed estimate's quanta), the
        // bounds it proved: τ + θ at most 1/5 of the hold, K = Δω/Δu of its tails.
        let mut scale_s = 0.0f32;
        let mut gain = 0.0f32;
        let wheels = Side::BOTH
            .iter()
            .zip(models)
            .zip(settled)
            .zip(self.step_sums.iter().zip(self.entry_volts))
            .zip(
                self.hold_volts
                    .iter()
                    .zip(self.warnings.hold_not_settled.iter_mut()),
            );
        for ((((side, model), ok), (sums, entry)), (tail_volts, unsettled)) in wheels {
            let (wheel_scale, wheel_gain) = match model {
                Some(m) => (settle_scale_s(&m), m.gain),
                None if ok => (
                    length_s / SETTLE_TAUS,
                    sums.delta() / (per * tail_volts - entry),
                ),
                None => return Err(TuneAbort::NoFit(*side)),
            };
            scale_s = scale_s.max(wheel_scale);
            gain = gain.max(wheel_gain);
            if !ok {
                *unsettled = true;
            }
        }
        // Written so that a NaN estimate stops the tune too.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(scale_s > 0.0 && gain > 0.0 && gain < f32::MAX) {
            return Err(TuneAbort::NoFit(Side::Left));
        }
        for ((steady, sums), entry) in self
            .hold_speed
            .iter_mut()
            .zip(&self.step_sums)
            .zip(self.entry_speed)
        {
            *steady = entry + sums.delta();
        }
        self.hold_volts = self.hold_volts.map(|x| x * per);
        self.plan_step(scale_s, gain);
        self.bank.restart();
        self.enter(Phase::Step, self.high_v);
        Ok(())
    }

    /// The step's length and level from the hold's τ + θ (`scale_s`, s) and gain (`gain`,
    /// rad/s per V, the larger wheel's): [`STEP_TAUS`] of the hold's τ + θ (at most the
    /// longest hold), and the largest level whose step and shortest ramp keep this
    /// direction's travel within its budget and the speed within its limit. The step is
    /// at least as large as the hold's own; when even that does not fit the budget, the
    /// step is shortened to fit (and its fit will say it had not settled).
    fn plan_step(&mut self, scale_s: f32, gain: f32) {
        let mut step_steps = self
            .steps_of(STEP_TAUS * scale_s)
            .max(self.steps_of(HOLD_FIRST_S))
            .min(self.max_hold_steps());
        let step_s = step_steps as f32 * self.period_s;
        let low = self.hold_speed[0].max(self.hold_speed[1]);
        let mut top = STEP_SPEED_FRACTION * self.config.max_speed_rad_s;
        // Wheel angle left once the shortest ramp (at the mean of ω_hi and ω_lo) and the
        // brake (about one τ at ω_lo) are paid for, rad, as ω_hi × s + this.
        let ramp_s = RAMP_MIN_TAUS * scale_s;
        let ground = self.config.load == TuneLoad::Ground && self.wheel_radius_m > 0.0;
        let angle = self.budget_left_m() / self.wheel_radius_m - low * (0.5 * ramp_s + scale_s);
        if ground {
            top = top.min(angle / (step_s + 0.5 * ramp_s));
        }
        let high = self.config.experiment_volts_v;
        let least = self.low_v + (self.low_v - self.entry_volts[0].max(self.entry_volts[1]));
        let planned = self.low_v + (top - low) / gain;
        // Written so that a NaN plan takes the least step.
        let planned = if planned >= least { planned } else { least };
        self.high_v = if planned < high { planned } else { high };
        if ground {
            let speed = low + gain * (self.high_v - self.low_v);
            let fits_s = angle / speed - 0.5 * ramp_s;
            if fits_s < step_s {
                step_steps = self.steps_of(fits_s).max(self.steps_of(HOLD_FIRST_S));
            }
        }
        self.step_steps = step_steps;
    }

    /// What is left of this direction's distance budget, m (never below 0).
    fn budget_left_m(&self) -> f32 {
        let used = math::hypot(
            self.pose.x_m - self.direction_start.x_m,
            self.pose.y_m - self.direction_start.y_m,
        );
        let left = DISTANCE_BUDGET_FRACTION * self.config.max_distance_m - used;
        if left > 0.0 {
            left
        } else {
            0.0
        }
    }

    fn step_response(&mut self, speed: [f32; 2], volts: [f32; 2]) -> Result<(), TuneAbort> {
        let length = self.step_steps;
        self.check_turning(speed, 0)?;
        // Each sample is one period after the last, the first one period after the step
        // was asked for. The controller applies what the tune asks in its next step, so
        // the identified θ includes that period; the wheel loop acts in the same step and
        // does not have it, so its PI is set for one period more dead time than it sees.
        self.bank.advance();
        let tail = self.steps >= length - length / BASELINE_FRACTION;
        let weights = self.bank.weights();
        for ((sums, w), base) in self.step_sums.iter_mut().zip(speed).zip(self.hold_speed) {
            sums.push(w - base, weights, tail);
        }
        if tail {
            add(&mut self.step_volts, volts);
            self.hold_n += 1;
        }
        if self.steps + 1 < length {
            return Ok(());
        }
        let tail_n = self.hold_n.max(1) as f32;
        let length_s = length as f32 * self.period_s;
        let mut slowest = 0.0f32;
        let mut high_speed = 0.0f32;
        let fits = self
            .fits
            .get_mut(self.direction)
            .ok_or(TuneAbort::Stopped)?;
        let wheels = Side::BOTH
            .iter()
            .zip(fits.iter_mut())
            .zip(self.step_sums.iter().zip(self.step_volts))
            .zip(self.hold_volts.iter().zip(self.hold_speed))
            .zip(self.warnings.step_not_settled.iter_mut());
        for ((((side, fit), (sums, step_volts)), (hold_volts, hold_speed)), unsettled) in wheels {
            let delta_u = step_volts / tail_n - hold_volts;
            // `fit` returns τ > 0 (a bisection's midpoint) and K = Δω/Δu > 0 (both > 0)
            // unless Δω/Δu underflows f32; the filter guards against that.
            let model = sums
                .fit(delta_u, self.period_s, self.window_steps, weights)
                .filter(|m| m.gain > 0.0 && m.tau > 0.0)
                .ok_or(TuneAbort::NoFit(*side))?;
            fit.model = model;
            // Written so that a NaN time scale counts as unsettled.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(length_s >= SETTLE_TAUS * settle_scale_s(&model)) {
                *unsettled = true;
            }
            slowest = slowest.max(model.tau);
            high_speed = high_speed.max(hold_speed + sums.delta());
        }
        // The ramp: 12 τ (at least [`RAMP_LEAST_S`]), or as long as the budget left
        // allows but at least 5 τ, from ω_hi down to ω_lo (the brake about one τ at ω_lo
        // after it).
        let low_speed = self.hold_speed[0].max(self.hold_speed[1]);
        let mut ramp_s = (RAMP_TAUS * slowest).max(RAMP_LEAST_S);
        if self.config.load == TuneLoad::Ground && self.wheel_radius_m > 0.0 {
            let angle = self.budget_left_m() / self.wheel_radius_m;
            let fits_in = (angle - low_speed * slowest) / (0.5 * (high_speed + low_speed));
            ramp_s = ramp_s.min(fits_in).max(RAMP_MIN_TAUS * slowest);
        }
        let span = self.high_v - self.low_v;
        self.ramp_rate = span / ramp_s;
        self.ramp_skip = self.steps_of(RAMP_SKIP_FRACTION * ramp_s);
        self.enter(Phase::Ramp, self.high_v);
        Ok(())
    }

    fn ramp(&mut self, speed: [f32; 2], volts: [f32; 2]) -> Result<(), TuneAbort> {
        self.check_turning(speed, 0)?;
        if self.steps >= self.ramp_skip {
            for ((fit, w), u) in self.ramp.iter_mut().zip(speed).zip(volts) {
                fit.push(w, u);
            }
        }
        let next = self.high_v - self.ramp_rate * self.period_s * (self.steps + 1) as f32;
        if next > self.low_v {
            self.command = next;
            return Ok(());
        }
        // The ramp is done: k_V from its slope, k_S from its intercept and the step's lag.
        let window_lag = self.window_lag_s();
        let fits = self
            .fits
            .get_mut(self.direction)
            .ok_or(TuneAbort::Stopped)?;
        for ((side, fit), line) in Side::BOTH.iter().zip(fits.iter_mut()).zip(&self.ramp) {
            let (intercept, slope) = line
                .line()
                .filter(|(_, k)| *k > 0.0)
                .ok_or(TuneAbort::NoFit(*side))?;
            let lag = fit.model.tau + fit.model.theta + window_lag;
            fit.kv_v_per_rad_s = slope;
            fit.ks_v = intercept + self.ramp_rate * lag;
        }
        self.enter(Phase::Brake, 0.0);
        Ok(())
    }

    fn brake(&mut self, speed: [f32; 2]) -> Result<(), TuneAbort> {
        if speed.iter().any(|w| math::abs(*w) >= STALLED_RAD_S) {
            // Counted as steps at rest in `hold_n` (reused: the hold is over).
            self.hold_n = 0;
        } else {
            self.hold_n += 1;
        }
        if self.hold_n >= REST_STEPS {
            if self.direction == 0 {
                self.direction = 1;
                self.direction_start = self.pose;
                self.breakaway = [None; 2];
                self.enter(Phase::Breakaway, 0.0);
            } else {
                // Stored as it comes, not unwrapped and wrapped again: each copy of
                // the result was another 96 bytes of the control interrupt's stack.
                let outcome = self.result();
                outcome?;
                self.finish(outcome);
            }
        } else if self.steps >= self.steps_of(BRAKE_TIMEOUT_S) {
            return Err(TuneAbort::NotStopped);
        }
        Ok(())
    }

    /// A wheel that should turn stopped, after `grace` steps of the phase.
    fn check_turning(&self, speed: [f32; 2], grace: u32) -> Result<(), TuneAbort> {
        if self.steps < grace {
            return Ok(());
        }
        match speed {
            [l, _] if l < STALLED_RAD_S => Err(TuneAbort::Stalled(Side::Left)),
            [_, r] if r < STALLED_RAD_S => Err(TuneAbort::Stalled(Side::Right)),
            _ => Ok(()),
        }
    }

    /// Into `phase`, asking `volts` (magnitude) next; the phase's accumulators restart.
    fn enter(&mut self, phase: Phase, volts: f32) {
        self.phase = phase;
        self.steps = 0;
        self.command = volts;
        match phase {
            Phase::Hold => {
                self.step_sums = [StepSums::default(); 2];
                // The previous checkpoint's Δω: none yet.
                self.hold_speed = [f32::NAN; 2];
                self.hold_volts = [0.0; 2];
                self.hold_n = 0;
            }
            Phase::Step => {
                self.step_sums = [StepSums::default(); 2];
                self.step_volts = [0.0; 2];
                self.hold_n = 0;
            }
            Phase::Ramp => self.ramp = [LineFit::default(); 2],
            Phase::Brake => self.hold_n = 0,
            Phase::Idle | Phase::Breakaway | Phase::Finished => {}
        }
    }

    /// Both directions averaged, checked, and the PI by SIMC (module doc).
    fn result(&self) -> Result<TuneResult, TuneAbort> {
        let [[f_left, f_right], [b_left, b_right]] = &self.fits;
        let (left_model, left_loop) = self.wheel_result(f_left, b_left, Side::Left)?;
        let (right_model, right_loop) = self.wheel_result(f_right, b_right, Side::Right)?;
        Ok(TuneResult {
            models: [left_model, right_model],
            loops: [left_loop, right_loop],
            warnings: self.warnings,
        })
    }

    /// One wheel's model and loop from its forward fit `f` and backward fit `b`.
    fn wheel_result(
        &self,
        f: &DirectionFit,
        b: &DirectionFit,
        side: Side,
    ) -> Result<(WheelModel, WheelLoopConfig), TuneAbort> {
        let mean = |x: f32, y: f32| 0.5 * (x + y);
        let agree = |x: f32, y: f32| math::abs(x - y) <= MAX_MISMATCH * mean(x, y);
        let kv = mean(f.kv_v_per_rad_s, b.kv_v_per_rad_s);
        let gain = mean(f.model.gain, b.model.gain);
        let tau = mean(f.model.tau, b.model.tau);
        let consistent = agree(f.kv_v_per_rad_s, b.kv_v_per_rad_s)
            && agree(f.model.gain, b.model.gain)
            && agree(f.model.tau, b.model.tau)
            && agree(gain * kv, 1.0);
        if !consistent {
            return Err(TuneAbort::Inconsistent(side));
        }
        let factor = match self.config.load {
            TuneLoad::Ground => 1.0,
            TuneLoad::Lifted {
                ground_inertia_factor,
            } => ground_inertia_factor,
        };
        let model = Fopdt {
            gain,
            tau: tau * factor,
            theta: mean(f.model.theta, b.model.theta),
        };
        // The loop's dead time: the plant's (never below 0) and the controller's own.
        let window_lag = self.window_lag_s();
        let dead_time = if model.theta > 0.0 { model.theta } else { 0.0 } + window_lag;
        let (kp, ti) = simc(
            &model,
            dead_time,
            self.config.tau_c_per_dead_time * dead_time,
        );
        let ks = mean(f.ks_v, b.ks_v);
        let ks = if ks > 0.0 { ks } else { 0.0 };
        if ![ks, kv, kp, ti].iter().all(|x| x.is_finite()) {
            return Err(TuneAbort::NoFit(side));
        }
        Ok((
            WheelModel {
                ks_v: ks,
                kv_v_per_rad_s: kv,
                gain_rad_s_per_v: gain,
                time_constant_s: tau,
                dead_time_s: model.theta,
                design_time_constant_s: model.tau,
            },
            WheelLoopConfig {
                ks_v: ks,
                kv_v_per_rad_s: kv,
                kp_v_per_rad_s: kp,
                ti_s: ti,
                td_s: 0.0,
                d_filter_tau_s: 0.0,
            },
        ))
    }
}

/// The time scale a response settles on, τ + θ (θ never below 0), s.
fn settle_scale_s(model: &Fopdt) -> f32 {
    model.tau + if model.theta > 0.0 { model.theta } else { 0.0 }
}

/// `into[i] += x[i]` for both wheels.
fn add(into: &mut [f32; 2], x: [f32; 2]) {
    for (a, b) in into.iter_mut().zip(x) {
        *a += b;
    }
}

#[cfg(test)]
mod tests;
