//! One wheel's motor and gearbox, driven through the H-bridge of [`super::driver`].
//!
//! ## Model
//!
//! The armature inductance (≈ 1 mH on a 4 Ω motor: τ_e ≈ 0.25 ms) is far faster than the
//! mechanics (τ_m ≈ 60–80 ms) and is neglected, so while the bridge drives (slow decay,
//! averaged armature voltage u = d · V_s, u = 0 = short brake) the current is algebraic:
//!
//! i = (u − K_e · N · ω) / (R_a + R_bridge)
//!
//! with ω the **wheel** speed (rad/s), N the gear ratio (motor turns per wheel turn) and
//! R_bridge the driver's switch resistance ([`DriverKind::on_resistance_ohm`](robot_files::plant::DriverKind::on_resistance_ohm)).
//! With the bridge high impedance (coasting) i = 0.
//!
//! The gearbox loses a fraction of the power flowing through it, whichever way it flows:
//!
//! - motoring (i and ω of the same sign, or ω = 0): the motor drives the wheel and the
//!   wheel gets τ_e = η · N · K_t · i;
//! - back-driven (i and ω of opposite signs: braking, generating): the wheel drives the
//!   motor, and must supply the motor's torque plus the gear losses, τ_e = N · K_t · i / η.
//!
//! So for the same current a braking wheel sees 1/η² the torque of the motoring formula
//! (1.56 × at η = 0.8). τ_e is continuous at i = 0, where the two meet. The net torque at
//! the wheel, before the robot's inertia, is
//!
//! τ = τ_e − b · ω − τ_c · sgn(ω)
//!
//! with viscous friction b and Coulomb friction τ_c, both referred to the wheel shaft. At
//! rest (ω = 0) Coulomb friction is static friction; whether it holds the wheel is decided
//! with the other wheel's pull through the chassis ([`super::robot`]).
//!
//! The constants are [`MotorParams`], a scenario's `[plant.motor]`, each wheel with its
//! share of `[plant.motor_mismatch]` ([`MotorMismatch`](robot_files::plant::MotorMismatch)).

use robot_files::plant::MotorParams;

/// Which way power flows through one wheel's gearbox, and so which torque formula holds
/// (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PowerFlow {
    /// Bridge high impedance: no current, no electrical torque.
    Coasting,
    /// The motor drives the wheel (i · ω ≥ 0): τ_e = η · N · K_t · i.
    Motoring,
    /// The wheel drives the motor (i · ω < 0): τ_e = N · K_t · i / η.
    BackDriven,
}

/// Motor, gearbox and bridge resistance folded into wheel-shaft quantities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelDrive {
    /// Stall torque per volt at the wheel before the gear loss, N K_t / (R_a + R_bridge),
    /// N·m/V.
    pub torque_per_volt: f64,
    /// Electrical damping at the wheel before the gear loss, N² K_t K_e / (R_a + R_bridge),
    /// N·m·s/rad.
    pub emf_damping_nm_s_per_rad: f64,
    /// Gearbox efficiency η.
    pub efficiency: f64,
    /// Viscous friction b at the wheel, N·m·s/rad.
    pub viscous_nm_s_per_rad: f64,
    /// Coulomb (and static) friction τ_c at the wheel, N·m.
    pub coulomb_nm: f64,
    /// Back-EMF per wheel rad/s, N K_e, V·s/rad.
    pub back_emf_v_s_per_rad: f64,
    /// Armature plus bridge resistance R_a + R_bridge, Ω.
    pub circuit_resistance_ohm: f64,
}

impl WheelDrive {
    /// Folds `motor` through a gearbox of `gear_ratio` (motor turns per wheel turn), with
    /// `bridge_resistance_ohm` (Ω) of driver switches in series with the armature.
    pub fn new(motor: &MotorParams, gear_ratio: f64, bridge_resistance_ohm: f64) -> Self {
        let n = gear_ratio;
        let r = motor.resistance_ohm + bridge_resistance_ohm;
        let torque_per_volt = n * motor.torque_constant_nm_per_a / r;
        Self {
            torque_per_volt,
            emf_damping_nm_s_per_rad: torque_per_volt * n * motor.back_emf_v_s_per_rad,
            efficiency: motor.gear_efficiency,
            viscous_nm_s_per_rad: motor.viscous_friction_nm_s_per_rad,
            coulomb_nm: motor.coulomb_friction_nm,
            back_emf_v_s_per_rad: n * motor.back_emf_v_s_per_rad,
            circuit_resistance_ohm: r,
        }
    }

