//! Gain and phase margins of the wheel-speed loop: from its linearised model, and
//! measured on the simulated robot by a frequency sweep.
//!
//! ## The linearised loop
//!
//! One wheel, in one load case, while it drives (motoring) away from rest, is a first-order
//! plant from armature voltage u (V) to wheel speed ω (rad/s):
//!
//! τ ω̇ = −ω + K u,   K = g / c,   τ = J / c,
//!
//! with g the torque per volt at the wheel (η N K_t / (R_a + R_bridge) motoring, ÷ η
//! instead of × η back-driven), c the damping (electrical plus viscous, [`PowerFlow`]) and
//! J the inertia the wheel sees: a + b of the chassis' inertia matrix driving straight,
//! a − b turning on the spot (with identical wheel loops the two wheels' loops split
//! exactly into these two modes), the wheel's own inertia lifted
//! ([`robot_files::plant::Load`]). Coulomb friction is a constant offset and drops out;
//! the feed-forward acts on the set-point, outside the loop.
//!
//! Discretised exactly at the control period T with the voltage held over the period
//! (zero-order hold, as the PWM does), with the wheel angle φ as a second state (the
//! encoder measures angle, not speed), a = e^(−T/τ):
//!
//! ```text
//! ω[k+1] = a ω[k] + K (1 − a) u[k]
//! φ[k+1] = φ[k] + τ (1 − a) ω[k] + K (T − τ (1 − a)) u[k]
//! ω̂[k]   = (φ[k] − φ[k−W]) / (W T)                      (the speed estimate's window)
//! ```
//!
//! The controller is the core's incremental PID in volts, C(z) = K_p + K_i / (1 − z⁻¹) +
//! (1 − α) K_d (1 − z⁻¹) / (1 − α z⁻¹) with the discrete gains of
//! [`controller_core::pid::PidGains`], on e = ω* − ω̂; the output is applied in the same
//! step (no computation delay: the firmware writes the compare register microseconds
//! after reading the encoders). The open loop is L(z) = C(z) P(z), P the plant above from
//! u to ω̂, evaluated on the unit circle up to the Nyquist frequency π/T.
//!
//! - **Gain margin**: 1/|L| where L crosses the negative real axis (the smallest, if it
//!   crosses more than once).
//! - **Phase margin**: 180° + arg L where |L| = 1 (the smallest), and the **delay margin**
//!   it buys, PM / ω_c.
//! - **Stable**: the linear closed loop, started from a speed error, decays (simulated
//!   for 20 s; the margins mean nothing for an unstable loop).
//!
//! What the model leaves out, and the sweep on the nonlinear plant therefore checks: the
//! encoder's quantisation, the PWM's, the voltage, current and slew limits (inactive for
//! small signals), the switch between motoring and back-driven gear efficiency (the
//! back-driven case is computed on its own: its torque per volt is 1/η² larger), and the
//! wheels' coupling through the chassis when the two loops differ.
//!
//! ## The measurement
//!
//! [`measure_open_loop`] breaks the loop at the plant's input on the simulated robot: with
//! the robot armed in hold mode through the supervisor at a wheel speed well above rest,
//! it adds d = A sin(Ω k T) volts to both wheels (straight: in phase; turning: opposite)
//! and correlates, over a whole number of periods, the controller's output v with the
//! voltage actually applied, u = v + d: L(e^(jΩT)) = −V/U at that frequency.

use controller_core::kinematics::WheelSpeeds;
use controller_core::law::LawKind;
use controller_core::params::Params;
use controller_core::pid::PidGains;
use controller_core::supervisor::{ArmRequest, RunMode};
use robot_files::plant::{Load, Wheel};
use robot_files::scenario::Scenario;

use crate::plant::{Plant, PlantError, PlantParams, PowerFlow};
use crate::run::{plant_params, RunError};

