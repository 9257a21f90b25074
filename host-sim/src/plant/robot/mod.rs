//! The robot's body: two driven wheels coupled through the chassis, slip, faults and the
//! true pose — [`Plant`].
//!
//! Per wheel, an H-bridge ([`super::driver`]) drives a DC motor and gearbox
//! ([`super::motor`]); the two wheels are coupled through the chassis' mass, yaw inertia
//! and centre of mass, with static friction that sees the coupling; the state (wheel
//! speeds and angles) is integrated exactly over each control period while it stays in
//! one regime, with RK4 at the plant rate otherwise, the bridge held over the period; the
//! contact points move the true pose, with slip. Each concern is
//! one file, whose module doc states its contract and derivation:
//!
//! | file | concern |
//! |---|---|
//! | `params.rs` | [`PlantParams`], [`TrueGeometry`], [`PlantError`]: what a valid robot is |
//! | `chassis.rs` | the inertia matrix on (ω_l, ω_r), the centre-of-mass terms, lifted wheels, static friction with the coupling |
//! | `bridge.rs` | duties, the enable line, what each bridge applies, the currents |
//! | `faults.rs` | the fault hooks: motor lead off, jammed wheel, slip patch, supply sag |
//! | `integration.rs` | the exact solution over a hold while it stays in one regime, else RK4 at the plant rate; [`Plant::advance`], [`Integration`] |
//! | `pose.rs` | the wheel-ground contact with slip and the true pose |
//!
//! Contract of the whole: [`Plant::new`] refuses parameters out of range; the setters take
//! effect from the next [`Plant::advance`], which moves the state by whole plant steps;
//! the same parameters, calls and steps give the same numbers, bit for bit.

mod bridge;
mod chassis;
mod faults;
mod integration;
mod params;
mod pose;
#[cfg(test)]
mod tests;

use robot_files::plant::{Load, Wheel};

use self::chassis::inertia_matrix_kg_m2;
use self::integration::Propagators;
use self::pose::PoseTrack;
use super::friction::{Friction, Inertia};
use super::motor::WheelDrive;

pub use self::integration::Integration;
pub use self::params::{PlantError, PlantParams, TrueGeometry};

/// The simulated robot: parameters, state, bridge and fault state, and the integrator
/// (module doc; each group of fields is the concern of one file, named beside it).
#[derive(Clone, Debug)]
pub struct Plant {
    // Parameters and the chassis coupling (`params`, `chassis`).
    params: PlantParams,
    /// Each wheel's motor, gearbox and bridge resistance [left, right].
    drives: [WheelDrive; 2],
    /// The chassis' inertia matrix and the wheels' Coulomb/static friction.
    friction: Friction,
    /// m · d, kg·m (0: centre of mass on the axle, no centre-of-mass terms).
    mass_com: f64,
    /// Mean true wheel radius R and true track width L, m.
    radius_m: f64,
    track_m: f64,
    // The integrator (`integration`).
    /// How `advance` integrates.
    integration: Integration,
    /// Closed-form RK4 per regime pair, for the last plant step size.
    rk4: Propagators,
    /// The exact solution per regime pair, for the last hold.
    exact: Propagators,
    /// Wheel speeds [left, right], rad/s.
    speed: [f64; 2],
    /// Wheel angles [left, right], rad (what the encoders see).
    angle: [f64; 2],
    // The bridge (`bridge`) and the fault hooks (`faults`).
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
    // The contact and the true pose (`pose`).
    /// The true pose.
    pose: PoseTrack,
    /// Ground distance per wheel radian [left, right]: (1 − s_i)·R_i, m/rad.
    ground_per_rad: [f64; 2],
}

impl Plant {
    /// A robot with `params`, at rest at the origin, driver enabled, duties 0 (braking),
    /// no faults; [`PlantError`] for parameters out of range or a chassis whose inertia
    /// matrix is not positive definite.
    pub fn new(params: PlantParams) -> Result<Self, PlantError> {
        params::validate(&params)?;
        let body = &params.body;
        let g = &params.geometry;
        let r = 0.5 * (g.wheel_radius_left_m + g.wheel_radius_right_m);
        let [a, b] = inertia_matrix_kg_m2(&params);
        let inertia = Inertia::new(a, b).ok_or(PlantError::SingularInertia)?;
        let drives = [Wheel::Left, Wheel::Right].map(|wheel| {
            WheelDrive::new(
                &params.motor_mismatch.wheel_motor(&params.motor, wheel),
                params.gear_ratio,
                params.driver.kind.on_resistance_ohm(),
            )
        });
        let mut plant = Self {
            drives,
            friction: Friction {
                inertia,
                coulomb_nm: drives.map(|d| d.coulomb_nm),
            },
            // Lifted, the chassis does not move: no centre-of-mass terms.
            mass_com: match params.load {
                Load::Ground => body.mass_kg * body.com_ahead_of_axle_m,
                Load::Lifted => 0.0,
            },
            radius_m: r,
            track_m: g.track_width_m,
            integration: Integration::default(),
            rk4: Propagators::new(&drives, &inertia, 0.0, false),
            exact: Propagators::new(&drives, &inertia, 0.0, true),
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
            pose: PoseTrack::ORIGIN,
            ground_per_rad: [0.0; 2],
            params,
        };
        plant.update_ground_per_rad();
        plant.update_bridge();
        Ok(plant)
    }

    /// The parameters the plant was built with (the supply and slip may have changed
    /// since: see [`Plant::supply_v`] and [`Plant::slip`]).
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// `wheel`'s motor, gearbox and bridge resistance folded into wheel-shaft quantities.
    pub fn drive(&self, wheel: Wheel) -> &WheelDrive {
        &self.drives[wheel.index()]
    }

    /// True wheel speeds [left, right], rad/s.
    pub fn wheel_speeds(&self) -> [f64; 2] {
        self.speed
    }

    /// Wheel angles [left, right] since the last reset, rad.
    pub fn wheel_angles(&self) -> [f64; 2] {
        self.angle
    }
}
