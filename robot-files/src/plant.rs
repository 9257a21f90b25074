//! The simulated robot's parameters, as a scenario's `[plant]` states them and as the
//! simulator takes them: the H-bridge chip and its supply, the motor and gearbox, the
//! chassis' mass properties, what the wheels drive, and how the wheels are named. SI
//! units throughout. The model that uses them (bridge, motor, friction, chassis
//! dynamics, integration) is host-sim's `plant`.

/// Which H-bridge chip drives the motors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DriverKind {
    /// Toshiba TB6612FNG (the firmware's default board).
    #[default]
    Tb6612,
    /// TI DRV8833 (the firmware's `drv8833` feature).
    Drv8833,
}

impl DriverKind {
    /// Both kinds, for listings and tests.
    pub const ALL: [DriverKind; 2] = [DriverKind::Tb6612, DriverKind::Drv8833];

    /// On-resistance of one bridge path (high-side + low-side switch), typical, Ω. It is
    /// in series with the armature in both the drive and the brake phase.
    ///
    /// - TB6612FNG: 0.5 Ω, "Output low ON resistor: 0.5 Ω (upper + lower, typ. @ VM ≥
    ///   5 V)" (Toshiba TB6612FNG datasheet, features).
    /// - DRV8833: 0.36 Ω, "Low MOSFET on-resistance: HS + LS 360 mΩ" at VM = 5 V, 25 °C
    ///   (TI DRV8833 datasheet SLVSAR1, features).
    pub const fn on_resistance_ohm(self) -> f64 {
        match self {
            DriverKind::Tb6612 => 0.5,
            DriverKind::Drv8833 => 0.36,
        }
    }

    /// Motor supply (VM) range the datasheet specifies for operation, (min, max), V:
    /// TB6612FNG 2.5–13.5 V (pin table, VM); DRV8833 2.7–10.8 V (features, "wide power
    /// supply voltage range").
    pub const fn operating_supply_v(self) -> (f64, f64) {
        match self {
            DriverKind::Tb6612 => (2.5, 13.5),
            DriverKind::Drv8833 => (2.7, 10.8),
        }
    }

    /// Absolute maximum motor supply (VM) rating, V: TB6612FNG 15 V ("Power supply
    /// voltage: VM = 15 V (max)", absolute maximum ratings); DRV8833 11.8 V (absolute
    /// maximum ratings, VM). A supply above this destroys the chip; the firmware refuses
    /// to arm above it and the scenario loader rejects it.
    pub const fn max_supply_v(self) -> f64 {
        match self {
            DriverKind::Tb6612 => 15.0,
            DriverKind::Drv8833 => 11.8,
        }
    }

    /// The name used in scenario files: `tb6612` or `drv8833`.
    pub const fn name(self) -> &'static str {
        match self {
            DriverKind::Tb6612 => "tb6612",
            DriverKind::Drv8833 => "drv8833",
        }
    }
}

/// The H-bridge, its supply and its PWM timer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriverParams {
    /// The chip (its switch resistance is in series with the armature).
    pub kind: DriverKind,
    /// Supply (battery) voltage V_s, V.
    pub supply_v: f64,
    /// PWM resolution: the compare value of a 100 % duty (the timer's auto-reload + 1);
    /// the applied duty is a multiple of 1 / `pwm_levels`.
    pub pwm_levels: u32,
    /// Dead-band: a quantised |duty| below this fraction gives u = 0 V, dimensionless in
    /// [0, 1). It stands for the shortest drive pulse that makes it through the bridge
    /// (input-to-output propagation, rise and fall, the internal dead time) and for the
    /// motor's electrical start-up; a pulse shorter than that leaves the outputs in the
    /// brake state, so in slow decay a duty in the dead-band brakes (u = 0), it does not
    /// coast.
    pub dead_band_duty: f64,
}

impl DriverParams {
    /// TB6612FNG, 6 V supply, 5 000-level PWM (TIM3 at 100 MHz / 20 kHz), 2 % dead-band.
    pub const DEFAULT: DriverParams = DriverParams {
        kind: DriverKind::Tb6612,
        supply_v: 6.0,
        pwm_levels: 5000,
        dead_band_duty: 0.02,
    };
}