/// A complex number, for frequency responses.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// re + j·im.
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    /// e^(jθ).
    pub fn unit(theta_rad: f64) -> Self {
        Self::new(theta_rad.cos(), theta_rad.sin())
    }

    /// |z|.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }

    /// arg z, rad, in (−π, π].
    pub fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }

    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }

    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn scale(self, k: f64) -> Complex {
        Complex::new(k * self.re, k * self.im)
    }

    fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }

    fn one_minus(self) -> Complex {
        Complex::new(1.0 - self.re, -self.im)
    }
}

/// Which of the wheel loops' two modes a load case excites.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Both wheels the same way: driving straight (the chassis' mass).
    Straight,
    /// The wheels opposite: turning on the spot (the chassis' yaw inertia).
    Turning,
}

/// One wheel linearised in one load case: τ ω̇ = −ω + K u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelPlant {
    /// Steady-state gain K, rad/s per V.
    pub gain_rad_s_per_v: f64,
    /// Time constant τ, s.
    pub time_constant_s: f64,
}

impl WheelPlant {
    /// The plant of `params` in `motion` with gearbox power flow `flow` (motoring or
    /// back-driven; coasting has no input and gives an error), both wheels taken alike:
    /// with a motor mismatch, both with the left wheel's motor.
    pub fn linearise(
        params: &PlantParams,
        motion: Motion,
        flow: PowerFlow,
    ) -> Result<Self, PlantError> {
        if flow == PowerFlow::Coasting {
            return Err(PlantError::OutOfRange("flow"));
        }
        let plant = Plant::new(*params)?;
        let [a, b] = plant.inertia_kg_m2();
        let inertia = match motion {
            Motion::Straight => a + b,
            Motion::Turning => a - b,
        };
        let drive = plant.drive(Wheel::Left);
        let damping = drive.damping_nm_s_per_rad(flow);
        let torque_per_volt = drive.gear_factor(flow) * drive.torque_per_volt;
        Ok(Self {
            gain_rad_s_per_v: torque_per_volt / damping,
            time_constant_s: inertia / damping,
        })
    }
}

/// Gain and phase margins of one loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// Gain margin (a factor; `None`: L never crosses the negative real axis below the
    /// Nyquist frequency, an infinite margin).
    pub gain_margin: Option<f64>,
    /// Where the gain margin is taken, rad/s.
    pub phase_crossover_rad_s: Option<f64>,
    /// Phase margin, degrees (`None`: |L| never reaches 1).
    pub phase_margin_deg: Option<f64>,
    /// Where the phase margin is taken (the gain crossover), rad/s.
    pub gain_crossover_rad_s: Option<f64>,
}

impl Margins {
    /// The gain margin in dB (`None`: infinite).
    pub fn gain_margin_db(&self) -> Option<f64> {
        self.gain_margin.map(|g| 20.0 * g.log10())
    }

    /// The extra loop delay that would use up the phase margin, s.
    pub fn delay_margin_s(&self) -> Option<f64> {
        match (self.phase_margin_deg, self.gain_crossover_rad_s) {
            (Some(pm), Some(w)) if w > 0.0 => Some(pm.to_radians() / w),
            _ => None,
        }
    }

    /// Margins from `points` of a frequency response, (Ω rad/s, L(e^(jΩT))) in increasing
    /// frequency, interpolating between neighbours.
    pub fn from_response(points: &[(f64, Complex)]) -> Self {
        let mut margins = Margins {
            gain_margin: None,
            phase_crossover_rad_s: None,
            phase_margin_deg: None,
            gain_crossover_rad_s: None,
        };
        for pair in points.windows(2) {
            let [(w0, l0), (w1, l1)] = [pair[0], pair[1]];
            // The negative real axis: Im L changes sign with Re L < 0.
            if (l0.im < 0.0) != (l1.im < 0.0) || l1.im == 0.0 {
                let t = if l0.im == l1.im {
                    1.0
                } else {
                    l0.im / (l0.im - l1.im)
                };
                let re = l0.re + t * (l1.re - l0.re);
                if re < 0.0 {
                    let gm = 1.0 / -re;
                    if margins.gain_margin.is_none_or(|g| gm < g) {
                        margins.gain_margin = Some(gm);
                        margins.phase_crossover_rad_s = Some(w0 + t * (w1 - w0));
                    }
                }
            }
            // The unit circle.
            let (m0, m1) = (l0.abs(), l1.abs());
            if (m0 - 1.0) * (m1 - 1.0) <= 0.0 && m0 != m1 {
                let t = (m0 - 1.0) / (m0 - m1);
                let phase0 = l0.arg();
                // Interpolate the phase along the shorter way round.
                let mut dphase = l1.arg() - phase0;
                if dphase > std::f64::consts::PI {
                    dphase -= std::f64::consts::TAU;
                } else if dphase < -std::f64::consts::PI {
                    dphase += std::f64::consts::TAU;
                }
                let phase = phase0 + t * dphase;
                let pm = 180.0 - wrap_pi(phase).abs().to_degrees();
                if margins.phase_margin_deg.is_none_or(|p| pm < p) {
                    margins.phase_margin_deg = Some(pm);
                    margins.gain_crossover_rad_s = Some(w0 + t * (w1 - w0));
                }
            }
        }
        margins
    }
}