    /// Armature current, A, while the bridge drives at `volts` (V, 0 = brake) and the
    /// wheel turns at `speed_rad_s` (rad/s).
    pub fn current_a(&self, volts: f64, speed_rad_s: f64) -> f64 {
        (volts - self.back_emf_v_s_per_rad * speed_rad_s) / self.circuit_resistance_ohm
    }

    /// The power flow while driven at `volts` (V) at wheel speed `speed_rad_s` (rad/s).
    /// Decided on u − K_e N ω, which has the sign of the current.
    #[inline]
    pub fn power_flow(&self, volts: f64, speed_rad_s: f64) -> PowerFlow {
        if (volts - self.back_emf_v_s_per_rad * speed_rad_s) * speed_rad_s >= 0.0 {
            PowerFlow::Motoring
        } else {
            PowerFlow::BackDriven
        }
    }

    /// The gear factor on N K_t i for `flow`: η motoring, 1/η back-driven, 0 coasting.
    #[inline]
    pub fn gear_factor(&self, flow: PowerFlow) -> f64 {
        match flow {
            PowerFlow::Coasting => 0.0,
            PowerFlow::Motoring => self.efficiency,
            PowerFlow::BackDriven => 1.0 / self.efficiency,
        }
    }

    /// Total damping at the wheel for `flow`: gear factor × electrical damping + viscous
    /// friction, N·m·s/rad (the speed coefficient of the net torque away from rest).
    pub fn damping_nm_s_per_rad(&self, flow: PowerFlow) -> f64 {
        self.gear_factor(flow) * self.emf_damping_nm_s_per_rad + self.viscous_nm_s_per_rad
    }

    /// Electrical torque delivered to the wheel, N·m, while the bridge drives at `volts`
    /// (V) and the wheel turns at `speed_rad_s` (rad/s): η N K_t i motoring, N K_t i / η
    /// back-driven.
    #[inline]
    pub fn electrical_torque_nm(&self, volts: f64, speed_rad_s: f64) -> f64 {
        let flow = self.power_flow(volts, speed_rad_s);
        self.gear_factor(flow)
            * (self.torque_per_volt * volts - self.emf_damping_nm_s_per_rad * speed_rad_s)
    }

    /// Steady-state wheel speed (rad/s) at constant `volts` with no load other than the
    /// motor's own friction (the no-load speed when `volts` is the supply).
    pub fn steady_speed_rad_s(&self, volts: f64) -> f64 {
        let drive = self.efficiency * self.torque_per_volt * volts.abs() - self.coulomb_nm;
        if drive <= 0.0 {
            0.0
        } else {
            volts.signum() * drive / self.damping_nm_s_per_rad(PowerFlow::Motoring)
        }
    }