impl Default for DriverParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Motor and gearbox constants of one wheel, SI units.
///
/// The defaults ([`MotorParams::DEFAULT`]) describe a small 6 V brushed gear motor of the
/// "N20 / TT, 1:30" class driving a 65 mm wheel. With 6 V across its terminals: 36.2 rad/s
/// (1.18 m/s at the rim, 345 rpm) at no load, 1.5 A and 0.18 N·m at the wheel when
/// stalled. Behind a TB6612's 0.5 Ω on a 6 V supply: 35.7 rad/s, 1.33 A, 0.16 N·m.
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
    /// Gearbox efficiency η, 0 < η ≤ 1: × η on the torque when the motor drives the wheel,
    /// ÷ η when the wheel drives the motor (the back-driven gearbox must supply the
    /// motor's torque plus its losses).
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

/// How the right motor differs from the left, as split percentages: the left wheel's
/// constant is (1 + p/200) × [`MotorParams`]'s, the right wheel's (1 − p/200) ×, so the two
/// differ by p % of the nominal and their mean is the nominal (the convention of a
/// scenario's `wheel_radius_left_right_pct`). All 0 ([`MotorMismatch::NONE`]): both wheels
/// have the nominal motor. The rotor inertia and gear efficiency stay common.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotorMismatch {
    /// Armature resistance R_a, left − right, % of nominal.
    pub resistance_left_right_pct: f64,
    /// Torque constant K_t and back-EMF constant K_e together (one magnet, one winding),
    /// left − right, % of nominal.
    pub torque_constant_left_right_pct: f64,
    /// Viscous friction b, left − right, % of nominal.
    pub viscous_friction_left_right_pct: f64,
    /// Coulomb (and static) friction τ_c, left − right, % of nominal.
    pub coulomb_friction_left_right_pct: f64,
}

impl MotorMismatch {
    /// Both motors nominal.
    pub const NONE: MotorMismatch = MotorMismatch {
        resistance_left_right_pct: 0.0,
        torque_constant_left_right_pct: 0.0,
        viscous_friction_left_right_pct: 0.0,
        coulomb_friction_left_right_pct: 0.0,
    };

    /// The motor of `wheel`: `nominal` with this mismatch's share for that wheel. With
    /// every percentage 0 the result is `nominal`, bit for bit.
    pub fn wheel_motor(&self, nominal: &MotorParams, wheel: Wheel) -> MotorParams {
        let side = match wheel {
            Wheel::Left => 1.0,
            Wheel::Right => -1.0,
        };
        let scale = |pct: f64| 1.0 + side * pct / 200.0;
        let k = scale(self.torque_constant_left_right_pct);
        MotorParams {
            resistance_ohm: nominal.resistance_ohm * scale(self.resistance_left_right_pct),
            torque_constant_nm_per_a: nominal.torque_constant_nm_per_a * k,
            back_emf_v_s_per_rad: nominal.back_emf_v_s_per_rad * k,
            viscous_friction_nm_s_per_rad: nominal.viscous_friction_nm_s_per_rad
                * scale(self.viscous_friction_left_right_pct),
            coulomb_friction_nm: nominal.coulomb_friction_nm
                * scale(self.coulomb_friction_left_right_pct),
            ..*nominal
        }
    }
}

/// Chassis mass properties, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyParams {
    /// Total mass m, kg.
    pub mass_kg: f64,
    /// Yaw inertia I about the vertical axis through the wheel axle's midpoint, kg·m²
    /// (includes m d² for a centre of mass a distance d off the axle).
    pub yaw_inertia_kg_m2: f64,
    /// Inertia of one wheel (with hub) about its axle, kg·m².
    pub wheel_inertia_kg_m2: f64,
    /// Distance d of the centre of mass ahead of the wheel axle, along the robot's x axis
    /// (robot frame), m; negative behind. Needs m d² ≤ I.
    pub com_ahead_of_axle_m: f64,
}