/// `a` wrapped to (−π, π], rad.
fn wrap_pi(a: f64) -> f64 {
    robot_files::truth::wrap_angle(a)
}

/// The linearised wheel loop (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopModel {
    /// The plant.
    pub plant: WheelPlant,
    /// Control period T, s.
    pub period_s: f64,
    /// Steps W of the speed estimate's window.
    pub window_steps: u32,
    /// The PID's discrete gains.
    pub gains: PidGains,
}

/// Frequencies of the model's grid.
const MODEL_POINTS: usize = 20_000;

impl LoopModel {
    /// The loop of wheel `wheel` (0 left, 1 right) of the controller `params` around
    /// `plant`.
    pub fn new(plant: WheelPlant, params: &Params, wheel: usize) -> Self {
        Self {
            plant,
            period_s: f64::from(params.period_s()),
            window_steps: params.config().speed_window_steps,
            gains: params.wheel_pid()[wheel.min(1)],
        }
    }

    /// The plant from u (V) to the speed estimate ω̂ (rad/s), at `omega_rad_s`.
    pub fn plant_response(&self, omega_rad_s: f64) -> Complex {
        let t = self.period_s;
        let tau = self.plant.time_constant_s;
        let k = self.plant.gain_rad_s_per_v;
        let a = (-t / tau).exp();
        let zi = Complex::unit(-omega_rad_s * t);
        // Φ/U = z⁻¹ [τ(1−a) K(1−a) z⁻¹ / (1 − a z⁻¹) + K (T − τ(1−a))] / (1 − z⁻¹), and
        // the window (1 − z⁻ᵂ)/(W T): the two (1 − z⁻¹) cancel into Σ z⁻ⁿ, n < W.
        let lagged = zi
            .div(zi.scale(a).one_minus())
            .scale(tau * (1.0 - a) * k * (1.0 - a));
        let direct = Complex::new(k * (t - tau * (1.0 - a)), 0.0);
        let mut window = Complex::default();
        let mut power = Complex::new(1.0, 0.0);
        for _ in 0..self.window_steps {
            window = window.add(power);
            power = power.mul(zi);
        }
        let w = f64::from(self.window_steps.max(1));
        zi.mul(lagged.add(direct)).mul(window).scale(1.0 / (w * t))
    }

    /// The controller C(z) at `omega_rad_s`, V per rad/s.
    pub fn controller_response(&self, omega_rad_s: f64) -> Complex {
        let g = &self.gains;
        let zi = Complex::unit(-omega_rad_s * self.period_s);
        let integral = Complex::new(f64::from(g.ki), 0.0).div(zi.one_minus());
        let derivative = zi
            .one_minus()
            .div(zi.scale(f64::from(g.d_filter_alpha)).one_minus())
            .scale(f64::from((1.0 - g.d_filter_alpha) * g.kd));
        Complex::new(f64::from(g.kp), 0.0)
            .add(integral)
            .add(derivative)
    }

