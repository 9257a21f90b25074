//! The robot's body: two driven wheels coupled through the chassis, slip, faults and the
//! true pose.
//!
//! ## Dynamics
//!
//! With no slip, the chassis' forward speed v and yaw rate Ω follow from the wheel speeds
//! (eq. (4) of the paper): v = R (ω_l + ω_r)/2, Ω = R (ω_r − ω_l)/L. The chassis has mass
//! m, its centre of mass a distance d ahead of the wheel axle on the centre line
//! ([`BodyParams::com_ahead_of_axle_m`], default 0), and yaw inertia I **about the vertical
//! axis through the axle's midpoint** (I = I_com + m d²); each wheel side adds J_w = wheel
//! inertia + rotor inertia × N². Its kinetic energy, ½ m v² + ½ I Ω² + ½ J_w (ω_l² + ω_r²),
//! gives a symmetric 2 × 2 inertia matrix on (ω_l, ω_r):
//!
//! ```text
//! ⎡a b⎤ ⎡ω̇_l⎤   ⎡τ_l + Q_l⎤      a = J_w + m R²/4 + I R²/L²
//! ⎣b a⎦ ⎣ω̇_r⎦ = ⎣τ_r + Q_r⎦,     b = m R²/4 − I R²/L²
//! ```
//!
//! with τ the net wheel torques of [`super::motor`] and Q the centre-of-mass terms. The
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
//!
//! ## Bridge states and faults
//!
//! Each wheel's bridge either drives (slow decay: u = d · V_s, d = 0 is a short brake) or
//! coasts (no current); see [`super::driver`]. [`Plant::set_duty`] sets the duties,
//! [`Plant::set_driver_enabled`] the driver's enable line (disabled = both coast). The
//! fault hooks, for a fault timeline:
//!
//! - [`Plant::set_motor_connected`] — a motor lead off: that wheel coasts whatever the
//!   duty;
//! - [`Plant::set_wheel_blocked`] — the wheel jammed: its speed is set to 0 and held there
//!   by unlimited static friction until released (the robot pivots about it);
//! - [`Plant::set_slip`] — a slip patch: the wheel's longitudinal slip ratio from now on;
//! - [`Plant::set_supply_v`] — supply sag (or recovery): the bridge's supply from now on.
//!
//! ## Integration
//!
//! The state (ω_l, ω_r, φ_l, φ_r) — wheel speeds and wheel angles — is advanced with the
//! classic fourth-order Runge–Kutta method at the plant rate (≥ 10 × the control rate),
//! the bridge held constant over the control period (zero-order hold, as a PWM timer
//! does). Each wheel's regime — its direction, and its power flow (coasting, motoring,
//! back-driven) — makes the dynamics affine, ω̇ = A ω + b, with A and b fixed by the
//! regime. When every RK4 stage point of a step provably stays in the regime of its start
//! (each wheel farther from rest and from its zero-current speed than any stage of the
//! step can have moved it, a bound derived in the `propagator` module), the step is taken
//! in closed form, which is the same arithmetic as RK4 stage by stage; otherwise (a wheel at rest or reversing, a
//! current changing sign, d ≠ 0) RK4 evaluates the full model at every stage. Friction is
//! decided once per step, at its start: a sliding wheel's Coulomb friction keeps its sign
//! through the four stages (a sign flip between stages would make RK4 average the
//! friction away near rest), a wheel at rest is held or breaks away as above, and a wheel
//! that ends the step moving the way its friction pushes has passed through rest and is
//! stopped there; static friction decides at the next step whether it breaks away.
//!
//! ## True pose and slip
//!
//! Each plant step the wheels turn by Δφ_l, Δφ_r (from RK4). Wheel i moves its contact
//! point by (1 − s_i)·R_i·Δφ_i over the ground, s_i being a longitudinal slip ratio
//! (0 = pure rolling). The true pose moves along the arc those two distances define on the
//! true track width L — exact for a constant curvature over the 0.1 ms step. The heading's
//! cosine and sine are advanced by a small-angle rotation each step and re-derived from
//! θ once per control period, so there is no trigonometry in the inner loop.

use robot_files::plant::{BodyParams, DriverParams, Load, MotorParams, Wheel};
use robot_files::truth::{wrap_angle, TruePose};

use super::driver::{self, BridgeOutput};
use super::friction::{Friction, Grip, Inertia};
use super::motor::{PowerFlow, WheelDrive};
use super::propagator::Propagator;

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
    /// H-bridge, supply and PWM.
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
    /// What the wheels drive: the robot on the floor, or nothing (on a stand).
    pub load: Load,
}

/// The inertia matrix [a, b] of `params` (see [`Plant::inertia_kg_m2`]), kg·m².
fn inertia_matrix_kg_m2(params: &PlantParams) -> [f64; 2] {
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

/// Index of a power flow in the propagator table.
const fn flow_index(flow: PowerFlow) -> usize {
    match flow {
        PowerFlow::Coasting => 0,
        PowerFlow::Motoring => 1,
        PowerFlow::BackDriven => 2,
    }
}

/// All three power flows, in [`flow_index`] order.
const FLOWS: [PowerFlow; 3] = [
    PowerFlow::Coasting,
    PowerFlow::Motoring,
    PowerFlow::BackDriven,
];

/// The affine model ω̇ = A ω + b of one regime (both wheels' directions and power
/// flows) under the present bridge state, ready for its [`Propagator`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct Affine {
    /// Index into `Plant::propagators`: 3 · flow(left) + flow(right).
    index: usize,
    /// S b and T b, with b = M⁻¹ τ₀ and τ₀ the electrical torque at ω = 0 minus the
    /// Coulomb friction [left, right]: rad/s and rad.
    sb: [f64; 2],
    tb: [f64; 2],
}

/// Added to the closed form's reach (rad/s) so that rounding in the stage points cannot
/// cross a regime boundary the exact arithmetic does not.
const ROUNDING_MARGIN_RAD_S: f64 = 1e-9;

