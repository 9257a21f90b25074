//! The H-bridge between the PWM timer and the motor: which chip, how a duty becomes an
//! armature voltage, and what the bridge does when it is not driving.
//!
//! ## Slow decay, averaged
//!
//! Both supported drivers run in slow decay (drive/brake PWM). For a forward duty d the
//! bridge alternates between *drive* (supply across the armature through one high-side
//! and one low-side switch) for a fraction d of each PWM period and *short brake* (both
//! armature leads on the low-side switches) for the rest:
//!
//! - TB6612FNG: IN1/IN2 set the direction, PWMx low = short brake;
//! - DRV8833: forward IN1 = 1 with IN2 = PWM (IN2 high = both high = brake), reverse
//!   mirrored.
//!
//! At 20 kHz the PWM period (50 µs) is far below the armature's electrical time constant
//! (L/R ≈ 0.25 ms) and the mechanics (60–80 ms), so the bridge is modelled by its
//! average: the armature sees u = d · V_s through the bridge's switch resistance, which is
//! the same in both phases (one high-side + one low-side switch while driving, two
//! low-side switches while braking; the datasheets quote high + low side, and the two
//! sides are close). d = 0 is therefore a full-time short brake (u = 0, current −e/R),
//! not a coast. This average is exact for slow decay; fast decay (the other half-bridge
//! held low, current recirculating through the supply) would not be linear in d.
//!
//! ## Coast
//!
//! With the driver disabled (TB6612 STBY low, DRV8833 nSLEEP low) or a motor lead
//! disconnected, the bridge is high impedance and no armature current flows: only
//! friction slows the wheel. (The switches' body diodes would conduct if the back-EMF
//! exceeded V_s plus two diode drops, about V_s + 1.4 V; the default motor's back-EMF at
//! its no-load speed is 5.4 V on a 6 V supply, so this regeneration is not modelled.)
//!
//! ## PWM quantisation
//!
//! The firmware's TIM3 runs from the 100 MHz APB1 timer clock (APB1 = 50 MHz, doubled for
//! the timers) at 20 kHz: stm32f4xx-hal 0.23's `pwm_hz` sets prescaler 0 and auto-reload
//! 4 999, and `max_duty_cycle()` returns ARR + 1 = 5 000, the compare value of a 100 %
//! duty. The firmware writes `(|d| · 5000 + 0.5) as u16` computed in `f32` (0 for
//! |d| ≤ 0 or NaN, 5 000 for |d| ≥ 1), and [`DriverParams::compare_value`] does the same
//! arithmetic, so the simulated duty is exactly the one the timer produces. (On an
//! STM32F401 at 84 MHz the same code gives 4 200 levels.)

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

    /// The compare value the firmware writes for a commanded `duty` (any f32): |duty|
    /// scaled to `pwm_levels`, rounded half up in `f32` exactly as the firmware's
    /// `motor::compare_value` does; 0 for |duty| = 0 or NaN, `pwm_levels` for |duty| ≥ 1.
    pub fn compare_value(&self, duty: f32) -> u32 {
        let magnitude = if duty >= 0.0 { duty } else { -duty };
        let levels = self.pwm_levels.max(1);
        if magnitude >= 1.0 {
            levels
        } else if magnitude > 0.0 {
            // f32 arithmetic as on the target; `as` saturates, and the product is below
            // `levels` + 0.5 here.
            (magnitude * levels as f32 + 0.5) as u32
        } else {
            0
        }
    }

    /// The duty the bridge actually applies for a commanded `duty` (any f32, even NaN):
    /// the firmware's compare value ([`DriverParams::compare_value`]) over `pwm_levels`,
    /// with the command's sign, zeroed in the dead-band. In [−1, 1].
    pub fn applied_duty(&self, duty: f32) -> f64 {
        let q = f64::from(self.compare_value(duty)) / f64::from(self.pwm_levels.max(1));
        if q < self.dead_band_duty || q == 0.0 {
            0.0
        } else if duty < 0.0 {
            -q
        } else {
            q
        }
    }

    /// Averaged armature voltage (before the bridge's resistance) for an applied duty
    /// (from [`DriverParams::applied_duty`]) at supply `supply_v`, V.
    pub fn voltage_v(applied_duty: f64, supply_v: f64) -> f64 {
        applied_duty * supply_v
    }
}