    /// The open loop L = C·P at `omega_rad_s`.
    pub fn open_loop(&self, omega_rad_s: f64) -> Complex {
        self.controller_response(omega_rad_s)
            .mul(self.plant_response(omega_rad_s))
    }

    /// The open loop on a log grid from 0.1 rad/s to the Nyquist frequency.
    pub fn response(&self) -> Vec<(f64, Complex)> {
        let nyquist = std::f64::consts::PI / self.period_s;
        let (lo, hi) = (0.1f64.ln(), nyquist.ln());
        (0..MODEL_POINTS)
            .map(|i| {
                let w = (lo + (hi - lo) * i as f64 / (MODEL_POINTS - 1) as f64).exp();
                (w, self.open_loop(w))
            })
            .collect()
    }

    /// The margins (module doc).
    pub fn margins(&self) -> Margins {
        Margins::from_response(&self.response())
    }

    /// True when the linear closed loop, started with a 1 rad/s speed error and no
    /// set-point, decays to a millionth within 20 s.
    pub fn is_stable(&self) -> bool {
        let t = self.period_s;
        let tau = self.plant.time_constant_s;
        let k = self.plant.gain_rad_s_per_v;
        let a = (-t / tau).exp();
        let g = &self.gains;
        let (alpha, kd) = (f64::from(g.d_filter_alpha), f64::from(g.kd));
        let w_steps = self.window_steps.max(1) as usize;
        let mut omega = 1.0f64;
        // The window starts filled with the initial speed (as if it had held for a while).
        let mut increments = vec![omega * t; w_steps];
        let (mut output, mut error_1, mut derivative) = (0.0f64, 0.0f64, 0.0f64);
        let steps = (20.0 / t) as usize;
        let tail_from = steps - (2.0 / t) as usize;
        let mut tail_peak = 0.0f64;
        for step in 0..steps {
            let estimate = increments.iter().sum::<f64>() / (w_steps as f64 * t);
            let error = -estimate;
            let delta = error - error_1;
            let d_new = alpha * derivative + (1.0 - alpha) * kd * delta;
            output += f64::from(g.kp) * delta + f64::from(g.ki) * error + d_new - derivative;
            derivative = d_new;
            error_1 = error;
            let advance = tau * (1.0 - a) * omega + k * (t - tau * (1.0 - a)) * output;
            omega = a * omega + k * (1.0 - a) * output;
            increments.rotate_left(1);
            if let Some(last) = increments.last_mut() {
                *last = advance;
            }
            if !omega.is_finite() {
                return false;
            }
            if step >= tail_from {
                tail_peak = tail_peak.max(omega.abs());
            }
        }
        tail_peak < 1e-6
    }
}

/// One load case of the wheel loop, for [`model_cases`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadCase {
    /// What the wheels drive.
    pub load: Load,
    /// Which mode.
    pub motion: Motion,
    /// The gearbox's power flow linearised about.
    pub flow: PowerFlow,
}

impl LoadCase {
    /// A short description, e.g. `ground, straight`.
    pub fn name(&self) -> String {
        let mut name = match (self.load, self.motion) {
            (Load::Lifted, _) => "lifted".to_string(),
            (Load::Ground, Motion::Straight) => "ground, straight".to_string(),
            (Load::Ground, Motion::Turning) => "ground, turning".to_string(),
        };
        if self.flow == PowerFlow::BackDriven {
            name.push_str(", braking");
        }
        name
    }

    /// The cases the `margins` command reports: on the ground straight and turning,
    /// lifted, each motoring, then the same braking (back-driven gearbox).
    pub const ALL: [LoadCase; 6] = [
        LoadCase::new(Load::Ground, Motion::Straight, PowerFlow::Motoring),
        LoadCase::new(Load::Ground, Motion::Turning, PowerFlow::Motoring),
        LoadCase::new(Load::Lifted, Motion::Straight, PowerFlow::Motoring),
        LoadCase::new(Load::Ground, Motion::Straight, PowerFlow::BackDriven),
        LoadCase::new(Load::Ground, Motion::Turning, PowerFlow::BackDriven),
        LoadCase::new(Load::Lifted, Motion::Straight, PowerFlow::BackDriven),
    ];

