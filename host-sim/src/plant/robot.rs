//! The robot's body: two driven wheels coupled through the chassis, slip, and the true pose.
//!
//! ## Dynamics
//!
//! With no slip, the chassis' forward speed and yaw rate follow from the wheel speeds
//! (eq. (4) of the paper). Writing the power balance of wheels plus chassis (mass m, yaw
//! inertia I about the wheel axle's midpoint, wheel-side inertia J_w per wheel) gives a
//! symmetric 2 × 2 inertia matrix on (ω_l, ω_r):
//!
//! ```text
//! ⎡a b⎤ ⎡ω̇_l⎤   ⎡τ_l⎤      a = J_w + m R²/4 + I R²/L²
//! ⎣b a⎦ ⎣ω̇_r⎦ = ⎣τ_r⎦,     b = m R²/4 − I R²/L²
//! ```
//!
//! with τ the net wheel torques of [`super::motor::WheelDrive`] and J_w = wheel inertia +
//! rotor inertia × N². So driving one wheel drags the other (b ≠ 0), forward motion sees
//! a + b and turning a − b, as on a real chassis. R is the mean of the two true wheel radii.
//!
//! ## Integration
//!
//! The state (ω_l, ω_r, φ_l, φ_r) — wheel speeds and wheel angles — is advanced with the
//! classic fourth-order Runge–Kutta method at the plant rate (≥ 10 × the control rate),
//! the armature voltages held constant over the control period (zero-order hold, as a PWM
//! timer does). When a wheel speed crosses zero inside a step it is stopped at zero, where
//! static friction then decides whether it breaks away, after Karnopp's stick–slip model.
//! Simplification: a wheel at rest compares static friction with its own drive torque
//! only; the other wheel's pull through the chassis inertia is not included, so a stuck
//! wheel can creep slowly when the other wheel is driven.
//!
//! ## True pose and slip
//!
//! Each plant step the wheels turn by Δφ_l, Δφ_r (from RK4). Wheel i moves its contact
//! point by (1 − s_i)·R_i·Δφ_i over the ground, s_i being a longitudinal slip ratio
//! (0 = pure rolling). The true pose moves along the arc those two distances define on the
//! true track width L — exact for a constant curvature over the 0.1 ms step. The heading's
//! cosine and sine are advanced by a small-angle rotation each step and re-derived from
//! θ once per control period, so there is no trigonometry in the inner loop.
//!
//! Slip does not change the inertia seen by the motors (a slipping wheel on a slippery
//! floor would see less of the chassis): a small, stated approximation.

use super::motor::{DriverParams, MotorParams, WheelDrive};

/// Chassis mass properties, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyParams {
    /// Total mass m, kg.
    pub mass_kg: f64,
    /// Yaw inertia I about the vertical axis through the wheel axle's midpoint, kg·m².
    pub yaw_inertia_kg_m2: f64,
    /// Inertia of one wheel (with hub) about its axle, kg·m².
    pub wheel_inertia_kg_m2: f64,
}

impl BodyParams {
    /// A 0.5 kg robot with a 60 mm radius of gyration (I = 1.8e-3 kg·m²) and 20 g wheels
    /// (2e-5 kg·m² each).
    pub const DEFAULT: BodyParams = BodyParams {
        mass_kg: 0.5,
        yaw_inertia_kg_m2: 1.8e-3,
        wheel_inertia_kg_m2: 2.0e-5,
    };
}

impl Default for BodyParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The robot's true geometry (which may differ from what the controller believes), m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueGeometry {
    /// True radius of the left wheel, m.
    pub wheel_radius_left_m: f64,
    /// True radius of the right wheel, m.
    pub wheel_radius_right_m: f64,
    /// True track width (distance between the contact points), m.
    pub track_width_m: f64,
}

/// Everything that defines the simulated robot, SI units. See [`super`] for defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantParams {
    /// Motor and gearbox of each wheel (both wheels identical).
    pub motor: MotorParams,
    /// H-bridge and supply.
    pub driver: DriverParams,
    /// Gearbox ratio N, motor turns per wheel turn.
    pub gear_ratio: f64,
    /// Chassis mass properties.
    pub body: BodyParams,
    /// True wheel radii and track width.
    pub geometry: TrueGeometry,
    /// Longitudinal slip ratio of each wheel [left, right], in [0, 1): the contact point
    /// moves (1 − s)·R·Δφ for a wheel rotation Δφ.
    pub slip: [f64; 2],
}