/// The simulated robot: parameters, state, bridge and fault state, and the RK4 integrator.
#[derive(Clone, Debug)]
pub struct Plant {
    params: PlantParams,
    drive: WheelDrive,
    /// The chassis' inertia matrix and the wheels' Coulomb/static friction.
    friction: Friction,
    /// m · d, kg·m (0: centre of mass on the axle, no centre-of-mass terms).
    mass_com: f64,
    /// Mean true wheel radius R and true track width L, m.
    radius_m: f64,
    track_m: f64,
    /// Closed-form RK4 per regime pair, index 3 · flow(left) + flow(right), for the step
    /// size `propagator_dt_s`.
    propagators: [Propagator; 9],
    propagator_dt_s: f64,
    /// False only in tests: every step stage by stage.
    use_closed_form: bool,
    /// Wheel speeds [left, right], rad/s.
    speed: [f64; 2],
    /// Wheel angles [left, right], rad (what the encoders see).
    angle: [f64; 2],
    /// Applied duties [left, right], after quantisation and dead-band.
    applied_duty: [f64; 2],
    /// Present supply voltage, V.
    supply_v: f64,
    /// Driver enable line (TB6612 STBY, DRV8833 nSLEEP).
    enabled: bool,
    /// Motor leads connected [left, right].
    connected: [bool; 2],
    /// Wheels jammed [left, right].
    blocked: [bool; 2],
    /// Present slip ratios [left, right].
    slip: [f64; 2],
    /// Derived from the above by `update_bridge`: coasting [left, right] …
    coasting: [bool; 2],
    /// … armature voltage while driven [left, right], V …
    volts: [f64; 2],
    /// … the speed at which the current is zero, u / (N K_e), rad/s (∞ coasting) …
    zero_current_speed: [f64; 2],
    /// … and the speed-independent electrical torque g · k_V · u for motoring and
    /// back-driven flow [left, right], N·m.
    motoring_torque: [f64; 2],
    back_driven_torque: [f64; 2],
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

/// Why [`Plant::new`] or a run-time setter rejected a value (the scenario layer validates
/// first, with the TOML key; this is the last line of defence).
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
    /// A robot with `params`, at rest at the origin, driver enabled, duties 0 (braking),
    /// no faults.
    pub fn new(params: PlantParams) -> Result<Self, PlantError> {
        let m = &params.motor;
        let body = &params.body;
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
            ("driver.pwm_levels", params.driver.pwm_levels > 0),
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
            ("body.mass_kg", body.mass_kg >= 0.0),
            ("body.yaw_inertia_kg_m2", body.yaw_inertia_kg_m2 >= 0.0),
            ("body.wheel_inertia_kg_m2", body.wheel_inertia_kg_m2 >= 0.0),
            (
                "body.com_ahead_of_axle_m",
                body.com_ahead_of_axle_m.is_finite()
                    && body.mass_kg * body.com_ahead_of_axle_m * body.com_ahead_of_axle_m
                        <= body.yaw_inertia_kg_m2,
            ),
        ];
        // `x > 0.0` is false for NaN, so the checks above also reject NaN.
        if let Some((name, _)) = checks.iter().find(|(_, ok)| !ok) {
            return Err(PlantError::OutOfRange(name));
        }
        let g = &params.geometry;
        let r = 0.5 * (g.wheel_radius_left_m + g.wheel_radius_right_m);
        let [a, b] = inertia_matrix_kg_m2(&params);
        let inertia = Inertia::new(a, b).ok_or(PlantError::SingularInertia)?;
        let drive = WheelDrive::new(
            &params.motor,
            params.gear_ratio,
            params.driver.kind.on_resistance_ohm(),
        );
        let mut plant = Self {
            drive,
            friction: Friction {
                inertia,
                coulomb_nm: drive.coulomb_nm,
            },
            // Lifted, the chassis does not move: no centre-of-mass terms.
            mass_com: match params.load {
                Load::Ground => body.mass_kg * body.com_ahead_of_axle_m,
                Load::Lifted => 0.0,
            },
            radius_m: r,
            track_m: g.track_width_m,
            propagators: Self::propagators(&drive, &inertia, 0.0),
            propagator_dt_s: 0.0,
            use_closed_form: true,
            speed: [0.0; 2],
            angle: [0.0; 2],
            applied_duty: [0.0; 2],
            supply_v: params.driver.supply_v,
            enabled: true,
            connected: [true; 2],
            blocked: [false; 2],
            slip: params.slip,
            coasting: [false; 2],
            volts: [0.0; 2],
            zero_current_speed: [0.0; 2],
            motoring_torque: [0.0; 2],
            back_driven_torque: [0.0; 2],
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: 0.0,
            heading: [1.0, 0.0],
            ground_per_rad: [0.0; 2],
            params,
        };
        plant.update_ground_per_rad();
        plant.update_bridge();
        Ok(plant)
    }

    /// The inertia matrix on the wheel speeds (ω_l, ω_r), [a, b] for M = [[a, b], [b, a]],
    /// kg·m² (module doc): a + b is what each wheel sees driving straight, a − b turning on
    /// the spot; lifted, b = 0 and a is the wheel's own inertia.
    pub fn inertia_kg_m2(&self) -> [f64; 2] {
        [self.friction.inertia.a, self.friction.inertia.b]
    }

    /// The closed-form RK4 of every regime pair for step `h` (s).
    fn propagators(drive: &WheelDrive, inertia: &Inertia, h: f64) -> [Propagator; 9] {
        core::array::from_fn(|k| {
            let damping = [
                drive.damping_nm_s_per_rad(FLOWS[k / 3]),
                drive.damping_nm_s_per_rad(FLOWS[k % 3]),
            ];
            Propagator::new(inertia.inv_p, inertia.inv_q, damping, h)
        })
    }

    /// The parameters the plant was built with (the supply and slip may have changed
    /// since: see [`Plant::supply_v`] and [`Plant::slip`]).
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// The motor, gearbox and bridge resistance folded into wheel-shaft quantities.
    pub fn drive(&self) -> &WheelDrive {
        &self.drive
    }

    /// Places the robot at `pose` (world frame) with wheel speeds `speeds` [left, right]
    /// (rad/s). Wheel angles restart at 0. The bridge and fault state are kept (a blocked
    /// wheel's speed stays 0).
    pub fn reset(&mut self, pose: TruePose, speeds: [f64; 2]) {
        self.x_m = pose.x_m;
        self.y_m = pose.y_m;
        self.theta_rad = pose.theta_rad;
        self.heading = [pose.theta_rad.cos(), pose.theta_rad.sin()];
        self.speed = speeds;
        for (w, blocked) in self.speed.iter_mut().zip(self.blocked) {
            if blocked {
                *w = 0.0;
            }
        }
        self.angle = [0.0; 2];
    }

    /// Wheel speeds [left, right] that drive the *true* robot (true radii, track width
    /// and slip) at forward speed `v_m_s` (m/s) and yaw rate `omega_rad_s` (rad/s).
    /// Lifted, the wheels turn as they would on the ground (the robot stays put).
    pub fn wheel_speeds_for(&self, v_m_s: f64, omega_rad_s: f64) -> [f64; 2] {
        let g = &self.params.geometry;
        let half = 0.5 * omega_rad_s * g.track_width_m;
        [
            (v_m_s - half) / ((1.0 - self.slip[0]) * g.wheel_radius_left_m),
            (v_m_s + half) / ((1.0 - self.slip[1]) * g.wheel_radius_right_m),
        ]
    }

    /// Sets both PWM duties (any f32, positive forward; see
    /// [`driver::applied_duty`]) for the following [`Plant::advance`] calls. While
    /// the driver is enabled and a motor connected, its bridge drives in slow decay at
    /// u = d · V_s; a duty of 0 (or in the dead-band) is a short brake.
    pub fn set_duty(&mut self, left: f32, right: f32) {
        let bridge = &self.params.driver;
        self.applied_duty = [
            driver::applied_duty(bridge, left),
            driver::applied_duty(bridge, right),
        ];
        self.update_bridge();
    }

    /// Enables or disables the driver (TB6612 STBY, DRV8833 nSLEEP). Disabled, both
    /// bridges are high impedance and both motors coast, whatever the duties; the duties
    /// set are applied again once enabled.
    pub fn set_driver_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
        self.update_bridge();
    }

    /// Whether the driver is enabled.
    pub fn driver_enabled(&self) -> bool {
        self.enabled
    }

    /// Fault hook: connects or disconnects `wheel`'s motor leads. Disconnected, that motor
    /// carries no current and its wheel coasts whatever the duty and enable line.
    pub fn set_motor_connected(&mut self, wheel: Wheel, connected: bool) {
        self.connected[wheel.index()] = connected;
        self.update_bridge();
    }

    /// Whether each motor [left, right] is connected.
    pub fn motor_connected(&self) -> [bool; 2] {
        self.connected
    }

    /// Fault hook: jams `wheel` (`true`) or releases it (`false`). Jammed, the wheel's
    /// speed is set to 0 at once (the chassis' momentum through it is lost into the jam)
    /// and held at 0 by unlimited static friction; its contact point stays put, so the
    /// robot pivots about it. Released, ordinary static friction decides again.
    pub fn set_wheel_blocked(&mut self, wheel: Wheel, blocked: bool) {
        let i = wheel.index();
        self.blocked[i] = blocked;
        if blocked {
            self.speed[i] = 0.0;
        }
    }

    /// Whether each wheel [left, right] is jammed.
    pub fn wheel_blocked(&self) -> [bool; 2] {
        self.blocked
    }

    /// Fault hook: a slip patch. `wheel`'s longitudinal slip ratio becomes `ratio`, in
    /// [0, 1), from now on (its contact point moves (1 − ratio)·R·Δφ per wheel rotation Δφ).
    /// A ratio outside [0, 1) or NaN is refused and nothing changes.
    pub fn set_slip(&mut self, wheel: Wheel, ratio: f64) -> Result<(), PlantError> {
        if !(0.0..1.0).contains(&ratio) {
            return Err(PlantError::OutOfRange("slip"));
        }
        self.slip[wheel.index()] = ratio;
        self.update_ground_per_rad();
        Ok(())
    }

    /// The present slip ratios [left, right].
    pub fn slip(&self) -> [f64; 2] {
        self.slip
    }

    /// Fault hook: supply sag (or recovery). The bridge's supply becomes `volts` (V,
    /// finite, > 0) from now on: the armature sees d · `volts`. Under-voltage lockout of
    /// the driver is not modelled. A non-positive or non-finite value is refused and
    /// nothing changes.
    pub fn set_supply_v(&mut self, volts: f64) -> Result<(), PlantError> {
        if !(volts > 0.0 && volts.is_finite()) {
            return Err(PlantError::OutOfRange("supply_v"));
        }
        self.supply_v = volts;
        self.update_bridge();
        Ok(())
    }

    /// The present supply voltage, V.
    pub fn supply_v(&self) -> f64 {
        self.supply_v
    }

    /// What each bridge [left, right] applies now.
    pub fn bridge_outputs(&self) -> [BridgeOutput; 2] {
        core::array::from_fn(|i| {
            if self.coasting[i] {
                BridgeOutput::Coast
            } else {
                BridgeOutput::Drive {
                    volts: self.volts[i],
                }
            }
        })
    }

    fn update_ground_per_rad(&mut self) {
        let g = &self.params.geometry;
        self.ground_per_rad = match self.params.load {
            Load::Ground => [
                (1.0 - self.slip[0]) * g.wheel_radius_left_m,
                (1.0 - self.slip[1]) * g.wheel_radius_right_m,
            ],
            // In the air a wheel moves nothing.
            Load::Lifted => [0.0; 2],
        };
    }

    /// Re-derives each wheel's bridge output and its constant terms from the duties,
    /// supply, enable line and connections.
    fn update_bridge(&mut self) {
        let d = &self.drive;
        for i in 0..2 {
            self.coasting[i] = !(self.enabled && self.connected[i]);
            let u = if self.coasting[i] {
                0.0
            } else {
                driver::voltage_v(self.applied_duty[i], self.supply_v)
            };
            self.volts[i] = u;
            self.zero_current_speed[i] = if self.coasting[i] {
                f64::INFINITY
            } else {
                u / d.back_emf_v_s_per_rad
            };
            self.motoring_torque[i] = d.gear_factor(PowerFlow::Motoring) * d.torque_per_volt * u;
            self.back_driven_torque[i] =
                d.gear_factor(PowerFlow::BackDriven) * d.torque_per_volt * u;
        }
    }

    /// Wheel torques [left, right] at speeds `w`, N·m, everything but Coulomb/static
    /// friction: electrical torque, viscous friction and the centre-of-mass terms.
    fn torques_without_friction(&self, w: [f64; 2]) -> [f64; 2] {
        let mut tau = [0.0; 2];
        for (i, t) in tau.iter_mut().enumerate() {
            let electrical = if self.coasting[i] {
                0.0
            } else {
                self.drive.electrical_torque_nm(self.volts[i], w[i])
            };
            *t = electrical - self.drive.viscous_nm_s_per_rad * w[i];
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
    fn accel(&self, w: [f64; 2], grip: [Grip; 2]) -> [f64; 2] {
        self.friction
            .inertia
            .accel(self.torques_without_friction(w), grip)
    }

    /// One classic RK4 step of `dt_s` from wheel speeds `w0`, for the speeds and angles,
    /// evaluating the full model ([`Plant::accel`]) at every stage with the friction
    /// decided at the start ([`Friction::grip`]). A wheel that ends the step moving the way
    /// its friction pushes has passed through rest: it is stopped at zero, and static
    /// friction decides at the next step. Returns the new speeds and the angle increments.
    fn rk4_step(&self, w0: [f64; 2], dt_s: f64) -> ([f64; 2], [f64; 2]) {
        let grip = self
            .friction
            .grip(w0, self.blocked, || self.torques_without_friction(w0));
        let k1 = self.accel(w0, grip);
        let w1 = [w0[0] + 0.5 * dt_s * k1[0], w0[1] + 0.5 * dt_s * k1[1]];
        let k2 = self.accel(w1, grip);
        let w2 = [w0[0] + 0.5 * dt_s * k2[0], w0[1] + 0.5 * dt_s * k2[1]];
        let k3 = self.accel(w2, grip);
        let w3 = [w0[0] + dt_s * k3[0], w0[1] + dt_s * k3[1]];
        let k4 = self.accel(w3, grip);
        let mut next = [0.0; 2];
        let mut dphi = [0.0; 2];
        for i in 0..2 {
            // φ̇ = ω: the RK4 increment of φ uses the stage speeds.
            dphi[i] = dt_s / 6.0 * (w0[i] + 2.0 * w1[i] + 2.0 * w2[i] + w3[i]);
            next[i] = w0[i] + dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            let stops = match grip[i] {
                Grip::Held => true,
                Grip::Slides(friction) => next[i] * friction > 0.0,
            };
            if stops || self.blocked[i] {
                next[i] = 0.0;
            }
        }
        (next, dphi)
    }

    /// The affine model ω̇ = A ω + b of the regime both wheels are in at speeds `w`
    /// (both non-zero): their directions and power flows.
    fn affine(&self, w: [f64; 2]) -> Affine {
        let d = &self.drive;
        let mut index = 0;
        let mut torque_at_rest = [0.0; 2];
        for i in 0..2 {
            let (flow, electrical) = if self.coasting[i] {
                (PowerFlow::Coasting, 0.0)
            } else {
                match d.power_flow(self.volts[i], w[i]) {
                    PowerFlow::BackDriven => (PowerFlow::BackDriven, self.back_driven_torque[i]),
                    _ => (PowerFlow::Motoring, self.motoring_torque[i]),
                }
            };
            let coulomb = if w[i] > 0.0 {
                d.coulomb_nm
            } else {
                -d.coulomb_nm
            };
            torque_at_rest[i] = electrical - coulomb;
            index = 3 * index + flow_index(flow);
        }
        let (sb, tb) = self
            .propagators
            .get(index)
            .map_or(([0.0; 2], [0.0; 2]), |p| {
                p.forcing(self.friction.inertia.solve(torque_at_rest))
            });
        Affine { index, sb, tb }
    }

    /// The closed-form RK4 step from `w` in the regime `affine` (which must be the regime
    /// of `w`), if every stage stayed in it: neither wheel reaching rest, neither driven
    /// wheel reaching its zero-current speed, within the step's reach. `None` otherwise.
    /// When it returns a step, the step's end is in the same regime.
    #[inline]
    fn closed_form_step(&self, w: [f64; 2], affine: &Affine) -> Option<([f64; 2], [f64; 2])> {
        let propagator = self.propagators.get(affine.index)?;
        let (next, dphi) = propagator.step(w, affine.sb, affine.tb);
        let reach = propagator.reach([next[0] - w[0], next[1] - w[1]]) + ROUNDING_MARGIN_RAD_S;
        // A coasting wheel's zero-current speed is infinite: no boundary.
        let stays =
            |i: usize| w[i].abs() > reach && (w[i] - self.zero_current_speed[i]).abs() > reach;
        if stays(0) && stays(1) {
            Some((next, dphi))
        } else {
            None
        }
    }

    /// Advances `steps` RK4 steps of `dt_s` seconds each with the bridge state last set.
    pub fn advance(&mut self, dt_s: f64, steps: u32) {
        if self.propagator_dt_s != dt_s {
            self.propagators = Self::propagators(&self.drive, &self.friction.inertia, dt_s);
            self.propagator_dt_s = dt_s;
        }
        let closed_form = self.use_closed_form && self.mass_com == 0.0;
        // The state lives in locals for the loop (registers, not memory round trips).
        let [mut c, mut s] = self.heading;
        let (mut x, mut y, mut theta) = (self.x_m, self.y_m, self.theta_rad);
        let (mut w, mut angle) = (self.speed, self.angle);
        let inv_l = 1.0 / self.params.geometry.track_width_m;
        // The regime of the last closed-form step: still the regime of `w`, since a
        // closed-form step ends in the regime it started in.
        let mut regime: Option<Affine> = None;
        for _ in 0..steps {
            let step = if closed_form && w[0] != 0.0 && w[1] != 0.0 {
                let affine = *regime.get_or_insert_with(|| self.affine(w));
                self.closed_form_step(w, &affine)
            } else {
                None
            };
            let (next, dphi) = match step {
                Some(step) => step,
                None => {
                    regime = None;
                    self.rk4_step(w, dt_s)
                }
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
        // One Newton step of 1/√(c² + s²) removes the rounding drift of the rotations.
        let norm = 0.5 * (3.0 - (c * c + s * s));
        self.heading = [c * norm, s * norm];
        self.theta_rad = wrap_angle(theta);
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

    /// Duties [left, right] the PWM applies (quantised as the firmware writes them,
    /// dead-band zeroed). They reach the motor only while its bridge drives
    /// ([`Plant::bridge_outputs`]).
    pub fn applied_duty(&self) -> [f64; 2] {
        self.applied_duty
    }

    /// Armature currents [left, right] at the present state, A (0 for a coasting motor).
    pub fn currents_a(&self) -> [f64; 2] {
        core::array::from_fn(|i| {
            if self.coasting[i] {
                0.0
            } else {
                self.drive.current_a(self.volts[i], self.speed[i])
            }
        })
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
    use robot_files::rng::Rng;

    const H: f64 = 1e-4;

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
            load: Load::Ground,
        }
    }

    /// No Coulomb or viscous friction: what is left is inertia, the bridge and the
    /// centre-of-mass terms.
    fn frictionless() -> PlantParams {
        let mut pp = params();
        pp.motor.coulomb_friction_nm = 0.0;
        pp.motor.viscous_friction_nm_s_per_rad = 0.0;
        pp
    }

    /// Steps of `H` until `done` holds (at most `max` steps); the count.
    fn steps_until(p: &mut Plant, max: u32, done: impl Fn(&Plant) -> bool) -> u32 {
        let mut n = 0;
        while !done(p) && n < max {
            p.advance(H, 1);
            n += 1;
        }
        n
    }

    #[test]
    fn full_duty_reaches_the_no_load_speed() {
        let mut p = Plant::new(params()).unwrap();
        p.set_duty(1.0, 1.0);
        for _ in 0..2000 {
            p.advance(H, 10);
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
        p.advance(H, 500); // 50 ms
        let d = *p.drive();
        let r = 0.0325;
        let j = pp.body.wheel_inertia_kg_m2
            + pp.motor.rotor_inertia_kg_m2 * 900.0
            + pp.body.mass_kg * r * r / 2.0;
        let tau = j / d.damping_nm_s_per_rad(PowerFlow::Motoring);
        let w_inf = d.steady_speed_rad_s(3.0);
        let exact = w_inf * (1.0 - (-0.05 / tau).exp());
        assert!(
            (p.wheel_speeds()[0] - exact).abs() < 1e-9,
            "{:?} {exact}",
            p.wheel_speeds()
        );
    }

    #[test]
    fn lifted_wheels_see_only_their_own_inertia_and_the_robot_stays_put() {
        let mut pp = params();
        pp.load = Load::Lifted;
        let mut p = Plant::new(pp).unwrap();
        let j_w = pp.body.wheel_inertia_kg_m2 + pp.motor.rotor_inertia_kg_m2 * 900.0;
        assert_eq!(p.inertia_kg_m2(), [j_w, 0.0]);
        // Only the left wheel driven: the right one is not dragged along (no coupling).
        p.set_duty(0.5, 0.0);
        p.advance(H, 100); // 10 ms
        let d = *p.drive();
        let tau = j_w / d.damping_nm_s_per_rad(PowerFlow::Motoring);
        assert!((tau - 0.0262).abs() < 1e-3, "{tau}");
        let w_inf = d.steady_speed_rad_s(3.0);
        let exact = w_inf * (1.0 - (-0.01 / tau).exp());
        let w = p.wheel_speeds();
        assert!((w[0] - exact).abs() < 1e-6, "{} vs {exact}", w[0]);
        assert_eq!(w[1], 0.0);
        assert_eq!(p.pose(), TruePose::default());
        assert_eq!(p.body_velocity(), (0.0, 0.0));
        // On the ground the same duty meets the chassis: slower, and the robot moves.
        let mut ground = Plant::new(params()).unwrap();
        ground.set_duty(0.5, 0.0);
        ground.advance(H, 100);
        assert!(ground.wheel_speeds()[0] < 0.7 * w[0]);
        assert!(ground.pose().x_m != 0.0);
    }

    #[test]
    fn spinning_on_the_spot_turns_by_the_wheel_arc() {
        let mut p = Plant::new(params()).unwrap();
        p.reset(TruePose::default(), [-10.0, 10.0]);
        p.set_duty(0.0, 0.0);
        p.advance(H, 1);
        // Braked spin: position stays at the origin, heading follows the wheels.
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
        let duty = |w: f64| (d.steady_volts(w) / 6.0) as f32;
        p.set_duty(duty(speeds[0]), duty(speeds[1]));
        let period_steps = (2.0 * PI / 0.2 / H).round() as u32;
        p.advance(H, period_steps);
        let pose = p.pose();
        // f32 duty resolution limits the speed balance to ~1e-7 relative.
        assert!(pose.x_m.abs() < 2e-3 && pose.y_m.abs() < 2e-3, "{pose:?}");
    }

    #[test]
    fn closed_form_rk4_equals_stage_by_stage_rk4_in_every_regime() {
        let mut p = Plant::new(params()).unwrap();
        p.propagators = Plant::propagators(&p.drive, &p.friction.inertia, H);
        p.propagator_dt_s = H;
        let mut rng = Rng::new(5);
        // Regime pair × direction pattern: how often each was compared.
        let mut seen = [[0u32; 4]; 9];
        let mut taken = 0;
        for _ in 0..40_000 {
            p.set_motor_connected(Wheel::Left, rng.uniform() > 0.3);
            p.set_motor_connected(Wheel::Right, rng.uniform() > 0.3);
            p.set_duty(rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32);
            let w = [rng.symmetric(40.0), rng.symmetric(40.0)];
            let affine = p.affine(w);
            let Some((w_fast, phi_fast)) = p.closed_form_step(w, &affine) else {
                continue;
            };
            taken += 1;
            let (w_ref, phi_ref) = p.rk4_step(w, H);
            for i in 0..2 {
                assert!((w_fast[i] - w_ref[i]).abs() < 1e-11, "{w_fast:?} {w_ref:?}");
                assert!(
                    (phi_fast[i] - phi_ref[i]).abs() < 1e-15,
                    "{phi_fast:?} {phi_ref:?}"
                );
            }
            // The end of the step is in the same regime (what lets `advance` keep it).
            assert_eq!(p.affine(w_fast), affine);
            let signs = usize::from(w[0] > 0.0) * 2 + usize::from(w[1] > 0.0);
            seen[affine.index][signs] += 1;
        }
        // Every regime pair in every direction was exercised, and the guard lets almost
        // every random state through.
        for (index, counts) in seen.iter().enumerate() {
            for (signs, n) in counts.iter().enumerate() {
                assert!(*n >= 20, "regime {index}, directions {signs}: {n}");
            }
        }
        assert!(taken > 38_000, "{taken}");

        // The guard matters: a back-driven wheel just above its zero-current speed crosses
        // into motoring within the step; the closed form of the starting regime would then
        // be wrong, and it is not used.
        p.set_motor_connected(Wheel::Left, true);
        p.set_motor_connected(Wheel::Right, true);
        p.set_duty(0.5, 0.5);
        let w = [p.zero_current_speed[0] + 1e-3, 10.0];
        let affine = p.affine(w);
        assert!(p.closed_form_step(w, &affine).is_none());
        let (w_naive, _) = p.propagators[affine.index].step(w, affine.sb, affine.tb);
        let (w_ref, _) = p.rk4_step(w, H);
        assert!(w_ref[0] < p.zero_current_speed[0], "the step crosses");
        assert!(
            (w_naive[0] - w_ref[0]).abs() > 1e-9,
            "{w_naive:?} {w_ref:?}"
        );

        // At rest, stage by stage (static friction): a small duty does not move the wheel.
        p.reset(TruePose::default(), [0.0, 0.0]);
        p.set_duty(0.03, 0.03);
        p.advance(H, 10);
        assert_eq!(p.wheel_speeds(), [0.0, 0.0]);
    }

    #[test]
    fn closed_form_and_stage_by_stage_runs_agree() {
        // A second of random duties, changed every millisecond, through rest, reversals
        // and current sign changes: the fast path and the full model stay together.
        let mut fast = Plant::new(params()).unwrap();
        let mut full = fast.clone();
        full.use_closed_form = false;
        let mut rng = Rng::new(11);
        for _ in 0..1000 {
            let (l, r) = (rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32);
            fast.set_duty(l, r);
            full.set_duty(l, r);
            fast.advance(H, 10);
            full.advance(H, 10);
        }
        let (a, b) = (fast.pose(), full.pose());
        assert!(fast.wheel_speeds()[0] != 0.0);
        for i in 0..2 {
            assert!((fast.wheel_speeds()[i] - full.wheel_speeds()[i]).abs() < 1e-9);
            assert!((fast.wheel_angles()[i] - full.wheel_angles()[i]).abs() < 1e-9);
        }
        assert!((a.x_m - b.x_m).abs() < 1e-9 && (a.y_m - b.y_m).abs() < 1e-9);
        assert!((a.theta_rad - b.theta_rad).abs() < 1e-9);
    }

    #[test]
    fn a_braked_wheel_stops_much_sooner_than_a_coasting_one() {
        // Both wheels from ω₀ with duty 0: each obeys J ω̇ = −D ω − τ_c (J = a + b), so it
        // stops after (J/D) ln(1 + D ω₀ / τ_c). Braked (enabled, short brake), the wheel
        // back-drives the motor: D = N² K_t K_e / (η (R_a + R_bridge)) + b. Coasting
        // (disabled), no current: D = b.
        let w0 = 30.0;
        let mut stop_s = [0.0; 2];
        let mut initial_decel = [0.0; 2];
        for (k, enabled) in [true, false].into_iter().enumerate() {
            let mut p = Plant::new(params()).unwrap();
            p.reset(TruePose::default(), [w0, w0]);
            p.set_duty(0.0, 0.0);
            p.set_driver_enabled(enabled);
            let d = *p.drive();
            let flow = if enabled {
                PowerFlow::BackDriven
            } else {
                PowerFlow::Coasting
            };
            let damping = d.damping_nm_s_per_rad(flow);
            let j = p.friction.inertia.a + p.friction.inertia.b;
            p.advance(H, 1);
            // One step against the exact solution (ω₀ + τ_c/D) e^{−D t / J} − τ_c/D.
            let offset = d.coulomb_nm / damping;
            let exact = (w0 + offset) * (-damping * H / j).exp() - offset;
            assert!((p.wheel_speeds()[0] - exact).abs() < 1e-9, "{exact}");
            initial_decel[k] = (w0 - p.wheel_speeds()[0]) / H;
            let steps = 1 + steps_until(&mut p, 100_000, |p| p.wheel_speeds()[0] == 0.0);
            stop_s[k] = f64::from(steps) * H;
            let expected = j / damping * (damping * w0 / d.coulomb_nm).ln_1p();
            assert!(
                stop_s[k] >= expected - 1e-9 && stop_s[k] <= expected + H + 1e-9,
                "{stop_s:?} {expected}"
            );
            // Stopped, it stays stopped (braked or not, nothing drives it).
            p.advance(H, 100);
            assert_eq!(p.wheel_speeds(), [0.0, 0.0]);
        }
        // The default robot at 30 rad/s: the brake decelerates 12.7 × harder.
        let d = *Plant::new(params()).unwrap().drive();
        let ratio = (d.damping_nm_s_per_rad(PowerFlow::BackDriven) * w0 + d.coulomb_nm)
            / (d.viscous_nm_s_per_rad * w0 + d.coulomb_nm);
        assert!((initial_decel[0] / initial_decel[1] / ratio - 1.0).abs() < 2e-3);
        assert!(ratio > 12.0, "{ratio}");
        assert!(stop_s[1] > 4.0 * stop_s[0], "{stop_s:?}");
    }

    #[test]
    fn disabled_driver_and_disconnected_motor_coast() {
        let mut p = Plant::new(params()).unwrap();
        p.reset(TruePose::default(), [15.0, 15.0]);
        p.set_duty(0.5, 0.5);
        assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 3.0 }; 2]);
        assert!(p.currents_a().iter().all(|i| i.abs() > 0.01));
        // Disabled: both coast, no current; enabling again restores the duties.
        p.set_driver_enabled(false);
        assert!(!p.driver_enabled());
        assert_eq!(p.bridge_outputs(), [BridgeOutput::Coast; 2]);
        assert_eq!(p.currents_a(), [0.0, 0.0]);
        let mut coasting = p.clone();
        coasting.advance(H, 1);
        let d = *p.drive();
        let j = p.friction.inertia.a + p.friction.inertia.b;
        let decel = (15.0 - coasting.wheel_speeds()[0]) / H;
        let expected = (d.viscous_nm_s_per_rad * 15.0 + d.coulomb_nm) / j;
        assert!((decel / expected - 1.0).abs() < 1e-3, "{decel} {expected}");
        p.set_driver_enabled(true);
        assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 3.0 }; 2]);

        // The left motor's leads off: it coasts whatever the duty, the right one drives.
        p.set_motor_connected(Wheel::Left, false);
        assert_eq!(p.motor_connected(), [false, true]);
        assert_eq!(
            p.bridge_outputs(),
            [BridgeOutput::Coast, BridgeOutput::Drive { volts: 3.0 }]
        );
        p.set_duty(1.0, 0.5);
        assert_eq!(p.currents_a()[0], 0.0);
        p.advance(H, 10_000);
        let [wl, wr] = p.wheel_speeds();
        assert!(wr > 15.0 && wl < wr - 10.0, "{wl} {wr}");
        // Reconnected, full duty takes the left wheel past the right one.
        p.set_motor_connected(Wheel::Left, true);
        p.advance(H, 5000);
        let [wl, wr] = p.wheel_speeds();
        assert!(wl > wr + 5.0, "{wl} {wr}");
    }

    /// The right motor disconnected (coasting) and the left one driven from rest at
    /// `duty`: the largest |right speed| seen over 0.3 s, and whether the left moved.
    fn drag(pp: PlantParams, duty: f32) -> (f64, bool) {
        let mut p = Plant::new(pp).unwrap();
        p.set_motor_connected(Wheel::Right, false);
        p.set_duty(duty, 0.0);
        let mut biggest = 0.0_f64;
        for _ in 0..3000 {
            p.advance(H, 1);
            let w = p.wheel_speeds()[1];
            if w.abs() > biggest.abs() {
                biggest = w;
            }
        }
        (biggest, p.wheel_speeds()[0] > 1.0)
    }

    #[test]
    fn a_wheel_at_rest_is_dragged_only_when_the_coupling_beats_static_friction() {
        // Holding the right wheel while the left breaks away with net torque τ_l − τ_c
        // takes f = b (τ_l − τ_c) / a of static friction on the right. Duties giving 1.5 τ_c
        // and 0.5 τ_c of pull, for the default body (b > 0: turning is the cheaper motion,
        // a − b < a + b, so the right wheel is pulled backward as the robot yaws) and a
        // body with a large yaw inertia (b < 0: translating is cheaper, pulled forward).
        let mut heavy_yaw = params();
        heavy_yaw.body.yaw_inertia_kg_m2 = 5e-3;
        for pp in [params(), heavy_yaw] {
            let p = Plant::new(pp).unwrap();
            let d = *p.drive();
            let (a, b) = (p.friction.inertia.a, p.friction.inertia.b);
            let stall_per_duty = d.efficiency * d.torque_per_volt * pp.driver.supply_v;
            let duty_for_pull = |pull: f64| {
                let torque = d.coulomb_nm + pull * d.coulomb_nm * a / b.abs();
                (torque / stall_per_duty) as f32
            };
            let (strong, weak) = (duty_for_pull(1.5), duty_for_pull(0.5));
            assert!(strong < 1.0 && weak > 0.0, "{strong} {weak}");
            let (dragged, left_moved) = drag(pp, strong);
            assert!(left_moved);
            assert!(dragged * b.signum() < -0.05, "b = {b}: {dragged}");
            let (held, left_moved) = drag(pp, weak);
            assert!(left_moved);
            assert_eq!(held, 0.0, "b = {b}");
        }
    }

    #[test]
    fn a_blocked_wheel_stays_at_zero_and_the_robot_pivots_about_it() {
        let mut p = Plant::new(params()).unwrap();
        p.set_wheel_blocked(Wheel::Left, true);
        assert_eq!(p.wheel_blocked(), [true, false]);
        p.set_duty(1.0, 0.6);
        p.advance(H, 15_000);
        assert_eq!(p.wheel_speeds()[0], 0.0);
        assert_eq!(p.wheel_angles()[0], 0.0);
        // Held, the right wheel alone sees inertia a: it settles at its own steady speed.
        let steady = p.drive().steady_speed_rad_s(0.6 * 6.0);
        assert!((p.wheel_speeds()[1] - steady).abs() < 1e-6);
        // The left contact point (0, L/2) has not moved.
        let pose = p.pose();
        let left_x = pose.x_m - 0.075 * pose.theta_rad.sin();
        let left_y = pose.y_m + 0.075 * pose.theta_rad.cos();
        assert!(
            left_x.abs() < 1e-12 && (left_y - 0.075).abs() < 1e-12,
            "{pose:?}"
        );
        assert!(p.wheel_angles()[1] > 10.0);
        // Released, the full duty breaks it away.
        p.set_wheel_blocked(Wheel::Left, false);
        p.advance(H, 100);
        assert!(p.wheel_speeds()[0] > 1.0);
        // Blocking a turning wheel stops it at once.
        p.set_wheel_blocked(Wheel::Right, true);
        assert_eq!(p.wheel_speeds()[1], 0.0);
        p.reset(TruePose::default(), [5.0, 5.0]);
        assert_eq!(p.wheel_speeds(), [5.0, 0.0]);
    }

    #[test]
    fn a_slip_patch_shortens_that_wheels_ground_distance() {
        let mut p = Plant::new(frictionless()).unwrap();
        p.set_driver_enabled(false);
        p.reset(TruePose::default(), [10.0, 10.0]);
        p.set_slip(Wheel::Right, 0.5).unwrap();
        assert_eq!(p.slip(), [0.0, 0.5]);
        let (v, yaw) = p.body_velocity();
        assert!((v - 0.75 * 0.325).abs() < 1e-12 && (yaw + 0.5 * 0.325 / 0.15).abs() < 1e-12);
        p.advance(H, 1000);
        let [al, ar] = p.wheel_angles();
        let expected = (0.5 * 0.0325 * ar - 0.0325 * al) / 0.15;
        assert!((p.pose().theta_rad - expected).abs() < 1e-12);
        assert!(expected < -0.1);
        // Out of range: refused, nothing changes.
        assert!(p.set_slip(Wheel::Left, 1.0).is_err());
        assert!(p.set_slip(Wheel::Left, f64::NAN).is_err());
        assert!(p.set_slip(Wheel::Left, -0.1).is_err());
        assert_eq!(p.slip(), [0.0, 0.5]);
    }

    #[test]
    fn supply_sag_lowers_the_voltage_and_the_speed() {
        let mut p = Plant::new(params()).unwrap();
        p.set_duty(1.0, 1.0);
        p.advance(H, 10_000);
        let full = p.wheel_speeds()[0];
        p.set_supply_v(4.0).unwrap();
        assert_eq!(p.supply_v(), 4.0);
        assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 4.0 }; 2]);
        p.advance(H, 30_000);
        let sagged = p.wheel_speeds()[0];
        assert!((sagged - p.drive().steady_speed_rad_s(4.0)).abs() < 1e-6);
        assert!(sagged < 0.7 * full, "{sagged} {full}");
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(p.set_supply_v(bad).is_err());
        }
        assert_eq!(p.supply_v(), 4.0);
    }

    #[test]
    fn centre_of_mass_terms_conserve_energy_and_push_the_right_way() {
        let kinetic = |p: &Plant| {
            let [l, r] = p.wheel_speeds();
            0.5 * (p.friction.inertia.a * (l * l + r * r) + 2.0 * p.friction.inertia.b * l * r)
        };
        for d in [0.05, -0.05] {
            let mut pp = frictionless();
            pp.body.com_ahead_of_axle_m = d;
            let mut p = Plant::new(pp).unwrap();
            p.set_driver_enabled(false);
            // Turning on the spot: v̇ = m d Ω² / (m + 2 J_w / R²) at the start.
            p.reset(TruePose::default(), [-10.0, 10.0]);
            let energy = kinetic(&p);
            p.advance(H, 1);
            let (v, _) = p.body_velocity();
            let yaw: f64 = 0.0325 * 20.0 / 0.15;
            let j_w = pp.body.wheel_inertia_kg_m2 + pp.motor.rotor_inertia_kg_m2 * 900.0;
            let expected =
                pp.body.mass_kg * d * yaw * yaw / (pp.body.mass_kg + 2.0 * j_w / (0.0325 * 0.0325));
            assert!((v / H / expected - 1.0).abs() < 1e-3, "{v} {expected}");
            // The robot pulls forward if the centre of mass is ahead, back if behind, and
            // the terms do no work: the energy stays while v and Ω trade.
            p.advance(H, 20_000);
            let (v, _) = p.body_velocity();
            assert!(v * d > 0.0 && v.abs() > 0.01, "{d}: {v}");
            assert!((kinetic(&p) / energy - 1.0).abs() < 1e-9, "{d}");
        }
        // Centred: no push.
        let mut p = Plant::new(frictionless()).unwrap();
        p.set_driver_enabled(false);
        p.reset(TruePose::default(), [-10.0, 10.0]);
        p.advance(H, 1000);
        assert_eq!(p.body_velocity().0, 0.0);
    }

    #[test]
    fn invalid_parameters_are_refused_with_their_name() {
        let mut pp = params();
        pp.body.com_ahead_of_axle_m = 0.1; // m d² = 5e-3 > I = 1.8e-3
        assert_eq!(
            Plant::new(pp).unwrap_err(),
            PlantError::OutOfRange("body.com_ahead_of_axle_m")
        );
        let mut pp = params();
        pp.driver.pwm_levels = 0;
        assert_eq!(
            Plant::new(pp).unwrap_err(),
            PlantError::OutOfRange("driver.pwm_levels")
        );
        let mut pp = params();
        pp.body.mass_kg = 0.0;
        pp.body.yaw_inertia_kg_m2 = 0.0;
        pp.body.wheel_inertia_kg_m2 = 0.0;
        pp.motor.rotor_inertia_kg_m2 = 0.0;
        assert_eq!(Plant::new(pp).unwrap_err(), PlantError::SingularInertia);
    }
}