    const fn new(load: Load, motion: Motion, flow: PowerFlow) -> Self {
        Self { load, motion, flow }
    }
}

/// The model of one load case and its margins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaseMargins {
    /// The case.
    pub case: LoadCase,
    /// The linearised loop.
    pub model: LoopModel,
    /// Its margins.
    pub margins: Margins,
    /// The linear closed loop is stable.
    pub stable: bool,
}

/// The linearised loop of `scenario`'s left wheel in `case` (the scenario's own load is
/// replaced by the case's).
pub fn case_model(scenario: &Scenario, case: LoadCase) -> Result<LoopModel, RunError> {
    let params = scenario.params()?;
    let mut plant = plant_params(scenario);
    plant.load = case.load;
    let wheel = WheelPlant::linearise(&plant, case.motion, case.flow)?;
    Ok(LoopModel::new(wheel, &params, 0))
}

/// Every [`LoadCase::ALL`] of `scenario`'s robot and plant, from the model.
pub fn model_cases(scenario: &Scenario) -> Result<Vec<CaseMargins>, RunError> {
    LoadCase::ALL
        .iter()
        .map(|&case| {
            let model = case_model(scenario, case)?;
            Ok(CaseMargins {
                case,
                model,
                margins: model.margins(),
                stable: model.is_stable(),
            })
        })
        .collect()
}

/// Settings of a measured frequency sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSettings {
    /// Wheel speed held while measuring, rad/s (well above rest, so the gearbox stays
    /// motoring and friction is kinetic).
    pub operating_rad_s: f64,
    /// Amplitude A of the injected voltage, V.
    pub amplitude_v: f64,
    /// Length of the correlation window, control steps; frequencies are whole numbers of
    /// periods in it.
    pub window_steps: u32,
}

impl SweepSettings {
    /// 15 rad/s, 0.5 V, a 2 s window at the scenario's control rate.
    pub fn default_for(scenario: &Scenario) -> Self {
        Self {
            operating_rad_s: 15.0,
            amplitude_v: 0.5,
            window_steps: 2 * scenario.robot.control_rate_hz,
        }
    }
}

/// Cycles per window of the default measured sweep: about 4–600 rad/s at 1 kHz and a 2 s
/// window, log-spaced, denser where the crossovers are.
pub const SWEEP_CYCLES: [u32; 24] = [
    1, 2, 3, 5, 8, 12, 15, 18, 21, 25, 30, 35, 40, 45, 50, 56, 63, 70, 80, 90, 110, 130, 160, 190,
];

/// Measures the open loop of `scenario`'s robot in `load` and `motion` at Ω =
/// 2π·cycles/(window·T) for each of `cycles` (module doc). Returns (Ω rad/s, L) per
/// frequency, the left wheel's.
pub fn measure_open_loop(
    scenario: &Scenario,
    load: Load,
    motion: Motion,
    settings: SweepSettings,
    cycles: &[u32],
) -> Result<Vec<(f64, Complex)>, RunError> {
    let mut scenario = scenario.clone();
    scenario.plant.load = load;
    scenario.faults.clear();
    let period = 1.0 / f64::from(scenario.robot.control_rate_hz);
    let n = settings.window_steps.max(1);
    let sign = match motion {
        Motion::Straight => 1.0,
        Motion::Turning => -1.0,
    };
    let mut points = Vec::with_capacity(cycles.len());
    for &m in cycles {
        let omega = std::f64::consts::TAU * f64::from(m) / (f64::from(n) * period);
        let mut robot = crate::run::Robot::new(&scenario, LawKind::Tracking, &[])?;
        for _ in 0..50 {
            robot.step();
        }
        let sp = settings.operating_rad_s as f32;
        robot
            .supervisor
            .arm_locally(
                &mut robot.controller,
                ArmRequest {
                    mode: RunMode::HoldWheelSpeeds,
                    hold_speeds: Some(WheelSpeeds::new(sp, sp)),
                    initial_motion: None,
                    max_armed_steps: None,
                },
            )
            .map_err(|_| RunError::Argument {
                name: "scenario",
                rule: "must let the robot arm",
                value: 0.0,
            })?;
        // Settle at the operating speed, then let the injection's transient pass.
        let settle = (0.6 / period) as u32;
        let transient = (0.5 / period) as u32;
        for _ in 0..settle {
            robot.step();
        }
        let (mut v_sum, mut u_sum) = (Complex::default(), Complex::default());
        for k in 0..transient + n {
            let phase = omega * f64::from(k) * period;
            let d = settings.amplitude_v * phase.sin();
            robot.step_with_added_volts([d, sign * d]);
            if k < transient {
                continue;
            }
            let v = f64::from(robot.controller.telemetry().wheel_loop.volts.left_v);
            let plant = robot.hardware.plant();
            let u = plant.applied_duty()[0] * plant.supply_v();
            let basis = Complex::unit(-phase);
            v_sum = v_sum.add(basis.scale(v));
            u_sum = u_sum.add(basis.scale(u));
        }
        points.push((omega, v_sum.div(u_sum).scale(-1.0)));
    }
    Ok(points)
}