/// The true pose, world frame: position in m, heading in rad (counter-clockwise from x,
/// wrapped to (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TruePose {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// θ, rad, in (−π, π].
    pub theta_rad: f64,
}

/// Wrap an angle to (−π, π], rad.
pub fn wrap_angle(a: f64) -> f64 {
    use core::f64::consts::{PI, TAU};
    let w = a - TAU * ((a + PI) / TAU).floor();
    // w is in [−π, π); map −π to π.
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

/// The simulated robot: parameters, state, and the RK4 integrator.
#[derive(Clone, Debug)]
pub struct Plant {
    params: PlantParams,
    drive: WheelDrive,
    /// Inverse inertia matrix entries: M⁻¹ = [[p, q], [q, p]], 1/(kg·m²).
    inv_p: f64,
    inv_q: f64,
    /// RK4 in closed form for the affine case, for the last step size used.
    propagator: Propagator,
    /// Wheel speeds [left, right], rad/s.
    speed: [f64; 2],
    /// Wheel angles [left, right], rad (what the encoders see).
    angle: [f64; 2],
    /// Last armature voltages [left, right], V.
    volts: [f64; 2],
    /// Last applied duties [left, right], after quantisation and dead-band.
    applied_duty: [f64; 2],
    x_m: f64,
    y_m: f64,
    /// Unwrapped heading, rad.
    theta_rad: f64,
    /// (cos θ, sin θ), advanced by small rotations and renormalised once per
    /// [`Plant::advance`] call, so the inner loop has no trigonometry.
    heading: [f64; 2],
    /// Ground distance per wheel radian [left, right]: (1 − s_i)·R_i, m/rad.
    ground_per_rad: [f64; 2],
}

/// Why [`Plant::new`] rejected parameters (the scenario layer validates first, with the
/// TOML key; this is the last line of defence).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlantError {
    /// The inertia matrix is not positive definite (mass or inertias ≤ 0).
    #[error("the chassis inertia matrix is not positive definite (check mass and inertias)")]
    SingularInertia,
    /// A parameter is not finite or outside its physical range.
    #[error("plant parameter {0} is out of range")]
    OutOfRange(&'static str),
}

impl Plant {
    /// A robot with `params`, at rest at the origin.
    pub fn new(params: PlantParams) -> Result<Self, PlantError> {
        let m = &params.motor;
        let checks = [
            ("motor.resistance_ohm", m.resistance_ohm > 0.0),
            (
                "motor.torque_constant_nm_per_a",
                m.torque_constant_nm_per_a > 0.0,
            ),
            ("motor.back_emf_v_s_per_rad", m.back_emf_v_s_per_rad > 0.0),
            ("motor.rotor_inertia_kg_m2", m.rotor_inertia_kg_m2 >= 0.0),
            (
                "motor.gear_efficiency",
                m.gear_efficiency > 0.0 && m.gear_efficiency <= 1.0,
            ),
            (
                "motor.viscous_friction_nm_s_per_rad",
                m.viscous_friction_nm_s_per_rad >= 0.0,
            ),
            ("motor.coulomb_friction_nm", m.coulomb_friction_nm >= 0.0),
            ("gear_ratio", params.gear_ratio > 0.0),
            ("driver.supply_v", params.driver.supply_v > 0.0),
            (
                "driver.dead_band_duty",
                (0.0..1.0).contains(&params.driver.dead_band_duty),
            ),
            (
                "geometry.wheel_radius_left_m",
                params.geometry.wheel_radius_left_m > 0.0,
            ),
            (
                "geometry.wheel_radius_right_m",
                params.geometry.wheel_radius_right_m > 0.0,
            ),
            (
                "geometry.track_width_m",
                params.geometry.track_width_m > 0.0,
            ),
            ("slip", params.slip.iter().all(|s| (0.0..1.0).contains(s))),
            ("body.mass_kg", params.body.mass_kg >= 0.0),
            (
                "body.yaw_inertia_kg_m2",
                params.body.yaw_inertia_kg_m2 >= 0.0,
            ),
            (
                "body.wheel_inertia_kg_m2",
                params.body.wheel_inertia_kg_m2 >= 0.0,
            ),
        ];
        // `x > 0.0` is false for NaN, so the checks above also reject NaN.
        if let Some((name, _)) = checks.iter().find(|(_, ok)| !ok) {
            return Err(PlantError::OutOfRange(name));
        }
        let g = &params.geometry;
        let r = 0.5 * (g.wheel_radius_left_m + g.wheel_radius_right_m);
        let j_w = params.body.wheel_inertia_kg_m2
            + params.motor.rotor_inertia_kg_m2 * params.gear_ratio * params.gear_ratio;
        let translational = params.body.mass_kg * r * r / 4.0;
        let rotational =
            params.body.yaw_inertia_kg_m2 * r * r / (g.track_width_m * g.track_width_m);
        let a = j_w + translational + rotational;
        let b = translational - rotational;
        let det = a * a - b * b;
        if !(a > 0.0 && det > 0.0 && det.is_finite()) {
            return Err(PlantError::SingularInertia);
        }
        let ground_per_rad = [
            (1.0 - params.slip[0]) * g.wheel_radius_left_m,
            (1.0 - params.slip[1]) * g.wheel_radius_right_m,
        ];
        let drive = WheelDrive::new(&params.motor, params.gear_ratio);
        let (inv_p, inv_q) = (a / det, -b / det);
        Ok(Self {
            drive,
            inv_p,
            inv_q,
            propagator: Propagator::new(inv_p, inv_q, drive.damping_nm_s_per_rad, 0.0),
            params,
            speed: [0.0; 2],
            angle: [0.0; 2],
            volts: [0.0; 2],
            applied_duty: [0.0; 2],
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: 0.0,
            heading: [1.0, 0.0],
            ground_per_rad,
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// The motor folded into wheel-shaft quantities.
    pub fn drive(&self) -> &WheelDrive {
        &self.drive
    }

    /// Places the robot at `pose` (world frame) with wheel speeds `speeds` [left, right]
    /// (rad/s). Wheel angles restart at 0.
    pub fn reset(&mut self, pose: TruePose, speeds: [f64; 2]) {
        self.x_m = pose.x_m;
        self.y_m = pose.y_m;
        self.theta_rad = pose.theta_rad;
        self.heading = [pose.theta_rad.cos(), pose.theta_rad.sin()];
        self.speed = speeds;
        self.angle = [0.0; 2];
    }

    /// Wheel speeds [left, right] that drive the *true* robot (true radii, track width
    /// and slip) at forward speed `v_m_s` (m/s) and yaw rate `omega_rad_s` (rad/s).
    pub fn wheel_speeds_for(&self, v_m_s: f64, omega_rad_s: f64) -> [f64; 2] {
        let half = 0.5 * omega_rad_s * self.params.geometry.track_width_m;
        [
            (v_m_s - half) / self.ground_per_rad[0],
            (v_m_s + half) / self.ground_per_rad[1],
        ]
    }

    /// Sets both duties (any f32; see [`DriverParams::applied_duty`]) for the following
    /// [`Plant::advance`] calls.
    pub fn set_duty(&mut self, left: f32, right: f32) {
        let driver = &self.params.driver;
        self.applied_duty = [driver.applied_duty(left), driver.applied_duty(right)];
        self.volts = [
            driver.voltage_v(self.applied_duty[0]),
            driver.voltage_v(self.applied_duty[1]),
        ];
    }

    /// Wheel accelerations [left, right], rad/s², at wheel speeds `w`.
    #[inline]
    fn accel(&self, w: [f64; 2]) -> [f64; 2] {
        let tl = self.drive.wheel_torque_nm(self.volts[0], w[0]);
        let tr = self.drive.wheel_torque_nm(self.volts[1], w[1]);
        [
            self.inv_p * tl + self.inv_q * tr,
            self.inv_q * tl + self.inv_p * tr,
        ]
    }

    /// One classic RK4 step of `dt_s` from wheel speeds `w0`, for the speeds and angles, evaluating
    /// [`WheelDrive::wheel_torque_nm`] at every stage, with Karnopp's zero crossing.
    /// Returns the new speeds and the angle increments.
    fn rk4_step(&self, w0: [f64; 2], dt_s: f64) -> ([f64; 2], [f64; 2]) {
        let k1 = self.accel(w0);
        let w1 = [w0[0] + 0.5 * dt_s * k1[0], w0[1] + 0.5 * dt_s * k1[1]];
        let k2 = self.accel(w1);
        let w2 = [w0[0] + 0.5 * dt_s * k2[0], w0[1] + 0.5 * dt_s * k2[1]];
        let k3 = self.accel(w2);
        let w3 = [w0[0] + dt_s * k3[0], w0[1] + dt_s * k3[1]];
        let k4 = self.accel(w3);
        let mut next = [0.0; 2];
        let mut dphi = [0.0; 2];
        for i in 0..2 {
            // φ̇ = ω: the RK4 increment of φ uses the stage speeds.
            dphi[i] = dt_s / 6.0 * (w0[i] + 2.0 * w1[i] + 2.0 * w2[i] + w3[i]);
            next[i] = w0[i] + dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            // Karnopp: a speed crossing zero stops there; static friction decides next.
            if next[i] * w0[i] < 0.0 {
                next[i] = 0.0;
            }
        }
        (next, dphi)
    }

    /// The constant terms (S b, T b) of the closed-form RK4 step ([`Propagator`]) for the
    /// present voltages and wheel directions `signs` (±1 each): b = M⁻¹ (k_V · V − τ_c ·
    /// sgn ω) is the speed-independent part of ω̇, constant while neither wheel reverses.
    fn forcing(&self, signs: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let c = self.drive.coulomb_nm;
        let tl = self.drive.torque_per_volt * self.volts[0] - c * signs[0];
        let tr = self.drive.torque_per_volt * self.volts[1] - c * signs[1];
        let b = [
            self.inv_p * tl + self.inv_q * tr,
            self.inv_q * tl + self.inv_p * tr,
        ];
        (
            mat_vec(&self.propagator.s, b),
            mat_vec(&self.propagator.t, b),
        )
    }

    /// Advances `steps` RK4 steps of `dt_s` seconds each with the duties last set.
    pub fn advance(&mut self, dt_s: f64, steps: u32) {
        if self.propagator.dt_s != dt_s {
            self.propagator = Propagator::new(
                self.inv_p,
                self.inv_q,
                self.drive.damping_nm_s_per_rad,
                dt_s,
            );
        }
        // The state lives in locals for the loop (registers, not memory round trips).
        let [mut c, mut s] = self.heading;
        let (mut x, mut y, mut theta) = (self.x_m, self.y_m, self.theta_rad);
        let (mut w, mut angle) = (self.speed, self.angle);
        let inv_l = 1.0 / self.params.geometry.track_width_m;
        // The closed-form RK4 step (see `Propagator`) while both wheels turn and keep
        // their direction; stage by stage otherwise (static friction, reversal).
        let mut signs = [w[0].signum(), w[1].signum()];
        let (mut sb, mut tb) = self.forcing(signs);
        for _ in 0..steps {
            let mut closed_form = None;
            if w[0] != 0.0 && w[1] != 0.0 {
                if w[0].signum() != signs[0] || w[1].signum() != signs[1] {
                    signs = [w[0].signum(), w[1].signum()];
                    (sb, tb) = self.forcing(signs);
                }
                let (next, dphi) = self.propagator.step(w, sb, tb);
                if next[0] * w[0] > 0.0 && next[1] * w[1] > 0.0 {
                    closed_form = Some((next, dphi));
                }
            }
            let (next, dphi) = match closed_form {
                Some(step) => step,
                None => self.rk4_step(w, dt_s),
            };
            w = next;
            angle[0] += dphi[0];
            angle[1] += dphi[1];
            // Ground distances and the arc they define on the true track.
            let dl = self.ground_per_rad[0] * dphi[0];
            let dr = self.ground_per_rad[1] * dphi[1];
            let ds = 0.5 * (dl + dr);
            let dth = (dr - dl) * inv_l;
            let half = 0.5 * dth;
            let (sin_h, cos_h) = small_sin_cos(half);
            // Chord length ds·sinc(Δθ/2) along heading θ + Δθ/2.
            let chord = ds * sin_h_over_h(half);
            let (cm, sm) = (c * cos_h - s * sin_h, s * cos_h + c * sin_h);
            x += chord * cm;
            y += chord * sm;
            // Rotate (c, s) by Δθ = two half-angle rotations.
            c = cm * cos_h - sm * sin_h;
            s = sm * cos_h + cm * sin_h;
            theta += dth;
        }
        self.speed = w;
        self.angle = angle;
        self.x_m = x;
        self.y_m = y;
        self.theta_rad = theta;
        // One Newton step of 1/√(c² + s²) removes the rounding drift of the rotations.
        let norm = 0.5 * (3.0 - (c * c + s * s));
        self.heading = [c * norm, s * norm];
        self.theta_rad = wrap_angle(self.theta_rad);
    }

    /// True pose, world frame.
    pub fn pose(&self) -> TruePose {
        TruePose {
            x_m: self.x_m,
            y_m: self.y_m,
            theta_rad: wrap_angle(self.theta_rad),
        }
    }

    /// True wheel speeds [left, right], rad/s.
    pub fn wheel_speeds(&self) -> [f64; 2] {
        self.speed
    }

    /// Wheel angles [left, right] since the last reset, rad.
    pub fn wheel_angles(&self) -> [f64; 2] {
        self.angle
    }

    /// Duties the bridge applied in the last period [left, right] (quantised, dead-band).
    pub fn applied_duty(&self) -> [f64; 2] {
        self.applied_duty
    }

    /// Armature currents [left, right] at the present state, A.
    pub fn currents_a(&self) -> [f64; 2] {
        [
            self.drive.current_a(self.volts[0], self.speed[0]),
            self.drive.current_a(self.volts[1], self.speed[1]),
        ]
    }

    /// True body velocity (forward m/s, yaw rad/s) from the wheel speeds and slip.
    pub fn body_velocity(&self) -> (f64, f64) {
        let vl = self.ground_per_rad[0] * self.speed[0];
        let vr = self.ground_per_rad[1] * self.speed[1];
        (
            0.5 * (vl + vr),
            (vr - vl) / self.params.geometry.track_width_m,
        )
    }
}

/// A 2 × 2 matrix, row-major.
type Mat2 = [[f64; 2]; 2];

fn mat_mul(a: &Mat2, b: &Mat2) -> Mat2 {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

fn mat_lin(terms: &[(f64, &Mat2)]) -> Mat2 {
    let mut out = [[0.0; 2]; 2];
    for (k, m) in terms {
        for i in 0..2 {
            for j in 0..2 {
                out[i][j] += k * m[i][j];
            }
        }
    }
    out
}

#[inline]
fn mat_vec(m: &Mat2, v: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

/// Classic RK4 applied to the affine system ω̇ = Aω + b (b constant over the step),
/// φ̇ = ω, written in closed form. With z = Aω + b (= k₁), the four stages give
///
/// - ω⁺ = ω + S z,  S = h (I + hA/2 + (hA)²/6 + (hA)³/24),
/// - Δφ = h ω + T z, T = (h²/6) (3I + hA + (hA)²/4),
///
/// which is the same arithmetic as four stage evaluations, collapsed into 2 × 2 matrices
/// computed once per step size. It is what [`Plant::rk4_step`] computes whenever neither
/// wheel is at rest or reverses within the step (the Coulomb term is then constant);
/// `plant::robot::tests::closed_form_rk4_equals_stage_by_stage_rk4` checks it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Propagator {
    /// Step size h, s (0 before the first use).
    dt_s: f64,
    /// I + S A: ω⁺ = Pω ω + S b.
    p_w: Mat2,
    s: Mat2,
    /// h I + T A: Δφ = Qω ω + T b.
    q_w: Mat2,
    t: Mat2,
}

impl Propagator {
    /// For A = −M⁻¹ · damping (M⁻¹ = [[p, q], [q, p]]) and step `h`.
    fn new(inv_p: f64, inv_q: f64, damping: f64, h: f64) -> Self {
        let i: Mat2 = [[1.0, 0.0], [0.0, 1.0]];
        let ha: Mat2 = [
            [-h * damping * inv_p, -h * damping * inv_q],
            [-h * damping * inv_q, -h * damping * inv_p],
        ];
        let ha2 = mat_mul(&ha, &ha);
        let ha3 = mat_mul(&ha2, &ha);
        let s = mat_lin(&[(h, &i), (h / 2.0, &ha), (h / 6.0, &ha2), (h / 24.0, &ha3)]);
        let t = mat_lin(&[(h * h / 2.0, &i), (h * h / 6.0, &ha), (h * h / 24.0, &ha2)]);
        // S A = S (hA) / h, T A likewise (h = 0 gives the identity and zeros).
        let (sa, ta) = if h > 0.0 {
            let sa = mat_mul(&s, &ha);
            let ta = mat_mul(&t, &ha);
            (mat_lin(&[(1.0 / h, &sa)]), mat_lin(&[(1.0 / h, &ta)]))
        } else {
            ([[0.0; 2]; 2], [[0.0; 2]; 2])
        };
        Self {
            dt_s: h,
            p_w: mat_lin(&[(1.0, &i), (1.0, &sa)]),
            s,
            q_w: mat_lin(&[(h, &i), (1.0, &ta)]),
            t,
        }
    }

    /// (ω⁺, Δφ) from ω and the forcing terms S b, T b.
    #[inline]
    fn step(&self, w: [f64; 2], sb: [f64; 2], tb: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let pw = mat_vec(&self.p_w, w);
        let qw = mat_vec(&self.q_w, w);
        (
            [pw[0] + sb[0], pw[1] + sb[1]],
            [qw[0] + tb[0], qw[1] + tb[1]],
        )
    }
}

/// (sin a, cos a) for the tiny angles of one plant step (Taylor to a⁵ / a⁴: error < 1e-16
/// for |a| < 2e-3), falling back to the library for larger ones. Constants are
/// multiplied, not divided: a division by 6 is not exact, so the compiler keeps it a
/// (slow) division.
#[inline]
fn small_sin_cos(a: f64) -> (f64, f64) {
    let z = a * a;
    if z < 4e-6 {
        (
            a * (1.0 - z * (1.0 / 6.0) * (1.0 - z * (1.0 / 20.0))),
            1.0 - z * 0.5 * (1.0 - z * (1.0 / 12.0)),
        )
    } else {
        a.sin_cos()
    }
}

/// sin(a)/a, with the series near 0.
#[inline]
fn sin_h_over_h(a: f64) -> f64 {
    let z = a * a;
    if z < 4e-6 {
        1.0 - z * (1.0 / 6.0) * (1.0 - z * (1.0 / 20.0))
    } else {
        a.sin() / a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn params() -> PlantParams {
        PlantParams {
            motor: MotorParams::DEFAULT,
            driver: DriverParams::DEFAULT,
            gear_ratio: 30.0,
            body: BodyParams::DEFAULT,
            geometry: TrueGeometry {
                wheel_radius_left_m: 0.0325,
                wheel_radius_right_m: 0.0325,
                track_width_m: 0.15,
            },
            slip: [0.0; 2],
        }
    }

    #[test]
    fn full_duty_reaches_the_no_load_speed() {
        let mut p = Plant::new(params()).unwrap();
        p.set_duty(1.0, 1.0);
        for _ in 0..2000 {
            p.advance(1e-4, 10);
        }
        let expected = p.drive().steady_speed_rad_s(6.0);
        let w = p.wheel_speeds();
        assert!((w[0] - expected).abs() < 1e-6 && (w[1] - expected).abs() < 1e-6);
        // Straight line: no yaw, moved along x.
        let pose = p.pose();
        assert!(pose.theta_rad.abs() < 1e-12 && pose.y_m.abs() < 1e-12 && pose.x_m > 1.0);
    }

    #[test]
    fn rk4_matches_the_first_order_solution() {
        // Both wheels equal: ω(t) = ω∞ (1 − e^{−t/τ}) with τ = (a + b) / damping.
        let pp = params();
        let mut p = Plant::new(pp).unwrap();
        p.set_duty(0.5, 0.5);
        p.advance(1e-4, 500); // 50 ms
        let d = WheelDrive::new(&pp.motor, 30.0);
        let r = 0.0325;
        let j = pp.body.wheel_inertia_kg_m2
            + pp.motor.rotor_inertia_kg_m2 * 900.0
            + pp.body.mass_kg * r * r / 2.0;
        let tau = j / d.damping_nm_s_per_rad;
        let w_inf = d.steady_speed_rad_s(3.0);
        let exact = w_inf * (1.0 - (-0.05 / tau).exp());
        assert!(
            (p.wheel_speeds()[0] - exact).abs() < 1e-9,
            "{:?} {exact}",
            p.wheel_speeds()
        );
    }

    #[test]
    fn spinning_on_the_spot_turns_by_the_wheel_arc() {
        let mut p = Plant::new(params()).unwrap();
        p.reset(TruePose::default(), [-10.0, 10.0]);
        p.set_duty(0.0, 0.0);
        p.advance(1e-4, 1);
        // Free-wheeling spin: position stays at the origin, heading follows the wheels.
        let [al, ar] = p.wheel_angles();
        let pose = p.pose();
        assert!(pose.x_m.abs() < 1e-12 && pose.y_m.abs() < 1e-12);
        assert!((pose.theta_rad - 0.0325 * (ar - al) / 0.15).abs() < 1e-12);
    }

    #[test]
    fn constant_arc_closes_a_circle() {
        // No Coulomb friction, a fine PWM and no dead-band: the steady voltage for each
        // wheel's speed holds it exactly, so the robot drives a circle of radius v/ω and
        // comes back to its start after 2π/ω.
        let mut pp = params();
        pp.motor.coulomb_friction_nm = 0.0;
        pp.driver.pwm_levels = u32::MAX;
        pp.driver.dead_band_duty = 0.0;
        let mut p = Plant::new(pp).unwrap();
        let speeds = p.wheel_speeds_for(0.25, 0.2);
        p.reset(TruePose::default(), speeds);
        let d = *p.drive();
        let duty = |w: f64| (w * d.damping_nm_s_per_rad / d.torque_per_volt / 6.0) as f32;
        p.set_duty(duty(speeds[0]), duty(speeds[1]));
        let period_steps = (2.0 * PI / 0.2 / 1e-4).round() as u32;
        p.advance(1e-4, period_steps);
        let pose = p.pose();
        // f32 duty resolution limits the speed balance to ~1e-7 relative.
        assert!(pose.x_m.abs() < 2e-3 && pose.y_m.abs() < 2e-3, "{pose:?}");
    }

    #[test]
    fn closed_form_rk4_equals_stage_by_stage_rk4() {
        let mut p = Plant::new(params()).unwrap();
        p.propagator = Propagator::new(p.inv_p, p.inv_q, p.drive.damping_nm_s_per_rad, 1e-4);
        let mut rng = crate::rng::Rng::new(5);
        for _ in 0..1000 {
            let w = [rng.symmetric(40.0), rng.symmetric(40.0)];
            p.set_duty(rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32);
            let (w_ref, phi_ref) = p.rk4_step(w, 1e-4);
            let (sb, tb) = p.forcing([w[0].signum(), w[1].signum()]);
            let (w_fast, phi_fast) = p.propagator.step(w, sb, tb);
            // Where neither wheel reverses, the two are the same arithmetic.
            if w_ref[0] * w[0] > 0.0 && w_ref[1] * w[1] > 0.0 {
                for i in 0..2 {
                    assert!((w_fast[i] - w_ref[i]).abs() < 1e-11, "{w_fast:?} {w_ref:?}");
                    assert!(
                        (phi_fast[i] - phi_ref[i]).abs() < 1e-15,
                        "{phi_fast:?} {phi_ref:?}"
                    );
                }
            }
        }
        // At rest, stage by stage (static friction): a small duty does not move the wheel.
        p.reset(TruePose::default(), [0.0, 0.0]);
        p.set_duty(0.03, 0.03);
        p.advance(1e-4, 10);
        assert_eq!(p.wheel_speeds(), [0.0, 0.0]);
    }

    #[test]
    fn wrap_angle_range() {
        for a in [-10.0, -PI, 0.0, PI, 3.5, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            let turns = (a - w) / (2.0 * PI);
            assert!((turns - turns.round()).abs() < 1e-9, "{a} -> {w}");
        }
    }
}
