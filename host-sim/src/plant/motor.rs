//! One wheel's drive: H-bridge (PWM duty × supply voltage), brushed DC motor and gearbox.
//!
//! ## Model
//!
//! The PWM frequency of a small robot's H-bridge (typically 20 kHz) is far above the
//! motor's electrical and mechanical bandwidth, so the bridge is modelled by its average:
//! the armature sees `u = d · V_s`, with the duty d first quantised to the timer's
//! resolution, clamped to [−1, 1] (the supply is the most the bridge can apply) and zeroed
//! inside the driver's dead-band.
//!
//! The armature inductance (≈ 1 mH on a 4 Ω motor: τ_e ≈ 0.25 ms) is far faster than the
//! mechanics (τ_m ≈ 60–80 ms) and is neglected, so the current is algebraic:
//!
//! i = (u − K_e · N · ω) / R_a
//!
//! with ω the **wheel** speed (rad/s) and N the gear ratio (motor turns per wheel turn).
//! The torque delivered at the wheel, before the robot's inertia, is
//!
//! τ = η · N · K_t · i − b · ω − τ_c · sgn(ω)
//!
//! with gearbox efficiency η, viscous friction b and Coulomb friction τ_c, both referred to
//! the wheel shaft. At rest (ω = 0) Coulomb friction is static friction: it cancels any
//! drive torque up to τ_c, so a wheel does not creep under a small duty
//! ([`WheelDrive::wheel_torque_nm`]).

/// Motor and gearbox constants of one wheel, SI units.
///
/// The defaults ([`MotorParams::DEFAULT`]) describe a small 6 V brushed gear motor of the
/// "N20 / TT, 1:30" class driving a 65 mm wheel: about 36 rad/s (1.2 m/s at the rim, 350
/// rpm) at no load, 1.5 A and 0.18 N·m at the wheel when stalled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Armature resistance R_a, Ω.
    pub resistance_ohm: f64,
    /// Torque constant K_t, N·m/A (motor shaft).
    pub torque_constant_nm_per_a: f64,
    /// Back-EMF constant K_e, V·s/rad (motor shaft). Equal to K_t in SI for an ideal motor.
    pub back_emf_v_s_per_rad: f64,
    /// Rotor inertia, kg·m² (motor shaft); reflected to the wheel as × N².
    pub rotor_inertia_kg_m2: f64,
    /// Gearbox efficiency η, 0 < η ≤ 1 (applied to the drive torque).
    pub gear_efficiency: f64,
    /// Viscous friction b at the wheel shaft, N·m·s/rad.
    pub viscous_friction_nm_s_per_rad: f64,
    /// Coulomb (and static) friction τ_c at the wheel shaft, N·m.
    pub coulomb_friction_nm: f64,
}

impl MotorParams {
    /// Default small 6 V gear motor (see the type's doc).
    pub const DEFAULT: MotorParams = MotorParams {
        resistance_ohm: 4.0,
        torque_constant_nm_per_a: 0.005,
        back_emf_v_s_per_rad: 0.005,
        rotor_inertia_kg_m2: 1.0e-7,
        gear_efficiency: 0.8,
        viscous_friction_nm_s_per_rad: 2.0e-4,
        coulomb_friction_nm: 0.01,
    };
}

impl Default for MotorParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The H-bridge that turns a duty into an armature voltage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriverParams {
    /// Supply (battery) voltage V_s, V.
    pub supply_v: f64,
    /// PWM resolution: the duty is rounded to a multiple of 1 / `pwm_levels` (for example
    /// a timer's auto-reload + 1).
    pub pwm_levels: u32,
    /// Dead-band: a quantised |duty| below this fraction gives 0 V (the bridge's minimum
    /// pulse width), dimensionless in [0, 1).
    pub dead_band_duty: f64,
}

impl DriverParams {
    /// 6 V supply, 1000-level PWM, 2 % dead-band.
    pub const DEFAULT: DriverParams = DriverParams {
        supply_v: 6.0,
        pwm_levels: 1000,
        dead_band_duty: 0.02,
    };

    /// The duty the bridge actually applies for a commanded `duty` (any f32, even NaN):
    /// clamped to [−1, 1], quantised to the PWM resolution, zeroed in the dead-band.
    /// A non-finite command gives 0.
    pub fn applied_duty(&self, duty: f32) -> f64 {
        let d = f64::from(duty);
        if !d.is_finite() {
            return 0.0;
        }
        let levels = f64::from(self.pwm_levels.max(1));
        let q = (d.clamp(-1.0, 1.0) * levels).round() / levels;
        if q.abs() < self.dead_band_duty {
            0.0
        } else {
            q
        }
    }