impl BodyParams {
    /// A 0.5 kg robot with a 60 mm radius of gyration about the axle (I = 1.8e-3 kg·m²),
    /// 20 g wheels (2e-5 kg·m² each) and its centre of mass on the axle.
    pub const DEFAULT: BodyParams = BodyParams {
        mass_kg: 0.5,
        yaw_inertia_kg_m2: 1.8e-3,
        wheel_inertia_kg_m2: 2.0e-5,
        com_ahead_of_axle_m: 0.0,
    };
}

impl Default for BodyParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the wheels drive, and so the inertia each motor sees.
///
/// On the ground the chassis' mass and yaw inertia are coupled to the wheels (through the
/// simulator's 2 × 2 inertia matrix on the wheel speeds): the default robot's wheel sees 3.7e-4 kg·m² driving straight,
/// τ ≈ 89 ms. Lifted (on a stand, wheels in the air, the way wheel loops are often tuned
/// on a bench) each wheel sees only its own inertia and the reflected rotor's,
/// 1.1e-4 kg·m², τ ≈ 26 ms, the wheels are not coupled and the robot does not move.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Load {
    /// On the floor: the chassis is part of the load.
    #[default]
    Ground,
    /// On a stand: each wheel turns freely against its own inertia and friction.
    Lifted,
}

impl Load {
    /// The name used in scenario files: `ground` or `lifted`.
    pub const fn name(self) -> &'static str {
        match self {
            Load::Ground => "ground",
            Load::Lifted => "lifted",
        }
    }
}

/// One of the two driven wheels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wheel {
    /// The left wheel (index 0 in every `[left, right]` pair).
    Left,
    /// The right wheel (index 1).
    Right,
}

impl Wheel {
    /// The index of this wheel in `[left, right]` arrays.
    pub const fn index(self) -> usize {
        match self {
            Wheel::Left => 0,
            Wheel::Right => 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motor_mismatch_splits_about_the_nominal() {
        let nominal = MotorParams::DEFAULT;
        assert_eq!(
            MotorMismatch::NONE.wheel_motor(&nominal, Wheel::Left),
            nominal
        );
        assert_eq!(
            MotorMismatch::NONE.wheel_motor(&nominal, Wheel::Right),
            nominal
        );
        let m = MotorMismatch {
            torque_constant_left_right_pct: 4.0,
            coulomb_friction_left_right_pct: -10.0,
            ..MotorMismatch::NONE
        };
        let left = m.wheel_motor(&nominal, Wheel::Left);
        let right = m.wheel_motor(&nominal, Wheel::Right);
        // The left motor is 2 % stronger, the right 2 % weaker; K_e follows K_t.
        assert!(
            (left.torque_constant_nm_per_a / nominal.torque_constant_nm_per_a - 1.02).abs() < 1e-12
        );
        assert!((right.back_emf_v_s_per_rad / nominal.back_emf_v_s_per_rad - 0.98).abs() < 1e-12);
        // A negative split makes the right wheel's friction the larger.
        assert!(right.coulomb_friction_nm > nominal.coulomb_friction_nm);
        assert!(left.coulomb_friction_nm < nominal.coulomb_friction_nm);
        assert_eq!(left.resistance_ohm, nominal.resistance_ohm);
        assert_eq!(left.rotor_inertia_kg_m2, right.rotor_inertia_kg_m2);
    }

    #[test]
    fn default_pwm_has_the_firmware_timer_resolution() {
        // TIM3: 100 MHz timer clock / 20 kHz = 5 000 counts per period.
        assert_eq!(DriverParams::DEFAULT.pwm_levels, 100_000_000 / 20_000);
    }

    #[test]
    fn datasheet_figures_are_consistent() {
        for kind in DriverKind::ALL {
            let (lo, hi) = kind.operating_supply_v();
            assert!(0.0 < lo && lo < hi && hi < kind.max_supply_v(), "{kind:?}");
            assert!((0.1..1.0).contains(&kind.on_resistance_ohm()), "{kind:?}");
        }
        assert_eq!(DriverKind::default(), DriverKind::Tb6612);
    }
}
