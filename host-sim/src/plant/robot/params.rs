//! What defines the simulated robot ([`PlantParams`]) and the rule for a valid one.
//!
//! Contract: [`validate`] accepts a parameter set only when every quantity is in its
//! physical range, which NaN never is (each wheel's motor, with its share of the
//! mismatch, has positive resistance and constants, frictions ≥ 0 and efficiency in
//! (0, 1]; the gear ratio, the supply, the PWM levels and the radii positive; inertias
//! and mass ≥ 0; dead-band and slip in [0, 1); the centre of mass no farther off the axle than
//! the yaw inertia allows, m d² ≤ I), and names the first offending one. `Plant::new`
//! refuses anything else, and a positive-definite inertia matrix is checked there.

use robot_files::plant::{BodyParams, DriverParams, Load, MotorMismatch, MotorParams, Wheel};

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

/// Everything that defines the simulated robot, SI units. See [`crate::plant`] for defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantParams {
    /// The nominal motor and gearbox; each wheel's own is this with its share of
    /// `motor_mismatch` ([`MotorMismatch::wheel_motor`]).
    pub motor: MotorParams,
    /// How the left and right motors differ about `motor` ([`MotorMismatch::NONE`]: both
    /// nominal).
    pub motor_mismatch: MotorMismatch,
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

/// Why [`Plant::new`](super::Plant::new) or a run-time setter rejected a value (the scenario layer validates
/// first, with the TOML key; this is the last line of defence).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PlantError {
    /// The inertia matrix is not positive definite (mass or inertias ≤ 0).
    #[error("the chassis inertia matrix is not positive definite (check mass and inertias)")]
    SingularInertia,
    /// A parameter is not finite or outside its physical range.
    #[error("plant parameter {0} is out of range")]
    OutOfRange(&'static str),
    /// A start in motion needs a wheel turning faster than its motor's no-load speed on
    /// the present supply: a speed the motor can never have given it.
    #[error(
        "the {wheel} wheel would turn at {needed_rad_s:.1} rad/s (slip {slip}), beyond its \
         motor's no-load speed of {no_load_rad_s:.1} rad/s on {supply_v} V"
    )]
    BeyondNoLoadSpeed {
        /// `left` or `right`.
        wheel: &'static str,
        /// The wheel speed the motion needs, rad/s (magnitude).
        needed_rad_s: f64,
        /// That wheel's slip ratio.
        slip: f64,
        /// The no-load speed at the supply, rad/s.
        no_load_rad_s: f64,
        /// The supply, V.
        supply_v: f64,
    },
}

/// The rule of [`PlantParams`] (module doc): `Ok` for a valid set, otherwise the first
/// out-of-range parameter by name.
pub(super) fn validate(params: &PlantParams) -> Result<(), PlantError> {
    for wheel in [Wheel::Left, Wheel::Right] {
        validate_motor(&params.motor_mismatch.wheel_motor(&params.motor, wheel))?;
    }
    let body = &params.body;
    let checks = [
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
    first_failed(&checks)
}

/// The rule for one wheel's motor `m` (with its share of the mismatch).
fn validate_motor(m: &MotorParams) -> Result<(), PlantError> {
    first_failed(&[
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
    ])
}

/// `Ok` when every check holds, else the name of the first that does not. (`x > 0.0` is
/// false for NaN, so the checks also reject NaN.)
fn first_failed(checks: &[(&'static str, bool)]) -> Result<(), PlantError> {
    match checks.iter().find(|(_, ok)| !ok) {
        Some((name, _)) => Err(PlantError::OutOfRange(name)),
        None => Ok(()),
    }
}