    /// Armature voltage for an applied duty (from [`DriverParams::applied_duty`]), V.
    pub fn voltage_v(&self, applied_duty: f64) -> f64 {
        applied_duty * self.supply_v
    }
}

impl Default for DriverParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Motor and gearbox constants folded into wheel-shaft quantities, for the integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelDrive {
    /// Stall torque per volt at the wheel, η N K_t / R_a, N·m/V.
    pub torque_per_volt: f64,
    /// Total damping at the wheel, η N² K_t K_e / R_a + b, N·m·s/rad.
    pub damping_nm_s_per_rad: f64,
    /// Coulomb friction at the wheel, N·m.
    pub coulomb_nm: f64,
    /// Current per volt, 1/R_a, A/V.
    current_per_volt: f64,
    /// Current per wheel rad/s of back-EMF, N K_e / R_a, A·s/rad.
    current_per_rad_s: f64,
}

impl WheelDrive {
    /// Folds `motor` through a gearbox of `gear_ratio` (motor turns per wheel turn).
    pub fn new(motor: &MotorParams, gear_ratio: f64) -> Self {
        let n = gear_ratio;
        let torque_per_volt =
            motor.gear_efficiency * n * motor.torque_constant_nm_per_a / motor.resistance_ohm;
        Self {
            torque_per_volt,
            damping_nm_s_per_rad: torque_per_volt * n * motor.back_emf_v_s_per_rad
                + motor.viscous_friction_nm_s_per_rad,
            coulomb_nm: motor.coulomb_friction_nm,
            current_per_volt: 1.0 / motor.resistance_ohm,
            current_per_rad_s: n * motor.back_emf_v_s_per_rad / motor.resistance_ohm,
        }
    }

    /// Net torque at the wheel shaft, N·m, for armature voltage `volts` (V) and wheel speed
    /// `speed_rad_s`. At exactly 0 rad/s the friction is static: it cancels the drive
    /// torque up to τ_c.
    #[inline]
    pub fn wheel_torque_nm(&self, volts: f64, speed_rad_s: f64) -> f64 {
        let drive = self.torque_per_volt * volts - self.damping_nm_s_per_rad * speed_rad_s;
        let friction = if speed_rad_s > 0.0 {
            -self.coulomb_nm
        } else if speed_rad_s < 0.0 {
            self.coulomb_nm
        } else {
            -drive.clamp(-self.coulomb_nm, self.coulomb_nm)
        };
        drive + friction
    }

    /// Armature current, A, at `volts` (V) and wheel speed `speed_rad_s` (rad/s).
    pub fn current_a(&self, volts: f64, speed_rad_s: f64) -> f64 {
        self.current_per_volt * volts - self.current_per_rad_s * speed_rad_s
    }

    /// Steady-state wheel speed (rad/s) at constant `volts` with no load other than the
    /// motor's own friction (the no-load speed when `volts` is the supply).
    pub fn steady_speed_rad_s(&self, volts: f64) -> f64 {
        let drive = self.torque_per_volt * volts.abs() - self.coulomb_nm;
        if drive <= 0.0 {
            0.0
        } else {
            volts.signum() * drive / self.damping_nm_s_per_rad
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_motor_has_the_stated_no_load_speed_and_stall_torque() {
        let d = WheelDrive::new(&MotorParams::DEFAULT, 30.0);
        let no_load = d.steady_speed_rad_s(6.0);
        assert!((35.0..40.0).contains(&no_load), "{no_load}");
        let stall = d.torque_per_volt * 6.0;
        assert!((stall - 0.18).abs() < 1e-9, "{stall}");
        assert!((d.current_a(6.0, 0.0) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn static_friction_holds_a_small_torque() {
        let d = WheelDrive::new(&MotorParams::DEFAULT, 30.0);
        // 0.1 V gives 0.003 N·m of drive, below τ_c = 0.01: no net torque at rest.
        assert_eq!(d.wheel_torque_nm(0.1, 0.0), 0.0);
        assert!(d.wheel_torque_nm(2.0, 0.0) > 0.0);
        assert!(d.wheel_torque_nm(-2.0, 0.0) < 0.0);
    }

    #[test]
    fn driver_quantises_clamps_and_dead_bands() {
        let drv = DriverParams::DEFAULT;
        assert_eq!(drv.applied_duty(0.12345), 0.123);
        assert_eq!(drv.applied_duty(1.7), 1.0);
        assert_eq!(drv.applied_duty(-0.015), 0.0);
        assert_eq!(drv.applied_duty(f32::NAN), 0.0);
        assert_eq!(drv.voltage_v(-0.5), -3.0);
    }
}