impl Default for DriverParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What one wheel's bridge applies to its motor for the next plant steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BridgeOutput {
    /// Driven in slow decay: averaged armature voltage u = d · V_s, V, behind the bridge's
    /// on-resistance. 0 V is a short brake.
    Drive {
        /// u, V.
        volts: f64,
    },
    /// High impedance (driver disabled or motor disconnected): no armature current.
    Coast,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's `compare_value` (firmware/src/motor.rs), restated for a `u32`
    /// maximum: the reference the plant must match.
    fn firmware_compare(duty: f32, max: u32) -> u32 {
        let magnitude = if duty >= 0.0 { duty } else { -duty };
        if magnitude >= 1.0 {
            max
        } else if magnitude > 0.0 {
            (magnitude * max as f32 + 0.5) as u32
        } else {
            0
        }
    }

    #[test]
    fn default_pwm_has_the_firmware_timer_resolution() {
        // TIM3: 100 MHz timer clock / 20 kHz = 5 000 counts per period.
        assert_eq!(DriverParams::DEFAULT.pwm_levels, 100_000_000 / 20_000);
    }

    #[test]
    fn quantisation_matches_the_firmware_rounding() {
        let drv = DriverParams {
            dead_band_duty: 0.0,
            ..DriverParams::DEFAULT
        };
        let levels = drv.pwm_levels;
        // Every level's own duty maps back to it, and the half-way points round up.
        for k in 0..=levels {
            let exact = k as f32 / levels as f32;
            assert_eq!(drv.compare_value(exact), k, "{k}");
            assert_eq!(drv.compare_value(-exact), k, "-{k}");
            let below_half = (k as f32 + 0.45) / levels as f32;
            let above_half = (k as f32 + 0.55) / levels as f32;
            if k < levels {
                assert_eq!(drv.compare_value(below_half), k, "{k} + 0.45");
                assert_eq!(drv.compare_value(above_half), k + 1, "{k} + 0.55");
            }
            assert_eq!(
                drv.applied_duty(-exact),
                -f64::from(k) / f64::from(levels),
                "{k}"
            );
        }
        // The rounding happens in f32, as on the target: just below a half-way point the
        // f32 product can round up to it where f64 arithmetic would not. Find such duties
        // and check the plant follows f32.
        let mut differing = 0;
        for k in 0..levels {
            let mut d = (k as f32 + 0.5) / levels as f32;
            for _ in 0..4 {
                d = f32::from_bits(d.to_bits() - 1);
                let f64_round = (f64::from(d) * f64::from(levels) + 0.5).floor() as u32;
                let firmware = firmware_compare(d, levels);
                assert_eq!(drv.compare_value(d), firmware, "{d}");
                if firmware != f64_round {
                    differing += 1;
                }
            }
        }
        assert!(differing > 0, "no duty where f32 and f64 rounding differ");
        // Saturation, zero and NaN.
        assert_eq!(drv.compare_value(1.7), levels);
        assert_eq!(drv.compare_value(-1.0), levels);
        assert_eq!(drv.compare_value(0.0), 0);
        assert_eq!(drv.compare_value(f32::NAN), 0);
        assert_eq!(drv.applied_duty(f32::NAN), 0.0);
        assert_eq!(drv.applied_duty(f32::INFINITY), 1.0);
        assert_eq!(drv.applied_duty(f32::NEG_INFINITY), -1.0);
    }

    #[test]
    fn dead_band_gives_zero_volts() {
        let drv = DriverParams::DEFAULT;
        // 0.015 → 75 / 5000 = 1.5 % < 2 %: braked.
        assert_eq!(drv.applied_duty(-0.015), 0.0);
        assert_eq!(drv.applied_duty(0.019), 0.0);
        assert_eq!(drv.applied_duty(0.02), 0.02);
        assert_eq!(drv.applied_duty(0.12345), 617.0 / 5000.0);
        assert_eq!(DriverParams::voltage_v(-0.5, 6.0), -3.0);
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