/// The aim: gain margin at least this factor (8 dB).
pub const GAIN_MARGIN_AIM: f64 = 2.5;
/// The aim: phase margin at least this, degrees.
pub const PHASE_MARGIN_AIM_DEG: f64 = 45.0;

/// A measured case beside its model, for [`table`].
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredCase {
    /// The case (motoring).
    pub case: LoadCase,
    /// Margins from the measured points.
    pub measured: Margins,
    /// The model's margins.
    pub model: Margins,
    /// Largest |measured/model| gain difference over the points, dB.
    pub max_gain_error_db: f64,
    /// Largest phase difference over the points, degrees.
    pub max_phase_error_deg: f64,
}

/// Measures the motoring cases that exist on this robot (ground straight and turning,
/// lifted) with `settings` over [`SWEEP_CYCLES`] and compares each with its model.
pub fn measure_cases(
    scenario: &Scenario,
    settings: SweepSettings,
) -> Result<Vec<MeasuredCase>, RunError> {
    LoadCase::ALL
        .iter()
        .filter(|c| c.flow == PowerFlow::Motoring)
        .map(|&case| {
            let model = case_model(scenario, case)?;
            let points =
                measure_open_loop(scenario, case.load, case.motion, settings, &SWEEP_CYCLES)?;
            let (mut gain_err, mut phase_err) = (0.0f64, 0.0f64);
            for (w, l) in &points {
                let expected = model.open_loop(*w);
                gain_err = gain_err.max((20.0 * (l.abs() / expected.abs()).log10()).abs());
                phase_err = phase_err.max(wrap_pi(l.arg() - expected.arg()).to_degrees().abs());
            }
            Ok(MeasuredCase {
                case,
                measured: Margins::from_response(&points),
                model: model.margins(),
                max_gain_error_db: gain_err,
                max_phase_error_deg: phase_err,
            })
        })
        .collect()
}

/// `value` with `decimals`, or `∞`/`—` when absent.
fn opt(value: Option<f64>, decimals: usize, absent: &str) -> String {
    value.map_or(absent.to_string(), |v| format!("{v:.decimals$}"))
}

/// The margins of every case as a text table, with the aim.
pub fn table(cases: &[CaseMargins]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<26} {:>9} {:>7} {:>6} {:>6} {:>10} {:>6} {:>9} {:>8} {:>7}",
        "load case",
        "K rad/s/V",
        "τ ms",
        "GM",
        "GM dB",
        "ω180 rad/s",
        "PM °",
        "ωc rad/s",
        "delay ms",
        "stable"
    );
    for c in cases {
        let m = &c.margins;
        let _ = writeln!(
            out,
            "{:<26} {:>9.2} {:>7.1} {:>6} {:>6} {:>10} {:>6} {:>9} {:>8} {:>7}",
            c.case.name(),
            c.model.plant.gain_rad_s_per_v,
            c.model.plant.time_constant_s * 1e3,
            opt(m.gain_margin, 2, "∞"),
            opt(m.gain_margin_db(), 1, "∞"),
            opt(m.phase_crossover_rad_s, 0, "—"),
            opt(m.phase_margin_deg, 1, "—"),
            opt(m.gain_crossover_rad_s, 0, "—"),
            opt(m.delay_margin_s().map(|s| s * 1e3), 1, "—"),
            if c.stable { "yes" } else { "NO" }
        );
    }
    out
}