    /// The constant voltage (V) that holds the wheel at `speed_rad_s` (rad/s) against the
    /// motor's own friction: the inverse of [`WheelDrive::steady_speed_rad_s`] for a
    /// turning wheel.
    pub fn steady_volts(&self, speed_rad_s: f64) -> f64 {
        let torque =
            self.damping_nm_s_per_rad(PowerFlow::Motoring) * speed_rad_s.abs() + self.coulomb_nm;
        speed_rad_s.signum() * torque / (self.efficiency * self.torque_per_volt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_files::plant::DriverKind;

    fn tb6612_drive() -> WheelDrive {
        WheelDrive::new(
            &MotorParams::DEFAULT,
            30.0,
            DriverKind::Tb6612.on_resistance_ohm(),
        )
    }

    #[test]
    fn default_motor_has_the_stated_no_load_speed_and_stall_torque() {
        // The motor alone (no bridge resistance): 36.2 rad/s, 0.18 N·m, 1.5 A at 6 V.
        let bare = WheelDrive::new(&MotorParams::DEFAULT, 30.0, 0.0);
        assert!((bare.steady_speed_rad_s(6.0) - 36.17).abs() < 0.01);
        assert!((bare.electrical_torque_nm(6.0, 0.0) - 0.18).abs() < 1e-12);
        assert!((bare.current_a(6.0, 0.0) - 1.5).abs() < 1e-12);
        // Behind the TB6612's 0.5 Ω: 4.5 Ω in the circuit.
        let d = tb6612_drive();
        let no_load = d.steady_speed_rad_s(6.0);
        assert!((no_load - 35.71).abs() < 0.01, "{no_load}");
        assert!((d.electrical_torque_nm(6.0, 0.0) - 0.16).abs() < 1e-12);
        assert!((d.current_a(6.0, 0.0) - 6.0 / 4.5).abs() < 1e-12);
        // steady_volts inverts steady_speed_rad_s.
        assert!((d.steady_volts(no_load) - 6.0).abs() < 1e-12);
        assert!((d.steady_volts(-no_load) + 6.0).abs() < 1e-12);
        // At the no-load speed the motor still motors: it supplies the friction.
        assert_eq!(d.power_flow(6.0, no_load), PowerFlow::Motoring);
    }

    #[test]
    fn gear_efficiency_follows_the_power_flow() {
        let d = tb6612_drive();
        let eta = d.efficiency;
        let nkt_i = |volts: f64, w: f64| 30.0 * 0.005 * d.current_a(volts, w);
        for w in [20.0_f64, -20.0] {
            // Motoring: current and speed of the same sign.
            let u = 6.0 * w.signum();
            assert_eq!(d.power_flow(u, w), PowerFlow::Motoring);
            let motoring = d.electrical_torque_nm(u, w);
            assert!((motoring - eta * nkt_i(u, w)).abs() < 1e-15, "{motoring}");
            assert!(motoring * w > 0.0);
            // Short brake at the same speed: the wheel drives the motor.
            assert_eq!(d.power_flow(0.0, w), PowerFlow::BackDriven);
            let braking = d.electrical_torque_nm(0.0, w);
            assert!((braking - nkt_i(0.0, w) / eta).abs() < 1e-15, "{braking}");
            assert!(braking * w < 0.0, "a brake opposes the motion");
            // The same current magnitude gives 1/η² the torque when back-driven: choose
            // the drive voltage whose current mirrors the brake current.
            let mirror = 2.0 * d.back_emf_v_s_per_rad * w;
            assert!((d.current_a(mirror, w) + d.current_a(0.0, w)).abs() < 1e-12);
            let ratio = -braking / d.electrical_torque_nm(mirror, w);
            assert!((ratio - 1.0 / (eta * eta)).abs() < 1e-12, "{ratio}");
        }
        // Continuous where the current changes sign.
        let w = 20.0;
        let u0 = d.back_emf_v_s_per_rad * w;
        assert!(d.electrical_torque_nm(u0, w).abs() < 1e-15);
        assert!(d.electrical_torque_nm(u0 + 1e-9, w).abs() < 1e-9);
        assert!(d.electrical_torque_nm(u0 - 1e-9, w).abs() < 1e-9);
        // At rest the motor motors (η), whatever the voltage's sign.
        assert_eq!(d.power_flow(-3.0, 0.0), PowerFlow::Motoring);
        assert!((d.electrical_torque_nm(-3.0, 0.0) + eta * nkt_i(3.0, 0.0)).abs() < 1e-15);
        // Back-driven damping exceeds motoring damping by the factor 1/η² on the EMF part.
        let emf = |flow| d.damping_nm_s_per_rad(flow) - d.viscous_nm_s_per_rad;
        let ratio = emf(PowerFlow::BackDriven) / emf(PowerFlow::Motoring);
        assert!((ratio - 1.0 / (eta * eta)).abs() < 1e-12);
        assert_eq!(emf(PowerFlow::Coasting), 0.0);
    }
}