/// True when `margins` meet the aim (GM ≥ 2.5, PM ≥ 45°; an infinite GM meets it).
pub fn meets_aim(margins: &Margins) -> bool {
    margins.gain_margin.is_none_or(|g| g >= GAIN_MARGIN_AIM)
        && margins
            .phase_margin_deg
            .is_some_and(|p| p >= PHASE_MARGIN_AIM_DEG)
}

/// The measured cases beside their models, as a text table.
pub fn measured_table(cases: &[MeasuredCase], settings: SweepSettings) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "frequency sweep on the simulated robot: hold {} rad/s, inject ±{} V at the plant input, \
{} frequencies, {} steps each",
        settings.operating_rad_s,
        settings.amplitude_v,
        SWEEP_CYCLES.len(),
        settings.window_steps
    );
    let _ = writeln!(
        out,
        "{:<18} {:>13} {:>13} {:>15} {:>15} {:>10} {:>9}",
        "load case",
        "GM model",
        "GM measured",
        "PM model °",
        "PM measured °",
        "max |ΔL| dB",
        "max Δφ °"
    );
    for c in cases {
        let _ = writeln!(
            out,
            "{:<18} {:>13} {:>13} {:>15} {:>15} {:>10.2} {:>9.1}",
            c.case.name(),
            opt(c.model.gain_margin, 2, "∞"),
            opt(c.measured.gain_margin, 2, "∞"),
            opt(c.model.phase_margin_deg, 1, "—"),
            opt(c.measured.phase_margin_deg, 1, "—"),
            c.max_gain_error_db,
            c.max_phase_error_deg
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::params::RobotConfig;

    fn reference_plant() -> PlantParams {
        plant_params(&Scenario::load("paper-circle").unwrap())
    }

    #[test]
    fn the_reference_wheel_linearises_to_the_stated_time_constants() {
        let p = reference_plant();
        let straight = WheelPlant::linearise(&p, Motion::Straight, PowerFlow::Motoring).unwrap();
        let turning = WheelPlant::linearise(&p, Motion::Turning, PowerFlow::Motoring).unwrap();
        let mut lifted_params = p;
        lifted_params.load = Load::Lifted;
        let lifted =
            WheelPlant::linearise(&lifted_params, Motion::Straight, PowerFlow::Motoring).unwrap();
        assert!(
            (straight.time_constant_s - 0.0891).abs() < 5e-4,
            "{straight:?}"
        );
        assert!(
            (turning.time_constant_s - 0.066).abs() < 1e-3,
            "{turning:?}"
        );
        assert!((lifted.time_constant_s - 0.0262).abs() < 5e-4, "{lifted:?}");
        // K = 1/k_V: the same in every load case while motoring.
        assert!((straight.gain_rad_s_per_v - 6.349).abs() < 1e-3);
        assert_eq!(straight.gain_rad_s_per_v, lifted.gain_rad_s_per_v);
        // Back-driven, the gearbox multiplies the torque per volt by 1/η² = 1.5625 and the
        // electrical damping too: τ shorter, K smaller (viscous friction is not scaled).
        let braking = WheelPlant::linearise(&p, Motion::Straight, PowerFlow::BackDriven).unwrap();
        assert!(braking.time_constant_s < 0.7 * straight.time_constant_s);
        assert!(WheelPlant::linearise(&p, Motion::Straight, PowerFlow::Coasting).is_err());
    }

    #[test]
    fn the_plant_model_has_the_plant_gain_at_dc_and_the_window_zero() {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let plant = WheelPlant {
            gain_rad_s_per_v: 6.0,
            time_constant_s: 0.08,
        };
        let model = LoopModel::new(plant, &params, 0);
        let dc = model.plant_response(1e-6);
        assert!((dc.re - 6.0).abs() < 1e-4 && dc.im.abs() < 1e-3, "{dc:?}");
        // The 20 ms window averages a 50 Hz sine to nothing.
        let notch = model.plant_response(std::f64::consts::TAU * 50.0);
        assert!(notch.abs() < 1e-6, "{notch:?}");
        // Well below the window's zero the estimate lags by about W T / 2 + the plant.
        let w = 10.0;
        let lag = model.plant_response(w).arg();
        let expected = -(w * 0.08f64).atan() - w * (0.010 + 0.0005);
        assert!((lag - expected).abs() < 0.01, "{lag} vs {expected}");
    }

    /// A textbook check of the margin finder: K/(s(s+1)²)-like loops are covered by the
    /// model tests; here L = 2 e^(−jω) / (jω) style points, analytic crossovers.
    #[test]
    fn margins_are_found_where_the_response_crosses() {
        // L(jω) = k e^(−jωθ)/(jω): |L| = 1 at ω = k, phase −90° − ωθ.
        let (k, theta) = (2.0, 0.25);
        let points: Vec<(f64, Complex)> = (1..5000)
            .map(|i| {
                let w = i as f64 * 0.002;
                (
                    w,
                    Complex::unit(-std::f64::consts::FRAC_PI_2 - w * theta).scale(k / w),
                )
            })
            .collect();
        let m = Margins::from_response(&points);
        let pm = 90.0 - (k * theta).to_degrees();
        assert!((m.phase_margin_deg.unwrap() - pm).abs() < 0.05, "{m:?}");
        assert!((m.gain_crossover_rad_s.unwrap() - k).abs() < 1e-3);
        // Phase −180° at ω = π/(2θ): GM = ω/k.
        let w180 = std::f64::consts::PI / (2.0 * theta);
        assert!(
            (m.phase_crossover_rad_s.unwrap() - w180).abs() < 1e-3,
            "{m:?}"
        );
        assert!((m.gain_margin.unwrap() - w180 / k).abs() < 1e-3);
        assert!((m.delay_margin_s().unwrap() - pm.to_radians() / k).abs() < 1e-3);
    }

    #[test]
    fn too_much_gain_is_unstable_and_has_no_gain_margin_left() {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let plant = WheelPlant {
            gain_rad_s_per_v: 6.35,
            time_constant_s: 0.089,
        };
        let good = LoopModel::new(plant, &params, 0);
        assert!(good.is_stable());
        let gm = good.margins().gain_margin.unwrap();
        assert!(gm > 1.0);
        // Scale the PID by a bit more than its gain margin: unstable.
        let mut bad = good;
        let scale = (gm * 1.1) as f32;
        bad.gains.kp *= scale;
        bad.gains.ki *= scale;
        assert!(!bad.is_stable());
        assert!(bad.margins().gain_margin.unwrap() < 1.0);
        // And a bit less: still stable.
        let mut fine = good;
        let scale = (gm * 0.9) as f32;
        fine.gains.kp *= scale;
        fine.gains.ki *= scale;
        assert!(fine.is_stable());
    }

    #[test]
    fn the_measured_sweep_agrees_with_the_model_near_crossover() {
        let scenario = Scenario::load("paper-circle").unwrap();
        let settings = SweepSettings::default_for(&scenario);
        let case = LoadCase::ALL[0];
        let model = case_model(&scenario, case).unwrap();
        let measured = measure_open_loop(
            &scenario,
            Load::Ground,
            Motion::Straight,
            settings,
            &[20, 40],
        )
        .unwrap();
        for (w, l) in measured {
            let expected = model.open_loop(w);
            let gain_db = 20.0 * (l.abs() / expected.abs()).log10();
            let phase = wrap_pi(l.arg() - expected.arg()).to_degrees();
            assert!(gain_db.abs() < 1.0, "{w} rad/s: {gain_db} dB");
            assert!(phase.abs() < 5.0, "{w} rad/s: {phase}°");
        }
    }
}
